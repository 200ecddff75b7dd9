// The session reader: manifest, calibration, index and commit files, image checks.
#include "drivers/record/session_reader.h"

#include <algorithm>
#include <array>
#include <cstring>
#include <fstream>
#include <iterator>
#include <map>
#include <sstream>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace mocap {
namespace fs = std::filesystem;
namespace {

struct CsvFile {
  std::vector<std::pair<int, std::string>> lines;  // line number, text; header excluded
  bool truncated_tail = false;                     // the last line had no newline: dropped
};

// A crash-tolerant CSV log: a truncated last line is dropped and noted in `notes`.
Expected<CsvFile> readCsv(const fs::path& path, const std::string& header,
                          std::vector<std::string>& notes) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return Status::Error(path.string() + ": missing or unreadable");
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  CsvFile file;
  std::size_t start = 0;
  int number = 0;
  while (start < text.size()) {
    const std::size_t end = text.find('\n', start);
    ++number;
    if (end == std::string::npos) {
      // The writer appends whole lines; a line without its newline was cut by a crash.
      file.truncated_tail = true;
      break;
    }
    std::string line = text.substr(start, end - start);
    start = end + 1;
    if (number == 1) {
      if (line != header) return Status::Error(path.string() + ":1: header is '" + line + "', expected '" + header + "'");
      continue;
    }
    file.lines.emplace_back(number, std::move(line));
  }
  if (number == 0 || (number == 1 && file.truncated_tail)) {
    return Status::Error(path.string() + ": empty (no header line)");
  }
  if (file.truncated_tail) notes.push_back(path.string() + ": dropped a truncated last line");
  return file;
}

bool readBytes(const fs::path& path, std::vector<uint8_t>& bytes) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return false;
  bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  return true;
}

uint32_t bigEndian32(const uint8_t* p) {
  return (uint32_t{p[0]} << 24) | (uint32_t{p[1]} << 16) | (uint32_t{p[2]} << 8) | uint32_t{p[3]};
}

std::string describeFrame(int camera, const IndexRecord& record) {
  return "frame " + std::to_string(record.camera_sequence) + " of camera " + std::to_string(camera) +
         " (set " + std::to_string(record.set_sequence) + ")";
}

// Everything of a frame but its pixels, as the index records it.
void setRecordedFields(const IndexRecord& record, int camera, Frame& frame) {
  frame.camera = camera;
  frame.sequence = record.camera_sequence;
  frame.timestamp_ns = record.timestamp_ns;
  frame.dropped_before = record.dropped_before;
  frame.corrupt = record.corrupt;
}

}  // namespace

Expected<std::unique_ptr<SessionReader>> SessionReader::open(const fs::path& dir, SessionReadOptions options) {
  std::unique_ptr<SessionReader> reader(new SessionReader());
  reader->dir_ = dir;
  if (Status status = reader->load(options); !status.ok()) return status;
  return reader;
}

fs::path SessionReader::imagePath(int camera, const IndexRecord& record) const {
  return dir_ / cameraDirectoryName(camera) / record.file;
}

Status SessionReader::loadBackgrounds() {
  const fs::path path = dir_ / kBackgroundsFile;
  std::error_code error;
  if (!fs::exists(path, error)) return Status::Ok();  // recorded without (or before) backgrounds
  Expected<CsvFile> file = readCsv(path, kBackgroundsHeader, notes_);
  if (!file.ok()) return Status::Error(file.error());
  const std::size_t camera_count = manifest_.cameras.size();
  std::vector<uint64_t> latest_from(camera_count, 0);  // per camera, its last line's from_sequence
  for (const auto& [number, line] : file.value().lines) {
    const std::string where = path.string() + ":" + std::to_string(number) + ": ";
    Expected<BackgroundRecord> parsed = parseBackgroundLine(line, camera_count);
    if (!parsed.ok()) return Status::Error(where + parsed.error());
    const BackgroundRecord& record = parsed.value();
    uint64_t& latest = latest_from[static_cast<std::size_t>(record.camera)];
    if (record.from_sequence < latest)
      return Status::Error(where + "from_sequence " + std::to_string(record.from_sequence) +
                           " goes back (camera " + std::to_string(record.camera) + ")");
    latest = record.from_sequence;
    SessionBackground background{record.from_sequence, record.camera, "", nullptr};
    if (!record.file.empty()) {
      const fs::path model_path = dir_ / cameraDirectoryName(record.camera) / record.file;
      BackgroundModel model;
      try {
        model = loadBackground(model_path.string());
      } catch (const std::exception& e) {
        return Status::Error(where + e.what());
      }
      const SessionCamera& camera = manifest_.cameras[static_cast<std::size_t>(record.camera)];
      const int channels = camera.pixel_format == kPixelGray ? 1 : 3;
      if (model.size() != cv::Size(camera.width, camera.height) || model.channels() != channels) {
        return Status::Error(where + model_path.string() + " is " +
                             std::to_string(model.size().width) + "x" +
                             std::to_string(model.size().height) + " with " +
                             std::to_string(model.channels()) + " channel(s), camera " +
                             std::to_string(record.camera) + " is " + std::to_string(camera.width) +
                             "x" + std::to_string(camera.height) + " " + camera.pixel_format);
      }
      background.file = cameraDirectoryName(record.camera) + "/" + record.file;
      background.model = std::make_shared<const BackgroundModel>(std::move(model));
    }
    backgrounds_.push_back(std::move(background));
  }
  return Status::Ok();
}

Status SessionReader::loadTruth() {
  const fs::path path = dir_ / kTruthFile;
  std::error_code error;
  if (!fs::exists(path, error)) return Status::Ok();
  // Its columns are the stored body's DOFs, so the header is known only with the body.
  if (!body_model_) return Status::Error(path.string() + ": the session stores no body model");
  std::vector<std::string> names;
  for (const Dof& dof : body_model_->dofs) names.push_back(dof.name);
  Expected<CsvFile> file = readCsv(path, truthHeader(names), notes_);
  if (!file.ok()) return Status::Error(file.error());
  for (const auto& [number, line] : file.value().lines) {
    Expected<TruthRecord> record = parseTruthLine(line, names);
    if (!record.ok())
      return Status::Error(path.string() + ":" + std::to_string(number) + ": " + record.error());
    const std::vector<double>& dofs = record.value().dofs;
    truth_[record.value().frame_sequence] =
        Eigen::Map<const Eigen::VectorXd>(dofs.data(), static_cast<Eigen::Index>(dofs.size()));
  }
  return Status::Ok();
}

Status SessionReader::load(const SessionReadOptions& options) {
  const fs::path manifest_path = dir_ / kManifestFile;
  std::ifstream manifest_file(manifest_path);
  if (!manifest_file) return Status::Error(manifest_path.string() + ": missing or unreadable (not a session directory?)");
  const std::string manifest_text((std::istreambuf_iterator<char>(manifest_file)), std::istreambuf_iterator<char>());
  Expected<SessionManifest> manifest = parseManifest(manifest_text, manifest_path.string());
  if (!manifest.ok()) return Status::Error(manifest.error());
  manifest_ = std::move(manifest.value());
  const std::size_t camera_count = manifest_.cameras.size();

  if (!manifest_.calibration_file.empty()) {
    const fs::path calibration = dir_ / manifest_.calibration_file;
    try {
      rig_ = loadRig(calibration.string());
    } catch (const std::exception& e) {
      return Status::Error(e.what());
    }
    if (rig_.size() != camera_count) {
      return Status::Error(calibration.string() + ": camera_count is " + std::to_string(rig_.size()) +
                           ", the manifest lists " + std::to_string(camera_count) + " cameras");
    }
  }

  for (const auto& [file, body] :
       {std::pair{&manifest_.body_model_file, &body_model_},
        std::pair{&manifest_.truth_body_model_file, &truth_body_model_}}) {
    if (file->empty()) continue;
    try {
      *body = loadBodyModel((dir_ / *file).string());
    } catch (const std::exception& e) {
      return Status::Error(e.what());
    }
  }
  if (truth_body_model_) {
    const auto names = [](const BodyModel& body) {
      std::vector<std::string> out;
      for (const Dof& dof : body.dofs) out.push_back(dof.name);
      return out;
    };
    if (!body_model_ || names(*truth_body_model_) != names(*body_model_))
      return Status::Error((dir_ / manifest_.truth_body_model_file).string() +
                           ": its DOFs are not those of the tracked body (body_model)");
  }

  if (Status status = loadBackgrounds(); !status.ok()) return status;
  if (Status status = loadTruth(); !status.ok()) return status;

  // Each camera's records by set sequence.
  std::vector<std::map<uint64_t, IndexRecord>> records(camera_count);
  for (std::size_t c = 0; c < camera_count; ++c) {
    const fs::path index_path = dir_ / cameraDirectoryName(static_cast<int>(c)) / kIndexFile;
    const int version = manifest_.format_version;
    Expected<CsvFile> index =
        readCsv(index_path, version == 1 ? kIndexHeaderV1 : kIndexHeader, notes_);
    if (!index.ok()) return Status::Error(index.error());
    for (const auto& [number, line] : index.value().lines) {
      Expected<IndexRecord> record = parseIndexLine(line, version);
      const std::string where = index_path.string() + ":" + std::to_string(number) + ": ";
      if (!record.ok()) return Status::Error(where + record.error());
      const uint64_t set_sequence = record.value().set_sequence;
      if (!records[c].empty() && set_sequence <= records[c].rbegin()->first) {
        return Status::Error(where + "set_sequence " + std::to_string(set_sequence) + " does not increase");
      }
      records[c].emplace(set_sequence, std::move(record.value()));
    }
  }

  const fs::path sets_path = dir_ / kSetsFile;
  Expected<CsvFile> sets_file = readCsv(sets_path, kSetsHeader, notes_);
  if (!sets_file.ok()) return Status::Error(sets_file.error());
  std::size_t referenced = 0;
  for (const auto& [number, line] : sets_file.value().lines) {
    const std::string where = sets_path.string() + ":" + std::to_string(number) + ": ";
    Expected<SetRecord> parsed = parseSetLine(line, camera_count);
    if (!parsed.ok()) return Status::Error(where + parsed.error());
    const SetRecord& set_record = parsed.value();
    if (!sets_.empty() && set_record.set_sequence <= sets_.back().sequence) {
      return Status::Error(where + "set_sequence " + std::to_string(set_record.set_sequence) + " does not increase");
    }
    SessionSet set{set_record.set_sequence, set_record.timestamp_ns, std::vector<std::optional<IndexRecord>>(camera_count)};
    for (std::size_t c = 0; c < camera_count; ++c) {
      if (set_record.present[c] != '1') continue;
      const auto found = records[c].find(set_record.set_sequence);
      if (found == records[c].end()) {
        return Status::Error(where + "set " + std::to_string(set_record.set_sequence) + " has a frame of camera " +
                             std::to_string(c) + " but " + cameraDirectoryName(static_cast<int>(c)) + "/" +
                             kIndexFile + " has no line for it");
      }
      if (Status status = checkImage(static_cast<int>(c), found->second, options.decode_all); !status.ok()) {
        return status;
      }
      set.frames[c] = found->second;
      ++referenced;
    }
    sets_.push_back(std::move(set));
  }
  std::size_t indexed = 0;
  for (const auto& camera_records : records) indexed += camera_records.size();
  if (indexed > referenced) {
    notes_.push_back(std::to_string(indexed - referenced) +
                     " indexed frames belong to no committed set (a set cut short): ignored");
  }
  return Status::Ok();
}

namespace {

// Cheap checks without decoding: the signature, the IHDR (size, 8-bit, colour type) and the
// closing IEND chunk, which a file cut short lacks. `color_type`: 0 gray, 2 RGB.
Status checkPngFile(const fs::path& path, const std::string& where, int width, int height,
                    int color_type, uintmax_t size) {
  static constexpr std::array<uint8_t, 8> kSignature{0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  static constexpr std::array<uint8_t, 12> kEnd{0, 0, 0, 0, 'I', 'E', 'N', 'D', 0xae, 0x42, 0x60, 0x82};
  if (size < 33 + kEnd.size()) return Status::Error(where + "truncated PNG (" + std::to_string(size) + " bytes)");
  std::ifstream in(path, std::ios::binary);
  std::array<uint8_t, 33> head{};
  std::array<uint8_t, 12> tail{};
  in.read(reinterpret_cast<char*>(head.data()), head.size());
  in.seekg(-static_cast<std::streamoff>(tail.size()), std::ios::end);
  in.read(reinterpret_cast<char*>(tail.data()), tail.size());
  if (!in) return Status::Error(where + "image unreadable");
  if (!std::equal(kSignature.begin(), kSignature.end(), head.begin()) || std::memcmp(head.data() + 12, "IHDR", 4) != 0) {
    return Status::Error(where + "not a PNG file");
  }
  if (tail != kEnd) return Status::Error(where + "truncated PNG (no IEND chunk)");
  const uint32_t png_width = bigEndian32(head.data() + 16);
  const uint32_t png_height = bigEndian32(head.data() + 20);
  const int bit_depth = head[24];
  const int png_color = head[25];
  if (static_cast<int>(png_width) != width || static_cast<int>(png_height) != height || bit_depth != 8 ||
      png_color != color_type) {
    return Status::Error(where + "PNG is " + std::to_string(png_width) + "x" + std::to_string(png_height) +
                         " depth " + std::to_string(bit_depth) + " colour type " + std::to_string(png_color) +
                         ", expected " + std::to_string(width) + "x" + std::to_string(height) +
                         " depth 8 colour type " + std::to_string(color_type));
  }
  return Status::Ok();
}

// Cheap checks of a JPEG without decoding: the start and end markers, and the frame header's
// size and components, found by walking the marker segments before the scan.
Status checkJpegFile(const fs::path& path, const std::string& where, int width, int height,
                     int components, uintmax_t size) {
  std::ifstream in(path, std::ios::binary);
  std::vector<uint8_t> head(std::min<uintmax_t>(size, 65536));
  std::array<uint8_t, 2> tail{};
  in.read(reinterpret_cast<char*>(head.data()), static_cast<std::streamsize>(head.size()));
  if (size >= 4) {
    in.seekg(-2, std::ios::end);
    in.read(reinterpret_cast<char*>(tail.data()), tail.size());
  }
  if (!in) return Status::Error(where + "image unreadable");
  if (size < 4 || head[0] != 0xff || head[1] != 0xd8) return Status::Error(where + "not a JPEG file");
  if (tail[0] != 0xff || tail[1] != 0xd9) return Status::Error(where + "truncated JPEG (no end marker)");
  for (std::size_t at = 2; at + 4 <= head.size() && head[at] == 0xff;) {
    const uint8_t marker = head[at + 1];
    const std::size_t length = (std::size_t{head[at + 2]} << 8) | head[at + 3];
    const bool frame_header = marker >= 0xc0 && marker <= 0xcf && marker != 0xc4 && marker != 0xc8 && marker != 0xcc;
    if (frame_header && at + 10 <= head.size()) {
      const int jpeg_height = (head[at + 5] << 8) | head[at + 6];
      const int jpeg_width = (head[at + 7] << 8) | head[at + 8];
      if (jpeg_width != width || jpeg_height != height || head[at + 9] != components)
        return Status::Error(where + "JPEG is " + std::to_string(jpeg_width) + "x" + std::to_string(jpeg_height) +
                             " with " + std::to_string(head[at + 9]) + " components, expected " +
                             std::to_string(width) + "x" + std::to_string(height) + " with " +
                             std::to_string(components));
      return Status::Ok();
    }
    if (marker == 0xda) break;  // the scan: no frame header before it
    at += 2 + length;
  }
  return Status::Error(where + "JPEG without a frame header");
}

}  // namespace

Status SessionReader::checkImage(int camera, const IndexRecord& record, bool decode) const {
  const SessionCamera& cam = manifest_.cameras[camera];
  const bool gray = cvTypeOfPixelFormat(cam.pixel_format) == CV_8UC1;
  const std::string frame = describeFrame(camera, record) + ": ";
  const bool has_images = manifest_.images != ImageMode::kNone;
  if (has_images == record.file.empty())
    return Status::Error(dir_.string() + ": " + frame +
                         (has_images ? "no image file, the session keeps images ("
                                     : "an image file, the session keeps none (") +
                         imageModeName(manifest_.images) + ")");
  if (has_images) {
    const fs::path path = imagePath(camera, record);
    const std::string where = path.string() + ": " + frame;
    std::error_code error;
    const auto size = fs::file_size(path, error);
    if (error) return Status::Error(where + "image missing (" + error.message() + ")");
    if (decode) {
      std::vector<uint8_t> bytes;
      if (!readBytes(path, bytes)) return Status::Error(where + "image unreadable");
      const cv::Mat image = cv::imdecode(bytes, cv::IMREAD_UNCHANGED);
      if (image.empty()) return Status::Error(where + "not a decodable image");
      if (image.cols != cam.width || image.rows != cam.height || image.type() != cvTypeOfPixelFormat(cam.pixel_format)) {
        return Status::Error(where + "image is " + std::to_string(image.cols) + "x" + std::to_string(image.rows) +
                             " with " + std::to_string(image.channels()) + " channels, the manifest says " +
                             std::to_string(cam.width) + "x" + std::to_string(cam.height) + " " + cam.pixel_format);
      }
    } else {
      const Status checked = manifest_.images == ImageMode::kCompressed
                                 ? checkJpegFile(path, where, cam.width, cam.height, gray ? 1 : 3, size)
                                 : checkPngFile(path, where, cam.width, cam.height, gray ? 0 : 2, size);
      if (!checked.ok()) return checked;
    }
  }
  if (record.silhouette.empty()) return Status::Ok();
  const fs::path path = dir_ / cameraDirectoryName(camera) / record.silhouette;
  const std::string where = path.string() + ": silhouette of " + frame;
  std::error_code error;
  const auto size = fs::file_size(path, error);
  if (error) return Status::Error(where + "missing (" + error.message() + ")");
  return checkPngFile(path, where, cam.width, cam.height, 0, size);
}

Expected<cv::Mat> SessionReader::readSilhouette(std::size_t set_index, int camera) const {
  Expected<IndexRecord> record = frameRecord(set_index, camera);
  if (!record.ok()) return Status::Error(record.error());
  if (record.value().silhouette.empty()) return cv::Mat();
  const fs::path path = dir_ / cameraDirectoryName(camera) / record.value().silhouette;
  std::vector<uint8_t> bytes;
  if (!readBytes(path, bytes))
    return Status::Error(path.string() + ": " + describeFrame(camera, record.value()) + ": silhouette missing or unreadable");
  cv::Mat silhouette = cv::imdecode(bytes, cv::IMREAD_UNCHANGED);
  const SessionCamera& cam = manifest_.cameras[camera];
  if (silhouette.cols != cam.width || silhouette.rows != cam.height || silhouette.type() != CV_8UC1)
    return Status::Error(path.string() + ": " + describeFrame(camera, record.value()) +
                         ": the silhouette is not a " + std::to_string(cam.width) + "x" +
                         std::to_string(cam.height) + " gray PNG");
  return silhouette;
}

Expected<IndexRecord> SessionReader::frameRecord(std::size_t set_index, int camera) const {
  if (set_index >= sets_.size() || camera < 0 || static_cast<std::size_t>(camera) >= manifest_.cameras.size()) {
    return Status::Error(dir_.string() + ": no set " + std::to_string(set_index) + " / camera " + std::to_string(camera));
  }
  const std::optional<IndexRecord>& record = sets_[set_index].frames[camera];
  if (!record) {
    return Status::Error(dir_.string() + ": set " + std::to_string(sets_[set_index].sequence) + " has no frame of camera " +
                         std::to_string(camera));
  }
  return *record;
}

Expected<Frame> SessionReader::readFrame(std::size_t set_index, int camera) const {
  Expected<IndexRecord> found = frameRecord(set_index, camera);
  if (!found.ok()) return Status::Error(found.error());
  const IndexRecord& record = found.value();
  const SessionCamera& cam = manifest_.cameras[camera];
  Frame frame;
  if (manifest_.images == ImageMode::kNone) {
    Expected<cv::Mat> silhouette = readSilhouette(set_index, camera);
    if (!silhouette.ok()) return Status::Error(silhouette.error());
    frame.image = silhouette.value().empty() ? cv::Mat::zeros(cam.height, cam.width, CV_8UC1)
                                             : silhouette.value();
    if (cvTypeOfPixelFormat(cam.pixel_format) == CV_8UC3)
      cv::cvtColor(frame.image, frame.image, cv::COLOR_GRAY2BGR);
  } else {
    const fs::path path = imagePath(camera, record);
    const std::string where = path.string() + ": " + describeFrame(camera, record) + ": ";
    std::vector<uint8_t> bytes;
    if (!readBytes(path, bytes)) return Status::Error(where + "image missing or unreadable");
    frame.image = cv::imdecode(bytes, cv::IMREAD_UNCHANGED);
    if (frame.image.empty()) return Status::Error(where + "not a decodable image");
    if (frame.image.cols != cam.width || frame.image.rows != cam.height ||
        frame.image.type() != cvTypeOfPixelFormat(cam.pixel_format)) {
      return Status::Error(where + "image does not match the manifest's " + std::to_string(cam.width) + "x" +
                           std::to_string(cam.height) + " " + cam.pixel_format);
    }
  }
  setRecordedFields(record, camera, frame);
  return frame;
}

Expected<Frame> SessionReader::readFrameSilhouette(std::size_t set_index, int camera) const {
  Expected<IndexRecord> found = frameRecord(set_index, camera);
  if (!found.ok()) return Status::Error(found.error());
  Expected<cv::Mat> silhouette = readSilhouette(set_index, camera);
  if (!silhouette.ok()) return Status::Error(silhouette.error());
  Frame frame;
  frame.image = std::move(silhouette.value());
  setRecordedFields(found.value(), camera, frame);
  return frame;
}

}  // namespace mocap
