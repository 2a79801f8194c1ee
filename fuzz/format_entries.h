#pragma once
// Entry points of the format fuzz targets, shared with the regression test
// (tests/format/format_regressions_test.cpp replays tests/regressions/format/<target>-*
// through the same functions). Each returns normally for accepted or rejected input and
// aborts (FUZZ_CHECK) when a property breaks: a decoder that accepted input must produce
// output the next stage accepts; the round trip must be exact and deterministic.
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "../tests/format/format_roundtrip_check.h"
#include "vgeo/core/error.h"
#include "vgeo/format/format.h"
#include "vgeo/format/page_codec.h"

#define FUZZ_CHECK(cond)                                                                   \
  do {                                                                                     \
    if (!(cond)) {                                                                         \
      std::fprintf(stderr, "FUZZ_CHECK failed: %s (%s:%d)\n", #cond, __FILE__, __LINE__); \
      std::abort();                                                                        \
    }                                                                                      \
  } while (0)

namespace vgeo::fuzz {

// Deterministic byte consumer (no dependency on clang's FuzzedDataProvider, so the
// regression test builds with any compiler). Past the end it yields zeros.
struct Bytes {
  const uint8_t* p;
  size_t n;
  uint32_t u8() { return n ? (--n, *p++) : 0u; }
  uint32_t u32() { return u8() | u8() << 8 | u8() << 16 | u8() << 24; }
  uint32_t range(uint32_t lo, uint32_t hi) { return lo + (hi > lo ? u32() % (hi - lo + 1) : 0); }
};

inline MeshQuantization quantization_from(uint8_t a, uint8_t b) {
  MeshQuantization q;
  q.has_normals = a & 1, q.has_uvs = a & 2;
  q.normal_bits = 1 + b % kMaxNormalBits;
  q.position_step_log2 = -10, q.uv_step_log2 = -12;
  return q;
}

// Whole files: container parse, then a full decode.
inline void container_entry(const uint8_t* data, size_t size) {
  try {
    (void)parse_container(data, size, "<fuzz>");
  } catch (const VgeoError&) {
  }
  try {
    const BuiltScene s = decode_format(data, size, "<fuzz>");
    // Accepted files decode to clusters whose triangles index their own vertices.
    for (const ClusterDag& d : s.meshes)
      for (const DagCluster& c : d.clusters)
        for (uint32_t t = 0; t < 3 * c.triangle_count; ++t)
          FUZZ_CHECK(d.indices[3 * size_t(c.triangle_offset) + t] < c.vertex_count);
  } catch (const VgeoError&) {
  }
}

// Raw disk page (after decompression) → memory form; byte 0: mesh flags (bit 0 normals,
// bit 1 UVs, bit 2 set: page format version 2, else 1), byte 1: normal bits, the rest is
// the page. An accepted page must yield a valid memory page.
inline void page_transcode_entry(const uint8_t* data, size_t size) {
  if (size < 2) return;
  const MeshQuantization q = quantization_from(data[0], data[1]);
  std::vector<uint8_t> page(data + 2, data + size);  // exact size: overreads trip ASan
  const uint32_t declared = page.size() >= 8 ? uint32_t(page[4] | page[5] << 8 | page[6] << 16 | page[7] << 24) : 0;
  try {
    struct Sink final : format_detail::ClusterSink {
      format_detail::MemoryPageBuilder b;
      explicit Sink(uint32_t n) : b(n, kMaxPageSize / 4, where()) {}
      static const std::string& where() { static const std::string w = "<fuzz>"; return w; }
      void cluster(uint32_t, const format_detail::CanonicalCluster& c) override { b.add(c); }
    };
    if (declared > (1u << 16)) return;  // the page table bounds this in real files
    Sink sink(declared);
    const uint32_t version = (data[0] & 4) ? 2 : 1;
    format_detail::parse_disk_page(page.data(), page.size(), q, declared, sink, "<fuzz>", version);
    const std::vector<uint32_t> words = sink.b.finish();
    try {
      validate_memory_page(words.data(), words.size(), q, "<fuzz>");
    } catch (const VgeoError& e) {
      std::fprintf(stderr, "transcoder produced an invalid memory page: %s\n", e.what());
      std::abort();
    }
    DecodedCluster dc;
    for (uint32_t i = 0; i < words[0]; ++i) decode_cluster(words.data(), i, q, &dc);
  } catch (const VgeoError&) {
  }
}

// Memory-form page: byte 0: mesh flags, byte 1: normal bits, then little-endian words.
inline void memory_decode_entry(const uint8_t* data, size_t size) {
  if (size < 2) return;
  const MeshQuantization q = quantization_from(data[0], data[1]);
  std::vector<uint32_t> words((size - 2) / 4);
  if (!words.empty()) std::memcpy(words.data(), data + 2, words.size() * 4);
  try {
    validate_memory_page(words.data(), words.size(), q, "<fuzz>");
  } catch (const VgeoError&) {
    return;
  }
  DecodedCluster dc;
  for (uint32_t i = 0; i < words[0]; ++i) {
    decode_cluster(words.data(), i, q, &dc);
    for (uint8_t idx : dc.indices) FUZZ_CHECK(idx < dc.vertex_count);
    for (size_t k = 0; k < dc.positions.size(); ++k) FUZZ_CHECK(std::isfinite(dc.positions[k]));
  }
}

// A small DAG driven by the input: encode must succeed or fail with FORMAT_ENCODE; an
// encoded scene decodes exactly, and encoding is deterministic.
inline void roundtrip_entry(const uint8_t* data, size_t size) {
  Bytes in{data, size};
  ClusterDag d;
  const bool normals = in.u8() & 1, uvs = in.u8() & 1;
  const uint32_t clusters = in.range(1, 4);
  const bool raw_floats = in.u8() == 0xAB;  // occasionally arbitrary float bits (NaN, huge)
  auto coord = [&](float scale) {
    if (raw_floats) {
      const uint32_t u = in.u32();
      float f;
      std::memcpy(&f, &u, 4);
      return f;
    }
    return float(int8_t(in.u8())) * scale;
  };
  for (uint32_t c = 0; c < clusters; ++c) {
    DagCluster cl;
    cl.vertex_offset = uint32_t(d.vertex_count());
    cl.triangle_offset = cl.material_offset = uint32_t(d.triangle_count());
    cl.vertex_count = in.u8() & 1 ? in.range(1, 255) : in.range(1, 12);
    cl.triangle_count = in.u8() & 1 ? in.range(1, 128) : in.range(1, 12);
    for (uint32_t v = 0; v < cl.vertex_count; ++v) {
      for (int k = 0; k < 3; ++k) d.positions.push_back(coord(0.25f));
      if (normals) for (int k = 0; k < 3; ++k) d.normals.push_back(coord(1.0f));
      if (uvs) for (int k = 0; k < 2; ++k) d.uvs.push_back(coord(0.0625f));
    }
    for (uint32_t t = 0; t < cl.triangle_count; ++t) {
      for (int k = 0; k < 3; ++k) d.indices.push_back(uint8_t(in.u8() % cl.vertex_count));
      d.triangle_materials.push_back(in.u8() % 4);
    }
    cl.group = 0;
    cl.bounds = cl.lod_bounds = cl.parent_bounds = Sphere{{0, 0, 0}, 1.0f};
    cl.parent_error = kTerminalError;
    d.clusters.push_back(cl);
  }
  DagGroup g;
  g.cluster_count = clusters;
  g.flags = kGroupTerminal;
  g.parent_error = kTerminalError;
  d.groups.push_back(g);
  BvhNode root;
  root.child_count = 1, root.group_mask = 1, root.children[0] = 0;
  d.bvh_nodes.push_back(root);
  d.level_count = 1;
  BuiltScene s;
  s.meshes.push_back(std::move(d));
  s.materials.push_back(Material{});
  FormatOptions o;
  o.compression = Compression(in.u8() % 3);
  o.normal_bits = in.range(1, kMaxNormalBits);
  o.zstd_level = 1;
  o.page_size = kMinPageSize;
  o.version = in.u8() & 1 ? kMinFormatVersion : kFormatVersion;
  if (in.u8() & 1) o.position_step_log2 = int32_t(in.range(0, 12)) - 8;
  std::vector<uint8_t> f;
  try {
    f = encode_format(s, o);
  } catch (const VgeoError& e) {
    FUZZ_CHECK(e.error().code == kErrEncode);
    return;
  }
  FUZZ_CHECK(encode_format(s, o) == f);
  try {
    const BuiltScene out = decode_format(f.data(), f.size(), "<fuzz>");
    const std::string diff = compare_roundtrip(s, out, parse_container(f.data(), f.size(), "<fuzz>"));
    if (!diff.empty()) std::fprintf(stderr, "round trip: %s\n", diff.c_str());
    FUZZ_CHECK(diff.empty());
  } catch (const VgeoError& e) {
    std::fprintf(stderr, "decoder rejected the encoder's output: %s\n", e.what());
    std::abort();
  }
}

}  // namespace vgeo::fuzz
