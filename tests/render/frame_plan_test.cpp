// The frame plan (spec/scene.md §Frame pipeline): decided before any pass runs, result-dependent
// conditions evaluated by execute_frame_plan, statistics assembled the same way for any executor.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "render/render_helpers.h"
#include <algorithm>

#include "vgeo/render/frame.h"
#include "vgeo/render/frame_plan.h"

namespace vgeo {
namespace {

// An executor that runs nothing: records the steps it is asked for, returns the given results
// (pass 1 occluded something; pass 2 found one cluster) and counts one visited node per step
// (so a pass's counters show how many of its steps ran); finish() covers 7 pixels.
struct RecordingExecutor final : FrameExecutor {
  FrameFacts report;
  Frame* frame = nullptr;
  std::vector<FrameStep> steps;
  StepResult run(FrameStep step, const FrameState&, PassStats* stats) override {
    steps.push_back(step);
    stats->nodes_visited += 1;
    StepResult r;
    if (step == FrameStep::kClusterCull) r.occluded = report.pass1_occluded;
    if (step == FrameStep::kClusterCullPost && report.pass2_found_visible) r.visible.push_back({0, 0});
    return r;
  }
  void finish() override { std::fill(frame->vis.keys.begin(), frame->vis.keys.begin() + 7, 1); }
};

std::string reason_of(const FrameStats& s, const std::string& pass) {
  for (const auto& [name, reason] : s.skipped)
    if (name == pass) return reason;
  return "";
}

std::vector<std::string> pass_names(const FrameStats& s) {
  std::vector<std::string> out;
  for (const PassStats& p : s.passes) out.push_back(p.name);
  return out;
}

TEST(FramePlan, EveryStepIsDecidedOrConditionalBeforeAnyPassRuns) {
  RenderScene scene;  // two instances: occlusion is not ruled out by a single convex object
  scene.instances.resize(2);
  RenderSettings settings;
  FrameContext context;
  context.previous_hzb = context.keep_history = context.has_next_frame = true;
  FramePlan p = plan_frame(scene, settings, context);
  EXPECT_TRUE(p.occlusion);
  EXPECT_TRUE(p.previous_hzb);
  EXPECT_EQ(p.step(FrameStep::kHzb).when, StepCondition::kIfPass1Occluded);
  EXPECT_EQ(p.step(FrameStep::kClusterCullPost).when, StepCondition::kIfPass1Occluded);
  EXPECT_EQ(p.step(FrameStep::kRasterPost).when, StepCondition::kIfPass2FoundVisible);
  EXPECT_EQ(p.step(FrameStep::kHzbNext).when, StepCondition::kRun);
  EXPECT_EQ(p.step(FrameStep::kStreamBegin).when, StepCondition::kSkip);
  EXPECT_EQ(p.step(FrameStep::kStreamBegin).skip_reason, "no stream budget");
  EXPECT_EQ(p.step(FrameStep::kOverdraw).skip_reason, "overdraw view not requested");

  settings.occlusion = false;
  p = plan_frame(scene, settings, context);
  for (FrameStep s : {FrameStep::kHzb, FrameStep::kInstanceCullPost, FrameStep::kClusterCullPost,
                      FrameStep::kRasterPost, FrameStep::kHzbNext}) {
    EXPECT_EQ(p.step(s).when, StepCondition::kSkip) << frame_step_name(s);
    EXPECT_EQ(p.step(s).skip_reason, "occlusion off") << frame_step_name(s);
  }
  settings.occlusion = true;
  scene.single_convex_object = true;
  EXPECT_EQ(plan_frame(scene, settings, context).step(FrameStep::kHzb).skip_reason, "single convex object");
  scene.single_convex_object = false;
  context.previous_hzb = false;
  p = plan_frame(scene, settings, context);
  EXPECT_EQ(p.step(FrameStep::kClusterCullPost).skip_reason, "no previous-frame HZB");
  EXPECT_EQ(p.step(FrameStep::kHzbNext).when, StepCondition::kRun);
  context.has_next_frame = false;
  EXPECT_EQ(plan_frame(scene, settings, context).step(FrameStep::kHzbNext).skip_reason, "no next frame");
  context.streamed = true;
  settings.shade = false;
  p = plan_frame(scene, settings, context);
  EXPECT_EQ(p.step(FrameStep::kStreamEnd).when, StepCondition::kRun);
  EXPECT_EQ(p.step(FrameStep::kShade).skip_reason, "shading not requested");
  EXPECT_EQ(p.step(FrameStep::kOverdraw).skip_reason, "shading not requested");
}

TEST(FramePlan, ExecutorRunsExactlyThePlannedStepsInOrderAndStatisticsFollowTheReportOrder) {
  RenderScene scene;
  scene.instances.resize(3);
  RenderSettings settings;
  FrameContext context;
  context.previous_hzb = context.keep_history = context.has_next_frame = context.streamed = true;
  const FramePlan plan = plan_frame(scene, settings, context);
  struct Case {
    bool occluded, found;
    std::vector<FrameStep> steps;
    std::string raster_post_reason;
  };
  using S = FrameStep;
  const std::vector<Case> cases = {
      {false, false, {S::kStreamBegin, S::kInstanceCull, S::kClusterCull, S::kStreamBind, S::kRaster, S::kHzbNext,
                      S::kStreamEnd, S::kShade}, "pass 1 occluded nothing"},
      {true, false, {S::kStreamBegin, S::kInstanceCull, S::kClusterCull, S::kStreamBind, S::kRaster, S::kHzb,
                     S::kInstanceCullPost, S::kClusterCullPost, S::kHzbNext, S::kStreamEnd, S::kShade},
       "pass 2 found nothing newly visible"},
      {true, true, {S::kStreamBegin, S::kInstanceCull, S::kClusterCull, S::kStreamBind, S::kRaster, S::kHzb,
                    S::kInstanceCullPost, S::kClusterCullPost, S::kStreamBindPost, S::kRasterPost, S::kHzbNext,
                    S::kStreamEnd, S::kShade}, ""},
  };
  scene.meshes.resize(1);
  scene.meshes[0].clusters.resize(1);
  scene.meshes[0].clusters[0].triangle_count = 5;
  for (const Case& c : cases) {
    RecordingExecutor ex;
    ex.report = {c.occluded, c.found};
    Frame frame;
    frame.vis.resize(10, 10);
    ex.frame = &frame;
    execute_frame_plan(plan, ex, scene, nullptr, nullptr, &frame);
    const FrameStats& stats = frame.stats;
    EXPECT_EQ(ex.steps, c.steps) << c.occluded << c.found;
    EXPECT_EQ(reason_of(stats, "raster_post"), c.raster_post_reason);
    EXPECT_EQ(reason_of(stats, "overdraw"), "overdraw view not requested");
    // Passes that ran, in report order; the stream pass sums its steps.
    std::vector<std::string> names = pass_names(stats);
    for (size_t i = 1; i < names.size(); ++i) {
      size_t a = 0, b = 0;
      for (size_t p = 0; p < kFramePassCount; ++p) {
        if (names[i - 1] == frame_pass_name(FramePass(p))) a = p;
        if (names[i] == frame_pass_name(FramePass(p))) b = p;
      }
      EXPECT_LT(a, b);
    }
    EXPECT_EQ(stats.passes.size() + stats.skipped.size(), kFramePassCount);
    ASSERT_NE(stats.find("stream"), nullptr);
    EXPECT_EQ(stats.find("stream")->nodes_visited, c.found ? 4u : 3u);
    // The plan layer applies the results: pass 2's cluster is appended after pass 1's (none)
    // and counted by raster_post with its triangles.
    EXPECT_EQ(frame.visible.size(), c.found ? 1u : 0u);
    EXPECT_EQ(frame.pass1_visible, 0u);
    EXPECT_EQ(stats.clusters_drawn, c.found ? 1u : 0u);
    EXPECT_EQ(stats.triangles_drawn, c.found ? 5u : 0u);
    EXPECT_EQ(stats.instances, 3u);
    EXPECT_EQ(stats.pixels, 100u);
    EXPECT_EQ(stats.pixels_covered, 7u);
    EXPECT_TRUE(stats.streamed);
  }
}

TEST(FramePlan, CpuExecutorReportsEveryPassAsRunOrSkippedWithTheConditionsReason) {
  RenderScene scene = test::make_row_scene(1.0, 0.0, 6);
  ThreadPool pool(2);
  FrameHistory history;
  RenderSettings settings;
  bool saw_pass2 = false;
  for (int f = 0; f < 6; ++f) {
    double x = -1.5 + 3.0 * f / 5;
    Camera cam = test::look_camera({x, 1.5, 6}, {0, 1.2, -10});
    const FrameInputs in{scene, cam, settings, pool, &history, f < 5};
    const FramePlan plan = plan_frame(scene, settings, frame_context(in));
    Frame frame;
    render_planned_frame(plan, in, &frame);
    EXPECT_EQ(frame.stats.passes.size() + frame.stats.skipped.size(), kFramePassCount) << f;
    for (const auto& [name, reason] : frame.stats.skipped) EXPECT_FALSE(reason.empty()) << name;
    saw_pass2 |= frame.stats.find("cluster_cull_post") != nullptr;
    EXPECT_EQ(frame.stats.find("hzb_next") != nullptr, f < 5) << f;
  }
  EXPECT_TRUE(saw_pass2);
}

TEST(FramePlan, APlanForStreamingIsRefusedWithoutAStreamingState) {
  RenderScene scene = test::make_row_scene();
  FrameContext context;
  context.streamed = true;
  const FramePlan plan = plan_frame(scene, {}, context);
  ThreadPool pool(1);
  Frame frame;
  try {
    render_planned_frame(plan, {scene, test::look_camera({0, 2, 6}, {0, 1, 0}), {}, pool}, &frame);
    FAIL() << "no error";
  } catch (const VgeoError& e) {
    EXPECT_EQ(e.error().code, "RENDER_PLAN_MISMATCH");
  }
}

}  // namespace
}  // namespace vgeo
