// Vulkan frame executor (gpu_frame.h, spec/gpu.md §Frame).
#include "vgeo/gpu/gpu_frame.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstring>

#include "vgeo/core/error.h"
#include "vgeo/core/lod.h"
#include "vgeo/gpu/shader_records.h"
#include "vgeo/gpu/shaders.h"

namespace vgeo {

MemoryFormScene make_memory_form_scene(const RenderScene& scene) {
  BuiltScene built;
  built.meshes = scene.meshes;
  built.materials = scene.materials;
  // The memory form does not depend on the disk compression: skip zstd (level 19 costs
  // seconds on the default scene).
  FormatOptions format;
  format.compression = Compression::kNone;
  const std::vector<uint8_t> bytes = encode_format(built, format);
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
  std::unique_ptr<GpuRasterPasses> raster;
  GpuRendererOptions options;
  ComputePipeline shade;
  GpuBuffer pages, locations, meshes, materials;
  // Per frame, grown on demand.
  GpuBuffer instances, visible, vis, counters, shade_instances, shade_clusters, overdraw, image;
};

void GpuRendererDeleter::operator()(GpuRenderer* r) const { delete r; }

namespace {

// Shade shader bindings: the raster ones less counters, then shade instances, shade clusters,
// materials, overdraw, image.
constexpr uint32_t kShadeBindings = 11;
constexpr uint32_t kShadeGroupSize = 64;  // shaders/shade.comp local_size_x

template <class T>
GpuBuffer upload(GpuContext& gpu, const std::vector<T>& data) {
  GpuBuffer b = create_gpu_buffer(gpu, data.size() * sizeof(T));
  if (!data.empty()) std::memcpy(b.mapped, data.data(), data.size() * sizeof(T));
  return b;
}

// Keeps `buffer` at least `bytes` long (contents not preserved).
void ensure_size(GpuContext& gpu, GpuBuffer& buffer, uint64_t bytes) { ensure_gpu_buffer(gpu, buffer, bytes); }

void check_buffer_range(const GpuContext& gpu, uint64_t bytes, const char* what) {
  if (bytes > gpu.properties.limits.maxStorageBufferRange)
    fail("GPU_SCENE_TOO_LARGE", gpu.device_name,
         std::string(what) + " needs " + std::to_string(bytes) + " bytes, more than one storage buffer (" +
             std::to_string(gpu.properties.limits.maxStorageBufferRange) + ")",
         kExitUsage);
}

// Rasterizes visible[first, first + count) into the vis buffer by the renderer's raster mode
// (hw_raster.h); returns the GPU time and the pixels written, adds the split to `split`.
void raster_range(GpuRenderer& r, uint32_t width, uint32_t height, float z_near, float pixels_per_unit_at_1,
                  bool cull_backfaces, uint32_t first, uint32_t count, PassStats* stats, RasterSplitStats* split) {
  GpuRecorder& rec = *r.recorder;
  begin_commands(rec);
  cmd_fill(rec, r.counters, 0);
  GpuRasterRequest request;
  request.mode = r.options.raster;
  request.first_visible = first;
  request.visible_count = count;
  request.width = width;
  request.height = height;
  request.z_near = z_near;
  request.pixels_per_unit_at_1 = pixels_per_unit_at_1;
  request.hw_min_triangle_area_px = r.options.hw_min_triangle_area_px;
  request.cull_backfaces = cull_backfaces;
  uint32_t t0 = cmd_timestamp(rec);
  record_gpu_raster(rec, *r.raster, {&r.pages, &r.locations, &r.meshes, &r.instances, &r.visible, &r.vis, &r.counters},
                    request);
  uint32_t t1 = cmd_timestamp(rec);
  submit_and_wait(rec);
  stats->ms = timestamp_ms(rec, t0, t1);
  stats->pixels_written = r.counters.data<uint64_t>()[0];
  split->add(read_gpu_raster_split(*r.raster));
}

// Uploads the per-frame raster inputs and clears the visibility buffer.
void upload_raster_inputs(GpuRenderer& r, const std::vector<Mat4>& object_to_clip, const std::vector<uint32_t>& mesh,
                          const std::vector<float>& instance_scale, const std::vector<VisibleCluster>& visible,
                          uint32_t width, uint32_t height) {
  GpuContext& gpu = *r.gpu;
  std::vector<GpuInstance> instances(object_to_clip.size());
  for (size_t i = 0; i < instances.size(); ++i) {
    std::memcpy(instances[i].object_to_clip, object_to_clip[i].m, sizeof(instances[i].object_to_clip));
    instances[i].mesh = mesh[i];
  }
  ensure_size(gpu, r.instances, instances.size() * sizeof(GpuInstance));
  if (!instances.empty()) std::memcpy(r.instances.mapped, instances.data(), instances.size() * sizeof(GpuInstance));
  static_assert(sizeof(VisibleCluster) == sizeof(GpuVisibleCluster));
  ensure_size(gpu, r.visible, visible.size() * sizeof(GpuVisibleCluster));
  if (!visible.empty()) std::memcpy(r.visible.mapped, visible.data(), visible.size() * sizeof(GpuVisibleCluster));
  prepare_gpu_raster(*r.raster, instance_scale, uint32_t(visible.size()));
  const uint64_t vis_bytes = uint64_t(width) * height * 8;
  check_buffer_range(gpu, vis_bytes, "the visibility buffer");
  ensure_size(gpu, r.vis, vis_bytes);
  std::memset(r.vis.mapped, 0, vis_bytes);
}

// shade.cpp shade_frame on the GPU: every view, from the visibility buffer now in r.vis.
void shade_pass(GpuRenderer& r, const RenderScene& scene, const RenderSettings& settings, const Camera& camera,
                Frame* out) {
  GpuContext& gpu = *r.gpu;
  const ShadeInput defaults;
  std::vector<GpuShadeInstance> si(scene.instances.size());
  for (size_t i = 0; i < si.size(); ++i) {
    std::copy(std::begin(out->instance_views[i].object_to_view.m), std::end(out->instance_views[i].object_to_view.m),
              si[i].object_to_view);
    double nm[3][3];
    shade_normal_matrix(scene.instances[i].object_to_world, nm);
    for (int row = 0; row < 3; ++row)
      for (int col = 0; col < 3; ++col) si[i].normal_matrix[3 * row + col] = nm[row][col];
  }
  LodView lv;
  lv.pixels_per_unit_at_1 = out->view.pixels_per_unit_at_1;
  lv.z_near = float(out->view.z_near);
  std::vector<GpuShadeCluster> sc(out->visible.size());
  for (size_t i = 0; i < sc.size(); ++i) {
    const VisibleCluster& v = out->visible[i];
    const ClusterDag& dag = scene.meshes[scene.instances[v.instance].mesh];
    const DagCluster& c = dag.clusters[v.cluster];
    const InstanceView& iv = out->instance_views[v.instance];
    sc[i] = {c.group, c.level, dag.level_count,
             projected_error(sphere_to_view(iv.object_to_view, iv.scale, c.lod_bounds), error_to_view(c.lod_error, iv.scale), lv)};
  }
  const uint64_t pixels = uint64_t(camera.width) * camera.height;
  ensure_size(gpu, r.shade_instances, si.size() * sizeof(GpuShadeInstance));
  if (!si.empty()) std::memcpy(r.shade_instances.mapped, si.data(), si.size() * sizeof(GpuShadeInstance));
  ensure_size(gpu, r.shade_clusters, sc.size() * sizeof(GpuShadeCluster));
  if (!sc.empty()) std::memcpy(r.shade_clusters.mapped, sc.data(), sc.size() * sizeof(GpuShadeCluster));
  uint32_t max_overdraw = 1;
  const bool overdraw = settings.view == ShadeView::kOverdraw && !out->overdraw.empty();
  ensure_size(gpu, r.overdraw, overdraw ? pixels * 4 : 4);
  if (overdraw) {
    std::memcpy(r.overdraw.mapped, out->overdraw.data(), pixels * 4);
    for (uint32_t c : out->overdraw) max_overdraw = std::max(max_overdraw, c);
  }
  ensure_size(gpu, r.image, pixels * 4);

  GpuShadeParams params{};
  params.tan_half_x = out->view.tan_half_x;
  params.tan_half_y = out->view.tan_half_y;
  const Vec3 L = defaults.light_direction;
  const double ll = std::sqrt(double(L.x) * L.x + double(L.y) * L.y + double(L.z) * L.z);
  params.light[0] = L.x / ll;
  params.light[1] = L.y / ll;
  params.light[2] = L.z / ll;
  params.width = camera.width;
  params.height = camera.height;
  params.view = uint32_t(settings.view);
  params.material_count = uint32_t(scene.materials.size());
  params.ambient = defaults.ambient;
  params.threshold_px = settings.threshold_px;
  params.max_overdraw = max_overdraw;
  GpuRecorder& rec = *r.recorder;
  begin_commands(rec);
  uint32_t t0 = cmd_timestamp(rec);
  cmd_dispatch(rec, r.shade,
               {&r.pages, &r.locations, &r.meshes, &r.instances, &r.visible, &r.vis, &r.shade_instances,
                &r.shade_clusters, &r.materials, &r.overdraw, &r.image},
               &params, uint32_t((pixels + kShadeGroupSize - 1) / kShadeGroupSize));
  uint32_t t1 = cmd_timestamp(rec);
  submit_and_wait(rec);

  out->image.width = camera.width;
  out->image.height = camera.height;
  out->image.rgb.resize(pixels * 3);
  const uint32_t* rgba = r.image.data<uint32_t>();
  for (uint64_t p = 0; p < pixels; ++p)
    for (int k = 0; k < 3; ++k) out->image.rgb[3 * p + k] = uint8_t(rgba[p] >> (8 * k));
  FrameStats& stats = out->stats;
  std::erase_if(stats.skipped, [](const auto& s) { return s.first == "shade"; });
  PassStats pass;
  pass.name = "shade";
  pass.ms = timestamp_ms(rec, t0, t1);
  stats.passes.push_back(pass);
}

}  // namespace

std::vector<GpuClusterRasterInfo> cluster_raster_infos(const MemoryFormScene& scene) {
  std::vector<GpuClusterRasterInfo> infos;
  for (const ClusterDag& dag : scene.scene.meshes)
    for (const DagCluster& c : dag.clusters) {
      GpuClusterRasterInfo info{};
      info.center[0] = c.bounds.center.x;
      info.center[1] = c.bounds.center.y;
      info.center[2] = c.bounds.center.z;
      info.radius = c.bounds.radius;
      info.triangle_count = c.triangle_count;
      infos.push_back(info);
    }
  return infos;
}

GpuRendererPtr create_gpu_renderer(GpuContext& gpu, const MemoryFormScene& scene, const GpuRendererOptions& options) {
  GpuRendererPtr r(new GpuRenderer);
  r->gpu = &gpu;
  r->options = options;
  r->recorder = create_gpu_recorder(gpu);
  r->raster = create_gpu_raster_passes(gpu, cluster_raster_infos(scene));
  r->shade = create_compute_pipeline(gpu, kShaderShade, kShadeBindings, sizeof(GpuShadeParams));

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
  std::vector<GpuMaterial> materials(scene.scene.materials.size());
  for (size_t i = 0; i < materials.size(); ++i)
    std::copy(scene.scene.materials[i].base_color.begin(), scene.scene.materials[i].base_color.end(), materials[i].base_color);
  r->materials = upload(gpu, materials);
  return r;
}

void render_frame_vulkan(GpuRenderer& r, const MemoryFormScene& mscene, const Camera& camera,
                         const RenderSettings& settings, ThreadPool& pool, FrameHistory* history, Frame* out,
                         bool has_next_frame, RasterSplitStats* split) {
  const RenderScene& scene = mscene.scene;
  // Host cull (the CPU reference's passes) decides the visible clusters; its raster output
  // is replaced below by the GPU's.
  // The overdraw counts are still computed on the host: frame.cpp runs that pass only
  // together with its own shading, whose image and "shade" pass are replaced below.
  RenderSettings host = settings;
  host.shade = settings.shade && settings.view == ShadeView::kOverdraw;
  render_frame(scene, camera, host, pool, history, out, has_next_frame);
  std::erase_if(out->stats.passes, [](const PassStats& p) { return p.name == "shade"; });

  // Per-instance object→clip matrices exactly as frame.cpp (float, from double products).
  const Mat4d view_to_clip =
      perspective_reversed_z(camera.fov_y, double(camera.width) / double(camera.height), camera.z_near);
  std::vector<Mat4> object_to_clip(scene.instances.size());
  std::vector<uint32_t> mesh(scene.instances.size());
  std::vector<float> scale(scene.instances.size());
  for (size_t i = 0; i < scene.instances.size(); ++i) {
    object_to_clip[i] = to_float(view_to_clip * out->instance_views[i].object_to_view);
    mesh[i] = scene.instances[i].mesh;
    scale[i] = float(out->instance_views[i].scale);
  }
  upload_raster_inputs(r, object_to_clip, mesh, scale, out->visible, camera.width, camera.height);

  FrameStats& stats = out->stats;
  const uint32_t n = uint32_t(out->visible.size()), n1 = out->pass1_visible;
  // frame.cpp raster_pass: RasterOptions::z_near = float(z_near), default back-face culling.
  const float z_near = float(camera.z_near);
  const bool cull_backfaces = RasterOptions{}.cull_backfaces;
  RasterSplitStats frame_split;
  for (PassStats& p : stats.passes) {
    if (p.name == "raster")
      raster_range(r, camera.width, camera.height, z_near, out->view.pixels_per_unit_at_1, cull_backfaces, 0, n1, &p,
                   &frame_split);
    if (p.name == "raster_post")
      raster_range(r, camera.width, camera.height, z_near, out->view.pixels_per_unit_at_1, cull_backfaces, n1, n - n1,
                   &p, &frame_split);
  }
  if (split) *split = frame_split;
  const uint64_t vis_bytes = uint64_t(camera.width) * camera.height * 8;
  std::memcpy(out->vis.keys.data(), r.vis.mapped, vis_bytes);
  uint64_t covered = 0;
  for (uint64_t k : out->vis.keys) covered += k != 0;
  stats.pixels_covered = covered;

  if (settings.shade) shade_pass(r, scene, settings, camera, out);
  // Frame time: the passes' own times (host cull + GPU raster/shade); the host reference's
  // raster, which render_frame also ran, is not part of this backend's frame.
  stats.total_ms = 0;
  for (const PassStats& p : stats.passes) stats.total_ms += p.ms;
}

void raster_visible_vulkan(GpuRenderer& r, const GpuRasterInput& in, GpuRasterOutput* out) {
  upload_raster_inputs(r, in.object_to_clip, in.instance_mesh, in.instance_scale, in.visible, in.width, in.height);
  PassStats pass;
  out->split = {};
  raster_range(r, in.width, in.height, in.z_near, in.pixels_per_unit_at_1, in.cull_backfaces, 0,
               uint32_t(in.visible.size()), &pass, &out->split);
  out->ms = pass.ms;
  out->pixels_written = pass.pixels_written;
  out->vis.width = in.width;
  out->vis.height = in.height;
  out->vis.keys.resize(size_t(in.width) * in.height);
  std::memcpy(out->vis.keys.data(), r.vis.mapped, out->vis.keys.size() * 8);
}

}  // namespace vgeo
