#include <gtest/gtest.h>

#include <atomic>
#include <mutex>
#include <set>
#include <stdexcept>
#include <thread>
#include <vector>

#include <sys/mman.h>
#include <unistd.h>

#include "vgeo/core/lod.h"
#include "vgeo/core/thread_pool.h"

namespace vgeo {

TEST(ThreadPool, ParallelForVisitsEveryIndexOnce) {
  for (unsigned threads : {1u, 2u, 5u}) {
    ThreadPool pool(threads);
    std::vector<std::atomic<int>> hits(1000);
    pool.parallel_for(hits.size(), [&](size_t i) { hits[i]++; });
    for (auto& h : hits) EXPECT_EQ(h.load(), 1);
  }
}

TEST(ThreadPool, ParallelForRethrows) {
  ThreadPool pool(3);
  EXPECT_THROW(pool.parallel_for(100, [](size_t i) { if (i == 42) throw std::runtime_error("x"); }),
               std::runtime_error);
  // The pool stays usable after an exception.
  std::atomic<int> n{0};
  pool.parallel_for(10, [&](size_t) { n++; });
  EXPECT_EQ(n.load(), 10);
}

// A single index runs on the calling thread (no worker is woken for it).
TEST(ThreadPool, ParallelForOfOneIndexRunsOnTheCallingThread) {
  ThreadPool pool(3);
  std::thread::id ran_on;
  pool.parallel_for(1, [&](size_t) { ran_on = std::this_thread::get_id(); });
  EXPECT_EQ(ran_on, std::this_thread::get_id());
}

// Short parallel_fors return while workers may still be asleep (they are not waited for when
// the calling thread took every index); every index still runs once, and run_on_all after them
// still runs on every thread once, with each worker index once.
TEST(ThreadPool, WorkersThatWakeLateSkipAFinishedParallelFor) {
  for (unsigned threads : {2u, 3u, 5u}) {
    ThreadPool pool(threads);
    for (int round = 0; round < 300; ++round) {
      std::atomic<int> hits[2] = {0, 0};
      pool.parallel_for(2, [&](size_t i) { hits[i]++; });
      EXPECT_EQ(hits[0].load(), 1);
      EXPECT_EQ(hits[1].load(), 1);
      if (round % 50 == 0) {
        std::mutex m;
        std::multiset<unsigned> workers;
        std::set<std::thread::id> ids;
        pool.run_on_all([&](unsigned w) {
          std::lock_guard<std::mutex> lock(m);
          workers.insert(w);
          ids.insert(std::this_thread::get_id());
        });
        ASSERT_EQ(workers.size(), threads);
        for (unsigned w = 0; w < threads; ++w) EXPECT_EQ(workers.count(w), 1u);
        EXPECT_EQ(ids.size(), threads);
      }
    }
  }
}

// prefault_parallel cuts a range below one 2 MiB chunk into a piece per thread and writes every
// page once: the pages of each range (those wholly inside it) are resident afterwards, on any
// pool, and bytes already there are kept (each page's byte is written back as read).
TEST(ThreadPool, PrefaultMakesPagesResidentAndKeepsBytes) {
  const size_t page = size_t(sysconf(_SC_PAGESIZE));
  for (unsigned threads : {1u, 2u, 3u}) {
    ThreadPool pool(threads);
    // 1.5 MiB (below a chunk: pieces), 5 MiB + 3 pages (chunks), 40 KiB (below the minimum: skipped).
    for (size_t bytes : {size_t(3) << 19, (size_t(5) << 20) + 3 * page, size_t(40) << 10}) {
      const size_t mapped = bytes + 2 * page;
      void* map = mmap(nullptr, mapped, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
      ASSERT_NE(map, MAP_FAILED);
      auto* base = static_cast<uint8_t*>(map);
      // An unaligned start: the partial first and last pages are outside the range's pages.
      uint8_t* data = base + page / 2;
      std::vector<unsigned char> resident((mapped + page - 1) / page);
      ASSERT_EQ(mincore(map, mapped, resident.data()), 0);
      for (unsigned char r : resident) EXPECT_EQ(r & 1, 0);  // fresh: nothing resident yet
      prefault_parallel({{data, bytes}}, pool);
      ASSERT_EQ(mincore(map, mapped, resident.data()), 0);
      const size_t first = 1, last = (page / 2 + bytes) / page;  // whole pages of the range
      for (size_t p = first; p < last; ++p) EXPECT_EQ(resident[p] & 1, bytes >= (size_t(64) << 10) ? 1 : 0) << p;
      // Bytes written before a prefault are kept.
      for (size_t i = 0; i < bytes; i += 997) data[i] = uint8_t(i * 31 + 7);
      prefault_parallel({{data, bytes}}, pool);
      for (size_t i = 0; i < bytes; i += 997) ASSERT_EQ(data[i], uint8_t(i * 31 + 7)) << i;
      munmap(map, mapped);
    }
  }
}

TEST(Lod, ProjectedErrorFiniteWithEyeInsideSphere) {
  LodView view{{0, 0, 0}, 500.0f, 0.1f};
  Sphere s{{0, 0, 0}, 10.0f};
  float e = projected_error(s, 1.0f, view);
  EXPECT_TRUE(std::isfinite(e));
  EXPECT_FLOAT_EQ(e, 1.0f * 500.0f / 0.1f);
}

TEST(Lod, MergedSphereEnclosesInputs) {
  Sphere a{{1e7f, 0, 0}, 1.0f}, b{{1e7f + 3.0f, 1.0f, -2.0f}, 0.5f};
  Sphere m = merge_spheres(a, b);
  EXPECT_TRUE(sphere_contains(m, a));
  EXPECT_TRUE(sphere_contains(m, b));
}

}  // namespace vgeo
