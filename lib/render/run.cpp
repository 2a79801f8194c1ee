#include "vgeo/render/run.h"

#include <algorithm>
#include <cstdio>
#include <nlohmann/json.hpp>

#include "vgeo/core/error.h"
#include "vgeo/core/hash.h"

namespace vgeo {

RenderReport render_scene(const SceneFile& file, const RenderRequest& request) {
  RenderSettings settings = file.settings;
  if (request.threshold_px) settings.threshold_px = *request.threshold_px;
  if (request.view) settings.view = *request.view;
  if (request.occlusion) settings.occlusion = *request.occlusion;
  if (!(settings.threshold_px > 0) || !std::isfinite(settings.threshold_px))
    fail("RENDER_BAD_OPTION", "render", "--tau must be a positive finite number of pixels", kExitUsage);
  if (request.camera >= file.cameras.size())
    fail("RENDER_BAD_CAMERA", "render", "camera " + std::to_string(request.camera) + " does not exist", kExitUsage);
  uint32_t frames = request.frames ? request.frames : (file.path.empty() ? 1 : uint32_t(file.path.size()));
  if (frames > kMaxPathFrames) fail("RENDER_BAD_OPTION", "render", "--frames at most 100000", kExitUsage);

  ThreadPool pool(request.threads);
  FrameHistory history;
  RenderReport report;
  Frame frame;
  for (uint32_t f = 0; f < frames; ++f) {
    const Camera& cam = file.path.empty() ? file.cameras[request.camera]
                                          : file.path[std::min<size_t>(f, file.path.size() - 1)];
    bool last = f + 1 == frames;
    RenderSettings s = settings;
    // Only the image of the last frame is kept; earlier frames stop at the visibility buffer.
    s.shade = last;
    render_frame(file.scene, cam, s, pool, &history, &frame, !last);
    report.frames.push_back(frame.stats);
  }
  report.width = frame.vis.width;
  report.height = frame.vis.height;
  report.vis_hash = fnv1a64(frame.vis.keys.data(), frame.vis.keys.size() * sizeof(uint64_t));
  report.image_hash = fnv1a64(frame.image.rgb.data(), frame.image.rgb.size());
  if (!request.output_png.empty()) write_png(request.output_png, frame.image);
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
  return j.dump(2);
}

}  // namespace vgeo
