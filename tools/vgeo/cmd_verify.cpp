// `vgeo verify FILE`: checks every mesh's DAG of a VGEODAG1 file against the invariants of
// spec/invariants.md; exit 0 when all hold, 1 (kExitInvariantViolation) otherwise.
#include <cstdio>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "commands.h"
#include "junit.h"
#include "vgeo/core/file_io.h"
#include "vgeo/format/asset_file.h"
#include "vgeo/core/error.h"
#include "vgeo/verify/verify.h"

namespace vgeo::cli {

namespace {
struct VerifyArgs {
  std::string input;
  std::string json_path;
  std::string junit_path;
  std::string checks = "all";
  uint32_t views = VerifyOptions{}.views;
  uint32_t thresholds = VerifyOptions{}.thresholds_per_view;
  uint64_t seed = VerifyOptions{}.seed;
  uint32_t samples_per_edge = VerifyOptions{}.error_samples_per_edge;
  unsigned threads = 0;
  uint32_t max_stored = VerifyOptions{}.max_stored_per_code;
  bool quiet = false;
  bool strict_border = false;
  bool certify = false;
};

// The check a code belongs to: from the stored violations, else by its prefix
// (spec/invariants.md: STRUCT_ structure, MONO_ monotonic, CUT_ cut, CRACK_ crack, ERROR_CERTIFIED
// certified_bound, other ERROR_ error_bound).
std::string check_of_code(const VerifyReport& report, const std::string& code) {
  for (const Violation& v : report.violations)
    if (v.code == code) return v.check;
  static const std::pair<const char*, const char*> kPrefixes[] = {
      {"STRUCT_", "structure"}, {"MONO_", "monotonic"}, {"CUT_", "cut"},
      {"CRACK_", "crack"}, {"ERROR_CERTIFIED", "certified_bound"}, {"ERROR_", "error_bound"}};
  for (const auto& [prefix, check] : kPrefixes)
    if (code.rfind(prefix, 0) == 0) return check;
  return "structure";
}

// One testcase per check: failed with every code it reported, skipped with its reason.
JunitSuite junit_suite(const VerifyReport& report, const std::string& file, size_t mesh) {
  JunitSuite suite{file + " mesh " + std::to_string(mesh), {}};
  for (const CheckStats& c : report.checks) {
    JunitCase tc = junit_case("vgeo.verify.mesh" + std::to_string(mesh), c.check);
    tc.seconds = c.seconds;
    tc.skipped = !c.ran;
    tc.skipped_message = c.skipped_reason;
    for (const ViolationCount& n : report.counts) {
      if (check_of_code(report, n.code) != c.check) continue;
      if (tc.failure_type.empty()) tc.failure_type = n.code;
      tc.failure_message += (tc.failed ? ", " : "") + n.code + " x" + std::to_string(n.count);
      tc.failed = true;
    }
    for (const Violation& v : report.violations)
      if (v.check == c.check)
        tc.failure_text += v.code + " " + v.element + " " + std::to_string(v.index) + ": " + v.message + "\n";
    suite.cases.push_back(std::move(tc));
  }
  return suite;
}

// A file the decoder rejected, as one failing testcase (the code is the decoder's).
void write_rejected_junit(const std::string& path, const std::string& file, const VgeoError& e) {
  JunitCase tc = junit_case("vgeo.verify", "decode");
  tc.failed = true;
  tc.failure_type = e.error().code;
  tc.failure_message = e.error().line();
  write_junit(path, "vgeo verify", {JunitSuite{file, {tc}}});
}

int run_verify(const VerifyArgs& a) {
  VerifyOptions options;
  if (!parse_verify_checks(a.checks, &options.checks))
    fail("CLI_BAD_CHECKS", "vgeo verify",
         "--checks takes a comma-separated list of: structure, monotonic, cut, crack, error_bound, certified_bound, all",
         kExitUsage);
  if (a.certify) options.checks |= kCheckCertifiedBound;
  options.views = a.views;
  options.thresholds_per_view = a.thresholds;
  options.seed = a.seed;
  options.error_samples_per_edge = a.samples_per_edge;
  options.threads = a.threads;
  options.max_stored_per_code = a.max_stored;
  options.strict_border = a.strict_border;

  BuiltScene scene;
  try {
    scene = read_asset_file(a.input);  // page format or VGEODAG1; throws VgeoError
  } catch (const VgeoError& e) {
    if (!a.junit_path.empty()) write_rejected_junit(a.junit_path, a.input, e);
    throw;
  }
  bool all_ok = true;
  std::vector<JunitSuite> junit;
  nlohmann::json json{{"file", a.input}, {"meshes", nlohmann::json::array()}};
  for (size_t m = 0; m < scene.meshes.size(); ++m) {
    VerifyReport report = verify_dag(scene.meshes[m], options);
    all_ok &= report.ok();
    if (!a.quiet) {
      std::printf("mesh %zu: %s\n%s", m, report.ok() ? "all invariants hold" : "INVARIANT VIOLATIONS",
                  verify_report_summary(report).c_str());
      for (size_t i = 0; i < report.violations.size() && i < 10; ++i) {
        const Violation& v = report.violations[i];
        std::printf("  %s %s %llu: %s\n", v.code.c_str(), v.element.c_str(), (unsigned long long)v.index,
                    v.message.c_str());
      }
    }
    junit.push_back(junit_suite(report, a.input, m));
    json["meshes"].push_back(nlohmann::json::parse(verify_report_json(report, "mesh " + std::to_string(m))));
  }
  if (scene.meshes.empty()) {
    all_ok = false;
    std::printf("the file holds no meshes\n");
    JunitCase tc = junit_case("vgeo.verify", "meshes");
    tc.failed = true;
    tc.failure_type = "VERIFY_NO_MESHES";
    tc.failure_message = "the file holds no meshes";
    junit.push_back({a.input, {tc}});
  }
  if (!a.junit_path.empty()) write_junit(a.junit_path, "vgeo verify", junit);
  json["ok"] = all_ok;
  if (!a.json_path.empty()) write_file_atomic(a.json_path, json.dump(2) + "\n");
  return all_ok ? kExitOk : kExitInvariantViolation;
}
}  // namespace

void add_verify_command(CLI::App& app, Context& ctx) {
  auto args = std::make_shared<VerifyArgs>();
  auto* cmd = app.add_subcommand("verify", "check a DAG file against every invariant of spec/invariants.md");
  cmd->add_option("file", args->input, "asset file written by `vgeo build` (page format VGEOPAGE or DAG file VGEODAG1)")->required();
  cmd->add_option("--json", args->json_path, "write the full report (every stored violation) as JSON");
  cmd->add_option("--junit", args->junit_path, "write a JUnit XML report (one testcase per check and mesh)");
  cmd->add_option("--checks", args->checks,
                  "comma-separated: structure,monotonic,cut,crack,error_bound,certified_bound (default all = every check "
                  "but certified_bound)");
  cmd->add_option("--views", args->views, "random viewpoints for the projected-error, cut and crack checks");
  cmd->add_option("--thresholds", args->thresholds, "pixel thresholds (cuts) per viewpoint");
  cmd->add_option("--seed", args->seed, "seed of the views and thresholds");
  cmd->add_option("--samples-per-edge", args->samples_per_edge,
                  "error-bound sampling lattice: subdivisions per triangle edge");
  cmd->add_option("--threads", args->threads, "worker threads (0 = all cores); results do not depend on it");
  cmd->add_option("--max-stored", args->max_stored, "violations stored per code (all are counted)");
  cmd->add_flag("--strict-border", args->strict_border,
                 "the mesh's own open border must survive every cut unchanged (CRACK_BORDER_CHANGED)");
  cmd->add_flag("--certify", args->certify,
                "also prove every stored error bounds the continuous deviation (certified_bound, ERROR_CERTIFIED; "
                "holds for `vgeo build --error-bound certified`)");
  cmd->add_flag("--quiet", args->quiet, "print nothing; rely on the exit code and --json");
  cmd->callback([args, &ctx] { ctx.exit_code = run_verify(*args); });
}

}  // namespace vgeo::cli
