#pragma once
// Invariant checker for cluster DAGs (spec/invariants.md is normative). Every check is a
// library function returning a verdict plus per-element diagnostics with a stable code;
// tests, `vgeo verify` and the runtime call the same functions. Works on any ClusterDag,
// also one produced by another implementation and read with read_dag_file().
//
// Checks (VerifyOptions::checks is a bitmask of these):
//   kCheckStructure  STRUCT_*  array sizes, index ranges, limits, levels, shared values, BVH
//   kCheckMonotonic  MONO_*    parent_error ≥ lod_error, parent_bounds ⊇ lod_bounds, and the
//                              projected error along every DAG edge for random views
//   kCheckCut        CUT_*     every leaf covered exactly once by lod_selects cuts; siblings agree
//   kCheckCrack      CRACK_*   each tested cut has the leaves' open edges (the mesh's own open
//                              border may be simplified unless strict_border)
//   kCheckErrorBound ERROR_*   sampled distance from each non-leaf cluster to the leaves ≤ lod_error
//   kCheckCertifiedBound ERROR_CERTIFIED  every point of each non-leaf cluster within lod_error of
//                              the leaves, proven (not sampled); opt-in: not in kCheckAll (vgeo's
//                              default build stores the sampled maximum; `--error-bound certified`
//                              stores what this proves)
// The later checks index the DAG's arrays, so they are skipped (and say so) when the
// structure check finds an index-safety violation.
#include <cstdint>
#include <string>
#include <vector>

#include "vgeo/dag/cluster_dag.h"
#include "vgeo/core/surface_distance.h"

namespace vgeo {

enum VerifyCheck : uint32_t {
  kCheckStructure = 1u << 0,
  kCheckMonotonic = 1u << 1,
  kCheckCut = 1u << 2,
  kCheckCrack = 1u << 3,
  kCheckErrorBound = 1u << 4,
  kCheckAll = (1u << 5) - 1,
  kCheckCertifiedBound = 1u << 5,  // opt-in (above)
};

// Stable names of the checks ("structure", "monotonic", "cut", "crack", "error_bound",
// "certified_bound").
const char* verify_check_name(VerifyCheck check);
// Parses a comma-separated list of check names (or "all"); returns false on an unknown name.
bool parse_verify_checks(const std::string& list, uint32_t* checks);

struct VerifyOptions {
  uint32_t checks = kCheckAll;
  uint32_t views = 64;                // random viewpoints (MONO_PROJECTED, CUT_*, CRACK_*)
  uint32_t thresholds_per_view = 4;   // pixel thresholds per viewpoint; each gives one cut
  uint64_t seed = 1;                  // views and thresholds are a pure function of the seed
  // Error-bound sampling: barycentric lattice with this many subdivisions per triangle edge
  // ((k+1)(k+2)/2 points per triangle; 3 = corners, edge thirds and the centroid).
  uint32_t error_samples_per_edge = kErrorLatticeSubdivisions;  // the builder's lattice (lib/vgeo/core/surface_distance.h)
  unsigned threads = 0;               // 0 = hardware concurrency; results identical for any value
  uint32_t max_stored_per_code = 64;  // violations kept per code (all are counted)
  // The mesh's own open border may be simplified (only vertices shared between groups need
  // locking; spec/invariants.md §4). Strict: any change of it is CRACK_BORDER_CHANGED.
  bool strict_border = false;
};

struct VerifyValue {
  std::string name;
  double value = 0;
};

struct Violation {
  std::string code;     // e.g. "MONO_BOUNDS" (spec/invariants.md)
  std::string check;    // verify_check_name() of the check that found it
  std::string element;  // "cluster", "group", "bvh_node", "edge", "view", "dag", "selection"
  uint64_t index = 0;   // index of the element (kNone-extended to 64 bits when not applicable)
  std::string message;  // one line
  std::vector<VerifyValue> values;  // the numbers behind the verdict
};

struct ViolationCount {
  std::string code;
  uint64_t count = 0;
};

struct Distribution {
  uint64_t count = 0;
  double min = 0, median = 0, p95 = 0, max = 0;
};

struct CheckStats {
  std::string check;
  bool ran = false;
  std::string skipped_reason;  // set when !ran although requested
  uint64_t items = 0;          // elements/views/cuts/samples examined
  uint64_t violations = 0;
  double seconds = 0;
};

struct VerifyReport {
  std::vector<Violation> violations;     // ≤ max_stored_per_code per code, in check order
  std::vector<ViolationCount> counts;    // every code that fired, with its full count
  std::vector<CheckStats> checks;        // one per requested check
  uint64_t clusters = 0, groups = 0, leaf_clusters = 0, levels = 0, triangles = 0;
  uint64_t cuts_tested = 0;
  uint64_t border_edges_changed = 0;     // over all cuts: mesh-border edges simplified (allowed unless strict)
  Distribution cut_clusters;             // selected clusters per tested cut
  Distribution error_ratio;              // measured / stored lod_error per non-leaf cluster (stored > 0)
  std::vector<Distribution> error_ratio_per_level;  // index = level (level 0 empty)
  uint64_t error_samples = 0;

  uint64_t total_violations() const;
  uint64_t count(const std::string& code) const;
  bool ok() const;
};

VerifyReport verify_dag(const ClusterDag& dag, const VerifyOptions& options = {});

// The ERROR_BOUND measurement, per cluster: the sampled one-sided distance from the cluster's
// triangles to the leaves (lattice of options.error_samples_per_edge, exact in double against
// a tree of all leaf triangles); 0 for leaves. Depends only on the DAG (any builder's).
struct ClusterDeviation {
  std::vector<double> distance;  // per cluster
  std::vector<DVec3> worst;      // the lattice point where it is reached
  uint64_t samples = 0;
};
ClusterDeviation measure_cluster_deviation(const ClusterDag& dag, const VerifyOptions& options = {});

// The report as a JSON object (spec/invariants.md §Report); `mesh` names the DAG.
std::string verify_report_json(const VerifyReport& report, const std::string& mesh = "");
// A short human-readable table (one line per check plus the distributions).
std::string verify_report_summary(const VerifyReport& report);

// ---- One explicit cut (the runtime checks the cut of every rendered frame) ----

// DAG-derived data reused across cuts: welded vertex ids, each cluster's open edges
// (mod 2), the leaves' open edges, group order. Build once per DAG.
struct CutCheckContext {
  bool usable = false;                  // false when the DAG fails index-safety checks
  std::vector<uint32_t> weld_id;        // per DAG vertex: id of its welded position
  std::vector<uint32_t> edge_offset;    // per cluster (+1): range in edges
  std::vector<uint64_t> edges;          // per cluster: its odd-use edges (packed welded ids)
  std::vector<uint64_t> leaf_open_edges;  // sorted odd-use edges of all leaves together
  std::vector<uint32_t> group_order;    // groups by decreasing level
  std::vector<float> weld_positions;    // 3 per welded id (diagnostics)
  std::vector<uint8_t> on_mesh_border;  // per welded id: endpoint of a leaf open edge
};

struct CutCheck {
  std::vector<Violation> violations;   // capped at max_stored
  std::vector<ViolationCount> counts;
  uint64_t selected = 0;
  uint64_t leaf_open_edges = 0;   // open edges (odd use) of the leaves
  uint64_t mismatched_edges = 0;  // edges whose parity differs between the cut and the leaves
  uint64_t border_edges_changed = 0;  // of those, edges between two mesh-border vertices
  bool ok() const;
};

CutCheckContext prepare_cut_check(const ClusterDag& dag);
// Checks that `selected` (cluster indices; order irrelevant) covers every leaf exactly once
// (CUT_COVERAGE, CUT_DUPLICATE, CUT_DANGLING_INDEX) and is crack-free (CRACK_OPEN_EDGE;
// with strict_border also CRACK_BORDER_CHANGED).
CutCheck check_cut(const ClusterDag& dag, const CutCheckContext& context,
                   const std::vector<uint32_t>& selected, uint32_t max_stored = 64, bool strict_border = false);
CutCheck check_cut(const ClusterDag& dag, const std::vector<uint32_t>& selected);

}  // namespace vgeo
