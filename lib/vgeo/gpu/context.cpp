// Headless Vulkan context, buffers, compute pipelines and the command recorder
// (lib/vgeo/gpu/context.h, spec/gpu.md).
#include "vgeo/gpu/context.h"

#include <dlfcn.h>

#include <algorithm>
#include <cassert>
#include <cctype>
#include <cstdlib>
#include <cstring>

#include "vgeo/core/error.h"
#include "vgeo/core/shared_library.h"

namespace vgeo {

#define VGEO_VULKAN_DEFINE(name) PFN_##name name = nullptr;
VGEO_VULKAN_FUNCTIONS(VGEO_VULKAN_DEFINE)
#undef VGEO_VULKAN_DEFINE

namespace {

// The Vulkan loader's ABI name (Debian: libvulkan1).
constexpr const char* kVulkanLoader = "libvulkan.so.1";

// Opens the loader and fills the function pointers, once per process; never unloaded. A
// missing loader or function is GPU_NO_DEVICE (no usable Vulkan), as a missing driver is.
void load_vulkan() {
  static std::once_flag once;
  static std::string failure;
  std::call_once(once, [] {
    const OpenedLibrary opened = open_shared_library(kVulkanLoader, "the Vulkan loader");
    if (!opened.handle) {
      failure = opened.failure;
      return;
    }
    void* loader = opened.handle;
#define VGEO_VULKAN_LOAD(name)                                          \
  name = reinterpret_cast<PFN_##name>(dlsym(loader, #name));            \
  if (!name) {                                                          \
    failure = std::string(kVulkanLoader) + " does not export " #name;   \
    return;                                                             \
  }
    VGEO_VULKAN_FUNCTIONS(VGEO_VULKAN_LOAD)
#undef VGEO_VULKAN_LOAD
  });
  if (!failure.empty())
    fail("GPU_NO_DEVICE", "vulkan", failure + " (install libvulkan1 and mesa-vulkan-drivers; tools/setup does)",
         kExitUsage);
}

constexpr const char* kValidationLayer = "VK_LAYER_KHRONOS_validation";
// Timestamp slots per submission: two per timed pass, far more than a frame has passes.
constexpr uint32_t kMaxTimestamps = 256;
// Descriptor sets per submission (one per dispatch) and storage-buffer descriptors in all.
constexpr uint32_t kMaxDispatchesPerSubmit = 4096;
constexpr uint32_t kMaxBuffersPerDispatch = 16;

bool env_flag(const char* name) {
  const char* v = std::getenv(name);
  return v && *v && std::strcmp(v, "0") != 0;
}

std::string lower(std::string s) {
  for (char& c : s) c = char(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

VKAPI_ATTR VkBool32 VKAPI_CALL on_debug_message(VkDebugUtilsMessageSeverityFlagBitsEXT severity,
                                                VkDebugUtilsMessageTypeFlagsEXT,
                                                const VkDebugUtilsMessengerCallbackDataEXT* data,
                                                void* user) {
  auto* context = static_cast<GpuContext*>(user);
  const char* severity_name = (severity & VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT) ? "error" : "warning";
  std::lock_guard<std::mutex> lock(context->messages_mutex);
  context->validation_messages.push_back(std::string(severity_name) + ": " +
                                         (data && data->pMessage ? data->pMessage : "(no text)"));
  return VK_FALSE;
}

VkDebugUtilsMessengerCreateInfoEXT messenger_info(GpuContext* context) {
  auto info = vk_struct<VkDebugUtilsMessengerCreateInfoEXT>(VK_STRUCTURE_TYPE_DEBUG_UTILS_MESSENGER_CREATE_INFO_EXT);
  // Warnings and errors of every type: "any validation message fails" (spec/gpu.md).
  info.messageSeverity = VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT | VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT;
  info.messageType = VK_DEBUG_UTILS_MESSAGE_TYPE_GENERAL_BIT_EXT | VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT |
                     VK_DEBUG_UTILS_MESSAGE_TYPE_PERFORMANCE_BIT_EXT;
  info.pfnUserCallback = on_debug_message;
  info.pUserData = context;
  return info;
}

bool layer_available(const char* name) {
  uint32_t n = 0;
  vkEnumerateInstanceLayerProperties(&n, nullptr);
  std::vector<VkLayerProperties> layers(n);
  vkEnumerateInstanceLayerProperties(&n, layers.data());
  for (const VkLayerProperties& l : layers)
    if (std::strcmp(l.layerName, name) == 0) return true;
  return false;
}

VkInstance create_instance(bool validate, GpuContext* context) {
  load_vulkan();  // every GPU entry point starts here
  auto app = vk_struct<VkApplicationInfo>(VK_STRUCTURE_TYPE_APPLICATION_INFO);
  app.pApplicationName = "vgeo";
  app.pEngineName = "vgeo";
  app.apiVersion = VK_API_VERSION_1_3;
  auto info = vk_struct<VkInstanceCreateInfo>(VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO);
  info.pApplicationInfo = &app;
  std::vector<const char*> layers, extensions;
  VkDebugUtilsMessengerCreateInfoEXT debug = messenger_info(context);
  if (validate) {
    if (!layer_available(kValidationLayer))
      fail("GPU_VALIDATION_UNAVAILABLE", "vulkan",
           std::string(kValidationLayer) + " is not installed (Debian: vulkan-validationlayers)", kExitUsage);
    layers.push_back(kValidationLayer);
    extensions.push_back(VK_EXT_DEBUG_UTILS_EXTENSION_NAME);
    info.pNext = &debug;  // also reports problems in vkCreateInstance itself
  }
  info.enabledLayerCount = uint32_t(layers.size());
  info.ppEnabledLayerNames = layers.data();
  info.enabledExtensionCount = uint32_t(extensions.size());
  info.ppEnabledExtensionNames = extensions.data();
  VkInstance instance = VK_NULL_HANDLE;
  VkResult r = vkCreateInstance(&info, nullptr, &instance);
  if (r == VK_ERROR_INCOMPATIBLE_DRIVER || r == VK_ERROR_INITIALIZATION_FAILED)
    fail("GPU_NO_DEVICE", "vulkan",
         "no Vulkan 1.3 driver (install mesa-vulkan-drivers for lavapipe; tools/setup does)", kExitUsage);
  // The layer's manifest was listed but its library did not load (removed, or not on the
  // library path): the layer is as unavailable as when it is not listed at all.
  if (r == VK_ERROR_LAYER_NOT_PRESENT && validate)
    fail("GPU_VALIDATION_UNAVAILABLE", "vulkan",
         std::string(kValidationLayer) + " is listed but its library could not be loaded", kExitUsage);
  check_vk(r, "vkCreateInstance");
  return instance;
}

std::vector<VkPhysicalDevice> physical_devices(VkInstance instance) {
  uint32_t n = 0;
  vkEnumeratePhysicalDevices(instance, &n, nullptr);
  std::vector<VkPhysicalDevice> devices(n);
  if (n) vkEnumeratePhysicalDevices(instance, &n, devices.data());
  devices.resize(n);
  return devices;
}

std::string device_name(VkPhysicalDevice d) {
  VkPhysicalDeviceProperties p;
  vkGetPhysicalDeviceProperties(d, &p);
  return p.deviceName;
}

// Index of the requested device (see GpuOptions::device).
size_t pick_device(const std::vector<VkPhysicalDevice>& devices, const std::string& requested) {
  std::string all;
  for (size_t i = 0; i < devices.size(); ++i) all += (i ? ", " : "") + std::to_string(i) + ": " + device_name(devices[i]);
  bool explicit_choice = !requested.empty();
  std::string want = explicit_choice ? requested : kDefaultGpuDevice;
  if (!want.empty() && std::all_of(want.begin(), want.end(), [](char c) { return std::isdigit((unsigned char)c); })) {
    size_t index = std::strtoul(want.c_str(), nullptr, 10);
    if (index < devices.size()) return index;
  } else {
    for (size_t i = 0; i < devices.size(); ++i)
      if (lower(device_name(devices[i])).find(lower(want)) != std::string::npos) return i;
  }
  if (!explicit_choice) return 0;
  fail("GPU_DEVICE_NOT_FOUND", "vulkan", "no device matches '" + requested + "' (devices: " + all + ")", kExitUsage);
}

void require_features(VkPhysicalDevice d) {
  VkPhysicalDeviceProperties props;
  vkGetPhysicalDeviceProperties(d, &props);
  std::string missing;
  if (props.apiVersion < VK_API_VERSION_1_3) missing += " Vulkan-1.3";
  auto f13 = vk_struct<VkPhysicalDeviceVulkan13Features>(VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_3_FEATURES);
  auto f12 = vk_struct<VkPhysicalDeviceVulkan12Features>(VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES);
  f12.pNext = &f13;
  auto f = vk_struct<VkPhysicalDeviceFeatures2>(VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2);
  f.pNext = &f12;
  vkGetPhysicalDeviceFeatures2(d, &f);
  if (!f.features.shaderInt64) missing += " shaderInt64";
  if (!f.features.shaderFloat64) missing += " shaderFloat64";
  if (!f12.shaderBufferInt64Atomics) missing += " shaderBufferInt64Atomics";
  if (!f13.synchronization2) missing += " synchronization2";
  if (!f13.maintenance4) missing += " maintenance4";
  // The hardware raster path (hw_raster.h): atomics from fragment shaders, dynamic
  // rendering without attachments, draws from a GPU-written command list and count.
  if (!f.features.fragmentStoresAndAtomics) missing += " fragmentStoresAndAtomics";
  if (!f.features.multiDrawIndirect) missing += " multiDrawIndirect";
  if (!f.features.drawIndirectFirstInstance) missing += " drawIndirectFirstInstance";
  if (!f12.drawIndirectCount) missing += " drawIndirectCount";
  if (!f13.dynamicRendering) missing += " dynamicRendering";
  if (!missing.empty())
    fail("GPU_FEATURE_MISSING", device_name(d), "required features missing:" + missing, kExitUsage);
}

uint32_t find_host_memory_type(VkPhysicalDevice d) {
  VkPhysicalDeviceMemoryProperties mem;
  vkGetPhysicalDeviceMemoryProperties(d, &mem);
  const VkMemoryPropertyFlags want = VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
  for (uint32_t i = 0; i < mem.memoryTypeCount; ++i)
    if ((mem.memoryTypes[i].propertyFlags & want) == want) return i;
  fail("GPU_FEATURE_MISSING", device_name(d), "no host-visible coherent memory type", kExitUsage);
}

}  // namespace

void check_vk(VkResult result, const char* what) {
  if (result != VK_SUCCESS)
    fail("GPU_ERROR", "vulkan", std::string(what) + " failed (VkResult " + std::to_string(int(result)) + ")",
         kExitInternal);
}

std::vector<std::string> list_gpu_devices() {
  GpuContext scratch;
  scratch.instance = create_instance(false, &scratch);
  std::vector<std::string> names;
  for (VkPhysicalDevice d : physical_devices(scratch.instance)) names.push_back(device_name(d));
  return names;
}

std::unique_ptr<GpuContext> create_gpu_context(const GpuOptions& options) {
  auto context = std::make_unique<GpuContext>();
  GpuContext& c = *context;
  c.validation = options.validate || env_flag("VGEO_VK_VALIDATE");
  c.instance = create_instance(c.validation, &c);
  if (c.validation) {
    auto create = reinterpret_cast<PFN_vkCreateDebugUtilsMessengerEXT>(
        vkGetInstanceProcAddr(c.instance, "vkCreateDebugUtilsMessengerEXT"));
    VkDebugUtilsMessengerCreateInfoEXT info = messenger_info(&c);
    check_vk(create ? create(c.instance, &info, nullptr, &c.messenger) : VK_ERROR_EXTENSION_NOT_PRESENT,
             "vkCreateDebugUtilsMessengerEXT");
  }
  std::vector<VkPhysicalDevice> devices = physical_devices(c.instance);
  if (devices.empty())
    fail("GPU_NO_DEVICE", "vulkan", "no Vulkan physical device (install mesa-vulkan-drivers for lavapipe)",
         kExitUsage);
  std::string requested = options.device;
  if (requested.empty())
    if (const char* env = std::getenv("VGEO_VK_DEVICE")) requested = env;
  c.physical = devices[pick_device(devices, requested)];
  require_features(c.physical);
  vkGetPhysicalDeviceProperties(c.physical, &c.properties);
  c.device_name = c.properties.deviceName;
  c.host_memory_type = find_host_memory_type(c.physical);

  uint32_t family_count = 0;
  vkGetPhysicalDeviceQueueFamilyProperties(c.physical, &family_count, nullptr);
  std::vector<VkQueueFamilyProperties> families(family_count);
  vkGetPhysicalDeviceQueueFamilyProperties(c.physical, &family_count, families.data());
  bool found = false;
  for (uint32_t i = 0; i < family_count && !found; ++i)
    if (families[i].queueFlags & VK_QUEUE_COMPUTE_BIT) {
      c.queue_family = i;
      found = true;
    }
  if (!found) fail("GPU_FEATURE_MISSING", c.device_name, "no compute queue", kExitUsage);

  float priority = 1.0f;
  auto queue = vk_struct<VkDeviceQueueCreateInfo>(VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO);
  queue.queueFamilyIndex = c.queue_family;
  queue.queueCount = 1;
  queue.pQueuePriorities = &priority;
  auto f13 = vk_struct<VkPhysicalDeviceVulkan13Features>(VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_3_FEATURES);
  f13.synchronization2 = VK_TRUE;
  f13.maintenance4 = VK_TRUE;  // glslc --target-env=vulkan1.3 declares workgroup sizes with LocalSizeId
  f13.dynamicRendering = VK_TRUE;  // hw_raster.h: a render pass with no attachments
  auto f12 = vk_struct<VkPhysicalDeviceVulkan12Features>(VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES);
  f12.pNext = &f13;
  f12.shaderBufferInt64Atomics = VK_TRUE;
  f12.drawIndirectCount = VK_TRUE;
  auto features = vk_struct<VkPhysicalDeviceFeatures2>(VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2);
  features.pNext = &f12;
  features.features.shaderInt64 = VK_TRUE;
  features.features.shaderFloat64 = VK_TRUE;
  features.features.fragmentStoresAndAtomics = VK_TRUE;
  features.features.multiDrawIndirect = VK_TRUE;
  features.features.drawIndirectFirstInstance = VK_TRUE;
  auto info = vk_struct<VkDeviceCreateInfo>(VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO);
  info.pNext = &features;
  info.queueCreateInfoCount = 1;
  info.pQueueCreateInfos = &queue;
  check_vk(vkCreateDevice(c.physical, &info, nullptr, &c.device), "vkCreateDevice");
  vkGetDeviceQueue(c.device, c.queue_family, 0, &c.queue);
  return context;
}

GpuContext::~GpuContext() {
  if (device) {
    vkDeviceWaitIdle(device);
    vkDestroyDevice(device, nullptr);
  }
  if (messenger) {
    auto destroy = reinterpret_cast<PFN_vkDestroyDebugUtilsMessengerEXT>(
        vkGetInstanceProcAddr(instance, "vkDestroyDebugUtilsMessengerEXT"));
    if (destroy) destroy(instance, messenger, nullptr);
  }
  if (instance) vkDestroyInstance(instance, nullptr);
}

// ---- buffers ----

GpuBuffer& GpuBuffer::operator=(GpuBuffer&& o) noexcept {
  if (this != &o) {
    reset();
    context = o.context;
    buffer = o.buffer;
    memory = o.memory;
    size = o.size;
    mapped = o.mapped;
    o.context = nullptr;
    o.buffer = VK_NULL_HANDLE;
    o.memory = VK_NULL_HANDLE;
    o.size = 0;
    o.mapped = nullptr;
  }
  return *this;
}

void GpuBuffer::reset() {
  if (!context) return;
  if (buffer) vkDestroyBuffer(context->device, buffer, nullptr);
  if (memory) vkFreeMemory(context->device, memory, nullptr);  // unmaps implicitly
  context = nullptr;
  buffer = VK_NULL_HANDLE;
  memory = VK_NULL_HANDLE;
  size = 0;
  mapped = nullptr;
}

GpuBuffer create_gpu_buffer(GpuContext& c, VkDeviceSize size) {
  size = std::max<VkDeviceSize>(4, (size + 3) & ~VkDeviceSize(3));
  assert(size <= c.properties.limits.maxStorageBufferRange);
  GpuBuffer b;
  b.context = &c;
  b.size = size;
  auto info = vk_struct<VkBufferCreateInfo>(VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO);
  info.size = size;
  info.usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT |
               VK_BUFFER_USAGE_TRANSFER_SRC_BIT | VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT;
  info.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
  check_vk(vkCreateBuffer(c.device, &info, nullptr, &b.buffer), "vkCreateBuffer");
  VkMemoryRequirements req;
  vkGetBufferMemoryRequirements(c.device, b.buffer, &req);
  if (!(req.memoryTypeBits & (1u << c.host_memory_type)))
    fail("GPU_FEATURE_MISSING", c.device_name, "storage buffers cannot live in host-visible memory", kExitUsage);
  auto alloc = vk_struct<VkMemoryAllocateInfo>(VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO);
  alloc.allocationSize = req.size;
  alloc.memoryTypeIndex = c.host_memory_type;
  VkResult r = vkAllocateMemory(c.device, &alloc, nullptr, &b.memory);
  if (r == VK_ERROR_OUT_OF_DEVICE_MEMORY || r == VK_ERROR_OUT_OF_HOST_MEMORY)
    fail("OUT_OF_MEMORY", c.device_name, "GPU buffer of " + std::to_string(size) + " bytes", kExitInternal);
  check_vk(r, "vkAllocateMemory");
  check_vk(vkBindBufferMemory(c.device, b.buffer, b.memory, 0), "vkBindBufferMemory");
  check_vk(vkMapMemory(c.device, b.memory, 0, VK_WHOLE_SIZE, 0, &b.mapped), "vkMapMemory");
  return b;
}

void ensure_gpu_buffer(GpuContext& c, GpuBuffer& buffer, VkDeviceSize size) {
  if (buffer.buffer == VK_NULL_HANDLE || buffer.size < size) buffer = create_gpu_buffer(c, size);
}

// ---- compute pipelines ----

ComputePipeline& ComputePipeline::operator=(ComputePipeline&& o) noexcept {
  if (this != &o) {
    reset();
    context = o.context;
    set_layout = o.set_layout;
    layout = o.layout;
    pipeline = o.pipeline;
    storage_buffers = o.storage_buffers;
    push_constant_bytes = o.push_constant_bytes;
    o.context = nullptr;
    o.set_layout = VK_NULL_HANDLE;
    o.layout = VK_NULL_HANDLE;
    o.pipeline = VK_NULL_HANDLE;
  }
  return *this;
}

void ComputePipeline::reset() {
  if (!context) return;
  if (pipeline) vkDestroyPipeline(context->device, pipeline, nullptr);
  if (layout) vkDestroyPipelineLayout(context->device, layout, nullptr);
  if (set_layout) vkDestroyDescriptorSetLayout(context->device, set_layout, nullptr);
  context = nullptr;
  pipeline = VK_NULL_HANDLE;
  layout = VK_NULL_HANDLE;
  set_layout = VK_NULL_HANDLE;
}

ComputePipeline create_compute_pipeline(GpuContext& c, const ShaderBinary& shader, uint32_t storage_buffers,
                                        uint32_t push_constant_bytes) {
  assert(storage_buffers <= kMaxBuffersPerDispatch);
  ComputePipeline p;
  p.context = &c;
  p.storage_buffers = storage_buffers;
  p.push_constant_bytes = push_constant_bytes;
  std::vector<VkDescriptorSetLayoutBinding> bindings(storage_buffers);
  for (uint32_t i = 0; i < storage_buffers; ++i)
    bindings[i] = {i, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr};
  auto set_info = vk_struct<VkDescriptorSetLayoutCreateInfo>(VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO);
  set_info.bindingCount = storage_buffers;
  set_info.pBindings = bindings.data();
  check_vk(vkCreateDescriptorSetLayout(c.device, &set_info, nullptr, &p.set_layout), "vkCreateDescriptorSetLayout");
  VkPushConstantRange range{VK_SHADER_STAGE_COMPUTE_BIT, 0, push_constant_bytes};
  auto layout_info = vk_struct<VkPipelineLayoutCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO);
  layout_info.setLayoutCount = 1;
  layout_info.pSetLayouts = &p.set_layout;
  layout_info.pushConstantRangeCount = push_constant_bytes ? 1 : 0;
  layout_info.pPushConstantRanges = &range;
  check_vk(vkCreatePipelineLayout(c.device, &layout_info, nullptr, &p.layout), "vkCreatePipelineLayout");
  auto module_info = vk_struct<VkShaderModuleCreateInfo>(VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO);
  module_info.codeSize = shader.word_count * 4;
  module_info.pCode = shader.words;
  VkShaderModule module = VK_NULL_HANDLE;
  check_vk(vkCreateShaderModule(c.device, &module_info, nullptr, &module), "vkCreateShaderModule");
  auto info = vk_struct<VkComputePipelineCreateInfo>(VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO);
  info.stage = vk_struct<VkPipelineShaderStageCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO);
  info.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
  info.stage.module = module;
  info.stage.pName = "main";
  info.layout = p.layout;
  VkResult r = vkCreateComputePipelines(c.device, VK_NULL_HANDLE, 1, &info, nullptr, &p.pipeline);
  vkDestroyShaderModule(c.device, module, nullptr);
  check_vk(r, shader.name);
  return p;
}

// ---- command recorder ----

std::unique_ptr<GpuRecorder> create_gpu_recorder(GpuContext& c) {
  auto rec = std::make_unique<GpuRecorder>();
  rec->context = &c;
  auto pool = vk_struct<VkCommandPoolCreateInfo>(VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO);
  pool.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
  pool.queueFamilyIndex = c.queue_family;
  check_vk(vkCreateCommandPool(c.device, &pool, nullptr, &rec->pool), "vkCreateCommandPool");
  auto alloc = vk_struct<VkCommandBufferAllocateInfo>(VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO);
  alloc.commandPool = rec->pool;
  alloc.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
  alloc.commandBufferCount = 1;
  check_vk(vkAllocateCommandBuffers(c.device, &alloc, &rec->commands), "vkAllocateCommandBuffers");
  VkDescriptorPoolSize size{VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, kMaxDispatchesPerSubmit * kMaxBuffersPerDispatch};
  auto dp = vk_struct<VkDescriptorPoolCreateInfo>(VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO);
  dp.maxSets = kMaxDispatchesPerSubmit;
  dp.poolSizeCount = 1;
  dp.pPoolSizes = &size;
  check_vk(vkCreateDescriptorPool(c.device, &dp, nullptr, &rec->descriptors), "vkCreateDescriptorPool");
  auto fence = vk_struct<VkFenceCreateInfo>(VK_STRUCTURE_TYPE_FENCE_CREATE_INFO);
  check_vk(vkCreateFence(c.device, &fence, nullptr, &rec->fence), "vkCreateFence");
  auto q = vk_struct<VkQueryPoolCreateInfo>(VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO);
  q.queryType = VK_QUERY_TYPE_TIMESTAMP;
  q.queryCount = kMaxTimestamps;
  check_vk(vkCreateQueryPool(c.device, &q, nullptr, &rec->timestamps), "vkCreateQueryPool");
  return rec;
}

GpuRecorder::~GpuRecorder() {
  if (!context) return;
  VkDevice d = context->device;
  if (timestamps) vkDestroyQueryPool(d, timestamps, nullptr);
  if (fence) vkDestroyFence(d, fence, nullptr);
  if (descriptors) vkDestroyDescriptorPool(d, descriptors, nullptr);
  if (pool) vkDestroyCommandPool(d, pool, nullptr);
}

void begin_commands(GpuRecorder& rec) {
  assert(!rec.recording);
  check_vk(vkResetDescriptorPool(rec.context->device, rec.descriptors, 0), "vkResetDescriptorPool");
  check_vk(vkResetCommandBuffer(rec.commands, 0), "vkResetCommandBuffer");
  auto begin = vk_struct<VkCommandBufferBeginInfo>(VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO);
  begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  check_vk(vkBeginCommandBuffer(rec.commands, &begin), "vkBeginCommandBuffer");
  vkCmdResetQueryPool(rec.commands, rec.timestamps, 0, kMaxTimestamps);
  rec.timestamps_used = 0;
  rec.recording = true;
}

namespace {
// Everything written before is visible to everything after (compute, transfer, host).
void full_barrier(VkCommandBuffer cmd) {
  auto barrier = vk_struct<VkMemoryBarrier2>(VK_STRUCTURE_TYPE_MEMORY_BARRIER_2);
  barrier.srcStageMask = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_2_TRANSFER_BIT;
  barrier.srcAccessMask = VK_ACCESS_2_SHADER_WRITE_BIT | VK_ACCESS_2_TRANSFER_WRITE_BIT;
  barrier.dstStageMask = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_2_TRANSFER_BIT |
                         VK_PIPELINE_STAGE_2_DRAW_INDIRECT_BIT | VK_PIPELINE_STAGE_2_HOST_BIT;
  barrier.dstAccessMask = VK_ACCESS_2_SHADER_READ_BIT | VK_ACCESS_2_SHADER_WRITE_BIT |
                          VK_ACCESS_2_TRANSFER_READ_BIT | VK_ACCESS_2_TRANSFER_WRITE_BIT |
                          VK_ACCESS_2_INDIRECT_COMMAND_READ_BIT | VK_ACCESS_2_HOST_READ_BIT;
  auto dep = vk_struct<VkDependencyInfo>(VK_STRUCTURE_TYPE_DEPENDENCY_INFO);
  dep.memoryBarrierCount = 1;
  dep.pMemoryBarriers = &barrier;
  vkCmdPipelineBarrier2(cmd, &dep);
}
}  // namespace

void cmd_fill(GpuRecorder& rec, const GpuBuffer& buffer, uint32_t value) {
  assert(rec.recording);
  vkCmdFillBuffer(rec.commands, buffer.buffer, 0, VK_WHOLE_SIZE, value);
  full_barrier(rec.commands);
}

std::vector<const GpuBuffer*> gpu_bindings(uint32_t count, const std::vector<GpuBinding>& buffers) {
  std::vector<const GpuBuffer*> out(count, nullptr);
  for (const GpuBinding& b : buffers) {
    if (b.index >= count || out[b.index] != nullptr || b.buffer == nullptr)
      fail("GPU_ERROR", "vulkan", "binding " + std::to_string(b.index) + " of a " + std::to_string(count) +
                                      "-binding shader is out of range, null or given twice", kExitInternal);
    out[b.index] = b.buffer;
  }
  if (buffers.size() != count)
    fail("GPU_ERROR", "vulkan", std::to_string(buffers.size()) + " buffers for a shader with " +
                                    std::to_string(count) + " bindings", kExitInternal);
  return out;
}

VkDescriptorSet storage_buffer_set(GpuRecorder& rec, VkDescriptorSetLayout layout,
                                   const std::vector<const GpuBuffer*>& buffers) {
  VkDevice d = rec.context->device;
  auto alloc = vk_struct<VkDescriptorSetAllocateInfo>(VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO);
  alloc.descriptorPool = rec.descriptors;
  alloc.descriptorSetCount = 1;
  alloc.pSetLayouts = &layout;
  VkDescriptorSet set = VK_NULL_HANDLE;
  check_vk(vkAllocateDescriptorSets(d, &alloc, &set), "vkAllocateDescriptorSets");
  std::vector<VkDescriptorBufferInfo> infos(buffers.size());
  std::vector<VkWriteDescriptorSet> writes(buffers.size());
  for (size_t i = 0; i < buffers.size(); ++i) {
    infos[i] = {buffers[i]->buffer, 0, VK_WHOLE_SIZE};
    writes[i] = vk_struct<VkWriteDescriptorSet>(VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET);
    writes[i].dstSet = set;
    writes[i].dstBinding = uint32_t(i);
    writes[i].descriptorCount = 1;
    writes[i].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
    writes[i].pBufferInfo = &infos[i];
  }
  vkUpdateDescriptorSets(d, uint32_t(writes.size()), writes.data(), 0, nullptr);
  return set;
}

namespace {
// Binds `pipeline` with `buffers` at bindings 0..n-1 and pushes the constants.
void bind_compute(GpuRecorder& rec, const ComputePipeline& pipeline, const std::vector<const GpuBuffer*>& buffers,
                  const void* push_constants) {
  assert(rec.recording && buffers.size() == pipeline.storage_buffers);
  VkDescriptorSet set = storage_buffer_set(rec, pipeline.set_layout, buffers);
  vkCmdBindPipeline(rec.commands, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline.pipeline);
  vkCmdBindDescriptorSets(rec.commands, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline.layout, 0, 1, &set, 0, nullptr);
  if (pipeline.push_constant_bytes)
    vkCmdPushConstants(rec.commands, pipeline.layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, pipeline.push_constant_bytes,
                       push_constants);
}
}  // namespace

void cmd_dispatch(GpuRecorder& rec, const ComputePipeline& pipeline, const std::vector<const GpuBuffer*>& buffers,
                  const void* push_constants, uint32_t gx, uint32_t gy, uint32_t gz) {
  bind_compute(rec, pipeline, buffers, push_constants);
  if (gx && gy && gz) vkCmdDispatch(rec.commands, gx, gy, gz);
  full_barrier(rec.commands);
}

void cmd_dispatch_indirect(GpuRecorder& rec, const ComputePipeline& pipeline,
                           const std::vector<const GpuBuffer*>& buffers, const void* push_constants,
                           const GpuBuffer& args, VkDeviceSize offset) {
  bind_compute(rec, pipeline, buffers, push_constants);
  vkCmdDispatchIndirect(rec.commands, args.buffer, offset);
  full_barrier(rec.commands);
}

uint32_t cmd_timestamp(GpuRecorder& rec) {
  assert(rec.recording && rec.timestamps_used < kMaxTimestamps);
  uint32_t slot = rec.timestamps_used++;
  vkCmdWriteTimestamp2(rec.commands, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, rec.timestamps, slot);
  return slot;
}

void submit_and_wait(GpuRecorder& rec) {
  assert(rec.recording);
  rec.recording = false;
  check_vk(vkEndCommandBuffer(rec.commands), "vkEndCommandBuffer");
  auto submit = vk_struct<VkSubmitInfo>(VK_STRUCTURE_TYPE_SUBMIT_INFO);
  submit.commandBufferCount = 1;
  submit.pCommandBuffers = &rec.commands;
  VkDevice d = rec.context->device;
  check_vk(vkResetFences(d, 1, &rec.fence), "vkResetFences");
  check_vk(vkQueueSubmit(rec.context->queue, 1, &submit, rec.fence), "vkQueueSubmit");
  check_vk(vkWaitForFences(d, 1, &rec.fence, VK_TRUE, UINT64_MAX), "vkWaitForFences");
}

void continue_commands(GpuRecorder& rec) {
  uint32_t timestamps_used = rec.timestamps_used;
  submit_and_wait(rec);
  check_vk(vkResetDescriptorPool(rec.context->device, rec.descriptors, 0), "vkResetDescriptorPool");
  check_vk(vkResetCommandBuffer(rec.commands, 0), "vkResetCommandBuffer");
  auto begin = vk_struct<VkCommandBufferBeginInfo>(VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO);
  begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  check_vk(vkBeginCommandBuffer(rec.commands, &begin), "vkBeginCommandBuffer");
  rec.timestamps_used = timestamps_used;  // the query pool is not reset: earlier slots stay valid
  rec.recording = true;
}

double timestamp_ms(GpuRecorder& rec, uint32_t from, uint32_t to) {
  uint64_t t[2] = {0, 0};
  check_vk(vkGetQueryPoolResults(rec.context->device, rec.timestamps, from, 1, 8, &t[0], 8,
                                 VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT),
           "vkGetQueryPoolResults");
  check_vk(vkGetQueryPoolResults(rec.context->device, rec.timestamps, to, 1, 8, &t[1], 8,
                                 VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT),
           "vkGetQueryPoolResults");
  return double(t[1] - t[0]) * double(rec.context->properties.limits.timestampPeriod) * 1e-6;
}

}  // namespace vgeo
