#pragma once
// What the lod/scaling/stability suites need around lib/vgeo/render's frame pipeline
// (lib/vgeo/render/frame.h render_frame) that lib/vgeo/render does not provide: placement and camera
// shorthands, and the image-difference metric between two frames of the same view.
#include <cstdint>
#include <initializer_list>

#include "vgeo/render/frame.h"

namespace vgeo::bench {

// The full-detail reference cut: tau = 0 selects every cluster whose own error is 0 (the
// leaves; coarser clusters only where simplification was exactly lossless) under a parent
// with error > 0, i.e. the zero-error surface.
constexpr float kFullDetailTau = 0.0f;

// Translation + uniform scale (the suites place instances; rotation adds nothing to measure).
CullInstance placed_instance(uint32_t mesh, Vec3d translation, double scale = 1);

// Camera at `eye` looking at `target` (`up` not parallel to the view direction).
Camera look_at_camera(Vec3d eye, Vec3d target, Vec3d up, uint32_t width, uint32_t height, double z_near = 0.01);

// Image error of `test` against `reference` of the same view.
struct ImageError {
  double mean_abs = 0, max_abs = 0;  // shaded sRGB difference per channel, 0..255
  double surface_differs = 0;        // share of pixels: coverage differs or depth differs > tolerance
};
ImageError compare_frames(const Frame& test, const Frame& reference);

// Sum of the wall times (ms) of the named passes of one frame; passes that did not run count 0.
double passes_ms(const FrameStats& stats, std::initializer_list<const char*> names);

// The occlusion scene (occlusion and backend suites): side x side instances of one generated
// sphere DAG (`triangles`, seed 9) in rows kSphereRowSpacing apart, and a camera at eye level
// with the rows, so each row hides most of the next and the occlusion passes find work.
// Spheres of radius ~1 this far apart: neighbours nearly touch, so rows hide rows behind.
constexpr double kSphereRowSpacing = 2.2;
RenderScene sphere_rows_scene(uint32_t side, uint32_t triangles, unsigned threads);
Camera sphere_rows_camera(uint32_t side, uint32_t width, uint32_t height);

}  // namespace vgeo::bench
