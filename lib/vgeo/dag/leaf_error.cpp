// A simplified group's deviation from the original surface (spec/dag.md §Error): the stored
// error is what lib/vgeo/verify measures (ERROR_BOUND), so the builder measures the same thing
// the same way: every lattice point of the simplified triangles (lib/vgeo/core/surface_distance.h,
// kErrorLatticeSubdivisions, the same point coordinates) against *all* leaf triangles, exact
// nearest distance in double. Measuring against the group's input (its children) and adding
// the children's error instead sums one bound per level: honest, but loose (measured:
// docs/acceptance/issue15.md §2).
// Based on: Cignoni, Rocchini, Scopigno, "Metro: Measuring Error on Simplified Surfaces",
// Computer Graphics Forum 17(2), 1998 (one-sided distance of sample points to the original
// surface); Karis et al., "Nanite: A Deep Dive", SIGGRAPH 2021, §"Error metric" (a mesh
// distance instead of the quadrics' estimate); the walk: Devillers, Pion, Teillaud, "Walking
// in a Triangulation", IJFCS 13(2), 2002 (the visibility walk, never stepping straight back).
//
// Only the maximum is wanted, and only above a floor (the children's stored error, which the
// parent's stored error takes the max with anyway): a point with *some* leaf triangle within
// the running threshold cannot raise the maximum and needs no nearest search. That triangle
// is looked for by walking over the leaf surface (edge adjacency by welded position) from
// the last one found to the triangle the point projects into, tested with the tree's own
// triangle test; only when the walk fails does the tree decide, in one search that stops at
// the first leaf triangle within the threshold or else finds the exact nearest. The walk
// proves "within" only, so the result is the tree's, bit for bit
// (docs/acceptance/issue23_errspeed.md: 99.5% of the points are decided by a walk of ~2.4 steps).
// A measurement without a record or peak walks every point first and asks the tree for the
// largest walk bound first (deviation_squared; docs/acceptance/issue23_walk38.md).
#include <algorithm>
#include <atomic>
#include <bit>
#include <cmath>
#include <limits>

#include "vgeo/core/process_memory.h"
#include "vgeo/core/thread_pool.h"
#include "vgeo/dag/build_internal.h"

namespace vgeo::build_detail {

namespace {

// Empty slot of the edge set (no edge has both ends ~0u: vertex ids are < 2^32 - 1).
constexpr uint64_t kNoEdge = ~uint64_t(0);
// Vertices per chunk of the parallel adjacency passes, at most (cheap per vertex: large chunks).
constexpr size_t kAdjacencyChunk = size_t(1) << 16;
// A mesh under kAdjacencyChunk vertex ids (bunny00 37,706, armadillo 26,002) was one chunk:
// one thread linked it while the others waited. On a pool the chunks are cut smaller, so each
// thread gets kAdjacencyChunksPerThread of them (uneven lists balance), but not below
// kMinAdjacencyChunk vertices (bunny00's adjacency: ~12 ms of CPU for ~38k vertex ids, ~0.3 us
// each, so a chunk is ~1 ms, far above a pool round's few microseconds).
constexpr size_t kAdjacencyChunksPerThread = 4;
constexpr size_t kMinAdjacencyChunk = size_t(1) << 12;

// The chunk of the adjacency passes over `vertices` welded ids on `pool` (the chunks change
// who computes what, not the result: each vertex's lists and links are its own, and the
// prefix sums add the chunks' totals in chunk order).
size_t adjacency_chunk(size_t vertices, const ThreadPool& pool) {
  if (pool.size() <= 1) return kAdjacencyChunk;
  const size_t even = (vertices + kAdjacencyChunksPerThread * pool.size() - 1) / (kAdjacencyChunksPerThread * pool.size());
  return std::clamp(even, kMinAdjacencyChunk, kAdjacencyChunk);
}
// Triangles a walk visits before the tree takes over. A walk's length is the point's
// distance from its start in leaf triangles, which grows with the level; on the 1M sphere a
// limit of 8 stopped 4.4% of the walks (each then a tree search, over 10× a walk), 64 stopped
// 0.05%; 32 keeps the cost of a hopeless walk (a fold, a hole) within a few tree searches.
constexpr int kMaxWalkSteps = 32;
// Relative margin of the displacement bound (deviation_squared): lattice points are computed
// in double from float corners, a few ulps (2^-52) of the coordinates; 1e-9 is far above that
// and far below any displacement that matters.
constexpr double kDisplacedBoundMargin = 1e-9;

// Vertex placement's leaf normal (LeafSurface::normal) of a vertex from its triangles `list`.
void vertex_normal(const float* positions, const std::vector<uint32_t>& ids, const uint32_t* list, uint32_t count,
                   std::vector<DVec3>& face, float* out) {
  auto at = [&](uint32_t v) { return DVec3{positions[3 * size_t(v)], positions[3 * size_t(v) + 1], positions[3 * size_t(v) + 2]}; };
  face.resize(count);
  DVec3 sum{0, 0, 0};
  for (uint32_t i = 0; i < count; ++i) {
    const uint32_t* c = &ids[3 * size_t(list[i])];
    const DVec3 a = at(c[0]), b = at(c[1]), d = at(c[2]);
    const DVec3 u{b.x - a.x, b.y - a.y, b.z - a.z}, v{d.x - a.x, d.y - a.y, d.z - a.z};
    face[i] = DVec3{u.y * v.z - u.z * v.y, u.z * v.x - u.x * v.z, u.x * v.y - u.y * v.x};  // 2 × area × unit normal
    sum = DVec3{sum.x + face[i].x, sum.y + face[i].y, sum.z + face[i].z};
  }
  const double length = std::sqrt(sum.x * sum.x + sum.y * sum.y + sum.z * sum.z);
  if (!(length > 0)) return;
  const DVec3 n{sum.x / length, sum.y / length, sum.z / length};
  // Triangles without an area (degenerate, fins) face nowhere: they neither count nor veto (they
  // used to veto, and a mesh with a degenerate triangle every few placed no vertex at all).
  for (uint32_t i = 0; i < count; ++i) {
    const double f = std::sqrt(face[i].x * face[i].x + face[i].y * face[i].y + face[i].z * face[i].z);
    if (f > 0 && face[i].x * n.x + face[i].y * n.y + face[i].z * n.z < kCosPlacementCrease * f) return;
  }
  out[0] = float(n.x), out[1] = float(n.y), out[2] = float(n.z);
}

// Parts of the parallel counting sort of sort_triangles_by_vertex: each part counts its
// corners per welded vertex (4 bytes per vertex and part), so at most 4 parts keep that
// transient memory below the leaf surface's own (12 bytes per triangle for `neighbour`); 2
// parts already split the sort evenly on 2 threads, 4 on 4.
constexpr size_t kAdjacencySortParts = 4;

// Triangles by welded vertex (a counting sort of the corners `ids`, 3 per triangle id): the
// list of welded vertex w is triangles[first[w] .. first[w + 1]), in ascending id order. With
// a pool of more than one thread the corners are cut into parts (consecutive triangle ranges)
// that count, and then place, their corners in parallel, each part's entries of a vertex after
// the earlier parts' entries of it: the lists of the one-pass sort, on any thread count. One
// thread keeps the one pass (no per-part counts to allocate and add up).
void sort_triangles_by_vertex(const std::vector<uint32_t>& weld, const std::vector<uint32_t>& ids, ThreadPool& pool,
                              std::vector<uint32_t>& first, std::vector<uint32_t>& triangles) {
  const size_t vertices = weld.size();
  reserve_huge_pages(first, vertices + 1);
  first.assign(vertices + 1, 0);
  triangles.reserve(ids.size());
  prefault_parallel({{triangles.data(), 4 * ids.size()}}, pool);  // (as build_adjacency's arrays)
  triangles.resize(ids.size());
  const size_t parts = std::min<size_t>({size_t(pool.size()), kAdjacencySortParts, ids.size() / 3});
  if (parts <= 1) {
    for (uint32_t v : ids) ++first[weld[v] + 1];
    for (size_t w = 0; w < vertices; ++w) first[w + 1] += first[w];
    for (size_t k = 0; k < ids.size(); ++k) triangles[first[weld[ids[k]]]++] = uint32_t(k / 3);
    for (size_t w = vertices; w-- > 0;) first[w + 1] = first[w];  // back to starts, shifted
    first[0] = 0;
    return;
  }
  auto part_corners = [&](size_t p) {  // [begin, end) of part p's corners: whole triangles
    const size_t triangle_count = ids.size() / 3;
    return std::pair<size_t, size_t>{3 * (triangle_count * p / parts), 3 * (triangle_count * (p + 1) / parts)};
  };
  std::vector<std::vector<uint32_t>> next(parts);  // per part and welded vertex: its count, then its next slot
  pool.parallel_for(parts, [&](size_t p) {
    reserve_huge_pages(next[p], vertices);
    next[p].assign(vertices, 0);
    const auto [begin, end] = part_corners(p);
    for (size_t k = begin; k < end; ++k) ++next[p][weld[ids[k]]];
  });
  // Starts: an exclusive prefix sum over (vertex, part), by chunks of vertices (their totals
  // first, then each chunk from its start).
  const size_t chunk = adjacency_chunk(vertices, pool);
  const size_t chunks = (vertices + chunk - 1) / chunk;
  std::vector<uint32_t> chunk_start(chunks + 1, 0);
  for_chunks(&pool, vertices, chunk, [&](size_t begin, size_t end) {
    uint32_t total = 0;
    for (size_t w = begin; w < end; ++w)
      for (size_t p = 0; p < parts; ++p) total += next[p][w];
    chunk_start[begin / chunk + 1] = total;
  });
  for (size_t c = 0; c < chunks; ++c) chunk_start[c + 1] += chunk_start[c];
  for_chunks(&pool, vertices, chunk, [&](size_t begin, size_t end) {
    uint32_t at = chunk_start[begin / chunk];
    for (size_t w = begin; w < end; ++w) {
      first[w] = at;
      for (size_t p = 0; p < parts; ++p) {
        const uint32_t count = next[p][w];
        next[p][w] = at;
        at += count;
      }
    }
  });
  first[vertices] = uint32_t(ids.size());
  pool.parallel_for(parts, [&](size_t p) {
    const auto [begin, end] = part_corners(p);
    uint32_t* slot = next[p].data();
    for (size_t k = begin; k < end; ++k) triangles[slot[weld[ids[k]]]++] = uint32_t(k / 3);
  });
}

// Lists of at most this many triangles (a welded vertex's; 6 on a regular mesh) find their
// edges' neighbours by a match mask, one bit per entry: a uint32_t holds it.
constexpr uint32_t kMaskedListLength = 32;

// LeafSurface::neighbour of the edges that start at welded vertex u: edge j of triangle
// list[i] starts at u when its corner j is welded to u, and its neighbour is the first other
// entry of u's list (ascending ids) that has the edge's second vertex. u's triangles' welded
// corners are read once into `corners` (3 per list entry) and every edge is matched against
// them. A list within kMaskedListLength entries gets, per edge, the mask of all entries that
// match (no early exit, no branch per entry: where the match falls is unpredictable), and
// takes its lowest bit; a triangle with two corners at u is in the list twice, and neither copy
// is "other".
void link_edges_at(uint32_t u, const uint32_t* list, uint32_t count, const std::vector<uint32_t>& weld,
                   const std::vector<uint32_t>& ids, std::vector<uint32_t>& corners, uint32_t* neighbour) {
  corners.resize(3 * size_t(count));
  for (uint32_t i = 0; i < count; ++i)
    for (int j = 0; j < 3; ++j) corners[3 * i + j] = weld[ids[3 * size_t(list[i]) + j]];
  for (uint32_t i = 0; i < count; ++i)
    for (int j = 0; j < 3; ++j) {
      if (corners[3 * i + j] != u) continue;
      const uint32_t w = corners[3 * i + (j + 1) % 3];
      uint32_t found = kNone;
      if (count <= kMaskedListLength) {
        uint32_t matches = 0;
        for (uint32_t k = 0; k < count; ++k) {
          const bool has_w = (corners[3 * k] == w) | (corners[3 * k + 1] == w) | (corners[3 * k + 2] == w);
          matches |= uint32_t(has_w & (list[k] != list[i])) << k;
        }
        if (matches != 0) found = list[std::countr_zero(matches)];
      } else {
        for (uint32_t k = 0; k < count && found == kNone; ++k)
          if (list[k] != list[i] && (corners[3 * k] == w || corners[3 * k + 1] == w || corners[3 * k + 2] == w)) found = list[k];
      }
      neighbour[3 * size_t(list[i]) + j] = found;
    }
}

// The walk's adjacency (LeafSurface::neighbour, vertex_triangle) from the leaf triangles'
// corners (`ids`, 3 per triangle id), by welded id: triangles by welded vertex
// (sort_triangles_by_vertex), then for each edge the first other triangle of its
// first vertex's list that has its second vertex, vertex by vertex (link_edges_at).
// With `normals`, also LeafSurface::normal: per welded vertex the area-weighted normal of its
// triangles (ascending ids: the same sum on any thread count), 0 where some triangle with an
// area faces more than the crease angle away from it (or none has an area).
void build_adjacency(LeafSurface& s, const WeldedMesh& welded, const std::vector<uint32_t>& ids, ThreadPool& pool,
                     bool normals) {
  const size_t vertices = welded.weld.size();
  const std::vector<uint32_t>& weld = welded.weld;
  std::vector<uint32_t> first, triangles;
  sort_triangles_by_vertex(weld, ids, pool, first, triangles);
  // Fresh arrays (12 bytes per triangle, 4 per vertex): faulted in on every thread first, so
  // their zero fill below runs on mapped pages.
  s.neighbour.reserve(ids.size());
  s.vertex_triangle.reserve(welded.weld.size());
  prefault_parallel({{s.neighbour.data(), 4 * ids.size()}, {s.vertex_triangle.data(), 4 * welded.weld.size()}}, pool);
  s.neighbour.resize(ids.size());
  if (normals) s.normal.assign(3 * vertices, 0.0f);
  const float* positions = welded.mesh->positions.data();
  const size_t chunk = adjacency_chunk(vertices, pool);
  for_chunks(&pool, vertices, chunk, [&](size_t begin, size_t end) {
    std::vector<uint32_t> corners;  // welded corners of the vertex's triangles, 3 per list entry
    std::vector<DVec3> face;        // their area vectors (normals only)
    for (size_t u = begin; u < end; ++u) {
      const uint32_t* list = &triangles[first[u]];
      const uint32_t count = first[u + 1] - first[u];
      if (count == 0) continue;  // not a welded id, or no leaf triangle has it
      if (normals) vertex_normal(positions, ids, list, count, face, &s.normal[3 * u]);
      link_edges_at(uint32_t(u), list, count, weld, ids, corners, s.neighbour.data());
    }
  });
  s.vertex_triangle.resize(welded.weld.size());
  for_chunks(&pool, vertices, chunk, [&](size_t begin, size_t end) {
    for (size_t v = begin; v < end; ++v) {
      const uint32_t w = weld[v];
      s.vertex_triangle[v] = first[w] < first[w + 1] ? triangles[first[w]] : kNone;
    }
  });
}

// Looks for a leaf triangle within sqrt(threshold) of p: walks over the leaf surface from
// triangle *at to the one p projects into (a visibility walk: cross the first edge p lies
// outside of, never straight back), and decides there with the tree's own triangle test
// (surface_distance_impl.h), so a "within" here is one the tree would find. *at gets the
// triangle where the walk stopped: found, or nearby (the tree's starting hint). A walk only
// ever proves "within"; a miss is decided by the tree.
// `*d2` gets the squared distance to the part of the walk's triangle that decided (an upper
// bound of p's distance to the leaves when within). `unchanged_below` (optional): as
// prepared_triangle_within_squared's.
bool walk_within(const LeafSurface& s, DVec3 p, double threshold, uint32_t* at, double* d2,
                 double* unchanged_below = nullptr) {
  const LeafWalkEnd end = walk_leaf_surface(s, p, *at, kMaxWalkSteps);
  *at = end.triangle;
  if (end.projects_inside) {
    if ((*d2 = prepared_plane_distance_squared(p, end.prepared)) <= threshold) return true;
    if (unchanged_below) *unchanged_below = std::min(*unchanged_below, *d2);
    return false;
  }
  // p lies off the triangle's edges (or it has no normal): the nearest edge decides
  return prepared_triangle_within_squared(p, end.prepared, threshold, d2, unchanged_below);
}

// A point of a decision-only measurement whose search waits (deviation_squared): where it is,
// the exact squared distance to the leaf triangle its walk ended in (`bound`: an upper bound of
// its nearest distance, the value the tree's own test gives that triangle) and the walk's end
// (the tree's starting hint).
struct DeferredPoint {
  DVec3 p;
  double bound;
  uint32_t at;
};

// Deferred points resolved together (deviation_squared): the batch's largest bound lifts the
// running maximum near its final value in the first batch (a level-1 group holds ~4,000
// points), and later points enter only beyond it. 256 keeps the batch (10 KB) on the stack:
// a buffer of all of a group's points cost armadillo 0.4 MB of peak memory.
constexpr size_t kDeferredBatch = 256;

// A decision-only measurement on a pool (decided_deviation_squared) is cut into this many
// pieces per thread, each of at least this many triangles: a piece's cost varies (a coarse
// level's points mostly need tree searches, some many), so more pieces than threads balance
// them; a piece re-marks the edges of the triangles before it (a hash insert each) and a
// pool round costs some microseconds, small against a top level's 15-25 us per triangle (the
// 1M sphere's levels 10-11: docs/acceptance/issue23_lone39.md).
constexpr size_t kMeasurePiecesPerThread = 4;
constexpr size_t kMinMeasurePieceTriangles = 16;

}  // namespace

LeafSurface build_leaf_surface(const WeldedMesh& welded, const std::vector<const TriangleSet*>& leaves, ThreadPool& pool,
                               bool normals) {
  std::vector<size_t> first_triangle(leaves.size() + 1, 0);  // per leaf set: its first triangle
  for (size_t i = 0; i < leaves.size(); ++i) first_triangle[i + 1] = first_triangle[i] + leaves[i]->triangle_count();
  // Fresh memory (12 bytes per triangle): its pages faulted in on every thread first, so the
  // resize's zero fill runs on mapped pages (the 1M sphere at two threads: ~6 ms of faults
  // and fill on the calling thread alone before the copy; docs/acceptance/issue23_big41.md).
  std::vector<uint32_t> ids;
  ids.reserve(3 * first_triangle.back());
  prefault_parallel({{ids.data(), 4 * ids.capacity()}}, pool);
  ids.resize(3 * first_triangle.back());
  pool.parallel_for(leaves.size(), [&](size_t i) {
    std::copy(leaves[i]->corners.begin(), leaves[i]->corners.end(), &ids[3 * first_triangle[i]]);
  });
  LeafSurface s;
  s.leaf_vertex_count = uint32_t(welded.weld.size());
  build_adjacency(s, welded, ids, pool, normals);
  // Leaves in cluster order: clusters of spatial chunks in Morton order, each cluster a
  // connected patch, which is the spatial coherence the order-keeping tree needs.
  s.tree = TriangleDistanceTree(welded.mesh->positions.data(), std::move(ids), &pool);
  return s;
}

namespace {

// A float squared is exact in double, and sqrt and the rounding up are monotonic: a maximum
// ≤ floor² rounds to ≤ floor, so points within the floor cannot change the result.
double floor_squared(float floor) { return std::isfinite(floor) && floor > 0 ? double(floor) * double(floor) : 0.0; }

// Positions and walk starts by vertex id: the mesh's (leaf and already placed vertices) and,
// from fresh->first on, a group's moved vertices before their ids are final.
struct VertexSource {
  const LeafSurface& leaves;
  const Mesh& mesh;
  const FreshVertices* fresh;
  bool is_fresh(uint32_t v) const { return fresh && fresh->positions && v >= fresh->first; }
  DVec3 operator()(uint32_t v) const {
    const float* p = is_fresh(v) ? &fresh->positions[3 * size_t(v - fresh->first)] : &mesh.positions[3 * size_t(v)];
    return DVec3{p[0], p[1], p[2]};
  }
  // A leaf triangle at the vertex (or at the leaf vertex it was moved from): a walk's start.
  // The id a moved vertex had before this group placed it (its own id when not moved here).
  uint32_t previous(uint32_t v) const { return is_fresh(v) ? fresh->previous[v - fresh->first] : v; }
  // How far this group moved vertex v (0 when it did not).
  double displacement(uint32_t v) const {
    if (!is_fresh(v)) return 0.0;
    const DVec3 a = (*this)(v), b = (*this)(previous(v));
    return std::sqrt((a.x - b.x) * (a.x - b.x) + (a.y - b.y) * (a.y - b.y) + (a.z - b.z) * (a.z - b.z));
  }
  uint32_t start_triangle(uint32_t v) const {
    return leaves.vertex_triangle[is_fresh(v) ? fresh->origin[v - fresh->first] : leaves.origin(v)];
  }
};

// Visits the lattice points of one place of triangle `tri` (corner ids): edge j's points (j <
// 3), from corner j to corner j + 1, or its interior points (kLatticeInterior). The points of
// for_each_lattice_point (lib/vgeo/core/surface_distance.h, which lib/vgeo/verify samples),
// same formulas: an edge's point i/s is computed from its smaller vertex id.
template <class Visit>
void for_each_place_point(const VertexSource& mesh_vertex, const uint32_t* tri, int place, Visit&& visit) {
  const uint32_t s = kErrorLatticeSubdivisions ? kErrorLatticeSubdivisions : 1;
  if (place != kLatticeInterior) {
    const int j = place;
    const bool forward = tri[j] < tri[(j + 1) % 3];
    const DVec3 e0 = mesh_vertex(forward ? tri[j] : tri[(j + 1) % 3]);
    const DVec3 e1 = mesh_vertex(forward ? tri[(j + 1) % 3] : tri[j]);
    for (uint32_t k = 1; k < s; ++k) {
      const uint32_t i = forward ? k : s - k;
      const double f = double(i) / s;
      visit(DVec3{e0.x + (e1.x - e0.x) * f, e0.y + (e1.y - e0.y) * f, e0.z + (e1.z - e0.z) * f});
    }
    return;
  }
  const DVec3 a = mesh_vertex(tri[0]), b = mesh_vertex(tri[1]), c = mesh_vertex(tri[2]);
  for (uint32_t u = 1; u < s; ++u)
    for (uint32_t w = 1; u + w < s; ++w) {
      const double bu = double(u) / s, bw = double(w) / s, bv = 1.0 - bu - bw;
      visit(DVec3{a.x * bv + b.x * bu + c.x * bw, a.y * bv + b.y * bu + c.y * bw, a.z * bv + b.z * bu + c.z * bw});
    }
}

// The triangles [begin, end) of a simplified set: one piece of a measurement.
struct TriangleRange {
  size_t begin = 0, end = 0;
};

// The running maximum of the pieces of one decision-only measurement measured in parallel
// (decided_deviation_squared): each piece's points skip what cannot raise it, whichever piece
// found it. Only exact nearest distances enter it, so every value it holds is one the whole
// measurement reaches.
struct SharedMaximum {
  std::atomic<double> d2{0.0};
  double load() const { return d2.load(std::memory_order_relaxed); }
  void raise(double v) {
    double now = load();
    while (v > now && !d2.compare_exchange_weak(now, v, std::memory_order_relaxed)) {
    }
  }
};

// One piece of a recording measurement measured in parallel (recorded_deviation_squared). A
// record's values depend on the running maximum at each point, which at the piece's start is
// the maximum of every point before it. A first pass assumes a lower one: `start_d2`, raised
// as it goes by the maxima the pieces before it have reached so far (`earlier`, each a value
// the measurement reaches); its record is the whole measurement's if the true start lies below
// `unchanged_below`, the smallest value any of its points' decisions compared with its assumed
// maximum and found beyond it (every decision is the same for any maximum from the assumed one
// up to below that). A piece rerun from the true start (earlier = null) is the whole
// measurement's.
struct RecordPiece {
  double start_d2 = 0.0;
  const SharedMaximum* earlier = nullptr;  // the pieces before this one: [0, index)
  size_t index = 0;
  SharedMaximum* own = nullptr;  // this piece's running maximum, for the pieces after it
  double unchanged_below = std::numeric_limits<double>::infinity();
};

// leaf_deviation's search (below) before the rounding: the largest squared distance of the
// points beyond floor_d2, or 0 when none lies beyond it. `record` (optional) gets every point
// visited. Only the points of the triangles in `range` are visited, as the whole set's
// measurement visits them (the edges of the triangles before it count as visited); with
// `shared` (decision-only: no peak, no record) the running maximum is also the other pieces'.
// `piece` (a recording piece without moved vertices: RecordPiece): the running maximum starts
// at its start and follows the pieces before it; `record` gets the places of `range` only.
double deviation_squared(const LeafSurface& leaves, const VertexSource& mesh, const TriangleSet& input,
                         const TriangleSet& simplified, double floor_d2, LatticePeak* peak, LatticeRecord* record,
                         TriangleRange range, SharedMaximum* shared = nullptr, RecordPiece* piece = nullptr) {
  // Edges (by original vertex ids, smaller first: the lattice points depend on both) whose
  // points need no visit: edges of the input when the input is itself simplified (floor > 0)
  // — the same points were measured for the members, within their stored error ≤ floor —
  // and edges already visited. Open addressing, load ≤ 1/2.
  size_t slots = 16;
  int shift = 60;  // hash = top log2(slots) bits of a multiplicative hash
  // Keys: ≤ 3 per triangle of each set (moved corners are kept apart: corner_seen).
  const size_t fresh_keys = mesh.fresh ? mesh.fresh->count : 0;
  while (slots < 2 * (3 * simplified.triangle_count() + (floor_d2 > 0 ? 3 * input.triangle_count() : 0)))
    slots <<= 1, --shift;
  std::vector<uint64_t> edge_slot(slots, kNoEdge);
  auto insert_edge = [&](uint32_t a, uint32_t b) {  // true iff the edge was not in the set
    const uint64_t key = a < b ? (uint64_t(a) << 32 | b) : (uint64_t(b) << 32 | a);
    size_t h = size_t((key * 0x9E3779B97F4A7C15ull) >> shift);
    while (edge_slot[h] != kNoEdge) {
      if (edge_slot[h] == key) return false;
      h = (h + 1) & (slots - 1);
    }
    edge_slot[h] = key;
    return true;
  };
  auto has_edge = [&](uint32_t a, uint32_t b) {
    const uint64_t key = a < b ? (uint64_t(a) << 32 | b) : (uint64_t(b) << 32 | a);
    for (size_t h = size_t((key * 0x9E3779B97F4A7C15ull) >> shift); edge_slot[h] != kNoEdge; h = (h + 1) & (slots - 1))
      if (edge_slot[h] == key) return true;
    return false;
  };
  if (floor_d2 > 0)
    for (size_t t = 0; t < input.triangle_count(); ++t)
      for (int j = 0; j < 3; ++j) insert_edge(input.corners[3 * t + j], input.corners[3 * t + (j + 1) % 3]);

  double best2 = 0.0;
  // A recording piece's assumed maximum of the points before it (RecordPiece).
  double before_d2 = piece ? piece->start_d2 : 0.0;
  auto follow_earlier_pieces = [&]() {
    if (piece && piece->earlier)
      for (size_t k = 0; k < piece->index; ++k) before_d2 = std::max(before_d2, piece->earlier[k].load());
  };
  // The running threshold: a point within it cannot raise the maximum.
  auto running = [&]() { return std::max({best2, floor_d2, before_d2, shared ? shared->load() : 0.0}); };
  auto raise = [&](double d2) {
    best2 = d2;
    if (shared) shared->raise(d2);
    if (piece && piece->own) piece->own->raise(d2);
  };
  // Where a first pass's decisions would change (RecordPiece::unchanged_below).
  double* const unchanged_below = piece && piece->earlier ? &piece->unchanged_below : nullptr;
  // A point's search starts from `at`: a leaf triangle at its simplified triangle's first
  // corner (every corner is a leaf vertex), then the triangle where the previous point's
  // search ended (the points of a triangle are visited in a tour around it), or a leaf
  // triangle at the first corner of an edge whose tour predecessor was skipped.
  uint32_t at = kNone;
  LatticePeak here;  // the place of the points being visited (for `peak`)
  // Points of a placed vertex (its corner; the points of an input edge it ends) lie within its
  // displacement of the points the members measured (within the floor; a leaf vertex at 0): they
  // cannot raise the maximum while floor + displacement is within it. The margin covers the
  // rounding of the lattice points (ulps of the coordinates, far below any displacement).
  const double floor_distance = std::sqrt(floor_d2);
  auto displaced_bound2 = [&](double displacement, DVec3 p) {
    const double scale = std::max({std::fabs(p.x), std::fabs(p.y), std::fabs(p.z)});
    const double bound = (floor_distance + displacement) * (1.0 + kDisplacedBoundMargin) + kDisplacedBoundMargin * scale;
    return bound * bound;
  };
  auto cannot_raise = [&](double bound2) { return bound2 <= running(); };
  // The record's entry for the points being visited: a moved corner's own, else its place's.
  auto record_place = [&]() -> LatticeRecord::Place& {
    return here.corner ? record->fresh[size_t(here.place)] : record->places[4 * size_t(here.triangle) + size_t(here.place)];
  };
  auto note = [&](double d2, uint32_t leaf) {
    LatticeRecord::Place& r = record_place();
    if (d2 > r.d2) r.d2 = d2, r.leaf = leaf;
  };
  auto visit = [&](DVec3 p) {
    const double threshold = running();
    double d2;
    if (at == kNone || !walk_within(leaves, p, threshold, &at, &d2, unchanged_below)) {
      // One tree search: "within" or, when not, the nearest distance.
      d2 = unchanged_below ? leaves.tree.nearest_or_within_squared(p, threshold, &at, unchanged_below)
                           : leaves.tree.nearest_or_within_squared(p, threshold, &at);
      if (d2 > threshold) {
        raise(d2);
        if (peak) *peak = here;
      }
    }
    if (record) note(d2, at);
  };
  // A decision-only measurement (no record, no peak: floor 0's, leaf_deviation_after_change's)
  // defers its tree searches: each point's walk first, keeping its bound (DeferredPoint) when
  // that lies beyond the running maximum; then, for a batch of those, the exact nearest of the
  // largest bound first, which lifts the maximum to its final value or near it at once, and
  // only then the batch's points whose bound still lies beyond it (bunny00: 605 tree searches
  // in 41 such measurements, one at a time, 463 of them raising the maximum). The maximum of
  // the points' nearest distances is the same in any order. A record keeps each point's own
  // walk value, which depends on the running maximum when it was visited, and the peak is the
  // first point in visiting order at the maximum: those measurements visit in order (`visit`).
  const bool defer_searches = !record && !peak;
  DeferredPoint deferred[kDeferredBatch];
  size_t deferred_count = 0;
  auto resolve_deferred = [&]() {
    if (deferred_count == 0) return;
    auto search = [&](DeferredPoint& d) {  // as `visit`'s search: best2 rises to d's nearest beyond the threshold
      const double threshold = running();
      const double d2 = leaves.tree.nearest_or_within_squared(d.p, threshold, &d.at);
      if (d2 > threshold) raise(d2);
    };
    size_t largest = 0;
    for (size_t i = 1; i < deferred_count; ++i)
      if (deferred[i].bound > deferred[largest].bound) largest = i;
    search(deferred[largest]);
    deferred[largest].bound = 0;  // searched
    for (size_t i = 0; i < deferred_count; ++i)
      if (deferred[i].bound > running()) search(deferred[i]);
    deferred_count = 0;
  };
  auto defer = [&](DVec3 p) {
    double bound;
    if (at != kNone) {
      const LeafWalkEnd end = walk_leaf_surface(leaves, p, at, kMaxWalkSteps);
      at = end.triangle;
      bound = end.projects_inside ? prepared_plane_distance_squared(p, end.prepared)
                                  : prepared_triangle_distance_squared(p, end.prepared);
    } else {
      bound = leaves.tree.nearest_distance_squared(p, &at);  // no walk start: the exact distance
    }
    if (!(bound > running())) return;  // within the maximum: it cannot raise it
    if (deferred_count == kDeferredBatch) resolve_deferred();
    deferred[deferred_count++] = {p, bound, at};
  };
  auto measure = [&](DVec3 p) {
    if (defer_searches)
      defer(p);
    else
      visit(p);
  };
  // The points of for_each_lattice_point, triangle by triangle (for_each_place_point).
  // Corners are skipped: a simplified corner is an input vertex (both backends only remove
  // vertices), a corner of a leaf triangle, at distance exactly 0. Which points are visited
  // decides the result, not the order: edge points go from corner j to corner j + 1, so
  // consecutive points are a short walk apart.
  if (record && piece) {
    std::fill(record->places.begin() + 4 * range.begin, record->places.begin() + 4 * range.end, LatticeRecord::Place{});
  } else if (record) {
    record->places.assign(4 * simplified.triangle_count(), LatticeRecord::Place{});
    record->fresh.assign(fresh_keys, LatticeRecord::Place{});
  }
  // Placed corners and input edges with a placed end are visited last, when the running maximum
  // is near its final value, so that most of them need no visit (cannot_raise).
  std::vector<std::pair<uint32_t, int>> displaced;  // (triangle, place: an edge j, or 3 + corner j)
  // Each moved vertex's displacement, once (a vertex ends ~6 of the edges).
  std::vector<double> moved_by(fresh_keys, -1.0);
  // Whether a moved vertex's corner is queued already (moved ids are consecutive from
  // fresh->first: indexed directly, where a key in the edge set cost a probe per corner).
  std::vector<uint8_t> corner_seen(fresh_keys, 0);
  auto first_corner_use = [&](uint32_t v) { return !corner_seen[v - mesh.fresh->first]++; };
  auto displacement = [&](uint32_t v) {
    if (!mesh.is_fresh(v)) return 0.0;
    double& d = moved_by[v - mesh.fresh->first];
    if (d < 0) d = mesh.displacement(v);
    return d;
  };
  for (size_t t = 0; t < range.begin; ++t) {  // (as the loop below marks them)
    const uint32_t* tri = &simplified.corners[3 * t];
    for (int j = 0; j < 3; ++j) {
      if (mesh.is_fresh(tri[j])) first_corner_use(tri[j]);
      insert_edge(tri[j], tri[(j + 1) % 3]);
    }
  }
  for (size_t t = range.begin; t < range.end; ++t) {
    const uint32_t* tri = &simplified.corners[3 * t];
    follow_earlier_pieces();
    at = mesh.start_triangle(tri[0]);
    here.triangle = uint32_t(t);
    here.corner = false;
    // A moved corner (fresh) is no leaf vertex: measured once, from its leaf vertex's triangle.
    for (int j = 0; j < 3; ++j)
      if (mesh.is_fresh(tri[j]) && first_corner_use(tri[j])) displaced.push_back({uint32_t(t), 3 + j});
    bool after_previous_edge = false;  // the last point visited is on edge j - 1, next to corner j
    for (int j = 0; j < 3; ++j) {
      const uint32_t a = tri[j], b = tri[(j + 1) % 3];
      if (!insert_edge(a, b)) {
        after_previous_edge = false;
        continue;
      }
      if (floor_d2 > 0 && (mesh.is_fresh(a) || mesh.is_fresh(b)) && has_edge(mesh.previous(a), mesh.previous(b))) {
        displaced.push_back({uint32_t(t), j});
        after_previous_edge = false;
        continue;
      }
      // An edge whose tour predecessor was skipped (an input edge, or one visited from the
      // other side) starts from its own first corner, not from wherever the last point was
      // (sphere 1M: 11.40M -> 10.59M walk steps).
      if (j > 0 && !after_previous_edge) at = mesh.start_triangle(tri[j]);
      after_previous_edge = true;
      here.place = j;
      for_each_place_point(mesh, tri, j, measure);
    }
    here.place = kLatticeInterior;
    for_each_place_point(mesh, tri, kLatticeInterior, measure);
  }
  resolve_deferred();
  // A skipped place is recorded with its bound (the walk of a later search starts at its first
  // vertex's leaf triangle).
  for (const auto& [t, place] : displaced) {
    const uint32_t* tri = &simplified.corners[3 * size_t(t)];
    here.triangle = t;
    if (place >= 3) {  // a placed corner: no leaf vertex, measured from its leaf vertex's triangle
      const uint32_t v = tri[place - 3];
      here.corner = true;
      here.place = int(v - mesh.fresh->first);
      const double bound2 = displaced_bound2(displacement(v), mesh(v));
      if (cannot_raise(bound2)) {
        if (record) note(bound2, mesh.start_triangle(v));
        continue;
      }
      at = mesh.start_triangle(v);
      visit(mesh(v));
      continue;
    }
    here.corner = false;
    here.place = place;
    const uint32_t a = tri[place], b = tri[(place + 1) % 3];
    const double moved = std::max(displacement(a), displacement(b));
    const double bound2 = std::max(displaced_bound2(moved, mesh(a)), displaced_bound2(moved, mesh(b)));
    if (cannot_raise(bound2)) {
      if (record) note(bound2, mesh.start_triangle(a));
      continue;
    }
    at = mesh.start_triangle(a);
    for_each_place_point(mesh, tri, place, visit);
  }
  return best2;
}

// A decision-only measurement (no peak, no record) with `pool`: the triangles cut into
// consecutive pieces (kMeasurePiecesPerThread per thread, at least kMinMeasurePieceTriangles
// each) measured in parallel with one running maximum (SharedMaximum), the largest of their
// results kept. The value is deviation_squared's over the whole set, bit for bit: every value
// a piece keeps is an exact nearest distance beyond the floor, every point skipped lies within
// some such value or the floor, and a maximum does not depend on the order it was found in.
// The pieces visit the points the whole set's measurement visits (TriangleRange).
double decided_deviation_squared(const LeafSurface& leaves, const VertexSource& mesh, const TriangleSet& input,
                                 const TriangleSet& simplified, double floor_d2, ThreadPool* pool) {
  const size_t n = simplified.triangle_count();
  const size_t pieces =
      pool && pool->size() > 1 ? std::min(size_t(pool->size()) * kMeasurePiecesPerThread, n / kMinMeasurePieceTriangles) : 1;
  if (pieces <= 1) return deviation_squared(leaves, mesh, input, simplified, floor_d2, nullptr, nullptr, {0, n});
  SharedMaximum shared;
  std::vector<double> best(pieces, 0.0);
  pool->parallel_for(pieces, [&](size_t k) {
    best[k] = deviation_squared(leaves, mesh, input, simplified, floor_d2, nullptr, nullptr,
                                {n * k / pieces, n * (k + 1) / pieces}, &shared);
  });
  return *std::max_element(best.begin(), best.end());
}

// A measurement with a peak and a record (the first of a group with edge flips) with `pool`:
// the triangles cut into pieces as decided_deviation_squared's, each measured in parallel from
// an assumed maximum of the points before it (RecordPiece), then the pieces whose assumption
// could have changed a decision measured again, in parallel, from the true one, which the
// first pass gives: each piece's own largest distance beyond its assumed maximum is exact
// whenever it exceeds the true maximum before the piece. So every piece's record, the peak
// (the first point at the largest distance) and the value are the one-range measurement's, bit
// for bit. Without a pool, or with moved vertices (their points are visited after all others),
// the one-range measurement.
double recorded_deviation_squared(const LeafSurface& leaves, const VertexSource& mesh, const TriangleSet& input,
                                  const TriangleSet& simplified, double floor_d2, LatticePeak* peak,
                                  LatticeRecord* record, ThreadPool* pool) {
  const size_t n = simplified.triangle_count();
  const size_t pieces = pool && pool->size() > 1 && !mesh.fresh && record
                            ? std::min(size_t(pool->size()) * kMeasurePiecesPerThread, n / kMinMeasurePieceTriangles)
                            : 1;
  if (pieces <= 1) return deviation_squared(leaves, mesh, input, simplified, floor_d2, peak, record, {0, n});
  record->places.assign(4 * n, LatticeRecord::Place{});
  record->fresh.clear();
  std::vector<SharedMaximum> reached(pieces);
  std::vector<RecordPiece> piece(pieces);
  std::vector<LatticePeak> piece_peak(pieces);
  std::vector<double> best(pieces, 0.0);
  auto range = [&](size_t k) { return TriangleRange{n * k / pieces, n * (k + 1) / pieces}; };
  pool->parallel_for(pieces, [&](size_t k) {
    piece[k].earlier = reached.data();
    piece[k].index = k;
    piece[k].own = &reached[k];
    best[k] = deviation_squared(leaves, mesh, input, simplified, floor_d2, &piece_peak[k], record, range(k), nullptr,
                                &piece[k]);
  });
  // The true maximum before each piece, and the pieces whose first pass assumed too low a one.
  std::vector<size_t> again;
  double before = 0.0;
  for (size_t k = 0; k < pieces; ++k) {
    if (!(std::max(before, floor_d2) < piece[k].unchanged_below)) {
      piece[k] = RecordPiece{};
      piece[k].start_d2 = before;
      again.push_back(k);
    }
    before = std::max(before, best[k]);
  }
  if (!again.empty())
    pool->parallel_for(again.size(), [&](size_t i) {
      const size_t k = again[i];
      piece_peak[k] = LatticePeak{};
      best[k] = deviation_squared(leaves, mesh, input, simplified, floor_d2, &piece_peak[k], record, range(k), nullptr,
                                  &piece[k]);
    });
  const size_t top = size_t(std::max_element(best.begin(), best.end()) - best.begin());  // the first at the maximum
  if (best[top] > 0) *peak = piece_peak[top];
  return best[top];
}

}  // namespace

float leaf_deviation(const LeafSurface& leaves, const Mesh& mesh, const TriangleSet& input, const TriangleSet& simplified,
                     float floor, LatticePeak* peak, LatticeRecord* record, const FreshVertices* fresh,
                     ThreadPool* pool) {
  if (peak) *peak = LatticePeak{};
  if (record) record->places.clear();
  if (leaves.tree.empty() || simplified.triangle_count() == 0) return floor;
  const VertexSource source{leaves, mesh, fresh};
  const double floor_d2 = floor_squared(floor);
  const double best2 = peak && record ? recorded_deviation_squared(leaves, source, input, simplified, floor_d2, peak, record, pool)
                      : peak || record
                          ? deviation_squared(leaves, source, input, simplified, floor_d2, peak, record,
                                              {0, simplified.triangle_count()})
                          : decided_deviation_squared(leaves, source, input, simplified, floor_d2, pool);
  return std::max(floor, round_up_to_float(std::sqrt(best2)));
}

float leaf_deviation_after_change(const LeafSurface& leaves, const Mesh& mesh, const TriangleSet& input,
                                  const TriangleSet& changed_surface, const std::vector<uint8_t>& changed,
                                  const LatticeRecord& record, float floor, const FreshVertices* fresh,
                                  ThreadPool* pool) {
  if (leaves.tree.empty() || changed_surface.triangle_count() == 0) return floor;
  const double floor_d2 = floor_squared(floor);
  const VertexSource source{leaves, mesh, fresh};
  // The changed triangles' points (new, or on an edge a changed triangle shares), measured.
  TriangleSet now;
  for (size_t t = 0; t < changed_surface.triangle_count(); ++t)
    if (changed[t]) {
      now.corners.insert(now.corners.end(), &changed_surface.corners[3 * t], &changed_surface.corners[3 * t + 3]);
      now.materials.push_back(changed_surface.materials[t]);
    }
  double best2 = now.triangle_count() ? decided_deviation_squared(leaves, source, input, now, floor_d2, pool) : 0.0;
  // Every other point was visited from an unchanged triangle (or is a moved corner): its
  // place's recorded value bounds its distance, so only places recorded beyond the running
  // maximum are searched, largest first.
  std::vector<std::pair<double, uint32_t>> open;  // (recorded value, 4t + place, or the places' count + moved vertex)
  for (size_t k = 0; k < record.places.size() && k / 4 < changed.size(); ++k)
    if (!changed[k / 4] && record.places[k].d2 > std::max(best2, floor_d2)) open.push_back({record.places[k].d2, uint32_t(k)});
  const size_t moved_base = record.places.size();
  for (size_t i = 0; i < record.fresh.size(); ++i)
    if (record.fresh[i].d2 > std::max(best2, floor_d2)) open.push_back({record.fresh[i].d2, uint32_t(moved_base + i)});
  std::sort(open.begin(), open.end(), [](const auto& x, const auto& y) { return x.first > y.first || (x.first == y.first && x.second < y.second); });
  for (const auto& [bound, k] : open) {
    if (bound <= std::max(best2, floor_d2)) break;
    const bool corner = k >= moved_base;
    uint32_t at = corner ? record.fresh[k - moved_base].leaf : record.places[k].leaf;  // where the measurement's walk or search ended
    auto search = [&](DVec3 p) {
      const double threshold = std::max(best2, floor_d2);
      double d2;
      if (at != kNone && walk_within(leaves, p, threshold, &at, &d2)) return;  // as deviation_squared
      d2 = leaves.tree.nearest_or_within_squared(p, threshold, &at);
      if (d2 > threshold) best2 = d2;
    };
    if (corner)
      search(source(fresh->first + uint32_t(k - moved_base)));
    else
      for_each_place_point(source, &changed_surface.corners[3 * size_t(k / 4)], int(k % 4), search);
  }
  return std::max(floor, round_up_to_float(std::sqrt(best2)));
}

LeafWalkEnd walk_leaf_surface(const LeafSurface& s, DVec3 p, uint32_t start, int max_steps) {
  uint32_t t = start, previous = kNone;
  for (int step = 1;; ++step) {
    // Each step needs only the side tests (triangle_region); the whole prepared triangle is
    // made once, for the triangle where the walk ends.
    const DVec3 a = s.tree.corner(t, 0), b = s.tree.corner(t, 1), c = s.tree.corner(t, 2);
    const int region = triangle_region(p, a, b, c);
    const uint32_t next = region == kProjectsInside || region == kNoNormal ? kNone : s.neighbour[3 * size_t(t) + size_t(region)];
    if (next == kNone || next == previous || step == max_steps) {
      LeafWalkEnd end;
      end.triangle = t;
      end.prepared = prepare_triangle(a, b, c);
      end.projects_inside = region == kProjectsInside;
      return end;
    }
    previous = t;
    t = next;
  }
}

}  // namespace vgeo::build_detail
