// Shading from the visibility buffer: decode (instance, cluster, triangle) per pixel, re-fetch
// the triangle and shade it. Based on: Burns, Hunt, "The Visibility Buffer: A Cache-Friendly
// Approach to Deferred Shading", JCGT 2(2), 2013; Nanite's material pass (Karis et al. 2021).
#include "vgeo/shade/shade.h"

#include <algorithm>
#include <array>
#include <cmath>

#include "vgeo/core/hash.h"
#include "vgeo/core/lod.h"

namespace vgeo {

bool parse_shade_view(const std::string& name, ShadeView* out) {
  static const struct { const char* name; ShadeView view; } kViews[] = {
      {"lit", ShadeView::kLit}, {"triangle", ShadeView::kTriangle}, {"cluster", ShadeView::kCluster},
      {"group", ShadeView::kGroup}, {"lod", ShadeView::kLod}, {"error", ShadeView::kError},
      {"overdraw", ShadeView::kOverdraw}};
  for (const auto& v : kViews)
    if (name == v.name) {
      *out = v.view;
      return true;
    }
  return false;
}

const char* shade_view_name(ShadeView view) {
  switch (view) {
    case ShadeView::kLit: return "lit";
    case ShadeView::kTriangle: return "triangle";
    case ShadeView::kCluster: return "cluster";
    case ShadeView::kGroup: return "group";
    case ShadeView::kLod: return "lod";
    case ShadeView::kError: return "error";
    case ShadeView::kOverdraw: return "overdraw";
  }
  return "?";
}

namespace {

struct Rgb {
  float r = 0, g = 0, b = 0;
};
// Linear background colour (dark blue-grey): distinct from every lit surface.
constexpr Rgb kBackground{0.02f, 0.025f, 0.035f};

// Linear → 8-bit sRGB through a table (the per-pixel pow() dominated shading time).
// 16384 entries: one step moves the sRGB value by < 0.25 of an 8-bit unit everywhere.
constexpr int kSrgbTableSize = 16384;
std::vector<uint8_t> make_srgb_table() {
  std::vector<uint8_t> t(kSrgbTableSize + 1);
  for (int i = 0; i <= kSrgbTableSize; ++i) {
    double c = double(i) / kSrgbTableSize;
    double s = c <= 0.0031308 ? 12.92 * c : 1.055 * std::pow(c, 1.0 / 2.4) - 0.055;
    t[i] = uint8_t(std::lround(s * 255.0));
  }
  return t;
}
uint8_t to_srgb8(const std::vector<uint8_t>& table, float linear) {
  float c = std::clamp(linear, 0.0f, 1.0f);  // NaN → 0 via the comparison below
  if (!(c >= 0.0f)) c = 0.0f;
  return table[size_t(std::lround(c * kSrgbTableSize))];
}

// Well-spread colour for an id (debug views): hash → hue-ish RGB in [0.15, 1].
Rgb id_colour(uint64_t a, uint64_t b) {
  uint64_t v[2] = {a, b};
  uint64_t h = fnv1a64(v, sizeof(v));
  auto ch = [&](int shift) { return 0.15f + 0.85f * float((h >> shift) & 0xFF) / 255.0f; };
  return {ch(8), ch(24), ch(40)};
}

// Blue → green → yellow → red ramp for t in [0, 1].
Rgb heat(float t) {
  t = std::clamp(t, 0.0f, 1.0f);
  if (t < 1.0f / 3) return {0, 3 * t, 1 - 3 * t};
  if (t < 2.0f / 3) return {3 * (t - 1.0f / 3), 1, 0};
  return {1, 1 - 3 * (t - 2.0f / 3), 0};
}

// spec/shadow.md §2: Σ over lights of color × intensity × cone × lambert × shadow, per channel,
// at pixel (x, y) with sample point p (world) and unit world normal n; the shadow test's trace
// walks `screen`.
std::array<double, 3> sum_lights(const std::vector<Light>& lights, const ShadowFrame* shadows,
                                 const ShadowScreen& screen, uint32_t x, uint32_t y, const Vec3d& p, double footprint,
                                 const double n[3]) {
  std::array<double, 3> sum{0, 0, 0};
  for (uint32_t i = 0; i < lights.size(); ++i) {
    const Light& light = lights[i];
    double l[3];
    if (light.type == LightType::kDirectional) {
      l[0] = -light.direction.x, l[1] = -light.direction.y, l[2] = -light.direction.z;
    } else {
      double d[3] = {light.position.x - p.x, light.position.y - p.y, light.position.z - p.z};
      double len = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
      for (int k = 0; k < 3; ++k) l[k] = d[k] / len;  // len 0: NaN, rejected below
    }
    const double c = n[0] * l[0] + n[1] * l[1] + n[2] * l[2];
    if (!(c > 0)) continue;
    if (light.type == LightType::kSpot &&
        !(-(l[0] * light.direction.x + l[1] * light.direction.y + l[2] * light.direction.z) >=
          std::cos(0.5 * light.cone_radians)))
      continue;
    double shadow = 1.0;
    if (light.shadows && shadows) {
      const ShadowReceiver receiver{x, y, p, footprint, {n[0], n[1], n[2]}, {l[0], l[1], l[2]}, c};
      shadow = shadow_term(*shadows, i, receiver, screen);
    }
    for (int k = 0; k < 3; ++k) sum[k] += double(light.color[k]) * light.intensity * c * shadow;
  }
  return sum;
}

struct Vec3dd {
  double x, y, z;
};
Vec3dd xform_point(const Mat4d& m, const float* p) {
  return {m.at(0, 0) * p[0] + m.at(0, 1) * p[1] + m.at(0, 2) * p[2] + m.at(0, 3),
          m.at(1, 0) * p[0] + m.at(1, 1) * p[1] + m.at(1, 2) * p[2] + m.at(1, 3),
          m.at(2, 0) * p[0] + m.at(2, 1) * p[1] + m.at(2, 2) * p[2] + m.at(2, 3)};
}

}  // namespace

void shade_normal_matrix(const Mat4d& m, double out[3][3]) {
  double a[3][3];
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) a[r][c] = m.at(r, c);
  // Cofactor matrix == det * inverse-transpose.
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) {
      int r1 = (r + 1) % 3, r2 = (r + 2) % 3, c1 = (c + 1) % 3, c2 = (c + 2) % 3;
      out[r][c] = a[r1][c1] * a[r2][c2] - a[r1][c2] * a[r2][c1];
    }
  double det = a[0][0] * out[0][0] + a[0][1] * out[0][1] + a[0][2] * out[0][2];
  if (det < 0)
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) out[r][c] = -out[r][c];
}

void shade_frame(const ShadeInput& in, ShadeView mode, ThreadPool& pool, Image* out) {
  const VisBuffer& vis = *in.vis;
  const ViewParams& view = *in.view;
  out->width = vis.width;
  out->height = vis.height;
  out->rgb.assign(size_t(vis.width) * vis.height * 3, 0);

  std::vector<std::array<std::array<double, 3>, 3>> normal_mats(in.instances->size());
  for (size_t i = 0; i < in.instances->size(); ++i) {
    double nm[3][3];
    shade_normal_matrix((*in.instances)[i].object_to_world, nm);
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) normal_mats[i][r][c] = nm[r][c];
  }
  Vec3 L = in.light_direction;
  double ll = std::sqrt(double(L.x) * L.x + double(L.y) * L.y + double(L.z) * L.z);
  double lx = L.x / ll, ly = L.y / ll, lz = L.z / ll;
  const bool scene_lights = in.lights && !in.lights->empty();
  const Mat4d view_to_world = rigid_inverse(view.world_to_view);
  const ShadowScreen screen = make_shadow_screen(vis, view);
  LodView lv;
  lv.pixels_per_unit_at_1 = view.pixels_per_unit_at_1;
  lv.z_near = float(view.z_near);

  const std::vector<uint8_t> srgb = make_srgb_table();
  uint32_t max_overdraw = 1;
  if (mode == ShadeView::kOverdraw && in.overdraw)
    for (uint32_t c : *in.overdraw) max_overdraw = std::max(max_overdraw, c);

  pool.parallel_for(vis.height, [&](size_t y) {
    for (uint32_t x = 0; x < vis.width; ++x) {
      size_t p = y * vis.width + x;
      uint64_t key = vis.keys[p];
      Rgb col = kBackground;
      if (mode == ShadeView::kOverdraw) {
        uint32_t n = in.overdraw ? (*in.overdraw)[p] : 0;
        if (n > 0) col = heat(float(n - 1) / float(std::max<uint32_t>(max_overdraw - 1, 1)));
      } else if (key != 0) {
        uint32_t vc = vis_key_cluster(key), tri = vis_key_triangle(key);
        const VisibleCluster& v = (*in.visible)[vc];
        const CullInstance& inst = (*in.instances)[v.instance];
        const ClusterDag& dag = (*in.meshes)[inst.mesh];
        const DagCluster& c = dag.clusters[v.cluster];
        switch (mode) {
          case ShadeView::kTriangle: col = id_colour(vc, tri); break;
          case ShadeView::kCluster: col = id_colour(v.instance, v.cluster); break;
          case ShadeView::kGroup: col = id_colour(v.instance, uint64_t(c.group) | (1ull << 40)); break;
          case ShadeView::kLod:
            col = heat(dag.level_count > 1 ? float(c.level) / float(dag.level_count - 1) : 0.0f);
            break;
          case ShadeView::kError: {
            const InstanceView& iv = (*in.instance_views)[v.instance];
            float e = projected_error(sphere_to_view(iv.object_to_view, iv.scale, c.lod_bounds),
                                      error_to_view(c.lod_error, iv.scale), lv);
            col = heat(e / std::max(in.threshold_px, 1e-6f));
            break;
          }
          default: {  // lit
            const InstanceView& iv = (*in.instance_views)[v.instance];
            const uint8_t* idx = dag.indices.data() + 3 * (size_t(c.triangle_offset) + tri);
            size_t vi[3];
            Vec3dd q[3];
            for (int k = 0; k < 3; ++k) {
              vi[k] = size_t(c.vertex_offset) + idx[k];
              q[k] = xform_point(iv.object_to_view, dag.positions.data() + 3 * vi[k]);
            }
            // Ray from the eye through the pixel centre, intersected with the triangle's
            // plane (Möller–Trumbore without the inside test): perspective-correct weights.
            double dx = ((x + 0.5) / vis.width * 2 - 1) * view.tan_half_x;
            double dy = (1 - (y + 0.5) / vis.height * 2) * view.tan_half_y, dz = -1;
            double e1[3] = {q[1].x - q[0].x, q[1].y - q[0].y, q[1].z - q[0].z};
            double e2[3] = {q[2].x - q[0].x, q[2].y - q[0].y, q[2].z - q[0].z};
            double pv[3] = {dy * e2[2] - dz * e2[1], dz * e2[0] - dx * e2[2], dx * e2[1] - dy * e2[0]};
            double det = e1[0] * pv[0] + e1[1] * pv[1] + e1[2] * pv[2];
            double b1 = 1.0 / 3, b2 = 1.0 / 3;
            if (std::abs(det) > 0) {
              double tv[3] = {-q[0].x, -q[0].y, -q[0].z};
              double qv[3] = {tv[1] * e1[2] - tv[2] * e1[1], tv[2] * e1[0] - tv[0] * e1[2], tv[0] * e1[1] - tv[1] * e1[0]};
              b1 = (tv[0] * pv[0] + tv[1] * pv[1] + tv[2] * pv[2]) / det;
              b2 = (dx * qv[0] + dy * qv[1] + dz * qv[2]) / det;
              if (!std::isfinite(b1) || !std::isfinite(b2)) b1 = b2 = 1.0 / 3;
              // Pixel centres just outside the triangle (edge pixels) extrapolate: clamp.
              b1 = std::clamp(b1, 0.0, 1.0);
              b2 = std::clamp(b2, 0.0, 1.0 - b1);
            }
            double b0 = 1 - b1 - b2, bw[3] = {b0, b1, b2};
            double n[3] = {0, 0, 0};
            if (!dag.normals.empty()) {
              for (int k = 0; k < 3; ++k)
                for (int a = 0; a < 3; ++a) n[a] += bw[k] * dag.normals[3 * vi[k] + a];
            } else {
              const float* p0 = dag.positions.data() + 3 * vi[0];
              const float* p1 = dag.positions.data() + 3 * vi[1];
              const float* p2 = dag.positions.data() + 3 * vi[2];
              double a1[3] = {double(p1[0]) - p0[0], double(p1[1]) - p0[1], double(p1[2]) - p0[2]};
              double a2[3] = {double(p2[0]) - p0[0], double(p2[1]) - p0[1], double(p2[2]) - p0[2]};
              n[0] = a1[1] * a2[2] - a1[2] * a2[1];
              n[1] = a1[2] * a2[0] - a1[0] * a2[2];
              n[2] = a1[0] * a2[1] - a1[1] * a2[0];
            }
            const auto& nm = normal_mats[v.instance];
            double wn[3];
            for (int r = 0; r < 3; ++r) wn[r] = nm[r][0] * n[0] + nm[r][1] * n[1] + nm[r][2] * n[2];
            double nl = std::sqrt(wn[0] * wn[0] + wn[1] * wn[1] + wn[2] * wn[2]);
            double lambert = nl > 0 ? std::max(0.0, (wn[0] * lx + wn[1] * ly + wn[2] * lz) / nl) : 0.0;
            uint32_t mat = dag.triangle_materials.empty() ? 0 : dag.triangle_materials[c.triangle_offset + tri];
            std::array<float, 4> base{0.8f, 0.8f, 0.8f, 1};
            if (mat < in.materials->size()) base = (*in.materials)[mat].base_color;
            if (scene_lights) {
              double f;
              const Vec3d sp = shadow_sample_point(view, view_to_world, x, uint32_t(y), vis_key_depth(key), &f);
              double un[3] = {0, 0, 0};
              if (nl > 0)
                for (int a = 0; a < 3; ++a) un[a] = wn[a] / nl;
              std::array<double, 3> sum = sum_lights(*in.lights, in.shadows, screen, x, uint32_t(y), sp, f, un);
              col = {base[0] * float(in.ambient + (1 - in.ambient) * sum[0]),
                     base[1] * float(in.ambient + (1 - in.ambient) * sum[1]),
                     base[2] * float(in.ambient + (1 - in.ambient) * sum[2])};
            } else {
              float k = float(in.ambient + (1 - in.ambient) * lambert);
              col = {base[0] * k, base[1] * k, base[2] * k};
            }
          }
        }
      }
      uint8_t* o = out->rgb.data() + 3 * p;
      o[0] = to_srgb8(srgb, col.r);
      o[1] = to_srgb8(srgb, col.g);
      o[2] = to_srgb8(srgb, col.b);
    }
  });
}

}  // namespace vgeo
