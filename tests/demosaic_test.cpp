// Demosaicing family: exactness on smooth and flat fields for every method and pattern, phase
// consistency, Kodak CPSNR floors, and the `photosite demosaic` command.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "core/isa_detail.h"
#include "photosite/error.h"
#include "photosite/io.h"
#include "photosite/rng.h"
#include "photosite/sensor/demosaic.h"
#include "sensor/demosaic_detail.h"
#include "test_util.h"

namespace photosite {
namespace {

// A smooth colour field: slow sinusoids, different per channel (periods of 150-250 px).
ImageF smooth_field(int w, int h, bool grey_gb = false) {
  ImageF rgb(w, h, 3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      rgb.at(x, y, 0) = 0.40f + 0.15f * std::sin(x / 35.0f + 0.3f) * std::cos(y / 28.0f);
      rgb.at(x, y, 1) = 0.50f + 0.20f * std::cos(x / 40.0f - y / 33.0f);
      rgb.at(x, y, 2) = grey_gb ? rgb.at(x, y, 1) : 0.30f + 0.10f * std::sin((x + y) / 30.0f);
    }
  return rgb;
}

// The RGB the pattern can represent: RCCC sees red and R+G+B only, so G = B = (C - R) / 2.
ImageF representable(const ImageF& rgb, CfaPattern p) {
  ImageF e = rgb;
  for (size_t i = 0; i < e.pixel_count(); ++i) {
    if (p == CfaPattern::RCCC) e[3 * i + 1] = e[3 * i + 2] = 0.5f * (e[3 * i + 1] + e[3 * i + 2]);
    if (p == CfaPattern::Mono) e[3 * i] = e[3 * i + 1] = e[3 * i + 2] = (e[3 * i] + e[3 * i + 1] + e[3 * i + 2]) / 3;
  }
  return e;
}

const CfaPattern kColourPatterns[] = {CfaPattern::RGGB, CfaPattern::BGGR, CfaPattern::GRBG,
                                      CfaPattern::GBRG, CfaPattern::RCCB, CfaPattern::RCCC};

// The interpolation error bound of a linear method (bilinear, Malvar) on smooth_field's interior:
// each output is Σ_q W(p, q)·m(q), m(q) = f_col(q)(q), with weights that reproduce every affine
// field (per input colour they sum to 1 for the output's own colour, 0 for the others, with zero
// first moments: symmetric stencils), so by Taylor's theorem |out − f(p)| ≤ ½·Σ_q |W(p, q)|·|q −
// p|²·H_col(q), H_k the largest second directional derivative of colour k's field (a sinusoid of
// amplitude A and wave vector k: A·|k|²; a product sin(ax)·cos(by): at most A·(a² + b²); the clear
// colour the sum of the three). W is read off the method's response to a unit sample at each of
// the four CFA phases (translation by two pixels leaves the method unchanged), grouped by the
// output pixel's phase; the bound is the largest over phases and channels. Computed from the
// method's own weights, it holds for any linear method that reproduces affine fields: what it
// catches is one that does not (Malvar's G at R from l twice instead of l + r: 2.6e-3 against
// 6.9e-4), or a method that is not linear.
double smooth_field_linear_bound(CfaPattern p, DemosaicMethod m) {
  const double h_r = 0.15 * (1 / (35.0 * 35.0) + 1 / (28.0 * 28.0)), h_g = 0.20 * (1 / (40.0 * 40.0) + 1 / (33.0 * 33.0)),
               h_b = 0.10 * (2 / (30.0 * 30.0));
  auto hessian = [&](FilterColor c) {
    switch (c) {
      case FilterColor::R: return h_r;
      case FilterColor::G: return h_g;
      case FilterColor::B: return h_b;
      default: return h_r + h_g + h_b;  // C = R + G + B
    }
  };
  const int n = 33, q0 = 16, reach = 6;  // the stencils reach 2 px (3 with RCCB's colour difference)
  double s[2][2][3] = {};
  for (int dy = 0; dy < 2; ++dy)
    for (int dx = 0; dx < 2; ++dx) {
      ImageF mos(n, n, 1, 0.f);
      const int qx = q0 + dx, qy = q0 + dy;
      mos.at(qx, qy) = 1.f;
      const ImageF out = demosaic(mos, p, m);
      const double hq = hessian(cfa_color(p, qx, qy));
      for (int y = qy - reach; y <= qy + reach; ++y)
        for (int x = qx - reach; x <= qx + reach; ++x)
          for (int c = 0; c < 3; ++c)
            s[y & 1][x & 1][c] += std::fabs(out.at(x, y, c)) * ((x - qx) * (x - qx) + (y - qy) * (y - qy)) * hq;
    }
  double worst = 0;
  for (auto& row : s)
    for (auto& px : row)
      for (double v : px) worst = std::max(worst, 0.5 * v);
  return worst;
}

TEST(Demosaic, EveryMethodRecoversASmoothColourFieldOnEveryPattern) {
  for (auto p : kColourPatterns)
    for (auto m : all_demosaic_methods()) {
      // odd sizes: the last row and column end mid-cell
      const ImageF truth = representable(smooth_field(97, 63), p);
      const ImageF mos = mosaic(truth, p);
      const double max_x = *std::max_element(mos.vec().begin(), mos.vec().end());
      const ImageF out = demosaic(mos, p, m);
      ASSERT_EQ(out.channels(), 3);
      double se = 0, worst_inner = 0, worst = 0;
      for (int y = 0; y < out.height(); ++y)
        for (int x = 0; x < out.width(); ++x)
          for (int c = 0; c < 3; ++c) {
            const double d = std::fabs(out.at(x, y, c) - truth.at(x, y, c));
            se += d * d;
            worst = std::max(worst, d);
            if (x >= 3 && y >= 3 && x < out.width() - 3 && y < out.height() - 3) worst_inner = std::max(worst_inner, d);
          }
      const double rms = std::sqrt(se / out.size());
      // The linear methods: the interior within their Taylor bound (smooth_field_linear_bound),
      // plus the flat-area rounding bound of AllMethodsRecoverFlatAreasToRounding (48 u of the
      // largest mosaic sample; (3·48 + 3.5) u with RCCB's clear).
      if (m == DemosaicMethod::Bilinear || m == DemosaicMethod::Malvar) {
        const double rounding = (p == CfaPattern::RCCB ? 3 * 48 + 3.5 : 48.0) * 0x1p-24 * max_x;
        EXPECT_LE(worst_inner, smooth_field_linear_bound(p, m) + rounding) << to_string(m) << " on " << to_string(p);
      }
      // Not derived (the edge-directed methods are not linear, and the mirrored border breaks the
      // affine reproduction): measured figures. A field of amplitude 0.1-0.2 recovered to about
      // 1/1000 of full scale; the mirrored border bends the field's slope, still within 1/100.
      // RCCB's G = C - R - B subtracts three interpolated values (C carries the sum of all three
      // channels' variation), which doubles the error: its limits are twice as wide.
      const double k = p == CfaPattern::RCCB ? 2.0 : 1.0;
      EXPECT_LT(rms, 1e-3 * k) << to_string(m) << " on " << to_string(p);
      EXPECT_LT(worst_inner, 2e-3 * k) << to_string(m) << " on " << to_string(p);
      EXPECT_LT(worst, 1.5e-2 * k) << to_string(m) << " on " << to_string(p);
    }
}

// RCCB's clear samples enter every method but bilinear at green's level
// (kernels/common/clear_level.glsl): the result is, bit for bit, the RGGB method's on the mosaic
// with every clear sample times 1/3 (kClearToGreen, written out), its green taken back as
// G = (C_hat - R) - B, C_hat the clear sample at its own site and 3 G_hat (kGreenToClear)
// elsewhere. Bilinear reads C as it is (G = (C - R) - B). A mosaic of independent samples
// (detail at every scale), odd size.
TEST(Demosaic, RccbFeedsTheClearSamplesAtGreensLevel) {
  const int w = 61, h = 37;
  ImageF m(w, h, 1);
  for (size_t i = 0; i < m.size(); ++i)
    m[i] = static_cast<float>(1000.0 * uniform_open(random_words(17, 0, i, Stream::Test)[0]));
  for (auto method : all_demosaic_methods()) {
    const bool bilinear = method == DemosaicMethod::Bilinear;
    ImageF as_green = m;
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        if (cfa_color(CfaPattern::RCCB, x, y) == FilterColor::C && !bilinear) as_green.at(x, y) *= 1.f / 3.f;
    ImageF want = demosaic(as_green, CfaPattern::RGGB, method);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const bool clear = cfa_color(CfaPattern::RCCB, x, y) == FilterColor::C;
        // C_hat: the clear sample itself at its site, 3 G_hat elsewhere (bilinear: G_hat is C)
        const float c = clear ? m.at(x, y) : bilinear ? want.at(x, y, 1) : 3.f * want.at(x, y, 1);
        want.at(x, y, 1) = (c - want.at(x, y, 0)) - want.at(x, y, 2);
      }
    const ImageF got = demosaic(m, CfaPattern::RCCB, method);
    ASSERT_EQ(got.size(), want.size());
    EXPECT_EQ(std::memcmp(got.data(), want.data(), got.size() * sizeof(float)), 0) << to_string(method);
  }
}

// The reason for the above (docs/demosaic.md, "RCCB"): on an image whose colour differences are
// constant (R = t + 0.15, G = t + 0.05, B = t, t a common texture: the premise of
// Hamilton-Adams's, LMMSE's and MLRI's G - X and of Malvar's equal-Laplacian gains) those methods
// carry the texture only through the difference between the green plane they are given and R or
// B, where bilinear interpolates the texture itself in every plane. With the clear samples
// scaled by s, that difference is s C - X = (3s - 1) t + constant, and G = C_hat - R - B
// multiplies its error by 1/s: |3 - 1/s| times the texture's interpolation error. s = 1 (C read
// as green, before) puts twice the texture into it, which is about twice bilinear's error
// (measured with the scaling taken out: malvar 2.53, hamilton-adams 2.55, lmmse 5.94, mlri 1.37
// times bilinear's RMS error); s = 1/3 leaves none, and only each method's own error on a
// constant-difference image remains (measured 0.67, 0.92, 0.0003, 0.13). The bound, bilinear's
// RMS error, lies between the two. The texture: oblique sinusoids of periods 9 and 13 px and a
// disc's soft edge; a border of MLRI's support radius is left out.
TEST(Demosaic, RccbEdgeDirectedMethodsBeatBilinearOnACommonTexture) {
  const int w = 160, h = 120;
  ImageF rgb(w, h, 3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const double r2 = (x - 80.0) * (x - 80.0) + (y - 60.0) * (y - 60.0);
      const double t = 0.3 + 0.1 * std::sin(2 * M_PI * (0.8 * x + 0.6 * y) / 9.0) +
                       0.08 * std::cos(2 * M_PI * (0.6 * x - 0.8 * y) / 13.0) + 0.15 / (1 + std::exp((std::sqrt(r2) - 35.0) / 1.5));
      rgb.at(x, y, 0) = static_cast<float>(t + 0.15);
      rgb.at(x, y, 1) = static_cast<float>(t + 0.05);
      rgb.at(x, y, 2) = static_cast<float>(t);
    }
  const ImageF m = mosaic(rgb, CfaPattern::RCCB);
  const int e = detail::mlri_support_radius();
  auto rms = [&](DemosaicMethod method) {
    const ImageF out = demosaic(m, CfaPattern::RCCB, method);
    double se = 0;
    size_t n = 0;
    for (int y = e; y < h - e; ++y)
      for (int x = e; x < w - e; ++x)
        for (int c = 0; c < 3; ++c, ++n) se += std::pow(double(out.at(x, y, c)) - rgb.at(x, y, c), 2);
    return std::sqrt(se / double(n));
  };
  const double bilinear = rms(DemosaicMethod::Bilinear);
  for (auto method : {DemosaicMethod::Malvar, DemosaicMethod::HamiltonAdams, DemosaicMethod::Lmmse, DemosaicMethod::Mlri}) {
    const double r = rms(method);
    std::printf("RCCB %s: RMS error %.3g, bilinear %.3g (ratio %.3f)\n", to_string(method), r, bilinear, r / bilinear);
    EXPECT_LT(r, bilinear) << to_string(method);
  }
}

// Malvar-He-Cutler is its paper's eight 5x5 filters (Malvar, He, Cutler, ICASSP 2004, Fig. 2, in
// units of 1/8), evaluated here in double on a random RGGB mosaic at every interior pixel. The
// smooth-field and flat-area tests cannot tell a wrong tap from a right one where the field has no
// curvature (a filter's vertical and horizontal ±2 taps see the same values there): a mutation
// that made the green pixels' filter read the horizontal ±2 taps for the vertical ones survived
// them (docs/testing.md). Tolerance: the code's float evaluation takes at most 16 roundings, each
// of an intermediate no larger than 8·Σ|w|·max|v| = 20 (Σ|w| ≤ 20/8, values in [0, 1)) before the
// exact ×1/8: |error| ≤ 16·2⁻²⁴·2.5.
TEST(Demosaic, MalvarIsThePapersFiltersOnARandomMosaic) {
  const int w = 40, h = 30;
  ImageF m(w, h, 1);
  uint64_t state = 0x9e3779b97f4a7c15ull;
  for (size_t i = 0; i < m.size(); ++i) {  // splitmix64 in [0, 1)
    uint64_t z = (state += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    m[i] = static_cast<float>((z ^ (z >> 31)) >> 40) * 0x1p-24f;
  }
  const ImageF out = demosaic_malvar(m, CfaPattern::RGGB);
  const double tol = 16 * 0x1p-24 * 2.5;
  int checked = 0;
  for (int y = 2; y < h - 2; ++y)
    for (int x = 2; x < w - 2; ++x) {
      auto v = [&](int dx, int dy) { return static_cast<double>(m.at(x + dx, y + dy, 0)); };
      const double c = v(0, 0), cross = v(-1, 0) + v(1, 0) + v(0, -1) + v(0, 1);
      const double h1 = v(-1, 0) + v(1, 0), v1 = v(0, -1) + v(0, 1);
      const double h2 = v(-2, 0) + v(2, 0), v2 = v(0, -2) + v(0, 2);
      const double diag = v(-1, -1) + v(1, -1) + v(-1, 1) + v(1, 1);
      double want[3];
      const bool even_x = x % 2 == 0, even_y = y % 2 == 0;
      if (even_x == even_y) {  // R (even, even) or B (odd, odd)
        const double g = (4 * c + 2 * cross - (h2 + v2)) / 8;            // G at R and B
        const double other = (6 * c + 2 * diag - 1.5 * (h2 + v2)) / 8;   // B at R, R at B
        want[0] = even_x ? c : other;
        want[1] = g;
        want[2] = even_x ? other : c;
      } else {  // G in an R row (odd x, even y) or in a B row (even x, odd y)
        const double row = (5 * c + 4 * h1 - h2 - diag + 0.5 * v2) / 8;  // the row's colour
        const double col = (5 * c + 4 * v1 - v2 - diag + 0.5 * h2) / 8;  // the column's colour
        want[0] = even_y ? row : col;
        want[1] = c;
        want[2] = even_y ? col : row;
      }
      for (int k = 0; k < 3; ++k) EXPECT_NEAR(out.at(x, y, k), want[k], tol) << x << "," << y << " channel " << k;
      ++checked;
    }
  EXPECT_EQ(checked, (w - 4) * (h - 4));
}

// Flat areas come back to float rounding (not exactly: Malvar's and LMMSE's weighted sums round).
// Every method forms each output in at most two passes of weighted sums of mosaic samples whose
// weights sum to 1, at most 13 taps and Σ|w| ≤ 2 (Malvar's 5×5 filters, the widest with negative
// taps; LMMSE and MLRI combine such estimates with weights summing to 1). A sum of 13 terms errs
// by at most 12·u·Σ|w_i x_i| (u = 2⁻²⁴, the recursive summation bound), so two passes by
// 2·12·u·2·max x, max x the largest mosaic sample. RCCB's green is G = (C_hat − R̂) − B̂ with
// C_hat = 3·Ĝ, Ĝ interpolated from the clear samples times 1/3 (kernels/common/clear_level.glsl):
// three interpolated terms, each within that bound (Ĝ's on values up to max x/3, times 3), plus
// the 1/3 product's and the 3·Ĝ product's roundings (0.5 + 1 u of max x) and the two
// subtractions' (2 u): (3·48 + 3.5)·u·max x.
TEST(Demosaic, AllMethodsRecoverFlatAreasToRoundingIncludingBorders) {
  for (auto p : kColourPatterns)
    for (auto m : all_demosaic_methods()) {
      ImageF rgb(23, 14, 3);
      for (size_t i = 0; i < rgb.pixel_count(); ++i) rgb[3 * i] = 0.2f, rgb[3 * i + 1] = 0.5f, rgb[3 * i + 2] = 0.7f;
      const ImageF truth = representable(rgb, p);
      const ImageF mos = mosaic(truth, p);
      const double max_x = *std::max_element(mos.vec().begin(), mos.vec().end());
      const double tol = (p == CfaPattern::RCCB ? 3 * 48 + 3.5 : 48.0) * 0x1p-24 * max_x;
      const ImageF out = demosaic(mos, p, m);
      for (size_t i = 0; i < out.size(); ++i)
        ASSERT_NEAR(out[i], truth[i], tol) << to_string(m) << " on " << to_string(p) << " at sample " << i;
    }
}

TEST(Demosaic, BordersAreNeitherBlackNorWrappedAround) {
  // A left-to-right ramp: wrap-around would bring the bright right edge into the left column
  // (0.78 off), a black border would be 0.1 off. The limit: one pixel's step of the ramp, what
  // the mirrored border costs a two-tap average (bilinear: the mirror puts x = 1's value in
  // place of x = −1's, (v(1) + v(1))/2 = v(0) + step), plus float rounding (16 u of values < 1).
  const float step = 0.02f;
  ImageF rgb(40, 30, 3);
  for (int y = 0; y < 30; ++y)
    for (int x = 0; x < 40; ++x)
      for (int c = 0; c < 3; ++c) rgb.at(x, y, c) = 0.1f + step * x;
  const double tol = step + 16 * 0x1p-24;
  for (auto m : all_demosaic_methods()) {
    const ImageF out = demosaic(mosaic(rgb, CfaPattern::GRBG), CfaPattern::GRBG, m);
    for (int y = 0; y < 30; ++y)
      for (int c = 0; c < 3; ++c) {
        EXPECT_NEAR(out.at(0, y, c), 0.1f, tol) << to_string(m);
        EXPECT_NEAR(out.at(39, y, c), 0.1f + step * 39, tol) << to_string(m);
      }
  }
}

TEST(Demosaic, EveryBayerPhaseGivesTheSameInterior) {
  // Shifting the image by one pixel turns RGGB into GRBG (x), GBRG (y) or BGGR (both): the
  // methods must give the same result away from the borders, bit for bit (each output sample is
  // the same operations on the same samples in the same order, whatever the phase).
  const ImageF base = smooth_field(80, 60);
  ImageF tex = base;  // add fine detail so the edge-directed paths are exercised
  for (int y = 0; y < 60; ++y)
    for (int x = 0; x < 80; ++x)
      for (int c = 0; c < 3; ++c) tex.at(x, y, c) += 0.2f * (((x * 7 + y * 3 + c) % 5) == 0);
  struct Shift { CfaPattern p; int dx, dy; };
  for (auto m : all_demosaic_methods()) {
    const ImageF ref = demosaic(mosaic(tex, CfaPattern::RGGB), CfaPattern::RGGB, m);
    for (Shift s : {Shift{CfaPattern::GRBG, 1, 0}, Shift{CfaPattern::GBRG, 0, 1}, Shift{CfaPattern::BGGR, 1, 1}}) {
      ImageF sub(80 - s.dx, 60 - s.dy, 3);
      for (int y = 0; y < sub.height(); ++y)
        for (int x = 0; x < sub.width(); ++x)
          for (int c = 0; c < 3; ++c) sub.at(x, y, c) = tex.at(x + s.dx, y + s.dy, c);
      const ImageF out = demosaic(mosaic(sub, s.p), s.p, m);
      // Away from the borders by the method's support radius (how far a mirrored sample
      // reaches): 14 px covers the one-pass and two-pass methods and LMMSE; MLRI's is larger.
      const int e = m == DemosaicMethod::Mlri ? detail::mlri_support_radius() : 14;
      for (int y = e; y < sub.height() - e; ++y)
        for (int x = e; x < sub.width() - e; ++x)
          for (int c = 0; c < 3; ++c)
            ASSERT_EQ(out.at(x, y, c), ref.at(x + s.dx, y + s.dy, c))
                << to_string(m) << " " << to_string(s.p) << " at " << x << "," << y;
    }
  }
}

// interleave_rgb (the planar-to-RGB step of every stencil method): AVX-512 blocks of 16 or AVX2
// blocks of 8 (at every level the CPU has, detail::interleave_rgb_max_isa; from 64 pixels on,
// non-temporal stores after a scalar run up to the first 64- or 32-byte boundary of the
// output), SSE blocks of 4 and the scalar tail give exactly r0 g0 b0 r1 ..., at every length
// and misalignment of the planes and of the output (every float offset within 64 bytes).
TEST(Demosaic, InterleaveRgbIsExactAtEveryLengthAndOffset) {
  std::vector<float> planes(3 * 128);
  for (size_t i = 0; i < planes.size(); ++i) planes[i] = static_cast<float>(i) + 0.25f;
  struct UncapOnExit {
    ~UncapOnExit() { detail::interleave_rgb_max_isa(2); }
  } uncap;
  for (int isa = 0; isa <= detail::machine_isa_level(); ++isa)
    for (int off = 0; off < 3; ++off)
      for (int out_off = 1; out_off <= 17; ++out_off)
        for (int n = 0; n <= 100; ++n) {
          const float *r = planes.data() + off, *g = r + 128, *b = g + 128;
          std::vector<float> out(3 * n + 20, -1.f);
          detail::interleave_rgb_max_isa(isa);
          interleave_rgb(r, g, b, out.data() + out_off, n);
          EXPECT_EQ(out[out_off - 1], -1.f) << n;
          EXPECT_EQ(out[3 * n + out_off], -1.f) << n;  // nothing written past the end
          for (int x = 0; x < n; ++x) {
            const std::string at = "n " + std::to_string(n) + " x " + std::to_string(x) + " output offset " +
                                   std::to_string(out_off) + " isa " + std::to_string(isa);
            ASSERT_EQ(out[out_off + 3 * x], r[x]) << at;
            ASSERT_EQ(out[out_off + 1 + 3 * x], g[x]) << at;
            ASSERT_EQ(out[out_off + 2 + 3 * x], b[x]) << at;
          }
        }
}

TEST(Demosaic, LmmseAvx2AndBaselineBuildsAreBitIdentical) {
  // The run-time ISA choice must not change a result (determinism across machines).
  if (!detail::lmmse_have_avx2()) {
    std::fprintf(stderr, "\n*** LmmseAvx2AndBaselineBuildsAreBitIdentical: this CPU has no AVX2; only the "
                         "baseline build runs here ***\n\n");
    GTEST_SKIP() << "no AVX2 on this CPU";
  }
  for (CfaPattern p : {CfaPattern::RGGB, CfaPattern::GBRG, CfaPattern::RCCB}) {
    ImageF m(203, 77, 1);
    for (int y = 0; y < m.height(); ++y)
      for (int x = 0; x < m.width(); ++x)
        m.at(x, y) = static_cast<float>(0.5 + 0.4 * std::sin(0.37 * x + 0.11 * y * y) * std::cos(0.05 * x * y));
    const ImageF a = detail::demosaic_lmmse_baseline(m, p), b = detail::demosaic_lmmse_avx2(m, p);
    ASSERT_EQ(a.size(), b.size());
    size_t diff = 0;
    for (size_t i = 0; i < a.size(); ++i) diff += std::memcmp(&a[i], &b[i], sizeof(float)) != 0;
    EXPECT_EQ(diff, 0u) << to_string(p);
  }
}

TEST(Demosaic, NamesParseAndUnknownNamesAreBadInput) {
  for (auto m : all_demosaic_methods()) EXPECT_EQ(parse_demosaic_method(to_string(m)), m);
  EXPECT_EQ(parse_demosaic_method("MHC"), DemosaicMethod::Malvar);
  EXPECT_EQ(parse_demosaic_method("ha"), DemosaicMethod::HamiltonAdams);
  try {
    parse_demosaic_method("vng");
    FAIL() << "no exception";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), Error::Kind::BadInput);
    EXPECT_NE(std::string(e.what()).find("lmmse"), std::string::npos);
  }
}

// Mean squared error (8-bit scale, 10-px border) of a demosaiced image (float [0, 1], rounded to
// 8-bit codes) against the original.
double mse_8bit(const ImageF& rgb, const ImageF& out) {
  double se = 0;
  size_t n = 0;
  for (int y = 10; y < rgb.height() - 10; ++y)
    for (int x = 10; x < rgb.width() - 10; ++x)
      for (int c = 0; c < 3; ++c) {
        const double v = std::nearbyint(std::clamp(out.at(x, y, c), 0.f, 1.f) * 255.f);
        const double d = v - 255.0 * rgb.at(x, y, c);
        se += d * d;
        ++n;
      }
  return se / n;
}
double cpsnr(double mse) { return 10 * std::log10(255.0 * 255.0 / mse); }

// OpenCV's demosaicing of the same mosaic quantized to 8 bits (OpenCV calls RGGB "BayerBG").
ImageF opencv_demosaic(const ImageF& mos, int code, bool vng) {
  const int w = mos.width(), h = mos.height();
  cv::Mat raw(h, w, CV_8U), o;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) raw.at<uint8_t>(y, x) = static_cast<uint8_t>(std::nearbyint(std::clamp(mos.at(x, y), 0.f, 1.f) * 255.f));
  cv::demosaicing(raw, o, code);
  if (vng) {  // OpenCV 4.6's VNG writes row y + 2 into row y (bench/cmd/bench_demosaic.cpp): shift it back
    cv::Mat shifted = o.clone();
    o.rowRange(0, o.rows - 2).copyTo(shifted.rowRange(2, o.rows));
    o.row(0).copyTo(shifted.row(0));
    o.row(0).copyTo(shifted.row(1));
    o = shifted;
  }
  ImageF out(w, h, 3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < 3; ++c) out.at(x, y, c) = o.at<cv::Vec3b>(y, x)[c] / 255.f;
  return out;
}

// Kodak (kodim 1, 8, 19: detailed, the hardest for demosaicing) against peers run in the same
// process, not against floors under earlier results:
// * bilinear is OpenCV's bilinear (the same formula); OpenCV reads the mosaic rounded to 8 bits.
//   That input error is at most ½ code and bilinear weights are positive and sum to 1, so before
//   the output rounding the two differ by at most ½ code, and after it (round or truncate) by at
//   most 1 code at every pixel.
// * Malvar-He-Cutler beats bilinear (its gradient correction; Malvar et al., ICASSP 2004), and
//   Hamilton-Adams and LMMSE beat OpenCV's VNG, as docs/demosaic.md states for every Kodak image.
TEST(Demosaic, KodakCpsnrAgainstPeersInTheSameRun) {
  PHOTOSITE_REQUIRE_SHARED("data/kodak24");
  const auto dir = test::shared_dir() / "data/kodak24";
  for (const char* file : {"kodim01.png", "kodim08.png", "kodim19.png"}) {
    const ImageF rgb = read_image((dir / file).string());
    const ImageF mos = mosaic(rgb, CfaPattern::RGGB);
    auto ours = [&](DemosaicMethod m) { return mse_8bit(rgb, demosaic(mos, CfaPattern::RGGB, m)); };
    const double bil = ours(DemosaicMethod::Bilinear), malvar = ours(DemosaicMethod::Malvar),
                 ha = ours(DemosaicMethod::HamiltonAdams), lmmse = ours(DemosaicMethod::Lmmse);
    const ImageF cv_bil_img = opencv_demosaic(mos, cv::COLOR_BayerBG2RGB, false);
    const ImageF bil_img = demosaic(mos, CfaPattern::RGGB, DemosaicMethod::Bilinear);
    double worst = 0;
    for (int y = 10; y < rgb.height() - 10; ++y)
      for (int x = 10; x < rgb.width() - 10; ++x)
        for (int c = 0; c < 3; ++c)
          worst = std::max(worst, std::fabs(std::nearbyint(std::clamp(bil_img.at(x, y, c), 0.f, 1.f) * 255.f) -
                                            std::nearbyint(255.0 * cv_bil_img.at(x, y, c))));
    EXPECT_LE(worst, 1.0) << file;
    const double cv_bil = mse_8bit(rgb, cv_bil_img);
    const double cv_vng = mse_8bit(rgb, opencv_demosaic(mos, cv::COLOR_BayerBG2RGB_VNG, true));
    std::printf("%s CPSNR dB: bilinear %.3f (OpenCV %.3f), malvar %.3f, hamilton-adams %.3f, lmmse %.3f, OpenCV VNG %.3f\n",
                file, cpsnr(bil), cpsnr(cv_bil), cpsnr(malvar), cpsnr(ha), cpsnr(lmmse), cpsnr(cv_vng));
    EXPECT_LT(malvar, bil) << file;
    EXPECT_LT(ha, cv_vng) << file;
    EXPECT_LT(lmmse, cv_vng) << file;
  }
}

// A clipped disc in an RCCB and an RCCC mosaic: every pixel whose 3x3 window holds a clipped
// sample is the neutral value exactly, every other pixel keeps the method's bits; a Bayer mosaic
// and a mosaic with no sample at the clip level are not touched (0 pixels).
TEST(Demosaic, ClippedClearSamplesGiveNeutralInTheirWindowOnly) {
  const int w = 40, h = 30;
  const float clip = 4000.f, neutral = clip / 3;
  for (CfaPattern p : {CfaPattern::RCCB, CfaPattern::RCCC, CfaPattern::RGGB}) {
    ImageF field = smooth_field(w, h);
    for (float& v : field.vec()) v *= 1000.f;
    ImageF m = mosaic(field, p);
    std::vector<uint8_t> clipped(m.size(), 0);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        if ((x - 12) * (x - 12) + (y - 9) * (y - 9) <= 25 || (x == 0 && y == h - 1)) {  // a disc and a corner
          m.at(x, y, 0) = clip;
          clipped[static_cast<size_t>(y) * w + x] = 1;
        }
    for (DemosaicMethod method : all_demosaic_methods()) {
      const ImageF before = demosaic(m, p, method);
      ImageF rgb = before;
      EXPECT_EQ(neutralize_clipped_highlights(rgb, m, p, clip + 1, neutral), 0u);  // nothing at the level
      EXPECT_EQ(rgb.vec(), before.vec());
      const size_t n = neutralize_clipped_highlights(rgb, m, p, clip, neutral);
      size_t want = 0;
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
          bool near = false;
          for (int dy = -1; dy <= 1; ++dy)
            for (int dx = -1; dx <= 1; ++dx) {
              const int xx = x + dx, yy = y + dy;
              near = near || (xx >= 0 && xx < w && yy >= 0 && yy < h && clipped[static_cast<size_t>(yy) * w + xx]);
            }
          near = near && p != CfaPattern::RGGB;
          want += near;
          for (int c = 0; c < 3; ++c)
            ASSERT_EQ(rgb.at(x, y, c), near ? neutral : before.at(x, y, c))
                << to_string(p) << " " << to_string(method) << " " << x << "," << y << " channel " << c;
        }
      EXPECT_EQ(n, want) << to_string(p);
      if (p == CfaPattern::RGGB) continue;
      // The old output at the disc's centre: not neutral (RCCB's G about -C, RCCC's G = B = 0).
      EXPECT_GT(std::abs(before.at(12, 9, 1) - before.at(12, 9, 0)), 0.5f * neutral) << to_string(p);
    }
  }
}

TEST(DemosaicCli, RoundTripMatchesTheLibraryAndListsMethods) {
  test::TempDir dir;
  const ImageF rgb = smooth_field(64, 48);
  ImageF mos = mosaic(rgb, CfaPattern::GRBG);
  write_png(dir.file("m.png"), mos, 16);
  const ImageF read_back = read_image(dir.file("m.png"));
  for (auto m : all_demosaic_methods()) {
    const std::string out = dir.file(std::string("o_") + to_string(m) + ".exr");
    auto r = test::run_cli("demosaic --in '" + dir.file("m.png") + "' --cfa grbg --method " + to_string(m) +
                           " --out '" + out + "'");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    const ImageF want = demosaic(read_back, CfaPattern::GRBG, m);
    const ExrContents got = read_exr(out);
    ASSERT_EQ(got.width, 64);
    const char* names[3] = {"R", "G", "B"};
    for (int c = 0; c < 3; ++c) {
      const ImageF& ch = got.channels.at(names[c]);
      for (int y = 0; y < 48; ++y)
        for (int x = 0; x < 64; ++x) ASSERT_EQ(ch.at(x, y), want.at(x, y, c)) << to_string(m);
    }
  }
  // PNG out keeps the 16-bit scale of a 16-bit PNG in.
  auto r = test::run_cli("demosaic --in '" + dir.file("m.png") + "' --cfa GRBG --method lmmse --out '" + dir.file("o.png") + "'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  ImageFileInfo info;
  const ImageF png = read_image(dir.file("o.png"), &info);
  EXPECT_EQ(info.bits_per_sample, 16);
  EXPECT_EQ(png.channels(), 3);
  // The PNG holds the library's demosaic of the same input to the 16-bit quantum: half a code,
  // 0.5/65535, plus the float rounding of the scalings out and back (2⁻²⁴ relative each, values
  // below 1). An 8-bit scale would be off by up to 0.5/255.
  const ImageF lmmse = demosaic(read_back, CfaPattern::GRBG, DemosaicMethod::Lmmse);
  ASSERT_TRUE(png.same_shape(lmmse));
  double worst = 0;
  for (size_t i = 0; i < png.size(); ++i) worst = std::max(worst, std::fabs(double(png[i]) - lmmse[i]));
  EXPECT_LE(worst, 0.5 / 65535 + 4 * 0x1p-24);
  auto l = test::run_cli("demosaic --list");
  ASSERT_EQ(l.exit_code, 0);
  for (const auto& n : demosaic_method_names()) EXPECT_NE(l.output.find(n), std::string::npos) << n;
}

// photosite's own raw mosaic (`expose --layers raw`: UINT raw.Y in DN, the CFA, bit depth and black
// level in the header) demosaiced by the command gives expose's own R,G,B for the same method, bit
// for bit: DN read as counts (before: code / (2^32 - 1), ~1e-7), the header's GRBG (before: the
// default RGGB) and its black level subtracted. A PNG out is DN / (2^12 - 1).
// The night chart (`chart`, w x h) exposed by `expose <args>` twice, into dir's raw.exr (--layers
// raw) and rgb.exr (--layers sensor); false (with a failure) where a command failed.
static bool expose_chart_raw_and_rgb(const test::TempDir& dir, const std::string& size, const std::string& args) {
  auto r = test::run_cli("chart " + size + " --out '" + dir.file("chart.exr") + "'");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  if (r.exit_code != 0) return false;
  const std::string expose = "expose " + args + " --backend cpu --seed 5 --device-store '" + dir.file("store") +
                             "' --radiance '" + dir.file("chart.exr") + "'";
  for (const char* layers : {"raw", "sensor"}) {
    r = test::run_cli(expose + " --layers " + layers + " --out '" + dir.file(layers == std::string("raw") ? "raw.exr" : "rgb.exr") + "'");
    EXPECT_EQ(r.exit_code, 0) << r.output;
    if (r.exit_code != 0) return false;
  }
  return true;
}

TEST(DemosaicCli, PhotositeRawMosaicGivesExposesRgb) {
  test::TempDir dir;
  const std::string raw = dir.file("raw.exr"), rgb = dir.file("rgb.exr");
  ASSERT_TRUE(expose_chart_raw_and_rgb(dir, "--width 64 --height 48", "--preset onsemi-ar0331 --demosaic malvar"));
  test::CliResult r;
  const std::string in = "demosaic --backend cpu --method malvar --in '" + raw + "'";
  r = test::run_cli(in + " --out '" + dir.file("d.exr") + "'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const ExrContents want = read_exr(rgb), got = read_exr(dir.file("d.exr"));
  EXPECT_EQ(got.attributes.at("photosite/cfa"), "GRBG");
  EXPECT_EQ(got.attributes.at("photosite/cfa_source"), "input header");
  EXPECT_EQ(got.attributes.at("photosite/source_channel"), "raw.Y");
  EXPECT_EQ(std::stod(got.attributes.at("photosite/black_level_dn")), std::stod(want.attributes.at("photosite/black_level_dn")));
  EXPECT_EQ(got.attributes.at("photosite/bit_depth"), "12");
  double peak = 0;
  for (const char* c : {"R", "G", "B"}) {
    const ImageF &g = got.channels.at(c), &w = want.channels.at(c);
    EXPECT_EQ(g.unit(), "DN above black level");
    EXPECT_EQ(w.unit(), "DN above black level");
    for (size_t i = 0; i < w.size(); ++i) {
      ASSERT_EQ(g[i], w[i]) << c << " sample " << i;
      peak = std::max(peak, static_cast<double>(w[i]));
    }
  }
  EXPECT_GT(peak, 1000);  // DN, not a code fraction
  // PNG: DN / (2^12 - 1) as 16-bit codes (clipped at 0 below black).
  r = test::run_cli(in + " --out '" + dir.file("d.png") + "'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const ImageU16 png = read_image_u16(dir.file("d.png"));
  ASSERT_EQ(png.channels(), 3);
  const char* names[3] = {"R", "G", "B"};
  for (size_t p = 0; p < png.pixel_count(); ++p)
    for (int c = 0; c < 3; ++c)
      ASSERT_EQ(png[3 * p + c], float_to_code16(static_cast<float>(want.channels.at(names[c])[p] * (1.0 / 4095)))) << p;
  // A --cfa that contradicts the header is refused, naming both; the header's own (any case) is taken.
  r = test::run_cli(in + " --cfa RGGB --out '" + dir.file("x.exr") + "'");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  for (const char* s : {"raw.exr", "--cfa RGGB", "photosite/cfa GRBG"}) EXPECT_NE(r.output.find(s), std::string::npos) << s << "\n" << r.output;
  EXPECT_FALSE(std::filesystem::exists(dir.file("x.exr")));
  r = test::run_cli(in + " --cfa grbg --out '" + dir.file("y.exr") + "'");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(read_exr(dir.file("y.exr")).attributes.at("photosite/cfa_source"), "input header and --cfa");
}

// A clear-pattern camera's raw (onsemi AR0132AT, RCCC) with clipped lamp heads (the night chart at
// 40 ms): the raw's header carries where it clipped (photosite/clipped_at_dn, clip_neutral_dn),
// and `demosaic` without --white-level makes the clipped pixels neutral as expose made its own
// R,G,B: the same bits. Without the header's clip level (before), those pixels stayed red.
TEST(DemosaicCli, ClearPatternRawUsesItsOwnClipLevel) {
  test::TempDir dir;
  const std::string raw = dir.file("raw.exr"), rgb = dir.file("rgb.exr");
  ASSERT_TRUE(expose_chart_raw_and_rgb(dir, "--width 96 --height 64", "--preset onsemi-ar0132at-rccc --exposure-s 0.04"));
  test::CliResult r;
  const ExrContents raw_exr = read_exr(raw);
  const double at = std::stod(raw_exr.attributes.at("photosite/clipped_at_dn"));
  size_t clipped = 0;
  for (float v : raw_exr.channels.at("raw.Y").vec()) clipped += v >= at;
  ASSERT_GT(clipped, 0u) << "the chart's lamps must clip for this test";
  r = test::run_cli("demosaic --backend cpu --in '" + raw + "' --out '" + dir.file("d.exr") + "'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const ExrContents want = read_exr(rgb), got = read_exr(dir.file("d.exr"));
  EXPECT_EQ(got.attributes.at("photosite/white_level_source"), "input header (photosite/clipped_at_dn)");
  EXPECT_EQ(std::stod(got.attributes.at("photosite/white_level")), at);
  for (const char* c : {"R", "G", "B"}) {
    const ImageF &g = got.channels.at(c), &w = want.channels.at(c);
    for (size_t i = 0; i < w.size(); ++i) ASSERT_EQ(g[i], w[i]) << c << " sample " << i;
  }
}

// --white-level: an 8-bit RCCC mosaic with a disc at code 255 comes out neutral at 255/255/3 where
// the disc is, with the flag only (without it the clip is unknown and the disc stays red: G = B = 0).
TEST(DemosaicCli, WhiteLevelMakesClippedClearPixelsNeutral) {
  test::TempDir dir;
  ImageF field = smooth_field(24, 20);
  for (float& v : field.vec()) v *= 0.5f;  // C = R + G + B at most 0.75: no code 255 outside the disc
  ImageF m = mosaic(field, CfaPattern::RCCC);
  for (int y = 0; y < 20; ++y)
    for (int x = 0; x < 24; ++x)
      if ((x - 10) * (x - 10) + (y - 10) * (y - 10) <= 9) m.at(x, y, 0) = 1.f;
  write_png(dir.file("m.png"), m, 8);
  const std::string base = "demosaic --backend cpu --cfa RCCC --in '" + dir.file("m.png") + "'";
  auto r = test::run_cli(base + " --white-level 255 --out '" + dir.file("w.exr") + "'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  r = test::run_cli(base + " --out '" + dir.file("n.exr") + "'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const ExrContents with = read_exr(dir.file("w.exr")), without = read_exr(dir.file("n.exr"));
  EXPECT_EQ(std::stod(with.attributes.at("photosite/white_level")), 255.0);
  const size_t centre = 10 * 24 + 10, far = 2 * 24 + 22;
  for (const char* c : {"R", "G", "B"}) {
    EXPECT_EQ(with.channels.at(c)[centre], static_cast<float>(1.0 / 3)) << c;
    EXPECT_EQ(with.channels.at(c)[far], without.channels.at(c)[far]) << c;
  }
  EXPECT_EQ(without.channels.at("G")[centre], 0.f);
}

TEST(DemosaicCli, BadInputExitsWithStatus2) {
  test::TempDir dir;
  write_png(dir.file("m.png"), mosaic(smooth_field(16, 16), CfaPattern::RGGB), 8);
  write_png(dir.file("rgb.png"), smooth_field(16, 16), 8);
  const std::string in = " --in '" + dir.file("m.png") + "'";
  const std::string out = " --out '" + dir.file("o.exr") + "'";
  struct Case { std::string args, needle; };
  const Case cases[] = {
      {"demosaic" + in + out + " --method nope", "nope"},
      {"demosaic" + in + out + " --cfa RGBW", "RGBW"},
      {"demosaic --in '" + dir.file("rgb.png") + "'" + out, "one channel"},
      {"demosaic --in '" + dir.file("missing.png") + "'" + out, "missing.png"},
      {"demosaic" + in + " --out '" + dir.file("o.jpg") + "'", ".exr or .png"},
      {"demosaic" + in + " --out '" + dir.file("m.png") + "'", "--out is the run's --in input"},
      {"demosaic" + in + " --out '" + dir.file("rgb.png") + "'", "already exists"},
      {"demosaic" + out, "--in"},
      {"demosaic" + in + out + " --white-level 255", "--white-level: clip handling is for the clear patterns"},
      {"demosaic" + in + out + " --cfa RCCC --white-level 0", "--white-level 0 is not above"},
  };
  for (const auto& c : cases) {
    auto r = test::run_cli(c.args);
    EXPECT_EQ(r.exit_code, 2) << c.args << "\n" << r.output;
    EXPECT_NE(r.output.find(c.needle), std::string::npos) << c.args << "\n" << r.output;
  }
  EXPECT_FALSE(std::filesystem::exists(dir.file("o.exr")));
}

}  // namespace
}  // namespace photosite
