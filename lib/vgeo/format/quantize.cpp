// Quantization of a mesh's attributes for the page format (spec/format.md §2): the position
// and UV grids the encoder chooses, dequantization, octahedral normals, and the conservative
// metadata that keeps the DAG's bounds and errors true for the quantized geometry (§2.1).
// Based on: Cigolle, Donow, Evangelakos, Mara, McGuire, Meyer, "A Survey of Efficient
// Representations for Independent Unit Vectors", JCGT 3(2), 2014 (octahedral encoding).
#include "vgeo/format/quantize.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "vgeo/core/math.h"

namespace vgeo {

using namespace format_detail;

namespace format_detail {

// Values per task of the chunked scans below: ~0.1 ms of work against a task's ~1 µs hand-out.
// Fixed, and the scans take maxima and minima (exact in any order), so the results do not
// depend on the thread count.
constexpr size_t kScanValuesPerTask = size_t(1) << 16;

int32_t choose_position_step(const ClusterDag& dag, const FormatOptions& o, ThreadPool* pool) {
  if (o.position_step_log2) return *o.position_step_log2;
  double max_abs = 0, extent = 0;
  Aabb box;
  const size_t vertex_count = dag.vertex_count();
  const size_t chunks = (vertex_count + kScanValuesPerTask - 1) / kScanValuesPerTask;
  std::vector<Aabb> chunk_box(chunks);
  std::vector<double> chunk_max_abs(chunks, 0.0);
  std::vector<uint8_t> chunk_finite(chunks, 1);
  for_chunks(pool, vertex_count, kScanValuesPerTask, [&](size_t begin, size_t end) {
    const size_t c = begin / kScanValuesPerTask;
    for (size_t v = begin; v < end; ++v) {
      const Vec3 p = dag.position(v);
      if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) {
        chunk_finite[c] = 0;
        return;
      }
      chunk_box[c].extend(p);
      chunk_max_abs[c] = std::max({chunk_max_abs[c], std::fabs(double(p.x)), std::fabs(double(p.y)), std::fabs(double(p.z))});
    }
  });
  for (size_t c = 0; c < chunks; ++c) {
    if (!chunk_finite[c]) encode_fail("non-finite position");
    if (!chunk_box[c].empty()) box.extend(chunk_box[c].min), box.extend(chunk_box[c].max);
    max_abs = std::max(max_abs, chunk_max_abs[c]);
  }
  if (!box.empty())
    extent = std::max({double(box.max.x) - box.min.x, double(box.max.y) - box.min.y, double(box.max.z) - box.min.z});
  // Smallest power-of-two step with extent ≤ 2^bits steps and |coordinate| ≤ 2^24 - 1 steps.
  int32_t e = kMinStepLog2;
  while (e < kMaxStepLog2 && (std::ldexp(extent, -e) > std::ldexp(1.0, int(o.position_bits)) ||
                              std::ldexp(max_abs, -e) > double(kMaxQuantized - 1)))
    ++e;
  if (!o.position_step_from_lod_error) return e;
  // Refine while √3/2·step exceeds the median first-simplification error (level-0 groups):
  // quantization then moves vertices less than the DAG's typical finest LOD error.
  std::vector<float> leaf_errors;
  for (const DagGroup& g : dag.groups)
    if (g.level == 0 && g.parent_error > 0 && std::isfinite(g.parent_error)) leaf_errors.push_back(g.parent_error);
  if (leaf_errors.empty()) return e;
  std::nth_element(leaf_errors.begin(), leaf_errors.begin() + long(leaf_errors.size() / 2), leaf_errors.end());
  const double median = leaf_errors[leaf_errors.size() / 2];
  const uint32_t max_bits = std::max(o.position_bits, kMaxAutoPositionBits);
  while (e > kMinStepLog2 && kQuantRadiusSlack * std::ldexp(1.0, e) > median &&
         std::ldexp(extent, -(e - 1)) <= std::ldexp(1.0, int(max_bits)) &&
         std::ldexp(max_abs, -(e - 1)) <= double(kMaxQuantized - 1))
    --e;
  return e;
}

int32_t choose_uv_step(const ClusterDag& dag, const FormatOptions& o) {
  double max_abs = 0;
  for (float u : dag.uvs) {
    if (!std::isfinite(u)) encode_fail("non-finite uv");
    max_abs = std::max(max_abs, std::fabs(double(u)));
  }
  int32_t e = o.uv_step_log2;
  // Rounding to the nearest step may reach the limit + 1/2: compare the rounded value.
  while (e < kMaxUvStepLog2 && std::nearbyint(std::ldexp(max_abs, -e)) > double(uv_quantized_limit(e))) ++e;
  return e;
}

FormatReport::MeshQuantizationReport measure_quantization(const ClusterDag& dag, const MeshQuantization& q,
                                                          ThreadPool* pool) {
  FormatReport::MeshQuantizationReport r;
  r.quantization = q;
  // Per value: the quantized value and its dequantization (dequantize_position) as products
  // with the exact powers of two 2^-e and 2^e (e within ±104, so no double overflows or goes
  // subnormal for a float times them): the same doubles as std::ldexp, without two libm calls
  // per coordinate (~5% of the write stage's instructions on bunny00).
  auto max_error = [pool](const std::vector<float>& values, int32_t e) {
    const double inverse_step = std::ldexp(1.0, -e), step = std::ldexp(1.0, e);
    std::vector<double> chunk_max((values.size() + kScanValuesPerTask - 1) / kScanValuesPerTask, 0.0);
    for_chunks(pool, values.size(), kScanValuesPerTask, [&](size_t begin, size_t end) {
      double m = 0;
      for (size_t i = begin; i < end; ++i) {
        const float v = values[i];
        m = std::max(m, std::fabs(double(float(double(int32_t(round_to_nearest_even(double(v) * inverse_step))) * step)) - double(v)));
      }
      chunk_max[begin / kScanValuesPerTask] = m;
    });
    double m = 0;
    for (double c : chunk_max) m = std::max(m, c);
    return m;
  };
  r.position_max_error = max_error(dag.positions, q.position_step_log2);
  r.uv_max_error = max_error(dag.uvs, q.uv_step_log2);
  return r;
}

}  // namespace format_detail

namespace {
// Smallest float ≥ x / largest float ≤ x (x finite double; may give ±inf on overflow).
float float_up(double x) {
  float f = float(x);
  if (double(f) < x) f = std::nextafter(f, std::numeric_limits<float>::infinity());
  return f;
}
float float_down(double x) {
  float f = float(x);
  if (double(f) > x) f = std::nextafter(f, -std::numeric_limits<float>::infinity());
  return f;
}
}  // namespace

void inflate_metadata_for_quantization(ClusterDag* dag, int32_t step_log2) {
  const double step = std::ldexp(1.0, step_log2);
  auto radius = [&](Sphere& s) {
    if (s.radius < 0) return;  // negative radius: "no bounds" marker (lib/vgeo/verify), kept
    s.radius = float_up(double(s.radius) + kQuantRadiusSlack * step);
    if (!std::isfinite(s.radius)) encode_fail("bounding sphere radius overflows after quantization slack");
  };
  auto error = [&](float& e) {
    if (std::isinf(e)) return;  // terminal: never refined
    e = float_up(double(e) + kQuantErrorSlack * step);
    if (!std::isfinite(e)) encode_fail("LOD error overflows after quantization slack");
  };
  for (DagCluster& c : dag->clusters) {
    radius(c.bounds);
    radius(c.lod_bounds);
    radius(c.parent_bounds);
    if (c.generating_group != kNone) error(c.lod_error);  // a leaf's lod_error is exact (0)
    error(c.parent_error);
  }
  for (DagGroup& g : dag->groups) {
    radius(g.bounds);
    radius(g.parent_bounds);
    error(g.parent_error);
  }
  for (BvhNode& n : dag->bvh_nodes) {
    radius(n.bounds);
    radius(n.lod_bounds);
    error(n.max_parent_error);
  }
  Aabb& b = dag->bounds;
  if (!b.empty())
    for (int k = 0; k < 3; ++k) {
      // Rounding to the grid is monotone: a coordinate inside [min, max] quantizes inside
      // [floor(min / step), ceil(max / step)] steps.
      b.min[k] = float_down(std::ldexp(std::floor(std::ldexp(double(b.min[k]), -step_log2)), step_log2));
      b.max[k] = float_up(std::ldexp(std::ceil(std::ldexp(double(b.max[k]), -step_log2)), step_log2));
      if (!std::isfinite(b.min[k]) || !std::isfinite(b.max[k])) encode_fail("mesh bounds overflow on the grid");
    }
}

float dequantize_position(int32_t q, int32_t step_log2) { return float(std::ldexp(double(q), step_log2)); }

int32_t uv_quantized_limit(int32_t step_log2) { return step_log2 >= kMaxUvStepLog2 ? kMaxQuantized - 1 : kMaxQuantized; }

void octahedral_encode(const float n[3], uint32_t bits, uint32_t out[2]) {
  float x = n[0], y = n[1], z = n[2];
  float s = std::fabs(x) + std::fabs(y) + std::fabs(z);
  if (!std::isfinite(s) || s == 0.0f) x = 0, y = 0, z = 1, s = 1;  // undefined normal: +Z
  x /= s, y /= s, z /= s;
  if (z < 0) {
    const float ox = (1 - std::fabs(y)) * (x >= 0 ? 1.0f : -1.0f);
    const float oy = (1 - std::fabs(x)) * (y >= 0 ? 1.0f : -1.0f);
    x = ox, y = oy;
  }
  const float scale = float((1u << bits) - 1);
  for (int k = 0; k < 2; ++k) {
    const float u = std::clamp((k == 0 ? x : y) * 0.5f + 0.5f, 0.0f, 1.0f);
    out[k] = uint32_t(std::lround(u * scale));
  }
}

void octahedral_decode(const uint32_t q[2], uint32_t bits, float n[3]) {
  const float scale = float((1u << bits) - 1);
  float x = float(q[0]) / scale * 2 - 1, y = float(q[1]) / scale * 2 - 1;
  const float z = 1 - std::fabs(x) - std::fabs(y);
  if (z < 0) {
    const float ox = (1 - std::fabs(y)) * (x >= 0 ? 1.0f : -1.0f);
    const float oy = (1 - std::fabs(x)) * (y >= 0 ? 1.0f : -1.0f);
    x = ox, y = oy;
  }
  const float len = std::sqrt(x * x + y * y + z * z);
  n[0] = x / len, n[1] = y / len, n[2] = z / len;
}

}  // namespace vgeo
