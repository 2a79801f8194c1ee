// Backend runner and comparison (backend_run.h).
#include "vgeo/gpu/backend_run.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <sstream>
#include <tuple>

#include <nlohmann/json.hpp>

#include "vgeo/core/error.h"
#include "vgeo/core/file_io.h"
#include "vgeo/core/hash.h"
#include "vgeo/gpu/gpu_frame.h"
#include "vgeo/render/run.h"

namespace vgeo {

bool parse_backend(const std::string& name, Backend* out) {
  if (name == "cpu") *out = Backend::kCpu;
  else if (name == "vulkan") *out = Backend::kVulkan;
  else return false;
  return true;
}

const char* backend_name(Backend backend) { return backend == Backend::kCpu ? "cpu" : "vulkan"; }

namespace {

// What a key denotes, independent of the visible-cluster list's order. Background: zeros
// (depth bits 0 never occur in a written key).
struct Denoted {
  uint32_t depth_bits = 0, instance = 0, cluster = 0, triangle = 0;
  friend bool operator==(const Denoted&, const Denoted&) = default;
};
Denoted denote(uint64_t key, const std::vector<VisibleCluster>& visible) {
  if (key == 0) return {};
  const VisibleCluster& v = visible[vis_key_cluster(key)];
  return {vis_key_depth_bits(key), v.instance, v.cluster, vis_key_triangle(key)};
}

std::string hex64(uint64_t v) {
  char buf[24];
  std::snprintf(buf, sizeof buf, "%016llx", (unsigned long long)v);
  return buf;
}

// The triangle a key denotes, as the exact model sees it (hw_rule.h), with the frame's own
// float object→clip matrix (as gpu_frame.cpp and frame.cpp make it).
struct TriangleModels {
  const RenderScene& scene;
  const std::vector<ClusterDag>& geometry;  // the scene's meshes, or a streamed frame's (streaming.h)
  const Camera& camera;
  const Frame& frame;
  std::map<std::tuple<uint32_t, uint32_t, uint32_t>, ModelTriangle> cache;
  const ModelTriangle* of(const Denoted& d) {
    if (d.depth_bits == 0) return nullptr;
    auto [it, fresh] = cache.try_emplace({d.instance, d.cluster, d.triangle});
    if (fresh) {
      const Mat4d view_to_clip =
          perspective_reversed_z(camera.fov_y, double(camera.width) / double(camera.height), camera.z_near);
      const Mat4 m = to_float(view_to_clip * frame.instance_views[d.instance].object_to_view);
      const ClusterDag& dag = geometry[scene.instances[d.instance].mesh];
      const DagCluster& c = dag.clusters[d.cluster];
      Vec3 v[3];
      for (int k = 0; k < 3; ++k) v[k] = dag.position(c.vertex_offset + dag.indices[3 * (c.triangle_offset + d.triangle) + k]);
      it->second = model_triangle(v, m, float(camera.z_near), camera.width, camera.height);
    }
    return &it->second;
  }
};

// spec/raster.md §13.3 over one frame: every pixel classified (hw_rule.h).
HwRasterAgreement compare_hw_frame(const RenderScene& scene, const std::vector<ClusterDag>& geometry, const Camera& camera,
                                   const Frame& cpu, const Frame& gpu) {
  HwRasterAgreement agreement;
  TriangleModels models{scene, geometry, camera, cpu, {}};
  for (uint32_t y = 0; y < cpu.vis.height; ++y)
    for (uint32_t x = 0; x < cpu.vis.width; ++x) {
      const size_t p = size_t(y) * cpu.vis.width + x;
      const Denoted a = denote(cpu.vis.keys[p], cpu.visible), b = denote(gpu.vis.keys[p], gpu.visible);
      const bool same = a.depth_bits && b.depth_bits && a.instance == b.instance && a.cluster == b.cluster &&
                        a.triangle == b.triangle;
      const HwPixel kind = a == b ? HwPixel::kIdentical
                                  : classify_hw_pixel(cpu.vis.keys[p], gpu.vis.keys[p], same, models.of(a), models.of(b), x, y);
      ++agreement.pixels[int(kind)];
      if (same && kind != HwPixel::kIdentical) {
        const double tol = models.of(a)->depth_tolerance;
        const double dz = std::abs(double(vis_key_depth(cpu.vis.keys[p])) - double(vis_key_depth(gpu.vis.keys[p])));
        if (tol > 0) agreement.max_depth_error_ratio = std::max(agreement.max_depth_error_ratio, dz / tol);
      }
    }
  return agreement;
}

// `geometry`: what the CPU frame drew from (the scene's meshes, or its streamed frame's).
FrameComparison compare_frames(const RenderScene& scene, const std::vector<ClusterDag>& geometry, const Camera& camera,
                               const Frame& cpu, const Frame& gpu, bool shaded, bool hw_rule) {
  FrameComparison c;
  std::vector<VisibleCluster> a = cpu.visible, b = gpu.visible;
  std::sort(a.begin(), a.end());
  std::sort(b.begin(), b.end());
  c.clusters_equal = a == b;
  for (size_t p = 0; p < cpu.vis.keys.size(); ++p)
    c.vis_pixels_differing += !(denote(cpu.vis.keys[p], cpu.visible) == denote(gpu.vis.keys[p], gpu.visible));
  c.hw_rule = hw_rule;
  if (hw_rule && c.clusters_equal) c.hw = compare_hw_frame(scene, geometry, camera, cpu, gpu);
  c.shaded = shaded;
  if (shaded)
    for (size_t p = 0; p < cpu.image.rgb.size() / 3; ++p) {
      // The hardware rule compares shading where the keys are identical (elsewhere the
      // pixel shows another surface or depth, which the rule allows).
      if (hw_rule && !(denote(cpu.vis.keys[p], cpu.visible) == denote(gpu.vis.keys[p], gpu.visible))) continue;
      int d = 0;
      for (int k = 0; k < 3; ++k) d = std::max(d, std::abs(int(cpu.image.rgb[3 * p + k]) - int(gpu.image.rgb[3 * p + k])));
      c.max_channel_diff = std::max(c.max_channel_diff, d);
      c.pixels_over += d > 1;
    }
  return c;
}

// Diff image: red = the visibility key differs, green = shaded difference (×64, so 1/255
// shows dim and anything over the rule bright), black = identical.
Image diff_image(const Frame& cpu, const Frame& gpu) {
  Image d;
  d.width = cpu.vis.width;
  d.height = cpu.vis.height;
  d.rgb.assign(size_t(d.width) * d.height * 3, 0);
  for (size_t p = 0; p < size_t(d.width) * d.height; ++p) {
    if (!(denote(cpu.vis.keys[p], cpu.visible) == denote(gpu.vis.keys[p], gpu.visible))) d.rgb[3 * p] = 255;
    int m = 0;
    if (!cpu.image.rgb.empty() && !gpu.image.rgb.empty())
      for (int k = 0; k < 3; ++k) m = std::max(m, std::abs(int(cpu.image.rgb[3 * p + k]) - int(gpu.image.rgb[3 * p + k])));
    d.rgb[3 * p + 1] = uint8_t(std::min(255, 64 * m));
  }
  return d;
}

void write_failure(const std::string& dir, uint32_t f, const Frame& cpu, const Frame& gpu) {
  char stem[32];
  std::snprintf(stem, sizeof stem, "/frame_%05u", f);
  write_png(dir + stem + "_diff.png", diff_image(cpu, gpu));
  std::ostringstream out;
  out << "# x y | cpu: depth_bits instance cluster triangle | vulkan: depth_bits instance cluster triangle\n";
  for (uint32_t y = 0; y < cpu.vis.height; ++y)
    for (uint32_t x = 0; x < cpu.vis.width; ++x) {
      const size_t p = size_t(y) * cpu.vis.width + x;
      const Denoted a = denote(cpu.vis.keys[p], cpu.visible), b = denote(gpu.vis.keys[p], gpu.visible);
      if (a == b) continue;
      out << x << ' ' << y << " | " << a.depth_bits << ' ' << a.instance << ' ' << a.cluster << ' ' << a.triangle
          << " | " << b.depth_bits << ' ' << b.instance << ' ' << b.cluster << ' ' << b.triangle << '\n';
    }
  write_file_atomic(dir + stem + "_pixels.txt", out.str());
}

}  // namespace

uint64_t vis_buffer_hash(const VisBuffer& vis, const std::vector<VisibleCluster>& visible) {
  uint64_t h = kFnvOffset;
  for (uint64_t key : vis.keys) {
    const Denoted d = denote(key, visible);
    const uint32_t words[4] = {d.depth_bits, d.instance, d.cluster, d.triangle};
    h = fnv1a64(words, sizeof words, h);
  }
  return h;
}

uint64_t cluster_set_hash(const std::vector<VisibleCluster>& visible) {
  std::vector<VisibleCluster> sorted = visible;
  std::sort(sorted.begin(), sorted.end());
  uint64_t h = kFnvOffset;
  for (const VisibleCluster& v : sorted) {
    const uint32_t words[2] = {v.instance, v.cluster};
    h = fnv1a64(words, sizeof words, h);
  }
  return h;
}

BackendRunReport run_backend(const SceneFile& file, const BackendRunRequest& request) {
  // The CPU reference draws the scene's decode; only the GPU reads the pages.
  return run_backend(file, request.backend == Backend::kVulkan ? memory_form_pages(file) : MemoryFormPages{}, request);
}

BackendRunReport run_backend(const SceneFile& file, const MemoryFormPages& pages, const BackendRunRequest& request,
                             GpuContext* shared_gpu) {
  uint32_t frames = 0;
  const RenderSettings settings = resolve_render_options(
      file, {request.threshold_px, request.view, request.occlusion, request.camera, request.frames}, &frames);
  const bool vulkan = request.backend == Backend::kVulkan;
  const bool compare = vulkan && request.compare_cpu;

  // Streamed (spec/gpu.md §Streaming): each renderer has its own Streamer over the scene's
  // page files and draws from its resident pages (the memory form as it is). A comparison
  // forces the deterministic loader on both, so both install the same pages in the same frame.
  std::unique_ptr<SceneStreaming> gpu_stream, cpu_stream;
  if (file.streaming) {
    if (vulkan) gpu_stream = start_scene_streaming(file, settings.threshold_px, compare);
    if (!vulkan || compare) cpu_stream = start_scene_streaming(file, settings.threshold_px, compare);
  }
  const RenderScene& gpu_scene = gpu_stream ? gpu_stream->scene : file.scene;
  const RenderScene& cpu_scene = cpu_stream ? cpu_stream->scene : file.scene;
  std::unique_ptr<GpuContext> own_gpu;
  GpuContext* gpu = shared_gpu;
  GpuRendererPtr renderer;
  size_t first_message = 0;
  if (vulkan) {
    if (!gpu) {
      own_gpu = create_gpu_context(request.gpu);
      gpu = own_gpu.get();
    }
    std::lock_guard<std::mutex> lock(gpu->messages_mutex);
    first_message = gpu->validation_messages.size();
  }
  if (vulkan) {
    GpuRendererOptions options;
    options.raster = request.raster;
    renderer = gpu_stream
                   ? create_gpu_renderer_streamed(*gpu, gpu_stream->scene, gpu_stream->frame, pages, request.traversal,
                                                  options)
                   : create_gpu_renderer(*gpu, file.scene, pages, request.traversal, options);
  }
  BackendRunReport report;
  report.backend = request.backend;
  report.raster = request.raster;
  if (gpu) report.device = gpu->device_name;
  ThreadPool pool(request.threads);
  FrameHistory history, cpu_history;
  Frame frame, cpu_frame;
  // The CPU reference's frame (render_frame's plan and executor, with streaming when streamed).
  auto render_cpu = [&](const Camera& cam, const RenderSettings& s, FrameHistory* h, Frame* out, bool next) {
    FrameStreaming* fs = cpu_stream ? &cpu_stream->frame : nullptr;
    const FramePlan plan = plan_frame(cpu_scene, s, frame_context(cpu_scene, cam, h, next, fs, file.stream_reason));
    const auto start = std::chrono::steady_clock::now();
    render_planned_frame(plan, cpu_scene, cam, s, pool, h, out, fs);
    out->stats.total_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  };
  for (uint32_t f = 0; f < frames; ++f) {
    const Camera& cam = file.path.empty() ? file.cameras[request.camera] : file.path[std::min<size_t>(f, file.path.size() - 1)];
    const bool last = f + 1 == frames;
    RenderSettings s = settings;
    s.shade = last;  // as render_scene: only the kept image is shaded
    RasterSplitStats split;
    if (vulkan)
      render_frame_vulkan(*renderer, gpu_scene, cam, s, pool, &history, &frame, !last,
                          gpu_stream ? &gpu_stream->frame : nullptr, file.stream_reason, &split);
    else
      render_cpu(cam, s, &history, &frame, !last);
    report.frames.push_back(frame.stats);
    if (vulkan) report.raster_split.push_back(split);
    if (compare) {
      render_cpu(cam, s, &cpu_history, &cpu_frame, !last);
      report.comparisons.push_back(
          compare_frames(cpu_scene, cpu_stream ? cpu_stream->frame.geometry : cpu_scene.meshes, cam, cpu_frame, frame,
                         last, request.raster != GpuRasterMode::kSw));
      report.rule_holds = report.rule_holds && report.comparisons.back().holds();
      if (!report.comparisons.back().holds() && !request.failure_dir.empty())
        write_failure(request.failure_dir, f, cpu_frame, frame);
    }
  }
  if (renderer && gpu_stream) report.pool = gpu_pool_stats(*renderer);
  report.width = frame.vis.width;
  report.height = frame.vis.height;
  report.vis_hash = vis_buffer_hash(frame.vis, frame.visible);
  report.cluster_set_hash = cluster_set_hash(frame.visible);
  report.image_hash = fnv1a64(frame.image.rgb.data(), frame.image.rgb.size());
  if (!request.output_png.empty()) write_png(request.output_png, frame.image);
  if (compare && !request.diff_png.empty()) write_png(request.diff_png, diff_image(cpu_frame, frame));
  renderer.reset();
  if (gpu) {
    std::lock_guard<std::mutex> lock(gpu->messages_mutex);
    report.validation_messages.assign(gpu->validation_messages.begin() + first_message, gpu->validation_messages.end());
  }
  return report;
}

std::string BackendRunReport::table() const {
  std::string out = "backend: " + std::string(backend_name(backend)) + (device.empty() ? "" : " (" + device + ")") + "\n";
  if (!frames.empty()) out += frame_stats_table(frames.back());
  if (!raster_split.empty()) {
    const RasterSplitStats& r = raster_split.back();
    char line[256];
    std::snprintf(line, sizeof line,
                  "raster paths (--raster %s): sw %llu clusters %llu triangles | hw %llu clusters %llu triangles\n",
                  gpu_raster_mode_name(raster), (unsigned long long)r.sw_clusters, (unsigned long long)r.sw_triangles,
                  (unsigned long long)r.hw_clusters, (unsigned long long)r.hw_triangles);
    out += line;
    if (r.sw_tiled_triangles) {
      std::snprintf(line, sizeof line, "sw big triangles drawn by tiles: %llu triangles, %llu tiles\n",
                    (unsigned long long)r.sw_tiled_triangles, (unsigned long long)r.sw_tiles);
      out += line;
    }
  }
  out += "vis_hash " + hex64(vis_hash) + "  cluster_set_hash " + hex64(cluster_set_hash) + "\n";
  if (pool.slots) {
    char line[200];
    std::snprintf(line, sizeof line, "gpu page pool: %u slots (%llu bytes), %llu pages uploaded (%llu bytes), %llu freed\n",
                  pool.slots, (unsigned long long)pool.pool_bytes, (unsigned long long)pool.pages_uploaded,
                  (unsigned long long)pool.bytes_uploaded, (unsigned long long)pool.pages_freed);
    out += line;
  }
  if (!comparisons.empty()) {
    uint64_t vis_diff = 0, over = 0;
    int max_diff = 0;
    uint32_t cluster_mismatch = 0;
    for (const FrameComparison& c : comparisons) {
      vis_diff += c.vis_pixels_differing;
      over += c.pixels_over;
      max_diff = std::max(max_diff, c.max_channel_diff);
      cluster_mismatch += !c.clusters_equal;
    }
    char line[256];
    std::snprintf(line, sizeof line,
                  "compare cpu: %zu frame(s); cluster sets %s; vis pixels differing %llu; shaded max channel diff "
                  "%d/255, pixels over 1/255 %llu: rule %s\n",
                  comparisons.size(), cluster_mismatch ? "DIFFER" : "equal", (unsigned long long)vis_diff, max_diff,
                  (unsigned long long)over, rule_holds ? "holds" : "FAILS");
    out += line;
    HwRasterAgreement hw;
    bool any_hw = false;
    for (const FrameComparison& c : comparisons)
      if (c.hw_rule) {
        hw.add(c.hw);
        any_hw = true;
      }
    if (any_hw) {
      out += "hardware rule (spec/raster.md §13.3), pixels over all frames:";
      for (int k = 0; k < kHwPixelKinds; ++k)
        out += std::string(" ") + hw_pixel_name(HwPixel(k)) + " " + std::to_string(hw.pixels[k]);
      char ratio[64];
      std::snprintf(ratio, sizeof ratio, "; max same-triangle depth error %.3g x tolerance\n", hw.max_depth_error_ratio);
      out += ratio;
    }
  }
  return out;
}

std::string BackendRunReport::json() const {
  nlohmann::ordered_json j;
  j["backend"] = backend_name(backend);
  if (!device.empty()) j["device"] = device;
  j["width"] = width;
  j["height"] = height;
  j["vis_hash"] = hex64(vis_hash);
  j["cluster_set_hash"] = hex64(cluster_set_hash);
  j["image_hash"] = hex64(image_hash);
  j["raster"] = gpu_raster_mode_name(raster);
  j["frames"] = nlohmann::ordered_json::array();
  for (size_t i = 0; i < frames.size(); ++i) {
    nlohmann::ordered_json f = nlohmann::ordered_json::parse(frame_stats_json(frames[i]));
    if (i < raster_split.size())
      f["raster_split"] = {{"sw_clusters", raster_split[i].sw_clusters},
                           {"sw_triangles", raster_split[i].sw_triangles},
                           {"hw_clusters", raster_split[i].hw_clusters},
                           {"hw_triangles", raster_split[i].hw_triangles},
                           {"sw_tiled_triangles", raster_split[i].sw_tiled_triangles},
                           {"sw_tiles", raster_split[i].sw_tiles}};
    j["frames"].push_back(f);
  }
  if (!comparisons.empty()) {
    nlohmann::ordered_json c = nlohmann::ordered_json::array();
    for (const FrameComparison& fc : comparisons) {
      nlohmann::ordered_json e;
      e["clusters_equal"] = fc.clusters_equal;
      e["vis_pixels_differing"] = fc.vis_pixels_differing;
      if (fc.hw_rule) {
        nlohmann::ordered_json h;
        for (int k = 0; k < kHwPixelKinds; ++k) h[hw_pixel_name(HwPixel(k))] = fc.hw.pixels[k];
        h["max_depth_error_ratio"] = fc.hw.max_depth_error_ratio;
        e["hw_rule"] = h;
      }
      if (fc.shaded) {
        e["max_channel_diff"] = fc.max_channel_diff;
        e["pixels_over"] = fc.pixels_over;
      }
      c.push_back(e);
    }
    j["compare_cpu"] = c;
    j["rule_holds"] = rule_holds;
  }
  if (pool.slots) {
    nlohmann::ordered_json p;
    p["slots"] = pool.slots;
    p["pool_bytes"] = pool.pool_bytes;
    p["pages_uploaded"] = pool.pages_uploaded;
    p["bytes_uploaded"] = pool.bytes_uploaded;
    p["pages_freed"] = pool.pages_freed;
    j["gpu_page_pool"] = p;
  }
  j["validation_messages"] = validation_messages.size();
  return j.dump(2);
}

}  // namespace vgeo
