// The builder's error measurement (lib/vgeo/dag/measure_error.cpp) takes shortcuts in *how* it
// finds the maximum; these properties pin that its value is bit-identical to the reference
// sampled_one_sided_distance of lib/vgeo/core on the same lattice (what lib/vgeo/verify checks).
#include <gtest/gtest.h>
#include <rapidcheck/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>

#include "vgeo/dag/build_internal.h"
#include "vgeo/core/surface_distance.h"

namespace vgeo::test {
namespace {

using build_detail::TriangleSet;

float reference_error(const Mesh& mesh, const TriangleSet& input, const TriangleSet& simplified) {
  std::vector<float> corners;
  for (uint32_t v : input.corners) corners.insert(corners.end(), &mesh.positions[3 * size_t(v)], &mesh.positions[3 * size_t(v)] + 3);
  TriangleDistanceTree tree(std::move(corners));
  double d = sampled_one_sided_distance(mesh.positions.data(), simplified.corners.data(),
                                        simplified.triangle_count(), tree, kErrorLatticeSubdivisions);
  float e = float(d);
  if (double(e) < d) e = std::nextafter(e, std::numeric_limits<float>::infinity());
  return e;
}

uint32_t bits(float f) {
  uint32_t b;
  std::memcpy(&b, &f, 4);
  return b;
}

// Positions on a coarse grid (coincident and collinear points common), triangles over them.
RC_GTEST_PROP(MeasureError, BitIdenticalToReferenceLattice, ()) {
  const uint32_t vertex_count = *rc::gen::inRange<uint32_t>(3, 40);
  Mesh mesh;
  for (uint32_t v = 0; v < 3 * vertex_count; ++v) mesh.positions.push_back(float(*rc::gen::inRange(-4, 5)) * 0.25f);
  auto triangles = [&](uint32_t min_count) {
    TriangleSet t;
    const uint32_t count = *rc::gen::inRange<uint32_t>(min_count, 60);
    for (uint32_t i = 0; i < count; ++i) {
      for (int k = 0; k < 3; ++k) t.corners.push_back(*rc::gen::inRange<uint32_t>(0, vertex_count));
      t.materials.push_back(0);
    }
    return t;
  };
  TriangleSet input = triangles(1);
  // Simplified corners are input vertices (both backends only remove vertices); the
  // triangles themselves are arbitrary.
  TriangleSet simplified;
  const uint32_t count = *rc::gen::inRange<uint32_t>(1, 40);
  for (uint32_t i = 0; i < count; ++i) {
    for (int k = 0; k < 3; ++k)
      simplified.corners.push_back(input.corners[*rc::gen::inRange<size_t>(0, input.corners.size())]);
    simplified.materials.push_back(0);
  }
  const float reference = reference_error(mesh, input, simplified);
  RC_ASSERT(bits(build_detail::measured_simplification_error(mesh, input, simplified)) == bits(reference));
  const float estimate = *rc::gen::element(0.0f, 0.01f, 0.1f, 0.3f, 1.0f, 10.0f, reference,
                                           std::nextafter(reference, 0.0f));
  RC_ASSERT(bits(build_detail::simplification_error(mesh, input, simplified, estimate)) ==
            bits(std::max(estimate, reference)));
}

// Many tiny input triangles and a few that span the whole group: the search's grid would need
// far more than 16 entries per triangle, so it is not built and uncovered points take the
// exact scan. The value must still be the reference's, bit for bit.
TEST(MeasureError, HugeAmongTinyTrianglesStillBitIdentical) {
  Mesh mesh;
  TriangleSet input, simplified;
  auto vertex = [&](float x, float y, float z) {
    mesh.positions.insert(mesh.positions.end(), {x, y, z});
    return uint32_t(mesh.vertex_count() - 1);
  };
  for (int i = 0; i < 40; ++i)
    for (int j = 0; j < 40; ++j) {  // 1600 tiny triangles on a wavy sheet
      const float x = float(i), y = float(j), z = 0.3f * float((i * 7 + j * 3) % 5);
      input.corners.insert(input.corners.end(), {vertex(x, y, z), vertex(x + 0.01f, y, z), vertex(x, y + 0.01f, z)});
      input.materials.push_back(0);
    }
  for (int k = 0; k < 60; ++k) {  // 60 huge ones across the sheet, at several heights
    const float z = 0.05f * float(k % 11);
    input.corners.insert(input.corners.end(), {vertex(-1, -1, z), vertex(45, -1, z + 0.5f), vertex(-1, 45, z + 1.0f)});
    input.materials.push_back(0);
  }
  // Simplified triangles over input vertices, far apart (interior points off the surface).
  const size_t tiny_vertices = 3 * 1600;
  for (uint32_t t = 0; t < 200; ++t) {
    const uint32_t a = (t * 97) % tiny_vertices, b = (t * 389 + 11) % tiny_vertices, c = (t * 1013 + 5) % tiny_vertices;
    simplified.corners.insert(simplified.corners.end(), {a, b, c});
    simplified.materials.push_back(0);
  }
  const float reference = reference_error(mesh, input, simplified);
  EXPECT_GT(reference, 0.0f);
  EXPECT_EQ(bits(build_detail::measured_simplification_error(mesh, input, simplified)), bits(reference));
  for (float estimate : {0.0f, reference * 0.5f, reference, reference * 2.0f})
    EXPECT_EQ(bits(build_detail::simplification_error(mesh, input, simplified, estimate)),
              bits(std::max(estimate, reference)));
}

}  // namespace
}  // namespace vgeo::test
