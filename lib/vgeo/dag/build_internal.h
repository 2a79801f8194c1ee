#pragma once
// Internal pieces of the DAG builder (lib/vgeo/dag), shared by its .cpp files and its tests.
// Not a public API: names and signatures may change with the builder.
#include <metis.h>

#include <cmath>
#include <array>
#include <cstdint>
#include <limits>
#include <mutex>
#include <vector>

#include "vgeo/dag/build.h"
#include "vgeo/core/math.h"
#include "vgeo/core/surface_distance.h"
#include "vgeo/core/surface_distance_impl.h"
#include "vgeo/core/thread_pool.h"
#include "vgeo/mesh/mesh.h"

namespace vgeo::build_detail {

// ---- tuning constants (spec/dag.md §Build explains each choice) ----

// A group is simplified to half its triangles (Nanite: "simplify to 50%"), so that the
// DAG stores about twice the input and each level halves the cluster count.
inline constexpr double kSimplifyTargetRatio = 0.5;
// A group with its own open edges (a chain, spec/dag.md §3 open-border caps) is also simplified
// with caps to this ratio, milder than kSimplifyTargetRatio, and that result competes by the
// product measured error × triangles like the other candidates: near the leaves of a holed
// mesh the measured error falls faster than 1/triangles as collapses are given back
// (elephant-with-holes' largest level-0 group: 788 triangles at 0.0080 at ratio 0.5, 967 at
// 0.0047 at 0.6, product 6.3 against 4.6). Measured on the 9 quality meshes
// (docs/acceptance/issue23_holes36.md): 0.55, 0.6 and 0.65 each bring every mesh under the
// peer's triangles at equal measured error, 0.6 has the smallest gmean of all 9 without a
// change of roots, 0.7 puts mech-holes-shark over the peer (1.039).
inline constexpr double kMilderCapsRatio = 0.6;
// A capped result with fewer real triangles than this share of the real target is redone
// (simplify_with_open_border_caps, simplify.cpp). 0.9 redoes elephant-with-holes' level-0 groups (82% of
// their target) and no group of the other measured meshes' default builds but blade's; 1.0
// (every short result) moved blade's last levels into a collapse (dagq 0.62 -> 0.90 of the
// peer, 1.02 with placement and flips); 0.8 redoes nothing (docs/acceptance/issue23_holes.md).
inline constexpr double kCapShortfallRedo = 0.9;
// Whether the milder capped candidate can win a group's product (spec/dag.md §3, open-border
// caps), asked before it is simplified: `input` triangles in the group, `capped` the triangles
// of its first result if that moved the group's own open borders (caps, or a lone group's
// simplification without LockBorder; 0: it did not), `kept_product` the kept result's
// measured error × triangles, `floor` the members' largest stored error, `ratio` the milder
// ratio. It cannot where
// * that result already holds `ratio` of the input: meshopt stopped short of the target
//   (the error budget, or a border retry's ratio), and the milder target asks for no fewer
//   triangles than it kept, so there is nothing to give back;
// * the kept product is at most floor × kCapShortfallRedo × ratio × input: the milder result's
//   measured error is at least the floor (the members' error is a floor), and it keeps about
//   `ratio` of the input (at least kCapShortfallRedo of that target, which the shortfall redo
//   asks for), so its product cannot be the smaller.
// Over the 34 CGAL meshes whose groups run the candidate it skips 61 of 302 runs, none of the
// 72 it won (every output byte-identical; docs/acceptance/issue23_holes37.md).
inline bool milder_caps_may_win(double input, double capped, double kept_product, float floor, double ratio) {
  if (capped >= ratio * input) return false;
  return kept_product > double(floor) * kCapShortfallRedo * ratio * input;
}
// A group whose simplification removes fewer than 15% of its triangles is terminal: it
// would otherwise spend levels on almost nothing; forcing progress by unlocking its border
// would open cracks (spec/dag.md §2: > 85% of the triangles left = stuck).
inline constexpr double kMinReduction = 0.15;
// Target ratios of the retries of a group whose simplification broke its border or folded
// (spec/dag.md §2.3): fewer collapses, each still below 1 - kMinReduction = 0.85.
inline constexpr std::array<double, 2> kBorderRetryRatios = {0.65, 0.8};
// Mean clusters per group asked from the partitioner (chosen with METIS k-way, kept for the
// greedy partitioner that replaced it: same mean group weight). Chosen by `vgeo bench dagquality` (spec/dag.md,
// "Group size and error budget"): 16 with kSimplifyErrorBudget draws 9–50% fewer triangles at equal
// measured error than 8 on the spheres, bunny00, refined_elephant and mech-holes-shark
// (fewer locked border edges per triangle), 12% more on armadillo at 1e-3 only.
inline constexpr uint32_t kGroupTargetClusters = 16;
// The OpenMesh backend keeps 8: with 16 its measured/stored error median fell to 0.73–0.75
// on bunny00 and refined_elephant (0.82–0.84 with 8) and bunny00 and armadillo drew 4–8%
// more triangles at 1e-3 (its decimater has no error budget to stop a group's spike).
inline constexpr uint32_t kGroupTargetClustersOpenMesh = 8;
inline uint32_t default_group_target_clusters(Simplifier s) {
  return s == Simplifier::kOpenMesh ? kGroupTargetClustersOpenMesh : kGroupTargetClusters;
}
// A group's meshopt simplification stops where meshopt's error estimate passes this × the
// largest stored error of its members (spec/dag.md, "Group size and error budget"): a group whose
// members are already coarse may halve; one that would jump far above its members' error
// stops earlier, so one group's error spike does not hold the cut back. 1.25 was best of
// 1, 1.25, 1.5 (1 and below stop most groups; ≥ 2 never binds).
inline constexpr float kSimplifyErrorBudget = 1.25f;
// Weak spatial edges for islands: each cluster is linked to its nearest kSpatialNeighbors
// clusters among kSpatialWindow neighbours on each side in Morton order, with weight 1
// (a shared triangle edge weighs 1 too, and real neighbours share ~10-30 edges), so
// they only decide where the mesh graph gives no preference: islands share no edge, so the
// partitioner would group them arbitrarily (or leave them alone), while strong spatial edges
// override the surface's own.
inline constexpr uint32_t kSpatialNeighbors = 2;
inline constexpr uint32_t kSpatialWindow = 8;
inline constexpr int kSpatialEdgeWeight = 1;
// Levels with more active clusters than this are grouped in spatial blocks of at most this
// many clusters, one partition each, so the blocks' partitions run in parallel and overlap the
// simplification of blocks already grouped. 4096 clusters = 256 groups per block: block
// borders are a few percent of the group borders (they are group borders at that level).
inline constexpr size_t kGroupBlockClusters = 4096;
// Fixed METIS seed: METIS is randomised; a fixed seed makes the grouping reproducible.
inline constexpr int kMetisSeed = 42;
// No mesh needs more: each level at least halves the non-terminal clusters or retires
// them, so 64 levels cover 2^64 clusters. Remaining clusters become terminal.
inline constexpr uint32_t kMaxLevels = 64;
// Meshes above this many triangles are leaf-clustered in spatial chunks of about this
// size, in parallel: chunk borders add ~1% cluster-border edges at 128k triangles/chunk.
inline constexpr size_t kLeafChunkTriangles = size_t(1) << 17;
// Seams (spec/dag.md §2.3): mesh-border vertices less than this fraction of the mesh's
// largest axis extent apart (per axis) are locked at every level. The page format's coarsest
// automatic position grid (16 bits, spec/format.md §2.1) has the smallest power-of-two step s
// with extent <= 2^16 s, so s < 2^-15 extent, and coordinates it rounds together differ by
// less than s.
inline constexpr double kSeamExtentFraction = 0x1p-15;
// ... or less than this fraction of the largest |coordinate|: the grid step is also at least
// max|p| / (2^24 - 1) (quantized coordinates fit 2^24), which is below 2^-22 max|p|.
inline constexpr double kSeamMagnitudeFraction = 0x1p-22;
// A cell of the seam search holding more mesh-border vertices than this pins them all instead
// of comparing every pair (bounded work on pathological inputs; pinning is always safe).
inline constexpr size_t kSeamCellPairwiseLimit = 64;
// Vertex placement (spec/dag.md §2.3 Place): offset = this × the mean estimated centroid sag
// of the vertex's simplified triangles. On a sphere 1/2 would balance a flat triangle's
// centroid (inside) against its corners (outside), but locked border corners never move and
// the leaves' own facets add to the deviation at fine levels: measured with dagq
// (docs/acceptance/issue23_place.md), 0.25 drew the fewest triangles at equal measured error
// of 0.25, 0.35, 0.4 and 0.5 on the 1M sphere and the 8 CGAL meshes of the issue.
inline constexpr double kPlacementShare = 0.25;
// meshopt target error (relative to the sub-mesh extent): 1 = "no error bound", the
// triangle count target drives the simplification and the error is measured.
inline constexpr float kMeshoptTargetError = 1.0f;

// ---- the welded input (welded_mesh.cpp) ----
struct WeldedMesh {
  const Mesh* mesh = nullptr;
  // weld[v] = smallest vertex index whose position has the same bits as v's. Adjacency,
  // borders and locks are computed on welded ids, so attribute seams do not cut the graph.
  std::vector<uint32_t> weld;
  // copies[w] = input vertices at welded position w (saturating at 255; 0 for other ids).
  // More than two make w a per-corner position (simplify.cpp, kMaxSeamWedges) at every level,
  // also where a group holds only one or two of its copies.
  std::vector<uint8_t> copies;
};
WeldedMesh weld_positions(const Mesh& mesh);

// A set of triangles referencing original vertex ids (corners) with one material each.
struct TriangleSet {
  std::vector<uint32_t> corners;    // 3 per triangle, original vertex ids
  std::vector<uint32_t> materials;  // 1 per triangle
  size_t triangle_count() const { return materials.size(); }
};

// Degenerate triangle (spec/dag.md §2.2): two corners share a welded position, or its height
// over its longest edge is below kDegenerateRelativeHeight (collinear up to the float rounding
// of its coordinates: 2^-20 is 16 ulps). It has no area and no direction: the clusterizer
// places such triangles badly and the simplifier misreads them (a repeated-corner triangle
// closes a border edge, a sliver's vertex copies look like seams).
inline constexpr double kDegenerateRelativeHeight = 1.0 / (1 << 20);
bool is_degenerate(const WeldedMesh& welded, const uint32_t* corners);

// Fins (spec/dag.md §2.3): collinear degenerate triangles on three distinct welded positions
// each of which ends an edge used an odd number of times by the whole mesh (a sliver hung on
// an edge, or on the mesh border). Their edges all join mesh-border vertices, so leaving them
// out of the simplifier's input changes only the mesh's own border, which coarser levels may
// simplify; a sliver inside a closed surface is not a fin (dropping it would open a crack).
// Corner triples, each sorted, in ascending order; empty for most meshes (one parallel scan).
using FinSet = std::vector<std::array<uint32_t, 3>>;
// Triangles per task of the fin scan: large enough that task overhead is noise (the test per
// triangle is a few ns), small enough to balance two threads on a 1M mesh.
inline constexpr size_t kFinScanTriangles = size_t(1) << 16;
// With `degenerate`, it also gets is_degenerate of every mesh triangle (the scan computes it),
// so the leaf split need not compute it again (split_into_clusters' `degenerate`).
FinSet find_fins(const WeldedMesh& welded, ThreadPool& pool, std::vector<uint8_t>* degenerate = nullptr);

// Splits triangles into clusters of ≤ kMaxClusterTriangles triangles and
// ≤ kMaxClusterVertices original vertices. Deterministic. `scratch` must have
// weld.size() entries, all kNone, and is returned in that state. kGrow: the own greedy grower
// (the default; meshopt_buildMeshlets 0.18's rule, cluster_grow.cpp); kMeshopt:
// meshopt_buildMeshlets itself; kMetis: recursive bisection (both kept for measurement).
// `degenerate`, when given: is_degenerate of each triangle of `tris`, known already.
// `sink`, when given, gets the clusters instead of the result (which is then empty): in
// order, in batches, each as soon as it is final (ClusterSink).
enum class SplitMethod : uint8_t { kMeshopt = 0, kMetis = 1, kGrow = 2 };
class ClusterSink;
std::vector<TriangleSet> split_into_clusters(const WeldedMesh& welded, const TriangleSet& tris,
                                             std::vector<uint32_t>& scratch,
                                             SplitMethod method = SplitMethod::kGrow,
                                             const uint8_t* degenerate = nullptr, ClusterSink* sink = nullptr);
// Takes a split's clusters as the splitter finishes them (split_into_clusters with a sink), so
// the leaf pass gives them their facts on another thread while the grower goes on
// (build_leaves). The grower hands them over every kSinkBatchClusters clusters; a split that
// rewrites its clusters afterwards (degenerate triangles attached) or another method, at the
// end, in batches of that size.
class ClusterSink {
 public:
  virtual ~ClusterSink() = default;
  // The next `count` clusters in order: the sink moves them out.
  virtual void take(TriangleSet* clusters, size_t count) = 0;
  // The next `count` clusters in order as lists of triangles (indices into `tris`, which stays
  // alive and unchanged until the split returns, or until the sink is done with them where its
  // owner keeps it longer): cluster k is ids[ends[k - 1] .. ends[k]) (ends[-1] = 0). The grower
  // hands its clusters over this way, so a sink may build their TriangleSets on another thread
  // (append_cluster and the sets' hand-over: 3-6 CPU-ms of bunny00's ~20-ms grower at two
  // threads, docs/acceptance/issue23_leaf40.md). By default: built here, then take().
  virtual void take_lists(const TriangleSet& tris, const uint32_t* ids, const uint32_t* ends, size_t count);
};
// ~150 µs of facts per batch (cluster_facts: ~5 µs a cluster on the 1M sphere, measured), which
// is what is left after a chunk's grower ends, against a few µs (estimated) of hand-over on the
// grower's thread: a lock, and a futex wake-up where the other thread waits. bunny00's 590
// leaves are 19 batches.
inline constexpr size_t kSinkBatchClusters = 32;

// The splitters' shared steps (cluster_split.cpp), the grower (cluster_grow.cpp) and the two
// kept for measurement (cluster_split_alternatives.cpp), which split_into_clusters calls.
// Compacts the welded ids of `tris` into local ids [0, n) in order of first use.
// Returns the welded ids per local id; `local_corner` gets 3 local ids per triangle.
std::vector<uint32_t> compact_welded(const WeldedMesh& welded, const TriangleSet& tris,
                                     std::vector<uint32_t>& scratch, std::vector<uint32_t>& local_corner);
// Appends one cluster of triangles `ids` (indices into tris), as they are: the caller knows
// it holds ≤ kMaxClusterTriangles triangles and ≤ kMaxClusterVertices original vertices.
void append_cluster(const TriangleSet& tris, const uint32_t* ids, size_t count, std::vector<TriangleSet>& out);
// Appends the clusters holding triangles `ids` (indices into tris), bisecting in order
// until the original-vertex limit holds (attribute seams can push a welded cluster of
// ≤ 255 positions over 255 vertices).
void emit_cluster(const TriangleSet& tris, const uint32_t* ids, size_t count, std::vector<uint32_t>& scratch,
                  std::vector<TriangleSet>& out);
// The pieces emit_cluster cuts triangles `ids` into, as the ends of consecutive ranges of
// `ids`, each plus `offset`, appended to `ends`.
void cluster_pieces(const TriangleSet& tris, const uint32_t* ids, size_t count, std::vector<uint32_t>& scratch,
                    uint32_t offset, std::vector<uint32_t>& ends);
// along_curve = false: the grower keeps the input order of a large split instead of the curve
// order (slower; the same clusters: tests compare the two).
// `sink`: as split_into_clusters'.
std::vector<TriangleSet> split_grow(const WeldedMesh& welded, const TriangleSet& tris, std::vector<uint32_t>& scratch,
                                   bool along_curve = true, ClusterSink* sink = nullptr);
std::vector<TriangleSet> split_meshopt(const WeldedMesh& welded, const TriangleSet& tris,
                                       std::vector<uint32_t>& scratch);
std::vector<TriangleSet> split_metis(const WeldedMesh& welded, const TriangleSet& tris,
                                     std::vector<uint32_t>& scratch);

// How group_clusters partitions the cluster graph: kGreedy (the builder's; cluster_partition.cpp)
// or METIS k-way (kept for measuring: quality at parity, ~9× the CPU; spec/dag.md §Grouping).
enum class GroupMethod { kGreedy, kMetis };

// Clusters → groups: returns, per group, its member indices into `clusters` (ascending).
// Deterministic (kGreedy: serial, ties broken by index; kMetis: fixed seed, single call).
// `open_edges[i]`: the welded edge keys used once inside cluster i, in any order
// (count_cluster_edges; the graph is built from all of them sorted together).
// `pool`: a pool of idle threads for the graph's passes on large blocks (a level of one block),
// or null (one thread); the groups are the same either way.
std::vector<std::vector<uint32_t>> group_clusters(const std::vector<const TriangleSet*>& clusters,
                                                  const std::vector<std::vector<uint64_t>>& open_edges,
                                                  const std::vector<Sphere>& bounds,
                                                  uint32_t target_clusters = kGroupTargetClusters,
                                                  GroupMethod method = GroupMethod::kGreedy, ThreadPool* pool = nullptr);

// One use of a welded edge by list `list` of sorted_edge_uses' input, the edge key compressed
// to (high << low_bits) | low (SortedEdgeUses::edge gives edge_key back).
struct KeyedUse {
  uint64_t key;
  uint32_t list;
};
struct SortedEdgeUses {
  std::vector<KeyedUse> uses;
  uint32_t low_bits = 0;
  uint64_t edge(size_t i) const {
    return (uses[i].key >> low_bits) << 32 | (uses[i].key & ((uint64_t(1) << low_bits) - 1));
  }
};
// Every edge key of lists[i] paired with i, sorted by key, then i (group.cpp): what a sort of
// the (key, i) pairs gives. `pool` (may be null): a pool of idle threads for large inputs; the
// same order either way.
SortedEdgeUses sorted_edge_uses(const std::vector<std::vector<uint64_t>>& lists, ThreadPool* pool);

// The cluster graph of a block: row c = [first[c], first[c + 1]) of (to, weight), neighbours
// ascending, weight = shared welded edges (+ the weak spatial edges, kSpatialEdgeWeight).
struct ClusterAdjacency {
  std::vector<uint32_t> first, to, weight;
};
// Partitions the graph's nodes (node weight = triangles) into groups of about the weight of
// 1 / part_count of the whole with few cut edges (cluster_partition.cpp): returns each node's
// group, groups numbered in order of their lowest node. Deterministic.
std::vector<uint32_t> partition_clusters(const ClusterAdjacency& graph, const std::vector<uint32_t>& weight,
                                         size_t part_count);

// Splits items (by their centres) into spatially compact blocks of at most max_items:
// recursive median split along the largest extent, ties by index. Each block's indices are
// ascending; blocks are in split order (lower half first). Deterministic.
std::vector<std::vector<uint32_t>> spatial_blocks(const std::vector<Vec3>& centres, size_t max_items);

// The locks of a level with several spatial blocks, before any block task runs: locks
// (locked[w] = 1) every welded vertex used by clusters of two blocks (block_of[i] = block of
// clusters[i]) and returns the sorted welded edges used by two blocks. `owner` (weld.size()
// entries, all kNone) is scratch, returned all kNone. Same result for any thread count.
// `vertices` (optional, per cluster, null where unknown): the distinct welded ids of its
// corners; the claims then walk those instead of the corners (the same locks).
std::vector<uint64_t> lock_cross_block_vertices(const WeldedMesh& welded, const std::vector<const TriangleSet*>& clusters,
                                                const std::vector<uint32_t>& block_of, ThreadPool& pool,
                                                std::vector<uint32_t>& owner, std::vector<uint8_t>& locked,
                                                const std::vector<const std::vector<uint32_t>*>* vertices = nullptr);

// Knobs for measuring alternatives (benchmarks, tests); build_dag uses the defaults.
struct InternalBuildOptions {
  SplitMethod leaf_split = SplitMethod::kGrow;
  SplitMethod group_split = SplitMethod::kGrow;
  uint32_t group_target_clusters = 0;  // 0: default_group_target_clusters(the simplifier)
  size_t group_block_clusters = kGroupBlockClusters;  // tests force small blocks
  GroupMethod group_method = GroupMethod::kGreedy;
  double simplify_target_ratio = kSimplifyTargetRatio;
  // > 0: a group's simplification stops where meshopt's error estimate passes this × the
  // largest stored error of its members (0: no bound, the ratio alone decides).
  float simplify_error_budget = kSimplifyErrorBudget;
  bool simplify_open_borders = true;  // SimplifyTarget::open_borders
  double milder_caps_ratio = kMilderCapsRatio;  // 0: no milder capped candidate (tests compare)
  // false: every candidate of a group is simplified and measured (milder_caps_may_win and the
  // repeat check of simplify_one_group off; the same output, tests compare)
  bool skip_losing_candidates = true;
  double placement_share = kPlacementShare;  // PlacementContext::share (with BuildOptions::vertex_placement)
};
ClusterDag build_dag_internal(const Mesh& mesh, const BuildOptions& options, const InternalBuildOptions& internal,
                              BuildReport* report);

// A triangle and its reverse (the same welded positions, opposite orientation) are a fold
// that adds 2 to each of their edges' use counts: parity unchanged, so neither the border
// nor the fold check sees it, but on a group border it makes a locked edge non-manifold
// (used 3 times) and the pair covers its area twice. meshopt 0.18 emits such pairs; both
// triangles of each pair are dropped (every edge's parity is kept).
void drop_reversed_pairs(const WeldedMesh& welded, TriangleSet& triangles);

// Open-border caps (border_caps.cpp): temporary triangles that close each chain of the
// group's own open edges (an open edge with an unlocked end) to one apex vertex, so meshopt
// 0.18's LockBorder locks only the group border and the apexes, and the mesh's own borders
// simplify. add_open_border_caps appends apexes to `positions` (xyz per sub-mesh vertex) and
// cap triangles to `indices`; welded_of_sub[v] is sub-mesh vertex v's welded id.
struct BorderCaps {
  size_t first_apex = 0;        // sub-mesh vertices from here on are apexes and copies
  std::vector<uint32_t> origin;  // per appended vertex: the real sub-mesh vertex it copies, or ~0 (apex)
  size_t apex_count = 0;        // 0: nothing was added
  size_t cap_triangles = 0;
};
// A group's own open edges, found once per group (every simplification of it sees the same
// welded edges): `chain_corners`, the corners i of `input` whose welded edge (i, next corner)
// the input uses once and which has an unlocked end (ascending: the caps' chain edges), and
// `open_edges`, the welded edges the input uses once (sorted). One hash count of the edges.
struct OpenBorder {
  std::vector<uint32_t> chain_corners;
  std::vector<uint64_t> open_edges;
};
OpenBorder find_open_border(const WeldedMesh& welded, const TriangleSet& input, const std::vector<uint8_t>& locked);
// `chain_corners`: find_open_border's, for the sub-mesh whose corners `indices` are (one per
// input corner, in order).
BorderCaps add_open_border_caps(const std::vector<uint32_t>& chain_corners, const std::vector<uint32_t>& welded_of_sub,
                                const std::vector<uint8_t>& locked, std::vector<unsigned int>& indices,
                                std::vector<float>& positions, bool keep_loops = false);
// Removes the cap triangles from a simplification `out` (out_count indices) of the capped
// sub-mesh. False when the result is not a simplification of the real surface alone (an apex
// lost, a real vertex moved onto an apex, a cap base not a single border edge of the real
// output, or a new open edge that is no cap base nor in `input_open_edges`, find_open_border's
// open_edges): then the caller simplifies without caps.
bool remove_open_border_caps(const BorderCaps& caps, const std::vector<uint32_t>& welded_of_sub,
                             const std::vector<uint8_t>& mesh_border, const std::vector<uint64_t>& input_open_edges,
                             std::vector<unsigned int>& out, size_t& out_count);

// Simplification of one group's triangles with locked vertices (by welded id).
struct SimplifyResult {
  TriangleSet triangles;  // references original vertex ids only (no new positions)
  bool capped = false;    // the group's own open borders were simplified (border_caps.cpp)
  // Known to use every locked welded id of the group (PreparedGroup::group_locked): the
  // meshopt backend checked it for its retries, and nothing was dropped since.
  bool group_locked_kept = false;
};
// The smallest float ≥ d: stored errors are rounded up, never below the measured double.
inline float round_up_to_float(double d) {
  float e = float(d);
  if (double(e) < d) e = std::nextafter(e, std::numeric_limits<float>::infinity());
  return e;
}

// Vertex placement's crease angle, 30 degrees (LeafSurface::normal): a smooth mesh's leaf
// faces around a vertex stay well within it; CAD edges (90 degrees) and sharp features do not.
inline constexpr double kCosPlacementCrease = 0.8660254037844386;

// The original surface, for measuring a simplification's deviation from it (leaf_error.cpp):
// all leaf triangles in a distance tree, and their edge adjacency (by welded id) for walking
// from triangle to triangle before asking the tree. Triangle ids are the tree's.
struct LeafSurface {
  TriangleDistanceTree tree;
  // neighbour[3t + j]: a triangle sharing edge j of t (corners j, (j + 1) % 3, welded), kNone
  // on a border; on an edge of more than two triangles, the first other one in id order.
  std::vector<uint32_t> neighbour;
  // vertex_triangle[v] (v: a mesh vertex): the smallest triangle id with a corner welded to v,
  // or kNone.
  std::vector<uint32_t> vertex_triangle;
  // Vertices placed off the leaves (vertex_placement.cpp) get ids from leaf_vertex_count on:
  // moved_origin[v - leaf_vertex_count] is the leaf vertex each was moved from (where a walk
  // over the leaves starts). Ids below leaf_vertex_count are the mesh's: leaf vertices.
  uint32_t leaf_vertex_count = 0;
  std::vector<uint32_t> moved_origin;
  // With vertex placement: per welded leaf vertex, 3 floats: the area-weighted normal of its
  // leaf triangles, or 0 where some of them faces more than the crease angle away from it (a
  // crease or a CAD face edge: moving along the average would leave both faces) or none has an
  // area. Only these vertices move.
  std::vector<float> normal;
  // The leaf vertex vertex `v` is (v itself) or was moved from.
  uint32_t origin(uint32_t v) const { return v < leaf_vertex_count ? v : moved_origin[v - leaf_vertex_count]; }
};
// Moved vertices of one group before their ids are final (vertex_placement.cpp): ids first,
// first + 1, ... (ordered as their final ids will be, all above every id in use) have
// positions[3i, 3i + 3), leaf vertex origin[i] and replace vertex previous[i] (an input
// vertex of the group), i < count. first = kNone: none.
struct FreshVertices {
  uint32_t first = kNone, count = 0;
  const float* positions = nullptr;
  const uint32_t* origin = nullptr;
  const uint32_t* previous = nullptr;
};
// `normals`: also LeafSurface::normal (vertex placement).
LeafSurface build_leaf_surface(const WeldedMesh& welded, const std::vector<const TriangleSet*>& leaves,
                               ThreadPool& pool, bool normals = false);
// Where a visibility walk over the leaf surface ends: from triangle `start` towards p, crossing
// the first edge p lies outside of, never straight back, at most `max_steps` triangles; in the
// triangle p projects into (projects_inside), or where it stops: a border, a ridge (two
// triangles each behind the other), a triangle without a normal, the step limit.
struct LeafWalkEnd {
  uint32_t triangle = kNone;
  PreparedTriangle prepared;
  bool projects_inside = false;
};
LeafWalkEnd walk_leaf_surface(const LeafSurface& s, DVec3 p, uint32_t start, int max_steps);
// max(floor, the distance lib/vgeo/verify measures from `simplified` to the leaves), rounded
// up to float: the lattice of surface_distance.h, exact nearest leaf triangle, the same
// points. `floor` = the largest stored error of the group's members (`input`); the search
// skips points that cannot raise the result (within the floor, or on an edge of a simplified
// input, measured for the members already).
// Where the measured maximum lies: the lattice point farthest from the leaves that raised the
// result above the floor, as the triangle of `simplified` it was visited from and its place
// there (0..2: a point of edge j, corners j and j + 1; kLatticeInterior: an interior point).
// triangle = kNone when no point lies beyond the floor (the result is the floor).
inline constexpr int kLatticeInterior = 3;
// corner: the point is a moved vertex (FreshVertices), a corner no flip changes.
struct LatticePeak {
  uint32_t triangle = kNone;
  int place = kLatticeInterior;
  bool corner = false;
};
// What leaf_deviation found at each place of `simplified` (places[4t + place], place as in
// LatticePeak): the largest upper bound of its points' squared distances to the leaves (the
// walk's or the tree's triangle that decided each; exact for a point that raised the
// maximum) and the leaf triangle where that point's walk or search ended; d2 < 0: no point
// visited there (an edge of the input, or one visited from its other triangle). With moved
// vertices (FreshVertices), fresh[i] is moved vertex first + i's corner point; a point the
// search skipped as unable to raise the maximum (a moved corner, an input edge with a moved
// end) is recorded with that bound, floor + displacement.
struct LatticeRecord {
  struct Place {
    double d2 = -1;
    uint32_t leaf = kNone;
  };
  std::vector<Place> places;
  std::vector<Place> fresh;
};
// `fresh`: corners with ids from fresh->first on are moved vertices (not leaf vertices: their
// points are measured, corners included; their edges are no edge of the input).
// `pool`: the measurement is cut into pieces measured on it (the same value, peak and record,
// bit for bit; one with a peak but no record, or with moved vertices and a record, is not);
// not to be called from a task of that pool (no nested parallel_for).
float leaf_deviation(const LeafSurface& leaves, const Mesh& mesh, const TriangleSet& input, const TriangleSet& simplified,
                     float floor, LatticePeak* peak = nullptr, LatticeRecord* record = nullptr,
                     const FreshVertices* fresh = nullptr, ThreadPool* pool = nullptr);
// leaf_deviation(leaves, mesh, input, changed_surface, floor), bit for bit, where
// `changed_surface` is a surface leaf_deviation measured with `record`, with the triangles
// marked in `changed` replaced (same count; an edge of a replaced triangle that is still used
// is used by a replaced one): only the replaced triangles' points are visited, and the
// others' recorded bounds decide which of them need a search.
// `fresh`: as leaf_deviation's, the same as the measurement that recorded `record`. `pool`: as
// leaf_deviation's (the replaced triangles' points are measured on it).
float leaf_deviation_after_change(const LeafSurface& leaves, const Mesh& mesh, const TriangleSet& input,
                                  const TriangleSet& changed_surface, const std::vector<uint8_t>& changed,
                                  const LatticeRecord& record, float floor, const FreshVertices* fresh = nullptr,
                                  ThreadPool* pool = nullptr);
// Flips edges inside a simplified group where the other diagonal lies clearly closer to the
// leaves; never an edge with both ends locked, never onto an existing edge (edge_flip.cpp).
// Only flips that can lower the group's measured error are wanted (spec/dag.md §3, edge
// flips): the edges that change the lattice point at `peak` (leaf_deviation's) are tried
// first, and when none of them flips, nothing is flipped. Returns whether any edge flipped.
// `flipped` gets, per triangle, whether a flip replaced it. `fresh`: corners from fresh->first
// on are moved vertices (their positions are fresh's; welded and locked as the vertex they
// replace), as in the measurement that found `peak` and `record`. `pool`: the candidates' tests
// run on it (the same flips); not to be called from a task of that pool.
bool flip_edges_towards_leaves(const WeldedMesh& welded, const LeafSurface& leaves, const std::vector<uint8_t>& locked,
                               float floor, const LatticePeak& peak, const LatticeRecord& record, TriangleSet& triangles,
                               std::vector<uint8_t>& flipped, const FreshVertices* fresh = nullptr,
                               ThreadPool* pool = nullptr);

// Certified mode (BuildOptions::error_bound = ErrorBound::kCertified; leaf_certify.cpp,
// spec/dag.md §Error "Certified bound"). twin[3t + j]: the edge k of g = neighbour[3t + j]
// that runs back along edge j of t (welded) and whose neighbour is t, on an edge of exactly
// these two triangles; 3 when there is none (a border, an edge of more than two triangles, or
// g wound the other way): the only leaf edges the certification's overlay crosses.
struct LeafTwins {
  std::vector<uint8_t> twin;
};
LeafTwins build_leaf_twins(const LeafSurface& leaves, const WeldedMesh& welded, ThreadPool& pool);
// max(floor, lower, a certified upper bound of the continuous one-sided deviation of the
// triangles of `simplified` from the leaves), rounded up to float. `floor`: the members'
// (certified) stored error; `lower`: an exact distance of some point of these triangles to the
// leaves (their measured error) or 0, where the search for the maximum starts.
float certified_leaf_deviation(const LeafSurface& leaves, const LeafTwins& twins, const Mesh& mesh,
                               const std::vector<const TriangleSet*>& simplified, float floor, double lower);

// Vertex placement (vertex_placement.cpp, spec/dag.md §2.3 Place).
// |offset| ≤ this × the vertex's shortest incident simplified edge: the sag estimate assumes
// the surface is nearly flat over a triangle (sag ≪ edge: L/(6R) on a sphere); beyond that
// it is no estimate, and a large move could fold a thin part.
inline constexpr double kMaxOffsetPerEdge = 0.125;
// A position with more attribute copies than this is per-corner (simplify.cpp: every wedge its
// own vertex): left where it is.
inline constexpr uint8_t kMaxMovedCopies = 2;
struct PlacementContext {
  const WeldedMesh* welded = nullptr;
  const Mesh* mesh = nullptr;             // current positions by id (leaves and moved vertices)
  const float* leaf_positions = nullptr;  // the input mesh's positions (leaf vertices)
  const LeafSurface* leaves = nullptr;    // origin of moved ids, leaf normals
  const std::vector<uint8_t>* locked = nullptr;
  const std::vector<uint8_t>* pinned = nullptr;
  const std::vector<uint8_t>* mesh_border = nullptr;  // may be empty
  double share = kPlacementShare;
};
// The vertices of `tris` to move, in order of first use, and their new positions (3 floats
// each; all attribute copies of a welded position: the same bits). `scratch` (weld.size(), all
// kNone) is returned in that state.
struct VertexMoves {
  std::vector<uint32_t> vertex;
  std::vector<float> positions;
};
VertexMoves place_vertices(const PlacementContext& ctx, const TriangleSet& tris, std::vector<uint32_t>& scratch);

// How far a group is simplified: to ratio × its triangles, stopping early where the
// backend's error estimate would pass max_error (object units; meshopt only; +inf: no bound).
struct SimplifyTarget {
  double ratio = kSimplifyTargetRatio;
  float max_error = std::numeric_limits<float>::infinity();
  // meshopt: the group's own open borders simplify (add_open_border_caps); false: LockBorder
  // keeps them as it keeps the group border.
  bool open_borders = true;
  // meshopt, open_borders: a group sharing no vertex with another group is simplified without
  // LockBorder (false: with caps, as other groups are).
  bool lone_unlocked = true;
  // meshopt, caps: every loop of the group's own open edges keeps three vertices fixed, so no
  // hole closes (uncapped_keeping_loops, border_caps.cpp).
  bool keep_loops = false;
  // Welded ids on the mesh's own open edges (1), the only ends a new open edge may have;
  // null: no caps (open_borders is then ignored).
  const std::vector<uint8_t>* mesh_border = nullptr;
};
// Triangles of `fins` (find_fins) are left out of the simplifier's input like those with a
// repeated welded position (spec/dag.md §2.3).
SimplifyResult simplify_group(const WeldedMesh& welded, const TriangleSet& group,
                              const std::vector<uint8_t>& locked, Simplifier simplifier,
                              const SimplifyTarget& target = {}, const FinSet& fins = {});

// What simplify_group builds from a group before simplifying it, which does not depend on the
// target: the builder prepares each group once (prepare_group; the level's locks are final
// before any group is simplified) and simplifies it as often as its retries need
// (simplify_prepared), each time from the same input.
struct PreparedGroup {
  const TriangleSet* group = nullptr;
  bool any_left_out = false;  // degenerate triangles or fins were left out: the input is `proper`
  TriangleSet proper;
  const TriangleSet& input() const { return any_left_out ? proper : *group; }
  // meshopt's sub-mesh (simplify.cpp): sorted distinct sub-mesh keys (vertex or welded id) << 32
  // | material, one per sub-mesh vertex; their xyz, and 3 indices per input triangle.
  std::vector<uint64_t> sub_keys;
  std::vector<float> positions;
  std::vector<unsigned int> indices;
  float scale = 0.0f;  // meshopt_simplifyScale of the sub-mesh
  // Welded ids whose wedges are welded into one sub-mesh vertex per material (sorted), and, when
  // any, each input corner's sub-mesh key (the corners that may take its attributes).
  std::vector<uint32_t> welded_positions;
  std::vector<uint64_t> corner_sub_key;
  // Distinct locked welded ids of the group's corners and of the input's (in no particular
  // order): what the border checks ask the simplifications to keep.
  std::vector<uint32_t> group_locked, input_locked;
  // The input's open edges, for open-border caps (empty unless prepared for them).
  OpenBorder open_border;
};
// `scratch` (weld.size() entries, all kNone) is returned in that state.
// `mesh_border`: SimplifyTarget::mesh_border when some simplification of the group may ask for
// open-border caps (open_borders), else null.
PreparedGroup prepare_group(const WeldedMesh& welded, const TriangleSet& group, const std::vector<uint8_t>& locked,
                            Simplifier simplifier, const FinSet& fins, const std::vector<uint8_t>* mesh_border,
                            std::vector<uint32_t>& scratch);
SimplifyResult simplify_prepared(const WeldedMesh& welded, const PreparedGroup& prepared,
                                 const std::vector<uint8_t>& locked, Simplifier simplifier,
                                 const SimplifyTarget& target, std::vector<uint32_t>& scratch);

// True when `after` uses some welded edge more than twice (three or more of its triangles on
// one edge: a fold) and an odd number of times more or fewer than `before` does: a change of
// that edge's parity, a crack to `vgeo verify` (spec/dag.md §2.3).
bool simplification_folds(const WeldedMesh& welded, const TriangleSet& before, const TriangleSet& after);

// The border check of spec/dag.md §2.3. `shared_edges`: the welded edges of `before` that are
// also used outside the group (both ends locked), one edge key per use by `before`, sorted.
// kBroken: some locked welded vertex of `before` is not used by `after`, or some shared edge
// is not an edge of `after`. kFoldedOver: not broken, but a shared edge `before` uses once is
// used more often by `after` (folded over the border; parity is the fold check's business).
// kKept: neither.
enum class BorderState : uint8_t { kBroken, kFoldedOver, kKept };
// A simplification's border check and fold check (simplification_folds), from one count of
// `after`'s welded edges.
struct SimplificationCheck {
  BorderState border;
  bool folds;
};
// `before_locked`: the distinct locked welded ids of `before` (PreparedGroup::group_locked);
// `locked_kept`: `after` is known to use them all (SimplifyResult::group_locked_kept), so
// they are not looked up again. `scratch` (weld.size() entries, all kNone) is returned in
// that state.
SimplificationCheck check_simplification(const WeldedMesh& welded, const TriangleSet& before, const TriangleSet& after,
                                         const std::vector<uint32_t>& before_locked, bool locked_kept,
                                         const std::vector<uint64_t>& shared_edges, std::vector<uint32_t>& scratch);

// Spheres, computed in double and rounded outward so containment survives float rounding
// (bounding_spheres.cpp).
Sphere sphere_of_points(const Mesh& mesh, const uint32_t* vertices, size_t count);
Sphere enclose_spheres(const Sphere* spheres, size_t count);

// Per-cluster count of welded edges used by exactly one triangle of the cluster, and of
// all distinct welded edges (for BuildLevelReport::boundary_edge_fraction; welded_mesh.cpp);
// `open_keys` gets the former's keys appended, in the order of their corners.
void count_cluster_edges(const WeldedMesh& welded, const TriangleSet& cluster, uint64_t* open_edges,
                         uint64_t* all_edges, std::vector<uint64_t>* open_keys = nullptr);
// The same counts and keys from the cluster in local ids: `vertices` = its distinct welded ids,
// `local` = 3 indices into them per triangle (count_cluster_edges finds them itself; the build
// has them from the pass that lists a new cluster's vertices).
void count_local_edges(const uint32_t* vertices, size_t vertex_count, const uint16_t* local, size_t triangles,
                       uint64_t* open_edges, uint64_t* all_edges, std::vector<uint64_t>* open_keys);

// Every METIS call holds this lock: GKlib's random state is process-global, so concurrent
// calls would make results depend on timing (and would race). Defined in group.cpp.
std::mutex& metis_mutex();
// METIS's entry points, from libmetis opened on first use, not linked: only the measuring-only
// GroupMethod::kMetis and SplitMethod::kMetis call it, so a default build neither maps the
// library nor resolves its symbols (docs/acceptance/issue23_rss.md). Defined in group.cpp.
struct MetisFunctions {
  decltype(&METIS_SetDefaultOptions) set_default_options = nullptr;
  decltype(&METIS_PartGraphKway) part_graph_kway = nullptr;
  decltype(&METIS_PartGraphRecursive) part_graph_recursive = nullptr;
};
// Loads libmetis once per process. Throws VgeoError MODULE_UNAVAILABLE when it cannot.
const MetisFunctions& metis_functions();
// The options of every METIS call: defaults, the fixed seed (determinism), C numbering.
inline void set_metis_options(idx_t (&options)[METIS_NOPTIONS]) {
  metis_functions().set_default_options(options);
  options[METIS_OPTION_SEED] = kMetisSeed;
  options[METIS_OPTION_NUMBERING] = 0;
}

inline uint64_t edge_key(uint32_t a, uint32_t b) {
  return a < b ? (uint64_t(a) << 32) | b : (uint64_t(b) << 32) | a;
}

// Welded edge use counts of a triangle set: open addressing (load ≤ 1/2), keys edge_key(a, b).
struct EdgeUses {  // (simplify.cpp, border_caps.cpp)
  static constexpr uint64_t kEmpty = ~uint64_t(0);  // no edge key (a < b) equals it
  std::vector<uint64_t> keys;
  std::vector<uint32_t> uses;
  int shift = 60;
  explicit EdgeUses(size_t edges) {
    size_t slots = 16;
    while (slots < 2 * edges) slots <<= 1, --shift;
    keys.assign(slots, kEmpty);
    uses.assign(slots, 0);
  }
  size_t slot(uint64_t key) const {
    size_t h = size_t((key * 0x9E3779B97F4A7C15ull) >> shift);
    while (keys[h] != kEmpty && keys[h] != key) h = (h + 1) & (keys.size() - 1);
    return h;
  }
  uint32_t add(uint64_t key) {
    const size_t h = slot(key);
    keys[h] = key;
    return ++uses[h];
  }
  uint32_t count(uint64_t key) const {
    const size_t h = slot(key);
    return keys[h] == key ? uses[h] : 0;
  }
};

// The welded edges of a corner list: fn(a, b) per corner, a = welded id of the corner, b = of
// the next corner of its triangle, in corner order. a == b on welded-degenerate triangles.
// Each corner's welded id is read once (fn's stores may alias `weld`, so the compiler would
// read each twice).
template <class Fn>
inline void for_each_welded_edge(const WeldedMesh& welded, const std::vector<uint32_t>& corners, Fn&& fn) {
  for (size_t t = 0; t + 3 <= corners.size(); t += 3) {
    const uint32_t a = welded.weld[corners[t]], b = welded.weld[corners[t + 1]], c = welded.weld[corners[t + 2]];
    fn(a, b);
    fn(b, c);
    fn(c, a);
  }
}

}  // namespace vgeo::build_detail
