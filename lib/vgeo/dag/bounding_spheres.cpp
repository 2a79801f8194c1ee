// Bounding spheres of clusters, groups and BVH nodes (spec/dag.md §Build): the box centre and
// the farthest point or sphere from it, computed in double and rounded outward so containment
// survives float rounding.
// Based on: Karis et al., "Nanite: A Deep Dive", SIGGRAPH 2021, §"LOD selection in parallel" (a
// parent's bounds enclose its children's, so the projected error is monotonic up the DAG).
#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

#include "vgeo/dag/build_internal.h"

namespace vgeo::build_detail {

Sphere sphere_of_points(const Mesh& mesh, const uint32_t* vertices, size_t count) {
  Sphere s;
  if (count == 0) return s;
  // The box in float (a float's conversion to double is exact and monotonic, so this is the
  // double box), the radius as the root of the largest squared distance (the root is
  // correctly rounded and monotonic, so it equals the largest root): one sqrt, not one per
  // point (this ran once per cluster over its corners, 1.8% of a 1M-triangle build).
  const float* P = mesh.positions.data();
  float lo[3] = {P[3 * size_t(vertices[0])], P[3 * size_t(vertices[0]) + 1], P[3 * size_t(vertices[0]) + 2]};
  float hi[3] = {lo[0], lo[1], lo[2]};
  for (size_t i = 1; i < count; ++i) {
    const float* p = &P[3 * size_t(vertices[i])];
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], p[k]);
      hi[k] = std::max(hi[k], p[k]);
    }
  }
  s.center = {float(0.5 * (double(lo[0]) + double(hi[0]))), float(0.5 * (double(lo[1]) + double(hi[1]))),
              float(0.5 * (double(lo[2]) + double(hi[2])))};
  const double c[3] = {s.center.x, s.center.y, s.center.z};
  double r2 = 0;
  for (size_t i = 0; i < count; ++i) {
    const float* p = &P[3 * size_t(vertices[i])];
    // distance_d's expression (core/math.h), squared.
    const double dx = c[0] - double(p[0]), dy = c[1] - double(p[1]), dz = c[2] - double(p[2]);
    r2 = std::max(r2, dx * dx + dy * dy + dz * dz);
  }
  const double r = std::sqrt(r2);
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
