// Physical constants (CODATA 2018 exact SI values) and unit helpers.
#pragma once
#include <cmath>

namespace photosite::units {

inline constexpr double planck_J_s = 6.62607015e-34;      // h, exact (SI 2019)
inline constexpr double light_speed_m_per_s = 299792458.0;  // c, exact
inline constexpr double boltzmann_J_per_K = 1.380649e-23;   // k_B, exact
inline constexpr double max_luminous_efficacy_lm_per_W = 683.0;  // K_m at 555 nm (CIE)
inline constexpr double pi = 3.14159265358979323846;

// Energy of one photon of wavelength lambda: E = h c / lambda.
inline constexpr double photon_energy_J(double wavelength_nm) {
  return planck_J_s * light_speed_m_per_s / (wavelength_nm * 1e-9);
}

// Amplitude gain from decibels, as camera gain registers are specified: g = 10^(dB/20).
inline double db_to_gain(double gain_db) { return std::pow(10.0, gain_db / 20.0); }

}  // namespace photosite::units
