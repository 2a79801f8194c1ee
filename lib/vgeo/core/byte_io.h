#pragma once
// The one little-endian byte writer and checked byte reader of vgeo's binary files (the page
// format, its disk pages, VGEODAG1). Every field is little-endian whatever the host.
#include <bit>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "vgeo/core/error.h"
#include "vgeo/core/file_io.h"
#include "vgeo/core/math.h"

namespace vgeo {

inline uint32_t load_le32(const uint8_t* b) {
  return uint32_t(b[0]) | uint32_t(b[1]) << 8 | uint32_t(b[2]) << 16 | uint32_t(b[3]) << 24;
}
inline uint64_t load_le64(const uint8_t* b) { return load_le32(b) | uint64_t(load_le32(b + 4)) << 32; }

inline void append_le32(std::vector<uint8_t>& out, uint32_t v) {
  for (int k = 0; k < 4; ++k) out.push_back(uint8_t(v >> (8 * k)));
}

// Appends fields to `bytes`. With a `sink`, `bytes` is handed over whenever it reaches
// kFlushBytes (a raw array that would carry it past kFlushBytes hands it over first, so it never
// regrows) and large raw arrays go to the sink straight from the caller's memory (no copy of a
// multi-GB file in memory); without one everything stays in `bytes`.
struct ByteWriter {
  // 256 KiB: a few hundred system calls for a 100 MB file, and the staging memory a small
  // build touches stays small (a 1 MiB buffer that regrew to 2 MiB was 2 MiB of a 2.4 MB
  // .vgeodag's write peak; docs/acceptance/issue23_rss.md).
  static constexpr size_t kFlushBytes = size_t(256) << 10;
  std::vector<uint8_t> bytes;
  ByteSink* sink = nullptr;

  void u8(uint8_t v) { bytes.push_back(v); }
  void u32(uint32_t v) { append_le32(bytes, v); }
  void i32(int32_t v) { u32(uint32_t(v)); }
  void u64(uint64_t v) {
    u32(uint32_t(v));
    u32(uint32_t(v >> 32));
  }
  void f32(float f) { u32(std::bit_cast<uint32_t>(f)); }
  void sphere(const Sphere& s) {
    f32(s.center.x);
    f32(s.center.y);
    f32(s.center.z);
    f32(s.radius);
  }
  void raw(const void* data, size_t size) {
    if (sink && bytes.size() + size > kFlushBytes) {
      flush();
      if (size >= kFlushBytes) {
        sink->write(data, size);
        return;
      }
    }
    const auto* p = static_cast<const uint8_t*>(data);
    bytes.insert(bytes.end(), p, p + size);
    maybe_flush();
  }
  // Arrays of 32-bit values: one copy on little-endian hosts (the files are little-endian).
  template <class T>
  void array32(const T* values, size_t count) {
    static_assert(sizeof(T) == 4);
    if constexpr (std::endian::native == std::endian::little) {
      raw(values, 4 * count);
    } else {
      for (size_t i = 0; i < count; ++i) {
        u32(std::bit_cast<uint32_t>(values[i]));
        maybe_flush();
      }
    }
  }
  void maybe_flush() {
    if (sink && bytes.size() >= kFlushBytes) flush();
  }
  void flush() {
    if (!sink) return;  // in-memory encoding: everything stays in `bytes`
    if (!bytes.empty()) sink->write(bytes.data(), bytes.size());
    bytes.clear();
  }
};

// Reads fields from [data, data + size); reading past the end throws `truncated_code` at
// `where` with "<region> ends inside <what>". `where` must outlive the reader.
struct ByteReader {
  const uint8_t* data = nullptr;
  size_t size = 0, pos = 0;
  const std::string* where = nullptr;
  const char* truncated_code = "";
  const char* region = "data";

  ByteReader(const uint8_t* d, size_t n, const std::string& w, const char* code, const char* reg)
      : data(d), size(n), where(&w), truncated_code(code), region(reg) {}
  // `where` is kept by pointer (error messages only): a temporary would dangle (found by
  // ASan in AtomicWrite.StreamedAndWholeWritesProduceTheSameBytes).
  ByteReader(const uint8_t*, size_t, const std::string&&, const char*, const char*) = delete;

  size_t remaining() const { return size - pos; }
  void need(uint64_t n, const char* what) const {
    if (n > remaining()) fail(truncated_code, *where, std::string(region) + " ends inside " + what);
  }
  const uint8_t* take(size_t n, const char* what = "a field") {
    need(n, what);
    const uint8_t* r = data + pos;
    pos += n;
    return r;
  }
  uint8_t u8() { return *take(1); }
  uint32_t u32() { return load_le32(take(4)); }
  int32_t i32() { return int32_t(u32()); }
  float f32() { return std::bit_cast<float>(u32()); }
  Sphere sphere() {
    Sphere s;
    s.center.x = f32();
    s.center.y = f32();
    s.center.z = f32();
    s.radius = f32();
    return s;
  }
};

}  // namespace vgeo
