// The CPU executor of the frame plan (frame.h). Based on: Karis et al., "Nanite: A Deep Dive", SIGGRAPH 2021,
// §"Culling Dataflow" and §"Persistent threads" (one work queue, here on a thread pool); the
// visibility buffer of Burns, Hunt, JCGT 2(2), 2013 (shaded in lib/vgeo/shade/shade.cpp).
#include "vgeo/render/frame.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>

#include "vgeo/core/error.h"

namespace vgeo {

namespace {

// Convexity is checked on the leaf triangles only up to this many (triangle, vertex)
// pairs (O(T·V)); a larger mesh is conservatively treated as non-convex.
constexpr uint64_t kConvexCheckBudget = 20'000'000;
// Clusters handed to one raster task: amortizes scheduling, small enough to balance.
constexpr size_t kRasterChunk = 32;

bool dag_is_convex(const ClusterDag& dag) {
  if (dag.positions.empty()) return false;  // metadata only (streamed): unknown, assume not
  uint64_t leaf_tris = 0, leaf_vertices = 0;
  for (const DagCluster& c : dag.clusters)
    if (c.level == 0) leaf_tris += c.triangle_count, leaf_vertices += c.vertex_count;
  if (leaf_tris * leaf_vertices > kConvexCheckBudget || leaf_tris == 0) return false;
  double extent = distance_d(dag.bounds.min, dag.bounds.max);
  // Tolerance: a vertex may sit this far outside a face plane (float rounding of positions).
  double tolerance = extent * 1e-5;
  for (const DagCluster& c : dag.clusters) {
    if (c.level != 0) continue;
    for (uint32_t t = 0; t < c.triangle_count; ++t) {
      const uint8_t* idx = dag.indices.data() + 3 * (size_t(c.triangle_offset) + t);
      Vec3 a = dag.position(c.vertex_offset + idx[0]), b = dag.position(c.vertex_offset + idx[1]),
           d = dag.position(c.vertex_offset + idx[2]);
      double e1[3] = {double(b.x) - a.x, double(b.y) - a.y, double(b.z) - a.z};
      double e2[3] = {double(d.x) - a.x, double(d.y) - a.y, double(d.z) - a.z};
      double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
      double nl = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
      if (!(nl > 0)) continue;
      // The object is its leaves: coarser clusters' vertices are leaf vertices or placed ones
      // (spec/dag.md §2.3 Place), which lie outside the leaf faces' planes by design. Skipping
      // the occlusion passes is conservative anyway (it only draws what they would have culled).
      for (const DagCluster& leaf : dag.clusters) {
        if (leaf.level != 0) continue;
        for (uint32_t v = leaf.vertex_offset; v < leaf.vertex_offset + leaf.vertex_count; ++v) {
          Vec3 p = dag.position(v);
          double s = (n[0] * (p.x - a.x) + n[1] * (p.y - a.y) + n[2] * (p.z - a.z)) / nl;
          if (s > tolerance) return false;
        }
      }
    }
  }
  return true;
}

double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

std::vector<Mat4> clip_matrices(const std::vector<InstanceView>& views, const Mat4d& view_to_clip) {
  std::vector<Mat4> out(views.size());
  for (size_t i = 0; i < views.size(); ++i) out[i] = to_float(view_to_clip * views[i].object_to_view);
  return out;
}

// `geometry`: the scene's meshes, or the streamed frame's (FrameStreaming::geometry).
void raster_pass(const RenderScene& scene, const std::vector<ClusterDag>& geometry,
                 const std::vector<VisibleCluster>& visible, size_t first,
                 const std::vector<Mat4>& object_to_clip, const RenderSettings& settings, double z_near,
                 ThreadPool& pool, VisBuffer& vis, PassStats* stats) {
  size_t n = visible.size() - first;
  size_t chunks = (n + kRasterChunk - 1) / kRasterChunk;
  std::vector<RasterStats> chunk_stats(chunks);
  RasterOptions ro;
  ro.path = settings.raster_path;
  ro.z_near = float(z_near);
  pool.parallel_for(chunks, [&](size_t k) {
    size_t end = std::min(n, (k + 1) * kRasterChunk);
    for (size_t i = k * kRasterChunk; i < end; ++i) {
      const VisibleCluster& v = visible[first + i];
      const ClusterDag& dag = geometry[scene.instances[v.instance].mesh];
      const DagCluster& c = dag.clusters[v.cluster];
      rasterize_cluster(vis, dag.positions.data() + 3 * size_t(c.vertex_offset), c.vertex_count,
                        dag.indices.data() + 3 * size_t(c.triangle_offset), c.triangle_count,
                        object_to_clip[v.instance], uint32_t(first + i), ro, &chunk_stats[k]);
    }
  });
  RasterStats total;
  for (const RasterStats& s : chunk_stats) total.add(s);
  stats->pixels_written = total.pixels_written;  // clusters and triangles drawn: execute_frame_plan
}

}  // namespace

// Overdraw: each drawn cluster rasterized alone into a per-task scratch buffer; the count
// buffer gets +1 for every pixel the cluster covers (overdraw at cluster granularity:
// triangles of one cluster overlapping each other count once).
void overdraw_pass(const RenderScene& scene, const std::vector<ClusterDag>& geometry,
                   const std::vector<VisibleCluster>& visible,
                   const std::vector<Mat4>& object_to_clip, const std::vector<InstanceView>& views,
                   const ViewParams& view, ThreadPool& pool, std::vector<uint32_t>* counts) {
  const uint32_t width = view.width, height = view.height;
  const double z_near = view.z_near;
  counts->assign(size_t(width) * height, 0);
  std::vector<VisBuffer> scratch(pool.size());
  for (VisBuffer& s : scratch) s.resize(width, height);
  std::atomic<size_t> next{0};
  RasterOptions ro;
  ro.z_near = float(z_near);
  pool.run_on_all([&](unsigned worker) {
    VisBuffer& s = scratch[worker];
    for (;;) {
      size_t i = next.fetch_add(1);
      if (i >= visible.size()) return;
      const VisibleCluster& v = visible[i];
      const ClusterDag& dag = geometry[scene.instances[v.instance].mesh];
      const DagCluster& c = dag.clusters[v.cluster];
      rasterize_cluster(s, dag.positions.data() + 3 * size_t(c.vertex_offset), c.vertex_count,
                        dag.indices.data() + 3 * size_t(c.triangle_offset), c.triangle_count,
                        object_to_clip[v.instance], 0, ro, nullptr);
      // Only the cluster's screen rectangle can have been written (whole screen when its
      // bounds reach the near plane).
      Sphere b = inflate_for_subtree_test(sphere_to_view(views[v.instance].object_to_view, views[v.instance].scale, c.bounds));
      ScreenRect r{0, 0, int32_t(width) - 1, int32_t(height) - 1};
      if (!sphere_crosses_near(b, view)) r = sphere_screen_rect(b, view);
      for (int32_t y = r.y0; y <= r.y1; ++y)
        for (int32_t x = r.x0; x <= r.x1; ++x) {
          size_t p = size_t(y) * width + size_t(x);
          if (s.keys[p]) {
            std::atomic_ref<uint32_t>((*counts)[p]).fetch_add(1, std::memory_order_relaxed);
            s.keys[p] = 0;
          }
        }
    }
  });
}

std::vector<Mat4> begin_frame(const RenderScene& scene, const Camera& camera, Frame* out) {
  out->view = make_view(camera);
  out->instance_views = make_instance_views(scene.instances, out->view);
  out->vis.resize(camera.width, camera.height);
  out->visible.clear();
  out->overdraw.clear();
  out->image = {};  // shaded only when the plan says so: no stale image of an earlier frame
  out->pass1_visible = 0;
  out->shadow = {};
  const Mat4d view_to_clip =
      perspective_reversed_z(camera.fov_y, double(camera.width) / double(camera.height), camera.z_near);
  return clip_matrices(out->instance_views, view_to_clip);
}

void add_instance_counters(const CullCounters& c, PassStats* p) {
  p->instances_in += c.instances_in;
  p->instances_out += c.instances_out;
}

void add_cull_counters(const CullCounters& c, PassStats* p) {
  p->nodes_visited += c.nodes_visited;
  p->groups_visited += c.groups_visited;
  p->cluster_candidates += c.cluster_candidates;
  p->clusters_occluded += c.clusters_occluded;
}

void check_visible_count(size_t n) {
  if (n > kMaxVisibleClusters)
    fail("RENDER_TOO_MANY_VISIBLE_CLUSTERS", "render", "more than 2^25 visible clusters in one view", kExitBadInput);
}

void analyze_render_scene(RenderScene* scene) {
  scene->single_convex_object =
      scene->instances.size() == 1 && dag_is_convex(scene->meshes[scene->instances[0].mesh]);
}

namespace {

// The CPU executor: each step is the reference code of its pass; the frame's bookkeeping is
// execute_frame_plan's (frame_plan.h), this keeps only what its own later steps read.
class CpuFrameExecutor final : public FrameExecutor {
 public:
  CpuFrameExecutor(const FramePlan& plan, const FrameInputs& in, Frame* out)
      : in_(in), out_(out), geometry_(in.streaming ? in.streaming->geometry : in.scene.meshes) {
    object_to_clip_ = begin_frame(in_.scene, in_.camera, out);
    options_.threshold_px = in_.settings.threshold_px;
    if (in_.streaming) options_.usable_groups = &in_.streaming->usable;
    if (plan.previous_hzb) {
      options_.occlusion.hzb = &in_.history->hzb;
      options_.occlusion.view = &in_.history->view;
      options_.occlusion.instances = &in_.history->instance_views;
      options_.occlusion.policy = in_.settings.hzb_policy;
    }
  }

  StepResult run(FrameStep step, const FrameState& state, PassStats* p) override {
    const ViewParams& view = out_->view;
    StepResult r;
    switch (step) {
      case FrameStep::kStreamBegin:
        begin_streamed_frame(in_.scene, in_.streaming);
        break;
      case FrameStep::kInstanceCull: {
        std::vector<uint32_t> all(in_.scene.instances.size());
        for (uint32_t i = 0; i < all.size(); ++i) all[i] = i;
        CullCounters cc;
        cull_instances(in_.scene.meshes, in_.scene.instances, out_->instance_views, all, view, options_,
                       &visible_instances_, &occluded_instances_, &cc);
        add_instance_counters(cc, p);
        r.occluded = !occluded_instances_.empty();
        break;
      }
      case FrameStep::kClusterCull: {
        std::vector<CullItem> seeds;
        for (uint32_t i : visible_instances_) seeds.push_back({i, 0, CullItem::kNode});
        cull_clusters(in_.scene.meshes, in_.scene.instances, out_->instance_views, seeds, view, options_, in_.pool, &pass1_);
        add_cull_counters(pass1_.counters, p);
        r.visible = pass1_.visible;
        r.requests = std::move(pass1_.requests);
        r.clusters_coarser = pass1_.counters.clusters_coarser;
        r.occluded = !pass1_.occluded.empty();
        break;
      }
      case FrameStep::kStreamBind:
        bind_streamed_geometry(in_.streaming, in_.scene, out_->visible, 0, in_.pool);
        break;
      case FrameStep::kRaster:
        raster_pass(in_.scene, geometry_, out_->visible, 0, object_to_clip_, in_.settings, in_.camera.z_near, in_.pool, out_->vis, p);
        break;
      case FrameStep::kHzb:
        build_hzb(out_->vis.keys.data(), in_.camera.width, in_.camera.height, in_.pool, &hzb_);
        break;
      case FrameStep::kInstanceCullPost: {
        CullCounters cc;
        cull_instances(in_.scene.meshes, in_.scene.instances, out_->instance_views, occluded_instances_, view, post_options(),
                       &post_instances_, nullptr, &cc);
        add_instance_counters(cc, p);
        break;
      }
      case FrameStep::kClusterCullPost: {
        std::vector<CullItem> seeds = pass1_.occluded;
        for (uint32_t i : post_instances_) seeds.push_back({i, 0, CullItem::kNode});
        CullResult pass2;
        cull_clusters(in_.scene.meshes, in_.scene.instances, out_->instance_views, seeds, view, post_options(), in_.pool, &pass2);
        add_cull_counters(pass2.counters, p);
        r.visible = std::move(pass2.visible);
        r.requests = std::move(pass2.requests);
        r.clusters_coarser = pass2.counters.clusters_coarser;
        break;
      }
      case FrameStep::kStreamBindPost:
        bind_streamed_geometry(in_.streaming, in_.scene, out_->visible, out_->pass1_visible, in_.pool);
        break;
      case FrameStep::kRasterPost:
        raster_pass(in_.scene, geometry_, out_->visible, out_->pass1_visible, object_to_clip_, in_.settings, in_.camera.z_near,
                    in_.pool, out_->vis, p);
        break;
      case FrameStep::kHzbNext:
        if (state.hzb_is_complete) in_.history->hzb = std::move(hzb_);
        else build_hzb(out_->vis.keys.data(), in_.camera.width, in_.camera.height, in_.pool, &in_.history->hzb);
        break;
      case FrameStep::kStreamEnd:
        // Every cluster of this frame is bound: reads may now be issued and pages evicted.
        end_streamed_frame(in_.streaming, state.requests, state.clusters_coarser, out_->visible.size());
        break;
      case FrameStep::kShadowMark:
        shadow_mark_step(in_, out_);
        shadows_drawn_ = true;
        break;
      case FrameStep::kShadowDraw:
        shadow_draw(in_.history ? &in_.history->shadow_cache : nullptr);
        r.shadow = shadow_frame_stats(out_->shadow);
        break;
      case FrameStep::kOverdraw:
        overdraw_pass(in_.scene, geometry_, out_->visible, object_to_clip_, out_->instance_views, view, in_.pool,
                      &out_->overdraw);
        break;
      case FrameStep::kShade: {
        ShadeInput in;
        in.vis = &out_->vis;
        in.visible = &out_->visible;
        in.meshes = &geometry_;
        in.materials = &in_.scene.materials;
        in.instances = &in_.scene.instances;
        in.instance_views = &out_->instance_views;
        in.view = &view;
        in.threshold_px = in_.settings.threshold_px;
        in.overdraw = &out_->overdraw;
        in.lights = &in_.scene.lights;
        in.shadows = shadows_drawn_ ? &out_->shadow : nullptr;
        shade_frame(in, in_.settings.view, in_.pool, &out_->image);
        break;
      }
    }
    return r;
  }

  void finish() override {}  // the visibility buffer is Frame::vis already

 private:
  // Pass 2 tests against this frame's pass-1 HZB with this frame's view and transforms.
  CullOptions post_options() const {
    CullOptions post = options_;
    post.occlusion.hzb = &hzb_;
    post.occlusion.view = &out_->view;
    post.occlusion.instances = &out_->instance_views;
    post.occlusion.policy = in_.settings.hzb_policy;
    return post;
  }

  // spec/shadow.md §5, §9: the shadow views' cull (from the metadata; when streaming, the
  // resident cut of what stream_end left resident), the drawn clusters' geometry bound from
  // resident pages, the requests kept for the next stream_end, then the raster.
  void shadow_draw(ShadowCache* cache) {
    FrameStreaming* s = in_.streaming;
    if (s) refresh_usable_groups(in_.scene, s);
    ShadowCache local;
    ShadowCache* c = cache ? cache : &local;
    ShadowDrawList list = begin_shadow_draw(in_.scene.meshes, in_.scene.instances, in_.scene.lights, in_.pool,
                                            &out_->shadow, c, s ? &s->usable : nullptr);
    if (s) {
      bind_streamed_geometry(s, in_.scene, shadow_draw_clusters(list), 0, in_.pool);
      s->shadow_requests = std::move(list.requests);
    }
    auto drawn = std::make_shared<const ShadowDrawList>(std::move(list));
    raster_shadow_pages_cpu(geometry_, in_.scene.instances, *drawn, in_.pool, c);
    end_shadow_draw(in_.scene.instances, in_.scene.lights, &out_->shadow, c, cache != nullptr);
    out_->shadow.drawn = std::move(drawn);
  }

  const FrameInputs& in_;
  Frame* out_;
  bool shadows_drawn_ = false;
  const std::vector<ClusterDag>& geometry_;  // the scene's meshes, or the streamed frame's
  std::vector<Mat4> object_to_clip_;
  CullOptions options_;
  std::vector<uint32_t> visible_instances_, occluded_instances_, post_instances_;
  CullResult pass1_;  // its occluded items seed pass 2
  Hzb hzb_;           // step hzb's pyramid
};

}  // namespace

void begin_shadow_mark(const FrameInputs& in, Frame* out) {
  ShadowOptions options;
  options.threshold_px = in.settings.threshold_px;
  out->shadow = make_shadow_frame(in.scene.lights, shadow_scene_bounds(in.scene.meshes, in.scene.instances),
                                  in.camera.position, options);
}

void shadow_mark_step(const FrameInputs& in, Frame* out) {
  begin_shadow_mark(in, out);
  mark_shadow_pages(out->vis, out->view, in.scene.lights, in.pool, &out->shadow);
}

ShadowFrameStats shadow_frame_stats(const ShadowFrame& f) {
  return {f.lights, f.pages_marked, f.pages_cached, f.pages_drawn, f.pages_dropped, f.clusters_drawn};
}

FrameContext frame_context(const FrameInputs& in) {
  const FrameHistory* history = in.history;
  FrameContext c;
  c.previous_hzb = history && history->valid && history->hzb.width == in.camera.width &&
                   history->hzb.height == in.camera.height &&
                   history->instance_views.size() == in.scene.instances.size();
  c.keep_history = history != nullptr;
  c.has_next_frame = in.has_next_frame;
  c.streamed = in.streaming != nullptr;
  c.no_stream_reason = in.no_stream_reason;
  return c;
}

void render_planned_frame(const FramePlan& plan, const FrameInputs& in, Frame* out) {
  if (plan.streamed != (in.streaming != nullptr))
    fail("RENDER_PLAN_MISMATCH", "render", "the frame plan's streaming disagrees with the streaming state", kExitInternal);
  const auto frame_start = std::chrono::steady_clock::now();
  CpuFrameExecutor executor(plan, in, out);
  execute_frame_plan(plan, executor, in.scene, in.history, in.streaming, out);
  out->stats.total_ms = ms_since(frame_start);
}

void render_frame(const FrameInputs& in, Frame* out) {
  render_planned_frame(plan_frame(in.scene, in.settings, frame_context(in)), in, out);
}

}  // namespace vgeo
