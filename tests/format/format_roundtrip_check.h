#pragma once
// The round-trip comparison shared by the format tests and the round-trip fuzzer:
// decode(encode(x)) equals x quantized up to the canonical order of spec/format.md
// §Decoded scene. Returns "" or the first difference. No test framework needed.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "vgeo/dag/cluster_dag.h"
#include "vgeo/format/format.h"

namespace vgeo {
namespace roundtrip_check {

using Key = std::vector<uint32_t>;  // one corner: attribute bits + material

inline uint32_t bits_of(float f) {
  uint32_t u;
  std::memcpy(&u, &f, 4);
  return u;
}

// Expected decoded attributes of a vertex of the input (quantize, then dequantize).
inline Key expected_corner(const ClusterDag& d, size_t v, const MeshQuantization& q) {
  Key k;
  for (int a = 0; a < 3; ++a)
    k.push_back(bits_of(dequantize_position(int32_t(std::nearbyint(std::ldexp(double(d.positions[3 * v + a]), -q.position_step_log2))),
                                            q.position_step_log2)));
  if (q.has_normals) {
    uint32_t o[2];
    float n[3];
    octahedral_encode(&d.normals[3 * v], q.normal_bits, o);
    octahedral_decode(o, q.normal_bits, n);
    for (float x : n) k.push_back(bits_of(x));
  }
  if (q.has_uvs)
    for (int a = 0; a < 2; ++a)
      k.push_back(bits_of(dequantize_position(int32_t(std::nearbyint(std::ldexp(double(d.uvs[2 * v + a]), -q.uv_step_log2))),
                                              q.uv_step_log2)));
  return k;
}
inline Key decoded_corner(const ClusterDag& d, size_t v) {
  Key k;
  for (int a = 0; a < 3; ++a) k.push_back(bits_of(d.positions[3 * v + a]));
  if (!d.normals.empty())
    for (int a = 0; a < 3; ++a) k.push_back(bits_of(d.normals[3 * v + a]));
  if (!d.uvs.empty())
    for (int a = 0; a < 2; ++a) k.push_back(bits_of(d.uvs[2 * v + a]));
  return k;
}

// Triangles of a cluster as corner keys, each rotated to its smallest rotation, sorted.
template <class Corner>
std::vector<std::vector<Key>> triangle_set(const ClusterDag& d, const DagCluster& c, Corner corner) {
  std::vector<std::vector<Key>> out;
  for (uint32_t t = 0; t < c.triangle_count; ++t) {
    std::vector<Key> tri;
    for (int k = 0; k < 3; ++k) tri.push_back(corner(c.vertex_offset + d.indices[3 * (c.triangle_offset + t) + k]));
    std::vector<Key> best = tri;
    for (int r = 1; r < 3; ++r) {
      std::vector<Key> rot = {tri[r], tri[(r + 1) % 3], tri[(r + 2) % 3]};
      if (rot < best) best = rot;
    }
    best.push_back({d.triangle_materials[c.triangle_offset + t]});
    out.push_back(best);
  }
  std::sort(out.begin(), out.end());
  return out;
}

// Checks decode(encode(in)) against `in`; returns "" or the first difference.
inline std::string compare_roundtrip(const BuiltScene& in, const BuiltScene& out, const FormatContainer& fc) {
  if (in.meshes.size() != out.meshes.size()) return "mesh count";
  if (in.materials.size() != out.materials.size() || in.instances.size() != out.instances.size()) return "scene tables";
  for (size_t m = 0; m < in.materials.size(); ++m)
    if (in.materials[m].name != out.materials[m].name || in.materials[m].base_color != out.materials[m].base_color)
      return "material " + std::to_string(m);
  for (size_t i = 0; i < in.instances.size(); ++i)
    if (in.instances[i].mesh != out.instances[i].mesh || in.instances[i].transform != out.instances[i].transform)
      return "instance";
  for (size_t mi = 0; mi < in.meshes.size(); ++mi) {
    const MeshQuantization& q = fc.meshes[mi].quantization;
    // Metadata is stored with the quantization slack of spec/format.md §2.1.
    ClusterDag a = in.meshes[mi];
    inflate_metadata_for_quantization(&a, q.position_step_log2);
    const ClusterDag& b = out.meshes[mi];
    if (a.clusters.size() != b.clusters.size() || a.groups.size() != b.groups.size()) return "dag sizes";
    if (a.level_count != b.level_count || std::memcmp(&a.bounds, &b.bounds, sizeof(Aabb))) return "dag header";
    if (a.generated_clusters != b.generated_clusters) return "generated clusters";
    if (a.groups.size() && std::memcmp(a.groups.data(), b.groups.data(), a.groups.size() * sizeof(DagGroup)))
      return "groups differ";
    if (a.bvh_nodes.size() != b.bvh_nodes.size() ||
        (a.bvh_nodes.size() && std::memcmp(a.bvh_nodes.data(), b.bvh_nodes.data(), a.bvh_nodes.size() * sizeof(BvhNode))))
      return "bvh differs";
    const double step = std::ldexp(1.0, q.position_step_log2);
    for (size_t c = 0; c < a.clusters.size(); ++c) {
      DagCluster ca = a.clusters[c], cb = b.clusters[c];
      if (ca.vertex_count != cb.vertex_count || ca.triangle_count != cb.triangle_count) return "cluster counts";
      const std::string at = "mesh " + std::to_string(mi) + " cluster " + std::to_string(c) + ": ";
      for (uint32_t v = 0; v < cb.vertex_count; ++v)
        for (int k = 0; k < 3; ++k) {
          const double p = b.positions[3 * (size_t(cb.vertex_offset) + v) + k];
          const double on_grid = std::ldexp(p, -q.position_step_log2);
          if (on_grid != std::nearbyint(on_grid)) return at + "decoded position not on the grid";
        }
      for (uint32_t v = 0; v < ca.vertex_count; ++v)
        for (int k = 0; k < 3; ++k) {
          const double p = a.positions[3 * (size_t(ca.vertex_offset) + v) + k];
          const double qp = dequantize_position(int32_t(std::nearbyint(std::ldexp(p, -q.position_step_log2))), q.position_step_log2);
          if (std::fabs(qp - p) > 0.5 * step) return at + "quantization error above half a step";
        }
      auto ea = [&](size_t v) { return expected_corner(a, v, q); };
      auto eb = [&](size_t v) { return decoded_corner(b, v); };
      if (triangle_set(a, ca, ea) != triangle_set(b, cb, eb)) return at + "triangles differ";
      std::vector<Key> va, vb;
      for (uint32_t v = 0; v < ca.vertex_count; ++v) va.push_back(ea(ca.vertex_offset + v)), vb.push_back(eb(cb.vertex_offset + v));
      std::sort(va.begin(), va.end());
      std::sort(vb.begin(), vb.end());
      if (va != vb) return at + "vertex multisets differ";
      for (uint32_t t = 0; t < cb.triangle_count; ++t) {
        const uint8_t* i = &b.indices[3 * (size_t(cb.triangle_offset) + t)];
        if (!(i[0] <= i[1] && i[0] <= i[2])) return at + "decoded triangle not smallest-index-first";
      }
      ca.vertex_offset = cb.vertex_offset, ca.triangle_offset = cb.triangle_offset, ca.material_offset = cb.material_offset;
      if (std::memcmp(&ca, &cb, sizeof(DagCluster))) return at + "cluster metadata differs";
    }
  }
  return "";
}

}  // namespace roundtrip_check
using roundtrip_check::compare_roundtrip;
}  // namespace vgeo
