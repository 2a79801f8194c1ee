#pragma once
// Densify a mesh with Loop subdivision (OpenMesh's Uniform::LoopT on a TriMesh): each
// iteration splits every triangle into four, moves old vertices by Loop's smoothing mask
// and places edge vertices by the 3/8-1/8 mask (boundary edges and vertices use the
// 1/2-1/2 and 1-6-1 curve masks, so open borders stay open and closed meshes stay closed).
//
// Topology is taken from the index buffer as given (no welding by position): a mesh with
// split vertices at UV seams gets boundary masks along the seams (both sides move
// identically, so no crack opens, but the surface is less smooth there).
//
// Output: vertices = referenced input vertices (in input order; unreferenced ones are
// dropped) followed by new edge vertices; triangles in OpenMesh's order; positions from
// Loop; normals recomputed (compute_smooth_normals); UVs carried: old vertices keep
// theirs, each edge vertex gets the midpoint of its edge's endpoints (linear, not Loop-
// smoothed: UVs are parameters, smoothing them would shear textures); materials carried
// from the parent triangle.
//
// Loop needs a 2-manifold, consistently oriented triangle mesh; anything else is rejected
// before OpenMesh sees it, with a stable code (never a crash):
//   SUBDIVIDE_INDEX_OUT_OF_RANGE, SUBDIVIDE_DEGENERATE_TRIANGLE (repeated vertex),
//   SUBDIVIDE_NON_MANIFOLD (an edge used twice in the same direction, i.e. > 2 faces or
//   inconsistent orientation, or a vertex whose triangles form more than one fan),
//   SUBDIVIDE_TOO_LARGE (result above options.max_triangles), SUBDIVIDE_EMPTY.
#include <cstdint>
#include <string>

#include "vgeo/mesh/mesh.h"

namespace vgeo {

// OpenMesh's half-edge mesh costs ~250-300 bytes per output triangle at peak; 2^25
// (33.5M) triangles stays below ~10 GB on a 23 GB box.
inline constexpr uint64_t kMaxSubdivideTriangles = uint64_t(1) << 25;

struct SubdivideOptions {
  uint32_t iterations = 1;                          // each multiplies triangles by 4
  uint64_t max_triangles = kMaxSubdivideTriangles;  // refuse bigger results up front
};

Mesh subdivide_loop(const Mesh& mesh, const SubdivideOptions& options = {});

// Throws SUBDIVIDE_* (see above) when `mesh` is not acceptable Loop input.
void check_loop_input(const Mesh& mesh, const std::string& where = "subdivide");

}  // namespace vgeo
