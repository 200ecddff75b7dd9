// Background learning recovers per-pixel mean and noise; a saved model reads back identical, files
// cv::FileStorage wrote still load, and bad files are refused naming the file and the field.
#include "tracker/vision/background_model.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>

#include <unistd.h>

#include <opencv2/core.hpp>

namespace mocap {
namespace {

using ::testing::EndsWith;
using ::testing::HasSubstr;

std::vector<cv::Mat> noisyFrames(int type, int count, double sigma) {
  cv::Mat base(30, 40, type);
  cv::randu(base, 40, 200);
  cv::RNG rng(5);
  std::vector<cv::Mat> frames;
  for (int i = 0; i < count; ++i) {
    cv::Mat noise(base.size(), CV_32FC(base.channels()));
    rng.fill(noise, cv::RNG::NORMAL, 0, sigma);
    cv::Mat frame;
    base.convertTo(frame, CV_32F);
    frame += noise;
    frame.convertTo(frame, CV_8U);
    frames.push_back(frame);
  }
  return frames;
}

TEST(BackgroundModel, LearnsMeanAndNoise) {
  for (int type : {CV_8UC1, CV_8UC3}) {
    const auto frames = noisyFrames(type, 200, 3.0);
    const BackgroundModel model = learnBackground(frames);
    ASSERT_EQ(model.channels(), CV_MAT_CN(type));
    EXPECT_NEAR(cv::mean(model.stddev.reshape(1))[0], 3.0, 0.2);
    cv::Mat first;
    frames[0].convertTo(first, CV_32F);
    EXPECT_LT(cv::norm(model.mean, first, cv::NORM_INF), 15.0);  // within 5 sigma of one frame
  }
}

// Noise alone leaves the capture steady; a patch that changes in some frames (someone walking
// through) is counted, in gray and in colour, whichever channel changes.
TEST(BackgroundModel, UnsteadyShareCountsThePixelsThatChangedDuringTheCapture) {
  for (int type : {CV_8UC1, CV_8UC3}) {
    std::vector<cv::Mat> frames = noisyFrames(type, 25, 3.0);
    EXPECT_EQ(unsteadyShare(learnBackground(frames)), 0.0);
    // A 10x12 patch of the 30x40 image (10 %) covered in 5 of the 25 frames, 80 levels off in
    // the last channel only.
    for (int i = 0; i < 5; ++i) {
      cv::Mat patch = frames[i](cv::Rect(5, 5, 12, 10));
      std::vector<cv::Mat> channels;
      cv::split(patch, channels);
      channels.back() += 80;
      cv::merge(channels, patch);
    }
    EXPECT_NEAR(unsteadyShare(learnBackground(frames)), 0.10, 1e-9) << type;
  }
}

// Someone standing still through a capture leaves it steady, but the background it replaces shows
// them: two captures of the empty room differ by noise alone, one with a still patch by its share.
TEST(BackgroundModel, ChangedShareCountsWhatMovedSinceTheBackgroundItReplaces) {
  for (int type : {CV_8UC1, CV_8UC3}) {
    // One room, two captures of 25 frames with their own noise.
    const std::vector<cv::Mat> frames = noisyFrames(type, 50, 3.0);
    const std::vector<cv::Mat> first(frames.begin(), frames.begin() + 25);
    std::vector<cv::Mat> second(frames.begin() + 25, frames.end());
    const BackgroundModel before = learnBackground(first);
    EXPECT_EQ(changedShare(before, learnBackground(second), 4, 9), 0.0) << type;
    // A 10 % patch 30 levels brighter in the first channel in every frame: steady, but changed.
    for (cv::Mat& frame : second) {
      cv::Mat patch = frame(cv::Rect(5, 5, 12, 10));
      std::vector<cv::Mat> channels;
      cv::split(patch, channels);
      channels.front() += 30;
      cv::merge(channels, patch);
    }
    const BackgroundModel after = learnBackground(second);
    EXPECT_EQ(unsteadyShare(after), 0.0) << type;
    EXPECT_NEAR(changedShare(before, after, 4, 9), 0.10, 1e-9) << type;
    // The floor of the test decides for a change well above the noise: 25 levels count, 40 not.
    EXPECT_NEAR(changedShare(before, after, 4, 25), 0.10, 1e-9) << type;
    EXPECT_EQ(changedShare(before, after, 4, 40), 0.0) << type;
  }
  const BackgroundModel gray = learnBackground(noisyFrames(CV_8UC1, 5, 3.0));
  const BackgroundModel colour = learnBackground(noisyFrames(CV_8UC3, 5, 3.0));
  EXPECT_THROW(changedShare(gray, colour, 4, 9), std::invalid_argument);
}

TEST(BackgroundModel, RefusesMismatchedFrames) {
  BackgroundLearner learner;
  EXPECT_TRUE(learner.add(cv::Mat(10, 10, CV_8UC3, cv::Scalar::all(7))));
  EXPECT_FALSE(learner.add(cv::Mat(10, 11, CV_8UC3)));
  EXPECT_FALSE(learner.add(cv::Mat(10, 10, CV_8UC1)));
  EXPECT_EQ(learner.frames(), 1);
}

// A scratch directory per test, removed after it.
class BackgroundFile : public testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() /
           ("mocap_bg_file_" + std::to_string(::getpid()) + "_" +
            testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::remove_all(dir_);
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  std::string file(const std::string& name) const { return (dir_ / name).string(); }
  std::string write(const std::string& name, const std::string& bytes) const {
    std::ofstream(file(name), std::ios::binary) << bytes;
    return file(name);
  }
  static std::string read(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  }
  // loadBackground's message for `path`; "(loaded)" if it loads.
  static std::string loadError(const std::string& path) {
    try {
      loadBackground(path);
    } catch (const std::runtime_error& e) {
      return e.what();
    }
    return "(loaded)";
  }

  std::filesystem::path dir_;
};

// What saveBackground wrote until it wrote the files itself: cv::FileStorage, matrices in base64.
void writeWithFileStorage(const std::string& path, const BackgroundModel& model) {
  cv::FileStorage fs(path, cv::FileStorage::WRITE | cv::FileStorage::BASE64);
  fs << "image_width" << model.mean.cols << "image_height" << model.mean.rows;
  fs << "channels" << model.channels();
  fs << "mean" << model.mean << "stddev" << model.stddev;
}

void expectSameModel(const BackgroundModel& expected, const BackgroundModel& actual) {
  ASSERT_EQ(actual.mean.type(), expected.mean.type());
  ASSERT_EQ(actual.stddev.type(), expected.stddev.type());
  ASSERT_EQ(actual.size(), expected.size());
  EXPECT_EQ(cv::norm(expected.mean, actual.mean, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(expected.stddev, actual.stddev, cv::NORM_INF), 0.0);
}

// Gray and BGR, plain and gzip-compressed, one pixel or a camera's frame, and a model cut from a
// larger one (its rows not contiguous): every value reads back as it was.
TEST_F(BackgroundFile, SavedModelsReadBackExactly) {
  for (int type : {CV_8UC1, CV_8UC3}) {
    const BackgroundModel learned = learnBackground(noisyFrames(type, 10, 2.0));
    const cv::Rect inside(3, 2, 17, 11);
    const BackgroundModel pixel{learned.mean(cv::Rect(0, 0, 1, 1)).clone(),
                                learned.stddev(cv::Rect(0, 0, 1, 1)).clone()};
    const BackgroundModel cut{learned.mean(inside), learned.stddev(inside)};
    for (const BackgroundModel& model : {learned, pixel, cut}) {
      for (const std::string name : {"model.yml", "model.yml.gz"}) {
        saveBackground(file(name), model);
        expectSameModel(model, loadBackground(file(name)));
      }
    }
  }
  EXPECT_EQ(read(file("model.yml.gz")).substr(0, 2), "\x1f\x8b");
  EXPECT_EQ(read(file("model.yml")).substr(0, 10), "%YAML:1.0\n");
}

// Files already on disk were written by cv::FileStorage: they load with the same values, and new
// files are the same text, byte for byte.
TEST_F(BackgroundFile, ReadsWhatFileStorageWroteAndWritesTheSameText) {
  for (int type : {CV_8UC1, CV_8UC3}) {
    const BackgroundModel model = learnBackground(noisyFrames(type, 10, 2.0));
    for (const std::string name : {"opencv.yml", "opencv.yml.gz"}) {
      writeWithFileStorage(file(name), model);
      expectSameModel(model, loadBackground(file(name)));
    }
    saveBackground(file("ours.yml"), model);
    EXPECT_EQ(read(file("ours.yml")), read(file("opencv.yml"))) << type;
  }
}

// A model that is not a capture's: nothing is written, the error names the file and the value.
TEST_F(BackgroundFile, SaveRefusesValuesNoCaptureHas) {
  BackgroundModel model = learnBackground(noisyFrames(CV_8UC3, 3, 2.0));
  model.mean.at<cv::Vec3f>(2, 5)[1] = std::numeric_limits<float>::quiet_NaN();
  try {
    saveBackground(file("model.yml"), model);
    FAIL() << "saved a mean holding NaN";
  } catch (const std::runtime_error& e) {
    EXPECT_STREQ(e.what(),
                 (file("model.yml") + ": mean: not a finite number at row 2, column 5").c_str());
  }
  EXPECT_TRUE(std::filesystem::is_empty(dir_));
}

// A FileStorage file of a 4x3 gray model; `edit` replaces the first `from` in its text by `to`.
struct Edit {
  std::string from, to, error;
  int line = 0;  // the line the error names, if it names one
};

TEST_F(BackgroundFile, EveryRefusalNamesTheFileAndTheField) {
  const BackgroundModel model{cv::Mat(3, 4, CV_32FC1, cv::Scalar(100)),
                              cv::Mat(3, 4, CV_32FC1, cv::Scalar(2))};
  writeWithFileStorage(file("good.yml"), model);
  const std::string good = read(file("good.yml"));
  // The first data line of mean, and the base64 header alone ("1f" and spaces, 24 bytes).
  const std::string first_data = good.substr(good.find("      MWYg"), 71);
  const Edit edits[] = {
      {"%YAML:1.0", "%YAML:2.0", ": not an OpenCV FileStorage YAML file", 1},
      {"---", "--- x", ": expected '---' after the %YAML line", 2},
      {"image_width: 4", "image_width: four", ": image_width: 'four' is not a positive integer", 3},
      {"image_width: 4", "image_width: 0", ": image_width: must be positive, got 0", 3},
      {"image_height: 3", "image_height: 20000",
       ": image_height: 20000 is more than the 16384 a background model may have", 4},
      {"image_width: 4\nimage_height: 3", "image_width: 16384\nimage_height: 16384",
       ": mean: image_width x image_height, 16384x16384, is more than the 33554432 pixels", 6},
      {"4\nimage_height: 3\nchannels: 1\nmean: !!opencv-matrix\n   rows: 3\n   cols: 4",
       "4000\nimage_height: 3000\nchannels: 1\nmean: !!opencv-matrix\n   rows: 3000\n   cols: 4000",
       ": mean.data: 4000x3000x1 floats take 64000032 base64 characters, more than the file's", 10},
      {"image_width: 4", "image_width: 4\nimage_width: 4", ": image_width: given twice", 4},
      {"channels: 1", "channels: 2", ": channels: expected 1 or 3, got 2", 5},
      {"channels: 1\n", "", ": channels: missing before mean", 5},
      {"mean: !!opencv-matrix", "mean: [ 1, 2 ]", ": mean: expected an OpenCV matrix", 6},
      {"   rows: 3", "   rows: 5", ": mean.rows: 5, but image_height is 3", 7},
      {"   cols: 4", "   cols: 40", ": mean.cols: 40, but image_width is 4", 8},
      {"   dt: f", "   dt: d", ": mean.dt: 'd', expected f (float, 1 channel(s)", 9},
      {"   data: !!binary |", "   data: [ 1., 2. ]", ": mean.data: expected base64", 10},
      {"   rows: 3\n", "", ": mean.data: comes before rows, cols and dt", 9},
      {first_data, "", ": mean.data: holds 24 bytes where the size and type need 72"},
      {"      MWYg", "      M*Yg", ": mean.data: '*' in the base64 data", 11},
      {"      MWYg", "      MmYg", ": mean.data: its header says '2f' where dt says '1f'"},
      {"stddev: !!opencv-matrix", "stdev: !!opencv-matrix", ": unexpected field 'stdev'", 13},
      {"stddev: !!opencv-matrix", "stddev: !!opencv-matrix\n   step: 4",
       ": unexpected field 'stddev.step'", 14},
      {"stddev", "mean", ": mean: given twice", 13},
      {"image_width: 4", "image_width: 4\n" + std::string(2000, 'x'),
       ": longer than 1024 characters", 4},
      {"channels: 1", "channels 1", ": expected a field of the model", 5},
  };
  for (const Edit& edit : edits) {
    std::string text = good;
    ASSERT_NE(text.find(edit.from), std::string::npos) << edit.from;
    text.replace(text.find(edit.from), edit.from.size(), edit.to);
    const std::string path = write("edited.yml", text);
    const std::string error = loadError(path);
    EXPECT_THAT(error, HasSubstr(path + edit.error)) << edit.from << " -> " << edit.to;
    if (edit.line > 0) {
      EXPECT_THAT(error, EndsWith(" (line " + std::to_string(edit.line) + ")")) << edit.from;
    }
  }
  EXPECT_THAT(loadError(write("empty.yml", "")), HasSubstr("empty.yml: empty file"));
  EXPECT_THAT(loadError(write("model.xml", "<?xml version=\"1.0\"?>\n")),
              HasSubstr("model.xml: OpenCV FileStorage XML or JSON is not read"));
  EXPECT_THAT(loadError(file("absent.yml")),
              HasSubstr("absent.yml: cannot open background model: No such file or directory"));
  EXPECT_THAT(loadError(dir_.string()), HasSubstr(dir_.string() + ": not a regular file"));
}

// Values a capture cannot have, in files FileStorage wrote: refused, naming the matrix and pixel.
TEST_F(BackgroundFile, RefusesValuesNoCaptureHas) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  const struct {
    bool in_mean;
    float value;
    std::string error;
  } cases[] = {{true, nan, ": mean: not a finite number at row 1, column 2"},
               {true, -inf, ": mean: not a finite number at row 1, column 2"},
               {false, inf, ": stddev: not a finite number at row 1, column 2"},
               {false, -0.5f, ": stddev: negative at row 1, column 2"}};
  for (const auto& c : cases) {
    BackgroundModel model{cv::Mat(3, 4, CV_32FC3, cv::Scalar::all(100)),
                          cv::Mat(3, 4, CV_32FC3, cv::Scalar::all(2))};
    (c.in_mean ? model.mean : model.stddev).at<cv::Vec3f>(1, 2)[2] = c.value;
    const std::string path = file("values.yml");
    writeWithFileStorage(path, model);
    EXPECT_EQ(loadError(path), path + c.error);
  }
}

// A compressed file cut short or corrupted: zlib's reason, naming the file.
TEST_F(BackgroundFile, RefusesBrokenCompression) {
  saveBackground(file("model.yml.gz"), learnBackground(noisyFrames(CV_8UC1, 3, 2.0)));
  const std::string whole = read(file("model.yml.gz"));
  const std::string cut = write("cut.yml.gz", whole.substr(0, whole.size() / 2));
  EXPECT_THAT(loadError(cut), HasSubstr(cut + ": cannot read background model: "));
  std::string flipped = whole;
  flipped[flipped.size() - 6] ^= 0x55;  // the CRC at the end
  const std::string corrupt = write("corrupt.yml.gz", flipped);
  EXPECT_THAT(loadError(corrupt), HasSubstr(corrupt + ": cannot read background model: "));
}

TEST(BackgroundModel, SaveReplacesTheFileWholeAndLeavesNoTemporary) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("mocap_bg_atomic_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const std::string path = (dir / "camera.background.yml").string();
  saveBackground(path, learnBackground(noisyFrames(CV_8UC1, 3, 2.0)));
  const BackgroundModel colour = learnBackground(noisyFrames(CV_8UC3, 3, 2.0));
  saveBackground(path, colour);
  EXPECT_EQ(loadBackground(path).channels(), 3);
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir),
                          std::filesystem::directory_iterator()),
            1);
  // A directory that does not exist: refused, naming the file, and nothing is left behind.
  const std::string nowhere = (dir / "missing" / "camera.background.yml").string();
  try {
    saveBackground(nowhere, colour);
    FAIL() << "expected an error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(nowhere + ": background model not saved"),
              std::string::npos)
        << e.what();
  }
  EXPECT_FALSE(std::filesystem::exists(dir / "missing"));
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace mocap
