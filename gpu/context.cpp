// The Vulkan context: the loader opened at run time, an instance (with the Khronos validation
// layer and a recording debug messenger on request), and one device with a compute queue.
#include <dlfcn.h>
#include <link.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <mutex>
#include <fmt/format.h>

#include "photosite/environment.h"
#include "photosite/gpu/kernel.h"
#include "photosite/sanitizer.h"
#include "vk.h"

namespace photosite::gpu {
namespace vk {
const char* result_name(VkResult r) {
  switch (r) {
    case VK_SUCCESS: return "VK_SUCCESS";
    case VK_ERROR_OUT_OF_HOST_MEMORY: return "VK_ERROR_OUT_OF_HOST_MEMORY";
    case VK_ERROR_OUT_OF_DEVICE_MEMORY: return "VK_ERROR_OUT_OF_DEVICE_MEMORY";
    case VK_ERROR_INITIALIZATION_FAILED: return "VK_ERROR_INITIALIZATION_FAILED";
    case VK_ERROR_DEVICE_LOST: return "VK_ERROR_DEVICE_LOST";
    case VK_ERROR_LAYER_NOT_PRESENT: return "VK_ERROR_LAYER_NOT_PRESENT";
    case VK_ERROR_EXTENSION_NOT_PRESENT: return "VK_ERROR_EXTENSION_NOT_PRESENT";
    case VK_ERROR_FEATURE_NOT_PRESENT: return "VK_ERROR_FEATURE_NOT_PRESENT";
    case VK_ERROR_INCOMPATIBLE_DRIVER: return "VK_ERROR_INCOMPATIBLE_DRIVER (no Vulkan driver found)";
    default: return "VkResult error";
  }
}
void check(VkResult r, const char* what) {
  if (r != VK_SUCCESS) fail(fmt::format("Vulkan: {} failed ({}, {})", what, result_name(r), static_cast<int>(r)));
}
}  // namespace vk

namespace {
VKAPI_ATTR VkBool32 VKAPI_CALL on_message(VkDebugUtilsMessageSeverityFlagBitsEXT severity,
                                          VkDebugUtilsMessageTypeFlagsEXT,
                                          const VkDebugUtilsMessengerCallbackDataEXT* data, void* user) {
  const char* sev = severity >= VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT ? "error" : "warning";
  static_cast<Context*>(user)->record_message(fmt::format("{}: {}", sev, data && data->pMessage ? data->pMessage : "?"));
  return VK_FALSE;
}

const char* type_name(VkPhysicalDeviceType t) {
  switch (t) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU: return "discrete";
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU: return "integrated";
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU: return "virtual";
    case VK_PHYSICAL_DEVICE_TYPE_CPU: return "cpu";
    default: return "other";
  }
}
int preference(VkPhysicalDeviceType t) {  // higher is better: real GPUs before CPU drivers
  switch (t) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU: return 4;
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU: return 3;
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU: return 2;
    case VK_PHYSICAL_DEVICE_TYPE_CPU: return 1;
    default: return 0;
  }
}
// Sanitizer builds only: the Vulkan loader and the libraries it opened for the instance (the
// driver, e.g. Mesa's lavapipe with its LLVM, and the layers) are kept mapped after vkDestroyInstance, so
// LeakSanitizer, which runs at exit, names them in its reports instead of "<unknown module>" and
// scripts/lsan.supp can suppress the driver's own leaks by module (docs/robustness.md).
#if PHOTOSITE_ASAN
std::vector<std::string> loaded_libraries() {
  std::vector<std::string> names;
  dl_iterate_phdr([](dl_phdr_info* info, size_t, void* out) {
    if (info->dlpi_name && *info->dlpi_name) static_cast<std::vector<std::string>*>(out)->push_back(info->dlpi_name);
    return 0;
  }, &names);
  return names;
}
void pin_libraries_loaded_since(const std::vector<std::string>& before) {
  for (const auto& name : loaded_libraries())
    if (std::find(before.begin(), before.end(), name) == before.end())
      dlopen(name.c_str(), RTLD_NOW | RTLD_NOLOAD | RTLD_NODELETE);
}
#endif
}  // namespace

void Context::Impl::release(Buffer::Impl& b, bool mapped) {
  if (mapped) f.vkUnmapMemory(device, b.memory);
  if (b.buffer) f.vkDestroyBuffer(device, b.buffer, nullptr);
  if (b.memory) f.vkFreeMemory(device, b.memory, nullptr);
  b = {};
}

void Context::Impl::free_staging() {
  release(staging, staging_mapped != nullptr);
  staging_mapped = nullptr, staging_bytes = 0;
}

// ---- memory types ------------------------------------------------------------------------

int pick_memory_type(const std::vector<uint32_t>& type_flags, uint32_t allowed, uint32_t need, uint32_t prefer,
                     uint32_t avoid) {
  for (int pass = 0; pass < 3; ++pass)
    for (size_t i = 0; i < type_flags.size() && i < 32; ++i) {
      const uint32_t flags = type_flags[i];
      const bool ok = (allowed & (1u << i)) && (flags & need) == need &&
                      (pass == 2 || (flags & prefer) == prefer) && (pass >= 1 || (flags & avoid) == 0);
      if (ok) return static_cast<int>(i);
    }
  return -1;
}

bool unified_memory(const std::vector<uint32_t>& type_flags) {
  const uint32_t all = VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT | VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT |
                       VK_MEMORY_PROPERTY_HOST_COHERENT_BIT | VK_MEMORY_PROPERTY_HOST_CACHED_BIT;
  for (uint32_t f : type_flags)
    if ((f & all) == all) return true;
  return false;
}

namespace {
std::vector<uint32_t> type_flags(const VkPhysicalDeviceMemoryProperties& m) {
  std::vector<uint32_t> t(m.memoryTypeCount);
  for (uint32_t i = 0; i < m.memoryTypeCount; ++i) t[i] = m.memoryTypes[i].propertyFlags;
  return t;
}
// Creates out.buffer (`bytes`, `usage`) and binds memory of the type pick_memory_type() names
// for (need, prefer, avoid); when that allocation fails (device memory or a small BAR window
// full) any other allowed type with `need` is tried. Maps it into *mapped when given.
void allocate(Context::Impl& C, size_t bytes, VkBufferUsageFlags usage, VkMemoryPropertyFlags need,
              VkMemoryPropertyFlags prefer, VkMemoryPropertyFlags avoid, const char* what, Buffer::Impl& out,
              void** mapped) {
  auto& f = C.f;
  VkBufferCreateInfo bci{VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO};
  bci.size = bytes;
  bci.usage = usage;
  bci.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
  vk::check(f.vkCreateBuffer(C.device, &bci, nullptr, &out.buffer), fmt::format("creating {}", what).c_str());
  VkMemoryRequirements req;
  f.vkGetBufferMemoryRequirements(C.device, out.buffer, &req);
  const std::vector<uint32_t> types = type_flags(C.memory);
  const int type = pick_memory_type(types, req.memoryTypeBits, need, prefer, avoid);
  if (type < 0) fail(fmt::format("Vulkan: no memory type for {}", what));
  VkMemoryAllocateInfo mai{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
  mai.allocationSize = req.size;
  mai.memoryTypeIndex = static_cast<uint32_t>(type);
  bool done = f.vkAllocateMemory(C.device, &mai, nullptr, &out.memory) == VK_SUCCESS;
  for (uint32_t i = 0; i < types.size() && !done; ++i)
    if ((req.memoryTypeBits & (1u << i)) && (types[i] & need) == need && static_cast<int>(i) != type) {
      mai.memoryTypeIndex = i;
      done = f.vkAllocateMemory(C.device, &mai, nullptr, &out.memory) == VK_SUCCESS;
    }
  if (!done) fail(fmt::format("Vulkan: allocating {} of {} MB failed", what, bytes >> 20));
  vk::check(f.vkBindBufferMemory(C.device, out.buffer, out.memory, 0), fmt::format("binding {}", what).c_str());
  if (mapped) vk::check(f.vkMapMemory(C.device, out.memory, 0, VK_WHOLE_SIZE, 0, mapped), fmt::format("mapping {}", what).c_str());
}
}  // namespace

Context::Impl::~Impl() {
  if (device) {
    f.vkDeviceWaitIdle(device);
    free_staging();
    for (VkFence fence : transfer_fence)
      if (fence) f.vkDestroyFence(device, fence, nullptr);
    if (transfer_pool) f.vkDestroyCommandPool(device, transfer_pool, nullptr);
    f.vkDestroyDevice(device, nullptr);
  }
  if (messenger) f.vkDestroyDebugUtilsMessengerEXT(instance, messenger, nullptr);
  if (instance) f.vkDestroyInstance(instance, nullptr);
  if (lib) dlclose(lib);
}

void Context::record_message(std::string m) {
  std::lock_guard<std::mutex> lock(mutex_);
  messages_.push_back(std::move(m));
}
std::vector<std::string> Context::messages() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return messages_;
}

Context::Context(const ContextOptions& options) : impl_(std::make_unique<Impl>()) {
  Impl& I = *impl_;
  auto& f = I.f;
#if PHOTOSITE_ASAN
  const auto before = loaded_libraries();
#endif
  I.lib = dlopen("libvulkan.so.1", RTLD_NOW | RTLD_LOCAL);
  if (!I.lib)
    fail_parameter("backend",
                   "Vulkan: the Vulkan loader (libvulkan.so.1) is not installed; install libvulkan1 and a "
                   "driver (mesa-vulkan-drivers for lavapipe), or use ",
                   " cpu");
  f.vkGetInstanceProcAddr = reinterpret_cast<PFN_vkGetInstanceProcAddr>(dlsym(I.lib, "vkGetInstanceProcAddr"));
  if (!f.vkGetInstanceProcAddr) fail("Vulkan: libvulkan.so.1 has no vkGetInstanceProcAddr");
#define PHOTOSITE_VK_LOAD_GLOBAL(name) f.name = reinterpret_cast<PFN_##name>(f.vkGetInstanceProcAddr(nullptr, #name));
  PHOTOSITE_VK_GLOBAL(PHOTOSITE_VK_LOAD_GLOBAL)
#undef PHOTOSITE_VK_LOAD_GLOBAL

  const auto validation_env = env::get(env::Var::VkValidation);
  validation_ = options.validation || (validation_env && *validation_env != "0");
  std::vector<const char*> layers, extensions;
  bool sync_validation = false;
  if (validation_) {
    uint32_t n = 0;
    f.vkEnumerateInstanceLayerProperties(&n, nullptr);
    std::vector<VkLayerProperties> props(n);
    f.vkEnumerateInstanceLayerProperties(&n, props.data());
    bool found = false;
    for (auto& p : props) found |= std::strcmp(p.layerName, "VK_LAYER_KHRONOS_validation") == 0;
    if (!found)
      fail("Vulkan: validation requested (PHOTOSITE_VK_VALIDATION) but VK_LAYER_KHRONOS_validation "
           "is not installed (Debian: vulkan-validationlayers)");
    layers.push_back("VK_LAYER_KHRONOS_validation");
    extensions.push_back(VK_EXT_DEBUG_UTILS_EXTENSION_NAME);
    // Synchronization validation too, where the layer offers it: a missing barrier between two
    // kernels, or between a copy and a kernel, is then a reported hazard, not a silent race.
    const auto sv = env::get(env::Var::VkSyncValidation);
    const bool want_sync = !(sv && *sv == "0");
    uint32_t ne = 0;
    f.vkEnumerateInstanceExtensionProperties("VK_LAYER_KHRONOS_validation", &ne, nullptr);
    std::vector<VkExtensionProperties> ext(ne);
    f.vkEnumerateInstanceExtensionProperties("VK_LAYER_KHRONOS_validation", &ne, ext.data());
    for (auto& e : ext)
      sync_validation |= want_sync && std::strcmp(e.extensionName, VK_EXT_VALIDATION_FEATURES_EXTENSION_NAME) == 0;
    if (sync_validation) extensions.push_back(VK_EXT_VALIDATION_FEATURES_EXTENSION_NAME);
  }
  VkApplicationInfo app{VK_STRUCTURE_TYPE_APPLICATION_INFO};
  app.pApplicationName = "photosite";
  app.apiVersion = VK_API_VERSION_1_1;
  VkDebugUtilsMessengerCreateInfoEXT dm{VK_STRUCTURE_TYPE_DEBUG_UTILS_MESSENGER_CREATE_INFO_EXT};
  dm.messageSeverity = VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT | VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT;
  dm.messageType = VK_DEBUG_UTILS_MESSAGE_TYPE_GENERAL_BIT_EXT | VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT |
                   VK_DEBUG_UTILS_MESSAGE_TYPE_PERFORMANCE_BIT_EXT;
  dm.pfnUserCallback = on_message;
  dm.pUserData = this;
  VkInstanceCreateInfo ici{VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO};
  ici.pApplicationInfo = &app;
  ici.enabledLayerCount = static_cast<uint32_t>(layers.size());
  ici.ppEnabledLayerNames = layers.data();
  ici.enabledExtensionCount = static_cast<uint32_t>(extensions.size());
  ici.ppEnabledExtensionNames = extensions.data();
  const VkValidationFeatureEnableEXT sync = VK_VALIDATION_FEATURE_ENABLE_SYNCHRONIZATION_VALIDATION_EXT;
  VkValidationFeaturesEXT vf{VK_STRUCTURE_TYPE_VALIDATION_FEATURES_EXT};
  vf.enabledValidationFeatureCount = 1;
  vf.pEnabledValidationFeatures = &sync;
  vf.pNext = &dm;  // (dm itself keeps pNext null: it is also given to vkCreateDebugUtilsMessengerEXT)
  if (validation_) ici.pNext = sync_validation ? static_cast<const void*>(&vf) : &dm;
  const VkResult created = f.vkCreateInstance(&ici, nullptr, &I.instance);
#if PHOTOSITE_ASAN
  pin_libraries_loaded_since(before);
#endif
  if (created == VK_ERROR_INCOMPATIBLE_DRIVER)
    fail("Vulkan: no Vulkan driver found (install mesa-vulkan-drivers for lavapipe, or a GPU driver; "
         "VK_DRIVER_FILES / VK_ICD_FILENAMES may point elsewhere)");
  // The loader also answers VK_ERROR_OUT_OF_HOST_MEMORY when a driver manifest it was pointed to
  // is not valid JSON (a memory problem is then the wrong lead): name the manifests given.
  if (created == VK_ERROR_OUT_OF_HOST_MEMORY)
    for (env::Var v : {env::Var::VkDriverFiles, env::Var::VkIcdFilenames})
      if (auto files = env::get(v))
        fail(std::string("Vulkan: creating an instance failed (VK_ERROR_OUT_OF_HOST_MEMORY), which the Vulkan loader also "
                         "answers for a driver manifest it cannot read: check ") + env::name(v) + "=" + *files);
  vk::check(created, "creating an instance");
#define PHOTOSITE_VK_LOAD_INSTANCE(name) f.name = reinterpret_cast<PFN_##name>(f.vkGetInstanceProcAddr(I.instance, #name));
  PHOTOSITE_VK_INSTANCE(PHOTOSITE_VK_LOAD_INSTANCE)
#undef PHOTOSITE_VK_LOAD_INSTANCE
  if (validation_) vk::check(f.vkCreateDebugUtilsMessengerEXT(I.instance, &dm, nullptr, &I.messenger), "creating the debug messenger");

  uint32_t n = 0;
  vk::check(f.vkEnumeratePhysicalDevices(I.instance, &n, nullptr), "listing devices");
  std::vector<VkPhysicalDevice> devices(n);
  if (n) vk::check(f.vkEnumeratePhysicalDevices(I.instance, &n, devices.data()), "listing devices");
  // The kernels need a compute queue and 64-bit floats (the sensor's ADC and photon integral
  // are computed in double, as on the CPU, so DN agree exactly).
  int best = -1, best_score = -1;
  std::string rejected;
  for (uint32_t i = 0; i < n; ++i) {
    VkPhysicalDeviceProperties p;
    f.vkGetPhysicalDeviceProperties(devices[i], &p);
    VkPhysicalDeviceFeatures feat;
    f.vkGetPhysicalDeviceFeatures(devices[i], &feat);
    uint32_t nq = 0;
    f.vkGetPhysicalDeviceQueueFamilyProperties(devices[i], &nq, nullptr);
    std::vector<VkQueueFamilyProperties> q(nq);
    f.vkGetPhysicalDeviceQueueFamilyProperties(devices[i], &nq, q.data());
    bool compute = false;
    for (auto& fam : q) compute |= (fam.queueFlags & VK_QUEUE_COMPUTE_BIT) != 0;
    if (!compute || !feat.shaderFloat64 || p.apiVersion < VK_API_VERSION_1_1) {
      rejected += fmt::format(" '{}' ({})", p.deviceName,
                              !compute ? "no compute queue" : !feat.shaderFloat64 ? "no shaderFloat64" : "Vulkan < 1.1");
      continue;
    }
    int score = options.prefer_gpu ? preference(p.deviceType) : (p.deviceType == VK_PHYSICAL_DEVICE_TYPE_CPU ? 5 : preference(p.deviceType));
    if (score > best_score) best = static_cast<int>(i), best_score = score;
  }
  if (best < 0)
    fail(n == 0 ? std::string("Vulkan: no Vulkan device found (no driver: install mesa-vulkan-drivers for lavapipe, or a GPU driver)")
                : "Vulkan: no usable device:" + rejected);
  I.physical = devices[best];
  VkPhysicalDeviceProperties p;
  f.vkGetPhysicalDeviceProperties(I.physical, &p);
  f.vkGetPhysicalDeviceMemoryProperties(I.physical, &I.memory);
  uint32_t nq = 0;
  f.vkGetPhysicalDeviceQueueFamilyProperties(I.physical, &nq, nullptr);
  std::vector<VkQueueFamilyProperties> q(nq);
  f.vkGetPhysicalDeviceQueueFamilyProperties(I.physical, &nq, q.data());
  for (uint32_t i = 0; i < nq; ++i)
    if (q[i].queueFlags & VK_QUEUE_COMPUTE_BIT) {
      I.queue_family = i;
      // Prefer a compute family without graphics (a dedicated compute queue), else the first.
      if (!(q[i].queueFlags & VK_QUEUE_GRAPHICS_BIT)) break;
    }
  info_.name = p.deviceName;
  info_.type = type_name(p.deviceType);
  info_.cpu = p.deviceType == VK_PHYSICAL_DEVICE_TYPE_CPU;
  info_.vendor_id = p.vendorID;
  info_.api_version = p.apiVersion;
  info_.timestamps = q[I.queue_family].timestampValidBits > 0 && p.limits.timestampPeriod > 0;
  info_.timestamp_period_ns = p.limits.timestampPeriod;

  const float priority = 1.0f;
  VkDeviceQueueCreateInfo qci{VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO};
  qci.queueFamilyIndex = I.queue_family;
  qci.queueCount = 1;
  qci.pQueuePriorities = &priority;
  VkPhysicalDeviceFeatures enabled{};
  enabled.shaderFloat64 = VK_TRUE;
  // Direct (mapped storage buffers) where some memory is device-local, host-visible, coherent
  // and cached at once (lavapipe, integrated GPUs); staged copies otherwise.
  const bool unified = unified_memory(type_flags(I.memory));
  Staging mode = options.staging;
  if (const auto e = env::get(env::Var::VkStaging); e && mode == Staging::Auto)
    mode = *e == "0" ? Staging::Direct : Staging::Staged;
  I.staged = mode == Staging::Staged || (mode == Staging::Auto && !unified);
  // Staged contexts can import the caller's pages for large copies (of buffers that ask for it:
  // Buffer::set_host_import) where the device offers VK_EXT_external_memory_host (NVIDIA's 580
  // driver and Mesa's lavapipe do), with the alignment it needs.
  std::vector<const char*> device_extensions;
  const auto import_env = env::get(env::Var::VkHostImport);
  if (I.staged && options.host_import && !(import_env && *import_env == "0")) {
    uint32_t ne = 0;
    f.vkEnumerateDeviceExtensionProperties(I.physical, nullptr, &ne, nullptr);
    std::vector<VkExtensionProperties> ext(ne);
    if (ne) f.vkEnumerateDeviceExtensionProperties(I.physical, nullptr, &ne, ext.data());
    bool offered = false;
    for (auto& e : ext) offered |= std::strcmp(e.extensionName, VK_EXT_EXTERNAL_MEMORY_HOST_EXTENSION_NAME) == 0;
    if (offered) {
      VkPhysicalDeviceExternalMemoryHostPropertiesEXT hp{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_EXTERNAL_MEMORY_HOST_PROPERTIES_EXT};
      VkPhysicalDeviceProperties2 p2{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2};
      p2.pNext = &hp;
      f.vkGetPhysicalDeviceProperties2(I.physical, &p2);
      const VkDeviceSize a = hp.minImportedHostPointerAlignment;
      if (a > 0 && (a & (a - 1)) == 0 && a <= (VkDeviceSize{1} << 21)) {
        device_extensions.push_back(VK_EXT_EXTERNAL_MEMORY_HOST_EXTENSION_NAME);
        I.import_alignment = static_cast<size_t>(a);
      }
    }
  }
  VkDeviceCreateInfo dci{VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO};
  dci.queueCreateInfoCount = 1;
  dci.pQueueCreateInfos = &qci;
  dci.pEnabledFeatures = &enabled;
  dci.enabledExtensionCount = static_cast<uint32_t>(device_extensions.size());
  dci.ppEnabledExtensionNames = device_extensions.data();
  vk::check(f.vkCreateDevice(I.physical, &dci, nullptr, &I.device), "creating the device");
#define PHOTOSITE_VK_LOAD_DEVICE(name) f.name = reinterpret_cast<PFN_##name>(f.vkGetDeviceProcAddr(I.device, #name));
  PHOTOSITE_VK_DEVICE(PHOTOSITE_VK_LOAD_DEVICE)
#undef PHOTOSITE_VK_LOAD_DEVICE
  f.vkGetDeviceQueue(I.device, I.queue_family, 0, &I.queue);
  I.host_import = I.import_alignment > 0 && f.vkGetMemoryHostPointerPropertiesEXT != nullptr;
  I.import_always = I.host_import && import_env && *import_env == "1";
  info_.staged = I.staged;
  info_.host_import = I.host_import;
  if (I.staged) {
    VkCommandPoolCreateInfo cpi{VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
    cpi.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
    cpi.queueFamilyIndex = I.queue_family;
    vk::check(f.vkCreateCommandPool(I.device, &cpi, nullptr, &I.transfer_pool), "creating a command pool");
    VkCommandBufferAllocateInfo cai{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
    cai.commandPool = I.transfer_pool;
    cai.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    cai.commandBufferCount = 2;
    vk::check(f.vkAllocateCommandBuffers(I.device, &cai, I.transfer_cmd), "allocating command buffers");
    VkFenceCreateInfo fci{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
    for (VkFence& fence : I.transfer_fence) vk::check(f.vkCreateFence(I.device, &fci, nullptr, &fence), "creating a fence");
  }
}

Context::~Context() { kernels_.clear(); }  // pipelines before the device

Kernel& Context::kernel(const std::string& name, int buffers, uint32_t push_bytes) {
  auto it = kernels_.find(name);
  if (it == kernels_.end()) it = kernels_.emplace(name, std::make_unique<Kernel>(*this, name, buffers, push_bytes)).first;
  if (it->second->buffers() != buffers || it->second->push_bytes() != push_bytes)
    internal_error("gpu: kernel " + name + " requested with a different interface");
  return *it->second;
}

bool available(std::string* why, DeviceInfo* info) {
  try {
    Context ctx;
    if (info) *info = ctx.device();
    return true;
  } catch (const Error& e) {
    if (why) *why = e.what();
    return false;
  }
}

Context& shared_context() {
  // Made on first use (a failed construction throws and is retried next call), in the process
  // that uses it. A process forked after the context was opened (a DataLoader worker, a
  // multiprocessing pool) inherits the driver's objects but not its threads: its first submission
  // would wait for ever. It is refused instead (`auto` then runs the CPU path, which gives the
  // same bits); a child of a process that never opened Vulkan opens its own.
  static std::mutex m;
  static Context* ctx = nullptr;
  static pid_t owner = 0;
  std::lock_guard<std::mutex> lock(m);
  if (ctx && owner != getpid())
    fail(fmt::format("Vulkan: the device was opened by process {} before this process (pid {}) was forked from it, "
                     "and a forked process cannot use it (its driver threads did not survive the fork): open the "
                     "Vulkan backend only after forking, or start workers with the 'spawn' method",
                     owner, getpid()));
  if (!ctx) {
    ctx = new Context;
    owner = getpid();
  }
  return *ctx;
}

// ---- buffers -----------------------------------------------------------------------------

Buffer::Buffer(Context& ctx, size_t bytes) : ctx_(ctx), bytes_(bytes), impl_(std::make_unique<Impl>()) {
  auto& C = ctx.impl();
  // Staged: device-local memory, reached by copies, kept out of host-visible device memory where
  // it can be (on a GPU without resizable BAR that window is 256 MB, better left to mapping).
  // Direct: host-visible and coherent, mapped once, preferably also device-local (a CPU driver's
  // memory, a GPU's resizable BAR).
  const size_t words = std::max<size_t>(4, (bytes + 3) & ~size_t{3});  // storage buffers are read in words
  if (C.staged)
    allocate(C, words,
             VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
             0, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT, VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT, "a buffer", *impl_, nullptr);
  else
    allocate(C, words, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
             VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT,
             VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT, 0, "a buffer", *impl_, &mapped_);
}

Buffer& BufferCache::get(const std::string& name, size_t bytes) {
  auto& b = buffers_[name];
  if (!b || b->bytes() != bytes) {
    b = std::make_unique<Buffer>(ctx_, bytes);
    b->set_host_import(host_import_);
  }
  return *b;
}

void BufferCache::set_host_import(bool on) {
  host_import_ = on;
  for (auto& [name, b] : buffers_) b->set_host_import(on);
}

Buffer* BufferCache::find(const std::string& name) {
  const auto it = buffers_.find(name);
  return it == buffers_.end() ? nullptr : it->second.get();
}

Buffer::~Buffer() { ctx_.impl().release(*impl_, mapped_ != nullptr); }

namespace {
// Staged transfers: host ↔ the context's staging buffer (memcpy) ↔ the device buffer (a copy
// command), in chunks of at most kStagingChunk bytes through two slots of the staging buffer, so
// that the host's memcpy of one chunk overlaps the device's copy of the one before (an upload) or
// after (a download), and the memcpy is split over the OpenMP threads. (On the lent H200, Intel
// Xeon at 2 threads, docs/vulkan.md, the earlier one-slot, one-thread copies moved the night
// tail's 88 MB in 17.9 ms, 4.9 GB/s: each chunk's memcpy and its device copy one after the other.)
constexpr size_t kStagingChunk = size_t{4} << 20;

void ensure_staging(Context::Impl& C, size_t bytes) {
  if (C.staging_bytes >= bytes) return;
  C.free_staging();
  // Host-cached and not device-local where offered: the CPU reads downloads from it at memory speed.
  allocate(C, bytes, VK_BUFFER_USAGE_TRANSFER_SRC_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
           VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT,
           VK_MEMORY_PROPERTY_HOST_CACHED_BIT, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT, "the staging buffer", C.staging,
           &C.staging_mapped);
  C.staging_bytes = bytes;
}

// memcpy over the OpenMP threads in blocks of 256 KB (one thread where the caller is inside a
// parallel region, or the copy is small).
void copy_parallel(void* dst, const void* src, size_t n) {
  constexpr size_t kBlock = size_t{256} << 10;
  const auto blocks = static_cast<std::ptrdiff_t>((n + kBlock - 1) / kBlock);
#pragma omp parallel for schedule(static) if (blocks > 1)
  for (std::ptrdiff_t b = 0; b < blocks; ++b) {
    const size_t o = static_cast<size_t>(b) * kBlock;
    std::memcpy(static_cast<char*>(dst) + o, static_cast<const char*>(src) + o, std::min(kBlock, n - o));
  }
}

// Records and submits the copy of c bytes between the device buffer (at device_offset) and a
// host-side buffer (at host_offset: a staging slot, or an imported range of the caller's pages),
// with transfer_cmd[slot] and transfer_fence[slot].
void submit_copy(Context::Impl& C, int slot, VkBuffer device_buffer, size_t device_offset, VkBuffer host_buffer,
                 size_t host_offset, size_t c, bool up) {
  auto& f = C.f;
  VkCommandBuffer cmd = C.transfer_cmd[slot];
  vk::check(f.vkResetCommandBuffer(cmd, 0), "resetting a command buffer");
  VkCommandBufferBeginInfo bi{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
  bi.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  vk::check(f.vkBeginCommandBuffer(cmd, &bi), "beginning a command buffer");
  // Earlier submissions' kernels and copies on the buffer finish (and their writes are
  // available) before this copy.
  VkMemoryBarrier before{VK_STRUCTURE_TYPE_MEMORY_BARRIER};
  before.srcAccessMask = VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_TRANSFER_WRITE_BIT;
  before.dstAccessMask = VK_ACCESS_TRANSFER_READ_BIT | VK_ACCESS_TRANSFER_WRITE_BIT;
  f.vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT,
                         VK_PIPELINE_STAGE_TRANSFER_BIT, 0, 1, &before, 0, nullptr, 0, nullptr);
  VkBufferCopy region{};
  region.size = c;
  region.srcOffset = up ? host_offset : device_offset;
  region.dstOffset = up ? device_offset : host_offset;
  f.vkCmdCopyBuffer(cmd, up ? host_buffer : device_buffer, up ? device_buffer : host_buffer, 1, &region);
  // The copy's writes are visible to later kernels (upload) or to the host (download).
  VkMemoryBarrier after{VK_STRUCTURE_TYPE_MEMORY_BARRIER};
  after.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
  after.dstAccessMask = up ? VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT : VK_ACCESS_HOST_READ_BIT;
  f.vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT,
                         up ? VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT : VK_PIPELINE_STAGE_HOST_BIT, 0, 1, &after, 0,
                         nullptr, 0, nullptr);
  vk::check(f.vkEndCommandBuffer(cmd), "ending a command buffer");
  VkSubmitInfo si{VK_STRUCTURE_TYPE_SUBMIT_INFO};
  si.commandBufferCount = 1;
  si.pCommandBuffers = &cmd;
  vk::check(f.vkResetFences(C.device, 1, &C.transfer_fence[slot]), "resetting a fence");
  std::lock_guard<std::mutex> q(C.queue_mutex);
  vk::check(f.vkQueueSubmit(C.queue, 1, &si, C.transfer_fence[slot]), "submitting a copy");
}

// The copy of chunk [offset, offset + c) of the device buffer through staging slot `slot`.
void submit_chunk(Context::Impl& C, int slot, VkBuffer device_buffer, size_t device_offset, size_t c, bool up) {
  submit_copy(C, slot, device_buffer, device_offset, C.staging.buffer, static_cast<size_t>(slot) * kStagingChunk, c,
              up);
}

// One copy between the device buffer and the caller's own pages, imported for it
// (VK_EXT_external_memory_host): the device's copy engine reads (writes) host memory itself, with
// no memcpy through the staging slots. The import covers [p, p + n) widened to the device's
// alignment (whole pages the process has mapped; the copy touches [p, p + n) alone) and lasts
// the copy. False, with nothing copied, where the driver refuses the range (memory it cannot
// import, e.g. a read-only file mapping, or no coherent host-visible type for it): the caller
// then stages.
bool imported_copy(Context::Impl& C, VkBuffer device_buffer, size_t offset, const void* src, void* dst, size_t n) {
  auto& f = C.f;
  const bool up = src != nullptr;
  const auto p = reinterpret_cast<uintptr_t>(up ? src : dst);
  const uintptr_t a = C.import_alignment, base = p & ~(a - 1), end = (p + n + a - 1) & ~(a - 1);
  const size_t bytes = end - base;
  void* host = reinterpret_cast<void*>(base);
  const auto handle = VK_EXTERNAL_MEMORY_HANDLE_TYPE_HOST_ALLOCATION_BIT_EXT;
  VkMemoryHostPointerPropertiesEXT hp{VK_STRUCTURE_TYPE_MEMORY_HOST_POINTER_PROPERTIES_EXT};
  if (f.vkGetMemoryHostPointerPropertiesEXT(C.device, handle, host, &hp) != VK_SUCCESS) return false;
  Buffer::Impl imp;
  struct Release {  // the buffer and memory go when the copy is done, or when it fails
    Context::Impl& C;
    Buffer::Impl& b;
    ~Release() { C.release(b, false); }
  } release{C, imp};
  VkExternalMemoryBufferCreateInfo ebi{VK_STRUCTURE_TYPE_EXTERNAL_MEMORY_BUFFER_CREATE_INFO};
  ebi.handleTypes = handle;
  VkBufferCreateInfo bci{VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO};
  bci.pNext = &ebi;
  bci.size = bytes;
  bci.usage = up ? VK_BUFFER_USAGE_TRANSFER_SRC_BIT : VK_BUFFER_USAGE_TRANSFER_DST_BIT;
  bci.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
  if (f.vkCreateBuffer(C.device, &bci, nullptr, &imp.buffer) != VK_SUCCESS) return false;
  VkMemoryRequirements req;
  f.vkGetBufferMemoryRequirements(C.device, imp.buffer, &req);
  // Host-visible and coherent: the host's writes before an upload, and the device's writes
  // before a download's fence, need no flush or invalidate (which only a mapping could do).
  const int type = pick_memory_type(type_flags(C.memory), req.memoryTypeBits & hp.memoryTypeBits,
                                    VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT, 0);
  if (type < 0 || req.size > bytes) return false;
  VkImportMemoryHostPointerInfoEXT imi{VK_STRUCTURE_TYPE_IMPORT_MEMORY_HOST_POINTER_INFO_EXT};
  imi.handleType = handle;
  imi.pHostPointer = host;
  VkMemoryAllocateInfo mai{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
  mai.pNext = &imi;
  mai.allocationSize = bytes;
  mai.memoryTypeIndex = static_cast<uint32_t>(type);
  if (f.vkAllocateMemory(C.device, &mai, nullptr, &imp.memory) != VK_SUCCESS) return false;
  vk::check(f.vkBindBufferMemory(C.device, imp.buffer, imp.memory, 0), "binding imported host memory");
  submit_copy(C, 0, device_buffer, offset, imp.buffer, static_cast<size_t>(p - base), n, up);
  vk::check(f.vkWaitForFences(C.device, 1, &C.transfer_fence[0], VK_TRUE, UINT64_MAX), "waiting for a copy");
  return true;
}

// Returns whether the copy went straight from (to) the caller's imported pages (asked for by
// `import`, or by PHOTOSITE_VK_HOST_IMPORT=1, where the context offers it).
bool staged_copy(Context::Impl& C, VkBuffer device_buffer, size_t offset, const void* src, void* dst, size_t n,
                 bool import) {
  std::lock_guard<std::mutex> lock(C.transfer_mutex);
  if (C.host_import && (import || C.import_always) && n >= kHostImportMinBytes &&
      imported_copy(C, device_buffer, offset, src, dst, n))
    return true;
  ensure_staging(C, 2 * kStagingChunk);
  const bool up = src != nullptr;
  const size_t chunks = (n + kStagingChunk - 1) / kStagingChunk;
  auto slot_ptr = [&](size_t k) { return static_cast<char*>(C.staging_mapped) + (k % 2) * kStagingChunk; };
  auto size_of = [&](size_t k) { return std::min(kStagingChunk, n - k * kStagingChunk); };
  auto wait = [&](size_t k) {
    vk::check(C.f.vkWaitForFences(C.device, 1, &C.transfer_fence[k % 2], VK_TRUE, UINT64_MAX), "waiting for a copy");
  };
  if (up) {
    // Chunk k is written into its slot once the copy of chunk k - 2 (the slot's last use) is done.
    for (size_t k = 0; k < chunks; ++k) {
      if (k >= 2) wait(k - 2);
      copy_parallel(slot_ptr(k), static_cast<const char*>(src) + k * kStagingChunk, size_of(k));
      submit_chunk(C, static_cast<int>(k % 2), device_buffer, offset + k * kStagingChunk, size_of(k), true);
    }
    for (size_t k = chunks >= 2 ? chunks - 2 : 0; k < chunks; ++k) wait(k);
  } else {
    // Chunk k + 2 is asked for as soon as chunk k has been read out of its slot.
    for (size_t k = 0; k < std::min<size_t>(chunks, 2); ++k)
      submit_chunk(C, static_cast<int>(k), device_buffer, offset + k * kStagingChunk, size_of(k), false);
    for (size_t k = 0; k < chunks; ++k) {
      wait(k);
      copy_parallel(static_cast<char*>(dst) + k * kStagingChunk, slot_ptr(k), size_of(k));
      if (k + 2 < chunks)
        submit_chunk(C, static_cast<int>(k % 2), device_buffer, offset + (k + 2) * kStagingChunk, size_of(k + 2), false);
    }
  }
  return false;
}
}  // namespace

void Buffer::upload(const void* src, size_t n, size_t offset) {
  if (offset + n > bytes_) internal_error("gpu::Buffer::upload beyond the buffer");
  if (n == 0) return;
  if (mapped_) std::memcpy(static_cast<char*>(mapped_) + offset, src, n);
  else if (staged_copy(ctx_.impl(), impl_->buffer, offset, src, nullptr, n, host_import_)) ctx_.count_imported(n);
  ctx_.count_upload(n);
}
void Buffer::download(void* dst, size_t n, size_t offset) const {
  if (offset + n > bytes_) internal_error("gpu::Buffer::download beyond the buffer");
  if (n == 0) return;
  if (mapped_) std::memcpy(dst, static_cast<const char*>(mapped_) + offset, n);
  else if (staged_copy(ctx_.impl(), impl_->buffer, offset, nullptr, dst, n, host_import_)) ctx_.count_imported(n);
  ctx_.count_download(n);
}


}  // namespace photosite::gpu
