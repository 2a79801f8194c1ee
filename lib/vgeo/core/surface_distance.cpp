#include "vgeo/core/surface_distance.h"

#include <cmath>
#include <limits>
#include <numeric>

namespace vgeo {
namespace {

// Triangles per tree leaf: a few exact tests beat a deeper tree.
constexpr uint32_t kLeafSize = 4;

}  // namespace

double point_triangle_distance_squared(DVec3 p, DVec3 a, DVec3 b, DVec3 c) {
  return prepared_triangle_distance_squared(p, prepare_triangle(a, b, c));
}

bool point_triangle_within_squared(DVec3 p, DVec3 a, DVec3 b, DVec3 c, double threshold, double* d2) {
  return prepared_triangle_within_squared(p, prepare_triangle(a, b, c), threshold, d2);
}

TriangleDistanceTree::TriangleDistanceTree(std::vector<DVec3> corners) : corners_(std::move(corners)) {
  const uint32_t n = uint32_t(corners_.size() / 3);
  order_.resize(n);
  std::iota(order_.begin(), order_.end(), 0u);
  // Build-time only: per triangle its box (lo, hi) and centroid, by axis (x of all
  // triangles, then y, then z) so the median split compares plain doubles.
  std::vector<DVec3> tri_box(2 * size_t(n));
  std::vector<double> centroids(3 * size_t(n));
  for (uint32_t t = 0; t < n; ++t) {
    const DVec3* c = &corners_[3 * size_t(t)];
    tri_box[2 * size_t(t)] = {std::min({c[0].x, c[1].x, c[2].x}), std::min({c[0].y, c[1].y, c[2].y}),
                              std::min({c[0].z, c[1].z, c[2].z})};
    tri_box[2 * size_t(t) + 1] = {std::max({c[0].x, c[1].x, c[2].x}), std::max({c[0].y, c[1].y, c[2].y}),
                                  std::max({c[0].z, c[1].z, c[2].z})};
    centroids[t] = (c[0].x + c[1].x + c[2].x) / 3;
    centroids[n + size_t(t)] = (c[0].y + c[1].y + c[2].y) / 3;
    centroids[2 * size_t(n) + t] = (c[0].z + c[1].z + c[2].z) / 3;
  }
  if (n) {
    nodes_.reserve(2 * size_t(n) / kLeafSize + 2);
    nodes_.resize(1);
    build(0, 0, n, tri_box.data(), centroids.data());
    // Corners in tree order: a leaf's triangles are adjacent in memory (queries are bound by
    // cache misses), and a triangle's id is its tree position.
    // In place, cycle by cycle (no second copy of the corners at the peak).
    auto triangle = [&](uint32_t t) { return &corners_[3 * size_t(t)]; };
    for (uint32_t i = 0; i < n; ++i) {
      if (order_[i] == i) continue;
      const DVec3 saved[3] = {triangle(i)[0], triangle(i)[1], triangle(i)[2]};
      uint32_t j = i;
      for (uint32_t k = order_[j]; k != i; j = k, k = order_[j]) {
        std::copy(triangle(k), triangle(k) + 3, triangle(j));
        order_[j] = j;
      }
      std::copy(saved, saved + 3, triangle(j));
      order_[j] = j;
    }
    std::vector<uint32_t>().swap(order_);
    parent_.assign(nodes_.size(), 0);
    leaf_of_.resize(n);
    for (uint32_t i = 0; i < nodes_.size(); ++i) {
      const Node& nd = nodes_[i];
      if (nd.count)
        for (uint32_t j = nd.first; j < nd.first + nd.count; ++j) leaf_of_[j] = i;
      else
        parent_[nd.first] = parent_[nd.first + 1] = i;
    }
  }
}

double TriangleDistanceTree::triangle_d2(DVec3 p, uint32_t t) const {
  const DVec3* c = &corners_[3 * size_t(t)];
  return point_triangle_distance_squared(p, c[0], c[1], c[2]);
}

static inline double box_d2(DVec3 p, DVec3 lo, DVec3 hi) {
  double dx = std::max(std::max(lo.x - p.x, 0.0), p.x - hi.x);
  double dy = std::max(std::max(lo.y - p.y, 0.0), p.y - hi.y);
  double dz = std::max(std::max(lo.z - p.z, 0.0), p.z - hi.z);
  return dx * dx + dy * dy + dz * dz;
}

static double box_centre_d2(DVec3 p, DVec3 lo, DVec3 hi) {
  const double dx = 0.5 * (lo.x + hi.x) - p.x, dy = 0.5 * (lo.y + hi.y) - p.y, dz = 0.5 * (lo.z + hi.z) - p.z;
  return dx * dx + dy * dy + dz * dz;
}

// Median splits keep the depth ≤ log2(n) + 1, so the query's fixed stack (2 entries per
// level) cannot overflow.
void TriangleDistanceTree::build(uint32_t index, uint32_t first, uint32_t last, const DVec3* tri_box,
                                 const double* centroids) {
  Node nd;
  const double inf = std::numeric_limits<double>::infinity();
  const size_t n = order_.size();
  nd.lo = {inf, inf, inf};
  nd.hi = {-inf, -inf, -inf};
  if (last - first <= kLeafSize) {
    for (uint32_t i = first; i < last; ++i) {
      uint32_t t = order_[i];
      const DVec3& lo = tri_box[2 * size_t(t)];
      const DVec3& hi = tri_box[2 * size_t(t) + 1];
      nd.lo = {std::min(nd.lo.x, lo.x), std::min(nd.lo.y, lo.y), std::min(nd.lo.z, lo.z)};
      nd.hi = {std::max(nd.hi.x, hi.x), std::max(nd.hi.y, hi.y), std::max(nd.hi.z, hi.z)};
    }
    nd.first = first;
    nd.count = last - first;
    nodes_[index] = nd;
    return;
  }
  // Inner node: only the centroid extent is needed to pick the axis; the node's box is the
  // union of its children's (min/max are exact, so it equals the box over its triangles).
  DVec3 clo = nd.lo, chi = nd.hi;
  for (uint32_t i = first; i < last; ++i) {
    uint32_t t = order_[i];
    const DVec3 c{centroids[t], centroids[n + t], centroids[2 * n + t]};
    clo = {std::min(clo.x, c.x), std::min(clo.y, c.y), std::min(clo.z, c.z)};
    chi = {std::max(chi.x, c.x), std::max(chi.y, c.y), std::max(chi.z, c.z)};
  }
  DVec3 ext = surface_distance_detail::sub(chi, clo);
  int axis = ext.x >= ext.y && ext.x >= ext.z ? 0 : (ext.y >= ext.z ? 1 : 2);
  const double* key = centroids + size_t(axis) * n;
  uint32_t mid = first + (last - first) / 2;
  // Ties broken by triangle index: the tree (and so every query) is deterministic.
  std::nth_element(order_.begin() + first, order_.begin() + mid, order_.begin() + last, [key](uint32_t a, uint32_t b) {
    double ka = key[a], kb = key[b];
    return ka < kb || (ka == kb && a < b);
  });
  uint32_t child = uint32_t(nodes_.size());
  nodes_.resize(nodes_.size() + 2);
  build(child, first, mid, tri_box, centroids);
  build(child + 1, mid, last, tri_box, centroids);
  const Node& l = nodes_[child];
  const Node& r = nodes_[child + 1];
  nd.lo = {std::min(l.lo.x, r.lo.x), std::min(l.lo.y, r.lo.y), std::min(l.lo.z, r.lo.z)};
  nd.hi = {std::max(l.hi.x, r.hi.x), std::max(l.hi.y, r.hi.y), std::max(l.hi.z, r.hi.z)};
  nd.first = child;
  nd.count = 0;
  nodes_[index] = nd;
}

double TriangleDistanceTree::nearest_distance_squared(DVec3 p, uint32_t* hint) const {
  double best = std::numeric_limits<double>::infinity();
  if (nodes_.empty()) return best;
  uint32_t best_t = *hint;
  if (best_t < leaf_of_.size()) best = triangle_d2(p, best_t);
  uint32_t stack[128];
  int top = 0;
  stack[top++] = 0;
  while (top) {
    const Node& nd = nodes_[stack[--top]];
    if (box_d2(p, nd.lo, nd.hi) >= best) continue;
    if (nd.count) {
      for (uint32_t i = 0; i < nd.count; ++i) {
        uint32_t t = nd.first + i;
        double d = triangle_d2(p, t);
        if (d < best) best = d, best_t = t;
      }
      continue;
    }
    uint32_t l = nd.first, r = nd.first + 1;
    double dl = box_d2(p, nodes_[l].lo, nodes_[l].hi), dr = box_d2(p, nodes_[r].lo, nodes_[r].hi);
    if (dl > dr) std::swap(l, r), std::swap(dl, dr);
    if (dr < best) stack[top++] = r;
    if (dl < best) stack[top++] = l;
  }
  *hint = best_t;
  return best;
}

bool TriangleDistanceTree::triangle_within_squared(DVec3 p, uint32_t t, double threshold) const {
  const DVec3* c = &corners_[3 * size_t(t)];
  double d2;
  return point_triangle_within_squared(p, c[0], c[1], c[2], threshold, &d2);
}

bool TriangleDistanceTree::any_within_squared(DVec3 p, double threshold, uint32_t* hint) const {
  if (nodes_.empty()) return false;
  // Searched from the hint's tree leaf outwards (the leaf, then the sibling subtree of each
  // ancestor): every triangle is searched, and a query near the last one ends near its leaf
  // instead of descending from the root.
  uint32_t node = *hint < leaf_of_.size() ? leaf_of_[*hint] : 0;
  uint32_t stack[128];
  auto search = [&](uint32_t root) {
    int top = 0;
    stack[top++] = root;
    while (top) {
      const Node& nd = nodes_[stack[--top]];
      if (box_d2(p, nd.lo, nd.hi) > threshold) continue;
      if (nd.count) {
        for (uint32_t i = 0; i < nd.count; ++i)
          if (triangle_within_squared(p, nd.first + i, threshold)) return *hint = nd.first + i, true;
        continue;
      }
      uint32_t l = nd.first, r = nd.first + 1;
      double dl = box_d2(p, nodes_[l].lo, nodes_[l].hi), dr = box_d2(p, nodes_[r].lo, nodes_[r].hi);
      // Boxes of a curved surface's triangles often all contain p (distance 0): then the
      // child whose box centre is nearer more likely holds a triangle within the threshold.
      const bool swap = dl == dr ? box_centre_d2(p, nodes_[l].lo, nodes_[l].hi) > box_centre_d2(p, nodes_[r].lo, nodes_[r].hi)
                                 : dl > dr;
      if (swap) std::swap(l, r), std::swap(dl, dr);
      if (dr <= threshold) stack[top++] = r;
      if (dl <= threshold) stack[top++] = l;
    }
    return false;
  };
  if (search(node)) return true;
  while (node != 0) {
    const uint32_t parent = parent_[node];
    const uint32_t sibling = nodes_[parent].first + (nodes_[parent].first == node ? 1 : 0);
    if (search(sibling)) return true;
    node = parent;
  }
  return false;
}

double sampled_one_sided_distance(const float* positions, const uint32_t* from_indices, size_t from_triangles,
                                  const TriangleDistanceTree& to, uint32_t subdivisions) {
  double best2 = 0;
  uint32_t hint = ~0u;
  for_each_lattice_point(positions, from_indices, from_triangles, subdivisions, [&](DVec3 p) {
    double d2 = to.nearest_distance_squared(p, &hint);
    if (d2 > best2) best2 = d2;
  });
  return std::sqrt(best2);
}

}  // namespace vgeo
