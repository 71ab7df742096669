// The bridge between the EMVA 1288 module and photosite's simulator: a simulated camera that
// serves flat fields through emva::Camera, the measurement plan for a preset, and the values
// EMVA 1288 should find for it, derived from the preset alone.
#pragma once
#include <functional>

#include "photosite/sensor/emva.h"
#include "photosite/sensor/pipeline.h"

namespace photosite::emva {

class SimulatedCamera : public Camera {
 public:
  // How a frame's mean electrons become an exposure: photosite::sense (the default) or the same
  // stage on another backend (the CLI's --backend passes the Vulkan one).
  using SenseFn = std::function<SensorOutput(const ImageF& mean_e, const CameraPreset&, const ResolvedExposure&,
                                             const ExposureSettings&, const FixedPatternMaps&)>;
  SimulatedCamera(CameraPreset preset, LensPreset lens, ExposureSettings settings,
                  FixedPatternMaps fpn, double wavelength_nm = 525.0, SenseFn sense_fn = {});
  int width() const override { return fpn_.width; }
  int height() const override { return fpn_.height; }
  int bit_depth() const override { return preset_.bit_depth; }
  double wavelength_nm() const override { return wavelength_nm_; }
  std::vector<ImageF> acquire(double photons_per_pixel, double exposure_s, int frames) override;

 private:
  CameraPreset preset_;
  LensPreset lens_;
  ExposureSettings settings_;
  FixedPatternMaps fpn_;
  double wavelength_nm_;
  SenseFn sense_;
  uint32_t next_frame_ = 0;
};

// Measures the CFA colour with the highest QE at the wavelength (one 2x2 sub-lattice).
Plan plan_for(const CameraPreset& preset, double wavelength_nm = 525.0);

// What a perfect EMVA 1288 measurement of this preset should report (at the settings' gain and
// temperature, the plan's exposure and colour): K, η, σ_d (read, row, column and dark shot
// noise), the saturation capacity where the temporal variance of the clipped signal peaks, the
// dark current (mean over the per-pixel rates, hot pixels included), DSNU1288, PRNU1288, SNR
// and dynamic range. `pixels` is the number measured: the uncertainties given are those of a
// device of that many pixels drawn from the preset's distributions.
Result expected(const CameraPreset& preset, const ExposureSettings& settings, const Plan& plan, int pixels,
                double wavelength_nm = 525.0);

}  // namespace photosite::emva
