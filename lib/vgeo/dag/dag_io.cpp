// VGEODAG1: uncompressed little-endian serialization of a BuiltScene (spec/dag.md §7).
// The decoder is hardened for files from other implementations: every count is checked
// against the remaining bytes before anything is allocated, every index is range-checked,
// padding is not stored (so valid data has exactly one encoding), trailing bytes are an error.
#include "vgeo/dag/dag_io.h"

#include <algorithm>
#include <cstring>

#include "vgeo/core/byte_io.h"
#include "vgeo/core/error.h"
#include "vgeo/core/file_io.h"

namespace vgeo {

namespace {

constexpr uint32_t kVersion = 1;
constexpr uint32_t kMeshHasNormals = 1u << 0;
constexpr uint32_t kMeshHasUvs = 1u << 1;
// Encoded sizes (bytes) of the fixed records; pads are not stored.
constexpr size_t kSphereBytes = 16;
constexpr size_t kClusterBytes = 8 * 4 + 3 * kSphereBytes + 2 * 4;
constexpr size_t kGroupBytes = 6 * 4 + 2 * kSphereBytes + 4;
constexpr size_t kBvhNodeBytes = 2 * kSphereBytes + 4 + 4 + 4 + kBvhMaxChildren * 4;
constexpr size_t kDagMeshHeaderBytes = 4 + 4 + 6 * 4 + 6 * 4;
constexpr size_t kDagMaterialMinBytes = 4 + 4 * 4;
constexpr size_t kDagInstanceBytes = 4 + 16 * 4;

// The decoder's reader: truncation is DAGFILE_TRUNCATED ("file ends inside ...").
ByteReader file_reader(const uint8_t* data, size_t size, const std::string& where) {
  return ByteReader(data, size, where, "DAGFILE_TRUNCATED", "file");
}
[[noreturn]] void out_of_range(const std::string& where, const std::string& what) {
  fail("DAGFILE_INDEX_OUT_OF_RANGE", where, what);
}

void encode_mesh(ByteWriter& w, const ClusterDag& d) {
  size_t vcount = d.vertex_count(), tcount = d.triangle_count();
  bool normals = !d.normals.empty(), uvs = !d.uvs.empty();
  w.u32((normals ? kMeshHasNormals : 0) | (uvs ? kMeshHasUvs : 0));
  w.u32(d.level_count);
  for (int k = 0; k < 3; ++k) w.f32(d.bounds.min[k]);
  for (int k = 0; k < 3; ++k) w.f32(d.bounds.max[k]);
  w.u32(uint32_t(d.clusters.size()));
  w.u32(uint32_t(d.groups.size()));
  w.u32(uint32_t(d.generated_clusters.size()));
  w.u32(uint32_t(d.bvh_nodes.size()));
  w.u32(uint32_t(vcount));
  w.u32(uint32_t(tcount));
  for (const DagCluster& c : d.clusters) {
    for (uint32_t v : {c.vertex_offset, c.vertex_count, c.triangle_offset, c.triangle_count, c.group,
                       c.generating_group, c.level, c.material_offset})
      w.u32(v);
    w.sphere(c.bounds);
    w.sphere(c.lod_bounds);
    w.sphere(c.parent_bounds);
    w.f32(c.lod_error);
    w.f32(c.parent_error);
    w.maybe_flush();
  }
  for (const DagGroup& g : d.groups) {
    for (uint32_t v : {g.first_cluster, g.cluster_count, g.first_generated, g.generated_count, g.level, g.flags})
      w.u32(v);
    w.sphere(g.bounds);
    w.sphere(g.parent_bounds);
    w.f32(g.parent_error);
    w.maybe_flush();
  }
  w.array32(d.generated_clusters.data(), d.generated_clusters.size());
  for (const BvhNode& n : d.bvh_nodes) {
    w.sphere(n.bounds);
    w.sphere(n.lod_bounds);
    w.f32(n.max_parent_error);
    w.u32(n.child_count);
    w.u32(n.group_mask);
    for (uint32_t c : n.children) w.u32(c);
    w.maybe_flush();
  }
  w.array32(d.positions.data(), 3 * vcount);
  if (normals) w.array32(d.normals.data(), 3 * vcount);
  if (uvs) w.array32(d.uvs.data(), 2 * vcount);
  w.raw(d.indices.data(), 3 * tcount);
  w.array32(d.triangle_materials.data(), tcount);
}

ClusterDag decode_mesh(ByteReader& r, const std::string& where, uint32_t material_count) {
  ClusterDag d;
  uint32_t flags = r.u32();
  if (flags & ~(kMeshHasNormals | kMeshHasUvs))
    fail("DAGFILE_BAD_VALUE", where, "unknown mesh flags " + std::to_string(flags));
  d.level_count = r.u32();
  for (int k = 0; k < 3; ++k) d.bounds.min[k] = r.f32();
  for (int k = 0; k < 3; ++k) d.bounds.max[k] = r.f32();
  uint32_t clusters = r.u32(), groups = r.u32(), generated = r.u32(), nodes = r.u32(), vertices = r.u32(),
           triangles = r.u32();
  // Everything that follows has a known size: check it all before allocating.
  uint64_t per_vertex = 12 + ((flags & kMeshHasNormals) ? 12 : 0) + ((flags & kMeshHasUvs) ? 8 : 0);
  uint64_t need = uint64_t(clusters) * kClusterBytes + uint64_t(groups) * kGroupBytes + uint64_t(generated) * 4 +
                  uint64_t(nodes) * kBvhNodeBytes + uint64_t(vertices) * per_vertex + uint64_t(triangles) * 7;
  r.need(need, "the mesh arrays");

  d.clusters.resize(clusters);
  for (DagCluster& c : d.clusters) {
    c.vertex_offset = r.u32();
    c.vertex_count = r.u32();
    c.triangle_offset = r.u32();
    c.triangle_count = r.u32();
    c.group = r.u32();
    c.generating_group = r.u32();
    c.level = r.u32();
    c.material_offset = r.u32();
    c.bounds = r.sphere();
    c.lod_bounds = r.sphere();
    c.parent_bounds = r.sphere();
    c.lod_error = r.f32();
    c.parent_error = r.f32();
  }
  d.groups.resize(groups);
  for (DagGroup& g : d.groups) {
    g.first_cluster = r.u32();
    g.cluster_count = r.u32();
    g.first_generated = r.u32();
    g.generated_count = r.u32();
    g.level = r.u32();
    g.flags = r.u32();
    g.bounds = r.sphere();
    g.parent_bounds = r.sphere();
    g.parent_error = r.f32();
  }
  d.generated_clusters.resize(generated);
  for (uint32_t& c : d.generated_clusters) c = r.u32();
  d.bvh_nodes.resize(nodes);
  for (BvhNode& n : d.bvh_nodes) {
    n.bounds = r.sphere();
    n.lod_bounds = r.sphere();
    n.max_parent_error = r.f32();
    n.child_count = r.u32();
    n.group_mask = r.u32();
    for (uint32_t& c : n.children) c = r.u32();
  }
  d.positions.resize(3 * size_t(vertices));
  for (float& f : d.positions) f = r.f32();
  if (flags & kMeshHasNormals) {
    d.normals.resize(3 * size_t(vertices));
    for (float& f : d.normals) f = r.f32();
  }
  if (flags & kMeshHasUvs) {
    d.uvs.resize(2 * size_t(vertices));
    for (float& f : d.uvs) f = r.f32();
  }
  const uint8_t* idx = r.take(3 * size_t(triangles), "a byte array");
  d.indices.assign(idx, idx + 3 * size_t(triangles));
  d.triangle_materials.resize(triangles);
  for (uint32_t& m : d.triangle_materials) m = r.u32();

  // ---- structural validation: every index in range, every range inside its array ----
  for (size_t i = 0; i < d.clusters.size(); ++i) {
    const DagCluster& c = d.clusters[i];
    std::string at = "cluster " + std::to_string(i);
    if (uint64_t(c.vertex_offset) + c.vertex_count > vertices) out_of_range(where, at + ": vertex range");
    if (uint64_t(c.triangle_offset) + c.triangle_count > triangles) out_of_range(where, at + ": triangle range");
    if (c.material_offset != c.triangle_offset)
      fail("DAGFILE_BAD_VALUE", where, at + ": material_offset != triangle_offset");
    if (c.triangle_count == 0 || c.triangle_count > kMaxClusterTriangles || c.vertex_count > kMaxClusterVertices)
      fail("DAGFILE_LIMIT_EXCEEDED", where, at + ": triangle or vertex count outside the cluster limits");
    if (c.group >= groups) out_of_range(where, at + ": group");
    if (c.generating_group != kNone && c.generating_group >= groups) out_of_range(where, at + ": generating_group");
    for (size_t k = 0; k < 3 * size_t(c.triangle_count); ++k)
      if (d.indices[3 * size_t(c.triangle_offset) + k] >= c.vertex_count)
        out_of_range(where, at + ": local vertex index");
  }
  uint32_t material_limit = std::max<uint32_t>(material_count, 1);
  for (size_t t = 0; t < d.triangle_materials.size(); ++t)
    if (d.triangle_materials[t] >= material_limit) out_of_range(where, "triangle " + std::to_string(t) + ": material");
  for (size_t i = 0; i < d.groups.size(); ++i) {
    const DagGroup& g = d.groups[i];
    std::string at = "group " + std::to_string(i);
    if (uint64_t(g.first_cluster) + g.cluster_count > clusters) out_of_range(where, at + ": cluster range");
    if (uint64_t(g.first_generated) + g.generated_count > generated) out_of_range(where, at + ": generated range");
    if (g.flags & ~uint32_t(kGroupTerminal)) fail("DAGFILE_BAD_VALUE", where, at + ": unknown flags");
  }
  for (size_t i = 0; i < d.generated_clusters.size(); ++i)
    if (d.generated_clusters[i] >= clusters) out_of_range(where, "generated_clusters[" + std::to_string(i) + "]");
  for (size_t i = 0; i < d.bvh_nodes.size(); ++i) {
    const BvhNode& n = d.bvh_nodes[i];
    std::string at = "bvh node " + std::to_string(i);
    if (n.child_count > kBvhMaxChildren) fail("DAGFILE_BAD_VALUE", where, at + ": more than 8 children");
    if (n.group_mask >> n.child_count) fail("DAGFILE_BAD_VALUE", where, at + ": group_mask beyond child_count");
    for (uint32_t k = 0; k < kBvhMaxChildren; ++k) {
      uint32_t c = n.children[k];
      if (k >= n.child_count) {
        if (c != kNone) fail("DAGFILE_BAD_VALUE", where, at + ": unused child slot is not 0xFFFFFFFF");
      } else if ((n.group_mask >> k) & 1) {
        if (c >= groups) out_of_range(where, at + ": child group");
      } else if (c >= nodes) {
        out_of_range(where, at + ": child node");
      }
    }
  }
  return d;
}

}  // namespace

namespace {

// The whole file through `w` (its own bytes, or its sink).
void encode_scene(ByteWriter& w, const BuiltScene& scene) {
  w.raw(kDagFileMagic, 8);
  w.u32(kVersion);
  w.u32(uint32_t(scene.meshes.size()));
  w.u32(uint32_t(scene.materials.size()));
  w.u32(uint32_t(scene.instances.size()));
  for (const Material& m : scene.materials) {
    w.u32(uint32_t(m.name.size()));
    w.raw(m.name.data(), m.name.size());
    for (float c : m.base_color) w.f32(c);
  }
  for (const Instance& i : scene.instances) {
    w.u32(i.mesh);
    for (float f : i.transform) w.f32(f);
    w.maybe_flush();
  }
  for (const ClusterDag& d : scene.meshes) encode_mesh(w, d);
  w.flush();
}

}  // namespace

std::vector<uint8_t> encode_dag_file(const BuiltScene& scene) {
  ByteWriter w;
  {
    // Reserve the whole file: the large arrays are appended without regrowth.
    size_t size = 8 + 4 * 4 + scene.instances.size() * kDagInstanceBytes;
    for (const Material& m : scene.materials) size += kDagMaterialMinBytes + m.name.size();
    for (const ClusterDag& d : scene.meshes)
      size += kDagMeshHeaderBytes + kClusterBytes * d.clusters.size() + kGroupBytes * d.groups.size() +
              4 * d.generated_clusters.size() + kBvhNodeBytes * d.bvh_nodes.size() +
              4 * (d.positions.size() + d.normals.size() + d.uvs.size()) + d.indices.size() +
              4 * d.triangle_materials.size();
    w.bytes.reserve(size);
  }
  encode_scene(w, scene);
  return std::move(w.bytes);
}

void write_dag_to(ByteSink& sink, const BuiltScene& scene) {
  ByteWriter w;
  w.sink = &sink;
  w.bytes.reserve(ByteWriter::kFlushBytes + 4096);
  encode_scene(w, scene);
}

BuiltScene decode_dag_file(const uint8_t* data, size_t size, const std::string& where) {
  ByteReader r = file_reader(data, size, where);
  // "VGEODAG" then the format generation digit: a different digit is another version.
  size_t prefix = std::min<size_t>(size, 7);
  if (prefix > 0 && std::memcmp(data, kDagFileMagic, prefix) != 0) fail("DAGFILE_BAD_MAGIC", where, "not a VGEODAG file");
  if (size < 8) fail("DAGFILE_TRUNCATED", where, "file ends inside the magic");
  r.take(8);
  if (data[7] != kDagFileMagic[7]) fail("DAGFILE_BAD_VERSION", where, "unsupported VGEODAG version");
  uint32_t version = r.u32();
  if (version != kVersion)
    fail("DAGFILE_BAD_VERSION", where, "version " + std::to_string(version) + ", expected " + std::to_string(kVersion));
  uint32_t mesh_count = r.u32(), material_count = r.u32(), instance_count = r.u32();
  r.need(uint64_t(mesh_count) * kDagMeshHeaderBytes + uint64_t(material_count) * kDagMaterialMinBytes +
             uint64_t(instance_count) * kDagInstanceBytes,
         "the scene tables");
  BuiltScene s;
  s.materials.resize(material_count);
  for (Material& m : s.materials) {
    uint32_t len = r.u32();
    const uint8_t* name = r.take(len, "a byte array");
    m.name.assign(reinterpret_cast<const char*>(name), len);
    for (float& c : m.base_color) c = r.f32();
  }
  s.instances.resize(instance_count);
  for (size_t i = 0; i < s.instances.size(); ++i) {
    Instance& inst = s.instances[i];
    inst.mesh = r.u32();
    if (inst.mesh >= mesh_count) out_of_range(where, "instance " + std::to_string(i) + ": mesh");
    for (float& f : inst.transform) f = r.f32();
  }
  s.meshes.reserve(mesh_count);
  for (uint32_t m = 0; m < mesh_count; ++m) s.meshes.push_back(decode_mesh(r, where, material_count));
  if (r.remaining() != 0)
    fail("DAGFILE_TRAILING_BYTES", where, std::to_string(r.remaining()) + " bytes after the last mesh");
  return s;
}

void write_dag_file(const std::string& path, const BuiltScene& scene) {
  write_file_atomic(path, [&](ByteSink& sink) { write_dag_to(sink, scene); });
}

BuiltScene read_dag_file(const std::string& path) {
  const std::vector<uint8_t> bytes = read_file(path, kAnyFileSize);  // multi-GB DAGs are valid
  return decode_dag_file(bytes.data(), bytes.size(), path);
}

}  // namespace vgeo
