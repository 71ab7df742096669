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

}  // namespace

ImageF demosaic_lmmse(const ImageF& m, CfaPattern pattern) {
  using detail::reflect;
  if (!detail::bayer_path_ok(m, pattern)) return detail::demosaic_bilinear_generic(m, pattern);
  const auto ph = detail::bayer_phase(pattern);
  const int w = m.width(), h = m.height();
  static const Gauss9 gauss;
  const float* gw = gauss.w;
  // Sign of Delta = G - X at a pixel: +1 where X is observed (R/B sites, whose column and row
  // parities relative to the red site agree: Delta = G_est - X), -1 at green sites
  // (Delta = G - X_est).
  auto fill_sign = [&](float* sg, int x0, int n, int y) {
    for (int i = 0; i < n; ++i) sg[i] = ((x0 + i - ph.ox) & 1) == ((y - ph.oy) & 1) ? 1.f : -1.f;
  };
  ImageF dv(w, h, 1, uninitialized), sv(w, h, 1, uninitialized), dplane(w, h, 1, uninitialized);

  // Vertical observations.
#pragma omp parallel
  {
    std::vector<float> sg0(w), sg1(w);  // sign rows for the two row parities
    fill_sign(sg0.data(), 0, w, ph.oy);
    fill_sign(sg1.data(), 0, w, ph.oy + 1);
#pragma omp for schedule(static)
    for (int y = 0; y < h; ++y) {
      const float* sg = ((y - ph.oy) & 1) ? sg1.data() : sg0.data();
      const float *a = m.row(reflect(y - 2, h)), *b = m.row(reflect(y - 1, h)), *c = m.row(y),
                  *d = m.row(reflect(y + 1, h)), *e = m.row(reflect(y + 2, h));
      float* o = dv.row(y);
      for (int x = 0; x < w; ++x)
        o[x] = sg[x] * (0.25f * (2.f * (b[x] + c[x] + d[x]) - a[x] - e[x]) - c[x]);
    }
  }
  // Their vertical low-pass.
#pragma omp parallel for schedule(static)
  for (int y = 0; y < h; ++y) {
    const float* r[2 * kHalf + 1];
    for (int k = -kHalf; k <= kHalf; ++k) r[k + kHalf] = dv.row(reflect(y + k, h));
    float* o = sv.row(y);
#pragma omp simd
    for (int x = 0; x < w; ++x) {
      float s = 0;
      for (int k = 0; k <= 2 * kHalf; ++k) s += gw[k] * r[k][x];
      o[x] = s;
    }
  }
  // Horizontal estimate (row-local, in a mirrored copy of the row), vertical estimate and
  // their fusion, computed at the R/B sites only (every other pixel of a row): D = G - X there,
  // zero at green sites.
  constexpr int P = 2 + 2 * kHalf;  // margin: observation filter + low-pass + window
  const int n = w + 2 * P;
#pragma omp parallel
  {
    std::vector<float> sg0(n), sg1(n), mp(n), zh(n), sh(n);
    fill_sign(sg0.data(), -P, n, ph.oy);
    fill_sign(sg1.data(), -P, n, ph.oy + 1);
#pragma omp for schedule(static)
    for (int y = 0; y < h; ++y) {
      const float* sg = ((y - ph.oy) & 1) ? sg1.data() : sg0.data();
      const float* mr = m.row(y);
      float* M = mp.data();
      std::copy(mr, mr + w, M + P);
      for (int i = 0; i < P; ++i) {
        M[P - 1 - i] = mr[reflect(-1 - i, w)];
        M[P + w + i] = mr[reflect(w + i, w)];
      }
      float* Z = zh.data();
      float* S = sh.data();
      for (int i = 2; i < n - 2; ++i)
        Z[i] = sg[i] * (0.25f * (2.f * (M[i - 1] + M[i] + M[i + 1]) - M[i - 2] - M[i + 2]) - M[i]);
      for (int i = 2 + kHalf; i < n - 2 - kHalf; ++i) {
        float s = 0;
        for (int k = -kHalf; k <= kHalf; ++k) s += gw[k + kHalf] * Z[i + k];
        S[i] = s;
      }
      const float* sr[2 * kHalf + 1];
      const float* zr[2 * kHalf + 1];
      for (int k = -kHalf; k <= kHalf; ++k) {
        sr[k + kHalf] = sv.row(reflect(y + k, h));
        zr[k + kHalf] = dv.row(reflect(y + k, h));
      }
      float* o = dplane.row(y);
      std::fill(o, o + w, 0.f);
      const int a = (ph.ox + y - ph.oy) & 1;  // column parity of this row's R/B sites
      const int nj = (w - a + 1) / 2;
#pragma omp simd
      for (int j = 0; j < nj; ++j) {
        const int x = a + 2 * j, i = x + P;
        float eh, ev;
        const float xh = lmmse_estimate(Z[i], [&](int k) { return S[i + k]; },
                                        [&](int k) { return Z[i + k]; }, eh);
        const float xv = lmmse_estimate(zr[kHalf][x], [&](int k) { return sr[k + kHalf][x]; },
                                        [&](int k) { return zr[k + kHalf][x]; }, ev);
        o[x] = (xh * ev + xv * eh) / (eh + ev);
      }
    }
  }
  ImageF out(w, h, 3, uninitialized, m.unit());
  const ImageF* planes[2] = {&m, &dplane};
  detail::run_stencil<2>(planes, ph, out, LmmseColour{}, ph.clear);
  return out;
}

}  // namespace photosite
