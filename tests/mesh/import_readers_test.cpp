// The OBJ / PLY / OFF / STL readers (lib/vgeo/mesh/import_{obj,ply,off,stl}.cpp) on small
// hand-made files: every PLY encoding and both STL encodings give the same mesh, OBJ corners
// keep their seams, counts beyond the file are refused before anything is reserved, and the
// memory import equals the file import.
#include <gtest/gtest.h>

#include <bit>
#include <charconv>
#include <cstring>
#include <string>
#include <vector>

#include "vgeo/mesh/import.h"
#include "vgeo/mesh/import_text.h"

namespace {

vgeo::ImportResult import_bytes(const std::string& bytes, const std::string& name) {
  return vgeo::import_scene_from_memory(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size(), name);
}

std::string code_of(const std::string& bytes, const std::string& name) {
  try {
    import_bytes(bytes, name);
  } catch (const vgeo::VgeoError& e) {
    return e.error().code;
  }
  return "OK";
}

// A tetrahedron with per-vertex normals and uvs.
const float kVerts[4][8] = {{0, 0, 0, 0, 0, 1, 0, 0}, {1, 0, 0, 0, 0, 1, 1, 0}, {0, 1, 0, 0, 0, 1, 0, 1}, {0, 0, 1, 1, 0, 0, 1, 1}};
const int kFaces[4][3] = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};

std::string ply_header(const char* format) {
  return std::string("ply\nformat ") + format +
         " 1.0\ncomment test\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
         "property float nx\nproperty float ny\nproperty float nz\nproperty float s\nproperty float t\n"
         "element face 4\nproperty list uchar int vertex_indices\nend_header\n";
}

template <typename T>
void put(std::string& s, T v, bool big) {
  char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  if (big == (std::endian::native == std::endian::little))
    for (size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(b[i], b[sizeof(T) - 1 - i]);
  s.append(b, sizeof(T));
}

std::string binary_ply(bool big) {
  std::string s = ply_header(big ? "binary_big_endian" : "binary_little_endian");
  for (const auto& v : kVerts)
    for (float x : v) put(s, x, big);
  for (const auto& f : kFaces) {
    put(s, uint8_t(3), big);
    for (int i : f) put(s, int32_t(i), big);
  }
  return s;
}

std::string ascii_ply() {
  std::string s = ply_header("ascii");
  for (const auto& v : kVerts) {
    for (float x : v) s += std::to_string(x) + " ";
    s += "\n";
  }
  for (const auto& f : kFaces) s += "3 " + std::to_string(f[0]) + " " + std::to_string(f[1]) + " " + std::to_string(f[2]) + "\n";
  return s;
}

void expect_same_mesh(const vgeo::Mesh& a, const vgeo::Mesh& b) {
  EXPECT_EQ(a.positions, b.positions);
  EXPECT_EQ(a.normals, b.normals);
  EXPECT_EQ(a.uvs, b.uvs);
  EXPECT_EQ(a.indices, b.indices);
}

}  // namespace

TEST(ImportReaders, PlyEncodingsGiveTheSameMesh) {
  const auto ascii = import_bytes(ascii_ply(), "t.ply");
  const auto little = import_bytes(binary_ply(false), "t.ply");
  const auto big = import_bytes(binary_ply(true), "t.ply");
  ASSERT_EQ(ascii.scene.meshes.size(), 1u);
  const vgeo::Mesh& m = ascii.scene.meshes[0];
  EXPECT_EQ(m.triangle_count(), 4u);
  EXPECT_EQ(m.vertex_count(), 4u);
  EXPECT_EQ(m.uvs.size(), 8u);
  EXPECT_EQ(m.normals.size(), 12u);
  EXPECT_EQ(m.uvs[7], 1.0f);
  expect_same_mesh(m, little.scene.meshes[0]);
  expect_same_mesh(m, big.scene.meshes[0]);
}

TEST(ImportReaders, StlAsciiAndBinaryGiveTheSameMesh) {
  std::string ascii = "solid t\n", binary(80, ' ');
  put(binary, uint32_t(4), false);
  for (const auto& f : kFaces) {
    ascii += "  facet normal 0 0 1\n    outer loop\n";
    for (int k = 0; k < 3; ++k) put(binary, 0.0f, false);
    for (int i : f) {
      ascii += "      vertex " + std::to_string(kVerts[i][0]) + " " + std::to_string(kVerts[i][1]) + " " +
               std::to_string(kVerts[i][2]) + "\n";
      for (int k = 0; k < 3; ++k) put(binary, kVerts[i][k], false);
    }
    put(binary, uint16_t(0), false);
    ascii += "    endloop\n  endfacet\n";
  }
  ascii += "endsolid t\n";
  const auto a = import_bytes(ascii, "t.stl"), b = import_bytes(binary, "t.stl");
  EXPECT_EQ(a.scene.meshes[0].vertex_count(), 4u);  // corners merged by position
  expect_same_mesh(a.scene.meshes[0], b.scene.meshes[0]);
}

TEST(ImportReaders, ObjCornersKeepSeamsAndNegativeIndicesResolve) {
  const std::string obj =
      "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nvt 1 1\nvt 0.5 0.5\n"
      "f 1/1 2/2 3/3\nf -3/5 -1/4 -2/3\n";  // second face: v2 v4 v3, v2 with another uv
  const auto r = import_bytes(obj, "t.obj");
  const vgeo::Mesh& m = r.scene.meshes[0];
  EXPECT_EQ(m.triangle_count(), 2u);
  EXPECT_EQ(m.vertex_count(), 5u);  // v2 twice (two uvs), v3 once (same vt 3)
  EXPECT_TRUE(m.normals.empty());
  EXPECT_EQ(m.uvs[2 * m.indices[3]], 0.5f);
  EXPECT_EQ(m.positions[3 * m.indices[3]], 1.0f);
  EXPECT_TRUE(r.warnings.empty());
}

TEST(ImportReaders, ObjCornersWithoutVtAreFilledAndWarned) {
  // As in assimp's regr01.obj: some faces use vt, others do not.
  const auto r = import_bytes("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvt 0.25 0.75\nf 1/1 2/1 3/1\nf 2 4 3\n", "t.obj");
  const vgeo::Mesh& m = r.scene.meshes[0];
  ASSERT_EQ(m.uvs.size(), 2 * m.vertex_count());
  EXPECT_EQ(m.uvs[0], 0.25f);
  EXPECT_EQ(m.uvs[2 * m.indices[4]], 0.0f);
  ASSERT_EQ(r.warnings.size(), 1u);
  EXPECT_EQ(r.warnings[0].code, "ATTRIBUTE_FILLED");
  // Normals filled the same way: the polygon's unit normal.
  const auto n = import_bytes("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvn 0 0 1\nf 1//1 2//1 3//1\nf 2 4 3\n", "t.obj");
  const vgeo::Mesh& nm = n.scene.meshes[0];
  ASSERT_EQ(nm.normals.size(), 3 * nm.vertex_count());
  EXPECT_EQ(nm.normals[3 * nm.indices[4] + 2], 1.0f);
}

TEST(ImportReaders, ObjRepeatedCornersAreRemovedFromThePolygon) {
  // A ring closed by repeating its first corner, and a quad repeated twice over.
  const auto r = import_bytes("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4 1\nf 1 2 3 4 1 2 3 4\n", "t.obj");
  EXPECT_EQ(r.scene.meshes[0].triangle_count(), 4u);
  EXPECT_EQ(r.stats.degenerate_removed, 0u);
}

TEST(ImportReaders, CountsBeyondTheFileAreRefusedBeforeReserving) {
  EXPECT_EQ(code_of("ply\nformat binary_little_endian 1.0\nelement vertex 100000\nproperty float x\nproperty float y\n"
                    "property float z\nend_header\n",
                    "t.ply"),
            "FILE_TRUNCATED");
  std::string list = "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty uchar x\nproperty uchar y\n"
                     "property uchar z\nelement face 1\nproperty list uint uint vertex_indices\nend_header\n";
  list += std::string(9, '\0');
  put(list, uint32_t(4000000000u), false);
  EXPECT_EQ(code_of(list, "t.ply"), "FILE_TRUNCATED");
  EXPECT_EQ(code_of("OFF\n3 2000000000 0\n0 0 0\n1 0 0\n0 1 0\n", "t.off"), "FILE_TRUNCATED");
  std::string stl(80, ' ');
  put(stl, uint32_t(0xFFFFFFFFu), false);
  EXPECT_EQ(code_of(stl, "t.stl"), "FILE_TRUNCATED");
}

TEST(ImportReaders, MalformedFilesGiveTheirCodes) {
  // The OpenMesh reader looped forever on a header cut inside a property line.
  EXPECT_EQ(code_of("ply\nformat ascii 1.0\nelement vertex 3\nprop", "t.ply"), "FILE_TRUNCATED");
  EXPECT_EQ(code_of("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                    "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0 1 0 0 0 1 0\n3 0 1 5\n",
                    "t.ply"),
            "INDEX_OUT_OF_RANGE");
  EXPECT_EQ(code_of("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nend_header\n0\n", "t.ply"), "MESH_PARSE_ERROR");
  EXPECT_EQ(code_of("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 x\n3 0 1 2\n", "t.off"), "MESH_PARSE_ERROR");
  EXPECT_EQ(code_of("OFF BINARY\n", "t.off"), "MESH_FORMAT_UNSUPPORTED");
  EXPECT_EQ(code_of("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 0\n", "t.obj"), "INDEX_OUT_OF_RANGE");
  EXPECT_EQ(code_of("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3/7\n", "t.obj"), "INDEX_OUT_OF_RANGE");
  EXPECT_EQ(code_of("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -4\n", "t.obj"), "INDEX_OUT_OF_RANGE");
  EXPECT_EQ(code_of("solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nendloop\n", "t.stl"), "MESH_PARSE_ERROR");
}

namespace {

// An OFF grid of (n+1)^2 vertices and 2 n^2 triangles (a body of several MiB, so the reader
// cuts it into line ranges when given threads), with `extra` spliced in after line `at` of the body.
std::string grid_off(int n, const std::string& extra = "", size_t at = 0) {
  std::vector<std::string> body;
  for (int y = 0; y <= n; ++y)
    for (int x = 0; x <= n; ++x)
      body.push_back(std::to_string(x * 0.37f) + " " + std::to_string(y * 1.13f) + " " + std::to_string((x ^ y) * 0.01f));
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      const int a = y * (n + 1) + x, b = a + 1, c = a + n + 1, d = c + 1;
      body.push_back("3 " + std::to_string(a) + " " + std::to_string(b) + " " + std::to_string(d));
      // One quad in 97 and one polygon repeating a vertex in 101 (dropped and counted).
      if ((x + y) % 101 == 0) body.push_back("4 " + std::to_string(a) + " " + std::to_string(d) + " " + std::to_string(c) + " " + std::to_string(a));
      else if ((x + y) % 97 == 0) body.push_back("4 " + std::to_string(a) + " " + std::to_string(b) + " " + std::to_string(d) + " " + std::to_string(c));
      else body.push_back("3 " + std::to_string(a) + " " + std::to_string(d) + " " + std::to_string(c));
    }
  const size_t faces = body.size() - size_t(n + 1) * (n + 1);
  if (!extra.empty()) body.insert(body.begin() + std::ptrdiff_t(at), extra);
  std::string s = "OFF\n" + std::to_string((n + 1) * (n + 1)) + " " + std::to_string(faces) + " 0\n";
  for (const std::string& line : body) s += line + "\n";
  return s;
}

vgeo::ImportResult import_with_threads(const std::string& bytes, unsigned threads) {
  vgeo::ImportOptions options;
  options.threads = threads;
  return vgeo::import_scene_from_memory(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size(), "t.off", options);
}

std::string code_with_threads(const std::string& bytes, unsigned threads) {
  try {
    import_with_threads(bytes, threads);
  } catch (const vgeo::VgeoError& e) {
    return e.error().code + " " + e.error().where;
  }
  return "OK";
}

}  // namespace

TEST(ImportReaders, OffByLineRangesEqualsOneThread) {
  // Plain, with a comment line among the vertices (the parallel read refuses it and the serial
  // loop reads it), with a blank line among the faces, and with empty lines before the first
  // vertex (CGAL's blank line after the counts: the ranges start past them).
  const int n = 300;
  for (const std::string& bytes : {grid_off(n), grid_off(n, "# a comment", 1000), grid_off(n, "", 0),
                                   grid_off(n, " \t\n# a comment\n", 0), grid_off(n, "# a comment\n\n   ", 0),
                                   grid_off(n, "   ", size_t(n + 1) * (n + 1) + 5000)}) {
    ASSERT_GT(bytes.size(), size_t(3) << 20);
    const vgeo::ImportResult one = import_with_threads(bytes, 1);
    for (unsigned threads : {2u, 3u, 0u}) {
      const vgeo::ImportResult many = import_with_threads(bytes, threads);
      ASSERT_EQ(many.scene.meshes.size(), 1u);
      EXPECT_EQ(many.scene.meshes[0].positions, one.scene.meshes[0].positions);
      EXPECT_EQ(many.scene.meshes[0].indices, one.scene.meshes[0].indices);
      EXPECT_EQ(many.stats.degenerate_removed, one.stats.degenerate_removed);
      ASSERT_EQ(many.warnings.size(), one.warnings.size());
      for (size_t i = 0; i < one.warnings.size(); ++i) EXPECT_EQ(many.warnings[i].what, one.warnings[i].what);
    }
  }
  EXPECT_GT(import_with_threads(grid_off(n), 2).stats.degenerate_removed, 0u);
}

TEST(ImportReaders, OffByLineRangesGivesTheOneThreadError) {
  const int n = 300;
  const size_t vertices = size_t(n + 1) * (n + 1);
  std::string truncated = grid_off(n);
  truncated.resize(truncated.size() - 200000);
  std::string bad_index = grid_off(n, "3 0 1 " + std::to_string(vertices), vertices + 7000);
  std::string bad_number = grid_off(n, "1 2 x", 4000);
  for (const std::string& bytes : {truncated, bad_index, bad_number}) {
    const std::string one = code_with_threads(bytes, 1);
    EXPECT_NE(one, "OK");
    EXPECT_EQ(code_with_threads(bytes, 2), one);
  }
}

// The short-decimal path of the text readers (read_short_decimal, mesh/import_text.h) gives
// from_chars' float bit for bit, and ends where it does: 2M random decimals of 1-9 integer and
// 0-11 fraction digits (leading zeros, signs, both sides of 2^24 and of 10^10), plus edges.
// Where it declines (nullptr), from_chars reads the token as before.
TEST(ImportReaders, ShortDecimalsReadAsFromCharsDoes) {
  uint64_t state = 0x9E3779B97F4A7C15ull;
  auto next = [&] {
    state ^= state << 13, state ^= state >> 7, state ^= state << 17;
    return state;
  };
  auto check = [](const std::string& text) {
    const char* const end = text.data() + text.size();
    float fast = 0.0f, slow = 0.0f;
    const char* q = vgeo::detail::read_short_decimal(text.data(), end, fast);
    if (q == nullptr) return false;
    const auto r = std::from_chars(text.data(), end, slow);
    EXPECT_EQ(r.ec, std::errc()) << text;
    EXPECT_EQ(r.ptr, q) << text;
    EXPECT_EQ(std::bit_cast<uint32_t>(fast), std::bit_cast<uint32_t>(slow)) << text;
    return true;
  };
  size_t taken = 0;
  for (int i = 0; i < 2'000'000; ++i) {
    std::string text = next() % 2 ? "-" : "";
    const int integer = 1 + int(next() % 9), fraction = int(next() % 12);
    for (int k = 0; k < integer; ++k) text += char('0' + (k == 0 && next() % 4 ? next() % 2 : next() % 10));
    if (fraction > 0) text += '.';
    for (int k = 0; k < fraction; ++k) text += char('0' + next() % 10);
    taken += check(text);
  }
  EXPECT_GT(taken, size_t(500'000));  // the path is taken, not only declined
  for (const char* text : {"0", "-0", "0.0", "-0.000", "16777215", "16777216", "1.6777215", "0.0000000001",
                           "-0.0000000001", "0.00000000001", "1677721.5", "9999999", "0.1", "-0.5", "3.4028235"})
    check(text);
  for (const char* text : {"", "-", ".5", "-.5", "5.", "1e5", "+1", "1.5e3", "inf", "nan"}) {
    float v = 7.0f;
    const char* end = text + std::strlen(text);
    const char* q = vgeo::detail::read_short_decimal(text, end, v);
    EXPECT_TRUE(q == nullptr || q < end) << text;  // declined, or stops before what it does not read
  }
}
