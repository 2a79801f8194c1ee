// Suite "scaling": Nanite's claim that frame cost tracks screen pixels, not scene size.
// Axis A: instances of one mesh (1 → many) on a ground grid receding from the camera.
// Axis B: triangles per mesh at a fixed instance count.
#include <algorithm>
#include <cmath>
#include <tuple>

#include "bench_render.h"
#include "bench_shapes.h"
#include "bench_suites.h"
#include "vgeo/dag/build.h"
#include "vgeo/core/progress.h"

namespace vgeo::bench {
namespace {

// Instances sit on a k x k grid this many mesh radii apart (gaps between unit spheres).
constexpr double kGridSpacing = 3.0;
// The LOD threshold of the measured frames: 1 px, the default the lod suite supports.
constexpr float kScalingTau = 1.0f;

std::vector<CullInstance> grid_instances(uint32_t count, uint32_t mesh) {
  uint32_t k = uint32_t(std::ceil(std::sqrt(double(count))));
  std::vector<CullInstance> v;
  for (uint32_t i = 0; i < count; ++i)
    v.push_back(placed_instance(mesh, {(double(i % k) - 0.5 * (k - 1)) * kGridSpacing, double(i / k) * kGridSpacing, 0}));
  return v;
}

Camera scaling_camera(bool quick) {
  return look_at_camera({0, -6, 3}, {0, 6, 0}, {0, 0, 1}, quick ? 480 : 960, quick ? 270 : 540);
}

struct Config {
  uint32_t instances, mesh_index;
};

}  // namespace

void run_scaling_suite(const BenchConfig& cfg, SuiteReport& out) {
  out.ran = true;
  const int reps = cfg.repetitions(5);
  ThreadPool pool(cfg.threads);
  Camera cam = scaling_camera(cfg.quick);
  const std::vector<uint32_t> counts = cfg.quick ? std::vector<uint32_t>{1, 16, 64}
                                                 : std::vector<uint32_t>{1, 4, 16, 64, 256, 1024, 4096};
  const std::vector<uint32_t> sizes = cfg.quick ? std::vector<uint32_t>{2000, 8000}
                                                : std::vector<uint32_t>{2000, 8000, 32000, 128000};
  const uint32_t base_size = cfg.quick ? 8000 : 32000, fixed_instances = cfg.quick ? 16 : 256;

  // One scene holds every mesh; each configuration swaps in its instances (untimed).
  RenderScene scene;
  scene.materials.push_back(Material{});
  BuildOptions bo;
  bo.threads = cfg.threads;
  for (uint32_t s : sizes) scene.meshes.push_back(build_dag(make_shape(Shape::kSphere, s, 3), bo, nullptr));
  const std::vector<ClusterDag>& dags = scene.meshes;
  size_t base_index = 0;
  for (size_t i = 0; i < sizes.size(); ++i)
    if (sizes[i] == base_size) base_index = i;
  for (size_t i = 0; i < sizes.size(); ++i)
    out.inputs.push_back("sphere mesh of " + std::to_string(dags[i].triangle_count() ? sizes[i] : 0) +
                         " triangles (seed 3): " + std::to_string(dags[i].clusters.size()) + " clusters, " +
                         std::to_string(dags[i].level_count) + " levels");
  out.inputs.push_back("instances on a " + fmt(kGridSpacing) + "-radius-spaced grid receding from the camera, " +
                       std::to_string(cam.width) + "x" + std::to_string(cam.height) + ", tau = " + fmt(kScalingTau) + " px");
  out.summary =
      "Frames by lib/vgeo/render's render_frame with its default settings (instance + hierarchical cluster culling "
      "with two-pass HZB occlusion, raster, lit shading; " + std::to_string(pool.size()) +
      " threads) in steady state: each configuration keeps its own previous-frame history and is warmed up by one "
      "frame; then " + std::to_string(reps) + " interleaved repetitions per configuration, CPU time (all threads) "
      "and wall time. 'occluded' sums clusters_occluded over the frame's passes. 'scene tris' is what a renderer without LOD would submit (instances x mesh triangles); "
      "'covered px' is the number of non-background pixels. If cost tracks pixels, triangles drawn and frame time "
      "level off while scene triangles keep growing.";

  std::vector<Config> configs;
  for (uint32_t n : counts) configs.push_back({n, uint32_t(base_index)});
  for (size_t i = 0; i < sizes.size(); ++i)
    if (i != base_index || std::find(counts.begin(), counts.end(), fixed_instances) == counts.end())
      configs.push_back({fixed_instances, uint32_t(i)});

  std::vector<std::vector<CullInstance>> placements;
  for (const Config& c : configs) placements.push_back(grid_instances(c.instances, c.mesh_index));
  std::vector<Frame> frames(configs.size());
  std::vector<FrameHistory> history(configs.size());
  RenderSettings settings;
  settings.threshold_px = kScalingTau;
  auto use_config = [&](size_t v) {
    scene.instances = placements[v];
    analyze_render_scene(&scene);
  };
  auto render = [&](size_t v) { render_frame({scene, cam, settings, pool, &history[v], true}, &frames[v]); };
  for (size_t v = 0; v < configs.size(); ++v) {  // warm-up: builds each configuration's history
    use_config(v);
    render(v);
  }
  Progress progress("bench scaling", size_t(reps) * configs.size(), cfg.progress);
  auto samples = time_interleaved(
      reps, configs.size(),
      [&](size_t v) {
        render(v);
        progress.advance();
      },
      use_config);

  auto row_for = [&](size_t v) {
    uint64_t scene_tris = 0;
    // Leaf triangles: the mesh's triangle_count() counts every level; the leaves are level 0.
    uint64_t leaf_tris = 0;
    for (const DagCluster& c : dags[configs[v].mesh_index].clusters)
      if (c.level == 0) leaf_tris += c.triangle_count;
    scene_tris = uint64_t(configs[v].instances) * leaf_tris;
    uint64_t covered = frames[v].stats.pixels_covered;
    return std::make_tuple(scene_tris, covered, summarize(samples.cpu[v]), summarize(samples.wall[v]));
  };

  Table ta{"Axis A: instances of a " + std::to_string(sizes[base_index]) + "-triangle mesh",
           {"instances", "scene tris", "occluded", "clusters", "tris drawn", "drawn / scene", "covered px", "tris / covered px",
            "frame CPU", "frame wall"}, {}};
  Table tb{"Axis B: triangles per mesh at " + std::to_string(fixed_instances) + " instances",
           {"mesh tris", "scene tris", "occluded", "clusters", "tris drawn", "drawn / scene", "covered px", "frame CPU",
            "frame wall"}, {}};
  Series sa_scene = named_series("scene triangles (no LOD)"), sa_drawn = named_series("triangles drawn (tau = 1)"), sa_px = named_series("covered pixels");
  Series ta_cpu = named_series("frame CPU time (ms)");
  Series sb_scene = named_series("scene triangles (no LOD)"), sb_drawn = named_series("triangles drawn (tau = 1)"), tb_cpu = named_series("frame CPU time (ms)");
  nlohmann::json ja = nlohmann::json::array(), jb = nlohmann::json::array();
  for (size_t v = 0; v < configs.size(); ++v) {
    auto [scene_tris, covered, cpu, wall] = row_for(v);
    const FrameStats& f = frames[v].stats;
    uint64_t occluded = 0;
    for (const PassStats& p : f.passes) occluded += p.clusters_occluded;
    nlohmann::json j{{"instances", configs[v].instances},
                     {"mesh_triangles", sizes[configs[v].mesh_index]},
                     {"scene_triangles", scene_tris},
                     {"clusters_occluded", occluded},
                     {"clusters", f.clusters_drawn},
                     {"triangles_drawn", f.triangles_drawn},
                     {"covered_pixels", covered},
                     {"frame_cpu_seconds", to_json(cpu)},
                     {"frame_wall_seconds", to_json(wall)}};
    double ratio = scene_tris ? double(f.triangles_drawn) / double(scene_tris) : 0;
    if (configs[v].mesh_index == base_index && v < counts.size()) {
      ta.rows.push_back({std::to_string(configs[v].instances), std::to_string(scene_tris), std::to_string(occluded),
                         std::to_string(f.clusters_drawn), std::to_string(f.triangles_drawn), fmt(ratio),
                         std::to_string(covered), fmt(covered ? double(f.triangles_drawn) / double(covered) : 0), fmt_stats_time(cpu),
                         fmt_stats_time(wall)});
      double x = configs[v].instances;
      sa_scene.x.push_back(x);
      sa_scene.y.push_back(double(scene_tris));
      sa_drawn.x.push_back(x);
      sa_drawn.y.push_back(double(f.triangles_drawn));
      sa_px.x.push_back(x);
      sa_px.y.push_back(double(covered));
      ta_cpu.x.push_back(x);
      ta_cpu.y.push_back(cpu.median * 1e3);
      ta_cpu.y_low.push_back(cpu.min * 1e3);
      ta_cpu.y_high.push_back(cpu.max * 1e3);
      ja.push_back(j);
    }
    if (configs[v].instances == fixed_instances) {
      tb.rows.push_back({std::to_string(sizes[configs[v].mesh_index]), std::to_string(scene_tris),
                         std::to_string(occluded), std::to_string(f.clusters_drawn), std::to_string(f.triangles_drawn),
                         fmt(ratio), std::to_string(covered),
                         fmt_stats_time(cpu), fmt_stats_time(wall)});
      double x = sizes[configs[v].mesh_index];
      sb_scene.x.push_back(x);
      sb_scene.y.push_back(double(scene_tris));
      sb_drawn.x.push_back(x);
      sb_drawn.y.push_back(double(f.triangles_drawn));
      tb_cpu.x.push_back(x);
      tb_cpu.y.push_back(cpu.median * 1e3);
      tb_cpu.y_low.push_back(cpu.min * 1e3);
      tb_cpu.y_high.push_back(cpu.max * 1e3);
      jb.push_back(j);
    }
  }
  std::sort(tb.rows.begin(), tb.rows.end(),
            [](const auto& a, const auto& b) { return std::stoull(a[0]) < std::stoull(b[0]); });
  out.tables.push_back(ta);
  out.tables.push_back(tb);
  out.data["instances_axis"] = ja;
  out.data["mesh_size_axis"] = jb;
  add_plot(out, cfg, "scaling_instances_triangles.svg",
           Plot{"Instances: scene triangles vs triangles drawn", "instances", "count", true, true,
                {sa_scene, sa_drawn, sa_px}},
           "Scene triangles grow with instances; triangles drawn follow covered pixels");
  add_plot(out, cfg, "scaling_instances_time.svg",
           Plot{"Instances: frame CPU time", "instances", "frame CPU time (ms)", true, true, {ta_cpu}},
           "Frame CPU time against instance count (median, bars = min/max)");
  add_plot(out, cfg, "scaling_mesh_size.svg",
           Plot{"Triangles per mesh: scene vs drawn", "triangles per mesh", "count", true, true,
                {sb_scene, sb_drawn}},
           "Scene triangles vs triangles drawn as the mesh gets denser (fixed instances and camera)");
  add_plot(out, cfg, "scaling_mesh_size_time.svg",
           Plot{"Triangles per mesh: frame CPU time", "triangles per mesh", "frame CPU time (ms)", true, true, {tb_cpu}},
           "Frame CPU time against mesh density (median, bars = min/max)");
}

}  // namespace vgeo::bench
