// VGEODAG1 file: exact round trip, every truncation and trailing bytes rejected, indices
// range-checked (spec/dag.md §File).
#include <gtest/gtest.h>

#include <cstdio>
#include <cstring>
#include <filesystem>
#include <unistd.h>

#include "support/shapes.h"
#include "vgeo/dag/build.h"
#include "vgeo/dag/dag_io.h"
#include "vgeo/core/error.h"

namespace vgeo::test {
namespace {

BuiltScene small_scene() {
  Scene s;
  Mesh m = make_sphere(10, 16);
  m.materials.resize(m.triangle_count());
  for (size_t t = 0; t < m.triangle_count(); ++t) m.materials[t] = m.positions[3 * m.indices[3 * t] + 2] > 0 ? 1 : 0;
  m.uvs.resize(2 * m.vertex_count(), 0.25f);
  s.meshes.push_back(m);
  s.meshes.push_back(make_grid(6));
  s.materials = {Material{"red", {1, 0, 0, 1}}, Material{"", {0, 1, 0, 0.5f}}};
  Instance a, b;
  b.mesh = 1;
  b.transform[12] = 1e7f;
  s.instances = {a, b};
  BuildOptions o;
  o.threads = 1;
  return build_scene(s, o);
}

std::string code_of(const std::vector<uint8_t>& bytes) {
  try {
    decode_dag_file(bytes.data(), bytes.size(), "<memory>");
  } catch (const VgeoError& e) {
    return e.error().code;
  }
  return "";
}

TEST(DagFile, RoundTripIsExact) {
  BuiltScene s = small_scene();
  std::vector<uint8_t> bytes = encode_dag_file(s);
  BuiltScene d = decode_dag_file(bytes.data(), bytes.size(), "<memory>");
  EXPECT_EQ(encode_dag_file(d), bytes);
  ASSERT_EQ(d.meshes.size(), 2u);
  const ClusterDag& a = s.meshes[0];
  const ClusterDag& b = d.meshes[0];
  ASSERT_EQ(a.clusters.size(), b.clusters.size());
  EXPECT_EQ(std::memcmp(a.clusters.data(), b.clusters.data(), a.clusters.size() * sizeof(DagCluster)), 0);
  EXPECT_EQ(std::memcmp(a.groups.data(), b.groups.data(), a.groups.size() * sizeof(DagGroup)), 0);
  EXPECT_EQ(std::memcmp(a.bvh_nodes.data(), b.bvh_nodes.data(), a.bvh_nodes.size() * sizeof(BvhNode)), 0);
  EXPECT_EQ(a.positions, b.positions);
  EXPECT_EQ(a.normals, b.normals);
  EXPECT_EQ(a.uvs, b.uvs);
  EXPECT_EQ(a.indices, b.indices);
  EXPECT_EQ(a.triangle_materials, b.triangle_materials);
  EXPECT_EQ(a.generated_clusters, b.generated_clusters);
  EXPECT_EQ(a.level_count, b.level_count);
  EXPECT_EQ(d.materials[0].name, "red");
  EXPECT_EQ(d.instances[1].transform[12], 1e7f);
}

TEST(DagFile, EveryTruncationIsRejected) {
  std::vector<uint8_t> bytes = encode_dag_file(small_scene());
  for (size_t n = 0; n < bytes.size(); ++n) {
    std::vector<uint8_t> prefix(bytes.begin(), bytes.begin() + n);
    ASSERT_EQ(code_of(prefix), "DAGFILE_TRUNCATED") << "prefix of " << n << " bytes";
  }
}

TEST(DagFile, TrailingByteIsRejected) {
  std::vector<uint8_t> bytes = encode_dag_file(small_scene());
  bytes.push_back(0);
  EXPECT_EQ(code_of(bytes), "DAGFILE_TRAILING_BYTES");
}

TEST(DagFile, BadMagicAndVersion) {
  std::vector<uint8_t> bytes = encode_dag_file(small_scene());
  std::vector<uint8_t> m = bytes;
  m[0] = 'X';
  EXPECT_EQ(code_of(m), "DAGFILE_BAD_MAGIC");
  m = bytes;
  m[7] = '2';
  EXPECT_EQ(code_of(m), "DAGFILE_BAD_VERSION");
  m = bytes;
  m[8] = 2;  // version field
  EXPECT_EQ(code_of(m), "DAGFILE_BAD_VERSION");
}

TEST(DagFile, HugeCountsAreRejectedBeforeAllocation) {
  std::vector<uint8_t> bytes = encode_dag_file(small_scene());
  std::vector<uint8_t> m = bytes;
  // mesh_count = 0xFFFFFFFF
  std::memset(&m[12], 0xFF, 4);
  EXPECT_EQ(code_of(m), "DAGFILE_TRUNCATED");
}

TEST(DagFile, OutOfRangeIndicesAreRejected) {
  BuiltScene s = small_scene();
  ASSERT_FALSE(s.meshes[0].generated_clusters.empty());
  ASSERT_FALSE(s.meshes[0].bvh_nodes.empty());
  auto expect_code = [&](auto mutate, const char* code) {
    BuiltScene c = s;
    mutate(c);
    std::vector<uint8_t> bytes = encode_dag_file(c);
    EXPECT_EQ(code_of(bytes), code);
  };
  expect_code([](BuiltScene& c) { c.meshes[0].clusters[0].group = 1000000; }, "DAGFILE_INDEX_OUT_OF_RANGE");
  expect_code([](BuiltScene& c) { c.meshes[0].clusters[0].vertex_offset = 1u << 30; }, "DAGFILE_INDEX_OUT_OF_RANGE");
  expect_code([](BuiltScene& c) { c.meshes[0].indices[0] = 255; }, "DAGFILE_INDEX_OUT_OF_RANGE");
  expect_code([](BuiltScene& c) { c.meshes[0].generated_clusters[0] = 1u << 30; }, "DAGFILE_INDEX_OUT_OF_RANGE");
  expect_code([](BuiltScene& c) { c.meshes[0].bvh_nodes[0].children[0] = 1u << 30; }, "DAGFILE_INDEX_OUT_OF_RANGE");
  expect_code([](BuiltScene& c) { c.meshes[0].triangle_materials[0] = 7; }, "DAGFILE_INDEX_OUT_OF_RANGE");
  expect_code([](BuiltScene& c) { c.instances[0].mesh = 2; }, "DAGFILE_INDEX_OUT_OF_RANGE");
  expect_code([](BuiltScene& c) { c.meshes[0].groups[0].flags = 2; }, "DAGFILE_BAD_VALUE");
  expect_code([](BuiltScene& c) { c.meshes[0].clusters[0].triangle_count = 0; }, "DAGFILE_LIMIT_EXCEEDED");
}

TEST(DagFile, WriteReadFile) {
  BuiltScene s = small_scene();
  std::filesystem::path dir = std::filesystem::temp_directory_path() / ("vgeo_dag_io_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  std::string path = (dir / "a.vgeodag").string();
  write_dag_file(path, s);
  BuiltScene r = read_dag_file(path);
  EXPECT_EQ(encode_dag_file(r), encode_dag_file(s));
  try {
    read_dag_file((dir / "missing.vgeodag").string());
    FAIL();
  } catch (const VgeoError& e) {
    EXPECT_EQ(e.error().code, "FILE_NOT_FOUND");
    EXPECT_EQ(e.error().exit_code, kExitIo);
  }
  std::filesystem::remove_all(dir);
}

// The streaming writer hands arrays of ≥ 1 MiB to the file directly and flushes its field
// buffer every 1 MiB: the file must still be byte-identical to the in-memory encoding, and
// a failed write must leave the previous file and no temporary behind.
TEST(DagFile, StreamedFileEqualsTheEncodingAcrossFlushes) {
  BuiltScene s = small_scene();
  ClusterDag& big = s.meshes[1];
  // Pad the vertex arrays past several flushes (the encoder does not validate).
  const size_t extra = 400000;
  for (size_t i = 0; i < 3 * extra; ++i) big.positions.push_back(float(i) * 0.5f);
  if (!big.normals.empty()) big.normals.resize(big.positions.size(), 0.0f);
  if (!big.uvs.empty()) big.uvs.resize(2 * (big.positions.size() / 3), 0.0f);
  big.clusters.resize(big.clusters.size() + 20000, big.clusters.back());  // > 1 MiB of records
  std::filesystem::path dir = std::filesystem::temp_directory_path() / ("vgeo_dag_stream_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::string path = (dir / "big.vgeodag").string();
  write_dag_file(path, s);
  std::vector<uint8_t> expected = encode_dag_file(s);
  std::vector<uint8_t> got(std::filesystem::file_size(path));
  std::FILE* f = std::fopen(path.c_str(), "rb");
  ASSERT_NE(f, nullptr);
  ASSERT_EQ(std::fread(got.data(), 1, got.size(), f), got.size());
  std::fclose(f);
  EXPECT_GT(expected.size(), size_t(5) << 20);
  EXPECT_TRUE(got == expected);
  // Writing into a directory that does not exist fails with IO_WRITE_FAILED and creates nothing.
  try {
    write_dag_file((dir / "no" / "such.vgeodag").string(), s);
    FAIL();
  } catch (const VgeoError& e) {
    EXPECT_EQ(e.error().code, "IO_WRITE_FAILED");
    EXPECT_EQ(e.error().exit_code, kExitIo);
  }
  size_t entries = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) entries += entry.path() != path;
  EXPECT_EQ(entries, 0u);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace vgeo::test
