// `vgeo build INPUT -o OUT [--simplifier meshopt|openmesh] [--threads N] [--report R.json]`:
// builds the cluster DAG of every mesh of INPUT and writes a VGEODAG1 file (spec/dag.md).
#include <cstdio>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>

#include "commands.h"
#include "vgeo/build/build.h"
#include "vgeo/build/dag_io.h"
#include "vgeo/build/temp_import.h"
#include "vgeo/core/error.h"
#include "vgeo/core/progress.h"

namespace vgeo::cli {

namespace {

struct BuildArgs {
  std::string input, output, report, simplifier = "meshopt";
  unsigned threads = 0;
};

// TODO(lead): switch to vgeo::import_scene(path) from "vgeo/mesh/import.h" once merged,
// then delete lib/build/temp_import.*.
Scene load_input(const std::string& path) { return build_detail::read_mesh_file_temporary(path); }

nlohmann::json report_json(const BuildReport& r) {
  nlohmann::json j;
  j["input_triangles"] = r.input_triangles;
  j["stored_triangles"] = r.stored_triangles;
  j["root_clusters"] = r.root_clusters;
  j["root_triangles"] = r.root_triangles;
  j["seconds"] = {{"cluster", r.seconds_cluster}, {"group", r.seconds_group},     {"simplify", r.seconds_simplify},
                  {"split", r.seconds_split},     {"hierarchy", r.seconds_hierarchy}, {"total", r.seconds_total}};
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

void print_summary(const std::string& name, const BuildReport& r) {
  std::printf("mesh %s: %llu input triangles -> %llu stored (%.2fx), %llu root clusters (%llu triangles)\n",
              name.c_str(), (unsigned long long)r.input_triangles, (unsigned long long)r.stored_triangles,
              r.input_triangles ? double(r.stored_triangles) / double(r.input_triangles) : 0.0,
              (unsigned long long)r.root_clusters, (unsigned long long)r.root_triangles);
  std::printf("  level  clusters  triangles   groups  stuck  fill   border\n");
  for (const BuildLevelReport& l : r.levels)
    std::printf("  %5u  %8llu  %9llu  %7llu  %5llu  %4.0f%%  %5.1f%%\n", l.level, (unsigned long long)l.clusters,
                (unsigned long long)l.triangles, (unsigned long long)l.groups, (unsigned long long)l.stuck_groups,
                100.0 * l.average_fill, 100.0 * l.boundary_edge_fraction);
  std::printf("  time %.2fs (cluster %.2f, group %.2f, simplify %.2f, split %.2f, hierarchy %.2f), peak %.0f MiB\n",
              r.seconds_total, r.seconds_cluster, r.seconds_group, r.seconds_simplify, r.seconds_split,
              r.seconds_hierarchy, double(r.peak_memory_bytes) / (1 << 20));
}

}  // namespace

void add_build_command(CLI::App& app, Context& ctx) {
  auto args = std::make_shared<BuildArgs>();
  auto* cmd = app.add_subcommand("build", "Build the cluster DAG of a mesh file (writes VGEODAG1, spec/dag.md)");
  cmd->add_option("input", args->input, "input mesh (OFF, OBJ, PLY, STL)")->required();
  cmd->add_option("-o,--output", args->output, "output .vgeodag file")->required();
  cmd->add_option("--simplifier", args->simplifier, "meshopt (default) or openmesh")
      ->check(CLI::IsMember({"meshopt", "openmesh"}));
  cmd->add_option("--threads", args->threads, "worker threads (0 = all cores); output is identical for any value");
  cmd->add_option("--report", args->report, "write the build report as JSON");
  cmd->callback([args, &ctx] {
    Scene scene = load_input(args->input);
    BuildOptions options;
    options.simplifier = args->simplifier == "openmesh" ? Simplifier::kOpenMesh : Simplifier::kMeshopt;
    options.threads = args->threads;
    options.progress = progress_wanted();
    std::vector<BuildReport> reports;
    BuiltScene built = build_scene(scene, options, &reports);
    write_dag_file(args->output, built);
    for (size_t i = 0; i < reports.size(); ++i)
      print_summary(scene.meshes[i].name.empty() ? std::to_string(i) : scene.meshes[i].name, reports[i]);
    if (!args->report.empty()) {
      nlohmann::json j;
      j["input"] = args->input;
      j["output"] = args->output;
      j["simplifier"] = args->simplifier;
      j["meshes"] = nlohmann::json::array();
      for (size_t i = 0; i < reports.size(); ++i) {
        nlohmann::json m = report_json(reports[i]);
        m["name"] = scene.meshes[i].name;
        j["meshes"].push_back(m);
      }
      std::ofstream out(args->report);
      out << j.dump(2) << "\n";
      if (!out) fail("REPORT_IO", args->report, "cannot write the report", kExitIo);
    }
    ctx.exit_code = kExitOk;
  });
}

}  // namespace vgeo::cli
