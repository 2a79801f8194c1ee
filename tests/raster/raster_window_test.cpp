// The scissor window (RasterOptions::virtual_width, window_x/y; spec/shadow.md §5, the seeds'
// "scissor to the page"): a window target gets exactly the keys the whole viewport gets there, on
// every raster path, for triangles of every kind (clipped, huge, degenerate, sub-pixel).
#include <gtest/gtest.h>
#include <rapidcheck/gtest.h>

#include "raster/raster_testing.h"

namespace vgeo {
namespace {

using raster_test::Tri;

RC_GTEST_PROP(RasterWindow, WindowEqualsTheWholeViewportCroppedOnEveryPath, ()) {
  const uint32_t w = 64, h = 64;  // 4 x 4 windows of 16 x 16
  const uint32_t win = 16;
  int n = raster_test::uniform(1, 12);
  std::vector<Tri> tris;
  for (int i = 0; i < n; ++i)
    tris.push_back(i > 0 && raster_test::uniform(0, 2) ? raster_test::neighbour_triangle(tris.back(), int(w), int(h))
                                                       : raster_test::pixel_triangle(int(w), int(h)));
  const Mat4 m = raster_test::pixel_to_clip(w, h);
  const bool cull = *rc::gen::arbitrary<bool>();
  for (RasterPath path : {RasterPath::kMicropoly, RasterPath::kScanline, RasterPath::kReference, RasterPath::kAuto}) {
    RasterOptions opt;
    opt.path = path;
    opt.cull_backfaces = cull;
    opt.z_near = 0.5f;
    VisBuffer full;
    full.resize(w, h);
    raster_test::raster_tris(full, tris, m, 3, opt);
    const uint32_t wx = raster_test::uniform(0u, w / win) * win, wy = raster_test::uniform(0u, h / win) * win;
    RasterOptions wopt = opt;
    wopt.virtual_width = w;
    wopt.virtual_height = h;
    wopt.window_x = wx;
    wopt.window_y = wy;
    VisBuffer window;
    window.resize(win, win);
    raster_test::raster_tris(window, tris, m, 3, wopt);
    for (uint32_t y = 0; y < win; ++y)
      for (uint32_t x = 0; x < win; ++x)
        RC_ASSERT(window.keys[size_t(y) * win + x] == full.keys[size_t(wy + y) * w + wx + x]);
  }
}

}  // namespace
}  // namespace vgeo
