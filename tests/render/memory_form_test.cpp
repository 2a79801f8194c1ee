// Built meshes are drawn in their decoded memory form (spec/raster.md §Geometry): the geometry a
// GPU reads from pages. The change from the float DAG is exactly the position quantization.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <unistd.h>

#include "support/shapes.h"
#include "vgeo/core/file_io.h"
#include "vgeo/dag/build.h"
#include "vgeo/dag/dag_io.h"
#include "vgeo/format/asset_file.h"
#include "vgeo/format/format.h"
#include "vgeo/mesh/generate.h"
#include "vgeo/render/run.h"
#include "vgeo/render/scene_file.h"

namespace vgeo {
namespace {

constexpr const char* kCamera = R"("cameras": [{"position": [0.5, 0.8, 3.2], "look_at": [0, 0, 0], "resolution": [96, 64]}])";

// The scene's procedural mesh, built here as the scene loader builds it.
ClusterDag built_float_dag() {
  GenerateOptions gen;
  gen.shape = GenShape::kSphere;
  gen.target_triangles = 3000;
  gen.seed = 5;
  Mesh mesh = generate_mesh(gen);
  mesh.materials.assign(mesh.triangle_count(), 0);
  return build_dag(mesh, {});
}

std::string procedural_scene() {
  return std::string(R"({"version": 1, "meshes": [{"procedural": {"shape": "sphere", "triangles": 3000, "seed": 5}}],
    "instances": [{"mesh": 0}], )") + kCamera + "}";
}

using Triangle = std::array<float, 9>;
// A cluster's triangles as position triples, each rotated to its smallest corner, sorted:
// equal for two encodings of the same triangles whatever the vertex and triangle order.
std::vector<Triangle> cluster_triangles(const ClusterDag& dag, uint32_t c,
                                        const std::function<float(float)>& map = [](float v) { return v; }) {
  const DagCluster& cl = dag.clusters[c];
  std::vector<Triangle> out;
  for (uint32_t t = 0; t < cl.triangle_count; ++t) {
    std::array<std::array<float, 3>, 3> corner;
    for (int k = 0; k < 3; ++k) {
      const size_t v = cl.vertex_offset + dag.indices[3 * (size_t(cl.triangle_offset) + t) + k];
      for (int a = 0; a < 3; ++a) corner[k][a] = map(dag.positions[3 * v + a]);
    }
    int r = 0;
    for (int k = 1; k < 3; ++k)
      if (corner[k] < corner[r]) r = k;
    Triangle tri;
    for (int k = 0; k < 3; ++k)
      for (int a = 0; a < 3; ++a) tri[3 * k + a] = corner[(r + k) % 3][a];
    out.push_back(tri);
  }
  std::sort(out.begin(), out.end());
  return out;
}

TEST(MemoryForm, BuiltMeshIsDrawnAsTheDecodedPageFileOfItsDag) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / ("vgeo_memory_form_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  BuiltScene built;
  built.meshes.push_back(built_float_dag());
  built.materials.push_back(Material{});
  // `vgeo build`'s defaults (zstd): compression does not change the memory form.
  write_asset_file((dir / "sphere.vgp").string(), built, AssetFileKind::kPages, {});
  write_dag_file((dir / "sphere.vgeodag").string(), built);
  const BuiltScene pages = read_asset_file((dir / "sphere.vgp").string());

  const SceneFile procedural = parse_scene_json(procedural_scene(), "<test>", dir.string(), {});
  const std::string from = R"({"version": 1, "meshes": [{"dag": "FILE"}], "instances": [{"mesh": 0}], )" + std::string(kCamera) + "}";
  auto with_file = [&](const char* file) {
    std::string t = from;
    t.replace(t.find("FILE"), 4, file);
    return parse_scene_json(t, "<test>", dir.string(), {});
  };
  const SceneFile page_file = with_file("sphere.vgp"), dag_file = with_file("sphere.vgeodag");
  SceneLoadOptions cached;
  cached.cache_dir = (dir / "cache").string();
  const SceneFile first = parse_scene_json(procedural_scene(), "<test>", dir.string(), cached);
  const SceneFile second = parse_scene_json(procedural_scene(), "<test>", dir.string(), cached);  // from the cache

  const ClusterDag& expect = pages.meshes[0];
  for (const SceneFile* f : {&procedural, &page_file, &dag_file, &first, &second}) {
    const ClusterDag& got = f->scene.meshes[0];
    EXPECT_EQ(got.positions, expect.positions);
    EXPECT_EQ(got.normals, expect.normals);
    EXPECT_EQ(got.indices, expect.indices);
    ASSERT_EQ(got.clusters.size(), expect.clusters.size());
    for (size_t c = 0; c < got.clusters.size(); ++c) {
      EXPECT_EQ(got.clusters[c].lod_error, expect.clusters[c].lod_error);
      EXPECT_EQ(got.clusters[c].bounds.radius, expect.clusters[c].bounds.radius);
    }
  }
  // And the renderer draws it: the same visibility buffer and image from each.
  RenderRequest r;
  r.threads = 2;
  const RenderReport a = render_scene(procedural, r), b = render_scene(page_file, r), d = render_scene(dag_file, r);
  EXPECT_GT(a.frames.back().pixels_covered, 0u);
  EXPECT_EQ(a.vis_hash, b.vis_hash);
  EXPECT_EQ(a.image_hash, b.image_hash);
  EXPECT_EQ(a.vis_hash, d.vis_hash);
  EXPECT_EQ(a.image_hash, d.image_hash);
  std::filesystem::remove_all(dir);
}

TEST(MemoryForm, DrawnGeometryIsTheFloatDagQuantizedAndNothingElse) {
  const ClusterDag dag = built_float_dag();
  BuiltScene one;
  one.meshes.push_back(dag);
  const std::vector<uint8_t> bytes = encode_format(one, memory_form_options());
  const int32_t step = parse_container(bytes.data(), bytes.size(), "<test>").meshes[0].quantization.position_step_log2;
  // The grid point nearest each coordinate (ties to even): an independent statement of §2.
  auto quantize = [step](float v) { return dequantize_position(int32_t(std::nearbyint(std::ldexp(double(v), -step))), step); };
  const SceneFile scene = parse_scene_json(procedural_scene(), "<test>", ".", {});
  const ClusterDag& drawn = scene.scene.meshes[0];
  ASSERT_EQ(drawn.clusters.size(), dag.clusters.size());
  uint64_t moved = 0;
  for (uint32_t c = 0; c < dag.clusters.size(); ++c) {
    ASSERT_EQ(drawn.clusters[c].triangle_count, dag.clusters[c].triangle_count) << c;
    ASSERT_EQ(drawn.clusters[c].vertex_count, dag.clusters[c].vertex_count) << c;
    EXPECT_EQ(drawn.clusters[c].level, dag.clusters[c].level) << c;
    EXPECT_EQ(drawn.clusters[c].group, dag.clusters[c].group) << c;
    EXPECT_EQ(cluster_triangles(drawn, c), cluster_triangles(dag, c, quantize)) << "cluster " << c;
    moved += cluster_triangles(drawn, c) != cluster_triangles(dag, c);
  }
  EXPECT_GT(moved, 0u);  // not vacuous: the float DAG is off the grid
}

// A page file is read once per load and kept as the scene's one encoding of it; every scene
// mesh drawn from it is the decode of those bytes (the first takes the decoded DAG, later ones
// copy it), with its own material offset.
TEST(MemoryForm, APageFileIsReadOnceAndEveryMeshFromItIsItsDecode) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / ("vgeo_memory_form_once_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  BuiltScene built;
  built.meshes.push_back(built_float_dag());
  built.meshes.push_back(built.meshes[0]);
  for (uint32_t& t : built.meshes[1].triangle_materials) t = 1;
  built.materials = {Material{"a", {1, 0, 0, 1}}, Material{"b", {0, 1, 0, 1}}};
  write_asset_file((dir / "two.vgp").string(), built, AssetFileKind::kPages, {});
  const std::vector<uint8_t> bytes = read_file((dir / "two.vgp").string());
  const BuiltScene decoded = decode_format(bytes.data(), bytes.size(), "<test>");
  const std::string json = R"({"version": 1, "meshes": [{"dag": "two.vgp", "index": 0}, {"dag": "two.vgp", "index": 1},
      {"dag": "two.vgp", "index": 0}], "instances": [{"mesh": 0}, {"mesh": 1}, {"mesh": 2}], )" + std::string(kCamera) + "}";
  const SceneFile sf = parse_scene_json(json, "<test>", dir.string(), {});
  ASSERT_EQ(sf.encodings.size(), 1u);
  EXPECT_EQ(sf.encodings[0].bytes, bytes);
  ASSERT_EQ(sf.mesh_forms.size(), 3u);
  const uint32_t index[3] = {0, 1, 0}, offset[3] = {1, 3, 5};  // after the default material, 2 per use
  for (uint32_t m = 0; m < 3; ++m) {
    EXPECT_EQ(sf.mesh_forms[m].encoding, 0u);
    EXPECT_EQ(sf.mesh_forms[m].mesh, index[m]);
    EXPECT_EQ(sf.mesh_forms[m].material_offset, offset[m]);
    const ClusterDag& want = decoded.meshes[index[m]];
    EXPECT_EQ(sf.scene.meshes[m].positions, want.positions) << m;
    EXPECT_EQ(sf.scene.meshes[m].indices, want.indices) << m;
    std::vector<uint32_t> materials = want.triangle_materials;
    for (uint32_t& t : materials) t += offset[m];
    EXPECT_EQ(sf.scene.meshes[m].triangle_materials, materials) << m;
  }
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace vgeo
