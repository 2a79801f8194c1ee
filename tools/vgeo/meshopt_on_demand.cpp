// The meshoptimizer entry points the executable calls, loaded on the first call (dlopen of the
// library the build linked against) instead of at process start. libmeshoptimizer is a C++
// library: mapping it maps libstdc++.so too, ~0.9 MiB of text and relocated data (the
// executable's own C++ runtime is linked statically, tools/CMakeLists.txt). A build calls
// meshoptimizer first when it simplifies the first level, after the leaf pass, whose heap is
// the peak of a small mesh's build and is returned before (dag/build.cpp release_free_heap): the
// two libraries then no longer add to that peak (armadillo .vgeodag -0.9 MiB;
// docs/acceptance/issue23_smallrss.md). The installed libvgeo.so links meshoptimizer as before;
// only the executable defines these forwarders, with the header's declarations, so a signature
// that changes fails to compile. The same idea as the Vulkan loader's table (gpu/context.h).
#include <dlfcn.h>

#include <meshoptimizer.h>

#include <mutex>
#include <string>

#include "vgeo/core/error.h"
#include "vgeo/core/shared_library.h"

namespace {

// The C entry points' types (the header also declares C++ template overloads of three of them).
using SimplifyFn = size_t (*)(unsigned int*, const unsigned int*, size_t, const float*, size_t, size_t, size_t, float,
                              unsigned int, float*);
using BuildMeshletsFn = size_t (*)(meshopt_Meshlet*, unsigned int*, unsigned char*, const unsigned int*, size_t,
                                   const float*, size_t, size_t, size_t, size_t, float);
using EncodeIndexBufferFn = size_t (*)(unsigned char*, size_t, const unsigned int*, size_t);

struct MeshoptFunctions {
  SimplifyFn simplify = nullptr;
  decltype(&meshopt_simplifyScale) simplify_scale = nullptr;
  BuildMeshletsFn build_meshlets = nullptr;
  decltype(&meshopt_buildMeshletsBound) build_meshlets_bound = nullptr;
  EncodeIndexBufferFn encode_index_buffer = nullptr;
  decltype(&meshopt_encodeIndexBufferBound) encode_index_buffer_bound = nullptr;
  decltype(&meshopt_encodeVertexBuffer) encode_vertex_buffer = nullptr;
  decltype(&meshopt_encodeVertexBufferBound) encode_vertex_buffer_bound = nullptr;
};

template <typename F>
bool look_up(void* library, const char* name, F& f) {
  f = reinterpret_cast<F>(dlsym(library, name));
  return f != nullptr;
}

const MeshoptFunctions& meshopt() {
  static constexpr const char* kLibrary = VGEO_MESHOPT_SONAME;  // the soname the build linked against
  // An empty name would open the executable itself, whose forwarders these are.
  static_assert(sizeof(VGEO_MESHOPT_SONAME) > 1, "meshoptimizer's soname is unknown (tools/CMakeLists.txt)");
  static std::once_flag once;
  static MeshoptFunctions functions;
  static std::string failure;
  std::call_once(once, [] {
    const vgeo::OpenedLibrary opened = vgeo::open_shared_library(kLibrary, "meshoptimizer");
    if (!opened.handle) {
      failure = opened.failure;
      return;
    }
    void* l = opened.handle;
    MeshoptFunctions f;
    const bool all = look_up(l, "meshopt_simplify", f.simplify) && look_up(l, "meshopt_simplifyScale", f.simplify_scale) &&
                     look_up(l, "meshopt_buildMeshlets", f.build_meshlets) &&
                     look_up(l, "meshopt_buildMeshletsBound", f.build_meshlets_bound) &&
                     look_up(l, "meshopt_encodeIndexBuffer", f.encode_index_buffer) &&
                     look_up(l, "meshopt_encodeIndexBufferBound", f.encode_index_buffer_bound) &&
                     look_up(l, "meshopt_encodeVertexBuffer", f.encode_vertex_buffer) &&
                     look_up(l, "meshopt_encodeVertexBufferBound", f.encode_vertex_buffer_bound);
    if (all)
      functions = f;
    else
      failure = std::string(kLibrary) + " lacks a meshoptimizer entry point";
  });
  if (!failure.empty())
    vgeo::fail("MODULE_UNAVAILABLE", "meshoptimizer", failure + " (tools/setup installs libmeshoptimizer)",
               vgeo::kExitUsage);
  return functions;
}

}  // namespace

size_t meshopt_simplify(unsigned int* destination, const unsigned int* indices, size_t index_count,
                        const float* vertex_positions, size_t vertex_count, size_t vertex_positions_stride,
                        size_t target_index_count, float target_error, unsigned int options, float* result_error) {
  return meshopt().simplify(destination, indices, index_count, vertex_positions, vertex_count, vertex_positions_stride,
                            target_index_count, target_error, options, result_error);
}

float meshopt_simplifyScale(const float* vertex_positions, size_t vertex_count, size_t vertex_positions_stride) {
  return meshopt().simplify_scale(vertex_positions, vertex_count, vertex_positions_stride);
}

size_t meshopt_buildMeshlets(meshopt_Meshlet* meshlets, unsigned int* meshlet_vertices, unsigned char* meshlet_triangles,
                             const unsigned int* indices, size_t index_count, const float* vertex_positions,
                             size_t vertex_count, size_t vertex_positions_stride, size_t max_vertices,
                             size_t max_triangles, float cone_weight) {
  return meshopt().build_meshlets(meshlets, meshlet_vertices, meshlet_triangles, indices, index_count, vertex_positions,
                                  vertex_count, vertex_positions_stride, max_vertices, max_triangles, cone_weight);
}

size_t meshopt_buildMeshletsBound(size_t index_count, size_t max_vertices, size_t max_triangles) {
  return meshopt().build_meshlets_bound(index_count, max_vertices, max_triangles);
}

size_t meshopt_encodeIndexBuffer(unsigned char* buffer, size_t buffer_size, const unsigned int* indices,
                                 size_t index_count) {
  return meshopt().encode_index_buffer(buffer, buffer_size, indices, index_count);
}

size_t meshopt_encodeIndexBufferBound(size_t index_count, size_t vertex_count) {
  return meshopt().encode_index_buffer_bound(index_count, vertex_count);
}

size_t meshopt_encodeVertexBuffer(unsigned char* buffer, size_t buffer_size, const void* vertices, size_t vertex_count,
                                  size_t vertex_size) {
  return meshopt().encode_vertex_buffer(buffer, buffer_size, vertices, vertex_count, vertex_size);
}

size_t meshopt_encodeVertexBufferBound(size_t vertex_count, size_t vertex_size) {
  return meshopt().encode_vertex_buffer_bound(vertex_count, vertex_size);
}
