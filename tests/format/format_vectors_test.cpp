// Conformance kit (spec/format.md §9): spec/vectors/ holds small valid files with the hash
// of their decoded scene and invalid files with the error code a decoder must report. The
// files are produced by make_vectors() below, never by hand:
//   VGEO_UPDATE_VECTORS=1 build/release/tests/test_format --gtest_filter=FormatVectors.*
// rewrites them (only on a deliberate format or encoder change). Without the variable the
// tests check the stored files and that the generator still reproduces them byte for byte
// (the encoder's output is pinned per format version).
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <map>
#include <set>
#include <stdexcept>
#include <sstream>

#include "format_file_edit.h"
#include "format_vector_edits.h"
#include "format_test_util.h"
#include "support/paths.h"
#include "vgeo/format/crc32c.h"
#include "vgeo/format/lz4_block.h"
#include "vgeo/format/page_codec.h"

namespace vgeo {
namespace {

namespace fs = std::filesystem;

struct Vector {
  std::string name;
  std::vector<uint8_t> bytes;
  std::string expected;  // "OK" (hashes added when written) or an error code
  std::vector<uint8_t> twin_bytes;  // invalid vectors: the valid file it was derived from
  std::string twin;                 // its name (resolved by resolve_twins)
};


// Offset of the version 2 copy mask in a raw (uncompressed) disk page (spec §5.2).
size_t copy_mask_offset(const uint8_t* page, uint32_t channels, uint64_t* total_vertices) {
  const uint32_t n = test::file_le32(page + 4);
  size_t at = 8;
  uint64_t tris = 0, runs = 0, verts = 0;
  for (uint32_t i = 0; i < n; ++i) verts += page[at + i], tris += page[at + n + i], runs += page[at + 2 * n + i];
  at += size_t(n) * (3 + 5 * channels) + tris;
  at += 4 + test::file_le32(page + at);
  *total_vertices = verts;
  return at + 5 * runs;
}

ClusterDag with_attributes(ClusterDag d, bool normals, bool uvs) {
  if (!normals) d.normals.clear();
  if (!uvs) d.uvs.clear();
  return d;
}

[[noreturn]] void generator_bug(const std::string& what) { throw std::logic_error("vector generator: " + what); }

// Every invalid vector names the valid file it was derived from (its twin, spec/format.md §9).
void resolve_twins(std::vector<Vector>& v) {
  for (Vector& x : v) {
    if (x.expected == "OK") continue;
    for (const Vector& y : v)
      if (y.expected == "OK" && y.bytes == x.twin_bytes) x.twin = y.name;
    if (x.twin.empty()) generator_bug(x.name + " has no valid twin in the set");
  }
}

// Version 2 vectors for every rule of spec/format.md §8 and the valid files of §9: mesh flag
// combinations, every normal_bits, several pages with split groups, wide UVs, and the
// multi-fault files that pin the check order. Metadata edits go through
// format_vector_edits.h (the metadata is then stored uncompressed, sizes and CRCs fixed).
void add_rule_vectors(std::vector<Vector>& v, const std::vector<uint8_t>& sphere_zstd, const std::vector<uint8_t>& grid_none) {
  using namespace test;
  FormatOptions none;
  none.compression = Compression::kNone;
  none.page_size = kMinPageSize;
  FormatOptions zstd = none;
  zstd.compression = Compression::kZstd;
  zstd.zstd_level = 9;
  auto valid = [&](const std::string& name, std::vector<uint8_t> bytes) {
    v.push_back({name, std::move(bytes), "OK", {}, ""});
    return v.back().bytes;
  };
  auto invalid = [&](const std::string& name, const std::vector<uint8_t>& base, const char* code,
                     const std::function<void(std::vector<uint8_t>&)>& edit) {
    std::vector<uint8_t> f = base;
    edit(f);
    v.push_back({name, std::move(f), code, base, ""});
  };
  auto meta = [](const MetadataEdit& e) { return [e](std::vector<uint8_t>& f) { edit_meta(f, e); }; };
  auto header = [](size_t at, uint32_t value) {
    return [at, value](std::vector<uint8_t>& f) {
      file_put32(&f[at], value);
      fix_file_crcs(f);
    };
  };

  // ---- valid: every mesh flag combination, every normal_bits ----
  const Mesh grid3 = make_grid(3);
  for (int flags = 0; flags < 4; ++flags) {
    static const char* const kNames[] = {"positions_only", "normals", "uvs", "normals_uvs"};
    valid(std::string("valid_flags_") + kNames[flags] + "_none.vgp",
          encode_format(scene_of({with_attributes(make_leaf_dag(grid3), flags & 1, flags & 2)}), none));
  }
  for (uint32_t b = 1; b <= kMaxNormalBits; ++b) {
    FormatOptions o = none;
    o.normal_bits = b;
    valid("valid_normal_bits_" + std::to_string(b) + "_none.vgp",
          encode_format(scene_of({with_attributes(make_leaf_dag(make_sphere(3, 6)), true, false)}), o));
  }
  // Several pages, groups split across pages, a BVH with inner nodes: the first group size
  // (from 2) whose placement splits a group (deterministic).
  // zstd keeps it at ~12 KB; its invalid twins edit only the metadata or whole stored pages.
  std::vector<uint8_t> pages_zstd;
  for (uint32_t group_size = 2; pages_zstd.empty(); ++group_size) {
    if (group_size > 8) generator_bug("valid_pages_split_groups_zstd.vgp: no group size splits a group");
    const std::vector<uint8_t> f = encode_format(scene_of({make_leaf_dag(make_sphere(40, 48), group_size)}), zstd);
    const FormatContainer fc = parse_container(f.data(), f.size(), "gen");
    bool split = false, inner = false;
    for (uint32_t n : fc.meshes[0].group_page_count) split |= n > 1;
    for (const BvhNode& n : fc.meshes[0].dag.bvh_nodes) inner |= n.group_mask != (1u << n.child_count) - 1;
    if (fc.pages.size() >= 2 && split && inner) pages_zstd = valid("valid_pages_split_groups_zstd.vgp", f);
  }
  const std::vector<uint8_t> two_meshes_none =
      valid("valid_two_meshes_none.vgp", encode_format(scene_of({make_leaf_dag(grid3), make_leaf_dag(make_grid(4))}), none));
  const std::vector<uint8_t> two_level_none =
      valid("valid_generated_none.vgp", encode_format(scene_of({make_two_level_dag(make_grid(12, 2.0f), make_grid(4, 2.0f))}), none));
  // Tiling UVs far outside [0, 1]: the step is coarsened per mesh (spec/format.md §2).
  {
    ClusterDag wide = make_leaf_dag(grid3);
    for (size_t i = 0; i < wide.uvs.size(); ++i) wide.uvs[i] = wide.uvs[i] * 3.0e6f - 1.0e6f;
    valid("valid_uv_wide_none.vgp", encode_format(scene_of({wide}), none));
    ClusterDag huge = make_leaf_dag(grid3);
    huge.uvs[0] = std::numeric_limits<float>::max(), huge.uvs[1] = -std::numeric_limits<float>::max();
    valid("valid_uv_float_max_none.vgp", encode_format(scene_of({huge}), none));
  }
  const std::vector<uint8_t> grid_lz4 = [&] {
    for (const Vector& x : v)
      if (x.name == "valid_grid_uv_lz4.vgp") return x.bytes;
    generator_bug("valid_grid_uv_lz4.vgp missing");
  }();

  // ---- header (§8 A) ----
  invalid("header_size_not_64.vgp", sphere_zstd, kErrInconsistent, header(12, 65));
  invalid("reserved_header_byte.vgp", sphere_zstd, kErrUnsupported, [](auto& f) { f[56] = 1, fix_file_crcs(f); });
  invalid("metadata_compression_none_size_mismatch.vgp", grid_none, kErrInconsistent, header(44, file_le32(&grid_none[36]) + 1));
  invalid("file_size_below_metadata.vgp", grid_none, kErrInconsistent, header(16, 64));
  invalid("truncated_in_metadata.vgp", grid_none, kErrTruncated, [](auto& f) { f.resize(64 + 10); });
  invalid("metadata_checksum.vgp", grid_none, kErrChecksum, [](auto& f) { f[64 + 1] ^= 1; });
  invalid("metadata_zstd_trailing_bytes.vgp", sphere_zstd, kErrTrailingBytes, [](auto& f) {
    // One byte after the metadata's zstd frame (metadata_size + 1, pages shifted, CRCs fixed).
    const uint32_t ms = file_le32(&f[36]);
    f.insert(f.begin() + 64 + ms, 0);
    file_put32(&f[36], ms + 1);
    file_put32(&f[16], file_le32(&f[16]) + 1);
    file_put32(&f[40], crc32c(&f[64], ms + 1));
    file_put32(&f[60], crc32c(f.data(), 60));
  });

  // ---- metadata (§8 B) ----
  auto mesh_field = [&](uint32_t mesh, uint32_t offset, uint32_t value) {
    return meta([=](std::vector<uint8_t>& m, const MetaLayout& L) { file_put32(&m[L.meshes[mesh].header_at + offset], value); });
  };
  invalid("mesh_flags_unknown.vgp", grid_none, kErrUnsupported, mesh_field(0, 0, 4 | 3));
  invalid("position_step_out_of_range.vgp", grid_none, kErrOutOfRange, mesh_field(0, 4, uint32_t(kMaxStepLog2 + 1)));
  invalid("uv_step_out_of_range.vgp", grid_none, kErrOutOfRange, mesh_field(0, 8, uint32_t(kMaxUvStepLog2 + 1)));
  invalid("normal_bits_zero.vgp", grid_none, kErrOutOfRange, mesh_field(0, 12, 0));
  invalid("normal_bits_over_16.vgp", grid_none, kErrOutOfRange, mesh_field(0, 12, kMaxNormalBits + 1));
  invalid("first_page_not_tiling.vgp", two_meshes_none, kErrInconsistent, mesh_field(1, 60, 0));
  invalid("mesh_pages_not_covering.vgp", pages_zstd, kErrInconsistent, meta([](auto& m, const MetaLayout& L) {
    file_put32(&m[L.meshes[0].header_at + 64], file_le32(&m[L.meshes[0].header_at + 64]) - 1);
  }));
  invalid("clusters_without_pages.vgp", two_meshes_none, kErrInconsistent, [&](auto& f) {
    // Mesh 1 claims no page (tiling still holds: header and metadata page counts follow).
    edit_meta(f, [](auto& m, const MetaLayout& L) {
      file_put32(&m[L.meshes[1].header_at + 64], 0);
      file_put32(&m[L.page_count_at], file_le32(&m[L.page_count_at]) - 1);
    });
    file_put32(&f[32], file_le32(&f[32]) - 1);
    file_put32(&f[60], crc32c(f.data(), 60));
  });
  invalid("mesh_counts_exceed_metadata.vgp", grid_none, kErrTruncated, mesh_field(0, 56, 1u << 24));
  auto cluster_field = [&](uint32_t offset, uint32_t value) {
    return meta([=](auto& m, const MetaLayout& L) { meta_put32(m, L.meshes[0].clusters, 0, offset, value); });
  };
  invalid("cluster_group_out_of_range.vgp", grid_none, kErrOutOfRange, cluster_field(0, 1000));
  invalid("cluster_generating_group_out_of_range.vgp", grid_none, kErrOutOfRange, cluster_field(4, 1000));
  invalid("cluster_vertex_count_zero.vgp", grid_none, kErrOutOfRange, cluster_field(12, 0));
  invalid("cluster_vertex_count_over_255.vgp", grid_none, kErrOutOfRange, cluster_field(12, 256));
  invalid("cluster_triangle_count_over_128.vgp", grid_none, kErrOutOfRange, cluster_field(16, 129));
  invalid("sphere_not_finite.vgp", grid_none, kErrOutOfRange, cluster_field(32, 0x7FC00000u));  // bounds radius NaN
  invalid("lod_error_negative.vgp", grid_none, kErrOutOfRange, cluster_field(72, 0xBF800000u));  // parent_error -1
  invalid("group_range_out_of_range.vgp", grid_none, kErrOutOfRange,
          meta([](auto& m, const MetaLayout& L) { meta_put32(m, L.meshes[0].groups, 0, 4, 1000); }));
  invalid("group_flags_unknown.vgp", grid_none, kErrUnsupported,
          meta([](auto& m, const MetaLayout& L) { meta_put32(m, L.meshes[0].groups, 0, 20, 2); }));
  invalid("generated_id_out_of_range.vgp", two_level_none, kErrOutOfRange,
          meta([](auto& m, const MetaLayout& L) { meta_put32(m, L.meshes[0].generated, 0, 0, L.meshes[0].clusters.count); }));
  auto bvh = [&](const char* name, const char* code, auto edit) {
    invalid(name, pages_zstd, code, meta([edit](auto& m, const MetaLayout& L) { edit(m, L.meshes[0].bvh); }));
  };
  bvh("bvh_child_count_over_8.vgp", kErrOutOfRange, [](auto& m, const MetaArray& b) { meta_put32(m, b, 0, 36, 9); });
  bvh("bvh_mask_beyond_child_count.vgp", kErrOutOfRange, [](auto& m, const MetaArray& b) {
    meta_put32(m, b, 0, 40, meta_get32(m, b, 0, 40) | 1u << meta_get32(m, b, 0, 36));
  });
  bvh("bvh_unused_slot_not_empty.vgp", kErrOutOfRange, [](auto& m, const MetaArray& b) {
    for (uint32_t i = 0; i < b.count; ++i)
      if (meta_get32(m, b, i, 36) < kBvhMaxChildren) return meta_put32(m, b, i, 44 + 4 * (kBvhMaxChildren - 1), 0);
    generator_bug("no BVH node with a free slot");
  });
  auto first_child = [](const std::vector<uint8_t>& m, const MetaArray& b, bool group, uint32_t* node) {
    for (uint32_t i = 0; i < b.count; ++i)
      for (uint32_t k = 0; k < meta_get32(m, b, i, 36); ++k)
        if (bool((meta_get32(m, b, i, 40) >> k) & 1u) == group) return *node = i, k;
    generator_bug("no BVH child of that kind");
  };
  bvh("bvh_group_child_out_of_range.vgp", kErrOutOfRange, [&](auto& m, const MetaArray& b) {
    uint32_t i = 0;
    const uint32_t k = first_child(m, b, true, &i);
    meta_put32(m, b, i, 44 + 4 * k, 100000);
  });
  bvh("bvh_node_child_is_root.vgp", kErrInconsistent, [&](auto& m, const MetaArray& b) {
    uint32_t i = 0;
    const uint32_t k = first_child(m, b, false, &i);
    meta_put32(m, b, i, 44 + 4 * k, 0);
  });
  bvh("bvh_node_child_twice.vgp", kErrInconsistent, [&](auto& m, const MetaArray& b) {
    // The root's first two node children made equal: one node with two parents.
    if (meta_get32(m, b, 0, 36) < 2 || (meta_get32(m, b, 0, 40) & 3u)) generator_bug("root without two node children");
    meta_put32(m, b, 0, 48, meta_get32(m, b, 0, 44));
  });
  invalid("page_clusters_not_permutation.vgp", pages_zstd, kErrInconsistent, meta([](auto& m, const MetaLayout& L) {
    meta_put32(m, L.meshes[0].page_clusters, 1, 0, meta_get32(m, L.meshes[0].page_clusters, 0, 0));
  }));
  invalid("group_parts_not_consecutive.vgp", pages_zstd, kErrInconsistent, meta([](auto& m, const MetaLayout& L) {
    // Swap the first and the last slot: both pages keep their cluster counts, groups break.
    const MetaArray& pc = L.meshes[0].page_clusters;
    const uint32_t a = meta_get32(m, pc, 0, 0), b = meta_get32(m, pc, pc.count - 1, 0);
    meta_put32(m, pc, 0, 0, b);
    meta_put32(m, pc, pc.count - 1, 0, a);
  }));
  invalid("instance_mesh_out_of_range.vgp", grid_none, kErrOutOfRange,
          meta([](auto& m, const MetaLayout& L) { meta_put32(m, L.instances, 0, 0, 7); }));
  invalid("page_table_count_mismatch.vgp", grid_none, kErrInconsistent,
          meta([](auto& m, const MetaLayout& L) { file_put32(&m[L.page_count_at], file_le32(&m[L.page_count_at]) + 1); }));
  invalid("page_table_truncated.vgp", grid_none, kErrTruncated, meta([](auto& m, const MetaLayout&) { m.pop_back(); }));
  auto page_field = [&](uint32_t page, uint32_t offset, uint32_t value) {
    return meta([=](auto& m, const MetaLayout& L) { meta_put32(m, L.pages, page, offset, value); });
  };
  invalid("page_entry_mesh_out_of_range.vgp", grid_none, kErrOutOfRange, page_field(0, 0, 5));
  invalid("page_entry_stored_size_zero.vgp", grid_none, kErrOutOfRange, page_field(0, 4, 0));
  invalid("page_entry_raw_size_below_8.vgp", grid_none, kErrOutOfRange, page_field(0, 8, 7));
  invalid("page_entry_raw_size_over_2x_page.vgp", grid_none, kErrOutOfRange, page_field(0, 8, 2 * kMinPageSize + 1));
  invalid("page_entry_memory_size_over_page.vgp", grid_none, kErrOutOfRange, page_field(0, 12, kMinPageSize + 4));
  invalid("page_entry_memory_size_unaligned.vgp", grid_none, kErrOutOfRange, page_field(0, 12, 402));
  invalid("page_entry_cluster_count_zero.vgp", grid_none, kErrOutOfRange, page_field(0, 16, 0));
  invalid("page_entry_descriptors_over_memory.vgp", grid_none, kErrOutOfRange, page_field(0, 12, 40));
  invalid("uncompressed_stored_ne_raw.vgp", grid_none, kErrInconsistent, meta([](auto& m, const MetaLayout& L) {
    meta_put32(m, L.pages, 0, 8, meta_get32(m, L.pages, 0, 8) - 1);
  }));
  invalid("metadata_trailing_byte.vgp", grid_none, kErrTrailingBytes, meta([](auto& m, const MetaLayout&) { m.push_back(0); }));
  invalid("page_mesh_mismatch.vgp", two_meshes_none, kErrInconsistent, page_field(1, 0, 0));
  invalid("page_cluster_counts_exceed_mesh.vgp", pages_zstd, kErrInconsistent, meta([](auto& m, const MetaLayout& L) {
    meta_put32(m, L.pages, 0, 16, meta_get32(m, L.pages, 0, 16) + 1);
  }));
  invalid("page_cluster_counts_short_of_mesh.vgp", pages_zstd, kErrInconsistent, meta([](auto& m, const MetaLayout& L) {
    meta_put32(m, L.pages, 0, 16, meta_get32(m, L.pages, 0, 16) - 1);
  }));
  invalid("memory_size_mismatch.vgp", grid_none, kErrInconsistent, meta([](auto& m, const MetaLayout& L) {
    meta_put32(m, L.pages, 0, 12, meta_get32(m, L.pages, 0, 12) + 4);
  }));
  invalid("cluster_counts_differ_from_page.vgp", grid_none, kErrInconsistent, meta([](auto& m, const MetaLayout& L) {
    // The cluster in page slot 0 claims one vertex more than its page stores.
    const uint32_t c = meta_get32(m, L.meshes[0].page_clusters, 0, 0);
    meta_put32(m, L.meshes[0].clusters, c, 12, meta_get32(m, L.meshes[0].clusters, c, 12) + 1);
  }));

  // ---- compression (§5.1) ----
  invalid("zstd_bytes_after_frame.vgp", sphere_zstd, kErrTrailingBytes,
          [](auto& f) { edit_page(f, 0, [](auto& p) { p.push_back(0); }, false); });
  invalid("zstd_skippable_frame.vgp", sphere_zstd, kErrDecompress, [](auto& f) {
    edit_page(f, 0, [](auto& p) { p.insert(p.begin(), {0x50, 0x2A, 0x4D, 0x18, 0, 0, 0, 0}); }, false);
  });
  invalid("zstd_content_size_mismatch.vgp", sphere_zstd, kErrDecompress, meta([](auto& m, const MetaLayout& L) {
    meta_put32(m, L.pages, 0, 8, meta_get32(m, L.pages, 0, 8) + 1);
  }));
  invalid("lz4_block_cut.vgp", grid_lz4, kErrDecompress, [](auto& f) { edit_page(f, 0, [](auto& p) { p.pop_back(); }, false); });
  invalid("lz4_output_longer_than_raw_size.vgp", grid_lz4, kErrDecompress, [](auto& f) {
    edit_meta(f, [](auto& m, const MetaLayout& L) { meta_put32(m, L.pages, 0, 8, meta_get32(m, L.pages, 0, 8) - 1); });
  });
  invalid("lz4_output_shorter_than_raw_size.vgp", grid_lz4, kErrDecompress, [](auto& f) {
    edit_meta(f, [](auto& m, const MetaLayout& L) { meta_put32(m, L.pages, 0, 8, meta_get32(m, L.pages, 0, 8) + 1); });
  });

  // A match offset of 0 (every offset MUST be >= 1): LZ4_decompress_safe alone accepts it and
  // copies the output buffer's own bytes — zeros in a zeroed buffer. The match chosen copies
  // zeros, so such a decoder decodes the file to its twin's hash (as vgeo did).
  invalid("lz4_match_offset_zero.vgp", grid_lz4, kErrDecompress, [](auto& f) {
    edit_page(f, 0, [](std::vector<uint8_t>& p) {
      uint64_t raw_size = 0;
      walk_lz4_block(p.data(), p.size(), [&](const Lz4Sequence& s) {
        raw_size += s.literal_count + s.match_length;
        return true;
      });
      std::vector<uint8_t> raw(raw_size);
      format_detail::decompress(p.data(), p.size(), Compression::kLz4, raw.data(), raw.size(), "gen");
      size_t out = 0, zero_match = 0, first_match = 0;
      walk_lz4_block(p.data(), p.size(), [&](const Lz4Sequence& s) {
        out += s.literal_count;
        if (s.has_match && first_match == 0) first_match = s.offset_at;
        if (s.has_match && zero_match == 0 &&
            std::all_of(raw.begin() + long(out), raw.begin() + long(out + s.match_length), [](uint8_t b) { return b == 0; }))
          zero_match = s.offset_at;
        out += size_t(s.match_length);
        return true;
      });
      const size_t at = zero_match ? zero_match : first_match;
      if (at == 0) generator_bug("lz4_match_offset_zero.vgp: page 0 holds no match");
      p[at] = 0, p[at + 1] = 0;
    }, false);
  });

  // ---- raw page (§5.2), first page of grid_none ----
  const FormatContainer gc = parse_container(grid_none.data(), grid_none.size(), "gen");
  const uint32_t C = gc.meshes[0].quantization.channel_count();
  auto page = [&](const char* name, const char* code, const std::function<void(std::vector<uint8_t>&, const RawPageLayout&)>& edit,
                  const std::vector<uint8_t>& base = {}) {
    const std::vector<uint8_t>& b = base.empty() ? grid_none : base;
    invalid(name, b, code, [&](auto& f) {
      edit_page(f, 0, [&](std::vector<uint8_t>& p) { edit(p, page_layout(p, C)); });
    });
  };
  page("page_vertex_count_zero.vgp", kErrOutOfRange, [](auto& p, const RawPageLayout& L) { p[L.counts] = 0; });
  page("page_triangle_count_over_128.vgp", kErrOutOfRange, [](auto& p, const RawPageLayout& L) { p[L.counts + L.n] = 129; });
  page("page_run_count_over_triangles.vgp", kErrOutOfRange,
       [](auto& p, const RawPageLayout& L) { p[L.counts + 2 * L.n] = uint8_t(p[L.counts + L.n] + 1); });
  page("page_channel_bits_over_25.vgp", kErrOutOfRange, [](auto& p, const RawPageLayout& L) { p[L.bits] = 26; });
  page("page_channel_min_out_of_range.vgp", kErrOutOfRange,
       [](auto& p, const RawPageLayout& L) { file_put32(&p[L.mins], uint32_t(kMaxQuantized + 1)); });
  page("page_normal_min_out_of_range.vgp", kErrOutOfRange,
       [](auto& p, const RawPageLayout& L) { file_put32(&p[L.mins + 4 * 3], 1u << 12); });  // channel 3: normal u
  page("ref_total_over_3x_triangles.vgp", kErrOutOfRange,
       [](auto& p, const RawPageLayout& L) { file_put32(&p[L.ref_total], uint32_t(3 * L.triangles + 1)); });
  page("strip_more_vertices_than_cluster.vgp", kErrOutOfRange, [](auto& p, const RawPageLayout& L) {
    // Turn cluster 0's first reference into a new vertex: the strip then introduces one more.
    for (size_t t = 0; t < p[L.counts + L.n]; ++t) {
      uint8_t& c = p[L.ctl + t];
      const uint8_t mask = (c & 1) ? 0x1C : 0x04;
      if (c & mask) {
        c &= uint8_t(~(c & mask & uint8_t(-(c & mask))));  // lowest set reference bit
        return;
      }
    }
    generator_bug("cluster 0 has no reference");
  });
  page("reference_not_yet_introduced.vgp", kErrOutOfRange, [](auto& p, const RawPageLayout& L) { p[L.refs] = 0xFF; });
  page("references_run_out.vgp", kErrInconsistent, [](auto& p, const RawPageLayout& L) {
    const uint32_t n = file_le32(&p[L.ref_total]);
    p.erase(p.begin() + long(L.refs + n - 1));
    file_put32(&p[L.ref_total], n - 1);
  });
  page("references_left_unused.vgp", kErrInconsistent, [](auto& p, const RawPageLayout& L) {
    const uint32_t n = file_le32(&p[L.ref_total]);
    p.insert(p.begin() + long(L.refs + n), 0);
    file_put32(&p[L.ref_total], n + 1);
  });
  auto first_multi_run = [](const std::vector<uint8_t>& p, const RawPageLayout& L, size_t* run) {
    size_t r = 0;
    for (uint32_t i = 0; i < L.n; ++i) {
      if (p[L.counts + 2 * L.n + i] >= 2) return *run = r, i;
      r += p[L.counts + 2 * L.n + i];
    }
    generator_bug("no cluster with two material runs");
  };
  page("run_start_not_zero.vgp", kErrOutOfRange, [](auto& p, const RawPageLayout& L) { p[L.run_start] = 1; });
  page("run_starts_not_increasing.vgp", kErrOutOfRange, [&](auto& p, const RawPageLayout& L) {
    size_t r = 0;
    first_multi_run(p, L, &r);
    p[L.run_start + r + 1] = 0;
  });
  page("run_material_over_limit.vgp", kErrOutOfRange,
       [](auto& p, const RawPageLayout& L) { file_put32(&p[L.run_material], kMaxMaterialId + 1); });
  page("run_materials_not_increasing.vgp", kErrNonCanonical, [&](auto& p, const RawPageLayout& L) {
    size_t r = 0;
    first_multi_run(p, L, &r);
    file_put32(&p[L.run_material + 4 * (r + 1)], file_le32(&p[L.run_material + 4 * r]));
  });
  page("page_magic_version_1_in_version_2.vgp", kErrBadMagic, [](auto& p, const RawPageLayout&) { file_put32(&p[0], 0x47504456u); });
  page("page_longer_than_sections.vgp", kErrTrailingBytes, [](auto& p, const RawPageLayout&) { p.push_back(0); });
  page("page_shorter_than_sections.vgp", kErrTruncated, [](auto& p, const RawPageLayout&) { p.pop_back(); });

  // ---- multi-fault files: the first failing check of §8 wins ----
  invalid("multi_version_before_header_crc.vgp", sphere_zstd, kErrBadVersion, [](auto& f) { file_put32(&f[8], 9); });
  invalid("multi_compression_before_page_size.vgp", sphere_zstd, kErrUnsupported, [](auto& f) {
    file_put32(&f[24], 3), file_put32(&f[28], 3u << 14), fix_file_crcs(f);
  });
  invalid("multi_page_size_before_reserved.vgp", sphere_zstd, kErrOutOfRange, [](auto& f) {
    file_put32(&f[28], 3u << 14), f[56] = 1, fix_file_crcs(f);
  });
  invalid("multi_file_size_before_truncation.vgp", grid_none, kErrInconsistent, [](auto& f) {
    file_put32(&f[16], 64), fix_file_crcs(f), f.resize(64 + 10);
  });
  invalid("multi_mesh_before_page_table.vgp", grid_none, kErrUnsupported, meta([](auto& m, const MetaLayout& L) {
    file_put32(&m[L.meshes[0].header_at], 4);
    file_put32(&m[L.page_count_at], file_le32(&m[L.page_count_at]) + 1);
  }));
  invalid("multi_meshes_before_instances.vgp", grid_none, kErrUnsupported, meta([](auto& m, const MetaLayout& L) {
    meta_put32(m, L.instances, 0, 0, 7);  // checked after the meshes (B5)
    file_put32(&m[L.meshes[0].header_at], 4);
  }));
  invalid("multi_clusters_before_groups.vgp", grid_none, kErrOutOfRange, meta([](auto& m, const MetaLayout& L) {
    meta_put32(m, L.meshes[0].groups, 0, 20, 2);                           // group flags: UNSUPPORTED
    meta_put32(m, L.meshes[0].clusters, L.meshes[0].clusters.count - 1, 72, 0xBF800000u);  // last cluster: OUT_OF_RANGE
  }));
  invalid("multi_permutation_before_page_entries.vgp", pages_zstd, kErrInconsistent, meta([](auto& m, const MetaLayout& L) {
    meta_put32(m, L.meshes[0].page_clusters, 1, 0, meta_get32(m, L.meshes[0].page_clusters, 0, 0));
    meta_put32(m, L.pages, 0, 12, 402);
  }));
  invalid("multi_metadata_trailing_before_file_size.vgp", grid_none, kErrTrailingBytes, [](auto& f) {
    edit_meta(f, [](auto& m, const MetaLayout&) { m.push_back(0); });
    file_put32(&f[16], file_le32(&f[16]) + 1);
    file_put32(&f[60], crc32c(f.data(), 60));
  });
  invalid("multi_truncated_before_page_crc.vgp", grid_none, kErrTruncated, [](auto& f) {
    f[f.size() - 2] ^= 1;  // page CRC now wrong, and the file one byte short
    f.pop_back();
  });
  invalid("multi_page_crc_before_page_magic.vgp", grid_none, kErrChecksum, [&](auto& f) { f[gc.pages[0].file_offset] ^= 1; });
  invalid("multi_topology_before_vertices.vgp", grid_none, kErrOutOfRange, [&](auto& f) {
    edit_page(f, 0, [&](std::vector<uint8_t>& p) {
      const RawPageLayout L = page_layout(p, C);
      p[L.ctl] |= 0x80;  // reserved strip bit: OUT_OF_RANGE
      p[L.bits] += 1;    // wider than needed, same planes: NON_CANONICAL (later)
    });
  });
  invalid("multi_runs_before_vertices.vgp", grid_none, kErrNonCanonical, [&](auto& f) {
    edit_page(f, 0, [&](std::vector<uint8_t>& p) {
      const RawPageLayout L = page_layout(p, C);
      size_t r = 0;
      first_multi_run(p, L, &r);
      file_put32(&p[L.run_material + 4 * (r + 1)], file_le32(&p[L.run_material + 4 * r]));  // NON_CANONICAL
      file_put32(&p[L.mins], file_le32(&p[L.mins]) - 1);  // min below the values: NON_CANONICAL too, but later
    });
  });
  invalid("multi_first_page_wins.vgp", pages_zstd, kErrChecksum, [&](auto& f) {
    edit_page(f, 1, [](std::vector<uint8_t>& p) { p.push_back(0); }, false);  // page 1: TRAILING_BYTES
    f[page_at(f, 0) + 5] ^= 1;                                                // page 0: CHECKSUM
  });
  invalid("multi_unused_refs_after_clusters.vgp", grid_none, kErrNonCanonical, [&](auto& f) {
    edit_page(f, 0, [&](std::vector<uint8_t>& p) {
      const RawPageLayout L = page_layout(p, C);
      const uint32_t n = file_le32(&p[L.ref_total]);
      p.insert(p.begin() + long(L.refs + n), 0);  // an unused reference: INCONSISTENT after the last cluster
      file_put32(&p[L.ref_total], n + 1);
      const RawPageLayout M = page_layout(p, C);
      size_t r = 0;
      first_multi_run(p, M, &r);
      file_put32(&p[M.run_material + 4 * (r + 1)], file_le32(&p[M.run_material + 4 * r]));  // NON_CANONICAL first
    });
  });
}

// One set per format version: names of the version 1 set start with "v1_" (files of
// version N keep decoding under N+1, spec §Versioning).
std::vector<Vector> make_vectors(uint32_t version) {
  std::vector<Vector> v;
  const std::string prefix = version == kFormatVersion ? "" : "v" + std::to_string(version) + "_";
  FormatOptions zstd;
  zstd.zstd_level = 9;
  zstd.version = version;
  if (version == 1) zstd.normal_bits = 10;  // the version 1 default: the v1_ files stay as first written
  FormatOptions none = zstd, lz4 = zstd;
  none.compression = Compression::kNone;
  lz4.compression = Compression::kLz4;
  none.page_size = lz4.page_size = kMinPageSize;

  const BuiltScene sphere = test::scene_of({test::make_leaf_dag(test::make_sphere(6, 12))});
  const std::vector<uint8_t> sphere_zstd = encode_format(sphere, zstd);
  v.push_back({prefix + "valid_sphere_zstd.vgp", sphere_zstd, "OK", {}, ""});
  v.push_back({prefix + "valid_grid_uv_lz4.vgp", encode_format(test::scene_of({test::make_leaf_dag(test::make_grid(10, 1.0f, true))}), lz4), "OK", {}, ""});
  v.push_back({prefix + "valid_two_level_none.vgp",
               encode_format(test::scene_of({test::make_two_level_dag(test::make_grid(24, 2.0f), test::make_grid(8, 2.0f))}), none), "OK", {}, ""});
  {
    // A cluster whose triangles span more than 32 indices (wide index offsets) and a mesh with
    // several materials per cluster, two meshes.
    ClusterDag d = test::make_leaf_dag(test::make_sphere(8, 16));
    DagCluster& c = d.clusters[0];
    for (uint32_t t = 0; t + 1 < c.triangle_count; t += 2)
      std::swap(d.indices[3 * (c.triangle_offset + t)], d.indices[3 * (c.triangle_offset + c.triangle_count - 1 - t / 2) + 1]);
    v.push_back({prefix + "valid_wide_index_two_meshes_zstd.vgp",
                 encode_format(test::scene_of({d, test::make_leaf_dag(test::make_grid(3))}), zstd), "OK", {}, ""});
  }
  auto derived = [&](const std::string& name, const std::vector<uint8_t>& base, const std::string& code, auto edit, bool crc) {
    std::vector<uint8_t> f = base;
    edit(f);
    if (crc) test::fix_file_crcs(f);
    v.push_back({prefix + name, f, code, base, ""});
  };
  const FormatContainer fc = parse_container(sphere_zstd.data(), sphere_zstd.size(), "gen");
  const size_t page0 = fc.pages[0].file_offset;
  derived("bad_magic.vgp", sphere_zstd, kErrBadMagic, [](auto& f) { f[3] = 'X'; }, false);
  derived("bad_version.vgp", sphere_zstd, kErrBadVersion, [](auto& f) { test::file_put32(&f[8], kFormatVersion + 1); }, true);
  derived("truncated.vgp", sphere_zstd, kErrTruncated, [](auto& f) { f.pop_back(); }, false);
  derived("trailing_byte.vgp", sphere_zstd, kErrTrailingBytes, [](auto& f) { f.push_back(0); }, false);
  derived("header_checksum.vgp", sphere_zstd, kErrChecksum, [](auto& f) { f[44] ^= 1; }, false);
  derived("page_checksum.vgp", sphere_zstd, kErrChecksum, [&](auto& f) { f[page0 + 7] ^= 0x10; }, false);
  derived("unknown_compression.vgp", sphere_zstd, kErrUnsupported, [](auto& f) { test::file_put32(&f[24], 3); }, true);
  derived("page_size_out_of_range.vgp", sphere_zstd, kErrOutOfRange, [](auto& f) { test::file_put32(&f[28], 3u << 14); }, true);
  derived("file_size_inconsistent.vgp", sphere_zstd, kErrInconsistent, [](auto& f) { test::file_put32(&f[16], test::file_le32(&f[16]) - 1); }, true);
  derived("zstd_frame_broken.vgp", sphere_zstd, kErrDecompress, [&](auto& f) { f[page0] ^= 0xFF; }, true);
  // Raw (uncompressed) page edits: offsets from spec §5.2 for the first page.
  const BuiltScene grid = test::scene_of({test::make_leaf_dag(test::make_grid(6))});
  const std::vector<uint8_t> grid_none = encode_format(grid, none);
  // Metadata edit (plain metadata in version 1; in version 2 only without compression).
  derived("material_name_too_long.vgp", version == 1 ? sphere_zstd : grid_none, kErrOutOfRange,
          [](auto& f) { test::file_put32(&f[68], 4097); }, true);
  if (version >= 2) {
    derived("metadata_compression_unknown.vgp", sphere_zstd, kErrUnsupported, [](auto& f) { test::file_put32(&f[48], 3); }, true);
    derived("metadata_raw_size_over_cap.vgp", sphere_zstd, kErrOutOfRange,
            [](auto& f) { test::file_put32(&f[44], kMaxMetadataRatio * test::file_le32(&f[36]) + 1); }, true);
    derived("metadata_raw_size_mismatch.vgp", sphere_zstd, kErrDecompress, [](auto& f) { test::file_put32(&f[44], test::file_le32(&f[44]) + 1); }, true);
    // A page of several clusters with vertex copies (spec §5.2 version 2).
    const std::vector<uint8_t> multi = encode_format(test::scene_of({test::make_leaf_dag(test::make_grid(24, 1.0f, true))}), none);
    v.push_back({"valid_copies_none.vgp", multi, "OK", {}, ""});
    const FormatContainer mc = parse_container(multi.data(), multi.size(), "gen");
    const size_t mp = mc.pages[0].file_offset;
    uint64_t verts = 0;
    const size_t mask = mp + copy_mask_offset(&multi[mp], mc.meshes[0].quantization.channel_count(), &verts);
    if (verts % 8)
      derived("copy_mask_padding.vgp", multi, kErrOutOfRange, [&](auto& f) { f[mask + verts / 8] |= 0x80; }, true);
    uint64_t copies = 0;
    for (uint64_t i = 0; i < verts; ++i) copies += (multi[mask + i / 8] >> (i % 8)) & 1;
    if (copies > 0)  // plane 3 of the first copy reference: a source far beyond the page
      derived("copy_source_out_of_range.vgp", multi, kErrOutOfRange,
              [&](auto& f) { f[mask + (verts + 7) / 8 + 3 * copies] = 0x7F; }, true);
  }
  const FormatContainer gc = parse_container(grid_none.data(), grid_none.size(), "gen");
  const size_t p = gc.pages[0].file_offset;
  const uint32_t n = gc.pages[0].cluster_count, C = gc.meshes[0].quantization.channel_count();
  v.push_back({prefix + "valid_grid_none.vgp", grid_none, "OK", {}, ""});
  derived("page_cluster_count_mismatch.vgp", grid_none, kErrInconsistent, [&](auto& f) { test::file_put32(&f[p + 4], n + 1); }, true);
  derived("page_bad_magic.vgp", grid_none, kErrBadMagic, [&](auto& f) { f[p] ^= 1; }, true);
  const size_t ctl = p + 8 + size_t(n) * (3 + 5 * C);
  derived("strip_reserved_bit.vgp", grid_none, kErrOutOfRange, [&](auto& f) { f[ctl] |= 0x80; }, true);
  derived("strip_first_not_reset.vgp", grid_none, kErrOutOfRange, [&](auto& f) { f[ctl] = 0; }, true);
  // Widen channel 0 of cluster 0 by one bit where the byte-plane count stays the same:
  // still decodable, but not the tightest encoding.
  const size_t bits0 = p + 8 + 3 * size_t(n);
  if ((grid_none[bits0] + 2 + 7) / 8 == (grid_none[bits0] + 1 + 7) / 8)
    derived("channel_bits_not_tightest.vgp", grid_none, kErrNonCanonical, [&](auto& f) { f[bits0] += 1; }, true);
  if (version >= 2) add_rule_vectors(v, sphere_zstd, grid_none);
  resolve_twins(v);
  return v;
}

// `OK <decode hash> memory=<memory-form hash>` or the error code (spec/format.md §9).
std::string outcome(const std::vector<uint8_t>& f) {
  try {
    const BuiltScene s = decode_format(f.data(), f.size(), "<vector>");
    char hex[64];
    std::snprintf(hex, sizeof hex, "OK %016llx memory=%016llx", static_cast<unsigned long long>(test::decoded_hash(s)),
                  static_cast<unsigned long long>(memory_form_hash(f.data(), f.size(), "<vector>")));
    return hex;
  } catch (const VgeoError& e) {
    return e.error().code;
  }
}

// The manifest line of a vector: `name expected[ twin=NAME]`.
std::string manifest_line(const Vector& v, const std::string& got) {
  return v.name + " " + got + (v.twin.empty() ? "" : " twin=" + v.twin);
}

fs::path vector_dir() { return test::source_dir() / "spec" / "vectors"; }

std::vector<uint8_t> read_file(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// Both versions' sets, generated once per test binary run.
const std::vector<Vector>& all_vectors() {
  static const std::vector<Vector> all = [] {
    std::vector<Vector> v = make_vectors(kMinFormatVersion);
    for (Vector& x : make_vectors(kFormatVersion)) v.push_back(std::move(x));
    return v;
  }();
  return all;
}

TEST(FormatVectors, ManifestMatches) {
  const std::vector<Vector>& vectors = all_vectors();
  if (const char* u = std::getenv("VGEO_UPDATE_VECTORS"); u && std::string(u) == "1") {
    fs::create_directories(vector_dir());
    std::ofstream manifest(vector_dir() / "manifest.txt");
    manifest << "# name expected [twin=valid file it was derived from] — spec/format.md §9;"
                " generated by tests/format/format_vectors_test.cpp\n";
    for (const Vector& v : vectors) {
      std::ofstream(vector_dir() / v.name, std::ios::binary)
          .write(reinterpret_cast<const char*>(v.bytes.data()), std::streamsize(v.bytes.size()));
      const std::string got = outcome(v.bytes);
      // Invalid files fail as designed (exactly their code), valid ones decode.
      EXPECT_EQ(v.expected == "OK" ? got.substr(0, 2) : got, v.expected) << v.name;
      manifest << manifest_line(v, got) << "\n";
    }
    GTEST_SKIP() << "vectors rewritten";
  }
  std::ifstream manifest(vector_dir() / "manifest.txt");
  ASSERT_TRUE(manifest) << "missing spec/vectors/manifest.txt";
  std::string line;
  std::map<std::string, std::string> listed;
  while (std::getline(manifest, line)) {
    if (line.empty() || line[0] == '#') continue;
    listed[line.substr(0, line.find(' '))] = line;
  }
  EXPECT_EQ(listed.size(), vectors.size());
  for (const Vector& v : vectors) {
    ASSERT_TRUE(listed.count(v.name)) << v.name << " not in the manifest";
    // The stored file decodes as the manifest says, and its twin is a listed valid file.
    EXPECT_EQ(listed[v.name], manifest_line(v, outcome(read_file(vector_dir() / v.name)))) << v.name;
    if (!v.twin.empty()) {
      EXPECT_NE(listed[v.twin].find(" OK "), std::string::npos) << v.name;
    }
  }
}

// Uncompressed files are pinned byte for byte; zstd/lz4 output may legitimately change with
// the library version, so compressed files are compared by their decode outcome.
TEST(FormatVectors, GeneratorReproducesStoredFiles) {
  for (const Vector& v : all_vectors()) {
    const std::vector<uint8_t> stored = read_file(vector_dir() / v.name);
    if (stored == v.bytes) continue;  // (the usual case: no decode needed)
    if (v.bytes.size() >= 28 && test::file_le32(&v.bytes[24]) == uint32_t(Compression::kNone))
      EXPECT_TRUE(stored == v.bytes) << v.name;
    else
      EXPECT_EQ(outcome(stored), outcome(v.bytes)) << v.name;
  }
}

// The codes a page-format decoder reports (spec/errors.md §Page format, every code but
// FORMAT_ENCODE, which only the encoder raises): each has at least one invalid vector.
std::set<std::string> errors_md_codes(const std::string& section_start, const std::string& prefix) {
  std::ifstream in(test::source_dir() / "spec" / "errors.md");
  std::string line;
  bool inside = false;
  std::set<std::string> codes;
  while (std::getline(in, line)) {
    if (line.rfind("#", 0) == 0) inside = line.find(section_start) != std::string::npos;
    if (!inside || line.rfind("| `" + prefix, 0) != 0) continue;
    codes.insert(line.substr(3, line.find('`', 3) - 3));
  }
  return codes;
}

TEST(FormatVectors, EveryDecoderCodeHasAnInvalidVector) {
  std::set<std::string> codes = errors_md_codes("Page format", "FORMAT_");
  ASSERT_TRUE(codes.count(kErrEncode)) << "spec/errors.md §Page format not parsed";
  codes.erase(kErrEncode);
  // From the committed manifest (ManifestMatches ties it to the generator): no generation here.
  std::set<std::string> covered;
  std::ifstream manifest(vector_dir() / "manifest.txt");
  for (std::string line; std::getline(manifest, line);) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream words(line);
    std::string name, expected;
    words >> name >> expected;
    if (expected != "OK") covered.insert(expected);
  }
  for (const std::string& c : codes) EXPECT_TRUE(covered.count(c)) << c << " has no invalid vector";
  for (const std::string& c : covered) EXPECT_TRUE(codes.count(c)) << c << " is not a code of spec/errors.md";
}

}  // namespace
}  // namespace vgeo
