// The frame loop (run.h): one for every backend.
#include "vgeo/render/run.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <thread>
#include <nlohmann/json.hpp>

#include "vgeo/core/error.h"
#include "vgeo/core/hash.h"

namespace vgeo {

bool parse_backend(const std::string& name, Backend* out) {
  if (name == "cpu") *out = Backend::kCpu;
  else if (name == "vulkan") *out = Backend::kVulkan;
  else return false;
  return true;
}

const char* backend_name(Backend backend) { return backend == Backend::kCpu ? "cpu" : "vulkan"; }

bool parse_byte_size(const std::string& text, uint64_t* out) {
  size_t i = 0;
  uint64_t value = 0;
  constexpr uint64_t kMaxBytes = uint64_t(1) << 62;  // far above any memory; keeps products exact
  while (i < text.size() && text[i] >= '0' && text[i] <= '9') {
    value = value * 10 + uint64_t(text[i] - '0');
    if (value > kMaxBytes) return false;
    ++i;
  }
  if (i == 0) return false;
  const std::string unit = text.substr(i);
  static const std::pair<const char*, uint64_t> kUnits[] = {
      {"", 1}, {"B", 1}, {"KiB", 1ull << 10}, {"MiB", 1ull << 20}, {"GiB", 1ull << 30},
      {"KB", 1000}, {"MB", 1000000}, {"GB", 1000000000}, {"K", 1ull << 10}, {"M", 1ull << 20}, {"G", 1ull << 30}};
  for (const auto& [name, scale] : kUnits)
    if (unit == name) {
      if (value > kMaxBytes / scale) return false;
      *out = value * scale;
      return true;
    }
  return false;
}

std::string format_bytes(uint64_t bytes) {
  char buf[64];
  if (bytes >= (1ull << 30)) std::snprintf(buf, sizeof buf, "%.2f GiB", double(bytes) / double(1ull << 30));
  else if (bytes >= (1ull << 20)) std::snprintf(buf, sizeof buf, "%.2f MiB", double(bytes) / double(1ull << 20));
  else if (bytes >= (1ull << 10)) std::snprintf(buf, sizeof buf, "%.1f KiB", double(bytes) / double(1ull << 10));
  else std::snprintf(buf, sizeof buf, "%llu B", (unsigned long long)bytes);
  return buf;
}

RenderSettings resolve_render_options(const SceneFile& file, const RenderRequest& o, uint32_t* frames) {
  RenderSettings settings = file.settings;
  if (o.threshold_px) settings.threshold_px = *o.threshold_px;
  if (o.view) settings.view = *o.view;
  if (o.occlusion) settings.occlusion = *o.occlusion;
  if (!(settings.threshold_px > 0) || !std::isfinite(settings.threshold_px))
    fail("RENDER_BAD_OPTION", "render", "--tau must be a positive finite number of pixels", kExitUsage);
  if (o.camera >= file.cameras.size())
    fail("RENDER_BAD_CAMERA", "render", "camera " + std::to_string(o.camera) + " does not exist", kExitUsage);
  *frames = o.frames ? o.frames : (file.path.empty() ? 1 : uint32_t(file.path.size()));
  if (*frames > kMaxPathFrames) fail("RENDER_BAD_OPTION", "render", "--frames at most 100000", kExitUsage);
  return settings;
}

std::unique_ptr<SceneStreaming> start_scene_streaming(const SceneFile& file, float threshold_px, bool synchronous) {
  auto out = std::make_unique<SceneStreaming>();
  out->scene = file.scene;
  std::vector<std::string> paths;
  std::vector<FormatContainer> metadata;
  // Mesh k of file j is streamer mesh (meshes of files < j) + k.
  std::vector<uint32_t> base;
  for (const ScenePageFile& pf : file.page_files) {
    base.push_back(metadata.empty() ? 0 : base.back() + uint32_t(metadata.back().meshes.size()));
    paths.push_back(pf.path);
    metadata.push_back(pf.metadata);
  }
  std::vector<uint32_t> stream_mesh(file.scene.meshes.size(), kNone), material_offset(file.scene.meshes.size(), 0);
  for (size_t m = 0; m < file.page_meshes.size(); ++m) {
    const ScenePageMesh& pm = file.page_meshes[m];
    if (pm.file == kNone) continue;
    stream_mesh[m] = base[pm.file] + pm.index;
    material_offset[m] = pm.material_offset;
  }
  StreamOptions so = *file.stream;
  so.threshold_px = threshold_px;
  if (synchronous) so.loader.asynchronous = false;
  out->streamer = std::make_unique<Streamer>(paths, std::move(metadata), so);
  // The scene decided: its used pages alone exceed the budget, and the files hold at least those.
  if (!out->streamer->active())
    fail("RENDER_PLAN_MISMATCH", "render", "the streamer found the data within the budget the scene exceeds", kExitInternal);
  init_frame_streaming(&out->scene, out->streamer.get(), stream_mesh, material_offset, &out->frame);
  return out;
}

namespace {

// The CPU reference: plan_frame and the CPU executor (frame.cpp) on the scene, or on its own
// streamed copy.
class CpuFrameRenderer final : public SceneFrameRenderer {
 public:
  using SceneFrameRenderer::SceneFrameRenderer;
  void render(const Camera& camera, const RenderSettings& settings, bool has_next_frame, Frame* out) override {
    render_frame(frame_inputs(camera, settings, has_next_frame), out);
  }
};

// Frame f's camera: the path's (held at its last camera past its end), else the request's.
const Camera& frame_camera(const SceneFile& file, const RenderRequest& request, uint32_t f) {
  return file.path.empty() ? file.cameras[request.camera] : file.path[std::min<size_t>(f, file.path.size() - 1)];
}

// Whether frame f's image is kept: the last frame's always (output_png, image_hash), and every
// save_every-th with an out_dir.
bool frame_is_saved(const RenderRequest& request, uint32_t f, bool last) {
  return !request.out_dir.empty() && (last || (request.save_every > 0 && f % request.save_every == 0));
}

std::string saved_png_path(const std::string& dir, uint32_t f) {
  char name[32];
  std::snprintf(name, sizeof name, "frame_%05u.png", f);
  return (std::filesystem::path(dir) / name).string();
}

void start_stream_summary(const SceneFile& file, const FrameRenderer& renderer, StreamSummary* sum) {
  sum->requested = file.stream.has_value();
  sum->budget_bytes = file.stream ? file.stream->budget_bytes : 0;
  sum->page_bytes = file.page_bytes;
  sum->stop_frame = file.path.empty() ? 0 : uint32_t(file.path.size() - 1);
  if (sum->requested) sum->note = file.stream_note();
  if (const FrameStreaming* fs = renderer.streaming()) {
    sum->active = true;
    sum->file_bytes = fs->streamer->container().file_size;
  }
}

// Over all frames: totals, the traffic after the camera stopped, pop-in frames and convergence.
void finish_stream_summary(const std::vector<FrameStats>& frames, StreamSummary* sum) {
  std::vector<double> ms;
  for (const FrameStats& fs : frames) ms.push_back(fs.total_ms);
  std::sort(ms.begin(), ms.end());
  if (!ms.empty()) sum->median_frame_ms = ms[ms.size() / 2];
  if (!sum->active) return;
  int64_t converged_from = -1;
  for (uint32_t f = 0; f < frames.size(); ++f) {
    const StreamFrameStats& st = frames[f].stream;
    sum->bytes_read += st.bytes_read;
    sum->pages_loaded += st.pages_loaded;
    sum->pages_evicted += st.pages_evicted;
    sum->faults += st.read_failures + st.checksum_failures + st.decode_failures;
    sum->pages_marked_bad += st.pages_marked_bad;
    sum->peak_reserved_bytes = std::max(sum->peak_reserved_bytes, st.reserved_bytes);
    if (f >= sum->stop_frame) {
      sum->bytes_read_after_stop += st.bytes_read;
      sum->pages_loaded_after_stop += st.pages_loaded;
    }
    sum->stop_required_bytes = st.required_bytes;
    if (!st.cut_is_ideal) {
      sum->popin_frames++;
      converged_from = -1;
    } else if (converged_from < 0) {
      converged_from = f;
    }
  }
  if (converged_from >= 0) sum->frames_to_converge = std::max<int64_t>(0, converged_from - int64_t(sum->stop_frame));
}

}  // namespace

SceneFrameRenderer::SceneFrameRenderer(const SceneFile& file, const RenderSettings& settings, ThreadPool& pool,
                                       bool synchronous_stream)
    : file_(file), pool_(pool) {
  if (file.streaming) streaming_ = start_scene_streaming(file, settings.threshold_px, synchronous_stream);
  else if (!file.moves.empty()) moved_ = std::make_unique<RenderScene>(file.scene);
}

void SceneFrameRenderer::apply_moves(uint32_t frame) {
  RenderScene* scene = streaming_ ? &streaming_->scene : moved_.get();
  if (scene) apply_scene_moves(file_.moves, frame, &scene->lights, &scene->instances);
}

FrameInputs SceneFrameRenderer::frame_inputs(const Camera& camera, const RenderSettings& settings, bool has_next_frame) {
  FrameInputs in{scene(), camera, settings, pool_};
  in.history = &history_;
  in.has_next_frame = has_next_frame;
  in.streaming = streaming_ ? &streaming_->frame : nullptr;
  in.no_stream_reason = file_.stream_reason;
  return in;
}

std::unique_ptr<FrameRenderer> make_cpu_renderer(const SceneFile& file, const RenderSettings& settings,
                                                 ThreadPool& pool, bool synchronous_stream) {
  return std::make_unique<CpuFrameRenderer>(file, settings, pool, synchronous_stream);
}

RenderReport run_frames(const SceneFile& file, const RenderRequest& request, const RenderSettings& settings,
                        uint32_t frames, FrameRenderer& renderer, FrameRenderer* reference,
                        const FrameCallback& on_frame) {
  RenderReport report;
  report.backend = request.backend;
  start_stream_summary(file, renderer, &report.stream);
  Frame frame, reference_frame;
  for (uint32_t f = 0; f < frames; ++f) {
    const auto frame_start = std::chrono::steady_clock::now();
    const Camera& camera = frame_camera(file, request, f);
    const bool last = f + 1 == frames;
    const bool save = frame_is_saved(request, f, last);
    RenderSettings s = settings;
    s.shade = last || save;  // only images that are kept are shaded; the others stop at the visibility buffer
    renderer.apply_moves(f);
    if (reference) reference->apply_moves(f);
    renderer.render(camera, s, !last, &frame);
    report.frames.push_back(frame.stats);
    if (reference) {
      reference->render(camera, s, !last, &reference_frame);
      report.comparisons.push_back(compare_frames(reference->scene(), reference->geometry(), camera, reference_frame,
                                                  frame, request.raster != GpuRasterMode{}));
      report.rule_holds = report.rule_holds && report.comparisons.back().holds();
      if (!report.comparisons.back().holds() && !request.failure_dir.empty())
        write_comparison_failure(request.failure_dir, f, reference_frame, frame);
    }
    if (save) {
      const std::string png = saved_png_path(request.out_dir, f);
      write_png(png, frame.image);
      report.saved_pngs.push_back(png);
    }
    if (on_frame) on_frame(f, frame, renderer.streaming());
    if (request.frame_interval_ms > 0 && !last)
      std::this_thread::sleep_until(frame_start + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                                      std::chrono::duration<double, std::milli>(request.frame_interval_ms)));
  }
  report.width = frame.vis.width;
  report.height = frame.vis.height;
  report.vis_hash = vis_buffer_hash(frame.vis, frame.visible);
  report.cluster_set_hash = cluster_set_hash(frame.visible);
  report.image_hash = fnv1a64(frame.image.rgb.data(), frame.image.rgb.size());
  if (!request.output_png.empty()) write_png(request.output_png, frame.image);
  if (reference && !request.diff_png.empty()) write_png(request.diff_png, diff_image(reference_frame, frame));
  finish_stream_summary(report.frames, &report.stream);
  renderer.finish(&report);
  return report;
}

RenderReport render_scene(const SceneFile& file, const RenderRequest& request, const FrameCallback& on_frame) {
  if (request.backend != Backend::kCpu || request.compare_cpu)
    fail("RENDER_BAD_OPTION", "render", "render_scene renders on the CPU only (run_backend: every backend)",
         kExitInternal);
  uint32_t frames = 0;
  const RenderSettings settings = resolve_render_options(file, request, &frames);
  ThreadPool pool(request.threads);
  std::unique_ptr<FrameRenderer> cpu = make_cpu_renderer(file, settings, pool, false);
  return run_frames(file, request, settings, frames, *cpu, nullptr, on_frame);
}

SceneFile load_default_scene(const RenderRequest& request, uint32_t width, uint32_t height,
                             const std::string& cache_dir) {
  SceneLoadOptions options;
  options.cache_dir = cache_dir;
  options.build.threads = request.threads;
  return make_default_scene(width, height, std::max<uint32_t>(request.frames, 1), options);
}

std::string RenderReport::stream_table() const {
  if (!stream.requested) return "";
  std::string out = stream.note + "\n";
  if (!stream.active) return out;
  char line[512];
  std::snprintf(line, sizeof line, "%6s %9s %7s %7s %7s %11s %11s %7s %8s %6s %9s\n", "frame", "requested", "missing",
                "loaded", "evicted", "bytes_read", "resident", "faults", "coarser", "ideal", "ms");
  out += line;
  for (size_t f = 0; f < frames.size(); ++f) {
    const StreamFrameStats& s = frames[f].stream;
    std::snprintf(line, sizeof line, "%6zu %9u %7u %7u %7u %11llu %11llu %7u %8u %6s %9.2f\n", f, s.pages_requested,
                  s.pages_missing, s.pages_loaded, s.pages_evicted, (unsigned long long)s.bytes_read,
                  (unsigned long long)s.resident_bytes, s.read_failures + s.checksum_failures + s.decode_failures,
                  s.clusters_coarser, s.cut_is_ideal ? "yes" : "no", frames[f].total_ms);
    out += line;
  }
  std::snprintf(line, sizeof line,
                "stream summary: read %s of %s file (%.3f), %llu pages loaded, %llu evicted, peak pool %s of %s, "
                "%llu faults, %llu pages bad, pop-in frames %u of %zu, ",
                format_bytes(stream.bytes_read).c_str(), format_bytes(stream.file_bytes).c_str(),
                stream.file_bytes ? double(stream.bytes_read) / double(stream.file_bytes) : 0.0,
                (unsigned long long)stream.pages_loaded, (unsigned long long)stream.pages_evicted,
                format_bytes(stream.peak_reserved_bytes).c_str(), format_bytes(stream.budget_bytes).c_str(),
                (unsigned long long)stream.faults, (unsigned long long)stream.pages_marked_bad, stream.popin_frames,
                frames.size());
  out += line;
  std::snprintf(line, sizeof line,
                "read while moving %s (%llu pages), after the stop %s (%llu pages); the stopped view needs %s, ",
                format_bytes(stream.bytes_read - stream.bytes_read_after_stop).c_str(),
                (unsigned long long)(stream.pages_loaded - stream.pages_loaded_after_stop),
                format_bytes(stream.bytes_read_after_stop).c_str(), (unsigned long long)stream.pages_loaded_after_stop,
                format_bytes(stream.stop_required_bytes).c_str());
  out += line;
  if (stream.frames_to_converge >= 0)
    std::snprintf(line, sizeof line, "converged %lld frames after the camera stopped (frame %u), median %.2f ms/frame\n",
                  (long long)stream.frames_to_converge, stream.stop_frame, stream.median_frame_ms);
  else
    std::snprintf(line, sizeof line, "not converged by the last frame (camera stopped at frame %u), median %.2f ms/frame\n",
                  stream.stop_frame, stream.median_frame_ms);
  out += line;
  return out;
}

std::string RenderReport::table() const {
  std::string out = "backend: " + std::string(backend_name(backend)) + (device.empty() ? "" : " (" + device + ")") + "\n";
  if (!frames.empty()) out += frame_stats_table(frames.back());
  if (frames.size() > 1) {
    std::vector<double> ms;
    for (const FrameStats& f : frames) ms.push_back(f.total_ms);
    std::sort(ms.begin(), ms.end());
    char line[128];
    std::snprintf(line, sizeof line, "%zu frames: median %.3f ms, min %.3f ms, max %.3f ms\n", ms.size(),
                  ms[ms.size() / 2], ms.front(), ms.back());
    out += line;
  }
  if (!frames.empty() && frames.back().has_raster_split) {
    const RasterSplitStats& r = frames.back().raster_split;
    char line[256];
    std::snprintf(line, sizeof line,
                  "raster paths (--raster %s): sw %llu clusters %llu triangles | hw %llu clusters %llu triangles\n",
                  raster.c_str(), (unsigned long long)r.sw_clusters, (unsigned long long)r.sw_triangles,
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
    uint64_t shadow_frames = 0, shadow_tables_differ = 0, shadow_texels = 0;
    for (const FrameComparison& c : comparisons)
      if (c.shadow_compared) {
        ++shadow_frames;
        shadow_tables_differ += !c.shadow_tables_equal;
        shadow_texels += c.shadow_texels_differing;
      }
    if (shadow_frames) {
      std::snprintf(line, sizeof line, "compare cpu, shadow pages: %llu frame(s); page tables %s; pool texels differing %llu\n",
                    (unsigned long long)shadow_frames, shadow_tables_differ ? "DIFFER" : "equal",
                    (unsigned long long)shadow_texels);
      out += line;
    }
    // Under the hardware rule: the pages both sides drew, texel classes (spec/shadow.md §8).
    HwRasterAgreement shadow_hw;
    uint64_t shadow_hw_frames = 0, pages_compared = 0, pages_one_side = 0, lists_differ = 0;
    for (const FrameComparison& c : comparisons)
      if (c.shadow_hw_compared) {
        ++shadow_hw_frames;
        pages_compared += c.shadow_pages_compared;
        pages_one_side += c.shadow_pages_one_side;
        lists_differ += c.shadow_element_lists_differing;
        shadow_hw.add(c.shadow_hw);
      }
    if (shadow_hw_frames) {
      std::snprintf(line, sizeof line,
                    "compare cpu, shadow pages (hardware rule): %llu frame(s); pages compared %llu, drawn by one side "
                    "only %llu, element lists differing %llu; texels: ",
                    (unsigned long long)shadow_hw_frames, (unsigned long long)pages_compared,
                    (unsigned long long)pages_one_side, (unsigned long long)lists_differ);
      out += line;
      for (int k = 0; k < kHwPixelKinds; ++k) {
        std::snprintf(line, sizeof line, "%s%s %llu", k ? ", " : "", hw_pixel_name(HwPixel(k)),
                      (unsigned long long)shadow_hw.pixels[k]);
        out += line;
      }
      std::snprintf(line, sizeof line, "; max depth error %.3g tol\n", shadow_hw.max_depth_error_ratio);
      out += line;
    }
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

std::string RenderReport::json() const {
  nlohmann::ordered_json j;
  j["backend"] = backend_name(backend);
  if (!device.empty()) j["device"] = device;
  j["width"] = width;
  j["height"] = height;
  j["vis_hash"] = hex64(vis_hash);
  j["cluster_set_hash"] = hex64(cluster_set_hash);
  j["image_hash"] = hex64(image_hash);
  if (!raster.empty()) j["raster"] = raster;
  j["frames"] = nlohmann::ordered_json::array();
  for (const FrameStats& f : frames) j["frames"].push_back(nlohmann::ordered_json::parse(frame_stats_json(f)));
  if (stream.requested) {
    nlohmann::ordered_json s;
    s["note"] = stream.note;
    s["active"] = stream.active;
    s["budget_bytes"] = stream.budget_bytes;
    s["page_bytes"] = stream.page_bytes;
    s["file_bytes"] = stream.file_bytes;
    s["bytes_read"] = stream.bytes_read;
    s["pages_loaded"] = stream.pages_loaded;
    s["pages_evicted"] = stream.pages_evicted;
    s["faults"] = stream.faults;
    s["pages_marked_bad"] = stream.pages_marked_bad;
    s["peak_reserved_bytes"] = stream.peak_reserved_bytes;
    s["popin_frames"] = stream.popin_frames;
    s["stop_frame"] = stream.stop_frame;
    s["bytes_read_after_stop"] = stream.bytes_read_after_stop;
    s["pages_loaded_after_stop"] = stream.pages_loaded_after_stop;
    s["stop_required_bytes"] = stream.stop_required_bytes;
    s["frames_to_converge"] = stream.frames_to_converge;
    s["median_frame_ms"] = stream.median_frame_ms;
    j["stream_summary"] = s;
  }
  if (!saved_pngs.empty()) j["saved_pngs"] = saved_pngs;
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
      if (fc.shadow_compared) {
        e["shadow_tables_equal"] = fc.shadow_tables_equal;
        e["shadow_texels_differing"] = fc.shadow_texels_differing;
      }
      if (fc.shadow_hw_compared) {
        nlohmann::ordered_json h;
        h["pages_compared"] = fc.shadow_pages_compared;
        h["pages_one_side"] = fc.shadow_pages_one_side;
        h["element_lists_differing"] = fc.shadow_element_lists_differing;
        for (int k = 0; k < kHwPixelKinds; ++k) h[hw_pixel_name(HwPixel(k))] = fc.shadow_hw.pixels[k];
        h["max_depth_error_ratio"] = fc.shadow_hw.max_depth_error_ratio;
        e["shadow_hw_rule"] = h;
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
