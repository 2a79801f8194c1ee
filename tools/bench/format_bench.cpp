// Page format measurements (spec/format.md): bytes per stored triangle on disk and in memory
// per component, the meshoptimizer codec baseline on the same clusters and pages, page fill,
// transcode and cluster-decode speed on one core, and the encoder's speed on one core (whole
// encode_format at the default options; canonicalization alone: quantization and strip order).
//   build/release/bin/vgeo_microbench --benchmark_filter=Format
// Inputs: CGAL demo meshes from data/ (tools/fetch-data) with area-weighted smooth normals and
// planar-projected UVs (OFF files carry neither), and a generated sphere, each built into a
// full DAG by the real builder (build_dag); "/leaf" variants use only a one-level DAG from a
// simple clusterer (triangles sorted by the Morton code of their centroid, runs of ≤ 128
// triangles and ≤ 128 vertices) for comparison.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <numeric>
#include <sstream>
#include <string>
#include <unordered_map>

#include "vgeo/dag/build.h"
#include "vgeo/dag/cluster_dag.h"
#include "vgeo/dag/dag_io.h"
#include "vgeo/core/error.h"
#include "vgeo/mesh/generate.h"
#include "vgeo/format/format.h"
#include "vgeo/format/format_measure.h"
#include "vgeo/format/page_codec.h"

namespace {
using namespace vgeo;

// The source tree from this file's path (CMake compiles it by absolute path).
std::string source_dir() {
  const std::string f = __FILE__;
  const std::string tail = "/tools/bench/format_bench.cpp";
  return f.size() > tail.size() ? f.substr(0, f.size() - tail.size()) : ".";
}

Mesh load_off(const std::string& path) {
  Mesh m;
  std::ifstream in(path);
  std::string magic;
  size_t nv = 0, nf = 0, ne = 0;
  if (!(in >> magic >> nv >> nf >> ne) || magic != "OFF") return m;
  m.positions.resize(3 * nv);
  for (float& p : m.positions) in >> p;
  for (size_t f = 0; f < nf; ++f) {
    size_t k;
    in >> k;
    std::vector<uint32_t> poly(k);
    for (auto& i : poly) in >> i;
    for (size_t j = 1; j + 1 < k; ++j) m.indices.insert(m.indices.end(), {poly[0], poly[j], poly[j + 1]});
  }
  return m;
}

void add_normals_and_uvs(Mesh& m) {
  m.normals.assign(m.positions.size(), 0.0f);
  for (size_t t = 0; t < m.triangle_count(); ++t) {
    const uint32_t* i = &m.indices[3 * t];
    const Vec3 n = cross(m.position(i[1]) - m.position(i[0]), m.position(i[2]) - m.position(i[0]));
    for (int k = 0; k < 3; ++k)
      for (int a = 0; a < 3; ++a) m.normals[3 * i[k] + a] += n[a];
  }
  for (size_t v = 0; v < m.vertex_count(); ++v) {
    Vec3 n{m.normals[3 * v], m.normals[3 * v + 1], m.normals[3 * v + 2]};
    const float l = length(n) > 0 ? length(n) : 1.0f;
    for (int a = 0; a < 3; ++a) m.normals[3 * v + a] = n[a] / l;
  }
  Aabb b;
  for (size_t v = 0; v < m.vertex_count(); ++v) b.extend(m.position(v));
  const float s = std::max(b.max.x - b.min.x, b.max.y - b.min.y);
  for (size_t v = 0; v < m.vertex_count(); ++v)
    m.uvs.insert(m.uvs.end(), {(m.positions[3 * v] - b.min.x) / s, (m.positions[3 * v + 1] - b.min.y) / s});
}

Sphere sphere_of(const std::vector<float>& pos, size_t first, size_t count) {
  Aabb b;
  for (size_t v = first; v < first + count; ++v) b.extend(Vec3{pos[3 * v], pos[3 * v + 1], pos[3 * v + 2]});
  Sphere s;
  s.center = (b.min + b.max) * 0.5f;
  s.radius = 0.5f * length(b.max - b.min) * 1.001f;
  return s;
}

ClusterDag leaf_dag(const Mesh& m) {
  ClusterDag d;
  Aabb b;
  for (size_t v = 0; v < m.vertex_count(); ++v) b.extend(m.position(v));
  auto spread = [](uint32_t v) {
    v &= 0x3FFu;
    v = (v | (v << 16)) & 0x030000FFu;
    v = (v | (v << 8)) & 0x0300F00Fu;
    v = (v | (v << 4)) & 0x030C30C3u;
    return (v | (v << 2)) & 0x09249249u;
  };
  std::vector<std::pair<uint32_t, uint32_t>> order;
  for (uint32_t t = 0; t < m.triangle_count(); ++t) {
    Vec3 c = (m.position(m.indices[3 * t]) + m.position(m.indices[3 * t + 1]) + m.position(m.indices[3 * t + 2])) * (1.0f / 3);
    uint32_t code = 0;
    for (int a = 0; a < 3; ++a) code |= spread(uint32_t((c[a] - b.min[a]) / (b.max[a] - b.min[a] + 1e-20f) * 1023)) << a;
    order.push_back({code, t});
  }
  std::sort(order.begin(), order.end());
  std::unordered_map<uint32_t, uint8_t> local;
  DagCluster cur;
  auto close = [&] {
    if (cur.triangle_count == 0) return;
    cur.bounds = cur.lod_bounds = sphere_of(d.positions, cur.vertex_offset, cur.vertex_count);
    d.clusters.push_back(cur);
    cur = DagCluster{};
    local.clear();
  };
  for (auto [code, t] : order) {
    uint32_t fresh = 0;
    for (int k = 0; k < 3; ++k) fresh += local.count(m.indices[3 * t + k]) ? 0 : 1;
    if (cur.triangle_count == 128 || cur.vertex_count + fresh > 128) close();
    if (cur.triangle_count == 0) {
      cur.vertex_offset = uint32_t(d.vertex_count());
      cur.triangle_offset = cur.material_offset = uint32_t(d.triangle_count());
    }
    for (int k = 0; k < 3; ++k) {
      const uint32_t v = m.indices[3 * t + k];
      auto it = local.find(v);
      if (it == local.end()) {
        it = local.emplace(v, uint8_t(cur.vertex_count++)).first;
        for (int a = 0; a < 3; ++a) d.positions.push_back(m.positions[3 * v + a]), d.normals.push_back(m.normals[3 * v + a]);
        d.uvs.insert(d.uvs.end(), {m.uvs[2 * v], m.uvs[2 * v + 1]});
      }
      d.indices.push_back(it->second);
    }
    d.triangle_materials.push_back(0);
    ++cur.triangle_count;
  }
  close();
  for (uint32_t c = 0; c < d.clusters.size(); c += 8) {
    DagGroup g;
    g.first_cluster = c;
    g.cluster_count = std::min<uint32_t>(8, uint32_t(d.clusters.size()) - c);
    g.flags = kGroupTerminal;
    g.parent_error = kTerminalError;
    for (uint32_t k = c; k < c + g.cluster_count; ++k) {
      g.bounds = merge_spheres(g.bounds, d.clusters[k].bounds);
      d.clusters[k].group = uint32_t(d.groups.size());
      d.clusters[k].parent_error = kTerminalError;
    }
    g.parent_bounds = g.bounds;
    for (uint32_t k = c; k < c + g.cluster_count; ++k) d.clusters[k].parent_bounds = g.bounds;
    d.groups.push_back(g);
  }
  // Flat BVH: root over up to 8 inner nodes... kept minimal: one node per 8 groups under a
  // chain of roots is not needed for size measurements; a single root node with ≤ 8 groups
  // would not cover all groups, so build two levels (enough for ≤ 64·8 groups).
  BvhNode root;
  const uint32_t ng = uint32_t(d.groups.size()), per = (ng + 7) / 8, inner = (ng + per - 1) / per;
  d.bvh_nodes.push_back(root);
  for (uint32_t i = 0; i < inner; ++i) {
    BvhNode n;
    for (uint32_t g = i * per; g < std::min(ng, (i + 1) * per) && n.child_count < 8; ++g) {
      n.children[n.child_count] = g;
      n.group_mask |= 1u << n.child_count++;
      n.bounds = merge_spheres(n.bounds, d.groups[g].bounds);
    }
    d.bvh_nodes[0].children[d.bvh_nodes[0].child_count++] = uint32_t(d.bvh_nodes.size());
    d.bvh_nodes.push_back(n);
  }
  d.level_count = 1;
  d.bounds = b;
  return d;
}

struct Case {
  BuiltScene scene;
  std::vector<uint8_t> file;
  FormatReport report;
  ComponentBytes stream_compressed;  // measure_stream_compression: each component compressed alone
  FormatContainer container;
};

// Defaults, or overrides for experiments: VGEO_FORMAT_POSITION_BITS, VGEO_FORMAT_NORMAL_BITS,
// VGEO_FORMAT_UV_STEP_LOG2, VGEO_FORMAT_VERSION.
FormatOptions bench_options() {
  FormatOptions o;
  if (const char* e = std::getenv("VGEO_FORMAT_POSITION_BITS")) o.position_bits = uint32_t(std::atoi(e));
  if (const char* e = std::getenv("VGEO_FORMAT_NORMAL_BITS")) o.normal_bits = uint32_t(std::atoi(e));
  if (const char* e = std::getenv("VGEO_FORMAT_UV_STEP_LOG2")) o.uv_step_log2 = std::atoi(e);
  if (const char* e = std::getenv("VGEO_FORMAT_VERSION")) o.version = uint32_t(std::atoi(e));
  return o;
}

const Case* get_case(const std::string& full_name) {
  const bool leaf = full_name.size() > 5 && full_name.substr(full_name.size() - 5) == "/leaf";
  const std::string name = leaf ? full_name.substr(0, full_name.size() - 5) : full_name;
  static std::map<std::string, std::unique_ptr<Case>> cache;
  auto& slot = cache[full_name];
  if (slot) return slot.get();
  slot = std::make_unique<Case>();
  // Built DAGs are cached next to the build (format changes do not rebuild them):
  // build/format_bench_cache/<name>.vgeodag.
  const std::string cache_path = source_dir() + "/build/format_bench_cache/" + name + (leaf ? "_leaf" : "") + ".vgeodag";
  bool cached = false;
  try {
    slot->scene = read_dag_file(cache_path);
    cached = !slot->scene.meshes.empty();
  } catch (const VgeoError&) {
  }
  Mesh m;
  if (cached) {
  } else if (name == "gen10m") {
    // 10M-triangle generated mesh (vgeo gen sphere --triangles 10000000 --seed 1).
    GenerateOptions g;
    g.shape = GenShape::kSphere;
    g.target_triangles = 10'000'000;
    g.threads = 2;
    m = generate_mesh(g);
  } else if (name == "sphere") {
    const uint32_t rings = 160, seg = 320;
    const double pi = 3.14159265358979323846;
    for (uint32_t r = 0; r <= rings; ++r)
      for (uint32_t s = 0; s <= seg; ++s) {
        const double th = pi * r / rings, ph = 2 * pi * s / seg;
        m.positions.insert(m.positions.end(), {float(std::sin(th) * std::cos(ph)), float(std::sin(th) * std::sin(ph)), float(std::cos(th))});
      }
    for (uint32_t r = 0; r < rings; ++r)
      for (uint32_t s = 0; s < seg; ++s) {
        const uint32_t a = r * (seg + 1) + s, b = a + 1, c = a + seg + 1, dd = c + 1;
        if (r > 0) m.indices.insert(m.indices.end(), {a, c, b});
        if (r + 1 < rings) m.indices.insert(m.indices.end(), {b, c, dd});
      }
  } else {
    m = load_off(source_dir() + "/data/cgal/meshes/" + name + ".off");
    if (m.indices.empty()) return slot.reset(), nullptr;
  }
  if (!cached) {
    m.normals.clear();
    m.uvs.clear();
    add_normals_and_uvs(m);
    if (leaf) {
      slot->scene.meshes.push_back(leaf_dag(m));
    } else {
      BuildOptions bo;
      bo.threads = name == "gen10m" ? 2 : 1;
      slot->scene.meshes.push_back(build_dag(m, bo));
    }
    slot->scene.materials.resize(m.materials.empty() ? 1 : 2);  // gen: materials 0 and 1
    std::filesystem::create_directories(source_dir() + "/build/format_bench_cache");
    write_dag_file(cache_path, slot->scene);
  }
  FormatOptions o = bench_options();
  slot->file = encode_format(slot->scene, o, &slot->report);
  slot->stream_compressed = measure_stream_compression(slot->scene, slot->file, o);
  slot->container = parse_container(slot->file.data(), slot->file.size(), name);
  return slot.get();
}

void BM_FormatSize(benchmark::State& state, const std::string& name) {
  const Case* c = get_case(name);
  if (!c) return state.SkipWithError(("missing data/cgal/meshes/" + name + ".off (tools/fetch-data)").c_str());
  MeshoptBaseline base;
  for (auto _ : state) base = measure_meshopt_baseline(c->scene, c->file, bench_options());
  const FormatReport& r = c->report;
  const double t = double(r.triangles);
  auto& k = state.counters;
  k["tris"] = t;
  k["disk_B/tri"] = double(r.file_bytes) / t;
  k["disk_pages_B/tri"] = double(r.pages_stored_bytes) / t;
  k["disk_pos_B/tri"] = c->stream_compressed.positions / t;
  k["disk_nrm_B/tri"] = c->stream_compressed.normals / t;
  k["disk_uv_B/tri"] = c->stream_compressed.uvs / t;
  k["disk_topo_bits/tri"] = 8 * c->stream_compressed.topology / t;
  k["disk_hdr_B/tri"] = c->stream_compressed.cluster_headers / t;
  k["disk_meta_B/tri"] = double(r.metadata_bytes) / t;
  k["mem_B/tri"] = r.memory.total() / t;
  k["mem_pos_B/tri"] = r.memory.positions / t;
  k["mem_nrm_B/tri"] = r.memory.normals / t;
  k["mem_uv_B/tri"] = r.memory.uvs / t;
  k["mem_topo_bits/tri"] = 8 * r.memory.topology / t;
  k["mem_hdr_B/tri"] = (r.memory.cluster_headers + r.memory.materials) / t;
  k["disk_vref_B/tri"] = c->stream_compressed.vertex_refs / t;
  k["copied_vtx_%"] = 100.0 * double(r.copied_vertices) / double(r.vertices);
  k["meta_raw_B/tri"] = double(r.metadata_raw_bytes) / t;
  k["wide_idx_%"] = 100.0 * double(r.wide_index_clusters) / double(r.clusters);
  // Quantization error (spec/format.md §2): position √3/2·step in units of the finest
  // non-zero LOD error of the DAG, largest normal angle, UV half step.
  const MeshQuantization& q = c->container.meshes[0].quantization;
  const ClusterDag& dag = c->scene.meshes[0];
  // Finest LOD errors: the parent_error of the leaf (level 0) groups, i.e. the error of the
  // first simplification; smallest non-zero and median.
  std::vector<double> leaf_errors;
  for (const DagGroup& g : dag.groups)
    if (g.level == 0 && g.parent_error > 0 && std::isfinite(g.parent_error)) leaf_errors.push_back(g.parent_error);
  std::sort(leaf_errors.begin(), leaf_errors.end());
  const double finest = leaf_errors.empty() ? INFINITY : leaf_errors.front();
  const double median = leaf_errors.empty() ? INFINITY : leaf_errors[leaf_errors.size() / 2];
  const double step = std::ldexp(1.0, q.position_step_log2);
  k["pos_step_log2"] = q.position_step_log2;
  k["pos_err/finest_lod_err"] = 0.8660254 * step / finest;
  k["pos_err/median_leaf_err"] = 0.8660254 * step / median;
  double worst = 0;
  for (size_t v = 0; v < dag.normals.size() / 3; ++v) {
    const float* n = &dag.normals[3 * v];
    uint32_t o[2];
    float d[3];
    octahedral_encode(n, q.normal_bits, o);
    octahedral_decode(o, q.normal_bits, d);
    const double l = std::sqrt(double(n[0]) * n[0] + double(n[1]) * n[1] + double(n[2]) * n[2]);
    if (l == 0) continue;
    const double cosang = std::clamp((double(n[0]) * d[0] + double(n[1]) * d[1] + double(n[2]) * d[2]) / l, -1.0, 1.0);
    worst = std::max(worst, std::acos(cosang) * 180.0 / 3.14159265358979323846);
  }
  k["nrm_bits"] = q.normal_bits;
  k["nrm_max_err_deg"] = worst;
  k["uv_step_log2"] = q.uv_step_log2;
  k["verts/tri"] = double(r.vertices) / t;
  double slack = 0;
  for (const PageFill& p : r.pages) slack += p.slack_bytes;
  k["pages"] = double(r.pages.size());
  k["slack_%"] = 100.0 * slack / (double(r.pages.size()) * kDefaultPageSize);
  k["meshopt_B/tri"] = double(base.total_compressed) / t;
  k["meshopt_idx_bits/tri"] = 8.0 * double(base.index_compressed) / t;
  k["meshopt_vtx_B/tri"] = double(base.vertex_compressed) / t;
}

void BM_FormatTranscode(benchmark::State& state, const std::string& name) {
  const Case* c = get_case(name);
  if (!c) return state.SkipWithError("missing mesh (tools/fetch-data)");
  const FormatContainer& fc = c->container;
  uint64_t stored = 0, memory = 0;
  for (const PageEntry& e : fc.pages) stored += e.stored_size, memory += e.memory_size;
  for (auto _ : state)
    for (uint32_t p = 0; p < fc.pages.size(); ++p) {
      std::vector<uint32_t> w = transcode_page(fc, p, c->file.data() + fc.pages[p].file_offset, fc.pages[p].stored_size, name);
      benchmark::DoNotOptimize(w.data());
    }
  state.SetBytesProcessed(int64_t(state.iterations() * stored));  // compressed input
  state.SetItemsProcessed(int64_t(state.iterations() * c->report.triangles));
  state.counters["memory_out_MB/s"] = benchmark::Counter(double(state.iterations()) * double(memory) / 1e6, benchmark::Counter::kIsRate);
}

void BM_FormatDecodeClusters(benchmark::State& state, const std::string& name) {
  const Case* c = get_case(name);
  if (!c) return state.SkipWithError("missing mesh (tools/fetch-data)");
  const FormatContainer& fc = c->container;
  std::vector<std::vector<uint32_t>> pages;
  for (uint32_t p = 0; p < fc.pages.size(); ++p)
    pages.push_back(transcode_page(fc, p, c->file.data() + fc.pages[p].file_offset, fc.pages[p].stored_size, name));
  DecodedCluster dc;
  for (auto _ : state)
    for (const auto& w : pages)
      for (uint32_t i = 0; i < memory_page_cluster_count(w.data()); ++i) {
        decode_cluster(w.data(), i, fc.meshes[0].quantization, &dc);
        benchmark::DoNotOptimize(dc.positions.data());
      }
  state.SetItemsProcessed(int64_t(state.iterations() * c->report.triangles));
}

// The write stage without file I/O: encode_format at the bench options on one thread.
void BM_FormatEncode(benchmark::State& state, const std::string& name) {
  const Case* c = get_case(name);
  if (!c) return state.SkipWithError("missing mesh (tools/fetch-data)");
  FormatOptions o = bench_options();
  o.threads = 1;
  for (auto _ : state) {
    std::vector<uint8_t> f = encode_format(c->scene, o);
    benchmark::DoNotOptimize(f.data());
  }
  state.SetItemsProcessed(int64_t(state.iterations() * c->report.triangles));
}

// Canonicalization alone (quantization, material runs, span-aware strip order; spec/format.md §3),
// every cluster of the DAG with the file's quantization.
void BM_FormatCanonicalize(benchmark::State& state, const std::string& name) {
  const Case* c = get_case(name);
  if (!c) return state.SkipWithError("missing mesh (tools/fetch-data)");
  const ClusterDag& dag = c->scene.meshes[0];
  const MeshQuantization& q = c->container.meshes[0].quantization;
  auto canon = std::make_unique<format_detail::CanonicalCluster>();
  for (auto _ : state)
    for (uint32_t ci = 0; ci < dag.clusters.size(); ++ci) {
      format_detail::canonicalize_cluster(dag, ci, q, canon.get());
      benchmark::DoNotOptimize(canon->strip);
    }
  state.SetItemsProcessed(int64_t(state.iterations() * c->report.triangles));
}

const char* const kFormatBenchMeshes[] = {"bunny00", "armadillo", "refined_elephant", "fandisk_large", "sphere", "gen10m", "armadillo/leaf"};
const int kRegistered = [] {
  for (const char* m : kFormatBenchMeshes) {
    benchmark::RegisterBenchmark((std::string("BM_FormatSize/") + m).c_str(), BM_FormatSize, std::string(m))
        ->Iterations(1)->Unit(benchmark::kMillisecond);
    benchmark::RegisterBenchmark((std::string("BM_FormatTranscode/") + m).c_str(), BM_FormatTranscode, std::string(m))
        ->Unit(benchmark::kMillisecond);
    benchmark::RegisterBenchmark((std::string("BM_FormatDecodeClusters/") + m).c_str(), BM_FormatDecodeClusters, std::string(m))
        ->Unit(benchmark::kMillisecond);
    benchmark::RegisterBenchmark((std::string("BM_FormatEncode/") + m).c_str(), BM_FormatEncode, std::string(m))
        ->Unit(benchmark::kMillisecond);
    benchmark::RegisterBenchmark((std::string("BM_FormatCanonicalize/") + m).c_str(), BM_FormatCanonicalize, std::string(m))
        ->Unit(benchmark::kMillisecond);
  }
  return 0;
}();

}  // namespace
