// Splitting a triangle set into clusters (spec/dag.md §2.2): the splitter (the grower,
// cluster_grow.cpp, by default) on the proper triangles, degenerate ones attached afterwards to
// the cluster that already uses their positions; clusters over the vertex limit (attribute
// seams) bisected in order.
// Based on: Karis, Stubbe, Wihlidal, "Nanite: A Deep Dive", SIGGRAPH 2021, §"Build operations"
// (clusters of 128 triangles); the degenerate-triangle placement is this project's own rule.
#include <algorithm>
#include <array>
#include <cassert>
#include <cstring>
#include <memory>

#include "vgeo/dag/build_internal.h"
#include "vgeo/dag/cluster_dag.h"

namespace vgeo::build_detail {

std::vector<uint32_t> compact_welded(const WeldedMesh& welded, const TriangleSet& tris,
                                     std::vector<uint32_t>& scratch, std::vector<uint32_t>& local_corner) {
  std::vector<uint32_t> welded_of_local;
  local_corner.resize(tris.corners.size());
  for (size_t i = 0; i < tris.corners.size(); ++i) {
    uint32_t w = welded.weld[tris.corners[i]];
    if (scratch[w] == kNone) {
      scratch[w] = uint32_t(welded_of_local.size());
      welded_of_local.push_back(w);
    }
    local_corner[i] = scratch[w];
  }
  for (uint32_t w : welded_of_local) scratch[w] = kNone;
  return welded_of_local;
}

void append_cluster(const TriangleSet& tris, const uint32_t* ids, size_t count, std::vector<TriangleSet>& out) {
  TriangleSet c;
  c.corners.resize(3 * count);
  c.materials.resize(count);
  for (size_t i = 0; i < count; ++i) {
    const uint32_t* corners = &tris.corners[3 * size_t(ids[i])];
    c.corners[3 * i] = corners[0], c.corners[3 * i + 1] = corners[1], c.corners[3 * i + 2] = corners[2];
    c.materials[i] = tris.materials[ids[i]];
  }
  out.push_back(std::move(c));
}

void cluster_pieces(const TriangleSet& tris, const uint32_t* ids, size_t count, std::vector<uint32_t>& scratch,
                    uint32_t offset, std::vector<uint32_t>& ends) {
  // Distinct vertices marked in scratch, then unmarked by a second pass over the corners
  // (no list of the marked ones to allocate: this ran once per cluster).
  uint32_t unique = 0;
  for (size_t i = 0; i < count; ++i)
    for (int k = 0; k < 3; ++k) {
      uint32_t& mark = scratch[tris.corners[3 * size_t(ids[i]) + k]];
      if (mark == kNone) mark = 0, ++unique;
    }
  for (size_t i = 0; i < count; ++i)
    for (int k = 0; k < 3; ++k) scratch[tris.corners[3 * size_t(ids[i]) + k]] = kNone;
  if (count > kMaxClusterTriangles || unique > kMaxClusterVertices) {
    assert(count > 1);
    size_t half = count / 2;
    cluster_pieces(tris, ids, half, scratch, offset, ends);
    cluster_pieces(tris, ids + half, count - half, scratch, offset + uint32_t(half), ends);
    return;
  }
  ends.push_back(offset + uint32_t(count));
}

void emit_cluster(const TriangleSet& tris, const uint32_t* ids, size_t count, std::vector<uint32_t>& scratch,
                  std::vector<TriangleSet>& out) {
  std::vector<uint32_t> ends;
  cluster_pieces(tris, ids, count, scratch, 0, ends);
  for (size_t k = 0, begin = 0; k < ends.size(); begin = ends[k++]) append_cluster(tris, ids + begin, ends[k] - begin, out);
}

void ClusterSink::take_lists(const TriangleSet& tris, const uint32_t* ids, const uint32_t* ends, size_t count) {
  std::vector<TriangleSet> clusters;
  clusters.reserve(count);
  for (size_t k = 0, begin = 0; k < count; begin = ends[k++]) append_cluster(tris, ids + begin, ends[k] - begin, clusters);
  take(clusters.data(), clusters.size());
}

namespace {

// Hands `clusters` to `sink` (when given) in batches of kSinkBatchClusters; returns what is
// left: none with a sink.
std::vector<TriangleSet> deliver(std::vector<TriangleSet> clusters, ClusterSink* sink) {
  if (!sink) return clusters;
  for (size_t i = 0; i < clusters.size(); i += kSinkBatchClusters)
    sink->take(&clusters[i], std::min(kSinkBatchClusters, clusters.size() - i));
  return {};
}

// `sink`: the grower hands its clusters over as it goes; the other methods at the end.
std::vector<TriangleSet> split_proper(const WeldedMesh& welded, const TriangleSet& tris, std::vector<uint32_t>& scratch,
                                      SplitMethod method, ClusterSink* sink) {
  switch (method) {
    case SplitMethod::kMetis: return deliver(split_metis(welded, tris, scratch), sink);
    case SplitMethod::kMeshopt: return deliver(split_meshopt(welded, tris, scratch), sink);
    default: return split_grow(welded, tris, scratch, true, sink);
  }
}

// Emits triangles [begin, end) of `tris` (`ids` = identity order) as emit_cluster does, but
// bisects at the unit start (`units`, ascending: a proper triangle followed by the degenerate
// ones placed with it) nearest the middle, so a unit stays in one piece.
void emit_units(const TriangleSet& tris, const uint32_t* ids, size_t begin, size_t end,
                const std::vector<uint32_t>& units, std::vector<uint32_t>& scratch, std::vector<TriangleSet>& out) {
  uint32_t unique = 0;
  for (size_t i = begin; i < end; ++i)
    for (int k = 0; k < 3; ++k) {
      const uint32_t v = tris.corners[3 * ids[i] + k];
      if (scratch[v] == kNone) scratch[v] = 0, ++unique;
    }
  for (size_t i = begin; i < end; ++i)
    for (int k = 0; k < 3; ++k) scratch[tris.corners[3 * ids[i] + k]] = kNone;
  const auto lo = std::upper_bound(units.begin(), units.end(), uint32_t(begin));
  const auto hi = std::lower_bound(lo, units.end(), uint32_t(end));
  if ((end - begin <= kMaxClusterTriangles && unique <= kMaxClusterVertices) || lo == hi) {
    emit_cluster(tris, ids + begin, end - begin, scratch, out);
    return;
  }
  const uint32_t middle = uint32_t(begin + (end - begin) / 2);
  auto cut = std::lower_bound(lo, hi, middle);
  if (cut == hi || (cut != lo && middle - *(cut - 1) < *cut - middle)) --cut;
  emit_units(tris, ids, begin, *cut, units, scratch, out);
  emit_units(tris, ids, *cut, end, units, scratch, out);
}

// Adds each degenerate triangle (`ids` into `tris`, ascending) to the first cluster (in
// cluster order) that uses every one of its welded positions that proper triangles use, right
// after that cluster's first triangle at one of them; a cluster that grows past the limits is
// bisected in that order (emit_cluster), so the pieces stay local. A degenerate triangle
// placed elsewhere would bring a position into a group that does not otherwise use it: locked
// there, and lost when the simplifier drops the degenerate triangle (a stuck group). Those
// no cluster holds entirely are clustered among themselves. Output: `clusters` in order
// (grown ones replaced by their pieces), then the clusters of those left over.
std::vector<TriangleSet> attach_degenerate(const WeldedMesh& welded, const TriangleSet& tris,
                                           const std::vector<uint32_t>& ids, std::vector<TriangleSet> clusters,
                                           std::vector<uint32_t>& scratch, SplitMethod method) {
  constexpr uint32_t kWanted = 0, kSeen = 1;  // scratch marks: a degenerate's position (seen in this cluster)
  std::vector<uint32_t> wanted;
  for (uint32_t id : ids)
    for (int k = 0; k < 3; ++k) {
      const uint32_t w = welded.weld[tris.corners[3 * size_t(id) + k]];
      if (scratch[w] == kNone) scratch[w] = kWanted, wanted.push_back(w);
    }
  // (position, cluster, first triangle of the cluster at that position), sorted.
  std::vector<std::array<uint32_t, 3>> uses;
  for (size_t c = 0; c < clusters.size(); ++c) {
    const size_t first_use = uses.size();
    for (size_t i = 0; i < clusters[c].corners.size(); ++i) {
      const uint32_t w = welded.weld[clusters[c].corners[i]];
      if (scratch[w] != kWanted) continue;
      scratch[w] = kSeen;
      uses.push_back({w, uint32_t(c), uint32_t(i / 3)});
    }
    for (size_t u = first_use; u < uses.size(); ++u) scratch[uses[u][0]] = kWanted;
  }
  for (uint32_t w : wanted) scratch[w] = kNone;
  std::sort(uses.begin(), uses.end());
  auto uses_of = [&](uint32_t w) {
    auto lo = std::lower_bound(uses.begin(), uses.end(), std::array<uint32_t, 3>{w, 0, 0});
    auto hi = std::lower_bound(lo, uses.end(), std::array<uint32_t, 3>{w + 1, 0, 0});
    return std::make_pair(lo, hi);
  };
  // Per cluster, the degenerates placed in it: (anchor triangle, index into ids). A position
  // that only degenerate triangles use ties them to one place: the first one's (scratch[w] =
  // index into `placements`), or the leftovers.
  std::vector<std::vector<std::pair<uint32_t, uint32_t>>> attached(clusters.size());
  std::vector<std::pair<uint32_t, uint32_t>> placements;  // (cluster or kNone = leftover, anchor)
  std::vector<uint32_t> tied;
  TriangleSet leftover;
  for (size_t d = 0; d < ids.size(); ++d) {
    const uint32_t* corners = &tris.corners[3 * size_t(ids[d])];
    uint32_t w[3];
    bool used[3];
    for (int k = 0; k < 3; ++k) {
      w[k] = welded.weld[corners[k]];
      used[k] = uses_of(w[k]).first != uses_of(w[k]).second;
    }
    // Where the tied positions already point (kNone: free).
    uint32_t tie = kNone;
    bool conflict = false;
    for (int k = 0; k < 3; ++k)
      if (!used[k] && scratch[w[k]] != kNone) {
        if (tie != kNone && placements[tie] != placements[scratch[w[k]]]) conflict = true;
        tie = scratch[w[k]];
      }
    const uint32_t tie_cluster = tie == kNone ? kNone : placements[tie].first;
    uint32_t best_cluster = kNone, best_triangle = kNone;
    int first = -1;
    for (int k = 0; k < 3 && first < 0; ++k)
      if (used[k]) first = k;
    if (conflict || (tie != kNone && tie_cluster == kNone)) {
      // tied to the leftovers
    } else if (first < 0) {
      if (tie != kNone) best_cluster = tie_cluster, best_triangle = placements[tie].second;
    } else {
      // Candidates: the clusters of a used position; each must hold the other used positions.
      // The first one with a triangle holding them all wins, else the first holding them: a
      // cluster can hold two positions without their edge (it lies on its border, the edge's
      // triangle in the next cluster), and where that next cluster falls into another group
      // the degenerate one alone would carry the edge in this group: an edge shared with
      // the other group that the simplifier drops with it (a broken border, a stuck group).
      uint32_t fallback_cluster = kNone, fallback_triangle = kNone;
      for (auto [it, end] = uses_of(w[first]); it != end && best_cluster == kNone; ++it) {
        const uint32_t c = (*it)[1];
        if (tie_cluster != kNone && c != tie_cluster) continue;
        uint32_t anchor = (*it)[2];
        bool holds_all = true;
        for (int k = 0; k < 3 && holds_all; ++k) {
          if (!used[k]) continue;
          auto [lo, hi] = uses_of(w[k]);
          auto at = std::lower_bound(lo, hi, std::array<uint32_t, 3>{w[k], c, 0});
          holds_all = at != hi && (*at)[1] == c;
          if (holds_all) anchor = std::min(anchor, (*at)[2]);
        }
        if (!holds_all) continue;
        // Better: a triangle holding all of them (the proper side of a degenerate one's edge),
        // so a bisection that keeps the two together keeps the positions in one piece.
        const TriangleSet& cl = clusters[c];
        for (size_t t = 0; t < cl.triangle_count(); ++t) {
          bool all = true;
          for (int k = 0; k < 3 && all; ++k) {
            if (!used[k]) continue;
            const uint32_t* tc = &cl.corners[3 * t];
            all = welded.weld[tc[0]] == w[k] || welded.weld[tc[1]] == w[k] || welded.weld[tc[2]] == w[k];
          }
          if (all) {
            best_cluster = c, best_triangle = uint32_t(t);
            break;
          }
        }
        if (fallback_cluster == kNone) fallback_cluster = c, fallback_triangle = anchor;
      }
      if (best_cluster == kNone) best_cluster = fallback_cluster, best_triangle = fallback_triangle;
    }
    for (int k = 0; k < 3; ++k)
      if (!used[k] && scratch[w[k]] == kNone) {
        scratch[w[k]] = uint32_t(placements.size());
        tied.push_back(w[k]);
      }
    placements.push_back({best_cluster, best_triangle});
    if (best_cluster != kNone) {
      attached[best_cluster].push_back({best_triangle, uint32_t(d)});
    } else {
      leftover.corners.insert(leftover.corners.end(), corners, corners + 3);
      leftover.materials.push_back(tris.materials[ids[d]]);
    }
  }
  for (uint32_t x : tied) scratch[x] = kNone;
  std::vector<TriangleSet> out;
  out.reserve(clusters.size() + 1);
  std::vector<uint32_t> order, units;
  for (size_t c = 0; c < clusters.size(); ++c) {
    if (attached[c].empty()) {
      out.push_back(std::move(clusters[c]));
      continue;
    }
    std::stable_sort(attached[c].begin(), attached[c].end(),
                     [](const auto& x, const auto& y) { return x.first < y.first; });
    // The grown cluster as one triangle list (its triangles, each followed by its degenerates).
    TriangleSet grown;
    const TriangleSet& cl = clusters[c];
    size_t next = 0;
    auto append = [&](const uint32_t* corners, uint32_t material) {
      grown.corners.insert(grown.corners.end(), corners, corners + 3);
      grown.materials.push_back(material);
    };
    units.clear();
    for (size_t t = 0; t < cl.triangle_count(); ++t) {
      units.push_back(uint32_t(grown.triangle_count()));
      append(&cl.corners[3 * t], cl.materials[t]);
      for (; next < attached[c].size() && attached[c][next].first == t; ++next) {
        const uint32_t id = ids[attached[c][next].second];
        append(&tris.corners[3 * size_t(id)], tris.materials[id]);
      }
    }
    order.resize(grown.triangle_count());
    for (size_t i = 0; i < order.size(); ++i) order[i] = uint32_t(i);
    emit_units(grown, order.data(), 0, order.size(), units, scratch, out);
  }
  if (leftover.triangle_count() > 0)
    for (TriangleSet& t : split_proper(welded, leftover, scratch, method, nullptr)) out.push_back(std::move(t));
  return out;
}

}  // namespace

std::vector<TriangleSet> split_into_clusters(const WeldedMesh& welded, const TriangleSet& tris,
                                             std::vector<uint32_t>& scratch, SplitMethod method,
                                             const uint8_t* known_degenerate, ClusterSink* sink) {
  const size_t n = tris.triangle_count();
  if (n == 0) return {};
  // Degenerate triangles are left out of the clusterizer and attached afterwards: meshopt
  // gathers them into clusters that span the mesh, whose positions then lock every group
  // border (spec/dag.md §2.2).
  std::vector<uint32_t> degenerate;
  for (size_t t = 0; t < n; ++t)
    if (known_degenerate ? known_degenerate[t] != 0 : is_degenerate(welded, &tris.corners[3 * t]))
      degenerate.push_back(uint32_t(t));
  if (degenerate.empty() || degenerate.size() == n) return split_proper(welded, tris, scratch, method, sink);
  TriangleSet proper;
  proper.corners.reserve(3 * (n - degenerate.size()));
  proper.materials.reserve(n - degenerate.size());
  for (size_t t = 0, d = 0; t < n; ++t) {
    if (d < degenerate.size() && degenerate[d] == t) {
      ++d;
      continue;
    }
    proper.corners.insert(proper.corners.end(), &tris.corners[3 * t], &tris.corners[3 * t] + 3);
    proper.materials.push_back(tris.materials[t]);
  }
  std::vector<TriangleSet> clusters = split_proper(welded, proper, scratch, method, nullptr);
  return deliver(attach_degenerate(welded, tris, degenerate, std::move(clusters), scratch, method), sink);
}

}  // namespace vgeo::build_detail
