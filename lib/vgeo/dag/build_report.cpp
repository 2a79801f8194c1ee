#include <cstdio>
#include <string>

#include "vgeo/dag/build.h"

namespace vgeo {

std::string build_report_summary(const std::string& name, const BuildReport& r) {
  std::string out;
  char line[256];
  auto u = [](uint64_t v) { return (unsigned long long)v; };
  std::snprintf(line, sizeof line, "mesh %s: %llu input triangles -> %llu stored (%.2fx), %llu root clusters (%llu triangles)\n",
                name.c_str(), u(r.input_triangles), u(r.stored_triangles),
                r.input_triangles ? double(r.stored_triangles) / double(r.input_triangles) : 0.0, u(r.root_clusters),
                u(r.root_triangles));
  out += line;
  out += "  level  clusters  triangles   groups  stuck  fill   border\n";
  for (const BuildLevelReport& l : r.levels) {
    std::snprintf(line, sizeof line, "  %5u  %8llu  %9llu  %7llu  %5llu  %4.0f%%  %5.1f%%\n", l.level, u(l.clusters),
                  u(l.triangles), u(l.groups), u(l.stuck_groups), 100.0 * l.average_fill,
                  100.0 * l.boundary_edge_fraction);
    out += line;
  }
  std::snprintf(line, sizeof line,
                "  time %.2fs (prepare %.2f, cluster %.2f, edges %.2f, group %.2f, locks %.2f, simplify %.2f, "
                "error %.2f, split %.2f, combine %.2f, layout %.2f, hierarchy %.2f), peak %.0f MiB\n",
                r.seconds_total, r.seconds_prepare, r.seconds_cluster, r.seconds_edges, r.seconds_group,
                r.seconds_locks, r.seconds_simplify, r.seconds_error, r.seconds_split, r.seconds_combine,
                r.seconds_layout, r.seconds_hierarchy, double(r.peak_memory_bytes) / (1 << 20));
  out += line;
  return out;
}

}  // namespace vgeo
