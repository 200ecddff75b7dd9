// Deterministic replay into a synchronizer in SyncMode::kReplay: one thread pushes the frames of
// all cameras of a session in timestamp order and promises time with advance(), so the frame sets
// the consumer pops depend only on the recording, never on thread timing.
#pragma once

#include <atomic>
#include <functional>
#include <string>

#include "drivers/record/session_reader.h"
#include "drivers/status.h"
#include "drivers/sync/frame_synchronizer.h"

namespace mocap {

struct ReplayPumpOptions {
  bool real_time = false;  // at the recorded pace instead of as fast as the consumer pops
  int loops = 1;           // passes over the session; later passes shift timestamps and sequences
  bool close_at_end = true;  // close() the synchronizer afterwards, so the consumer drains and ends
  const std::atomic<bool>* stop = nullptr;  // checked between frames; set it, then close() the sync
  // Each frame's recorded silhouette as its image (SessionReader::readFrameSilhouette) instead of
  // the stored image: no image is decoded.
  bool silhouettes = false;
};

// Call on a thread of its own while another thread pops. Frames are pushed in order of corrected
// time (recorded timestamp + the synchronizer's clock offset for that camera; ties by set, then
// camera), each followed by advance() to its corrected time: the promise that no earlier frame
// follows, which lets a camera's gap or early end pass in recorded time. Frame::camera is the
// session's camera index, so the synchronizer's camera_count must be the session's. Fails naming
// the file and frame if an image does not decode (the synchronizer is still closed if asked).
Status pumpSession(const SessionReader& reader, FrameSynchronizer& sync, const ReplayPumpOptions& options = {});

}  // namespace mocap
