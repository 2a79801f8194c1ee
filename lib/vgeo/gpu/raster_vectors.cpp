// Raster conformance vectors (raster_vectors.h, spec/raster.md §14).
// Based on: the Vulkan CTS's model of rasterization conformance: only pixels whose coverage is
// unambiguous at the declared sub-pixel precision are compared (lib/vgeo/raster/raster_model.h).
#include "vgeo/gpu/raster_vectors.h"

#include <algorithm>
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <sstream>

#include "vgeo/core/error.h"
#include "vgeo/mesh/generate.h"
#include "vgeo/raster/raster.h"

namespace vgeo {

namespace {

constexpr const char* kMagic = "vgeo-raster-vector 1";
// Vector viewport: 16×16 keeps a vector at a few KB (256 keys) while holding every case.
constexpr uint32_t kSide = 16;
// Dyadic grid of the exact vectors' coordinates: 2^-10 NDC (1/64 sub-pixel unit at 16 px),
// so x·0.5 + 0.5 and ·W·256 are exact in float.
constexpr double kExactGrid = 1.0 / 1024.0;
// Seed of the random vectors: any fixed value; changing it changes every vector file.
constexpr uint64_t kSeed = 13;

double on_grid(double v) { return std::round(v / kExactGrid) * kExactGrid; }

// Builder of one vector's clusters: triangles appended with their own (deduplicated)
// vertices; a new cluster starts when the current one would exceed the format's limits.
struct VectorBuilder {
  RasterVector v;
  void triangle(Vec3 a, Vec3 b, Vec3 c) {
    if (v.clusters.empty() || v.clusters.back().indices.size() / 3 >= kMaxClusterTriangles ||
        v.clusters.back().positions.size() / 3 + 3 > kMaxClusterVertices)
      v.clusters.emplace_back();
    RasterVectorCluster& cl = v.clusters.back();
    for (const Vec3& p : {a, b, c}) {
      uint32_t found = uint32_t(cl.positions.size() / 3);
      for (uint32_t i = 0; i < cl.positions.size() / 3; ++i)
        if (cl.positions[3 * i] == p.x && cl.positions[3 * i + 1] == p.y && cl.positions[3 * i + 2] == p.z) found = i;
      if (found == cl.positions.size() / 3) cl.positions.insert(cl.positions.end(), {p.x, p.y, p.z});
      cl.indices.push_back(uint8_t(found));
    }
  }
  // Front face (counter-clockwise in NDC) from any three points.
  void front(Vec3 a, Vec3 b, Vec3 c) {
    const double cross = (double(b.x) - a.x) * (double(c.y) - a.y) - (double(c.x) - a.x) * (double(b.y) - a.y);
    if (cross < 0) std::swap(b, c);
    triangle(a, b, c);
  }
};

// w = 1 and clip = object: NDC = object xy, depth = object z (reversed Z: larger is nearer).
RasterVector exact_vector(const char* name, const char* description) {
  RasterVector v;
  v.name = name;
  v.description = description;
  v.width = v.height = kSide;
  v.exact_transform = true;
  return v;  // identity object_to_clip
}

Vec3 grid_point(double x, double y, double z) { return {float(on_grid(x)), float(on_grid(y)), float(on_grid(z))}; }

RasterVector make_random() {
  VectorBuilder b{exact_vector("random", "32 random triangles of both orientations, random depths (w = 1)")};
  SplitMix64 rng{kSeed};
  for (int i = 0; i < 32; ++i) {
    Vec3 p[3];
    for (Vec3& q : p) q = grid_point(rng.uniform(-1.1, 1.1), rng.uniform(-1.1, 1.1), rng.uniform(0.05, 1.0));
    b.triangle(p[0], p[1], p[2]);
  }
  return b.v;
}

RasterVector make_slivers() {
  VectorBuilder b{exact_vector("slivers", "long thin triangles (0.02–0.5 px wide) at many angles")};
  SplitMix64 rng{kSeed + 1};
  for (int i = 0; i < 40; ++i) {
    const double angle = rng.uniform(0, 3.14159265358979);
    const double cx = rng.uniform(-0.5, 0.5), cy = rng.uniform(-0.5, 0.5), half = rng.uniform(0.4, 1.2);
    const double width = rng.uniform(0.02, 0.5) * 2.0 / kSide;  // px → NDC
    const double dx = std::cos(angle), dy = std::sin(angle);
    const double z = rng.uniform(0.1, 1.0);
    b.front(grid_point(cx - dx * half, cy - dy * half, z), grid_point(cx + dx * half, cy + dy * half, z),
            grid_point(cx + dx * half - dy * width, cy + dy * half + dx * width, z));
  }
  return b.v;
}

RasterVector make_fan() {
  VectorBuilder b{exact_vector("fan", "two closed fans of 24 and 7 triangles sharing a centre vertex (watertight)")};
  for (const auto& [cx, cy, n, r] : {std::tuple{-0.3, 0.2, 24, 0.65}, std::tuple{0.55, -0.5, 7, 0.4}}) {
    const Vec3 centre = grid_point(cx, cy, 0.5);
    for (int k = 0; k < n; ++k) {
      const double a0 = 2 * 3.14159265358979 * k / n, a1 = 2 * 3.14159265358979 * (k + 1) / n;
      b.front(centre, grid_point(cx + r * std::cos(a0), cy + r * std::sin(a0), 0.5 + 0.3 * std::cos(a0)),
              grid_point(cx + r * std::cos(a1), cy + r * std::sin(a1), 0.5 + 0.3 * std::cos(a1)));
    }
  }
  return b.v;
}

RasterVector make_grid() {
  VectorBuilder b{exact_vector("grid", "a jittered 7×7-cell grid over the viewport, tilted depth (shared edges)")};
  SplitMix64 rng{kSeed + 2};
  constexpr int kCells = 7;
  Vec3 p[kCells + 1][kCells + 1];
  for (int j = 0; j <= kCells; ++j)
    for (int i = 0; i <= kCells; ++i) {
      const double jx = (i == 0 || i == kCells) ? 0 : rng.uniform(-0.08, 0.08);
      const double jy = (j == 0 || j == kCells) ? 0 : rng.uniform(-0.08, 0.08);
      const double x = -1.05 + 2.1 * i / kCells + jx, y = -1.05 + 2.1 * j / kCells + jy;
      p[j][i] = grid_point(x, y, 0.5 + 0.2 * x - 0.1 * y);
    }
  for (int j = 0; j < kCells; ++j)
    for (int i = 0; i < kCells; ++i) {
      b.front(p[j][i], p[j][i + 1], p[j + 1][i + 1]);
      b.front(p[j][i], p[j + 1][i + 1], p[j + 1][i]);
    }
  return b.v;
}

RasterVector make_huge() {
  VectorBuilder b{exact_vector("huge", "triangles 40–60 viewports across (inside the guard band) over small ones")};
  b.front(grid_point(-60, -60, 0.2), grid_point(60, -59, 0.3), grid_point(-1, 61, 0.25));
  b.front(grid_point(-40, 3, 0.6), grid_point(41, 0.5, 0.1), grid_point(0.3, 45, 0.9));
  b.front(grid_point(-0.5, -0.5, 0.8), grid_point(0.5, -0.4, 0.8), grid_point(0, 0.5, 0.8));
  return b.v;
}

RasterVector make_subpixel() {
  VectorBuilder b{exact_vector("subpixel", "40 triangles smaller than a pixel, many covering no centre")};
  SplitMix64 rng{kSeed + 3};
  for (int i = 0; i < 40; ++i) {
    const double cx = rng.uniform(-1, 1), cy = rng.uniform(-1, 1), s = rng.uniform(0.05, 0.9) * 2.0 / kSide;
    const double z = rng.uniform(0.1, 1);
    b.front(grid_point(cx, cy, z), grid_point(cx + s * rng.uniform(0.2, 1), cy + s * rng.uniform(-0.3, 0.3), z),
            grid_point(cx + s * rng.uniform(-0.3, 0.3), cy + s * rng.uniform(0.2, 1), z));
  }
  return b.v;
}

RasterVector make_pixel_centres() {
  VectorBuilder b{exact_vector("pixel_centres",
                               "vertices and edges exactly on pixel centres: horizontal, vertical and diagonal shared "
                               "edges decided by the top-left rule")};
  // NDC of pixel centre k: (k + 0.5) / 16 · 2 − 1, exact on the grid.
  auto c = [](double px, double py, double z) {
    return grid_point((px + 0.5) / kSide * 2 - 1, 1 - (py + 0.5) / kSide * 2, z);
  };
  b.front(c(1, 1, 0.5), c(7, 1, 0.5), c(1, 7, 0.5));
  b.front(c(7, 1, 0.5), c(7, 7, 0.5), c(1, 7, 0.5));
  b.front(c(9, 2, 0.3), c(14, 2, 0.3), c(9, 7, 0.3));
  b.front(c(9, 7, 0.3), c(14, 2, 0.3), c(14, 7, 0.3));
  b.front(c(2, 9, 0.7), c(6, 13, 0.7), c(2, 13, 0.7));
  b.front(c(2, 9, 0.7), c(6, 9, 0.7), c(6, 13, 0.7));
  b.front(c(9, 9, 0.4), c(13, 9, 0.6), c(11, 14, 0.5));
  return b.v;
}

RasterVector make_z_fight() {
  VectorBuilder b{exact_vector("z_fight",
                               "coplanar overlapping triangles and two planes crossing: triangle ids there depend on "
                               "interpolated depth precision (the depth mask)")};
  // The plane z = 1/2 + x/8 + y/8: exact for grid x, y (multiples of 2^-13), so both
  // triangles lie on it exactly and every centre they share is within the depth tolerance.
  auto on_plane = [](double x, double y) {
    const Vec3 p = grid_point(x, y, 0);
    return Vec3{p.x, p.y, float(0.5 + p.x / 8.0 + p.y / 8.0)};
  };
  b.front(on_plane(-0.9, -0.9), on_plane(0.8, -0.8), on_plane(-0.8, 0.9));
  b.front(on_plane(-0.5, -0.95), on_plane(0.9, 0.9), on_plane(-0.95, 0.3));
  // A plane crossing the first one along a line.
  b.front(grid_point(-1, 0.5, 0.3), grid_point(1, 0.5, 0.9), grid_point(0, -1, 0.6));
  return b.v;
}

// View space → clip by the reference projection (not exact in float).
RasterVector perspective_vector(const char* name, const char* description, float z_near) {
  RasterVector v;
  v.name = name;
  v.description = description;
  v.width = v.height = kSide;
  v.z_near = z_near;
  v.object_to_clip = to_float(perspective_reversed_z(1.0, 1.0, z_near));
  return v;
}

RasterVector make_near_plane() {
  VectorBuilder b{perspective_vector("near_plane", "perspective; triangles crossing and touching the near plane", 0.25f)};
  SplitMix64 rng{kSeed + 4};
  b.front(grid_point(-2, -0.4, -0.05), grid_point(2, -0.5, -0.05), grid_point(0.1, -0.3, -8));
  b.front(grid_point(-0.3, 0.6, -3), grid_point(0.4, 0.4, -0.1), grid_point(0.2, 1.5, -2));
  for (int i = 0; i < 12; ++i) {
    Vec3 p[3];
    for (Vec3& q : p) q = grid_point(rng.uniform(-1, 1), rng.uniform(-1, 1), -rng.uniform(0.0, 1.5));
    b.triangle(p[0], p[1], p[2]);
  }
  return b.v;
}

RasterVector make_guard_band() {
  VectorBuilder b{exact_vector("guard_band", "vertices beyond the guard band (|x|, |y| > 64 w): the reference clips there")};
  b.front(grid_point(-200, -0.3, 0.5), grid_point(150, -0.2, 0.5), grid_point(0.2, 0.7, 0.5));
  b.front(grid_point(-0.6, -90, 0.4), grid_point(0.7, -0.9, 0.6), grid_point(-0.4, 130, 0.8));
  return b.v;
}

}  // namespace

RenderScene raster_vector_scene(const RasterVector& v) { return flat_cluster_scene(v.clusters, v.name); }

RenderScene flat_cluster_scene(const std::vector<RasterVectorCluster>& clusters, const std::string& where) {
  ClusterDag dag;
  for (const RasterVectorCluster& c : clusters) {
    DagCluster dc;
    dc.vertex_offset = uint32_t(dag.vertex_count());
    dc.vertex_count = uint32_t(c.positions.size() / 3);
    dc.triangle_offset = dc.material_offset = uint32_t(dag.triangle_count());
    dc.triangle_count = uint32_t(c.indices.size() / 3);
    dag.positions.insert(dag.positions.end(), c.positions.begin(), c.positions.end());
    dag.indices.insert(dag.indices.end(), c.indices.begin(), c.indices.end());
    dag.triangle_materials.insert(dag.triangle_materials.end(), dc.triangle_count, 0u);
    Aabb box;
    for (uint32_t i = 0; i < dc.vertex_count; ++i) box.extend(dag.position(dc.vertex_offset + i));
    dc.bounds.center = (box.min + box.max) * 0.5f;
    float r = 0;
    for (uint32_t i = 0; i < dc.vertex_count; ++i)
      r = std::max(r, float(distance_d(dc.bounds.center, dag.position(dc.vertex_offset + i))));
    dc.bounds.radius = r * 1.0001f + 1e-6f;
    dc.lod_bounds = dc.parent_bounds = dc.bounds;
    dc.parent_error = kTerminalError;
    dc.group = uint32_t(dag.groups.size());
    DagGroup g;
    g.first_cluster = uint32_t(dag.clusters.size());
    g.cluster_count = 1;
    g.flags = kGroupTerminal;
    g.bounds = g.parent_bounds = dc.bounds;
    g.parent_error = kTerminalError;
    dag.groups.push_back(g);
    dag.clusters.push_back(dc);
    dag.bounds.extend(box.min);
    dag.bounds.extend(box.max);
  }
  // A two-level BVH8: the root over leaf nodes of up to kBvhMaxChildren groups each.
  const uint32_t groups = uint32_t(dag.groups.size());
  if (groups > kBvhMaxChildren * kBvhMaxChildren)
    fail("RASTER_VECTOR_PARSE", where, "more than " + std::to_string(kBvhMaxChildren * kBvhMaxChildren) + " clusters",
         kExitUsage);
  if (groups) dag.bvh_nodes.emplace_back();
  BvhNode root;
  root.max_parent_error = kTerminalError;
  for (uint32_t first = 0; first < groups; first += kBvhMaxChildren) {
    BvhNode node;
    node.max_parent_error = kTerminalError;
    for (uint32_t g = first; g < std::min(groups, first + kBvhMaxChildren); ++g) {
      node.children[node.child_count] = g;
      node.group_mask |= 1u << node.child_count++;
      node.bounds = merge_spheres(node.bounds, dag.groups[g].bounds);
      node.lod_bounds = merge_spheres(node.lod_bounds, dag.groups[g].parent_bounds);
    }
    if (groups <= kBvhMaxChildren) {
      root = node;
      break;
    }
    root.children[root.child_count++] = uint32_t(dag.bvh_nodes.size());
    root.bounds = merge_spheres(root.bounds, node.bounds);
    root.lod_bounds = merge_spheres(root.lod_bounds, node.lod_bounds);
    dag.bvh_nodes.push_back(node);
  }
  if (groups) dag.bvh_nodes[0] = root;
  dag.level_count = 1;
  RenderScene scene;
  scene.meshes.push_back(std::move(dag));
  scene.materials.push_back(Material{"vector", {0.8f, 0.8f, 0.8f, 1.0f}});
  scene.instances.push_back(CullInstance{0, Mat4d{}});
  return scene;
}

void canonicalize_raster_vector(RasterVector* v) {
  const MemoryFormScene ms = make_memory_form_scene(raster_vector_scene(*v));
  const ClusterDag& dag = ms.scene.meshes[0];
  for (uint32_t c = 0; c < v->clusters.size(); ++c) {
    const DagCluster& dc = dag.clusters[c];
    RasterVectorCluster& out = v->clusters[c];
    out.positions.assign(dag.positions.begin() + 3 * dc.vertex_offset,
                         dag.positions.begin() + 3 * (dc.vertex_offset + dc.vertex_count));
    out.indices.assign(dag.indices.begin() + 3 * dc.triangle_offset,
                       dag.indices.begin() + 3 * (dc.triangle_offset + dc.triangle_count));
  }
}

ModelTriangle raster_vector_triangle(const RasterVector& v, uint32_t cluster, uint32_t triangle) {
  const RasterVectorCluster& c = v.clusters[cluster];
  Vec3 p[3];
  for (int k = 0; k < 3; ++k) {
    const uint32_t i = c.indices[3 * triangle + k];
    p[k] = {c.positions[3 * i], c.positions[3 * i + 1], c.positions[3 * i + 2]};
  }
  return model_triangle(p, v.object_to_clip, v.z_near, v.width, v.height);
}

void compute_raster_vector_expected(RasterVector* v) {
  VisBuffer vis;
  vis.resize(v->width, v->height);
  RasterOptions options;
  options.path = RasterPath::kReference;
  options.cull_backfaces = v->cull_backfaces;
  options.z_near = v->z_near;
  struct Drawn {
    uint32_t id_bits;  // visible cluster << kVisTriangleBits | triangle
    ModelTriangle model;
  };
  std::vector<Drawn> triangles;  // the ones the reference draws (front faces when culling)
  for (uint32_t c = 0; c < v->clusters.size(); ++c) {
    const RasterVectorCluster& cl = v->clusters[c];
    RasterStats stats;
    rasterize_cluster(vis, cl.positions.data(), uint32_t(cl.positions.size() / 3), cl.indices.data(),
                      uint32_t(cl.indices.size() / 3), v->object_to_clip, c, options, &stats);
    for (uint32_t t = 0; t < cl.indices.size() / 3; ++t) {
      ModelTriangle m = raster_vector_triangle(*v, c, t);
      const ModelPolygon& p = m.polygon;
      const double area = p.count >= 3 ? (p.x[1] - p.x[0]) * (p.y[2] - p.y[0]) - (p.x[2] - p.x[0]) * (p.y[1] - p.y[0]) : 0;
      if (p.count >= 3 && (!v->cull_backfaces || area < 0)) triangles.push_back({(c << kVisTriangleBits) | t, m});
    }
  }
  v->keys = vis.keys;
  v->mask.assign(v->keys.size(), 0);
  for (uint32_t y = 0; y < v->height; ++y)
    for (uint32_t x = 0; x < v->width; ++x) {
      const size_t p = size_t(y) * v->width + x;
      const double cx = x + 0.5, cy = y + 0.5;
      const uint64_t key = v->keys[p];
      ModelTriangle winner;
      if (key) winner = raster_vector_triangle(*v, vis_key_cluster(key), vis_key_triangle(key));
      for (const Drawn& d : triangles) {
        const ModelTriangle& t = d.model;
        const ModelCoverage cov = model_coverage(t.polygon, cx, cy, t.margin);
        if (cov == ModelCoverage::kAmbiguous) v->mask[p] |= t.clipped ? kRasterMaskClipEdge : kRasterMaskEdge;
        // Another surface over this centre within the two depth tolerances of the winner.
        if (key && d.id_bits != uint32_t(key) && cov != ModelCoverage::kOutside &&
            std::abs(model_depth_at(t, cx, cy) - model_depth_at(winner, cx, cy)) <=
                t.depth_tolerance + winner.depth_tolerance)
          v->mask[p] |= kRasterMaskDepth;
      }
    }
}

std::vector<RasterVector> make_raster_vectors() {
  std::vector<RasterVector> set = {make_random(),   make_slivers(),       make_fan(),    make_grid(),
                                   make_huge(),     make_subpixel(),      make_pixel_centres(),
                                   make_z_fight(),  make_near_plane(),    make_guard_band()};
  for (RasterVector& v : set) {
    canonicalize_raster_vector(&v);
    compute_raster_vector_expected(&v);
  }
  return set;
}

std::string write_raster_vector(const RasterVector& v) {
  std::string out = std::string(kMagic) + "\n";
  char line[512];
  out += "name " + v.name + "\n";
  out += "description " + v.description + "\n";
  std::snprintf(line, sizeof line, "viewport %u %u\nz_near %.9g\ncull_backfaces %d\nexact_transform %d\nobject_to_clip",
                v.width, v.height, double(v.z_near), v.cull_backfaces ? 1 : 0, v.exact_transform ? 1 : 0);
  out += line;
  for (float f : v.object_to_clip.m) {
    std::snprintf(line, sizeof line, " %.9g", double(f));
    out += line;
  }
  out += "\n";
  for (size_t c = 0; c < v.clusters.size(); ++c) {
    const RasterVectorCluster& cl = v.clusters[c];
    std::snprintf(line, sizeof line, "cluster %zu vertices %zu triangles %zu\n", c, cl.positions.size() / 3,
                  cl.indices.size() / 3);
    out += line;
    for (size_t i = 0; i < cl.positions.size(); i += 3) {
      std::snprintf(line, sizeof line, "v %.9g %.9g %.9g\n", double(cl.positions[i]), double(cl.positions[i + 1]),
                    double(cl.positions[i + 2]));
      out += line;
    }
    for (size_t i = 0; i < cl.indices.size(); i += 3) {
      std::snprintf(line, sizeof line, "t %u %u %u\n", cl.indices[i], cl.indices[i + 1], cl.indices[i + 2]);
      out += line;
    }
  }
  out += "keys\n";
  for (uint32_t y = 0; y < v.height; ++y) {
    for (uint32_t x = 0; x < v.width; ++x) {
      const uint64_t k = v.keys[size_t(y) * v.width + x];
      if (k) std::snprintf(line, sizeof line, "%s%016" PRIx64, x ? " " : "", k);
      else std::snprintf(line, sizeof line, "%s0", x ? " " : "");
      out += line;
    }
    out += "\n";
  }
  out += "mask\n";
  for (uint32_t y = 0; y < v.height; ++y) {
    for (uint32_t x = 0; x < v.width; ++x) out += char('0' + v.mask[size_t(y) * v.width + x]);
    out += "\n";
  }
  return out;
}

RasterVector parse_raster_vector(const std::string& text, const std::string& where) {
  auto bad = [&](const std::string& what) -> void { fail("RASTER_VECTOR_PARSE", where, what, kExitUsage); };
  std::istringstream in(text);
  std::string line, word;
  if (!std::getline(in, line) || line != kMagic) bad("not a raster vector (first line must be '" + std::string(kMagic) + "')");
  RasterVector v;
  std::vector<uint32_t> vertex_count, triangle_count;
  auto read_field = [&](const char* name) {
    if (!std::getline(in, line) || line.rfind(std::string(name) + " ", 0) != 0) bad(std::string("expected '") + name + "'");
    return line.substr(std::strlen(name) + 1);
  };
  v.name = read_field("name");
  v.description = read_field("description");
  {
    std::istringstream f(read_field("viewport"));
    if (!(f >> v.width >> v.height) || v.width == 0 || v.height == 0 || v.width > kMaxRasterViewport ||
        v.height > kMaxRasterViewport)
      bad("bad viewport");
  }
  v.z_near = std::strtof(read_field("z_near").c_str(), nullptr);
  if (!(v.z_near > 0) || !std::isfinite(v.z_near)) bad("z_near must be positive and finite");
  v.cull_backfaces = read_field("cull_backfaces") == "1";
  v.exact_transform = read_field("exact_transform") == "1";
  {
    std::istringstream f(read_field("object_to_clip"));
    for (float& m : v.object_to_clip.m)
      if (!(f >> m)) bad("object_to_clip needs 16 numbers");
  }
  while (std::getline(in, line) && line.rfind("cluster ", 0) == 0) {
    std::istringstream f(line);
    std::string c, vw, tw;
    size_t index = 0, nv = 0, nt = 0;
    if (!(f >> c >> index >> vw >> nv >> tw >> nt) || index != v.clusters.size() || nv == 0 || nv > kMaxClusterVertices ||
        nt == 0 || nt > kMaxClusterTriangles || v.clusters.size() >= kBvhMaxChildren)
      bad("bad cluster line '" + line + "'");
    RasterVectorCluster cl;
    for (size_t i = 0; i < nv; ++i) {
      float x, y, z;
      if (!std::getline(in, line) || std::sscanf(line.c_str(), "v %f %f %f", &x, &y, &z) != 3) bad("bad vertex line");
      cl.positions.insert(cl.positions.end(), {x, y, z});
    }
    for (size_t i = 0; i < nt; ++i) {
      unsigned a, b, cc;
      if (!std::getline(in, line) || std::sscanf(line.c_str(), "t %u %u %u", &a, &b, &cc) != 3 || a >= nv || b >= nv ||
          cc >= nv)
        bad("bad triangle line");
      cl.indices.insert(cl.indices.end(), {uint8_t(a), uint8_t(b), uint8_t(cc)});
    }
    v.clusters.push_back(std::move(cl));
  }
  if (line != "keys") bad("expected 'keys'");
  v.keys.assign(size_t(v.width) * v.height, 0);
  for (uint32_t y = 0; y < v.height; ++y) {
    if (!std::getline(in, line)) bad("truncated keys");
    std::istringstream f(line);
    for (uint32_t x = 0; x < v.width; ++x) {
      if (!(f >> word)) bad("key row " + std::to_string(y) + " too short");
      v.keys[size_t(y) * v.width + x] = std::strtoull(word.c_str(), nullptr, 16);
    }
  }
  if (!std::getline(in, line) || line != "mask") bad("expected 'mask'");
  v.mask.assign(size_t(v.width) * v.height, 0);
  for (uint32_t y = 0; y < v.height; ++y) {
    if (!std::getline(in, line) || line.size() != v.width) bad("bad mask row " + std::to_string(y));
    for (uint32_t x = 0; x < v.width; ++x) {
      if (line[x] < '0' || line[x] > '7') bad("bad mask digit");
      v.mask[size_t(y) * v.width + x] = uint8_t(line[x] - '0');
    }
  }
  return v;
}

}  // namespace vgeo
