#pragma once
// Internals shared by the lib/vgeo/verify sources (not part of the public API).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include "vgeo/verify/verify.h"

namespace vgeo::verify_detail {

// An element index as printed in a violation's message.
inline std::string idx(uint64_t v) { return std::to_string(v); }

// Collects violations: counts every one, stores the first `cap` per code.
struct Sink {
  uint32_t cap = 64;
  std::vector<Violation> stored;
  std::vector<ViolationCount> counts;  // in order of first occurrence
  std::map<std::string, size_t> slot;

  // Counts one violation of `code`; true when the caller should also store it.
  bool take(const std::string& code) {
    auto [it, inserted] = slot.try_emplace(code, counts.size());
    if (inserted) counts.push_back({code, 0});
    return ++counts[it->second].count <= cap;
  }
  void add(const std::string& code, const char* check, const char* element, uint64_t index,
           std::string message, std::vector<VerifyValue> values = {}) {
    if (!take(code)) return;
    stored.push_back({code, check, element, index, std::move(message), std::move(values)});
  }
  uint64_t total() const {
    uint64_t n = 0;
    for (const auto& c : counts) n += c.count;
    return n;
  }
  // Appends another sink's violations after ours (counts add up; storage respects cap).
  void merge(const Sink& other) {
    std::map<std::string, uint64_t> room;
    for (const auto& c : other.counts) {
      auto [it, inserted] = slot.try_emplace(c.code, counts.size());
      if (inserted) counts.push_back({c.code, 0});
      uint64_t before = counts[it->second].count;
      room[c.code] = before < cap ? cap - before : 0;
      counts[it->second].count += c.count;
    }
    for (const auto& v : other.stored) {
      uint64_t& r = room[v.code];
      if (r > 0) {
        stored.push_back(v);
        --r;
      }
    }
  }
};

inline uint32_t float_bits(float f) {
  uint32_t u;
  std::memcpy(&u, &f, 4);
  return u;
}
inline bool same_bits(float a, float b) { return float_bits(a) == float_bits(b); }
inline bool same_bits(const Sphere& a, const Sphere& b) {
  return same_bits(a.center.x, b.center.x) && same_bits(a.center.y, b.center.y) &&
         same_bits(a.center.z, b.center.z) && same_bits(a.radius, b.radius);
}
inline bool finite(const Sphere& s) {
  return std::isfinite(s.center.x) && std::isfinite(s.center.y) && std::isfinite(s.center.z) &&
         std::isfinite(s.radius);
}

// Containment tolerance for MONO_BOUNDS and the conservative-bounds checks
// (spec/invariants.md §Tolerances): 2^-40 relative covers the double rounding of
// distance_d() (a few units of 2^-53) with margin and stays far below float's 2^-24, so a
// sphere shrunk by even one float ulp is still reported.
inline constexpr double kContainmentRelTolerance = 1.0 / double(1ull << 40);

inline bool contains_tol(const Sphere& outer, const Sphere& inner) {
  if (inner.radius < 0) return true;
  if (outer.radius < 0) return false;
  double lhs = distance_d(outer.center, inner.center) + double(inner.radius);
  double rhs = double(outer.radius);
  return lhs <= rhs + kContainmentRelTolerance * (lhs + rhs);
}
// One float ulp at `magnitude` (at least the smallest normal float's ulp).
inline double float_ulp(double magnitude) {
  float m = float(std::max(std::fabs(magnitude), double(std::numeric_limits<float>::min())));
  return double(std::nextafter(m, std::numeric_limits<float>::infinity())) - double(m);
}

// How far `inner` sticks out of `outer`: absolute, in float ulps and relative to the larger of
// the two sides of the test (d + r_in vs r_out). Reported with every containment miss so a reader
// can tell float rounding (a fraction of an ulp to a few ulps: spheres computed in float and not
// rounded outward) from geometry (many ulps, relative 1e-3 and up). spec/invariants.md §Tolerances.
struct ContainmentMiss {
  double excess = 0;    // d + r_in − r_out (object units)
  double ulps = 0;      // excess / ulp_f(max(d + r_in, r_out))
  double relative = 0;  // excess / max(d + r_in, r_out)
};
inline ContainmentMiss containment_miss(const Sphere& outer, const Sphere& inner) {
  double lhs = distance_d(outer.center, inner.center) + double(inner.radius);
  double scale = std::max(lhs, double(outer.radius));
  ContainmentMiss m;
  m.excess = lhs - double(outer.radius);
  m.ulps = m.excess / float_ulp(scale);
  m.relative = scale > 0 ? m.excess / scale : std::numeric_limits<double>::infinity();
  return m;
}
// " (misses by 1.2e-07 = 0.5 ulp, 3e-08 relative)"
std::string miss_text(const ContainmentMiss& m);
// The leaf clusters' triangles as a corner soup (9 floats a triangle, cluster order): the
// surface the error checks measure against (verify_error.cpp, verify_certify.cpp).
std::vector<float> leaf_corner_soup(const ClusterDag& dag);
inline std::vector<VerifyValue> miss_values(const ContainmentMiss& m) {
  return {{"excess", m.excess}, {"excess_ulps", m.ulps}, {"excess_relative", m.relative}};
}

std::string fmt_sphere(const Sphere& s);
std::string fmt_float(double v);

// Deterministic, platform-independent random numbers (std distributions are not).
struct SplitMix64 {
  uint64_t state;
  explicit SplitMix64(uint64_t seed) : state(seed) {}
  uint64_t next() {
    uint64_t z = (state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  double uniform() { return double(next() >> 11) * (1.0 / double(1ull << 53)); }  // [0,1)
  uint32_t below(uint32_t n) { return n == 0 ? 0 : uint32_t(next() % n); }
};

// Check implementations (one per source file). Each returns false when it could not run.
// `index_safe` (out) says whether the later checks may index the DAG's arrays.
void check_structure(const ClusterDag& dag, Sink& sink, CheckStats& stats, bool* index_safe);
void check_monotonic_static(const ClusterDag& dag, Sink& sink, CheckStats& stats);
// Views: MONO_PROJECTED + CUT_* + CRACK_* over the same random views.
struct ViewCheckResult {
  uint64_t views = 0, cuts = 0, projected_edges = 0, border_edges_changed = 0;
  std::vector<double> cut_sizes;
};
void check_views(const ClusterDag& dag, const VerifyOptions& options, bool monotonic, bool cut,
                 bool crack, Sink& mono_sink, Sink& cut_sink, Sink& crack_sink,
                 ViewCheckResult* result);
struct ErrorBoundResult {
  std::vector<double> ratios;                       // all non-leaf clusters with stored error > 0
  std::vector<std::vector<double>> ratios_per_level;
  uint64_t samples = 0, clusters = 0;
};
// The largest |coordinate| of the clusters' stored vertices: the scale of the error checks'
// float tolerances (ERROR_BOUND, ERROR_CERTIFIED).
double largest_stored_coordinate(const ClusterDag& dag);

void check_error_bound(const ClusterDag& dag, const VerifyOptions& options, Sink& sink,
                       ErrorBoundResult* result);

// ERROR_CERTIFIED (verify_certify.cpp): each non-leaf cluster's stored error proven to bound the
// continuous deviation (spec/invariants.md §5 "Certified bound").
struct CertifiedBoundResult {
  uint64_t clusters = 0, subtriangles = 0;  // clusters certified; sub-triangles examined
};
void check_certified_bound(const ClusterDag& dag, const VerifyOptions& options, Sink& sink, CertifiedBoundResult* result);

Distribution make_distribution(std::vector<double> values);

// The group order used by the cut DP: groups by decreasing level (ties by index).
std::vector<uint32_t> groups_by_decreasing_level(const ClusterDag& dag);

}  // namespace vgeo::verify_detail
