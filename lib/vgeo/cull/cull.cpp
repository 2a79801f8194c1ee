// Cluster culling: LOD cut, frustum and two-pass occlusion against the previous frame's HZB.
// Based on: Karis, Stubbe, Wihlidal, "Nanite: A Deep Dive", SIGGRAPH 2021 Advances in
// Real-Time Rendering;
// Haar, Aaltonen, "GPU-Driven Rendering Pipelines", SIGGRAPH 2015 Advances.
#include "vgeo/cull/cull.h"

#include <algorithm>
#include <atomic>
#include <cassert>
#include <mutex>
#include <thread>

#include "vgeo/core/lod.h"

namespace vgeo {

void CullCounters::add(const CullCounters& o) {
  instances_in += o.instances_in; instances_out += o.instances_out;
  instances_occluded += o.instances_occluded;
  nodes_visited += o.nodes_visited; nodes_occluded += o.nodes_occluded;
  groups_visited += o.groups_visited; groups_occluded += o.groups_occluded;
  cluster_candidates += o.cluster_candidates; clusters_selected_lod += o.clusters_selected_lod;
  clusters_frustum_culled += o.clusters_frustum_culled; clusters_occluded += o.clusters_occluded;
  clusters_visible += o.clusters_visible;
  clusters_ideal += o.clusters_ideal; clusters_coarser += o.clusters_coarser;
}

std::vector<InstanceView> make_instance_views(const std::vector<CullInstance>& instances,
                                              const ViewParams& view) {
  std::vector<InstanceView> out(instances.size());
  for (size_t i = 0; i < instances.size(); ++i) {
    out[i].object_to_view = view.world_to_view * instances[i].object_to_world;
    out[i].scale = max_axis_scale(instances[i].object_to_world);
  }
  return out;
}

namespace {

LodView lod_view_of(const ViewParams& view) {
  LodView lv;  // eye at the view-space origin
  lv.pixels_per_unit_at_1 = view.pixels_per_unit_at_1;
  lv.z_near = float(view.z_near);
  return lv;
}

// The per-cluster LOD decision, shared by the traversal and the flat reference.
bool cluster_lod_selects(const DagCluster& c, const InstanceView& iv, const LodView& lv, float tau) {
  return lod_selects(sphere_to_view(iv.object_to_view, iv.scale, c.lod_bounds), error_to_view(c.lod_error, iv.scale),
                     sphere_to_view(iv.object_to_view, iv.scale, c.parent_bounds),
                     error_to_view(c.parent_error, iv.scale), lv, tau);
}

// Culling bounds (frustum, occlusion) of anything: inflated so float rounding never
// drops a pixel the rasterizer would cover.
Sphere culling_sphere(const InstanceView& iv, const Sphere& s) {
  return inflate_for_subtree_test(sphere_to_view(iv.object_to_view, iv.scale, s));
}

// A subtree may still hold a cluster selected by the LOD test.
bool subtree_may_select(const Sphere& lod_bounds, float max_parent_error, const InstanceView& iv,
                        const LodView& lv, float tau) {
  Sphere s = culling_sphere(iv, lod_bounds);
  float e = inflate_error_for_subtree_test(error_to_view(max_parent_error, iv.scale));
  return projected_error(s, e, lv) > tau;
}

bool occluded(const CullOptions& o, uint32_t instance, const Sphere& bounds) {
  if (!o.occlusion.hzb) return false;
  const InstanceView& iv = (*o.occlusion.instances)[instance];
  return hzb_occludes(*o.occlusion.hzb, culling_sphere(iv, bounds), *o.occlusion.view, o.occlusion.policy);
}

struct WorkerOut {
  std::vector<VisibleCluster> visible;
  std::vector<CullItem> occluded;
  std::vector<GroupRequest> requests;
  CullCounters counters;
};

// Two MPMC queues behind one mutex (the CPU stand-in for Nanite's GPU queues) plus a
// count of items pushed but not finished: the traversal ends when it reaches 0.
struct WorkQueues {
  std::mutex mutex;
  std::vector<CullItem> nodes, clusters;
  std::atomic<int64_t> pending{0};
};

// What every step of one cull_clusters call reads: the scene, the view and the options.
struct ClusterCull {
  const std::vector<ClusterDag>& meshes;
  const std::vector<CullInstance>& instances;
  const std::vector<InstanceView>& instance_views;
  const ViewParams& view;
  const CullOptions& options;
  LodView lv;
  float tau;
};

// Streaming: the residency rule (resident_lod_test, lib/vgeo/stream) then frustum; `from_group` is false for a cluster postponed by pass 1,
// whose request was already emitted there.
bool resident_cluster_test(const ClusterCull& cc, WorkerOut& w, uint32_t instance, const ClusterDag& dag, uint32_t ci,
                           const std::vector<uint8_t>& usable, bool from_group) {
  const DagCluster& c = dag.clusters[ci];
  const InstanceView& iv = cc.instance_views[instance];
  const float parent_px = projected_error(sphere_to_view(iv.object_to_view, iv.scale, c.parent_bounds),
                                          error_to_view(c.parent_error, iv.scale), cc.lv);
  const float lod_px = projected_error(sphere_to_view(iv.object_to_view, iv.scale, c.lod_bounds),
                                       error_to_view(c.lod_error, iv.scale), cc.lv);
  const ResidentLod r = resident_lod_test(c, usable, parent_px, lod_px, cc.tau);
  if (!r.drawn && !r.ideal) return false;
  if (cc.options.frustum && sphere_outside_frustum(culling_sphere(iv, c.bounds), cc.view)) {
    if (r.drawn) ++w.counters.clusters_frustum_culled;
    return false;
  }
  if (r.ideal && from_group) {  // a cluster of the ideal cut, in view: request its group
    ++w.counters.clusters_ideal;
    w.counters.clusters_coarser += usable[c.group] ? 0 : 1;
    w.requests.push_back({cc.instances[instance].mesh, c.group, parent_px});
  }
  return r.drawn;
}

// One cluster: LOD and frustum (the resident rule when streaming), then occlusion.
void test_cluster(const ClusterCull& cc, WorkerOut& w, uint32_t instance, const ClusterDag& dag, uint32_t ci,
                  bool from_group) {
  const DagCluster& c = dag.clusters[ci];
  const InstanceView& iv = cc.instance_views[instance];
  ++w.counters.cluster_candidates;
  const std::vector<uint8_t>* usable =
      cc.options.usable_groups ? &(*cc.options.usable_groups)[cc.instances[instance].mesh] : nullptr;
  if (usable && !usable->empty()) {
    // Tests LOD and frustum on the resident rule (and emits the page requests).
    if (!resident_cluster_test(cc, w, instance, dag, ci, *usable, from_group)) return;
    ++w.counters.clusters_selected_lod;
  } else {
    if (!cluster_lod_selects(c, iv, cc.lv, cc.tau)) return;
    ++w.counters.clusters_selected_lod;
    if (cc.options.frustum && sphere_outside_frustum(culling_sphere(iv, c.bounds), cc.view)) {
      ++w.counters.clusters_frustum_culled;
      return;
    }
  }
  if (occluded(cc.options, instance, c.bounds)) {
    ++w.counters.clusters_occluded;
    w.occluded.push_back({instance, ci, CullItem::kCluster});
    return;
  }
  ++w.counters.clusters_visible;
  w.visible.push_back({instance, ci});
}

// What a BVH node and a group are tested for before their contents: frustum, whether the
// subtree can still hold a selected cluster, occlusion (an occluded item is kept for pass 2,
// counted in *occluded_count). True when the contents are to be visited.
bool subtree_visible(const ClusterCull& cc, WorkerOut& w, const CullItem& item, const Sphere& bounds,
                     const Sphere& lod_bounds, float max_parent_error, uint64_t* occluded_count) {
  const InstanceView& iv = cc.instance_views[item.instance];
  if (cc.options.frustum && sphere_outside_frustum(culling_sphere(iv, bounds), cc.view)) return false;
  if (!subtree_may_select(lod_bounds, max_parent_error, iv, cc.lv, cc.tau)) return false;
  if (occluded(cc.options, item.instance, bounds)) {
    ++*occluded_count;
    w.occluded.push_back(item);
    return false;
  }
  return true;
}

// A BVH node: its children go to `children`.
void process_node(const ClusterCull& cc, WorkerOut& w, const CullItem& item, const ClusterDag& dag,
                  std::vector<CullItem>& children) {
  const BvhNode& node = dag.bvh_nodes[item.index];
  ++w.counters.nodes_visited;
  if (!subtree_visible(cc, w, item, node.bounds, node.lod_bounds, node.max_parent_error, &w.counters.nodes_occluded))
    return;
  for (uint32_t k = 0; k < node.child_count && k < kBvhMaxChildren; ++k) {
    bool is_group = (node.group_mask >> k) & 1u;
    children.push_back({item.instance, node.children[k], is_group ? CullItem::kGroup : CullItem::kNode});
  }
}

// A group: each of its clusters is tested.
void process_group(const ClusterCull& cc, WorkerOut& w, const CullItem& item, const ClusterDag& dag) {
  const DagGroup& g = dag.groups[item.index];
  ++w.counters.groups_visited;
  if (!subtree_visible(cc, w, item, g.bounds, g.parent_bounds, g.parent_error, &w.counters.groups_occluded)) return;
  for (uint32_t k = 0; k < g.cluster_count; ++k) test_cluster(cc, w, item.instance, dag, g.first_cluster + k, true);
}

// Processes one item; appends follow-up work to `children`.
void process_item(const ClusterCull& cc, WorkerOut& w, const CullItem& item, std::vector<CullItem>& children) {
  const ClusterDag& dag = cc.meshes[cc.instances[item.instance].mesh];
  if (item.kind == CullItem::kNode) {
    process_node(cc, w, item, dag, children);
  } else if (item.kind == CullItem::kGroup) {
    process_group(cc, w, item, dag);
  } else {
    test_cluster(cc, w, item.instance, dag, item.index, false);
  }
}

void push_item(WorkQueues& queues, const CullItem& item) {
  (item.kind == CullItem::kNode ? queues.nodes : queues.clusters).push_back(item);
}

// The seeds queued, pending counted.
void seed_queues(WorkQueues& queues, const std::vector<CullItem>& seeds) {
  for (const CullItem& s : seeds) push_item(queues, s);
  // Pop from the back: reverse so seeds start in order (not needed for correctness).
  std::reverse(queues.nodes.begin(), queues.nodes.end());
  std::reverse(queues.clusters.begin(), queues.clusters.end());
  queues.pending = int64_t(seeds.size());
}

// The next item, if either queue holds one.
bool pop_item(WorkQueues& queues, CullItem* item) {
  std::lock_guard<std::mutex> lock(queues.mutex);
  // Nodes first: they expand into more work for the other threads; clusters fill
  // the holes while the node queue is momentarily empty (Nanite's two queues).
  if (!queues.nodes.empty()) {
    *item = queues.nodes.back();
    queues.nodes.pop_back();
    return true;
  }
  if (!queues.clusters.empty()) {
    *item = queues.clusters.back();
    queues.clusters.pop_back();
    return true;
  }
  return false;
}

// One worker: pops and processes items until no item is queued or in flight.
void run_worker(const ClusterCull& cc, WorkQueues& queues, WorkerOut& w) {
  std::vector<CullItem> children;
  for (;;) {
    CullItem item;
    if (!pop_item(queues, &item)) {
      if (queues.pending.load(std::memory_order_acquire) == 0) return;
      std::this_thread::yield();
      continue;
    }
    children.clear();
    process_item(cc, w, item, children);
    if (!children.empty()) {
      queues.pending.fetch_add(int64_t(children.size()), std::memory_order_acq_rel);
      std::lock_guard<std::mutex> lock(queues.mutex);
      for (const CullItem& c : children) push_item(queues, c);
    }
    queues.pending.fetch_sub(1, std::memory_order_acq_rel);
  }
}

// The workers' outputs merged in canonical order: identical output for any thread count and schedule.
void merge_workers(std::vector<WorkerOut>& workers, CullResult* out) {
  for (WorkerOut& w : workers) {
    out->visible.insert(out->visible.end(), w.visible.begin(), w.visible.end());
    out->occluded.insert(out->occluded.end(), w.occluded.begin(), w.occluded.end());
    out->requests.insert(out->requests.end(), w.requests.begin(), w.requests.end());
    out->counters.add(w.counters);
  }
  if (!out->requests.empty()) {
    // Canonical: one request per (mesh, group) with the max priority over its clusters.
    std::sort(out->requests.begin(), out->requests.end(), [](const GroupRequest& a, const GroupRequest& b) {
      return a.mesh != b.mesh ? a.mesh < b.mesh : a.group != b.group ? a.group < b.group : a.priority > b.priority;
    });
    out->requests.erase(std::unique(out->requests.begin(), out->requests.end(),
                                    [](const GroupRequest& a, const GroupRequest& b) {
                                      return a.mesh == b.mesh && a.group == b.group;
                                    }),
                        out->requests.end());
  }
  std::sort(out->visible.begin(), out->visible.end());
  std::sort(out->occluded.begin(), out->occluded.end());
}

}  // namespace

void cull_instances(const std::vector<ClusterDag>& meshes, const std::vector<CullInstance>& instances,
                    const std::vector<InstanceView>& instance_views, const std::vector<uint32_t>& candidates,
                    const ViewParams& view, const CullOptions& options, std::vector<uint32_t>* visible,
                    std::vector<uint32_t>* occluded_out, CullCounters* counters) {
  visible->clear();
  if (occluded_out) occluded_out->clear();
  for (uint32_t i : candidates) {
    ++counters->instances_in;
    const ClusterDag& dag = meshes[instances[i].mesh];
    if (dag.bvh_nodes.empty()) continue;
    const Sphere& b = dag.bvh_nodes[0].bounds;
    if (options.frustum && sphere_outside_frustum(culling_sphere(instance_views[i], b), view)) continue;
    if (occluded(options, i, b)) {
      ++counters->instances_occluded;
      if (occluded_out) occluded_out->push_back(i);
      continue;
    }
    ++counters->instances_out;
    visible->push_back(i);
  }
  std::sort(visible->begin(), visible->end());
  if (occluded_out) std::sort(occluded_out->begin(), occluded_out->end());
}

void cull_clusters(const std::vector<ClusterDag>& meshes, const std::vector<CullInstance>& instances,
                   const std::vector<InstanceView>& instance_views, const std::vector<CullItem>& seeds,
                   const ViewParams& view, const CullOptions& options, ThreadPool& pool, CullResult* out) {
  out->visible.clear();
  out->occluded.clear();
  out->counters = {};
  if (seeds.empty()) return;
  const ClusterCull cc{meshes, instances, instance_views, view, options, lod_view_of(view), options.threshold_px};
  WorkQueues queues;
  seed_queues(queues, seeds);
  std::vector<WorkerOut> workers(pool.size());
  pool.run_on_all([&](unsigned worker) { run_worker(cc, queues, workers[worker]); });
  merge_workers(workers, out);
}

std::vector<VisibleCluster> select_cut(const std::vector<ClusterDag>& meshes,
                                       const std::vector<CullInstance>& instances,
                                       const ViewParams& view, float threshold_px, ThreadPool& pool,
                                       const std::vector<std::vector<uint8_t>>* usable_groups) {
  std::vector<InstanceView> views = make_instance_views(instances, view);
  std::vector<CullItem> seeds;
  for (uint32_t i = 0; i < instances.size(); ++i)
    if (!meshes[instances[i].mesh].bvh_nodes.empty()) seeds.push_back({i, 0, CullItem::kNode});
  CullOptions options;
  options.threshold_px = threshold_px;
  options.frustum = false;
  options.usable_groups = usable_groups;
  CullResult result;
  cull_clusters(meshes, instances, views, seeds, view, options, pool, &result);
  return result.visible;
}

bool bvh_is_tree(const ClusterDag& dag) {
  if (dag.bvh_nodes.empty()) return true;
  std::vector<uint8_t> seen(dag.bvh_nodes.size(), 0);
  std::vector<uint32_t> stack{0};
  seen[0] = 1;
  while (!stack.empty()) {
    const BvhNode& n = dag.bvh_nodes[stack.back()];
    stack.pop_back();
    for (uint32_t k = 0; k < n.child_count && k < kBvhMaxChildren; ++k) {
      if ((n.group_mask >> k) & 1u) continue;
      uint32_t c = n.children[k];
      if (c >= dag.bvh_nodes.size() || seen[c]) return false;
      seen[c] = 1;
      stack.push_back(c);
    }
  }
  return true;
}

std::vector<uint32_t> cut_of_instance(const std::vector<VisibleCluster>& cut, uint32_t instance) {
  std::vector<uint32_t> out;
  for (const VisibleCluster& v : cut)
    if (v.instance == instance) out.push_back(v.cluster);
  return out;
}

std::vector<VisibleCluster> select_flat(const std::vector<ClusterDag>& meshes,
                                        const std::vector<CullInstance>& instances,
                                        const ViewParams& view, float threshold_px, bool frustum) {
  std::vector<InstanceView> views = make_instance_views(instances, view);
  const LodView lv = lod_view_of(view);
  std::vector<VisibleCluster> out;
  for (uint32_t i = 0; i < instances.size(); ++i) {
    const ClusterDag& dag = meshes[instances[i].mesh];
    for (uint32_t c = 0; c < dag.clusters.size(); ++c) {
      if (!cluster_lod_selects(dag.clusters[c], views[i], lv, threshold_px)) continue;
      if (frustum && sphere_outside_frustum(culling_sphere(views[i], dag.clusters[c].bounds), view)) continue;
      out.push_back({i, c});
    }
  }
  return out;
}

}  // namespace vgeo
