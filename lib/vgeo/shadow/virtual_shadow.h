#pragma once
// Virtual shadow maps, CPU reference (normative: spec/shadow.md). Every shadowing light has one
// (spot), six (point) or kDirectionalLevels (directional clipmap) virtual depth maps of
// 16384² texels in 128² pages with mips; each frame the pages the visible pixels sample are
// marked, given physical slots from a fixed pool (reusing cached pages), and the missing ones
// drawn through the software raster scissored to the page. Records are flat arrays (page table,
// pool texels, needed keys) a GPU path can upload as they are.
// Based on: Karis et al., "Nanite: A Deep Dive" (SIGGRAPH 2021), §"Virtual shadow maps",
// §"Multi-view rendering", §"Culling and addressing to pages", §"Nanite shadow LOD"; the seed
// notes' §"Virtual shadow buffer".
#include <cstdint>
#include <memory>
#include <vector>

#include "vgeo/core/thread_pool.h"
#include "vgeo/cull/cull.h"
#include "vgeo/dag/cluster_dag.h"
#include "vgeo/raster/raster.h"
#include "vgeo/raster/visbuffer.h"
#include "vgeo/shadow/light.h"
#include "vgeo/stream/stream.h"

namespace vgeo {

// spec/shadow.md §3: 128-texel pages, a 128 x 128 page table at mip 0 (16384² texels), mips 0..7.
inline constexpr uint32_t kShadowPageTexels = 128;
inline constexpr uint32_t kShadowPagesPerSide = 128;
inline constexpr uint32_t kShadowMips = 8;
// Directional clipmap levels: level k's side is 4r·2^(k−7); 8 levels span 128x in texel size
// (the coarsest covers the scene from anywhere inside it, the finest ~r/32).
inline constexpr uint32_t kDirectionalLevels = 8;
// Physical pool (spec/shadow.md §5): 1024 pages x 64 KiB = 64 MiB of depth.
inline constexpr uint32_t kShadowPoolPages = 1024;
// Shadow LOD bias (seed: "Defaults to 2 pixels of error"): τ_s = kShadowLodBias · τ.
inline constexpr float kShadowLodBias = 2.0f;
// Slope part of the bias is clamped here (tan of ~86.4°): beyond it Lambert is < 0.063 and the
// bias would grow without bound at grazing angles. The trace's view slope uses the same clamp.
inline constexpr double kMaxShadowSlope = 16.0;
// The LOD-mismatch zone's secant factor min(1 + s, 8) (spec/shadow.md §6): the zone covers the
// mismatch along the light for c ≥ 1/8; at more grazing light (Lambert < 1/8) it stops growing,
// so the trace stays short (a few pixels, as the seeds' "short screen space trace") and a far
// caster stays a far caster: a zone of 17·(f + 2T) reached past a closed mesh around a point light.
inline constexpr double kMaxMismatchSecant = 8.0;
// Screen-space trace (spec/shadow.md §6): at most this many depth-buffer samples per light per
// pixel. Steps are one pixel footprint long (≤ 1 screen pixel each) until the LOD-mismatch zone
// is longer than 16 footprints (only at slopes s > ~3 with τ = 1); then the zone is split into 16
// equal steps: the seeds' "walk a few pixels", with a bounded cost per pixel.
inline constexpr uint32_t kShadowTraceMaxSteps = 16;

struct ShadowOptions {
  // Virtual size: pages per side at mip 0 (spec value 128; tests shrink it so a brute-force
  // full-resolution map fits in memory). A power of two ≥ 2^(kShadowMips−1).
  uint32_t pages_per_side = kShadowPagesPerSide;
  uint32_t pool_pages = kShadowPoolPages;
  float threshold_px = 1.0f;  // τ of the primary view (τ_s = kShadowLodBias · τ)
  // Texel density (spec/shadow.md §4, step 2): a texel's side is at most 2^−b screen pixels
  // (b = texels_per_pixel_log2). Frames use 0 (the seeds' one texel ≈ one pixel); `vgeo bench
  // shadows` varies it to measure shadow error against texel density and time.
  int texels_per_pixel_log2 = 0;
};

struct ShadowSceneBounds {
  Vec3d center;
  double radius = 1;
};
// spec/shadow.md §3: centre of the world AABB of every instance's mesh-AABB corners, radius the
// largest corner distance (1 when 0).
ShadowSceneBounds shadow_scene_bounds(const std::vector<ClusterDag>& meshes, const std::vector<CullInstance>& instances);

// One virtual shadow map of a frame: its light view and projection.
struct ShadowMapView {
  LightType type = LightType::kDirectional;
  uint32_t light = 0;   // scene light index
  uint32_t index = 0;   // spot 0; point face 0..5; directional level 0..7
  bool ortho = false;
  Mat4d world_to_light;  // light view (looks down −Z)
  Mat4d light_to_clip;   // perspective_reversed_z, or the level's orthographic window
  double tan_half = 0;   // perspective: tan(fov/2)
  double z_near = 0;     // perspective: z_s
  double side = 0;       // ortho: S_k (light-view units)
  int64_t origin_x = 0, origin_y = 0;  // ortho: world page index of the window's page (0, 0)
  double depth_range = 0;              // ortho: 4r
  Vec3d eye;                           // E of spec/shadow.md §3
  uint32_t table_offset = 0;           // first page-table entry of this map's mip 0
};

// A texel a pixel needs (select_shadow_texel).
struct ShadowTexel {
  uint32_t map = 0, mip = 0, x = 0, y = 0;  // texel (x, y) of mip `mip` of maps[map]
  double dist = 0;                          // the point's light-view depth (−z)
};

inline constexpr uint32_t kNoShadowSlot = 0xFFFFFFFFu;

// The frame's maps, page table and needed set (spec/shadow.md §3–§5).
struct ShadowDrawList;  // below

struct ShadowFrame {
  ShadowOptions options;
  ShadowSceneBounds bounds;
  std::vector<ShadowMapView> maps;        // shadowing lights' maps, light by light
  std::vector<uint32_t> light_first_map;  // per scene light: first map, kNoShadowSlot if none
  std::vector<uint32_t> light_map_count;  // per scene light
  // Page table: for map i, mip m: entries table_offset + mip_table_offset(m) + y·side_m + x,
  // each a physical slot or kNoShadowSlot; `needed` marks the pages of this frame.
  std::vector<uint32_t> page_table;
  std::vector<uint8_t> needed;
  const std::vector<float>* pool_texels = nullptr;  // the pool's texels (ShadowCache::texels); null: own_texels
  std::vector<float> own_texels;                    // the pool when no cache is kept
  uint64_t lights = 0;                              // shadowing lights
  uint64_t pages_marked = 0, pages_cached = 0, pages_drawn = 0, pages_dropped = 0, clusters_drawn = 0;
  // What shadow_draw drew this frame (its pages, their elements and matrices), kept for the
  // comparison of another backend's pages under the hardware rule (shadow_hw_rule.h).
  std::shared_ptr<const ShadowDrawList> drawn;
};

// What survives between frames (spec/shadow.md §5): the pool and the pages it holds.
struct ShadowCache {
  bool valid = false;
  std::vector<Light> lights;
  ShadowSceneBounds bounds;
  std::vector<Mat4d> transforms;  // instance transforms the pages were drawn with
  std::vector<float> texels;      // pool: slot s at [s·128², (s+1)·128²)
  // Per slot: the page it holds (map key) or unused. Keys name world pages (stable for
  // directional levels whose window moved with the camera).
  struct SlotKey {
    uint32_t light = 0, map = 0, mip = 0;
    int64_t x = 0, y = 0;
    bool used = false;
    friend bool operator==(const SlotKey&, const SlotKey&) = default;
  };
  std::vector<SlotKey> slots;
};

// Step shadow_mark's setup: the maps of every shadowing light for a camera at `camera_position`.
ShadowFrame make_shadow_frame(const std::vector<Light>& lights, const ShadowSceneBounds& bounds,
                              const Vec3d& camera_position, const ShadowOptions& options);

// spec/shadow.md §4: the sample point of pixel (x, y) with reversed-Z depth `depth` (world,
// double) and its footprint (world size of one pixel there).
Vec3d shadow_sample_point(const ViewParams& view, const Mat4d& view_to_world, uint32_t x, uint32_t y, float depth,
                          double* footprint);
// Inverse of a rigid transform (rotation + translation).
Mat4d rigid_inverse(const Mat4d& m);

// spec/shadow.md §4: the texel light `light` needs at world point p with footprint f; false
// when none (a non-shadowing light, outside a spot's cone, outside every clipmap level).
bool select_shadow_texel(const ShadowFrame& frame, uint32_t light, const Vec3d& p, double footprint,
                         ShadowTexel* out);
// Texel size (light-view units) of `texel`'s map and mip at its depth.
double shadow_texel_size(const ShadowFrame& frame, const ShadowTexel& texel);
// Page-table entry of the page holding `texel`.
size_t shadow_page_entry(const ShadowFrame& frame, const ShadowTexel& texel);

// Step shadow_mark (spec/shadow.md §4): marks the page of every texel a covered pixel of `vis`
// needs, for every shadowing light. Deterministic for any thread count.
void mark_shadow_pages(const VisBuffer& vis, const ViewParams& view, const std::vector<Light>& lights,
                       ThreadPool& pool, ShadowFrame* frame);

// Step shadow_draw (spec/shadow.md §5): reuses cached pages (when neither the light nor an
// overlapping caster moved), allocates slots in page-table order and draws every other needed
// page: per (map, mip) the LOD cut with τ_s, each cut cluster rasterized into every needed page
// its texel rectangle overlaps. `cache` null: nothing is kept (every needed page drawn).
void draw_shadow_pages(const std::vector<ClusterDag>& meshes, const std::vector<CullInstance>& instances,
                       const std::vector<Light>& lights, ThreadPool& pool, ShadowFrame* frame, ShadowCache* cache);

// Step shadow_draw in three phases, so that every executor shares the cache, allocation and
// multi-view cull and only the raster differs (the CPU's raster_shadow_pages_cpu, Vulkan's compute
// raster; spec/shadow.md §5). begin_shadow_draw invalidates the cache, allocates slots in
// page-table order (filling the frame's page table and counters), grows cache->texels to the
// slots in use and culls every view; the caller then writes each listed page's 128² texels into
// its slot of cache->texels (every texel: 0 where nothing was drawn); end_shadow_draw records
// what the pages were drawn with and points the frame at the pool (`kept` false: the cache is
// the frame's own, its texels move into ShadowFrame::own_texels).
// Streaming (spec/shadow.md §9): `usable` holds per scene mesh its usable groups (empty: every
// group; null: not streamed); the views then draw the resident cut of spec/stream.md §Cut with
// τ_s (its clusters' geometry must be bound before the raster: shadow_draw_clusters), a page an
// undrawn ideal-cut cluster overlaps is provisional (drawn, not kept in the cache), and the
// ideal cut's groups are requested at the lower priority of secondary_view_priority.
struct ShadowPageDraw {
  uint32_t map = 0, mip = 0, x = 0, y = 0;  // page (x, y) (local) of mip `mip` of maps[map]
  uint32_t slot = 0;                        // the pool slot it is drawn into
  uint32_t view = 0;                        // its view: index into ShadowDrawList::object_to_clip
  RasterOptions raster;                     // the mip's viewport, the page's window, z_near, no back-face culling
};
struct ShadowDrawList {
  std::vector<ShadowPageDraw> pages;                  // page-table order
  std::vector<std::vector<VisibleCluster>> clusters;  // per page: its clusters, (instance, cluster) order
  std::vector<std::vector<Mat4>> object_to_clip;      // per view (map, mip): float object→clip per instance
  std::vector<uint8_t> provisional;    // per page: drawn coarser than its ideal cut (streaming): not cached
  std::vector<GroupRequest> requests;  // streaming: the shadow views' ideal-cut groups (scene mesh ids)
};
// begin_shadow_draw's phases, so that a backend may run the multi-view cull elsewhere (the
// Vulkan executor: shaders/shadow_cull.comp) and share the rest (spec/shadow.md §8):
// plan_shadow_draw invalidates the cache and allocates slots (the page table, the counters but
// clusters_drawn, cache->texels grown) and lists the pages to draw and their views;
// cull_shadow_views is the reference's multi-view cull (the list's clusters, provisional pages
// and requests); finish_shadow_cull counts the elements, drops provisional pages' slots from the
// cache and adds the pages and their views' float object→clip matrices to the list.
// One view of the multi-view pass (spec/shadow.md §5): a (map, mip) with pages to draw.
struct ShadowView {
  uint32_t map = 0, mip = 0;
  uint32_t r_m = 0;   // the mip's side in texels
  uint32_t side = 0;  // the mip's pages per side
  // Its LOD test (spec/shadow.md §5): orthographic (texel size `texel`) or from the light's
  // projection (LodView with the eye at the light-view origin).
  bool ortho = false;
  double texel = 0;
  float pixels_per_unit_at_1 = 0, lod_z_near = 0;
  float tau_s = 0;
  std::vector<int32_t> draw_of_page;  // per page of the mip: its index in ShadowDrawPlan::pages, or −1
};
struct ShadowDrawPlan {
  std::vector<ShadowPageDraw> pages;  // page-table order (ShadowPageDraw::view: index into views)
  std::vector<ShadowView> views;
};
ShadowDrawPlan plan_shadow_draw(const std::vector<ClusterDag>& meshes, const std::vector<CullInstance>& instances,
                               const std::vector<Light>& lights, ShadowFrame* frame, ShadowCache* cache);
void cull_shadow_views(const std::vector<ClusterDag>& meshes, const std::vector<CullInstance>& instances,
                       const ShadowFrame& frame, const ShadowDrawPlan& plan,
                       const std::vector<std::vector<uint8_t>>* usable, ThreadPool& pool, ShadowDrawList* out);
void finish_shadow_cull(const std::vector<CullInstance>& instances, ShadowDrawPlan plan, ShadowFrame* frame,
                        ShadowCache* cache, ShadowDrawList* list);
// What the multi-view cull reads per instance and view: the instance's world sphere (its mesh's
// root sphere placed, in double; radius 0 for an empty mesh), its double object→light matrix for
// map `map`, and per instance the float object→clip of map `map` (the raster's).
void shadow_instance_sphere(const std::vector<ClusterDag>& meshes, const CullInstance& inst, Vec3d* center,
                            double* radius);
Mat4d shadow_object_to_light(const ShadowFrame& frame, uint32_t map, const CullInstance& inst);
std::vector<Mat4> shadow_object_to_clip(const ShadowFrame& frame, uint32_t map, const std::vector<CullInstance>& instances);
ShadowDrawList begin_shadow_draw(const std::vector<ClusterDag>& meshes, const std::vector<CullInstance>& instances,
                                 const std::vector<Light>& lights, ThreadPool& pool, ShadowFrame* frame,
                                 ShadowCache* cache, const std::vector<std::vector<uint8_t>>* usable = nullptr);
// The distinct (instance, cluster) pairs the draw list rasterizes, ascending (what a streamed
// frame binds before the raster).
std::vector<VisibleCluster> shadow_draw_clusters(const ShadowDrawList& list);
// The CPU reference's raster phase: every listed page from `raster_meshes` (which need the vertex
// data of the listed clusters: the scene's meshes, or a streamed frame's bound geometry) into
// its slot of cache->texels.
void raster_shadow_pages_cpu(const std::vector<ClusterDag>& raster_meshes, const std::vector<CullInstance>& instances,
                             const ShadowDrawList& list, ThreadPool& pool, ShadowCache* cache);
void end_shadow_draw(const std::vector<CullInstance>& instances, const std::vector<Light>& lights, ShadowFrame* frame,
                     ShadowCache* cache, bool kept);

// The primary view the shadow test's screen-space trace walks (spec/shadow.md §6): its
// visibility buffer (depths), view, and the eye's world position.
struct ShadowScreen {
  const VisBuffer* vis = nullptr;
  const ViewParams* view = nullptr;
  Vec3d camera;  // translation of view_to_world
};
ShadowScreen make_shadow_screen(const VisBuffer& vis, const ViewParams& view);

// One pixel's inputs to the shadow test of one light (spec/shadow.md §6).
struct ShadowReceiver {
  uint32_t x = 0, y = 0;  // the pixel
  Vec3d p;                // its sample point (world)
  double footprint = 0;   // f
  Vec3d normal;           // unit shading normal (world)
  Vec3d to_light;         // l: unit, towards the light
  double cos_nl = 0;      // c = n·l > 0, as the shading computed it
};

// How the shadow test decided (spec/shadow.md §6).
enum class ShadowDecision : uint8_t {
  kNoTexel,    // the pixel needs no texel of this light (lit)
  kLit,        // stored ≤ d_lit: nothing nearer the light beyond the sampling bias
  kFarCaster,  // stored > d_far: a caster beyond the LOD-mismatch zone (shadowed, no trace)
  kTraceHit,   // in the zone; the screen-space trace found the caster (shadowed)
  kTraceMiss,  // in the zone; the trace found nothing: LOD mismatch, not a caster (lit)
};
struct ShadowTestDetail {
  ShadowDecision decision = ShadowDecision::kNoTexel;
  ShadowTexel texel;
  float stored = 0, d_lit = 0, d_far = 0;  // the texel's depth and the two receiver depths
  double zone = 0;                        // D = b_t + M, the far end of the zone (light-view units)
  uint32_t trace_steps = 0;               // depth-buffer samples the trace read
};
// spec/shadow.md §6, every intermediate of the decision (tests, statistics).
ShadowTestDetail shadow_test(const ShadowFrame& frame, uint32_t light, const ShadowReceiver& receiver,
                             const ShadowScreen& screen);
// spec/shadow.md §6: 1 (lit) or 0 (shadowed).
float shadow_term(const ShadowFrame& frame, uint32_t light, const ShadowReceiver& receiver, const ShadowScreen& screen);

// Reference for tests: texels of the whole mip `mip` of map `map` (R_m x R_m, row-major)
// drawn in one pass with the same cut and raster (spec/shadow.md §5, "the page's texels are
// exactly those of the whole map").
std::vector<float> draw_full_shadow_map(const std::vector<ClusterDag>& meshes, const std::vector<CullInstance>& instances,
                                        const ShadowFrame& frame, uint32_t map, uint32_t mip, ThreadPool& pool);
// The depth stored for `texel` (0 when its page has no slot).
float shadow_stored_depth(const ShadowFrame& frame, const ShadowTexel& texel);

}  // namespace vgeo
