#pragma once
// The sequences of one LZ4 block, walked front to back. Based on lz4's doc/lz4_Block_format.md
// (the block format, no frame). Used by the decoder to enforce what LZ4_decompress_safe does
// not (a match offset of 0, spec/format.md §5.1), by the vector generator, and by the
// compressed-stream mutants of `vgeo conform decoder` (spec/conform.md §5.2).
#include <cstddef>
#include <cstdint>

namespace vgeo {

// One sequence: a token (literal-length and match-length nibbles), optional literal-length
// bytes, the literals, then, except in the final literals-only sequence, a 2-byte
// little-endian match offset and optional match-length bytes. Positions are block bytes.
struct Lz4Sequence {
  size_t token_at = 0;
  size_t literals_at = 0, literal_count = 0;
  bool has_match = false;        // false: the final literals-only sequence
  size_t offset_at = 0;          // the match offset's 2 bytes (when has_match)
  uint32_t offset = 0;
  uint64_t match_length = 0;     // bytes the match copies (4 + the nibble + its length bytes)
  size_t end = 0;                // one past the sequence's last byte (the next token)
};

// Calls `visit(const Lz4Sequence&)` for each sequence until it returns false or a sequence does
// not parse (a length or offset cut by the block's end, literals beyond it). Returns true when
// the walk ended exactly at the block's end after a literals-only sequence. Checks no output
// position (LZ4_decompress_safe does). Reads only [src, src + size).
template <class Visit>
bool walk_lz4_block(const uint8_t* src, size_t size, Visit&& visit) {
  // A nibble of 15 continues with length bytes; a length byte of 255 continues with another.
  constexpr uint32_t kNibbleMore = 15, kByteMore = 255, kMinMatch = 4;
  auto extend = [&](size_t* ip, uint64_t* length) {
    for (uint8_t b = kByteMore; b == kByteMore;) {
      if (*ip >= size) return false;
      b = src[(*ip)++];
      *length += b;  // at most 255 per input byte: no overflow
    }
    return true;
  };
  size_t ip = 0;
  while (ip < size) {
    Lz4Sequence s;
    s.token_at = ip;
    const uint8_t token = src[ip++];
    uint64_t literals = token >> 4;
    if (literals == kNibbleMore && !extend(&ip, &literals)) return false;
    if (literals > size - ip) return false;
    s.literals_at = ip, s.literal_count = size_t(literals);
    ip += size_t(literals);
    if (ip == size) {
      s.end = ip;
      visit(s);
      return true;
    }
    if (size - ip < 2) return false;
    s.has_match = true;
    s.offset_at = ip;
    s.offset = uint32_t(src[ip]) | uint32_t(src[ip + 1]) << 8;
    ip += 2;
    s.match_length = token & 15u;
    if (s.match_length == kNibbleMore && !extend(&ip, &s.match_length)) return false;
    s.match_length += kMinMatch;
    s.end = ip;
    if (!visit(s)) return false;
  }
  return false;  // an empty block, or one that ends after a match
}

}  // namespace vgeo
