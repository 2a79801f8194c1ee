#pragma once
// The table of the vgeo_extras module (tools/CMakeLists.txt): the parts of libvgeo that need a
// heavy dependency only a few commands use, built from the same sources into a module that the
// `vgeo` executable loads only when a command calls one of them:
//   OpenMesh  - Loop subdivision (`gen --subdivide`), the OpenMesh simplifier (`--simplifier openmesh`);
//   tinygltf  - the glTF/GLB reader (importing a .gltf/.glb file; tinygltf also loads stb);
//   libpng    - PNG output (`render --png`, reference images, bench figures).
// A process that calls none of them (a `vgeo build` of an OBJ/PLY/OFF/STL mesh) maps none of these
// libraries nor runs their load-time initializers (OpenMesh registers every reader and writer
// it has): measured in docs/acceptance/issue23_small.md. libvgeo.so links the same code directly.
#include <cstdint>
#include <string>
#include <vector>

#include "vgeo/dag/simplify_openmesh.h"
#include "vgeo/mesh/import.h"
#include "vgeo/mesh/subdivide.h"
#include "vgeo/shade/shade.h"

namespace vgeo {

// Bumped whenever the table or a signature in it changes: a module from another build is
// refused with a message instead of being called through the wrong types.
inline constexpr uint32_t kExtrasModuleAbi = 1;

struct ExtrasModule {
  uint32_t abi = kExtrasModuleAbi;
  uint32_t table_size = sizeof(ExtrasModule);
  Mesh (*subdivide_loop)(const Mesh&, const SubdivideOptions&) = nullptr;
  build_detail::SimplifyResult (*simplify_openmesh)(const build_detail::WeldedMesh&, const build_detail::TriangleSet&,
                                                    const std::vector<uint8_t>&,
                                                    const build_detail::SimplifyTarget&) = nullptr;
  void (*import_gltf)(const uint8_t*, size_t, std::vector<uint8_t>*, bool, const std::string&, const std::string&,
                      bool, ImportResult&) = nullptr;
  void (*write_png)(const std::string&, const Image&) = nullptr;
};

}  // namespace vgeo

// The module's one exported entry point (C linkage: no mangled name to look up).
extern "C" const vgeo::ExtrasModule* vgeo_extras_module();
