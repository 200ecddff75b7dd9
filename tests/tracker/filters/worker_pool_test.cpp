// The worker pool runs every index exactly once per job, on worker ids within range, returns only
// when the workers that took part are done, and keeps both with more threads than cores.
#include "tracker/filters/worker_pool.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <thread>
#include <vector>

namespace mocap {
namespace {

TEST(WorkerPool, EveryIndexRunsExactlyOncePerJob) {
  for (int threads : {1, 2, 4}) {
    WorkerPool pool(threads);
    EXPECT_EQ(pool.size(), threads);
    for (int job = 0; job < 200; ++job) {
      const int count = 1 + job % 37;
      std::vector<std::atomic<int>> hits(count);
      std::atomic<int> bad_worker{0};
      pool.parallelFor(count, [&](int i, int worker) {
        hits[i].fetch_add(1);
        if (worker < 0 || worker >= threads) bad_worker.fetch_add(1);
      });
      for (int i = 0; i < count; ++i) ASSERT_EQ(hits[i].load(), 1) << "threads " << threads;
      ASSERT_EQ(bad_worker.load(), 0);
    }
  }
}

// A worker slow to finish its index is waited for: the caller may not return before it is done.
TEST(WorkerPool, AJobEndsOnlyWhenEveryIndexIsDone) {
  WorkerPool pool(2);
  for (int job = 0; job < 20; ++job) {
    std::vector<std::atomic<bool>> done(8);
    pool.parallelFor(8, [&](int i, int worker) {
      if (worker != 0) std::this_thread::sleep_for(std::chrono::milliseconds(2));
      done[i].store(true);
    });
    for (int i = 0; i < 8; ++i) ASSERT_TRUE(done[i].load()) << "job " << job << " index " << i;
  }
}

// Four threads on fewer cores: workers are often not running when a job starts, so the caller
// drains jobs alone and workers wake into later ones; still every index runs once.
TEST(WorkerPool, ManyShortJobsWithMoreThreadsThanCores) {
  WorkerPool pool(4);
  std::vector<std::atomic<int>> hits(3);
  for (int job = 0; job < 20000; ++job) {
    for (auto& h : hits) h.store(0, std::memory_order_relaxed);
    pool.parallelFor(3, [&](int i, int) { hits[i].fetch_add(1); });
    for (int i = 0; i < 3; ++i) ASSERT_EQ(hits[i].load(), 1) << "job " << job;
  }
}

TEST(WorkerPool, ZeroCountIsANoOp) {
  WorkerPool pool(2);
  bool called = false;
  pool.parallelFor(0, [&](int, int) { called = true; });
  EXPECT_FALSE(called);
}

}  // namespace
}  // namespace mocap
