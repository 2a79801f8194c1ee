// glTF 2.0 / GLB reader. tinygltf parses the JSON and resolves buffers; everything it hands
// back is treated as untrusted: every index, offset, stride and count is bounds-checked here
// before any byte is read (tinygltf validates only part of the schema).
#include <tiny_gltf.h>

#include <array>
#include <cmath>
#include <cstring>
#include <nlohmann/json.hpp>
#include <set>

#include "vgeo/core/byte_io.h"
#include "vgeo/mesh/glb.h"
#include "vgeo/mesh/import.h"
#include "vgeo/mesh/validate.h"

namespace vgeo::detail {
namespace {

// Non-affine tolerance for node matrices: exporters write tiny round-off (1e-17) into the
// last row; anything larger is a projective matrix the mesh model cannot represent.
constexpr double kAffineTolerance = 1e-6;

constexpr int kModePoints = 0, kModeLines = 1, kModeLineLoop = 2, kModeLineStrip = 3;
constexpr int kModeTriangleStrip = 5, kModeTriangleFan = 6;

// Geometry-neutral extensions: they change appearance only, so a file requiring them still
// imports correctly. KHR_mesh_quantization widens the accepted accessor component types.
const std::set<std::string> kIgnorableRequiredExtensions = {
    "KHR_texture_transform", "KHR_materials_unlit", "KHR_materials_emissive_strength",
    "KHR_materials_clearcoat", "KHR_materials_transmission", "KHR_materials_sheen",
    "KHR_materials_volume", "KHR_materials_ior", "KHR_materials_specular",
    "KHR_materials_pbrSpecularGlossiness", "KHR_texture_basisu", "EXT_texture_webp",
    "KHR_mesh_quantization", "KHR_lights_punctual",
    "KHR_technique_webgl"};  // legacy shader-technique materials

int component_size(int ctype) {
  switch (ctype) {
    case TINYGLTF_COMPONENT_TYPE_BYTE:
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return 1;
    case TINYGLTF_COMPONENT_TYPE_SHORT:
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: return 2;
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT:
    case TINYGLTF_COMPONENT_TYPE_FLOAT: return 4;
    default: return 0;
  }
}

int type_components(int type) {
  switch (type) {
    case TINYGLTF_TYPE_SCALAR: return 1;
    case TINYGLTF_TYPE_VEC2: return 2;
    case TINYGLTF_TYPE_VEC3: return 3;
    case TINYGLTF_TYPE_VEC4: return 4;
    case TINYGLTF_TYPE_MAT2: return 4;
    case TINYGLTF_TYPE_MAT3: return 9;
    case TINYGLTF_TYPE_MAT4: return 16;
    default: return 0;
  }
}

// Normalized integer -> float per the glTF 2.0 spec (signed: max(c / MAX, -1)).
template <class T>
float to_float(const uint8_t* p, bool normalized) {
  T v;
  std::memcpy(&v, p, sizeof(T));
  if constexpr (std::is_same_v<T, float>) {
    return v;
  } else {
    if (!normalized) return float(v);
    constexpr float kMax = float(std::numeric_limits<T>::max());
    return std::max(float(v) / kMax, -1.0f);
  }
}

// A checked window onto an accessor's bytes: base + i * stride for i < count is in bounds.
struct Span {
  const uint8_t* base = nullptr;  // nullptr: no bufferView, elements are zero
  size_t stride = 0;
  size_t count = 0;
};

class GltfReader {
 public:
  GltfReader(const tinygltf::Model& model, std::string where, uint64_t input_bytes, ImportResult& out)
      : model_(model),
        where_(std::move(where)),
        budget_(OutputBudget::for_input(input_bytes, where_)),
        out_(out) {
    for (const auto& e : model_.extensionsUsed)
      if (e == "KHR_mesh_quantization") quantized_ = true;
  }

  void run();

 private:
  [[noreturn]] void error(const char* code, const std::string& what) const { fail(code, where_, what); }
  void warn(const char* code, const std::string& what) { out_.warnings.push_back({code, what}); }

  const tinygltf::Accessor& accessor(int index, const std::string& role) const {
    if (index < 0 || size_t(index) >= model_.accessors.size())
      error("ACCESSOR_INDEX_OUT_OF_RANGE", role + " refers to accessor " + std::to_string(index) +
                                               " of " + std::to_string(model_.accessors.size()));
    return model_.accessors[size_t(index)];
  }

  // Bytes [offset, offset + length) of bufferView `view_index`, checked against its buffer.
  const uint8_t* view_bytes(int view_index, size_t& length, size_t& stride, const std::string& role) const {
    if (view_index < 0 || size_t(view_index) >= model_.bufferViews.size())
      error("BUFFER_VIEW_INDEX_OUT_OF_RANGE", role + " refers to bufferView " + std::to_string(view_index) +
                                                  " of " + std::to_string(model_.bufferViews.size()));
    const tinygltf::BufferView& view = model_.bufferViews[size_t(view_index)];
    if (view.buffer < 0 || size_t(view.buffer) >= model_.buffers.size())
      error("BUFFER_INDEX_OUT_OF_RANGE", "bufferView " + std::to_string(view_index) + " refers to buffer " +
                                             std::to_string(view.buffer) + " of " +
                                             std::to_string(model_.buffers.size()));
    const std::vector<unsigned char>& data = model_.buffers[size_t(view.buffer)].data;
    if (view.byteOffset > data.size() || view.byteLength > data.size() - view.byteOffset)
      error("BUFFER_VIEW_OUT_OF_RANGE", "bufferView " + std::to_string(view_index) + " [offset " +
                                            std::to_string(view.byteOffset) + ", length " +
                                            std::to_string(view.byteLength) + "] exceeds buffer " +
                                            std::to_string(view.buffer) + " of " +
                                            std::to_string(data.size()) + " bytes");
    length = view.byteLength;
    stride = view.byteStride;
    return data.data() + view.byteOffset;
  }

  // Checked span of `count` elements of `element_bytes` at `offset` inside a bufferView.
  Span view_span(int view_index, size_t offset, size_t count, size_t element_bytes, bool allow_stride,
                 const std::string& role) const {
    size_t length = 0, stride = 0;
    const uint8_t* bytes = view_bytes(view_index, length, stride, role);
    if (!allow_stride) stride = 0;
    if (stride == 0) stride = element_bytes;
    if (stride < element_bytes)
      error("BUFFER_VIEW_STRIDE_INVALID", role + ": byteStride " + std::to_string(stride) +
                                              " is smaller than the element size " +
                                              std::to_string(element_bytes));
    // offset + (count - 1) * stride + element_bytes <= length, without overflow.
    bool fits = offset <= length && element_bytes <= length - offset &&
                (count == 0 || (count - 1) <= (length - offset - element_bytes) / stride);
    if (!fits)
      error("ACCESSOR_OUT_OF_RANGE", role + ": " + std::to_string(count) + " elements of " +
                                         std::to_string(element_bytes) + " bytes (stride " +
                                         std::to_string(stride) + ") at offset " + std::to_string(offset) +
                                         " exceed bufferView " + std::to_string(view_index) + " of " +
                                         std::to_string(length) + " bytes");
    return Span{bytes + offset, stride, count};
  }

  Span accessor_span(const tinygltf::Accessor& acc, size_t element_bytes, const std::string& role) const {
    if (acc.bufferView < 0) return Span{nullptr, 0, acc.count};
    return view_span(acc.bufferView, acc.byteOffset, acc.count, element_bytes, true, role);
  }

  // Checks type/componentType/normalized of an attribute accessor against what glTF allows.
  void check_attribute_type(const tinygltf::Accessor& acc, const std::string& semantic, int want_type,
                            const std::string& role) const {
    const int ct = acc.componentType;
    bool ok_component = false;
    const bool is_float = ct == TINYGLTF_COMPONENT_TYPE_FLOAT;
    const bool small_int = ct == TINYGLTF_COMPONENT_TYPE_BYTE || ct == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE ||
                           ct == TINYGLTF_COMPONENT_TYPE_SHORT || ct == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT;
    if (semantic == "POSITION") {
      ok_component = is_float || (quantized_ && small_int);
    } else if (semantic == "NORMAL") {
      ok_component = is_float || (quantized_ && acc.normalized &&
                                  (ct == TINYGLTF_COMPONENT_TYPE_BYTE || ct == TINYGLTF_COMPONENT_TYPE_SHORT));
    } else {  // TEXCOORD_0
      ok_component = is_float ||
                     (acc.normalized && (ct == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE ||
                                         ct == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT)) ||
                     (quantized_ && small_int);
    }
    if (acc.type != want_type || !ok_component)
      error("ACCESSOR_TYPE_INVALID", role + " (" + semantic + ") has type " + std::to_string(acc.type) +
                                         ", componentType " + std::to_string(ct) +
                                         (acc.normalized ? " normalized" : "") +
                                         ", which glTF does not allow for " + semantic);
    if (acc.normalized && is_float)
      error("ACCESSOR_TYPE_INVALID", role + ": a float accessor cannot be normalized");
  }

  template <class T>
  void decode_span(const Span& s, int comps, bool normalized, float* dst) const {
    const size_t csize = sizeof(T);
    for (size_t i = 0; i < s.count; ++i) {
      const uint8_t* p = s.base + i * s.stride;
      for (int c = 0; c < comps; ++c) dst[i * comps + c] = to_float<T>(p + c * csize, normalized);
    }
  }

  void decode_to_float(const Span& s, int ctype, int comps, bool normalized, float* dst) const {
    if (s.base == nullptr) {
      std::fill(dst, dst + s.count * comps, 0.0f);
      return;
    }
    switch (ctype) {
      case TINYGLTF_COMPONENT_TYPE_FLOAT:
        if (s.stride == size_t(comps) * 4) {
          std::memcpy(dst, s.base, s.count * comps * 4);
        } else {
          decode_span<float>(s, comps, normalized, dst);
        }
        break;
      case TINYGLTF_COMPONENT_TYPE_BYTE: decode_span<int8_t>(s, comps, normalized, dst); break;
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: decode_span<uint8_t>(s, comps, normalized, dst); break;
      case TINYGLTF_COMPONENT_TYPE_SHORT: decode_span<int16_t>(s, comps, normalized, dst); break;
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: decode_span<uint16_t>(s, comps, normalized, dst); break;
      default: error("ACCESSOR_TYPE_INVALID", "unsupported componentType " + std::to_string(ctype));
    }
  }

  // Reads sparse indices (checked < accessor.count) into `out`.
  void sparse_indices(const tinygltf::Accessor& acc, std::vector<uint32_t>& out, const std::string& role) {
    const auto& sp = acc.sparse;
    if (sp.count <= 0 || size_t(sp.count) > acc.count)
      error("ACCESSOR_SPARSE_INVALID", role + ": sparse count " + std::to_string(sp.count) +
                                           " must be in [1, " + std::to_string(acc.count) + "]");
    const int ict = sp.indices.componentType;
    const int isize = component_size(ict);
    if (ict != TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE && ict != TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT &&
        ict != TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT)
      error("ACCESSOR_SPARSE_INVALID", role + ": sparse indices componentType " + std::to_string(ict) +
                                           " is not an unsigned integer type");
    if (sp.indices.byteOffset < 0)
      error("ACCESSOR_SPARSE_INVALID", role + ": negative sparse indices byteOffset");
    budget_.charge(uint64_t(sp.count), 4, "sparse indices");
    Span s = view_span(sp.indices.bufferView, size_t(sp.indices.byteOffset), size_t(sp.count), size_t(isize),
                       false, role + " sparse indices");
    out.resize(size_t(sp.count));
    for (size_t i = 0; i < out.size(); ++i) {
      const uint8_t* p = s.base + i * s.stride;
      uint32_t v = isize == 1 ? *p : isize == 2 ? uint32_t(p[0] | (p[1] << 8)) : load_le32(p);
      if (v >= acc.count)
        error("ACCESSOR_SPARSE_INVALID", role + ": sparse index " + std::to_string(v) +
                                             " >= accessor count " + std::to_string(acc.count));
      if (i > 0 && v <= out[i - 1])
        error("ACCESSOR_SPARSE_INVALID", role + ": sparse indices are not strictly increasing");
      out[i] = v;
    }
  }

  // Appends accessor `index` decoded to floats (`comps` per element) to `dst`; returns count.
  size_t append_float_attribute(int index, const std::string& semantic, int want_type, std::vector<float>& dst,
                                const std::string& role) {
    const tinygltf::Accessor& acc = accessor(index, role);
    check_attribute_type(acc, semantic, want_type, role);
    const int comps = type_components(acc.type);
    const size_t esize = size_t(comps) * size_t(component_size(acc.componentType));
    if (acc.count == 0) error("ACCESSOR_COUNT_INVALID", role + " has count 0");
    Span s = accessor_span(acc, esize, role);
    budget_.charge(s.count, uint64_t(comps) * sizeof(float), "attribute data");
    const size_t start = dst.size();
    dst.resize(start + s.count * comps);
    decode_to_float(s, acc.componentType, comps, acc.normalized, dst.data() + start);
    if (acc.sparse.isSparse) {
      std::vector<uint32_t> where;
      sparse_indices(acc, where, role);
      if (acc.sparse.values.byteOffset < 0)
        error("ACCESSOR_SPARSE_INVALID", role + ": negative sparse values byteOffset");
      Span vs = view_span(acc.sparse.values.bufferView, size_t(acc.sparse.values.byteOffset), where.size(), esize,
                          false, role + " sparse values");
      std::vector<float> values(where.size() * comps);
      decode_to_float(vs, acc.componentType, comps, acc.normalized, values.data());
      for (size_t i = 0; i < where.size(); ++i)
        for (int c = 0; c < comps; ++c) dst[start + size_t(where[i]) * comps + c] = values[i * comps + c];
    }
    return s.count;
  }

  // Validates index accessor `index` and returns its element count.
  size_t index_count(int index, const std::string& role) const {
    const tinygltf::Accessor& acc = accessor(index, role);
    const int ct = acc.componentType;
    if (acc.type != TINYGLTF_TYPE_SCALAR ||
        (ct != TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE && ct != TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT &&
         ct != TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT) ||
        acc.normalized)
      error("ACCESSOR_TYPE_INVALID", role + " (indices) must be SCALAR unsigned byte/short/int, got type " +
                                         std::to_string(acc.type) + " componentType " + std::to_string(ct));
    return accessor_span(acc, size_t(component_size(ct)), role).count;
  }

  // Decodes index accessor `index` (validated by index_count) into dst[0, count). Values are
  // checked against the vertex count by the caller.
  void decode_indices(int index, uint32_t* dst, const std::string& role) {
    const tinygltf::Accessor& acc = accessor(index, role);
    const size_t isize = size_t(component_size(acc.componentType));
    Span s = accessor_span(acc, isize, role);
    budget_.charge(s.count, 4, "index data");
    if (s.base == nullptr) {
      std::fill(dst, dst + s.count, 0u);
    } else if (isize == 4 && s.stride == 4) {
      std::memcpy(dst, s.base, s.count * 4);
    } else if (isize == 2 && s.stride == 2) {
      for (size_t i = 0; i < s.count; ++i) dst[i] = uint32_t(s.base[2 * i] | (s.base[2 * i + 1] << 8));
    } else {
      for (size_t i = 0; i < s.count; ++i) {
        const uint8_t* p = s.base + i * s.stride;
        dst[i] = isize == 1 ? *p : isize == 2 ? uint32_t(p[0] | (p[1] << 8)) : load_le32(p);
      }
    }
    if (acc.sparse.isSparse) {
      std::vector<uint32_t> where;
      sparse_indices(acc, where, role);
      if (acc.sparse.values.byteOffset < 0)
        error("ACCESSOR_SPARSE_INVALID", role + ": negative sparse values byteOffset");
      Span vs = view_span(acc.sparse.values.bufferView, size_t(acc.sparse.values.byteOffset), where.size(), isize,
                          false, role + " sparse values");
      for (size_t i = 0; i < where.size(); ++i) {
        const uint8_t* p = vs.base + i * vs.stride;
        dst[where[i]] = isize == 1 ? *p : isize == 2 ? uint32_t(p[0] | (p[1] << 8)) : load_le32(p);
      }
    }
  }

  void append_primitive(const tinygltf::Primitive& prim, const std::string& role, Mesh& mesh,
                        bool mesh_has_normals, bool mesh_has_uvs, uint32_t material);
  void fill_normals(Mesh& mesh, size_t first_vertex, size_t first_index);
  void import_mesh(size_t gltf_mesh, Mesh& mesh);
  std::array<double, 16> local_matrix(const tinygltf::Node& node, size_t node_index) const;

  const tinygltf::Model& model_;
  std::string where_;
  OutputBudget budget_;
  ImportResult& out_;
  bool quantized_ = false;
  uint32_t default_material_ = 0;
  bool need_default_material_ = false;
};

void GltfReader::fill_normals(Mesh& mesh, size_t first_vertex, size_t first_index) {
  const size_t n = mesh.vertex_count();
  std::vector<double> acc((n - first_vertex) * 3, 0.0);
  for (size_t i = first_index; i + 2 < mesh.indices.size(); i += 3) {
    uint32_t a = mesh.indices[i], b = mesh.indices[i + 1], c = mesh.indices[i + 2];
    const float* p = mesh.positions.data();
    double e1[3], e2[3];
    for (int k = 0; k < 3; ++k) {
      e1[k] = double(p[3 * size_t(b) + k]) - p[3 * size_t(a) + k];
      e2[k] = double(p[3 * size_t(c) + k]) - p[3 * size_t(a) + k];
    }
    // Unnormalized cross product = area-weighted face normal.
    double nrm[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
    for (uint32_t v : {a, b, c})
      for (int k = 0; k < 3; ++k) acc[(v - first_vertex) * 3 + k] += nrm[k];
  }
  for (size_t v = first_vertex; v < n; ++v) {
    double* a = &acc[(v - first_vertex) * 3];
    double len = std::sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
    bool usable = len > 0 && std::isfinite(len);
    for (int k = 0; k < 3; ++k)
      mesh.normals[3 * v + k] = usable ? float(a[k] / len) : (k == 2 ? 1.0f : 0.0f);
  }
}

void GltfReader::append_primitive(const tinygltf::Primitive& prim, const std::string& role, Mesh& mesh,
                                  bool mesh_has_normals, bool mesh_has_uvs, uint32_t material) {
  auto pos_it = prim.attributes.find("POSITION");
  if (pos_it == prim.attributes.end()) error("MISSING_POSITION", role + " has no POSITION attribute");
  const size_t first_vertex = mesh.vertex_count();
  const size_t vcount = append_float_attribute(pos_it->second, "POSITION", TINYGLTF_TYPE_VEC3, mesh.positions,
                                               role + " POSITION");
  if (first_vertex + vcount > UINT32_MAX)
    error("MESH_TOO_LARGE", role + ": mesh exceeds 2^32-1 vertices");

  auto normal_it = prim.attributes.find("NORMAL");
  if (normal_it != prim.attributes.end()) {
    size_t n = append_float_attribute(normal_it->second, "NORMAL", TINYGLTF_TYPE_VEC3, mesh.normals,
                                      role + " NORMAL");
    if (n != vcount)
      error("ACCESSOR_COUNT_MISMATCH", role + ": NORMAL count " + std::to_string(n) + " != POSITION count " +
                                           std::to_string(vcount));
  } else if (mesh_has_normals) {
    mesh.normals.resize(mesh.positions.size(), 0.0f);  // filled after the indices are known
  }
  auto uv_it = prim.attributes.find("TEXCOORD_0");
  if (uv_it != prim.attributes.end()) {
    size_t n = append_float_attribute(uv_it->second, "TEXCOORD_0", TINYGLTF_TYPE_VEC2, mesh.uvs,
                                      role + " TEXCOORD_0");
    if (n != vcount)
      error("ACCESSOR_COUNT_MISMATCH", role + ": TEXCOORD_0 count " + std::to_string(n) +
                                           " != POSITION count " + std::to_string(vcount));
  } else if (mesh_has_uvs) {
    budget_.charge(vcount, 8, "filled uvs");
    mesh.uvs.resize(mesh.vertex_count() * 2, 0.0f);
    warn("ATTRIBUTE_FILLED", role + " has no TEXCOORD_0 while other primitives of its mesh do: uv (0,0)");
  }

  // TRIANGLES with indices decode straight into the mesh (no temporary: the 10M-triangle
  // import budget is 3x the raw data); strips and fans go through a corner list.
  const bool indexed = prim.indices >= 0;
  const size_t ncorners = indexed ? index_count(prim.indices, role + " indices") : vcount;
  size_t tris = 0;
  if (prim.mode == kGltfModeTriangles) {
    if (ncorners % 3 != 0)
      error("ACCESSOR_COUNT_MISMATCH", role + ": TRIANGLES needs a multiple of 3 corners, got " +
                                           std::to_string(ncorners));
    tris = ncorners / 3;
  } else {
    tris = ncorners >= 3 ? ncorners - 2 : 0;
  }
  budget_.charge(tris, 16, "triangles");
  std::vector<uint32_t> corners;
  if (indexed && prim.mode != kGltfModeTriangles) {
    corners.resize(ncorners);
    decode_indices(prim.indices, corners.data(), role + " indices");
  }
  const size_t first_index = mesh.indices.size();
  mesh.indices.resize(first_index + tris * 3);
  uint32_t* dst = mesh.indices.data() + first_index;
  if (indexed && prim.mode == kGltfModeTriangles) decode_indices(prim.indices, dst, role + " indices");
  const uint32_t* local = indexed ? (prim.mode == kGltfModeTriangles ? dst : corners.data()) : nullptr;
  if (local != nullptr) {
    for (size_t i = 0; i < ncorners; ++i)
      if (local[i] >= vcount)
        error("INDEX_OUT_OF_RANGE", role + ": index " + std::to_string(i) + " = " + std::to_string(local[i]) +
                                        " >= vertex count " + std::to_string(vcount));
  }
  const uint32_t base = uint32_t(first_vertex);
  auto corner = [&](size_t i) -> uint32_t { return base + (local != nullptr ? local[i] : uint32_t(i)); };
  if (prim.mode == kGltfModeTriangles) {
    if (indexed) {
      if (base != 0)
        for (size_t i = 0; i < ncorners; ++i) dst[i] += base;
    } else {
      for (size_t i = 0; i < ncorners; ++i) dst[i] = base + uint32_t(i);
    }
  } else if (prim.mode == kModeTriangleStrip) {
    // glTF 2.0 3.7.2.1: triangle i = {i, i+1+(i%2), i+2-(i%2)} keeps every triangle CCW.
    for (size_t i = 0; i < tris; ++i) {
      dst[3 * i] = corner(i);
      dst[3 * i + 1] = corner(i + 1 + (i % 2));
      dst[3 * i + 2] = corner(i + 2 - (i % 2));
    }
  } else {  // fan: {i+1, i+2, 0}
    for (size_t i = 0; i < tris; ++i) {
      dst[3 * i] = corner(i + 1);
      dst[3 * i + 1] = corner(i + 2);
      dst[3 * i + 2] = corner(0);
    }
  }
  if (mesh_has_normals && normal_it == prim.attributes.end()) {
    fill_normals(mesh, first_vertex, first_index);
    warn("ATTRIBUTE_FILLED", role + " has no NORMAL while other primitives of its mesh do: area-weighted normals");
  }
  mesh.materials.resize(mesh.triangle_count(), material);
}

void GltfReader::import_mesh(size_t gltf_mesh, Mesh& mesh) {
  const tinygltf::Mesh& src = model_.meshes[gltf_mesh];
  mesh.name = src.name.empty() ? "mesh" + std::to_string(gltf_mesh) : src.name;
  bool has_normals = false, has_uvs = false;
  for (const auto& prim : src.primitives) {
    if (prim.mode != kGltfModeTriangles && prim.mode != kModeTriangleStrip && prim.mode != kModeTriangleFan) continue;
    has_normals |= prim.attributes.count("NORMAL") > 0;
    has_uvs |= prim.attributes.count("TEXCOORD_0") > 0;
  }
  for (size_t p = 0; p < src.primitives.size(); ++p) {
    const tinygltf::Primitive& prim = src.primitives[p];
    const std::string role = "mesh " + std::to_string(gltf_mesh) + " primitive " + std::to_string(p);
    if (prim.mode == kModePoints || prim.mode == kModeLines || prim.mode == kModeLineLoop ||
        prim.mode == kModeLineStrip) {
      ++out_.stats.primitives_skipped;
      warn("PRIMITIVE_MODE_SKIPPED", role + " has mode " + std::to_string(prim.mode) + " (points/lines)");
      continue;
    }
    if (prim.mode != kGltfModeTriangles && prim.mode != kModeTriangleStrip && prim.mode != kModeTriangleFan)
      error("PRIMITIVE_MODE_INVALID", role + " has mode " + std::to_string(prim.mode) + ", not in [0, 6]");
    if (prim.extensions.count("KHR_draco_mesh_compression"))
      error("EXTENSION_UNSUPPORTED", role + " uses KHR_draco_mesh_compression, which vgeo does not decode");
    uint32_t material = default_material_;
    if (prim.material >= 0) {
      if (size_t(prim.material) >= model_.materials.size())
        error("MATERIAL_INDEX_OUT_OF_RANGE", role + " refers to material " + std::to_string(prim.material) +
                                                 " of " + std::to_string(model_.materials.size()));
      material = uint32_t(prim.material);
    } else {
      need_default_material_ = true;
    }
    if (!prim.targets.empty()) warn("MORPH_TARGETS_IGNORED", role + " has morph targets; the base shape is used");
    append_primitive(prim, role, mesh, has_normals, has_uvs, material);
  }
}

std::array<double, 16> GltfReader::local_matrix(const tinygltf::Node& node, size_t node_index) const {
  const std::string role = "node " + std::to_string(node_index);
  auto check = [&](const std::vector<double>& v, size_t n, const char* name) {
    if (!v.empty() && v.size() != n)
      error("NODE_TRANSFORM_INVALID", role + ": " + name + " has " + std::to_string(v.size()) + " values, not " +
                                          std::to_string(n));
    for (double x : v)
      if (!std::isfinite(x)) error("NODE_TRANSFORM_INVALID", role + ": " + name + " is not finite");
  };
  check(node.matrix, 16, "matrix");
  check(node.translation, 3, "translation");
  check(node.rotation, 4, "rotation");
  check(node.scale, 3, "scale");
  std::array<double, 16> m{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  if (!node.matrix.empty()) {
    for (int i = 0; i < 16; ++i) m[i] = node.matrix[i];
    // Column-major: the last row is elements 3, 7, 11, 15.
    if (std::abs(m[3]) > kAffineTolerance || std::abs(m[7]) > kAffineTolerance ||
        std::abs(m[11]) > kAffineTolerance || std::abs(m[15] - 1) > kAffineTolerance)
      error("NODE_TRANSFORM_INVALID", role + ": matrix is not affine");
    m[3] = m[7] = m[11] = 0;
    m[15] = 1;
    return m;
  }
  double t[3] = {0, 0, 0}, s[3] = {1, 1, 1}, q[4] = {0, 0, 0, 1};
  for (size_t i = 0; i < node.translation.size(); ++i) t[i] = node.translation[i];
  for (size_t i = 0; i < node.scale.size(); ++i) s[i] = node.scale[i];
  for (size_t i = 0; i < node.rotation.size(); ++i) q[i] = node.rotation[i];
  double qn = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  if (!(qn > 0)) error("NODE_TRANSFORM_INVALID", role + ": rotation quaternion has zero length");
  double x = q[0] / qn, y = q[1] / qn, z = q[2] / qn, w = q[3] / qn;
  double r[9] = {1 - 2 * (y * y + z * z), 2 * (x * y + z * w),     2 * (x * z - y * w),
                 2 * (x * y - z * w),     1 - 2 * (x * x + z * z), 2 * (y * z + x * w),
                 2 * (x * z + y * w),     2 * (y * z - x * w),     1 - 2 * (x * x + y * y)};  // column-major
  for (int c = 0; c < 3; ++c)
    for (int rr = 0; rr < 3; ++rr) m[c * 4 + rr] = r[c * 3 + rr] * s[c];
  m[12] = t[0];
  m[13] = t[1];
  m[14] = t[2];
  return m;
}

std::array<double, 16> mat_mul(const std::array<double, 16>& a, const std::array<double, 16>& b) {
  std::array<double, 16> r{};
  for (int c = 0; c < 4; ++c)
    for (int rr = 0; rr < 4; ++rr) {
      double s = 0;
      for (int k = 0; k < 4; ++k) s += a[k * 4 + rr] * b[c * 4 + k];
      r[c * 4 + rr] = s;
    }
  return r;
}

void GltfReader::run() {

  const size_t node_count = model_.nodes.size();
  // Nodes must form a forest: every node has at most one parent, children indices exist.
  std::vector<int> parent(node_count, -1);
  for (size_t n = 0; n < node_count; ++n) {
    for (int c : model_.nodes[n].children) {
      if (c < 0 || size_t(c) >= node_count)
        error("NODE_INDEX_OUT_OF_RANGE", "node " + std::to_string(n) + " has child " + std::to_string(c) + " of " +
                                             std::to_string(node_count));
      if (parent[size_t(c)] != -1 || size_t(c) == n)
        error("NODE_HIERARCHY_INVALID", "node " + std::to_string(c) + " has more than one parent (or is its own)");
      parent[size_t(c)] = int(n);
    }
  }
  // In a forest every node is reachable from a parentless node; a node that is not sits on
  // (or under) a parent cycle such as RecursiveNodes.gltf's 0 -> 1 -> 0.
  {
    std::vector<int> todo;
    std::vector<uint8_t> reached(node_count, 0);
    for (size_t n = 0; n < node_count; ++n)
      if (parent[n] == -1) todo.push_back(int(n));
    size_t reached_count = 0;
    while (!todo.empty()) {
      int n = todo.back();
      todo.pop_back();
      reached[size_t(n)] = 1;
      ++reached_count;
      for (int c : model_.nodes[size_t(n)].children) todo.push_back(c);
    }
    if (reached_count != node_count)
      for (size_t n = 0; n < node_count; ++n)
        if (!reached[n]) error("NODE_HIERARCHY_INVALID", "node " + std::to_string(n) + " is part of a parent cycle");
  }
  // Roots of the default scene.
  std::vector<int> roots;
  if (!model_.scenes.empty()) {
    int s = model_.defaultScene >= 0 ? model_.defaultScene : 0;
    if (size_t(s) >= model_.scenes.size())
      error("SCENE_INDEX_OUT_OF_RANGE", "scene " + std::to_string(s) + " of " + std::to_string(model_.scenes.size()));
    roots = model_.scenes[size_t(s)].nodes;
  } else {
    for (size_t n = 0; n < node_count; ++n)
      if (parent[n] == -1) roots.push_back(int(n));
  }
  // Depth-first flattening with an explicit stack; the forest check plus `visited` makes
  // cycles (a root reachable from itself) impossible to loop on.
  struct Item {
    int node;
    std::array<double, 16> parent_world;
  };
  std::vector<uint8_t> visited(node_count, 0);
  std::vector<std::pair<int, std::array<double, 16>>> placed;  // (gltf mesh, world)
  std::array<double, 16> identity{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  for (size_t r = roots.size(); r-- > 0;) {
    int root = roots[r];
    if (root < 0 || size_t(root) >= node_count)
      error("NODE_INDEX_OUT_OF_RANGE", "scene root " + std::to_string(root) + " of " + std::to_string(node_count));
    if (parent[size_t(root)] != -1)
      error("NODE_HIERARCHY_INVALID", "scene root node " + std::to_string(root) + " has a parent");
  }
  std::vector<Item> stack;
  for (size_t r = roots.size(); r-- > 0;) stack.push_back({roots[r], identity});
  while (!stack.empty()) {
    Item it = stack.back();
    stack.pop_back();
    if (visited[size_t(it.node)])
      error("NODE_HIERARCHY_INVALID", "node " + std::to_string(it.node) + " is reached twice (cycle or repeated root)");
    visited[size_t(it.node)] = 1;
    const tinygltf::Node& node = model_.nodes[size_t(it.node)];
    std::array<double, 16> world = mat_mul(it.parent_world, local_matrix(node, size_t(it.node)));
    if (node.mesh >= 0) {
      if (size_t(node.mesh) >= model_.meshes.size())
        error("MESH_INDEX_OUT_OF_RANGE", "node " + std::to_string(it.node) + " refers to mesh " +
                                             std::to_string(node.mesh) + " of " + std::to_string(model_.meshes.size()));
      placed.push_back({node.mesh, world});
    }
    for (size_t c = node.children.size(); c-- > 0;) stack.push_back({node.children[c], world});
  }
  // Materials 1:1, then the default one when needed (decided while reading primitives).
  default_material_ = uint32_t(model_.materials.size());
  for (size_t i = 0; i < model_.materials.size(); ++i) {
    const tinygltf::Material& src = model_.materials[i];
    Material m;
    m.name = src.name.empty() ? "material" + std::to_string(i) : src.name;
    const auto& f = src.pbrMetallicRoughness.baseColorFactor;
    if (f.size() == 4) {
      for (int k = 0; k < 4; ++k) {
        if (!std::isfinite(f[k])) error("GLTF_SCHEMA_ERROR", "material " + std::to_string(i) + " baseColorFactor is not finite");
        m.base_color[k] = float(f[k]);
      }
    } else if (!f.empty()) {
      error("GLTF_SCHEMA_ERROR", "material " + std::to_string(i) + " baseColorFactor must have 4 values");
    }
    out_.scene.materials.push_back(std::move(m));
  }

  // Meshes referenced by the scene, in glTF mesh order.
  std::vector<int> mesh_slot(model_.meshes.size(), -1);
  for (const auto& pl : placed) mesh_slot[size_t(pl.first)] = 0;
  std::vector<int> kept_slot(model_.meshes.size(), -1);
  for (size_t m = 0; m < model_.meshes.size(); ++m) {
    if (mesh_slot[m] < 0) continue;
    Mesh mesh;
    import_mesh(m, mesh);
    if (mesh.triangle_count() == 0) {
      warn("MESH_EMPTY", "mesh " + std::to_string(m) + " has no triangles; it and its instances are dropped");
      continue;
    }
    bool uniform = true;
    for (uint32_t mat : mesh.materials) uniform &= mat == mesh.materials[0];
    if (uniform && mesh.materials[0] == 0) mesh.materials.clear();
    kept_slot[m] = int(out_.scene.meshes.size());
    out_.scene.meshes.push_back(std::move(mesh));
  }
  if (need_default_material_ || out_.scene.materials.empty()) {
    Material d;
    d.name = "default";
    out_.scene.materials.push_back(d);
  }
  for (const auto& [gm, world] : placed) {
    if (kept_slot[size_t(gm)] < 0) continue;
    Instance inst;
    inst.mesh = uint32_t(kept_slot[size_t(gm)]);
    for (int i = 0; i < 16; ++i) {
      inst.transform[i] = float(world[i]);
      if (!std::isfinite(inst.transform[i]))
        error("NODE_TRANSFORM_INVALID", "world transform of an instance of mesh " + std::to_string(gm) +
                                            " is not finite in float");
    }
    out_.scene.instances.push_back(inst);
  }
}

// No file system in memory mode: any external URI is reported as missing.
bool fs_none_exists(const std::string&, void*) { return false; }
std::string fs_none_expand(const std::string& p, void*) { return p; }
bool fs_none_read(std::vector<unsigned char>*, std::string* err, const std::string& p, void*) {
  if (err) *err += "File not found : " + p + "\n";
  return false;
}
bool fs_none_write(std::string*, const std::string&, const std::vector<unsigned char>&, void*) { return false; }

// Images are irrelevant to geometry: accept them without decoding.
bool skip_image(tinygltf::Image*, const int, std::string*, std::string*, int, int, const unsigned char*, int, void*) {
  return true;
}

// Schema rules that hold everywhere in a glTF document (outside `extras`): `name` is a
// string, `extensions` is an object of objects, texture references (`index`, `texCoord`) are
// non-negative integers, `scale`/`strength` are numbers. Depth is capped to bound recursion.
constexpr int kMaxJsonDepth = 64;  // glTF's schema nests < 10 deep; deeper is hostile input

void check_json_recursive(const nlohmann::json& j, const std::string& where, int depth) {
  if (depth > kMaxJsonDepth) fail("GLTF_SCHEMA_ERROR", where, "JSON nesting deeper than " + std::to_string(kMaxJsonDepth));
  if (j.is_array()) {
    for (const auto& x : j) check_json_recursive(x, where, depth + 1);
    return;
  }
  if (!j.is_object()) return;
  for (const auto& [key, value] : j.items()) {
    if (key == "extras") continue;
    if (key == "name" && !value.is_string()) fail("GLTF_SCHEMA_ERROR", where, "'name' must be a string");
    if (key == "extensions") {
      if (!value.is_object()) fail("GLTF_SCHEMA_ERROR", where, "'extensions' must be an object");
      for (const auto& [ext, body] : value.items())
        if (!body.is_object()) fail("GLTF_SCHEMA_ERROR", where, "extension '" + ext + "' must be an object");
    }
    if ((key == "baseColorTexture" || key == "metallicRoughnessTexture" || key == "normalTexture" ||
         key == "occlusionTexture" || key == "emissiveTexture")) {
      if (!value.is_object()) fail("GLTF_SCHEMA_ERROR", where, "'" + key + "' must be an object");
      if (!value.contains("index") || !value["index"].is_number_unsigned())
        fail("GLTF_SCHEMA_ERROR", where, "'" + key + ".index' must be a non-negative integer");
      if (value.contains("texCoord") && !value["texCoord"].is_number_unsigned())
        fail("GLTF_SCHEMA_ERROR", where, "'" + key + ".texCoord' must be a non-negative integer");
      for (const char* k : {"scale", "strength"})
        if (value.contains(k) && !value[k].is_number())
          fail("GLTF_SCHEMA_ERROR", where, "'" + key + "." + k + "' must be a number");
    }
    check_json_recursive(value, where, depth + 1);
  }
}

// Classifies a tinygltf load failure into a stable code.
const char* classify_tinygltf_error(const std::string& err) {
  if (err.find("File not found") != std::string::npos || err.find("Failed to load external") != std::string::npos)
    return "EXTERNAL_BUFFER_MISSING";
  if (err.find("File size mismatch") != std::string::npos || err.find("Invalid binary data") != std::string::npos ||
      err.find("Invalid `byteLength'") != std::string::npos)
    return "BUFFER_LENGTH_MISMATCH";
  if (err.find("Failed to decode 'uri'") != std::string::npos) return "BUFFER_URI_INVALID";
  return "GLTF_SCHEMA_ERROR";
}

std::string one_line(std::string s) {
  while (!s.empty() && (s.back() == '\n' || s.back() == '\r')) s.pop_back();
  for (char& c : s)
    if (c == '\n' || c == '\r') c = ' ';
  return s;
}

}  // namespace

void import_gltf(const uint8_t* data, size_t size, std::vector<uint8_t>* owned_bytes, bool is_glb,
                 const std::string& where, const std::string& base_dir, bool allow_fs, ImportResult& out) {
  if (size > UINT32_MAX) fail("FILE_TOO_LARGE", where, "glTF input larger than 4 GiB is not supported");
  const char* json_begin = reinterpret_cast<const char*>(data);
  size_t json_size = size;
  size_t glb_length = size;
  if (is_glb) {
    if (size < kGlbHeaderBytes + kGlbChunkHeaderBytes)
      fail("GLB_TRUNCATED", where, "GLB is " + std::to_string(size) + " bytes, shorter than its headers");
    if (load_le32(data) != kGlbMagic) fail("GLB_HEADER_INVALID", where, "GLB magic is not 'glTF'");
    if (load_le32(data + 4) != kGlbVersion)
      fail("GLB_VERSION_UNSUPPORTED", where, "GLB version " + std::to_string(load_le32(data + 4)) + " (only 2)");
    glb_length = load_le32(data + 8);
    if (glb_length > size)
      fail("GLB_TRUNCATED", where, "GLB header length " + std::to_string(glb_length) + " > file size " +
                                       std::to_string(size));
    if (glb_length < size)
      fail("GLB_HEADER_INVALID", where, "GLB header length " + std::to_string(glb_length) + " < file size " +
                                            std::to_string(size) + " (trailing bytes)");
    const uint32_t json_len = load_le32(data + 12);
    if (load_le32(data + 16) != kGlbChunkJson) fail("GLB_HEADER_INVALID", where, "first GLB chunk is not JSON");
    if (json_len > size - kGlbHeaderBytes - kGlbChunkHeaderBytes)
      fail("GLB_TRUNCATED", where, "JSON chunk of " + std::to_string(json_len) + " bytes exceeds the file");
    size_t pos = kGlbHeaderBytes + kGlbChunkHeaderBytes + json_len;
    json_begin = reinterpret_cast<const char*>(data + kGlbHeaderBytes + kGlbChunkHeaderBytes);
    json_size = json_len;
    if (pos < size) {
      if (size - pos < kGlbChunkHeaderBytes) fail("GLB_TRUNCATED", where, "truncated chunk header after JSON");
      const uint32_t bin_len = load_le32(data + pos);
      if (load_le32(data + pos + 4) != kGlbChunkBin)
        fail("GLB_HEADER_INVALID", where, "second GLB chunk is not BIN");
      if (bin_len > size - pos - kGlbChunkHeaderBytes)
        fail("GLB_TRUNCATED", where, "BIN chunk of " + std::to_string(bin_len) + " bytes exceeds the file");
      // Anything after the BIN chunk is an unknown chunk; glTF says to ignore those.
    }
  }
  // Our own JSON parse first: a syntax error gets its own code, independent of tinygltf's text.
  {
    nlohmann::json doc = nlohmann::json::parse(json_begin, json_begin + json_size, nullptr, false);
    if (doc.is_discarded()) fail("GLTF_PARSE_ERROR", where, "the glTF JSON is not valid JSON");
    if (!doc.is_object()) fail("GLTF_PARSE_ERROR", where, "the glTF JSON is not an object");
    // Type checks tinygltf 2.7 silently skips: a wrongly typed field is ignored there, which
    // would import a different scene than the file describes.
    auto need = [&](bool ok, const std::string& what) {
      if (!ok) fail("GLTF_SCHEMA_ERROR", where, what);
    };
    if (doc.contains("scene")) need(doc["scene"].is_number_unsigned(), "'scene' must be a non-negative integer");
    for (const char* key : {"scenes", "nodes", "meshes", "accessors", "bufferViews", "buffers", "materials"})
      if (doc.contains(key)) need(doc[key].is_array(), std::string("'") + key + "' must be an array");
    if (doc.contains("meshes"))
      for (const auto& m : doc["meshes"]) {
        need(m.is_object(), "each mesh must be an object");
        need(m.contains("primitives") && m["primitives"].is_array(), "mesh 'primitives' must be an array");
        if (m.contains("name")) need(m["name"].is_string(), "mesh 'name' must be a string");
        for (const auto& p : m["primitives"]) {
          need(p.is_object() && p.contains("attributes") && p["attributes"].is_object(),
               "primitive 'attributes' must be an object");
          for (const char* k : {"indices", "material", "mode"})
            if (p.contains(k)) need(p[k].is_number_unsigned(), std::string("primitive '") + k + "' must be a non-negative integer");
          for (const auto& [name, idx] : p["attributes"].items())
            need(idx.is_number_unsigned(), "attribute '" + name + "' must be a non-negative integer");
        }
      }
    if (doc.contains("materials"))
      for (const auto& m : doc["materials"]) {
        need(m.is_object(), "each material must be an object");
        if (m.contains("name")) need(m["name"].is_string(), "material 'name' must be a string");
      }
    if (doc.contains("nodes"))
      for (const auto& n : doc["nodes"]) {
        need(n.is_object(), "each node must be an object");
        if (n.contains("mesh")) need(n["mesh"].is_number_unsigned(), "node 'mesh' must be a non-negative integer");
        if (n.contains("children")) need(n["children"].is_array(), "node 'children' must be an array");
      }
    if (doc.contains("accessors"))
      for (const auto& a : doc["accessors"]) {
        need(a.is_object(), "each accessor must be an object");
        if (a.contains("count")) need(a["count"].is_number_unsigned(), "accessor 'count' must be a non-negative integer");
        if (a.contains("byteOffset"))
          need(a["byteOffset"].is_number_unsigned(), "accessor 'byteOffset' must be a non-negative integer");
      }
    if (doc.contains("bufferViews"))
      for (const auto& v : doc["bufferViews"]) {
        need(v.is_object(), "each bufferView must be an object");
        for (const char* k : {"buffer", "byteOffset", "byteLength", "byteStride"})
          if (v.contains(k)) need(v[k].is_number_unsigned(), std::string("bufferView '") + k + "' must be a non-negative integer");
      }
    if (doc.contains("materials"))
      for (const auto& m : doc["materials"]) {
        if (m.contains("pbrMetallicRoughness")) {
          const auto& pbr = m["pbrMetallicRoughness"];
          need(pbr.is_object(), "material 'pbrMetallicRoughness' must be an object");
          if (pbr.contains("baseColorFactor")) {
            const auto& f = pbr["baseColorFactor"];
            need(f.is_array() && f.size() == 4, "'baseColorFactor' must be an array of 4 numbers");
            for (const auto& x : f) need(x.is_number(), "'baseColorFactor' must be an array of 4 numbers");
          }
          for (const char* k : {"metallicFactor", "roughnessFactor"})
            if (pbr.contains(k)) need(pbr[k].is_number(), std::string("'") + k + "' must be a number");
        }
      }
    if (doc.contains("extensionsRequired")) need(doc["extensionsRequired"].is_array(), "'extensionsRequired' must be an array");
    if (doc.contains("extensionsUsed")) need(doc["extensionsUsed"].is_array(), "'extensionsUsed' must be an array");
    check_json_recursive(doc, where, 0);
    // Before tinygltf: it rejects e.g. Draco-only accessors with a less specific message.
    if (doc.contains("extensionsRequired"))
      for (const auto& e : doc["extensionsRequired"]) {
        need(e.is_string(), "'extensionsRequired' entries must be strings");
        if (!kIgnorableRequiredExtensions.count(e.get<std::string>()))
          fail("EXTENSION_UNSUPPORTED", where, "required extension " + e.get<std::string>() + " is not supported");
      }
  }

  tinygltf::TinyGLTF loader;
  loader.SetImageLoader(skip_image, nullptr);
  if (!allow_fs) loader.SetFsCallbacks(tinygltf::FsCallbacks{fs_none_exists, fs_none_expand, fs_none_read, fs_none_write, nullptr});
  tinygltf::Model model;
  std::string err, warn;
  bool ok = is_glb ? loader.LoadBinaryFromMemory(&model, &err, &warn, data, unsigned(glb_length), base_dir)
                   : loader.LoadASCIIFromString(&model, &err, &warn, json_begin, unsigned(json_size), base_dir);
  if (!ok) fail(classify_tinygltf_error(err), where, "tinygltf: " + one_line(err));
  if (owned_bytes != nullptr) std::vector<uint8_t>().swap(*owned_bytes);

  uint64_t input_bytes = size;
  for (const auto& b : model.buffers) input_bytes += b.uri.empty() || b.uri.rfind("data:", 0) == 0 ? 0 : b.data.size();
  GltfReader reader(model, where, input_bytes, out);
  reader.run();
}

}  // namespace vgeo::detail
