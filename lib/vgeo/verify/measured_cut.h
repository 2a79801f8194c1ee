#pragma once
// The cut at equal *measured* error: how many triangles a DAG needs to stay within ε of its
// leaves, whatever built it and whatever errors it claims (spec/conform.md §2.2).
// Per non-leaf cluster the deviation from the leaves is measured as ERROR_BOUND measures it
// (measure_cluster_deviation); a monotone hull takes the maximum up the DAG; the cut at ε draws
// cluster c iff hull(c) ≤ ε < hull of what c's group generated (+inf for terminal groups).
// One implementation, used by `vgeo compare` and `vgeo bench dagquality`.
#include <cstdint>
#include <vector>

#include "vgeo/dag/cluster_dag.h"

namespace vgeo {

// The 17-ε curve: ε log-spaced from 1e-3 to 1e-2 of the diagonal, 16 steps per decade. A DAG's
// levels halve the triangle count, so the cut at one ε jumps by up to 2x as ε crosses a level's
// typical hull (a sawtooth); 16 steps per decade are finer than one level's 2x error step, and
// the curve's geometric mean averages the sawtooth out.
constexpr int kMeasuredCutCurvePoints = 17;
constexpr double kMeasuredCutEpsilonLow = 1e-3;   // of the diagonal: fine detail
constexpr double kMeasuredCutEpsilonHigh = 1e-2;  // of the diagonal: a coarse view
double measured_cut_epsilon(int i);               // fraction of the diagonal, i in [0, 17)

struct DagQuality {
  double diagonal = 0;               // the ε unit (object units)
  uint64_t cut_measured[2] = {0, 0}; // triangles of the measured-hull cut at 1e-3, 1e-2
  uint64_t cut_stored[2] = {0, 0};   // the same cut by stored lod_error/parent_error
  std::vector<uint64_t> cut_curve;   // measured-hull cut at measured_cut_epsilon(i)
  double cut_curve_geometric_mean = 0;  // of cut_curve (a 0 counts as 1)
  std::vector<double> ratios;        // measured / stored lod_error, non-leaf clusters with 0 < stored < inf
  uint64_t roots = 0, root_triangles = 0;
  struct Level {
    uint64_t clusters = 0, triangles = 0;
    double hull_median = 0;  // of its clusters' measured hull, / diagonal
  };
  std::vector<Level> levels;  // by the level of the cluster's group
};

// `diagonal` > 0 fixes the ε unit (compare two builds of one mesh at the same ε); 0 = this
// DAG's leaf AABB diagonal. `threads`: measurement workers (0 = all cores).
DagQuality measure_dag_quality(const ClusterDag& dag, unsigned threads, double diagonal = 0);

}  // namespace vgeo
