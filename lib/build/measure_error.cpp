// A simplification's own error, measured (spec/dag.md §Error).
#include <cmath>
#include <limits>

#include "vgeo/build/build_internal.h"
#include "vgeo/core/surface_distance.h"

namespace vgeo::build_detail {

float measured_simplification_error(const Mesh& mesh, const TriangleSet& input, const TriangleSet& simplified) {
  std::vector<DVec3> corners(input.corners.size());
  for (size_t i = 0; i < corners.size(); ++i) {
    const float* p = &mesh.positions[3 * size_t(input.corners[i])];
    corners[i] = {p[0], p[1], p[2]};
  }
  TriangleDistanceTree tree(std::move(corners));
  double d = sampled_one_sided_distance(mesh.positions.data(), simplified.corners.data(),
                                        simplified.triangle_count(), tree, kErrorLatticeSubdivisions);
  float e = float(d);
  if (double(e) < d) e = std::nextafter(e, std::numeric_limits<float>::infinity());
  return e;
}

}  // namespace vgeo::build_detail
