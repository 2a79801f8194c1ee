// Frame comparison and order-independent hashes (compare.h, spec/raster.md §Backends agree).
#include "vgeo/render/compare.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <map>
#include <sstream>
#include <tuple>

#include "vgeo/core/file_io.h"
#include "vgeo/core/hash.h"
#include "vgeo/shadow/shadow_hw_rule.h"

namespace vgeo {

std::string hex64(uint64_t v) {
  char buf[24];
  std::snprintf(buf, sizeof buf, "%016llx", (unsigned long long)v);
  return buf;
}

namespace {

// What a key denotes, independent of the visible-cluster list's order. Background: zeros
// (depth bits 0 never occur in a written key).
struct Denoted {
  uint32_t depth_bits = 0, instance = 0, cluster = 0, triangle = 0;
  friend bool operator==(const Denoted&, const Denoted&) = default;
};
Denoted denote(uint64_t key, const std::vector<VisibleCluster>& visible) {
  if (key == 0) return {};
  const VisibleCluster& v = visible[vis_key_cluster(key)];
  return {vis_key_depth_bits(key), v.instance, v.cluster, vis_key_triangle(key)};
}

// The triangle a key denotes, as the exact model sees it (hw_rule.h), with the frame's own
// float object→clip matrix (as gpu_frame.cpp and frame.cpp make it).
struct TriangleModels {
  const RenderScene& scene;
  const std::vector<ClusterDag>& geometry;  // the scene's meshes, or a streamed frame's (streaming.h)
  const Camera& camera;
  const Frame& frame;
  std::map<std::tuple<uint32_t, uint32_t, uint32_t>, ModelTriangle> cache;
  const ModelTriangle* of(const Denoted& d) {
    if (d.depth_bits == 0) return nullptr;
    auto [it, fresh] = cache.try_emplace({d.instance, d.cluster, d.triangle});
    if (fresh) {
      const Mat4d view_to_clip =
          perspective_reversed_z(camera.fov_y, double(camera.width) / double(camera.height), camera.z_near);
      const Mat4 m = to_float(view_to_clip * frame.instance_views[d.instance].object_to_view);
      const ClusterDag& dag = geometry[scene.instances[d.instance].mesh];
      const DagCluster& c = dag.clusters[d.cluster];
      Vec3 v[3];
      for (int k = 0; k < 3; ++k) v[k] = dag.position(c.vertex_offset + dag.indices[3 * (c.triangle_offset + d.triangle) + k]);
      it->second = model_triangle(v, m, float(camera.z_near), camera.width, camera.height);
    }
    return &it->second;
  }
};

// spec/raster.md §13.3 over one frame: every pixel classified (hw_rule.h).
HwRasterAgreement compare_hw_frame(const RenderScene& scene, const std::vector<ClusterDag>& geometry, const Camera& camera,
                                   const Frame& cpu, const Frame& gpu) {
  HwRasterAgreement agreement;
  TriangleModels models{scene, geometry, camera, cpu, {}};
  for (uint32_t y = 0; y < cpu.vis.height; ++y)
    for (uint32_t x = 0; x < cpu.vis.width; ++x) {
      const size_t p = size_t(y) * cpu.vis.width + x;
      const Denoted a = denote(cpu.vis.keys[p], cpu.visible), b = denote(gpu.vis.keys[p], gpu.visible);
      const bool same = a.depth_bits && b.depth_bits && a.instance == b.instance && a.cluster == b.cluster &&
                        a.triangle == b.triangle;
      const HwPixel kind = a == b ? HwPixel::kIdentical
                                  : classify_hw_pixel(cpu.vis.keys[p], gpu.vis.keys[p], same, models.of(a), models.of(b), x, y);
      ++agreement.pixels[int(kind)];
      if (same && kind != HwPixel::kIdentical) {
        const double tol = model_depth_tolerance_at(*models.of(a), x + 0.5, y + 0.5);
        const double dz = std::abs(double(vis_key_depth(cpu.vis.keys[p])) - double(vis_key_depth(gpu.vis.keys[p])));
        if (tol > 0 && !std::isinf(tol)) agreement.max_depth_error_ratio = std::max(agreement.max_depth_error_ratio, dz / tol);
      }
    }
  return agreement;
}

}  // namespace

// The shadow part of a comparison (FrameComparison::shadow_*).
static void compare_shadow_pages(const Frame& cpu, const Frame& gpu, FrameComparison* c) {
  const ShadowFrame& a = cpu.shadow;
  const ShadowFrame& b = gpu.shadow;
  c->shadow_tables_equal = cpu.stats.has_shadow == gpu.stats.has_shadow && a.page_table == b.page_table &&
                           a.needed == b.needed && shadow_frame_stats(a) == shadow_frame_stats(b);
  const std::vector<float>& ta = a.pool_texels ? *a.pool_texels : a.own_texels;
  const std::vector<float>& tb = b.pool_texels ? *b.pool_texels : b.own_texels;
  if (ta.size() != tb.size()) c->shadow_tables_equal = false;
  for (size_t i = 0; i < std::min(ta.size(), tb.size()); ++i)
    c->shadow_texels_differing += std::bit_cast<uint32_t>(ta[i]) != std::bit_cast<uint32_t>(tb[i]);
}

// The shadow part under the hardware rule (spec/shadow.md §8): the pages both sides drew
// this frame, matched by (map, mip, page), classified texel by texel.
// `geometry`: the reference's vertex data (a streamed frame's bound geometry holds the shadow
// views' clusters too: frame.cpp's shadow_draw binds them; the scene's meshes are metadata only).
static void compare_shadow_pages_hw(const RenderScene& scene, const std::vector<ClusterDag>& geometry, const Frame& cpu,
                                    const Frame& gpu, FrameComparison* c) {
  const ShadowFrame& a = cpu.shadow;
  const ShadowFrame& b = gpu.shadow;
  if (!a.drawn || !b.drawn) return;
  const ShadowDrawList& la = *a.drawn;
  const ShadowDrawList& lb = *b.drawn;
  const std::vector<float>& ta = a.pool_texels ? *a.pool_texels : a.own_texels;
  const std::vector<float>& tb = b.pool_texels ? *b.pool_texels : b.own_texels;
  constexpr size_t kPageTexelCount = size_t(kShadowPageTexels) * kShadowPageTexels;
  std::map<std::tuple<uint32_t, uint32_t, uint32_t, uint32_t>, size_t> drawn_b;
  for (size_t d = 0; d < lb.pages.size(); ++d)
    drawn_b[{lb.pages[d].map, lb.pages[d].mip, lb.pages[d].x, lb.pages[d].y}] = d;
  size_t matched = 0;
  for (size_t d = 0; d < la.pages.size(); ++d) {
    const ShadowPageDraw& pa = la.pages[d];
    auto it = drawn_b.find({pa.map, pa.mip, pa.x, pa.y});
    if (it == drawn_b.end()) continue;
    ++matched;
    const ShadowPageDraw& pb = lb.pages[it->second];
    ++c->shadow_pages_compared;
    if (la.clusters[d] != lb.clusters[it->second]) {
      ++c->shadow_element_lists_differing;
      continue;
    }
    if ((size_t(pa.slot) + 1) * kPageTexelCount > ta.size() || (size_t(pb.slot) + 1) * kPageTexelCount > tb.size()) {
      ++c->shadow_element_lists_differing;  // a drawn slot outside the pool: never compare past it
      continue;
    }
    classify_shadow_page_hw(geometry, scene.instances, la, d, ta.data() + pa.slot * kPageTexelCount,
                            tb.data() + pb.slot * kPageTexelCount, &c->shadow_hw);
  }
  c->shadow_pages_one_side = (la.pages.size() - matched) + (lb.pages.size() - matched);
}

FrameComparison compare_frames(const RenderScene& scene, const std::vector<ClusterDag>& geometry, const Camera& camera,
                               const Frame& cpu, const Frame& gpu, bool hw_rule) {
  FrameComparison c;
  std::vector<VisibleCluster> a = cpu.visible, b = gpu.visible;
  std::sort(a.begin(), a.end());
  std::sort(b.begin(), b.end());
  c.clusters_equal = a == b;
  for (size_t p = 0; p < cpu.vis.keys.size(); ++p)
    c.vis_pixels_differing += !(denote(cpu.vis.keys[p], cpu.visible) == denote(gpu.vis.keys[p], gpu.visible));
  c.hw_rule = hw_rule;
  if (hw_rule && c.clusters_equal) c.hw = compare_hw_frame(scene, geometry, camera, cpu, gpu);
  c.shadow_compared = !hw_rule && (cpu.stats.has_shadow || gpu.stats.has_shadow);
  if (c.shadow_compared) compare_shadow_pages(cpu, gpu, &c);
  c.shadow_hw_compared = hw_rule && (cpu.stats.has_shadow || gpu.stats.has_shadow);
  if (c.shadow_hw_compared) compare_shadow_pages_hw(scene, geometry, cpu, gpu, &c);
  // Images are compared where both sides shaded this frame (the kept ones, run_frames).
  c.shaded = !cpu.image.rgb.empty() && cpu.image.rgb.size() == gpu.image.rgb.size();
  if (c.shaded)
    for (size_t p = 0; p < cpu.image.rgb.size() / 3; ++p) {
      // The hardware rule compares shading where the keys are identical (elsewhere the
      // pixel shows another surface or depth, which the rule allows).
      if (hw_rule && !(denote(cpu.vis.keys[p], cpu.visible) == denote(gpu.vis.keys[p], gpu.visible))) continue;
      int d = 0;
      for (int k = 0; k < 3; ++k) d = std::max(d, std::abs(int(cpu.image.rgb[3 * p + k]) - int(gpu.image.rgb[3 * p + k])));
      c.max_channel_diff = std::max(c.max_channel_diff, d);
      c.pixels_over += d > 1;
    }
  return c;
}

Image diff_image(const Frame& cpu, const Frame& gpu) {
  Image d;
  d.width = cpu.vis.width;
  d.height = cpu.vis.height;
  d.rgb.assign(size_t(d.width) * d.height * 3, 0);
  for (size_t p = 0; p < size_t(d.width) * d.height; ++p) {
    if (!(denote(cpu.vis.keys[p], cpu.visible) == denote(gpu.vis.keys[p], gpu.visible))) d.rgb[3 * p] = 255;
    int m = 0;
    if (!cpu.image.rgb.empty() && !gpu.image.rgb.empty())
      for (int k = 0; k < 3; ++k) m = std::max(m, std::abs(int(cpu.image.rgb[3 * p + k]) - int(gpu.image.rgb[3 * p + k])));
    d.rgb[3 * p + 1] = uint8_t(std::min(255, 64 * m));
  }
  return d;
}

void write_comparison_failure(const std::string& dir, uint32_t f, const Frame& cpu, const Frame& gpu) {
  char stem[32];
  std::snprintf(stem, sizeof stem, "/frame_%05u", f);
  write_png(dir + stem + "_diff.png", diff_image(cpu, gpu));
  std::ostringstream out;
  out << "# x y | cpu: depth_bits instance cluster triangle | vulkan: depth_bits instance cluster triangle\n";
  for (uint32_t y = 0; y < cpu.vis.height; ++y)
    for (uint32_t x = 0; x < cpu.vis.width; ++x) {
      const size_t p = size_t(y) * cpu.vis.width + x;
      const Denoted a = denote(cpu.vis.keys[p], cpu.visible), b = denote(gpu.vis.keys[p], gpu.visible);
      if (a == b) continue;
      out << x << ' ' << y << " | " << a.depth_bits << ' ' << a.instance << ' ' << a.cluster << ' ' << a.triangle
          << " | " << b.depth_bits << ' ' << b.instance << ' ' << b.cluster << ' ' << b.triangle << '\n';
    }
  write_file_atomic(dir + stem + "_pixels.txt", out.str());
}

uint64_t vis_buffer_hash(const VisBuffer& vis, const std::vector<VisibleCluster>& visible) {
  uint64_t h = kFnvOffset;
  for (uint64_t key : vis.keys) {
    const Denoted d = denote(key, visible);
    const uint32_t words[4] = {d.depth_bits, d.instance, d.cluster, d.triangle};
    h = fnv1a64(words, sizeof words, h);
  }
  return h;
}

uint64_t cluster_set_hash(const std::vector<VisibleCluster>& visible) {
  std::vector<VisibleCluster> sorted = visible;
  std::sort(sorted.begin(), sorted.end());
  uint64_t h = kFnvOffset;
  for (const VisibleCluster& v : sorted) {
    const uint32_t words[2] = {v.instance, v.cluster};
    h = fnv1a64(words, sizeof words, h);
  }
  return h;
}

}  // namespace vgeo
