// Streaming fly-through: a camera orbits close to a dense sphere for kMovingFrames frames,
// then stops. Reported per (budget, disk speed): bytes read / file size, pop-in frames
// (drawn cut coarser than the ideal one), frames to converge after the stop.
// Run: vgeo_microbench --benchmark_filter=StreamFlyThrough
#include <filesystem>
#include <benchmark/benchmark.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <fstream>
#include <thread>

#include "vgeo/dag/build.h"
#include "vgeo/format/format.h"
#include "vgeo/mesh/generate.h"
#include "vgeo/stream/stream.h"

namespace {

constexpr uint32_t kMovingFrames = 90;   // 1.5 s at 60 Hz
constexpr uint32_t kStoppedFrames = 60;  // convergence must happen within 1 s
constexpr float kOrbitRadius = 2.5f;   // sphere radius 1: the cut needs a fraction of the pages
constexpr double kFrameMs = 16.7;        // 60 Hz frame pacing (the loader runs in real time)

const std::string& scene_file() {
  static const std::string path = [] {
    vgeo::BuildOptions bo;
    vgeo::BuiltScene scene;
    scene.meshes.push_back(vgeo::build_dag(vgeo::make_uv_sphere(200, 400), bo));
    scene.materials.push_back(vgeo::Material{});
    scene.instances.push_back(vgeo::Instance{});
    vgeo::FormatOptions fo;
    fo.page_size = vgeo::kMinPageSize;
    fo.zstd_level = 3;
    const std::vector<uint8_t> bytes = vgeo::encode_format(scene, fo);
    std::string p = (std::filesystem::temp_directory_path() / ("vgeo_stream_bench_" + std::to_string(getpid()) + ".vgp")).string();
    std::ofstream(p, std::ios::binary).write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
    return p;
  }();
  return path;
}

// range(0): budget in percent of all pages' memory bytes; range(1): 0 fast disk, 1 slow disk.
void BM_StreamFlyThrough(benchmark::State& state) {
  const std::string& path = scene_file();
  vgeo::StreamOptions probe_options;
  probe_options.budget_bytes = UINT64_MAX;
  vgeo::Streamer probe(path, probe_options);
  const uint64_t total = vgeo::total_page_bytes(probe.container());
  const uint64_t file_size = probe.container().file_size;
  vgeo::StreamOptions o;
  o.budget_bytes = total * uint64_t(state.range(0)) / 100;
  // Fast: NVMe-like (0.1 ms, 2 GB/s). Slow: HDD-like (5 ms seek, 100 MB/s).
  o.loader.latency_ms = state.range(1) ? 5.0 : 0.1;
  o.loader.bandwidth_mb_s = state.range(1) ? 100.0 : 2000.0;
  double converge = 0, pop_in = 0, bytes_ratio = 0, required_pct = 0;
  for (auto _ : state) {
    vgeo::Streamer s(path, o);
    vgeo::LodView view;
    view.pixels_per_unit_at_1 = vgeo::lod_projection_scale(1.0471976f, 1080.0f);
    uint32_t converged_at = kStoppedFrames;
    for (uint32_t f = 0; f < kMovingFrames + kStoppedFrames; ++f) {
      const uint32_t t = std::min(f, kMovingFrames);
      const float a = 0.05f * float(t);
      view.eye = {kOrbitRadius * std::cos(a), kOrbitRadius * std::sin(a), 0.3f};
      const auto start = std::chrono::steady_clock::now();
      const vgeo::StreamFrameStats st = s.update({vgeo::StreamView{0, view}}, nullptr);
      required_pct = 100.0 * double(st.required_bytes) / double(total);
      if (f >= kMovingFrames && st.cut_is_ideal && converged_at == kStoppedFrames) converged_at = f - kMovingFrames;
      std::this_thread::sleep_until(start + std::chrono::duration<double, std::milli>(kFrameMs));
    }
    converge = converged_at;
    pop_in = double(s.totals().frames_coarser);
    bytes_ratio = double(s.totals().bytes_read) / double(file_size);
  }
  state.counters["budget_pct"] = double(state.range(0));
  state.counters["bytes_read_per_file"] = bytes_ratio;
  state.counters["popin_frames"] = pop_in;
  state.counters["converge_frames"] = converge;
  state.counters["required_pct"] = required_pct;  // of all pages, at the stopped view
  state.counters["file_MB"] = double(file_size) / 1e6;
}
BENCHMARK(BM_StreamFlyThrough)->ArgsProduct({{25, 60}, {0, 1}})->Iterations(1)->Unit(benchmark::kMillisecond);

}  // namespace
