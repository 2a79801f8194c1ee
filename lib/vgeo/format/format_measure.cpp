// Size measurements of an encoded file (format_measure.h). Based on: meshoptimizer's index and
// vertex buffer codecs (Kapoulkine; meshopt_encodeIndexBuffer / meshopt_encodeVertexBuffer,
// 0.18) for the baseline; the per-component split follows spec/format.md's layout.
#include "vgeo/format/format_measure.h"

#include <meshoptimizer.h>
#include <zstd.h>
#include <lz4.h>
#include <lz4hc.h>

#include <cstring>

#include "vgeo/core/error.h"
#include "vgeo/format/page_codec.h"

namespace vgeo {
using namespace format_detail;

namespace {
size_t compressed_size(const std::vector<uint8_t>& raw, const FormatOptions& o) {
  if (raw.empty()) return 0;
  if (o.compression == Compression::kZstd) {
    std::vector<uint8_t> out(ZSTD_compressBound(raw.size()));
    return ZSTD_compress(out.data(), out.size(), raw.data(), raw.size(), o.zstd_level);
  }
  if (o.compression == Compression::kLz4) {
    std::vector<char> out(size_t(LZ4_compressBound(int(raw.size()))));
    return size_t(LZ4_compress_HC(reinterpret_cast<const char*>(raw.data()), out.data(), int(raw.size()),
                                  int(out.size()), LZ4HC_CLEVEL_MAX));
  }
  return raw.size();
}
}  // namespace

MeshoptBaseline measure_meshopt_baseline(const BuiltScene& scene, const std::vector<uint8_t>& file,
                                         const FormatOptions& o) {
  const FormatContainer fc = parse_container(file.data(), file.size(), "<baseline>");
  MeshoptBaseline r;
  CanonicalCluster c;
  for (const PageEntry& e : fc.pages) {
    const MeshMetadata& mm = fc.meshes[e.mesh];
    const uint32_t channels = mm.quantization.channel_count();
    std::vector<uint8_t> idx_stream, vtx_stream;
    for (uint32_t k = 0; k < e.cluster_count; ++k) {
      canonicalize_cluster(scene.meshes[e.mesh], mm.page_clusters[e.first_cluster_slot + k], mm.quantization, &c);
      r.triangles += c.triangle_count;
      std::vector<uint32_t> indices;
      for (uint32_t t = 0; t < c.triangle_count; ++t) {
        uint8_t m[3];
        min_first(c.strip[t], m);
        indices.insert(indices.end(), {m[0], m[1], m[2]});
      }
      std::vector<uint8_t> buf(meshopt_encodeIndexBufferBound(indices.size(), c.vertex_count));
      buf.resize(meshopt_encodeIndexBuffer(buf.data(), buf.size(), indices.data(), indices.size()));
      idx_stream.insert(idx_stream.end(), buf.begin(), buf.end());
      // Vertex records: one field per channel (16 or 32 bits), padded to a multiple of 4.
      bool wide = false;
      for (uint32_t ch = 0; ch < channels; ++ch) wide |= c.bits[ch] > 16;
      const size_t field = wide ? 4 : 2, stride = (channels * field + 3) / 4 * 4;
      std::vector<uint8_t> verts(stride * c.vertex_count, 0);
      for (uint32_t v = 0; v < c.vertex_count; ++v)
        for (uint32_t ch = 0; ch < channels; ++ch) {
          const uint32_t off = uint32_t(int64_t(c.values[ch][v]) - c.min[ch]);
          std::memcpy(&verts[v * stride + ch * field], &off, field);  // little-endian low bytes
        }
      buf.assign(meshopt_encodeVertexBufferBound(c.vertex_count, stride), 0);
      buf.resize(meshopt_encodeVertexBuffer(buf.data(), buf.size(), verts.data(), c.vertex_count, stride));
      vtx_stream.insert(vtx_stream.end(), buf.begin(), buf.end());
    }
    r.index_codec_bytes += idx_stream.size();
    r.vertex_codec_bytes += vtx_stream.size();
    r.index_compressed += compressed_size(idx_stream, o);
    r.vertex_compressed += compressed_size(vtx_stream, o);
    std::vector<uint8_t> both = idx_stream;
    both.insert(both.end(), vtx_stream.begin(), vtx_stream.end());
    r.total_compressed += compressed_size(both, o);
  }
  return r;
}

ComponentBytes measure_stream_compression(const BuiltScene& scene, const std::vector<uint8_t>& file,
                                          const FormatOptions& o) {
  const FormatContainer fc = parse_container(file.data(), file.size(), "<stream measure>");
  ComponentBytes r;
  std::vector<CanonicalCluster> canon;
  for (const PageEntry& e : fc.pages) {
    const MeshMetadata& mm = fc.meshes[e.mesh];
    if (e.mesh >= scene.meshes.size() || scene.meshes[e.mesh].clusters.size() != mm.dag.clusters.size())
      fail(kErrInconsistent, "<stream measure>", "the file was not encoded from this scene");
    canon.resize(e.cluster_count);
    std::vector<const CanonicalCluster*> clusters;
    for (uint32_t k = 0; k < e.cluster_count; ++k) {
      canonicalize_cluster(scene.meshes[e.mesh], mm.page_clusters[e.first_cluster_slot + k], mm.quantization, &canon[k]);
      clusters.push_back(&canon[k]);
    }
    DiskStreams s;
    encode_disk_page(clusters, mm.quantization, fc.version, &s);
    r.cluster_headers += double(compressed_size(s.headers, o));
    r.topology += double(compressed_size(s.topology, o));
    r.materials += double(compressed_size(s.materials, o));
    r.positions += double(compressed_size(s.positions, o));
    r.normals += double(compressed_size(s.normals, o));
    r.uvs += double(compressed_size(s.uvs, o));
    r.vertex_refs += double(compressed_size(s.vertex_refs, o));
  }
  return r;
}

}  // namespace vgeo
