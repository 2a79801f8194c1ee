// Suite "raster": time per triangle of each rasterizer path by triangle size, and each
// path's ratio to the brute-force reference measured side by side (spec/raster.md paths).
#include <algorithm>
#include <cmath>
#include <cstring>

#include "bench_shapes.h"
#include "bench_suites.h"
#include "vgeo/core/progress.h"
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
