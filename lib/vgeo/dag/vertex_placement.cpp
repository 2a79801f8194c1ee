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
#include <cmath>
#include <cstdlib>

#include "vgeo/dag/build_internal.h"

namespace vgeo::build_detail {

namespace {

DVec3 dvec(const float* p) { return DVec3{p[0], p[1], p[2]}; }
double ddot(DVec3 a, DVec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
DVec3 dsub(DVec3 a, DVec3 b) { return DVec3{a.x - b.x, a.y - b.y, a.z - b.z}; }

}  // namespace

LeafNormals compute_leaf_normals(const WeldedMesh& welded, const Mesh& mesh, double cos_crease) {
  const size_t n = mesh.vertex_count();
  LeafNormals out;
  std::vector<double> sum(3 * n, 0.0);
  auto face = [&](size_t t, DVec3& normal) {
    const uint32_t* c = &mesh.indices[3 * t];
    const DVec3 a = dvec(&mesh.positions[3 * size_t(c[0])]), b = dvec(&mesh.positions[3 * size_t(c[1])]),
                d = dvec(&mesh.positions[3 * size_t(c[2])]);
    const DVec3 u = dsub(b, a), v = dsub(d, a);
    normal = DVec3{u.y * v.z - u.z * v.y, u.z * v.x - u.x * v.z, u.x * v.y - u.y * v.x};  // 2 × area × unit normal
  };
  for (size_t t = 0; t < mesh.triangle_count(); ++t) {
    DVec3 f;
    face(t, f);
    for (int k = 0; k < 3; ++k) {
      const uint32_t w = welded.weld[mesh.indices[3 * t + k]];
      sum[3 * w] += f.x, sum[3 * w + 1] += f.y, sum[3 * w + 2] += f.z;
    }
  }
  out.normal.assign(3 * n, 0.0f);
  out.smooth.assign(n, 0);
  for (size_t w = 0; w < n; ++w) {
    const double len = std::sqrt(sum[3 * w] * sum[3 * w] + sum[3 * w + 1] * sum[3 * w + 1] + sum[3 * w + 2] * sum[3 * w + 2]);
    if (!(len > 0)) continue;
    for (int k = 0; k < 3; ++k) out.normal[3 * w + k] = float(sum[3 * w + k] / len);
    out.smooth[w] = 1;
  }
  // A position is smooth when every leaf face at it is within the crease angle of its normal.
  for (size_t t = 0; t < mesh.triangle_count(); ++t) {
    DVec3 f;
    face(t, f);
    const double len = std::sqrt(ddot(f, f));
    for (int k = 0; k < 3; ++k) {
      const uint32_t w = welded.weld[mesh.indices[3 * t + k]];
      if (!out.smooth[w]) continue;
      const DVec3 nw = dvec(&out.normal[3 * size_t(w)]);
      if (!(len > 0) || ddot(f, nw) < cos_crease * len) out.smooth[w] = 0;
    }
  }
  return out;
}

VertexMoves place_vertices(const PlacementContext& ctx, const TriangleSet& tris, double alpha,
                           std::vector<uint32_t>& scratch) {
  const WeldedMesh& welded = *ctx.welded;
  // Per distinct welded corner (local index via scratch): summed centroid bulge, count,
  // shortest incident edge (squared), at the leaf positions.
  std::vector<uint32_t> positions;  // welded ids, in order of first use
  std::vector<double> bulge_sum, min_edge2;
  std::vector<uint32_t> count;
  auto local = [&](uint32_t w) {
    if (scratch[w] == kNone) {
      scratch[w] = uint32_t(positions.size());
      positions.push_back(w);
      bulge_sum.push_back(0.0);
      min_edge2.push_back(std::numeric_limits<double>::infinity());
      count.push_back(0);
    }
    return scratch[w];
  };
  for (size_t t = 0; t < tris.triangle_count(); ++t) {
    const uint32_t* c = &tris.corners[3 * t];
    uint32_t w[3], leaf_w[3];
    DVec3 p[3], nrm[3];
    for (int k = 0; k < 3; ++k) {
      w[k] = welded.weld[c[k]];
      const uint32_t o = ctx.leaves->origin(c[k]);
      leaf_w[k] = welded.weld[o];
      p[k] = dvec(&ctx.leaf_positions[3 * size_t(o)]);
      nrm[k] = dvec(&ctx.normals->normal[3 * size_t(leaf_w[k])]);
    }
    if (w[0] == w[1] || w[1] == w[2] || w[2] == w[0]) continue;
    double bulge = 0.0;
    double e2[3];
    for (int k = 0; k < 3; ++k) {
      const int j = (k + 1) % 3;
      const DVec3 d = dsub(p[k], p[j]);
      e2[k] = ddot(d, d);
      bulge += ddot(dsub(nrm[k], nrm[j]), d) / 8.0;
    }
    bulge *= 4.0 / 9.0;
    for (int k = 0; k < 3; ++k) {
      const uint32_t i = local(w[k]);
      bulge_sum[i] += bulge;
      ++count[i];
      min_edge2[i] = std::min({min_edge2[i], e2[k], e2[(k + 2) % 3]});
    }
  }
  // The offset of each movable position (0: it stays).
  std::vector<float> moved(3 * positions.size());
  std::vector<uint8_t> moves(positions.size(), 0);
  for (size_t i = 0; i < positions.size(); ++i) {
    const uint32_t w = positions[i];
    scratch[w] = kNone;
    if ((*ctx.locked)[w] || (*ctx.pinned)[w] || (ctx.mesh_border && !ctx.mesh_border->empty() && (*ctx.mesh_border)[w]) ||
        welded.copies[w] > kMaxMovedCopies)
      continue;
    const uint32_t o = ctx.leaves->origin(w);
    const uint32_t leaf_w = welded.weld[o];
    if (!ctx.normals->smooth[leaf_w] || count[i] == 0) continue;
    double t = alpha * bulge_sum[i] / count[i];
    static const double lim = std::getenv("VGEO_LIMIT") ? std::atof(std::getenv("VGEO_LIMIT")) : kMaxOffsetPerEdge;  // PROTOTYPE
    const double limit = lim * std::sqrt(min_edge2[i]);
    t = std::clamp(t, -limit, limit);
    if (!(t != 0.0) || !std::isfinite(t)) continue;
    const DVec3 p = dvec(&ctx.leaf_positions[3 * size_t(o)]), nrm = dvec(&ctx.normals->normal[3 * size_t(leaf_w)]);
    const float q[3] = {float(p.x + t * nrm.x), float(p.y + t * nrm.y), float(p.z + t * nrm.z)};
    const float* now = &ctx.mesh->positions[3 * size_t(w)];
    if (q[0] == now[0] && q[1] == now[1] && q[2] == now[2]) continue;
    std::copy(q, q + 3, &moved[3 * i]);
    moves[i] = 1;
  }
  // Every corner vertex at a moved position moves (attribute copies: to the same bits).
  VertexMoves out;
  // Local index of each welded position again, for the corner pass.
  for (size_t i = 0; i < positions.size(); ++i) scratch[positions[i]] = uint32_t(i);
  std::vector<uint32_t> corner_vertices(tris.corners);
  std::sort(corner_vertices.begin(), corner_vertices.end());
  corner_vertices.erase(std::unique(corner_vertices.begin(), corner_vertices.end()), corner_vertices.end());
  for (uint32_t v : corner_vertices) {
    const uint32_t w = welded.weld[v];
    const uint32_t i = scratch[w];
    if (i == kNone || !moves[i]) continue;
    out.vertex.push_back(v);
    out.positions.insert(out.positions.end(), &moved[3 * size_t(i)], &moved[3 * size_t(i) + 3]);
  }
  for (uint32_t w : positions) scratch[w] = kNone;
  return out;
}

}  // namespace vgeo::build_detail
