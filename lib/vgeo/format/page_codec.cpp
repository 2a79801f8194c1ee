// Based on: Karis et al., "Nanite: A Deep Dive", SIGGRAPH 2021, §"Memory - Triangles and attributes", §"Disk - Topology encoding".
// Cluster canonicalization, memory-form and disk-form page codecs (spec/format.md
// §Canonical cluster, §Memory form, §Disk form). The decoders here treat their input as
// untrusted: every read is bounds-checked and every field is checked before use.
#include "vgeo/format/page_codec.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstring>
#include <memory>

#include "vgeo/core/byte_io.h"
#include "vgeo/core/error.h"
#include "vgeo/format/bitstream.h"
#include "vgeo/format/memory_page.h"
#include "vgeo/format/quantize.h"

namespace vgeo::format_detail {
namespace {

// `inverse_step` = 2^-step_log2 (inverse_step_of). A float times a power of two in
// [2^-104, 2^40] is exact in double (no overflow or underflow: |v| < 2^128, smallest float
// 2^-149), so this equals std::ldexp(double(v), -step_log2) without a libm call per value.
double inverse_step_of(int32_t step_log2) { return std::ldexp(1.0, -step_log2); }
int32_t quantize_scalar(float v, double inverse_step, int32_t limit, const char* what) {
  if (!std::isfinite(v)) encode_fail(std::string("non-finite ") + what);
  const double q = round_to_nearest_even(double(v) * inverse_step);
  if (!(std::fabs(q) <= double(limit)))
    encode_fail(std::string(what) + " beyond 2^24 grid steps (use a coarser step)");
  return int32_t(q);
}

uint32_t zigzag(int32_t d) { return (uint32_t(d) << 1) ^ uint32_t(d >> 31); }
int32_t unzigzag(uint32_t z) { return int32_t(z >> 1) ^ -int32_t(z & 1u); }
// Bytes per zigzag delta of a channel with `bits` bits: deltas span ±(2^bits - 1).
uint32_t delta_bytes(uint32_t bits) { return bits == 0 ? 0 : (bits + 1 + 7) / 8; }

// ---- generalized strips over the material runs of one cluster (spec/format.md §3) ----
// Based on: the span-aware generalized-strip order that spec/format.md §3 states (this
// project's own rule). The cluster's adjacency is indexed once and shared by every order
// tried, and every query of a strip step is local (the triangles across an edge, the
// triangles of one or two vertices), so one order costs O(triangles · valence), plus a scan
// of the run for a strip start only when no fitting triangle uses a numbered vertex; an order
// stops as soon as it is bound to exceed the window (all that decides whether it is kept).
// Largest triangle span the 5-bit memory-form offsets hold (Nanite's window of 32).
constexpr uint32_t kIndexSpanWindow = (1u << kNaniteIndexOffsetBits) - 1;
// First triangles of the orders tried (choose_strip_order), as positions of the first material
// run of n triangles: n·k/8 for k in this order, then its last triangle (each position once).
// A DAG cluster's triangles come in the order its builder grew or split them, so positions far
// apart in the list lie far apart on the cluster: the starts are spread over the surface, halving
// it first, then quartering; the last triangle comes after them. Position 0 is first so that a
// decoded memory form re-encodes to itself (its first triangle started the kept order; the raster
// vectors rely on it, spec/raster.md §14). Measured on the 1M-triangle sphere (15,745 clusters):
// one start alone fits the window for 59–67% of the clusters, and the further starts leave
// 40 clusters with wider offsets, where the previous rule (the heuristic's own start, then each of
// the first 16 positions) left 394 after emitting 72% more triangles
// (docs/acceptance/issue23_wstrip.md).
constexpr uint32_t kStripStartEighths[] = {0, 4, 2, 6, 1, 3, 5, 7};
constexpr uint32_t kStripStartDivisor = 8;
// A triangle with at least one numbered vertex has at most two fresh ones.
constexpr uint32_t kMaxFreshBesideNumbered = 2;

// The cluster's triangles in material-sorted order ("positions"), indexed once.
struct StripIndex {
  uint32_t triangle_count = 0;
  uint8_t tri[kMaxClusterTriangles][3];   // triangle at position p, original winding
  uint8_t run_begin[kMaxClusterTriangles], run_end[kMaxClusterTriangles];  // p's material run
  uint8_t distinct[kMaxClusterTriangles];  // distinct vertices of p (all fresh before any is numbered)
  // Positions that use each vertex, ascending, each once (CSR over vertices).
  uint16_t uses_begin[kMaxClusterVertices + 1];
  uint8_t uses[3 * kMaxClusterTriangles];
  // The corners at each vertex by ascending (position, corner) (CSR over vertices): the
  // position and the vertex after the corner, i.e. the directed edges leaving the vertex.
  // Filled only when some directed edge has two or more holders (the only walk that reads it).
  uint16_t corners_begin[kMaxClusterVertices + 1];
  uint8_t corner_position[3 * kMaxClusterTriangles], corner_index[3 * kMaxClusterTriangles],
      corner_next[3 * kMaxClusterTriangles];
  // The first triangle of p's run across edge k of p (kNoStripTriangle if none), the corner where
  // the shared edge starts in it, and whether more follow (non-manifold edges: found again
  // by for_each_across, ascending like the first).
  uint8_t across_first[kMaxClusterTriangles][3], across_corner[kMaxClusterTriangles][3];
  bool across_more[kMaxClusterTriangles][3];
};
constexpr uint8_t kNoStripTriangle = 0xFF;
// index_strips' edge table: no corner holds the edge / two or more do (positions are < 128).
constexpr uint8_t kNoEdgeOwner = 0xFF, kManyEdgeOwners = 0xFE;
// No numbered vertex yet (ids are < kMaxClusterVertices = 255).
constexpr uint8_t kNoOldest = 0xFF;

// Each of the triangles of p's run that hold directed edge from -> to, by ascending position,
// until `f` returns true.
template <class F>
void for_each_across(const StripIndex& x, uint32_t p, uint8_t from, uint8_t to, F&& f) {
  for (uint32_t c = x.corners_begin[from]; c < x.corners_begin[from + 1]; ++c) {
    if (x.corner_next[c] != to) continue;
    const uint32_t q = x.corner_position[c];
    if (q < x.run_begin[p] || q >= x.run_end[p]) continue;
    if (f(q, uint32_t(x.corner_index[c]))) return;
  }
}

void index_strips(const uint8_t (*tris)[3], const uint32_t* mat, const uint32_t* order,
                  uint32_t tc, uint32_t vc, StripIndex* x) {
  x->triangle_count = tc;
  for (uint32_t p = 0; p < tc; ++p)
    for (int k = 0; k < 3; ++k) x->tri[p][k] = tris[order[p]][k];
  for (uint32_t r0 = 0; r0 < tc;) {
    uint32_t r1 = r0;
    while (r1 < tc && mat[order[r1]] == mat[order[r0]]) ++r1;
    for (uint32_t p = r0; p < r1; ++p) x->run_begin[p] = uint8_t(r0), x->run_end[p] = uint8_t(r1);
    r0 = r1;
  }
  uint16_t count[kMaxClusterVertices + 1] = {};
  auto for_each_use = [&](auto&& f) {
    for (uint32_t p = 0; p < tc; ++p) {
      const uint8_t* t = x->tri[p];
      f(t[0], p);
      if (t[1] != t[0]) f(t[1], p);
      if (t[2] != t[0] && t[2] != t[1]) f(t[2], p);
    }
  };
  for (uint32_t p = 0; p < tc; ++p) {
    const uint8_t* t = x->tri[p];
    x->distinct[p] = uint8_t(1 + (t[1] != t[0]) + (t[2] != t[0] && t[2] != t[1]));
  }
  for_each_use([&](uint8_t v, uint32_t) { ++count[v + 1]; });
  for (uint32_t v = 0; v < vc; ++v) count[v + 1] = uint16_t(count[v + 1] + count[v]);
  std::copy(count, count + vc + 1, x->uses_begin);
  for_each_use([&](uint8_t v, uint32_t p) { x->uses[count[v]++] = uint8_t(p); });
  // The triangle holding each directed edge (from, to), by a table over vertex pairs: a
  // lookup per edge instead of a walk over the corners of its vertex (that walk's
  // unpredictable compares were ~10% of the write stage on a 1M-triangle sphere). An edge
  // held by two or more corners (non-manifold, repeated vertices) is marked and found by the
  // walk, ascending, as before; so are edges whose one holder lies in another run.
  // edge_corner: the owner's corner where the edge starts (read only for a single owner, so
  // never cleared).
  uint8_t edge_owner[kMaxClusterVertices * kMaxClusterVertices], edge_corner[kMaxClusterVertices * kMaxClusterVertices];
  std::memset(edge_owner, kNoEdgeOwner, size_t(vc) * vc);
  bool shared_edges = false;
  for (uint32_t p = 0; p < tc; ++p)
    for (uint32_t k = 0; k < 3; ++k) {
      const uint32_t key = x->tri[p][k] * vc + x->tri[p][(k + 1) % 3];
      shared_edges |= edge_owner[key] != kNoEdgeOwner;
      edge_owner[key] = edge_owner[key] == kNoEdgeOwner ? uint8_t(p) : kManyEdgeOwners;
      edge_corner[key] = uint8_t(k);
    }
  // The corner walk (for_each_across) is only taken for an edge with two or more holders: a
  // cluster without one (nearly all) never reads the corners, so they are not indexed.
  if (shared_edges) {
    std::fill(count, count + vc + 1, 0);
    for (uint32_t p = 0; p < tc; ++p)
      for (uint32_t k = 0; k < 3; ++k) ++count[x->tri[p][k] + 1];
    for (uint32_t v = 0; v < vc; ++v) count[v + 1] = uint16_t(count[v + 1] + count[v]);
    std::copy(count, count + vc + 1, x->corners_begin);
    for (uint32_t p = 0; p < tc; ++p)
      for (uint32_t k = 0; k < 3; ++k) {
        const uint32_t c = count[x->tri[p][k]]++;
        x->corner_position[c] = uint8_t(p), x->corner_index[c] = uint8_t(k);
        x->corner_next[c] = x->tri[p][(k + 1) % 3];
      }
  }
  for (uint32_t p = 0; p < tc; ++p)
    for (uint32_t k = 0; k < 3; ++k) {
      x->across_first[p][k] = kNoStripTriangle, x->across_corner[p][k] = 0, x->across_more[p][k] = false;
      const uint8_t from = x->tri[p][(k + 1) % 3], to = x->tri[p][k];
      const uint32_t key = from * vc + to;
      const uint8_t q = edge_owner[key];
      if (q == kNoEdgeOwner) continue;
      if (q != kManyEdgeOwners) {
        if (q < x->run_begin[p] || q >= x->run_end[p]) continue;
        x->across_first[p][k] = q;
        x->across_corner[p][k] = edge_corner[key];
        continue;
      }
      for_each_across(*x, p, from, to, [&](uint32_t q2, uint32_t j) {
        if (x->across_first[p][k] != kNoStripTriangle) return x->across_more[p][k] = true;
        x->across_first[p][k] = uint8_t(q2), x->across_corner[p][k] = uint8_t(j);
        return false;
      });
    }
}

// One strip order being built: the first-use numbering, the visited triangles, and what a
// strip step asks about the current run kept up to date as vertices get numbered.
struct StripOrder {
  int32_t new_id[kMaxClusterVertices];
  uint8_t vertex_of_id[kMaxClusterVertices];
  uint32_t seen = 0, emitted = 0;
  bool visited[kMaxClusterTriangles];
  uint8_t fresh[kMaxClusterTriangles];  // distinct unnumbered vertices (current run, unvisited)
  // Smallest and largest numbered id (kNoOldest: none yet; current run, unvisited).
  uint8_t oldest[kMaxClusterTriangles], newest[kMaxClusterTriangles];
  // Unvisited triangles of the run by fresh-vertex count f ∈ {1, 2} and oldest numbered id: a
  // span is seen + f − 1 − oldest for them, so these counts answer the window and give-up
  // questions without walking any triangle (count_at_window, check_give_up).
  uint8_t waiting[kMaxFreshBesideNumbered + 1][kMaxClusterVertices];
  // Unvisited triangles of the run with every vertex numbered and a span that fits the window,
  // by oldest id: with `waiting`, strip_start skips an id no fitting triangle starts at.
  uint8_t settled_fitting[kMaxClusterVertices];
  // Unvisited triangles of the run with every vertex numbered and a span of exactly the window.
  uint32_t settled_at_window = 0;
  uint32_t r0 = 0, r1 = 0;  // the current material run
  // Ids below this one are the oldest vertex of no unvisited triangle of the run that fits
  // the window (strip_start).
  uint32_t oldest_live = 0;
  uint32_t max_span = 0;    // largest span emitted so far
  // The order's give-up bound (build_strip_order's give_up_span; UINT32_MAX: none, the
  // fallback order), and whether an unvisited triangle of the run already spans at least that
  // much if emitted now: a span never shrinks while a triangle waits (below), so the order is
  // then bound to reach it.
  uint32_t give_up_span = UINT32_MAX;
  bool doomed = false;
};

// Position of the first unvisited triangle across edge k of p, and the corner of that
// triangle where the shared (reversed) edge starts; -1 if none.
[[gnu::always_inline]] inline int across(const StripIndex& x, const StripOrder& s, uint32_t p, uint32_t k, uint32_t* corner) {
  const uint8_t first = x.across_first[p][k];
  if (first == kNoStripTriangle) return -1;
  if (!s.visited[first]) {
    *corner = x.across_corner[p][k];
    return first;
  }
  if (!x.across_more[p][k]) return -1;
  int found = -1;
  for_each_across(x, p, x.tri[p][(k + 1) % 3], x.tri[p][k], [&](uint32_t q, uint32_t j) {
    if (s.visited[q]) return false;
    *corner = j, found = int(q);
    return true;
  });
  return found;
}
[[gnu::always_inline]] inline uint32_t open_neighbors(const StripIndex& x, const StripOrder& s, uint32_t p) {
  uint32_t n = 0, corner;
  for (uint32_t k = 0; k < 3; ++k) n += across(x, s, p, k, &corner) >= 0 ? 1 : 0;
  return n;
}
// Span of a triangle of the current run if emitted now: its f fresh (distinct) vertices get
// the next f first-use ids seen .. seen + f − 1, above every numbered id. `oldest`: its
// smallest already-numbered id (UINT32_MAX if none). From the run's per-triangle counts, not
// from its corners: the fresh count already tells repeated corners apart.
[[gnu::always_inline]] inline uint32_t span_now(const StripIndex&, const StripOrder& s, uint32_t p, uint32_t* oldest) {
  const uint32_t f = s.fresh[p], old = s.oldest[p];
  if (old == kNoOldest) {
    if (oldest) *oldest = UINT32_MAX;
    return f - 1;  // every vertex fresh (f ≥ 1)
  }
  if (oldest) *oldest = old;
  return (f > 0 ? s.seen + f - 1 : uint32_t(s.newest[p])) - old;
}
// A triangle that uses a numbered vertex and spans the whole window: one more fresh vertex
// would push it out.
[[gnu::always_inline]] inline bool at_window_edge(const StripIndex& x, const StripOrder& s, uint32_t p) {
  uint32_t old;
  const uint32_t sp = span_now(x, s, p, &old);
  return old != UINT32_MAX && sp == kIndexSpanWindow;
}
bool in_run(const StripOrder& s, uint32_t p) { return p >= s.r0 && p < s.r1; }

// Early give-up of an order (same result as running it to the end, sooner). An unvisited
// triangle's span_now never shrinks: its numbered ids are fixed, and its f fresh vertices get
// f distinct ids ≥ seen whenever they are numbered, so its span when emitted is ≥ span_now.
// A triangle with a numbered vertex (oldest id o) and f ∈ {1, 2} fresh ones spans
// seen + f − 1 − o, which grows by one with each vertex numbered elsewhere and stays put when
// one of its own is numbered; once f = 0 it is fixed. So a triangle first reaches `give_up_span`
// just after a vertex is numbered, with o = seen + f − 1 − give_up_span: the waiting counts of
// those two (f, o) say whether one did. A run's triangles are checked whole when the run
// begins (their spans grew unseen during the earlier runs).
void check_give_up(StripOrder* s) {
  const uint32_t g = s->give_up_span;
  for (uint32_t f = 1; f <= kMaxFreshBesideNumbered; ++f)
    if (s->seen + f >= g + 1 && s->waiting[f][s->seen + f - 1 - g] != 0) s->doomed = true;
}

// A triangle of the run with every vertex numbered enters (+1) or leaves (−1) the counts of
// settled triangles at the window's edge and of those that fit (its span is fixed from now on).
void settle(const StripIndex& x, uint32_t p, int delta, StripOrder* s) {
  const uint32_t sp = span_now(x, *s, p, nullptr);
  if (sp == kIndexSpanWindow) s->settled_at_window += uint32_t(delta);
  if (sp <= kIndexSpanWindow) s->settled_fitting[s->oldest[p]] = uint8_t(s->settled_fitting[s->oldest[p]] + delta);
}

void begin_run(const StripIndex& x, uint32_t r0, StripOrder* s) {
  s->r0 = r0, s->r1 = x.run_end[r0];
  s->settled_at_window = 0, s->oldest_live = 0;
  std::memset(s->waiting, 0, sizeof s->waiting);
  std::memset(s->settled_fitting, 0, sizeof s->settled_fitting);
  if (s->seen == 0) {
    // Nothing numbered yet (every order's first run): all fresh, spans ≤ 2, nothing counted.
    std::memcpy(s->fresh + s->r0, x.distinct + s->r0, s->r1 - s->r0);
    std::memset(s->oldest + s->r0, kNoOldest, s->r1 - s->r0);
    std::memset(s->newest + s->r0, 0, s->r1 - s->r0);
    return;
  }
  for (uint32_t p = s->r0; p < s->r1; ++p) {
    const uint8_t* t = x.tri[p];
    uint32_t f = 0, old = kNoOldest, hi = 0;
    for (int k = 0; k < 3; ++k) {
      const int32_t id = s->new_id[t[k]];
      if (id >= 0) old = std::min(old, uint32_t(id)), hi = std::max(hi, uint32_t(id));
      else if ((k < 1 || t[k] != t[0]) && (k < 2 || t[k] != t[1])) ++f;  // distinct fresh vertices
    }
    s->fresh[p] = uint8_t(f), s->oldest[p] = uint8_t(old), s->newest[p] = uint8_t(hi);
    if (f > 0 && old != kNoOldest) ++s->waiting[f][old];
    if (f == 0) settle(x, p, +1, s);
    if (s->give_up_span != UINT32_MAX && span_now(x, *s, p, nullptr) >= s->give_up_span) s->doomed = true;
  }
}
void visit(const StripIndex& x, uint32_t p, StripOrder* s) {
  s->visited[p] = true;
  if (s->fresh[p] == 0) {
    settle(x, p, -1, s);
  } else if (s->oldest[p] != kNoOldest) {
    --s->waiting[s->fresh[p]][s->oldest[p]];
  }
}
// Emits corner v of the triangle being written: a new vertex takes the next first-use id,
// a numbered one becomes an explicit reference (`flag` in ctl).
uint8_t corner(const StripIndex& x, uint8_t v, uint8_t* ctl, uint8_t flag, StripOrder* s,
               CanonicalCluster* out) {
  if (s->new_id[v] >= 0) {
    *ctl |= flag;
    out->refs[out->ref_count++] = uint8_t(s->seen - 1 - uint32_t(s->new_id[v]));
    return uint8_t(s->new_id[v]);
  }
  s->new_id[v] = int32_t(s->seen);
  s->vertex_of_id[s->seen++] = v;
  for (uint32_t u = x.uses_begin[v]; u < x.uses_begin[v + 1]; ++u) {
    const uint32_t q = x.uses[u];
    if (!in_run(*s, q) || s->visited[q]) continue;
    if (s->oldest[q] != kNoOldest) --s->waiting[s->fresh[q]][s->oldest[q]];
    else s->oldest[q] = uint8_t(s->new_id[v]);
    s->newest[q] = uint8_t(s->new_id[v]);  // the largest id so far
    if (--s->fresh[q] == 0) {
      settle(x, q, +1, s);
    } else {
      ++s->waiting[s->fresh[q]][s->oldest[q]];
    }
  }
  if (s->give_up_span != UINT32_MAX) check_give_up(s);
  return uint8_t(s->new_id[v]);
}
// Unvisited triangles of the run at the window's edge. Those with every vertex numbered are
// counted as they settle; one with f ∈ {1, 2} fresh vertices spans seen + f − 1 − oldest,
// so it is at the edge only if its oldest numbered vertex has id seen − 32 + f (the waiting
// counts).
uint32_t count_at_window(const StripOrder& s) {
  uint32_t n = s.settled_at_window;
  for (uint32_t f = 1; f <= kMaxFreshBesideNumbered; ++f)
    if (s.seen + f >= kIndexSpanWindow + 1) n += s.waiting[f][s.seen + f - (kIndexSpanWindow + 1)];
  return n;
}
// Start of a strip (span-aware, spec/format.md §3): a triangle whose span fits the window,
// preferring the one that uses the oldest numbered vertex (it leaves the window first), then
// the fewest open neighbours (strips then end less often mid-run); ties: the first position.
// A triangle's oldest numbered vertex is fixed once it has one and its span never shrinks, so
// an id that is no fitting triangle's oldest stays so: the ids are walked once per run, and
// the whole run is scanned only when no fitting triangle uses a numbered vertex.
uint32_t strip_start(const StripIndex& x, StripOrder* so) {
  const StripOrder& s = *so;
  for (; so->oldest_live < s.seen; ++so->oldest_live) {
    const uint32_t id = s.oldest_live;
    // No fitting triangle has this oldest id (the counts; spans seen + f − 1 − id for f fresh).
    if (s.settled_fitting[id] == 0 && (s.waiting[1][id] == 0 || s.seen - id > kIndexSpanWindow) &&
        (s.waiting[2][id] == 0 || s.seen + 1 - id > kIndexSpanWindow))
      continue;
    const uint8_t v = s.vertex_of_id[id];
    uint32_t start = UINT32_MAX, best_open = UINT32_MAX;
    for (uint32_t u = x.uses_begin[v]; u < x.uses_begin[v + 1]; ++u) {
      const uint32_t q = x.uses[u];
      if (!in_run(s, q) || s.visited[q]) continue;
      uint32_t old;
      if (span_now(x, s, q, &old) > kIndexSpanWindow || old != id) continue;
      const uint32_t open = open_neighbors(x, s, q);
      if (open < best_open) best_open = open, start = q;
    }
    if (start != UINT32_MAX) return start;
  }
  uint32_t start = s.r0;
  uint64_t best = UINT64_MAX;
  for (uint32_t p = s.r0; p < s.r1; ++p)
    if (!s.visited[p]) {
      uint32_t old;
      const uint32_t sp = span_now(x, s, p, &old);
      const uint64_t key = uint64_t(sp > kIndexSpanWindow ? sp : 0) << 40 |
                           uint64_t(std::min<uint32_t>(old, 0xFFFF)) << 8 | open_neighbors(x, s, p);
      if (key < best) best = key, start = p;
    }
  return start;
}
void note_span(const uint8_t* t, StripOrder* s) {
  s->max_span = std::max<uint32_t>(s->max_span, std::max({t[0], t[1], t[2]}) - std::min({t[0], t[1], t[2]}));
}

// Builds one strip order into `out` (strip, ctl, refs, runs) and `s`. `first` is the
// first triangle of the cluster (a position in the first run); later strips start where
// strip_start says. Returns false, with `out` incomplete, as soon as a span reaches `give_up_span` or an
// unvisited triangle is bound to (check_give_up).
bool build_strip_order(const StripIndex& x, const uint32_t* run_material, uint32_t vc, uint32_t first,
                       uint32_t give_up_span, StripOrder* s, CanonicalCluster* out) {
  const uint32_t tc = x.triangle_count;
  std::fill(s->new_id, s->new_id + vc, -1);
  std::fill(s->visited, s->visited + tc, false);
  s->seen = 0, s->emitted = 0, s->max_span = 0;
  s->give_up_span = give_up_span, s->doomed = false;
  out->ref_count = 0, out->run_count = 0;
  for (uint32_t r0 = 0; r0 < tc; r0 = x.run_end[r0]) {
    out->run_start[out->run_count] = uint8_t(r0);
    out->run_material[out->run_count++] = run_material[r0];
    begin_run(x, r0, s);
    if (s->doomed) return false;
    for (uint32_t left = s->r1 - r0; left > 0;) {
      uint32_t cur = s->emitted == 0 ? first : strip_start(x, s);
      visit(x, cur, s);
      --left;
      // Rotated so a neighbour continues the strip: across b–c or c–a of (a, b, c).
      uint32_t rot = 0, unused;
      for (uint32_t r = 0; r < 3; ++r)
        if (across(x, *s, cur, (r + 1) % 3, &unused) >= 0 || across(x, *s, cur, (r + 2) % 3, &unused) >= 0) {
          rot = r;
          break;
        }
      const uint8_t* t = x.tri[cur];
      uint8_t ctl = kCtlReset;
      uint8_t* o = out->strip[s->emitted];
      o[0] = corner(x, t[rot], &ctl, kCtlRef0, s, out);
      o[1] = corner(x, t[(rot + 1) % 3], &ctl, kCtlRef0 << 1, s, out);
      o[2] = corner(x, t[(rot + 2) % 3], &ctl, kCtlRef0 << 2, s, out);
      out->ctl[s->emitted++] = ctl;
      note_span(o, s);
      if (s->max_span >= give_up_span || s->doomed) return false;
      while (left > 0) {
        // Candidates across b–c (side 0) and c–a (side 1); corner k of a candidate starts the
        // shared edge, so its strip rotation is k and its third vertex tri[n][k + 2].
        uint32_t k1 = 0, k2 = 0;
        const int n1 = across(x, *s, cur, (rot + 1) % 3, &k1), n2 = across(x, *s, cur, (rot + 2) % 3, &k2);
        // A continuation must keep the span within the window and, if its third vertex is
        // new, not push another unvisited triangle beyond it. Both candidates ask against
        // the same state: the count is taken once per step (-1 = not yet).
        int at_window = -1;
        auto fits = [&](int n, uint32_t k) {
          if (n < 0 || span_now(x, *s, uint32_t(n), nullptr) > kIndexSpanWindow) return false;
          if (s->new_id[x.tri[n][(k + 2) % 3]] >= 0) return true;
          if (at_window < 0) at_window = int(count_at_window(*s));
          return at_window - (at_window_edge(x, *s, uint32_t(n)) ? 1 : 0) <= 0;
        };
        const bool ok1 = fits(n1, k1), ok2 = fits(n2, k2);
        if (!ok1 && !ok2) break;
        bool side = !ok1;
        if (ok1 && ok2) {
          s->visited[n1] = s->visited[n2] = true;  // exclude each other from the neighbour counts
          const uint32_t o1 = open_neighbors(x, *s, uint32_t(n1)), o2 = open_neighbors(x, *s, uint32_t(n2));
          s->visited[n1] = s->visited[n2] = false;
          side = o2 < o1;
        }
        const uint32_t n = uint32_t(side ? n2 : n1), k = side ? k2 : k1;
        visit(x, n, s);
        --left;
        ctl = side ? kCtlSide : 0;
        o = out->strip[s->emitted];
        o[0] = uint8_t(s->new_id[x.tri[n][k]]);
        o[1] = uint8_t(s->new_id[x.tri[n][(k + 1) % 3]]);
        o[2] = corner(x, x.tri[n][(k + 2) % 3], &ctl, kCtlRef0, s, out);
        out->ctl[s->emitted++] = ctl;
        note_span(o, s);
        if (s->max_span >= give_up_span || s->doomed) return false;
        cur = n, rot = k;
      }
    }
  }
  assert(s->emitted == tc);
  return true;
}

}  // namespace

uint32_t channel_max_bits(const MeshQuantization& q, uint32_t channel) {
  return channel_is_normal(q, channel) ? q.normal_bits : kMaxChannelBits;
}
bool channel_is_normal(const MeshQuantization& q, uint32_t channel) {
  return q.has_normals && (channel == 3 || channel == 4);
}
void channel_value_range(const MeshQuantization& q, uint32_t channel, int64_t* lo, int64_t* hi) {
  if (channel_is_normal(q, channel)) {
    *lo = 0, *hi = (int64_t(1) << q.normal_bits) - 1;
  } else {
    *hi = channel < 3 ? kMaxQuantized : uv_quantized_limit(q.uv_step_log2);
    *lo = -*hi;
  }
}

namespace {
// min_first's body, inlined into the memory-form encoder: an exported function of this
// shared library is interposable, so the compiler calls it (once per triangle) instead.
[[gnu::always_inline]] inline void rotate_min_first(const uint8_t in[3], uint8_t out[3]) {
  // Rotation (winding kept) with the smallest index first; ties: lexicographically smallest
  // (bytes packed most significant first compare as the byte sequences do).
  auto packed = [&](int r) { return uint32_t(in[r]) << 16 | uint32_t(in[(r + 1) % 3]) << 8 | in[(r + 2) % 3]; };
  int best = 0;
  uint32_t best_key = packed(0);
  for (int r = 1; r < 3; ++r)
    if (packed(r) < best_key) best = r, best_key = packed(r);
  for (int k = 0; k < 3; ++k) out[k] = in[(best + k) % 3];
}
// Writes fields LSB-first from a word boundary on, in the layout write_bits gives (spec/format.md
// §4), a whole word at a time: the memory-form encoder's streams are written in order, so no
// word is read back and or-ed once per field.
struct SequentialBitWriter {
  uint32_t* out;
  uint64_t pending = 0;   // bits not yet stored, least significant first
  uint32_t pending_bits = 0;  // < 32 between calls
  void put(uint32_t n, uint32_t value) {  // n ≤ 32
    const uint64_t field = n == 32 ? value : value & ((1u << n) - 1u);
    pending |= field << pending_bits;
    pending_bits += n;
    if (pending_bits >= 32) {
      *out++ = uint32_t(pending);
      pending >>= 32;
      pending_bits -= 32;
    }
  }
  void flush() {  // the last, partial word
    if (pending_bits != 0) *out++ = uint32_t(pending);
    pending = 0, pending_bits = 0;
  }
};
}  // namespace

void min_first(const uint8_t in[3], uint8_t out[3]) { rotate_min_first(in, out); }

ClusterView view_of(const CanonicalCluster& c) {
  ClusterView v;
  v.vertex_count = c.vertex_count, v.triangle_count = c.triangle_count;
  v.ref_count = c.ref_count, v.run_count = c.run_count;
  for (uint32_t k = 0; k < kMaxChannels; ++k) v.min[k] = c.min[k], v.bits[k] = c.bits[k], v.values[k] = c.values[k];
  v.strip = c.strip, v.ctl = c.ctl, v.refs = c.refs, v.run_start = c.run_start, v.run_material = c.run_material;
  return v;
}

namespace {
// Views of `clusters`, in order (held by `views`).
std::vector<const ClusterView*> views_of(const std::vector<const CanonicalCluster*>& clusters,
                                         std::vector<ClusterView>* views) {
  views->clear();
  views->reserve(clusters.size());
  for (const CanonicalCluster* c : clusters) views->push_back(view_of(*c));
  std::vector<const ClusterView*> ptrs;
  for (const ClusterView& v : *views) ptrs.push_back(&v);
  return ptrs;
}
}  // namespace

uint32_t index_offset_bits(const CanonicalCluster& c) { return index_offset_bits(view_of(c)); }
uint32_t index_offset_bits(const ClusterView& c) {
  // After min_first the first index is the smallest, so a triangle's span
  // max(i1 − i0, i2 − i0) is its largest index minus its smallest.
  uint32_t span = 0;
  for (uint32_t t = 0; t < c.triangle_count; ++t) {
    const uint8_t* x = c.strip[t];
    span = std::max<uint32_t>(span, std::max({x[0], x[1], x[2]}) - std::min({x[0], x[1], x[2]}));
  }
  return bits_for_range(span);
}

void compute_channel_ranges(CanonicalCluster* c, uint32_t channel_count) {
  for (uint32_t k = 0; k < kMaxChannels; ++k) {
    c->min[k] = 0;
    c->bits[k] = 0;
    if (k >= channel_count) continue;
    int32_t lo = c->values[k][0], hi = lo;
    for (uint32_t v = 1; v < c->vertex_count; ++v) {
      lo = std::min(lo, c->values[k][v]);
      hi = std::max(hi, c->values[k][v]);
    }
    c->min[k] = lo;
    c->bits[k] = bits_for_range(uint32_t(int64_t(hi) - lo));
  }
}

namespace {

// Step 1: the cluster's triangles (cluster-local indices) and materials, checked.
void read_cluster_triangles(const ClusterDag& dag, const DagCluster& cl, uint8_t (*tris)[3], uint32_t* mat) {
  const uint32_t vc = cl.vertex_count, tc = cl.triangle_count;
  if (vc == 0 || vc > kMaxClusterVertices) encode_fail("cluster vertex count outside 1..255");
  if (tc == 0 || tc > kMaxClusterTriangles) encode_fail("cluster triangle count outside 1..128");
  if (uint64_t(cl.vertex_offset) + vc > dag.vertex_count() ||
      uint64_t(cl.triangle_offset) + tc > dag.triangle_count())
    encode_fail("cluster vertex/triangle range outside the mesh arrays");
  for (uint32_t t = 0; t < tc; ++t) {
    for (int k = 0; k < 3; ++k) {
      const uint8_t v = dag.indices[3 * (size_t(cl.triangle_offset) + t) + k];
      if (v >= vc) encode_fail("triangle index beyond the cluster's vertex count");
      tris[t][k] = v;
    }
    mat[t] = size_t(cl.triangle_offset) + t < dag.triangle_materials.size()
                 ? dag.triangle_materials[cl.triangle_offset + t] : 0u;
    if (mat[t] > kMaxMaterialId) encode_fail("material id beyond 2^24 - 1");
  }
}

// Step 2: triangles sorted by material (stable), then generalized strips per material run.
// Orders are tried from the first triangles of strip_start_candidates, and the first whose
// spans all fit the window is kept: the memory form's offset bits are what a wider span costs,
// and a fitting order is as narrow as any (5 bits). Every order but the kept one gives up as
// soon as it is bound to exceed the window (build_strip_order). When none fits (0.25% of the
// clusters on a 1M-triangle sphere), the first candidate's order (position 0) is run to its end. Leaves the
// strip order in *out and the vertex renumbering in *s.
uint32_t strip_start_candidates(uint32_t run_triangles, uint32_t* out) {
  const uint32_t n = run_triangles;
  uint32_t count = 0;
  for (uint32_t k : kStripStartEighths) {
    const uint32_t p = n * k / kStripStartDivisor;
    if (std::find(out, out + count, p) == out + count) out[count++] = p;
  }
  if (std::find(out, out + count, n - 1) == out + count) out[count++] = n - 1;
  return count;
}
void choose_strip_order(const uint8_t (*tris)[3], const uint32_t* mat, uint32_t tc, uint32_t vc, StripOrder* s,
                        CanonicalCluster* out) {
  uint32_t order[kMaxClusterTriangles] = {};  // (cleared: GCC cannot see the loop below fills what is read)
  for (uint32_t t = 0; t < tc; ++t) order[t] = t;
  // Already in material order (one material: nearly every cluster): the identity is the stable
  // sort's result, without its temporary buffer.
  if (!std::is_sorted(mat, mat + tc))
    std::stable_sort(order, order + tc, [&](uint32_t a, uint32_t b) { return mat[a] < mat[b]; });
  StripIndex index;
  index_strips(tris, mat, order, tc, vc, &index);
  uint32_t run_material[kMaxClusterTriangles];
  for (uint32_t p = 0; p < tc; ++p) run_material[p] = mat[order[p]];
  uint32_t starts[1 + std::size(kStripStartEighths)];
  const uint32_t start_count = strip_start_candidates(index.run_end[0], starts);
  bool fits = false;
  for (uint32_t i = 0; i < start_count && !fits; ++i)
    fits = build_strip_order(index, run_material, vc, starts[i], kIndexSpanWindow + 1, s, out);
  if (!fits) build_strip_order(index, run_material, vc, starts[0], UINT32_MAX, s, out);
  // Vertices no triangle uses keep their relative order after the used ones.
  for (uint32_t v = 0; v < vc; ++v)
    if (s->new_id[v] < 0) s->new_id[v] = int32_t(s->seen++);
}

// Step 3: each vertex's attributes quantized on the mesh's grids, in the new vertex order.
void quantize_cluster_vertices(const ClusterDag& dag, const DagCluster& cl, const MeshQuantization& q,
                               const int32_t* new_id, CanonicalCluster* out) {
  const size_t base = cl.vertex_offset;
  const double position_scale = inverse_step_of(q.position_step_log2), uv_scale = inverse_step_of(q.uv_step_log2);
  for (uint32_t v = 0; v < cl.vertex_count; ++v) {
    const uint32_t n = uint32_t(new_id[v]);
    for (int k = 0; k < 3; ++k)
      out->values[k][n] = quantize_scalar(dag.positions[3 * (base + v) + k], position_scale, kMaxQuantized, "position");
    uint32_t ch = 3;
    if (q.has_normals) {
      uint32_t o[2];
      octahedral_encode(&dag.normals[3 * (base + v)], q.normal_bits, o);
      out->values[ch++][n] = int32_t(o[0]);
      out->values[ch++][n] = int32_t(o[1]);
    }
    if (q.has_uvs)
      for (int k = 0; k < 2; ++k)
        out->values[ch++][n] = quantize_scalar(dag.uvs[2 * (base + v) + k], uv_scale,
                                               uv_quantized_limit(q.uv_step_log2), "uv");
  }
}

}  // namespace

void canonicalize_cluster(const ClusterDag& dag, uint32_t ci, const MeshQuantization& q,
                          CanonicalCluster* out) {
  const DagCluster& cl = dag.clusters[ci];
  uint8_t tris[kMaxClusterTriangles][3];
  uint32_t mat[kMaxClusterTriangles];
  read_cluster_triangles(dag, cl, tris, mat);
  // Not cleared whole (8.8 KB per cluster: ~11% of canonicalization on a 1M-triangle sphere):
  // every field is written below up to the cluster's counts, which is all any reader reads
  // (strip, ctl, refs and runs by the strip order, the used channels' values by the quantizer,
  // min and bits of every channel by compute_channel_ranges); the unused channels' values are
  // zeroed for the cluster's vertices.
  out->vertex_count = cl.vertex_count;
  out->triangle_count = cl.triangle_count;
  StripOrder s;
  choose_strip_order(tris, mat, cl.triangle_count, cl.vertex_count, &s, out);
  quantize_cluster_vertices(dag, cl, q, s.new_id, out);
  for (uint32_t k = q.channel_count(); k < kMaxChannels; ++k) std::fill(out->values[k], out->values[k] + cl.vertex_count, 0);
  compute_channel_ranges(out, q.channel_count());
}

// ---------------------------------------------------------------- memory form

namespace {
uint32_t vertex_bits(const ClusterView& c) {
  uint32_t b = 0;
  for (uint32_t k = 0; k < kMaxChannels; ++k) b += c.bits[k];
  return b;
}
}  // namespace

uint32_t memory_cluster_words(const CanonicalCluster& c, uint32_t ob) { return memory_cluster_words(view_of(c), ob); }
uint32_t memory_cluster_words(const ClusterView& c, uint32_t ob) {
  return kDescriptorWords + words_for_bits(uint64_t(c.vertex_count) * vertex_bits(c)) +
         words_for_bits(uint64_t(c.triangle_count) * memory_triangle_bits(c.vertex_count, ob)) + c.run_count;
}

MemoryPageBuilder::MemoryPageBuilder(uint32_t cluster_count, uint64_t max_words, const std::string& where)
    : n_(cluster_count), max_words_(max_words), where_(where) {
  const uint64_t head = 1 + uint64_t(cluster_count) * kDescriptorWords;
  if (head > max_words_) fail(kErrInconsistent, where_, "memory form exceeds the page table's memory size");
  w_.assign(head, 0u);
  w_[0] = cluster_count;
}

void MemoryPageBuilder::add(const ClusterView& c) {
  assert(next_ < n_);
  const uint32_t ob = index_offset_bits(c);
  const uint32_t vb = vertex_bits(c), tb = memory_triangle_bits(c.vertex_count, ob), bb = tb - 2 * ob;
  const uint64_t data = w_.size();
  const uint64_t vwords = words_for_bits(uint64_t(c.vertex_count) * vb);
  const uint64_t twords = words_for_bits(uint64_t(c.triangle_count) * tb);
  if (data + vwords + twords + c.run_count > max_words_)
    fail(kErrInconsistent, where_, "memory form exceeds the page table's memory size");
  w_.resize(data + vwords + twords + c.run_count, 0u);
  uint32_t* d = &w_[1 + size_t(next_++) * kDescriptorWords];
  d[0] = c.vertex_count | (c.triangle_count << 8) | (c.run_count << 16) | (ob << 24);
  for (uint32_t k = 0; k < 6; ++k) d[1] |= c.bits[k] << (5 * k);
  d[2] = c.bits[6] | uint32_t(data << 10);
  for (uint32_t k = 0; k < kMaxChannels; ++k) d[3 + k] = uint32_t(c.min[k]);
  // Vertices: fixed-width records, fields in channel order (channels of 0 bits hold nothing).
  uint32_t stored[kMaxChannels], stored_count = 0;
  for (uint32_t k = 0; k < kMaxChannels; ++k)
    if (c.bits[k] != 0) stored[stored_count++] = k;
  SequentialBitWriter vertices{&w_[data]};
  for (uint32_t v = 0; v < c.vertex_count; ++v)
    for (uint32_t i = 0; i < stored_count; ++i) {
      const uint32_t k = stored[i];
      vertices.put(c.bits[k], uint32_t(int64_t(c.values[k][v]) - c.min[k]));
    }
  vertices.flush();
  SequentialBitWriter indices{&w_[data + vwords]};
  for (uint32_t t = 0; t < c.triangle_count; ++t) {
    uint8_t m[3];
    rotate_min_first(c.strip[t], m);
    indices.put(bb, m[0]);
    indices.put(ob, uint32_t(m[1] - m[0]));
    indices.put(ob, uint32_t(m[2] - m[0]));
  }
  indices.flush();
  uint64_t mat = data + vwords + twords;
  for (uint32_t r = 0; r < c.run_count; ++r) w_[mat++] = c.run_start[r] | (c.run_material[r] << 8);
}

std::vector<uint32_t> MemoryPageBuilder::finish() {
  assert(next_ == n_);
  return std::move(w_);
}

std::vector<uint32_t> encode_memory_page(const std::vector<const ClusterView*>& clusters, const MeshQuantization&) {
  static const std::string where = "<encoder>";
  MemoryPageBuilder b(uint32_t(clusters.size()), UINT64_MAX, where);
  for (const ClusterView* c : clusters) b.add(*c);
  return b.finish();
}
std::vector<uint32_t> encode_memory_page(const std::vector<const CanonicalCluster*>& clusters,
                                         const MeshQuantization& q) {
  std::vector<ClusterView> views;
  return encode_memory_page(views_of(clusters, &views), q);
}

}  // namespace vgeo::format_detail

namespace vgeo {
using namespace format_detail;

uint32_t memory_page_cluster_count(const uint32_t* words) { return words[0]; }

void validate_memory_page(const uint32_t* w, size_t word_count, const MeshQuantization& q,
                          const std::string& where) {
  if (word_count < 1) fail(kErrTruncated, where, "memory page has no header word");
  const uint32_t n = w[0];
  if (n == 0) fail(kErrOutOfRange, where, "memory page with no cluster");
  if (uint64_t(n) * kDescriptorWords + 1 > word_count)
    fail(kErrTruncated, where, "memory page shorter than its cluster descriptors");
  const uint32_t channels = q.channel_count();
  uint64_t data = 1 + uint64_t(n) * kDescriptorWords;
  for (uint32_t i = 0; i < n; ++i) {
    const uint32_t* d = &w[1 + i * kDescriptorWords];
    const uint32_t vc = d[0] & 0xFFu, tc = (d[0] >> 8) & 0xFFu, runs = (d[0] >> 16) & 0xFFu,
                   ob = (d[0] >> 24) & 15u;
    const std::string at = "cluster " + std::to_string(i) + ": ";
    if (vc == 0 || tc == 0 || tc > kMaxClusterTriangles || runs == 0 || runs > tc || ob > kMaxIndexOffsetBits ||
        (d[0] >> 28) != 0)
      fail(kErrOutOfRange, where, at + "descriptor counts/flags out of range");
    if ((d[1] >> 30) != 0 || ((d[2] >> 5) & 31u) != 0) fail(kErrOutOfRange, where, at + "reserved bits set");
    uint32_t bits[kMaxChannels], vb = 0;
    for (uint32_t k = 0; k < kMaxChannels; ++k) {
      bits[k] = k < 6 ? (d[1] >> (5 * k)) & 31u : d[2] & 31u;
      const int32_t mn = int32_t(d[3 + k]);
      if (k >= channels ? (bits[k] != 0 || mn != 0) : bits[k] > channel_max_bits(q, k))
        fail(kErrOutOfRange, where, at + "channel bit width out of range");
      int64_t kind_lo = 0, kind_hi = 0;
      if (k < channels) channel_value_range(q, k, &kind_lo, &kind_hi);
      if (k < channels && (mn < kind_lo || mn > kind_hi)) fail(kErrOutOfRange, where, at + "channel minimum out of range");
      vb += bits[k];
    }
    if ((d[2] >> 10) != data) fail(kErrInconsistent, where, at + "data offset is not the running offset");
    const uint32_t tb = memory_triangle_bits(vc, ob), bb = tb - 2 * ob;
    const uint64_t vwords = words_for_bits(uint64_t(vc) * vb), twords = words_for_bits(uint64_t(tc) * tb);
    if (data + vwords + twords + runs > word_count) fail(kErrTruncated, where, at + "data beyond the page");
    uint64_t bit = data * 32;
    for (uint32_t v = 0; v < vc; ++v)
      for (uint32_t k = 0; k < channels; ++k) {
        const int64_t value = int64_t(int32_t(d[3 + k])) + read_bits(w, bit, bits[k]);
        bit += bits[k];
        int64_t lo = 0, hi = 0;
        channel_value_range(q, k, &lo, &hi);
        if (value > hi) fail(kErrOutOfRange, where, at + "vertex value beyond the quantized range");
      }
    data += vwords;
    bit = data * 32;
    for (uint32_t t = 0; t < tc; ++t, bit += tb) {
      const uint32_t i0 = read_bits(w, bit, bb);
      const uint32_t i1 = i0 + read_bits(w, bit + bb, ob), i2 = i0 + read_bits(w, bit + bb + ob, ob);
      if (i0 >= vc || i1 >= vc || i2 >= vc) fail(kErrOutOfRange, where, at + "triangle index beyond vertex count");
    }
    data += twords;
    for (uint32_t r = 0; r < runs; ++r) {
      const uint32_t start = w[data + r] & 0xFFu;
      if (r == 0 ? start != 0 : start <= (w[data + r - 1] & 0xFFu) || start >= tc)
        fail(kErrOutOfRange, where, at + "material runs not strictly increasing from 0");
    }
    data += runs;
  }
  if (data != word_count) fail(kErrTrailingBytes, where, "memory page longer than its clusters");
}

void decode_cluster(const uint32_t* w, uint32_t i, const MeshQuantization& q, DecodedCluster* out) {
  assert(i < w[0]);
  const uint32_t* d = &w[memory_descriptor_word(i)];
  const uint32_t vc = memory_vertex_count(d[0]), tc = memory_triangle_count(d[0]), runs = memory_run_count(d[0]);
  const uint32_t ob = memory_offset_bits(d[0]);
  const uint32_t channels = q.channel_count();
  uint32_t bits[kMaxChannels], vb = 0;
  for (uint32_t k = 0; k < kMaxChannels; ++k) {
    bits[k] = memory_channel_bits(d[1], d[2], k);
    vb += bits[k];
  }
  uint64_t data = memory_data_offset(d[2]);
  out->vertex_count = vc;
  out->triangle_count = tc;
  out->index_offset_bits = ob;
  out->quantized.assign(size_t(vc) * channels, 0);
  out->positions.assign(size_t(vc) * 3, 0.0f);
  out->normals.assign(q.has_normals ? size_t(vc) * 3 : 0, 0.0f);
  out->uvs.assign(q.has_uvs ? size_t(vc) * 2 : 0, 0.0f);
  uint64_t bit = data * 32;
  for (uint32_t v = 0; v < vc; ++v) {
    int32_t* qv = &out->quantized[size_t(v) * channels];
    for (uint32_t k = 0; k < channels; ++k) {
      qv[k] = int32_t(d[kMemoryMinWord + k]) + int32_t(read_bits(w, bit, bits[k]));
      bit += bits[k];
    }
    for (int k = 0; k < 3; ++k) out->positions[3 * v + k] = dequantize_position(qv[k], q.position_step_log2);
    uint32_t ch = 3;
    if (q.has_normals) {
      const uint32_t oct[2] = {uint32_t(qv[3]), uint32_t(qv[4])};
      octahedral_decode(oct, q.normal_bits, &out->normals[3 * v]);
      ch = 5;
    }
    if (q.has_uvs)
      for (int k = 0; k < 2; ++k) out->uvs[2 * v + k] = dequantize_position(qv[ch + k], q.uv_step_log2);
  }
  data += words_for_bits(uint64_t(vc) * vb);
  const uint32_t tb = memory_triangle_bits(vc, ob), bb = tb - 2 * ob;
  out->indices.resize(size_t(tc) * 3);
  bit = data * 32;
  for (uint32_t t = 0; t < tc; ++t, bit += tb) {
    uint8_t* o = &out->indices[3 * t];
    const uint32_t b = read_bits(w, bit, bb);
    o[0] = uint8_t(b);
    o[1] = uint8_t(b + read_bits(w, bit + bb, ob));
    o[2] = uint8_t(b + read_bits(w, bit + bb + ob, ob));
  }
  data += words_for_bits(uint64_t(tc) * tb);
  out->materials.resize(tc);
  for (uint32_t r = 0; r < runs; ++r) {
    const uint32_t start = w[data + r] & 0xFFu, end = r + 1 < runs ? w[data + r + 1] & 0xFFu : tc;
    for (uint32_t t = start; t < end; ++t) out->materials[t] = w[data + r] >> 8;
  }
}

}  // namespace vgeo

namespace vgeo::format_detail {

// ---------------------------------------------------------------- disk form


uint32_t disk_cluster_bytes(const CanonicalCluster& c, uint32_t channel_count, uint32_t version) {
  return disk_cluster_bytes(view_of(c), channel_count, version);
}
uint32_t disk_cluster_bytes(const ClusterView& c, uint32_t channel_count, uint32_t version) {
  uint32_t b = 3 + 5 * channel_count + c.triangle_count + c.ref_count + 5 * c.run_count;
  for (uint32_t k = 0; k < channel_count; ++k) b += delta_bytes(c.bits[k]) * c.vertex_count;
  // Version 2: one copy-mask bit per vertex (rounded up per cluster); a copy replaces at
  // least kCopyRefBytes residual bytes by a kCopyRefBytes reference, never more.
  if (version >= 2) b += (c.vertex_count + 7) / 8;
  return b;
}

void strip_predictors(const CanonicalCluster& c, uint8_t pred[][3], bool* has) { strip_predictors(view_of(c), pred, has); }
void strip_predictors(const ClusterView& c, uint8_t pred[][3], bool* has) {
  std::fill(has, has + c.vertex_count, false);
  for (uint32_t t = 1; t < c.triangle_count; ++t) {
    const uint8_t ctl = c.ctl[t];
    if ((ctl & kCtlReset) || (ctl & kCtlRef0)) continue;
    const uint8_t* s = c.strip[t];
    const uint8_t* p = c.strip[t - 1];
    // The continuation shares edge (s0, s1) with the previous triangle; its third corner is
    // the previous triangle's vertex opposite that edge.
    const uint8_t d = s[2], opp = (ctl & kCtlSide) ? p[1] : p[0];
    if (d >= c.vertex_count) continue;  // (the parser has already rejected this)
    has[d] = true;
    pred[d][0] = s[0], pred[d][1] = s[1], pred[d][2] = opp;
  }
}

namespace {
// Version 2 prediction of vertex v of channel k (spec/format.md §5.3): the parallelogram
// when a strip continuation introduced v, else the previous vertex (the minimum for v = 0),
// clamped to the channel's range so a residual fits the same byte planes as a delta.
int64_t predict_v2(const int32_t* values, uint32_t v, int64_t lo, int64_t hi, const uint8_t pred[][3], const bool* has) {
  int64_t p;
  if (has[v]) p = int64_t(values[pred[v][0]]) + values[pred[v][1]] - values[pred[v][2]];
  else p = v == 0 ? lo : values[v - 1];
  return std::clamp(p, lo, hi);
}
int64_t channel_hi(const ClusterView& c, uint32_t k) { return int64_t(c.min[k]) + (int64_t(1) << c.bits[k]) - 1; }
}  // namespace

std::vector<uint8_t> encode_disk_page(const std::vector<const CanonicalCluster*>& clusters,
                                      const MeshQuantization& q, uint32_t version, DiskStreams* streams,
                                      DiskSections* sections) {
  std::vector<ClusterView> views;
  return encode_disk_page(views_of(clusters, &views), q, version, streams, sections);
}
std::vector<uint8_t> encode_disk_page(const std::vector<const ClusterView*>& clusters, const MeshQuantization& q,
                                      uint32_t version, DiskStreams* streams, DiskSections* sections) {
  assert(version == 1 || version == 2);
  const uint32_t channels = q.channel_count();
  std::vector<uint8_t> b;
  // The page's bound (break_batch's): no regrowth copies.
  uint64_t bound = 12;
  for (const auto* c : clusters) bound += disk_cluster_bytes(*c, channels, version);
  b.reserve(bound);
  append_le32(b, version >= 2 ? kDiskPageMagicV2 : kDiskPageMagic);
  append_le32(b, uint32_t(clusters.size()));
  for (const auto* c : clusters) b.push_back(uint8_t(c->vertex_count));
  for (const auto* c : clusters) b.push_back(uint8_t(c->triangle_count));
  for (const auto* c : clusters) b.push_back(uint8_t(c->run_count));
  for (const auto* c : clusters)
    for (uint32_t k = 0; k < channels; ++k) b.push_back(uint8_t(c->bits[k]));
  for (const auto* c : clusters)
    for (uint32_t k = 0; k < channels; ++k) append_le32(b, uint32_t(c->min[k]));
  size_t mark = b.size();
  if (streams) streams->headers.insert(streams->headers.end(), b.begin(), b.end());
  if (sections) sections->headers += b.size();
  auto section = [&](std::vector<uint8_t> DiskStreams::*s, uint64_t DiskSections::*n) {
    if (streams) (streams->*s).insert((streams->*s).end(), b.begin() + long(mark), b.end());
    if (sections) sections->*n += b.size() - mark;
    mark = b.size();
  };
  // Topology: one control byte per triangle, then the explicit references.
  uint32_t refs = 0;
  for (const auto* c : clusters) {
    b.insert(b.end(), c->ctl, c->ctl + c->triangle_count);
    refs += c->ref_count;
  }
  append_le32(b, refs);
  for (const auto* c : clusters) b.insert(b.end(), c->refs, c->refs + c->ref_count);
  section(&DiskStreams::topology, &DiskSections::topology);
  for (const auto* c : clusters) b.insert(b.end(), c->run_start, c->run_start + c->run_count);
  for (const auto* c : clusters)
    for (uint32_t r = 0; r < c->run_count; ++r) append_le32(b, c->run_material[r]);
  section(&DiskStreams::materials, &DiskSections::materials);
  if (version == 1) {
    // Vertices: per channel, per cluster, byte planes of zigzag deltas along first-use order.
    for (uint32_t k = 0; k < channels; ++k) {
      for (const auto* c : clusters) {
        const uint32_t nb = delta_bytes(c->bits[k]);
        for (uint32_t plane = 0; plane < nb; ++plane) {
          int32_t prev = c->min[k];
          for (uint32_t v = 0; v < c->vertex_count; ++v) {
            b.push_back(uint8_t(zigzag(c->values[k][v] - prev) >> (8 * plane)));
            prev = c->values[k][v];
          }
        }
      }
      section(k < 3 ? &DiskStreams::positions : channel_is_normal(q, k) ? &DiskStreams::normals : &DiskStreams::uvs,
              k < 3 ? &DiskSections::positions : channel_is_normal(q, k) ? &DiskSections::normals : &DiskSections::uvs);
    }
    return b;
  }
  // Version 2 copies: a vertex equal in every channel to a vertex of an earlier cluster of
  // the page (its first occurrence) is a reference to that page vertex.
  uint64_t total_vertices = 0;
  for (const auto* c : clusters) total_vertices += c->vertex_count;
  std::vector<uint32_t> copy_of(total_vertices, UINT32_MAX);
  {
    // First occurrence of each vertex value (all channels): an open-addressing table of page
    // vertex indices, linear probing, at most half full. A slot's values are read from the
    // cluster that holds the vertex (`holder`: cluster index << 8 | vertex, 4 bytes a page
    // vertex instead of a copy of its 12-28 value bytes: fewer fresh pages per page encoded).
    constexpr uint32_t kHolderVertexBits = 8;  // a cluster's vertex index: < kMaxClusterVertices
    static_assert(kMaxClusterVertices <= (1u << kHolderVertexBits), "holder packs the vertex in 8 bits");
    std::vector<uint32_t> holder(total_vertices);
    uint32_t size = 16;
    while (size < 2 * total_vertices) size *= 2;
    std::vector<uint32_t> first(size, UINT32_MAX);
    auto same_value = [&](uint32_t page_vertex, const int32_t* key) {
      const ClusterView& o = *clusters[holder[page_vertex] >> kHolderVertexBits];
      const uint32_t ov = holder[page_vertex] & ((1u << kHolderVertexBits) - 1);
      for (uint32_t k = 0; k < channels; ++k)
        if (o.values[k][ov] != key[k]) return false;
      return true;
    };
    uint32_t base = 0;
    for (size_t ci = 0; ci < clusters.size(); ++ci) {
      const ClusterView* c = clusters[ci];
      uint32_t residual_bytes = 0;
      for (uint32_t k = 0; k < channels; ++k) residual_bytes += delta_bytes(c->bits[k]);
      for (uint32_t v = 0; v < c->vertex_count; ++v) {
        holder[base + v] = uint32_t(ci) << kHolderVertexBits | v;
        int32_t key[kMaxChannels];
        uint64_t h = 1469598103934665603ull;  // FNV-1a over the channel values
        for (uint32_t k = 0; k < channels; ++k) {
          key[k] = c->values[k][v];
          h = (h ^ uint32_t(key[k])) * 1099511628211ull;
        }
        uint32_t slot = uint32_t(h) & (size - 1);
        while (first[slot] != UINT32_MAX && !same_value(first[slot], key)) slot = (slot + 1) & (size - 1);
        if (first[slot] == UINT32_MAX) first[slot] = base + v;
        else if (first[slot] < base && residual_bytes >= kCopyRefBytes) copy_of[base + v] = first[slot];
      }
      base += c->vertex_count;
    }
  }
  std::vector<uint8_t> mask((total_vertices + 7) / 8, 0);
  std::vector<uint32_t> copy_refs;
  int64_t expected = 0;
  for (uint64_t v = 0; v < total_vertices; ++v)
    if (copy_of[v] != UINT32_MAX) {
      mask[v / 8] |= uint8_t(1u << (v % 8));
      copy_refs.push_back(zigzag(int32_t(int64_t(copy_of[v]) - expected)));
      expected = int64_t(copy_of[v]) + 1;
    }
  if (streams) streams->copies += copy_refs.size();
  if (sections) sections->copies += copy_refs.size();
  b.insert(b.end(), mask.begin(), mask.end());
  for (uint32_t plane = 0; plane < kCopyRefBytes; ++plane)
    for (uint32_t z : copy_refs) b.push_back(uint8_t(z >> (8 * plane)));
  section(&DiskStreams::vertex_refs, &DiskSections::vertex_refs);
  // Residuals against the parallelogram / previous-vertex prediction, non-copies only.
  // Predictors per page vertex (strip_predictors fills each cluster's first vertex_count
  // entries), found once for every channel.
  std::vector<uint8_t> pred_store(size_t(total_vertices) * 3);
  std::unique_ptr<bool[]> has_store(new bool[total_vertices]);
  {
    uint64_t base = 0;
    for (const auto* c : clusters) {
      strip_predictors(*c, reinterpret_cast<uint8_t(*)[3]>(&pred_store[3 * base]), &has_store[base]);
      base += c->vertex_count;
    }
  }
  uint32_t z[kMaxClusterVertices];
  for (uint32_t k = 0; k < channels; ++k) {
    uint32_t base = 0;
    for (size_t i = 0; i < clusters.size(); ++i) {
      const ClusterView& c = *clusters[i];
      const uint32_t nb = delta_bytes(c.bits[k]);
      const bool* has = &has_store[base];
      const auto* pred = reinterpret_cast<const uint8_t(*)[3]>(&pred_store[3 * size_t(base)]);
      uint32_t zn = 0;
      if (nb > 0)
        for (uint32_t v = 0; v < c.vertex_count; ++v) {
          if (copy_of[base + v] != UINT32_MAX) continue;
          const int64_t p = predict_v2(c.values[k], v, c.min[k], channel_hi(c, k), pred, has);
          z[zn++] = zigzag(int32_t(int64_t(c.values[k][v]) - p));
        }
      size_t at = b.size();
      b.resize(at + size_t(nb) * zn);
      for (uint32_t plane = 0; plane < nb; ++plane)
        for (uint32_t j = 0; j < zn; ++j) b[at++] = uint8_t(z[j] >> (8 * plane));
      base += c.vertex_count;
    }
    section(k < 3 ? &DiskStreams::positions : channel_is_normal(q, k) ? &DiskStreams::normals : &DiskStreams::uvs,
              k < 3 ? &DiskSections::positions : channel_is_normal(q, k) ? &DiskSections::normals : &DiskSections::uvs);
  }
  return b;
}

void parse_disk_page(const uint8_t* data, size_t size, const MeshQuantization& q,
                     uint32_t expected_clusters, ClusterSink& sink, const std::string& where,
                     uint32_t version) {
  ByteReader r(data, size, where, kErrTruncated, "disk page");
  const uint32_t magic = version >= 2 ? kDiskPageMagicV2 : kDiskPageMagic;
  if (r.u32() != magic) fail(kErrBadMagic, where, version >= 2 ? "disk page magic is not VDP2" : "disk page magic is not VDPG");
  const uint32_t n = r.u32();
  if (n != expected_clusters) fail(kErrInconsistent, where, "disk page cluster count differs from the page table");
  if (n == 0) fail(kErrOutOfRange, where, "disk page with no cluster");  // as validate_memory_page
  // Each cluster takes ≥ 3 + 5·channels header bytes: n is bounded by the page size
  // before the (small) per-cluster header arrays are allocated.
  const uint32_t channels = q.channel_count();
  if (uint64_t(n) * (3 + 5 * channels) > size - r.pos) fail(kErrTruncated, where, "disk page shorter than its cluster headers");
  struct Head {
    uint32_t vc, tc, runs, bits[kMaxChannels];
    int32_t min[kMaxChannels];
    size_t ctl, refs, run_start, run_material;  // section offsets of this cluster
    uint32_t first_vertex = 0, copies = 0;       // version 2: page vertex index, copy count
  };
  std::vector<Head> hs(n);
  for (Head& h : hs) h.vc = r.u8();
  for (Head& h : hs) h.tc = r.u8();
  for (Head& h : hs) h.runs = r.u8();
  for (const Head& h : hs)
    if (h.vc == 0 || h.tc == 0 || h.tc > kMaxClusterTriangles || h.runs == 0 || h.runs > h.tc)
      fail(kErrOutOfRange, where, "cluster vertex/triangle/run count out of range");
  for (Head& h : hs)
    for (uint32_t k = 0; k < channels; ++k) {
      h.bits[k] = r.u8();
      if (h.bits[k] > channel_max_bits(q, k)) fail(kErrOutOfRange, where, "channel bit width out of range");
    }
  for (Head& h : hs)
    for (uint32_t k = 0; k < channels; ++k) {
      h.min[k] = int32_t(r.u32());
      int64_t kind_lo = 0, kind_hi = 0;
      channel_value_range(q, k, &kind_lo, &kind_hi);
      if (h.min[k] < kind_lo || h.min[k] > kind_hi)
        fail(kErrOutOfRange, where, "channel minimum out of range");
    }
  // Section layout from the headers alone.
  uint64_t total_tris = 0;
  for (Head& h : hs) {
    h.ctl = r.pos;
    r.take(h.tc);
    total_tris += h.tc;
  }
  const uint32_t ref_total = r.u32();
  if (ref_total > 3 * total_tris) fail(kErrOutOfRange, where, "more references than triangle corners");
  const uint8_t* refs = r.take(ref_total);
  for (Head& h : hs) {
    h.run_start = r.pos;
    r.take(h.runs);
  }
  for (Head& h : hs) {
    h.run_material = r.pos;
    r.take(4 * size_t(h.runs));
  }
  // Version 2: copy mask (one bit per page vertex) and the copy references.
  const uint8_t* mask = nullptr;
  const uint8_t* copy_planes = nullptr;
  uint64_t total_vertices = 0, copy_total = 0;
  if (version >= 2) {
    for (Head& h : hs) {
      h.first_vertex = uint32_t(total_vertices);
      total_vertices += h.vc;
    }
    const size_t mask_bytes = size_t((total_vertices + 7) / 8);
    mask = r.take(mask_bytes);
    if (total_vertices % 8 && (mask[mask_bytes - 1] >> (total_vertices % 8)) != 0)
      fail(kErrOutOfRange, where, "copy mask padding bits set");
    for (Head& h : hs) {
      for (uint32_t v = h.first_vertex; v < h.first_vertex + h.vc; ++v) h.copies += (mask[v / 8] >> (v % 8)) & 1u;
      copy_total += h.copies;
    }
    copy_planes = r.take(size_t(copy_total) * kCopyRefBytes);
  }
  std::vector<size_t> planes(size_t(n) * channels);
  for (uint32_t k = 0; k < channels; ++k)
    for (uint32_t i = 0; i < n; ++i) {
      planes[size_t(i) * channels + k] = r.pos;
      r.take(size_t(delta_bytes(hs[i].bits[k])) * (hs[i].vc - hs[i].copies));
    }
  if (r.pos != size) fail(kErrTrailingBytes, where, "disk page longer than its clusters");

  // Version 2: values of the page's vertices so far (copy sources), channel-interleaved.
  // Grows with the clusters parsed: ≤ 255 · channels · 4 bytes per declared cluster.
  std::vector<int32_t> page_values;
  uint64_t copy_used = 0;
  int64_t copy_expected = 0;
  CanonicalCluster c;
  uint32_t ref_used = 0;
  for (uint32_t i = 0; i < n; ++i) {
    const Head& h = hs[i];
    c.vertex_count = h.vc;
    c.triangle_count = h.tc;
    c.run_count = h.runs;
    c.ref_count = 0;
    for (uint32_t k = 0; k < kMaxChannels; ++k) {
      c.bits[k] = k < channels ? h.bits[k] : 0;
      c.min[k] = k < channels ? h.min[k] : 0;
    }
    // Topology.
    uint32_t seen = 0;
    auto corner = [&](bool is_ref) -> uint8_t {
      if (!is_ref) {
        if (seen >= c.vertex_count) fail(kErrOutOfRange, where, "strip introduces more vertices than the cluster has");
        return uint8_t(seen++);
      }
      if (ref_used >= ref_total) fail(kErrInconsistent, where, "strip uses more references than declared");
      const uint32_t back = refs[ref_used++];
      c.refs[c.ref_count++] = uint8_t(back);
      if (back >= seen) fail(kErrOutOfRange, where, "reference to a vertex not yet introduced");
      return uint8_t(seen - 1 - back);
    };
    for (uint32_t t = 0; t < c.triangle_count; ++t) {
      const uint8_t ctl = data[h.ctl + t];
      c.ctl[t] = ctl;
      uint8_t* s = c.strip[t];
      if (ctl & kCtlReset) {
        if (ctl & (0xE0u | kCtlSide)) fail(kErrOutOfRange, where, "strip control byte has reserved bits set");
        for (int k = 0; k < 3; ++k) s[k] = corner(ctl & (kCtlRef0 << k));
      } else {
        if (t == 0) fail(kErrOutOfRange, where, "first triangle of a cluster does not start a strip");
        if (ctl & 0xF8u) fail(kErrOutOfRange, where, "strip control byte has reserved bits set");
        const uint8_t* p = c.strip[t - 1];
        if (ctl & kCtlSide) s[0] = p[0], s[1] = p[2];
        else s[0] = p[2], s[1] = p[1];
        s[2] = corner(ctl & kCtlRef0);
      }
    }
    // Material runs.
    for (uint32_t k = 0; k < c.run_count; ++k) {
      c.run_start[k] = data[h.run_start + k];
      const uint8_t* m = data + h.run_material + 4 * k;
      c.run_material[k] = load_le32(m);
      if (k == 0 ? c.run_start[0] != 0 : c.run_start[k] <= c.run_start[k - 1] || c.run_start[k] >= c.triangle_count)
        fail(kErrOutOfRange, where, "material runs not strictly increasing from 0");
      if (c.run_material[k] > kMaxMaterialId) fail(kErrOutOfRange, where, "material id beyond 2^24 - 1");
      if (k > 0 && c.run_material[k] <= c.run_material[k - 1])
        fail(kErrNonCanonical, where, "material ids of a cluster's runs not strictly increasing");
    }
    // Vertices.
    bool is_copy[kMaxClusterVertices] = {};
    if (version >= 2) {
      for (uint32_t v = 0; v < c.vertex_count; ++v) {
        const uint32_t pv = h.first_vertex + v;
        if (!((mask[pv / 8] >> (pv % 8)) & 1u)) continue;
        is_copy[v] = true;
        uint32_t zz = 0;
        for (uint32_t plane = 0; plane < kCopyRefBytes; ++plane)
          zz |= uint32_t(copy_planes[size_t(plane) * copy_total + copy_used]) << (8 * plane);
        ++copy_used;
        const int64_t src = copy_expected + unzigzag(zz);
        if (src < 0 || src >= int64_t(h.first_vertex))
          fail(kErrOutOfRange, where, "vertex copy does not refer to an earlier cluster of the page");
        copy_expected = src + 1;
        for (uint32_t k = 0; k < channels; ++k) c.values[k][v] = page_values[size_t(src) * channels + k];
      }
    }
    uint8_t pred[kMaxClusterVertices][3];
    bool has[kMaxClusterVertices];
    if (version >= 2) strip_predictors(c, pred, has);
    for (uint32_t k = 0; k < channels; ++k) {
      const uint32_t nb = delta_bytes(c.bits[k]);
      const uint8_t* pl = data + planes[size_t(i) * channels + k];
      const uint32_t stored = c.vertex_count - h.copies;
      const int64_t lo = c.min[k], hi = lo + (int64_t(1) << c.bits[k]) - 1;
      int64_t kind_lo = 0, kind_hi = 0;
      channel_value_range(q, k, &kind_lo, &kind_hi);
      int64_t prev = lo, seen_lo = INT64_MAX, seen_hi = INT64_MIN;
      for (uint32_t v = 0, s = 0; v < c.vertex_count; ++v) {
        int64_t value;
        if (is_copy[v]) {
          value = c.values[k][v];
        } else {
          uint32_t z = 0;
          for (uint32_t plane = 0; plane < nb; ++plane) z |= uint32_t(pl[size_t(plane) * stored + s]) << (8 * plane);
          ++s;
          const int64_t p = version >= 2 ? predict_v2(c.values[k], v, lo, hi, pred, has) : prev;
          value = p + unzigzag(z);
        }
        if (value < lo || value > hi || value < kind_lo || value > kind_hi) fail(kErrOutOfRange, where, "vertex value outside its cluster range");
        c.values[k][v] = int32_t(value);
        seen_lo = std::min(seen_lo, value);
        seen_hi = std::max(seen_hi, value);
        prev = value;
      }
      if (seen_lo != lo || bits_for_range(uint32_t(seen_hi - seen_lo)) != c.bits[k])
        fail(kErrNonCanonical, where, "channel minimum/bit width not the tightest");
    }
    if (version >= 2)
      for (uint32_t v = 0; v < c.vertex_count; ++v)
        for (uint32_t k = 0; k < channels; ++k) page_values.push_back(c.values[k][v]);
    sink.cluster(i, c);
  }
  if (ref_used != ref_total) fail(kErrInconsistent, where, "declared references left unused");
}

}  // namespace vgeo::format_detail
