// The frame plan (spec/scene.md §Frame pipeline): decided before any pass runs, result-dependent
// conditions evaluated by execute_frame_plan, statistics assembled the same way for any executor.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "render/render_helpers.h"
#include "vgeo/render/frame_plan.h"

namespace vgeo {
namespace {

// An executor that runs nothing: records the steps it is asked for, reports the given facts
// and counts one drawn cluster per step (so a pass's counters show how many of its steps ran).
struct RecordingExecutor final : FrameExecutor {
  FrameFacts report;
  std::vector<FrameStep> steps;
  void run(FrameStep step, PassStats* stats, FrameFacts* facts) override {
    steps.push_back(step);
    stats->clusters_drawn += 1;
    if (step == FrameStep::kClusterCull) facts->pass1_occluded = report.pass1_occluded;
    if (step == FrameStep::kClusterCullPost) facts->pass2_found_visible = report.pass2_found_visible;
  }
  void finish(FrameStats* stats) override { stats->pixels_covered = 7; }
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
  for (const Case& c : cases) {
    RecordingExecutor ex;
    ex.report = {c.occluded, c.found};
    FrameStats stats;
    execute_frame_plan(plan, ex, 3, 100, &stats);
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
    EXPECT_EQ(stats.find("stream")->clusters_drawn, c.found ? 4u : 3u);
    EXPECT_EQ(stats.clusters_drawn, c.steps.size());
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
    const FramePlan plan = plan_frame(scene, settings, frame_context(scene, cam, &history, f < 5, nullptr));
    Frame frame;
    render_planned_frame(plan, scene, cam, settings, pool, &history, &frame, nullptr);
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
    render_planned_frame(plan, scene, test::look_camera({0, 2, 6}, {0, 1, 0}), {}, pool, nullptr, &frame, nullptr);
    FAIL() << "no error";
  } catch (const VgeoError& e) {
    EXPECT_EQ(e.error().code, "RENDER_PLAN_MISMATCH");
  }
}

}  // namespace
}  // namespace vgeo
