// Suite "compression": what the page format's bytes cost in time. The same DAG encoded
// (encode_format, one thread) with every zstd level of a list, plus no compression and lz4 HC:
// file size against encode CPU time. The encode CPU with no compression is the quantization and
// page coding alone; the difference to it is what the compressor costs. This curve is where
// kDefaultZstdLevel (lib/vgeo/format/format.h) comes from. Also: the per-component split of the
// compressed size at the default level (measure_stream_compression: each component's streams
// compressed alone, an estimate the encoder never pays for), and the parallel encode's wall
// time at 1 thread against the configured threads (same bytes).
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <sstream>

#include "bench_suites.h"
#include "vgeo/core/progress.h"
#include "vgeo/core/thread_pool.h"
#include "vgeo/dag/build.h"
#include "vgeo/format/format.h"
#include "vgeo/format/format_measure.h"
#include "vgeo/mesh/generate.h"
#include "vgeo/mesh/import.h"

namespace vgeo::bench {
namespace {

struct CompressionInput {
  std::string label;
  std::string path;            // a mesh file, or empty: generated
  uint64_t gen_triangles = 0;  // generate_mesh sphere, seed 1
  bool keep_normals = false;   // generated: keep generate_mesh's smooth normals (else positions only, as OFF)
};

// VGEO_COMPRESSION_INPUTS: comma-separated mesh files or "sphere:N" / "sphere+normals:N" (normals and uvs)
// (replaces the defaults). Defaults: the meshes of the side-by-side table in
// docs/acceptance/issue23_asset.md when tools/fetch-data has fetched them, and one mesh with
// normals (their streams compress differently from positions).
std::vector<CompressionInput> compression_inputs(bool quick) {
  std::vector<CompressionInput> in;
  auto add_token = [&](const std::string& t) {
    const size_t colon = t.find(':');
    if (t.rfind("sphere:", 0) == 0) {
      in.push_back({"sphere " + t.substr(colon + 1), "", std::stoull(t.substr(colon + 1)), false});
    } else if (t.rfind("sphere+normals:", 0) == 0) {
      in.push_back({"sphere " + t.substr(colon + 1) + " + normals + uvs", "", std::stoull(t.substr(colon + 1)), true});
    } else {
      in.push_back({std::filesystem::path(t).stem().string(), t, 0, false});
    }
  };
  if (const char* env = std::getenv("VGEO_COMPRESSION_INPUTS"); env && *env) {
    std::stringstream ss(env);
    for (std::string t; std::getline(ss, t, ',');)
      if (!t.empty()) add_token(t);
    return in;
  }
  if (quick) return {{"sphere 20000", "", 20000, false}, {"sphere 20000 + normals + uvs", "", 20000, true}};
  in.push_back({"sphere 1000000", "", 1000000, false});
  for (const char* name : {"bunny00", "armadillo"}) {
    const std::string p = std::string("data/cgal/meshes/") + name + ".off";
    if (std::filesystem::exists(p)) in.push_back({name, p, 0, false});
  }
  in.push_back({"sphere 200000 + normals + uvs", "", 200000, true});
  return in;
}

// One encoder setting of the curve.
struct Codec {
  std::string label;
  Compression compression = Compression::kZstd;
  int level = 0;
};

std::vector<Codec> codec_list(bool quick) {
  std::vector<Codec> codecs{{"none", Compression::kNone, 0}, {"lz4 HC", Compression::kLz4, 0}};
  const std::vector<int> levels = quick ? std::vector<int>{1, 3, kDefaultZstdLevel, 19}
                                        : std::vector<int>{1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 15, 17, 19, 22};
  std::vector<int> unique_levels = levels;
  std::sort(unique_levels.begin(), unique_levels.end());
  unique_levels.erase(std::unique(unique_levels.begin(), unique_levels.end()), unique_levels.end());
  for (int l : unique_levels) codecs.push_back({"zstd " + std::to_string(l), Compression::kZstd, l});
  return codecs;
}

BuiltScene build_input(const CompressionInput& in, const BenchConfig& cfg, std::string* description) {
  Scene scene;
  if (in.path.empty()) {
    GenerateOptions g;
    g.shape = GenShape::kSphere;
    g.target_triangles = in.gen_triangles;
    g.seed = 1;
    g.threads = cfg.threads;
    scene = generate_scene(g);
    if (!in.keep_normals) {  // as `vgeo gen sphere -o X.off` writes it
      scene.meshes[0].normals.clear();
      scene.meshes[0].uvs.clear();
    }
    *description = in.label + ": generate_mesh sphere, seed 1" +
                   (in.keep_normals ? ", smooth normals and uvs" : ", positions only (as an OFF file)");
  } else {
    scene = import_scene(in.path).scene;
    *description = in.label + ": " + in.path;
  }
  BuildOptions bo;
  bo.threads = cfg.threads;
  return build_scene(scene, bo, nullptr);
}

// The default-level rule (kDefaultZstdLevel, lib/vgeo/format/format.h): per mesh, walk the lower
// convex hull of (compression CPU, file bytes) over the zstd levels from the cheapest point and stop
// before the first step that saves fewer than kRuleMinBytesPerCpuSecond bytes per CPU-second of
// compression; the default is the lowest of the meshes' stops (no mesh buys bytes at a worse rate).
// 0.5 MB/s: on the measured meshes the hull saves >= 0.85 MB/s up to level 6 and 0.20-0.35 MB/s
// after it on the 1M sphere and bunny00 (docs/acceptance/issue23_encspeed.md). The small meshes'
// compression takes milliseconds, so their slopes are noisy (armadillo's 6->13 step measured
// 0.34-0.53 MB/s); the lowest stop is decided by the sphere, whose seconds are not.
constexpr double kRuleMinBytesPerCpuSecond = 0.5e6;

struct CurvePoint {
  double cpu = 0, bytes = 0;
  int level = 0;
};
struct RulePick {
  int level = 0;
  std::vector<std::string> steps;  // "A->B: x MB/s" along the hull
};

RulePick pick_level_by_rule(std::vector<CurvePoint> pts) {
  std::sort(pts.begin(), pts.end(), [](const CurvePoint& a, const CurvePoint& b) {
    return a.cpu != b.cpu ? a.cpu < b.cpu : a.bytes < b.bytes;
  });
  std::vector<CurvePoint> hull;  // lower-left convex hull: CPU rising, bytes falling
  for (const CurvePoint& p : pts) {
    if (!hull.empty() && p.bytes >= hull.back().bytes) continue;
    while (hull.size() >= 2) {
      const CurvePoint &a = hull[hull.size() - 2], &b = hull.back();
      if ((b.bytes - a.bytes) * (p.cpu - a.cpu) >= (p.bytes - a.bytes) * (b.cpu - a.cpu)) hull.pop_back();
      else break;
    }
    hull.push_back(p);
  }
  RulePick r;
  if (hull.empty()) return r;
  r.level = hull[0].level;
  bool stopped = false;
  for (size_t i = 1; i < hull.size(); ++i) {
    const double saved_per_s = (hull[i - 1].bytes - hull[i].bytes) / std::max(hull[i].cpu - hull[i - 1].cpu, 1e-9);
    r.steps.push_back(std::to_string(hull[i - 1].level) + "->" + std::to_string(hull[i].level) + ": " +
                      fmt(saved_per_s / 1e6) + " MB/s");
    if (!stopped && saved_per_s >= kRuleMinBytesPerCpuSecond) r.level = hull[i].level;
    else stopped = true;
  }
  return r;
}

}  // namespace

void run_compression_suite(const BenchConfig& cfg, SuiteReport& out) {
  out.ran = true;
  const std::vector<CompressionInput> inputs = compression_inputs(cfg.quick);
  const std::vector<Codec> codecs = codec_list(cfg.quick);
  const int reps = cfg.repetitions(3);
  out.summary =
      "File size against encoder CPU time: each DAG encoded with encode_format (default options, one thread) for "
      "every codec; CPU seconds are process CPU, median of " +
      std::to_string(reps) +
      " interleaved repetitions. 'compress CPU' is the encode CPU minus that of no compression (quantization and "
      "page coding alone). kDefaultZstdLevel = " +
      std::to_string(kDefaultZstdLevel) +
      " is chosen from this curve (the rule: docs/acceptance/issue23_encspeed.md). 'components' splits the compressed size at "
      "the default level by compressing each component's streams alone per page (measure_stream_compression: an "
      "estimate, the pages compress them together). 'parallel' is the default encode's wall time at 1 thread and "
      "at --threads (bytes identical).";
  Table curve{"Size against compression CPU per codec",
              {"mesh", "codec", "file bytes", "bytes / stored tri", "size / level 19", "encode CPU", "compress CPU",
               "compress CPU / MB raw"},
              {}};
  Table parts{"Components at the default level: raw disk form, and each compressed alone (estimate)",
              {"mesh", "component", "raw bytes", "compressed alone", "ratio"},
              {}};
  Table rule{"Default level by the rule: lower convex hull of (compress CPU, file bytes), stop before a step saving < " +
                 fmt(kRuleMinBytesPerCpuSecond / 1e6) + " MB per CPU-second",
             {"mesh", "hull steps (bytes saved per compression CPU-second)", "rule's level", "default"},
             {}};
  Table parallel{"Parallel encode (default options): wall time, bytes identical",
                 {"mesh", "1 thread", "threads", "wall", "speedup", "same bytes"},
                 {}};
  nlohmann::json rows = nlohmann::json::array();
  std::vector<Series> curve_series;
  int lowest_pick = kMaxZstdLevel;  // the rule's default: the lowest of the meshes' stops
  Progress progress("bench compression", inputs.size(), cfg.progress);
  for (size_t mi = 0; mi < inputs.size(); ++mi) {
    const CompressionInput& in = inputs[mi];
    std::string description;
    BuiltScene scene;
    try {
      scene = build_input(in, cfg, &description);
    } catch (const VgeoError& e) {
      out.notes.push_back(in.label + ": not measured: " + e.error().line());
      progress.advance();
      continue;
    }
    uint64_t stored_triangles = 0;
    for (const ClusterDag& d : scene.meshes) stored_triangles += d.triangle_count();
    out.inputs.push_back(description + ", " + std::to_string(stored_triangles) + " stored triangles");

    std::vector<std::vector<uint8_t>> files(codecs.size());
    std::vector<FormatReport> reports(codecs.size());
    auto options = [&](size_t v) {
      FormatOptions o;
      o.compression = codecs[v].compression;
      if (codecs[v].compression == Compression::kZstd) o.zstd_level = codecs[v].level;
      o.threads = 1;
      return o;
    };
    const Samples samples = time_interleaved(reps, codecs.size(), [&](size_t v) {
      files[v] = encode_format(scene, options(v), &reports[v]);
    });
    const double none_cpu = summarize(samples.cpu[0]).median;
    double level19_bytes = 0;
    for (size_t v = 0; v < codecs.size(); ++v)
      if (codecs[v].compression == Compression::kZstd && codecs[v].level == 19) level19_bytes = double(files[v].size());
    const double raw_mb = double(files[0].size()) / 1e6;  // no compression: the raw file
    Series s = named_series(in.label);
    std::vector<CurvePoint> curve_points;
    nlohmann::json codec_rows = nlohmann::json::array();
    for (size_t v = 0; v < codecs.size(); ++v) {
      const Stats cpu = summarize(samples.cpu[v]);
      const double compress_cpu = std::max(0.0, cpu.median - none_cpu);
      const double bytes = double(files[v].size());
      curve.rows.push_back({in.label, codecs[v].label + (codecs[v].compression == Compression::kZstd &&
                                                                 codecs[v].level == kDefaultZstdLevel
                                                             ? " (default)"
                                                             : ""),
                            std::to_string(files[v].size()), fmt(bytes / double(std::max<uint64_t>(1, stored_triangles))),
                            level19_bytes > 0 ? fmt(bytes / level19_bytes) : "-", fmt_stats_time(cpu),
                            fmt_time(compress_cpu), fmt_time(raw_mb > 0 ? compress_cpu / raw_mb : 0)});
      codec_rows.push_back({{"codec", codecs[v].label},
                            {"compression", int(codecs[v].compression)},
                            {"zstd_level", codecs[v].level},
                            {"file_bytes", files[v].size()},
                            {"pages_stored_bytes", reports[v].pages_stored_bytes},
                            {"metadata_bytes", reports[v].metadata_bytes},
                            {"encode_cpu_seconds", to_json(cpu)},
                            {"compress_cpu_seconds", compress_cpu}});
      if (codecs[v].compression == Compression::kZstd) {
        curve_points.push_back({compress_cpu, bytes, codecs[v].level});
        s.x.push_back(std::max(compress_cpu, 1e-4));
        s.y.push_back(level19_bytes > 0 ? bytes / level19_bytes : bytes);
      }
    }
    curve_series.push_back(s);
    const RulePick pick = pick_level_by_rule(curve_points);
    std::string steps;
    for (const std::string& st : pick.steps) steps += (steps.empty() ? "" : ", ") + st;
    rule.rows.push_back({in.label, steps, std::to_string(pick.level), std::to_string(kDefaultZstdLevel)});
    lowest_pick = std::min(lowest_pick, pick.level);

    // The per-component split at the default level (one more compression of the asset).
    FormatOptions def;
    FormatReport def_report;
    const std::vector<uint8_t> def_file = encode_format(scene, def, &def_report);
    const ComponentBytes alone = measure_stream_compression(scene, def_file, def);
    const ComponentBytes& raw = def_report.disk_raw;
    const std::pair<const char*, double ComponentBytes::*> components[] = {
        {"positions", &ComponentBytes::positions},   {"normals", &ComponentBytes::normals},
        {"uvs", &ComponentBytes::uvs},               {"topology", &ComponentBytes::topology},
        {"materials", &ComponentBytes::materials},   {"cluster headers", &ComponentBytes::cluster_headers},
        {"vertex copies", &ComponentBytes::vertex_refs}};
    nlohmann::json parts_json = nlohmann::json::object();
    for (const auto& [name, field] : components) {
      if (raw.*field == 0) continue;
      parts.rows.push_back({in.label, name, fmt(raw.*field), fmt(alone.*field), fmt(raw.*field / std::max(1.0, alone.*field))});
      parts_json[name] = {{"raw_bytes", raw.*field}, {"compressed_alone_bytes", alone.*field}};
    }
    parts.rows.push_back({in.label, "all (pages compressed whole)", fmt(raw.total()), fmt(double(def_report.pages_stored_bytes)),
                          fmt(raw.total() / std::max(1.0, double(def_report.pages_stored_bytes)))});

    // Parallel encode: wall time at 1 thread and at cfg.threads, same bytes.
    FormatOptions one = def, many = def;
    one.threads = 1;
    many.threads = cfg.threads;
    std::vector<std::vector<uint8_t>> par(2);
    const Samples ps = time_interleaved(reps, 2, [&](size_t v) { par[v] = encode_format(scene, v == 0 ? one : many); });
    const Stats w1 = summarize(ps.wall[0]), wn = summarize(ps.wall[1]);
    const bool same = par[0] == par[1] && par[0] == def_file;
    parallel.rows.push_back({in.label, fmt_stats_time(w1), std::to_string(many.threads ? many.threads : default_thread_count()),
                             fmt_stats_time(wn), fmt(w1.median / std::max(1e-9, wn.median)), same ? "yes" : "NO"});
    if (!same) out.notes.push_back(in.label + ": the parallel encode's bytes differ from one thread's (a bug)");

    rows.push_back({{"mesh", in.label},
                    {"stored_triangles", stored_triangles},
                    {"rule_level", pick.level},
                    {"codecs", codec_rows},
                    {"components_at_default_level", parts_json},
                    {"parallel", {{"threads", many.threads}, {"wall_1", to_json(w1)}, {"wall_n", to_json(wn)}, {"same_bytes", same}}}});
    progress.advance();
  }
  out.tables.push_back(curve);
  if (!rule.rows.empty()) {
    rule.rows.push_back({"all meshes", "the lowest stop", std::to_string(lowest_pick), std::to_string(kDefaultZstdLevel)});
    if (lowest_pick != kDefaultZstdLevel)
      out.notes.push_back("the default-level rule picks level " + std::to_string(lowest_pick) + ", not the default " +
                          std::to_string(kDefaultZstdLevel) + " (a quick run's short level list, or the curve moved)");
    out.data["rule_level"] = lowest_pick;
  }
  out.tables.push_back(rule);
  out.tables.push_back(parts);
  out.tables.push_back(parallel);
  out.data["default_zstd_level"] = kDefaultZstdLevel;
  out.data["rule_min_bytes_per_cpu_second"] = kRuleMinBytesPerCpuSecond;
  out.data["meshes"] = rows;
  add_plot(out, cfg, "compression_curve.svg",
           Plot{"Size against compression CPU (zstd levels)", "compression CPU seconds (encode minus no compression)",
                "file size / level 19", true, false, curve_series},
           "Each point is one zstd level (left to right: faster to slower); size relative to level 19");
}

}  // namespace vgeo::bench
