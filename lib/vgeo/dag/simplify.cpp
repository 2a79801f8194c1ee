// Simplification of one group with its outer border locked (spec/dag.md §Simplify).
// Both backends only delete vertices (halfedge collapses / index rewrites), so every output
// corner is an original vertex with its original bits: locked borders stay bit-identical.
// Based on: Garland, Heckbert, "Surface Simplification Using Quadric Error Metrics", SIGGRAPH
// 1997, as meshoptimizer's meshopt_simplify (Kapoulkine) and OpenMesh's Decimater (ModQuadric)
// implement it; Karis et al., "Nanite: A Deep Dive", SIGGRAPH 2021, §"Mesh simplify" and
// §"Locked boundaries".
#include <meshoptimizer.h>

#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstring>
#include <functional>
#include <iterator>
#include <unordered_map>

#include "vgeo/dag/build_internal.h"
#include "vgeo/dag/cluster_dag.h"
#include "vgeo/core/surface_distance.h"
#include "vgeo/dag/simplify_openmesh.h"

namespace vgeo::build_detail {

size_t target_triangles(size_t n, double ratio) { return std::max<size_t>(1, size_t(double(n) * ratio)); }

namespace {


// ---------------------------------------------------------------- meshopt backend
// Sub-mesh vertices are (vertex, material) pairs: attribute and material discontinuities
// become meshopt "seams" (same position, other index), which it keeps consistent without
// locking. meshopt 0.18 locks a position with more than two such wedges ("complex"), and a
// per-corner mesh (every triangle owns its corners: flat normals, UV seams everywhere) is
// nothing but such positions: there a position is welded into one sub-mesh vertex per
// material (`kMaxSeamWedges`), simplified as a smooth surface, and each surviving corner
// takes the attributes of the input corner (same position and material) whose triangle faces
// most like the output triangle (pick_corner_attributes). LockBorder locks the sub-mesh's
// topological border: the group border, and also the original mesh's open edges (0.18 has no
// per-vertex locks; spec/dag.md §Limitations).

// Wedges (distinct (vertex, material) pairs) at one position that meshopt 0.18 can move as a
// seam; more are locked by it, so such positions are welded instead.
constexpr size_t kMaxSeamWedges = 2;

// Attempts after the first that give lost locked vertices their own copies: the first also
// splits every locked vertex off the sub-mesh border, later ones add what the previous one
// lost; a group still losing one is terminal by the border check, as before. One retry
// recovered every case measured (CGAL anchor_dense, femur, a test sphere), a second is margin.
constexpr uint32_t kMaxLockedRetries = 2;

// Unit geometric normal of a triangle, in double (zero for a degenerate one).
DVec3 face_normal(const Mesh& mesh, uint32_t a, uint32_t b, uint32_t c) {
  const float *p = &mesh.positions[3 * size_t(a)], *q = &mesh.positions[3 * size_t(b)], *r = &mesh.positions[3 * size_t(c)];
  double e1[3], e2[3];
  for (int k = 0; k < 3; ++k) e1[k] = double(q[k]) - p[k], e2[k] = double(r[k]) - p[k];
  DVec3 n{e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
  double len = std::sqrt(n.x * n.x + n.y * n.y + n.z * n.z);
  if (!(len > 0)) return DVec3{};
  return DVec3{n.x / len, n.y / len, n.z / len};
}

// Copy `k` (k >= 1) of a sub-mesh position: every coordinate k ulps towards +inf. meshopt
// joins bit-equal positions into wedges, so a copy must differ from the original and from the
// other copies; a few ulps change no quadric measurably, and outputs map back to the vertex.
void perturbed_copy(const float* p, uint32_t k, float* out) {
  for (int a = 0; a < 3; ++a) {
    float x = p[a];
    for (uint32_t i = 0; i < k; ++i) x = std::nextafter(x, INFINITY);
    out[a] = x;
  }
}

// Distinct locked welded ids of a corner list, in order of first use. `scratch` (welded ids,
// all kNone) is returned so.
std::vector<uint32_t> locked_ids(const WeldedMesh& welded, const std::vector<uint32_t>& corners,
                                 const std::vector<uint8_t>& locked, std::vector<uint32_t>& scratch) {
  constexpr uint32_t kSeen = 0;
  std::vector<uint32_t> ids;
  for (uint32_t v : corners) {
    const uint32_t w = welded.weld[v];
    if (locked[w] && scratch[w] != kSeen) scratch[w] = kSeen, ids.push_back(w);
  }
  for (uint32_t w : ids) scratch[w] = kNone;
  return ids;
}

// Of `before_locked` (distinct welded ids), those `after_corners` do not use (sorted). The
// border checks ask this of every simplification: the ids are marked in `scratch` (welded ids,
// all kNone, returned so), then one pass over the output's corners finds the kept ones, with
// no set built and nothing allocated when none is lost.
std::vector<uint32_t> lost_locked_vertices(const WeldedMesh& welded, const std::vector<uint32_t>& before_locked,
                                           const std::vector<uint32_t>& after_corners, std::vector<uint32_t>& scratch) {
  constexpr uint32_t kWanted = 0, kKept = 1;
  for (uint32_t w : before_locked) scratch[w] = kWanted;
  size_t kept = 0;
  for (uint32_t v : after_corners) {
    uint32_t& mark = scratch[welded.weld[v]];
    if (mark == kWanted) mark = kKept, ++kept;
  }
  std::vector<uint32_t> lost;
  if (kept != before_locked.size())
    for (uint32_t w : before_locked)
      if (scratch[w] == kWanted) lost.push_back(w);
  for (uint32_t w : before_locked) scratch[w] = kNone;
  std::sort(lost.begin(), lost.end());
  return lost;
}

// Locked welded ids of `group` without exactly two open welded edges (used by one triangle of
// the group) at them: inside the group (none) or complex (more), where LockBorder may not hold
// them (sorted).
std::vector<uint32_t> locked_vertices_off_the_border(const WeldedMesh& welded, const TriangleSet& group,
                                                     const std::vector<uint8_t>& locked) {
  std::vector<uint64_t> edges;
  for_each_welded_edge(welded, group.corners, [&](uint32_t a, uint32_t b) {
    if (a != b && (locked[a] || locked[b])) edges.push_back(edge_key(a, b));
  });
  std::sort(edges.begin(), edges.end());
  std::vector<std::pair<uint32_t, uint32_t>> open_ends;  // (welded id, 1) per open edge end
  for (size_t i = 0; i < edges.size();) {
    size_t j = i + 1;
    while (j < edges.size() && edges[j] == edges[i]) ++j;
    if (j - i == 1) open_ends.insert(open_ends.end(), {{uint32_t(edges[i] >> 32), 1}, {uint32_t(edges[i]), 1}});
    i = j;
  }
  std::sort(open_ends.begin(), open_ends.end());
  std::vector<uint32_t> out;
  for (uint32_t v : group.corners) {
    const uint32_t w = welded.weld[v];
    if (!locked[w]) continue;
    const auto range = std::equal_range(open_ends.begin(), open_ends.end(), std::pair<uint32_t, uint32_t>{w, 1});
    if (range.second - range.first != 2) out.push_back(w);
  }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

// meshopt_simplify with LockBorder of a sub-mesh whose own open borders are capped
// (add_open_border_caps), so only the group border stays locked. The cap triangles count
// towards meshopt's target: they are asked to shrink by the same ratio as the surface.
// Returns the index count of the real output in `out`, or 0 when there was nothing to cap or
// the capped result was refused (remove_open_border_caps): then the caller simplifies
// without caps.
size_t simplify_with_open_border_caps(const OpenBorder& border, const std::vector<unsigned int>& sub_indices,
                                      const std::vector<float>& sub_positions,
                                      const std::vector<uint32_t>& welded_of_sub, const std::vector<uint8_t>& locked,
                                      size_t target_real_triangles, const SimplifyTarget& target,
                                      std::vector<unsigned int>& out) {
  std::vector<unsigned int> indices = sub_indices;
  std::vector<float> positions = sub_positions;
  const BorderCaps caps =
      add_open_border_caps(border.chain_corners, welded_of_sub, locked, indices, positions, target.keep_loops);
  if (caps.apex_count == 0) return 0;
  const size_t vertices = positions.size() / 3;
  // meshopt's error bound is relative to the extent of every vertex it is given (apexes too).
  const float scale = meshopt_simplifyScale(positions.data(), vertices, sizeof(float) * 3);
  const float target_error = std::isfinite(target.max_error) && scale > 0 ? target.max_error / scale : kMeshoptTargetError;
  // The caps count in meshopt's target but resist collapse (their apex and the chain ends are
  // locked), so meshopt can take the difference out of the real surface: elephant-with-holes'
  // level-0 groups came out at 41% of their triangles (target 50%) at 2.4x the peer's error. A
  // result more than kCapShortfallRedo short of its real target is redone once with the target
  // raised by the shortfall.
  size_t target_total = target_real_triangles + size_t(double(caps.cap_triangles) * target.ratio);
  size_t count = 0;
  for (int pass = 0; pass < 2; ++pass) {
    out.resize(indices.size());
    count = meshopt_simplify(out.data(), indices.data(), indices.size(), positions.data(), vertices,
                             sizeof(float) * 3, 3 * target_total, target_error, meshopt_SimplifyLockBorder, nullptr);
    if (!remove_open_border_caps(caps, welded_of_sub, *target.mesh_border, border.open_edges, out, count) || count == 0)
      return 0;
    if (double(count / 3) >= kCapShortfallRedo * double(target_real_triangles)) break;
    target_total += target_real_triangles - count / 3;
  }
  return count;
}

// The permutation that sorts `keys` ascending (stable): a least-significant-digit radix sort
// on bytes (Knuth, TAOCP vol. 3, §5.2.5) that skips every byte all keys share (the material
// and the high bytes of the vertex id on most groups: three passes for a million-vertex
// mesh). A group has about a thousand sub-mesh keys, where std::sort's mispredicted
// comparisons (and a binary search per key for its rank) cost several times more.
std::vector<uint32_t> sort_keys(const std::vector<uint64_t>& keys) {
  constexpr int kDigitBits = 8, kDigits = 64 / kDigitBits;
  constexpr size_t kBuckets = size_t(1) << kDigitBits;
  const size_t n = keys.size();
  std::vector<uint32_t> order(n), next(n);
  for (size_t i = 0; i < n; ++i) order[i] = uint32_t(i);
  if (n < 2) return order;
  // The digits where keys differ (bits set in some key and clear in another); only they are
  // counted and sorted by.
  uint64_t any_set = 0, all_set = ~uint64_t(0);
  for (uint64_t key : keys) any_set |= key, all_set &= key;
  const uint64_t varying = any_set ^ all_set;
  int digits[kDigits], varying_digits = 0;
  for (int d = 0; d < kDigits; ++d)
    if ((varying >> (kDigitBits * d)) & (kBuckets - 1)) digits[varying_digits++] = d;
  std::vector<uint32_t> count(size_t(varying_digits) * kBuckets, 0);
  for (uint64_t key : keys)
    for (int j = 0; j < varying_digits; ++j)
      ++count[j * kBuckets + ((key >> (kDigitBits * digits[j])) & (kBuckets - 1))];
  for (int j = 0; j < varying_digits; ++j) {
    uint32_t* c = &count[j * kBuckets];
    const int shift = kDigitBits * digits[j];
    uint32_t sum = 0;
    for (size_t b = 0; b < kBuckets; ++b) {
      const uint32_t k = c[b];
      c[b] = sum;
      sum += k;
    }
    for (uint32_t i : order) next[c[(keys[i] >> shift) & (kBuckets - 1)]++] = i;
    order.swap(next);
  }
  return order;
}

// The meshopt sub-mesh of a group's input (PreparedGroup's meshopt fields).
void build_sub_mesh(const WeldedMesh& welded, PreparedGroup& p, std::vector<uint32_t>& scratch) {
  const Mesh& mesh = *welded.mesh;
  const TriangleSet& group = p.input();
  const size_t n = group.triangle_count();
  // Distinct (vertex << 32 | material) keys of the corners, in order of first use;
  // distinct_of[i] is corner i's. scratch[v] holds the last distinct key found with vertex v
  // and next_of_vertex chains the earlier ones: a vertex has one key per material of its
  // triangles in the group (almost always one), so a corner's key is found in one or two
  // steps without hashing (the vertex-indexed scratch array is there anyway). With one
  // material (most groups) a vertex has one key: scratch[v] is it, and there is no chain.
  const bool one_material = std::adjacent_find(group.materials.begin(), group.materials.end(),
                                               std::not_equal_to<uint32_t>()) == group.materials.end();
  std::vector<uint64_t> distinct;
  std::vector<uint32_t> distinct_of(3 * n);
  distinct.reserve(3 * n);
  const uint32_t* corners = group.corners.data();
  uint32_t* const key_of_vertex = scratch.data();
  if (one_material) {
    const uint64_t material = n > 0 ? group.materials[0] : 0;
    for (size_t i = 0; i < 3 * n; ++i) {
      const uint32_t v = corners[i];
      uint32_t u = key_of_vertex[v];
      if (u == kNone) {
        u = key_of_vertex[v] = uint32_t(distinct.size());
        distinct.push_back((uint64_t(v) << 32) | material);
      }
      distinct_of[i] = u;
    }
  } else {
    std::vector<uint32_t> next_of_vertex;
    next_of_vertex.reserve(3 * n);
    for (size_t i = 0; i < 3 * n; ++i) {
      const uint32_t v = corners[i];
      const uint64_t key = (uint64_t(v) << 32) | group.materials[i / 3];
      uint32_t u = key_of_vertex[v];
      while (u != kNone && distinct[u] != key) u = next_of_vertex[u];
      if (u == kNone) {
        u = uint32_t(distinct.size());
        distinct.push_back(key);
        next_of_vertex.push_back(key_of_vertex[v]);
        key_of_vertex[v] = u;
      }
      distinct_of[i] = u;
    }
  }
  for (uint64_t key : distinct) key_of_vertex[uint32_t(key >> 32)] = kNone;
  // Positions with more than kMaxSeamWedges wedges in the group, or more than kMaxSeamWedges
  // input vertices in the mesh, are welded: the second because above the leaves a group of a
  // per-corner mesh holds only the corners earlier levels kept (often one or two per position,
  // not a seam: meshopt 0.18 locks such a pair, and per-corner groups stopped reducing at
  // level 5 on bunny00). Their keys become
  // (welded id, material). Sorted welded ids, so the sub-mesh does not depend on corner order.
  // A position has one wedge when one input vertex sits there and the group has one material
  // (most meshes): then none is welded, and the sort below is skipped.
  bool any_wedges = !one_material;
  for (size_t u = 0; u < distinct.size() && !any_wedges; ++u)
    any_wedges = welded.copies[welded.weld[uint32_t(distinct[u] >> 32)]] > 1;
  std::vector<std::pair<uint32_t, uint32_t>> wedge_of;  // (welded id, vertex)
  if (any_wedges) {
    wedge_of.resize(distinct.size());
    for (size_t u = 0; u < distinct.size(); ++u) {
      uint32_t v = uint32_t(distinct[u] >> 32);
      wedge_of[u] = {welded.weld[v], v};
    }
    std::sort(wedge_of.begin(), wedge_of.end());
  }
  std::vector<uint32_t>& welded_positions = p.welded_positions;  // sorted
  for (size_t i = 0; i < wedge_of.size();) {
    size_t j = i;
    while (j < wedge_of.size() && wedge_of[j].first == wedge_of[i].first) ++j;
    if (j - i > kMaxSeamWedges || welded.copies[wedge_of[i].first] > kMaxSeamWedges)
      welded_positions.push_back(wedge_of[i].first);
    i = j;
  }
  // Sub-mesh key per distinct key; the sub-mesh vertex = rank among the distinct sub-mesh keys.
  std::vector<uint64_t> sub_of(distinct);
  if (!welded_positions.empty())
    for (uint64_t& key : sub_of) {
      const uint32_t w = welded.weld[uint32_t(key >> 32)];
      if (std::binary_search(welded_positions.begin(), welded_positions.end(), w))
        key = (uint64_t(w) << 32) | uint32_t(key);
    }
  // The sub-mesh vertex = rank among the distinct sub-mesh keys: one stable sort of (key,
  // distinct key) and a walk that counts the distinct keys.
  std::vector<uint32_t> order = sort_keys(sub_of);
  std::vector<uint32_t> rank_of(distinct.size());
  p.sub_keys.reserve(distinct.size());
  for (uint32_t u : order) {
    if (p.sub_keys.empty() || p.sub_keys.back() != sub_of[u]) p.sub_keys.push_back(sub_of[u]);
    rank_of[u] = uint32_t(p.sub_keys.size() - 1);
  }
  p.indices.resize(3 * n);
  for (size_t i = 0; i < 3 * n; ++i) p.indices[i] = rank_of[distinct_of[i]];
  p.positions.resize(3 * p.sub_keys.size());
  {
    const float* from = mesh.positions.data();
    float* to = p.positions.data();
    for (uint64_t key : p.sub_keys) std::memcpy(to, &from[3 * size_t(key >> 32)], 12), to += 3;
  }
  // meshopt 0.18's error bound is relative to the sub-mesh's extent.
  p.scale = meshopt_simplifyScale(p.positions.data(), p.sub_keys.size(), sizeof(float) * 3);
  if (!welded_positions.empty()) {
    p.corner_sub_key.resize(3 * n);
    for (size_t i = 0; i < 3 * n; ++i) p.corner_sub_key[i] = sub_of[distinct_of[i]];
  }
}

SimplifyResult simplify_meshopt(const WeldedMesh& welded, const PreparedGroup& p, const std::vector<uint8_t>& locked,
                                const SimplifyTarget& target, std::vector<uint32_t>& scratch) {
  const Mesh& mesh = *welded.mesh;
  const TriangleSet& group = p.input();
  const size_t n = group.triangle_count();
  const std::vector<uint64_t>& unique_keys = p.sub_keys;
  const std::vector<unsigned int>& indices = p.indices;
  const std::vector<float>& positions = p.positions;
  const std::vector<uint32_t>& welded_positions = p.welded_positions;
  auto is_welded = [&](uint32_t w) {
    return std::binary_search(welded_positions.begin(), welded_positions.end(), w);
  };

  // LockBorder keeps the sub-mesh's topological border only. A locked vertex with no open
  // edge in the group (the coarse surface can pinch: another group uses the vertex too) or
  // one meshopt classifies as complex may still be collapsed; then the border check would
  // make the group terminal. Each such vertex lost by an attempt gets, in the next, a
  // sub-mesh vertex of its own per corner (perturbed_copy): every copy is then a border
  // vertex, which LockBorder keeps, and the outputs map back to the vertex.
  std::vector<uint64_t> copy_keys;  // sub-mesh vertex unique_keys.size() + c has key copy_keys[c]
  auto key_of = [&](unsigned int sub) {
    return sub < unique_keys.size() ? unique_keys[sub] : copy_keys[sub - unique_keys.size()];
  };
  std::vector<uint32_t> split;  // welded ids given per-corner copies, sorted
  std::vector<unsigned int> out(indices.size());
  // meshopt 0.18's error bound is relative to the sub-mesh's extent (meshopt_simplifyScale).
  const float scale = p.scale;
  const float target_error = std::isfinite(target.max_error) && scale > 0 ? target.max_error / scale : kMeshoptTargetError;
  SimplifyResult r;
  size_t out_count = 0;
  for (uint32_t attempt = 0;; ++attempt) {
    // The first attempt simplifies the sub-mesh as built; retries work on copies of it.
    std::vector<unsigned int> attempt_indices;
    std::vector<float> attempt_positions;
    copy_keys.clear();
    if (!split.empty()) {
      attempt_indices = indices;
      attempt_positions = positions;
      for (size_t i = 0; i < 3 * n; ++i) {
        if (!std::binary_search(split.begin(), split.end(), welded.weld[group.corners[i]])) continue;
        const uint64_t key = unique_keys[indices[i]];
        copy_keys.push_back(key);
        attempt_indices[i] = unsigned(unique_keys.size() + copy_keys.size() - 1);
        attempt_positions.resize(attempt_positions.size() + 3);
        perturbed_copy(&positions[3 * indices[i]], uint32_t(copy_keys.size()),
                       &attempt_positions[attempt_positions.size() - 3]);
      }
    }
    const std::vector<unsigned int>& sub_indices = split.empty() ? indices : attempt_indices;
    const std::vector<float>& sub_positions = split.empty() ? positions : attempt_positions;
    const size_t sub_vertices = unique_keys.size() + copy_keys.size();
    out_count = 0;
    r.capped = false;
    // Caps need a chain of the group's own open edges (most groups have none: their open edges
    // are group borders, both ends locked).
    if (target.open_borders && target.mesh_border && target.lone_unlocked && p.input_locked.empty()) {
      // Nothing of the group is shared with another group (the last levels of a mesh with
      // holes): no vertex needs LockBorder, and meshopt moves the mesh's own border vertices
      // only along their border. Compared with the locked-border result as a capped one is.
      out.resize(sub_indices.size());
      out_count = meshopt_simplify(out.data(), sub_indices.data(), sub_indices.size(), sub_positions.data(),
                                   sub_vertices, sizeof(float) * 3, 3 * target_triangles(n, target.ratio), target_error,
                                   0, nullptr);
      r.capped = out_count > 0;
    } else if (target.open_borders && target.mesh_border && !p.open_border.chain_corners.empty()) {
      std::vector<uint32_t> welded_of_sub(sub_vertices);
      for (size_t v = 0; v < sub_vertices; ++v) welded_of_sub[v] = welded.weld[uint32_t(key_of(unsigned(v)) >> 32)];
      out_count = simplify_with_open_border_caps(p.open_border, sub_indices, sub_positions, welded_of_sub, locked,
                                                 target_triangles(n, target.ratio), target, out);
      r.capped = out_count > 0;
    }
    if (out_count == 0) {
      out.resize(sub_indices.size());
      out_count = meshopt_simplify(out.data(), sub_indices.data(), sub_indices.size(), sub_positions.data(),
                                   sub_vertices, sizeof(float) * 3, 3 * target_triangles(n, target.ratio), target_error,
                                   meshopt_SimplifyLockBorder, nullptr);
    }
    r.triangles.corners.resize(out_count);
    r.triangles.materials.resize(out_count / 3);
    for (size_t i = 0; i < out_count; ++i) r.triangles.corners[i] = uint32_t(key_of(out[i]) >> 32);
    for (size_t t = 0; t < out_count / 3; ++t) r.triangles.materials[t] = uint32_t(key_of(out[3 * t]));
    if (attempt == kMaxLockedRetries) break;
    std::vector<uint32_t> lost = lost_locked_vertices(welded, p.input_locked, r.triangles.corners, scratch);
    if (lost.empty()) {
      // The group's locked ids are the input's when no triangle was left out.
      r.group_locked_kept = !p.any_left_out;
      break;
    }
    // Another collapse order loses other such vertices: the first retry also splits every
    // locked vertex LockBorder cannot hold (not exactly two open welded edges in the group).
    if (attempt == 0) {
      std::vector<uint32_t> unheld = locked_vertices_off_the_border(welded, group, locked);
      lost.insert(lost.end(), unheld.begin(), unheld.end());
      std::sort(lost.begin(), lost.end());
      lost.erase(std::unique(lost.begin(), lost.end()), lost.end());
    }
    std::vector<uint32_t> merged;
    std::set_union(split.begin(), split.end(), lost.begin(), lost.end(), std::back_inserter(merged));
    split = std::move(merged);
  }
  if (welded_positions.empty()) return r;

  // Welded corners: the input corner of the same position and material whose triangle's
  // normal is closest to the output triangle's (ties: smallest vertex id), so flat-shaded
  // corners keep the attributes of the face they now approximate. D2: an input vertex.
  std::vector<std::pair<uint64_t, uint32_t>> candidates;  // (sub-mesh key, input corner)
  for (size_t i = 0; i < 3 * n; ++i) {
    const uint64_t sub = p.corner_sub_key[i];
    if (is_welded(uint32_t(sub >> 32))) candidates.push_back({sub, uint32_t(i)});
  }
  std::sort(candidates.begin(), candidates.end());
  std::vector<DVec3> input_normal(n);
  for (size_t t = 0; t < n; ++t)
    input_normal[t] = face_normal(mesh, group.corners[3 * t], group.corners[3 * t + 1], group.corners[3 * t + 2]);
  for (size_t t = 0; t < out_count / 3; ++t) {
    DVec3 nt{};
    bool normal_known = false;
    for (int k = 0; k < 3; ++k) {
      const uint64_t sub = key_of(out[3 * t + k]);
      if (!is_welded(uint32_t(sub >> 32))) continue;
      if (!normal_known) {
        nt = face_normal(mesh, r.triangles.corners[3 * t], r.triangles.corners[3 * t + 1], r.triangles.corners[3 * t + 2]);
        normal_known = true;
      }
      auto it = std::lower_bound(candidates.begin(), candidates.end(), std::make_pair(sub, uint32_t(0)));
      double best_score = -2;
      uint32_t best = kNone;
      for (; it != candidates.end() && it->first == sub; ++it) {
        const DVec3& ni = input_normal[it->second / 3];
        const double score = nt.x * ni.x + nt.y * ni.y + nt.z * ni.z;
        const uint32_t v = group.corners[it->second];
        if (score > best_score || (score == best_score && v < best)) best_score = score, best = v;
      }
      assert(best != kNone);
      r.triangles.corners[3 * t + k] = best;
    }
  }
  return r;
}



}  // namespace

PreparedGroup prepare_group(const WeldedMesh& welded, const TriangleSet& group, const std::vector<uint8_t>& locked,
                            Simplifier simplifier, const FinSet& fins, const std::vector<uint8_t>* mesh_border,
                            std::vector<uint32_t>& scratch) {
  // Triangles with a repeated welded position are left out (they cover no area and use each
  // of their edges twice, so no edge's parity and no open edge changes): to meshopt such a
  // triangle is the far side of a border edge, so locked border vertices would move, and
  // OpenMesh refuses it and locks its corners. Each one lies in a cluster whose proper
  // triangles use its positions (split_into_clusters), so leaving it out loses no locked
  // position. Fins are left out too: to meshopt one is a border that locks its base edge,
  // OpenMesh refuses it; they change only the mesh's own border. Other collinear slivers
  // stay: dropping one would open its edges (spec/dag.md §2.3).
  auto is_fin = [&](const uint32_t* c) {
    if (fins.empty()) return false;
    std::array<uint32_t, 3> key{c[0], c[1], c[2]};
    std::sort(key.begin(), key.end());
    return std::binary_search(fins.begin(), fins.end(), key);
  };
  PreparedGroup p;
  p.group = &group;
  std::vector<uint32_t> left_out;  // triangle indices
  const uint32_t* weld = welded.weld.data();
  for (size_t t = 0; t < group.triangle_count(); ++t) {
    const uint32_t* c = &group.corners[3 * t];
    const uint32_t a = weld[c[0]], b = weld[c[1]], d = weld[c[2]];
    if (a == b || b == d || d == a || is_fin(c)) left_out.push_back(uint32_t(t));
  }
  p.any_left_out = !left_out.empty();
  for (size_t t = 0, k = 0; p.any_left_out && t < group.triangle_count(); ++t) {
    if (k < left_out.size() && left_out[k] == t) {
      ++k;
      continue;
    }
    p.proper.corners.insert(p.proper.corners.end(), &group.corners[3 * t], &group.corners[3 * t] + 3);
    p.proper.materials.push_back(group.materials[t]);
  }
  if (simplifier != Simplifier::kMeshopt || p.input().triangle_count() == 0) {
    p.group_locked = locked_ids(welded, group.corners, locked, scratch);
    p.input_locked = p.any_left_out ? locked_ids(welded, p.proper.corners, locked, scratch) : p.group_locked;
    return p;
  }
  build_sub_mesh(welded, p, scratch);
  // The input's locked ids, and whether it has a mesh-border vertex, from its sub-mesh vertices
  // (each welded position of the input once, or once per material: a sixth of its corners).
  // Caps are accepted only with a cap base between two mesh-border vertices of the input
  // (remove_open_border_caps): an input without one is never capped.
  constexpr uint32_t kSeen = 0;
  bool on_mesh_border = false;
  for (uint64_t key : p.sub_keys) {
    const uint32_t w = welded.weld[uint32_t(key >> 32)];
    if (locked[w] && scratch[w] != kSeen) scratch[w] = kSeen, p.input_locked.push_back(w);
    if (mesh_border && (*mesh_border)[w]) on_mesh_border = true;
  }
  for (uint32_t w : p.input_locked) scratch[w] = kNone;
  p.group_locked = p.any_left_out ? locked_ids(welded, group.corners, locked, scratch) : p.input_locked;
  if (on_mesh_border) p.open_border = find_open_border(welded, p.input(), locked);
  return p;
}

SimplifyResult simplify_prepared(const WeldedMesh& welded, const PreparedGroup& prepared,
                                 const std::vector<uint8_t>& locked, Simplifier simplifier,
                                 const SimplifyTarget& target, std::vector<uint32_t>& scratch) {
  const TriangleSet& input = prepared.input();
  if (input.triangle_count() == 0) return SimplifyResult{};
  SimplifyResult r = simplifier == Simplifier::kOpenMesh ? simplify_openmesh(welded, input, locked, target)
                                                         : simplify_meshopt(welded, prepared, locked, target, scratch);
  const size_t kept = r.triangles.triangle_count();
  drop_reversed_pairs(welded, r.triangles);
  if (r.triangles.triangle_count() != kept) r.group_locked_kept = false;
  return r;
}

SimplifyResult simplify_group(const WeldedMesh& welded, const TriangleSet& group,
                              const std::vector<uint8_t>& locked, Simplifier simplifier, const SimplifyTarget& target,
                              const FinSet& fins) {
  std::vector<uint32_t> scratch(welded.weld.size(), kNone);
  const PreparedGroup prepared =
      prepare_group(welded, group, locked, simplifier, fins, target.open_borders ? target.mesh_border : nullptr, scratch);
  return simplify_prepared(welded, prepared, locked, simplifier, target, scratch);
}

void drop_reversed_pairs(const WeldedMesh& welded, TriangleSet& triangles) {
  // (sorted welded corners, orientation, triangle): a triangle's orientation is whether its
  // welded corners are an even rotation of the sorted ones.
  struct Face {
    std::array<uint32_t, 3> key;
    bool odd;
    uint32_t t;
  };
  std::vector<Face> faces;
  const size_t n = triangles.triangle_count();
  faces.reserve(n);
  for (size_t t = 0; t < n; ++t) {
    const uint32_t* c = &triangles.corners[3 * t];
    const uint32_t a = welded.weld[c[0]], b = welded.weld[c[1]], d = welded.weld[c[2]];
    if (a == b || b == d || d == a) continue;
    std::array<uint32_t, 3> key{a, b, d};
    // Rotate the smallest first; then (lo, mid, hi) is even, (lo, hi, mid) odd.
    std::rotate(key.begin(), std::min_element(key.begin(), key.end()), key.end());
    const bool odd = key[1] > key[2];
    if (odd) std::swap(key[1], key[2]);
    faces.push_back({key, odd, uint32_t(t)});
  }
  // A reversed pair needs two faces on one key, which simplified groups almost never have: an
  // open addressing set of the keys (load ≤ 1/2) says whether any key repeats before anything
  // is sorted (the sort was most of this function's cost).
  auto same_key = [](const Face& x, const Face& y) {
    return x.key[0] == y.key[0] && x.key[1] == y.key[1] && x.key[2] == y.key[2];
  };
  {
    size_t slots = 16;
    while (slots < 2 * faces.size()) slots <<= 1;
    std::vector<uint32_t> table(slots, kNone);  // face index
    bool repeated = false;
    for (size_t i = 0; i < faces.size() && !repeated; ++i) {
      const std::array<uint32_t, 3>& k = faces[i].key;
      uint64_t h = (uint64_t(k[0]) * 0x9E3779B97F4A7C15ull) ^ (uint64_t(k[1]) * 0xC2B2AE3D27D4EB4Full) ^
                   (uint64_t(k[2]) * 0x165667B19E3779F9ull);
      size_t slot = size_t(h ^ (h >> 29)) & (slots - 1);
      while (table[slot] != kNone && !same_key(faces[table[slot]], faces[i])) slot = (slot + 1) & (slots - 1);
      if (table[slot] != kNone) repeated = true;
      table[slot] = uint32_t(i);
    }
    if (!repeated) return;
  }
  std::sort(faces.begin(), faces.end(), [](const Face& x, const Face& y) {
    for (int k = 0; k < 3; ++k)
      if (x.key[k] != y.key[k]) return x.key[k] < y.key[k];
    return x.odd != y.odd ? x.odd < y.odd : x.t < y.t;
  });
  std::vector<uint8_t> drop(n, 0);
  bool any = false;
  for (size_t i = 0; i < faces.size();) {
    size_t j = i;
    while (j < faces.size() && same_key(faces[j], faces[i])) ++j;
    size_t even_end = i;
    while (even_end < j && !faces[even_end].odd) ++even_end;
    // The first k of each orientation pair up (sorted by triangle: deterministic).
    const size_t k = std::min(even_end - i, j - even_end);
    for (size_t m = 0; m < k; ++m) drop[faces[i + m].t] = drop[faces[even_end + m].t] = 1, any = true;
    i = j;
  }
  if (!any) return;
  size_t kept = 0;
  for (size_t t = 0; t < n; ++t) {
    if (drop[t]) continue;
    std::copy_n(&triangles.corners[3 * t], 3, &triangles.corners[3 * kept]);
    triangles.materials[kept++] = triangles.materials[t];
  }
  triangles.corners.resize(3 * kept);
  triangles.materials.resize(kept);
}

namespace {

// `after`'s welded edge uses, and in `folded` the keys of the edges it uses more than a
// 2-manifold allows (once each).
EdgeUses count_edge_uses(const WeldedMesh& welded, const TriangleSet& after, std::vector<uint64_t>& folded) {
  constexpr uint32_t kManifoldUses = 2;  // an edge of a 2-manifold is used by at most 2 triangles
  EdgeUses out(after.corners.size());
  for_each_welded_edge(welded, after.corners, [&](uint32_t a, uint32_t b) {
    if (a != b && out.add(edge_key(a, b)) == kManifoldUses + 1) folded.push_back(edge_key(a, b));
  });
  return out;
}

// The fold check (simplification_folds) given `after`'s edge uses.
bool folds_parity(const WeldedMesh& welded, const TriangleSet& before, const EdgeUses& out,
                  const std::vector<uint64_t>& folded) {
  if (folded.empty()) return false;
  EdgeUses in(before.corners.size());
  for_each_welded_edge(welded, before.corners, [&](uint32_t a, uint32_t b) {
    if (a != b) in.add(edge_key(a, b));
  });
  // Only a fold that changes the edge's parity is a crack (four triangles on an edge pair up).
  for (uint64_t key : folded)
    if ((out.count(key) + in.count(key)) % 2 != 0) return true;
  return false;
}

// The border check (check_simplification) given `after`'s edge uses.
BorderState border_state(const WeldedMesh& welded, const std::vector<uint32_t>& before_locked, bool locked_kept,
                         const TriangleSet& after, const EdgeUses& out, const std::vector<uint64_t>& before_shared,
                         std::vector<uint32_t>& scratch) {
  // Every locked vertex of `before` is used by `after`.
  if (!locked_kept && !lost_locked_vertices(welded, before_locked, after.corners, scratch).empty())
    return BorderState::kBroken;
  // Every shared edge of `before` is an edge of `after`; one used once (a manifold border)
  // should stay used once: more uses are a fold over the border (spec/dag.md §2.3).
  BorderState state = BorderState::kKept;
  for (size_t i = 0; i < before_shared.size();) {
    size_t j = i;
    while (j < before_shared.size() && before_shared[j] == before_shared[i]) ++j;
    const uint32_t after_uses = out.count(before_shared[i]);
    if (after_uses == 0) return BorderState::kBroken;
    if (j - i == 1 && after_uses != 1) state = BorderState::kFoldedOver;
    i = j;
  }
  return state;
}

}  // namespace

bool simplification_folds(const WeldedMesh& welded, const TriangleSet& before, const TriangleSet& after) {
  std::vector<uint64_t> folded;
  const EdgeUses out = count_edge_uses(welded, after, folded);
  return folds_parity(welded, before, out, folded);
}

SimplificationCheck check_simplification(const WeldedMesh& welded, const TriangleSet& before, const TriangleSet& after,
                                         const std::vector<uint32_t>& before_locked, bool locked_kept,
                                         const std::vector<uint64_t>& shared_edges, std::vector<uint32_t>& scratch) {
  // One count of `after`'s edges serves both checks.
  std::vector<uint64_t> folded;
  const EdgeUses out = count_edge_uses(welded, after, folded);
  return {border_state(welded, before_locked, locked_kept, after, out, shared_edges, scratch),
          folds_parity(welded, before, out, folded)};
}

}  // namespace vgeo::build_detail
