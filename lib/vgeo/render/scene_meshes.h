#pragma once
// Mesh loading of render scenes (scene_meshes.cpp), called by the scene reader (scene_file.cpp).
// Internal to lib/vgeo/render; not a public API.
#include <string>

#include "vgeo/mesh/mesh.h"
#include "vgeo/render/scene_file.h"
#include "vgeo/render/scene_json.h"

namespace vgeo::scene_detail {

// The scene's `meshes` list (spec/scene.md §meshes), appended to out->scene.meshes with their
// memory forms (out->encodings, out->mesh_forms); with a stream budget, also the decision whether
// the scene streams (spec/stream.md §Renderer). Materials a mesh file brings are appended to
// out->scene.materials.
void load_scene_meshes(const Ctx& c, const json& doc, SceneFile* out);

// A mesh built on demand (its DAG from the cache, else build_dag) appended to the scene in its
// memory form, storing the scene's material ids.
void add_built_scene_mesh(const Ctx& c, const Mesh& mesh, const std::string& path, SceneFile* out);

}  // namespace vgeo::scene_detail
