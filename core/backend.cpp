#include "photosite/backend.h"

#include <fmt/format.h>

#include <atomic>
#include <cstdio>

#include "photosite/error.h"
#include "scene/night_detail.h"
#ifdef PHOTOSITE_HAVE_VULKAN
#include "photosite/gpu/scene.h"
#include "photosite/gpu/sensor.h"
#include "photosite/gpu/stages.h"
#endif

namespace photosite {

DeviceImage DeviceImage::issue() {
  static std::atomic<uint64_t> next{1};
  return DeviceImage(next++);
}

const char* to_string(Backend b) { return b == Backend::Vulkan ? "vulkan" : "cpu"; }

bool vulkan_runs_camera(const CameraPreset& camera) { return camera.read_noise_tukey_lambda == 0; }

Backend choose_auto(bool device_is_gpu, const CameraPreset* camera) {
  if (!device_is_gpu) return Backend::Cpu;
  return camera && !vulkan_runs_camera(*camera) ? Backend::Cpu : Backend::Vulkan;
}

Backend resolve_backend(const std::string& name, const CameraPreset* camera) {
  if (name == "cpu") return Backend::Cpu;
#ifdef PHOTOSITE_HAVE_VULKAN
  if (name == "vulkan") {
    try {
      gpu::shared_context();
    } catch (const ParameterError& e) {
      // "backend vulkan: <why>", where <why> may name the parameter again ("or use backend cpu").
      std::vector<std::string> parts{"", " vulkan: "};
      if (e.parameter() == "backend") {
        parts.back() += e.parts().front();
        parts.insert(parts.end(), e.parts().begin() + 1, e.parts().end());
      } else {
        parts.back() += e.what();
      }
      throw ParameterError("backend", std::move(parts));
    } catch (const Error& e) {
      fail_parameter("backend", "", std::string(" vulkan: ") + e.what());
    }
    return Backend::Vulkan;
  }
  if (name == "auto") {
    try {
      return choose_auto(!gpu::shared_context().device().cpu, camera);
    } catch (const Error&) {
      return Backend::Cpu;  // no loader or device: the native path, silently (that is auto)
    }
  }
#else
  if (name == "vulkan")
    fail_parameter("backend", "", " vulkan: this photosite was built without the Vulkan backend (PHOTOSITE_VULKAN=OFF)");
  (void)camera;
  if (name == "auto") return Backend::Cpu;
#endif
  fail_parameter("backend", "unknown ", " '" + name + "' (known: cpu, vulkan, auto)");
}

#ifdef PHOTOSITE_HAVE_VULKAN
struct SensorRunner::Device {
  gpu::SensorChain chain{gpu::shared_context()};
  std::shared_ptr<gpu::SceneStages> scene = std::make_shared<gpu::SceneStages>(gpu::shared_context());
};
#else
struct SensorRunner::Device {};
#endif

SensorRunner::SensorRunner(Backend b) : backend_(b) {
#ifdef PHOTOSITE_HAVE_VULKAN
  if (b == Backend::Vulkan) device_ = std::make_unique<Device>();
#endif
}
SensorRunner::SensorRunner(SensorRunner&&) noexcept = default;
SensorRunner& SensorRunner::operator=(SensorRunner&&) noexcept = default;
SensorRunner make_backend(const std::string& name, const CameraPreset* camera) {
  return SensorRunner(resolve_backend(name, camera));
}

SensorRunner::~SensorRunner() {
#ifdef PHOTOSITE_HAVE_VULKAN
  // With PHOTOSITE_VK_VALIDATION=1 every validation message is reported (tests look for them).
  if (device_ && device_->chain.context().validation())
    for (const auto& m : device_->chain.context().messages()) std::fprintf(stderr, "photosite: Vulkan validation: %s\n", m.c_str());
#endif
}

#ifdef PHOTOSITE_HAVE_VULKAN
namespace {
// The scene stages' radiance buffer when `token` still names it and it fits `radiance`.
gpu::Buffer* resident(gpu::SceneStages& scene, DeviceImage token, const ImageF& radiance) {
  gpu::Buffer* b = scene.resident_radiance(token);
  return b && b->bytes() == radiance.size() * sizeof(float) ? b : nullptr;
}
}  // namespace
#endif

ImageF SensorRunner::mean_signal_electrons(const ImageF& radiance, const CameraPreset& p, const LensPreset& lens,
                                           const ResolvedExposure& ex, DeviceImage resident_radiance,
                                           const GlareLevel1* glare_level1) {
#ifdef PHOTOSITE_HAVE_VULKAN
  if (device_)
    return device_->chain.mean_signal_electrons(radiance, p, lens, ex,
                                                resident(*device_->scene, resident_radiance, radiance));
#endif
  (void)resident_radiance;
  return photosite::mean_signal_electrons(radiance, p, lens, ex, glare_level1);
}

DeviceImage SensorRunner::resident_mean_e() const {
#ifdef PHOTOSITE_HAVE_VULKAN
  if (device_) return device_->chain.resident_mean_e();
#endif
  return {};
}

SensorOutput SensorRunner::sense(const ImageF& mean_e, const CameraPreset& p, const ResolvedExposure& ex,
                                 const ExposureSettings& s, const FixedPatternMaps& fpn, DeviceImage resident_mean_e) {
#ifdef PHOTOSITE_HAVE_VULKAN
  if (device_) return device_->chain.sense(mean_e, p, ex, s, fpn, resident_mean_e);
#endif
  (void)resident_mean_e;
  return photosite::sense(mean_e, p, ex, s, fpn);
}

SensorOutput SensorRunner::expose(const ImageF& radiance, const CameraPreset& p, const LensPreset& lens,
                                  const ExposureSettings& s, const FixedPatternMaps& fpn, DeviceImage resident_radiance,
                                  const GlareLevel1* glare_level1) {
#ifdef PHOTOSITE_HAVE_VULKAN
  if (device_)
    return device_->chain.expose(radiance, p, lens, s, fpn, resident(*device_->scene, resident_radiance, radiance));
#endif
  (void)resident_radiance;
  return photosite::expose(radiance, p, lens, s, fpn, glare_level1);
}

ImageF SensorRunner::demosaic(const ImageF& mosaic, CfaPattern pattern, DemosaicMethod method) {
#ifdef PHOTOSITE_HAVE_VULKAN
  if (device_) return gpu::demosaic(device_->chain.context(), mosaic, pattern, method);
#endif
  return photosite::demosaic(mosaic, pattern, method);
}

scene::PixelTail SensorRunner::night_tail(const ImageF& texture, ImageF& lights, const ImageU16& labels,
                                          const ImageF& beam_lux, const scene::ScenePreset& p, bool keep_darkened) {
#ifdef PHOTOSITE_HAVE_VULKAN
  if (device_) return device_->scene->tail(texture, lights, labels, beam_lux, p, keep_darkened);
#endif
  scene::PixelTail t;
  if (keep_darkened) t.darkened = scene::darken(texture, labels, p);
  t.radiance = scene::compose(texture, lights, labels, beam_lux, p);
  return t;
}

namespace scene {
NightScene night_scene(const ImageF& day, const LabelMap& labels, const ScenePreset& p, uint64_t seed,
                       bool keep_darkened, SensorRunner& backend, SequenceState* sequence, const TextureSums* sums,
                       bool glare_level1) {
  NightTail tail;  // empty on the CPU: night_scene's own path (the same operations, its own timings)
  if (backend.backend() == Backend::Vulkan)
    tail = [&backend](const ImageF& t, ImageF& lights, const ImageU16& ids, const ImageF& beam_lux,
                      const ScenePreset& q, bool keep) { return backend.night_tail(t, lights, ids, beam_lux, q, keep); };
  // The texture sums are the CPU linearisation's on every backend (the texture is made on the
  // CPU); the glare's level 1 is made by the CPU compose pass only (night_scene_with: not with a
  // tail).
  return night_scene_with(day, labels, p, seed, keep_darkened, tail, sequence, sums, glare_level1);
}
}  // namespace scene

void SensorRunner::set_host_import(bool on) {
  host_import_ = on;
#ifdef PHOTOSITE_HAVE_VULKAN
  if (device_) {
    device_->chain.set_host_import(on);
    device_->scene->set_host_import(on);
  }
#else
  (void)on;
#endif
}

SensorRunner::Transfers SensorRunner::transfers() const {
#ifdef PHOTOSITE_HAVE_VULKAN
  if (device_) {
    const auto t = device_->chain.context().transfers();
    return {t.uploaded, t.downloaded, t.imported, device_->chain.context().device().staged};
  }
#endif
  return {};
}

}  // namespace photosite
