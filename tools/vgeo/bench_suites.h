#pragma once
// The `vgeo bench` suites. Each fills a SuiteReport (and sets `ran`); a suite that throws is
// recorded as failed by cmd_bench and the others still run.
#include <string>
#include <vector>

#include "bench_harness.h"

namespace vgeo::bench {

using SuiteFn = void (*)(const BenchConfig&, SuiteReport&);

struct SuiteDef {
  const char* name;
  const char* what;  // one line for --help
  SuiteFn run;
};

void run_raster_suite(const BenchConfig& cfg, SuiteReport& out);
void run_simplifier_suite(const BenchConfig& cfg, SuiteReport& out);
void run_lod_suite(const BenchConfig& cfg, SuiteReport& out);
void run_quantization_suite(const BenchConfig& cfg, SuiteReport& out);
void run_occlusion_suite(const BenchConfig& cfg, SuiteReport& out);
void run_scaling_suite(const BenchConfig& cfg, SuiteReport& out);
void run_stability_suite(const BenchConfig& cfg, SuiteReport& out);
void run_dagquality_suite(const BenchConfig& cfg, SuiteReport& out);
void run_backend_suite(const BenchConfig& cfg, SuiteReport& out);
void run_compression_suite(const BenchConfig& cfg, SuiteReport& out);
void run_build_suite(const BenchConfig& cfg, SuiteReport& out);
void run_shadows_suite(const BenchConfig& cfg, SuiteReport& out);

// In report order.
inline std::vector<SuiteDef> suite_list() {
  return {
      {"raster", "micropoly vs scanline vs brute-force reference, by triangle size", run_raster_suite},
      {"simplifier", "meshopt vs OpenMesh DAG build: time, levels, triangles drawn at equal tau", run_simplifier_suite},
      {"lod", "tau sweep: triangles drawn, frame time, image error vs full detail", run_lod_suite},
      {"quantization", "position grid bits: size, position error, decode time", run_quantization_suite},
      {"occlusion", "HZB occlusion off / coarse / fine mip: clusters culled, time saved", run_occlusion_suite},
      {"scaling", "instances and triangles per mesh vs triangles drawn and frame time", run_scaling_suite},
      {"stability", "far instances, extreme scales, camera inside/near plane, slivers", run_stability_suite},
      {"backend", "CPU reference vs Vulkan (lavapipe) per pass, level-by-level vs persistent GPU traversal", run_backend_suite},
      {"build", "vgeo build end to end per output and thread count: process CPU, stage CPU (import/build/write), peak RSS; --threads one-thread builds at once (the machine's ceiling)", run_build_suite},
      {"compression", "page format: file size against encode CPU over zstd levels, per-component sizes, parallel encode", run_compression_suite},
      {"shadows", "virtual shadow maps: pages marked/drawn/cached, shadow pass time vs lights and resolution, first vs cached frame", run_shadows_suite},
      {"dagquality", "cut triangles at equal measured error (1e-3, 1e-2 of the diagonal), measured/stored error", run_dagquality_suite},
  };
}

}  // namespace vgeo::bench
