#pragma once
// The OpenMesh simplification backend (`--simplifier openmesh`), in its own source file so the
// `vgeo` executable can leave OpenMesh out of every process that does not ask for it: the CLI
// loads it from the vgeo_extras module on first use (tools/modules/extras_module.h), while
// libvgeo.so links it directly.
#include <cstddef>
#include <cstdint>
#include <vector>

#include "vgeo/dag/build_internal.h"

namespace vgeo::build_detail {

// Triangles a simplification of n triangles aims for at `ratio` (at least one); shared by both
// backends (simplify.cpp).
size_t target_triangles(size_t n, double ratio);

// One OpenMesh vertex per welded position of the group; material is a face property, so
// material borders move but never open. Faces OpenMesh cannot add (complex edges,
// non-manifold vertices) pass through unchanged and lock their vertices. (The error is
// measured by the builder against the leaves: leaf_error.cpp.)
SimplifyResult simplify_openmesh(const WeldedMesh& welded, const TriangleSet& group,
                                 const std::vector<uint8_t>& locked, const SimplifyTarget& target);

}  // namespace vgeo::build_detail
