// A fixed pool of worker threads for the per-layer parallel evaluation of candidates. The calling
// thread works too; parallelFor returns when every index is done (the layer barrier).
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

namespace mocap {

class WorkerPool {
 public:
  // `threads` counts the caller: 1 runs everything inline. 0 means the hardware thread count.
  explicit WorkerPool(int threads);
  ~WorkerPool();
  WorkerPool(const WorkerPool&) = delete;
  WorkerPool& operator=(const WorkerPool&) = delete;

  int size() const { return static_cast<int>(workers_.size()) + 1; }
  // Calls fn(index, worker) for index in [0, count), worker in [0, size()) naming the thread so it
  // can use its own scratch. Not reentrant; call from one thread at a time.
  void parallelFor(int count, const std::function<void(int index, int worker)>& fn);

 private:
  void workerLoop(int worker);
  bool join(uint64_t ticket);
  void drain(int worker);

  std::vector<std::thread> workers_;
  std::mutex mutex_;
  std::condition_variable wake_;
  std::condition_variable done_;
  const std::function<void(int, int)>* job_ = nullptr;
  int count_ = 0;
  std::atomic<int> next_{0};
  // The current job's ticket: its generation (high 32 bits, bumped per job), whether it is closed
  // to workers (kClosed) and how many joined it (the low bits). A worker joins while the job is
  // open; the caller closes it once it has drained the indices itself and waits only for the
  // workers that joined, so a worker the scheduler has not run (another process on its core) does
  // not hold up the layer barrier.
  std::atomic<uint64_t> ticket_{0};
  std::atomic<int> finished_{0};  // workers of the current job that are done with it
  std::atomic<bool> stopping_{false};
};

}  // namespace mocap
