// libFuzzer target: see fuzz/format_entries.h (memory_decode_entry).
#include "format_entries.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  vgeo::fuzz::memory_decode_entry(data, size);
  return 0;
}
