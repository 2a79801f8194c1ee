#include "vgeo/mesh/mesh.h"

namespace vgeo {

MeshStats mesh_stats(const Mesh& mesh) {
  MeshStats s;
  s.vertices = mesh.vertex_count();
  s.triangles = mesh.triangle_count();
  for (size_t v = 0; v < s.vertices; ++v) s.bounds.extend(mesh.position(v));
  return s;
}

}  // namespace vgeo
