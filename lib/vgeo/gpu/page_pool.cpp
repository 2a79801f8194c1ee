// The GPU page pool of a streamed scene (gpu_frame.h, spec/gpu.md §Streaming): a fixed pool of
// slots, each the size of the largest memory-form page, mirroring the Streamer's residency;
// the pages of meshes not streamed follow the pool, placed once.
// Based on: Karis et al., "Nanite: A Deep Dive", SIGGRAPH 2021, §"Paging" (fixed-size GPU page
// slots the streamer fills and frees).
#include <algorithm>
#include <cassert>
#include <functional>

#include "vgeo/core/error.h"
#include "vgeo/gpu/gpu_renderer.h"
#include "vgeo/render/streaming.h"

namespace vgeo {

using namespace gpu_detail;

namespace {

// The most pages `budget` bytes can hold at once: the count of the smallest pages whose
// sizes sum to ≤ budget (the Streamer keeps resident + in-flight bytes ≤ budget).
uint32_t max_resident_pages(const FormatContainer& c, uint64_t budget) {
  std::vector<uint32_t> sizes;
  for (const PageEntry& e : c.pages) sizes.push_back(e.memory_size);
  std::sort(sizes.begin(), sizes.end());
  uint64_t sum = 0;
  uint32_t n = 0;
  while (n < sizes.size() && sum + sizes[n] <= budget) sum += sizes[n++];
  return n;
}

}  // namespace

namespace gpu_detail {

void sync_page_pool(GpuRenderer& r, const FrameStreaming& s) {
  const Streamer& streamer = *s.streamer;
  const FormatContainer& c = streamer.container();
  for (uint32_t p = 0; p < c.pages.size(); ++p)
    if (r.slot_of_page[p] != kNone && streamer.page_state(p) != PageState::kResident) {
      r.free_slots.push_back(r.slot_of_page[p]);
      r.slot_of_page[p] = kNone;
      ++r.pool_stats.pages_freed;
    }
  std::sort(r.free_slots.begin(), r.free_slots.end(), std::greater<>());
  GpuClusterLocation* locations = r.locations.data<GpuClusterLocation>();
  const GpuMesh* meshes = r.meshes.data<GpuMesh>();
  for (uint32_t p = 0; p < c.pages.size(); ++p) {
    if (r.slot_of_page[p] != kNone || streamer.page_state(p) != PageState::kResident) continue;
    if (r.free_slots.empty())
      fail("GPU_ERROR", "vulkan", "GPU page pool full: the Streamer holds more pages than its budget allows",
           kExitInternal);
    const uint32_t slot = r.free_slots.back();
    r.free_slots.pop_back();
    r.slot_of_page[p] = slot;
    const std::vector<uint32_t>& words = streamer.page_words(p);
    assert(words.size() <= r.slot_words);
    const uint32_t page_word = slot * r.slot_words;
    std::memcpy(r.pages.data<uint32_t>() + page_word, words.data(), words.size() * 4);
    ++r.pool_stats.pages_uploaded;
    r.pool_stats.bytes_uploaded += words.size() * 4;
    const PageEntry& e = c.pages[p];
    const MeshMetadata& mm = c.meshes[e.mesh];
    for (uint32_t m = 0; m < s.stream_mesh.size(); ++m) {
      if (s.stream_mesh[m] != e.mesh) continue;
      for (uint32_t k = 0; k < e.cluster_count; ++k) {
        const uint32_t cluster = mm.page_clusters[e.first_cluster_slot + k];
        locations[meshes[m].first_location + cluster] = {page_word, k};
      }
    }
  }
}

}  // namespace gpu_detail

GpuRendererPtr create_gpu_renderer_streamed(GpuContext& gpu, const RenderScene& scene, const FrameStreaming& s,
                                            const MemoryFormPages& in_memory, GpuTraversal traversal,
                                            const GpuRendererOptions& options) {
  const FormatContainer& c = s.streamer->container();
  GpuRendererPtr r = create_renderer_common(gpu, scene, traversal, options);
  r->streamed = true;
  uint32_t max_page = 0;
  for (const PageEntry& e : c.pages) max_page = std::max(max_page, e.memory_size);
  r->slot_words = (max_page + 3) / 4;
  const uint32_t slots = max_resident_pages(c, s.streamer->budget_bytes());
  const uint64_t pool_bytes = uint64_t(slots) * r->slot_words * 4;
  r->slot_of_page.assign(c.pages.size(), kNone);
  for (uint32_t k = slots; k-- > 0;) r->free_slots.push_back(k);
  r->pool_stats.slots = slots;
  r->pool_stats.pool_bytes = pool_bytes;

  // Streamed meshes' locations are written when their pages are installed (read only once
  // resident); the other meshes' pages follow the pool, placed once.
  uint64_t location_count = 0;
  std::vector<GpuMesh> meshes = mesh_records(scene, &location_count);
  std::vector<GpuClusterLocation> locations(location_count);
  std::vector<bool> in_memory_mesh(scene.meshes.size());
  for (uint32_t m = 0; m < scene.meshes.size(); ++m) {
    in_memory_mesh[m] = s.stream_mesh[m] == kNone;
    if (!in_memory_mesh[m])
      meshes[m] = gpu_mesh(c.meshes[s.stream_mesh[m]].quantization, meshes[m].first_location, s.material_offset[m]);
  }
  std::vector<uint32_t> fixed_words;
  place_in_memory_pages(scene, in_memory, in_memory_mesh, pool_bytes / 4, &fixed_words, &meshes, &locations);
  const uint64_t page_bytes = pool_bytes + fixed_words.size() * 4;
  check_buffer_range(gpu, page_bytes, "the GPU page pool and the pages of meshes not streamed");
  r->pages = create_gpu_buffer(gpu, std::max<uint64_t>(page_bytes, 4));
  if (!fixed_words.empty()) std::memcpy(r->pages.data<uint32_t>() + pool_bytes / 4, fixed_words.data(), fixed_words.size() * 4);
  r->meshes = upload(gpu, meshes);
  r->locations = upload(gpu, locations);
  return r;
}

const GpuPoolStats& gpu_pool_stats(const GpuRenderer& r) { return r.pool_stats; }

}  // namespace vgeo
