// vgeo render SCENE.json -o frame.png: a scene's frames on the CPU reference (spec/scene.md) or
// the Vulkan backend (spec/gpu.md), optionally streaming page-file meshes through a fixed pool
// (spec/stream.md §Renderer); every option means the same on every backend (one request, one
// frame loop: lib/vgeo/render/run.h).
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>

#include "commands.h"
#include "vgeo/core/file_io.h"
#include "vgeo/core/error.h"
#include "vgeo/gpu/backend_run.h"
#include "vgeo/render/run.h"

namespace vgeo::cli {

namespace {
struct RenderArgs {
  std::string scene, output, view = "lit", cache_dir;
  unsigned threads = 0;
  uint32_t frames = 0, camera = 0;
  float tau = 0;  // 0: the scene's setting
  bool json = false, no_occlusion = false, no_cache = false;
  // Streaming
  std::string stream_budget, camera_path, out_dir, json_file;
  double disk_latency_ms = 0, disk_bandwidth_mbs = 0, frame_ms = 0;
  uint32_t save_every = 0, stream_issues = 8;
  bool stream_sync = false;
  // Backends (spec/gpu.md).
  std::string backend, compare, device, diff_png, traversal, raster;
  bool validate = false;
};

// --backend / --compare / --raster / --traversal / --device / --validate into the request.
void resolve_backend_args(const RenderArgs& args, RenderRequest* request) {
  if (!args.backend.empty() && !parse_backend(args.backend, &request->backend))
    fail("RENDER_BAD_OPTION", "vgeo render", "--backend must be cpu or vulkan", kExitUsage);
  if (!args.compare.empty()) {
    if (args.compare != "cpu") fail("RENDER_BAD_OPTION", "vgeo render", "--compare supports only cpu", kExitUsage);
    if (args.backend.empty()) request->backend = Backend::kVulkan;
    if (request->backend != Backend::kVulkan)
      fail("RENDER_BAD_OPTION", "vgeo render", "--compare cpu needs --backend vulkan", kExitUsage);
    request->compare_cpu = true;
  }
  if (args.traversal == "level") request->traversal = GpuTraversal::kLevel;
  else if (args.traversal == "persistent") request->traversal = GpuTraversal::kPersistent;
  else if (!args.traversal.empty())
    fail("RENDER_BAD_OPTION", "vgeo render", "--traversal must be level or persistent", kExitUsage);
  if (request->traversal && request->backend != Backend::kVulkan)
    fail("RENDER_BAD_OPTION", "vgeo render", "--traversal needs --backend vulkan", kExitUsage);
  if (!args.raster.empty()) {
    if (!parse_gpu_raster_mode(args.raster, &request->raster))
      fail("RENDER_BAD_OPTION", "vgeo render", "--raster must be sw, hw or auto", kExitUsage);
    if (request->backend != Backend::kVulkan)
      fail("RENDER_BAD_OPTION", "vgeo render", "--raster needs --backend vulkan", kExitUsage);
  }
  request->gpu_device = args.device;
  request->gpu_validate = args.validate;
  request->diff_png = args.diff_png;
}

std::string default_cache_dir() {
  if (const char* x = std::getenv("XDG_CACHE_HOME"); x && *x) return std::string(x) + "/vgeo";
  if (const char* h = std::getenv("HOME"); h && *h) return std::string(h) + "/.cache/vgeo";
  return "";
}

[[noreturn]] void bad_stream_option(const std::string& what) {
  fail("RENDER_STREAM_OPTION", "vgeo render", what, kExitUsage);
}
}  // namespace

void add_render_command(CLI::App& app, Context& ctx) {
  auto args = std::make_shared<RenderArgs>();
  auto* cmd = app.add_subcommand("render", "Render a scene on the CPU reference or the Vulkan backend (cull, raster, shade)");
  cmd->add_option("scene", args->scene, "scene JSON file (spec/scene.md); omit for the embedded default scene");
  cmd->add_option("-o,--output", args->output, "PNG of the last frame");
  cmd->add_option("--threads", args->threads, "worker threads (0 = all cores); output is identical for any value");
  cmd->add_flag("--json", args->json, "print statistics as JSON");
  cmd->add_option("--json-file", args->json_file, "also write the JSON statistics (per-frame streaming metrics) to this file");
  cmd->add_option("--view", args->view, "lit|triangle|cluster|group|lod|error|overdraw");
  cmd->add_option("--frames", args->frames, "frames to render (default: camera path length, else 1; frames past the path hold its last camera)");
  cmd->add_option("--camera", args->camera, "scene camera index when there is no camera path");
  cmd->add_option("--camera-path", args->camera_path, "camera path JSON ({\"frames\",\"keyframes\"} as the scene's camera_path) replacing the scene's");
  cmd->add_option("--tau", args->tau, "pixel error threshold (overrides the scene's tau_px)");
  cmd->add_flag("--no-occlusion", args->no_occlusion, "disable HZB occlusion culling");
  cmd->add_option("--cache-dir", args->cache_dir, "DAG cache directory (default ~/.cache/vgeo)");
  cmd->add_flag("--no-cache", args->no_cache, "always build meshes, never read or write the cache");
  cmd->add_option("--stream-budget", args->stream_budget,
                  "stream page-file meshes through a pool of this many memory-form bytes (e.g. 64MiB, 512KiB, 1GB); "
                  "off when the data fits");
  cmd->add_option("--disk-latency-ms", args->disk_latency_ms, "simulated per-read latency (streaming)");
  cmd->add_option("--disk-bandwidth-mbs", args->disk_bandwidth_mbs, "simulated disk bandwidth in MB/s (streaming; 0 = unlimited)");
  cmd->add_option("--stream-issues", args->stream_issues, "page reads issued per frame at most (streaming; default 8)");
  cmd->add_option("--frame-ms", args->frame_ms,
                  "pace frames: each frame starts at least this many ms after the previous one (e.g. 16.7; 0 = unpaced)");
  cmd->add_flag("--stream-sync", args->stream_sync, "deterministic loader: each read completes at the next frame");
  cmd->add_option("--out-dir", args->out_dir, "write PNGs of frames here (frame_NNNNN.png): every --save-every-th and the last");
  cmd->add_option("--save-every", args->save_every, "with --out-dir: save every K-th frame (0 = only the last)");
  cmd->add_option("--backend", args->backend, "cpu|vulkan: the backend that renders the scene's memory form (default cpu; spec/gpu.md)");
  cmd->add_option("--compare", args->compare, "cpu: with --backend vulkan, render every frame on the CPU too and compare "
                                              "(spec/raster.md; exit 1 when the rule fails)");
  cmd->add_option("--traversal", args->traversal,
                  "level|persistent: the Vulkan cull's BVH traversal (default: level, spec/raster.md §12)");
  cmd->add_option("--raster", args->raster,
                  "sw|hw|auto: with --backend vulkan, the compute rasterizer, the hardware pipeline, or per cluster by "
                  "projected triangle size (spec/raster.md §13; default sw)");
  cmd->add_option("--diff-png", args->diff_png, "with --compare: PNG of the last frame's differences");
  cmd->add_option("--device", args->device, "Vulkan device: index or name substring (default: lavapipe; env VGEO_VK_DEVICE)");
  cmd->add_flag("--validate", args->validate, "enable the Vulkan validation layer; any message fails (env VGEO_VK_VALIDATE=1)");
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
    SceneLoadOptions options;
    if (!args->stream_budget.empty()) {
      uint64_t budget = 0;
      if (!parse_byte_size(args->stream_budget, &budget) || budget == 0)
        fail("RENDER_STREAM_BUDGET", "vgeo render",
             "--stream-budget '" + args->stream_budget + "' is not a positive size like 64MiB, 512KiB, 1GB or 4096",
             kExitUsage);
      options.stream.emplace();
      options.stream->budget_bytes = budget;
    }
    if (!std::isfinite(args->disk_latency_ms) || args->disk_latency_ms < 0 || args->disk_latency_ms > 1e4)
      bad_stream_option("--disk-latency-ms must be in [0, 10000]");
    if (!std::isfinite(args->disk_bandwidth_mbs) || args->disk_bandwidth_mbs < 0)
      bad_stream_option("--disk-bandwidth-mbs must be a non-negative number");
    if (args->stream_issues == 0) bad_stream_option("--stream-issues must be at least 1");
    if (!std::isfinite(args->frame_ms) || args->frame_ms < 0 || args->frame_ms > 1e4)
      bad_stream_option("--frame-ms must be in [0, 10000]");
    request.frame_interval_ms = args->frame_ms;
    if (args->save_every > 0 && args->out_dir.empty()) bad_stream_option("--save-every needs --out-dir");
    if (options.stream) {
      options.stream->loader.latency_ms = args->disk_latency_ms;
      options.stream->loader.bandwidth_mb_s = args->disk_bandwidth_mbs;
      options.stream->loader.asynchronous = !args->stream_sync;
      options.stream->max_issues_per_frame = args->stream_issues;
      options.stream->max_in_flight = std::max<uint32_t>(16, 2 * args->stream_issues);
    }
    request.out_dir = args->out_dir;
    request.save_every = args->save_every;
    if (!args->out_dir.empty()) create_output_directory(args->out_dir);
    std::string cache = args->no_cache ? "" : (args->cache_dir.empty() ? default_cache_dir() : args->cache_dir);
    resolve_backend_args(*args, &request);
    SceneFile scene;
    if (args->scene.empty()) {
      if (!args->stream_budget.empty() || !args->camera_path.empty())
        bad_stream_option("--stream-budget and --camera-path need a scene file");
      scene = load_default_scene(request, 1280, 720, cache);
    } else {
      options.cache_dir = cache;
      options.build.threads = args->threads;
      scene = load_scene_file(args->scene, options);
      if (!args->camera_path.empty()) scene.path = load_camera_path_file(args->camera_path, scene.cameras[0]);
    }
    const RenderReport report = run_backend(scene, request);
    if (!args->json_file.empty()) write_file_atomic(args->json_file, report.json() + "\n");
    if (args->json) {
      std::printf("%s\n", report.json().c_str());
    } else {
      std::printf("%s", report.stream_table().c_str());
      std::printf("%s", report.table().c_str());
    }
    if (!report.validation_messages.empty())
      fail("GPU_VALIDATION", "vulkan",
           std::to_string(report.validation_messages.size()) + " validation message(s), first: " +
               report.validation_messages[0],
           kExitInternal);
    if (!report.rule_holds)
      fail("RENDER_BACKENDS_DIFFER", "vgeo render",
           "the Vulkan frames break the rule of spec/raster.md §Backends agree (see the comparison above)",
           kExitInvariantViolation);
    ctx.exit_code = kExitOk;
  });
}

}  // namespace vgeo::cli
