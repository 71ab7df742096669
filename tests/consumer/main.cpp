// An exposure through an installed photosite (the InstalledConsumer test): a bundled camera
// preset found by the library relative to itself, a uniform scene, two frames of one simulated
// device, and a check of the mean signal against the library's own photon model.
//
// Check: a lit frame minus a dark frame of the same device (fixed patterns equal, temporal noise
// independent) has, per pixel, the mean  s_i·g_i  (s: mean photo-electrons of the optics model,
// g: the device's PRNU gain; the dark charge d_i cancels) and the variance  s_i·g_i + 2·d_i
// (Poisson: the variance of a count is its mean; d_i from both frames). So the residuals
// r_i = lit_i - dark_i - s_i·g_i over N pixels must have
//   mean 0, within 5 standard errors 5·sd(r)/√N, and
//   variance mean(s·g) + 2·mean(dark frame), within 5 standard errors of a sample variance,
//   5·√(2/(N-1)) relative (Gaussian: a Poisson count of mean ~1000 is Gaussian to 1/1000 in its
//   excess kurtosis).
// The signal is set to ~1000 e-, far below the 9000 e- full well, so clipping does not enter.
#include <cmath>
#include <cstdio>
#include <exception>
#include <string>

#include "photosite/environment.h"
#include "photosite/error.h"
#include "photosite/sensor/fpn.h"
#include "photosite/sensor/pipeline.h"
#include "photosite/sensor/preset.h"

int main() {
  using namespace photosite;
  try {
    const CameraPreset camera = load_camera_preset("onsemi-ar0331");
    const LensPreset lens = load_lens_preset(camera.default_lens);
    std::printf("data_dir %s\n", data_dir().c_str());
    std::printf("preset %s\n", camera.file.c_str());

    const int w = 64, h = 64;
    ExposureSettings settings;
    settings.exposure_s = 0.01;
    const ResolvedExposure ex = resolve(camera, lens, settings);
    // Radiance (equal in R, G, B) for a mean of ~1000 e- per pixel: the model is linear in it.
    const ImageF unit_scene(w, h, 3, 1.0f, unit::radiance);
    const ImageF per_unit = mean_signal_electrons(unit_scene, camera, lens, ex);
    double m = 0;
    for (size_t i = 0; i < per_unit.size(); ++i) m += per_unit[i];
    m /= static_cast<double>(per_unit.size());
    const ImageF scene(w, h, 3, static_cast<float>(1000.0 / m), unit::radiance);
    const ImageF dark_scene(w, h, 3, 0.0f, unit::radiance);

    const FixedPatternMaps fpn = generate_fixed_pattern(camera, w, h, "consumer-0");
    const ImageF signal = mean_signal_electrons(scene, camera, lens, ex);
    const SensorOutput lit = expose(scene, camera, lens, settings, fpn);
    ExposureSettings dark_settings = settings;
    dark_settings.seed = 1;  // independent temporal noise
    const SensorOutput dark = expose(dark_scene, camera, lens, dark_settings, fpn);

    const size_t n = signal.size();
    const double nd = static_cast<double>(n);
    double expected = 0, dark_mean = 0, sum = 0, sum2 = 0;
    for (size_t i = 0; i < n; ++i) {
      const double sg = signal[i] * (fpn.prnu_gain.empty() ? 1.0 : fpn.prnu_gain[i]);
      const double r = static_cast<double>(lit.electrons[i]) - dark.electrons[i] - sg;
      expected += sg;
      dark_mean += dark.electrons[i];
      sum += r;
      sum2 += r * r;
    }
    expected /= nd;
    dark_mean /= nd;
    const double mean_r = sum / nd;
    const double var_r = (sum2 - sum * mean_r) / (nd - 1);
    const double se_mean = std::sqrt(var_r / nd);
    const double var_expected = expected + 2 * dark_mean;
    const double var_rel_tol = 5 * std::sqrt(2 / (nd - 1));
    std::printf("signal %.3f e-, dark %.3f e-; residual mean %.4f e- (5 se %.4f), variance %.2f e-^2 "
                "(expected %.2f, +-%.1f %%)\n",
                expected, dark_mean, mean_r, 5 * se_mean, var_r, var_expected, 100 * var_rel_tol);
    const bool ok = std::fabs(mean_r) <= 5 * se_mean && std::fabs(var_r / var_expected - 1) <= var_rel_tol &&
                    expected > 900 /* scaled to 1000 e-; PRNU mean is 1 within 0.1 % */ &&
                    lit.raw_dn.width() == w && lit.rgb.channels() == 3;
    std::printf("%s\n", ok ? "consumer: ok" : "consumer: FAILED");
    return ok ? 0 : 1;
  } catch (const Error& e) {
    std::fprintf(stderr, "consumer: error: %s\n", e.what());
    return 1;
  }
}
