#pragma once
// Procedural benchmark meshes (deterministic for a seed): a stand-in until
// lib/mesh/generate.h is available in main, kept so the bench never depends on data files.
#include <cstdint>
#include <string>

#include "vgeo/mesh/mesh.h"

namespace vgeo::bench {

enum class Shape : uint8_t { kSphere, kTerrain, kIslands, kThin };
const char* shape_name(Shape s);

// A closed or open surface with about `triangles` triangles (within a few percent),
// fitting in a unit-radius ball around the origin.
Mesh make_shape(Shape shape, uint32_t triangles, uint64_t seed);

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
