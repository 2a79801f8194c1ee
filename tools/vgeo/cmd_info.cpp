// `vgeo info FILE [--json] [--weld]`: import a mesh/scene with full validation and print what
// it contains (counts, bounds, materials, instances, warnings, import stats).
#include <cstdio>
#include <nlohmann/json.hpp>
#include <string>

#include "commands.h"
#include "vgeo/core/error.h"
#include "vgeo/mesh/import.h"

namespace vgeo::cli {
namespace {

struct InfoArgs {
  std::string path;
  bool json = false;
  bool weld = false;
};

// World-space bounds of every instance's transformed vertices (affine transforms).
Aabb scene_bounds(const Scene& scene) {
  Aabb world;
  for (const Instance& inst : scene.instances) {
    const Mesh& mesh = scene.meshes[inst.mesh];
    const auto& m = inst.transform;
    for (size_t v = 0; v < mesh.vertex_count(); ++v) {
      Vec3 p = mesh.position(v);
      world.extend(Vec3{m[0] * p.x + m[4] * p.y + m[8] * p.z + m[12], m[1] * p.x + m[5] * p.y + m[9] * p.z + m[13],
                        m[2] * p.x + m[6] * p.y + m[10] * p.z + m[14]});
    }
  }
  return world;
}

nlohmann::json vec_json(Vec3 v) { return nlohmann::json::array({v.x, v.y, v.z}); }

void run_info(const InfoArgs& args) {
  ImportOptions options;
  options.weld = args.weld;
  ImportResult r = import_scene(args.path, options);
  const Scene& s = r.scene;

  size_t mesh_triangles = 0, mesh_vertices = 0, instanced_triangles = 0;
  for (const Mesh& m : s.meshes) {
    mesh_triangles += m.triangle_count();
    mesh_vertices += m.vertex_count();
  }
  for (const Instance& i : s.instances) instanced_triangles += s.meshes[i.mesh].triangle_count();
  const Aabb bounds = scene_bounds(s);

  if (args.json) {
    nlohmann::json j;
    j["file"] = args.path;
    j["triangles"] = mesh_triangles;
    j["vertices"] = mesh_vertices;
    j["instanced_triangles"] = instanced_triangles;
    j["bounds"] = {{"min", vec_json(bounds.min)}, {"max", vec_json(bounds.max)}};
    j["meshes"] = nlohmann::json::array();
    for (const Mesh& m : s.meshes) {
      MeshStats st = mesh_stats(m);
      j["meshes"].push_back({{"name", m.name},
                             {"triangles", st.triangles},
                             {"vertices", st.vertices},
                             {"has_normals", !m.normals.empty()},
                             {"has_uvs", !m.uvs.empty()},
                             {"bounds", {{"min", vec_json(st.bounds.min)}, {"max", vec_json(st.bounds.max)}}}});
    }
    j["materials"] = nlohmann::json::array();
    for (const Material& m : s.materials) j["materials"].push_back({{"name", m.name}, {"base_color", m.base_color}});
    j["instances"] = nlohmann::json::array();
    for (const Instance& i : s.instances) j["instances"].push_back({{"mesh", i.mesh}, {"transform", i.transform}});
    j["warnings"] = nlohmann::json::array();
    for (const Warning& w : r.warnings) j["warnings"].push_back({{"code", w.code}, {"what", w.what}});
    j["stats"] = {{"degenerate_removed", r.stats.degenerate_removed},
                  {"duplicates_welded", r.stats.duplicates_welded},
                  {"primitives_skipped", r.stats.primitives_skipped}};
    std::printf("%s\n", j.dump(2).c_str());
    return;
  }
  std::printf("file:        %s\n", args.path.c_str());
  std::printf("triangles:   %zu (%zu after instancing)\n", mesh_triangles, instanced_triangles);
  std::printf("vertices:    %zu\n", mesh_vertices);
  std::printf("bounds:      [%g %g %g] .. [%g %g %g]\n", bounds.min.x, bounds.min.y, bounds.min.z, bounds.max.x,
              bounds.max.y, bounds.max.z);
  std::printf("meshes:      %zu\n", s.meshes.size());
  for (size_t m = 0; m < s.meshes.size(); ++m)
    std::printf("  [%zu] %s: %zu triangles, %zu vertices%s%s\n", m, s.meshes[m].name.c_str(),
                s.meshes[m].triangle_count(), s.meshes[m].vertex_count(), s.meshes[m].normals.empty() ? "" : ", normals",
                s.meshes[m].uvs.empty() ? "" : ", uvs");
  std::printf("materials:   %zu\n", s.materials.size());
  for (size_t m = 0; m < s.materials.size(); ++m) {
    const auto& c = s.materials[m].base_color;
    std::printf("  [%zu] %s: base color (%g, %g, %g, %g)\n", m, s.materials[m].name.c_str(), c[0], c[1], c[2], c[3]);
  }
  std::printf("instances:   %zu\n", s.instances.size());
  std::printf("import:      %zu degenerate triangles removed, %zu duplicate vertices welded, %zu primitives skipped\n",
              r.stats.degenerate_removed, r.stats.duplicates_welded, r.stats.primitives_skipped);
  std::printf("warnings:    %zu\n", r.warnings.size());
  for (const Warning& w : r.warnings) std::printf("  warning[%s]: %s\n", w.code.c_str(), w.what.c_str());
}

}  // namespace

void add_info_command(CLI::App& app, Context& ctx) {
  auto args = std::make_shared<InfoArgs>();
  auto* cmd = app.add_subcommand("info", "Import a mesh or scene with full validation and print what it contains");
  cmd->add_option("file", args->path, "Input: .gltf .glb .obj .ply .off .stl")->required();
  cmd->add_flag("--json", args->json, "Machine-readable JSON on stdout");
  cmd->add_flag("--weld", args->weld, "Weld exactly equal vertices (position + normal + uv)");
  cmd->callback([args, &ctx] {
    run_info(*args);
    ctx.exit_code = kExitOk;
  });
}

}  // namespace vgeo::cli
