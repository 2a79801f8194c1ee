// Certified bound (ERROR_CERTIFIED, the `certified_bound` check; spec/invariants.md §5
// "Certified bound"). Samples (ERROR_BOUND) only bound the deviation from below; this proves
// each non-leaf cluster's stored lod_error is an upper bound of the *continuous* one-sided
// deviation of its triangles from the leaves: each cluster triangle is covered by edge-midpoint
// sub-triangles (at most kCertifyMaxDepth splits), each proven within the stored error by the
// 1-Lipschitz bound, by the overlay of the leaf triangles projected onto its plane, or by one
// leaf triangle near all its corners. Written independently of the builder's certification
// (lib/vgeo/dag/leaf_certify.cpp): only lib/vgeo/core's distance tree is shared. Opt-in (not in
// kCheckAll): vgeo's default build stores the lattice maximum, which this check does not
// promise to prove; `vgeo build --error-bound certified` stores what it proves.
//
// Based on: branch-and-bound over a simplex with a Lipschitz bound (Piyavskii, 1972) and the
// overlay of two triangulated height fields, as spec/invariants.md §5 states them.
#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstring>
#include <string>
#include <unordered_set>

#include "vgeo/core/surface_distance.h"
#include "vgeo/core/thread_pool.h"
#include "vgeo/verify/verify_detail.h"

namespace vgeo::verify_detail {

namespace {

// Rounding margin of the overlay's crossing test, in units of T's barycentric coordinates
// (spec/invariants.md §5: a patch boundary edge within it of T counts as crossing T).
constexpr double kCrossingMargin = 1e-9;
// Below this fraction of |e1|²|e2|², T's Gram determinant makes the projection ill-conditioned:
// no overlay proof (spec/invariants.md §5).
constexpr double kMinGram = 1e-12;
// A projected leaf triangle's orientation counts only when the sine of its projected angle
// exceeds this (rounding is ~1e-16 relative; an edge-on one proves nothing).
constexpr double kMinSine = 1e-9;
// The overlay needs one piece with an interior (spec/invariants.md §5): twice its area in the
// unit triangle's coordinates above this; rounding slivers are ~1e-16.
constexpr double kMinPieceArea = 1e-12;

DVec3 minus(DVec3 a, DVec3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
double inner(DVec3 a, DVec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }

// Radius within which every point of triangle c has a corner (spec/invariants.md §5): with an
// angle of 90° or more at corner k, the largest distance from the far edge's points equidistant
// to corner k and that edge's ends; otherwise the circumradius.
double corner_cover_radius(const std::array<DVec3, 3>& c) {
  for (int k = 0; k < 3; ++k) {
    const DVec3 p = c[size_t(k)], a = c[size_t((k + 1) % 3)], b = c[size_t((k + 2) % 3)];
    const double ea = inner(minus(a, p), minus(a, p)), eb = inner(minus(b, p), minus(b, p));
    const double ab = inner(minus(b, a), minus(b, a));
    if (!(ab >= ea + eb)) continue;  // corner k is not the (non-acute) corner opposite the longest edge
    if (ab == 0) return 0;
    const double len = std::sqrt(ab);
    double r = 0;
    // End a: the point a + s·(b - a)/len with |point - a| = |point - p|: s = ea / (2 (p - a)·û).
    const double pa = inner(minus(p, a), minus(b, a)) / len, pb = inner(minus(p, b), minus(a, b)) / len;
    if (ea > 0) r = std::max(r, pa > 0 ? ea / (2 * pa) : std::sqrt(ea));
    if (eb > 0) r = std::max(r, pb > 0 ? eb / (2 * pb) : std::sqrt(eb));
    return r;
  }
  const DVec3 u = minus(c[1], c[0]), v = minus(c[2], c[0]), w = minus(c[2], c[1]);
  const DVec3 n{u.y * v.z - u.z * v.y, u.z * v.x - u.x * v.z, u.x * v.y - u.y * v.x};
  return std::sqrt(inner(u, u)) * std::sqrt(inner(v, v)) * std::sqrt(inner(w, w)) / (2 * std::sqrt(inner(n, n)));
}

struct SubTriangle {
  std::array<DVec3, 3> c;
  std::array<double, 3> d;  // exact distances of the corners to the leaves
  uint32_t depth;
};

// Whether segment a→b meets {x ≥ -m, y ≥ -m, x + y ≤ 1 + m} (m = kCrossingMargin).
bool crosses_unit_triangle(const double a[2], const double b[2]) {
  double t0 = 0, t1 = 1;
  auto keep = [&](double p0, double dp, double limit) {  // keep the part with p0 + t·dp ≤ limit
    if (dp == 0) return p0 <= limit;
    const double t = (limit - p0) / dp;
    if (dp > 0) t1 = std::min(t1, t);
    else t0 = std::max(t0, t);
    return t0 <= t1;
  };
  return keep(-a[0], -(b[0] - a[0]), kCrossingMargin) && keep(-a[1], -(b[1] - a[1]), kCrossingMargin) &&
         keep(a[0] + a[1], (b[0] - a[0]) + (b[1] - a[1]), 1 + kCrossingMargin);
}

// The leaf surface's edge pairing, built here from the leaf triangles' float corners (not
// the builder's adjacency): corner keys are position bits; an edge a→b of one triangle is
// paired with an edge b→a of another when each of the two directed edges occurs exactly once.
struct LeafPairing {
  std::vector<uint32_t> across;  // 3 per leaf triangle (tree id): the paired triangle, or ~0u
};

LeafPairing pair_leaf_edges(const TriangleDistanceTree& leaves) {
  const uint32_t n = leaves.triangle_count();
  // Vertex ids: corners sorted by their position bits.
  struct CornerKey {
    std::array<uint32_t, 3> bits;
    uint32_t corner;  // 3·triangle + j
  };
  std::vector<CornerKey> keys(3 * size_t(n));
  for (uint32_t t = 0; t < n; ++t)
    for (int j = 0; j < 3; ++j) {
      CornerKey& k = keys[3 * size_t(t) + size_t(j)];
      std::memcpy(k.bits.data(), leaves.triangle_corner_floats(t, j), 12);
      k.corner = 3 * t + uint32_t(j);
    }
  std::sort(keys.begin(), keys.end(), [](const CornerKey& a, const CornerKey& b) {
    return a.bits != b.bits ? a.bits < b.bits : a.corner < b.corner;
  });
  std::vector<uint32_t> vertex(keys.size());
  uint32_t next_id = 0;
  for (size_t i = 0; i < keys.size(); ++i) {
    if (i > 0 && keys[i].bits != keys[i - 1].bits) ++next_id;
    vertex[keys[i].corner] = next_id;
  }
  // Directed edges (from, to, corner), sorted by the undirected pair then direction.
  struct Directed {
    uint64_t pair;  // min id << 32 | max id
    uint32_t forward, corner;
  };
  std::vector<Directed> edges(keys.size());
  for (uint32_t c = 0; c < 3 * n; ++c) {
    const uint32_t a = vertex[c], b = vertex[c - c % 3 + (c % 3 + 1) % 3];
    edges[c] = {a < b ? (uint64_t(a) << 32 | b) : (uint64_t(b) << 32 | a), a < b ? 1u : 0u, c};
  }
  std::sort(edges.begin(), edges.end(), [](const Directed& x, const Directed& y) {
    return x.pair != y.pair ? x.pair < y.pair : x.forward != y.forward ? x.forward < y.forward : x.corner < y.corner;
  });
  LeafPairing out;
  out.across.assign(3 * size_t(n), ~0u);
  for (size_t i = 0; i < edges.size();) {
    size_t j = i;
    while (j < edges.size() && edges[j].pair == edges[i].pair) ++j;
    const uint64_t a = edges[i].pair >> 32, b = edges[i].pair & 0xffffffffu;
    if (j == i + 2 && a != b && edges[i].forward != edges[i + 1].forward) {
      out.across[edges[i].corner] = edges[i + 1].corner / 3;
      out.across[edges[i + 1].corner] = edges[i].corner / 3;
    }
    i = j;
  }
  return out;
}

// A sub-triangle's plane coordinates: x ↦ (a, b) with x's projection = c0 + a·e1 + b·e2, and
// its height along the unit normal.
struct PlaneCoords {
  DVec3 origin, e1, e2, normal;
  double a11, a12, a22, gram;
  std::array<double, 3> of(DVec3 x) const {
    const DVec3 r = minus(x, origin);
    const double r1 = inner(e1, r), r2 = inner(e2, r);
    return {(a22 * r1 - a12 * r2) / gram, (a11 * r2 - a12 * r1) / gram, inner(normal, r)};
  }
};

bool plane_coords(const std::array<DVec3, 3>& c, PlaneCoords* p) {
  p->origin = c[0], p->e1 = minus(c[1], c[0]), p->e2 = minus(c[2], c[0]);
  p->a11 = inner(p->e1, p->e1), p->a12 = inner(p->e1, p->e2), p->a22 = inner(p->e2, p->e2);
  p->gram = p->a11 * p->a22 - p->a12 * p->a12;
  if (!(p->gram > kMinGram * p->a11 * p->a22)) return false;
  const DVec3 n{p->e1.y * p->e2.z - p->e1.z * p->e2.y, p->e1.z * p->e2.x - p->e1.x * p->e2.z,
                p->e1.x * p->e2.y - p->e1.y * p->e2.x};
  const double len = std::sqrt(inner(n, n));
  p->normal = {n.x / len, n.y / len, n.z / len};
  return true;
}

// Whether the leaf edge from a to b, one end of which is corner k of the sub-triangle (ka or kb),
// leaves that corner strictly outside the sub-triangle's angle there (spec/invariants.md §5).
bool outside_corner_angle(const std::array<double, 3>& a, const std::array<double, 3>& b, int ka, int kb) {
  if ((ka >= 0) == (kb >= 0)) return false;
  const double du = ka >= 0 ? b[0] - a[0] : a[0] - b[0], dv = ka >= 0 ? b[1] - a[1] : a[1] - b[1];
  const double margin = kCrossingMargin * std::hypot(du, dv);
  const int k = ka >= 0 ? ka : kb;
  if (k == 0) return du < -margin || dv < -margin;
  if (k == 1) return dv < -margin || du + dv > margin;
  return du < -margin || du + dv > margin;
}

// Proves max over the sub-triangle of the distance to the leaves ≤ tau (spec/invariants.md §5):
// the overlay (a patch of paired leaf triangles covering its projection, each piece within tau
// vertically or by distance at its corners), else one leaf triangle within tau of its corners.
class OverlayProver {
 public:
  OverlayProver(const TriangleDistanceTree& leaves, const LeafPairing& pairing) : leaves_(leaves), pairing_(pairing) {}

  // The leaf triangle whose projection contains point (a, b), walked to from `from`; ~0u if none.
  uint32_t walk(const PlaneCoords& plane, uint32_t from, double a, double b) const {
    uint32_t t = from, came_from = ~0u;
    for (int steps = 0; steps < kWalkLimit && t != ~0u; ++steps) {
      std::array<std::array<double, 3>, 3> p;
      for (int j = 0; j < 3; ++j) p[size_t(j)] = plane.of(leaves_.triangle_corner(t, j));
      const double area = (p[1][0] - p[0][0]) * (p[2][1] - p[0][1]) - (p[2][0] - p[0][0]) * (p[1][1] - p[0][1]);
      if (area == 0) return ~0u;
      int exit = -1, outside = 0;
      for (int j = 0; j < 3; ++j) {
        const auto& x = p[size_t(j)];
        const auto& y = p[size_t((j + 1) % 3)];
        const double s = (y[0] - x[0]) * (b - x[1]) - (y[1] - x[1]) * (a - x[0]);
        if ((area > 0 ? s : -s) < 0) {
          ++outside;
          if (exit < 0 && pairing_.across[3 * size_t(t) + size_t(j)] != came_from) exit = j;
        }
      }
      if (outside == 0) return t;
      if (exit < 0) return ~0u;
      came_from = t;
      t = pairing_.across[3 * size_t(t) + size_t(exit)];
    }
    return ~0u;
  }

  bool proves(const SubTriangle& s, double tau, uint32_t start) {
    PlaneCoords plane;
    if (plane_coords(s.c, &plane)) {
      // From the leaf triangle under the centroid (or, where no walk reaches it, the start).
      const uint32_t under = walk(plane, start, 1.0 / 3, 1.0 / 3);
      if (overlay(s, plane, tau, under != ~0u ? under : start)) return true;
      // A patch from another leaf triangle under the centroid (another layer, or one the walk
      // did not reach: a builder may have started elsewhere): up to kOtherStarts of them.
      tried_.assign(patch_.begin(), patch_.end());
      std::sort(tried_.begin(), tried_.end());
      DVec3 lo = s.c[0], hi = s.c[0];
      for (const DVec3& c : s.c)
        lo = {std::min(lo.x, c.x), std::min(lo.y, c.y), std::min(lo.z, c.z)}, hi = {std::max(hi.x, c.x), std::max(hi.y, c.y), std::max(hi.z, c.z)};
      others_.clear();
      leaves_.triangles_in_box({lo.x - tau, lo.y - tau, lo.z - tau}, {hi.x + tau, hi.y + tau, hi.z + tau}, &others_, plane.normal,
                               inner(plane.normal, plane.origin), tau, kOtherCandidates);
      size_t starts = 0;
      for (size_t i = 0; i < others_.size() && i < kOtherCandidates && starts < kOtherStarts; ++i) {
        const uint32_t f = others_[i];
        if (std::binary_search(tried_.begin(), tried_.end(), f) || walk(plane, f, 1.0 / 3, 1.0 / 3) != f) continue;
        ++starts;
        if (overlay(s, plane, tau, f)) return true;
        tried_.insert(tried_.end(), patch_.begin(), patch_.end());
        std::sort(tried_.begin(), tried_.end());
      }
    }
    // One leaf triangle within tau of the three corners (d(·, F) is convex): any such lies in
    // the box of corner 0 widened by tau; all of them are tried.
    near_.clear();
    leaves_.triangles_in_box({s.c[0].x - tau, s.c[0].y - tau, s.c[0].z - tau}, {s.c[0].x + tau, s.c[0].y + tau, s.c[0].z + tau},
                             &near_);
    for (uint32_t f : near_) {
      const DVec3 a = leaves_.triangle_corner(f, 0), b = leaves_.triangle_corner(f, 1), c = leaves_.triangle_corner(f, 2);
      if (point_triangle_distance_squared(s.c[0], a, b, c) <= tau * tau &&
          point_triangle_distance_squared(s.c[1], a, b, c) <= tau * tau &&
          point_triangle_distance_squared(s.c[2], a, b, c) <= tau * tau)
        return true;
    }
    return false;
  }

 private:
  // Walk steps before giving up (a fold can send a walk in circles; a top-level triangle of a
  // 1M-triangle mesh is ~40 leaf triangles across).
  static constexpr int kWalkLimit = 128;
  // After a failed overlay, other leaf triangles under the centroid are tried as starts: at most
  // this many starts, among at most kOtherCandidates leaf triangles within tau of the box and plane.
  static constexpr size_t kOtherStarts = 8;
  static constexpr size_t kOtherCandidates = 256;

  bool overlay(const SubTriangle& s, const PlaneCoords& plane, double tau, uint32_t first) {
    patch_.assign(1, first);
    seen_.clear();
    seen_.insert(first);
    int orientation = 0;
    bool covered_somewhere = false;
    for (size_t next = 0; next < patch_.size(); ++next) {
      const uint32_t t = patch_[next];
      std::array<DVec3, 3> f;
      std::array<std::array<double, 3>, 3> p;
      std::array<int, 3> corner_of{-1, -1, -1};  // which sub-triangle corner each leaf corner is
      for (int j = 0; j < 3; ++j) {
        f[size_t(j)] = leaves_.triangle_corner(t, j);
        p[size_t(j)] = plane.of(f[size_t(j)]);
        for (int k = 0; k < 3; ++k)
          if (s.depth == 0 && f[size_t(j)].x == s.c[size_t(k)].x && f[size_t(j)].y == s.c[size_t(k)].y &&
              f[size_t(j)].z == s.c[size_t(k)].z)
            corner_of[size_t(j)] = k;
      }
      const double ux = p[1][0] - p[0][0], uy = p[1][1] - p[0][1], vx = p[2][0] - p[0][0], vy = p[2][1] - p[0][1];
      const double area = ux * vy - uy * vx;
      if (!(std::abs(area) > kMinSine * std::sqrt((ux * ux + uy * uy) * (vx * vx + vy * vy)))) return false;
      const int sign = area > 0 ? 1 : -1;
      if (orientation == 0) orientation = sign;
      if (sign != orientation) return false;
      // The piece: the unit triangle clipped by the projected leaf triangle's edge lines.
      poly_.assign({{0, 0}, {1, 0}, {0, 1}});
      for (int j = 0; j < 3 && !poly_.empty(); ++j) {
        const auto& a = p[size_t(j)];
        const auto& b = p[size_t((j + 1) % 3)];
        auto inside = [&](const std::array<double, 2>& x) {
          return sign * ((b[0] - a[0]) * (x[1] - a[1]) - (b[1] - a[1]) * (x[0] - a[0]));
        };
        next_.clear();
        for (size_t k = 0; k < poly_.size(); ++k) {
          const auto& x = poly_[k];
          const auto& y = poly_[(k + 1) % poly_.size()];
          const double sx = inside(x), sy = inside(y);
          if (sx >= 0) next_.push_back(x);
          if ((sx >= 0) != (sy >= 0)) {
            const double w = sx / (sx - sy);
            next_.push_back({x[0] + (y[0] - x[0]) * w, x[1] + (y[1] - x[1]) * w});
          }
        }
        poly_.swap(next_);
      }
      if (!poly_.empty()) {
        double doubled_area = 0;  // a piece with an interior, not a point or a sliver
        for (size_t k = 0; k < poly_.size(); ++k)
          doubled_area += poly_[k][0] * poly_[(k + 1) % poly_.size()][1] - poly_[(k + 1) % poly_.size()][0] * poly_[k][1];
        if (std::abs(doubled_area) > kMinPieceArea) covered_somewhere = true;
        for (const auto& x : poly_) {
          // The leaf triangle's height above this piece corner, by its barycentric coordinates
          // in the projected leaf triangle; then, if that is not within tau, the distance.
          const double px = x[0] - p[0][0], py = x[1] - p[0][1];
          const double l1 = (px * vy - py * vx) / area, l2 = (ux * py - uy * px) / area;
          const double h = p[0][2] + l1 * (p[1][2] - p[0][2]) + l2 * (p[2][2] - p[0][2]);
          if (std::abs(h) <= tau) continue;
          const DVec3 q{plane.origin.x + plane.e1.x * x[0] + plane.e2.x * x[1],
                        plane.origin.y + plane.e1.y * x[0] + plane.e2.y * x[1],
                        plane.origin.z + plane.e1.z * x[0] + plane.e2.z * x[1]};
          if (point_triangle_distance_squared(q, f[0], f[1], f[2]) > tau * tau) return false;
        }
      }
      // Every edge whose projection meets the sub-triangle (other than at one of its corners,
      // leaving outward) must be paired; the paired triangle joins the patch.
      for (int j = 0; j < 3; ++j) {
        const auto& a = p[size_t(j)];
        const auto& b = p[size_t((j + 1) % 3)];
        if (!crosses_unit_triangle(a.data(), b.data())) continue;
        if (outside_corner_angle(a, b, corner_of[size_t(j)], corner_of[size_t((j + 1) % 3)])) continue;
        const uint32_t g = pairing_.across[3 * size_t(t) + size_t(j)];
        if (g == ~0u) return false;
        if (seen_.insert(g).second) patch_.push_back(g);
      }
    }
    return covered_somewhere;
  }

  const TriangleDistanceTree& leaves_;
  const LeafPairing& pairing_;
  std::vector<uint32_t> patch_, near_, tried_, others_;
  std::unordered_set<uint32_t> seen_;
  std::vector<std::array<double, 2>> poly_, next_;
};

// Outcome of certifying one cluster at tau.
struct Certificate {
  bool proven = true;
  bool point_beyond = false;  // a sub-triangle corner is farther than tau (a definite violation)
  double distance = 0;        // that corner's distance, or the best bound left at the depth cap
  DVec3 where{};
  uint64_t subtriangles = 0;
};

Certificate certify_cluster(const ClusterDag& dag, const DagCluster& k, const TriangleDistanceTree& leaves,
                            const LeafPairing& pairing, double tau) {
  Certificate out;
  OverlayProver overlay(leaves, pairing);
  uint32_t hint = ~0u;
  auto distance = [&](DVec3 p, uint32_t* nearest) {
    const double d = std::sqrt(leaves.nearest_distance_squared(p, &hint));
    if (nearest) *nearest = hint;
    return d;
  };
  struct Pending {
    SubTriangle s;
    uint32_t start;  // a leaf triangle near it, where its overlay's walk begins
  };
  std::vector<Pending> stack;
  for (uint32_t t = 0; t < k.triangle_count && out.proven; ++t) {
    Pending top;
    top.s.depth = 0;
    for (int j = 0; j < 3; ++j) {
      const float* p = &dag.positions[3 * (size_t(k.vertex_offset) + dag.indices[3 * (size_t(k.triangle_offset) + t) + size_t(j)])];
      top.s.c[size_t(j)] = {p[0], p[1], p[2]};
      top.s.d[size_t(j)] = distance(top.s.c[size_t(j)], j == 0 ? &top.start : nullptr);
    }
    stack.assign(1, top);
    while (!stack.empty() && out.proven) {
      const Pending item = stack.back();
      const SubTriangle& s = item.s;
      stack.pop_back();
      ++out.subtriangles;
      for (int j = 0; j < 3; ++j)
        if (s.d[size_t(j)] > tau) {
          out.proven = false, out.point_beyond = true, out.distance = s.d[size_t(j)], out.where = s.c[size_t(j)];
          break;
        }
      if (!out.proven) break;
      const double lipschitz = std::max({s.d[0], s.d[1], s.d[2]}) + corner_cover_radius(s.c);
      if (lipschitz <= tau || overlay.proves(s, tau, item.start)) continue;
      if (s.depth >= kCertifyMaxDepth) {
        out.proven = false, out.distance = lipschitz;
        out.where = {(s.c[0].x + s.c[1].x + s.c[2].x) / 3, (s.c[0].y + s.c[1].y + s.c[2].y) / 3,
                     (s.c[0].z + s.c[1].z + s.c[2].z) / 3};
        break;
      }
      // Edge midpoints, 0.5·(a + b) per coordinate (spec/invariants.md §5).
      auto half = [](DVec3 a, DVec3 b) { return DVec3{0.5 * (a.x + b.x), 0.5 * (a.y + b.y), 0.5 * (a.z + b.z)}; };
      const DVec3 m01 = half(s.c[0], s.c[1]), m12 = half(s.c[1], s.c[2]), m20 = half(s.c[2], s.c[0]);
      uint32_t near01 = ~0u, near12 = ~0u, near20 = ~0u;
      const double d01 = distance(m01, &near01), d12 = distance(m12, &near12), d20 = distance(m20, &near20);
      const uint32_t depth = s.depth + 1;
      stack.push_back({{{s.c[0], m01, m20}, {s.d[0], d01, d20}, depth}, near01});
      stack.push_back({{{m01, s.c[1], m12}, {d01, s.d[1], d12}, depth}, near01});
      stack.push_back({{{m20, m12, s.c[2]}, {d20, d12, s.d[2]}, depth}, near12});
      stack.push_back({{{m12, m20, m01}, {d12, d20, d01}, depth}, near20});
    }
  }
  return out;
}

}  // namespace

void check_certified_bound(const ClusterDag& dag, const VerifyOptions& options, Sink& sink, CertifiedBoundResult* result) {
  const double max_abs = largest_stored_coordinate(dag);
  // The tolerance of ERROR_BOUND (spec/invariants.md §5): four float ulps of the largest
  // coordinate, which also covers the double rounding of the proofs (~2^-50 relative).
  const double abs_tol = 4.0 * float_ulp(max_abs);
  std::vector<float> leaf_corners = leaf_corner_soup(dag);
  ThreadPool pool(options.threads);
  const TriangleDistanceTree leaves(std::move(leaf_corners), &pool);
  const LeafPairing pairing = pair_leaf_edges(leaves);
  // Clusters in parallel, each on one thread: the verdicts do not depend on the thread count.
  std::vector<Certificate> certificates(dag.clusters.size());
  std::vector<uint8_t> checked(dag.clusters.size(), 0);
  if (!leaves.empty()) {
    std::atomic<size_t> next{0};
    pool.run_on_all([&](unsigned) {
      for (size_t c; (c = next.fetch_add(1)) < dag.clusters.size();) {
        const DagCluster& k = dag.clusters[c];
        if (k.generating_group == kNone) continue;
        checked[c] = 1;
        // NaN proves nothing (no comparison holds: the search would run to the depth cap).
        if (std::isnan(k.lod_error)) {
          certificates[c].proven = false;
          continue;
        }
        certificates[c] = certify_cluster(dag, k, leaves, pairing, double(k.lod_error) + abs_tol);
      }
    });
  }
  for (size_t c = 0; c < dag.clusters.size(); ++c) {
    if (!checked[c]) continue;
    const DagCluster& k = dag.clusters[c];
    const Certificate& cert = certificates[c];
    ++result->clusters;
    result->subtriangles += cert.subtriangles;
    if (cert.proven) continue;
    sink.add("ERROR_CERTIFIED", "certified_bound", "cluster", c,
             std::string(cert.point_beyond ? "a point at distance " + fmt_float(cert.distance) +
                                                 " from the leaves (between the samples) exceeds"
                                           : "no proof within " + std::to_string(kCertifyMaxDepth) + " splits (best bound " +
                                                 fmt_float(cert.distance) + ") that the deviation stays within") +
                 " stored lod_error " + fmt_float(k.lod_error) + " (level " + std::to_string(k.level) + ")",
             {{"bound", cert.distance},
              {"stored", k.lod_error},
              {"tolerance", abs_tol},
              {"subtriangles", double(cert.subtriangles)},
              {"where_x", cert.where.x},
              {"where_y", cert.where.y},
              {"where_z", cert.where.z}});
  }
}

}  // namespace vgeo::verify_detail
