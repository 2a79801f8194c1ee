#pragma once
// The table of the vgeo_openmesh module (tools/CMakeLists.txt): the OpenMesh code of libvgeo
// (Loop subdivision, the OpenMesh simplification backend), built from the same sources into a
// module that the `vgeo` executable loads only when a command asks for it (`gen --subdivide`,
// `build --simplifier openmesh`). A process that never does so does not map OpenMesh, nor run
// its load-time registration of every OpenMesh reader and writer (1.6 MiB of RSS, 0.5 ms per
// process: docs/acceptance/issue23_small.md). libvgeo.so links the same code directly.
#include <cstdint>
#include <vector>

#include "vgeo/dag/simplify_openmesh.h"
#include "vgeo/mesh/subdivide.h"

namespace vgeo {

// Bumped whenever the table or a signature in it changes: a module from another build is
// refused with a message instead of being called through the wrong types.
inline constexpr uint32_t kOpenMeshModuleAbi = 1;

struct OpenMeshModule {
  uint32_t abi = kOpenMeshModuleAbi;
  uint32_t table_size = sizeof(OpenMeshModule);
  Mesh (*subdivide_loop)(const Mesh&, const SubdivideOptions&) = nullptr;
  build_detail::SimplifyResult (*simplify_openmesh)(const build_detail::WeldedMesh&, const build_detail::TriangleSet&,
                                                    const std::vector<uint8_t>&,
                                                    const build_detail::SimplifyTarget&) = nullptr;
};

}  // namespace vgeo

// The module's one exported entry point (C linkage: no mangled name to look up).
extern "C" const vgeo::OpenMeshModule* vgeo_openmesh_module();
