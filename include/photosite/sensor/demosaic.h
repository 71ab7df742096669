// Demosaicing: a single-channel CFA mosaic (linear, float) in, a full-colour linear RGB image
// out, for every pattern in cfa.h. For the clear patterns the output is still R, G, B: with a
// clear pixel passing R+G+B (photosite's box spectral basis), G = C - R - B for RCCB, and for
// RCCC (red + clear only) G = B = (C - R) / 2, a red-and-grey image.
//
// Methods (docs/demosaic.md has their accuracy and speed, measured side by side with OpenCV):
//   bilinear        per-colour bilinear interpolation (3x3).
//   malvar (mhc)    Malvar, He & Cutler 2004, gradient-corrected linear 5x5 filters.
//   hamilton-adams  Hamilton & Adams 1997 (US 5,629,734): green along the direction of the
//   (ha)            smaller gradient (first + second order), R/B from colour differences.
//   lmmse           Zhang & Wu 2005, directional linear minimum mean-square-error estimation
//                   of the green-minus-red/blue difference, fused by the estimation errors.
//   mlri            Kiku, Monno, Tanaka & Okutomi 2014, minimized-Laplacian residual
//                   interpolation: guided-filter estimates whose residuals are interpolated.
// Every method handles all four Bayer phases and RCCB (whose clear pixels take the place of
// green: the clear channel is smooth and correlated with R and B as green is). RCCC (a single
// sparse colour) and Mono use the bilinear path whatever the method. Borders are mirrored
// (reflect-101, which keeps the CFA phase): no black frame and no wrap-around.
#pragma once
#include <string>
#include <vector>

#include "photosite/image.h"
#include "photosite/sensor/cfa.h"

namespace photosite {

enum class DemosaicMethod { Bilinear, Malvar, HamiltonAdams, Lmmse, Mlri };

std::vector<std::string> demosaic_method_names();
std::vector<DemosaicMethod> all_demosaic_methods();
DemosaicMethod parse_demosaic_method(const std::string& name);  // bad input on unknown names
const char* to_string(DemosaicMethod m);
const char* demosaic_method_description(DemosaicMethod m);

ImageF demosaic(const ImageF& mosaic, CfaPattern pattern,
                DemosaicMethod method = DemosaicMethod::Bilinear);

// Bilinear interpolation: on Bayer and RCCB data the textbook per-colour bilinear (mirrored
// borders); on RCCC and Mono normalized convolution with [1 2 1; 2 4 2; 1 2 1] over the pixels
// of each filter colour, borders using only the neighbours that exist.
ImageF demosaic_bilinear(const ImageF& mosaic, CfaPattern pattern);
ImageF demosaic_malvar(const ImageF& mosaic, CfaPattern pattern);
ImageF demosaic_hamilton_adams(const ImageF& mosaic, CfaPattern pattern);
ImageF demosaic_lmmse(const ImageF& mosaic, CfaPattern pattern);
ImageF demosaic_mlri(const ImageF& mosaic, CfaPattern pattern);

namespace detail {
// demosaic_lmmse's two builds of one body (baseline SSE2 and AVX2, picked at run time by
// lmmse_have_avx2()); bit-identical results. Exposed for the test that says so.
ImageF demosaic_lmmse_baseline(const ImageF& mosaic, CfaPattern pattern);
ImageF demosaic_lmmse_avx2(const ImageF& mosaic, CfaPattern pattern);  // needs lmmse_have_avx2()
bool lmmse_have_avx2();
// LMMSE's 9 Gaussian weights (sigma 2), as the C++ path uses them (the Vulkan kernels take these).
void lmmse_gauss_weights(float out[9]);
// MLRI's float constants (sensor/demosaic_mlri.cpp), as the C++ path uses them; the Vulkan
// kernels take these. Relations k = 0..3 of a site class to a window centre (bit 0: other column
// parity, bit 1: other row parity).
struct MlriConstants {
  float gw[5];                     // one-sided Gaussian weights (sigma 3 px), gw[4] at the centre
  float tau_n_g[2], inv_n_g[2];    // green guided filters (1-D, 9 taps): tau / N and 1 / N per relation
  float tau_n_b[4], inv_n_b[4];    // red/blue guided filters (5x5)
  float inv_box_g, inv_box_b;      // 1/9, 1/25: the coefficient box means
};
const MlriConstants& mlri_constants();
// MLRI's stage margins around the frame (pixels), for the Vulkan dispatches: each stage is
// computed this far beyond the frame (along / across the direction for the green stages).
struct MlriGeometry {
  int rg, rb;                          // green (1-D) and red/blue (2-D) window radii
  int lap, ab, q, dif, across, green;  // green stages along the direction; across it; green
  int margin;                          // the support radius: how far a mosaic sample reaches
};
MlriGeometry mlri_geometry();
int mlri_support_radius();  // pixels: how far a mosaic sample influences the output
// demosaic_mlri's three builds of one body (baseline SSE2, AVX2 and AVX-512, the widest the CPU
// has picked at run time like LMMSE's); bit-identical results. Exposed for the test that says so.
ImageF demosaic_mlri_baseline(const ImageF& mosaic, CfaPattern pattern);
ImageF demosaic_mlri_avx2(const ImageF& mosaic, CfaPattern pattern);    // needs lmmse_have_avx2()
ImageF demosaic_mlri_avx512(const ImageF& mosaic, CfaPattern pattern);  // needs mlri_have_avx512()
bool mlri_have_avx512();  // AVX-512 F, VL, BW and DQ
// Bilinear demosaic one row at a time, for a caller that makes the mosaic row by row (the fused
// sensor loop, sensor/pipeline.cpp): whether a w×h mosaic of `pattern` takes demosaic_bilinear's
// mirrored Bayer path (Bayer phases and RCCB, at least 2×2; the row form exists only for it),
// and output row y of that path: above, centre, below are the mosaic rows reflect101(y-1), y,
// reflect101(y+1); rgb_row gets 3w floats; planar is 3w floats of scratch. The same code as
// demosaic_bilinear's rows, so the same bits as demosaic_bilinear on the whole mosaic.
bool bilinear_row_path(int w, int h, CfaPattern pattern);
void demosaic_bilinear_row(CfaPattern pattern, const float* above, const float* centre, const float* below, int y,
                           int w, int h, float* rgb_row, float* planar);
}  // namespace detail

// Writes n pixels of planar R, G, B rows as interleaved RGB (SSE2 shuffles where available).
void interleave_rgb(const float* r, const float* g, const float* b, float* rgb, int n);

// Turns per-filter planes (R, G, B, C interpolated at every pixel) into RGB for the pattern.
void filter_planes_to_rgb(CfaPattern pattern, const float planes[4], float rgb[3]);

// Clipped highlights of the clear patterns (RCCB, RCCC; other patterns: nothing is done, 0 is
// returned). A sample at the clip level (the well's capacity or the ADC's top code) carries no
// colour: its true value is only known to be at least the clip level, so G = C - R - B (RCCB)
// and G = B = (C - R) / 2 (RCCC) read from clipped samples are no colour at all (a clipped white
// gave G = -C on RCCB and a saturated red on RCCC). The rule: every output pixel whose 3x3 mosaic
// neighbourhood (the pixels that exist; the smallest window holding a sample of each of the
// pattern's colours, and the one bilinear reads) holds a sample >= clipped_at becomes
// R = G = B = neutral. The caller passes neutral = (clip level above black) / 3: a white
// (R = G = B = L) gives C = R + G + B = 3L on RCCB and C = R + 2G = 3L on RCCC, so its clear
// samples clip first, at L = clip / 3, the brightest white the sensor records; a clipped pixel is
// shown as that white (as dcraw's highlight mode 0 clips every channel where the first one
// saturates on white). mosaic and clipped_at are in the same units (mosaic: one channel, rgb's
// size), neutral in rgb's. Pixels with no clipped sample in their window keep their bits.
// Returns the number of pixels set.
size_t neutralize_clipped_highlights(ImageF& rgb, const ImageF& mosaic, CfaPattern pattern, float clipped_at,
                                     float neutral);
// The same at a white level V given in a file's or an array's stored values (`photosite demosaic
// --white-level`, `ps.demosaic(white_level=)`): a stored value v is the sample
// (v - stored_offset) * stored_scale; the clip level is (V - stored_offset) * stored_scale, and the
// neutral a third of it. Integer codes (a PNG, TIFF, uint array) clip at code >= V, so the samples
// at or above (V - 1/2 - stored_offset) * stored_scale count; float data at V itself. The caller
// has checked that the pattern is RCCB or RCCC and V is above stored_offset.
size_t neutralize_at_white_level(ImageF& rgb, const ImageF& mosaic, CfaPattern pattern, double white_level,
                                 double stored_offset, double stored_scale, bool integer_codes);

}  // namespace photosite
