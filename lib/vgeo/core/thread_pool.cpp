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
  std::unique_lock<std::mutex> lock(mutex_);
  for (;;) {
    wake_.wait(lock, [&] { return stop_ || generation_ != seen; });
    if (stop_) return;
    seen = generation_;
    const std::function<void(unsigned)>* job = job_;
    if (!job) continue;  // a parallel_for that finished before this thread woke
    ++taken_, ++running_;
    lock.unlock();
    (*job)(index);
    lock.lock();
    if (--running_ == 0) done_.notify_all();
  }
}

void ThreadPool::run(const std::function<void(unsigned)>& fn, bool every_worker) {
  if (workers_.empty()) {
    fn(0);
    return;
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    job_ = &fn;
    taken_ = running_ = 0;
    ++generation_;
  }
  wake_.notify_all();
  fn(0);
  std::unique_lock<std::mutex> lock(mutex_);
  // A parallel_for's workers that are still asleep (or not yet scheduled) when the calling thread
  // has handed out every index have nothing left to do: the job is withdrawn instead of waiting for
  // their wake-up, which costs this thread a sleep and a wake-up of its own (a futex wait and a
  // context switch; on the 2-vCPU virtual machine 11-20 of bunny00's 40 regions at --threads 2
  // woke their worker too late to take an index, docs/acceptance/issue23_t2cpu40.md).
  if (!every_worker) job_ = nullptr;
  done_.wait(lock, [&] { return running_ == 0 && (!every_worker || taken_ == workers_.size()); });
  job_ = nullptr;
}

void ThreadPool::run_on_all(const std::function<void(unsigned)>& fn) { run(fn, true); }

void ThreadPool::parallel_for(size_t n, const std::function<void(size_t)>& fn) {
  if (n == 0) return;
  if (n == 1) {  // nothing to share: no worker woken
    fn(0);
    return;
  }
  std::atomic<size_t> next{0};
  std::exception_ptr first_error;
  std::mutex error_mutex;
  run(
      [&](unsigned) {
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
      },
      false);
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
  // Smaller ranges are left to their first touch. One call populates a page for ~0.7 µs, where
  // a first-touch fault costs ~10 µs on the virtual machine of docs/acceptance/issue23_write.md;
  // the first write of a populated page still costs ~4 µs there (the host's side), so a page
  // costs ~4.5 µs instead of ~10 (a 16 MiB test, 4 KiB pages: docs/acceptance/issue23_scratch38.md).
  // A call pays for itself from a few pages on: 16 of them, small meshes' arrays (bunny00's
  // leaf surface, layout and import arrays: 0.1-1.7 MiB each) included.
  constexpr size_t kMinPrefaultBytes = size_t(64) << 10;
  const size_t page = size_t(sysconf(_SC_PAGESIZE));
  std::vector<std::pair<uintptr_t, size_t>> chunks;
  for (auto [data, bytes] : ranges) {
    if (!data || bytes < kMinPrefaultBytes) continue;  // small arrays: not worth a system call
    advise_huge_pages(data, bytes);
    uintptr_t begin = (reinterpret_cast<uintptr_t>(data) + page - 1) & ~uintptr_t(page - 1);
    uintptr_t end = (reinterpret_cast<uintptr_t>(data) + bytes) & ~uintptr_t(page - 1);
    // A range below one chunk holds no whole huge page: it is cut into one piece per thread
    // (whole pages, at least kMinPrefaultBytes), not left to one task (bunny00's layout
    // positions, 1.2 MB).
    const size_t piece = std::max(kMinPrefaultBytes, (end - begin) / pool.size() / page * page);
    for (uintptr_t at = begin; at < end;) {
      const uintptr_t next = end - begin < kChunk ? std::min(end, at + piece) : std::min(end, (at + kChunk) & ~(kChunk - 1));
      chunks.push_back({at, size_t(next - at)});
      at = next;
    }
  }
  // Each populated page is also written once, in its task: the first write of a populated
  // 4 KiB page still costs ~4-10 µs on this VM (the host's side; 1.2 MB: 1.4-1.6 ms, 16 MiB:
  // 36-48 ms in the resize's zero fill, one thread), and the resize that follows then fills
  // pages that cost nothing more (0.02 / 0.7 ms). Huge pages: ~0.1 ms per 16 MiB. A byte is
  // written back as read, so contents are kept (the ranges hold no objects yet anyway).
  pool.parallel_for(chunks.size(), [&](size_t i) {
    (void)madvise(reinterpret_cast<void*>(chunks[i].first), chunks[i].second, MADV_POPULATE_WRITE);
    for (uintptr_t at = chunks[i].first; at < chunks[i].first + chunks[i].second; at += page) {
      volatile uint8_t* byte = reinterpret_cast<volatile uint8_t*>(at);
      *byte = *byte;
    }
  });
#else
  (void)ranges;
  (void)pool;
#endif
}

}  // namespace vgeo
