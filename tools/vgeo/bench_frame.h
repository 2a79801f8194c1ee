#pragma once
// A minimal frame driver for the benchmarks, written only against frozen interfaces
// (lib/core/lod.h, lib/build/cluster_dag.h, lib/raster/raster.h): per instance a LOD cut
// (BVH-guided when the DAG has one, flat otherwise) + sphere frustum culling, software
// raster of the cut into a VisBuffer, then a Lambert shade of the visibility buffer.
// It gives the lod/scaling/stability suites identical passes for every variant; it is a
// measuring instrument, not the runtime (lib/render).
#include <cstdint>
#include <vector>

#include "vgeo/build/cluster_dag.h"
#include "vgeo/core/math.h"
#include "vgeo/core/thread_pool.h"
#include "vgeo/raster/raster.h"
#include "vgeo/raster/visbuffer.h"

namespace vgeo::bench {

struct DVec3 {
  double x = 0, y = 0, z = 0;
};

// Translation + uniform scale (the suites place instances; rotation adds nothing to measure).
struct BenchInstance {
  uint32_t mesh = 0;
  DVec3 translation;
  double scale = 1;
};

struct BenchCamera {
  DVec3 eye, target{0, 0, -1}, up{0, 1, 0};
  double fov_y = 1.0471975511965976;  // 60°
  uint32_t width = 640, height = 360;
  float z_near = 0.01f;
};

struct FrameOptions {
  float tau = 1.0f;          // LOD threshold in pixels
  bool leaves_only = false;  // draw every leaf cluster (full detail reference)
  bool frustum_cull = true;
};

struct VisibleCluster {
  uint32_t instance, cluster;
};

struct FrameResult {
  uint64_t clusters = 0, triangles = 0;
  double seconds_cut = 0, seconds_raster = 0, seconds_shade = 0;  // wall
  double cpu_cut = 0, cpu_raster = 0, cpu_shade = 0;              // process CPU (all threads)
  std::vector<VisibleCluster> visible;
  VisBuffer vis;
  std::vector<uint8_t> image;  // grey 0..255 per pixel; 0 = background
  RasterStats raster;
  double total() const { return seconds_cut + seconds_raster + seconds_shade; }
};

// Renders one frame. `meshes[i]` is the DAG of mesh i.
void render_frame(const std::vector<const ClusterDag*>& meshes, const std::vector<BenchInstance>& instances,
                  const BenchCamera& camera, const FrameOptions& options, ThreadPool& pool, FrameResult& out);

// Image error of `test` against `reference` of the same view.
struct ImageError {
  double mean_abs = 0, max_abs = 0;  // shaded grey difference, 0..255
  double surface_differs = 0;        // share of pixels: coverage differs or depth differs > tolerance
};
ImageError compare_frames(const FrameResult& test, const FrameResult& reference);

// Count of clusters the flat (non-BVH) cut selects, to cross-check the BVH traversal.
uint64_t flat_cut_clusters(const std::vector<const ClusterDag*>& meshes, const std::vector<BenchInstance>& instances,
                           const BenchCamera& camera, const FrameOptions& options);

}  // namespace vgeo::bench
