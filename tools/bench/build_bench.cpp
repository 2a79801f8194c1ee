// Builder throughput: DAG build of a dense UV sphere (lib/vgeo/mesh's make_uv_sphere).
// Run: vgeo_microbench --benchmark_filter=BuildSphere  (10M triangles needs ~2-3 GB RAM).
// Args: tris, openmesh (simplifier), split (build_detail::SplitMethod of leaves and groups:
// 0 meshopt_buildMeshlets, the default; 2 the own grower), threads (0 = all cores).
#include <benchmark/benchmark.h>

#include <cmath>

#include "vgeo/dag/build.h"
#include "vgeo/dag/build_internal.h"
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
  options.threads = unsigned(state.range(3));
  vgeo::build_detail::InternalBuildOptions internal;
  internal.leaf_split = internal.group_split = vgeo::build_detail::SplitMethod(state.range(2));
  vgeo::BuildReport report;
  for (auto _ : state) {
    vgeo::ClusterDag dag = vgeo::build_detail::build_dag_internal(mesh, options, internal, &report);
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
  state.counters["s_error"] = report.seconds_error;
  state.counters["s_edges"] = report.seconds_edges;
  state.counters["s_locks"] = report.seconds_locks;
  state.counters["s_serial"] = report.seconds_prepare + report.seconds_combine + report.seconds_layout +
                               report.seconds_hierarchy;
}

BENCHMARK(BM_BuildSphere)->ArgNames({"tris", "openmesh", "split", "threads"})
    ->Args({200000, 0, 0, 0})->Args({200000, 1, 0, 0})->Args({1000000, 0, 0, 0})->Args({1000000, 1, 0, 0})
    ->Args({10000000, 0, 0, 0})
    ->Args({1000000, 0, 0, 1})->Args({1000000, 0, 2, 1})->Args({1000000, 0, 2, 0})
    ->Args({10000000, 0, 0, 1})->Args({10000000, 0, 2, 1})->Args({10000000, 0, 2, 0})
    ->Unit(benchmark::kSecond)->Iterations(1)->UseRealTime();

}  // namespace
