// The checks every importer shares (lib/vgeo/mesh/validate.h), called directly at their
// boundaries: what an importer's own parser lets through must still be rejected here.
#include <gtest/gtest.h>

#include <string>

#include "vgeo/core/error.h"
#include "vgeo/mesh/validate.h"

namespace vgeo {
namespace {

std::string index_check_code(const Mesh& m) {
  try {
    check_mesh_indices(m, "<test>");
  } catch (const VgeoError& e) {
    return e.error().code;
  }
  return "";
}

// Indices must be < vertex_count: the last vertex is fine, one past it is not.
TEST(Validate, IndexEqualToVertexCountIsOutOfRange) {
  Mesh m;
  m.positions = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  m.indices = {0, 1, 2};
  EXPECT_EQ(index_check_code(m), "");
  m.indices = {0, 1, 3};
  EXPECT_EQ(index_check_code(m), "INDEX_OUT_OF_RANGE");
}

}  // namespace
}  // namespace vgeo
