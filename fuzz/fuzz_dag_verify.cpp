// libFuzzer target for the VGEODAG1 reader (the interchange format other implementations hand
// `vgeo verify`), followed by verify_dag on every mesh it accepts: a decoded DAG is untrusted
// input to the checker too.
#include <string>

#include "vgeo/core/error.h"
#include "vgeo/dag/dag_io.h"
#include "vgeo/verify/verify.h"

// A few views and one thread: every check still runs, at a cost that keeps thousands of
// executions per second on the small DAGs the seeds hold.
constexpr uint32_t kFuzzViews = 4;
constexpr uint32_t kFuzzThresholdsPerView = 2;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  vgeo::BuiltScene scene;
  try {
    scene = vgeo::decode_dag_file(data, size, "fuzz.vgeodag");
  } catch (const vgeo::VgeoError&) {
    return 0;
  }
  vgeo::VerifyOptions options;
  options.views = kFuzzViews;
  options.thresholds_per_view = kFuzzThresholdsPerView;
  options.threads = 1;
  for (const vgeo::ClusterDag& dag : scene.meshes) {
    try {
      (void)vgeo::verify_dag(dag, options);
    } catch (const vgeo::VgeoError&) {
    }
  }
  return 0;
}
