// Board detection over a recorded session's frame sets.
#include "clients/mocapctl/session_views.h"

#include "drivers/record/session_reader.h"

namespace mocapctl {

std::vector<mocap::CameraObservations> detectSession(const std::string& dir,
                                                     const mocap::BoardSpec& board, int every,
                                                     std::vector<mocap::RejectedView>& rejected) {
  if (every < 1) throw mocap::CalibrationError("--every must be at least 1");
  auto opened = mocap::SessionReader::open(dir);
  if (!opened.ok()) throw mocap::CalibrationError("session " + dir + ": " + opened.error());
  const mocap::SessionReader& session = *opened.value();
  if (session.sets().empty())
    throw mocap::CalibrationError("session " + dir + ": no frame set was recorded");
  const mocap::BoardDetector detector(board);
  std::vector<mocap::CameraObservations> cameras(session.cameras().size());
  for (std::size_t c = 0; c < cameras.size(); ++c) {
    cameras[c].name = session.cameras()[c].name;
    cameras[c].image_size = cv::Size(session.cameras()[c].width, session.cameras()[c].height);
  }
  for (std::size_t s = 0; s < session.sets().size(); s += static_cast<std::size_t>(every)) {
    const std::string view = std::to_string(session.sets()[s].sequence);
    for (std::size_t c = 0; c < cameras.size(); ++c) {
      if (!session.sets()[s].frames[c]) continue;  // the camera gave no frame in this set
      auto frame = session.readFrame(s, static_cast<int>(c));
      if (!frame.ok()) {
        rejected.push_back({cameras[c].name, view, frame.error()});
        continue;
      }
      mocap::BoardDetection detection;
      std::string why;
      if (detector.detect(frame.value().image, detection, why))
        cameras[c].views[view] = std::move(detection);
      else
        rejected.push_back({cameras[c].name, view, why});
    }
  }
  return cameras;
}

}  // namespace mocapctl
