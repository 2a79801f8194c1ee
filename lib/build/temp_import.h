#pragma once
// TEMPORARY (until lib/mesh/import.h lands): reads OFF (own parser) and OBJ/PLY/STL (via
// OpenMesh) into a one-mesh Scene for `vgeo build` and the builder's benchmarks/tests.
// The lead replaces its uses with vgeo::import_scene and deletes this file.
#include <string>

#include "vgeo/mesh/mesh.h"

namespace vgeo::build_detail {

// Throws VgeoError: IMPORT_IO (exit 4), IMPORT_BAD_FILE / IMPORT_UNSUPPORTED (exit 3).
Scene read_mesh_file_temporary(const std::string& path);

}  // namespace vgeo::build_detail
