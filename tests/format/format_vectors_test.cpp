// Conformance kit (spec/format.md §9): spec/vectors/ holds small valid files with the hash
// of their decoded scene and invalid files with the error code a decoder must report. The
// files are produced by make_vectors() below, never by hand:
//   VGEO_UPDATE_VECTORS=1 build/release/tests/test_format --gtest_filter=FormatVectors.*
// rewrites them (only on a deliberate format or encoder change). Without the variable the
// tests check the stored files and that the generator still reproduces them byte for byte
// (the encoder's output is pinned per format version).
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>

#include "format_file_edit.h"
#include "format_test_util.h"
#include "support/paths.h"
#include "vgeo/format/crc32c.h"

namespace vgeo {
namespace {

namespace fs = std::filesystem;

struct Vector {
  std::string name;
  std::vector<uint8_t> bytes;
  std::string expected;  // "OK" (hash added when written) or an error code
};

uint32_t le32(const uint8_t* p) { return test::file_le32(p); }
void put32(uint8_t* p, uint32_t v) { test::file_put32(p, v); }
void fix_crcs(std::vector<uint8_t>& f) { test::fix_file_crcs(f); }

// Offset of the version 2 copy mask in a raw (uncompressed) disk page (spec §5.2).
size_t copy_mask_offset(const uint8_t* page, uint32_t channels, uint64_t* total_vertices) {
  const uint32_t n = le32(page + 4);
  size_t at = 8;
  uint64_t tris = 0, runs = 0, verts = 0;
  for (uint32_t i = 0; i < n; ++i) verts += page[at + i], tris += page[at + n + i], runs += page[at + 2 * n + i];
  at += size_t(n) * (3 + 5 * channels) + tris;
  at += 4 + le32(page + at);
  *total_vertices = verts;
  return at + 5 * runs;
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
  v.push_back({prefix + "valid_sphere_zstd.vgp", sphere_zstd, "OK"});
  v.push_back({prefix + "valid_grid_uv_lz4.vgp", encode_format(test::scene_of({test::make_leaf_dag(test::make_grid(10, 1.0f, true))}), lz4), "OK"});
  v.push_back({prefix + "valid_two_level_none.vgp",
               encode_format(test::scene_of({test::make_two_level_dag(test::make_grid(24, 2.0f), test::make_grid(8, 2.0f))}), none), "OK"});
  {
    // A cluster whose triangles span more than 32 indices (wide index offsets) and a mesh with
    // several materials per cluster, two meshes.
    ClusterDag d = test::make_leaf_dag(test::make_sphere(8, 16));
    DagCluster& c = d.clusters[0];
    for (uint32_t t = 0; t + 1 < c.triangle_count; t += 2)
      std::swap(d.indices[3 * (c.triangle_offset + t)], d.indices[3 * (c.triangle_offset + c.triangle_count - 1 - t / 2) + 1]);
    v.push_back({prefix + "valid_wide_index_two_meshes_zstd.vgp",
                 encode_format(test::scene_of({d, test::make_leaf_dag(test::make_grid(3))}), zstd), "OK"});
  }
  auto derived = [&](const std::string& name, const std::vector<uint8_t>& base, const std::string& code, auto edit, bool crc) {
    std::vector<uint8_t> f = base;
    edit(f);
    if (crc) fix_crcs(f);
    v.push_back({prefix + name, f, code});
  };
  const FormatContainer fc = parse_container(sphere_zstd.data(), sphere_zstd.size(), "gen");
  const size_t page0 = fc.pages[0].file_offset;
  derived("bad_magic.vgp", sphere_zstd, kErrBadMagic, [](auto& f) { f[3] = 'X'; }, false);
  derived("bad_version.vgp", sphere_zstd, kErrBadVersion, [](auto& f) { put32(&f[8], kFormatVersion + 1); }, true);
  derived("truncated.vgp", sphere_zstd, kErrTruncated, [](auto& f) { f.pop_back(); }, false);
  derived("trailing_byte.vgp", sphere_zstd, kErrTrailingBytes, [](auto& f) { f.push_back(0); }, false);
  derived("header_checksum.vgp", sphere_zstd, kErrChecksum, [](auto& f) { f[44] ^= 1; }, false);
  derived("page_checksum.vgp", sphere_zstd, kErrChecksum, [&](auto& f) { f[page0 + 7] ^= 0x10; }, false);
  derived("unknown_compression.vgp", sphere_zstd, kErrUnsupported, [](auto& f) { put32(&f[24], 3); }, true);
  derived("page_size_out_of_range.vgp", sphere_zstd, kErrOutOfRange, [](auto& f) { put32(&f[28], 3u << 14); }, true);
  derived("file_size_inconsistent.vgp", sphere_zstd, kErrInconsistent, [](auto& f) { put32(&f[16], le32(&f[16]) - 1); }, true);
  derived("zstd_frame_broken.vgp", sphere_zstd, kErrDecompress, [&](auto& f) { f[page0] ^= 0xFF; }, true);
  // Raw (uncompressed) page edits: offsets from spec §5.2 for the first page.
  const BuiltScene grid = test::scene_of({test::make_leaf_dag(test::make_grid(6))});
  const std::vector<uint8_t> grid_none = encode_format(grid, none);
  // Metadata edit (plain metadata in version 1; in version 2 only without compression).
  derived("material_name_too_long.vgp", version == 1 ? sphere_zstd : grid_none, kErrOutOfRange,
          [](auto& f) { put32(&f[68], 4097); }, true);
  if (version >= 2) {
    derived("metadata_compression_unknown.vgp", sphere_zstd, kErrUnsupported, [](auto& f) { put32(&f[48], 3); }, true);
    derived("metadata_raw_size_over_cap.vgp", sphere_zstd, kErrOutOfRange,
            [](auto& f) { put32(&f[44], kMaxMetadataRatio * le32(&f[36]) + 1); }, true);
    derived("metadata_raw_size_mismatch.vgp", sphere_zstd, kErrDecompress, [](auto& f) { put32(&f[44], le32(&f[44]) + 1); }, true);
    // A page of several clusters with vertex copies (spec §5.2 version 2).
    const std::vector<uint8_t> multi = encode_format(test::scene_of({test::make_leaf_dag(test::make_grid(24, 1.0f, true))}), none);
    v.push_back({"valid_copies_none.vgp", multi, "OK"});
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
  v.push_back({prefix + "valid_grid_none.vgp", grid_none, "OK"});
  derived("page_cluster_count_mismatch.vgp", grid_none, kErrInconsistent, [&](auto& f) { put32(&f[p + 4], n + 1); }, true);
  derived("page_bad_magic.vgp", grid_none, kErrBadMagic, [&](auto& f) { f[p] ^= 1; }, true);
  const size_t ctl = p + 8 + size_t(n) * (3 + 5 * C);
  derived("strip_reserved_bit.vgp", grid_none, kErrOutOfRange, [&](auto& f) { f[ctl] |= 0x80; }, true);
  derived("strip_first_not_reset.vgp", grid_none, kErrOutOfRange, [&](auto& f) { f[ctl] = 0; }, true);
  // Widen channel 0 of cluster 0 by one bit where the byte-plane count stays the same:
  // still decodable, but not the tightest encoding.
  const size_t bits0 = p + 8 + 3 * size_t(n);
  if ((grid_none[bits0] + 2 + 7) / 8 == (grid_none[bits0] + 1 + 7) / 8)
    derived("channel_bits_not_tightest.vgp", grid_none, kErrNonCanonical, [&](auto& f) { f[bits0] += 1; }, true);
  return v;
}

std::string outcome(const std::vector<uint8_t>& f) {
  try {
    const BuiltScene s = decode_format(f.data(), f.size(), "<vector>");
    char hex[32];
    std::snprintf(hex, sizeof hex, "OK %016llx", static_cast<unsigned long long>(test::decoded_hash(s)));
    return hex;
  } catch (const VgeoError& e) {
    return e.error().code;
  }
}

fs::path vector_dir() { return test::source_dir() / "spec" / "vectors"; }

std::vector<uint8_t> read_file(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

TEST(FormatVectors, ManifestMatches) {
  std::vector<Vector> vectors = make_vectors(kMinFormatVersion);
  for (Vector& x : make_vectors(kFormatVersion)) vectors.push_back(std::move(x));
  if (const char* u = std::getenv("VGEO_UPDATE_VECTORS"); u && std::string(u) == "1") {
    fs::create_directories(vector_dir());
    std::ofstream manifest(vector_dir() / "manifest.txt");
    manifest << "# name expected — spec/format.md §9; generated by tests/format/format_vectors_test.cpp\n";
    for (const Vector& v : vectors) {
      std::ofstream(vector_dir() / v.name, std::ios::binary)
          .write(reinterpret_cast<const char*>(v.bytes.data()), std::streamsize(v.bytes.size()));
      const std::string got = outcome(v.bytes);
      ASSERT_EQ(got.substr(0, v.expected.size()), v.expected) << v.name;  // invalid files fail as designed
      manifest << v.name << " " << got << "\n";
    }
    GTEST_SKIP() << "vectors rewritten";
  }
  std::ifstream manifest(vector_dir() / "manifest.txt");
  ASSERT_TRUE(manifest) << "missing spec/vectors/manifest.txt";
  std::string line;
  int checked = 0;
  while (std::getline(manifest, line)) {
    if (line.empty() || line[0] == '#') continue;
    const std::string name = line.substr(0, line.find(' ')), expected = line.substr(line.find(' ') + 1);
    EXPECT_EQ(outcome(read_file(vector_dir() / name)), expected) << name;
    ++checked;
  }
  EXPECT_EQ(checked, int(vectors.size()));
}

// Uncompressed files are pinned byte for byte; zstd/lz4 output may legitimately change with
// the library version, so compressed files are compared by their decode outcome.
TEST(FormatVectors, GeneratorReproducesStoredFiles) {
  std::vector<Vector> all = make_vectors(kMinFormatVersion);
  for (Vector& x : make_vectors(kFormatVersion)) all.push_back(std::move(x));
  for (const Vector& v : all) {
    const std::vector<uint8_t> stored = read_file(vector_dir() / v.name);
    if (v.bytes.size() >= 28 && le32(&v.bytes[24]) == uint32_t(Compression::kNone))
      EXPECT_TRUE(stored == v.bytes) << v.name;
    else
      EXPECT_EQ(outcome(stored), outcome(v.bytes)) << v.name;
  }
}

}  // namespace
}  // namespace vgeo
