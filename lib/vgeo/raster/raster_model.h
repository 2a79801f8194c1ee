#pragma once
// Exact coverage model for comparing a rasterizer against this specification
// (spec/raster.md §10, the Vulkan CTS model): the triangle clipped against w = z_near in
// double, projected without snapping or guard band. A pixel is compared only when its
// centre is at least unambiguous_margin() from the polygon outline; there coverage must
// match exactly. Used by tests/raster and meant for the GPU path and other implementations.
#include <cstdint>

#include "vgeo/core/math.h"

namespace vgeo {

enum class ModelCoverage : int8_t { kOutside = -1, kAmbiguous = 0, kInside = 1 };

struct ModelPolygon {
  static constexpr uint32_t kMaxVertices = 4;  // a triangle clipped by one plane
  uint32_t count = 0;                          // < 3: covers nothing
  double x[kMaxVertices] = {}, y[kMaxVertices] = {};  // screen pixels, row 0 at the top
  double depth[kMaxVertices] = {};                    // clip.z / clip.w
};

// Exact screen polygon of one triangle (object-space vertices). Non-finite input → empty.
ModelPolygon model_polygon(const Vec3 (&object)[3], const Mat4& object_to_clip, double z_near,
                           uint32_t width, uint32_t height);

// δ = 2^-6 px + 2^-18 · (largest |screen coordinate| of the polygon, px).
double unambiguous_margin(const ModelPolygon& polygon);

// The M term of δ alone: 2^-18 · M, how far (per coordinate, px) a conforming float32
// transform may put a vertex from the exact one.
double model_transform_shift(const ModelPolygon& polygon);

// Euclidean distance from (x, y) to the polygon's outline; *inside: whether the point is
// inside (nonzero winding).
double model_outline_distance(const ModelPolygon& polygon, double x, double y, bool* inside);

// Coverage class of the point (x, y) in screen pixels (pixel centres are at +0.5):
// inside/outside when at distance ≥ `margin` from the outline, else ambiguous.
ModelCoverage model_coverage(const ModelPolygon& polygon, double x, double y, double margin);

}  // namespace vgeo
