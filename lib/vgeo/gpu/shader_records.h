#ifndef VGEO_GPU_SHADER_RECORDS_H
#define VGEO_GPU_SHADER_RECORDS_H
// Records the host writes and the shaders read (storage buffers and push constants), written
// once in the common C++/GLSL subset (core/shared_glsl.h). Only 32-bit scalars and arrays of
// them, so std430 (GLSL) and the C++ layout agree; C++ checks size and offsets below.
#include "vgeo/core/shared_glsl.h"

#ifdef __cplusplus
namespace vgeo {
#endif

// Where cluster c of a mesh lives: word offset of its memory-form page in the page buffer,
// and its index in that page. One per (mesh, cluster), meshes concatenated.
struct GpuClusterLocation {
  uint32_t page_word;
  uint32_t cluster_in_page;
};

struct GpuMesh {
  uint32_t first_location;       // index of cluster 0's GpuClusterLocation
  int32_t position_step_log2;    // MeshQuantization::position_step_log2
  uint32_t channel_count;        // MeshQuantization::channel_count()
  uint32_t normal_bits;          // 0: no normals
  // Added to the page's per-triangle material ids (a page file's ids are the file's own; a
  // streamed scene mesh's materials start at this offset, FrameStreaming::material_offset).
  uint32_t material_offset;
  uint32_t reserved[3];
};

// Per instance and frame: the float object→clip matrix the CPU rasterizer gets
// (column-major, Mat4::m), the mesh, and the material offset of the mesh's materials.
struct GpuInstance {
  float object_to_clip[16];
  uint32_t mesh;
  uint32_t reserved[3];
};

// The visibility key's visible-cluster index i denotes visible[i] (cull/cull.h VisibleCluster).
struct GpuVisibleCluster {
  uint32_t instance;
  uint32_t cluster;
};

// Push constants of shaders/raster.comp: rasterize visible[first_visible + g] for workgroup g
// (g = y · groups_x + x) of visible_count.
struct GpuRasterParams {
  uint32_t width;
  uint32_t height;
  uint32_t first_visible;
  uint32_t visible_count;
  uint32_t groups_x;
  uint32_t cull_backfaces;
  float z_near;                  // RasterOptions::z_near (float, widened to double as on the CPU)
  // 0: rasterize every cluster of the range; 1: only those whose word in the path buffer
  // (binding 7, written by shaders/raster_split.comp) is kGpuRasterPathSw (hw_raster.h).
  uint32_t select_path;
  // shaders/raster_tiles.comp (the tile pass): invocation i draws tiles[i] (binding 9) for
  // i < tile_count. The cluster pass (raster.comp) defers triangles with a pixel box wider or
  // taller than kGpuRasterTileSize into the big-triangle list (binding 8).
  uint32_t tile_count;
  uint32_t reserved[3];
};

// The compute rasterizer's big-triangle tiles (spec/raster.md §13.5). A triangle whose
// viewport-clamped pixel box has more than kGpuRasterTileSize rows or columns is not drawn by
// the cluster pass but recorded (GpuBigTriangle, counted at counters word kGpuRasterBigWord);
// the host cuts each recorded box into kGpuRasterTileSize² tiles (GpuRasterTile) and the tile
// pass (shaders/raster_tiles.comp) draws each tile in its own invocation with the same setup, snapping, top-left rule and
// key. 64: a cluster-pass invocation vector then runs at most 6 fan triangles × (64 rows ×
// 65 columns + 1) + 1 = 24,967 pixel-loop back edges whatever its 8 lanes' boxes (the vector
// runs the largest rows and columns of its lanes), a tile invocation 4,161: both under
// kGpuLoopBudget - kGpuRasterLoopMargin.
VGEO_CONSTANT uint32_t kGpuRasterTileSize = 64u;
// Big triangles one raster pass may defer (GpuBigTriangle: 32 bytes, a 2 MiB list); more is
// GPU_SCENE_TOO_LARGE.
VGEO_CONSTANT uint32_t kGpuRasterMaxBigTriangles = 65536u;
// Tiles per tile-pass dispatch (GpuRasterTile: 16 bytes, a 16 MiB list at most); more are
// drawn in further dispatches.
VGEO_CONSTANT uint32_t kGpuRasterTilesPerDispatch = 1048576u;

// A deferred triangle: its key's id bits ((visible index << kVisTriangleBits) | triangle),
// which fan triangle of its clipped polygon (0 when not clipped), and its pixel box
// (inclusive, clamped to the viewport).
struct GpuBigTriangle {
  uint32_t id_bits;
  uint32_t fan;
  int32_t min_px;
  int32_t max_px;
  int32_t min_py;
  int32_t max_py;
  uint32_t reserved[2];
};

// One tile of a deferred triangle: pixels [x0, x0 + kGpuRasterTileSize) × [y0, y0 +
// kGpuRasterTileSize) of big[big]'s box.
struct GpuRasterTile {
  uint32_t big;
  int32_t x0;
  int32_t y0;
  uint32_t reserved;
};

// shaders/raster.comp's loop bound (llvmpipe's loop limiter, core/cull_shared.h
// kGpuLoopBudget; spec/raster.md §13.5): an invocation's pixel loops may plan at most
// kGpuLoopBudget - kGpuRasterLoopMargin back edges. The margin covers its other loops (vertex
// decode and transform, ≤ 5 clip planes × 8 polygon vertices, ≤ 6 fan triangles: well under
// 1024) and follows gpu_cull.cpp's kPlannedLoopBudget.
VGEO_CONSTANT uint32_t kGpuRasterLoopMargin = 1024u;
// The raster counters (binding 6): uint64 pixels written (words 0-1), then at this word the
// count of triangles whose pixel loops could not run to the end, then the count of deferred
// big triangles (kGpuRasterTileSize).
VGEO_CONSTANT uint32_t kGpuRasterOverflowWord = 2u;
VGEO_CONSTANT uint32_t kGpuRasterBigWord = 3u;

// The virtual shadow pages' raster (shaders/raster_shadow*.comp, spec/shadow.md §5): the
// texels per page side (shadow/virtual_shadow.h kShadowPageTexels; checked in gpu_frame.cpp) and one
// record per page drawn this frame. The elements (GpuVisibleCluster, instance = the index of
// its view's GpuInstance: per view and instance the float object→clip of the light) each name
// their page (one uint per element).
VGEO_CONSTANT uint32_t kGpuShadowPageTexels = 128u;
struct GpuShadowPage {
  uint32_t viewport;   // R_m: the mip's side, the raster's viewport (virtual_width/height)
  uint32_t window_x;   // the page's first texel in the mip (RasterOptions::window_x)
  uint32_t window_y;
  uint32_t slot;       // pool slot: texels [slot · 128², (slot + 1) · 128²) of the pool
  float z_near;        // RasterOptions::z_near
  uint32_t table_offset;  // page-table entry of page (0, 0) of its (map, mip) (hw_shadow.frag)
  uint32_t table_side;    // pages per side of its mip
  uint32_t reserved;
};

// The shadow views' multi-view cull (shaders/shadow_cull.comp; virtual_shadow.cpp
// cull_shadow_views, spec/shadow.md §5, §8). A view is a (map, mip) with pages to draw; a pair
// is (view, instance), numbered view · instance_count + instance: its GpuCullInstance holds the
// double object→light matrix (object_to_view) and max_axis_scale, and its GpuInstance (the
// raster's) the float object→clip, so an element's instance field is its pair.
struct GpuShadowCullView {
  double texel;                // ortho: the mip's texel size S_k / R_m (ShadowView::texel)
  uint32_t map;                // GpuShadowMap index
  uint32_t r_m;                // the mip's side in texels (R_m)
  uint32_t side;               // the mip's pages per side
  uint32_t page_offset;        // first word of the view's draw-of-page table (side² words)
  float pixels_per_unit_at_1;  // perspective: the view's LodView
  float lod_z_near;
  float tau_s;                 // τ_s
  uint32_t reserved;
};
// An instance's world sphere (virtual_shadow.cpp shadow_instance_sphere, in double).
struct GpuShadowCullInstance {
  double center[3];
  double radius;
};
// Workgroup size of both passes; a work item is one pair's clusters [block · 64, block · 64 + 64).
#define VGEO_SHADOW_CULL_GROUP_SIZE 64
VGEO_CONSTANT uint32_t kGpuShadowCullGroupSize = VGEO_SHADOW_CULL_GROUP_SIZE;
VGEO_CONSTANT uint32_t kShadowCullInstances = 0u;  // mode: one invocation per pair (instance cull)
VGEO_CONSTANT uint32_t kShadowCullArgs = 1u;       // mode: the cluster pass's dispatch arguments
VGEO_CONSTANT uint32_t kShadowCullClusters = 2u;   // mode: one workgroup per work item (cluster cull)
struct GpuShadowCullPush {
  uint32_t mode;
  uint32_t pair_count;        // views × instances
  uint32_t instance_count;
  uint32_t streamed;          // 1: a streamed frame (resident cut, provisional pages, requests)
  float tau;                  // τ of the primary view (secondary_view_priority)
  uint32_t element_capacity;  // elements the element buffers hold (more are counted, not written)
  uint32_t work_capacity;     // work items the work buffer holds
  uint32_t reserved;
};
// The work buffer's header: the instance pass appends kept pairs' work items (work_count),
// the args pass writes the cluster pass's indirect dispatch (item = y · x-count + x), the
// cluster pass counts its elements.
struct GpuShadowCullHeader {
  uint32_t work_count;
  uint32_t dispatch_x, dispatch_y, dispatch_z;
  uint32_t element_count;
  uint32_t reserved[3];
};

// Per instance and frame, for shading (shade.cpp): object→view (column-major Mat4d::m) and
// the normal matrix (cofactor matrix of the 3x3 part, sign-corrected; row-major 3x3).
struct GpuShadeInstance {
  double object_to_view[16];
  double normal_matrix[9];
  double reserved;
};

// Per visible cluster, what the debug views colour by (from the DAG metadata; the error is
// core/lod.h projected_error evaluated on the host, the one implementation).
struct GpuShadeCluster {
  uint32_t group;
  uint32_t level;
  uint32_t level_count;
  float projected_error;
};

struct GpuMaterial {
  float base_color[4];  // linear RGBA (Material::base_color)
};

// Push constants of shaders/shade.comp (doubles first: std430 aligns them to 8).
struct GpuShadeParams {
  double tan_half_x;        // ViewParams
  double tan_half_y;
  double light[3];          // normalized light direction (world), as shade.cpp lx, ly, lz
  uint32_t width;
  uint32_t height;
  uint32_t view;            // ShadeView
  uint32_t material_count;
  float ambient;
  float threshold_px;
  uint32_t max_overdraw;
  uint32_t reserved;
};

// Scene lights and their virtual shadow maps for shaders/shade.comp's lit view (spec/shadow.md
// §2, §4, §6; shade.cpp sum_lights, virtual_shadow.cpp select_shadow_texel / shadow_term).
// Doubles first (std430 aligns them to 8).
struct GpuShadeLight {
  double position[3];     // Light::position (spot, point)
  double direction[3];    // Light::direction (unit; directional, spot)
  double cos_half_cone;   // spot: std::cos(0.5 · cone_radians), evaluated on the host
  float color[3];
  float intensity;
  uint32_t type;          // LightType
  uint32_t shadows;       // 1: Light::shadows and the frame drew its maps (shadow term read)
  uint32_t first_map;     // ShadowFrame::light_first_map
  uint32_t map_count;     // ShadowFrame::light_map_count
  uint32_t reserved[2];
};

// One ShadowMapView: the light view's rows 0..2 and the projection, row-major (Mat4d::at(r, c)
// at r · 4 + c).
struct GpuShadowMap {
  double world_to_light[12];
  double light_to_clip[16];
  double eye[3];
  double tan_half;
  double z_near;
  double side;
  double depth_range;
  uint32_t type;          // LightType
  uint32_t ortho;
  uint32_t table_offset;
  uint32_t reserved;
};

// The frame's part of the lit view with lights: view → world (rows 0..2 of the rigid inverse,
// row-major; its column 3 is the camera position the trace starts from), world → view, the
// view's near plane, the shadow test's constants (spec/shadow.md §6).
struct GpuLitFrame {
  double view_to_world[12];
  double world_to_view[12];  // ViewParams::world_to_view rows 0..2 (the screen-space trace)
  double z_near;          // ViewParams::z_near
  double tau;             // ShadowOptions::threshold_px (τ)
  double tau_s;           // kShadowLodBias · τ
  double max_slope;       // kMaxShadowSlope
  double max_mismatch_secant;  // kMaxMismatchSecant
  uint32_t light_count;   // 0: the fixed light of GpuShadeParams::light
  uint32_t pages_per_side;  // ShadowOptions::pages_per_side
  uint32_t mips;          // mips per map
  uint32_t directional_levels;  // kDirectionalLevels
  uint32_t trace_max_steps;     // kShadowTraceMaxSteps
  int32_t texels_per_pixel_log2;  // ShadowOptions::texels_per_pixel_log2 (b of spec/shadow.md §4 step 2)
};

// Workgroup size of the raster shader: one invocation per triangle of a cluster.
VGEO_CONSTANT uint32_t kGpuRasterGroupSize = 128u;
// Largest workgroup count per dispatch dimension the host uses (Vulkan guarantees 65535).
VGEO_CONSTANT uint32_t kGpuMaxGroupsX = 65535u;

#ifdef __cplusplus
static_assert(sizeof(GpuClusterLocation) == 8);
static_assert(sizeof(GpuMesh) == 32 && offsetof(GpuMesh, material_offset) == 16);
static_assert(sizeof(GpuInstance) == 80 && offsetof(GpuInstance, mesh) == 64);
static_assert(sizeof(GpuVisibleCluster) == 8);
static_assert(sizeof(GpuRasterParams) == 48 && offsetof(GpuRasterParams, z_near) == 24 &&
              offsetof(GpuRasterParams, tile_count) == 32);
static_assert(sizeof(GpuBigTriangle) == 32 && sizeof(GpuRasterTile) == 16);
static_assert(sizeof(GpuShadowCullView) == 40 && offsetof(GpuShadowCullView, pixels_per_unit_at_1) == 24);
static_assert(sizeof(GpuShadowCullInstance) == 32 && sizeof(GpuShadowCullPush) == 32 && sizeof(GpuShadowCullHeader) == 32);
static_assert(sizeof(GpuShadeInstance) == 208 && offsetof(GpuShadeInstance, normal_matrix) == 128);
static_assert(sizeof(GpuShadeCluster) == 16);
static_assert(sizeof(GpuShadowPage) == 32 && offsetof(GpuShadowPage, z_near) == 16);
static_assert(sizeof(GpuShadeLight) == 96 && offsetof(GpuShadeLight, color) == 56 && offsetof(GpuShadeLight, type) == 72);
static_assert(sizeof(GpuShadowMap) == 296 && offsetof(GpuShadowMap, type) == 280);
static_assert(sizeof(GpuLitFrame) == 256 && offsetof(GpuLitFrame, light_count) == 232);
static_assert(sizeof(GpuMaterial) == 16);
static_assert(sizeof(GpuShadeParams) == 72 && offsetof(GpuShadeParams, width) == 40 && offsetof(GpuShadeParams, ambient) == 56);
}  // namespace vgeo
#endif
#endif
