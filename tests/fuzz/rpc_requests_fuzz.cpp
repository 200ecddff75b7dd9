// Fuzzes what the service does with a request's bytes (server/mocap_service.cpp): gRPC hands it
// to protobuf, then the handler checks the fields. The input is parsed as each request message;
// the checks with code of their own are run on the result: StreamPoses' joint names against the
// body, and StartRecording's path against the recording directory (resolveInsideRoot, which must
// never accept a path that leads out of it, through "..", an absolute path or a symlink).
#include <filesystem>

#include "drivers/record/recorder.h"
#include "mocap/v1/mocap.pb.h"
#include "tests/fuzz/fuzz_support.h"
#include "tracker/model/builtin_models.h"

namespace {

namespace fs = std::filesystem;

// A recording directory holding a folder, a symlink to it and one leading out of the directory.
struct RecordingRoot {
  mocap::fuzz::ScratchDirectory scratch;
  fs::path root;
  RecordingRoot() {
    root = fs::canonical(scratch.path()) / "recordings";
    fs::create_directories(root / "day1");
    fs::create_directory_symlink(root / "day1", root / "today");
    fs::create_directory_symlink(scratch.path(), root / "escape");
  }
};

void checkJoints(const mocap::v1::StreamPosesRequest& request) {
  static const mocap::BodyModel body = mocap::builtinHumanModel();
  for (const std::string& name : request.joints()) {
    const int index = body.pointIndex(name);
    if (index >= 0 && body.points.at(static_cast<std::size_t>(index)).name != name) std::abort();
  }
}

void checkRecordingPath(const mocap::v1::StartRecordingRequest& request) {
  static const RecordingRoot recordings;
  const auto resolved = mocap::resolveInsideRoot(recordings.root, request.path());
  if (!resolved.ok()) return;
  const fs::path relative = resolved.value().lexically_relative(recordings.root);
  const bool inside = !relative.empty() && relative != "." && *relative.begin() != ".." &&
                      fs::weakly_canonical(resolved.value()) == resolved.value();
  if (!inside) {
    std::fprintf(stderr, "session path '%s' accepted as %s, outside %s\n", request.path().c_str(),
                 resolved.value().c_str(), recordings.root.c_str());
    std::abort();
  }
}

template <typename Request>
bool parse(Request& request, const uint8_t* data, std::size_t size) {
  return request.ParseFromArray(data, static_cast<int>(size));
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, std::size_t size) {
  // The requests without fields: protobuf keeps whatever arrives as unknown fields.
  mocap::v1::GetSkeletonRequest skeleton;
  mocap::v1::GetStatusRequest status;
  mocap::v1::ListCamerasRequest cameras;
  mocap::v1::StopRecordingRequest stop;
  mocap::v1::ReacquireRequest reacquire;
  parse(skeleton, data, size);
  parse(status, data, size);
  parse(cameras, data, size);
  parse(stop, data, size);
  parse(reacquire, data, size);
  // The numbers of these two are range-checked inline by their handlers.
  mocap::v1::CaptureBackgroundRequest background;
  mocap::v1::FitBodyRequest fit;
  parse(background, data, size);
  parse(fit, data, size);

  if (mocap::v1::StreamPosesRequest poses; parse(poses, data, size)) checkJoints(poses);
  if (mocap::v1::StartRecordingRequest recording; parse(recording, data, size))
    checkRecordingPath(recording);
  return 0;
}
