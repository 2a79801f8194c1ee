#pragma once
// Mesh writers: GLB (glTF 2.0 binary), OBJ, PLY (binary little endian) and OFF.
//
// Contract:
//  - byte-identical output for identical input (no timestamps, locale-independent
//    shortest round-trip float text via std::to_chars, JSON keys in sorted order);
//  - files are written atomically (write_file_atomic, lib/vgeo/core/file_io.h: temporary
//    file, fsync, rename, directory fsync), so an existing file is never left half-written;
//  - triangles are grouped by material (stable: original order within a material) in
//    GLB (one primitive per used material, ascending) and OBJ (one `usemtl` run each);
//    PLY and OFF keep the original triangle order.
//  - invalid meshes are rejected with a stable code before anything is written:
//    EXPORT_ATTRIBUTE_SIZE, EXPORT_INDEX_OUT_OF_RANGE, EXPORT_MATERIAL_OUT_OF_RANGE,
//    EXPORT_NON_FINITE (positions), EXPORT_EMPTY_MESH, EXPORT_TOO_LARGE (GLB > 4 GiB),
//    EXPORT_BAD_INSTANCE (mesh index); I/O failures are IO_WRITE_FAILED (kExitIo);
//    an unknown extension is EXPORT_UNKNOWN_FORMAT (kExitUsage).
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "vgeo/core/file_io.h"
#include "vgeo/mesh/mesh.h"

namespace vgeo {

enum class MeshFormat : uint8_t { kGlb, kObj, kPly, kOff };

// By extension, case-insensitive: .glb .obj .ply .off.
std::optional<MeshFormat> mesh_format_from_path(std::string_view path);
std::string_view mesh_format_name(MeshFormat format);  // "glb", "obj", "ply", "off"

// GLB layout: one buffer; per mesh four bufferViews (POSITION, NORMAL if present,
// TEXCOORD_0 if present, indices as uint32) and one primitive (mode 4) per used material;
// one node per instance (column-major `matrix`, omitted when identity) in scene 0;
// materials as pbrMetallicRoughness baseColorFactor with metallicFactor 0.
// An empty scene.materials gets one default material. Little-endian hosts only.
std::vector<uint8_t> encode_glb(const Scene& scene);
void write_glb(const Scene& scene, const std::string& path);

// Single-mesh text/binary formats. OBJ writes v/vt/vn and `usemtl <name>` per material
// run (names from `materials`, or "material<i>"); no .mtl file is written.
// PLY writes float x y z [nx ny nz] [s t], faces as `list uchar uint vertex_indices` and,
// when the mesh has materials, a `uint material_index` face property.
void write_obj(const Mesh& mesh, const std::string& path, const std::vector<Material>& materials = {});
void write_ply(const Mesh& mesh, const std::string& path);
void write_off(const Mesh& mesh, const std::string& path);

// All instances of a scene baked into one world-space mesh (positions by the instance
// matrix, normals by its inverse transpose then renormalised; attributes present in every
// mesh are kept, others dropped). Triangles with negative-determinant transforms are
// flipped so counter-clockwise stays front.
Mesh bake_scene(const Scene& scene);

// Writes `scene` in the format of `path`'s extension (GLB keeps the scene; the other
// formats get bake_scene(scene)).
void write_scene_file(const Scene& scene, const std::string& path);

}  // namespace vgeo
