#pragma once
// The GLB container's constants (glTF 2.0 specification §4.4 "Binary glTF Layout"), shared by
// the GLB reader (import_gltf.cpp) and writer (export.cpp). All fields are little-endian u32.
#include <cstddef>
#include <cstdint>

namespace vgeo {

inline constexpr uint32_t kGlbMagic = 0x46546C67;      // "glTF"
inline constexpr uint32_t kGlbVersion = 2;             // the only GLB container version
inline constexpr uint32_t kGlbChunkJson = 0x4E4F534A;  // "JSON"
inline constexpr uint32_t kGlbChunkBin = 0x004E4942;   // "BIN\0"
inline constexpr size_t kGlbHeaderBytes = 12;          // magic, version, length
inline constexpr size_t kGlbChunkHeaderBytes = 8;      // chunkLength, chunkType
// glTF 2.0 §5.24 mesh.primitive.mode: TRIANGLES (the reader also takes strips and fans).
inline constexpr int kGltfModeTriangles = 4;

}  // namespace vgeo
