// GPU raster passes: compute SW, hardware pipeline, per-cluster split (hw_raster.h,
// spec/raster.md §13).
// Based on: Karis et al., "Nanite: A Deep Dive", SIGGRAPH 2021, §"Software Rasterization",
// §"How to depth test?" (64-bit atomic max of depth and ids into the visibility buffer) and
// §"Hardware Rasterization" (large triangles to the fixed-function rasterizer).
#include "vgeo/gpu/hw_raster.h"

#include <algorithm>
#include <cassert>
#include <cstring>

#include "vgeo/core/error.h"
#include "vgeo/gpu/shader_records.h"
#include "vgeo/gpu/shaders.h"

namespace vgeo {

bool parse_gpu_raster_mode(const std::string& name, GpuRasterMode* out) {
  if (name == "sw") *out = GpuRasterMode::kSw;
  else if (name == "hw") *out = GpuRasterMode::kHw;
  else if (name == "auto") *out = GpuRasterMode::kAuto;
  else return false;
  return true;
}

const char* gpu_raster_mode_name(GpuRasterMode mode) {
  switch (mode) {
    case GpuRasterMode::kSw: return "sw";
    case GpuRasterMode::kHw: return "hw";
    case GpuRasterMode::kAuto: return "auto";
  }
  return "?";
}

namespace {

// The graphics pipeline's set: raster.comp's first kHwRasterBindingCount bindings (the vertex
// stage reads the geometry, the fragment stage writes the visibility buffer and counters).
constexpr uint32_t kHwBindings = kHwRasterBindingCount;
constexpr VkShaderStageFlags kHwStages = VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT;

VkShaderModule make_module(GpuContext& c, const ShaderBinary& shader) {
  auto info = vk_struct<VkShaderModuleCreateInfo>(VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO);
  info.codeSize = shader.word_count * 4;
  info.pCode = shader.words;
  VkShaderModule module = VK_NULL_HANDLE;
  check_vk(vkCreateShaderModule(c.device, &info, nullptr, &module), shader.name);
  return module;
}

// A hardware raster pipeline: no vertex input (the vertex shader fetches), triangle lists,
// no attachments (dynamic rendering with zero formats), viewport/scissor/cull mode dynamic;
// `binding_count` storage buffers visible to both stages.
void create_hw_pipeline(GpuContext& c, uint32_t binding_count, const ShaderBinary& vert_shader,
                        const ShaderBinary& frag_shader, VkDescriptorSetLayout* set_layout, VkPipelineLayout* layout,
                        VkPipeline* pipeline) {
  std::vector<VkDescriptorSetLayoutBinding> bindings(binding_count);
  for (uint32_t i = 0; i < binding_count; ++i) bindings[i] = {i, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, kHwStages, nullptr};
  auto set_info = vk_struct<VkDescriptorSetLayoutCreateInfo>(VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO);
  set_info.bindingCount = binding_count;
  set_info.pBindings = bindings.data();
  check_vk(vkCreateDescriptorSetLayout(c.device, &set_info, nullptr, set_layout), "vkCreateDescriptorSetLayout");
  VkPushConstantRange range{kHwStages, 0, sizeof(GpuRasterParams)};
  auto layout_info = vk_struct<VkPipelineLayoutCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO);
  layout_info.setLayoutCount = 1;
  layout_info.pSetLayouts = set_layout;
  layout_info.pushConstantRangeCount = 1;
  layout_info.pPushConstantRanges = &range;
  check_vk(vkCreatePipelineLayout(c.device, &layout_info, nullptr, layout), "vkCreatePipelineLayout");

  VkShaderModule vert = make_module(c, vert_shader), frag = make_module(c, frag_shader);
  VkPipelineShaderStageCreateInfo stages[2] = {vk_struct<VkPipelineShaderStageCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO),
                                               vk_struct<VkPipelineShaderStageCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO)};
  stages[0].stage = VK_SHADER_STAGE_VERTEX_BIT;
  stages[0].module = vert;
  stages[0].pName = "main";
  stages[1].stage = VK_SHADER_STAGE_FRAGMENT_BIT;
  stages[1].module = frag;
  stages[1].pName = "main";
  auto vertex_input = vk_struct<VkPipelineVertexInputStateCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_VERTEX_INPUT_STATE_CREATE_INFO);
  auto assembly = vk_struct<VkPipelineInputAssemblyStateCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_INPUT_ASSEMBLY_STATE_CREATE_INFO);
  assembly.topology = VK_PRIMITIVE_TOPOLOGY_TRIANGLE_LIST;
  auto viewport = vk_struct<VkPipelineViewportStateCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_VIEWPORT_STATE_CREATE_INFO);
  viewport.viewportCount = 1;
  viewport.scissorCount = 1;
  auto raster = vk_struct<VkPipelineRasterizationStateCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_RASTERIZATION_STATE_CREATE_INFO);
  raster.polygonMode = VK_POLYGON_MODE_FILL;
  // Vulkan's area sign is computed in y-down framebuffer coordinates with a leading minus
  // (a = −½ Σ x_i y_{i+1} − x_{i+1} y_i), so a > 0 ("counter-clockwise") is exactly
  // raster.cpp's front face, area < 0 (spec/raster.md §2).
  raster.frontFace = VK_FRONT_FACE_COUNTER_CLOCKWISE;
  raster.cullMode = VK_CULL_MODE_BACK_BIT;  // dynamic (vkCmdSetCullMode)
  raster.lineWidth = 1.0f;
  auto multisample = vk_struct<VkPipelineMultisampleStateCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_MULTISAMPLE_STATE_CREATE_INFO);
  multisample.rasterizationSamples = VK_SAMPLE_COUNT_1_BIT;
  const VkDynamicState dynamic_states[] = {VK_DYNAMIC_STATE_VIEWPORT, VK_DYNAMIC_STATE_SCISSOR, VK_DYNAMIC_STATE_CULL_MODE};
  auto dynamic = vk_struct<VkPipelineDynamicStateCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_DYNAMIC_STATE_CREATE_INFO);
  dynamic.dynamicStateCount = 3;
  dynamic.pDynamicStates = dynamic_states;
  auto rendering = vk_struct<VkPipelineRenderingCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_RENDERING_CREATE_INFO);  // no attachments
  auto info = vk_struct<VkGraphicsPipelineCreateInfo>(VK_STRUCTURE_TYPE_GRAPHICS_PIPELINE_CREATE_INFO);
  info.pNext = &rendering;
  info.stageCount = 2;
  info.pStages = stages;
  info.pVertexInputState = &vertex_input;
  info.pInputAssemblyState = &assembly;
  info.pViewportState = &viewport;
  info.pRasterizationState = &raster;
  info.pMultisampleState = &multisample;
  info.pDynamicState = &dynamic;
  info.layout = *layout;
  VkResult r = vkCreateGraphicsPipelines(c.device, VK_NULL_HANDLE, 1, &info, nullptr, pipeline);
  vkDestroyShaderModule(c.device, vert, nullptr);
  vkDestroyShaderModule(c.device, frag, nullptr);
  check_vk(r, vert_shader.name);
}

// Shader writes of `src` stages become visible to the `dst` stages' `access`.
void barrier(GpuRecorder& rec, VkPipelineStageFlags2 src, VkPipelineStageFlags2 dst, VkAccessFlags2 access) {
  auto b = vk_struct<VkMemoryBarrier2>(VK_STRUCTURE_TYPE_MEMORY_BARRIER_2);
  b.srcStageMask = src;
  b.srcAccessMask = VK_ACCESS_2_SHADER_WRITE_BIT;
  b.dstStageMask = dst;
  b.dstAccessMask = access;
  auto dep = vk_struct<VkDependencyInfo>(VK_STRUCTURE_TYPE_DEPENDENCY_INFO);
  dep.memoryBarrierCount = 1;
  dep.pMemoryBarriers = &b;
  vkCmdPipelineBarrier2(rec.commands, &dep);
}

// The hardware draw: one dynamic-rendering pass with no attachments over the viewport.
void record_hw_draw(GpuRecorder& rec, GpuRasterPasses& p, const GpuRasterBuffers& b, const GpuRasterParams& params,
                    uint32_t max_draws) {
  std::vector<GpuBinding> bindings = geometry_bindings(b.geometry);
  bindings.push_back({kRasterBindCounters, b.counters});
  VkDescriptorSet set = storage_buffer_set(rec, p.hw_set_layout, gpu_bindings(kHwBindings, bindings));

  auto rendering = vk_struct<VkRenderingInfo>(VK_STRUCTURE_TYPE_RENDERING_INFO);
  rendering.renderArea = {{0, 0}, {params.width, params.height}};
  rendering.layerCount = 1;
  vkCmdBeginRendering(rec.commands, &rendering);
  vkCmdBindPipeline(rec.commands, VK_PIPELINE_BIND_POINT_GRAPHICS, p.hw);
  vkCmdBindDescriptorSets(rec.commands, VK_PIPELINE_BIND_POINT_GRAPHICS, p.hw_layout, 0, 1, &set, 0, nullptr);
  vkCmdPushConstants(rec.commands, p.hw_layout, kHwStages, 0, sizeof params, &params);
  const VkViewport viewport{0.0f, 0.0f, float(params.width), float(params.height), 0.0f, 1.0f};
  const VkRect2D scissor{{0, 0}, {params.width, params.height}};
  vkCmdSetViewport(rec.commands, 0, 1, &viewport);
  vkCmdSetScissor(rec.commands, 0, 1, &scissor);
  vkCmdSetCullMode(rec.commands, params.cull_backfaces ? VK_CULL_MODE_BACK_BIT : VK_CULL_MODE_NONE);
  vkCmdDrawIndirectCount(rec.commands, p.commands.buffer, 0, p.split_counters.buffer,
                         offsetof(GpuRasterSplitCounters, hw_draw_count), max_draws, sizeof(GpuDrawCommand));
  vkCmdEndRendering(rec.commands);
}

// The compute rasterizer's push constants of a request (the cluster pass; groups_x and the
// tile fields are the caller's).
GpuRasterParams sw_params(const GpuRasterRequest& q) {
  GpuRasterParams params{};
  params.width = q.width;
  params.height = q.height;
  params.first_visible = q.first_visible;
  params.visible_count = q.visible_count;
  params.cull_backfaces = q.cull_backfaces ? 1u : 0u;
  params.z_near = q.z_near;
  params.select_path = q.mode == GpuRasterMode::kSw ? 0u : 1u;
  return params;
}

// raster.glsl's bindings.
std::vector<const GpuBuffer*> sw_buffers(const GpuRasterPasses& p, const GpuRasterBuffers& b) {
  std::vector<GpuBinding> bindings = geometry_bindings(b.geometry);
  bindings.insert(bindings.end(), {{kRasterBindCounters, b.counters},
                                   {kRasterBindPaths, &p.paths},
                                   {kRasterBindBig, &p.big_triangles},
                                   {kRasterBindTiles, &p.tiles}});
  return gpu_bindings(kRasterBindingCount, bindings);
}

// raster.glsl's bindings with VGEO_RASTER_SHADOW_PASS.
// The shadow compute raster's bindings (raster_shadow*.comp), which the hardware page raster
// (hw_shadow.vert/.frag) extends with the page table: one list for both.
std::vector<GpuBinding> shadow_binding_list(const GpuRasterPasses& p, const GpuShadowRasterBuffers& b) {
  std::vector<GpuBinding> bindings = geometry_bindings(b.raster.geometry);
  bindings.insert(bindings.end(), {{kRasterBindCounters, b.raster.counters},
                                   {kRasterBindPaths, &p.paths},
                                   {kRasterBindBig, &p.big_triangles},
                                   {kRasterBindTiles, &p.tiles},
                                   {kRasterBindShadowPages, b.pages},
                                   {kRasterBindShadowElementPage, b.element_page},
                                   {kRasterBindShadowPool, b.pool}});
  return bindings;
}
std::vector<const GpuBuffer*> shadow_buffers(const GpuRasterPasses& p, const GpuShadowRasterBuffers& b) {
  return gpu_bindings(kRasterShadowBindingCount, shadow_binding_list(p, b));
}

// The tile pass of a cluster pass's deferred big triangles (spec/raster.md §13.5): each box in
// tiles of kGpuRasterTileSize² from its corner, row by row, dispatched on `tiles_pipeline`
// with `params` (tile_count and groups_x set here).
void record_tiles(GpuRecorder& rec, GpuRasterPasses& p, const GpuBuffer& counters, const ComputePipeline& tiles_pipeline,
                  const std::vector<const GpuBuffer*>& buffers, const GpuRasterParams& base, RasterSplitStats* split) {
  const uint32_t count = counters.data<uint32_t>()[kGpuRasterBigWord];
  if (count == 0) return;
  if (count > kGpuRasterMaxBigTriangles)
    fail("GPU_SCENE_TOO_LARGE", p.context->device_name,
         std::to_string(count) + " triangles with a pixel box over " + std::to_string(kGpuRasterTileSize) +
             " px in one raster pass, more than the compute rasterizer's big-triangle list holds (" +
             std::to_string(kGpuRasterMaxBigTriangles) + ", spec/raster.md §13.5): use --raster hw or auto",
         kExitUsage);
  // The tile pass reads the list (and the big triangles) while the next batch waits for
  // continue_commands.
  const GpuBigTriangle* big = p.big_triangles.data<GpuBigTriangle>();
  std::vector<GpuRasterTile> tiles;
  const int32_t size = int32_t(kGpuRasterTileSize);
  auto flush = [&] {
    if (tiles.empty()) return;
    ensure_gpu_buffer(*p.context, p.tiles, tiles.size() * sizeof(GpuRasterTile));
    std::memcpy(p.tiles.mapped, tiles.data(), tiles.size() * sizeof(GpuRasterTile));
    GpuRasterParams params = base;
    params.tile_count = uint32_t(tiles.size());
    const uint32_t groups = (params.tile_count + kGpuRasterGroupSize - 1) / kGpuRasterGroupSize;
    params.groups_x = std::min(groups, kGpuMaxGroupsX);
    cmd_dispatch(rec, tiles_pipeline, buffers, &params, params.groups_x, (groups + params.groups_x - 1) / params.groups_x);
    split->sw_tiles += tiles.size();
    tiles.clear();
  };
  for (uint32_t i = 0; i < count; ++i)
    for (int32_t y = big[i].min_py; y <= big[i].max_py; y += size)
      for (int32_t x = big[i].min_px; x <= big[i].max_px; x += size) {
        if (tiles.size() == kGpuRasterTilesPerDispatch) {
          flush();
          continue_commands(rec);  // the dispatch has read its tiles before the list is rewritten
        }
        tiles.push_back({i, x, y, 0});
      }
  flush();
  split->sw_tiled_triangles += count;
}

// The shadow raster's push constants: back faces drawn (spec/shadow.md §5); the viewport,
// window and z_near come per element from its GpuShadowPage.
GpuRasterParams shadow_params(uint32_t element_count) {
  GpuRasterParams params{};
  params.visible_count = element_count;
  params.cull_backfaces = 0u;
  return params;
}

}  // namespace

std::vector<GpuBinding> geometry_bindings(const GpuGeometryBuffers& g) {
  return {{kGeomBindPages, g.pages},         {kGeomBindLocations, g.locations}, {kGeomBindMeshes, g.meshes},
          {kGeomBindInstances, g.instances}, {kGeomBindVisible, g.visible},     {kGeomBindVis, g.vis}};
}

GpuRasterPasses::~GpuRasterPasses() {
  if (!context) return;
  VkDevice d = context->device;
  for (VkPipeline pipeline : {hw, hw_shadow})
    if (pipeline) vkDestroyPipeline(d, pipeline, nullptr);
  for (VkPipelineLayout layout : {hw_layout, hw_shadow_layout})
    if (layout) vkDestroyPipelineLayout(d, layout, nullptr);
  for (VkDescriptorSetLayout layout : {hw_set_layout, hw_shadow_set_layout})
    if (layout) vkDestroyDescriptorSetLayout(d, layout, nullptr);
}

std::unique_ptr<GpuRasterPasses> create_gpu_raster_passes(GpuContext& gpu,
                                                          const std::vector<GpuClusterRasterInfo>& cluster_info) {
  auto p = std::make_unique<GpuRasterPasses>();
  p->context = &gpu;
  p->sw = create_compute_pipeline(gpu, kShaderRaster, kRasterBindingCount, sizeof(GpuRasterParams));
  p->sw_tiles = create_compute_pipeline(gpu, kShaderRasterTiles, kRasterBindingCount, sizeof(GpuRasterParams));
  p->split = create_compute_pipeline(gpu, kShaderRasterSplit, kSplitBindingCount, sizeof(GpuRasterSplitParams));
  p->shadow = create_compute_pipeline(gpu, kShaderRasterShadow, kRasterShadowBindingCount, sizeof(GpuRasterParams));
  p->shadow_tiles =
      create_compute_pipeline(gpu, kShaderRasterShadowTiles, kRasterShadowBindingCount, sizeof(GpuRasterParams));
  create_hw_pipeline(gpu, kHwBindings, kShaderHwRasterVert, kShaderHwRasterFrag, &p->hw_set_layout, &p->hw_layout, &p->hw);
  create_hw_pipeline(gpu, kHwShadowBindingCount, kShaderHwShadowVert, kShaderHwShadowFrag, &p->hw_shadow_set_layout,
                     &p->hw_shadow_layout, &p->hw_shadow);
  p->cluster_info = create_gpu_buffer(gpu, cluster_info.size() * sizeof(GpuClusterRasterInfo));
  if (!cluster_info.empty())
    std::memcpy(p->cluster_info.mapped, cluster_info.data(), cluster_info.size() * sizeof(GpuClusterRasterInfo));
  p->split_counters = create_gpu_buffer(gpu, sizeof(GpuRasterSplitCounters));
  p->big_triangles = create_gpu_buffer(gpu, uint64_t(kGpuRasterMaxBigTriangles) * sizeof(GpuBigTriangle));
  p->tiles = create_gpu_buffer(gpu, sizeof(GpuRasterTile));
  return p;
}

void prepare_gpu_raster(GpuRasterPasses& p, const std::vector<float>& instance_scale, uint32_t visible_total) {
  GpuContext& gpu = *p.context;
  ensure_gpu_buffer(gpu, p.raster_instances, instance_scale.size() * sizeof(GpuRasterInstance));
  if (!instance_scale.empty())
    std::memcpy(p.raster_instances.mapped, instance_scale.data(), instance_scale.size() * sizeof(float));
  ensure_gpu_buffer(gpu, p.paths, uint64_t(visible_total) * 4);
  ensure_gpu_buffer(gpu, p.commands, uint64_t(visible_total) * sizeof(GpuDrawCommand));
}

void record_gpu_raster(GpuRecorder& rec, GpuRasterPasses& p, const GpuRasterBuffers& b, const GpuRasterRequest& q) {
  cmd_fill(rec, p.split_counters, 0);
  GpuRasterSplitParams split{};
  split.first_visible = q.first_visible;
  split.visible_count = q.visible_count;
  const uint32_t split_groups = (q.visible_count + kGpuRasterSplitGroupSize - 1) / kGpuRasterSplitGroupSize;
  split.groups_x = std::min(split_groups, kGpuMaxGroupsX);
  split.mode = uint32_t(q.mode);
  split.z_near = q.z_near;
  split.pixels_per_unit_at_1 = q.pixels_per_unit_at_1;
  split.hw_min_triangle_area_px = q.hw_min_triangle_area_px;
  cmd_dispatch(rec, p.split,
               gpu_bindings(kSplitBindingCount, {{kSplitBindMeshes, b.geometry.meshes},
                                                 {kSplitBindInstances, b.geometry.instances},
                                                 {kSplitBindVisible, b.geometry.visible},
                                                 {kSplitBindInfos, &p.cluster_info},
                                                 {kSplitBindRasterInstances, &p.raster_instances},
                                                 {kSplitBindPaths, &p.paths},
                                                 {kSplitBindCommands, &p.commands},
                                                 {kSplitBindCounters, &p.split_counters}}),
               &split, split.groups_x, split.groups_x ? (split_groups + split.groups_x - 1) / split.groups_x : 0);

  GpuRasterParams params = sw_params(q);
  params.groups_x = std::min(q.visible_count, kGpuMaxGroupsX);
  if (q.mode != GpuRasterMode::kHw) {
    const uint32_t groups_y = params.groups_x ? (q.visible_count + params.groups_x - 1) / params.groups_x : 0;
    cmd_dispatch(rec, p.sw, sw_buffers(p, b), &params, params.groups_x, groups_y);
  }
  if (q.mode != GpuRasterMode::kSw && q.visible_count) {
    // The split's commands, count and paths, and the compute raster's keys, before the draw.
    barrier(rec, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
            VK_PIPELINE_STAGE_2_DRAW_INDIRECT_BIT | VK_PIPELINE_STAGE_2_VERTEX_SHADER_BIT |
                VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT,
            VK_ACCESS_2_INDIRECT_COMMAND_READ_BIT | VK_ACCESS_2_SHADER_READ_BIT | VK_ACCESS_2_SHADER_WRITE_BIT);
    record_hw_draw(rec, p, b, params, q.visible_count);
    // The fragment stage's keys and counter, before later passes and the host read-back.
    barrier(rec, VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT,
            VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT |
                VK_PIPELINE_STAGE_2_TRANSFER_BIT | VK_PIPELINE_STAGE_2_HOST_BIT,
            VK_ACCESS_2_SHADER_READ_BIT | VK_ACCESS_2_SHADER_WRITE_BIT | VK_ACCESS_2_TRANSFER_READ_BIT |
                VK_ACCESS_2_HOST_READ_BIT);
  }
}

void record_gpu_raster_tiles(GpuRecorder& rec, GpuRasterPasses& p, const GpuRasterBuffers& b, const GpuRasterRequest& q,
                             RasterSplitStats* split) {
  if (q.mode == GpuRasterMode::kHw) return;
  record_tiles(rec, p, *b.counters, p.sw_tiles, sw_buffers(p, b), sw_params(q), split);
}

void record_gpu_shadow_raster(GpuRecorder& rec, GpuRasterPasses& p, const GpuShadowRasterBuffers& b,
                              uint32_t element_count) {
  GpuRasterParams params = shadow_params(element_count);
  params.groups_x = std::min(element_count, kGpuMaxGroupsX);
  const uint32_t groups_y = params.groups_x ? (element_count + params.groups_x - 1) / params.groups_x : 0;
  cmd_dispatch(rec, p.shadow, shadow_buffers(p, b), &params, params.groups_x, groups_y);
}

void record_gpu_shadow_raster_tiles(GpuRecorder& rec, GpuRasterPasses& p, const GpuShadowRasterBuffers& b,
                                    uint32_t element_count, RasterSplitStats* split) {
  record_tiles(rec, p, *b.raster.counters, p.shadow_tiles, shadow_buffers(p, b), shadow_params(element_count), split);
}

void record_gpu_shadow_hw_raster(GpuRecorder& rec, GpuRasterPasses& p, const GpuShadowRasterBuffers& b,
                                 const GpuBuffer& page_table, const std::vector<GpuShadowPage>& pages,
                                 const std::vector<GpuShadowHwDraw>& draws) {
  if (draws.empty()) return;
  std::vector<GpuBinding> bindings = shadow_binding_list(p, b);
  bindings.push_back({kHwShadowBindPageTable, &page_table});
  VkDescriptorSet set = storage_buffer_set(rec, p.hw_shadow_set_layout, gpu_bindings(kHwShadowBindingCount, bindings));
  // The framebuffer is the largest mip drawn (no attachments: only its size matters); each
  // page's draws use its mip's viewport and the page's scissor.
  uint32_t side = 1;
  for (const GpuShadowPage& page : pages) side = std::max(side, page.viewport);
  auto rendering = vk_struct<VkRenderingInfo>(VK_STRUCTURE_TYPE_RENDERING_INFO);
  rendering.renderArea = {{0, 0}, {side, side}};
  rendering.layerCount = 1;
  vkCmdBeginRendering(rec.commands, &rendering);
  vkCmdBindPipeline(rec.commands, VK_PIPELINE_BIND_POINT_GRAPHICS, p.hw_shadow);
  vkCmdBindDescriptorSets(rec.commands, VK_PIPELINE_BIND_POINT_GRAPHICS, p.hw_shadow_layout, 0, 1, &set, 0, nullptr);
  const GpuRasterParams params = shadow_params(uint32_t(draws.size()));
  vkCmdPushConstants(rec.commands, p.hw_shadow_layout, kHwStages, 0, sizeof params, &params);
  vkCmdSetCullMode(rec.commands, VK_CULL_MODE_NONE);  // back faces are drawn (spec/shadow.md §5)
  uint32_t current = ~0u;
  for (const GpuShadowHwDraw& d : draws) {
    if (d.page != current) {
      current = d.page;
      const GpuShadowPage& page = pages[d.page];
      const VkViewport viewport{0.0f, 0.0f, float(page.viewport), float(page.viewport), 0.0f, 1.0f};
      const VkRect2D scissor{{int32_t(page.window_x), int32_t(page.window_y)}, {kGpuShadowPageTexels, kGpuShadowPageTexels}};
      vkCmdSetViewport(rec.commands, 0, 1, &viewport);
      vkCmdSetScissor(rec.commands, 0, 1, &scissor);
    }
    vkCmdDraw(rec.commands, 3 * d.triangles, 1, 0, d.element);
  }
  vkCmdEndRendering(rec.commands);
  // The fragment stage's pool writes, before the host reads the drawn slots back.
  barrier(rec, VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT,
          VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_2_TRANSFER_BIT | VK_PIPELINE_STAGE_2_HOST_BIT,
          VK_ACCESS_2_SHADER_READ_BIT | VK_ACCESS_2_TRANSFER_READ_BIT | VK_ACCESS_2_HOST_READ_BIT);
}

RasterSplitStats read_gpu_raster_split(const GpuRasterPasses& p) {
  const GpuRasterSplitCounters& c = *p.split_counters.data<GpuRasterSplitCounters>();
  RasterSplitStats s;
  s.sw_clusters = c.sw_clusters;
  s.hw_clusters = c.hw_clusters;
  s.sw_triangles = c.sw_triangles;
  s.hw_triangles = c.hw_triangles;
  return s;
}

}  // namespace vgeo
