// Scene files (spec/scene.md): example scenes load and render; malformed scenes fail with
// their stable SCENE_* code.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <unistd.h>

#include "support/paths.h"
#include "support/shapes.h"
#include "vgeo/dag/build.h"
#include "vgeo/dag/dag_io.h"
#include "vgeo/core/error.h"
#include "vgeo/render/run.h"
#include "vgeo/render/scene_file.h"

namespace vgeo {
namespace {

std::string scenes_dir() { return (test::source_dir() / "tests" / "scenes").string(); }

std::string error_code_of(const std::string& text) {
  try {
    parse_scene_json(text, "<test>", scenes_dir(), {});
  } catch (const VgeoError& e) {
    return e.error().code;
  }
  return "";
}

TEST(SceneFile, ExampleScenesLoadAndRender) {
  for (const char* name : {"spheres.json", "camera_path.json", "far_away.json"}) {
    SceneFile f = load_scene_file(scenes_dir() + "/" + name, {});
    EXPECT_FALSE(f.cameras.empty()) << name;
    EXPECT_FALSE(f.scene.meshes.empty()) << name;
    RenderRequest r;
    r.threads = 2;
    RenderReport report = render_scene(f, r);
    ASSERT_FALSE(report.frames.empty()) << name;
    EXPECT_GT(report.frames.back().pixels_covered, 0u) << name;
  }
}

TEST(SceneFile, CameraPathExpandsToItsFrameCount) {
  SceneFile f = load_scene_file(scenes_dir() + "/camera_path.json", {});
  ASSERT_EQ(f.path.size(), 6u);
  EXPECT_DOUBLE_EQ(f.path.front().position.x, -2.0);
  EXPECT_DOUBLE_EQ(f.path.back().position.y, 4.0);
  EXPECT_EQ(f.settings.hzb_policy, HzbMipPolicy::k2x2);
  RenderRequest r;
  r.threads = 2;
  RenderReport report = render_scene(f, r);
  ASSERT_EQ(report.frames.size(), 6u);
  // Every frame after the first tests against its predecessor's HZB; only the last frame
  // skips building one for a next frame.
  for (size_t i = 1; i < report.frames.size(); ++i)
    for (const auto& [name, reason] : report.frames[i].skipped) EXPECT_NE(reason, "no previous-frame HZB") << i;
  EXPECT_EQ(report.frames.back().find("hzb_next"), nullptr);
  EXPECT_NE(report.frames.front().find("hzb_next"), nullptr);
}

TEST(SceneFile, MalformedScenesFailWithStableCodes) {
  const std::string mesh = R"({"procedural": {"shape": "sphere", "triangles": 128}})";
  const std::string cam = R"({"position": [0, 0, 5], "look_at": [0, 0, 0]})";
  auto scene = [&](const std::string& meshes, const std::string& instances, const std::string& cameras,
                   const std::string& extra = "") {
    return R"({"version": 1, "meshes": )" + meshes + R"(, "instances": )" + instances + R"(, "cameras": )" +
           cameras + extra + "}";
  };
  struct Case {
    std::string text, code;
  };
  const Case cases[] = {
      {"{", "SCENE_JSON_PARSE"},
      {"[]", "SCENE_FIELD_TYPE"},
      {R"({"version": 2, "meshes": [], "instances": [], "cameras": []})", "SCENE_VERSION"},
      {R"({"meshes": [], "instances": [], "cameras": []})", "SCENE_MISSING_FIELD"},
      {R"({"version": 1, "instances": [], "cameras": [)" + cam + "]}", "SCENE_MISSING_FIELD"},
      {scene("[" + mesh + "]", "[]", "[]"), "SCENE_NO_CAMERA"},
      {scene("[" + mesh + "]", R"([{"mesh": 1}])", "[" + cam + "]"), "SCENE_MESH_INDEX"},
      {scene("[" + mesh + "]", R"([{"mesh": -1}])", "[" + cam + "]"), "SCENE_BAD_VALUE"},
      {scene("[" + mesh + "]", R"([{"mesh": 0, "scale": 0}])", "[" + cam + "]"), "SCENE_BAD_TRANSFORM"},
      {scene("[" + mesh + "]", R"([{"mesh": 0, "matrix": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,2]}])", "[" + cam + "]"),
       "SCENE_BAD_TRANSFORM"},
      {scene("[" + mesh + "]", R"([{"mesh": 0, "translation": [0, 0]}])", "[" + cam + "]"), "SCENE_FIELD_TYPE"},
      {scene("[" + mesh + "]", R"([{"mesh": 0, "colour": 1}])", "[" + cam + "]"), "SCENE_UNKNOWN_FIELD"},
      {scene("[" + mesh + "]", "[]", R"([{"position": [0, 0, 5], "look_at": [0, 0, 5]}])"), "SCENE_BAD_CAMERA"},
      {scene("[" + mesh + "]", "[]", R"([{"position": [0, 0, 5], "look_at": [0, 9, 5]}])"), "SCENE_BAD_CAMERA"},
      {scene("[" + mesh + "]", "[]", R"([{"position": [0, 0, 5]}])"), "SCENE_BAD_CAMERA"},
      {scene("[" + mesh + "]", "[]", R"([{"position": [0, 0, 5], "look_at": [0, 0, 0], "resolution": [0, 10]}])"),
       "SCENE_BAD_CAMERA"},
      {scene("[" + mesh + "]", "[]", R"([{"position": [0, 0, 5], "look_at": [0, 0, 0], "z_near": 0}])"),
       "SCENE_BAD_VALUE"},
      {scene("[" + mesh + "]", "[]", R"([{"position": [0, 0, 5], "look_at": [0, 0, 0], "fov_y_degrees": 180}])"),
       "SCENE_BAD_VALUE"},
      {scene("[" + mesh + "]", "[]", "[" + cam + "]", R"(, "settings": {"hzb_mip_policy": "8x8"})"), "SCENE_BAD_VALUE"},
      {scene("[" + mesh + "]", "[]", "[" + cam + "]", R"(, "settings": {"occlusion": 1})"), "SCENE_FIELD_TYPE"},
      {scene("[" + mesh + "]", "[]", "[" + cam + "]", R"(, "camera_path": {"frames": 0, "keyframes": []})"),
       "SCENE_BAD_VALUE"},
      {scene("[" + mesh + "]", "[]", "[" + cam + "]", R"(, "camera_path": {"frames": 3, "keyframes": []})"),
       "SCENE_BAD_CAMERA"},
      {scene("[" + mesh + "]", "[]", "[" + cam + "]", R"(, "camera_path": {"frames": 1e9, "keyframes": []})"),
       "SCENE_BAD_VALUE"},
      {scene(R"([{"procedural": {"shape": "sphere", "triangles": 5000000}}])", "[]", "[" + cam + "]"),
       "SCENE_TOO_LARGE"},
      {scene(R"([{"procedural": {"shape": "sphere", "triangles": 1e300}}])", "[]", "[" + cam + "]"),
       "SCENE_TOO_LARGE"},
      {scene(R"([{"procedural": {"shape": "sphere", "triangles": 0}}])", "[]", "[" + cam + "]"), "SCENE_BAD_VALUE"},
      {scene(R"([{"procedural": {"shape": "sphere", "triangles": 100.5}}])", "[]", "[" + cam + "]"),
       "SCENE_BAD_VALUE"},
      {scene(R"([{"procedural": {"shape": "sphere", "seed": -1}}])", "[]", "[" + cam + "]"), "SCENE_BAD_VALUE"},
      {scene(R"([{"procedural": {"shape": "sphere", "seed": 1.5}}])", "[]", "[" + cam + "]"), "SCENE_BAD_VALUE"},
      {scene(R"([{"procedural": {"shape": "sphere", "seed": "1"}}])", "[]", "[" + cam + "]"), "SCENE_FIELD_TYPE"},
      {scene(R"([{"procedural": {"shape": "cube"}}])", "[]", "[" + cam + "]"), "SCENE_BAD_VALUE"},
      {scene(R"([{"procedural": {"triangles": 100}}])", "[]", "[" + cam + "]"), "SCENE_MISSING_FIELD"},
      {scene(R"([{"procedural": {"type": "sphere", "rings": 8, "segments": 8}}])", "[]", "[" + cam + "]"),
       "SCENE_UNKNOWN_FIELD"},
      {scene(R"([{"name": "x"}])", "[]", "[" + cam + "]"), "SCENE_MESH_SOURCE"},
      {scene(R"([{"dag": "does-not-exist.vgeodag"}])", "[]", "[" + cam + "]"), "SCENE_MESH_SOURCE"},
      {scene("[" + mesh + "]", "[]", "[" + cam + "]", R"(, "materials": [{"base_color": [2, 0, 0, 1]}])"),
       "SCENE_BAD_VALUE"},
      {scene(R"([{"procedural": {"shape": "sphere", "triangles": 128}, "material": 3}])", "[]", "[" + cam + "]"),
       "SCENE_BAD_VALUE"},
  };
  for (const Case& c : cases) EXPECT_EQ(error_code_of(c.text), c.code) << c.text;
}

TEST(SceneFile, SourceMeshesAreImportedAndDagFilesAreRead) {
  auto dir = std::filesystem::temp_directory_path() / ("vgeo_scene_src_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  {
    std::ofstream obj(dir / "quad.obj");
    obj << "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nf 1 2 3\nf 1 3 4\n";
  }
  BuiltScene built;
  built.meshes.push_back(build_dag(test::make_sphere(8, 16), {}));
  built.materials.push_back(Material{"red", {1, 0, 0, 1}});
  write_dag_file((dir / "sphere.vgeodag").string(), built);
  std::string text = R"({"version": 1,
    "meshes": [{"source": "quad.obj"}, {"dag": "sphere.vgeodag"}],
    "instances": [{"mesh": 0}, {"mesh": 1, "translation": [0, 0, -3]}],
    "cameras": [{"position": [0, 0, 4], "look_at": [0, 0, 0], "resolution": [64, 48]}]})";
  SceneLoadOptions options;
  options.cache_dir = (dir / "cache").string();
  for (int pass = 0; pass < 2; ++pass) {  // second pass: the source mesh comes from the cache
    SceneFile f = parse_scene_json(text, "<test>", dir.string(), options);
    ASSERT_EQ(f.scene.meshes.size(), 2u);
    EXPECT_EQ(f.scene.meshes[0].clusters.size() > 0, true);
    EXPECT_EQ(f.scene.meshes[1].triangle_count(), built.meshes[0].triangle_count());
    EXPECT_FALSE(std::filesystem::is_empty(dir / "cache"));
    RenderRequest r;
    r.threads = 2;
    EXPECT_GT(render_scene(f, r).frames.back().pixels_covered, 0u);
  }
  EXPECT_EQ(error_code_of(R"({"version": 1, "meshes": [{"source": "/nonexistent.obj"}], "instances": [],
    "cameras": [{"position": [0, 0, 4], "look_at": [0, 0, 0]}]})"), "SCENE_MESH_SOURCE");
  std::filesystem::remove_all(dir);
}

TEST(SceneFile, MissingFileIsAnIoError) {
  try {
    load_scene_file("/nonexistent/scene.json", {});
    FAIL();
  } catch (const VgeoError& e) {
    EXPECT_EQ(e.error().code, "FILE_NOT_FOUND");
    EXPECT_EQ(e.error().exit_code, kExitIo);
  }
}

TEST(SceneFile, MeshContentHashDependsOnContent) {
  Mesh a = test::make_sphere(8, 8), b = a;
  EXPECT_EQ(mesh_content_hash(a, {}), mesh_content_hash(b, {}));
  b.positions[0] += 1e-3f;
  EXPECT_NE(mesh_content_hash(a, {}), mesh_content_hash(b, {}));
}

}  // namespace
}  // namespace vgeo
