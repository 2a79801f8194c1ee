#pragma once
// The cluster DAG: the output of the offline build and the input of every later stage
// (format, stream, cull, raster, verify). Plain structs of flat arrays; the GPU path
// uploads DagCluster/DagGroup/BvhNode arrays as they are (std430: 16-byte aligned
// members, no pointers). Normative description: spec/dag.md.
//
// Vocabulary (Nanite deep dive):
//  - clusters of level L are partitioned into *groups*; each group is simplified as a
//    whole with its outer border locked and split into clusters of level L+1, which the
//    group *generated*. A group that cannot be simplified enough is *terminal*.
//  - every cluster carries two (bounds, error) pairs, each shared bit-identically by a set
//    of clusters so that the set always makes the same decision:
//      lod_*    : the simplification that produced this cluster (shared by everything its
//                 generating group produced; leaves: error 0),
//      parent_* : the simplification of the group it belongs to (shared by all members;
//                 +inf for terminal groups, so they are never refined away).
//    A cluster is drawn iff projected(parent) > τ && projected(lod) ≤ τ (lib/vgeo/core/lod.h).
#include <cstdint>
#include <limits>
#include <vector>

#include "vgeo/core/math.h"
#include "vgeo/mesh/mesh.h"

namespace vgeo {

// 128: Nanite's cluster size (two 64-wide waves; 7-bit triangle id in the visibility
// buffer). 255: 8-bit local vertex indices with 0xFF reserved by meshopt_buildMeshlets
// (its 0.18 limit is max_vertices ≤ 255).
inline constexpr uint32_t kMaxClusterTriangles = 128;
inline constexpr uint32_t kMaxClusterVertices = 255;
inline constexpr uint32_t kNone = 0xFFFFFFFFu;
inline constexpr float kTerminalError = std::numeric_limits<float>::infinity();

struct DagCluster {
  uint32_t vertex_offset = 0;    // first vertex in ClusterDag::positions (/3) etc.
  uint32_t vertex_count = 0;     // ≤ kMaxClusterVertices
  uint32_t triangle_offset = 0;  // first triangle in ClusterDag::indices (/3)
  uint32_t triangle_count = 0;   // 1..kMaxClusterTriangles
  uint32_t group = kNone;        // the group this cluster is a member of (always set)
  uint32_t generating_group = kNone;  // the group whose simplification produced it; kNone for leaves
  uint32_t level = 0;            // 0 = leaf (original triangles)
  uint32_t material_offset = 0;  // first entry in ClusterDag::triangle_materials (== triangle_offset)
  Sphere bounds;                 // encloses its own triangles (culling)
  Sphere lod_bounds;             // == generating group's parent_bounds; leaves: == bounds
  Sphere parent_bounds;          // == member group's parent_bounds
  float lod_error = 0.0f;        // == generating group's parent_error; leaves: 0
  float parent_error = 0.0f;     // == member group's parent_error; kTerminalError if terminal
  uint32_t pad0 = 0, pad1 = 0;   // std430 alignment to 16 bytes
};

enum GroupFlags : uint32_t {
  kGroupTerminal = 1u << 0,  // not simplified: members are roots of the DAG
};

struct DagGroup {
  uint32_t first_cluster = 0;    // members are clusters[first_cluster, +cluster_count)
  uint32_t cluster_count = 0;
  uint32_t first_generated = 0;  // clusters it produced: generated_clusters[first_generated, +generated_count)
  uint32_t generated_count = 0;  // 0 iff terminal
  uint32_t level = 0;            // level of its members
  uint32_t flags = 0;            // GroupFlags
  uint32_t pad0 = 0, pad1 = 0;
  Sphere bounds;                 // encloses members' bounds (culling)
  Sphere parent_bounds;          // encloses members' lod_bounds (never recomputed from triangles)
  float parent_error = 0.0f;     // ≥ every member's lod_error + this simplification's own error
  uint32_t pad2 = 0, pad3 = 0, pad4 = 0;
};

// Culling hierarchy over groups: up to 8 children per node (Nanite's BVH8).
inline constexpr uint32_t kBvhMaxChildren = 8;
struct BvhNode {
  Sphere bounds;                 // encloses bounds of every group below (frustum/HZB)
  Sphere lod_bounds;             // encloses parent_bounds of every group below
  float max_parent_error = 0.0f; // max parent_error below: skip the subtree when it projects ≤ τ
  uint32_t child_count = 0;
  uint32_t group_mask = 0;       // bit i set: children[i] is a group index, else a node index
  uint32_t pad0 = 0;
  uint32_t children[kBvhMaxChildren] = {kNone, kNone, kNone, kNone, kNone, kNone, kNone, kNone};
};

struct ClusterDag {
  std::vector<DagCluster> clusters;   // sorted by group; groups sorted by level
  std::vector<DagGroup> groups;
  std::vector<uint32_t> generated_clusters;  // group -> clusters it produced
  std::vector<BvhNode> bvh_nodes;     // bvh_nodes[0] is the root (if any groups)

  // Per-cluster vertex copies (a vertex shared by clusters is stored once per cluster,
  // bit-identical, so welding by position bits recovers the shared surface).
  std::vector<float> positions;       // 3 per vertex
  std::vector<float> normals;         // 3 per vertex, or empty
  std::vector<float> uvs;             // 2 per vertex, or empty
  std::vector<uint8_t> indices;       // 3 per triangle, local to the triangle's cluster
  std::vector<uint32_t> triangle_materials;  // 1 per triangle

  uint32_t level_count = 0;
  Aabb bounds;                        // of all leaf positions

  size_t triangle_count() const { return indices.size() / 3; }
  size_t vertex_count() const { return positions.size() / 3; }
  Vec3 position(size_t v) const { return {positions[3 * v], positions[3 * v + 1], positions[3 * v + 2]}; }
};

// A built asset: one DAG per mesh, plus the scene's materials and instances
// (what `vgeo build` writes and `vgeo render`/`vgeo verify` read).
struct BuiltScene {
  std::vector<ClusterDag> meshes;
  std::vector<Material> materials;
  std::vector<Instance> instances;
};

}  // namespace vgeo
