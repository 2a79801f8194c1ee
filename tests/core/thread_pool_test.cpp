#include <gtest/gtest.h>

#include <atomic>
#include <stdexcept>
#include <vector>

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
