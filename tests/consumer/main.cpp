// A tiny project using an installed vgeo through find_package(vgeo).
#include <cstdio>

#include "vgeo/dag/cluster_dag.h"
#include "vgeo/core/lod.h"
#include "vgeo/mesh/mesh.h"

int main() {
  vgeo::Mesh mesh;
  mesh.positions = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  mesh.indices = {0, 1, 2};
  vgeo::MeshStats s = vgeo::mesh_stats(mesh);
  std::printf("triangles=%zu max_cluster_triangles=%u\n", s.triangles, vgeo::kMaxClusterTriangles);
  return s.triangles == 1 ? 0 : 1;
}
