#ifndef VGEO_GPU_SHADER_BINDINGS_H
#define VGEO_GPU_SHADER_BINDINGS_H
// Every storage-buffer binding index of every shader, declared once and included by the host
// (descriptor writes: gpu_bindings(), context.h) and by the shaders (`layout(binding = ...)`),
// as vk_lod_clusters' shaderio headers do: a binding that moves moves on both sides, and a
// host list that leaves one out fails at record time instead of drawing a wrong image. Set 0
// only; each shader's bindings are 0..k<Shader>BindingCount-1 (the pipeline's layout).
// Common C++/GLSL subset: core/shared_glsl.h. Records the buffers hold: core/cull_shared.h,
// gpu/shader_records.h, gpu/hw_raster_records.h.
#include "vgeo/core/shared_glsl.h"

#ifdef __cplusplus
namespace vgeo {
#endif

// ---- the cull passes: cull_common.glsl (cull_instances, cull_seed, cull_traverse_*,
// cull_compact), gpu_cull.cpp cull_bindings ----
VGEO_CONSTANT uint32_t kCullBindParams = 0u;              // GpuCullParams of the pass
VGEO_CONSTANT uint32_t kCullBindMeshes = 1u;              // GpuCullMesh[]
VGEO_CONSTANT uint32_t kCullBindClusters = 2u;            // GpuCluster[]
VGEO_CONSTANT uint32_t kCullBindGroups = 3u;              // GpuGroup[]
VGEO_CONSTANT uint32_t kCullBindNodes = 4u;               // GpuBvhNode[]
VGEO_CONSTANT uint32_t kCullBindInstances = 5u;           // GpuCullInstance[] (this frame)
VGEO_CONSTANT uint32_t kCullBindOcclusionInstances = 6u;  // GpuCullInstance[] the HZB was drawn with
VGEO_CONSTANT uint32_t kCullBindHzb = 7u;                 // float bits, all mips
VGEO_CONSTANT uint32_t kCullBindQueue = 8u;               // GpuQueueHeader, then uint64 slots
VGEO_CONSTANT uint32_t kCullBindBits = 9u;                // output bit sets
VGEO_CONSTANT uint32_t kCullBindCounters = 10u;           // uint64 per kCounter*
VGEO_CONSTANT uint32_t kCullBindListIn = 11u;             // seeds (instance list or CullItems)
VGEO_CONSTANT uint32_t kCullBindListOut = 12u;            // compacted list (kListHeaderWords, records)
VGEO_CONSTANT uint32_t kCullBindStream = 13u;             // streaming words (GpuCullMesh::stream_base)
VGEO_CONSTANT uint32_t kCullBindingCount = 14u;

// cull_advance.comp: the traversal queue alone.
VGEO_CONSTANT uint32_t kAdvanceBindQueue = 0u;
VGEO_CONSTANT uint32_t kAdvanceBindingCount = 1u;

// hzb_build.comp.
VGEO_CONSTANT uint32_t kHzbBindParams = 0u;  // GpuCullParams (mip table)
VGEO_CONSTANT uint32_t kHzbBindVis = 1u;     // the visibility buffer (uint64 keys as uint pairs)
VGEO_CONSTANT uint32_t kHzbBindHzb = 2u;     // the pyramid written
VGEO_CONSTANT uint32_t kHzbBindingCount = 3u;

// ---- the geometry every raster and shade shader reads (shaders/geometry.glsl: raster.glsl,
// hw_raster.vert, shade.comp), then the visibility buffer ----
VGEO_CONSTANT uint32_t kGeomBindPages = 0u;      // memory-form page words
VGEO_CONSTANT uint32_t kGeomBindLocations = 1u;  // GpuClusterLocation per (mesh, cluster)
VGEO_CONSTANT uint32_t kGeomBindMeshes = 2u;     // GpuMesh[]
VGEO_CONSTANT uint32_t kGeomBindInstances = 3u;  // GpuInstance[]
VGEO_CONSTANT uint32_t kGeomBindVisible = 4u;    // GpuVisibleCluster per visible index
VGEO_CONSTANT uint32_t kGeomBindVis = 5u;        // uint64 visibility keys
VGEO_CONSTANT uint32_t kGeomBindingCount = 6u;

// raster.comp / raster_tiles.comp (raster.glsl): the geometry, then these.
VGEO_CONSTANT uint32_t kRasterBindCounters = 6u;  // pixels written, loop overflow, big count
VGEO_CONSTANT uint32_t kRasterBindPaths = 7u;     // kGpuRasterPath* per visible cluster
VGEO_CONSTANT uint32_t kRasterBindBig = 8u;       // GpuBigTriangle[]
VGEO_CONSTANT uint32_t kRasterBindTiles = 9u;     // GpuRasterTile[]
VGEO_CONSTANT uint32_t kRasterBindingCount = 10u;
// raster_shadow.comp / raster_shadow_tiles.comp (raster.glsl with VGEO_RASTER_SHADOW_PASS):
// the compute rasterizer's bindings, then the shadow pages (spec/shadow.md §5).
VGEO_CONSTANT uint32_t kRasterBindShadowPages = 10u;        // GpuShadowPage per page drawn
VGEO_CONSTANT uint32_t kRasterBindShadowElementPage = 11u;  // page index per element (visible index)
VGEO_CONSTANT uint32_t kRasterBindShadowPool = 12u;         // float depth bits per pool texel
VGEO_CONSTANT uint32_t kRasterShadowBindingCount = 13u;
// The hardware raster pipeline (hw_raster.vert reads the geometry, hw_raster.frag writes the
// visibility buffer and the counters): the compute rasterizer's first bindings.
VGEO_CONSTANT uint32_t kHwRasterBindingCount = 7u;
// The hardware raster of the shadow pages (hw_shadow.vert/.frag, spec/shadow.md §8): the
// shadow compute rasterizer's bindings, then the frame's page table (a slot per entry).
VGEO_CONSTANT uint32_t kHwShadowBindPageTable = 13u;
VGEO_CONSTANT uint32_t kHwShadowBindingCount = 14u;

// shade.comp: the geometry, then these.
VGEO_CONSTANT uint32_t kShadeBindInstances = 6u;  // GpuShadeInstance[]
VGEO_CONSTANT uint32_t kShadeBindClusters = 7u;   // GpuShadeCluster per visible cluster
VGEO_CONSTANT uint32_t kShadeBindMaterials = 8u;  // GpuMaterial[]
VGEO_CONSTANT uint32_t kShadeBindOverdraw = 9u;   // uint per pixel (overdraw view)
VGEO_CONSTANT uint32_t kShadeBindImage = 10u;     // RGBA8 per pixel
VGEO_CONSTANT uint32_t kShadeBindLitFrame = 11u;    // GpuLitFrame
VGEO_CONSTANT uint32_t kShadeBindLights = 12u;      // GpuShadeLight per scene light
VGEO_CONSTANT uint32_t kShadeBindShadowMaps = 13u;  // GpuShadowMap per shadow map of the frame
VGEO_CONSTANT uint32_t kShadeBindShadowTable = 14u; // ShadowFrame::page_table (slot per entry)
VGEO_CONSTANT uint32_t kShadeBindShadowPool = 15u;  // the physical pool (float depths)
VGEO_CONSTANT uint32_t kShadeBindingCount = 16u;

// shadow_mark.comp (spec/shadow.md §4): the primary keys, the lit frame's records, the marks.
VGEO_CONSTANT uint32_t kMarkBindVis = 0u;         // uint64 visibility keys
VGEO_CONSTANT uint32_t kMarkBindLitFrame = 1u;    // GpuLitFrame
VGEO_CONSTANT uint32_t kMarkBindLights = 2u;      // GpuShadeLight per scene light
VGEO_CONSTANT uint32_t kMarkBindShadowMaps = 3u;  // GpuShadowMap per shadow map
VGEO_CONSTANT uint32_t kMarkBindNeeded = 4u;      // uint per page-table entry (1: needed)
VGEO_CONSTANT uint32_t kMarkBindingCount = 5u;

// shadow_cull.comp (spec/shadow.md §5, §8: the shadow views' multi-view cull): the scene's
// cull records (GpuCullMeshes), the frame's maps, views and instances, then its outputs, which
// are the shadow raster's inputs (the elements and their pages).
VGEO_CONSTANT uint32_t kShadowCullBindMeshes = 0u;         // GpuCullMesh[]
VGEO_CONSTANT uint32_t kShadowCullBindClusters = 1u;       // GpuCluster[]
VGEO_CONSTANT uint32_t kShadowCullBindStream = 2u;         // streaming words (GpuCullMesh::stream_base)
VGEO_CONSTANT uint32_t kShadowCullBindMaps = 3u;           // GpuShadowMap per shadow map
VGEO_CONSTANT uint32_t kShadowCullBindViews = 4u;          // GpuShadowCullView per view (map, mip)
VGEO_CONSTANT uint32_t kShadowCullBindInstances = 5u;      // GpuShadowCullInstance per instance
VGEO_CONSTANT uint32_t kShadowCullBindViewInstances = 6u;  // GpuCullInstance per (view, instance): object→light
VGEO_CONSTANT uint32_t kShadowCullBindDrawOfPage = 7u;     // int per page of each view's mip: draw or −1
VGEO_CONSTANT uint32_t kShadowCullBindWork = 8u;           // GpuShadowCullHeader, then (pair, block) items
VGEO_CONSTANT uint32_t kShadowCullBindElements = 9u;       // GpuVisibleCluster per element (written)
VGEO_CONSTANT uint32_t kShadowCullBindElementPage = 10u;   // draw per element (written)
VGEO_CONSTANT uint32_t kShadowCullBindProvisional = 11u;   // uint per draw: 1 = provisional (written)
VGEO_CONSTANT uint32_t kShadowCullBindRequests = 12u;      // uint per group (meshes concatenated): priority bits + 1
VGEO_CONSTANT uint32_t kShadowCullBindingCount = 13u;

// raster_split.comp.
VGEO_CONSTANT uint32_t kSplitBindMeshes = 0u;           // GpuMesh[]
VGEO_CONSTANT uint32_t kSplitBindInstances = 1u;        // GpuInstance[]
VGEO_CONSTANT uint32_t kSplitBindVisible = 2u;          // GpuVisibleCluster[]
VGEO_CONSTANT uint32_t kSplitBindInfos = 3u;            // GpuClusterRasterInfo per (mesh, cluster)
VGEO_CONSTANT uint32_t kSplitBindRasterInstances = 4u;  // GpuRasterInstance[]
VGEO_CONSTANT uint32_t kSplitBindPaths = 5u;            // kGpuRasterPath* per visible cluster (written)
VGEO_CONSTANT uint32_t kSplitBindCommands = 6u;         // GpuDrawCommand[] (written)
VGEO_CONSTANT uint32_t kSplitBindCounters = 7u;         // GpuRasterSplitCounters
VGEO_CONSTANT uint32_t kSplitBindingCount = 8u;

// smoke_atomic_max.comp (tests/gpu: the device's 64-bit atomicMax).
VGEO_CONSTANT uint32_t kSmokeBindValues = 0u;
VGEO_CONSTANT uint32_t kSmokeBindSlots = 1u;
VGEO_CONSTANT uint32_t kSmokeBindingCount = 2u;

#ifdef __cplusplus
// The raster and shade shaders share the geometry bindings and extend them.
static_assert(kRasterBindCounters == kGeomBindingCount && kShadeBindInstances == kGeomBindingCount);
static_assert(kHwRasterBindingCount == kRasterBindCounters + 1);  // through the counters
static_assert(kRasterBindShadowPages == kRasterBindingCount);
static_assert(kHwShadowBindPageTable == kRasterShadowBindingCount);
}  // namespace vgeo
#endif
#endif
