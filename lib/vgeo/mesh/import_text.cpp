// Polygon triangulation and scene assembly shared by the OBJ / PLY / OFF / STL readers.
#include "vgeo/mesh/import_text.h"

#include <algorithm>
#include <filesystem>

namespace vgeo::detail {
namespace {

bool repeats_a_vertex(const uint32_t* ring, size_t n, std::vector<uint32_t>& sorted) {
  if (n <= kPairwiseRepeatTestMax) {
    for (size_t i = 0; i < n; ++i)
      for (size_t j = i + 1; j < n; ++j)
        if (ring[i] == ring[j]) return true;
    return false;
  }
  sorted.assign(ring, ring + n);
  std::sort(sorted.begin(), sorted.end());
  return std::adjacent_find(sorted.begin(), sorted.end()) != sorted.end();
}
}  // namespace

void PolygonSink::add_polygon(const uint32_t* ring, size_t n) {
  if (n < 3) return;
  if (repeats_a_vertex(ring, n, sorted)) {
    ++repeated_vertex_faces;
    return;
  }
  for (size_t i = 1; i + 1 < n; ++i) {
    mesh.indices.push_back(ring[0]);
    mesh.indices.push_back(ring[i]);
    mesh.indices.push_back(ring[i + 1]);
  }
}

void PolygonSink::finish(ImportResult& out) const {
  if (repeated_vertex_faces == 0) return;
  out.stats.degenerate_removed += repeated_vertex_faces;
  out.warnings.push_back({"FACE_REPEATED_VERTEX", std::to_string(repeated_vertex_faces) +
                                                       " faces repeat a vertex; removed as degenerate"});
}

void push_single_mesh_scene(Mesh&& mesh, const std::string& where, ImportResult& out) {
  mesh.name = std::filesystem::path(where).stem().string();
  out.scene.meshes.push_back(std::move(mesh));
  out.scene.materials.push_back(Material{"default", {0.8f, 0.8f, 0.8f, 1.0f}});
  out.scene.instances.push_back(Instance{});
}

}  // namespace vgeo::detail
