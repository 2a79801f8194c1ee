// Asset files: both containers are read back by magic, written atomically, and the page
// format's decoded DAG still passes every invariant (what `vgeo verify FILE` checks).
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <unistd.h>

#include "support/paths.h"
#include "support/shapes.h"
#include "vgeo/dag/build.h"
#include "vgeo/format/asset_file.h"
#include "vgeo/verify/verify.h"

namespace vgeo {
namespace {

std::filesystem::path scratch(const std::string& name) {
  auto dir = std::filesystem::temp_directory_path() / ("vgeo_asset_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  return dir / name;
}

BuiltScene small_scene() {
  BuiltScene s;
  s.meshes.push_back(build_dag(test::make_sphere(24, 32), BuildOptions{}));
  s.materials.push_back(Material{});
  s.instances.push_back(Instance{});
  return s;
}

std::string error_code_of(const std::string& path) {
  try {
    read_asset_file(path);
  } catch (const VgeoError& e) {
    return e.error().code;
  }
  return "";
}

TEST(AssetFile, KindFollowsExtension) {
  EXPECT_EQ(asset_file_kind_for_path("a/b.vgeodag"), AssetFileKind::kDagFile);
  EXPECT_EQ(asset_file_kind_for_path("a/b.vgp"), AssetFileKind::kPages);
  EXPECT_EQ(asset_file_kind_for_path("b"), AssetFileKind::kPages);
}

TEST(AssetFile, BothContainersReadBackByMagic) {
  BuiltScene s = small_scene();
  auto dag_path = scratch("s.vgeodag"), page_path = scratch("s.vgp");
  write_asset_file(dag_path.string(), s, AssetFileKind::kDagFile);
  write_asset_file(page_path.string(), s, AssetFileKind::kPages);
  BuiltScene from_dag = read_asset_file(dag_path.string());
  BuiltScene from_pages = read_asset_file(page_path.string());
  ASSERT_EQ(from_dag.meshes.size(), 1u);
  ASSERT_EQ(from_pages.meshes.size(), 1u);
  // The DAG file is lossless; the page format keeps the topology and quantizes positions.
  EXPECT_EQ(from_dag.meshes[0].positions, s.meshes[0].positions);
  EXPECT_EQ(from_pages.meshes[0].clusters.size(), s.meshes[0].clusters.size());
  EXPECT_EQ(from_pages.meshes[0].triangle_count(), s.meshes[0].triangle_count());
}

TEST(AssetFile, DecodedPageFormatPassesEveryInvariant) {
  auto page_path = scratch("v.vgp");
  write_asset_file(page_path.string(), small_scene(), AssetFileKind::kPages);
  BuiltScene decoded = read_asset_file(page_path.string());
  VerifyOptions o;
  o.views = 16;
  VerifyReport r = verify_dag(decoded.meshes[0], o);
  EXPECT_TRUE(r.ok()) << verify_report_summary(r);
}

TEST(AssetFile, RejectsUnknownTruncatedAndMissingFiles) {
  auto unknown = scratch("unknown.bin");
  std::ofstream(unknown) << "not an asset file";
  EXPECT_EQ(error_code_of(unknown.string()), "ASSET_FILE_UNKNOWN");
  EXPECT_EQ(error_code_of(scratch("missing.vgp").string()), "FILE_NOT_FOUND");
  auto page_path = scratch("t.vgp");
  write_asset_file(page_path.string(), small_scene(), AssetFileKind::kPages);
  std::filesystem::resize_file(page_path, std::filesystem::file_size(page_path) - 1);
  EXPECT_EQ(error_code_of(page_path.string()), "FORMAT_TRUNCATED");
}

// One reader, one code: every invalid vector of spec/vectors (page format) and
// spec/vectors/dag (VGEODAG1) is rejected by read_asset_file — what `vgeo verify` reads with —
// with exactly the code its manifest gives (a bad magic included: the extension picks the
// reader when neither magic matches), and every valid one is read.
TEST(AssetFile, EveryVectorIsRejectedWithItsManifestCode) {
  size_t checked = 0;
  for (const std::filesystem::path& dir : {test::source_dir() / "spec" / "vectors", test::source_dir() / "spec" / "vectors" / "dag"}) {
    std::ifstream manifest(dir / "manifest.txt");
    ASSERT_TRUE(manifest) << dir;
    for (std::string line; std::getline(manifest, line);) {
      if (line.empty() || line[0] == '#') continue;
      std::istringstream words(line);
      std::string name, expected;
      words >> name >> expected;
      EXPECT_EQ(error_code_of((dir / name).string()), expected == "OK" ? "" : expected) << dir / name;
      ++checked;
    }
  }
  EXPECT_GT(checked, 150u);
  // A file named as neither format keeps ASSET_FILE_UNKNOWN (above); a bad magic under the page
  // extension (.vgp) is the page decoder's.
  auto named_page = scratch("bad_magic.vgp");
  std::ofstream(named_page) << "VGEOPAGX and more bytes than a header would need, all of them wrong....";
  EXPECT_EQ(error_code_of(named_page.string()), "FORMAT_BAD_MAGIC");
}

}  // namespace
}  // namespace vgeo
