// Inputs that crashed the readers in the fuzz build (tests/fuzz, with ASan and UBSan), each fed to
// its parser, which must now refuse it with an error naming the file and what is wrong.
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <stdexcept>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "drivers/record/session_format.h"
#include "tracker/model/camera.h"
#include "tracker/motion/bvh.h"
#include "tracker/vision/background_model.h"

namespace mocap {
namespace {

using ::testing::HasSubstr;

// A file of the test's own, removed when it goes out of scope.
class TempFile {
 public:
  TempFile(const std::string& name, const std::string& text)
      : path_((std::filesystem::path(testing::TempDir()) / (std::to_string(getpid()) + "_" + name))
                  .string()) {
    std::ofstream(path_) << text;
  }
  ~TempFile() { std::filesystem::remove(path_); }
  TempFile(const TempFile&) = delete;
  TempFile& operator=(const TempFile&) = delete;
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

// loadRig's message for the rig file at `path`; "(loaded)" if it loads.
std::string rigError(const std::string& path) {
  try {
    loadRig(path);
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "(loaded)";
}

// OpenCV asserted (cv::Exception, "isMap()") on a rig whose top level is not a map.
TEST(FuzzFindingsTest, RigWhoseTopLevelIsNotAMapIsRefusedByName) {
  for (const std::string top : {"- camera_count\n- 2\n", "just text\n"}) {
    const TempFile file("rig_not_a_map.yaml", "%YAML:1.0\n---\n" + top);
    const std::string& path = file.path();
    EXPECT_THAT(rigError(path), HasSubstr(path + ": not a camera rig")) << top;
  }
}

// Texts the YAML parsers failed on. OpenCV's FileStorage parser threw std::length_error
// (basic_string::_M_create, past loadRig's std::runtime_error) on the first and never returned on
// the second (libFuzzer's 20-s timeout, in cv::FileStorage::Impl::open); yaml-cpp's LoadAll never
// returned on the third, reading the stray ',' as one empty document after another.
TEST(FuzzFindingsTest, RigTextsTheParsersFailedOnAreRefusedByName) {
  const struct {
    std::string name, text, error;
  } cases[] = {
      {"rig_length_error.yaml", "%YAML:1.\n      s:1\n      :", ": not a readable YAML file: "},
      {"rig_opencv_hang.yaml",
       "%YAML:1.0\n---\n# Example two-cameme!opencv-matrix\n      rows: 4\n"
       "      \x80\xff\xff\xff:namm     :dt d\n     two-cameme!opencv-matrix\n      rows: 4\n"
       "  e-00 \n ",
       ": not a readable YAML file: "},
      {"rig_yaml_cpp_hang.yaml", "%YAML:1.0\n,",
       ": not a camera rig: text after the first YAML document"},
  };
  for (const auto& c : cases) {
    const TempFile file(c.name, c.text);
    const std::string& path = file.path();
    EXPECT_THAT(rigError(path), HasSubstr(path + c.error)) << c.name;
  }
}

// OpenCV allocated rows x cols (80 GB here) before reading a matrix's data (ASan: out of memory);
// the size is still checked before anything is read.
TEST(FuzzFindingsTest, RigMatrixOfAHugeSizeIsRefusedBeforeAllocating) {
  const TempFile file(
      "rig_huge_matrix.yaml",
      "%YAML:1.0\n---\ncamera_count: 1\ncamera_0:\n   image_width: 780\n   image_height: 580\n"
      "   camera_matrix: !!opencv-matrix\n      rows: 100000\n      cols: 100000\n      dt: d\n"
      "      data: [ 1200., 0., 390., 0., 1200., 290., 0., 0., 1. ]\n");
  const std::string& path = file.path();
  EXPECT_EQ(rigError(path),
            path + ": camera_0.camera_matrix: 100000x100000 is larger than any matrix of a rig");
}

// loadBackground's message for the background file at `path`; "(loaded)" if it loads.
std::string backgroundError(const std::string& path) {
  try {
    loadBackground(path);
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "(loaded)";
}

// A 1x1 gray background file as saveBackground writes it, up to its mean's data.
const std::string kBackgroundStart =
    "%YAML:1.0\n---\nimage_width: 1\nimage_height: 1\nchannels: 1\nmean: !!opencv-matrix\n"
    "   rows: 1\n";

// Background files OpenCV's FileStorage failed on, when it read them: it never returned on a
// base64 line starting with a character outside base64 (libFuzzer's 20-s timeout, in
// FileStorage::Impl::parseBase64), allocated 8 GB for "cols:%8" (a size it could not read; ASan:
// out of memory), and asserted (cv::Exception, "isMap()", not naming the file) on a file whose top
// level is a list.
TEST(FuzzFindingsTest, BackgroundTextsFileStorageFailedOnAreRefusedByName) {
  const struct {
    std::string name, text, error;
  } cases[] = {
      {"background_opencv_hang.yml",
       kBackgroundStart + "   cols: 1\n   dt: f\n   data: !!binary |\n"
                          "     & MWYgICAgICAgICAgICAgICAgICAgICAgAADgQA==\n",
       ": mean.data: '&' in the base64 data (line 11)"},
      {"background_huge_matrix.yml",
       kBackgroundStart + "   cols:%8\n   dt: f\n   data: !!binary |\n"
                          "      MWYgICAgICAgICAgICAgICAgICAgICAgAADgQA==\n",
       ": mean: expected one of its fields (rows, cols, dt, data) as \"name: value\" (line 8)"},
      {"background_not_a_map.yml", "%YAML:1.0\n---\n- image_width\n",
       ": expected a field of the model (\"name: value\") (line 3)"},
  };
  for (const auto& c : cases) {
    const TempFile file(c.name, c.text);
    const std::string& path = file.path();
    EXPECT_THAT(backgroundError(path), HasSubstr(path + c.error)) << c.name;
  }
}

// yaml-cpp threw YAML::BadSubscript out of parseManifest for a camera that is not a map.
TEST(FuzzFindingsTest, ManifestCameraThatIsNotAMapIsAnError) {
  const std::string manifest =
      "format_version: 1\nsoftware_version: x\nstart_time_utc: t\nstart_monotonic_ns: 0\n"
      "calibration: ''\ncameras: [cam0]\n";
  const Expected<SessionManifest> parsed = parseManifest(manifest, "session/manifest.yaml");
  ASSERT_FALSE(parsed.ok());
  EXPECT_EQ(parsed.error(),
            "session/manifest.yaml: cameras[0]: expected a map (name, width, height, ...)");
}

// Converting "Frames: 1e300" to an integer was undefined behaviour (UBSan: float-cast-overflow).
TEST(FuzzFindingsTest, BvhFrameCountNoIntegerHoldsIsAnError) {
  const std::string bvh =
      "HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 0\n  CHANNELS 1 Xposition\n}\n"
      "MOTION\nFrames: 1e300\nFrame Time: 0.04\n1\n";
  try {
    parseBvh(bvh, "huge.bvh");
    FAIL() << "parsed a file declaring 1e300 frames";
  } catch (const std::runtime_error& e) {
    EXPECT_STREQ(e.what(), "huge.bvh:8: Frames: more frames than the file has lines (10)");
  }
}

// A deeply nested hierarchy recursed until the stack overflowed (ASan: stack-overflow).
TEST(FuzzFindingsTest, BvhNestedTooDeepIsAnError) {
  std::string bvh = "HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\n";
  for (int depth = 0; depth < 1000; ++depth) bvh += "JOINT b\n{\nOFFSET 0 0 0\n";
  bvh += std::string(1001, '}') + "\nMOTION\nFrames: 0\nFrame Time: 0.04\n";
  try {
    parseBvh(bvh, "deep.bvh");
    FAIL() << "parsed joints nested 1000 deep";
  } catch (const std::runtime_error& e) {
    EXPECT_STREQ(e.what(), "deep.bvh:770: joints nested deeper than 256 levels");
  }
}

}  // namespace
}  // namespace mocap
