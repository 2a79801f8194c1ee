// VGEODAG1: uncompressed little-endian serialization of a BuiltScene (spec/dag.md §File).
// The decoder is hardened for files from other implementations: every count is checked
// against the remaining bytes before anything is allocated, every index is range-checked,
// padding is not stored (so valid data has exactly one encoding), trailing bytes are an error.
#include "vgeo/dag/dag_io.h"

#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <bit>
#include <cstring>
#include <algorithm>
#include <filesystem>

#include "vgeo/core/error.h"
#include "vgeo/mesh/export.h"

namespace vgeo {

namespace {

constexpr char kMagic[8] = {'V', 'G', 'E', 'O', 'D', 'A', 'G', '1'};
constexpr uint32_t kVersion = 1;
constexpr uint32_t kMeshHasNormals = 1u << 0;
constexpr uint32_t kMeshHasUvs = 1u << 1;
// Encoded sizes (bytes) of the fixed records; pads are not stored.
constexpr size_t kSphereBytes = 16;
constexpr size_t kClusterBytes = 8 * 4 + 3 * kSphereBytes + 2 * 4;
constexpr size_t kGroupBytes = 6 * 4 + 2 * kSphereBytes + 4;
constexpr size_t kBvhNodeBytes = 2 * kSphereBytes + 4 + 4 + 4 + kBvhMaxChildren * 4;
constexpr size_t kMeshHeaderBytes = 4 + 4 + 6 * 4 + 6 * 4;
constexpr size_t kMaterialMinBytes = 4 + 4 * 4;
constexpr size_t kInstanceBytes = 4 + 16 * 4;

// Little-endian field writer. Without a sink everything stays in `bytes`; with one,
// `bytes` is handed over whenever it passes kFlushBytes and large 32-bit arrays go to the
// sink straight from the caller's memory (no copy of a multi-GB file in memory).
class Writer {
 public:
  static constexpr size_t kFlushBytes = size_t(1) << 20;  // same order as the file buffer
  std::vector<uint8_t> bytes;
  ByteSink* sink = nullptr;
  void u8(uint8_t v) { bytes.push_back(v); }
  void u32(uint32_t v) {
    for (int i = 0; i < 4; ++i) bytes.push_back(uint8_t(v >> (8 * i)));
  }
  void f32(float f) {
    uint32_t v;
    std::memcpy(&v, &f, 4);
    u32(v);
  }
  void raw(const void* data, size_t size) {
    if (sink && size >= kFlushBytes) {
      flush();
      sink->write(data, size);
      return;
    }
    const auto* p = static_cast<const uint8_t*>(data);
    bytes.insert(bytes.end(), p, p + size);
    maybe_flush();
  }
  // Arrays of 32-bit values: one copy on little-endian hosts (the file is little-endian).
  template <class T>
  void array32(const T* values, size_t count) {
    static_assert(sizeof(T) == 4);
    if constexpr (std::endian::native == std::endian::little) {
      raw(values, 4 * count);
    } else {
      for (size_t i = 0; i < count; ++i) {
        uint32_t v;
        std::memcpy(&v, &values[i], 4);
        u32(v);
        maybe_flush();
      }
    }
  }
  void sphere(const Sphere& s) {
    f32(s.center.x);
    f32(s.center.y);
    f32(s.center.z);
    f32(s.radius);
  }
  void maybe_flush() {
    if (sink && bytes.size() >= kFlushBytes) flush();
  }
  void flush() {
    if (!sink) return;  // in-memory encoding: everything stays in `bytes`
    if (!bytes.empty()) sink->write(bytes.data(), bytes.size());
    bytes.clear();
  }
};

class Reader {
 public:
  Reader(const uint8_t* data, size_t size, const std::string& where) : p_(data), end_(data + size), where_(where) {}
  size_t remaining() const { return size_t(end_ - p_); }
  void need(uint64_t bytes, const char* what) {
    if (bytes > remaining())
      fail("DAGFILE_TRUNCATED", where_, std::string("file ends inside ") + what);
  }
  uint8_t u8() {
    need(1, "a byte field");
    return *p_++;
  }
  uint32_t u32() {
    need(4, "a 32-bit field");
    uint32_t v = uint32_t(p_[0]) | uint32_t(p_[1]) << 8 | uint32_t(p_[2]) << 16 | uint32_t(p_[3]) << 24;
    p_ += 4;
    return v;
  }
  float f32() {
    uint32_t v = u32();
    float f;
    std::memcpy(&f, &v, 4);
    return f;
  }
  Sphere sphere() {
    Sphere s;
    s.center.x = f32();
    s.center.y = f32();
    s.center.z = f32();
    s.radius = f32();
    return s;
  }
  const uint8_t* bytes(size_t n) {
    need(n, "a byte array");
    const uint8_t* q = p_;
    p_ += n;
    return q;
  }

 private:
  const uint8_t* p_;
  const uint8_t* end_;
  const std::string& where_;
};

[[noreturn]] void out_of_range(const std::string& where, const std::string& what) {
  fail("DAGFILE_INDEX_OUT_OF_RANGE", where, what);
}

void encode_mesh(Writer& w, const ClusterDag& d) {
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

ClusterDag decode_mesh(Reader& r, const std::string& where, uint32_t material_count) {
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
  const uint8_t* idx = r.bytes(3 * size_t(triangles));
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
void encode_scene(Writer& w, const BuiltScene& scene) {
  w.raw(kMagic, 8);
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
  Writer w;
  {
    // Reserve the whole file: the large arrays are appended without regrowth.
    size_t size = 8 + 4 * 4 + scene.instances.size() * kInstanceBytes;
    for (const Material& m : scene.materials) size += kMaterialMinBytes + m.name.size();
    for (const ClusterDag& d : scene.meshes)
      size += kMeshHeaderBytes + kClusterBytes * d.clusters.size() + kGroupBytes * d.groups.size() +
              4 * d.generated_clusters.size() + kBvhNodeBytes * d.bvh_nodes.size() +
              4 * (d.positions.size() + d.normals.size() + d.uvs.size()) + d.indices.size() +
              4 * d.triangle_materials.size();
    w.bytes.reserve(size);
  }
  encode_scene(w, scene);
  return std::move(w.bytes);
}

void write_dag_to(ByteSink& sink, const BuiltScene& scene) {
  Writer w;
  w.sink = &sink;
  w.bytes.reserve(Writer::kFlushBytes + 4096);
  encode_scene(w, scene);
}

BuiltScene decode_dag_file(const uint8_t* data, size_t size, const std::string& where) {
  Reader r(data, size, where);
  // "VGEODAG" then the format generation digit: a different digit is another version.
  size_t prefix = std::min<size_t>(size, 7);
  if (prefix > 0 && std::memcmp(data, kMagic, prefix) != 0) fail("DAGFILE_BAD_MAGIC", where, "not a VGEODAG file");
  if (size < 8) fail("DAGFILE_TRUNCATED", where, "file ends inside the magic");
  r.bytes(8);
  if (data[7] != kMagic[7]) fail("DAGFILE_BAD_VERSION", where, "unsupported VGEODAG version");
  uint32_t version = r.u32();
  if (version != kVersion)
    fail("DAGFILE_BAD_VERSION", where, "version " + std::to_string(version) + ", expected " + std::to_string(kVersion));
  uint32_t mesh_count = r.u32(), material_count = r.u32(), instance_count = r.u32();
  r.need(uint64_t(mesh_count) * kMeshHeaderBytes + uint64_t(material_count) * kMaterialMinBytes +
             uint64_t(instance_count) * kInstanceBytes,
         "the scene tables");
  BuiltScene s;
  s.materials.resize(material_count);
  for (Material& m : s.materials) {
    uint32_t len = r.u32();
    const uint8_t* name = r.bytes(len);
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
  write_file_atomic(path, [&](ByteSink& sink) { write_dag_to(sink, scene); }, "DAGFILE_IO");
}

BuiltScene read_dag_file(const std::string& path) {
  FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) fail("DAGFILE_IO", path, std::string("cannot open: ") + std::strerror(errno), kExitIo);
  std::vector<uint8_t> bytes;
  uint8_t buf[1 << 16];
  size_t n;
  while ((n = std::fread(buf, 1, sizeof(buf), f)) > 0) bytes.insert(bytes.end(), buf, buf + n);
  bool error = std::ferror(f) != 0;
  std::fclose(f);
  if (error) fail("DAGFILE_IO", path, "read failed", kExitIo);
  return decode_dag_file(bytes.data(), bytes.size(), path);
}

}  // namespace vgeo
