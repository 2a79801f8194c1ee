// Where the GPU's geometry comes from (spec/gpu.md §Geometry, spec/raster.md §Backends agree):
// the scene's own encodings. A page file written with non-default format options is drawn
// from its own pages (its quantization, its page size), a built mesh from its one encoding;
// the CPU reference draws the decode of the same bytes, and the two agree.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <set>

#include "gpu/gpu_testing.h"
#include "render/stream_fixture.h"
#include "vgeo/core/file_io.h"
#include "vgeo/core/hash.h"
#include "vgeo/format/decode_hash.h"
#include "vgeo/gpu/backend_run.h"
#include "vgeo/gpu/gpu_frame.h"
#include "vgeo/mesh/generate.h"

namespace vgeo {
namespace {

// FNV-1a over the pages scene mesh `m` is drawn from, in page order: spec/format.md §9's
// memory hash when the mesh is the only one of its encoding.
uint64_t drawn_pages_hash(const MemoryFormPages& pages, size_t m) {
  std::set<uint32_t> used;
  for (const auto& [page, index] : pages.cluster_page[m]) used.insert(page);
  uint64_t h = kFnvOffset;
  for (uint32_t p : used) h = fnv1a64(pages.pages[p].data(), pages.pages[p].size() * 4, h);
  return h;
}

// A mesh built at load (procedural) and one from a page file with non-default quantization,
// page size and material, side by side.
struct MixedScene {
  std::string dir, page_file;
  std::vector<uint8_t> file_bytes;
  SceneFile scene;
};
MixedScene mixed_scene() {
  MixedScene s;
  s.dir = ::testing::TempDir() + "/vgeo_gpu_memory_form_" + std::to_string(::getpid());
  std::filesystem::create_directories(s.dir);
  GenerateOptions gen;
  gen.shape = GenShape::kSphere;
  gen.target_triangles = 2000;
  gen.seed = 3;
  Mesh mesh = generate_mesh(gen);
  mesh.materials.assign(mesh.triangle_count(), 0);
  BuiltScene built;
  built.meshes.push_back(build_dag(mesh, {}));
  built.materials.push_back(Material{"red", {0.9f, 0.15f, 0.1f, 1.0f}});
  FormatOptions odd;  // none of `vgeo build`'s defaults (memory_form_options)
  odd.position_bits = 9;
  odd.position_step_from_lod_error = false;
  odd.normal_bits = 5;
  odd.page_size = kMinPageSize;
  odd.zstd_level = 1;
  s.page_file = s.dir + "/odd.vgp";
  write_asset_file(s.page_file, built, AssetFileKind::kPages, odd);
  s.file_bytes = read_file(s.page_file);
  const std::string json =
      R"({"version": 1, "meshes": [{"procedural": {"shape": "sphere", "triangles": 600, "seed": 5}}, {"dag": "odd.vgp"}],
      "instances": [{"mesh": 0, "translation": [-1.1, 0, 0]}, {"mesh": 1, "translation": [1.1, 0, 0]}],
      "cameras": [{"position": [0, 0.6, 4], "look_at": [0, 0, 0], "resolution": [96, 64]}]})";
  s.scene = parse_scene_json(json, "<test>", s.dir, {});
  return s;
}

TEST(GpuMemoryForm, PageFileWithNonDefaultOptionsIsDrawnFromItsOwnPages) {
  const MixedScene s = mixed_scene();
  const SceneFile& sf = s.scene;
  ASSERT_EQ(sf.mesh_forms.size(), 2u);
  ASSERT_EQ(sf.encodings.size(), 2u);
  // Mesh 1 is the page file's: its encoding is the file's bytes, its CPU mesh their decode
  // (materials offset past the scene's one), the GPU's pages their memory form.
  const SceneMeshForm& form = sf.mesh_forms[1];
  ASSERT_NE(form.encoding, kNone);
  EXPECT_EQ(sf.encodings[form.encoding].bytes, s.file_bytes);
  EXPECT_EQ(form.material_offset, 1u);
  const BuiltScene file = decode_format(s.file_bytes.data(), s.file_bytes.size(), s.page_file);
  EXPECT_EQ(sf.scene.meshes[1].positions, file.meshes[0].positions);
  EXPECT_EQ(sf.scene.meshes[1].normals, file.meshes[0].normals);
  std::vector<uint32_t> materials = file.meshes[0].triangle_materials;
  for (uint32_t& t : materials) t += 1;
  EXPECT_EQ(sf.scene.meshes[1].triangle_materials, materials);
  const MemoryFormPages pages = memory_form_pages(sf);
  EXPECT_EQ(drawn_pages_hash(pages, 1), memory_form_hash(s.file_bytes.data(), s.file_bytes.size(), s.page_file));
  const FormatContainer fc = parse_container(s.file_bytes.data(), s.file_bytes.size(), s.page_file);
  EXPECT_EQ(pages.quantization[1].position_step_log2, fc.meshes[0].quantization.position_step_log2);
  EXPECT_EQ(pages.quantization[1].normal_bits, 5u);
  EXPECT_EQ(pages.material_offset[1], 1u);
  // Not vacuous: encoding the decoded mesh again with the defaults (what the GPU drew before)
  // gives another grid and other pages.
  BuiltScene again;
  again.meshes.push_back(sf.scene.meshes[1]);
  const SceneEncoding reencoded = encode_memory_form(again, "<again>", nullptr);
  EXPECT_NE(reencoded.container.meshes[0].quantization.position_step_log2, fc.meshes[0].quantization.position_step_log2);
  EXPECT_GT(fc.pages.size(), 1u);  // the 16 KiB pages: several

  // Mesh 0 was built at load: one encoding, whose decode is the CPU's mesh and whose memory
  // form is the GPU's pages (both from those bytes: nothing encoded twice).
  const SceneEncoding& built = sf.encodings[sf.mesh_forms[0].encoding];
  EXPECT_EQ(sf.scene.meshes[0].positions, decode_format(built.bytes.data(), built.bytes.size(), "<built>").meshes[0].positions);
  EXPECT_EQ(drawn_pages_hash(pages, 0), memory_form_hash(built.bytes.data(), built.bytes.size(), "<built>"));

  // The GPU reads exactly those pages, and draws what the CPU draws (with the file's material).
  auto gpu = testing::make_test_gpu();
  ASSERT_TRUE(gpu);
  {
    GpuRendererPtr renderer = create_gpu_renderer(*gpu, sf.scene, pages);
    std::vector<uint32_t> all;
    for (const std::vector<uint32_t>& p : pages.pages) all.insert(all.end(), p.begin(), p.end());
    EXPECT_EQ(gpu_page_words(*renderer), all);
  }
  RenderRequest vk;
  vk.backend = Backend::kVulkan;
  vk.compare_cpu = true;
  vk.threads = 2;
  const RenderReport r = run_backend(sf, vk, {gpu.get(), &pages});
  ASSERT_EQ(r.comparisons.size(), 1u);
  EXPECT_TRUE(r.rule_holds) << r.table();
  EXPECT_EQ(r.comparisons[0].vis_pixels_differing, 0u) << r.table();
  EXPECT_GT(r.frames[0].pixels_covered, 0u);
  testing::expect_no_validation_messages(*gpu);
  std::filesystem::remove_all(s.dir);
}

// A streamed scene with a mesh not from a page file (spec/gpu.md §Streaming): the streamed
// mesh's pages go through the GPU pool, the other's are placed once after it; the rule holds
// on every frame.
TEST(GpuMemoryForm, StreamedSceneWithABuiltMeshKeepsTheRule) {
  const test::StreamFixture& f = test::stream_fixture();
  SceneLoadOptions options;
  options.stream.emplace();
  options.stream->budget_bytes = f.pinned + (f.total - f.pinned) / 8;
  options.stream->loader.asynchronous = false;
  const std::string json =
      R"({"version": 1, "meshes": [{"dag": "meshes.vgp", "index": 0}, {"procedural": {"shape": "sphere", "triangles": 600}}],
      "instances": [{"mesh": 0, "translation": [-1, 0, -3]}, {"mesh": 1, "translation": [1, 0, -3]}],
      "cameras": [{"position": [0, 0.5, 6], "look_at": [0, 0, -3], "resolution": [96, 72]}],
      "camera_path": {"frames": 3, "keyframes": [{"position": [0, 0.5, 6], "look_at": [0, 0, -3]},
                                                {"position": [0.2, 0.4, 0], "look_at": [0, 0, -3]}]}})";
  const SceneFile sf = parse_scene_json(json, "<test>", f.dir, options);
  ASSERT_TRUE(sf.streaming) << sf.stream_reason;
  EXPECT_EQ(sf.mesh_forms[0].encoding, kNone);
  ASSERT_NE(sf.mesh_forms[1].encoding, kNone);
  auto gpu = testing::make_test_gpu();
  ASSERT_TRUE(gpu);
  RenderRequest vk;
  vk.backend = Backend::kVulkan;
  vk.compare_cpu = true;
  vk.threads = 2;
  const RenderReport r = run_backend(sf, vk, {gpu.get(), nullptr});
  ASSERT_EQ(r.comparisons.size(), 3u);
  EXPECT_TRUE(r.rule_holds) << r.table();
  for (const FrameComparison& c : r.comparisons) EXPECT_EQ(c.vis_pixels_differing, 0u) << r.table();
  EXPECT_GT(r.pool.pages_uploaded, 0u);
  EXPECT_GT(r.frames.back().pixels_covered, 0u);
  testing::expect_no_validation_messages(*gpu);
}

}  // namespace
}  // namespace vgeo
