#include "vgeo/render/frame.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <nlohmann/json.hpp>

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
  uint64_t leaf_tris = 0;
  for (const DagCluster& c : dag.clusters)
    if (c.level == 0) leaf_tris += c.triangle_count;
  if (leaf_tris * dag.vertex_count() > kConvexCheckBudget || leaf_tris == 0) return false;
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
      for (size_t v = 0; v < dag.vertex_count(); ++v) {
        Vec3 p = dag.position(v);
        double s = (n[0] * (p.x - a.x) + n[1] * (p.y - a.y) + n[2] * (p.z - a.z)) / nl;
        if (s > tolerance) return false;
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
  stats->clusters_drawn = n;
  for (size_t i = first; i < visible.size(); ++i) {
    const VisibleCluster& v = visible[i];
    stats->triangles_drawn += scene.meshes[scene.instances[v.instance].mesh].clusters[v.cluster].triangle_count;
  }
  stats->pixels_written = total.pixels_written;
}

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

}  // namespace

void analyze_render_scene(RenderScene* scene) {
  scene->single_convex_object =
      scene->instances.size() == 1 && dag_is_convex(scene->meshes[scene->instances[0].mesh]);
}

void render_frame(const RenderScene& scene, const Camera& camera, const RenderSettings& settings,
                  ThreadPool& pool, FrameHistory* history, Frame* out, bool has_next_frame,
                  FrameStreaming* streaming) {
  auto frame_start = std::chrono::steady_clock::now();
  FrameStats& stats = out->stats;
  stats = {};
  out->view = make_view(camera);
  const ViewParams& view = out->view;
  out->instance_views = make_instance_views(scene.instances, view);
  out->vis.resize(camera.width, camera.height);
  out->visible.clear();
  out->overdraw.clear();
  stats.instances = scene.instances.size();
  stats.pixels = uint64_t(camera.width) * camera.height;
  const Mat4d view_to_clip =
      perspective_reversed_z(camera.fov_y, double(camera.width) / double(camera.height), camera.z_near);
  const std::vector<Mat4> object_to_clip = clip_matrices(out->instance_views, view_to_clip);

  bool occlusion = settings.occlusion && !scene.single_convex_object;
  std::string no_occlusion_reason = !settings.occlusion ? "occlusion off" : "single convex object";
  bool have_previous = occlusion && history && history->valid && history->hzb.width == camera.width &&
                       history->hzb.height == camera.height &&
                       history->instance_views.size() == scene.instances.size();

  const std::vector<ClusterDag>& geometry = streaming ? streaming->geometry : scene.meshes;
  double stream_ms = 0;
  if (streaming) {
    auto t0 = std::chrono::steady_clock::now();
    begin_streamed_frame(scene, streaming);
    stream_ms += ms_since(t0);
  }

  // ---- pass 1 ----
  CullOptions options;
  options.threshold_px = settings.threshold_px;
  if (streaming) options.usable_groups = &streaming->usable;
  if (have_previous) {
    options.occlusion.hzb = &history->hzb;
    options.occlusion.view = &history->view;
    options.occlusion.instances = &history->instance_views;
    options.occlusion.policy = settings.hzb_policy;
  }
  std::vector<uint32_t> all(scene.instances.size()), visible_instances, occluded_instances;
  for (uint32_t i = 0; i < all.size(); ++i) all[i] = i;
  {
    PassStats p;
    p.name = "instance_cull";
    auto t0 = std::chrono::steady_clock::now();
    CullCounters cc;
    cull_instances(scene.meshes, scene.instances, out->instance_views, all, view, options, &visible_instances,
                   &occluded_instances, &cc);
    p.ms = ms_since(t0);
    p.instances_in = cc.instances_in;
    p.instances_out = cc.instances_out;
    stats.passes.push_back(p);
  }
  CullResult pass1;
  {
    PassStats p;
    p.name = "cluster_cull";
    auto t0 = std::chrono::steady_clock::now();
    std::vector<CullItem> seeds;
    for (uint32_t i : visible_instances) seeds.push_back({i, 0, CullItem::kNode});
    cull_clusters(scene.meshes, scene.instances, out->instance_views, seeds, view, options, pool, &pass1);
    p.ms = ms_since(t0);
    p.nodes_visited = pass1.counters.nodes_visited;
    p.groups_visited = pass1.counters.groups_visited;
    p.cluster_candidates = pass1.counters.cluster_candidates;
    p.clusters_occluded = pass1.counters.clusters_occluded;
    stats.passes.push_back(p);
  }
  out->visible = pass1.visible;
  out->pass1_visible = uint32_t(std::min<size_t>(out->visible.size(), kMaxVisibleClusters));
  if (out->visible.size() > kMaxVisibleClusters)
    fail("RENDER_TOO_MANY_VISIBLE_CLUSTERS", "render", "more than 2^25 visible clusters in one view", kExitBadInput);
  if (streaming) {
    auto t0 = std::chrono::steady_clock::now();
    bind_streamed_geometry(streaming, scene, out->visible, 0, pool);
    stream_ms += ms_since(t0);
  }
  {
    PassStats p;
    p.name = "raster";
    auto t0 = std::chrono::steady_clock::now();
    raster_pass(scene, geometry, out->visible, 0, object_to_clip, settings, camera.z_near, pool, out->vis, &p);
    p.ms = ms_since(t0);
    stats.passes.push_back(p);
  }

  // ---- pass 2 ----
  bool pass1_occluded = !occluded_instances.empty() || !pass1.occluded.empty();
  Hzb hzb;
  bool hzb_is_complete = false;
  std::vector<GroupRequest> requests;
  uint64_t clusters_ideal = pass1.counters.clusters_ideal, clusters_coarser = pass1.counters.clusters_coarser;
  if (streaming) requests = std::move(pass1.requests);
  if (!occlusion) {
    for (const char* name : {"hzb", "instance_cull_post", "cluster_cull_post", "raster_post", "hzb_next"})
      stats.skipped.push_back({name, no_occlusion_reason});
  } else if (!pass1_occluded) {
    const char* reason = have_previous ? "pass 1 occluded nothing" : "no previous-frame HZB";
    for (const char* name : {"hzb", "instance_cull_post", "cluster_cull_post", "raster_post"})
      stats.skipped.push_back({name, reason});
  } else {
    {
      PassStats p;
      p.name = "hzb";
      auto t0 = std::chrono::steady_clock::now();
      build_hzb(out->vis.keys.data(), camera.width, camera.height, pool, &hzb);
      p.ms = ms_since(t0);
      stats.passes.push_back(p);
    }
    CullOptions post = options;
    post.occlusion.hzb = &hzb;
    post.occlusion.view = &view;
    post.occlusion.instances = &out->instance_views;
    std::vector<uint32_t> post_instances;
    {
      PassStats p;
      p.name = "instance_cull_post";
      auto t0 = std::chrono::steady_clock::now();
      CullCounters cc;
      cull_instances(scene.meshes, scene.instances, out->instance_views, occluded_instances, view, post,
                     &post_instances, nullptr, &cc);
      p.ms = ms_since(t0);
      p.instances_in = cc.instances_in;
      p.instances_out = cc.instances_out;
      stats.passes.push_back(p);
    }
    CullResult pass2;
    {
      PassStats p;
      p.name = "cluster_cull_post";
      auto t0 = std::chrono::steady_clock::now();
      std::vector<CullItem> seeds = pass1.occluded;
      for (uint32_t i : post_instances) seeds.push_back({i, 0, CullItem::kNode});
      cull_clusters(scene.meshes, scene.instances, out->instance_views, seeds, view, post, pool, &pass2);
      p.ms = ms_since(t0);
      p.nodes_visited = pass2.counters.nodes_visited;
      p.groups_visited = pass2.counters.groups_visited;
      p.cluster_candidates = pass2.counters.cluster_candidates;
      p.clusters_occluded = pass2.counters.clusters_occluded;
      stats.passes.push_back(p);
    }
    if (out->visible.size() + pass2.visible.size() > kMaxVisibleClusters)
      fail("RENDER_TOO_MANY_VISIBLE_CLUSTERS", "render", "more than 2^25 visible clusters in one view", kExitBadInput);
    if (streaming) {
      requests.insert(requests.end(), pass2.requests.begin(), pass2.requests.end());
      clusters_ideal += pass2.counters.clusters_ideal;
      clusters_coarser += pass2.counters.clusters_coarser;
    }
    if (pass2.visible.empty()) {
      stats.skipped.push_back({"raster_post", "pass 2 found nothing newly visible"});
      hzb_is_complete = true;  // nothing drawn after the pass-1 HZB
    } else {
      out->visible.insert(out->visible.end(), pass2.visible.begin(), pass2.visible.end());
      if (streaming) {
        auto t0 = std::chrono::steady_clock::now();
        bind_streamed_geometry(streaming, scene, out->visible, out->pass1_visible, pool);
        stream_ms += ms_since(t0);
      }
      PassStats p;
      p.name = "raster_post";
      auto t0 = std::chrono::steady_clock::now();
      raster_pass(scene, geometry, out->visible, out->pass1_visible, object_to_clip, settings, camera.z_near, pool, out->vis, &p);
      p.ms = ms_since(t0);
      stats.passes.push_back(p);
    }
  }
  if (occlusion) {
    if (!history || !has_next_frame) {
      stats.skipped.push_back({"hzb_next", "no next frame"});
    } else {
      PassStats p;
      p.name = "hzb_next";
      auto t0 = std::chrono::steady_clock::now();
      if (hzb_is_complete) history->hzb = std::move(hzb);
      else build_hzb(out->vis.keys.data(), camera.width, camera.height, pool, &history->hzb);
      history->view = view;
      history->instance_views = out->instance_views;
      history->valid = true;
      p.ms = ms_since(t0);
      stats.passes.push_back(p);
    }
  }

  if (streaming) {
    // Every cluster of this frame is bound: reads may now be issued and pages evicted.
    PassStats p;
    p.name = "stream";
    auto t0 = std::chrono::steady_clock::now();
    end_streamed_frame(streaming, requests, clusters_ideal, clusters_coarser, out->visible.size());
    p.ms = stream_ms + ms_since(t0);
    stats.passes.push_back(p);
    stats.streamed = true;
    stats.stream = streaming->stats;
  }
  if (settings.shade && settings.view == ShadeView::kOverdraw) {
    PassStats p;
    p.name = "overdraw";
    auto t0 = std::chrono::steady_clock::now();
    overdraw_pass(scene, geometry, out->visible, object_to_clip, out->instance_views, view, pool, &out->overdraw);
    p.ms = ms_since(t0);
    stats.passes.push_back(p);
  }
  if (settings.shade) {
    PassStats p;
    p.name = "shade";
    auto t0 = std::chrono::steady_clock::now();
    ShadeInput in;
    in.vis = &out->vis;
    in.visible = &out->visible;
    in.meshes = &geometry;
    in.materials = &scene.materials;
    in.instances = &scene.instances;
    in.instance_views = &out->instance_views;
    in.view = &view;
    in.threshold_px = settings.threshold_px;
    in.overdraw = &out->overdraw;
    shade_frame(in, settings.view, pool, &out->image);
    p.ms = ms_since(t0);
    stats.passes.push_back(p);
  } else {
    stats.skipped.push_back({"shade", "shading not requested"});
  }

  for (const PassStats& p : stats.passes) {
    stats.clusters_drawn += p.clusters_drawn;
    stats.triangles_drawn += p.triangles_drawn;
  }
  for (uint64_t k : out->vis.keys) stats.pixels_covered += k != 0;
  stats.total_ms = ms_since(frame_start);
}

std::string frame_stats_table(const FrameStats& s) {
  std::string out;
  char line[512];
  std::snprintf(line, sizeof line, "%-19s %9s %9s %9s %9s %10s %9s %9s %11s %11s\n", "pass", "ms", "inst_in",
                "inst_out", "nodes", "candidates", "occluded", "clusters", "triangles", "pixels");
  out += line;
  for (const PassStats& p : s.passes) {
    std::snprintf(line, sizeof line, "%-19s %9.3f %9llu %9llu %9llu %10llu %9llu %9llu %11llu %11llu\n",
                  p.name.c_str(), p.ms, (unsigned long long)p.instances_in, (unsigned long long)p.instances_out,
                  (unsigned long long)p.nodes_visited, (unsigned long long)p.cluster_candidates,
                  (unsigned long long)p.clusters_occluded, (unsigned long long)p.clusters_drawn,
                  (unsigned long long)p.triangles_drawn, (unsigned long long)p.pixels_written);
    out += line;
  }
  for (const auto& [name, reason] : s.skipped) out += "(skipped) " + name + ": " + reason + "\n";
  std::snprintf(line, sizeof line,
                "frame: %.3f ms, %llu clusters, %llu triangles drawn, %llu of %llu pixels covered "
                "(%.2f triangles/pixel)\n",
                s.total_ms, (unsigned long long)s.clusters_drawn, (unsigned long long)s.triangles_drawn,
                (unsigned long long)s.pixels_covered, (unsigned long long)s.pixels,
                s.pixels ? double(s.triangles_drawn) / double(s.pixels) : 0.0);
  out += line;
  return out;
}

std::string stream_frame_stats_json(const StreamFrameStats& s) {
  nlohmann::ordered_json j;
  j["frame"] = s.frame;
  j["active"] = s.active;
  j["pages_requested"] = s.pages_requested;
  j["pages_missing"] = s.pages_missing;
  j["requested_bytes"] = s.requested_bytes;
  j["required_bytes"] = s.required_bytes;
  j["pages_issued"] = s.pages_issued;
  j["pages_loaded"] = s.pages_loaded;
  j["pages_evicted"] = s.pages_evicted;
  j["bytes_read"] = s.bytes_read;
  j["resident_bytes"] = s.resident_bytes;
  j["reserved_bytes"] = s.reserved_bytes;
  j["resident_pages"] = s.resident_pages;
  j["read_failures"] = s.read_failures;
  j["checksum_failures"] = s.checksum_failures;
  j["decode_failures"] = s.decode_failures;
  j["pages_marked_bad"] = s.pages_marked_bad;
  j["clusters_drawn"] = s.clusters_drawn;
  j["clusters_coarser"] = s.clusters_coarser;
  j["cut_is_ideal"] = s.cut_is_ideal;
  return j.dump();
}

std::string frame_stats_json(const FrameStats& s) {
  nlohmann::ordered_json j;
  j["total_ms"] = s.total_ms;
  j["instances"] = s.instances;
  j["clusters_drawn"] = s.clusters_drawn;
  j["triangles_drawn"] = s.triangles_drawn;
  j["pixels_covered"] = s.pixels_covered;
  j["pixels"] = s.pixels;
  j["passes"] = nlohmann::ordered_json::array();
  for (const PassStats& p : s.passes) {
    nlohmann::ordered_json q;
    q["name"] = p.name;
    q["ms"] = p.ms;
    q["instances_in"] = p.instances_in;
    q["instances_out"] = p.instances_out;
    q["nodes_visited"] = p.nodes_visited;
    q["groups_visited"] = p.groups_visited;
    q["cluster_candidates"] = p.cluster_candidates;
    q["clusters_occluded"] = p.clusters_occluded;
    q["clusters_drawn"] = p.clusters_drawn;
    q["triangles_drawn"] = p.triangles_drawn;
    q["pixels_written"] = p.pixels_written;
    j["passes"].push_back(q);
  }
  j["skipped"] = nlohmann::ordered_json::array();
  for (const auto& [name, reason] : s.skipped) j["skipped"].push_back({{"name", name}, {"reason", reason}});
  if (s.streamed) j["stream"] = nlohmann::ordered_json::parse(stream_frame_stats_json(s.stream));
  return j.dump();
}

}  // namespace vgeo
