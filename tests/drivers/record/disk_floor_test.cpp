// The recorder on a filling disk: the free-space floor refuses a start and stops a recording, a
// failing write (EFBIG from a file size limit, ENOSPC on a small tmpfs) stops it too, and every
// time the session stays readable to its last committed frame set.
#include <signal.h>
#include <sys/mount.h>
#include <sys/resource.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <thread>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "drivers/record/recorder.h"
#include "drivers/record/session_reader.h"
#include "drivers/record/recording_test_scene.h"

namespace mocap {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

constexpr uint64_t kMegabyte = 1'000'000;

class DiskFloorTest : public ::testing::Test {
 protected:
  void SetUp() override { root_ = test::freshRoot("disk_floor"); }
  void TearDown() override {
    if (mounted_) ::umount2(root_.c_str(), MNT_DETACH);
    fs::remove_all(root_);
  }

  // Mounts a tmpfs of `megabytes` on the root; false (the test skips) where mounting is not
  // permitted, as in most CI containers.
  bool mountSmallFileSystem(int megabytes) {
    const std::string size = "size=" + std::to_string(megabytes) + "m";
    if (::mount("tmpfs", root_.c_str(), "tmpfs", 0, size.c_str()) != 0) {
      reason_ = std::string("mounting a tmpfs is not permitted here (") + std::strerror(errno) +
                "); the floor and write failures are tested without it too";
      return false;
    }
    mounted_ = true;
    return true;
  }

  // Writes sets of the scene until the recorder stops on its own (or `limit` sets).
  static void recordUntilStopped(Recorder& recorder, std::size_t limit) {
    for (std::size_t n = 0; n < limit && !recorder.stopped(); ++n) {
      recorder.write(test::sceneSet(n));
      waitForWriter(recorder, n + 1);
    }
  }

  // Waits until the writer has taken `sets` sets (written, failed or discarded).
  static void waitForWriter(const Recorder& recorder, uint64_t sets) {
    const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(10);
    while (std::chrono::steady_clock::now() < give_up) {
      const RecorderStats stats = recorder.stats();
      if (stats.sets_written + stats.sets_discarded + stats.write_errors >= sets) return;
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
    ADD_FAILURE() << "the writer did not take set " << sets;
  }

  // The session opens, holding exactly the sets the recorder says it wrote.
  static void expectReadableToTheLastCommittedSet(const Recorder& recorder) {
    Expected<std::unique_ptr<SessionReader>> reader =
        SessionReader::open(recorder.sessionPath(), {.decode_all = true});
    ASSERT_TRUE(reader.ok()) << reader.error();
    EXPECT_EQ(reader.value()->sets().size(), recorder.stats().sets_written);
    for (std::size_t s = 0; s < reader.value()->sets().size(); ++s)
      for (int c = 0; c < 2; ++c) ASSERT_TRUE(reader.value()->readFrame(s, c).ok());
  }

  fs::path root_;
  bool mounted_ = false;
  std::string reason_;
};

// A free-space probe that reports `plenty` for its first `calls` calls, then `scarce`.
std::function<Expected<uint64_t>(const fs::path&)> freeSpaceDropping(int calls, uint64_t plenty,
                                                                     uint64_t scarce) {
  auto count = std::make_shared<int>(0);
  return [=](const fs::path&) -> Expected<uint64_t> { return ++*count > calls ? scarce : plenty; };
}

TEST_F(DiskFloorTest, RefusesToStartUnderTheFloor) {
  RecorderOptions options;
  options.min_free_bytes = 100 * kMegabyte;
  options.free_space = freeSpaceDropping(0, 0, 40 * kMegabyte);
  Recorder recorder(root_, options);
  const Status opened = recorder.open("session", test::sceneRig(), test::sceneCameras());
  ASSERT_FALSE(opened.ok());
  EXPECT_THAT(opened.message(), HasSubstr("40 MB free"));
  EXPECT_THAT(opened.message(), HasSubstr("under the floor of 100 MB (recording.min_free_mb)"));
  EXPECT_FALSE(fs::exists(root_ / "session"));
}

TEST_F(DiskFloorTest, TheRealFreeSpaceIsMeasured) {
  const Expected<uint64_t> free = freeBytesAt(root_);
  ASSERT_TRUE(free.ok()) << free.error();
  RecorderOptions options;
  options.min_free_bytes = free.value() + 1'000'000'000'000;  // a terabyte more than there is
  Recorder recorder(root_, options);
  EXPECT_THAT(recorder.open("session", test::sceneRig(), test::sceneCameras()).message(),
              HasSubstr("under the floor"));
}

TEST_F(DiskFloorTest, StopsAtTheFloorKeepingEveryCommittedSet) {
  RecorderOptions options;
  options.min_free_bytes = 100 * kMegabyte;
  // The open and the first 3 sets see 1 GB; the 4th set finds the disk at the floor.
  options.free_space = freeSpaceDropping(4, 1000 * kMegabyte, 99 * kMegabyte);
  Recorder recorder(root_, options);
  ASSERT_TRUE(recorder.open("session", test::sceneRig(), test::sceneCameras()).ok());
  recordUntilStopped(recorder, 10);
  ASSERT_TRUE(recorder.stopped());
  recorder.write(test::sceneSet(5));  // ignored once stopped
  EXPECT_TRUE(recorder.close().ok());  // a stop at the floor is no I/O error
  const RecorderStats stats = recorder.stats();
  EXPECT_EQ(stats.sets_written, 3u);
  EXPECT_EQ(stats.sets_discarded, 1u);
  EXPECT_EQ(stats.write_errors, 0u);
  EXPECT_THAT(stats.stopped, HasSubstr("99 MB free"));
  expectReadableToTheLastCommittedSet(recorder);
}

// EFBIG from RLIMIT_FSIZE stands for any failing write without filling a disk: the image files
// exceed the limit, the index files do not.
TEST_F(DiskFloorTest, AFailedWriteStopsTheRecordingCleanly) {
  Recorder recorder(root_);
  ASSERT_TRUE(recorder.open("session", test::sceneRig(), test::sceneCameras()).ok());
  for (std::size_t n = 0; n < 2; ++n) {
    recorder.write(test::sceneSet(n));
    waitForWriter(recorder, n + 1);
  }
  rlimit saved{};
  ASSERT_EQ(::getrlimit(RLIMIT_FSIZE, &saved), 0);
  const auto previous_handler = ::signal(SIGXFSZ, SIG_IGN);
  rlimit limited = saved;
  limited.rlim_cur = 4096;
  ASSERT_EQ(::setrlimit(RLIMIT_FSIZE, &limited), 0);
  recorder.write(test::sceneSet(2));
  waitForWriter(recorder, 3);
  ::setrlimit(RLIMIT_FSIZE, &saved);
  ::signal(SIGXFSZ, previous_handler);

  EXPECT_TRUE(recorder.stopped());
  const Status closed = recorder.close();
  EXPECT_FALSE(closed.ok());
  EXPECT_THAT(closed.message(), HasSubstr("File too large"));
  EXPECT_THAT(recorder.stats().stopped, HasSubstr("cannot write"));
  EXPECT_EQ(recorder.stats().sets_written, 2u);
  expectReadableToTheLastCommittedSet(recorder);
}

TEST_F(DiskFloorTest, ANearlyFullFileSystemStopsAtTheFloor) {
  if (!mountSmallFileSystem(8)) GTEST_SKIP() << reason_;
  RecorderOptions options;
  options.min_free_bytes = 2 * kMegabyte;
  Recorder recorder(root_, options);
  ASSERT_TRUE(recorder.open("session", test::sceneRig(), test::sceneCameras()).ok());
  recordUntilStopped(recorder, 1000);
  ASSERT_TRUE(recorder.stopped());
  EXPECT_TRUE(recorder.close().ok());
  EXPECT_THAT(recorder.stats().stopped, HasSubstr("under the floor of 2 MB"));
  EXPECT_GT(recorder.stats().sets_written, 10u);
  expectReadableToTheLastCommittedSet(recorder);
}

TEST_F(DiskFloorTest, AFullFileSystemStopsTheRecordingCleanly) {
  if (!mountSmallFileSystem(4)) GTEST_SKIP() << reason_;
  Recorder recorder(root_);  // no floor: the writes themselves fail
  ASSERT_TRUE(recorder.open("session", test::sceneRig(), test::sceneCameras()).ok());
  recordUntilStopped(recorder, 1000);
  ASSERT_TRUE(recorder.stopped());
  const Status closed = recorder.close();
  EXPECT_FALSE(closed.ok());
  EXPECT_THAT(closed.message(), HasSubstr("No space left on device"));
  EXPECT_GT(recorder.stats().sets_written, 10u);
  expectReadableToTheLastCommittedSet(recorder);
}

}  // namespace
}  // namespace mocap
