#include "vgeo/core/shared_library.h"

#include <dlfcn.h>

namespace vgeo {

OpenedLibrary open_shared_library(const std::string& path, const std::string& what) {
  OpenedLibrary opened;
  opened.handle = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (!opened.handle) {
    const char* why = dlerror();
    opened.failure = "cannot load " + what + " (" + (why ? std::string(why) : path) + ")";
  }
  return opened;
}

}  // namespace vgeo
