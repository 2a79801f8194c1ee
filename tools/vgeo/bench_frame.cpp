#include "bench_frame.h"

#include <algorithm>
#include <cmath>

#include "bench_harness.h"
#include "vgeo/core/lod.h"

// Weak: the suites using this driver skip themselves when lib/raster is not linked in.
namespace vgeo {
void rasterize_cluster(VisBuffer& target, const float* positions, uint32_t vertex_count, const uint8_t* indices,
                       uint32_t triangle_count, const Mat4& object_to_clip, uint32_t visible_cluster,
                       const RasterOptions& options, RasterStats* stats) __attribute__((weak));
}

namespace vgeo::bench {
namespace {

// Visible clusters handed to one raster task: large enough to amortise scheduling,
// small enough to balance two to a few dozen threads.
constexpr size_t kClustersPerRasterTask = 32;
// A pixel's visible surface "differs" when its depth differs by more than this fraction
// (1%: far above LOD displacement at tau ≤ 1 px, so it flags a different surface, not a shifted one).
constexpr double kSurfaceDepthTolerance = 0.01;
// Ambient share of the Lambert shade, so lit geometry is never confused with background (0).
constexpr double kAmbient = 0.15;

DVec3 sub(DVec3 a, DVec3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
double dotd(DVec3 a, DVec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
DVec3 crossd(DVec3 a, DVec3 b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
DVec3 normd(DVec3 a) {
  double l = std::sqrt(dotd(a, a));
  return l > 0 ? DVec3{a.x / l, a.y / l, a.z / l} : DVec3{0, 0, 1};
}

struct ViewSetup {
  Mat4d view, proj;
  double tan_half_x, tan_half_y, cos_x, sin_x, cos_y, sin_y;
  float pixels_per_unit_at_1;
};

ViewSetup make_view(const BenchCamera& c) {
  ViewSetup v;
  DVec3 f = normd(sub(c.target, c.eye)), s = normd(crossd(f, c.up)), u = crossd(s, f);
  double r[3][3] = {{s.x, s.y, s.z}, {u.x, u.y, u.z}, {-f.x, -f.y, -f.z}};
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) v.view.at(i, j) = r[i][j];
    v.view.at(i, 3) = -(r[i][0] * c.eye.x + r[i][1] * c.eye.y + r[i][2] * c.eye.z);
  }
  double aspect = double(c.width) / c.height, fy = 1.0 / std::tan(c.fov_y / 2);
  // Reversed-Z infinite far (raster.h): clip.z = z_near, clip.w = view depth.
  v.proj = Mat4d{};
  v.proj.at(0, 0) = fy / aspect;
  v.proj.at(1, 1) = fy;
  v.proj.at(2, 2) = 0;
  v.proj.at(2, 3) = c.z_near;
  v.proj.at(3, 2) = -1;
  v.proj.at(3, 3) = 0;
  v.tan_half_y = 1.0 / fy;
  v.tan_half_x = aspect / fy;
  double hx = std::atan(v.tan_half_x), hy = std::atan(v.tan_half_y);
  v.cos_x = std::cos(hx);
  v.sin_x = std::sin(hx);
  v.cos_y = std::cos(hy);
  v.sin_y = std::sin(hy);
  v.pixels_per_unit_at_1 = lod_projection_scale(float(c.fov_y), float(c.height));
  return v;
}

Mat4d instance_matrix(const BenchInstance& in) {
  Mat4d m;
  for (int i = 0; i < 3; ++i) m.at(i, i) = in.scale;
  m.at(0, 3) = in.translation.x;
  m.at(1, 3) = in.translation.y;
  m.at(2, 3) = in.translation.z;
  return m;
}

struct InstanceView {
  LodView lod;  // in object space
  const BenchInstance* inst;
};

InstanceView instance_view(const BenchInstance& in, const BenchCamera& cam, const ViewSetup& v) {
  InstanceView iv;
  iv.inst = &in;
  // Object-space eye: with a uniform scale s, err_obj * ppu / (d_world / s) = err_world * ppu / d_world.
  iv.lod.eye = {float((cam.eye.x - in.translation.x) / in.scale), float((cam.eye.y - in.translation.y) / in.scale),
                float((cam.eye.z - in.translation.z) / in.scale)};
  iv.lod.pixels_per_unit_at_1 = v.pixels_per_unit_at_1;
  iv.lod.z_near = float(cam.z_near / in.scale);
  if (!(iv.lod.z_near > 0)) iv.lod.z_near = std::numeric_limits<float>::min();
  return iv;
}

// Sphere (object space) against the view frustum (side planes + near plane).
bool sphere_visible(const Sphere& s, const BenchInstance& in, const ViewSetup& v, float z_near) {
  if (s.radius < 0) return false;
  double wx = in.translation.x + in.scale * s.center.x, wy = in.translation.y + in.scale * s.center.y,
         wz = in.translation.z + in.scale * s.center.z, r = in.scale * s.radius;
  double x = v.view.at(0, 0) * wx + v.view.at(0, 1) * wy + v.view.at(0, 2) * wz + v.view.at(0, 3);
  double y = v.view.at(1, 0) * wx + v.view.at(1, 1) * wy + v.view.at(1, 2) * wz + v.view.at(1, 3);
  double z = v.view.at(2, 0) * wx + v.view.at(2, 1) * wy + v.view.at(2, 2) * wz + v.view.at(2, 3);
  if (-z + r < z_near) return false;                   // entirely behind the near plane
  if (x * v.cos_x + z * v.sin_x > r) return false;     // right
  if (-x * v.cos_x + z * v.sin_x > r) return false;    // left
  if (y * v.cos_y + z * v.sin_y > r) return false;     // top
  if (-y * v.cos_y + z * v.sin_y > r) return false;    // bottom
  return true;
}

void cut_instance(const ClusterDag& dag, uint32_t inst_index, const InstanceView& iv, const ViewSetup& v,
                  const BenchCamera& cam, const FrameOptions& opt, bool use_bvh, std::vector<VisibleCluster>& out) {
  auto consider = [&](uint32_t ci) {
    const DagCluster& c = dag.clusters[ci];
    bool selected = opt.leaves_only ? c.level == 0
                                    : lod_selects(c.lod_bounds, c.lod_error, c.parent_bounds, c.parent_error, iv.lod, opt.tau);
    if (selected && (!opt.frustum_cull || sphere_visible(c.bounds, *iv.inst, v, cam.z_near)))
      out.push_back({inst_index, ci});
  };
  if (!use_bvh || opt.leaves_only || dag.bvh_nodes.empty()) {
    for (uint32_t ci = 0; ci < dag.clusters.size(); ++ci) consider(ci);
    return;
  }
  std::vector<uint32_t> stack{0};
  while (!stack.empty()) {
    const BvhNode& n = dag.bvh_nodes[stack.back()];
    stack.pop_back();
    if (opt.frustum_cull && !sphere_visible(n.bounds, *iv.inst, v, cam.z_near)) continue;
    // Every group below is fine enough already: none of their members is drawn (monotonic test).
    if (!(projected_error(n.lod_bounds, n.max_parent_error, iv.lod) > opt.tau)) continue;
    for (uint32_t k = 0; k < n.child_count && k < kBvhMaxChildren; ++k) {
      uint32_t child = n.children[k];
      if (!(n.group_mask & (1u << k))) {
        if (child < dag.bvh_nodes.size()) stack.push_back(child);
        continue;
      }
      if (child >= dag.groups.size()) continue;
      const DagGroup& g = dag.groups[child];
      if (!(projected_error(g.parent_bounds, g.parent_error, iv.lod) > opt.tau)) continue;
      for (uint32_t ci = g.first_cluster; ci < g.first_cluster + g.cluster_count && ci < dag.clusters.size(); ++ci)
        consider(ci);
    }
  }
  // Group order from the traversal is not cluster order: sort for a deterministic id assignment.
}

void cut_all(const std::vector<const ClusterDag*>& meshes, const std::vector<BenchInstance>& instances,
             const BenchCamera& cam, const FrameOptions& opt, const ViewSetup& v, bool use_bvh,
             std::vector<VisibleCluster>& out) {
  out.clear();
  for (uint32_t i = 0; i < instances.size(); ++i) {
    size_t first = out.size();
    InstanceView iv = instance_view(instances[i], cam, v);
    cut_instance(*meshes[instances[i].mesh], i, iv, v, cam, opt, use_bvh, out);
    std::sort(out.begin() + long(first), out.end(),
              [](const VisibleCluster& a, const VisibleCluster& b) { return a.cluster < b.cluster; });
  }
}

}  // namespace

uint64_t flat_cut_clusters(const std::vector<const ClusterDag*>& meshes, const std::vector<BenchInstance>& instances,
                           const BenchCamera& camera, const FrameOptions& options) {
  ViewSetup v = make_view(camera);
  std::vector<VisibleCluster> vis;
  cut_all(meshes, instances, camera, options, v, false, vis);
  return vis.size();
}

void render_frame(const std::vector<const ClusterDag*>& meshes, const std::vector<BenchInstance>& instances,
                  const BenchCamera& cam, const FrameOptions& opt, ThreadPool& pool, FrameResult& out) {
  ViewSetup v = make_view(cam);
  double c0 = cpu_seconds(), t0 = now_seconds();
  cut_all(meshes, instances, cam, opt, v, true, out.visible);
  if (out.visible.size() > kMaxVisibleClusters) out.visible.resize(kMaxVisibleClusters);
  std::vector<Mat4> matrices(instances.size());
  Mat4d pv = v.proj * v.view;
  for (size_t i = 0; i < instances.size(); ++i) matrices[i] = to_float(pv * instance_matrix(instances[i]));
  out.clusters = out.visible.size();
  out.triangles = 0;
  for (const VisibleCluster& vc : out.visible)
    out.triangles += meshes[instances[vc.instance].mesh]->clusters[vc.cluster].triangle_count;
  double t1 = now_seconds(), c1 = cpu_seconds();
  out.seconds_cut = t1 - t0;
  out.cpu_cut = c1 - c0;

  if (out.vis.width != cam.width || out.vis.height != cam.height) out.vis.resize(cam.width, cam.height);
  else out.vis.clear();
  size_t tasks = (out.visible.size() + kClustersPerRasterTask - 1) / kClustersPerRasterTask;
  std::vector<RasterStats> stats(tasks);
  RasterOptions ropt;
  ropt.z_near = cam.z_near;
  pool.parallel_for(tasks, [&](size_t t) {
    size_t end = std::min(out.visible.size(), (t + 1) * kClustersPerRasterTask);
    for (size_t i = t * kClustersPerRasterTask; i < end; ++i) {
      const VisibleCluster& vc = out.visible[i];
      const ClusterDag& dag = *meshes[instances[vc.instance].mesh];
      const DagCluster& c = dag.clusters[vc.cluster];
      rasterize_cluster(out.vis, dag.positions.data() + 3 * size_t(c.vertex_offset), c.vertex_count,
                        dag.indices.data() + 3 * size_t(c.triangle_offset), c.triangle_count, matrices[vc.instance],
                        uint32_t(i), ropt, &stats[t]);
    }
  });
  out.raster = RasterStats{};
  for (const RasterStats& s : stats) out.raster.add(s);
  double t2 = now_seconds(), c2 = cpu_seconds();
  out.seconds_raster = t2 - t1;
  out.cpu_raster = c2 - c1;

  // Shade: Lambert with one fixed directional light, from the triangle's geometric normal.
  const DVec3 light = normd({0.4, 0.8, 0.45});
  out.image.assign(size_t(cam.width) * cam.height, 0);
  pool.parallel_for(cam.height, [&](size_t y) {
    for (size_t x = 0; x < cam.width; ++x) {
      size_t p = y * cam.width + x;
      uint64_t key = out.vis.keys[p];
      if (key == 0) continue;
      uint32_t vi = vis_key_cluster(key), tri = vis_key_triangle(key);
      if (vi >= out.visible.size()) continue;
      const VisibleCluster& vc = out.visible[vi];
      const ClusterDag& dag = *meshes[instances[vc.instance].mesh];
      const DagCluster& c = dag.clusters[vc.cluster];
      if (tri >= c.triangle_count) continue;
      size_t ti = 3 * (size_t(c.triangle_offset) + tri);
      Vec3 a = dag.position(c.vertex_offset + dag.indices[ti]), b = dag.position(c.vertex_offset + dag.indices[ti + 1]),
           d = dag.position(c.vertex_offset + dag.indices[ti + 2]);
      Vec3 n = cross(b - a, d - a);
      DVec3 nd = normd({n.x, n.y, n.z});
      double lambert = std::max(0.0, dotd(nd, light));
      out.image[p] = uint8_t(std::clamp(std::lround(255.0 * (kAmbient + (1 - kAmbient) * lambert)), 1l, 255l));
    }
  });
  out.seconds_shade = now_seconds() - t2;
  out.cpu_shade = cpu_seconds() - c2;
}

ImageError compare_frames(const FrameResult& test, const FrameResult& ref) {
  ImageError e;
  size_t n = std::min(test.image.size(), ref.image.size());
  if (n == 0) return e;
  double sum = 0;
  uint64_t differs = 0;
  for (size_t i = 0; i < n; ++i) {
    double d = std::fabs(double(test.image[i]) - double(ref.image[i]));
    sum += d;
    e.max_abs = std::max(e.max_abs, d);
    uint64_t ka = test.vis.keys[i], kb = ref.vis.keys[i];
    if ((ka == 0) != (kb == 0)) {
      ++differs;
    } else if (ka != 0) {
      // NDC depth = z_near / view depth: the relative difference is the same in both.
      double da = vis_key_depth(ka), db = vis_key_depth(kb);
      if (std::fabs(da - db) > kSurfaceDepthTolerance * db) ++differs;
    }
  }
  e.mean_abs = sum / double(n);
  e.surface_differs = double(differs) / double(n);
  return e;
}

}  // namespace vgeo::bench
