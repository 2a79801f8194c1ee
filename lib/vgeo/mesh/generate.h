#pragma once
// Deterministic procedural meshes for tests and benchmarks: a shape, a seed and a target
// triangle count give the same bytes on every run, thread count and IEEE-754 platform.
//
// Determinism rules (relied upon by tests that hash outputs):
//  - randomness comes only from SplitMix64 / hash_noise below (no <random>, whose
//    distributions are implementation-defined);
//  - positions use only + - * / sqrt floor and our own polynomial sin/cos (no libm
//    transcendental whose last bit may differ between C libraries);
//  - work split across threads writes disjoint, precomputed slots; normals are
//    accumulated serially in triangle order.
//
// Every shape is welded (shared vertices, no duplicates), has no unreferenced vertex and
// no degenerate triangle, carries positions, unit normals (area-weighted smooth), UV0
// in [0,1] and two materials (indices 0 and 1). Counter-clockwise = front = outside.
//
// Triangle count: what the shape's grid reaches when rounded to the target (formulas per
// shape below), never below the shape's minimum. Worst-case absolute error: sphere
// 12n+9 (n = grid), terrain ~2n, thin 2S, torus R, islands 6(2b+1) (b = island grid);
// relative error is about 1/n for the sphere, the coarsest. Hence the pinned tolerance:
// |count - target| <= 2% of target for targets >= 32,000 (kGenToleranceFrom), and for
// islands only with the default island count (an explicit small count coarsens steps).
#include <array>
#include <cstdint>
#include <optional>
#include <string_view>

#include "vgeo/mesh/mesh.h"

namespace vgeo {

enum class GenShape : uint8_t {
  // Cube-sphere with n x n quads per cube face (12 n^2 triangles, n = round(sqrt(T/12))),
  // radially displaced by seeded fBm noise: closed, genus 0, star-shaped (no
  // self-intersection). Material 1 where the displacement is positive ("highlands").
  kSphere,
  // Heightfield over [-1,1]^2 in XZ (Y up), n x n quads with seeded circular holes cut out
  // (whole quads removed, bow-tie vertices repaired so the result is 2-manifold with
  // boundary). Holes never touch the outer border. n is searched so that the kept
  // 2 * quads is closest to T; minimum grid kTerrainMinGrid. Material 1 above a seeded
  // "snow line".
  kTerrain,
  // `islands` disjoint closed cube-spheres (own seed, ellipsoidal scale, noise) in
  // separate cells of a cubic grid, so they never overlap. Island i has n_i x n_i quads
  // per face; n_i is b or b+1 chosen to bring the sum of 12 n_i^2 closest to T.
  // Material = island index % 2.
  kIslands,
  // Thin-walled tube (outer radius 1, seeded wall thickness 1-3% of the radius, Y axis,
  // length 2) closed by annular caps: closed, genus 1, inner and outer walls a hair apart.
  // S segments around, L rings along: 4 S (L+1) triangles. Material 0 outside, 1 inside.
  kThin,
  // Torus (major radius 1, minor 0.35, seeded noise on the minor radius): closed,
  // genus 1, 2 S R triangles with S = 2R around the major circle. Material in 8 bands.
  kTorus,
};

inline constexpr std::array<GenShape, 5> kAllGenShapes{GenShape::kSphere, GenShape::kTerrain,
                                                       GenShape::kIslands, GenShape::kThin,
                                                       GenShape::kTorus};

// "sphere", "terrain", "islands", "thin", "torus" (stable: used on the command line).
std::string_view gen_shape_name(GenShape shape);
std::optional<GenShape> parse_gen_shape(std::string_view name);

// Largest accepted target: 2^30 triangles keeps every count (after rounding up to a
// shape's grid) below 2^31 and every vertex index in uint32_t.
inline constexpr uint64_t kMaxGenTriangles = uint64_t(1) << 30;
// Relative tolerance of the reached triangle count for targets >= kGenToleranceFrom:
// the sphere's worst case (12n+9)/(12n^2+12n+3) drops below 2% at n = 51 (31,827).
inline constexpr double kGenTriangleTolerance = 0.02;
inline constexpr uint64_t kGenToleranceFrom = 32'000;
// Default island size when GenerateOptions::islands == 0: 8x8 quads per cube face.
inline constexpr uint64_t kDefaultIslandTriangles = 768;
// Smallest terrain grid: below it the seeded holes would eat most of the surface.
inline constexpr uint32_t kTerrainMinGrid = 16;

struct GenerateOptions {
  GenShape shape = GenShape::kSphere;
  uint64_t target_triangles = 100'000;  // 1 .. kMaxGenTriangles
  uint64_t seed = 1;
  uint32_t islands = 0;  // kIslands only: component count; 0 = target / kDefaultIslandTriangles
  unsigned threads = 1;  // 0 = default_thread_count(); output is identical for any value
};

// Throws VgeoError GEN_TRIANGLES_OUT_OF_RANGE (kExitUsage) when target_triangles is 0 or
// above kMaxGenTriangles, GEN_ISLANDS_OUT_OF_RANGE when islands * 12 > kMaxGenTriangles.
Mesh generate_mesh(const GenerateOptions& options);

// The mesh, two materials ("gen_a", "gen_b") and one identity instance.
Scene generate_scene(const GenerateOptions& options);

// Area-weighted smooth vertex normals, accumulated serially in triangle order (so the
// result is deterministic); vertices with a zero sum get (0,0,1). Resizes mesh.normals.
void compute_smooth_normals(Mesh& mesh);

// Closed UV sphere, the small fixed mesh of unit tests and benchmarks (generate_mesh's
// shapes are for scale): `rings` x `segments`, one vertex per pole (welded), CCW seen from
// outside, unit normals, no uvs; 2 * segments * (rings - 1) triangles.
Mesh make_uv_sphere(uint32_t rings, uint32_t segments, float radius = 1.0f, Vec3 center = {});

// SplitMix64 (Steele, Lea, Flood 2014): the only PRNG used by the generators.
struct SplitMix64 {
  uint64_t state = 0;
  uint64_t next() {
    uint64_t z = (state += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
  }
  // Uniform in [0,1) with 53 random bits.
  double uniform01() { return double(next() >> 11) * (1.0 / 9007199254740992.0); }
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform01(); }
  // Uniform integer in [0, n) (multiply-shift; bias below 2^-32 for n < 2^32).
  uint32_t below(uint32_t n) { return uint32_t(((next() >> 32) * uint64_t(n)) >> 32); }
};

// Smooth seeded 3D value noise (quintic fade, trilinear), one octave, in [-1,1].
float value_noise(float x, float y, float z, uint64_t seed);
// Fractal sum of `octaves` value-noise octaves (frequency x2, amplitude x0.5), ~[-1,1].
float fbm_noise(float x, float y, float z, uint64_t seed, int octaves);

}  // namespace vgeo
