// Error bound (ERROR_BOUND): spec/invariants.md §5. The one-sided distance from each
// non-leaf cluster's surface to the original surface (all leaf triangles), sampled on a
// barycentric lattice and measured exactly in double against a BVH of the leaves, must
// not exceed the cluster's stored lod_error.
// Based on: Cignoni, Rocchini, Scopigno, "Metro: Measuring Error on Simplified Surfaces",
// Computer Graphics Forum 17(2), 1998 (sampled one-sided distance to the original surface).
#include <algorithm>
#include <atomic>
#include <cmath>
#include <numeric>
#include <string>

#include "vgeo/core/surface_distance.h"
#include "vgeo/core/thread_pool.h"
#include "vgeo/verify/verify_detail.h"

namespace vgeo {

std::vector<float> verify_detail::leaf_corner_soup(const ClusterDag& dag) {
  std::vector<float> leaf_corners;
  for (const DagCluster& k : dag.clusters) {
    if (k.generating_group != kNone) continue;
    for (uint32_t t = 0; t < k.triangle_count; ++t)
      for (int j = 0; j < 3; ++j) {
        const float* p = &dag.positions[3 * (size_t(k.vertex_offset) + dag.indices[3 * (size_t(k.triangle_offset) + t) + j])];
        leaf_corners.insert(leaf_corners.end(), p, p + 3);
      }
  }
  return leaf_corners;
}

ClusterDeviation measure_cluster_deviation(const ClusterDag& dag, const VerifyOptions& options) {
  const size_t nc = dag.clusters.size();
  std::vector<float> leaf_corners = verify_detail::leaf_corner_soup(dag);
  ThreadPool pool(options.threads);
  TriangleDistanceTree bvh(std::move(leaf_corners), &pool);
  ClusterDeviation out;
  out.distance.assign(nc, 0.0);
  out.worst.assign(nc, DVec3{});
  std::vector<uint32_t> targets;
  for (size_t c = 0; c < nc; ++c)
    if (dag.clusters[c].generating_group != kNone) targets.push_back(uint32_t(c));
  std::vector<uint64_t> samples(targets.size(), 0);
  const uint32_t k_sub = std::max(1u, options.error_samples_per_edge);
  if (!bvh.empty()) {
    std::atomic<size_t> next{0};
    pool.run_on_all([&](unsigned) {
      for (size_t i; (i = next.fetch_add(1)) < targets.size();) {
        const DagCluster& k = dag.clusters[targets[i]];
        uint32_t hint = ~0u;
        double best2 = 0;
        DVec3 worst{0, 0, 0};
        auto sample = [&](DVec3 p) {
          double d2 = bvh.nearest_distance_squared(p, &hint);
          ++samples[i];
          if (d2 > best2) best2 = d2, worst = p;
        };
        // The shared lattice (lib/vgeo/core/surface_distance.h): the builder measures its stored
        // error on a refinement of the same lattice, so every point sampled here was measured.
        std::vector<uint32_t> tri_indices(3 * size_t(k.triangle_count));
        for (size_t j = 0; j < tri_indices.size(); ++j)
          tri_indices[j] = k.vertex_offset + dag.indices[3 * size_t(k.triangle_offset) + j];
        for_each_lattice_point(dag.positions.data(), tri_indices.data(), k.triangle_count, k_sub, sample);
        out.distance[targets[i]] = std::sqrt(best2);
        out.worst[targets[i]] = worst;
      }
    });
  }
  for (uint64_t n : samples) out.samples += n;
  return out;
}

}  // namespace vgeo

namespace vgeo::verify_detail {

double largest_stored_coordinate(const ClusterDag& dag) {
  double max_abs = 0;
  for (const DagCluster& k : dag.clusters)
    for (uint32_t v = 0; v < k.vertex_count; ++v)
      for (int j = 0; j < 3; ++j)
        max_abs = std::max(max_abs, std::fabs(double(dag.positions[3 * (size_t(k.vertex_offset) + v) + j])));
  return max_abs;
}

void check_error_bound(const ClusterDag& dag, const VerifyOptions& options, Sink& sink, ErrorBoundResult* result) {
  const double max_abs = largest_stored_coordinate(dag);
  // Tolerance: stored positions are float; a simplified vertex placed at the measured
  // error is rounded by up to half an ulp per coordinate (√3/2 ulp), and so are the leaves.
  // Four ulps of the largest coordinate covers both roundings (spec/invariants.md §5).
  const double abs_tol = 4.0 * verify_detail::float_ulp(max_abs);
  const ClusterDeviation deviation = measure_cluster_deviation(dag, options);
  result->samples += deviation.samples;
  // Sized by the levels the clusters hold, not by dag.level_count: an untrusted file may claim
  // 2^32 levels (fuzz_dag_verify: out of memory here), and only clusters fill the rows.
  uint32_t top_level = 0;
  for (const DagCluster& k : dag.clusters)
    if (k.generating_group != kNone) top_level = std::max(top_level, k.level);
  result->ratios_per_level.assign(std::min<size_t>(size_t(dag.level_count), size_t(top_level)) + 1, {});
  for (size_t c = 0; c < dag.clusters.size(); ++c) {
    const DagCluster& k = dag.clusters[c];
    if (k.generating_group == kNone) continue;
    const double dist = deviation.distance[c];
    const DVec3 worst = deviation.worst[c];
    ++result->clusters;
    if (k.lod_error > 0 && std::isfinite(k.lod_error)) {
      double ratio = dist / k.lod_error;
      result->ratios.push_back(ratio);
      if (k.level < result->ratios_per_level.size()) result->ratios_per_level[k.level].push_back(ratio);
    }
    if (!(dist <= double(k.lod_error) + abs_tol))
      sink.add("ERROR_BOUND", "error_bound", "cluster", c,
               "sampled distance to the leaves " + fmt_float(dist) + " exceeds stored lod_error " +
                   fmt_float(k.lod_error) + " (level " + std::to_string(k.level) + ")",
               {{"measured", dist},
                {"stored", k.lod_error},
                {"ratio", k.lod_error > 0 ? dist / k.lod_error : std::numeric_limits<double>::infinity()},
                {"tolerance", abs_tol},
                {"worst_x", worst.x},
                {"worst_y", worst.y},
                {"worst_z", worst.z}});
  }
}

}  // namespace vgeo::verify_detail
