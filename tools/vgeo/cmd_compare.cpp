// `vgeo compare A B [--mesh N] [--tau PX] [--fail-if EXPR]... [--json F] [--junit F]`: two
// builds (VGEODAG1 or page files) of the same mesh side by side — levels, stored and root
// triangles, triangles of the cut at equal *measured* error (builder-independent: the measured
// hull cut of lib/vgeo/verify/measured_cut.h), ERROR_BOUND violations, the measured/stored error
// distribution, triangles drawn at equal τ by the stored errors over the standard view set
// (what the runtime draws given the builder's claims), file sizes — and `--fail-if` thresholds
// on B against A, so CI can fail a builder change that makes LOD quality or size worse, and a
// builder cannot pass by under-stating its errors. spec/conform.md §2.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "commands.h"
#include "junit.h"
#include "vgeo/core/error.h"
#include "vgeo/core/lod.h"
#include "vgeo/format/asset_file.h"
#include "vgeo/core/file_io.h"
#include "vgeo/verify/measured_cut.h"
#include "vgeo/verify/verify.h"

namespace vgeo::cli {

namespace {

// The standard view set (spec/conform.md §2.1): a pure function of the leaf AABB, so both
// builds of one mesh are cut from the same cameras. 14 directions (6 axes, 8 diagonals) ×
// 4 distances in bounding radii (close, framing, far, very far), 1080 px, 60° field of view.
constexpr double kViewDistancesInRadii[] = {1.5, 3.0, 10.0, 100.0};
constexpr float kViewFovY = 1.0471975511965976f;  // 60°: a common game camera
constexpr float kViewportHeight = 1080.0f;        // 1080p
constexpr double kNearInRadii = 1e-3;             // z_near = 0.001 bounding radii
// Leaf AABBs of two builds of one mesh agree to quantization: the page format stores positions
// on a grid of ≤ 2^-16 of the extent (spec/format.md), so 1e-4 of the diagonal is generous.
constexpr double kSameBoundsRelative = 1e-4;

std::vector<LodView> standard_views(const Aabb& bounds) {
  const double cx = 0.5 * (double(bounds.min.x) + bounds.max.x), cy = 0.5 * (double(bounds.min.y) + bounds.max.y),
               cz = 0.5 * (double(bounds.min.z) + bounds.max.z);
  const double radius = std::max(0.5 * distance_d(bounds.min, bounds.max), double(std::numeric_limits<float>::min()));
  std::vector<std::array<double, 3>> dirs;
  for (int axis = 0; axis < 3; ++axis)
    for (double s : {1.0, -1.0}) {
      std::array<double, 3> d{0, 0, 0};
      d[axis] = s;
      dirs.push_back(d);
    }
  const double k = 1.0 / std::sqrt(3.0);
  for (int i = 0; i < 8; ++i) dirs.push_back({(i & 1 ? -k : k), (i & 2 ? -k : k), (i & 4 ? -k : k)});
  std::vector<LodView> views;
  for (double dist : kViewDistancesInRadii)
    for (const auto& d : dirs) {
      LodView v;
      v.eye = {float(cx + d[0] * dist * radius), float(cy + d[1] * dist * radius), float(cz + d[2] * dist * radius)};
      v.pixels_per_unit_at_1 = lod_projection_scale(kViewFovY, kViewportHeight);
      v.z_near = float(kNearInRadii * radius);
      views.push_back(v);
    }
  return views;
}

// Metric names, in table order (also the names `--fail-if` takes).
// The measured-error cut comes first: it is the quality gate (spec/conform.md §2); the
// stored-error cut `drawn_triangles` trusts each builder's own errors.
const char* const kMetrics[] = {"levels",
                                "clusters",
                                "stored_triangles",
                                "root_clusters",
                                "root_triangles",
                                "file_bytes",
                                "measured_cut_gmean",
                                "measured_cut_1e-3",
                                "measured_cut_1e-2",
                                "error_bound_violations",
                                "drawn_triangles",
                                "error_ratio_median",
                                "error_ratio_p95",
                                "error_ratio_max"};
constexpr size_t kMetricCount = sizeof kMetrics / sizeof kMetrics[0];

struct Summary {
  double value[kMetricCount] = {};
  uint64_t leaf_triangles = 0;
  Aabb bounds;
};

size_t metric_index(const std::string& name) {
  for (size_t i = 0; i < kMetricCount; ++i)
    if (name == kMetrics[i]) return i;
  return kMetricCount;
}

// `diagonal`: the ε unit of the measured cut, A's leaf diagonal for both builds (the same ε).
Summary summarize(const ClusterDag& dag, uint64_t file_bytes, const std::vector<LodView>& views, float tau,
                  double diagonal, unsigned threads) {
  Summary s;
  uint64_t stored = 0, root_clusters = 0, root_triangles = 0, drawn = 0;
  for (const DagCluster& c : dag.clusters) {
    stored += c.triangle_count;
    if (c.generating_group == kNone) s.leaf_triangles += c.triangle_count;
    if (c.group < dag.groups.size() && (dag.groups[c.group].flags & kGroupTerminal))
      ++root_clusters, root_triangles += c.triangle_count;
  }
  for (const LodView& v : views)
    for (const DagCluster& c : dag.clusters)
      if (lod_selects(c.lod_bounds, c.lod_error, c.parent_bounds, c.parent_error, v, tau)) drawn += c.triangle_count;
  VerifyOptions options;
  options.checks = kCheckStructure | kCheckErrorBound;
  options.threads = threads;
  VerifyReport report = verify_dag(dag, options);
  const DagQuality quality = measure_dag_quality(dag, threads, diagonal);
  const double v[kMetricCount] = {double(dag.level_count),
                                  double(dag.clusters.size()),
                                  double(stored),
                                  double(root_clusters),
                                  double(root_triangles),
                                  double(file_bytes),
                                  quality.cut_curve_geometric_mean,
                                  double(quality.cut_measured[0]),
                                  double(quality.cut_measured[1]),
                                  double(report.count("ERROR_BOUND")),
                                  double(drawn),
                                  report.error_ratio.median,
                                  report.error_ratio.p95,
                                  report.error_ratio.max};
  std::copy(v, v + kMetricCount, s.value);
  s.bounds = dag.bounds;
  return s;
}

double ratio(double a, double b) {
  if (a == b) return 1.0;
  return a == 0 ? std::numeric_limits<double>::infinity() : b / a;
}

// `NAME>X` / `NAME<X`: B/A above / below X fails; `b.NAME>X` / `b.NAME<X`: B's own value.
struct Threshold {
  std::string text;
  size_t metric = 0;
  bool absolute = false, greater = true;
  double limit = 0;
  double observed = 0;
  bool exceeded = false;
};

Threshold parse_threshold(const std::string& text) {
  Threshold t;
  t.text = text;
  size_t op = text.find_first_of("<>");
  std::string name = op == std::string::npos ? text : text.substr(0, op);
  if (name.rfind("b.", 0) == 0) t.absolute = true, name = name.substr(2);
  t.metric = metric_index(name);
  bool ok = op != std::string::npos && t.metric < kMetricCount && op + 1 < text.size();
  if (ok) {
    t.greater = text[op] == '>';
    char* end = nullptr;
    t.limit = std::strtod(text.c_str() + op + 1, &end);
    ok = end && *end == '\0' && std::isfinite(t.limit);
  }
  if (!ok) {
    std::string names;
    for (const char* m : kMetrics) names += std::string(names.empty() ? "" : ", ") + m;
    fail("COMPARE_BAD_THRESHOLD", "vgeo compare",
         "--fail-if '" + text + "': expected [b.]METRIC>NUMBER or [b.]METRIC<NUMBER with METRIC one of " + names,
         kExitUsage);
  }
  return t;
}

std::string number_text(double v) {
  char buf[48];
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  if (v == std::floor(v) && std::fabs(v) < 1e15) std::snprintf(buf, sizeof buf, "%.0f", v);
  else std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

struct CompareArgs {
  std::string a, b, json_path, junit_path;
  std::vector<std::string> fail_if;
  uint32_t mesh = 0;
  float tau = 1.0f;
  unsigned threads = 0;
  bool quiet = false;
};

ClusterDag load_mesh(const std::string& path, uint32_t mesh) {
  BuiltScene scene = read_asset_file(path);  // throws VgeoError with the decoder's code
  if (mesh >= scene.meshes.size())
    fail("COMPARE_NO_MESH", path, "has " + std::to_string(scene.meshes.size()) + " mesh(es), no mesh " +
         std::to_string(mesh), kExitBadInput);
  return std::move(scene.meshes[mesh]);
}

bool same_mesh(const Summary& a, const Summary& b, std::string* why) {
  if (a.leaf_triangles != b.leaf_triangles) {
    *why = "leaf triangles differ (" + std::to_string(a.leaf_triangles) + " vs " + std::to_string(b.leaf_triangles) + ")";
    return false;
  }
  const double tol = kSameBoundsRelative * distance_d(a.bounds.min, a.bounds.max);
  const float av[6] = {a.bounds.min.x, a.bounds.min.y, a.bounds.min.z, a.bounds.max.x, a.bounds.max.y, a.bounds.max.z};
  const float bv[6] = {b.bounds.min.x, b.bounds.min.y, b.bounds.min.z, b.bounds.max.x, b.bounds.max.y, b.bounds.max.z};
  for (int i = 0; i < 6; ++i)
    if (!(std::fabs(double(av[i]) - double(bv[i])) <= tol)) {
      *why = "leaf bounds differ by more than 1e-4 of the diagonal";
      return false;
    }
  return true;
}

int run_compare(const CompareArgs& args) {
  if (!(args.tau > 0) || !std::isfinite(args.tau))
    fail("COMPARE_BAD_THRESHOLD", "vgeo compare", "--tau must be a positive number of pixels", kExitUsage);
  std::vector<Threshold> thresholds;
  for (const std::string& t : args.fail_if) thresholds.push_back(parse_threshold(t));

  ClusterDag dag_a = load_mesh(args.a, args.mesh), dag_b = load_mesh(args.b, args.mesh);
  const std::vector<LodView> views = standard_views(dag_a.bounds);
  const double diagonal = distance_d(dag_a.bounds.min, dag_a.bounds.max);
  Summary a = summarize(dag_a, std::filesystem::file_size(args.a), views, args.tau, diagonal, args.threads);
  Summary b = summarize(dag_b, std::filesystem::file_size(args.b), views, args.tau, diagonal, args.threads);
  const std::string suite_name = args.a + " vs " + args.b;

  std::string why;
  if (!same_mesh(a, b, &why)) {
    if (!args.junit_path.empty()) {
      JunitCase tc = junit_case("vgeo.compare", "same_mesh");
      tc.failed = true;
      tc.failure_type = "COMPARE_NOT_SAME_MESH";
      tc.failure_message = why;
      write_junit(args.junit_path, "vgeo compare", {JunitSuite{suite_name, {tc}}});
    }
    fail("COMPARE_NOT_SAME_MESH", args.b, "is not a build of " + args.a + "'s mesh: " + why, kExitBadInput);
  }

  bool exceeded = false;
  for (Threshold& t : thresholds) {
    t.observed = t.absolute ? b.value[t.metric] : ratio(a.value[t.metric], b.value[t.metric]);
    t.exceeded = t.greater ? !(t.observed <= t.limit) : !(t.observed >= t.limit);
    exceeded |= t.exceeded;
  }

  if (!args.quiet) {
    std::printf("A: %s\nB: %s\nmesh %u\n", args.a.c_str(), args.b.c_str(), args.mesh);
    std::printf("measured_cut_*: triangles of the cut at equal MEASURED error (deviation from the leaves, whatever the\n"
                "  builder claims; eps = 1e-3 and 1e-2 of A's diagonal %s, gmean over 17 eps in between): the quality gate\n",
                number_text(diagonal).c_str());
    std::printf("drawn_triangles: the cut by STORED errors over %zu standard views at tau %s px, summed: what the runtime\n"
                "  draws given the builder's claims (fewer when a builder under-states its errors)\n",
                views.size(), number_text(args.tau).c_str());
    std::printf("  %-24s %14s %14s %9s\n", "metric", "A", "B", "B/A");
    for (size_t i = 0; i < kMetricCount; ++i)
      std::printf("  %-24s %14s %14s %9s\n", kMetrics[i], number_text(a.value[i]).c_str(),
                  number_text(b.value[i]).c_str(), number_text(ratio(a.value[i], b.value[i])).c_str());
    for (const Threshold& t : thresholds)
      std::printf("  fail-if %s: %s %s -> %s\n", t.text.c_str(), t.absolute ? "B =" : "B/A =",
                  number_text(t.observed).c_str(), t.exceeded ? "EXCEEDED" : "ok");
  }

  if (!args.json_path.empty()) {
    nlohmann::json j{{"a", args.a},   {"b", args.b},         {"mesh", args.mesh},
                     {"tau", args.tau}, {"views", views.size()}, {"measured_cut_diagonal", diagonal}};
    auto num = [](double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(v > 0 ? "inf" : "-inf"); };
    for (size_t i = 0; i < kMetricCount; ++i) {
      j["metrics"][kMetrics[i]] = {{"a", num(a.value[i])}, {"b", num(b.value[i])}, {"ratio", num(ratio(a.value[i], b.value[i]))}};
    }
    j["thresholds"] = nlohmann::json::array();
    for (const Threshold& t : thresholds)
      j["thresholds"].push_back({{"expression", t.text}, {"observed", num(t.observed)}, {"exceeded", t.exceeded}});
    j["ok"] = !exceeded;
    std::string text = j.dump(2) + "\n";
    write_file_atomic(args.json_path, text);
  }
  if (!args.junit_path.empty()) {
    JunitSuite suite{suite_name, {junit_case("vgeo.compare", "same_mesh")}};
    for (const Threshold& t : thresholds) {
      JunitCase tc = junit_case("vgeo.compare", "fail-if " + t.text);
      if (t.exceeded) {
        tc.failed = true;
        tc.failure_type = "COMPARE_THRESHOLD";
        tc.failure_message = t.text + ": " + (t.absolute ? "B = " : "B/A = ") + number_text(t.observed);
      }
      suite.cases.push_back(std::move(tc));
    }
    write_junit(args.junit_path, "vgeo compare", {suite});
  }
  return exceeded ? kExitInvariantViolation : kExitOk;
}

}  // namespace

void add_compare_command(CLI::App& app, Context& ctx) {
  auto args = std::make_shared<CompareArgs>();
  auto* cmd = app.add_subcommand("compare", "compare two builds of one mesh: LOD quality and size, with CI thresholds");
  cmd->add_option("a", args->a, "reference build (VGEODAG1 or page file)")->required();
  cmd->add_option("b", args->b, "candidate build of the same mesh")->required();
  cmd->add_option("--mesh", args->mesh, "mesh index in both files (default 0)");
  cmd->add_option("--tau", args->tau, "pixel threshold of the cuts over the standard views (default 1)");
  cmd->add_option("--fail-if", args->fail_if,
                  "exit 1 when [b.]METRIC>X or [b.]METRIC<X holds (ratio B/A, or B's value with b.); repeatable");
  cmd->add_option("--threads", args->threads, "worker threads of the error measurement (0 = all cores)");
  cmd->add_option("--json", args->json_path, "write both summaries, ratios and thresholds as JSON");
  cmd->add_option("--junit", args->junit_path, "write a JUnit XML report (one testcase per --fail-if)");
  cmd->add_flag("--quiet", args->quiet, "print nothing; rely on the exit code");
  cmd->callback([args, &ctx] { ctx.exit_code = run_compare(*args); });
}

}  // namespace vgeo::cli
