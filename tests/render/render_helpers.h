#pragma once
// Small render scenes for pipeline tests (meshes from tests/support/shapes.h and
// lib/vgeo/mesh/generate.h, DAGs from build_dag).
#include <cmath>
#include <cstring>
#include <vector>

#include "support/shapes.h"
#include "vgeo/dag/build.h"
#include "vgeo/mesh/generate.h"
#include "vgeo/render/frame.h"

namespace vgeo::test {

inline Mat4d translate_scale(double x, double y, double z, double s) {
  Mat4d m;
  m.at(0, 0) = m.at(1, 1) = m.at(2, 2) = s;
  m.at(0, 3) = x;
  m.at(1, 3) = y;
  m.at(2, 3) = z;
  return m;
}

inline Camera look_camera(Vec3d eye, Vec3d target, uint32_t w = 160, uint32_t h = 120, double z_near = 0.01) {
  Camera c;
  c.position = eye;
  c.width = w;
  c.height = h;
  c.z_near = z_near;
  if (!look_at_orientation(eye, target, {0, 1, 0}, &c.orientation)) c.orientation = {0, 0, 0, 1};
  return c;
}

// A row of displaced spheres on a terrain ground, spaced so that they occlude each other
// when seen along the row. `scale` scales the whole scene, `offset` moves it.
inline RenderScene make_row_scene(double scale = 1.0, double offset = 0.0, uint32_t spheres = 5) {
  RenderScene s;
  s.materials = {Material{"a", {0.8f, 0.3f, 0.2f, 1}}, Material{"b", {0.2f, 0.6f, 0.3f, 1}}};
  BuildOptions bo;
  bo.threads = 1;
  GenerateOptions gen;
  gen.shape = GenShape::kSphere;
  gen.target_triangles = 2304;  // as many as a 24 x 48 UV sphere
  Mesh sphere = generate_mesh(gen);
  sphere.materials.assign(sphere.triangle_count(), 0);
  gen.shape = GenShape::kTerrain;
  gen.target_triangles = 2048;
  Mesh ground = generate_mesh(gen);
  ground.materials.assign(ground.triangle_count(), 1);
  s.meshes.push_back(build_dag(sphere, bo));
  s.meshes.push_back(build_dag(ground, bo));
  // The [-1,1]^2 terrain (heights within about ±0.25) as a 30 x 30 ground with ±0.2 bumps.
  Mat4d ground_to_world = translate_scale(offset, 0, offset, 15.0 * scale);
  ground_to_world.at(1, 1) = 0.8 * scale;
  s.instances.push_back({1, ground_to_world});
  for (uint32_t i = 0; i < spheres; ++i)
    s.instances.push_back({0, translate_scale(offset, 1.2 * scale, offset - 3.0 * i * scale, scale)});
  analyze_render_scene(&s);
  return s;
}

// Per-pixel (instance, cluster, triangle, depth): what a visibility buffer means,
// independent of visible-cluster numbering.
struct DecodedPixel {
  uint32_t instance = kNone, cluster = kNone, triangle = 0, depth_bits = 0;
  bool operator==(const DecodedPixel&) const = default;
};
inline std::vector<DecodedPixel> decode(const Frame& f) {
  std::vector<DecodedPixel> out(f.vis.keys.size());
  for (size_t p = 0; p < out.size(); ++p) {
    uint64_t k = f.vis.keys[p];
    if (!k) continue;
    const VisibleCluster& v = f.visible[vis_key_cluster(k)];
    out[p] = {v.instance, v.cluster, vis_key_triangle(k), uint32_t(k >> 32)};
  }
  return out;
}

}  // namespace vgeo::test
