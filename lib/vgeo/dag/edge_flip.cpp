// Edge flips at a fixed vertex set after a group's simplification (spec/dag.md §Simplify):
// both backends only collapse edges, so which diagonal joins two kept triangles is whatever
// the collapse order left. On a curved or noisy surface the other diagonal can lie closer
// to the original surface; the stored error is the largest distance of the simplified
// surface from the leaves, so a flip that brings the pair closer to the leaves can lower it.
// Based on: Hoppe, DeRose, Duchamp, McDonald, Stuetzle, "Mesh Optimization", SIGGRAPH 1993
// (§4.2: edge swaps kept when they lower the distance energy); Dyn, Hormann, Kim, Levin,
// "Optimizing 3D Triangulations Using Discrete Curvature Analysis", 2001 (data-dependent
// triangulations: the diagonal chosen by the surface, not by the plane).
//
// The pass costs little because the group's error measurement (leaf_deviation) hands it what
// it found: the peak (the point farthest from the leaves) and, per triangle edge and interior,
// its points' distances and the leaf triangles their walks ended at. The old pair's side of
// every decision is read from there, and the new pair's walks start where the measurement's
// walks for the neighbouring old points ended (docs/acceptance/issue23_flipfast.md).
#include <algorithm>
#include <array>
#include <cmath>

#include "vgeo/core/surface_distance.h"
#include "vgeo/core/thread_pool.h"
#include "vgeo/dag/build_internal.h"

namespace vgeo::build_detail {

namespace {

// A flip must lower the pair's largest sampled squared distance by this factor: a flip is
// kept only for a clear gain, so no pair flips back and forth on rounding noise.
constexpr double kFlipGain = 0.98;
// Only pairs whose measured squared distance reaches this share of the group's peak are
// candidates (their farthest point at ≥ 0.71 of the group's error). The others are most
// candidates and do not decide the group's error; flipping them changes the next level's
// input only, within dagq's noise (qual.sh's 9 meshes, two sweeps, one run each: gmean 0.907
// at 0.5, 0.899 at 0.25, 0.907 with every pair) for ~4.7x the walks (armadillo: 84k -> 18k).
constexpr double kCandidatePeakShare = 0.5;
// Barycentric steps of the sample points of a pair (the centroid of each triangle, the thirds
// of the diagonal: verify's lattice, kErrorLatticeSubdivisions, on the edges a flip changes).
constexpr uint32_t kFlipSampleSteps = 3;
// A pair whose points lie within this fraction of the diagonal's length of the leaves is
// flat to float precision: there a "gain" is rounding (blade, a CAD part with flat faces,
// flipped on it and lost its last level: dagq 0.85 -> 1.28 of the peer's).
constexpr double kFlatDeviation = 1e-4;
// Walk steps before the tree takes over (as leaf_error.cpp's walk: a sample lies within a few
// leaf triangles of the previous one).
constexpr int kFlipMaxWalkSteps = 32;
// The candidates' gain tests on a pool (a lone level's group: flip_edges_towards_leaves' `pool`)
// run in this many pieces per thread, each of at least this many pairs: a test is up to 8
// walks (a coarse level's mostly end in tree searches, ~25 us each), a pool round some us.
constexpr size_t kFlipPiecesPerThread = 4;
constexpr size_t kMinFlipPiecePairs = 4;

// Positions, welded ids and leaf origins by vertex id: the mesh's, and a group's moved vertices
// (fresh) before their ids are final, welded and locked as the vertex each replaces.
struct FlipVertices {
  const WeldedMesh& welded;
  const LeafSurface& leaves;
  const FreshVertices* fresh;
  bool is_fresh(uint32_t v) const { return fresh && fresh->positions && v >= fresh->first; }
  DVec3 position(uint32_t v) const {
    const float* p = is_fresh(v) ? &fresh->positions[3 * size_t(v - fresh->first)] : &welded.mesh->positions[3 * size_t(v)];
    return {p[0], p[1], p[2]};
  }
  uint32_t weld(uint32_t v) const { return welded.weld[is_fresh(v) ? fresh->previous[v - fresh->first] : v]; }
  uint32_t origin(uint32_t v) const { return is_fresh(v) ? fresh->origin[v - fresh->first] : leaves.origin(v); }
};

// Whether p lies within sqrt(threshold) of the leaves: a visibility walk from *at (*at gets
// where it ended), decided by the triangle p projects into; a walk that stops (a border, a
// ridge, the step limit) asks the tree, whose answer is exact.
bool walked_within(const LeafSurface& leaves, DVec3 p, double threshold, uint32_t* at) {
  const LeafWalkEnd end = walk_leaf_surface(leaves, p, *at, kFlipMaxWalkSteps);
  *at = end.triangle;
  if (end.projects_inside) return prepared_plane_distance_squared(p, end.prepared) <= threshold;
  return leaves.tree.nearest_or_within_squared(p, threshold, at) <= threshold;
}

DVec3 midpoint(DVec3 p, DVec3 q) { return {0.5 * (p.x + q.x), 0.5 * (p.y + q.y), 0.5 * (p.z + q.z)}; }

// Whether every sample point of triangles (p, q, r) and (q, p, s) that is not on their outer
// edges (their interior points and the diagonal p-q's) lies within sqrt(threshold) of the
// leaves.
bool pair_within(const LeafSurface& leaves, DVec3 p, DVec3 q, DVec3 r, DVec3 s, double threshold, uint32_t start) {
  const uint32_t n = kFlipSampleSteps;
  uint32_t at = start;
  for (uint32_t i = 1; i < n; ++i) {
    const double f = double(i) / n;
    if (!walked_within(leaves, {p.x + (q.x - p.x) * f, p.y + (q.y - p.y) * f, p.z + (q.z - p.z) * f}, threshold, &at)) return false;
  }
  for (const DVec3& c : {r, s})
    for (uint32_t u = 1; u < n; ++u)
      for (uint32_t w = 1; u + w < n; ++w) {
        const double bu = double(u) / n, bw = double(w) / n, bv = 1.0 - bu - bw;
        if (!walked_within(leaves, {p.x * bv + q.x * bu + c.x * bw, p.y * bv + q.y * bu + c.y * bw, p.z * bv + q.z * bu + c.z * bw}, threshold, &at)) return false;
      }
  return true;
}

}  // namespace

bool flip_edges_towards_leaves(const WeldedMesh& welded, const LeafSurface& leaves, const std::vector<uint8_t>& locked,
                               float floor, const LatticePeak& peak, const LatticeRecord& record, TriangleSet& triangles,
                               std::vector<uint8_t>& flipped, const FreshVertices* fresh, ThreadPool* pool) {
  const FlipVertices vertex{welded, leaves, fresh};
  const size_t n = triangles.triangle_count();
  flipped.assign(n, 0);
  // The first simplification of the leaves (floor 0) is left as collapsed: it lies a few
  // percent of a leaf edge from the leaves (200k sphere: 1.8e-4 of a 3.6 diagonal), far below
  // any error a cut is asked for, and it is half the candidates (flipping there too: dagq's
  // ratio to the peer within noise, geometric mean 0.91 both, over three spheres, armadillo
  // and bunny00). A group whose error is its floor (no peak) cannot get below it.
  // A peak at a moved vertex is a point of every flipped surface.
  if (n < 2 || leaves.tree.empty() || !(floor > 0) || peak.triangle == kNone || peak.corner || peak.triangle >= n ||
      record.places.size() != 4 * n)
    return false;
  std::vector<uint32_t>& corners = triangles.corners;
  auto w = [&](size_t corner) { return vertex.weld(corners[corner]); };
  // The measurement's values (the old pair's side of each decision). A diagonal without
  // points was skipped by it: an input edge, within the floor.
  const std::vector<LatticeRecord::Place>& known = record.places;
  const double floor_d2 = double(floor) * double(floor);
  double peak_d2 = floor_d2;
  for (const LatticeRecord::Place& q : known) peak_d2 = std::max(peak_d2, q.d2);
  const double candidate_d2 = kCandidatePeakShare * peak_d2;

  // Welded edges of the group: open addressing (load <= 1/2), per edge its number of uses and
  // its first two directed uses (3t + j). Edges made by a flip are added (one use each: never
  // a candidate, and never made twice).
  size_t slots = 16;
  int shift = 60;  // hash = top log2(slots) bits of a multiplicative hash
  while (slots < 4 * n) slots <<= 1, --shift;
  constexpr uint64_t kNoEdgeKey = ~uint64_t(0);  // no edge key (a < b) equals it
  std::vector<uint64_t> keys(slots, kNoEdgeKey);
  std::vector<std::array<uint32_t, 3>> edge(slots);  // uses, first use, second use
  auto slot = [&](uint64_t key) {
    size_t h = size_t((key * 0x9E3779B97F4A7C15ull) >> shift);
    while (keys[h] != kNoEdgeKey && keys[h] != key) h = (h + 1) & (slots - 1);
    return h;
  };
  auto add_use = [&](uint64_t key, uint32_t use) {
    const size_t h = slot(key);
    if (keys[h] == kNoEdgeKey) keys[h] = key, edge[h] = {0, kNone, kNone};
    std::array<uint32_t, 3>& e = edge[h];
    if (e[0] < 2) e[1 + e[0]] = use;
    ++e[0];
  };
  for (size_t t = 0; t < n; ++t)
    for (int j = 0; j < 3; ++j) {
      const uint32_t a = w(3 * t + j), b = w(3 * t + (j + 1) % 3);
      if (a != b) add_use(edge_key(a, b), uint32_t(3 * t + j));
    }

  // A candidate flip: the manifold edge's two triangles, t1 = (a, b, c) at its first use, t2 =
  // (b, a, d) (ia.. jd: their corner slots), and the old pair's largest measured value.
  struct Pair {
    uint32_t t1, t2, ia, ib, ic, jd, u1;
    double before;
    LatticeRecord::Place diagonal, inside;
  };
  // The tests of the edge of directed use `use` that no flip changes while its two triangles
  // are unflipped (its use count, materials, the measured values, degeneracy, locks).
  auto find_pair = [&](uint32_t use, Pair* pair) {
    const uint32_t ea = w(use), eb = w(3 * (use / 3) + (use % 3 + 1) % 3);
    if (ea == eb) return false;
    const std::array<uint32_t, 3>& e = edge[slot(edge_key(ea, eb))];
    if (e[0] != 2) return false;
    const uint32_t u1 = e[1], u2 = e[2];
    const uint32_t t1 = u1 / 3, t2 = u2 / 3, j1 = u1 % 3, j2 = u2 % 3;
    if (triangles.materials[t1] != triangles.materials[t2]) return false;
    // The old pair's points as measured: the diagonal's (visited from either triangle) and
    // both interiors'.
    const LatticeRecord::Place diagonal = known[4 * t1 + j1].d2 >= known[4 * t2 + j2].d2 ? known[4 * t1 + j1] : known[4 * t2 + j2];
    const LatticeRecord::Place inside = known[4 * t1 + kLatticeInterior];
    const double before = std::max({diagonal.d2 < 0 ? floor_d2 : diagonal.d2, inside.d2, known[4 * t2 + kLatticeInterior].d2});
    if (before < candidate_d2) return false;
    // t1 = (a, b, c), t2 = (b, a, d): opposite directions, the same vertices (no seam) on the edge.
    const uint32_t ia = 3 * t1 + j1, ib = 3 * t1 + (j1 + 1) % 3, ic = 3 * t1 + (j1 + 2) % 3;
    const uint32_t jb = 3 * t2 + j2, ja = 3 * t2 + (j2 + 1) % 3, jd = 3 * t2 + (j2 + 2) % 3;
    if (corners[ia] != corners[ja] || corners[ib] != corners[jb]) return false;
    const uint32_t a = w(ia), b = w(ib), c = w(ic), d = w(jd);
    if (c == d || c == a || c == b || d == a || d == b) return false;
    // Group-border edges are never removed or made (another group may use them).
    if ((locked[a] && locked[b]) || (locked[c] && locked[d])) return false;
    *pair = {t1, t2, ia, ib, ic, jd, u1, before, diagonal, inside};
    return true;
  };
  // Whether earlier flips rule the pair out: one of its triangles flipped, or its new diagonal
  // made (it would be used more than twice).
  auto blocked = [&](const Pair& f) {
    return flipped[f.t1] || flipped[f.t2] || keys[slot(edge_key(w(f.ic), w(f.jd)))] != kNoEdgeKey;
  };
  // Whether the new pair lies clearly closer to the leaves than the old one (reads neither the
  // flips made nor the edge table: the same answer before and after other pairs flip).
  auto gains = [&](const Pair& f) {
    const DVec3 pa = vertex.position(corners[f.ia]), pb = vertex.position(corners[f.ib]);
    const DVec3 pc = vertex.position(corners[f.ic]), pd = vertex.position(corners[f.jd]);
    using surface_distance_detail::cross, surface_distance_detail::dot, surface_distance_detail::sub;
    const DVec3 ab = sub(pb, pa);
    if (f.before <= kFlatDeviation * kFlatDeviation * dot(ab, ab)) return false;
    // The new pair (c, a, d), (d, b, c) must face as the old pair does.
    const DVec3 n1 = cross(sub(pb, pa), sub(pc, pa)), n2 = cross(sub(pa, pb), sub(pd, pb));
    const DVec3 m1 = cross(sub(pa, pc), sub(pd, pc)), m2 = cross(sub(pb, pd), sub(pc, pd));
    if (dot(m1, n1) <= 0 || dot(m1, n2) <= 0 || dot(m2, n1) <= 0 || dot(m2, n2) <= 0) return false;
    // Every sample of the new pair must lie clearly closer than the old pair's worst; its
    // diagonal's midpoint, farthest from the old pair, rejects most first. The new pair's
    // points lie next to the old pair's (the new diagonal's thirds by the old interiors, its
    // interiors by the old diagonal's thirds), so the walks start where the measurement's
    // walks for those ended.
    uint32_t at = f.diagonal.leaf != kNone ? f.diagonal.leaf : leaves.vertex_triangle[vertex.origin(corners[f.ia])];
    if (at == kNone) return false;
    if (!walked_within(leaves, midpoint(pc, pd), kFlipGain * f.before, &at)) return false;
    if (f.inside.leaf != kNone) at = f.inside.leaf;
    return pair_within(leaves, pc, pd, pb, pa, kFlipGain * f.before, at);
  };
  auto apply = [&](const Pair& f) {
    const uint32_t vc = corners[f.ic], vd = corners[f.jd], va = corners[f.ia], vb = corners[f.ib];
    const uint32_t c = w(f.ic), d = w(f.jd);
    corners[3 * f.t1] = vc, corners[3 * f.t1 + 1] = va, corners[3 * f.t1 + 2] = vd;
    corners[3 * f.t2] = vd, corners[3 * f.t2 + 1] = vb, corners[3 * f.t2 + 2] = vc;
    flipped[f.t1] = flipped[f.t2] = 1;
    add_use(edge_key(c, d), kNone);
  };
  // Flips the edge of directed use `use` when it passes every test; whether it flipped. Each
  // manifold edge is tried at its first use; a pair is flipped at most once (one sweep: a
  // second over the neighbours of flips would need the flipped pairs measured again).
  auto try_flip = [&](uint32_t use) {
    if (flipped[use / 3]) return false;
    Pair f;
    if (!find_pair(use, &f) || blocked(f) || !gains(f)) return false;
    apply(f);
    return true;
  };
  // The peak first: the edge its point lies on, or the three edges of the triangle it lies
  // inside. Unless one of them flips, the peak stays a point of the flipped surface, whose
  // error then cannot fall below the collapsed one's, and the group keeps its triangles as
  // collapsed (the caller's keep rule): the other candidates need no test.
  const uint32_t t = peak.triangle;
  const int first = peak.place == kLatticeInterior ? 0 : peak.place;
  const int last = peak.place == kLatticeInterior ? 2 : peak.place;
  bool peak_flipped = false;
  for (int j = first; j <= last && !peak_flipped; ++j) {
    const uint32_t ea = w(3 * t + j), eb = w(3 * t + (j + 1) % 3);
    if (ea == eb) continue;
    const std::array<uint32_t, 3>& e = edge[slot(edge_key(ea, eb))];
    if (e[0] == 2) peak_flipped = try_flip(e[1]);
  }
  if (!peak_flipped) return false;
  // Then every candidate, from the triangles with a place at or beyond the share (a pair's
  // old side is its triangles' places, so each candidate has one), in triangle order.
  std::vector<uint32_t> tries;
  for (uint32_t t = 0; t < n; ++t) {
    double hottest = floor_d2;  // an unmeasured diagonal counts as the floor
    for (int place = 0; place < 4; ++place) hottest = std::max(hottest, known[4 * t + place].d2);
    if (hottest < candidate_d2) continue;
    for (uint32_t j = 0; j < 3; ++j) tries.push_back(3 * t + j);
  }
  if (!pool || pool->size() < 2) {
    for (uint32_t use : tries) try_flip(use);
    return true;
  }
  // On a pool: the pairs not yet ruled out, each once (an edge is tried from both of its
  // triangles), their gains tested in parallel, then the flips made in the serial order with
  // what earlier flips rule out (blocked): the same flips as above, since a pair's gain does
  // not depend on the others' flips. Pairs an earlier flip rules out are tested in vain.
  std::vector<Pair> pairs;
  std::vector<uint32_t> pair_of(tries.size(), kNone), pair_at_first_use(3 * n, kNone);
  for (size_t i = 0; i < tries.size(); ++i) {
    Pair f;
    if (flipped[tries[i] / 3] || !find_pair(tries[i], &f) || blocked(f)) continue;
    if (pair_at_first_use[f.u1] == kNone) pair_at_first_use[f.u1] = uint32_t(pairs.size()), pairs.push_back(f);
    pair_of[i] = pair_at_first_use[f.u1];
  }
  std::vector<uint8_t> gain(pairs.size(), 0);
  const size_t pieces = std::max<size_t>(1, std::min(size_t(pool->size()) * kFlipPiecesPerThread, pairs.size() / kMinFlipPiecePairs));
  for_chunks(pool, pairs.size(), std::max<size_t>(1, (pairs.size() + pieces - 1) / pieces), [&](size_t begin, size_t end) {
    for (size_t k = begin; k < end; ++k) gain[k] = gains(pairs[k]);
  });
  for (size_t i = 0; i < tries.size(); ++i) {
    if (pair_of[i] == kNone || flipped[tries[i] / 3]) continue;
    const Pair& f = pairs[pair_of[i]];
    if (!blocked(f) && gain[pair_of[i]]) apply(f);
  }
  return true;
}

}  // namespace vgeo::build_detail
