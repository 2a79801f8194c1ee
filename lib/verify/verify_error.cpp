// Error bound (ERROR_BOUND): spec/invariants.md §5. The one-sided distance from each
// non-leaf cluster's surface to the original surface (all leaf triangles), sampled on a
// barycentric lattice and measured exactly in double against a BVH of the leaves, must
// not exceed the cluster's stored lod_error.
#include <algorithm>
#include <atomic>
#include <cmath>
#include <numeric>
#include <string>

#include "vgeo/core/thread_pool.h"
#include "vgeo/verify/verify_detail.h"

namespace vgeo::verify_detail {
namespace {

struct D3 {
  double x, y, z;
};
D3 operator-(D3 a, D3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
double dot(D3 a, D3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
D3 cross(D3 a, D3 b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }

double point_segment_d2(D3 p, D3 a, D3 b) {
  D3 ab = b - a, ap = p - a;
  double len2 = dot(ab, ab);
  double t = len2 > 0 ? std::clamp(dot(ap, ab) / len2, 0.0, 1.0) : 0.0;
  D3 q{a.x + ab.x * t - p.x, a.y + ab.y * t - p.y, a.z + ab.z * t - p.z};
  return dot(q, q);
}

// Exact-in-double squared distance from p to triangle abc: the plane distance when p
// projects inside, else the nearest edge (also the degenerate-triangle case).
double point_triangle_d2(D3 p, D3 a, D3 b, D3 c) {
  D3 n = cross(b - a, c - a);
  double nn = dot(n, n);
  if (nn > 0) {
    D3 ap = p - a, bp = p - b, cp = p - c;
    if (dot(cross(b - a, ap), n) >= 0 && dot(cross(c - b, bp), n) >= 0 && dot(cross(a - c, cp), n) >= 0) {
      double h = dot(n, ap);
      return h * h / nn;
    }
  }
  return std::min({point_segment_d2(p, a, b), point_segment_d2(p, b, c), point_segment_d2(p, c, a)});
}

// Median-split AABB tree over the leaf triangles (double precision).
class TriangleBvh {
 public:
  explicit TriangleBvh(std::vector<D3> corners) : corners_(std::move(corners)) {
    const uint32_t n = uint32_t(corners_.size() / 3);
    order_.resize(n);
    std::iota(order_.begin(), order_.end(), 0u);
    centroids_.resize(n);
    for (uint32_t t = 0; t < n; ++t) {
      const D3* c = &corners_[3 * size_t(t)];
      centroids_[t] = {(c[0].x + c[1].x + c[2].x) / 3, (c[0].y + c[1].y + c[2].y) / 3, (c[0].z + c[1].z + c[2].z) / 3};
    }
    if (n) {
      nodes_.resize(1);
      build(0, 0, n);
    }
  }
  bool empty() const { return nodes_.empty(); }

  // Squared distance to the nearest triangle; `hint` (in/out) is a triangle to start from.
  double nearest_d2(D3 p, uint32_t* hint) const {
    double best = std::numeric_limits<double>::infinity();
    uint32_t best_t = *hint;
    if (best_t < order_.size()) best = tri_d2(p, best_t);
    uint32_t stack[128];
    int top = 0;
    stack[top++] = 0;
    while (top) {
      const Node& nd = nodes_[stack[--top]];
      if (box_d2(p, nd) >= best) continue;
      if (nd.count) {
        for (uint32_t i = 0; i < nd.count; ++i) {
          uint32_t t = order_[nd.first + i];
          double d = tri_d2(p, t);
          if (d < best) best = d, best_t = t;
        }
        continue;
      }
      uint32_t l = nd.first, r = nd.first + 1;
      double dl = box_d2(p, nodes_[l]), dr = box_d2(p, nodes_[r]);
      if (dl > dr) std::swap(l, r), std::swap(dl, dr);
      if (dr < best) stack[top++] = r;
      if (dl < best) stack[top++] = l;
    }
    *hint = best_t;
    return best;
  }

 private:
  struct Node {
    D3 lo, hi;
    uint32_t first = 0, count = 0;  // leaf: order_[first, +count); inner: children first, first+1
  };
  static constexpr uint32_t kLeafSize = 4;  // triangles per BVH leaf: a few exact tests beat a deeper tree

  double tri_d2(D3 p, uint32_t t) const {
    const D3* c = &corners_[3 * size_t(t)];
    return point_triangle_d2(p, c[0], c[1], c[2]);
  }
  static double box_d2(D3 p, const Node& n) {
    double dx = std::max({n.lo.x - p.x, 0.0, p.x - n.hi.x});
    double dy = std::max({n.lo.y - p.y, 0.0, p.y - n.hi.y});
    double dz = std::max({n.lo.z - p.z, 0.0, p.z - n.hi.z});
    return dx * dx + dy * dy + dz * dz;
  }
  // Builds the subtree of order_[first, last) into nodes_[index]. Median splits keep the
  // depth ≤ log2(n) + 1, so the query's fixed stack (2 entries per level) cannot overflow.
  void build(uint32_t index, uint32_t first, uint32_t last) {
    Node nd;
    const double inf = std::numeric_limits<double>::infinity();
    nd.lo = {inf, inf, inf};
    nd.hi = {-inf, -inf, -inf};
    D3 clo = nd.lo, chi = nd.hi;
    for (uint32_t i = first; i < last; ++i) {
      uint32_t t = order_[i];
      for (int j = 0; j < 3; ++j) {
        const D3& q = corners_[3 * size_t(t) + j];
        nd.lo = {std::min(nd.lo.x, q.x), std::min(nd.lo.y, q.y), std::min(nd.lo.z, q.z)};
        nd.hi = {std::max(nd.hi.x, q.x), std::max(nd.hi.y, q.y), std::max(nd.hi.z, q.z)};
      }
      const D3& c = centroids_[t];
      clo = {std::min(clo.x, c.x), std::min(clo.y, c.y), std::min(clo.z, c.z)};
      chi = {std::max(chi.x, c.x), std::max(chi.y, c.y), std::max(chi.z, c.z)};
    }
    if (last - first <= kLeafSize) {
      nd.first = first;
      nd.count = last - first;
      nodes_[index] = nd;
      return;
    }
    D3 ext = chi - clo;
    int axis = ext.x >= ext.y && ext.x >= ext.z ? 0 : ext.y >= ext.z ? 1 : 2;
    auto key = [&](uint32_t t) { return axis == 0 ? centroids_[t].x : axis == 1 ? centroids_[t].y : centroids_[t].z; };
    uint32_t mid = first + (last - first) / 2;
    std::nth_element(order_.begin() + first, order_.begin() + mid, order_.begin() + last,
                     [&](uint32_t a, uint32_t b) { return key(a) < key(b) || (key(a) == key(b) && a < b); });
    uint32_t l = uint32_t(nodes_.size());
    nodes_.resize(l + 2);
    nd.first = l;
    nd.count = 0;
    nodes_[index] = nd;
    build(l, first, mid);
    build(l + 1, mid, last);
  }

  std::vector<D3> corners_;
  std::vector<D3> centroids_;
  std::vector<uint32_t> order_;
  std::vector<Node> nodes_;
};

double float_ulp(double magnitude) {
  float m = float(std::max(magnitude, double(std::numeric_limits<float>::min())));
  return double(std::nextafter(m, std::numeric_limits<float>::infinity())) - double(m);
}

}  // namespace

void check_error_bound(const ClusterDag& dag, const VerifyOptions& options, Sink& sink, ErrorBoundResult* result) {
  const size_t nc = dag.clusters.size();
  auto corner = [&](const DagCluster& k, uint32_t t, int j) {
    size_t v = size_t(k.vertex_offset) + dag.indices[3 * (size_t(k.triangle_offset) + t) + j];
    return D3{dag.positions[3 * v], dag.positions[3 * v + 1], dag.positions[3 * v + 2]};
  };
  std::vector<D3> leaf_corners;
  double max_abs = 0;
  for (const DagCluster& k : dag.clusters) {
    for (uint32_t v = 0; v < k.vertex_count; ++v)
      for (int j = 0; j < 3; ++j)
        max_abs = std::max(max_abs, std::fabs(double(dag.positions[3 * (size_t(k.vertex_offset) + v) + j])));
    if (k.generating_group != kNone) continue;
    for (uint32_t t = 0; t < k.triangle_count; ++t)
      for (int j = 0; j < 3; ++j) leaf_corners.push_back(corner(k, t, j));
  }
  // Tolerance: stored positions are float; a simplified vertex placed at the measured
  // error is rounded by up to half an ulp per coordinate (√3/2 ulp), and so are the leaves.
  // Four ulps of the largest coordinate covers both roundings (spec/invariants.md §5).
  const double abs_tol = 4.0 * float_ulp(max_abs);
  TriangleBvh bvh(std::move(leaf_corners));

  std::vector<uint32_t> targets;
  for (size_t c = 0; c < nc; ++c)
    if (dag.clusters[c].generating_group != kNone) targets.push_back(uint32_t(c));
  struct Measured {
    double dist = 0;
    D3 worst{0, 0, 0};
    uint64_t samples = 0;
  };
  std::vector<Measured> measured(targets.size());
  const uint32_t k_sub = std::max(1u, options.error_samples_per_edge);
  if (!bvh.empty()) {
    ThreadPool pool(options.threads);
    std::atomic<size_t> next{0};
    pool.run_on_all([&](unsigned) {
      for (size_t i; (i = next.fetch_add(1)) < targets.size();) {
        const DagCluster& k = dag.clusters[targets[i]];
        Measured m;
        uint32_t hint = ~0u;
        double best2 = 0;
        auto sample = [&](D3 p) {
          double d2 = bvh.nearest_d2(p, &hint);
          ++m.samples;
          if (d2 > best2) best2 = d2, m.worst = p;
        };
        auto vertex = [&](uint32_t local) {
          size_t v = size_t(k.vertex_offset) + local;
          return D3{dag.positions[3 * v], dag.positions[3 * v + 1], dag.positions[3 * v + 2]};
        };
        // The lattice points of all triangles, each once: corners per vertex, edge points
        // per distinct edge (from its lower local index), interior points per triangle.
        std::vector<uint8_t> used(k.vertex_count, 0);
        std::vector<uint32_t> edges;
        edges.reserve(3 * k.triangle_count);
        for (uint32_t t = 0; t < k.triangle_count; ++t) {
          const uint8_t* tri = &dag.indices[3 * (size_t(k.triangle_offset) + t)];
          for (int j = 0; j < 3; ++j) {
            uint32_t a = tri[j], b = tri[(j + 1) % 3];
            edges.push_back(std::min(a, b) << 8 | std::max(a, b));
            used[a] = 1;
          }
          D3 a = vertex(tri[0]), b = vertex(tri[1]), c = vertex(tri[2]);
          for (uint32_t u = 1; u < k_sub; ++u)
            for (uint32_t w = 1; u + w < k_sub; ++w) {
              double bu = double(u) / k_sub, bw = double(w) / k_sub, bv = 1.0 - bu - bw;
              sample({a.x * bv + b.x * bu + c.x * bw, a.y * bv + b.y * bu + c.y * bw, a.z * bv + b.z * bu + c.z * bw});
            }
        }
        for (uint32_t v = 0; v < k.vertex_count; ++v)
          if (used[v]) sample(vertex(v));  // corners (unreferenced vertices bound nothing)
        std::sort(edges.begin(), edges.end());
        edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
        for (uint32_t e : edges) {
          D3 a = vertex(e >> 8), b = vertex(e & 0xFF);
          for (uint32_t i = 1; i < k_sub; ++i) {
            double t = double(i) / k_sub;
            sample({a.x + (b.x - a.x) * t, a.y + (b.y - a.y) * t, a.z + (b.z - a.z) * t});
          }
        }
        m.dist = std::sqrt(best2);
        measured[i] = m;
      }
    });
  }
  result->ratios_per_level.assign(dag.level_count + 1, {});
  for (size_t i = 0; i < targets.size(); ++i) {
    const uint32_t c = targets[i];
    const DagCluster& k = dag.clusters[c];
    const Measured& m = measured[i];
    result->samples += m.samples;
    ++result->clusters;
    if (k.lod_error > 0 && std::isfinite(k.lod_error)) {
      double ratio = m.dist / k.lod_error;
      result->ratios.push_back(ratio);
      if (k.level < result->ratios_per_level.size()) result->ratios_per_level[k.level].push_back(ratio);
    }
    if (!(m.dist <= double(k.lod_error) + abs_tol))
      sink.add("ERROR_BOUND", "error_bound", "cluster", c,
               "sampled distance to the leaves " + fmt_float(m.dist) + " exceeds stored lod_error " +
                   fmt_float(k.lod_error) + " (level " + std::to_string(k.level) + ")",
               {{"measured", m.dist},
                {"stored", k.lod_error},
                {"ratio", k.lod_error > 0 ? m.dist / k.lod_error : std::numeric_limits<double>::infinity()},
                {"tolerance", abs_tol},
                {"worst_x", m.worst.x},
                {"worst_y", m.worst.y},
                {"worst_z", m.worst.z}});
  }
}

}  // namespace vgeo::verify_detail
