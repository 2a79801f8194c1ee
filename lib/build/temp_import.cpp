// TEMPORARY reader, see temp_import.h.
#include "vgeo/build/temp_import.h"

#include <OpenMesh/Core/IO/MeshIO.hh>
#include <OpenMesh/Core/Mesh/PolyMesh_ArrayKernelT.hh>
#include <algorithm>
#include <cctype>
#include <fstream>
#include <sstream>

#include "vgeo/core/error.h"

namespace vgeo::build_detail {

namespace {

// OFF: "OFF" header (optionally followed by counts on the same line), then
// vertex_count face_count edge_count, vertices, faces "n i0 .. in-1" (fan-triangulated).
Mesh read_off(const std::string& path) {
  std::ifstream in(path);
  if (!in) fail("IMPORT_IO", path, "cannot open", kExitIo);
  std::stringstream ss;
  ss << in.rdbuf();
  std::string text = ss.str();
  // Strip comments.
  std::string clean;
  clean.reserve(text.size());
  bool comment = false;
  for (char c : text) {
    if (c == '#') comment = true;
    if (c == '\n') comment = false;
    if (!comment) clean.push_back(c);
  }
  std::istringstream s(clean);
  std::string header;
  s >> header;
  if (header.size() < 3 || header.substr(header.size() - 3) != "OFF") fail("IMPORT_BAD_FILE", path, "missing OFF header");
  // COFF/NOFF/CNOFF...: extra per-vertex values follow x y z on the vertex's line.
  if (header.find("4") != std::string::npos || header.find("n") != std::string::npos)
    fail("IMPORT_UNSUPPORTED", path, "OFF variant " + header + " is not supported");
  long long nv = -1, nf = -1, ne = -1;
  if (!(s >> nv >> nf >> ne) || nv < 0 || nf < 0) fail("IMPORT_BAD_FILE", path, "bad OFF counts");
  // Each vertex needs at least 6 bytes of text, each face 8: bounds allocation by file size.
  if (uint64_t(nv) * 6 > clean.size() || uint64_t(nf) * 8 > clean.size())
    fail("IMPORT_BAD_FILE", path, "OFF counts exceed the file size");
  Mesh m;
  m.name = path;
  m.positions.resize(3 * size_t(nv));
  std::string line;
  std::getline(s, line);  // rest of the counts line
  for (long long v = 0; v < nv;) {
    if (!std::getline(s, line)) fail("IMPORT_BAD_FILE", path, "truncated vertex list");
    std::istringstream ls(line);
    float x, y, z;
    if (!(ls >> x)) continue;  // blank line
    if (!(ls >> y >> z)) fail("IMPORT_BAD_FILE", path, "bad vertex line");
    m.positions[3 * size_t(v)] = x;
    m.positions[3 * size_t(v) + 1] = y;
    m.positions[3 * size_t(v) + 2] = z;
    ++v;
  }
  for (long long f = 0; f < nf; ++f) {
    long long n;
    if (!(s >> n) || n < 0 || n > 1000000) fail("IMPORT_BAD_FILE", path, "bad face");
    std::vector<uint32_t> poly(static_cast<size_t>(n));
    for (auto& i : poly) {
      long long x;
      if (!(s >> x) || x < 0 || x >= nv) fail("IMPORT_BAD_FILE", path, "face index out of range");
      i = uint32_t(x);
    }
    // Skip optional per-face colour values up to the end of the line.
    std::string rest;
    std::getline(s, rest);
    for (size_t k = 1; k + 1 < poly.size(); ++k) m.indices.insert(m.indices.end(), {poly[0], poly[k], poly[k + 1]});
  }
  return m;
}

Mesh read_openmesh(const std::string& path) {
  OpenMesh::PolyMesh_ArrayKernelT<> pm;
  OpenMesh::IO::Options opt;
  if (!OpenMesh::IO::read_mesh(pm, path, opt)) fail("IMPORT_BAD_FILE", path, "OpenMesh could not read the file");
  Mesh m;
  m.name = path;
  for (auto v : pm.vertices()) {
    auto p = pm.point(v);
    m.positions.insert(m.positions.end(), {p[0], p[1], p[2]});
  }
  for (auto f : pm.faces()) {
    std::vector<uint32_t> poly;
    for (auto v : pm.fv_range(f)) poly.push_back(uint32_t(v.idx()));
    for (size_t k = 1; k + 1 < poly.size(); ++k) m.indices.insert(m.indices.end(), {poly[0], poly[k], poly[k + 1]});
  }
  return m;
}

}  // namespace

Scene read_mesh_file_temporary(const std::string& path) {
  std::string ext = path.substr(path.find_last_of('.') == std::string::npos ? path.size() : path.find_last_of('.'));
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  Scene scene;
  if (ext == ".off") scene.meshes.push_back(read_off(path));
  else if (ext == ".obj" || ext == ".ply" || ext == ".stl") scene.meshes.push_back(read_openmesh(path));
  else fail("IMPORT_UNSUPPORTED", path, "unsupported extension '" + ext + "' (OFF, OBJ, PLY, STL)");
  scene.materials.push_back(Material{"default", {0.8f, 0.8f, 0.8f, 1.0f}});
  scene.instances.push_back(Instance{});
  return scene;
}

}  // namespace vgeo::build_detail
