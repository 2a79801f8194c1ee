// The encoder's pages are encoded and compressed in parallel (FormatOptions::threads): the
// file bytes and the size report are identical for any thread count, a bad input gets the
// same error, the zstd level is range-checked, and the report's raw per-component sizes add
// up to the raw pages exactly (the compressed split is measure_stream_compression's, on request).
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <unistd.h>

#include "format_test_util.h"
#include "support/run_command.h"
#include "vgeo/core/error.h"
#include "vgeo/core/file_io.h"
#include "vgeo/format/format_measure.h"
#include "vgeo/format/page_codec.h"

namespace vgeo {
namespace {

// Several meshes, many small pages: work for every thread, pages finishing out of order.
BuiltScene many_page_scene() {
  Mesh with_attributes = test::make_sphere(48, 96);
  with_attributes.uvs.clear();
  for (size_t v = 0; v < with_attributes.vertex_count(); ++v)
    with_attributes.uvs.insert(with_attributes.uvs.end(),
                               {with_attributes.positions[3 * v] * 3.0f, with_attributes.positions[3 * v + 1] * 3.0f});
  return test::scene_of({test::make_two_level_dag(test::make_grid(40, 2.0f, true), test::make_grid(12, 2.0f)),
                         test::make_leaf_dag(with_attributes)});
}

FormatOptions small_pages(Compression c, unsigned threads) {
  FormatOptions o;
  o.page_size = kMinPageSize;
  o.compression = c;
  o.zstd_level = 3;
  o.threads = threads;
  return o;
}

void expect_same_components(const ComponentBytes& a, const ComponentBytes& b) {
  EXPECT_EQ(a.positions, b.positions);
  EXPECT_EQ(a.normals, b.normals);
  EXPECT_EQ(a.uvs, b.uvs);
  EXPECT_EQ(a.topology, b.topology);
  EXPECT_EQ(a.materials, b.materials);
  EXPECT_EQ(a.cluster_headers, b.cluster_headers);
  EXPECT_EQ(a.vertex_refs, b.vertex_refs);
}

TEST(FormatParallelEncode, SameBytesAndReportForAnyThreadCount) {
  const BuiltScene s = many_page_scene();
  for (Compression c : {Compression::kZstd, Compression::kLz4, Compression::kNone})
    for (uint32_t version : {kMinFormatVersion, kFormatVersion}) {
      FormatOptions one = small_pages(c, 1);
      one.version = version;
      FormatReport r1;
      const std::vector<uint8_t> f1 = encode_format(s, one, &r1);
      ASSERT_GE(r1.pages.size(), 6u) << "the scene must give every thread several pages";
      EXPECT_EQ(f1, encode_format(s, one)) << "the report must not change the bytes";
      for (unsigned threads : {2u, 3u, 0u}) {
        FormatOptions many = one;
        many.threads = threads;
        FormatReport rn;
        EXPECT_EQ(f1, encode_format(s, many, &rn)) << "threads " << threads;
        ASSERT_EQ(r1.pages.size(), rn.pages.size());
        for (size_t p = 0; p < r1.pages.size(); ++p) {
          EXPECT_EQ(r1.pages[p].stored_bytes, rn.pages[p].stored_bytes);
          EXPECT_EQ(r1.pages[p].raw_bytes, rn.pages[p].raw_bytes);
          EXPECT_EQ(r1.pages[p].memory_bytes, rn.pages[p].memory_bytes);
        }
        expect_same_components(r1.disk_raw, rn.disk_raw);
        expect_same_components(r1.memory, rn.memory);
        EXPECT_EQ(r1.copied_vertices, rn.copied_vertices);
        EXPECT_EQ(r1.file_bytes, rn.file_bytes);
      }
    }
}

// The raw per-component sizes are a partition of the raw pages (every byte of a disk page
// belongs to one component), and pages_stored_bytes is the stored pages' total.
TEST(FormatParallelEncode, ReportComponentsPartitionTheRawPages) {
  const BuiltScene s = many_page_scene();
  FormatReport r;
  const std::vector<uint8_t> f = encode_format(s, small_pages(Compression::kZstd, 2), &r);
  uint64_t raw = 0, stored = 0;
  for (const PageFill& p : r.pages) raw += p.raw_bytes, stored += p.stored_bytes;
  EXPECT_EQ(r.disk_raw.total(), double(raw));
  EXPECT_EQ(r.pages_stored_bytes, stored);
  const FormatContainer fc = parse_container(f.data(), f.size(), "<test>");
  uint64_t table_stored = 0;
  for (const PageEntry& e : fc.pages) table_stored += e.stored_size;
  EXPECT_EQ(stored, table_stored);
  EXPECT_GT(r.disk_raw.uvs, 0.0);
  EXPECT_GT(r.disk_raw.normals, 0.0);
}

// measure_stream_compression compresses each component's streams of every page alone: for
// the uncompressed codec that is exactly the raw split the encoder reports.
TEST(FormatParallelEncode, StreamMeasureMatchesRawSplitWithoutCompression) {
  const BuiltScene s = many_page_scene();
  const FormatOptions none = small_pages(Compression::kNone, 1);
  FormatReport r;
  const std::vector<uint8_t> f = encode_format(s, none, &r);
  expect_same_components(measure_stream_compression(s, f, none), r.disk_raw);
  const FormatOptions zstd = small_pages(Compression::kZstd, 1);
  const std::vector<uint8_t> fz = encode_format(s, zstd);
  const ComponentBytes alone = measure_stream_compression(s, fz, zstd);
  EXPECT_GT(alone.positions, 0.0);
  EXPECT_LT(alone.positions, r.disk_raw.positions);
  // A file of another scene is refused with a code, not read out of bounds.
  const BuiltScene other = test::scene_of({test::make_leaf_dag(test::make_grid(4))});
  EXPECT_EQ(test::error_code_of([&] { measure_stream_compression(other, fz, zstd); }), kErrInconsistent);
}

// A cluster the encoder cannot represent fails with the same error at any thread count
// (the error of the lowest index, not of the first thread to fail).
TEST(FormatParallelEncode, SameErrorForAnyThreadCount) {
  BuiltScene s = many_page_scene();
  ClusterDag& dag = s.meshes[1];
  // Two clusters with different defects: the lowest cluster's error wins at any thread count.
  const DagCluster& low = dag.clusters[3];
  const DagCluster& high = dag.clusters[dag.clusters.size() - 2];
  ASSERT_LT(low.vertex_count, kMaxClusterVertices);
  dag.indices[3 * size_t(low.triangle_offset)] = uint8_t(kMaxClusterVertices);  // beyond the cluster's vertices
  dag.triangle_materials[high.material_offset] = kMaxMaterialId + 1;
  std::string first;
  for (unsigned threads : {1u, 2u, 4u}) {
    try {
      encode_format(s, small_pages(Compression::kZstd, threads));
      ADD_FAILURE() << "threads " << threads << ": no error";
    } catch (const VgeoError& e) {
      EXPECT_EQ(e.error().code, std::string(kErrEncode));
      if (first.empty()) first = e.error().line();
      EXPECT_NE(first.find("triangle index"), std::string::npos) << first;
      EXPECT_EQ(first, e.error().line()) << "threads " << threads;
    }
  }
}

TEST(FormatParallelEncode, ZstdLevelOutsideRangeIsRefused) {
  const BuiltScene s = test::scene_of({test::make_leaf_dag(test::make_grid(8))});
  for (int level : {kMinZstdLevel - 1, kMaxZstdLevel + 1, -5, 100}) {
    FormatOptions o;
    o.zstd_level = level;
    EXPECT_EQ(test::error_code_of([&] { encode_format(s, o); }), kErrEncode) << level;
  }
  for (int level : {kMinZstdLevel, kDefaultZstdLevel, kMaxZstdLevel}) {
    FormatOptions o;
    o.zstd_level = level;
    const std::vector<uint8_t> f = encode_format(s, o);
    EXPECT_EQ(test::decoded_hash(decode_format(f.data(), f.size(), "<test>")),
              test::decoded_hash(decode_format(encode_format(s, FormatOptions{}).data(),
                                               encode_format(s, FormatOptions{}).size(), "<test>")));
  }
  // The level does not matter without zstd.
  FormatOptions lz4;
  lz4.compression = Compression::kLz4;
  lz4.zstd_level = 0;
  EXPECT_NO_THROW(encode_format(s, lz4));
}

// `vgeo build --zstd-level`: a bad level is BUILD_ZSTD_LEVEL (one line, exit 2, checked
// before the input is read); a good one gives the same decoded asset as the default, in
// bytes that do not depend on --threads.
TEST(FormatParallelEncode, BuildCliZstdLevel) {
  for (const char* bad : {"0", "23", "-1", "abc", "9x", "3.5"}) {
    const test::CliResult r = test::run_cli(std::string("build missing_input.ply -o /dev/null --zstd-level '") + bad + "'");
    EXPECT_EQ(r.exit_code, 2) << bad;
    EXPECT_EQ(r.output.rfind("error[BUILD_ZSTD_LEVEL]", 0), 0u) << r.output;
    EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << r.output;
  }
  const auto dir = std::filesystem::temp_directory_path() / ("vgeo_build_zstd_level_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::string ply = (dir / "s.ply").string();
  ASSERT_EQ(test::run_cli("gen sphere -n 20000 -o " + ply).exit_code, 0);
  auto build = [&](const std::string& name, const std::string& flags) {
    const std::string out = (dir / name).string();
    const test::CliResult r = test::run_cli("build " + ply + " -o " + out + " " + flags);
    EXPECT_EQ(r.exit_code, 0) << r.output;
    return read_file(out, kAnyFileSize);
  };
  const std::vector<uint8_t> fast1 = build("a.vgp", "--threads 1 --zstd-level 1 --page-size 16KiB");
  const std::vector<uint8_t> fast2 = build("b.vgp", "--threads 2 --zstd-level 1 --page-size 16KiB");
  const std::vector<uint8_t> def = build("c.vgp", "--threads 2 --page-size 16KiB");
  EXPECT_EQ(fast1, fast2);
  EXPECT_EQ(test::decoded_hash(decode_format(fast1.data(), fast1.size(), "a")),
            test::decoded_hash(decode_format(def.data(), def.size(), "c")));
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace vgeo
