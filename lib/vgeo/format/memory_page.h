#ifndef VGEO_FORMAT_MEMORY_PAGE_H
#define VGEO_FORMAT_MEMORY_PAGE_H
// Memory-form page layout (spec/format.md §4), the one definition the CPU codec
// (page_codec.cpp) and the shaders (shaders/memory_page.glsl) share (common C++/GLSL
// subset, core/shared_glsl.h). A page: word 0 cluster count N, words 1..10·N descriptors,
// then each cluster's vertex stream, index stream and material runs.
// Based on: Karis et al., "Nanite: A Deep Dive", SIGGRAPH 2021, §"Vertex quantization and
// encoding" (per-cluster bit widths, random access) and §"Memory - Triangles and attributes".
#include "vgeo/format/bitstream.h"

#ifdef __cplusplus
namespace vgeo {
#endif

VGEO_CONSTANT uint32_t kMemoryDescriptorWords = 10u;
VGEO_CONSTANT uint32_t kMemoryChannelBitsWidth = 5u;  // per-channel bit count fields in d1/d2
VGEO_CONSTANT uint32_t kMemoryDataOffsetShift = 10u;  // d2 bits 10..31: vertex stream word
VGEO_CONSTANT uint32_t kMemoryMinWord = 3u;           // d3..d9: channel minima as i32
VGEO_CONSTANT uint32_t kMemoryRunStartBits = 8u;      // material run word: start | material << 8

// Word index of cluster i's descriptor in its page.
VGEO_FUNCTION uint32_t memory_descriptor_word(uint32_t cluster_in_page) {
  return 1u + cluster_in_page * kMemoryDescriptorWords;
}
VGEO_FUNCTION uint32_t memory_vertex_count(uint32_t d0) { return d0 & 0xFFu; }
VGEO_FUNCTION uint32_t memory_triangle_count(uint32_t d0) { return (d0 >> 8) & 0xFFu; }
VGEO_FUNCTION uint32_t memory_run_count(uint32_t d0) { return (d0 >> 16) & 0xFFu; }
VGEO_FUNCTION uint32_t memory_offset_bits(uint32_t d0) { return (d0 >> 24) & 15u; }
// Bits of channel k (0..6): channels 0..5 in d1, channel 6 in d2.
VGEO_FUNCTION uint32_t memory_channel_bits(uint32_t d1, uint32_t d2, uint32_t k) {
  return k < 6u ? (d1 >> (kMemoryChannelBitsWidth * k)) & 31u : d2 & 31u;
}
VGEO_FUNCTION uint32_t memory_data_offset(uint32_t d2) { return d2 >> kMemoryDataOffsetShift; }
// Bits per triangle: base index (enough bits for vertex_count − 1) plus two offsets.
VGEO_FUNCTION uint32_t memory_triangle_bits(uint32_t vertex_count, uint32_t offset_bits) {
  return bits_for_range(vertex_count - 1u) + 2u * offset_bits;
}

#ifdef __cplusplus
}  // namespace vgeo
#endif
#endif
