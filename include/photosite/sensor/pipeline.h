// The sensor chain, stage by stage, in physical units:
//   radiance RGB (W·sr⁻¹·m⁻²) ─optics→ irradiance ─photon integral→ mean electrons per pixel
//   ─PRNU, dark current, shot noise→ electrons ─read noise, gain, full well, ADC→ DN mosaic
//   ─black level removed, demosaic→ RGB (DN).
// Each stage is a pure function; expose() composes them. docs/sensor.md has the equations.
#pragma once
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <vector>

#include "photosite/image.h"
#include "photosite/sensor/demosaic.h"
#include "photosite/sensor/fpn.h"
#include "photosite/sensor/poisson.h"
#include "photosite/sensor/preset.h"
#include "photosite/sensor/spectrum.h"

namespace photosite {

struct ExposureSettings {
  double exposure_s = 0.02;
  std::optional<double> f_number;       // none: the lens preset's
  double gain_db = 0.0;                 // analog gain over K
  std::optional<double> temperature_c;  // none: the camera preset's
  uint64_t seed = 0;     // temporal-noise seed (the device seed keys the fixed pattern)
  uint32_t frame = 0;
  DemosaicMethod demosaic = DemosaicMethod::Bilinear;
  PoissonMethod poisson = PoissonMethod::Exact;  // the shot-noise sampler (poisson.h)
};

// Settings with the preset/lens defaults filled in and checked (bad input on impossible values).
struct ResolvedExposure {
  double exposure_s, f_number, gain_db, gain_linear, temperature_c;
  double system_gain_dn_per_e;   // K · 10^(gain_db/20)
  double dark_current_e_per_s;   // mean rate at temperature_c (doubling law)
  double hot_pixel_rate_e_per_s; // hot pixels' mean rate at temperature_c
};
ResolvedExposure resolve(const CameraPreset& preset, const LensPreset& lens,
                         const ExposureSettings& settings);

// Optics (Eq. 3 of Baek 2020 after Jähne / EMVA 1288): image-plane irradiance per unit scene
// radiance, E/L = π·T / (1 + 4(N(1+|m|))²), times cos⁴θ at the pixel when enabled.
double irradiance_per_radiance(double f_number, double magnification, double transmittance);

// The photon integral reduced to a matrix: mean electrons in a pixel with filter colour c per
// unit band radiance (W·sr⁻¹·m⁻²) of band k (R, G, B), for the on-axis pixel:
//   e[c][k] = t · A_pix · FF · (E/L) · ∫ b_k(λ) QE_c(λ) λ/(hc) dλ.
using PhotonMatrix = std::array<std::array<double, 3>, 4>;
PhotonMatrix photon_matrix(const CameraPreset& preset, const LensPreset& lens,
                           const ResolvedExposure& exposure);

// A light source's colour as this camera records it, in photosite's box basis: the band radiances
// w (R, G, B, W·sr⁻¹·m⁻² per cd/m² of the source's photometric luminance) that the camera's filters
// turn into the same electrons as the source's own spectrum does, Σ_k M[c][k]·w_k = ∫ S(λ) QE_c(λ)
// λ/(hc) dλ / L_v(S) for each filter colour c the camera has (M: photon_matrix's band integrals;
// S: `spd` on the 5-nm grid from 380 nm, `n` samples, linear between them; L_v = 683 ∫ S·V dλ with
// photosite's V(λ)). A camera metamer: for a line spectrum such as sodium's, which the boxes cannot
// carry, the camera's raw colour of a grey surface it lights is the spectrum's (the band integrals'
// would be 2.2-2.4 times too green, docs/night.md §7), but its box luminance is not L_v and another
// camera needs other w. Three filter colours: the 3x3 solve; one or two (RCCC): the least-norm
// solution. Where that w has a negative box (a narrow LED line the flat boxes cannot carry through
// these filters: the green signal on every bundled camera, the amber's B and the red's G on the
// RGB ones), the non-negative w closest to the spectrum's electrons in least squares instead
// (non-negative least squares over the filter colours; docs/night.md §7 "Signal and rear-lamp
// LEDs" gives what is then left). Empty (all 0) where no filter has a QE table.
std::array<double, 3> camera_metamer_rgb(const CameraPreset& preset, const double* spd, int n);
// The same for one of the named lamp spectra (spectrum::lamp_spd): HP1 through its 5-nm table
// (the overload above), an LED's Gaussian or CIE LED-B's blend at cct_K (LedBHeads, LedBStreet;
// the others ignore cct_K) at every quadrature point.
std::array<double, 3> camera_metamer_rgb(const CameraPreset& preset, spectrum::LampSpectrum s, double cct_K = 0);

// The lens's veiling-glare plan on this camera: plan_glare at the lens's pixels per degree on the
// sensor's pitch. The one plan the CPU and Vulkan photon stages use, and by which the night chain
// decides whether its compose pass makes the glare's level 1.
GlarePlan lens_glare_plan(const CameraPreset& preset, const LensPreset& lens);

struct GlareLevel1;  // sensor/glare.h

// Mean photo-electrons per pixel (before PRNU and noise), sampled through the CFA. Rejects NaN,
// Inf and negative radiance (bad input). `glare_level1`: the lens glare's level 1 of this
// radiance, made by the caller (glare_level1_row: the scene's compose pass), or null; the same
// result either way.
ImageF mean_signal_electrons(const ImageF& radiance_rgb, const CameraPreset& preset,
                             const LensPreset& lens, const ResolvedExposure& exposure,
                             const GlareLevel1* glare_level1 = nullptr);

struct SensorOutput {
  ImageF electrons;  // e-, collected (signal + dark) after shot noise, integer-valued
  ImageF raw_dn;     // DN, ADC output with black level, integer-valued, CFA mosaic
  ImageF rgb;        // DN above black, demosaiced linear RGB (3 channels)
};

// From mean photo-electrons to the camera's output: PRNU, dark current (+ its non-uniformity
// and hot pixels), Poisson shot noise, DSNU offset, read noise (Gaussian or Tukey-λ), row and
// column noise, full well, conversion gain, black level, ADC quantization, demosaic.
SensorOutput sense(const ImageF& mean_signal_e, const CameraPreset& preset,
                   const ResolvedExposure& exposure, const ExposureSettings& settings,
                   const FixedPatternMaps& fpn);

// The whole chain from scene radiance.
SensorOutput expose(const ImageF& radiance_rgb, const CameraPreset& preset, const LensPreset& lens,
                    const ExposureSettings& settings, const FixedPatternMaps& fpn,
                    const GlareLevel1* glare_level1 = nullptr);

// sense() and expose() into a caller-owned SensorOutput: the same results, with out's images
// reused where they already have the frame's shape (else made). A caller that runs frame after
// frame and keeps one SensorOutput (its previous frame's outputs consumed) skips the first-touch
// page faults of fresh outputs (electrons, raw, RGB: 40 MB a 2048×1024 frame). out must not be,
// or share buffers with, an input.
void sense(const ImageF& mean_signal_e, const CameraPreset& preset, const ResolvedExposure& exposure,
           const ExposureSettings& settings, const FixedPatternMaps& fpn, SensorOutput& out);
void expose(const ImageF& radiance_rgb, const CameraPreset& preset, const LensPreset& lens,
            const ExposureSettings& settings, const FixedPatternMaps& fpn, SensorOutput& out,
            const GlareLevel1* glare_level1 = nullptr);

// The sensor's full scale in DN above black at this exposure: the ADC's top code above black or
// the full well times the system gain, the lower (the previews' exposure, isp.h, and the clip
// level below).
double sensor_full_scale_dn(const CameraPreset& camera, const ResolvedExposure& exposure);

// Where the sensor's output clips, for the clear patterns' highlight handling
// (neutralize_clipped_highlights, sensor/demosaic.h), which sense() and expose() (on either
// backend) apply to their R, G, B. A full well reads FW·K + black DN on average (K: the system
// gain) and the ADC stops at its top code 2^bits - 1; after the well the samples still take the
// DSNU offset, read, row and column noise (σ in quadrature, e-) and one rounding, so a clipped
// sample lies at min(top code, FW·K + black ± 4Kσ ± 0.5) but for a 6.3e-5 two-sided tail (a
// pixel escapes only when all nine samples of its window do). clipped_at_dn (raw DN):
// min(top code, FW·K + black - 4Kσ - 0.5); neutral_dn (DN above black): the clip level
// sensor_full_scale_dn = min(FW·K, top code - black) over 3, the white that reaches it.
struct ClipLevel {
  double clipped_at_dn;
  double neutral_dn;
};
ClipLevel clip_level(const CameraPreset& preset, const ResolvedExposure& exposure);
// out.rgb's clipped highlights made neutral (out.raw_dn the mosaic): what sense() and expose() do
// last; returns the number of pixels set (0 for the Bayer patterns and Mono).
size_t neutralize_clipped_highlights(SensorOutput& out, const CameraPreset& preset, const ResolvedExposure& exposure);

// A flat field of `photons_per_pixel` mean photons of one wavelength on every pixel (0: dark).
SensorOutput flat_field(double photons_per_pixel, double wavelength_nm, int width, int height,
                        const CameraPreset& preset, const LensPreset& lens,
                        const ExposureSettings& settings, const FixedPatternMaps& fpn);

// Pieces of sense() shared with the Vulkan backend (gpu/sensor_chain.cpp), so both paths key,
// check and draw the same way.
namespace detail {
// The temporal-noise key: the run seed mixed into the device seed.
uint64_t temporal_key(uint64_t device_seed, uint64_t seed);
// Bad input when the maps do not fit the frame or belong to another preset.
void check_sense_inputs(int width, int height, const CameraPreset& preset, const FixedPatternMaps& fpn);
// Bad input unless the scene radiance is a non-empty 3-channel (R, G, B) image.
void check_radiance_shape(const ImageF& radiance);
// Bad input naming the first non-physical radiance pixel (x, y) (NaN, Inf or negative), the one
// the photon stage found (CPU: its scan; Vulkan: the kernel's atomic minimum index).
[[noreturn]] void fail_bad_radiance(const ImageF& radiance, int x, int y);
// One Gaussian per row and per column per frame (e-); empty vectors when the preset has none.
void row_column_noise(const CameraPreset& preset, uint64_t key, uint32_t frame, int width, int height,
                      std::vector<float>& row_e, std::vector<float>& col_e);
// ParameterError "wavelength_nm" unless the wavelength lies in [200, 1200] nm and on the preset's
// QE table (QeTable::at is 0 outside it: a flat field there would be a dark frame).
void check_flat_field_wavelength(double wavelength_nm, const CameraPreset& preset);
// flat_field()'s mean photo-electrons per pixel (before sense()).
ImageF flat_field_mean(double photons_per_pixel, double wavelength_nm, int width, int height,
                       const CameraPreset& preset);
}  // namespace detail

}  // namespace photosite
