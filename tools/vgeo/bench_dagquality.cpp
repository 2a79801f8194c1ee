// Suite "dagquality": how many triangles a DAG needs at a given *measured* error, whatever
// built it, so builders that store different errors compare fairly (figures:
// docs/acceptance/issue15.md §2). The measurement is lib/vgeo/verify/measured_cut.h (the one
// implementation `vgeo compare` uses too): per cluster the deviation from the leaves on the
// verify lattice, a monotone hull up the DAG, the cut at ε. Reported: triangles in the cuts at
// ε = 1e-3 and 1e-2 of the mesh diagonal (also the cut by *stored* error at the same ε, what
// lod_selects would draw given the builder's claims), the 17-ε curve and its geometric mean,
// the measured/stored error ratios, levels, stored ×, roots. Inputs are meshes (built here with
// vgeo's builder variants) or built files of any builder (.vgeodag or page files, measured as
// they are); an input that cannot be read fails the suite with its code.
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <sstream>

#include "bench_suites.h"
#include "vgeo/core/error.h"
#include "vgeo/core/progress.h"
#include "vgeo/dag/build.h"
#include "vgeo/dag/build_internal.h"
#include "vgeo/format/asset_file.h"
#include "vgeo/mesh/generate.h"
#include "vgeo/mesh/import.h"
#include "vgeo/verify/measured_cut.h"

namespace vgeo::bench {

namespace {

struct QualityInput {
  std::string label;
  std::string path;           // a mesh file or a built file (.vgeodag / page file), or empty: generated
  uint64_t gen_triangles = 0; // `vgeo gen sphere --triangles N --seed 1`
};

// Mesh files are built here; any other path is a built DAG of some builder (VGEODAG1 or page
// file, told apart by magic; neither → ASSET_FILE_UNKNOWN) and is measured as it is.
bool is_mesh_file(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  for (char& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
  for (const char* e : {".gltf", ".glb", ".obj", ".ply", ".off", ".stl"})
    if (ext == e) return true;
  return false;
}

// VGEO_DAGQUALITY_INPUTS: comma-separated mesh files or "sphere:N" (replaces the defaults).
std::vector<QualityInput> quality_inputs(bool quick) {
  std::vector<QualityInput> in;
  auto add_token = [&](const std::string& t) {
    if (t.rfind("sphere:", 0) == 0) in.push_back({"sphere " + t.substr(7), "", std::stoull(t.substr(7))});
    else in.push_back({std::filesystem::path(t).stem().string(), t, 0});
  };
  if (const char* env = std::getenv("VGEO_DAGQUALITY_INPUTS"); env && *env) {
    std::stringstream ss(env);
    for (std::string t; std::getline(ss, t, ',');)
      if (!t.empty()) add_token(t);
    return in;
  }
  if (quick) return {{"sphere 30000", "", 30000}};
  in.push_back({"sphere 1000000", "", 1000000});
  // The CGAL meshes of docs/acceptance/issue15.md §2 (closed, open, smooth, sharp), when
  // tools/fetch-data has fetched them.
  for (const char* name : {"bunny00", "armadillo", "refined_elephant", "mech-holes-shark"}) {
    std::string p = std::string("data/cgal/meshes/") + name + ".off";
    if (std::filesystem::exists(p)) in.push_back({name, p, 0});
  }
  return in;
}

// VGEO_DAGQUALITY_GROUP_SIZES: comma-separated kGroupTargetClusters values to compare
// (e.g. 8,16,32); default: the builder's.
std::vector<uint32_t> group_sizes() {
  std::vector<uint32_t> sizes;
  if (const char* env = std::getenv("VGEO_DAGQUALITY_GROUP_SIZES"); env && *env) {
    std::stringstream ss(env);
    for (std::string t; std::getline(ss, t, ',');)
      if (!t.empty()) sizes.push_back(uint32_t(std::stoul(t)));
  }
  if (sizes.empty()) sizes.push_back(0);  // the builder's default for the simplifier
  return sizes;
}

// VGEO_DAGQUALITY_VARIANTS: semicolon-separated builder variants to compare, each
// "simplifier:ratio:budget:split" (meshopt|openmesh, simplify target ratio, error budget
// factor, 0 = none, clusterizer of leaves and group splits: meshopt|grow; an empty field
// keeps the builder's default); default: the builder's defaults.
struct BuilderVariant {
  Simplifier simplifier = Simplifier::kMeshopt;
  double ratio = build_detail::kSimplifyTargetRatio;
  float budget = build_detail::kSimplifyErrorBudget;
  build_detail::SplitMethod split = build_detail::InternalBuildOptions{}.leaf_split;
  std::string label() const {
    std::string l = simplifier == Simplifier::kOpenMesh ? "openmesh" : "meshopt";
    if (ratio != build_detail::kSimplifyTargetRatio) l += " r" + fmt(ratio);
    if (budget != build_detail::kSimplifyErrorBudget) l += " b" + fmt(budget);
    if (split != build_detail::InternalBuildOptions{}.leaf_split)
      l += split == build_detail::SplitMethod::kGrow ? " grow" : " meshopt-clusters";
    return l;
  }
};
std::vector<BuilderVariant> builder_variants() {
  std::vector<BuilderVariant> out;
  if (const char* env = std::getenv("VGEO_DAGQUALITY_VARIANTS"); env && *env) {
    std::stringstream ss(env);
    for (std::string t; std::getline(ss, t, ';');) {
      if (t.empty()) continue;
      BuilderVariant v;
      std::stringstream f(t);
      std::string part;
      if (std::getline(f, part, ':')) v.simplifier = part == "openmesh" ? Simplifier::kOpenMesh : Simplifier::kMeshopt;
      if (std::getline(f, part, ':') && !part.empty()) v.ratio = std::stod(part);
      if (std::getline(f, part, ':') && !part.empty()) v.budget = std::stof(part);
      if (std::getline(f, part, ':') && !part.empty())
        v.split = part == "grow" ? build_detail::SplitMethod::kGrow : build_detail::SplitMethod::kMeshopt;
      out.push_back(v);
    }
  }
  if (out.empty()) out.push_back(BuilderVariant{});
  return out;
}

std::string median_str(std::vector<double> v, double q) {
  if (v.empty()) return "-";
  std::sort(v.begin(), v.end());
  return fmt(v[std::min(v.size() - 1, size_t(q * double(v.size() - 1) + 0.5))]);
}

// One measured DAG's rows in the three tables and the JSON (`build_s` < 0: not built here).
void add_quality_rows(const std::string& mesh_label, const std::string& builder, const std::string& group_size,
                      uint64_t input_triangles, const ClusterDag& dag, const DagQuality& q, double build_s, Table& t,
                      Table& curve, Table& level_table, nlohmann::json& rows) {
  const double stored_x = double(dag.triangle_count()) / double(std::max<uint64_t>(input_triangles, 1));
  const std::string build_text = build_s < 0 ? "-" : fmt(build_s);
  t.rows.push_back({mesh_label, builder, group_size, std::to_string(input_triangles), std::to_string(q.cut_measured[0]),
                    std::to_string(q.cut_measured[1]), std::to_string(q.cut_stored[0]), std::to_string(q.cut_stored[1]),
                    median_str(q.ratios, 0.5), median_str(q.ratios, 0.05), median_str(q.ratios, 1.0),
                    std::to_string(dag.level_count), fmt(stored_x), std::to_string(q.roots), build_text});
  std::vector<std::string> row{mesh_label, builder, group_size};
  for (int i : {0, 2, 4, 6, 8, 12, 16}) row.push_back(std::to_string(q.cut_curve[size_t(i)]));
  row.push_back(std::to_string(*std::min_element(q.cut_curve.begin(), q.cut_curve.end())));
  row.push_back(std::to_string(*std::max_element(q.cut_curve.begin(), q.cut_curve.end())));
  row.push_back(std::to_string(uint64_t(std::llround(q.cut_curve_geometric_mean))));
  curve.rows.push_back(row);
  std::string ladder;
  for (size_t l = 0; l < q.levels.size(); ++l)
    if (q.levels[l].triangles)
      ladder += (ladder.empty() ? "" : ", ") + std::to_string(l) + ": " + std::to_string(q.levels[l].triangles) + " @ " +
                fmt(q.levels[l].hull_median);
  level_table.rows.push_back({mesh_label, builder, group_size, ladder});
  nlohmann::json curve_json = nlohmann::json::array(), levels_json = nlohmann::json::array();
  for (int i = 0; i < kMeasuredCutCurvePoints; ++i)
    curve_json.push_back({{"eps", measured_cut_epsilon(i)}, {"triangles", q.cut_curve[size_t(i)]}});
  for (const DagQuality::Level& l : q.levels)
    levels_json.push_back({{"clusters", l.clusters}, {"triangles", l.triangles}, {"hull_median", l.hull_median}});
  rows.push_back({{"mesh", mesh_label},
                  {"builder", builder},
                  {"group_target_clusters", group_size},
                  {"input_triangles", input_triangles},
                  {"cut_measured_1e-3", q.cut_measured[0]},
                  {"cut_measured_1e-2", q.cut_measured[1]},
                  {"cut_stored_1e-3", q.cut_stored[0]},
                  {"cut_stored_1e-2", q.cut_stored[1]},
                  {"cut_curve_geometric_mean", q.cut_curve_geometric_mean},
                  {"ratio_median", q.ratios.empty() ? 0.0 : std::stod(median_str(q.ratios, 0.5))},
                  {"levels", dag.level_count},
                  {"stored_x", stored_x},
                  {"roots", q.roots},
                  {"root_triangles", q.root_triangles},
                  {"build_seconds", build_s < 0 ? nlohmann::json(nullptr) : nlohmann::json(build_s)},
                  {"cut_curve", curve_json},
                  {"levels_by_hull", levels_json}});
}

// A DAG some builder wrote (VGEODAG1 or page file): every mesh is measured as stored; the
// "builder" column says "file". Read errors keep their code (FILE_*, ASSET_FILE_UNKNOWN,
// DAGFILE_*, FORMAT_*) and fail the suite.
void measure_built_file(const BenchConfig& cfg, const QualityInput& in, Table& t, Table& curve, Table& level_table,
                        nlohmann::json& rows, SuiteReport& out) {
  BuiltScene scene = read_asset_file(in.path);
  if (scene.meshes.empty()) fail("BENCH_INPUT_EMPTY", in.path, "holds no mesh to measure");
  out.inputs.push_back(in.label + ": " + in.path + " (built file, measured as stored)");
  for (size_t m = 0; m < scene.meshes.size(); ++m) {
    const ClusterDag& dag = scene.meshes[m];
    uint64_t leaf_triangles = 0;
    for (const DagCluster& c : dag.clusters)
      if (c.generating_group == kNone) leaf_triangles += c.triangle_count;
    const std::string label = scene.meshes.size() > 1 ? in.label + " mesh " + std::to_string(m) : in.label;
    add_quality_rows(label, "file", "-", leaf_triangles, dag, measure_dag_quality(dag, cfg.threads), -1.0, t, curve,
                     level_table, rows);
  }
}

}  // namespace

void run_dagquality_suite(const BenchConfig& cfg, SuiteReport& out) {
  out.ran = true;
  out.summary =
      "Triangles a DAG needs at equal *measured* error (builder-independent: only the DAG is read). Every non-leaf "
      "cluster's deviation from the leaves is measured on the verify lattice (lib/vgeo/verify/measured_cut.h, "
      "the measurement `vgeo compare` reports too); a monotone hull takes the maximum up the DAG; the cut at eps draws a cluster when "
      "its hull <= eps < its group's parents' hull (terminal groups: +inf). eps = 1e-3 and 1e-2 of the mesh "
      "diagonal. 'stored cut' is the same cut with the stored lod_error/parent_error (what the runtime draws given "
      "the builder's claims: a builder that under-states its errors draws fewer triangles there, not here). "
      "Inputs: `vgeo gen sphere --seed 1` meshes and CGAL meshes from data/, built here; VGEO_DAGQUALITY_INPUTS "
      "(comma-separated) overrides them and may name built files of any builder (.vgeodag, page files), "
      "measured as stored (builder 'file'). An input that cannot be read fails the suite with its code.";
  Table t{"Cut triangles at equal measured error, and DAG shape (builder variants: VGEO_DAGQUALITY_VARIANTS)",
          {"mesh", "builder", "group size", "input tris", "cut 1e-3 (measured)", "cut 1e-2 (measured)", "cut 1e-3 (stored)", "cut 1e-2 (stored)",
           "measured/stored median", "p5", "max", "levels", "stored x", "roots", "build s"},
          {}};
  Table curve{"Cut triangles over eps (measured hull; eps / diagonal, log-spaced): the level sawtooth",
              {"mesh", "builder", "group size", "1e-3", "1.33e-3", "1.78e-3", "2.37e-3", "3.16e-3", "5.62e-3", "1e-2",
               "min", "max", "geometric mean (17 eps)"},
              {}};
  Table level_table{"Levels: triangles and median measured hull / diagonal (the ladder the cut picks from)",
                    {"mesh", "builder", "group size", "level: triangles @ median hull"},
                    {}};
  nlohmann::json rows = nlohmann::json::array();
  const std::vector<QualityInput> inputs = quality_inputs(cfg.quick);
  Progress progress("bench dagquality", inputs.size(), cfg.progress);
  for (const QualityInput& in : inputs) {
    if (!in.path.empty() && !is_mesh_file(in.path)) {
      measure_built_file(cfg, in, t, curve, level_table, rows, out);
      progress.advance();
      continue;
    }
    Mesh mesh;
    if (in.path.empty()) {
      GenerateOptions g;
      g.shape = GenShape::kSphere;
      g.target_triangles = in.gen_triangles;
      g.seed = 1;
      mesh = generate_mesh(g);
      out.inputs.push_back(in.label + ": vgeo gen sphere --triangles " + std::to_string(in.gen_triangles) + " --seed 1");
    } else {
      // An input that cannot be measured fails the suite with its code (never a silent skip).
      ImportResult r = import_scene(in.path);
      if (r.scene.meshes.empty()) fail("BENCH_INPUT_EMPTY", in.path, "holds no mesh to measure");
      mesh = std::move(r.scene.meshes[0]);
      out.inputs.push_back(in.label + ": " + in.path);
    }
    for (const BuilderVariant& variant : builder_variants())
    for (uint32_t group_size : group_sizes()) {
    BuildOptions bo;
    bo.threads = cfg.threads;
    bo.simplifier = variant.simplifier;
    build_detail::InternalBuildOptions internal;
    if (group_size == 0) group_size = build_detail::default_group_target_clusters(variant.simplifier);
    internal.group_target_clusters = group_size;
    internal.simplify_target_ratio = variant.ratio;
    internal.simplify_error_budget = variant.budget;
    internal.leaf_split = internal.group_split = variant.split;
    BuildReport br;
    const double t0 = now_seconds();
    ClusterDag dag = build_detail::build_dag_internal(mesh, bo, internal, &br);
    const double build_s = now_seconds() - t0;
    DagQuality q = measure_dag_quality(dag, cfg.threads);
    add_quality_rows(in.label, variant.label(), std::to_string(group_size), mesh.triangle_count(), dag, q, build_s, t,
                     curve, level_table, rows);
    }
    progress.advance();
  }
  out.tables.push_back(t);
  out.tables.push_back(curve);
  out.tables.push_back(level_table);
  out.data["meshes"] = rows;
}

}  // namespace vgeo::bench
