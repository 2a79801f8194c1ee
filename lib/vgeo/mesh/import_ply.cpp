// PLY reader: ascii, binary_little_endian, binary_big_endian (spec/errors.md §Import).
// Imported: vertex x y z, nx ny nz (all three), u v / s t / texture_u texture_v /
// texture_s texture_t; face vertex_indices or vertex_index lists. Every other element and
// property is read and skipped. Unknown header lines are skipped (Blender writes some).
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>

#include "vgeo/mesh/import_text.h"

namespace vgeo::detail {
namespace {

enum class Encoding { kAscii, kLittle, kBig };

enum class ScalarType : uint8_t { kInt8, kUint8, kInt16, kUint16, kInt32, kUint32, kFloat32, kFloat64 };

size_t scalar_bytes(ScalarType t) {
  switch (t) {
    case ScalarType::kInt8:
    case ScalarType::kUint8: return 1;
    case ScalarType::kInt16:
    case ScalarType::kUint16: return 2;
    case ScalarType::kInt32:
    case ScalarType::kUint32:
    case ScalarType::kFloat32: return 4;
    case ScalarType::kFloat64: return 8;
  }
  return 1;
}

bool scalar_type(std::string_view s, ScalarType& t) {
  struct Name {
    const char* a;
    const char* b;
    ScalarType t;
  };
  static const Name names[] = {{"char", "int8", ScalarType::kInt8},       {"uchar", "uint8", ScalarType::kUint8},
                               {"short", "int16", ScalarType::kInt16},    {"ushort", "uint16", ScalarType::kUint16},
                               {"int", "int32", ScalarType::kInt32},      {"uint", "uint32", ScalarType::kUint32},
                               {"float", "float32", ScalarType::kFloat32}, {"double", "float64", ScalarType::kFloat64}};
  for (const Name& n : names)
    if (s == n.a || s == n.b) {
      t = n.t;
      return true;
    }
  return false;
}

struct Property {
  std::string name;
  ScalarType type = ScalarType::kFloat32;
  bool is_list = false;
  ScalarType count_type = ScalarType::kUint8;
};

struct Element {
  std::string name;
  uint64_t count = 0;
  std::vector<Property> properties;
};

struct Header {
  Encoding encoding = Encoding::kAscii;
  std::vector<Element> elements;
  size_t body_offset = 0;
};

Header parse_header(const uint8_t* data, size_t size, const std::string& where) {
  TextCursor in(data, size);
  Header h;
  if (in.rest_of_line() != "ply") fail("MESH_PARSE_ERROR", where, "PLY file does not start with 'ply'");
  bool have_format = false;
  while (true) {
    if (in.at_end()) fail("FILE_TRUNCATED", where, "PLY header has no end_header line");
    const uint64_t line = in.line;
    const std::string_view word = in.token_on_line();
    if (word == "end_header") {
      in.rest_of_line();
      break;
    }
    if (word == "format") {
      const std::string_view f = in.token_on_line();
      if (f == "ascii")
        h.encoding = Encoding::kAscii;
      else if (f == "binary_little_endian")
        h.encoding = Encoding::kLittle;
      else if (f == "binary_big_endian")
        h.encoding = Encoding::kBig;
      else
        fail("MESH_PARSE_ERROR", at_line(where, line), "PLY format '" + std::string(f.substr(0, 32)) + "' is unknown");
      have_format = true;
    } else if (word == "element") {
      Element e;
      e.name = std::string(in.token_on_line());
      int64_t n = -1;
      if (e.name.empty() || !parse_int(in.token_on_line(), n) || n < 0)
        fail("MESH_PARSE_ERROR", at_line(where, line), "PLY element line is malformed");
      // Every element needs at least one byte (an ASCII value and its separator: two), so a
      // count above the file size cannot be real; this also bounds loops over property-less elements.
      if (uint64_t(n) > size)
        fail("FILE_TRUNCATED", where, "PLY header declares " + std::to_string(n) + " " + e.name +
                                          " elements, more than a " + std::to_string(size) + "-byte file can hold");
      e.count = uint64_t(n);
      h.elements.push_back(std::move(e));
    } else if (word == "property") {
      if (h.elements.empty()) fail("MESH_PARSE_ERROR", at_line(where, line), "PLY property before any element");
      Property p;
      std::string_view t = in.token_on_line();
      if (t == "list") {
        p.is_list = true;
        if (!scalar_type(in.token_on_line(), p.count_type) || p.count_type == ScalarType::kFloat32 ||
            p.count_type == ScalarType::kFloat64)
          fail("MESH_PARSE_ERROR", at_line(where, line), "PLY list count type is not an integer type");
        t = in.token_on_line();
      }
      if (!scalar_type(t, p.type)) fail("MESH_PARSE_ERROR", at_line(where, line), "PLY property type is unknown");
      p.name = std::string(in.token_on_line());
      if (p.name.empty()) fail("MESH_PARSE_ERROR", at_line(where, line), "PLY property has no name");
      h.elements.back().properties.push_back(std::move(p));
    }
    // "comment", "obj_info" and any other line: skipped.
    in.rest_of_line();
  }
  if (!have_format) fail("MESH_PARSE_ERROR", where, "PLY header has no format line");
  h.body_offset = size_t(in.p - reinterpret_cast<const char*>(data));
  return h;
}

// Reads values of the body in file order, ASCII or binary.
struct BodyReader {
  Encoding encoding;
  const uint8_t* p;
  const uint8_t* end;
  const std::string& where;
  TextCursor text;

  BodyReader(const Header& h, const uint8_t* data, size_t size, const std::string& w)
      : encoding(h.encoding), p(data + h.body_offset), end(data + size), where(w),
        text(data + h.body_offset, size - h.body_offset) {
    text.line = 1 + uint64_t(std::count(data, data + h.body_offset, uint8_t('\n')));  // errors name file lines
  }

  [[noreturn]] void truncated() const { fail("FILE_TRUNCATED", where, "PLY body ends before the elements its header declares"); }

  double binary_value(ScalarType t) {
    const size_t n = scalar_bytes(t);
    if (size_t(end - p) < n) truncated();
    uint8_t b[8];
    std::memcpy(b, p, n);
    p += n;
    const bool swap = (encoding == Encoding::kBig) == (std::endian::native == std::endian::little);
    if (swap)
      for (size_t i = 0; i < n / 2; ++i) std::swap(b[i], b[n - 1 - i]);
    switch (t) {
      case ScalarType::kInt8: return double(int8_t(b[0]));
      case ScalarType::kUint8: return double(b[0]);
      case ScalarType::kInt16: { int16_t v; std::memcpy(&v, b, 2); return v; }
      case ScalarType::kUint16: { uint16_t v; std::memcpy(&v, b, 2); return v; }
      case ScalarType::kInt32: { int32_t v; std::memcpy(&v, b, 4); return v; }
      case ScalarType::kUint32: { uint32_t v; std::memcpy(&v, b, 4); return v; }
      case ScalarType::kFloat32: { float v; std::memcpy(&v, b, 4); return v; }
      case ScalarType::kFloat64: { double v; std::memcpy(&v, b, 8); return v; }
    }
    return 0;
  }
  // Float properties are returned exactly (float -> double -> float round trips).
  double value(ScalarType t) {
    if (encoding != Encoding::kAscii) return binary_value(t);
    const std::string_view tok = text.token();
    if (tok.empty()) truncated();
    if (t == ScalarType::kFloat32) {
      float f = 0;
      if (!parse_float(tok, f)) bad_number(tok);
      return f;
    }
    double d = 0;
    if (t == ScalarType::kFloat64) {
      if (!parse_double(tok, d)) bad_number(tok);
      return d;
    }
    int64_t i = 0;
    if (!parse_int(tok, i)) bad_number(tok);
    return double(i);
  }
  [[noreturn]] void bad_number(std::string_view tok) const {
    fail("MESH_PARSE_ERROR", at_line(where, text.line), "PLY value '" + std::string(tok.substr(0, 32)) + "' is not a number of its property's type");
  }
  // Bytes left: a bound on how many values can still follow (each takes >= 1 byte).
  size_t remaining() const { return encoding == Encoding::kAscii ? text.remaining() : size_t(end - p); }
};

// Which vertex property feeds which attribute slot.
struct VertexLayout {
  int position[3] = {-1, -1, -1};
  int normal[3] = {-1, -1, -1};
  int uv[2] = {-1, -1};
  bool has_normals() const { return normal[0] >= 0 && normal[1] >= 0 && normal[2] >= 0; }
  bool has_uvs() const { return uv[0] >= 0 && uv[1] >= 0; }
};

VertexLayout vertex_layout(const Element& e, const std::string& where) {
  VertexLayout l;
  const std::pair<const char*, const char*> uv_names[] = {
      {"u", "v"}, {"s", "t"}, {"texture_u", "texture_v"}, {"texture_s", "texture_t"}};
  for (size_t i = 0; i < e.properties.size(); ++i) {
    const Property& p = e.properties[i];
    if (p.is_list) continue;
    const int k = int(i);
    if (p.name == "x") l.position[0] = k;
    if (p.name == "y") l.position[1] = k;
    if (p.name == "z") l.position[2] = k;
    if (p.name == "nx") l.normal[0] = k;
    if (p.name == "ny") l.normal[1] = k;
    if (p.name == "nz") l.normal[2] = k;
    for (const auto& [u, v] : uv_names) {
      if (p.name == u && l.uv[0] < 0) l.uv[0] = k;
      if (p.name == v && l.uv[1] < 0) l.uv[1] = k;
    }
  }
  if (l.position[0] < 0 || l.position[1] < 0 || l.position[2] < 0)
    fail("MESH_PARSE_ERROR", where, "PLY vertex element lacks an x, y or z property");
  return l;
}

// Fewest body bytes one element can take: a bound for its count before reserving.
uint64_t min_element_bytes(const Element& e, Encoding enc) {
  uint64_t n = 0;
  for (const Property& p : e.properties) n += enc == Encoding::kAscii ? 2 : scalar_bytes(p.is_list ? p.count_type : p.type);
  return n;
}

void check_count(const Element& e, const BodyReader& body, Encoding enc, const std::string& where) {
  const uint64_t each = min_element_bytes(e, enc);
  if (each > 0 && e.count > body.remaining() / each)
    fail("FILE_TRUNCATED", where, "PLY header declares " + std::to_string(e.count) + " " + e.name + " elements, more than the " +
                                      std::to_string(body.remaining()) + " bytes after the header can hold");
}

// A list's length, checked against the bytes left (every item takes at least one).
uint64_t list_length(BodyReader& body, const Property& p) {
  const double n = body.value(p.count_type);
  if (n < 0) fail("MESH_PARSE_ERROR", body.where, "PLY list has a negative length");
  if (n > double(body.remaining())) body.truncated();
  return uint64_t(n);
}

}  // namespace

void import_ply(const uint8_t* data, size_t size, const std::string& where, ImportResult& out) {
  if (size == 0) fail("MESH_EMPTY", where, "file is empty");
  const Header h = parse_header(data, size, where);
  BodyReader body(h, data, size, where);
  Mesh mesh;
  PolygonSink sink(mesh);
  bool have_vertices = false;
  uint64_t vertex_count = 0;
  std::vector<double> values;
  std::vector<uint32_t> ring;
  for (const Element& e : h.elements) {
    check_count(e, body, h.encoding, where);
    if (e.name == "vertex" && !have_vertices) {
      have_vertices = true;
      vertex_count = e.count;
      const VertexLayout l = vertex_layout(e, where);
      mesh.positions.reserve(e.count * 3);
      if (l.has_normals()) mesh.normals.reserve(e.count * 3);
      if (l.has_uvs()) mesh.uvs.reserve(e.count * 2);
      values.resize(e.properties.size());
      for (uint64_t v = 0; v < e.count; ++v) {
        for (size_t i = 0; i < e.properties.size(); ++i) {
          const Property& p = e.properties[i];
          if (!p.is_list) {
            values[i] = body.value(p.type);
            continue;
          }
          for (uint64_t n = list_length(body, p); n > 0; --n) body.value(p.type);
        }
        for (int k : l.position) mesh.positions.push_back(float(values[size_t(k)]));
        if (l.has_normals())
          for (int k : l.normal) mesh.normals.push_back(float(values[size_t(k)]));
        if (l.has_uvs())
          for (int k : l.uv) mesh.uvs.push_back(float(values[size_t(k)]));
      }
      continue;
    }
    if (e.name == "face") {
      int indices = -1;
      for (size_t i = 0; i < e.properties.size(); ++i)
        if (e.properties[i].is_list && (e.properties[i].name == "vertex_indices" || e.properties[i].name == "vertex_index")) {
          indices = int(i);
          break;
        }
      if (indices < 0) fail("MESH_PARSE_ERROR", where, "PLY face element has no vertex_indices list");
      if (!have_vertices) fail("MESH_PARSE_ERROR", where, "PLY face element comes before the vertex element");
      for (uint64_t f = 0; f < e.count; ++f) {
        for (size_t i = 0; i < e.properties.size(); ++i) {
          const Property& p = e.properties[i];
          if (!p.is_list) {
            body.value(p.type);
            continue;
          }
          const uint64_t n = list_length(body, p);
          if (int(i) != indices) {
            for (uint64_t c = 0; c < n; ++c) body.value(p.type);
            continue;
          }
          ring.clear();
          for (uint64_t c = 0; c < n; ++c) {
            const double idx = body.value(p.type);
            if (!(idx >= 0 && idx < double(vertex_count)))
              fail("INDEX_OUT_OF_RANGE", where,
                   "PLY face " + std::to_string(f) + " refers to a vertex outside the " + std::to_string(vertex_count) + " vertices");
            ring.push_back(uint32_t(idx));
          }
        }
        sink.add(ring.data(), ring.size());
      }
      continue;
    }
    // Any other element (edges, materials, a second vertex element): read and dropped.
    for (uint64_t r = 0; r < e.count; ++r)
      for (const Property& p : e.properties) {
        if (!p.is_list) {
          body.value(p.type);
          continue;
        }
        for (uint64_t n = list_length(body, p); n > 0; --n) body.value(p.type);
      }
  }
  sink.finish(out);
  push_single_mesh_scene(std::move(mesh), where, out);
}

}  // namespace vgeo::detail
