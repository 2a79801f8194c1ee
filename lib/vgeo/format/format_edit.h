#pragma once
// Field-level edits of a page-format file that keep it parseable up to a planted fault: the
// metadata walked by the layout of spec/format.md §1.2 (version 2 record arrays byte-transposed),
// edited, stored back uncompressed (metadata_compression 0, a valid encoder choice), pages
// edited in their raw (decompressed) form and recompressed, and every size and CRC fixed. Used
// by the vector generator (tests/format/format_vectors_test.cpp) and by the structure-aware
// mutants of `vgeo conform decoder` (spec/conform.md §5.2). Inputs are files this library
// wrote (or that decode); malformed ones make the functions return false, never read out of
// bounds.
#include <cstdint>
#include <functional>
#include <vector>

namespace vgeo {

// Record sizes of spec/format.md §1.2.
inline constexpr uint32_t kMetaInstanceBytes = 68, kMetaMeshHeaderBytes = 68, kMetaClusterBytes = 76,
                          kMetaGroupBytes = 60, kMetaBvhBytes = 76, kMetaPageEntryBytes = 24;

// A fixed-size record array in the raw metadata.
struct MetaArray {
  size_t at = 0;
  uint32_t count = 0, record_size = 0;
  bool transposed = false;
  size_t byte(uint32_t i, uint32_t offset) const {
    return transposed ? at + size_t(offset) * count + i : at + size_t(i) * record_size + offset;
  }
};

struct MetaLayout {
  MetaArray instances, pages;
  size_t page_count_at = 0;
  struct Mesh {
    // Header fields: flags +0, position_step +4, uv_step +8, normal_bits +12, level_count +16,
    // bounds +20, cluster/group/generated/bvh counts +44/+48/+52/+56, first_page +60, page_count +64.
    size_t header_at = 0;
    MetaArray clusters, groups, generated, bvh, page_clusters;
  };
  std::vector<Mesh> meshes;
};

uint32_t le32_at(const uint8_t* p);
void put_le32_at(uint8_t* p, uint32_t v);
uint32_t meta_get32(const std::vector<uint8_t>& raw, const MetaArray& a, uint32_t i, uint32_t offset);
void meta_put32(std::vector<uint8_t>& raw, const MetaArray& a, uint32_t i, uint32_t offset, uint32_t v);

// The layout of a raw metadata; false if it does not fit its bytes.
bool walk_metadata(const std::vector<uint8_t>& raw, uint32_t version, MetaLayout* layout);
// The raw (decompressed) metadata of a file; false if the header or the stream is broken.
bool raw_metadata(const std::vector<uint8_t>& file, std::vector<uint8_t>* raw);

using MetadataEdit = std::function<void(std::vector<uint8_t>& raw, const MetaLayout& layout)>;
// Applies `edit` to the raw metadata and stores it back uncompressed; file_size moves by the
// size change; every page CRC is recomputed through the page table as laid out before the
// edit (with the stored sizes after it), then the metadata and header CRCs.
bool edit_metadata(std::vector<uint8_t>& file, const MetadataEdit& edit);
// File offset of page `p`'s stored bytes.
bool page_offset(const std::vector<uint8_t>& file, uint32_t p, size_t* offset);
// Replaces page `p`'s stored bytes by what `edit` makes of them, stored_size (and raw_size
// when `raw_too`) updated, file_size and every CRC fixed.
bool edit_stored_page(std::vector<uint8_t>& file, uint32_t p, const std::function<void(std::vector<uint8_t>&)>& edit,
                      bool raw_too = true);
// The same on the page's raw (decompressed) bytes, recompressed with the file's codec.
bool edit_raw_page(std::vector<uint8_t>& file, uint32_t p, const std::function<void(std::vector<uint8_t>&)>& edit);
// Replaces the *stored* metadata bytes (compressed or not) by what `edit` makes of them:
// metadata_size and file_size move by the size change, the metadata CRC and the header CRC are
// recomputed (page CRCs are untouched: the pages are). False without a header and metadata.
bool edit_stored_metadata(std::vector<uint8_t>& file, const std::function<void(std::vector<uint8_t>&)>& edit);
// Recomputes every checksum the file's own bytes allow, changing nothing else: with
// uncompressed metadata (version 1, or metadata_compression 0) each page CRC the page table
// reaches within the file, then the metadata CRC (when the metadata lies within the file),
// then the header CRC. For a file whose bytes were cut or edited (`vgeo conform decoder
// --minimize`), so that the next check past the CRCs is reached.
void fix_checksums(std::vector<uint8_t>& file);
// Recomputes the header CRC only.
void fix_header_crc(std::vector<uint8_t>& file);

// Offsets inside a raw disk page (spec/format.md §5.2) of the cluster headers and sections.
struct RawPageLayout {
  uint32_t n = 0, channels = 0;
  size_t counts = 8, bits = 0, mins = 0, ctl = 0, ref_total = 0, refs = 0, run_start = 0, run_material = 0;
  uint64_t triangles = 0, runs = 0;
};
bool raw_page_layout(const std::vector<uint8_t>& page, uint32_t channels, RawPageLayout* layout);

}  // namespace vgeo
