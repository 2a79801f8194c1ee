#pragma once
// Procedural meshes for scenes that need no files (the embedded default scene, tests):
// deterministic, closed where stated, counter-clockwise front faces, with normals and UVs.
#include <cstdint>

#include "vgeo/mesh/mesh.h"

namespace vgeo {

// Upper bound on generated triangles (memory bound for untrusted scene parameters):
// 4M triangles ≈ 150 MB of DAG, far above any default scene.
inline constexpr uint64_t kMaxProceduralTriangles = 1u << 22;

// Closed UV sphere (poles welded) of `rings` x `segments`, radius scaled per vertex by
// 1 + amplitude · d(direction), d a smooth sum of sines of spatial frequency `frequency`.
// amplitude 0 gives a plain (convex) sphere.
Mesh make_displaced_sphere(uint32_t rings, uint32_t segments, float radius, float amplitude, float frequency);

// n x n quads in the XZ plane centred at the origin (y up), size `size`, heights
// amplitude · smooth noise (frequency in waves per size).
Mesh make_ground_grid(uint32_t n, float size, float amplitude, float frequency);

}  // namespace vgeo
