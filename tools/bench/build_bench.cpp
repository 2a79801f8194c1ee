// Builder throughput: DAG build of a dense UV sphere (lib/vgeo/mesh's make_uv_sphere).
// Run: vgeo_microbench --benchmark_filter=BuildSphere  (10M triangles needs ~2-3 GB RAM).
#include <benchmark/benchmark.h>

#include <cmath>

#include "vgeo/dag/build.h"
#include "vgeo/mesh/generate.h"

namespace {

vgeo::Mesh dense_sphere(size_t target_triangles) {
  // rings x segments quads, 2 triangles each (poles as fans): ~2 * rings * segments.
  uint32_t segments = uint32_t(std::sqrt(double(target_triangles)));
  uint32_t rings = uint32_t(target_triangles / (2 * segments)) + 1;
  vgeo::Mesh m = vgeo::make_uv_sphere(rings, segments);
  m.normals.clear();  // positions only, as the figures in spec/dag.md §5 were measured
  return m;
}

void BM_BuildSphere(benchmark::State& state) {
  vgeo::Mesh mesh = dense_sphere(size_t(state.range(0)));
  vgeo::BuildOptions options;
  options.simplifier = state.range(1) ? vgeo::Simplifier::kOpenMesh : vgeo::Simplifier::kMeshopt;
  options.threads = 0;
  vgeo::BuildReport report;
  for (auto _ : state) {
    vgeo::ClusterDag dag = vgeo::build_dag(mesh, options, &report);
    benchmark::DoNotOptimize(dag.clusters.data());
  }
  state.counters["input_tris_per_s"] =
      benchmark::Counter(double(mesh.triangle_count()) * double(state.iterations()), benchmark::Counter::kIsRate);
  state.counters["levels"] = double(report.levels.size());
  state.counters["stored_ratio"] = double(report.stored_triangles) / double(report.input_triangles);
  state.counters["peak_MiB"] = double(report.peak_memory_bytes) / (1 << 20);
  state.counters["s_cluster"] = report.seconds_cluster;
  state.counters["s_group"] = report.seconds_group;
  state.counters["s_simplify"] = report.seconds_simplify;
  state.counters["s_split"] = report.seconds_split;
}

BENCHMARK(BM_BuildSphere)->ArgNames({"tris", "openmesh"})
    ->Args({200000, 0})->Args({200000, 1})->Args({1000000, 0})->Args({1000000, 1})->Args({10000000, 0})
    ->Unit(benchmark::kSecond)->Iterations(1)->UseRealTime();

}  // namespace
