// Import throughput and peak memory for a large generated GLB (a flat grid, float positions +
// uint32 indices, one mesh). Target: 10M triangles in < 3 s with peak RSS < 3x the raw
// vertex+index bytes. The GLB is streamed to a temp file so generation adds no memory peak.
// Peak RSS is the process's ru_maxrss: run this benchmark alone (--benchmark_filter=ImportGlb)
// for a meaningful ratio.
#include <benchmark/benchmark.h>
#include <sys/resource.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "vgeo/mesh/glb.h"
#include "vgeo/mesh/import.h"

namespace {

using vgeo::kGlbChunkBin;
using vgeo::kGlbChunkJson;
using vgeo::kGlbMagic;

struct GridGlb {
  std::string path;
  size_t triangles = 0, vertices = 0, raw_bytes = 0;
};

// Grid of side x side quads (2 triangles each), written straight to `path` row by row.
GridGlb write_grid_glb(size_t target_triangles) {
  const size_t side = size_t(std::ceil(std::sqrt(double(target_triangles) / 2)));
  const size_t verts = (side + 1) * (side + 1), tris = 2 * side * side;
  const size_t pos_bytes = verts * 12, idx_bytes = tris * 12;
  GridGlb g;
  g.path = (std::filesystem::temp_directory_path() /
            ("vgeo_import_bench_" + std::to_string(::getpid()) + "_" + std::to_string(tris) + ".glb"))
               .string();
  g.triangles = tris;
  g.vertices = verts;
  g.raw_bytes = pos_bytes + idx_bytes;
  const size_t side1 = side + 1;
  std::string json = "{\"asset\":{\"version\":\"2.0\"},\"scene\":0,\"scenes\":[{\"nodes\":[0]}],\"nodes\":[{\"mesh\":0}],"
                     "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0},\"indices\":1}]}],"
                     "\"buffers\":[{\"byteLength\":" + std::to_string(pos_bytes + idx_bytes) + "}],"
                     "\"bufferViews\":[{\"buffer\":0,\"byteOffset\":0,\"byteLength\":" + std::to_string(pos_bytes) +
                     "},{\"buffer\":0,\"byteOffset\":" + std::to_string(pos_bytes) + ",\"byteLength\":" +
                     std::to_string(idx_bytes) + "}],"
                     "\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":" + std::to_string(verts) +
                     ",\"type\":\"VEC3\",\"min\":[0,0,0],\"max\":[1,1,0]},{\"bufferView\":1,\"componentType\":5125,\"count\":" +
                     std::to_string(tris * 3) + ",\"type\":\"SCALAR\"}]}";
  while (json.size() % 4) json.push_back(' ');
  const uint32_t bin_len = uint32_t(pos_bytes + idx_bytes);
  const uint32_t total = uint32_t(12 + 8 + json.size() + 8 + bin_len);
  FILE* f = std::fopen(g.path.c_str(), "wb");
  auto u32 = [&](uint32_t v) { std::fwrite(&v, 4, 1, f); };
  u32(kGlbMagic);
  u32(2);
  u32(total);
  u32(uint32_t(json.size()));
  u32(kGlbChunkJson);
  std::fwrite(json.data(), 1, json.size(), f);
  u32(bin_len);
  u32(kGlbChunkBin);
  std::vector<float> row(side1 * 3);
  for (size_t y = 0; y < side1; ++y) {
    for (size_t x = 0; x < side1; ++x) {
      row[3 * x] = float(x) / float(side);
      row[3 * x + 1] = float(y) / float(side);
      row[3 * x + 2] = 0.0f;
    }
    std::fwrite(row.data(), 4, row.size(), f);
  }
  std::vector<uint32_t> irow(side * 6);
  for (size_t y = 0; y < side; ++y) {
    for (size_t x = 0; x < side; ++x) {
      uint32_t a = uint32_t(y * side1 + x), b = a + 1, c = a + uint32_t(side1), d = c + 1;
      uint32_t* q = &irow[6 * x];
      q[0] = a, q[1] = b, q[2] = c, q[3] = c, q[4] = b, q[5] = d;
    }
    std::fwrite(irow.data(), 4, irow.size(), f);
  }
  std::fclose(f);
  return g;
}

double max_rss_bytes() {
  rusage ru{};
  getrusage(RUSAGE_SELF, &ru);
  return double(ru.ru_maxrss) * 1024.0;  // Linux reports KiB
}

void BM_ImportGlb(benchmark::State& state) {
  const GridGlb g = write_grid_glb(size_t(state.range(0)));
  size_t tris = 0;
  for (auto _ : state) {
    vgeo::ImportResult r = vgeo::import_scene(g.path);
    tris = r.scene.meshes[0].triangle_count();
    benchmark::DoNotOptimize(r.scene.meshes[0].indices.data());
  }
  std::filesystem::remove(g.path);
  if (tris != g.triangles) state.SkipWithError("triangle count mismatch");
  const double peak = max_rss_bytes();
  state.counters["triangles"] = double(g.triangles);
  state.counters["raw_MB"] = double(g.raw_bytes) / 1e6;
  state.counters["peak_rss_MB"] = peak / 1e6;
  state.counters["peak_over_raw"] = peak / double(g.raw_bytes);
  state.counters["Mtri_per_s"] =
      benchmark::Counter(double(g.triangles) * double(state.iterations()) / 1e6, benchmark::Counter::kIsRate);
}

}  // namespace

BENCHMARK(BM_ImportGlb)->Arg(1'000'000)->Arg(10'000'000)->Unit(benchmark::kMillisecond)->Iterations(1);
