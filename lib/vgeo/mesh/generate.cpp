// Procedural shapes (see generate.h for the contract). Every vertex and triangle is a
// pure function of (shape parameters, index), so chunks can be filled by any thread in
// any order; only normals are accumulated serially.
// Based on: value noise summed over octaves (fractional Brownian motion), as in Ebert et al.,
// "Texturing and Modeling: A Procedural Approach", 3rd ed., 2003 (Musgrave's chapters).
#include "vgeo/mesh/generate.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <memory>
#include <string>

#include "vgeo/core/thread_pool.h"

namespace vgeo {
namespace {

// Vertices / triangles filled per parallel work item: large enough to amortise the
// pool's dispatch, small enough to balance 2-16 threads on 1M-vertex meshes.
constexpr size_t kChunk = 1 << 15;

// Sphere: relative radial displacement and noise frequency over the unit sphere. 12%
// keeps the surface visibly bumpy and strictly star-shaped (radius stays > 0.8).
constexpr float kSphereAmplitude = 0.12f;
constexpr float kSphereFrequency = 1.7f;
constexpr int kSphereOctaves = 4;
// Islands: cells of size 1; |jitter| + radius * scale * (1 + amplitude) < 0.5 so two
// islands never touch (0.12 + 0.3 * 1 * 1.12 = 0.456).
constexpr double kIslandJitter = 0.12;
constexpr double kIslandRadiusMin = 0.18, kIslandRadiusMax = 0.3;
constexpr double kIslandAxisMin = 0.65;
constexpr int kIslandOctaves = 3;
// Terrain: height scale over a 2x2 extent, hole radii, and the distance kept free of
// holes along the outer border (so the outer border stays one simple loop).
constexpr float kTerrainHeight = 0.25f;
constexpr float kTerrainFrequency = 2.0f;
constexpr int kTerrainOctaves = 5;
constexpr uint32_t kTerrainHolesMin = 3, kTerrainHolesSpread = 6;  // 3..8 holes
constexpr double kTerrainHoleRadiusMin = 0.05, kTerrainHoleRadiusMax = 0.14;
constexpr double kTerrainBorderMargin = 0.05;
// Thin tube: wall thickness relative to the outer radius (1-3%: thinner than a typical
// cluster's extent at any LOD, which is the point) and the waviness shared by both walls.
constexpr double kThinWallMin = 0.01, kThinWallMax = 0.03;
constexpr float kThinWaviness = 0.03f;
// Torus: minor radius and its noise amplitude (0.35 * 1.25 < 1: never self-intersects).
constexpr double kTorusMinor = 0.35;
constexpr float kTorusAmplitude = 0.25f;
constexpr uint32_t kTorusBands = 8;

// ---------------------------------------------------------------- small helpers

uint64_t mix64(uint64_t z) {
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  return z ^ (z >> 31);
}

uint64_t derive_seed(uint64_t seed, uint64_t stream) {
  return mix64(seed ^ mix64(stream + 0x632be59bd9b4e019ull));
}

// sin and cos of 2*pi*k/n from + - * / only (bit-identical wherever IEEE-754 double is):
// quadrant by integer arithmetic, then Taylor series on [0, pi/2) (error < 1e-15).
void sincos_turn(uint64_t k, uint64_t n, double* s, double* c) {
  const double half_pi = 1.57079632679489661923;
  uint64_t k4 = (k % n) * 4;
  uint64_t quadrant = k4 / n, rem = k4 % n;
  double x = double(rem) / double(n) * half_pi;
  double x2 = x * x;
  double sn = 0, cs = 0, term_s = x, term_c = 1;
  for (int i = 0; i < 12; ++i) {
    sn += term_s;
    cs += term_c;
    term_s *= -x2 / double((2 * i + 2) * (2 * i + 3));
    term_c *= -x2 / double((2 * i + 1) * (2 * i + 2));
  }
  switch (quadrant) {
    case 0: *s = sn, *c = cs; break;
    case 1: *s = cs, *c = -sn; break;
    case 2: *s = -sn, *c = -cs; break;
    default: *s = -cs, *c = sn; break;
  }
}

// Continuous periodic UV coordinate for welded wrap-around grids: 0 -> 1 -> 0.
float triangle_wave(uint64_t k, uint64_t n) {
  double t = double(k % n) / double(n);
  return float(1.0 - std::fabs(2.0 * t - 1.0));
}

template <class Fn>
void for_chunks(ThreadPool* pool, size_t n, Fn&& fn) {
  size_t chunks = (n + kChunk - 1) / kChunk;
  auto body = [&](size_t c) { fn(c * kChunk, std::min(n, (c + 1) * kChunk)); };
  if (!pool || chunks <= 1) {
    for (size_t c = 0; c < chunks; ++c) body(c);
    return;
  }
  pool->parallel_for(chunks, body);
}

void resize_mesh(Mesh& m, size_t vertices, size_t triangles) {
  m.positions.resize(3 * vertices);
  m.uvs.resize(2 * vertices);
  m.indices.resize(3 * triangles);
  m.materials.resize(triangles);
}

void put3(float* p, size_t v, double x, double y, double z) {
  p[3 * v] = float(x), p[3 * v + 1] = float(y), p[3 * v + 2] = float(z);
}

// ---------------------------------------------------------------- cube-sphere
// Lattice points on the surface of the cube [0,n]^3, numbered without duplicates:
// the z=0 layer, the z=n layer, then the boundary ring of each layer 0<z<n.
struct CubeLattice {
  uint32_t n;
  uint64_t vertex_count() const { return 6ull * n * n + 2; }
  uint64_t triangle_count() const { return 12ull * n * n; }

  uint32_t index(uint32_t x, uint32_t y, uint32_t z) const {
    const uint32_t row = n + 1, layer = row * row;
    if (z == 0) return y * row + x;
    if (z == n) return layer + y * row + x;
    uint32_t k;
    if (y == 0 && x < n) k = x;
    else if (x == n && y < n) k = n + y;
    else if (y == n && x > 0) k = 3 * n - x;
    else k = 4 * n - y;  // x == 0, y > 0
    return 2 * layer + (z - 1) * 4 * n + k;
  }
  void point(uint32_t i, uint32_t& x, uint32_t& y, uint32_t& z) const {
    const uint32_t row = n + 1, layer = row * row;
    if (i < 2 * layer) {
      z = i < layer ? 0 : n;
      uint32_t j = i % layer;
      y = j / row, x = j % row;
      return;
    }
    uint32_t r = i - 2 * layer;
    z = 1 + r / (4 * n);
    uint32_t k = r % (4 * n);
    if (k < n) x = k, y = 0;
    else if (k < 2 * n) x = n, y = k - n;
    else if (k < 3 * n) x = 3 * n - k, y = n;
    else x = 0, y = 4 * n - k;
  }
  // Face f's grid point (u,v) -> lattice point; (u, v, outward) is right-handed so
  // quads (a,b,d),(a,d,c) are counter-clockwise seen from outside.
  void face_point(int f, uint32_t u, uint32_t v, uint32_t& x, uint32_t& y, uint32_t& z) const {
    switch (f) {
      case 0: x = n, y = u, z = v; break;  // +X: U=+Y V=+Z
      case 1: x = 0, y = v, z = u; break;  // -X: U=+Z V=+Y
      case 2: x = v, y = n, z = u; break;  // +Y: U=+Z V=+X
      case 3: x = u, y = 0, z = v; break;  // -Y: U=+X V=+Z
      case 4: x = u, y = v, z = n; break;  // +Z: U=+X V=+Y
      default: x = v, y = u, z = 0; break; // -Z: U=+Y V=+X
    }
  }
  uint32_t face_index(int f, uint32_t u, uint32_t v) const {
    uint32_t x, y, z;
    face_point(f, u, v, x, y, z);
    return index(x, y, z);
  }
};

struct CubeSphere {
  uint32_t n = 1;
  Vec3 center;
  double radius[3] = {1, 1, 1};  // ellipsoid semi-axes
  float amplitude = kSphereAmplitude, frequency = kSphereFrequency;
  int octaves = kSphereOctaves;
  uint64_t noise_seed = 0;
};

// Unit direction of a cube lattice point (Nowell's cube-to-sphere map: only sqrt, and
// far more uniform than normalising the cube point).
void cube_direction(const CubeLattice& lat, uint32_t x, uint32_t y, uint32_t z, double d[3]) {
  double cx = 2.0 * x / lat.n - 1.0, cy = 2.0 * y / lat.n - 1.0, cz = 2.0 * z / lat.n - 1.0;
  double x2 = cx * cx, y2 = cy * cy, z2 = cz * cz;
  d[0] = cx * std::sqrt(std::max(0.0, 1.0 - y2 / 2 - z2 / 2 + y2 * z2 / 3));
  d[1] = cy * std::sqrt(std::max(0.0, 1.0 - z2 / 2 - x2 / 2 + z2 * x2 / 3));
  d[2] = cz * std::sqrt(std::max(0.0, 1.0 - x2 / 2 - y2 / 2 + x2 * y2 / 3));
}

// Octahedral map of a unit direction to [0,1]^2 (Y is the octahedron's axis).
void octahedral_uv(const double d[3], float* uv) {
  double l1 = std::fabs(d[0]) + std::fabs(d[1]) + std::fabs(d[2]);
  double px = d[0] / l1, pz = d[2] / l1;
  if (d[1] < 0) {
    double ox = (1 - std::fabs(pz)) * (px >= 0 ? 1 : -1);
    double oz = (1 - std::fabs(px)) * (pz >= 0 ? 1 : -1);
    px = ox, pz = oz;
  }
  uv[0] = float(std::clamp(0.5 * (px + 1), 0.0, 1.0));
  uv[1] = float(std::clamp(0.5 * (pz + 1), 0.0, 1.0));
}

// Vertices [begin,end) of one cube-sphere into slots base+begin.. of pos/uv/height.
void cube_sphere_vertices(const CubeSphere& s, size_t begin, size_t end, float* pos, float* uv,
                          float* height) {
  CubeLattice lat{s.n};
  for (size_t i = begin; i < end; ++i) {
    uint32_t x, y, z;
    lat.point(uint32_t(i), x, y, z);
    double d[3];
    cube_direction(lat, x, y, z, d);
    float h = fbm_noise(float(d[0]) * s.frequency, float(d[1]) * s.frequency,
                        float(d[2]) * s.frequency, s.noise_seed, s.octaves);
    double r = 1.0 + double(s.amplitude) * h;
    put3(pos, i, s.center.x + s.radius[0] * r * d[0], s.center.y + s.radius[1] * r * d[1],
         s.center.z + s.radius[2] * r * d[2]);
    octahedral_uv(d, uv + 2 * i);
    if (height) height[i] = h;
  }
}

// Triangles [begin,end) (two per quad, quads numbered face-major) into idx slots.
void cube_sphere_triangles(uint32_t n, uint32_t base_vertex, size_t begin, size_t end,
                           uint32_t* idx) {
  CubeLattice lat{n};
  const size_t per_face = size_t(n) * n;
  for (size_t t = begin & ~size_t(1); t < end; t += 2) {
    size_t q = t / 2;
    int f = int(q / per_face);
    uint32_t u = uint32_t(q % per_face % n), v = uint32_t(q % per_face / n);
    uint32_t a = base_vertex + lat.face_index(f, u, v), b = base_vertex + lat.face_index(f, u + 1, v);
    uint32_t c = base_vertex + lat.face_index(f, u, v + 1);
    uint32_t d = base_vertex + lat.face_index(f, u + 1, v + 1);
    const uint32_t tri[6] = {a, b, d, a, d, c};
    for (size_t k = 0; k < 2; ++k)
      if (t + k >= begin && t + k < end) std::copy(tri + 3 * k, tri + 3 * k + 3, idx + 3 * (t + k));
  }
}

uint32_t grid_for(double triangles_per_unit) {
  return uint32_t(std::max(1.0, std::round(std::sqrt(triangles_per_unit))));
}

Mesh make_sphere(const GenerateOptions& o, ThreadPool* pool) {
  CubeSphere s;
  s.n = grid_for(double(o.target_triangles) / 12.0);
  s.noise_seed = derive_seed(o.seed, 1);
  CubeLattice lat{s.n};
  Mesh m;
  m.name = "sphere";
  resize_mesh(m, lat.vertex_count(), lat.triangle_count());
  std::vector<float> height(lat.vertex_count());
  for_chunks(pool, lat.vertex_count(), [&](size_t b, size_t e) {
    cube_sphere_vertices(s, b, e, m.positions.data(), m.uvs.data(), height.data());
  });
  for_chunks(pool, lat.triangle_count(), [&](size_t b, size_t e) {
    cube_sphere_triangles(s.n, 0, b, e, m.indices.data());
    for (size_t t = b; t < e; ++t) {
      const uint32_t* v = &m.indices[3 * t];
      m.materials[t] = height[v[0]] + height[v[1]] + height[v[2]] > 0 ? 1u : 0u;
    }
  });
  return m;
}

// ---------------------------------------------------------------- islands

Mesh make_islands(const GenerateOptions& o, ThreadPool* pool) {
  const uint64_t target = o.target_triangles;
  uint64_t k = o.islands ? o.islands
                         : std::max<uint64_t>(1, (target + kDefaultIslandTriangles / 2) /
                                                     kDefaultIslandTriangles);
  // Base grid b for every island, b+1 for the first m islands, m chosen closest to target.
  uint64_t b = std::max<uint64_t>(1, uint64_t(std::sqrt(double(target) / (12.0 * k))));
  while (12 * k * (b + 1) * (b + 1) <= target) ++b;  // guard sqrt rounding
  while (b > 1 && 12 * k * b * b > target) --b;
  double rest = double(target) - 12.0 * double(k) * double(b * b);
  uint64_t m_big = uint64_t(std::clamp(std::round(rest / (12.0 * double(2 * b + 1))), 0.0, double(k)));

  std::vector<CubeSphere> islands(k);
  std::vector<uint64_t> vbase(k + 1, 0), tbase(k + 1, 0);
  uint64_t cells = 1;
  while (cells * cells * cells < k) ++cells;
  for (uint64_t i = 0; i < k; ++i) {
    SplitMix64 rng{derive_seed(o.seed, 1000 + i)};
    CubeSphere& s = islands[i];
    s.n = uint32_t(i < m_big ? b + 1 : b);
    uint64_t cx = i % cells, cy = i / cells % cells, cz = i / (cells * cells);
    s.center = {float(double(cx) + 0.5 + rng.uniform(-kIslandJitter, kIslandJitter)),
                float(double(cy) + 0.5 + rng.uniform(-kIslandJitter, kIslandJitter)),
                float(double(cz) + 0.5 + rng.uniform(-kIslandJitter, kIslandJitter))};
    double radius = rng.uniform(kIslandRadiusMin, kIslandRadiusMax);
    for (double& r : s.radius) r = radius * rng.uniform(kIslandAxisMin, 1.0);
    s.octaves = kIslandOctaves;
    s.noise_seed = rng.next();
    CubeLattice lat{s.n};
    vbase[i + 1] = vbase[i] + lat.vertex_count();
    tbase[i + 1] = tbase[i] + lat.triangle_count();
  }
  Mesh m;
  m.name = "islands";
  resize_mesh(m, vbase[k], tbase[k]);
  auto fill = [&](size_t i) {
    const CubeSphere& s = islands[i];
    CubeLattice lat{s.n};
    float* pos = m.positions.data() + 3 * vbase[i];
    float* uv = m.uvs.data() + 2 * vbase[i];
    cube_sphere_vertices(s, 0, lat.vertex_count(), pos, uv, nullptr);
    cube_sphere_triangles(s.n, uint32_t(vbase[i]), 0, lat.triangle_count(),
                          m.indices.data() + 3 * tbase[i]);
    std::fill(m.materials.begin() + tbase[i], m.materials.begin() + tbase[i + 1], uint32_t(i % 2));
  };
  if (pool && k > 1) pool->parallel_for(k, fill);
  else for (size_t i = 0; i < k; ++i) fill(i);
  return m;
}

// ---------------------------------------------------------------- terrain

struct Hole {
  double x, z, r;
};

// removed[j*n+i] = 1 for quad (i,j) cut by a hole, then bow-tie repair: a grid vertex
// whose four quads are kept/removed diagonally would join two fans (not 2-manifold),
// so one of the two kept quads is removed; repeat until stable.
std::vector<uint8_t> terrain_mask(uint32_t n, const std::vector<Hole>& holes) {
  std::vector<uint8_t> removed(size_t(n) * n, 0);
  for (const Hole& h : holes) {
    auto to_cell = [&](double w) { return std::clamp(int64_t(std::floor((w + 1) * 0.5 * n)), int64_t(0), int64_t(n) - 1); };
    for (int64_t j = to_cell(h.z - h.r); j <= to_cell(h.z + h.r); ++j)
      for (int64_t i = to_cell(h.x - h.r); i <= to_cell(h.x + h.r); ++i) {
        double qx = (i + 0.5) * 2.0 / n - 1, qz = (j + 0.5) * 2.0 / n - 1;
        if ((qx - h.x) * (qx - h.x) + (qz - h.z) * (qz - h.z) < h.r * h.r) removed[size_t(j) * n + i] = 1;
      }
  }
  for (bool changed = true; changed;) {
    changed = false;
    for (uint32_t j = 1; j < n; ++j)
      for (uint32_t i = 1; i < n; ++i) {
        uint8_t& q00 = removed[size_t(j - 1) * n + i - 1];
        uint8_t& q10 = removed[size_t(j - 1) * n + i];
        uint8_t q01 = removed[size_t(j) * n + i - 1], q11 = removed[size_t(j) * n + i];
        if (!q00 && !q11 && q10 && q01) q00 = 1, changed = true;
        else if (!q10 && !q01 && q00 && q11) q10 = 1, changed = true;
      }
  }
  return removed;
}

uint64_t kept_triangles(const std::vector<uint8_t>& removed) {
  uint64_t kept = 0;
  for (uint8_t r : removed) kept += r ? 0 : 2;
  return kept;
}

Mesh make_terrain(const GenerateOptions& o, ThreadPool* pool) {
  SplitMix64 rng{derive_seed(o.seed, 2)};
  std::vector<Hole> holes(kTerrainHolesMin + rng.below(kTerrainHolesSpread));
  for (Hole& h : holes) {
    h.r = rng.uniform(kTerrainHoleRadiusMin, kTerrainHoleRadiusMax);
    double lim = 1.0 - h.r - kTerrainBorderMargin;
    h.x = rng.uniform(-lim, lim), h.z = rng.uniform(-lim, lim);
  }
  const uint64_t noise_seed = rng.next();
  const float snow_line = float(rng.uniform(0.0, 0.15)) * kTerrainHeight;

  // Grid search: estimate, correct by the measured kept fraction, then best of +-1.
  const double target = double(o.target_triangles);
  auto clamp_grid = [](double g) { return uint32_t(std::max<double>(kTerrainMinGrid, std::round(g))); };
  uint32_t n0 = clamp_grid(std::sqrt(target / 2));
  uint64_t c0 = kept_triangles(terrain_mask(n0, holes));
  uint32_t n1 = clamp_grid(n0 * std::sqrt(target / double(std::max<uint64_t>(c0, 1))));
  uint32_t best_n = n0;
  uint64_t best_c = c0;
  for (uint32_t cand : {n1 > kTerrainMinGrid ? n1 - 1 : n1, n1, n1 + 1}) {
    uint64_t c = kept_triangles(terrain_mask(cand, holes));
    if (std::fabs(double(c) - target) < std::fabs(double(best_c) - target)) best_n = cand, best_c = c;
  }
  const uint32_t n = best_n;
  const std::vector<uint8_t> removed = terrain_mask(n, holes);

  // Keep only referenced grid vertices, numbered in grid order.
  const uint32_t row = n + 1;
  std::vector<uint32_t> remap(size_t(row) * row, UINT32_MAX);
  for (uint32_t j = 0; j < n; ++j)
    for (uint32_t i = 0; i < n; ++i)
      if (!removed[size_t(j) * n + i])
        for (uint32_t c : {j * row + i, j * row + i + 1, (j + 1) * row + i, (j + 1) * row + i + 1})
          remap[c] = 0;
  std::vector<uint32_t> grid_of_vertex;
  for (uint32_t g = 0; g < remap.size(); ++g)
    if (remap[g] == 0) remap[g] = uint32_t(grid_of_vertex.size()), grid_of_vertex.push_back(g);

  Mesh m;
  m.name = "terrain";
  resize_mesh(m, grid_of_vertex.size(), best_c);
  for_chunks(pool, grid_of_vertex.size(), [&](size_t b, size_t e) {
    for (size_t v = b; v < e; ++v) {
      uint32_t i = grid_of_vertex[v] % row, j = grid_of_vertex[v] / row;
      double x = 2.0 * i / n - 1, z = 2.0 * j / n - 1;
      float h = kTerrainHeight * fbm_noise(float(x) * kTerrainFrequency, 0.37f,
                                           float(z) * kTerrainFrequency, noise_seed, kTerrainOctaves);
      put3(m.positions.data(), v, x, h, z);
      m.uvs[2 * v] = float(double(i) / n), m.uvs[2 * v + 1] = float(double(j) / n);
    }
  });
  size_t t = 0;
  for (uint32_t j = 0; j < n; ++j)
    for (uint32_t i = 0; i < n; ++i) {
      if (removed[size_t(j) * n + i]) continue;
      // a=(i,j) b=(i+1,j) c=(i,j+1) d=(i+1,j+1); X x Z = -Y, so (a,c,d),(a,d,b) face +Y.
      uint32_t a = remap[j * row + i], b = remap[j * row + i + 1];
      uint32_t c = remap[(j + 1) * row + i], d = remap[(j + 1) * row + i + 1];
      const uint32_t tri[6] = {a, c, d, a, d, b};
      for (int k = 0; k < 2; ++k, ++t) {
        std::copy(tri + 3 * k, tri + 3 * k + 3, &m.indices[3 * t]);
        float mean = (m.positions[3 * tri[3 * k] + 1] + m.positions[3 * tri[3 * k + 1] + 1] +
                      m.positions[3 * tri[3 * k + 2] + 1]) / 3.0f;
        m.materials[t] = mean > snow_line ? 1u : 0u;
      }
    }
  assert(t == best_c);
  return m;
}

// ---------------------------------------------------------------- torus

Mesh make_torus(const GenerateOptions& o, ThreadPool* pool) {
  const double target = double(o.target_triangles);
  const uint32_t rings = std::max<uint32_t>(3, uint32_t(std::round(std::sqrt(target / 4))));
  const uint32_t segs = std::max<uint32_t>(3, uint32_t(std::round(target / (2.0 * rings))));
  const uint64_t noise_seed = derive_seed(o.seed, 3);
  Mesh m;
  m.name = "torus";
  resize_mesh(m, size_t(segs) * rings, 2 * size_t(segs) * rings);
  // Vertex (i minor, j major) = j * rings + i.
  for_chunks(pool, size_t(segs) * rings, [&](size_t b, size_t e) {
    for (size_t v = b; v < e; ++v) {
      uint32_t i = uint32_t(v % rings), j = uint32_t(v / rings);
      double st, ct, sp, cp;
      sincos_turn(j, segs, &st, &ct);
      sincos_turn(i, rings, &sp, &cp);
      double bx = (1 + kTorusMinor * cp) * ct, by = kTorusMinor * sp, bz = (1 + kTorusMinor * cp) * st;
      float h = fbm_noise(float(bx) * 2, float(by) * 2, float(bz) * 2, noise_seed, kSphereOctaves);
      double r = kTorusMinor * (1.0 + double(kTorusAmplitude) * h);
      put3(m.positions.data(), v, (1 + r * cp) * ct, r * sp, (1 + r * cp) * st);
      m.uvs[2 * v] = triangle_wave(j, segs), m.uvs[2 * v + 1] = triangle_wave(i, rings);
    }
  });
  // U = minor angle, V = major angle: U x V points outward.
  for_chunks(pool, size_t(segs) * rings, [&](size_t b, size_t e) {
    for (size_t q = b; q < e; ++q) {
      uint32_t i = uint32_t(q % rings), j = uint32_t(q / rings);
      uint32_t i1 = (i + 1) % rings, j1 = (j + 1) % segs;
      uint32_t a = j * rings + i, bb = j * rings + i1, c = j1 * rings + i, d = j1 * rings + i1;
      const uint32_t tri[6] = {a, bb, d, a, d, c};
      std::copy(tri, tri + 6, &m.indices[6 * q]);
      m.materials[2 * q] = m.materials[2 * q + 1] = (uint64_t(j) * kTorusBands / segs) % 2;
    }
  });
  return m;
}

// ---------------------------------------------------------------- thin tube

Mesh make_thin(const GenerateOptions& o, ThreadPool* pool) {
  const double target = double(o.target_triangles);
  const uint32_t segs = std::max<uint32_t>(3, uint32_t(std::round(std::sqrt(target / 2))));
  const uint32_t rings = std::max<uint32_t>(2, uint32_t(std::round(target / (4.0 * segs))));  // L+1
  SplitMix64 rng{derive_seed(o.seed, 4)};
  const double wall = rng.uniform(kThinWallMin, kThinWallMax);
  const uint64_t noise_seed = rng.next();
  const size_t per_wall = size_t(rings) * segs;
  Mesh m;
  m.name = "thin";
  resize_mesh(m, 2 * per_wall, 4 * per_wall);
  // Outer vertex (r ring, j segment) = r * segs + j; inner = per_wall + the same.
  for_chunks(pool, per_wall, [&](size_t b, size_t e) {
    for (size_t v = b; v < e; ++v) {
      uint32_t j = uint32_t(v % segs), r = uint32_t(v / segs);
      double s, c;
      sincos_turn(j, segs, &s, &c);
      double y = 2.0 * r / (rings - 1) - 1.0;
      double w = 1.0 + double(kThinWaviness) * fbm_noise(float(c) * 2, float(y) * 2, float(s) * 2,
                                                         noise_seed, kSphereOctaves);
      double ro = w, ri = (1.0 - wall) * w;
      put3(m.positions.data(), v, ro * c, y, ro * s);
      put3(m.positions.data(), per_wall + v, ri * c, y, ri * s);
      float u = triangle_wave(j, segs), vv = float((y + 1) / 2);
      m.uvs[2 * v] = m.uvs[2 * (per_wall + v)] = u;
      m.uvs[2 * v + 1] = m.uvs[2 * (per_wall + v) + 1] = vv;
    }
  });
  const uint32_t pw = uint32_t(per_wall);
  size_t t = 0;
  auto emit = [&](uint32_t a, uint32_t b, uint32_t c, uint32_t mat) {
    m.indices[3 * t] = a, m.indices[3 * t + 1] = b, m.indices[3 * t + 2] = c;
    m.materials[t++] = mat;
  };
  for (uint32_t r = 0; r + 1 < rings; ++r)
    for (uint32_t j = 0; j < segs; ++j) {
      uint32_t j1 = (j + 1) % segs;
      uint32_t a = r * segs + j, b = (r + 1) * segs + j, c = r * segs + j1, d = (r + 1) * segs + j1;
      emit(a, b, d, 0), emit(a, d, c, 0);                  // outer: (y, theta) faces outward
      emit(pw + a, pw + d, pw + b, 1), emit(pw + a, pw + c, pw + d, 1);  // inner: reversed
    }
  for (uint32_t j = 0; j < segs; ++j) {
    uint32_t j1 = (j + 1) % segs;
    uint32_t top = (rings - 1) * segs;
    uint32_t a = top + j, b = top + j1, c = pw + top + j, d = pw + top + j1;
    emit(a, c, d, 0), emit(a, d, b, 0);  // top cap faces +Y
    a = j, b = j1, c = pw + j, d = pw + j1;
    emit(a, d, c, 0), emit(a, b, d, 0);  // bottom cap faces -Y
  }
  assert(t == 4 * per_wall);
  return m;
}

}  // namespace

// ---------------------------------------------------------------- public

std::string_view gen_shape_name(GenShape shape) {
  switch (shape) {
    case GenShape::kSphere: return "sphere";
    case GenShape::kTerrain: return "terrain";
    case GenShape::kIslands: return "islands";
    case GenShape::kThin: return "thin";
    case GenShape::kTorus: return "torus";
  }
  return "?";
}

std::optional<GenShape> parse_gen_shape(std::string_view name) {
  for (GenShape s : kAllGenShapes)
    if (gen_shape_name(s) == name) return s;
  return std::nullopt;
}

float value_noise(float x, float y, float z, uint64_t seed) {
  float fx = std::floor(x), fy = std::floor(y), fz = std::floor(z);
  float tx = x - fx, ty = y - fy, tz = z - fz;
  auto fade = [](float t) { return t * t * t * (t * (t * 6.0f - 15.0f) + 10.0f); };
  float ux = fade(tx), uy = fade(ty), uz = fade(tz);
  int64_t ix = int64_t(fx), iy = int64_t(fy), iz = int64_t(fz);
  auto lattice = [&](int64_t dx, int64_t dy, int64_t dz) {
    uint64_t h = seed + uint64_t(ix + dx) * 0x9e3779b97f4a7c15ull +
                 uint64_t(iy + dy) * 0xc2b2ae3d27d4eb4full + uint64_t(iz + dz) * 0x165667b19e3779f9ull;
    return float(mix64(h) >> 40) * (2.0f / 16777216.0f) - 1.0f;  // 24 bits -> [-1,1)
  };
  auto lerp = [](float a, float b, float t) { return a + (b - a) * t; };
  float x00 = lerp(lattice(0, 0, 0), lattice(1, 0, 0), ux);
  float x10 = lerp(lattice(0, 1, 0), lattice(1, 1, 0), ux);
  float x01 = lerp(lattice(0, 0, 1), lattice(1, 0, 1), ux);
  float x11 = lerp(lattice(0, 1, 1), lattice(1, 1, 1), ux);
  return lerp(lerp(x00, x10, uy), lerp(x01, x11, uy), uz);
}

float fbm_noise(float x, float y, float z, uint64_t seed, int octaves) {
  float sum = 0, amp = 0.5f, freq = 1.0f;
  for (int o = 0; o < octaves; ++o) {
    sum += amp * value_noise(x * freq, y * freq, z * freq, seed + uint64_t(o) * 0x9e3779b97f4a7c15ull);
    amp *= 0.5f, freq *= 2.0f;
  }
  return sum * 2.0f;  // 0.5 + 0.25 + ... < 1: rescale so the sum spans ~[-1,1]
}

void compute_smooth_normals(Mesh& mesh) {
  const size_t nv = mesh.vertex_count();
  mesh.normals.assign(3 * nv, 0.0f);
  const float* p = mesh.positions.data();
  float* nrm = mesh.normals.data();
  for (size_t t = 0; t < mesh.triangle_count(); ++t) {
    const uint32_t* v = &mesh.indices[3 * t];
    Vec3 a{p[3 * v[0]], p[3 * v[0] + 1], p[3 * v[0] + 2]};
    Vec3 b{p[3 * v[1]], p[3 * v[1] + 1], p[3 * v[1] + 2]};
    Vec3 c{p[3 * v[2]], p[3 * v[2] + 1], p[3 * v[2] + 2]};
    Vec3 fn = cross(b - a, c - a);  // length = 2 * area: area weighting
    for (int k = 0; k < 3; ++k) {
      nrm[3 * v[k]] += fn.x, nrm[3 * v[k] + 1] += fn.y, nrm[3 * v[k] + 2] += fn.z;
    }
  }
  for (size_t v = 0; v < nv; ++v) {
    Vec3 n{nrm[3 * v], nrm[3 * v + 1], nrm[3 * v + 2]};
    float len = length(n);
    if (len > 0 && std::isfinite(len)) n = n * (1.0f / len);
    else n = {0, 0, 1};
    nrm[3 * v] = n.x, nrm[3 * v + 1] = n.y, nrm[3 * v + 2] = n.z;
  }
}

Mesh generate_mesh(const GenerateOptions& options) {
  if (options.target_triangles == 0 || options.target_triangles > kMaxGenTriangles)
    fail("GEN_TRIANGLES_OUT_OF_RANGE", "generate",
         "target triangle count " + std::to_string(options.target_triangles) + " not in [1, " +
             std::to_string(kMaxGenTriangles) + "]",
         kExitUsage);
  if (uint64_t(options.islands) * 12 > kMaxGenTriangles)
    fail("GEN_ISLANDS_OUT_OF_RANGE", "generate",
         std::to_string(options.islands) + " islands exceed the triangle limit", kExitUsage);
  std::unique_ptr<ThreadPool> pool;
  unsigned threads = options.threads ? options.threads : default_thread_count();
  if (threads > 1) pool = std::make_unique<ThreadPool>(threads);
  Mesh m;
  switch (options.shape) {
    case GenShape::kSphere: m = make_sphere(options, pool.get()); break;
    case GenShape::kTerrain: m = make_terrain(options, pool.get()); break;
    case GenShape::kIslands: m = make_islands(options, pool.get()); break;
    case GenShape::kThin: m = make_thin(options, pool.get()); break;
    case GenShape::kTorus: m = make_torus(options, pool.get()); break;
  }
  assert(m.triangle_count() < (uint64_t(1) << 31));
  compute_smooth_normals(m);
  return m;
}

Scene generate_scene(const GenerateOptions& options) {
  Scene scene;
  scene.meshes.push_back(generate_mesh(options));
  scene.materials.push_back(Material{"gen_a", {0.80f, 0.62f, 0.42f, 1.0f}});
  scene.materials.push_back(Material{"gen_b", {0.30f, 0.55f, 0.80f, 1.0f}});
  scene.instances.push_back(Instance{});
  return scene;
}

Mesh make_uv_sphere(uint32_t rings, uint32_t segments, float radius, Vec3 center) {
  Mesh m;
  m.name = "sphere";
  const double pi = 3.14159265358979323846;
  auto add = [&](double th, double ph) {
    double x = std::sin(th) * std::cos(ph), y = std::sin(th) * std::sin(ph), z = std::cos(th);
    m.positions.insert(m.positions.end(), {center.x + float(radius * x), center.y + float(radius * y),
                                           center.z + float(radius * z)});
    m.normals.insert(m.normals.end(), {float(x), float(y), float(z)});
  };
  add(0, 0);  // north pole: vertex 0
  for (uint32_t r = 1; r < rings; ++r)
    for (uint32_t s = 0; s < segments; ++s) add(pi * r / rings, 2 * pi * s / segments);
  add(pi, 0);  // south pole
  uint32_t south = uint32_t(m.positions.size() / 3 - 1);
  auto ring = [&](uint32_t r, uint32_t s) { return 1 + (r - 1) * segments + (s % segments); };
  for (uint32_t s = 0; s < segments; ++s) m.indices.insert(m.indices.end(), {0, ring(1, s), ring(1, s + 1)});
  for (uint32_t r = 1; r + 1 < rings; ++r)
    for (uint32_t s = 0; s < segments; ++s) {
      uint32_t a = ring(r, s), b = ring(r, s + 1), c = ring(r + 1, s), d = ring(r + 1, s + 1);
      m.indices.insert(m.indices.end(), {a, c, d, a, d, b});
    }
  for (uint32_t s = 0; s < segments; ++s)
    m.indices.insert(m.indices.end(), {south, ring(rings - 1, s + 1), ring(rings - 1, s)});
  return m;
}

}  // namespace vgeo
