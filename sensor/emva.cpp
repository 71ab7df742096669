// EMVA 1288 Release 4.0 measurements (sections cited as "§"): mean and temporal variance from
// frame pairs (§4.3), the photon-transfer fit for the overall system gain K and the
// responsivity R = ηK (§5.1–5.2, fit range 0–70 % of saturation), temporal dark noise, saturation
// capacity at the variance maximum (§5.4), absolute sensitivity threshold and dynamic range
// (§5.5), dark current from the dark mean against exposure time (§6), DSNU1288 and PRNU1288 from
// averaged frames with the residual temporal variance removed (§8).
#include "photosite/sensor/emva.h"

#include <algorithm>
#include <cmath>
#include <fmt/format.h>

#include "photosite/error.h"

namespace photosite::emva {
namespace {

struct Stats {
  double mean = 0, var = 0;  // mean, and (temporal or spatial) variance
  int n = 0;
};

template <class F>
void for_lattice(const Plan& p, int w, int h, F&& f) {
  for (int y = p.y0; y < h; y += p.step)
    for (int x = p.x0; x < w; x += p.step) f(static_cast<size_t>(y) * w + x);
}

// §4.3: μ_y = mean of both frames; σ²_y = 1/(2N) Σ [(y_A − y_B) − (μ_A − μ_B)]².
Stats pair_stats(const Plan& p, const ImageF& a, const ImageF& b) {
  double sa = 0, sb = 0;
  int n = 0;
  for_lattice(p, a.width(), a.height(), [&](size_t i) {
    sa += a[i];
    sb += b[i];
    ++n;
  });
  const double ma = sa / n, mb = sb / n;
  double v = 0;
  for_lattice(p, a.width(), a.height(), [&](size_t i) {
    const double d = (a[i] - b[i]) - (ma - mb);
    v += d * d;
  });
  return {0.5 * (ma + mb), v / (2.0 * n), n};
}

// Average of L frames, and its spatial mean and variance over the lattice (§8.2).
Stats averaged_spatial(const Plan& p, const std::vector<ImageF>& frames) {
  const int w = frames[0].width(), h = frames[0].height();
  std::vector<double> avg(static_cast<size_t>(w) * h, 0.0);
  for (const auto& f : frames)
    for_lattice(p, w, h, [&](size_t i) { avg[i] += f[i]; });
  double s = 0;
  int n = 0;
  for_lattice(p, w, h, [&](size_t i) {
    avg[i] /= frames.size();
    s += avg[i];
    ++n;
  });
  const double m = s / n;
  double v = 0;
  for_lattice(p, w, h, [&](size_t i) { v += (avg[i] - m) * (avg[i] - m); });
  return {m, v / (n - 1), n};
}

// Mean temporal variance over L frames: Σ_l (y_l − ȳ)² averaged over pixels, /(L−1).
double temporal_variance(const Plan& p, const std::vector<ImageF>& frames) {
  const int w = frames[0].width(), h = frames[0].height();
  const double L = static_cast<double>(frames.size());
  double total = 0;
  int n = 0;
  for_lattice(p, w, h, [&](size_t i) {
    double s = 0, s2 = 0;
    for (const auto& f : frames) {
      s += f[i];
      s2 += static_cast<double>(f[i]) * f[i];
    }
    total += (s2 - s * s / L) / (L - 1);
    ++n;
  });
  return total / n;
}

// The relative variance lost when a normal signal is clipped from below at its p-quantile
// c = Φ⁻¹(p): δ(p) = 1 − Var(max(X, c)) for X ~ N(0, 1), which is Var(min(X, −c)) by symmetry.
// (δ(0.005) = 0.032, δ(0.05) = 0.16.) c by bisection.
double clipped_variance_loss(double p) {
  if (!(p > 0)) return 0;
  if (p >= 0.5) return 1;  // the median is clipped: the estimate says nothing
  double lo = -40, hi = 0;
  for (int i = 0; i < 200; ++i) {
    const double mid = 0.5 * (lo + hi);
    (normal_cdf(mid) < p ? lo : hi) = mid;
  }
  return 1 - clipped_normal_variance(0, 1, -0.5 * (lo + hi));
}

struct Fit {
  double slope = 0, intercept = 0, slope_se = 0;
};
// Least squares y = a + b x, with the standard error of b from the residuals.
Fit linear_fit(const std::vector<double>& x, const std::vector<double>& y) {
  const size_t n = x.size();
  if (n < 3) fail("EMVA 1288: too few points in the linear range to fit");
  double mx = 0, my = 0;
  for (size_t i = 0; i < n; ++i) {
    mx += x[i];
    my += y[i];
  }
  mx /= n;
  my /= n;
  double sxx = 0, sxy = 0;
  for (size_t i = 0; i < n; ++i) {
    sxx += (x[i] - mx) * (x[i] - mx);
    sxy += (x[i] - mx) * (y[i] - my);
  }
  Fit f;
  f.slope = sxy / sxx;
  f.intercept = my - f.slope * mx;
  double rss = 0;
  for (size_t i = 0; i < n; ++i) {
    const double r = y[i] - f.intercept - f.slope * x[i];
    rss += r * r;
  }
  f.slope_se = std::sqrt(rss / (n - 2) / sxx);
  return f;
}

}  // namespace

double normal_cdf(double z) { return 0.5 * std::erfc(-z / std::sqrt(2.0)); }

double clipped_normal_variance(double m, double s, double c) {
  const double a = (c - m) / s, P = normal_cdf(a), d = std::exp(-0.5 * a * a) / std::sqrt(2 * M_PI);
  const double mean = m * P - s * d + c * (1 - P);
  const double m2 = (m * m + s * s) * P - s * (m + c) * d + c * c * (1 - P);
  return m2 - mean * mean;
}

Result measure(Camera& cam, const Plan& plan) {
  const int w = cam.width(), h = cam.height();
  if (w < 8 || h < 8) fail("EMVA 1288: the measured region must be at least 8x8 pixels");
  if (plan.levels < 10) fail("EMVA 1288: at least 10 photon levels are needed");
  const double max_code = std::ldexp(1.0, cam.bit_depth()) - 1.0;
  const double sigma_q2 = 1.0 / 12.0;  // DN², uniform quantization (§4.2)
  Result r;
  r.wavelength_nm = cam.wavelength_nm();
  auto pair = [&](double photons, double t) {
    auto f = cam.acquire(photons, t, 2);
    return pair_stats(plan, f[0], f[1]);
  };
  const double t = plan.exposure_s;
  Stats dark;
  {
    const auto f = cam.acquire(0.0, t, 2);
    dark = pair_stats(plan, f[0], f[1]);
    // The dark signal clipped at code 0 (a black level too small for the gain: EMVA 1288 needs
    // an offset that keeps the dark signal above 0).
    int zeros = 0;
    for (const auto& fr : f) for_lattice(plan, w, h, [&](size_t i) { zeros += fr[i] <= 0.f; });
    r.dark_clipped_fraction = zeros / (2.0 * dark.n);
  }
  r.pixels_measured = dark.n;

  // 1. Find saturation coarsely: double the irradiation until the temporal variance collapses
  //    (every pixel clipped) or the mean reaches the top code.
  double p_hi = 10;
  double best_var = -1;
  for (int i = 0; i < 40; ++i, p_hi *= 2) {
    const Stats s = pair(p_hi, t);
    if (s.var > best_var) best_var = s.var;
    if (s.mean >= max_code - 0.5 || (best_var > 0 && s.var < 0.2 * best_var && s.mean > dark.mean + 10)) break;
  }
  // 2. The photon-transfer sweep: equally spaced levels from 0 to just past saturation.
  std::vector<double> photons, mean, var;
  const double p_max = p_hi;
  for (int i = 1; i <= plan.levels; ++i) {
    const double p = p_max * i / plan.levels;
    const Stats s = pair(p, t);
    photons.push_back(p);
    mean.push_back(s.mean - dark.mean);
    var.push_back(s.var - dark.var);
    r.ptc.push_back({p, s.mean - dark.mean, s.var - dark.var});
  }
  // Saturation (§5.4): the irradiation with the largest temporal variance.
  size_t isat = static_cast<size_t>(std::max_element(var.begin(), var.end()) - var.begin());
  // Refine around the peak with a finer sweep (two pairs per level to halve the variance noise).
  // The uncertainty of μ_p.sat is half the span of levels whose variance is within two
  // standard errors of the maximum: the top of the curve is flat within the noise.
  double sat_span = 0;
  {
    const double lo = photons[isat > 0 ? isat - 1 : 0], hi = photons[std::min(isat + 1, photons.size() - 1)];
    std::vector<double> ps, vs;
    for (int i = 0; i <= 20; ++i) {
      const double p = lo + (hi - lo) * i / 20.0;
      const Stats s1 = pair(p, t), s2 = pair(p, t);
      ps.push_back(p);
      vs.push_back(0.5 * (s1.var + s2.var) - dark.var);
    }
    const size_t ib = static_cast<size_t>(std::max_element(vs.begin(), vs.end()) - vs.begin());
    const double se_var = vs[ib] * std::sqrt(2.0 / (2.0 * dark.n));
    double pmin = ps[ib], pmax = ps[ib];
    for (size_t i = 0; i < ps.size(); ++i)
      if (vs[i] >= vs[ib] - 2 * se_var) {
        pmin = std::min(pmin, ps[i]);
        pmax = std::max(pmax, ps[i]);
      }
    r.saturation_photons = ps[ib];
    sat_span = std::max(0.5 * (pmax - pmin), (hi - lo) / 20.0);
  }
  const double p_sat = r.saturation_photons;
  const double step_sat = sat_span;
  // 3. Linear range: up to 70 % of the saturation signal (§5.2).
  double mean_sat = 0;
  {
    const Stats s = pair(p_sat, t);
    mean_sat = s.mean - dark.mean;
  }
  std::vector<double> fx, fy, rx, ry;
  for (size_t i = 0; i < photons.size(); ++i)
    if (mean[i] <= 0.7 * mean_sat && photons[i] < p_sat) {
      fx.push_back(mean[i]);
      fy.push_back(var[i]);
      rx.push_back(photons[i]);
      ry.push_back(mean[i]);
    }
  const Fit ptc = linear_fit(fx, fy);  // σ²_y − σ²_dark = K (μ_y − μ_dark)  (Eq. 11)
  const Fit resp = linear_fit(rx, ry); // μ_y − μ_dark = R μ_p            (Eq. 12)
  const double K = ptc.slope, R = resp.slope;
  if (!(K > 0) || !(R > 0)) fail("EMVA 1288: the photon-transfer fit failed (no signal?)");
  r.system_gain_dn_per_e = {K, ptc.slope_se};
  const double eta = R / K;
  r.qe = {eta, eta * std::hypot(resp.slope_se / R, ptc.slope_se / K)};
  // 4. Temporal dark noise σ_d = √(σ²_y.dark − σ²_q)/K (§5.3); its standard error from the
  //    chi-square spread of a variance over N pixel pairs and the error of K.
  const double var_d = std::max(dark.var - sigma_q2, 1e-12);
  const double sd = std::sqrt(var_d) / K;
  r.temporal_dark_noise_e = {sd, sd * std::hypot(0.5 * std::sqrt(2.0 / dark.n) * dark.var / var_d,
                                                 ptc.slope_se / K)};
  // 5. Saturation capacity, SNR max, sensitivity threshold, dynamic range (§5.4–5.5).
  const double e_sat = eta * p_sat;
  r.saturation_capacity_e = {e_sat, e_sat * std::hypot(r.qe.uncertainty / eta, step_sat / p_sat)};
  r.snr_max_db = {20 * std::log10(std::sqrt(e_sat)), 10 / std::log(10.0) * r.saturation_capacity_e.uncertainty / e_sat};
  const double p_min = (std::sqrt(dark.var) / K + 0.5) / eta;
  r.sensitivity_threshold_photons = p_min;
  r.dynamic_range_db = {20 * std::log10(p_sat / p_min),
                        20 / std::log(10.0) * std::hypot(step_sat / p_sat, r.qe.uncertainty / eta)};
  // 6. Dark current: slope of the dark mean against exposure time, in e⁻/s (§6.1), over
  //    exposures whose dark signal stays within the linear range (70 % of the saturation signal,
  //    as the photon-transfer fit): a dark frame that has filled the well no longer grows with
  //    time. Where the plan's exposures leave fewer than three such points (a hot sensor: at
  //    120 °C an automotive sensor fills 22,000 e⁻ in 15 ms), four shorter ones are measured, up
  //    to the longest that stays within the range, found by halving.
  {
    auto dark_mean = [&](double te) {
      auto frames = cam.acquire(0.0, te, plan.dark_frames);
      double m = 0;
      for (const auto& f : frames) {
        double s = 0;
        int n = 0;
        for_lattice(plan, w, h, [&](size_t i) {
          s += f[i];
          ++n;
        });
        m += s / n;
      }
      return m / frames.size();
    };
    const double limit = dark.mean + 0.7 * mean_sat;
    std::vector<double> tx, my;
    for (double te : plan.dark_exposures_s) {
      const double m = dark_mean(te);
      if (m <= limit) {
        tx.push_back(te);
        my.push_back(m);
      }
    }
    if (tx.size() < 3) {
      double te = *std::min_element(plan.dark_exposures_s.begin(), plan.dark_exposures_s.end());
      for (int i = 0; i < 60 && dark_mean(te) > limit; ++i) te *= 0.5;
      tx.clear();
      my.clear();
      for (int k = 1; k <= 4; ++k) {
        tx.push_back(te * k / 4);
        my.push_back(dark_mean(te * k / 4));
      }
    }
    r.dark_exposures_s = tx;
    const Fit dc = linear_fit(tx, my);
    r.dark_current_e_per_s = {dc.slope / K, std::hypot(dc.slope_se / K, dc.slope * ptc.slope_se / (K * K))};
  }
  // 7. DSNU1288 and PRNU1288 (§8): L averaged frames, dark and at 50 % saturation; the spatial
  //    variance of the average less its residual temporal part σ²_temporal / L.
  {
    const int L = plan.nonuniformity_frames;
    auto dark_frames = cam.acquire(0.0, t, L);
    const Stats ds = averaged_spatial(plan, dark_frames);
    const double dark_tvar = temporal_variance(plan, dark_frames);
    const double s2_dark = std::max(ds.var - dark_tvar / L, 0.0);
    const double dsnu = std::sqrt(s2_dark) / K;
    // Standard error of a spatial variance over N pixels: √(2/N)·s²; of its root: that / (2s).
    const double se_s2 = std::sqrt(2.0 / ds.n) * ds.var;
    r.dsnu_e = {dsnu, (s2_dark > 0 ? se_s2 / (2 * std::sqrt(s2_dark)) : std::sqrt(se_s2)) / K +
                          dsnu * ptc.slope_se / K};
    auto half = cam.acquire(0.5 * p_sat, t, L);
    const Stats hs = averaged_spatial(plan, half);
    const double half_tvar = temporal_variance(plan, half);
    const double s2_half = std::max(hs.var - half_tvar / L, 0.0);
    const double signal = hs.mean - ds.mean;
    const double s2_prnu = std::max(s2_half - s2_dark, 0.0);
    const double prnu = std::sqrt(s2_prnu) / signal * 100.0;
    // Standard error: the variance of a spatial variance over N pixels is ≈ 2 s⁴/N.
    const double var_s2 = 2 * (s2_half + half_tvar / L) * (s2_half + half_tvar / L) / hs.n +
                          2 * (s2_dark + dark_tvar / L) * (s2_dark + dark_tvar / L) / ds.n;
    // Where the estimate is clamped at 0 (the half-saturation variance no larger than the dark
    // one), one standard error of the variance difference, as a PRNU: the estimate is 0 within
    // it, not exactly 0 (as DSNU1288 above).
    r.prnu_percent = {prnu, s2_prnu > 0 ? 0.5 * std::sqrt(var_s2) / s2_prnu * prnu
                                        : std::sqrt(std::sqrt(var_s2)) / signal * 100.0};
  }
  // 8. Warnings. The dark noise's standard error is √(2/N) of its variance (a variance over N
  //    pixel pairs); clipping at code 0 biases it low by δ(p) (clipped_variance_loss), which
  //    passes that standard error once p reaches about 0.5 % of the pixels at N = 16,384.
  const double loss = clipped_variance_loss(r.dark_clipped_fraction), dark_var_se = std::sqrt(2.0 / dark.n);
  if (loss > dark_var_se)
    r.warnings.push_back(fmt::format(
        "{:.2f}% of the dark pixels read 0 DN: the ADC clips the dark signal (black level too low for "
        "this gain), so the temporal dark noise, DSNU1288, sensitivity threshold and dynamic range are "
        "biased (dark variance about {:.1f}% low, against a standard error of {:.1f}%)",
        100 * r.dark_clipped_fraction, 100 * loss, 100 * dark_var_se));
  if (r.dark_exposures_s != plan.dark_exposures_s)
    r.warnings.push_back(fmt::format(
        "the dark signal fills the well within the planned exposures: dark current fitted over {:.3g} to {:.3g} s",
        r.dark_exposures_s.front(), r.dark_exposures_s.back()));
  return r;
}

}  // namespace photosite::emva
