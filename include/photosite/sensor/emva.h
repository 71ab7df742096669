// EMVA 1288 (Release 4.0, linear sensors) photon-transfer characterization.
//
// This module knows nothing of photosite's simulator: it sees a camera only through
// emva::Camera, which returns raw frames (DN, black level included) for a requested mean number
// of photons per pixel and an exposure time — exactly what a test bench with a calibrated light
// source gives. The same code would characterize a real camera fed through that interface.
#pragma once
#include <string>
#include <vector>

#include "photosite/image.h"

namespace photosite::emva {

class Camera {
 public:
  virtual ~Camera() = default;
  virtual int width() const = 0;
  virtual int height() const = 0;
  virtual int bit_depth() const = 0;
  virtual double wavelength_nm() const = 0;
  // `frames` raw frames at a mean of `photons_per_pixel` photons (over the pixel area, at
  // wavelength_nm()) during `exposure_s`; 0 photons is a dark frame.
  virtual std::vector<ImageF> acquire(double photons_per_pixel, double exposure_s, int frames) = 0;
};

struct Plan {
  // The pixels measured: the sub-lattice x0 + i·step, y0 + j·step (step 2 picks one CFA colour).
  int x0 = 0, y0 = 0, step = 1;
  double exposure_s = 1e-3;          // photon-transfer sweep exposure (short: little dark charge)
  int levels = 40;                   // photon levels from dark to beyond saturation
  int nonuniformity_frames = 16;     // L frames averaged for DSNU1288 and PRNU1288
  // Dark current slope. Exposures whose dark signal passes 70 % of the saturation signal (the
  // linear range of §5.2) are left out; where fewer than three remain, the fit uses four shorter
  // ones up to the longest that stays within it.
  std::vector<double> dark_exposures_s = {0.01, 0.5, 1.0, 2.0, 4.0};
  int dark_frames = 4;
};

struct Value {
  double value = 0, uncertainty = 0;  // uncertainty: one standard error
};

struct PtcPoint {
  double photons;     // μ_p
  double mean_dn;     // μ_y − μ_y.dark
  double var_dn2;     // σ²_y − σ²_y.dark (temporal)
};

struct Result {
  Value system_gain_dn_per_e;   // K
  Value qe;                      // η at wavelength
  Value temporal_dark_noise_e;   // σ_d
  Value saturation_capacity_e;   // μ_e.sat = η μ_p.sat
  Value dark_current_e_per_s;
  Value dsnu_e;                  // DSNU1288
  Value prnu_percent;            // PRNU1288
  Value snr_max_db;              // 20 log10 √μ_e.sat
  Value dynamic_range_db;        // 20 log10 (μ_p.sat / μ_p.min)
  double saturation_photons = 0, sensitivity_threshold_photons = 0;
  double wavelength_nm = 0;
  int pixels_measured = 0;
  std::vector<PtcPoint> ptc;
  // Share of the dark pair's measured pixels at code 0 (the ADC clipped the dark signal).
  double dark_clipped_fraction = 0;
  // The exposures the dark current was fitted over (the plan's, or shorter ones where the plan's
  // longest fill the well: a hot sensor).
  std::vector<double> dark_exposures_s;
  // Conditions under which some results are biased, in words (empty: none found).
  std::vector<std::string> warnings;
};

Result measure(Camera& camera, const Plan& plan);

// Normal-distribution helpers shared by the measurement and the expectation (emva_sim.cpp).
// Φ(z), the standard normal distribution function.
double normal_cdf(double z);
// The variance of min(X, c) for X ~ N(m, s²): a normal signal clipped from above at c (the
// saturation a measurement sees; by symmetry, max(X, c) clipped from below at c has the variance
// of min(−X, −c)).
double clipped_normal_variance(double m, double s, double c);

}  // namespace photosite::emva
