// DAG quality of builder variants on CGAL meshes (run tools/fetch-data first; VGEO_DATA_DIR
// overrides ./data). Quality = triangles of the cut at equal *measured* error ε (the measured
// hull cut of lib/vgeo/verify/measured_cut.h, the one implementation `vgeo compare` and
// `vgeo bench dagquality` report): fewer triangles at the same ε is a better DAG. Counters:
// the cut at ε = 1e-3 and 1e-2 × diagonal and the 17-ε curve's geometric mean; the cut by
// *stored* errors at the same ε (what the runtime draws given the builder's claims) beside it.
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <string>

#include "vgeo/dag/build_internal.h"
#include "vgeo/dag/cluster_dag.h"
#include "vgeo/mesh/import.h"
#include "vgeo/verify/measured_cut.h"

namespace {

using namespace vgeo;
using namespace vgeo::build_detail;

const char* kDagQualityMeshes[] = {"armadillo", "bunny00", "fandisk", "refined_elephant", "man", "elephant-with-holes"};

void BM_DagQuality(benchmark::State& state) {
  const char* dir = std::getenv("VGEO_DATA_DIR");
  std::string path = std::string(dir ? dir : "data") + "/cgal/meshes/" + kDagQualityMeshes[state.range(0)] + ".off";
  if (!std::filesystem::exists(path)) {
    state.SkipWithError(("missing " + path + " (run tools/fetch-data)").c_str());
    return;
  }
  Scene scene = import_scene(path).scene;
  const Mesh& mesh = scene.meshes[0];
  BuildOptions options;
  options.threads = 0;
  InternalBuildOptions internal;
  const char* variant = "meshopt";
  switch (state.range(1)) {
    case 1: internal.leaf_split = SplitMethod::kMetis; variant = "metis-leaves"; break;
    case 2: internal.leaf_split = internal.group_split = SplitMethod::kMetis; variant = "metis-all"; break;
    case 3: internal.group_target_clusters = 8; variant = "group8"; break;
    case 4: internal.group_target_clusters = 32; variant = "group32"; break;
    case 5: options.simplifier = Simplifier::kOpenMesh; variant = "openmesh"; break;
    default: break;
  }
  BuildReport report;
  ClusterDag dag;
  for (auto _ : state) dag = build_dag_internal(mesh, options, internal, &report);
  const DagQuality q = measure_dag_quality(dag, options.threads);
  state.counters["cut_3"] = double(q.cut_measured[0]);
  state.counters["cut_2"] = double(q.cut_measured[1]);
  state.counters["cut_gmean"] = q.cut_curve_geometric_mean;
  state.counters["stored_cut_3"] = double(q.cut_stored[0]);
  state.counters["stored_cut_2"] = double(q.cut_stored[1]);
  uint64_t stuck = 0;
  for (const BuildLevelReport& l : report.levels) stuck += l.stuck_groups;
  state.SetLabel(std::string(kDagQualityMeshes[state.range(0)]) + " " + variant);
  state.counters["levels"] = double(report.levels.size());
  state.counters["stored"] = double(report.stored_triangles) / double(report.input_triangles);
  state.counters["stuck"] = double(stuck);
  state.counters["root_tris"] = double(report.root_triangles);
  state.counters["in_tris"] = double(report.input_triangles);
}

BENCHMARK(BM_DagQuality)->ArgNames({"mesh", "variant"})->ArgsProduct({{0, 1, 2, 3, 4, 5}, {0, 1, 2, 3, 4, 5}})
    ->Unit(benchmark::kMillisecond)->Iterations(1);

}  // namespace
