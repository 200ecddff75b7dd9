// A fixed pool of worker threads for the per-layer parallel evaluation of candidates. The calling
// thread works too; parallelFor returns when every index is done (the layer barrier).
#pragma once

#include <atomic>
#include <condition_variable>
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
  void drain(int worker);

  std::vector<std::thread> workers_;
  std::mutex mutex_;
  std::condition_variable wake_;
  std::condition_variable done_;
  const std::function<void(int, int)>* job_ = nullptr;
  int count_ = 0;
  std::atomic<int> next_{0};
  std::atomic<int> busy_{0};             // workers still inside the current job
  std::atomic<unsigned> generation_{0};  // bumped per job so workers join each job once
  std::atomic<bool> stopping_{false};
};

}  // namespace mocap
