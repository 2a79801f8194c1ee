#pragma once
// The distributable compressed page format (normative: spec/format.md).
//
// A file holds a BuiltScene: a header, always-resident metadata (materials, instances, per
// mesh the full cluster/group/BVH metadata and the page table) and fixed-capacity pages of
// cluster geometry. Each page exists in two forms:
//   - disk form: byte-aligned, grouped by type, generalized-strip topology, zigzag-delta
//     vertices, then zstd / lz4 / nothing; protected by a CRC-32C;
//   - memory form: what the renderer reads with random access per vertex and triangle
//     (bit-packed uint32 words, lib/vgeo/format/bitstream.h). transcode_page() turns the first
//     into the second, exactly.
// Positions are quantized on one power-of-two grid per mesh, centred at the object origin
// and shared by every LOD level, so vertices shared across levels stay bit-identical.
//
// Every decoder entry point treats its input as untrusted: it throws VgeoError with a
// stable FORMAT_* code (kErr* below, spec/errors.md) and never reads out of bounds,
// recurses, or allocates more than a bound derived from the declared sizes.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "vgeo/dag/cluster_dag.h"

namespace vgeo {

struct ByteSink;  // vgeo/core/file_io.h

// ---- stable error codes (never change meaning) ----
inline constexpr const char* kErrBadMagic = "FORMAT_BAD_MAGIC";
inline constexpr const char* kErrBadVersion = "FORMAT_BAD_VERSION";
inline constexpr const char* kErrTruncated = "FORMAT_TRUNCATED";
inline constexpr const char* kErrTrailingBytes = "FORMAT_TRAILING_BYTES";
inline constexpr const char* kErrChecksum = "FORMAT_CHECKSUM";
inline constexpr const char* kErrOutOfRange = "FORMAT_OUT_OF_RANGE";       // a field outside its declared bound
inline constexpr const char* kErrDecompress = "FORMAT_DECOMPRESS";         // zstd/lz4 rejected the page
inline constexpr const char* kErrInconsistent = "FORMAT_INCONSISTENT";     // fields disagree with each other
inline constexpr const char* kErrUnsupported = "FORMAT_UNSUPPORTED";       // unknown compression / flags
inline constexpr const char* kErrNonCanonical = "FORMAT_NON_CANONICAL";    // decodable, but not the one encoding
inline constexpr const char* kErrEncode = "FORMAT_ENCODE";                 // encoder cannot represent the input

// The file's first 8 bytes (spec/format.md §1); told apart from VGEODAG1 files by it.
inline constexpr char kPageFileMagic[8] = {'V', 'G', 'E', 'O', 'P', 'A', 'G', 'E'};

// ---- limits (each justified in spec/format.md §Limits) ----
inline constexpr uint32_t kFormatVersion = 2;     // written by default
inline constexpr uint32_t kMinFormatVersion = 1;  // oldest version still decoded (and writable)
// Version 2 metadata is compressed with the file's codec; a declared raw size above this
// multiple of the stored size is rejected before allocating (measured metadata compresses
// 2-4x; the encoder stores the metadata uncompressed rather than exceed the ratio).
inline constexpr uint32_t kMaxMetadataRatio = 32;
inline constexpr uint32_t kFileHeaderSize = 64;
inline constexpr uint32_t kDefaultPageSize = 128u * 1024u;  // Nanite's page size
inline constexpr uint32_t kMinPageSize = 16u * 1024u;       // > largest memory-form cluster (~6.2 KiB)
inline constexpr uint32_t kMaxPageSize = 16u * 1024u * 1024u;  // word offsets fit the 22-bit descriptor field
// Largest quantized |coordinate|: float represents every integer multiple of the grid
// step up to 2^24 steps exactly, so decoded positions are exact grid points.
inline constexpr int32_t kMaxQuantized = 1 << 24;
inline constexpr uint32_t kMaxChannelBits = 25;     // bits_for_range(2 * kMaxQuantized)
inline constexpr uint32_t kMaxNormalBits = 16;      // per octahedral component
inline constexpr int32_t kMinStepLog2 = -40, kMaxStepLog2 = 40;  // grid steps 2^-40 .. 2^40
// Coarsest stored UV step: FLT_MAX = (2^24 - 1) * 2^104, so with steps up to 2^104 every finite
// UV quantizes (tiling UVs of any size encode; spec/format.md §2). At 2^104 the quantized
// range is |q| <= 2^24 - 1, so every decodable value stays finite (uv_quantized_limit).
inline constexpr int32_t kMaxUvStepLog2 = 104;
inline constexpr uint32_t kMaxMaterialId = (1u << 24) - 1;       // 24-bit field of a material run
inline constexpr uint32_t kMaxNameBytes = 4096;                 // material name length
// Memory-form triangles are a base index plus two offsets of a per-cluster width: 5 bits
// (Nanite's span of 32) when the canonical order allows, up to 8 bits (any span of a
// 255-vertex cluster) otherwise; see spec/format.md §4.
inline constexpr uint32_t kNaniteIndexOffsetBits = 5;
// Finest automatic position grid: 2^20 steps over the extent (4 bits per axis beyond the
// default 16) bounds what the LOD-error refinement of the grid may cost.
inline constexpr uint32_t kMaxAutoPositionBits = 20;
inline constexpr uint32_t kMaxIndexOffsetBits = 8;

enum class Compression : uint32_t { kNone = 0, kZstd = 1, kLz4 = 2 };

// zstd levels the encoder accepts: zstd's own range of regular levels (ZSTD_maxCLevel() is 22;
// its negative "fast" levels are not offered).
inline constexpr int kMinZstdLevel = 1, kMaxZstdLevel = 22;
// Default page and metadata level, from `vgeo bench compression` by this rule: walk the lower
// convex hull of (compression CPU, file bytes) over the levels from the cheapest, and stop before
// the first step that saves under 0.5 MB per CPU-second; the default is the lowest of the curve
// meshes' stops (docs/acceptance/issue23_encspeed.md). Three runs on the 1M sphere, bunny00 and
// armadillo: the hull saves >= 0.85 MB per CPU-second up to level 6 (files 1.06-1.07x the
// smallest, 6-170 ms of compression), then 0.20-0.35 MB/s to level 13 on the sphere and bunny00
// (optimal parsing: 1.01x for 1.2-1.6 s on the sphere, over a third of the peer builder's whole
// build), and under 0.17 MB/s beyond. `--zstd-level 13` (or 19) buys the ~5% smaller file where
// build CPU matters less.
inline constexpr int kDefaultZstdLevel = 6;

struct FormatOptions {
  uint32_t page_size = kDefaultPageSize;  // power of two in [kMinPageSize, kMaxPageSize]
  // Position grid: step 2^position_step_log2 if set, else the smallest power of two with
  // the mesh's largest axis extent ≤ 2^position_bits steps (and |q| ≤ kMaxQuantized),
  // then, if position_step_from_lod_error, halved while the quantization displacement
  // √3/2·step exceeds the median parent_error of the DAG's level-0 groups (the typical
  // error of its first simplification), up to kMaxAutoPositionBits over the extent
  // (spec/format.md §2).
  std::optional<int32_t> position_step_log2;
  uint32_t position_bits = 16;
  bool position_step_from_lod_error = true;
  // 9 bits: largest angular error 0.47° (spec/format.md §2, measured ≤ 0.466° on the CGAL meshes).
  // Per octahedral component, 1..kMaxNormalBits. 9: largest angular error < 0.5°
  // (spec/format.md §2; version 1's default was 10).
  uint32_t normal_bits = 9;
  // Finest UV grid step (1/4096: ~1 texel of a 4K texture). A mesh whose |UV| exceeds 2^24
  // such steps gets the smallest coarser power of two that holds it (spec/format.md §2);
  // FormatReport::meshes says which step each mesh got and the UV error it caused.
  int32_t uv_step_log2 = -12;
  Compression compression = Compression::kZstd;
  int zstd_level = kDefaultZstdLevel;  // kMinZstdLevel .. kMaxZstdLevel (zstd only)
  uint32_t version = kFormatVersion;  // kMinFormatVersion .. kFormatVersion
  // Worker threads of the encoder (0 = hardware concurrency). Pages are quantized, encoded and
  // compressed in parallel; the bytes are identical for any value.
  unsigned threads = 1;
};

// Per-mesh quantization, stored in the metadata.
struct MeshQuantization {
  int32_t position_step_log2 = 0;
  int32_t uv_step_log2 = -12;
  uint32_t normal_bits = 9;
  bool has_normals = false, has_uvs = false;
  uint32_t channel_count() const { return 3 + (has_normals ? 2 : 0) + (has_uvs ? 2 : 0); }
};

struct PageEntry {
  uint32_t mesh = 0;
  uint32_t stored_size = 0;   // bytes in the file (after compression)
  uint32_t raw_size = 0;      // disk form before compression
  uint32_t memory_size = 0;   // memory form bytes (≤ page_size)
  uint32_t cluster_count = 0;
  uint32_t crc = 0;           // CRC-32C of the stored bytes
  uint64_t file_offset = 0;   // derived: header + metadata + earlier pages
  uint32_t first_cluster_slot = 0;  // derived: index into MeshMetadata::page_clusters
};

// One mesh's always-resident part: the DAG without vertex data (cluster vertex/triangle
// offsets filled by prefix sums), plus where each cluster lives.
struct MeshMetadata {
  MeshQuantization quantization;
  ClusterDag dag;                        // positions/normals/uvs/indices/materials empty
  uint32_t first_page = 0, page_count = 0;
  std::vector<uint32_t> page_clusters;   // cluster ids in page order (a permutation)
  std::vector<uint32_t> cluster_page;    // derived: page of each cluster
  std::vector<uint32_t> group_first_page, group_page_count;  // derived: a group's parts
};

struct FormatContainer {
  uint32_t version = 0;
  Compression compression = Compression::kNone;
  uint32_t page_size = 0;
  uint64_t file_size = 0;
  uint32_t metadata_size = 0;
  std::vector<Material> materials;
  std::vector<Instance> instances;
  std::vector<MeshMetadata> meshes;
  std::vector<PageEntry> pages;
};

// ---- size report ----
struct ComponentBytes {
  double positions = 0, normals = 0, uvs = 0, topology = 0, materials = 0, cluster_headers = 0;
  double vertex_refs = 0;  // version 2 disk form: copies of earlier vertices of the page
  double total() const { return positions + normals + uvs + topology + materials + cluster_headers + vertex_refs; }
};
struct PageFill {
  uint32_t mesh = 0, clusters = 0, memory_bytes = 0, slack_bytes = 0, raw_bytes = 0, stored_bytes = 0;
};
struct FormatReport {
  uint64_t triangles = 0, vertices = 0, clusters = 0;
  uint64_t wide_index_clusters = 0;  // clusters whose index offsets need > 5 bits
  uint64_t file_bytes = 0, metadata_bytes = 0, header_bytes = kFileHeaderSize;
  uint64_t metadata_raw_bytes = 0;   // before compression (version 2)
  uint64_t copied_vertices = 0;      // version 2 disk form: vertices stored as copies
  ComponentBytes memory;           // memory-form bytes (bit fields rounded per stream)
  // Disk form before compression, per component (exact). Pages are compressed whole, so the
  // compressed size has no exact per-component split: the encoder reports the real total
  // below, and measure_stream_compression (format_measure.h) estimates the split on request
  // by compressing each component's streams again (as costly as a second encode).
  ComponentBytes disk_raw;
  uint64_t pages_stored_bytes = 0; // the real compressed total of the pages
  std::vector<PageFill> pages;
  // Per mesh: the stored quantization and the largest quantization error measured over its
  // vertices (|decoded − source| per component, in object / UV units; 0 when absent).
  struct MeshQuantizationReport {
    MeshQuantization quantization;
    double position_max_error = 0, uv_max_error = 0;
  };
  std::vector<MeshQuantizationReport> meshes;
};

// ---- whole file ----
// Throws VgeoError(FORMAT_ENCODE) for input it cannot represent (non-finite values, a
// coordinate beyond kMaxQuantized grid steps, > 255 vertices in a cluster, ...).
std::vector<uint8_t> encode_format(const BuiltScene& scene, const FormatOptions& options,
                                   FormatReport* report = nullptr);
// The same bytes, handed to `sink` in order (header and metadata, then each page) instead of
// assembled in one buffer: the file is never held whole in memory on top of its pages
// (write_asset_file).
void encode_format(const BuiltScene& scene, const FormatOptions& options, ByteSink& sink,
                   FormatReport* report = nullptr);
// Decodes every page into a BuiltScene with quantized attributes; see spec/format.md
// §Decoded scene for the canonical vertex/triangle order within each cluster.
BuiltScene decode_format(const uint8_t* data, size_t size, const std::string& where);

// ---- page level (streaming) ----
// Parses header + metadata. `data` holds at least the file's first header+metadata bytes;
// pages need not be present. `file_size` is the full file size if known (0 = unknown: the
// page table is then only checked against the header's declared size).
FormatContainer parse_container(const uint8_t* data, size_t size, const std::string& where);

// Reads and parses a page file's header + metadata only (positioned reads; no page is read).
// Throws the FILE_* codes of lib/vgeo/core/file_io.h or those of parse_container; a file whose
// size differs from the header's is FORMAT_INCONSISTENT; metadata past the end FORMAT_TRUNCATED.
FormatContainer read_container_metadata(const std::string& path);
// True when the file starts with kPageFileMagic; false when it cannot be read or holds
// anything else.
bool is_page_file(const std::string& path);

// Checks the CRC, decompresses and transcodes one page's stored bytes into the memory
// form (words). Output size == the page table's memory_size / 4.
std::vector<uint32_t> transcode_page(const FormatContainer& container, uint32_t page,
                                     const uint8_t* stored, size_t stored_size,
                                     const std::string& where);

// Validates a memory-form page once (every field inside the page, every index < vertex
// count, every value on the quantized range); after that decode_cluster needs no checks.
void validate_memory_page(const uint32_t* words, size_t word_count, const MeshQuantization& q,
                          const std::string& where);

// One cluster of a memory-form page, in quantized integers and in floats.
struct DecodedCluster {
  uint32_t vertex_count = 0, triangle_count = 0;
  uint32_t index_offset_bits = 0;
  std::vector<int32_t> quantized;     // channel_count per vertex (x y z [nu nv] [u v])
  std::vector<float> positions, normals, uvs;
  std::vector<uint8_t> indices;       // 3 per triangle, smallest index first
  std::vector<uint32_t> materials;    // 1 per triangle
};
uint32_t memory_page_cluster_count(const uint32_t* words);
// Requires a page accepted by validate_memory_page (asserts in debug only).
void decode_cluster(const uint32_t* words, uint32_t cluster_in_page, const MeshQuantization& q,
                    DecodedCluster* out);

// Conservative metadata for quantized geometry (spec/format.md §2.1). Quantization moves
// every vertex by at most half a grid step per axis (√3/2·step in space), so the encoder
// stores, instead of the builder's values: every sphere radius (cluster bounds, lod_bounds,
// parent_bounds, group bounds/parent_bounds, BVH bounds/lod_bounds) plus
// kQuantRadiusSlack·step, every LOD error except a leaf's lod_error (0) and +inf plus
// kQuantErrorSlack·step (both surfaces of a one-sided distance move by ≤ √3/2·step), each
// sum rounded up to float, and the mesh AABB widened outward to whole grid steps. The same
// function maps equal inputs to equal outputs and is monotone, so shared values stay
// bit-identical and every monotonicity / containment relation of the DAG is kept.
// Throws FORMAT_ENCODE if an adjusted value is not finite.
inline constexpr double kQuantRadiusSlack = 0.8660254038;  // ≥ √3/2 = 0.86602540378…
inline constexpr double kQuantErrorSlack = 1.7320508076;   // ≥ √3 = 1.73205080756…
void inflate_metadata_for_quantization(ClusterDag* dag, int32_t position_step_log2);

// Dequantization (the one definition the renderer and the tests use).
float dequantize_position(int32_t q, int32_t step_log2);
// Largest |q| of a UV channel with step 2^step_log2: 2^24, or 2^24 - 1 at kMaxUvStepLog2
// (2^24 · 2^104 is not a finite float).
int32_t uv_quantized_limit(int32_t step_log2);
void octahedral_encode(const float n[3], uint32_t bits, uint32_t out[2]);
void octahedral_decode(const uint32_t q[2], uint32_t bits, float n[3]);

}  // namespace vgeo
