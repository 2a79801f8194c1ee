// Golden renders (spec/raster.md §10a): per scene, the CPU reference's vis_hash,
// cluster_set_hash and image must equal the committed ones (tests/golden/expected/, written
// only by tools/update-goldens), and the Vulkan backend on lavapipe, with the validation layer
// on, must keep the rule against the CPU on every frame; under --raster hw and auto the
// hardware rule of spec/raster.md §13.3. A failure leaves the diff PNG and
// the differing pixels in <build>/golden-out/NAME/.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <nlohmann/json.hpp>

#include "render/stream_fixture.h"
#include "vgeo/gpu/backend_run.h"

namespace vgeo {
namespace {

namespace fs = std::filesystem;

struct Golden {
  const char* name;
  const char* scene;       // path under the source tree; "" = the embedded default scene
  ShadeView view = ShadeView::kLit;
  uint32_t width = 0, height = 0;  // 0: the scene's resolution
  uint32_t frames = 0;             // 0: the scene's camera path, else 1
  bool streamed = false;           // scene = the stream fixture's fly-through at kStreamBudgetShare
  // A scene with a shadowing light (spec/shadow.md): every frame is shaded and saved (shadow_draw
  // runs on every frame of a sequence and the cache carries over), and every frame's shadow
  // pages are compared bit for bit.
  bool shadows = false;
  bool shadow_cache_used = false;  // some frame after the first reuses cached pages (a moving camera)
  // The scene's moves (spec/scene.md §Moves) at this frame (> 1; 0: none): the frame before it
  // draws no page (a static scene's pages are all cached), the moved frame redraws every page
  // of the light (a light moved) or only some (a caster moved: `caster`).
  uint32_t moved_at = 0;
  bool caster = false;
};

// The streamed fly-through's budget: the pinned pages plus this share of the rest (pages are
// loaded and evicted along the path; the cut is coarser than ideal on some frames).
constexpr uint64_t kStreamBudgetShareInverse = 4;

// Small resolutions keep the whole test at seconds (CI budget, DEVELOPERS.md).
const Golden kGoldens[] = {
    {"default", "", ShadeView::kLit, 160, 90, 1},
    {"cgal", "tests/scenes/cgal.json", ShadeView::kLit, 160, 90},
    {"far_away", "tests/scenes/far_away.json", ShadeView::kLit, 128, 96},
    {"scale_small", "tests/golden/scenes/scale_small.json"},
    {"scale_large", "tests/golden/scenes/scale_large.json"},
    {"inside_bounds", "tests/golden/scenes/inside_bounds.json"},
    {"near_plane", "tests/golden/scenes/near_plane.json"},
    {"occlusion_path", "tests/scenes/camera_path.json", ShadeView::kLit, 128, 96},
    {"view_triangle", "tests/scenes/spheres.json", ShadeView::kTriangle, 160, 90},
    {"view_cluster", "tests/scenes/spheres.json", ShadeView::kCluster, 160, 90},
    {"view_group", "tests/scenes/spheres.json", ShadeView::kGroup, 160, 90},
    {"view_lod", "tests/scenes/spheres.json", ShadeView::kLod, 160, 90},
    {"view_error", "tests/scenes/spheres.json", ShadeView::kError, 160, 90},
    {"view_overdraw", "tests/scenes/spheres.json", ShadeView::kOverdraw, 160, 90},
    {"stream_flythrough", "", ShadeView::kLit, 0, 0, 0, true},
    {"light_directional", "tests/shadow/scenes/directional.json", ShadeView::kLit, 160, 90, 1, false, true},
    {"light_spot", "tests/shadow/scenes/spot.json", ShadeView::kLit, 160, 90, 1, false, true},
    {"light_point", "tests/shadow/scenes/point.json", ShadeView::kLit, 160, 90, 1, false, true},
    {"light_flight", "tests/golden/scenes/light_flight.json", ShadeView::kLit, 0, 0, 0, false, true, true},
    {"light_moving", "tests/golden/scenes/light_moving.json", ShadeView::kLit, 0, 0, 4, false, true, true, 2},
    {"caster_moving", "tests/golden/scenes/caster_moving.json", ShadeView::kLit, 0, 0, 4, false, true, true, 2, true},
};

SceneFile load_golden_scene(const Golden& g) {
  SceneLoadOptions options;
  options.cache_dir = std::string(VGEO_BINARY_DIR) + "/cache/vgeo-golden";
  if (g.streamed) {
    // The streaming tests' page file (16 KiB pages, deterministic build) and fly-through
    // (3 instances, 9 frames from far to near, then sideways), with the deterministic loader.
    const test::StreamFixture& f = test::stream_fixture();
    options.stream.emplace();
    options.stream->budget_bytes = f.pinned + (f.total - f.pinned) / kStreamBudgetShareInverse;
    options.stream->loader.asynchronous = false;
    return parse_scene_json(test::stream_scene_json("meshes.vgp", 3, 12, 2, true), "<golden stream>", f.dir, options);
  }
  if (!*g.scene) return make_default_scene(g.width, g.height, 1, options);
  SceneFile sf = load_scene_file(std::string(VGEO_SOURCE_DIR) + "/" + g.scene, options);
  if (g.width)
    for (std::vector<Camera>* cams : {&sf.cameras, &sf.path})
      for (Camera& c : *cams) {
        c.width = g.width;
        c.height = g.height;
      }
  return sf;
}


class GoldenTest : public ::testing::TestWithParam<Golden> {};

TEST_P(GoldenTest, CpuMatchesCommittedAndVulkanKeepsTheRule) {
  const Golden& g = GetParam();
  const fs::path expected_dir = fs::path(VGEO_SOURCE_DIR) / "tests/golden/expected";
  const fs::path out_dir = fs::path(VGEO_BINARY_DIR) / "golden-out" / g.name;
  fs::create_directories(out_dir);
  SceneFile sf = load_golden_scene(g);

  RenderRequest cpu;
  cpu.backend = Backend::kCpu;
  cpu.view = g.view;
  cpu.frames = g.frames;
  cpu.threads = 2;
  const bool update = std::getenv("VGEO_UPDATE_GOLDENS") && std::string(std::getenv("VGEO_UPDATE_GOLDENS")) == "1";
  cpu.output_png = ((update ? expected_dir : out_dir) / (std::string(g.name) + ".png")).string();
  if (g.shadows) {  // save every frame's image (each frame's shadow term, not only the last one's)
    cpu.out_dir = (out_dir / "cpu_frames").string();
    fs::create_directories(cpu.out_dir);
    cpu.save_every = 1;
  }
  // The GPU's pages: the scene's own encodings transcoded (a streamed scene's page-file meshes
  // are drawn from each renderer's Streamer).
  const MemoryFormPages memory_form = memory_form_pages(sf);
  RenderReport ref = run_backend(sf, cpu, {nullptr, &memory_form});
  const fs::path expected_json = expected_dir / (std::string(g.name) + ".json");
  if (update) {
    nlohmann::ordered_json j;
    j["vis_hash"] = hex64(ref.vis_hash);
    j["cluster_set_hash"] = hex64(ref.cluster_set_hash);
    j["image_hash"] = hex64(ref.image_hash);
    j["frames"] = ref.frames.size();
    std::ofstream(expected_json) << j.dump(2) << "\n";
  } else {
    std::ifstream in(expected_json);
    ASSERT_TRUE(in) << expected_json << " missing: run tools/update-goldens";
    nlohmann::json j = nlohmann::json::parse(in);
    EXPECT_EQ(j["vis_hash"].get<std::string>(), hex64(ref.vis_hash)) << g.name << ": CPU reference changed";
    EXPECT_EQ(j["cluster_set_hash"].get<std::string>(), hex64(ref.cluster_set_hash)) << g.name;
    EXPECT_EQ(j["image_hash"].get<std::string>(), hex64(ref.image_hash)) << g.name;
  }

  if (g.shadows) {
    ASSERT_FALSE(ref.frames.empty());
    for (size_t f = 0; f < ref.frames.size(); ++f) {
      EXPECT_TRUE(ref.frames[f].has_shadow) << g.name << " frame " << f;
      EXPECT_GT(ref.frames[f].shadow.pages_marked, 0u) << g.name << " frame " << f;
    }
    uint64_t cached = 0;
    for (size_t f = 1; f < ref.frames.size(); ++f) cached += ref.frames[f].shadow.pages_cached;
    if (g.shadow_cache_used) {
      EXPECT_GT(cached, 0u) << g.name << ": no frame reuses a cached page";
    }
    if (g.moved_at) {
      ASSERT_LT(g.moved_at, ref.frames.size());
      const ShadowFrameStats& before = ref.frames[g.moved_at - 1].shadow;
      const ShadowFrameStats& moved = ref.frames[g.moved_at].shadow;
      EXPECT_EQ(before.pages_drawn, 0u) << g.name << ": the static frame before the move drew pages";
      EXPECT_GT(moved.pages_drawn, 0u) << g.name << ": the move invalidated nothing";
      if (g.caster) {
        EXPECT_LT(moved.pages_drawn, moved.pages_marked) << g.name << ": a caster move redrew every page";
      }
      else EXPECT_EQ(moved.pages_drawn, moved.pages_marked) << g.name << ": a light move kept cached pages";
    }
  }

  RenderRequest vk = cpu;
  vk.backend = Backend::kVulkan;
  if (g.shadows) {
    vk.out_dir = (out_dir / "vulkan_frames").string();
    fs::create_directories(vk.out_dir);
  }
  vk.compare_cpu = true;
  vk.gpu_validate = true;
  vk.output_png = (out_dir / "vulkan.png").string();
  vk.diff_png = (out_dir / "diff.png").string();
  vk.failure_dir = out_dir.string();
  GpuOptions gpu_options;
  gpu_options.validate = true;
  std::unique_ptr<GpuContext> gpu = create_gpu_context(gpu_options);
  RenderReport got = run_backend(sf, vk, {gpu.get(), &memory_form});
  EXPECT_TRUE(got.rule_holds) << g.name << ":\n" << got.table() << "diff PNG and differing pixels in " << out_dir;
  EXPECT_EQ(got.vis_hash, ref.vis_hash) << g.name;
  EXPECT_EQ(got.cluster_set_hash, ref.cluster_set_hash) << g.name;
  EXPECT_TRUE(got.validation_messages.empty()) << g.name << ": " << got.validation_messages.size()
                                               << " validation message(s), first: "
                                               << (got.validation_messages.empty() ? "" : got.validation_messages[0]);
  ASSERT_EQ(got.comparisons.size(), ref.frames.size());
  if (g.shadows)
    for (size_t f = 0; f < got.comparisons.size(); ++f) {
      EXPECT_TRUE(got.comparisons[f].shadow_compared) << g.name << " frame " << f;
      EXPECT_TRUE(got.comparisons[f].shadow_tables_equal) << g.name << " frame " << f;
      EXPECT_EQ(got.comparisons[f].shadow_texels_differing, 0u) << g.name << " frame " << f;
      EXPECT_EQ(got.frames[f].shadow, ref.frames[f].shadow) << g.name << " frame " << f;
    }
  if (g.streamed) {
    // Streaming really ran on both, with pages installed along the path and the pool in use.
    ASSERT_TRUE(sf.streaming) << sf.stream_reason;
    uint64_t loaded = 0;
    for (size_t f = 0; f < got.frames.size(); ++f) {
      EXPECT_TRUE(got.frames[f].streamed);
      EXPECT_EQ(got.frames[f].stream.pages_loaded, ref.frames[f].stream.pages_loaded) << "frame " << f;
      EXPECT_EQ(got.frames[f].stream.resident_bytes, ref.frames[f].stream.resident_bytes) << "frame " << f;
      EXPECT_EQ(got.frames[f].stream.clusters_coarser, ref.frames[f].stream.clusters_coarser) << "frame " << f;
      loaded += got.frames[f].stream.pages_loaded;
    }
    EXPECT_GT(loaded, 0u);
    EXPECT_GT(got.pool.pages_uploaded, 0u);
    EXPECT_LE(got.pool.pages_uploaded, got.pool.pages_freed + got.pool.slots);
  }

  // The hardware raster path and the per-cluster split (spec/raster.md §13.3): coverage and
  // triangle ids as the CPU outside the ambiguity mask, depth within tolerance; the pixels
  // inside the mask are reported.
  for (GpuRasterMode mode : {GpuRasterMode::kHw, GpuRasterMode::kAuto}) {
    const fs::path mode_dir = out_dir / gpu_raster_mode_name(mode);
    fs::create_directories(mode_dir);
    RenderRequest m = vk;
    m.raster = mode;
    m.output_png = (mode_dir / "vulkan.png").string();
    if (!m.out_dir.empty()) {
      m.out_dir = (mode_dir / "frames").string();
      fs::create_directories(m.out_dir);
    }
    m.diff_png = (mode_dir / "diff.png").string();
    m.failure_dir = mode_dir.string();
    RenderReport r = run_backend(sf, m, {gpu.get(), &memory_form});
    const char* name = gpu_raster_mode_name(mode);
    EXPECT_TRUE(r.rule_holds) << g.name << " --raster " << name << ":\n" << r.table() << "output in " << mode_dir;
    EXPECT_EQ(r.cluster_set_hash, ref.cluster_set_hash) << g.name << " --raster " << name;
    EXPECT_TRUE(r.validation_messages.empty()) << g.name << " --raster " << name << ": " << r.validation_messages.size()
                                               << " validation message(s), first: "
                                               << (r.validation_messages.empty() ? "" : r.validation_messages[0]);
    HwRasterAgreement total, shadow_total;
    uint64_t shadow_pages = 0;
    for (size_t f = 0; f < r.frames.size(); ++f) {
      ASSERT_TRUE(r.frames[f].has_raster_split) << g.name << " frame " << f;
      const RasterSplitStats& split = r.frames[f].raster_split;
      EXPECT_EQ(split.sw_clusters + split.hw_clusters, r.frames[f].clusters_drawn) << g.name << " frame " << f;
      EXPECT_EQ(split.sw_triangles + split.hw_triangles, r.frames[f].triangles_drawn) << g.name << " frame " << f;
      if (mode == GpuRasterMode::kHw) {
        EXPECT_EQ(split.sw_clusters, 0u) << g.name << " frame " << f;
      }
      total.add(r.comparisons[f].hw);
      // The shadow pages both sides drew, under the shadow-page hardware rule (spec/shadow.md §8).
      if (g.shadows) {
        const FrameComparison& c = r.comparisons[f];
        EXPECT_TRUE(c.shadow_hw_compared) << g.name << " --raster " << name << " frame " << f;
        EXPECT_EQ(c.shadow_element_lists_differing, 0u) << g.name << " --raster " << name << " frame " << f;
        EXPECT_EQ(c.shadow_hw.failures(), 0u) << g.name << " --raster " << name << " frame " << f;
        shadow_pages += c.shadow_pages_compared;
        shadow_total.add(c.shadow_hw);
      }
    }
    if (g.shadows) {
      EXPECT_GT(shadow_pages, 0u) << g.name << " --raster " << name << ": no shadow page compared";
      std::printf("%s --raster %s: shadow pages compared %llu; texels depth only %llu, inside the mask %llu, max depth "
                  "error %.3g x tolerance\n",
                  g.name, name, (unsigned long long)shadow_pages,
                  (unsigned long long)shadow_total.count(HwPixel::kDepthOnly), (unsigned long long)shadow_total.in_mask(),
                  shadow_total.max_depth_error_ratio);
    }
    std::printf("%s --raster %s: sw/hw clusters %llu/%llu (last frame); pixels differing in depth only %llu, inside "
                "the mask %llu (ambiguous depth %llu, clip coverage %llu, snap coverage %llu), max depth error %.3g x "
                "tolerance\n",
                g.name, name, (unsigned long long)r.frames.back().raster_split.sw_clusters,
                (unsigned long long)r.frames.back().raster_split.hw_clusters,
                (unsigned long long)total.count(HwPixel::kDepthOnly), (unsigned long long)total.in_mask(),
                (unsigned long long)total.count(HwPixel::kAmbiguousDepth),
                (unsigned long long)total.count(HwPixel::kAmbiguousClipCoverage),
                (unsigned long long)total.count(HwPixel::kAmbiguousSnapCoverage), total.max_depth_error_ratio);
  }
}

INSTANTIATE_TEST_SUITE_P(Scenes, GoldenTest, ::testing::ValuesIn(kGoldens),
                         [](const ::testing::TestParamInfo<Golden>& info) { return std::string(info.param.name); });

}  // namespace
}  // namespace vgeo
