#pragma once
// `vgeo bench` harness: repeated, interleaved timing with medians and spread, machine
// description, and a report model written as report.md + report.json (+ SVG plots).
// The machine running the benchmarks may be shared, so every timing is a median over
// repetitions and every comparison is a per-repetition ratio of variants run back to back.
#include <chrono>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "bench_svg.h"

namespace vgeo::bench {

// Summary of repeated measurements (seconds, or any unit for ratios).
struct Stats {
  double median = 0, min = 0, max = 0, q1 = 0, q3 = 0;
  size_t count = 0;
};
Stats summarize(std::vector<double> samples);
nlohmann::json to_json(const Stats& s);

inline double now_seconds() {
  using namespace std::chrono;
  return duration<double>(steady_clock::now().time_since_epoch()).count();
}
// CPU time of the whole process (all threads). On a shared machine this is far less noisy
// than wall time: time spent preempted by other processes is not counted.
double cpu_seconds();

// Samples of repeated runs: wall-clock and process CPU seconds, per variant.
struct Samples {
  std::vector<std::vector<double>> wall, cpu;
};

// Runs every variant once per repetition, rotating the starting variant each repetition so
// slow drift (other processes, thermal state) hits every variant alike. `setup(v, rep)` runs
// untimed right before variant v.
Samples time_interleaved(
    int repetitions, size_t variant_count, const std::function<void(size_t variant)>& run,
    const std::function<void(size_t variant)>& setup = {});

// How many calls of run(v) make one sample of at least `target_seconds` CPU time (short samples are
// dominated by timer and scheduling noise). Also warms caches and the allocator up.
std::vector<int> calibrate_batches(size_t variant_count, const std::function<void(size_t variant)>& run,
                                   double target_seconds, const std::function<void(size_t variant)>& setup = {});

// Per-repetition ratios samples[a][i] / samples[b][i] (same repetition = side by side).
Stats ratio_stats(const std::vector<double>& a, const std::vector<double>& b);

struct BenchConfig {
  bool quick = false;
  int repeat = 0;          // 0: the suite's default (quick: 3)
  unsigned threads = 0;    // 0: hardware concurrency
  std::string out_dir;
  bool progress = false;   // terminal progress on stderr
  int repetitions(int full_default) const {
    if (repeat > 0) return repeat;
    // Quick runs only keep the harness alive: the fewest repetitions that still give a median.
    return quick ? 3 : full_default;
  }
};

// A table in the report: header row + string cells.
struct Table {
  std::string caption;
  std::vector<std::string> columns;
  std::vector<std::vector<std::string>> rows;
};

// One suite's section of the report.
struct SuiteReport {
  std::string name;
  bool ran = false;
  std::string failure;             // when !ran: the error that stopped the suite (one line)
  std::string summary;             // what was measured, one paragraph
  std::vector<std::string> inputs; // input descriptions
  std::vector<Table> tables;
  std::vector<std::pair<std::string, std::string>> plots;  // (file name, caption)
  std::vector<std::string> notes;
  nlohmann::json data = nlohmann::json::object();
  double seconds = 0;              // wall time of the suite
};

struct MachineInfo {
  std::string cpu_model, compiler, build_flags, command_line, hostname, started_utc;
  unsigned logical_cores = 0;
  uint64_t memory_bytes = 0;
  std::string load_average_start, load_average_end;
};
MachineInfo describe_machine();
std::string read_load_average();

// Saves an SVG plot into cfg.out_dir and records it in the suite report.
void add_plot(SuiteReport& suite, const BenchConfig& cfg, const std::string& file_name,
              const Plot& plot, const std::string& caption);

// Writes DIR/report.md and DIR/report.json. Throws VgeoError (IO) on failure.
void write_reports(const BenchConfig& cfg, const MachineInfo& machine,
                   const std::vector<SuiteReport>& suites, double total_seconds);

// Number formatting for tables.
std::string fmt(double v, int significant = 3);
std::string fmt_time(double seconds);        // "12.3 ms", "4.56 us"
std::string fmt_stats_time(const Stats& s);  // "median [min, max]"
std::string fmt_ratio(const Stats& s);       // "0.123x [0.11, 0.13]"

}  // namespace vgeo::bench
