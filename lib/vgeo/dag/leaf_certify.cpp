// Certified stored errors (BuildOptions::error_bound = ErrorBound::kCertified; spec/dag.md
// §Error "Certified bound", spec/invariants.md §5 "Certified bound", ERROR_CERTIFIED).
//
// The default build stores the maximum over the 3-step lattice (leaf_error.cpp): a lower bound
// of the continuous one-sided deviation, which between those points is up to 1.3× larger. In
// certified mode the builder runs as in the default mode (every decision that shapes the DAG
// is taken against the measured error, so the clusters are the same), and after the levels
// each group's stored error is raised to a proven upper bound of the continuous deviation of
// its simplified triangles from the leaves: every simplified triangle is covered by
// sub-triangles (edge-midpoint splits, at most kCertifyMaxDepth deep), each with a proven
// upper bound of the distance of all its points to the leaves — the Lipschitz bound, the
// overlay (the leaf triangles under it, flooded over the leaf adjacency: where they cover it
// with one orientation, each point lies over a piece of one leaf triangle, and the vertical
// distance and the distance to that triangle are convex on the piece, so its corners bound
// it), or one leaf triangle near all three corners — and the group's bound is the largest
// bound used (docs/acceptance/issue23_certfast.md: the design and its measurements;
// docs/acceptance/issue23_certopt.md: the opt-in mode).
// Based on: branch-and-bound maximisation of a Lipschitz function over a simplex (Piyavskii,
// 1972); the overlay of two triangulated height fields, with coverage by the winding number of
// the patch boundary (a degree argument); both written here for this use.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

#include "vgeo/core/thread_pool.h"
#include "vgeo/dag/build_internal.h"

namespace vgeo::build_detail {

namespace {

// Triangles per chunk of the parallel twin pass (a few ns per triangle: large chunks).
constexpr size_t kTwinChunk = size_t(1) << 16;


// The overlay needs T's plane frame: skipped when the Gram determinant of T's edges is below
// this fraction of the product of their squared lengths (a needle or a point: the projection
// is ill-conditioned; the Lipschitz bound and the splits handle it).
constexpr double kOverlayMinDeterminant = 1e-12;
// A patch edge counts as meeting T when it comes within this many units of T's barycentric
// coordinates (conservative: rounding in the projection, ~1e-16 relative, cannot hide a crossing).
constexpr double kOverlayCrossingMargin = 1e-9;
// A projected leaf triangle's orientation is trusted only when |cross| of its projected edges
// exceeds this fraction of the product of their lengths (the sine of its projected angle):
// rounding is ~1e-16 relative, so a sign this clear is the true one. An edge-on one fails.
constexpr double kOverlayMinSine = 1e-9;
// A patch covers T only if one of its pieces has an interior: twice its area, in T's unit
// triangle (area 1/2), above this (rounding leaves slivers of ~1e-16 where a leaf triangle
// touches T at a corner or along an edge; the smallest real piece of a 1M-triangle mesh under
// a root triangle is ~1e-7).
constexpr double kOverlayMinPieceArea = 1e-12;

// ---- The certified bound (spec/invariants.md §5 "Certified bound"; spec/dag.md §Error) ----

// A triangle whose bound exceeds the target — the largest exact distance found in the group ×
// (1 + kCertifySlack), or the members' floor — is split (up to kCertifyMaxDepth) in the hope
// of a tighter one. The overlay's vertical bound is near exact on smooth surfaces, so splits
// are rare; the slack only decides how hard the builder tries where the proofs are loose
// (creases, folds, bumps steeper than the triangle), i.e. how far above the continuous maximum
// the stored error may end up. Measured (docs/acceptance/issue23_certfast.md): 1/128 and 1/32
// cost the same CPU within the noise; 1/128 gives the higher measured/stored median.
constexpr double kCertifySlack = 1.0 / 128;

inline DVec3 sub3(DVec3 a, DVec3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline double dot3(DVec3 a, DVec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline DVec3 mid3(DVec3 a, DVec3 b) { return {0.5 * (a.x + b.x), 0.5 * (a.y + b.y), 0.5 * (a.z + b.z)}; }
inline DVec3 cross3(DVec3 a, DVec3 b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }

// Largest distance from a point of the triangle to its nearest corner: the circumradius when
// no angle exceeds 90°; otherwise the point of the longest edge equidistant from the obtuse
// corner and an end of that edge (spec/invariants.md §5, Lipschitz).
double covering_radius(const DVec3 c[3]) {
  double l2[3];
  for (int k = 0; k < 3; ++k) l2[k] = dot3(sub3(c[(k + 1) % 3], c[(k + 2) % 3]), sub3(c[(k + 1) % 3], c[(k + 2) % 3]));
  int o = 0;  // corner opposite the longest edge
  if (l2[1] > l2[o]) o = 1;
  if (l2[2] > l2[o]) o = 2;
  const DVec3 a = c[(o + 1) % 3], b = c[(o + 2) % 3], p = c[o];
  if (l2[o] >= l2[(o + 1) % 3] + l2[(o + 2) % 3]) {
    const double len = std::sqrt(l2[o]);
    if (len == 0) return 0;
    const DVec3 u{(b.x - a.x) / len, (b.y - a.y) / len, (b.z - a.z) / len};
    double r = 0;
    for (int side = 0; side < 2; ++side) {
      const DVec3 end = side ? b : a;
      const DVec3 w = sub3(p, end);
      const double w2 = dot3(w, w), along = side ? -dot3(w, u) : dot3(w, u);
      if (w2 > 0) r = std::max(r, along > 0 ? w2 / (2 * along) : std::sqrt(w2));
    }
    return r;
  }
  const DVec3 n = cross3(sub3(c[1], c[0]), sub3(c[2], c[0]));
  return std::sqrt(l2[0]) * std::sqrt(l2[1]) * std::sqrt(l2[2]) / (2 * std::sqrt(dot3(n, n)));
}

// T's plane frame: a point x maps to barycentric-like (u, v) with x ≈ o + u·e1 + v·e2 and its
// height h = n̂·(x − o) above T's plane. T itself is the unit triangle {u, v ≥ 0, u + v ≤ 1}.
struct OverlayFrame {
  DVec3 o, e1, e2, unit_normal;
  double g11, g12, g22, det;
};
struct Projected {
  double u, v, h;
};

bool make_overlay_frame(const DVec3 c[3], OverlayFrame* f) {
  f->o = c[0], f->e1 = sub3(c[1], c[0]), f->e2 = sub3(c[2], c[0]);
  f->g11 = dot3(f->e1, f->e1), f->g12 = dot3(f->e1, f->e2), f->g22 = dot3(f->e2, f->e2);
  f->det = f->g11 * f->g22 - f->g12 * f->g12;
  if (!(f->det > kOverlayMinDeterminant * f->g11 * f->g22)) return false;
  const DVec3 n = cross3(f->e1, f->e2);
  const double len = std::sqrt(dot3(n, n));
  f->unit_normal = {n.x / len, n.y / len, n.z / len};
  return true;
}

inline Projected project(const OverlayFrame& f, DVec3 x) {
  const DVec3 r = sub3(x, f.o);
  const double a = dot3(f.e1, r), b = dot3(f.e2, r);
  return {(f.g22 * a - f.g12 * b) / f.det, (f.g11 * b - f.g12 * a) / f.det, dot3(f.unit_normal, r)};
}

// Whether segment pq meets T's unit triangle widened by kOverlayCrossingMargin (Liang–Barsky).
bool segment_meets_unit_triangle(const Projected& p, const Projected& q) {
  const double m = kOverlayCrossingMargin;
  double lo = 0, hi = 1;
  const double dx = q.u - p.u, dy = q.v - p.v;
  const double n[3][2] = {{-1, 0}, {0, -1}, {1, 1}};  // constraints n·x ≤ h
  const double h[3] = {m, m, 1 + m};
  for (int k = 0; k < 3; ++k) {
    const double start = n[k][0] * p.u + n[k][1] * p.v - h[k], slope = n[k][0] * dx + n[k][1] * dy;
    if (slope == 0) {
      if (start > 0) return false;
      continue;
    }
    const double s = -start / slope;
    if (slope > 0) hi = std::min(hi, s);
    else lo = std::max(lo, s);
    if (lo > hi) return false;
  }
  return true;
}

// Whether leaf edge pq, of which one end is corner k of T (kp or kq ≥ 0, the other -1),
// meets T at that corner only: its direction from the corner points strictly out of T's angle
// there (by kOverlayCrossingMargin of its length). Then it needs no neighbour: a patch
// boundary through a corner of T only leaves T's interior connected and free of it.
bool touches_only_at_corner(const Projected& p, const Projected& q, int kp, int kq) {
  if (kp >= 0 && kq >= 0) return false;
  const double du = kp >= 0 ? q.u - p.u : p.u - q.u, dv = kp >= 0 ? q.v - p.v : p.v - q.v;
  const double m = kOverlayCrossingMargin * std::sqrt(du * du + dv * dv);
  switch (kp >= 0 ? kp : kq) {
    case 0: return du < -m || dv < -m;
    case 1: return dv < -m || du + dv > m;
    default: return du < -m || du + dv > m;
  }
}

// Visited leaf triangles of one overlay (open addressing; cleared through the visit list).
struct OverlayScratch {
  std::vector<uint32_t> slot = std::vector<uint32_t>(64, kNone);
  std::vector<uint32_t> visited, stack;
  bool insert(uint32_t t) {
    if (2 * (visited.size() + 1) > slot.size()) {
      slot.assign(2 * slot.size(), kNone);
      for (uint32_t v : visited) place(v);
    }
    if (!place(t)) return false;
    visited.push_back(t);
    return true;
  }
  bool place(uint32_t t) {
    const size_t mask = slot.size() - 1;
    for (size_t h = size_t((uint64_t(t) * 0x9E3779B97F4A7C15ull) >> 20) & mask;; h = (h + 1) & mask) {
      if (slot[h] == t) return false;
      if (slot[h] == kNone) return slot[h] = t, true;
    }
  }
  void clear() {
    // Each visited id is in the table: its probe chain is followed until it is found (an
    // emptied slot before it does not stop the search), so every slot is reset.
    const size_t mask = slot.size() - 1;
    for (uint32_t t : visited)
      for (size_t h = size_t((uint64_t(t) * 0x9E3779B97F4A7C15ull) >> 20) & mask;; h = (h + 1) & mask)
        if (slot[h] == t) {
          slot[h] = kNone;
          break;
        }
    visited.clear();
    stack.clear();
  }
};

// The overlay bound of the sub-triangle with frame f (spec/invariants.md §5): the leaf
// triangles whose projection onto T's plane meets T, flooded from `start` across the edges
// whose projection meets T. Each such edge must be shared, in opposite directions, with a
// neighbour projecting with the same orientation: then the patch's projection covers T (its
// boundary misses T), and every point x of T lies in the piece T ∩ proj(F) of some patch
// triangle F, within min(|h_F(x)|, d(x, F)) of the leaves — the vertical distance to F and
// the distance to F, both convex on the piece, so bounded by their values at its corners.
// Returns that bound, or +inf when the patch does not provably cover T.
double overlay_bound(const LeafSurface& leaves, const LeafTwins& twins, const OverlayFrame& f, const DVec3* t_corners, uint32_t start,
                     double exact_above, OverlayScratch& scratch, DVec3* argmax) {
  constexpr double inf = std::numeric_limits<double>::infinity();
  if (start == kNone) return inf;
  const TriangleDistanceTree& tree = leaves.tree;
  scratch.clear();
  scratch.insert(start);
  scratch.stack.push_back(start);
  int orientation = 0;
  bool any_piece = false;
  double bound = 0;
  while (!scratch.stack.empty()) {
    const uint32_t t = scratch.stack.back();
    scratch.stack.pop_back();
    DVec3 corner[3];
    Projected q[3];
    for (int j = 0; j < 3; ++j) corner[j] = tree.corner(t, j), q[j] = project(f, corner[j]);
    // Orientation, clear of rounding: |cross| above kOverlayMinSine of the edge lengths' product.
    const double ax = q[1].u - q[0].u, ay = q[1].v - q[0].v, bx = q[2].u - q[0].u, by = q[2].v - q[0].v;
    const double area = ax * by - ay * bx;
    if (!(std::abs(area) > kOverlayMinSine * std::sqrt((ax * ax + ay * ay) * (bx * bx + by * by)))) return inf;
    const int sign = area > 0 ? 1 : -1;
    if (orientation == 0) orientation = sign;
    if (sign != orientation) return inf;
    // The piece T ∩ proj(t) and the bound on it.
    const bool inside = q[0].u > 0 && q[0].v > 0 && q[0].u + q[0].v < 1 && q[1].u > 0 && q[1].v > 0 &&
                        q[1].u + q[1].v < 1 && q[2].u > 0 && q[2].v > 0 && q[2].u + q[2].v < 1;
    double poly[2][9][3];  // (u, v, h) per piece corner
    int m = 0, cur = 0;
    if (inside) {
      for (int j = 0; j < 3; ++j) poly[0][j][0] = q[j].u, poly[0][j][1] = q[j].v, poly[0][j][2] = q[j].h;
      m = 3;
    } else {
      // Sutherland–Hodgman: T's unit triangle (heights interpolated later) clipped by t's edges.
      const double unit[3][2] = {{0, 0}, {1, 0}, {0, 1}};
      for (int k = 0; k < 3; ++k) poly[0][k][0] = unit[k][0], poly[0][k][1] = unit[k][1];
      m = 3;
      for (int j = 0; j < 3 && m > 0; ++j, cur ^= 1) {
        const Projected& a = q[j];
        const Projected& b = q[(j + 1) % 3];
        auto side = [&](const double* x) { return sign * ((b.u - a.u) * (x[1] - a.v) - (b.v - a.v) * (x[0] - a.u)); };
        int out = 0;
        for (int k = 0; k < m; ++k) {
          const double* x = poly[cur][k];
          const double* y = poly[cur][(k + 1) % m];
          const double sx = side(x), sy = side(y);
          if (sx >= 0) poly[cur ^ 1][out][0] = x[0], poly[cur ^ 1][out][1] = x[1], ++out;
          if ((sx >= 0) != (sy >= 0)) {
            const double s = sx / (sx - sy);
            poly[cur ^ 1][out][0] = x[0] + (y[0] - x[0]) * s, poly[cur ^ 1][out][1] = x[1] + (y[1] - x[1]) * s, ++out;
          }
        }
        m = out;
      }
      // Heights of t above each piece corner: t's plane over its projection, by the corner's
      // barycentric coordinates in proj(t).
      for (int k = 0; k < m; ++k) {
        const double px = poly[cur][k][0] - q[0].u, py = poly[cur][k][1] - q[0].v;
        const double l1 = (px * by - py * bx) / area, l2 = (ax * py - ay * px) / area;
        poly[cur][k][2] = q[0].h + l1 * (q[1].h - q[0].h) + l2 * (q[2].h - q[0].h);
      }
    }
    if (m > 0) {
      // Only a piece with an interior shows the patch covers T (the degree argument); one
      // touching T at a point or along a line does not.
      double twice_area = 0;
      for (int k = 0; k < m; ++k)
        twice_area += poly[cur][k][0] * poly[cur][(k + 1) % m][1] - poly[cur][(k + 1) % m][0] * poly[cur][k][1];
      if (std::abs(twice_area) > kOverlayMinPieceArea) any_piece = true;
      bool prepared = false;
      PreparedTriangle tri;
      for (int k = 0; k < m; ++k) {
        double value = std::abs(poly[cur][k][2]);
        if (value > exact_above) {  // the distance to t itself, which the vertical one bounds
          if (!prepared) tri = prepare_triangle(corner[0], corner[1], corner[2]), prepared = true;
          const double u = poly[cur][k][0], v = poly[cur][k][1];
          const DVec3 x{f.o.x + f.e1.x * u + f.e2.x * v, f.o.y + f.e1.y * u + f.e2.y * v, f.o.z + f.e1.z * u + f.e2.z * v};
          value = std::min(value, std::sqrt(prepared_triangle_distance_squared(x, tri)));
        }
        if (value > bound) {
          bound = value;
          const double u = poly[cur][k][0], v = poly[cur][k][1];
          *argmax = {f.o.x + f.e1.x * u + f.e2.x * v, f.o.y + f.e1.y * u + f.e2.y * v, f.o.z + f.e1.z * u + f.e2.z * v};
        }
      }
    }
    // Which corner of T each corner of t is, if any (t strictly inside T has none).
    int at_corner[3] = {-1, -1, -1};
    if (t_corners && !inside)
      for (int j = 0; j < 3; ++j)
        for (int k = 0; k < 3; ++k)
          if (corner[j].x == t_corners[k].x && corner[j].y == t_corners[k].y && corner[j].z == t_corners[k].z) at_corner[j] = k;
    // Edges whose projection meets T: matched with a neighbour, which joins the patch.
    for (int j = 0; j < 3; ++j) {
      if (!inside && !segment_meets_unit_triangle(q[j], q[(j + 1) % 3])) continue;
      if (at_corner[j] >= 0 || at_corner[(j + 1) % 3] >= 0) {
        if (touches_only_at_corner(q[j], q[(j + 1) % 3], at_corner[j], at_corner[(j + 1) % 3])) continue;
      }
      const uint32_t g = leaves.neighbour[3 * size_t(t) + size_t(j)];
      if (g == kNone || twins.twin[3 * size_t(t) + size_t(j)] > 2) return inf;
      if (scratch.insert(g)) scratch.stack.push_back(g);
    }
  }
  return any_piece ? bound : inf;
}

// The certification of one group's simplified triangles (one thread: deterministic).
struct Certifier {
  Certifier(const LeafSurface& l, const LeafTwins& t, double floor_error, double lower_bound)
      : leaves(l), twins(t), floor(floor_error), measured(lower_bound) {}
  const LeafSurface& leaves;
  const LeafTwins& twins;
  double floor;
  double measured;  // largest exact distance found (the measured error above the floor, sub-triangle corners)
  uint32_t hint = kNone;
  OverlayScratch scratch;
  std::vector<uint32_t> candidates;  // the one-triangle bound's

  double target() const { return std::max(floor, measured * (1 + kCertifySlack)); }
  // Exact distance of p to the leaves; *nearest gets the nearest leaf triangle.
  double distance(DVec3 p, uint32_t* nearest) {
    const double d = std::sqrt(leaves.tree.nearest_distance_squared(p, &hint));
    measured = std::max(measured, d);
    if (nearest) *nearest = hint;
    return d;
  }
  // An upper bound of the distance from every point of the triangle c (corner distances d)
  // to the leaves; `start`: a leaf triangle whose projection may meet it.
  double certify(const DVec3 c[3], const double d[3], uint32_t start, uint32_t depth);
};

// Steps of a walk in a sub-triangle's plane (walk_to_projection) before the nearest search
// takes over: a top-level triangle of the 1M sphere is ~40 leaf triangles across; a walk that
// long is still cheaper than a tree search, and folds end a walk early anyway.
constexpr int kMaxPlaneWalkSteps = 128;

// The leaf triangle whose projection onto the frame's plane contains (pu, pv): a visibility
// walk in the frame from `from`, crossing the first edge whose line has the point outside,
// never straight back; kNone after kMaxPlaneWalkSteps or at a border, fold or edge-on triangle.
uint32_t walk_to_projection(const LeafSurface& leaves, const OverlayFrame& f, uint32_t from, double pu, double pv) {
  uint32_t t = from, previous = kNone;
  for (int step = 0; step < kMaxPlaneWalkSteps && t != kNone; ++step) {
    Projected q[3];
    for (int j = 0; j < 3; ++j) q[j] = project(f, leaves.tree.corner(t, j));
    const double area = (q[1].u - q[0].u) * (q[2].v - q[0].v) - (q[1].v - q[0].v) * (q[2].u - q[0].u);
    if (area == 0) return kNone;
    const double sign = area > 0 ? 1 : -1;
    int out = -1;
    bool outside = false;
    for (int j = 0; j < 3 && out < 0; ++j) {
      const Projected& a = q[j];
      const Projected& b = q[(j + 1) % 3];
      if (sign * ((b.u - a.u) * (pv - a.v) - (b.v - a.v) * (pu - a.u)) < 0) {
        outside = true;
        if (leaves.neighbour[3 * size_t(t) + size_t(j)] != previous) out = j;
      }
    }
    if (!outside) return t;
    if (out < 0) return kNone;  // only the way back leads on: a fold
    previous = t;
    t = leaves.neighbour[3 * size_t(t) + size_t(out)];
  }
  return kNone;
}

// Most leaf triangles the one-triangle bound tries on a sub-triangle whose other bounds fail
// (those in the box of its corner 0 widened by the target): a sub-triangle at a fold or a
// border is small (split) and its target a few leaf triangles wide; a larger box is skipped.
constexpr size_t kOneTriangleCandidates = 64;

double Certifier::certify(const DVec3 c[3], const double d[3], uint32_t start, uint32_t depth) {
  constexpr double inf = std::numeric_limits<double>::infinity();
  const double lipschitz = std::max({d[0], d[1], d[2]}) + covering_radius(c);
  if (lipschitz <= target()) return lipschitz;
  OverlayFrame frame;
  const bool framed = make_overlay_frame(c, &frame);
  // The overlay floods from the leaf triangle under the centroid (or, where no walk reaches
  // it, from the start).
  if (framed) {
    const uint32_t under = walk_to_projection(leaves, frame, start, 1.0 / 3, 1.0 / 3);
    if (under != kNone) start = under;
  }
  DVec3 argmax{};
  const double overlay =
      framed ? overlay_bound(leaves, twins, frame, depth == 0 ? c : nullptr, start, measured, scratch, &argmax) : inf;
  // The overlay's bound is attained (vertically, or by the distance to one leaf triangle) at
  // argmax: where it is above the target, the exact distance there usually raises the target
  // to it (the continuous maximum found) instead of splitting in search of a tighter bound.
  if (overlay > target() && overlay < inf) distance(argmax, nullptr);
  double best = std::min(lipschitz, overlay);
  if (best <= target()) return best;
  // One leaf triangle F within the target of all three corners: d(·, F) is convex, so F bounds
  // the whole sub-triangle (what proves small sub-triangles at a fold or a border). Every
  // such F lies in the box of corner 0 widened by the target: all of them are tried (up to
  // kOneTriangleCandidates; more, and the proof is not tried), so verify, which searches the
  // same box at a threshold at least the stored error, finds the same F.
  {
    const double r = target();
    candidates.clear();
    leaves.tree.triangles_in_box({c[0].x - r, c[0].y - r, c[0].z - r}, {c[0].x + r, c[0].y + r, c[0].z + r}, &candidates, {},
                                 0, 0, kOneTriangleCandidates);
    if (candidates.size() <= kOneTriangleCandidates)
      for (uint32_t t : candidates) {
        const PreparedTriangle tri = prepare_triangle(leaves.tree.corner(t, 0), leaves.tree.corner(t, 1), leaves.tree.corner(t, 2));
        double worst2 = 0;
        for (int j = 0; j < 3 && worst2 < best * best; ++j) worst2 = std::max(worst2, prepared_triangle_distance_squared(c[j], tri));
        best = std::min(best, std::sqrt(worst2));
      }
  }
  if (best <= target() || depth >= kCertifyMaxDepth) return best;
  const DVec3 m[3] = {mid3(c[0], c[1]), mid3(c[1], c[2]), mid3(c[2], c[0])};
  const double dm[3] = {distance(m[0], nullptr), distance(m[1], nullptr), distance(m[2], nullptr)};
  const DVec3 child[4][3] = {{c[0], m[0], m[2]}, {m[0], c[1], m[1]}, {m[2], m[1], c[2]}, {m[1], m[2], m[0]}};
  const double child_d[4][3] = {{d[0], dm[0], dm[2]}, {dm[0], d[1], dm[1]}, {dm[2], dm[1], d[2]}, {dm[1], dm[2], dm[0]}};
  // The children's centroids in this triangle's frame (they share its plane).
  const double centroid_uv[4][2] = {{1.0 / 6, 1.0 / 6}, {2.0 / 3, 1.0 / 6}, {1.0 / 6, 2.0 / 3}, {1.0 / 3, 1.0 / 3}};
  double bound = 0;
  for (int k = 0; k < 4 && bound < best; ++k) {
    // The child's start: the leaf triangle under its centroid, walked to over the leaves from
    // this triangle's start; where the walk fails (a fold), the leaf triangle nearest to it.
    uint32_t child_start = framed ? walk_to_projection(leaves, frame, start, centroid_uv[k][0], centroid_uv[k][1]) : kNone;
    if (child_start == kNone) {
      const DVec3 centroid{(child[k][0].x + child[k][1].x + child[k][2].x) / 3, (child[k][0].y + child[k][1].y + child[k][2].y) / 3,
                           (child[k][0].z + child[k][1].z + child[k][2].z) / 3};
      distance(centroid, &child_start);
    }
    bound = std::max(bound, certify(child[k], child_d[k], child_start, depth + 1));
  }
  return std::min(best, bound);
}


}  // namespace

LeafTwins build_leaf_twins(const LeafSurface& leaves, const WeldedMesh& welded, ThreadPool& pool) {
  const TriangleDistanceTree& tree = leaves.tree;
  const size_t n = tree.triangle_count(), vertices = welded.weld.size();
  const std::vector<uint32_t>& weld = welded.weld;
  auto wid = [&](size_t t, int j) { return weld[tree.triangle_corner_id(uint32_t(t), j)]; };
  // Triangles by welded vertex (counting sort, each list in ascending id order).
  std::vector<uint32_t> first(vertices + 1, 0);
  for (size_t t = 0; t < n; ++t)
    for (int j = 0; j < 3; ++j) ++first[wid(t, j) + 1];
  for (size_t w = 0; w < vertices; ++w) first[w + 1] += first[w];
  std::vector<uint32_t> triangles(3 * n);
  {
    std::vector<uint32_t> fill(first.begin(), first.end() - 1);
    for (size_t t = 0; t < n; ++t)
      for (int j = 0; j < 3; ++j) triangles[fill[wid(t, j)]++] = uint32_t(t);
  }
  auto has_corner = [&](uint32_t t, uint32_t w) { return wid(t, 0) == w || wid(t, 1) == w || wid(t, 2) == w; };
  LeafTwins out;
  out.twin.assign(3 * n, 3);
  for_chunks(&pool, n, kTwinChunk, [&](size_t begin, size_t end) {
    for (size_t t = begin; t < end; ++t)
      for (int j = 0; j < 3; ++j) {
        const uint32_t g = leaves.neighbour[3 * t + j];
        if (g == kNone) continue;
        const uint32_t u = wid(t, j), w = wid(t, (j + 1) % 3);
        // Only an edge of exactly two triangles (the rule verify pairs leaf edges by).
        uint32_t sharing = 0;
        for (uint32_t i = first[u]; i < first[u + 1]; ++i)
          if (triangles[i] != t && has_corner(triangles[i], w) && (i == first[u] || triangles[i] != triangles[i - 1])) ++sharing;
        if (sharing != 1) continue;
        for (int k = 0; k < 3; ++k)
          if (wid(g, k) == w && wid(g, (k + 1) % 3) == u && leaves.neighbour[3 * size_t(g) + k] == t) out.twin[3 * t + j] = uint8_t(k);
      }
  });
  return out;
}

float certified_leaf_deviation(const LeafSurface& leaves, const LeafTwins& twins, const Mesh& mesh,
                               const std::vector<const TriangleSet*>& simplified, float floor, double lower) {
  if (leaves.tree.empty()) return floor;
  auto vertex = [&](uint32_t v) {
    return DVec3{mesh.positions[3 * size_t(v)], mesh.positions[3 * size_t(v) + 1], mesh.positions[3 * size_t(v) + 2]};
  };
  // `lower` (an exact distance of some point of these triangles, or 0) starts the target only
  // above the floor: below it the floor is the target anyway.
  const double start_max = std::isfinite(floor) && lower > double(floor) ? lower : 0.0;
  Certifier cert(leaves, twins, std::isfinite(floor) ? double(floor) : 0.0, start_max);
  double bound = 0;
  for (const TriangleSet* set : simplified)
    for (size_t t = 0; t < set->triangle_count(); ++t) {
      const uint32_t* tri = &set->corners[3 * t];
      const DVec3 c[3] = {vertex(tri[0]), vertex(tri[1]), vertex(tri[2])};
      // A simplified corner that was not moved (vertex_placement.cpp) is a leaf vertex (distance
      // 0; its leaf triangle starts the overlay); a moved one is measured.
      auto leaf_triangle = [&](uint32_t v) { return v < leaves.leaf_vertex_count ? leaves.vertex_triangle[v] : kNone; };
      double d[3];
      for (int j = 0; j < 3; ++j) d[j] = leaf_triangle(tri[j]) != kNone ? 0.0 : cert.distance(c[j], nullptr);
      uint32_t start = leaf_triangle(tri[0]);
      if (start == kNone) cert.distance(c[0], &start);
      bound = std::max(bound, cert.certify(c, d, start, 0));
    }
  return std::max(floor, round_up_to_float(std::max(bound, start_max)));
}

}  // namespace vgeo::build_detail
