// Hardware raster rule (hw_rule.h, spec/raster.md §13.3).
// Based on: the Vulkan specification's polygon rasterization (coverage of sample points, a
// tie-break rule for samples on a shared edge), as fixed-function hardware applies it.
#include "vgeo/raster/hw_rule.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "vgeo/core/vis_key.h"
#include "vgeo/raster/raster.h"

namespace vgeo {

namespace {
// §10: 10^-6 of the largest depth (float interpolation) plus the gradient times twice the
// snapping displacement (2/256 px).
constexpr double kDepthRelativeTolerance = 1e-6;
constexpr double kDepthSnapPixels = 2.0 / 256.0;
}  // namespace

ModelTriangle model_triangle(const Vec3 (&object)[3], const Mat4& m, double z_near, uint32_t width, uint32_t height) {
  ModelTriangle t;
  t.polygon = model_polygon(object, m, z_near, width, height);
  const ModelPolygon& p = t.polygon;
  t.margin = unambiguous_margin(p);
  if (p.count < 3) return t;
  // Clipped by the reference: the near plane cut it, or a vertex lies beyond the guard band
  // (|x_ndc| or |y_ndc| > kGuardBandNdc: screen x outside [−(G−1)/2·W, (G+1)/2·W]).
  t.clipped = p.count > 3;
  const double gx_lo = -(kGuardBandNdc - 1) / 2 * width, gx_hi = (kGuardBandNdc + 1) / 2 * width;
  const double gy_lo = -(kGuardBandNdc - 1) / 2 * height, gy_hi = (kGuardBandNdc + 1) / 2 * height;
  double z_max = 0;
  for (uint32_t i = 0; i < p.count; ++i) {
    t.clipped = t.clipped || p.x[i] < gx_lo || p.x[i] > gx_hi || p.y[i] < gy_lo || p.y[i] > gy_hi;
    z_max = std::max(z_max, std::abs(p.depth[i]));
  }
  // Depth = z/w is affine in screen space over the polygon: the plane through vertices 0–2.
  const double x1 = p.x[1] - p.x[0], y1 = p.y[1] - p.y[0], x2 = p.x[2] - p.x[0], y2 = p.y[2] - p.y[0];
  const double z1 = p.depth[1] - p.depth[0], z2 = p.depth[2] - p.depth[0];
  const double area = x1 * y2 - x2 * y1;
  t.x0 = p.x[0];
  t.y0 = p.y[0];
  t.z0 = p.depth[0];
  if (area != 0) {
    t.gx = (z1 * y2 - z2 * y1) / area;
    t.gy = (z2 * x1 - z1 * x2) / area;
  }
  t.depth_tolerance = kDepthRelativeTolerance * z_max + (std::abs(t.gx) + std::abs(t.gy)) * kDepthSnapPixels;
  t.area = std::abs(area) / 2;
  for (uint32_t i = 0; i < p.count; ++i)
    t.longest_edge = std::max(t.longest_edge, std::hypot(p.x[(i + 1) % p.count] - p.x[i], p.y[(i + 1) % p.count] - p.y[i]));
  t.vertex_shift = std::sqrt(2.0) * model_transform_shift(p);
  return t;
}

double model_depth_at(const ModelTriangle& t, double x, double y) { return t.z0 + t.gx * (x - t.x0) + t.gy * (y - t.y0); }

double model_depth_tolerance_at(const ModelTriangle& t, double x, double y) {
  if (t.polygon.count != 3) return t.depth_tolerance;
  // spec/raster.md §10: the hardware's plane interpolates its vertices' depths, each within
  // depth_tolerance of the exact plane at its rounded position; at a sample its barycentrics
  // weigh those residuals by Σ|λ| ≤ 1 + 2 d' L' / A' (d' the sample's distance outside its
  // triangle, L' ≥ its longest edge, A' ≤ its area, all within e of the exact triangle's).
  const double e = t.vertex_shift;
  const double area_low = t.area - 2 * t.longest_edge * e;
  if (!(area_low > 0)) return std::numeric_limits<double>::infinity();
  bool inside = false;
  const double outside = model_outline_distance(t.polygon, x, y, &inside);
  const double d = (inside ? 0.0 : outside) + e;
  return t.depth_tolerance * (1 + 2 * d * (t.longest_edge + 2 * e) / area_low);
}

const char* hw_pixel_name(HwPixel p) {
  switch (p) {
    case HwPixel::kIdentical: return "identical";
    case HwPixel::kDepthOnly: return "depth_only";
    case HwPixel::kAmbiguousDepth: return "ambiguous_depth";
    case HwPixel::kAmbiguousClipCoverage: return "ambiguous_clip_coverage";
    case HwPixel::kAmbiguousSnapCoverage: return "ambiguous_snap_coverage";
    case HwPixel::kDepthBeyondTolerance: return "depth_beyond_tolerance";
    case HwPixel::kViolation: return "violation";
  }
  return "?";
}

HwPixel classify_hw_pixel(uint64_t ref_key, uint64_t hw_key, bool same_triangle, const ModelTriangle* ref,
                          const ModelTriangle* hw, uint32_t px, uint32_t py) {
  if (ref_key == hw_key) return HwPixel::kIdentical;
  const double x = px + 0.5, y = py + 0.5;
  if (same_triangle && ref) {
    const double dz = std::abs(double(vis_key_depth(ref_key)) - double(vis_key_depth(hw_key)));
    return dz <= 2 * model_depth_tolerance_at(*ref, x, y) ? HwPixel::kDepthOnly : HwPixel::kDepthBeyondTolerance;
  }
  if (ref && hw && model_coverage(hw->polygon, x, y, hw->margin) != ModelCoverage::kOutside &&
      model_coverage(ref->polygon, x, y, ref->margin) != ModelCoverage::kOutside &&
      std::abs(model_depth_at(*hw, x, y) - model_depth_at(*ref, x, y)) <=
          model_depth_tolerance_at(*hw, x, y) + model_depth_tolerance_at(*ref, x, y))
    return HwPixel::kAmbiguousDepth;
  for (const ModelTriangle* t : {ref, hw})
    if (t && t->clipped && model_coverage(t->polygon, x, y, t->margin) == ModelCoverage::kAmbiguous)
      return HwPixel::kAmbiguousClipCoverage;
  for (const ModelTriangle* t : {ref, hw})
    if (t && model_coverage(t->polygon, x, y, t->margin) == ModelCoverage::kAmbiguous)
      return HwPixel::kAmbiguousSnapCoverage;
  return HwPixel::kViolation;
}

void HwRasterAgreement::add(const HwRasterAgreement& o) {
  for (int i = 0; i < kHwPixelKinds; ++i) pixels[i] += o.pixels[i];
  max_depth_error_ratio = std::max(max_depth_error_ratio, o.max_depth_error_ratio);
}

}  // namespace vgeo
