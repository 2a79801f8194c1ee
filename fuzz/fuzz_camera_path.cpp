// libFuzzer target for the camera-path JSON file (`--camera-path`, spec/scene.md). The reader
// takes a path, so each input is written to an in-memory file (memfd) and read back through it.
#include <sys/mman.h>
#include <unistd.h>

#include <string>

#include "vgeo/core/error.h"
#include "vgeo/render/scene_file.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const int fd = memfd_create("fuzz_camera_path", 0);
  if (fd < 0) return 0;
  if (ftruncate(fd, 0) != 0 || pwrite(fd, data, size, 0) != ssize_t(size)) return 0;
  const std::string path = "/proc/self/fd/" + std::to_string(fd);
  vgeo::Camera base;
  try {
    (void)vgeo::load_camera_path_file(path, base);
  } catch (const vgeo::VgeoError&) {
  }
  return 0;
}
