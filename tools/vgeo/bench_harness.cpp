#include "bench_harness.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

#include "vgeo/core/file_io.h"
#include "vgeo/core/error.h"

namespace vgeo::bench {

namespace {

// Linear interpolation between closest ranks (the usual "type 7" quantile).
double quantile(const std::vector<double>& sorted, double q) {
  if (sorted.empty()) return 0;
  double pos = q * double(sorted.size() - 1);
  size_t i = size_t(std::floor(pos));
  size_t j = std::min(i + 1, sorted.size() - 1);
  double f = pos - double(i);
  return sorted[i] * (1 - f) + sorted[j] * f;
}

// A /proc pseudo-file (its size is not known before reading; not a vgeo input).
std::string read_proc_file(const char* path) {
  std::ifstream f(path, std::ios::binary);
  std::ostringstream s;
  s << f.rdbuf();
  return s.str();
}

std::string trim(std::string s) {
  while (!s.empty() && (s.back() == '\n' || s.back() == ' ' || s.back() == '\t')) s.pop_back();
  size_t b = s.find_first_not_of(" \t");
  return b == std::string::npos ? std::string() : s.substr(b);
}

void write_text(const std::filesystem::path& path, const std::string& text) { write_file_atomic(path.string(), text); }

std::string md_cell(const std::string& s) {
  std::string o;
  for (char c : s) o += c == '|' ? std::string("\\|") : std::string(1, c);
  return o;
}

}  // namespace

Stats summarize(std::vector<double> samples) {
  Stats s;
  std::vector<double> v;
  for (double x : samples)
    if (std::isfinite(x)) v.push_back(x);
  s.count = v.size();
  if (v.empty()) return s;
  std::sort(v.begin(), v.end());
  s.min = v.front();
  s.max = v.back();
  s.median = quantile(v, 0.5);
  s.q1 = quantile(v, 0.25);
  s.q3 = quantile(v, 0.75);
  return s;
}

nlohmann::json to_json(const Stats& s) {
  return {{"median", s.median}, {"min", s.min}, {"max", s.max}, {"q1", s.q1}, {"q3", s.q3}, {"count", s.count}};
}

double cpu_seconds() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

Samples time_interleaved(int repetitions, size_t variant_count, const std::function<void(size_t)>& run,
                         const std::function<void(size_t)>& setup) {
  Samples s;
  s.wall.resize(variant_count);
  s.cpu.resize(variant_count);
  for (int rep = 0; rep < repetitions; ++rep) {
    for (size_t k = 0; k < variant_count; ++k) {
      size_t v = (k + size_t(rep)) % variant_count;  // rotate the start: no variant always goes first
      if (setup) setup(v);
      double c0 = cpu_seconds(), t0 = now_seconds();
      run(v);
      double t1 = now_seconds(), c1 = cpu_seconds();
      s.wall[v].push_back(t1 - t0);
      s.cpu[v].push_back(c1 - c0);
    }
  }
  return s;
}

std::vector<int> calibrate_batches(size_t variant_count, const std::function<void(size_t)>& run,
                                   double target_seconds, const std::function<void(size_t)>& setup) {
  // Cap: never more than this many calls per sample, whatever the timer says.
  constexpr int kMaxBatch = 1 << 16;
  std::vector<int> batch(variant_count, 1);
  for (size_t v = 0; v < variant_count; ++v) {
    if (setup) setup(v);
    run(v);  // warm-up
    if (setup) setup(v);
    double t0 = cpu_seconds();
    run(v);
    double t = cpu_seconds() - t0;
    batch[v] = t >= target_seconds ? 1 : std::min(kMaxBatch, int(std::ceil(target_seconds / std::max(t, 1e-9))));
  }
  return batch;
}

Stats ratio_stats(const std::vector<double>& a, const std::vector<double>& b) {
  std::vector<double> r;
  for (size_t i = 0; i < a.size() && i < b.size(); ++i)
    if (b[i] > 0) r.push_back(a[i] / b[i]);
  return summarize(r);
}

std::string read_load_average() {
  // The first three fields: 1, 5 and 15 minute load averages.
  std::istringstream in(read_proc_file("/proc/loadavg"));
  std::string a, b, c;
  in >> a >> b >> c;
  return a + " " + b + " " + c;
}

MachineInfo describe_machine() {
  MachineInfo m;
  std::istringstream cpu(read_proc_file("/proc/cpuinfo"));
  for (std::string line; std::getline(cpu, line);) {
    if (line.rfind("model name", 0) == 0) {
      m.cpu_model = trim(line.substr(line.find(':') + 1));
      break;
    }
  }
  if (m.cpu_model.empty()) m.cpu_model = "unknown";
  m.logical_cores = std::thread::hardware_concurrency();
  std::istringstream mem(read_proc_file("/proc/meminfo"));
  for (std::string line; std::getline(mem, line);) {
    if (line.rfind("MemTotal:", 0) == 0) {
      m.memory_bytes = std::strtoull(line.c_str() + 9, nullptr, 10) * 1024ull;
      break;
    }
  }
#if defined(__clang__)
  m.compiler = std::string("clang ") + __clang_version__;
#elif defined(__GNUC__)
  m.compiler = std::string("gcc ") + __VERSION__;
#else
  m.compiler = "unknown";
#endif
  // CMake's build type is not visible to the code; report what the compiler was told.
#if defined(__OPTIMIZE__)
  m.build_flags = "optimized";
#else
  m.build_flags = "not optimized (-O0)";
#endif
#if defined(NDEBUG)
  m.build_flags += ", NDEBUG (asserts off)";
#else
  m.build_flags += ", asserts on";
#endif
#if defined(__SANITIZE_ADDRESS__)
  m.build_flags += ", AddressSanitizer";
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
  m.build_flags += ", AddressSanitizer";
#endif
#endif
  std::string cmd = read_proc_file("/proc/self/cmdline");
  for (char& c : cmd)
    if (c == '\0') c = ' ';
  m.command_line = trim(cmd);
  char host[256] = {};
  if (gethostname(host, sizeof host - 1) == 0) m.hostname = host;
  std::time_t t = std::time(nullptr);
  char buf[64];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&t));
  m.started_utc = buf;
  m.load_average_start = read_load_average();
  return m;
}

void add_plot(SuiteReport& suite, const BenchConfig& cfg, const std::string& file_name, const Plot& plot,
              const std::string& caption) {
  write_text(std::filesystem::path(cfg.out_dir) / file_name, render_svg(plot));
  suite.plots.emplace_back(file_name, caption);
}

std::string fmt(double v, int significant) {
  if (!std::isfinite(v)) return std::isnan(v) ? "nan" : (v > 0 ? "inf" : "-inf");
  char b[48];
  double a = std::fabs(v);
  if (a != 0 && (a >= 1e7 || a < 1e-4)) std::snprintf(b, sizeof b, "%.*e", std::max(0, significant - 1), v);
  else if (a >= std::pow(10.0, significant)) std::snprintf(b, sizeof b, "%.0f", v);
  else std::snprintf(b, sizeof b, "%.*g", significant, v);
  return b;
}

std::string fmt_time(double s) {
  if (!std::isfinite(s)) return fmt(s);
  double a = std::fabs(s);
  if (a >= 1) return fmt(s) + " s";
  if (a >= 1e-3) return fmt(s * 1e3) + " ms";
  if (a >= 1e-6) return fmt(s * 1e6) + " us";
  return fmt(s * 1e9) + " ns";
}

std::string fmt_stats_time(const Stats& s) {
  return fmt_time(s.median) + " [" + fmt_time(s.min) + ", " + fmt_time(s.max) + "]";
}

std::string fmt_ratio(const Stats& s) {
  return fmt(s.median) + "x [" + fmt(s.min) + ", " + fmt(s.max) + "]";
}

void write_reports(const BenchConfig& cfg, const MachineInfo& machine, const std::vector<SuiteReport>& suites,
                   double total_seconds) {
  namespace fs = std::filesystem;
  std::string load_end = read_load_average();

  // ---- JSON ----
  nlohmann::json j;
  j["schema"] = "vgeo-bench/1";
  j["machine"] = {{"cpu_model", machine.cpu_model},
                  {"logical_cores", machine.logical_cores},
                  {"memory_bytes", machine.memory_bytes},
                  {"hostname", machine.hostname},
                  {"load_average_start", machine.load_average_start},
                  {"load_average_end", load_end}};
  j["build"] = {{"compiler", machine.compiler}, {"flags", machine.build_flags}};
  j["run"] = {{"command_line", machine.command_line},
              {"started_utc", machine.started_utc},
              {"quick", cfg.quick},
              {"repeat", cfg.repeat},
              {"threads", cfg.threads == 0 ? machine.logical_cores : cfg.threads},
              {"total_seconds", total_seconds}};
  j["suites"] = nlohmann::json::array();
  for (const SuiteReport& s : suites) {
    nlohmann::json js{{"name", s.name},
                      {"ran", s.ran},
                      {"status", s.ran ? "ran" : "failed"},
                      {"seconds", s.seconds}};
    if (!s.ran) js["failure"] = s.failure;
    js["inputs"] = s.inputs;
    js["notes"] = s.notes;
    js["plots"] = nlohmann::json::array();
    for (const auto& p : s.plots) js["plots"].push_back(p.first);
    js["data"] = s.data;
    j["suites"].push_back(js);
  }
  write_text(fs::path(cfg.out_dir) / "report.json", j.dump(2) + "\n");

  // ---- Markdown ----
  std::ostringstream md;
  md << "# vgeo bench report\n\n";
  md << "Generated by `vgeo bench` (tools/vgeo/cmd_bench.cpp). Every time is the **median** over "
        "repetitions with [min, max]; every ratio is the median of per-repetition ratios of variants run "
        "back to back in the same repetition (variant order rotated each repetition).\n\n";
  md << "| | |\n|---|---|\n";
  md << "| command | `" << md_cell(machine.command_line) << "` |\n";
  md << "| started (UTC) | " << machine.started_utc << " |\n";
  md << "| CPU | " << md_cell(machine.cpu_model) << " |\n";
  md << "| logical cores | " << machine.logical_cores << " |\n";
  md << "| memory | " << fmt(double(machine.memory_bytes) / double(1ull << 30)) << " GiB |\n";
  md << "| compiler | " << md_cell(machine.compiler) << " |\n";
  md << "| build | " << machine.build_flags << " |\n";
  md << "| threads | " << (cfg.threads == 0 ? machine.logical_cores : cfg.threads) << " |\n";
  md << "| mode | " << (cfg.quick ? "--quick (smoke sizes: numbers are indicative only)" : "full") << " |\n";
  md << "| load average (1/5/15 min, start → end) | " << machine.load_average_start << " → " << load_end << " |\n";
  md << "| total wall time | " << fmt_time(total_seconds) << " |\n\n";
  md << "The load average shows whether other processes competed for the cores during the run "
        "(a shared machine makes absolute times noisy; medians and interleaved ratios are the "
        "numbers to trust).\n\n";
  md << "## Suites\n\n";
  for (const SuiteReport& s : suites) {
    md << "- **" << s.name << "**: ";
    if (s.ran) md << "ran (" << fmt_time(s.seconds) << ")\n";
    else md << "failed: " << md_cell(s.failure) << "\n";
  }
  md << "\n";
  for (const SuiteReport& s : suites) {
    md << "## " << s.name << "\n\n";
    if (!s.ran) {
      md << "suite " << s.name << ": failed: " << s.failure << "\n\n";
      continue;
    }
    if (!s.summary.empty()) md << s.summary << "\n\n";
    if (!s.inputs.empty()) {
      md << "Inputs:\n\n";
      for (const std::string& in : s.inputs) md << "- " << in << "\n";
      md << "\n";
    }
    for (const Table& t : s.tables) {
      if (!t.caption.empty()) md << "**" << t.caption << "**\n\n";
      md << "|";
      for (const std::string& c : t.columns) md << " " << md_cell(c) << " |";
      md << "\n|";
      for (size_t i = 0; i < t.columns.size(); ++i) md << "---|";
      md << "\n";
      for (const auto& row : t.rows) {
        md << "|";
        for (const std::string& c : row) md << " " << md_cell(c) << " |";
        md << "\n";
      }
      md << "\n";
    }
    for (const auto& p : s.plots) md << "![" << p.second << "](" << p.first << ")\n\n*" << p.second << "*\n\n";
    if (!s.notes.empty()) {
      for (const std::string& n : s.notes) md << "- " << n << "\n";
      md << "\n";
    }
  }
  write_text(fs::path(cfg.out_dir) / "report.md", md.str());
}

}  // namespace vgeo::bench
