// Grouping clusters of one level (spec/dag.md §Grouping): the cluster graph — nodes are
// clusters (weight = triangles), edge weight = number of shared welded triangle edges, plus
// weak spatial edges so islands are grouped with their neighbours — partitioned by the greedy
// partitioner (cluster_partition.cpp) or, for measuring, by METIS k-way.
// Based on: Karis et al., "Nanite: A Deep Dive", SIGGRAPH 2021, §"DAG: Which clusters to group?" (a
// minimum edge cut locks the fewest edges); Karypis, Kumar, "A Fast and High Quality Multilevel
// Scheme for Partitioning Irregular Graphs", SIAM J. Sci. Comput. 20(1), 1998 (METIS, GroupMethod::kMetis).
#include <dlfcn.h>
#include <metis.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cassert>
#include <cmath>
#include <mutex>
#include <string>

#include "vgeo/core/error.h"
#include "vgeo/core/shared_library.h"
#include "vgeo/dag/build_internal.h"
#include "vgeo/dag/cluster_dag.h"

namespace vgeo::build_detail {

namespace {

// Bits per pass of the edge uses' radix sort: 2,048 counters (8 KiB) stay in L1.
constexpr uint32_t kEdgeRadixBits = 11;
constexpr uint32_t kEdgeRadixBuckets = 1u << kEdgeRadixBits;

// Edge uses below this many are sorted on one thread even with a pool: each parallel pass
// wakes the pool's threads (10 µs back to back, up to ~1 ms after a stretch of serial work on
// the loaded 2-vCPU VM of docs/acceptance/issue23_group39.md) and a sort runs ~10 of them;
// 2^16 uses are ~1 ms of sorting on one thread (the 1M sphere's level 2: 104k uses, 1.5 ms).
constexpr size_t kParallelEdgeUses = size_t(1) << 16;
// Blocks below this many clusters build their pair rows and spatial edges on one thread: the
// 1M sphere's level 2 (2,065 clusters) spent ~3 ms in them at one thread.
constexpr size_t kParallelGraphClusters = 2048;
// Tasks per pool thread in the graph's parallel passes: a thread that another process holds
// up leaves its few tasks to the others.
constexpr size_t kTasksPerThread = 4;

// The pool to run a pass of `items` on: `pool` when it has more than one thread and the pass
// is large enough, else null (for_chunks then runs it in order on this thread).
ThreadPool* pool_for(ThreadPool* pool, size_t items, size_t min_items) {
  return pool && pool->size() > 1 && items >= min_items ? pool : nullptr;
}

// Items per task of a pass over `items` (one task without a pool).
size_t task_items(const ThreadPool* pool, size_t items) {
  const size_t tasks = pool ? kTasksPerThread * pool->size() : 1;
  return std::max<size_t>(1, (items + tasks - 1) / tasks);
}

// A stable LSD radix sort of `items` by key (the lists' order kept among equal keys), over
// as many passes as keys have bits. With a pool each pass runs in parts of consecutive items:
// the parts count their digits, then each places its items of a digit after the earlier
// parts' (the one-part order).
void radix_sort_by_key(std::vector<KeyedUse>& items, uint32_t key_bits, ThreadPool* pool) {
  const size_t n = items.size(), part = task_items(pool, n), parts = (n + part - 1) / std::max<size_t>(part, 1);
  std::vector<KeyedUse> sorted;
  sorted.reserve(n);
  if (pool) prefault_parallel({{sorted.data(), n * sizeof(KeyedUse)}}, *pool);
  sorted.resize(n);
  std::vector<std::array<uint32_t, kEdgeRadixBuckets>> start(parts);
  for (uint32_t shift = 0; shift < key_bits; shift += kEdgeRadixBits) {
    auto digit = [&](const KeyedUse& e) { return uint32_t(e.key >> shift) & (kEdgeRadixBuckets - 1); };
    for_chunks(pool, n, part, [&](size_t begin, size_t end) {
      std::array<uint32_t, kEdgeRadixBuckets>& count = start[begin / part];
      count.fill(0);
      for (size_t i = begin; i < end; ++i) ++count[digit(items[i])];
    });
    uint32_t at = 0;
    for (uint32_t b = 0; b < kEdgeRadixBuckets; ++b)
      for (size_t p = 0; p < parts; ++p) {
        const uint32_t count = start[p][b];
        start[p][b] = at;
        at += count;
      }
    for_chunks(pool, n, part, [&](size_t begin, size_t end) {
      std::array<uint32_t, kEdgeRadixBuckets>& next = start[begin / part];
      for (size_t i = begin; i < end; ++i) sorted[next[digit(items[i])]++] = items[i];
    });
    items.swap(sorted);
  }
}

}  // namespace

// The keys compressed to (high << bits of the largest low) | low, which keeps their order and
// equality, sorted by an LSD radix sort over as many passes as the compressed keys have bits
// (40 on a 2^20-vertex mesh: 4 passes instead of a comparison sort of the pairs). The uses are
// listed in list order, so a stable sort by key alone gives the (key, list) order.
SortedEdgeUses sorted_edge_uses(const std::vector<std::vector<uint64_t>>& lists, ThreadPool* pool) {
  const size_t n = lists.size();
  std::vector<size_t> first(n + 1, 0);
  for (size_t c = 0; c < n; ++c) first[c + 1] = first[c] + lists[c].size();
  const size_t total = first[n];
  pool = pool_for(pool, total, kParallelEdgeUses);
  // The largest high and low halves, per task of lists, then combined.
  const size_t list_part = task_items(pool, n), list_parts = (n + list_part - 1) / list_part;
  std::vector<std::pair<uint64_t, uint64_t>> max_part(list_parts, {0, 0});
  for_chunks(pool, n, list_part, [&](size_t begin, size_t end) {
    uint64_t max_high = 0, max_low = 0;
    for (size_t c = begin; c < end; ++c)
      for (uint64_t k : lists[c]) max_high = std::max(max_high, k >> 32), max_low = std::max(max_low, k & 0xFFFFFFFFu);
    max_part[begin / list_part] = {max_high, max_low};
  });
  uint64_t max_high = 0, max_low = 0;
  for (const auto& [high, low] : max_part) max_high = std::max(max_high, high), max_low = std::max(max_low, low);
  SortedEdgeUses out;
  out.low_bits = uint32_t(std::bit_width(max_low));
  const uint32_t key_bits = out.low_bits + uint32_t(std::bit_width(max_high));
  std::vector<KeyedUse>& uses = out.uses;
  uses.reserve(total);
  if (pool) prefault_parallel({{uses.data(), total * sizeof(KeyedUse)}}, *pool);
  uses.resize(total);
  for_chunks(pool, n, list_part, [&](size_t begin, size_t end) {
    for (size_t c = begin; c < end; ++c) {
      KeyedUse* at = uses.data() + first[c];
      for (uint64_t k : lists[c]) *at++ = {((k >> 32) << out.low_bits) | (k & 0xFFFFFFFFu), uint32_t(c)};
    }
  });
  radix_sort_by_key(uses, key_bits, pool);
  return out;
}

namespace {

// Rows of (neighbour, weight) pairs: row a = [first[a], end[a]) of to and weight.
struct WeightedRows {
  std::vector<size_t> first, end;
  std::vector<uint32_t> to;
  std::vector<int> weight;
};

// Sorts each row of `rows` (to: one entry per use, weight: room for as many) and merges equal
// neighbours into one entry weighing their count; rows in tasks of the pool when there is one.
void sort_and_count_rows(WeightedRows& rows, ThreadPool* pool) {
  const size_t n = rows.first.size() - 1;
  rows.end.resize(n);
  rows.weight.resize(rows.to.size());
  for_chunks(pool, n, task_items(pool, n), [&](size_t begin, size_t end) {
    for (size_t a = begin; a < end; ++a) {
      uint32_t* to = rows.to.data();
      std::sort(to + rows.first[a], to + rows.first[a + 1]);
      size_t out = rows.first[a];
      for (size_t i = rows.first[a]; i < rows.first[a + 1];) {
        size_t j = i;
        while (j < rows.first[a + 1] && to[j] == to[i]) ++j;
        to[out] = to[i];
        rows.weight[out++] = int(j - i);
        i = j;
      }
      rows.end[a] = out;
    }
  });
}

// Rows from (a, b) pairs listed by for_each(fn): row a holds each b once per pair, in the
// pairs' order (a counting sort by a); n rows.
template <class ForEachPair>
WeightedRows rows_of_pairs(size_t n, ForEachPair&& for_each) {
  WeightedRows rows;
  std::vector<size_t>& fill = rows.first;
  fill.assign(n + 1, 0);
  for_each([&](uint32_t a, uint32_t) { ++fill[a + 1]; });
  for (size_t i = 0; i < n; ++i) fill[i + 1] += fill[i];
  rows.to.resize(fill[n]);
  for_each([&](uint32_t a, uint32_t b) { rows.to[fill[a]++] = b; });
  for (size_t i = n; i > 0; --i) fill[i] = fill[i - 1];  // back to each row's start
  fill[0] = 0;
  return rows;
}

// Per cluster, the clusters it shares welded edges with and how many, neighbours ascending
// (the same graph as a sort of every (a, b) use and a sum of equal pairs, built by rows).
WeightedRows shared_edge_rows(const std::vector<std::vector<uint64_t>>& cluster_open_edges, ThreadPool* pool) {
  const size_t n = cluster_open_edges.size();
  const std::vector<KeyedUse> open_edges = sorted_edge_uses(cluster_open_edges, pool).uses;
  // Pairs (a, b), one per use: a welded edge is shared by 2 clusters on a manifold;
  // non-manifold fans link all pairs up to a small bound, then consecutive ones (keeps the
  // graph linear in size).
  auto for_each_pair = [&](auto&& fn) {
    for (size_t i = 0; i < open_edges.size();) {
      size_t j = i;
      while (j < open_edges.size() && open_edges[j].key == open_edges[i].key) ++j;
      const bool fan = j - i > 4;
      for (size_t x = i; x < j; ++x)
        for (size_t y = x + 1; y < (fan ? std::min(j, x + 2) : j); ++y) {
          const uint32_t a = open_edges[x].list, b = open_edges[y].list;
          if (a == b) continue;
          fn(a, b);
          fn(b, a);
        }
      i = j;
    }
  };
  WeightedRows rows = rows_of_pairs(n, for_each_pair);
  sort_and_count_rows(rows, pool_for(pool, n, kParallelGraphClusters));
  return rows;
}

// Weak spatial edges between clusters near in Morton order that share no edge (both
// directions, deduplicated): rows of neighbours ascending (weights unused).
WeightedRows spatial_edges(const WeightedRows& shared, const std::vector<Sphere>& bounds, ThreadPool* pool) {
  const size_t n = bounds.size();
  pool = pool_for(pool, n, kParallelGraphClusters);
  double lo[3] = {1e300, 1e300, 1e300}, hi[3] = {-1e300, -1e300, -1e300};
  for (const Sphere& s : bounds)
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], double(s.center[k]));
      hi[k] = std::max(hi[k], double(s.center[k]));
    }
  double extent = std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2], 1e-30});
  std::vector<std::pair<uint32_t, uint32_t>> order(n);
  for (size_t c = 0; c < n; ++c) {
    uint32_t q[3];
    for (int k = 0; k < 3; ++k)
      q[k] = uint32_t(std::clamp((double(bounds[c].center[k]) - lo[k]) / extent * 1023.0, 0.0, 1023.0));
    order[c] = {morton_code(q[0], q[1], q[2]), uint32_t(c)};
  }
  std::sort(order.begin(), order.end());
  auto adjacent = [&](uint32_t a, uint32_t b) {
    return std::binary_search(shared.to.begin() + shared.first[a], shared.to.begin() + shared.end[a], b);
  };
  // Each cluster's picks (its nearest non-adjacent ones in the window), per task of Morton
  // positions, joined in task order: the one-thread order.
  const size_t part = task_items(pool, n);
  std::vector<std::vector<std::pair<uint32_t, uint32_t>>> picks((n + part - 1) / part);
  for_chunks(pool, n, part, [&](size_t begin, size_t end) {
    std::vector<std::pair<uint32_t, uint32_t>>& out = picks[begin / part];
    std::vector<std::pair<double, uint32_t>> cand;
    for (size_t i = begin; i < end; ++i) {
      uint32_t c = order[i].second;
      cand.clear();
      size_t from = i >= kSpatialWindow ? i - kSpatialWindow : 0, to = std::min(n, i + kSpatialWindow + 1);
      for (size_t j = from; j < to; ++j) {
        uint32_t d = order[j].second;
        if (d == c || adjacent(c, d)) continue;
        cand.push_back({distance_d(bounds[c].center, bounds[d].center), d});
      }
      std::sort(cand.begin(), cand.end());
      for (size_t k = 0; k < cand.size() && k < kSpatialNeighbors; ++k) out.push_back({c, cand[k].second});
    }
  });
  // Both ends may pick each other: each row sorted, each neighbour once.
  WeightedRows rows = rows_of_pairs(n, [&](auto&& fn) {
    for (const auto& task : picks)
      for (const auto& [c, d] : task) {
        fn(c, d);
        fn(d, c);
      }
  });
  sort_and_count_rows(rows, pool);
  return rows;
}

// The shared-edge rows and the spatial edges merged row by row (weights of equal pairs
// summed; none are equal, spatial edges join only non-adjacent clusters).
ClusterAdjacency cluster_graph(const std::vector<std::vector<uint64_t>>& cluster_open_edges,
                               const std::vector<Sphere>& bounds, ThreadPool* pool) {
  const size_t n = cluster_open_edges.size();
  const WeightedRows shared = shared_edge_rows(cluster_open_edges, pool);
  const WeightedRows spatial = spatial_edges(shared, bounds, pool);
  ClusterAdjacency g;
  g.first.assign(n + 1, 0);
  g.to.reserve(shared.to.size() + spatial.to.size());
  g.weight.reserve(shared.to.size() + spatial.to.size());
  for (size_t a = 0; a < n; ++a) {
    size_t i = shared.first[a], s = spatial.first[a];
    const size_t end = shared.end[a], spatial_end = spatial.end[a];
    while (i < end || s < spatial_end) {
      const bool take_spatial = s < spatial_end && (i == end || spatial.to[s] <= shared.to[i]);
      const bool take_shared = i < end && (!take_spatial || shared.to[i] == spatial.to[s]);
      const uint32_t b = take_shared ? shared.to[i] : spatial.to[s];
      int w = 0;
      if (take_shared) w += shared.weight[i++];
      if (take_spatial) w += kSpatialEdgeWeight, ++s;
      g.to.push_back(b);
      g.weight.push_back(uint32_t(w));
    }
    g.first[a + 1] = uint32_t(g.to.size());
  }
  return g;
}

}  // namespace

std::vector<std::vector<uint32_t>> spatial_blocks(const std::vector<Vec3>& centres, size_t max_items) {
  std::vector<std::vector<uint32_t>> blocks;
  std::vector<uint32_t> items(centres.size());
  for (size_t i = 0; i < items.size(); ++i) items[i] = uint32_t(i);
  if (items.empty()) return blocks;
  max_items = std::max<size_t>(max_items, 1);
  // Explicit stack of [begin, end) ranges, upper half pushed first so the lower half
  // comes out first.
  std::vector<std::pair<size_t, size_t>> stack{{0, items.size()}};
  while (!stack.empty()) {
    auto [begin, end] = stack.back();
    stack.pop_back();
    if (end - begin <= max_items) {
      std::vector<uint32_t> block(items.begin() + begin, items.begin() + end);
      std::sort(block.begin(), block.end());
      blocks.push_back(std::move(block));
      continue;
    }
    float lo[3] = {centres[items[begin]].x, centres[items[begin]].y, centres[items[begin]].z};
    float hi[3] = {lo[0], lo[1], lo[2]};
    for (size_t i = begin; i < end; ++i)
      for (int k = 0; k < 3; ++k) {
        lo[k] = std::min(lo[k], centres[items[i]][k]);
        hi[k] = std::max(hi[k], centres[items[i]][k]);
      }
    int axis = 0;
    for (int k = 1; k < 3; ++k)
      if (double(hi[k]) - lo[k] > double(hi[axis]) - lo[axis]) axis = k;
    size_t mid = begin + (end - begin) / 2;
    std::nth_element(items.begin() + begin, items.begin() + mid, items.begin() + end, [&](uint32_t a, uint32_t b) {
      float ca = centres[a][axis], cb = centres[b][axis];
      return ca < cb || (ca == cb && a < b);
    });
    stack.push_back({mid, end});
    stack.push_back({begin, mid});
  }
  return blocks;
}

namespace {

// METIS k-way over the same graph (GroupMethod::kMetis): each node's group, or an empty
// vector where METIS failed.
std::vector<uint32_t> partition_clusters_metis(const ClusterAdjacency& graph, const std::vector<uint32_t>& weight,
                                               size_t part_count) {
  const size_t n = weight.size();
  std::vector<idx_t> xadj(graph.first.begin(), graph.first.end()), adjncy(graph.to.begin(), graph.to.end()),
      adjwgt(graph.weight.begin(), graph.weight.end()), vwgt(weight.begin(), weight.end());
  std::vector<idx_t> part(n, 0);
  idx_t nvtxs = idx_t(n), ncon = 1, np = idx_t(part_count), objval = 0;
  idx_t options[METIS_NOPTIONS];
  set_metis_options(options);
  int rc;
  {
    std::lock_guard<std::mutex> lock(metis_mutex());
    rc = metis_functions().part_graph_kway(&nvtxs, &ncon, xadj.data(), adjncy.data(), vwgt.data(), nullptr,
                                           adjwgt.data(), &np, nullptr, nullptr, options, &objval, part.data());
  }
  if (rc != METIS_OK) return {};
  std::vector<uint32_t> out(n);
  for (size_t i = 0; i < n; ++i) out[i] = size_t(part[i]) < part_count ? uint32_t(part[i]) : 0;
  return out;
}

}  // namespace

std::vector<std::vector<uint32_t>> group_clusters(const std::vector<const TriangleSet*>& clusters,
                                                  const std::vector<std::vector<uint64_t>>& cluster_open_edges,
                                                  const std::vector<Sphere>& bounds, uint32_t target_clusters,
                                                  GroupMethod method, ThreadPool* pool) {
  size_t n = clusters.size();
  std::vector<std::vector<uint32_t>> groups;
  if (n == 0) return groups;
  size_t nparts = (n + target_clusters - 1) / target_clusters;
  if (nparts <= 1) {  // one group: the answer is known (and METIS misbehaves for nparts = 1)
    groups.emplace_back(n);
    for (size_t i = 0; i < n; ++i) groups[0][i] = uint32_t(i);
    return groups;
  }

  const ClusterAdjacency graph = cluster_graph(cluster_open_edges, bounds, pool);
  std::vector<uint32_t> weight(n);
  for (size_t i = 0; i < n; ++i) weight[i] = uint32_t(std::max<size_t>(1, clusters[i]->triangle_count()));
  std::vector<uint32_t> part = method == GroupMethod::kMetis ? partition_clusters_metis(graph, weight, nparts)
                                                             : partition_clusters(graph, weight, nparts);
  if (part.empty()) {
    // Fallback (METIS failed, e.g. out of memory): consecutive runs in index order.
    part.resize(n);
    for (size_t i = 0; i < n; ++i) part[i] = uint32_t(i / target_clusters);
  }
  for (size_t i = 0; i < n; ++i) {
    if (part[i] >= groups.size()) groups.resize(part[i] + 1);
    groups[part[i]].push_back(uint32_t(i));
  }
  groups.erase(std::remove_if(groups.begin(), groups.end(), [](const auto& g) { return g.empty(); }), groups.end());
  return groups;
}

std::mutex& metis_mutex() {
  static std::mutex m;
  return m;
}

const MetisFunctions& metis_functions() {
  static constexpr const char* kMetisLibrary = "libmetis.so.5";  // METIS 5's ABI name (Debian: libmetis5)
  static std::once_flag once;
  static MetisFunctions functions;
  static std::string failure;
  std::call_once(once, [] {
    const OpenedLibrary opened = open_shared_library(kMetisLibrary, "METIS");
    if (!opened.handle) {
      failure = opened.failure;
      return;
    }
    void* library = opened.handle;
    MetisFunctions f;
    f.set_default_options = reinterpret_cast<decltype(f.set_default_options)>(dlsym(library, "METIS_SetDefaultOptions"));
    f.part_graph_kway = reinterpret_cast<decltype(f.part_graph_kway)>(dlsym(library, "METIS_PartGraphKway"));
    f.part_graph_recursive =
        reinterpret_cast<decltype(f.part_graph_recursive)>(dlsym(library, "METIS_PartGraphRecursive"));
    if (!f.set_default_options || !f.part_graph_kway || !f.part_graph_recursive)
      failure = std::string(kMetisLibrary) + " lacks a METIS 5 entry point";
    else
      functions = f;
  });
  if (!failure.empty())
    fail("MODULE_UNAVAILABLE", "metis", failure + " (the METIS grouping and split need libmetis5; tools/setup installs it)",
         kExitUsage);
  return functions;
}

}  // namespace vgeo::build_detail
