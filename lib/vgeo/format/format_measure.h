#pragma once
// Size measurements of an encoded file that cost more than the encoder should pay on every
// write (each compresses the file's pages again): the per-component split of the compressed
// size, and a meshoptimizer-codec baseline.
//
// Size baseline for the page format's report: the same clusters, on the same pages,
// encoded with meshoptimizer's index and vertex codecs (meshopt_encodeIndexBuffer /
// meshopt_encodeVertexBuffer, 0.18) and then compressed per page with the file's codec.
// Vertices are given to meshopt already quantized exactly as in our format (per-cluster
// offsets from the cluster minimum, 16-bit fields, or 32-bit when a channel needs > 16
// bits), in our canonical vertex order, with triangles in our strip order.
#include <cstdint>
#include <vector>

#include "vgeo/format/format.h"

namespace vgeo {

struct MeshoptBaseline {
  uint64_t triangles = 0;
  uint64_t index_codec_bytes = 0, vertex_codec_bytes = 0;  // before the page compressor
  uint64_t index_compressed = 0, vertex_compressed = 0;    // each stream compressed per page alone
  uint64_t total_compressed = 0;                           // both streams of a page compressed together
};

// `file` is an encoded file (encode_format); throws VgeoError on a malformed one.
MeshoptBaseline measure_meshopt_baseline(const BuiltScene& scene, const std::vector<uint8_t>& file,
                                         const FormatOptions& options);

// Per-component compressed size: each page's disk-form streams of one component (cluster
// headers, topology, materials, positions, normals, uvs, vertex references) concatenated and
// compressed on their own with options.compression / options.zstd_level, summed over the pages.
// An estimate of each component's share (pages are compressed whole: the components' sum
// differs from FormatReport::pages_stored_bytes). Costs about one more encode of the file, so
// the encoder never does it; `vgeo bench compression` and tools/bench/format_bench ask for it.
// `file` is encode_format(scene, options); throws VgeoError on a malformed one.
ComponentBytes measure_stream_compression(const BuiltScene& scene, const std::vector<uint8_t>& file,
                                          const FormatOptions& options);

}  // namespace vgeo
