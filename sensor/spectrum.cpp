#include "photosite/sensor/spectrum.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <numbers>

#include "photosite/error.h"
#include "photosite/units.h"

namespace photosite::spectrum {
namespace {
// Piecewise Gaussian of Wyman et al. 2013, Eq. 2: different widths left and right of the mean.
double g(double x, double mu, double s1, double s2) {
  const double t = (x - mu) / (x < mu ? s1 : s2);
  return std::exp(-0.5 * t * t);
}

// ∫ f over [lo, hi] with the midpoint rule at 0.5 nm: the functions are smooth on that scale.
double integrate(const std::function<double(double)>& f, double lo, double hi) {
  const double step = 0.5;
  double s = 0;
  for (double x = lo + step / 2; x < hi; x += step) s += f(x);
  return s * step;
}

}  // namespace

// spectrum.h: the inverse of a 3 x 3 matrix by its adjugate over its determinant.
std::array<std::array<double, 3>, 3> invert3(const std::array<std::array<double, 3>, 3>& m) {
  const double a = m[0][0], b = m[0][1], c = m[0][2], d = m[1][0], e = m[1][1], f = m[1][2],
               gg = m[2][0], h = m[2][1], i = m[2][2];
  const double det = a * (e * i - f * h) - b * (d * i - f * gg) + c * (d * h - e * gg);
  return {{{(e * i - f * h) / det, (c * h - b * i) / det, (b * f - c * e) / det},
           {(f * gg - d * i) / det, (a * i - c * gg) / det, (c * d - a * f) / det},
           {(d * h - e * gg) / det, (b * gg - a * h) / det, (a * e - b * d) / det}}};
}

double cie_x_bar(double l) {
  return 1.056 * g(l, 599.8, 37.9, 31.0) + 0.362 * g(l, 442.0, 16.0, 26.7) -
         0.065 * g(l, 501.1, 20.4, 26.2);
}
double cie_y_bar(double l) { return 0.821 * g(l, 568.8, 46.9, 40.5) + 0.286 * g(l, 530.9, 16.3, 31.1); }
double cie_z_bar(double l) { return 1.217 * g(l, 437.0, 11.8, 36.0) + 0.681 * g(l, 459.0, 26.0, 13.8); }

double planck_W_sr_m2_nm(double wavelength_nm, double temperature_K) {
  // B_λ(T) = 2hc²/λ⁵ / (exp(hc/(λ k T)) − 1), per metre of wavelength; × 1e-9 per nm.
  using namespace units;
  const double l = wavelength_nm * 1e-9;
  const double x = planck_J_s * light_speed_m_per_s / (l * boltzmann_J_per_K * temperature_K);
  return 2 * planck_J_s * light_speed_m_per_s * light_speed_m_per_s / std::pow(l, 5) /
         std::expm1(x) * 1e-9;
}

std::array<double, 3> project_to_rgb(const std::function<double(double)>& spectral_radiance) {
  std::array<double, 3> rgb{};
  for (int k = 0; k < 3; ++k) rgb[k] = integrate(spectral_radiance, kBandLoNm[k], kBandHiNm[k]);
  return rgb;
}

const std::array<double, 3>& band_luminous_efficacy_lm_per_W() {
  static const std::array<double, 3> eff = [] {
    std::array<double, 3> e{};
    for (int k = 0; k < 3; ++k)
      e[k] = units::max_luminous_efficacy_lm_per_W *
             integrate(cie_y_bar, kBandLoNm[k], kBandHiNm[k]) / (kBandHiNm[k] - kBandLoNm[k]);
    return e;
  }();
  return eff;
}

double luminance_cd_m2(const float rgb[3]) {
  const auto& e = band_luminous_efficacy_lm_per_W();
  return e[0] * rgb[0] + e[1] * rgb[1] + e[2] * rgb[2];
}

std::array<double, 3> blackbody_rgb(double cct_K, double luminance) {
  // The band integrals and their luminance depend on the temperature alone: each thread keeps
  // those of its last kKept temperatures (a frame's light map asks for the same few, the window,
  // street, beam and head-lamp CCTs, a dozen times or more, each ~800 evaluations of Planck's law
  // on the thread that sets the frame's passes up). A kept entry holds the very doubles the
  // integration gives, and the scaling below is the same two operations, so the same bits. (The
  // temperatures are matched by their bits: +0 and −0 K integrate differently.)
  struct Kept {
    double cct = 0;
    std::array<double, 3> rgb{};
    double lum = 0;
  };
  constexpr int kKept = 8;
  thread_local Kept kept[kKept];
  thread_local int n_kept = 0, next = 0;
  const Kept* hit = nullptr;
  for (int i = 0; i < n_kept && !hit; ++i)
    if (std::bit_cast<uint64_t>(kept[i].cct) == std::bit_cast<uint64_t>(cct_K)) hit = &kept[i];
  if (!hit) {
    Kept k;
    k.cct = cct_K;
    k.rgb = project_to_rgb([cct_K](double l) { return planck_W_sr_m2_nm(l, cct_K); });
    const auto& e = band_luminous_efficacy_lm_per_W();
    k.lum = e[0] * k.rgb[0] + e[1] * k.rgb[1] + e[2] * k.rgb[2];
    kept[next] = k;
    hit = &kept[next];
    next = (next + 1) % kKept;
    n_kept = std::min(n_kept + 1, kKept);
  }
  std::array<double, 3> rgb = hit->rgb;
  for (auto& v : rgb) v *= luminance / hit->lum;
  return rgb;
}

std::array<double, 3> hp1_rgb(double luminance) {
  const auto& e = band_luminous_efficacy_lm_per_W();
  const double lum = e[0] * kHp1BandIntegral[0] + e[1] * kHp1BandIntegral[1] + e[2] * kHp1BandIntegral[2];
  std::array<double, 3> rgb{kHp1BandIntegral[0], kHp1BandIntegral[1], kHp1BandIntegral[2]};
  for (auto& v : rgb) v *= luminance / lum;
  return rgb;
}

double led_b_spd(double cct_K, double l) {
  if (!(cct_K > 0) || !std::isfinite(cct_K)) internal_error("led_b_spd: the CCT is not a positive number");
  if (!(l >= 380 && l <= 780)) return 0.0;
  // Each table's photopic sum Σ S_i·ȳ(λ_i) over its samples: the tables are in relative units of
  // their own, and the blend is of equal-luminance spectra (the metamer is per cd/m² anyway).
  static const std::array<double, 5> lum = [] {
    std::array<double, 5> a{};
    for (int t = 0; t < 5; ++t)
      for (int i = 0; i < 81; ++i) a[t] += kLedBSpd5nm[t][i] * cie_y_bar(380 + 5.0 * i);
    return a;
  }();
  auto table = [&](int t) { return table_5nm(kLedBSpd5nm[t], 81, l) / lum[t]; };
  if (cct_K <= kLedBCct_K[0]) return table(0);
  if (cct_K >= kLedBCct_K[4]) return table(4);
  int j = 0;
  while (!(cct_K < kLedBCct_K[j + 1])) ++j;  // kLedBCct_K[j] <= T < kLedBCct_K[j + 1]
  const double w = (1e6 / kLedBCct_K[j] - 1e6 / cct_K) / (1e6 / kLedBCct_K[j] - 1e6 / kLedBCct_K[j + 1]);
  if (w == 0) return table(j);  // on a table's CCT: that table alone
  return table(j) * (1 - w) + table(j + 1) * w;
}

double table_5nm(const double* spd, int n, double l) {
  if (!(l >= 380 && l <= 380 + 5.0 * (n - 1))) return 0.0;
  const double t = (l - 380) / 5;
  const int i = std::clamp(static_cast<int>(t), 0, n - 2);
  const double f = t - i;
  return spd[i] * (1 - f) + spd[i + 1] * f;
}

double lamp_spd(LampSpectrum s, double l, double cct_K) {
  auto led = [l](const LedLine& d) {
    const double t = (l - d.peak_nm) / d.fwhm_nm;
    return std::exp(-4 * std::numbers::ln2 * t * t);
  };
  switch (s) {
    case LampSpectrum::Hp1: return table_5nm(kHp1Spd5nm, 81, l);
    case LampSpectrum::RedLed: return led(kRedLed);
    case LampSpectrum::AmberLed: return led(kAmberLed);
    case LampSpectrum::GreenLed: return led(kGreenLed);
    case LampSpectrum::LedBHeads:
    case LampSpectrum::LedBStreet: return led_b_spd(cct_K, l);
  }
  return 0.0;
}

const std::array<std::array<double, 3>, 3>& box_to_linear_srgb() {
  static const auto m = [] {
    // XYZ (absolute, Y in cd/m²) of one W·sr⁻¹·m⁻² in each box, then XYZ→sRGB (kXyzToLinearSrgb).
    const auto& xyz_to_srgb = kXyzToLinearSrgb;
    std::array<std::array<double, 3>, 3> out{};
    for (int k = 0; k < 3; ++k) {
      const double w = kBandHiNm[k] - kBandLoNm[k];
      const double X = 683.0 * integrate(cie_x_bar, kBandLoNm[k], kBandHiNm[k]) / w;
      const double Y = 683.0 * integrate(cie_y_bar, kBandLoNm[k], kBandHiNm[k]) / w;
      const double Z = 683.0 * integrate(cie_z_bar, kBandLoNm[k], kBandHiNm[k]) / w;
      for (int r = 0; r < 3; ++r)
        out[r][k] = xyz_to_srgb[r][0] * X + xyz_to_srgb[r][1] * Y + xyz_to_srgb[r][2] * Z;
    }
    return out;
  }();
  return m;
}

const std::array<std::array<double, 3>, 3>& linear_srgb_to_box() {
  static const auto m = invert3(box_to_linear_srgb());
  return m;
}

}  // namespace photosite::spectrum
