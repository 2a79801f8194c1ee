// Software rasterizer in compute: the GLSL image of lib/vgeo/raster/raster.cpp, operation for
// operation, so every visibility-buffer key is bit-identical to the CPU reference
// (spec/raster.md §Backends agree). Doubles where the CPU uses double, int64 where it uses
// int64; every floating-point temporary is `precise` (SPIR-V NoContraction) because the CPU
// build does not contract a·b + c into a fused multiply-add either. Compiled twice
// (VGEO_RASTER_TILE_PASS): raster.comp, the cluster pass (one workgroup per visible cluster,
// one invocation per triangle; covered pixels get atomicMax of the key), which defers
// triangles whose pixel box exceeds kGpuRasterTileSize in x or y; raster_tiles.comp, the tile
// pass (one invocation per kGpuRasterTileSize² tile of a deferred box), which draws them with
// the same arithmetic (spec/raster.md §13.5). Two binaries, so neither pays for the other's
// branches per triangle. Both again with VGEO_RASTER_SHADOW_PASS (raster_shadow.comp,
// raster_shadow_tiles.comp): the virtual shadow pages (spec/shadow.md §5), where element i of
// the visible list is drawn into page shadow_pages[shadow_element_page[i]]: set up in that
// page's mip viewport, only the page's 128² texels visited (the CPU's RasterOptions window),
// and the texel's float depth bits atomicMax'ed into the page's pool slot (the CPU keeps the
// depth of the largest key, whose depth is the largest: the same value).
#extension GL_EXT_shader_explicit_arithmetic_types : require
#extension GL_EXT_shader_atomic_int64 : require
const bool kTilePass = VGEO_RASTER_TILE_PASS != 0;
#ifndef VGEO_RASTER_SHADOW_PASS
#define VGEO_RASTER_SHADOW_PASS 0
#endif
const bool kShadowPass = VGEO_RASTER_SHADOW_PASS != 0;
#include "vgeo/core/cull_shared.h"
#include "vgeo/core/vis_key.h"
#include "vgeo/gpu/shader_records.h"
#include "vgeo/gpu/hw_raster_records.h"

layout(local_size_x = 128) in;  // kGpuRasterGroupSize = kMaxClusterTriangles

#include "geometry.glsl"
layout(std430, binding = kGeomBindVis) buffer Vis { uint64_t vis[]; };
// Word kGpuRasterOverflowWord (after pixels_written): triangles whose pixel loops did not run
// to the end (llvmpipe's loop limiter, spec/raster.md §13.5); the host fails on any.
// Word kGpuRasterBigWord: the big triangles deferred to the tile pass (GpuBigTriangle).
layout(std430, binding = kRasterBindCounters) buffer Counters { uint64_t pixels_written; uint32_t loop_overflow; uint32_t big_count; };
layout(std430, binding = kRasterBindPaths) readonly buffer Paths { uint32_t path_of_visible[]; };
layout(std430, binding = kRasterBindBig) buffer BigTriangles { GpuBigTriangle big[]; };
layout(std430, binding = kRasterBindTiles) readonly buffer Tiles { GpuRasterTile tiles[]; };
layout(push_constant) uniform Push { GpuRasterParams params; };
#if VGEO_RASTER_SHADOW_PASS
layout(std430, binding = kRasterBindShadowPages) readonly buffer ShadowPages { GpuShadowPage shadow_pages[]; };
layout(std430, binding = kRasterBindShadowElementPage) readonly buffer ShadowElementPage { uint32_t shadow_element_page[]; };
layout(std430, binding = kRasterBindShadowPool) buffer ShadowPool { uint32_t shadow_pool[]; };
#endif

#define VGEO_PAGE_WORD(i) page_words[i]
#include "memory_page.glsl"

// raster.h / raster.cpp constants.
const int64_t kSubpixelScale = int64_t(256);  // 1 << kSubpixelBits
const int64_t kHalfPixel = int64_t(128);
const double kMaxSnapped = double(int64_t(1) << 28);
const double kGuardBandNdc = 64.0;
const uint32_t kNear = 0u, kGuardPosX = 1u, kGuardNegX = 2u, kGuardPosY = 3u, kGuardNegY = 4u, kPlaneCount = 5u;
const uint32_t kOutNear = 1u;
const uint32_t kOutClipMask = 31u;
const uint32_t kOutViewPosX = 32u, kOutViewNegX = 64u, kOutViewPosY = 128u, kOutViewNegY = 256u;
const uint32_t kOutRejectMask = 1u | 32u | 64u | 128u | 256u;
const int kMaxPolygon = 8;  // 3 + kPlaneCount

struct ClipVertex { double x, y, z, w; };
struct ScreenVertex { int64_t x, y; double z; };

double plane_distance(ClipVertex v, uint32_t plane, double z_near) {
  precise double d;
  if (plane == kNear) d = v.w - z_near;
  else if (plane == kGuardPosX) d = kGuardBandNdc * v.w - v.x;
  else if (plane == kGuardNegX) d = kGuardBandNdc * v.w + v.x;
  else if (plane == kGuardPosY) d = kGuardBandNdc * v.w - v.y;
  else d = kGuardBandNdc * v.w + v.y;
  return d;
}

uint32_t outcode(ClipVertex v, double z_near) {
  uint32_t code = 0u;
  for (uint32_t p = 0u; p < kPlaneCount; ++p)
    if (plane_distance(v, p, z_near) < 0.0) code |= 1u << p;
  if (v.x > v.w) code |= kOutViewPosX;
  if (v.x < -v.w) code |= kOutViewNegX;
  if (v.y > v.w) code |= kOutViewPosY;
  if (v.y < -v.w) code |= kOutViewNegY;
  return code;
}

ClipVertex intersect_plane(ClipVertex a, ClipVertex b, uint32_t plane, double z_near) {
  precise double d_in = plane_distance(a, plane, z_near);
  precise double d_out = plane_distance(b, plane, z_near);
  precise double t = d_in / (d_in - d_out);
  ClipVertex r;
  precise double rx = a.x + t * (b.x - a.x);
  precise double ry = a.y + t * (b.y - a.y);
  precise double rz = a.z + t * (b.z - a.z);
  precise double rw = a.w + t * (b.w - a.w);
  r.x = rx; r.y = ry; r.z = rz; r.w = rw;
  precise double g = kGuardBandNdc * r.w;
  if (plane == kNear) r.w = z_near;
  else if (plane == kGuardPosX) r.x = g;
  else if (plane == kGuardNegX) r.x = -g;
  else if (plane == kGuardPosY) r.y = g;
  else r.y = -g;
  return r;
}

int64_t snap(double units) {
  precise double u = units;
  if (!(u >= -kMaxSnapped)) u = -kMaxSnapped;
  if (!(u <= kMaxSnapped)) u = kMaxSnapped;
  precise double f = floor(u + 0.5);
  return int64_t(f);
}

ScreenVertex project(ClipVertex v, double scale_x, double scale_y) {
  precise double inv_w = 1.0 / v.w;
  precise double sx = (v.x * inv_w * 0.5 + 0.5) * scale_x;
  precise double sy = (0.5 - v.y * inv_w * 0.5) * scale_y;
  precise double sz = v.z * inv_w;
  ScreenVertex s;
  s.x = snap(sx);
  s.y = snap(sy);
  s.z = sz;
  return s;
}

int64_t floor_div(int64_t a, int64_t b) {
  int64_t q = a / b;
  return (a % b != int64_t(0) && a < int64_t(0)) ? q - int64_t(1) : q;
}
int64_t ceil_div(int64_t a, int64_t b) { return -floor_div(-a, b); }

const double kMinWrittenDepth = 1.1754943508222875e-38LF;  // FLT_MIN = 2^-126, exact in double

// The pixels a triangle may write (raster.cpp Setup's clamp): the viewport, or the shadow
// page's window in its mip (inclusive); the shadow page's pool slot.
int64_t g_clip_x0, g_clip_x1, g_clip_y0, g_clip_y1;
uint32_t g_slot;

// One oriented triangle's setup (raster.cpp Setup).
int64_t g_vx[3], g_vy[3], g_dx[3], g_dy[3], g_bias[3];
int64_t g_x0, g_y0;
double g_z0, g_a, g_b;

int64_t edge_at(int i, int64_t px, int64_t py) {
  int64_t cx = px * kSubpixelScale + kHalfPixel, cy = py * kSubpixelScale + kHalfPixel;
  return g_dx[i] * (cy - g_vy[i]) - g_dy[i] * (cx - g_vx[i]) - g_bias[i];
}

float depth_at(int64_t px, int64_t py) {
  precise double dx = double(px * kSubpixelScale + kHalfPixel - g_x0);
  precise double dy = double(py * kSubpixelScale + kHalfPixel - g_y0);
  precise double z = (g_z0 + g_a * dx) + g_b * dy;
  if (!(z >= kMinWrittenDepth)) z = kMinWrittenDepth;
  if (z > 1.0) z = 1.0;
  return float(z);
}

// Which pixels of a triangle an invocation draws. The cluster pass: its whole box, unless the
// box exceeds kGpuRasterTileSize in x or y (then it records the triangle in the big-triangle
// list as fan triangle `fan` of triangle id_bits); the tile pass: the box's pixels in the tile
// [lo, hi].
struct PixelScope {
  ivec2 lo, hi;
  uint32_t fan;
};

// raster.cpp raster_triangle (all pixel loops produce the same set; this is the bounding-box
// loop over exact edge functions). Returns false when culled (back face, zero area).
// `planned` sums the invocation's pixel-loop back edges; `overflow` is set when they would
// exceed kGpuLoopBudget less kGpuRasterLoopMargin (then nothing is drawn) or when a loop was
// left before its end all the same (the limiter counts a whole 8-lane vector's back edges).
// Neither can happen with boxes of at most kGpuRasterTileSize² (shader_records.h): kept so
// that a change of that bound cannot draw a wrong image silently.
bool raster_triangle(ScreenVertex v0, ScreenVertex v1, ScreenVertex v2, uint32_t id_bits, PixelScope scope,
                     inout uint64_t written, inout int64_t planned, inout bool overflow) {
  int64_t area = (v1.x - v0.x) * (v2.y - v0.y) - (v2.x - v0.x) * (v1.y - v0.y);
  if (area == int64_t(0)) return false;
  bool front = area < int64_t(0);
  if (!front && params.cull_backfaces != 0u) return false;
  if (area < int64_t(0)) {
    ScreenVertex t = v1;
    v1 = v2;
    v2 = t;
    area = -area;
  }
  ScreenVertex v[3] = ScreenVertex[3](v0, v1, v2);
  for (int i = 0; i < 3; ++i) {
    ScreenVertex a = v[i];
    ScreenVertex b = v[(i + 1) % 3];
    g_vx[i] = a.x;
    g_vy[i] = a.y;
    g_dx[i] = b.x - a.x;
    g_dy[i] = b.y - a.y;
    bool top_left = g_dy[i] < int64_t(0) || (g_dy[i] == int64_t(0) && g_dx[i] > int64_t(0));
    g_bias[i] = top_left ? int64_t(0) : int64_t(1);
  }
  int64_t min_x = min(v0.x, min(v1.x, v2.x)), max_x = max(v0.x, max(v1.x, v2.x));
  int64_t min_y = min(v0.y, min(v1.y, v2.y)), max_y = max(v0.y, max(v1.y, v2.y));
  int64_t min_px = max(g_clip_x0, ceil_div(min_x - kHalfPixel, kSubpixelScale));
  int64_t max_px = min(g_clip_x1, floor_div(max_x - kHalfPixel, kSubpixelScale));
  int64_t min_py = max(g_clip_y0, ceil_div(min_y - kHalfPixel, kSubpixelScale));
  int64_t max_py = min(g_clip_y1, floor_div(max_y - kHalfPixel, kSubpixelScale));
  const int64_t tile_size = int64_t(kGpuRasterTileSize);
  if (kTilePass) {
    min_px = max(min_px, int64_t(scope.lo.x));
    max_px = min(max_px, int64_t(scope.hi.x));
    min_py = max(min_py, int64_t(scope.lo.y));
    max_py = min(max_py, int64_t(scope.hi.y));
  } else if (max_px - min_px >= tile_size || max_py - min_py >= tile_size) {
    const uint32_t slot = atomicAdd(big_count, 1u);  // the host fails when slot ≥ the capacity
    if (slot < kGpuRasterMaxBigTriangles)
      big[slot] = GpuBigTriangle(id_bits, scope.fan, int32_t(min_px), int32_t(max_px), int32_t(min_py),
                                 int32_t(max_py), uint32_t[2](0u, 0u));
    return true;
  }

  precise double inv_area = 1.0 / double(area);
  precise double dz1 = v1.z - v0.z;
  precise double dz2 = v2.z - v0.z;
  g_x0 = v0.x;
  g_y0 = v0.y;
  g_z0 = v0.z;
  precise double pa = (dz1 * double(v2.y - v0.y) - dz2 * double(v1.y - v0.y)) * inv_area;
  precise double pb = (dz2 * double(v1.x - v0.x) - dz1 * double(v2.x - v0.x)) * inv_area;
  g_a = pa;
  g_b = pb;

  // Back edges of the loops below: one per pixel and one per row (inner exit), plus the
  // outer loop's own exit.
  const int64_t rows = max(int64_t(0), max_py - min_py + int64_t(1));
  const int64_t columns = max(int64_t(0), max_px - min_px + int64_t(1));
  planned += rows * (columns + int64_t(1)) + int64_t(1);
  if (planned > int64_t(kGpuLoopBudget - kGpuRasterLoopMargin)) {
    overflow = true;
    return true;
  }
  int64_t py = min_py;
  for (; py <= max_py; ++py) {
    int64_t px = min_px;
    for (; px <= max_px; ++px)
      if (edge_at(0, px, py) >= int64_t(0) && edge_at(1, px, py) >= int64_t(0) && edge_at(2, px, py) >= int64_t(0)) {
#if VGEO_RASTER_SHADOW_PASS
        const uint32_t texel = uint32_t(py - g_clip_y0) * kGpuShadowPageTexels + uint32_t(px - g_clip_x0);
        atomicMax(shadow_pool[g_slot * kGpuShadowPageTexels * kGpuShadowPageTexels + texel], floatBitsToUint(depth_at(px, py)));
#else
        uint64_t key = pack_vis_key_bits(floatBitsToUint(depth_at(px, py)), 0u, 0u) | uint64_t(id_bits);
        atomicMax(vis[uint32_t(py) * params.width + uint32_t(px)], key);
#endif
        ++written;
      }
    if (px <= max_px) overflow = true;  // the row was left early: the limiter ran out
  }
  if (py <= max_py) overflow = true;
  return true;
}

struct TransformedVertex {
  ClipVertex clip;
  ScreenVertex screen;
  uint32_t code;
  bool finite;
};

bool finite_d(double v) { return !isinf(v) && !isnan(v); }

TransformedVertex transform_vertex(MemoryCluster c, uint32_t v, GpuInstance inst, int32_t step_log2,
                                   double z_near, double scale_x, double scale_y) {
  double p[3];
  for (uint32_t k = 0u; k < 3u; ++k) p[k] = double(dequantize_position(memory_vertex_channel(c, v, k), step_log2));
  double cc[4];
  for (int r = 0; r < 4; ++r) {
    precise double s = ((double(inst.object_to_clip[r]) * p[0] + double(inst.object_to_clip[4 + r]) * p[1]) +
                        double(inst.object_to_clip[8 + r]) * p[2]) + double(inst.object_to_clip[12 + r]);
    cc[r] = s;
  }
  TransformedVertex t;
  t.clip = ClipVertex(cc[0], cc[1], cc[2], cc[3]);
  t.finite = finite_d(cc[0]) && finite_d(cc[1]) && finite_d(cc[2]) && finite_d(cc[3]);
  t.code = t.finite ? outcode(t.clip, z_near) : 0u;
  t.screen = ScreenVertex(int64_t(0), int64_t(0), 0.0);
  if (t.finite && (t.code & kOutClipMask) == 0u) t.screen = project(t.clip, scale_x, scale_y);
  return t;
}

// Triangle `tri` of visible[visible_index], transformed, clipped and drawn as raster.cpp does;
// `fan_only` ≥ 0 (the tile pass) draws only that fan triangle of its clipped polygon.
void draw_triangle(uint32_t visible_index, uint32_t tri, int fan_only, PixelScope scope, inout uint64_t written,
                   inout int64_t planned, inout bool overflow) {
  GpuVisibleCluster vc = visible[visible_index];
  GpuInstance inst = instances[vc.instance];
  GpuMesh mesh = meshes[inst.mesh];
  GpuClusterLocation loc = locations[mesh.first_location + vc.cluster];
  MemoryCluster c = memory_cluster(loc.page_word, loc.cluster_in_page, mesh.channel_count);
  if (tri >= c.triangle_count) return;

  double z_near = double(params.z_near);
  double scale_x = double(params.width) * double(kSubpixelScale);
  double scale_y = double(params.height) * double(kSubpixelScale);
  g_clip_x0 = int64_t(0);
  g_clip_y0 = int64_t(0);
  g_clip_x1 = int64_t(params.width) - int64_t(1);
  g_clip_y1 = int64_t(params.height) - int64_t(1);
#if VGEO_RASTER_SHADOW_PASS
  {
    const GpuShadowPage page = shadow_pages[shadow_element_page[visible_index]];
    z_near = double(page.z_near);
    scale_x = double(page.viewport) * double(kSubpixelScale);
    scale_y = scale_x;
    g_clip_x0 = int64_t(page.window_x);
    g_clip_y0 = int64_t(page.window_y);
    g_clip_x1 = g_clip_x0 + int64_t(kGpuShadowPageTexels) - int64_t(1);
    g_clip_y1 = g_clip_y0 + int64_t(kGpuShadowPageTexels) - int64_t(1);
    g_slot = page.slot;
  }
#endif
  uvec3 idx = memory_triangle(c, tri);
  if (idx.x >= c.vertex_count || idx.y >= c.vertex_count || idx.z >= c.vertex_count) return;
  TransformedVertex tv[3];
  tv[0] = transform_vertex(c, idx.x, inst, mesh.position_step_log2, z_near, scale_x, scale_y);
  tv[1] = transform_vertex(c, idx.y, inst, mesh.position_step_log2, z_near, scale_x, scale_y);
  tv[2] = transform_vertex(c, idx.z, inst, mesh.position_step_log2, z_near, scale_x, scale_y);
  if (!tv[0].finite || !tv[1].finite || !tv[2].finite) return;
  if ((tv[0].code & tv[1].code & tv[2].code & kOutRejectMask) != 0u) return;
  uint32_t id_bits = (visible_index << kVisTriangleBits) | tri;
  uint32_t clip_mask = (tv[0].code | tv[1].code | tv[2].code) & kOutClipMask;
  if (clip_mask == 0u) {
    scope.fan = 0u;
    raster_triangle(tv[0].screen, tv[1].screen, tv[2].screen, id_bits, scope, written, planned, overflow);
  } else {
    // raster.cpp clip_polygon: Sutherland–Hodgman in the fixed plane order.
    ClipVertex poly[kMaxPolygon];
    ClipVertex outp[kMaxPolygon];
    poly[0] = tv[0].clip;
    poly[1] = tv[1].clip;
    poly[2] = tv[2].clip;
    int count = 3;
    for (uint32_t plane = 0u; plane < kPlaneCount && count >= 3; ++plane) {
      if ((clip_mask & (1u << plane)) == 0u) continue;
      int n = 0;
      for (int i = 0; i < count; ++i) {
        ClipVertex cur = poly[i];
        ClipVertex next = poly[(i + 1) % count];
        bool cur_in = plane_distance(cur, plane, z_near) >= 0.0;
        bool next_in = plane_distance(next, plane, z_near) >= 0.0;
        if (cur_in) outp[n++] = cur;
        if (cur_in != next_in)
          outp[n++] = cur_in ? intersect_plane(cur, next, plane, z_near) : intersect_plane(next, cur, plane, z_near);
      }
      poly = outp;
      count = n;
    }
    if (count >= 3) {
      ScreenVertex screen[kMaxPolygon];
      for (int k = 0; k < count; ++k) screen[k] = project(poly[k], scale_x, scale_y);
      int k = 1;
      for (; k + 1 < count; ++k)
        if (fan_only < 0 || fan_only == k - 1) {
          scope.fan = uint32_t(k - 1);
          raster_triangle(screen[0], screen[k], screen[k + 1], id_bits, scope, written, planned, overflow);
        }
      if (k + 1 < count) overflow = true;  // a fan triangle was skipped: the limiter ran out
    }
  }
}

void main() {
  uint32_t group = gl_WorkGroupID.y * params.groups_x + gl_WorkGroupID.x;
  // One call of draw_triangle for both passes (one inlined copy of the pixel loops).
  uint32_t visible_index, tri;
  int fan_only = -1;
  PixelScope scope = PixelScope(ivec2(0, 0), ivec2(0, 0), 0u);
  if (kTilePass) {
    uint32_t t = group * kGpuRasterGroupSize + gl_LocalInvocationID.x;
    if (t >= params.tile_count) return;
    GpuRasterTile rt = tiles[t];
    GpuBigTriangle b = big[rt.big];
    visible_index = b.id_bits >> kVisTriangleBits;
    tri = b.id_bits & kVisTriangleMask;
    fan_only = int(b.fan);
    scope.lo = ivec2(rt.x0, rt.y0);
    scope.hi = scope.lo + ivec2(int(kGpuRasterTileSize) - 1);
  } else {
    if (group >= params.visible_count) return;
    visible_index = params.first_visible + group;
    if (params.select_path != 0u && path_of_visible[visible_index] != kGpuRasterPathSw) return;  // drawn by hw_raster
    tri = gl_LocalInvocationID.x;
  }
  uint64_t written = uint64_t(0);
  int64_t planned = int64_t(0);
  bool overflow = false;
  draw_triangle(visible_index, tri, fan_only, scope, written, planned, overflow);
  if (written != uint64_t(0)) atomicAdd(pixels_written, written);
  if (overflow) atomicAdd(loop_overflow, 1u);
}
