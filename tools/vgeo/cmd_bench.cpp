// `vgeo bench SUITE|all --out DIR [--quick] [--repeat N] [--threads N]`: measured curves of
// what accuracy costs in time. Writes DIR/report.md, DIR/report.json and SVG plots.
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <stdexcept>
#include <string>

#include "bench_harness.h"
#include "bench_suites.h"
#include "commands.h"
#include "vgeo/core/file_io.h"
#include "vgeo/core/error.h"
#include "vgeo/core/progress.h"

namespace vgeo::cli {

namespace {
struct BenchArgs {
  std::string suite;
  std::string out;
  bool quick = false;
  int repeat = 0;
  unsigned threads = 0;
};

// Returns the exit status: 0, or, when one suite was named (not `all`) and it failed with a
// coded error, that error's exit status (e.g. `vgeo bench dagquality` on an input it cannot
// measure), so a script running one suite cannot mistake a failure for a measurement.
int run_bench(const BenchArgs& args) {
  using namespace vgeo::bench;
  std::vector<SuiteDef> suites = suite_list();
  std::vector<SuiteDef> chosen;
  for (const SuiteDef& s : suites)
    if (args.suite == "all" || args.suite == s.name) chosen.push_back(s);
  if (chosen.empty()) {
    std::string names;
    for (const SuiteDef& s : suites) names += std::string(names.empty() ? "" : ", ") + s.name;
    fail("BENCH_UNKNOWN_SUITE", "vgeo bench", "unknown suite '" + args.suite + "' (expected all, " + names + ")",
         kExitUsage);
  }
  create_output_directory(args.out);

  BenchConfig cfg;
  cfg.quick = args.quick;
  cfg.repeat = args.repeat;
  cfg.threads = args.threads;
  cfg.out_dir = args.out;
  cfg.progress = progress_wanted();
  MachineInfo machine = describe_machine();
  std::vector<SuiteReport> reports;
  int named_suite_exit = kExitOk;
  double t0 = now_seconds();
  for (const SuiteDef& s : chosen) {
    SuiteReport r;
    r.name = s.name;
    double ts = now_seconds();
    // A stage that throws is a finding for that stage, not a reason to lose the other suites:
    // record it in the report (and on stderr) and go on. With `all` the exit status stays 0
    // so the smoke run in tools/test keeps the harness alive; the report names the failure.
    try {
      s.run(cfg, r);
    } catch (const VgeoError& e) {
      r = SuiteReport{};
      r.name = s.name;
      r.failure = e.error().line();
      std::fprintf(stderr, "suite %s: failed: %s\n", s.name, e.error().line().c_str());
      if (args.suite != "all") named_suite_exit = e.error().exit_code;
    } catch (const std::exception& e) {
      r = SuiteReport{};
      r.name = s.name;
      r.failure = e.what();
      std::fprintf(stderr, "suite %s: failed: %s\n", s.name, e.what());
    }
    r.seconds = now_seconds() - ts;
    if (cfg.progress) {
      if (r.ran) std::fprintf(stderr, "suite %s: done in %.1f s\n", s.name, r.seconds);
    }
    reports.push_back(std::move(r));
  }
  write_reports(cfg, machine, reports, now_seconds() - t0);
  if (cfg.progress) std::fprintf(stderr, "wrote %s/report.md\n", args.out.c_str());
  if (named_suite_exit != kExitOk) {
    // The one-line error of spec/errors.md on stderr, as every command ends with.
    std::fprintf(stderr, "%s\n", reports.back().failure.c_str());
  }
  return named_suite_exit;
}
}  // namespace

void add_bench_command(CLI::App& app, Context& ctx) {
  auto args = std::make_shared<BenchArgs>();
  std::string suite_help = "suite to run: all";
  for (const auto& s : bench::suite_list()) suite_help += std::string(", ") + s.name;
  auto* cmd = app.add_subcommand("bench", "measure what accuracy costs in time (report.md/.json + SVG plots)");
  cmd->add_option("suite", args->suite, suite_help)->required();
  cmd->add_option("--out", args->out, "output directory (created if missing)")->required();
  cmd->add_flag("--quick", args->quick, "smoke sizes: all suites in well under 2 minutes");
  cmd->add_option("--repeat", args->repeat, "repetitions per measurement (default: per suite; quick: 3)")
      ->check(CLI::Range(1, 1000));
  cmd->add_option("--threads", args->threads, "worker threads (default: hardware concurrency)")
      ->check(CLI::Range(0u, 1024u));
  cmd->callback([args, &ctx] { ctx.exit_code = run_bench(*args); });
}

}  // namespace vgeo::cli
