// View tests for bounding spheres: frustum rejection against the side planes through the eye
// and the sphere's screen rectangle from its view-space box. Based on: the conservative
// sphere tests of Haar, Aaltonen, "GPU-Driven Rendering Pipelines", SIGGRAPH 2015 Advances.
#include "vgeo/cull/view.h"

#include <algorithm>

#include "vgeo/core/lod.h"

namespace vgeo {

namespace {
Vec3d scaled(Vec3d a, double s) { return {a.x * s, a.y * s, a.z * s}; }
// |cross| below this (for unit inputs) means "parallel": sin(angle) < 1e-9.
constexpr double kParallelEpsilon = 1e-9;
}  // namespace

bool look_at_orientation(Vec3d eye, Vec3d target, Vec3d up, std::array<double, 4>* out) {
  Vec3d f = sub(target, eye);
  double fl = length(f), ul = length(up);
  if (!(fl > 0) || !(ul > 0) || !std::isfinite(fl) || !std::isfinite(ul)) return false;
  f = scaled(f, 1 / fl);
  Vec3d r = cross(f, scaled(up, 1 / ul));
  double rl = length(r);
  if (!(rl > kParallelEpsilon)) return false;
  r = scaled(r, 1 / rl);
  Vec3d u = cross(r, f);
  // Rotation matrix columns: camera +X = r, +Y = u, +Z = -f.
  double m00 = r.x, m10 = r.y, m20 = r.z;
  double m01 = u.x, m11 = u.y, m21 = u.z;
  double m02 = -f.x, m12 = -f.y, m22 = -f.z;
  double tr = m00 + m11 + m22, x, y, z, w;
  if (tr > 0) {
    double s = std::sqrt(tr + 1) * 2;
    w = 0.25 * s; x = (m21 - m12) / s; y = (m02 - m20) / s; z = (m10 - m01) / s;
  } else if (m00 > m11 && m00 > m22) {
    double s = std::sqrt(1 + m00 - m11 - m22) * 2;
    w = (m21 - m12) / s; x = 0.25 * s; y = (m01 + m10) / s; z = (m02 + m20) / s;
  } else if (m11 > m22) {
    double s = std::sqrt(1 + m11 - m00 - m22) * 2;
    w = (m02 - m20) / s; x = (m01 + m10) / s; y = 0.25 * s; z = (m12 + m21) / s;
  } else {
    double s = std::sqrt(1 + m22 - m00 - m11) * 2;
    w = (m10 - m01) / s; x = (m02 + m20) / s; y = (m12 + m21) / s; z = 0.25 * s;
  }
  *out = {x, y, z, w};
  return true;
}

ViewParams make_view(const Camera& camera) {
  auto q = camera.orientation;
  double n = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  double x = q[0] / n, y = q[1] / n, z = q[2] / n, w = q[3] / n;
  // Camera-to-world rotation R; world_to_view = R^T * translate(-position).
  double r[3][3] = {{1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)},
                    {2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)},
                    {2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)}};
  ViewParams v;
  const double p[3] = {camera.position.x, camera.position.y, camera.position.z};
  for (int row = 0; row < 3; ++row) {
    double t = 0;
    for (int col = 0; col < 3; ++col) {
      v.world_to_view.at(row, col) = r[col][row];
      t -= r[col][row] * p[col];
    }
    v.world_to_view.at(row, 3) = t;
  }
  v.width = camera.width;
  v.height = camera.height;
  v.z_near = camera.z_near;
  v.tan_half_y = std::tan(0.5 * camera.fov_y);
  v.tan_half_x = v.tan_half_y * double(camera.width) / double(camera.height);
  v.pixels_per_unit_at_1 = lod_projection_scale(float(camera.fov_y), float(camera.height));
  return v;
}

double max_axis_scale(const Mat4d& m) {
  double best = 0;
  for (int c = 0; c < 3; ++c) {
    double s = 0;
    for (int r = 0; r < 3; ++r) s += m.at(r, c) * m.at(r, c);
    best = std::max(best, std::sqrt(s));
  }
  return best;
}

bool sphere_outside_frustum(const Sphere& s, const ViewParams& view) {
  if (s.radius < 0) return true;
  double x = s.center.x, y = s.center.y, d = -double(s.center.z), r = s.radius;
  if (d + r < view.z_near) return true;  // entirely in front of the near plane
  // Side planes through the eye: inside iff |x| <= d * tan_half_x (same for y).
  double nx = 1 / std::sqrt(1 + view.tan_half_x * view.tan_half_x);
  double ny = 1 / std::sqrt(1 + view.tan_half_y * view.tan_half_y);
  if ((x - d * view.tan_half_x) * nx > r) return true;
  if ((-x - d * view.tan_half_x) * nx > r) return true;
  if ((y - d * view.tan_half_y) * ny > r) return true;
  if ((-y - d * view.tan_half_y) * ny > r) return true;
  return false;
}

ScreenRect sphere_screen_rect(const Sphere& s, const ViewParams& view) {
  // Project the 8 corners of the sphere's view-space box (all beyond the near plane):
  // the box encloses the sphere and its projection is the hull of the corners'.
  double d = -double(s.center.z), r = s.radius;
  double min_sx = 1e300, max_sx = -1e300, min_sy = 1e300, max_sy = -1e300;
  for (int i = 0; i < 8; ++i) {
    double x = s.center.x + ((i & 1) ? r : -r);
    double y = s.center.y + ((i & 2) ? r : -r);
    double depth = d + ((i & 4) ? r : -r);
    double ndc_x = x / (depth * view.tan_half_x), ndc_y = y / (depth * view.tan_half_y);
    double sx = (ndc_x * 0.5 + 0.5) * view.width, sy = (0.5 - ndc_y * 0.5) * view.height;
    min_sx = std::min(min_sx, sx); max_sx = std::max(max_sx, sx);
    min_sy = std::min(min_sy, sy); max_sy = std::max(max_sy, sy);
  }
  ScreenRect rect;
  // One pixel of margin each side covers sub-pixel snapping and the rounding above.
  double x0 = std::floor(min_sx) - 1, x1 = std::floor(max_sx) + 1;
  double y0 = std::floor(min_sy) - 1, y1 = std::floor(max_sy) + 1;
  x0 = std::max(x0, 0.0); y0 = std::max(y0, 0.0);
  x1 = std::min(x1, double(view.width) - 1); y1 = std::min(y1, double(view.height) - 1);
  if (!(x0 <= x1) || !(y0 <= y1)) return rect;  // also NaN
  rect.x0 = int32_t(x0); rect.x1 = int32_t(x1); rect.y0 = int32_t(y0); rect.y1 = int32_t(y1);
  return rect;
}

}  // namespace vgeo
