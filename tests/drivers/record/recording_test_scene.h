// A small scene for the recorder's tests: two cameras see a bright box cross a dim, noisy room,
// with the room's background model, so the recorder's silhouettes have something to find.
#pragma once

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "drivers/record/recorder.h"

namespace mocap::test {

constexpr int kSceneWidth = 160;
constexpr int kSceneHeight = 120;
constexpr int kRoomLevel = 60;
constexpr int kRoomNoise = 3;

// A fresh directory for this test, named after it.
inline std::filesystem::path freshRoot(const std::string& suite) {
  const std::filesystem::path root =
      std::filesystem::temp_directory_path() /
      ("mocap_" + suite + "_" + std::to_string(::getpid()) + "_" +
       ::testing::UnitTest::GetInstance()->current_test_info()->name());
  std::filesystem::remove_all(root);
  std::filesystem::create_directories(root);
  return root;
}

inline std::vector<SessionCamera> sceneCameras() {
  return {{"left", kSceneWidth, kSceneHeight, kPixelBgr, 25.0},
          {"right", kSceneWidth, kSceneHeight, kPixelBgr, 25.0}};
}

inline Rig sceneRig() {
  Rig rig;
  for (int i = 0; i < 2; ++i)
    rig.push_back(CameraModel::lookAt("cam" + std::to_string(i), Eigen::Vector3d(i, -4, 1.5),
                                      Eigen::Vector3d(0, 0, 1), Eigen::Vector3d::UnitZ(),
                                      kSceneWidth, kSceneHeight, 80));
  return rig;
}

inline std::shared_ptr<const BackgroundModel> sceneBackground() {
  BackgroundModel model;
  model.mean = cv::Mat(kSceneHeight, kSceneWidth, CV_32FC3, cv::Scalar::all(kRoomLevel));
  model.stddev = cv::Mat(kSceneHeight, kSceneWidth, CV_32FC3, cv::Scalar::all(kRoomNoise));
  return std::make_shared<const BackgroundModel>(std::move(model));
}

// The box camera `camera` sees in set `n` (255 inside).
inline cv::Mat sceneSubject(std::size_t n, int camera) {
  cv::Mat mask = cv::Mat::zeros(kSceneHeight, kSceneWidth, CV_8UC1);
  mask(cv::Rect(20 + 8 * static_cast<int>(n % 12) + 10 * camera, 30, 30, 60)).setTo(255);
  return mask;
}

// Set `n`: both cameras, frame sequence n, the box on the noisy room.
inline FrameSet sceneSet(std::size_t n) {
  FrameSet set;
  set.sequence = n;
  set.timestamp_ns = 1'000'000'000 + static_cast<int64_t>(n) * 40'000'000;
  set.frames.resize(2);
  for (int c = 0; c < 2; ++c) {
    Frame frame;
    frame.camera = c;
    frame.sequence = n;
    frame.timestamp_ns = set.timestamp_ns + c;
    frame.image.create(kSceneHeight, kSceneWidth, CV_8UC3);
    cv::RNG rng(static_cast<uint64_t>(n * 2 + c + 1));
    rng.fill(frame.image, cv::RNG::NORMAL, kRoomLevel, kRoomNoise);
    frame.image.setTo(cv::Scalar(200, 180, 160), sceneSubject(n, c));
    set.frames[c] = std::move(frame);
  }
  return set;
}

inline double intersectionOverUnion(const cv::Mat& a, const cv::Mat& b) {
  const double both = cv::countNonZero(a & b), either = cv::countNonZero(a | b);
  return either == 0 ? 1.0 : both / either;
}

// Replaces the file's text by `edit`'s of it.
inline void rewrite(const std::filesystem::path& path,
                    const std::function<std::string(std::string)>& edit) {
  std::ifstream in(path);
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  in.close();
  std::ofstream(path, std::ios::trunc) << edit(std::move(text));
}

// Makes a lossless session of two cameras one recorded before format 2: no `images` key, index
// lines without a silhouette column.
inline void downgradeToFormatOne(const std::filesystem::path& session) {
  rewrite(session / kManifestFile, [](std::string text) {
    text.replace(text.find("format_version: 2"), 17, "format_version: 1");
    text.erase(text.find("images: lossless\n"), 17);
    return text;
  });
  for (int c = 0; c < 2; ++c)
    rewrite(session / cameraDirectoryName(c) / kIndexFile, [](const std::string& text) {
      std::istringstream lines(text);
      std::string v1, line;
      while (std::getline(lines, line)) v1 += line.substr(0, line.rfind(',')) + "\n";
      return v1;
    });
}

}  // namespace mocap::test
