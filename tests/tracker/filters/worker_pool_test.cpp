// The worker pool runs every index exactly once per job, on worker ids within range.
#include "tracker/filters/worker_pool.h"

#include <gtest/gtest.h>

#include <atomic>
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

TEST(WorkerPool, ZeroCountIsANoOp) {
  WorkerPool pool(2);
  bool called = false;
  pool.parallelFor(0, [&](int, int) { called = true; });
  EXPECT_FALSE(called);
}

}  // namespace
}  // namespace mocap
