// Vertex placement (lib/vgeo/dag/vertex_placement.cpp, spec/dag.md §2.3 Place): only movable
// vertices move (never a locked, pinned, mesh-border, per-corner or crease one), along their leaf
// normal, by at most kMaxOffsetPerEdge of their shortest edge, all attribute copies of a position
// to the same bits, outward on a convex surface whatever its winding; builds with placement are
// byte-identical for any thread count and pass every verify check, and do move vertices on
// curved meshes.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <set>

#include "support/shapes.h"
#include "vgeo/core/thread_pool.h"
#include "vgeo/dag/build.h"
#include "vgeo/dag/build_internal.h"
#include "vgeo/dag/dag_io.h"
#include "vgeo/verify/verify.h"

// Own namespace: test files are compiled as one unity source.
namespace vgeo::test::vertex_placement {
namespace {

using namespace build_detail;

// One group's simplification stood in by the leaves themselves (every vertex has its full
// ring), with the locks, pins and mesh borders a test chooses.
struct GroupSetup {
  Mesh mesh;
  WeldedMesh welded;
  TriangleSet tris;
  LeafSurface leaves;
  std::vector<uint8_t> locked, pinned, mesh_border;
  explicit GroupSetup(Mesh m) : mesh(std::move(m)) {
    welded = weld_positions(mesh);
    tris.corners = mesh.indices;
    tris.materials.assign(mesh.triangle_count(), 0);
    ThreadPool pool(1);
    leaves = build_leaf_surface(welded, {&tris}, pool, true);
    locked.assign(mesh.vertex_count(), 0);
    pinned.assign(mesh.vertex_count(), 0);
  }
  VertexMoves place(double share = kPlacementShare) {
    PlacementContext ctx;
    ctx.share = share;
    ctx.welded = &welded;
    ctx.mesh = &mesh;
    ctx.leaf_positions = mesh.positions.data();
    ctx.leaves = &leaves;
    ctx.locked = &locked;
    ctx.pinned = &pinned;
    ctx.mesh_border = &mesh_border;
    std::vector<uint32_t> scratch(mesh.vertex_count(), kNone);
    VertexMoves moves = place_vertices(ctx, tris, scratch);
    EXPECT_TRUE(std::all_of(scratch.begin(), scratch.end(), [](uint32_t x) { return x == kNone; })) << "scratch returned";
    return moves;
  }
};

// `src` with a seam of copies: triangles whose centroid has x > 0 get their own copies (the same
// position bits) of the vertices they share with the others, as an attribute seam has.
Mesh with_copy_seam(const Mesh& src) {
  Mesh m = src;
  std::vector<uint8_t> left(src.vertex_count(), 0);
  auto right = [&](size_t t) {
    float x = 0;
    for (int k = 0; k < 3; ++k) x += src.positions[3 * src.indices[3 * t + k]];
    return x > 0;
  };
  for (size_t t = 0; t < src.triangle_count(); ++t)
    if (!right(t))
      for (int k = 0; k < 3; ++k) left[src.indices[3 * t + k]] = 1;
  std::vector<uint32_t> copy(src.vertex_count(), kNone);
  for (size_t t = 0; t < src.triangle_count(); ++t)
    if (right(t))
      for (int k = 0; k < 3; ++k) {
        uint32_t& v = m.indices[3 * t + k];
        if (!left[v]) continue;
        if (copy[v] == kNone) {
          copy[v] = uint32_t(m.vertex_count());
          for (int a = 0; a < 3; ++a) m.positions.push_back(src.positions[3 * v + a]);
        }
        v = copy[v];
      }
  return m;
}

double length3(const float* p) { return std::sqrt(double(p[0]) * p[0] + double(p[1]) * p[1] + double(p[2]) * p[2]); }

// Shortest welded edge at each welded position of the leaves.
std::vector<double> shortest_edges(const GroupSetup& s) {
  std::vector<double> shortest(s.mesh.vertex_count(), INFINITY);
  for (size_t t = 0; t < s.mesh.triangle_count(); ++t)
    for (int k = 0; k < 3; ++k) {
      const uint32_t a = s.mesh.indices[3 * t + k], b = s.mesh.indices[3 * t + (k + 1) % 3];
      double d2 = 0;
      for (int j = 0; j < 3; ++j) d2 += std::pow(double(s.mesh.positions[3 * a + j]) - s.mesh.positions[3 * b + j], 2);
      for (uint32_t v : {a, b}) shortest[s.welded.weld[v]] = std::min(shortest[s.welded.weld[v]], std::sqrt(d2));
    }
  return shortest;
}

TEST(VertexPlacement, MovesOnlyMovableVerticesOutwardAlongTheirNormalWithinTheEdgeLimit) {
  GroupSetup s(with_copy_seam(make_sphere(16, 32)));
  // Lock the northern cap, pin a band: neither may move.
  for (size_t v = 0; v < s.mesh.vertex_count(); ++v) {
    const float z = s.mesh.positions[3 * v + 2];
    if (z > 0.5f) s.locked[s.welded.weld[v]] = 1;
    if (z > -0.1f && z < 0.1f) s.pinned[s.welded.weld[v]] = 1;
  }
  const VertexMoves moves = s.place();
  ASSERT_EQ(moves.positions.size(), 3 * moves.vertex.size());
  ASSERT_GT(moves.vertex.size(), s.mesh.vertex_count() / 4) << "a sphere's free vertices move";
  const std::vector<double> shortest = shortest_edges(s);
  std::map<uint32_t, std::array<float, 3>> by_position;  // welded id -> moved position
  std::set<uint32_t> moved(moves.vertex.begin(), moves.vertex.end());
  EXPECT_EQ(moved.size(), moves.vertex.size()) << "each vertex once";
  for (size_t i = 0; i < moves.vertex.size(); ++i) {
    const uint32_t v = moves.vertex[i], w = s.welded.weld[v];
    EXPECT_FALSE(s.locked[w]) << v;
    EXPECT_FALSE(s.pinned[w]) << v;
    const float* p = &s.mesh.positions[3 * size_t(v)];
    const float* q = &moves.positions[3 * i];
    // Along the leaf normal (the sphere's radial direction, up to the facets' average), outward,
    // by at most the limit.
    double offset2 = 0;
    for (int k = 0; k < 3; ++k) offset2 += std::pow(double(q[k]) - p[k], 2);
    const double offset = std::sqrt(offset2);
    EXPECT_GT(length3(q), length3(p)) << "outward on a convex surface, vertex " << v;
    EXPECT_LE(offset, kMaxOffsetPerEdge * shortest[w] * (1 + 1e-6) + 1e-7) << v;
    double radial = 0;
    for (int k = 0; k < 3; ++k) radial += (double(q[k]) - p[k]) * p[k] / length3(p);
    EXPECT_GT(radial, 0.99 * offset) << "along the normal, vertex " << v;
    // All copies of a position: the same bits.
    std::array<float, 3> bits{q[0], q[1], q[2]};
    auto [it, fresh] = by_position.insert({w, bits});
    if (!fresh) {
      EXPECT_EQ(std::memcmp(it->second.data(), bits.data(), 12), 0) << "copies of welded " << w;
    }
  }
  // Every copy of a moved position moves (the UV sphere's seam has two per position).
  bool seam = false;
  for (uint32_t v : s.tris.corners)
    if (by_position.count(s.welded.weld[v])) {
      EXPECT_TRUE(moved.count(v)) << "copy " << v << " left behind";
      seam |= v != s.welded.weld[v];
    }
  EXPECT_TRUE(seam) << "the test sphere has a seam whose copies moved";
}

TEST(VertexPlacement, DoesNotDependOnTheWinding) {
  GroupSetup s(make_sphere(12, 24));
  Mesh reversed = s.mesh;
  for (size_t t = 0; t < reversed.triangle_count(); ++t) std::swap(reversed.indices[3 * t + 1], reversed.indices[3 * t + 2]);
  GroupSetup r(reversed);
  const VertexMoves a = s.place(), b = r.place();
  std::map<uint32_t, std::array<float, 3>> pa, pb;
  for (size_t i = 0; i < a.vertex.size(); ++i) pa[a.vertex[i]] = {a.positions[3 * i], a.positions[3 * i + 1], a.positions[3 * i + 2]};
  for (size_t i = 0; i < b.vertex.size(); ++i) pb[b.vertex[i]] = {b.positions[3 * i], b.positions[3 * i + 1], b.positions[3 * i + 2]};
  ASSERT_FALSE(pa.empty());
  EXPECT_EQ(pa, pb) << "inward normals and a negative sag give the same outward move";
}

TEST(VertexPlacement, LeavesMeshBordersCreasesAndPerCornerPositionsWhereTheyAre) {
  {  // A hemisphere-like cap: its open border stays.
    Mesh m = make_sphere(16, 32);
    std::vector<uint32_t> kept;
    for (size_t t = 0; t < m.triangle_count(); ++t) {
      bool north = true;
      for (int k = 0; k < 3; ++k) north &= m.positions[3 * m.indices[3 * t + k] + 2] > 0.0f;
      if (north) kept.insert(kept.end(), &m.indices[3 * t], &m.indices[3 * t] + 3);
    }
    m.indices = kept;
    GroupSetup s(m);
    s.mesh_border.assign(s.mesh.vertex_count(), 0);
    std::map<uint64_t, int> uses;
    for_each_welded_edge(s.welded, s.tris.corners, [&](uint32_t a, uint32_t b) { ++uses[edge_key(a, b)]; });
    for (auto [e, n] : uses)
      if (n == 1) s.mesh_border[uint32_t(e >> 32)] = s.mesh_border[uint32_t(e)] = 1;
    const VertexMoves moves = s.place();
    EXPECT_FALSE(moves.vertex.empty());
    for (uint32_t v : moves.vertex) EXPECT_FALSE(s.mesh_border[s.welded.weld[v]]) << v;
  }
  {  // A grid folded by 90 degrees along x = 0.5: the crease vertices and the flat faces stay.
    Mesh m = make_grid(8);
    for (size_t v = 0; v < m.vertex_count(); ++v) {
      float* p = &m.positions[3 * v];
      if (p[0] > 0.5f) p[2] = p[0] - 0.5f, p[0] = 0.5f;
    }
    GroupSetup s(m);
    EXPECT_TRUE(s.place().vertex.empty()) << "flat faces have no sag, the crease is no smooth vertex";
  }
  {  // Per-corner positions (every triangle its own vertices): none moves.
    GroupSetup s(make_per_corner(make_sphere(10, 20)));
    EXPECT_TRUE(s.place().vertex.empty());
  }
}

// A placed corner is measured: on a flat grid, one interior vertex lifted by h (as a fresh id,
// the way a group measures its moves) lies h from the leaves, and no other lattice point of its
// triangles is as far (the nearest edge points lie 2h/3 away).
TEST(VertexPlacement, PlacedCornerIsMeasured) {
  const Mesh m = make_grid(8);
  GroupSetup s(m);
  uint32_t lifted = kNone;
  for (uint32_t v = 0; v < m.vertex_count() && lifted == kNone; ++v)
    if (std::fabs(m.positions[3 * v] - 0.5f) < 1e-6f && std::fabs(m.positions[3 * v + 1] - 0.5f) < 1e-6f) lifted = v;
  ASSERT_NE(lifted, kNone);
  const float h = 0.01f;
  const float moved[3] = {m.positions[3 * lifted], m.positions[3 * lifted + 1], m.positions[3 * lifted + 2] + h};
  const uint32_t origin[1] = {lifted};
  const FreshVertices fresh{uint32_t(m.vertex_count()), 1, moved, origin, origin};
  TriangleSet placed = s.tris;
  for (uint32_t& v : placed.corners)
    if (v == lifted) v = fresh.first;
  for (float floor : {0.0f, 0.5f * h}) {
    const float d = leaf_deviation(s.leaves, m, s.tris, placed, floor, nullptr, nullptr, &fresh);
    EXPECT_GE(d, h) << "floor " << floor;
    EXPECT_LE(d, std::nextafter(h, 1.0f) * 1.0001f) << "floor " << floor;
  }
  // Without the lift the placed surface is the leaves: the floor.
  EXPECT_EQ(leaf_deviation(s.leaves, m, s.tris, s.tris, 0.0f), 0.0f);
}

// Flips on the placed surface (spec/dag.md §3, Edge flips, with placement) are measured from
// the placed surface's record: the changed triangles' points, and the recorded places (moved
// corners and skipped input edges with a moved end at their bound) beyond the running maximum.
// That must give what measuring the whole flipped surface gives, bit for bit, at any floor.
TEST(VertexPlacement, FlipsOnThePlacedSurfaceMeasureAsTheWholeSurfaceDoes) {
  Mesh m = make_sphere(16, 32);
  for (size_t v = 0; v < m.vertex_count(); ++v) {  // bumps: the moves are not all alike
    float* p = &m.positions[3 * v];
    const double bump = 1.0 + 0.05 * std::sin(5.0 * p[0]) * std::sin(4.0 * p[1] + 1.0);
    for (int k = 0; k < 3; ++k) p[k] = float(p[k] * bump);
  }
  GroupSetup s(m);
  // The default share (small moves: with a floor most moved points are skipped, recorded at
  // their bound) and 8x it (most at the edge limit: the moved corners are the farthest points);
  // few pairs flipped (most corners stay in unchanged triangles, where only the record knows
  // them) and many (the maximum falls below skipped places' bounds).
  const double kFarShare = 8 * kPlacementShare;
  size_t corner_peaks = 0;
  ThreadPool pool(3);  // the measurements without a record also in pieces on a pool: the same value
  for (const double share : {kPlacementShare, kFarShare})
    for (const uint32_t stride : {3u, 41u}) {  // triangles between the pairs flipped
      const VertexMoves moves = s.place(share);
      ASSERT_FALSE(moves.vertex.empty());
      const uint32_t first = uint32_t(m.vertex_count());
      std::vector<uint32_t> origin(moves.vertex.size()), fresh_id(m.vertex_count(), kNone);
      for (size_t i = 0; i < moves.vertex.size(); ++i) {
        origin[i] = s.leaves.origin(moves.vertex[i]);
        fresh_id[moves.vertex[i]] = first + uint32_t(i);
      }
      const FreshVertices fresh{first, uint32_t(moves.vertex.size()), moves.positions.data(), origin.data(),
                                moves.vertex.data()};
      TriangleSet placed = s.tris;
      for (uint32_t& v : placed.corners)
        if (fresh_id[v] != kNone) v = fresh_id[v];
      // (a, b, c), (b, a, d) become (c, a, d), (d, b, c).
      TriangleSet flipped = placed;
      std::vector<uint8_t> changed(placed.triangle_count(), 0);
      std::map<std::pair<uint32_t, uint32_t>, uint32_t> use;  // directed welded edge -> 3t + j
      auto w = [&](uint32_t v) { return s.welded.weld[v < first ? v : moves.vertex[v - first]]; };
      for (uint32_t t = 0; t < placed.triangle_count(); ++t)
        for (uint32_t j = 0; j < 3; ++j)
          use[{w(placed.corners[3 * t + j]), w(placed.corners[3 * t + (j + 1) % 3])}] = 3 * t + j;
      size_t flips = 0;
      for (uint32_t t1 = 0; t1 < placed.triangle_count(); t1 += stride) {
        if (changed[t1]) continue;
        const uint32_t a = placed.corners[3 * t1], b = placed.corners[3 * t1 + 1], c = placed.corners[3 * t1 + 2];
        const auto other = use.find({w(b), w(a)});
        if (other == use.end()) continue;
        const uint32_t t2 = other->second / 3, j2 = other->second % 3;
        if (changed[t2] || t2 == t1) continue;
        const uint32_t d = placed.corners[3 * t2 + (j2 + 2) % 3];
        if (w(c) == w(d)) continue;
        flipped.corners[3 * t1] = c, flipped.corners[3 * t1 + 1] = a, flipped.corners[3 * t1 + 2] = d;
        flipped.corners[3 * t2] = d, flipped.corners[3 * t2 + 1] = b, flipped.corners[3 * t2 + 2] = c;
        changed[t1] = changed[t2] = 1;
        ++flips;
      }
      ASSERT_GE(flips, 5u);
      const float whole = leaf_deviation(s.leaves, m, s.tris, placed, 0.0f, nullptr, nullptr, &fresh);
      ASSERT_GT(whole, 0.0f);
      for (const double at : {0.0, 0.2, 0.5, 0.8, 0.95}) {
        const float floor = float(at * whole);
        LatticePeak peak;
        LatticeRecord record;
        const float error = leaf_deviation(s.leaves, m, s.tris, placed, floor, &peak, &record, &fresh);
        EXPECT_EQ(error, leaf_deviation(s.leaves, m, s.tris, placed, floor, nullptr, nullptr, &fresh)) << floor;
        EXPECT_EQ(error, leaf_deviation(s.leaves, m, s.tris, placed, floor, nullptr, nullptr, &fresh, &pool)) << floor;
        // Every moved corner is recorded (visited, or skipped at its bound) at or above its distance.
        ASSERT_EQ(record.fresh.size(), moves.vertex.size());
        for (size_t i = 0; i < moves.vertex.size(); ++i) {
          uint32_t hint = kNone;
          const float* p = &moves.positions[3 * i];
          EXPECT_GE(record.fresh[i].d2, s.leaves.tree.nearest_distance_squared(DVec3{p[0], p[1], p[2]}, &hint)) << i;
        }
        corner_peaks += peak.corner;
        const float whole_flipped = leaf_deviation(s.leaves, m, s.tris, flipped, floor, nullptr, nullptr, &fresh);
        EXPECT_EQ(leaf_deviation_after_change(s.leaves, m, s.tris, flipped, changed, record, floor, &fresh), whole_flipped)
            << "share " << share << " stride " << stride << " floor " << floor;
        EXPECT_EQ(leaf_deviation_after_change(s.leaves, m, s.tris, flipped, changed, record, floor, &fresh, &pool),
                  whole_flipped)
            << "share " << share << " stride " << stride << " floor " << floor << " on a pool";
      }
    }
  EXPECT_GT(corner_peaks, 0u) << "a moved corner is the farthest point";
}

ClusterDag build_with(const Mesh& m, unsigned threads, bool placement, ErrorBound bound = ErrorBound::kMeasured) {
  BuildOptions o;
  o.threads = threads;
  o.vertex_placement = placement;
  o.error_bound = bound;
  return build_dag(m, o);
}

// Input vertex records (position, normal, uv bits) and positions.
struct InputVertices {
  std::set<std::array<uint32_t, 8>> records;
  std::set<std::array<uint32_t, 3>> positions;
  std::set<std::array<uint32_t, 5>> attributes;  // normal and uv bits
};
std::array<uint32_t, 8> record_of(const float* p, const float* n, const float* uv) {
  std::array<uint32_t, 8> key{};
  std::memcpy(key.data(), p, 12);
  if (n) std::memcpy(key.data() + 3, n, 12);
  if (uv) std::memcpy(key.data() + 6, uv, 8);
  return key;
}
InputVertices input_vertices(const Mesh& m) {
  InputVertices in;
  for (size_t v = 0; v < m.vertex_count(); ++v) {
    const auto key = record_of(&m.positions[3 * v], m.normals.empty() ? nullptr : &m.normals[3 * v],
                               m.uvs.empty() ? nullptr : &m.uvs[2 * v]);
    in.records.insert(key);
    in.positions.insert({key[0], key[1], key[2]});
    in.attributes.insert({key[3], key[4], key[5], key[6], key[7]});
  }
  return in;
}

TEST(VertexPlacement, BuiltDagMovesVerticesVerifiesAndIsByteIdenticalForAnyThreadCount) {
  const Mesh m = make_sphere(48, 96);  // uv seam: positions with two copies
  const ClusterDag d1 = build_with(m, 1, true), d2 = build_with(m, 2, true), d3 = build_with(m, 3, true);
  BuiltScene a, b, c;
  a.meshes.push_back(d1), b.meshes.push_back(d2), c.meshes.push_back(d3);
  const std::vector<uint8_t> bytes = encode_dag_file(a);
  EXPECT_EQ(bytes, encode_dag_file(b));
  EXPECT_EQ(bytes, encode_dag_file(c));
  const InputVertices in = input_vertices(m);
  size_t moved = 0, leaf_vertices = 0;
  for (const DagCluster& k : d1.clusters)
    for (uint32_t i = 0; i < k.vertex_count; ++i) {
      const size_t v = size_t(k.vertex_offset) + i;
      const auto key = record_of(&d1.positions[3 * v], d1.normals.empty() ? nullptr : &d1.normals[3 * v],
                                 d1.uvs.empty() ? nullptr : &d1.uvs[2 * v]);
      if (k.level == 0) {
        ++leaf_vertices;
        EXPECT_TRUE(in.records.count(key)) << "leaves are the input";
        continue;
      }
      if (in.positions.count({key[0], key[1], key[2]})) {
        EXPECT_TRUE(in.records.count(key)) << "an unmoved vertex is an input vertex";
      } else {
        ++moved;
        EXPECT_TRUE(in.attributes.count({key[3], key[4], key[5], key[6], key[7]})) << "a moved vertex keeps an input vertex's attributes";
      }
    }
  EXPECT_GT(moved, leaf_vertices / 20) << "a sphere's coarser levels move vertices";
  VerifyOptions vo;
  vo.threads = 2;
  const VerifyReport r = verify_dag(d1, vo);
  EXPECT_TRUE(r.ok());
  EXPECT_GE(r.error_ratio.median, 0.7) << "stored errors stay tight";
}

TEST(VertexPlacement, CertifiedBuildOfPlacedVerticesIsProven) {
  Mesh m = make_sphere(24, 48);
  for (size_t v = 0; v < m.vertex_count(); ++v) {  // bumps: curvature that varies
    float* p = &m.positions[3 * v];
    const double bump = 1.0 + 0.03 * std::sin(9.0 * p[0]) * std::sin(7.0 * p[1] + 1.0) * std::cos(5.0 * p[2]);
    for (int k = 0; k < 3; ++k) p[k] = float(p[k] * bump);
  }
  const ClusterDag d = build_with(m, 2, true, ErrorBound::kCertified);
  VerifyOptions vo;
  vo.threads = 2;
  vo.checks = kCheckAll | kCheckCertifiedBound;
  EXPECT_TRUE(verify_dag(d, vo).ok());
  // Stored at least the deviation on a dense lattice (16 steps), point for point, which a
  // certified bound must be (a moved corner is such a point too).
  VerifyOptions dense;
  dense.threads = 2;
  dense.error_samples_per_edge = 16;
  const ClusterDeviation deviation = measure_cluster_deviation(d, dense);
  size_t checked = 0;
  for (size_t c = 0; c < d.clusters.size(); ++c)
    if (d.clusters[c].generating_group != kNone) {
      EXPECT_GE(double(d.clusters[c].lod_error), deviation.distance[c]) << "cluster " << c;
      ++checked;
    }
  EXPECT_GT(checked, 0u);
}

TEST(VertexPlacement, WithoutPlacementEveryStoredVertexIsAnInputVertex) {
  const Mesh m = make_sphere(24, 48);
  const ClusterDag d = build_with(m, 2, false);
  const InputVertices in = input_vertices(m);
  for (size_t v = 0; v < d.positions.size() / 3; ++v)
    ASSERT_TRUE(in.records.count(record_of(&d.positions[3 * v], d.normals.empty() ? nullptr : &d.normals[3 * v],
                                           d.uvs.empty() ? nullptr : &d.uvs[2 * v])))
        << v;
}

}  // namespace
}  // namespace vgeo::test::vertex_placement
