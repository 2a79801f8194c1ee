#pragma once
// A fixed pool of worker threads; no global instance (callers own pools).
// parallel_for hands out indices dynamically; callers that need determinism write
// results into per-index slots and combine them in index order afterwards.
#include <algorithm>
#include <condition_variable>
#include <cstddef>
#include <functional>
#include <initializer_list>
#include <mutex>
#include <thread>
#include <utility>
#include <vector>

namespace vgeo {

class ThreadPool {
 public:
  // threads == 0 means std::thread::hardware_concurrency().
  explicit ThreadPool(unsigned threads = 0);
  ~ThreadPool();
  ThreadPool(const ThreadPool&) = delete;
  ThreadPool& operator=(const ThreadPool&) = delete;

  unsigned size() const { return unsigned(workers_.size()) + 1; }  // + the calling thread

  // Runs fn(i) for i in [0, n); the calling thread participates. Rethrows the first
  // exception thrown by fn (after all indices were handed out). One index runs on the calling
  // thread alone; a worker that wakes after the calling thread has handed out every index is
  // not waited for (it finds nothing to run).
  void parallel_for(size_t n, const std::function<void(size_t)>& fn);

  // Runs fn(worker_index) once on every thread of the pool (persistent-thread style).
  void run_on_all(const std::function<void(unsigned)>& fn);

 private:
  // Runs fn(0) here and fn(worker_index) on the workers; returns once every worker that took the
  // job has finished it. every_worker: wait until each worker has taken it; otherwise workers that
  // have not taken it when fn(0) returns skip it.
  void run(const std::function<void(unsigned)>& fn, bool every_worker);
  void worker_loop(unsigned index);
  std::vector<std::thread> workers_;
  std::mutex mutex_;
  std::condition_variable wake_, done_;
  const std::function<void(unsigned)>* job_ = nullptr;  // null: no job to take
  unsigned long generation_ = 0;
  unsigned taken_ = 0;    // workers that took the current job
  unsigned running_ = 0;  // of those, the ones still running it
  bool stop_ = false;
};

// Runs fn(begin, end) over [0, n) in chunks of `chunk` items: on the pool when there is one and
// more than one chunk, else in order on the calling thread. Chunks run in any order.
template <class Fn>
void for_chunks(ThreadPool* pool, size_t n, size_t chunk, Fn&& fn) {
  const size_t chunks = (n + chunk - 1) / chunk;
  auto body = [&](size_t i) { fn(i * chunk, std::min(n, (i + 1) * chunk)); };
  if (pool && chunks > 1)
    pool->parallel_for(chunks, body);
  else
    for (size_t i = 0; i < chunks; ++i) body(i);
}

unsigned default_thread_count();

// Faults in and writes once the pages of fresh allocations (reserved, not yet sized: `ranges`
// of (data, bytes)) in equal chunks on every pool thread, so a large array's first touch is not
// one thread's; the zero fill of the resize that follows then runs on pages that cost nothing
// more (thread_pool.cpp).
void prefault_parallel(std::initializer_list<std::pair<void*, size_t>> ranges, ThreadPool& pool);

}  // namespace vgeo
