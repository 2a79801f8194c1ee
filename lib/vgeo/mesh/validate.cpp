#include "vgeo/mesh/validate.h"

#include <algorithm>
#include <atomic>
#include <cmath>

namespace vgeo {

OutputBudget OutputBudget::for_input(uint64_t input_bytes, std::string where) {
  OutputBudget b;
  uint64_t limit = input_bytes > UINT64_MAX / kMaxOutputBytesPerInputByte
                       ? UINT64_MAX
                       : input_bytes * kMaxOutputBytesPerInputByte;
  b.remaining = std::max(limit, kMinOutputBudgetBytes);
  b.where = std::move(where);
  return b;
}

void OutputBudget::charge(uint64_t count, uint64_t bytes_each, const char* what) {
  if (bytes_each != 0 && count > remaining / bytes_each) {
    fail("INPUT_EXPANSION_LIMIT", where,
         std::string(what) + " would need " + std::to_string(count) + " x " + std::to_string(bytes_each) +
             " bytes, more than the input size allows (" +
             std::to_string(kMaxOutputBytesPerInputByte) + " output bytes per input byte)");
  }
  remaining -= count * bytes_each;
}

std::string mesh_array_size_defect(const Mesh& mesh) {
  const size_t n = mesh.vertex_count();
  if (mesh.positions.size() % 3 != 0) return "position array length is not a multiple of 3";
  if (mesh.indices.size() % 3 != 0) return "index array length is not a multiple of 3";
  if (!mesh.normals.empty() && mesh.normals.size() != 3 * n) return "normals are not one per vertex";
  if (!mesh.uvs.empty() && mesh.uvs.size() != 2 * n) return "uvs are not one per vertex";
  if (!mesh.materials.empty() && mesh.materials.size() != mesh.triangle_count())
    return "materials are not one per triangle";
  return {};
}

namespace {

// Values per task of a scan on a pool: 2^18 (1 MiB, ~0.1 ms: the scans run at memory speed, a
// 1M-triangle mesh's positions and indices took 1.7 ms on one thread), so a 1M-triangle mesh's
// 3M indices are 12 tasks.
constexpr size_t kScanTaskValues = size_t(1) << 18;

// The first i in [0, n) with bad(values[i]), or n; by parts on `pool` when there is one.
template <class T, class Bad>
size_t first_bad(const T* values, size_t n, ThreadPool* pool, Bad bad) {
  auto scan = [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i)
      if (bad(values[i])) return i;
    return end;
  };
  if (!pool || pool->size() == 1 || n <= kScanTaskValues) return scan(0, n);
  std::vector<size_t> first((n + kScanTaskValues - 1) / kScanTaskValues, n);
  for_chunks(pool, n, kScanTaskValues, [&](size_t begin, size_t end) {
    if (const size_t i = scan(begin, end); i < end) first[begin / kScanTaskValues] = i;
  });
  return *std::min_element(first.begin(), first.end());
}

}  // namespace

size_t first_non_finite(const std::vector<float>& values, ThreadPool* pool) {
  return first_bad(values.data(), values.size(), pool, [](float v) { return !std::isfinite(v); });
}

size_t first_index_out_of_range(const Mesh& mesh, ThreadPool* pool) {
  const size_t n = mesh.vertex_count();
  return first_bad(mesh.indices.data(), mesh.indices.size(), pool, [n](uint32_t i) { return size_t(i) >= n; });
}

void check_mesh_attributes(const Mesh& mesh, const std::string& where, ThreadPool* pool) {
  if (!mesh_array_size_defect(mesh).empty()) {
    fail("INTERNAL_SIZE_MISMATCH", where, "mesh '" + mesh.name + "' has inconsistent array sizes",
         kExitInternal);
  }
  if (size_t i = first_non_finite(mesh.positions, pool); i < mesh.positions.size()) {
    fail("POSITION_NOT_FINITE", where,
         "mesh '" + mesh.name + "' vertex " + std::to_string(i / 3) + " has a non-finite position");
  }
  if (size_t i = first_non_finite(mesh.normals, pool); i < mesh.normals.size()) {
    fail("ATTRIBUTE_NOT_FINITE", where,
         "mesh '" + mesh.name + "' vertex " + std::to_string(i / 3) + " has a non-finite normal");
  }
  if (size_t i = first_non_finite(mesh.uvs, pool); i < mesh.uvs.size()) {
    fail("ATTRIBUTE_NOT_FINITE", where,
         "mesh '" + mesh.name + "' vertex " + std::to_string(i / 2) + " has a non-finite uv");
  }
}

void check_mesh_indices(const Mesh& mesh, const std::string& where, ThreadPool* pool) {
  if (size_t i = first_index_out_of_range(mesh, pool); i < mesh.indices.size()) {
    fail("INDEX_OUT_OF_RANGE", where,
         "mesh '" + mesh.name + "' index " + std::to_string(i) + " = " + std::to_string(mesh.indices[i]) +
             " >= vertex count " + std::to_string(mesh.vertex_count()));
  }
}

bool triangle_has_zero_area(const Mesh& mesh, uint32_t a, uint32_t b, uint32_t c) {
  const float* p = mesh.positions.data();
  double e1[3], e2[3];
  for (int k = 0; k < 3; ++k) {
    e1[k] = double(p[3 * size_t(b) + k]) - double(p[3 * size_t(a) + k]);
    e2[k] = double(p[3 * size_t(c) + k]) - double(p[3 * size_t(a) + k]);
  }
  double cx = e1[1] * e2[2] - e1[2] * e2[1];
  double cy = e1[2] * e2[0] - e1[0] * e2[2];
  double cz = e1[0] * e2[1] - e1[1] * e2[0];
  return cx == 0.0 && cy == 0.0 && cz == 0.0;
}

namespace {

bool triangle_is_degenerate(const Mesh& mesh, size_t t) {
  const uint32_t a = mesh.indices[3 * t], b = mesh.indices[3 * t + 1], c = mesh.indices[3 * t + 2];
  return a == b || b == c || a == c || triangle_has_zero_area(mesh, a, b, c);
}

}  // namespace

size_t remove_degenerate_triangles(Mesh& mesh, ThreadPool* pool) {
  const size_t tris = mesh.triangle_count();
  const bool has_materials = !mesh.materials.empty();
  std::vector<uint8_t> degenerate;  // per triangle, when tested on the pool
  if (pool && pool->size() > 1 && tris > kDegenerateTestTriangles) {
    degenerate.resize(tris);
    std::atomic<size_t> found{0};
    for_chunks(pool, tris, kDegenerateTestTriangles, [&](size_t begin, size_t end) {
      size_t n = 0;
      for (size_t t = begin; t < end; ++t) n += degenerate[t] = triangle_is_degenerate(mesh, t);
      found.fetch_add(n, std::memory_order_relaxed);
    });
    if (found.load() == 0) return 0;  // the usual case: nothing to move
  }
  size_t kept = 0;
  for (size_t t = 0; t < tris; ++t) {
    if (degenerate.empty() ? triangle_is_degenerate(mesh, t) : degenerate[t] != 0) continue;
    const uint32_t a = mesh.indices[3 * t], b = mesh.indices[3 * t + 1], c = mesh.indices[3 * t + 2];
    mesh.indices[3 * kept] = a;
    mesh.indices[3 * kept + 1] = b;
    mesh.indices[3 * kept + 2] = c;
    if (has_materials) mesh.materials[kept] = mesh.materials[t];
    ++kept;
  }
  mesh.indices.resize(3 * kept);
  if (has_materials) mesh.materials.resize(kept);
  return tris - kept;
}

}  // namespace vgeo
