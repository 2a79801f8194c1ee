// The cut at equal measured error (measured_cut.h). Based on: the monotone error hull of Karis
// et al., "Nanite: A Deep Dive" (SIGGRAPH 2021), §"LOD selection in parallel" (a parent's error
// is at least its children's), applied to *measured* deviations from the leaves (ERROR_BOUND's
// measurement, spec/invariants.md) instead of stored ones, cut as lod_selects cuts at an
// object-space threshold; the method and its figures: docs/acceptance/issue15.md §2.
#include "vgeo/verify/measured_cut.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "vgeo/verify/verify.h"

namespace vgeo {

double measured_cut_epsilon(int i) {
  return kMeasuredCutEpsilonLow *
         std::pow(kMeasuredCutEpsilonHigh / kMeasuredCutEpsilonLow, double(i) / (kMeasuredCutCurvePoints - 1));
}

namespace {

double leaf_diagonal(const ClusterDag& dag) {
  double d2 = 0;
  for (int k = 0; k < 3; ++k) {
    double e = double(dag.bounds.max[k]) - dag.bounds.min[k];
    d2 += e * e;
  }
  return std::sqrt(d2);
}

// Triangles of the cut that draws cluster c iff self(c) ≤ eps < parent(group(c)).
uint64_t cut_triangles(const ClusterDag& dag, const std::vector<double>& self, const std::vector<double>& parent,
                       double eps) {
  uint64_t tris = 0;
  for (size_t c = 0; c < dag.clusters.size(); ++c)
    if (self[c] <= eps && eps < parent[dag.clusters[c].group]) tris += dag.clusters[c].triangle_count;
  return tris;
}

}  // namespace

DagQuality measure_dag_quality(const ClusterDag& dag, unsigned threads, double diagonal) {
  DagQuality q;
  VerifyOptions vo;
  vo.threads = threads;
  const ClusterDeviation dev = measure_cluster_deviation(dag, vo);
  const size_t ng = dag.groups.size(), nc = dag.clusters.size();
  // Hull of the clusters each group generated: max of their own deviation and the hull of
  // the group's members (groups by increasing level: members come from lower levels).
  std::vector<uint32_t> order(ng);
  for (size_t g = 0; g < ng; ++g) order[g] = uint32_t(g);
  std::stable_sort(order.begin(), order.end(),
                   [&](uint32_t a, uint32_t b) { return dag.groups[a].level < dag.groups[b].level; });
  std::vector<double> generated_hull(ng, 0.0), self_hull(nc, 0.0);
  for (uint32_t g : order) {
    const DagGroup& G = dag.groups[g];
    double h = 0;
    for (uint32_t c = G.first_cluster; c < G.first_cluster + G.cluster_count; ++c) h = std::max(h, self_hull[c]);
    for (uint32_t i = 0; i < G.generated_count; ++i)
      h = std::max(h, dev.distance[dag.generated_clusters[G.first_generated + i]]);
    generated_hull[g] = h;
    for (uint32_t i = 0; i < G.generated_count; ++i) self_hull[dag.generated_clusters[G.first_generated + i]] = h;
  }
  const double inf = std::numeric_limits<double>::infinity();
  std::vector<double> parent_hull(ng), parent_stored(ng), self_stored(nc);
  for (size_t g = 0; g < ng; ++g) {
    const bool terminal = dag.groups[g].generated_count == 0;
    parent_hull[g] = terminal ? inf : generated_hull[g];
    parent_stored[g] = terminal ? inf : double(dag.groups[g].parent_error);
  }
  for (size_t c = 0; c < nc; ++c) {
    const DagCluster& k = dag.clusters[c];
    self_stored[c] = k.generating_group == kNone ? 0.0 : double(k.lod_error);
    if (k.generating_group != kNone && k.lod_error > 0 && std::isfinite(k.lod_error))
      q.ratios.push_back(dev.distance[c] / k.lod_error);
    if (dag.groups[k.group].generated_count == 0) ++q.roots, q.root_triangles += k.triangle_count;
  }
  q.diagonal = diagonal > 0 ? diagonal : leaf_diagonal(dag);
  const double eps[2] = {kMeasuredCutEpsilonLow, kMeasuredCutEpsilonHigh};
  for (int e = 0; e < 2; ++e) {
    q.cut_measured[e] = cut_triangles(dag, self_hull, parent_hull, eps[e] * q.diagonal);
    q.cut_stored[e] = cut_triangles(dag, self_stored, parent_stored, eps[e] * q.diagonal);
  }
  double log_sum = 0;
  for (int i = 0; i < kMeasuredCutCurvePoints; ++i) {
    q.cut_curve.push_back(cut_triangles(dag, self_hull, parent_hull, measured_cut_epsilon(i) * q.diagonal));
    log_sum += std::log(double(std::max<uint64_t>(q.cut_curve.back(), 1)));
  }
  q.cut_curve_geometric_mean = std::exp(log_sum / kMeasuredCutCurvePoints);
  std::vector<std::vector<double>> level_hulls;
  for (size_t c = 0; c < nc; ++c) {
    // Clamped to the cluster count (a valid DAG has fewer levels than clusters): an untrusted
    // file's level field never sizes an allocation.
    const uint32_t level = uint32_t(std::min<size_t>(dag.groups[dag.clusters[c].group].level, nc));
    if (level >= q.levels.size()) q.levels.resize(level + 1), level_hulls.resize(level + 1);
    ++q.levels[level].clusters;
    q.levels[level].triangles += dag.clusters[c].triangle_count;
    level_hulls[level].push_back(self_hull[c] / q.diagonal);
  }
  for (size_t l = 0; l < q.levels.size(); ++l) {
    std::vector<double>& h = level_hulls[l];
    if (h.empty()) continue;
    std::nth_element(h.begin(), h.begin() + h.size() / 2, h.end());
    q.levels[l].hull_median = h[h.size() / 2];
  }
  return q;
}

}  // namespace vgeo
