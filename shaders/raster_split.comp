#version 460
// The per-cluster SW/HW split (spec/raster.md §13): one invocation per visible cluster of the
// range decides its path, writes it into the path buffer (shaders/raster.comp skips the
// clusters it does not own) and appends a draw command for hardware-rastered clusters, so
// the draw (vkCmdDrawIndirectCount) follows the cull output with no CPU round trip.
#extension GL_EXT_shader_explicit_arithmetic_types : require
#extension GL_GOOGLE_include_directive : require
#include "vgeo/gpu/shader_records.h"
#include "vgeo/gpu/hw_raster_records.h"
#include "vgeo/gpu/shader_bindings.h"

layout(local_size_x = 64) in;  // kGpuRasterSplitGroupSize

layout(std430, binding = kSplitBindMeshes) readonly buffer Meshes { GpuMesh meshes[]; };
layout(std430, binding = kSplitBindInstances) readonly buffer Instances { GpuInstance instances[]; };
layout(std430, binding = kSplitBindVisible) readonly buffer Visible { GpuVisibleCluster visible[]; };
layout(std430, binding = kSplitBindInfos) readonly buffer Infos { GpuClusterRasterInfo infos[]; };
layout(std430, binding = kSplitBindRasterInstances) readonly buffer RasterInstances { GpuRasterInstance raster_instances[]; };
layout(std430, binding = kSplitBindPaths) buffer Paths { uint32_t path_of_visible[]; };
layout(std430, binding = kSplitBindCommands) buffer Commands { GpuDrawCommand commands[]; };
layout(std430, binding = kSplitBindCounters) buffer SplitCounters { GpuRasterSplitCounters split; };
layout(push_constant) uniform Push { GpuRasterSplitParams params; };

const float kPi = 3.14159265358979;

// The auto rule (hw_raster.h choose_raster_path, spec/raster.md §13.2).
bool choose_hw(GpuInstance inst, GpuClusterRasterInfo info, float scale) {
  // View depth of the sphere centre: clip.w (= −z_view for perspective_reversed_z), in double
  // from the float matrix as the rasterizers transform vertices.
  precise double w = ((double(inst.object_to_clip[3]) * double(info.center[0]) +
                       double(inst.object_to_clip[7]) * double(info.center[1])) +
                      double(inst.object_to_clip[11]) * double(info.center[2])) + double(inst.object_to_clip[15]);
  precise double r = double(info.radius) * double(scale);
  precise double nearest = w - r;
  if (!(nearest >= double(params.z_near))) return true;  // crosses the near plane (or behind it): hardware clips
  precise double r_px = r * double(params.pixels_per_unit_at_1) / nearest;
  precise double area_px = double(kPi) * r_px * r_px / double(max(info.triangle_count, 1u));
  return area_px >= double(params.hw_min_triangle_area_px);
}

void main() {
  uint32_t i = (gl_WorkGroupID.y * params.groups_x + gl_WorkGroupID.x) * kGpuRasterSplitGroupSize + gl_LocalInvocationID.x;
  if (i >= params.visible_count) return;
  uint32_t v = params.first_visible + i;
  GpuVisibleCluster vc = visible[v];
  GpuInstance inst = instances[vc.instance];
  GpuClusterRasterInfo info = infos[meshes[inst.mesh].first_location + vc.cluster];
  bool hw = params.mode == kGpuRasterModeHw ||
            (params.mode == kGpuRasterModeAuto && choose_hw(inst, info, raster_instances[vc.instance].scale));
  path_of_visible[v] = hw ? kGpuRasterPathHw : kGpuRasterPathSw;
  if (hw) {
    uint32_t slot = atomicAdd(split.hw_draw_count, 1u);
    commands[slot] = GpuDrawCommand(3u * info.triangle_count, 1u, 0u, v);
    atomicAdd(split.hw_clusters, 1u);
    atomicAdd(split.hw_triangles, info.triangle_count);
  } else {
    atomicAdd(split.sw_clusters, 1u);
    atomicAdd(split.sw_triangles, info.triangle_count);
  }
}
