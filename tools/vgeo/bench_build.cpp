// Suite "build": the builder end to end, as a user runs it. Each run is `vgeo build MESH -o OUT`
// in a child process of its own (so its peak RSS is its own, libraries and all): the DAG file
// (.vgeodag) and the page format (.vgp, the default output) on one thread, and the page format on
// --threads; and --threads one-thread builds of the page format started at once, the machine's
// throughput ceiling for a --threads build (bench_ceiling.h). Per run: process CPU (user + sys)
// from wait4, its peak RSS (VmHWM) and the CPU and wall seconds of each stage (import / build /
// write) from the build report, and wall time. Variants of a mesh run interleaved, the starting
// variant rotating per repetition (bench_harness.h), medians.
// The builder's CPU and memory goals are measured with it; the peer (meshoptimizer's
// clusterlod) is measured beside it with the kit in ../shared/peer, never built into vgeo
// (docs/acceptance/issue23_stop31.md holds the side-by-side table).
#include <spawn.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fcntl.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <stdexcept>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "bench_ceiling.h"
#include "bench_suites.h"
#include "vgeo/core/error.h"
#include "vgeo/core/file_io.h"
#include "vgeo/core/progress.h"
#include "vgeo/core/thread_pool.h"
#include "vgeo/mesh/export.h"
#include "vgeo/mesh/generate.h"

extern char** environ;

namespace vgeo::bench {
namespace {

struct BuildInput {
  std::string label;
  std::string path;            // a mesh file, or empty: generated
  uint64_t gen_triangles = 0;  // generate_mesh sphere, seed 1, positions only (`vgeo gen sphere -n N --seed 1 -o X.off`)
};

// VGEO_BUILD_INPUTS: comma-separated mesh files or "sphere:N" (replaces the defaults). Defaults: the
// meshes of the side-by-side table (docs/acceptance/issue23_stop31.md) (the 1M sphere, bunny00 and armadillo when tools/fetch-data
// has fetched them); quick: a 20k sphere.
std::vector<BuildInput> build_inputs(bool quick) {
  std::vector<BuildInput> in;
  if (const char* env = std::getenv("VGEO_BUILD_INPUTS"); env && *env) {
    std::stringstream ss(env);
    for (std::string t; std::getline(ss, t, ',');) {
      if (t.rfind("sphere:", 0) == 0) in.push_back({"sphere " + t.substr(7), "", std::stoull(t.substr(7))});
      else if (!t.empty()) in.push_back({std::filesystem::path(t).stem().string(), t, 0});
    }
    return in;
  }
  if (quick) return {{"sphere 20000", "", 20000}};
  in.push_back({"sphere 1000000", "", 1000000});
  for (const char* name : {"bunny00", "armadillo"}) {
    const std::string p = std::string("data/cgal/meshes/") + name + ".off";
    if (std::filesystem::exists(p)) in.push_back({name, p, 0});
  }
  return in;
}

// A generated input is written as the OFF file `vgeo gen` would write, so the child imports a file
// as for any other mesh (import is one of the stages measured).
std::string materialize(const BuildInput& in, const std::string& dir) {
  if (!in.path.empty()) return in.path;
  GenerateOptions g;
  g.shape = GenShape::kSphere;
  g.target_triangles = in.gen_triangles;
  g.seed = 1;
  Scene scene = generate_scene(g);
  const std::string path = dir + "/sphere_" + std::to_string(in.gen_triangles) + ".off";
  write_off(scene.meshes[0], path);
  return path;
}

struct Variant {
  std::string label;
  std::string extension;    // ".vgeodag" or ".vgp"
  unsigned threads = 1;     // 0: all cores
  unsigned concurrent = 0;  // 0: one build; n: n builds of `threads` threads started at once
};

struct RunResult {
  double cpu = 0, wall = 0, rss_mib = 0;
  double stage_cpu[3] = {0, 0, 0};   // import, build, write (the build report's cpu_seconds)
  double stage_wall[3] = {0, 0, 0};  // the same stages' wall seconds (the build report's seconds)
};
const char* const kStageNames[3] = {"import", "build", "write"};

// One repetition of the concurrent variant: the set's wall (first start to last exit) and each
// child's own CPU, peak RSS and stage times (a child's `wall` is left 0: the children are reaped
// in start order, so when one is reaped is not when it ended).
struct ConcurrentRun {
  double wall = 0;
  std::vector<RunResult> children;
};

// Starts `vgeo build` in a child process (this executable). Throws std::runtime_error when it cannot.
pid_t start_build(const std::string& input, const std::string& output, const std::string& report, unsigned threads) {
  const std::string threads_text = std::to_string(threads);
  std::vector<std::string> args = {"vgeo", "build", input, "-o", output, "--threads", threads_text, "--report", report};
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, "/dev/null", O_WRONLY, 0);
  posix_spawn_file_actions_addopen(&actions, STDERR_FILENO, "/dev/null", O_WRONLY, 0);
  pid_t pid = 0;
  const int spawned = posix_spawn(&pid, "/proc/self/exe", &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (spawned != 0) throw std::runtime_error("cannot start vgeo build: " + std::string(std::strerror(spawned)));
  return pid;
}

// Reaps a started build; its CPU (user + sys) from wait4. Throws std::runtime_error on a failed run.
rusage wait_build(pid_t pid, const std::string& input) {
  int status = 0;
  rusage usage{};
  if (wait4(pid, &status, 0, &usage) != pid || !WIFEXITED(status) || WEXITSTATUS(status) != 0)
    throw std::runtime_error("vgeo build " + input + " failed (wait status " + std::to_string(status) + ")");
  return usage;
}

// A reaped build's figures: CPU from its rusage, peak RSS and stage times from its report.
RunResult read_build(const rusage& usage, const std::string& report) {
  RunResult r;
  r.cpu = double(usage.ru_utime.tv_sec + usage.ru_stime.tv_sec) + 1e-6 * double(usage.ru_utime.tv_usec + usage.ru_stime.tv_usec);
  const nlohmann::json j = nlohmann::json::parse(read_text_file(report));
  // The child's own peak (its report's VmHWM): wait4's ru_maxrss would count this process's
  // address space, which the spawned child had before exec (lib/vgeo/core/process_memory.h).
  r.rss_mib = double(j.at("peak_rss_bytes").get<uint64_t>()) / (1024.0 * 1024.0);
  for (int s = 0; s < 3; ++s) {
    r.stage_cpu[s] = j.at("cpu_seconds").at(kStageNames[s]).get<double>();
    r.stage_wall[s] = j.at("seconds").at(kStageNames[s]).get<double>();
  }
  return r;
}

// One `vgeo build` in a child process. Throws std::runtime_error on a failed run.
RunResult run_build(const std::string& input, const std::string& output, const std::string& report, unsigned threads) {
  const double t0 = now_seconds();
  const rusage usage = wait_build(start_build(input, output, report, threads), input);
  const double wall = now_seconds() - t0;
  RunResult r = read_build(usage, report);
  r.wall = wall;
  return r;
}

std::string concurrent_output(const std::string& dir, unsigned k) { return dir + "/together" + std::to_string(k) + ".vgp"; }
std::string concurrent_report(const std::string& dir, unsigned k) { return dir + "/together" + std::to_string(k) + ".json"; }

// n one-thread builds of the page format started together, each with its own output and report;
// waits for all of them (also when one fails, so no child outlives the run). Throws
// std::runtime_error on a failed run.
ConcurrentRun run_concurrent_builds(const std::string& input, const std::string& dir, unsigned n) {
  std::vector<pid_t> pids;
  std::vector<rusage> usages;
  std::string failure;
  const double t0 = now_seconds();
  for (unsigned k = 0; k < n && failure.empty(); ++k) {
    try {
      pids.push_back(start_build(input, concurrent_output(dir, k), concurrent_report(dir, k), 1));
    } catch (const std::exception& e) {
      failure = e.what();
    }
  }
  for (pid_t pid : pids) {
    try {
      usages.push_back(wait_build(pid, input));
    } catch (const std::exception& e) {
      if (failure.empty()) failure = e.what();
    }
  }
  ConcurrentRun set;
  set.wall = now_seconds() - t0;
  if (!failure.empty()) throw std::runtime_error(failure);
  for (unsigned k = 0; k < n; ++k) set.children.push_back(read_build(usages[k], concurrent_report(dir, k)));
  return set;
}

// The concurrent set as one row of the main table: the set's wall, one build's CPU and stage
// times (the children's median), the largest child's peak RSS.
RunResult set_row(const ConcurrentRun& set) {
  auto median = [&](auto field) {
    std::vector<double> xs;
    for (const RunResult& c : set.children) xs.push_back(field(c));
    return summarize(xs).median;
  };
  RunResult r;
  r.wall = set.wall;
  r.cpu = median([](const RunResult& c) { return c.cpu; });
  for (const RunResult& c : set.children) r.rss_mib = std::max(r.rss_mib, c.rss_mib);
  for (int s = 0; s < 3; ++s) {
    r.stage_cpu[s] = median([s](const RunResult& c) { return c.stage_cpu[s]; });
    r.stage_wall[s] = median([s](const RunResult& c) { return c.stage_wall[s]; });
  }
  return r;
}

// Quantities of the ceiling table: the three stages (indices into the stage arrays), then the
// whole build's wall.
constexpr int kWholeBuild = 3;
double seconds_of(const RunResult& r, int quantity) { return quantity == kWholeBuild ? r.wall : r.stage_wall[quantity]; }

// The throughput ceiling of one mesh (bench_ceiling.h), per repetition then medians: the whole
// build's wall and each stage's wall seconds, one thread alone against `n` threads and against n
// one-thread builds at once. A stage's seconds in the set are the children's median (see
// kCeilingStageStatistic). Adds one table row per quantity; returns the mesh's JSON.
const char* const kCeilingStageStatistic =
    "median of the concurrent builds' stage seconds (the builds do the same work, so their spread is start skew "
    "and noise, not work imbalance; the max is kept per repetition in repetitions[])";
nlohmann::json report_ceiling(const std::string& mesh, const std::vector<RunResult>& one_thread,
                              const std::vector<RunResult>& n_threads, const std::vector<ConcurrentRun>& sets,
                              unsigned n, Table& table) {
  nlohmann::json j{{"concurrent_builds", n}, {"threads", n}, {"stage_statistic", kCeilingStageStatistic}};
  nlohmann::json reps = nlohmann::json::array();
  for (size_t rep = 0; rep < sets.size(); ++rep) {
    auto stage_json = [](const RunResult& r) {
      return nlohmann::json{{"import", r.stage_wall[0]}, {"build", r.stage_wall[1]}, {"write", r.stage_wall[2]}};
    };
    nlohmann::json children = nlohmann::json::array(), slowest = nlohmann::json::object();
    for (const RunResult& c : sets[rep].children) children.push_back(stage_json(c));
    for (int s = 0; s < 3; ++s) {
      double m = 0;
      for (const RunResult& c : sets[rep].children) m = std::max(m, c.stage_wall[s]);
      slowest[kStageNames[s]] = m;
    }
    reps.push_back({{"one_thread", {{"wall", one_thread[rep].wall}, {"stage_seconds", stage_json(one_thread[rep])}}},
                    {"n_threads", {{"wall", n_threads[rep].wall}, {"stage_seconds", stage_json(n_threads[rep])}}},
                    {"concurrent",
                     {{"wall", sets[rep].wall},
                      {"stage_seconds", stage_json(set_row(sets[rep]))},
                      {"stage_seconds_max", slowest},
                      {"children_stage_seconds", children}}}});
  }
  j["repetitions"] = reps;
  for (int q : {kWholeBuild, 0, 1, 2}) {
    std::vector<double> alone, threaded, together, ceiling, speedup, share;
    for (size_t rep = 0; rep < sets.size(); ++rep) {
      const CeilingSeconds s{seconds_of(one_thread[rep], q), seconds_of(n_threads[rep], q), seconds_of(set_row(sets[rep]), q)};
      const CeilingRatios r = ceiling_ratios(s, n);
      alone.push_back(s.one_thread);
      threaded.push_back(s.n_threads);
      together.push_back(s.concurrent);
      ceiling.push_back(r.ceiling);
      speedup.push_back(r.speedup);
      share.push_back(r.share);
    }
    const Stats c = summarize(ceiling), sp = summarize(speedup), sh = summarize(share);
    const std::string name = q == kWholeBuild ? "wall" : kStageNames[q];
    table.rows.push_back({mesh, q == kWholeBuild ? "whole build (wall)" : name, fmt_time(summarize(alone).median),
                          fmt_time(summarize(threaded).median), fmt_time(summarize(together).median),
                          fmt_ratio(c), fmt_ratio(sp), fmt(100 * sh.median) + "% [" + fmt(100 * sh.min) + ", " + fmt(100 * sh.max) + "]"});
    j[name] = {{"one_thread_seconds", to_json(summarize(alone))},
               {"n_threads_seconds", to_json(summarize(threaded))},
               {"concurrent_seconds", to_json(summarize(together))},
               {"ceiling", to_json(c)},
               {"speedup", to_json(sp)},
               {"share_of_ceiling", to_json(sh)}};
  }
  return j;
}

}  // namespace

void run_build_suite(const BenchConfig& cfg, SuiteReport& out) {
  out.ran = true;
  const std::vector<BuildInput> inputs = build_inputs(cfg.quick);
  // The variants' indices below: the page format on one thread and on --threads, and the set of
  // --threads one-thread builds at once (only with 2 threads or more: one alone is variant 1).
  constexpr size_t kOneThread = 1, kThreads = 2, kConcurrent = 3;
  const unsigned n = cfg.threads ? cfg.threads : default_thread_count();
  std::vector<Variant> variants = {{".vgeodag, 1 thread", ".vgeodag", 1, 0},
                                   {"page format, 1 thread", ".vgp", 1, 0},
                                   {"page format, --threads", ".vgp", cfg.threads, 0}};
  if (n >= 2) variants.push_back({"page format, --threads one-thread builds at once", ".vgp", 1, n});
  else out.notes.push_back("no throughput ceiling: it needs --threads 2 or more");
  const int reps = cfg.repetitions(3);
  const std::string dir = cfg.out_dir + "/build_runs";
  std::filesystem::create_directories(dir);
  out.summary =
      "`vgeo build MESH -o OUT` end to end, each run a child process: CPU = user + sys of the process (all threads), "
      "peak RSS = its VmHWM (the report's peak_rss_bytes), stage CPU from the build report's cpu_seconds (import / build / write). Median of " +
      std::to_string(reps) +
      " interleaved repetitions [min, max]. Default options: the page format (.vgp) at the default zstd level; the "
      ".vgeodag output is the lossless DAG file (no page encoding). The peer's figures are measured with the kit in "
      "../shared/peer beside this suite (docs/acceptance/).\n\n"
      "**Throughput ceiling.** One more variant starts N = --threads independent one-thread builds of the page format "
      "at once (each its own output file and report) and waits for all: they share the cores, caches, memory bandwidth "
      "and disk as an N-thread build's threads would, but have no serial part, no synchronization and no work to split. "
      "N x (a lone one-thread build's time) / (their time) is the most any N-thread build can gain on this machine, "
      "whatever its code: the ceiling. It is given for the whole build's wall (the set's: first start to last exit) and "
      "per stage (the build reports' wall seconds; the set's stage time is the children's median). The N-thread "
      "build's speedup t1/tN beside it, and the share of the ceiling it reaches = speedup / ceiling (= the set's time / "
      "(N x tN): one-thread time cancels). Each ratio is taken within one repetition, then the median. The write "
      "stage's ceiling involves the disk: every build ends with an fsync of its file and of the directory, and N builds "
      "at once meet there (their fsyncs queue on the same device), so it depends on where --out is (a tmpfs has no "
      "such wait).";
  Table table{"Builder CPU, wall time and peak memory per output and thread count",
              {"mesh", "output", "threads", "CPU", "wall", "peak RSS MiB", "import CPU", "build CPU", "write CPU", "same bytes"},
              {}};
  Table ceiling_table{"Throughput ceiling: " + std::to_string(n) + " one-thread builds at once against one " + std::to_string(n) +
                          "-thread build (wall seconds)",
                      {"mesh", "stage", "1 thread alone", std::to_string(n) + " threads", std::to_string(n) + " x 1 thread at once",
                       "ceiling N x t1 / set", "speedup t1 / tN", "share of the ceiling"},
                      {}};
  nlohmann::json rows = nlohmann::json::array();
  Progress progress("bench build", inputs.size(), cfg.progress);
  for (const BuildInput& in : inputs) {
    std::string path;
    try {
      path = materialize(in, dir);
    } catch (const std::exception& e) {
      out.notes.push_back(in.label + ": not measured: " + std::string(e.what()));
      progress.advance();
      continue;
    }
    out.inputs.push_back(in.label + ": " + (in.path.empty() ? "generate_mesh sphere, seed 1, written as OFF" : in.path));
    std::vector<std::vector<RunResult>> runs(variants.size());
    std::vector<ConcurrentRun> sets;
    auto output_of = [&](size_t v) { return dir + "/out" + std::to_string(v) + variants[v].extension; };
    try {
      for (int rep = 0; rep < reps; ++rep)
        for (size_t k = 0; k < variants.size(); ++k) {
          const size_t v = (k + size_t(rep)) % variants.size();
          if (variants[v].concurrent) {
            sets.push_back(run_concurrent_builds(path, dir, variants[v].concurrent));
            runs[v].push_back(set_row(sets.back()));
          } else {
            runs[v].push_back(run_build(path, output_of(v), dir + "/report.json", variants[v].threads));
          }
        }
    } catch (const std::exception& e) {
      out.notes.push_back(in.label + ": not measured: " + std::string(e.what()));
      progress.advance();
      continue;
    }
    // The page format's bytes do not depend on the thread count (spec: determinism), nor on
    // another build running beside it.
    const std::vector<uint8_t> one_thread_bytes = read_file(output_of(kOneThread));
    const bool same = one_thread_bytes == read_file(output_of(kThreads));
    if (!same) out.notes.push_back(in.label + ": the page format's bytes differ between 1 and --threads threads (a bug)");
    bool same_concurrent = true;
    if (!sets.empty())
      for (unsigned k = 0; k < n; ++k) same_concurrent = same_concurrent && read_file(concurrent_output(dir, k)) == one_thread_bytes;
    if (!same_concurrent) out.notes.push_back(in.label + ": the page format's bytes differ between builds run at once (a bug)");
    nlohmann::json mesh_rows = nlohmann::json::array();
    for (size_t v = 0; v < variants.size(); ++v) {
      auto stat = [&](auto field) {
        std::vector<double> xs;
        for (const RunResult& r : runs[v]) xs.push_back(field(r));
        return summarize(xs);
      };
      const Stats cpu = stat([](const RunResult& r) { return r.cpu; });
      const Stats wall = stat([](const RunResult& r) { return r.wall; });
      const Stats rss = stat([](const RunResult& r) { return r.rss_mib; });
      Stats stage[3], stage_wall[3];
      for (int s = 0; s < 3; ++s) {
        stage[s] = stat([s](const RunResult& r) { return r.stage_cpu[s]; });
        stage_wall[s] = stat([s](const RunResult& r) { return r.stage_wall[s]; });
      }
      const unsigned threads = variants[v].threads ? variants[v].threads : default_thread_count();
      const std::string same_cell = v == 0 ? "-" : ((v == kConcurrent ? same_concurrent : same) ? "yes" : "NO");
      table.rows.push_back({in.label, variants[v].extension,
                            variants[v].concurrent ? "1 (" + std::to_string(variants[v].concurrent) + " at once)" : std::to_string(threads),
                            fmt_stats_time(cpu), fmt_stats_time(wall), fmt(rss.median), fmt_time(stage[0].median),
                            fmt_time(stage[1].median), fmt_time(stage[2].median), same_cell});
      nlohmann::json row{{"output", variants[v].extension},
                         {"threads", threads},
                         {"cpu_seconds", to_json(cpu)},
                         {"wall_seconds", to_json(wall)},
                         {"peak_rss_mib", to_json(rss)},
                         {"stage_cpu_seconds", {{"import", to_json(stage[0])}, {"build", to_json(stage[1])}, {"write", to_json(stage[2])}}},
                         {"stage_seconds", {{"import", to_json(stage_wall[0])}, {"build", to_json(stage_wall[1])}, {"write", to_json(stage_wall[2])}}}};
      // The set's row: wall is the set's; CPU, stage times and peak RSS are one build's (the
      // children's median; the largest peak).
      if (variants[v].concurrent) row["concurrent_builds"] = variants[v].concurrent;
      mesh_rows.push_back(row);
    }
    nlohmann::json mesh{{"mesh", in.label}, {"same_bytes_any_threads", same}, {"runs", mesh_rows}};
    if (!sets.empty()) {
      mesh["same_bytes_at_once"] = same_concurrent;
      mesh["throughput_ceiling"] = report_ceiling(in.label, runs[kOneThread], runs[kThreads], sets, n, ceiling_table);
    }
    rows.push_back(mesh);
    progress.advance();
  }
  std::filesystem::remove_all(dir);
  out.tables.push_back(table);
  if (!ceiling_table.rows.empty()) out.tables.push_back(ceiling_table);
  out.data["meshes"] = rows;
}

}  // namespace vgeo::bench
