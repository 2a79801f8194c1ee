// Mesh writers (lib/vgeo/mesh/export.h): GLB read back by tinygltf, OBJ/PLY/OFF read back by
// OpenMesh (independent parsers), byte determinism, atomic writes, stable error codes.
#include "support/errors.h"
#include "vgeo/mesh/export.h"

#include <gtest/gtest.h>
#include <tiny_gltf.h>

#include <OpenMesh/Core/IO/MeshIO.hh>
#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <unistd.h>

#include "generate_checks.h"
#include "support/shapes.h"
#include "vgeo/mesh/generate.h"

namespace vgeo {
namespace {

namespace fs = std::filesystem;

struct TempDir {
  fs::path path;
  TempDir() {
    path = fs::temp_directory_path() / ("vgeo_export_test_" + std::to_string(getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~TempDir() { fs::remove_all(path); }
  std::string file(const std::string& name) const { return (path / name).string(); }
  size_t entries() const { return size_t(std::distance(fs::directory_iterator(path), fs::directory_iterator())); }
};

Scene gen_scene(GenShape shape, uint64_t triangles, uint64_t seed = 1) {
  GenerateOptions o;
  o.shape = shape;
  o.target_triangles = triangles;
  o.seed = seed;
  return generate_scene(o);
}

template <class T>
std::vector<T> accessor_data(const tinygltf::Model& model, int index) {
  const tinygltf::Accessor& acc = model.accessors[size_t(index)];
  const tinygltf::BufferView& view = model.bufferViews[size_t(acc.bufferView)];
  const auto& buf = model.buffers[size_t(view.buffer)].data;
  size_t comps = acc.type == TINYGLTF_TYPE_VEC3 ? 3 : acc.type == TINYGLTF_TYPE_VEC2 ? 2 : 1;
  std::vector<T> out(acc.count * comps);
  std::memcpy(out.data(), buf.data() + view.byteOffset + acc.byteOffset, out.size() * sizeof(T));
  return out;
}

TEST(ExportGlb, TinyGltfLoadsItBackWithIdenticalAttributesAndIndices) {
  for (GenShape s : kAllGenShapes) {
    Scene scene = gen_scene(s, 5'000, 2);
    const Mesh& m = scene.meshes[0];
    std::vector<uint8_t> glb = encode_glb(scene);
    ASSERT_EQ(glb.size() % 4, 0u);
    tinygltf::TinyGLTF loader;
    tinygltf::Model model;
    std::string err, warn;
    ASSERT_TRUE(loader.LoadBinaryFromMemory(&model, &err, &warn, glb.data(), unsigned(glb.size()))) << err;
    EXPECT_TRUE(err.empty()) << err;
    EXPECT_TRUE(warn.empty()) << warn;
    ASSERT_EQ(model.meshes.size(), 1u);
    ASSERT_EQ(model.materials.size(), 2u);
    EXPECT_EQ(model.materials[1].name, "gen_b");
    EXPECT_FLOAT_EQ(float(model.materials[1].pbrMetallicRoughness.baseColorFactor[0]), scene.materials[1].base_color[0]);
    ASSERT_EQ(model.nodes.size(), 1u);
    EXPECT_TRUE(model.nodes[0].matrix.empty());
    const auto& prims = model.meshes[0].primitives;
    ASSERT_EQ(prims.size(), 2u) << gen_shape_name(s);  // every shape uses both materials
    // Same vertex attributes for every primitive; positions/normals/uvs bit-identical.
    const tinygltf::Primitive& p0 = prims[0];
    EXPECT_EQ(accessor_data<float>(model, p0.attributes.at("POSITION")), m.positions);
    EXPECT_EQ(accessor_data<float>(model, p0.attributes.at("NORMAL")), m.normals);
    EXPECT_EQ(accessor_data<float>(model, p0.attributes.at("TEXCOORD_0")), m.uvs);
    const tinygltf::Accessor& pos = model.accessors[size_t(p0.attributes.at("POSITION"))];
    MeshStats stats = mesh_stats(m);
    ASSERT_EQ(pos.minValues.size(), 3u);
    for (int k = 0; k < 3; ++k) {
      EXPECT_EQ(float(pos.minValues[size_t(k)]), stats.bounds.min[k]);
      EXPECT_EQ(float(pos.maxValues[size_t(k)]), stats.bounds.max[k]);
    }
    // Indices: the mesh's triangles grouped by material, original order within a group.
    std::vector<uint32_t> expected;
    for (size_t p = 0; p < prims.size(); ++p) {
      EXPECT_EQ(prims[p].mode, TINYGLTF_MODE_TRIANGLES);
      EXPECT_EQ(prims[p].material, int(p));
      for (size_t t = 0; t < m.triangle_count(); ++t)
        if (m.materials[t] == uint32_t(p)) expected.insert(expected.end(), &m.indices[3 * t], &m.indices[3 * t] + 3);
      std::vector<uint32_t> got = accessor_data<uint32_t>(model, prims[p].indices);
      EXPECT_EQ(model.accessors[size_t(prims[p].indices)].componentType, TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT);
      std::vector<uint32_t> want(expected.end() - std::ptrdiff_t(got.size()), expected.end());
      EXPECT_EQ(got, want) << gen_shape_name(s) << " primitive " << p;
    }
    EXPECT_EQ(expected.size(), m.indices.size());
  }
}

TEST(ExportGlb, InstancesBecomeNodesWithMatrices) {
  Scene scene;
  scene.meshes.push_back(test::make_sphere(4, 6));
  scene.meshes.push_back(test::make_grid(3));
  Instance a, b, c;
  b.mesh = 1;
  c.transform[12] = 5.0f;  // translated copy of mesh 0
  scene.instances = {a, b, c};
  std::vector<uint8_t> glb = encode_glb(scene);
  tinygltf::TinyGLTF loader;
  tinygltf::Model model;
  std::string err, warn;
  ASSERT_TRUE(loader.LoadBinaryFromMemory(&model, &err, &warn, glb.data(), unsigned(glb.size()))) << err;
  ASSERT_EQ(model.meshes.size(), 2u);
  ASSERT_EQ(model.nodes.size(), 3u);
  EXPECT_EQ(model.nodes[1].mesh, 1);
  ASSERT_EQ(model.nodes[2].matrix.size(), 16u);
  EXPECT_EQ(model.nodes[2].matrix[12], 5.0);
  ASSERT_EQ(model.materials.size(), 1u);  // default material added
  EXPECT_TRUE(model.meshes[0].primitives[0].attributes.count("TEXCOORD_0") == 0);  // make_sphere has none
  ASSERT_EQ(model.scenes.size(), 1u);
  EXPECT_EQ(model.scenes[0].nodes.size(), 3u);
}

TEST(ExportGlb, OutputIsByteIdenticalAndFileMatchesMemory) {
  TempDir dir;
  Scene scene = gen_scene(GenShape::kTerrain, 20'000, 4);
  std::vector<uint8_t> a = encode_glb(scene), b = encode_glb(gen_scene(GenShape::kTerrain, 20'000, 4));
  EXPECT_EQ(a, b);
  write_glb(scene, dir.file("t.glb"));
  write_scene_file(scene, dir.file("t2.GLB"));
  EXPECT_EQ(test::read_file_bytes(dir.file("t.glb")), a);
  EXPECT_EQ(test::read_file_bytes(dir.file("t2.GLB")), a);
  EXPECT_EQ(dir.entries(), 2u);  // no temp files left behind
}

TEST(ExportFiles, FailedWriteLeavesExistingFileUntouchedAndNoTempFiles) {
  TempDir dir;
  const std::string path = dir.file("keep.glb");
  Scene good = gen_scene(GenShape::kSphere, 1'000);
  write_glb(good, path);
  const std::vector<uint8_t> before = test::read_file_bytes(path);
  Scene bad = good;
  bad.meshes[0].indices[5] = uint32_t(bad.meshes[0].vertex_count());
  EXPECT_EQ(test::error_code_of([&] { write_glb(bad, path); }), "EXPORT_INDEX_OUT_OF_RANGE");
  EXPECT_EQ(test::error_code_of([&] { write_obj(bad.meshes[0], dir.file("keep.glb")); }), "EXPORT_INDEX_OUT_OF_RANGE");
  EXPECT_EQ(test::read_file_bytes(path), before);
  EXPECT_EQ(dir.entries(), 1u);
  try {
    write_glb(good, dir.file("no/such/dir/x.glb"));
    FAIL();
  } catch (const VgeoError& e) {
    EXPECT_EQ(e.error().code, "IO_WRITE_FAILED");
    EXPECT_EQ(e.error().exit_code, kExitIo);
  }
}

TEST(ExportFiles, RejectsInvalidMeshesWithStableCodes) {
  TempDir dir;
  Scene s = gen_scene(GenShape::kTorus, 500);
  EXPECT_EQ(test::error_code_of([&] { write_scene_file(s, dir.file("x.xyz")); }), "EXPORT_UNKNOWN_FORMAT");
  EXPECT_EQ(test::error_code_of([&] { write_scene_file(s, dir.file("noext")); }), "EXPORT_UNKNOWN_FORMAT");
  Scene nan = s;
  nan.meshes[0].positions[4] = std::nanf("");
  EXPECT_EQ(test::error_code_of([&] { encode_glb(nan); }), "EXPORT_NON_FINITE");
  Scene mat = s;
  mat.meshes[0].materials[3] = 2;
  EXPECT_EQ(test::error_code_of([&] { encode_glb(mat); }), "EXPORT_MATERIAL_OUT_OF_RANGE");
  Scene empty = s;
  empty.meshes[0].indices.clear();
  empty.meshes[0].materials.clear();
  EXPECT_EQ(test::error_code_of([&] { encode_glb(empty); }), "EXPORT_EMPTY_MESH");
  Scene sizes = s;
  sizes.meshes[0].normals.pop_back();
  EXPECT_EQ(test::error_code_of([&] { encode_glb(sizes); }), "EXPORT_ATTRIBUTE_SIZE");
  Scene inst = s;
  inst.instances[0].mesh = 3;
  EXPECT_EQ(test::error_code_of([&] { encode_glb(inst); }), "EXPORT_BAD_INSTANCE");
  EXPECT_EQ(dir.entries(), 0u);
}

using OmMesh = OpenMesh::TriMesh_ArrayKernelT<>;

// OpenMesh's readers: same face count, and every face's corner positions bit-identical to
// ours (shortest round-trip text is exact for floats).
void expect_same_faces(const Mesh& m, const OmMesh& om, bool grouped_by_material) {
  ASSERT_EQ(om.n_faces(), m.triangle_count());
  std::vector<size_t> order(m.triangle_count());
  std::iota(order.begin(), order.end(), size_t(0));
  if (grouped_by_material)
    std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) { return m.material(a) < m.material(b); });
  for (auto fh : om.faces()) {
    size_t t = order[size_t(fh.idx())];
    int k = 0;
    for (auto vh : om.fv_range(fh)) {
      Vec3 want = m.position(m.indices[3 * t + size_t(k++)]);
      const auto& p = om.point(vh);
      ASSERT_EQ(p[0], want.x);
      ASSERT_EQ(p[1], want.y);
      ASSERT_EQ(p[2], want.z);
    }
  }
}

TEST(ExportFiles, ObjPlyOffReadBackByOpenMesh) {
  TempDir dir;
  Scene scene = gen_scene(GenShape::kThin, 3'000, 5);
  const Mesh& m = scene.meshes[0];
  for (const char* ext : {"obj", "ply", "off"}) {
    const std::string path = dir.file(std::string("m.") + ext);
    write_scene_file(scene, path);
    OmMesh om;
    OpenMesh::IO::Options opt;
    ASSERT_TRUE(OpenMesh::IO::read_mesh(om, path, opt)) << ext;
    EXPECT_EQ(om.n_vertices(), m.vertex_count()) << ext;
    expect_same_faces(m, om, std::string(ext) == "obj");
    // Deterministic bytes.
    const std::vector<uint8_t> first = test::read_file_bytes(path);
    write_scene_file(scene, path);
    EXPECT_EQ(test::read_file_bytes(path), first) << ext;
  }
  EXPECT_EQ(dir.entries(), 3u);
}

TEST(ExportFiles, PlyHeaderDeclaresAllAttributes) {
  TempDir dir;
  Scene scene = gen_scene(GenShape::kSphere, 500);
  write_ply(scene.meshes[0], dir.file("a.ply"));
  std::vector<uint8_t> bytes = test::read_file_bytes(dir.file("a.ply"));
  std::string text(bytes.begin(), bytes.end());
  size_t end = text.find("end_header\n");
  ASSERT_NE(end, std::string::npos);
  std::string header = text.substr(0, end);
  for (const char* want : {"format binary_little_endian 1.0", "property float nx", "property float s",
                           "property list uchar uint vertex_indices", "property uint material_index"})
    EXPECT_NE(header.find(want), std::string::npos) << want;
  const Mesh& m = scene.meshes[0];
  EXPECT_EQ(bytes.size(), end + 11 + m.vertex_count() * 32 + m.triangle_count() * 17);
}

TEST(ExportFiles, BakeSceneAppliesTransformsAndKeepsOrientation) {
  Scene scene;
  scene.meshes.push_back(test::make_sphere(6, 8));
  Instance plain, moved, mirrored;
  moved.transform[13] = 10.0f;
  mirrored.transform[0] = -2.0f;  // mirror in X and scale: det < 0
  mirrored.transform[14] = -10.0f;
  scene.instances = {plain, moved, mirrored};
  Mesh baked = bake_scene(scene);
  const Mesh& m = scene.meshes[0];
  ASSERT_EQ(baked.triangle_count(), 3 * m.triangle_count());
  EXPECT_EQ(test::triangle_components(baked), 3u);
  EXPECT_TRUE(test::is_closed_oriented_manifold(baked));
  EXPECT_NEAR(test::signed_volume(baked), 4.0 * test::signed_volume(m), 1e-4);  // 1 + 1 + 2
  for (size_t v = 0; v < baked.vertex_count(); ++v) {
    Vec3 n{baked.normals[3 * v], baked.normals[3 * v + 1], baked.normals[3 * v + 2]};
    ASSERT_NEAR(length(n), 1.0f, 1e-5f);
  }
  // Mirrored copy: normals by the inverse transpose diag(-1/2, 1, 1), renormalised.
  const size_t off = 2 * m.vertex_count();
  Vec3 want{-0.5f * m.normals[3 * 5], m.normals[3 * 5 + 1], m.normals[3 * 5 + 2]};
  want = want * (1.0f / length(want));
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(baked.normals[3 * (off + 5) + size_t(k)], want[k], 1e-6f);
  EXPECT_EQ(baked.position(m.vertex_count() + 5).y, m.position(5).y + 10.0f);
}

}  // namespace
}  // namespace vgeo
