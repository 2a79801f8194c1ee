// The GPU cull passes (lib/vgeo/gpu/gpu_cull.h) against the CPU reference (lib/vgeo/cull):
// instance lists, visible-cluster lists, occluded items, HZB texels and every counter equal,
// for both traversals, on lavapipe with the validation layer on (spec/raster.md §12).
#include <gtest/gtest.h>
#include <rapidcheck/gtest.h>

#include <cmath>
#include <cstring>
#include <algorithm>
#include <random>

#include "cull/random_instances.h"
#include "cull/synthetic_dag.h"
#include "gpu/gpu_testing.h"
#include "support/paths.h"
#include "vgeo/gpu/gpu_cull.h"
#include "vgeo/render/scene_file.h"
#include "vgeo/stream/stream.h"

namespace vgeo {
namespace {

constexpr GpuTraversal kTraversals[] = {GpuTraversal::kLevel, GpuTraversal::kPersistent};

// One context and pipeline set for the whole binary (pipeline creation dominates otherwise).
struct TestGpu {
  std::unique_ptr<GpuContext> context;
  GpuCullPipelines pipelines;
  std::unique_ptr<GpuRecorder> recorder;
};
TestGpu* test_gpu() {
  static TestGpu* g = [] {
    auto* t = new TestGpu;
    t->context = testing::make_test_gpu();
    if (!t->context) return t;
    t->pipelines = create_cull_pipelines(*t->context);
    t->recorder = create_gpu_recorder(*t->context);
    return t;
  }();
  return g;
}

bool operator==(const CullCounters& a, const CullCounters& b) { return std::memcmp(&a, &b, sizeof a) == 0; }

std::string counters_text(const CullCounters& c) {
  const uint64_t* v = reinterpret_cast<const uint64_t*>(&c);
  std::string s;
  for (uint32_t i = 0; i < kCounterCount; ++i) s += std::to_string(v[i]) + " ";
  return s;
}

// What one frame's cull passes produce (the parts of frame.cpp's pass 1 / pass 2).
struct CullRun {
  std::vector<uint32_t> visible_instances, occluded_instances, post_instances;
  CullCounters instance_counters, post_instance_counters;
  CullResult pass1, pass2;
  Hzb hzb;  // of `vis`
  std::vector<VisibleCluster> frame_visible;  // pass 1's visible, then pass 2's (frame.cpp's Frame::visible)
  uint64_t persistent_dispatches = 0;          // GPU, persistent traversal: dispatches of all passes
};

struct CullCase {
  std::vector<ClusterDag> meshes;
  std::vector<CullInstance> instances;
  ViewParams view;
  float threshold_px = 1;
  bool frustum = true;
  // Occlusion (pass 1 against `previous_hzb` seen from `previous_view`; pass 2 against the
  // HZB of `vis`). Empty previous_hzb: pass 1 without occlusion.
  Hzb previous_hzb;
  ViewParams previous_view;
  std::vector<CullInstance> previous_instances;
  HzbMipPolicy policy = HzbMipPolicy::k4x4;
  std::vector<uint64_t> vis;  // view.width * view.height keys, or empty: no pass 2
  // Streaming residency (CullOptions::usable_groups) per mesh, or empty: no streaming.
  std::vector<std::vector<uint8_t>> usable;
};

CullRun run_cpu(const CullCase& c) {
  CullRun r;
  ThreadPool pool(2);
  std::vector<InstanceView> views = make_instance_views(c.instances, c.view);
  std::vector<InstanceView> previous_views = make_instance_views(c.previous_instances, c.previous_view);
  CullOptions options;
  options.threshold_px = c.threshold_px;
  options.frustum = c.frustum;
  if (!c.usable.empty()) options.usable_groups = &c.usable;
  if (!c.previous_hzb.empty()) {
    options.occlusion.hzb = &c.previous_hzb;
    options.occlusion.view = &c.previous_view;
    options.occlusion.instances = &previous_views;
    options.occlusion.policy = c.policy;
  }
  std::vector<uint32_t> all(c.instances.size());
  for (uint32_t i = 0; i < all.size(); ++i) all[i] = i;
  cull_instances(c.meshes, c.instances, views, all, c.view, options, &r.visible_instances, &r.occluded_instances,
                 &r.instance_counters);
  std::vector<CullItem> seeds;
  for (uint32_t i : r.visible_instances) seeds.push_back({i, 0, CullItem::kNode});
  cull_clusters(c.meshes, c.instances, views, seeds, c.view, options, pool, &r.pass1);
  r.frame_visible = r.pass1.visible;
  if (c.vis.empty()) return r;
  build_hzb(c.vis.data(), c.view.width, c.view.height, pool, &r.hzb);
  CullOptions post = options;
  post.occlusion.hzb = &r.hzb;
  post.occlusion.view = &c.view;
  post.occlusion.instances = &views;
  post.occlusion.policy = c.policy;
  cull_instances(c.meshes, c.instances, views, r.occluded_instances, c.view, post, &r.post_instances, nullptr,
                 &r.post_instance_counters);
  std::vector<CullItem> seeds2 = r.pass1.occluded;
  for (uint32_t i : r.post_instances) seeds2.push_back({i, 0, CullItem::kNode});
  cull_clusters(c.meshes, c.instances, views, seeds2, c.view, post, pool, &r.pass2);
  r.frame_visible.insert(r.frame_visible.end(), r.pass2.visible.begin(), r.pass2.visible.end());
  return r;
}

CullRun run_gpu(const CullCase& c, GpuTraversal traversal) {
  TestGpu& g = *test_gpu();
  GpuContext& gpu = *g.context;
  GpuRecorder& rec = *g.recorder;
  const GpuCullPipelines& p = g.pipelines;
  GpuCullMeshes m = upload_cull_meshes(gpu, c.meshes);
  GpuCullFrame f = create_cull_frame(gpu, c.meshes, c.instances, c.view.width, c.view.height);
  write_cull_instances(f, c.instances, make_instance_views(c.instances, c.view), false);
  GpuOcclusion previous{&c.previous_view, true, c.policy}, current{&c.view, false, c.policy};
  if (!c.previous_hzb.empty()) {
    write_cull_instances(f, c.previous_instances, make_instance_views(c.previous_instances, c.previous_view), true);
    write_previous_hzb(f, c.previous_hzb);
  }
  write_cull_params(f, 0, c.view, c.threshold_px, c.frustum, c.previous_hzb.empty() ? nullptr : &previous);
  write_cull_params(f, 1, c.view, c.threshold_px, c.frustum, &current);
  GpuBuffer vis = create_gpu_buffer(gpu, std::max<size_t>(c.vis.size() * 8, 8));
  if (!c.vis.empty()) std::memcpy(vis.mapped, c.vis.data(), c.vis.size() * 8);
  write_cull_usable(m, c.usable);

  CullRun r;
  begin_commands(rec);
  cmd_cull_instances(rec, p, m, f, 0, f.candidates, f.visible_instances, &f.occluded_instances, f.counters[0]);
  cmd_cull_clusters(rec, p, m, f, 0, traversal, f.visible_instances, nullptr, f.visible[0], false, &f.occluded_items,
                    f.counters[1]);
  // Each pass's requests are read after it (as the Vulkan executor does).
  submit_and_wait(rec);
  r.pass1.requests = take_cull_requests(m);
  begin_commands(rec);
  if (!c.vis.empty()) {
    cmd_build_hzb(rec, p, f, vis, f.hzb);
    cmd_cull_instances(rec, p, m, f, 1, f.occluded_instances, f.post_instances, nullptr, f.counters[2]);
    cmd_cull_clusters(rec, p, m, f, 1, traversal, f.post_instances, &f.occluded_items, f.visible[1], false, nullptr,
                      f.counters[3]);
    // Pass 2 appended to pass 1's list (the frame's visible-cluster order).
    cmd_cull_clusters(rec, p, m, f, 1, traversal, f.post_instances, &f.occluded_items, f.visible[0], true, nullptr,
                      f.counters[3]);
  }
  submit_and_wait(rec);
  r.pass2.requests = take_cull_requests(m);

  r.persistent_dispatches = f.persistent_dispatches;
  r.visible_instances = read_instance_list(f.visible_instances);
  r.occluded_instances = read_instance_list(f.occluded_instances);
  r.instance_counters = read_cull_counters(f.counters[0]);
  r.pass1.occluded = read_item_list(f.occluded_items);
  r.pass1.counters = read_cull_counters(f.counters[1]);
  // visible[0]: pass 1's list, then (with pass 2) pass 2's appended.
  r.frame_visible = read_visible_list(f.visible[0]);
  r.pass1.visible.assign(r.frame_visible.begin(),
                         r.frame_visible.begin() + std::min<size_t>(r.frame_visible.size(), r.pass1.counters.clusters_visible));
  if (!c.vis.empty()) {
    r.hzb = read_hzb(f, f.hzb);
    r.post_instances = read_instance_list(f.post_instances);
    r.post_instance_counters = read_cull_counters(f.counters[2]);
    r.pass2.visible = read_visible_list(f.visible[1]);
    r.pass2.counters = read_cull_counters(f.counters[3]);
  }
  return r;
}

// Empty string when equal, else what differs first.
std::string compare(const CullRun& cpu, const CullRun& gpu) {
  auto list_diff = [](const char* what, size_t a, size_t b) {
    return std::string(what) + ": CPU " + std::to_string(a) + " entries, GPU " + std::to_string(b);
  };
  if (cpu.visible_instances != gpu.visible_instances)
    return list_diff("visible instances", cpu.visible_instances.size(), gpu.visible_instances.size());
  if (cpu.occluded_instances != gpu.occluded_instances)
    return list_diff("occluded instances", cpu.occluded_instances.size(), gpu.occluded_instances.size());
  if (!(cpu.instance_counters == gpu.instance_counters))
    return "instance counters: CPU " + counters_text(cpu.instance_counters) + "GPU " + counters_text(gpu.instance_counters);
  if (cpu.pass1.visible != gpu.pass1.visible)
    return list_diff("pass 1 visible clusters", cpu.pass1.visible.size(), gpu.pass1.visible.size());
  if (cpu.pass1.occluded != gpu.pass1.occluded)
    return list_diff("pass 1 occluded items", cpu.pass1.occluded.size(), gpu.pass1.occluded.size());
  if (!(cpu.pass1.counters == gpu.pass1.counters))
    return "pass 1 counters: CPU " + counters_text(cpu.pass1.counters) + "GPU " + counters_text(gpu.pass1.counters);
  if (cpu.hzb.mip_width != gpu.hzb.mip_width || cpu.hzb.mip_height != gpu.hzb.mip_height) return "HZB mip sizes";
  for (size_t k = 0; k < cpu.hzb.mips.size(); ++k)
    if (std::memcmp(cpu.hzb.mips[k].data(), gpu.hzb.mips[k].data(), cpu.hzb.mips[k].size() * 4) != 0)
      return "HZB mip " + std::to_string(k) + " texels";
  if (cpu.post_instances != gpu.post_instances)
    return list_diff("pass 2 instances", cpu.post_instances.size(), gpu.post_instances.size());
  if (!(cpu.post_instance_counters == gpu.post_instance_counters)) return "pass 2 instance counters";
  if (cpu.pass2.visible != gpu.pass2.visible) {
    std::string missing;
    for (const VisibleCluster& v : cpu.pass2.visible)
      if (!std::binary_search(gpu.pass2.visible.begin(), gpu.pass2.visible.end(), v))
        missing += " (" + std::to_string(v.instance) + "," + std::to_string(v.cluster) + ")";
    std::string seeds;
    for (const CullItem& i : cpu.pass1.occluded)
      seeds += " (" + std::to_string(i.instance) + "," + std::to_string(i.index) + "," + std::to_string(i.kind) + ")";
    return list_diff("pass 2 visible clusters", cpu.pass2.visible.size(), gpu.pass2.visible.size()) + " missing" +
           missing + " seeds" + seeds + " counters CPU " + counters_text(cpu.pass2.counters) + "GPU " +
           counters_text(gpu.pass2.counters);
  }
  if (!(cpu.pass2.counters == gpu.pass2.counters))
    return "pass 2 counters: CPU " + counters_text(cpu.pass2.counters) + "GPU " + counters_text(gpu.pass2.counters);
  if (cpu.frame_visible != gpu.frame_visible)
    return list_diff("frame visible clusters (pass 2 appended)", cpu.frame_visible.size(), gpu.frame_visible.size());
  // Stream requests: the same (mesh, group) lists per pass with bit-identical priorities.
  auto same_requests = [](const std::vector<GroupRequest>& a, const std::vector<GroupRequest>& b) {
    if (a.size() != b.size()) return false;
    for (size_t i = 0; i < a.size(); ++i)
      if (a[i].mesh != b[i].mesh || a[i].group != b[i].group || std::memcmp(&a[i].priority, &b[i].priority, 4) != 0)
        return false;
    return true;
  };
  if (!same_requests(cpu.pass1.requests, gpu.pass1.requests))
    return list_diff("pass 1 stream requests", cpu.pass1.requests.size(), gpu.pass1.requests.size());
  if (!same_requests(cpu.pass2.requests, gpu.pass2.requests))
    return list_diff("pass 2 stream requests", cpu.pass2.requests.size(), gpu.pass2.requests.size());
  return "";
}

// Random synthetic DAGs and placements (far from the origin, tiny and huge scales, camera
// among the instances), as tests/cull/traversal_test.cpp draws them.
CullCase gen_case() {
  CullCase c;
  uint32_t mesh_count = *rc::gen::inRange<uint32_t>(1, 4);
  for (uint32_t m = 0; m < mesh_count; ++m)
    c.meshes.push_back(test::make_synthetic_dag(*rc::gen::arbitrary<uint32_t>(), *rc::gen::inRange<uint32_t>(1, 150),
                                                *rc::gen::inRange<uint32_t>(2, 9)).dag);
  double far = *rc::gen::element(0.0, 1e4, 1e7);
  uint32_t count = *rc::gen::inRange<uint32_t>(1, 40);
  for (uint32_t i = 0; i < count; ++i) {
    c.instances.push_back(test::random_cull_instance(mesh_count, far));
  }
  auto gen_camera = [&](Camera* cam) {
    double cs = *rc::gen::element(1e-4, 1.0, 1e4);
    cam->position = {far + *rc::gen::inRange(-60, 60) * cs, *rc::gen::inRange(-60, 60) * cs,
                     *rc::gen::inRange(-60, 60) * cs};
    Vec3d target{far + *rc::gen::inRange(-5, 5) * cs, *rc::gen::inRange(-5, 5) * cs, *rc::gen::inRange(-5, 5) * cs};
    if (!look_at_orientation(cam->position, target, {0, 1, 0}, &cam->orientation)) cam->orientation = {0, 0, 0, 1};
    cam->fov_y = *rc::gen::element(0.2, 1.0, 2.5);
    cam->z_near = *rc::gen::element(1e-6, 0.01, 1.0) * cs;
  };
  Camera camera;
  camera.width = *rc::gen::element(17u, 64u, 200u);
  camera.height = *rc::gen::element(9u, 48u, 120u);
  gen_camera(&camera);
  c.view = make_view(camera);
  c.threshold_px = *rc::gen::element(0.25f, 1.0f, 4.0f, 100.0f);
  c.frustum = *rc::gen::element(true, true, false);
  c.policy = *rc::gen::element(HzbMipPolicy::k4x4, HzbMipPolicy::k2x2, HzbMipPolicy::kFinest);
  // Half the cases stream: per mesh either not streamed (empty mask) or a random residency
  // closed to the usable groups (spec/stream.md §Cut), from none to all groups resident.
  if (*rc::gen::arbitrary<bool>()) {
    for (const ClusterDag& dag : c.meshes) {
      if (*rc::gen::element(0, 1, 1) == 0) {
        c.usable.emplace_back();
        continue;
      }
      const uint32_t percent = *rc::gen::element(0u, 30u, 70u, 100u);
      std::vector<uint8_t> resident(dag.groups.size());
      for (uint8_t& g : resident) g = *rc::gen::inRange<uint32_t>(0, 100) < percent;
      c.usable.push_back(usable_groups_of_resident(dag, resident));
    }
  }
  return c;
}

// A depth image of rectangles at random depths (the HZB's source; equal depths and
// background common), as tests/cull/hzb_test.cpp draws them.
std::vector<uint64_t> gen_vis(uint32_t w, uint32_t h) {
  std::vector<uint64_t> keys(size_t(w) * h, 0);
  float base = *rc::gen::element(0.0f, 1e-6f, 1e-3f);
  if (base > 0)
    for (uint64_t& k : keys) k = pack_vis_key(base, 0, 0);
  int rects = *rc::gen::inRange(0, 8);
  for (int r = 0; r < rects; ++r) {
    uint32_t x0 = *rc::gen::inRange<uint32_t>(0, w), y0 = *rc::gen::inRange<uint32_t>(0, h);
    uint32_t x1 = *rc::gen::inRange<uint32_t>(x0, w), y1 = *rc::gen::inRange<uint32_t>(y0, h);
    float depth = *rc::gen::element(1e-5f, 1e-3f, 0.05f, 0.5f, 1.0f);
    for (uint32_t y = y0; y <= y1 && y < h; ++y)
      for (uint32_t x = x0; x <= x1 && x < w; ++x) keys[size_t(y) * w + x] = pack_vis_key(depth, 1, 1);
  }
  return keys;
}

void check_case(const CullCase& c, GpuTraversal t) {
  CullRun cpu = run_cpu(c);
  CullRun gpu = run_gpu(c, t);
  std::string diff = compare(cpu, gpu);
  if (diff != "") RC_FAIL(std::string(t == GpuTraversal::kPersistent ? "persistent: " : "level: ") + diff);
  {
    // ctest runs every test in its own process: each property checks its own validation messages.
    GpuContext& context = *test_gpu()->context;
    std::lock_guard<std::mutex> lock(context.messages_mutex);
    RC_ASSERT(context.validation_messages.empty());
  }
  RC_TAG(cpu.pass1.visible.empty() ? "nothing visible" : "something visible");
  RC_TAG(cpu.pass1.occluded.empty() ? "nothing occluded" : "something occluded");
  RC_TAG(c.usable.empty() ? "no streaming" : cpu.pass1.requests.empty() ? "streaming, no request" : "streaming, requests");
}

void check_lod_and_frustum(GpuTraversal t) {
  RC_ASSERT(test_gpu()->context != nullptr);  // no Vulkan: fail, never skip
  check_case(gen_case(), t);
}
RC_GTEST_PROP(GpuCull, LodAndFrustumEqualCpuLevel, ()) { check_lod_and_frustum(GpuTraversal::kLevel); }
RC_GTEST_PROP(GpuCull, LodAndFrustumEqualCpuPersistent, ()) { check_lod_and_frustum(GpuTraversal::kPersistent); }

void check_two_pass(GpuTraversal t) {
  RC_ASSERT(test_gpu()->context != nullptr);  // no Vulkan: fail, never skip
  CullCase c = gen_case();
  // The previous frame: the same instances seen from a nearby camera, its HZB from a random
  // depth image; this frame's HZB from another.
  c.previous_instances = c.instances;
  c.previous_view = c.view;
  if (*rc::gen::arbitrary<bool>()) {
    for (CullInstance& inst : c.previous_instances) inst.object_to_world.at(0, 3) += *rc::gen::inRange(-2, 3) * 0.5;
  }
  ThreadPool pool(1);
  std::vector<uint64_t> previous = gen_vis(c.view.width, c.view.height);
  build_hzb(previous.data(), c.view.width, c.view.height, pool, &c.previous_hzb);
  c.vis = gen_vis(c.view.width, c.view.height);
  check_case(c, t);
}
// kFinest cases exercise the exact block-decomposed HZB minimum, and long persistent runs
// the bounded re-dispatched loop (llvmpipe's loop limiter: spec/raster.md §12).
RC_GTEST_PROP(GpuCull, TwoPassOcclusionAndHzbEqualCpuLevel, ()) { check_two_pass(GpuTraversal::kLevel); }
RC_GTEST_PROP(GpuCull, TwoPassOcclusionAndHzbEqualCpuPersistent, ()) { check_two_pass(GpuTraversal::kPersistent); }

// Beyond the loop limiter of the first version (spec/raster.md §12): kFinest HZB tests of
// rectangles up to the whole 640×360 view (the CPU reads up to 230,400 texels per test) and a
// persistent traversal long enough to need several bounded dispatches.
TEST(GpuCull, FinestHzbAndLongPersistentRunsEqualCpu) {
  ASSERT_NE(test_gpu()->context, nullptr) << "no Vulkan device";
  constexpr uint32_t kWidth = 640, kHeight = 360;
  CullCase c;
  for (uint32_t m = 0; m < 3; ++m) c.meshes.push_back(test::make_synthetic_dag(7 + m, 150, 8).dag);
  for (uint32_t i = 0; i < 24; ++i) {
    CullInstance inst;
    inst.mesh = i % 3;
    inst.object_to_world = test::make_transform((int(i % 6) - 2.5) * 12.0, (int(i / 6) - 1.5) * 10.0, 0, 0.3 * i, 1, 1, 1);
    c.instances.push_back(inst);
  }
  Camera camera;
  camera.width = kWidth;
  camera.height = kHeight;
  camera.position = {0, 0, 80};
  ASSERT_TRUE(look_at_orientation(camera.position, {0, 0, 0}, {0, 1, 0}, &camera.orientation));
  camera.fov_y = 1.0;
  camera.z_near = 0.01;
  c.view = make_view(camera);
  c.policy = HzbMipPolicy::kFinest;
  c.previous_instances = c.instances;
  c.previous_view = c.view;
  // Occluders nearer than every instance (depth 1e-3 vs ≈ 1.3e-4): the previous frame's over
  // the left part and a band, this frame's over the top right.
  std::vector<uint64_t> previous(size_t(kWidth) * kHeight, 0);
  c.vis.assign(size_t(kWidth) * kHeight, 0);
  for (uint32_t y = 0; y < kHeight; ++y)
    for (uint32_t x = 0; x < kWidth; ++x) {
      if (x < 301 || (y > 100 && y < 141)) previous[size_t(y) * kWidth + x] = pack_vis_key(1e-3f, 1, 1);
      if (x > 203 && y < 251) c.vis[size_t(y) * kWidth + x] = pack_vis_key(1e-3f, 1, 1);
    }
  ThreadPool pool(1);
  build_hzb(previous.data(), kWidth, kHeight, pool, &c.previous_hzb);
  CullRun cpu = run_cpu(c);
  ASSERT_FALSE(cpu.pass1.occluded.empty());
  ASSERT_FALSE(cpu.pass1.visible.empty());
  ASSERT_FALSE(cpu.pass2.visible.empty());
  for (GpuTraversal t : kTraversals) {
    CullRun gpu = run_gpu(c, t);
    EXPECT_EQ(compare(cpu, gpu), "") << (t == GpuTraversal::kPersistent ? "persistent" : "level");
    if (t == GpuTraversal::kPersistent) {
      EXPECT_GT(gpu.persistent_dispatches, 3u);  // > one per pass
    }
  }
  testing::expect_no_validation_messages(*test_gpu()->context);
}

// The repository's scenes: CPU frames along the camera path give real HZBs; every frame's
// cull passes on the GPU equal the CPU's. stream_flythrough.json is left out: its meshes are
// build products (build/accept6), not in the source tree.
TEST(GpuCull, SceneFramesEqualCpu) {
  ASSERT_NE(test_gpu()->context, nullptr) << "no Vulkan device";
  for (const char* name : {"camera_path.json", "spheres.json", "far_away.json", "cgal.json"}) {
    SceneLoadOptions lo;
    lo.cache_dir = std::string(VGEO_BINARY_DIR) + "/dag_cache";
    SceneFile sf = load_scene_file((test::source_dir() / "tests/scenes" / name).string(), lo);
    std::vector<Camera> cameras = sf.path.empty() ? sf.cameras : sf.path;
    RenderSettings settings = sf.settings;
    settings.shade = false;
    ThreadPool pool(2);
    FrameHistory history;
    for (size_t k = 0; k < cameras.size(); ++k) {
      FrameHistory previous = history;  // the history this frame's pass 1 tests against
      Frame frame;
      render_frame({sf.scene, cameras[k], settings, pool, &history, true}, &frame);
      CullCase c;
      c.meshes = sf.scene.meshes;
      c.instances = sf.scene.instances;
      c.view = frame.view;
      c.threshold_px = settings.threshold_px;
      c.policy = settings.hzb_policy;
      if (previous.valid) {
        c.previous_hzb = previous.hzb;
        c.previous_view = previous.view;
        c.previous_instances = sf.scene.instances;
      }
      c.vis = frame.vis.keys;
      CullRun cpu = run_cpu(c);
      EXPECT_FALSE(cpu.pass1.visible.empty()) << name;
      for (GpuTraversal t : kTraversals) {
        std::string diff = compare(cpu, run_gpu(c, t));
        EXPECT_EQ(diff, "") << name << " frame " << k << (t == GpuTraversal::kPersistent ? " persistent" : " level");
      }
    }
  }
  testing::expect_no_validation_messages(*test_gpu()->context);
}

}  // namespace
}  // namespace vgeo
