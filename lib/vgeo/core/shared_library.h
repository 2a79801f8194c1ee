#pragma once
// Shared libraries opened on first use (dlopen): the optional dependencies that only some
// commands need (the Vulkan loader, METIS, the vgeo_extras module), so that a build never maps
// them (docs/acceptance/issue23_rss.md). One place for the open and its message; each caller
// looks up its own symbols and raises its own error code.
#include <string>

namespace vgeo {

struct OpenedLibrary {
  void* handle = nullptr;  // null: not opened, see `failure`
  std::string failure;     // "cannot load WHAT (the loader's reason)"
};
// dlopen(path, RTLD_NOW | RTLD_LOCAL); never closed: the symbols stay callable until exit.
// `what` names the library in the failure message.
OpenedLibrary open_shared_library(const std::string& path, const std::string& what);

}  // namespace vgeo
