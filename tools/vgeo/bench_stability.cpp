// Suite "stability": hard cases (far instances, extreme scales, camera inside the bounds or
// at the near plane, sliver and degenerate input) measured with the lod suite's accuracy
// metrics at tau = 1, to show they neither degrade nor blow up.
#include <cmath>

#include "bench_render.h"
#include "bench_shapes.h"
#include "bench_suites.h"
#include "vgeo/dag/build.h"
#include "vgeo/core/error.h"
#include "vgeo/core/progress.h"

namespace vgeo::bench {
namespace {

constexpr float kStabilityTau = 1.0f;  // the default the lod suite supports
constexpr double kFar = 1e7;  // spec/invariants.md: instances up to 1e7 units from the origin

struct Case {
  std::string name;
  int mesh = 0;  // index into the case meshes
  Vec3d translation;
  double scale = 1;
  Camera camera;
  bool compare_to_baseline = false;  // same view up to translation/scale: image must match
};

// Keys whose depth is not a finite value in (0, 1]: must never be written (visbuffer.h).
uint64_t invalid_keys(const VisBuffer& vb) {
  uint64_t n = 0;
  for (uint64_t k : vb.keys) {
    if (k == 0) continue;
    float d = vis_key_depth(k);
    n += !(std::isfinite(d) && d > 0 && d <= 1);
  }
  return n;
}

}  // namespace

void run_stability_suite(const BenchConfig& cfg, SuiteReport& out) {
  out.ran = true;
  const uint32_t tris = cfg.quick ? 5000 : 40000;
  const int reps = cfg.repetitions(5);
  const uint32_t w = cfg.quick ? 320 : 640, h = cfg.quick ? 180 : 360;
  ThreadPool pool(cfg.threads);

  struct MeshCase {
    std::string name;
    Mesh mesh;
  };
  std::vector<MeshCase> inputs;
  inputs.push_back({"sphere", make_shape(Shape::kSphere, tris, 5)});
  inputs.push_back({"terrain", make_shape(Shape::kTerrain, tris, 5)});
  inputs.push_back({"ellipsoid 1:1:0.001 (slivers)", make_ellipsoid(tris, 1e-3f)});
  inputs.push_back({"sphere + degenerate triangles", add_degenerate_triangles(make_shape(Shape::kSphere, tris, 5), 7)});

  const Vec3d base_eye{2.2, 1.4, 1.8}, origin{0, 0, 0}, up{0, 1, 0};
  const Camera base = look_at_camera(base_eye, origin, up, w, h);

  std::vector<Case> cases;
  cases.push_back({"baseline: sphere, camera outside", 0, {}, 1, base, false});
  {
    Case c{"far: instance and camera at 1e7", 0, {kFar, 0, kFar}, 1, base, true};
    c.camera = look_at_camera({base_eye.x + kFar, base_eye.y, base_eye.z + kFar}, {kFar, 0, kFar}, up, w, h);
    cases.push_back(c);
  }
  for (double s : {1e-4, 1e4}) {
    Case c{std::string("scale ") + (s < 1 ? "1e-4" : "1e4") + ": instance, camera and near plane scaled", 0, {}, s,
           base, true};
    c.camera = look_at_camera({base_eye.x * s, base_eye.y * s, base_eye.z * s}, origin, up, w, h, base.z_near * s);
    cases.push_back(c);
  }
  {
    BoxFrame f = box_frame(inputs[1].mesh);
    Case c{"camera inside bounds: just under the terrain's top, looking across", 1, {}, 1, base, false};
    c.camera = look_at_camera({f.center.x - 0.2 * f.half.x, f.center.y + 0.8 * f.half.y, f.center.z - 0.5 * f.half.z},
                              {f.center.x + 0.3 * f.half.x, f.center.y, f.center.z + 0.5 * f.half.z}, up, w, h);
    cases.push_back(c);
  }
  {
    // The surface point nearest the +Z axis top, then the eye half a near distance above it:
    // triangles there cross the near plane and must be clipped, not drawn unclipped.
    const Mesh& m = inputs[0].mesh;
    Vec3 top{0, 0, -1e30f};
    for (size_t v = 0; v < m.vertex_count(); ++v)
      if (m.position(v).z > top.z) top = m.position(v);
    constexpr double kNear = 0.05;
    Case c{"near plane: surface closer than z_near in the view centre", 0, {}, 1, base, false};
    c.camera = look_at_camera({top.x, top.y, top.z + 0.5 * kNear}, origin, up, w, h, kNear);
    cases.push_back(c);
  }
  {
    Case c{"slivers: ellipsoid 1:1:0.001 seen obliquely", 2, {}, 1, base, false};
    c.camera = look_at_camera({1.8, 0.9, 0.6}, origin, up, w, h);
    cases.push_back(c);
  }
  cases.push_back({"degenerate input: zero-area and collinear triangles added", 3, {}, 1, base, false});

  // One scene holds every mesh; each case places one instance of its mesh.
  RenderScene scene;
  scene.meshes.resize(inputs.size());
  scene.materials.push_back(Material{});
  std::vector<ClusterDag>& dags = scene.meshes;
  std::vector<std::string> build_status(inputs.size(), "ok");
  BuildOptions bo;
  bo.threads = cfg.threads;
  for (size_t i = 0; i < inputs.size(); ++i) {
    try {
      dags[i] = build_dag(inputs[i].mesh, bo, nullptr);
    } catch (const VgeoError& e) {
      build_status[i] = "rejected: " + e.error().code;
    }
    out.inputs.push_back(inputs[i].name + ": " + std::to_string(inputs[i].mesh.triangle_count()) + " triangles, build " +
                         build_status[i] + (build_status[i] == "ok" ? ", " + std::to_string(dags[i].level_count) + " levels" : ""));
  }
  out.summary =
      "Each case renders at tau = " + fmt(kStabilityTau) + " px and at full detail (tau = 0) with lib/vgeo/render's render_frame "
      "(occlusion off: one object), " +
      std::to_string(reps) + " interleaved repetitions, " + std::to_string(w) + "x" + std::to_string(h) +
      ". Accuracy metrics as in the lod suite, against the case's own full-detail frame; cases that are the baseline "
      "view translated or scaled are also compared with the baseline's image (they should match it). "
      "'bad keys' counts visibility-buffer depths that are not finite in (0, 1] (must be 0).";

  Table t{"Hard cases at tau = 1", {"case", "tris drawn", "full tris", "frame CPU", "frame CPU / full", "mean |d|",
                                    "max |d|", "surface differs", "vs baseline: mean |d|", "vs baseline: surface differs",
                                    "bad keys"}, {}};
  nlohmann::json jcases = nlohmann::json::array();
  Series err = named_series("mean |shade diff| vs full detail"), surf = named_series("% surface differs vs full detail");
  Progress progress("bench stability", cases.size(), cfg.progress);
  Frame baseline;
  for (size_t ci = 0; ci < cases.size(); ++ci) {
    const Case& c = cases[ci];
    if (build_status[size_t(c.mesh)] != "ok") {
      t.rows.push_back({c.name, "build " + build_status[size_t(c.mesh)], "", "", "", "", "", "", "", "", ""});
      jcases.push_back({{"case", c.name}, {"build", build_status[size_t(c.mesh)]}});
      progress.advance();
      continue;
    }
    scene.instances = {placed_instance(uint32_t(c.mesh), c.translation, c.scale)};
    analyze_render_scene(&scene);
    Frame frames[2];
    auto samples = time_interleaved(reps, 2, [&](size_t v) {
      RenderSettings s;
      s.occlusion = false;
      s.threshold_px = v == 1 ? kFullDetailTau : kStabilityTau;
      render_frame({scene, c.camera, s, pool, nullptr, false}, &frames[v]);
    });
    ImageError e = compare_frames(frames[0], frames[1]);
    Stats cpu = summarize(samples.cpu[0]), ratio = ratio_stats(samples.cpu[0], samples.cpu[1]);
    uint64_t bad = invalid_keys(frames[0].vis) + invalid_keys(frames[1].vis);
    std::string vb_mean = "-", vb_surf = "-";
    nlohmann::json j{{"case", c.name},
                     {"build", "ok"},
                     {"triangles_drawn", frames[0].stats.triangles_drawn},
                     {"full_triangles", frames[1].stats.triangles_drawn},
                     {"frame_cpu_seconds", to_json(cpu)},
                     {"frame_cpu_over_full", to_json(ratio)},
                     {"mean_abs_diff", e.mean_abs},
                     {"max_abs_diff", e.max_abs},
                     {"surface_differs_share", e.surface_differs},
                     {"bad_keys", bad}};
    if (ci == 0) baseline = frames[0];
    if (c.compare_to_baseline && !baseline.image.rgb.empty()) {
      ImageError b = compare_frames(frames[0], baseline);
      vb_mean = fmt(b.mean_abs);
      vb_surf = fmt(100 * b.surface_differs) + "%";
      j["vs_baseline_mean_abs_diff"] = b.mean_abs;
      j["vs_baseline_surface_differs_share"] = b.surface_differs;
    }
    t.rows.push_back({c.name, std::to_string(frames[0].stats.triangles_drawn), std::to_string(frames[1].stats.triangles_drawn),
                      fmt_stats_time(cpu), fmt_ratio(ratio), fmt(e.mean_abs), fmt(e.max_abs),
                      fmt(100 * e.surface_differs) + "%", vb_mean, vb_surf, std::to_string(bad)});
    err.x.push_back(double(ci + 1));
    err.y.push_back(e.mean_abs);
    surf.x.push_back(double(ci + 1));
    surf.y.push_back(100 * e.surface_differs);
    jcases.push_back(j);
    progress.advance();
  }
  err.line = surf.line = false;
  out.tables.push_back(t);
  out.data["cases"] = jcases;
  std::string legend;
  for (size_t ci = 0; ci < cases.size(); ++ci) legend += (ci ? "; " : "") + std::to_string(ci + 1) + " = " + cases[ci].name;
  add_plot(out, cfg, "stability_cases.svg",
           Plot{"Hard cases: error at tau = 1 against full detail", "case number", "error", false, false, {err, surf}},
           "Accuracy per hard case (" + legend + ")");
}

}  // namespace vgeo::bench
