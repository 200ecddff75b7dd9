// Camera projection and rig file I/O: written with OpenCV FileStorage, read with yaml-cpp.
#include "tracker/model/camera.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <limits>
#include <optional>
#include <span>
#include <sstream>
#include <stdexcept>
#include <string_view>
#include <utility>

#include <yaml-cpp/eventhandler.h>
#include <yaml-cpp/yaml.h>
#include <opencv2/core.hpp>

namespace mocap {

Eigen::Vector2d CameraModel::projectCameraPoint(const Eigen::Vector3d& p) const {
  const double x = p.x() / p.z();
  const double y = p.y() / p.z();
  const auto& [k1, k2, p1, p2, k3] = distortion;
  const double r2 = x * x + y * y;
  const double radial = 1 + r2 * (k1 + r2 * (k2 + r2 * k3));
  const double xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x);
  const double yd = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y;
  return {fx * xd + cx, fy * yd + cy};
}

bool CameraModel::project(const Eigen::Vector3d& world, Eigen::Vector2d& pixel) const {
  const Eigen::Vector3d p = toCamera(world);
  if (p.z() < kMinDepth) return false;
  pixel = projectCameraPoint(p);
  return true;
}

Eigen::Vector3d CameraModel::backProject(const Eigen::Vector2d& pixel) const {
  const double xd = (pixel.x() - cx) / fx;
  const double yd = (pixel.y() - cy) / fy;
  const auto& [k1, k2, p1, p2, k3] = distortion;
  double x = xd, y = yd;
  // The distortion is a small correction within the image, so x = (xd - tangential) / radial
  // converges in a few rounds; 20 bring it to the rounding of a double for lenses seen here.
  for (int i = 0; i < 20; ++i) {
    const double r2 = x * x + y * y;
    const double radial = 1 + r2 * (k1 + r2 * (k2 + r2 * k3));
    x = (xd - 2 * p1 * x * y - p2 * (r2 + 2 * x * x)) / radial;
    y = (yd - p1 * (r2 + 2 * y * y) - 2 * p2 * x * y) / radial;
  }
  return (rotation.transpose() * Eigen::Vector3d(x, y, 1)).normalized();
}

CameraModel CameraModel::lookAt(const std::string& name, const Eigen::Vector3d& eye,
                                const Eigen::Vector3d& target, const Eigen::Vector3d& up, int width,
                                int height, double focal_px) {
  CameraModel cam;
  cam.name = name;
  cam.width = width;
  cam.height = height;
  cam.fx = cam.fy = focal_px;
  cam.cx = width / 2.0;
  cam.cy = height / 2.0;
  const Eigen::Vector3d forward = (target - eye).normalized();  // camera z
  Eigen::Vector3d right = forward.cross(up);                    // camera x
  if (right.norm() < 1e-9) right = forward.unitOrthogonal();
  right.normalize();
  const Eigen::Vector3d down = forward.cross(right);  // camera y
  cam.rotation.row(0) = right.transpose();
  cam.rotation.row(1) = down.transpose();
  cam.rotation.row(2) = forward.transpose();
  cam.translation = -cam.rotation * eye;
  return cam;
}

namespace {

void requireFinite(std::span<const double> values, const std::string& where) {
  if (!std::ranges::all_of(values, [](double v) { return std::isfinite(v); }))
    throw std::runtime_error(where + ": not a finite number");
}

// The longest string OpenCV's FileStorage writes (CV_FS_MAX_LEN); longer ones throw cv::Exception.
constexpr std::size_t kMaxWrittenString = 4096;

// `text` as a YAML double-quoted scalar. OpenCV's writer would take a name starting with '[' or '{'
// as the start of a structure, drop trailing spaces and the quotes of a name already in quotes;
// text in double quotes it writes as it is.
std::string yamlQuoted(std::string_view text) {
  std::string out = "\"";
  for (const char c : text) {
    if (c == '"' || c == '\\') {
      out += '\\';
      out += c;
    } else if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) {
      constexpr std::string_view kHex = "0123456789abcdef";
      out += "\\x";
      out += kHex[static_cast<unsigned char>(c) >> 4];
      out += kHex[c & 0xf];
    } else {
      out += c;  // UTF-8 bytes as they are: "\x" would name a code point, not a byte
    }
  }
  return out + '"';
}

// What loadRig refuses in a camera's values once read: the one check of both reading and writing.
void checkCameraValues(const CameraModel& c, const std::string& where) {
  requireFinite(std::array{c.fx, c.fy, c.cx, c.cy}, where + ".camera_matrix");
  if (c.fx <= 0 || c.fy <= 0)
    throw std::runtime_error(where + ".camera_matrix: focal lengths must be positive");
  requireFinite(c.distortion, where + ".distortion_coefficients");
  requireFinite({c.rotation.data(), 9}, where + ".R");
  requireFinite({c.translation.data(), 3}, where + ".T");
  const double orthogonality =
      (c.rotation * c.rotation.transpose() - Eigen::Matrix3d::Identity()).norm();
  if (orthogonality > 1e-4 || c.rotation.determinant() < 0)
    throw std::runtime_error(where + ".R: not a rotation matrix");
}

// Refuses what saveRig cannot write so that loadRig reads it back, before the file is opened.
void checkWritable(const CameraModel& c, const std::string& where) {
  if (yamlQuoted(c.name).size() > kMaxWrittenString)
    throw std::runtime_error(where + ".name: " + std::to_string(c.name.size()) +
                             " bytes, too long for a rig file");
  if (c.width <= 0 || c.height <= 0)
    throw std::runtime_error(where + ": image size must be positive, got " +
                             std::to_string(c.width) + "x" + std::to_string(c.height));
  checkCameraValues(c, where);
}

}  // namespace

void saveRig(const std::string& path, const Rig& rig) {
  for (std::size_t i = 0; i < rig.size(); ++i)
    checkWritable(rig[i], path + ": camera_" + std::to_string(i));
  cv::FileStorage fs(path, cv::FileStorage::WRITE);
  if (!fs.isOpened()) throw std::runtime_error(path + ": cannot open for writing");
  fs << "camera_count" << static_cast<int>(rig.size());
  for (std::size_t i = 0; i < rig.size(); ++i) {
    const CameraModel& c = rig[i];
    cv::Mat k = (cv::Mat_<double>(3, 3) << c.fx, 0, c.cx, 0, c.fy, c.cy, 0, 0, 1);
    cv::Mat dist(5, 1, CV_64F);
    for (int j = 0; j < 5; ++j) dist.at<double>(j) = c.distortion[j];
    cv::Mat r(3, 3, CV_64F), t(3, 1, CV_64F);
    for (int a = 0; a < 3; ++a) {
      t.at<double>(a) = c.translation[a];
      for (int b = 0; b < 3; ++b) r.at<double>(a, b) = c.rotation(a, b);
    }
    fs << "camera_" + std::to_string(i) << "{";
    fs << "name" << yamlQuoted(c.name) << "image_width" << c.width << "image_height" << c.height;
    fs << "camera_matrix" << k << "distortion_coefficients" << dist << "R" << r << "T" << t;
    fs << "}";
  }
}

namespace {

// A number as OpenCV's FileStorage YAML reads it: a plain (unquoted) scalar starting with a digit,
// a sign or a point; integers in decimal, 0x hexadecimal or 0-prefixed octal; .inf and .nan.
struct Number {
  double value = 0;
  bool is_integer = false;
};

std::optional<Number> integerNumber(std::string_view text) {
  const bool negative = text.front() == '-';
  if (text.front() == '-' || text.front() == '+') text.remove_prefix(1);
  int base = 10;
  if (text.size() > 2 && text[0] == '0' && (text[1] == 'x' || text[1] == 'X')) {
    base = 16;
    text.remove_prefix(2);
  } else if (text.size() > 1 && text[0] == '0') {
    base = 8;
  }
  if (text.empty() || !std::isxdigit(static_cast<unsigned char>(text[0]))) return std::nullopt;
  long long magnitude = 0;
  const auto [end, error] =
      std::from_chars(text.data(), text.data() + text.size(), magnitude, base);
  if (error != std::errc() || end != text.data() + text.size()) return std::nullopt;
  return Number{static_cast<double>(negative ? -magnitude : magnitude), true};
}

std::optional<Number> readNumber(const YAML::Node& node) {
  // yaml-cpp tags a quoted scalar "!": OpenCV reads quoted text as a string, never a number.
  if (!node.IsScalar() || node.Tag() == "!" || node.Scalar().empty()) return std::nullopt;
  std::string_view text = node.Scalar();
  const std::string_view unsigned_text = text.substr(text[0] == '-' || text[0] == '+' ? 1 : 0);
  const auto lower = [](std::string_view s) {
    std::string out(s);
    for (char& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return out;
  };
  if (lower(unsigned_text) == ".inf") return Number{text[0] == '-' ? -HUGE_VAL : HUGE_VAL, false};
  if (lower(unsigned_text) == ".nan") return Number{std::nan(""), false};
  const auto digit = [](char c) { return c >= '0' && c <= '9'; };
  const bool starts_as_number =
      digit(unsigned_text.empty() ? ' ' : unsigned_text[0]) ||
      (unsigned_text.size() > 1 && unsigned_text[0] == '.' && digit(unsigned_text[1]));
  if (!starts_as_number) return std::nullopt;
  if (const std::optional<Number> integer = integerNumber(text)) return integer;
  if (unsigned_text.find_first_not_of("0123456789.eE+-") != std::string_view::npos)
    return std::nullopt;
  if (text[0] == '+') text.remove_prefix(1);
  double value = 0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (end != text.data() + text.size()) return std::nullopt;
  // Beyond a double's range: infinity, zero or a subnormal, as OpenCV (strtod) reads it.
  if (error == std::errc::result_out_of_range)
    value = std::strtod(std::string(text).c_str(), nullptr);
  else if (error != std::errc())
    return std::nullopt;
  return Number{value, false};
}

// A matrix of a rig file, its values in row order.
struct Matrix {
  int rows = 0;
  int cols = 0;
  std::vector<double> values;
};

// `value` stored as an element of OpenCV type `dt` (one of "ucwsifdh"), as OpenCV reads it:
// integers rounded and saturated, floats rounded to their precision.
double storedAs(char dt, double value) {
  const auto to_float = [](double v) {
    return std::isfinite(v) && std::abs(v) > std::numeric_limits<float>::max()
               ? std::copysign(std::numeric_limits<float>::infinity(), v)
               : static_cast<float>(v);
  };
  switch (dt) {
    case 'u':
      return cv::saturate_cast<uchar>(value);
    case 'c':
      return cv::saturate_cast<schar>(value);
    case 'w':
      return cv::saturate_cast<ushort>(value);
    case 's':
      return cv::saturate_cast<short>(value);
    case 'i':
      return cv::saturate_cast<int>(value);
    case 'f':
      return to_float(value);
    case 'h':
      return static_cast<float>(cv::float16_t(to_float(value)));
    default:
      return value;
  }
}

// The size OpenCV gives a matrix map: rows and cols, or (rows absent or negative) `sizes` of one
// or two dimensions. Reals are rounded as OpenCV rounds them.
std::pair<int, int> matrixSize(const YAML::Node& node, const std::string& where) {
  const auto dimension = [&](const YAML::Node& field, const char* name) {
    if (!field) return -1;
    const std::optional<Number> n = readNumber(field);
    if (!n) throw std::runtime_error(where + ": not an OpenCV matrix: " + name + " not a number");
    return cv::saturate_cast<int>(n->value);
  };
  const int rows = dimension(node["rows"], "rows");
  if (rows >= 0) return {rows, dimension(node["cols"], "cols")};
  const YAML::Node sizes = node["sizes"];
  if (sizes && sizes.IsScalar()) return {dimension(sizes, "sizes"), 1};
  if (!sizes || !sizes.IsSequence() || sizes.size() < 1 || sizes.size() > 2)
    throw std::runtime_error(where + ": not an OpenCV matrix: no rows, or sizes of 1 or 2 values");
  return {dimension(sizes[0], "sizes"), sizes.size() == 2 ? dimension(sizes[1], "sizes") : 1};
}

// Any non-empty single-channel OpenCV matrix (rows, cols, dt, data) at `node`.
Matrix readAnyMatrix(const YAML::Node& node, const std::string& where) {
  if (!node) throw std::runtime_error(where + ": missing");
  if (!node.IsMap()) throw std::runtime_error(where + ": not an OpenCV matrix: not a map");
  const auto [rows, cols] = matrixSize(node, where);
  // A corrupt size must not ask for gigabytes: more than a rig's matrices hold is refused first.
  constexpr double kMaxValues = 16;
  if (static_cast<double>(rows) * cols > kMaxValues)
    throw std::runtime_error(where + ": " + std::to_string(rows) + "x" + std::to_string(cols) +
                             " is larger than any matrix of a rig");
  if (rows <= 0 || cols <= 0)
    throw std::runtime_error(where + ": not an OpenCV matrix: size " + std::to_string(rows) + "x" +
                             std::to_string(cols));
  const YAML::Node dt = node["dt"];
  const std::string type = dt && dt.IsScalar() ? dt.Scalar() : "";
  const std::string_view element = std::string_view(type).substr(type.starts_with('1') ? 1 : 0);
  if (element.size() != 1 || std::string_view("ucwsifdh").find(element[0]) == std::string::npos)
    throw std::runtime_error(where + ": not an OpenCV matrix: dt '" + type +
                             "' is not one of u c w s i f d h");
  const YAML::Node data = node["data"];
  const std::size_t count = !data ? 0 : data.IsSequence() ? data.size() : data.IsScalar() ? 1 : 0;
  if (count != static_cast<std::size_t>(rows * cols))
    throw std::runtime_error(where + ": not an OpenCV matrix: data holds " + std::to_string(count) +
                             " values for " + std::to_string(rows) + "x" + std::to_string(cols));
  Matrix m{rows, cols, {}};
  for (std::size_t i = 0; i < count; ++i) {
    const std::optional<Number> n = readNumber(data.IsSequence() ? data[i] : data);
    if (!n)
      throw std::runtime_error(where + ": not an OpenCV matrix: data[" + std::to_string(i) +
                               "] is not a number");
    m.values.push_back(storedAs(element[0], n->value));
  }
  return m;
}

Matrix readMatrix(const YAML::Node& node, const std::string& where, int rows, int cols) {
  Matrix m = readAnyMatrix(node, where);
  // A column where a row belongs (or the reverse) holds the same values in the same order.
  if (m.values.size() != static_cast<std::size_t>(rows * cols) ||
      (m.rows != rows && m.cols != rows))
    throw std::runtime_error(where + ": expected " + std::to_string(rows) + "x" +
                             std::to_string(cols) + ", got " + std::to_string(m.rows) + "x" +
                             std::to_string(m.cols));
  return m;
}

int readPositiveInt(const YAML::Node& node, const std::string& where) {
  const std::optional<Number> n = node ? readNumber(node) : std::nullopt;
  if (!n || !n->is_integer || n->value < std::numeric_limits<int>::min() ||
      n->value > std::numeric_limits<int>::max())
    throw std::runtime_error(where + ": missing or not an integer");
  const int v = static_cast<int>(n->value);
  if (v <= 0) throw std::runtime_error(where + ": must be positive, got " + std::to_string(v));
  return v;
}

// A camera's name as OpenCV read it. yaml-cpp reads "~" and "null" (which saveRig writes
// unquoted) as null, so those words come from the text; a list or a map was read as empty text.
std::string cameraName(const YAML::Node& name, const std::string& key, std::string_view text) {
  if (!name) return key;
  if (name.IsScalar()) return name.Scalar();
  if (!name.IsNull()) return "";
  const int pos = name.Mark().pos;
  const std::string_view rest =
      pos >= 0 && pos < static_cast<int>(text.size()) ? text.substr(pos) : "";
  for (const std::string_view word : {"~", "null", "Null", "NULL"})
    if (rest.starts_with(word)) return std::string(word);
  return key;
}

CameraModel readCamera(const YAML::Node& node, const std::string& key, const std::string& where,
                       std::string_view text) {
  CameraModel c;
  c.name = cameraName(node["name"], key, text);
  c.width = readPositiveInt(node["image_width"], where + ".image_width");
  c.height = readPositiveInt(node["image_height"], where + ".image_height");
  const Matrix k = readMatrix(node["camera_matrix"], where + ".camera_matrix", 3, 3);
  c.fx = k.values[0];
  c.fy = k.values[4];
  c.cx = k.values[2];
  c.cy = k.values[5];
  if (const YAML::Node dist = node["distortion_coefficients"]) {
    const Matrix d = readAnyMatrix(dist, where + ".distortion_coefficients");
    if (d.values.size() < 4 || d.values.size() > 5)
      throw std::runtime_error(where + ".distortion_coefficients: expected 4 or 5 values");
    std::copy(d.values.begin(), d.values.end(), c.distortion.begin());
  }
  const Matrix r = readMatrix(node["R"], where + ".R", 3, 3);
  const Matrix t = readMatrix(node["T"], where + ".T", 3, 1);
  for (int a = 0; a < 3; ++a) {
    c.translation[a] = t.values[a];
    for (int b = 0; b < 3; ++b) c.rotation(a, b) = r.values[3 * a + b];
  }
  checkCameraValues(c, where);
  return c;
}

Rig readRig(const YAML::Node& root, const std::string& path, std::string_view text) {
  if (!root.IsMap() && !root.IsNull())
    throw std::runtime_error(path + ": not a camera rig: the top level is not a map");
  const int count = readPositiveInt(root["camera_count"], path + ": camera_count");
  Rig rig;
  for (int i = 0; i < count; ++i) {
    const std::string key = "camera_" + std::to_string(i);
    const YAML::Node node = root[key];
    if (!node || !node.IsMap()) throw std::runtime_error(path + ": " + key + ": missing");
    rig.push_back(readCamera(node, key, path + ": " + key, text));
  }
  return rig;
}

// The text of an OpenCV FileStorage YAML file (first line "%YAML:1.x" or "%YAML 1.x", which
// yaml-cpp does not take, so it is blanked: line numbers stay) or JSON, ready for yaml-cpp.
std::string yamlText(std::string text, const std::string& path) {
  if (text.starts_with("%YAML:1.") || text.starts_with("%YAML 1."))
    text.erase(0, std::min(text.find('\n'), text.size()));
  else if (text.starts_with("<?xml"))
    throw std::runtime_error(path + ": OpenCV FileStorage XML is not read; write the rig as YAML");
  else if (!text.starts_with("{"))
    throw std::runtime_error(path +
                             ": not an OpenCV FileStorage YAML file (the first line must be "
                             "%YAML:1.0)");
  return text;
}

// How many YAML documents `text` holds, counting to two at most. (yaml-cpp's LoadAll never ends on
// some text: a stray ',' at the top level is read as one empty document after another.)
int documentCount(const std::string& text) {
  struct Ignore : YAML::EventHandler {
    void OnDocumentStart(const YAML::Mark&) override {}
    void OnDocumentEnd() override {}
    void OnNull(const YAML::Mark&, YAML::anchor_t) override {}
    void OnAlias(const YAML::Mark&, YAML::anchor_t) override {}
    void OnScalar(const YAML::Mark&, const std::string&, YAML::anchor_t,
                  const std::string&) override {}
    void OnSequenceStart(const YAML::Mark&, const std::string&, YAML::anchor_t,
                         YAML::EmitterStyle::value) override {}
    void OnSequenceEnd() override {}
    void OnMapStart(const YAML::Mark&, const std::string&, YAML::anchor_t,
                    YAML::EmitterStyle::value) override {}
    void OnMapEnd() override {}
  } ignore;
  std::istringstream stream(text);
  YAML::Parser parser(stream);
  int count = 0;
  while (count < 2 && parser.HandleNextDocument(ignore)) ++count;
  return count;
}

}  // namespace

// Read with yaml-cpp: OpenCV 4.6's own YAML parser never returns on some malformed files.
Rig loadRig(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(path + ": cannot open camera rig file");
  const std::string text =
      yamlText({std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()}, path);
  YAML::Node root;
  try {
    root = YAML::Load(text);
    if (documentCount(text) > 1)
      throw std::runtime_error(path + ": not a camera rig: text after the first YAML document");
  } catch (const YAML::Exception& e) {
    throw std::runtime_error(path + ": not a readable YAML file: " + e.what());
  }
  try {
    return readRig(root, path, text);
  } catch (const YAML::Exception& e) {
    throw std::runtime_error(path + ": not a camera rig: " + e.what());
  }
}

}  // namespace mocap
