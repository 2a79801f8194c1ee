// Hand-written mesh writers (see export.h). GLB is assembled from a layout computed up
// front, so the JSON chunk can be written before streaming the BIN chunk straight from
// the mesh arrays (no second in-memory copy of a multi-GB file).
#include "vgeo/mesh/export.h"

#include <algorithm>
#include <bit>
#include <charconv>
#include <cmath>
#include <nlohmann/json.hpp>

#include "vgeo/mesh/glb.h"

namespace vgeo {

static_assert(std::endian::native == std::endian::little, "GLB/PLY writers assume a little-endian host");

namespace {

// glTF constants (glTF 2.0 spec, section 5; the GLB container's in vgeo/mesh/glb.h).
constexpr int kComponentFloat = 5126, kComponentUint = 5125;
constexpr int kTargetArrayBuffer = 34962, kTargetElementArrayBuffer = 34963;
// Text formats are formatted into this many bytes before each write.
constexpr size_t kTextFlush = size_t(1) << 20;

// Buffered text formatting with locale-independent shortest round-trip floats.
class TextWriter {
 public:
  explicit TextWriter(ByteSink& sink) : sink_(sink) { buf_.reserve(kTextFlush + 256); }
  ~TextWriter() = default;
  TextWriter& str(std::string_view s) {
    buf_.append(s);
    maybe_flush();
    return *this;
  }
  TextWriter& f(float v) {
    char tmp[32];
    auto r = std::to_chars(tmp, tmp + sizeof tmp, v);
    buf_.append(tmp, r.ptr);
    return *this;
  }
  TextWriter& u(uint64_t v) {
    char tmp[24];
    auto r = std::to_chars(tmp, tmp + sizeof tmp, v);
    buf_.append(tmp, r.ptr);
    return *this;
  }
  TextWriter& ch(char c) {
    buf_.push_back(c);
    if (c == '\n') maybe_flush();
    return *this;
  }
  void flush() {
    sink_.write(buf_.data(), buf_.size());
    buf_.clear();
  }

 private:
  void maybe_flush() {
    if (buf_.size() >= kTextFlush) flush();
  }
  ByteSink& sink_;
  std::string buf_;
};

// ---------------------------------------------------------------- validation

void check_mesh(const Mesh& m, size_t material_count, const std::string& where) {
  const size_t nv = m.vertex_count(), nt = m.triangle_count();
  if (m.positions.size() % 3 || m.indices.size() % 3 || (!m.normals.empty() && m.normals.size() != 3 * nv) ||
      (!m.uvs.empty() && m.uvs.size() != 2 * nv) || (!m.materials.empty() && m.materials.size() != nt))
    fail("EXPORT_ATTRIBUTE_SIZE", where, "mesh '" + m.name + "': attribute array sizes disagree");
  if (nt == 0) fail("EXPORT_EMPTY_MESH", where, "mesh '" + m.name + "' has no triangles");
  if (nv > UINT32_MAX) fail("EXPORT_TOO_LARGE", where, "more than 2^32-1 vertices");
  for (uint32_t i : m.indices)
    if (i >= nv)
      fail("EXPORT_INDEX_OUT_OF_RANGE", where,
           "mesh '" + m.name + "': index " + std::to_string(i) + " >= vertex count " + std::to_string(nv));
  if (material_count)
    for (uint32_t mat : m.materials)
      if (mat >= material_count)
        fail("EXPORT_MATERIAL_OUT_OF_RANGE", where,
             "mesh '" + m.name + "': material " + std::to_string(mat) + " >= " + std::to_string(material_count));
  for (float p : m.positions)
    if (!std::isfinite(p)) fail("EXPORT_NON_FINITE", where, "mesh '" + m.name + "': non-finite position");
}

// Triangle order grouped by material: first[k]..first[k+1] of `order` are the triangles
// of used_materials[k], in original order.
struct MaterialGroups {
  std::vector<uint32_t> used_materials;
  std::vector<size_t> first;
  std::vector<uint32_t> order;  // empty when the mesh has a single material (identity order)
};

MaterialGroups group_by_material(const Mesh& m) {
  MaterialGroups g;
  const size_t nt = m.triangle_count();
  uint32_t max_mat = 0;
  for (uint32_t mat : m.materials) max_mat = std::max(max_mat, mat);
  std::vector<size_t> count(size_t(max_mat) + 1, 0);
  for (size_t t = 0; t < nt; ++t) ++count[m.material(t)];
  std::vector<size_t> start(count.size(), 0);
  size_t acc = 0;
  for (size_t k = 0; k < count.size(); ++k) {
    start[k] = acc;
    if (count[k]) g.used_materials.push_back(uint32_t(k)), g.first.push_back(acc);
    acc += count[k];
  }
  g.first.push_back(acc);
  if (g.used_materials.size() > 1) {
    g.order.resize(nt);
    for (size_t t = 0; t < nt; ++t) g.order[start[m.material(t)]++] = uint32_t(t);
  }
  return g;
}

void write_grouped_indices(ByteSink& sink, const Mesh& m, const MaterialGroups& g) {
  if (g.order.empty()) {
    sink.write(m.indices.data(), m.indices.size() * sizeof(uint32_t));
    return;
  }
  std::vector<uint32_t> chunk;
  chunk.reserve(3 * 65536);
  for (size_t i = 0; i < g.order.size(); ++i) {
    const uint32_t* tri = &m.indices[3 * size_t(g.order[i])];
    chunk.insert(chunk.end(), tri, tri + 3);
    if (chunk.size() >= 3 * 65536 || i + 1 == g.order.size()) {
      sink.write(chunk.data(), chunk.size() * sizeof(uint32_t));
      chunk.clear();
    }
  }
}

bool is_identity(const std::array<float, 16>& t) {
  for (int i = 0; i < 16; ++i)
    if (t[i] != ((i % 5 == 0) ? 1.0f : 0.0f)) return false;
  return true;
}

std::vector<Instance> effective_instances(const Scene& scene, const std::string& where) {
  if (scene.instances.empty()) {
    std::vector<Instance> all(scene.meshes.size());
    for (size_t i = 0; i < all.size(); ++i) all[i].mesh = uint32_t(i);
    return all;
  }
  for (const Instance& inst : scene.instances)
    if (inst.mesh >= scene.meshes.size())
      fail("EXPORT_BAD_INSTANCE", where, "instance references mesh " + std::to_string(inst.mesh));
  return scene.instances;
}

void encode_glb_to(const Scene& scene, ByteSink& sink, const std::string& where) {
  using nlohmann::json;
  const size_t material_count = std::max<size_t>(1, scene.materials.size());
  if (scene.meshes.empty()) fail("EXPORT_EMPTY_MESH", where, "scene has no meshes");
  for (const Mesh& m : scene.meshes) check_mesh(m, material_count, where);
  const std::vector<Instance> instances = effective_instances(scene, where);

  json doc;
  doc["asset"] = {{"version", "2.0"}, {"generator", "vgeo"}};
  json materials = json::array();
  if (scene.materials.empty()) {
    materials.push_back({{"name", "default"},
                         {"pbrMetallicRoughness", {{"baseColorFactor", {0.8f, 0.8f, 0.8f, 1.0f}}, {"metallicFactor", 0.0}}}});
  }
  for (const Material& mat : scene.materials) {
    json color = json::array();
    for (float c : mat.base_color) color.push_back(c);
    materials.push_back({{"name", mat.name}, {"pbrMetallicRoughness", {{"baseColorFactor", color}, {"metallicFactor", 0.0}}}});
  }
  doc["materials"] = materials;

  json views = json::array(), accessors = json::array(), meshes = json::array();
  std::vector<MaterialGroups> groups;
  uint64_t offset = 0;
  auto add_view = [&](uint64_t bytes, int target) {
    views.push_back({{"buffer", 0}, {"byteOffset", offset}, {"byteLength", bytes}, {"target", target}});
    offset += bytes;  // every element is 4-byte aligned, so every view stays aligned
    return views.size() - 1;
  };
  for (const Mesh& m : scene.meshes) {
    const uint64_t nv = m.vertex_count();
    Aabb box;
    for (size_t v = 0; v < nv; ++v) box.extend(m.position(v));
    json attributes;
    accessors.push_back({{"bufferView", add_view(12 * nv, kTargetArrayBuffer)}, {"componentType", kComponentFloat},
                         {"count", nv}, {"type", "VEC3"},
                         {"min", {box.min.x, box.min.y, box.min.z}}, {"max", {box.max.x, box.max.y, box.max.z}}});
    attributes["POSITION"] = accessors.size() - 1;
    if (!m.normals.empty()) {
      accessors.push_back({{"bufferView", add_view(12 * nv, kTargetArrayBuffer)}, {"componentType", kComponentFloat},
                           {"count", nv}, {"type", "VEC3"}});
      attributes["NORMAL"] = accessors.size() - 1;
    }
    if (!m.uvs.empty()) {
      accessors.push_back({{"bufferView", add_view(8 * nv, kTargetArrayBuffer)}, {"componentType", kComponentFloat},
                           {"count", nv}, {"type", "VEC2"}});
      attributes["TEXCOORD_0"] = accessors.size() - 1;
    }
    groups.push_back(group_by_material(m));
    const MaterialGroups& g = groups.back();
    size_t index_view = add_view(12 * uint64_t(m.triangle_count()), kTargetElementArrayBuffer);
    json prims = json::array();
    for (size_t k = 0; k < g.used_materials.size(); ++k) {
      accessors.push_back({{"bufferView", index_view}, {"byteOffset", 12 * uint64_t(g.first[k])},
                           {"componentType", kComponentUint}, {"count", 3 * uint64_t(g.first[k + 1] - g.first[k])},
                           {"type", "SCALAR"}});
      prims.push_back({{"attributes", attributes}, {"indices", accessors.size() - 1},
                       {"material", g.used_materials[k]}, {"mode", kGltfModeTriangles}});
    }
    json mesh_json = {{"primitives", prims}};
    if (!m.name.empty()) mesh_json["name"] = m.name;
    meshes.push_back(mesh_json);
  }
  json nodes = json::array(), roots = json::array();
  for (const Instance& inst : instances) {
    json node = {{"mesh", inst.mesh}};
    if (!is_identity(inst.transform)) node["matrix"] = inst.transform;
    nodes.push_back(node);
    roots.push_back(nodes.size() - 1);
  }
  doc["buffers"] = json::array({json{{"byteLength", offset}}});
  doc["bufferViews"] = views;
  doc["accessors"] = accessors;
  doc["meshes"] = meshes;
  doc["nodes"] = nodes;
  doc["scenes"] = json::array({json{{"nodes", roots}}});
  doc["scene"] = 0;

  std::string text = doc.dump();
  while (text.size() % 4) text.push_back(' ');  // JSON chunk is padded with spaces
  const uint64_t total = kGlbHeaderBytes + kGlbChunkHeaderBytes + text.size() + kGlbChunkHeaderBytes + offset;
  if (total > UINT32_MAX) fail("EXPORT_TOO_LARGE", where, "GLB would exceed 4 GiB (" + std::to_string(total) + " bytes)");
  const uint32_t header[5] = {kGlbMagic, kGlbVersion, uint32_t(total), uint32_t(text.size()), kGlbChunkJson};
  sink.write(header, sizeof header);
  sink.write(text.data(), text.size());
  const uint32_t bin_header[2] = {uint32_t(offset), kGlbChunkBin};
  sink.write(bin_header, sizeof bin_header);
  for (size_t i = 0; i < scene.meshes.size(); ++i) {
    const Mesh& m = scene.meshes[i];
    sink.write(m.positions.data(), m.positions.size() * sizeof(float));
    if (!m.normals.empty()) sink.write(m.normals.data(), m.normals.size() * sizeof(float));
    if (!m.uvs.empty()) sink.write(m.uvs.data(), m.uvs.size() * sizeof(float));
    write_grouped_indices(sink, m, groups[i]);
  }
}

void obj_to(const Mesh& m, const std::vector<Material>& materials, ByteSink& sink, const std::string& where) {
  check_mesh(m, materials.size(), where);
  TextWriter w(sink);
  w.str("# vgeo\n");
  if (!m.name.empty()) w.str("o ").str(m.name).ch('\n');
  const size_t nv = m.vertex_count();
  for (size_t v = 0; v < nv; ++v)
    w.str("v ").f(m.positions[3 * v]).ch(' ').f(m.positions[3 * v + 1]).ch(' ').f(m.positions[3 * v + 2]).ch('\n');
  for (size_t v = 0; v < nv && !m.uvs.empty(); ++v)
    w.str("vt ").f(m.uvs[2 * v]).ch(' ').f(m.uvs[2 * v + 1]).ch('\n');
  for (size_t v = 0; v < nv && !m.normals.empty(); ++v)
    w.str("vn ").f(m.normals[3 * v]).ch(' ').f(m.normals[3 * v + 1]).ch(' ').f(m.normals[3 * v + 2]).ch('\n');
  const MaterialGroups g = group_by_material(m);
  const bool uv = !m.uvs.empty(), nrm = !m.normals.empty();
  for (size_t k = 0; k < g.used_materials.size(); ++k) {
    uint32_t mat = g.used_materials[k];
    if (mat < materials.size() && !materials[mat].name.empty()) w.str("usemtl ").str(materials[mat].name).ch('\n');
    else w.str("usemtl material").u(mat).ch('\n');
    for (size_t i = g.first[k]; i < g.first[k + 1]; ++i) {
      size_t t = g.order.empty() ? i : g.order[i];
      w.ch('f');
      for (int c = 0; c < 3; ++c) {
        uint64_t idx = uint64_t(m.indices[3 * t + c]) + 1;  // OBJ is 1-based
        w.ch(' ').u(idx);
        if (uv || nrm) {
          w.ch('/');
          if (uv) w.u(idx);
          if (nrm) w.ch('/').u(idx);
        }
      }
      w.ch('\n');
    }
  }
  w.flush();
}

void ply_to(const Mesh& m, ByteSink& sink, const std::string& where) {
  check_mesh(m, 0, where);
  const bool nrm = !m.normals.empty(), uv = !m.uvs.empty(), mat = !m.materials.empty();
  std::string header = "ply\nformat binary_little_endian 1.0\ncomment vgeo\nelement vertex " +
                       std::to_string(m.vertex_count()) + "\nproperty float x\nproperty float y\nproperty float z\n";
  if (nrm) header += "property float nx\nproperty float ny\nproperty float nz\n";
  if (uv) header += "property float s\nproperty float t\n";
  header += "element face " + std::to_string(m.triangle_count()) + "\nproperty list uchar uint vertex_indices\n";
  if (mat) header += "property uint material_index\n";
  header += "end_header\n";
  sink.write(header.data(), header.size());
  std::vector<uint8_t> buf;
  buf.reserve(kTextFlush + 64);
  auto put = [&](const void* p, size_t n) {
    const auto* b = static_cast<const uint8_t*>(p);
    buf.insert(buf.end(), b, b + n);
    if (buf.size() >= kTextFlush) sink.write(buf.data(), buf.size()), buf.clear();
  };
  for (size_t v = 0; v < m.vertex_count(); ++v) {
    put(&m.positions[3 * v], 12);
    if (nrm) put(&m.normals[3 * v], 12);
    if (uv) put(&m.uvs[2 * v], 8);
  }
  for (size_t t = 0; t < m.triangle_count(); ++t) {
    const uint8_t three = 3;
    put(&three, 1);
    put(&m.indices[3 * t], 12);
    if (mat) put(&m.materials[t], 4);
  }
  sink.write(buf.data(), buf.size());
}

void off_to(const Mesh& m, ByteSink& sink, const std::string& where) {
  check_mesh(m, 0, where);
  TextWriter w(sink);
  w.str("OFF\n").u(m.vertex_count()).ch(' ').u(m.triangle_count()).str(" 0\n");
  for (size_t v = 0; v < m.vertex_count(); ++v)
    w.f(m.positions[3 * v]).ch(' ').f(m.positions[3 * v + 1]).ch(' ').f(m.positions[3 * v + 2]).ch('\n');
  for (size_t t = 0; t < m.triangle_count(); ++t)
    w.str("3 ").u(m.indices[3 * t]).ch(' ').u(m.indices[3 * t + 1]).ch(' ').u(m.indices[3 * t + 2]).ch('\n');
  w.flush();
}

}  // namespace

std::optional<MeshFormat> mesh_format_from_path(std::string_view path) {
  size_t dot = path.rfind('.');
  if (dot == std::string_view::npos) return std::nullopt;
  std::string ext(path.substr(dot + 1));
  for (char& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
  if (ext == "glb") return MeshFormat::kGlb;
  if (ext == "obj") return MeshFormat::kObj;
  if (ext == "ply") return MeshFormat::kPly;
  if (ext == "off") return MeshFormat::kOff;
  return std::nullopt;
}

std::string_view mesh_format_name(MeshFormat format) {
  switch (format) {
    case MeshFormat::kGlb: return "glb";
    case MeshFormat::kObj: return "obj";
    case MeshFormat::kPly: return "ply";
    case MeshFormat::kOff: return "off";
  }
  return "?";
}

std::vector<uint8_t> encode_glb(const Scene& scene) {
  MemorySink sink;
  encode_glb_to(scene, sink, "<memory>");
  return std::move(sink.bytes);
}

void write_glb(const Scene& scene, const std::string& path) {
  // A rejected scene throws before the rename: the temp file is removed, `path` untouched.
  write_file_atomic(path, [&](ByteSink& s) { encode_glb_to(scene, s, path); });
}

void write_obj(const Mesh& mesh, const std::string& path, const std::vector<Material>& materials) {
  write_file_atomic(path, [&](ByteSink& s) { obj_to(mesh, materials, s, path); });
}
void write_ply(const Mesh& mesh, const std::string& path) {
  write_file_atomic(path, [&](ByteSink& s) { ply_to(mesh, s, path); });
}
void write_off(const Mesh& mesh, const std::string& path) {
  write_file_atomic(path, [&](ByteSink& s) { off_to(mesh, s, path); });
}

Mesh bake_scene(const Scene& scene) {
  const std::vector<Instance> instances = effective_instances(scene, "bake_scene");
  if (instances.size() == 1 && is_identity(instances[0].transform)) return scene.meshes[instances[0].mesh];
  Mesh out;
  out.name = "scene";
  bool all_normals = true, all_uvs = true, any_materials = false;
  for (const Instance& inst : instances) {
    const Mesh& m = scene.meshes[inst.mesh];
    all_normals &= !m.normals.empty();
    all_uvs &= !m.uvs.empty();
    any_materials |= !m.materials.empty();
  }
  for (const Instance& inst : instances) {
    const Mesh& m = scene.meshes[inst.mesh];
    const auto& t = inst.transform;  // column-major: t[col * 4 + row]
    const uint64_t base = out.vertex_count();
    if (base + m.vertex_count() > UINT32_MAX) fail("EXPORT_TOO_LARGE", "bake_scene", "more than 2^32-1 vertices");
    // Normal matrix = cofactor matrix of the 3x3 part (= det * inverse transpose).
    double a[3][3];
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) a[r][c] = t[c * 4 + r];
    double cof[3][3];
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) {
        int r1 = (r + 1) % 3, r2 = (r + 2) % 3, c1 = (c + 1) % 3, c2 = (c + 2) % 3;
        cof[r][c] = a[r1][c1] * a[r2][c2] - a[r1][c2] * a[r2][c1];
      }
    const double det = a[0][0] * cof[0][0] + a[0][1] * cof[0][1] + a[0][2] * cof[0][2];
    const double sign = det < 0 ? -1.0 : 1.0;
    for (size_t v = 0; v < m.vertex_count(); ++v) {
      const double p[3] = {m.positions[3 * v], m.positions[3 * v + 1], m.positions[3 * v + 2]};
      for (int r = 0; r < 3; ++r)
        out.positions.push_back(float(a[r][0] * p[0] + a[r][1] * p[1] + a[r][2] * p[2] + t[12 + r]));
      if (all_normals) {
        const double n[3] = {m.normals[3 * v], m.normals[3 * v + 1], m.normals[3 * v + 2]};
        double w[3];
        for (int r = 0; r < 3; ++r) w[r] = sign * (cof[r][0] * n[0] + cof[r][1] * n[1] + cof[r][2] * n[2]);
        double len = std::sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
        for (int r = 0; r < 3; ++r) out.normals.push_back(len > 0 ? float(w[r] / len) : (r == 2 ? 1.0f : 0.0f));
      }
      if (all_uvs) out.uvs.insert(out.uvs.end(), m.uvs.begin() + 2 * v, m.uvs.begin() + 2 * v + 2);
    }
    for (size_t tri = 0; tri < m.triangle_count(); ++tri) {
      uint32_t i0 = m.indices[3 * tri], i1 = m.indices[3 * tri + 1], i2 = m.indices[3 * tri + 2];
      if (det < 0) std::swap(i1, i2);  // mirrored instance: keep counter-clockwise = front
      out.indices.insert(out.indices.end(), {uint32_t(base + i0), uint32_t(base + i1), uint32_t(base + i2)});
      if (any_materials) out.materials.push_back(m.material(tri));
    }
  }
  return out;
}

void write_scene_file(const Scene& scene, const std::string& path) {
  std::optional<MeshFormat> format = mesh_format_from_path(path);
  if (!format)
    fail("EXPORT_UNKNOWN_FORMAT", path, "unknown output extension (expected .glb, .obj, .ply or .off)", kExitUsage);
  switch (*format) {
    case MeshFormat::kGlb: write_glb(scene, path); return;
    case MeshFormat::kObj: write_obj(bake_scene(scene), path, scene.materials); return;
    case MeshFormat::kPly: write_ply(bake_scene(scene), path); return;
    case MeshFormat::kOff: write_off(bake_scene(scene), path); return;
  }
}

}  // namespace vgeo
