// Hand-made glTF/GLB files in memory: every accessor encoding the importer supports, the
// node hierarchy, and one file per error code (spec/errors.md, "Import").
#include <gtest/gtest.h>
#include <rapidcheck/gtest.h>

#include <cmath>
#include <cstring>
#include <functional>
#include <limits>
#include <nlohmann/json.hpp>

#include "vgeo/mesh/import.h"

using nlohmann::json;

namespace {

constexpr int kFloat = 5126, kUByte = 5121, kByte = 5120, kUShort = 5123, kShort = 5122, kUInt = 5125;

// Builds a glTF document with one binary buffer; emits GLB or .gltf with a data: URI.
struct GltfBuilder {
  json j;
  std::vector<uint8_t> bin;
  size_t buffer_length_override = 0;  // 0: the real BIN size

  GltfBuilder() {
    j["asset"] = {{"version", "2.0"}};
    j["bufferViews"] = json::array();
    j["accessors"] = json::array();
    j["meshes"] = json::array();
    j["nodes"] = json::array();
    j["scenes"] = json::array({json{{"nodes", json::array()}}});
    j["scene"] = 0;
  }
  int add_view(const void* data, size_t bytes, size_t stride = 0) {
    while (bin.size() % 4) bin.push_back(0);
    json v = {{"buffer", 0}, {"byteOffset", bin.size()}, {"byteLength", bytes}};
    if (stride) v["byteStride"] = stride;
    const uint8_t* p = static_cast<const uint8_t*>(data);
    bin.insert(bin.end(), p, p + bytes);
    j["bufferViews"].push_back(v);
    return int(j["bufferViews"].size()) - 1;
  }
  int add_accessor(int view, int ctype, size_t count, const char* type, bool normalized = false, size_t offset = 0) {
    json a = {{"componentType", ctype}, {"count", count}, {"type", type}};
    if (view >= 0) a["bufferView"] = view;
    if (offset) a["byteOffset"] = offset;
    if (normalized) a["normalized"] = true;
    j["accessors"].push_back(a);
    return int(j["accessors"].size()) - 1;
  }
  template <class T>
  int add_data(const std::vector<T>& v, int ctype, const char* type, bool normalized = false) {
    int view = add_view(v.data(), v.size() * sizeof(T));
    size_t comps = std::string(type) == "SCALAR" ? 1 : std::string(type) == "VEC2" ? 2 : std::string(type) == "VEC3" ? 3 : 4;
    return add_accessor(view, ctype, v.size() / comps, type, normalized);
  }
  int add_mesh(json primitives) {
    j["meshes"].push_back({{"primitives", primitives}});
    return int(j["meshes"].size()) - 1;
  }
  int add_node(json node, bool root = true) {
    j["nodes"].push_back(node);
    int id = int(j["nodes"].size()) - 1;
    if (root) j["scenes"][0]["nodes"].push_back(id);
    return id;
  }
  std::vector<uint8_t> glb() const {
    json doc = j;
    doc["buffers"] = json::array({json{{"byteLength", buffer_length_override ? buffer_length_override : bin.size()}}});
    std::string text = doc.dump();
    while (text.size() % 4) text.push_back(' ');
    std::vector<uint8_t> b(bin);
    while (b.size() % 4) b.push_back(0);
    std::vector<uint8_t> out;
    auto u32 = [&](uint32_t v) {
      for (int i = 0; i < 4; ++i) out.push_back(uint8_t(v >> (8 * i)));
    };
    u32(0x46546C67);
    u32(2);
    u32(uint32_t(12 + 8 + text.size() + 8 + b.size()));
    u32(uint32_t(text.size()));
    u32(0x4E4F534A);
    out.insert(out.end(), text.begin(), text.end());
    u32(uint32_t(b.size()));
    u32(0x004E4942);
    out.insert(out.end(), b.begin(), b.end());
    return out;
  }
  std::string gltf() const {
    static const char* kAlphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    std::string b64;
    for (size_t i = 0; i < bin.size(); i += 3) {
      uint32_t v = uint32_t(bin[i]) << 16 | (i + 1 < bin.size() ? uint32_t(bin[i + 1]) << 8 : 0) |
                   (i + 2 < bin.size() ? bin[i + 2] : 0);
      b64 += kAlphabet[(v >> 18) & 63];
      b64 += kAlphabet[(v >> 12) & 63];
      b64 += i + 1 < bin.size() ? kAlphabet[(v >> 6) & 63] : '=';
      b64 += i + 2 < bin.size() ? kAlphabet[v & 63] : '=';
    }
    json doc = j;
    doc["buffers"] = json::array({json{{"byteLength", bin.size()}, {"uri", "data:application/octet-stream;base64," + b64}}});
    return doc.dump();
  }
};

vgeo::ImportResult import_glb(const GltfBuilder& b, const vgeo::ImportOptions& o = {}) {
  auto bytes = b.glb();
  return vgeo::import_scene_from_memory(bytes.data(), bytes.size(), "test.glb", o);
}
vgeo::ImportResult import_gltf(const GltfBuilder& b) {
  std::string text = b.gltf();
  return vgeo::import_scene_from_memory(reinterpret_cast<const uint8_t*>(text.data()), text.size(), "test.gltf");
}

std::string error_code_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const vgeo::VgeoError& e) {
    EXPECT_EQ(e.error().line().find('\n'), std::string::npos);
    EXPECT_NE(e.error().exit_code, 0);
    return e.error().code;
  }
  return "OK";
}

// Unit quad in the z=0 plane: 4 vertices, CCW seen from +z.
const std::vector<float> kQuad = {0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0};

GltfBuilder quad_builder(int index_ctype = kUShort) {
  GltfBuilder b;
  int pos = b.add_data(kQuad, kFloat, "VEC3");
  int idx;
  if (index_ctype == kUByte) idx = b.add_data(std::vector<uint8_t>{0, 1, 2, 2, 1, 3}, kUByte, "SCALAR");
  else if (index_ctype == kUShort) idx = b.add_data(std::vector<uint16_t>{0, 1, 2, 2, 1, 3}, kUShort, "SCALAR");
  else idx = b.add_data(std::vector<uint32_t>{0, 1, 2, 2, 1, 3}, kUInt, "SCALAR");
  b.add_mesh(json::array({json{{"attributes", {{"POSITION", pos}}}, {"indices", idx}}}));
  b.add_node({{"mesh", 0}});
  return b;
}

}  // namespace

TEST(ImportGltf, IndexedQuadAllIndexComponentTypes) {
  for (int ct : {kUByte, kUShort, kUInt}) {
    SCOPED_TRACE(ct);
    auto r = import_glb(quad_builder(ct));
    ASSERT_EQ(r.scene.meshes.size(), 1u);
    const auto& m = r.scene.meshes[0];
    EXPECT_EQ(m.vertex_count(), 4u);
    EXPECT_EQ(m.indices, (std::vector<uint32_t>{0, 1, 2, 2, 1, 3}));
    EXPECT_EQ(m.positions, kQuad);
    EXPECT_EQ(r.scene.instances.size(), 1u);
    EXPECT_EQ(r.scene.materials.size(), 1u);  // the default
  }
}

TEST(ImportGltf, GltfWithDataUriEqualsGlb) {
  auto a = import_glb(quad_builder());
  auto b = import_gltf(quad_builder());
  EXPECT_EQ(a.scene.meshes[0].positions, b.scene.meshes[0].positions);
  EXPECT_EQ(a.scene.meshes[0].indices, b.scene.meshes[0].indices);
}

TEST(ImportGltf, NonIndexedStripAndFanFollowGltfWinding) {
  // Strip 0,1,2,3 -> {0,1,2}, {1,3,2} (glTF: i, i+1+(i%2), i+2-(i%2)); fan -> {1,2,0}, {2,3,0}.
  for (int mode : {4, 5, 6}) {
    GltfBuilder b;
    std::vector<float> pos = mode == 4 ? std::vector<float>{0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 1, 0, 1, 0, 0, 1, 1, 0} : kQuad;
    if (mode == 6) pos = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};
    int p = b.add_data(pos, kFloat, "VEC3");
    b.add_mesh(json::array({json{{"attributes", {{"POSITION", p}}}, {"mode", mode}}}));
    b.add_node({{"mesh", 0}});
    auto r = import_glb(b);
    const auto& idx = r.scene.meshes[0].indices;
    if (mode == 4) {
      EXPECT_EQ(idx, (std::vector<uint32_t>{0, 1, 2, 3, 4, 5}));
    }
    if (mode == 5) {
      EXPECT_EQ(idx, (std::vector<uint32_t>{0, 1, 2, 1, 3, 2}));
    }
    if (mode == 6) {
      EXPECT_EQ(idx, (std::vector<uint32_t>{1, 2, 0, 2, 3, 0}));
    }
  }
}

TEST(ImportGltf, IndexedStripUsesIndexValues) {
  GltfBuilder b;
  int p = b.add_data(kQuad, kFloat, "VEC3");
  int i = b.add_data(std::vector<uint8_t>{3, 2, 1, 0}, kUByte, "SCALAR");
  b.add_mesh(json::array({json{{"attributes", {{"POSITION", p}}}, {"indices", i}, {"mode", 5}}}));
  b.add_node({{"mesh", 0}});
  EXPECT_EQ(import_glb(b).scene.meshes[0].indices, (std::vector<uint32_t>{3, 2, 1, 2, 0, 1}));
}

TEST(ImportGltf, NormalizedIntegersDecodePerSpec) {
  GltfBuilder b;
  b.j["extensionsUsed"] = {"KHR_mesh_quantization"};
  // POSITION as unnormalized shorts (quantization), NORMAL as normalized bytes, UV as
  // normalized ubytes; -128 clamps to -1.
  std::vector<int16_t> pos = {0, 0, 0, 2, 0, 0, 0, 2, 0};
  std::vector<int8_t> nrm = {0, 0, 127, 0, 0, -128, 0, 0, 127};
  std::vector<uint8_t> uv = {0, 255, 255, 0, 51, 102};
  int p = b.add_view(pos.data(), pos.size() * 2);
  int pa = b.add_accessor(p, kShort, 3, "VEC3");
  int n = b.add_view(nrm.data(), nrm.size(), 4);  // stride 4: padded VEC3 bytes
  (void)n;
  // Re-lay normals with padding to satisfy the 4-byte stride.
  std::vector<int8_t> nrm_padded = {0, 0, 127, 0, 0, 0, -128, 0, 0, 0, 127, 0};
  int nv = b.add_view(nrm_padded.data(), nrm_padded.size(), 4);
  int na = b.add_accessor(nv, kByte, 3, "VEC3", true);
  std::vector<uint8_t> uv_padded = {0, 255, 0, 0, 255, 0, 0, 0, 51, 102, 0, 0};
  int uvv = b.add_view(uv_padded.data(), uv_padded.size(), 4);
  int ua = b.add_accessor(uvv, kUByte, 3, "VEC2", true);
  b.add_mesh(json::array({json{{"attributes", {{"POSITION", pa}, {"NORMAL", na}, {"TEXCOORD_0", ua}}}}}));
  b.add_node({{"mesh", 0}});
  auto r = import_glb(b);
  const auto& m = r.scene.meshes[0];
  EXPECT_EQ(m.positions, (std::vector<float>{0, 0, 0, 2, 0, 0, 0, 2, 0}));
  EXPECT_EQ(m.normals, (std::vector<float>{0, 0, 1, 0, 0, -1, 0, 0, 1}));
  ASSERT_EQ(m.uvs.size(), 6u);
  EXPECT_EQ(m.uvs[0], 0.0f);
  EXPECT_EQ(m.uvs[1], 1.0f);
  EXPECT_FLOAT_EQ(m.uvs[4], 0.2f);
  EXPECT_FLOAT_EQ(m.uvs[5], 0.4f);
  (void)uv;
}

TEST(ImportGltf, InterleavedByteStride) {
  GltfBuilder b;
  // position (3 floats) + uv (2 floats) per vertex, stride 20.
  std::vector<float> inter = {0, 0, 0, 0.1f, 0.2f, 1, 0, 0, 0.3f, 0.4f, 0, 1, 0, 0.5f, 0.6f};
  int v = b.add_view(inter.data(), inter.size() * 4, 20);
  int pa = b.add_accessor(v, kFloat, 3, "VEC3");
  int ua = b.add_accessor(v, kFloat, 3, "VEC2", false, 12);
  b.add_mesh(json::array({json{{"attributes", {{"POSITION", pa}, {"TEXCOORD_0", ua}}}}}));
  b.add_node({{"mesh", 0}});
  auto m = import_glb(b).scene.meshes[0];
  EXPECT_EQ(m.positions, (std::vector<float>{0, 0, 0, 1, 0, 0, 0, 1, 0}));
  EXPECT_EQ(m.uvs, (std::vector<float>{0.1f, 0.2f, 0.3f, 0.4f, 0.5f, 0.6f}));
}

TEST(ImportGltf, SparseAccessorsOverrideBaseAndZeroes) {
  for (bool with_base : {true, false}) {
    SCOPED_TRACE(with_base);
    GltfBuilder b;
    std::vector<float> base = {0, 0, 0, 5, 5, 5, 0, 1, 0};
    int bv = with_base ? b.add_view(base.data(), base.size() * 4) : -1;
    int pa = b.add_accessor(bv, kFloat, 3, "VEC3");
    std::vector<uint16_t> where = {1};
    std::vector<float> values = {1, 0, 0};
    int iv = b.add_view(where.data(), 2);
    int vv = b.add_view(values.data(), 12);
    b.j["accessors"][pa]["sparse"] = {{"count", 1},
                                      {"indices", {{"bufferView", iv}, {"componentType", kUShort}}},
                                      {"values", {{"bufferView", vv}}}};
    b.add_mesh(json::array({json{{"attributes", {{"POSITION", pa}}}}}));
    b.add_node({{"mesh", 0}});
    if (with_base) {
      EXPECT_EQ(import_glb(b).scene.meshes[0].positions, (std::vector<float>{0, 0, 0, 1, 0, 0, 0, 1, 0}));
    } else {
      // Without a bufferView, the two other vertices are zero: a degenerate triangle.
      EXPECT_EQ(error_code_of([&] { import_glb(b); }), "MESH_EMPTY");
    }
  }
}

TEST(ImportGltf, SparseIndices) {
  GltfBuilder b = quad_builder(kUShort);
  std::vector<uint8_t> where = {5};
  std::vector<uint16_t> values = {0};
  int iv = b.add_view(where.data(), 1);
  int vv = b.add_view(values.data(), 2);
  b.j["accessors"][1]["sparse"] = {{"count", 1},
                                   {"indices", {{"bufferView", iv}, {"componentType", kUByte}}},
                                   {"values", {{"bufferView", vv}}}};
  // Triangle 1 becomes {2,1,0}.
  EXPECT_EQ(import_glb(b).scene.meshes[0].indices, (std::vector<uint32_t>{0, 1, 2, 2, 1, 0}));
}

TEST(ImportGltf, HierarchyFlattensToWorldTransformsAndReusesMeshes) {
  GltfBuilder b = quad_builder();
  // Node 1: translate (10,0,0) with children [2]; node 2: scale 2 + mesh 0.
  b.j["nodes"].push_back({{"translation", {10, 0, 0}}, {"children", {2}}});
  b.j["nodes"].push_back({{"scale", {2, 2, 2}}, {"mesh", 0}});
  b.j["scenes"][0]["nodes"].push_back(1);
  auto r = import_glb(b);
  ASSERT_EQ(r.scene.meshes.size(), 1u);
  ASSERT_EQ(r.scene.instances.size(), 2u);
  EXPECT_EQ(r.scene.instances[0].mesh, 0u);
  EXPECT_EQ(r.scene.instances[1].mesh, 0u);
  const auto& t = r.scene.instances[1].transform;
  EXPECT_EQ(t[0], 2.0f);
  EXPECT_EQ(t[5], 2.0f);
  EXPECT_EQ(t[12], 10.0f);
  EXPECT_EQ(t[15], 1.0f);
}

TEST(ImportGltf, RotationQuaternionAndMatrix) {
  GltfBuilder b = quad_builder();
  // 90 degrees about z: x axis -> y axis.
  b.j["nodes"][0]["rotation"] = {0, 0, std::sqrt(0.5), std::sqrt(0.5)};
  b.j["nodes"].push_back({{"matrix", {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 4, 5, 6, 1}}, {"mesh", 0}});
  b.j["scenes"][0]["nodes"].push_back(1);
  auto r = import_glb(b);
  const auto& t = r.scene.instances[0].transform;
  EXPECT_NEAR(t[0], 0.0f, 1e-6);
  EXPECT_NEAR(t[1], 1.0f, 1e-6);
  EXPECT_NEAR(t[4], -1.0f, 1e-6);
  EXPECT_EQ(r.scene.instances[1].transform[13], 5.0f);
}

TEST(ImportGltf, PrimitivesMergeWithPerTriangleMaterialsAndFilledAttributes) {
  GltfBuilder b;
  int p0 = b.add_data(std::vector<float>{0, 0, 0, 1, 0, 0, 0, 1, 0}, kFloat, "VEC3");
  int n0 = b.add_data(std::vector<float>{0, 0, 1, 0, 0, 1, 0, 0, 1}, kFloat, "VEC3");
  int p1 = b.add_data(std::vector<float>{0, 0, 1, 0, 1, 1, 1, 0, 1}, kFloat, "VEC3");  // CW from +z: normal -z
  b.j["materials"] = json::array({json{{"name", "red"}, {"pbrMetallicRoughness", {{"baseColorFactor", {1, 0, 0, 1}}}}}});
  b.add_mesh(json::array({json{{"attributes", {{"POSITION", p0}, {"NORMAL", n0}}}, {"material", 0}},
                          json{{"attributes", {{"POSITION", p1}}}},
                          json{{"attributes", {{"POSITION", p1}}}, {"mode", 1}}}));
  b.add_node({{"mesh", 0}});
  auto r = import_glb(b);
  const auto& m = r.scene.meshes[0];
  EXPECT_EQ(m.triangle_count(), 2u);
  EXPECT_EQ(m.vertex_count(), 6u);
  ASSERT_EQ(r.scene.materials.size(), 2u);
  EXPECT_EQ(r.scene.materials[0].name, "red");
  EXPECT_EQ(r.scene.materials[0].base_color[0], 1.0f);
  EXPECT_EQ(r.scene.materials[1].name, "default");
  EXPECT_EQ(m.materials, (std::vector<uint32_t>{0, 1}));
  ASSERT_EQ(m.normals.size(), 18u);
  for (int v = 3; v < 6; ++v) EXPECT_EQ(m.normals[3 * v + 2], -1.0f);
  EXPECT_EQ(r.stats.primitives_skipped, 1u);
  int filled = 0, skipped = 0;
  for (const auto& w : r.warnings) {
    filled += w.code == "ATTRIBUTE_FILLED";
    skipped += w.code == "PRIMITIVE_MODE_SKIPPED";
  }
  EXPECT_EQ(filled, 1);
  EXPECT_EQ(skipped, 1);
}

TEST(ImportGltf, UnreferencedMeshesAreNotImported) {
  GltfBuilder b = quad_builder();
  b.add_mesh(b.j["meshes"][0]["primitives"]);  // mesh 1, no node
  auto r = import_glb(b);
  EXPECT_EQ(r.scene.meshes.size(), 1u);
}

// ---- one hand-made file per error code ----
struct ErrorCase {
  const char* code;
  std::function<void(GltfBuilder&)> edit;
};

TEST(ImportGltf, EachErrorCodeFromAMinimalFile) {
  const float inf = std::numeric_limits<float>::infinity();
  const std::vector<ErrorCase> cases = {
      {"BUFFER_VIEW_OUT_OF_RANGE", [](GltfBuilder& b) { b.j["bufferViews"][0]["byteLength"] = 4096; }},
      {"BUFFER_VIEW_OUT_OF_RANGE", [](GltfBuilder& b) { b.j["bufferViews"][0]["byteOffset"] = 1u << 30; }},
      {"BUFFER_VIEW_STRIDE_INVALID", [](GltfBuilder& b) { b.j["bufferViews"][0]["byteStride"] = 4; }},
      {"ACCESSOR_OUT_OF_RANGE", [](GltfBuilder& b) { b.j["accessors"][0]["count"] = 5; }},
      {"ACCESSOR_OUT_OF_RANGE", [](GltfBuilder& b) { b.j["accessors"][1]["byteOffset"] = 4; }},
      {"ACCESSOR_TYPE_INVALID", [](GltfBuilder& b) { b.j["accessors"][0]["type"] = "VEC2"; }},
      {"ACCESSOR_TYPE_INVALID", [](GltfBuilder& b) { b.j["accessors"][0]["componentType"] = kUShort; }},
      {"ACCESSOR_TYPE_INVALID", [](GltfBuilder& b) { b.j["accessors"][1]["componentType"] = kFloat; }},
      {"ACCESSOR_TYPE_INVALID", [](GltfBuilder& b) { b.j["accessors"][1]["type"] = "VEC2"; }},
      {"ACCESSOR_COUNT_MISMATCH", [](GltfBuilder& b) { b.j["accessors"][1]["count"] = 5; }},
      {"ACCESSOR_COUNT_MISMATCH",
       [](GltfBuilder& b) {
         int n = b.add_data(std::vector<float>{0, 0, 1, 0, 0, 1}, kFloat, "VEC3");
         b.j["meshes"][0]["primitives"][0]["attributes"]["NORMAL"] = n;
       }},
      {"ACCESSOR_SPARSE_INVALID",
       [](GltfBuilder& b) {
         std::vector<uint8_t> where = {9};
         int iv = b.add_view(where.data(), 1);
         b.j["accessors"][0]["sparse"] = {{"count", 1},
                                          {"indices", {{"bufferView", iv}, {"componentType", kUByte}}},
                                          {"values", {{"bufferView", 0}}}};
       }},
      {"ACCESSOR_INDEX_OUT_OF_RANGE", [](GltfBuilder& b) { b.j["meshes"][0]["primitives"][0]["attributes"]["NORMAL"] = 17; }},
      {"MISSING_POSITION",
       [](GltfBuilder& b) {
         auto& a = b.j["meshes"][0]["primitives"][0]["attributes"];
         a["NORMAL"] = a["POSITION"];
         a.erase("POSITION");
       }},
      {"INDEX_OUT_OF_RANGE",
       [](GltfBuilder& b) {
         uint16_t four = 4;
         std::memcpy(&b.bin[48 + 4], &four, 2);
       }},
      {"POSITION_NOT_FINITE", [inf](GltfBuilder& b) { std::memcpy(&b.bin[4], &inf, 4); }},
      {"ATTRIBUTE_NOT_FINITE",
       [inf](GltfBuilder& b) {
         int u = b.add_data(std::vector<float>{0, 0, 0, 0, 0, inf, 0, 0}, kFloat, "VEC2");
         b.j["meshes"][0]["primitives"][0]["attributes"]["TEXCOORD_0"] = u;
       }},
      {"PRIMITIVE_MODE_INVALID", [](GltfBuilder& b) { b.j["meshes"][0]["primitives"][0]["mode"] = 7; }},
      {"MATERIAL_INDEX_OUT_OF_RANGE", [](GltfBuilder& b) { b.j["meshes"][0]["primitives"][0]["material"] = 3; }},
      {"GLTF_SCHEMA_ERROR",
       [](GltfBuilder& b) {
         b.j["materials"] = json::array({json{{"pbrMetallicRoughness", {{"baseColorFactor", {1, 0, 0}}}}}});
       }},
      {"MESH_INDEX_OUT_OF_RANGE", [](GltfBuilder& b) { b.j["nodes"][0]["mesh"] = 4; }},
      {"NODE_INDEX_OUT_OF_RANGE", [](GltfBuilder& b) { b.j["scenes"][0]["nodes"].push_back(9); }},
      {"NODE_INDEX_OUT_OF_RANGE", [](GltfBuilder& b) { b.j["nodes"][0]["children"] = {5}; }},
      {"NODE_HIERARCHY_INVALID",
       [](GltfBuilder& b) {
         b.j["nodes"].push_back({{"children", {0}}});
         b.j["nodes"].push_back({{"children", {0}}});
       }},
      {"NODE_HIERARCHY_INVALID", [](GltfBuilder& b) { b.j["scenes"][0]["nodes"].push_back(0); }},
      {"NODE_HIERARCHY_INVALID", [](GltfBuilder& b) { b.j["nodes"][0]["children"] = {0}; }},
      {"NODE_TRANSFORM_INVALID", [](GltfBuilder& b) { b.j["nodes"][0]["matrix"] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0.5, 0, 0, 0, 1}; }},
      {"NODE_TRANSFORM_INVALID", [](GltfBuilder& b) { b.j["nodes"][0]["rotation"] = {0, 0, 0, 0}; }},
      {"NODE_TRANSFORM_INVALID", [](GltfBuilder& b) { b.j["nodes"][0]["scale"] = {1e30, 1e30, 1e30}; b.j["nodes"].push_back({{"scale", {1e30, 1e30, 1e30}}, {"children", {0}}}); b.j["scenes"][0]["nodes"] = {1}; }},
      {"SCENE_INDEX_OUT_OF_RANGE", [](GltfBuilder& b) { b.j["scene"] = 3; }},
      {"MESH_EMPTY", [](GltfBuilder& b) { b.j["meshes"][0]["primitives"][0]["mode"] = 0; }},
      {"MESH_EMPTY", [](GltfBuilder& b) { b.j["scenes"][0]["nodes"] = json::array(); }},
      {"MESH_EMPTY",
       [](GltfBuilder& b) {
         std::vector<float> zero(12, 0.0f);
         std::memcpy(b.bin.data(), zero.data(), 48);
       }},
      {"EXTENSION_UNSUPPORTED", [](GltfBuilder& b) { b.j["extensionsRequired"] = {"KHR_draco_mesh_compression"}; }},
      {"BUFFER_VIEW_INDEX_OUT_OF_RANGE", [](GltfBuilder& b) { b.j["accessors"][0]["bufferView"] = 9; }},
      {"BUFFER_VIEW_INDEX_OUT_OF_RANGE",
       [](GltfBuilder& b) {
         std::vector<uint8_t> where = {1};
         int iv = b.add_view(where.data(), 1);
         b.j["accessors"][0]["sparse"] = {{"count", 1},
                                          {"indices", {{"bufferView", iv}, {"componentType", kUByte}}},
                                          {"values", {{"bufferView", 42}}}};
       }},
      {"BUFFER_INDEX_OUT_OF_RANGE", [](GltfBuilder& b) { b.j["bufferViews"][0]["buffer"] = 3; }},
      {"ACCESSOR_COUNT_INVALID", [](GltfBuilder& b) { b.j["accessors"][0]["count"] = 0; }},
      {"GLTF_SCHEMA_ERROR", [](GltfBuilder& b) { b.j["meshes"][0]["primitives"] = json::object(); }},
      {"GLTF_SCHEMA_ERROR", [](GltfBuilder& b) { b.j["nodes"][0]["name"] = 3; }},
      {"GLTF_SCHEMA_ERROR", [](GltfBuilder& b) { b.j["accessors"][0]["count"] = -1; }},
      {"INPUT_EXPANSION_LIMIT",
       [](GltfBuilder& b) {
         // A bufferView-less accessor costs no bytes in the file; its count is not a licence to allocate.
         b.j["accessors"][0].erase("bufferView");
         b.j["accessors"][0]["count"] = 1000000000;
         b.j["meshes"][0]["primitives"][0].erase("indices");
       }},
      {"INPUT_EXPANSION_LIMIT",
       [](GltfBuilder& b) {
         // count * 12 overflows 64 bits if multiplied naively.
         b.j["accessors"][0].erase("bufferView");
         b.j["accessors"][0]["count"] = uint64_t(1) << 62;
         b.j["meshes"][0]["primitives"][0].erase("indices");
       }},
  };
  for (const auto& c : cases) {
    GltfBuilder b = quad_builder();
    c.edit(b);
    std::vector<uint8_t> glb;
    glb = b.glb();
    SCOPED_TRACE(std::string(c.code) + " " + b.j.dump().substr(0, 400));
    EXPECT_EQ(error_code_of([&] { vgeo::import_scene_from_memory(glb.data(), glb.size(), "case.glb"); }), c.code);
  }
}

TEST(ImportGltf, ExternalBufferIsMissingInMemoryMode) {
  json doc = json::parse(quad_builder().gltf());
  doc["buffers"][0]["uri"] = "quad.bin";
  const std::string text = doc.dump();
  EXPECT_EQ(error_code_of([&] {
              vgeo::import_scene_from_memory(reinterpret_cast<const uint8_t*>(text.data()), text.size(), "x.gltf");
            }),
            "EXTERNAL_BUFFER_MISSING");
}

TEST(ImportGltf, NumberOutsideDoubleRangeIsAParseError) {
  // JSON has no infinity literal; 1e400 overflows double and is rejected by the JSON parser,
  // so no non-finite number can reach a material or transform.
  GltfBuilder b = quad_builder();
  b.j["materials"] = json::array({json{{"pbrMetallicRoughness", {{"baseColorFactor", {12345, 0, 0, 1}}}}}});
  std::string text = b.gltf();
  text.replace(text.find("12345"), 5, "1e400");
  EXPECT_EQ(error_code_of([&] {
              vgeo::import_scene_from_memory(reinterpret_cast<const uint8_t*>(text.data()), text.size(), "m.gltf");
            }),
            "GLTF_PARSE_ERROR");
}

TEST(ImportGltf, BufferErrorsFromTinygltf) {
  json doc = json::parse(quad_builder().gltf());
  doc["buffers"][0]["byteLength"] = 4096;  // the data: URI holds 60 bytes: a decode failure
  std::string text = doc.dump();
  auto code = [&] {
    return error_code_of([&] {
      vgeo::import_scene_from_memory(reinterpret_cast<const uint8_t*>(text.data()), text.size(), "b.gltf");
    });
  };
  EXPECT_EQ(code(), "BUFFER_URI_INVALID");
  GltfBuilder b = quad_builder();
  b.buffer_length_override = 4096;  // BIN chunk holds 60 bytes
  auto glb = b.glb();
  EXPECT_EQ(error_code_of([&] { vgeo::import_scene_from_memory(glb.data(), glb.size(), "b.glb"); }),
            "BUFFER_LENGTH_MISMATCH");
  doc = json::parse(quad_builder().gltf());
  doc["buffers"][0]["uri"] = "data:application/octet-stream;base64,@@@@";
  text = doc.dump();
  EXPECT_EQ(code(), "BUFFER_URI_INVALID");
}

TEST(ImportGltf, ContainerAndFormatErrors) {
  auto glb = quad_builder().glb();
  auto with = [&](size_t at, uint32_t v) {
    auto g = glb;
    std::memcpy(&g[at], &v, 4);
    return g;
  };
  auto code = [](const std::vector<uint8_t>& g) {
    return error_code_of([&] { vgeo::import_scene_from_memory(g.data(), g.size(), "c.glb"); });
  };
  EXPECT_EQ(code(with(0, 0x12345678)), "GLB_HEADER_INVALID");
  EXPECT_EQ(code(with(4, 1)), "GLB_VERSION_UNSUPPORTED");
  EXPECT_EQ(code(with(8, uint32_t(glb.size() + 4))), "GLB_TRUNCATED");
  EXPECT_EQ(code(with(16, 0x11111111)), "GLB_HEADER_INVALID");
  auto trailing = glb;
  trailing.push_back(0);
  EXPECT_EQ(code(trailing), "GLB_HEADER_INVALID");
  const std::string bad_json = "{\"asset\": {\"version\": \"2.0\"";
  EXPECT_EQ(error_code_of([&] {
              vgeo::import_scene_from_memory(reinterpret_cast<const uint8_t*>(bad_json.data()), bad_json.size(), "b.gltf");
            }),
            "GLTF_PARSE_ERROR");
  EXPECT_EQ(error_code_of([&] { vgeo::import_scene_from_memory(glb.data(), glb.size(), "mesh.xyz"); }),
            "MESH_FORMAT_UNSUPPORTED");
  EXPECT_EQ(error_code_of([&] { vgeo::import_scene_from_memory(nullptr, 0, "empty.gltf"); }), "GLTF_PARSE_ERROR");
  EXPECT_EQ(error_code_of([&] { vgeo::import_scene("/nonexistent/x.glb"); }), "FILE_NOT_FOUND");
}

TEST(ImportGltf, EveryTruncatedPrefixOfAValidGlbFailsCleanly) {
  const auto glb = quad_builder().glb();
  ASSERT_NO_THROW(vgeo::import_scene_from_memory(glb.data(), glb.size(), "ok.glb"));
  for (size_t len = 0; len < glb.size(); ++len) {
    // Copy into an exact-size allocation so ASan catches any read past the prefix.
    std::vector<uint8_t> prefix(glb.begin(), glb.begin() + len);
    std::string code = error_code_of([&] { vgeo::import_scene_from_memory(prefix.data(), prefix.size(), "t.glb"); });
    EXPECT_TRUE(code == "GLB_TRUNCATED") << "prefix " << len << ": " << code;
  }
}

// Property: arbitrary byte corruption of a valid GLB either imports (meeting the importer's
// contract) or fails with a VgeoError; it never crashes or throws anything else.
RC_GTEST_PROP(ImportGltf, CorruptedGlbImportsOrFailsWithACode, ()) {
  static const auto glb = quad_builder().glb();
  auto bytes = glb;
  const auto flips = *rc::gen::container<std::vector<std::pair<size_t, uint8_t>>>(
      *rc::gen::inRange<size_t>(1, 6),
      rc::gen::pair(rc::gen::inRange<size_t>(0, glb.size()), rc::gen::arbitrary<uint8_t>()));
  for (auto [at, v] : flips) bytes[at] = v;
  try {
    auto r = vgeo::import_scene_from_memory(bytes.data(), bytes.size(), "f.glb");
    for (const auto& m : r.scene.meshes) {
      RC_ASSERT(m.triangle_count() > 0u);
      for (uint32_t i : m.indices) RC_ASSERT(i < m.vertex_count());
      for (float x : m.positions) RC_ASSERT(std::isfinite(x));
    }
  } catch (const vgeo::VgeoError& e) {
    RC_ASSERT(!e.error().code.empty());
  }
}
