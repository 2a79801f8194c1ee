#pragma once
// Exact vertex weld: vertices whose position, normal and uv compare equal (as float values, so
// -0 == +0; the importer has already rejected NaN) become one. Deterministic: the surviving
// vertex of each class is its first occurrence in triangle order, and output vertices are
// numbered in order of first reference, so the result depends only on the input arrays.
#include <cstddef>

#include "vgeo/mesh/mesh.h"

namespace vgeo {

// Welds `mesh` in place and drops vertices no triangle references. Returns how many vertices
// were removed (old vertex count - new vertex count).
size_t weld_exact(Mesh& mesh);

}  // namespace vgeo
