#pragma once
// Test wrappers of lib/vgeo/format/format_edit.h for the vector generator: the inputs are our
// own valid files, so a failed edit is a generator bug (thrown).
#include <stdexcept>
#include <string>

#include "format_file_edit.h"
#include "vgeo/format/format_edit.h"

namespace vgeo::test {

inline void must(bool ok, const char* what) {
  if (!ok) throw std::logic_error(std::string("format edit failed: ") + what);
}
inline void edit_meta(std::vector<uint8_t>& f, const MetadataEdit& e) { must(edit_metadata(f, e), "metadata"); }
inline void edit_page(std::vector<uint8_t>& f, uint32_t p, const std::function<void(std::vector<uint8_t>&)>& e,
                      bool raw_too = true) {
  must(edit_stored_page(f, p, e, raw_too), "page");
}
inline size_t page_at(const std::vector<uint8_t>& f, uint32_t p) {
  size_t at = 0;
  must(page_offset(f, p, &at), "page offset");
  return at;
}
inline RawPageLayout page_layout(const std::vector<uint8_t>& page, uint32_t channels) {
  RawPageLayout L;
  must(raw_page_layout(page, channels, &L), "raw page layout");
  return L;
}

}  // namespace vgeo::test
