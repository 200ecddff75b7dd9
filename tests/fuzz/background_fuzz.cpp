// Fuzzes the learned-background reader, tracker/vision/background_model.h's loadBackground: each
// input is written to a scratch file (named .yml.gz if it starts as gzip does) and loaded. A model
// it accepts must be whole: two float matrices of one size, channels 1 or 3, finite values, and no
// negative deviation.
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <stdexcept>

#include <opencv2/core.hpp>

#include "tests/fuzz/fuzz_support.h"
#include "tracker/vision/background_model.h"

namespace {

void requireWhole(const mocap::BackgroundModel& model) {
  const double largest = std::numeric_limits<double>::max();
  const bool whole = !model.empty() && model.mean.depth() == CV_32F &&
                     (model.channels() == 1 || model.channels() == 3) &&
                     model.stddev.type() == model.mean.type() &&
                     model.stddev.size() == model.mean.size() && cv::checkRange(model.mean) &&
                     cv::checkRange(model.stddev, true, nullptr, 0, largest);
  if (whole) return;
  std::fprintf(stderr, "loadBackground accepted a model that is not whole\n");
  std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, std::size_t size) {
  static const mocap::fuzz::ScratchDirectory scratch;
  const bool gzip = size >= 2 && data[0] == 0x1f && data[1] == 0x8b;
  const std::string path =
      scratch.write(gzip ? "background.yml.gz" : "background.yml", mocap::fuzz::asText(data, size))
          .string();
  try {
    const mocap::BackgroundModel model = mocap::loadBackground(path);
    requireWhole(model);
    mocap::unsteadyShare(model);
    mocap::changedShare(model, model, 4, 9);
  } catch (const std::runtime_error& e) {
    mocap::fuzz::requireNamesSource(e, path);
  }
  return 0;
}
