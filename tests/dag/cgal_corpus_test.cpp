// Builder properties on a few small real meshes of the CGAL corpus (tools/fetch-data):
// open borders, holes, several components, sharp features, sliding degenerate triangles.
#include <gtest/gtest.h>

#include <filesystem>

#include "dag_checks.h"
#include "support/paths.h"
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

}  // namespace
}  // namespace vgeo::test
