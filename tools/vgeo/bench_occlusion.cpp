// Suite "occlusion": two-pass HZB occlusion culling (lib/vgeo/render) off / at the coarse
// ≤2x2 mip / at Nanite's ≤4x4 mip / at the finest mip: clusters culled, the time the
// occlusion passes cost and the frame time they save, measured side by side in steady
// state (each variant keeps its own previous-frame HZB).
#include <cmath>

#include "bench_render.h"
#include "bench_shapes.h"
#include "bench_suites.h"
#include "vgeo/dag/build.h"
#include "vgeo/core/progress.h"
#include "vgeo/cull/view.h"
#include "vgeo/render/frame.h"

namespace vgeo::bench {
namespace {

struct OcclusionVariant {
  const char* name;
  bool occlusion;
  HzbMipPolicy policy;
};
constexpr OcclusionVariant kOcclusionVariants[] = {{"off", false, HzbMipPolicy::k4x4},
                                                   {"HZB <=2x2 mip", true, HzbMipPolicy::k2x2},
                                                   {"HZB <=4x4 mip (Nanite)", true, HzbMipPolicy::k4x4},
                                                   {"HZB finest mip", true, HzbMipPolicy::kFinest}};
constexpr size_t kOcclusionVariantCount = 4;
// Passes that exist only because occlusion is on: their time is the cost of occlusion.
const char* const kOcclusionPasses[] = {"hzb", "instance_cull_post", "cluster_cull_post", "raster_post", "hzb_next"};

}  // namespace

void run_occlusion_suite(const BenchConfig& cfg, SuiteReport& out) {
  out.ran = true;
  const uint32_t side = cfg.quick ? 8 : 24, tris = cfg.quick ? 3000 : 12000;
  const int reps = cfg.repetitions(7);
  ThreadPool pool(cfg.threads);
  RenderScene scene = sphere_rows_scene(side, tris, cfg.threads);
  const Camera cam = sphere_rows_camera(side, cfg.quick ? 480 : 960, cfg.quick ? 270 : 540);
  out.inputs.push_back(std::to_string(side) + "x" + std::to_string(side) + " instances of a " +
                       std::to_string(scene.meshes[0].clusters.size()) + "-cluster sphere DAG (" + std::to_string(tris) +
                       " triangles, seed 9), spacing " + fmt(kSphereRowSpacing) + ", camera at eye level with the rows, " +
                       std::to_string(cam.width) + "x" + std::to_string(cam.height) + ", tau = 1 px");
  out.summary =
      "lib/vgeo/render's frame pipeline (two-pass HZB occlusion with previous-frame history, then shading) in steady "
      "state: each variant keeps its own history and is warmed up by one frame, then the variants are rendered "
      "interleaved, " + std::to_string(reps) + " repetitions, " + std::to_string(pool.size()) + " threads. "
      "'occluded' sums clusters_occluded over the passes; 'occlusion passes' is the wall time of the passes that "
      "exist only for occlusion (hzb, *_post, hzb_next); the frame ratio is of process CPU time against 'off' in the "
      "same repetition. 'px differing' compares the shaded image with 'off' (must be 0: culling is conservative).";

  std::vector<FrameHistory> history(kOcclusionVariantCount);
  std::vector<Frame> frames(kOcclusionVariantCount);
  auto render = [&](size_t v) {
    RenderSettings s;
    s.occlusion = kOcclusionVariants[v].occlusion;
    s.hzb_policy = kOcclusionVariants[v].policy;
    render_frame({scene, cam, s, pool, &history[v], true}, &frames[v]);
  };
  for (size_t v = 0; v < kOcclusionVariantCount; ++v) render(v);  // warm-up: builds each history
  std::vector<std::vector<double>> occl_ms(kOcclusionVariantCount), raster_ms(kOcclusionVariantCount);
  Progress progress("bench occlusion", size_t(reps) * kOcclusionVariantCount, cfg.progress);
  auto samples = time_interleaved(reps, kOcclusionVariantCount, [&](size_t v) {
    render(v);
    double o = 0, r = 0;
    for (const PassStats& p : frames[v].stats.passes) {
      for (const char* n : kOcclusionPasses)
        if (p.name == n) o += p.ms;
      if (p.name == "raster" || p.name == "raster_post") r += p.ms;
    }
    occl_ms[v].push_back(o);
    raster_ms[v].push_back(r);
    progress.advance();
  });

  Table t{"Occlusion variants (steady state)", {"variant", "occluded", "clusters drawn", "triangles drawn",
                                                "occlusion passes (spent)", "raster passes", "raster saved vs off", "frame wall", "frame CPU",
                                                "CPU / off", "px differing"}, {}};
  nlohmann::json jrows = nlohmann::json::array();
  Series drawn = named_series("clusters drawn"), occluded = named_series("clusters occluded");
  Series ratio_s = named_series("frame CPU / off");
  for (size_t v = 0; v < kOcclusionVariantCount; ++v) {
    const Frame& f = frames[v];
    uint64_t occ = 0;
    for (const PassStats& p : f.stats.passes) occ += p.clusters_occluded;
    uint64_t differing = 0;
    const auto& a = f.image.rgb;
    const auto& b = frames[0].image.rgb;
    for (size_t i = 0; i + 2 < a.size() && i + 2 < b.size(); i += 3)
      differing += a[i] != b[i] || a[i + 1] != b[i + 1] || a[i + 2] != b[i + 2];
    Stats wall = summarize(samples.wall[v]), cpu = summarize(samples.cpu[v]),
          ratio = ratio_stats(samples.cpu[v], samples.cpu[0]);
    Stats om = summarize(occl_ms[v]), rm = summarize(raster_ms[v]);
    t.rows.push_back({kOcclusionVariants[v].name, std::to_string(occ), std::to_string(f.stats.clusters_drawn),
                      std::to_string(f.stats.triangles_drawn), fmt_time(om.median * 1e-3), fmt_time(rm.median * 1e-3),
                      fmt_time((summarize(raster_ms[0]).median - rm.median) * 1e-3), fmt_stats_time(wall), fmt_stats_time(cpu), fmt_ratio(ratio), std::to_string(differing)});
    jrows.push_back({{"variant", kOcclusionVariants[v].name},
                     {"clusters_occluded", occ},
                     {"clusters_drawn", f.stats.clusters_drawn},
                     {"triangles_drawn", f.stats.triangles_drawn},
                     {"occlusion_pass_ms", to_json(om)},
                     {"raster_pass_ms", to_json(rm)},
                     {"frame_wall_seconds", to_json(wall)},
                     {"frame_cpu_seconds", to_json(cpu)},
                     {"frame_cpu_over_off", to_json(ratio)},
                     {"pixels_differing_from_off", differing},
                     {"passes", nlohmann::json::parse(frame_stats_json(f.stats))}});
    double x = double(v);
    drawn.x.push_back(x);
    drawn.y.push_back(double(f.stats.clusters_drawn));
    occluded.x.push_back(x);
    occluded.y.push_back(double(occ));
    ratio_s.x.push_back(x);
    ratio_s.y.push_back(ratio.median);
    ratio_s.y_low.push_back(ratio.min);
    ratio_s.y_high.push_back(ratio.max);
  }
  out.tables.push_back(t);
  out.data["rows"] = jrows;
  add_plot(out, cfg, "occlusion_clusters.svg",
           Plot{"Occlusion: clusters drawn and culled", "variant (0 off, 1 <=2x2, 2 <=4x4, 3 finest)", "clusters",
                false, false, {drawn, occluded}},
           "Clusters drawn and occluded per variant");
  add_plot(out, cfg, "occlusion_frame_ratio.svg",
           Plot{"Occlusion: frame CPU time relative to off", "variant (0 off, 1 <=2x2, 2 <=4x4, 3 finest)",
                "frame CPU / off (same repetition)", false, false, {ratio_s}},
           "Per-repetition frame CPU time ratio against occlusion off (median, bars = min/max)");
}

}  // namespace vgeo::bench
