// `vgeo conform lod --vectors DIR (--selections FILE | --write-reference FILE) [--junit F]`:
// checks a runtime's LOD selections against the vectors of spec/vectors/lod (spec/conform.md §3).
// Every vector's expected set is first recomputed with lib/vgeo/core/lod.h (select_resident_cut,
// spec/stream.md §Cut) so a corrupted vector cannot pass silently; an exact tie's claim is checked
// too. Mismatches at ties are named by the comparisons the selection equals (>= for >, < for <=),
// and exact ties, which no rounding can move, tell a comparison bug from rounding.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <iterator>
#include <cstdio>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "conform.h"
#include "junit.h"
#include "vgeo/core/error.h"
#include "vgeo/core/lod.h"
#include "vgeo/format/asset_file.h"
#include "vgeo/core/file_io.h"
#include "vgeo/stream/stream.h"

namespace vgeo::cli {

namespace {

constexpr size_t kListedDifferences = 8;  // cluster ids quoted per mismatch (the rest are counted)

// The kinds of spec/conform.md §3.1. `exact_tie`: τ equals a projected error every IEEE
// arithmetic computes exactly (k = 1, z_near a power of two that clamps every denominator), so
// a mismatch there is a comparison bug; `tie`: τ equals a projected error as lod.h's arithmetic
// computes it, which another arithmetic may round to either side.
const char* const kKinds[] = {"plain", "tie", "exact_tie", "residency"};

struct LodVector {
  std::string name, kind, what;
  LodView view;
  float tau = 1.0f;
  std::vector<uint8_t> usable;     // per group (spec/stream.md §Usable groups)
  std::vector<uint32_t> expected;  // ascending
};

struct LodVectorSet {
  ClusterDag dag;
  std::vector<LodVector> vectors;
};

// How a tie was decided: the cut with the parent test `>=` instead of `>` and/or the lod test
// `<` instead of `<=` (spec/stream.md §Cut otherwise). Not a second LOD rule: it only names
// what a runtime's selection at a tie equals, so a comparison bug reads as one.
struct Comparisons {
  bool parent_inclusive = false, lod_strict = false;
};

std::vector<uint32_t> cut_with_comparisons(const ClusterDag& dag, const LodVector& v, Comparisons cmp) {
  std::vector<uint32_t> out;
  for (uint32_t c = 0; c < dag.clusters.size(); ++c) {
    const DagCluster& k = dag.clusters[c];
    const float parent = projected_error(k.parent_bounds, k.parent_error, v.view);
    const float lod = projected_error(k.lod_bounds, k.lod_error, v.view);
    const bool parent_passes = cmp.parent_inclusive ? parent >= v.tau : parent_too_coarse(parent, v.tau);
    const bool lod_passes = cmp.lod_strict ? lod < v.tau : fine_enough(lod, v.tau);
    const bool finer_unusable = k.generating_group != kNone && !v.usable[k.generating_group];
    if (v.usable[k.group] && parent_passes && (lod_passes || finer_unusable)) out.push_back(c);
  }
  return out;
}

// The exact-tie claim of a vector, checked on the DAG: k = 1, z_near a power of two, every
// sphere's d - r at most half of z_near (so a distance rounded by any arithmetic still clamps),
// and τ·z_near a stored error. Empty when it holds, else why not.
std::string exact_tie_claim_fails(const ClusterDag& dag, const LodVector& v) {
  int exponent = 0;
  if (v.view.pixels_per_unit_at_1 != 1.0f) return "pixels_per_unit_at_1 is not 1";
  if (!(v.view.z_near > 0) || std::frexp(v.view.z_near, &exponent) != 0.5f) return "z_near is not a power of two";
  bool error_found = false;
  for (const DagCluster& c : dag.clusters) {
    for (const Sphere* s : {&c.lod_bounds, &c.parent_bounds})
      if (!(distance_d(s->center, v.view.eye) - double(s->radius) <= 0.5 * double(v.view.z_near)))
        return "a sphere is not within half of z_near of the eye";
    error_found |= double(c.parent_error) == double(v.tau) * double(v.view.z_near);
  }
  return error_found ? "" : "tau * z_near is no stored parent_error";
}

struct ConformLodArgs {
  std::string vectors, selections, reference, junit_path;  // vectors: "" = spec/vectors/lod (resolve_vectors_dir)
  bool quiet = false;
};

[[noreturn]] void bad_vector(const std::string& where, const std::string& what) {
  fail("CONFORM_LOD_VECTOR_INVALID", where, what, kExitBadInput);
}

LodVectorSet load_vectors(const std::string& dir) {
  const std::string path = dir + "/manifest.json";
  nlohmann::json m = nlohmann::json::parse(read_conform_text(path, "the vector manifest"), nullptr, false);
  if (m.is_discarded() || !m.is_object() || m.value("format", "") != "vgeo-lod-vectors" || m.value("version", 0) != 1 ||
      !m.contains("dag") || !m["dag"].is_string() || !m.contains("vectors") || !m["vectors"].is_array())
    bad_vector(path, "not a vgeo-lod-vectors version 1 manifest");
  BuiltScene scene = read_asset_file(dir + "/" + m["dag"].get<std::string>());
  const uint32_t mesh = m.value("mesh", 0u);
  if (mesh >= scene.meshes.size()) bad_vector(path, "mesh " + std::to_string(mesh) + " not in the DAG file");
  LodVectorSet set;
  set.dag = std::move(scene.meshes[mesh]);
  const ClusterDag& dag = set.dag;
  std::vector<LodVector>& out = set.vectors;
  for (const auto& v : m["vectors"]) {
    LodVector x;
    try {
      x.name = v.at("name").get<std::string>();
      x.kind = v.at("kind").get<std::string>();
      x.what = v.value("what", "");
      const auto& eye = v.at("eye");
      x.view.eye = {float(eye.at(0).get<double>()), float(eye.at(1).get<double>()), float(eye.at(2).get<double>())};
      x.view.pixels_per_unit_at_1 = float(v.at("pixels_per_unit_at_1").get<double>());
      x.view.z_near = float(v.at("z_near").get<double>());
      x.tau = float(v.at("tau").get<double>());
      x.expected = v.at("expected").get<std::vector<uint32_t>>();
      if (std::find(std::begin(kKinds), std::end(kKinds), x.kind) == std::end(kKinds))
        bad_vector(path, x.name + ": unknown kind '" + x.kind + "'");
      std::vector<uint8_t> usable(dag.groups.size(), 1);
      if (v.contains("resident_groups")) {
        std::vector<uint8_t> resident(dag.groups.size(), 0);
        for (uint32_t g : v["resident_groups"].get<std::vector<uint32_t>>()) {
          if (g >= resident.size()) bad_vector(path, x.name + ": resident group " + std::to_string(g) + " out of range");
          resident[g] = 1;
        }
        usable = usable_groups_of_resident(dag, std::move(resident));
      }
      if (select_resident_cut(dag, usable, x.view, x.tau) != x.expected)
        bad_vector(path, x.name + ": the expected set is not the cut of spec/stream.md §Cut on " +
                   m["dag"].get<std::string>());
      if (x.kind == "exact_tie")
        if (std::string why = exact_tie_claim_fails(dag, x); !why.empty()) bad_vector(path, x.name + ": not an exact tie: " + why);
      x.usable = std::move(usable);
    } catch (const nlohmann::json::exception& e) {
      bad_vector(path, "vector " + x.name + ": " + e.what());
    }
    out.push_back(std::move(x));
  }
  return set;
}

// The selections file (spec/conform.md §3.2): `NAME: id id ...` per line, `#` comments.
std::map<std::string, std::vector<uint32_t>> load_selections(const std::string& path,
                                                             const std::vector<LodVector>& vectors) {
  std::string text = read_conform_text(path, "the selections file");
  // A leading UTF-8 byte-order mark (written by some editors and Windows tools) is ignored,
  // not read as part of the first vector's name (spec/conform.md §3.2).
  static constexpr char kUtf8Bom[] = "\xEF\xBB\xBF";
  if (text.rfind(kUtf8Bom, 0) == 0) text.erase(0, sizeof kUtf8Bom - 1);
  std::istringstream f(text);
  std::map<std::string, std::vector<uint32_t>> out;
  std::string line;
  for (size_t number = 1; std::getline(f, line); ++number) {
    const std::string where = path + ":" + std::to_string(number);
    if (size_t hash = line.find('#'); hash != std::string::npos) line.resize(hash);
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    const size_t colon = line.find(':');
    const size_t start = line.find_first_not_of(" \t");
    std::string name = colon == std::string::npos ? "" : line.substr(start, colon - start);
    if (name.empty() || name.find_first_of(" \t") != std::string::npos)
      fail("CONFORM_LOD_SELECTION_SYNTAX", where, "expected `NAME: cluster ids...`", kExitBadInput);
    if (std::none_of(vectors.begin(), vectors.end(), [&](const LodVector& v) { return v.name == name; }))
      fail("CONFORM_LOD_UNKNOWN_VECTOR", where, "no vector named '" + name + "'", kExitBadInput);
    if (out.count(name)) fail("CONFORM_LOD_SELECTION_SYNTAX", where, "vector '" + name + "' listed twice", kExitBadInput);
    std::vector<uint32_t>& ids = out[name];
    std::istringstream rest(line.substr(colon + 1));
    std::string token;
    while (rest >> token) {
      if (token.size() > 10 || token.find_first_not_of("0123456789") != std::string::npos ||
          std::stoull(token) > 0xFFFFFFFFull)
        fail("CONFORM_LOD_SELECTION_SYNTAX", where, "'" + token + "' is not a cluster index", kExitBadInput);
      ids.push_back(uint32_t(std::stoull(token)));
    }
  }
  return out;
}

std::string id_list(const std::vector<uint32_t>& ids) {
  std::string s;
  for (size_t i = 0; i < ids.size() && i < kListedDifferences; ++i) s += (i ? " " : "") + std::to_string(ids[i]);
  if (ids.size() > kListedDifferences) s += " ...";
  return s;
}

// At a tie, which comparisons the runtime's (sorted, unique) selection equals, as text; empty
// when it equals none of the flipped cuts.
std::string tie_diagnosis(const ClusterDag& dag, const LodVector& v, const std::vector<uint32_t>& got) {
  for (Comparisons cmp : {Comparisons{true, true}, Comparisons{true, false}, Comparisons{false, true}})
    if (cut_with_comparisons(dag, v, cmp) == got)
      return std::string("the selection is the cut with proj(parent) ") + (cmp.parent_inclusive ? ">=" : ">") +
             " tau and proj(lod) " + (cmp.lod_strict ? "<" : "<=") + " tau";
  return "";
}

// Compares one vector; fills the testcase (failure type = the code).
void judge(const ClusterDag& dag, const LodVector& v, const std::map<std::string, std::vector<uint32_t>>& selections,
           JunitCase* tc) {
  auto it = selections.find(v.name);
  if (it == selections.end()) {
    tc->failed = true;
    tc->failure_type = "CONFORM_LOD_NO_SELECTION";
    tc->failure_message = v.name + ": the selections file has no line for this vector";
    return;
  }
  std::vector<uint32_t> got = it->second;
  std::sort(got.begin(), got.end());
  std::vector<uint32_t> twice;
  for (size_t i = 1; i < got.size(); ++i)
    if (got[i] == got[i - 1] && (twice.empty() || twice.back() != got[i])) twice.push_back(got[i]);
  got.erase(std::unique(got.begin(), got.end()), got.end());
  std::vector<uint32_t> missing, extra;
  std::set_difference(v.expected.begin(), v.expected.end(), got.begin(), got.end(), std::back_inserter(missing));
  std::set_difference(got.begin(), got.end(), v.expected.begin(), v.expected.end(), std::back_inserter(extra));
  if (missing.empty() && extra.empty() && twice.empty()) return;
  tc->failed = true;
  if (!missing.empty() || !extra.empty()) {
    tc->failure_type = v.kind == "exact_tie" ? "CONFORM_LOD_TIE_DIRECTION"
                       : v.kind == "tie"     ? "CONFORM_LOD_TIE_MISMATCH"
                                             : "CONFORM_LOD_MISMATCH";
    tc->failure_message = v.name + ": " + std::to_string(missing.size()) + " missing [" + id_list(missing) + "], " +
                          std::to_string(extra.size()) + " extra [" + id_list(extra) + "]";
    if (v.kind == "tie" || v.kind == "exact_tie") {
      const std::string how = tie_diagnosis(dag, v, got);
      if (!how.empty()) tc->failure_message += "; " + how;
      tc->failure_message += v.kind == "exact_tie"
                                 ? " (an exact tie: every IEEE arithmetic computes tau here, so not rounding)"
                                 : " (a rounding-sensitive tie: see the exact_tie vectors)";
    }
  } else {
    tc->failure_type = "CONFORM_LOD_DUPLICATE";
    tc->failure_message = v.name + ": clusters listed more than once [" + id_list(twice) + "]";
  }
  tc->failure_text = v.what + "\n";
}

int run_conform_lod(const ConformLodArgs& a) {
  if (a.selections.empty() && a.reference.empty())
    fail("CONFORM_USAGE", "vgeo conform lod", "give --selections FILE (check) and/or --write-reference FILE", kExitUsage);
  const std::string dir = resolve_vectors_dir(a.vectors, "spec/vectors/lod", "manifest.json");
  const LodVectorSet set = load_vectors(dir);
  const std::vector<LodVector>& vectors = set.vectors;
  if (!a.reference.empty()) {
    std::string text = "# vgeo-lod-selections 1 (vgeo's reference selections of " + dir + ")\n";
    for (const LodVector& v : vectors) {
      text += v.name + ":";
      for (uint32_t c : v.expected) text.append(" ").append(std::to_string(c));  // (GCC 12's -Wrestrict misfires on " " + string)
      text += "\n";
    }
    write_file_atomic(a.reference, text);
  }
  if (a.selections.empty()) return kExitOk;
  const auto selections = load_selections(a.selections, vectors);
  JunitSuite suite{"vgeo conform lod " + a.selections, {}};
  size_t failed = 0, exact_ties = 0, exact_failed = 0, ties_failed = 0;
  for (const LodVector& v : vectors) {
    JunitCase tc = junit_case("vgeo.conform.lod", v.name);
    const auto started = std::chrono::steady_clock::now();
    judge(set.dag, v, selections, &tc);
    tc.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    exact_ties += v.kind == "exact_tie";
    if (tc.failed) {
      ++failed;
      exact_failed += tc.failure_type == "CONFORM_LOD_TIE_DIRECTION";
      ties_failed += tc.failure_type == "CONFORM_LOD_TIE_MISMATCH";
      if (!a.quiet) std::printf("%s %s\n", tc.failure_type.c_str(), tc.failure_message.c_str());
    }
    suite.cases.push_back(std::move(tc));
  }
  if (!a.quiet) {
    std::printf("%zu of %zu LOD vectors agree\n", vectors.size() - failed, vectors.size());
    // The tie verdict (spec/conform.md §3.3): exact ties cannot differ by rounding.
    if (exact_failed)
      std::printf("exact ties: %zu of %zu disagree: a comparison-direction bug (>= for >, or < for <=), not rounding\n",
                  exact_failed, exact_ties);
    else if (ties_failed && exact_ties)
      std::printf("ties: %zu rounding-sensitive tie(s) disagree, all %zu exact ties agree: rounding, not a comparison bug\n",
                  ties_failed, exact_ties);
  }
  if (!a.junit_path.empty()) write_junit(a.junit_path, "vgeo conform lod", {suite});
  return failed ? kExitInvariantViolation : kExitOk;
}

}  // namespace

void add_conform_lod_command(CLI::App& conform, Context& ctx) {
  auto args = std::make_shared<ConformLodArgs>();
  auto* cmd = conform.add_subcommand("lod", "check a runtime's LOD selections against spec/vectors/lod");
  cmd->add_option("--vectors", args->vectors, "the vector directory (manifest.json + DAG; default spec/vectors/lod, found in the working directory or above the vgeo binary)");
  cmd->add_option("--selections", args->selections, "the runtime's selections: `NAME: cluster ids...` per vector");
  cmd->add_option("--write-reference", args->reference, "write vgeo's own selections in that format");
  cmd->add_option("--junit", args->junit_path, "write a JUnit XML report (one testcase per vector)");
  cmd->add_flag("--quiet", args->quiet, "print nothing; rely on the exit code");
  cmd->callback([args, &ctx] { ctx.exit_code = run_conform_lod(*args); });
}

}  // namespace vgeo::cli
