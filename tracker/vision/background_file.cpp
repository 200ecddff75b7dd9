// Background model files: the OpenCV FileStorage YAML that saveBackground has always written (two
// float matrices in OpenCV's base64, gzip-compressed if the name ends in ".gz"), written and read
// here line by line. OpenCV 4.6's own parser never returns on some malformed files and allocates
// whatever size a corrupt file declares; this reader takes that one layout only, checks every size
// against the file before allocating, and refuses values no capture produces.
#include "tracker/vision/background_model.h"

#include <zlib.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>
#include <optional>
#include <span>
#include <stdexcept>
#include <string_view>
#include <utility>

#include <fcntl.h>
#include <unistd.h>

#include <opencv2/core.hpp>

namespace mocap {
namespace {

static_assert(std::endian::native == std::endian::little, "the files hold little-endian floats");

// The largest model read: 16384 pixels a side and 2^25 pixels (8K UHD, 7680x4320, fits).
constexpr int kMaxSide = 16384;
constexpr long long kMaxPixels = 1LL << 25;
// OpenCV's base64 block starts with the element type ("1f", "3f") padded with spaces to 24 bytes.
constexpr std::size_t kBase64HeaderBytes = 24;
constexpr std::size_t kBytesPerLine = 48;  // 64 base64 characters a line, as OpenCV writes them
constexpr std::size_t kMaxLine = 1024;     // the longest line written has 70 characters
constexpr double kMaxInflation = 1032;     // the most text one byte of deflate data expands to
// The longest text of a model of kMaxPixels in BGR: two matrices of 12 bytes a pixel in base64 (4
// characters for 3 bytes), 64 characters and 7 more (indent, newline) a line, and the fields.
constexpr std::uintmax_t kMaxText = 2 * (kMaxPixels * 12 * 4 / 3 / 64 + 1) * 71 + 4096;
constexpr std::string_view kMatrixIndent = "   ";
constexpr std::string_view kDataIndent = "      ";
constexpr std::string_view kBase64 =
    "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";

std::string zlibError(gzFile file) {
  int code = Z_OK;
  const char* message = gzerror(file, &code);
  return code == Z_ERRNO ? std::strerror(errno) : message;
}

// Text of the file quoted in a message, at most 40 characters, with '?' for what is not ASCII.
std::string printable(std::string_view text) {
  std::string out;
  for (const char c : text.substr(0, 40)) out += c >= 0x20 && c < 0x7f ? c : '?';
  return out;
}

// The element type as the base64 header spells it: "1f" or "3f".
std::string elementType(int channels) { return std::to_string(channels) + "f"; }

// A model no capture produces: a value that is not finite, or a negative deviation.
void requirePlausibleValues(const cv::Mat& m, const std::string& where, bool deviation) {
  for (int row = 0; row < m.rows; ++row) {
    const std::span<const float> values(m.ptr<float>(row), std::size_t(m.cols) * m.channels());
    for (std::size_t i = 0; i < values.size(); ++i) {
      const bool finite = std::isfinite(values[i]);
      if (finite && (!deviation || values[i] >= 0)) continue;
      throw std::runtime_error(where + ": " + (finite ? "negative" : "not a finite number") +
                               " at row " + std::to_string(row) + ", column " +
                               std::to_string(i / m.channels()));
    }
  }
}

// A file written through zlib, compressed or as it is; every failure throws.
class OutputFile {
 public:
  OutputFile(const std::string& path, bool compress)
      : file_(gzopen(path.c_str(), compress ? "wbe" : "wbTe")) {
    if (file_ == nullptr)
      throw std::runtime_error(std::string("cannot open for writing: ") + std::strerror(errno));
  }
  ~OutputFile() {
    if (file_ != nullptr) gzclose(file_);
  }
  OutputFile(const OutputFile&) = delete;
  OutputFile& operator=(const OutputFile&) = delete;

  void write(std::string_view text) {
    if (!text.empty() && gzwrite(file_, text.data(), static_cast<unsigned>(text.size())) !=
                             static_cast<int>(text.size()))
      throw std::runtime_error("cannot write: " + zlibError(file_));
  }
  void close() {
    const int status = gzclose(std::exchange(file_, nullptr));
    if (status != Z_OK)
      throw std::runtime_error(std::string("cannot write: ") +
                               (status == Z_ERRNO ? std::strerror(errno) : zError(status)));
  }

 private:
  gzFile file_;
};

// `m` as FileStorage writes a matrix with cv::FileStorage::BASE64: its size, its type, then the
// header and the elements in base64, 48 bytes a line.
void writeMatrix(OutputFile& out, const std::string& name, const cv::Mat& m) {
  const cv::Mat values = m.isContinuous() ? m : m.clone();
  const std::string type = elementType(m.channels());
  std::string text = name + ": !!opencv-matrix\n";
  text += std::string(kMatrixIndent) + "rows: " + std::to_string(m.rows) + "\n";
  text += std::string(kMatrixIndent) + "cols: " + std::to_string(m.cols) + "\n";
  text += std::string(kMatrixIndent) +
          "dt: " + (m.channels() == 1 ? std::string("f") : '"' + type + '"') + "\n";
  text += std::string(kMatrixIndent) + "data: !!binary |\n";
  std::string header = type;
  header.resize(kBase64HeaderBytes, ' ');
  const std::span<const uchar> data(values.data, values.total() * values.elemSize());
  const std::size_t total = header.size() + data.size();
  const auto byteAt = [&](std::size_t i) -> unsigned {
    return i < header.size() ? static_cast<uchar>(header[i]) : data[i - header.size()];
  };
  for (std::size_t start = 0; start < total; start += kBytesPerLine) {
    text += kDataIndent;
    const std::size_t end = std::min(start + kBytesPerLine, total);
    for (std::size_t i = start; i < end; i += 3) {
      const std::size_t count = std::min<std::size_t>(3, end - i);
      const unsigned group =
          byteAt(i) << 16 | (count > 1 ? byteAt(i + 1) << 8 : 0) | (count > 2 ? byteAt(i + 2) : 0);
      for (std::size_t k = 0; k < 4; ++k)
        text += k <= count ? kBase64[(group >> (18 - 6 * k)) & 63] : '=';
    }
    text += '\n';
    if (text.size() >= (1 << 16)) out.write(std::exchange(text, {}));
  }
  out.write(text);
}

void writeModel(const std::string& path, const BackgroundModel& model) {
  OutputFile out(path, path.ends_with(".gz"));
  out.write("%YAML:1.0\n---\nimage_width: " + std::to_string(model.mean.cols) +
            "\nimage_height: " + std::to_string(model.mean.rows) +
            "\nchannels: " + std::to_string(model.channels()) + "\n");
  writeMatrix(out, "mean", model.mean);
  writeMatrix(out, "stddev", model.stddev);
  out.close();
}

// Flushes a file (or a directory's entries) to the disk; false on an error.
bool syncToDisk(const std::string& path, int flags) {
  const int fd = ::open(path.c_str(), flags | O_CLOEXEC);
  if (fd < 0) return false;
  const bool synced = ::fsync(fd) == 0;
  return ::close(fd) == 0 && synced;
}

bool sameValues(const cv::Mat& a, const cv::Mat& b) {
  return a.type() == b.type() && a.size() == b.size() && cv::norm(a, b, cv::NORM_INF) == 0;
}

}  // namespace

void saveBackground(const std::string& path, const BackgroundModel& model) {
  if (model.empty()) throw std::runtime_error(path + ": background model is empty");
  if (model.mean.depth() != CV_32F || (model.channels() != 1 && model.channels() != 3) ||
      model.stddev.type() != model.mean.type() || model.stddev.size() != model.mean.size())
    throw std::runtime_error(path + ": background model is not two float matrices of one size");
  requirePlausibleValues(model.mean, path + ": mean", false);
  requirePlausibleValues(model.stddev, path + ": stddev", true);
  // Written beside the target under a hidden name with the same extension, then renamed over it:
  // a crash or a full disk never leaves a half-written model where the daemon loads it.
  const std::filesystem::path target(path);
  const std::filesystem::path temporary =
      target.parent_path() /
      (".tmp-" + std::to_string(::getpid()) + "-" + target.filename().string());
  std::error_code ignored;
  try {
    writeModel(temporary.string(), model);
    // What a full disk or a failing device wrote is what the daemon would load: read it back.
    const BackgroundModel written = loadBackground(temporary.string());
    if (!sameValues(written.mean, model.mean) || !sameValues(written.stddev, model.stddev))
      throw std::runtime_error("reads back different");
    if (!syncToDisk(temporary.string(), O_RDONLY))
      throw std::runtime_error(std::string("cannot flush to disk: ") + std::strerror(errno));
  } catch (const std::exception& e) {
    std::filesystem::remove(temporary, ignored);
    throw std::runtime_error(path + ": background model not saved: " + e.what());
  }
  std::error_code error;
  std::filesystem::rename(temporary, target, error);
  if (error) {
    std::filesystem::remove(temporary, ignored);
    throw std::runtime_error(path + ": background model not saved: cannot rename " +
                             temporary.string() + ": " + error.message());
  }
  // The rename itself survives a power loss only once the directory is flushed.
  syncToDisk(target.parent_path().empty() ? "." : target.parent_path().string(),
             O_RDONLY | O_DIRECTORY);
}

namespace {

// The lines of a file, plain or gzip-compressed (zlib reads either), each at most kMaxLine long.
class InputLines {
 public:
  explicit InputLines(const std::string& path) : path_(path), file_(gzopen(path.c_str(), "rbe")) {
    if (file_ == nullptr)
      throw std::runtime_error(path + ": cannot open background model: " + std::strerror(errno));
  }
  ~InputLines() { gzclose(file_); }
  InputLines(const InputLines&) = delete;
  InputLines& operator=(const InputLines&) = delete;

  // The next line, without its '\n'; false at the end of the file. Throws on a read error or a
  // line too long to be one saveBackground wrote.
  bool next(std::string& line);
  // The next call of next() gives the last line again.
  void unread() { unread_ = true; }
  int number() const { return number_; }
  bool compressed() { return gzdirect(file_) == 0; }

 private:
  std::string path_;
  gzFile file_;
  std::string buffered_;
  std::size_t start_ = 0;
  std::uintmax_t total_ = 0;
  bool at_end_ = false;
  bool unread_ = false;
  std::string last_;
  int number_ = 0;
};

bool InputLines::next(std::string& line) {
  if (std::exchange(unread_, false)) {
    line = last_;
    return true;
  }
  for (;;) {
    const std::size_t newline = buffered_.find('\n', start_);
    const std::size_t length = (newline == std::string::npos ? buffered_.size() : newline) - start_;
    if (length > kMaxLine)
      throw std::runtime_error(path_ + ": longer than " + std::to_string(kMaxLine) +
                               " characters: not a background model (line " +
                               std::to_string(number_ + 1) + ")");
    if (newline != std::string::npos || (at_end_ && length > 0)) {
      last_.assign(buffered_, start_, length);
      start_ = std::min(start_ + length + 1, buffered_.size());
      ++number_;
      line = last_;
      return true;
    }
    if (at_end_) return false;
    buffered_.erase(0, start_);
    start_ = 0;
    std::array<char, 1 << 16> chunk;
    const int count = gzread(file_, chunk.data(), chunk.size());
    int code = Z_OK;
    gzerror(file_, &code);
    if (count < 0 || code != Z_OK)
      throw std::runtime_error(path_ + ": cannot read background model: " + zlibError(file_));
    at_end_ = count == 0;
    total_ += static_cast<std::uintmax_t>(count);
    if (total_ > kMaxText)
      throw std::runtime_error(path_ + ": longer than any background model (" +
                               std::to_string(kMaxText) + " characters)");
    buffered_.append(chunk.data(), static_cast<std::size_t>(count));
  }
}

// A line "key: value" split at its first ": ", with the spaces it starts with counted.
struct Field {
  std::size_t indent = 0;
  std::string_view key, value;
};

std::optional<Field> splitField(std::string_view line) {
  Field field;
  field.indent = std::min(line.find_first_not_of(' '), line.size());
  line.remove_prefix(field.indent);
  const std::size_t colon = line.find(':');
  if (colon == std::string_view::npos || colon == 0) return std::nullopt;
  field.key = line.substr(0, colon);
  field.value = line.substr(colon + 1);
  if (!field.value.empty() && field.value.front() != ' ') return std::nullopt;
  const std::size_t first = field.value.find_first_not_of(' ');
  const std::size_t last = field.value.find_last_not_of(' ');
  field.value = first == std::string_view::npos ? "" : field.value.substr(first, last - first + 1);
  return field;
}

bool skipped(std::string_view line) {
  const std::size_t first = line.find_first_not_of(' ');
  return first == std::string_view::npos || line[first] == '#';
}

// Decodes one matrix's base64 block (OpenCV's 24-byte header, then the elements) into `data`.
class Base64Block {
 public:
  explicit Base64Block(std::span<uchar> data) : data_(data) {}

  // Decodes the characters of one line; an error message, or "" if they are base64.
  std::string add(std::string_view text) {
    for (const char c : text) {
      if (ended_) return "text after the end of the base64 data";
      unsigned value = 0;
      if (c == '=') {
        if (group_size_ < 2) return "'=' inside a base64 group";
        ++padding_;
      } else {
        const std::size_t found = kBase64.find(c);
        if (found == std::string_view::npos || padding_ > 0)
          return "'" + printable(std::string_view(&c, 1)) + "' in the base64 data";
        value = static_cast<unsigned>(found);
      }
      group_ = group_ << 6 | value;
      if (++group_size_ == 4) flushGroup();
    }
    return "";
  }
  // The message for what the block lacks or holds too much of, or "" if it is whole.
  std::string check(const std::string& expected_header) const {
    if (group_size_ != 0) return "the base64 data ends inside a group";
    const std::size_t needed = kBase64HeaderBytes + data_.size();
    if (decoded_ != needed)
      return "holds " + std::to_string(decoded_) + " bytes where the size and type need " +
             std::to_string(needed) + " (24 of a header, then the values)";
    const std::size_t end = header_.find_last_not_of(' ');
    const std::string header = header_.substr(0, end == std::string::npos ? 0 : end + 1);
    if (header != expected_header)
      return "its header says '" + printable(header) + "' where dt says '" + expected_header + "'";
    return "";
  }

 private:
  void flushGroup() {
    for (unsigned k = 0; k < 3 - padding_; ++k) {
      const auto byte = static_cast<uchar>(group_ >> (16 - 8 * k));
      if (decoded_ < kBase64HeaderBytes)
        header_ += static_cast<char>(byte);
      else if (decoded_ - kBase64HeaderBytes < data_.size())
        data_[decoded_ - kBase64HeaderBytes] = byte;
      ++decoded_;
    }
    ended_ = padding_ > 0;
    group_ = 0;
    group_size_ = 0;
  }

  std::span<uchar> data_;
  std::string header_;
  std::size_t decoded_ = 0;
  unsigned group_ = 0, group_size_ = 0, padding_ = 0;
  bool ended_ = false;
};

// The size of the file at `path`, checked to be a regular one before it is opened (a pipe would
// block the reader).
std::uintmax_t regularFileBytes(const std::string& path) {
  std::error_code error;
  const std::filesystem::file_status status = std::filesystem::status(path, error);
  if (error) throw std::runtime_error(path + ": cannot open background model: " + error.message());
  if (!std::filesystem::is_regular_file(status))
    throw std::runtime_error(path + ": not a regular file");
  return std::filesystem::file_size(path, error);
}

// Reads the layout writeModel writes, refusing anything else with the line and field at fault.
class BackgroundReader {
 public:
  explicit BackgroundReader(const std::string& path)
      : path_(path), file_bytes_(regularFileBytes(path)), lines_(path) {}
  BackgroundModel read();

 private:
  [[noreturn]] void fail(const std::string& what) const {
    throw std::runtime_error(path_ + ": " + what);
  }
  [[noreturn]] void failHere(const std::string& what) const {
    throw std::runtime_error(path_ + ": " + what + " (line " + std::to_string(lines_.number()) +
                             ")");
  }
  void readFirstLines();
  int readPositive(const Field& field, const std::string& where, int largest) const;
  void readOnce(int& target, const Field& field, int largest);
  cv::Mat readMatrix(const std::string& name);
  cv::Mat readData(const std::string& where, std::size_t indent);

  std::string path_;
  std::uintmax_t file_bytes_;
  InputLines lines_;
  int width_ = 0, height_ = 0, channels_ = 0;
};

void BackgroundReader::readFirstLines() {
  std::string line;
  if (!lines_.next(line)) fail("empty file, not a background model");
  if (line.starts_with("<") || line.starts_with("{"))
    fail("OpenCV FileStorage XML or JSON is not read: background models are YAML");
  if (!line.starts_with("%YAML:1.") && !line.starts_with("%YAML 1."))
    failHere("not an OpenCV FileStorage YAML file (the first line must be %YAML:1.0)");
  if (!lines_.next(line) || line.find_last_not_of(' ') != 2 || !line.starts_with("---"))
    failHere("expected '---' after the %YAML line");
}

int BackgroundReader::readPositive(const Field& field, const std::string& where,
                                   int largest) const {
  const std::string_view text = field.value;
  if (text.empty() || text.size() > 9 || text.find_first_not_of("0123456789") != text.npos)
    failHere(where + ": '" + printable(text) + "' is not a positive integer");
  const int value = std::stoi(std::string(text));
  if (value <= 0) failHere(where + ": must be positive, got " + std::to_string(value));
  if (value > largest)
    failHere(where + ": " + std::to_string(value) + " is more than the " + std::to_string(largest) +
             " a background model may have");
  return value;
}

void BackgroundReader::readOnce(int& target, const Field& field, int largest) {
  const std::string key(field.key);
  if (target != 0) failHere(key + ": given twice");
  target = readPositive(field, key, largest);
}

BackgroundModel BackgroundReader::read() {
  readFirstLines();
  BackgroundModel model;
  std::string line;
  while (lines_.next(line)) {
    if (skipped(line)) continue;
    const std::optional<Field> field = splitField(line);
    if (!field || field->indent > 0) failHere("expected a field of the model (\"name: value\")");
    const std::string key(field->key);
    if (key == "image_width" || key == "image_height") {
      readOnce(key == "image_width" ? width_ : height_, *field, kMaxSide);
    } else if (key == "channels") {
      readOnce(channels_, *field, std::numeric_limits<int>::max());
      if (channels_ != 1 && channels_ != 3)
        failHere("channels: expected 1 or 3, got " + std::to_string(channels_));
    } else if (key == "mean" || key == "stddev") {
      cv::Mat& m = key == "mean" ? model.mean : model.stddev;
      if (!m.empty()) failHere(key + ": given twice");
      if (field->value != "!!opencv-matrix")
        failHere(key + ": expected an OpenCV matrix (!!opencv-matrix)");
      const std::pair<const char*, int> sizes[] = {
          {"image_width", width_}, {"image_height", height_}, {"channels", channels_}};
      for (const auto& [name, value] : sizes)
        if (value == 0) failHere(std::string(name) + ": missing before " + key);
      if (static_cast<long long>(width_) * height_ > kMaxPixels)
        failHere(key + ": image_width x image_height, " + std::to_string(width_) + "x" +
                 std::to_string(height_) + ", is more than the " + std::to_string(kMaxPixels) +
                 " pixels a background model may have");
      m = readMatrix(key);
    } else {
      failHere("unexpected field '" + printable(key) + "'");
    }
  }
  const std::pair<const char*, bool> required[] = {{"image_width", width_ > 0},
                                                   {"image_height", height_ > 0},
                                                   {"channels", channels_ > 0},
                                                   {"mean", !model.mean.empty()},
                                                   {"stddev", !model.stddev.empty()}};
  for (const auto& [name, found] : required)
    if (!found) fail(std::string(name) + ": missing");
  requirePlausibleValues(model.mean, path_ + ": mean", false);
  requirePlausibleValues(model.stddev, path_ + ": stddev", true);
  return model;
}

cv::Mat BackgroundReader::readMatrix(const std::string& name) {
  int rows = 0, cols = 0;
  std::string dt;
  std::string line;
  while (lines_.next(line)) {
    if (skipped(line)) continue;
    if (line.front() != ' ') {  // the next field of the model
      lines_.unread();
      break;
    }
    const std::optional<Field> field = splitField(line);
    if (!field)
      failHere(name + ": expected one of its fields (rows, cols, dt, data) as \"name: value\"");
    const std::string where = name + "." + std::string(field->key);
    if (field->key == "rows" || field->key == "cols") {
      const bool is_rows = field->key == "rows";
      (is_rows ? rows : cols) = readPositive(*field, where, kMaxSide);
      const int image = is_rows ? height_ : width_;
      if ((is_rows ? rows : cols) != image)
        failHere(where + ": " + std::to_string(is_rows ? rows : cols) + ", but " +
                 (is_rows ? "image_height" : "image_width") + " is " + std::to_string(image));
    } else if (field->key == "dt") {
      std::string_view text = field->value;
      if (text.size() >= 2 && text.front() == '"' && text.back() == '"')
        text = text.substr(1, text.size() - 2);
      dt = text.size() == 1 ? "1" + std::string(text) : std::string(text);
      if (dt != elementType(channels_))
        failHere(where + ": '" + printable(text) + "', expected " +
                 (channels_ == 1 ? "f" : "\"3f\"") + " (float, " + std::to_string(channels_) +
                 " channel(s), as channels says)");
    } else if (field->key == "data") {
      if (field->value != "!!binary |")
        failHere(where + ": expected base64 (\"!!binary |\"), as saveBackground writes");
      if (rows == 0 || cols == 0 || dt.empty())
        failHere(where + ": comes before rows, cols and dt");
      return readData(where, field->indent);
    } else {
      failHere("unexpected field '" + printable(where) + "'");
    }
  }
  const std::pair<const char*, bool> required[] = {
      {".rows", rows > 0}, {".cols", cols > 0}, {".dt", !dt.empty()}, {".data", false}};
  for (const auto& [field, found] : required)
    if (!found) fail(name + field + ": missing");
  return {};
}

cv::Mat BackgroundReader::readData(const std::string& where, std::size_t indent) {
  // Allocates only what the file can hold: a corrupt size asks for no more memory than that.
  const std::size_t bytes = static_cast<std::size_t>(width_) * height_ * channels_ * sizeof(float);
  const std::size_t characters = (kBase64HeaderBytes + bytes + 2) / 3 * 4;
  const double available =
      static_cast<double>(file_bytes_) * (lines_.compressed() ? kMaxInflation : 1);
  if (static_cast<double>(characters) > available)
    failHere(where + ": " + std::to_string(width_) + "x" + std::to_string(height_) + "x" +
             std::to_string(channels_) + " floats take " + std::to_string(characters) +
             " base64 characters, more than the file's " + std::to_string(file_bytes_) +
             " bytes can hold");
  cv::Mat m(height_, width_, CV_32FC(channels_));
  Base64Block block({m.data, bytes});
  std::string line;
  while (lines_.next(line)) {
    const std::size_t first = line.find_first_not_of(' ');
    if (first == std::string::npos) continue;
    if (first <= indent) {
      lines_.unread();
      break;
    }
    if (const std::string error = block.add(std::string_view(line).substr(first)); !error.empty())
      failHere(where + ": " + error);
  }
  if (const std::string error = block.check(elementType(channels_)); !error.empty())
    fail(where + ": " + error);
  return m;
}

}  // namespace

BackgroundModel loadBackground(const std::string& path) { return BackgroundReader(path).read(); }

}  // namespace mocap
