// `vgeo conform lod --vectors DIR (--selections FILE | --write-reference FILE) [--junit F]`:
// checks a runtime's LOD selections against the vectors of spec/vectors/lod (spec/conform.md §3).
// Every vector's expected set is first recomputed with lib/vgeo/core/lod.h (select_resident_cut,
// spec/stream.md §Cut) so a corrupted vector cannot pass silently.
#include <algorithm>
#include <chrono>
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

struct LodVector {
  std::string name, kind, what;
  LodView view;
  float tau = 1.0f;
  std::vector<uint32_t> expected;  // ascending
};

struct ConformLodArgs {
  std::string vectors, selections, reference, junit_path;  // vectors: "" = spec/vectors/lod (resolve_vectors_dir)
  bool quiet = false;
};

[[noreturn]] void bad_vector(const std::string& where, const std::string& what) {
  fail("CONFORM_LOD_VECTOR_INVALID", where, what, kExitBadInput);
}

std::vector<LodVector> load_vectors(const std::string& dir) {
  const std::string path = dir + "/manifest.json";
  nlohmann::json m = nlohmann::json::parse(read_conform_text(path, "the vector manifest"), nullptr, false);
  if (m.is_discarded() || !m.is_object() || m.value("format", "") != "vgeo-lod-vectors" || m.value("version", 0) != 1 ||
      !m.contains("dag") || !m["dag"].is_string() || !m.contains("vectors") || !m["vectors"].is_array())
    bad_vector(path, "not a vgeo-lod-vectors version 1 manifest");
  BuiltScene scene = read_asset_file(dir + "/" + m["dag"].get<std::string>());
  const uint32_t mesh = m.value("mesh", 0u);
  if (mesh >= scene.meshes.size()) bad_vector(path, "mesh " + std::to_string(mesh) + " not in the DAG file");
  const ClusterDag& dag = scene.meshes[mesh];
  std::vector<LodVector> out;
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
        bad_vector(path, x.name + ": the expected set is not what lib/vgeo/core/lod.h selects on " +
                   m["dag"].get<std::string>());
    } catch (const nlohmann::json::exception& e) {
      bad_vector(path, "vector " + x.name + ": " + e.what());
    }
    out.push_back(std::move(x));
  }
  return out;
}

// The selections file (spec/conform.md §3.2): `NAME: id id ...` per line, `#` comments.
std::map<std::string, std::vector<uint32_t>> load_selections(const std::string& path,
                                                             const std::vector<LodVector>& vectors) {
  std::istringstream f(read_conform_text(path, "the selections file"));
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

// Compares one vector; fills the testcase (failure type = the code).
void judge(const LodVector& v, const std::map<std::string, std::vector<uint32_t>>& selections, JunitCase* tc) {
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
    tc->failure_type = v.kind == "tie" ? "CONFORM_LOD_TIE_MISMATCH" : "CONFORM_LOD_MISMATCH";
    tc->failure_message = v.name + ": " + std::to_string(missing.size()) + " missing [" + id_list(missing) + "], " +
                          std::to_string(extra.size()) + " extra [" + id_list(extra) + "]";
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
  std::vector<LodVector> vectors = load_vectors(dir);
  if (!a.reference.empty()) {
    std::string text = "# vgeo-lod-selections 1 (vgeo's reference selections of " + dir + ")\n";
    for (const LodVector& v : vectors) {
      text += v.name + ":";
      for (uint32_t c : v.expected) text += " " + std::to_string(c);
      text += "\n";
    }
    write_file_atomic(a.reference, text);
  }
  if (a.selections.empty()) return kExitOk;
  const auto selections = load_selections(a.selections, vectors);
  JunitSuite suite{"vgeo conform lod " + a.selections, {}};
  size_t failed = 0;
  for (const LodVector& v : vectors) {
    JunitCase tc = junit_case("vgeo.conform.lod", v.name);
    const auto started = std::chrono::steady_clock::now();
    judge(v, selections, &tc);
    tc.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    if (tc.failed) {
      ++failed;
      if (!a.quiet) std::printf("%s %s\n", tc.failure_type.c_str(), tc.failure_message.c_str());
    }
    suite.cases.push_back(std::move(tc));
  }
  if (!a.quiet) std::printf("%zu of %zu LOD vectors agree\n", vectors.size() - failed, vectors.size());
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
