// Entry point of vgeo_microbench (every tools/bench/*.cpp registers benchmarks).
#include <benchmark/benchmark.h>

BENCHMARK_MAIN();
