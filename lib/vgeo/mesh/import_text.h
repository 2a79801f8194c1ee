#pragma once
// Shared pieces of the OBJ / PLY / OFF / STL readers (import_obj.cpp, import_ply.cpp,
// import_off.cpp, import_stl.cpp): a bounds-checked cursor over the file's bytes, strict
// number parsing, and the polygon-to-triangle step every format shares. Every read checks the
// end of the buffer, so no input can make a reader step outside it; every count taken from a
// file is checked against the bytes left before anything is reserved for it.
#include <charconv>
#include <cstring>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "vgeo/mesh/import.h"

namespace vgeo::detail {

// Bytes of text: whitespace-separated tokens, with line tracking for error messages.
struct TextCursor {
  const char* p = nullptr;
  const char* end = nullptr;
  uint64_t line = 1;  // 1-based line of `p`

  TextCursor(const uint8_t* data, size_t size)
      : p(reinterpret_cast<const char*>(data)), end(reinterpret_cast<const char*>(data) + size) {}
  bool at_end() const { return p >= end; }
  size_t remaining() const { return size_t(end - p); }
  // Skips spaces, tabs, '\r' (and, if `newlines`, line breaks).
  void skip_blanks(bool newlines) {
    while (p < end && (*p == ' ' || *p == '\t' || *p == '\r' || (newlines && *p == '\n') || *p == '\f' || *p == '\v')) {
      if (*p == '\n') ++line;
      ++p;
    }
  }
  bool at_line_end() const { return p >= end || *p == '\n'; }
  // Next token on this line (empty at the end of the line).
  std::string_view token_on_line() {
    skip_blanks(false);
    const char* b = p;
    while (p < end && *p != ' ' && *p != '\t' && *p != '\r' && *p != '\n' && *p != '\f' && *p != '\v') ++p;
    return {b, size_t(p - b)};
  }
  // Next token, crossing lines (empty only at the end of the buffer).
  std::string_view token() {
    skip_blanks(true);
    return token_on_line();
  }
  // The current line's '\n' (or `end`): memchr scans many bytes per step, where a byte loop was
  // a third of the OBJ reader's own time (its lines are read whole, then tokenized).
  const char* line_end() const {
    const void* nl = p < end ? std::memchr(p, '\n', size_t(end - p)) : nullptr;
    return nl != nullptr ? static_cast<const char*>(nl) : end;
  }
  // Moves past the end of the current line.
  void next_line() {
    p = line_end();
    if (p < end) {
      ++p;
      ++line;
    }
  }
  // The rest of the current line (without '\r\n'), leaving the cursor at the next line.
  std::string_view rest_of_line() {
    const char* b = p;
    p = line_end();
    const char* e = p;
    if (e > b && e[-1] == '\r') --e;
    if (p < end) {
      ++p;
      ++line;
    }
    return {b, size_t(e - b)};
  }
};

// Unsigned decimal tokens this long or shorter cannot overflow int64_t (10^18 - 1 < 2^63).
inline constexpr size_t kDigitLoopMaxDigits = 18;

// Whole-token numbers: "1", "+2.", "-3e4", "inf" (non-finite values are caught later by the
// shared validation with their own codes). A token with anything after the number is refused.
template <typename T>
bool parse_number(std::string_view t, T& out) {
  if (!t.empty() && t[0] == '+') t.remove_prefix(1);  // from_chars takes '-' only
  if (t.empty() || t[0] == '+' || (t[0] == '-' && t.size() > 1 && t[1] == '+')) return false;
  const auto r = std::from_chars(t.data(), t.data() + t.size(), out);
  return r.ec == std::errc() && r.ptr == t.data() + t.size();
}

// Short decimals "[-]digits[.digits]" read without from_chars (Clinger's fast path, in float):
// a significand below 2^24 and a power of ten up to 10^10 (5^10 < 2^24) are both exact in
// float, so the one IEEE division m / 10^k is the correctly rounded value of the decimal,
// which is from_chars' value, bit for bit. Mesh files mostly write 6-7 significant digits
// (bunny00, armadillo); from_chars' generic scan (infinities, exponents, long significands)
// was ~1% of a small mesh's build. Anything else is from_chars' to read.
inline constexpr uint32_t kExactFloatSignificandLimit = uint32_t(1) << 24;
inline constexpr float kExactFloatPowersOfTen[] = {1e0f, 1e1f, 1e2f, 1e3f, 1e4f, 1e5f,
                                                   1e6f, 1e7f, 1e8f, 1e9f, 1e10f};
inline constexpr int kMaxExactFloatPowerOfTen = 10;

// The short decimal at p into `out` and the end of its characters; nullptr (`out` untouched)
// where p does not start one (from_chars decides those). The caller checks what follows.
inline const char* read_short_decimal(const char* p, const char* end, float& out) {
  const bool negative = p < end && *p == '-';
  if (negative) ++p;
  uint64_t m = 0;
  size_t digits = 0;
  auto read_digits = [&] {
    for (unsigned d; p < end && (d = unsigned(uint8_t(*p)) - unsigned('0')) <= 9; ++p, ++digits) m = m * 10 + d;
  };
  const char* const integer = p;
  read_digits();
  if (p == integer) return nullptr;
  int fraction = 0;
  if (p < end && *p == '.') {
    const char* const first = ++p;
    read_digits();
    fraction = int(p - first);
    if (fraction == 0) return nullptr;
  }
  // (kDigitLoopMaxDigits keeps m from wrapping before it is compared.)
  if (digits > kDigitLoopMaxDigits || m >= kExactFloatSignificandLimit || fraction > kMaxExactFloatPowerOfTen)
    return nullptr;
  const float value = float(m) / kExactFloatPowersOfTen[fraction];
  out = negative ? -value : value;
  return p;
}
inline bool parse_float(std::string_view t, float& out) {
  const char* const end = t.data() + t.size();
  if (float v = 0.0f; read_short_decimal(t.data(), end, v) == end) {
    out = v;
    return true;
  }
  return parse_number(t, out);
}
inline bool parse_double(std::string_view t, double& out) { return parse_number(t, out); }


// The digits of `t` as a number when `t` is 1..kDigitLoopMaxDigits decimal digits and nothing
// else (every count and index a mesh file holds); false, `out` untouched, otherwise. The same
// value from_chars gives, without its generic base and sign handling: from_chars<long> was an
// eighth of a 1M-triangle OFF import.
inline bool parse_plain_digits(std::string_view t, int64_t& out) {
  if (t.empty() || t.size() > kDigitLoopMaxDigits) return false;
  int64_t v = 0;
  for (const char c : t) {
    const unsigned digit = unsigned(uint8_t(c)) - unsigned('0');
    if (digit > 9) return false;
    v = v * 10 + int64_t(digit);
  }
  out = v;
  return true;
}
inline bool parse_int(std::string_view t, int64_t& out) { return parse_plain_digits(t, out) || parse_number(t, out); }

// "<where>:<line>" for error messages that point into a text file.
inline std::string at_line(const std::string& where, uint64_t line) { return where + ":" + std::to_string(line); }

// Polygons up to this many corners are tested for repeated vertices pairwise (no allocation);
// longer ones are sorted, so a million-corner polygon costs n log n, not n^2.
inline constexpr size_t kPairwiseRepeatTestMax = 16;

// Triangles from polygons, shared by every format: fans (v0, vi, vi+1) in file order. A
// polygon that repeats a vertex is dropped whole (FACE_REPEATED_VERTEX, counted in
// degenerate_removed), one with fewer than 3 corners is skipped; indices are checked by the
// caller. Keeps the triangle output of the OpenMesh readers these replace.
struct PolygonSink {
  Mesh& mesh;
  size_t repeated_vertex_faces = 0;
  std::vector<uint32_t> sorted;  // scratch for the repeat test of long polygons

  explicit PolygonSink(Mesh& m) : mesh(m) {}
  void add(const uint32_t* ring, size_t n) {
    // A triangle of three distinct vertices (nearly every polygon of a triangle mesh) is its
    // own fan; inline, it skips the call and the repeat test's loops.
    if (n == 3 && ring[0] != ring[1] && ring[0] != ring[2] && ring[1] != ring[2]) {
      // Three push_backs, not insert(): a ranged insert of 3 is a memmove call.
      mesh.indices.push_back(ring[0]);
      mesh.indices.push_back(ring[1]);
      mesh.indices.push_back(ring[2]);
      return;
    }
    add_polygon(ring, n);
  }
  void add_polygon(const uint32_t* ring, size_t n);
  // Adds the FACE_REPEATED_VERTEX warning and count to `out` (once, after the last polygon).
  void finish(ImportResult& out) const;
};

// One mesh (named after the file stem of `where`), one identity instance, one default
// material: the scene of every single-mesh format.
void push_single_mesh_scene(Mesh&& mesh, const std::string& where, ImportResult& out);

// The readers. `data` is the whole file; `where` names it in errors.
void import_obj(const uint8_t* data, size_t size, const std::string& where, ImportResult& out);
void import_ply(const uint8_t* data, size_t size, const std::string& where, ImportResult& out);
// `threads` (import_off; 0 = all cores): the body is read by line ranges in parallel when it is
// plain (read_plain_body_in_parallel), with the same result as one thread.
void import_off(const uint8_t* data, size_t size, const std::string& where, ImportResult& out, unsigned threads = 1);
void import_stl(const uint8_t* data, size_t size, const std::string& where, ImportResult& out);

}  // namespace vgeo::detail
