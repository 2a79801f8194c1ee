#pragma once
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

}  // namespace vgeo
