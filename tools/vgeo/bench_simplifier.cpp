// Suite "simplifier": the two DAG simplifier backends on the same meshes: build time (side
// by side), DAG shape, and what a frame draws at equal tau for one fixed camera.
#include <cmath>

#include "bench_lodcut.h"
#include "bench_shapes.h"
#include "bench_suites.h"
#include "vgeo/dag/build.h"
#include "vgeo/core/progress.h"
#include "vgeo/verify/verify.h"

namespace vgeo::bench {
namespace {

struct Backend {
  const char* name;
  Simplifier simplifier;
};
constexpr Backend kBackends[] = {{"meshopt", Simplifier::kMeshopt}, {"openmesh", Simplifier::kOpenMesh}};
constexpr size_t kBackendCount = 2;
const std::vector<float> kTaus = {0.25f, 0.5f, 1, 2, 4, 8};
// Camera 4 bounding radii from the centre: the mesh covers about a third of the screen
// height, so the cut mixes levels (neither all leaves nor all roots).
constexpr double kCameraDistanceRadii = 4.0;

}  // namespace

void run_simplifier_suite(const BenchConfig& cfg, SuiteReport& out) {
  out.ran = true;
  struct Input {
    Shape shape;
    uint32_t triangles;
  };
  std::vector<Input> inputs = cfg.quick ? std::vector<Input>{{Shape::kSphere, 8000}}
                                        : std::vector<Input>{{Shape::kSphere, 60000},
                                                             {Shape::kTerrain, 60000},
                                                             {Shape::kIslands, 60000},
                                                             {Shape::kThin, 60000}};
  const int reps = cfg.repetitions(3);
  out.summary =
      "Both backends build the DAG of the same mesh (BuildOptions::simplifier), interleaved, " + std::to_string(reps) +
      " repetitions each; wall time and process CPU time (all threads) are both reported, the ratio is of CPU "
      "time (robust to other processes on a shared machine). The LOD cut is the runtime's test (lib/vgeo/core/lod.h lod_selects) over all clusters for one "
      "camera (" + fmt(kCameraDistanceRadii) + " bounding radii away on the diagonal, 1080 px tall, 60° fov), "
      "without culling: equal tau means equal promised screen-space error, so fewer triangles at equal tau means "
      "a better simplifier (if the stored errors are honest; see lib/vgeo/verify's error-bound check).";

  Table build_t{"Build time (median [min, max]) and DAG shape", {"mesh", "triangles", "backend", "build wall time",
                                                                 "build CPU time", "CPU time / meshopt", "levels", "clusters",
                                                                 "stored tris", "root tris"}, {}};
  Table cut_t{"Triangles drawn at equal tau (fixed camera)", {"mesh", "backend"}, {}};
  Table err_t{"Stored error honesty: measured / stored lod_error per non-leaf cluster (lib/vgeo/verify error_bound check)",
              {"mesh", "backend", "clusters checked", "median", "p95", "max", "ERROR_* violations"}, {}};
  for (float tau : kTaus) cut_t.columns.push_back("tau=" + fmt(tau));
  nlohmann::json jrows = nlohmann::json::array();
  std::vector<Series> cut_series;

  Progress progress("bench simplifier", inputs.size(), cfg.progress);
  for (const Input& in : inputs) {
    Mesh mesh = make_shape(in.shape, in.triangles, 7);
    std::string label = std::string(shape_name(in.shape)) + " " + std::to_string(mesh.triangle_count());
    out.inputs.push_back(label + " triangles (" + shape_name(in.shape) + ", seed 7)");
    std::vector<ClusterDag> dags(kBackendCount);
    std::vector<BuildReport> reports(kBackendCount);
    auto samples = time_interleaved(reps, kBackendCount, [&](size_t b) {
      BuildOptions opt;
      opt.simplifier = kBackends[b].simplifier;
      opt.threads = cfg.threads;
      dags[b] = build_dag(mesh, opt, &reports[b]);
    });
    for (size_t b = 0; b < kBackendCount; ++b) {
      const ClusterDag& dag = dags[b];
      Stats st = summarize(samples.wall[b]), cpu = summarize(samples.cpu[b]);
      Stats ratio = ratio_stats(samples.cpu[b], samples.cpu[0]);
      uint64_t root_tris = 0;
      for (const DagCluster& c : dag.clusters)
        if (c.parent_error == kTerminalError) root_tris += c.triangle_count;
      build_t.rows.push_back({shape_name(in.shape), std::to_string(mesh.triangle_count()), kBackends[b].name,
                              fmt_stats_time(st), fmt_stats_time(cpu), b == 0 ? "1" : fmt_ratio(ratio), std::to_string(dag.level_count),
                              std::to_string(dag.clusters.size()), std::to_string(dag.triangle_count()),
                              std::to_string(root_tris)});
      LodView view = bench_view(dag, kCameraDistanceRadii);
      std::vector<std::string> row{shape_name(in.shape), kBackends[b].name};
      Series s;
      s.name = std::string(shape_name(in.shape)) + " " + kBackends[b].name;
      s.dashed = b == 1;
      s.color = int(&in - inputs.data());
      nlohmann::json jcut = nlohmann::json::array();
      for (float tau : kTaus) {
        CutCount c = count_cut(dag, view, tau);
        row.push_back(std::to_string(c.triangles));
        s.x.push_back(tau);
        s.y.push_back(double(c.triangles));
        jcut.push_back({{"tau", tau}, {"clusters", c.clusters}, {"triangles", c.triangles}, {"max_level", c.max_level}});
      }
      cut_t.rows.push_back(row);
      nlohmann::json jerr = nullptr;
      {
        VerifyOptions vo;
        vo.checks = kCheckErrorBound;
        vo.threads = cfg.threads;
        VerifyReport vr = verify_dag(dag, vo);
        err_t.rows.push_back({shape_name(in.shape), kBackends[b].name, std::to_string(vr.error_ratio.count),
                              fmt(vr.error_ratio.median), fmt(vr.error_ratio.p95), fmt(vr.error_ratio.max),
                              std::to_string(vr.total_violations())});
        jerr = {{"count", vr.error_ratio.count}, {"median", vr.error_ratio.median}, {"p95", vr.error_ratio.p95},
                {"max", vr.error_ratio.max}, {"violations", vr.total_violations()}};
      }
      cut_series.push_back(s);
      jrows.push_back({{"mesh", shape_name(in.shape)},
                       {"input_triangles", mesh.triangle_count()},
                       {"backend", kBackends[b].name},
                       {"build_wall_seconds", to_json(st)},
                       {"build_cpu_seconds", to_json(cpu)},
                       {"build_cpu_time_over_meshopt", to_json(ratio)},
                       {"levels", dag.level_count},
                       {"clusters", dag.clusters.size()},
                       {"stored_triangles", dag.triangle_count()},
                       {"root_triangles", root_tris},
                       {"cut", jcut},
                       {"measured_over_stored_error", jerr}});
    }
    progress.advance();
  }
  out.tables.push_back(build_t);
  out.tables.push_back(cut_t);
  out.tables.push_back(err_t);
  out.notes.push_back("measured/stored > 1 means the stored lod_error understates the real deviation (an "
                      "invariant violation, counted in the last column): such a DAG draws too few triangles for its "
                      "promised tau. Well below 1 means a pessimistic stored error: the runtime refines more than "
                      "needed and draws more triangles at equal tau.");
  out.data["rows"] = jrows;
  add_plot(out, cfg, "simplifier_triangles_vs_tau.svg",
           Plot{"Triangles drawn at equal tau, per simplifier backend", "tau (pixels of projected error)",
                "triangles drawn", true, true, cut_series},
           "Triangles drawn by the LOD cut against the error threshold tau (fixed camera, no culling)");
}

}  // namespace vgeo::bench
