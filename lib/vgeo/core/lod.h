#pragma once
// Based on: Karis, Stubbe, Wihlidal, "Nanite: A Deep Dive", SIGGRAPH 2021 Advances in
// Real-Time Rendering (LOD by projected error: a cluster is drawn when its own error is small
// and its parent's is not).
// The LOD test shared by the builder's checks, lib/vgeo/verify and the runtime (one
// implementation, spec/invariants.md §LOD). Error is projected from the point of the
// sphere nearest to the eye: err * scale / max(d - r, z_near). Properties relied upon:
//  - monotonic: if sphere A ⊇ sphere B and err_A ≥ err_B then proj(A) ≥ proj(B) for
//    every eye (triangle inequality; the max() with z_near preserves order);
//  - finite: the denominator is ≥ z_near > 0, also with the eye inside the sphere.
#include <cmath>

#include "vgeo/core/math.h"

namespace vgeo {

struct LodView {
  Vec3 eye;              // in the same space as the spheres
  float pixels_per_unit_at_1 = 1.0f;  // 0.5 * viewport_height / tan(fov_y / 2)
  float z_near = 0.01f;  // > 0
};

inline float lod_projection_scale(float fov_y_radians, float viewport_height_px) {
  return 0.5f * viewport_height_px / std::tan(0.5f * fov_y_radians);
}

// Projected error in pixels. +inf error stays +inf (terminal groups never refine away).
inline float projected_error(const Sphere& bounds, float error, const LodView& view) {
  if (error == 0.0f) return 0.0f;
  double d = distance_d(bounds.center, view.eye) - double(bounds.radius);
  if (!(d > view.z_near)) d = view.z_near;  // also catches NaN distance
  return float(double(error) * view.pixels_per_unit_at_1 / d);
}

// Draw a cluster iff its parent is too coarse and it is fine enough (Nanite's local cut),
// on already projected errors: the one cut predicate (lod_selects, lib/vgeo/verify, the
// resident rule of spec/stream.md §Cut).
// Its two halves are named so the verifier's sibling checks (every member of a group decides
// the parent test alike, every generated cluster the lod test alike) use the same comparisons.
inline bool parent_too_coarse(float projected_parent_px, float threshold_px) {
  return projected_parent_px > threshold_px;
}
inline bool fine_enough(float projected_lod_px, float threshold_px) { return projected_lod_px <= threshold_px; }
inline bool cut_selects(float projected_parent_px, float projected_lod_px, float threshold_px) {
  return parent_too_coarse(projected_parent_px, threshold_px) && fine_enough(projected_lod_px, threshold_px);
}

inline bool lod_selects(const Sphere& lod_bounds, float lod_error, const Sphere& parent_bounds,
                        float parent_error, const LodView& view, float threshold_px) {
  return cut_selects(projected_error(parent_bounds, parent_error, view), projected_error(lod_bounds, lod_error, view),
                     threshold_px);
}

}  // namespace vgeo
