// Monotonicity (MONO_*), cut validity (CUT_*) and crack freedom (CRACK_*):
// spec/invariants.md §2–§4. The view-dependent checks share random views: each view is
// tested for projected-error monotonicity and then cut at several pixel thresholds; every
// cut is checked for exact leaf coverage, sibling agreement and open edges.
// Based on: the cut conditions of Cignoni et al., "Batched Multi Triangulation", IEEE
// Visualization 2005, as Nanite applies them to cluster groups (Karis et al. 2021).
#include <algorithm>
#include <atomic>
#include <cmath>
#include <numeric>
#include <string>

#include "vgeo/core/lod.h"
#include "vgeo/core/thread_pool.h"
#include "vgeo/verify/verify_detail.h"

namespace vgeo {
namespace verify_detail {
namespace {

uint64_t pack_edge(uint32_t a, uint32_t b) {
  if (a > b) std::swap(a, b);
  return (uint64_t(a) << 32) | b;
}

// Welding key: exact position bits, with -0 folded onto +0 (same point).
struct WeldKey {
  uint32_t x, y, z;
  bool operator<(const WeldKey& o) const { return x != o.x ? x < o.x : y != o.y ? y < o.y : z < o.z; }
  bool operator==(const WeldKey& o) const { return x == o.x && y == o.y && z == o.z; }
};
WeldKey weld_key(const float* p) { return {float_bits(p[0] + 0.0f), float_bits(p[1] + 0.0f), float_bits(p[2] + 0.0f)}; }

// Open-addressing table of edge parities, reused across cuts (cleared via its slot list).
class EdgeParity {
 public:
  void reset(size_t expected) {
    size_t cap = 16;
    while (cap < 2 * expected) cap <<= 1;
    if (keys_.size() < cap) {
      keys_.assign(cap, kEmpty);
      odd_.assign(cap, 0);
      owner_.assign(cap, kNone);
    } else {
      for (size_t s : used_) keys_[s] = kEmpty;
    }
    mask_ = keys_.size() - 1;
    used_.clear();
  }
  void toggle(uint64_t key, uint32_t owner) {
    size_t s = size_t((key * 0x9E3779B97F4A7C15ull) >> 17) & mask_;
    while (keys_[s] != kEmpty && keys_[s] != key) s = (s + 1) & mask_;
    if (keys_[s] == kEmpty) {
      keys_[s] = key;
      odd_[s] = 1;
      owner_[s] = owner;
      used_.push_back(s);
    } else {
      odd_[s] ^= 1;
      owner_[s] = owner;
    }
  }
  template <class F>
  void for_each_odd(F&& f) const {
    for (size_t s : used_)
      if (odd_[s]) f(keys_[s], owner_[s]);
  }

 private:
  static constexpr uint64_t kEmpty = ~0ull;  // (kNone, kNone) is never a welded edge
  std::vector<uint64_t> keys_;
  std::vector<uint8_t> odd_;
  std::vector<uint32_t> owner_;
  std::vector<size_t> used_;
  size_t mask_ = 0;
};

struct CutScratch {
  std::vector<uint32_t> sel;  // per cluster: times selected
  std::vector<uint32_t> up_min, up_max;
  std::vector<uint32_t> list;  // distinct selected clusters
  EdgeParity edges;
};

// Coverage by DP over groups in decreasing level: for every cluster, the minimum and
// maximum number of selected clusters over all upward paths starting at it.
void check_coverage(const ClusterDag& dag, const CutCheckContext& ctx, CutScratch& s, Sink& sink,
                    const std::string& where, const std::vector<VerifyValue>& extra) {
  s.up_min.resize(dag.clusters.size());
  s.up_max.resize(dag.clusters.size());
  for (uint32_t g : ctx.group_order) {
    const DagGroup& G = dag.groups[g];
    uint32_t lo = 0, hi = 0;
    if (G.generated_count) {
      lo = ~0u;
      for (uint32_t i = 0; i < G.generated_count; ++i) {
        uint32_t p = dag.generated_clusters[G.first_generated + i];
        lo = std::min(lo, s.up_min[p]);
        hi = std::max(hi, s.up_max[p]);
      }
    }
    for (uint32_t i = 0; i < G.cluster_count; ++i) {
      uint32_t c = G.first_cluster + i;
      s.up_min[c] = s.sel[c] + lo;
      s.up_max[c] = s.sel[c] + hi;
    }
  }
  for (size_t c = 0; c < dag.clusters.size(); ++c) {
    if (dag.clusters[c].generating_group != kNone) continue;
    if (s.up_min[c] == 1 && s.up_max[c] == 1) continue;
    if (!sink.take("CUT_COVERAGE")) continue;
    std::vector<VerifyValue> values{{"min_selected_on_path", double(s.up_min[c])},
                                    {"max_selected_on_path", double(s.up_max[c])}};
    values.insert(values.end(), extra.begin(), extra.end());
    sink.stored.push_back({"CUT_COVERAGE", "cut", "cluster", c,
                           "leaf covered " + idx(s.up_min[c]) + ".." + idx(s.up_max[c]) +
                               " times over its upward paths (must be exactly 1)" + where,
                           std::move(values)});
  }
}

// Open edges of the cut (mod 2) must equal the leaves' open edges, except that edges
// between two mesh-border vertices may differ (the mesh's own border was simplified)
// unless `strict_border`.
void check_cracks(const CutCheckContext& ctx, CutScratch& s, Sink& sink, const std::string& where,
                  const std::vector<VerifyValue>& extra, bool strict_border, uint64_t* mismatched,
                  uint64_t* border_changed) {
  size_t n = ctx.leaf_open_edges.size();
  for (uint32_t c : s.list) n += ctx.edge_offset[c + 1] - ctx.edge_offset[c];
  s.edges.reset(n);
  for (uint64_t e : ctx.leaf_open_edges) s.edges.toggle(e, kNone);
  for (uint32_t c : s.list)
    for (uint32_t i = ctx.edge_offset[c]; i < ctx.edge_offset[c + 1]; ++i) s.edges.toggle(ctx.edges[i], c);
  s.edges.for_each_odd([&](uint64_t key, uint32_t owner) {
    ++*mismatched;
    uint32_t a = uint32_t(key >> 32), b = uint32_t(key);
    const bool border = ctx.on_mesh_border[a] && ctx.on_mesh_border[b];
    if (border) {
      ++*border_changed;
      if (!strict_border) return;
    }
    const char* code = border ? "CRACK_BORDER_CHANGED" : "CRACK_OPEN_EDGE";
    if (!sink.take(code)) return;
    const float* pa = &ctx.weld_positions[3 * size_t(a)];
    const float* pb = &ctx.weld_positions[3 * size_t(b)];
    std::vector<VerifyValue> values{{"ax", pa[0]}, {"ay", pa[1]}, {"az", pa[2]},
                                    {"bx", pb[0]}, {"by", pb[1]}, {"bz", pb[2]}};
    values.insert(values.end(), extra.begin(), extra.end());
    // The line names the edge (welded vertex ids and positions): two violations of one cut
    // never read as duplicates, and the edge can be found without --json.
    auto end = [&](uint32_t id, const float* p) {
      return "v" + std::to_string(id) + " (" + fmt_float(p[0]) + ", " + fmt_float(p[1]) + ", " + fmt_float(p[2]) + ")";
    };
    const std::string edge = "edge " + end(a, pa) + " - " + end(b, pb);
    std::string msg = owner == kNone
                          ? "an open " + edge + " of the leaves is not open in the cut (covered or moved)"
                          : edge + " open in the cut but not in the leaves (hole, T-junction or moved vertex)";
    sink.stored.push_back({code, "crack", owner == kNone ? "edge" : "cluster",
                           owner == kNone ? uint64_t(kNone) : owner, msg + where, std::move(values)});
  });
}

}  // namespace

std::vector<uint32_t> groups_by_decreasing_level(const ClusterDag& dag) {
  std::vector<uint32_t> order(dag.groups.size());
  std::iota(order.begin(), order.end(), 0u);
  std::stable_sort(order.begin(), order.end(),
                   [&](uint32_t a, uint32_t b) { return dag.groups[a].level > dag.groups[b].level; });
  return order;
}

void check_monotonic_static(const ClusterDag& dag, Sink& sink, CheckStats& stats) {
  const char* kCheck = "monotonic";
  for (size_t c = 0; c < dag.clusters.size(); ++c) {
    const DagCluster& k = dag.clusters[c];
    ++stats.items;
    if (!(k.parent_error >= k.lod_error))
      sink.add("MONO_ERROR", kCheck, "cluster", c,
               "parent_error " + fmt_float(k.parent_error) + " < lod_error " + fmt_float(k.lod_error),
               {{"parent_error", k.parent_error}, {"lod_error", k.lod_error}});
    if (!contains_tol(k.parent_bounds, k.lod_bounds))
      sink.add("MONO_BOUNDS", kCheck, "cluster", c,
               "parent_bounds " + fmt_sphere(k.parent_bounds) + " do not enclose lod_bounds " + fmt_sphere(k.lod_bounds) +
                   miss_text(containment_miss(k.parent_bounds, k.lod_bounds)),
               miss_values(containment_miss(k.parent_bounds, k.lod_bounds)));
    // DAG edges c -> p (p generated by c's group). With shared values these are the same
    // comparisons as above; test them directly only when the sharing is broken.
    const DagGroup& G = dag.groups[k.group];
    for (uint32_t i = 0; i < G.generated_count; ++i) {
      uint32_t p = dag.generated_clusters[G.first_generated + i];
      const DagCluster& P = dag.clusters[p];
      if (!same_bits(P.lod_error, k.parent_error) && !(P.lod_error >= k.lod_error))
        sink.add("MONO_ERROR", kCheck, "cluster", c,
                 "generated cluster " + idx(p) + "'s lod_error " + fmt_float(P.lod_error) + " < lod_error " +
                     fmt_float(k.lod_error),
                 {{"parent_lod_error", P.lod_error}, {"lod_error", k.lod_error}});
      if (!same_bits(P.lod_bounds, k.parent_bounds) && !contains_tol(P.lod_bounds, k.lod_bounds))
        sink.add("MONO_BOUNDS", kCheck, "cluster", c,
                 "generated cluster " + idx(p) + "'s lod_bounds do not enclose lod_bounds " + fmt_sphere(k.lod_bounds) +
                     miss_text(containment_miss(P.lod_bounds, k.lod_bounds)),
                 miss_values(containment_miss(P.lod_bounds, k.lod_bounds)));
    }
  }
}

namespace {

// What every view of one check_views call reads: the DAG, the options, which checks run, the
// cut-check context and the scene's scale for camera placement.
struct ViewChecks {
  const ClusterDag& dag;
  const VerifyOptions& options;
  bool monotonic, cut, crack;
  CutCheckContext ctx;
  size_t nc = 0;  // clusters
  double diag = 1.0;  // the leaves' AABB diagonal (≥ a tiny floor)
  Vec3 mid;           // the leaves' AABB centre
};

// One view's findings, merged in view order after all views ran.
struct ViewOutput {
  Sink mono, cut, crack;
  uint64_t edges = 0, border_changed = 0;
  std::vector<double> cut_sizes;
};

// One worker's scratch, reused across its views.
struct ViewScratch {
  CutScratch cut;
  std::vector<float> proj_lod, proj_parent;  // per cluster, in the current view
};

// The view: an eye placed relative to a random sphere of the DAG.
LodView random_view(const ViewChecks& vc, SplitMix64& rng) {
  const ClusterDag& dag = vc.dag;
  const double diag = vc.diag;
  const DagCluster& anchor = dag.clusters[rng.below(uint32_t(vc.nc))];
  uint32_t which = rng.below(3);
  Sphere s0 = which == 0 ? anchor.bounds : which == 1 ? anchor.lod_bounds : anchor.parent_bounds;
  double r = std::max(0.0, double(s0.radius));
  double z = 2 * rng.uniform() - 1, phi = 6.283185307179586 * rng.uniform();
  double rho = std::sqrt(std::max(0.0, 1 - z * z));
  double dir[3] = {rho * std::cos(phi), rho * std::sin(phi), z};
  uint32_t mode = rng.below(6);
  double dist = 0;
  Vec3 base = s0.center;
  switch (mode) {
    case 0: dist = 0; break;                                     // at the centre
    case 1: dist = r * rng.uniform(); break;                     // inside the sphere
    case 2: dist = r; break;                                     // on its surface
    case 3: dist = r * (1 + rng.uniform()); break;               // just outside
    case 4: dist = (r + diag) * std::pow(10.0, 4 * rng.uniform()); break;  // far: up to 10^4 scene sizes
    default: base = vc.mid; dist = diag * rng.uniform(); break;  // anywhere around the scene
  }
  LodView view;
  view.eye = {float(base.x + dir[0] * dist), float(base.y + dir[1] * dist), float(base.z + dir[2] * dist)};
  double fov = (15.0 + 85.0 * rng.uniform()) * 3.141592653589793 / 180.0;
  double height = 64.0 + 4256.0 * rng.uniform();
  view.pixels_per_unit_at_1 = lod_projection_scale(float(fov), float(height));
  view.z_near = float(diag * std::pow(10.0, -6 + 5 * rng.uniform()));
  if (!(view.z_near > 0)) view.z_near = 1e-6f;
  return view;
}

// MONO_PROJECTED: along every DAG edge and within every cluster.
void check_projected_monotonic(const ClusterDag& dag, const std::vector<float>& proj_lod,
                               const std::vector<float>& proj_parent, const std::string& view_where,
                               const std::vector<VerifyValue>& view_values, ViewOutput& out) {
  for (size_t c = 0; c < dag.clusters.size(); ++c) {
    if (!(proj_lod[c] <= proj_parent[c]) && out.mono.take("MONO_PROJECTED")) {
      auto values = view_values;
      values.push_back({"projected_lod_error", proj_lod[c]});
      values.push_back({"projected_parent_error", proj_parent[c]});
      out.mono.stored.push_back({"MONO_PROJECTED", "monotonic", "cluster", c,
                                 "projected lod_error " + fmt_float(proj_lod[c]) + " px > projected parent_error " +
                                     fmt_float(proj_parent[c]) + " px" + view_where,
                                 std::move(values)});
    }
  }
  for (const DagGroup& G : dag.groups) {
    if (!G.generated_count) continue;
    float max_child = 0;
    uint32_t worst_child = G.first_cluster;
    for (uint32_t i = 0; i < G.cluster_count; ++i)
      if (proj_lod[G.first_cluster + i] > max_child) {
        max_child = proj_lod[G.first_cluster + i];
        worst_child = G.first_cluster + i;
      }
    for (uint32_t i = 0; i < G.generated_count; ++i) {
      uint32_t p = dag.generated_clusters[G.first_generated + i];
      ++out.edges;
      if (!(proj_lod[p] >= max_child) && out.mono.take("MONO_PROJECTED")) {
        auto values = view_values;
        values.push_back({"projected_child_lod_error", max_child});
        values.push_back({"projected_parent_lod_error", proj_lod[p]});
        out.mono.stored.push_back({"MONO_PROJECTED", "monotonic", "cluster", worst_child,
                                   "projected lod_error " + fmt_float(max_child) + " px exceeds generated cluster " +
                                       idx(p) + "'s " + fmt_float(proj_lod[p]) + " px" + view_where,
                                   std::move(values)});
      }
    }
  }
}

// The pixel threshold of cut t of a view: 1 px first, then stored projected values.
float random_threshold(uint32_t t, const ViewScratch& w, SplitMix64& rng) {
  float tau = 1.0f;  // the usual "one pixel" target
  if (t > 0) {
    const uint32_t nc = uint32_t(w.proj_parent.size());
    float ref = w.proj_parent[rng.below(nc)];
    if (!(ref > 0) || !std::isfinite(ref)) ref = w.proj_lod[rng.below(nc)];
    if (!(ref > 0) || !std::isfinite(ref)) ref = 1.0f;
    // t == 1: exactly a stored projected value (ties exercise the ≤ / > split);
    // otherwise a random factor in [1/4, 4] around one.
    tau = t == 1 ? ref : float(ref * std::pow(2.0, 4 * rng.uniform() - 2));
    if (!(tau > 0) || !std::isfinite(tau)) tau = 1.0f;
  }
  return tau;
}

// Sibling agreement: members decide the parent test alike; generated clusters decide the
// lod test alike.
void check_siblings(const ClusterDag& dag, const ViewScratch& w, float tau, const std::string& where,
                    const std::vector<VerifyValue>& values, Sink& sink) {
  for (size_t g = 0; g < dag.groups.size(); ++g) {
    const DagGroup& G = dag.groups[g];
    bool first = parent_too_coarse(w.proj_parent[G.first_cluster], tau);
    for (uint32_t i = 1; i < G.cluster_count; ++i)
      if (parent_too_coarse(w.proj_parent[G.first_cluster + i], tau) != first) {
        sink.add("CUT_SIBLING", "cut", "group", g,
                 "members disagree on the parent test (cluster " + idx(G.first_cluster + i) + ")" + where, values);
        break;
      }
    if (G.generated_count) {
      uint32_t p0 = dag.generated_clusters[G.first_generated];
      bool gfirst = fine_enough(w.proj_lod[p0], tau);
      for (uint32_t i = 1; i < G.generated_count; ++i) {
        uint32_t p = dag.generated_clusters[G.first_generated + i];
        if (fine_enough(w.proj_lod[p], tau) != gfirst) {
          sink.add("CUT_SIBLING", "cut", "group", g,
                   "generated clusters disagree on the lod test (cluster " + idx(p) + ")" + where, values);
          break;
        }
      }
    }
  }
}

// Cuts at several thresholds: each selected, then checked for siblings, coverage and cracks.
void check_cuts(const ViewChecks& vc, ViewScratch& w, uint32_t v, SplitMix64& rng,
                const std::vector<VerifyValue>& view_values, ViewOutput& out) {
  CutScratch& s = w.cut;
  for (uint32_t t = 0; t < vc.options.thresholds_per_view; ++t) {
    const float tau = random_threshold(t, w, rng);
    const std::string where = " (view " + idx(v) + ", threshold " + fmt_float(tau) + " px)";
    auto values = view_values;
    values.push_back({"threshold_px", tau});
    s.list.clear();
    for (size_t c = 0; c < vc.nc; ++c) {
      const bool selected = cut_selects(w.proj_parent[c], w.proj_lod[c], tau);
      s.sel[c] = selected;
      if (selected) s.list.push_back(uint32_t(c));
    }
    out.cut_sizes.push_back(double(s.list.size()));
    if (vc.cut) {
      check_siblings(vc.dag, w, tau, where, values, out.cut);
      check_coverage(vc.dag, vc.ctx, s, out.cut, where, values);
    }
    if (vc.crack && vc.ctx.usable) {
      uint64_t mismatched = 0;
      check_cracks(vc.ctx, s, out.crack, where, values, vc.options.strict_border, &mismatched, &out.border_changed);
    }
  }
}

// View v: its eye from its own random stream, the projected errors, then the checks.
void check_view(const ViewChecks& vc, ViewScratch& w, uint32_t v, ViewOutput& out) {
  SplitMix64 rng(vc.options.seed * 0x2545F4914F6CDD1Dull + v);
  rng.next();
  const LodView view = random_view(vc, rng);
  const std::string view_where = " (view " + idx(v) + ")";
  std::vector<VerifyValue> view_values{{"view", double(v)}, {"eye_x", view.eye.x}, {"eye_y", view.eye.y},
                                       {"eye_z", view.eye.z}};
  for (size_t c = 0; c < vc.nc; ++c) {
    const DagCluster& k = vc.dag.clusters[c];
    w.proj_lod[c] = projected_error(k.lod_bounds, k.lod_error, view);
    w.proj_parent[c] = projected_error(k.parent_bounds, k.parent_error, view);
  }
  if (vc.monotonic) check_projected_monotonic(vc.dag, w.proj_lod, w.proj_parent, view_where, view_values, out);
  if (vc.cut || vc.crack) check_cuts(vc, w, v, rng, view_values, out);
}

}  // namespace

void check_views(const ClusterDag& dag, const VerifyOptions& options, bool monotonic, bool cut, bool crack,
                 Sink& mono_sink, Sink& cut_sink, Sink& crack_sink, ViewCheckResult* result) {
  ViewChecks vc{dag, options, monotonic, cut, crack, {}, 0, 1.0, {}};
  if (cut || crack) vc.ctx = prepare_cut_check(dag);
  if (!vc.ctx.usable) vc.ctx.group_order = groups_by_decreasing_level(dag);
  vc.nc = dag.clusters.size();
  // Scene scale for camera placement: the leaves' AABB diagonal (≥ a tiny floor).
  double diag = 0;
  if (!dag.bounds.empty())
    diag = distance_d(dag.bounds.min, dag.bounds.max);
  if (!(diag > 0)) diag = 1.0;
  vc.diag = diag;
  vc.mid = dag.bounds.empty() ? Vec3{} : (dag.bounds.min + dag.bounds.max) * 0.5f;

  const uint32_t views = options.views;
  std::vector<ViewOutput> per_view(views);
  for (auto& pv : per_view) pv.mono.cap = pv.cut.cap = pv.crack.cap = options.max_stored_per_code;

  ThreadPool pool(options.threads);
  std::atomic<uint32_t> next{0};
  pool.run_on_all([&](unsigned) {
    ViewScratch w;
    w.cut.sel.assign(vc.nc, 0);
    w.proj_lod.resize(vc.nc);
    w.proj_parent.resize(vc.nc);
    for (uint32_t v; (v = next.fetch_add(1)) < views;) check_view(vc, w, v, per_view[v]);
  });
  for (auto& pv : per_view) {
    mono_sink.merge(pv.mono);
    cut_sink.merge(pv.cut);
    crack_sink.merge(pv.crack);
    result->projected_edges += pv.edges;
    result->border_edges_changed += pv.border_changed;
    result->cut_sizes.insert(result->cut_sizes.end(), pv.cut_sizes.begin(), pv.cut_sizes.end());
  }
  result->views = views;
  result->cuts = result->cut_sizes.size();
}

}  // namespace verify_detail

using namespace verify_detail;

CutCheckContext prepare_cut_check(const ClusterDag& dag) {
  CutCheckContext ctx;
  {
    Sink sink;
    CheckStats stats;
    bool safe = false;
    check_structure(dag, sink, stats, &safe);
    if (!safe) return ctx;
  }
  ctx.usable = true;
  ctx.group_order = groups_by_decreasing_level(dag);
  // Weld every vertex by exact position bits.
  const size_t nv = dag.vertex_count();
  std::vector<uint32_t> order(nv);
  std::iota(order.begin(), order.end(), 0u);
  std::vector<WeldKey> keys(nv);
  for (size_t v = 0; v < nv; ++v) keys[v] = weld_key(&dag.positions[3 * v]);
  std::sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) {
    return keys[a] < keys[b] || (keys[a] == keys[b] && a < b);
  });
  ctx.weld_id.assign(nv, 0);
  uint32_t id = 0;
  for (size_t i = 0; i < nv; ++i) {
    if (i > 0 && !(keys[order[i]] == keys[order[i - 1]])) ++id;
    if (i == 0 || !(keys[order[i]] == keys[order[i - 1]]))
      ctx.weld_positions.insert(ctx.weld_positions.end(), &dag.positions[3 * size_t(order[i])],
                                &dag.positions[3 * size_t(order[i])] + 3);
    ctx.weld_id[order[i]] = id;
  }
  // Each cluster's odd-use edges (its boundary mod 2); zero-length edges carry no area.
  const size_t nc = dag.clusters.size();
  ctx.edge_offset.assign(nc + 1, 0);
  std::vector<uint64_t> scratch, leaf;
  for (size_t c = 0; c < nc; ++c) {
    const DagCluster& k = dag.clusters[c];
    scratch.clear();
    for (uint32_t t = 0; t < k.triangle_count; ++t) {
      const uint8_t* tri = &dag.indices[3 * (size_t(k.triangle_offset) + t)];
      uint32_t w[3];
      for (int j = 0; j < 3; ++j) w[j] = ctx.weld_id[size_t(k.vertex_offset) + tri[j]];
      for (int j = 0; j < 3; ++j)
        if (w[j] != w[(j + 1) % 3]) scratch.push_back(pack_edge(w[j], w[(j + 1) % 3]));
    }
    std::sort(scratch.begin(), scratch.end());
    for (size_t i = 0; i < scratch.size();) {
      size_t j = i;
      while (j < scratch.size() && scratch[j] == scratch[i]) ++j;
      if ((j - i) % 2) {
        ctx.edges.push_back(scratch[i]);
        if (k.generating_group == kNone) leaf.push_back(scratch[i]);
      }
      i = j;
    }
    ctx.edge_offset[c + 1] = uint32_t(ctx.edges.size());
  }
  std::sort(leaf.begin(), leaf.end());
  for (size_t i = 0; i < leaf.size();) {
    size_t j = i;
    while (j < leaf.size() && leaf[j] == leaf[i]) ++j;
    if ((j - i) % 2) ctx.leaf_open_edges.push_back(leaf[i]);
    i = j;
  }
  ctx.on_mesh_border.assign(ctx.weld_positions.size() / 3, 0);
  for (uint64_t e : ctx.leaf_open_edges) ctx.on_mesh_border[e >> 32] = ctx.on_mesh_border[uint32_t(e)] = 1;
  return ctx;
}

bool CutCheck::ok() const { return counts.empty(); }

CutCheck check_cut(const ClusterDag& dag, const CutCheckContext& ctx, const std::vector<uint32_t>& selected,
                   uint32_t max_stored, bool strict_border) {
  CutCheck out;
  Sink sink;
  sink.cap = max_stored;
  out.selected = selected.size();
  if (!ctx.usable) {
    sink.add("CUT_DAG_UNUSABLE", "cut", "dag", 0, "the DAG fails the structure check's index-safety rules");
  } else {
    CutScratch s;
    s.sel.assign(dag.clusters.size(), 0);
    for (size_t i = 0; i < selected.size(); ++i) {
      uint32_t c = selected[i];
      if (c >= dag.clusters.size()) {
        sink.add("CUT_DANGLING_INDEX", "cut", "selection", i, "selected cluster " + idx(c) + " out of range");
        continue;
      }
      if (s.sel[c]++ == 0) s.list.push_back(c);
      else sink.add("CUT_DUPLICATE", "cut", "cluster", c, "cluster selected more than once");
    }
    // Crack check over distinct clusters (a duplicate is already a coverage violation).
    check_coverage(dag, ctx, s, sink, "", {});
    out.leaf_open_edges = ctx.leaf_open_edges.size();
    check_cracks(ctx, s, sink, "", {}, strict_border, &out.mismatched_edges, &out.border_edges_changed);
  }
  out.violations = std::move(sink.stored);
  out.counts = std::move(sink.counts);
  return out;
}

CutCheck check_cut(const ClusterDag& dag, const std::vector<uint32_t>& selected) {
  return check_cut(dag, prepare_cut_check(dag), selected);
}

}  // namespace vgeo
