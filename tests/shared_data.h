// The shared data folder's motion files, for the tests that need them. Such a test fails when the
// folder is missing, saying where it should be: a test that skipped would pass without running.
#pragma once

#include <filesystem>
#include <string>

#include <gtest/gtest.h>

namespace mocap::testing_support {

// data/motion/ of the shared folder: ../shared beside the checkout, or -DMOCAP_SHARED_DIR=DIR.
inline const std::string kSharedMotionDir = std::string(MOCAP_SHARED_DIR) + "/data/motion/";

inline std::string missingSharedData(const std::string& path) {
  return path + " not found: the shared data folder must sit beside the checkout as ../shared " +
         "(with data/motion/), or be named when configuring: cmake -DMOCAP_SHARED_DIR=DIR";
}

}  // namespace mocap::testing_support

// Fails the calling test, with where the data should be, unless the file `path` exists.
#define REQUIRE_SHARED_FILE(path) \
  ASSERT_TRUE(std::filesystem::exists(path)) << ::mocap::testing_support::missingSharedData(path)
