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

uint32_t le32(const uint8_t* p) { return uint32_t(p[0]) | uint32_t(p[1]) << 8 | uint32_t(p[2]) << 16 | uint32_t(p[3]) << 24; }
void put32(uint8_t* p, uint32_t v) { for (int k = 0; k < 4; ++k) p[k] = uint8_t(v >> (8 * k)); }

void fix_crcs(std::vector<uint8_t>& f) {
  const uint32_t meta_size = le32(&f[36]), pages = le32(&f[32]);
  uint8_t* table = &f[64 + meta_size - 24 * size_t(pages)];
  size_t offset = 64 + meta_size;
  for (uint32_t p = 0; p < pages; ++p) {
    const uint32_t stored = le32(table + 24 * p + 4);
    if (offset + stored <= f.size()) put32(table + 24 * p + 20, crc32c(&f[offset], stored));
    offset += stored;
  }
  put32(&f[40], crc32c(&f[64], meta_size));
  put32(&f[60], crc32c(&f[0], 60));
}

std::vector<Vector> make_vectors() {
  std::vector<Vector> v;
  FormatOptions zstd;
  zstd.zstd_level = 9;
  FormatOptions none = zstd, lz4 = zstd;
  none.compression = Compression::kNone;
  lz4.compression = Compression::kLz4;
  none.page_size = lz4.page_size = kMinPageSize;

  const BuiltScene sphere = test::scene_of({test::make_leaf_dag(test::make_sphere(6, 12))});
  const std::vector<uint8_t> sphere_zstd = encode_format(sphere, zstd);
  v.push_back({"valid_sphere_zstd.vgp", sphere_zstd, "OK"});
  v.push_back({"valid_grid_uv_lz4.vgp", encode_format(test::scene_of({test::make_leaf_dag(test::make_grid(10, 1.0f, true))}), lz4), "OK"});
  v.push_back({"valid_two_level_none.vgp",
               encode_format(test::scene_of({test::make_two_level_dag(test::make_grid(24, 2.0f), test::make_grid(8, 2.0f))}), none), "OK"});
  {
    // A cluster whose triangles span more than 32 indices (wide index offsets) and a mesh with
    // several materials per cluster, two meshes.
    ClusterDag d = test::make_leaf_dag(test::make_sphere(8, 16));
    DagCluster& c = d.clusters[0];
    for (uint32_t t = 0; t + 1 < c.triangle_count; t += 2)
      std::swap(d.indices[3 * (c.triangle_offset + t)], d.indices[3 * (c.triangle_offset + c.triangle_count - 1 - t / 2) + 1]);
    v.push_back({"valid_wide_index_two_meshes_zstd.vgp",
                 encode_format(test::scene_of({d, test::make_leaf_dag(test::make_grid(3))}), zstd), "OK"});
  }
  auto derived = [&](const std::string& name, const std::vector<uint8_t>& base, const std::string& code, auto edit, bool crc) {
    std::vector<uint8_t> f = base;
    edit(f);
    if (crc) fix_crcs(f);
    v.push_back({name, f, code});
  };
  const FormatContainer fc = parse_container(sphere_zstd.data(), sphere_zstd.size(), "gen");
  const size_t page0 = fc.pages[0].file_offset;
  derived("bad_magic.vgp", sphere_zstd, kErrBadMagic, [](auto& f) { f[3] = 'X'; }, false);
  derived("bad_version.vgp", sphere_zstd, kErrBadVersion, [](auto& f) { put32(&f[8], 2); }, true);
  derived("truncated.vgp", sphere_zstd, kErrTruncated, [](auto& f) { f.pop_back(); }, false);
  derived("trailing_byte.vgp", sphere_zstd, kErrTrailingBytes, [](auto& f) { f.push_back(0); }, false);
  derived("header_checksum.vgp", sphere_zstd, kErrChecksum, [](auto& f) { f[44] ^= 1; }, false);
  derived("page_checksum.vgp", sphere_zstd, kErrChecksum, [&](auto& f) { f[page0 + 7] ^= 0x10; }, false);
  derived("unknown_compression.vgp", sphere_zstd, kErrUnsupported, [](auto& f) { put32(&f[24], 3); }, true);
  derived("page_size_out_of_range.vgp", sphere_zstd, kErrOutOfRange, [](auto& f) { put32(&f[28], 3u << 14); }, true);
  derived("file_size_inconsistent.vgp", sphere_zstd, kErrInconsistent, [](auto& f) { put32(&f[16], le32(&f[16]) - 1); }, true);
  derived("zstd_frame_broken.vgp", sphere_zstd, kErrDecompress, [&](auto& f) { f[page0] ^= 0xFF; }, true);
  derived("material_name_too_long.vgp", sphere_zstd, kErrOutOfRange, [](auto& f) { put32(&f[68], 4097); }, true);

  // Raw (uncompressed) page edits: offsets from spec §5.2 for the first page.
  const BuiltScene grid = test::scene_of({test::make_leaf_dag(test::make_grid(6))});
  const std::vector<uint8_t> grid_none = encode_format(grid, none);
  const FormatContainer gc = parse_container(grid_none.data(), grid_none.size(), "gen");
  const size_t p = gc.pages[0].file_offset;
  const uint32_t n = gc.pages[0].cluster_count, C = gc.meshes[0].quantization.channel_count();
  v.push_back({"valid_grid_none.vgp", grid_none, "OK"});
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
  const std::vector<Vector> vectors = make_vectors();
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
  for (const Vector& v : make_vectors()) {
    const std::vector<uint8_t> stored = read_file(vector_dir() / v.name);
    if (v.bytes.size() >= 28 && le32(&v.bytes[24]) == uint32_t(Compression::kNone))
      EXPECT_TRUE(stored == v.bytes) << v.name;
    else
      EXPECT_EQ(outcome(stored), outcome(v.bytes)) << v.name;
  }
}

}  // namespace
}  // namespace vgeo
