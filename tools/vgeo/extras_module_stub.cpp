// The `vgeo` executable's forwarding definitions of the libvgeo functions that need OpenMesh,
// tinygltf or libpng (subdivide_loop, build_detail::simplify_openmesh, detail::import_gltf,
// write_png): the executable is linked without their objects and without those libraries
// (tools/CMakeLists.txt), and the first call loads the vgeo_extras module built from those same
// objects (tools/modules/extras_module.h), so only the commands that use them pay for loading them. A missing or foreign module is a
// one-line error with a stable code (MODULE_UNAVAILABLE, spec/errors.md), never a crash.
#include <dlfcn.h>
#include <unistd.h>

#include <cerrno>
#include <climits>
#include <mutex>
#include <string>

#include "../modules/extras_module.h"
#include "vgeo/core/error.h"
#include "vgeo/core/shared_library.h"

namespace vgeo {
namespace {

constexpr const char* kErrModuleUnavailable = "MODULE_UNAVAILABLE";
constexpr const char* kModuleFile = "vgeo_extras.so";

// The module's folder relative to the executable's: the build tree and an install share the
// layout <prefix>/bin/vgeo, <prefix>/<libdir>/vgeo/ (VGEO_MODULE_DIR_FROM_BIN, set by
// tools/CMakeLists.txt from CMAKE_INSTALL_LIBDIR).
std::string module_path() {
  char exe[PATH_MAX];
  const ssize_t n = readlink("/proc/self/exe", exe, sizeof(exe) - 1);
  std::string dir = ".";
  if (n > 0) {
    dir.assign(exe, size_t(n));
    const size_t slash = dir.rfind('/');
    dir = slash == std::string::npos ? "." : dir.substr(0, slash);
  }
  return dir + "/" VGEO_MODULE_DIR_FROM_BIN "/" + kModuleFile;
}

const ExtrasModule& load_extras_module() {
  // Loaded once per process, by the first caller (the simplifier runs on worker threads);
  // never unloaded: the table's functions stay callable until exit.
  static std::once_flag once;
  static const ExtrasModule* table = nullptr;
  static std::string failure;
  static const std::string path = module_path();
  std::call_once(once, [] {
    const OpenedLibrary opened = open_shared_library(path, "the vgeo_extras module");
    if (!opened.handle) {
      failure = opened.failure;
      return;
    }
    void* handle = opened.handle;
    using Entry = const ExtrasModule* (*)();
    auto entry = reinterpret_cast<Entry>(dlsym(handle, "vgeo_extras_module"));
    const ExtrasModule* t = entry ? entry() : nullptr;
    if (!t || t->abi != kExtrasModuleAbi || t->table_size != sizeof(ExtrasModule) || !t->subdivide_loop ||
        !t->simplify_openmesh || !t->import_gltf || !t->write_png) {
      failure = "not the vgeo_extras module of this vgeo build (entry point or table mismatch)";
      return;
    }
    table = t;
  });
  if (!table) fail(kErrModuleUnavailable, path, failure, kExitUsage);
  return *table;
}

}  // namespace

Mesh subdivide_loop(const Mesh& mesh, const SubdivideOptions& options) {
  return load_extras_module().subdivide_loop(mesh, options);
}

void write_png(const std::string& path, const Image& image) { load_extras_module().write_png(path, image); }

namespace detail {

void import_gltf(const uint8_t* data, size_t size, std::vector<uint8_t>* owned_bytes, bool is_glb,
                 const std::string& where, const std::string& base_dir, bool allow_fs, ImportResult& out) {
  load_extras_module().import_gltf(data, size, owned_bytes, is_glb, where, base_dir, allow_fs, out);
}

}  // namespace detail

namespace build_detail {

SimplifyResult simplify_openmesh(const WeldedMesh& welded, const TriangleSet& group, const std::vector<uint8_t>& locked,
                                 const SimplifyTarget& target) {
  return load_extras_module().simplify_openmesh(welded, group, locked, target);
}

}  // namespace build_detail
}  // namespace vgeo
