// Structure check (STRUCT_*): everything the later checks and every consumer of a
// ClusterDag index or rely on. spec/invariants.md §1.
#include <algorithm>
#include <cmath>
#include <string>

#include "vgeo/verify/verify_detail.h"

namespace vgeo::verify_detail {
namespace {

constexpr const char* kCheck = "structure";

bool finite3(const float* p) { return std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]); }

}  // namespace

void check_structure(const ClusterDag& dag, Sink& sink, CheckStats& stats, bool* index_safe) {
  const uint64_t before = sink.total();
  uint64_t unsafe = 0;  // violations that make indexing unsafe for the later checks
  auto bad = [&](const char* code, const char* element, uint64_t index, std::string message,
                 std::vector<VerifyValue> values = {}, bool makes_unsafe = false) {
    if (makes_unsafe) ++unsafe;
    sink.add(code, kCheck, element, index, std::move(message), std::move(values));
  };
  const size_t nc = dag.clusters.size(), ng = dag.groups.size(), nn = dag.bvh_nodes.size();
  stats.items = nc + ng + nn;

  // ---- array sizes ----
  if (nc == 0 || ng == 0)
    bad("STRUCT_EMPTY_DAG", "dag", 0, "the DAG has " + idx(nc) + " clusters and " + idx(ng) + " groups", {},
        true);
  if (dag.positions.size() % 3 != 0)
    bad("STRUCT_ARRAY_SIZE", "dag", 0, "positions.size() is not a multiple of 3", {}, true);
  if (dag.indices.size() % 3 != 0)
    bad("STRUCT_ARRAY_SIZE", "dag", 0, "indices.size() is not a multiple of 3", {}, true);
  const size_t nv = dag.vertex_count(), nt = dag.triangle_count();
  if (!dag.normals.empty() && dag.normals.size() != 3 * nv)
    bad("STRUCT_ARRAY_SIZE", "dag", 0, "normals is neither empty nor 3 per vertex", {}, true);
  if (!dag.uvs.empty() && dag.uvs.size() != 2 * nv)
    bad("STRUCT_ARRAY_SIZE", "dag", 0, "uvs is neither empty nor 2 per vertex", {}, true);
  if (dag.triangle_materials.size() != nt)
    bad("STRUCT_ARRAY_SIZE", "dag", 0, "triangle_materials is not 1 per triangle", {}, true);
  if (!ng && nn) bad("STRUCT_BVH_COVERAGE", "dag", 0, "BVH nodes without groups");
  if (ng && !nn) bad("STRUCT_BVH_COVERAGE", "dag", 0, "groups but no BVH root node");
  if (unsafe) {
    *index_safe = false;
    stats.violations = sink.total() - before;
    return;
  }

  // ---- clusters: ranges, limits, finiteness, own bounds ----
  uint32_t max_level = 0;
  for (size_t c = 0; c < nc; ++c) {
    const DagCluster& k = dag.clusters[c];
    max_level = std::max(max_level, k.level);
    if (k.triangle_count == 0 || k.vertex_count == 0)
      bad("STRUCT_EMPTY_CLUSTER", "cluster", c,
          "cluster has " + idx(k.triangle_count) + " triangles and " + idx(k.vertex_count) + " vertices");
    if (k.triangle_count > kMaxClusterTriangles || k.vertex_count > kMaxClusterVertices)
      bad("STRUCT_CLUSTER_LIMITS", "cluster", c,
          "cluster has " + idx(k.triangle_count) + " triangles (max " + idx(kMaxClusterTriangles) + ") and " +
              idx(k.vertex_count) + " vertices (max " + idx(kMaxClusterVertices) + ")",
          {{"triangles", double(k.triangle_count)}, {"vertices", double(k.vertex_count)}});
    bool ranges_ok = true;
    if (uint64_t(k.vertex_offset) + k.vertex_count > nv) {
      bad("STRUCT_DANGLING_INDEX", "cluster", c, "vertex range [" + idx(k.vertex_offset) + ", +" +
          idx(k.vertex_count) + ") exceeds " + idx(nv) + " vertices", {}, true);
      ranges_ok = false;
    }
    if (uint64_t(k.triangle_offset) + k.triangle_count > nt) {
      bad("STRUCT_DANGLING_INDEX", "cluster", c, "triangle range [" + idx(k.triangle_offset) + ", +" +
          idx(k.triangle_count) + ") exceeds " + idx(nt) + " triangles", {}, true);
      ranges_ok = false;
    }
    if (k.material_offset != k.triangle_offset)
      bad("STRUCT_MATERIAL_OFFSET", "cluster", c, "material_offset " + idx(k.material_offset) +
          " != triangle_offset " + idx(k.triangle_offset));
    if (k.group >= ng)
      bad("STRUCT_DANGLING_INDEX", "cluster", c, "group " + idx(k.group) + " out of range", {}, true);
    if (k.generating_group != kNone && k.generating_group >= ng)
      bad("STRUCT_DANGLING_INDEX", "cluster", c, "generating_group " + idx(k.generating_group) + " out of range",
          {}, true);
    if (ranges_ok) {
      for (uint32_t t = 0; t < k.triangle_count; ++t) {
        const uint8_t* tri = &dag.indices[3 * (size_t(k.triangle_offset) + t)];
        if (tri[0] >= k.vertex_count || tri[1] >= k.vertex_count || tri[2] >= k.vertex_count) {
          bad("STRUCT_DANGLING_INDEX", "cluster", c, "triangle " + idx(t) + " has a local index ≥ vertex_count " +
              idx(k.vertex_count), {{"triangle", double(t)}}, true);
          break;
        }
      }
      for (uint32_t v = 0; v < k.vertex_count; ++v) {
        size_t gv = size_t(k.vertex_offset) + v;
        bool ok = finite3(&dag.positions[3 * gv]) && (dag.normals.empty() || finite3(&dag.normals[3 * gv])) &&
                  (dag.uvs.empty() || (std::isfinite(dag.uvs[2 * gv]) && std::isfinite(dag.uvs[2 * gv + 1])));
        if (!ok) {
          bad("STRUCT_NOT_FINITE", "cluster", c, "vertex " + idx(v) + " has a non-finite attribute",
              {{"vertex", double(v)}});
          break;
        }
      }
      if (finite(k.bounds) && k.bounds.radius >= 0) {
        ContainmentMiss worst;
        uint32_t worst_vertex = kNone;
        for (uint32_t v = 0; v < k.vertex_count; ++v) {
          Sphere point{dag.position(size_t(k.vertex_offset) + v), 0.0f};
          if (contains_tol(k.bounds, point)) continue;
          ContainmentMiss m = containment_miss(k.bounds, point);
          if (worst_vertex == kNone || m.excess > worst.excess) worst = m, worst_vertex = v;
        }
        if (worst_vertex != kNone) {
          std::vector<VerifyValue> values = miss_values(worst);
          values.push_back({"vertex", double(worst_vertex)});
          bad("STRUCT_CLUSTER_BOUNDS", "cluster", c, "bounds " + fmt_sphere(k.bounds) +
              " do not enclose the cluster's vertex " + idx(worst_vertex) + miss_text(worst), values);
        }
      }
    }
    for (const Sphere* s : {&k.bounds, &k.lod_bounds, &k.parent_bounds})
      if (!finite(*s) || s->radius < 0) {
        bad(finite(*s) ? "STRUCT_NEGATIVE" : "STRUCT_NOT_FINITE", "cluster", c,
            std::string(s == &k.bounds ? "bounds" : s == &k.lod_bounds ? "lod_bounds" : "parent_bounds") +
                " is " + fmt_sphere(*s));
      }
    if (!std::isfinite(k.lod_error)) bad("STRUCT_NOT_FINITE", "cluster", c, "lod_error is " + fmt_float(k.lod_error));
    else if (k.lod_error < 0) bad("STRUCT_NEGATIVE", "cluster", c, "lod_error is " + fmt_float(k.lod_error));
    if (std::isnan(k.parent_error)) bad("STRUCT_NOT_FINITE", "cluster", c, "parent_error is NaN");
    else if (k.parent_error < 0) bad("STRUCT_NEGATIVE", "cluster", c, "parent_error is " + fmt_float(k.parent_error));
  }
  if (unsafe) {
    *index_safe = false;
    stats.violations = sink.total() - before;
    return;
  }

  // ---- groups: member ranges partition the clusters, levels, generated links ----
  std::vector<uint32_t> member_of(nc, 0);  // how many group ranges contain each cluster
  std::vector<uint32_t> generated_by(nc, 0);
  for (size_t g = 0; g < ng; ++g) {
    const DagGroup& G = dag.groups[g];
    if (G.cluster_count == 0) bad("STRUCT_GROUP_RANGE", "group", g, "group has no members", {}, true);
    if (uint64_t(G.first_cluster) + G.cluster_count > nc) {
      bad("STRUCT_DANGLING_INDEX", "group", g, "member range [" + idx(G.first_cluster) + ", +" +
          idx(G.cluster_count) + ") exceeds " + idx(nc) + " clusters", {}, true);
    } else {
      for (uint32_t i = 0; i < G.cluster_count; ++i) {
        uint32_t c = G.first_cluster + i;
        ++member_of[c];
        if (dag.clusters[c].group != g)
          bad("STRUCT_GROUP_RANGE", "cluster", c, "is in group " + idx(g) + "'s member range but names group " +
              idx(dag.clusters[c].group), {}, true);
        if (dag.clusters[c].level != G.level)
          bad("STRUCT_LEVEL", "cluster", c, "level " + idx(dag.clusters[c].level) + " != its group " + idx(g) +
              "'s level " + idx(G.level), {}, true);
      }
    }
    if (uint64_t(G.first_generated) + G.generated_count > dag.generated_clusters.size()) {
      bad("STRUCT_DANGLING_INDEX", "group", g, "generated range exceeds generated_clusters", {}, true);
    } else {
      for (uint32_t i = 0; i < G.generated_count; ++i) {
        uint32_t p = dag.generated_clusters[G.first_generated + i];
        if (p >= nc) {
          bad("STRUCT_DANGLING_INDEX", "group", g, "generated cluster " + idx(p) + " out of range", {}, true);
          continue;
        }
        ++generated_by[p];
        if (dag.clusters[p].generating_group != g)
          bad("STRUCT_GENERATED_LINK", "cluster", p, "listed as generated by group " + idx(g) +
              " but its generating_group is " + idx(dag.clusters[p].generating_group));
        if (dag.clusters[p].level != uint64_t(G.level) + 1)
          bad("STRUCT_LEVEL", "cluster", p, "level " + idx(dag.clusters[p].level) + " but generated by group " +
              idx(g) + " of level " + idx(G.level), {}, true);
      }
    }
    const bool terminal = (G.flags & kGroupTerminal) != 0;
    if (terminal && G.generated_count != 0)
      bad("STRUCT_TERMINAL", "group", g, "terminal group lists " + idx(G.generated_count) + " generated clusters");
    if (!terminal && G.generated_count == 0)
      bad("STRUCT_NO_PARENT_GROUP", "group", g, "non-terminal group generated no clusters");
    if (terminal && G.parent_error != kTerminalError)
      bad("STRUCT_TERMINAL", "group", g, "terminal group's parent_error is " + fmt_float(G.parent_error) + ", not +inf");
    if (!terminal && !std::isfinite(G.parent_error))
      bad("STRUCT_TERMINAL", "group", g, "non-terminal group's parent_error is " + fmt_float(G.parent_error));
    if (!std::isnan(G.parent_error) && G.parent_error < 0)
      bad("STRUCT_NEGATIVE", "group", g, "parent_error is " + fmt_float(G.parent_error));
    for (const Sphere* s : {&G.bounds, &G.parent_bounds})
      if (!finite(*s) || s->radius < 0)
        bad(finite(*s) ? "STRUCT_NEGATIVE" : "STRUCT_NOT_FINITE", "group", g,
            std::string(s == &G.bounds ? "bounds" : "parent_bounds") + " is " + fmt_sphere(*s));
    if (g > 0 && dag.groups[g - 1].level > G.level)
      bad("STRUCT_ORDER", "group", g, "groups are not sorted by level");
    if (g > 0 && dag.groups[g - 1].first_cluster >= G.first_cluster)
      bad("STRUCT_ORDER", "group", g, "member ranges are not in group order");
  }
  for (size_t c = 0; c < nc; ++c) {
    const DagCluster& k = dag.clusters[c];
    if (member_of[c] != 1)
      bad("STRUCT_GROUP_RANGE", "cluster", c, "lies in " + idx(member_of[c]) + " group member ranges (must be 1)",
          {}, true);
    if (k.generating_group == kNone) {
      if (k.level != 0) bad("STRUCT_LEVEL", "cluster", c, "leaf (no generating group) at level " + idx(k.level), {}, true);
      if (generated_by[c] != 0)
        bad("STRUCT_GENERATED_LINK", "cluster", c, "leaf listed as a generated cluster");
    } else {
      if (k.level == 0) bad("STRUCT_LEVEL", "cluster", c, "level-0 cluster has a generating group", {}, true);
      if (generated_by[c] != 1)
        bad("STRUCT_GENERATED_LINK", "cluster", c, "listed " + idx(generated_by[c]) +
            " times as generated (must be once, by its generating_group)");
    }
    if (k.level >= dag.level_count)
      bad("STRUCT_LEVEL", "cluster", c, "level " + idx(k.level) + " ≥ level_count " + idx(dag.level_count));
  }
  if (nc && dag.level_count != max_level + 1)
    bad("STRUCT_LEVEL", "dag", 0, "level_count " + idx(dag.level_count) + " != highest level + 1 = " +
        idx(max_level + 1));
  if (unsafe) {
    *index_safe = false;
    stats.violations = sink.total() - before;
    return;
  }

  // ---- shared values (bit-identical) and group bounds ----
  for (size_t c = 0; c < nc; ++c) {
    const DagCluster& k = dag.clusters[c];
    const DagGroup& G = dag.groups[k.group];
    if (!same_bits(k.parent_error, G.parent_error))
      bad("STRUCT_SHARED_VALUE", "cluster", c, "parent_error " + fmt_float(k.parent_error) + " != group " +
          idx(k.group) + "'s " + fmt_float(G.parent_error),
          {{"cluster_parent_error", k.parent_error}, {"group_parent_error", G.parent_error}});
    if (!same_bits(k.parent_bounds, G.parent_bounds))
      bad("STRUCT_SHARED_VALUE", "cluster", c, "parent_bounds " + fmt_sphere(k.parent_bounds) + " != group " +
          idx(k.group) + "'s " + fmt_sphere(G.parent_bounds));
    if (k.generating_group == kNone) {
      if (k.lod_error != 0.0f || std::signbit(k.lod_error))
        bad("STRUCT_SHARED_VALUE", "cluster", c, "leaf lod_error " + fmt_float(k.lod_error) + " != 0");
      if (!same_bits(k.lod_bounds, k.bounds))
        bad("STRUCT_SHARED_VALUE", "cluster", c, "leaf lod_bounds " + fmt_sphere(k.lod_bounds) + " != bounds " +
            fmt_sphere(k.bounds));
    } else {
      const DagGroup& P = dag.groups[k.generating_group];
      if (!same_bits(k.lod_error, P.parent_error))
        bad("STRUCT_SHARED_VALUE", "cluster", c, "lod_error " + fmt_float(k.lod_error) + " != generating group " +
            idx(k.generating_group) + "'s parent_error " + fmt_float(P.parent_error),
            {{"lod_error", k.lod_error}, {"generating_parent_error", P.parent_error}});
      if (!same_bits(k.lod_bounds, P.parent_bounds))
        bad("STRUCT_SHARED_VALUE", "cluster", c, "lod_bounds " + fmt_sphere(k.lod_bounds) + " != generating group " +
            idx(k.generating_group) + "'s parent_bounds " + fmt_sphere(P.parent_bounds));
    }
    if (!contains_tol(G.bounds, k.bounds))
      bad("STRUCT_GROUP_BOUNDS", "group", k.group, "bounds " + fmt_sphere(G.bounds) + " do not enclose member " +
          idx(c) + "'s bounds " + fmt_sphere(k.bounds) + miss_text(containment_miss(G.bounds, k.bounds)),
          miss_values(containment_miss(G.bounds, k.bounds)));
  }

  // ---- BVH: a tree from node 0 reaching every group once; conservative bounds/errors ----
  if (nn) {
    std::vector<uint32_t> node_seen(nn, 0), group_seen(ng, 0);
    std::vector<uint32_t> stack{0};
    node_seen[0] = 1;
    while (!stack.empty()) {
      uint32_t n = stack.back();
      stack.pop_back();
      const BvhNode& N = dag.bvh_nodes[n];
      if (N.child_count == 0 || N.child_count > kBvhMaxChildren) {
        bad("STRUCT_BVH_NODE", "bvh_node", n, "child_count " + idx(N.child_count) + " not in 1.." +
            idx(kBvhMaxChildren));
        if (N.child_count > kBvhMaxChildren) continue;
      }
      if (N.child_count < 32 && (N.group_mask >> N.child_count) != 0)
        bad("STRUCT_BVH_NODE", "bvh_node", n, "group_mask has bits beyond child_count");
      if (!finite(N.bounds) || !finite(N.lod_bounds) || std::isnan(N.max_parent_error))
        bad("STRUCT_NOT_FINITE", "bvh_node", n, "non-finite bounds or NaN max_parent_error");
      for (uint32_t i = 0; i < N.child_count; ++i) {
        uint32_t ch = N.children[i];
        const bool is_group = (N.group_mask >> i) & 1u;
        if (is_group) {
          if (ch >= ng) {
            bad("STRUCT_DANGLING_INDEX", "bvh_node", n, "child " + idx(i) + " names group " + idx(ch) + " (out of range)");
            continue;
          }
          ++group_seen[ch];
          const DagGroup& G = dag.groups[ch];
          if (!contains_tol(N.bounds, G.bounds))
            bad("STRUCT_BVH_BOUNDS", "bvh_node", n, "bounds do not enclose group " + idx(ch) + "'s bounds" +
                miss_text(containment_miss(N.bounds, G.bounds)), miss_values(containment_miss(N.bounds, G.bounds)));
          if (!contains_tol(N.lod_bounds, G.parent_bounds))
            bad("STRUCT_BVH_BOUNDS", "bvh_node", n, "lod_bounds do not enclose group " + idx(ch) + "'s parent_bounds" +
                miss_text(containment_miss(N.lod_bounds, G.parent_bounds)), miss_values(containment_miss(N.lod_bounds, G.parent_bounds)));
          if (!(N.max_parent_error >= G.parent_error))
            bad("STRUCT_BVH_BOUNDS", "bvh_node", n, "max_parent_error " + fmt_float(N.max_parent_error) +
                " < group " + idx(ch) + "'s parent_error " + fmt_float(G.parent_error));
        } else {
          if (ch >= nn) {
            bad("STRUCT_DANGLING_INDEX", "bvh_node", n, "child " + idx(i) + " names node " + idx(ch) + " (out of range)");
            continue;
          }
          if (node_seen[ch]++) {
            bad("STRUCT_BVH_COVERAGE", "bvh_node", ch, "node reached more than once (not a tree)");
            continue;
          }
          stack.push_back(ch);
          const BvhNode& C = dag.bvh_nodes[ch];
          if (!contains_tol(N.bounds, C.bounds))
            bad("STRUCT_BVH_BOUNDS", "bvh_node", n, "bounds do not enclose child node " + idx(ch) + "'s bounds" +
                miss_text(containment_miss(N.bounds, C.bounds)), miss_values(containment_miss(N.bounds, C.bounds)));
          if (!contains_tol(N.lod_bounds, C.lod_bounds))
            bad("STRUCT_BVH_BOUNDS", "bvh_node", n, "lod_bounds do not enclose child node " + idx(ch) + "'s lod_bounds" +
                miss_text(containment_miss(N.lod_bounds, C.lod_bounds)), miss_values(containment_miss(N.lod_bounds, C.lod_bounds)));
          if (!(N.max_parent_error >= C.max_parent_error))
            bad("STRUCT_BVH_BOUNDS", "bvh_node", n, "max_parent_error below child node " + idx(ch) + "'s");
        }
      }
    }
    for (size_t n = 0; n < nn; ++n)
      if (!node_seen[n]) bad("STRUCT_BVH_COVERAGE", "bvh_node", n, "node unreachable from the root");
    for (size_t g = 0; g < ng; ++g)
      if (group_seen[g] != 1)
        bad("STRUCT_BVH_COVERAGE", "group", g, "reached " + idx(group_seen[g]) + " times from the BVH root (must be 1)");
  }

  // ---- DAG bounds enclose the leaves ----
  for (size_t c = 0; c < nc; ++c) {
    const DagCluster& k = dag.clusters[c];
    if (k.generating_group != kNone) continue;
    for (uint32_t v = 0; v < k.vertex_count; ++v) {
      Vec3 p = dag.position(size_t(k.vertex_offset) + v);
      if (p.x < dag.bounds.min.x || p.y < dag.bounds.min.y || p.z < dag.bounds.min.z || p.x > dag.bounds.max.x ||
          p.y > dag.bounds.max.y || p.z > dag.bounds.max.z) {
        bad("STRUCT_DAG_BOUNDS", "cluster", c, "leaf vertex " + idx(v) + " lies outside ClusterDag::bounds");
        break;
      }
    }
  }

  *index_safe = unsafe == 0;
  stats.violations = sink.total() - before;
}

}  // namespace vgeo::verify_detail
