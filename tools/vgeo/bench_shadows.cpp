// Suite "shadows": virtual shadow maps (spec/shadow.md) on the CPU reference: pages marked /
// drawn / cached per frame and the shadow passes' time against the number of lights and the
// screen resolution, a first (uncached) frame against a steady (cached) one, and the frame
// without any shadowing light (the shadow steps skipped: today's frame).
#include <cmath>

#include "bench_render.h"
#include "bench_shapes.h"
#include "bench_suites.h"
#include "vgeo/core/progress.h"
#include "vgeo/dag/build.h"
#include "vgeo/render/frame.h"

namespace vgeo::bench {
namespace {

// Sphere grid spacing: neighbours nearly touch, so their shadows fall on each other and the ground.
constexpr double kSpacing = 2.5;
// Light sets, each adding one light type to the previous one.
constexpr size_t kLightSets = 4;
const char* const kLightSetNames[kLightSets] = {"none", "directional", "+ spot", "+ point"};

std::vector<Light> light_set(size_t n) {
  std::vector<Light> out;
  if (n >= 1) {
    Light d;
    const double n = std::sqrt(0.4 * 0.4 + 0.8 * 0.8 + 0.45 * 0.45);
    d.direction = {-0.4 / n, -0.8 / n, -0.45 / n};
    out.push_back(d);
  }
  if (n >= 2) {
    Light s;
    s.type = LightType::kSpot;
    s.position = {3, 8, 3};
    s.direction = {0, -1, 0};
    s.cone_radians = 1.4;
    out.push_back(s);
  }
  if (n >= 3) {
    Light p;
    p.type = LightType::kPoint;
    p.position = {-2, 3, -4};
    out.push_back(p);
  }
  return out;
}

}  // namespace

void run_shadows_suite(const BenchConfig& cfg, SuiteReport& out) {
  out.ran = true;
  const uint32_t side = cfg.quick ? 3 : 6, tris = cfg.quick ? 3000 : 12000;
  const int reps = cfg.repetitions(5);
  ThreadPool pool(cfg.threads);
  RenderScene scene;
  BuildOptions bo;
  bo.threads = cfg.threads;
  scene.meshes.push_back(build_dag(make_shape(Shape::kSphere, tris, 9), bo, nullptr));
  scene.meshes.push_back(build_dag(make_shape(Shape::kTerrain, tris, 3), bo, nullptr));
  scene.materials.push_back(Material{});
  CullInstance ground;
  ground.mesh = 1;
  ground.object_to_world.at(0, 0) = ground.object_to_world.at(2, 2) = kSpacing * side;
  ground.object_to_world.at(2, 3) = -kSpacing * side * 0.5;
  scene.instances.push_back(ground);
  for (uint32_t z = 0; z < side; ++z)
    for (uint32_t x = 0; x < side; ++x) {
      CullInstance in;
      in.object_to_world.at(0, 3) = (double(x) - 0.5 * (side - 1)) * kSpacing;
      in.object_to_world.at(1, 3) = 1.2;
      in.object_to_world.at(2, 3) = -double(z) * kSpacing;
      scene.instances.push_back(in);
    }
  analyze_render_scene(&scene);
  const uint32_t resolutions[2][2] = {{320, 180}, {cfg.quick ? 640u : 1280u, cfg.quick ? 360u : 720u}};
  out.inputs.push_back(std::to_string(side) + "x" + std::to_string(side) + " spheres (" + std::to_string(tris) +
                       " triangles, seed 9) on a terrain (seed 3), camera above the front row, tau = 1 px");
  out.summary =
      "CPU reference frame with 0..3 shadowing lights (directional, + spot, + point) at two resolutions. 'first' is a "
      "frame with an empty shadow cache (every needed page drawn); 'steady' the same camera's next frame (every page "
      "cached). Medians of " + std::to_string(reps) + " repetitions, " + std::to_string(pool.size()) +
      " threads; times are the passes' wall times (shadow_mark, shadow_draw) and the whole frame's.";
  Table t{"Shadow pages and time", {"lights", "resolution", "frame", "pages marked", "pages drawn", "pages cached",
                                    "cluster-page draws", "shadow_mark", "shadow_draw", "frame wall"}, {}};
  nlohmann::json rows = nlohmann::json::array();
  Progress progress("bench shadows", kLightSets * 2 * size_t(reps), cfg.progress);
  for (size_t ls = 0; ls < kLightSets; ++ls) {
    scene.lights = light_set(ls);
    for (const auto& res : resolutions) {
      Camera cam;
      cam.width = res[0];
      cam.height = res[1];
      cam.position = {0, 4, 5};
      look_at_orientation(cam.position, {0, 0.5, -kSpacing * side * 0.5}, {0, 1, 0}, &cam.orientation);
      std::vector<double> mark[2], draw[2], wall[2];
      Frame frames[2];
      for (int r = 0; r < reps; ++r) {
        FrameHistory history;  // empty: the first frame draws every needed page
        for (int k = 0; k < 2; ++k) {
          RenderSettings s;
          const double t0 = now_seconds();
          render_frame({scene, cam, s, pool, &history, true}, &frames[k]);
          wall[k].push_back(now_seconds() - t0);
          mark[k].push_back(passes_ms(frames[k].stats, {"shadow_mark"}));
          draw[k].push_back(passes_ms(frames[k].stats, {"shadow_draw"}));
        }
        progress.advance();
      }
      for (int k = 0; k < 2; ++k) {
        const ShadowFrameStats& sh = frames[k].stats.shadow;
        const std::string resolution = std::to_string(res[0]) + "x" + std::to_string(res[1]);
        Stats m = summarize(mark[k]), d = summarize(draw[k]), w = summarize(wall[k]);
        t.rows.push_back({kLightSetNames[ls], resolution, k ? "steady" : "first", std::to_string(sh.pages_marked),
                          std::to_string(sh.pages_drawn), std::to_string(sh.pages_cached), std::to_string(sh.clusters_drawn),
                          fmt_time(m.median * 1e-3), fmt_time(d.median * 1e-3), fmt_stats_time(w)});
        rows.push_back({{"lights", kLightSetNames[ls]},
                        {"resolution", resolution},
                        {"frame", k ? "steady" : "first"},
                        {"pages_marked", sh.pages_marked},
                        {"pages_drawn", sh.pages_drawn},
                        {"pages_cached", sh.pages_cached},
                        {"pages_dropped", sh.pages_dropped},
                        {"cluster_page_draws", sh.clusters_drawn},
                        {"shadow_mark_ms", to_json(m)},
                        {"shadow_draw_ms", to_json(d)},
                        {"frame_wall_seconds", to_json(w)}});
      }
    }
  }
  out.tables.push_back(t);
  out.data["rows"] = rows;
  out.notes.push_back(
      "Not measured yet (issue 26): one multi-view pass against one pass per view (the CPU reference always runs "
      "one multi-view cull and one raster pass over all pages), Vulkan, shadow error against texel density.");
}

}  // namespace vgeo::bench
