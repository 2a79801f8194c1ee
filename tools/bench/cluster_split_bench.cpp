// Leaf clustering: meshopt_buildMeshlets vs METIS recursive bisection vs the grower
// (method = SplitMethod: 0 meshopt, 1 METIS, 2 grow), and grouping those clusters
// (group_clusters), on CGAL meshes
// (run tools/fetch-data first; VGEO_DATA_DIR overrides ./data). Counters: average fill
// (triangles per cluster / 128) and boundary-edge fraction (cluster-border edge slots /
// all edge slots, as BuildLevelReport::boundary_edge_fraction).
#include <benchmark/benchmark.h>

#include <cstdlib>
#include <filesystem>
#include <string>

#include "vgeo/dag/build_internal.h"
#include "vgeo/dag/cluster_dag.h"
#include "vgeo/mesh/generate.h"
#include "vgeo/mesh/import.h"

namespace {

using namespace vgeo;
using namespace vgeo::build_detail;

// The last entry is not a file: a UV sphere of one leaf chunk (kLeafChunkTriangles triangles,
// the largest set the builder clusters at once).
const char* kSplitBenchMeshes[] = {"armadillo", "bunny00", "elephant", "fandisk", "refined_elephant", "diplodocus",
                         "blobby_3cc", "man", "sphere"};

Mesh bench_mesh(const std::string& name, const std::string& path) {
  if (name == "sphere") {
    const uint32_t segments = 512, rings = uint32_t(kLeafChunkTriangles / (2 * segments)) + 1;
    return make_uv_sphere(rings, segments);
  }
  return import_scene(path).scene.meshes[0];
}

// One benchmark's input (mesh index state.range(0)): the mesh, its welded positions, all its
// triangles as one set, a vertex scratch array.
struct BenchInput {
  Mesh mesh;
  WeldedMesh welded;
  TriangleSet all;
  std::vector<uint32_t> scratch;
};

// False, with the benchmark skipped and why, when the mesh file is missing.
bool load_bench_input(benchmark::State& state, BenchInput* in) {
  const char* dir = std::getenv("VGEO_DATA_DIR");
  const std::string name = kSplitBenchMeshes[state.range(0)];
  const std::string path = std::string(dir ? dir : "data") + "/cgal/meshes/" + name + ".off";
  if (name != "sphere" && !std::filesystem::exists(path)) {
    state.SkipWithError(("missing " + path + " (run tools/fetch-data)").c_str());
    return false;
  }
  in->mesh = bench_mesh(name, path);
  in->welded = weld_positions(in->mesh);
  in->all.corners = in->mesh.indices;
  in->all.materials.assign(in->mesh.triangle_count(), 0);
  in->scratch.assign(in->mesh.vertex_count(), kNone);
  return true;
}

void BM_LeafClusters(benchmark::State& state) {
  BenchInput in;
  if (!load_bench_input(state, &in)) return;
  const SplitMethod method = SplitMethod(state.range(1));
  std::vector<TriangleSet> clusters;
  for (auto _ : state) clusters = split_into_clusters(in.welded, in.all, in.scratch, method);
  uint64_t open = 0, edges = 0;
  for (const TriangleSet& c : clusters) {
    uint64_t o, a;
    count_cluster_edges(in.welded, c, &o, &a);
    open += o;
    edges += a;
  }
  state.SetLabel(kSplitBenchMeshes[state.range(0)]);
  state.counters["triangles"] = double(in.mesh.triangle_count());
  state.counters["clusters"] = double(clusters.size());
  state.counters["fill"] = double(in.mesh.triangle_count()) / double(clusters.size()) / kMaxClusterTriangles;
  state.counters["border"] = double(open) / double(edges);
}

BENCHMARK(BM_LeafClusters)->ArgNames({"mesh", "method"})
    ->ArgsProduct({{0, 1, 2, 3, 4, 5, 6, 7, 8},
                   {int(SplitMethod::kMeshopt), int(SplitMethod::kMetis), int(SplitMethod::kGrow)}})
    ->Unit(benchmark::kMillisecond)->Iterations(1);

// Grouping one level: group_clusters (the METIS graph of shared welded edges and weak spatial
// edges, then METIS) on a mesh's leaf clusters (the grower's), whole mesh as one block as the
// builder does for up to kGroupBlockClusters clusters; "sphere" is the one-chunk UV sphere
// (1,023 clusters). Counters: clusters, groups.
void BM_GroupClusters(benchmark::State& state) {
  BenchInput in;
  if (!load_bench_input(state, &in)) return;
  const std::vector<TriangleSet> clusters = split_into_clusters(in.welded, in.all, in.scratch, SplitMethod::kGrow);
  std::vector<const TriangleSet*> sets;
  std::vector<std::vector<uint64_t>> open_keys(clusters.size());
  std::vector<Sphere> bounds;
  for (size_t i = 0; i < clusters.size(); ++i) {
    uint64_t open = 0, edges = 0;
    count_cluster_edges(in.welded, clusters[i], &open, &edges, &open_keys[i]);
    sets.push_back(&clusters[i]);
    bounds.push_back(sphere_of_points(in.mesh, clusters[i].corners.data(), clusters[i].corners.size()));
  }
  std::vector<std::vector<uint32_t>> groups;
  for (auto _ : state) groups = group_clusters(sets, open_keys, bounds, kGroupTargetClusters);
  state.SetLabel(kSplitBenchMeshes[state.range(0)]);
  state.counters["clusters"] = double(clusters.size());
  state.counters["groups"] = double(groups.size());
}

BENCHMARK(BM_GroupClusters)->ArgNames({"mesh"})->DenseRange(0, 8)->Unit(benchmark::kMillisecond);

}  // namespace
