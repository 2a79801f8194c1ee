#pragma once
// The rule a hardware rasterizer is held to against this rasterizer (spec/raster.md §13.3),
// per pixel, on top of the exact model of §10 (raster_model.h): coverage equal for every
// triangle that is not clipped; depth may differ (fixed-function interpolation) within the
// §10 tolerance; the triangle id may differ only inside the depth-ambiguity mask (two
// surfaces within their tolerances) or where the pixel centre is within δ of the exact
// outline of a clipped triangle (the hardware clips with its own arithmetic).
#include <cstdint>

#include "vgeo/core/math.h"
#include "vgeo/raster/raster_model.h"

namespace vgeo {

// A triangle as the model sees it: exact polygon, margin δ, exact depth plane and the §10
// depth tolerance, and whether the reference clips it (near plane or guard band).
struct ModelTriangle {
  ModelPolygon polygon;
  double margin = 0;
  double z0 = 0, x0 = 0, y0 = 0, gx = 0, gy = 0;  // z(x, y) = z0 + gx (x − x0) + gy (y − y0), pixels
  double depth_tolerance = 0;                     // 10^-6 z_max + (|gx| + |gy|) · 2/256
  bool clipped = false;
  // The plane's conditioning (unclipped triangles): exact area (px²), longest edge (px), and
  // how far a conforming float32 transform may move a vertex (Euclidean, px).
  double area = 0, longest_edge = 0, vertex_shift = 0;
};
ModelTriangle model_triangle(const Vec3 (&object)[3], const Mat4& object_to_clip, double z_near, uint32_t width,
                             uint32_t height);
double model_depth_at(const ModelTriangle& t, double x, double y);

// The §10 depth tolerance at the point (x, y) (spec/raster.md §10, "plane conditioning"):
// depth_tolerance × (1 + 2 (d + e)(L + 2e) / (A − 2 L e)), d the point's distance outside
// the exact triangle, e = vertex_shift, L = longest_edge, A = area. A float implementation
// sets its depth plane up from its own rounded vertices; the factor bounds how far that plane
// can be from the exact one at a sample it covers. Infinite when A ≤ 2 L e (the triangle is
// degenerate within the transform's rounding: its float plane is rounding noise). Clipped
// polygons: depth_tolerance.
double model_depth_tolerance_at(const ModelTriangle& t, double x, double y);

enum class HwPixel : uint8_t {
  kIdentical = 0,           // same key
  kDepthOnly,               // same triangle, depth bits differ within 2× the tolerance
  kAmbiguousDepth,          // different triangles within the sum of their tolerances (the mask)
  kAmbiguousClipCoverage,   // centre within δ of a clipped triangle's exact outline
  kAmbiguousSnapCoverage,   // centre within δ of an unclipped triangle's exact outline (float32 transform)
  kDepthBeyondTolerance,    // same triangle, depth further apart: fails
  kViolation,               // anything else: fails
};
inline constexpr int kHwPixelKinds = 7;
inline bool hw_pixel_ok(HwPixel p) { return p <= HwPixel::kAmbiguousSnapCoverage; }
const char* hw_pixel_name(HwPixel p);

// One pixel (centre x + ½, y + ½). `ref`/`hw`: the triangles the two keys denote (nullptr for
// background); `same_triangle`: both denote the same (instance, cluster, triangle).
HwPixel classify_hw_pixel(uint64_t ref_key, uint64_t hw_key, bool same_triangle, const ModelTriangle* ref,
                          const ModelTriangle* hw, uint32_t x, uint32_t y);

struct HwRasterAgreement {
  uint64_t pixels[kHwPixelKinds] = {};
  double max_depth_error_ratio = 0;  // same-triangle |Δdepth| / tolerance, largest
  uint64_t count(HwPixel p) const { return pixels[int(p)]; }
  uint64_t failures() const { return count(HwPixel::kDepthBeyondTolerance) + count(HwPixel::kViolation); }
  uint64_t in_mask() const {
    return count(HwPixel::kAmbiguousDepth) + count(HwPixel::kAmbiguousClipCoverage) + count(HwPixel::kAmbiguousSnapCoverage);
  }
  void add(const HwRasterAgreement& o);
};

}  // namespace vgeo
