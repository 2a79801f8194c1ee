// libFuzzer target for one OBJ/PLY/OFF/STL reader: built once per format, the format chosen by
// the extension VGEO_FUZZ_EXTENSION (fuzz/CMakeLists.txt) passed to the memory import.
#include <string>

#include "vgeo/core/error.h"
#include "vgeo/mesh/import.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  try {
    (void)vgeo::import_scene_from_memory(data, size, "fuzz." VGEO_FUZZ_EXTENSION, vgeo::ImportOptions{});
  } catch (const vgeo::VgeoError&) {
  }
  return 0;
}
