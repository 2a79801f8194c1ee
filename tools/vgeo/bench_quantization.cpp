// Suite "quantization": the position grid (FormatOptions::position_bits) against size on disk
// and in memory, position error after decode, and decode time.
#include <algorithm>
#include <cmath>

#include "bench_shapes.h"
#include "bench_suites.h"
#include "vgeo/dag/build.h"
#include "vgeo/core/progress.h"
#include "vgeo/format/format.h"

namespace vgeo::bench {
namespace {

struct PositionError {
  double max = 0, rms = 0;
  uint64_t unmatched_clusters = 0;  // decoded cluster whose vertex count differs from the original
};

// Decoded vertices may be reordered within a cluster (spec/format.md §Decoded scene), so each
// decoded vertex is matched to the nearest original vertex of the same cluster.
PositionError position_error(const ClusterDag& original, const ClusterDag& decoded) {
  PositionError e;
  double sum = 0;
  uint64_t n = 0;
  size_t clusters = std::min(original.clusters.size(), decoded.clusters.size());
  e.unmatched_clusters = std::max(original.clusters.size(), decoded.clusters.size()) - clusters;
  for (size_t c = 0; c < clusters; ++c) {
    const DagCluster& a = original.clusters[c];
    const DagCluster& b = decoded.clusters[c];
    if (a.vertex_count != b.vertex_count) {
      ++e.unmatched_clusters;
      continue;
    }
    for (uint32_t i = 0; i < b.vertex_count; ++i) {
      Vec3 p = decoded.position(b.vertex_offset + i);
      double best = 1e300;
      for (uint32_t j = 0; j < a.vertex_count; ++j) {
        Vec3 q = original.position(a.vertex_offset + j);
        double dx = double(p.x) - q.x, dy = double(p.y) - q.y, dz = double(p.z) - q.z;
        best = std::min(best, dx * dx + dy * dy + dz * dz);
      }
      e.max = std::max(e.max, std::sqrt(best));
      sum += best;
      ++n;
    }
  }
  e.rms = n ? std::sqrt(sum / double(n)) : 0;
  return e;
}

}  // namespace

void run_quantization_suite(const BenchConfig& cfg, SuiteReport& out) {
  out.ran = true;
  const uint32_t tris = cfg.quick ? 8000 : 100000;
  const std::vector<uint32_t> bits = cfg.quick ? std::vector<uint32_t>{10, 16}
                                               : std::vector<uint32_t>{8, 10, 12, 14, 16, 18, 20};
  const int reps = cfg.repetitions(7);
  BuildOptions bo;
  bo.threads = cfg.threads;
  Mesh mesh = make_shape(Shape::kSphere, tris, 13);
  BuiltScene scene;
  scene.meshes.push_back(build_dag(mesh, bo, nullptr));
  scene.materials.push_back(Material{});
  scene.instances.push_back(Instance{});
  const ClusterDag& dag = scene.meshes[0];
  double extent = 0;
  for (int a = 0; a < 3; ++a) extent = std::max(extent, double(dag.bounds.max[a]) - dag.bounds.min[a]);
  out.inputs.push_back("sphere " + std::to_string(mesh.triangle_count()) + " triangles (seed 13), DAG of " +
                       std::to_string(dag.clusters.size()) + " clusters / " + std::to_string(dag.triangle_count()) +
                       " stored triangles, largest axis extent " + fmt(extent));
  out.summary =
      "The same DAG encoded with FormatOptions::position_bits = b (grid step: the smallest power of two with the "
      "largest axis extent <= 2^b steps; other options default: 10-bit normals, zstd). 'file' is the whole encoded "
      "file, 'memory' the memory-form page bytes (what stays resident), 'positions' their position share. Error "
      "is the distance of each decoded vertex to its nearest original vertex in the same cluster (max and RMS, also "
      "relative to the extent). Decode is decode_format() of the whole file, process CPU time, median of " +
      std::to_string(reps) + " interleaved repetitions.";

  Table t{"Position grid vs size, error and decode time", {"bits", "step", "file bytes", "bytes / tri (file)",
                                                            "memory bytes", "memory positions", "max error",
                                                            "RMS error", "max / extent", "decode CPU",
                                                            "unmatched clusters"}, {}};
  std::vector<std::vector<uint8_t>> files(bits.size());
  std::vector<FormatReport> reports(bits.size());
  Progress progress("bench quantization", bits.size() + size_t(reps) * bits.size(), cfg.progress);
  for (size_t i = 0; i < bits.size(); ++i) {
    FormatOptions fo;
    fo.position_bits = bits[i];
    files[i] = encode_format(scene, fo, &reports[i]);
    progress.advance();
  }
  std::vector<BuiltScene> decoded(bits.size());
  auto samples = time_interleaved(reps, bits.size(), [&](size_t v) {
    decoded[v] = decode_format(files[v].data(), files[v].size(), "<memory>");
    progress.advance();
  });
  Series size_s = named_series("file bytes"), mem_s = named_series("memory-form bytes");
  Series err_max = named_series("max error / extent"), err_rms = named_series("RMS error / extent");
  Series dec = named_series("decode CPU time (ms)");
  Series tradeoff = named_series("file bytes vs max error");
  nlohmann::json rows = nlohmann::json::array();
  for (size_t i = 0; i < bits.size(); ++i) {
    PositionError e = position_error(dag, decoded[i].meshes.empty() ? ClusterDag{} : decoded[i].meshes[0]);
    Stats d = summarize(samples.cpu[i]);
    const FormatReport& r = reports[i];
    double step = std::ldexp(1.0, int(std::ceil(std::log2(extent))) - int(bits[i]));
    t.rows.push_back({std::to_string(bits[i]), fmt(step), std::to_string(files[i].size()),
                      fmt(double(files[i].size()) / double(std::max<uint64_t>(1, dag.triangle_count()))),
                      fmt(r.memory.total()), fmt(r.memory.positions), fmt(e.max), fmt(e.rms), fmt(e.max / extent),
                      fmt_stats_time(d), std::to_string(e.unmatched_clusters)});
    rows.push_back({{"position_bits", bits[i]},
                    {"nominal_step", step},
                    {"file_bytes", files[i].size()},
                    {"memory_bytes", r.memory.total()},
                    {"memory_position_bytes", r.memory.positions},
                    {"disk_raw_bytes", r.disk_raw.total()},
                    {"max_error", e.max},
                    {"rms_error", e.rms},
                    {"extent", extent},
                    {"decode_cpu_seconds", to_json(d)},
                    {"unmatched_clusters", e.unmatched_clusters}});
    double x = bits[i];
    size_s.x.push_back(x);
    size_s.y.push_back(double(files[i].size()));
    mem_s.x.push_back(x);
    mem_s.y.push_back(r.memory.total());
    err_max.x.push_back(x);
    err_max.y.push_back(e.max / extent);
    err_rms.x.push_back(x);
    err_rms.y.push_back(e.rms / extent);
    dec.x.push_back(x);
    dec.y.push_back(d.median * 1e3);
    dec.y_low.push_back(d.min * 1e3);
    dec.y_high.push_back(d.max * 1e3);
    tradeoff.x.push_back(e.max / extent);
    tradeoff.y.push_back(double(files[i].size()));
  }
  out.tables.push_back(t);
  out.data["rows"] = rows;
  add_plot(out, cfg, "quantization_size.svg",
           Plot{"Size vs position bits", "position bits", "bytes", false, true, {size_s, mem_s}},
           "Encoded file and memory-form bytes against the position grid's bits");
  add_plot(out, cfg, "quantization_error.svg",
           Plot{"Position error vs position bits", "position bits", "error / largest extent", false, true,
                {err_max, err_rms}},
           "Max and RMS decoded position error relative to the mesh extent");
  add_plot(out, cfg, "quantization_tradeoff.svg",
           Plot{"Accuracy vs size", "max position error / extent", "file bytes", true, false, {tradeoff}},
           "Each point is one grid (left = more bits)");
  add_plot(out, cfg, "quantization_decode.svg",
           Plot{"Decode time vs position bits", "position bits", "decode CPU time (ms)", false, false, {dec}},
           "decode_format() CPU time (median, bars = min/max)");
}

}  // namespace vgeo::bench
