#version 460
// Deferred shading of the visibility buffer: the GLSL image of lib/vgeo/shade/shade.cpp,
// every view (lit, triangle, cluster, group, lod, error, overdraw). Same double arithmetic
// where the CPU uses double; sRGB by the formula the CPU tabulates (the rule allows 1/255).
// One invocation per pixel; output RGBA8 packed in a uint32 (A = 255). With scene lights, the
// sum over lights with each shadowing light's shadow term read from the virtual shadow maps
// (spec/shadow.md §2, §4, §6), in the CPU's double arithmetic operation for operation.
#extension GL_EXT_shader_explicit_arithmetic_types : require
#extension GL_GOOGLE_include_directive : require
#include "vgeo/core/vis_key.h"
#include "vgeo/gpu/shader_records.h"

layout(local_size_x = 64) in;

#include "geometry.glsl"
layout(std430, binding = kGeomBindVis) readonly buffer Vis { uint64_t vis[]; };
layout(std430, binding = kShadeBindInstances) readonly buffer ShadeInstances { GpuShadeInstance shade_instances[]; };
layout(std430, binding = kShadeBindClusters) readonly buffer ShadeClusters { GpuShadeCluster shade_clusters[]; };
layout(std430, binding = kShadeBindMaterials) readonly buffer Materials { GpuMaterial materials[]; };
layout(std430, binding = kShadeBindOverdraw) readonly buffer Overdraw { uint32_t overdraw[]; };
layout(std430, binding = kShadeBindImage) writeonly buffer Image { uint32_t image[]; };
layout(std430, binding = kShadeBindLitFrame) readonly buffer LitFrame { GpuLitFrame lit; };
layout(std430, binding = kShadeBindLights) readonly buffer Lights { GpuShadeLight lights[]; };
layout(std430, binding = kShadeBindShadowMaps) readonly buffer ShadowMaps { GpuShadowMap shadow_maps[]; };
layout(std430, binding = kShadeBindShadowTable) readonly buffer ShadowTable { uint32_t shadow_table[]; };
layout(std430, binding = kShadeBindShadowPool) readonly buffer ShadowPool { float shadow_pool[]; };
layout(push_constant) uniform Push { GpuShadeParams params; };

#define VGEO_PAGE_WORD(i) page_words[i]
#include "memory_page.glsl"

// ShadeView values (shade.h).
const uint32_t kLit = 0u, kTriangle = 1u, kCluster = 2u, kGroup = 3u, kLod = 4u, kError = 5u, kOverdraw = 6u;
const vec3 kBackground = vec3(0.02, 0.025, 0.035);

// core/hash.h fnv1a64 over the 16 bytes of two little-endian uint64 values.
uint64_t fnv1a64_pair(uint64_t a, uint64_t b) {
  uint64_t h = 14695981039346656037ul;
  const uint64_t prime = 1099511628211ul;
  for (uint32_t i = 0u; i < 8u; ++i) h = (h ^ ((a >> (8u * i)) & 0xFFul)) * prime;
  for (uint32_t i = 0u; i < 8u; ++i) h = (h ^ ((b >> (8u * i)) & 0xFFul)) * prime;
  return h;
}

float id_channel(uint64_t h, uint32_t shift) {
  precise float c = 0.15 + 0.85 * float(uint32_t((h >> shift) & 0xFFul)) / 255.0;
  return c;
}
vec3 id_colour(uint64_t a, uint64_t b) {
  uint64_t h = fnv1a64_pair(a, b);
  return vec3(id_channel(h, 8u), id_channel(h, 24u), id_channel(h, 40u));
}

vec3 heat(float t) {
  t = clamp(t, 0.0, 1.0);
  if (t < 1.0 / 3.0) return vec3(0.0, 3.0 * t, 1.0 - 3.0 * t);
  if (t < 2.0 / 3.0) return vec3(3.0 * (t - 1.0 / 3.0), 1.0, 0.0);
  return vec3(1.0, 1.0 - 3.0 * (t - 2.0 / 3.0), 0.0);
}

uint32_t to_srgb8(float linear) {
  float c = clamp(linear, 0.0, 1.0);
  if (!(c >= 0.0)) c = 0.0;
  double cd = double(c);
  double s = cd <= 0.0031308 ? 12.92 * cd : 1.055 * double(pow(c, 1.0 / 2.4)) - 0.055;
  return uint32_t(clamp(round(s * 255.0), 0.0, 255.0));
}

// format/container.cpp octahedral_decode.
vec3 octahedral_decode(uint32_t qx, uint32_t qy, uint32_t bits) {
  precise float scale = float((1u << bits) - 1u);
  precise float x = float(qx) / scale * 2.0 - 1.0;
  precise float y = float(qy) / scale * 2.0 - 1.0;
  precise float z = 1.0 - abs(x) - abs(y);
  if (z < 0.0) {
    precise float ox = (1.0 - abs(y)) * (x >= 0.0 ? 1.0 : -1.0);
    precise float oy = (1.0 - abs(x)) * (y >= 0.0 ? 1.0 : -1.0);
    x = ox;
    y = oy;
  }
  precise float len = sqrt(x * x + y * y + z * z);
  return vec3(x / len, y / len, z / len);
}

#include "shadow_select.glsl"

float shadow_stored_depth(ShadowTexel t) {
  const uint32_t slot = shadow_table[shadow_page_entry(t)];
  if (slot == kNoShadowSlot) return 0.0;
  return shadow_pool[slot * kGpuShadowPageTexels * kGpuShadowPageTexels +
                     (t.y % kGpuShadowPageTexels) * kGpuShadowPageTexels + t.x % kGpuShadowPageTexels];
}

// clamped_slope: tan of the angle of cosine c, at most max_slope (max_slope when c ≤ 0).
double clamped_slope(double c) {
  if (!(c > 0.0)) return lit.max_slope;
  precise double s = min(sqrt(max(0.0, 1.0 - c * c)) / c, lit.max_slope);
  return s;
}

// receiver_depth: the receiver's depth at light-view distance dist − b on map m.
float receiver_depth(uint32_t map, double dist, double b) {
  const GpuShadowMap m = shadow_maps[map];
  precise double d = dist - b;
  precise double ortho_depth = 1.0 - d / m.depth_range;
  precise double persp_depth = m.z_near / max(d, m.z_near);
  return m.ortho != 0u ? float(ortho_depth) : float(persp_depth);
}

// The pixel's inputs to the shadow test of one light (virtual_shadow.h ShadowReceiver).
struct ShadowReceiver {
  uint32_t x, y;
  dvec3 p;
  double footprint;
  dvec3 normal, to_light;
  double cos_nl;
};

// screen_trace_hits: the seeds' short screen-space trace through the primary depth buffer.
bool screen_trace_hits(ShadowReceiver r, double len, double zone) {
  const dvec3 camera = dvec3(lit.view_to_world[3], lit.view_to_world[7], lit.view_to_world[11]);
  precise dvec3 to_eye = camera - r.p;
  precise double eye_len = sqrt(to_eye.x * to_eye.x + to_eye.y * to_eye.y + to_eye.z * to_eye.z);
  precise double c_v = (r.normal.x * to_eye.x + r.normal.y * to_eye.y + r.normal.z * to_eye.z) / eye_len;
  const double view_slope = clamped_slope(c_v);
  const double f = r.footprint;
  precise double thickness = 2.0 * zone + f;
  const double max_steps = double(lit.trace_max_steps);
  precise double step = max(f, len / max_steps);
  const uint32_t steps = uint32_t(min(max_steps, ceil(len / step)));
  const double width = double(params.width), height = double(params.height);
  for (uint32_t k = 1u; k <= steps; ++k) {
    precise double t = min(double(k) * step, len);
    precise dvec3 q_world = dvec3(r.p.x + t * r.to_light.x, r.p.y + t * r.to_light.y, r.p.z + t * r.to_light.z);
    const dvec3 q = rows_times_point(lit.world_to_view, q_world);
    const double vd_q = -q.z;
    if (!(vd_q > lit.z_near)) return false;  // the ray left the view through the near plane
    precise double sx = ((q.x / vd_q) / params.tan_half_x * 0.5 + 0.5) * width;
    precise double sy = (0.5 - (q.y / vd_q) / params.tan_half_y * 0.5) * height;
    if (!(sx >= 0.0 && sx < width && sy >= 0.0 && sy < height)) return false;  // off the convex screen: stays off
    const uint32_t px = uint32_t(floor(sx)), py = uint32_t(floor(sy));
    if (px == r.x && py == r.y) continue;  // the receiver's own pixel shows the receiver
    const uint64_t key = vis[py * params.width + px];
    if (key == uint64_t(0)) continue;
    precise double eps = 2.0 * params.tan_half_y * vd_q / height * (1.0 + view_slope);
    precise double delta = vd_q - lit.z_near / double(uintBitsToFloat(vis_key_depth_bits(key)));
    if (delta > eps && delta <= eps + thickness) return true;
  }
  return false;
}

// shadow_test / shadow_term: 1 (lit) or 0 (shadowed); r.cos_nl > 0.
double shadow_term(uint32_t light, ShadowReceiver r) {
  ShadowTexel t;
  if (!select_shadow_texel(light, r.p, r.footprint, t)) return 1.0;
  const GpuShadowMap m = shadow_maps[t.map];
  const double r_m = double((lit.pages_per_side * kGpuShadowPageTexels) >> t.mip);
  precise double texel = m.ortho != 0u ? m.side / r_m : 2.0 * m.tan_half * t.dist / r_m;
  const double slope = clamped_slope(r.cos_nl);
  precise double sampling_bias = texel * (1.0 + slope);
  precise double mismatch = (lit.tau * r.footprint + lit.tau_s * texel) * min(1.0 + slope, lit.max_mismatch_secant);
  precise double zone = sampling_bias + mismatch;
  const float stored = shadow_stored_depth(t);
  const float d_lit = receiver_depth(t.map, t.dist, sampling_bias);
  const float d_far = receiver_depth(t.map, t.dist, zone);
  if (!(stored > d_lit)) return 1.0;  // lit
  if (stored > d_far) return 0.0;     // a far caster
  double len = zone;
  if (m.ortho == 0u) {  // a spot or point light: the trace ends at the light
    precise dvec3 to_light = dvec3(m.eye[0], m.eye[1], m.eye[2]) - r.p;
    precise double light_len = sqrt(to_light.x * to_light.x + to_light.y * to_light.y + to_light.z * to_light.z);
    len = min(len, light_len);
  }
  return screen_trace_hits(r, len, zone) ? 0.0 : 1.0;
}

// shade.cpp sum_lights: Σ color × intensity × cone × lambert × shadow per channel, unit normal n.
dvec3 sum_lights(uint32_t x, uint32_t y, dvec3 p, double footprint, dvec3 n) {
  dvec3 sum = dvec3(0.0);
  for (uint32_t i = 0u; i < lit.light_count; ++i) {
    const GpuShadeLight l = lights[i];
    dvec3 dir = dvec3(l.direction[0], l.direction[1], l.direction[2]);
    dvec3 lv;
    if (l.type == kDirectional) {
      lv = -dir;
    } else {
      precise dvec3 d = dvec3(l.position[0], l.position[1], l.position[2]) - p;
      precise double len = sqrt(d.x * d.x + d.y * d.y + d.z * d.z);
      precise dvec3 q = dvec3(d.x / len, d.y / len, d.z / len);  // len 0: NaN, rejected below
      lv = q;
    }
    precise double c = n.x * lv.x + n.y * lv.y + n.z * lv.z;
    if (!(c > 0.0)) continue;
    precise double spot_cos = -(lv.x * dir.x + lv.y * dir.y + lv.z * dir.z);
    if (l.type == kSpot && !(spot_cos >= l.cos_half_cone)) continue;
    const double shadow = l.shadows != 0u ? shadow_term(i, ShadowReceiver(x, y, p, footprint, n, lv, c)) : 1.0;
    for (int k = 0; k < 3; ++k) {
      precise double add = double(l.color[k]) * double(l.intensity) * c * shadow;
      sum[k] += add;
    }
  }
  return sum;
}

dvec3 vertex_position(MemoryCluster c, uint32_t v, int32_t step_log2) {
  return dvec3(double(dequantize_position(memory_vertex_channel(c, v, 0u), step_log2)),
               double(dequantize_position(memory_vertex_channel(c, v, 1u), step_log2)),
               double(dequantize_position(memory_vertex_channel(c, v, 2u), step_log2)));
}

vec3 shade_lit(uint32_t x, uint32_t y, GpuVisibleCluster v, uint32_t tri, float depth) {
  GpuInstance inst = instances[v.instance];
  GpuShadeInstance si = shade_instances[v.instance];
  GpuMesh mesh = meshes[inst.mesh];
  GpuClusterLocation loc = locations[mesh.first_location + v.cluster];
  MemoryCluster c = memory_cluster(loc.page_word, loc.cluster_in_page, mesh.channel_count);
  uvec3 idx = memory_triangle(c, tri);
  dvec3 p[3];
  dvec3 q[3];
  for (int k = 0; k < 3; ++k) {
    p[k] = vertex_position(c, idx[k], mesh.position_step_log2);
    precise double qx = si.object_to_view[0] * p[k].x + si.object_to_view[4] * p[k].y + si.object_to_view[8] * p[k].z + si.object_to_view[12];
    precise double qy = si.object_to_view[1] * p[k].x + si.object_to_view[5] * p[k].y + si.object_to_view[9] * p[k].z + si.object_to_view[13];
    precise double qz = si.object_to_view[2] * p[k].x + si.object_to_view[6] * p[k].y + si.object_to_view[10] * p[k].z + si.object_to_view[14];
    q[k] = dvec3(qx, qy, qz);
  }
  precise double dx = ((double(x) + 0.5) / double(params.width) * 2.0 - 1.0) * params.tan_half_x;
  precise double dy = (1.0 - (double(y) + 0.5) / double(params.height) * 2.0) * params.tan_half_y;
  const double dz = -1.0;
  precise dvec3 e1 = q[1] - q[0];
  precise dvec3 e2 = q[2] - q[0];
  precise dvec3 pv = dvec3(dy * e2.z - dz * e2.y, dz * e2.x - dx * e2.z, dx * e2.y - dy * e2.x);
  precise double det = e1.x * pv.x + e1.y * pv.y + e1.z * pv.z;
  double b1 = 1.0 / 3.0, b2 = 1.0 / 3.0;
  if (abs(det) > 0.0) {
    precise dvec3 tv = -q[0];
    precise dvec3 qv = dvec3(tv.y * e1.z - tv.z * e1.y, tv.z * e1.x - tv.x * e1.z, tv.x * e1.y - tv.y * e1.x);
    precise double nb1 = (tv.x * pv.x + tv.y * pv.y + tv.z * pv.z) / det;
    precise double nb2 = (dx * qv.x + dy * qv.y + dz * qv.z) / det;
    b1 = nb1;
    b2 = nb2;
    if (isinf(b1) || isnan(b1) || isinf(b2) || isnan(b2)) b1 = b2 = 1.0 / 3.0;
    b1 = clamp(b1, 0.0, 1.0);
    b2 = clamp(b2, 0.0, 1.0 - b1);
  }
  precise double b0 = 1.0 - b1 - b2;
  double bw[3] = double[3](b0, b1, b2);
  dvec3 n = dvec3(0.0);
  if (mesh.normal_bits != 0u) {
    for (int k = 0; k < 3; ++k) {
      vec3 nk = octahedral_decode(uint32_t(memory_vertex_channel(c, idx[k], 3u)),
                                  uint32_t(memory_vertex_channel(c, idx[k], 4u)), mesh.normal_bits);
      precise dvec3 add = bw[k] * dvec3(nk);
      n += add;
    }
  } else {
    precise dvec3 a1 = p[1] - p[0];
    precise dvec3 a2 = p[2] - p[0];
    precise dvec3 cr = dvec3(a1.y * a2.z - a1.z * a2.y, a1.z * a2.x - a1.x * a2.z, a1.x * a2.y - a1.y * a2.x);
    n = cr;
  }
  double wn[3];
  for (int r = 0; r < 3; ++r) {
    precise double w = si.normal_matrix[3 * r] * n.x + si.normal_matrix[3 * r + 1] * n.y + si.normal_matrix[3 * r + 2] * n.z;
    wn[r] = w;
  }
  precise double nl = sqrt(wn[0] * wn[0] + wn[1] * wn[1] + wn[2] * wn[2]);
  precise double lambert = nl > 0.0 ? max(0.0, (wn[0] * params.light[0] + wn[1] * params.light[1] + wn[2] * params.light[2]) / nl) : 0.0;
  uint32_t mat = memory_material(c, tri) + mesh.material_offset;  // uint32 wrap, as the CPU's sum
  vec4 base = vec4(0.8, 0.8, 0.8, 1.0);
  if (mat < params.material_count) {
    GpuMaterial m = materials[mat];
    base = vec4(m.base_color[0], m.base_color[1], m.base_color[2], m.base_color[3]);
  }
  if (lit.light_count != 0u) {
    double footprint;
    const dvec3 sp = shadow_sample_point(x, y, depth, footprint);
    dvec3 un = dvec3(0.0);
    if (nl > 0.0) {
      precise dvec3 q = dvec3(wn[0] / nl, wn[1] / nl, wn[2] / nl);
      un = q;
    }
    const dvec3 sum = sum_lights(x, y, sp, footprint, un);
    const double a = double(params.ambient), one_minus_a = double(1.0 - params.ambient);
    precise float kr = float(a + one_minus_a * sum.x);
    precise float kg = float(a + one_minus_a * sum.y);
    precise float kb = float(a + one_minus_a * sum.z);
    return vec3(base.r * kr, base.g * kg, base.b * kb);
  }
  precise float k = float(double(params.ambient) + double(1.0 - params.ambient) * lambert);
  return base.rgb * k;
}

void main() {
  uint32_t p = gl_GlobalInvocationID.x;
  if (p >= params.width * params.height) return;
  uint32_t x = p % params.width, y = p / params.width;
  uint64_t key = vis[p];
  vec3 col = kBackground;
  if (params.view == kOverdraw) {
    uint32_t n = overdraw[p];
    if (n > 0u) col = heat(float(n - 1u) / float(max(params.max_overdraw - 1u, 1u)));
  } else if (key != uint64_t(0)) {
    uint32_t vc = vis_key_cluster(key), tri = vis_key_triangle(key);
    GpuVisibleCluster v = visible[vc];
    GpuShadeCluster sc = shade_clusters[vc];
    if (params.view == kTriangle) col = id_colour(uint64_t(vc), uint64_t(tri));
    else if (params.view == kCluster) col = id_colour(uint64_t(v.instance), uint64_t(v.cluster));
    else if (params.view == kGroup) col = id_colour(uint64_t(v.instance), uint64_t(sc.group) | (uint64_t(1) << 40));
    else if (params.view == kLod) col = heat(sc.level_count > 1u ? float(sc.level) / float(sc.level_count - 1u) : 0.0);
    else if (params.view == kError) col = heat(sc.projected_error / max(params.threshold_px, 1e-6));
    else col = shade_lit(x, y, v, tri, uintBitsToFloat(vis_key_depth_bits(key)));
  }
  image[p] = to_srgb8(col.r) | (to_srgb8(col.g) << 8) | (to_srgb8(col.b) << 16) | (255u << 24);
}
