// Virtual shadow maps, CPU reference: maps, texel selection, marking, pool + cache, page drawing
// and the shadow test, each named as its step in spec/shadow.md.
// Based on: Karis et al., "Nanite: A Deep Dive" (SIGGRAPH 2021), §"Virtual shadow maps" (page
// size, page table with mips, marking by one texel ≈ one pixel, caching), §"Multi-view
// rendering", §"Culling and addressing to pages" (one cluster emitted per overlapped page,
// scissored to it), §"Nanite shadow LOD" (LOD from the light's projection, 2 px shadow LOD bias);
// the seed notes' §"Virtual shadow buffer" (reuse when neither light nor caster moved; the
// screen-space trace "walking a few pixels towards the light source if the difference in depths
// is small"; Karis et al.'s "short screen space trace to span the zone where they could differ").
// Multi-view: one cull traverses every instance once for all page views (each (map, mip) with
// pages to draw), then one raster pass draws every page. The traversal is flat over clusters
// (the BVH/persistent-thread traversal of lib/vgeo/cull is single-view and perspective-only).
#include "vgeo/shadow/virtual_shadow.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <map>
#include <numbers>
#include <tuple>

#include "vgeo/core/lod.h"
#include "vgeo/raster/raster.h"

namespace vgeo {

namespace {

constexpr uint32_t kPageTexelCount = kShadowPageTexels * kShadowPageTexels;
constexpr uint32_t kPointFaces = 6;
// Spot and point near plane z_s = kShadowNearFraction · r: far below any caster detail of a
// scene of radius r, far above the double rounding of light-view depths.
constexpr double kShadowNearFraction = 1e-4;
// |f.y| above this: f is too close to the default up (0,1,0); use (1,0,0) instead.
constexpr double kUpSwitch = 0.99;
// Directional light view, in scene radii r (spec/shadow.md §3): the eye sits 2r before the scene
// centre along the light, so every scene point has depth in [r, 3r]; depth maps 1 − dist/(4r)
// into [0.25, 0.75] (no clamping at either end); the coarsest clipmap level is 4r wide, so
// centred anywhere within r of the centre it still covers the whole scene sphere.
constexpr double kDirectionalEyeRadii = 2.0, kDirectionalDepthRadii = 4.0, kCoarsestLevelRadii = 4.0;
// Orthographic maps: clip.w = 1, so any raster near plane in (0, 1) never clips.
constexpr float kOrthoRasterNear = 0.5f;
// Mips of a map: kShadowMips, fewer when a test shrinks the page table below 128 pages (the
// coarsest mip is one page). The largest mip step by doubling is mips − 1 for spot/point maps
// and (levels − 1) + (mips − 1) for directional lights (levels, then mips of the coarsest level).
uint32_t mip_count(uint32_t pages_per_side) {
  uint32_t mips = 1;
  while (mips < kShadowMips && (pages_per_side >> mips) > 0) ++mips;
  return mips;
}

Vec3d normalized(const Vec3d& v) {
  double l = std::sqrt(dot(v, v));
  return {v.x / l, v.y / l, v.z / l};
}
Vec3d transform_point(const Mat4d& m, const Vec3d& p) {
  return {m.at(0, 0) * p.x + m.at(0, 1) * p.y + m.at(0, 2) * p.z + m.at(0, 3),
          m.at(1, 0) * p.x + m.at(1, 1) * p.y + m.at(1, 2) * p.z + m.at(1, 3),
          m.at(2, 0) * p.x + m.at(2, 1) * p.y + m.at(2, 2) * p.z + m.at(2, 3)};
}

// World → light view from eye E, forward f, up u (spec/shadow.md §3).
Mat4d light_view(const Vec3d& eye, const Vec3d& f, const Vec3d& up) {
  Vec3d x = normalized(cross(f, up));
  Vec3d y = cross(x, f);
  Vec3d rows[3] = {x, y, {-f.x, -f.y, -f.z}};
  Mat4d m;
  for (int r = 0; r < 3; ++r) {
    m.at(r, 0) = rows[r].x;
    m.at(r, 1) = rows[r].y;
    m.at(r, 2) = rows[r].z;
    m.at(r, 3) = -dot(rows[r], eye);
  }
  return m;
}

Vec3d default_up(const Vec3d& f) { return std::abs(f.y) > kUpSwitch ? Vec3d{1, 0, 0} : Vec3d{0, 1, 0}; }

uint32_t mip_table_offset(uint32_t pages_per_side, uint32_t mip) {
  uint32_t offset = 0;
  for (uint32_t k = 0; k < mip; ++k) offset += (pages_per_side >> k) * (pages_per_side >> k);
  return offset;
}

uint32_t virtual_size(const ShadowFrame& f) { return f.options.pages_per_side * kShadowPageTexels; }

ShadowMapView perspective_map(const Light& light, uint32_t index, const Vec3d& f, const Vec3d& up, double fov,
                              double z_s) {
  ShadowMapView m;
  m.type = light.type;
  m.index = index;
  m.eye = light.position;
  m.world_to_light = light_view(light.position, f, up);
  m.light_to_clip = perspective_reversed_z(fov, 1.0, z_s);
  m.tan_half = std::tan(0.5 * fov);
  m.z_near = z_s;
  return m;
}

// Clipmap level k of a directional light (spec/shadow.md §3).
ShadowMapView directional_level(const Light& light, uint32_t k, const ShadowSceneBounds& b, const Vec3d& camera,
                                uint32_t pages) {
  ShadowMapView m;
  m.type = light.type;
  m.index = k;
  m.ortho = true;
  const Vec3d& f = light.direction;
  const double back = kDirectionalEyeRadii * b.radius;
  m.eye = {b.center.x - back * f.x, b.center.y - back * f.y, b.center.z - back * f.z};
  m.world_to_light = light_view(m.eye, f, default_up(f));
  Vec3d o = transform_point(m.world_to_light, camera), c = transform_point(m.world_to_light, b.center);
  o.x = std::clamp(o.x, c.x - b.radius, c.x + b.radius);
  o.y = std::clamp(o.y, c.y - b.radius, c.y + b.radius);
  m.side = std::ldexp(kCoarsestLevelRadii * b.radius, int(k) - int(kDirectionalLevels - 1));
  const double w = m.side / pages;
  const int64_t half = pages / 2;
  m.origin_x = int64_t(std::floor(o.x / w)) - half;
  m.origin_y = int64_t(std::floor(o.y / w)) - half;
  m.depth_range = kDirectionalDepthRadii * b.radius;
  Mat4d p;
  for (double& v : p.m) v = 0;
  const double a = 1.0 / (double(half) * w);
  p.at(0, 0) = a;
  p.at(0, 3) = -double(m.origin_x + half) * w * a;
  p.at(1, 1) = a;
  p.at(1, 3) = -double(m.origin_y + half) * w * a;
  p.at(2, 2) = 1.0 / m.depth_range;  // clip.z = 1 − dist/(4r), dist = −z_view
  p.at(2, 3) = 1.0;
  p.at(3, 3) = 1.0;
  m.light_to_clip = p;
  return m;
}

// Cube faces in the order +X, −X, +Y, −Y, +Z, −Z (spec/shadow.md §3).
constexpr double kFaceAxis[kPointFaces][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
constexpr double kFaceUp[kPointFaces][3] = {{0, 1, 0}, {0, 1, 0}, {0, 0, 1}, {0, 0, 1}, {0, 1, 0}, {0, 1, 0}};

uint32_t point_face(const Vec3d& d) {
  const double ax = std::abs(d.x), ay = std::abs(d.y), az = std::abs(d.z);
  if (ax >= ay && ax >= az) return d.x >= 0 ? 0 : 1;
  if (ay >= az) return d.y >= 0 ? 2 : 3;
  return d.z >= 0 ? 4 : 5;
}

struct Ndc {
  double x = 0, y = 0;
  bool finite = false;
};
Ndc project_to_ndc(const ShadowMapView& m, const Vec3d& v) {
  const Mat4d& p = m.light_to_clip;
  double cx = p.at(0, 0) * v.x + p.at(0, 1) * v.y + p.at(0, 2) * v.z + p.at(0, 3);
  double cy = p.at(1, 0) * v.x + p.at(1, 1) * v.y + p.at(1, 2) * v.z + p.at(1, 3);
  double cw = p.at(3, 0) * v.x + p.at(3, 1) * v.y + p.at(3, 2) * v.z + p.at(3, 3);
  Ndc n{cx / cw, cy / cw, false};
  n.finite = std::isfinite(n.x) && std::isfinite(n.y);
  return n;
}

bool inside_map(const Ndc& n) { return n.finite && std::abs(n.x) <= 1 && std::abs(n.y) <= 1; }

// The largest j ≤ max_step with t0·2^j ≤ f, by exact doubling (0 when t0 > f).
int mip_step(double t0, double f, int max_step) {
  int j = 0;
  double t = t0;
  while (j < max_step && t * 2 <= f) {
    t *= 2;
    ++j;
  }
  return j;
}

ShadowTexel texel_of(uint32_t map, uint32_t mip, const Ndc& n, double dist, uint32_t size) {
  const double r = double(size >> mip);
  const double u = (n.x * 0.5 + 0.5) * r, v = (0.5 - n.y * 0.5) * r;
  const double last = r - 1;
  ShadowTexel t;
  t.map = map;
  t.mip = mip;
  t.x = uint32_t(std::clamp(std::floor(u), 0.0, last));
  t.y = uint32_t(std::clamp(std::floor(v), 0.0, last));
  t.dist = dist;
  return t;
}

// ---- drawing ----

// A page to draw this frame: its page-table entry, slot and place.
struct PageDraw {
  size_t entry = 0;
  uint32_t slot = 0, map = 0, mip = 0, x = 0, y = 0;  // x, y: local page
};

// Inclusive texel rectangle of a light-view sphere on (map, mip), one texel of margin; the
// whole mip when the sphere reaches a perspective map's near plane.
struct TexelRect {
  int64_t x0 = 0, y0 = 0, x1 = -1, y1 = -1;
};
TexelRect sphere_texel_rect(const ShadowMapView& m, uint32_t mip, uint32_t size, const Vec3d& c, double radius) {
  const int64_t r_m = int64_t(size >> mip);
  TexelRect all{0, 0, r_m - 1, r_m - 1};
  if (!m.ortho && -c.z - radius <= m.z_near) return all;
  double lo_x = std::numeric_limits<double>::infinity(), hi_x = -lo_x, lo_y = lo_x, hi_y = -lo_x;
  for (int k = 0; k < 8; ++k) {
    Vec3d corner{c.x + ((k & 1) ? radius : -radius), c.y + ((k & 2) ? radius : -radius),
                 c.z + ((k & 4) ? radius : -radius)};
    Ndc n = project_to_ndc(m, corner);
    if (!n.finite) return all;
    lo_x = std::min(lo_x, n.x);
    hi_x = std::max(hi_x, n.x);
    lo_y = std::min(lo_y, n.y);
    hi_y = std::max(hi_y, n.y);
  }
  const double r = double(r_m);
  auto clamp_texel = [&](double t) { return int64_t(std::clamp(std::floor(t), -2.0, r + 1)); };
  TexelRect out;
  out.x0 = std::max<int64_t>(0, clamp_texel((lo_x * 0.5 + 0.5) * r) - 1);
  out.x1 = std::min<int64_t>(r_m - 1, clamp_texel((hi_x * 0.5 + 0.5) * r) + 1);
  out.y0 = std::max<int64_t>(0, clamp_texel((0.5 - hi_y * 0.5) * r) - 1);
  out.y1 = std::min<int64_t>(r_m - 1, clamp_texel((0.5 - lo_y * 0.5) * r) + 1);
  return out;
}

Mat4d object_to_light(const ShadowMapView& m, const CullInstance& inst) { return m.world_to_light * inst.object_to_world; }

// The LOD test of one view (map, mip) with τ_s (spec/shadow.md §5): spot/point maps project from
// the light; orthographic levels divide by the texel size (distance-independent).
struct ShadowLod {
  bool ortho = false;
  LodView view;
  double texel = 0;  // ortho: texel size of the mip
  float tau_s = 0;
};
ShadowLod shadow_lod(const ShadowFrame& frame, const ShadowMapView& m, uint32_t mip) {
  const double r_m = double(virtual_size(frame) >> mip);
  ShadowLod lod;
  lod.ortho = m.ortho;
  lod.view.eye = {0, 0, 0};
  lod.view.pixels_per_unit_at_1 = float(0.5 * r_m / m.tan_half);
  lod.view.z_near = float(m.z_near);
  lod.texel = m.side / r_m;
  lod.tau_s = kShadowLodBias * frame.options.threshold_px;
  return lod;
}
// A cluster's projected parent and lod errors in the view's texels.
struct ShadowLodPx {
  float parent = 0, lod = 0;
};
ShadowLodPx shadow_lod_px(const ShadowLod& lod, const DagCluster& cl, const Mat4d& object_to_light, double scale) {
  if (lod.ortho)
    return {float(double(error_to_view(cl.parent_error, scale)) / lod.texel),
            float(double(error_to_view(cl.lod_error, scale)) / lod.texel)};
  return {projected_error(sphere_to_view(object_to_light, scale, cl.parent_bounds), error_to_view(cl.parent_error, scale),
                          lod.view),
          projected_error(sphere_to_view(object_to_light, scale, cl.lod_bounds), error_to_view(cl.lod_error, scale),
                          lod.view)};
}
bool shadow_lod_selects(const ShadowLod& lod, const DagCluster& cl, const Mat4d& object_to_light, double scale) {
  const ShadowLodPx px = shadow_lod_px(lod, cl, object_to_light, scale);
  return cut_selects(px.parent, px.lod, lod.tau_s);
}

// The whole cut of one view (the brute-force reference draws it all), in (instance, cluster) order.
std::vector<VisibleCluster> shadow_cut(const std::vector<ClusterDag>& meshes, const std::vector<CullInstance>& instances,
                                       const ShadowFrame& frame, const ShadowMapView& m, uint32_t mip) {
  const ShadowLod lod = shadow_lod(frame, m, mip);
  std::vector<VisibleCluster> cut;
  for (uint32_t i = 0; i < instances.size(); ++i) {
    const ClusterDag& dag = meshes[instances[i].mesh];
    const Mat4d o2l = object_to_light(m, instances[i]);
    const double scale = max_axis_scale(instances[i].object_to_world);
    for (uint32_t c = 0; c < dag.clusters.size(); ++c)
      if (shadow_lod_selects(lod, dag.clusters[c], o2l, scale)) cut.push_back({i, c});
  }
  return cut;
}

RasterOptions shadow_raster_options(const ShadowMapView& m, uint32_t r_m) {
  RasterOptions ro;
  ro.cull_backfaces = false;  // casters need not be closed (spec/shadow.md §5)
  ro.z_near = m.ortho ? kOrthoRasterNear : float(m.z_near);
  ro.virtual_width = r_m;
  ro.virtual_height = r_m;
  return ro;
}

void raster_cut_cluster(const std::vector<ClusterDag>& meshes, const std::vector<CullInstance>& instances,
                        const VisibleCluster& v, const Mat4& object_to_clip, const RasterOptions& ro, VisBuffer& target,
                        RasterStats* stats) {
  const ClusterDag& dag = meshes[instances[v.instance].mesh];
  const DagCluster& c = dag.clusters[v.cluster];
  rasterize_cluster(target, dag.positions.data() + 3 * size_t(c.vertex_offset), c.vertex_count,
                    dag.indices.data() + 3 * size_t(c.triangle_offset), c.triangle_count, object_to_clip, 0, ro, stats);
}

std::vector<Mat4> shadow_clip_matrices(const std::vector<CullInstance>& instances, const ShadowMapView& m) {
  std::vector<Mat4> out(instances.size());
  for (size_t i = 0; i < instances.size(); ++i) out[i] = to_float(m.light_to_clip * object_to_light(m, instances[i]));
  return out;
}

ShadowCache::SlotKey slot_key(const ShadowFrame& frame, uint32_t map, uint32_t mip, uint32_t x, uint32_t y) {
  const ShadowMapView& m = frame.maps[map];
  ShadowCache::SlotKey k;
  k.light = m.light;
  k.map = m.index;
  k.mip = mip;
  k.x = int64_t(x) + (m.ortho ? m.origin_x : 0);
  k.y = int64_t(y) + (m.ortho ? m.origin_y : 0);
  k.used = true;
  return k;
}

bool same_bounds(const ShadowSceneBounds& a, const ShadowSceneBounds& b) {
  return a.center.x == b.center.x && a.center.y == b.center.y && a.center.z == b.center.z && a.radius == b.radius;
}

bool same_transform(const Mat4d& a, const Mat4d& b) { return std::equal(a.m, a.m + 16, b.m); }

// World bounding sphere of an instance (its mesh's root bounds, as the culling places them).
void instance_world_sphere(const std::vector<ClusterDag>& meshes, const CullInstance& inst, const Mat4d& transform,
                           Vec3d* center, double* radius) {
  const ClusterDag& dag = meshes[inst.mesh];
  if (dag.bvh_nodes.empty() && dag.clusters.empty()) {  // an empty mesh casts nothing
    *center = transform_point(transform, {0, 0, 0});
    *radius = 0;
    return;
  }
  const Sphere& s = dag.bvh_nodes.empty() ? dag.clusters.front().bounds : dag.bvh_nodes[0].bounds;
  *center = transform_point(transform, {s.center.x, s.center.y, s.center.z});
  *radius = double(s.radius) * max_axis_scale(transform);
}

// The map of this frame holding a cached slot's page, or kNoShadowSlot.
uint32_t frame_map_of(const ShadowFrame& frame, const ShadowCache::SlotKey& k) {
  if (k.light >= frame.light_first_map.size() || frame.light_first_map[k.light] == kNoShadowSlot) return kNoShadowSlot;
  if (k.map >= frame.light_map_count[k.light]) return kNoShadowSlot;
  return frame.light_first_map[k.light] + k.map;
}

// spec/shadow.md §5 cache rule: drops every cached page whose light changed, and every page a
// moved caster (before or after its move) overlaps.
void invalidate_cache(const std::vector<ClusterDag>& meshes, const std::vector<CullInstance>& instances,
                      const std::vector<Light>& lights, const ShadowFrame& frame, ShadowCache* cache) {
  if (!cache->valid || cache->lights.size() != lights.size() || cache->transforms.size() != instances.size() ||
      !same_bounds(cache->bounds, frame.bounds)) {
    for (auto& s : cache->slots) s.used = false;
    return;
  }
  for (auto& s : cache->slots)
    if (s.used && (!same_light(cache->lights[s.light], lights[s.light]) || frame_map_of(frame, s) == kNoShadowSlot))
      s.used = false;
  const uint32_t size = virtual_size(frame);
  for (uint32_t i = 0; i < instances.size(); ++i) {
    if (same_transform(cache->transforms[i], instances[i].object_to_world)) continue;
    const Mat4d* before_after[2] = {&cache->transforms[i], &instances[i].object_to_world};
    for (const Mat4d* t : before_after) {
      Vec3d c;
      double r;
      instance_world_sphere(meshes, instances[i], *t, &c, &r);
      for (auto& s : cache->slots) {
        if (!s.used) continue;
        const ShadowMapView& m = frame.maps[frame_map_of(frame, s)];
        TexelRect rect = sphere_texel_rect(m, s.mip, size, transform_point(m.world_to_light, c), r);
        const int64_t px = s.x - (m.ortho ? m.origin_x : 0), py = s.y - (m.ortho ? m.origin_y : 0);
        const int64_t t = kShadowPageTexels;
        // A page outside the current window is compared in the window's texel coordinates too.
        if (rect.x0 <= px * t + t - 1 && rect.x1 >= px * t && rect.y0 <= py * t + t - 1 && rect.y1 >= py * t)
          s.used = false;
      }
    }
  }
}

// spec/shadow.md §5 allocation: reused pages keep their slot; the rest take the lowest
// never-used slot, then the lowest slot holding a page not needed this frame.
std::vector<PageDraw> allocate_shadow_pages(ShadowFrame* frame, ShadowCache* cache) {
  std::map<std::tuple<uint32_t, uint32_t, uint32_t, int64_t, int64_t>, uint32_t> cached;
  for (uint32_t s = 0; s < cache->slots.size(); ++s) {
    const auto& k = cache->slots[s];
    if (k.used) cached[{k.light, k.map, k.mip, k.x, k.y}] = s;
  }
  std::vector<uint8_t> kept(cache->slots.size(), 0);
  std::vector<PageDraw> missing;
  const uint32_t pages = frame->options.pages_per_side;
  for (uint32_t map = 0; map < frame->maps.size(); ++map)
    for (uint32_t mip = 0; mip < mip_count(pages); ++mip) {
      const uint32_t side = pages >> mip;
      const size_t base = frame->maps[map].table_offset + mip_table_offset(pages, mip);
      for (uint32_t y = 0; y < side; ++y)
        for (uint32_t x = 0; x < side; ++x) {
          const size_t e = base + size_t(y) * side + x;
          if (!frame->needed[e]) continue;
          ShadowCache::SlotKey k = slot_key(*frame, map, mip, x, y);
          auto it = cached.find({k.light, k.map, k.mip, k.x, k.y});
          if (it != cached.end()) {
            frame->page_table[e] = it->second;
            kept[it->second] = 1;
            ++frame->pages_cached;
          } else {
            missing.push_back({e, kNoShadowSlot, map, mip, x, y});
          }
        }
    }
  uint32_t next_new = uint32_t(cache->slots.size()), next_reuse = 0;
  for (PageDraw& d : missing) {
    if (next_new < frame->options.pool_pages) {
      d.slot = next_new++;
    } else {
      while (next_reuse < cache->slots.size() && kept[next_reuse]) ++next_reuse;
      if (next_reuse == cache->slots.size()) {
        ++frame->pages_dropped;
        continue;
      }
      d.slot = next_reuse;
      kept[next_reuse++] = 1;
    }
    frame->page_table[d.entry] = d.slot;
    if (d.slot >= cache->slots.size()) cache->slots.resize(d.slot + 1);
    cache->slots[d.slot] = slot_key(*frame, d.map, d.mip, d.x, d.y);
  }
  std::erase_if(missing, [](const PageDraw& d) { return d.slot == kNoShadowSlot; });
  return missing;
}

// Pages to draw whose pages a texel rectangle overlaps, reported to `emit(draw)`. An empty
// rectangle (a sphere wholly outside the mip: x1 < x0 or y1 < y0) overlaps none (without the
// test, one wholly left of or above the mip, x1 or y1 = −1, would visit column or row 0, since
// −1 / 128 is 0 in integer division).
template <typename Emit>
void for_pages_to_draw(const ShadowView& v, const TexelRect& rect, Emit&& emit) {
  if (rect.x1 < rect.x0 || rect.y1 < rect.y0) return;
  const int64_t t = kShadowPageTexels;
  for (int64_t py = rect.y0 / t; py <= rect.y1 / t; ++py)
    for (int64_t px = rect.x0 / t; px <= rect.x1 / t; ++px) {
      const int32_t d = v.draw_of_page[size_t(py) * v.side + size_t(px)];
      if (d >= 0 && !emit(uint32_t(d))) return;
    }
}

// The views of this frame's draws (draws are in page-table order: grouped by map, then mip).
std::vector<ShadowView> make_page_views(const ShadowFrame& frame, const std::vector<PageDraw>& draws) {
  std::vector<ShadowView> views;
  const uint32_t size = virtual_size(frame);
  for (uint32_t d = 0; d < draws.size(); ++d) {
    if (views.empty() || views.back().map != draws[d].map || views.back().mip != draws[d].mip) {
      ShadowView v;
      v.map = draws[d].map;
      v.mip = draws[d].mip;
      v.r_m = size >> v.mip;
      v.side = frame.options.pages_per_side >> v.mip;
      const ShadowLod lod = shadow_lod(frame, frame.maps[v.map], v.mip);
      v.ortho = lod.ortho;
      v.texel = lod.texel;
      v.pixels_per_unit_at_1 = lod.view.pixels_per_unit_at_1;
      v.lod_z_near = lod.view.z_near;
      v.tau_s = lod.tau_s;
      v.draw_of_page.assign(size_t(v.side) * v.side, -1);
      views.push_back(std::move(v));
    }
    views.back().draw_of_page[size_t(draws[d].y) * views.back().side + draws[d].x] = int32_t(d);
  }
  return views;
}

// The view's LOD test (the fields make_page_views copied from shadow_lod).
ShadowLod view_lod(const ShadowView& v) {
  ShadowLod lod;
  lod.ortho = v.ortho;
  lod.view.eye = {0, 0, 0};
  lod.view.pixels_per_unit_at_1 = v.pixels_per_unit_at_1;
  lod.view.z_near = v.lod_z_near;
  lod.texel = v.texel;
  lod.tau_s = v.tau_s;
  return lod;
}

// Instance culling next to the page test (seed: "Cull if doesn't overlap needed pages"): an
// instance whose root sphere overlaps no page to draw of a view is not traversed for it.
std::vector<uint8_t> instances_kept(const std::vector<ClusterDag>& meshes, const std::vector<CullInstance>& instances,
                                    const ShadowFrame& frame, const ShadowView& v) {
  const ShadowMapView& m = frame.maps[v.map];
  std::vector<uint8_t> kept(instances.size(), 0);
  for (uint32_t i = 0; i < instances.size(); ++i) {
    Vec3d c;
    double r;
    shadow_instance_sphere(meshes, instances[i], &c, &r);
    TexelRect rect = sphere_texel_rect(m, v.mip, virtual_size(frame), transform_point(m.world_to_light, c), r);
    for_pages_to_draw(v, rect, [&](uint32_t) { return !(kept[i] = 1); });
  }
  return kept;
}

// The multi-view cull (seed: "Multi-view rendering"): one traversal of every instance's clusters
// tests each cluster against every view at once (LOD from that view's projection, then its
// texel rectangle against the view's pages to draw) and emits one (page, cluster) element per
// overlapped page (seed: "emit cluster per overlapped page"). Parallel over instances; the
// per-page lists come out in (instance, cluster) order for any thread count.
// Streaming (`usable` non-null, spec/shadow.md §9): the drawn cut is the resident rule of
// spec/stream.md §Cut with τ_s; a page that an ideal-cut cluster not drawn overlaps is
// provisional; each ideal-cut cluster overlapping a page to draw requests its group at the
// lower priority of secondary_view_priority.
void cull_page_views(const std::vector<ClusterDag>& meshes, const std::vector<CullInstance>& instances,
                     const ShadowFrame& frame, const std::vector<ShadowView>& views, size_t draw_count,
                     const std::vector<std::vector<uint8_t>>* usable, ThreadPool& pool, ShadowDrawList* out) {
  struct Element {
    uint32_t draw, cluster;
  };
  struct InstanceOut {
    std::vector<Element> elements;
    std::vector<uint32_t> provisional;  // draws
    std::vector<GroupRequest> requests;
  };
  std::vector<InstanceOut> per_instance(instances.size());
  std::vector<std::vector<uint8_t>> kept(views.size());
  std::vector<ShadowLod> lods(views.size());
  pool.parallel_for(views.size(), [&](size_t k) {
    kept[k] = instances_kept(meshes, instances, frame, views[k]);
    lods[k] = view_lod(views[k]);
  });
  const uint32_t size = virtual_size(frame);
  const float tau = frame.options.threshold_px;
  pool.parallel_for(instances.size(), [&](size_t i) {
    const CullInstance& inst = instances[i];
    const ClusterDag& dag = meshes[inst.mesh];
    const std::vector<uint8_t>* resident = usable && !(*usable)[inst.mesh].empty() ? &(*usable)[inst.mesh] : nullptr;
    const double scale = max_axis_scale(inst.object_to_world);
    InstanceOut& io = per_instance[i];
    for (size_t k = 0; k < views.size(); ++k) {
      const ShadowView& v = views[k];
      if (!kept[k][i]) continue;
      const ShadowLod& lod = lods[k];
      const ShadowMapView& m = frame.maps[v.map];
      const Mat4d o2l = object_to_light(m, inst);
      for (uint32_t c = 0; c < dag.clusters.size(); ++c) {
        const DagCluster& cl = dag.clusters[c];
        const ShadowLodPx px = shadow_lod_px(lod, cl, o2l, scale);
        const bool ideal = cut_selects(px.parent, px.lod, lod.tau_s);
        const bool drawn = resident ? resident_lod_test(cl, *resident, px.parent, px.lod, lod.tau_s).drawn : ideal;
        if (!ideal && !drawn) continue;
        Sphere b = inflate_for_subtree_test(sphere_to_view(o2l, scale, cl.bounds));
        TexelRect rect = sphere_texel_rect(m, v.mip, size, {b.center.x, b.center.y, b.center.z}, b.radius);
        bool overlaps = false;
        for_pages_to_draw(v, rect, [&](uint32_t d) {
          overlaps = true;
          if (drawn) io.elements.push_back({d, c});
          else io.provisional.push_back(d);
          return true;
        });
        if (usable && ideal && overlaps) io.requests.push_back({inst.mesh, cl.group, secondary_view_priority(px.parent, tau)});
      }
    }
  });
  out->clusters.assign(draw_count, {});
  out->provisional.assign(draw_count, 0);
  for (uint32_t i = 0; i < instances.size(); ++i) {
    for (const Element& e : per_instance[i].elements) out->clusters[e.draw].push_back({i, e.cluster});
    for (uint32_t d : per_instance[i].provisional) out->provisional[d] = 1;
    out->requests.insert(out->requests.end(), per_instance[i].requests.begin(), per_instance[i].requests.end());
  }
}

// The raster of every page in one parallel pass: each page's clusters into a 128² target
// scissored to the page in its mip's coordinates (spec/shadow.md §5); depths into its slot.
void raster_page_views(const std::vector<ClusterDag>& meshes, const std::vector<CullInstance>& instances,
                       const ShadowDrawList& list, ThreadPool& pool, std::vector<float>* texels) {
  pool.parallel_for(list.pages.size(), [&](size_t d) {
    const ShadowPageDraw& page_draw = list.pages[d];
    VisBuffer page;
    page.resize(kShadowPageTexels, kShadowPageTexels);
    for (const VisibleCluster& c : list.clusters[d])
      raster_cut_cluster(meshes, instances, c, list.object_to_clip[page_draw.view][c.instance], page_draw.raster, page,
                         nullptr);
    float* out = texels->data() + size_t(page_draw.slot) * kPageTexelCount;
    for (uint32_t i = 0; i < kPageTexelCount; ++i) out[i] = page.keys[i] ? vis_key_depth(page.keys[i]) : 0.0f;
  });
}

}  // namespace

// ---- frame setup ----

ShadowSceneBounds shadow_scene_bounds(const std::vector<ClusterDag>& meshes, const std::vector<CullInstance>& instances) {
  Vec3d lo{std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity(),
           std::numeric_limits<double>::infinity()};
  Vec3d hi{-lo.x, -lo.y, -lo.z};
  std::vector<Vec3d> corners;
  for (const CullInstance& inst : instances) {
    const Aabb& b = meshes[inst.mesh].bounds;
    if (!(b.min.x <= b.max.x)) continue;  // empty mesh
    for (int k = 0; k < 8; ++k) {
      Vec3d p = transform_point(inst.object_to_world, {(k & 1) ? b.max.x : b.min.x, (k & 2) ? b.max.y : b.min.y,
                                                       (k & 4) ? b.max.z : b.min.z});
      corners.push_back(p);
      lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
      hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
    }
  }
  ShadowSceneBounds out;
  if (corners.empty()) return out;
  out.center = {(lo.x + hi.x) * 0.5, (lo.y + hi.y) * 0.5, (lo.z + hi.z) * 0.5};
  double r = 0;
  for (const Vec3d& p : corners) r = std::max(r, std::sqrt(dot(sub(p, out.center), sub(p, out.center))));
  out.radius = r > 0 ? r : 1;
  return out;
}

ShadowFrame make_shadow_frame(const std::vector<Light>& lights, const ShadowSceneBounds& bounds,
                              const Vec3d& camera_position, const ShadowOptions& options) {
  ShadowFrame frame;
  frame.options = options;
  frame.bounds = bounds;
  const double z_s = kShadowNearFraction * bounds.radius;
  const uint32_t pages = options.pages_per_side;
  const uint32_t table_size = mip_table_offset(pages, mip_count(pages));
  for (uint32_t i = 0; i < lights.size(); ++i) {
    const Light& l = lights[i];
    frame.light_first_map.push_back(l.shadows ? uint32_t(frame.maps.size()) : kNoShadowSlot);
    const size_t before = frame.maps.size();
    if (!l.shadows) {
      frame.light_map_count.push_back(0);
      continue;
    }
    ++frame.lights;
    switch (l.type) {
      case LightType::kSpot:
        frame.maps.push_back(perspective_map(l, 0, l.direction, default_up(l.direction), l.cone_radians, z_s));
        break;
      case LightType::kPoint:
        for (uint32_t f = 0; f < kPointFaces; ++f)
          frame.maps.push_back(perspective_map(l, f, {kFaceAxis[f][0], kFaceAxis[f][1], kFaceAxis[f][2]},
                                               {kFaceUp[f][0], kFaceUp[f][1], kFaceUp[f][2]}, std::numbers::pi / 2, z_s));
        break;
      case LightType::kDirectional:
        for (uint32_t k = 0; k < kDirectionalLevels; ++k)
          frame.maps.push_back(directional_level(l, k, bounds, camera_position, pages));
        break;
    }
    frame.light_map_count.push_back(uint32_t(frame.maps.size() - before));
  }
  for (uint32_t m = 0; m < frame.maps.size(); ++m) {
    frame.maps[m].light = 0;
    frame.maps[m].table_offset = m * table_size;
  }
  for (uint32_t i = 0; i < lights.size(); ++i)
    for (uint32_t k = 0; k < frame.light_map_count[i]; ++k) frame.maps[frame.light_first_map[i] + k].light = i;
  frame.page_table.assign(size_t(table_size) * frame.maps.size(), kNoShadowSlot);
  frame.needed.assign(frame.page_table.size(), 0);
  return frame;
}

Mat4d rigid_inverse(const Mat4d& m) {
  Mat4d r;
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) r.at(a, b) = m.at(b, a);
  for (int a = 0; a < 3; ++a) r.at(a, 3) = -(r.at(a, 0) * m.at(0, 3) + r.at(a, 1) * m.at(1, 3) + r.at(a, 2) * m.at(2, 3));
  return r;
}

Vec3d shadow_sample_point(const ViewParams& view, const Mat4d& view_to_world, uint32_t x, uint32_t y, float depth,
                          double* footprint) {
  const double vd = view.z_near / double(depth);
  Vec3d p{((x + 0.5) / view.width * 2 - 1) * view.tan_half_x * vd, (1 - (y + 0.5) / view.height * 2) * view.tan_half_y * vd,
          -vd};
  *footprint = 2 * view.tan_half_y * vd / view.height;
  return transform_point(view_to_world, p);
}

// ---- texel selection (spec/shadow.md §4) ----

bool select_shadow_texel(const ShadowFrame& frame, uint32_t light, const Vec3d& p, double pixel_footprint,
                         ShadowTexel* out) {
  if (light >= frame.light_first_map.size() || frame.light_first_map[light] == kNoShadowSlot) return false;
  // The largest texel the pixel may take: its footprint scaled by the density 2^−b (exact).
  const double footprint = std::ldexp(pixel_footprint, -frame.options.texels_per_pixel_log2);
  const uint32_t first = frame.light_first_map[light];
  const ShadowMapView& m0 = frame.maps[first];
  const uint32_t size = virtual_size(frame);
  if (m0.type == LightType::kDirectional) {
    const Vec3d v = transform_point(m0.world_to_light, p);  // every level shares the light view
    const double dist = -v.z;
    const int mips = int(mip_count(frame.options.pages_per_side));
    const int j = mip_step(m0.side / size, footprint, int(kDirectionalLevels) - 1 + mips - 1);
    for (uint32_t k = uint32_t(std::min<int>(j, kDirectionalLevels - 1)); k < kDirectionalLevels; ++k) {
      Ndc n = project_to_ndc(frame.maps[first + k], v);
      if (!inside_map(n)) continue;
      const bool beyond_coarsest = k == kDirectionalLevels - 1 && j > int(kDirectionalLevels - 1);
      const uint32_t mip = beyond_coarsest ? uint32_t(std::min<int>(j - int(kDirectionalLevels - 1), mips - 1)) : 0;
      *out = texel_of(first + k, mip, n, dist, size);
      return true;
    }
    return false;
  }
  const uint32_t map = m0.type == LightType::kPoint ? first + point_face(sub(p, m0.eye)) : first;
  const ShadowMapView& m = frame.maps[map];
  const Vec3d v = transform_point(m.world_to_light, p);
  const double dist = -v.z;
  if (!(dist > m.z_near)) return false;
  Ndc n = project_to_ndc(m, v);
  if (!n.finite || (m.type == LightType::kSpot && !inside_map(n))) return false;
  const int j = mip_step(2 * m.tan_half * dist / size, footprint, int(mip_count(frame.options.pages_per_side)) - 1);
  *out = texel_of(map, uint32_t(j), n, dist, size);
  return true;
}

double shadow_texel_size(const ShadowFrame& frame, const ShadowTexel& t) {
  const ShadowMapView& m = frame.maps[t.map];
  const double r_m = double(virtual_size(frame) >> t.mip);
  return m.ortho ? m.side / r_m : 2 * m.tan_half * t.dist / r_m;
}

size_t shadow_page_entry(const ShadowFrame& frame, const ShadowTexel& t) {
  const uint32_t side = frame.options.pages_per_side >> t.mip;
  return frame.maps[t.map].table_offset + mip_table_offset(frame.options.pages_per_side, t.mip) +
         size_t(t.y / kShadowPageTexels) * side + t.x / kShadowPageTexels;
}

float shadow_stored_depth(const ShadowFrame& frame, const ShadowTexel& t) {
  const uint32_t slot = frame.page_table[shadow_page_entry(frame, t)];
  if (slot == kNoShadowSlot) return 0.0f;
  const std::vector<float>& texels = frame.pool_texels ? *frame.pool_texels : frame.own_texels;
  return texels[size_t(slot) * kPageTexelCount + size_t(t.y % kShadowPageTexels) * kShadowPageTexels +
                              t.x % kShadowPageTexels];
}

// ---- steps ----

void mark_shadow_pages(const VisBuffer& vis, const ViewParams& view, const std::vector<Light>& lights, ThreadPool& pool,
                       ShadowFrame* frame) {
  const Mat4d view_to_world = rigid_inverse(view.world_to_view);
  pool.parallel_for(vis.height, [&](size_t y) {
    for (uint32_t x = 0; x < vis.width; ++x) {
      const uint64_t key = vis.keys[y * vis.width + x];
      if (!key) continue;
      double f;
      const Vec3d p = shadow_sample_point(view, view_to_world, x, uint32_t(y), vis_key_depth(key), &f);
      for (uint32_t l = 0; l < lights.size(); ++l) {
        ShadowTexel t;
        if (!select_shadow_texel(*frame, l, p, f, &t)) continue;
        std::atomic_ref<uint8_t>(frame->needed[shadow_page_entry(*frame, t)]).store(1, std::memory_order_relaxed);
      }
    }
  });
  for (uint8_t n : frame->needed) frame->pages_marked += n;
}

ShadowDrawPlan plan_shadow_draw(const std::vector<ClusterDag>& meshes, const std::vector<CullInstance>& instances,
                               const std::vector<Light>& lights, ShadowFrame* frame, ShadowCache* cache) {
  invalidate_cache(meshes, instances, lights, *frame, cache);
  const std::vector<PageDraw> draws = allocate_shadow_pages(frame, cache);
  const size_t needed_texels = cache->slots.size() * size_t(kPageTexelCount);
  if (cache->texels.size() < needed_texels) cache->texels.resize(needed_texels, 0.0f);
  frame->pages_drawn = draws.size();
  ShadowDrawPlan plan;
  plan.views = make_page_views(*frame, draws);
  plan.pages.resize(draws.size());
  for (uint32_t k = 0, d = 0; k < plan.views.size(); ++k)
    for (; d < draws.size() && draws[d].map == plan.views[k].map && draws[d].mip == plan.views[k].mip; ++d) {
      ShadowPageDraw& p = plan.pages[d];
      p = {draws[d].map, draws[d].mip, draws[d].x, draws[d].y, draws[d].slot, k, {}};
      p.raster = shadow_raster_options(frame->maps[p.map], plan.views[k].r_m);
      p.raster.window_x = p.x * kShadowPageTexels;
      p.raster.window_y = p.y * kShadowPageTexels;
    }
  return plan;
}

void cull_shadow_views(const std::vector<ClusterDag>& meshes, const std::vector<CullInstance>& instances,
                       const ShadowFrame& frame, const ShadowDrawPlan& plan,
                       const std::vector<std::vector<uint8_t>>* usable, ThreadPool& pool, ShadowDrawList* out) {
  cull_page_views(meshes, instances, frame, plan.views, plan.pages.size(), usable, pool, out);
}

void finish_shadow_cull(const std::vector<CullInstance>& instances, ShadowDrawPlan plan, ShadowFrame* frame,
                        ShadowCache* cache, ShadowDrawList* list) {
  for (const auto& clusters : list->clusters) frame->clusters_drawn += clusters.size();
  // A provisional page (drawn coarser than its ideal cut while streaming) serves this frame
  // only: its slot is not kept for the next frame's cache (it is drawn into all the same).
  for (size_t d = 0; d < plan.pages.size(); ++d)
    if (list->provisional[d]) cache->slots[plan.pages[d].slot].used = false;
  list->object_to_clip.clear();
  list->object_to_clip.reserve(plan.views.size());
  for (const ShadowView& v : plan.views) list->object_to_clip.push_back(shadow_clip_matrices(instances, frame->maps[v.map]));
  list->pages = std::move(plan.pages);
}

ShadowDrawList begin_shadow_draw(const std::vector<ClusterDag>& meshes, const std::vector<CullInstance>& instances,
                                 const std::vector<Light>& lights, ThreadPool& pool, ShadowFrame* frame,
                                 ShadowCache* cache, const std::vector<std::vector<uint8_t>>* usable) {
  ShadowDrawPlan plan = plan_shadow_draw(meshes, instances, lights, frame, cache);
  ShadowDrawList list;
  cull_shadow_views(meshes, instances, *frame, plan, usable, pool, &list);
  finish_shadow_cull(instances, std::move(plan), frame, cache, &list);
  return list;
}

void shadow_instance_sphere(const std::vector<ClusterDag>& meshes, const CullInstance& inst, Vec3d* center,
                            double* radius) {
  instance_world_sphere(meshes, inst, inst.object_to_world, center, radius);
}

Mat4d shadow_object_to_light(const ShadowFrame& frame, uint32_t map, const CullInstance& inst) {
  return object_to_light(frame.maps[map], inst);
}

std::vector<Mat4> shadow_object_to_clip(const ShadowFrame& frame, uint32_t map, const std::vector<CullInstance>& instances) {
  return shadow_clip_matrices(instances, frame.maps[map]);
}

std::vector<VisibleCluster> shadow_draw_clusters(const ShadowDrawList& list) {
  std::vector<VisibleCluster> out;
  for (const auto& clusters : list.clusters) out.insert(out.end(), clusters.begin(), clusters.end());
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

void raster_shadow_pages_cpu(const std::vector<ClusterDag>& raster_meshes, const std::vector<CullInstance>& instances,
                             const ShadowDrawList& list, ThreadPool& pool, ShadowCache* cache) {
  raster_page_views(raster_meshes, instances, list, pool, &cache->texels);
}

void end_shadow_draw(const std::vector<CullInstance>& instances, const std::vector<Light>& lights, ShadowFrame* frame,
                     ShadowCache* cache, bool kept) {
  cache->valid = true;
  cache->lights = lights;
  cache->bounds = frame->bounds;
  cache->transforms.resize(instances.size());
  for (size_t i = 0; i < instances.size(); ++i) cache->transforms[i] = instances[i].object_to_world;
  if (kept) {
    frame->pool_texels = &cache->texels;
  } else {
    frame->own_texels = std::move(cache->texels);
    frame->pool_texels = nullptr;  // own_texels (a pointer would not survive moving the frame)
  }
}

void draw_shadow_pages(const std::vector<ClusterDag>& meshes, const std::vector<CullInstance>& instances,
                       const std::vector<Light>& lights, ThreadPool& pool, ShadowFrame* frame, ShadowCache* cache) {
  ShadowCache local;
  ShadowCache* c = cache ? cache : &local;
  auto list = std::make_shared<const ShadowDrawList>(begin_shadow_draw(meshes, instances, lights, pool, frame, c));
  raster_shadow_pages_cpu(meshes, instances, *list, pool, c);
  end_shadow_draw(instances, lights, frame, c, cache != nullptr);
  frame->drawn = std::move(list);
}

ShadowScreen make_shadow_screen(const VisBuffer& vis, const ViewParams& view) {
  ShadowScreen s;
  s.vis = &vis;
  s.view = &view;
  const Mat4d view_to_world = rigid_inverse(view.world_to_view);
  s.camera = {view_to_world.at(0, 3), view_to_world.at(1, 3), view_to_world.at(2, 3)};
  return s;
}

namespace {

// tan of the angle between a unit normal and a unit direction with cosine c, clamped to
// kMaxShadowSlope (and kMaxShadowSlope when c ≤ 0: the surface faces away).
double clamped_slope(double c) {
  if (!(c > 0)) return kMaxShadowSlope;
  return std::min(std::sqrt(std::max(0.0, 1 - c * c)) / c, kMaxShadowSlope);
}

// Receiver depth at light-view distance dist − b on map m (spec/shadow.md §6).
float receiver_depth(const ShadowMapView& m, double dist, double b) {
  const double d = dist - b;
  return m.ortho ? float(1 - d / m.depth_range) : float(m.z_near / std::max(d, m.z_near));
}

// The seeds' short screen-space trace (spec/shadow.md §6): walks from the receiver towards the
// light over the LOD-mismatch zone through the primary depth buffer; true when a visible surface
// lies in front of the ray (beyond the own-surface tolerance ε, within the thickness h).
bool screen_trace_hits(const ShadowReceiver& r, const ShadowScreen& screen, double length, double zone,
                       uint32_t* steps_read) {
  const ViewParams& view = *screen.view;
  const VisBuffer& vis = *screen.vis;
  const Vec3d to_eye = sub(screen.camera, r.p);
  const double eye_len = std::sqrt(dot(to_eye, to_eye));
  const double view_slope = clamped_slope(dot(r.normal, to_eye) / eye_len);
  const double f = r.footprint;
  // h: the map's occluder lies within D of P (one texel ≤ f laterally), so within 2D + f of any
  // trace point; a surface further in front hides the ray from the eye but is not that caster.
  const double thickness = 2 * zone + f;
  const double step = std::max(f, length / kShadowTraceMaxSteps);
  const uint32_t steps = uint32_t(std::min<double>(kShadowTraceMaxSteps, std::ceil(length / step)));
  for (uint32_t k = 1; k <= steps; ++k) {
    const double t = std::min(k * step, length);
    const Vec3d q_world{r.p.x + t * r.to_light.x, r.p.y + t * r.to_light.y, r.p.z + t * r.to_light.z};
    const Vec3d q = transform_point(view.world_to_view, q_world);
    const double vd_q = -q.z;
    if (!(vd_q > view.z_near)) return false;  // the ray left the view through the near plane
    const double sx = ((q.x / vd_q) / view.tan_half_x * 0.5 + 0.5) * view.width;
    const double sy = (0.5 - (q.y / vd_q) / view.tan_half_y * 0.5) * view.height;
    // A segment's projection is a segment: once off the (convex) screen it stays off.
    if (!(sx >= 0 && sx < view.width && sy >= 0 && sy < view.height)) return false;
    const uint32_t px = uint32_t(std::floor(sx)), py = uint32_t(std::floor(sy));
    if (px == r.x && py == r.y) continue;  // the receiver's own pixel shows the receiver
    ++*steps_read;
    const uint64_t key = vis.keys[size_t(py) * vis.width + px];
    if (!key) continue;
    // ε: one pixel (at the trace point's depth) of lateral offset at the receiver's slope to the
    // eye: the receiver's own surface, above which the ray runs, sampled at a pixel centre up to
    // √2/2 pixel from the trace point's projection, is at most that much nearer the eye.
    const double eps = 2 * view.tan_half_y * vd_q / view.height * (1 + view_slope);
    const double delta = vd_q - view.z_near / double(vis_key_depth(key));
    if (delta > eps && delta <= eps + thickness) return true;
  }
  return false;
}

}  // namespace

ShadowTestDetail shadow_test(const ShadowFrame& frame, uint32_t light, const ShadowReceiver& r,
                             const ShadowScreen& screen) {
  ShadowTestDetail out;
  if (!select_shadow_texel(frame, light, r.p, r.footprint, &out.texel)) return out;
  const ShadowMapView& m = frame.maps[out.texel.map];
  const double texel = shadow_texel_size(frame, out.texel);
  const double slope = clamped_slope(r.cos_nl);
  const double tau = frame.options.threshold_px, tau_s = double(kShadowLodBias) * tau;
  // b_t: one texel of lateral offset at the surface's slope (the sample point is not the texel
  // centre). M: the largest distance between the primary cut (τ pixels of f) and the shadow cut
  // (τ_s texels) along the light: each cut's deviation times 1 + s ≥ 1/c, the secant.
  const double sampling_bias = texel * (1 + slope);
  const double mismatch = (tau * r.footprint + tau_s * texel) * std::min(1 + slope, kMaxMismatchSecant);
  out.zone = sampling_bias + mismatch;
  out.stored = shadow_stored_depth(frame, out.texel);
  out.d_lit = receiver_depth(m, out.texel.dist, sampling_bias);
  out.d_far = receiver_depth(m, out.texel.dist, out.zone);
  if (!(out.stored > out.d_lit)) {
    out.decision = ShadowDecision::kLit;
  } else if (out.stored > out.d_far) {
    out.decision = ShadowDecision::kFarCaster;
  } else {
    double length = out.zone;
    if (!m.ortho) {  // a spot or point light: the trace ends at the light
      const Vec3d to_light = sub(frame.maps[out.texel.map].eye, r.p);
      length = std::min(length, std::sqrt(dot(to_light, to_light)));
    }
    out.decision = screen_trace_hits(r, screen, length, out.zone, &out.trace_steps) ? ShadowDecision::kTraceHit
                                                                                       : ShadowDecision::kTraceMiss;
  }
  return out;
}

float shadow_term(const ShadowFrame& frame, uint32_t light, const ShadowReceiver& r, const ShadowScreen& screen) {
  const ShadowDecision d = shadow_test(frame, light, r, screen).decision;
  return d == ShadowDecision::kFarCaster || d == ShadowDecision::kTraceHit ? 0.0f : 1.0f;
}

std::vector<float> draw_full_shadow_map(const std::vector<ClusterDag>& meshes, const std::vector<CullInstance>& instances,
                                        const ShadowFrame& frame, uint32_t map, uint32_t mip, ThreadPool& pool) {
  const ShadowMapView& m = frame.maps[map];
  const uint32_t r_m = virtual_size(frame) >> mip;
  VisBuffer full;
  full.resize(r_m, r_m);
  RasterOptions ro = shadow_raster_options(m, r_m);
  ro.virtual_width = ro.virtual_height = 0;  // the whole mip is the target
  const std::vector<Mat4> clip = shadow_clip_matrices(instances, m);
  const std::vector<VisibleCluster> cut = shadow_cut(meshes, instances, frame, m, mip);
  pool.parallel_for(cut.size(), [&](size_t i) {
    raster_cut_cluster(meshes, instances, cut[i], clip[cut[i].instance], ro, full, nullptr);
  });
  std::vector<float> out(full.keys.size());
  for (size_t i = 0; i < out.size(); ++i) out[i] = full.keys[i] ? vis_key_depth(full.keys[i]) : 0.0f;
  return out;
}

}  // namespace vgeo
