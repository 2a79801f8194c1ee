#pragma once
// One camera's view as the culling, raster and shading stages see it (spec/scene.md §Camera).
// All per-frame geometry is brought into *view space* (camera at the origin, looking down
// −Z, +Y up, right-handed) in double before anything is rounded to float: instances 1e7
// units from the origin keep their sub-unit detail because only camera-relative
// coordinates are ever stored in float.
#include <array>
#include <cmath>
#include <cstdint>

#include "vgeo/core/cull_shared.h"
#include "vgeo/core/math.h"

namespace vgeo {

struct Vec3d {
  double x = 0, y = 0, z = 0;
};
inline Vec3d sub(Vec3d a, Vec3d b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline double dot(Vec3d a, Vec3d b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline Vec3d cross(Vec3d a, Vec3d b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
inline double length(Vec3d a) { return std::sqrt(dot(a, a)); }

// A pinhole camera with a reversed-Z infinite-far projection.
struct Camera {
  Vec3d position;
  std::array<double, 4> orientation{0, 0, 0, 1};  // unit quaternion (x, y, z, w): camera axes → world
  double fov_y = 1.0471975511965976;  // vertical field of view in radians (60°)
  uint32_t width = 1280, height = 720;
  double z_near = 0.01;
};

// Quaternion (x, y, z, w) of a camera at `eye` looking at `target`; `up` breaks the roll.
// Returns false (and leaves `out` alone) when the direction is zero or parallel to `up`.
bool look_at_orientation(Vec3d eye, Vec3d target, Vec3d up, std::array<double, 4>* out);

// Derived per-view constants shared by every test of one frame.
struct ViewParams {
  Mat4d world_to_view;       // rigid
  double tan_half_y = 0, tan_half_x = 0;
  uint32_t width = 0, height = 0;
  double z_near = 0.01;
  float pixels_per_unit_at_1 = 1;  // lod_projection_scale(fov_y, height)
};
ViewParams make_view(const Camera& camera);

// Largest factor by which the 3x3 part of `m` stretches any vector (max column length,
// an upper bound for the spectral norm of orthogonal-axis scales; conservative otherwise).
double max_axis_scale(const Mat4d& m);

// An object's bounding sphere in view space: centre transformed in double, radius scaled.
// The same function is used by every test so that spheres shared bit-identically in
// object space stay bit-identical in view space (the LOD cut depends on it).
inline Sphere sphere_to_view(const Mat4d& object_to_view, double scale, const Sphere& s) {
  double x = s.center.x, y = s.center.y, z = s.center.z;
  Sphere r;
  r.center = {float(object_to_view.at(0, 0) * x + object_to_view.at(0, 1) * y + object_to_view.at(0, 2) * z + object_to_view.at(0, 3)),
              float(object_to_view.at(1, 0) * x + object_to_view.at(1, 1) * y + object_to_view.at(1, 2) * z + object_to_view.at(1, 3)),
              float(object_to_view.at(2, 0) * x + object_to_view.at(2, 1) * y + object_to_view.at(2, 2) * z + object_to_view.at(2, 3))};
  r.radius = s.radius < 0 ? s.radius : float(double(s.radius) * scale);
  return r;
}

// 2^-16 relative + 2^-20 of the centre's distance: far above the float rounding of
// sphere_to_view (a few ulps of centre and radius), far below any visible LOD change.
// Bounding volumes of *subtrees* (BVH nodes, groups, instances) are inflated by it before
// the conservative tests, so a subtree is pruned only if every member would also fail.
// kConservativeRelativeSlack, kConservativeCentreSlack: vgeo/core/cull_shared.h (shared with the shaders).
inline Sphere inflate_for_subtree_test(Sphere s) {
  if (s.radius < 0) return s;
  double c = std::sqrt(double(s.center.x) * s.center.x + double(s.center.y) * s.center.y +
                       double(s.center.z) * s.center.z);
  s.radius = float(double(s.radius) * (1 + kConservativeRelativeSlack) + c * kConservativeCentreSlack);
  return s;
}
inline float error_to_view(float error, double scale) { return float(double(error) * scale); }
inline float inflate_error_for_subtree_test(float error) {
  return float(double(error) * (1 + kConservativeRelativeSlack));
}

// True when the view-space sphere lies entirely outside the frustum (4 sides + near).
bool sphere_outside_frustum(const Sphere& view_sphere, const ViewParams& view);

// True when the sphere reaches the near plane (or behind it): such bounds must never be
// occlusion-culled by a projected rectangle: with the eye inside or behind the sphere its
// rectangle is unbounded or inverted (spec/scene.md §Occlusion (HZB)).
inline bool sphere_crosses_near(const Sphere& view_sphere, const ViewParams& view) {
  return double(-view_sphere.center.z) - view_sphere.radius <= view.z_near;
}

// Pixel mapping used by every stage: pixel (px, py) covers [px, px+1) x [py, py+1) of
//   sx = (ndc.x * 0.5 + 0.5) * width,  sy = (0.5 - ndc.y * 0.5) * height  (row 0 at the top).
struct ScreenRect {
  int32_t x0 = 0, y0 = 0, x1 = -1, y1 = -1;  // inclusive pixel range; empty when x1 < x0
  bool empty() const { return x1 < x0 || y1 < y0; }
};
// Conservative pixel rectangle of a sphere that lies fully beyond the near plane,
// clamped to the viewport (one pixel of margin for sub-pixel snapping).
ScreenRect sphere_screen_rect(const Sphere& view_sphere, const ViewParams& view);
// Reversed-Z depth of the sphere's nearest point (larger = closer): z_near / (d - r).
inline double sphere_nearest_depth(const Sphere& view_sphere, const ViewParams& view) {
  return view.z_near / (double(-view_sphere.center.z) - view_sphere.radius);
}

}  // namespace vgeo
