// The sensor chain on the Vulkan backend: photon integral → sense (shot noise, dark current,
// fixed pattern, read noise, full well, gain, black, ADC) → demosaic (every method has kernels) as one sequence of
// kernels over buffers that stay on the device: one upload (the radiance, none when the scene
// stages left it there) and one download (the outputs) per frame; the fixed-pattern maps are uploaded once per device and reused by every
// frame. The twin of expose() / sense() / mean_signal_electrons() (sensor/pipeline.h), held to
// them by tests/gpu_test.cpp.
//
// The lens's veiling glare (sensor/glare.h) runs there too: kernels glare_down, glare_blur,
// glare_up and glare_norm build the pyramid, photon mixes it in.
// On the CPU stay: photon_matrix() (a spectral integral per frame, not per pixel), the w + h
// row/column noise draws.
// Tukey-λ read noise is not on the device yet: sense() there is bad input naming the preset.
#pragma once
#include <memory>
#include <string>
#include <vector>

#include "photosite/device_image.h"
#include "photosite/gpu/context.h"
#include "photosite/gpu/sequence.h"
#include "photosite/sensor/glare.h"
#include "photosite/sensor/pipeline.h"

namespace photosite::gpu {

class SensorChain {
 public:
  explicit SensorChain(Context& ctx);
  ~SensorChain();
  // `radiance_on_device`: a buffer of this context already holding `radiance_rgb` (a scene
  // stage's output, SceneStages::resident_radiance): read from there, not uploaded again. The
  // host image is still needed for its size and for naming a bad pixel.
  ImageF mean_signal_electrons(const ImageF& radiance_rgb, const CameraPreset& preset,
                               const LensPreset& lens, const ResolvedExposure& exposure,
                               Buffer* radiance_on_device = nullptr);
  // The mean signal of the last mean_signal_electrons() stays on the device under this token
  // until expose() or a sense() of another mean overwrites it; sense() given the token reads it
  // from there (a run of frames uploads it never).
  DeviceImage resident_mean_e() const { return mean_e_token_; }
  SensorOutput sense(const ImageF& mean_signal_e, const CameraPreset& preset,
                     const ResolvedExposure& exposure, const ExposureSettings& settings,
                     const FixedPatternMaps& fpn, DeviceImage mean_e_token = {});
  SensorOutput expose(const ImageF& radiance_rgb, const CameraPreset& preset, const LensPreset& lens,
                      const ExposureSettings& settings, const FixedPatternMaps& fpn,
                      Buffer* radiance_on_device = nullptr);
  // Device time per kernel of the last frame (empty without timestamps).
  std::vector<Sequence::StageTime> stage_times() const { return times_; }
  Context& context() { return ctx_; }
  // Large staged copies of this chain's buffers from (to) the host's imported pages
  // (Buffer::set_host_import).
  void set_host_import(bool on) { buffers_.set_host_import(on); }

 private:
  Buffer& buffer(const std::string& name, size_t bytes);
  void record_photon(Sequence& s, const ImageF& radiance, const CameraPreset& p, const LensPreset& lens,
                     const ResolvedExposure& ex, Buffer* radiance_on_device);
  bool record_glare(Sequence& s, Buffer& radiance, int w, int h, const GlarePlan& plan);
  static size_t glare_bytes(int w, int h, int level);
  void record_sense(Sequence& s, int w, int h, const CameraPreset& p, const ResolvedExposure& ex,
                    const ExposureSettings& st, const FixedPatternMaps& fpn);
  // The downloads, the CPU demosaic of the methods with no kernel, and the clear patterns'
  // clipped highlights (neutralize_clipped_highlights, on the host as in sense()).
  SensorOutput finish(int w, int h, const CameraPreset& p, const ResolvedExposure& ex, const ExposureSettings& st);

  Context& ctx_;
  BufferCache buffers_;
  std::string fpn_loaded_;  // device id + checksum of the maps now on the device
  std::vector<Sequence::StageTime> times_;
  std::unique_ptr<Sequence> seq_;
  DeviceImage mean_e_token_;  // what buffer "mean_e" holds; empty: nothing promised
};

}  // namespace photosite::gpu
