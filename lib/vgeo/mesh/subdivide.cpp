// Loop subdivision through OpenMesh, with our own manifold pre-check (OpenMesh's add_face
// reports complex edges/vertices only on stderr and silently drops the face) and our own
// attribute carrying (LoopT moves positions only).
// Based on: Loop, "Smooth Subdivision Surfaces Based on Triangles", MS thesis, University of
// Utah, 1987 (OpenMesh's LoopT).
#include "vgeo/mesh/subdivide.h"

#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>
#include <OpenMesh/Tools/Subdivider/Uniform/LoopT.hh>

#include <algorithm>
#include <utility>
#include <vector>

#include "vgeo/mesh/generate.h"
#include "vgeo/mesh/openmesh_streams.h"

namespace vgeo {
namespace {

using OmMesh = OpenMesh::TriMesh_ArrayKernelT<>;

// Corners incident to each vertex (compressed rows): corner c = 3 * triangle + k.
struct VertexCorners {
  std::vector<uint32_t> first;  // size nv + 1
  std::vector<uint32_t> corners;
};

VertexCorners build_vertex_corners(const Mesh& m) {
  VertexCorners vc;
  const size_t nv = m.vertex_count();
  vc.first.assign(nv + 1, 0);
  for (uint32_t i : m.indices) ++vc.first[i + 1];
  for (size_t v = 0; v < nv; ++v) vc.first[v + 1] += vc.first[v];
  vc.corners.resize(m.indices.size());
  std::vector<uint32_t> fill(vc.first.begin(), vc.first.end() - 1);
  for (size_t c = 0; c < m.indices.size(); ++c) vc.corners[fill[m.indices[c]]++] = uint32_t(c);
  return vc;
}

// Faces around vertex v, as link edges b->c of triangles (v,b,c): v is manifold iff all
// b are distinct (each directed edge v->b used once), all c are distinct, and the link
// edges form exactly one path (border vertex) or one cycle (interior vertex).
bool vertex_is_manifold(const Mesh& m, const VertexCorners& vc, uint32_t v,
                        std::vector<std::pair<uint32_t, uint32_t>>& link) {
  link.clear();
  for (uint32_t k = vc.first[v]; k < vc.first[v + 1]; ++k) {
    uint32_t c = vc.corners[k], t = c / 3, j = c % 3;
    link.emplace_back(m.indices[3 * t + (j + 1) % 3], m.indices[3 * t + (j + 2) % 3]);
  }
  if (link.empty()) return true;
  std::sort(link.begin(), link.end());
  for (size_t i = 1; i < link.size(); ++i)
    if (link[i].first == link[i - 1].first) return false;  // directed edge v->b twice
  std::vector<uint32_t> ends;
  ends.reserve(link.size());
  for (auto& e : link) ends.push_back(e.second);
  std::sort(ends.begin(), ends.end());
  if (std::adjacent_find(ends.begin(), ends.end()) != ends.end()) return false;  // b->v twice
  // Start of the single path: a link vertex that is a start but never an end; none for
  // a cycle (then start anywhere). Walk and require that every link edge is visited.
  uint32_t start = link[0].first;
  size_t path_starts = 0;
  for (auto& e : link)
    if (!std::binary_search(ends.begin(), ends.end(), e.first)) start = e.first, ++path_starts;
  if (path_starts > 1) return false;
  size_t steps = 0;
  uint32_t at = start;
  for (;;) {
    auto it = std::lower_bound(link.begin(), link.end(), std::make_pair(at, uint32_t(0)));
    if (it == link.end() || it->first != at) break;
    at = it->second;
    if (++steps > link.size()) break;
    if (at == start) break;
  }
  return steps == link.size();
}

}  // namespace

void check_loop_input(const Mesh& m, const std::string& where) {
  const size_t nv = m.vertex_count();
  if (m.triangle_count() == 0) fail("SUBDIVIDE_EMPTY", where, "mesh '" + m.name + "' has no triangles");
  for (size_t t = 0; t < m.triangle_count(); ++t) {
    const uint32_t* v = &m.indices[3 * t];
    for (int k = 0; k < 3; ++k)
      if (v[k] >= nv)
        fail("SUBDIVIDE_INDEX_OUT_OF_RANGE", where,
             "triangle " + std::to_string(t) + " uses vertex " + std::to_string(v[k]) + " >= " + std::to_string(nv));
    if (v[0] == v[1] || v[1] == v[2] || v[0] == v[2])
      fail("SUBDIVIDE_DEGENERATE_TRIANGLE", where, "triangle " + std::to_string(t) + " repeats a vertex");
  }
  const VertexCorners vc = build_vertex_corners(m);
  std::vector<std::pair<uint32_t, uint32_t>> link;
  for (uint32_t v = 0; v < nv; ++v)
    if (!vertex_is_manifold(m, vc, v, link))
      fail("SUBDIVIDE_NON_MANIFOLD", where,
           "vertex " + std::to_string(v) +
               ": an edge is shared by more than two triangles, oriented inconsistently, or the vertex joins "
               "several fans (Loop subdivision needs a 2-manifold)");
}

Mesh subdivide_loop(const Mesh& mesh, const SubdivideOptions& options) {
  check_loop_input(mesh);
  uint64_t out_triangles = mesh.triangle_count();
  for (uint32_t i = 0; i < options.iterations; ++i) {
    out_triangles *= 4;
    if (out_triangles > options.max_triangles)
      fail("SUBDIVIDE_TOO_LARGE", "subdivide",
           std::to_string(options.iterations) + " iterations of " + std::to_string(mesh.triangle_count()) +
               " triangles exceed the limit of " + std::to_string(options.max_triangles),
           kExitUsage);
  }

  silence_openmesh_streams();  // a face the pre-check missed is refused with a code, not chatter
  // Referenced vertices only: LoopT would move an isolated vertex to the origin.
  std::vector<uint32_t> remap(mesh.vertex_count(), UINT32_MAX);
  OmMesh om;
  std::vector<float> uvs;
  const bool has_uv = !mesh.uvs.empty();
  for (uint32_t i : mesh.indices)
    if (remap[i] == UINT32_MAX) remap[i] = 0;
  uint32_t next = 0;
  for (size_t v = 0; v < remap.size(); ++v) {
    if (remap[v] == UINT32_MAX) continue;
    remap[v] = next++;
    Vec3 p = mesh.position(v);
    om.add_vertex(OmMesh::Point(p.x, p.y, p.z));
    if (has_uv) uvs.insert(uvs.end(), {mesh.uvs[2 * v], mesh.uvs[2 * v + 1]});
  }
  std::vector<uint32_t> materials(mesh.triangle_count());
  for (size_t t = 0; t < mesh.triangle_count(); ++t) {
    const uint32_t* v = &mesh.indices[3 * t];
    OmMesh::FaceHandle fh = om.add_face(OmMesh::VertexHandle(int(remap[v[0]])), OmMesh::VertexHandle(int(remap[v[1]])),
                                        OmMesh::VertexHandle(int(remap[v[2]])));
    if (!fh.is_valid() || size_t(fh.idx()) != t)
      fail("SUBDIVIDE_NON_MANIFOLD", "subdivide", "OpenMesh rejected triangle " + std::to_string(t));
    materials[t] = mesh.material(t);
  }

  size_t max_valence = 0;
  for (auto vh : om.vertices()) max_valence = std::max<size_t>(max_valence, om.valence(vh));
  OpenMesh::Subdivider::Uniform::LoopT<OmMesh> loop;
  loop.attach(om);
  // LoopT precomputes weights for valence < 50 and indexes them unchecked; valences never
  // grow under Loop (old vertices keep theirs, new ones have 4 or 6), so size once.
  loop.init_weights(std::max<size_t>(50, max_valence + 1));

  for (uint32_t it = 0; it < options.iterations; ++it) {
    const size_t nv_old = om.n_vertices(), nf_old = om.n_faces();
    std::vector<uint32_t> old_faces(3 * nf_old);
    for (auto fh : om.faces()) {
      int k = 0;
      for (auto vh : om.fv_range(fh)) old_faces[3 * size_t(fh.idx()) + k++] = uint32_t(vh.idx());
    }
    loop(1);
    if (om.n_faces() != 4 * nf_old)
      fail("SUBDIVIDE_INTERNAL", "subdivide", "Loop step did not quadruple the faces", kExitInternal);
    // Edge vertices: the two old vertices among the new vertex's neighbours are its edge.
    if (has_uv) {
      uvs.resize(2 * om.n_vertices());
      for (size_t v = nv_old; v < om.n_vertices(); ++v) {
        uint32_t ends[2], found = 0;
        for (auto nb : om.vv_range(OmMesh::VertexHandle(int(v))))
          if (size_t(nb.idx()) < nv_old && found < 3) {
            if (found < 2) ends[found] = uint32_t(nb.idx());
            ++found;
          }
        if (found != 2) fail("SUBDIVIDE_INTERNAL", "subdivide", "edge vertex without two old neighbours", kExitInternal);
        for (int k = 0; k < 2; ++k) uvs[2 * v + k] = 0.5f * (uvs[2 * ends[0] + k] + uvs[2 * ends[1] + k]);
      }
    }
    // LoopT keeps each old face as the centre triangle and appends its three corner
    // triangles in face order; verify that via the corner's one old vertex.
    materials.resize(om.n_faces());
    for (size_t f = nf_old; f < om.n_faces(); ++f) {
      size_t parent = (f - nf_old) / 3;
      bool ok = false;
      for (auto vh : om.fv_range(OmMesh::FaceHandle(int(f))))
        if (size_t(vh.idx()) < nv_old)
          ok = old_faces[3 * parent] == uint32_t(vh.idx()) || old_faces[3 * parent + 1] == uint32_t(vh.idx()) ||
               old_faces[3 * parent + 2] == uint32_t(vh.idx());
      if (!ok) fail("SUBDIVIDE_INTERNAL", "subdivide", "unexpected LoopT face order", kExitInternal);
      materials[f] = materials[parent];
    }
  }
  loop.detach();

  Mesh out;
  out.name = mesh.name;
  out.positions.reserve(3 * om.n_vertices());
  for (auto vh : om.vertices()) {
    const auto& p = om.point(vh);
    out.positions.insert(out.positions.end(), {p[0], p[1], p[2]});
  }
  out.indices.reserve(3 * om.n_faces());
  for (auto fh : om.faces())
    for (auto vh : om.fv_range(fh)) out.indices.push_back(uint32_t(vh.idx()));
  if (has_uv) out.uvs = std::move(uvs);
  if (!mesh.materials.empty()) out.materials = std::move(materials);
  compute_smooth_normals(out);
  return out;
}

}  // namespace vgeo
