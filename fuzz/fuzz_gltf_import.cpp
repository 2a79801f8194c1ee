// libFuzzer target for the glTF importer (built only when lib/vgeo/mesh/import.h exists).
#include <string>

#include "vgeo/core/error.h"
#include "vgeo/mesh/import.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  try {
    (void)vgeo::import_scene_from_memory(data, size, "fuzz.glb", vgeo::ImportOptions{});
  } catch (const vgeo::VgeoError&) {
  }
  return 0;
}
