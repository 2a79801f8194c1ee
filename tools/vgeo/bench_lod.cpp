// Suite "lod": the accuracy/time curve of the LOD threshold tau. For each tau: triangles and
// clusters drawn, time per pass, and image error against a full-detail render of the same view,
// all by lib/vgeo/render's frame pipeline (render_frame).
#include <cmath>

#include "bench_render.h"
#include "bench_shapes.h"
#include "bench_suites.h"
#include "vgeo/dag/build.h"
#include "vgeo/core/progress.h"
#include "vgeo/cull/cull.h"

namespace vgeo::bench {
namespace {

const std::vector<float> kTaus = {0.25f, 0.5f, 1, 2, 4, 8};

struct View {
  const char* name;
  Shape shape;
  bool grazing;
};

std::vector<View> lod_views(bool quick) {
  if (quick) return {{"terrain grazing", Shape::kTerrain, true}};
  return {{"terrain grazing", Shape::kTerrain, true}, {"islands whole", Shape::kIslands, false}};
}

// Grazing: from just above one corner of a Y-up heightfield towards the far side, so the
// depth range across the screen is large and the cut mixes levels. Whole: the bounding
// box seen from outside at ~2 box radii.
Camera view_camera(const View& view, const Mesh& mesh, bool quick) {
  BoxFrame f = box_frame(mesh);
  const uint32_t width = quick ? 480 : 960, height = quick ? 270 : 540;
  if (view.grazing)
    return look_at_camera(
        {f.center.x - 1.02 * f.half.x, f.center.y + f.half.y + 0.12 * f.max_half(), f.center.z - 1.02 * f.half.z},
        {f.center.x + 0.35 * f.half.x, f.center.y - 0.5 * f.half.y, f.center.z + 0.35 * f.half.z}, {0, 1, 0}, width,
        height);
  double r = length(f.half);
  return look_at_camera({f.center.x + 1.3 * r, f.center.y + 1.0 * r, f.center.z + 1.6 * r},
                        {f.center.x, f.center.y, f.center.z}, {0, 1, 0}, width, height);
}

}  // namespace

void run_lod_suite(const BenchConfig& cfg, SuiteReport& out) {
  out.ran = true;
  const uint32_t triangles = cfg.quick ? 20000 : 200000;
  const int reps = cfg.repetitions(7);
  ThreadPool pool(cfg.threads);
  out.summary =
      "One frame = lib/vgeo/render's render_frame (instance cull + persistent-thread hierarchical LOD/frustum "
      "cluster cull, software raster on the auto path, deferred lit shading), occlusion off (one object; "
      "occlusion has its own suite). Each tau and the full-detail reference (tau = 0: the zero-error cut) are "
      "rendered interleaved, " + std::to_string(reps) + " repetitions, " + std::to_string(pool.size()) +
      " threads. 'cull', 'raster', 'shade' are the median wall times of render_frame's own passes "
      "(cull = instance_cull + cluster_cull); the frame is process CPU time (all threads: robust to other "
      "processes on a shared machine) and wall time. Image error is against the full-detail render of the same "
      "view: mean and max absolute difference of the 8-bit sRGB channels, and the share of pixels whose visible "
      "surface differs (coverage differs, or depth differs by more than 1%).";

  Table t{"Per tau: what is drawn, what it costs, how wrong it looks", {"view", "tau", "clusters", "triangles",
                                                                        "tris / full", "cull", "raster", "shade",
                                                                        "frame wall", "frame CPU", "CPU / full", "mean |d|",
                                                                        "max |d|", "surface differs"}, {}};
  nlohmann::json jviews = nlohmann::json::array();
  std::vector<Series> tri_series, time_series, err_series, surf_series;
  Progress progress("bench lod", lod_views(cfg.quick).size(), cfg.progress);
  for (const View& view : lod_views(cfg.quick)) {
    Mesh mesh = make_shape(view.shape, triangles, 11);
    const Camera camera = view_camera(view, mesh, cfg.quick);
    BuildOptions bo;
    bo.threads = cfg.threads;
    RenderScene scene;
    scene.meshes.push_back(build_dag(mesh, bo, nullptr));
    scene.materials.push_back(Material{});
    scene.instances.push_back(placed_instance(0, {0, 0, 0}));
    analyze_render_scene(&scene);
    const ClusterDag& dag = scene.meshes[0];
    out.inputs.push_back(std::string(view.name) + ": " + shape_name(view.shape) + " " +
                         std::to_string(mesh.triangle_count()) + " triangles (seed 11), " +
                         std::to_string(dag.clusters.size()) + " clusters in " + std::to_string(dag.level_count) +
                         " levels, " + std::to_string(camera.width) + "x" + std::to_string(camera.height));
    const size_t variants = kTaus.size() + 1, full = kTaus.size();
    std::vector<Frame> frames(variants);
    std::vector<std::vector<double>> cull(variants), raster(variants), shade(variants);  // wall ms
    auto settings = [&](size_t v) {
      RenderSettings s;
      s.occlusion = false;
      s.threshold_px = v == full ? kFullDetailTau : kTaus[v];
      return s;
    };
    auto totals = time_interleaved(reps, variants, [&](size_t v) {
      render_frame({scene, camera, settings(v), pool, nullptr, false}, &frames[v]);
      const FrameStats& fs = frames[v].stats;
      cull[v].push_back(passes_ms(fs, {"instance_cull", "cluster_cull"}));
      raster[v].push_back(passes_ms(fs, {"raster"}));
      shade[v].push_back(passes_ms(fs, {"shade"}));
    });
    Series ts, ft, es, ss;
    ts.name = ft.name = es.name = ss.name = view.name;
    nlohmann::json jrows = nlohmann::json::array();
    std::vector<std::string> bvh_mismatch;
    for (size_t v = 0; v < variants; ++v) {
      const Frame& f = frames[v];
      const uint64_t clusters = f.stats.clusters_drawn, tris = f.stats.triangles_drawn,
                     full_tris = frames[full].stats.triangles_drawn;
      ImageError e = compare_frames(f, frames[full]);
      Stats st = summarize(totals.wall[v]), sc = summarize(totals.cpu[v]), rt = ratio_stats(totals.cpu[v], totals.cpu[full]);
      std::string tau = v == full ? "full" : fmt(kTaus[v]);
      if (select_flat(scene.meshes, scene.instances, f.view, settings(v).threshold_px, true) != f.visible)
        bvh_mismatch.push_back(tau);
      double tri_ratio = full_tris ? double(tris) / double(full_tris) : 0;
      t.rows.push_back({view.name, tau, std::to_string(clusters), std::to_string(tris), fmt(tri_ratio),
                        fmt_time(1e-3 * summarize(cull[v]).median), fmt_time(1e-3 * summarize(raster[v]).median),
                        fmt_time(1e-3 * summarize(shade[v]).median), fmt_stats_time(st), fmt_stats_time(sc), fmt_ratio(rt), fmt(e.mean_abs),
                        fmt(e.max_abs), fmt(100 * e.surface_differs) + "%"});
      jrows.push_back({{"tau", v == full ? nlohmann::json("full") : nlohmann::json(kTaus[v])},
                       {"clusters", clusters},
                       {"triangles", tris},
                       {"pass_ms_cull", to_json(summarize(cull[v]))},
                       {"pass_ms_raster", to_json(summarize(raster[v]))},
                       {"pass_ms_shade", to_json(summarize(shade[v]))},
                       {"seconds_frame_wall", to_json(st)},
                       {"seconds_frame_cpu", to_json(sc)},
                       {"frame_cpu_over_full", to_json(rt)},
                       {"mean_abs_diff", e.mean_abs},
                       {"max_abs_diff", e.max_abs},
                       {"surface_differs_share", e.surface_differs}});
      if (v == full) {
        es.x.push_back(sc.median * 1e3);  // the full-detail end of the curve: error 0 by definition
        es.y.push_back(0);
        continue;
      }
      ts.x.push_back(kTaus[v]);
      ts.y.push_back(double(tris));
      ft.x.push_back(kTaus[v]);
      ft.y.push_back(rt.median);
      ft.y_low.push_back(rt.min);
      ft.y_high.push_back(rt.max);
      es.x.push_back(sc.median * 1e3);
      es.y.push_back(e.mean_abs);
      ss.x.push_back(kTaus[v]);
      ss.y.push_back(100 * e.surface_differs);
    }
    if (!bvh_mismatch.empty()) {
      std::string taus;
      for (const auto& s : bvh_mismatch) taus += " " + s;
      out.notes.push_back(std::string("FINDING: ") + view.name + ": render_frame's hierarchical cull "
                          "drew a different cluster set than lib/vgeo/cull's select_flat (flat LOD + frustum test of every "
                          "cluster) at tau =" + taus + ".");
    }
    tri_series.push_back(ts);
    time_series.push_back(ft);
    err_series.push_back(es);
    surf_series.push_back(ss);
    jviews.push_back({{"view", view.name}, {"rows", jrows}});
    progress.advance();
  }
  out.tables.push_back(t);
  out.data["views"] = jviews;
  add_plot(out, cfg, "lod_triangles_vs_tau.svg",
           Plot{"Triangles drawn vs tau", "tau (px)", "triangles drawn", true, true, tri_series},
           "Triangles drawn against the LOD threshold");
  add_plot(out, cfg, "lod_frame_ratio_vs_tau.svg",
           Plot{"Frame CPU time relative to full detail", "tau (px)", "frame CPU time / full-detail frame CPU time", true, false,
                time_series},
           "Per-repetition ratio of the frame time to the full-detail frame (median, bars = min/max)");
  add_plot(out, cfg, "lod_error_vs_time.svg",
           Plot{"Accuracy vs time: mean shade error against frame time", "frame CPU time (ms, median)",
                "mean |shade difference| (0..255)", false, false, err_series},
           "Each point is one tau (left = larger tau; the rightmost point, error 0, is full detail); the knee is where error starts rising faster than time falls");
  add_plot(out, cfg, "lod_surface_differs_vs_tau.svg",
           Plot{"Pixels whose visible surface differs", "tau (px)", "% of pixels", true, false, surf_series},
           "Share of pixels whose coverage differs or whose depth differs by more than 1% from full detail");
}

}  // namespace vgeo::bench
