// Reading and writing the session's manifest and CSV lines.
#include "drivers/record/session_format.h"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sstream>

#include <opencv2/core.hpp>
#include <yaml-cpp/yaml.h>

namespace mocap {
namespace {

std::vector<std::string> splitCsv(const std::string& line) {
  std::vector<std::string> columns;
  std::string::size_type start = 0;
  for (;;) {
    const std::string::size_type comma = line.find(',', start);
    columns.push_back(line.substr(start, comma - start));
    if (comma == std::string::npos) return columns;
    start = comma + 1;
  }
}

template <typename T>
bool parseNumber(const std::string& text, T& value) {
  const char* end = text.data() + text.size();
  const auto [ptr, error] = std::from_chars(text.data(), end, value);
  return error == std::errc() && ptr == end && !text.empty();
}

// The line's columns if there are `count` of them; the error names the count (and `header`, if
// given) otherwise.
Expected<std::vector<std::string>> columns(const std::string& line, std::size_t count,
                                           const std::string& header = "") {
  std::vector<std::string> c = splitCsv(line);
  if (c.size() != count) {
    return Status::Error("expected " + std::to_string(count) + " columns" +
                         (header.empty() ? "" : " (" + header + ")") + ", found " +
                         std::to_string(c.size()));
  }
  return c;
}

bool parseFlag(const std::string& text, bool& value) {
  if (text != "0" && text != "1") return false;
  value = text == "1";
  return true;
}

// A file name the reader may open: a plain name inside the camera directory.
bool isPlainFileName(const std::string& name) {
  return !name.empty() && name != "." && name != ".." && name.find('/') == std::string::npos;
}

}  // namespace

std::string cameraDirectoryName(int camera) { return "cam" + std::to_string(camera); }

const char* imageModeName(ImageMode mode) {
  switch (mode) {
    case ImageMode::kLossless: return "lossless";
    case ImageMode::kCompressed: return "compressed";
    case ImageMode::kNone: return "none";
  }
  return "lossless";
}

std::optional<ImageMode> parseImageMode(const std::string& name) {
  for (ImageMode mode : {ImageMode::kLossless, ImageMode::kCompressed, ImageMode::kNone})
    if (name == imageModeName(mode)) return mode;
  return std::nullopt;
}

const char* imageExtension(ImageMode mode) {
  return mode == ImageMode::kCompressed ? ".jpg" : ".png";
}

int cvTypeOfPixelFormat(const std::string& pixel_format) {
  if (pixel_format == kPixelGray) return CV_8UC1;
  if (pixel_format == kPixelBgr) return CV_8UC3;
  return -1;
}

std::string formatIndexLine(const IndexRecord& r) {
  return std::to_string(r.set_sequence) + "," + std::to_string(r.camera_sequence) + "," +
         std::to_string(r.timestamp_ns) + "," + std::to_string(r.dropped_before) + "," +
         (r.corrupt ? "1" : "0") + "," + r.file + "," + r.silhouette;
}

std::string formatSetLine(const SetRecord& r) {
  return std::to_string(r.set_sequence) + "," + std::to_string(r.timestamp_ns) + "," + r.present;
}

Expected<IndexRecord> parseIndexLine(const std::string& line, int format_version) {
  const bool v1 = format_version == 1;
  Expected<std::vector<std::string>> split =
      columns(line, v1 ? 6 : 7, v1 ? kIndexHeaderV1 : kIndexHeader);
  if (!split.ok()) return Status::Error(split.error());
  const std::vector<std::string>& c = split.value();
  IndexRecord r;
  if (!parseNumber(c[0], r.set_sequence)) return Status::Error("set_sequence '" + c[0] + "' is not a number");
  if (!parseNumber(c[1], r.camera_sequence)) return Status::Error("camera_sequence '" + c[1] + "' is not a number");
  if (!parseNumber(c[2], r.timestamp_ns)) return Status::Error("timestamp_ns '" + c[2] + "' is not a number");
  if (!parseNumber(c[3], r.dropped_before)) return Status::Error("dropped_before '" + c[3] + "' is not a number");
  if (!parseFlag(c[4], r.corrupt)) return Status::Error("corrupt '" + c[4] + "' is not 0 or 1");
  // Empty in a session without images; the reader checks that against the manifest.
  if ((v1 || !c[5].empty()) && !isPlainFileName(c[5]))
    return Status::Error("file '" + c[5] + "' is not a file name in the camera directory");
  r.file = c[5];
  if (!v1 && !c[6].empty() && !isPlainFileName(c[6]))
    return Status::Error("silhouette '" + c[6] + "' is not a file name in the camera directory");
  if (!v1) r.silhouette = c[6];
  return r;
}

std::string formatBackgroundLine(const BackgroundRecord& r) {
  return std::to_string(r.from_sequence) + "," + std::to_string(r.camera) + "," + r.file;
}

Expected<BackgroundRecord> parseBackgroundLine(const std::string& line, std::size_t camera_count) {
  Expected<std::vector<std::string>> split = columns(line, 3, kBackgroundsHeader);
  if (!split.ok()) return Status::Error(split.error());
  const std::vector<std::string>& c = split.value();
  BackgroundRecord r;
  if (!parseNumber(c[0], r.from_sequence))
    return Status::Error("from_sequence '" + c[0] + "' is not a number");
  if (!parseNumber(c[1], r.camera) || r.camera < 0 ||
      static_cast<std::size_t>(r.camera) >= camera_count) {
    return Status::Error("camera '" + c[1] + "' is not a camera of the session (" +
                         std::to_string(camera_count) + " cameras)");
  }
  if (!c[2].empty() && !isPlainFileName(c[2]))
    return Status::Error("file '" + c[2] + "' is not a file name in the camera directory");
  r.file = c[2];
  return r;
}

std::string truthHeader(const std::vector<std::string>& dof_names) {
  std::string header = "frame_sequence";
  for (const std::string& name : dof_names) header += "," + name;
  return header;
}

std::string formatTruthLine(const TruthRecord& r) {
  std::string line = std::to_string(r.frame_sequence);
  char value[32];
  for (double dof : r.dofs) {
    std::snprintf(value, sizeof value, ",%.17g", dof);
    line += value;
  }
  return line;
}

Expected<TruthRecord> parseTruthLine(const std::string& line,
                                     const std::vector<std::string>& dof_names) {
  Expected<std::vector<std::string>> split = columns(line, dof_names.size() + 1);
  if (!split.ok()) return Status::Error(split.error());
  const std::vector<std::string>& c = split.value();
  TruthRecord r;
  if (!parseNumber(c[0], r.frame_sequence))
    return Status::Error("frame_sequence '" + c[0] + "' is not a number");
  for (std::size_t d = 0; d < dof_names.size(); ++d) {
    char* end = nullptr;
    const double value = std::strtod(c[d + 1].c_str(), &end);
    if (c[d + 1].empty() || end != c[d + 1].c_str() + c[d + 1].size() || !std::isfinite(value))
      return Status::Error(dof_names[d] + ": '" + c[d + 1] + "' is not a finite number");
    r.dofs.push_back(value);
  }
  return r;
}

Expected<SetRecord> parseSetLine(const std::string& line, std::size_t camera_count) {
  Expected<std::vector<std::string>> split = columns(line, 3, kSetsHeader);
  if (!split.ok()) return Status::Error(split.error());
  const std::vector<std::string>& c = split.value();
  SetRecord r;
  if (!parseNumber(c[0], r.set_sequence)) return Status::Error("set_sequence '" + c[0] + "' is not a number");
  if (!parseNumber(c[1], r.timestamp_ns)) return Status::Error("timestamp_ns '" + c[1] + "' is not a number");
  if (c[2].size() != camera_count || c[2].find_first_not_of("01") != std::string::npos) {
    return Status::Error("present '" + c[2] + "' is not one 0/1 per camera (" +
                         std::to_string(camera_count) + " cameras)");
  }
  r.present = c[2];
  return r;
}

std::string emitManifest(const SessionManifest& m) {
  YAML::Emitter out;
  out << YAML::BeginMap;
  out << YAML::Key << "format_version" << YAML::Value << m.format_version;
  out << YAML::Key << "software_version" << YAML::Value << m.software_version;
  out << YAML::Key << "start_time_utc" << YAML::Value << m.start_time_utc;
  out << YAML::Key << "start_monotonic_ns" << YAML::Value << m.start_monotonic_ns;
  out << YAML::Key << "calibration" << YAML::Value << m.calibration_file;
  out << YAML::Key << "images" << YAML::Value << imageModeName(m.images);
  if (!m.body_model_file.empty()) out << YAML::Key << "body_model" << YAML::Value << m.body_model_file;
  if (!m.truth_body_model_file.empty())
    out << YAML::Key << "truth_body_model" << YAML::Value << m.truth_body_model_file;
  if (!m.tracker_settings.empty()) {
    out << YAML::Key << "tracker" << YAML::Value << YAML::BeginMap;
    for (const auto& [key, value] : m.tracker_settings) out << YAML::Key << key << YAML::Value << value;
    out << YAML::EndMap;
  }
  out << YAML::Key << "cameras" << YAML::Value << YAML::BeginSeq;
  for (const SessionCamera& c : m.cameras) {
    out << YAML::BeginMap;
    out << YAML::Key << "name" << YAML::Value << c.name;
    out << YAML::Key << "width" << YAML::Value << c.width;
    out << YAML::Key << "height" << YAML::Value << c.height;
    out << YAML::Key << "pixel_format" << YAML::Value << c.pixel_format;
    out << YAML::Key << "fps" << YAML::Value << c.fps;
    out << YAML::EndMap;
  }
  out << YAML::EndSeq << YAML::EndMap;
  return std::string(out.c_str()) + "\n";
}

Expected<SessionManifest> parseManifest(const std::string& yaml_text, const std::string& source) {
  // yaml-cpp throws on malformed input and bad conversions; this is the edge that catches.
  const auto fail = [&](const std::string& field, const std::string& reason) {
    return Status::Error(source + ": " + field + ": " + reason);
  };
  YAML::Node root;
  try {
    root = YAML::Load(yaml_text);
  } catch (const YAML::Exception& e) {
    return Status::Error(source + ":" + std::to_string(e.mark.line + 1) + ": not valid YAML: " + e.msg);
  }
  if (!root.IsMap()) return fail("(top level)", "expected a map");
  SessionManifest m;
  const auto scalar = [&](const YAML::Node& node, const std::string& field, auto& value) -> Status {
    if (!node) return fail(field, "missing");
    try {
      value = node.as<std::remove_reference_t<decltype(value)>>();
    } catch (const YAML::Exception&) {
      return fail(field, "bad value '" + (node.IsScalar() ? node.Scalar() : std::string("(not a scalar)")) + "'");
    }
    return Status::Ok();
  };
  if (Status s = scalar(root["format_version"], "format_version", m.format_version); !s.ok()) return s;
  if (m.format_version < 1 || m.format_version > kSessionFormatVersion) {
    return fail("format_version", std::to_string(m.format_version) +
                                      " is not supported (this build reads 1 to " +
                                      std::to_string(kSessionFormatVersion) + ")");
  }
  if (Status s = scalar(root["software_version"], "software_version", m.software_version); !s.ok()) return s;
  if (Status s = scalar(root["start_time_utc"], "start_time_utc", m.start_time_utc); !s.ok()) return s;
  if (Status s = scalar(root["start_monotonic_ns"], "start_monotonic_ns", m.start_monotonic_ns); !s.ok()) return s;
  if (Status s = scalar(root["calibration"], "calibration", m.calibration_file); !s.ok()) return s;
  if (m.calibration_file.find('/') != std::string::npos || m.calibration_file == "..") {
    return fail("calibration", "'" + m.calibration_file + "' is not a file name in the session");
  }
  // Format 1 sessions have none: they are lossless.
  if (root["images"]) {
    std::string name;
    if (Status s = scalar(root["images"], "images", name); !s.ok()) return s;
    const std::optional<ImageMode> mode = parseImageMode(name);
    if (!mode) return fail("images", "'" + name + "' is not lossless, compressed or none");
    if (m.format_version == 1 && *mode != ImageMode::kLossless)
      return fail("images", "format 1 sessions are lossless");
    m.images = *mode;
  }
  // Optional: sessions recorded before the body model was stored have none.
  if (root["body_model"]) {
    if (Status s = scalar(root["body_model"], "body_model", m.body_model_file); !s.ok()) return s;
    if (!isPlainFileName(m.body_model_file)) {
      return fail("body_model", "'" + m.body_model_file + "' is not a file name in the session");
    }
  }
  // Optional: only sessions whose truth is of another body than the tracked one have it.
  if (root["truth_body_model"]) {
    if (Status s = scalar(root["truth_body_model"], "truth_body_model", m.truth_body_model_file);
        !s.ok())
      return s;
    if (!isPlainFileName(m.truth_body_model_file)) {
      return fail("truth_body_model",
                  "'" + m.truth_body_model_file + "' is not a file name in the session");
    }
  }
  // Optional: sessions recorded before the tracker settings were stored have none.
  if (const YAML::Node tracker = root["tracker"]) {
    if (!tracker.IsMap()) return fail("tracker", "expected a map of settings");
    for (const auto& entry : tracker) {
      const std::string key = entry.first.Scalar();
      if (!entry.second.IsScalar()) return fail("tracker." + key, "expected a single value");
      m.tracker_settings.emplace_back(key, entry.second.Scalar());
    }
  }
  const YAML::Node cameras = root["cameras"];
  if (!cameras) return fail("cameras", "missing");
  if (!cameras.IsSequence() || cameras.size() == 0) return fail("cameras", "expected a non-empty list");
  for (std::size_t i = 0; i < cameras.size(); ++i) {
    const std::string prefix = "cameras[" + std::to_string(i) + "].";
    // yaml-cpp throws on a field of a scalar or a list: check the shape first.
    if (!cameras[i].IsMap())
      return fail("cameras[" + std::to_string(i) + "]", "expected a map (name, width, height, ...)");
    SessionCamera c;
    if (Status s = scalar(cameras[i]["name"], prefix + "name", c.name); !s.ok()) return s;
    if (Status s = scalar(cameras[i]["width"], prefix + "width", c.width); !s.ok()) return s;
    if (Status s = scalar(cameras[i]["height"], prefix + "height", c.height); !s.ok()) return s;
    if (Status s = scalar(cameras[i]["pixel_format"], prefix + "pixel_format", c.pixel_format); !s.ok()) return s;
    if (Status s = scalar(cameras[i]["fps"], prefix + "fps", c.fps); !s.ok()) return s;
    if (c.width <= 0 || c.height <= 0) {
      return fail(prefix + (c.width <= 0 ? "width" : "height"),
                  std::to_string(c.width <= 0 ? c.width : c.height) + " is not a positive size");
    }
    if (cvTypeOfPixelFormat(c.pixel_format) < 0) {
      return fail(prefix + "pixel_format", "'" + c.pixel_format + "' is not " + kPixelGray + " or " + kPixelBgr);
    }
    if (!(c.fps > 0)) return fail(prefix + "fps", "must be positive");
    m.cameras.push_back(c);
  }
  return m;
}

}  // namespace mocap
