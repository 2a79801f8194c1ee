// Deferred shading of the visibility buffer (spec/scene.md §Shading).
#include <gtest/gtest.h>
#include <png.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <set>
#include <unistd.h>

#include "render/render_helpers.h"
#include "vgeo/shade/shade.h"

namespace vgeo {
namespace {

// A single camera-facing quad (grid in XY at z = 0) with +Z normals.
RenderScene quad_scene(std::array<float, 4> colour) {
  RenderScene s;
  BuildOptions bo;
  bo.threads = 1;
  s.meshes.push_back(build_dag(test::make_grid(8, 2.0f, false, {-1, -1, 0}), bo));
  s.materials.push_back(Material{"c", colour});
  s.instances.push_back({0, Mat4d{}});
  analyze_render_scene(&s);
  return s;
}

TEST(Shade, FlatQuadIsUniformlyLitByLambertPlusAmbient) {
  RenderScene s = quad_scene({0.5f, 0.25f, 1.0f, 1});
  Camera cam = test::look_camera({0, 0, 3}, {0, 0, 0}, 64, 64);
  ThreadPool pool(2);
  Frame f;
  render_frame({s, cam, {}, pool, nullptr}, &f);
  // Expected: base × (0.25 + 0.75 · n·l), n = +Z, l = normalize(0.4, 0.8, 0.45).
  double l = 0.45 / std::sqrt(0.4 * 0.4 + 0.8 * 0.8 + 0.45 * 0.45), k = 0.25 + 0.75 * l;
  auto srgb = [](double c) {
    double v = c <= 0.0031308 ? 12.92 * c : 1.055 * std::pow(c, 1 / 2.4) - 0.055;
    return int(std::lround(v * 255));
  };
  int expect[3] = {srgb(0.5 * k), srgb(0.25 * k), srgb(1.0 * k)};
  size_t covered = 0;
  for (size_t p = 0; p < f.vis.keys.size(); ++p) {
    if (!f.vis.keys[p]) continue;
    ++covered;
    for (int c = 0; c < 3; ++c) ASSERT_NEAR(int(f.image.rgb[3 * p + c]), expect[c], 1) << p;
  }
  EXPECT_GT(covered, 64u * 64u / 4);
}

TEST(Shade, DebugViewsColourByTheirId) {
  RenderScene s = test::make_row_scene(1.0, 0.0, 2);
  Camera cam = test::look_camera({4, 3, 6}, {0, 1, -4}, 96, 64);
  ThreadPool pool(2);
  for (ShadeView view : {ShadeView::kTriangle, ShadeView::kCluster, ShadeView::kGroup}) {
    RenderSettings settings;
    settings.view = view;
    Frame f;
    render_frame({s, cam, settings, pool, nullptr}, &f);
    // Pixels of the same id share a colour; more than one colour appears.
    std::map<uint64_t, uint32_t> colour_of;
    std::set<uint32_t> colours;
    for (size_t p = 0; p < f.vis.keys.size(); ++p) {
      uint64_t k = f.vis.keys[p];
      if (!k) continue;
      const VisibleCluster& v = f.visible[vis_key_cluster(k)];
      uint64_t id = view == ShadeView::kTriangle ? (k & 0xFFFFFFFFu)
                    : view == ShadeView::kCluster ? (uint64_t(v.instance) << 32 | v.cluster)
                    : (uint64_t(v.instance) << 32 | s.meshes[s.instances[v.instance].mesh].clusters[v.cluster].group);
      uint32_t rgb = uint32_t(f.image.rgb[3 * p]) << 16 | uint32_t(f.image.rgb[3 * p + 1]) << 8 | f.image.rgb[3 * p + 2];
      auto [it, fresh] = colour_of.emplace(id, rgb);
      EXPECT_EQ(it->second, rgb);
      colours.insert(rgb);
    }
    EXPECT_GT(colours.size(), 1u) << shade_view_name(view);
  }
}

TEST(Shade, OverdrawCountsEveryDrawnClusterCoveringAPixel) {
  RenderScene s = test::make_row_scene(1.0, 0.0, 3);
  Camera cam = test::look_camera({0, 1.5, 6}, {0, 1.2, -10}, 80, 60);
  ThreadPool pool(2);
  RenderSettings settings;
  settings.view = ShadeView::kOverdraw;
  Frame f;
  render_frame({s, cam, settings, pool, nullptr}, &f);
  ASSERT_EQ(f.overdraw.size(), f.vis.keys.size());
  uint32_t max_count = 0;
  for (size_t p = 0; p < f.vis.keys.size(); ++p) {
    EXPECT_EQ(f.overdraw[p] == 0, f.vis.keys[p] == 0) << p;  // covered ⇔ counted
    max_count = std::max(max_count, f.overdraw[p]);
  }
  EXPECT_GE(max_count, 2u);  // spheres in a row overlap
}

TEST(Shade, ViewNamesRoundTrip) {
  for (ShadeView v : {ShadeView::kLit, ShadeView::kTriangle, ShadeView::kCluster, ShadeView::kGroup, ShadeView::kLod,
                      ShadeView::kError, ShadeView::kOverdraw}) {
    ShadeView back;
    ASSERT_TRUE(parse_shade_view(shade_view_name(v), &back));
    EXPECT_EQ(back, v);
  }
  ShadeView x;
  EXPECT_FALSE(parse_shade_view("depth", &x));
}

TEST(Shade, PngRoundTripsThroughLibpng) {
  Image img;
  img.width = 5;
  img.height = 3;
  for (uint32_t i = 0; i < 15 * 3; ++i) img.rgb.push_back(uint8_t(i * 7));
  std::string path = (std::filesystem::temp_directory_path() / ("vgeo_shade_png_" + std::to_string(::getpid()) + ".png")).string();
  write_png(path, img);
  png_image read{};
  read.version = PNG_IMAGE_VERSION;
  ASSERT_TRUE(png_image_begin_read_from_file(&read, path.c_str()));
  read.format = PNG_FORMAT_RGB;
  std::vector<uint8_t> pixels(PNG_IMAGE_SIZE(read));
  ASSERT_TRUE(png_image_finish_read(&read, nullptr, pixels.data(), 0, nullptr));
  EXPECT_EQ(read.width, 5u);
  EXPECT_EQ(read.height, 3u);
  EXPECT_EQ(pixels, img.rgb);
  std::filesystem::remove(path);
  EXPECT_THROW(write_png("/nonexistent-dir/x.png", img), VgeoError);
}

}  // namespace
}  // namespace vgeo
