// LOD-selection vectors (spec/vectors/lod/, spec/conform.md §3): (DAG, view, τ[, residency]) →
// the exact selected cluster set, computed with the one predicate (lib/vgeo/core/lod.h via
// select_resident_cut, spec/stream.md §Cut). This test regenerates the manifest from the
// committed DAG and requires it to equal the committed one; refresh after a deliberate change:
//   VGEO_UPDATE_VECTORS=1 build/release/tests/test_conform --gtest_filter=LodVectors.*
// It also drives `vgeo conform lod` with the reference selections (all agree) and with broken
// runtimes (ties decided with ≥, residency ignored, a cluster dropped): each disagreement found.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <map>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "conform/junit_check.h"
#include "support/paths.h"
#include "support/run_command.h"
#include "vgeo/core/lod.h"
#include "vgeo/dag/build.h"
#include "vgeo/dag/dag_io.h"
#include "vgeo/mesh/generate.h"
#include "vgeo/stream/stream.h"

namespace fs = std::filesystem;
using namespace vgeo;

namespace {

const fs::path kDir = test::source_dir() / "spec" / "vectors" / "lod";
constexpr const char* kDagName = "terrain.vgeodag";
constexpr uint64_t kDagTriangles = 2000;  // 30 clusters, 5 groups over 4 levels: small, every level present
// Exact-tie views: z_near ≥ 4 bounding radii while every sphere's d - r from the centre is at
// most ~1 radius, so the near clamp decides every denominator with a margin no rounding reaches.
constexpr double kExactTieNearInRadii = 4.0;

bool updating() {
  const char* u = std::getenv("VGEO_UPDATE_VECTORS");
  return u && std::string(u) == "1";
}

struct Vector {
  std::string name, kind, what;
  LodView view;
  float tau = 1.0f;
  bool has_residency = false;
  std::vector<uint8_t> resident;  // per group
};

// Every vector of the set, derived from the DAG alone (so the set is reproducible).
std::vector<Vector> make_vectors(const ClusterDag& dag) {
  const Vec3 lo = dag.bounds.min, hi = dag.bounds.max;
  const Vec3 centre{(lo.x + hi.x) * 0.5f, (lo.y + hi.y) * 0.5f, (lo.z + hi.z) * 0.5f};
  const float radius = float(0.5 * distance_d(lo, hi));
  const float scale = lod_projection_scale(1.0471975511965976f, 1080.0f);  // 60°, 1080 px
  auto view_at = [&](Vec3 eye, float z_near) {
    LodView v;
    v.eye = eye;
    v.pixels_per_unit_at_1 = scale;
    v.z_near = z_near;
    return v;
  };
  auto offset = [&](float dx, float dy, float dz) { return Vec3{centre.x + dx, centre.y + dy, centre.z + dz}; };
  const float diag = 3.0f * radius / std::sqrt(3.0f);
  const LodView framing = view_at(offset(diag, diag, diag), 0.01f * radius);
  std::vector<Vector> out;
  auto add = [&](std::string name, std::string kind, std::string what, LodView v, float tau) {
    Vector x;
    x.name = std::move(name), x.kind = std::move(kind), x.what = std::move(what), x.view = v, x.tau = tau;
    out.push_back(x);
    return &out.back();
  };
  // A threshold that cuts this view's DAG across the leaf groups: the geometric mean of the
  // smallest and largest projected parent error of the leaves (strictly between them when they
  // differ, so leaves near the eye refine and far ones do not; never a tie unless all are equal).
  auto mid_tau = [&](const LodView& v) {
    double lo = INFINITY, hi = 0;
    for (const DagCluster& c : dag.clusters)
      if (c.level == 0 && std::isfinite(c.parent_error)) {
        double e = projected_error(c.parent_bounds, c.parent_error, v);
        lo = std::min(lo, e), hi = std::max(hi, e);
      }
    return hi > 0 ? float(std::sqrt(lo * hi)) : 1.0f;
  };
  auto add_mid = [&](std::string name, std::string what, LodView v) {
    return add(std::move(name), "plain", std::move(what) + "; tau between the leaves' projected parent errors", v,
               mid_tau(v));
  };
  // First non-leaf cluster of a level (a cluster whose sphere the special eyes use).
  auto first_of_level = [&](uint32_t level) -> const DagCluster& {
    for (const DagCluster& c : dag.clusters)
      if (c.level == level) return c;
    return dag.clusters.front();
  };
  add_mid("framing_mid", "eye 3 bounding radii away on the diagonal", framing);
  add("framing_tau1", "plain", "as framing_mid with tau 1 px (a fine cut)", framing, 1.0f);
  add_mid("close_1.5_radii", "eye 1.5 bounding radii from the centre along +z",
          view_at(offset(0, 0, 1.5f * radius), 0.01f * radius));
  add("far_1e4_radii", "plain", "eye 10^4 bounding radii away, tau 1 px: only coarse clusters",
      view_at(offset(0, 0, 1e4f * radius), 0.01f * radius), 1.0f);
  add("very_far_1e30", "plain",
      "eye at x = 1e30, tau 1 px: the roots (binary32 runtimes: |E - c| must not overflow, spec/conform.md §3.1)",
      view_at(Vec3{1e30f, 0, 0}, 0.01f * radius), 1.0f);
  add("tau_tiny", "plain", "tau 1e-6 px: the leaves", framing, 1e-6f);
  add("tau_huge", "plain", "tau 1e30 px: the roots", framing, 1e30f);
  {
    const DagCluster& c = first_of_level(1);
    add_mid("eye_at_lod_sphere_centre", "distance 0: the eye at the centre of a level-1 cluster's lod_bounds",
            view_at(c.lod_bounds.center, 0.01f * radius));
    const Sphere& p = first_of_level(0).parent_bounds;
    add_mid("eye_inside_parent_sphere", "the eye halfway inside a leaf's parent_bounds (d - r < 0)",
            view_at(Vec3{p.center.x + 0.5f * p.radius, p.center.y, p.center.z}, 0.01f * radius));
    add_mid("eye_on_surface", "the eye at a leaf vertex (on the mesh)", view_at(dag.position(0), 0.01f * radius));
  }
  {
    // d - r of one sphere equal to z_near (the near-plane clamp decides at its boundary).
    const Sphere& s = first_of_level(1).parent_bounds;
    const Vec3 eye = offset(0, 2.0f * radius, 0);
    const float z_near = float(distance_d(s.center, eye) - double(s.radius));
    add_mid("near_plane_boundary", "z_near = d - r of a level-1 cluster's parent_bounds (as float)", view_at(eye, z_near));
    add_mid("near_plane_beyond_mesh", "z_near 10 bounding radii: every denominator is z_near",
            view_at(offset(0, 0, 1.5f * radius), 10.0f * radius));
  }
  // Ties: tau exactly a cluster's projected parent error (that cluster fails `> tau`, its
  // generated clusters pass `<= tau`).
  for (uint32_t level = 0; level + 1 < dag.level_count && level < 3; ++level) {
    const DagCluster& c = first_of_level(level);
    if (!std::isfinite(c.parent_error)) continue;
    const float tau = projected_error(c.parent_bounds, c.parent_error, framing);
    add("tie_level" + std::to_string(level), "tie",
        "tau = the projected parent error of the first level-" + std::to_string(level) + " cluster (lod.h arithmetic)",
        framing, tau);
  }
  // Exact ties: τ equals a projected error that every IEEE arithmetic
  // computes exactly, so a mismatch cannot be rounding. The eye sits at the DAG's centre and
  // z_near is a power of two ≥ kExactTieNearInRadii bounding radii, so d - r ≤ ~1 radius is far
  // below z_near for every sphere and every denominator is z_near itself; k = 1. Then
  // projected = error·1/z_near is a scaling by a power of two: exact in binary32 and binary64,
  // whatever the evaluation order or the distance's rounding.
  {
    const double z_near = std::exp2(std::ceil(std::log2(kExactTieNearInRadii * double(radius))));
    LodView exact;
    exact.eye = centre;
    exact.pixels_per_unit_at_1 = 1.0f;
    exact.z_near = float(z_near);
    for (uint32_t level = 0; level + 1 < dag.level_count && level < 3; ++level) {
      const DagCluster& c = first_of_level(level);
      if (!std::isfinite(c.parent_error)) continue;
      const float tau = projected_error(c.parent_bounds, c.parent_error, exact);
      add("exact_tie_level" + std::to_string(level), "exact_tie",
          "tau = the projected parent error of the first level-" + std::to_string(level) +
              " cluster, with k = 1 and every denominator clamped to z_near (a power of two): exact in every "
              "IEEE arithmetic, so a mismatch is a comparison bug (>= for >, < for <=), never rounding",
          exact, tau);
    }
  }
  // Residency (spec/stream.md §Usable groups, §Cut).
  const uint32_t ng = uint32_t(dag.groups.size());
  auto residency = [&](std::string name, std::string what, std::vector<uint8_t> resident) {
    Vector* v = add(std::move(name), "residency", std::move(what), framing, 1.0f);
    v->has_residency = true;
    v->resident = std::move(resident);
    return v;
  };
  residency("resident_all", "every group resident: the plain cut", std::vector<uint8_t>(ng, 1));
  {
    std::vector<uint8_t> r(ng, 0);
    for (uint32_t g = 0; g < ng; ++g) r[g] = (dag.groups[g].flags & kGroupTerminal) ? 1 : 0;
    residency("resident_roots_only", "only terminal groups resident: the roots", r);
  }
  {
    std::vector<uint8_t> r(ng, 1);
    r[0] = 0;
    residency("resident_missing_leaf_group", "group 0 (level 0) missing: drawn at its generated clusters", r);
  }
  {
    std::vector<uint8_t> r(ng, 1);
    for (uint32_t g = 0; g < ng; ++g)
      if (dag.groups[g].level == 1) {
        r[g] = 0;
        break;
      }
    residency("resident_missing_level1_group",
              "the first level-1 group missing: the leaf groups below it are unusable too (fixed point)", r);
  }
  // Depth ≥ 2: a level-2 group missing makes the level-1 groups below it
  // unusable and, through them, the leaf groups two levels down, although each leaf group and
  // its own parent group are resident. A selector that checks "resident and parent resident"
  // (one level) draws those leaves together with coarser clusters; the transitive closure of
  // spec/stream.md §Usable groups does not.
  for (uint32_t g = 0; g < ng; ++g)
    if (dag.groups[g].level == 2 && !(dag.groups[g].flags & kGroupTerminal)) {
      std::vector<uint8_t> r(ng, 1);
      r[g] = 0;
      residency("resident_missing_level2_group",
                "the first non-terminal level-2 group missing: the level-1 groups below it and the leaf groups below "
                "those are unusable (transitive closure, depth 2), although every leaf group and its parent are resident",
                r);
      break;
    }
  return out;
}

std::vector<uint32_t> expected_of(const ClusterDag& dag, const Vector& v) {
  std::vector<uint8_t> usable = v.has_residency ? usable_groups_of_resident(dag, v.resident)
                                                : std::vector<uint8_t>(dag.groups.size(), 1);
  return select_resident_cut(dag, usable, v.view, v.tau);
}

nlohmann::json manifest_of(const ClusterDag& dag) {
  nlohmann::json m{{"format", "vgeo-lod-vectors"}, {"version", 1}, {"dag", kDagName}, {"mesh", 0},
                   {"clusters", dag.clusters.size()}, {"groups", dag.groups.size()}};
  nlohmann::json vectors = nlohmann::json::array();
  for (const Vector& v : make_vectors(dag)) {
    // Floats are stored as the doubles they convert to exactly (17 significant digits).
    nlohmann::json j{{"name", v.name}, {"kind", v.kind}, {"what", v.what},
                     {"eye", {double(v.view.eye.x), double(v.view.eye.y), double(v.view.eye.z)}},
                     {"pixels_per_unit_at_1", double(v.view.pixels_per_unit_at_1)},
                     {"z_near", double(v.view.z_near)}, {"tau", double(v.tau)}};
    if (v.has_residency) {
      nlohmann::json resident = nlohmann::json::array();
      for (uint32_t g = 0; g < v.resident.size(); ++g)
        if (v.resident[g]) resident.push_back(g);
      j["resident_groups"] = resident;
    }
    j["expected"] = expected_of(dag, v);
    vectors.push_back(j);
  }
  m["vectors"] = vectors;
  return m;
}

ClusterDag committed_dag() {
  const fs::path path = kDir / kDagName;
  if (updating() && !fs::exists(path)) {
    GenerateOptions gen;
    gen.shape = GenShape::kTerrain;  // a heightfield: errors vary across the mesh, so cuts mix levels
    gen.target_triangles = kDagTriangles;
    BuiltScene scene = build_scene(generate_scene(gen), BuildOptions{});
    fs::create_directories(kDir);
    write_dag_file(path.string(), scene);
  }
  return read_dag_file(path.string()).meshes.at(0);
}

TEST(LodVectors, CommittedManifestIsTheLodPredicate) {
  ClusterDag dag = committed_dag();
  nlohmann::json generated = manifest_of(dag);
  const fs::path path = kDir / "manifest.json";
  if (updating()) {
    std::ofstream(path) << generated.dump(1) << "\n";
  }
  std::ifstream f(path);
  ASSERT_TRUE(f) << path << " missing (VGEO_UPDATE_VECTORS=1 writes it)";
  nlohmann::json committed = nlohmann::json::parse(f);
  EXPECT_EQ(committed, generated) << "spec/vectors/lod/manifest.json differs from lod.h on the committed DAG";

  // The set exercises what it claims: ties change the answer against `>=`, residency changes
  // the cut, the far/huge vectors select roots only and tau_tiny the leaves only.
  std::map<std::string, nlohmann::json> by_name;
  for (const auto& v : generated["vectors"]) by_name[v["name"]] = v;
  EXPECT_EQ(generated["vectors"].size(), 23u);  // 12 plain, 3 ties, 3 exact ties, 5 residency
  EXPECT_NE(by_name["resident_roots_only"]["expected"], by_name["resident_all"]["expected"]);
  EXPECT_NE(by_name["resident_missing_level1_group"]["expected"], by_name["resident_all"]["expected"]);
  EXPECT_EQ(by_name["resident_all"]["expected"], by_name["framing_tau1"]["expected"]);
  EXPECT_NE(by_name["framing_mid"]["expected"], by_name["framing_tau1"]["expected"]);
  EXPECT_NE(by_name["resident_missing_leaf_group"]["expected"], by_name["resident_all"]["expected"]);
  EXPECT_NE(by_name["resident_missing_level2_group"]["expected"], by_name["resident_all"]["expected"]);
  for (uint32_t c : by_name["tau_tiny"]["expected"]) EXPECT_EQ(dag.clusters[c].level, 0u);
  // Exact ties hold what their kind claims (spec/conform.md §3.1): k = 1, z_near a power of two,
  // every sphere's d - r at most half of z_near (so any rounding of the distance still clamps),
  // τ·z_near is a stored parent error bit for bit, and the tie changes the answer.
  int exact = 0;
  for (const Vector& v : make_vectors(dag)) {
    if (v.kind != "exact_tie") continue;
    ++exact;
    int exponent = 0;
    EXPECT_EQ(v.view.pixels_per_unit_at_1, 1.0f) << v.name;
    EXPECT_EQ(std::frexp(v.view.z_near, &exponent), 0.5f) << v.name;
    for (const DagCluster& c : dag.clusters)
      for (const Sphere* sphere : {&c.lod_bounds, &c.parent_bounds})
        EXPECT_LE(distance_d(sphere->center, v.view.eye) - double(sphere->radius), 0.5 * double(v.view.z_near)) << v.name;
    const double error = double(v.tau) * double(v.view.z_near);
    EXPECT_TRUE(std::any_of(dag.clusters.begin(), dag.clusters.end(),
                            [&](const DagCluster& c) { return double(c.parent_error) == error; })) << v.name;
  }
  EXPECT_EQ(exact, 3);
  for (const char* roots : {"tau_huge", "very_far_1e30"})
    for (uint32_t c : by_name[roots]["expected"])
      EXPECT_TRUE(dag.groups[dag.clusters[c].group].flags & kGroupTerminal) << roots;
}

// A selections file as a runtime writes it (spec/conform.md §3.2).
std::string selections_text(const nlohmann::json& manifest,
                            const std::function<std::vector<uint32_t>(const nlohmann::json&)>& select) {
  std::ostringstream s;
  s << "# vgeo-lod-selections 1\n";
  for (const auto& v : manifest["vectors"]) {
    s << v["name"].get<std::string>() << ":";
    for (uint32_t c : select(v)) s << " " << c;
    s << "\n";
  }
  return s.str();
}

// A runtime as an outsider might write one, with the mistakes the conformance kit must name.
struct Runtime {
  enum class Arithmetic { kReference, kFloat32, kFloat32Naive } arithmetic = Arithmetic::kReference;
  bool parent_ge = false;         // parent test `>= τ` instead of `> τ`
  bool lod_lt = false;            // lod test `< τ` instead of `<= τ`
  bool one_level_usable = false;  // usable = resident and every parent group resident (not transitive)
};

// binary32 evaluation of the projected error: the distance with the overflow-safe norm
// (scaled by the largest component, spec/conform.md §3.1) or naively (dx² overflows binary32
// beyond |dx| ≈ 1.8e19), then d - r, the near clamp and error·k/d, all in float.
float float32_projected(const Sphere& s, float error, const LodView& v, bool overflow_safe) {
  if (error == 0.0f) return 0.0f;
  const float dx = s.center.x - v.eye.x, dy = s.center.y - v.eye.y, dz = s.center.z - v.eye.z;
  float dist;
  if (overflow_safe) {
    const float m = std::max({std::fabs(dx), std::fabs(dy), std::fabs(dz)});
    const float x = m > 0 ? dx / m : 0.0f, y = m > 0 ? dy / m : 0.0f, z = m > 0 ? dz / m : 0.0f;
    dist = m * std::sqrt(x * x + y * y + z * z);
  } else {
    dist = std::sqrt(dx * dx + dy * dy + dz * dz);
  }
  float d = dist - s.radius;
  if (!(d > v.z_near)) d = v.z_near;
  return error * v.pixels_per_unit_at_1 / d;
}

std::vector<uint32_t> runtime_select(const ClusterDag& dag, const nlohmann::json& v, const Runtime& rt) {
  LodView view;
  view.eye = {float(v["eye"][0].get<double>()), float(v["eye"][1].get<double>()), float(v["eye"][2].get<double>())};
  view.pixels_per_unit_at_1 = float(v["pixels_per_unit_at_1"].get<double>());
  view.z_near = float(v["z_near"].get<double>());
  const float tau = float(v["tau"].get<double>());
  const size_t ng = dag.groups.size();
  std::vector<uint8_t> resident(ng, 1), usable(ng, 1);
  if (v.contains("resident_groups")) {
    resident.assign(ng, 0);
    for (uint32_t g : v["resident_groups"]) resident[g] = 1;
    usable = usable_groups_of_resident(dag, resident);
  }
  if (rt.one_level_usable) {
    for (size_t g = 0; g < ng; ++g) {
      usable[g] = resident[g];
      const DagGroup& G = dag.groups[g];
      for (uint32_t i = 0; i < G.generated_count; ++i)
        if (!resident[dag.clusters[dag.generated_clusters[G.first_generated + i]].group]) usable[g] = 0;
    }
  }
  auto project = [&](const Sphere& s, float e) {
    switch (rt.arithmetic) {
      case Runtime::Arithmetic::kFloat32: return float32_projected(s, e, view, true);
      case Runtime::Arithmetic::kFloat32Naive: return float32_projected(s, e, view, false);
      default: return projected_error(s, e, view);
    }
  };
  std::vector<uint32_t> out;
  for (uint32_t c = 0; c < dag.clusters.size(); ++c) {
    const DagCluster& k = dag.clusters[c];
    const float parent = project(k.parent_bounds, k.parent_error), lod = project(k.lod_bounds, k.lod_error);
    const bool parent_passes = rt.parent_ge ? parent >= tau : parent > tau;
    const bool lod_passes = rt.lod_lt ? lod < tau : lod <= tau;
    const bool finer_unusable = k.generating_group != kNone && !usable[k.generating_group];
    if (usable[k.group] && parent_passes && (lod_passes || finer_unusable)) out.push_back(c);
  }
  return out;
}

TEST(LodVectors, ConformLodFindsBrokenRuntimes) {
  ClusterDag dag = committed_dag();
  std::ifstream f(kDir / "manifest.json");
  nlohmann::json manifest = nlohmann::json::parse(f);
  const fs::path dir = fs::temp_directory_path() / ("vgeo_conform_lod_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  auto run = [&](const std::string& name, const std::string& text, const std::string& extra = "") {
    const fs::path p = dir / name;
    std::ofstream(p) << text;
    return test::run_cli("conform lod --vectors '" + kDir.string() + "' --selections '" + p.string() + "' " + extra);
  };
  auto view_of = [](const nlohmann::json& v) {
    LodView view;
    view.eye = {float(v["eye"][0].get<double>()), float(v["eye"][1].get<double>()), float(v["eye"][2].get<double>())};
    view.pixels_per_unit_at_1 = float(v["pixels_per_unit_at_1"].get<double>());
    view.z_near = float(v["z_near"].get<double>());
    return view;
  };

  // The reference runtime, written by vgeo itself, agrees with every vector.
  const fs::path reference = dir / "reference.txt";
  auto wrote = test::run_cli("conform lod --vectors '" + kDir.string() + "' --write-reference '" + reference.string() + "'");
  ASSERT_EQ(wrote.exit_code, 0) << wrote.output;
  auto same = test::run_cli("conform lod --vectors '" + kDir.string() + "' --selections '" + reference.string() + "'");
  EXPECT_EQ(same.exit_code, 0) << same.output;

  // The reference arithmetic through runtime_select agrees everywhere (the simulation is sound).
  auto reference_rt = run("reference_rt.txt", selections_text(manifest, [&](const nlohmann::json& v) {
                            return runtime_select(dag, v, Runtime{});
                          }));
  EXPECT_EQ(reference_rt.exit_code, 0) << reference_rt.output;

  // Broken 1: ties decided with >= / < (parent test `>= tau`, lod test `< tau`), residency
  // honoured. Every exact tie fails as a comparison-direction bug, named as such; the
  // rounding-sensitive ties fail as tie mismatches that equal the flipped cut.
  Runtime ge_rt;
  ge_rt.parent_ge = ge_rt.lod_lt = true;
  auto ge = run("ties_ge.txt", selections_text(manifest, [&](const nlohmann::json& v) { return runtime_select(dag, v, ge_rt); }),
                "--junit '" + (dir / "ge.xml").string() + "'");
  EXPECT_EQ(ge.exit_code, 1) << ge.output;
  std::string cases = test::checked_junit((dir / "ge.xml").string());
  for (const auto& v : manifest["vectors"]) {
    const std::string name = v["name"];
    if (v["kind"] == "tie") {
      EXPECT_NE(cases.find("." + name + ": failed CONFORM_LOD_TIE_MISMATCH"), std::string::npos) << name << "\n" << cases;
    } else if (v["kind"] == "exact_tie") {
      EXPECT_NE(cases.find("." + name + ": failed CONFORM_LOD_TIE_DIRECTION"), std::string::npos) << name << "\n" << cases;
    } else if (name.rfind("framing", 0) == 0 || name.rfind("far", 0) == 0) {
      EXPECT_NE(cases.find("." + name + ": passed"), std::string::npos) << name << "\n" << cases;
    }
  }
  EXPECT_NE(ge.output.find("the selection is the cut with proj(parent) >= tau and proj(lod) < tau"), std::string::npos)
      << ge.output;
  EXPECT_NE(ge.output.find("exact ties: 3 of 3 disagree: a comparison-direction bug"), std::string::npos) << ge.output;
  // Only the parent test flipped: named as that half.
  Runtime parent_ge_rt;
  parent_ge_rt.parent_ge = true;
  auto half = run("parent_ge.txt", selections_text(manifest, [&](const nlohmann::json& v) {
                    return runtime_select(dag, v, parent_ge_rt);
                  }));
  EXPECT_EQ(half.exit_code, 1) << half.output;
  EXPECT_NE(half.output.find("the selection is the cut with proj(parent) >= tau and proj(lod) <= tau"), std::string::npos)
      << half.output;

  // A binary32 runtime with the overflow-safe distance and the right comparisons agrees on
  // every vector except, at most, rounding-sensitive ties (spec/conform.md §3.1); the exact
  // ties and very_far_1e30 pass. A naive binary32 distance overflows at 1e30 and draws nothing.
  Runtime f32;
  f32.arithmetic = Runtime::Arithmetic::kFloat32;
  auto float_rt = run("float32.txt", selections_text(manifest, [&](const nlohmann::json& v) { return runtime_select(dag, v, f32); }),
                      "--junit '" + (dir / "f32.xml").string() + "'");
  cases = test::checked_junit((dir / "f32.xml").string());
  for (const auto& v : manifest["vectors"]) {
    const std::string name = v["name"];
    if (v["kind"] != "tie") {
      EXPECT_NE(cases.find("." + name + ": passed"), std::string::npos) << name << "\n" << cases;
    }
  }
  EXPECT_EQ(float_rt.output.find("comparison-direction"), std::string::npos) << float_rt.output;
  Runtime naive;
  naive.arithmetic = Runtime::Arithmetic::kFloat32Naive;
  auto naive_rt = run("naive.txt", selections_text(manifest, [&](const nlohmann::json& v) { return runtime_select(dag, v, naive); }),
                      "--junit '" + (dir / "naive.xml").string() + "'");
  EXPECT_EQ(naive_rt.exit_code, 1) << naive_rt.output;
  cases = test::checked_junit((dir / "naive.xml").string());
  EXPECT_NE(cases.find(".very_far_1e30: failed CONFORM_LOD_MISMATCH"), std::string::npos) << cases;

  // Broken 4: usability checked one level deep (resident and parent resident). It agrees with
  // every vector but the depth-2 one (resident_missing_level2_group, above).
  Runtime one_level;
  one_level.one_level_usable = true;
  auto shallow = run("one_level.txt", selections_text(manifest, [&](const nlohmann::json& v) {
                       return runtime_select(dag, v, one_level);
                     }), "--junit '" + (dir / "shallow.xml").string() + "'");
  EXPECT_EQ(shallow.exit_code, 1) << shallow.output;
  cases = test::checked_junit((dir / "shallow.xml").string());
  EXPECT_NE(cases.find(".resident_missing_level2_group: failed CONFORM_LOD_MISMATCH"), std::string::npos) << cases;
  EXPECT_NE(shallow.output.find(" of " + std::to_string(manifest["vectors"].size()) + " LOD vectors agree"),
            std::string::npos);
  EXPECT_NE(shallow.output.find(std::to_string(manifest["vectors"].size() - 1) + " of "), std::string::npos)
      << shallow.output;

  // Broken 2: residency ignored (always the plain lod_selects cut).
  auto ignore = run("no_residency.txt", selections_text(manifest, [&](const nlohmann::json& v) {
                      return select_resident_cut(dag, std::vector<uint8_t>(dag.groups.size(), 1), view_of(v),
                                                 float(v["tau"].get<double>()));
                    }), "--junit '" + (dir / "res.xml").string() + "'");
  EXPECT_EQ(ignore.exit_code, 1) << ignore.output;
  cases = test::checked_junit((dir / "res.xml").string());
  EXPECT_NE(cases.find(".resident_roots_only: failed CONFORM_LOD_MISMATCH"), std::string::npos) << cases;
  EXPECT_NE(cases.find(".resident_missing_level1_group: failed CONFORM_LOD_MISMATCH"), std::string::npos) << cases;
  EXPECT_NE(cases.find(".resident_all: passed"), std::string::npos) << cases;

  // Broken 3: one vector missing, one cluster dropped from another, one listed twice.
  std::string text = selections_text(manifest, [&](const nlohmann::json& v) {
    std::vector<uint32_t> e = v["expected"];
    if (v["name"] == "framing_mid") e.pop_back();
    if (v["name"] == "close_1.5_radii") e.push_back(e.front());
    return e;
  });
  text.erase(text.find("tau_tiny:"), text.find('\n', text.find("tau_tiny:")) - text.find("tau_tiny:") + 1);
  auto dropped = run("dropped.txt", text, "--junit '" + (dir / "drop.xml").string() + "'");
  EXPECT_EQ(dropped.exit_code, 1) << dropped.output;
  cases = test::checked_junit((dir / "drop.xml").string());
  EXPECT_NE(cases.find(".framing_mid: failed CONFORM_LOD_MISMATCH"), std::string::npos) << cases;
  EXPECT_NE(cases.find(".close_1.5_radii: failed CONFORM_LOD_DUPLICATE"), std::string::npos) << cases;
  EXPECT_NE(cases.find(".tau_tiny: failed CONFORM_LOD_NO_SELECTION"), std::string::npos) << cases;
  EXPECT_NE(dropped.output.find("framing_mid: 1 missing"), std::string::npos) << dropped.output;

  // A leading UTF-8 byte-order mark is ignored (spec/conform.md §3.2); an index beyond the
  // DAG's clusters is an extra cluster of that vector (a mismatch), not a syntax error.
  std::ifstream ref_in(reference);
  std::stringstream ref_text;
  ref_text << ref_in.rdbuf();
  auto bom = run("bom.txt", "\xEF\xBB\xBF" + ref_text.str());
  EXPECT_EQ(bom.exit_code, 0) << bom.output;
  std::string beyond = ref_text.str();
  beyond.insert(beyond.find('\n', beyond.find("tau_huge:")), " 99999");
  auto out_of_range = run("beyond.txt", beyond);
  EXPECT_EQ(out_of_range.exit_code, 1) << out_of_range.output;
  EXPECT_NE(out_of_range.output.find("CONFORM_LOD_MISMATCH tau_huge: 0 missing [], 1 extra [99999]"), std::string::npos)
      << out_of_range.output;

  // Malformed selections: a line without a name, an unknown vector (exit 3, with the code).
  auto syntax = run("syntax.txt", "framing_tau1 3 4\n");
  EXPECT_EQ(syntax.exit_code, 3) << syntax.output;
  EXPECT_NE(syntax.output.find("error[CONFORM_LOD_SELECTION_SYNTAX]"), std::string::npos) << syntax.output;
  auto unknown = run("unknown.txt", "no_such_vector: 1\n");
  EXPECT_EQ(unknown.exit_code, 3) << unknown.output;
  EXPECT_NE(unknown.output.find("error[CONFORM_LOD_UNKNOWN_VECTOR]"), std::string::npos) << unknown.output;
  fs::remove_all(dir);
}

TEST(LodVectors, CorruptedVectorsAreRejected) {
  // A vector whose expected set is not the reference cut, a vector claiming to be an exact tie
  // that is not one, and an unknown kind: CONFORM_LOD_VECTOR_INVALID (exit 3), never a pass.
  const fs::path dir = fs::temp_directory_path() / ("vgeo_lod_corrupt_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  std::ifstream f(kDir / "manifest.json");
  const nlohmann::json manifest = nlohmann::json::parse(f);
  auto check = [&](const std::string& what, const std::function<void(nlohmann::json&)>& corrupt,
                   const std::string& expected_text) {
    const fs::path vectors = dir / what;
    fs::create_directories(vectors);
    fs::copy_file(kDir / kDagName, vectors / kDagName, fs::copy_options::overwrite_existing);
    nlohmann::json m = manifest;
    corrupt(m);
    std::ofstream(vectors / "manifest.json") << m.dump(1);
    auto r = test::run_cli("conform lod --vectors '" + vectors.string() + "' --write-reference '" +
                           (vectors / "ref.txt").string() + "'");
    EXPECT_EQ(r.exit_code, 3) << what << "\n" << r.output;
    EXPECT_NE(r.output.find("error[CONFORM_LOD_VECTOR_INVALID]"), std::string::npos) << what << "\n" << r.output;
    EXPECT_NE(r.output.find(expected_text), std::string::npos) << what << "\n" << r.output;
  };
  auto named = [](nlohmann::json& m, const std::string& name) -> nlohmann::json& {
    for (auto& v : m["vectors"])
      if (v["name"] == name) return v;
    ADD_FAILURE() << name;
    return m;
  };
  check("expected", [&](nlohmann::json& m) { named(m, "framing_mid")["expected"].erase(0); }, "framing_mid");
  check("claim", [&](nlohmann::json& m) { named(m, "tie_level0")["kind"] = "exact_tie"; }, "not an exact tie");
  check("kind", [&](nlohmann::json& m) { named(m, "tau_tiny")["kind"] = "fuzzy"; }, "unknown kind");
  fs::remove_all(dir);
}

}  // namespace
