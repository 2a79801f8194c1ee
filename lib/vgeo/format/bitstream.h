#pragma once
// Bit-stream access over little-endian uint32 words, shared by the CPU decoder and (later)
// GPU shaders: plain C-like code, no allocation, no STL. Fields are packed LSB-first: a
// field of n bits at bit position p occupies bits p..p+n-1 of the stream, where bit b is
// bit (b % 32) of word b / 32 (spec/format.md §Memory form).
//
// Readers do no bounds checks: callers validate once (validate_memory_page) that every
// field read lies inside the page, then read freely in the hot path.
#include <cstdint>

namespace vgeo {

// Reads n ≤ 32 bits at bit position `bit`. Touches word bit/32 and, only when the field
// straddles a word boundary, the next word (so a stream padded to whole words suffices).
inline uint32_t read_bits(const uint32_t* words, uint64_t bit, uint32_t n) {
  if (n == 0) return 0;
  const uint64_t word = bit >> 5;
  const uint32_t shift = uint32_t(bit & 31u);
  uint64_t v = words[word] >> shift;
  if (shift + n > 32) v |= uint64_t(words[word + 1]) << (32 - shift);
  return n == 32 ? uint32_t(v) : uint32_t(v & ((1ull << n) - 1));
}

// Writes the low n ≤ 32 bits of `value` at bit position `bit` into zero-initialized words.
inline void write_bits(uint32_t* words, uint64_t bit, uint32_t n, uint32_t value) {
  if (n == 0) return;
  const uint64_t word = bit >> 5;
  const uint32_t shift = uint32_t(bit & 31u);
  const uint64_t v = uint64_t(n == 32 ? value : value & ((1u << n) - 1)) << shift;
  words[word] |= uint32_t(v);
  if (shift + n > 32) words[word + 1] |= uint32_t(v >> 32);
}

// Number of bits needed to store every value in [0, range]: 0 for range 0.
inline uint32_t bits_for_range(uint32_t range) {
  uint32_t b = 0;
  while (b < 32 && (range >> b) != 0) ++b;
  return b;
}

}  // namespace vgeo
