// The cull arithmetic without bindings (lib/vgeo/core/lod.h, lib/vgeo/cull/view.h/.cpp), shared
// by the primary view's cull passes (cull_common.glsl) and the shadow views' multi-view cull
// (shadow_cull.comp): operation for operation the CPU's (spec/raster.md §12): double where the
// CPU computes in double, `precise` so no multiply-add is contracted, the same comparisons in
// the same order (a NaN takes the same branch), std::min/std::max written as their ternaries.
#ifndef VGEO_SHADERS_CULL_MATH_GLSL
#define VGEO_SHADERS_CULL_MATH_GLSL
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_shader_explicit_arithmetic_types : require
#include "vgeo/core/cull_shared.h"

struct Sphere {
  float x, y, z, radius;
};
Sphere sphere_of(GpuSphere s) { return Sphere(s.x, s.y, s.z, s.radius); }

// view.h sphere_to_view: centre transformed in double (((m0·x + m4·y) + m8·z) + m12 per row),
// rounded to float; radius scaled in double.
Sphere sphere_to_view(GpuCullInstance iv, Sphere s) {
  precise double x = double(s.x), y = double(s.y), z = double(s.z);
  precise double cx = iv.object_to_view[0] * x + iv.object_to_view[4] * y + iv.object_to_view[8] * z + iv.object_to_view[12];
  precise double cy = iv.object_to_view[1] * x + iv.object_to_view[5] * y + iv.object_to_view[9] * z + iv.object_to_view[13];
  precise double cz = iv.object_to_view[2] * x + iv.object_to_view[6] * y + iv.object_to_view[10] * z + iv.object_to_view[14];
  precise double r = double(s.radius) * iv.scale;
  return Sphere(float(cx), float(cy), float(cz), s.radius < 0.0 ? s.radius : float(r));
}

// view.h inflate_for_subtree_test.
Sphere inflate_for_subtree_test(Sphere s) {
  if (s.radius < 0.0) return s;
  precise double c = sqrt(double(s.x) * double(s.x) + double(s.y) * double(s.y) + double(s.z) * double(s.z));
  precise double r = double(s.radius) * (1.0lf + kConservativeRelativeSlack) + c * kConservativeCentreSlack;
  s.radius = float(r);
  return s;
}
float error_to_view(float error, double scale) {
  precise double e = double(error) * scale;
  return float(e);
}
float inflate_error_for_subtree_test(float error) {
  precise double e = double(error) * (1.0lf + kConservativeRelativeSlack);
  return float(e);
}

// lod.h projected_error with the eye at the view-space origin (distance_d(c, 0)).
float projected_error(Sphere s, float error, GpuCullView v) {
  if (error == 0.0) return 0.0;
  precise double dx = double(s.x) - 0.0lf, dy = double(s.y) - 0.0lf, dz = double(s.z) - 0.0lf;
  precise double d = sqrt(dx * dx + dy * dy + dz * dz) - double(s.radius);
  if (!(d > double(v.lod_z_near))) d = double(v.lod_z_near);
  precise double p = double(error) * double(v.pixels_per_unit_at_1) / d;
  return float(p);
}

// view.cpp sphere_outside_frustum.
bool sphere_outside_frustum(Sphere s, GpuCullView v) {
  if (s.radius < 0.0) return true;
  precise double x = double(s.x), y = double(s.y), d = -double(s.z), r = double(s.radius);
  if (d + r < v.z_near) return true;
  precise double nx = 1.0lf / sqrt(1.0lf + v.tan_half_x * v.tan_half_x);
  precise double ny = 1.0lf / sqrt(1.0lf + v.tan_half_y * v.tan_half_y);
  if ((x - d * v.tan_half_x) * nx > r) return true;
  if ((-x - d * v.tan_half_x) * nx > r) return true;
  if ((y - d * v.tan_half_y) * ny > r) return true;
  if ((-y - d * v.tan_half_y) * ny > r) return true;
  return false;
}

// cull.cpp culling_sphere.
Sphere culling_sphere(GpuCullInstance iv, GpuSphere s) { return inflate_for_subtree_test(sphere_to_view(iv, sphere_of(s))); }

double min_d(double a, double b) { return (b < a) ? b : a; }  // std::min
double max_d(double a, double b) { return (a < b) ? b : a; }  // std::max

// view.cpp sphere_screen_rect → (x0, y0, x1, y1); empty when x1 < x0.
ivec4 sphere_screen_rect(Sphere s, GpuCullView v) {
  precise double d = -double(s.z), r = double(s.radius);
  double min_sx = 1e300lf, max_sx = -1e300lf, min_sy = 1e300lf, max_sy = -1e300lf;
  for (int i = 0; i < 8; ++i) {
    precise double x = double(s.x) + (((i & 1) != 0) ? r : -r);
    precise double y = double(s.y) + (((i & 2) != 0) ? r : -r);
    precise double depth = d + (((i & 4) != 0) ? r : -r);
    precise double ndc_x = x / (depth * v.tan_half_x), ndc_y = y / (depth * v.tan_half_y);
    precise double sx = (ndc_x * 0.5lf + 0.5lf) * double(v.width), sy = (0.5lf - ndc_y * 0.5lf) * double(v.height);
    min_sx = min_d(min_sx, sx); max_sx = max_d(max_sx, sx);
    min_sy = min_d(min_sy, sy); max_sy = max_d(max_sy, sy);
  }
  precise double x0 = floor(min_sx) - 1.0lf, x1 = floor(max_sx) + 1.0lf;
  precise double y0 = floor(min_sy) - 1.0lf, y1 = floor(max_sy) + 1.0lf;
  x0 = max_d(x0, 0.0lf); y0 = max_d(y0, 0.0lf);
  x1 = min_d(x1, double(v.width) - 1.0lf); y1 = min_d(y1, double(v.height) - 1.0lf);
  if (!(x0 <= x1) || !(y0 <= y1)) return ivec4(0, 0, -1, -1);
  return ivec4(int(x0), int(y0), int(x1), int(y1));
}
#endif
