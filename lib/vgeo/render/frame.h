#pragma once
// The CPU reference frame pipeline (spec/scene.md §Frame pipeline): the CPU executor of the
// frame plan (lib/vgeo/render/frame_plan.h, which lists every step and what it consumes and
// produces):
//   pass 1: instance cull (frustum, then previous-frame HZB with previous transforms)
//           → hierarchical LOD + cluster cull (persistent threads) → raster
//   pass 2: only when pass 1 occluded something: build HZB from pass-1 depth, retest what
//           pass 1 occluded against it, raster the newly visible
//   hzb_next: HZB of the complete frame for the next frame (only when a next frame exists)
//   shade: deferred shading of the visibility buffer
// A pass that does not run is absent from FrameStats::passes and costs nothing; the reason
// is listed in FrameStats::skipped.
#include <cstdint>
#include <string>
#include <vector>

#include "vgeo/dag/cluster_dag.h"
#include "vgeo/core/thread_pool.h"
#include "vgeo/cull/cull.h"
#include "vgeo/raster/raster.h"
#include "vgeo/raster/visbuffer.h"
#include "vgeo/render/frame_plan.h"
#include "vgeo/render/streaming.h"
#include "vgeo/shade/shade.h"
#include "vgeo/shadow/light.h"
#include "vgeo/shadow/virtual_shadow.h"

namespace vgeo {

struct RenderScene {
  std::vector<ClusterDag> meshes;
  std::vector<Material> materials;
  std::vector<CullInstance> instances;
  std::vector<Light> lights;  // spec/shadow.md; empty: the fixed light of spec/scene.md §Shading
  // Set by analyze_render_scene: one instance of a convex mesh cannot occlude itself
  // except by back faces (already culled), so occlusion passes would be pure cost.
  bool single_convex_object = false;
};
void analyze_render_scene(RenderScene* scene);

struct RenderSettings {
  float threshold_px = 1.0f;  // τ
  bool occlusion = true;
  HzbMipPolicy hzb_policy = HzbMipPolicy::k4x4;
  RasterPath raster_path = RasterPath::kAuto;
  ShadeView view = ShadeView::kLit;
  bool shade = true;          // false: stop after the visibility buffer (tests)
};

// What a frame leaves for the next one (two-pass occlusion's "previous frame").
struct FrameHistory {
  bool valid = false;
  Hzb hzb;
  ViewParams view;
  std::vector<InstanceView> instance_views;
  ShadowCache shadow_cache;  // the shadow pool and the pages it holds (spec/shadow.md §5)
};

struct Frame {
  ViewParams view;
  std::vector<InstanceView> instance_views;
  VisBuffer vis;
  std::vector<VisibleCluster> visible;  // visible-cluster index → (instance, cluster)
  uint32_t pass1_visible = 0;           // visible[0, pass1_visible) were drawn by pass 1
  std::vector<uint32_t> overdraw;       // per pixel, only for ShadeView::kOverdraw
  Image image;
  ShadowFrame shadow;  // this frame's virtual shadow maps (when shadow_mark ran)
  FrameStats stats;
};

// What one frame is rendered from, on every backend (render_frame, render_frame_vulkan).
// `history` null: no occlusion history at all; otherwise pass 1 tests against it when valid,
// and when `has_next_frame` it is replaced by this frame's (pass hzb_next). `streaming` null:
// every mesh fully in memory; otherwise the traversal applies its usable masks, drawn
// clusters' geometry comes from resident pages and the traversal's requests go to its
// streamer (spec/stream.md §Renderer); `no_stream_reason` is the stream pass's skip reason
// when it is null.
struct FrameInputs {
  const RenderScene& scene;
  const Camera& camera;
  const RenderSettings& settings;
  ThreadPool& pool;
  FrameHistory* history = nullptr;
  bool has_next_frame = true;
  FrameStreaming* streaming = nullptr;
  std::string no_stream_reason = "no stream budget";
};

// Renders one frame on the CPU: plan_frame from frame_context, then render_planned_frame.
// Throws VgeoError RENDER_TOO_MANY_VISIBLE_CLUSTERS when the visibility-buffer id space
// overflows.
void render_frame(const FrameInputs& in, Frame* out);

// What every frame executor does first and shares (CPU: frame.cpp; Vulkan: gpu_frame.cpp):
// resets `out` for `camera` (view, instance views, an empty visibility buffer, no visible
// clusters) and returns the per-instance object→clip matrices (float, from double products).
std::vector<Mat4> begin_frame(const RenderScene& scene, const Camera& camera, Frame* out);
// A cull pass's counters into its PassStats (the members the statistics table shows).
void add_instance_counters(const CullCounters& c, PassStats* p);
void add_cull_counters(const CullCounters& c, PassStats* p);
// Throws RENDER_TOO_MANY_VISIBLE_CLUSTERS when `n` visible clusters overflow the key's id space.
void check_visible_count(size_t n);

// Overdraw view: per-pixel count of the drawn clusters covering it (each cluster rasterized
// alone; `geometry`: the scene's meshes or the streamed frame's). The CPU step `overdraw`; the
// Vulkan executor runs it on the host too.
void overdraw_pass(const RenderScene& scene, const std::vector<ClusterDag>& geometry,
                   const std::vector<VisibleCluster>& visible, const std::vector<Mat4>& object_to_clip,
                   const std::vector<InstanceView>& views, const ViewParams& view, ThreadPool& pool,
                   std::vector<uint32_t>* counts);

// Step shadow_mark of every executor (spec/shadow.md §4): the frame's shadow maps (out->shadow)
// and the pages the covered pixels of out->vis need (the CPU executor's; the Vulkan executor
// marks on the device, shadow_mark.comp, after begin_shadow_mark).
void shadow_mark_step(const FrameInputs& in, Frame* out);
// Its first half, for an executor that marks on its device: out->shadow's maps, nothing marked.
void begin_shadow_mark(const FrameInputs& in, Frame* out);
// The shadow counters of a frame whose shadow_draw ran (spec/shadow.md §7).
ShadowFrameStats shadow_frame_stats(const ShadowFrame& f);

// The plan's context from the inputs' history and streaming state.
FrameContext frame_context(const FrameInputs& in);

// Executes `plan` (plan_frame of in.scene, in.settings and frame_context(in)) on the CPU;
// in.streaming must be non-null exactly when plan.streamed.
void render_planned_frame(const FramePlan& plan, const FrameInputs& in, Frame* out);

}  // namespace vgeo
