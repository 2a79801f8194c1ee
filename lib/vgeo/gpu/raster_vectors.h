#pragma once
// Raster conformance vectors (spec/raster.md §14, spec/vectors/raster/): small triangle
// sets with the expected visibility key of every pixel (8 sub-pixel bits, top-left rule, the
// CPU reference's kReference loop) and a per-pixel ambiguity mask for hardware rasterizers.
// The triangles are stored in their decoded memory form (canonical vertex/triangle order,
// quantized positions), so a key's (cluster, triangle) names a triangle of the file.
#include <cstdint>
#include <string>
#include <vector>

#include "vgeo/core/math.h"
#include "vgeo/gpu/gpu_frame.h"
#include "vgeo/raster/hw_rule.h"

namespace vgeo {

// Mask bits per pixel.
inline constexpr uint8_t kRasterMaskDepth = 1;      // two surfaces within their §10 depth tolerances
inline constexpr uint8_t kRasterMaskClipEdge = 2;   // centre within δ of a clipped triangle's exact outline
inline constexpr uint8_t kRasterMaskEdge = 4;       // centre within δ of an unclipped triangle's exact outline

struct RasterVectorCluster {
  std::vector<float> positions;   // 3 per vertex (object space)
  std::vector<uint8_t> indices;   // 3 per triangle
};

struct RasterVector {
  std::string name, description;
  uint32_t width = 16, height = 16;
  float z_near = 0.01f;
  bool cull_backfaces = true;
  // Every vertex maps to clip space exactly in float (w = 1, dyadic coordinates): a float32
  // implementation then snaps exactly as the reference, and kRasterMaskEdge pixels must match.
  bool exact_transform = false;
  Mat4 object_to_clip;
  std::vector<RasterVectorCluster> clusters;  // visible-cluster index = position here
  std::vector<uint64_t> keys;                 // width · height, row-major, 0 = background
  std::vector<uint8_t> mask;                  // width · height, kRasterMask* bits
};

// The committed set (deterministic): random, slivers, fan, grid, huge, subpixel,
// pixel_centres, z_fight, near_plane, guard_band. Keys and masks filled.
std::vector<RasterVector> make_raster_vectors();

// The vector's geometry as a one-mesh, one-instance scene (flat DAG: every cluster a leaf
// root) and its memory form; `canonicalize` replaces the clusters by their decoded form.
RenderScene raster_vector_scene(const RasterVector& v);
// The same for any clusters (at most 64; `vgeo bench raster` draws its GPU samples from it).
RenderScene flat_cluster_scene(const std::vector<RasterVectorCluster>& clusters, const std::string& where);
void canonicalize_raster_vector(RasterVector* v);
// CPU reference keys (kReference loop) and the mask.
void compute_raster_vector_expected(RasterVector* v);
// The model triangle of (cluster, triangle) (hw_rule.h).
ModelTriangle raster_vector_triangle(const RasterVector& v, uint32_t cluster, uint32_t triangle);

std::string write_raster_vector(const RasterVector& v);
// Throws VgeoError RASTER_VECTOR_PARSE (exit 2) on malformed text.
RasterVector parse_raster_vector(const std::string& text, const std::string& where);

}  // namespace vgeo
