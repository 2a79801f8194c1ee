#pragma once
// Render scenes: the JSON scene file (normative: spec/scene.md) and the embedded default
// scene. Loading builds every mesh's DAG on demand (build_dag), cached by content hash.
#include <cstdint>
#include <string>
#include <vector>

#include "vgeo/build/build.h"
#include "vgeo/cull/view.h"
#include "vgeo/render/frame.h"

namespace vgeo {

inline constexpr int kSceneFileVersion = 1;

struct SceneFile {
  RenderScene scene;
  std::vector<Camera> cameras;  // at least one
  std::vector<Camera> path;     // expanded camera path (empty when the file has none)
  RenderSettings settings;
};

struct SceneLoadOptions {
  std::string cache_dir;         // empty: no DAG cache (always build)
  BuildOptions build;            // used for meshes built on demand
};

// Throws VgeoError with a SCENE_* code (exit 3; SCENE_READ_FAILED exit 4) on any malformed
// input; never allocates more than a bound derived from the input (procedural meshes are
// capped by kMaxProceduralTriangles, camera paths by kMaxPathFrames).
SceneFile load_scene_file(const std::string& path, const SceneLoadOptions& options);
SceneFile parse_scene_json(const std::string& text, const std::string& where, const std::string& base_dir,
                           const SceneLoadOptions& options);

inline constexpr uint32_t kMaxPathFrames = 100000;  // a long flythrough at 60 fps is ~30 min
inline constexpr uint32_t kMaxResolution = 16384;   // per axis: 2 GB of 64-bit keys at most

// The embedded default scene (procedural, no files): a displaced sphere, a ground grid and
// several instances, one camera at width x height and an orbiting camera path of `frames`.
SceneFile make_default_scene(uint32_t width, uint32_t height, uint32_t frames, const SceneLoadOptions& options);

// Content hash of a mesh + builder identity: the cache key of its DAG.
uint64_t mesh_content_hash(const Mesh& mesh, const BuildOptions& options);

}  // namespace vgeo
