// The welded input mesh and what is measured on welded ids (spec/dag.md §Build): position
// welding, degenerate triangles and fins, the open and distinct edges of a cluster.
#include <algorithm>
#include <array>
#include <cassert>
#include <cstring>

#include "vgeo/core/process_memory.h"
#include "vgeo/dag/build_internal.h"

namespace vgeo::build_detail {

namespace {

uint64_t hash_position(const float* p) {
  uint32_t b[3];
  std::memcpy(b, p, sizeof(b));
  uint64_t h = 0x9E3779B97F4A7C15ull;
  for (uint32_t x : b) {
    h ^= x;
    h *= 0xFF51AFD7ED558CCDull;
    h ^= h >> 29;
  }
  return h;
}

// Vertices whose first slots are prefetched together: their misses overlap (the 1M sphere's weld
// took 7.2-8.3 CPU-ms without, 4.7-5.5 with (minimum of 20 runs, 4 rounds); 32 the same).
constexpr size_t kWeldPrefetchVertices = 16;

}  // namespace

WeldedMesh weld_positions(const Mesh& mesh) {
  const size_t n = mesh.vertex_count();
  WeldedMesh w;
  w.mesh = &mesh;
  reserve_huge_pages(w.weld, n);
  w.weld.resize(n);
  // Open addressing, table at least twice the vertex count: expected O(1) probes.
  size_t cap = 16;
  while (cap < 2 * n) cap <<= 1;
  std::vector<uint32_t> table;
  reserve_huge_pages(table, cap);
  table.assign(cap, kNone);
  const float* pos = mesh.positions.data();
  size_t first_slot[kWeldPrefetchVertices];
  for (size_t batch = 0; batch < n; batch += kWeldPrefetchVertices) {
    const size_t count = std::min(kWeldPrefetchVertices, n - batch);
    for (size_t i = 0; i < count; ++i) {
      first_slot[i] = hash_position(pos + 3 * (batch + i)) & (cap - 1);
      __builtin_prefetch(&table[first_slot[i]], 1);
    }
    for (size_t i = 0; i < count; ++i) {
      const size_t v = batch + i;
      for (size_t slot = first_slot[i];; slot = (slot + 1) & (cap - 1)) {
        const uint32_t e = table[slot];
        if (e == kNone) {
          table[slot] = uint32_t(v);
          w.weld[v] = uint32_t(v);
          break;
        }
        if (std::memcmp(pos + 3 * e, pos + 3 * v, 12) == 0) {
          w.weld[v] = e;
          break;
        }
      }
    }
  }
  reserve_huge_pages(w.copies, n);
  w.copies.assign(n, 0);
  for (size_t v = 0; v < n; ++v) {
    uint8_t& c = w.copies[w.weld[v]];
    if (c < 255) ++c;  // saturates: only "more than kMaxSeamWedges" is asked
  }
  return w;
}

void count_local_edges(const uint32_t* vertices, size_t vertex_count, const uint16_t* local, size_t triangles,
                       uint64_t* open_edges, uint64_t* all_edges, std::vector<uint64_t>* open_keys) {
  // Uses per edge in two bit matrices over (lower, higher) local id: `once` (used), `more`
  // (used again). No hashing, no probing, no branch on first or later use: an open addressing
  // table of the welded keys cost a multiply and an unpredictable probe per edge. A cluster's
  // ≤ 255 positions (kMaxClusterVertices) need ≤ 65,025 bits per matrix, on the stack; only
  // the vertex_count² bits in use are cleared (~800 bytes each for a closed surface's ~80).
  constexpr size_t kStackWords = (size_t(kMaxClusterVertices) * kMaxClusterVertices + 63) / 64;
  const size_t bits = vertex_count * vertex_count, words = (bits + 63) / 64;
  uint64_t stack_once[kStackWords], stack_more[kStackWords];
  std::vector<uint64_t> heap;
  uint64_t *once = stack_once, *more = stack_more;
  if (words > kStackWords) {
    heap.assign(2 * words, 0);
    once = heap.data(), more = heap.data() + words;
  } else {
    std::fill(once, once + words, uint64_t(0));
    std::fill(more, more + words, uint64_t(0));
  }
  auto bit_of = [vertex_count](uint32_t a, uint32_t b) { return a < b ? a * vertex_count + b : b * vertex_count + a; };
  // Each edge's first use, (a << kLocalBits) | b in corner order, written at index `all` whether or
  // not it is one (no branch: a later use is overwritten by the next first use). The open
  // edges are then the first uses never used again: counted, and their keys listed in corner
  // order, from these ~half of the corners instead of a pass over the matrices and the corners.
  constexpr uint32_t kLocalBits = 16;  // a local id is a uint16_t
  constexpr size_t kStackCorners = 3 * size_t(kMaxClusterTriangles);
  uint32_t stack_first[kStackCorners];
  std::vector<uint32_t> heap_first;
  uint32_t* first_use = stack_first;
  if (3 * triangles > kStackCorners) heap_first.resize(3 * triangles), first_use = heap_first.data();
  uint64_t all = 0;
  for (size_t t = 0; t < triangles; ++t)
    for (int k = 0; k < 3; ++k) {
      const uint32_t a = local[3 * t + k], b = local[3 * t + (k == 2 ? 0 : k + 1)];
      if (a == b) continue;
      const size_t i = bit_of(a, b);
      const uint64_t mask = uint64_t(1) << (i & 63), seen = once[i >> 6] & mask;
      more[i >> 6] |= seen;
      once[i >> 6] |= mask;
      first_use[all] = (a << kLocalBits) | b;
      all += seen == 0;
    }
  uint64_t open = 0;
  uint64_t stack_keys[kStackCorners];
  std::vector<uint64_t> heap_keys;
  uint64_t* keys = stack_keys;
  if (open_keys && all > kStackCorners) heap_keys.resize(all), keys = heap_keys.data();
  for (size_t j = 0; j < all; ++j) {
    const uint32_t a = first_use[j] >> kLocalBits, b = first_use[j] & ((1u << kLocalBits) - 1);
    const size_t i = bit_of(a, b);
    if ((more[i >> 6] >> (i & 63) & 1) != 0) continue;
    if (open_keys) keys[open] = edge_key(vertices[a], vertices[b]);
    ++open;
  }
  if (open_keys && open > 0) {
    open_keys->reserve(open_keys->size() + open);
    open_keys->insert(open_keys->end(), keys, keys + open);
    // (Not sorted: group_clusters sorts every cluster's keys together, and a cluster's are
    // distinct, so their order within the cluster changes nothing.)
  }
  *open_edges = open;
  *all_edges = all;
}

void count_cluster_edges(const WeldedMesh& welded, const TriangleSet& cluster, uint64_t* open_edges,
                         uint64_t* all_edges, std::vector<uint64_t>* open_keys) {
  // Local ids of the welded positions through an open addressing table (≥ 2 slots per corner:
  // a load ≤ 1/2), on the stack. A cluster has ≤ 384 corners: 16-bit local ids, and bit
  // matrices of ≤ 384² bits (count_local_edges).
  constexpr size_t kStackSlots = 1024;
  const size_t corners = cluster.corners.size();
  assert(cluster.triangle_count() <= kMaxClusterTriangles);
  size_t slots = 16;
  int shift = 32 - 4;  // hash = top log2(slots) bits of a 32-bit multiplicative hash
  while (slots < 2 * corners) slots <<= 1, --shift;
  uint32_t stack_key[kStackSlots];
  uint16_t stack_id[kStackSlots];
  std::vector<uint32_t> heap_key, vertices;
  std::vector<uint16_t> heap_id, local(corners);
  uint32_t* key = stack_key;
  uint16_t* id = stack_id;
  if (slots > kStackSlots) {
    heap_key.resize(slots), heap_id.resize(slots);
    key = heap_key.data(), id = heap_id.data();
  }
  std::fill(key, key + slots, kNone);
  vertices.reserve(corners);
  for (size_t i = 0; i < corners; ++i) {
    const uint32_t w = welded.weld[cluster.corners[i]];
    size_t h = size_t((w * 0x9E3779B1u) >> shift);
    while (key[h] != kNone && key[h] != w) h = (h + 1) & (slots - 1);
    if (key[h] == kNone) key[h] = w, id[h] = uint16_t(vertices.size()), vertices.push_back(w);
    local[i] = id[h];
  }
  count_local_edges(vertices.data(), vertices.size(), local.data(), cluster.triangle_count(), open_edges, all_edges,
                    open_keys);
}

bool is_degenerate(const WeldedMesh& welded, const uint32_t* corners) {
  const uint32_t a = welded.weld[corners[0]], b = welded.weld[corners[1]], c = welded.weld[corners[2]];
  if (a == b || b == c || c == a) return true;
  const Mesh& mesh = *welded.mesh;
  double p[3][3];
  for (int k = 0; k < 3; ++k)
    for (int j = 0; j < 3; ++j) p[k][j] = mesh.positions[3 * size_t(corners[k]) + size_t(j)];
  double e[3][3], longest2 = 0;
  for (int k = 0; k < 3; ++k) {
    double l2 = 0;
    for (int j = 0; j < 3; ++j) {
      e[k][j] = p[(k + 1) % 3][j] - p[k][j];
      l2 += e[k][j] * e[k][j];
    }
    longest2 = std::max(longest2, l2);
  }
  const double n[3] = {e[0][1] * e[2][2] - e[0][2] * e[2][1], e[0][2] * e[2][0] - e[0][0] * e[2][2],
                       e[0][0] * e[2][1] - e[0][1] * e[2][0]};
  // |n| = longest edge × height: height < h·longest  <=>  |n|^2 < h^2·longest^4.
  const double n2 = n[0] * n[0] + n[1] * n[1] + n[2] * n[2];
  return n2 < kDegenerateRelativeHeight * kDegenerateRelativeHeight * longest2 * longest2;
}

FinSet find_fins(const WeldedMesh& welded, ThreadPool& pool, std::vector<uint8_t>* degenerate) {
  const Mesh& mesh = *welded.mesh;
  const size_t n = mesh.triangle_count();
  if (degenerate) degenerate->assign(n, 1);
  // Collinear slivers on three distinct positions, per task in triangle order (deterministic).
  const size_t tasks = (n + kFinScanTriangles - 1) / kFinScanTriangles;
  std::vector<std::vector<uint32_t>> found(tasks);
  pool.parallel_for(tasks, [&](size_t k) {
    for (size_t t = k * kFinScanTriangles; t < std::min(n, (k + 1) * kFinScanTriangles); ++t) {
      const uint32_t* c = &mesh.indices[3 * t];
      const uint32_t a = welded.weld[c[0]], b = welded.weld[c[1]], d = welded.weld[c[2]];
      if (a == b || b == d || d == a) continue;  // degenerate (the flag's default), not a sliver
      const bool sliver = is_degenerate(welded, c);
      if (sliver) found[k].push_back(uint32_t(t));
      if (degenerate) (*degenerate)[t] = uint8_t(sliver);
    }
  });
  std::vector<uint32_t> slivers;
  for (const auto& f : found) slivers.insert(slivers.end(), f.begin(), f.end());
  if (slivers.empty()) return {};
  // Parity of every welded edge at a sliver's positions, over the whole mesh.
  std::vector<uint8_t> at_sliver(mesh.vertex_count(), 0), odd_end(mesh.vertex_count(), 0);
  for (uint32_t t : slivers)
    for (int k = 0; k < 3; ++k) at_sliver[welded.weld[mesh.indices[3 * size_t(t) + k]]] = 1;
  std::vector<uint64_t> edges;
  for_each_welded_edge(welded, mesh.indices, [&](uint32_t a, uint32_t b) {
    if (a != b && (at_sliver[a] || at_sliver[b])) edges.push_back(edge_key(a, b));
  });
  std::sort(edges.begin(), edges.end());
  for (size_t i = 0; i < edges.size();) {
    size_t j = i + 1;
    while (j < edges.size() && edges[j] == edges[i]) ++j;
    if ((j - i) % 2 == 1) odd_end[uint32_t(edges[i] >> 32)] = odd_end[uint32_t(edges[i])] = 1;
    i = j;
  }
  FinSet fins;
  for (uint32_t t : slivers) {
    const uint32_t* c = &mesh.indices[3 * size_t(t)];
    if (!odd_end[welded.weld[c[0]]] || !odd_end[welded.weld[c[1]]] || !odd_end[welded.weld[c[2]]]) continue;
    std::array<uint32_t, 3> key{c[0], c[1], c[2]};
    std::sort(key.begin(), key.end());
    fins.push_back(key);
  }
  std::sort(fins.begin(), fins.end());
  return fins;
}

}  // namespace vgeo::build_detail
