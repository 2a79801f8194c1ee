// Suite "backend": the frame pipeline on the CPU reference and on Vulkan (Mesa lavapipe by
// default), both traversals of the GPU cull (level by level, persistent threads), per pass,
// on the same scenes, side by side in one run (spec/raster.md §12). Every variant
// renders the scene's decoded memory form and keeps its own previous-frame history; the
// cluster sets must be equal to the CPU's (checked, reported).
#include <algorithm>
#include <map>

#include "bench_shapes.h"
#include "bench_suites.h"
#include "vgeo/core/progress.h"
#include "vgeo/cull/view.h"
#include "vgeo/dag/build.h"
#include "vgeo/gpu/gpu_frame.h"
#include "vgeo/render/frame.h"

namespace vgeo::bench {
namespace {

struct BackendVariant {
  const char* name;
  bool vulkan;
  GpuTraversal traversal;  // Vulkan only
};
constexpr BackendVariant kBackendVariants[] = {{"CPU reference", false, GpuTraversal::kLevel},
                                               {"Vulkan, level by level", true, GpuTraversal::kLevel},
                                               {"Vulkan, persistent threads", true, GpuTraversal::kPersistent}};
constexpr size_t kBackendVariantCount = 3;
// The occlusion suite's rows of spheres (neighbours nearly touch: rows hide rows), so the
// occlusion passes run and find work.
constexpr double kSpacing = 2.2;
// Untimed frames per variant before timing: pipelines compile on first use on lavapipe
// (40–80 ms each) and the history needs one frame.
constexpr int kWarmupFrames = 2;

struct BackendScene {
  uint32_t side, triangles, width, height;
};

RenderScene sphere_rows(const BackendScene& s, unsigned threads) {
  RenderScene scene;
  BuildOptions bo;
  bo.threads = threads;
  scene.meshes.push_back(build_dag(make_shape(Shape::kSphere, s.triangles, 9), bo, nullptr));
  scene.materials.push_back(Material{});
  for (uint32_t z = 0; z < s.side; ++z)
    for (uint32_t x = 0; x < s.side; ++x) {
      CullInstance in;
      in.mesh = 0;
      in.object_to_world.at(0, 3) = (double(x) - 0.5 * (s.side - 1)) * kSpacing;
      in.object_to_world.at(2, 3) = -double(z) * kSpacing;
      scene.instances.push_back(in);
    }
  analyze_render_scene(&scene);
  return scene;
}

std::vector<VisibleCluster> sorted(std::vector<VisibleCluster> v) {
  std::sort(v.begin(), v.end());
  return v;
}

}  // namespace

void run_backend_suite(const BenchConfig& cfg, SuiteReport& out) {
  out.ran = true;
  const int reps = cfg.repetitions(7);
  const std::vector<BackendScene> scenes =
      cfg.quick ? std::vector<BackendScene>{{4, 2000, 320, 180}}
                : std::vector<BackendScene>{{8, 12000, 640, 360}, {24, 12000, 1280, 720}};
  ThreadPool pool(cfg.threads);
  std::unique_ptr<GpuContext> gpu = create_gpu_context({});  // no device: the suite fails, others run
  out.inputs.push_back("device: " + gpu->device_name + " (validation off)");
  out.summary =
      "The frame pipeline (two-pass HZB occlusion with previous-frame history, then lit shading) in steady state on "
      "the CPU reference (render_frame, " + std::to_string(pool.size()) + " threads) and on the Vulkan executor "
      "(render_frame_vulkan: every pass on the device, one submit per pass) with each GPU traversal, rendered "
      "interleaved, " + std::to_string(reps) + " repetitions after " + std::to_string(kWarmupFrames) +
      " warm-up frames. Pass times are execute_frame_plan's wall time per step (for Vulkan: device time plus the "
      "submit, wait and small host copies); 'frame' is the frame's wall time. Medians [min, max].";

  nlohmann::json jscenes = nlohmann::json::array();
  Progress progress("bench backend", scenes.size() * size_t(reps) * kBackendVariantCount, cfg.progress);
  for (const BackendScene& bs : scenes) {
    const MemoryFormScene ms = make_memory_form_scene(sphere_rows(bs, cfg.threads));
    std::vector<GpuRendererPtr> renderers;
    for (const BackendVariant& v : kBackendVariants)
      renderers.push_back(v.vulkan ? create_gpu_renderer(*gpu, ms, v.traversal) : nullptr);
    Camera cam;
    cam.width = bs.width;
    cam.height = bs.height;
    cam.position = {0, 0.3, 4.0};
    look_at_orientation(cam.position, {0, 0.3, -double(bs.side) * kSpacing * 0.5}, {0, 1, 0}, &cam.orientation);
    const std::string scene_name = std::to_string(bs.side) + "x" + std::to_string(bs.side) + " spheres, " +
                                   std::to_string(cam.width) + "x" + std::to_string(cam.height);
    out.inputs.push_back(scene_name + ": " + std::to_string(bs.side * bs.side) + " instances of a " +
                         std::to_string(ms.scene.meshes[0].clusters.size()) + "-cluster sphere DAG (" +
                         std::to_string(bs.triangles) + " triangles, seed 9), spacing " + fmt(kSpacing) +
                         ", camera at eye level with the rows, tau = 1 px, HZB 4x4");

    std::vector<FrameHistory> history(kBackendVariantCount);
    std::vector<Frame> frames(kBackendVariantCount);
    const RenderSettings settings;
    auto render = [&](size_t v) {
      if (kBackendVariants[v].vulkan)
        render_frame_vulkan(*renderers[v], {ms.scene, cam, settings, pool, &history[v], true}, &frames[v]);
      else
        render_frame({ms.scene, cam, settings, pool, &history[v], true}, &frames[v]);
    };
    for (int w = 0; w < kWarmupFrames; ++w)
      for (size_t v = 0; v < kBackendVariantCount; ++v) render(v);
    std::map<std::string, std::vector<std::vector<double>>> pass_ms;  // pass → variant → samples (ms)
    std::vector<std::vector<double>> frame_ms(kBackendVariantCount);
    std::vector<bool> clusters_equal(kBackendVariantCount, true);
    time_interleaved(reps, kBackendVariantCount, [&](size_t v) {
      render(v);
      for (const PassStats& p : frames[v].stats.passes) {
        auto& per = pass_ms[p.name];
        per.resize(kBackendVariantCount);
        per[v].push_back(p.ms);
      }
      frame_ms[v].push_back(frames[v].stats.total_ms);
      progress.advance();
    });
    for (size_t v = 1; v < kBackendVariantCount; ++v)
      clusters_equal[v] = sorted(frames[v].visible) == sorted(frames[0].visible);

    Table t{"Per-pass time, " + scene_name, {"pass"}, {}};
    for (const BackendVariant& v : kBackendVariants) t.columns.push_back(v.name);
    t.columns.push_back("level / CPU");
    t.columns.push_back("persistent / level");
    nlohmann::json jpasses = nlohmann::json::object();
    auto add_row = [&](const std::string& name, const std::vector<std::vector<double>>& per) {
      std::vector<std::string> row{name};
      std::vector<double> med(kBackendVariantCount, 0);
      nlohmann::json jp = nlohmann::json::object();
      for (size_t v = 0; v < kBackendVariantCount; ++v) {
        if (v < per.size() && !per[v].empty()) {
          Stats s = summarize(per[v]);
          med[v] = s.median;
          row.push_back(fmt_stats_time({s.median * 1e-3, s.min * 1e-3, s.max * 1e-3, 0, 0, s.count}));
          jp[kBackendVariants[v].name] = to_json(s);
        } else {
          row.push_back("-");
        }
      }
      row.push_back(med[0] > 0 && med[1] > 0 ? fmt(med[1] / med[0]) + "x" : "-");
      row.push_back(med[1] > 0 && med[2] > 0 ? fmt(med[2] / med[1]) + "x" : "-");
      t.rows.push_back(row);
      jpasses[name] = jp;
    };
    for (size_t p = 0; p < kFramePassCount; ++p) {
      const std::string name = frame_pass_name(FramePass(p));
      if (pass_ms.count(name)) add_row(name, pass_ms[name]);
    }
    add_row("frame", frame_ms);
    out.tables.push_back(t);
    std::string equal;
    for (size_t v = 1; v < kBackendVariantCount; ++v)
      equal += std::string(equal.empty() ? "" : "; ") + kBackendVariants[v].name + ": " +
               (clusters_equal[v] ? "equal" : "DIFFERENT");
    out.notes.push_back(scene_name + ": cluster sets vs the CPU reference: " + equal + " (" +
                        std::to_string(frames[0].visible.size()) + " clusters drawn, " +
                        std::to_string(frames[0].stats.triangles_drawn) + " triangles)");
    jscenes.push_back({{"scene", scene_name},
                       {"passes_ms", jpasses},
                       {"clusters_equal", {clusters_equal[1], clusters_equal[2]}},
                       {"clusters_drawn", frames[0].visible.size()}});
  }
  out.data["scenes"] = jscenes;
}

}  // namespace vgeo::bench
