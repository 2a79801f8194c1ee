// `vgeo build INPUT -o OUT [--simplifier meshopt|openmesh] [--threads N] [--page-size SIZE]
// [--zstd-level L] [--error-bound measured|certified] [--report R.json]`: builds the cluster DAG of every mesh of INPUT and writes
// the page format (spec/format.md; a page file is named *.vgp), or a VGEODAG1 file (spec/dag.md) when OUT ends in .vgeodag.

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <map>
#include <stdexcept>
#include <string>
#include <nlohmann/json.hpp>

#include "bench_harness.h"
#include "commands.h"
#include "vgeo/core/file_io.h"
#include "vgeo/dag/build.h"
#include "vgeo/dag/dag_io.h"
#include "vgeo/format/asset_file.h"
#include "vgeo/core/error.h"
#include "vgeo/core/process_memory.h"
#include "vgeo/core/progress.h"
#include "vgeo/mesh/import.h"
#include "vgeo/render/run.h"

namespace vgeo::cli {

namespace {

struct BuildArgs {
  std::string input, output, report, simplifier = "meshopt", page_size, zstd_level, error_bound = "measured";
  bool edge_flips = true;
  bool vertex_placement = false;
  unsigned threads = 0;
};

// Every format the importer reads (glTF/GLB, OBJ, PLY, OFF, STL); every mesh of the scene is
// built. Import errors are VgeoErrors with their own codes and exit codes; warnings go to
// stderr and never stop the build.
Scene load_input(const std::string& path, unsigned threads) {
  ImportOptions options;
  options.threads = threads;  // the OFF reader's body by line ranges; the same scene for any count
  ImportResult imported = import_scene(path, options);
  for (const Warning& w : imported.warnings)
    std::fprintf(stderr, "warning[%s]: %s: %s\n", w.code.c_str(), path.c_str(), w.what.c_str());
  return std::move(imported.scene);
}

nlohmann::json report_json(const BuildReport& r) {
  nlohmann::json j;
  j["input_triangles"] = r.input_triangles;
  j["stored_triangles"] = r.stored_triangles;
  j["root_clusters"] = r.root_clusters;
  j["root_triangles"] = r.root_triangles;
  j["seconds"] = {{"cluster", r.seconds_cluster}, {"group", r.seconds_group},     {"simplify", r.seconds_simplify},
                  {"split", r.seconds_split},     {"hierarchy", r.seconds_hierarchy}, {"total", r.seconds_total},
                  {"prepare", r.seconds_prepare}, {"edges", r.seconds_edges},         {"locks", r.seconds_locks},
                  {"error", r.seconds_error},     {"combine", r.seconds_combine},     {"layout", r.seconds_layout}};
  j["peak_memory_bytes"] = r.peak_memory_bytes;
  j["levels"] = nlohmann::json::array();
  for (const BuildLevelReport& l : r.levels)
    j["levels"].push_back({{"level", l.level},
                           {"clusters", l.clusters},
                           {"triangles", l.triangles},
                           {"groups", l.groups},
                           {"stuck_groups", l.stuck_groups},
                           {"average_fill", l.average_fill},
                           {"boundary_edge_fraction", l.boundary_edge_fraction}});
  return j;
}

// --page-size: a size as --stream-budget takes it (parse_byte_size), which must be a page size
// the format accepts (power of two in [kMinPageSize, kMaxPageSize]). Smaller pages stream at a
// finer granularity; the default is Nanite's 128 KiB.
uint32_t parse_page_size(const std::string& text) {
  static_assert(kMinPageSize == 16u * 1024u && kMaxPageSize == 16u * 1024u * 1024u, "update the message below");
  uint64_t bytes = 0;
  const bool ok = parse_byte_size(text, &bytes) && bytes >= kMinPageSize && bytes <= kMaxPageSize &&
                  (bytes & (bytes - 1)) == 0;
  if (!ok)
    fail("BUILD_PAGE_SIZE", "vgeo build",
         "--page-size '" + text + "' is not a power of two in [16KiB, 16MiB] (e.g. 32KiB, 128KiB, 1MiB)", kExitUsage);
  return uint32_t(bytes);
}

// --zstd-level: an integer in [kMinZstdLevel, kMaxZstdLevel]. Higher levels give smaller pages
// for much more CPU; `vgeo bench compression` measures the curve behind kDefaultZstdLevel.
int parse_zstd_level(const std::string& text) {
  int level = 0;
  size_t used = 0;
  bool ok = false;
  try {
    level = std::stoi(text, &used);
    ok = used == text.size() && level >= kMinZstdLevel && level <= kMaxZstdLevel;
  } catch (const std::exception&) {
  }
  if (!ok)
    fail("BUILD_ZSTD_LEVEL", "vgeo build",
         "--zstd-level '" + text + "' is not an integer in [" + std::to_string(kMinZstdLevel) + ", " +
             std::to_string(kMaxZstdLevel) + "]",
         kExitUsage);
  return level;
}

const char* compression_name(Compression c) {
  return c == Compression::kZstd ? "zstd" : c == Compression::kLz4 ? "lz4" : "none";
}

// The page format's sizes: raw disk-form bytes per component (exact, free: the encoder knows
// them) and the compressed total. Pages are compressed whole, so a per-component compressed
// size would be an estimate costing a second compression of the asset: `vgeo bench
// compression` measures it.
nlohmann::json format_report_json(const FormatReport& r, const FormatOptions& o) {
  auto components = [](const ComponentBytes& c) {
    return nlohmann::json{{"positions", c.positions},   {"normals", c.normals},
                          {"uvs", c.uvs},               {"topology", c.topology},
                          {"materials", c.materials},   {"cluster_headers", c.cluster_headers},
                          {"vertex_refs", c.vertex_refs}, {"total", c.total()}};
  };
  uint64_t raw_pages = 0;
  for (const PageFill& p : r.pages) raw_pages += p.raw_bytes;
  nlohmann::json j;
  j["compression"] = compression_name(o.compression);
  if (o.compression == Compression::kZstd) j["zstd_level"] = o.zstd_level;
  j["page_size"] = o.page_size;
  j["pages"] = r.pages.size();
  j["file_bytes"] = r.file_bytes;
  j["metadata_bytes"] = r.metadata_bytes;
  j["metadata_raw_bytes"] = r.metadata_raw_bytes;
  j["pages_stored_bytes"] = r.pages_stored_bytes;
  j["pages_raw_bytes"] = raw_pages;
  j["disk_raw_bytes"] = components(r.disk_raw);
  j["memory_bytes"] = components(r.memory);
  j["stored_triangles"] = r.triangles;
  j["copied_vertices"] = r.copied_vertices;
  return j;
}

// One line per component: its share of the raw disk form, then the compressed total.
void print_format_sizes(const FormatReport& r) {
  const ComponentBytes& d = r.disk_raw;
  const double raw = d.total();
  if (raw <= 0) return;
  auto pct = [&](double v) { return 100.0 * v / raw; };
  std::printf("  disk form %.0f bytes before compression: positions %.0f%%, normals %.0f%%, uvs %.0f%%, topology %.0f%%, "
              "materials %.0f%%, headers %.0f%%, vertex copies %.0f%%; pages compressed to %llu bytes (%.2fx)\n",
              raw, pct(d.positions), pct(d.normals), pct(d.uvs), pct(d.topology), pct(d.materials),
              pct(d.cluster_headers), pct(d.vertex_refs), static_cast<unsigned long long>(r.pages_stored_bytes),
              r.pages_stored_bytes ? raw / double(r.pages_stored_bytes) : 0.0);
}

// A .vgeodag build whose peak RSS reached this keeps its freed heap for the write (see the
// callback): 32 MiB is ~25 times the write's buffers, and a build that large peaks in its own
// arrays (the 1M sphere's 105 MiB), while below it the peak is mostly code and fixed buffers.
constexpr uint64_t kKeepHeapPeakBytes = uint64_t(32) << 20;
// A .vgeodag build whose heap holds this much freed memory keeps it for the write too: twice
// the write's ~1.25 MiB of buffers, so they and the write's small allocations reuse pages that
// are resident already, and the peak stays near the build's own (its levels', 0.6-0.9 MiB
// above the RSS at the write). The trim cost 3-7 ms there, 2-3.5% of armadillo's and
// bunny00's builds (free heap 4.4 and 6.6 MiB), for 0.1-0.25 MiB of median peak (armadillo
// 9,576 -> 9,764 KiB, 1.15x -> 1.18x the peer's); lion, blade and the other small meshes (free
// heap 0.5-1.4 MiB, peaks within 0.3 MiB of the write's RSS) still trim
// (docs/acceptance/issue23_scratch38.md).
constexpr uint64_t kWriteReusesFreeHeapBytes = uint64_t(5) << 19;  // 2.5 MiB

}  // namespace

void add_build_command(CLI::App& app, Context& ctx) {
  auto args = std::make_shared<BuildArgs>();
  auto* cmd = app.add_subcommand(
      "build",
      "Build the cluster DAG of a mesh file and write the compressed page format (spec/format.md; name it *.vgp), or a "
      "lossless VGEODAG1 DAG file (spec/dag.md) when OUT ends in .vgeodag");
  cmd->add_option("input", args->input, "input scene (glTF/GLB, OBJ, PLY, OFF, STL)")->required();
  cmd->add_option("-o,--output", args->output,
                 "output asset: the page format (spec/format.md; name it *.vgp), or a lossless VGEODAG1 DAG file if it ends in .vgeodag")
      ->required();
  cmd->add_option("--simplifier", args->simplifier, "meshopt (default) or openmesh")
      ->check(CLI::IsMember({"meshopt", "openmesh"}));
  cmd->add_option("--threads", args->threads, "worker threads (0 = all cores); output is identical for any value");
  cmd->add_option("--page-size", args->page_size,
                  "page size of the page format: power of two in [16KiB, 16MiB] (default 128KiB); ignored for .vgeodag");
  cmd->add_option("--zstd-level", args->zstd_level,
                  "zstd level of the page format's pages and metadata: " + std::to_string(kMinZstdLevel) + ".." +
                      std::to_string(kMaxZstdLevel) + " (default " + std::to_string(kDefaultZstdLevel) +
                      "; `vgeo bench compression` measures size against CPU); ignored for .vgeodag");
  cmd->add_flag("!--no-edge-flips,--edge-flips", args->edge_flips,
                "--no-edge-flips: no edge flips towards the leaves after each simplification (on by default: fewer "
                "triangles at equal measured error; spec/dag.md, Edge flips)");
  cmd->add_flag("--vertex-placement,!--no-vertex-placement", args->vertex_placement,
                "move simplified vertices off the leaves along their normal: fewer triangles at equal measured error "
                "(gmean ~6% fewer with edge flips) for ~12% more DAG CPU and ~25% more peak memory (off by default; "
                "spec/dag.md, Place)");
  cmd->add_option("--error-bound", args->error_bound,
                  "what the stored errors promise: measured (default; the verify lattice's maximum, ERROR_BOUND) or "
                  "certified (an upper bound of the continuous deviation, ERROR_CERTIFIED; the same clusters, more build "
                  "time)")
      ->check(CLI::IsMember({"measured", "certified"}));
  cmd->add_option("--report", args->report, "write the build report as JSON");
  cmd->callback([args, &ctx] {
    std::error_code size_error;  // an unreadable input fails in the import
    const uintmax_t input_bytes = std::filesystem::file_size(args->input, size_error);
    prepare_build_heap(size_error ? 0 : uint64_t(input_bytes));  // before the first large allocation
    FormatOptions format_options;
    if (!args->page_size.empty()) format_options.page_size = parse_page_size(args->page_size);  // before the build
    if (!args->zstd_level.empty()) format_options.zstd_level = parse_zstd_level(args->zstd_level);
    format_options.threads = args->threads;  // pages encode in parallel; the bytes do not depend on it
    using clock = std::chrono::steady_clock;
    auto seconds_since = [](clock::time_point t) { return std::chrono::duration<double>(clock::now() - t).count(); };
    const double cpu_start = bench::cpu_seconds();
    const clock::time_point t_import = clock::now();
    Scene scene = load_input(args->input, args->threads);
    const double seconds_import = seconds_since(t_import);
    const double cpu_imported = bench::cpu_seconds();
    BuildOptions options;
    options.simplifier = args->simplifier == "openmesh" ? Simplifier::kOpenMesh : Simplifier::kMeshopt;
    options.threads = args->threads;
    if (args->error_bound == "certified") options.error_bound = ErrorBound::kCertified;
    options.edge_flips = args->edge_flips;
    options.vertex_placement = args->vertex_placement;
    options.progress = progress_wanted();
    std::vector<BuildReport> reports;
    // Only the meshes' names are read after the build: the scene is given up to it (each mesh's
    // triangle list becomes its leaf pass's, not copied; dag/build.h), and its geometry is
    // released before the write, whose buffers (and zstd's tables) then reuse its memory instead
    // of adding to the peak (docs/acceptance/issue23_rss.md).
    std::vector<std::string> mesh_names;
    for (const Mesh& m : scene.meshes) mesh_names.push_back(m.name);
    const clock::time_point t_build = clock::now();
    BuiltScene built = build_scene(std::move(scene), options, &reports);
    const double seconds_build = seconds_since(t_build);
    const double cpu_built = bench::cpu_seconds();
    scene = Scene();
    AssetFileKind kind = asset_file_kind_for_path(args->output);
    // The freed geometry and the build's freed state go back to the kernel: the write's buffers
    // and code then start from the live DAG instead of the build's high-water mark (armadillo
    // page format -0.9 MiB). (zstd's tables, 1.3-3.7 MB, have a huge-page mapping of their own:
    // lib/vgeo/format/container.cpp. Not trimming saved page faults but raised armadillo's
    // peak by ~2 MiB; docs/acceptance/issue23_write.md.) The
    // VGEODAG1 write streams the DAG through ~1.25 MiB of buffers: a large build's peak lies
    // far above what is live now, so there the trim is left out (on the 4M sphere it took
    // 0.05-0.1 s of one thread's time between the build and the write; the 1M sphere's peak
    // is the build's either way), and a small one's keeps it (lion's peak +0.3 MiB without)
    // unless its heap can hold the write (kWriteReusesFreeHeapBytes).
    uint64_t build_peak = 0;
    for (const BuildReport& r : reports) build_peak = std::max(build_peak, r.peak_memory_bytes);
    if (kind == AssetFileKind::kPages ||
        (build_peak < kKeepHeapPeakBytes && free_heap_bytes() < kWriteReusesFreeHeapBytes))
      release_free_heap();
    FormatReport format_report;
    const clock::time_point t_write = clock::now();
    write_asset_file(args->output, built, kind, format_options, &format_report);
    const double seconds_write = seconds_since(t_write);
    const double cpu_written = bench::cpu_seconds();
    if (kind == AssetFileKind::kPages)
    {
      std::printf("wrote %s: page format, %zu pages, %llu bytes (%s level %d)\n", args->output.c_str(),
                  format_report.pages.size(), static_cast<unsigned long long>(format_report.file_bytes),
                  compression_name(format_options.compression), format_options.zstd_level);
      print_format_sizes(format_report);
      // Quantization per mesh (spec/format.md §2): the steps chosen and the error they cause.
      for (size_t i = 0; i < format_report.meshes.size(); ++i) {
        const FormatReport::MeshQuantizationReport& m = format_report.meshes[i];
        std::printf("  mesh %zu quantization: position step 2^%d (max error %.3g)", i, m.quantization.position_step_log2,
                    m.position_max_error);
        if (m.quantization.has_uvs)
          std::printf(", uv step 2^%d (max error %.3g)", m.quantization.uv_step_log2, m.uv_max_error);
        std::printf("\n");
      }
    }
    for (size_t i = 0; i < reports.size(); ++i)
      std::fputs(build_report_summary(mesh_names[i].empty() ? std::to_string(i) : mesh_names[i], reports[i])
                     .c_str(),
                 stdout);
    // End to end: the per-mesh times above are the DAG builds alone.
    std::printf("import %.2fs, build %.2fs, write %.2fs\n", seconds_import, seconds_build, seconds_write);
    if (!args->report.empty()) {
      nlohmann::json j;
      j["input"] = args->input;
      j["seconds"] = {{"import", seconds_import}, {"build", seconds_build}, {"write", seconds_write}};
      // CPU of the stages, all threads (`vgeo bench build` reads it): on a shared machine the
      // stable measure, and the one the builder is compared by.
      j["peak_rss_bytes"] = peak_rss_bytes();  // the whole run: import, build and write
      j["cpu_seconds"] = {{"import", cpu_imported - cpu_start},
                          {"build", cpu_built - cpu_imported},
                          {"write", cpu_written - cpu_built}};
      j["output"] = args->output;
      j["simplifier"] = args->simplifier;
      j["error_bound"] = args->error_bound;
      j["edge_flips"] = args->edge_flips;
      j["vertex_placement"] = args->vertex_placement;
      if (kind == AssetFileKind::kPages) j["format"] = format_report_json(format_report, format_options);
      j["meshes"] = nlohmann::json::array();
      for (size_t i = 0; i < reports.size(); ++i) {
        nlohmann::json m = report_json(reports[i]);
        m["name"] = mesh_names[i];
        if (i < format_report.meshes.size()) {
          const FormatReport::MeshQuantizationReport& q = format_report.meshes[i];
          m["quantization"] = {{"position_step_log2", q.quantization.position_step_log2},
                               {"position_max_error", q.position_max_error},
                               {"uv_step_log2", q.quantization.uv_step_log2},
                               {"uv_max_error", q.uv_max_error}};
        }
        j["meshes"].push_back(m);
      }
      write_file_atomic(args->report, j.dump(2) + "\n");
    }
    ctx.exit_code = kExitOk;
  });
}

}  // namespace vgeo::cli
