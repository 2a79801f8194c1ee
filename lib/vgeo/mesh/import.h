#pragma once
// Mesh import with strict validation: glTF 2.0 (.gltf/.glb) via tinygltf, OBJ/PLY/OFF/STL by
// readers of our own (import_obj/ply/off/stl.cpp; OpenMesh's crash and hang on mutated files). Every rejection is a VgeoError with a stable code from spec/errors.md
// ("Import" section); warnings never stop an import and are returned with the scene.
//
// What the importer guarantees about a returned Scene (the contract later stages rely on):
//   - at least one mesh, every mesh has >= 1 triangle, every index < vertex_count();
//   - every position is finite; normals/uvs are either empty or sized per vertex and finite;
//   - no triangle repeats an index or has exactly zero area (both removed and counted);
//   - materials has >= 1 entry and every per-triangle material index is in range;
//   - every instance references an existing mesh; transforms are finite and affine.
//
// glTF specifics (documented behaviour, not errors):
//   - only the default scene (`scene`, else scene 0, else every parentless node) is imported;
//     meshes no node of it references are not imported. Scene::meshes keeps glTF mesh order.
//   - each node with a mesh becomes one Instance with world = parent * local (matrix or TRS).
//   - all triangle primitives (modes 4, 5, 6) of a glTF mesh become one vgeo Mesh with one
//     material index per triangle; points/lines primitives are skipped (warning
//     PRIMITIVE_MODE_SKIPPED). A mesh left without triangles is dropped (warning MESH_EMPTY)
//     with its instances; a file left without any triangle fails with MESH_EMPTY.
//   - attribute presence differing between primitives of one mesh: a primitive without NORMAL
//     gets area-weighted vertex normals of its own triangles ((0,0,1) where that sum is
//     zero); a primitive without TEXCOORD_0 gets uv (0,0). Warning ATTRIBUTE_FILLED.
//   - glTF materials map 1:1 to Scene::materials (name, baseColorFactor); primitives without
//     a material use one default material appended after them.
//
// OBJ/PLY/OFF/STL specifics: one mesh, one identity instance, one default material.
//   - polygons become fans (v0, vi, vi+1) in file order; a polygon repeating a vertex is
//     dropped whole (FACE_REPEATED_VERTEX, counted as degenerate). Triangles are those the
//     OpenMesh readers used before produced (tests/mesh/import_corpus_test.cpp checks data/).
//   - OBJ: one vertex per distinct (v, vt, vn) corner (seams kept; unused v lines dropped);
//     uvs/normals exist when a face uses vt/vn; corners lacking them are filled
//     (ATTRIBUTE_FILLED). PLY/OFF: vertices as in the file. STL: corners merged by exact
//     position; no normals.
//   - ASCII OFF: '#' comments anywhere; ST/C/N prefixes; nOFF, 4OFF and binary OFF refused
//     (MESH_FORMAT_UNSUPPORTED). PLY: ascii and binary of either byte order.
//   - every count read from a file is checked against the bytes left before storage is
//     reserved for it, so memory is bounded by a small multiple of the file size.
//   - a "zero-area" triangle is one whose edge cross product, computed in double from the
//     float positions, is exactly (0,0,0).
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "vgeo/core/error.h"
#include "vgeo/mesh/mesh.h"

namespace vgeo {

struct ImportOptions {
  // Merge vertices whose position, normal and uv are exactly equal (value comparison, so
  // -0 == +0). Also drops vertices no triangle references.
  bool weld = false;
  // Threads of the file read and the OFF reader (0 = all cores): the same scene for any count
  // (read_file_bytes, import_off.cpp).
  unsigned threads = 1;
};

struct ImportStats {
  size_t degenerate_removed = 0;  // triangles with a repeated index or exactly zero area
  size_t duplicates_welded = 0;   // vertices removed by the weld (including unreferenced)
  size_t primitives_skipped = 0;  // glTF points/lines primitives
};

struct ImportResult {
  Scene scene;
  std::vector<Warning> warnings;
  ImportStats stats;
};

// Reads the file at `path`; the format is chosen by extension (case-insensitive):
// .gltf .glb .obj .ply .off .stl. Throws VgeoError (codes in spec/errors.md).
ImportResult import_scene(const std::string& path, const ImportOptions& options = {});

// Imports file bytes (format from the extension of `name_for_format_detection`, as
// import_scene). No file system access: a glTF that references an external buffer fails with
// EXTERNAL_BUFFER_MISSING.
ImportResult import_scene_from_memory(const uint8_t* data, size_t size,
                                      const std::string& name_for_format_detection,
                                      const ImportOptions& options = {});

namespace detail {
// glTF reader (import_gltf.cpp; OBJ/PLY/OFF/STL readers: import_text.h). They fill `out.scene` with raw
// triangles and warnings; import_scene() then runs the shared clean-up (validate.h, weld.h).
// `allow_fs` false = memory mode. When `owned_bytes` is the vector holding `data`, it is freed
// as soon as tinygltf has copied the buffers (keeps peak memory near 2x the GLB size).
void import_gltf(const uint8_t* data, size_t size, std::vector<uint8_t>* owned_bytes, bool is_glb,
                 const std::string& where, const std::string& base_dir, bool allow_fs, ImportResult& out);
}  // namespace detail

}  // namespace vgeo
