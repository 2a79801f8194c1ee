// Wavefront OBJ reader (spec/errors.md §Import). Reads v, vt, vn and f; every other statement
// (o, g, s, usemtl, mtllib, l, p, ...) is skipped. A face corner is v, v/vt, v//vn or v/vt/vn
// with 1-based or negative (relative) indices; a backslash at the end of a line continues it.
// A corner repeating an earlier corner's v within one face is dropped (exporters close rings
// that way). One vgeo vertex per distinct (v, vt, vn) corner, in order of first use, so UV and normal
// seams survive. Corners without vt (vn) in a mesh where others have one get uv (0,0) (the
// polygon's normal) and warning ATTRIBUTE_FILLED; a file whose faces never use vt has no uvs
// however many vt lines it holds.
#include <algorithm>
#include <array>
#include <cmath>

#include "vgeo/mesh/import_text.h"

namespace vgeo::detail {
namespace {

constexpr int64_t kNone = -1;
constexpr uint32_t kNoTriangle = UINT32_MAX;

struct Corner {
  int64_t v = kNone, vt = kNone, vn = kNone;  // 0-based, kNone when absent
  bool operator==(const Corner& o) const { return v == o.v && vt == o.vt && vn == o.vn; }
};
// Output vertex of each distinct corner, found through the corner's position index: a chain of
// the vertices with that v (usually one). Faces use nearby v's, so lookups stay in cache (a
// node-based hash map cost half of a 1M-triangle import, a flat hash a random access each).
struct CornerTable {
  static constexpr uint32_t kEmpty = UINT32_MAX;
  std::vector<uint32_t> first;  // per v: the first vertex whose corner has it
  std::vector<uint32_t> next;   // per vertex: the next vertex with the same v
  // The vertex of `c` (c.v < position_count), adding it to `corners` if new; second = inserted.
  std::pair<uint32_t, bool> find_or_add(const Corner& c, size_t position_count, std::vector<Corner>& corners) {
    if (first.size() < position_count) first.resize(position_count, kEmpty);
    uint32_t* link = &first[size_t(c.v)];
    for (; *link != kEmpty; link = &next[*link])
      if (corners[*link] == c) return {*link, false};
    const uint32_t vertex = uint32_t(corners.size());
    *link = vertex;  // before next grows: `link` may point into it
    corners.push_back(c);
    next.push_back(kEmpty);
    return {vertex, true};
  }
};

struct ObjState {
  std::vector<float> v, vt, vn;  // 3, 2, 3 floats per entry
  std::vector<Corner> corners;   // per output vertex
  CornerTable vertex_of;
  bool any_vt = false, any_vn = false, missing_vt = false, missing_vn = false;
};

// Resolves a 1-based or negative OBJ index against `count` entries defined so far.
int64_t resolve(std::string_view t, size_t count, const char* kind, const std::string& where, uint64_t line) {
  int64_t i = 0;
  if (!parse_int(t, i))
    fail("MESH_PARSE_ERROR", at_line(where, line), std::string("OBJ ") + kind + " index '" + std::string(t.substr(0, 32)) + "' is not an integer");
  const int64_t n = int64_t(count);
  const int64_t r = i > 0 ? i - 1 : n + i;
  if (i == 0 || r < 0 || r >= n)
    fail("INDEX_OUT_OF_RANGE", at_line(where, line),
         std::string("OBJ face refers to ") + kind + " " + std::to_string(i) + " of " + std::to_string(n) + " defined so far");
  return r;
}

Corner parse_corner(std::string_view t, const ObjState& s, const std::string& where, uint64_t line) {
  Corner c;
  const size_t a = t.find('/');
  c.v = resolve(t.substr(0, a), s.v.size() / 3, "vertex", where, line);
  if (a == std::string_view::npos) return c;
  std::string_view rest = t.substr(a + 1);
  const size_t b = rest.find('/');
  const std::string_view vt = rest.substr(0, b);
  if (!vt.empty()) c.vt = resolve(vt, s.vt.size() / 2, "texture coordinate", where, line);
  if (b != std::string_view::npos) {
    const std::string_view vn = rest.substr(b + 1);
    if (!vn.empty()) c.vn = resolve(vn, s.vn.size() / 3, "normal", where, line);
  }
  return c;
}

// Reads `n` numbers of a v/vt/vn statement into `dst` (missing optional ones as 0; extra
// values, such as vertex colours or a w, are ignored).
void read_numbers(TextCursor& in, size_t required, size_t n, std::vector<float>& dst, const std::string& where,
                  const char* what) {
  const uint64_t line = in.line;
  for (size_t k = 0; k < n; ++k) {
    const std::string_view t = in.token_on_line();
    float x = 0;
    if (t.empty() && k >= required) {
      dst.push_back(0.0f);
      continue;
    }
    if (!parse_float(t, x))
      fail("MESH_PARSE_ERROR", at_line(where, line),
           std::string("OBJ ") + what + " value '" + std::string(t.substr(0, 32)) + "' is not a number");
    dst.push_back(x);
  }
}

// OBJ exporters close polygons by repeating their first corner (assimp's concave_polygon.obj)
// or repeat whole rings; the OpenMesh reader this replaces kept the first corner of each
// position index and so does this one. Long polygons are sorted, not compared pairwise.
void drop_repeated_positions(std::vector<Corner>& polygon, std::vector<std::pair<int64_t, size_t>>& order) {
  if (polygon.size() <= kPairwiseRepeatTestMax) {
    // Pairwise (no sort) for the common short polygon: a corner repeating an earlier v is
    // dropped, as below (a dropped corner's v is kNone, which no resolved v equals).
    bool repeats = false;
    for (size_t i = 1; i < polygon.size(); ++i)
      for (size_t j = 0; j < i; ++j)
        if (polygon[j].v == polygon[i].v) {
          polygon[i].v = kNone;
          repeats = true;
          break;
        }
    if (repeats)
      polygon.erase(std::remove_if(polygon.begin(), polygon.end(), [](const Corner& c) { return c.v == kNone; }),
                    polygon.end());
    return;
  }
  order.clear();
  for (size_t i = 0; i < polygon.size(); ++i) order.push_back({polygon[i].v, i});
  std::sort(order.begin(), order.end());  // by v, then by position in the polygon
  bool repeats = false;
  for (size_t i = 1; i < order.size(); ++i)
    if (order[i].first == order[i - 1].first) {
      polygon[order[i].second].v = kNone;  // a later corner of the same v: dropped below
      repeats = true;
    }
  if (!repeats) return;
  polygon.erase(std::remove_if(polygon.begin(), polygon.end(), [](const Corner& c) { return c.v == kNone; }), polygon.end());
}

// Joins continuation lines ("...\\\n") into one logical line; the text lives in `joined`.
std::string_view logical_line(TextCursor& in, std::string& joined) {
  std::string_view l = in.rest_of_line();
  if (l.empty() || l.back() != '\\') return l;
  joined.assign(l.substr(0, l.size() - 1));
  while (!in.at_end()) {
    l = in.rest_of_line();
    joined += ' ';
    if (l.empty() || l.back() != '\\') {
      joined += l;
      break;
    }
    joined.append(l.substr(0, l.size() - 1));
  }
  return joined;
}

}  // namespace

void import_obj(const uint8_t* data, size_t size, const std::string& where, ImportResult& out) {
  if (size == 0) fail("MESH_EMPTY", where, "file is empty");
  TextCursor file(data, size);
  ObjState s;
  Mesh mesh;
  PolygonSink sink(mesh);
  std::vector<uint32_t> ring;
  std::vector<Corner> polygon;
  std::vector<std::pair<int64_t, size_t>> seen;
  // (vertex, first index of the first triangle it was added with; kNoTriangle if its polygon was dropped)
  std::vector<std::pair<uint32_t, uint32_t>> filled_normals;
  std::string joined;
  while (!file.at_end()) {
    const uint64_t line = file.line;
    const std::string_view text = logical_line(file, joined);
    TextCursor in(reinterpret_cast<const uint8_t*>(text.data()), text.size());
    in.line = line;
    const std::string_view kw = in.token_on_line();
    if (kw == "v") {
      read_numbers(in, 3, 3, s.v, where, "vertex");
    } else if (kw == "vt") {
      read_numbers(in, 1, 2, s.vt, where, "texture coordinate");
    } else if (kw == "vn") {
      read_numbers(in, 3, 3, s.vn, where, "normal");
    } else if (kw == "f") {
      polygon.clear();
      for (std::string_view t = in.token_on_line(); !t.empty(); t = in.token_on_line())
        polygon.push_back(parse_corner(t, s, where, line));
      drop_repeated_positions(polygon, seen);
      ring.clear();
      const size_t filled_before = filled_normals.size();
      const size_t indices_before = mesh.indices.size();
      for (const Corner& c : polygon) {
        const auto [vertex, inserted] = s.vertex_of.find_or_add(c, s.v.size() / 3, s.corners);
        if (inserted) {
          if (c.vt == kNone) s.missing_vt = true; else s.any_vt = true;
          if (c.vn == kNone) {
            s.missing_vn = true;
            filled_normals.push_back({vertex, uint32_t(mesh.indices.size())});
          } else {
            s.any_vn = true;
          }
        }
        ring.push_back(vertex);
      }
      sink.add(ring.data(), ring.size());
      if (mesh.indices.size() == indices_before)
        for (size_t i = filled_before; i < filled_normals.size(); ++i) filled_normals[i].second = kNoTriangle;
    }
  }
  // Per-vertex arrays from the corners.
  const size_t nv = s.corners.size();
  mesh.positions.resize(nv * 3);
  for (size_t i = 0; i < nv; ++i)
    for (int k = 0; k < 3; ++k) mesh.positions[3 * i + size_t(k)] = s.v[3 * size_t(s.corners[i].v) + size_t(k)];
  if (s.any_vt) {
    mesh.uvs.assign(nv * 2, 0.0f);
    for (size_t i = 0; i < nv; ++i)
      if (s.corners[i].vt != kNone)
        for (int k = 0; k < 2; ++k) mesh.uvs[2 * i + size_t(k)] = s.vt[2 * size_t(s.corners[i].vt) + size_t(k)];
  }
  if (s.any_vn) {
    mesh.normals.assign(nv * 3, 0.0f);
    for (size_t i = 0; i < nv; ++i)
      if (s.corners[i].vn != kNone)
        for (int k = 0; k < 3; ++k) mesh.normals[3 * i + size_t(k)] = s.vn[3 * size_t(s.corners[i].vn) + size_t(k)];
    // A corner without vn gets the unit normal of the first triangle it was added with
    // ((0,0,1) when that triangle has no area or the polygon was dropped).
    for (const auto& [vertex, tri] : filled_normals) {
      std::array<double, 3> n{0, 0, 1};
      if (tri != kNoTriangle) {
        const Vec3 a = mesh.position(mesh.indices[tri]), b = mesh.position(mesh.indices[tri + 1]),
                   c = mesh.position(mesh.indices[tri + 2]);
        const double e1[3] = {double(b.x) - a.x, double(b.y) - a.y, double(b.z) - a.z};
        const double e2[3] = {double(c.x) - a.x, double(c.y) - a.y, double(c.z) - a.z};
        const double cx = e1[1] * e2[2] - e1[2] * e2[1], cy = e1[2] * e2[0] - e1[0] * e2[2], cz = e1[0] * e2[1] - e1[1] * e2[0];
        const double len = std::sqrt(cx * cx + cy * cy + cz * cz);
        if (len > 0 && std::isfinite(len)) n = {cx / len, cy / len, cz / len};
      }
      for (int k = 0; k < 3; ++k) mesh.normals[3 * vertex + size_t(k)] = float(n[size_t(k)]);
    }
  }
  if ((s.any_vt && s.missing_vt) || (s.any_vn && s.missing_vn))
    out.warnings.push_back({"ATTRIBUTE_FILLED", std::string("face corners without ") +
                                                    (s.any_vt && s.missing_vt ? "vt got uv (0,0)" : "") +
                                                    (s.any_vt && s.missing_vt && s.any_vn && s.missing_vn ? "; without " : "") +
                                                    (s.any_vn && s.missing_vn ? "vn got their polygon's normal" : "")});
  sink.finish(out);
  push_single_mesh_scene(std::move(mesh), where, out);
}

}  // namespace vgeo::detail
