// The Vulkan compute backend's host layer, part 1: the context (instance, device, queue) and
// storage buffers. Vulkan itself stays behind these classes (no Vulkan header here): the loader
// is opened at run time (dlopen libvulkan.so.1), so a machine without it runs the CPU path and
// `--backend vulkan` there fails with a message, not at start-up.
//
// Environment:
//   PHOTOSITE_VK_VALIDATION=1  enable VK_LAYER_KHRONOS_validation (synchronization validation
//                              included) and record every message (tests fail on any); an
//                              error if the layer is not installed.
//   PHOTOSITE_VK_STAGING=1|0   force staged copies or mapped buffers (ContextOptions::staging).
//   VK_DRIVER_FILES / VK_ICD_FILENAMES  the loader's own driver selection (lavapipe in CI).
#pragma once
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

namespace photosite::gpu {

struct DeviceInfo {
  std::string name;         // e.g. "llvmpipe (LLVM 15.0.6, 256 bits)", "NVIDIA GeForce ..."
  std::string type;         // discrete, integrated, virtual, cpu, other
  bool cpu = false;         // a CPU implementation (lavapipe, SwiftShader): slower than native code
  uint32_t vendor_id = 0, api_version = 0;
  bool timestamps = false;  // compute queue writes timestamps
  double timestamp_period_ns = 0;
  // Transfers go through staging copies (a discrete GPU: storage buffers in device-local memory,
  // copied to and from a host-cached staging buffer) rather than through mapped storage buffers
  // (a CPU driver or an integrated GPU, whose memory is device-local, host-visible and cached).
  bool staged = false;
};

// How Buffer::upload / download reach device memory: Auto picks Staged unless a memory type is
// device-local, host-visible, coherent and cached all at once (where mapping is free). Reading
// a GPU's BAR window from the CPU is uncached (slow), so a discrete GPU stages.
enum class Staging { Auto, Direct, Staged };

struct ContextOptions {
  bool validation = false;       // also on when PHOTOSITE_VK_VALIDATION=1
  bool prefer_gpu = true;        // a real GPU over a CPU implementation when both are present
  Staging staging = Staging::Auto;  // Auto: PHOTOSITE_VK_STAGING=1 / 0 forces Staged / Direct
};

class Context;
class Buffer;
class Kernel;

// A storage buffer. Direct contexts keep it in host-visible, coherent memory mapped for its whole
// life (upload and download are memcpy); staged ones keep it in device-local memory and copy
// through the context's staging buffer (DeviceInfo::staged). Stages read and write these on the
// device; the host copies in once (upload) and out once (download) per frame.
class Buffer {
 public:
  Buffer(Context& ctx, size_t bytes);
  ~Buffer();
  Buffer(const Buffer&) = delete;
  Buffer& operator=(const Buffer&) = delete;
  size_t bytes() const { return bytes_; }
  void upload(const void* src, size_t n, size_t offset = 0);
  void download(void* dst, size_t n, size_t offset = 0) const;
  template <class T> void store(const T& value) { upload(&value, sizeof(T)); }
  template <class T> T load() const {
    T value;
    download(&value, sizeof(T));
    return value;
  }
  struct Impl;
  Impl& impl() { return *impl_; }

 private:
  Context& ctx_;
  size_t bytes_;
  void* mapped_ = nullptr;  // direct contexts only
  std::unique_ptr<Impl> impl_;
};

// Device buffers by name, kept between calls and made again only when a name's size changes:
// a chain's images and scratch planes are allocated once for a run of frames of one size.
class BufferCache {
 public:
  explicit BufferCache(Context& ctx) : ctx_(ctx) {}
  Buffer& get(const std::string& name, size_t bytes);
  // The buffer `name` as it is, or nullptr when none was made yet.
  Buffer* find(const std::string& name);

 private:
  Context& ctx_;
  std::map<std::string, std::unique_ptr<Buffer>> buffers_;
};

class Context {
 public:
  // Opens the loader, creates an instance and a device; throws photosite::Error (bad input,
  // exit 2 in the CLI) naming what is missing: loader, driver, device, a required feature.
  explicit Context(const ContextOptions& options = {});
  ~Context();
  Context(const Context&) = delete;
  Context& operator=(const Context&) = delete;

  const DeviceInfo& device() const { return info_; }
  bool validation() const { return validation_; }
  // Every validation-layer / debug-utils message since creation ("severity: text").
  std::vector<std::string> messages() const;
  void record_message(std::string m);

  // The kernel `name` (kernels/<name>.comp), created on first use and kept with the context.
  Kernel& kernel(const std::string& name, int buffers, uint32_t push_bytes);

  // Bytes copied host→device (Buffer::upload) and device→host (Buffer::download) since creation:
  // what a chain moves per frame, the cost that keeping images on the device saves (on a GPU
  // each byte crosses PCIe; on lavapipe it is a memcpy).
  struct Transfers { uint64_t uploaded = 0, downloaded = 0; };
  Transfers transfers() const { return {uploaded_.load(), downloaded_.load()}; }
  void count_upload(size_t n) { uploaded_ += n; }
  void count_download(size_t n) { downloaded_ += n; }

  struct Impl;
  Impl& impl() { return *impl_; }

 private:
  DeviceInfo info_;
  std::map<std::string, std::unique_ptr<Kernel>> kernels_;
  bool validation_ = false;
  mutable std::mutex mutex_;
  std::vector<std::string> messages_;
  std::atomic<uint64_t> uploaded_{0}, downloaded_{0};
  std::unique_ptr<Impl> impl_;
};

// Memory-type choice, from each type's VkMemoryPropertyFlags (bit 0 device-local, 1 host-visible,
// 2 host-coherent, 3 host-cached) and the types a resource allows: the first type with all of
// `need`, preferably also all of `prefer` and none of `avoid`, else with `prefer`, else any;
// -1 when none has `need`. Storage buffers: need host-visible + coherent, prefer device-local
// (mapped), or prefer device-local and avoid host-visible (staged); the staging buffer: need
// host-visible + coherent, prefer cached, avoid device-local.
int pick_memory_type(const std::vector<uint32_t>& type_flags, uint32_t allowed, uint32_t need, uint32_t prefer,
                     uint32_t avoid = 0);
// Whether some type is device-local, host-visible, coherent and cached at once (a CPU driver, an
// integrated GPU): where mapping is free, so Staging::Auto maps.
bool unified_memory(const std::vector<uint32_t>& type_flags);


// Whether a Vulkan device can be opened here (loader, driver, device with the features the
// kernels need); `why` gets the reason when not. Creates and destroys a context.
bool available(std::string* why = nullptr, DeviceInfo* info = nullptr);

// The one context of the process (created on first use and never destroyed, so no Vulkan
// teardown runs in static destructors at exit), so commands and frames reuse pipelines.
Context& shared_context();

}  // namespace photosite::gpu
