#pragma once
// The canonical decode hash of spec/format.md §9 (the `OK <hash>` of spec/vectors/manifest.txt
// and the protocol of spec/conform.md §5): FNV-1a 64 over, per mesh in order, the decoded
// positions, normals, uvs (float32 bits, little-endian), indices (u8) and triangle materials
// (u32 little-endian), in cluster-index order. Little-endian hosts (as the decoder).
#include <cstdint>

#include "vgeo/core/hash.h"
#include "vgeo/dag/cluster_dag.h"

namespace vgeo {

inline uint64_t decode_hash(const BuiltScene& s) {
  uint64_t h = kFnvOffset;
  for (const ClusterDag& d : s.meshes) {
    h = fnv1a64(d.positions.data(), d.positions.size() * 4, h);
    h = fnv1a64(d.normals.data(), d.normals.size() * 4, h);
    h = fnv1a64(d.uvs.data(), d.uvs.size() * 4, h);
    h = fnv1a64(d.indices.data(), d.indices.size(), h);
    h = fnv1a64(d.triangle_materials.data(), d.triangle_materials.size() * 4, h);
  }
  return h;
}

}  // namespace vgeo
