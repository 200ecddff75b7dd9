// The on-disk session format shared by the Recorder and the SessionReader.
//
//   <session>/manifest.yaml      cameras (name, width, height, pixel_format, fps), calibration file,
//                                software version, start time (UTC and CLOCK_MONOTONIC), the
//                                tracker settings the session was tracked with (`tracker:`, the
//                                daemon configuration's tracker keys; absent in older sessions)
//                                and how the images are kept (`images:` lossless, compressed or
//                                none; absent in format 1 sessions, which are lossless)
//   <session>/calibration.yaml   the rig, OpenCV FileStorage (saveRig); absent if no rig was given
//   <session>/body.yaml          the body model tracked while recording (formatBodyModel), so a
//                                replay tracks the same body; absent in sessions without one
//   <session>/truth_body.yaml    the body truth.csv's poses are of, when it is not body.yaml (the
//                                fake scene's subject tracked with another body); absent otherwise
//   <session>/cam<i>/NNNNNN.png  the images, numbered consecutively per camera from 000000:
//                                lossless PNG (images: lossless), or NNNNNN.jpg, JPEG
//                                (compressed); none stored with images: none
//   <session>/cam<i>/NNNNNN_silhouette.png  the frame's silhouette (8-bit gray PNG, 255 where the
//                                subject is) as extracted against the camera's background
//                                (backgrounds.csv) from the frame as captured; absent for a frame
//                                with no background then, and in format 1 sessions
//   <session>/cam<i>/index.csv   one line per stored frame:
//                                set_sequence,camera_sequence,timestamp_ns,dropped_before,corrupt,
//                                file,silhouette (file empty with images: none; silhouette empty
//                                where none is stored; format 1 sessions lack the column)
//   <session>/sets.csv           one line per committed frame set: set_sequence,timestamp_ns,present
//                                (present: one '1'/'0' per camera), written after the set's images
//                                and index lines, so it is the commit record of the set.
//   <session>/backgrounds.csv    the silhouette backgrounds the session was tracked with, one line
//                                each, written after its file: from_sequence,camera,file. Camera
//                                `camera`'s frames with camera_sequence >= from_sequence were
//                                extracted against cam<i>/<file> (an OpenCV FileStorage background
//                                model, tracker/vision/background_model.h) until the next line of
//                                that camera; an empty file: thresholded from then on. Absent in
//                                sessions recorded without a background (and older ones), and
//                                with images: none (no image to extract from: the silhouettes
//                                are the record).
//   <session>/truth.csv          sessions of a source that knows the truth (the fake scene): one
//                                line per committed set whose subject was in view, written after
//                                its commit line: frame_sequence (camera_sequence of the set's
//                                first frame) then the true value of each DOF of body.yaml, in its
//                                order, the header naming them (the subject's joints are those
//                                DOFs on truth_body.yaml if present). Absent otherwise.
//
// Plain PNG, JPEG and CSV: every image tool, ffmpeg (-i cam0/%06d.png) and spreadsheet reads them.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "drivers/status.h"

namespace mocap {

inline constexpr const char* kManifestFile = "manifest.yaml";
inline constexpr const char* kCalibrationFile = "calibration.yaml";
inline constexpr const char* kBodyModelFile = "body.yaml";
inline constexpr const char* kTruthBodyModelFile = "truth_body.yaml";
inline constexpr const char* kSetsFile = "sets.csv";
inline constexpr const char* kIndexFile = "index.csv";
inline constexpr const char* kIndexHeader =
    "set_sequence,camera_sequence,timestamp_ns,dropped_before,corrupt,file,silhouette";
// Format 1's, before silhouettes were stored.
inline constexpr const char* kIndexHeaderV1 =
    "set_sequence,camera_sequence,timestamp_ns,dropped_before,corrupt,file";
inline constexpr const char* kSetsHeader = "set_sequence,timestamp_ns,present";
inline constexpr const char* kBackgroundsFile = "backgrounds.csv";
inline constexpr const char* kBackgroundsHeader = "from_sequence,camera,file";
inline constexpr const char* kTruthFile = "truth.csv";
// Format 2 added the images mode and the silhouettes; this build reads 1 and 2.
inline constexpr int kSessionFormatVersion = 2;

// Pixel formats a session stores, as FourCC names like VideoMode::pixel_format.
inline constexpr const char* kPixelGray = "GREY";  // CV_8UC1
inline constexpr const char* kPixelBgr = "BGR3";   // CV_8UC3, B, G, R

// How a session keeps its images (the manifest's `images`). Silhouettes and truth are kept alike.
enum class ImageMode {
  kLossless,    // PNG, exactly as captured
  kCompressed,  // JPEG (lossy): a fraction of the size; replay extracts from the decoded images
  kNone,        // no images: replay tracks the recorded silhouettes
};
const char* imageModeName(ImageMode mode);
// "lossless", "compressed" or "none"; nullopt for another name.
std::optional<ImageMode> parseImageMode(const std::string& name);
// The image file's extension for a mode that stores images (".png", ".jpg").
const char* imageExtension(ImageMode mode);

struct SessionCamera {
  std::string name;
  int width = 0;
  int height = 0;
  std::string pixel_format = kPixelBgr;
  double fps = 0;  // nominal rate
};

struct SessionManifest {
  int format_version = kSessionFormatVersion;
  std::string software_version;
  std::string start_time_utc;   // ISO 8601
  int64_t start_monotonic_ns = 0;
  std::string calibration_file;  // relative to the session; empty: no calibration
  std::string body_model_file;   // relative to the session; empty: no body model (optional key)
  // The body of the truth's poses when not body_model_file's (optional key `truth_body_model`).
  std::string truth_body_model_file;
  // The tracker's settings as key and value text, in the daemon configuration's `tracker:` keys;
  // the session format does not interpret them (the daemon does). Empty: none (optional key).
  std::vector<std::pair<std::string, std::string>> tracker_settings;
  ImageMode images = ImageMode::kLossless;  // key `images`; format 1: lossless
  std::vector<SessionCamera> cameras;
};

// One stored frame of one camera.
struct IndexRecord {
  uint64_t set_sequence = 0;
  uint64_t camera_sequence = 0;
  int64_t timestamp_ns = 0;
  uint32_t dropped_before = 0;
  bool corrupt = false;
  std::string file;        // relative to the camera directory; empty with images: none
  std::string silhouette;  // relative to the camera directory; empty: none stored
};

// One committed frame set.
struct SetRecord {
  uint64_t set_sequence = 0;
  int64_t timestamp_ns = 0;
  std::string present;  // '1' where the camera has a frame in this set
};

// One background change of one camera (backgrounds.csv).
struct BackgroundRecord {
  uint64_t from_sequence = 0;  // the camera's first frame (camera_sequence) it applies to
  int camera = 0;
  std::string file;  // in the camera's directory; empty: no background from then on
};

// The true pose of one set's frame (truth.csv).
struct TruthRecord {
  uint64_t frame_sequence = 0;  // camera_sequence of the set's first frame
  std::vector<double> dofs;     // in the order of the header's names
};

// "cam<i>": the camera's directory inside the session.
std::string cameraDirectoryName(int camera);
// CV type a pixel format stores, or -1 if the format is not one a session can hold.
int cvTypeOfPixelFormat(const std::string& pixel_format);

std::string formatIndexLine(const IndexRecord& record);  // no trailing newline
std::string formatSetLine(const SetRecord& record);
std::string formatBackgroundLine(const BackgroundRecord& record);
std::string truthHeader(const std::vector<std::string>& dof_names);
std::string formatTruthLine(const TruthRecord& record);  // values round-trip exactly
// Parse one line (no newline); the error names the bad column, not the file. An index line of a
// format 1 session has no silhouette column.
Expected<IndexRecord> parseIndexLine(const std::string& line,
                                     int format_version = kSessionFormatVersion);
Expected<SetRecord> parseSetLine(const std::string& line, std::size_t camera_count);
Expected<BackgroundRecord> parseBackgroundLine(const std::string& line, std::size_t camera_count);
Expected<TruthRecord> parseTruthLine(const std::string& line,
                                     const std::vector<std::string>& dof_names);

std::string emitManifest(const SessionManifest& manifest);
// `source` names the file in errors: "<source>: <field>: <reason>".
Expected<SessionManifest> parseManifest(const std::string& yaml_text, const std::string& source);

}  // namespace mocap
