#pragma once
// The mesh model every stage consumes: flat arrays, caller-owned, GPU-uploadable.
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "vgeo/core/error.h"
#include "vgeo/core/math.h"

namespace vgeo {

// Indexed triangle mesh. Attribute arrays are either empty or sized per vertex.
struct Mesh {
  std::string name;
  std::vector<float> positions;     // 3 per vertex (object space)
  std::vector<float> normals;       // 3 per vertex, or empty
  std::vector<float> uvs;           // 2 per vertex (UV0), or empty
  std::vector<uint32_t> indices;    // 3 per triangle, counter-clockwise front faces
  std::vector<uint32_t> materials;  // 1 per triangle (index into Scene::materials), or empty = 0

  size_t vertex_count() const { return positions.size() / 3; }
  size_t triangle_count() const { return indices.size() / 3; }
  Vec3 position(size_t v) const { return {positions[3 * v], positions[3 * v + 1], positions[3 * v + 2]}; }
  uint32_t material(size_t t) const { return materials.empty() ? 0u : materials[t]; }
};

struct Material {
  std::string name;
  std::array<float, 4> base_color{0.8f, 0.8f, 0.8f, 1.0f};  // linear RGBA
};

// One placed copy of a mesh. Mesh reuse across instances is instancing.
struct Instance {
  uint32_t mesh = 0;
  // Column-major 4x4 object->world matrix (glTF convention). Affine only.
  std::array<float, 16> transform{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
};

struct Scene {
  std::vector<Mesh> meshes;
  std::vector<Material> materials;  // at least one (a default) after import
  std::vector<Instance> instances;  // glTF node hierarchy flattened to world transforms
};

struct MeshStats {
  size_t vertices = 0, triangles = 0;
  Aabb bounds;
};
MeshStats mesh_stats(const Mesh& mesh);

}  // namespace vgeo
