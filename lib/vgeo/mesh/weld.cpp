#include "vgeo/mesh/weld.h"

#include <cstdint>
#include <cstring>
#include <vector>

namespace vgeo {
namespace {

constexpr uint32_t kNoVertex = UINT32_MAX;
// Up to 3 + 3 + 2 floats per vertex.
constexpr int kMaxVertexFloats = 8;

struct VertexKey {
  float v[kMaxVertexFloats];
  int n;
};

VertexKey key_of(const Mesh& m, uint32_t vtx) {
  VertexKey k{};
  k.n = 0;
  for (int c = 0; c < 3; ++c) k.v[k.n++] = m.positions[3 * size_t(vtx) + c];
  if (!m.normals.empty())
    for (int c = 0; c < 3; ++c) k.v[k.n++] = m.normals[3 * size_t(vtx) + c];
  if (!m.uvs.empty())
    for (int c = 0; c < 2; ++c) k.v[k.n++] = m.uvs[2 * size_t(vtx) + c];
  // Value equality: fold -0 into +0 so the bit hash agrees with operator==.
  for (int c = 0; c < k.n; ++c)
    if (k.v[c] == 0.0f) k.v[c] = 0.0f;
  return k;
}

uint64_t hash_key(const VertexKey& k) {
  uint64_t h = 0xcbf29ce484222325ull;  // FNV-1a over the float bits, then a final mix
  for (int c = 0; c < k.n; ++c) {
    uint32_t bits;
    std::memcpy(&bits, &k.v[c], 4);
    h = (h ^ bits) * 0x100000001b3ull;
  }
  h ^= h >> 33;
  h *= 0xff51afd7ed558ccdull;
  h ^= h >> 33;
  return h;
}

bool same_key(const VertexKey& a, const VertexKey& b) {
  for (int c = 0; c < a.n; ++c)
    if (a.v[c] != b.v[c]) return false;
  return true;
}

}  // namespace

size_t weld_exact(Mesh& mesh) {
  const size_t old_count = mesh.vertex_count();
  // Open-addressing table of new vertex ids, sized to a power of two >= 2x the vertex count.
  size_t cap = 16;
  while (cap < 2 * old_count) cap <<= 1;
  std::vector<uint32_t> table(cap, kNoVertex);
  std::vector<uint32_t> remap(old_count, kNoVertex);  // old vertex -> new vertex
  std::vector<uint32_t> first_old;                     // new vertex -> its first old vertex
  first_old.reserve(old_count);
  std::vector<VertexKey> new_keys;
  new_keys.reserve(old_count);

  for (uint32_t& idx : mesh.indices) {
    uint32_t old = idx;
    if (remap[old] == kNoVertex) {
      VertexKey k = key_of(mesh, old);
      size_t slot = hash_key(k) & (cap - 1);
      while (table[slot] != kNoVertex && !same_key(new_keys[table[slot]], k)) slot = (slot + 1) & (cap - 1);
      if (table[slot] == kNoVertex) {
        table[slot] = uint32_t(first_old.size());
        first_old.push_back(old);
        new_keys.push_back(k);
      }
      remap[old] = table[slot];
    }
    idx = remap[old];
  }

  const size_t new_count = first_old.size();
  auto gather = [&](std::vector<float>& attr, size_t width) {
    if (attr.empty()) return;
    std::vector<float> out(new_count * width);
    for (size_t v = 0; v < new_count; ++v)
      for (size_t c = 0; c < width; ++c) out[v * width + c] = attr[size_t(first_old[v]) * width + c];
    attr.swap(out);
  };
  gather(mesh.positions, 3);
  gather(mesh.normals, 3);
  gather(mesh.uvs, 2);
  return old_count - new_count;
}

}  // namespace vgeo
