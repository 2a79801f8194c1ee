// vgeo render SCENE.json -o frame.png: the CPU reference frame pipeline (spec/scene.md).
#include <cstdio>
#include <cstdlib>
#include <filesystem>

#include "commands.h"
#include "vgeo/core/error.h"
#include "vgeo/render/run.h"

namespace vgeo::cli {

namespace {
struct RenderArgs {
  std::string scene, output, view = "lit", cache_dir;
  unsigned threads = 0;
  uint32_t frames = 0, camera = 0;
  float tau = 0;  // 0: the scene's setting
  bool json = false, no_occlusion = false, no_cache = false;
};

std::string default_cache_dir() {
  if (const char* x = std::getenv("XDG_CACHE_HOME"); x && *x) return std::string(x) + "/vgeo";
  if (const char* h = std::getenv("HOME"); h && *h) return std::string(h) + "/.cache/vgeo";
  return "";
}
}  // namespace

void add_render_command(CLI::App& app, Context& ctx) {
  auto args = std::make_shared<RenderArgs>();
  auto* cmd = app.add_subcommand("render", "Render a scene with the CPU reference pipeline (cull, raster, shade)");
  cmd->add_option("scene", args->scene, "scene JSON file (spec/scene.md); omit for the embedded default scene");
  cmd->add_option("-o,--output", args->output, "PNG of the last frame");
  cmd->add_option("--threads", args->threads, "worker threads (0 = all cores); output is identical for any value");
  cmd->add_flag("--json", args->json, "print statistics as JSON");
  cmd->add_option("--view", args->view, "lit|triangle|cluster|group|lod|error|overdraw");
  cmd->add_option("--frames", args->frames, "frames to render (default: camera path length, else 1)");
  cmd->add_option("--camera", args->camera, "scene camera index when there is no camera path");
  cmd->add_option("--tau", args->tau, "pixel error threshold (overrides the scene's tau_px)");
  cmd->add_flag("--no-occlusion", args->no_occlusion, "disable HZB occlusion culling");
  cmd->add_option("--cache-dir", args->cache_dir, "DAG cache directory (default ~/.cache/vgeo)");
  cmd->add_flag("--no-cache", args->no_cache, "always build meshes, never read or write the cache");
  cmd->callback([args, &ctx] {
    RenderRequest request;
    request.output_png = args->output;
    request.threads = args->threads;
    request.frames = args->frames;
    request.camera = args->camera;
    if (args->tau != 0) request.threshold_px = args->tau;
    if (args->no_occlusion) request.occlusion = false;
    ShadeView view;
    if (!parse_shade_view(args->view, &view))
      fail("USAGE_BAD_VIEW", "vgeo render", "--view must be one of lit, triangle, cluster, group, lod, error, overdraw",
           kExitUsage);
    request.view = view;
    std::string cache = args->no_cache ? "" : (args->cache_dir.empty() ? default_cache_dir() : args->cache_dir);
    RenderReport report;
    if (args->scene.empty()) {
      report = render_default_scene(request, 1280, 720, cache);
    } else {
      SceneLoadOptions options;
      options.cache_dir = cache;
      options.build.threads = args->threads;
      SceneFile scene = load_scene_file(args->scene, options);
      report = render_scene(scene, request);
    }
    if (args->json) std::printf("%s\n", report.json().c_str());
    else std::printf("%s", report.table().c_str());
    ctx.exit_code = kExitOk;
  });
}

}  // namespace vgeo::cli
