// A virtual shadow map's light view and projection in the CPU's binary64 arithmetic
// (virtual_shadow.cpp transform_point, point_face, project_to_ndc, inside_map; spec/shadow.md
// §3), shared by the texel selection (shadow_select.glsl: marking, the shadow test) and the
// multi-view cull's texel rectangles (shadow_cull.comp). The including shader declares
// `shadow_maps` (GpuShadowMap[]).
#ifndef VGEO_SHADERS_SHADOW_MAP_GLSL
#define VGEO_SHADERS_SHADOW_MAP_GLSL

const uint32_t kDirectional = 0u, kSpot = 1u, kPoint = 2u;  // LightType
const uint32_t kNoShadowSlot = 0xFFFFFFFFu;

// transform_point with rows 0..2 of a row-major matrix.
dvec3 rows_times_point(double m[12], dvec3 p) {
  precise double x = m[0] * p.x + m[1] * p.y + m[2] * p.z + m[3];
  precise double y = m[4] * p.x + m[5] * p.y + m[6] * p.z + m[7];
  precise double z = m[8] * p.x + m[9] * p.y + m[10] * p.z + m[11];
  return dvec3(x, y, z);
}

uint32_t point_face(dvec3 d) {
  const double ax = abs(d.x), ay = abs(d.y), az = abs(d.z);
  if (ax >= ay && ax >= az) return d.x >= 0.0 ? 0u : 1u;
  if (ay >= az) return d.y >= 0.0 ? 2u : 3u;
  return d.z >= 0.0 ? 4u : 5u;
}

// project_to_ndc: (ndc.x, ndc.y); `finite` both finite.
dvec2 project_to_ndc(uint32_t map, dvec3 v, out bool finite) {
  const GpuShadowMap m = shadow_maps[map];
  precise double cx = m.light_to_clip[0] * v.x + m.light_to_clip[1] * v.y + m.light_to_clip[2] * v.z + m.light_to_clip[3];
  precise double cy = m.light_to_clip[4] * v.x + m.light_to_clip[5] * v.y + m.light_to_clip[6] * v.z + m.light_to_clip[7];
  precise double cw = m.light_to_clip[12] * v.x + m.light_to_clip[13] * v.y + m.light_to_clip[14] * v.z + m.light_to_clip[15];
  precise double nx = cx / cw;
  precise double ny = cy / cw;
  finite = !isinf(nx) && !isnan(nx) && !isinf(ny) && !isnan(ny);
  return dvec2(nx, ny);
}

bool inside_map(dvec2 n, bool finite) { return finite && abs(n.x) <= 1.0 && abs(n.y) <= 1.0; }
#endif
