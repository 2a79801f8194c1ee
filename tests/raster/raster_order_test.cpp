// Properties: order independence and depth-key ordering. The VisBuffer is bit-identical
// for any cluster submission order and any number of threads rasterizing concurrently
// into it; the nearer surface wins; at equal depth the larger (cluster, triangle) id wins.
#include <gtest/gtest.h>
#include <rapidcheck/gtest.h>

#include <algorithm>
#include <random>
#include <thread>

#include "raster_testing.h"

namespace vgeo {
namespace {

using raster_test::first_mismatch;
using raster_test::raster_tris;
using raster_test::Tri;
using raster_test::uniform;

struct Cluster {
  std::vector<Tri> tris;
  uint32_t id;
};

void draw(VisBuffer& buf, const std::vector<Cluster>& clusters, const std::vector<size_t>& order,
          const Mat4& m, const RasterOptions& opt) {
  for (size_t i : order) raster_tris(buf, clusters[i].tris, m, clusters[i].id, opt);
}

RC_GTEST_PROP(RasterOrder, ShuffledOrderAndThreadCountGiveIdenticalBuffers, ()) {
  const uint32_t w = 48, h = 48;
  Mat4 m = raster_test::pixel_to_clip(w, h);
  // Few distinct depths and repeated triangles so equal-depth ties are common.
  int cluster_count = uniform(1, 12);
  std::vector<Cluster> clusters;
  std::vector<Tri> pool;
  for (int c = 0; c < cluster_count; ++c) {
    Cluster cl;
    cl.id = uniform<uint32_t>(0, 64);  // duplicates allowed: identical keys then
    int n = uniform(1, 20);
    for (int t = 0; t < n; ++t) {
      if (!pool.empty() && uniform(0, 3) == 0) {
        cl.tris.push_back(pool[uniform<size_t>(0, pool.size())]);
      } else {
        Tri tri = raster_test::pixel_triangle(int(w), int(h));
        float z = *rc::gen::element(0.25f, 0.5f, 1.0f);
        if (uniform(0, 2)) tri.v[0].z = tri.v[1].z = tri.v[2].z = z;
        cl.tris.push_back(tri);
        pool.push_back(tri);
      }
    }
    clusters.push_back(cl);
  }
  RasterOptions opt;
  opt.path = *rc::gen::element(RasterPath::kAuto, RasterPath::kMicropoly, RasterPath::kScanline);
  opt.cull_backfaces = uniform(0, 2) == 0;

  std::vector<size_t> order(clusters.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = i;
  VisBuffer in_order;
  in_order.resize(w, h);
  draw(in_order, clusters, order, m, opt);

  std::mt19937 rng(uniform<uint32_t>(0, 1u << 30));
  std::shuffle(order.begin(), order.end(), rng);
  VisBuffer shuffled;
  shuffled.resize(w, h);
  draw(shuffled, clusters, order, m, opt);
  RC_ASSERT(first_mismatch(in_order, shuffled) == -1L);

  // N threads each drawing an interleaved share of the shuffled order, concurrently.
  int thread_count = uniform(2, 5);
  VisBuffer threaded;
  threaded.resize(w, h);
  std::vector<std::thread> threads;
  for (int t = 0; t < thread_count; ++t)
    threads.emplace_back([&, t] {
      std::vector<size_t> mine;
      for (size_t i = size_t(t); i < order.size(); i += size_t(thread_count)) mine.push_back(order[i]);
      draw(threaded, clusters, mine, m, opt);
    });
  for (auto& th : threads) th.join();
  RC_ASSERT(first_mismatch(in_order, threaded) == -1L);
}

// Triangle-level shuffle: each triangle submitted as its own cluster whose id is the
// triangle's original position, in a random order, equals the in-order submission.
RC_GTEST_PROP(RasterOrder, ShuffledTriangleOrderGivesIdenticalBuffer, ()) {
  const uint32_t w = 32, h = 32;
  Mat4 m = raster_test::pixel_to_clip(w, h);
  int n = uniform(2, 40);
  std::vector<Cluster> singles;
  for (int i = 0; i < n; ++i) {
    Tri t = raster_test::pixel_triangle(int(w), int(h));
    if (i > 0 && uniform(0, 3) == 0) t = singles[uniform<size_t>(0, singles.size())].tris[0];  // exact duplicate
    singles.push_back({{t}, uint32_t(i)});
  }
  RasterOptions opt;
  opt.path = *rc::gen::element(RasterPath::kAuto, RasterPath::kMicropoly, RasterPath::kScanline);
  std::vector<size_t> order(singles.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = i;
  VisBuffer a, b;
  a.resize(w, h);
  b.resize(w, h);
  draw(a, singles, order, m, opt);
  std::mt19937 rng(uniform<uint32_t>(0, 1u << 30));
  std::shuffle(order.begin(), order.end(), rng);
  draw(b, singles, order, m, opt);
  RC_ASSERT(first_mismatch(a, b) == -1L);
}

// Many threads hammering one small buffer with the same clusters (maximal contention).
TEST(RasterOrder, ConcurrentWritersOnSamePixelsMatchSerial) {
  const uint32_t w = 16, h = 16;
  Mat4 m = raster_test::pixel_to_clip(w, h);
  std::vector<Tri> tris;
  for (int i = 0; i < 64; ++i) {
    float z = float(1 + i % 5) / 8.0f;
    tris.push_back({{{-1, -1, z}, {-1, 40, z}, {40, -1, z}}});
  }
  RasterOptions opt;
  VisBuffer serial, parallel;
  serial.resize(w, h);
  parallel.resize(w, h);
  for (uint32_t c = 0; c < 16; ++c) raster_tris(serial, tris, m, c, opt);
  std::vector<std::thread> threads;
  for (uint32_t c = 0; c < 16; ++c)
    threads.emplace_back([&, c] { raster_tris(parallel, tris, m, c, opt); });
  for (auto& th : threads) th.join();
  EXPECT_EQ(first_mismatch(serial, parallel), -1);
  // Winner everywhere covered: depth 5/8 (the nearest), cluster 15, triangle 63 − (63−4) % 5…
  // i.e. the largest triangle index with i % 5 == 4.
  uint64_t key = serial.keys[0];
  EXPECT_EQ(vis_key_depth(key), 5.0f / 8.0f);
  EXPECT_EQ(vis_key_cluster(key), 15u);
  EXPECT_EQ(vis_key_triangle(key), 59u);
}

TEST(RasterKey, NearerSurfaceWinsInAnyOrder) {
  const uint32_t w = 32, h = 32;
  Mat4 m = raster_test::pixel_to_clip(w, h);
  Tri near_tri{{{0, 0, 0.75f}, {0, 32, 0.75f}, {32, 0, 0.75f}}};
  Tri far_tri{{{0, 0, 0.25f}, {0, 64, 0.25f}, {64, 0, 0.25f}}};
  RasterOptions opt;
  for (int order = 0; order < 2; ++order) {
    VisBuffer buf;
    buf.resize(w, h);
    // The far triangle gets the larger ids: depth must dominate ids.
    if (order == 0) {
      raster_tris(buf, {near_tri}, m, 1, opt);
      raster_tris(buf, {far_tri}, m, 1000, opt);
    } else {
      raster_tris(buf, {far_tri}, m, 1000, opt);
      raster_tris(buf, {near_tri}, m, 1, opt);
    }
    EXPECT_EQ(vis_key_cluster(buf.keys[0]), 1u);
    EXPECT_EQ(vis_key_depth(buf.keys[0]), 0.75f);
    EXPECT_EQ(vis_key_cluster(buf.keys[31 * w + 31]), 1000u);  // only the far one reaches here
  }
}

TEST(RasterKey, EqualDepthLargerIdWins) {
  const uint32_t w = 8, h = 8;
  Mat4 m = raster_test::pixel_to_clip(w, h);
  Tri t{{{0, 0, 0.5f}, {0, 16, 0.5f}, {16, 0, 0.5f}}};
  RasterOptions opt;
  VisBuffer a, b;
  a.resize(w, h);
  b.resize(w, h);
  raster_tris(a, {t, t, t}, m, 7, opt);
  raster_tris(a, {t}, m, 6, opt);
  raster_tris(b, {t}, m, 6, opt);
  raster_tris(b, {t, t, t}, m, 7, opt);
  EXPECT_EQ(first_mismatch(a, b), -1);
  EXPECT_EQ(vis_key_cluster(a.keys[0]), 7u);
  EXPECT_EQ(vis_key_triangle(a.keys[0]), 2u);  // largest triangle index of the three
  // Largest cluster id that fits the 25-bit field still packs losslessly.
  VisBuffer c;
  c.resize(w, h);
  raster_tris(c, {t}, m, kMaxVisibleClusters - 1, opt);
  EXPECT_EQ(vis_key_cluster(c.keys[0]), kMaxVisibleClusters - 1);
  EXPECT_EQ(vis_key_triangle(c.keys[0]), 0u);
}

}  // namespace
}  // namespace vgeo
