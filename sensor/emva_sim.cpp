#include "photosite/sensor/emva_sim.h"

#include <cmath>

namespace photosite::emva {

SimulatedCamera::SimulatedCamera(CameraPreset preset, LensPreset lens, ExposureSettings settings,
                                 FixedPatternMaps fpn, double wavelength_nm, SenseFn sense_fn)
    : preset_(std::move(preset)), lens_(std::move(lens)), settings_(settings), fpn_(std::move(fpn)),
      wavelength_nm_(wavelength_nm), sense_(std::move(sense_fn)) {
  if (!sense_) sense_ = [](const ImageF& m, const CameraPreset& p, const ResolvedExposure& ex,
                           const ExposureSettings& s, const FixedPatternMaps& f) { return sense(m, p, ex, s, f); };
}

std::vector<ImageF> SimulatedCamera::acquire(double photons, double exposure_s, int frames) {
  std::vector<ImageF> out;
  ExposureSettings s = settings_;
  s.exposure_s = exposure_s;
  for (int i = 0; i < frames; ++i) {
    s.frame = next_frame_++;
    // flat_field(), with the sense stage on the chosen backend.
    const ImageF mean = detail::flat_field_mean(photons, wavelength_nm_, fpn_.width, fpn_.height, preset_);
    out.push_back(sense_(mean, preset_, resolve(preset_, lens_, s), s, fpn_).raw_dn);
  }
  return out;
}

Plan plan_for(const CameraPreset& p, double wavelength_nm) {
  Plan plan;
  double best = -1;
  for (int y = 0; y < 2; ++y)
    for (int x = 0; x < 2; ++x) {
      const double q = p.qe.at(cfa_color(p.cfa, x, y), wavelength_nm);
      if (q > best) {
        best = q;
        plan.x0 = x;
        plan.y0 = y;
      }
    }
  plan.step = p.cfa == CfaPattern::Mono ? 1 : 2;
  if (plan.step == 1) plan.x0 = plan.y0 = 0;
  return plan;
}

Result expected(const CameraPreset& p, const ExposureSettings& settings, const Plan& plan, int pixels,
                double wavelength_nm) {
  LensPreset lens;
  const ResolvedExposure ex = resolve(p, lens, settings);
  const double t = plan.exposure_s;
  Result r;
  r.wavelength_nm = wavelength_nm;
  const double K = ex.system_gain_dn_per_e;
  const double eta = p.fill_factor * p.qe.at(cfa_color(p.cfa, plan.x0, plan.y0), wavelength_nm);
  r.system_gain_dn_per_e = {K, 0};
  r.qe = {eta, 0};
  // Per-pixel dark-rate factor: log-normal, mean 1, CV c; hot pixels (fraction f) at h times.
  const double cv = p.dark_current_nonuniformity_percent / 100.0;
  const double f = p.hot_pixel_fraction;
  const double hf = p.dark_current_e_per_s > 0 ? p.hot_pixel_dark_current_e_per_s / p.dark_current_e_per_s : 0;
  // Raw moments of the mixture: a log-normal with mean 1 has E[X^k] = (1+c²)^(k(k−1)/2).
  auto raw = [&](int k) { return std::pow(1 + cv * cv, k * (k - 1) / 2.0) * ((1 - f) + f * std::pow(hf, k)); };
  const double mean_factor = raw(1);
  const double var_factor = raw(2) - mean_factor * mean_factor;
  const double m4_factor = raw(4) - 4 * raw(3) * mean_factor + 6 * raw(2) * mean_factor * mean_factor -
                           3 * std::pow(mean_factor, 4);
  const double N = std::max(pixels, 1);
  const double dark_rate = ex.dark_current_e_per_s * mean_factor;
  // The uncertainties of the expected values are those of a finite device: N pixels drawn from
  // the preset's distributions (rare hot pixels make a small region differ from the population).
  r.dark_current_e_per_s = {dark_rate, ex.dark_current_e_per_s * std::sqrt(var_factor / N)};
  const double sd = std::sqrt(p.read_noise_e * p.read_noise_e + p.row_noise_e * p.row_noise_e +
                              p.column_noise_e * p.column_noise_e + dark_rate * t);
  r.temporal_dark_noise_e = {sd, 0};
  {
    const double dt2 = std::pow(ex.dark_current_e_per_s * t, 2);
    const double s2 = p.dsnu_e * p.dsnu_e + dt2 * var_factor;
    const double var_s2 = 2 * std::pow(p.dsnu_e, 4) / N + dt2 * dt2 * (m4_factor - var_factor * var_factor) / N;
    r.dsnu_e = {std::sqrt(s2), s2 > 0 ? std::sqrt(var_s2) / (2 * std::sqrt(s2)) : 0};
  }
  r.prnu_percent = {p.prnu_percent, p.prnu_percent / std::sqrt(2 * N)};
  // Saturation: the photo-signal level where the variance of the clipped signal peaks; the clip is
  // the full well or the ADC's top code, whichever comes first (in electrons), less the mean dark
  // charge at the sweep exposure, which shares the well with the photo-electrons (negligible at
  // room temperature: 0.03 e⁻ in 1 ms on sony-imx490; 1,500 e⁻ of its 22,000 at 120 °C).
  const double max_code = std::ldexp(1.0, p.bit_depth) - 1.0;
  const double clip = std::min(p.full_well_e, (max_code - p.black_level_dn) / K) - dark_rate * t;
  // The measured variance is the mean over pixels whose PRNU gains g ~ N(1, σ_PRNU) put them at
  // signal g·m: average the clipped variance over g (Gauss-Hermite-like grid, ±4σ).
  const double sg = p.prnu_percent / 100.0;
  auto mean_variance = [&](double m) {
    if (sg <= 0) return clipped_normal_variance(m, std::sqrt(m + sd * sd), clip);
    double acc = 0, wsum = 0;
    for (int i = -40; i <= 40; ++i) {
      const double z = i / 10.0, w = std::exp(-0.5 * z * z), mg = m * (1 + sg * z);
      acc += w * clipped_normal_variance(mg, std::sqrt(mg + sd * sd), clip);
      wsum += w;
    }
    return acc / wsum;
  };
  double best_m = clip, best_v = -1;
  for (double m = 0.9 * clip; m <= 1.05 * clip; m += clip * 2e-5) {
    const double v = mean_variance(m);
    if (v > best_v) {
      best_v = v;
      best_m = m;
    }
  }
  r.saturation_capacity_e = {best_m, 0};
  r.saturation_photons = best_m / eta;
  r.snr_max_db = {20 * std::log10(std::sqrt(best_m)), 0};
  const double sy_dark = std::sqrt(K * K * sd * sd + 1.0 / 12.0);
  r.sensitivity_threshold_photons = (sy_dark / K + 0.5) / eta;
  r.dynamic_range_db = {20 * std::log10(r.saturation_photons / r.sensitivity_threshold_photons), 0};
  return r;
}

}  // namespace photosite::emva
