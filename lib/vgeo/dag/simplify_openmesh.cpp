// The OpenMesh backend of the group simplification (spec/dag.md §Simplify; the meshopt backend
// and the shared checks are in simplify.cpp): OpenMesh's Decimater with quadrics and a
// normal-flip guard, halfedge collapses only, locked vertices never move.
// Based on: Garland, Heckbert, "Surface Simplification Using Quadric Error Metrics", SIGGRAPH
// 1997, as OpenMesh's Decimater (ModQuadric) implements it.
#include "vgeo/dag/simplify_openmesh.h"

#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>
#include <OpenMesh/Tools/Decimater/DecimaterT.hh>
#include <OpenMesh/Tools/Decimater/ModNormalFlippingT.hh>
#include <OpenMesh/Tools/Decimater/ModQuadricT.hh>
#include <algorithm>
#include <unordered_map>
#include <vector>

#include "vgeo/dag/cluster_dag.h"
#include "vgeo/mesh/openmesh_streams.h"

namespace vgeo::build_detail {

namespace {

struct OmTraits : public OpenMesh::DefaultTraits {
  typedef OpenMesh::Vec3d Point;  // double: quadrics far from the origin lose precision in float
  typedef OpenMesh::Vec3d Normal;
  VertexAttributes(OpenMesh::Attributes::Status);
  FaceAttributes(OpenMesh::Attributes::Status | OpenMesh::Attributes::Normal);
  EdgeAttributes(OpenMesh::Attributes::Status);
};
using OmMesh = OpenMesh::TriMesh_ArrayKernelT<OmTraits>;

}  // namespace

SimplifyResult simplify_openmesh(const WeldedMesh& welded, const TriangleSet& group,
                                 const std::vector<uint8_t>& locked, const SimplifyTarget& target) {
  silence_openmesh_streams();  // add_face reports complex edges on omerr
  const Mesh& mesh = *welded.mesh;
  size_t n = group.triangle_count();
  // Welded ids of the group, compacted in order of first use.
  std::unordered_map<uint32_t, int> om_of_welded;
  std::vector<uint32_t> welded_of_om;
  om_of_welded.reserve(2 * n);
  std::vector<int> om_corner(3 * n);
  for (size_t i = 0; i < 3 * n; ++i) {
    uint32_t w = welded.weld[group.corners[i]];
    auto it = om_of_welded.emplace(w, int(welded_of_om.size()));
    if (it.second) welded_of_om.push_back(w);
    om_corner[i] = it.first->second;
  }
  // Local origin (group AABB centre): quadric plane offsets stay small far from the origin.
  double lo[3] = {1e300, 1e300, 1e300}, hi[3] = {-1e300, -1e300, -1e300};
  for (uint32_t w : welded_of_om)
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], double(mesh.positions[3 * size_t(w) + k]));
      hi[k] = std::max(hi[k], double(mesh.positions[3 * size_t(w) + k]));
    }
  OpenMesh::Vec3d origin(0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1]), 0.5 * (lo[2] + hi[2]));

  OmMesh om;
  om.reserve(welded_of_om.size(), 3 * n, n);
  std::vector<OmMesh::VertexHandle> vh(welded_of_om.size());
  for (size_t v = 0; v < welded_of_om.size(); ++v) {
    const float* p = &mesh.positions[3 * size_t(welded_of_om[v])];
    vh[v] = om.add_vertex(OpenMesh::Vec3d(p[0], p[1], p[2]) - origin);
    if (locked[welded_of_om[v]]) om.status(vh[v]).set_locked(true);
  }
  OpenMesh::FPropHandleT<uint32_t> face_material;
  om.add_property(face_material);
  std::vector<uint32_t> passthrough;  // triangle indices kept as they are
  // OpenMesh refuses faces on complex edges / non-manifold vertices (and says so on its
  // error stream): those pass through unchanged.
  for (size_t t = 0; t < n; ++t) {
    int a = om_corner[3 * t], b = om_corner[3 * t + 1], c = om_corner[3 * t + 2];
    if (a == b || b == c || a == c) continue;  // welded-degenerate: zero area, dropped
    OmMesh::FaceHandle fh = om.add_face(vh[a], vh[b], vh[c]);
    if (!fh.is_valid()) {
      passthrough.push_back(uint32_t(t));
      continue;
    }
    om.property(face_material, fh) = group.materials[t];
  }
  for (uint32_t t : passthrough)
    for (int k = 0; k < 3; ++k) om.status(vh[om_corner[3 * t + k]]).set_locked(true);

  size_t target_count = target_triangles(n, target.ratio);
  size_t om_target = target_count > passthrough.size() ? target_count - passthrough.size() : 0;
  om.update_face_normals();
  OpenMesh::Decimater::DecimaterT<OmMesh> decimater(om);
  OpenMesh::Decimater::ModQuadricT<OmMesh>::Handle quadric;
  OpenMesh::Decimater::ModNormalFlippingT<OmMesh>::Handle normal_flipping;
  decimater.add(quadric);
  decimater.add(normal_flipping);
  decimater.module(quadric).unset_max_err();
  decimater.initialize();
  decimater.decimate_to_faces(0, std::max<size_t>(1, om_target));

  // Original vertex for each (welded id, material): the first use in the group, so
  // surviving corners keep the attributes they had on that side of the material border.
  std::unordered_map<uint64_t, uint32_t> original_of;
  original_of.reserve(3 * n);
  for (size_t i = 0; i < 3 * n; ++i) {
    uint32_t w = welded.weld[group.corners[i]];
    original_of.emplace((uint64_t(w) << 32) | group.materials[i / 3], group.corners[i]);
    original_of.emplace((uint64_t(w) << 32) | 0xFFFFFFFFu, group.corners[i]);
  }
  auto original = [&](uint32_t w, uint32_t material) {
    auto it = original_of.find((uint64_t(w) << 32) | material);
    if (it == original_of.end()) it = original_of.find((uint64_t(w) << 32) | 0xFFFFFFFFu);
    return it->second;
  };

  SimplifyResult r;
  for (auto fh : om.faces()) {
    if (om.status(fh).deleted()) continue;
    uint32_t material = om.property(face_material, fh);
    int corner_om[3], k = 0;
    for (auto fv : om.fv_range(fh)) corner_om[k++] = fv.idx();
    for (k = 0; k < 3; ++k) {
      r.triangles.corners.push_back(original(welded_of_om[corner_om[k]], material));
    }
    r.triangles.materials.push_back(material);
  }
  for (uint32_t t : passthrough) {
    r.triangles.corners.insert(r.triangles.corners.end(), &group.corners[3 * t], &group.corners[3 * t] + 3);
    r.triangles.materials.push_back(group.materials[t]);
  }

  return r;
}

}  // namespace vgeo::build_detail
