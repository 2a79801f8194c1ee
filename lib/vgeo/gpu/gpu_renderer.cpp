// The Vulkan renderer of an in-memory scene (gpu_frame.h): pipelines, the scene's pages,
// cluster locations, mesh and material records uploaded once (spec/gpu.md §Geometry).
#include "vgeo/gpu/gpu_renderer.h"

#include <algorithm>

#include "vgeo/core/error.h"
#include "vgeo/gpu/shaders.h"

namespace vgeo {

using namespace gpu_detail;

void GpuRendererDeleter::operator()(GpuRenderer* r) const { delete r; }

namespace gpu_detail {

void ensure_size(GpuContext& gpu, GpuBuffer& buffer, uint64_t bytes) {
  if (buffer.buffer == VK_NULL_HANDLE || buffer.size < bytes) buffer = create_gpu_buffer(gpu, bytes);
}

void check_buffer_range(const GpuContext& gpu, uint64_t bytes, const char* what) {
  if (bytes > gpu.properties.limits.maxStorageBufferRange)
    fail("GPU_SCENE_TOO_LARGE", gpu.device_name,
         std::string(what) + " needs " + std::to_string(bytes) + " bytes, more than one storage buffer (" +
             std::to_string(gpu.properties.limits.maxStorageBufferRange) + ")",
         kExitUsage);
}

GpuRendererPtr create_renderer_common(GpuContext& gpu, const RenderScene& scene, GpuTraversal traversal,
                                      const GpuRendererOptions& options) {
  GpuRendererPtr r(new GpuRenderer);
  r->gpu = &gpu;
  r->traversal = traversal;
  r->options = options;
  r->cull = create_cull_pipelines(gpu);
  r->cull_meshes = upload_cull_meshes(gpu, scene.meshes);
  r->recorder = create_gpu_recorder(gpu);
  r->raster = create_gpu_raster_passes(gpu, cluster_raster_infos(scene));
  r->shade = create_compute_pipeline(gpu, kShaderShade, kShadeBindingCount, sizeof(GpuShadeParams));
  r->shadow_mark = create_compute_pipeline(gpu, kShaderShadowMark, kMarkBindingCount, sizeof(GpuShadeParams));
  r->shadow_cull = create_compute_pipeline(gpu, kShaderShadowCull, kShadowCullBindingCount, sizeof(GpuShadowCullPush));
  r->counters = create_gpu_buffer(gpu, 64);
  std::vector<GpuMaterial> materials(scene.materials.size());
  for (size_t i = 0; i < materials.size(); ++i)
    std::copy(scene.materials[i].base_color.begin(), scene.materials[i].base_color.end(), materials[i].base_color);
  r->materials = upload(gpu, materials);
  return r;
}

GpuMesh gpu_mesh(const MeshQuantization& q, uint32_t first_location, uint32_t material_offset) {
  GpuMesh g{};
  g.first_location = first_location;
  g.position_step_log2 = q.position_step_log2;
  g.channel_count = q.channel_count();
  g.normal_bits = q.has_normals ? q.normal_bits : 0;
  g.material_offset = material_offset;
  return g;
}

void place_in_memory_pages(const RenderScene& scene, const MemoryFormPages& in_memory, const std::vector<bool>& drawn,
                           uint64_t first_word, std::vector<uint32_t>* words, std::vector<GpuMesh>* meshes,
                           std::vector<GpuClusterLocation>* locations) {
  if (in_memory.cluster_page.size() != scene.meshes.size())
    fail("GPU_ERROR", "vulkan", "the memory form has " + std::to_string(in_memory.cluster_page.size()) +
                                    " meshes, the scene " + std::to_string(scene.meshes.size()), kExitInternal);
  std::vector<uint32_t> page_word(in_memory.pages.size());
  uint64_t word = first_word;
  for (size_t p = 0; p < in_memory.pages.size(); ++p) {
    page_word[p] = uint32_t(std::min<uint64_t>(word, UINT32_MAX));
    word += in_memory.pages[p].size();
  }
  words->reserve(word - first_word);
  for (const std::vector<uint32_t>& page : in_memory.pages) words->insert(words->end(), page.begin(), page.end());
  for (size_t m = 0; m < scene.meshes.size(); ++m) {
    if (!drawn[m]) continue;
    if (in_memory.cluster_page[m].size() != scene.meshes[m].clusters.size())
      fail("GPU_ERROR", "vulkan", "scene mesh " + std::to_string(m) + " has no memory form", kExitInternal);
    (*meshes)[m] = gpu_mesh(in_memory.quantization[m], (*meshes)[m].first_location, in_memory.material_offset[m]);
    for (size_t c = 0; c < in_memory.cluster_page[m].size(); ++c) {
      const auto& [page, index] = in_memory.cluster_page[m][c];
      (*locations)[(*meshes)[m].first_location + c] = {page_word[page], index};
    }
  }
}

std::vector<GpuMesh> mesh_records(const RenderScene& scene, uint64_t* location_count) {
  std::vector<GpuMesh> meshes(scene.meshes.size());
  uint64_t locations = 0;
  for (size_t m = 0; m < scene.meshes.size(); ++m) {
    meshes[m].first_location = uint32_t(locations);
    locations += scene.meshes[m].clusters.size();
  }
  *location_count = locations;
  return meshes;
}

}  // namespace gpu_detail

std::vector<GpuClusterRasterInfo> cluster_raster_infos(const RenderScene& scene) {
  std::vector<GpuClusterRasterInfo> infos;
  for (const ClusterDag& dag : scene.meshes)
    for (const DagCluster& c : dag.clusters) {
      GpuClusterRasterInfo info{};
      info.center[0] = c.bounds.center.x;
      info.center[1] = c.bounds.center.y;
      info.center[2] = c.bounds.center.z;
      info.radius = c.bounds.radius;
      info.triangle_count = c.triangle_count;
      infos.push_back(info);
    }
  return infos;
}

GpuRendererPtr create_gpu_renderer(GpuContext& gpu, const RenderScene& scene, const MemoryFormPages& pages,
                                   GpuTraversal traversal, const GpuRendererOptions& options) {
  GpuRendererPtr r = create_renderer_common(gpu, scene, traversal, options);
  uint64_t location_count = 0;
  std::vector<GpuMesh> meshes = mesh_records(scene, &location_count);
  std::vector<GpuClusterLocation> locations(location_count);
  std::vector<uint32_t> words;
  place_in_memory_pages(scene, pages, std::vector<bool>(scene.meshes.size(), true), 0, &words, &meshes, &locations);
  check_buffer_range(gpu, words.size() * 4, "the memory-form pages");
  r->pages = upload(gpu, words);
  r->locations = upload(gpu, locations);
  r->meshes = upload(gpu, meshes);
  return r;
}

GpuRendererPtr create_gpu_renderer(GpuContext& gpu, const MemoryFormScene& scene, GpuTraversal traversal,
                                   const GpuRendererOptions& options) {
  return create_gpu_renderer(gpu, scene.scene, scene.pages, traversal, options);
}

std::vector<uint32_t> gpu_page_words(const GpuRenderer& r) {
  const uint32_t* words = static_cast<const uint32_t*>(r.pages.mapped);
  return std::vector<uint32_t>(words, words + r.pages.size / 4);
}

}  // namespace vgeo
