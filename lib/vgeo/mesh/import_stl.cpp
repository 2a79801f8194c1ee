// STL reader, ASCII and binary (spec/errors.md §Import). Corners are merged by exact position
// (value comparison, -0 == +0) in first-occurrence order, as the OpenMesh reader this replaces
// did; facet normals are not imported (an STL has no vertex normals).
#include <cmath>
#include <cstring>
#include <unordered_map>

#include "vgeo/mesh/import_text.h"

namespace vgeo::detail {
namespace {

constexpr size_t kStlCommentBytes = 80;
constexpr size_t kStlHeaderBytes = kStlCommentBytes + 4;  // comment + uint32 triangle count
constexpr size_t kStlTriangleBytes = 50;                  // normal + 3 corners (12 floats) + attribute word
// The shortest ASCII facet ("facet normal 0 0 0 outer loop vertex 0 0 0 ... endloop endfacet")
// is far longer than this: a bound for reserving from the file size.
constexpr size_t kMinAsciiFacetBytes = 64;

struct CornerKey {
  uint32_t bits[3];
  bool operator==(const CornerKey& o) const { return std::memcmp(bits, o.bits, sizeof bits) == 0; }
};
struct CornerKeyHash {
  size_t operator()(const CornerKey& k) const {
    uint64_t h = 1469598103934665603ull;
    for (uint32_t b : k.bits) h = (h ^ b) * 1099511628211ull;
    return size_t(h);
  }
};

// Merges corners by position. -0 is stored as +0 in the key so both merge (the first one seen
// is kept as the vertex's position).
struct CornerWelder {
  Mesh& mesh;
  std::unordered_map<CornerKey, uint32_t, CornerKeyHash> index;
  explicit CornerWelder(Mesh& m) : mesh(m) {}
  uint32_t add(const float p[3]) {
    CornerKey k;
    for (int i = 0; i < 3; ++i) {
      const float v = p[i] == 0.0f ? 0.0f : p[i];
      std::memcpy(&k.bits[i], &v, 4);
    }
    const auto [it, inserted] = index.emplace(k, uint32_t(mesh.vertex_count()));
    if (inserted) mesh.positions.insert(mesh.positions.end(), p, p + 3);
    return it->second;
  }
};

void check_finite(const float p[3], uint64_t facet, const std::string& where) {
  // A NaN corner would never merge with itself: reported here with the facet it belongs to.
  for (int i = 0; i < 3; ++i)
    if (!std::isfinite(p[i]))
      fail("POSITION_NOT_FINITE", where, "STL triangle " + std::to_string(facet) + " has a non-finite corner");
}

void read_binary(const uint8_t* data, size_t size, const std::string& where, Mesh& mesh, PolygonSink& sink) {
  uint32_t count = 0;
  std::memcpy(&count, data + kStlCommentBytes, 4);
  const uint64_t expected = kStlHeaderBytes + uint64_t(count) * kStlTriangleBytes;
  if (expected > size)
    fail("FILE_TRUNCATED", where, "binary STL declares " + std::to_string(count) + " triangles (" +
                                      std::to_string(expected) + " bytes) but has " + std::to_string(size));
  CornerWelder welder(mesh);
  welder.index.reserve(count);
  mesh.indices.reserve(size_t(count) * 3);
  for (uint32_t t = 0; t < count; ++t) {
    const uint8_t* tri = data + kStlHeaderBytes + size_t(t) * kStlTriangleBytes;
    uint32_t ring[3];
    for (int c = 0; c < 3; ++c) {
      float p[3];
      std::memcpy(p, tri + 12 * (c + 1), 12);  // floats 0..2 are the facet normal
      check_finite(p, t, where);
      ring[c] = welder.add(p);
    }
    sink.add(ring, 3);
  }
}

void read_ascii(const uint8_t* data, size_t size, const std::string& where, Mesh& mesh, PolygonSink& sink) {
  TextCursor in(data, size);
  CornerWelder welder(mesh);
  welder.index.reserve(size / kMinAsciiFacetBytes);
  uint64_t facet = 0;
  auto expect = [&](std::string_view got, const char* keyword) {
    if (got != keyword)
      fail("MESH_PARSE_ERROR", at_line(where, in.line),
           "expected '" + std::string(keyword) + "', found '" + std::string(got.substr(0, 32)) + "'");
  };
  bool in_solid = false;
  for (std::string_view t = in.token(); !t.empty(); t = in.token()) {
    if (t == "solid") {  // the name is the rest of the line
      in.rest_of_line();
      in_solid = true;
      continue;
    }
    if (t == "endsolid") {
      in.rest_of_line();
      in_solid = false;
      continue;
    }
    if (!in_solid) expect(t, "solid");
    expect(t, "facet");
    in.rest_of_line();  // "normal nx ny nz": not imported
    expect(in.token(), "outer");
    expect(in.token(), "loop");
    uint32_t ring[3];
    for (int c = 0; c < 3; ++c) {
      expect(in.token(), "vertex");
      float p[3];
      for (int k = 0; k < 3; ++k) {
        const std::string_view v = in.token();
        if (!parse_float(v, p[k]))
          fail(v.empty() ? "FILE_TRUNCATED" : "MESH_PARSE_ERROR", at_line(where, in.line),
               "STL vertex coordinate '" + std::string(v.substr(0, 32)) + "' is not a number");
      }
      check_finite(p, facet, where);
      ring[c] = welder.add(p);
    }
    expect(in.token(), "endloop");
    expect(in.token(), "endfacet");
    sink.add(ring, 3);
    ++facet;
  }
}

}  // namespace

void import_stl(const uint8_t* data, size_t size, const std::string& where, ImportResult& out) {
  if (size == 0) fail("MESH_EMPTY", where, "file is empty");
  // ASCII STL starts with "solid"; so do some binary files' comments, but those satisfy the
  // binary size relation exactly.
  const bool ascii_candidate = size >= 5 && std::memcmp(data, "solid", 5) == 0;
  bool binary = !ascii_candidate;
  if (ascii_candidate && size >= kStlHeaderBytes) {
    uint32_t count = 0;
    std::memcpy(&count, data + kStlCommentBytes, 4);
    binary = kStlHeaderBytes + uint64_t(count) * kStlTriangleBytes == size;
  }
  if (binary && size < kStlHeaderBytes) fail("FILE_TRUNCATED", where, "binary STL shorter than its 84-byte header");
  Mesh mesh;
  PolygonSink sink(mesh);
  if (binary)
    read_binary(data, size, where, mesh, sink);
  else
    read_ascii(data, size, where, mesh, sink);
  sink.finish(out);
  push_single_mesh_scene(std::move(mesh), where, out);
}

}  // namespace vgeo::detail
