// Builder properties on a few small real meshes of the CGAL corpus (tools/fetch-data):
// open borders, holes, several components, sharp features, sliding degenerate triangles.
#include <gtest/gtest.h>

#include <filesystem>

#include "dag_checks.h"
#include "support/paths.h"
#include "support/shapes.h"
#include "vgeo/dag/build.h"
#include "vgeo/mesh/import.h"

namespace vgeo::test {
namespace {

const char* kCorpus[] = {"elephant-with-holes", "blobby_3cc", "cube-ouvert", "degtri_sliding",
                         "corner_tris_with_hole", "hedra_open", "mushroom"};

class CgalCorpus : public ::testing::TestWithParam<std::tuple<const char*, Simplifier>> {};

TEST_P(CgalCorpus, DagPropertiesAndLockedBorders) {
  auto [name, simplifier] = GetParam();
  std::filesystem::path path = data_dir() / "cgal" / "meshes" / (std::string(name) + ".off");
  ASSERT_TRUE(std::filesystem::exists(path)) << path << " missing: run tools/fetch-data";
  Scene scene = import_scene(path.string()).scene;
  const Mesh& mesh = scene.meshes[0];
  BuildOptions o;
  o.simplifier = simplifier;
  o.threads = 2;
  BuildReport r;
  ClusterDag d = build_dag(mesh, o, &r);
  expect_dag_properties(d, mesh.triangle_count());
  expect_borders_preserved(d);
}

INSTANTIATE_TEST_SUITE_P(Build, CgalCorpus,
                         ::testing::Combine(::testing::ValuesIn(kCorpus),
                                            ::testing::Values(Simplifier::kMeshopt, Simplifier::kOpenMesh)),
                         [](const auto& info) {
                           std::string n = std::get<0>(info.param);
                           for (char& c : n)
                             if (!isalnum(static_cast<unsigned char>(c))) c = '_';
                           return n + (std::get<1>(info.param) == Simplifier::kMeshopt ? "_meshopt" : "_openmesh");
                         });

// A per-corner mesh (every triangle owns its corners) of a CGAL model
// simplifies like its welded twin. CGAL bull per-corner ended with 14 roots while coarse groups
// kept one or two corners per position, which meshopt 0.18 locks (spec/dag.md §3); the
// welded bull ends with 1.
TEST(Build, PerCornerCgalModelSimplifiesLikeItsWeldedTwin) {
  std::filesystem::path path = data_dir() / "cgal" / "meshes" / "bull.off";
  ASSERT_TRUE(std::filesystem::exists(path)) << path << " missing: run tools/fetch-data";
  Scene scene = import_scene(path.string()).scene;
  const Mesh m = make_per_corner(scene.meshes[0]);
  BuildOptions o;
  o.threads = 2;
  BuildReport r;
  ClusterDag d = build_dag(m, o, &r);
  expect_dag_properties(d, m.triangle_count());
  expect_borders_preserved(d, true);
  EXPECT_LE(r.root_clusters, 4u);
  EXPECT_GE(double(d.triangle_count()), 1.9 * double(m.triangle_count())) << "stored x";
}

}  // namespace
}  // namespace vgeo::test
