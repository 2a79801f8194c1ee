// `vgeo gen` end to end through the built binary.
#include <gtest/gtest.h>
#include <tiny_gltf.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "support/errors.h"
#include "support/paths.h"
#include "support/shapes.h"
#include "vgeo/mesh/export.h"

namespace vgeo {
namespace {

namespace fs = std::filesystem;

struct CliDir {
  fs::path path;
  CliDir() {
    path = fs::temp_directory_path() / ("vgeo_gen_cli_" + std::to_string(getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~CliDir() { fs::remove_all(path); }
  std::string file(const std::string& name) const { return (path / name).string(); }
};

// Runs `vgeo <args>` with stdout/stderr captured to files; returns the exit code.
int run(const CliDir& dir, const std::string& args, std::string* err = nullptr) {
  std::string cmd = "'" + test::cli_path() + "' " + args + " >'" + dir.file("stdout") + "' 2>'" + dir.file("stderr") + "'";
  int rc = std::system(cmd.c_str());
  if (err) {
    std::ifstream f(dir.file("stderr"));
    *err = std::string(std::istreambuf_iterator<char>(f), {});
  }
  return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
}

TEST(GenerateCli, SameArgumentsGiveByteIdenticalFiles) {
  CliDir dir;
  // Every shape as GLB, every format for the sphere (process start-up dominates).
  for (const char* shape : {"sphere", "terrain", "islands", "thin", "torus"}) {
    for (const char* ext : {"glb", "obj", "ply", "off"}) {
      if (std::string(ext) != "glb" && std::string(shape) != "sphere") continue;
      std::string a = dir.file(std::string(shape) + "_a." + ext), b = dir.file(std::string(shape) + "_b." + ext);
      ASSERT_EQ(run(dir, std::string("gen ") + shape + " --triangles 3000 --seed 7 -o '" + a + "'"), 0);
      ASSERT_EQ(run(dir, std::string("gen ") + shape + " --triangles 3000 --seed 7 -j 2 -o '" + b + "'"), 0);
      std::vector<uint8_t> bytes = test::read_file_bytes(a);
      EXPECT_GT(bytes.size(), 1000u) << shape << "." << ext;
      EXPECT_EQ(bytes, test::read_file_bytes(b)) << shape << "." << ext;
    }
  }
  // A different seed gives a different file.
  ASSERT_EQ(run(dir, "gen sphere --triangles 3000 --seed 8 -o '" + dir.file("s8.glb") + "'"), 0);
  EXPECT_NE(test::read_file_bytes(dir.file("s8.glb")), test::read_file_bytes(dir.file("sphere_a.glb")));
}

TEST(GenerateCli, SubdivideQuadruplesAndOutputLoadsInTinyGltf) {
  CliDir dir;
  ASSERT_EQ(run(dir, "gen torus -n 2000 --subdivide 2 -o '" + dir.file("t.glb") + "'"), 0);
  std::vector<uint8_t> glb = test::read_file_bytes(dir.file("t.glb"));
  tinygltf::TinyGLTF loader;
  tinygltf::Model model;
  std::string err, warn;
  ASSERT_TRUE(loader.LoadBinaryFromMemory(&model, &err, &warn, glb.data(), unsigned(glb.size()))) << err;
  size_t indices = 0;
  for (const auto& p : model.meshes.at(0).primitives) indices += model.accessors[size_t(p.indices)].count;
  // torus at 2000: rings 22, segments 45 -> 1980 triangles, x16.
  EXPECT_EQ(indices / 3, 1980u * 16);
}

TEST(GenerateCli, InputFileIsDensified) {
  CliDir dir;
  Mesh sphere = test::make_sphere(5, 7);
  write_off(sphere, dir.file("in.off"));
  ASSERT_EQ(run(dir, "gen --input '" + dir.file("in.off") + "' --subdivide 1 -o '" + dir.file("out.off") + "'"), 0);
  std::ifstream f(dir.file("out.off"));
  std::string magic;
  size_t v = 0, t = 0;
  f >> magic >> v >> t;
  EXPECT_EQ(magic, "OFF");
  EXPECT_EQ(t, 4 * sphere.triangle_count());
  EXPECT_EQ(v, sphere.vertex_count() + 3 * sphere.triangle_count() / 2);  // V + E on a closed mesh
}

TEST(GenerateCli, BadArgumentsGiveStableCodesAndExitCodes) {
  CliDir dir;
  std::string err;
  EXPECT_EQ(run(dir, "gen cube -o '" + dir.file("x.glb") + "'", &err), kExitUsage);
  EXPECT_NE(err.find("error[GEN_UNKNOWN_SHAPE]"), std::string::npos) << err;
  EXPECT_EQ(run(dir, "gen sphere -o '" + dir.file("x.stl") + "'", &err), kExitUsage);
  EXPECT_NE(err.find("error[EXPORT_UNKNOWN_FORMAT]"), std::string::npos) << err;
  EXPECT_EQ(run(dir, "gen sphere -n 0 -o '" + dir.file("x.glb") + "'", &err), kExitUsage);
  EXPECT_NE(err.find("error[GEN_TRIANGLES_OUT_OF_RANGE]"), std::string::npos) << err;
  EXPECT_EQ(run(dir, "gen -o '" + dir.file("x.glb") + "'", &err), kExitUsage);
  EXPECT_NE(err.find("error[GEN_NO_SHAPE]"), std::string::npos) << err;
  EXPECT_EQ(run(dir, "gen sphere --input '" + dir.file("a.off") + "' -o '" + dir.file("x.glb") + "'", &err), kExitUsage);
  EXPECT_NE(err.find("error[GEN_SHAPE_AND_INPUT]"), std::string::npos) << err;
  EXPECT_EQ(run(dir, "gen sphere", &err), kExitUsage);  // -o is required
  EXPECT_EQ(run(dir, "gen --input '" + dir.file("missing.off") + "' -o '" + dir.file("x.glb") + "'", &err), kExitIo);
  EXPECT_NE(err.find("error[FILE_NOT_FOUND]"), std::string::npos) << err;  // importer's code
  EXPECT_EQ(run(dir, "gen sphere -o '" + dir.file("nodir/x.glb") + "'", &err), kExitIo);
  EXPECT_NE(err.find("error[IO_WRITE_FAILED]"), std::string::npos) << err;
  // Non-manifold input to --subdivide: a bow-tie (two triangles sharing one vertex).
  {
    std::ofstream f(dir.file("bowtie.off"));
    f << "OFF\n5 2 0\n0 0 0\n1 0 0\n0 1 0\n-1 0 0\n0 -1 0\n3 0 1 2\n3 0 3 4\n";
  }
  EXPECT_EQ(run(dir, "gen --input '" + dir.file("bowtie.off") + "' --subdivide 1 -o '" + dir.file("x.glb") + "'", &err),
            kExitBadInput);
  EXPECT_NE(err.find("error[SUBDIVIDE_NON_MANIFOLD]"), std::string::npos) << err;
  EXPECT_FALSE(fs::exists(dir.file("x.glb")));
}

}  // namespace
}  // namespace vgeo
