// The welded input mesh and what is measured on welded ids (spec/dag.md §Build): position
// welding, degenerate triangles and fins, the open and distinct edges of a cluster.
#include <algorithm>
#include <array>
#include <cstring>

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

}  // namespace

WeldedMesh weld_positions(const Mesh& mesh) {
  WeldedMesh w;
  w.mesh = &mesh;
  size_t n = mesh.vertex_count();
  w.weld.resize(n);
  // Open addressing, table at least twice the vertex count: expected O(1) probes.
  size_t cap = 16;
  while (cap < 2 * n) cap <<= 1;
  std::vector<uint32_t> table(cap, kNone);
  const float* pos = mesh.positions.data();
  for (size_t v = 0; v < n; ++v) {
    size_t slot = hash_position(pos + 3 * v) & (cap - 1);
    for (;;) {
      uint32_t e = table[slot];
      if (e == kNone) {
        table[slot] = uint32_t(v);
        w.weld[v] = uint32_t(v);
        break;
      }
      if (std::memcmp(pos + 3 * e, pos + 3 * v, 12) == 0) {
        w.weld[v] = e;
        break;
      }
      slot = (slot + 1) & (cap - 1);
    }
  }
  w.copies.assign(n, 0);
  for (size_t v = 0; v < n; ++v) {
    uint8_t& c = w.copies[w.weld[v]];
    if (c < 255) ++c;  // saturates: only "more than kMaxSeamWedges" is asked
  }
  return w;
}

void count_cluster_edges(const WeldedMesh& welded, const TriangleSet& cluster, uint64_t* open_edges,
                         uint64_t* all_edges, std::vector<uint64_t>* open_keys) {
  // Uses per distinct welded edge in an open addressing table instead of a sort of all keys:
  // only the open keys (a minority) are sorted. The table and the list of filled slots live on
  // the stack up to kStackSlots (every cluster: 4 × 128 triangles fit), so the per-cluster pass
  // allocates nothing and visits only the filled slots. At least 4 slots per triangle: a load
  // ≤ 3/4 if all 3n edges were distinct, about 0.4 on a surface (each inner edge is used
  // twice); an empty slot is one with no use, so only the use counts are cleared (the
  // clearing was a third of this pass at 6 slots per triangle, keys and counts).
  constexpr size_t kStackSlots = 512;
  constexpr size_t kSlotsPerTriangle = 4;
  const size_t n = cluster.triangle_count();
  size_t slots = 16;
  int shift = 60;  // hash = top log2(slots) bits of a multiplicative hash
  while (slots < kSlotsPerTriangle * n) slots <<= 1, --shift;
  uint64_t stack_table[kStackSlots];
  uint32_t stack_uses[kStackSlots], stack_filled[kStackSlots];
  std::vector<uint64_t> heap_table;
  std::vector<uint32_t> heap_uses, heap_filled;
  uint64_t* table = stack_table;
  uint32_t *uses = stack_uses, *filled = stack_filled;
  if (slots > kStackSlots) {
    heap_table.resize(slots);
    heap_uses.resize(slots);
    heap_filled.resize(slots);
    table = heap_table.data(), uses = heap_uses.data(), filled = heap_filled.data();
  }
  std::fill(uses, uses + slots, 0u);
  size_t all = 0;
  const uint32_t* weld = welded.weld.data();
  const uint32_t* corners = cluster.corners.data();
  for (size_t t = 0; t < n; ++t) {
    // Each corner's welded id read once (for_each_welded_edge reads each twice).
    const uint32_t w[3] = {weld[corners[3 * t]], weld[corners[3 * t + 1]], weld[corners[3 * t + 2]]};
    for (int k = 0; k < 3; ++k) {
      const uint32_t a = w[k], b = w[k == 2 ? 0 : k + 1];
      if (a == b) continue;
      const uint64_t key = edge_key(a, b);
      size_t h = size_t((key * 0x9E3779B97F4A7C15ull) >> shift);
      while (uses[h] != 0 && table[h] != key) h = (h + 1) & (slots - 1);
      // A first use or a second one, about evenly mixed: written without a branch on which.
      const bool first_use = uses[h] == 0;
      table[h] = key;
      ++uses[h];
      filled[all] = uint32_t(h);
      all += first_use;
    }
  }
  uint64_t open = 0;
  for (size_t i = 0; i < all; ++i) open += uses[filled[i]] == 1;
  if (open_keys) {
    // Sized once (the list grew by doubling, several allocations per cluster).
    // One slot more: every key is written, and the last ones (not open) land past the list.
    const size_t first_open = open_keys->size();
    open_keys->resize(first_open + open + 1);
    uint64_t* out = open_keys->data() + first_open;
    for (size_t i = 0; i < all; ++i) {
      *out = table[filled[i]];
      out += uses[filled[i]] == 1;
    }
    open_keys->pop_back();
    std::sort(open_keys->begin() + ptrdiff_t(first_open), open_keys->end());
  }
  *open_edges = open;
  *all_edges = all;
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
