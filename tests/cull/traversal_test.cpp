// Hierarchical LOD + cluster culling against the flat reference (spec/scene.md §Culling).
#include <gtest/gtest.h>
#include <rapidcheck/gtest.h>

#include <cmath>
#include <map>

#include "cull/random_instances.h"
#include "cull/synthetic_dag.h"
#include "vgeo/cull/cull.h"

namespace vgeo {
namespace {

// Every leaf of every instance is covered by exactly one selected cluster (the cut is a
// partition of the original surface). Returns the first failure as a message.
std::string check_cut(const std::vector<test::SyntheticDag>& dags, const std::vector<CullInstance>& instances,
                      const std::vector<VisibleCluster>& cut) {
  std::map<uint32_t, std::vector<uint32_t>> cover;  // instance -> per-leaf count
  for (uint32_t i = 0; i < instances.size(); ++i) cover[i].assign(dags[instances[i].mesh].leaf_count, 0);
  for (const VisibleCluster& v : cut)
    for (uint32_t leaf : dags[instances[v.instance].mesh].leaves[v.cluster]) ++cover[v.instance][leaf];
  for (auto& [inst, counts] : cover)
    for (uint32_t leaf = 0; leaf < counts.size(); ++leaf)
      if (counts[leaf] != 1)
        return "instance " + std::to_string(inst) + " leaf " + std::to_string(leaf) + " covered " +
               std::to_string(counts[leaf]) + " times";
  return "";
}

struct RandomScene {
  std::vector<test::SyntheticDag> dags;
  std::vector<ClusterDag> meshes;
  std::vector<CullInstance> instances;
  Camera camera;
};

RandomScene gen_scene() {
  RandomScene s;
  uint32_t mesh_count = *rc::gen::inRange<uint32_t>(1, 3);
  for (uint32_t m = 0; m < mesh_count; ++m) {
    uint32_t seed = *rc::gen::arbitrary<uint32_t>();
    uint32_t leaves = *rc::gen::inRange<uint32_t>(1, 120);
    uint32_t group = *rc::gen::inRange<uint32_t>(2, 9);
    s.dags.push_back(test::make_synthetic_dag(seed, leaves, group));
    s.meshes.push_back(s.dags.back().dag);
  }
  // Offsets: near the origin, or 1e7 away (camera follows, so the scene stays in view).
  double far = *rc::gen::element(0.0, 1e4, 1e7);
  uint32_t count = *rc::gen::inRange<uint32_t>(1, 5);
  for (uint32_t i = 0; i < count; ++i) {
    s.instances.push_back(test::random_cull_instance(mesh_count, far));
  }
  double cs = *rc::gen::element(1e-4, 1.0, 1e4);
  s.camera.position = {far + *rc::gen::inRange(-60, 60) * cs, *rc::gen::inRange(-60, 60) * cs,
                       *rc::gen::inRange(-60, 60) * cs};
  Vec3d target{far + *rc::gen::inRange(-5, 5) * cs, *rc::gen::inRange(-5, 5) * cs, *rc::gen::inRange(-5, 5) * cs};
  if (!look_at_orientation(s.camera.position, target, {0, 1, 0}, &s.camera.orientation))
    s.camera.orientation = {0, 0, 0, 1};
  s.camera.width = *rc::gen::element(64u, 640u, 1920u);
  s.camera.height = *rc::gen::element(48u, 360u, 1080u);
  s.camera.fov_y = *rc::gen::element(0.2, 1.0, 2.5);
  s.camera.z_near = *rc::gen::element(1e-6, 0.01, 1.0) * cs;
  return s;
}

RC_GTEST_PROP(CullTraversal, HierarchicalCutEqualsFlatTestOfEveryCluster, ()) {
  RandomScene s = gen_scene();
  ViewParams view = make_view(s.camera);
  float tau = *rc::gen::element(0.25f, 1.0f, 4.0f, 100.0f);
  unsigned threads = *rc::gen::inRange(1u, 4u);
  ThreadPool pool(threads);
  std::vector<VisibleCluster> cut = select_cut(s.meshes, s.instances, view, tau, pool);
  std::vector<VisibleCluster> flat = select_flat(s.meshes, s.instances, view, tau, false);
  RC_ASSERT(cut == flat);
}

RC_GTEST_PROP(CullTraversal, FrustumCulledTraversalEqualsFlatTest, ()) {
  RandomScene s = gen_scene();
  ViewParams view = make_view(s.camera);
  float tau = *rc::gen::element(0.25f, 1.0f, 4.0f);
  ThreadPool pool(*rc::gen::inRange(1u, 4u));
  std::vector<InstanceView> views = make_instance_views(s.instances, view);
  std::vector<CullItem> seeds;
  for (uint32_t i = 0; i < s.instances.size(); ++i) seeds.push_back({i, 0, CullItem::kNode});
  CullOptions options;
  options.threshold_px = tau;
  CullResult result;
  cull_clusters(s.meshes, s.instances, views, seeds, view, options, pool, &result);
  RC_ASSERT(result.visible == select_flat(s.meshes, s.instances, view, tau, true));
  RC_ASSERT(result.occluded.empty());
}

RC_GTEST_PROP(CullTraversal, CutCoversEveryLeafExactlyOnce, ()) {
  RandomScene s = gen_scene();
  ViewParams view = make_view(s.camera);
  float tau = *rc::gen::element(0.25f, 1.0f, 4.0f, 1000.0f);
  ThreadPool pool(2);
  std::vector<VisibleCluster> cut = select_cut(s.meshes, s.instances, view, tau, pool);
  std::string err = check_cut(s.dags, s.instances, cut);
  RC_ASSERT(err == "");
  uint32_t lo = 99, hi = 0;
  for (const VisibleCluster& v : cut) {
    uint32_t level = s.meshes[s.instances[v.instance].mesh].clusters[v.cluster].level;
    lo = std::min(lo, level);
    hi = std::max(hi, level);
  }
  RC_CLASSIFY(lo != hi, "mixed LOD levels in the cut");
  RC_CLASSIFY(hi == 0, "leaves only");
}

TEST(CullTraversal, CameraInsideBoundsAndAtNearPlaneGivesValidCut) {
  std::vector<test::SyntheticDag> dags{test::make_synthetic_dag(7, 100, 4)};
  std::vector<ClusterDag> meshes{dags[0].dag};
  std::vector<CullInstance> instances(1);
  ThreadPool pool(2);
  for (Vec3d eye : {Vec3d{0, 0, 0}, Vec3d{0.5, 0.25, 0}, Vec3d{3, 3, 3}}) {
    for (double z_near : {1e-9, 1e-3, 1.0}) {
      Camera cam;
      cam.position = eye;
      cam.z_near = z_near;
      ViewParams view = make_view(cam);
      std::vector<VisibleCluster> cut = select_cut(meshes, instances, view, 1.0f, pool);
      EXPECT_EQ(check_cut(dags, instances, cut), "");
      EXPECT_EQ(cut, select_flat(meshes, instances, view, 1.0f, false));
    }
  }
}

TEST(CullTraversal, BvhTreeCheckRejectsCyclesAndSharedNodes) {
  test::SyntheticDag s = test::make_synthetic_dag(3, 200, 2);
  ASSERT_GT(s.dag.bvh_nodes.size(), 2u);
  EXPECT_TRUE(bvh_is_tree(s.dag));
  ClusterDag cyc = s.dag;
  // Point the first node child of the root back at the root.
  for (uint32_t k = 0; k < cyc.bvh_nodes[0].child_count; ++k)
    if (!((cyc.bvh_nodes[0].group_mask >> k) & 1u)) {
      cyc.bvh_nodes[cyc.bvh_nodes[0].children[k]] = cyc.bvh_nodes[0];
      break;
    }
  EXPECT_FALSE(bvh_is_tree(cyc));
}

TEST(CullTraversal, OutputIsIdenticalForAnyThreadCount) {
  std::vector<test::SyntheticDag> dags{test::make_synthetic_dag(11, 400, 4), test::make_synthetic_dag(12, 300, 8)};
  std::vector<ClusterDag> meshes{dags[0].dag, dags[1].dag};
  std::vector<CullInstance> instances;
  for (int i = 0; i < 20; ++i) {
    CullInstance inst;
    inst.mesh = i % 2;
    inst.object_to_world = test::make_transform(i * 7.0, 0, -30.0 - i, i * 0.3, 1, 1, 1);
    instances.push_back(inst);
  }
  Camera cam;
  cam.position = {60, 5, 20};
  look_at_orientation(cam.position, {60, 0, -40}, {0, 1, 0}, &cam.orientation);
  ViewParams view = make_view(cam);
  std::vector<InstanceView> views = make_instance_views(instances, view);
  std::vector<CullItem> seeds;
  for (uint32_t i = 0; i < instances.size(); ++i) seeds.push_back({i, 0, CullItem::kNode});
  CullOptions options;
  CullResult one;
  {
    ThreadPool pool(1);
    cull_clusters(meshes, instances, views, seeds, view, options, pool, &one);
  }
  EXPECT_GT(one.visible.size(), 0u);
  for (unsigned t : {2u, 3u, 8u}) {
    ThreadPool pool(t);
    CullResult many;
    cull_clusters(meshes, instances, views, seeds, view, options, pool, &many);
    EXPECT_EQ(one.visible, many.visible) << t << " threads";
    EXPECT_EQ(one.counters.nodes_visited, many.counters.nodes_visited);
    EXPECT_EQ(one.counters.cluster_candidates, many.counters.cluster_candidates);
  }
}

}  // namespace
}  // namespace vgeo
