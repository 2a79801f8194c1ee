// Suites whose pipeline stages are not in this build yet: they report "skipped".
#include "bench_suites.h"

namespace vgeo::bench {

void run_quantization_suite(const BenchConfig&, SuiteReport& out) { mark_skipped(out, "lib/format"); }

}  // namespace vgeo::bench
