// Culling and frame-pipeline micro-benchmarks (lib/vgeo/cull, lib/vgeo/render).
//   BM_CullTraversal/K/threads   persistent-thread LOD + cluster culling of K instances
//   BM_GpuCullTraversal/K/variant the same traversal on the Vulkan device (lavapipe), variant
//                                0 = persistent threads, 1 = level by level (GPU time of the
//                                pass: seeding, traversal, compaction; timestamps)
//   BM_HzbBuild/threads          HZB of a 1280x720 visibility buffer
//   BM_GpuHzbBuild               the same on the Vulkan device
//   BM_DefaultSceneFrame/threads the embedded default scene at 1280x720, whole frame
//   BM_Scaling/K                 K instances of one big mesh (only with VGEO_BENCH_SCALING=1;
//                                mesh size VGEO_SCALING_RINGS, default 512 → ~0.5M triangles):
//                                counters triangles_drawn, pixels, tri_per_pixel, per-pass ms
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdlib>
#include <map>
#include <memory>

#include "vgeo/core/error.h"
#include "vgeo/dag/build.h"
#include "vgeo/cull/cull.h"
#include "vgeo/gpu/gpu_cull.h"
#include "vgeo/mesh/generate.h"
#include "vgeo/render/frame.h"
#include "vgeo/render/scene_file.h"

namespace vgeo {
namespace {

Mat4d translate(double x, double y, double z) {
  Mat4d m;
  m.at(0, 3) = x;
  m.at(1, 3) = y;
  m.at(2, 3) = z;
  return m;
}

// Instances on a square grid in XZ, camera above one corner looking across the grid.
std::vector<CullInstance> grid_instances(uint32_t k, double spacing) {
  std::vector<CullInstance> out;
  uint32_t side = uint32_t(std::ceil(std::sqrt(double(k))));
  for (uint32_t i = 0; i < k; ++i) out.push_back({0, translate((i % side) * spacing, 0, -double(i / side) * spacing)});
  return out;
}

Camera grid_camera(uint32_t k, double spacing) {
  // Low over the near corner, looking across the grid's diagonal: near instances large,
  // far ones down to sub-pixel, the grid filling most of the view.
  double side = std::ceil(std::sqrt(double(k))) * spacing;
  Camera c;
  c.width = 1280;
  c.height = 720;
  c.position = {-2.0, 0.25 * side + 2.0, 2.0};
  look_at_orientation(c.position, {0.6 * side, 0, -0.6 * side}, {0, 1, 0}, &c.orientation);
  return c;
}

const ClusterDag& sphere_dag(uint32_t rings) {
  static std::map<uint32_t, std::unique_ptr<ClusterDag>> cache;
  auto& slot = cache[rings];
  if (!slot) {
    BuildOptions bo;
    GenerateOptions gen;
    gen.target_triangles = 4ull * rings * rings;  // as many as a rings x 2·rings UV sphere
    slot = std::make_unique<ClusterDag>(build_dag(generate_mesh(gen), bo));
  }
  return *slot;
}

void BM_CullTraversal(benchmark::State& state) {
  uint32_t k = uint32_t(state.range(0));
  std::vector<ClusterDag> meshes{sphere_dag(128)};
  std::vector<CullInstance> instances = grid_instances(k, 3.0);
  ViewParams view = make_view(grid_camera(k, 3.0));
  std::vector<InstanceView> views = make_instance_views(instances, view);
  std::vector<CullItem> seeds;
  for (uint32_t i = 0; i < k; ++i) seeds.push_back({i, 0, CullItem::kNode});
  ThreadPool pool(unsigned(state.range(1)));
  CullOptions options;
  CullResult result;
  for (auto _ : state) {
    cull_clusters(meshes, instances, views, seeds, view, options, pool, &result);
    benchmark::DoNotOptimize(result.visible.data());
  }
  state.counters["nodes"] = double(result.counters.nodes_visited);
  state.counters["candidates"] = double(result.counters.cluster_candidates);
  state.counters["visible"] = double(result.visible.size());
}
BENCHMARK(BM_CullTraversal)->Args({1, 1})->Args({100, 1})->Args({100, 2})->Args({1000, 2})->Unit(benchmark::kMillisecond);

// One Vulkan context for the whole run (null without a device: the GPU benchmarks report
// an error instead of a time).
struct BenchGpu {
  std::unique_ptr<GpuContext> context;
  GpuCullPipelines pipelines;
  std::unique_ptr<GpuRecorder> recorder;
};
BenchGpu* bench_gpu() {
  static BenchGpu* g = [] {
    auto* b = new BenchGpu;
    try {
      b->context = create_gpu_context({});
      b->pipelines = create_cull_pipelines(*b->context);
      b->recorder = create_gpu_recorder(*b->context);
    } catch (const VgeoError&) {
      b->context.reset();
    }
    return b;
  }();
  return g->context ? g : nullptr;
}

void BM_GpuCullTraversal(benchmark::State& state) {
  BenchGpu* g = bench_gpu();
  if (!g) return state.SkipWithError("no Vulkan device");
  uint32_t k = uint32_t(state.range(0));
  GpuTraversal traversal = state.range(1) == 0 ? GpuTraversal::kPersistent : GpuTraversal::kLevel;
  std::vector<ClusterDag> meshes{sphere_dag(128)};
  std::vector<CullInstance> instances = grid_instances(k, 3.0);
  ViewParams view = make_view(grid_camera(k, 3.0));
  GpuCullMeshes m = upload_cull_meshes(*g->context, meshes);
  GpuCullFrame f = create_cull_frame(*g->context, meshes, instances, view.width, view.height);
  write_cull_instances(f, instances, make_instance_views(instances, view), false);
  write_cull_params(f, 0, view, 1.0f, true, nullptr);
  GpuRecorder& rec = *g->recorder;
  for (auto _ : state) {
    begin_commands(rec);
    uint32_t t0 = cmd_timestamp(rec);
    cmd_cull_clusters(rec, g->pipelines, m, f, 0, traversal, f.candidates, nullptr, f.visible[0], false, nullptr,
                      f.counters[1]);
    uint32_t t1 = cmd_timestamp(rec);
    submit_and_wait(rec);
    state.SetIterationTime(timestamp_ms(rec, t0, t1) * 1e-3);
  }
  CullCounters c = read_cull_counters(f.counters[1]);
  state.counters["nodes"] = double(c.nodes_visited);
  state.counters["candidates"] = double(c.cluster_candidates);
  state.counters["visible"] = double(read_visible_list(f.visible[0]).size());
}
BENCHMARK(BM_GpuCullTraversal)->Args({1, 0})->Args({1, 1})->Args({100, 0})->Args({100, 1})->Args({1000, 0})
    ->Args({1000, 1})->UseManualTime()->Unit(benchmark::kMillisecond);

void BM_HzbBuild(benchmark::State& state) {
  std::vector<uint64_t> keys(1280 * 720);
  for (size_t i = 0; i < keys.size(); ++i) keys[i] = uint64_t(0x3c000000u + (i * 2654435761u) % 0x1000000u) << 32;
  ThreadPool pool(unsigned(state.range(0)));
  Hzb hzb;
  for (auto _ : state) build_hzb(keys.data(), 1280, 720, pool, &hzb);
}
BENCHMARK(BM_HzbBuild)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond);

void BM_GpuHzbBuild(benchmark::State& state) {
  BenchGpu* g = bench_gpu();
  if (!g) return state.SkipWithError("no Vulkan device");
  std::vector<ClusterDag> meshes;
  std::vector<CullInstance> instances;
  GpuCullFrame f = create_cull_frame(*g->context, meshes, instances, 1280, 720);
  Camera camera;
  write_cull_params(f, 0, make_view(camera), 1.0f, true, nullptr);
  GpuBuffer vis = create_gpu_buffer(*g->context, 1280 * 720 * 8);
  uint64_t* keys = vis.data<uint64_t>();
  for (size_t i = 0; i < 1280 * 720; ++i) keys[i] = uint64_t(0x3c000000u + (i * 2654435761u) % 0x1000000u) << 32;
  GpuRecorder& rec = *g->recorder;
  for (auto _ : state) {
    begin_commands(rec);
    uint32_t t0 = cmd_timestamp(rec);
    cmd_build_hzb(rec, g->pipelines, f, vis, f.hzb);
    uint32_t t1 = cmd_timestamp(rec);
    submit_and_wait(rec);
    state.SetIterationTime(timestamp_ms(rec, t0, t1) * 1e-3);
  }
}
BENCHMARK(BM_GpuHzbBuild)->UseManualTime()->Unit(benchmark::kMillisecond);

void BM_DefaultSceneFrame(benchmark::State& state) {
  static std::unique_ptr<SceneFile> scene;
  if (!scene) scene = std::make_unique<SceneFile>(make_default_scene(1280, 720, 1, {}));
  ThreadPool pool(unsigned(state.range(0)));
  Frame frame;
  for (auto _ : state) render_frame({scene->scene, scene->cameras[0], scene->settings, pool, nullptr}, &frame);
  for (const PassStats& p : frame.stats.passes) state.counters[p.name + "_ms"] = p.ms;
  state.counters["triangles"] = double(frame.stats.triangles_drawn);
}
BENCHMARK(BM_DefaultSceneFrame)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond);

// Generated sphere radius 1 (at most +12% displacement, lib/vgeo/mesh/generate.cpp): 2.4 leaves
// small gaps between neighbours.
constexpr double kScalingSpacing = 2.4;

void BM_Scaling(benchmark::State& state) {
  const char* r = std::getenv("VGEO_SCALING_RINGS");
  uint32_t rings = r ? uint32_t(std::atoi(r)) : 512;
  RenderScene scene;
  scene.meshes.push_back(sphere_dag(rings));
  scene.materials.push_back({});
  uint32_t k = uint32_t(state.range(0));
  scene.instances = grid_instances(k, kScalingSpacing);
  analyze_render_scene(&scene);
  Camera cam = grid_camera(k, kScalingSpacing);
  ThreadPool pool(0);
  RenderSettings settings;
  settings.occlusion = false;  // one frame: no history to test against
  Frame frame;
  for (auto _ : state) render_frame({scene, cam, settings, pool, nullptr}, &frame);
  state.counters["mesh_triangles"] = double(scene.meshes[0].triangle_count());
  state.counters["triangles_drawn"] = double(frame.stats.triangles_drawn);
  state.counters["pixels_covered"] = double(frame.stats.pixels_covered);
  state.counters["tri_per_pixel"] = double(frame.stats.triangles_drawn) / double(frame.stats.pixels);
  for (const PassStats& p : frame.stats.passes) state.counters[p.name + "_ms"] = p.ms;
}

// Heavy: registered only on request so `vgeo_microbench` stays quick by default.
const bool kScalingRegistered = [] {
  if (std::getenv("VGEO_BENCH_SCALING"))
    benchmark::RegisterBenchmark("BM_Scaling", BM_Scaling)
        ->Arg(1)->Arg(10)->Arg(100)->Arg(1000)->Arg(10000)->Iterations(1)->Unit(benchmark::kMillisecond);
  return true;
}();

}  // namespace
}  // namespace vgeo
