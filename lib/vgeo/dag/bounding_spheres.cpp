// Bounding spheres of clusters, groups and BVH nodes (spec/dag.md §Build): the box centre and
// the farthest point or sphere from it, computed in double and rounded outward so containment
// survives float rounding.
// Based on: Karis et al., "Nanite: A Deep Dive", SIGGRAPH 2021, §"LOD selection in parallel" (a
// parent's bounds enclose its children's, so the projected error is monotonic up the DAG).
#include <algorithm>
#include <cstring>
#include <limits>

#include "vgeo/dag/build_internal.h"

namespace vgeo::build_detail {

Sphere sphere_of_points(const Mesh& mesh, const uint32_t* vertices, size_t count) {
  Sphere s;
  if (count == 0) return s;
  double lo[3] = {1e300, 1e300, 1e300}, hi[3] = {-1e300, -1e300, -1e300};
  for (size_t i = 0; i < count; ++i) {
    Vec3 p = mesh.position(vertices[i]);
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], double(p[k]));
      hi[k] = std::max(hi[k], double(p[k]));
    }
  }
  s.center = {float(0.5 * (lo[0] + hi[0])), float(0.5 * (lo[1] + hi[1])), float(0.5 * (lo[2] + hi[2]))};
  double r = 0;
  for (size_t i = 0; i < count; ++i) r = std::max(r, distance_d(s.center, mesh.position(vertices[i])));
  s.radius = float(r * (1.0 + kSphereRelativeSlack)) + std::numeric_limits<float>::min();
  return s;
}

Sphere enclose_spheres(const Sphere* spheres, size_t count) {
  double lo[3] = {1e300, 1e300, 1e300}, hi[3] = {-1e300, -1e300, -1e300};
  bool any = false;
  for (size_t i = 0; i < count; ++i) {
    const Sphere& s = spheres[i];
    if (s.radius < 0) continue;
    any = true;
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], double(s.center[k]) - s.radius);
      hi[k] = std::max(hi[k], double(s.center[k]) + s.radius);
    }
  }
  Sphere out;
  if (!any) return out;
  out.center = {float(0.5 * (lo[0] + hi[0])), float(0.5 * (lo[1] + hi[1])), float(0.5 * (lo[2] + hi[2]))};
  double r = 0;
  for (size_t i = 0; i < count; ++i)
    if (spheres[i].radius >= 0) r = std::max(r, distance_d(out.center, spheres[i].center) + spheres[i].radius);
  out.radius = float(r * (1.0 + kSphereRelativeSlack)) + std::numeric_limits<float>::min();
  // A single sphere (or identical ones) is returned as is: siblings keep bit-identical values.
  bool all_same = true;
  const Sphere* first = nullptr;
  for (size_t i = 0; i < count && all_same; ++i) {
    if (spheres[i].radius < 0) continue;
    if (!first) first = &spheres[i];
    else all_same = std::memcmp(first, &spheres[i], sizeof(Sphere)) == 0;
  }
  if (all_same && first) return *first;
  return out;
}

}  // namespace vgeo::build_detail
