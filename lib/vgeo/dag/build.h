#pragma once
// Offline build of the cluster DAG (Nanite: cluster → group → simplify with locked group
// borders → split, level by level). Normative output description: spec/dag.md.
#include <cstdint>
#include <string>
#include <vector>

#include "vgeo/dag/cluster_dag.h"
#include "vgeo/mesh/mesh.h"

namespace vgeo {

enum class Simplifier : uint8_t { kMeshopt = 0, kOpenMesh = 1 };

enum class ErrorBound { kMeasured, kCertified };

struct BuildOptions {
  Simplifier simplifier = Simplifier::kMeshopt;
  unsigned threads = 0;     // 0 = machine's hardware concurrency; output is identical for any value
  bool progress = false;    // progress on stderr (the CLI enables it on a terminal)
  // What the stored errors promise (spec/dag.md §Error): kMeasured, the maximum over the
  // verify lattice (ERROR_BOUND); kCertified, an upper bound of the continuous deviation
  // (ERROR_CERTIFIED), for the same clusters, at some build time.
  ErrorBound error_bound = ErrorBound::kMeasured;
  // Edge flips towards the leaves after each group's simplification (spec/dag.md §3, Edge
  // flips), on the placed surface when vertex_placement is on: fewer triangles at equal
  // measured error. On by default (docs/acceptance/issue23_stop34.md: gmean over the issue's
  // 6 meshes 0.945 of the peer's against 0.993 without, ~10% more DAG CPU, no more memory).
  bool edge_flips = true;
  // Vertex placement after each group's simplification (spec/dag.md §2.3 Place): movable
  // vertices move off the leaves along their leaf normal, so the simplified surface lies on
  // both sides of curved leaves: fewer triangles at equal measured error
  // (docs/acceptance/issue23_place.md, docs/acceptance/issue23_modes.md). Either simplifier.
  // Off by default: on the 1M sphere it costs ~12% more DAG CPU than flips alone and peak RSS
  // 105 -> 132 MiB (1.31x the peer's; goal 2: <= 1.2x) (docs/acceptance/issue23_stop34.md);
  // off keeps every coarse vertex a leaf vertex (spec/dag.md D2).
  bool vertex_placement = false;
};

struct BuildLevelReport {
  uint32_t level = 0;
  uint64_t clusters = 0, triangles = 0, groups = 0, stuck_groups = 0;
  double average_fill = 0;            // mean triangles per cluster / kMaxClusterTriangles
  double boundary_edge_fraction = 0;  // cluster-boundary edges / all edges at this level
};

struct BuildReport {
  std::vector<BuildLevelReport> levels;
  uint64_t input_triangles = 0, stored_triangles = 0, root_clusters = 0, root_triangles = 0;
  // Wall-clock seconds per stage; they add up to seconds_total (the parallel simplify
  // region's wall time is divided between simplify/error/split by their summed task times).
  double seconds_cluster = 0, seconds_group = 0, seconds_simplify = 0, seconds_split = 0,
         seconds_hierarchy = 0, seconds_total = 0;
  double seconds_prepare = 0;  // validation + position welding
  // Per-level cluster edge counts (report + grouping input): only the gathering of the counts
  // the tasks that made the clusters took (in seconds_cluster / seconds_split), and with vertex
  // placement the counts themselves.
  double seconds_edges = 0;
  double seconds_locks = 0;    // per-level locked vertices and shared edges
  double seconds_error = 0;    // measured simplification error (part of the simplify region)
  double seconds_combine = 0;  // per-level results in group order, bounds, lock reset
  double seconds_layout = 0;   // final cluster/vertex arrays
  uint64_t peak_memory_bytes = 0;  // process peak RSS after the build
};

// Human summary of a build report: one header line, a per-level table, times and memory.
std::string build_report_summary(const std::string& mesh_name, const BuildReport& report);

// Builds the DAG of one mesh. Throws VgeoError on input it cannot build (e.g. empty mesh).
ClusterDag build_dag(const Mesh& mesh, const BuildOptions& options, BuildReport* report = nullptr);

// Builds every mesh of a scene (materials and instances carried over).
BuiltScene build_scene(const Scene& scene, const BuildOptions& options,
                       std::vector<BuildReport>* reports = nullptr);
// The same DAGs from a scene the caller gives up: the triangle list (`indices`) of a mesh the
// leaf pass clusters as one chunk (up to 2^17 triangles: kLeafChunkTriangles, build_internal.h)
// is taken over by it instead of copied, and left empty (the build's peak memory is lower by
// its size: armadillo's 0.6 MB). The rest of the scene is left as it was.
BuiltScene build_scene(Scene&& scene, const BuildOptions& options, std::vector<BuildReport>* reports = nullptr);

}  // namespace vgeo
