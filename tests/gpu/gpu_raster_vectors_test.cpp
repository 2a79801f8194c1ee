// Raster conformance vectors (spec/raster.md §14, spec/vectors/raster/): the committed files
// are what `vgeo vectors raster` writes (CPU reference unchanged, geometry canonical), every
// CPU pixel loop and the compute rasterizer reproduce every key bit for bit, and the hardware
// pipeline keeps the hardware rule (§13.3) with every ambiguous pixel inside the file's mask.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include "gpu/gpu_testing.h"
#include "vgeo/gpu/raster_vectors.h"
#include "vgeo/raster/raster.h"

namespace vgeo {
namespace {

const std::string kVectorDir = std::string(VGEO_SOURCE_DIR) + "/spec/vectors/raster/";

std::string read_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

std::vector<std::string> manifest() {
  std::vector<std::string> names;
  std::istringstream in(read_text(kVectorDir + "manifest.txt"));
  std::string line;
  while (std::getline(in, line))
    if (!line.empty() && line[0] != '#') names.push_back(line);
  return names;
}

TEST(RasterVectors, CommittedFilesAreTheGeneratorsOutput) {
  const std::vector<RasterVector> generated = make_raster_vectors();
  const std::vector<std::string> names = manifest();
  ASSERT_EQ(names.size(), generated.size());
  for (size_t i = 0; i < generated.size(); ++i) {
    EXPECT_EQ(names[i], generated[i].name + ".txt");
    EXPECT_EQ(read_text(kVectorDir + names[i]), write_raster_vector(generated[i]))
        << names[i] << ": regenerate with `vgeo vectors raster` (and say why the expected keys changed)";
  }
}

TEST(RasterVectors, EveryCpuPixelLoopAndTheCanonicalFormReproduceTheFile) {
  for (const std::string& name : manifest()) {
    const RasterVector v = parse_raster_vector(read_text(kVectorDir + name), name);
    RasterVector again = v;
    canonicalize_raster_vector(&again);  // the file's triangles are already the decoded memory form
    for (size_t c = 0; c < v.clusters.size(); ++c) {
      EXPECT_EQ(again.clusters[c].positions, v.clusters[c].positions) << name << " cluster " << c;
      EXPECT_EQ(again.clusters[c].indices, v.clusters[c].indices) << name << " cluster " << c;
    }
    for (RasterPath path : {RasterPath::kReference, RasterPath::kMicropoly, RasterPath::kScanline, RasterPath::kAuto}) {
      VisBuffer vis;
      vis.resize(v.width, v.height);
      RasterOptions options;
      options.path = path;
      options.cull_backfaces = v.cull_backfaces;
      options.z_near = v.z_near;
      for (uint32_t c = 0; c < v.clusters.size(); ++c)
        rasterize_cluster(vis, v.clusters[c].positions.data(), uint32_t(v.clusters[c].positions.size() / 3),
                          v.clusters[c].indices.data(), uint32_t(v.clusters[c].indices.size() / 3), v.object_to_clip, c,
                          options, nullptr);
      uint64_t covered = 0;
      for (uint64_t k : v.keys) covered += k != 0;
      EXPECT_GT(covered, 0u) << name;
      EXPECT_EQ(vis.keys, v.keys) << name << " path " << int(path);
    }
  }
}

// Vector i is mesh and instance i of one scene, so two renderers (one per mode) serve all.
GpuRasterInput vector_input(const std::vector<RasterVector>& all, uint32_t i) {
  const RasterVector& v = all[i];
  GpuRasterInput in;
  for (uint32_t k = 0; k < all.size(); ++k) {
    in.object_to_clip.push_back(all[k].object_to_clip);
    in.instance_mesh.push_back(k);
    in.instance_scale.push_back(1.0f);
  }
  for (uint32_t c = 0; c < v.clusters.size(); ++c) in.visible.push_back({i, c});
  in.width = v.width;
  in.height = v.height;
  in.z_near = v.z_near;
  in.cull_backfaces = v.cull_backfaces;
  return in;
}

TEST(RasterVectors, ComputeBitIdenticalAndHardwareKeepsTheRule) {
  auto gpu = testing::make_test_gpu();
  ASSERT_TRUE(gpu);
  const std::vector<std::string> names = manifest();
  std::vector<RasterVector> vectors;
  RenderScene scene;
  for (const std::string& name : names) {
    vectors.push_back(parse_raster_vector(read_text(kVectorDir + name), name));
    RenderScene one = raster_vector_scene(vectors.back());
    scene.meshes.push_back(std::move(one.meshes[0]));
    scene.instances.push_back({uint32_t(scene.instances.size()), Mat4d{}});
    scene.materials = one.materials;
  }
  const MemoryFormScene ms = make_memory_form_scene(scene);
  GpuRendererOptions sw_options, hw_options;
  sw_options.raster = GpuRasterMode::kSw;
  hw_options.raster = GpuRasterMode::kHw;
  GpuRendererPtr sw = create_gpu_renderer(*gpu, ms, kDefaultGpuTraversal, sw_options);
  GpuRendererPtr hw = create_gpu_renderer(*gpu, ms, kDefaultGpuTraversal, hw_options);
  for (uint32_t i = 0; i < vectors.size(); ++i) {
    const RasterVector& v = vectors[i];
    const std::string& name = names[i];
    const GpuRasterInput in = vector_input(vectors, i);
    GpuRasterOutput sw_out;
    raster_visible_vulkan(*sw, in, &sw_out);
    EXPECT_EQ(sw_out.vis.keys, v.keys) << name << ": compute rasterizer";
    GpuRasterOutput hw_out;
    raster_visible_vulkan(*hw, in, &hw_out);
    EXPECT_EQ(hw_out.split.hw_clusters, v.clusters.size()) << name;
    HwRasterAgreement agreement;
    uint64_t mask_pixels = 0;
    for (uint32_t y = 0; y < v.height; ++y)
      for (uint32_t x = 0; x < v.width; ++x) {
        const size_t p = size_t(y) * v.width + x;
        const uint64_t ref = v.keys[p], got = hw_out.vis.keys[p];
        mask_pixels += v.mask[p] != 0;
        ModelTriangle ref_t, got_t;
        if (ref) ref_t = raster_vector_triangle(v, vis_key_cluster(ref), vis_key_triangle(ref));
        if (got) got_t = raster_vector_triangle(v, vis_key_cluster(got), vis_key_triangle(got));
        const bool same = ref && got && uint32_t(ref) == uint32_t(got);
        const HwPixel kind = classify_hw_pixel(ref, got, same, ref ? &ref_t : nullptr, got ? &got_t : nullptr, x, y);
        ++agreement.pixels[int(kind)];
        EXPECT_TRUE(hw_pixel_ok(kind)) << name << " pixel " << x << "," << y << ": " << hw_pixel_name(kind) << " ref "
                                       << std::hex << ref << " hw " << got << std::dec;
        // Every accepted difference lies inside the file's mask.
        if (kind == HwPixel::kAmbiguousDepth) {
          EXPECT_TRUE(v.mask[p] & kRasterMaskDepth) << name << " " << x << "," << y;
        }
        if (kind == HwPixel::kAmbiguousClipCoverage) {
          EXPECT_TRUE(v.mask[p] & kRasterMaskClipEdge) << name << " " << x << "," << y;
        }
        if (kind == HwPixel::kAmbiguousSnapCoverage) {
          EXPECT_TRUE((v.mask[p] & kRasterMaskEdge) && !v.exact_transform) << name << " " << x << "," << y;
        }
      }
    std::printf("%-18s mask %3llu px; hw: identical %3llu depth-only %3llu ambiguous depth %llu clip %llu snap %llu\n",
                name.c_str(), (unsigned long long)mask_pixels, (unsigned long long)agreement.count(HwPixel::kIdentical),
                (unsigned long long)agreement.count(HwPixel::kDepthOnly),
                (unsigned long long)agreement.count(HwPixel::kAmbiguousDepth),
                (unsigned long long)agreement.count(HwPixel::kAmbiguousClipCoverage),
                (unsigned long long)agreement.count(HwPixel::kAmbiguousSnapCoverage));
  }
  testing::expect_no_validation_messages(*gpu);
}

TEST(RasterVectors, MalformedFileIsACodedError) {
  std::string text = read_text(kVectorDir + "fan.txt");
  for (const std::string& broken : {std::string("nonsense\n"), text.substr(0, text.size() / 2),
                                    std::string(text).replace(text.find("viewport 16 16"), 14, "viewport 0 16")}) {
    try {
      parse_raster_vector(broken, "broken.txt");
      ADD_FAILURE() << "accepted a malformed vector";
    } catch (const VgeoError& e) {
      EXPECT_EQ(e.error().code, "RASTER_VECTOR_PARSE");
    }
  }
}

}  // namespace
}  // namespace vgeo
