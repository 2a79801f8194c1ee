#pragma once
// The rule a hardware-rastered virtual shadow page is held to against the CPU reference's
// (spec/shadow.md §8, "The hardware rule for shadow pages"): spec/raster.md §13.3's per-pixel
// classifier (classify_hw_pixel, raster/hw_rule.h) applied per texel. A texel keeps only a
// depth, not the key's triangle, so each side's texel is first *explained*: the triangle of
// the page's elements whose exact model covers the texel centre (not outside, margin δ) and
// whose model depth there is nearest the stored depth, within 2 · its tolerance at the centre
// (model_depth_tolerance_at; a triangle degenerate within rounding explains any depth, last). An
// unexplained nonzero depth fails; explained ones are classified as §13.3 classifies keys.
#include <cstdint>
#include <vector>

#include "vgeo/dag/cluster_dag.h"
#include "vgeo/raster/hw_rule.h"
#include "vgeo/shadow/virtual_shadow.h"

namespace vgeo {

// Page `page` of `list` (the reference's draw list: the page's elements and each view's float
// object→clip matrices): its 128² reference texels `reference` against `hardware` (both row
// by row from the page's first texel). Adds every texel's class to `agreement`.
void classify_shadow_page_hw(const std::vector<ClusterDag>& meshes, const std::vector<CullInstance>& instances,
                             const ShadowDrawList& list, size_t page,
                             const float* reference, const float* hardware, HwRasterAgreement* agreement);

}  // namespace vgeo
