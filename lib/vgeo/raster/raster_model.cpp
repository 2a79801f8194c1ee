// Exact coverage model (spec/raster.md §10). Deliberately shares no code with raster.cpp:
// it is the yardstick the rasterizer's own tests and other implementations are held to.
// Based on: the Vulkan specification's rasterization rules and the Vulkan CTS's comparison of
// only the pixels unambiguous at the declared sub-pixel precision.
#include "vgeo/raster/raster_model.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace vgeo {

namespace {
// δ = kMarginPixels + kMarginRelative · M (spec/raster.md §10): 4 sub-pixel units cover our
// snapping (≤ √2/512 px) with a wide margin; 2^-18 of the coordinate magnitude covers the
// float32 transform rounding of a conforming GPU implementation far from the screen.
constexpr double kMarginPixels = 1.0 / 64.0;
constexpr double kMarginRelative = 1.0 / (1 << 18);
}  // namespace

ModelPolygon model_polygon(const Vec3 (&object)[3], const Mat4& m, double z_near, uint32_t width,
                           uint32_t height) {
  ModelPolygon out;
  double clip[3][4];
  for (int v = 0; v < 3; ++v)
    for (int r = 0; r < 4; ++r) {
      clip[v][r] = double(m.at(r, 0)) * object[v].x + double(m.at(r, 1)) * object[v].y +
                   double(m.at(r, 2)) * object[v].z + double(m.at(r, 3));
      if (!std::isfinite(clip[v][r])) return out;
    }
  double poly[ModelPolygon::kMaxVertices][4];
  uint32_t n = 0;
  for (int i = 0; i < 3; ++i) {
    const double* a = clip[i];
    const double* b = clip[(i + 1) % 3];
    double da = a[3] - z_near, db = b[3] - z_near;
    if (da >= 0) std::copy(a, a + 4, poly[n++]);
    if ((da >= 0) != (db >= 0)) {
      double t = da / (da - db);
      for (int k = 0; k < 4; ++k) poly[n][k] = a[k] + t * (b[k] - a[k]);
      ++n;
    }
  }
  out.count = n;
  for (uint32_t i = 0; i < n; ++i) {
    out.x[i] = (poly[i][0] / poly[i][3] * 0.5 + 0.5) * width;
    out.y[i] = (0.5 - poly[i][1] / poly[i][3] * 0.5) * height;
    out.depth[i] = poly[i][2] / poly[i][3];
  }
  return out;
}

double model_transform_shift(const ModelPolygon& p) {
  double largest = 0;
  for (uint32_t i = 0; i < p.count; ++i) largest = std::max({largest, std::abs(p.x[i]), std::abs(p.y[i])});
  return kMarginRelative * largest;
}

double unambiguous_margin(const ModelPolygon& p) { return kMarginPixels + model_transform_shift(p); }

double model_outline_distance(const ModelPolygon& p, double x, double y, bool* inside) {
  // Euclidean distance to the outline segments (no edge orientation needed, so slivers
  // and zero-area polygons are handled) and the winding number for inside/outside.
  double min_dist = std::numeric_limits<double>::infinity();
  int winding = 0;
  for (uint32_t i = 0; i < p.count; ++i) {
    uint32_t j = (i + 1) % p.count;
    double ax = p.x[i], ay = p.y[i], dx = p.x[j] - ax, dy = p.y[j] - ay;
    double len2 = dx * dx + dy * dy;
    double t = len2 > 0 ? std::clamp(((x - ax) * dx + (y - ay) * dy) / len2, 0.0, 1.0) : 0.0;
    min_dist = std::min(min_dist, std::hypot(ax + t * dx - x, ay + t * dy - y));
    if ((ay <= y) != (p.y[j] <= y)) {
      double crossing = ax + (y - ay) / dy * dx;
      if (crossing > x) winding += dy > 0 ? 1 : -1;
    }
  }
  *inside = winding != 0;
  return min_dist;
}

ModelCoverage model_coverage(const ModelPolygon& p, double x, double y, double margin) {
  if (p.count < 3) return ModelCoverage::kOutside;
  bool inside = false;
  const double min_dist = model_outline_distance(p, x, y, &inside);
  if (min_dist < margin) return ModelCoverage::kAmbiguous;
  return inside ? ModelCoverage::kInside : ModelCoverage::kOutside;
}

}  // namespace vgeo
