// Import over the real corpora in data/ (tools/fetch-data): every CGAL mesh and every valid
// assimp glTF 2.0 file imports with triangle counts equal to an independent count; every
// deliberately broken glTF gives its stable error code and a non-zero exit through the CLI.
#include <gtest/gtest.h>

#include <OpenMesh/Core/IO/MeshIO.hh>
#include <OpenMesh/Core/Mesh/PolyMesh_ArrayKernelT.hh>
#include <OpenMesh/Core/System/omstream.hh>
#include <algorithm>
#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <sys/wait.h>

#include "support/paths.h"
#include "support/run_command.h"
#include "vgeo/mesh/import.h"

namespace fs = std::filesystem;
using vgeo::test::data_dir;

namespace {

fs::path require_dir(const fs::path& p) {
  if (!fs::is_directory(p))
    ADD_FAILURE() << "test data missing: " << p << " (run tools/fetch-data; tools/test does it)";
  return p;
}

std::vector<fs::path> files_with_extension(const fs::path& dir, const std::set<std::string>& exts) {
  std::vector<fs::path> out;
  if (!fs::is_directory(dir)) return out;
  for (const auto& e : fs::recursive_directory_iterator(dir)) {
    std::string ext = e.path().extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    if (e.is_regular_file() && exts.count(ext)) out.push_back(e.path());
  }
  std::sort(out.begin(), out.end());
  return out;
}

// ---- independent OFF reference: OpenMesh directly, fan triangles, own zero-area test ----
struct Reference {
  size_t triangles = 0;   // fan triangles of every face OpenMesh kept
  size_t degenerate = 0;  // of those, exactly zero area in double
};

Reference openmesh_reference(const fs::path& path) {
  using PolyMesh = OpenMesh::PolyMesh_ArrayKernelT<>;
  PolyMesh pm;
  OpenMesh::IO::Options opt;
  omerr().disable();
  bool ok = false;
  if (path.extension() != ".off") {
    ok = OpenMesh::IO::read_mesh(pm, path.string(), opt);
  } else {
    // OpenMesh misreads CGAL's '#' comments (it may even "succeed" with 0 faces): strip
    // them (test-local, naive) first.
    std::ifstream f(path);
    std::string line, text;
    while (std::getline(f, line)) {
      line = line.substr(0, line.find('#'));
      if (line.find_first_not_of(" \t\r") != std::string::npos) text += line + "\n";
    }
    std::istringstream in(text);
    ok = OpenMesh::IO::read_mesh(pm, in, ".off", opt);
  }
  omerr().enable();
  EXPECT_TRUE(ok) << "OpenMesh reference cannot read " << path;
  Reference r;
  for (const auto& fh : pm.faces()) {
    std::vector<PolyMesh::Point> ring;
    for (const auto& vh : pm.fv_range(fh)) ring.push_back(pm.point(vh));
    for (size_t i = 1; i + 1 < ring.size(); ++i) {
      ++r.triangles;
      std::array<double, 3> e1, e2;
      for (int k = 0; k < 3; ++k) {
        e1[k] = double(ring[i][k]) - ring[0][k];
        e2[k] = double(ring[i + 1][k]) - ring[0][k];
      }
      double cx = e1[1] * e2[2] - e1[2] * e2[1], cy = e1[2] * e2[0] - e1[0] * e2[2],
             cz = e1[0] * e2[1] - e1[1] * e2[0];
      if (cx == 0 && cy == 0 && cz == 0) ++r.degenerate;
    }
  }
  return r;
}

size_t total_triangles(const vgeo::Scene& s) {
  size_t n = 0;
  for (const auto& m : s.meshes) n += m.triangle_count();
  return n;
}

using vgeo::test::CliResult;
using vgeo::test::run_cli;

}  // namespace

// The brief counts 139; Debian's libcgal-demo data.tar.gz ships 138 .off plus 3 .ply, 2 .stl.
constexpr size_t kMinCgalOffFiles = 138;

TEST(ImportCorpus, EveryCgalMeshImportsWithOpenMeshTriangleCount) {
  const fs::path dir = require_dir(data_dir() / "cgal" / "meshes");
  const auto files = files_with_extension(dir, {".off", ".ply", ".stl"});
  size_t off_files = 0;
  for (const auto& f : files) off_files += f.extension() == ".off";
  EXPECT_GE(off_files, kMinCgalOffFiles);
  // b9.ply is a 22300-point cloud (element face 0): genuinely no triangles.
  const std::set<std::string> no_triangles = {"b9.ply"};
  for (const auto& f : files) {
    SCOPED_TRACE(f.string());
    if (no_triangles.count(f.filename().string())) {
      try {
        vgeo::import_scene(f.string());
        ADD_FAILURE() << "expected MESH_EMPTY";
      } catch (const vgeo::VgeoError& e) {
        EXPECT_EQ(e.error().code, "MESH_EMPTY");
      }
      continue;
    }
    vgeo::ImportResult r;
    try {
      r = vgeo::import_scene(f.string());
    } catch (const vgeo::VgeoError& e) {
      ADD_FAILURE() << e.what();
      continue;
    }
    Reference ref = openmesh_reference(f);
    EXPECT_EQ(total_triangles(r.scene), ref.triangles - ref.degenerate);
    EXPECT_EQ(r.stats.degenerate_removed, ref.degenerate);
    ASSERT_EQ(r.scene.meshes.size(), 1u);
    EXPECT_EQ(r.scene.instances.size(), 1u);
  }
}

TEST(ImportCorpus, CliInfoSucceedsOnEveryCgalOffFile) {
  const fs::path dir = require_dir(data_dir() / "cgal" / "meshes");
  for (const auto& f : files_with_extension(dir, {".off"})) {
    CliResult r = run_cli("info --json '" + f.string() + "'");
    EXPECT_EQ(r.exit_code, 0) << f << ": " << r.output.substr(0, 300);
    auto j = nlohmann::json::parse(r.output, nullptr, false);
    ASSERT_FALSE(j.is_discarded()) << f;
    EXPECT_GT(j["triangles"].get<size_t>(), 0u) << f;
  }
}

// ---- glTF: independent triangle count from the raw JSON ----
namespace {

nlohmann::json load_gltf_json(const fs::path& path) {
  std::ifstream f(path, std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  if (path.extension() == ".glb") {
    uint32_t len = 0;
    std::memcpy(&len, bytes.data() + 12, 4);
    bytes = bytes.substr(20, len);
  }
  return nlohmann::json::parse(bytes);
}

struct GltfCount {
  size_t triangles = 0;  // before degenerate removal
  size_t instances = 0;
};

GltfCount count_from_json(const nlohmann::json& j) {
  GltfCount c;
  std::set<size_t> meshes;
  std::vector<size_t> stack;
  size_t scene = j.value("scene", 0);
  for (size_t n : j["scenes"][scene].value("nodes", std::vector<size_t>{})) stack.push_back(n);
  while (!stack.empty()) {
    const auto& node = j["nodes"][stack.back()];
    stack.pop_back();
    if (node.contains("mesh")) {
      meshes.insert(node["mesh"].get<size_t>());
      ++c.instances;
    }
    for (size_t ch : node.value("children", std::vector<size_t>{})) stack.push_back(ch);
  }
  for (size_t m : meshes)
    for (const auto& p : j["meshes"][m]["primitives"]) {
      int mode = p.value("mode", 4);
      size_t count = p.contains("indices") ? j["accessors"][p["indices"].get<size_t>()]["count"].get<size_t>()
                                           : j["accessors"][p["attributes"]["POSITION"].get<size_t>()]["count"].get<size_t>();
      if (mode == 4) c.triangles += count / 3;
      if (mode == 5 || mode == 6) c.triangles += count >= 3 ? count - 2 : 0;
    }
  return c;
}

const fs::path kGltf2 = fs::path("assimp") / "glTF2";

// Valid glTF 2.0 files with no triangle geometry (valid, but nothing for vgeo to build).
const std::set<std::string> kValidWithoutTriangles = {
    "TestNoRootNode/NoScene.gltf",
    "TestNoRootNode/SceneWithoutNodes.gltf",
    "glTF-Asset-Generator/Mesh_PrimitiveMode/Mesh_PrimitiveMode_00.gltf",  // points
    "glTF-Asset-Generator/Mesh_PrimitiveMode/Mesh_PrimitiveMode_01.gltf",  // lines
    "glTF-Asset-Generator/Mesh_PrimitiveMode/Mesh_PrimitiveMode_02.gltf",  // line loop
    "glTF-Asset-Generator/Mesh_PrimitiveMode/Mesh_PrimitiveMode_03.gltf",  // line strip
    "glTF-Asset-Generator/Mesh_PrimitiveMode/Mesh_PrimitiveMode_07.gltf",  // indexed points
    "glTF-Asset-Generator/Mesh_PrimitiveMode/Mesh_PrimitiveMode_08.gltf",  // indexed lines
    "glTF-Asset-Generator/Mesh_PrimitiveMode/Mesh_PrimitiveMode_09.gltf",  // indexed line loop
    "glTF-Asset-Generator/Mesh_PrimitiveMode/Mesh_PrimitiveMode_10.gltf",  // indexed line strip
};

// Deliberately broken (or unsupported) files and the code each must produce.
const std::map<std::string, std::string> kExpectedErrors = {
    {"BoxWithInfinites-glTF-Binary/BoxWithInfinites.glb", "POSITION_NOT_FINITE"},
    {"IncorrectVertexArrays/Cube.gltf", "ACCESSOR_COUNT_MISMATCH"},  // 35 corners of TRIANGLES
    {"IndexOutOfRange/IndexOutOfRange.gltf", "INDEX_OUT_OF_RANGE"},
    {"IndexOutOfRange/AllIndicesOutOfRange.gltf", "INDEX_OUT_OF_RANGE"},
    {"MissingBin/BoxTextured.gltf", "EXTERNAL_BUFFER_MISSING"},
    {"RecursiveNodes/RecursiveNodes.gltf", "NODE_HIERARCHY_INVALID"},
    {"SchemaFailures/sceneWrongType.gltf", "GLTF_SCHEMA_ERROR"},
    {"wrongTypes/badArray.gltf", "GLTF_SCHEMA_ERROR"},
    {"wrongTypes/badExtension.gltf", "GLTF_SCHEMA_ERROR"},
    {"wrongTypes/badNumber.gltf", "GLTF_SCHEMA_ERROR"},
    {"wrongTypes/badObject.gltf", "GLTF_SCHEMA_ERROR"},
    {"wrongTypes/badString.gltf", "GLTF_SCHEMA_ERROR"},
    {"wrongTypes/badUint.gltf", "GLTF_SCHEMA_ERROR"},
    {"draco/2CylinderEngine.gltf", "EXTENSION_UNSUPPORTED"},  // KHR_draco_mesh_compression required
};

std::string rel(const fs::path& p) { return fs::relative(p, data_dir() / kGltf2).generic_string(); }

}  // namespace

TEST(ImportCorpus, EveryValidAssimpGltfImportsWithJsonTriangleCount) {
  const fs::path dir = require_dir(data_dir() / kGltf2);
  const auto files = files_with_extension(dir, {".gltf", ".glb"});
  EXPECT_GE(files.size(), 40u);
  size_t imported = 0;
  for (const auto& f : files) {
    const std::string name = rel(f);
    if (kExpectedErrors.count(name)) continue;
    SCOPED_TRACE(name);
    if (kValidWithoutTriangles.count(name)) {
      try {
        vgeo::import_scene(f.string());
        ADD_FAILURE() << "expected MESH_EMPTY";
      } catch (const vgeo::VgeoError& e) {
        EXPECT_EQ(e.error().code, "MESH_EMPTY");
      }
      continue;
    }
    vgeo::ImportResult r;
    try {
      r = vgeo::import_scene(f.string());
    } catch (const vgeo::VgeoError& e) {
      ADD_FAILURE() << e.what();
      continue;
    }
    GltfCount ref = count_from_json(load_gltf_json(f));
    EXPECT_EQ(total_triangles(r.scene) + r.stats.degenerate_removed, ref.triangles);
    EXPECT_EQ(r.scene.instances.size(), ref.instances);
    ++imported;
  }
  EXPECT_GE(imported, 22u);  // 46 files - 14 broken - 10 without triangles
}

TEST(ImportCorpus, EveryBrokenAssimpGltfFailsWithItsCodeThroughTheCli) {
  const fs::path dir = require_dir(data_dir() / kGltf2);
  for (const auto& [name, code] : kExpectedErrors) {
    SCOPED_TRACE(name);
    const fs::path f = dir / name;
    ASSERT_TRUE(fs::exists(f)) << "corpus changed: " << f;
    CliResult r = run_cli("info '" + f.string() + "'");
    EXPECT_EQ(r.exit_code, vgeo::kExitBadInput) << r.output;
    EXPECT_NE(r.output.find("error[" + code + "]: " + f.string() + ": "), std::string::npos) << r.output;
    // Exactly one line.
    EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << r.output;
  }
}

TEST(ImportCorpus, CliMissingFileIsAnIoError) {
  CliResult r = run_cli("info /nonexistent/vgeo/file.glb");
  EXPECT_EQ(r.exit_code, vgeo::kExitIo);
  EXPECT_NE(r.output.find("error[FILE_NOT_FOUND]"), std::string::npos) << r.output;
}

TEST(ImportCorpus, CliInfoJsonReportsSceneContents) {
  const fs::path f = require_dir(data_dir() / kGltf2) / "2CylinderEngine-glTF-Binary" / "2CylinderEngine.glb";
  CliResult r = run_cli("info --json --weld '" + f.string() + "'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  auto j = nlohmann::json::parse(r.output);
  for (const char* k : {"triangles", "vertices", "bounds", "meshes", "materials", "instances", "warnings", "stats"})
    EXPECT_TRUE(j.contains(k)) << k;
  EXPECT_EQ(j["instances"].size(), 67u);
  EXPECT_TRUE(j["stats"].contains("duplicates_welded"));
}
