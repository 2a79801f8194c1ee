// Reader of memory-form pages (spec/format.md §4) over the storage buffer of all resident
// pages. The layout and the field arithmetic are the shared headers
// (format/memory_page.h, format/bitstream.h); this file only adds the buffer loads, as
// lib/vgeo/format/page_codec.cpp decode_cluster does with a pointer.
// The including shader defines VGEO_PAGE_WORD(i) (word i of the page buffer, uint32_t).
#include "vgeo/format/memory_page.h"

// n ≤ 32 bits at absolute bit `bit` of the page buffer (bitstream.h read_bits).
uint32_t page_read_bits(uint64_t bit, uint32_t n) {
  if (n == 0u) return 0u;
  uint32_t word = uint32_t(bit >> 5);
  uint32_t shift = uint32_t(bit & uint64_t(31));
  uint32_t hi = bits_straddle(shift, n) ? VGEO_PAGE_WORD(word + 1u) : 0u;
  return bits_field(VGEO_PAGE_WORD(word), hi, shift, n);
}

struct MemoryCluster {
  uint32_t vertex_count, triangle_count, run_count, offset_bits;
  uint32_t channel_count, vertex_bits;
  uint32_t bits[7];
  int32_t mins[7];
  uint64_t vertex_bit;   // absolute bit of vertex 0
  uint64_t index_bit;    // absolute bit of triangle 0
  uint32_t run_word;     // absolute word of the first material run
};

MemoryCluster memory_cluster(uint32_t page_word, uint32_t cluster_in_page, uint32_t channel_count) {
  MemoryCluster c;
  uint32_t d = page_word + memory_descriptor_word(cluster_in_page);
  uint32_t d0 = VGEO_PAGE_WORD(d), d1 = VGEO_PAGE_WORD(d + 1u), d2 = VGEO_PAGE_WORD(d + 2u);
  c.vertex_count = memory_vertex_count(d0);
  c.triangle_count = memory_triangle_count(d0);
  c.run_count = memory_run_count(d0);
  c.offset_bits = memory_offset_bits(d0);
  c.channel_count = channel_count;
  c.vertex_bits = 0u;
  for (uint32_t k = 0u; k < 7u; ++k) {
    c.bits[k] = memory_channel_bits(d1, d2, k);
    c.mins[k] = int32_t(VGEO_PAGE_WORD(d + kMemoryMinWord + k));
    c.vertex_bits += c.bits[k];
  }
  uint32_t data = page_word + memory_data_offset(d2);
  c.vertex_bit = uint64_t(data) * uint64_t(32);
  data += words_for_bits(uint64_t(c.vertex_count) * uint64_t(c.vertex_bits));
  c.index_bit = uint64_t(data) * uint64_t(32);
  data += words_for_bits(uint64_t(c.triangle_count) * uint64_t(memory_triangle_bits(c.vertex_count, c.offset_bits)));
  c.run_word = data;
  return c;
}

// Quantized value of channel k of vertex v.
int32_t memory_vertex_channel(MemoryCluster c, uint32_t v, uint32_t k) {
  uint64_t bit = c.vertex_bit + uint64_t(v) * uint64_t(c.vertex_bits);
  for (uint32_t j = 0u; j < k; ++j) bit += uint64_t(c.bits[j]);
  return c.mins[k] + int32_t(page_read_bits(bit, c.bits[k]));
}

// Local vertex indices of triangle t (smallest first, as decode_cluster).
uvec3 memory_triangle(MemoryCluster c, uint32_t t) {
  uint32_t tb = memory_triangle_bits(c.vertex_count, c.offset_bits);
  uint32_t bb = tb - 2u * c.offset_bits;
  uint64_t bit = c.index_bit + uint64_t(t) * uint64_t(tb);
  uint32_t b = page_read_bits(bit, bb);
  return uvec3(b, b + page_read_bits(bit + uint64_t(bb), c.offset_bits),
               b + page_read_bits(bit + uint64_t(bb + c.offset_bits), c.offset_bits));
}

// Material of triangle t: the last run with start ≤ t.
uint32_t memory_material(MemoryCluster c, uint32_t t) {
  uint32_t material = 0u;
  for (uint32_t r = 0u; r < c.run_count; ++r) {
    uint32_t w = VGEO_PAGE_WORD(c.run_word + r);
    if ((w & 0xFFu) <= t) material = w >> kMemoryRunStartBits;
  }
  return material;
}

// format/container.cpp dequantize_position: float(ldexp(double(q), step)), exact.
float dequantize_position(int32_t q, int32_t step_log2) { return float(ldexp(double(q), int(step_log2))); }
