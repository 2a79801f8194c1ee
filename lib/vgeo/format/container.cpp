// File container: header, metadata (materials, instances, per-mesh DAG metadata, page
// table), page placement, compression and checksums (spec/format.md §Container). The
// quantization grids and the conservative metadata are quantize.cpp's.
// Based on: Karis et al., "Nanite: A Deep Dive", SIGGRAPH 2021, §"Paging" (fixed-size pages, a
// resident root) and §"Disk representation" (byte-aligned streams, then a general-purpose LZ).
// ZSTD_customMem and ZSTD_createCCtx_advanced sit in zstd.h's experimental section (unchanged
// since zstd 1.0; exported by the shared library).
#define ZSTD_STATIC_LINKING_ONLY
#include <zstd.h>
#include <lz4.h>
#include <lz4hc.h>

#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstddef>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <functional>
#include <limits>
#include <memory>
#include <numeric>

#include "vgeo/core/byte_io.h"
#include "vgeo/core/error.h"
#include "vgeo/core/file_io.h"
#include "vgeo/core/math.h"
#include "vgeo/core/process_memory.h"
#include "vgeo/core/thread_pool.h"
#include "vgeo/format/bitstream.h"
#include "vgeo/format/crc32c.h"
#include "vgeo/format/format.h"
#include "vgeo/format/lz4_block.h"
#include "vgeo/format/page_codec.h"
#include "vgeo/format/quantize.h"

namespace vgeo {

using namespace format_detail;

namespace {

// Record sizes in the metadata (bytes); used to bound counts before allocating.
constexpr uint32_t kMaterialMinBytes = 20, kInstanceBytes = 68, kMeshHeaderBytes = 68,
                   kClusterBytes = 76, kGroupBytes = 60, kBvhNodeBytes = 76, kPageEntryBytes = 24;
constexpr uint32_t kMeshFlagNormals = 1u, kMeshFlagUvs = 2u;

#ifdef FUZZING_BUILD_MODE_UNSAFE_FOR_PRODUCTION
constexpr bool kCheckChecksums = false;  // let fuzzers reach the parsers behind the CRCs
#else
constexpr bool kCheckChecksums = true;
#endif

// ---- metadata fields (lib/vgeo/core/byte_io.h) with the checks of spec/format.md §2 ----
ByteReader metadata_reader(const uint8_t* data, size_t size, const std::string& where) {
  return ByteReader(data, size, where, kErrTruncated, "metadata");
}
// Counts are bounded by the bytes left: each element takes ≥ min_bytes.
uint32_t read_count(ByteReader& r, uint32_t min_bytes, const char* what) {
  const uint32_t n = r.u32();
  if (uint64_t(n) * min_bytes > r.remaining())
    fail(kErrTruncated, *r.where, std::string(what) + " count exceeds the remaining metadata");
  return n;
}
Sphere read_finite_sphere(ByteReader& r) {
  const Sphere s = r.sphere();
  if (!std::isfinite(s.center.x) || !std::isfinite(s.center.y) || !std::isfinite(s.center.z) || !std::isfinite(s.radius))
    fail(kErrOutOfRange, *r.where, "non-finite bounding sphere");
  return s;
}
float read_lod_error(ByteReader& r) {
  const float e = r.f32();
  if (!(e >= 0.0f)) fail(kErrOutOfRange, *r.where, "LOD error negative or NaN");
  return e;
}

// Byte offsets of the 64-byte file header's fields (spec/format.md §1).
constexpr size_t kHeaderVersion = 8, kHeaderHeaderSize = 12, kHeaderFileSize = 16, kHeaderCompression = 24,
                 kHeaderPageSize = 28, kHeaderPageCount = 32, kHeaderMetadataSize = 36, kHeaderMetadataCrc = 40,
                 kHeaderMetadataRawSize = 44, kHeaderMetadataCompression = 48, kHeaderReservedV1 = 44,
                 kHeaderReservedV2 = 52, kHeaderCrc = 60;

bool is_pow2(uint32_t v) { return v && !(v & (v - 1)); }

}  // namespace

namespace format_detail {

void encode_fail(const std::string& what) { fail(kErrEncode, "<encoder>", what); }

// ---- compression (declared in page_codec.h: the encoder, the decoder and format_edit.h) ----
namespace {
// zstd with `ctx` (a reused context) or, when null, a fresh one (ZSTD_compress): same bytes.
std::vector<uint8_t> compress_with(ZSTD_CCtx* ctx, const std::vector<uint8_t>& raw, Compression c, int level) {
  std::vector<uint8_t> out;
  if (c == Compression::kNone) return raw;
  if (c == Compression::kZstd) {
    out.resize(ZSTD_compressBound(raw.size()));
    const size_t n = ctx ? ZSTD_compressCCtx(ctx, out.data(), out.size(), raw.data(), raw.size(), level)
                         : ZSTD_compress(out.data(), out.size(), raw.data(), raw.size(), level);
    if (ZSTD_isError(n)) encode_fail(std::string("zstd: ") + ZSTD_getErrorName(n));
    out.resize(n);
  } else {
    out.resize(size_t(LZ4_compressBound(int(raw.size()))));
    const int n = LZ4_compress_HC(reinterpret_cast<const char*>(raw.data()), reinterpret_cast<char*>(out.data()),
                                  int(raw.size()), int(out.size()), LZ4HC_CLEVEL_MAX);
    if (n <= 0) encode_fail("lz4 compression failed");
    out.resize(size_t(n));
  }
  return out;
}
}  // namespace

std::vector<uint8_t> compress(const std::vector<uint8_t>& raw, Compression c, int level) {
  return compress_with(nullptr, raw, c, level);
}

namespace {
// zstd's allocations (ZSTD_customMem): its workspace, the match-finder tables that every
// ZSTD_compressCCtx clears whole (1.3 MB at level 6 for a page up to 128 KiB, 3.7 MB above),
// on huge pages (allocate_huge_pages); anything smaller from malloc. A tag in front of each
// block says which (zstd aligns within the workspace itself).
constexpr size_t kZstdHugeMinBytes = size_t(1) << 20;
constexpr size_t kZstdTagBytes = alignof(std::max_align_t);
void* zstd_alloc(void*, size_t n) {
  if (n >= kZstdHugeMinBytes)
    if (auto* p = static_cast<uint8_t*>(allocate_huge_pages(n + kZstdTagBytes))) {
      p[0] = 1;
      return p + kZstdTagBytes;
    }
  auto* p = static_cast<uint8_t*>(std::malloc(n + kZstdTagBytes));
  if (!p) return nullptr;
  p[0] = 0;
  return p + kZstdTagBytes;
}
void zstd_free(void*, void* q) {
  if (!q) return;
  uint8_t* p = static_cast<uint8_t*>(q) - kZstdTagBytes;
  if (p[0]) free_huge_pages(p);
  else std::free(p);
}
}  // namespace

CompressContexts::~CompressContexts() {
  for (Context& c : idle_) ZSTD_freeCCtx(c.ctx);
}

std::vector<uint8_t> CompressContexts::compress(const std::vector<uint8_t>& raw, Compression c, int level) {
  if (c != Compression::kZstd) return compress_with(nullptr, raw, c, level);
  Context ctx;
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    if (!idle_.empty()) {
      ctx = std::move(idle_.back());
      idle_.pop_back();
    }
  }
  if (!ctx.ctx && !(ctx.ctx = ZSTD_createCCtx_advanced(ZSTD_customMem{zstd_alloc, zstd_free, nullptr})))
    encode_fail("zstd: cannot allocate a compression context");
  // Back to the idle list whether or not compression throws.
  struct Return {
    CompressContexts* self;
    Context& ctx;
    ~Return() {
      const std::lock_guard<std::mutex> lock(self->mutex_);
      self->idle_.push_back(std::move(ctx));
    }
  } give_back{this, ctx};
  // Same call as compress_with's: same bytes.
  const size_t bound = ZSTD_compressBound(raw.size());
  if (ctx.out.size() < bound) ctx.out.resize(bound);
  const size_t n = ZSTD_compressCCtx(ctx.ctx, ctx.out.data(), bound, raw.data(), raw.size(), level);
  if (ZSTD_isError(n)) encode_fail(std::string("zstd: ") + ZSTD_getErrorName(n));
  return std::vector<uint8_t>(ctx.out.begin(), ctx.out.begin() + ptrdiff_t(n));
}

void decompress(const uint8_t* src, size_t src_size, Compression c, uint8_t* dst, size_t raw_size,
                const std::string& where) {
  if (c == Compression::kNone) {
    if (src_size != raw_size) fail(kErrInconsistent, where, "uncompressed page size differs from its raw size");
    std::memcpy(dst, src, raw_size);
    return;
  }
  if (c == Compression::kZstd) {
    const unsigned long long content = ZSTD_getFrameContentSize(src, src_size);
    if (content == ZSTD_CONTENTSIZE_ERROR || content == ZSTD_CONTENTSIZE_UNKNOWN)
      fail(kErrDecompress, where, "zstd frame header invalid or without content size");
    if (content != raw_size) fail(kErrDecompress, where, "zstd content size differs from the page table");
    const size_t frame = ZSTD_findFrameCompressedSize(src, src_size);
    if (ZSTD_isError(frame)) fail(kErrDecompress, where, std::string("zstd: ") + ZSTD_getErrorName(frame));
    if (frame != src_size) fail(kErrTrailingBytes, where, "bytes after the zstd frame");
    // Output capacity is exactly the declared raw size: zstd cannot write beyond it.
    const size_t n = ZSTD_decompress(dst, raw_size, src, src_size);
    if (ZSTD_isError(n)) fail(kErrDecompress, where, std::string("zstd: ") + ZSTD_getErrorName(n));
    if (n != raw_size) fail(kErrDecompress, where, "zstd output shorter than declared");
    return;
  }
  // LZ4_decompress_safe accepts a match offset of 0 (it copies the output buffer's own
  // bytes: whatever the buffer held), which lz4_Block_format.md calls invalid and §5.1
  // rejects. Any block it decodes parses into the same sequences as this walk (it succeeds
  // only when the final literals end exactly at the block's end), so checking the walk's
  // offsets first rejects exactly those blocks; a block the walk cannot parse is left to
  // LZ4_decompress_safe, which rejects it with the same code.
  walk_lz4_block(src, src_size, [&](const Lz4Sequence& s) {
    if (s.has_match && s.offset == 0)
      fail(kErrDecompress, where, "lz4 match offset 0 at block byte " + std::to_string(s.offset_at));
    return true;
  });
  const int n = LZ4_decompress_safe(reinterpret_cast<const char*>(src), reinterpret_cast<char*>(dst),
                                    int(src_size), int(raw_size));
  if (n < 0) fail(kErrDecompress, where, "lz4 block invalid");
  if (size_t(n) != raw_size) fail(kErrDecompress, where, "lz4 output shorter than declared");
}

}  // namespace format_detail

namespace {

void check_options(const FormatOptions& o) {
  if (!is_pow2(o.page_size) || o.page_size < kMinPageSize || o.page_size > kMaxPageSize)
    encode_fail("page size must be a power of two in [16 KiB, 16 MiB]");
  if (o.normal_bits < 1 || o.normal_bits > kMaxNormalBits) encode_fail("normal bits outside 1..16");
  if (o.position_bits < 1 || o.position_bits > 24) encode_fail("position bits outside 1..24");
  if (o.uv_step_log2 < kMinStepLog2 || o.uv_step_log2 > kMaxStepLog2) encode_fail("uv step outside 2^-40..2^40");
  if (o.position_step_log2 && (*o.position_step_log2 < kMinStepLog2 || *o.position_step_log2 > kMaxStepLog2))
    encode_fail("position step outside 2^-40..2^40");
  if (o.compression != Compression::kNone && o.compression != Compression::kZstd && o.compression != Compression::kLz4)
    encode_fail("unknown compression");
  if (o.compression == Compression::kZstd && (o.zstd_level < kMinZstdLevel || o.zstd_level > kMaxZstdLevel))
    encode_fail("zstd level " + std::to_string(o.zstd_level) + " outside " + std::to_string(kMinZstdLevel) + ".." +
                std::to_string(kMaxZstdLevel));
  if (o.version < kMinFormatVersion || o.version > kFormatVersion) encode_fail("unsupported format version");
}

// Version 2 stores every array of fixed-size metadata records byte-transposed (byte j of
// record i at j·n + i): equal and slowly varying fields line up for the compressor.
void put_records(ByteWriter& meta, const ByteWriter& records, uint32_t record_size, uint32_t version) {
  assert(records.bytes.size() % record_size == 0);
  if (version < 2) {
    meta.bytes.insert(meta.bytes.end(), records.bytes.begin(), records.bytes.end());
    return;
  }
  const size_t n = records.bytes.size() / record_size, at = meta.bytes.size();
  meta.bytes.resize(at + records.bytes.size());
  for (size_t i = 0; i < n; ++i)
    for (uint32_t j = 0; j < record_size; ++j) meta.bytes[at + j * n + i] = records.bytes[i * record_size + j];
}

void write_cluster(ByteWriter& w, const DagCluster& c) {
  w.u32(c.group); w.u32(c.generating_group); w.u32(c.level); w.u32(c.vertex_count); w.u32(c.triangle_count);
  w.sphere(c.bounds); w.sphere(c.lod_bounds); w.sphere(c.parent_bounds);
  w.f32(c.lod_error); w.f32(c.parent_error);
}
void write_group(ByteWriter& w, const DagGroup& g) {
  w.u32(g.first_cluster); w.u32(g.cluster_count); w.u32(g.first_generated); w.u32(g.generated_count);
  w.u32(g.level); w.u32(g.flags); w.sphere(g.bounds); w.sphere(g.parent_bounds); w.f32(g.parent_error);
}
void write_node(ByteWriter& w, const BvhNode& n) {
  w.sphere(n.bounds); w.sphere(n.lod_bounds); w.f32(n.max_parent_error);
  w.u32(n.child_count); w.u32(n.group_mask);
  for (uint32_t k = 0; k < kBvhMaxChildren; ++k) w.u32(n.children[k]);
}

void add_memory_sizes(const ClusterView& c, const MeshQuantization& q, ComponentBytes* m) {
  const uint32_t ob = index_offset_bits(c);
  auto channel_bytes = [&](uint32_t k0, uint32_t k1) {
    double b = 0;
    for (uint32_t k = k0; k < k1; ++k) b += c.bits[k];
    return b * c.vertex_count / 8.0;
  };
  m->positions += channel_bytes(0, 3);
  if (q.has_normals) m->normals += channel_bytes(3, 5);
  if (q.has_uvs) m->uvs += q.has_normals ? channel_bytes(5, 7) : channel_bytes(3, 5);
  const uint32_t tb = bits_for_range(c.vertex_count - 1) + 2 * ob;
  m->topology += double(c.triangle_count) * tb / 8.0;
  m->materials += 4.0 * c.run_count;
  m->cluster_headers += 4.0 * kDescriptorWords;
}

}  // namespace

// ================================================================ encoder

namespace {

// One page of the output, encoded by one task of the pool.
struct PageOut {
  uint32_t mesh = 0, clusters = 0, raw = 0, memory = 0, crc = 0;
  std::vector<uint8_t> stored;
  // Size report (only when one is asked for): raw disk bytes per component, vertices stored
  // as copies, memory-form bytes per component.
  ComponentBytes disk_raw, memory_sizes;
  uint64_t copies = 0;
};

// A page's clusters: slots [first, first + count) of the mesh's page order.
struct PageRange {
  size_t first = 0, count = 0;
  uint64_t memory_bytes = 0, raw_bound = 0;  // exact memory form; raw disk form bound (exact in version 1)
};

// Runs fn(i) for every i in [0, n) on the pool. When calls throw, the exception of the lowest
// index is rethrown, so which error a bad input gets does not depend on the thread count.
void parallel_for_ordered_errors(ThreadPool& pool, size_t n, const std::function<void(size_t)>& fn) {
  std::vector<std::exception_ptr> errors(n);
  pool.parallel_for(n, [&](size_t i) {
    try {
      fn(i);
    } catch (...) {
      errors[i] = std::current_exception();
    }
  });
  for (const std::exception_ptr& e : errors)
    if (e) std::rethrow_exception(e);
}

// Placement: coarsest level first (root page = top of the DAG), then spatial order of the
// groups (Morton code of the bounds centre), clusters of a group consecutively. Returns the
// cluster ids in page order.
std::vector<uint32_t> place_clusters(const ClusterDag& dag) {
  const uint32_t nc = uint32_t(dag.clusters.size()), ng = uint32_t(dag.groups.size());
  std::vector<uint32_t> group_order(ng);
  std::iota(group_order.begin(), group_order.end(), 0u);
  std::vector<uint32_t> key(ng, 0);
  const Aabb& box = dag.bounds;
  for (uint32_t g = 0; g < ng; ++g) {
    uint32_t cell[3] = {0, 0, 0};
    for (int k = 0; k < 3; ++k) {
      const double lo = box.empty() ? 0 : box.min[k], hi = box.empty() ? 1 : box.max[k];
      const double t = hi > lo ? (double(dag.groups[g].bounds.center[k]) - lo) / (hi - lo) : 0.0;
      cell[k] = uint32_t(std::clamp(t, 0.0, 1.0) * 1023.0);
    }
    key[g] = morton_code(cell[0], cell[1], cell[2]);
  }
  std::stable_sort(group_order.begin(), group_order.end(), [&](uint32_t a, uint32_t b) {
    if (dag.groups[a].level != dag.groups[b].level) return dag.groups[a].level > dag.groups[b].level;
    return key[a] < key[b];
  });
  std::vector<uint32_t> slots;
  slots.reserve(nc);
  std::vector<uint8_t> placed(nc, 0);
  for (uint32_t g : group_order)
    for (uint32_t c = dag.groups[g].first_cluster; c < dag.groups[g].first_cluster + dag.groups[g].cluster_count; ++c) {
      if (placed[c]) encode_fail("cluster is a member of two groups");
      if (dag.clusters[c].group != g) encode_fail("cluster's group disagrees with the group's member range");
      placed[c] = 1;
      slots.push_back(c);
    }
  if (slots.size() != nc) encode_fail("cluster not a member of any group");
  return slots;
}

// Clusters are canonicalized in page order, a batch at a time, and each page is encoded as soon
// as it is complete, so only the canonical clusters of the open pages are held (not the whole
// mesh's: 139 MB on a 1M-triangle sphere). A batch is this many clusters per thread of the pool:
// a full 128 KiB page holds ~200 clusters of a 1M-triangle sphere, so 512 per thread is ~2.5
// pages of work per thread, and the window (a CanonicalCluster is ~8.8 KB) stays ~4.5 MB per
// thread. It was 4096 clusters whatever the thread count: 36 MB faulted in at one thread,
// ~17,700 page faults, ~0.1 CPU-s on that sphere (docs/acceptance/issue23_encspeed.md). The
// batch size never changes the bytes (page breaking runs over the clusters in page order).
constexpr size_t kCanonicalBatchClustersPerThread = 512;
// One thread has no work to balance: a batch only needs to amortize the per-batch bookkeeping
// (a pool call, a page break pass), so the window is the open page plus a few clusters, not
// plus 512 (~4.5 MB less peak memory; the DAG is still held while the pages are written).
constexpr size_t kCanonicalBatchClustersOneThread = 32;
constexpr uint64_t kPageHeadMem = 4, kPageHeadRaw = 12;  // cluster count; magic, count, ref total

// A canonical cluster packed to its counts: the view's arrays point into `bytes` (values of
// the mesh's channels, run materials, strip, control bytes, references, run starts).
struct PackedCluster {
  ClusterView view;
  std::unique_ptr<uint8_t[]> bytes;
};
void pack_cluster(const CanonicalCluster& c, uint32_t channels, PackedCluster* out) {
  const size_t value_bytes = sizeof(int32_t) * c.vertex_count, run_material_bytes = sizeof(uint32_t) * c.run_count,
               strip_bytes = 3 * size_t(c.triangle_count);
  const size_t size = channels * value_bytes + run_material_bytes + strip_bytes + c.triangle_count + c.ref_count +
                      c.run_count;
  out->bytes.reset(new uint8_t[size]);  // int32 first: malloc's alignment holds them
  uint8_t* at = out->bytes.get();
  auto put = [&](const void* from, size_t n) {
    std::memcpy(at, from, n);
    at += n;
    return at - n;
  };
  ClusterView& v = out->view;
  v = ClusterView();
  v.vertex_count = c.vertex_count, v.triangle_count = c.triangle_count;
  v.ref_count = c.ref_count, v.run_count = c.run_count;
  for (uint32_t k = 0; k < kMaxChannels; ++k) v.min[k] = c.min[k], v.bits[k] = c.bits[k];
  for (uint32_t k = 0; k < channels; ++k) v.values[k] = reinterpret_cast<const int32_t*>(put(c.values[k], value_bytes));
  v.run_material = reinterpret_cast<const uint32_t*>(put(c.run_material, run_material_bytes));
  v.strip = reinterpret_cast<const uint8_t(*)[3]>(put(c.strip, strip_bytes));
  v.ctl = put(c.ctl, c.triangle_count);
  v.refs = put(c.refs, c.ref_count);
  v.run_start = put(c.run_start, c.run_count);
  assert(at == out->bytes.get() + size);
}

// One page: disk form, memory form (its size goes to the page table), compression, CRC.
// `clusters` are the page's canonical clusters in page order.
PageOut encode_page(const std::vector<const ClusterView*>& clusters, const PageRange& range,
                    const MeshQuantization& q, uint32_t mesh, const FormatOptions& o, bool want_report,
                    CompressContexts& compressor) {
  PageOut p;
  p.mesh = mesh;
  p.clusters = uint32_t(range.count);
  DiskSections sections;
  const std::vector<uint8_t> raw = encode_disk_page(clusters, q, o.version, nullptr, want_report ? &sections : nullptr);
  assert(o.version == 1 ? raw.size() == range.raw_bound : raw.size() <= range.raw_bound);
  // The page table's memory size is the page breaker's sum (memory_cluster_words per cluster),
  // which is the memory form's exact size: the memory form itself is not encoded (it was, only
  // to take its size: ~6% of the write stage's instructions). Debug builds check the two agree.
  assert(encode_memory_page(clusters, q).size() * 4 == range.memory_bytes);
  p.raw = uint32_t(raw.size());
  p.memory = uint32_t(range.memory_bytes);
  p.stored = compressor.compress(raw, o.compression, o.zstd_level);
  p.crc = crc32c(p.stored.data(), p.stored.size());
  if (want_report) {
    p.disk_raw.cluster_headers = double(sections.headers);
    p.disk_raw.topology = double(sections.topology);
    p.disk_raw.materials = double(sections.materials);
    p.disk_raw.positions = double(sections.positions);
    p.disk_raw.normals = double(sections.normals);
    p.disk_raw.uvs = double(sections.uvs);
    p.disk_raw.vertex_refs = double(sections.vertex_refs);
    p.copies = sections.copies;
    for (const ClusterView* c : clusters) add_memory_sizes(*c, q, &p.memory_sizes);
    p.memory_sizes.cluster_headers += 4;  // the page's cluster count
  }
  return p;
}

// Cluster counts of the report, summed in page order.
struct ClusterTotals {
  uint64_t clusters = 0, triangles = 0, vertices = 0, wide_index_clusters = 0;
};

// The pages of one mesh: canonicalize a batch of clusters (in parallel), break pages (sizes
// only: clusters fill a page in page order until the next one would exceed the page size in
// memory form or the raw disk bound), encode the completed pages (in parallel), drop their
// clusters. Pages, report sums and the error thrown are the same for any thread count.
struct PageStream {
  const ClusterDag& dag;
  const std::vector<uint32_t>& slots;  // cluster ids in page order
  const MeshQuantization& q;
  const FormatOptions& o;
  uint32_t mesh = 0;
  bool want_report = false;
  ThreadPool& pool;
  CompressContexts& compressor;

  PageStream(const ClusterDag& d, const std::vector<uint32_t>& s, const MeshQuantization& mq, const FormatOptions& fo,
             uint32_t m, bool report, ThreadPool& tp, CompressContexts& cc)
      : dag(d), slots(s), q(mq), o(fo), mesh(m), want_report(report), pool(tp), compressor(cc) {}

  // Canonical clusters of page-order positions [window_first, window_first + window.size()),
  // each packed to its counts (PackedCluster). A CanonicalCluster is a fixed ~8.8 KB (255
  // vertices of 7 channels); held for a whole open page (~200 clusters) that was ~430 page
  // faults and ~1.7 MB of peak memory on armadillo, where a packed cluster of positions only
  // takes ~1 KB (docs/acceptance/issue23_write.md). Each cluster is canonicalized into its
  // thread's CanonicalCluster, then packed.
  size_t window_first = 0;
  std::vector<PackedCluster> window;
  PageRange open{0, 0, kPageHeadMem, kPageHeadRaw};
  std::vector<PageRange> complete;          // closed pages not yet encoded
  std::vector<PageOut> pages;
  ClusterTotals totals;

  const ClusterView& at(size_t pos) const { return window[pos - window_first].view; }

  void canonicalize_batch(size_t first, size_t count) {
    const size_t base = window.size();
    window.resize(base + count);
    const uint32_t channels = q.channel_count();
    parallel_for_ordered_errors(pool, count, [&](size_t k) {
      thread_local std::unique_ptr<CanonicalCluster> scratch;
      if (!scratch) scratch = std::make_unique<CanonicalCluster>();
      canonicalize_cluster(dag, slots[first + k], q, scratch.get());
      pack_cluster(*scratch, channels, &window[base + k]);
    });
  }

  void break_batch(size_t first, size_t count) {
    const uint32_t max_raw = max_raw_page_size(o.page_size);
    for (size_t i = first; i < first + count; ++i) {
      const ClusterView& c = at(i);
      totals.clusters += 1;
      totals.triangles += c.triangle_count;
      totals.vertices += c.vertex_count;
      const uint32_t offset_bits = index_offset_bits(c);
      totals.wide_index_clusters += offset_bits > kNaniteIndexOffsetBits ? 1 : 0;
      const uint64_t m = 4ull * memory_cluster_words(c, offset_bits);
      const uint64_t r = disk_cluster_bytes(c, q.channel_count(), o.version);
      if (open.count && (open.memory_bytes + m > o.page_size || open.raw_bound + r > max_raw)) {
        complete.push_back(open);
        open = PageRange{i, 0, kPageHeadMem, kPageHeadRaw};
      }
      assert(open.memory_bytes + m <= o.page_size && open.raw_bound + r <= max_raw);
      open.count += 1;
      open.memory_bytes += m;
      open.raw_bound += r;
    }
  }

  void encode_complete() {
    const size_t base = pages.size();
    pages.resize(base + complete.size());
    parallel_for_ordered_errors(pool, complete.size(), [&](size_t i) {
      const PageRange& range = complete[i];
      std::vector<const ClusterView*> clusters;
      clusters.reserve(range.count);
      for (size_t k = 0; k < range.count; ++k) clusters.push_back(&at(range.first + k));
      pages[base + i] = encode_page(clusters, range, q, mesh, o, want_report, compressor);
    });
    complete.clear();
  }

  // Keeps only the open page's clusters.
  void drop_encoded() {
    const size_t keep_from = open.count ? open.first : window_first + window.size();
    const size_t drop = keep_from - window_first;
    if (drop == 0) return;
    window.erase(window.begin(), window.begin() + ptrdiff_t(drop));
    window_first = keep_from;
  }

  void run() {
    const size_t batch =
        pool.size() == 1 ? kCanonicalBatchClustersOneThread : kCanonicalBatchClustersPerThread * pool.size();
    for (size_t first = 0; first < slots.size(); first += batch) {
      const size_t count = std::min(batch, slots.size() - first);
      canonicalize_batch(first, count);
      break_batch(first, count);
      encode_complete();
      drop_encoded();
    }
    if (open.count) complete.push_back(open);
    encode_complete();
  }
};

void add_components(const ComponentBytes& a, ComponentBytes* sum) {
  sum->positions += a.positions;
  sum->normals += a.normals;
  sum->uvs += a.uvs;
  sum->topology += a.topology;
  sum->materials += a.materials;
  sum->cluster_headers += a.cluster_headers;
  sum->vertex_refs += a.vertex_refs;
}

void add_page_report(const PageOut& p, uint32_t page_size, FormatReport* rep) {
  rep->pages.push_back({p.mesh, p.clusters, p.memory, page_size - p.memory, p.raw, uint32_t(p.stored.size())});
  add_components(p.disk_raw, &rep->disk_raw);
  add_components(p.memory_sizes, &rep->memory);
  rep->copied_vertices += p.copies;
}

// What encode_format writes: the header and the (stored) metadata, then the pages' stored bytes.
struct EncodedFile {
  std::vector<uint8_t> head;
  std::vector<PageOut> pages;
  uint64_t total = 0;
};

EncodedFile encode_parts(const BuiltScene& scene, const FormatOptions& o, FormatReport* report) {
  check_options(o);
  ByteWriter meta;
  // The metadata's size up to the page table (spec/format.md §2): reserved, so the buffer is
  // not regrown by doubling (each regrowth a copy into fresh memory: ~3.5 MB written for the
  // 1.4 MB of a 1M-triangle sphere's metadata, ~600 page faults). Materials' names and the page
  // table may still grow it once.
  {
    uint64_t bytes = 16 + uint64_t(kInstanceBytes) * scene.instances.size();
    for (const ClusterDag& dag : scene.meshes)
      bytes += kMeshHeaderBytes + uint64_t(kClusterBytes + 4) * dag.clusters.size() +
               uint64_t(kGroupBytes) * dag.groups.size() + 4ull * dag.generated_clusters.size() +
               uint64_t(kBvhNodeBytes) * dag.bvh_nodes.size();
    meta.bytes.reserve(size_t(bytes));
  }
  meta.u32(uint32_t(scene.materials.size()));
  for (const Material& m : scene.materials) {
    if (m.name.size() > kMaxNameBytes) encode_fail("material name longer than 4096 bytes");
    meta.u32(uint32_t(m.name.size()));
    meta.bytes.insert(meta.bytes.end(), m.name.begin(), m.name.end());
    for (float c : m.base_color) meta.f32(c);
  }
  meta.u32(uint32_t(scene.instances.size()));
  {
    ByteWriter recs;
    for (const Instance& in : scene.instances) {
      if (in.mesh >= scene.meshes.size()) encode_fail("instance refers to a missing mesh");
      recs.u32(in.mesh);
      for (float t : in.transform) recs.f32(t);
    }
    put_records(meta, recs, kInstanceBytes, o.version);
  }
  meta.u32(uint32_t(scene.meshes.size()));

  ThreadPool pool(o.threads);
  CompressContexts compressor;
  std::vector<PageOut> pages;
  FormatReport rep;
  for (uint32_t mi = 0; mi < scene.meshes.size(); ++mi) {
    const ClusterDag& dag = scene.meshes[mi];
    MeshQuantization q;
    q.has_normals = !dag.normals.empty();
    q.has_uvs = !dag.uvs.empty();
    if (dag.positions.size() % 3 || (q.has_normals && dag.normals.size() != dag.positions.size()) ||
        (q.has_uvs && dag.uvs.size() / 2 != dag.vertex_count()) || dag.uvs.size() % 2 || dag.indices.size() % 3)
      encode_fail("attribute array sizes disagree");
    q.position_step_log2 = choose_position_step(dag, o, &pool);
    q.normal_bits = o.normal_bits;
    q.uv_step_log2 = q.has_uvs ? choose_uv_step(dag, o) : o.uv_step_log2;
    if (report) rep.meshes.push_back(measure_quantization(dag, q, &pool));
    const uint32_t nc = uint32_t(dag.clusters.size()), ng = uint32_t(dag.groups.size());
    // Structural checks the decoder would otherwise reject.
    for (const DagCluster& c : dag.clusters)
      if (c.group >= ng || (c.generating_group != kNone && c.generating_group >= ng))
        encode_fail("cluster refers to a missing group");
    for (const DagGroup& g : dag.groups)
      if (uint64_t(g.first_cluster) + g.cluster_count > nc ||
          uint64_t(g.first_generated) + g.generated_count > dag.generated_clusters.size() || (g.flags & ~uint32_t(kGroupTerminal)))
        encode_fail("group ranges outside the DAG");
    for (uint32_t id : dag.generated_clusters)
      if (id >= nc) encode_fail("generated cluster id outside the DAG");

    const std::vector<uint32_t> slots = place_clusters(dag);
    PageStream stream(dag, slots, q, o, mi, report != nullptr, pool, compressor);
    stream.run();
    std::vector<PageOut>& mesh_pages = stream.pages;
    if (report) {
      rep.clusters += stream.totals.clusters;
      rep.triangles += stream.totals.triangles;
      rep.vertices += stream.totals.vertices;
      rep.wide_index_clusters += stream.totals.wide_index_clusters;
      // Summed in page order: the same doubles for any thread count.
      for (const PageOut& p : mesh_pages) add_page_report(p, o.page_size, &rep);
    }
    const uint32_t first_page = uint32_t(pages.size());
    for (PageOut& p : mesh_pages) pages.push_back(std::move(p));

    meta.u32((q.has_normals ? kMeshFlagNormals : 0) | (q.has_uvs ? kMeshFlagUvs : 0));
    meta.i32(q.position_step_log2);
    meta.i32(q.uv_step_log2);
    meta.u32(q.normal_bits);
    // Stored metadata covers the quantized geometry (spec/format.md §2.1).
    ClusterDag stored;
    stored.bounds = dag.bounds;
    stored.clusters = dag.clusters;
    stored.groups = dag.groups;
    stored.bvh_nodes = dag.bvh_nodes;
    inflate_metadata_for_quantization(&stored, q.position_step_log2);
    meta.u32(dag.level_count);
    for (int k = 0; k < 3; ++k) meta.f32(stored.bounds.min[k]);
    for (int k = 0; k < 3; ++k) meta.f32(stored.bounds.max[k]);
    meta.u32(nc);
    meta.u32(ng);
    meta.u32(uint32_t(dag.generated_clusters.size()));
    meta.u32(uint32_t(dag.bvh_nodes.size()));
    meta.u32(first_page);
    meta.u32(uint32_t(pages.size()) - first_page);
    ByteWriter recs;  // reused for each record array: sized for the largest
    recs.bytes.reserve(size_t(std::max<uint64_t>({uint64_t(kClusterBytes) * nc, uint64_t(kGroupBytes) * ng,
                                                  uint64_t(kBvhNodeBytes) * dag.bvh_nodes.size(),
                                                  uint64_t(4) * dag.generated_clusters.size()})));
    for (const DagCluster& c : stored.clusters) write_cluster(recs, c);
    put_records(meta, recs, kClusterBytes, o.version);
    recs.bytes.clear();
    for (const DagGroup& g : stored.groups) write_group(recs, g);
    put_records(meta, recs, kGroupBytes, o.version);
    recs.bytes.clear();
    for (uint32_t id : dag.generated_clusters) recs.u32(id);
    put_records(meta, recs, 4, o.version);
    recs.bytes.clear();
    for (const BvhNode& n : stored.bvh_nodes) {
      if (n.child_count > kBvhMaxChildren) encode_fail("BVH node with more than 8 children");
      write_node(recs, n);
    }
    put_records(meta, recs, kBvhNodeBytes, o.version);
    recs.bytes.clear();
    for (uint32_t c : slots) recs.u32(c);
    put_records(meta, recs, 4, o.version);
  }
  meta.u32(uint32_t(pages.size()));
  {
    ByteWriter recs;
    for (const PageOut& p : pages) {
      recs.u32(p.mesh); recs.u32(uint32_t(p.stored.size())); recs.u32(p.raw); recs.u32(p.memory);
      recs.u32(p.clusters); recs.u32(p.crc);
    }
    put_records(meta, recs, kPageEntryBytes, o.version);
  }
  // Version 2: the metadata is compressed with the file's codec unless that would exceed
  // kMaxMetadataRatio (then it is stored as is, metadata_compression 0).
  const uint64_t meta_raw_size = meta.bytes.size();
  Compression meta_comp = Compression::kNone;
  std::vector<uint8_t> meta_stored;
  if (o.version >= 2 && o.compression != Compression::kNone) {
    meta_stored = compressor.compress(meta.bytes, o.compression, o.zstd_level);
    if (meta_stored.size() < meta.bytes.size() && meta_stored.size() * uint64_t(kMaxMetadataRatio) >= meta.bytes.size())
      meta_comp = o.compression;
  }
  if (meta_comp == Compression::kNone) meta_stored = meta.bytes;
  if (meta_stored.size() > UINT32_MAX || meta_raw_size > UINT32_MAX) encode_fail("metadata larger than 4 GiB");

  EncodedFile out;
  ByteWriter file;
  out.total = kFileHeaderSize + meta_stored.size();
  for (const PageOut& p : pages) out.total += p.stored.size();
  file.bytes.reserve(kFileHeaderSize + meta_stored.size());
  file.bytes.insert(file.bytes.end(), kPageFileMagic, kPageFileMagic + 8);
  file.u32(o.version);
  file.u32(kFileHeaderSize);
  file.u64(out.total);
  file.u32(uint32_t(o.compression));
  file.u32(o.page_size);
  file.u32(uint32_t(pages.size()));
  file.u32(uint32_t(meta_stored.size()));
  file.u32(crc32c(meta_stored.data(), meta_stored.size()));
  if (o.version >= 2) {
    file.u32(uint32_t(meta_raw_size));
    file.u32(uint32_t(meta_comp));
  }
  while (file.bytes.size() < kFileHeaderSize - 4) file.bytes.push_back(0);  // reserved, zero
  file.u32(crc32c(file.bytes.data(), kFileHeaderSize - 4));
  file.bytes.insert(file.bytes.end(), meta_stored.begin(), meta_stored.end());
  for (const PageOut& p : pages) rep.pages_stored_bytes += p.stored.size();
  if (report) {
    rep.file_bytes = out.total;
    rep.metadata_bytes = meta_stored.size();
    rep.metadata_raw_bytes = meta_raw_size;
    *report = std::move(rep);
  }
  out.head = std::move(file.bytes);
  out.pages = std::move(pages);
  return out;
}

}  // namespace

std::vector<uint8_t> encode_format(const BuiltScene& scene, const FormatOptions& o, FormatReport* report) {
  EncodedFile f = encode_parts(scene, o, report);
  // The whole file in one allocation (no regrowth copies), each page's bytes freed once copied.
  std::vector<uint8_t> file;
  file.reserve(f.total);
  file.insert(file.end(), f.head.begin(), f.head.end());
  for (PageOut& p : f.pages) {
    file.insert(file.end(), p.stored.begin(), p.stored.end());
    std::vector<uint8_t>().swap(p.stored);
  }
  assert(file.size() == f.total);
  return file;
}

void encode_format(const BuiltScene& scene, const FormatOptions& o, ByteSink& sink, FormatReport* report) {
  EncodedFile f = encode_parts(scene, o, report);
  // Not assembled: a file buffer (the file's size, on top of its pages: 5.4 MB, ~1,300 page
  // faults on a 1M-triangle sphere) is only copied to the sink; each page is freed once written.
  sink.write(f.head.data(), f.head.size());
  for (PageOut& p : f.pages) {
    sink.write(p.stored.data(), p.stored.size());
    std::vector<uint8_t>().swap(p.stored);
  }
}

// ================================================================ decoder

FormatContainer parse_container(const uint8_t* data, size_t size, const std::string& where) {
  if (size < 8) fail(kErrTruncated, where, "shorter than the file magic");
  if (std::memcmp(data, kPageFileMagic, 8) != 0) fail(kErrBadMagic, where, "not a vgeo page file (magic VGEOPAGE)");
  if (size < kFileHeaderSize) fail(kErrTruncated, where, "shorter than the 64-byte header");
  FormatContainer fc;
  fc.version = load_le32(data + kHeaderVersion);
  if (fc.version < kMinFormatVersion || fc.version > kFormatVersion)
    fail(kErrBadVersion, where, "version " + std::to_string(fc.version) + " (supported: 1, 2)");
  const uint32_t version = fc.version;
  if (kCheckChecksums && crc32c(data, kHeaderCrc) != load_le32(data + kHeaderCrc))
    fail(kErrChecksum, where, "header CRC-32C mismatch");
  if (load_le32(data + kHeaderHeaderSize) != kFileHeaderSize) fail(kErrInconsistent, where, "header size is not 64");
  fc.file_size = load_le64(data + kHeaderFileSize);
  const uint32_t comp = load_le32(data + kHeaderCompression);
  if (comp > uint32_t(Compression::kLz4)) fail(kErrUnsupported, where, "unknown compression " + std::to_string(comp));
  fc.compression = Compression(comp);
  fc.page_size = load_le32(data + kHeaderPageSize);
  if (!is_pow2(fc.page_size) || fc.page_size < kMinPageSize || fc.page_size > kMaxPageSize)
    fail(kErrOutOfRange, where, "page size not a power of two in [16 KiB, 16 MiB]");
  const uint32_t page_count = load_le32(data + kHeaderPageCount);
  fc.metadata_size = load_le32(data + kHeaderMetadataSize);
  const uint32_t meta_crc = load_le32(data + kHeaderMetadataCrc);
  // Version 2: metadata_raw_size (44) and metadata_compression (48); reserved from 52.
  uint32_t meta_raw_size = fc.metadata_size, meta_comp = 0;
  if (version >= 2) {
    meta_raw_size = load_le32(data + kHeaderMetadataRawSize);
    meta_comp = load_le32(data + kHeaderMetadataCompression);
  }
  for (size_t i = version >= 2 ? kHeaderReservedV2 : kHeaderReservedV1; i < kHeaderCrc; ++i)
    if (data[i] != 0) fail(kErrUnsupported, where, "reserved header bytes are not zero");
  if (meta_comp > uint32_t(Compression::kLz4)) fail(kErrUnsupported, where, "unknown metadata compression");
  if (meta_comp == 0 && meta_raw_size != fc.metadata_size)
    fail(kErrInconsistent, where, "uncompressed metadata with raw size != stored size");
  // Caps the decompression buffer before allocating it.
  if (uint64_t(meta_raw_size) > uint64_t(kMaxMetadataRatio) * fc.metadata_size)
    fail(kErrOutOfRange, where, "metadata raw size beyond 32x its stored size");
  if (fc.file_size < kFileHeaderSize + uint64_t(fc.metadata_size))
    fail(kErrInconsistent, where, "declared file size smaller than header + metadata");
  if (size - kFileHeaderSize < fc.metadata_size) fail(kErrTruncated, where, "file ends inside the metadata");
  const uint8_t* m = data + kFileHeaderSize;
  if (kCheckChecksums && crc32c(m, fc.metadata_size) != meta_crc) fail(kErrChecksum, where, "metadata CRC-32C mismatch");
  std::vector<uint8_t> meta_raw;
  if (meta_comp != 0) {
    meta_raw.resize(meta_raw_size);
    decompress(m, fc.metadata_size, Compression(meta_comp), meta_raw.data(), meta_raw.size(), where + ": metadata");
    m = meta_raw.data();
  }
  // Arrays of fixed-size records: version 2 stores them byte-transposed (put_records).
  std::vector<uint8_t> scratch;
  auto records = [&](ByteReader& from, uint64_t n, uint32_t record_size) {
    const uint8_t* src = from.take(size_t(n) * record_size);  // n bounded by the caller
    if (version < 2) return metadata_reader(src, size_t(n) * record_size, where);
    scratch.resize(size_t(n) * record_size);
    for (size_t i = 0; i < n; ++i)
      for (uint32_t j = 0; j < record_size; ++j) scratch[i * record_size + j] = src[j * n + i];
    return metadata_reader(scratch.data(), scratch.size(), where);
  };

  ByteReader r = metadata_reader(m, meta_raw_size, where);
  fc.materials.resize(read_count(r, kMaterialMinBytes, "material"));
  for (Material& mat : fc.materials) {
    const uint32_t len = r.u32();
    if (len > kMaxNameBytes) fail(kErrOutOfRange, where, "material name longer than 4096 bytes");
    const uint8_t* s = r.take(len);
    mat.name.assign(reinterpret_cast<const char*>(s), len);
    for (float& c : mat.base_color) c = r.f32();
  }
  fc.instances.resize(read_count(r, kInstanceBytes, "instance"));
  {
    ByteReader rr = records(r, fc.instances.size(), kInstanceBytes);
    for (Instance& in : fc.instances) {
      in.mesh = rr.u32();
      for (float& t : in.transform) t = rr.f32();
    }
  }
  fc.meshes.resize(read_count(r, kMeshHeaderBytes, "mesh"));
  uint32_t next_page = 0;
  for (MeshMetadata& mm : fc.meshes) {
    const uint32_t flags = r.u32();
    if (flags & ~(kMeshFlagNormals | kMeshFlagUvs)) fail(kErrUnsupported, where, "unknown mesh flags");
    MeshQuantization& q = mm.quantization;
    q.has_normals = flags & kMeshFlagNormals;
    q.has_uvs = flags & kMeshFlagUvs;
    q.position_step_log2 = r.i32();
    q.uv_step_log2 = r.i32();
    q.normal_bits = r.u32();
    if (q.position_step_log2 < kMinStepLog2 || q.position_step_log2 > kMaxStepLog2 ||
        q.uv_step_log2 < kMinStepLog2 || q.uv_step_log2 > kMaxUvStepLog2 || q.normal_bits < 1 ||
        q.normal_bits > kMaxNormalBits)
      fail(kErrOutOfRange, where, "quantization parameters out of range");
    ClusterDag& dag = mm.dag;
    dag.level_count = r.u32();
    for (int k = 0; k < 3; ++k) dag.bounds.min[k] = r.f32();
    for (int k = 0; k < 3; ++k) dag.bounds.max[k] = r.f32();
    const uint32_t nc = r.u32(), ng = r.u32(), nge = r.u32(), nb = r.u32();
    mm.first_page = r.u32();
    mm.page_count = r.u32();
    if (mm.first_page != next_page || mm.page_count > page_count - std::min(page_count, next_page))
      fail(kErrInconsistent, where, "mesh page ranges do not tile the page table");
    next_page += mm.page_count;
    // Bound every count by the bytes left before allocating.
    const uint64_t need = uint64_t(nc) * (kClusterBytes + 4) + uint64_t(ng) * kGroupBytes + uint64_t(nge) * 4 +
                          uint64_t(nb) * kBvhNodeBytes;
    if (need > r.remaining()) fail(kErrTruncated, where, "mesh record counts exceed the remaining metadata");
    if (nc > 0 && mm.page_count == 0) fail(kErrInconsistent, where, "clusters but no pages");
    dag.clusters.resize(nc);
    uint32_t vsum = 0, tsum = 0;
    ByteReader rc = records(r, nc, kClusterBytes);
    for (DagCluster& c : dag.clusters) {
      ByteReader& r = rc;
      c.group = r.u32();
      c.generating_group = r.u32();
      c.level = r.u32();
      c.vertex_count = r.u32();
      c.triangle_count = r.u32();
      if (c.group >= ng || (c.generating_group != kNone && c.generating_group >= ng))
        fail(kErrOutOfRange, where, "cluster group index out of range");
      if (c.vertex_count == 0 || c.vertex_count > kMaxClusterVertices || c.triangle_count == 0 ||
          c.triangle_count > kMaxClusterTriangles)
        fail(kErrOutOfRange, where, "cluster vertex/triangle count out of range");
      c.bounds = read_finite_sphere(r);
      c.lod_bounds = read_finite_sphere(r);
      c.parent_bounds = read_finite_sphere(r);
      c.lod_error = read_lod_error(r);
      c.parent_error = read_lod_error(r);
      c.vertex_offset = vsum;
      c.triangle_offset = c.material_offset = tsum;
      vsum += c.vertex_count;  // ≤ 255 · 2^32 / 80: counts bounded by metadata size, no wrap
      tsum += c.triangle_count;
    }
    dag.groups.resize(ng);
    ByteReader rg = records(r, ng, kGroupBytes);
    for (DagGroup& g : dag.groups) {
      ByteReader& r = rg;
      g.first_cluster = r.u32();
      g.cluster_count = r.u32();
      g.first_generated = r.u32();
      g.generated_count = r.u32();
      g.level = r.u32();
      g.flags = r.u32();
      if (uint64_t(g.first_cluster) + g.cluster_count > nc || uint64_t(g.first_generated) + g.generated_count > nge)
        fail(kErrOutOfRange, where, "group member/generated range out of range");
      if (g.flags & ~uint32_t(kGroupTerminal)) fail(kErrUnsupported, where, "unknown group flags");
      g.bounds = read_finite_sphere(r);
      g.parent_bounds = read_finite_sphere(r);
      g.parent_error = read_lod_error(r);
    }
    dag.generated_clusters.resize(nge);
    ByteReader rge = records(r, nge, 4);
    for (uint32_t& id : dag.generated_clusters) {
      id = rge.u32();
      if (id >= nc) fail(kErrOutOfRange, where, "generated cluster id out of range");
    }
    dag.bvh_nodes.resize(nb);
    std::vector<uint8_t> referenced(nb, 0);
    ByteReader rb = records(r, nb, kBvhNodeBytes);
    for (BvhNode& n : dag.bvh_nodes) {
      ByteReader& r = rb;
      n.bounds = read_finite_sphere(r);
      n.lod_bounds = read_finite_sphere(r);
      n.max_parent_error = read_lod_error(r);
      n.child_count = r.u32();
      n.group_mask = r.u32();
      if (n.child_count > kBvhMaxChildren || (n.group_mask >> n.child_count) != 0)
        fail(kErrOutOfRange, where, "BVH node child count/mask out of range");
      for (uint32_t k = 0; k < kBvhMaxChildren; ++k) {
        const uint32_t ch = r.u32();
        n.children[k] = ch;
        if (k >= n.child_count) {
          if (ch != kNone) fail(kErrOutOfRange, where, "BVH child slot beyond child count is not empty");
        } else if (n.group_mask & (1u << k)) {
          if (ch >= ng) fail(kErrOutOfRange, where, "BVH group child out of range");
        } else {
          // Each node has at most one parent and the root none: traversal from the root
          // is a tree (no cycles), whatever else the file says.
          if (ch >= nb || ch == 0 || referenced[ch]) fail(kErrInconsistent, where, "BVH node child is not a tree edge");
          referenced[ch] = 1;
        }
      }
    }
    mm.page_clusters.resize(nc);
    std::vector<uint8_t> seen(nc, 0);
    ByteReader rp = records(r, nc, 4);
    for (uint32_t& c : mm.page_clusters) {
      c = rp.u32();
      if (c >= nc || seen[c]) fail(kErrInconsistent, where, "page cluster list is not a permutation");
      seen[c] = 1;
    }
  }
  if (next_page != page_count) fail(kErrInconsistent, where, "meshes do not cover every page");
  for (const Instance& in : fc.instances)
    if (in.mesh >= fc.meshes.size()) fail(kErrOutOfRange, where, "instance mesh index out of range");
  if (r.u32() != page_count) fail(kErrInconsistent, where, "page table count differs from the header");
  if (uint64_t(page_count) * kPageEntryBytes > r.remaining()) fail(kErrTruncated, where, "page table exceeds the metadata");
  fc.pages.resize(page_count);
  uint64_t offset = kFileHeaderSize + uint64_t(fc.metadata_size);
  const uint32_t max_raw = max_raw_page_size(fc.page_size);
  ByteReader pr = records(r, page_count, kPageEntryBytes);
  for (PageEntry& p : fc.pages) {
    ByteReader& r = pr;
    p.mesh = r.u32();
    p.stored_size = r.u32();
    p.raw_size = r.u32();
    p.memory_size = r.u32();
    p.cluster_count = r.u32();
    p.crc = r.u32();
    if (p.mesh >= fc.meshes.size() || p.stored_size == 0 || p.raw_size < 8 || p.raw_size > max_raw ||
        p.memory_size > fc.page_size || p.memory_size % 4 || p.cluster_count == 0 ||
        uint64_t(p.cluster_count) * (4 * kDescriptorWords) + 4 > p.memory_size)
      fail(kErrOutOfRange, where, "page table entry out of range");
    if (fc.compression == Compression::kNone && p.stored_size != p.raw_size)
      fail(kErrInconsistent, where, "uncompressed page with stored size != raw size");
    p.file_offset = offset;
    offset += p.stored_size;
  }
  if (r.remaining() != 0) fail(kErrTrailingBytes, where, "bytes after the page table in the metadata");
  if (offset != fc.file_size) fail(kErrInconsistent, where, "page sizes do not add up to the declared file size");
  // Per mesh: pages belong to it, their cluster counts tile page_clusters, groups' parts
  // occupy consecutive slots (hence consecutive pages).
  for (uint32_t mi = 0; mi < fc.meshes.size(); ++mi) {
    MeshMetadata& mm = fc.meshes[mi];
    const uint32_t nc = uint32_t(mm.dag.clusters.size());
    uint64_t slot = 0;
    mm.cluster_page.assign(nc, 0);
    std::vector<uint32_t> cluster_slot(nc, 0);
    for (uint32_t p = mm.first_page; p < mm.first_page + mm.page_count; ++p) {
      PageEntry& e = fc.pages[p];
      if (e.mesh != mi) fail(kErrInconsistent, where, "page table mesh differs from the mesh's page range");
      if (slot + e.cluster_count > nc) fail(kErrInconsistent, where, "page cluster counts exceed the mesh's clusters");
      e.first_cluster_slot = uint32_t(slot);
      for (uint32_t k = 0; k < e.cluster_count; ++k) {
        const uint32_t c = mm.page_clusters[slot + k];
        mm.cluster_page[c] = p;
        cluster_slot[c] = uint32_t(slot + k);
      }
      slot += e.cluster_count;
    }
    if (slot != nc) fail(kErrInconsistent, where, "page cluster counts do not cover the mesh's clusters");
    const uint32_t ng = uint32_t(mm.dag.groups.size());
    mm.group_first_page.assign(ng, kNone);
    mm.group_page_count.assign(ng, 0);
    for (uint32_t g = 0; g < ng; ++g) {
      const DagGroup& gr = mm.dag.groups[g];
      if (gr.cluster_count == 0) continue;
      uint32_t lo = UINT32_MAX, hi = 0;
      for (uint32_t c = gr.first_cluster; c < gr.first_cluster + gr.cluster_count; ++c) {
        lo = std::min(lo, cluster_slot[c]);
        hi = std::max(hi, cluster_slot[c]);
      }
      if (hi - lo + 1 != gr.cluster_count) fail(kErrInconsistent, where, "group parts are not consecutive in page order");
      mm.group_first_page[g] = mm.cluster_page[mm.page_clusters[lo]];
      mm.group_page_count[g] = mm.cluster_page[mm.page_clusters[hi]] - mm.group_first_page[g] + 1;
    }
  }
  return fc;
}

FormatContainer read_container_metadata(const std::string& path) {
  const ReadOnlyFile file(path);
  if (file.size() < kFileHeaderSize) fail(kErrTruncated, path, "file shorter than the 64-byte header");
  std::vector<uint8_t> head(kFileHeaderSize);
  file.read_exact(0, head.data(), head.size());
  // Allocation bound: the metadata must lie inside the real file.
  const uint64_t metadata_size = load_le32(&head[kHeaderMetadataSize]);
  if (kFileHeaderSize + metadata_size > file.size()) fail(kErrTruncated, path, "metadata extends past the end of the file");
  head.resize(size_t(kFileHeaderSize + metadata_size));
  file.read_exact(kFileHeaderSize, head.data() + kFileHeaderSize, size_t(metadata_size));
  FormatContainer container = parse_container(head.data(), head.size(), path);
  if (container.file_size != file.size())
    fail(kErrInconsistent, path, "file size " + std::to_string(file.size()) + " differs from the header's " +
                                     std::to_string(container.file_size));
  return container;
}

bool is_page_file(const std::string& path) {
  try {
    const ReadOnlyFile file(path);
    char magic[sizeof kPageFileMagic] = {};
    if (file.size() < sizeof magic) return false;
    file.read_exact(0, magic, sizeof magic);
    return std::memcmp(magic, kPageFileMagic, sizeof magic) == 0;
  } catch (const VgeoError&) {
    return false;  // unreadable: not a page file this caller can use
  }
}

std::vector<uint32_t> transcode_page(const FormatContainer& fc, uint32_t page, const uint8_t* stored,
                                     size_t stored_size, const std::string& where) {
  if (page >= fc.pages.size()) fail(kErrOutOfRange, where, "page index beyond the page table");
  const PageEntry& e = fc.pages[page];
  const std::string at = where + ": page " + std::to_string(page);
  if (stored_size < e.stored_size) fail(kErrTruncated, at, "page shorter than its page-table size");
  if (stored_size > e.stored_size) fail(kErrTrailingBytes, at, "page longer than its page-table size");
  if (kCheckChecksums && crc32c(stored, stored_size) != e.crc) fail(kErrChecksum, at, "page CRC-32C mismatch");
  std::vector<uint8_t> raw(e.raw_size);  // ≤ 2 · page_size (checked by parse_container)
  decompress(stored, stored_size, fc.compression, raw.data(), raw.size(), at);
  const MeshMetadata& mm = fc.meshes[e.mesh];
  struct Sink final : ClusterSink {
    const MeshMetadata& mm;
    const PageEntry& e;
    const std::string& at;
    MemoryPageBuilder builder;
    Sink(const MeshMetadata& m, const PageEntry& pe, const std::string& a)
        : mm(m), e(pe), at(a), builder(pe.cluster_count, pe.memory_size / 4, a) {}
    void cluster(uint32_t k, const CanonicalCluster& c) override {
      const DagCluster& meta = mm.dag.clusters[mm.page_clusters[e.first_cluster_slot + k]];
      if (c.vertex_count != meta.vertex_count || c.triangle_count != meta.triangle_count)
        fail(kErrInconsistent, at, "cluster counts differ from the metadata");
      builder.add(c);
    }
  } sink(mm, e, at);
  // The memory form is built with a cap of the declared memory size (≤ page_size).
  parse_disk_page(raw.data(), raw.size(), mm.quantization, e.cluster_count, sink, at, fc.version);
  std::vector<uint32_t> words = sink.builder.finish();
  if (words.size() * 4 != e.memory_size) fail(kErrInconsistent, at, "memory form size differs from the page table");
  return words;
}

BuiltScene decode_format(const uint8_t* data, size_t size, const std::string& where) {
  FormatContainer fc = parse_container(data, size, where);
  if (size < fc.file_size) fail(kErrTruncated, where, "file shorter than its declared size");
  if (size > fc.file_size) fail(kErrTrailingBytes, where, "bytes after the last page");
  BuiltScene scene;
  scene.materials = std::move(fc.materials);
  scene.instances = std::move(fc.instances);
  scene.meshes.resize(fc.meshes.size());
  DecodedCluster dc;
  for (uint32_t mi = 0; mi < fc.meshes.size(); ++mi) {
    MeshMetadata& mm = fc.meshes[mi];
    ClusterDag& dag = scene.meshes[mi];
    dag = mm.dag;  // (copy: transcode_page still reads the container metadata)
    const MeshQuantization& q = mm.quantization;
    uint64_t vc = 0, tc = 0;
    for (const DagCluster& c : dag.clusters) vc += c.vertex_count, tc += c.triangle_count;
    dag.positions.resize(vc * 3);
    dag.normals.resize(q.has_normals ? vc * 3 : 0);
    dag.uvs.resize(q.has_uvs ? vc * 2 : 0);
    dag.indices.resize(tc * 3);
    dag.triangle_materials.resize(tc);
    for (uint32_t p = mm.first_page; p < mm.first_page + mm.page_count; ++p) {
      const PageEntry& e = fc.pages[p];
      const std::vector<uint32_t> words = transcode_page(fc, p, data + e.file_offset, e.stored_size, where);
      for (uint32_t k = 0; k < e.cluster_count; ++k) {
        decode_cluster(words.data(), k, q, &dc);
        const DagCluster& c = dag.clusters[mm.page_clusters[e.first_cluster_slot + k]];
        std::copy(dc.positions.begin(), dc.positions.end(), dag.positions.begin() + 3 * size_t(c.vertex_offset));
        // (Attribute arrays may be empty: never offset an iterator of an empty vector.)
        if (q.has_normals) std::copy(dc.normals.begin(), dc.normals.end(), dag.normals.begin() + 3 * size_t(c.vertex_offset));
        if (q.has_uvs) std::copy(dc.uvs.begin(), dc.uvs.end(), dag.uvs.begin() + 2 * size_t(c.vertex_offset));
        std::copy(dc.indices.begin(), dc.indices.end(), dag.indices.begin() + 3 * size_t(c.triangle_offset));
        std::copy(dc.materials.begin(), dc.materials.end(), dag.triangle_materials.begin() + c.triangle_offset);
      }
    }
  }
  return scene;
}

}  // namespace vgeo
