// Procedural generation and GLB writing at 1M and 10M triangles (single thread unless
// the benchmark name says otherwise). Run: vgeo_microbench --benchmark_filter=Gen
#include <filesystem>
#include <benchmark/benchmark.h>

#include <cstdio>
#include <string>
#include <unistd.h>

#include "vgeo/mesh/export.h"
#include "vgeo/mesh/generate.h"
#include "vgeo/mesh/subdivide.h"

namespace {

void BM_GenerateMesh(benchmark::State& state, vgeo::GenShape shape, unsigned threads) {
  vgeo::GenerateOptions o;
  o.shape = shape;
  o.target_triangles = uint64_t(state.range(0));
  o.seed = 7;
  o.threads = threads;
  size_t tris = 0;
  for (auto _ : state) {
    vgeo::Mesh m = vgeo::generate_mesh(o);
    tris = m.triangle_count();
    benchmark::DoNotOptimize(m.positions.data());
  }
  state.counters["triangles"] = double(tris);
  state.counters["Mtri/s"] = benchmark::Counter(double(tris) * state.iterations() / 1e6, benchmark::Counter::kIsRate);
}

void BM_SmoothNormals(benchmark::State& state) {
  vgeo::GenerateOptions o;
  o.target_triangles = uint64_t(state.range(0));
  vgeo::Mesh m = vgeo::generate_mesh(o);
  for (auto _ : state) {
    vgeo::compute_smooth_normals(m);
    benchmark::DoNotOptimize(m.normals.data());
  }
}

void BM_WriteGlb(benchmark::State& state) {
  vgeo::GenerateOptions o;
  o.target_triangles = uint64_t(state.range(0));
  vgeo::Scene scene = vgeo::generate_scene(o);
  const std::string path = (std::filesystem::temp_directory_path() / ("vgeo_generate_bench_" + std::to_string(getpid()) + ".glb")).string();
  for (auto _ : state) vgeo::write_glb(scene, path);
  std::remove(path.c_str());
  state.counters["triangles"] = double(scene.meshes[0].triangle_count());
}

// Generation + GLB write end to end (what `vgeo gen sphere -n N -o x.glb` does).
void BM_GenerateAndWriteGlb(benchmark::State& state, vgeo::GenShape shape) {
  vgeo::GenerateOptions o;
  o.shape = shape;
  o.target_triangles = uint64_t(state.range(0));
  const std::string path = (std::filesystem::temp_directory_path() / ("vgeo_generate_bench_" + std::to_string(getpid()) + ".glb")).string();
  for (auto _ : state) vgeo::write_glb(vgeo::generate_scene(o), path);
  std::remove(path.c_str());
}

// One Loop step through OpenMesh (input triangles given; output is 4x).
void BM_SubdivideLoop(benchmark::State& state) {
  vgeo::GenerateOptions o;
  o.target_triangles = uint64_t(state.range(0));
  vgeo::Mesh m = vgeo::generate_mesh(o);
  for (auto _ : state) {
    vgeo::Mesh d = vgeo::subdivide_loop(m);
    benchmark::DoNotOptimize(d.positions.data());
  }
  state.counters["out_triangles"] = double(4 * m.triangle_count());
}

constexpr int64_t k1M = 1'000'000, k10M = 10'000'000;

BENCHMARK_CAPTURE(BM_GenerateMesh, sphere_1thread, vgeo::GenShape::kSphere, 1u)
    ->Arg(k1M)->Arg(k10M)->Unit(benchmark::kMillisecond)->Iterations(1);
BENCHMARK_CAPTURE(BM_GenerateMesh, sphere_2threads, vgeo::GenShape::kSphere, 2u)
    ->Arg(k1M)->Arg(k10M)->Unit(benchmark::kMillisecond)->Iterations(1);
BENCHMARK_CAPTURE(BM_GenerateMesh, terrain_1thread, vgeo::GenShape::kTerrain, 1u)
    ->Arg(k1M)->Arg(k10M)->Unit(benchmark::kMillisecond)->Iterations(1);
BENCHMARK_CAPTURE(BM_GenerateMesh, islands_1thread, vgeo::GenShape::kIslands, 1u)
    ->Arg(k1M)->Arg(k10M)->Unit(benchmark::kMillisecond)->Iterations(1);
BENCHMARK_CAPTURE(BM_GenerateMesh, thin_1thread, vgeo::GenShape::kThin, 1u)
    ->Arg(k1M)->Arg(k10M)->Unit(benchmark::kMillisecond)->Iterations(1);
BENCHMARK_CAPTURE(BM_GenerateMesh, torus_1thread, vgeo::GenShape::kTorus, 1u)
    ->Arg(k1M)->Arg(k10M)->Unit(benchmark::kMillisecond)->Iterations(1);
BENCHMARK(BM_SmoothNormals)->Arg(k1M)->Arg(k10M)->Unit(benchmark::kMillisecond)->Iterations(1);
BENCHMARK(BM_WriteGlb)->Arg(k1M)->Arg(k10M)->Unit(benchmark::kMillisecond)->Iterations(1);
BENCHMARK(BM_SubdivideLoop)->Arg(250'000)->Arg(2'500'000)->Unit(benchmark::kMillisecond)->Iterations(1);
BENCHMARK_CAPTURE(BM_GenerateAndWriteGlb, sphere, vgeo::GenShape::kSphere)
    ->Arg(k1M)->Arg(k10M)->Unit(benchmark::kMillisecond)->Iterations(1);

}  // namespace

