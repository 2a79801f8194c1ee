#version 460
// The shadow views' multi-view cull on the device (spec/shadow.md §5, §8; virtual_shadow.cpp
// cull_page_views, instances_kept, sphere_texel_rect, for_pages_to_draw), in the CPU's
// arithmetic (cull_math.glsl, shadow_map.glsl: binary64, `precise`, the same comparisons), so
// it emits exactly the reference's (page, cluster) elements, in another order (atomics). Three
// modes (GpuShadowCullPush::mode), one layout:
//   kShadowCullInstances: one invocation per pair (view, instance): the instance's world sphere
//     as a texel rectangle of the view's mip against its pages to draw (the seed's "cull if
//     doesn't overlap needed pages"); a kept pair appends one work item per 64 of its clusters.
//   kShadowCullArgs: the cluster pass's indirect dispatch from the work count.
//   kShadowCullClusters: one invocation per (pair, cluster): the view's LOD test (its own
//     projection, τ_s; streamed: the resident rule), the cluster's texel rectangle, one element
//     per overlapped page to draw (drawn clusters), provisional pages (ideal-cut clusters not
//     drawn) and the secondary-priority group requests (ideal-cut clusters overlapping a page).
// Based on: Karis et al., "Nanite: A Deep Dive" (SIGGRAPH 2021), §"Multi-view rendering",
// §"Culling and addressing to pages", §"Nanite shadow LOD".
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_shader_explicit_arithmetic_types : require
#include "vgeo/gpu/shader_bindings.h"
#include "vgeo/gpu/shader_records.h"
#include "cull_math.glsl"

layout(local_size_x = VGEO_SHADOW_CULL_GROUP_SIZE) in;

layout(std430, binding = kShadowCullBindMeshes) readonly buffer MeshBuf { GpuCullMesh meshes[]; };
layout(std430, binding = kShadowCullBindClusters) readonly buffer ClusterBuf { GpuCluster clusters[]; };
layout(std430, binding = kShadowCullBindStream) readonly buffer StreamBuf { uint32_t stream_words[]; };
layout(std430, binding = kShadowCullBindMaps) readonly buffer MapBuf { GpuShadowMap shadow_maps[]; };
layout(std430, binding = kShadowCullBindViews) readonly buffer ViewBuf { GpuShadowCullView views[]; };
layout(std430, binding = kShadowCullBindInstances) readonly buffer InstanceBuf { GpuShadowCullInstance instances[]; };
layout(std430, binding = kShadowCullBindViewInstances) readonly buffer PairBuf { GpuCullInstance pairs[]; };
layout(std430, binding = kShadowCullBindDrawOfPage) readonly buffer DrawOfPageBuf { int32_t draw_of_page[]; };
layout(std430, binding = kShadowCullBindWork) coherent buffer WorkBuf { GpuShadowCullHeader header; uint32_t work[]; };
layout(std430, binding = kShadowCullBindElements) writeonly buffer ElementBuf { GpuVisibleCluster elements[]; };
layout(std430, binding = kShadowCullBindElementPage) writeonly buffer ElementPageBuf { uint32_t element_page[]; };
layout(std430, binding = kShadowCullBindProvisional) writeonly buffer ProvisionalBuf { uint32_t provisional[]; };
layout(std430, binding = kShadowCullBindRequests) buffer RequestBuf { uint32_t requests[]; };
layout(push_constant) uniform Push { GpuShadowCullPush push; };

#include "shadow_map.glsl"

double infinity_d() { return uint64BitsToDouble(0x7FF0000000000000ul); }  // std::numeric_limits<double>::infinity()

// std::clamp(v, lo, hi) as written: (v < lo) ? lo : (hi < v) ? hi : v.
double clamp_d(double v, double lo, double hi) { return (v < lo) ? lo : ((hi < v) ? hi : v); }
// The page of a texel of a non-empty rectangle (texels ≥ 0 there).
int page_of(int t) { return t / int(kGpuShadowPageTexels); }
// for_pages_to_draw's empty rectangle: a sphere wholly outside the mip overlaps no page.
bool empty_rect(ivec4 r) { return r.z < r.x || r.w < r.y; }

// virtual_shadow.cpp sphere_texel_rect: the inclusive texel rectangle (x0, y0, x1, y1) of a
// light-view sphere on a mip of R_m texels, one texel of margin, clamped; the whole mip when the
// sphere reaches a perspective map's near plane or a corner does not project.
ivec4 sphere_texel_rect(uint32_t map, uint32_t r_m, dvec3 c, double radius) {
  const int last = int(r_m) - 1;
  const ivec4 all = ivec4(0, 0, last, last);
  if (shadow_maps[map].ortho == 0u) {
    precise double near_side = -c.z - radius;
    if (near_side <= shadow_maps[map].z_near) return all;
  }
  const double inf = infinity_d();
  double lo_x = inf, hi_x = -inf, lo_y = inf, hi_y = -inf;
  for (int k = 0; k < 8; ++k) {
    precise double x = c.x + (((k & 1) != 0) ? radius : -radius);
    precise double y = c.y + (((k & 2) != 0) ? radius : -radius);
    precise double z = c.z + (((k & 4) != 0) ? radius : -radius);
    bool finite;
    const dvec2 n = project_to_ndc(map, dvec3(x, y, z), finite);
    if (!finite) return all;
    lo_x = min_d(lo_x, n.x);
    hi_x = max_d(hi_x, n.x);
    lo_y = min_d(lo_y, n.y);
    hi_y = max_d(hi_y, n.y);
  }
  const double r = double(r_m);
  precise double u0 = (lo_x * 0.5 + 0.5) * r, u1 = (hi_x * 0.5 + 0.5) * r;
  precise double v0 = (0.5 - hi_y * 0.5) * r, v1 = (0.5 - lo_y * 0.5) * r;
  precise double r_plus = r + 1.0;
  const int x0 = int(clamp_d(floor(u0), -2.0, r_plus)) - 1, x1 = int(clamp_d(floor(u1), -2.0, r_plus)) + 1;
  const int y0 = int(clamp_d(floor(v0), -2.0, r_plus)) - 1, y1 = int(clamp_d(floor(v1), -2.0, r_plus)) + 1;
  return ivec4(max(0, x0), max(0, y0), min(last, x1), min(last, y1));
}

// secondary_view_priority (stream.h): float(τ · p/(p + 1)), 1·τ for p = +inf, 0 for p ≤ 0 or NaN.
float secondary_view_priority(float projected_px, float tau) {
  if (!(projected_px > 0.0)) return 0.0;
  const double p = double(projected_px);
  precise double q = isinf(p) ? 1.0lf : p / (p + 1.0lf);
  precise double priority = double(tau) * q;
  return float(priority);
}

void cull_instance(uint32_t pair) {
  const uint32_t v = pair / push.instance_count, i = pair % push.instance_count;
  const GpuShadowCullView view = views[v];
  const GpuShadowCullInstance inst = instances[i];
  const dvec3 c = rows_times_point(shadow_maps[view.map].world_to_light, dvec3(inst.center[0], inst.center[1], inst.center[2]));
  const ivec4 rect = sphere_texel_rect(view.map, view.r_m, c, inst.radius);
  if (empty_rect(rect)) return;
  bool kept = false;
  for (int py = page_of(rect.y); py <= page_of(rect.w) && !kept; ++py)
    for (int px = page_of(rect.x); px <= page_of(rect.z) && !kept; ++px)
      kept = draw_of_page[view.page_offset + uint32_t(py) * view.side + uint32_t(px)] >= 0;
  if (!kept) return;
  const uint32_t blocks = (meshes[pairs[pair].mesh].cluster_count + kGpuShadowCullGroupSize - 1u) / kGpuShadowCullGroupSize;
  if (blocks == 0u) return;
  const uint32_t first = atomicAdd(header.work_count, blocks);
  for (uint32_t b = 0u; b < blocks; ++b)
    if (first + b < push.work_capacity) {  // the host sizes it for every pair: never false
      work[2u * (first + b)] = pair;
      work[2u * (first + b) + 1u] = b;
    }
}

void emit(uint32_t pair, uint32_t cluster, uint32_t draw) {
  const uint32_t at = atomicAdd(header.element_count, 1u);
  if (at >= push.element_capacity) return;  // counted: the host grows the buffers and runs again
  elements[at] = GpuVisibleCluster(pair, cluster);
  element_page[at] = draw;
}

bool usable_group(GpuCullMesh mesh, uint32_t group) { return stream_words[mesh.stream_base + 1u + group] != 0u; }

void cull_cluster(uint32_t pair, uint32_t ci) {
  const GpuCullInstance iv = pairs[pair];
  const GpuCullMesh mesh = meshes[iv.mesh];
  if (ci >= mesh.cluster_count) return;
  const GpuShadowCullView view = views[pair / push.instance_count];
  const GpuCluster cl = clusters[mesh.first_cluster + ci];
  // shadow_lod_px: projected errors in the view's texels.
  float parent_px, lod_px;
  if (shadow_maps[view.map].ortho != 0u) {
    precise double parent = double(error_to_view(cl.parent_error, iv.scale)) / view.texel;
    precise double lod = double(error_to_view(cl.lod_error, iv.scale)) / view.texel;
    parent_px = float(parent);
    lod_px = float(lod);
  } else {
    const GpuCullView lv = GpuCullView(0.0lf, 0.0lf, 0.0lf, 0u, 0u, view.pixels_per_unit_at_1, view.lod_z_near, 0u, 0u);
    parent_px = projected_error(sphere_to_view(iv, sphere_of(cl.parent_bounds)), error_to_view(cl.parent_error, iv.scale), lv);
    lod_px = projected_error(sphere_to_view(iv, sphere_of(cl.lod_bounds)), error_to_view(cl.lod_error, iv.scale), lv);
  }
  const float tau_s = view.tau_s;
  const bool ideal = parent_px > tau_s && lod_px <= tau_s;  // lod.h cut_selects
  bool drawn = ideal;
  if (push.streamed != 0u && stream_words[mesh.stream_base] != 0u) {  // stream.h resident_lod_test
    const bool finer_unusable = cl.generating_group != kGpuNone && !usable_group(mesh, cl.generating_group);
    drawn = usable_group(mesh, cl.group) && parent_px > tau_s && (ideal || finer_unusable);
  }
  if (!ideal && !drawn) return;
  const Sphere b = culling_sphere(iv, cl.bounds);  // inflate_for_subtree_test(sphere_to_view(...))
  const ivec4 rect = sphere_texel_rect(view.map, view.r_m, dvec3(double(b.x), double(b.y), double(b.z)), double(b.radius));
  bool overlaps = false;
  if (empty_rect(rect)) return;
  for (int py = page_of(rect.y); py <= page_of(rect.w); ++py)
    for (int px = page_of(rect.x); px <= page_of(rect.z); ++px) {
      const int32_t d = draw_of_page[view.page_offset + uint32_t(py) * view.side + uint32_t(px)];
      if (d < 0) continue;
      overlaps = true;
      if (drawn) emit(pair, ci, uint32_t(d));
      else provisional[d] = 1u;
    }
  // The max priority per group, as the Streamer reduces a request list (bits + 1: 0 = none;
  // priorities are ≥ 0, whose bits order as the floats).
  if (push.streamed != 0u && ideal && overlaps)
    atomicMax(requests[mesh.first_group + cl.group], floatBitsToUint(secondary_view_priority(parent_px, push.tau)) + 1u);
}

void main() {
  if (push.mode == kShadowCullInstances) {
    if (gl_GlobalInvocationID.x < push.pair_count) cull_instance(gl_GlobalInvocationID.x);
  } else if (push.mode == kShadowCullArgs) {
    if (gl_GlobalInvocationID.x != 0u) return;
    const uint32_t n = header.work_count;
    const uint32_t x = min(n, kGpuMaxGroupsX);
    header.dispatch_x = x;
    header.dispatch_y = x == 0u ? 0u : (n + x - 1u) / x;
    header.dispatch_z = 1u;
  } else {
    const uint32_t item = gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x;
    if (item >= header.work_count) return;
    cull_cluster(work[2u * item], work[2u * item + 1u] * kGpuShadowCullGroupSize + gl_LocalInvocationIndex);
  }
}
