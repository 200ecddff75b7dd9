// Worker pool: one job at a time, indices handed out by an atomic counter. A layer of the filter
// lasts tens of microseconds, about as long as a sleep/wake round trip, so both sides spin briefly
// before they block.
#include "tracker/filters/worker_pool.h"

namespace mocap {
namespace {

constexpr uint64_t kClosed = uint64_t{1} << 31;
constexpr uint64_t kJoinedMask = kClosed - 1;
inline uint32_t generationOf(uint64_t ticket) { return static_cast<uint32_t>(ticket >> 32); }

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
    finished_.store(0, std::memory_order_relaxed);
    const uint32_t generation = generationOf(ticket_.load(std::memory_order_relaxed)) + 1;
    ticket_.store(static_cast<uint64_t>(generation) << 32, std::memory_order_release);
  }
  wake_.notify_all();
  drain(0);
  // Every index is taken: no worker may join now, and only those that did are waited for.
  const int joined =
      static_cast<int>(ticket_.fetch_or(kClosed, std::memory_order_acq_rel) & kJoinedMask);
  for (int spin = 0;
       spin < kSpinIterations && finished_.load(std::memory_order_acquire) != joined; ++spin)
    cpuRelax();
  if (finished_.load(std::memory_order_acquire) != joined) {
    std::unique_lock<std::mutex> lock(mutex_);
    done_.wait(lock, [&] { return finished_.load(std::memory_order_acquire) == joined; });
  }
  job_ = nullptr;
}

// Joins the job of `ticket`'s generation if it is still open; false if it was closed first.
bool WorkerPool::join(uint64_t ticket) {
  const uint32_t generation = generationOf(ticket);
  while (!(ticket & kClosed)) {
    if (ticket_.compare_exchange_weak(ticket, ticket + 1, std::memory_order_acq_rel,
                                      std::memory_order_acquire))
      return true;
    if (generationOf(ticket) != generation) return false;
  }
  return false;
}

void WorkerPool::workerLoop(int worker) {
  uint32_t seen = 0;
  while (true) {
    auto idle = [&] {
      return !stopping_.load(std::memory_order_acquire) &&
             generationOf(ticket_.load(std::memory_order_acquire)) == seen;
    };
    for (int spin = 0; spin < kSpinIterations && idle(); ++spin) cpuRelax();
    if (idle()) {
      std::unique_lock<std::mutex> lock(mutex_);
      wake_.wait(lock, [&] { return !idle(); });
    }
    if (stopping_.load(std::memory_order_acquire)) return;
    const uint64_t ticket = ticket_.load(std::memory_order_acquire);
    seen = generationOf(ticket);
    if (!join(ticket)) continue;  // the caller drained it alone
    drain(worker);
    finished_.fetch_add(1, std::memory_order_acq_rel);
    std::lock_guard<std::mutex> lock(mutex_);
    done_.notify_one();
  }
}

}  // namespace mocap
