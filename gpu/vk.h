// Vulkan entry points loaded at run time (dlopen libvulkan.so.1, then vkGetInstanceProcAddr /
// vkGetDeviceProcAddr), so photosite links no Vulkan library and starts without one.
#pragma once
#include <mutex>
#define VK_NO_PROTOTYPES
#include <vulkan/vulkan.h>

#include <string>

#include "photosite/error.h"
#include "photosite/gpu/context.h"

namespace photosite::gpu::vk {

#define PHOTOSITE_VK_GLOBAL(X) \
  X(vkCreateInstance) X(vkEnumerateInstanceLayerProperties) X(vkEnumerateInstanceExtensionProperties)
#define PHOTOSITE_VK_INSTANCE(X)                                                              \
  X(vkDestroyInstance) X(vkEnumeratePhysicalDevices) X(vkGetPhysicalDeviceProperties)          \
  X(vkGetPhysicalDeviceQueueFamilyProperties) X(vkGetPhysicalDeviceFeatures)                   \
  X(vkGetPhysicalDeviceMemoryProperties) X(vkCreateDevice) X(vkGetDeviceProcAddr)              \
  X(vkCreateDebugUtilsMessengerEXT) X(vkDestroyDebugUtilsMessengerEXT)                         \
  X(vkEnumerateDeviceExtensionProperties) X(vkGetPhysicalDeviceProperties2)
#define PHOTOSITE_VK_DEVICE(X)                                                                 \
  X(vkDestroyDevice) X(vkGetDeviceQueue) X(vkDeviceWaitIdle) X(vkCreateBuffer)                 \
  X(vkDestroyBuffer) X(vkGetBufferMemoryRequirements) X(vkAllocateMemory) X(vkFreeMemory)       \
  X(vkBindBufferMemory) X(vkMapMemory) X(vkUnmapMemory) X(vkCreateShaderModule)                 \
  X(vkDestroyShaderModule) X(vkCreateDescriptorSetLayout) X(vkDestroyDescriptorSetLayout)       \
  X(vkCreatePipelineLayout) X(vkDestroyPipelineLayout) X(vkCreateComputePipelines)              \
  X(vkDestroyPipeline) X(vkCreateDescriptorPool) X(vkDestroyDescriptorPool)                     \
  X(vkResetDescriptorPool) X(vkAllocateDescriptorSets) X(vkUpdateDescriptorSets)                \
  X(vkCreateCommandPool) X(vkDestroyCommandPool) X(vkAllocateCommandBuffers)                    \
  X(vkResetCommandBuffer) X(vkBeginCommandBuffer) X(vkEndCommandBuffer) X(vkCmdBindPipeline)    \
  X(vkCmdBindDescriptorSets) X(vkCmdPushConstants) X(vkCmdDispatch) X(vkCmdPipelineBarrier)     \
  X(vkQueueSubmit) X(vkCreateFence) X(vkDestroyFence) X(vkWaitForFences) X(vkResetFences)       \
  X(vkCreateQueryPool) X(vkDestroyQueryPool) X(vkCmdResetQueryPool) X(vkCmdWriteTimestamp)     \
  X(vkGetQueryPoolResults) X(vkCmdCopyBuffer)                                                  \
  X(vkGetMemoryHostPointerPropertiesEXT) /* VK_EXT_external_memory_host: null where not enabled */

struct Functions {
  PFN_vkGetInstanceProcAddr vkGetInstanceProcAddr = nullptr;
#define PHOTOSITE_VK_DECLARE(name) PFN_##name name = nullptr;
  PHOTOSITE_VK_GLOBAL(PHOTOSITE_VK_DECLARE)
  PHOTOSITE_VK_INSTANCE(PHOTOSITE_VK_DECLARE)
  PHOTOSITE_VK_DEVICE(PHOTOSITE_VK_DECLARE)
#undef PHOTOSITE_VK_DECLARE
};

// Throws a bad-input Error "Vulkan: <what> failed (VK_ERROR_...)" on a failed call.
void check(VkResult r, const char* what);
const char* result_name(VkResult r);

}  // namespace photosite::gpu::vk

namespace photosite::gpu {
struct Buffer::Impl {
  VkBuffer buffer = VK_NULL_HANDLE;
  VkDeviceMemory memory = VK_NULL_HANDLE;
};
struct Context::Impl {
  void* lib = nullptr;
  vk::Functions f;
  VkInstance instance = VK_NULL_HANDLE;
  VkDebugUtilsMessengerEXT messenger = VK_NULL_HANDLE;
  VkPhysicalDevice physical = VK_NULL_HANDLE;
  VkDevice device = VK_NULL_HANDLE;
  VkQueue queue = VK_NULL_HANDLE;
  uint32_t queue_family = 0;
  VkPhysicalDeviceMemoryProperties memory{};
  std::mutex queue_mutex;  // the one queue, submitted to from any thread
  // Staged transfers (DeviceInfo::staged): one host-visible, cached staging buffer of two slots,
  // each with its command buffer and fence (the host fills or empties one slot while the device
  // copies the other), shared by every Buffer of the context under transfer_mutex.
  bool staged = false;
  std::mutex transfer_mutex;
  VkCommandPool transfer_pool = VK_NULL_HANDLE;
  VkCommandBuffer transfer_cmd[2] = {VK_NULL_HANDLE, VK_NULL_HANDLE};
  VkFence transfer_fence[2] = {VK_NULL_HANDLE, VK_NULL_HANDLE};
  Buffer::Impl staging;  // its buffer and memory
  void* staging_mapped = nullptr;
  size_t staging_bytes = 0;
  // Staged transfers of at least kHostImportMinBytes can copy straight from (to) the caller's own
  // pages, imported for the copy with VK_EXT_external_memory_host (DeviceInfo::host_import), where
  // the device offers it and the buffer asks for it (Buffer::set_host_import): no memcpy through
  // the staging slots. import_alignment is the device's
  // minImportedHostPointerAlignment (the imported range is widened to it).
  bool host_import = false;
  bool import_always = false;  // PHOTOSITE_VK_HOST_IMPORT=1: every buffer's, not only those asked to
  size_t import_alignment = 0;
  void free_staging();
  // Destroys b's buffer and frees its memory (unmapped first where `mapped`), where made.
  void release(Buffer::Impl& b, bool mapped);
  ~Impl();
};

}  // namespace photosite::gpu
