#pragma once
// Deferred shading of the visibility buffer (Nanite deep dive, "Visibility Buffer recap"):
// per pixel, key → visible cluster → (instance, cluster), triangle → its 3 vertices in view
// space → perspective-correct barycentrics (ray/triangle-plane intersection through the
// pixel centre: exact, and finite for triangles that cross the near plane) → interpolated
// normal → material colour × (ambient + Lambert). Debug views colour ids instead.
#include <cstdint>
#include <string>
#include <vector>

#include "vgeo/dag/cluster_dag.h"
#include "vgeo/core/thread_pool.h"
#include "vgeo/cull/cull.h"
#include "vgeo/raster/visbuffer.h"
#include "vgeo/shadow/light.h"
#include "vgeo/shadow/virtual_shadow.h"

namespace vgeo {

enum class ShadeView : uint8_t { kLit, kTriangle, kCluster, kGroup, kLod, kError, kOverdraw };
bool parse_shade_view(const std::string& name, ShadeView* out);
const char* shade_view_name(ShadeView view);

struct Image {
  uint32_t width = 0, height = 0;
  std::vector<uint8_t> rgb;  // 3 bytes per pixel, sRGB, row 0 at the top
};

struct ShadeInput {
  const VisBuffer* vis = nullptr;
  const std::vector<VisibleCluster>* visible = nullptr;  // visible-cluster index → (instance, cluster)
  const std::vector<ClusterDag>* meshes = nullptr;
  const std::vector<Material>* materials = nullptr;
  const std::vector<CullInstance>* instances = nullptr;
  const std::vector<InstanceView>* instance_views = nullptr;  // current frame
  const ViewParams* view = nullptr;
  Vec3 light_direction{0.4f, 0.8f, 0.45f};  // world space, towards the light (normalized here)
  float ambient = 0.25f;
  float threshold_px = 1.0f;                // τ, the scale of the error view
  const std::vector<uint32_t>* overdraw = nullptr;  // per pixel count (ShadeView::kOverdraw)
  // Scene lights (spec/shadow.md §2): null or empty, the fixed light_direction above; else the
  // sum over lights, each × its shadow term read from `shadows` (null: every term 1).
  const std::vector<Light>* lights = nullptr;
  const ShadowFrame* shadows = nullptr;
};

// Inverse-transpose of the 3x3 part of `m` (normals to world), scaled arbitrarily (the
// shader normalizes): the cofactor matrix, negated when det < 0. Row-major out[r][c].
void shade_normal_matrix(const Mat4d& m, double out[3][3]);

// Shades every pixel; deterministic for any thread count (pure per-pixel function).
void shade_frame(const ShadeInput& input, ShadeView view, ThreadPool& pool, Image* out);

// Writes an 8-bit RGB PNG. Throws VgeoError IO_WRITE_FAILED (exit 4).
void write_png(const std::string& path, const Image& image);

}  // namespace vgeo
