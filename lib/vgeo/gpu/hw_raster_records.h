#ifndef VGEO_GPU_HW_RASTER_RECORDS_H
#define VGEO_GPU_HW_RASTER_RECORDS_H
// Records of the hardware raster path and the per-cluster SW/HW split (hw_raster.h,
// spec/raster.md §13), written once in the common C++/GLSL subset (core/shared_glsl.h).
// 32-bit scalars only, so std430 and the C++ layout agree (checked below).
#include "vgeo/core/shared_glsl.h"

#ifdef __cplusplus
namespace vgeo {
#endif

// Per (mesh, cluster), indexed like GpuClusterLocation: what the split rule reads. The
// sphere is DagCluster::bounds of the decoded memory form (conservative: inflated for the
// quantization, spec/format.md §2.1), in object space.
struct GpuClusterRasterInfo {
  float center[3];
  float radius;
  uint32_t triangle_count;
  uint32_t reserved[3];
};

// Per instance: the factor that takes object-space lengths to view space (cull/view.h
// InstanceView::scale, the largest axis scale of the instance transform).
struct GpuRasterInstance {
  float scale;
};

// VkDrawIndirectCommand: one draw per hardware-rastered cluster. firstInstance carries the
// visible-cluster index (the vertex shader reads it as gl_InstanceIndex).
struct GpuDrawCommand {
  uint32_t vertex_count;    // 3 · triangle count
  uint32_t instance_count;  // 1
  uint32_t first_vertex;    // 0
  uint32_t first_instance;  // visible-cluster index
};

// Written by shaders/raster_split.comp (atomicAdd), read back for the statistics table.
struct GpuRasterSplitCounters {
  uint32_t hw_draw_count;   // drawIndirectCount's count; == hw_clusters
  uint32_t sw_clusters;
  uint32_t hw_clusters;
  uint32_t reserved;
  uint32_t sw_triangles;
  uint32_t hw_triangles;
  uint32_t reserved2[2];
};

// GpuRasterSplitParams::mode (GpuRasterMode in hw_raster.h).
VGEO_CONSTANT uint32_t kGpuRasterModeSw = 0u;
VGEO_CONSTANT uint32_t kGpuRasterModeHw = 1u;
VGEO_CONSTANT uint32_t kGpuRasterModeAuto = 2u;
// Values of the per-visible-cluster path word (shaders/raster.comp skips clusters that are not
// kGpuRasterPathSw when its params.select_path is set).
VGEO_CONSTANT uint32_t kGpuRasterPathSw = 0u;
VGEO_CONSTANT uint32_t kGpuRasterPathHw = 1u;
// Workgroup size of shaders/raster_split.comp (one invocation per visible cluster).
VGEO_CONSTANT uint32_t kGpuRasterSplitGroupSize = 64u;

// Push constants of shaders/raster_split.comp: classify visible[first_visible + i] for
// i < visible_count (i = y · groups_x · 64 + global x).
struct GpuRasterSplitParams {
  uint32_t first_visible;
  uint32_t visible_count;
  uint32_t groups_x;
  uint32_t mode;                    // kGpuRasterMode*
  float z_near;                     // view-space near plane
  float pixels_per_unit_at_1;       // ViewParams: pixels per view unit at distance 1
  float hw_min_triangle_area_px;    // the auto rule's threshold (hw_raster.h)
  uint32_t reserved;
};

#ifdef __cplusplus
static_assert(sizeof(GpuClusterRasterInfo) == 32);
static_assert(sizeof(GpuRasterInstance) == 4);
static_assert(sizeof(GpuDrawCommand) == 16);
static_assert(sizeof(GpuRasterSplitCounters) == 32 && offsetof(GpuRasterSplitCounters, sw_triangles) == 16);
static_assert(sizeof(GpuRasterSplitParams) == 32);
}  // namespace vgeo
#endif
#endif
