// Software rasterizer into the 64-bit visibility buffer. Normative: spec/raster.md.
//
// Pipeline per triangle: transform (double) → reject non-finite / trivially outside →
// Sutherland–Hodgman clip against w = z_near and the guard band (only when needed) →
// snap to 8-bit sub-pixel fixed point → back-face / degenerate cull → exact int64
// half-space coverage with the top-left rule over one of three pixel loops (micropoly
// bounding box, exact scanline spans, brute-force reference). All loops share one
// coverage predicate and one depth function, so they produce bit-identical buffers.
// Design source: Nanite deep dive (Karis et al. 2021), "Software Rasterization".
// Based on: Pineda, "A Parallel Algorithm for Polygon Rasterization", SIGGRAPH 1988 (edge
// functions); Sutherland, Hodgman, "Reentrant Polygon Clipping", CACM 1974; the software
// micro-triangle raster of Karis et al., "Nanite: A Deep Dive", SIGGRAPH 2021.
#include "vgeo/raster/raster.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cassert>
#include <cmath>
#include <limits>
#include <numbers>
#include <utility>

namespace vgeo {
namespace {

constexpr int64_t kSubpixelScale = int64_t(1) << kSubpixelBits;  // 256 units per pixel
constexpr int64_t kHalfPixel = kSubpixelScale / 2;                // pixel centre offset

// Bound on |snapped coordinate| (sub-pixel units). Guard band: |x_ndc| ≤ 64 maps to
// |sx| ≤ 32.5 · 16384 px < 2^20 px < 2^28 units. Clamping to 2^28 is only a safety net
// against the last-bit rounding of clipping; edge products stay below 2^58 (exact).
constexpr double kMaxSnapped = double(int64_t(1) << 28);

// Auto path threshold: triangles whose clamped bounding box is at least this many pixels
// wide use the scanline loop. Micropoly tests every pixel of the box (≥ half wasted for
// any triangle); scanline pays a few integer divisions per row to skip the misses.
// Measured crossover on x86-64 (tools/bench/raster_bench.cpp, spec/raster.md): ~8 px.
constexpr int64_t kScanlineMinWidth = 8;

// Smallest depth ever written: the smallest normal float. Depths of very distant
// surfaces (z/w underflowing) clamp here, so a written depth is never 0, −0 or a
// denormal (GPU paths flush denormals; both must write the same key).
constexpr float kMinWrittenDepth = std::numeric_limits<float>::min();

// Planes clipped against, in this fixed order (the order is part of the determinism
// contract: shared edges must be clipped identically in neighbouring triangles).
enum ClipPlane : int { kNear = 0, kGuardPosX, kGuardNegX, kGuardPosY, kGuardNegY, kPlaneCount };
// Outcode bits: one per clip plane, then the four viewport planes for trivial rejection.
constexpr uint32_t kOutNear = 1u << kNear;
constexpr uint32_t kOutClipMask = (1u << kPlaneCount) - 1;
constexpr uint32_t kOutViewPosX = 1u << 5, kOutViewNegX = 1u << 6, kOutViewPosY = 1u << 7,
                   kOutViewNegY = 1u << 8;
constexpr uint32_t kOutRejectMask = kOutNear | kOutViewPosX | kOutViewNegX | kOutViewPosY | kOutViewNegY;

// Local vertex indices are 8-bit.
constexpr uint32_t kAddressableVertices = 256;

// Sutherland–Hodgman output grows by at most one vertex per plane.
constexpr int kMaxPolygon = 3 + kPlaneCount;

struct ClipVertex {
  double x, y, z, w;
};

struct ScreenVertex {
  int64_t x, y;  // sub-pixel fixed point, row 0 at the top
  double z;      // NDC depth z/w
};

struct Viewport {
  int64_t width, height;
  double scale_x, scale_y;  // width·256, height·256
};

double plane_distance(const ClipVertex& v, int plane, double z_near) {
  switch (plane) {
    case kNear: return v.w - z_near;
    case kGuardPosX: return kGuardBandNdc * v.w - v.x;
    case kGuardNegX: return kGuardBandNdc * v.w + v.x;
    case kGuardPosY: return kGuardBandNdc * v.w - v.y;
    default: return kGuardBandNdc * v.w + v.y;
  }
}

uint32_t outcode(const ClipVertex& v, double z_near) {
  uint32_t code = 0;
  for (int p = 0; p < kPlaneCount; ++p)
    if (plane_distance(v, p, z_near) < 0) code |= 1u << p;
  if (v.x > v.w) code |= kOutViewPosX;
  if (v.x < -v.w) code |= kOutViewNegX;
  if (v.y > v.w) code |= kOutViewPosY;
  if (v.y < -v.w) code |= kOutViewNegY;
  return code;
}

// Intersection of edge (inside, outside) with `plane`. Always computed from the inside
// vertex towards the outside one, so the two triangles sharing an edge (which walk it
// in opposite directions) get bit-identical vertices; the plane coordinate is then set
// exactly so later planes and the depth see a point on the plane.
ClipVertex intersect(const ClipVertex& in, const ClipVertex& out, int plane, double z_near) {
  double d_in = plane_distance(in, plane, z_near), d_out = plane_distance(out, plane, z_near);
  double t = d_in / (d_in - d_out);  // d_in ≥ 0 > d_out, so the divisor is > 0 and t ∈ [0, 1]
  ClipVertex r{in.x + t * (out.x - in.x), in.y + t * (out.y - in.y), in.z + t * (out.z - in.z),
               in.w + t * (out.w - in.w)};
  switch (plane) {
    case kNear: r.w = z_near; break;
    case kGuardPosX: r.x = kGuardBandNdc * r.w; break;
    case kGuardNegX: r.x = -kGuardBandNdc * r.w; break;
    case kGuardPosY: r.y = kGuardBandNdc * r.w; break;
    default: r.y = -kGuardBandNdc * r.w; break;
  }
  return r;
}

// Clips a convex polygon in place against every plane in `mask`; returns the new count.
int clip_polygon(std::array<ClipVertex, kMaxPolygon>& poly, int count, uint32_t mask, double z_near) {
  std::array<ClipVertex, kMaxPolygon> out;
  for (int plane = 0; plane < kPlaneCount && count >= 3; ++plane) {
    if (!(mask & (1u << plane))) continue;
    int n = 0;
    for (int i = 0; i < count; ++i) {
      const ClipVertex& cur = poly[i];
      const ClipVertex& next = poly[(i + 1) % count];
      bool cur_in = plane_distance(cur, plane, z_near) >= 0;
      bool next_in = plane_distance(next, plane, z_near) >= 0;
      if (cur_in) out[n++] = cur;
      if (cur_in != next_in) out[n++] = cur_in ? intersect(cur, next, plane, z_near)
                                               : intersect(next, cur, plane, z_near);
      assert(n <= kMaxPolygon);
    }
    poly = out;
    count = n;
  }
  return count;
}

// Rounds a (finite, bounded) screen coordinate in sub-pixel units to the nearest integer,
// ties upward. The clamp is the range check that makes the float→int cast defined.
int64_t snap(double units) {
  if (!(units >= -kMaxSnapped)) units = -kMaxSnapped;
  if (!(units <= kMaxSnapped)) units = kMaxSnapped;
  return int64_t(std::floor(units + 0.5));
}

// Requires w ≥ z_near > 0 and |x|,|y| ≤ ~kGuardBandNdc·w (after clipping).
ScreenVertex project(const ClipVertex& v, const Viewport& vp) {
  double inv_w = 1.0 / v.w;
  ScreenVertex s;
  s.x = snap((v.x * inv_w * 0.5 + 0.5) * vp.scale_x);
  s.y = snap((0.5 - v.y * inv_w * 0.5) * vp.scale_y);  // NDC y up → row 0 at the top
  s.z = v.z * inv_w;
  return s;
}

int64_t floor_div(int64_t a, int64_t b) {  // b > 0
  int64_t q = a / b;
  return (a % b != 0 && a < 0) ? q - 1 : q;
}
int64_t ceil_div(int64_t a, int64_t b) { return -floor_div(-a, b); }  // b > 0

// Depth plane z(X, Y) = z0 + a·(X − X0) + b·(Y − Y0) over sub-pixel coordinates. Every
// pixel loop evaluates it through depth_at() with the same operation order, so the key
// of a pixel does not depend on the path.
struct DepthPlane {
  int64_t x0, y0;
  double z0, a, b;
};

float depth_at(const DepthPlane& p, int64_t px, int64_t py) {
  double dx = double(px * kSubpixelScale + kHalfPixel - p.x0);
  double dy = double(py * kSubpixelScale + kHalfPixel - p.y0);
  double z = (p.z0 + p.a * dx) + p.b * dy;
  // Clamp in double before narrowing (an out-of-range double→float conversion is UB);
  // the negated test also maps a NaN (inf − inf in extreme planes) to the minimum.
  if (!(z >= double(kMinWrittenDepth))) z = kMinWrittenDepth;
  if (z > 1.0) z = 1.0;
  return float(z);
}

// One oriented triangle (area > 0 in y-down screen space) ready for a pixel loop.
struct Setup {
  // Biased edge function e_i(px, py) = E_i(pixel centre) − bias_i; covered ⇔ all e_i ≥ 0.
  // E_i(P) = dx_i·(P.y − y_i) − dy_i·(P.x − x_i) for the edge v_i → v_{i+1}.
  int64_t vx[3], vy[3], dx[3], dy[3], bias[3];
  int64_t min_px, max_px, min_py, max_py;  // pixel range (inclusive), clamped to the viewport
  DepthPlane depth;
  uint64_t id_bits;
  int64_t window_x, window_y;  // the target's pixel (0, 0) in the viewport (RasterOptions)
};

int64_t edge_at(const Setup& s, int i, int64_t px, int64_t py) {
  int64_t cx = px * kSubpixelScale + kHalfPixel, cy = py * kSubpixelScale + kHalfPixel;
  return s.dx[i] * (cy - s.vy[i]) - s.dy[i] * (cx - s.vx[i]) - s.bias[i];
}

void write_pixel(VisBuffer& target, const Setup& s, int64_t px, int64_t py) {
  uint64_t key = (uint64_t(std::bit_cast<uint32_t>(depth_at(s.depth, px, py))) << 32) | s.id_bits;
  target.write_max(uint32_t(px - s.window_x), uint32_t(py - s.window_y), key);
}

uint64_t loop_reference(VisBuffer& target, const Setup& s) {
  uint64_t written = 0;
  for (int64_t py = s.window_y; py < s.window_y + int64_t(target.height); ++py)
    for (int64_t px = s.window_x; px < s.window_x + int64_t(target.width); ++px)
      if (edge_at(s, 0, px, py) >= 0 && edge_at(s, 1, px, py) >= 0 && edge_at(s, 2, px, py) >= 0) {
        write_pixel(target, s, px, py);
        ++written;
      }
  return written;
}

uint64_t loop_micropoly(VisBuffer& target, const Setup& s) {
  uint64_t written = 0;
  int64_t row[3], step_x[3], step_y[3];
  for (int i = 0; i < 3; ++i) {
    row[i] = edge_at(s, i, s.min_px, s.min_py);
    step_x[i] = -s.dy[i] * kSubpixelScale;
    step_y[i] = s.dx[i] * kSubpixelScale;
  }
  for (int64_t py = s.min_py; py <= s.max_py; ++py) {
    int64_t e0 = row[0], e1 = row[1], e2 = row[2];
    for (int64_t px = s.min_px; px <= s.max_px; ++px) {
      if ((e0 | e1 | e2) >= 0) {  // all three signs clear
        write_pixel(target, s, px, py);
        ++written;
      }
      e0 += step_x[0];
      e1 += step_x[1];
      e2 += step_x[2];
    }
    row[0] += step_y[0];
    row[1] += step_y[1];
    row[2] += step_y[2];
  }
  return written;
}

// Per row, solves e_i(min_px + k) = c_i + a_i·k ≥ 0 for k exactly in integers.
uint64_t loop_scanline(VisBuffer& target, const Setup& s) {
  uint64_t written = 0;
  int64_t row[3], step_x[3], step_y[3];
  for (int i = 0; i < 3; ++i) {
    row[i] = edge_at(s, i, s.min_px, s.min_py);
    step_x[i] = -s.dy[i] * kSubpixelScale;
    step_y[i] = s.dx[i] * kSubpixelScale;
  }
  const int64_t last = s.max_px - s.min_px;
  for (int64_t py = s.min_py; py <= s.max_py; ++py) {
    int64_t lo = 0, hi = last;
    for (int i = 0; i < 3; ++i) {
      int64_t c = row[i], a = step_x[i];
      if (a > 0) {
        if (c < 0) lo = std::max(lo, ceil_div(-c, a));
      } else if (a < 0) {
        if (c < 0) hi = -1;
        else hi = std::min(hi, c / -a);  // c ≥ 0: truncation is floor
      } else if (c < 0) {
        hi = -1;
      }
    }
    for (int64_t k = lo; k <= hi; ++k) {
      write_pixel(target, s, s.min_px + k, py);
      ++written;
    }
    row[0] += step_y[0];
    row[1] += step_y[1];
    row[2] += step_y[2];
  }
  return written;
}

enum class TriangleResult { kCulled, kRasterized };

// Rasterizes one snapped triangle (any winding). Returns kCulled for back faces (when
// culling) and zero-area triangles.
TriangleResult raster_triangle(VisBuffer& target, ScreenVertex v0, ScreenVertex v1, ScreenVertex v2,
                               uint64_t id_bits, const RasterOptions& options, RasterStats& stats) {
  int64_t area = (v1.x - v0.x) * (v2.y - v0.y) - (v2.x - v0.x) * (v1.y - v0.y);
  if (area == 0) return TriangleResult::kCulled;
  // y-down screen space: counter-clockwise in NDC (y up) has negative area here.
  bool front = area < 0;
  if (!front && options.cull_backfaces) return TriangleResult::kCulled;
  if (area < 0) {
    std::swap(v1, v2);
    area = -area;
  }

  Setup s;
  const ScreenVertex* v[3] = {&v0, &v1, &v2};
  for (int i = 0; i < 3; ++i) {
    const ScreenVertex& a = *v[i];
    const ScreenVertex& b = *v[(i + 1) % 3];
    s.vx[i] = a.x;
    s.vy[i] = a.y;
    s.dx[i] = b.x - a.x;
    s.dy[i] = b.y - a.y;
    // Top-left rule (y down, interior to the left of the walk): a top edge is horizontal
    // with the interior below (dx > 0), a left edge goes up (dy < 0). Centres exactly on
    // any other edge are outside.
    bool top_left = s.dy[i] < 0 || (s.dy[i] == 0 && s.dx[i] > 0);
    s.bias[i] = top_left ? 0 : 1;
  }
  int64_t min_x = std::min({v0.x, v1.x, v2.x}), max_x = std::max({v0.x, v1.x, v2.x});
  int64_t min_y = std::min({v0.y, v1.y, v2.y}), max_y = std::max({v0.y, v1.y, v2.y});
  // Pixel px is a candidate iff its centre px·256 + 128 lies in [min, max].
  s.window_x = options.window_x;
  s.window_y = options.window_y;
  s.min_px = std::max<int64_t>(s.window_x, ceil_div(min_x - kHalfPixel, kSubpixelScale));
  s.max_px = std::min<int64_t>(s.window_x + int64_t(target.width) - 1, floor_div(max_x - kHalfPixel, kSubpixelScale));
  s.min_py = std::max<int64_t>(s.window_y, ceil_div(min_y - kHalfPixel, kSubpixelScale));
  s.max_py = std::min<int64_t>(s.window_y + int64_t(target.height) - 1, floor_div(max_y - kHalfPixel, kSubpixelScale));

  double inv_area = 1.0 / double(area);
  double dz1 = v1.z - v0.z, dz2 = v2.z - v0.z;
  s.depth.x0 = v0.x;
  s.depth.y0 = v0.y;
  s.depth.z0 = v0.z;
  s.depth.a = (dz1 * double(v2.y - v0.y) - dz2 * double(v1.y - v0.y)) * inv_area;
  s.depth.b = (dz2 * double(v1.x - v0.x) - dz1 * double(v2.x - v0.x)) * inv_area;
  s.id_bits = id_bits;

  RasterPath path = options.path;
  if (path == RasterPath::kAuto)
    path = (s.max_px - s.min_px + 1 >= kScanlineMinWidth) ? RasterPath::kScanline : RasterPath::kMicropoly;
  switch (path) {
    case RasterPath::kReference: stats.pixels_written += loop_reference(target, s); break;
    case RasterPath::kScanline:
      ++stats.scanline_triangles;
      if (s.min_px <= s.max_px && s.min_py <= s.max_py) stats.pixels_written += loop_scanline(target, s);
      break;
    default:
      ++stats.micropoly_triangles;
      if (s.min_px <= s.max_px && s.min_py <= s.max_py) stats.pixels_written += loop_micropoly(target, s);
      break;
  }
  return TriangleResult::kRasterized;
}

struct TransformedVertex {
  ClipVertex clip;
  ScreenVertex screen;  // valid when finite and (code & kOutClipMask) == 0
  uint32_t code;
  bool finite;
};

}  // namespace

void rasterize_cluster(VisBuffer& target, const float* positions, uint32_t vertex_count,
                       const uint8_t* indices, uint32_t triangle_count, const Mat4& object_to_clip,
                       uint32_t visible_cluster, const RasterOptions& options, RasterStats* stats_out) {
  RasterStats stats;
  stats.triangles_in = triangle_count;
  // Limits of the key layout and of exact fixed point. Programming errors (the culling
  // stage checks them, spec/raster.md); in release the whole cluster is dropped rather
  // than writing a wrong key.
  const bool windowed = options.virtual_width > 0;
  const uint32_t view_width = windowed ? options.virtual_width : target.width;
  const uint32_t view_height = windowed ? options.virtual_height : target.height;
  bool valid_call = visible_cluster < kMaxVisibleClusters && triangle_count <= kMaxClusterTriangles &&
                    view_width <= kMaxRasterViewport && view_height <= kMaxRasterViewport &&
                    (!windowed || (uint64_t(options.window_x) + target.width <= view_width &&
                                   uint64_t(options.window_y) + target.height <= view_height)) &&
                    std::isfinite(options.z_near) && options.z_near > 0 &&
                    target.keys.size() == size_t(target.width) * target.height;
  assert(valid_call);
  if (!valid_call) {
    stats.triangles_culled = stats.triangles_invalid = triangle_count;
    if (stats_out) stats_out->add(stats);
    return;
  }

  const double z_near = options.z_near;
  Viewport vp{int64_t(view_width), int64_t(view_height), double(view_width) * kSubpixelScale,
              double(view_height) * kSubpixelScale};

  double m[16];
  for (int i = 0; i < 16; ++i) m[i] = object_to_clip.m[i];
  // 8-bit indices address at most kAddressableVertices vertices: transform only those.
  const uint32_t transformed = std::min(vertex_count, kAddressableVertices);
  std::array<TransformedVertex, kAddressableVertices> verts;
  for (uint32_t i = 0; i < transformed; ++i) {
    double p[3] = {positions[3 * i], positions[3 * i + 1], positions[3 * i + 2]};
    double c[4];
    for (int r = 0; r < 4; ++r) c[r] = ((m[r] * p[0] + m[4 + r] * p[1]) + m[8 + r] * p[2]) + m[12 + r];
    TransformedVertex& t = verts[i];
    t.clip = {c[0], c[1], c[2], c[3]};
    t.finite = std::isfinite(c[0]) && std::isfinite(c[1]) && std::isfinite(c[2]) && std::isfinite(c[3]);
    t.code = t.finite ? outcode(t.clip, z_near) : 0;
    if (t.finite && (t.code & kOutClipMask) == 0) t.screen = project(t.clip, vp);
  }

  for (uint32_t tri = 0; tri < triangle_count; ++tri) {
    uint32_t idx[3] = {indices[3 * tri], indices[3 * tri + 1], indices[3 * tri + 2]};
    if (idx[0] >= vertex_count || idx[1] >= vertex_count || idx[2] >= vertex_count) {
      ++stats.triangles_culled;
      ++stats.triangles_invalid;
      continue;
    }
    const TransformedVertex* tv[3] = {&verts[idx[0]], &verts[idx[1]], &verts[idx[2]]};
    if (!tv[0]->finite || !tv[1]->finite || !tv[2]->finite) {
      ++stats.triangles_culled;
      ++stats.triangles_invalid;
      continue;
    }
    // Entirely behind the near plane or entirely outside one viewport side.
    if (tv[0]->code & tv[1]->code & tv[2]->code & kOutRejectMask) {
      ++stats.triangles_culled;
      continue;
    }
    uint64_t id_bits = (uint64_t(visible_cluster) << kVisTriangleBits) | tri;
    uint32_t clip_mask = (tv[0]->code | tv[1]->code | tv[2]->code) & kOutClipMask;
    bool any_drawn = false;
    if (clip_mask == 0) {
      any_drawn = raster_triangle(target, tv[0]->screen, tv[1]->screen, tv[2]->screen, id_bits, options,
                                  stats) == TriangleResult::kRasterized;
    } else {
      ++stats.triangles_clipped;
      std::array<ClipVertex, kMaxPolygon> poly;
      for (int k = 0; k < 3; ++k) poly[k] = tv[k]->clip;
      int count = clip_polygon(poly, 3, clip_mask, z_near);
      if (count >= 3) {
        std::array<ScreenVertex, kMaxPolygon> screen;
        for (int k = 0; k < count; ++k) screen[k] = project(poly[k], vp);
        for (int k = 1; k + 1 < count; ++k)  // fan: sub-triangles keep the winding
          any_drawn |= raster_triangle(target, screen[0], screen[k], screen[k + 1], id_bits, options,
                                       stats) == TriangleResult::kRasterized;
      }
    }
    if (!any_drawn) ++stats.triangles_culled;
  }
  if (stats_out) stats_out->add(stats);
}

Mat4d perspective_reversed_z(double fov_y_radians, double aspect, double z_near) {
  assert(fov_y_radians > 0 && fov_y_radians < std::numbers::pi && aspect > 0 && z_near > 0);
  double f = 1.0 / std::tan(0.5 * fov_y_radians);
  Mat4d p;
  for (double& v : p.m) v = 0;
  p.at(0, 0) = f / aspect;
  p.at(1, 1) = f;
  p.at(2, 3) = z_near;  // clip.z = z_near
  p.at(3, 2) = -1.0;    // clip.w = −view_z (view looks down −Z)
  return p;
}

}  // namespace vgeo
