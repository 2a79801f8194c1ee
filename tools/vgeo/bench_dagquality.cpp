// Suite "dagquality": how many triangles a DAG needs at a given *measured* error, whatever
// built it (issue 15 §2). Per cluster, the deviation from the leaves is measured on the
// verify lattice (measure_cluster_deviation, the ERROR_BOUND measurement); a monotone hull
// takes the maximum up the DAG, and the cut at ε draws a cluster when its hull ≤ ε < its
// group's parents' hull. Reported: triangles in the cuts at ε = 1e-3 and 1e-2 of the mesh
// diagonal (also the cut by *stored* error at the same ε, what lod_selects would draw), the
// measured/stored error ratios, levels, stored ×, roots.
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <sstream>

#include "bench_suites.h"
#include "vgeo/core/progress.h"
#include "vgeo/dag/build.h"
#include "vgeo/dag/build_internal.h"
#include "vgeo/mesh/generate.h"
#include "vgeo/mesh/import.h"
#include "vgeo/verify/verify.h"

namespace vgeo::bench {

struct DagQuality {
  uint64_t cut_measured[2] = {0, 0};  // triangles of the measured-hull cut at kCutEpsilons
  uint64_t cut_stored[2] = {0, 0};    // triangles of the stored-error cut at kCutEpsilons
  std::vector<double> ratios;         // measured / stored lod_error, non-leaf clusters
  uint64_t roots = 0, root_triangles = 0;
  std::vector<uint64_t> cut_curve;    // measured-hull cut at curve_epsilon(i)
  struct Level {
    uint64_t clusters = 0, triangles = 0;
    double hull_median = 0;  // of its clusters' measured hull, / diagonal
  };
  std::vector<Level> levels;  // by DAG level (of the cluster's group)
};

namespace {

// Cut errors as fractions of the mesh diagonal (issue 15 §2).
constexpr double kCutEpsilons[2] = {1e-3, 1e-2};
// The cut as a curve over eps: a DAG's levels halve the triangle count, so the cut at one eps
// jumps by up to 2x as eps crosses a level's typical hull (a sawtooth); two builders compared
// at one eps compare where their sawteeth fall. kCurvePoints log-spaced eps from 1e-3 to 1e-2
// (16 steps per decade: finer than one level's 2x error step) give the curve and its
// geometric mean, which averages the sawtooth out.
constexpr int kCurvePoints = 17;
double curve_epsilon(int i) { return 1e-3 * std::pow(10.0, double(i) / (kCurvePoints - 1)); }

double diagonal(const ClusterDag& dag) {
  double d2 = 0;
  for (int k = 0; k < 3; ++k) {
    double e = double(dag.bounds.max[k]) - dag.bounds.min[k];
    d2 += e * e;
  }
  return std::sqrt(d2);
}

// Triangles of the cut that draws cluster c iff self(c) ≤ eps < parent(group(c)).
uint64_t cut_triangles(const ClusterDag& dag, const std::vector<double>& self, const std::vector<double>& parent,
                       double eps) {
  uint64_t tris = 0;
  for (size_t c = 0; c < dag.clusters.size(); ++c)
    if (self[c] <= eps && eps < parent[dag.clusters[c].group]) tris += dag.clusters[c].triangle_count;
  return tris;
}

}  // namespace

DagQuality measure_dag_quality(const ClusterDag& dag, unsigned threads) {
  DagQuality q;
  VerifyOptions vo;
  vo.threads = threads;
  const ClusterDeviation dev = measure_cluster_deviation(dag, vo);
  const size_t ng = dag.groups.size(), nc = dag.clusters.size();
  // Hull of the clusters each group generated: max of their own deviation and the hull of
  // the group's members (groups by increasing level: members come from lower levels).
  std::vector<uint32_t> order(ng);
  for (size_t g = 0; g < ng; ++g) order[g] = uint32_t(g);
  std::stable_sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) { return dag.groups[a].level < dag.groups[b].level; });
  std::vector<double> generated_hull(ng, 0.0), self_hull(nc, 0.0);
  for (uint32_t g : order) {
    const DagGroup& G = dag.groups[g];
    double h = 0;
    for (uint32_t c = G.first_cluster; c < G.first_cluster + G.cluster_count; ++c) h = std::max(h, self_hull[c]);
    for (uint32_t i = 0; i < G.generated_count; ++i) h = std::max(h, dev.distance[dag.generated_clusters[G.first_generated + i]]);
    generated_hull[g] = h;
    for (uint32_t i = 0; i < G.generated_count; ++i) self_hull[dag.generated_clusters[G.first_generated + i]] = h;
  }
  const double inf = std::numeric_limits<double>::infinity();
  std::vector<double> parent_hull(ng), parent_stored(ng), self_stored(nc);
  for (size_t g = 0; g < ng; ++g) {
    const bool terminal = dag.groups[g].generated_count == 0;
    parent_hull[g] = terminal ? inf : generated_hull[g];
    parent_stored[g] = terminal ? inf : double(dag.groups[g].parent_error);
  }
  for (size_t c = 0; c < nc; ++c) {
    const DagCluster& k = dag.clusters[c];
    self_stored[c] = k.generating_group == kNone ? 0.0 : double(k.lod_error);
    if (k.generating_group != kNone && k.lod_error > 0 && std::isfinite(k.lod_error))
      q.ratios.push_back(dev.distance[c] / k.lod_error);
    if (dag.groups[k.group].generated_count == 0) ++q.roots, q.root_triangles += k.triangle_count;
  }
  const double diag = diagonal(dag);
  for (int e = 0; e < 2; ++e) {
    q.cut_measured[e] = cut_triangles(dag, self_hull, parent_hull, kCutEpsilons[e] * diag);
    q.cut_stored[e] = cut_triangles(dag, self_stored, parent_stored, kCutEpsilons[e] * diag);
  }
  for (int i = 0; i < kCurvePoints; ++i) q.cut_curve.push_back(cut_triangles(dag, self_hull, parent_hull, curve_epsilon(i) * diag));
  std::vector<std::vector<double>> level_hulls;
  for (size_t c = 0; c < nc; ++c) {
    const uint32_t level = dag.groups[dag.clusters[c].group].level;
    if (level >= q.levels.size()) q.levels.resize(level + 1), level_hulls.resize(level + 1);
    ++q.levels[level].clusters;
    q.levels[level].triangles += dag.clusters[c].triangle_count;
    level_hulls[level].push_back(self_hull[c] / diag);
  }
  for (size_t l = 0; l < q.levels.size(); ++l) {
    std::vector<double>& h = level_hulls[l];
    if (h.empty()) continue;
    std::nth_element(h.begin(), h.begin() + h.size() / 2, h.end());
    q.levels[l].hull_median = h[h.size() / 2];
  }
  return q;
}

namespace {

struct QualityInput {
  std::string label;
  std::string path;           // a mesh file, or empty: generated
  uint64_t gen_triangles = 0; // `vgeo gen sphere --triangles N --seed 1`
};

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
  // The CGAL meshes of issue 15 §2, when tools/fetch-data has fetched them.
  for (const char* name : {"bunny00", "armadillo", "refined_elephant", "mech-holes-shark"}) {
    std::string p = std::string("data/cgal/meshes/") + name + ".off";
    if (std::filesystem::exists(p)) in.push_back({name, p, 0});
  }
  return in;
}

// VGEO_DAGQUALITY_GROUP_SIZES: comma-separated kGroupTargetClusters values to compare
// (issue 15 §2 asks for 8..32); default: the builder's.
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
    if (split == build_detail::SplitMethod::kGrow) l += " grow";
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

}  // namespace

void run_dagquality_suite(const BenchConfig& cfg, SuiteReport& out) {
  out.ran = true;
  out.summary =
      "Triangles a DAG needs at equal *measured* error (builder-independent: only the DAG is read). Every non-leaf "
      "cluster's deviation from the leaves is measured on the verify lattice (lib/vgeo/verify "
      "measure_cluster_deviation); a monotone hull takes the maximum up the DAG; the cut at eps draws a cluster when "
      "its hull <= eps < its group's parents' hull (terminal groups: +inf). eps = 1e-3 and 1e-2 of the mesh "
      "diagonal. 'stored cut' is the same cut with the stored lod_error/parent_error (what the runtime draws). "
      "Inputs: `vgeo gen sphere --seed 1` meshes and CGAL meshes from data/ (VGEO_DAGQUALITY_INPUTS overrides).";
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
    Mesh mesh;
    if (in.path.empty()) {
      GenerateOptions g;
      g.shape = GenShape::kSphere;
      g.target_triangles = in.gen_triangles;
      g.seed = 1;
      mesh = generate_mesh(g);
      out.inputs.push_back(in.label + ": vgeo gen sphere --triangles " + std::to_string(in.gen_triangles) + " --seed 1");
    } else {
      // An input that does not import is noted, not a reason to lose the other rows.
      try {
        ImportResult r = import_scene(in.path);
        if (r.scene.meshes.empty()) continue;
        mesh = std::move(r.scene.meshes[0]);
      } catch (const VgeoError& e) {
        out.notes.push_back(in.label + ": not measured: " + e.error().line());
        continue;
      }
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
    const double stored_x = double(dag.triangle_count()) / double(mesh.triangle_count());
    t.rows.push_back({in.label, variant.label(), std::to_string(group_size), std::to_string(mesh.triangle_count()), std::to_string(q.cut_measured[0]),
                      std::to_string(q.cut_measured[1]), std::to_string(q.cut_stored[0]), std::to_string(q.cut_stored[1]),
                      median_str(q.ratios, 0.5), median_str(q.ratios, 0.05), median_str(q.ratios, 1.0),
                      std::to_string(dag.level_count), fmt(stored_x), std::to_string(q.roots), fmt(build_s)});
    {
      std::vector<std::string> row{in.label, variant.label(), std::to_string(group_size)};
      for (int i : {0, 2, 4, 6, 8, 12, 16}) row.push_back(std::to_string(q.cut_curve[size_t(i)]));
      double log_sum = 0;
      for (uint64_t c : q.cut_curve) log_sum += std::log(double(std::max<uint64_t>(c, 1)));
      row.push_back(std::to_string(*std::min_element(q.cut_curve.begin(), q.cut_curve.end())));
      row.push_back(std::to_string(*std::max_element(q.cut_curve.begin(), q.cut_curve.end())));
      row.push_back(std::to_string(uint64_t(std::llround(std::exp(log_sum / kCurvePoints)))));
      curve.rows.push_back(row);
      std::string ladder;
      for (size_t l = 0; l < q.levels.size(); ++l)
        if (q.levels[l].triangles)
          ladder += (ladder.empty() ? "" : ", ") + std::to_string(l) + ": " + std::to_string(q.levels[l].triangles) + " @ " +
                    fmt(q.levels[l].hull_median);
      level_table.rows.push_back({in.label, variant.label(), std::to_string(group_size), ladder});
    }
    nlohmann::json curve_json = nlohmann::json::array(), levels_json = nlohmann::json::array();
    for (int i = 0; i < kCurvePoints; ++i) curve_json.push_back({{"eps", curve_epsilon(i)}, {"triangles", q.cut_curve[size_t(i)]}});
    for (const DagQuality::Level& l : q.levels)
      levels_json.push_back({{"clusters", l.clusters}, {"triangles", l.triangles}, {"hull_median", l.hull_median}});
    rows.push_back({{"mesh", in.label},
                    {"builder", variant.label()},
                    {"group_target_clusters", group_size},
                    {"input_triangles", mesh.triangle_count()},
                    {"cut_measured_1e-3", q.cut_measured[0]},
                    {"cut_measured_1e-2", q.cut_measured[1]},
                    {"cut_stored_1e-3", q.cut_stored[0]},
                    {"cut_stored_1e-2", q.cut_stored[1]},
                    {"ratio_median", q.ratios.empty() ? 0.0 : std::stod(median_str(q.ratios, 0.5))},
                    {"levels", dag.level_count},
                    {"stored_x", stored_x},
                    {"roots", q.roots},
                    {"root_triangles", q.root_triangles},
                    {"build_seconds", build_s},
                    {"cut_curve", curve_json},
                    {"levels_by_hull", levels_json}});
    }
    progress.advance();
  }
  out.tables.push_back(t);
  out.tables.push_back(curve);
  out.tables.push_back(level_table);
  out.data["meshes"] = rows;
}

}  // namespace vgeo::bench
