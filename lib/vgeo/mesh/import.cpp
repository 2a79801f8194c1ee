// Import entry points: format dispatch, file reading, and the clean-up every format shares
// (validation, degenerate removal, optional weld). Format readers live in import_*.cpp.
#include "vgeo/mesh/import.h"

#include "vgeo/core/file_io.h"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <memory>

#include "vgeo/mesh/import_text.h"
#include "vgeo/mesh/validate.h"
#include "vgeo/mesh/weld.h"

namespace vgeo {
namespace {

std::string lower_extension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  if (!ext.empty() && ext[0] == '.') ext.erase(0, 1);
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return ext;
}

// Shared post-processing: validate, remove degenerates, weld, drop meshes left empty.
void finish(ImportResult& r, const ImportOptions& options, const std::string& where) {
  Scene& scene = r.scene;
  // The value checks and the degenerate-triangle test on the import's threads (a large mesh's
  // last serial passes here).
  std::unique_ptr<ThreadPool> pool;
  std::vector<int> new_slot(scene.meshes.size(), -1);
  std::vector<Mesh> kept;
  kept.reserve(scene.meshes.size());
  for (size_t m = 0; m < scene.meshes.size(); ++m) {
    Mesh& mesh = scene.meshes[m];
    if (options.threads != 1 && !pool && mesh.triangle_count() > kDegenerateTestTriangles)
      pool = std::make_unique<ThreadPool>(options.threads);
    check_mesh_attributes(mesh, where, pool.get());
    check_mesh_indices(mesh, where, pool.get());
    for (uint32_t mat : mesh.materials)
      if (mat >= scene.materials.size())
        fail("MATERIAL_INDEX_OUT_OF_RANGE", where, "mesh '" + mesh.name + "' uses material " + std::to_string(mat));
    r.stats.degenerate_removed += remove_degenerate_triangles(mesh, pool.get());
    if (mesh.triangle_count() == 0) {
      r.warnings.push_back({"MESH_EMPTY", "mesh '" + mesh.name + "' has only degenerate triangles; dropped"});
      continue;
    }
    if (options.weld) r.stats.duplicates_welded += weld_exact(mesh);
    new_slot[m] = int(kept.size());
    kept.push_back(std::move(mesh));
  }
  scene.meshes = std::move(kept);
  std::vector<Instance> instances;
  for (const Instance& inst : scene.instances)
    if (inst.mesh < new_slot.size() && new_slot[inst.mesh] >= 0) {
      Instance i = inst;
      i.mesh = uint32_t(new_slot[inst.mesh]);
      instances.push_back(i);
    }
  scene.instances = std::move(instances);
  if (scene.meshes.empty() || scene.instances.empty())
    fail("MESH_EMPTY", where, "the file contains no triangles to import");
  if (scene.materials.empty()) scene.materials.push_back(Material{"default", {0.8f, 0.8f, 0.8f, 1.0f}});
}

bool is_mesh_file_format(const std::string& ext) { return ext == "obj" || ext == "ply" || ext == "off" || ext == "stl"; }

// OBJ / PLY / OFF / STL: the readers of import_obj.cpp ... import_stl.cpp.
void import_mesh_file(const uint8_t* data, size_t size, const std::string& ext, const std::string& where, ImportResult& r,
                      unsigned threads) {
  if (ext == "obj") detail::import_obj(data, size, where, r);
  if (ext == "ply") detail::import_ply(data, size, where, r);
  if (ext == "off") detail::import_off(data, size, where, r, threads);
  if (ext == "stl") detail::import_stl(data, size, where, r);
}

}  // namespace

ImportResult import_scene(const std::string& path, const ImportOptions& options) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) fail("FILE_NOT_FOUND", path, "no such file", kExitIo);
  if (!std::filesystem::is_regular_file(path, ec)) fail("FILE_READ_ERROR", path, "not a regular file", kExitIo);
  const std::string ext = lower_extension(path);
  ImportResult r;
  if (ext == "gltf" || ext == "glb") {
    std::vector<uint8_t> bytes = read_file(path);
    std::string base_dir = std::filesystem::path(path).parent_path().string();
    detail::import_gltf(bytes.data(), bytes.size(), &bytes, ext == "glb", path, base_dir, true, r);
  } else if (is_mesh_file_format(ext)) {
    const FileBytes bytes = read_file_bytes(path, kMaxReadBytes, options.threads);  // by pieces when threads != 1
    import_mesh_file(bytes.data.get(), bytes.size, ext, path, r, options.threads);
  } else {
    fail("MESH_FORMAT_UNSUPPORTED", path, "unknown extension '." + ext + "' (expected .gltf .glb .obj .ply .off .stl)");
  }
  finish(r, options, path);
  return r;
}

ImportResult import_scene_from_memory(const uint8_t* data, size_t size, const std::string& name_for_format_detection,
                                      const ImportOptions& options) {
  const std::string ext = lower_extension(name_for_format_detection);
  const std::string where = name_for_format_detection.empty() ? "<memory>" : name_for_format_detection;
  ImportResult r;
  static const uint8_t kEmpty = 0;
  if (size == 0) data = &kEmpty;
  if (ext == "gltf" || ext == "glb")
    detail::import_gltf(data, size, nullptr, ext == "glb", where, "", false, r);
  else if (is_mesh_file_format(ext))
    import_mesh_file(data, size, ext, where, r, options.threads);
  else
    fail("MESH_FORMAT_UNSUPPORTED", where, "unknown extension '." + ext + "' (expected .gltf .glb .obj .ply .off .stl)");
  finish(r, options, where);
  return r;
}

}  // namespace vgeo
