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
//   PHOTOSITE_VK_HOST_IMPORT=0|1  0: staged copies never import the caller's pages
//                              (ContextOptions::host_import); 1: every Buffer's large staged copies
//                              do, not only those of buffers asked to (Buffer::set_host_import).
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
  // Staged transfers of at least kHostImportMinBytes can run as one device copy straight from (or
  // to) the caller's own pages, imported for that copy (VK_EXT_external_memory_host), not through
  // the staging buffer: the device offers the extension and ContextOptions::host_import allows it.
  // Which copies do: Buffer::set_host_import.
  bool host_import = false;
};

// The smallest staged transfer that imports the caller's pages (Buffer::set_host_import); smaller
// ones go through the staging buffer, where the import's fixed cost (the driver pins the pages and
// maps them for the device) would outweigh the memcpy it saves.
inline constexpr size_t kHostImportMinBytes = size_t{1} << 20;

// How Buffer::upload / download reach device memory: Auto picks Staged unless a memory type is
// device-local, host-visible, coherent and cached all at once (where mapping is free). Reading
// a GPU's BAR window from the CPU is uncached (slow), so a discrete GPU stages.
enum class Staging { Auto, Direct, Staged };

struct ContextOptions {
  bool validation = false;       // also on when PHOTOSITE_VK_VALIDATION=1
  bool prefer_gpu = true;        // a real GPU over a CPU implementation when both are present
  Staging staging = Staging::Auto;  // Auto: PHOTOSITE_VK_STAGING=1 / 0 forces Staged / Direct
  bool host_import = true;       // DeviceInfo::host_import where offered; PHOTOSITE_VK_HOST_IMPORT=0 turns it off
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
  // Staged copies of kHostImportMinBytes or more straight from (to) the caller's imported pages,
  // where the context offers it (DeviceInfo::host_import), instead of through the staging slots.
  // Off by default. On a lent H200 (docs/vulkan.md, 2026-12-04 17:40 UTC) the import made a single
  // frame slower at 2 threads (the night tail 7.8-8.3 -> 10.1-12.1 ms, the sensor 4.7-4.9 ->
  // 6.3-6.7 ms, 4 of 4 pairs): pinning the pages costs more than the staging slots' memcpy on
  // idle cores. It made `batch` faster (40 frames at its default --jobs 1: 4.86-5.09 -> 4.53-4.85 s
  // in 6 pairs timed by the wall clock, lower in those and in 5 more), where the host's cores are
  // busy encoding beside the copies and the device's copy engine spares them the memcpy; batch
  // turns it on (SensorRunner::set_host_import).
  void set_host_import(bool on) { host_import_ = on; }
  bool host_import() const { return host_import_; }
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
  bool host_import_ = false;
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
  // Buffer::set_host_import for every buffer, those made later included.
  void set_host_import(bool on);

 private:
  Context& ctx_;
  bool host_import_ = false;
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
  // `imported`: the part of both that was copied straight from (to) the caller's imported pages
  // (DeviceInfo::host_import), not through the staging buffer.
  struct Transfers { uint64_t uploaded = 0, downloaded = 0, imported = 0; };
  Transfers transfers() const { return {uploaded_.load(), downloaded_.load(), imported_.load()}; }
  void count_upload(size_t n) { uploaded_ += n; }
  void count_download(size_t n) { downloaded_ += n; }
  void count_imported(size_t n) { imported_ += n; }

  struct Impl;
  Impl& impl() { return *impl_; }

 private:
  DeviceInfo info_;
  std::map<std::string, std::unique_ptr<Kernel>> kernels_;
  bool validation_ = false;
  mutable std::mutex mutex_;
  std::vector<std::string> messages_;
  std::atomic<uint64_t> uploaded_{0}, downloaded_{0}, imported_{0};
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
