// Software rasterizer micro-benchmarks (spec/raster.md "Path choice"):
//  * BM_RasterBySize: micropoly / scanline / auto / reference for clusters of
//    front-facing triangles of a given screen area (1 … 256 px² and a large one) on a
//    256×256 target (the reference loops over the whole viewport per triangle).
//  * BM_RasterMicroTriangles1080p: triangles/s for ~1 px² triangles at 1920×1080.
// Keys grow every iteration (cluster id = iteration) so each covered pixel really
// performs the atomic compare-exchange, as in a frame with fresh content.
#include <benchmark/benchmark.h>

#include <cmath>
#include <random>
#include <vector>

#include "vgeo/raster/raster.h"

namespace {

using namespace vgeo;

struct BenchCluster {
  std::vector<float> positions;
  std::vector<uint8_t> indices;
};

// Pixel coordinates → clip space with w = 1 (x right, y down), depth = z.
Mat4 pixel_to_clip(uint32_t width, uint32_t height) {
  Mat4 m;
  m.at(0, 0) = 2.0f / float(width);
  m.at(0, 3) = -1.0f;
  m.at(1, 1) = -2.0f / float(height);
  m.at(1, 3) = 1.0f;
  return m;
}

// `count` clusters, each a rotated grid patch of right triangles of `area` px² (shared
// vertices, as in a real cluster: 8×8 cells = 128 triangles on 81 vertices, fewer cells
// when the patch would not fit the target), at a random position, rotation and depth.
std::vector<BenchCluster> make_clusters(int count, double area, uint32_t width, uint32_t height) {
  std::mt19937 rng(12345);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  double cell = std::sqrt(2.0 * area);
  int cells = std::max(1, std::min(8, int(0.7 * std::min(width, height) / cell)));
  double half = 0.5 * cells * cell * std::sqrt(2.0);  // bounding radius of the patch
  std::vector<BenchCluster> clusters(static_cast<size_t>(count));
  for (BenchCluster& c : clusters) {
    double cx = half + unit(rng) * (width - 2 * half), cy = half + unit(rng) * (height - 2 * half);
    double rot = unit(rng) * 6.283185307179586, cs = std::cos(rot), sn = std::sin(rot);
    float z = float(0.05 + 0.95 * unit(rng));
    for (int j = 0; j <= cells; ++j)
      for (int i = 0; i <= cells; ++i) {
        double u = (i - 0.5 * cells) * cell, v = (j - 0.5 * cells) * cell;
        c.positions.insert(c.positions.end(), {float(cx + cs * u - sn * v), float(cy + sn * u + cs * v), z});
      }
    for (int j = 0; j < cells; ++j)
      for (int i = 0; i < cells; ++i) {
        uint8_t a = uint8_t(j * (cells + 1) + i), b = uint8_t(a + 1), d = uint8_t(a + cells + 1), e = uint8_t(d + 1);
        // (a, d, b) and (b, d, e): counter-clockwise in NDC for a proper rotation.
        c.indices.insert(c.indices.end(), {a, d, b, b, d, e});
      }
  }
  return clusters;
}

void run(benchmark::State& state, RasterPath path, double area, uint32_t width, uint32_t height,
         int cluster_count) {
  std::vector<BenchCluster> clusters = make_clusters(cluster_count, area, width, height);
  VisBuffer target;
  target.resize(width, height);
  Mat4 m = pixel_to_clip(width, height);
  RasterOptions opt;
  opt.path = path;
  RasterStats stats;
  uint32_t iteration = 0;
  for (auto _ : state) {
    ++iteration;
    for (const BenchCluster& c : clusters)
      rasterize_cluster(target, c.positions.data(), uint32_t(c.positions.size() / 3), c.indices.data(),
                        uint32_t(c.indices.size() / 3), m, iteration & (kMaxVisibleClusters - 1), opt, &stats);
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(int64_t(state.iterations()) * int64_t(clusters[0].indices.size() / 3) * cluster_count);
  state.counters["culled%"] =
      100.0 * double(stats.triangles_culled) / double(std::max<uint64_t>(1, stats.triangles_in));
  state.counters["px/tri"] = double(stats.pixels_written) / double(stats.triangles_in);
  state.counters["scanline%"] =
      100.0 * double(stats.scanline_triangles) / double(std::max<uint64_t>(1, stats.triangles_in));
}

// Areas in px²; 16384 px² is the "large" triangle (a ~190 px side).
void BM_RasterBySize(benchmark::State& state) {
  RasterPath path = RasterPath(state.range(0));
  double area = double(state.range(1));
  // The reference visits all 65536 pixels per triangle: one cluster is enough work.
  run(state, path, area, 256, 256, path == RasterPath::kReference ? 1 : 8);
}
BENCHMARK(BM_RasterBySize)
    ->ArgNames({"path", "area"})
    ->ArgsProduct({{int(RasterPath::kMicropoly), int(RasterPath::kScanline), int(RasterPath::kAuto),
                    int(RasterPath::kReference)},
                   {1, 4, 16, 64, 256, 16384}})
    ->Unit(benchmark::kMicrosecond);

void BM_RasterMicroTriangles1080p(benchmark::State& state) {
  run(state, RasterPath(state.range(0)), 1.0, 1920, 1080, 256);
}
BENCHMARK(BM_RasterMicroTriangles1080p)
    ->ArgName("path")
    ->Arg(int(RasterPath::kAuto))
    ->Arg(int(RasterPath::kMicropoly))
    ->Arg(int(RasterPath::kScanline))
    ->Unit(benchmark::kMicrosecond);

}  // namespace

