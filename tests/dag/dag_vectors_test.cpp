// VGEODAG1 conformance vectors (spec/dag.md §7, spec/format.md §9): spec/vectors/dag/ holds small
// valid files with the decode hash of their scene (lib/vgeo/format/decode_hash.h over what
// decode_dag_file returns) and invalid files with the DAGFILE_* code a reader must report, each
// naming its valid twin. The files come from make_dag_vectors() below, never by hand:
//   VGEO_UPDATE_VECTORS=1 build/release/tests/test_dag --gtest_filter=DagVectors.*
// rewrites them. VGEODAG1 is uncompressed, so the files are pinned byte for byte.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <set>
#include <string>

#include "format/format_test_util.h"
#include "support/paths.h"
#include "vgeo/dag/dag_io.h"
#include "vgeo/format/decode_hash.h"

namespace vgeo {
namespace {

namespace fs = std::filesystem;

struct DagVector {
  std::string name;
  std::vector<uint8_t> bytes;
  std::string expected;  // "OK" or a DAGFILE_* code
  std::string twin;      // invalid vectors: the valid file they were derived from
};

uint32_t get32(const std::vector<uint8_t>& f, size_t at) {
  return uint32_t(f[at]) | uint32_t(f[at + 1]) << 8 | uint32_t(f[at + 2]) << 16 | uint32_t(f[at + 3]) << 24;
}
void put32(std::vector<uint8_t>& f, size_t at, uint32_t v) {
  for (int k = 0; k < 4; ++k) f[at + k] = uint8_t(v >> (8 * k));
}

// Byte offsets of spec/dag.md §7 in a file of one mesh.
constexpr size_t kHeaderBytes = 24, kInstanceBytes = 68, kMeshHeaderBytes = 56, kClusterBytes = 88;
size_t mesh_offset(const std::vector<uint8_t>& f) {
  size_t at = kHeaderBytes;
  for (uint32_t m = 0, n = get32(f, 16); m < n; ++m) at += 4 + get32(f, at) + 16;
  return at + kInstanceBytes * get32(f, 20);
}

std::vector<DagVector> make_dag_vectors() {
  std::vector<DagVector> v;
  const std::vector<uint8_t> leaf = encode_dag_file(test::scene_of({test::make_leaf_dag(test::make_grid(3))}));
  v.push_back({"valid_leaf.vgeodag", leaf, "OK", ""});
  ClusterDag bare = test::make_leaf_dag(test::make_grid(3));
  bare.normals.clear(), bare.uvs.clear();
  v.push_back({"valid_positions_only.vgeodag", encode_dag_file(test::scene_of({bare})), "OK", ""});
  v.push_back({"valid_two_level.vgeodag",
               encode_dag_file(test::scene_of({test::make_two_level_dag(test::make_grid(12, 2.0f), test::make_grid(4, 2.0f))})),
               "OK", ""});
  const size_t mesh = mesh_offset(leaf), cluster0 = mesh + kMeshHeaderBytes;
  const uint32_t clusters = get32(leaf, mesh + 32);
  const size_t group0 = cluster0 + kClusterBytes * size_t(clusters);
  auto invalid = [&](const std::string& name, const char* code, auto edit) {
    std::vector<uint8_t> f = leaf;
    edit(f);
    v.push_back({name, f, code, "valid_leaf.vgeodag"});
  };
  invalid("bad_magic.vgeodag", "DAGFILE_BAD_MAGIC", [](auto& f) { f[0] = 'X'; });
  invalid("bad_generation.vgeodag", "DAGFILE_BAD_VERSION", [](auto& f) { f[7] = '2'; });
  invalid("bad_version.vgeodag", "DAGFILE_BAD_VERSION", [](auto& f) { put32(f, 8, 2); });
  invalid("truncated.vgeodag", "DAGFILE_TRUNCATED", [](auto& f) { f.pop_back(); });
  invalid("count_exceeds_data.vgeodag", "DAGFILE_TRUNCATED", [&](auto& f) { put32(f, mesh + 32, 1u << 28); });
  invalid("trailing_byte.vgeodag", "DAGFILE_TRAILING_BYTES", [](auto& f) { f.push_back(0); });
  invalid("mesh_flags_unknown.vgeodag", "DAGFILE_BAD_VALUE", [&](auto& f) { put32(f, mesh, get32(f, mesh) | 4); });
  invalid("material_offset_mismatch.vgeodag", "DAGFILE_BAD_VALUE", [&](auto& f) { put32(f, cluster0 + 28, get32(f, cluster0 + 28) + 1); });
  invalid("group_flags_unknown.vgeodag", "DAGFILE_BAD_VALUE", [&](auto& f) { put32(f, group0 + 20, 2); });
  // (Counts above the limits are caught first by the range check: the arrays are small.)
  invalid("cluster_triangles_zero.vgeodag", "DAGFILE_LIMIT_EXCEEDED", [&](auto& f) { put32(f, cluster0 + 12, 0); });
  invalid("cluster_vertices_over_range.vgeodag", "DAGFILE_INDEX_OUT_OF_RANGE", [&](auto& f) { put32(f, cluster0 + 4, 256); });
  invalid("cluster_group_out_of_range.vgeodag", "DAGFILE_INDEX_OUT_OF_RANGE", [&](auto& f) { put32(f, cluster0 + 16, 1000); });
  invalid("instance_mesh_out_of_range.vgeodag", "DAGFILE_INDEX_OUT_OF_RANGE", [&](auto& f) { put32(f, mesh - kInstanceBytes, 9); });
  return v;
}

// `OK <decode hash>` or the code.
std::string outcome(const std::vector<uint8_t>& f) {
  try {
    char hex[32];
    std::snprintf(hex, sizeof hex, "OK %016llx",
                  static_cast<unsigned long long>(decode_hash(decode_dag_file(f.data(), f.size(), "<vector>"))));
    return hex;
  } catch (const VgeoError& e) {
    return e.error().code;
  }
}

std::string manifest_line(const DagVector& v, const std::string& got) {
  return v.name + " " + got + (v.twin.empty() ? "" : " twin=" + v.twin);
}

fs::path dag_vector_dir() { return test::source_dir() / "spec" / "vectors" / "dag"; }

std::vector<uint8_t> read_bytes(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

const std::vector<DagVector>& dag_vectors() {
  static const std::vector<DagVector> all = make_dag_vectors();
  return all;
}

TEST(DagVectors, ManifestMatches) {
  if (const char* u = std::getenv("VGEO_UPDATE_VECTORS"); u && std::string(u) == "1") {
    fs::create_directories(dag_vector_dir());
    std::ofstream manifest(dag_vector_dir() / "manifest.txt");
    manifest << "# name expected [twin=valid file it was derived from] — VGEODAG1 (spec/dag.md §7, spec/format.md §9);"
                " generated by tests/dag/dag_vectors_test.cpp\n";
    for (const DagVector& v : dag_vectors()) {
      std::ofstream(dag_vector_dir() / v.name, std::ios::binary)
          .write(reinterpret_cast<const char*>(v.bytes.data()), std::streamsize(v.bytes.size()));
      const std::string got = outcome(v.bytes);
      EXPECT_EQ(v.expected == "OK" ? got.substr(0, 2) : got, v.expected) << v.name;
      manifest << manifest_line(v, got) << "\n";
    }
    GTEST_SKIP() << "vectors rewritten";
  }
  std::ifstream manifest(dag_vector_dir() / "manifest.txt");
  ASSERT_TRUE(manifest) << "missing spec/vectors/dag/manifest.txt";
  std::map<std::string, std::string> listed;
  for (std::string line; std::getline(manifest, line);)
    if (!line.empty() && line[0] != '#') listed[line.substr(0, line.find(' '))] = line;
  EXPECT_EQ(listed.size(), dag_vectors().size());
  for (const DagVector& v : dag_vectors()) {
    const std::vector<uint8_t> stored = read_bytes(dag_vector_dir() / v.name);
    EXPECT_TRUE(stored == v.bytes) << v.name << ": the generator no longer reproduces the stored file";
    EXPECT_EQ(listed[v.name], manifest_line(v, outcome(stored))) << v.name;
  }
}

// Every DAGFILE_* code of spec/errors.md §Build (VGEODAG1 decode) has an invalid vector.
TEST(DagVectors, EveryDagFileCodeHasAnInvalidVector) {
  std::ifstream in(test::source_dir() / "spec" / "errors.md");
  std::set<std::string> codes, covered;
  bool inside = false;
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("#", 0) == 0) inside = line.find("VGEODAG1 decode") != std::string::npos;
    if (inside && line.rfind("| `DAGFILE_", 0) == 0) codes.insert(line.substr(3, line.find('`', 3) - 3));
  }
  ASSERT_FALSE(codes.empty()) << "spec/errors.md §VGEODAG1 decode not parsed";
  for (const DagVector& v : dag_vectors())
    if (v.expected != "OK") covered.insert(v.expected);
  for (const std::string& c : codes) EXPECT_TRUE(covered.count(c)) << c << " has no invalid vector";
}

}  // namespace
}  // namespace vgeo
