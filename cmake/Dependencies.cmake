# All third-party libraries come from Debian packages (tools/setup installs them).
# They are linked privately into libvgeo through one interface target, so public
# headers never expose a third-party type and consumers need none of them.
find_package(meshoptimizer REQUIRED)
find_package(TinyGLTF REQUIRED)
find_package(OpenMesh REQUIRED)
find_package(PkgConfig REQUIRED)
find_package(PNG REQUIRED)
find_package(nlohmann_json REQUIRED)
find_package(Vulkan REQUIRED)
find_library(METIS_LIBRARY metis REQUIRED)
find_path(METIS_INCLUDE_DIR metis.h REQUIRED)
pkg_check_modules(ZSTD REQUIRED IMPORTED_TARGET libzstd)
pkg_check_modules(LZ4 REQUIRED IMPORTED_TARGET liblz4)

add_library(vgeo_deps INTERFACE)
target_include_directories(vgeo_deps INTERFACE ${METIS_INCLUDE_DIR})
target_link_libraries(vgeo_deps INTERFACE
  meshoptimizer::meshoptimizer TinyGLTF::TinyGLTF OpenMeshCore OpenMeshTools
  PkgConfig::ZSTD PkgConfig::LZ4 PNG::PNG nlohmann_json::nlohmann_json Vulkan::Headers ${CMAKE_DL_LIBS})
# Vulkan and METIS: headers only; lib/vgeo/gpu/context.cpp opens the Vulkan loader and
# lib/vgeo/dag/group.cpp libmetis on first use (METIS_LIBRARY: configure checks it is installed).
# OpenMesh's headers need _USE_MATH_DEFINES on some platforms; harmless here.
target_compile_definitions(vgeo_deps INTERFACE _USE_MATH_DEFINES)
