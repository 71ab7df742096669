// Directional LMMSE demosaicing.
// L. Zhang, X. Wu, "Color demosaicking via directional linear minimum mean square-error
// estimation", IEEE Transactions on Image Processing 14(12), 2005, pp. 2167-2178.
//
// The colour difference Delta = G - X (X = R or B) is smooth in natural images. Along a row, the
// 1-D filter [-1 2 2 2 -1]/4 of the CFA samples estimates the missing colour at every pixel
// (green at R/B sites, R/B at green sites), so each pixel gets a noisy horizontal observation
// of Delta; likewise along the column. Each observation is modelled as the true difference plus
// estimation noise. Over a 9-pixel window along the direction, the signal statistics come from
// a Gaussian low-pass (sigma 2, 9 taps) of the observations (mean mu, variance var_s) and the
// noise variance var_n from the residual observation - low-pass; the LMMSE estimate is
//     Delta_hat = mu + var_s / (var_s + var_n) * (observation - mu),
// with error variance var_s var_n / (var_s + var_n). The horizontal and vertical estimates are
// fused with weights inversely proportional to their errors (the direction across an edge has
// the large error), and green = X + Delta at R/B sites. Red and blue follow from the now dense
// differences: at B (R) sites from the four diagonal R (B) sites, at green sites from the four
// axial neighbours (Zhang-Wu Sec. IV).
//
// Implementation: float, every loop a unit-stride row loop (sign of Delta by pixel parity from a
// small row of +-1), the horizontal estimate computed per row in thread-local buffers, the
// vertical one from two planes (observations, low-pass) whose 9-row windows are read through
// mirrored row pointers. Then one stencil pass (demosaic_detail.h) writes R, G, B.
#include <algorithm>
#include <cmath>
#include <vector>

#include "core/isa_detail.h"
#include "demosaic_detail.h"
#include "photosite/sensor/demosaic.h"

namespace photosite {
namespace {

constexpr int kHalf = 4;  // Gaussian and statistics windows: 9 samples

struct Gauss9 {
  float w[2 * kHalf + 1];
  Gauss9() {
    double s = 0, t[2 * kHalf + 1];
    for (int k = -kHalf; k <= kHalf; ++k) s += t[k + kHalf] = std::exp(-k * k / 8.0);  // sigma 2
    for (int k = 0; k <= 2 * kHalf; ++k) w[k] = static_cast<float>(t[k] / s);
  }
};

// LMMSE estimate from the observation o at the window centre and the window's low-pass values
// s[-4..4] and observations z[-4..4] (both reached through index functors). Returns the
// estimate, writes the error variance.
template <class S, class Z>
inline float lmmse_estimate(float o, const S& s, const Z& z, float& err) {
  float mu = 0;
  for (int k = -kHalf; k <= kHalf; ++k) mu += s(k);
  mu *= 1.f / 9.f;
  float var_s = 1e-10f, var_n = 1e-10f;
  for (int k = -kHalf; k <= kHalf; ++k) {
    const float a = s(k) - mu, b = z(k) - s(k);
    var_s += a * a;
    var_n += b * b;
  }
  const float inv = 1.f / (var_s + var_n);
  err = var_s * var_n * inv;
  return mu + var_s * inv * (o - mu);
}

// Final pass: plane 0 the mosaic, plane 1 D = G - (own colour) (zero at green sites). Green is
// mosaic + D everywhere; the missing R/B are green minus the mean difference of the nearest
// sites of that colour.
struct LmmseColour {
  static constexpr int kOut = 3;
  template <int T, class F>
  void px(const F& f, const detail::PixelOut& o) const {
    using namespace detail;
    const float c = f(0, 0, 0), d0 = f(1, 0, 0), g = c + d0;
    auto diag = [&](int dx, int dy) {  // mean D over the diagonal neighbours of (dx, dy)
      return 0.25f * ((f(1, dx - 1, dy - 1) + f(1, dx + 1, dy - 1)) +
                      (f(1, dx - 1, dy + 1) + f(1, dx + 1, dy + 1)));
    };
    if constexpr (T == kR || T == kB) {
      const float other = g - diag(0, 0);
      o[0] = T == kR ? c : other;
      o[1] = g;
      o[2] = T == kR ? other : c;
    } else {
      // Left/right neighbours hold D of one colour and (through their diagonals) the other
      // colour's D; likewise up/down with the roles swapped.
      const float dh_own = f(1, -1, 0) + f(1, 1, 0), dv_own = f(1, 0, -1) + f(1, 0, 1);
      const float dh_x = diag(-1, 0) + diag(1, 0), dv_x = diag(0, -1) + diag(0, 1);
      const float horiz = g - 0.25f * (dh_own + dv_x);  // colour of the left/right sites
      const float vert = g - 0.25f * (dv_own + dh_x);   // colour of the up/down sites
      o[0] = T == kGr ? horiz : vert;
      o[1] = g;
      o[2] = T == kGr ? vert : horiz;
    }
  }
};

const Gauss9& gauss9() {
  static const Gauss9 g;
  return g;
}

}  // namespace

namespace detail {
#define LMMSE_ATTR
#define LMMSE_NAME demosaic_lmmse_baseline
#include "demosaic_lmmse_body.inc"
#undef LMMSE_ATTR
#undef LMMSE_NAME
#if defined(__x86_64__) && defined(__GNUC__)
#define LMMSE_ATTR __attribute__((target("avx2")))
#define LMMSE_NAME demosaic_lmmse_avx2
#include "demosaic_lmmse_body.inc"
#undef LMMSE_ATTR
#undef LMMSE_NAME
bool lmmse_have_avx2() { return photosite::detail::have_avx2(); }
#else
ImageF demosaic_lmmse_avx2(const ImageF& m, CfaPattern pattern) { return demosaic_lmmse_baseline(m, pattern); }
bool lmmse_have_avx2() { return false; }
#endif
void lmmse_gauss_weights(float out[9]) {
  for (int k = 0; k <= 2 * kHalf; ++k) out[k] = gauss9().w[k];
}
}  // namespace detail

// Most of LMMSE's time is in its row loops of 9-tap windows, which AVX2 runs 8 floats wide
// (measured 1.7x faster than the SSE2 baseline on the development VM, docs/demosaic.md).
ImageF demosaic_lmmse(const ImageF& m, CfaPattern pattern) {
  static const bool avx2 = detail::lmmse_have_avx2();
  return avx2 ? detail::demosaic_lmmse_avx2(m, pattern) : detail::demosaic_lmmse_baseline(m, pattern);
}

}  // namespace photosite
