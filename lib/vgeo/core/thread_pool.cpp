#include "vgeo/core/thread_pool.h"

#include <sys/mman.h>
#include <unistd.h>

#include <atomic>
#include <exception>

#include "vgeo/core/process_memory.h"

namespace vgeo {

unsigned default_thread_count() {
  unsigned n = std::thread::hardware_concurrency();
  return n ? n : 1;
}

ThreadPool::ThreadPool(unsigned threads) {
  if (threads == 0) threads = default_thread_count();
  for (unsigned i = 1; i < threads; ++i) workers_.emplace_back([this, i] { worker_loop(i); });
}

ThreadPool::~ThreadPool() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  for (auto& t : workers_) t.join();
}

void ThreadPool::worker_loop(unsigned index) {
  unsigned long seen = 0;
  for (;;) {
    const std::function<void(unsigned)>* job;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      wake_.wait(lock, [&] { return stop_ || generation_ != seen; });
      if (stop_) return;
      seen = generation_;
      job = job_;
    }
    (*job)(index);
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (--running_ == 0) done_.notify_all();
    }
  }
}

void ThreadPool::run_on_all(const std::function<void(unsigned)>& fn) {
  if (workers_.empty()) {
    fn(0);
    return;
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    job_ = &fn;
    running_ = unsigned(workers_.size());
    ++generation_;
  }
  wake_.notify_all();
  fn(0);
  std::unique_lock<std::mutex> lock(mutex_);
  done_.wait(lock, [&] { return running_ == 0; });
  job_ = nullptr;
}

void ThreadPool::parallel_for(size_t n, const std::function<void(size_t)>& fn) {
  if (n == 0) return;
  std::atomic<size_t> next{0};
  std::exception_ptr first_error;
  std::mutex error_mutex;
  run_on_all([&](unsigned) {
    for (;;) {
      size_t i = next.fetch_add(1, std::memory_order_relaxed);
      if (i >= n) return;
      try {
        fn(i);
      } catch (...) {
        std::lock_guard<std::mutex> lock(error_mutex);
        if (!first_error) first_error = std::current_exception();
      }
    }
  });
  if (first_error) std::rethrow_exception(first_error);
}

// Faults in the pages of fresh allocations in equal chunks on every pool thread
// (MADV_POPULATE_WRITE, Linux ≥ 5.14), backed by huge pages where the kernel gives them
// (advise_huge_pages). On a virtual machine a first touch costs several µs per 4 KiB page, so
// spreading it evenly beats one task per array; where the advice is not supported this does
// nothing and the first writes fault as before.
void prefault_parallel(std::initializer_list<std::pair<void*, size_t>> ranges, ThreadPool& pool) {
#ifdef MADV_POPULATE_WRITE
  // 2 MiB (512 pages, ~1 ms of faults on a VM; one huge page): arrays of a few MiB (the leaf
  // surface's on a 1M-triangle mesh) still split over 2-4 threads; a 10M-triangle DAG's are a
  // few thousand tasks. Chunk ends fall on multiples of it, so a huge page is one task's.
  constexpr uintptr_t kChunk = uintptr_t(2) << 20;
  // Smaller arrays are populated too, in one call each: the call faults its pages in without
  // an exception per page, ~7 us per 4 KiB page against ~13 us for a first touch on this
  // machine's VM (a scratch test of 500 pages), and a system call (~1 us) pays for itself from
  // a few pages. 64 KiB (16 pages) keeps it to arrays where that is sure. A small build's fresh
  // arrays are mostly below 2 MiB: the layout's DAG arrays (bunny00: ~2 MB in four arrays,
  // fresh after the levels' memory went back to the kernel) and the leaf surface's.
  constexpr size_t kMinPrefaultBytes = size_t(64) << 10;
  const size_t page = size_t(sysconf(_SC_PAGESIZE));
  std::vector<std::pair<uintptr_t, size_t>> chunks;
  for (auto [data, bytes] : ranges) {
    if (!data || bytes < kMinPrefaultBytes) continue;  // a few pages: not worth a system call
    advise_huge_pages(data, bytes);
    uintptr_t begin = (reinterpret_cast<uintptr_t>(data) + page - 1) & ~uintptr_t(page - 1);
    uintptr_t end = (reinterpret_cast<uintptr_t>(data) + bytes) & ~uintptr_t(page - 1);
    for (uintptr_t at = begin; at < end;) {
      const uintptr_t next = std::min(end, (at + kChunk) & ~(kChunk - 1));
      chunks.push_back({at, size_t(next - at)});
      at = next;
    }
  }
  pool.parallel_for(chunks.size(), [&](size_t i) {
    (void)madvise(reinterpret_cast<void*>(chunks[i].first), chunks[i].second, MADV_POPULATE_WRITE);
  });
#else
  (void)ranges;
  (void)pool;
#endif
}

}  // namespace vgeo
