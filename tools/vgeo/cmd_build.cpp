// `vgeo build INPUT -o OUT [--simplifier meshopt|openmesh] [--threads N] [--page-size SIZE]
// [--report R.json]`: builds the cluster DAG of every mesh of INPUT and writes the page format
// (spec/format.md), or a VGEODAG1 file (spec/dag.md) when OUT ends in .vgeodag.
#include <chrono>
#include <cstdio>
#include <map>
#include <nlohmann/json.hpp>

#include "commands.h"
#include "vgeo/core/file_io.h"
#include "vgeo/dag/build.h"
#include "vgeo/dag/dag_io.h"
#include "vgeo/format/asset_file.h"
#include "vgeo/core/error.h"
#include "vgeo/core/progress.h"
#include "vgeo/mesh/import.h"
#include "vgeo/render/run.h"

namespace vgeo::cli {

namespace {

struct BuildArgs {
  std::string input, output, report, simplifier = "meshopt", page_size;
  unsigned threads = 0;
};

// Every format the importer reads (glTF/GLB, OBJ, PLY, OFF, STL); every mesh of the scene is
// built. Import errors are VgeoErrors with their own codes and exit codes; warnings go to
// stderr and never stop the build.
Scene load_input(const std::string& path) {
  ImportResult imported = import_scene(path);
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

}  // namespace

void add_build_command(CLI::App& app, Context& ctx) {
  auto args = std::make_shared<BuildArgs>();
  auto* cmd = app.add_subcommand("build", "Build the cluster DAG of a mesh file (writes VGEODAG1, spec/dag.md)");
  cmd->add_option("input", args->input, "input scene (glTF/GLB, OBJ, PLY, OFF, STL)")->required();
  cmd->add_option("-o,--output", args->output,
                 "output asset: the page format (spec/format.md), or a lossless VGEODAG1 DAG file if it ends in .vgeodag")
      ->required();
  cmd->add_option("--simplifier", args->simplifier, "meshopt (default) or openmesh")
      ->check(CLI::IsMember({"meshopt", "openmesh"}));
  cmd->add_option("--threads", args->threads, "worker threads (0 = all cores); output is identical for any value");
  cmd->add_option("--page-size", args->page_size,
                  "page size of the page format: power of two in [16KiB, 16MiB] (default 128KiB); ignored for .vgeodag");
  cmd->add_option("--report", args->report, "write the build report as JSON");
  cmd->callback([args, &ctx] {
    FormatOptions format_options;
    if (!args->page_size.empty()) format_options.page_size = parse_page_size(args->page_size);  // before the build
    using clock = std::chrono::steady_clock;
    auto seconds_since = [](clock::time_point t) { return std::chrono::duration<double>(clock::now() - t).count(); };
    const clock::time_point t_import = clock::now();
    Scene scene = load_input(args->input);
    const double seconds_import = seconds_since(t_import);
    BuildOptions options;
    options.simplifier = args->simplifier == "openmesh" ? Simplifier::kOpenMesh : Simplifier::kMeshopt;
    options.threads = args->threads;
    options.progress = progress_wanted();
    std::vector<BuildReport> reports;
    const clock::time_point t_build = clock::now();
    BuiltScene built = build_scene(scene, options, &reports);
    const double seconds_build = seconds_since(t_build);
    AssetFileKind kind = asset_file_kind_for_path(args->output);
    FormatReport format_report;
    const clock::time_point t_write = clock::now();
    write_asset_file(args->output, built, kind, format_options, &format_report);
    const double seconds_write = seconds_since(t_write);
    if (kind == AssetFileKind::kPages)
    {
      std::printf("wrote %s: page format, %zu pages\n", args->output.c_str(), format_report.pages.size());
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
      std::fputs(build_report_summary(scene.meshes[i].name.empty() ? std::to_string(i) : scene.meshes[i].name, reports[i])
                     .c_str(),
                 stdout);
    // End to end: the per-mesh times above are the DAG builds alone.
    std::printf("import %.2fs, build %.2fs, write %.2fs\n", seconds_import, seconds_build, seconds_write);
    if (!args->report.empty()) {
      nlohmann::json j;
      j["input"] = args->input;
      j["seconds"] = {{"import", seconds_import}, {"build", seconds_build}, {"write", seconds_write}};
      j["output"] = args->output;
      j["simplifier"] = args->simplifier;
      j["meshes"] = nlohmann::json::array();
      for (size_t i = 0; i < reports.size(); ++i) {
        nlohmann::json m = report_json(reports[i]);
        m["name"] = scene.meshes[i].name;
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
