// The cull passes on the GPU (gpu_cull.h; the decisions are shaders/cull_*.comp). Based on:
// Karis et al., "Nanite: A Deep Dive", SIGGRAPH 2021, §"Persistent threads", §"Persistent Threads -
// Hierarchy Culling" and §"Two-Pass Occlusion Culling"; Haar, Aaltonen, "GPU-Driven Rendering
// Pipelines", SIGGRAPH 2015 Advances (compute culling against a hierarchical Z-buffer).
#include "vgeo/gpu/gpu_cull.h"

#include <algorithm>
#include <cstddef>
#include <cstring>

#include "vgeo/core/error.h"
#include "vgeo/gpu/shader_bindings.h"
#include "vgeo/gpu/shaders.h"

namespace vgeo {

// The GLSL records are the DAG's records, byte for byte (uploaded as they are).
static_assert(sizeof(GpuSphere) == sizeof(Sphere) && offsetof(Sphere, radius) == offsetof(GpuSphere, radius));
static_assert(sizeof(GpuCluster) == sizeof(DagCluster) && offsetof(GpuCluster, group) == offsetof(DagCluster, group) &&
              offsetof(GpuCluster, bounds) == offsetof(DagCluster, bounds) &&
              offsetof(GpuCluster, lod_bounds) == offsetof(DagCluster, lod_bounds) &&
              offsetof(GpuCluster, parent_bounds) == offsetof(DagCluster, parent_bounds) &&
              offsetof(GpuCluster, lod_error) == offsetof(DagCluster, lod_error) &&
              offsetof(GpuCluster, parent_error) == offsetof(DagCluster, parent_error));
static_assert(sizeof(GpuGroup) == sizeof(DagGroup) && offsetof(GpuGroup, cluster_count) == offsetof(DagGroup, cluster_count) &&
              offsetof(GpuGroup, bounds) == offsetof(DagGroup, bounds) &&
              offsetof(GpuGroup, parent_bounds) == offsetof(DagGroup, parent_bounds) &&
              offsetof(GpuGroup, parent_error) == offsetof(DagGroup, parent_error));
static_assert(sizeof(GpuBvhNode) == sizeof(BvhNode) && offsetof(GpuBvhNode, lod_bounds) == offsetof(BvhNode, lod_bounds) &&
              offsetof(GpuBvhNode, max_parent_error) == offsetof(BvhNode, max_parent_error) &&
              offsetof(GpuBvhNode, child_count) == offsetof(BvhNode, child_count) &&
              offsetof(GpuBvhNode, group_mask) == offsetof(BvhNode, group_mask) &&
              offsetof(GpuBvhNode, children) == offsetof(BvhNode, children));
static_assert(kGpuBvhMaxChildren == kBvhMaxChildren && kGpuNone == kNone);
static_assert(sizeof(GpuCullInstance) == 152 && sizeof(GpuCullView) == 48 && sizeof(GpuQueueHeader) == 32);
static_assert(uint32_t(HzbMipPolicy::k4x4) == kHzbPolicy4x4 && uint32_t(HzbMipPolicy::k2x2) == kHzbPolicy2x2 &&
              uint32_t(HzbMipPolicy::kFinest) == kHzbPolicyFinest);
static_assert(sizeof(CullCounters) == kCounterCount * sizeof(uint64_t) &&
              offsetof(CullCounters, clusters_coarser) == kCounterClustersCoarser * sizeof(uint64_t));
static_assert(sizeof(VisibleCluster) == 2 * sizeof(uint32_t) && sizeof(CullItem) == 3 * sizeof(uint32_t));
static_assert(uint32_t(CullItem::kNode) == kItemNode && uint32_t(CullItem::kGroup) == kItemGroup &&
              uint32_t(CullItem::kCluster) == kItemCluster);

namespace {

// Workgroups of the persistent traversal: lavapipe runs one workgroup per worker thread
// (one per core; this machine class has ≤ 16), so more would only wait for the queue to drain.
constexpr uint32_t kPersistentWorkgroups = 16;
// Loop back edges one traversal item may cost besides its HZB test: the push loop (a node's
// ≤ kBvhMaxChildren children or a group's clusters: added per scene), sphere_screen_rect's
// 8 corners and the persistent loop's own claim loop (≤ VGEO_PERSISTENT_GROUP_SIZE), with
// room to spare for loops the compiler keeps (none else in cull_traverse.glsl).
constexpr uint32_t kItemLoopOverhead = 64;
// Part of kGpuLoopBudget an invocation may plan to use: the rest is margin for the few
// loops outside the per-item bound (counter clear/flush: kCounterCount each).
constexpr uint32_t kPlannedLoopBudget = kGpuLoopBudget - 1024;
constexpr VkDeviceSize kQueueDispatchOffset = offsetof(GpuQueueHeader, dispatch_x);

uint32_t groups_for(uint64_t n, uint32_t size) { return uint32_t((n + size - 1) / size); }

// Buffers larger than one binding can address are a scene-size limit of the GPU cull.
GpuBuffer make_buffer(GpuContext& gpu, uint64_t bytes, const char* what) {
  if (bytes > gpu.properties.limits.maxStorageBufferRange)
    fail("GPU_SCENE_TOO_LARGE", "vulkan",
         std::string(what) + " needs " + std::to_string(bytes) + " bytes, more than one storage buffer (" +
             std::to_string(gpu.properties.limits.maxStorageBufferRange) + ")",
         kExitUsage);
  return create_gpu_buffer(gpu, std::max<uint64_t>(bytes, 4));
}

template <class T>
GpuBuffer upload(GpuContext& gpu, const std::vector<T>& v, const char* what) {
  GpuBuffer b = make_buffer(gpu, v.size() * sizeof(T), what);
  if (!v.empty()) std::memcpy(b.mapped, v.data(), v.size() * sizeof(T));
  return b;
}

// Deepest node of the BVH reachable from node 0 (root depth 0); the DAG is a tree
// (dag_io validates bvh_is_tree), the visited guard only bounds a malformed one.
uint32_t bvh_depth(const ClusterDag& dag) {
  if (dag.bvh_nodes.empty()) return 0;
  uint32_t deepest = 0;
  std::vector<std::pair<uint32_t, uint32_t>> stack{{0, 0}};
  size_t visited = 0;
  while (!stack.empty() && visited++ <= dag.bvh_nodes.size()) {
    auto [n, depth] = stack.back();
    stack.pop_back();
    deepest = std::max(deepest, depth);
    const BvhNode& node = dag.bvh_nodes[n];
    for (uint32_t k = 0; k < node.child_count && k < kBvhMaxChildren; ++k)
      if (!((node.group_mask >> k) & 1u) && node.children[k] < dag.bvh_nodes.size())
        stack.push_back({node.children[k], depth + 1});
  }
  return deepest;
}

GpuCullView gpu_view(const ViewParams& v) {
  GpuCullView g{};
  g.tan_half_x = v.tan_half_x;
  g.tan_half_y = v.tan_half_y;
  g.z_near = v.z_near;
  g.width = v.width;
  g.height = v.height;
  g.pixels_per_unit_at_1 = v.pixels_per_unit_at_1;
  g.lod_z_near = float(v.z_near);  // cull.cpp lod_view_of
  return g;
}

// The bindings of cull_common.glsl (shader_bindings.h) for pass `pass`.
std::vector<const GpuBuffer*> cull_bindings(const GpuCullMeshes& m, GpuCullFrame& f, uint32_t pass, bool previous,
                                            const GpuBuffer& counters, const GpuBuffer& list_in,
                                            const GpuBuffer& list_out) {
  return gpu_bindings(kCullBindingCount,
                      {{kCullBindParams, &f.params[pass]},
                       {kCullBindMeshes, &m.meshes},
                       {kCullBindClusters, &m.clusters},
                       {kCullBindGroups, &m.groups},
                       {kCullBindNodes, &m.nodes},
                       {kCullBindInstances, &f.instances},
                       {kCullBindOcclusionInstances, previous ? &f.previous_instances : &f.instances},
                       {kCullBindHzb, previous ? &f.previous_hzb : &f.hzb},
                       {kCullBindQueue, &f.queue},
                       {kCullBindBits, &f.bits},
                       {kCullBindCounters, &counters},
                       {kCullBindListIn, &list_in},
                       {kCullBindListOut, &list_out},
                       {kCullBindStream, &m.stream}});
}

// The most loop back edges one HZB test of `params` runs (cull_common.glsl): the 4x4 / 2x2
// mip search (≤ levels) and ≤ (span + 1) rows of ≤ span texels; kFinest's block walk reads
// ≤ 4·(w + h) texels of a w×h rectangle (two blocks per level per axis: the reads of a
// pair of blocks of levels kx ≥ ky are 2^(kx−ky), Σ over y blocks ≤ 4·2^kx, Σ over x
// blocks ≤ 4w; likewise ≤ 4h for kx < ky).
uint64_t hzb_test_loop_bound(const GpuCullParams& p) {
  if ((p.flags & kGpuCullOcclusion) == 0) return 0;
  if (p.hzb_policy == kHzbPolicyFinest) return 4ull * (uint64_t(p.hzb_width) + p.hzb_height);
  uint64_t span = p.hzb_policy == kHzbPolicy4x4 ? 4 : 2;
  return p.hzb_levels + (span + 1) * span;
}

// One traversal item's loop bound; fails when a single item could exceed the budget
// (kFinest on a very large viewport: an exact test cannot be split across invocations).
uint64_t item_loop_bound(const GpuCullMeshes& m, const GpuCullParams& p) {
  uint64_t bound = kItemLoopOverhead + std::max<uint64_t>(kBvhMaxChildren, m.max_group_clusters) +
                   hzb_test_loop_bound(p);
  if (bound > kPlannedLoopBudget)
    fail("GPU_SCENE_TOO_LARGE", "vulkan",
         "one cull item may run " + std::to_string(bound) + " shader loop iterations, more than the device allows per "
             "invocation (" + std::to_string(kPlannedLoopBudget) + "; HZB policy finest at " +
             std::to_string(p.hzb_width) + "x" + std::to_string(p.hzb_height) + "?)",
         kExitUsage);
  return bound;
}

bool pass_reads_previous(const GpuCullFrame& f, uint32_t pass) {
  return f.params[pass].data<GpuCullParams>()->occlusion_previous != 0;
}

// cull_compact.comp: one workgroup; an invocation counts and then emits `per` words (≤ 32
// set bits each) and invocation 0 scans kCompactGroupSize counts: per·(2 + 32) +
// kCompactGroupSize back edges, within the loop budget up to ~1.9M words (61M keys;
// larger lists would not fit one storage buffer anyway). Checked, not assumed.
void cmd_compact(GpuRecorder& rec, const GpuCullPipelines& p, const std::vector<const GpuBuffer*>& bindings,
                 uint32_t mode, uint32_t word_begin, uint32_t words, bool append = false) {
  const uint64_t per = (uint64_t(words) + kCompactGroupSize - 1) / kCompactGroupSize;
  if (per * (2 + 32) + kCompactGroupSize > kPlannedLoopBudget)
    fail("GPU_SCENE_TOO_LARGE", "vulkan",
         "a cull list of " + std::to_string(words) + " bit-set words exceeds the device's loop budget", kExitUsage);
  GpuCullPush push{mode, word_begin, words, append ? 1u : 0u, 0};
  cmd_dispatch(rec, p.compact, bindings, &push, 1);
}

}  // namespace

GpuCullPipelines create_cull_pipelines(GpuContext& gpu) {
  const uint32_t push = sizeof(GpuCullPush);
  GpuCullPipelines p;
  p.instances = create_compute_pipeline(gpu, kShaderCullInstances, kCullBindingCount, push);
  p.seed = create_compute_pipeline(gpu, kShaderCullSeed, kCullBindingCount, push);
  p.traverse_persistent = create_compute_pipeline(gpu, kShaderCullTraversePersistent, kCullBindingCount, push);
  p.traverse_level = create_compute_pipeline(gpu, kShaderCullTraverseLevel, kCullBindingCount, push);
  p.advance = create_compute_pipeline(gpu, kShaderCullAdvance, kAdvanceBindingCount, 0);
  p.compact = create_compute_pipeline(gpu, kShaderCullCompact, kCullBindingCount, push);
  p.hzb = create_compute_pipeline(gpu, kShaderHzbBuild, kHzbBindingCount, push);
  return p;
}

GpuCullMeshes upload_cull_meshes(GpuContext& gpu, const std::vector<ClusterDag>& meshes) {
  GpuCullMeshes m;
  std::vector<DagCluster> clusters;
  std::vector<DagGroup> groups;
  std::vector<BvhNode> nodes;
  uint32_t deepest = 0;
  uint64_t stream_words = 0;
  for (const ClusterDag& dag : meshes) {
    GpuCullMesh g{};
    g.first_cluster = uint32_t(clusters.size());
    g.cluster_count = uint32_t(dag.clusters.size());
    g.first_group = uint32_t(groups.size());
    g.group_count = uint32_t(dag.groups.size());
    g.first_node = uint32_t(nodes.size());
    g.node_count = uint32_t(dag.bvh_nodes.size());
    g.stream_base = uint32_t(stream_words);
    stream_words += 1 + 2ull * dag.groups.size();
    m.table.push_back(g);
    clusters.insert(clusters.end(), dag.clusters.begin(), dag.clusters.end());
    groups.insert(groups.end(), dag.groups.begin(), dag.groups.end());
    nodes.insert(nodes.end(), dag.bvh_nodes.begin(), dag.bvh_nodes.end());
    deepest = std::max(deepest, bvh_depth(dag));
    for (const DagGroup& group : dag.groups) m.max_group_clusters = std::max(m.max_group_clusters, group.cluster_count);
  }
  m.levels = deepest + 3;  // nodes at depths 0..deepest, then their groups, then the groups' clusters
  m.meshes = upload(gpu, m.table, "mesh table");
  m.clusters = upload(gpu, clusters, "clusters");
  m.groups = upload(gpu, groups, "groups");
  m.nodes = upload(gpu, nodes, "BVH nodes");
  m.stream = make_buffer(gpu, stream_words * 4, "stream words");
  std::memset(m.stream.mapped, 0, stream_words * 4);  // no mesh streams until write_cull_usable
  return m;
}

void write_cull_usable(GpuCullMeshes& m, const std::vector<std::vector<uint8_t>>& usable) {
  uint32_t* w = m.stream.data<uint32_t>();
  for (size_t k = 0; k < m.table.size(); ++k) {
    const GpuCullMesh& g = m.table[k];
    const bool streams = k < usable.size() && !usable[k].empty();
    w[g.stream_base] = streams ? 1u : 0u;
    for (uint32_t i = 0; i < g.group_count; ++i) w[g.stream_base + 1 + i] = streams && usable[k][i] ? 1u : 0u;
  }
}

std::vector<GroupRequest> take_cull_requests(GpuCullMeshes& m) {
  std::vector<GroupRequest> out;
  uint32_t* w = m.stream.data<uint32_t>();
  for (uint32_t k = 0; k < m.table.size(); ++k) {
    const GpuCullMesh& g = m.table[k];
    if (w[g.stream_base] == 0) continue;
    uint32_t* request = w + g.stream_base + 1 + g.group_count;
    for (uint32_t i = 0; i < g.group_count; ++i) {
      if (request[i] == 0) continue;
      float priority;
      std::memcpy(&priority, &request[i], 4);
      out.push_back({k, i, priority});
      request[i] = 0;
    }
  }
  return out;
}

GpuCullLayout make_cull_layout(const std::vector<ClusterDag>& meshes, const std::vector<CullInstance>& instances) {
  GpuCullLayout l;
  uint64_t cluster_keys = 0, item_keys = 0, capacity = 0;
  if (instances.size() > kItemInstanceMask)
    fail("GPU_SCENE_TOO_LARGE", "vulkan", "more than 2^31 instances in one scene", kExitUsage);
  for (const CullInstance& inst : instances) {
    const ClusterDag& dag = meshes[inst.mesh];
    l.cluster_key_base.push_back(uint32_t(cluster_keys));
    l.item_key_base.push_back(uint32_t(item_keys));
    cluster_keys += dag.clusters.size();
    item_keys += uint64_t(kItemKinds) * std::max({dag.clusters.size(), dag.groups.size(), dag.bvh_nodes.size()});
    // Each node and group is reached at most once per traversal; cluster items only as seeds.
    capacity += dag.bvh_nodes.size() + dag.groups.size() + dag.clusters.size();
    if (item_keys > UINT32_MAX || capacity > UINT32_MAX)
      fail("GPU_SCENE_TOO_LARGE", "vulkan", "more than 2^32 cull keys in one scene", kExitUsage);
  }
  l.visible_words = uint32_t((cluster_keys + 31) / 32);
  l.occluded_words = uint32_t((item_keys + 31) / 32);
  l.instance_words = uint32_t((instances.size() + 31) / 32);
  l.queue_capacity = uint32_t(capacity);
  return l;
}

GpuHzbLayout make_hzb_layout(uint32_t width, uint32_t height) {
  GpuHzbLayout h;
  h.width = width;
  h.height = height;
  if (width == 0 || height == 0) return h;
  uint32_t w = width, hh = height, words = 0;
  for (;;) {
    h.offset[h.levels] = words;
    h.mip_width[h.levels] = w;
    h.mip_height[h.levels] = hh;
    ++h.levels;
    words += w * hh;
    if (w == 1 && hh == 1) break;
    w = (w + 1) / 2;
    hh = (hh + 1) / 2;
  }
  h.words = words;
  return h;
}

GpuCullFrame create_cull_frame(GpuContext& gpu, const std::vector<ClusterDag>& meshes,
                               const std::vector<CullInstance>& instances, uint32_t width, uint32_t height) {
  GpuCullFrame f;
  f.layout = make_cull_layout(meshes, instances);
  f.hzb_layout = make_hzb_layout(width, height);
  if (f.hzb_layout.levels > kGpuHzbMaxLevels) fail("GPU_SCENE_TOO_LARGE", "vulkan", "viewport too large for the HZB", kExitUsage);
  const GpuCullLayout& l = f.layout;
  const uint64_t n = instances.size();
  for (GpuBuffer& b : f.params) b = make_buffer(gpu, sizeof(GpuCullParams), "cull parameters");
  f.instances = make_buffer(gpu, n * sizeof(GpuCullInstance), "instances");
  f.previous_instances = make_buffer(gpu, n * sizeof(GpuCullInstance), "instances");
  f.hzb = make_buffer(gpu, uint64_t(f.hzb_layout.words) * 4, "HZB");
  f.previous_hzb = make_buffer(gpu, uint64_t(f.hzb_layout.words) * 4, "HZB");
  f.queue = make_buffer(gpu, sizeof(GpuQueueHeader) + uint64_t(l.queue_capacity) * 8, "traversal queue");
  f.bits = make_buffer(gpu, (uint64_t(l.visible_words) + l.occluded_words + 2ull * l.instance_words) * 4, "bit sets");
  auto list = [&](uint64_t records, uint32_t words_per_record) {
    return make_buffer(gpu, (kListHeaderWords + records * words_per_record) * 4, "cull list");
  };
  f.candidates = list(n, 1);
  f.visible_instances = list(n, 1);
  f.occluded_instances = list(n, 1);
  f.post_instances = list(n, 1);
  for (GpuBuffer& b : f.visible) b = list(uint64_t(l.visible_words) * 32, 2);
  f.occluded_items = list(uint64_t(l.occluded_words) * 32, 3);
  for (GpuBuffer& b : f.counters) b = make_buffer(gpu, sizeof(CullCounters), "counters");
  uint32_t* c = f.candidates.data<uint32_t>();
  c[0] = uint32_t(n);
  for (uint32_t i = 0; i < n; ++i) c[kListHeaderWords + i] = i;
  return f;
}

void write_cull_params(GpuCullFrame& f, uint32_t pass, const ViewParams& view, float threshold_px, bool frustum,
                       const GpuOcclusion* occlusion) {
  GpuCullParams p{};
  p.view = gpu_view(view);
  p.threshold_px = threshold_px;
  p.flags = frustum ? kGpuCullFrustum : 0u;
  // hzb_occludes: an HZB of another size never occludes.
  if (occlusion && occlusion->view && occlusion->view->width == f.hzb_layout.width &&
      occlusion->view->height == f.hzb_layout.height && f.hzb_layout.levels > 0) {
    p.flags |= kGpuCullOcclusion;
    p.occlusion_view = gpu_view(*occlusion->view);
    p.hzb_policy = uint32_t(occlusion->policy);
    p.occlusion_previous = occlusion->previous ? 1u : 0u;
  }
  const GpuHzbLayout& h = f.hzb_layout;
  p.hzb_levels = h.levels;
  p.hzb_width = h.width;
  p.hzb_height = h.height;
  for (uint32_t k = 0; k < h.levels; ++k) {
    p.hzb_mip_offset[k] = h.offset[k];
    p.hzb_mip_width[k] = h.mip_width[k];
    p.hzb_mip_height[k] = h.mip_height[k];
  }
  const GpuCullLayout& l = f.layout;
  p.instance_count = uint32_t(l.cluster_key_base.size());
  p.queue_capacity = l.queue_capacity;
  p.visible_bits = 0;
  p.occluded_bits = l.visible_words;
  p.instance_visible_bits = l.visible_words + l.occluded_words;
  p.instance_occluded_bits = p.instance_visible_bits + l.instance_words;
  p.visible_words = l.visible_words;
  p.occluded_words = l.occluded_words;
  p.instance_words = l.instance_words;
  *f.params[pass].data<GpuCullParams>() = p;
}

void write_cull_instances(GpuCullFrame& f, const std::vector<CullInstance>& instances,
                          const std::vector<InstanceView>& views, bool previous) {
  GpuCullInstance* out = (previous ? f.previous_instances : f.instances).data<GpuCullInstance>();
  for (size_t i = 0; i < instances.size(); ++i) {
    GpuCullInstance g{};
    std::memcpy(g.object_to_view, views[i].object_to_view.m, sizeof g.object_to_view);
    g.scale = views[i].scale;
    g.mesh = instances[i].mesh;
    g.cluster_key_base = f.layout.cluster_key_base[i];
    g.item_key_base = f.layout.item_key_base[i];
    out[i] = g;
  }
}

void write_previous_hzb(GpuCullFrame& f, const Hzb& hzb) {
  uint32_t* out = f.previous_hzb.data<uint32_t>();
  for (uint32_t k = 0; k < f.hzb_layout.levels && k < hzb.mips.size(); ++k)
    std::memcpy(out + f.hzb_layout.offset[k], hzb.mips[k].data(), hzb.mips[k].size() * 4);
}

void cmd_cull_instances(GpuRecorder& rec, const GpuCullPipelines& p, const GpuCullMeshes& m, GpuCullFrame& f,
                        uint32_t pass, const GpuBuffer& input, GpuBuffer& visible_out, GpuBuffer* occluded_out,
                        GpuBuffer& counters) {
  const GpuCullParams& params = *f.params[pass].data<GpuCullParams>();
  const bool previous = pass_reads_previous(f, pass);
  cmd_fill(rec, f.bits, 0);
  cmd_fill(rec, counters, 0);
  GpuCullPush push{};
  cmd_dispatch(rec, p.instances, cull_bindings(m, f, pass, previous, counters, input, visible_out), &push,
               groups_for(params.instance_count, kCullGroupSize));
  cmd_compact(rec, p, cull_bindings(m, f, pass, previous, counters, input, visible_out), kCompactInstances,
              params.instance_visible_bits, params.instance_words);
  if (occluded_out)
    cmd_compact(rec, p, cull_bindings(m, f, pass, previous, counters, input, *occluded_out), kCompactInstances,
                params.instance_occluded_bits, params.instance_words);
}

void cmd_cull_clusters(GpuRecorder& rec, const GpuCullPipelines& p, const GpuCullMeshes& m, GpuCullFrame& f,
                       uint32_t pass, GpuTraversal traversal, const GpuBuffer& seed_instances,
                       const GpuBuffer* seed_items, GpuBuffer& visible_out, bool append_visible,
                       GpuBuffer* occluded_out, GpuBuffer& counters) {
  const GpuCullParams& params = *f.params[pass].data<GpuCullParams>();
  const bool previous = pass_reads_previous(f, pass);
  auto bind = [&](const GpuBuffer& in, const GpuBuffer& out) {
    return cull_bindings(m, f, pass, previous, counters, in, out);
  };
  cmd_fill(rec, f.queue, 0);
  cmd_fill(rec, f.bits, 0);
  cmd_fill(rec, counters, 0);
  GpuCullPush push{kSeedInstances, 0, 0, 0, 0};
  cmd_dispatch(rec, p.seed, bind(seed_instances, visible_out), &push, groups_for(params.instance_count, kCullGroupSize));
  if (seed_items) {
    push.mode = kSeedItems;
    // The item list holds at most one record per item key.
    cmd_dispatch(rec, p.seed, bind(*seed_items, visible_out), &push,
                 groups_for(uint64_t(params.occluded_words) * 32, kCullGroupSize));
  }
  push.mode = 0;
  const uint64_t item_bound = item_loop_bound(m, params);
  if (traversal == GpuTraversal::kPersistent) {
    // Each invocation runs ≤ iterations × (item bound + 1) back edges per dispatch; the host
    // re-dispatches until no item is pending. Each dispatch finishes ≥ 1 item (at its start
    // every pending item is written, and the first claim of the queue's head succeeds), so
    // queue_capacity + 1 dispatches always suffice.
    push.iterations = uint32_t(kPlannedLoopBudget / (item_bound + 1));
    const GpuQueueHeader* header = f.queue.data<GpuQueueHeader>();
    for (uint64_t round = 0;; ++round) {
      if (round > uint64_t(params.queue_capacity) + 1)
        fail("GPU_ERROR", "vulkan", "persistent cull traversal made no progress", kExitInternal);
      cmd_dispatch(rec, p.traverse_persistent, bind(seed_instances, visible_out), &push, kPersistentWorkgroups);
      continue_commands(rec);
      ++f.persistent_dispatches;
      if (header->pending == 0) break;
    }
  } else {
    // One item per invocation: its bound is the invocation's.
    cmd_dispatch(rec, p.advance, gpu_bindings(kAdvanceBindingCount, {{kAdvanceBindQueue, &f.queue}}), nullptr, 1);
    for (uint32_t level = 0; level < m.levels; ++level) {
      cmd_dispatch_indirect(rec, p.traverse_level, bind(seed_instances, visible_out), &push, f.queue,
                            kQueueDispatchOffset);
      cmd_dispatch(rec, p.advance, gpu_bindings(kAdvanceBindingCount, {{kAdvanceBindQueue, &f.queue}}), nullptr, 1);
    }
  }
  cmd_compact(rec, p, bind(seed_instances, visible_out), kCompactClusters, params.visible_bits, params.visible_words,
              append_visible);
  if (occluded_out)
    cmd_compact(rec, p, bind(seed_instances, *occluded_out), kCompactItems, params.occluded_bits, params.occluded_words);
}

void cmd_build_hzb(GpuRecorder& rec, const GpuCullPipelines& p, GpuCullFrame& f, const GpuBuffer& vis,
                   GpuBuffer& hzb_out) {
  const GpuHzbLayout& h = f.hzb_layout;
  for (uint32_t level = 0; level < h.levels; ++level) {
    GpuCullPush push{level, 0, 0, 0, 0};
    cmd_dispatch(rec, p.hzb,
                 gpu_bindings(kHzbBindingCount, {{kHzbBindParams, &f.params[0]}, {kHzbBindVis, &vis}, {kHzbBindHzb, &hzb_out}}),
                 &push,
                 groups_for(uint64_t(h.mip_width[level]) * h.mip_height[level], kHzbGroupSize));
  }
}

std::vector<uint32_t> read_instance_list(const GpuBuffer& list) {
  const uint32_t* w = list.data<uint32_t>();
  return std::vector<uint32_t>(w + kListHeaderWords, w + kListHeaderWords + w[0]);
}

std::vector<VisibleCluster> read_visible_list(const GpuBuffer& list) {
  const uint32_t* w = list.data<uint32_t>();
  std::vector<VisibleCluster> out(w[0]);
  std::memcpy(static_cast<void*>(out.data()), w + kListHeaderWords, out.size() * sizeof(VisibleCluster));  // plain words, as the shader wrote them
  return out;
}

std::vector<CullItem> read_item_list(const GpuBuffer& list) {
  const uint32_t* w = list.data<uint32_t>();
  std::vector<CullItem> out(w[0]);
  std::memcpy(static_cast<void*>(out.data()), w + kListHeaderWords, out.size() * sizeof(CullItem));  // plain words, as the shader wrote them
  return out;
}

CullCounters read_cull_counters(const GpuBuffer& counters) {
  CullCounters c;
  std::memcpy(&c, counters.mapped, sizeof c);
  return c;
}

Hzb read_hzb(const GpuCullFrame& f, const GpuBuffer& hzb) {
  Hzb out;
  const GpuHzbLayout& h = f.hzb_layout;
  out.width = h.width;
  out.height = h.height;
  const float* src = hzb.data<float>();
  for (uint32_t k = 0; k < h.levels; ++k) {
    out.mip_width.push_back(h.mip_width[k]);
    out.mip_height.push_back(h.mip_height[k]);
    out.mips.emplace_back(src + h.offset[k], src + h.offset[k] + size_t(h.mip_width[k]) * h.mip_height[k]);
  }
  return out;
}

}  // namespace vgeo
