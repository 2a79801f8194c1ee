// Import clean-up (degenerate removal, exact weld) and the OpenMesh formats' own checks
// (header counts vs file size, out-of-range face indices, comments, polygons).
#include <gtest/gtest.h>
#include <rapidcheck/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <tuple>

#include "vgeo/mesh/import.h"
#include "vgeo/mesh/validate.h"
#include "vgeo/mesh/weld.h"

namespace fs = std::filesystem;

namespace {

vgeo::Mesh mesh_of(std::vector<float> pos, std::vector<uint32_t> idx) {
  vgeo::Mesh m;
  m.positions = std::move(pos);
  m.indices = std::move(idx);
  return m;
}

// A temporary file removed at scope exit.
struct TempFile {
  fs::path path;
  TempFile(const std::string& name, const std::string& content) {
    path = fs::temp_directory_path() / ("vgeo_import_" + std::to_string(::getpid()) + "_" + name);
    std::ofstream(path, std::ios::binary) << content;
  }
  ~TempFile() { fs::remove(path); }
};

std::string code_of(const std::string& path) {
  try {
    vgeo::import_scene(path);
  } catch (const vgeo::VgeoError& e) {
    return e.error().code;
  }
  return "OK";
}

}  // namespace

TEST(ImportCleanup, DegenerateRemovalDropsRepeatedIndexAndZeroAreaOnly) {
  // 0..3 a unit square, 4 on the line 0-1 (collinear), 5 a copy of 0's position.
  auto m = mesh_of({0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0, 0.5f, 0, 0, 0, 0, 0},
                   {0, 1, 2,    // kept
                    0, 0, 3,    // repeated index
                    0, 4, 1,    // collinear: zero area
                    5, 0, 2,    // coincident corners: zero area
                    2, 1, 3});  // kept
  m.materials = {7, 1, 2, 3, 9};
  EXPECT_EQ(vgeo::remove_degenerate_triangles(m), 3u);
  EXPECT_EQ(m.indices, (std::vector<uint32_t>{0, 1, 2, 2, 1, 3}));
  EXPECT_EQ(m.materials, (std::vector<uint32_t>{7, 9}));
}

TEST(ImportCleanup, DegenerateRemovalOnAPoolEqualsOneThread) {
  // More triangles than one task of the pool's test: the square's two triangles repeated, with
  // a repeated-index, a collinear and a coincident-corner triangle every 1,000; and once clean.
  const size_t triangles = 3 * vgeo::kDegenerateTestTriangles + 123;
  for (bool with_degenerates : {true, false}) {
    auto base = mesh_of({0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0, 0.5f, 0, 0, 0, 0, 0}, {});
    const uint32_t degenerate[3][3] = {{0, 0, 3}, {0, 4, 1}, {5, 0, 2}}, kept[2][3] = {{0, 1, 2}, {2, 1, 3}};
    for (size_t t = 0; t < triangles; ++t) {
      const uint32_t* tri = with_degenerates && t % 1000 == 999 ? degenerate[t / 1000 % 3] : kept[t % 2];
      base.indices.insert(base.indices.end(), tri, tri + 3);
      base.materials.push_back(uint32_t(t % 7));
    }
    vgeo::Mesh serial = base;
    const size_t removed = vgeo::remove_degenerate_triangles(serial);
    EXPECT_EQ(removed, with_degenerates ? triangles / 1000 : 0u);
    for (unsigned threads : {2u, 3u, 0u}) {
      vgeo::ThreadPool pool(threads);
      vgeo::Mesh pooled = base;
      EXPECT_EQ(vgeo::remove_degenerate_triangles(pooled, &pool), removed) << threads;
      EXPECT_EQ(pooled.indices, serial.indices) << threads;
      EXPECT_EQ(pooled.materials, serial.materials) << threads;
    }
  }
}

// The value scans (by blocks, by parts on a pool) give a plain loop's first bad index: bad values
// at block and part edges, several parts with one (the first wins), none; finite edge values
// (-0.0, the largest float, a subnormal) are not bad.
TEST(ImportCleanup, ValueScansFindTheFirstBadValueOnAnyPool) {
  const size_t n = (size_t(1) << 20) + 4097;  // 4+ parts of 2^18 values, a partial block at the end
  const float inf = std::numeric_limits<float>::infinity(), nan = std::numeric_limits<float>::quiet_NaN();
  const std::vector<std::vector<std::pair<size_t, float>>> plants = {
      {}, {{0, nan}}, {{1023, inf}}, {{1024, -inf}}, {{n - 1, nan}}, {{(size_t(1) << 18) - 1, nan}},
      {{(size_t(1) << 18) * 3 + 5, inf}, {(size_t(1) << 18) + 7, nan}, {(size_t(1) << 18) * 2, -inf}}};
  for (const auto& plant : plants) {
    vgeo::Mesh m;
    m.positions.assign(n - n % 3, 1.0f);
    m.positions[1] = -0.0f, m.positions[2] = std::numeric_limits<float>::max(), m.positions[4] = 1e-45f;
    m.indices.assign(n - n % 3, 7);
    for (auto [at, value] : plant) {
      if (at >= m.positions.size()) at = m.positions.size() - 1;
      m.positions[at] = value;
      m.indices[at] = uint32_t(m.vertex_count() + at % 3);  // out of range by 0, 1 or 2
    }
    size_t want = m.positions.size();
    for (size_t i = 0; i < m.positions.size() && want == m.positions.size(); ++i)
      if (!std::isfinite(m.positions[i])) want = i;
    EXPECT_EQ(vgeo::first_non_finite(m.positions), want);
    EXPECT_EQ(vgeo::first_index_out_of_range(m), want);
    for (unsigned threads : {2u, 3u, 0u}) {
      vgeo::ThreadPool pool(threads);
      EXPECT_EQ(vgeo::first_non_finite(m.positions, &pool), want) << threads;
      EXPECT_EQ(vgeo::first_index_out_of_range(m, &pool), want) << threads;
    }
  }
}

TEST(ImportCleanup, TinyButNonZeroAreaIsKept) {
  // Area ~1e-14: below float epsilon squared, still not exactly zero in double.
  auto m = mesh_of({0, 0, 0, 1e-7f, 0, 0, 0, 1e-7f, 0}, {0, 1, 2});
  EXPECT_EQ(vgeo::remove_degenerate_triangles(m), 0u);
}

TEST(ImportCleanup, WeldMergesExactDuplicatesOnly) {
  // Two triangles of a quad stored as 6 separate vertices: 2 exact duplicates.
  auto m = mesh_of({0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 1, 0, 1, 0, 0, 1, 1, 0}, {0, 1, 2, 3, 4, 5});
  EXPECT_EQ(vgeo::weld_exact(m), 2u);
  EXPECT_EQ(m.vertex_count(), 4u);
  EXPECT_EQ(m.indices, (std::vector<uint32_t>{0, 1, 2, 2, 1, 3}));
  // Same positions, different normals: nothing merges.
  auto n = mesh_of({0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 1, 0, 1, 0, 0, 1, 1, 0}, {0, 1, 2, 3, 4, 5});
  n.normals = {0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, -1, 0, 0, -1, 0, 0, -1};
  EXPECT_EQ(vgeo::weld_exact(n), 0u);
  // -0 equals +0; a one-ulp difference does not.
  auto z = mesh_of({0, 0, 0, -0.0f, 0, 0, std::nextafter(0.0f, 1.0f), 0, 0}, {0, 1, 2});
  EXPECT_EQ(vgeo::weld_exact(z), 1u);
}

TEST(ImportCleanup, WeldDropsUnreferencedVertices) {
  auto m = mesh_of({0, 0, 0, 9, 9, 9, 1, 0, 0, 0, 1, 0}, {0, 2, 3});
  EXPECT_EQ(vgeo::weld_exact(m), 1u);
  EXPECT_EQ(m.positions, (std::vector<float>{0, 0, 0, 1, 0, 0, 0, 1, 0}));
}

// Property: welding preserves every triangle's corner attributes exactly, leaves no two
// equal vertices, and is idempotent. Positions come from a tiny grid so duplicates are common.
RC_GTEST_PROP(ImportCleanup, WeldPreservesCornersAndLeavesNoDuplicates, ()) {
  const size_t nv = *rc::gen::inRange<size_t>(1, 40);
  vgeo::Mesh m;
  for (size_t i = 0; i < nv * 3; ++i) m.positions.push_back(float(*rc::gen::inRange(-1, 2)) * 0.5f);
  const bool with_uv = *rc::gen::arbitrary<bool>();
  if (with_uv)
    for (size_t i = 0; i < nv * 2; ++i) m.uvs.push_back(float(*rc::gen::inRange(0, 2)));
  const size_t nt = *rc::gen::inRange<size_t>(1, 30);
  for (size_t i = 0; i < nt * 3; ++i) m.indices.push_back(uint32_t(*rc::gen::inRange<size_t>(0, nv)));
  const vgeo::Mesh before = m;
  vgeo::weld_exact(m);
  RC_ASSERT(m.indices.size() == before.indices.size());
  for (size_t c = 0; c < m.indices.size(); ++c) {
    for (int k = 0; k < 3; ++k)
      RC_ASSERT(m.positions[3 * m.indices[c] + k] == before.positions[3 * before.indices[c] + k]);
    if (with_uv)
      for (int k = 0; k < 2; ++k) RC_ASSERT(m.uvs[2 * m.indices[c] + k] == before.uvs[2 * before.indices[c] + k]);
  }
  std::map<std::vector<float>, int> seen;
  for (size_t v = 0; v < m.vertex_count(); ++v) {
    std::vector<float> key(m.positions.begin() + 3 * v, m.positions.begin() + 3 * v + 3);
    if (with_uv) key.insert(key.end(), m.uvs.begin() + 2 * v, m.uvs.begin() + 2 * v + 2);
    for (float& x : key) x = x == 0 ? 0.0f : x;
    RC_ASSERT(seen[key]++ == 0);
  }
  vgeo::Mesh again = m;
  RC_ASSERT(vgeo::weld_exact(again) == 0u);
  RC_ASSERT(again.indices == m.indices);
}

TEST(ImportCleanup, ImportStatsCountDegeneratesAndWeld) {
  TempFile f("stats.obj",
             "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nv 0 0 0\nv 1 0 0\nv 1 1 0\n"
             "f 1 2 3\nf 2 1 4\nf 5 6 7\n");
  vgeo::ImportOptions weld;
  weld.weld = true;
  auto r = vgeo::import_scene(f.path.string(), weld);
  EXPECT_EQ(r.stats.degenerate_removed, 1u);  // 2 1 4 is collinear
  EXPECT_EQ(r.scene.meshes[0].triangle_count(), 2u);
  // Vertices 5, 6 duplicate 1, 2; vertex 4 is unreferenced after degenerate removal.
  EXPECT_EQ(r.stats.duplicates_welded, 3u);
  EXPECT_EQ(r.scene.meshes[0].vertex_count(), 4u);
  auto plain = vgeo::import_scene(f.path.string());
  EXPECT_EQ(plain.stats.duplicates_welded, 0u);
  EXPECT_EQ(plain.scene.meshes[0].vertex_count(), 7u);
}

TEST(ImportCleanup, OffPolygonsCommentsAndColorsImport) {
  TempFile f("poly.off",
             "# leading comment\nCOFF\n# counts\n5 2 0\n0 0 0 1 0 0\n1 0 0 1 0 0 # red\n1 1 0 0 1 0\n0 1 0 0 0 1\n"
             "2 2 0 1 1 1\n4 0 1 2 3\n3 1 4 2\n");
  auto r = vgeo::import_scene(f.path.string());
  EXPECT_EQ(r.scene.meshes[0].triangle_count(), 3u);  // quad fan (2) + triangle
  EXPECT_EQ(r.scene.meshes[0].vertex_count(), 5u);
}

TEST(ImportCleanup, MeshFileFormatErrors) {
  std::vector<std::tuple<std::string, std::string, std::string>> cases = {
      {"huge.off", "OFF\n100000000 100000000 0\n0 0 0\n", "FILE_TRUNCATED"},
      {"huge.ply", "ply\nformat ascii 1.0\nelement vertex 4000000000\nproperty float x\nend_header\n", "FILE_TRUNCATED"},
      {"badidx.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n", "INDEX_OUT_OF_RANGE"},
      {"badidx.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n", "INDEX_OUT_OF_RANGE"},
      {"nan.obj", "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n", "POSITION_NOT_FINITE"},
      {"nofaces.off", "OFF\n3 0 0\n0 0 0\n1 0 0\n0 1 0\n", "MESH_EMPTY"},
      {"empty.stl", "", "MESH_EMPTY"},
      {"short.stl", std::string(80, 'x') + std::string("\x10\x00\x00\x00", 4) + std::string(50, '\0'), "FILE_TRUNCATED"},
      {"garbage.off", "this is not an off file\n", "MESH_PARSE_ERROR"},
      {"mesh.xyz", "1 2 3\n", "MESH_FORMAT_UNSUPPORTED"},
      {"four.off", "4OFF\n1 0 0\n0 0 0 0\n", "MESH_FORMAT_UNSUPPORTED"},
  };
  for (const auto& [name, content, code] : cases) {
    TempFile f(name, content);
    EXPECT_EQ(code_of(f.path.string()), code) << name;
  }
  EXPECT_EQ(code_of("/nonexistent/mesh.off"), "FILE_NOT_FOUND");
  EXPECT_EQ(code_of(fs::temp_directory_path().string()), "FILE_READ_ERROR");
}

TEST(ImportCleanup, NonFiniteStlPositionIsRejected) {
  std::string stl(80, ' ');
  uint32_t n = 1;
  stl.append(reinterpret_cast<const char*>(&n), 4);
  float tri[12] = {0, 0, 1, 0, 0, 0, std::numeric_limits<float>::quiet_NaN(), 0, 0, 0, 1, 0};
  stl.append(reinterpret_cast<const char*>(tri), 48);
  stl.append(2, '\0');
  TempFile f("nan.stl", stl);
  EXPECT_EQ(code_of(f.path.string()), "POSITION_NOT_FINITE");
}

TEST(ImportCleanup, BinaryStlImports) {
  std::string stl(80, ' ');
  uint32_t n = 1;
  stl.append(reinterpret_cast<const char*>(&n), 4);
  float tri[12] = {0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0};
  stl.append(reinterpret_cast<const char*>(tri), 48);
  stl.append(2, '\0');
  TempFile f("one.stl", stl);
  auto r = vgeo::import_scene(f.path.string());
  EXPECT_EQ(r.scene.meshes[0].triangle_count(), 1u);
  EXPECT_TRUE(r.scene.meshes[0].normals.empty());
}
