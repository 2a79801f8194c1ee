#pragma once
// The throughput ceiling of `vgeo bench build` (tools/vgeo/bench_build.cpp): N independent
// one-thread builds started at once share the machine as an N-thread build's threads would, but
// with no serial part, no synchronization and no work split; how much faster than one lone build
// they finish N builds is the most any N-thread build can gain on this machine (cores, shared
// caches and memory bandwidth, the disk that two fsyncs meet on). Header-only so that
// tests/integration/bench_build_test.cpp checks the arithmetic against given seconds.
#include <limits>

namespace vgeo::bench {

// One repetition's seconds of one quantity: the whole build's wall, or one stage's wall seconds.
struct CeilingSeconds {
  double one_thread = 0;  // a lone --threads 1 build
  double n_threads = 0;   // a lone --threads N build
  double concurrent = 0;  // N one-thread builds at once: the set's wall, or a stage's seconds in one of them
};

struct CeilingRatios {
  double ceiling = 0;  // N x one_thread / concurrent: the speedup of N perfectly split threads on this machine
  double speedup = 0;  // one_thread / n_threads: what the N-thread build achieves
  double share = 0;    // speedup / ceiling (= concurrent / (N x n_threads): one_thread cancels)
};

// Ratios of one repetition (variants run back to back, so the same minute's machine); a time that
// is not positive gives NaN, which the medians (summarize) leave out.
inline CeilingRatios ceiling_ratios(const CeilingSeconds& s, unsigned n) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  CeilingRatios r;
  r.ceiling = s.one_thread > 0 && s.concurrent > 0 ? double(n) * s.one_thread / s.concurrent : nan;
  r.speedup = s.one_thread > 0 && s.n_threads > 0 ? s.one_thread / s.n_threads : nan;
  r.share = r.speedup / r.ceiling;
  return r;
}

}  // namespace vgeo::bench
