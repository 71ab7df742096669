// Minimized-Laplacian residual interpolation (MLRI).
// D. Kiku, Y. Monno, M. Tanaka, M. Okutomi, "Minimized-Laplacian residual interpolation for color
// image demosaicking", Proc. SPIE 9023, Digital Photography X, 90230L (2014); built on their
// "Residual interpolation for color image demosaicking", Proc. IEEE ICIP 2013, pp. 2304-2308.
//
// Residual interpolation: instead of interpolating a colour (or the colour difference G - X, as
// Hamilton-Adams and LMMSE do), fit a local linear model X ~ a G + b of the missing colour on a
// guide, evaluate it everywhere (the "tentative" estimate), and interpolate only the residual
// X - tentative between the sites where X was measured. Where the channels are not similar (a
// saturated red edge has a jump in G - R), the residual is still smooth if the local model holds.
// MLRI fits (a, b) by minimizing the energy of the Laplacian of the residual instead of the
// residual itself (the guided filter of He, Sun & Tang, TPAMI 35(6), 2013, with its slope taken
// from Laplacians):
//     a = sum_M L(I) L(p) / sum_M L(I)^2,        b = mean_M(p) - a mean_M(I),
// the sums over the sites M of the sparse colour p in a window, L a Laplacian along the sampled
// lattice (step 2), I the guide; then (a, b) are averaged over the window (the guided filter's
// second box) and the tentative estimate is a_mean I + b_mean.
//
// What this file computes (parameters stated, chosen on the Kodak set; docs/demosaic.md):
// 1. Green, per direction d (horizontal, vertical), as in RI/MLRI: guides by 2-tap linear
//    interpolation along d (G at R/B sites, R or B at the green sites of their row/column). In
//    each row (column) two guided filters: the red (blue) samples on the green guide and the green
//    samples on the red (blue) guide, L = [-1 0 2 0 -1] along d, window 5x5 (radius kRg = 2).
//    The residuals at the measured sites are interpolated with [1/2 . 1/2] along d, giving a
//    directional colour difference G - X at every pixel.
// 2. The directional differences are combined as in GBTF (Pekkucuksen & Altunbasak, ICASSP 2010)
//    and RI: weights 1 / (sum of |difference gradient| over 3x3, taken one pixel to the N, S, W, E)^2,
//    and one-sided 5-tap Gaussian (sigma 3 px) averages of the differences towards each side;
//    green = X + combined difference at the R and B sites.
// 3. Red and blue: one MLRI guided filter each on the full green plane, the sparse R (B) samples,
//    L the 5-point cross Laplacian with step 2, window 5x5 (radius kRb = 2); residual interpolated
//    bilinearly (3x3 [1/4 1/2 1/4; 1/2 1 1/2; 1/4 1/2 1/4]); measured samples kept as they are.
// Regularization: sum L(I)^2 is clamped below at tau N mean_M(I)^2 (tau = 1e-3), a scale-free
// form of the original's fixed floor on the mean squared Laplacian; where both are 0, a = 0.
// Borders: the mosaic is extended by reflect-101 (parity-preserving: a valid mosaic of the
// mirrored scene) and every stage runs on the extended frame; the support radius is 23 px.
//
// Arithmetic: every window sum is separable, row (x) first then column (y), each in a fixed order
// (increasing offsets, or for the green filters' 1-D windows pairs q(o) + q(o + 2) added as
// demosaic_mlri_body.inc says), so a value does not depend on how the frame is cut into tiles or
// threads, and kernels/demosaic_mlri_*.comp reproduce it operation for operation (bit-equal;
// -ffp-contract=off, no reassociation). The CPU path runs tile by tile (512 output pixels wide,
// as tall as keeps about two tiles per thread, plus the 23-px margin); within a tile all stages'
// passes run as one wavefront over the rows, every intermediate plane a ring of a few rows
// (demosaic_mlri_body.inc), and the output rows are written with non-temporal stores.
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <tuple>
#include <type_traits>
#include <utility>
#include <vector>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "core/isa_detail.h"
#include "demosaic_detail.h"
#include "photosite/sensor/demosaic.h"

namespace photosite {
namespace {

constexpr int kRg = 4;       // green guided filters: 1-D window of 2 kRg + 1 along the direction
constexpr int kRb = 2;       // red/blue guided filters: (2 kRb + 1)^2 window
// Margins of the stages around an output tile (each stage needs the previous one this far out).
constexpr int kMGreen = 2 * kRb + 3;         // green, for the red/blue stage (1 + 2 kRb + Laplacian 2)
constexpr int kAcross = kMGreen + 1;          // directional differences across their direction
constexpr int kMDif = kMGreen + 4;            // ... along it (one-sided 5-tap means)
constexpr int kMQ = kMDif + 1;                // tentative estimates (residuals at +-1)
constexpr int kMAb = kMQ + kRg;               // coefficients (their box mean)
constexpr int kMLap = kMAb + kRg;             // Laplacian products (the window sums)
constexpr int kMGuide = kMLap + 2;            // guides (the step-2 Laplacian)
constexpr int kMargin = kMGuide + 1;          // = 23: the mosaic, and the support radius
constexpr float kTau = 1e-3f;

}  // namespace

namespace detail {
// The float constants of MLRI, computed once, shared with the Vulkan kernels (push constants):
//   gw[5]      one-sided Gaussian weights (sigma 3), gw[4] at the centre, sum 1
//   tau_n_g[2] tau / N and inv_n_g[2] 1 / N of the green filters' two site relations (1-D)
//   tau_n_b[4], inv_n_b[4] the same for the red/blue filters' four; inv_box_g = 1/9, inv_box_b = 1/25.
const MlriConstants& mlri_constants() {
  static const MlriConstants c = [] {
    MlriConstants k{};
    double s = 0, t[5];
    for (int j = 0; j < 5; ++j) s += t[j] = std::exp(-(4.0 - j) * (4.0 - j) / (2.0 * 3.0 * 3.0));
    for (int j = 0; j < 5; ++j) k.gw[j] = static_cast<float>(t[j] / s);
    // Relation k = kx | ky << 1 of a site class to the window centre: kx = 0 when the class's
    // columns have the centre's parity (ky the same for rows). N = the class's sites in a
    // (2r+1)^2 window: (offsets in [-r, r] of parity kx) x (of parity ky).
    auto count = [](int r, int par) {
      int n = 0;
      for (int d = -r; d <= r; ++d) n += (d & 1) == par;
      return n;
    };
    for (int rel = 0; rel < 4; ++rel) {
      const int nb = count(kRb, rel & 1) * count(kRb, rel >> 1);
      k.tau_n_b[rel] = kTau / static_cast<float>(nb);
      k.inv_n_b[rel] = 1.f / static_cast<float>(nb);
    }
    for (int rel = 0; rel < 2; ++rel) {  // the green filters' windows are 1-D
      const int ng = count(kRg, rel);
      k.tau_n_g[rel] = kTau / static_cast<float>(ng);
      k.inv_n_g[rel] = 1.f / static_cast<float>(ng);
    }
    k.inv_box_g = 1.f / static_cast<float>(2 * kRg + 1);
    k.inv_box_b = 1.f / static_cast<float>((2 * kRb + 1) * (2 * kRb + 1));
    return k;
  }();
  return c;
}
int mlri_support_radius() { return kMargin; }
MlriGeometry mlri_geometry() { return {kRg, kRb, kMLap, kMAb, kMQ, kMDif, kAcross, kMGreen, kMargin}; }
}  // namespace detail


namespace {

// The two builds of the body.
namespace mlri_base {
#include "demosaic_mlri_body.inc"
}  // namespace mlri_base
#if defined(__x86_64__) && defined(__GNUC__)
#pragma GCC push_options
#pragma GCC target("avx2")
namespace mlri_avx2 {
#include "demosaic_mlri_body.inc"
}  // namespace mlri_avx2
#pragma GCC pop_options
// 16 floats wide. The same IEEE operations as the other builds (no FMA, -ffp-contract=off; the
// division, max and compares are exact in every width), so the same bits.
#pragma GCC push_options
#pragma GCC target("avx512f,avx512vl,avx512bw,avx512dq,prefer-vector-width=512")
namespace mlri_avx512 {
#include "demosaic_mlri_body.inc"
}  // namespace mlri_avx512
#pragma GCC pop_options
#endif

}  // namespace

namespace detail {
ImageF demosaic_mlri_baseline(const ImageF& m, CfaPattern pattern) { return mlri_base::run(m, pattern); }
#if defined(__x86_64__) && defined(__GNUC__)
ImageF demosaic_mlri_avx2(const ImageF& m, CfaPattern pattern) { return mlri_avx2::run(m, pattern); }
ImageF demosaic_mlri_avx512(const ImageF& m, CfaPattern pattern) { return mlri_avx512::run(m, pattern); }
bool mlri_have_avx512() {
  return photosite::detail::have_avx512();  // F, VL, BW, DQ: the four its pragma names
}
#else
ImageF demosaic_mlri_avx2(const ImageF& m, CfaPattern pattern) { return mlri_base::run(m, pattern); }
ImageF demosaic_mlri_avx512(const ImageF& m, CfaPattern pattern) { return mlri_base::run(m, pattern); }
bool mlri_have_avx512() { return false; }
#endif
}  // namespace detail

// Most of MLRI's time is in unit-stride row loops of window sums, which AVX2 runs 8 floats wide
// and AVX-512 16.
ImageF demosaic_mlri(const ImageF& m, CfaPattern pattern) {
  static const int isa = detail::mlri_have_avx512() ? 2 : detail::lmmse_have_avx2() ? 1 : 0;
  return isa == 2   ? detail::demosaic_mlri_avx512(m, pattern)
         : isa == 1 ? detail::demosaic_mlri_avx2(m, pattern)
                    : detail::demosaic_mlri_baseline(m, pattern);
}

}  // namespace photosite
