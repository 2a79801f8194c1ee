#include "bench_render.h"

#include <algorithm>
#include <cassert>
#include <cmath>

#include "bench_shapes.h"
#include "vgeo/cull/view.h"
#include "vgeo/dag/build.h"

namespace vgeo::bench {
namespace {

// A pixel's visible surface "differs" when its depth differs by more than this fraction
// (1%: far above LOD displacement at tau ≤ 1 px, so it flags a different surface, not a shifted one).
constexpr double kSurfaceDepthTolerance = 0.01;

}  // namespace

CullInstance placed_instance(uint32_t mesh, Vec3d translation, double scale) {
  CullInstance in;
  in.mesh = mesh;
  for (int i = 0; i < 3; ++i) in.object_to_world.at(i, i) = scale;
  in.object_to_world.at(0, 3) = translation.x;
  in.object_to_world.at(1, 3) = translation.y;
  in.object_to_world.at(2, 3) = translation.z;
  return in;
}

Camera look_at_camera(Vec3d eye, Vec3d target, Vec3d up, uint32_t width, uint32_t height, double z_near) {
  Camera c;
  c.position = eye;
  c.width = width;
  c.height = height;
  c.z_near = z_near;
  [[maybe_unused]] bool ok = look_at_orientation(eye, target, up, &c.orientation);
  assert(ok && "bench camera: view direction zero or parallel to up");
  return c;
}

ImageError compare_frames(const Frame& test, const Frame& ref) {
  ImageError e;
  size_t pixels = std::min({test.image.rgb.size() / 3, ref.image.rgb.size() / 3, test.vis.keys.size(), ref.vis.keys.size()});
  if (pixels == 0) return e;
  double sum = 0;
  uint64_t differs = 0;
  for (size_t i = 0; i < pixels; ++i) {
    for (size_t ch = 0; ch < 3; ++ch) {
      double d = std::fabs(double(test.image.rgb[3 * i + ch]) - double(ref.image.rgb[3 * i + ch]));
      sum += d;
      e.max_abs = std::max(e.max_abs, d);
    }
    uint64_t ka = test.vis.keys[i], kb = ref.vis.keys[i];
    if ((ka == 0) != (kb == 0)) {
      ++differs;
    } else if (ka != 0) {
      // NDC depth = z_near / view depth: the relative difference is the same in both.
      double da = vis_key_depth(ka), db = vis_key_depth(kb);
      if (std::fabs(da - db) > kSurfaceDepthTolerance * db) ++differs;
    }
  }
  e.mean_abs = sum / double(3 * pixels);
  e.surface_differs = double(differs) / double(pixels);
  return e;
}

double passes_ms(const FrameStats& stats, std::initializer_list<const char*> names) {
  double ms = 0;
  for (const char* n : names)
    if (const PassStats* p = stats.find(n)) ms += p->ms;
  return ms;
}

RenderScene sphere_rows_scene(uint32_t side, uint32_t triangles, unsigned threads) {
  RenderScene scene;
  BuildOptions bo;
  bo.threads = threads;
  scene.meshes.push_back(build_dag(make_shape(Shape::kSphere, triangles, 9), bo, nullptr));
  scene.materials.push_back(Material{});
  for (uint32_t z = 0; z < side; ++z)
    for (uint32_t x = 0; x < side; ++x) {
      CullInstance in;
      in.mesh = 0;
      in.object_to_world.at(0, 3) = (double(x) - 0.5 * (side - 1)) * kSphereRowSpacing;
      in.object_to_world.at(2, 3) = -double(z) * kSphereRowSpacing;
      scene.instances.push_back(in);
    }
  analyze_render_scene(&scene);
  return scene;
}

Camera sphere_rows_camera(uint32_t side, uint32_t width, uint32_t height) {
  Camera cam;
  cam.width = width;
  cam.height = height;
  cam.position = {0, 0.3, 4.0};  // eye level with the spheres: each row hides most of the next
  look_at_orientation(cam.position, {0, 0.3, -double(side) * kSphereRowSpacing * 0.5}, {0, 1, 0}, &cam.orientation);
  return cam;
}

}  // namespace vgeo::bench
