#pragma once
// Frame comparison and the order-independent hashes (spec/raster.md §Backends agree,
// §Hashes): what a visibility key denotes (depth, instance, cluster, triangle) does not depend
// on the order of the visible-cluster list a backend appended, so two backends' frames are
// compared, and hashed, by what each pixel denotes.
#include <cstdint>
#include <string>
#include <vector>

#include "vgeo/raster/hw_rule.h"
#include "vgeo/render/frame.h"

namespace vgeo {

// One frame of a comparison (spec/raster.md §Backends agree; with a hardware-rastered
// cluster in the frame, the hardware rule of §13.3 instead of bit identity).
struct FrameComparison {
  bool clusters_equal = true;        // same selected (instance, cluster) set
  uint64_t vis_pixels_differing = 0; // pixels whose key denotes a different (depth, instance, cluster, triangle)
  bool shaded = false;               // the images were compared (frames shaded on both sides)
  int max_channel_diff = 0;          // in 1/255 units (hardware rule: pixels with identical keys only)
  uint64_t pixels_over = 0;          // pixels with a channel more than 1/255 apart
  bool hw_rule = false;              // judged by the hardware rule (--raster hw|auto)
  HwRasterAgreement hw;              // per-pixel classes of the hardware rule
  // The virtual shadow pages (spec/shadow.md §5), compared when either side drew them. Bit
  // identity (not under the hardware rule): the same page table and counters, and every pool
  // texel of the slots in use bit-identical.
  bool shadow_compared = false;
  bool shadow_tables_equal = true;
  uint64_t shadow_texels_differing = 0;
  // Under the hardware rule (spec/shadow.md §8; the primary pixels, and so the marked pages,
  // may differ): every page both sides drew this frame (same map, mip, page), its element
  // lists equal and its texels classified by the shadow-page hardware rule (shadow_hw_rule.h).
  bool shadow_hw_compared = false;
  uint64_t shadow_pages_compared = 0;      // pages drawn on both sides
  uint64_t shadow_pages_one_side = 0;      // pages drawn by one side only (not compared)
  uint64_t shadow_element_lists_differing = 0;  // compared pages whose element lists differ: fails
  HwRasterAgreement shadow_hw;             // texel classes over the compared pages
  bool holds() const {
    return clusters_equal && (hw_rule ? hw.failures() == 0 : vis_pixels_differing == 0) && max_channel_diff <= 1 &&
           shadow_tables_equal && shadow_texels_differing == 0 && shadow_element_lists_differing == 0 &&
           shadow_hw.failures() == 0;
  }
};

// `reference` and `frame` of the same camera; `scene`/`geometry`: what the reference drew
// from (the scene's meshes, or its streamed frame's). `hw_rule`: judge by spec/raster.md §13.3.
FrameComparison compare_frames(const RenderScene& scene, const std::vector<ClusterDag>& geometry, const Camera& camera,
                               const Frame& reference, const Frame& frame, bool hw_rule);

// Red = the visibility key denotes something else, green = shaded difference (×64, so 1/255
// shows dim and anything over the rule bright), black = identical.
Image diff_image(const Frame& reference, const Frame& frame);
// dir/frame_NNNNN_diff.png and dir/frame_NNNNN_pixels.txt (each differing pixel's x y and both
// sides' denoted keys).
void write_comparison_failure(const std::string& dir, uint32_t frame_index, const Frame& reference, const Frame& frame);

// spec/raster.md §Hashes. Both are independent of the visible-cluster list's order.
uint64_t vis_buffer_hash(const VisBuffer& vis, const std::vector<VisibleCluster>& visible);
uint64_t cluster_set_hash(const std::vector<VisibleCluster>& visible);

std::string hex64(uint64_t v);  // 16 lower-case hex digits

}  // namespace vgeo
