// The frame plan (frame_plan.h). Based on: Karis et al., "Nanite: A Deep Dive", SIGGRAPH 2021,
// §"Two-Pass Occlusion Culling" (pass 1 against the previous frame's HZB; pass 2 retests what
// pass 1 occluded against the new one) and §"Culling Dataflow".
#include "vgeo/render/frame_plan.h"

#include <chrono>
#include <cstdio>
#include <nlohmann/json.hpp>

#include "vgeo/render/frame.h"

namespace vgeo {

namespace {

// Reasons of the result-dependent conditions (step_runs).
constexpr const char* kPass1OccludedNothing = "pass 1 occluded nothing";
constexpr const char* kPass2FoundNothing = "pass 2 found nothing newly visible";
constexpr const char* kNoShading = "shading not requested";

constexpr std::array<FramePass, kFrameStepCount> kStepPass = {
    FramePass::kStream,           FramePass::kInstanceCull, FramePass::kClusterCull,     FramePass::kStream,
    FramePass::kRaster,           FramePass::kHzb,          FramePass::kInstanceCullPost, FramePass::kClusterCullPost,
    FramePass::kStream,           FramePass::kRasterPost,   FramePass::kHzbNext,          FramePass::kStream,
    FramePass::kShadowMark,       FramePass::kShadowDraw,   FramePass::kOverdraw,         FramePass::kShade,
};

StepPlan run() { return {StepCondition::kRun, ""}; }
StepPlan skip(const std::string& reason) { return {StepCondition::kSkip, reason}; }

// spec/shadow.md §1: the shadow steps run only for a shadowing light whose shadows are shown,
// on a shaded frame (its shadow term) or on any frame whose shadow pages outlive it (a history
// keeps the page cache, a streamer takes the shadow views' requests), so that a shaded frame
// of a sequence is the same whichever frames before it were shaded.
StepPlan shadow_steps(const RenderScene& scene, const RenderSettings& settings, const FrameContext& context) {
  if (!has_shadowing_light(scene.lights)) return skip("no shadowing light");
  if (!settings.shade && !context.keep_history && !context.streamed) return skip(kNoShading);
  if (settings.view != ShadeView::kLit) return skip("shadows not shown by this view");
  return run();
}

}  // namespace

const char* frame_pass_name(FramePass pass) {
  static constexpr const char* kNames[kFramePassCount] = {
      "instance_cull", "cluster_cull", "raster",   "hzb",      "instance_cull_post", "cluster_cull_post",
      "raster_post",   "hzb_next",     "stream",   "shadow_mark", "shadow_draw", "overdraw", "shade"};
  return kNames[size_t(pass)];
}

const char* frame_step_name(FrameStep step) {
  static constexpr const char* kNames[kFrameStepCount] = {
      "stream_begin",       "instance_cull",     "cluster_cull",     "stream_bind", "raster",
      "hzb",                "instance_cull_post", "cluster_cull_post", "stream_bind_post", "raster_post",
      "hzb_next",           "stream_end",         "shadow_mark",       "shadow_draw", "overdraw", "shade"};
  return kNames[size_t(step)];
}

FramePass frame_step_pass(FrameStep step) { return kStepPass[size_t(step)]; }

FramePlan plan_frame(const RenderScene& scene, const RenderSettings& settings, const FrameContext& context) {
  FramePlan plan;
  plan.occlusion = settings.occlusion && !scene.single_convex_object;
  plan.previous_hzb = plan.occlusion && context.previous_hzb;
  plan.streamed = context.streamed;
  auto set = [&](FrameStep s, StepPlan p) { plan.steps[size_t(s)] = std::move(p); };
  const std::string no_occlusion = !settings.occlusion ? "occlusion off" : "single convex object";
  // Pass 2 needs something pass 1 occluded, which needs a previous-frame HZB to test against.
  auto pass2 = [&](StepCondition when) {
    if (!plan.occlusion) return skip(no_occlusion);
    if (!plan.previous_hzb) return skip("no previous-frame HZB");
    return StepPlan{when, ""};
  };
  const StepPlan streamed = context.streamed ? run() : skip(context.no_stream_reason);
  set(FrameStep::kStreamBegin, streamed);
  set(FrameStep::kInstanceCull, run());
  set(FrameStep::kClusterCull, run());
  set(FrameStep::kStreamBind, streamed);
  set(FrameStep::kRaster, run());
  set(FrameStep::kHzb, pass2(StepCondition::kIfPass1Occluded));
  set(FrameStep::kInstanceCullPost, pass2(StepCondition::kIfPass1Occluded));
  set(FrameStep::kClusterCullPost, pass2(StepCondition::kIfPass1Occluded));
  set(FrameStep::kStreamBindPost, context.streamed ? pass2(StepCondition::kIfPass2FoundVisible) : streamed);
  set(FrameStep::kRasterPost, pass2(StepCondition::kIfPass2FoundVisible));
  if (!plan.occlusion) set(FrameStep::kHzbNext, skip(no_occlusion));
  else if (!context.keep_history || !context.has_next_frame) set(FrameStep::kHzbNext, skip("no next frame"));
  else set(FrameStep::kHzbNext, run());
  set(FrameStep::kStreamEnd, streamed);
  const StepPlan shadows = shadow_steps(scene, settings, context);
  set(FrameStep::kShadowMark, shadows);
  set(FrameStep::kShadowDraw, shadows);
  if (!settings.shade) set(FrameStep::kOverdraw, skip(kNoShading));
  else if (settings.view != ShadeView::kOverdraw) set(FrameStep::kOverdraw, skip("overdraw view not requested"));
  else set(FrameStep::kOverdraw, run());
  set(FrameStep::kShade, settings.shade ? run() : skip(kNoShading));
  return plan;
}

bool step_runs(const StepPlan& step, const FrameFacts& facts, std::string* reason) {
  switch (step.when) {
    case StepCondition::kRun:
      return true;
    case StepCondition::kSkip:
      *reason = step.skip_reason;
      return false;
    case StepCondition::kIfPass1Occluded:
      if (facts.pass1_occluded) return true;
      *reason = kPass1OccludedNothing;
      return false;
    case StepCondition::kIfPass2FoundVisible:
      if (facts.pass1_occluded && facts.pass2_found_visible) return true;
      *reason = facts.pass1_occluded ? kPass2FoundNothing : kPass1OccludedNothing;
      return false;
  }
  return false;
}

namespace {

// Applies what `step` produced to the frame and the state (the one place the frame's
// bookkeeping is written, for every executor).
void apply_step_result(FrameStep step, StepResult&& r, const RenderScene& scene, FrameHistory* history,
                       FrameState* state, Frame* frame, PassStats* pass) {
  switch (step) {
    case FrameStep::kInstanceCull:
      state->facts.pass1_occluded |= r.occluded;
      break;
    case FrameStep::kClusterCull:
      check_visible_count(r.visible.size());
      frame->visible = std::move(r.visible);
      frame->pass1_visible = uint32_t(frame->visible.size());
      state->requests = std::move(r.requests);
      state->clusters_coarser = r.clusters_coarser;
      state->facts.pass1_occluded |= r.occluded;
      break;
    case FrameStep::kClusterCullPost:
      check_visible_count(frame->visible.size() + r.visible.size());
      state->facts.pass2_found_visible = !r.visible.empty();
      frame->visible.insert(frame->visible.end(), r.visible.begin(), r.visible.end());
      state->requests.insert(state->requests.end(), r.requests.begin(), r.requests.end());
      state->clusters_coarser += r.clusters_coarser;
      break;
    case FrameStep::kRaster:
    case FrameStep::kRasterPost: {
      const size_t first = step == FrameStep::kRaster ? 0 : frame->pass1_visible;
      pass->clusters_drawn += frame->visible.size() - first;
      for (size_t i = first; i < frame->visible.size(); ++i) {
        const VisibleCluster& v = frame->visible[i];
        pass->triangles_drawn += scene.meshes[scene.instances[v.instance].mesh].clusters[v.cluster].triangle_count;
      }
      if (step == FrameStep::kRasterPost) state->hzb_is_complete = false;  // drawn after the pass-1 HZB
      break;
    }
    case FrameStep::kHzb:
      state->hzb_is_complete = true;
      break;
    case FrameStep::kShadowDraw:
      frame->stats.has_shadow = true;
      frame->stats.shadow = r.shadow;
      break;
    case FrameStep::kHzbNext:
      // The executor stored the HZB; the rest of the history is the frame's.
      if (history) {
        history->view = frame->view;
        history->instance_views = frame->instance_views;
        history->valid = true;
      }
      break;
    default:
      break;
  }
}

}  // namespace

void execute_frame_plan(const FramePlan& plan, FrameExecutor& executor, const RenderScene& scene,
                        FrameHistory* history, const FrameStreaming* streaming, Frame* frame) {
  FrameStats* stats = &frame->stats;
  *stats = {};
  std::array<PassStats, kFramePassCount> pass{};
  std::array<bool, kFramePassCount> ran{};
  std::array<std::string, kFramePassCount> reason;
  FrameState state;
  for (size_t s = 0; s < kFrameStepCount; ++s) {
    const size_t p = size_t(kStepPass[s]);
    std::string why;
    if (!step_runs(plan.steps[s], state.facts, &why)) {
      if (reason[p].empty()) reason[p] = why;
      continue;
    }
    const auto t0 = std::chrono::steady_clock::now();
    StepResult result = executor.run(FrameStep(s), state, &pass[p]);
    pass[p].ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    ran[p] = true;
    apply_step_result(FrameStep(s), std::move(result), scene, history, &state, frame, &pass[p]);
  }
  for (size_t p = 0; p < kFramePassCount; ++p) {
    if (ran[p]) {
      pass[p].name = frame_pass_name(FramePass(p));
      stats->clusters_drawn += pass[p].clusters_drawn;
      stats->triangles_drawn += pass[p].triangles_drawn;
      stats->passes.push_back(std::move(pass[p]));
    } else {
      stats->skipped.push_back({frame_pass_name(FramePass(p)), reason[p]});
    }
  }
  stats->instances = scene.instances.size();
  stats->pixels = uint64_t(frame->vis.width) * frame->vis.height;
  stats->streamed = plan.streamed;
  executor.finish();
  for (uint64_t k : frame->vis.keys) stats->pixels_covered += k != 0;
  if (streaming) stats->stream = streaming->stats;
}

std::string frame_stats_table(const FrameStats& s) {
  std::string out;
  char line[512];
  std::snprintf(line, sizeof line, "%-19s %9s %9s %9s %9s %10s %9s %9s %11s %11s\n", "pass", "ms", "inst_in",
                "inst_out", "nodes", "candidates", "occluded", "clusters", "triangles", "pixels");
  out += line;
  for (const PassStats& p : s.passes) {
    std::snprintf(line, sizeof line, "%-19s %9.3f %9llu %9llu %9llu %10llu %9llu %9llu %11llu %11llu\n",
                  p.name.c_str(), p.ms, (unsigned long long)p.instances_in, (unsigned long long)p.instances_out,
                  (unsigned long long)p.nodes_visited, (unsigned long long)p.cluster_candidates,
                  (unsigned long long)p.clusters_occluded, (unsigned long long)p.clusters_drawn,
                  (unsigned long long)p.triangles_drawn, (unsigned long long)p.pixels_written);
    out += line;
  }
  for (const auto& [name, reason] : s.skipped) out += "(skipped) " + name + ": " + reason + "\n";
  if (s.has_shadow) {
    std::snprintf(line, sizeof line,
                  "shadow: %llu lights, %llu pages marked, %llu cached, %llu drawn, %llu dropped, %llu cluster-page draws\n",
                  (unsigned long long)s.shadow.lights, (unsigned long long)s.shadow.pages_marked,
                  (unsigned long long)s.shadow.pages_cached, (unsigned long long)s.shadow.pages_drawn,
                  (unsigned long long)s.shadow.pages_dropped, (unsigned long long)s.shadow.clusters_drawn);
    out += line;
  }
  std::snprintf(line, sizeof line,
                "frame: %.3f ms, %llu clusters, %llu triangles drawn, %llu of %llu pixels covered "
                "(%.2f triangles/pixel)\n",
                s.total_ms, (unsigned long long)s.clusters_drawn, (unsigned long long)s.triangles_drawn,
                (unsigned long long)s.pixels_covered, (unsigned long long)s.pixels,
                s.pixels ? double(s.triangles_drawn) / double(s.pixels) : 0.0);
  out += line;
  return out;
}

std::string stream_frame_stats_json(const StreamFrameStats& s) {
  nlohmann::ordered_json j;
  j["frame"] = s.frame;
  j["active"] = s.active;
  j["pages_requested"] = s.pages_requested;
  j["pages_missing"] = s.pages_missing;
  j["requested_bytes"] = s.requested_bytes;
  j["required_bytes"] = s.required_bytes;
  j["pages_issued"] = s.pages_issued;
  j["pages_loaded"] = s.pages_loaded;
  j["pages_evicted"] = s.pages_evicted;
  j["bytes_read"] = s.bytes_read;
  j["resident_bytes"] = s.resident_bytes;
  j["reserved_bytes"] = s.reserved_bytes;
  j["resident_pages"] = s.resident_pages;
  j["read_failures"] = s.read_failures;
  j["checksum_failures"] = s.checksum_failures;
  j["decode_failures"] = s.decode_failures;
  j["pages_marked_bad"] = s.pages_marked_bad;
  j["clusters_drawn"] = s.clusters_drawn;
  j["clusters_coarser"] = s.clusters_coarser;
  j["cut_is_ideal"] = s.cut_is_ideal;
  return j.dump();
}

std::string frame_stats_json(const FrameStats& s) {
  nlohmann::ordered_json j;
  j["total_ms"] = s.total_ms;
  j["instances"] = s.instances;
  j["clusters_drawn"] = s.clusters_drawn;
  j["triangles_drawn"] = s.triangles_drawn;
  j["pixels_covered"] = s.pixels_covered;
  j["pixels"] = s.pixels;
  j["passes"] = nlohmann::ordered_json::array();
  for (const PassStats& p : s.passes) {
    nlohmann::ordered_json q;
    q["name"] = p.name;
    q["ms"] = p.ms;
    q["instances_in"] = p.instances_in;
    q["instances_out"] = p.instances_out;
    q["nodes_visited"] = p.nodes_visited;
    q["groups_visited"] = p.groups_visited;
    q["cluster_candidates"] = p.cluster_candidates;
    q["clusters_occluded"] = p.clusters_occluded;
    q["clusters_drawn"] = p.clusters_drawn;
    q["triangles_drawn"] = p.triangles_drawn;
    q["pixels_written"] = p.pixels_written;
    j["passes"].push_back(q);
  }
  j["skipped"] = nlohmann::ordered_json::array();
  for (const auto& [name, reason] : s.skipped) j["skipped"].push_back({{"name", name}, {"reason", reason}});
  if (s.streamed) j["stream"] = nlohmann::ordered_json::parse(stream_frame_stats_json(s.stream));
  if (s.has_shadow)
    j["shadow"] = {{"lights", s.shadow.lights},           {"pages_marked", s.shadow.pages_marked},
                   {"pages_cached", s.shadow.pages_cached}, {"pages_drawn", s.shadow.pages_drawn},
                   {"pages_dropped", s.shadow.pages_dropped}, {"clusters_drawn", s.shadow.clusters_drawn}};
  if (s.has_raster_split)
    j["raster_split"] = {{"sw_clusters", s.raster_split.sw_clusters},
                         {"sw_triangles", s.raster_split.sw_triangles},
                         {"hw_clusters", s.raster_split.hw_clusters},
                         {"hw_triangles", s.raster_split.hw_triangles},
                         {"sw_tiled_triangles", s.raster_split.sw_tiled_triangles},
                         {"sw_tiles", s.raster_split.sw_tiles}};
  return j.dump();
}

}  // namespace vgeo
