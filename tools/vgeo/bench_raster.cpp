// Suite "raster": time per triangle of each rasterizer path by triangle size, and each
// path's ratio to the brute-force reference measured side by side (spec/raster.md paths).
#include <algorithm>
#include <cmath>
#include <cstring>

#include "bench_shapes.h"
#include "bench_suites.h"
#include "vgeo/core/error.h"
#include "vgeo/core/progress.h"
#include "vgeo/gpu/raster_vectors.h"
#include "vgeo/raster/raster.h"

namespace vgeo::bench {
namespace {

// The reference path scans the whole viewport per triangle, so its cost grows with the
// viewport area: 256² keeps one reference triangle at ~65k pixel tests.
constexpr uint32_t kViewport = 256;
// Independent triangles (3 own vertices each) per cluster: 85 * 3 = 255 = kMaxClusterVertices.
constexpr uint32_t kTrianglesPerCluster = kMaxClusterVertices / 3;
constexpr float kZNear = 0.01f;
// Shortest timed sample: well above timer resolution and a scheduler tick on a shared machine.
constexpr double kTargetSampleSeconds = 0.01;

struct Variant {
  const char* name;
  RasterPath path;
};
constexpr Variant kVariants[] = {{"micropoly", RasterPath::kMicropoly},
                                 {"scanline", RasterPath::kScanline},
                                 {"auto", RasterPath::kAuto},
                                 {"reference", RasterPath::kReference}};
constexpr size_t kVariantCount = 4;
constexpr size_t kReferenceIndex = 3;

struct ClusterSet {
  std::vector<std::vector<float>> positions;  // per cluster
  std::vector<uint8_t> indices;               // shared: 0,1,2, 3,4,5, ...
};

// Right triangles with legs of `size_px` pixels, random rotation and position fully inside
// the viewport, random view depth in [1, 4]. Positions are given as (ndc.xy * w, w) so the
// object→clip matrix below is linear: clip = (x, y, z_near, z).
ClusterSet make_clusters(double size_px, uint32_t clusters, uint64_t seed) {
  Rng rng(seed);
  ClusterSet set;
  for (uint32_t t = 0; t < kTrianglesPerCluster; ++t)
    for (uint8_t k = 0; k < 3; ++k) set.indices.push_back(uint8_t(3 * t + k));
  const double margin = size_px * 1.5 + 1;
  for (uint32_t c = 0; c < clusters; ++c) {
    std::vector<float> p;
    for (uint32_t t = 0; t < kTrianglesPerCluster; ++t) {
      double cx = rng.uniform(margin, kViewport - margin), cy = rng.uniform(margin, kViewport - margin);
      double a = rng.uniform(0, 6.283185307179586), w = rng.uniform(1, 4);
      double ca = std::cos(a) * size_px, sa = std::sin(a) * size_px;
      double px[3][2] = {{cx, cy}, {cx + ca, cy + sa}, {cx - sa, cy + ca}};
      for (auto& v : px) {
        double nx = 2 * v[0] / kViewport - 1, ny = 2 * v[1] / kViewport - 1;
        p.insert(p.end(), {float(nx * w), float(ny * w), float(w)});
      }
    }
    set.positions.push_back(std::move(p));
  }
  return set;
}

Mat4 clip_matrix() {
  Mat4 m;  // identity, then: row 2 = (0,0,0,z_near), row 3 = (0,0,1,0)
  m.at(2, 2) = 0;
  m.at(2, 3) = kZNear;
  m.at(3, 2) = 1;
  m.at(3, 3) = 0;
  return m;
}

void draw(VisBuffer& vb, const ClusterSet& set, uint32_t cluster_count, RasterPath path, RasterStats* stats) {
  RasterOptions opt;
  opt.path = path;
  opt.cull_backfaces = false;  // random orientations: measure coverage, not culling
  opt.z_near = kZNear;
  Mat4 m = clip_matrix();
  for (uint32_t c = 0; c < cluster_count; ++c)
    rasterize_cluster(vb, set.positions[c].data(), kTrianglesPerCluster * 3, set.indices.data(), kTrianglesPerCluster,
                      m, c, opt, stats);
}

// GPU paths (spec/raster.md §13): the compute rasterizer and the hardware pipeline draw the
// same clusters (their decoded memory form) on the default Vulkan device, interleaved.
// Clusters per GPU sample: 16 × 85 triangles keep the largest size's SW sample well under a
// second on lavapipe.
constexpr uint32_t kGpuClusters = 16;
constexpr int kGpuModes = 2;  // 0: compute SW, 1: hardware
// A timed GPU sample is at least this long in both modes: the raster passes' fixed cost (a few
// dispatches or draws and barriers, ~10-50 us on a discrete GPU) then stays a small share of
// it. Lavapipe's one-copy samples are already longer (0.7-20 ms), so there the sample is the
// 16 clusters alone; a discrete GPU draws them as up to kMaxGpuCopies instances.
constexpr double kGpuMinSampleSeconds = 0.5e-3;
constexpr uint32_t kMaxGpuCopies = 4096;  // 5.6M triangles per sample: ample for any current GPU
constexpr uint32_t kGpuCopiesStep = 4;
struct GpuBench {
  std::unique_ptr<GpuContext> gpu;
  std::string unavailable;  // why the GPU rows are missing
};

struct GpuSizeResult {
  Stats per_tri[kGpuModes];
  Stats sw_over_hw;
  uint32_t copies = 1;  // instances of the clusters per timed sample
  uint64_t hw_rule_failures = 0, hw_pixels_differing = 0;
};

// The clusters drawn `copies` times, as instances at the same place (the copies overlap: each
// pixel is covered `copies` times as often, alike for both modes).
GpuRasterInput gpu_raster_input(uint32_t count, uint32_t copies) {
  GpuRasterInput in;
  for (uint32_t i = 0; i < copies; ++i) {
    in.object_to_clip.push_back(clip_matrix());
    in.instance_mesh.push_back(0);
    in.instance_scale.push_back(1.0f);
    for (uint32_t c = 0; c < count; ++c) in.visible.push_back({i, c});
  }
  in.width = in.height = kViewport;
  in.z_near = kZNear;
  in.cull_backfaces = false;
  return in;
}

GpuSizeResult measure_gpu(GpuBench& bench, const ClusterSet& set, int reps) {
  const uint32_t count = std::min<uint32_t>(kGpuClusters, uint32_t(set.positions.size()));
  std::vector<RasterVectorCluster> clusters(count);
  for (uint32_t c = 0; c < count; ++c) clusters[c] = {set.positions[c], set.indices};
  const MemoryFormScene ms = make_memory_form_scene(flat_cluster_scene(clusters, "bench raster"));
  const GpuRasterInput in = gpu_raster_input(count, 1);
  GpuRendererPtr renderer[kGpuModes];
  for (int m = 0; m < kGpuModes; ++m) {
    GpuRendererOptions o;
    o.raster = m == 0 ? GpuRasterMode::kSw : GpuRasterMode::kHw;
    renderer[m] = create_gpu_renderer(*bench.gpu, ms, kDefaultGpuTraversal, o);
  }
  GpuRasterOutput out[kGpuModes];
  for (int m = 0; m < kGpuModes; ++m) raster_visible_vulkan(*renderer[m], in, &out[m]);  // warm-up: LLVM compiles on first use
  GpuSizeResult result;
  // Timed samples: as many copies as make both modes' samples at least kGpuMinSampleSeconds.
  GpuRasterInput timed = in;
  GpuRasterOutput scratch;
  for (;;) {
    double shortest = 1e30;
    for (int m = 0; m < kGpuModes; ++m) {
      raster_visible_vulkan(*renderer[m], timed, &scratch);
      shortest = std::min(shortest, scratch.ms * 1e-3);
    }
    if (shortest >= kGpuMinSampleSeconds || result.copies >= kMaxGpuCopies) break;
    result.copies = std::min(kMaxGpuCopies, result.copies * kGpuCopiesStep);
    timed = gpu_raster_input(count, result.copies);
  }
  std::vector<double> samples[kGpuModes];
  const double triangles = double(count) * kTrianglesPerCluster * result.copies;
  for (int r = 0; r < reps; ++r)
    for (int m = 0; m < kGpuModes; ++m) {
      raster_visible_vulkan(*renderer[m], timed, &scratch);
      samples[m].push_back(scratch.ms * 1e-3 / triangles);
    }
  for (int m = 0; m < kGpuModes; ++m) result.per_tri[m] = summarize(samples[m]);
  result.sw_over_hw = ratio_stats(samples[0], samples[1]);
  // The hardware rule against the compute path (bit-identical to the CPU reference).
  for (size_t p = 0; p < out[0].vis.keys.size(); ++p) {
    const uint64_t a = out[0].vis.keys[p], b = out[1].vis.keys[p];
    if (a == b) continue;
    ++result.hw_pixels_differing;
    if (!a || !b || uint32_t(a) != uint32_t(b)) ++result.hw_rule_failures;  // ids differ (depth-only is allowed)
  }
  return result;
}

}  // namespace

void run_raster_suite(const BenchConfig& cfg, SuiteReport& out) {
  out.ran = true;
  const std::vector<double> sizes = cfg.quick ? std::vector<double>{0.5, 4, 32}
                                              : std::vector<double>{0.25, 0.5, 1, 2, 4, 8, 16, 32, 64, 128};
  // Fast paths get enough triangles for a sample of a few ms; the reference gets fewer
  // (its per-triangle cost is ~10^3-10^5 times higher). Times are normalised per triangle.
  const uint32_t fast_clusters = cfg.quick ? 8 : 48, reference_clusters = cfg.quick ? 1 : 2;
  const int reps = cfg.repetitions(15);

  out.summary =
      "Each path rasterizes the same clusters of independent right triangles (legs = size px, random rotation, "
      "position and depth, back-face culling off) into a " + std::to_string(kViewport) + "x" +
      std::to_string(kViewport) + " visibility buffer. Time per triangle is CPU time (single thread; immune to preemption on a shared machine), the median over " +
      std::to_string(reps) + " interleaved repetitions of samples of >= 10 ms; the ratio is per repetition against the brute-force "
      "reference (whole-viewport scan). 'mismatch px' counts pixels whose key differs from the reference's on "
      "the reference's clusters (must be 0: every path is exact).";
  out.inputs.push_back(std::to_string(fast_clusters * kTrianglesPerCluster) + " triangles per sample (" +
                       std::to_string(reference_clusters * kTrianglesPerCluster) + " for the reference), seed 1");

  Table t{"Time per triangle (median [min, max]) and ratio to the reference", {"size px", "px/tri"}, {}};
  for (const Variant& v : kVariants) t.columns.push_back(std::string(v.name) + " /tri");
  for (size_t v = 0; v + 1 < kVariantCount; ++v) t.columns.push_back(std::string(kVariants[v].name) + " / ref");
  t.columns.push_back("mismatch px");
  t.columns.push_back("auto: micropoly share");

  std::vector<Series> time_series(kVariantCount), ratio_series(kVariantCount - 1);
  for (size_t v = 0; v < kVariantCount; ++v) time_series[v].name = kVariants[v].name;
  for (size_t v = 0; v + 1 < kVariantCount; ++v) ratio_series[v].name = std::string(kVariants[v].name) + " / reference";
  nlohmann::json rows = nlohmann::json::array();
  double crossover = -1;
  std::vector<double> scan_over_micro;  // per size: median of per-repetition scanline/micropoly ratios

  GpuBench gpu;
  try {
    gpu.gpu = create_gpu_context(GpuOptions{});
  } catch (const VgeoError& e) {
    gpu.unavailable = e.what();
  }
  Table gt{"GPU paths on " + (gpu.gpu ? gpu.gpu->device_name : std::string("(no device)")) +
               ": time per triangle (median [min, max]), SW/HW ratio, CPU reference (auto path) for scale",
           {"size px", "px/tri", "copies", "compute SW /tri", "hardware /tri", "SW / HW", "CPU auto /tri", "ids differing px"},
           {}};
  std::vector<Series> gpu_series(3);
  gpu_series[0].name = "compute SW (GPU)";
  gpu_series[1].name = "hardware (GPU)";
  gpu_series[2].name = "CPU auto";
  nlohmann::json gpu_rows = nlohmann::json::array();
  std::vector<double> hw_over_sw;  // per size: median per-repetition hw/sw
  double sw_over_hw_at_1px = -1;

  Progress progress("bench raster", sizes.size(), cfg.progress);
  VisBuffer vb;
  vb.resize(kViewport, kViewport);
  for (size_t si = 0; si < sizes.size(); ++si) {
    double size = sizes[si];
    ClusterSet set = make_clusters(size, fast_clusters, 1 + si);
    auto once = [&](size_t v) {
      draw(vb, set, v == kReferenceIndex ? reference_clusters : fast_clusters, kVariants[v].path, nullptr);
    };
    std::vector<int> batch = calibrate_batches(kVariantCount, once, kTargetSampleSeconds, [&](size_t) { vb.clear(); });
    // Single-threaded work: CPU time excludes preemption by other processes on a shared machine.
    auto samples = time_interleaved(
                       reps, kVariantCount, [&](size_t v) { for (int b = 0; b < batch[v]; ++b) once(v); },
                       [&](size_t) { vb.clear(); })
                       .cpu;
    std::vector<Stats> per_tri(kVariantCount);
    for (size_t v = 0; v < kVariantCount; ++v) {
      double n = double(batch[v]) * double((v == kReferenceIndex ? reference_clusters : fast_clusters) * kTrianglesPerCluster);
      std::vector<double> s = samples[v];
      for (double& x : s) x /= n;
      samples[v] = s;
      per_tri[v] = summarize(s);
    }
    // Exactness: every path against the reference on the reference's clusters.
    VisBuffer ref;
    ref.resize(kViewport, kViewport);
    RasterStats ref_stats;
    draw(ref, set, reference_clusters, RasterPath::kReference, &ref_stats);
    uint64_t mismatch = 0;
    for (size_t v = 0; v + 1 < kVariantCount; ++v) {
      VisBuffer other;
      other.resize(kViewport, kViewport);
      draw(other, set, reference_clusters, kVariants[v].path, nullptr);
      for (size_t i = 0; i < ref.keys.size(); ++i) mismatch += other.keys[i] != ref.keys[i];
    }
    RasterStats auto_stats;
    vb.clear();
    draw(vb, set, fast_clusters, RasterPath::kAuto, &auto_stats);
    double drawn = double(auto_stats.micropoly_triangles + auto_stats.scanline_triangles);
    double micro_share = drawn > 0 ? double(auto_stats.micropoly_triangles) / drawn : 0;
    double px_per_tri = double(ref_stats.pixels_written) / double(reference_clusters * kTrianglesPerCluster);

    std::vector<std::string> row{fmt(size), fmt(px_per_tri)};
    nlohmann::json jr{{"size_px", size}, {"pixels_written_per_triangle", px_per_tri}, {"mismatch_pixels", mismatch},
                      {"auto_micropoly_share", micro_share}};
    for (size_t v = 0; v < kVariantCount; ++v) {
      row.push_back(fmt_stats_time(per_tri[v]));
      jr[std::string(kVariants[v].name) + "_seconds_per_triangle"] = to_json(per_tri[v]);
      time_series[v].x.push_back(size);
      time_series[v].y.push_back(per_tri[v].median);
      time_series[v].y_low.push_back(per_tri[v].min);
      time_series[v].y_high.push_back(per_tri[v].max);
    }
    for (size_t v = 0; v + 1 < kVariantCount; ++v) {
      Stats r = ratio_stats(samples[v], samples[kReferenceIndex]);
      row.push_back(fmt_ratio(r));
      jr[std::string(kVariants[v].name) + "_over_reference"] = to_json(r);
      ratio_series[v].x.push_back(size);
      ratio_series[v].y.push_back(r.median);
      ratio_series[v].y_low.push_back(r.min);
      ratio_series[v].y_high.push_back(r.max);
    }
    Stats ms = ratio_stats(samples[1], samples[0]);  // scanline / micropoly, per repetition
    jr["scanline_over_micropoly"] = to_json(ms);
    scan_over_micro.push_back(ms.median);
    row.push_back(std::to_string(mismatch));
    row.push_back(fmt(100 * micro_share) + "%");
    t.rows.push_back(row);
    rows.push_back(jr);
    if (gpu.gpu) {
      const GpuSizeResult g = measure_gpu(gpu, set, reps);
      gt.rows.push_back({fmt(size), fmt(px_per_tri), std::to_string(g.copies), fmt_stats_time(g.per_tri[0]), fmt_stats_time(g.per_tri[1]),
                         fmt_ratio(g.sw_over_hw), fmt_stats_time(per_tri[2]), std::to_string(g.hw_rule_failures)});
      gpu_rows.push_back({{"size_px", size},
                          {"copies_per_sample", g.copies},
                          {"compute_sw_seconds_per_triangle", to_json(g.per_tri[0])},
                          {"hardware_seconds_per_triangle", to_json(g.per_tri[1])},
                          {"sw_over_hw", to_json(g.sw_over_hw)},
                          {"cpu_auto_seconds_per_triangle", to_json(per_tri[2])},
                          {"ids_differing_pixels", g.hw_rule_failures},
                          {"depth_or_id_differing_pixels", g.hw_pixels_differing}});
      for (int m = 0; m < kGpuModes; ++m) {
        gpu_series[m].x.push_back(size);
        gpu_series[m].y.push_back(g.per_tri[m].median);
        gpu_series[m].y_low.push_back(g.per_tri[m].min);
        gpu_series[m].y_high.push_back(g.per_tri[m].max);
      }
      gpu_series[2].x.push_back(size);
      gpu_series[2].y.push_back(per_tri[2].median);
      gpu_series[2].y_low.push_back(per_tri[2].min);
      gpu_series[2].y_high.push_back(per_tri[2].max);
      hw_over_sw.push_back(1.0 / g.sw_over_hw.median);
      if (size == 1) sw_over_hw_at_1px = g.sw_over_hw.median;
    }
    progress.advance();
  }
  // The knee: the smallest size from which scanline stays clearly faster at every larger size
  // (a margin over the ~2% spread of the per-repetition ratios, so noise at equal speed is no knee).
  constexpr double kClearlyFaster = 0.95;
  for (size_t i = scan_over_micro.size(); i-- > 0;) {
    if (!(scan_over_micro[i] < kClearlyFaster)) break;
    crossover = sizes[i];
  }
  out.tables.push_back(t);
  out.data["rows"] = rows;
  out.data["viewport"] = kViewport;
  out.data["scanline_faster_from_size_px"] = crossover;
  out.notes.push_back(crossover > 0 ? "Scanline is clearly faster than the micropoly loop (median per-repetition ratio < 0.95 "
                                      "at this and every larger size) from triangle legs of " + fmt(crossover) + " px."
                                    : "Scanline was not faster than the micropoly loop at any measured size.");

  if (gpu.gpu) {
    // Crossover: the smallest size from which the hardware path is clearly faster (median
    // per-repetition HW/SW < 0.95) at this and every larger size; the auto rule's threshold
    // is the area of that right triangle (leg² / 2).
    constexpr double kClearlyFasterGpu = 0.95;
    double hw_from = -1;
    for (size_t i = hw_over_sw.size(); i-- > 0;) {
      if (!(hw_over_sw[i] < kClearlyFasterGpu)) break;
      hw_from = sizes[i];
    }
    out.tables.push_back(gt);
    out.data["gpu"] = {{"device", gpu.gpu->device_name}, {"clusters_per_copy", kGpuClusters},
                       {"min_sample_seconds", kGpuMinSampleSeconds},
                       {"rows", gpu_rows}, {"hardware_faster_from_size_px", hw_from},
                       {"sw_over_hw_at_1px", sw_over_hw_at_1px},
                       {"auto_threshold_area_px", hw_from > 0 ? hw_from * hw_from / 2 : -1},
                       {"committed_auto_threshold_area_px", kAutoHwMinTriangleAreaPx}};
    out.notes.push_back(
        "GPU: " + std::to_string(kGpuClusters * kTrianglesPerCluster) +
        " triangles per copy, as many overlapping copies (instances) per sample as make every sample >= " +
        fmt(kGpuMinSampleSeconds * 1e3) + " ms ('copies'), GPU timestamps of the raster passes (split + compute SW or hardware draw), " +
        std::to_string(reps) + " interleaved repetitions. " +
        (hw_from > 0 ? "The hardware path is clearly faster (HW/SW < 0.95) from legs of " + fmt(hw_from) +
                           " px (area " + fmt(hw_from * hw_from / 2) + " px²): the auto rule's threshold "
                           "(kAutoHwMinTriangleAreaPx, committed " + fmt(kAutoHwMinTriangleAreaPx) + " px²)."
                     : std::string("The hardware path was not clearly faster at any measured size.")) +
        (sw_over_hw_at_1px > 0 ? " SW/HW at 1-px legs: " + fmt(sw_over_hw_at_1px) + " (below 1: SW faster)." : ""));
    add_plot(out, cfg, "raster_gpu_time_per_triangle.svg",
             Plot{"GPU rasterizers: time per triangle", "triangle leg length (px)", "seconds per triangle", true, true,
                  gpu_series},
             "Compute SW vs hardware pipeline (GPU timestamps) and the CPU auto path, per triangle");
  } else {
    out.notes.push_back("GPU paths not measured: " + gpu.unavailable);
  }
  add_plot(out, cfg, "raster_time_per_triangle.svg",
           Plot{"Rasterizer: time per triangle", "triangle leg length (px)", "seconds per triangle", true, true,
                time_series},
           "Time per triangle by path (median, bars = min/max over repetitions)");
  add_plot(out, cfg, "raster_ratio_vs_reference.svg",
           Plot{"Rasterizer: time relative to brute-force reference", "triangle leg length (px)",
                "time / reference time (same repetition)", true, true, ratio_series},
           "Per-repetition time ratio against the reference path (median, bars = min/max)");
}

}  // namespace vgeo::bench
