// Frame pipeline properties (spec/scene.md §Frame pipeline).
#include <gtest/gtest.h>

#include <cmath>
#include <set>

#include "render/render_helpers.h"

namespace vgeo {
namespace {

using test::decode;
using test::look_camera;

Frame render(const RenderScene& scene, const Camera& cam, unsigned threads, RenderSettings settings = {},
             FrameHistory* history = nullptr) {
  ThreadPool pool(threads);
  Frame f;
  render_frame({scene, cam, settings, pool, history}, &f);
  return f;
}

// τ for the occlusion tests: enough clusters in the cut that some are hidden behind others.
constexpr float kFineThresholdPx = 0.25f;

bool image_finite_and_sized(const Frame& f) {
  return f.image.width == f.vis.width && f.image.height == f.vis.height &&
         f.image.rgb.size() == size_t(f.vis.width) * f.vis.height * 3;
}

TEST(RenderFrame, OneThreadAndManyThreadsGiveBitIdenticalVisBufferAndImage) {
  RenderScene scene = test::make_row_scene();
  Camera cam = look_camera({4, 3, 6}, {0, 1, -4});
  for (ShadeView view : {ShadeView::kLit, ShadeView::kCluster, ShadeView::kOverdraw}) {
    RenderSettings s;
    s.view = view;
    Frame one = render(scene, cam, 1, s);
    EXPECT_GT(one.stats.pixels_covered, 0u);
    for (unsigned t : {2u, 5u}) {
      Frame many = render(scene, cam, t, s);
      EXPECT_EQ(one.vis.keys, many.vis.keys) << t << " threads";
      EXPECT_EQ(one.image.rgb, many.image.rgb) << t << " threads, view " << shade_view_name(view);
    }
  }
}

TEST(RenderFrame, OcclusionCullingNeverChangesTheVisibilityBufferAlongACameraPath) {
  RenderScene scene = test::make_row_scene(1.0, 0.0, 6);
  ASSERT_FALSE(scene.single_convex_object);
  RenderSettings on, off;
  off.occlusion = false;
  // Finer than τ = 1 px: these small meshes' stored errors are tight (measured against the
  // leaves), so at 1 px the cut holds a few coarse clusters and nothing is ever occluded.
  on.threshold_px = off.threshold_px = kFineThresholdPx;
  FrameHistory history;
  uint64_t occluded_total = 0, pass2_frames = 0;
  ThreadPool pool(2);
  const int kFrames = 8;
  for (int f = 0; f < kFrames; ++f) {
    // Look down the row, sliding sideways so objects disocclude between frames.
    double x = -1.5 + 3.0 * f / (kFrames - 1);
    Camera cam = look_camera({x, 1.5, 6}, {0, 1.2, -10});
    Frame with, without;
    render_frame({scene, cam, on, pool, &history}, &with);
    render_frame({scene, cam, off, pool, nullptr}, &without);
    EXPECT_TRUE(decode(with) == decode(without)) << "frame " << f;
    for (const PassStats& p : with.stats.passes) occluded_total += p.clusters_occluded;
    pass2_frames += with.stats.find("cluster_cull_post") != nullptr;
    EXPECT_LE(with.stats.triangles_drawn, without.stats.triangles_drawn);
  }
  // Not vacuous: occlusion culled something and the second pass ran.
  EXPECT_GT(occluded_total, 0u);
  EXPECT_GT(pass2_frames, 0u);
}

TEST(RenderFrame, ClustersPostponedByAStaleHzbAreDrawnByPass2) {
  // Pass 1 tests clusters against the previous frame's HZB. Here that HZB is stale: the
  // sphere in front has left the view since, so the ground and the sphere behind it are
  // partly hidden in the old HZB only. Their clusters there are postponed by pass 1 (their
  // instances are partly visible, so this is the clusters' pass-2 path, not the instances')
  // and pass 2 must draw every one of them: the frame equals the one without occlusion.
  RenderScene scene = test::make_row_scene(1.0, 0.0, 2);  // ground, spheres at z = 0 and z = -3
  const Camera cam = look_camera({0.8, 1.4, 4}, {0, 1.2, -3});
  ThreadPool pool(2);
  RenderSettings on, off;
  off.occlusion = false;
  on.threshold_px = off.threshold_px = kFineThresholdPx;  // as above: clusters small enough to hide
  FrameHistory history;
  Frame previous, with, without;
  render_frame({scene, cam, on, pool, &history}, &previous);
  ASSERT_TRUE(history.valid);
  scene.instances[1].object_to_world = test::translate_scale(0, 100, 0, 1.0);  // out of view
  render_frame({scene, cam, on, pool, &history}, &with);
  render_frame({scene, cam, off, pool, nullptr}, &without);
  EXPECT_TRUE(decode(with) == decode(without));
  const PassStats* pass1 = with.stats.find("cluster_cull");
  ASSERT_NE(pass1, nullptr);
  EXPECT_GT(pass1->clusters_occluded, 0u) << "not vacuous: pass 1 postponed clusters";
  EXPECT_GT(with.visible.size(), size_t(with.pass1_visible)) << "pass 2 drew clusters";
}

TEST(RenderFrame, SkippedPassesAreAbsentWithAReason) {
  RenderScene scene = test::make_row_scene();
  Camera cam = look_camera({4, 3, 6}, {0, 1, -4});
  auto has = [](const Frame& f, const char* name) { return f.stats.find(name) != nullptr; };
  auto skipped = [](const Frame& f, const char* name) {
    for (const auto& [n, reason] : f.stats.skipped)
      if (n == name) return !reason.empty();
    return false;
  };
  {  // occlusion off: no HZB, no second pass
    RenderSettings s;
    s.occlusion = false;
    FrameHistory h;
    Frame f = render(scene, cam, 2, s, &h);
    for (const char* n : {"hzb", "instance_cull_post", "cluster_cull_post", "raster_post", "hzb_next"}) {
      EXPECT_FALSE(has(f, n)) << n;
      EXPECT_TRUE(skipped(f, n)) << n;
    }
    EXPECT_TRUE(has(f, "cluster_cull"));
    EXPECT_TRUE(has(f, "raster"));
  }
  {  // first frame: nothing to test against, so pass 1 occludes nothing → no pass 2
    FrameHistory h;
    Frame f = render(scene, cam, 2, {}, &h);
    EXPECT_FALSE(has(f, "cluster_cull_post"));
    EXPECT_TRUE(skipped(f, "cluster_cull_post"));
    EXPECT_TRUE(has(f, "hzb_next"));  // the next frame needs it
    EXPECT_TRUE(h.valid);
  }
  {  // single convex object (a plain UV sphere): occlusion passes are never assembled
    RenderScene one;
    BuildOptions bo;
    bo.threads = 1;
    one.meshes.push_back(build_dag(test::make_sphere(16, 32), bo));
    one.materials.push_back({});
    one.instances.push_back({0, Mat4d{}});
    analyze_render_scene(&one);
    ASSERT_TRUE(one.single_convex_object);
    FrameHistory h;
    Camera c = look_camera({0, 0, 4}, {0, 0, 0});
    Frame f1 = render(one, c, 2, {}, &h);
    Frame f2 = render(one, c, 2, {}, &h);
    for (const char* n : {"hzb", "cluster_cull_post", "hzb_next"}) {
      EXPECT_FALSE(has(f2, n)) << n;
      EXPECT_TRUE(skipped(f2, n)) << n;
    }
  }
  {  // a displaced sphere is not convex
    RenderScene one;
    BuildOptions bo;
    bo.threads = 1;
    GenerateOptions gen;
    gen.target_triangles = 1024;
    one.meshes.push_back(build_dag(generate_mesh(gen), bo));
    one.instances.push_back({0, Mat4d{}});
    analyze_render_scene(&one);
    EXPECT_FALSE(one.single_convex_object);
  }
}

TEST(RenderFrame, ClosedSphereFillingTheViewShowsNoBackground) {
  // Render-level crack test: a closed mesh at mixed LODs (fine near the eye, coarse at the
  // rim) must cover every pixel of its silhouette; here the silhouette is the whole view.
  RenderScene scene;
  BuildOptions bo;
  bo.threads = 2;
  scene.meshes.push_back(build_dag(test::make_sphere(96, 192, 1.0f), bo));
  scene.materials.push_back({});
  scene.instances.push_back({0, Mat4d{}});
  analyze_render_scene(&scene);
  bool mixed = false;
  for (float tau : {1.0f, 4.0f, 16.0f}) {
    for (Vec3d eye : {Vec3d{0, 0, 1.5}, Vec3d{0.3, 1.2, 0.8}}) {
      Camera cam = look_camera(eye, {0, 0, 0}, 128, 128, 0.01);
      cam.fov_y = 0.9;  // corners stay on the sphere: asin(1/1.5) > atan(tan(0.45)·√2)
      RenderSettings s;
      s.threshold_px = tau;
      s.shade = false;
      Frame f = render(scene, cam, 2, s);
      size_t background = 0;
      for (uint64_t k : f.vis.keys) background += k == 0;
      EXPECT_EQ(background, 0u) << "tau " << tau << " eye " << eye.x << "," << eye.y << "," << eye.z;
      std::set<uint32_t> levels;
      for (const VisibleCluster& v : f.visible) levels.insert(scene.meshes[0].clusters[v.cluster].level);
      mixed |= levels.size() > 1;
    }
  }
  // Not vacuous once the DAG has several levels: some view mixes them.
  if (scene.meshes[0].level_count > 1) {
    EXPECT_TRUE(mixed);
  }
}

TEST(RenderFrame, HardCasesGiveFiniteImagesAndNoCrash) {
  struct Case {
    const char* name;
    double scale, offset;
    Vec3d eye_rel, target_rel;
    double z_near;
  };
  const Case cases[] = {
      {"far away 1e7", 1.0, 1e7, {4, 3, 6}, {0, 1, -4}, 0.01},
      {"scaled 1e-4", 1e-4, 0.0, {4e-4, 3e-4, 6e-4}, {0, 1e-4, -4e-4}, 1e-6},
      {"scaled 1e4", 1e4, 0.0, {4e4, 3e4, 6e4}, {0, 1e4, -4e4}, 10},
      {"camera inside a sphere", 1.0, 0.0, {0, 1.2, 0.1}, {0, 1.2, -5}, 0.01},
      {"camera inside the scene bounds at ground level", 1.0, 0.0, {0, 0.05, 2}, {0, 0.05, -5}, 0.01},
      {"near plane touching a surface", 1.0, 0.0, {0, 1.2, 1.0 + 0.01}, {0, 1.2, -5}, 0.01},
  };
  for (const Case& c : cases) {
    RenderScene scene = test::make_row_scene(c.scale, c.offset, 3);
    Camera cam = look_camera({c.offset + c.eye_rel.x, c.eye_rel.y, c.offset + c.eye_rel.z},
                             {c.offset + c.target_rel.x, c.target_rel.y, c.offset + c.target_rel.z}, 96, 64, c.z_near);
    FrameHistory h;
    ThreadPool pool(2);
    Frame f;
    for (int i = 0; i < 2; ++i) render_frame({scene, cam, {}, pool, &h}, &f);
    EXPECT_TRUE(image_finite_and_sized(f)) << c.name;
    for (uint64_t k : f.vis.keys) {
      if (!k) continue;
      float d = vis_key_depth(k);
      ASSERT_TRUE(std::isfinite(d) && d > 0) << c.name;
      ASSERT_LT(vis_key_cluster(k), f.visible.size()) << c.name;
    }
    // The LOD cut is valid from here too: hierarchy == flat reference.
    std::vector<VisibleCluster> cut = select_cut(scene.meshes, scene.instances, f.view, 1.0f, pool);
    EXPECT_EQ(cut, select_flat(scene.meshes, scene.instances, f.view, 1.0f, false)) << c.name;
    EXPECT_GT(f.stats.pixels_covered, 0u) << c.name;
  }
}

TEST(RenderFrame, FarAwaySceneRendersLikeTheSameSceneAtTheOrigin) {
  // Camera-relative double precision: moving scene and camera by 1e4 changes nothing
  // visible (float positions are exact at this offset for this scene's coordinates).
  RenderScene near_scene = test::make_row_scene(1.0, 0.0, 3), far_scene = test::make_row_scene(1.0, 1024.0, 3);
  Camera a = look_camera({4, 3, 6}, {0, 1, -4}), b = look_camera({1028, 3, 1030}, {1024, 1, 1020});
  Frame fa = render(near_scene, a, 2), fb = render(far_scene, b, 2);
  size_t differ = 0;
  for (size_t p = 0; p < fa.vis.keys.size(); ++p) differ += (fa.vis.keys[p] == 0) != (fb.vis.keys[p] == 0);
  EXPECT_LE(differ, fa.vis.keys.size() / 200);  // ≤ 0.5% coverage change from rounding
}

}  // namespace
}  // namespace vgeo
