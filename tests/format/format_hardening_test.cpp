// Decoder hardening (spec/format.md §Decoder obligations): every prefix truncation and a
// one-byte extension are rejected with the right code, every single-bit flip of a page is
// caught by its CRC, malformed fields map to their stable codes, and mutated pages whose
// CRCs were recomputed never crash the decoder (runs under ASan in CI).
#include <gtest/gtest.h>

#include <cstring>
#include <random>

#include "format_file_edit.h"
#include "format_test_util.h"
#include "vgeo/format/crc32c.h"
#include "vgeo/format/lz4_block.h"
#include "vgeo/format/page_codec.h"

namespace vgeo {
namespace {

using test::error_code_of;

std::vector<uint8_t> small_file(Compression c = Compression::kZstd, uint32_t rings = 6,
                                uint32_t version = kFormatVersion) {
  FormatOptions o;
  o.compression = c;
  o.zstd_level = 3;
  o.version = version;
  return encode_format(test::scene_of({test::make_leaf_dag(test::make_sphere(rings, 2 * rings))}), o);
}


// Recomputes every CRC (pages, metadata, header) after a deliberate edit.

std::string decode_code(const std::vector<uint8_t>& f) {
  return error_code_of([&] { decode_format(f.data(), f.size(), "<test>"); });
}

TEST(FormatHardening, ValidFileDecodes) { EXPECT_EQ(decode_code(small_file()), "OK"); }

TEST(FormatHardening, EveryPrefixTruncationIsRejectedAsTruncated) {
  for (uint32_t version : {kMinFormatVersion, kFormatVersion})
  for (Compression c : {Compression::kNone, Compression::kZstd, Compression::kLz4}) {
    const std::vector<uint8_t> f = small_file(c, 6, version);
    for (size_t n = 0; n < f.size(); ++n) {
      const std::vector<uint8_t> cut(f.begin(), f.begin() + long(n));
      ASSERT_EQ(decode_code(cut), kErrTruncated) << "prefix " << n << " of " << f.size();
    }
  }
}

TEST(FormatHardening, OneByteExtensionIsRejectedAsTrailing) {
  for (uint32_t version : {kMinFormatVersion, kFormatVersion})
  for (uint8_t extra : {0x00, 0xFF}) {
    std::vector<uint8_t> f = small_file(Compression::kZstd, 6, version);
    f.push_back(extra);
    EXPECT_EQ(decode_code(f), kErrTrailingBytes);
  }
}

TEST(FormatHardening, PageTruncationAndExtensionRejected) {
  for (Compression c : {Compression::kNone, Compression::kZstd, Compression::kLz4}) {
    const std::vector<uint8_t> f = small_file(c, 12);
    const FormatContainer fc = parse_container(f.data(), f.size(), "<test>");
    for (uint32_t p = 0; p < fc.pages.size(); ++p) {
      const PageEntry& e = fc.pages[p];
      std::vector<uint8_t> page(f.begin() + long(e.file_offset), f.begin() + long(e.file_offset + e.stored_size));
      for (size_t n = 0; n < page.size(); ++n)
        ASSERT_EQ(error_code_of([&] { transcode_page(fc, p, page.data(), n, "<test>"); }), kErrTruncated) << n;
      page.push_back(0);
      EXPECT_EQ(error_code_of([&] { transcode_page(fc, p, page.data(), page.size(), "<test>"); }), kErrTrailingBytes);
    }
  }
}

TEST(FormatHardening, RawDiskPageTruncationAndExtensionRejected) {
  for (uint32_t version : {kMinFormatVersion, kFormatVersion}) {
  const std::vector<uint8_t> f = small_file(Compression::kNone, 12, version);
  const FormatContainer fc = parse_container(f.data(), f.size(), "<test>");
  const PageEntry& e = fc.pages[0];
  std::vector<uint8_t> raw(f.begin() + long(e.file_offset), f.begin() + long(e.file_offset + e.stored_size));
  struct Null final : format_detail::ClusterSink {
    void cluster(uint32_t, const format_detail::CanonicalCluster&) override {}
  } sink;
  const MeshQuantization& q = fc.meshes[0].quantization;
  EXPECT_EQ(error_code_of([&] { format_detail::parse_disk_page(raw.data(), raw.size(), q, e.cluster_count, sink, "t", fc.version); }), "OK");
  for (size_t n = 0; n < raw.size(); ++n)
    ASSERT_EQ(error_code_of([&] { format_detail::parse_disk_page(raw.data(), n, q, e.cluster_count, sink, "t", fc.version); }), kErrTruncated) << n;
  raw.push_back(0);
  EXPECT_EQ(error_code_of([&] { format_detail::parse_disk_page(raw.data(), raw.size(), q, e.cluster_count, sink, "t", fc.version); }),
            kErrTrailingBytes);
  }
}

TEST(FormatHardening, MemoryPageTruncationAndExtensionRejected) {
  const std::vector<uint8_t> f = small_file(Compression::kZstd, 12);
  const FormatContainer fc = parse_container(f.data(), f.size(), "<test>");
  const PageEntry& e = fc.pages[0];
  std::vector<uint32_t> words = transcode_page(fc, 0, f.data() + e.file_offset, e.stored_size, "<test>");
  const MeshQuantization& q = fc.meshes[0].quantization;
  EXPECT_EQ(error_code_of([&] { validate_memory_page(words.data(), words.size(), q, "t"); }), "OK");
  for (size_t n = 0; n < words.size(); ++n) {
    // Exact-size copies so that ASan sees any read beyond the declared length.
    std::vector<uint32_t> cut(words.begin(), words.begin() + long(n));
    ASSERT_EQ(error_code_of([&] { validate_memory_page(cut.data(), cut.size(), q, "t"); }), kErrTruncated) << n;
  }
  words.push_back(0);
  EXPECT_EQ(error_code_of([&] { validate_memory_page(words.data(), words.size(), q, "t"); }), kErrTrailingBytes);
}

TEST(FormatHardening, EverySingleBitFlipOfAPageIsCaughtByItsChecksum) {
  const std::vector<uint8_t> f = small_file(Compression::kZstd, 10);
  const FormatContainer fc = parse_container(f.data(), f.size(), "<test>");
  for (uint32_t p = 0; p < fc.pages.size(); ++p) {
    const PageEntry& e = fc.pages[p];
    std::vector<uint8_t> page(f.begin() + long(e.file_offset), f.begin() + long(e.file_offset + e.stored_size));
    for (size_t bit = 0; bit < page.size() * 8; ++bit) {
      page[bit / 8] ^= uint8_t(1u << (bit % 8));
      ASSERT_EQ(error_code_of([&] { transcode_page(fc, p, page.data(), page.size(), "<test>"); }), kErrChecksum) << bit;
      page[bit / 8] ^= uint8_t(1u << (bit % 8));
    }
  }
}

TEST(FormatHardening, EverySingleBitFlipOfTheFileIsRejected) {
  const std::vector<uint8_t> f = small_file(Compression::kZstd, 4);
  std::vector<uint8_t> g = f;
  for (size_t bit = 0; bit < f.size() * 8; ++bit) {
    g[bit / 8] ^= uint8_t(1u << (bit % 8));
    const std::string code = decode_code(g);
    const size_t byte = bit / 8;
    const std::string expected = byte < 8 ? kErrBadMagic : byte < 12 ? kErrBadVersion : kErrChecksum;
    ASSERT_EQ(code, expected) << "bit " << bit;
    g[bit / 8] ^= uint8_t(1u << (bit % 8));
  }
}

TEST(FormatHardening, MalformedFieldsMapToStableCodes) {
  const std::vector<uint8_t> f = small_file(Compression::kZstd);
  auto edited = [&](auto edit) {
    std::vector<uint8_t> g = f;
    edit(g);
    test::fix_file_crcs(g);
    return decode_code(g);
  };
  EXPECT_EQ(edited([](auto& g) { g[0] = 'X'; }), kErrBadMagic);
  EXPECT_EQ(edited([](auto& g) { test::file_put32(&g[8], 3); }), kErrBadVersion);
  EXPECT_EQ(edited([](auto& g) { test::file_put32(&g[8], 0); }), kErrBadVersion);
  EXPECT_EQ(edited([](auto& g) { test::file_put32(&g[24], 7); }), kErrUnsupported);          // compression
  EXPECT_EQ(edited([](auto& g) { test::file_put32(&g[28], 1000); }), kErrOutOfRange);        // page size
  EXPECT_EQ(edited([](auto& g) { g[54] = 1; }), kErrUnsupported);                 // reserved
  // Version 2 metadata fields (spec §1.1): codec, raw size cap, raw size.
  EXPECT_EQ(edited([](auto& g) { test::file_put32(&g[48], 3); }), kErrUnsupported);
  EXPECT_EQ(edited([](auto& g) { test::file_put32(&g[44], 32 * test::file_le32(&g[36]) + 1); }), kErrOutOfRange);
  EXPECT_EQ(edited([](auto& g) { test::file_put32(&g[44], test::file_le32(&g[44]) + 1); }), kErrDecompress);
  EXPECT_EQ(edited([](auto& g) { test::file_put32(&g[44], test::file_le32(&g[44]) - 1); }), kErrDecompress);
  EXPECT_EQ(edited([](auto& g) { test::file_put32(&g[48], 0); }), kErrInconsistent);        // raw size != stored size
  EXPECT_EQ(edited([](auto& g) { g[64] ^= 0xFF; }), kErrDecompress);              // metadata zstd frame
  EXPECT_EQ(edited([](auto& g) { test::file_put32(&g[16], test::file_le32(&g[16]) + 1); }), kErrInconsistent);  // file size
  // First page's zstd frame magic broken (CRC recomputed): the decompressor rejects it.
  const FormatContainer fc = parse_container(f.data(), f.size(), "<test>");
  const size_t page0 = fc.pages[0].file_offset;
  EXPECT_EQ(edited([&](auto& g) { g[page0] ^= 0xFF; }), kErrDecompress);
  // Metadata fields (uncompressed metadata, versions 1 and 2): first material's name length
  // made huge; material count bigger than the metadata can hold.
  for (uint32_t version : {kMinFormatVersion, kFormatVersion}) {
    FormatOptions o;
    o.compression = Compression::kNone;
    o.version = version;
    const std::vector<uint8_t> plain = encode_format(test::scene_of({test::make_leaf_dag(test::make_sphere(6, 12))}), o);
    auto plain_edited = [&](auto edit) {
      std::vector<uint8_t> g = plain;
      edit(g);
      test::fix_file_crcs(g);
      return decode_code(g);
    };
    EXPECT_EQ(plain_edited([](auto&) {}), "OK") << version;
    EXPECT_EQ(plain_edited([](auto& g) { test::file_put32(&g[68], 5000); }), kErrOutOfRange) << version;
    EXPECT_EQ(plain_edited([](auto& g) { test::file_put32(&g[64], 0x7FFFFFFF); }), kErrTruncated) << version;
  }
}

// spec/format.md §5.1: every lz4 match offset MUST be >= 1. LZ4_decompress_safe itself
// accepts 0 (it copies whatever the output buffer held), so a file with such a block decoded
// (to its twin's hash, the buffer being zeroed) until the decoder checked the offsets.
TEST(FormatHardening, Lz4MatchOffsetZeroIsRejected) {
  const std::vector<uint8_t> f = small_file(Compression::kLz4, 8);
  ASSERT_EQ(decode_code(f), "OK");
  const FormatContainer fc = parse_container(f.data(), f.size(), "<test>");
  size_t matches = 0;
  for (const PageEntry& p : fc.pages) {
    const uint8_t* block = f.data() + p.file_offset;
    std::vector<size_t> offsets;
    // Every stored page parses whole into sequences, each match offset >= 1.
    EXPECT_TRUE(walk_lz4_block(block, p.stored_size, [&](const Lz4Sequence& s) {
      if (!s.has_match) return true;
      offsets.push_back(s.offset_at);
      EXPECT_GE(s.offset, 1u);
      return true;
    }));
    // Each match in turn set to offset 0 (CRCs fixed): FORMAT_DECOMPRESS, never a decode.
    for (size_t at : offsets) {
      std::vector<uint8_t> g = f;
      g[p.file_offset + at] = 0, g[p.file_offset + at + 1] = 0;
      test::fix_file_crcs(g);
      EXPECT_EQ(decode_code(g), "FORMAT_DECOMPRESS") << "page at " << p.file_offset << ", offset at " << at;
    }
    matches += offsets.size();
  }
  EXPECT_GT(matches, 0u) << "the lz4 pages hold no match: the test pins nothing";
  // A hand-made block: 8 literals "abcdefgh", a 4-byte match at offset 4, 8 final literals
  // (raw size 20; the match starts 12 bytes before the end, as the block format requires).
  std::vector<uint8_t> block = {0x80, 'a', 'b', 'c', 'd', 'e', 'f', 'g', 'h', 4, 0,
                                0x80, 'i', 'j', 'k', 'l', 'm', 'n', 'o', 'p'};
  std::vector<uint8_t> out(20);
  format_detail::decompress(block.data(), block.size(), Compression::kLz4, out.data(), out.size(), "<test>");
  EXPECT_EQ(std::string(out.begin(), out.end()), "abcdefghefghijklmnop");
  block[9] = 0;
  EXPECT_EQ(error_code_of([&] {
              format_detail::decompress(block.data(), block.size(), Compression::kLz4, out.data(), out.size(), "<test>");
            }),
            "FORMAT_DECOMPRESS");
}

TEST(FormatHardening, MutatedPagesWithFixedChecksumsNeverCrash) {
  // A small deterministic in-test fuzzer: byte mutations of valid files with the CRCs
  // recomputed, so mutations reach the page parsers. Any VgeoError is fine; a crash or an
  // exception of another type is not.
  std::mt19937 rng(12345);
  for (Compression c : {Compression::kNone, Compression::kZstd}) {
    const std::vector<uint8_t> f = small_file(c, 8);
    const FormatContainer fc = parse_container(f.data(), f.size(), "<test>");
    const size_t pages_begin = fc.pages[0].file_offset;
    for (int iter = 0; iter < 3000; ++iter) {
      std::vector<uint8_t> g = f;
      const int edits = 1 + int(rng() % 4);
      for (int k = 0; k < edits; ++k) {
        const size_t at = (iter & 1) ? pages_begin + rng() % (g.size() - pages_begin) : 64 + rng() % (g.size() - 64);
        g[at] = (rng() & 1) ? uint8_t(rng()) : uint8_t(g[at] ^ (1u << (rng() % 8)));
      }
      test::fix_file_crcs(g);
      try {
        decode_format(g.data(), g.size(), "<test>");
      } catch (const VgeoError&) {
      }
    }
  }
}

}  // namespace
}  // namespace vgeo
