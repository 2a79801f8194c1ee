// Shadow pages under the hardware raster rule (shadow_hw_rule.h, spec/shadow.md §8).
// Based on: spec/raster.md §13.3 (classify_hw_pixel), with each texel's triangle recovered
// from the exact model of §10 since a shadow texel stores no triangle id.
#include "vgeo/shadow/shadow_hw_rule.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>

#include "vgeo/core/vis_key.h"

namespace vgeo {

namespace {

constexpr uint32_t kPageSide = kShadowPageTexels;
constexpr size_t kPageTexels = size_t(kPageSide) * kPageSide;
// A stored depth is explained by a triangle within this many of its depth tolerances: the
// same-triangle bound of spec/raster.md §13.3 ("depth only": within 2 · tol).
constexpr double kExplainedTolerances = 2.0;

// Per texel with differing bits: the best-explaining triangle of each side (−1: none) and its
// score (|stored − model depth| / tolerance), and whether any triangle covers the centre.
struct TexelMatch {
  int32_t tri[2] = {-1, -1};
  double score[2] = {std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity()};
  bool covered = false;
};

std::vector<ModelTriangle> page_models(const std::vector<ClusterDag>& meshes, const std::vector<CullInstance>& instances,
                                       const ShadowDrawList& list, size_t page) {
  const ShadowPageDraw& p = list.pages[page];
  std::vector<ModelTriangle> models;
  for (const VisibleCluster& c : list.clusters[page]) {
    const Mat4& m = list.object_to_clip[p.view][c.instance];
    const ClusterDag& dag = meshes[instances[c.instance].mesh];
    const DagCluster& cluster = dag.clusters[c.cluster];
    for (uint32_t t = 0; t < cluster.triangle_count; ++t) {
      Vec3 v[3];
      for (int k = 0; k < 3; ++k) v[k] = dag.position(cluster.vertex_offset + dag.indices[3 * (cluster.triangle_offset + t) + k]);
      models.push_back(model_triangle(v, m, p.raster.z_near, p.raster.virtual_width, p.raster.virtual_height));
    }
  }
  return models;
}

// The texel box a model can touch (its outline widened by its margin and one texel), clipped
// to the page's window; false when empty.
bool model_box(const ModelTriangle& t, const ShadowPageDraw& p, uint32_t* x0, uint32_t* x1, uint32_t* y0, uint32_t* y1) {
  const ModelPolygon& poly = t.polygon;
  if (poly.count < 3) return false;
  double lo_x = poly.x[0], hi_x = poly.x[0], lo_y = poly.y[0], hi_y = poly.y[0];
  for (uint32_t i = 1; i < poly.count; ++i) {
    lo_x = std::min(lo_x, poly.x[i]);
    hi_x = std::max(hi_x, poly.x[i]);
    lo_y = std::min(lo_y, poly.y[i]);
    hi_y = std::max(hi_y, poly.y[i]);
  }
  const double wx0 = p.raster.window_x, wy0 = p.raster.window_y;
  const double bx0 = std::max(wx0, std::floor(lo_x - t.margin) - 1), bx1 = std::min(wx0 + kPageSide - 1, std::ceil(hi_x + t.margin) + 1);
  const double by0 = std::max(wy0, std::floor(lo_y - t.margin) - 1), by1 = std::min(wy0 + kPageSide - 1, std::ceil(hi_y + t.margin) + 1);
  if (!(bx0 <= bx1 && by0 <= by1)) return false;
  *x0 = uint32_t(bx0);
  *x1 = uint32_t(bx1);
  *y0 = uint32_t(by0);
  *y1 = uint32_t(by1);
  return true;
}

}  // namespace

void classify_shadow_page_hw(const std::vector<ClusterDag>& meshes, const std::vector<CullInstance>& instances,
                             const ShadowDrawList& list, size_t page,
                             const float* reference, const float* hardware, HwRasterAgreement* agreement) {
  const ShadowPageDraw& p = list.pages[page];
  std::vector<int32_t> differing(kPageTexels, -1);  // index into matches
  std::vector<TexelMatch> matches;
  for (size_t i = 0; i < kPageTexels; ++i) {
    if (std::bit_cast<uint32_t>(reference[i]) == std::bit_cast<uint32_t>(hardware[i])) {
      ++agreement->pixels[int(HwPixel::kIdentical)];
      continue;
    }
    differing[i] = int32_t(matches.size());
    matches.emplace_back();
  }
  if (matches.empty()) return;
  const std::vector<ModelTriangle> models = page_models(meshes, instances, list, page);
  for (size_t t = 0; t < models.size(); ++t) {
    const ModelTriangle& m = models[t];
    uint32_t x0, x1, y0, y1;
    if (!model_box(m, p, &x0, &x1, &y0, &y1)) continue;
    for (uint32_t y = y0; y <= y1; ++y)
      for (uint32_t x = x0; x <= x1; ++x) {
        const size_t i = size_t(y - p.raster.window_y) * kPageSide + (x - p.raster.window_x);
        if (differing[i] < 0) continue;
        const double cx = x + 0.5, cy = y + 0.5;
        if (model_coverage(m.polygon, cx, cy, m.margin) == ModelCoverage::kOutside) continue;
        TexelMatch& match = matches[size_t(differing[i])];
        match.covered = true;
        const double z = model_depth_at(m, cx, cy);
        const float stored[2] = {reference[i], hardware[i]};
        for (int side = 0; side < 2; ++side) {
          if (stored[side] == 0.0f) continue;
          const double error = std::abs(double(stored[side]) - z);
          // A triangle degenerate within rounding (infinite tolerance: no depth plane) explains
          // any depth, but only where no triangle with a plane explains it.
          const double tol = model_depth_tolerance_at(m, cx, cy);
          const double score = std::isinf(tol) ? kExplainedTolerances
                               : tol > 0       ? error / tol
                                               : (error == 0 ? 0 : std::numeric_limits<double>::infinity());
          if (score <= kExplainedTolerances && score < match.score[side]) {
            match.score[side] = score;
            match.tri[side] = int32_t(t);
          }
        }
      }
  }
  for (size_t i = 0; i < kPageTexels; ++i) {
    if (differing[i] < 0) continue;
    const TexelMatch& match = matches[size_t(differing[i])];
    const float stored[2] = {reference[i], hardware[i]};
    bool explained = true;
    for (int side = 0; side < 2; ++side) explained = explained && (stored[side] == 0.0f || match.tri[side] >= 0);
    HwPixel kind;
    if (!explained) {
      // A depth no covering triangle explains: out of tolerance where some triangle covers the
      // centre, written where none does otherwise.
      kind = match.covered ? HwPixel::kDepthBeyondTolerance : HwPixel::kViolation;
    } else {
      const ModelTriangle* ref = match.tri[0] >= 0 ? &models[size_t(match.tri[0])] : nullptr;
      const ModelTriangle* hw = match.tri[1] >= 0 ? &models[size_t(match.tri[1])] : nullptr;
      const bool same = ref && hw && match.tri[0] == match.tri[1];
      // Keys carrying the depths and the explaining triangles (background: 0).
      const uint64_t ref_key = ref ? pack_vis_key(stored[0], 0, 0) | (uint64_t(match.tri[0]) + 1) : 0;
      const uint64_t hw_key = hw ? pack_vis_key(stored[1], 0, 0) | (uint64_t(match.tri[1]) + 1) : 0;
      const uint32_t x = p.raster.window_x + uint32_t(i % kPageSide), y = p.raster.window_y + uint32_t(i / kPageSide);
      kind = classify_hw_pixel(ref_key, hw_key, same, ref, hw, x, y);
      const double tol = same ? model_depth_tolerance_at(*ref, x + 0.5, y + 0.5) : 0;
      if (same && tol > 0 && !std::isinf(tol))
        agreement->max_depth_error_ratio =
            std::max(agreement->max_depth_error_ratio, std::abs(double(stored[0]) - double(stored[1])) / tol);
    }
    ++agreement->pixels[int(kind)];
  }
}

}  // namespace vgeo
