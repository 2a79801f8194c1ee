// A simplification's own error, measured (spec/dag.md §Error).
//
// The stored error must cover every lattice point lib/vgeo/verify samples (ERROR_BOUND), so the
// builder measures at every point of the kErrorLatticeSubdivisions lattice of the simplified
// triangles and takes the exact nearest-triangle distance of lib/vgeo/core/surface_distance.h
// (same point coordinates, same point_triangle_distance_squared). What is cheap here is only
// *how* the maximum is found: the result is max(estimate, max over points of min over
// triangles), so a point whose distance to *some* input triangle is already ≤ the running
// maximum cannot change it and needs no nearest search (the early break of exact Hausdorff
// distance algorithms). Candidates are tried first (the last nearest triangle, then the
// input triangles incident to the simplified triangle's corners, nearest corner first);
// only a point farther than the running maximum from all of them gets the exact tree search.
#include <algorithm>
#include <cmath>
#include <limits>

#include "vgeo/dag/build_internal.h"
#include "vgeo/core/surface_distance.h"

namespace vgeo::build_detail {

namespace {

// Empty slot of the vertex hash (not a valid vertex id: meshes have < 2^32 - 1 vertices).
constexpr uint32_t kNoVertex = ~uint32_t(0);

// Uniform grid over triangle boxes (cells of the mean largest box extent, at most
// kGridCellsPerTriangle cells per triangle in total): for_each_near lists every triangle whose
// box may lie within r of a point (a triangle in several cells is listed once per cell).
class TriangleGrid {
 public:
  // Total cells ≤ this × triangles: a group is a surface patch, so most cells hold a few
  // triangles and memory stays linear in the group.
  static constexpr double kGridCellsPerTriangle = 4.0;
  // Above this many cells a query is not worth it: the caller's exact scan is as cheap.
  static constexpr size_t kMaxQueryCells = 64;
  // Grid entries per triangle above which the grid is not built (see the constructor); a
  // surface patch has 1–4 (boxes of about the cell size).
  static constexpr size_t kMaxItemsPerTriangle = 16;

  TriangleGrid() = default;
  TriangleGrid(const DVec3* box, uint32_t n) {
    const double inf = std::numeric_limits<double>::infinity();
    DVec3 lo{inf, inf, inf}, hi{-inf, -inf, -inf};
    double mean_extent = 0;
    for (uint32_t t = 0; t < n; ++t) {
      const DVec3 a = box[2 * size_t(t)], b = box[2 * size_t(t) + 1];
      lo = {std::min(lo.x, a.x), std::min(lo.y, a.y), std::min(lo.z, a.z)};
      hi = {std::max(hi.x, b.x), std::max(hi.y, b.y), std::max(hi.z, b.z)};
      mean_extent += std::max({b.x - a.x, b.y - a.y, b.z - a.z});
    }
    mean_extent /= std::max<uint32_t>(n, 1);
    const double extent[3] = {hi.x - lo.x, hi.y - lo.y, hi.z - lo.z};
    double cell = mean_extent;
    const double cap = kGridCellsPerTriangle * std::max<uint32_t>(n, 1);
    for (;;) {
      double cells = 1;
      for (int k = 0; k < 3; ++k) {
        dims_[k] = cell > 0 && std::isfinite(extent[k] / cell) ? size_t(std::min(extent[k] / cell, cap)) + 1 : 1;
        cells *= double(dims_[k]);
      }
      if (cells <= cap) break;
      cell = cell > 0 ? cell * std::cbrt(cells / cap) * 1.01 : 1.0;
    }
    origin_ = lo;
    inv_cell_ = cell > 0 ? 1.0 / cell : 0.0;
    const size_t cells = dims_[0] * dims_[1] * dims_[2];
    first_.assign(cells + 1, 0);
    auto range = [&](const DVec3& a, const DVec3& b, size_t r[3][2]) {
      const double alo[3] = {a.x, a.y, a.z}, ahi[3] = {b.x, b.y, b.z};
      for (int k = 0; k < 3; ++k) r[k][0] = coord(alo[k], k), r[k][1] = coord(ahi[k], k);
    };
    auto each_cell = [&](const DVec3& a, const DVec3& b, auto&& fn) {
      size_t r[3][2];
      range(a, b, r);
      for (size_t z = r[2][0]; z <= r[2][1]; ++z)
        for (size_t y = r[1][0]; y <= r[1][1]; ++y)
          for (size_t x = r[0][0]; x <= r[0][1]; ++x) fn((z * dims_[1] + y) * dims_[0] + x);
    };
    // A few huge triangles among tiny ones could each span most cells (items up to ~n^(5/3)):
    // above kMaxItemsPerTriangle × n entries the grid stays empty and every uncovered point
    // takes the exact scan instead (same result, bounded memory).
    size_t items = 0;
    for (uint32_t t = 0; t < n; ++t) {
      size_t r[3][2];
      range(box[2 * size_t(t)], box[2 * size_t(t) + 1], r);
      items += (r[0][1] - r[0][0] + 1) * (r[1][1] - r[1][0] + 1) * (r[2][1] - r[2][0] + 1);
    }
    if (items > kMaxItemsPerTriangle * size_t(n)) {
      first_.assign(cells + 1, 0);
      return;
    }
    for (uint32_t t = 0; t < n; ++t) each_cell(box[2 * size_t(t)], box[2 * size_t(t) + 1], [&](size_t c) { ++first_[c + 1]; });
    for (size_t c = 0; c < cells; ++c) first_[c + 1] += first_[c];
    items_.resize(first_[cells]);
    std::vector<uint32_t> fill(first_.begin(), first_.end() - 1);
    for (uint32_t t = 0; t < n; ++t)
      each_cell(box[2 * size_t(t)], box[2 * size_t(t) + 1], [&](size_t c) { items_[fill[c]++] = t; });
  }

  // Calls fn(t) for the triangles of the cells overlapping the box of radius r around p
  // until fn returns false. Lists nothing when that box spans more than kMaxQueryCells.
  template <class Fn>
  void for_each_near(DVec3 p, double r, Fn&& fn) const {
    const double plo[3] = {p.x - r, p.y - r, p.z - r}, phi[3] = {p.x + r, p.y + r, p.z + r};
    size_t lo[3], hi[3], count = 1;
    for (int k = 0; k < 3; ++k) {
      lo[k] = coord(plo[k], k), hi[k] = coord(phi[k], k);
      count *= hi[k] - lo[k] + 1;
    }
    if (count > kMaxQueryCells) return;
    for (size_t z = lo[2]; z <= hi[2]; ++z)
      for (size_t y = lo[1]; y <= hi[1]; ++y)
        for (size_t x = lo[0]; x <= hi[0]; ++x) {
          const size_t c = (z * dims_[1] + y) * dims_[0] + x;
          for (uint32_t i = first_[c]; i < first_[c + 1]; ++i)
            if (!fn(items_[i])) return;
        }
  }

 private:
  // Monotonic in v, clamped to the grid (NaN → cell 0; only finite input reaches here).
  size_t coord(double v, int axis) const {
    const double o = axis == 0 ? origin_.x : axis == 1 ? origin_.y : origin_.z;
    const double f = (v - o) * inv_cell_;
    if (!(f > 0)) return 0;
    return size_t(std::min(f, double(dims_[axis] - 1)));
  }
  DVec3 origin_;
  double inv_cell_ = 0;
  size_t dims_[3] = {1, 1, 1};
  std::vector<uint32_t> first_, items_;
};

// Max over the lattice points of `simplified` of the squared distance to `input`'s
// triangles, or any value ≤ floor_d2 when that maximum is ≤ floor_d2.
double max_lattice_d2_above(const Mesh& mesh, const TriangleSet& input, const TriangleSet& simplified,
                            double floor_d2) {
  const size_t n = input.triangle_count();
  if (n == 0 || simplified.triangle_count() == 0) return 0.0;
  const float* pos = mesh.positions.data();
  auto vertex = [&](uint32_t v) { return DVec3{pos[3 * size_t(v)], pos[3 * size_t(v) + 1], pos[3 * size_t(v) + 2]}; };
  // Per input triangle its bounding box (a point farther than the running maximum from the
  // box is farther from the triangle, so the exact distance is not needed to reject it) and
  // its prepared form (edge vectors and normal once, not once per point).
  std::vector<DVec3> box(2 * n);
  std::vector<PreparedTriangle> prepared(n);
  for (size_t t = 0; t < n; ++t) {
    const DVec3 c[3] = {vertex(input.corners[3 * t]), vertex(input.corners[3 * t + 1]), vertex(input.corners[3 * t + 2])};
    box[2 * t] = {std::min({c[0].x, c[1].x, c[2].x}), std::min({c[0].y, c[1].y, c[2].y}),
                  std::min({c[0].z, c[1].z, c[2].z})};
    box[2 * t + 1] = {std::max({c[0].x, c[1].x, c[2].x}), std::max({c[0].y, c[1].y, c[2].y}),
                      std::max({c[0].z, c[1].z, c[2].z})};
    prepared[t] = prepare_triangle(c[0], c[1], c[2]);
  }
  // Input triangles incident to each input vertex (ascending triangle order per vertex):
  // vertex ids → dense local ids by open addressing (load ≤ 1/2), then a counting sort.
  size_t vertex_slots = 16;
  int vertex_shift = 28;  // hash = top log2(vertex_slots) bits of a 32-bit multiplicative hash
  while (vertex_slots < 6 * n) vertex_slots <<= 1, --vertex_shift;
  std::vector<uint32_t> slot_vertex(vertex_slots, kNoVertex), slot_local(vertex_slots);
  auto slot_of = [&](uint32_t v) {
    size_t h = size_t(uint32_t(v * 0x9E3779B1u) >> vertex_shift);
    while (slot_vertex[h] != kNoVertex && slot_vertex[h] != v) h = (h + 1) & (vertex_slots - 1);
    return h;
  };
  std::vector<uint32_t> local_of_corner(3 * n);
  uint32_t local_count = 0;
  for (size_t i = 0; i < 3 * n; ++i) {
    const size_t h = slot_of(input.corners[i]);
    if (slot_vertex[h] == kNoVertex) slot_vertex[h] = input.corners[i], slot_local[h] = local_count++;
    local_of_corner[i] = slot_local[h];
  }
  std::vector<uint32_t> ring_first(size_t(local_count) + 1, 0), ring(3 * n);
  for (uint32_t l : local_of_corner) ++ring_first[l + 1];
  for (uint32_t l = 0; l < local_count; ++l) ring_first[l + 1] += ring_first[l];
  {
    std::vector<uint32_t> fill(ring_first.begin(), ring_first.end() - 1);
    for (size_t i = 0; i < 3 * n; ++i) ring[fill[local_of_corner[i]]++] = uint32_t(i / 3);
  }

  // True iff triangle t is within `threshold` of p; `d` gets its squared distance or, when
  // the box alone rejects it, the box's (a lower bound).
  auto within = [&](DVec3 p, uint32_t t, double threshold, double& d) {
    const DVec3 lo = box[2 * size_t(t)], hi = box[2 * size_t(t) + 1];
    const double dx = std::max({lo.x - p.x, 0.0, p.x - hi.x}), dy = std::max({lo.y - p.y, 0.0, p.y - hi.y}),
                 dz = std::max({lo.z - p.z, 0.0, p.z - hi.z});
    d = dx * dx + dy * dy + dz * dz;
    if (d > threshold) return false;
    return prepared_triangle_within_squared(p, prepared[t], threshold, &d);
  };
  // Exact minimum over every input triangle (box-rejected against the best so far), for
  // the few points that no candidate covers; `nearest` gets its argmin.
  auto exact_min = [&](DVec3 p, uint32_t& nearest) {
    double best = std::numeric_limits<double>::infinity();
    for (uint32_t t = 0; t < n; ++t) {
      const DVec3 lo = box[2 * size_t(t)], hi = box[2 * size_t(t) + 1];
      const double dx = std::max({lo.x - p.x, 0.0, p.x - hi.x}), dy = std::max({lo.y - p.y, 0.0, p.y - hi.y}),
                   dz = std::max({lo.z - p.z, 0.0, p.z - hi.z});
      if (dx * dx + dy * dy + dz * dz >= best) continue;
      const double d = prepared_triangle_distance_squared(p, prepared[t]);
      if (d < best) best = d, nearest = t;
    }
    return best;
  };
  TriangleGrid grid;  // built on the first point the corner rings do not cover
  bool grid_built = false;
  double best2 = 0.0;
  uint32_t hint = 0;
  // Candidate rings: input triangles incident to each corner of the simplified triangle
  // (ranges of `ring`).
  const uint32_t* ring_begin[3] = {};
  const uint32_t* ring_end[3] = {};

  // `first_ring`: the corner nearest to p (its ring is tried first).
  auto visit = [&](DVec3 p, int first_ring) {
    const double threshold = std::max(best2, floor_d2);
    double d;  // `within` reports a distance or a lower bound; only the verdict is used here
    if (within(p, hint, threshold, d)) return;
    for (int r = 0; r < 3; ++r)
      for (const uint32_t* it = ring_begin[(first_ring + r) % 3]; it != ring_end[(first_ring + r) % 3]; ++it)
        if (within(p, *it, threshold, d)) {
          hint = *it;
          return;
        }
    if (!grid_built) {
      grid = TriangleGrid(box.data(), n);
      grid_built = true;
    }
    bool covered = false;
    grid.for_each_near(p, std::sqrt(threshold), [&](uint32_t t) {
      covered = within(p, t, threshold, d);
      if (covered) hint = t;
      return !covered;
    });
    if (covered) return;
    // No triangle within the running maximum: p raises it to its exact minimum.
    const double exact = exact_min(p, hint);
    if (exact > best2) best2 = exact;
  };

  // Edges already sampled (open addressing over (i0 << 32 | i1), load ≤ 1/2): the points of
  // an edge shared by two simplified triangles are bit-identical, so the second visit cannot
  // change the maximum and is skipped.
  size_t edge_slots = 16;
  int edge_shift = 60;  // hash = top log2(edge_slots) bits of a multiplicative hash
  while (edge_slots < 6 * simplified.triangle_count()) edge_slots <<= 1, --edge_shift;
  std::vector<uint64_t> edge_seen(edge_slots, ~uint64_t(0));
  auto first_visit = [&](uint64_t key) {
    size_t h = size_t((key * 0x9E3779B97F4A7C15ull) >> edge_shift);
    while (edge_seen[h] != ~uint64_t(0)) {
      if (edge_seen[h] == key) return false;
      h = (h + 1) & (edge_slots - 1);
    }
    edge_seen[h] = key;
    return true;
  };
  const uint32_t s = kErrorLatticeSubdivisions ? kErrorLatticeSubdivisions : 1;
  for (size_t t = 0; t < simplified.triangle_count(); ++t) {
    const uint32_t* tri = &simplified.corners[3 * t];
    for (int j = 0; j < 3; ++j) {
      // A corner that is not an input vertex (cannot happen with either backend) has no ring.
      const size_t h = slot_of(tri[j]);
      const uint32_t l = slot_vertex[h] == kNoVertex ? 0 : slot_local[h];
      ring_begin[j] = ring.data() + (slot_vertex[h] == kNoVertex ? 0 : ring_first[l]);
      ring_end[j] = ring.data() + (slot_vertex[h] == kNoVertex ? 0 : ring_first[l + 1]);
    }
    DVec3 a = vertex(tri[0]), b = vertex(tri[1]), c = vertex(tri[2]);
    // Corner points are skipped: a simplified corner is an input vertex (both backends only
    // remove vertices), i.e. a corner of an input triangle, where
    // point_triangle_distance_squared returns exactly 0 (ap = 0 in both branches), which
    // cannot raise a maximum that starts at 0. Edge and interior points have the coordinates
    // for_each_lattice_point computes (edges from the smaller vertex id), so every point is
    // bit-identical to the one lib/vgeo/verify samples. Points of shared edges are visited once
    // (first_visit).
    for (int j = 0; j < 3; ++j) {
      const int k = (j + 1) % 3;
      const bool forward = tri[j] <= tri[k];
      uint32_t i0 = forward ? tri[j] : tri[k], i1 = forward ? tri[k] : tri[j];
      if (!first_visit((uint64_t(i0) << 32) | i1)) continue;
      DVec3 e0 = vertex(i0), e1 = vertex(i1);
      for (uint32_t i = 1; i < s; ++i) {
        double f = double(i) / s;
        bool near_e0 = 2 * i <= s;
        visit(DVec3{e0.x + (e1.x - e0.x) * f, e0.y + (e1.y - e0.y) * f, e0.z + (e1.z - e0.z) * f},
              near_e0 == forward ? j : k);
      }
    }
    for (uint32_t u = 1; u < s; ++u)
      for (uint32_t w = 1; u + w < s; ++w) {
        double bu = double(u) / s, bw = double(w) / s, bv = 1.0 - bu - bw;
        int first_ring = bv >= bu && bv >= bw ? 0 : (bu >= bw ? 1 : 2);
        visit(DVec3{a.x * bv + b.x * bu + c.x * bw, a.y * bv + b.y * bu + c.y * bw, a.z * bv + b.z * bu + c.z * bw},
              first_ring);
      }
  }
  return best2;
}

}  // namespace

float measured_simplification_error(const Mesh& mesh, const TriangleSet& input, const TriangleSet& simplified) {
  return round_up_to_float(std::sqrt(max_lattice_d2_above(mesh, input, simplified, 0.0)));
}

float simplification_error(const Mesh& mesh, const TriangleSet& input, const TriangleSet& simplified,
                           float estimate) {
  // A float squared is exact in double (24-bit mantissa → 48 bits), and sqrt and the
  // rounding up are monotonic, so any measured value ≤ estimate² rounds to ≤ estimate: the
  // search may stop below the floor without changing max(estimate, measured).
  double floor_d2 = std::isfinite(estimate) && estimate > 0 ? double(estimate) * double(estimate) : 0.0;
  float measured = round_up_to_float(std::sqrt(max_lattice_d2_above(mesh, input, simplified, floor_d2)));
  return std::max(estimate, measured);
}

}  // namespace vgeo::build_detail
