#pragma once
// The frame plan (normative: spec/scene.md §Frame pipeline): which steps of a frame run and, for
// each that does not, why — decided once per frame from the scene, the settings and the history,
// before any pass runs, and executed by a backend's FrameExecutor (the CPU reference in
// lib/vgeo/render/frame.cpp; a Vulkan executor in lib/vgeo/gpu implements the same steps).
// Where a decision depends on a pass's result (pass 2 runs only when pass 1 occluded something),
// the plan states the condition and execute_frame_plan evaluates it, in one place, from the
// StepResult the executor returns. The frame's bookkeeping lives here too, once for every
// executor: an executor step returns what it produced (StepResult) and execute_frame_plan
// applies it to the frame (the visible list and its pass-1 part, the stream requests and cut
// counters, the facts, the drawn clusters and triangles, the history's view). Statistics,
// their table and JSON are assembled here from what the executor counts, so they have the same
// shape for every executor.
//
// Steps, in execution order, with what each consumes and produces. "Visible list": the frame's
// visible clusters (instance, cluster) in draw order; a visibility-buffer key's cluster field is
// the index into it (lib/vgeo/raster/visbuffer.h), so both backends must append in this order:
//   stream_begin        (pass stream) streaming only. Consumes completed page reads. Produces the
//                       per-mesh usable-group masks the traversal reads (spec/stream.md §Renderer).
//   instance_cull       Consumes instances, their root bounds, the view; when the plan says
//                       previous_hzb, the previous frame's HZB, view and instance views. Produces
//                       the visible instances and the occluded ones (ascending instance order).
//                       Sets FrameFacts::pass1_occluded when it occluded an instance.
//   cluster_cull        Consumes the visible instances (their BVH roots as seeds), LOD threshold,
//                       usable masks, previous HZB as above. Produces the visible list [0, n1),
//                       pass-1 occluded items (nodes, groups, clusters), stream requests and the
//                       ideal/coarser cut counters. Sets pass1_occluded when it occluded anything.
//                       Fails RENDER_TOO_MANY_VISIBLE_CLUSTERS beyond kMaxVisibleClusters.
//   stream_bind         (pass stream) streaming only: geometry of visible[0, n1) from resident pages.
//   raster              Rasterizes visible[0, n1) into the visibility buffer (cleared at frame start).
//   hzb                 When pass1_occluded: HZB of the pass-1 visibility buffer's depth.
//   instance_cull_post  When pass1_occluded: the pass-1 occluded instances retested against `hzb`
//                       with this frame's view and transforms. Produces newly visible instances.
//   cluster_cull_post   When pass1_occluded: seeds = pass-1 occluded items, then the newly visible
//                       instances' roots; tested against `hzb`. Appends visible[n1, n2), adds its
//                       requests and cut counters. Sets FrameFacts::pass2_found_visible when n2 > n1.
//   stream_bind_post    (pass stream) when pass2_found_visible: geometry of visible[n1, n2).
//   raster_post         When pass2_found_visible: rasterizes visible[n1, n2) into the same buffer.
//   hzb_next            Occlusion active, a history to keep and a next frame: HZB of the complete
//                       visibility buffer (the `hzb` pyramid when raster_post did not run after
//                       it), stored with this view and instance views as the next frame's history.
//   stream_end          (pass stream) streaming only: hands requests and cut counters to the
//                       Streamer (issues reads, evicts). Every visible cluster is bound by now.
//   shadow_mark         A shadowing light and the lit view shaded (spec/shadow.md §4): the
//                       virtual shadow maps of the frame and the pages the covered pixels of the
//                       complete visibility buffer need.
//   shadow_draw         With shadow_mark: reuses cached pages, allocates pool slots, draws the
//                       other needed pages (spec/shadow.md §5). Produces the shadow statistics.
//   overdraw            `overdraw` view and shading: per-pixel count of drawn clusters covering it.
//   shade               Shading requested: RGBA image from the visibility buffer and visible list.
// A pass's statistics (time and counters) are the sum over its steps; a pass none of whose steps
// ran is listed under FrameStats::skipped with the reason of its first step.
#include <array>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "vgeo/cull/cull.h"
#include "vgeo/stream/stream.h"

namespace vgeo {

struct RenderScene;
struct RenderSettings;
struct Frame;
struct FrameHistory;
struct FrameStreaming;

// Passes of the statistics, in the order they are reported.
enum class FramePass : uint8_t {
  kInstanceCull, kClusterCull, kRaster, kHzb, kInstanceCullPost, kClusterCullPost, kRasterPost,
  kHzbNext, kStream, kShadowMark, kShadowDraw, kOverdraw, kShade,
};
inline constexpr size_t kFramePassCount = 13;
const char* frame_pass_name(FramePass pass);

// Steps, in execution order (see the table above).
enum class FrameStep : uint8_t {
  kStreamBegin, kInstanceCull, kClusterCull, kStreamBind, kRaster, kHzb, kInstanceCullPost,
  kClusterCullPost, kStreamBindPost, kRasterPost, kHzbNext, kStreamEnd, kShadowMark, kShadowDraw, kOverdraw, kShade,
};
inline constexpr size_t kFrameStepCount = 16;
const char* frame_step_name(FrameStep step);
FramePass frame_step_pass(FrameStep step);  // whose statistics the step adds to

// When a step runs. kRun/kSkip are decided by plan_frame; the others name a pass result.
enum class StepCondition : uint8_t {
  kRun,
  kSkip,
  kIfPass1Occluded,          // FrameFacts::pass1_occluded
  kIfPass2FoundVisible,      // pass1_occluded and FrameFacts::pass2_found_visible
};

struct StepPlan {
  StepCondition when = StepCondition::kSkip;
  std::string skip_reason;  // kSkip: why (a false condition's reason is step_runs')
};

// Results of passes that later steps' conditions read (set by the executor).
struct FrameFacts {
  bool pass1_occluded = false;       // instance_cull or cluster_cull occluded something
  bool pass2_found_visible = false;  // cluster_cull_post appended visible clusters
};

// What the plan is decided from besides the scene and settings.
struct FrameContext {
  bool previous_hzb = false;    // a previous-frame HZB of this resolution and instance count exists
  bool keep_history = false;    // this frame's HZB can be kept for a next frame (a history exists)
  bool has_next_frame = false;
  bool streamed = false;        // the frame runs with page streaming
  std::string no_stream_reason = "no stream budget";  // when !streamed
};

struct FramePlan {
  std::array<StepPlan, kFrameStepCount> steps;  // indexed by FrameStep
  bool occlusion = false;     // occlusion active (setting on and not a single convex object)
  bool previous_hzb = false;  // pass 1 tests against the previous frame's HZB
  bool streamed = false;
  const StepPlan& step(FrameStep s) const { return steps[size_t(s)]; }
};

FramePlan plan_frame(const RenderScene& scene, const RenderSettings& settings, const FrameContext& context);

// The one place a step's condition is evaluated: true when it runs; else *reason says why.
bool step_runs(const StepPlan& step, const FrameFacts& facts, std::string* reason);

struct PassStats {
  std::string name;
  double ms = 0;
  uint64_t instances_in = 0, instances_out = 0, nodes_visited = 0, groups_visited = 0,
           cluster_candidates = 0, clusters_occluded = 0, clusters_drawn = 0, triangles_drawn = 0,
           pixels_written = 0;
};

// The GPU rasterizers' split of a frame's clusters (spec/raster.md §13; the Vulkan executor
// counts it, FrameStats::raster_split).
struct RasterSplitStats {
  uint64_t sw_clusters = 0, hw_clusters = 0, sw_triangles = 0, hw_triangles = 0;
  // Of the compute path's (fan) triangles, those drawn tile by tile, and their tiles
  // (spec/raster.md §13.5).
  uint64_t sw_tiled_triangles = 0, sw_tiles = 0;
  void add(const RasterSplitStats& o) {
    sw_clusters += o.sw_clusters;
    hw_clusters += o.hw_clusters;
    sw_triangles += o.sw_triangles;
    hw_triangles += o.hw_triangles;
    sw_tiled_triangles += o.sw_tiled_triangles;
    sw_tiles += o.sw_tiles;
  }
};

// The virtual shadow maps' counters of a frame (spec/shadow.md §7).
struct ShadowFrameStats {
  uint64_t lights = 0, pages_marked = 0, pages_cached = 0, pages_drawn = 0, pages_dropped = 0, clusters_drawn = 0;
  friend bool operator==(const ShadowFrameStats&, const ShadowFrameStats&) = default;
};

struct FrameStats {
  std::vector<PassStats> passes;                                  // only passes that ran
  std::vector<std::pair<std::string, std::string>> skipped;       // (pass, reason)
  uint64_t instances = 0, clusters_drawn = 0, triangles_drawn = 0, pixels_covered = 0, pixels = 0;
  double total_ms = 0;
  bool streamed = false;        // the frame ran with streaming (pass "stream")
  StreamFrameStats stream;      // when streamed
  bool has_raster_split = false;  // the Vulkan executor's frames: clusters and triangles per raster path
  RasterSplitStats raster_split;
  bool has_shadow = false;      // shadow_draw ran
  ShadowFrameStats shadow;
  const PassStats* find(const std::string& name) const {
    for (const PassStats& p : passes)
      if (p.name == name) return &p;
    return nullptr;
  }
};

// What a step produced, returned by FrameExecutor::run; execute_frame_plan applies it.
struct StepResult {
  // instance_cull, cluster_cull: the pass occluded something (FrameFacts::pass1_occluded).
  bool occluded = false;
  // cluster_cull, cluster_cull_post: the visible clusters found, in draw order (appended to
  // Frame::visible; cluster_cull's are visible[0, pass1_visible)), the stream requests (scene
  // mesh ids) and the cut's coarser-than-ideal cluster count.
  std::vector<VisibleCluster> visible;
  std::vector<GroupRequest> requests;
  uint64_t clusters_coarser = 0;
  // shadow_draw: the shadow pages' counters.
  ShadowFrameStats shadow;
};

// What execute_frame_plan keeps between steps (besides the Frame it fills); executors read it.
struct FrameState {
  FrameFacts facts;
  std::vector<GroupRequest> requests;  // both cull passes' (stream_end hands them to the Streamer)
  uint64_t clusters_coarser = 0;
  // The executor's pass-1 HZB (step hzb) is the HZB of the complete frame: hzb ran and
  // raster_post did not run after it, so hzb_next may keep it instead of building another.
  bool hzb_is_complete = false;
};

// A backend's frame. execute_frame_plan calls run() once per step that runs, in FrameStep
// order, and times each call (host wall time; an executor that waits for its device per step
// therefore reports device time per pass). The executor only runs the step on its device and
// returns what it produced; it reads the frame's state (`state`, and the Frame it was made for:
// the visible list, visible[0, pass1_visible) drawn by pass 1) but never changes the
// bookkeeping. `stats` is the step's pass's slot: the executor adds its device counters
// (nodes, candidates, pixels written; a pass's steps share it; `name`, `ms`, clusters and
// triangles drawn are filled by execute_frame_plan). finish() runs after the last step and
// leaves the frame's visibility buffer in Frame::vis.
class FrameExecutor {
 public:
  virtual ~FrameExecutor() = default;
  virtual StepResult run(FrameStep step, const FrameState& state, PassStats* stats) = 0;
  virtual void finish() = 0;
};

// Runs `plan` on `executor` for `frame` (reset by begin_frame, frame.h) of `scene` and fills
// frame->stats (total_ms excluded: the caller's frame time): applies each step's result to the
// frame (visible list, pass-1 count, RENDER_TOO_MANY_VISIBLE_CLUSTERS beyond
// kMaxVisibleClusters), counts the drawn clusters and triangles of each raster step, and at
// hzb_next stores this frame's view and instance views in `history` (the executor stores the
// HZB). `streaming`, when the plan streams: its frame statistics go into the stats.
void execute_frame_plan(const FramePlan& plan, FrameExecutor& executor, const RenderScene& scene,
                        FrameHistory* history, const FrameStreaming* streaming, Frame* frame);

// Human-readable per-pass table and JSON (object) of one frame's statistics.
std::string frame_stats_table(const FrameStats& stats);
std::string frame_stats_json(const FrameStats& stats);
std::string stream_frame_stats_json(const StreamFrameStats& stats);

}  // namespace vgeo
