// The runtime's per-frame LOD cut passes lib/vgeo/verify's cut checker (every leaf covered
// exactly once, crack-free) on real DAGs from build_dag, over random cameras.
#include <gtest/gtest.h>
#include <rapidcheck/gtest.h>

#include "render/render_helpers.h"
#include "vgeo/verify/verify.h"

namespace vgeo {
namespace {

struct CutFixture {
  RenderScene scene = test::make_row_scene(1.0, 0.0, 3);
  std::vector<CutCheckContext> contexts;
  CutFixture() {
    for (const ClusterDag& dag : scene.meshes) contexts.push_back(prepare_cut_check(dag));
  }
};

const CutFixture& fixture() {
  static const CutFixture f;
  return f;
}

RC_GTEST_PROP(RuntimeCut, EveryFrameCutPassesTheVerifierCutCheck, ()) {
  const CutFixture& f = fixture();
  Camera cam = test::look_camera({*rc::gen::inRange(-30, 30) * 0.5, *rc::gen::inRange(1, 20) * 0.5,
                                  *rc::gen::inRange(-30, 30) * 0.5},
                                 {*rc::gen::inRange(-5, 5) * 1.0, 1.0, *rc::gen::inRange(-10, 2) * 1.0},
                                 *rc::gen::element(64u, 1280u), *rc::gen::element(48u, 720u));
  float tau = *rc::gen::element(0.5f, 1.0f, 4.0f, 32.0f);
  ThreadPool pool(2);
  ViewParams view = make_view(cam);
  std::vector<VisibleCluster> cut = select_cut(f.scene.meshes, f.scene.instances, view, tau, pool);
  for (uint32_t i = 0; i < f.scene.instances.size(); ++i) {
    uint32_t mesh = f.scene.instances[i].mesh;
    CutCheck check = check_cut(f.scene.meshes[mesh], f.contexts[mesh], cut_of_instance(cut, i));
    RC_ASSERT(f.contexts[mesh].usable);
    RC_ASSERT(check.ok());
  }
}

}  // namespace
}  // namespace vgeo
