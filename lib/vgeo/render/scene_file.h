#pragma once
// Render scenes: the JSON scene file (normative: spec/scene.md) and the embedded default
// scene. Loading builds every mesh's DAG on demand (build_dag), cached by content hash, and
// draws it in its decoded memory form (memory_form_options); page-file meshes are drawn as
// stored. The encoding each mesh is decoded from is kept (SceneFile::encodings).
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "vgeo/dag/build.h"
#include "vgeo/cull/view.h"
#include "vgeo/format/format.h"
#include "vgeo/render/frame.h"
#include "vgeo/render/scene_lights.h"
#include "vgeo/stream/stream.h"

namespace vgeo {

inline constexpr int kSceneFileVersion = 1;

// A page file a scene streams from: its header + metadata, read once at load.
struct ScenePageFile {
  std::string path;          // canonical
  FormatContainer metadata;  // read_container_metadata(path)
};

// A scene mesh read from a page-format file and streamed (its scene DAG is the file's
// metadata DAG, without vertex arrays).
struct ScenePageMesh {
  uint32_t file = kNone;         // index into SceneFile::page_files; kNone: fully in memory
  uint32_t index = 0;            // mesh index in the file
  uint32_t material_offset = 0;  // the file's materials start here in the scene's
  uint64_t page_bytes = 0;       // memory-form bytes of the mesh's pages
};

// One page-format encoding the scene's meshes are drawn from (spec/raster.md §Geometry): a page
// file's bytes as read, or the one encoding of meshes built at load (encode_memory_form). Both
// backends draw from it: the CPU reference its decode (SceneFile::scene), the GPU its pages
// transcoded to the memory form (lib/vgeo/gpu memory_form_pages); nothing is encoded again.
struct SceneEncoding {
  std::string where;           // the page file, or the built mesh's place in the scene
  std::vector<uint8_t> bytes;  // the whole page-format file
  FormatContainer container;   // parse_container(bytes)
};

// Where a scene mesh's memory form is: mesh `mesh` of encodings[encoding]. Its decoded
// triangle materials are the stored ids + material_offset (a page file's materials are
// appended to the scene's; a built mesh stores the scene's ids: offset 0).
struct SceneMeshForm {
  uint32_t encoding = kNone;  // kNone: a streamed mesh (its pages are the Streamer's)
  uint32_t mesh = 0;
  uint32_t material_offset = 0;
};

struct SceneFile {
  RenderScene scene;
  // The memory form of every mesh, each encoded at most once (spec/raster.md §Geometry):
  // scene.meshes[m] (unless streamed) is the decode of mesh_forms[m]'s encoding.
  std::vector<SceneEncoding> encodings;
  std::vector<SceneMeshForm> mesh_forms;  // per scene mesh
  std::vector<Camera> cameras;  // at least one
  std::vector<Camera> path;     // expanded camera path (empty when the file has none)
  std::vector<SceneMove> moves; // lights and instances changed at given frames (run_frames applies them)
  RenderSettings settings;
  // Streaming (spec/stream.md §Renderer), decided once, at load, from SceneLoadOptions::stream:
  std::optional<StreamOptions> stream;     // as requested (budget_bytes > 0); nullopt: no budget
  bool streaming = false;                  // page_bytes > budget: page-file meshes stay metadata-only
  std::string stream_reason = "no stream budget";  // why streaming is on or off (one line)
  std::vector<ScenePageFile> page_files;   // when streaming: the streamed files, each read once
  std::vector<ScenePageMesh> page_meshes;  // when a budget is given: per scene mesh
  uint64_t page_bytes = 0;   // memory-form page bytes of the distinct page-file meshes used
  std::string stream_note() const;  // "streaming: on (<reason>)" / "streaming: off (<reason>)"
};

struct SceneLoadOptions {
  std::string cache_dir;         // empty: no DAG cache (always build)
  BuildOptions build;            // used for meshes built on demand
  // Streaming, the one place its options are given (the budget decides it; threshold_px is
  // the render's τ): meshes from page-format files are first read as metadata only; if their
  // pages' memory bytes exceed stream->budget_bytes they stay so (SceneFile::streaming),
  // otherwise they are decoded as without a budget (streaming off, identical output).
  std::optional<StreamOptions> stream;
};

// Throws VgeoError with a SCENE_* code (exit 3) on any malformed input, or a FILE_* code of
// read_text_file (lib/vgeo/core/file_io.h: missing/unreadable exit 4, over 64 MB exit 3); never allocates more than a bound derived from the input (procedural meshes are
// capped by kMaxProceduralTriangles, camera paths by kMaxPathFrames).
SceneFile load_scene_file(const std::string& path, const SceneLoadOptions& options);
SceneFile parse_scene_json(const std::string& text, const std::string& where, const std::string& base_dir,
                           const SceneLoadOptions& options);

// Upper bound on a scene's generated mesh (`procedural.triangles`, memory bound for untrusted
// input): 4M triangles ≈ 150 MB of DAG, far above any default scene.
inline constexpr uint64_t kMaxProceduralTriangles = 1u << 22;
// `procedural.triangles` when absent: a mesh with a few LOD levels that builds in well under a second.
inline constexpr uint64_t kDefaultProceduralTriangles = 20000;
inline constexpr uint32_t kMaxPathFrames = 100000;  // a long flythrough at 60 fps is ~30 min
inline constexpr uint32_t kMaxResolution = 16384;   // per axis: 2 GB of 64-bit keys at most

// A camera path file: the scene's `camera_path` object on its own ({"frames", "keyframes"}),
// expanded with `base`'s fov/resolution/near. Throws the SCENE_* codes of the scene file.
std::vector<Camera> load_camera_path_file(const std::string& path, const Camera& base);

// The embedded default scene (generated by lib/vgeo/mesh/generate.h, no files): a displaced sphere,
// a terrain ground and several instances, one camera at width x height and an orbiting camera path of `frames`.
SceneFile make_default_scene(uint32_t width, uint32_t height, uint32_t frames, const SceneLoadOptions& options);

// The page-format options of the memory form a built mesh is drawn from (spec/raster.md
// §Geometry): meshes built on demand, the default scene's and VGEODAG1 files' are encoded with
// these and decoded at load, so the CPU reference draws the quantized geometry a GPU reads
// from pages (page-file meshes are drawn as stored). `vgeo build`'s defaults, less compression.
FormatOptions memory_form_options();

// Built (float) DAGs in their memory form: `built` encoded once with memory_form_options();
// `decoded` (optional) receives the decode of those same bytes. Throws FORMAT_ENCODE (format.h)
// for meshes the page format cannot represent.
SceneEncoding encode_memory_form(const BuiltScene& built, const std::string& where, BuiltScene* decoded);

// Content hash of a mesh + builder identity: the cache key of its DAG.
uint64_t mesh_content_hash(const Mesh& mesh, const BuildOptions& options);

}  // namespace vgeo
