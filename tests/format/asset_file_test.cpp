// Asset files: both containers are read back by magic, written atomically, and the page
// format's decoded DAG still passes every invariant (what `vgeo verify FILE` checks).
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
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
  EXPECT_EQ(asset_file_kind_for_path("a/b.vgeo"), AssetFileKind::kPages);
  EXPECT_EQ(asset_file_kind_for_path("b"), AssetFileKind::kPages);
}

TEST(AssetFile, BothContainersReadBackByMagic) {
  BuiltScene s = small_scene();
  auto dag_path = scratch("s.vgeodag"), page_path = scratch("s.vgeo");
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
  auto page_path = scratch("v.vgeo");
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
  EXPECT_EQ(error_code_of(scratch("missing.vgeo").string()), "FILE_NOT_FOUND");
  auto page_path = scratch("t.vgeo");
  write_asset_file(page_path.string(), small_scene(), AssetFileKind::kPages);
  std::filesystem::resize_file(page_path, std::filesystem::file_size(page_path) - 1);
  EXPECT_EQ(error_code_of(page_path.string()), "FORMAT_TRUNCATED");
}

}  // namespace
}  // namespace vgeo
