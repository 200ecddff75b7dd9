// Worker pool: one job at a time, indices handed out by an atomic counter. A layer of the filter
// lasts tens of microseconds, about as long as a sleep/wake round trip, so both sides spin briefly
// before they block.
#include "tracker/filters/worker_pool.h"

namespace mocap {
namespace {

// A bound on the spin, not a time: 20,000 pauses took 300-370 us on the Xeon VM the benchmarks
// in docs/ ran on (PAUSE costs about 140 cycles from Skylake on), far longer than on older cores.
constexpr int kSpinIterations = 20000;

inline void cpuRelax() {
#if defined(__x86_64__) || defined(__i386__)
  __builtin_ia32_pause();
#else
  std::this_thread::yield();
#endif
}

}  // namespace

WorkerPool::WorkerPool(int threads) {
  if (threads <= 0) threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  for (int w = 1; w < threads; ++w) workers_.emplace_back([this, w] { workerLoop(w); });
}

WorkerPool::~WorkerPool() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_.store(true);
  }
  wake_.notify_all();
  for (std::thread& t : workers_) t.join();
}

void WorkerPool::drain(int worker) {
  for (int i = next_.fetch_add(1, std::memory_order_relaxed); i < count_;
       i = next_.fetch_add(1, std::memory_order_relaxed)) {
    (*job_)(i, worker);
  }
}

void WorkerPool::parallelFor(int count, const std::function<void(int, int)>& fn) {
  if (count <= 0) return;
  if (workers_.empty() || count == 1) {
    for (int i = 0; i < count; ++i) fn(i, 0);
    return;
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    job_ = &fn;
    count_ = count;
    next_.store(0, std::memory_order_relaxed);
    busy_.store(static_cast<int>(workers_.size()), std::memory_order_relaxed);
    generation_.fetch_add(1, std::memory_order_release);
  }
  wake_.notify_all();
  drain(0);
  for (int spin = 0; spin < kSpinIterations && busy_.load(std::memory_order_acquire) != 0; ++spin)
    cpuRelax();
  if (busy_.load(std::memory_order_acquire) != 0) {
    std::unique_lock<std::mutex> lock(mutex_);
    done_.wait(lock, [this] { return busy_.load(std::memory_order_acquire) == 0; });
  }
  job_ = nullptr;
}

void WorkerPool::workerLoop(int worker) {
  unsigned seen = 0;
  while (true) {
    auto idle = [&] {
      return !stopping_.load(std::memory_order_acquire) &&
             generation_.load(std::memory_order_acquire) == seen;
    };
    for (int spin = 0; spin < kSpinIterations && idle(); ++spin) cpuRelax();
    if (idle()) {
      std::unique_lock<std::mutex> lock(mutex_);
      wake_.wait(lock, [&] { return !idle(); });
    }
    if (stopping_.load(std::memory_order_acquire)) return;
    seen = generation_.load(std::memory_order_acquire);
    drain(worker);
    if (busy_.fetch_sub(1, std::memory_order_acq_rel) == 1) {
      std::lock_guard<std::mutex> lock(mutex_);
      done_.notify_one();
    }
  }
}

}  // namespace mocap
