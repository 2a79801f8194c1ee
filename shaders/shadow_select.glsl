// Texel selection of the virtual shadow maps (virtual_shadow.cpp select_shadow_texel,
// shadow_sample_point, shadow_page_entry; spec/shadow.md §3–§4) in the CPU's binary64
// arithmetic, shared by shade.comp (the shadow test) and shadow_mark.comp (marking). The
// including shader declares `lit` (GpuLitFrame), `lights` (GpuShadeLight[]), `shadow_maps`
// (GpuShadowMap[]) and `params` (GpuShadeParams: the view's size and tan_half).
#extension GL_GOOGLE_include_directive : require

#include "shadow_map.glsl"

// The largest j ≤ max_step with t0·2^j ≤ f, by exact doubling (0 when t0 > f).
int mip_step(double t0, double f, int max_step) {
  int j = 0;
  precise double t = t0;
  while (j < max_step && t * 2.0 <= f) {
    t *= 2.0;
    ++j;
  }
  return j;
}

struct ShadowTexel {
  uint32_t map, mip, x, y;
  double dist;
};

ShadowTexel texel_of(uint32_t map, uint32_t mip, dvec2 n, double dist, uint32_t size) {
  const double r = double(size >> mip);
  precise double u = (n.x * 0.5 + 0.5) * r;
  precise double v = (0.5 - n.y * 0.5) * r;
  const double last = r - 1.0;
  return ShadowTexel(map, mip, uint32_t(clamp(floor(u), 0.0, last)), uint32_t(clamp(floor(v), 0.0, last)), dist);
}

// select_shadow_texel: false when the light needs nothing at p.
bool select_shadow_texel(uint32_t light, dvec3 p, double pixel_footprint, out ShadowTexel t) {
  t = ShadowTexel(0u, 0u, 0u, 0u, 0.0);
  // The largest texel the pixel may take: its footprint scaled by the density 2^-b (exact).
  const double footprint = ldexp(pixel_footprint, -lit.texels_per_pixel_log2);
  const GpuShadeLight l = lights[light];
  if (l.shadows == 0u) return false;
  const uint32_t first = l.first_map;
  const uint32_t size = lit.pages_per_side * kGpuShadowPageTexels;
  const int mips = int(lit.mips);
  if (l.type == kDirectional) {
    const dvec3 v = rows_times_point(shadow_maps[first].world_to_light, p);  // every level shares the light view
    const double dist = -v.z;
    const int levels = int(lit.directional_levels);
    precise double t0 = shadow_maps[first].side / double(size);
    const int j = mip_step(t0, footprint, levels - 1 + mips - 1);
    for (int k = min(j, levels - 1); k < levels; ++k) {
      bool finite;
      const dvec2 n = project_to_ndc(first + uint32_t(k), v, finite);
      if (!inside_map(n, finite)) continue;
      const bool beyond_coarsest = k == levels - 1 && j > levels - 1;
      const uint32_t mip = beyond_coarsest ? uint32_t(min(j - (levels - 1), mips - 1)) : 0u;
      t = texel_of(first + uint32_t(k), mip, n, dist, size);
      return true;
    }
    return false;
  }
  const GpuShadowMap m0 = shadow_maps[first];
  uint32_t map = first;
  if (l.type == kPoint) {
    precise dvec3 d = p - dvec3(m0.eye[0], m0.eye[1], m0.eye[2]);
    map = first + point_face(d);
  }
  const GpuShadowMap m = shadow_maps[map];
  const dvec3 v = rows_times_point(m.world_to_light, p);
  const double dist = -v.z;
  if (!(dist > m.z_near)) return false;
  bool finite;
  const dvec2 n = project_to_ndc(map, v, finite);
  if (!finite || (l.type == kSpot && !inside_map(n, finite))) return false;
  precise double t0 = 2.0 * m.tan_half * dist / double(size);
  const int j = mip_step(t0, footprint, mips - 1);
  t = texel_of(map, uint32_t(j), n, dist, size);
  return true;
}

// shadow_page_entry: the page-table entry of the page holding texel t.
uint32_t shadow_page_entry(ShadowTexel t) {
  const uint32_t pages = lit.pages_per_side;
  uint32_t entry = shadow_maps[t.map].table_offset;
  for (uint32_t k = 0u; k < t.mip; ++k) entry += (pages >> k) * (pages >> k);
  return entry + (t.y / kGpuShadowPageTexels) * (pages >> t.mip) + t.x / kGpuShadowPageTexels;
}

// shadow_sample_point: pixel (x, y)'s world point at reversed-Z depth `depth`, its footprint.
dvec3 shadow_sample_point(uint32_t x, uint32_t y, float depth, out double footprint) {
  precise double vd = lit.z_near / double(depth);
  precise double px = ((double(x) + 0.5) / double(params.width) * 2.0 - 1.0) * params.tan_half_x * vd;
  precise double py = (1.0 - (double(y) + 0.5) / double(params.height) * 2.0) * params.tan_half_y * vd;
  precise double f = 2.0 * params.tan_half_y * vd / double(params.height);
  footprint = f;
  return rows_times_point(lit.view_to_world, dvec3(px, py, -vd));
}
