#pragma once
// Internal to lib/vgeo/format: the canonical cluster shared by the memory-form and disk-form
// codecs. Both forms are produced from (and the disk form parses back into) this one
// representation, which is what makes transcoding exact by construction.
#include <cstdint>
#include <mutex>
#include <string>
#include <vector>

#include "vgeo/dag/cluster_dag.h"
#include "vgeo/format/format.h"
#include "vgeo/format/memory_page.h"

// zstd's context type (zstd.h: typedef struct ZSTD_CCtx_s ZSTD_CCtx), kept out of this header.
struct ZSTD_CCtx_s;

namespace vgeo::format_detail {

inline constexpr uint32_t kMaxChannels = 7;          // x y z, oct u v, uv u v
inline constexpr uint32_t kDescriptorWords = kMemoryDescriptorWords;  // memory-form cluster descriptor
inline constexpr uint32_t kDiskPageMagic = 0x47504456u;    // "VDPG" little-endian (version 1)
inline constexpr uint32_t kDiskPageMagicV2 = 0x32504456u;  // "VDP2" little-endian (version 2)
// Version 2: a vertex equal (every channel) to a vertex of an earlier cluster of the same
// page is stored as a copy when its residual bytes are at least this many (a copy costs
// one 4-byte reference): the raw page then never grows, so the v1 size bound holds.
inline constexpr uint32_t kCopyRefBytes = 4;
// A raw disk page may exceed its memory form (zigzag deltas need one more bit than the
// memory field, refs are whole bytes); pages close before reaching this bound.
inline uint32_t max_raw_page_size(uint32_t page_size) { return 2 * page_size; }

// Strip control byte (spec/format.md §5.2).
inline constexpr uint8_t kCtlReset = 1u << 0;
inline constexpr uint8_t kCtlSide = 1u << 1;   // 0: (c, b, d) across edge b-c; 1: (a, c, d) across c-a
inline constexpr uint8_t kCtlRef0 = 1u << 2;   // corner is an explicit reference (not a new vertex)

struct CanonicalCluster {
  uint32_t vertex_count = 0, triangle_count = 0;
  int32_t values[kMaxChannels][kMaxClusterVertices] = {};  // quantized, canonical vertex order
  int32_t min[kMaxChannels] = {};
  uint32_t bits[kMaxChannels] = {};
  uint8_t strip[kMaxClusterTriangles][3] = {};   // triangles in strip order and strip rotation
  uint8_t ctl[kMaxClusterTriangles] = {};
  uint8_t refs[3 * kMaxClusterTriangles] = {};
  uint32_t ref_count = 0;
  uint32_t run_count = 0;
  uint8_t run_start[kMaxClusterTriangles] = {};
  uint32_t run_material[kMaxClusterTriangles] = {};
};

// Quantizes cluster `c` of `dag` and puts it in canonical order (material-sorted
// generalized strips, vertices by first use). Throws FORMAT_ENCODE on unrepresentable input.
// Writes every field up to the cluster's counts (vertex, triangle, reference and run counts;
// all kMaxChannels channels' values, min and bits); entries past the counts are left as they
// were (no reader reads them).
void canonicalize_cluster(const ClusterDag& dag, uint32_t c, const MeshQuantization& q,
                          CanonicalCluster* out);
// Fills min/bits from values (the encoder side; the disk parser checks them instead).
void compute_channel_ranges(CanonicalCluster* c, uint32_t channel_count);

// A canonical cluster as the page encoders read it: counts and channel ranges by value, the
// arrays by pointer, under CanonicalCluster's field names. The page writer holds the clusters of
// its open page packed to their counts behind views (container.cpp: ~1 KB each on a mesh with
// positions only, where a CanonicalCluster is a fixed ~8.8 KB); view_of views a CanonicalCluster.
struct ClusterView {
  uint32_t vertex_count = 0, triangle_count = 0, ref_count = 0, run_count = 0;
  int32_t min[kMaxChannels] = {};
  uint32_t bits[kMaxChannels] = {};
  const int32_t* values[kMaxChannels] = {};  // null past the mesh's channels (0 bits: never read)
  const uint8_t (*strip)[3] = nullptr;
  const uint8_t* ctl = nullptr;
  const uint8_t* refs = nullptr;
  const uint8_t* run_start = nullptr;
  const uint32_t* run_material = nullptr;
};
ClusterView view_of(const CanonicalCluster& c);

// Memory-form triangle of a strip triangle: rotated so the smallest index comes first.
void min_first(const uint8_t in[3], uint8_t out[3]);
// Bits per index offset in the memory form: the fewest that hold the cluster's largest
// triangle span (max(i1 - i0, i2 - i0) after min_first); 0..8.
uint32_t index_offset_bits(const ClusterView& c);
uint32_t index_offset_bits(const CanonicalCluster& c);

// Memory-form words of a cluster whose index_offset_bits is `offset_bits` (the caller has it).
uint32_t memory_cluster_words(const ClusterView& c, uint32_t offset_bits);
uint32_t memory_cluster_words(const CanonicalCluster& c, uint32_t offset_bits);
// Appends clusters one at a time to a memory-form page of `cluster_count` clusters; fails
// with FORMAT_INCONSISTENT (at `where`) as soon as the page would exceed `max_words`.
class MemoryPageBuilder {
 public:
  MemoryPageBuilder(uint32_t cluster_count, uint64_t max_words, const std::string& where);
  void add(const ClusterView& c);
  void add(const CanonicalCluster& c) { add(view_of(c)); }
  std::vector<uint32_t> finish();  // asserts every cluster was added
 private:
  std::vector<uint32_t> w_;
  uint32_t n_, next_ = 0;
  uint64_t max_words_;
  const std::string& where_;
};
std::vector<uint32_t> encode_memory_page(const std::vector<const CanonicalCluster*>& clusters,
                                         const MeshQuantization& q);
std::vector<uint32_t> encode_memory_page(const std::vector<const ClusterView*>& clusters, const MeshQuantization& q);

struct DiskSections {  // raw byte counts per component and vertex copies (size report)
  uint64_t headers = 0, topology = 0, materials = 0, positions = 0, normals = 0, uvs = 0, vertex_refs = 0;
  uint64_t copies = 0;
};
// The concatenated bytes of each component (the stream measure compresses them one by one).
struct DiskStreams {
  std::vector<uint8_t> headers, topology, materials, positions, normals, uvs, vertex_refs;
  uint64_t copies = 0;
};
// Returns the raw disk form. The byte count of each component is added to `sections` if given
// (the build report: counts only, no copy of the page's bytes), and its bytes are appended to
// `streams` if given (the stream measure).
std::vector<uint8_t> encode_disk_page(const std::vector<const CanonicalCluster*>& clusters,
                                      const MeshQuantization& q, uint32_t version,
                                      DiskStreams* streams = nullptr, DiskSections* sections = nullptr);
std::vector<uint8_t> encode_disk_page(const std::vector<const ClusterView*>& clusters, const MeshQuantization& q,
                                      uint32_t version, DiskStreams* streams = nullptr,
                                      DiskSections* sections = nullptr);
// Upper bound of a cluster's raw disk bytes (exact for version 1).
uint32_t disk_cluster_bytes(const ClusterView& c, uint32_t channel_count, uint32_t version);
uint32_t disk_cluster_bytes(const CanonicalCluster& c, uint32_t channel_count, uint32_t version);
// Version 2 parallelogram predictor of every vertex a strip continuation introduced:
// has[v] and pred[v] = (e1, e2, opposite) with value(v) ≈ e1 + e2 − opposite.
void strip_predictors(const ClusterView& c, uint8_t pred[][3], bool* has);
void strip_predictors(const CanonicalCluster& c, uint8_t pred[][3], bool* has);

// Parses a raw disk page with `expected_clusters` clusters, handing each cluster to
// `sink` in page order (one scratch cluster: memory use does not grow with the cluster
// count). Throws FORMAT_* on any defect and requires every byte to be consumed.
class ClusterSink {
 public:
  virtual void cluster(uint32_t index, const CanonicalCluster& c) = 0;
 protected:
  ~ClusterSink() = default;
};
void parse_disk_page(const uint8_t* data, size_t size, const MeshQuantization& q,
                     uint32_t expected_clusters, ClusterSink& sink, const std::string& where,
                     uint32_t version);

// Compression of pages and metadata (spec/format.md §5.1): `compress` throws FORMAT_ENCODE;
// `decompress` writes exactly raw_size bytes or throws DECOMPRESS / TRAILING_BYTES /
// INCONSISTENT (none: sizes differ).
std::vector<uint8_t> compress(const std::vector<uint8_t>& raw, Compression c, int level);
// zstd compression contexts reused across calls, one per concurrent caller (taken from an idle
// list, created when none is idle, freed with this object). A fresh context per page allocates
// and faults in a new workspace each time (ZSTD_compress; ~11,000 page faults, ~80 ms on a
// 1M-triangle sphere); a reused one keeps its workspace. ZSTD_compressCCtx with a level resets
// every parameter of the context, so the bytes are compress()'s for any reuse order.
class CompressContexts {
 public:
  CompressContexts() = default;
  CompressContexts(const CompressContexts&) = delete;
  CompressContexts& operator=(const CompressContexts&) = delete;
  ~CompressContexts();
  // Same result as compress(raw, c, level); safe to call from several threads at once.
  std::vector<uint8_t> compress(const std::vector<uint8_t>& raw, Compression c, int level);

 private:
  // A context and its output buffer: zstd writes into the buffer (sized to the largest
  // ZSTD_compressBound seen, kept), and the result is copied out at its exact size. A
  // ZSTD_compressBound-sized vector per call, shrunk only logically, kept every page's output
  // at ~its raw size until the file was assembled (10.5 MB instead of 5.4 MB on a 1M-triangle
  // sphere: ~2,600 page faults more; docs/acceptance/issue23_write.md).
  struct Context {
    ZSTD_CCtx_s* ctx = nullptr;
    std::vector<uint8_t> out;
  };
  std::mutex mutex_;
  std::vector<Context> idle_;
};
void decompress(const uint8_t* src, size_t src_size, Compression c, uint8_t* dst, size_t raw_size,
                const std::string& where);

// Channel kind limits.
uint32_t channel_max_bits(const MeshQuantization& q, uint32_t channel);
bool channel_is_normal(const MeshQuantization& q, uint32_t channel);
// The quantized values a channel may hold (spec/format.md §2.1): normals [0, 2^normal_bits − 1],
// positions ±2^24, UVs ±uv_quantized_limit(uv_step_log2).
void channel_value_range(const MeshQuantization& q, uint32_t channel, int64_t* lo, int64_t* hi);

}  // namespace vgeo::format_detail
