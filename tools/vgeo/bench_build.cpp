// Suite "build": the builder end to end, as a user runs it. Each run is `vgeo build MESH -o OUT`
// in a child process of its own (so its peak RSS is its own, libraries and all): the DAG file
// (.vgeodag) and the page format (.vgp, the default output) on one thread, and the page format on
// --threads. Per run: process CPU (user + sys) from wait4, its peak RSS (VmHWM) and the CPU of
// each stage (import / build / write) from the build report, and wall time. Variants of a mesh
// run interleaved, the starting variant rotating per repetition (bench_harness.h), medians.
// The builder's CPU and memory goals are measured with it; the peer (meshoptimizer's
// clusterlod) is measured beside it with the kit in ../shared/peer, never built into vgeo
// (docs/acceptance/issue23_stop31.md holds the side-by-side table).
#include <spawn.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fcntl.h>

#include <cstdlib>
#include <cstring>
#include <stdexcept>
#include <filesystem>
#include <fstream>
#include <sstream>

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
  std::string extension;  // ".vgeodag" or ".vgp"
  unsigned threads = 1;   // 0: all cores
};

struct RunResult {
  double cpu = 0, wall = 0, rss_mib = 0;
  double stage_cpu[3] = {0, 0, 0};  // import, build, write (the build report's cpu_seconds)
};

// One `vgeo build` in a child process (this executable). Throws std::runtime_error on a failed run.
RunResult run_build(const std::string& input, const std::string& output, const std::string& report, unsigned threads) {
  const std::string threads_text = std::to_string(threads);
  std::vector<std::string> args = {"vgeo", "build", input, "-o", output, "--threads", threads_text, "--report", report};
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, "/dev/null", O_WRONLY, 0);
  posix_spawn_file_actions_addopen(&actions, STDERR_FILENO, "/dev/null", O_WRONLY, 0);
  const double t0 = now_seconds();
  pid_t pid = 0;
  const int spawned = posix_spawn(&pid, "/proc/self/exe", &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (spawned != 0) throw std::runtime_error("cannot start vgeo build: " + std::string(std::strerror(spawned)));
  int status = 0;
  rusage usage{};
  if (wait4(pid, &status, 0, &usage) != pid || !WIFEXITED(status) || WEXITSTATUS(status) != 0)
    throw std::runtime_error("vgeo build " + input + " failed (wait status " + std::to_string(status) + ")");
  RunResult r;
  r.wall = now_seconds() - t0;
  r.cpu = double(usage.ru_utime.tv_sec + usage.ru_stime.tv_sec) + 1e-6 * double(usage.ru_utime.tv_usec + usage.ru_stime.tv_usec);
  const nlohmann::json j = nlohmann::json::parse(read_text_file(report));
  // The child's own peak (its report's VmHWM): wait4's ru_maxrss would count this process's
  // address space, which the spawned child had before exec (lib/vgeo/core/process_memory.h).
  r.rss_mib = double(j.at("peak_rss_bytes").get<uint64_t>()) / (1024.0 * 1024.0);
  const char* stages[3] = {"import", "build", "write"};
  for (int s = 0; s < 3; ++s) r.stage_cpu[s] = j.at("cpu_seconds").at(stages[s]).get<double>();
  return r;
}

}  // namespace

void run_build_suite(const BenchConfig& cfg, SuiteReport& out) {
  out.ran = true;
  const std::vector<BuildInput> inputs = build_inputs(cfg.quick);
  const std::vector<Variant> variants = {{".vgeodag, 1 thread", ".vgeodag", 1},
                                         {"page format, 1 thread", ".vgp", 1},
                                         {"page format, --threads", ".vgp", cfg.threads}};
  const int reps = cfg.repetitions(3);
  const std::string dir = cfg.out_dir + "/build_runs";
  std::filesystem::create_directories(dir);
  out.summary =
      "`vgeo build MESH -o OUT` end to end, each run a child process: CPU = user + sys of the process (all threads), "
      "peak RSS = its VmHWM (the report's peak_rss_bytes), stage CPU from the build report's cpu_seconds (import / build / write). Median of " +
      std::to_string(reps) +
      " interleaved repetitions [min, max]. Default options: the page format (.vgp) at the default zstd level; the "
      ".vgeodag output is the lossless DAG file (no page encoding). The peer's figures are measured with the kit in "
      "../shared/peer beside this suite (docs/acceptance/).";
  Table table{"Builder CPU, wall time and peak memory per output and thread count",
              {"mesh", "output", "threads", "CPU", "wall", "peak RSS MiB", "import CPU", "build CPU", "write CPU", "same bytes"},
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
    auto output_of = [&](size_t v) { return dir + "/out" + std::to_string(v) + variants[v].extension; };
    try {
      for (int rep = 0; rep < reps; ++rep)
        for (size_t k = 0; k < variants.size(); ++k) {
          const size_t v = (k + size_t(rep)) % variants.size();
          runs[v].push_back(run_build(path, output_of(v), dir + "/report.json", variants[v].threads));
        }
    } catch (const std::exception& e) {
      out.notes.push_back(in.label + ": not measured: " + std::string(e.what()));
      progress.advance();
      continue;
    }
    // The page format's bytes do not depend on the thread count (spec: determinism).
    const bool same = read_file(output_of(1)) == read_file(output_of(2));
    if (!same) out.notes.push_back(in.label + ": the page format's bytes differ between 1 and --threads threads (a bug)");
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
      Stats stage[3];
      for (int s = 0; s < 3; ++s) stage[s] = stat([s](const RunResult& r) { return r.stage_cpu[s]; });
      const unsigned threads = variants[v].threads ? variants[v].threads : default_thread_count();
      table.rows.push_back({in.label, variants[v].extension, std::to_string(threads), fmt_stats_time(cpu),
                            fmt_stats_time(wall), fmt(rss.median), fmt_time(stage[0].median), fmt_time(stage[1].median),
                            fmt_time(stage[2].median), v == 0 ? "-" : (same ? "yes" : "NO")});
      mesh_rows.push_back({{"output", variants[v].extension},
                           {"threads", threads},
                           {"cpu_seconds", to_json(cpu)},
                           {"wall_seconds", to_json(wall)},
                           {"peak_rss_mib", to_json(rss)},
                           {"stage_cpu_seconds", {{"import", to_json(stage[0])}, {"build", to_json(stage[1])}, {"write", to_json(stage[2])}}}});
    }
    rows.push_back({{"mesh", in.label}, {"same_bytes_any_threads", same}, {"runs", mesh_rows}});
    progress.advance();
  }
  std::filesystem::remove_all(dir);
  out.tables.push_back(table);
  out.data["meshes"] = rows;
}

}  // namespace vgeo::bench
