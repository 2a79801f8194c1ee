#pragma once
// Validation and clean-up shared by every import format. Each check names the error code it
// raises (spec/errors.md, "Import"); clean-ups return what they removed so imports can count it.
#include <cstddef>
#include <cstdint>
#include <string>

#include "vgeo/core/error.h"
#include "vgeo/core/thread_pool.h"
#include "vgeo/mesh/mesh.h"

namespace vgeo {

// Allocation bound for untrusted input: an importer may produce at most this many output
// bytes per input byte (file + external buffers). The worst legitimate expansion is a
// uint8 triangle-strip index (1 byte -> 12 bytes of uint32 triangle indices) plus an attribute
// of normalized bytes (1 byte -> 4 bytes of float); 64 leaves room for sparse overrides and
// filled attributes while stopping decompression-bomb style files (accessors referenced by
// thousands of primitives, bufferView-less accessors with huge counts).
inline constexpr uint64_t kMaxOutputBytesPerInputByte = 64;
// Floor for the bound so tiny hand-written files with zero-filled accessors still import.
inline constexpr uint64_t kMinOutputBudgetBytes = uint64_t(1) << 20;

// Tracks the output bytes an import is still allowed to allocate. Fails with
// INPUT_EXPANSION_LIMIT when a charge exceeds what is left.
struct OutputBudget {
  uint64_t remaining = 0;
  std::string where;
  static OutputBudget for_input(uint64_t input_bytes, std::string where);
  // Charges count * bytes_each without overflow (counts come straight from the file).
  void charge(uint64_t count, uint64_t bytes_each, const char* what);
};

// The checks themselves, shared by the importers (codes below) and build_dag (BUILD_* codes,
// spec/dag.md §6): each returns what is wrong, so each caller raises its own stable code.
// Empty when every array has the length the mesh's counts imply, else which one does not.
std::string mesh_array_size_defect(const Mesh& mesh);
// Index of the first non-finite value, or values.size() when all are finite. With a `pool` of
// more than one thread a long array is scanned by parts on it (the same index).
size_t first_non_finite(const std::vector<float>& values, ThreadPool* pool = nullptr);
// Corner of the first index >= vertex_count(), or indices.size() when all are in range (`pool`
// as above).
size_t first_index_out_of_range(const Mesh& mesh, ThreadPool* pool = nullptr);

// POSITION_NOT_FINITE for the first non-finite position coordinate; ATTRIBUTE_NOT_FINITE for
// a non-finite normal or uv. Also asserts (fails INTERNAL_SIZE_MISMATCH) array-size contracts.
void check_mesh_attributes(const Mesh& mesh, const std::string& where, ThreadPool* pool = nullptr);

// INDEX_OUT_OF_RANGE for the first index >= vertex_count().
void check_mesh_indices(const Mesh& mesh, const std::string& where, ThreadPool* pool = nullptr);

// True when the triangle's edge cross product, computed in double from the float positions,
// is exactly zero (collinear or coincident corners).
bool triangle_has_zero_area(const Mesh& mesh, uint32_t a, uint32_t b, uint32_t c);

// Triangles per task of remove_degenerate_triangles' test on a pool (~0.3 ms of work each); a
// mesh of at most one task is tested in order.
inline constexpr size_t kDegenerateTestTriangles = size_t(1) << 16;
// Removes triangles with a repeated index or exactly zero area (and their per-triangle
// material entries), keeping the order of the rest. Returns how many were removed. With a
// `pool` of more than one thread the triangles are tested on it (the same result).
size_t remove_degenerate_triangles(Mesh& mesh, ThreadPool* pool = nullptr);

}  // namespace vgeo
