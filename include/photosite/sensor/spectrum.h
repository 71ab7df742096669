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

// CIE illuminants LED-B1..B5, CIE 015:2018's typical phosphor-converted white LEDs (a blue InGaN
// pump line near 450 nm and a broad phosphor band), nominal CCTs 2700, 3000, 4000, 5000 and 6500 K:
// relative spectral power, 380-780 nm every 5 nm, the tables scripts/lamp_spectra.py reads and
// checks (their source there: colour-science/colour, CIE 015:2018) against CIE's chromaticities and
// the efficacies of night-photometry.md §0. What an led street lamp is, through a camera
// (led_b_spd, ScenePreset::lamp_camera_rgb).
inline constexpr double kLedBCct_K[5] = {2700, 3000, 4000, 5000, 6500};
inline constexpr double kLedBSpd5nm[5][81] = {
    {0, 0.01, 0.01, 0.02, 0.04, 0.07, 0.15, 0.28, 0.53, 0.92, 1.54, 2.52, 4.16, 6.39, 7.89, 7.57, 6.25, 5.16, 4.37, 3.84, 3.7, 3.88, 4.26, 4.79, 5.41, 6.05, 6.7, 7.34, 7.98, 8.64, 9.31, 10.02, 10.76, 11.53, 12.38, 13.28, 14.23, 15.2, 16.2, 17.19, 18.14, 19.02, 19.78, 20.38, 20.8, 21, 20.97, 20.71, 20.23, 19.56, 18.76, 17.82, 16.78, 15.66, 14.49, 13.31, 12.15, 11.02, 9.95, 8.93, 7.98, 7.1, 6.3, 5.57, 4.89, 4.26, 3.72, 3.25, 2.83, 2.47, 2.15, 1.87, 1.63, 1.42, 1.25, 1.1, 0.97, 0.86, 0.76, 0.68, 0.61},  // LED-B1
    {0, 0, 0, 0.01, 0.02, 0.05, 0.11, 0.24, 0.5, 0.96, 1.71, 2.82, 4.71, 7.87, 10.56, 10.24, 7.94, 6.25, 5.23, 4.36, 4, 4.17, 4.59, 5.21, 5.96, 6.72, 7.44, 8.11, 8.74, 9.39, 10.06, 10.75, 11.49, 12.25, 13.05, 13.86, 14.7, 15.5, 16.28, 17, 17.69, 18.31, 18.83, 19.24, 19.51, 19.59, 19.48, 19.19, 18.72, 18.1, 17.34, 16.47, 15.51, 14.49, 13.42, 12.33, 11.26, 10.24, 9.25, 8.3, 7.42, 6.6, 5.85, 5.17, 4.55, 3.99, 3.49, 3.04, 2.65, 2.31, 2.01, 1.75, 1.52, 1.32, 1.15, 1, 0.87, 0.76, 0.67, 0.59, 0.52},  // LED-B2
    {0, 0, 0.01, 0.02, 0.05, 0.11, 0.25, 0.56, 1.2, 2.37, 4.24, 7.17, 12.11, 17.7, 18.87, 14.58, 9.9, 7.53, 6.02, 5.11, 5.17, 5.82, 6.77, 7.88, 8.94, 9.82, 10.52, 11.06, 11.51, 11.93, 12.37, 12.83, 13.31, 13.79, 14.26, 14.68, 15.08, 15.42, 15.72, 15.97, 16.18, 16.37, 16.5, 16.55, 16.5, 16.32, 16, 15.54, 14.96, 14.27, 13.48, 12.62, 11.71, 10.78, 9.85, 8.93, 8.04, 7.2, 6.42, 5.69, 5.02, 4.42, 3.88, 3.39, 2.95, 2.56, 2.22, 1.92, 1.65, 1.43, 1.23, 1.06, 0.91, 0.78, 0.68, 0.58, 0.5, 0.43, 0.37, 0.32, 0.28},  // LED-B3
    {0, 0, 0, 0.01, 0.03, 0.08, 0.21, 0.54, 1.31, 2.75, 5.04, 8.31, 13.37, 20.61, 25.91, 24.12, 17.47, 11.9, 8.62, 6.34, 4.89, 4.25, 4.19, 4.7, 5.77, 7.27, 8.94, 10.6, 12.11, 13.36, 14.3, 15.02, 15.54, 15.9, 16.15, 16.33, 16.42, 16.44, 16.36, 16.2, 15.98, 15.7, 15.36, 14.93, 14.44, 13.86, 13.24, 12.57, 11.84, 11.12, 10.38, 9.65, 8.91, 8.19, 7.51, 6.86, 6.21, 5.6, 5.05, 4.54, 4.05, 3.62, 3.23, 2.87, 2.53, 2.24, 1.99, 1.76, 1.55, 1.37, 1.21, 1.07, 0.95, 0.85, 0.75, 0.67, 0.61, 0.55, 0.5, 0.45, 0.42},  // LED-B4
    {0, 0.01, 0.01, 0.03, 0.07, 0.16, 0.35, 0.78, 1.67, 3.3, 5.94, 9.92, 16.15, 25.15, 32.34, 31.18, 23.46, 16.39, 12.08, 9.08, 7.21, 6.48, 6.49, 7.05, 8.1, 9.45, 10.88, 12.22, 13.38, 14.29, 14.98, 15.48, 15.81, 16.01, 16.1, 16.13, 16.1, 15.98, 15.77, 15.5, 15.15, 14.76, 14.31, 13.79, 13.22, 12.59, 11.91, 11.2, 10.47, 9.73, 9, 8.27, 7.57, 6.9, 6.25, 5.65, 5.08, 4.55, 4.06, 3.61, 3.22, 2.86, 2.54, 2.26, 2, 1.75, 1.54, 1.36, 1.2, 1.05, 0.93, 0.82, 0.72, 0.64, 0.56, 0.49, 0.44, 0.39, 0.35, 0.31, 0.27},  // LED-B5
};
// The LED-B spectrum at a CCT (K), relative spectral power at λ (nm), linear between the tables'
// 5-nm samples (0 outside 380-780 nm): between two of kLedBCct_K the two neighbouring tables, each
// scaled to the same photopic luminance (Σ S·ȳ over its samples, photosite's ȳ fit), blended
// linearly in mired (10⁶/T) — a photosite choice (CIE gives five lamps, no family between them; a
// CCT is near linear in mired along the Planck locus, and both tables' shapes are kept at their
// ends); at or outside the range's ends (≤ 2700 K, ≥ 6500 K) the nearest table alone, another
// photosite choice (no CIE LED-B beyond them). At a table's own CCT, that table (scaled).
double led_b_spd(double cct_K, double wavelength_nm);

// A spectrum tabulated every 5 nm from 380 nm (n samples) at λ (nm): linear between the samples,
// 0 outside 380 .. 380 + 5·(n − 1) nm. What lamp_spd, led_b_spd and camera_metamer_rgb read the
// CIE tables with.
double table_5nm(const double* spd, int n, double wavelength_nm);

// The lamp spectra the night chain gives each camera's metamer of (camera_metamer_rgb,
// sensor/pipeline.h; ScenePreset::lamp_camera_rgb): CIE HP1 for hps street lamps, the LEDs for
// traffic signals (red, amber, green) and vehicles' rear lamps (red), and for led street lamps CIE
// LED-B at a CCT (led_b_spd): LedBHeads at lamps.streetlamp_cct_K (the lamps' heads),
// LedBStreet at street.cct_K (their light on the street: pools, vertical light).
enum class LampSpectrum : int { Hp1 = 0, RedLed, AmberLed, GreenLed, LedBHeads, LedBStreet };
inline constexpr int kLampSpectrumCount = 6;
// The spectrum's relative spectral power at λ (nm): HP1 linear between its 5-nm samples (0
// outside 380-780 nm), an LED its Gaussian, LedBHeads and LedBStreet led_b_spd at cct_K (which
// the others ignore; a LED-B one without a positive, finite cct_K is an internal error).
double lamp_spd(LampSpectrum s, double wavelength_nm, double cct_K = 0);

// CIE XYZ to linear sRGB (Rec. 709 primaries, D65 white), rows R, G, B: the matrix derived from
// the primaries' and the white's chromaticities (B. Lindbloom, "RGB/XYZ Matrices"). IEC
// 61966-2-1:1999 prints a four-decimal matrix (3.2406, -1.5372, -0.4986 / -0.9689, 1.8758, 0.0415 /
// 0.0557, -0.2040, 1.0570): the inverse of its four-decimal RGB→XYZ matrix (0.4124, 0.3576, 0.1805
// / ...), which differs from this one by up to 3.7e-4 per entry.
// photosite's one copy: the box basis (box_to_linear_srgb) and the daylight locus
// (scene::daylight_log_ratios) both use it.
inline constexpr double kXyzToLinearSrgb[3][3] = {{3.2404542, -1.5371385, -0.4985314},
                                                  {-0.9692660, 1.8760108, 0.0415560},
                                                  {0.0556434, -0.2040259, 1.0572252}};

// 3x3 matrices between photosite's box RGB radiance and linear sRGB (Rec. 709 primaries, D65),
// from the boxes' CIE XYZ. srgb = M · box; box = M⁻¹ · srgb. Rows are output channels.
const std::array<std::array<double, 3>, 3>& box_to_linear_srgb();
// The inverse of a 3 x 3 matrix (adjugate over determinant; a singular one gives inf or NaN entries).
std::array<std::array<double, 3>, 3> invert3(const std::array<std::array<double, 3>, 3>& m);
const std::array<std::array<double, 3>, 3>& linear_srgb_to_box();

}  // namespace photosite::spectrum
