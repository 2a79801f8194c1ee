// Vertex placement (spec/dag.md §2.3 Place): after a group is simplified, each of its movable
// vertices is moved off the leaves along its leaf normal, so that the simplified surface lies
// on both sides of the curved leaves instead of wholly inside (or outside) them.
// Based on: Garland, Heckbert, "Surface Simplification Using Quadric Error Metrics", SIGGRAPH
// 1997, §4 (optimal placement: a collapse's vertex goes where its quadric is smallest, off the
// surface on curved regions); Karis et al., "Nanite: A Deep Dive", SIGGRAPH 2021 (Nanite's
// simplifier places each collapse's vertex from its quadric). Here the simplifier (meshopt 0.18)
// only collapses edges, so every vertex it keeps is a leaf vertex; the placement is done after
// it, restricted to the vertex's leaf normal line (one unknown per vertex: always well posed),
// with the offset estimated from the curvature the leaf normals show (a circular arc's
// midpoint lies (n_i - n_j)·(p_i - p_j)/8 outside its chord; a quadratic patch's centroid 4/9
// of the sum of its edges' bulges outside the flat triangle), half of it: the largest deviation
// is then split between the vertices (outside) and the triangle interiors (inside).
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "vgeo/dag/build_internal.h"

namespace vgeo::build_detail {

namespace {

DVec3 dvec(const float* p) { return DVec3{p[0], p[1], p[2]}; }
double ddot(DVec3 a, DVec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
DVec3 dsub(DVec3 a, DVec3 b) { return DVec3{a.x - b.x, a.y - b.y, a.z - b.z}; }

// Per welded position of the group's triangles (in order of first use): its leaf position and
// leaf normal, whether it may move, the summed centroid sag estimates of its triangles, their
// count, its shortest incident edge (squared), and its corner vertices (at most
// kMaxMovedCopies are kept: a position with more never moves).
struct Position {
  uint32_t welded = kNone, leaf = kNone;
  bool movable = false, smooth = false;
  DVec3 p, n;
  uint32_t triangles = 0;
  double sag = 0.0, shortest_edge2 = std::numeric_limits<double>::infinity();
  std::array<uint32_t, kMaxMovedCopies> vertex{};
  uint32_t vertex_count = 0;
};

}  // namespace

// Sag estimates from the leaf positions and leaf normals only (no distance query): a circular
// arc from p_i to p_j with end normals n_i, n_j bulges (n_i - n_j)·(p_i - p_j)/8 out of its
// chord at the midpoint (exact for the arc: |p_i - p_j|^2 / 8R); a quadratic patch over a
// triangle bulges 4/9 of its three edges' bulges at the centroid. Positive: the leaves lie on
// the normals' side (convex), so the vertex moves outward.
VertexMoves place_vertices(const PlacementContext& ctx, const TriangleSet& tris, std::vector<uint32_t>& scratch) {
  const WeldedMesh& welded = *ctx.welded;
  const LeafSurface& leaves = *ctx.leaves;
  // The positions, each read once (the leaf arrays are large: one cache miss per position, not
  // per corner), and each corner's position. The leaf data are read in passes of their own,
  // after the corners: the reads of different positions do not depend on each other there, so
  // their cache misses overlap (place_vertices was ~60% waiting on them when read per corner).
  std::vector<Position> at;
  at.reserve(tris.triangle_count() / 2 + 3);
  std::vector<uint32_t> corner_position(tris.corners.size());
  for (size_t i = 0; i < tris.corners.size(); ++i) {
    const uint32_t v = tris.corners[i], w = welded.weld[v];
    if (scratch[w] == kNone) {
      scratch[w] = uint32_t(at.size());
      Position q;
      q.welded = w;
      at.push_back(q);
    }
    Position& q = at[scratch[w]];
    corner_position[i] = scratch[w];
    bool known = false;
    for (uint32_t k = 0; k < std::min<uint32_t>(q.vertex_count, kMaxMovedCopies); ++k) known |= q.vertex[k] == v;
    if (!known) {
      if (q.vertex_count < kMaxMovedCopies) q.vertex[q.vertex_count] = v;
      ++q.vertex_count;
    }
  }
  for (const Position& q : at) scratch[q.welded] = kNone;
  for (Position& q : at) q.leaf = leaves.origin(q.welded);
  for (Position& q : at) q.leaf = welded.weld[q.leaf];
  bool any_movable = false;
  for (Position& q : at) {
    const uint32_t w = q.welded;
    q.n = dvec(&leaves.normal[3 * size_t(q.leaf)]);
    q.smooth = !(q.n.x == 0 && q.n.y == 0 && q.n.z == 0);
    q.movable = !(*ctx.locked)[w] && !(*ctx.pinned)[w] && !(!ctx.mesh_border->empty() && (*ctx.mesh_border)[w]) &&
                welded.copies[w] <= kMaxMovedCopies && q.smooth;
    q.p = dvec(&ctx.leaf_positions[3 * size_t(q.leaf)]);
    any_movable |= q.movable;
  }
  VertexMoves out;
  if (!any_movable) return out;
  for (size_t t = 0; t < tris.triangle_count(); ++t) {
    Position* q[3] = {&at[corner_position[3 * t]], &at[corner_position[3 * t + 1]], &at[corner_position[3 * t + 2]]};
    if (q[0] == q[1] || q[1] == q[2] || q[2] == q[0]) continue;  // no area, no sag
    if (!q[0]->movable && !q[1]->movable && !q[2]->movable) continue;
    double bulge = 0.0, e2[3];
    bool smooth = true;
    for (int k = 0; k < 3; ++k) {
      const int j = k == 2 ? 0 : k + 1;
      const DVec3 d = dsub(q[k]->p, q[j]->p);
      e2[k] = ddot(d, d);
      bulge += ddot(dsub(q[k]->n, q[j]->n), d) / 8.0;
      smooth &= q[k]->smooth;
    }
    // A triangle at a crease corner has no sag estimate (no leaf normal there), and the surface
    // it replaces is no smooth patch: its corners stay (CGAL fandisk drew 3.2x the triangles at
    // equal error when its smooth corners moved by the sag of triangles across its creases).
    if (!smooth) {
      for (int k = 0; k < 3; ++k) q[k]->movable = false;
      continue;
    }
    const double sag = bulge * (4.0 / 9.0);
    for (int k = 0; k < 3; ++k) {
      q[k]->sag += sag;
      ++q[k]->triangles;
      q[k]->shortest_edge2 = std::min({q[k]->shortest_edge2, e2[k], e2[k == 0 ? 2 : k - 1]});
    }
  }
  for (const Position& q : at) {
    if (!q.movable || q.vertex_count > kMaxMovedCopies || q.triangles == 0) continue;
    const double limit = kMaxOffsetPerEdge * std::sqrt(q.shortest_edge2);
    const double offset = std::clamp(ctx.share * q.sag / q.triangles, -limit, limit);
    if (!(offset != 0.0)) continue;
    const float moved[3] = {float(q.p.x + offset * q.n.x), float(q.p.y + offset * q.n.y), float(q.p.z + offset * q.n.z)};
    const float* now = &ctx.mesh->positions[3 * size_t(q.welded)];
    if (moved[0] == now[0] && moved[1] == now[1] && moved[2] == now[2]) continue;
    for (uint32_t i = 0; i < q.vertex_count; ++i) {
      out.vertex.push_back(q.vertex[i]);
      out.positions.insert(out.positions.end(), moved, moved + 3);
    }
  }
  return out;
}

}  // namespace vgeo::build_detail
