// Property: watertightness. Triangles sharing edges (a perturbed grid filling a rectangle,
// a fan filling a convex polygon, a 3D grid crossing the near plane) cover every pixel
// centre inside their union exactly once and nothing outside it, on every path.
#include <gtest/gtest.h>
#include <rapidcheck/gtest.h>
#include <algorithm>
#include <array>

#include "raster_testing.h"

namespace vgeo {
namespace {

using raster_test::raster_tris;
using raster_test::Tri;
using raster_test::uniform;

constexpr RasterPath kAllPaths[] = {RasterPath::kReference, RasterPath::kMicropoly, RasterPath::kScanline,
                                    RasterPath::kAuto};

// Rasterizes every triangle alone and counts, per pixel, how many triangles covered it.
std::vector<int> coverage_counts(const std::vector<Tri>& tris, const Mat4& m, uint32_t w, uint32_t h,
                                 RasterOptions opt) {
  std::vector<int> count(size_t(w) * h, 0);
  VisBuffer buf;
  buf.resize(w, h);
  for (const Tri& t : tris) {
    buf.clear();
    raster_tris(buf, {t}, m, 1, opt);
    for (size_t i = 0; i < buf.keys.size(); ++i) count[i] += buf.keys[i] != 0;
  }
  return count;
}

// Pixel coordinate on the 1/256 grid (exactly representable through pixel_to_clip).
float grid_coord(int units) { return float(units) / 256.0f; }

RC_GTEST_PROP(RasterWatertight, PerturbedGridCoversRectangleExactlyOnce, ()) {
  const uint32_t w = 64, h = 64;
  // Rectangle [x0, x1) × [y0, y1) in sub-pixel units, possibly reaching past the viewport.
  int x0 = uniform(-8 * 256, 40 * 256), y0 = uniform(-8 * 256, 40 * 256);
  int cols = uniform(1, 7), rows = uniform(1, 7);
  int cell_w = uniform(2 * 256, 12 * 256), cell_h = uniform(2 * 256, 12 * 256);
  if (uniform(0, 2)) {  // half-pixel grid: pixel centres exactly on the rectangle sides
    x0 = x0 / 128 * 128, y0 = y0 / 128 * 128;
    cell_w = cell_w / 128 * 128, cell_h = cell_h / 128 * 128;
  }
  int x1 = x0 + cols * cell_w, y1 = y0 + rows * cell_h;
  bool snap_interior = uniform(0, 2) == 0;  // interior vertices on the half-pixel grid
  // Vertex (i, j): boundary vertices stay on their rectangle side; each coordinate moves
  // by at most 0.15 of a cell, which keeps every triangle positively oriented.
  std::vector<Vec3> grid(size_t(cols + 1) * (rows + 1));
  for (int j = 0; j <= rows; ++j)
    for (int i = 0; i <= cols; ++i) {
      int ux = x0 + i * cell_w, uy = y0 + j * cell_h;
      int jitter_x = cell_w * 15 / 100, jitter_y = cell_h * 15 / 100;
      if (i > 0 && i < cols) ux += uniform(-jitter_x, jitter_x + 1);
      if (j > 0 && j < rows) uy += uniform(-jitter_y, jitter_y + 1);
      if (snap_interior && i > 0 && i < cols) ux = ux / 128 * 128;
      if (snap_interior && j > 0 && j < rows) uy = uy / 128 * 128;
      float z = raster_test::depth_value();
      grid[size_t(j) * (cols + 1) + i] = {grid_coord(ux), grid_coord(uy), z};
    }
  std::vector<Tri> tris;
  for (int j = 0; j < rows; ++j)
    for (int i = 0; i < cols; ++i) {
      Vec3 p00 = grid[size_t(j) * (cols + 1) + i], p10 = grid[size_t(j) * (cols + 1) + i + 1];
      Vec3 p01 = grid[size_t(j + 1) * (cols + 1) + i], p11 = grid[size_t(j + 1) * (cols + 1) + i + 1];
      // Front-facing (counter-clockwise in NDC = clockwise on screen with y down).
      if (uniform(0, 2)) {
        tris.push_back({{p00, p01, p10}});
        tris.push_back({{p10, p01, p11}});
      } else {
        tris.push_back({{p00, p01, p11}});
        tris.push_back({{p00, p11, p10}});
      }
    }
  RasterOptions opt;
  opt.cull_backfaces = true;  // all triangles are front-facing: culling must not drop any
  for (RasterPath path : kAllPaths) {
    opt.path = path;
    std::vector<int> count = coverage_counts(tris, raster_test::pixel_to_clip(w, h), w, h, opt);
    for (uint32_t py = 0; py < h; ++py)
      for (uint32_t px = 0; px < w; ++px) {
        int cx = int(px) * 256 + 128, cy = int(py) * 256 + 128;
        // Top-left rule on the rectangle: left and top sides inside, right and bottom not.
        int expected = (cx >= x0 && cx < x1 && cy >= y0 && cy < y1) ? 1 : 0;
        int got = count[size_t(py) * w + px];
        if (got != expected)
          RC_LOG() << "path " << int(path) << " pixel (" << px << ", " << py << ") covered " << got
                   << " times, expected " << expected << "\n";
        RC_ASSERT(got == expected);
      }
  }
}

// Exact top-left inside test for a convex polygon in sub-pixel units (counter-clockwise
// in NDC = clockwise on screen), written independently of the rasterizer.
bool polygon_covers(const std::vector<std::array<int64_t, 2>>& poly, int64_t cx, int64_t cy) {
  for (size_t i = 0; i < poly.size(); ++i) {
    auto a = poly[i], b = poly[(i + 1) % poly.size()];
    int64_t dx = b[0] - a[0], dy = b[1] - a[1];
    // Front-facing order has negative area in y-down screen space: interior is e < 0.
    int64_t e = dx * (cy - a[1]) - dy * (cx - a[0]);
    if (e > 0) return false;
    if (e == 0) {
      // The rasterizer walks this edge reversed, (−dx, −dy), with the interior on its
      // positive side: top edge ⇔ −dy == 0 and −dx > 0; left edge ⇔ −dy < 0.
      bool top_left = (-dy < 0) || (dy == 0 && -dx > 0);
      if (!top_left) return false;
    }
  }
  return true;
}

RC_GTEST_PROP(RasterWatertight, FanCoversConvexPolygonExactlyOnce, ()) {
  const uint32_t w = 64, h = 64;
  int n = uniform(3, 13);
  double cx = uniform(0, 64), cy = uniform(0, 64), r = uniform(1, 48);
  // Sorted angles; vertices on the 1/256 (or half-pixel) grid.
  std::vector<int> angles;
  for (int i = 0; i < n; ++i) angles.push_back(uniform(0, 3600));
  std::sort(angles.begin(), angles.end());
  int grid = uniform(0, 2) ? 256 : 2;
  std::vector<std::array<int64_t, 2>> poly;  // sub-pixel units
  for (int a : angles) {
    // Screen-clockwise order = increasing angle with y down; build then reverse to get
    // counter-clockwise-in-NDC front faces below.
    double t = a * 3.14159265358979 / 1800.0;
    int64_t ux = int64_t(std::lround((cx + r * std::cos(t)) * grid)) * (256 / grid);
    int64_t uy = int64_t(std::lround((cy + r * std::sin(t)) * grid)) * (256 / grid);
    if (!poly.empty() && poly.back()[0] == ux && poly.back()[1] == uy) continue;
    poly.push_back({ux, uy});
  }
  // Keep only strictly convex polygons (snapping can break convexity).
  RC_PRE(poly.size() >= 3);
  for (size_t i = 0; i < poly.size(); ++i) {
    auto a = poly[i], b = poly[(i + 1) % poly.size()], c = poly[(i + 2) % poly.size()];
    int64_t cross = (b[0] - a[0]) * (c[1] - b[1]) - (b[1] - a[1]) * (c[0] - b[0]);
    RC_PRE(cross > 0);  // increasing angle with y down: positive turn
  }
  std::reverse(poly.begin(), poly.end());  // now counter-clockwise in NDC (front faces)
  // Centre vertex: inside the polygon, sometimes on a pixel centre, sometimes off-grid.
  int64_t sx = 0, sy = 0;
  for (auto& p : poly) sx += p[0], sy += p[1];
  Vec3 centre{float(double(sx) / double(poly.size()) / 256.0), float(double(sy) / double(poly.size()) / 256.0),
              0.5f};
  if (uniform(0, 2)) centre = {std::floor(centre.x) + 0.5f, std::floor(centre.y) + 0.5f, 0.5f};
  std::vector<Tri> tris;
  for (size_t i = 0; i < poly.size(); ++i) {
    auto a = poly[i], b = poly[(i + 1) % poly.size()];
    tris.push_back({{centre, {grid_coord(int(a[0])), grid_coord(int(a[1])), raster_test::depth_value()},
                     {grid_coord(int(b[0])), grid_coord(int(b[1])), raster_test::depth_value()}}});
  }
  // The fan tiles the polygon only if the centre is strictly inside every edge.
  for (const Tri& t : tris) {
    double area = (double(t.v[1].x) - t.v[0].x) * (double(t.v[2].y) - t.v[0].y) -
                  (double(t.v[2].x) - t.v[0].x) * (double(t.v[1].y) - t.v[0].y);
    RC_PRE(area < -1e-3);
  }
  RasterOptions opt;
  for (RasterPath path : kAllPaths) {
    opt.path = path;
    std::vector<int> count = coverage_counts(tris, raster_test::pixel_to_clip(w, h), w, h, opt);
    for (uint32_t py = 0; py < h; ++py)
      for (uint32_t px = 0; px < w; ++px) {
        int expected = polygon_covers(poly, int64_t(px) * 256 + 128, int64_t(py) * 256 + 128) ? 1 : 0;
        int got = count[size_t(py) * w + px];
        if (got != expected)
          RC_LOG() << "path " << int(path) << " pixel (" << px << ", " << py << ") covered " << got
                   << " times, expected " << expected << "\n";
        RC_ASSERT(got == expected);
      }
  }
}

// A planar grid in view space that crosses the near plane (and reaches behind the
// camera): shared edges are clipped identically, so no pixel is covered twice, and no
// pixel inside the clipped quad (away from its outline) is left uncovered.
RC_GTEST_PROP(RasterWatertight, NearPlaneClippedGridHasNoOverlapOrHole, ()) {
  const uint32_t w = 64, h = 48;
  const float z_near = 0.1f;
  Mat4 proj = to_float(perspective_reversed_z(1.3, double(w) / h, z_near));
  // Floor-like plane y = height, spanning z from behind the camera to far in front.
  float height = float(uniform(-300, 301)) / 100.0f;
  float tilt = float(uniform(-100, 101)) / 100.0f;
  // height 0: the plane contains the eye and projects to a line. Its snapped triangles are
  // slivers of either orientation that fold over their neighbours, and folded triangles
  // legitimately overlap with culling off (spec/raster.md §5: "exactly once" is for a grid
  // whose snapped triangles keep one orientation). Found by this property (1 run in ~9).
  RC_PRE(height != 0.0f);
  int cols = uniform(1, 6), rows = uniform(1, 6);
  float zb = float(uniform(-50, 300)) / 100.0f, zf = -float(uniform(100, 2000)) / 100.0f;
  float xl = -float(uniform(50, 1000)) / 100.0f, xr = float(uniform(50, 1000)) / 100.0f;
  auto point = [&](int i, int j) {
    float x = xl + (xr - xl) * float(i) / float(cols);
    float z = zb + (zf - zb) * float(j) / float(rows);
    return Vec3{x, height + tilt * x, z};
  };
  std::vector<Tri> tris, quad;
  for (int j = 0; j < rows; ++j)
    for (int i = 0; i < cols; ++i) {
      Vec3 a = point(i, j), b = point(i + 1, j), c = point(i, j + 1), d = point(i + 1, j + 1);
      tris.push_back({{a, b, d}});
      tris.push_back({{a, d, c}});
    }
  quad.push_back({{point(0, 0), point(cols, 0), point(cols, rows)}});
  quad.push_back({{point(0, 0), point(cols, rows), point(0, rows)}});
  RasterOptions opt;
  opt.z_near = z_near;
  opt.cull_backfaces = false;  // the plane may face either way
  for (RasterPath path : kAllPaths) {
    opt.path = path;
    std::vector<int> count = coverage_counts(tris, proj, w, h, opt);
    std::vector<int> whole = coverage_counts(quad, proj, w, h, opt);
    for (uint32_t py = 0; py < h; ++py)
      for (uint32_t px = 0; px < w; ++px) {
        int got = count[size_t(py) * w + px];
        RC_ASSERT(got <= 1);
        // Deep inside the two-triangle quad (its whole 3×3 neighbourhood covered and not
        // on the viewport border) the grid must cover the pixel too.
        bool deep = px > 0 && py > 0 && px + 1 < w && py + 1 < h;
        for (int dy = -1; dy <= 1 && deep; ++dy)
          for (int dx = -1; dx <= 1 && deep; ++dx) deep = whole[size_t(int(py) + dy) * w + size_t(int(px) + dx)] > 0;
        if (deep && got != 1) RC_LOG() << "hole at (" << px << ", " << py << ") path " << int(path) << "\n";
        RC_ASSERT(!deep || got == 1);
      }
  }
}

}  // namespace
}  // namespace vgeo
