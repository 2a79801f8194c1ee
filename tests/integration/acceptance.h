#pragma once
// End-to-end acceptance helpers shared by the corpus and generated-mesh tests: one run =
// import (or generate) → build_dag → verify_dag, optionally → encode_format → decode_format →
// verify_dag of the decoded DAG. Results are plain structs so the caller reports failures on
// the test thread (and the report writer turns them into docs/acceptance/issue3.md rows).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <sstream>
#include <string>
#include <sys/wait.h>
#include <vector>

#include "vgeo/dag/build.h"
#include "vgeo/core/error.h"
#include "vgeo/format/format.h"
#include "vgeo/verify/verify.h"
#include "support/run_command.h"  // CliResult, run_command
#include "support/sanitizer.h"     // kSanitizerBuild

namespace vgeo::test {

// Views of the acceptance verification: 8 random viewpoints x 4 thresholds = 32 tested cuts
// per DAG. The default 64 views are for `vgeo verify` on one file; over ~140 meshes x 2
// backends they would dominate the run. The structure, monotonic-bounds, cut-coverage and
// error-bound checks do not depend on the view count (they examine every element).
inline constexpr uint32_t kAcceptanceViews = 8;

inline const char* simplifier_name(Simplifier s) { return s == Simplifier::kMeshopt ? "meshopt" : "openmesh"; }

inline VerifyOptions acceptance_verify_options() {
  VerifyOptions o;  // defaults: every check, the builder's error lattice, non-strict border
  o.views = kAcceptanceViews;
  o.threads = 1;  // the caller parallelizes over meshes
  return o;
}

// Violation codes with counts and the first stored violation of each code with its values,
// e.g. "MONO_BOUNDS x3 [cluster 17: ... (parent_radius=1.2, child_radius=1.3)]".
inline std::string describe_violations(const VerifyReport& r) {
  std::ostringstream s;
  for (const ViolationCount& c : r.counts) {
    s << c.code << " x" << c.count;
    for (const Violation& v : r.violations) {
      if (v.code != c.code) continue;
      s << " [" << v.element << " " << v.index << ": " << v.message;
      if (!v.values.empty()) {
        s << " (";
        for (size_t i = 0; i < v.values.size(); ++i)
          s << (i ? ", " : "") << v.values[i].name << "=" << v.values[i].value;
        s << ")";
      }
      s << "]";
      break;
    }
    s << "; ";
  }
  for (const CheckStats& c : r.checks)
    if (!c.ran) s << "check " << c.check << " skipped: " << c.skipped_reason << "; ";
  return s.str();
}

// Everything one (mesh, backend) run measured.
struct AcceptanceRun {
  std::string mesh, backend;
  std::string error;  // a thrown VgeoError/std::exception (empty = none)
  BuildReport build;
  VerifyReport verify;
  bool roundtrip_ran = false;
  VerifyReport roundtrip_verify;  // verify_dag of decode_format(encode_format(dag))
  std::string roundtrip_error;
  double seconds_build = 0, seconds_verify = 0;

  bool ok() const {
    return error.empty() && verify.ok() && (!roundtrip_ran || (roundtrip_error.empty() && roundtrip_verify.ok()));
  }
  // One line naming mesh, backend and every violation code (empty when ok()).
  std::string failure() const {
    if (ok()) return "";
    std::string s = mesh + " [" + backend + "]: ";
    if (!error.empty()) return s + "threw " + error;
    if (!verify.ok()) s += "verify_dag: " + describe_violations(verify);
    if (!roundtrip_error.empty()) s += "format round trip threw " + roundtrip_error;
    else if (roundtrip_ran && !roundtrip_verify.ok())
      s += "verify_dag after encode/decode_format: " + describe_violations(roundtrip_verify);
    return s;
  }
};

inline double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// Page format options of the round trip: the default quantization (16 position bits, 10
// normal bits, 1/4096 UV grid), but lz4 instead of zstd-19: compression is lossless and
// checked by the format tests; zstd-19 would make the encode the slowest step here.
inline FormatOptions roundtrip_format_options() {
  FormatOptions f;
  f.compression = Compression::kLz4;
  return f;
}

// build → verify (→ encode → decode → verify). Never throws; everything lands in the result.
inline AcceptanceRun run_acceptance(const std::string& name, const Mesh& mesh, const std::vector<Material>& materials,
                                    Simplifier simplifier, bool roundtrip) {
  AcceptanceRun r;
  r.mesh = name;
  r.backend = simplifier_name(simplifier);
  try {
    BuildOptions b;
    b.simplifier = simplifier;
    b.threads = 1;  // the caller parallelizes over meshes; output is identical for any value
    auto t0 = std::chrono::steady_clock::now();
    BuiltScene scene;
    scene.meshes.push_back(build_dag(mesh, b, &r.build));
    r.seconds_build = seconds_since(t0);
    t0 = std::chrono::steady_clock::now();
    r.verify = verify_dag(scene.meshes[0], acceptance_verify_options());
    r.seconds_verify = seconds_since(t0);
    if (roundtrip) {
      r.roundtrip_ran = true;
      try {
        scene.materials = materials;
        scene.instances.push_back(Instance{});
        std::vector<uint8_t> bytes = encode_format(scene, roundtrip_format_options());
        BuiltScene decoded = decode_format(bytes.data(), bytes.size(), name);
        if (decoded.meshes.size() != 1) throw std::runtime_error("decoded mesh count != 1");
        const ClusterDag& in = scene.meshes[0];
        const ClusterDag& out = decoded.meshes[0];
        if (out.clusters.size() != in.clusters.size() || out.groups.size() != in.groups.size() ||
            out.triangle_materials.size() != in.triangle_materials.size())
          throw std::runtime_error("decoded DAG differs in cluster, group or triangle count");
        r.roundtrip_verify = verify_dag(decoded.meshes[0], acceptance_verify_options());
      } catch (const std::exception& e) {
        r.roundtrip_error = e.what();
      }
    }
  } catch (const std::exception& e) {
    r.error = e.what();
  }
  return r;
}

inline double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

}  // namespace vgeo::test
