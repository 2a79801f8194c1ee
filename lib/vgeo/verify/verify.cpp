// verify_dag(): runs the requested checks in order and assembles the report; the JSON
// and text renderings of a report. spec/invariants.md.
#include "vgeo/verify/verify.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <sstream>

#include "vgeo/verify/verify_detail.h"

namespace vgeo {
namespace verify_detail {

std::string fmt_float(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.9g", v);
  return buf;
}
std::string fmt_sphere(const Sphere& s) {
  return "(" + fmt_float(s.center.x) + ", " + fmt_float(s.center.y) + ", " + fmt_float(s.center.z) + "; r " +
         fmt_float(s.radius) + ")";
}

std::string miss_text(const ContainmentMiss& m) {
  char buf[128];
  std::snprintf(buf, sizeof buf, " (misses by %.3g = %.3g ulp, %.3g relative)", m.excess, m.ulps, m.relative);
  return buf;
}

Distribution make_distribution(std::vector<double> v) {
  Distribution d;
  d.count = v.size();
  if (v.empty()) return d;
  std::sort(v.begin(), v.end());
  auto at = [&](double q) { return v[std::min(v.size() - 1, size_t(q * double(v.size() - 1) + 0.5))]; };
  d.min = v.front();
  d.median = at(0.5);
  d.p95 = at(0.95);
  d.max = v.back();
  return d;
}

}  // namespace verify_detail

using namespace verify_detail;

namespace {
constexpr VerifyCheck kAllChecks[] = {kCheckStructure, kCheckMonotonic, kCheckCut, kCheckCrack, kCheckErrorBound,
                                      kCheckCertifiedBound};

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}
}  // namespace

const char* verify_check_name(VerifyCheck check) {
  switch (check) {
    case kCheckStructure: return "structure";
    case kCheckMonotonic: return "monotonic";
    case kCheckCut: return "cut";
    case kCheckCrack: return "crack";
    case kCheckErrorBound: return "error_bound";
    case kCheckCertifiedBound: return "certified_bound";
    default: return "?";
  }
}

bool parse_verify_checks(const std::string& list, uint32_t* checks) {
  uint32_t out = 0;
  std::stringstream ss(list);
  std::string item;
  while (std::getline(ss, item, ',')) {
    if (item.empty()) continue;
    if (item == "all") {
      out |= kCheckAll;
      continue;
    }
    bool found = false;
    for (VerifyCheck c : kAllChecks)
      if (item == verify_check_name(c)) out |= c, found = true;
    if (!found) return false;
  }
  if (!out) return false;
  *checks = out;
  return true;
}

uint64_t VerifyReport::total_violations() const {
  uint64_t n = 0;
  for (const auto& c : counts) n += c.count;
  return n;
}
uint64_t VerifyReport::count(const std::string& code) const {
  for (const auto& c : counts)
    if (c.code == code) return c.count;
  return 0;
}
bool VerifyReport::ok() const {
  if (total_violations() != 0) return false;
  for (const auto& c : checks)
    if (!c.ran) return false;  // a requested check that could not run is not a pass
  return true;
}

VerifyReport verify_dag(const ClusterDag& dag, const VerifyOptions& options) {
  VerifyReport report;
  report.clusters = dag.clusters.size();
  report.groups = dag.groups.size();
  report.levels = dag.level_count;
  report.triangles = dag.triangle_count();
  for (const auto& k : dag.clusters) report.leaf_clusters += k.generating_group == kNone;

  Sink all;
  all.cap = options.max_stored_per_code;
  auto stats_for = [&](VerifyCheck c) -> CheckStats* {
    if (!(options.checks & c)) return nullptr;
    CheckStats st;
    st.check = verify_check_name(c);
    report.checks.push_back(st);
    return &report.checks.back();
  };
  report.checks.reserve(6);

  // Structure always runs (the other checks index the arrays); it is reported only when asked.
  bool safe = false;
  {
    auto t0 = std::chrono::steady_clock::now();
    Sink s;
    s.cap = options.max_stored_per_code;
    CheckStats st;
    st.check = verify_check_name(kCheckStructure);
    check_structure(dag, s, st, &safe);
    st.ran = true;
    st.seconds = seconds_since(t0);
    if (CheckStats* out = stats_for(kCheckStructure)) {
      *out = st;
      all.merge(s);
    } else if (!safe) {
      all.merge(s);  // index-safety violations are reported even when not requested
    }
  }
  const char* unsafe_reason = "skipped: the structure check found index-safety violations";

  CheckStats* mono = stats_for(kCheckMonotonic);
  CheckStats* cut = stats_for(kCheckCut);
  CheckStats* crack = stats_for(kCheckCrack);
  CheckStats* err = stats_for(kCheckErrorBound);
  CheckStats* cert = stats_for(kCheckCertifiedBound);
  if (!safe) {
    for (CheckStats* st : {mono, cut, crack, err, cert})
      if (st) st->skipped_reason = unsafe_reason;
  } else {
    Sink mono_sink, cut_sink, crack_sink, err_sink, cert_sink;
    mono_sink.cap = cut_sink.cap = crack_sink.cap = err_sink.cap = cert_sink.cap = options.max_stored_per_code;
    if (mono) {
      auto t0 = std::chrono::steady_clock::now();
      check_monotonic_static(dag, mono_sink, *mono);
      mono->seconds += seconds_since(t0);
    }
    if ((mono || cut || crack) && options.views > 0) {
      auto t0 = std::chrono::steady_clock::now();
      ViewCheckResult vr;
      check_views(dag, options, mono != nullptr, cut != nullptr, crack != nullptr, mono_sink, cut_sink, crack_sink,
                  &vr);
      double sec = seconds_since(t0);
      report.cuts_tested = vr.cuts;
      report.border_edges_changed = vr.border_edges_changed;
      report.cut_clusters = make_distribution(vr.cut_sizes);
      if (mono) mono->items += vr.projected_edges, mono->seconds += sec;
      if (cut) cut->items = vr.cuts, cut->seconds = sec;
      if (crack) crack->items = vr.cuts, crack->seconds = sec;
    }
    if (err) {
      auto t0 = std::chrono::steady_clock::now();
      ErrorBoundResult er;
      check_error_bound(dag, options, err_sink, &er);
      err->seconds = seconds_since(t0);
      err->items = er.clusters;
      report.error_samples = er.samples;
      report.error_ratio = make_distribution(er.ratios);
      for (auto& lv : er.ratios_per_level) report.error_ratio_per_level.push_back(make_distribution(lv));
    }
    if (cert) {
      auto t0 = std::chrono::steady_clock::now();
      CertifiedBoundResult cr;
      check_certified_bound(dag, options, cert_sink, &cr);
      cert->seconds = seconds_since(t0);
      cert->items = cr.clusters;
    }
    for (CheckStats* st : {mono, cut, crack, err, cert})
      if (st) st->ran = true;
    if (mono) mono->violations = mono_sink.total();
    if (cut) cut->violations = cut_sink.total();
    if (crack) crack->violations = crack_sink.total();
    if (err) err->violations = err_sink.total();
    if (cert) cert->violations = cert_sink.total();
    all.merge(mono_sink);
    all.merge(cut_sink);
    all.merge(crack_sink);
    all.merge(err_sink);
    all.merge(cert_sink);
  }
  report.violations = std::move(all.stored);
  report.counts = std::move(all.counts);
  return report;
}

namespace {
nlohmann::json dist_json(const Distribution& d) {
  return {{"count", d.count}, {"min", d.min}, {"median", d.median}, {"p95", d.p95}, {"max", d.max}};
}
// JSON has no inf/NaN: encode them as strings so the report stays valid JSON.
nlohmann::json num(double v) {
  if (std::isnan(v)) return "nan";
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  return v;
}
}  // namespace

std::string verify_report_json(const VerifyReport& r, const std::string& mesh) {
  nlohmann::json j;
  j["mesh"] = mesh;
  j["ok"] = r.ok();
  j["clusters"] = r.clusters;
  j["groups"] = r.groups;
  j["leaf_clusters"] = r.leaf_clusters;
  j["levels"] = r.levels;
  j["triangles"] = r.triangles;
  j["cuts_tested"] = r.cuts_tested;
  j["border_edges_changed"] = r.border_edges_changed;
  j["cut_clusters"] = dist_json(r.cut_clusters);
  j["error_ratio"] = dist_json(r.error_ratio);
  j["error_samples"] = r.error_samples;
  nlohmann::json per_level = nlohmann::json::array();
  for (size_t l = 0; l < r.error_ratio_per_level.size(); ++l)
    if (r.error_ratio_per_level[l].count) {
      auto d = dist_json(r.error_ratio_per_level[l]);
      d["level"] = l;
      per_level.push_back(d);
    }
  j["error_ratio_per_level"] = per_level;
  nlohmann::json checks = nlohmann::json::array();
  for (const auto& c : r.checks) {
    nlohmann::json cj{{"check", c.check}, {"ran", c.ran}, {"items", c.items}, {"violations", c.violations},
                      {"seconds", c.seconds}};
    if (!c.skipped_reason.empty()) cj["skipped_reason"] = c.skipped_reason;
    checks.push_back(cj);
  }
  j["checks"] = checks;
  nlohmann::json counts = nlohmann::json::object();
  for (const auto& c : r.counts) counts[c.code] = c.count;
  j["violation_counts"] = counts;
  nlohmann::json vs = nlohmann::json::array();
  for (const auto& v : r.violations) {
    nlohmann::json values = nlohmann::json::object();
    for (const auto& x : v.values) values[x.name] = num(x.value);
    vs.push_back({{"code", v.code}, {"check", v.check}, {"element", v.element}, {"index", v.index},
                  {"message", v.message}, {"values", values}});
  }
  j["violations"] = vs;
  return j.dump(2);
}

std::string verify_report_summary(const VerifyReport& r) {
  std::string out;
  char line[256];
  std::snprintf(line, sizeof line, "%llu clusters (%llu leaves), %llu groups, %llu levels, %llu stored triangles\n",
                (unsigned long long)r.clusters, (unsigned long long)r.leaf_clusters, (unsigned long long)r.groups,
                (unsigned long long)r.levels, (unsigned long long)r.triangles);
  out += line;
  std::snprintf(line, sizeof line, "  %-15s %-8s %9s %11s %9s\n", "check", "result", "items", "violations", "seconds");
  out += line;
  for (const auto& c : r.checks) {
    const char* verdict = !c.ran ? "SKIPPED" : c.violations ? "FAIL" : "ok";
    std::snprintf(line, sizeof line, "  %-15s %-8s %9llu %11llu %9.3f\n", c.check.c_str(), verdict,
                  (unsigned long long)c.items, (unsigned long long)c.violations, c.seconds);
    out += line;
    if (!c.skipped_reason.empty()) out += "    " + c.skipped_reason + "\n";
  }
  for (const auto& c : r.counts) {
    std::snprintf(line, sizeof line, "  %-28s %llu\n", c.code.c_str(), (unsigned long long)c.count);
    out += line;
  }
  if (r.cuts_tested) {
    std::snprintf(line, sizeof line, "  cuts tested: %llu, selected clusters per cut: min %.0f median %.0f max %.0f\n",
                  (unsigned long long)r.cuts_tested, r.cut_clusters.min, r.cut_clusters.median, r.cut_clusters.max);
    out += line;
    if (r.border_edges_changed) {
      std::snprintf(line, sizeof line, "  mesh-border edges simplified, summed over cuts: %llu (allowed; --strict-border)\n",
                    (unsigned long long)r.border_edges_changed);
      out += line;
    }
  }
  if (r.error_ratio.count) {
    std::snprintf(line, sizeof line,
                  "  measured/stored error over %llu clusters: min %.3g median %.3g p95 %.3g max %.3g\n",
                  (unsigned long long)r.error_ratio.count, r.error_ratio.min, r.error_ratio.median, r.error_ratio.p95,
                  r.error_ratio.max);
    out += line;
  }
  return out;
}

}  // namespace vgeo
