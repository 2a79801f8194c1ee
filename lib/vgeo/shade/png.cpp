#include <png.h>

#include <csetjmp>
#include <vector>

#include "vgeo/core/error.h"
#include "vgeo/core/file_io.h"
#include "vgeo/shade/shade.h"

namespace vgeo {
namespace {

// libpng writes into memory; the file is then written atomically (lib/vgeo/core/file_io.h),
// so a failed or interrupted render never leaves a truncated PNG at the path.
void append_to_buffer(png_structp png, png_bytep data, png_size_t size) {
  auto* out = static_cast<std::vector<uint8_t>*>(png_get_io_ptr(png));
  out->insert(out->end(), data, data + size);
}
void flush_nothing(png_structp) {}

}  // namespace

void write_png(const std::string& path, const Image& image) {
  std::vector<uint8_t> bytes;
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png ? png_create_info_struct(png) : nullptr;
  if (!png || !info || setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    fail(kErrFileWrite, path, "libpng failed to encode the image", kExitIo);
  }
  png_set_write_fn(png, &bytes, append_to_buffer, flush_nothing);
  png_set_IHDR(png, info, image.width, image.height, 8, PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE,
               PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  for (uint32_t y = 0; y < image.height; ++y)
    png_write_row(png, const_cast<png_bytep>(image.rgb.data() + size_t(y) * image.width * 3));
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  write_file_atomic(path, bytes.data(), bytes.size());
}

}  // namespace vgeo
