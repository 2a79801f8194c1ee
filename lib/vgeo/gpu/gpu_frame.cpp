// Vulkan frame executor (gpu_frame.h, spec/gpu.md §Frame).
#include "vgeo/gpu/gpu_frame.h"

#include <algorithm>
#include <cassert>
#include <cstring>

#include "vgeo/core/error.h"
#include "vgeo/gpu/shader_records.h"
#include "vgeo/gpu/shaders.h"

namespace vgeo {

MemoryFormScene make_memory_form_scene(const RenderScene& scene) {
  BuiltScene built;
  built.meshes = scene.meshes;
  built.materials = scene.materials;
  const std::vector<uint8_t> bytes = encode_format(built, FormatOptions{});
  const std::string where = "<memory form>";
  const FormatContainer container = parse_container(bytes.data(), bytes.size(), where);
  BuiltScene decoded = decode_format(bytes.data(), bytes.size(), where);

  MemoryFormScene out;
  out.scene = scene;
  out.scene.meshes = std::move(decoded.meshes);
  analyze_render_scene(&out.scene);
  out.pages.resize(container.pages.size());
  for (uint32_t p = 0; p < container.pages.size(); ++p) {
    const PageEntry& e = container.pages[p];
    out.pages[p] = transcode_page(container, p, bytes.data() + e.file_offset, e.stored_size, where);
  }
  out.quantization.resize(container.meshes.size());
  out.cluster_page.resize(container.meshes.size());
  for (uint32_t m = 0; m < container.meshes.size(); ++m) {
    const MeshMetadata& mm = container.meshes[m];
    out.quantization[m] = mm.quantization;
    out.cluster_page[m].resize(mm.dag.clusters.size());
    for (uint32_t p = mm.first_page; p < mm.first_page + mm.page_count; ++p) {
      const PageEntry& e = container.pages[p];
      for (uint32_t k = 0; k < e.cluster_count; ++k) out.cluster_page[m][mm.page_clusters[e.first_cluster_slot + k]] = {p, k};
    }
  }
  return out;
}

struct GpuRenderer {
  GpuContext* gpu = nullptr;
  std::unique_ptr<GpuRecorder> recorder;
  ComputePipeline raster;
  GpuBuffer pages, locations, meshes;
  // Per frame, grown on demand.
  GpuBuffer instances, visible, vis, counters;
};

void GpuRendererDeleter::operator()(GpuRenderer* r) const { delete r; }

namespace {

// Raster shader bindings: pages, locations, meshes, instances, visible, vis, counters.
constexpr uint32_t kRasterBindings = 7;

template <class T>
GpuBuffer upload(GpuContext& gpu, const std::vector<T>& data) {
  GpuBuffer b = create_gpu_buffer(gpu, data.size() * sizeof(T));
  if (!data.empty()) std::memcpy(b.mapped, data.data(), data.size() * sizeof(T));
  return b;
}

// Keeps `buffer` at least `bytes` long (contents not preserved).
void ensure_size(GpuContext& gpu, GpuBuffer& buffer, uint64_t bytes) {
  if (buffer.buffer == VK_NULL_HANDLE || buffer.size < bytes) buffer = create_gpu_buffer(gpu, bytes);
}

void check_buffer_range(const GpuContext& gpu, uint64_t bytes, const char* what) {
  if (bytes > gpu.properties.limits.maxStorageBufferRange)
    fail("GPU_SCENE_TOO_LARGE", gpu.device_name,
         std::string(what) + " needs " + std::to_string(bytes) + " bytes, more than one storage buffer (" +
             std::to_string(gpu.properties.limits.maxStorageBufferRange) + ")",
         kExitUsage);
}

// Dispatches the raster shader over visible[first, first + count) into the vis buffer;
// returns the GPU time and the pixels written.
void raster_range(GpuRenderer& r, const Camera& camera, uint32_t first, uint32_t count, PassStats* stats) {
  GpuRecorder& rec = *r.recorder;
  begin_commands(rec);
  cmd_fill(rec, r.counters, 0);
  GpuRasterParams params{};
  params.width = camera.width;
  params.height = camera.height;
  params.first_visible = first;
  params.visible_count = count;
  params.groups_x = std::min(count, kGpuMaxGroupsX);
  params.cull_backfaces = RasterOptions{}.cull_backfaces ? 1u : 0u;
  params.z_near = float(camera.z_near);  // frame.cpp raster_pass: RasterOptions::z_near = float(z_near)
  const uint32_t groups_y = params.groups_x ? (count + params.groups_x - 1) / params.groups_x : 0;
  uint32_t t0 = cmd_timestamp(rec);
  cmd_dispatch(rec, r.raster, {&r.pages, &r.locations, &r.meshes, &r.instances, &r.visible, &r.vis, &r.counters},
               &params, params.groups_x, groups_y);
  uint32_t t1 = cmd_timestamp(rec);
  submit_and_wait(rec);
  stats->ms = timestamp_ms(rec, t0, t1);
  stats->pixels_written = r.counters.data<uint64_t>()[0];
}

}  // namespace

GpuRendererPtr create_gpu_renderer(GpuContext& gpu, const MemoryFormScene& scene) {
  GpuRendererPtr r(new GpuRenderer);
  r->gpu = &gpu;
  r->recorder = create_gpu_recorder(gpu);
  r->raster = create_compute_pipeline(gpu, kShaderRaster, kRasterBindings, sizeof(GpuRasterParams));

  std::vector<uint32_t> page_word(scene.pages.size());
  uint64_t words = 0;
  for (size_t p = 0; p < scene.pages.size(); ++p) {
    page_word[p] = uint32_t(std::min<uint64_t>(words, UINT32_MAX));
    words += scene.pages[p].size();
  }
  check_buffer_range(gpu, words * 4, "the memory-form pages");
  std::vector<uint32_t> all(words);
  for (size_t p = 0; p < scene.pages.size(); ++p)
    std::copy(scene.pages[p].begin(), scene.pages[p].end(), all.begin() + page_word[p]);
  r->pages = upload(gpu, all);

  std::vector<GpuClusterLocation> locations;
  std::vector<GpuMesh> meshes(scene.cluster_page.size());
  for (size_t m = 0; m < scene.cluster_page.size(); ++m) {
    meshes[m].first_location = uint32_t(locations.size());
    meshes[m].position_step_log2 = scene.quantization[m].position_step_log2;
    meshes[m].channel_count = scene.quantization[m].channel_count();
    meshes[m].normal_bits = scene.quantization[m].has_normals ? scene.quantization[m].normal_bits : 0;
    for (const auto& [page, index] : scene.cluster_page[m]) locations.push_back({page_word[page], index});
  }
  r->locations = upload(gpu, locations);
  r->meshes = upload(gpu, meshes);
  r->counters = create_gpu_buffer(gpu, 64);
  return r;
}

void render_frame_vulkan(GpuRenderer& r, const MemoryFormScene& mscene, const Camera& camera,
                         const RenderSettings& settings, ThreadPool& pool, FrameHistory* history, Frame* out,
                         bool has_next_frame) {
  GpuContext& gpu = *r.gpu;
  const RenderScene& scene = mscene.scene;
  // Host cull (the CPU reference's passes) decides the visible clusters; its raster output
  // is replaced below by the GPU's.
  RenderSettings host = settings;
  host.shade = false;
  render_frame(scene, camera, host, pool, history, out, has_next_frame);

  // Per-instance object→clip matrices exactly as frame.cpp (float, from double products).
  const Mat4d view_to_clip =
      perspective_reversed_z(camera.fov_y, double(camera.width) / double(camera.height), camera.z_near);
  std::vector<GpuInstance> instances(scene.instances.size());
  for (size_t i = 0; i < instances.size(); ++i) {
    const Mat4 m = to_float(view_to_clip * out->instance_views[i].object_to_view);
    std::memcpy(instances[i].object_to_clip, m.m, sizeof(instances[i].object_to_clip));
    instances[i].mesh = scene.instances[i].mesh;
  }
  ensure_size(gpu, r.instances, instances.size() * sizeof(GpuInstance));
  std::memcpy(r.instances.mapped, instances.data(), instances.size() * sizeof(GpuInstance));
  static_assert(sizeof(VisibleCluster) == sizeof(GpuVisibleCluster));
  ensure_size(gpu, r.visible, out->visible.size() * sizeof(GpuVisibleCluster));
  if (!out->visible.empty()) std::memcpy(r.visible.mapped, out->visible.data(), out->visible.size() * sizeof(GpuVisibleCluster));
  const uint64_t vis_bytes = uint64_t(camera.width) * camera.height * 8;
  check_buffer_range(gpu, vis_bytes, "the visibility buffer");
  ensure_size(gpu, r.vis, vis_bytes);
  std::memset(r.vis.mapped, 0, vis_bytes);

  FrameStats& stats = out->stats;
  const uint32_t n = uint32_t(out->visible.size()), n1 = out->pass1_visible;
  for (PassStats& p : stats.passes) {
    if (p.name == "raster") raster_range(r, camera, 0, n1, &p);
    if (p.name == "raster_post") raster_range(r, camera, n1, n - n1, &p);
  }
  std::memcpy(out->vis.keys.data(), r.vis.mapped, vis_bytes);
  uint64_t covered = 0;
  for (uint64_t k : out->vis.keys) covered += k != 0;
  stats.pixels_covered = covered;

  if (settings.shade) {
    ShadeInput in;
    in.vis = &out->vis;
    in.visible = &out->visible;
    in.meshes = &scene.meshes;
    in.materials = &scene.materials;
    in.instances = &scene.instances;
    in.instance_views = &out->instance_views;
    in.view = &out->view;
    in.threshold_px = settings.threshold_px;
    in.overdraw = out->overdraw.empty() ? nullptr : &out->overdraw;
    shade_frame(in, settings.view, pool, &out->image);
  }
}

}  // namespace vgeo
