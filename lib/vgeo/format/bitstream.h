#ifndef VGEO_FORMAT_BITSTREAM_H
#define VGEO_FORMAT_BITSTREAM_H
// Bit-stream access over little-endian uint32 words, shared by the CPU decoder and the GPU
// shaders (common C++/GLSL subset, core/shared_glsl.h): the field arithmetic is written once
// (bits_field); C++ reads words through a pointer, GLSL through its storage buffer
// (shaders/memory_page.glsl). Fields are packed LSB-first: a field of n bits at bit position
// p occupies bits p..p+n-1 of the stream, where bit b is bit (b % 32) of word b / 32
// (spec/format.md §Memory form).
//
// Readers do no bounds checks: callers validate once (validate_memory_page) that every
// field read lies inside the page, then read freely in the hot path.
#include "vgeo/core/shared_glsl.h"

#ifdef __cplusplus
namespace vgeo {
#endif

// True when a field of n bits at bit offset `shift` (0..31) within a word continues into
// the next word (the only case in which a reader touches that word).
VGEO_FUNCTION bool bits_straddle(uint32_t shift, uint32_t n) { return shift + n > 32u; }

// The n ≤ 32 bit field starting at bit `shift` of word `lo`, continued in word `hi` when it
// straddles (hi is ignored otherwise).
VGEO_FUNCTION uint32_t bits_field(uint32_t lo, uint32_t hi, uint32_t shift, uint32_t n) {
  if (n == 0u) return 0u;
  uint64_t v = uint64_t(lo) >> shift;
  if (bits_straddle(shift, n)) v |= uint64_t(hi) << (32u - shift);
  return n == 32u ? uint32_t(v) : uint32_t(v & ((uint64_t(1) << n) - uint64_t(1)));
}

// Number of bits needed to store every value in [0, range]: 0 for range 0.
VGEO_FUNCTION uint32_t bits_for_range(uint32_t range) {
  uint32_t b = 0u;
  while (b < 32u && (range >> b) != 0u) ++b;
  return b;
}

// Whole words holding `bits` bits.
VGEO_FUNCTION uint32_t words_for_bits(uint64_t bits) { return uint32_t((bits + uint64_t(31)) / uint64_t(32)); }

#ifdef __cplusplus
// Reads n ≤ 32 bits at bit position `bit`. Touches word bit/32 and, only when the field
// straddles a word boundary, the next word (so a stream padded to whole words suffices).
inline uint32_t read_bits(const uint32_t* words, uint64_t bit, uint32_t n) {
  if (n == 0) return 0;
  const uint64_t word = bit >> 5;
  const uint32_t shift = uint32_t(bit & 31u);
  return bits_field(words[word], bits_straddle(shift, n) ? words[word + 1] : 0u, shift, n);
}

// Writes the low n ≤ 32 bits of `value` at bit position `bit` into zero-initialized words.
inline void write_bits(uint32_t* words, uint64_t bit, uint32_t n, uint32_t value) {
  if (n == 0) return;
  const uint64_t word = bit >> 5;
  const uint32_t shift = uint32_t(bit & 31u);
  const uint64_t v = uint64_t(n == 32 ? value : value & ((1u << n) - 1)) << shift;
  words[word] |= uint32_t(v);
  if (bits_straddle(shift, n)) words[word + 1] |= uint32_t(v >> 32);
}
}  // namespace vgeo
#endif
#endif
