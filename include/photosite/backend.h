// The backend: where the per-pixel sensor and scene stages run (the command line's
// `--backend cpu|vulkan|auto`, the Python module's `backend=`).
//   cpu     the native C++ path (OpenMP, AVX2);
//   vulkan  the GLSL kernels (kernels/) through Vulkan; no loader, driver or usable device is
//           bad input (exit 2) with the reason;
//   auto    (default) Vulkan on a real GPU when one is present, else the CPU path: a CPU Vulkan
//           driver (lavapipe) runs the same kernels slower than the native code
//           (docs/vulkan.md has the ratio).
// Both give the same numbers (tests/gpu_test.cpp: bit-equal on lavapipe).
#pragma once
#include <memory>
#include <string>

#include "photosite/device_image.h"
#include "photosite/scene/night.h"
#include "photosite/sensor/pipeline.h"

namespace photosite {

enum class Backend { Cpu, Vulkan };
const char* to_string(Backend b);

// Resolves "cpu", "vulkan" or "auto"; `vulkan` with no usable device fails here, before any
// work. Errors are ParameterErrors of "backend" (the command line calls it --backend). With the
// camera given, `auto` keeps the CPU for a camera the kernels cannot run (choose_auto).
Backend resolve_backend(const std::string& name, const CameraPreset* camera = nullptr);
// Whether the Vulkan kernels run this camera's sensor model (not Tukey-lambda read noise: it
// needs erfc and pow in double, which GLSL lacks; the Vulkan sensor refuses such a preset).
bool vulkan_runs_camera(const CameraPreset& camera);
// `auto`'s choice: Vulkan on a real GPU, the CPU path on a CPU Vulkan driver (lavapipe runs the
// kernels slower than the native code), and the CPU path for a camera the kernels cannot run
// (both paths give the same bits where both run).
Backend choose_auto(bool device_is_gpu, const CameraPreset* camera);

// The sensor stages on the chosen backend; on Vulkan the device buffers and fixed-pattern maps
// are kept from one frame to the next. Not thread-safe: one per thread of work.
class SensorRunner {
 public:
  explicit SensorRunner(Backend b);
  SensorRunner(SensorRunner&&) noexcept;
  SensorRunner& operator=(SensorRunner&&) noexcept;
  ~SensorRunner();
  Backend backend() const { return backend_; }
  // resident_radiance: NightScene::resident_radiance of a scene made on this runner
  // (night_scene(..., runner)): on Vulkan the radiance is read where the scene stages left it on the device
  // (a stale or empty handle uploads the host image, with the same result).
  ImageF mean_signal_electrons(const ImageF& radiance_rgb, const CameraPreset& preset,
                               const LensPreset& lens, const ResolvedExposure& exposure,
                               DeviceImage resident_radiance = {}, const GlareLevel1* glare_level1 = nullptr);
  // resident_mean_e(): a handle on the mean signal of the last mean_signal_electrons(), which on
  // Vulkan stays on the device; sense() given it uploads nothing for a run of frames.
  DeviceImage resident_mean_e() const;
  SensorOutput sense(const ImageF& mean_signal_e, const CameraPreset& preset,
                     const ResolvedExposure& exposure, const ExposureSettings& settings,
                     const FixedPatternMaps& fpn, DeviceImage resident_mean_e = {});
  SensorOutput expose(const ImageF& radiance_rgb, const CameraPreset& preset, const LensPreset& lens,
                      const ExposureSettings& settings, const FixedPatternMaps& fpn,
                      DeviceImage resident_radiance = {}, const GlareLevel1* glare_level1 = nullptr);
  // glare_level1 (mean_signal_electrons, expose): NightScene::glare_level1 of the radiance, read
  // by the CPU's lens glare instead of the full-resolution radiance (the same bits), or null.
  // demosaic() of a single-channel mosaic (every method has kernels).
  ImageF demosaic(const ImageF& mosaic, CfaPattern pattern, DemosaicMethod method);
  // The night chain's full-resolution per-pixel tail: darken (`darkened` only with
  // keep_darkened), low beam and lights. On Vulkan the kernels in one sequence
  // (gpu::SceneStages::tail), the radiance also left on the device (PixelTail::resident); on the
  // CPU scene::darken and scene::compose.
  scene::PixelTail night_tail(const ImageF& texture, ImageF& lights, const ImageU16& labels,
                              const ImageF& beam_lux, const scene::ScenePreset& p, bool keep_darkened);
  // Bytes moved host→device and back so far (Vulkan; zeros on the CPU).
  struct Transfers {
    uint64_t uploaded = 0, downloaded = 0;
    uint64_t imported = 0;  // of both: copied straight from (to) imported host pages (gpu::DeviceInfo::host_import)
    bool staged = false;  // through staging copies (a discrete GPU), not mapped buffers
  };
  Transfers transfers() const;
  // On Vulkan, with staged transfers on a device that can import host memory: the large copies
  // go straight from (to) the host's imported pages, by the device's copy engine, not through the
  // staging buffer by the host's memcpy (gpu::Buffer::set_host_import, which has the measurements:
  // faster where the host's cores are busy beside the copies, as in batch; slower for one frame on
  // idle cores). Off by default; nothing on the CPU backend.
  void set_host_import(bool on);
  bool host_import() const { return host_import_; }

 private:
  Backend backend_;
  bool host_import_ = false;
  struct Device;
  std::unique_ptr<Device> device_;
};

// make_backend("cpu" | "vulkan" | "auto"): resolve_backend() and a runner on the result.
SensorRunner make_backend(const std::string& name, const CameraPreset* camera = nullptr);

namespace scene {
// The night chain (scene::night_scene) with its per-pixel tail on `backend`
// (SensorRunner::night_tail): on Vulkan the radiance stays on the device under
// NightScene::resident_radiance for the same runner's sensor stages; on the CPU it is
// scene::night_scene itself.
// `sequence`, `sums`, `glare_level1`: as for scene::night_scene (the texture is made on the CPU on
// every backend, so `sums` is read on both); on Vulkan no glare level 1 (compose runs on the device).
NightScene night_scene(const ImageF& day_linear_srgb, const LabelMap& labels, const ScenePreset& p,
                       uint64_t seed, bool keep_darkened, SensorRunner& backend, SequenceState* sequence = nullptr,
                       const TextureSums* sums = nullptr, bool glare_level1 = false);
}  // namespace scene

}  // namespace photosite
