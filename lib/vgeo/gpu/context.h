#pragma once
// Headless Vulkan 1.3 context for the GPU backend (spec/gpu.md): instance, one compute-
// capable device (Mesa lavapipe by default), host-visible buffers, compute pipelines from
// the SPIR-V embedded in the library, and a one-shot command recorder. Plain structs,
// no global state: every object belongs to the GpuContext that made it.
//
// Validation: with GpuOptions::validate (CLI --validate, env VGEO_VK_VALIDATE=1) the
// Khronos validation layer and a debug-utils messenger are on; every message the layer
// reports is kept in GpuContext::validation_messages (never printed by the library), and
// callers fail on a non-empty list.
//
// The Vulkan loader is opened on first use (create_gpu_context, list_gpu_devices), not linked:
// a process that never uses the GPU (every `vgeo build`) neither maps libvulkan nor resolves
// its symbols at start (~0.35 MiB resident; docs/acceptance/issue23_rss.md). vgeo calls Vulkan
// through the pointers declared below, one per function it calls, named as the functions are
// so call sites read as plain Vulkan: the library's one piece of process-wide state, set once
// (from the loader's own exported symbols, the functions a link would have bound).
#ifndef VK_NO_PROTOTYPES
#define VK_NO_PROTOTYPES
#endif
#include <vulkan/vulkan.h>

#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#define VGEO_VULKAN_FUNCTIONS(X) \
  X(vkAllocateCommandBuffers) X(vkAllocateDescriptorSets) X(vkAllocateMemory) X(vkBeginCommandBuffer) \
  X(vkBindBufferMemory) X(vkCmdBeginRendering) X(vkCmdBindDescriptorSets) X(vkCmdBindPipeline) \
  X(vkCmdDispatch) X(vkCmdDispatchIndirect) X(vkCmdDraw) X(vkCmdDrawIndirectCount) X(vkCmdEndRendering) \
  X(vkCmdFillBuffer) X(vkCmdPipelineBarrier2) X(vkCmdPushConstants) X(vkCmdResetQueryPool) \
  X(vkCmdSetCullMode) X(vkCmdSetScissor) X(vkCmdSetViewport) X(vkCmdWriteTimestamp2) X(vkCreateBuffer) \
  X(vkCreateCommandPool) X(vkCreateComputePipelines) X(vkCreateDescriptorPool) \
  X(vkCreateDescriptorSetLayout) X(vkCreateDevice) X(vkCreateFence) X(vkCreateGraphicsPipelines) \
  X(vkCreateInstance) X(vkCreatePipelineLayout) X(vkCreateQueryPool) X(vkCreateShaderModule) \
  X(vkDestroyBuffer) X(vkDestroyCommandPool) X(vkDestroyDescriptorPool) X(vkDestroyDescriptorSetLayout) \
  X(vkDestroyDevice) X(vkDestroyFence) X(vkDestroyInstance) X(vkDestroyPipeline) X(vkDestroyPipelineLayout) \
  X(vkDestroyQueryPool) X(vkDestroyShaderModule) X(vkDeviceWaitIdle) X(vkEndCommandBuffer) \
  X(vkEnumerateInstanceLayerProperties) X(vkEnumeratePhysicalDevices) X(vkFreeMemory) \
  X(vkGetBufferMemoryRequirements) X(vkGetDeviceQueue) X(vkGetInstanceProcAddr) \
  X(vkGetPhysicalDeviceFeatures2) X(vkGetPhysicalDeviceMemoryProperties) X(vkGetPhysicalDeviceProperties) \
  X(vkGetPhysicalDeviceQueueFamilyProperties) X(vkGetQueryPoolResults) X(vkMapMemory) X(vkQueueSubmit) \
  X(vkResetCommandBuffer) X(vkResetDescriptorPool) X(vkResetFences) X(vkUpdateDescriptorSets) \
  X(vkWaitForFences)

namespace vgeo {

// A Vulkan function vgeo calls, or a new one: add it to VGEO_VULKAN_FUNCTIONS.
#define VGEO_VULKAN_DECLARE(name) extern PFN_##name name;
VGEO_VULKAN_FUNCTIONS(VGEO_VULKAN_DECLARE)
#undef VGEO_VULKAN_DECLARE


// Device chosen when neither GpuOptions::device nor VGEO_VK_DEVICE names one: the
// project's reference GPU is Mesa's CPU driver (lavapipe reports "llvmpipe ...").
// A Vulkan structure with its sType set and every other member zero (what `VkX x{sType}`
// means, without GCC's -Wmissing-field-initializers for each member it leaves out).
template <class VkStruct>
VkStruct vk_struct(VkStructureType type) {
  VkStruct s{};
  s.sType = type;
  return s;
}

inline constexpr const char* kDefaultGpuDevice = "llvmpipe";

struct GpuOptions {
  // Device to use: a decimal index into vkEnumeratePhysicalDevices, or a case-insensitive
  // substring of the device name. Empty: env VGEO_VK_DEVICE, else kDefaultGpuDevice,
  // else the first device.
  std::string device;
  bool validate = false;  // also on when env VGEO_VK_VALIDATE=1
};

struct GpuContext {
  VkInstance instance = VK_NULL_HANDLE;
  VkDebugUtilsMessengerEXT messenger = VK_NULL_HANDLE;
  VkPhysicalDevice physical = VK_NULL_HANDLE;
  VkDevice device = VK_NULL_HANDLE;
  VkQueue queue = VK_NULL_HANDLE;
  uint32_t queue_family = 0;
  uint32_t host_memory_type = 0;  // host-visible, host-coherent memory type index
  VkPhysicalDeviceProperties properties{};
  std::string device_name;
  bool validation = false;

  // Filled by the debug messenger (any thread); read after the GPU work has finished.
  std::mutex messages_mutex;
  std::vector<std::string> validation_messages;

  GpuContext() = default;
  GpuContext(const GpuContext&) = delete;
  GpuContext& operator=(const GpuContext&) = delete;
  ~GpuContext();
};

// Throws VgeoError: GPU_NO_DEVICE (no Vulkan driver or no physical device),
// GPU_DEVICE_NOT_FOUND (the requested device does not exist), GPU_FEATURE_MISSING
// (a required feature: Vulkan 1.3 with synchronization2, maintenance4 and dynamicRendering,
// shaderInt64, shaderFloat64, shaderBufferInt64Atomics, and for the hardware raster path
// fragmentStoresAndAtomics, multiDrawIndirect, drawIndirectFirstInstance, drawIndirectCount),
// GPU_VALIDATION_UNAVAILABLE (validation requested, layer not installed), GPU_ERROR.
std::unique_ptr<GpuContext> create_gpu_context(const GpuOptions& options);

// Names of the physical devices, in enumeration order (for error messages and `--device`).
std::vector<std::string> list_gpu_devices();

// Throws VgeoError GPU_ERROR (exit kExitInternal) when `result` is not VK_SUCCESS.
void check_vk(VkResult result, const char* what);

// A host-visible, host-coherent storage buffer, persistently mapped (lavapipe's only heap
// is device-local and host-visible). Move-only; frees itself.
struct GpuBuffer {
  GpuContext* context = nullptr;
  VkBuffer buffer = VK_NULL_HANDLE;
  VkDeviceMemory memory = VK_NULL_HANDLE;
  VkDeviceSize size = 0;
  void* mapped = nullptr;

  GpuBuffer() = default;
  GpuBuffer(GpuBuffer&& o) noexcept { *this = std::move(o); }
  GpuBuffer& operator=(GpuBuffer&& o) noexcept;
  GpuBuffer(const GpuBuffer&) = delete;
  GpuBuffer& operator=(const GpuBuffer&) = delete;
  ~GpuBuffer() { reset(); }
  void reset();
  template <class T>
  T* data() const { return static_cast<T*>(mapped); }
};

// `size` bytes (0 is rounded up to 4, the smallest legal storage buffer). Larger than
// maxStorageBufferRange is a programming error: callers split (spec/gpu.md).
GpuBuffer create_gpu_buffer(GpuContext& context, VkDeviceSize size);
// Keeps `buffer` at least `size` bytes long (a new buffer when it grows: contents not kept).
void ensure_gpu_buffer(GpuContext& context, GpuBuffer& buffer, VkDeviceSize size);

// SPIR-V embedded in the library by the build (shaders/*.comp → generated shaders.h).
struct ShaderBinary {
  const char* name;
  const uint32_t* words;
  size_t word_count;
};

// A compute pipeline whose bindings 0..storage_buffers-1 of set 0 are storage buffers and
// whose push-constant block is `push_constant_bytes` long.
struct ComputePipeline {
  GpuContext* context = nullptr;
  VkDescriptorSetLayout set_layout = VK_NULL_HANDLE;
  VkPipelineLayout layout = VK_NULL_HANDLE;
  VkPipeline pipeline = VK_NULL_HANDLE;
  uint32_t storage_buffers = 0, push_constant_bytes = 0;

  ComputePipeline() = default;
  ComputePipeline(ComputePipeline&& o) noexcept { *this = std::move(o); }
  ComputePipeline& operator=(ComputePipeline&& o) noexcept;
  ComputePipeline(const ComputePipeline&) = delete;
  ComputePipeline& operator=(const ComputePipeline&) = delete;
  ~ComputePipeline() { reset(); }
  void reset();
};

ComputePipeline create_compute_pipeline(GpuContext& context, const ShaderBinary& shader,
                                        uint32_t storage_buffers, uint32_t push_constant_bytes);

// Records compute work into one command buffer and runs it synchronously. Every dispatch
// is followed by a full compute→compute/transfer/host memory barrier, so consecutive
// dispatches see each other's writes (the frame's passes are sequential by design).
struct GpuRecorder {
  GpuContext* context = nullptr;
  VkCommandPool pool = VK_NULL_HANDLE;
  VkCommandBuffer commands = VK_NULL_HANDLE;
  VkDescriptorPool descriptors = VK_NULL_HANDLE;
  VkFence fence = VK_NULL_HANDLE;
  VkQueryPool timestamps = VK_NULL_HANDLE;
  uint32_t timestamps_used = 0;
  bool recording = false;

  GpuRecorder() = default;
  GpuRecorder(const GpuRecorder&) = delete;
  GpuRecorder& operator=(const GpuRecorder&) = delete;
  ~GpuRecorder();
};

std::unique_ptr<GpuRecorder> create_gpu_recorder(GpuContext& context);
void begin_commands(GpuRecorder& rec);
void cmd_fill(GpuRecorder& rec, const GpuBuffer& buffer, uint32_t value);
// One shader's storage buffers by binding index (gpu/shader_bindings.h: the indices the GLSL
// declares), as cmd_dispatch and storage_buffer_set take them: `count` slots (the shader's
// k<Shader>BindingCount), each pair placed at its index. Fails GPU_ERROR (internal) when a
// slot is left empty, given twice or out of range, so a host list that disagrees with the
// shader is an error at record time, never a wrong image.
struct GpuBinding {
  uint32_t index;
  const GpuBuffer* buffer;
};
std::vector<const GpuBuffer*> gpu_bindings(uint32_t count, const std::vector<GpuBinding>& buffers);

// A descriptor set of this submission whose bindings 0..n-1 are the storage buffers `buffers`
// (for cmd_dispatch and the graphics pipeline of hw_raster.h).
VkDescriptorSet storage_buffer_set(GpuRecorder& rec, VkDescriptorSetLayout layout,
                                   const std::vector<const GpuBuffer*>& buffers);
void cmd_dispatch(GpuRecorder& rec, const ComputePipeline& pipeline,
                  const std::vector<const GpuBuffer*>& buffers, const void* push_constants,
                  uint32_t groups_x, uint32_t groups_y = 1, uint32_t groups_z = 1);
// The same with the group counts read by the GPU from `args` at `offset` (VkDispatchIndirectCommand).
void cmd_dispatch_indirect(GpuRecorder& rec, const ComputePipeline& pipeline,
                           const std::vector<const GpuBuffer*>& buffers, const void* push_constants,
                           const GpuBuffer& args, VkDeviceSize offset);
// Writes a GPU timestamp; returns its slot (read with read_timestamps_ms after submit).
uint32_t cmd_timestamp(GpuRecorder& rec);
void submit_and_wait(GpuRecorder& rec);
// Submits what is recorded, waits, and begins a new command buffer that continues the
// same recording: timestamp slots keep counting (timestamp_ms may span the two), so a
// pass that must read a GPU result on the host to decide its next dispatch (the
// persistent cull traversal) can sit between other recorded passes.
void continue_commands(GpuRecorder& rec);
// Milliseconds between timestamp slots `from` and `to` of the last submission.
double timestamp_ms(GpuRecorder& rec, uint32_t from, uint32_t to);

}  // namespace vgeo
