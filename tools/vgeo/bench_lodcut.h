#pragma once
// The LOD cut as the runtime makes it (the lod_selects cut: select_resident_cut with every
// group usable), counted over all clusters of a DAG for one camera: what a frame would draw
// at threshold tau, without culling.
#include <cstdint>

#include "vgeo/dag/cluster_dag.h"
#include "vgeo/core/lod.h"
#include "vgeo/stream/stream.h"

namespace vgeo::bench {

struct CutCount {
  uint64_t clusters = 0, triangles = 0;
  uint32_t max_level = 0;
};

inline CutCount count_cut(const ClusterDag& dag, const LodView& view, float tau) {
  CutCount c;
  for (uint32_t ci : select_resident_cut(dag, {}, view, tau)) {
    const DagCluster& cl = dag.clusters[ci];
    ++c.clusters;
    c.triangles += cl.triangle_count;
    if (cl.level > c.max_level) c.max_level = cl.level;
  }
  return c;
}

// A camera looking at the DAG's bounds from `distance_in_radii` bounding radii away
// (diagonal direction), 1080 px tall viewport, 60° vertical field of view.
inline LodView bench_view(const ClusterDag& dag, double distance_in_radii) {
  constexpr float kFovY = 1.0471975511965976f;  // 60°: a common game camera
  constexpr float kViewportHeight = 1080;        // 1080p
  Vec3 c{(dag.bounds.min.x + dag.bounds.max.x) / 2, (dag.bounds.min.y + dag.bounds.max.y) / 2,
         (dag.bounds.min.z + dag.bounds.max.z) / 2};
  double r = 0.5 * distance_d(dag.bounds.min, dag.bounds.max);
  double d = r * distance_in_radii / std::sqrt(3.0);
  LodView v;
  v.eye = {float(c.x + d), float(c.y + d), float(c.z + d)};
  v.pixels_per_unit_at_1 = lod_projection_scale(kFovY, kViewportHeight);
  v.z_near = 0.01f;
  return v;
}

}  // namespace vgeo::bench
