#include "vgeo/render/run.h"

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <memory>
#include <optional>
#include <thread>
#include <cstdio>
#include <nlohmann/json.hpp>

#include "vgeo/core/error.h"
#include "vgeo/core/hash.h"

namespace vgeo {

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

RenderSettings resolve_render_options(const SceneFile& file, const RenderOverrides& o, uint32_t* frames) {
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

RenderReport render_scene(const SceneFile& file, const RenderRequest& request,
                          const std::function<void(uint32_t, const Frame&, const FrameStreaming*)>& on_frame) {
  uint32_t frames = 0;
  const RenderSettings settings = resolve_render_options(
      file, {request.threshold_px, request.view, request.occlusion, request.camera, request.frames}, &frames);

  RenderReport report;
  StreamSummary& sum = report.stream;
  sum.requested = file.stream.has_value();
  sum.budget_bytes = file.stream ? file.stream->budget_bytes : 0;
  sum.page_bytes = file.page_bytes;
  sum.stop_frame = file.path.empty() ? 0 : uint32_t(file.path.size() - 1);
  if (sum.requested) sum.note = file.stream_note();

  // Streaming state: a private copy of the scene (in-memory meshes move into the geometry).
  std::optional<RenderScene> streamed_scene;
  std::unique_ptr<Streamer> streamer;
  FrameStreaming streaming;
  if (file.streaming) {
    streamed_scene = file.scene;
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
    so.threshold_px = settings.threshold_px;
    streamer = std::make_unique<Streamer>(paths, std::move(metadata), so);
    // The scene decided: its used pages alone exceed the budget, and the files hold at least those.
    if (!streamer->active())
      fail("RENDER_PLAN_MISMATCH", "render", "the streamer found the data within the budget the scene exceeds", kExitInternal);
    init_frame_streaming(&*streamed_scene, streamer.get(), stream_mesh, material_offset, &streaming);
    sum.active = true;
    sum.file_bytes = streamer->container().file_size;
  }
  const RenderScene& scene = streamed_scene ? *streamed_scene : file.scene;

  ThreadPool pool(request.threads);
  FrameHistory history;
  Frame frame;
  for (uint32_t f = 0; f < frames; ++f) {
    const auto frame_start = std::chrono::steady_clock::now();
    const Camera& cam = file.path.empty() ? file.cameras[request.camera]
                                          : file.path[std::min<size_t>(f, file.path.size() - 1)];
    bool last = f + 1 == frames;
    bool save = !request.out_dir.empty() && (last || (request.save_every > 0 && f % request.save_every == 0));
    RenderSettings s = settings;
    // Only images that are kept are shaded; other frames stop at the visibility buffer.
    s.shade = last || save;
    FrameStreaming* fs = streamer ? &streaming : nullptr;
    const FramePlan plan = plan_frame(scene, s, frame_context(scene, cam, &history, !last, fs, file.stream_reason));
    render_planned_frame(plan, scene, cam, s, pool, &history, &frame, fs);
    report.frames.push_back(frame.stats);
    if (save) {
      char name[32];
      std::snprintf(name, sizeof name, "frame_%05u.png", f);
      std::string png = (std::filesystem::path(request.out_dir) / name).string();
      write_png(png, frame.image);
      report.saved_pngs.push_back(png);
    }
    if (on_frame) on_frame(f, frame, streamer ? &streaming : nullptr);
    if (request.frame_interval_ms > 0 && !last)
      std::this_thread::sleep_until(frame_start + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                                      std::chrono::duration<double, std::milli>(request.frame_interval_ms)));
  }
  report.width = frame.vis.width;
  report.height = frame.vis.height;
  report.vis_hash = fnv1a64(frame.vis.keys.data(), frame.vis.keys.size() * sizeof(uint64_t));
  report.image_hash = fnv1a64(frame.image.rgb.data(), frame.image.rgb.size());
  if (!request.output_png.empty()) write_png(request.output_png, frame.image);

  std::vector<double> ms;
  for (const FrameStats& fs : report.frames) ms.push_back(fs.total_ms);
  std::sort(ms.begin(), ms.end());
  if (!ms.empty()) sum.median_frame_ms = ms[ms.size() / 2];
  if (streamer) {
    int64_t converged_from = -1;
    for (uint32_t f = 0; f < report.frames.size(); ++f) {
      const StreamFrameStats& st = report.frames[f].stream;
      sum.bytes_read += st.bytes_read;
      sum.pages_loaded += st.pages_loaded;
      sum.pages_evicted += st.pages_evicted;
      sum.faults += st.read_failures + st.checksum_failures + st.decode_failures;
      sum.pages_marked_bad += st.pages_marked_bad;
      sum.peak_reserved_bytes = std::max(sum.peak_reserved_bytes, st.reserved_bytes);
      if (f >= sum.stop_frame) {
        sum.bytes_read_after_stop += st.bytes_read;
        sum.pages_loaded_after_stop += st.pages_loaded;
      }
      sum.stop_required_bytes = st.required_bytes;
      if (!st.cut_is_ideal) {
        sum.popin_frames++;
        converged_from = -1;
      } else if (converged_from < 0) {
        converged_from = f;
      }
    }
    if (converged_from >= 0) sum.frames_to_converge = std::max<int64_t>(0, converged_from - int64_t(sum.stop_frame));
  }
  return report;
}

RenderReport render_default_scene(const RenderRequest& request, uint32_t width, uint32_t height,
                                  const std::string& cache_dir) {
  SceneLoadOptions options;
  options.cache_dir = cache_dir;
  options.build.threads = request.threads;
  SceneFile scene = make_default_scene(width, height, std::max<uint32_t>(request.frames, 1), options);
  return render_scene(scene, request);
}

std::string RenderReport::table() const {
  if (frames.empty()) return "";
  std::string out = frame_stats_table(frames.back());
  if (frames.size() > 1) {
    std::vector<double> ms;
    for (const FrameStats& f : frames) ms.push_back(f.total_ms);
    std::sort(ms.begin(), ms.end());
    char line[128];
    std::snprintf(line, sizeof line, "%zu frames: median %.3f ms, min %.3f ms, max %.3f ms\n", ms.size(),
                  ms[ms.size() / 2], ms.front(), ms.back());
    out += line;
  }
  return out;
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

std::string RenderReport::json() const {
  nlohmann::ordered_json j;
  j["width"] = width;
  j["height"] = height;
  char hex[32];
  std::snprintf(hex, sizeof hex, "%016llx", (unsigned long long)vis_hash);
  j["vis_hash"] = hex;
  std::snprintf(hex, sizeof hex, "%016llx", (unsigned long long)image_hash);
  j["image_hash"] = hex;
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
  return j.dump(2);
}

}  // namespace vgeo
