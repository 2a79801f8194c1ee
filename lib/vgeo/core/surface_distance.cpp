// One-sided surface distance (surface_distance.h). Based on: Cignoni, Rocchini, Scopigno,
// "Metro: Measuring Error on Simplified Surfaces", Computer Graphics Forum 17(2), 1998 (sampled
// one-sided distance); the point-triangle distance by regions (inside the triangle's prism the
// plane distance, else the nearest edge), as in Ericson, "Real-Time Collision Detection", 2005,
// §5.1.5; a median-split bounding-volume hierarchy over the triangles.
#include "vgeo/core/surface_distance.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>

#include "vgeo/core/process_memory.h"
#include "vgeo/core/thread_pool.h"

namespace vgeo {
namespace {

// Triangles per tree leaf of a soup tree: a few exact tests beat a deeper tree.
constexpr uint32_t kLeafSize = 4;
// Triangles per tree leaf of an indexed tree: its caller (the builder's stored error, which
// walks over the surface first) asks it for ~0.5% of its points, so a 4× smaller node array
// (fewer pages to fill; 4 MB instead of 16 on a 1M mesh) is worth a few more tests per query.
constexpr uint32_t kIndexedLeafSize = 16;

}  // namespace

double point_triangle_distance_squared(DVec3 p, DVec3 a, DVec3 b, DVec3 c) {
  return prepared_triangle_distance_squared(p, prepare_triangle(a, b, c));
}

bool point_triangle_within_squared(DVec3 p, DVec3 a, DVec3 b, DVec3 c, double threshold, double* d2) {
  return prepared_triangle_within_squared(p, prepare_triangle(a, b, c), threshold, d2);
}

namespace {

// Triangles (or nodes) per parallel build chunk: centroids, reordering, indexing.
constexpr size_t kBuildChunk = 1 << 16;
// Subtrees built as independent tasks per pool thread: enough for the dynamic scheduling to
// even out their unequal costs.
constexpr size_t kSubtreesPerThread = 8;

// Nodes of a subtree over m triangles (median splits: the children take m/2 and m - m/2).
// Sizes at one depth differ by at most one, so the memo stays small.
uint32_t subtree_nodes(uint32_t m, uint32_t leaf_size, std::map<uint32_t, uint32_t>& memo) {
  if (m <= leaf_size) return 1;
  auto it = memo.find(m);
  if (it != memo.end()) return it->second;
  const uint32_t count = 1 + subtree_nodes(m / 2, leaf_size, memo) + subtree_nodes(m - m / 2, leaf_size, memo);
  memo.emplace(m, count);
  return count;
}

}  // namespace

TriangleDistanceTree::TriangleDistanceTree(std::vector<float> corners, ThreadPool* pool) : leaf_size_(kLeafSize) {
  const uint32_t n = uint32_t(corners.size() / 9);
  if (n == 0) return;
  std::vector<BuildItem> items(n);  // build-time only
  for_chunks(pool, n, kBuildChunk, [&](size_t begin, size_t end) {
    for (size_t t = begin; t < end; ++t) {
      const float* c = &corners[9 * t];
      items[t].triangle = uint32_t(t);
      for (int k = 0; k < 3; ++k) items[t].centroid[k] = (double(c[k]) + double(c[3 + k]) + double(c[6 + k])) / 3;
    }
  });
  std::vector<Subtree> frontier, top;
  build_structure(n, pool, items.data(), frontier, top);
  // Corners in tree order: a leaf's triangles are adjacent in memory, and a triangle's id
  // is its tree position.
  corners_.resize(corners.size());
  for_chunks(pool, n, kBuildChunk, [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) std::copy_n(&corners[9 * size_t(items[i].triangle)], 9, &corners_[9 * i]);
  });
  std::vector<float>().swap(corners);
  std::vector<BuildItem>().swap(items);
  finish(n, pool, frontier, top);
}

TriangleDistanceTree::TriangleDistanceTree(const float* positions, std::vector<uint32_t> corner_ids, ThreadPool* pool)
    : positions_(positions), corner_ids_(std::move(corner_ids)), leaf_size_(kIndexedLeafSize) {
  const uint32_t n = uint32_t(corner_ids_.size() / 3);
  if (n == 0) return;
  std::vector<Subtree> frontier, top;
  build_structure(n, pool, nullptr, frontier, top);
  finish(n, pool, frontier, top);
}

void TriangleDistanceTree::build_structure(uint32_t n, ThreadPool* pool, BuildItem* items, std::vector<Subtree>& frontier,
                                           std::vector<Subtree>& top) {
  std::map<uint32_t, uint32_t> memo;
  const size_t node_count = subtree_nodes(n, leaf_size_, memo);
  reserve_huge_pages(nodes_, node_count);
  nodes_.resize(node_count);
  // The top of the tree breadth first, each level's splits in parallel, until there are
  // enough subtrees to build as independent tasks. Every node's place is fixed by the
  // triangle counts alone (subtree_nodes), so the tree is the one the serial depth-first
  // build makes, whatever the pool.
  const size_t wanted = pool ? kSubtreesPerThread * pool->size() : 1;
  frontier = {{0, 0, n, 1}};
  top.clear();
  for (;;) {
    std::vector<size_t> splittable;
    for (size_t i = 0; i < frontier.size(); ++i)
      if (frontier[i].last - frontier[i].first > leaf_size_) splittable.push_back(i);
    if (frontier.size() >= wanted || splittable.empty()) break;
    std::vector<uint32_t> mids(splittable.size());
    auto split_one = [&](size_t i) {
      const Subtree& at = frontier[splittable[i]];
      mids[i] = split(items, at.first, at.last);
    };
    if (pool && items && splittable.size() > 1)
      pool->parallel_for(splittable.size(), split_one);
    else
      for (size_t i = 0; i < splittable.size(); ++i) split_one(i);
    std::vector<Subtree> next;
    for (size_t i = 0, k = 0; i < frontier.size(); ++i) {
      const Subtree at = frontier[i];
      if (k == splittable.size() || splittable[k] != i) {
        next.push_back(at);
        continue;
      }
      const uint32_t mid = mids[k++];
      nodes_[at.index].first = at.next;
      nodes_[at.index].count = 0;
      top.push_back(at);
      next.push_back({at.next, at.first, mid, at.next + 2});
      next.push_back({at.next + 1, mid, at.last, at.next + 1 + subtree_nodes(mid - at.first, leaf_size_, memo)});
    }
    frontier = std::move(next);
  }
  if (pool && frontier.size() > 1)
    pool->parallel_for(frontier.size(), [&](size_t i) { build(frontier[i], items); });
  else
    for (const Subtree& at : frontier) build(at, items);
}

void TriangleDistanceTree::finish(uint32_t n, ThreadPool* pool, const std::vector<Subtree>& frontier,
                                  const std::vector<Subtree>& top) {
  // Boxes bottom up: children follow their parent, and a subtree's descendants are the
  // nodes [next, next + subtree_nodes - 1).
  std::map<uint32_t, uint32_t> memo;
  std::vector<uint32_t> descendants(frontier.size());
  for (size_t i = 0; i < frontier.size(); ++i) descendants[i] = subtree_nodes(frontier[i].last - frontier[i].first, leaf_size_, memo) - 1;
  auto boxes = [&](size_t i) {
    const Subtree& at = frontier[i];
    for (uint32_t j = at.next + descendants[i]; j-- > at.next;) set_box(j);
    set_box(at.index);
  };
  if (pool && frontier.size() > 1)
    pool->parallel_for(frontier.size(), boxes);
  else
    for (size_t i = 0; i < frontier.size(); ++i) boxes(i);
  for (size_t i = top.size(); i-- > 0;) set_box(top[i].index);
  reserve_huge_pages(parent_, nodes_.size());
  parent_.assign(nodes_.size(), 0);
  reserve_huge_pages(leaf_of_, n);
  leaf_of_.resize(n);
  for_chunks(pool, nodes_.size(), kBuildChunk, [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) {
      const Node& nd = nodes_[i];
      if (nd.count)
        for (uint32_t j = nd.first; j < nd.first + nd.count; ++j) leaf_of_[j] = uint32_t(i);
      else
        parent_[nd.first] = parent_[nd.first + 1] = uint32_t(i);
    }
  });
}

// The triangle tests of point_triangle_*, inlined here (the tree's inner loops).
inline double TriangleDistanceTree::triangle_d2(DVec3 p, uint32_t t) const {
  return prepared_triangle_distance_squared(p, prepare_triangle(corner(t, 0), corner(t, 1), corner(t, 2)));
}

static inline double box_d2(DVec3 p, const float* lo, const float* hi) {
  double dx = std::max(std::max(double(lo[0]) - p.x, 0.0), p.x - double(hi[0]));
  double dy = std::max(std::max(double(lo[1]) - p.y, 0.0), p.y - double(hi[1]));
  double dz = std::max(std::max(double(lo[2]) - p.z, 0.0), p.z - double(hi[2]));
  return dx * dx + dy * dy + dz * dz;
}

// The median split of items[first, last) (an inner node's triangles): along the longest axis
// of the centroids' extent; returns where the second child's triangles begin.
uint32_t TriangleDistanceTree::split(BuildItem* items, uint32_t first, uint32_t last) {
  if (!items) return first + (last - first) / 2;
  const double inf = std::numeric_limits<double>::infinity();
  DVec3 clo{inf, inf, inf}, chi{-inf, -inf, -inf};
  for (uint32_t i = first; i < last; ++i) {
    const double* c = items[i].centroid;
    clo = {std::min(clo.x, c[0]), std::min(clo.y, c[1]), std::min(clo.z, c[2])};
    chi = {std::max(chi.x, c[0]), std::max(chi.y, c[1]), std::max(chi.z, c[2])};
  }
  DVec3 ext = surface_distance_detail::sub(chi, clo);
  int axis = ext.x >= ext.y && ext.x >= ext.z ? 0 : (ext.y >= ext.z ? 1 : 2);
  uint32_t mid = first + (last - first) / 2;
  // Ties broken by triangle index: the tree (and so every query) is deterministic.
  std::nth_element(items + first, items + mid, items + last, [axis](const BuildItem& a, const BuildItem& b) {
    double ka = a.centroid[axis], kb = b.centroid[axis];
    return ka < kb || (ka == kb && a.triangle < b.triangle);
  });
  return mid;
}

// A leaf's box is over its triangles' corners; an inner node's is the union of its children's
// (set first: min/max are exact, so it equals the box over its triangles).
void TriangleDistanceTree::set_box(uint32_t index) {
  Node& nd = nodes_[index];
  if (nd.count) {
    const float inf = std::numeric_limits<float>::infinity();
    for (int k = 0; k < 3; ++k) nd.lo[k] = inf, nd.hi[k] = -inf;
    for (uint32_t t = nd.first; t < nd.first + nd.count; ++t)
      for (int j = 0; j < 3; ++j) {
        const DVec3 c = corner(t, j);  // exact: a float widened
        const float xyz[3] = {float(c.x), float(c.y), float(c.z)};
        for (int k = 0; k < 3; ++k) nd.lo[k] = std::min(nd.lo[k], xyz[k]), nd.hi[k] = std::max(nd.hi[k], xyz[k]);
      }
    return;
  }
  const Node& l = nodes_[nd.first];
  const Node& r = nodes_[nd.first + 1];
  for (int k = 0; k < 3; ++k) nd.lo[k] = std::min(l.lo[k], r.lo[k]), nd.hi[k] = std::max(l.hi[k], r.hi[k]);
}

// Builds the structure of subtree `at` depth first (boxes: set_box); returns the index after
// its last descendant. Median splits keep the depth ≤ log2(n) + 1, so the query's fixed stack
// (2 entries per level) cannot overflow.
uint32_t TriangleDistanceTree::build(Subtree at, BuildItem* items) {
  Node& nd = nodes_[at.index];
  if (at.last - at.first <= leaf_size_) {
    nd.first = at.first;
    nd.count = at.last - at.first;
    return at.next;
  }
  nd.first = at.next;
  nd.count = 0;
  const uint32_t mid = split(items, at.first, at.last);
  const uint32_t after_left = build({at.next, at.first, mid, at.next + 2}, items);
  return build({at.next + 1, mid, at.last, after_left}, items);
}

double TriangleDistanceTree::nearest_distance_squared(DVec3 p, uint32_t* hint) const {
  return nearest_or_within_squared(p, -1.0, hint);  // no distance is ≤ -1: the nearest, always
}

double TriangleDistanceTree::nearest_or_within_squared(DVec3 p, double threshold, uint32_t* hint) const {
  return search_within<false>(p, threshold, hint, nullptr);
}

double TriangleDistanceTree::nearest_or_within_squared(DVec3 p, double threshold, uint32_t* hint,
                                                       double* unchanged_below) const {
  return search_within<true>(p, threshold, hint, unchanged_below);
}

// The threshold enters only the early returns: each compares the best distance so far (which
// only falls) with it, so the result is the same for any threshold below the last one compared
// and found beyond it (kTrack: *unchanged_below gets that one).
template <bool kTrack>
double TriangleDistanceTree::search_within(DVec3 p, double threshold, uint32_t* hint, double* unchanged_below) const {
  double best = std::numeric_limits<double>::infinity();
  if (nodes_.empty()) return best;
  uint32_t best_t = *hint;
  // The hint's whole leaf first: a smaller first bound prunes more of the descent, which then
  // skips that leaf (its triangles are in `best` already: testing them again changes neither
  // `best` nor `best_t`, whose update needs a strictly smaller distance).
  uint32_t tested_leaf = ~0u;
  if (best_t < leaf_of_.size()) {
    tested_leaf = leaf_of_[best_t];
    const Node& leaf = nodes_[tested_leaf];
    for (uint32_t t = leaf.first; t < leaf.first + leaf.count; ++t) {
      const double d = triangle_d2(p, t);
      if (d < best) best = d, best_t = t;
    }
    if (best <= threshold) return *hint = best_t, best;
    if constexpr (kTrack) *unchanged_below = std::min(*unchanged_below, best);
  }
  // Nodes are pushed with their box distance: compared again with the (smaller) best when
  // popped, not recomputed.
  struct Entry {
    uint32_t node;
    double d2;
  };
  Entry stack[128];
  int top = 0;
  stack[top++] = {0, box_d2(p, nodes_[0].lo, nodes_[0].hi)};
  while (top) {
    const Entry e = stack[--top];
    if (e.d2 >= best || e.node == tested_leaf) continue;
    const Node& nd = nodes_[e.node];
    if (nd.count) {
      for (uint32_t i = 0; i < nd.count; ++i) {
        uint32_t t = nd.first + i;
        double d = triangle_d2(p, t);
        if (d < best) best = d, best_t = t;
      }
      if (best <= threshold) return *hint = best_t, best;
      if constexpr (kTrack) *unchanged_below = std::min(*unchanged_below, best);
      continue;
    }
    uint32_t l = nd.first, r = nd.first + 1;
    double dl = box_d2(p, nodes_[l].lo, nodes_[l].hi), dr = box_d2(p, nodes_[r].lo, nodes_[r].hi);
    if (dl > dr) std::swap(l, r), std::swap(dl, dr);
    if (dr < best) stack[top++] = {r, dr};
    if (dl < best) stack[top++] = {l, dl};
  }
  *hint = best_t;
  return best;
}

void TriangleDistanceTree::triangles_in_box(DVec3 lo, DVec3 hi, std::vector<uint32_t>* out, DVec3 normal, double offset,
                                            double width, size_t max_count) const {
  if (nodes_.empty()) return;
  const bool slab = normal.x != 0 || normal.y != 0 || normal.z != 0;
  // Whether [blo, bhi] meets the query box and the slab (the box's extent along the normal
  // overlaps [offset - width, offset + width]).
  auto meets = [&](const float* blo, const float* bhi) {
    if (!(double(blo[0]) <= hi.x && double(bhi[0]) >= lo.x && double(blo[1]) <= hi.y && double(bhi[1]) >= lo.y &&
          double(blo[2]) <= hi.z && double(bhi[2]) >= lo.z))
      return false;
    if (!slab) return true;
    const double n[3] = {normal.x, normal.y, normal.z};
    double smin = 0, smax = 0;
    for (int k = 0; k < 3; ++k) {
      const double a = n[k] * double(blo[k]), b = n[k] * double(bhi[k]);
      smin += std::min(a, b), smax += std::max(a, b);
    }
    return smin <= offset + width && smax >= offset - width;
  };
  uint32_t stack[128];
  int top = 0;
  stack[top++] = 0;
  while (top) {
    const Node& nd = nodes_[stack[--top]];
    if (!meets(nd.lo, nd.hi)) continue;
    if (nd.count) {
      for (uint32_t t = nd.first; t < nd.first + nd.count; ++t) {
        const float* c0 = triangle_corner_floats(t, 0);
        const float* c1 = triangle_corner_floats(t, 1);
        const float* c2 = triangle_corner_floats(t, 2);
        const float c[9] = {c0[0], c0[1], c0[2], c1[0], c1[1], c1[2], c2[0], c2[1], c2[2]};
        float tlo[3], thi[3];
        for (int k = 0; k < 3; ++k)
          tlo[k] = std::min({c[k], c[3 + k], c[6 + k]}), thi[k] = std::max({c[k], c[3 + k], c[6 + k]});
        if (!meets(tlo, thi)) continue;
        if (slab) {  // the triangle itself, not only its box, against the slab
          double smin = std::numeric_limits<double>::infinity(), smax = -smin;
          for (int j = 0; j < 3; ++j) {
            const double v = normal.x * double(c[3 * j]) + normal.y * double(c[3 * j + 1]) + normal.z * double(c[3 * j + 2]);
            smin = std::min(smin, v), smax = std::max(smax, v);
          }
          if (smin > offset + width || smax < offset - width) continue;
        }
        out->push_back(t);
        if (out->size() > max_count) return;
      }
      continue;
    }
    stack[top++] = nd.first + 1;  // right pushed first: triangles come out in tree order
    stack[top++] = nd.first;
  }
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
