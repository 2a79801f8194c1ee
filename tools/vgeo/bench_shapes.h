#pragma once
// Benchmark meshes: lib/vgeo/mesh/generate.h shapes (deterministic for a seed, no data files),
// plus the hard inputs of the stability suite (slivers, degenerate triangles).
#include <algorithm>
#include <cstdint>
#include <string>

#include "vgeo/mesh/mesh.h"

namespace vgeo::bench {

enum class Shape : uint8_t { kSphere, kTerrain, kIslands, kThin };
const char* shape_name(Shape s);

// generate_mesh() of the shape with about `triangles` triangles.
Mesh make_shape(Shape shape, uint32_t triangles, uint64_t seed);

// A UV ellipsoid with radii (1, 1, thickness), no uvs: thickness 1e-3 makes a sliver-heavy shell.
Mesh make_ellipsoid(uint32_t triangles, float thickness);

// `mesh` plus degenerate input: every `every`-th triangle gets a zero-area twin (two equal
// corners) and a collinear sliver on duplicated vertices.
Mesh add_degenerate_triangles(Mesh mesh, uint32_t every);

// Centre and half extent of the mesh's bounding box.
struct BoxFrame {
  Vec3 center, half;
  float max_half() const { return std::max(half.x, std::max(half.y, half.z)); }
};
BoxFrame box_frame(const Mesh& mesh);

// Deterministic PRNG (splitmix64): the benchmarks' inputs are identical on every run.
struct Rng {
  uint64_t state;
  explicit Rng(uint64_t seed) : state(seed) {}
  uint64_t next() {
    uint64_t z = (state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  double uniform() { return double(next() >> 11) * (1.0 / 9007199254740992.0); }  // [0, 1)
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
};

}  // namespace vgeo::bench
