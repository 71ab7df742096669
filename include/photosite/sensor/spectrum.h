// photosite's spectral model. Linear RGB radiance in W·sr⁻¹·m⁻² is defined on a fixed spectral
// basis of three unit-area boxes:
//     B: 400-500 nm,  G: 500-600 nm,  R: 600-700 nm,   b_k(λ) = 1/(100 nm) inside its band.
// A pixel (R, G, B) therefore means the spectral radiance L(λ) = R·b_R(λ) + G·b_G(λ) + B·b_B(λ):
// each channel is the radiance carried in its 100-nm band, and R + G + B is the total radiance
// from 400 to 700 nm. Everything the sensor needs then reduces to a small matrix: electrons per
// filter colour = Σ_k (channel k) · ∫ b_k(λ) QE(λ) λ/(hc) dλ · (optics, area, time), and the
// photometric quantities (luminance, lux) to a fixed efficacy per band from CIE 1931 ȳ(λ).
#pragma once
#include <array>
#include <functional>

namespace photosite::spectrum {

inline constexpr double kBandLoNm[3] = {600.0, 500.0, 400.0};  // R, G, B
inline constexpr double kBandHiNm[3] = {700.0, 600.0, 500.0};

// CIE 1931 2° colour-matching functions, the multi-lobe Gaussian fits of Wyman, Sloan & Shirley,
// "Simple Analytic Approximations to the CIE XYZ Color Matching Functions", JCGT 2(2), 2013.
double cie_x_bar(double wavelength_nm);
double cie_y_bar(double wavelength_nm);  // = V(λ), photopic luminous efficiency
double cie_z_bar(double wavelength_nm);

// Planck's law, spectral radiance of a black body, W·sr⁻¹·m⁻²·nm⁻¹.
double planck_W_sr_m2_nm(double wavelength_nm, double temperature_K);

// Band radiances (W·sr⁻¹·m⁻²) of a spectral radiance function (W·sr⁻¹·m⁻²·nm⁻¹): ∫ over each box.
std::array<double, 3> project_to_rgb(const std::function<double(double)>& spectral_radiance);

// Luminous efficacy of each box (lm/W): 683 · mean of V(λ) over the band. Luminance in cd/m² of
// an RGB radiance is dot(efficacy, rgb).
const std::array<double, 3>& band_luminous_efficacy_lm_per_W();
double luminance_cd_m2(const float rgb_W_sr_m2[3]);

// The RGB radiance of a black body (or a CCT proxy for a lamp) scaled to a given luminance.
std::array<double, 3> blackbody_rgb(double cct_K, double luminance_cd_m2);

// CIE illuminant HP1, the standard high-pressure sodium (HPS) lamp of CIE 015:2018 (5-nm table,
// 380-780 nm), in the box basis: its band integrals ∫ S(λ) dλ over the R, G, B boxes in the table's
// relative units (trapezoid rule on the 5-nm grid, a sample on a band edge split half and half),
// computed offline by scripts/lamp_spectra.py from the tabulated SPD. HPS is not a Planck radiator:
// its light is the pressure-broadened, self-reversed sodium D line (peaks near 568 nm and 589-615 nm,
// a dip at 589 nm), so no CCT stands for it. Only the ratios matter (B/R 0.2234, G/R 1.9454);
// hp1_rgb scales them to a luminance. The sensor's box-averaged QE reads these band radiances as a
// flat spectrum within each box: for sodium's lines the cameras' raw G/R then comes out 2.2-2.4x
// the spectrum's (scripts/lamp_spectra.py, docs/night.md §7), which is why the night chain gives
// the lamps its camera's metamer instead (camera_metamer_rgb, sensor/pipeline.h).
inline constexpr double kHp1BandIntegral[3] = {3747.625, 7290.6, 837.2};  // R, G, B
// CIE illuminant HP1's relative spectral power, 380-780 nm every 5 nm (CIE 015:2018, the table
// scripts/lamp_spectra.py reads; its source there): what camera_metamer_rgb (sensor/pipeline.h)
// runs through a camera's QE.
inline constexpr double kHp1Spd5nm[81] = {1.9, 2.2, 2.5, 2.7, 3.1, 4.3, 3.8, 4.2, 4.8, 5.19, 5.89, 7.39, 7.89, 5.69, 12.89, 6.69, 4.3, 20.78, 12.99, 6.69, 1.4, 1.5, 3.2, 18.18, 56.24, 2.9, 2.1, 13.39, 2.1, 2, 2.2, 2.3, 2.6, 5.1, 11.39, 15.48, 20.78, 55.64, 254.03, 56.14, 111.78, 297.98, 142.55, 334.84, 189.4, 117.78, 79.92, 108.09, 46.85, 38.16, 32.47, 28.37, 25.37, 22.98, 20.38, 19.78, 17.78, 16.78, 19.18, 17.98, 13.69, 9.99, 8.19, 7.59, 6.99, 6.79, 6.49, 6.39, 6.09, 5.99, 5.79, 5.79, 5.79, 5.79, 6.39, 5.99, 5.59, 31.97, 27.87, 5.89, 6.69};

// The RGB radiance of CIE HP1 scaled to a luminance (cd/m², luminance_cd_m2's dot(K, rgb)), as
// blackbody_rgb for a CCT. (V(λ) on the SPD itself gives 1.098× this luminance over 400-700 nm: the
// box basis averages V over each 100 nm, and HP1's light sits where V is above its band mean;
// scripts/lamp_spectra.py.)
std::array<double, 3> hp1_rgb(double luminance_cd_m2);

// Single-colour LEDs of traffic signals and rear lamps, each a Gaussian of its peak wavelength and
// full width at half maximum: S(λ) = exp(−4 ln2 (λ − peak)² / fwhm²), relative units. The dominant
// wavelengths are data sheets' (scripts/signal_spectra.py, its sources there): AlInGaP red 626 nm and
// amber 590 nm (Broadcom HSMx-A46x Table 3; HLMP-EGxx/ELxx, the traffic-signal lamps), InGaN cyan 505
// nm (Avago HLMP-CMxx, "matches international specifications for green traffic signals"). The
// peaks are a photosite choice: solved by that script so that the Gaussian's dominant wavelength
// (CIE 1931, from E) is the data sheet's (a symmetric Gaussian at the red data sheet's 635-nm peak
// would have a 632-nm dominant wavelength). The widths are [U]: typical data-sheet "spectral
// halfwidths" (17 nm AlInGaP, 30 nm InGaN), not read. Each lies inside ITE VTCSH's and EN 12368's
// signal colour (red also ECE R48's rear-lamp red). Rear lamps take the red signal's LED (a
// photosite choice: no rear-lamp LED data sheet read).
struct LedLine {
  double peak_nm, fwhm_nm;
};
inline constexpr LedLine kRedLed{628.49, 17.0};    // dominant 626 nm
inline constexpr LedLine kAmberLed{590.62, 17.0};  // dominant 590 nm
inline constexpr LedLine kGreenLed{505.70, 30.0};  // dominant 505 nm

// The lamp spectra the night chain gives each camera's metamer of (camera_metamer_rgb,
// sensor/pipeline.h; ScenePreset::lamp_camera_rgb): CIE HP1 for hps street lamps, the LEDs for
// traffic signals (red, amber, green) and vehicles' rear lamps (red).
enum class LampSpectrum : int { Hp1 = 0, RedLed, AmberLed, GreenLed };
inline constexpr int kLampSpectrumCount = 4;
// The spectrum's relative spectral power at λ (nm): HP1 linear between its 5-nm samples (0
// outside 380-780 nm), an LED its Gaussian.
double lamp_spd(LampSpectrum s, double wavelength_nm);

// 3x3 matrices between photosite's box RGB radiance and linear sRGB (Rec. 709 primaries, D65),
// from the boxes' CIE XYZ. srgb = M · box; box = M⁻¹ · srgb. Rows are output channels.
const std::array<std::array<double, 3>, 3>& box_to_linear_srgb();
const std::array<std::array<double, 3>, 3>& linear_srgb_to_box();

}  // namespace photosite::spectrum
