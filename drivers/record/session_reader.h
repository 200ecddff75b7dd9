// Reads a recorded session (see session_format.h): validates it at open, then hands out its frame
// sets in recorded order. Used by the fake driver's replay source and by tools.
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "drivers/frame.h"
#include "drivers/record/session_format.h"
#include "drivers/status.h"
#include "tracker/model/body_model.h"
#include "tracker/model/camera.h"
#include "tracker/vision/background_model.h"

namespace mocap {

// One committed frame set: per camera, its index record or nothing.
struct SessionSet {
  uint64_t sequence = 0;
  int64_t timestamp_ns = 0;
  std::vector<std::optional<IndexRecord>> frames;
};

// One camera's silhouette background from one of its frames on (backgrounds.csv), loaded.
struct SessionBackground {
  uint64_t from_sequence = 0;  // the camera's first frame (camera_sequence) it applies to
  int camera = 0;
  std::string file;  // its path in the session, "cam<i>/<file>"; empty: none
  std::shared_ptr<const BackgroundModel> model;  // null: none from then on (thresholded)
};

struct SessionReadOptions {
  // Decode every image at open (slow: the whole session) instead of checking each PNG's or
  // JPEG's header against the manifest. Either way a missing file fails the open.
  bool decode_all = false;
};

// Thread use: after open() the reader is immutable; readFrame() may be called from any threads.
class SessionReader {
 public:
  // Fails with a message naming the file and field or frame: missing or bad manifest, unreadable
  // calibration or body model, an index line that does not parse, a set whose frame has no index
  // line, a missing or truncated image, an image whose size or type is not the manifest's. A
  // truncated last line of an index or of sets.csv (a crash mid-append) is dropped and noted in
  // notes(). So is backgrounds.csv's; a background file that does not load, or does not fit its
  // camera, fails the open.
  static Expected<std::unique_ptr<SessionReader>> open(const std::filesystem::path& dir,
                                                       SessionReadOptions options = {});

  const std::filesystem::path& path() const { return dir_; }
  const SessionManifest& manifest() const { return manifest_; }
  const std::vector<SessionCamera>& cameras() const { return manifest_.cameras; }
  const Rig& rig() const { return rig_; }  // empty if the session has no calibration
  // The body model the session was tracked with; nullptr if the session stores none.
  const BodyModel* bodyModel() const { return body_model_ ? &*body_model_ : nullptr; }
  // The body truth()'s poses are of: truth_body.yaml if the session stores one, else bodyModel().
  const BodyModel* truthBodyModel() const {
    return truth_body_model_ ? &*truth_body_model_ : bodyModel();
  }
  // The tracker settings the session was tracked with (the manifest's `tracker:`); empty if none.
  const std::vector<std::pair<std::string, std::string>>& trackerSettings() const {
    return manifest_.tracker_settings;
  }
  const std::vector<SessionSet>& sets() const { return sets_; }
  // The backgrounds the session was tracked with, in recorded order (per camera, from_sequence
  // never decreases); empty if none (or an older session).
  const std::vector<SessionBackground>& backgrounds() const { return backgrounds_; }
  // The true pose (the body model's DOFs) of the set whose first frame has camera_sequence
  // `frame_sequence`; nullptr if the session does not know it (truth.csv absent or no line).
  const Eigen::VectorXd* truth(uint64_t frame_sequence) const {
    const auto found = truth_.find(frame_sequence);
    return found == truth_.end() ? nullptr : &found->second;
  }
  bool hasTruth() const { return !truth_.empty(); }
  // What was tolerated at open (dropped partial lines, uncommitted frames), one line each.
  const std::vector<std::string>& notes() const { return notes_; }

  // How the session keeps its images (manifest().images).
  ImageMode images() const { return manifest_.images; }

  // The stored frame of `camera` in set `set_index` (an index into sets()), as recorded:
  // Frame::camera = camera, recorded sequence, timestamp and flags, decoded pixels (a JPEG's with
  // images: compressed). A session without images (images: none) gives the recorded silhouette
  // as the image, in the camera's pixel format, 255 where the subject is (black where none is
  // stored): what a threshold turns back into that silhouette. An error names the file and frame
  // if the set has no frame of that camera or the image does not decode.
  Expected<Frame> readFrame(std::size_t set_index, int camera) const;
  // The same frame with its recorded silhouette (readSilhouette) as the image, decoding no stored
  // image: an empty Mat if none is stored.
  Expected<Frame> readFrameSilhouette(std::size_t set_index, int camera) const;
  // The recorded silhouette of `camera` in set `set_index`: CV_8UC1, 255 where the subject is;
  // an empty Mat if none is stored (no background then, or a format 1 session).
  Expected<cv::Mat> readSilhouette(std::size_t set_index, int camera) const;
  std::filesystem::path imagePath(int camera, const IndexRecord& record) const;

 private:
  SessionReader() = default;
  Status load(const SessionReadOptions& options);
  // Checks the frame's image (as the session keeps them) and silhouette files.
  Status checkImage(int camera, const IndexRecord& record, bool decode) const;
  Expected<IndexRecord> frameRecord(std::size_t set_index, int camera) const;
  Status loadBackgrounds();
  Status loadTruth();

  std::filesystem::path dir_;
  SessionManifest manifest_;
  Rig rig_;
  std::optional<BodyModel> body_model_;
  std::optional<BodyModel> truth_body_model_;
  std::vector<SessionSet> sets_;
  std::vector<SessionBackground> backgrounds_;
  std::map<uint64_t, Eigen::VectorXd> truth_;
  std::vector<std::string> notes_;
};

}  // namespace mocap
