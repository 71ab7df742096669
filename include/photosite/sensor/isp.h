// A small, documented ISP for previews (people look at these; the EXR is the data):
//  1. white balance: per-channel gains that make an equal-energy white (box radiance 1,1,1)
//     neutral through this camera's QE and CFA (von Kries on the camera's own response);
//  2. colour matrix: none by default (camera RGB is shown as if it were linear sRGB; documented),
//     or the camera's colour correction matrix (colour_correction_matrix below, `--preview-ccm camera`);
//  3. exposure: the 99th percentile of luminance maps to `white_point` (default 1);
//  4. tone curve: the sRGB transfer function (IEC 61966-2-1), clipped to [0, 1].
#pragma once
#include <array>
#include <vector>
#include <cstdint>
#include <string>

#include "photosite/image.h"
#include "photosite/sensor/pipeline.h"

namespace photosite {

std::array<double, 3> white_balance_gains(const CameraPreset& preset);
double srgb_encode(double linear);  // IEC 61966-2-1 OETF
double srgb_decode(double encoded);  // its inverse

// rgb: linear camera RGB (any scale, e.g. DN above black). Returns sRGB-encoded [0,1] floats.
// The exposure maps the `percentile` of the white-balanced luminance to `white_point`, that
// luminance taken as at least min_white (0: no floor; preview_min_white() gives a camera's).
ImageF preview_srgb(const ImageF& rgb, const std::array<double, 3>& wb_gains,
                    double percentile = 0.99, double white_point = 1.0, double min_white = 0.0);
// The same preview as 8-bit sRGB codes, what a PNG preview stores: each sample's code is the
// nearest to 255 · srgb_encode(x), x = rgb · wb · scale in float, found by comparing x with the
// 255 decision levels srgb_decode((k - 1/2) / 255) (no pow per sample). Exact: a level is kept
// as the smallest float not below its double value, so for a float x the comparison decides as
// the double one would.
uint8_t srgb_encode8(float linear);  // that code for one sample (NaN and below 0: 0)
// preview_srgb8's inner loop, exposed for tests: dst[j] = srgb_encode8(src[j] · gain[j mod 3])
// for the n samples of n / 3 RGB pixels; `vector`: AVX2 where the CPU has it (the same codes).
void srgb_encode8_rgb(const float* src, size_t n, const float gain[3], uint8_t* dst, bool vector = true);
ImageU8 preview_srgb8(const ImageF& rgb, const std::array<double, 3>& wb_gains,
                      double percentile = 0.99, double white_point = 1.0, double min_white = 0.0);

// The camera's colour correction matrix (CCM; `night --preview-ccm camera`, docs/sensor.md §9):
// a camera ISP maps its white-balanced raw RGB to the display's colour space with a 3 x 3 matrix
// fitted to the camera's spectral sensitivities (ISO 17321-1; the raw processors' "camera matrix").
// photosite's scene radiance lies in its three-box basis (spectrum::box_to_linear_srgb), where the
// camera's RGB is exactly M·b (M: camera RGB per unit box radiance, the photon matrix through the
// CFA's filter_planes_to_rgb), so the matrix is derived, not fitted: C = s·T·M⁻¹·diag(1/wb), with
//   wb  the preset's white balance (white_balance_gains: equal-energy white neutral),
//   T   = diag(1 / (B·1))·B, B = box_to_linear_srgb: the boxes' sRGB colours, von Kries-scaled so
//       that the equal-energy white (box 1, 1, 1) is neutral, as the white balance makes it,
//   s   = (M·1)_G, so that every row of C sums to 1: a neutral keeps its value (and the exposure,
//       the white floor and the camera ISP's noise model their meaning).
// Then C·(wb ∘ M·b) = s·T·b for every box radiance b: the preview shows the scene's colour instead
// of the camera's (its filters' overlaps desaturate, their peaks shift the hues). Saturated
// colours fall outside sRGB (negative entries, clipped by the tone curve, as in a camera) and the
// off-diagonal terms amplify the chroma noise, as a real CCM does. A camera without three
// independent colour channels (RCCC: its G and B are the same clear-minus-red; Mono) has no such
// matrix: ParameterError "preview_ccm" where M's determinant is below 1e-6 of the product of its
// columns' norms (Hadamard's bound on the determinant; a photosite threshold, far below the RGB
// cameras' ratios, which the test ColourMatrix.* prints).
using ColourMatrix = std::array<std::array<double, 3>, 3>;
ColourMatrix colour_correction_matrix(const CameraPreset& camera);
// The demosaiced DN above black through the CCM, still in the white-balanced preview's input space:
// each pixel c -> diag(1/wb)·C·diag(wb)·c (in double, stored as float), so that a preview of it with
// the gains wb shows C·(wb ∘ c). `wb`: the preview's gains (the preset's or the AWB's, whose ratio
// to the preset's then acts in camera space before the matrix, as a camera's AWB gains do).
ImageF apply_colour_matrix(const ImageF& rgb, const ColourMatrix& ccm, const std::array<double, 3>& wb_gains);

// Auto exposure of a preview (`photosite bench realism`'s auto-exposure methods; not an option of
// `night`, whose preview keeps the 99th percentile; docs/realism.md): the
// gain a camera's auto exposure (AE) settles at, applied to the simulated frame, and the sensor's
// full scale divided by that gain shown as white, instead of the frame's 99th percentile.
// The AE meters the frame's mean luminance (white-balanced camera RGB, Rec. 709 weights, each
// pixel clipped at the sensor's full scale: a saturated pixel reports no more than full scale)
// and raises the gain until that mean reaches `target` of the full scale or the gain reaches
// `max_gain`. The exposure time stays the simulated one (an ADAS AE of this kind fixes it and
// moves only the gain: TI's AE set-up for the IMX390 on TDA4/AM6xA, exposure 11 ms fixed, analog
// gain 1-8x; e2e.ti.com FAQ thread 1262114). The gain is applied digitally to the simulated
// frame; a camera applies it before the ADC, which lowers the ADC's quantization and the read
// noise after the gain relative to the signal (the preview keeps the simulated frame's noise).
// The AE cannot go below the simulated exposure (min gain 1): the frame's clipping is done.
struct AutoExposure {
  // Mean metered luminance / full scale. TI's AE for ADAS cameras: targetBrightness 45 on 0-255,
  // "45 for 18% gray" (linear raw statistics; the same FAQ) [D]. The ISO 2720 / ISO 12232 meter
  // calibration puts the mean at 12.7-12.8 % of saturation instead (K = 12.5-14 cd s/m2);
  // 45/255 = 17.6 % is the automotive ISP's value.
  double target = 45.0 / 255.0;
  double max_gain = 1.0;  // linear gain headroom above the simulated frame: 10^(max_gain_db/20) / its gain
  // Highlight protection, 0: none. > 0: the gain is also kept at or below the one at which this
  // fraction of the pixels clips (their metered luminance reaches full scale), as AEs that limit
  // the clipped share of the frame do. 0.01 is photosite's own 99th-percentile preview rule [E],
  // not a measured camera setting.
  double clip_fraction = 0;
};
// The gain G in [1, max_gain] at which mean_i min(G * y_i, 1) = target, y_i a pixel's luminance
// over the white-balanced full scale (wb gains divided by the smallest, so a pixel saturated in
// every channel has y >= 1); max_gain when the target is out of reach (an all-black frame too),
// 1 when the frame already meters above it. With clip_fraction h > 0, G is at most 1 / y_(k),
// y_(k) the k-th smallest y, k = floor((1 - h)(n - 1)) (no more than about h of the pixels clip),
// and still at least 1. Deterministic for any thread count.
double auto_exposure_gain(const ImageF& rgb, const std::array<double, 3>& wb_gains, double full_scale_dn,
                          const AutoExposure& ae);
// The 8-bit sRGB preview at that gain: sample x -> srgb_encode8(x * wb_c * G / (min(wb) * full scale)).
ImageU8 preview_srgb8_auto(const ImageF& rgb, const std::array<double, 3>& wb_gains, double full_scale_dn,
                           const AutoExposure& ae, double* gain_out = nullptr);
// The sensor's full scale in DN above black: sensor_full_scale_dn (sensor/pipeline.h).
// The AE of a camera at this exposure: the target above and the preset's gain range,
// max_gain = 10^(max_gain_db / 20) / the exposure's own linear gain (at least 1).
AutoExposure camera_auto_exposure(const CameraPreset& camera, const ResolvedExposure& exposure);
// The floor of the percentile previews' white (preview_srgb's min_white, in the white-balanced
// luminance of DN above black): a preview applies no more gain than the camera itself could add,
// so the white is at least the full scale over the camera's remaining gain range,
// min(wb) · sensor_full_scale_dn / camera_auto_exposure().max_gain. Without it a frame with no
// signal (0 e- everywhere) previewed as its read noise stretched to white. Frames whose 99th
// percentile lies above it (every night frame of the shared data at the presets' exposures) keep
// their preview.
double preview_min_white(const CameraPreset& camera, const ResolvedExposure& exposure,
                         const std::array<double, 3>& wb_gains);

// Auto white balance of a preview (`night --preview-wb auto`, docs/realism.md): the gray-world
// estimate (Buchsbaum 1980, J. Franklin Inst. 310:1-26: the scene's mean reflectance is taken as
// achromatic, so the frame's mean raw colour is the illuminant's), metered as a camera ISP's AWB
// statistics are: only pixels with every channel finite and below `clip` of the sensor's full scale
// (a clipped channel's ratio is the clip level's, not the light's; OpenCV's xphoto::GrayworldWB
// likewise drops pixels by a threshold). Pixels near black are kept: the frame is DN above black,
// its noise is zero-mean, so the sums are unbiased where a dark cut would bias them (a photosite
// choice). Gains g_c = mean_G / mean_c (green 1, as white_balance_gains), each then held inside
// the box `bounds` (see camera_awb_bounds). Where the metered means are not signal (no pixel
// metered, or a channel's mean below 3 standard errors of it from the pixels' own spread: a
// black or noise-only frame) the gains are `fallback` (the preset's fixed white balance).
// Sums in double over fixed 65536-pixel chunks added in chunk order: the same for any thread count.
struct AwbBounds {
  std::array<double, 3> lo{1, 1, 1}, hi{1, 1, 1};  // per-channel gain range, green 1
};
// The bound of a real AWB: it corrects only along the illuminants it expects. Here the gains the
// camera itself needs for a black body between cct_lo_K and cct_hi_K (its photon_matrix on
// blackbody_rgb, the box basis; sampled every 1/64 of the range in mired, min/max per channel).
// 2000-10000 K: a camera's white-balance scale from blue sky (10000 K) down to sodium/candle
// light (the colour-temperature chart of a camera manual's WHITE BAL menu, Samsung SCC-643P; the
// high-pressure sodium street lamp, the warmest the night scenes have, is ~2000 K CCT); a
// photosite choice of range, fixed before any measurement.
AwbBounds camera_awb_bounds(const CameraPreset& camera, double cct_lo_K = 2000, double cct_hi_K = 10000);
std::array<double, 3> auto_white_balance_gains(const ImageF& rgb, double full_scale_dn, const AwbBounds& bounds,
                                               const std::array<double, 3>& fallback, double clip = 0.95);

// The camera-ISP preview (`photosite night --preview-isp camera`, docs/realism.md): an
// approximation of a generic in-camera ISP, what a dashcam or phone JPEG went through, for
// previews that are compared with real night photos. Not any one camera's ISP; the EXR sensor
// layers never pass through it. Steps, on the demosaiced DN above black:
//  1. variance stabilisation: the generalized Anscombe transform of the sensor's Poisson-Gaussian
//     noise (Murtagh, Starck & Bijaoui 1995; Makitalo & Foi 2013),
//     t = 2·sqrt(max(x/K + σ_r² + 3/8, 0)), x in DN, K the system gain in DN/e-, σ_r the read
//     noise in e- (ADC quantization, 1/12 DN², added to σ_r²): the noise of t is about 1 at every
//     level (an approximation: demosaicing correlates and shrinks the noise of the interpolated
//     channels);
//  2. noise reduction: the guided filter (He, Sun & Tang, ECCV 2010, self-guided: an edge-preserving
//     smoother) on an opponent transform of t, luma Y = (R+G+B)/3 and chroma C1 = (R-B)/2,
//     C2 = (R-2G+B)/4, with ε = (strength·σ)², σ the noise of that channel in the stabilised domain
//     (Y: √3/3, C1: √2/2, C2: √6/4 for unit independent channel noise); chroma over a larger window
//     (cameras filter colour noise harder than luma);
//  3. back to DN by the algebraic inverse of 1 (biased below a few electrons; a preview);
//  4. white balance and exposure as preview_srgb (the `percentile` luminance maps to
//     `white_point`), the sRGB transfer function, 8 bits;
//  5. optional unsharp mask on the 8-bit image (in-camera sharpening) and a JPEG round trip
//     (libjpeg via OpenCV, 4:2:0 chroma), as the real photos' cameras stored them.
struct CameraIspOptions {
  double denoise = 1.0;         // luma noise-reduction strength (ε = (denoise·σ_Y)²: 1 smooths what is
                                // within the noise and keeps what stands above it); 0: off
  double chroma_denoise = 2.0;  // chroma strength; 0: off
  int luma_radius_px = 2;       // guided-filter window (2r+1)² for luma
  int chroma_radius_px = 4;     // and for chroma
  double sharpen = 0.0;         // unsharp-mask amount (0: none), Gaussian σ 1 px
  int jpeg_quality = 90;        // JPEG round trip at this quality (1-100); 0: none. 90: photosite choice
                                // (the real photos' qualities are unknown; BDD100K, nuScenes were JPEGs)
  double percentile = 0.99, white_point = 1.0;  // exposure, as preview_srgb
  double min_white = 0.0;                       // as preview_srgb's (preview_min_white: a camera's)
  // > 0: fixed exposure instead: white balance gains divided by the smallest, every channel
  // clipped at this full scale (DN above black), shown as white (the bench's "ISP full scale").
  double full_scale_dn = 0;
};
// The sensor's noise model for step 1: K (system gain, DN per e-) and the read noise (e-).
struct PreviewNoise {
  double gain_dn_per_e = 1.0;
  double read_noise_e = 0.0;
};
// Throws photosite::Error naming the field when an option is out of range.
void check_camera_isp_options(const CameraIspOptions& o);
// The same for a width x height frame: the JPEG round trip (jpeg_quality > 0) takes frames of at most
// 65500 px a side, JPEG's limit (bad input naming preview_jpeg_quality beyond it).
void check_camera_isp_frame(const CameraIspOptions& o, int width, int height);
ImageU8 preview_camera8(const ImageF& rgb, const std::array<double, 3>& wb_gains, const PreviewNoise& noise,
                        const CameraIspOptions& options = {});
// The k-th smallest value of v (0-based; v without NaN): the value std::nth_element would put at
// k, found by a radix select (exposed for tests; the previews' percentile exposure uses it).
float kth_smallest(const std::vector<float>& v, size_t k);
// The guided filter of step 2 on one float plane (exposed for tests): mean over a (2r+1)² window
// clipped at the borders, deterministic for any thread count.
ImageF guided_filter_self(const ImageF& plane, int radius_px, double eps);

}  // namespace photosite
