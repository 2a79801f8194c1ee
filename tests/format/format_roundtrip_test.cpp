// Round-trip properties of the page format (spec/format.md §Decoded scene):
//  - decode(encode(x)) equals x quantized, up to the documented canonical order
//    (triangles permuted within a cluster, each triangle rotated, vertices permuted);
//  - quantization error ≤ half a grid step; metadata bit-identical;
//  - the decoded scene is a fixed point of quantization (re-encoding it is lossless);
//  - transcode(disk page) == memory page built directly from the clusters.
#include <gtest/gtest.h>
#include <rapidcheck/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <cstring>
#include <random>

#include "format_roundtrip_check.h"
#include "vgeo/dag/build.h"
#include "format_test_util.h"
#include "vgeo/format/crc32c.h"
#include "vgeo/format/page_codec.h"

namespace vgeo {
namespace {

// Random DAG with small integer-ish coordinates: coincident vertices, degenerate and
// duplicate triangles, unused vertices and zero normals are common.
ClusterDag random_dag(uint32_t seed, uint32_t clusters, bool normals, bool uvs) {
  std::mt19937 rng(seed);
  auto uni = [&](int lo, int hi) { return std::uniform_int_distribution<int>(lo, hi)(rng); };
  ClusterDag d;
  for (uint32_t c = 0; c < clusters; ++c) {
    DagCluster cl;
    cl.vertex_offset = uint32_t(d.vertex_count());
    cl.triangle_offset = cl.material_offset = uint32_t(d.triangle_count());
    cl.vertex_count = uint32_t(uni(0, 3) == 0 ? uni(1, 255) : uni(1, 40));
    cl.triangle_count = uint32_t(uni(0, 3) == 0 ? uni(1, 128) : uni(1, 40));
    const int spread = uni(0, 3) == 0 ? 4000 : 8;
    for (uint32_t v = 0; v < cl.vertex_count; ++v) {
      for (int k = 0; k < 3; ++k) d.positions.push_back(float(uni(-spread, spread)) * 0.25f + (uni(0, 4) == 0 ? 0.1f : 0.0f));
      if (normals) for (int k = 0; k < 3; ++k) d.normals.push_back(float(uni(-2, 2)));
      if (uvs) for (int k = 0; k < 2; ++k) d.uvs.push_back(float(uni(-8, 8)) * 0.125f);
    }
    for (uint32_t t = 0; t < cl.triangle_count; ++t) {
      for (int k = 0; k < 3; ++k) d.indices.push_back(uint8_t(uni(0, int(cl.vertex_count) - 1)));
      const uint32_t mats[] = {0, 1, 2, 1000, kMaxMaterialId};
      d.triangle_materials.push_back(mats[uni(0, 4)]);
    }
    cl.bounds = cl.lod_bounds = test::sphere_of(d.positions, cl.vertex_offset, cl.vertex_count);
    d.clusters.push_back(cl);
  }
  test::group_clusters(d, 0, uint32_t(uni(1, 4)), uni(0, 1) == 0);
  test::finish_dag(d);
  return d;
}

std::vector<uint8_t> encode(const BuiltScene& s, const FormatOptions& o = {}) { return encode_format(s, o); }

TEST(FormatRoundTrip, CrcTestVector) {
  EXPECT_EQ(crc32c("123456789", 9), 0xE3069283u);
  EXPECT_EQ(crc32c("", 0), 0u);
  EXPECT_EQ(crc32c("56789", 5, crc32c("1234", 4)), 0xE3069283u);
}

TEST(FormatRoundTrip, LeafDagOfSphereDecodesToQuantizedInput) {
  BuiltScene s = test::scene_of({test::make_leaf_dag(test::make_sphere(24, 48)), test::make_leaf_dag(test::make_grid(20))});
  for (Compression c : {Compression::kNone, Compression::kZstd, Compression::kLz4}) {
    FormatOptions o;
    o.compression = c;
    const std::vector<uint8_t> f = encode(s, o);
    const BuiltScene d = decode_format(f.data(), f.size(), "<test>");
    const FormatContainer fc = parse_container(f.data(), f.size(), "<test>");
    EXPECT_EQ(compare_roundtrip(s, d, fc), "") << "compression " << int(c);
    // The decoded scene is a fixed point of quantization: encoding it again loses nothing.
    FormatOptions again = o;
    again.position_step_log2 = fc.meshes[0].quantization.position_step_log2;
    const std::vector<uint8_t> f2 = encode(d, again);
    EXPECT_EQ(compare_roundtrip(d, decode_format(f2.data(), f2.size(), "<test>"), parse_container(f2.data(), f2.size(), "<test>")), "");
  }
}

TEST(FormatRoundTrip, TwoLevelDagKeepsStructureAndGroupPartsConsecutive) {
  BuiltScene s = test::scene_of({test::make_two_level_dag(test::make_grid(80, 2.0f, true), test::make_grid(20, 2.0f, true))});
  FormatOptions o;
  o.page_size = kMinPageSize;  // force several pages and split groups
  const std::vector<uint8_t> f = encode(s, o);
  const FormatContainer fc = parse_container(f.data(), f.size(), "<test>");
  EXPECT_GT(fc.pages.size(), 2u);
  EXPECT_EQ(compare_roundtrip(s, decode_format(f.data(), f.size(), "<test>"), fc), "");
  // Root page holds the coarsest level; a group's parts are consecutive pages.
  const MeshMetadata& mm = fc.meshes[0];
  EXPECT_EQ(mm.dag.clusters[mm.page_clusters[0]].level, 1u);
  for (uint32_t g = 0; g < mm.dag.groups.size(); ++g)
    for (uint32_t c = mm.dag.groups[g].first_cluster; c < mm.dag.groups[g].first_cluster + mm.dag.groups[g].cluster_count; ++c) {
      EXPECT_GE(mm.cluster_page[c], mm.group_first_page[g]);
      EXPECT_LT(mm.cluster_page[c], mm.group_first_page[g] + mm.group_page_count[g]);
    }
}

TEST(FormatRoundTrip, EncodingIsDeterministic) {
  BuiltScene s = test::scene_of({test::make_leaf_dag(test::make_sphere(16, 32))});
  EXPECT_EQ(encode(s), encode(s));
}

TEST(FormatRoundTrip, TranscodeEqualsDirectMemoryForm) {
  BuiltScene s = test::scene_of({test::make_leaf_dag(test::make_sphere(30, 60))});
  FormatOptions o;
  o.page_size = kMinPageSize;
  const std::vector<uint8_t> f = encode(s, o);
  const FormatContainer fc = parse_container(f.data(), f.size(), "<test>");
  for (uint32_t p = 0; p < fc.pages.size(); ++p) {
    const PageEntry& e = fc.pages[p];
    const MeshMetadata& mm = fc.meshes[e.mesh];
    std::vector<format_detail::CanonicalCluster> canon(e.cluster_count);
    std::vector<const format_detail::CanonicalCluster*> ptrs;
    for (uint32_t k = 0; k < e.cluster_count; ++k) {
      format_detail::canonicalize_cluster(s.meshes[e.mesh], mm.page_clusters[e.first_cluster_slot + k], mm.quantization, &canon[k]);
      ptrs.push_back(&canon[k]);
    }
    const std::vector<uint32_t> direct = format_detail::encode_memory_page(ptrs, mm.quantization);
    const std::vector<uint32_t> transcoded = transcode_page(fc, p, f.data() + e.file_offset, e.stored_size, "<test>");
    ASSERT_EQ(direct, transcoded) << "page " << p;
    EXPECT_NO_THROW(validate_memory_page(transcoded.data(), transcoded.size(), mm.quantization, "<test>"));
  }
}

// Version 2 (vertex copies, parallelogram prediction, compressed transposed metadata) and
// version 1 encode the same scene to the same decoded scene and the same memory form, and
// version 2 pages really use copies (clusters of one page share border vertices).
TEST(FormatRoundTrip, VersionsDecodeIdenticallyAndV2CopiesSharedVertices) {
  BuiltScene s = test::scene_of({test::make_leaf_dag(test::make_grid(24, 1.0f, true))});
  FormatOptions o1, o2;
  o1.version = kMinFormatVersion;
  o2.version = kFormatVersion;
  o1.zstd_level = o2.zstd_level = 3;
  FormatReport r2;
  const std::vector<uint8_t> f1 = encode_format(s, o1), f2 = encode_format(s, o2, &r2);
  EXPECT_GT(r2.copied_vertices, 0u);
  EXPECT_EQ(test::decoded_hash(decode_format(f1.data(), f1.size(), "v1")), test::decoded_hash(decode_format(f2.data(), f2.size(), "v2")));
  const FormatContainer c1 = parse_container(f1.data(), f1.size(), "v1"), c2 = parse_container(f2.data(), f2.size(), "v2");
  ASSERT_EQ(c1.pages.size(), c2.pages.size());
  EXPECT_EQ(c1.version, kMinFormatVersion);
  EXPECT_EQ(c2.version, kFormatVersion);
  for (uint32_t p = 0; p < c1.pages.size(); ++p)
    EXPECT_EQ(transcode_page(c1, p, f1.data() + c1.pages[p].file_offset, c1.pages[p].stored_size, "v1"),
              transcode_page(c2, p, f2.data() + c2.pages[p].file_offset, c2.pages[p].stored_size, "v2"));
}

// Default position grid (spec/format.md §2): extent ≤ 2^16 steps, then refined until
// √3/2·step ≤ the median parent_error of the level-0 groups, never beyond 2^20 steps.
TEST(FormatRoundTrip, PositionGridFollowsMedianLeafErrorWithinCap) {
  const ClusterDag base = test::make_two_level_dag(test::make_grid(24, 2.0f), test::make_grid(8, 2.0f));
  auto step_log2 = [&](float leaf_error, bool refine) {
    ClusterDag d = base;
    for (DagGroup& g : d.groups)
      if (g.level == 0) g.parent_error = leaf_error;
    for (DagCluster& c : d.clusters)
      if (c.level == 0) c.parent_error = leaf_error;
      else if (c.generating_group != kNone) c.lod_error = leaf_error;
    for (DagGroup& g : d.groups)
      if (g.level > 0) g.parent_error = std::max(g.parent_error, leaf_error);
    FormatOptions o;
    o.zstd_level = 1;
    o.position_step_from_lod_error = refine;
    const std::vector<uint8_t> f = encode_format(test::scene_of({d}), o);
    return parse_container(f.data(), f.size(), "<test>").meshes[0].quantization.position_step_log2;
  };
  const int32_t extent_rule = step_log2(1.0f, false);  // grid extent 2: step 2^-15
  EXPECT_EQ(extent_rule, -15);
  EXPECT_EQ(step_log2(1.0f, true), extent_rule);          // coarse errors: no refinement
  const int32_t refined = step_log2(1e-5f, true);         // √3/2·2^-17 ≈ 6.6e-6 ≤ 1e-5 < √3/2·2^-16
  EXPECT_EQ(refined, -17);
  EXPECT_EQ(step_log2(1e-12f, true), extent_rule - 4);    // capped at 2^20 steps over the extent
}

RC_GTEST_PROP(FormatRoundTrip, RandomDagsRoundTripExactly, ()) {
  const uint32_t seed = *rc::gen::arbitrary<uint32_t>();
  const uint32_t clusters = *rc::gen::inRange(1, 12);
  const bool normals = *rc::gen::arbitrary<bool>(), uvs = *rc::gen::arbitrary<bool>();
  BuiltScene s = test::scene_of({random_dag(seed, clusters, normals, uvs)});
  FormatOptions o;
  o.normal_bits = *rc::gen::inRange(1, 17);
  o.compression = *rc::gen::element(Compression::kNone, Compression::kZstd, Compression::kLz4);
  o.zstd_level = 3;
  o.version = *rc::gen::element(kMinFormatVersion, kFormatVersion);
  if (*rc::gen::arbitrary<bool>()) o.position_step_log2 = *rc::gen::inRange(-6, 3);
  std::vector<uint8_t> f;
  try {
    f = encode_format(s, o);
  } catch (const VgeoError& e) {
    RC_ASSERT(e.error().code == std::string(kErrEncode));
    RC_ASSERT(o.position_step_log2.has_value());  // only a too-fine explicit step may fail here
    return;
  }
  const BuiltScene d = decode_format(f.data(), f.size(), "<test>");
  const FormatContainer fc = parse_container(f.data(), f.size(), "<test>");
  RC_ASSERT(compare_roundtrip(s, d, fc) == std::string());
  FormatOptions again = o;
  again.position_step_log2 = fc.meshes[0].quantization.position_step_log2;
  const std::vector<uint8_t> f2 = encode_format(d, again);
  RC_ASSERT(compare_roundtrip(d, decode_format(f2.data(), f2.size(), "<test>"), parse_container(f2.data(), f2.size(), "<test>")) ==
            std::string());
}

}  // namespace
}  // namespace vgeo

namespace vgeo {
namespace {

// The real builder's DAGs (several levels, split groups, real BVH) round-trip exactly too.
TEST(FormatRoundTrip, BuiltDagsRoundTripExactly) {
  BuildOptions bo;
  bo.threads = 1;
  Mesh grid = test::make_grid(48, 2.0f, true);
  Mesh sphere = test::make_sphere(40, 80);
  BuiltScene s = test::scene_of({build_dag(sphere, bo), build_dag(grid, bo)});
  FormatOptions o;
  o.page_size = kMinPageSize;
  o.zstd_level = 3;
  FormatReport report;
  const std::vector<uint8_t> f = encode_format(s, o, &report);
  const FormatContainer fc = parse_container(f.data(), f.size(), "<test>");
  EXPECT_GT(s.meshes[0].level_count, 1u);
  EXPECT_EQ(compare_roundtrip(s, decode_format(f.data(), f.size(), "<test>"), fc), "");
  EXPECT_EQ(report.triangles, s.meshes[0].triangle_count() + s.meshes[1].triangle_count());
  // Span-aware strip order (spec/format.md §3): nearly every cluster fits 5-bit offsets.
  // (Measured: 3 of 164 clusters here; the bound leaves room for builder changes.)
  EXPECT_LE(report.wide_index_clusters * 20, report.clusters)
      << report.wide_index_clusters << " of " << report.clusters << " clusters need > 5-bit offsets";
  // Root page of each mesh holds clusters of its coarsest level.
  for (const MeshMetadata& mm : fc.meshes) {
    uint32_t top = 0;
    for (const DagCluster& c : mm.dag.clusters) top = std::max(top, c.level);
    EXPECT_EQ(mm.dag.clusters[mm.page_clusters[0]].level, top);
  }
}

}  // namespace
}  // namespace vgeo

namespace vgeo {
namespace {

// Every finite UV encodes. UVs of a few units keep the 1/4096 step; tiling UVs of
// ±1e6 and ±FLT_MAX get a coarser per-mesh step (spec/format.md §2); the decoded UV is within
// half a step of the source and FormatReport::meshes reports that step and the measured error.
TEST(FormatRoundTrip, EveryFiniteUvEncodes) {
  struct Case { float scale, offset; bool float_max; int32_t expected_step; };
  const Case cases[] = {{4.0f, -1.0f, false, -12}, {3.0e6f, -1.0e6f, false, -3}, {1.0f, 0.0f, true, 104}};
  for (const Case& c : cases) {
    ClusterDag d = test::make_leaf_dag(test::make_grid(3));
    for (float& u : d.uvs) u = u * c.scale + c.offset;
    if (c.float_max) d.uvs[0] = std::numeric_limits<float>::max(), d.uvs[1] = -std::numeric_limits<float>::max();
    FormatReport report;
    const std::vector<uint8_t> f = encode_format(test::scene_of({d}), FormatOptions{}, &report);
    ASSERT_EQ(report.meshes.size(), 1u);
    const int32_t step = report.meshes[0].quantization.uv_step_log2;
    EXPECT_EQ(step, c.expected_step) << c.scale;
    const BuiltScene s = decode_format(f.data(), f.size(), "<uv>");
    // Decoded vertices are in canonical order: compare each with the source vertex nearest
    // to its (quantized) position (grid positions are distinct).
    const ClusterDag& out = s.meshes[0];
    double worst = 0;
    for (size_t v = 0; v < out.vertex_count(); ++v) {
      size_t src = 0;
      for (size_t w = 1; w < d.vertex_count(); ++w)
        if (distance_d(d.position(w), out.position(v)) < distance_d(d.position(src), out.position(v))) src = w;
      for (int k = 0; k < 2; ++k) {
        ASSERT_TRUE(std::isfinite(out.uvs[2 * v + k]));
        worst = std::max(worst, std::fabs(double(out.uvs[2 * v + k]) - double(d.uvs[2 * src + k])));
      }
    }
    EXPECT_LE(worst, std::ldexp(1.0, step - 1)) << c.scale;
    EXPECT_EQ(report.meshes[0].uv_max_error, worst) << c.scale;
  }
}

}  // namespace
}  // namespace vgeo
