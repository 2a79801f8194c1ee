// OBJ / PLY / OFF / STL via OpenMesh. OpenMesh reserves storage from header counts and
// drops faces it cannot use with only a log line, so this reader (1) checks header counts
// against the file size before OpenMesh allocates, and (2) captures OpenMesh's error log to
// turn "invalid vertex index" into INDEX_OUT_OF_RANGE instead of a silently smaller mesh.
#include <OpenMesh/Core/IO/MeshIO.hh>
#include <OpenMesh/Core/Mesh/PolyMesh_ArrayKernelT.hh>
#include <OpenMesh/Core/System/omstream.hh>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <mutex>
#include <sstream>

#include "vgeo/mesh/import.h"
#include "vgeo/mesh/validate.h"

namespace vgeo::detail {
namespace {

using PolyMesh = OpenMesh::PolyMesh_ArrayKernelT<>;

constexpr size_t kStlHeaderBytes = 84;    // 80-byte comment + uint32 triangle count
constexpr size_t kStlTriangleBytes = 50;  // normal + 3 corners (12 floats) + attribute word
constexpr size_t kHeaderProbeBytes = 4096;  // OFF/PLY headers are far shorter in practice

// OpenMesh logs to process-wide streams; the capture below swaps their targets, so imports
// through OpenMesh are serialized.
std::mutex& openmesh_log_mutex() {
  static std::mutex m;
  return m;
}

std::string read_prefix(const std::string& path, size_t n) {
  std::ifstream f(path, std::ios::binary);
  std::string s(n, '\0');
  f.read(s.data(), std::streamsize(n));
  s.resize(size_t(f.gcount()));
  return s;
}

// Element counts declared by an OFF header (after comments), or false if not ASCII-parsable
// (OpenMesh then reports the failure itself).
void check_off_header(const std::string& head, uint64_t file_size, const std::string& where) {
  std::istringstream in(head);
  std::string token;
  // Skip comment lines before the keyword.
  std::string line;
  while (std::getline(in, line)) {
    size_t p = line.find_first_not_of(" \t\r");
    if (p == std::string::npos || line[p] == '#') continue;
    break;
  }
  std::istringstream kw(line);
  kw >> token;
  if (token.find("OFF") == std::string::npos)
    fail("MESH_PARSE_ERROR", where, "OFF file does not start with an OFF keyword");
  if (token.find('n') != std::string::npos || token.find('4') != std::string::npos)
    fail("MESH_FORMAT_UNSUPPORTED", where, "OFF variant '" + token + "' (nOFF/4OFF) is not supported");
  std::string rest;
  std::getline(kw, rest);
  if (rest.find("BINARY") != std::string::npos) return;  // OpenMesh checks binary reads itself
  // Counts are on the rest of the keyword line or the next non-comment line.
  std::istringstream counts_line(rest);
  long long nv = -1, nf = -1;
  if (!(counts_line >> nv >> nf)) {
    while (std::getline(in, line)) {
      size_t p = line.find_first_not_of(" \t\r");
      if (p == std::string::npos || line[p] == '#') continue;
      std::istringstream cl(line);
      if (!(cl >> nv >> nf)) fail("MESH_PARSE_ERROR", where, "OFF header counts are not integers");
      break;
    }
  }
  if (nv < 0 || nf < 0) fail("MESH_PARSE_ERROR", where, "OFF header counts missing or negative");
  // Every vertex and face needs at least two bytes of text: a bound on OpenMesh's reserve().
  if (uint64_t(nv) > file_size / 2 || uint64_t(nf) > file_size / 2)
    fail("FILE_TRUNCATED", where, "OFF header declares " + std::to_string(nv) + " vertices and " +
                                      std::to_string(nf) + " faces, more than a " + std::to_string(file_size) +
                                      "-byte file can hold");
}

void check_ply_header(const std::string& head, uint64_t file_size, const std::string& where) {
  std::istringstream in(head);
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream ls(line);
    std::string word, name;
    long long n = -1;
    ls >> word;
    if (word == "end_header") return;
    if (word == "element") {
      if (!(ls >> name >> n) || n < 0) fail("MESH_PARSE_ERROR", where, "PLY element line is malformed: " + line);
      if (uint64_t(n) > file_size)
        fail("FILE_TRUNCATED", where, "PLY header declares " + std::to_string(n) + " " + name +
                                          " elements, more than a " + std::to_string(file_size) +
                                          "-byte file can hold");
    }
  }
}

void check_stl(const std::string& head, uint64_t file_size, const std::string& where) {
  // ASCII STL starts with "solid" and has no fixed size relation; binary has an exact one.
  const bool ascii_candidate = head.compare(0, 5, "solid") == 0;
  if (file_size < kStlHeaderBytes) {
    if (!ascii_candidate) fail("FILE_TRUNCATED", where, "binary STL shorter than its 84-byte header");
    return;
  }
  uint32_t count = 0;
  std::memcpy(&count, head.data() + 80, 4);
  const uint64_t expected = kStlHeaderBytes + uint64_t(count) * kStlTriangleBytes;
  if (ascii_candidate && expected != file_size) return;  // ASCII
  if (expected > file_size)
    fail("FILE_TRUNCATED", where, "binary STL declares " + std::to_string(count) + " triangles (" +
                                      std::to_string(expected) + " bytes) but has " + std::to_string(file_size));
  // OpenMesh merges STL corners by position; a NaN corner would be merged away silently,
  // so non-finite positions are found here, before it reads.
  std::ifstream f(where, std::ios::binary);
  f.seekg(std::streamoff(kStlHeaderBytes));
  char tri[kStlTriangleBytes];
  for (uint32_t t = 0; t < count && f.read(tri, kStlTriangleBytes); ++t) {
    for (int k = 3; k < 12; ++k) {  // floats 0..2 are the facet normal
      float x;
      std::memcpy(&x, tri + 4 * k, 4);
      if (!std::isfinite(x))
        fail("POSITION_NOT_FINITE", where, "STL triangle " + std::to_string(t) + " has a non-finite corner");
    }
  }
}

// ASCII OFF with comments: CGAL writes '#' comment blocks before the keyword and after
// values, which OpenMesh's OFF reader misparses. Strip every '#'-to-end-of-line and blank
// line; returns false for binary OFF (left to OpenMesh untouched).
bool strip_off_comments(const std::string& path, std::string& cleaned) {
  std::ifstream f(path, std::ios::binary);
  std::string line;
  cleaned.clear();
  bool first = true;
  while (std::getline(f, line)) {
    size_t hash = line.find('#');
    if (hash != std::string::npos) line.erase(hash);
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    if (first) {
      if (line.find("BINARY") != std::string::npos) return false;
      first = false;
    }
    cleaned += line;
    cleaned += '\n';
  }
  return true;
}

}  // namespace

void import_openmesh(const std::string& path, const std::string& extension, ImportResult& out) {
  std::error_code ec;
  const uint64_t file_size = std::filesystem::file_size(path, ec);
  if (ec) fail("FILE_READ_ERROR", path, "cannot stat file: " + ec.message(), kExitIo);
  if (file_size == 0) fail("MESH_EMPTY", path, "file is empty");
  const std::string head = read_prefix(path, kHeaderProbeBytes);
  if (extension == "off") check_off_header(head, file_size, path);
  if (extension == "ply") check_ply_header(head, file_size, path);
  if (extension == "stl") check_stl(head, file_size, path);

  PolyMesh pm;
  OpenMesh::IO::Options opt;
  // STL carries face normals only; asking OpenMesh for vertex normals there yields unset values.
  if (extension != "stl") {
    pm.request_vertex_normals();
    pm.request_vertex_texcoords2D();
    opt += OpenMesh::IO::Options::VertexNormal;
    opt += OpenMesh::IO::Options::VertexTexCoord;
  }
  std::string cleaned_off;
  const bool use_cleaned = extension == "off" && strip_off_comments(path, cleaned_off);
  std::ostringstream log;
  bool ok = false;
  {
    // OpenMesh's omerr/omlog/omout write to std::cerr/std::cout. Their connect()/disconnect()
    // API leaks a wrapper per call (OpenMesh 9), so the capture swaps the std streams'
    // buffers instead, restored by the guard even if OpenMesh throws.
    std::lock_guard<std::mutex> lock(openmesh_log_mutex());
    struct StreamSwap {
      std::ostream& stream;
      std::streambuf* saved;
      StreamSwap(std::ostream& s, std::streambuf* to) : stream(s), saved(s.rdbuf(to)) {}
      ~StreamSwap() {
        omerr().flush();
        omlog().flush();
        omout().flush();
        stream.rdbuf(saved);
      }
    };
    StreamSwap err_swap(std::cerr, log.rdbuf());
    StreamSwap out_swap(std::cout, log.rdbuf());
    try {
      if (use_cleaned) {
        std::istringstream in(cleaned_off);
        ok = OpenMesh::IO::read_mesh(pm, in, ".off", opt);
      } else {
        ok = OpenMesh::IO::read_mesh(pm, path, opt);
      }
    } catch (const std::bad_alloc&) {
      ok = false;
      log << "allocation failed while reading\n";
    }
    omerr().flush();
  }
  std::string log_text = log.str();
  auto first_log_line = [&]() {
    std::string s = log_text.substr(0, log_text.find('\n'));
    return s.empty() ? std::string("OpenMesh could not read the file") : s;
  };
  if (!ok) fail("MESH_PARSE_ERROR", path, first_log_line());
  if (log_text.find("invalid vertex index") != std::string::npos)
    fail("INDEX_OUT_OF_RANGE", path, "a face refers to a vertex index outside the vertex list");
  size_t equal_vertex_faces = 0;
  for (size_t p = log_text.find("Face has equal vertices"); p != std::string::npos;
       p = log_text.find("Face has equal vertices", p + 1))
    ++equal_vertex_faces;
  out.stats.degenerate_removed += equal_vertex_faces;
  if (equal_vertex_faces > 0)
    out.warnings.push_back({"FACE_REPEATED_VERTEX", std::to_string(equal_vertex_faces) +
                                                         " faces repeat a vertex; removed as degenerate"});

  Mesh mesh;
  mesh.name = std::filesystem::path(path).stem().string();
  const size_t nv = pm.n_vertices();
  if (nv > UINT32_MAX) fail("MESH_TOO_LARGE", path, "more than 2^32-1 vertices");
  mesh.positions.resize(nv * 3);
  const bool has_normals = pm.has_vertex_normals() && opt.check(OpenMesh::IO::Options::VertexNormal);
  const bool has_uvs = pm.has_vertex_texcoords2D() && opt.check(OpenMesh::IO::Options::VertexTexCoord);
  if (has_normals) mesh.normals.resize(nv * 3);
  if (has_uvs) mesh.uvs.resize(nv * 2);
  for (size_t v = 0; v < nv; ++v) {
    const PolyMesh::VertexHandle vh{int(v)};
    const auto& p = pm.point(vh);
    for (int k = 0; k < 3; ++k) mesh.positions[3 * v + k] = p[k];
    if (has_normals) {
      const auto& n = pm.normal(vh);
      for (int k = 0; k < 3; ++k) mesh.normals[3 * v + k] = n[k];
    }
    if (has_uvs) {
      const auto& t = pm.texcoord2D(vh);
      mesh.uvs[2 * v] = t[0];
      mesh.uvs[2 * v + 1] = t[1];
    }
  }
  // Polygons become fans (v0, vi, vi+1) in OpenMesh's stored (counter-clockwise) order.
  size_t tri_count = 0;
  for (const auto& fh : pm.faces()) tri_count += pm.valence(fh) >= 3 ? pm.valence(fh) - 2 : 0;
  mesh.indices.reserve(tri_count * 3);
  std::vector<uint32_t> ring;
  for (const auto& fh : pm.faces()) {
    ring.clear();
    for (const auto& vh : pm.fv_range(fh)) ring.push_back(uint32_t(vh.idx()));
    for (size_t i = 1; i + 1 < ring.size(); ++i) {
      mesh.indices.push_back(ring[0]);
      mesh.indices.push_back(ring[i]);
      mesh.indices.push_back(ring[i + 1]);
    }
  }
  out.scene.meshes.push_back(std::move(mesh));
  out.scene.materials.push_back(Material{"default", {0.8f, 0.8f, 0.8f, 1.0f}});
  out.scene.instances.push_back(Instance{});
}

}  // namespace vgeo::detail
