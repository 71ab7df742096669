// Lens veiling glare: the reduced-resolution pyramid of include/photosite/sensor/glare.h.
// Every float operation below is written in a fixed order (no FMA: -ffp-contract=off), the
// same order as kernels/glare_*.comp and photon.comp; the borders, taps, bilinear steps and the
// mix are the same functions (kernels/common/glare.glsl), so both backends give the same bits. Rows are independent and the energy sums run in a fixed order, so the thread
// count never changes a result.
#include "photosite/sensor/glare.h"

#include <algorithm>
#include <cmath>
#include <immintrin.h>

#include "photosite/error.h"
#include "photosite/units.h"
#include "sensor/glare_detail.h"

namespace photosite {

namespace {
constexpr int kMaxLevel = 16;

// The pyramid's borders, taps, steps and mix are kernels/common/glare.glsl's, shared with the
// Vulkan kernels (sensor/glare_detail.h).
using shader::glare_lerp;
using shader::glare_mirror;
using shader::glare_up_tap;
using UpTap = shader::GlareTap;

// The row kernels below carry an AVX2 clone (target_clones): the same IEEE operations in the
// same order per sample on either clone (no FMA: -ffp-contract=off, and the avx2 target has no
// fma), so the same bits; the default clone is the SSE2 baseline the library is built for.

// One row of the bilinear 2x upsampling along x: u[3x + c] = w0·t[3·i0 + c] + w1·t[3·i1 + c]
// with glare_up_tap's taps, for x < width; t holds cw pixels; e, o: scratch of 3·cw floats
// each. The interior pairs (x = 2j, 2j + 1) need no clamping: their even and odd samples
// e[k] = ¼·t[k − 3] + ¾·t[k], o[k] = ¾·t[k] + ¼·t[k + 3] (glare_up_tap's arithmetic) are formed
// first over the contiguous row, where they vectorize, then interleaved pixel by pixel.
__attribute__((target_clones("avx2", "default")))
void upsample_row(const float* __restrict t, int cw, int width, float* __restrict u, float* __restrict e,
                  float* __restrict o) {
  auto one = [&](int x) {
    const UpTap tx = glare_up_tap(x, cw);
    for (int c = 0; c < 3; ++c) u[3 * x + c] = glare_lerp(tx.w0, t[3 * tx.i0 + c], tx.w1, t[3 * tx.i1 + c]);
  };
  if (cw < 3) {
    for (int x = 0; x < width; ++x) one(x);
    return;
  }
  one(0);
  one(1);
  const int k_end = 3 * (cw - 1);  // x = 2j and 2j + 1 for 1 <= j < cw − 1, below 2cw − 2 <= width
  for (int k = 3; k < k_end; ++k) {
    e[k] = glare_lerp(0.25f, t[k - 3], 0.75f, t[k]);
    o[k] = glare_lerp(0.75f, t[k], 0.25f, t[k + 3]);
  }
  // Interleaved by 4-float stores that overlap: e[k..k+3] to u[2k..], then o[k..k+3] to u[2k+3..]
  // over e's fourth float, whose own fourth float the next pixel pair (or one(), past the
  // interior) overwrites in turn. e, o hold 3·cw floats, so the reads stay inside them.
  for (int k = 3; k < k_end; k += 3) {
    _mm_storeu_ps(u + 2 * k, _mm_loadu_ps(e + k));
    _mm_storeu_ps(u + 2 * k + 3, _mm_loadu_ps(o + k));
  }
  for (int x = 2 * (cw - 1); x < width; ++x) one(x);
}

// out[j] = glare_lerp(w0, a[j], w1, b[j]) over n samples (the vertical bilinear step).
__attribute__((target_clones("avx2", "default")))
void lerp_row(float w0, const float* __restrict a, float w1, const float* __restrict b, size_t n,
              float* __restrict out) {
  for (size_t j = 0; j < n; ++j) out[j] = glare_lerp(w0, a[j], w1, b[j]);
}

// o[j] = o[j] + w·p[j] over n samples (one tap of a blur).
__attribute__((target_clones("avx2", "default")))
void add_tap(float* __restrict o, float w, const float* __restrict p, size_t n) {
  for (size_t j = 0; j < n; ++j) o[j] = o[j] + w * p[j];
}

// o[j] = w·o[j] + u[j] (u given) or w·o[j] (u null): a level's weighted blur plus the upsampled
// coarser accumulator.
__attribute__((target_clones("avx2", "default")))
void weigh_add(float* __restrict o, float w, const float* __restrict u, size_t n) {
  if (u)
    for (size_t j = 0; j < n; ++j) o[j] = w * o[j] + u[j];
  else
    for (size_t j = 0; j < n; ++j) o[j] = w * o[j];
}

// out[3x + c] = glare_mix(keep, in[3x + c], s_c, u[3x + c]) over n = 3·width samples, in blocks
// of 24 (8 pixels: a whole number of vectors and of pixels) with the scales laid out per lane.
__attribute__((target_clones("avx2", "default")))
void mix_row(float keep, const float* s3, const float* __restrict in, const float* __restrict u, size_t n,
             float* __restrict out) {
  float sl[24];
  for (int i = 0; i < 24; ++i) sl[i] = s3[i % 3];
  size_t k = 0;
  for (; k + 24 <= n; k += 24)
    for (int i = 0; i < 24; ++i) out[k + i] = shader::glare_mix(keep, in[k + i], sl[i], u[k + i]);
  for (; k < n; ++k) out[k] = shader::glare_mix(keep, in[k], sl[k % 24], u[k]);
}

// Σ_j n_x(j)·v over one level-1 row (n = number of full-resolution children), per channel, in
// double and in order: the row sums behind glare_level1_energy.
inline std::array<double, 3> level1_row_sum(const float* r, int w, int full_width) {
  double s0 = 0, s1 = 0, s2 = 0;
  for (int j = 0; j < w; ++j) {
    const double n = 2 * j + 1 < full_width ? 2.0 : 1.0;
    s0 += n * static_cast<double>(r[3 * j]);
    s1 += n * static_cast<double>(r[3 * j + 1]);
    s2 += n * static_cast<double>(r[3 * j + 2]);
  }
  return {s0, s1, s2};
}
std::array<double, 3> combine_rows(const std::vector<std::array<double, 3>>& rows, int full_height) {
  std::array<double, 3> e{0, 0, 0};
  for (size_t i = 0; i < rows.size(); ++i) {
    const double n = 2 * static_cast<int>(i) + 1 < full_height ? 2.0 : 1.0;
    for (int c = 0; c < 3; ++c) e[c] += n * rows[i][c];
  }
  return e;
}
// Levels this small run on one thread: under load, a barrier costs more than their work.
constexpr int64_t kParallelPixels = int64_t{1} << 18;

// One output row of down2 from input rows ra, rb (w pixels): pixel x averages the pairs at 2x
// and min(2x + 1, w − 1), in the order ((a0 + a1) + (b0 + b1))·¼; the interior pairs without
// the clamp, so that the loop vectorizes.
__attribute__((target_clones("avx2", "default")))
void down2_row(const float* __restrict ra, const float* __restrict rb, int w, float* __restrict o) {
  const int w2 = (w + 1) / 2, pairs = w / 2;  // pixels 2x, 2x + 1 both inside for x < pairs
  for (int x = 0; x < pairs; ++x)
    for (int c = 0; c < 3; ++c) {
      const int k = 6 * x + c;
      o[3 * x + c] = ((ra[k] + ra[k + 3]) + (rb[k] + rb[k + 3])) * 0.25f;
    }
  for (int x = pairs; x < w2; ++x) {  // odd w: the last pixel averages with itself
    const int xa = 3 * (2 * x), xb = 3 * std::min(2 * x + 1, w - 1);
    for (int c = 0; c < 3; ++c) o[3 * x + c] = ((ra[xa + c] + ra[xb + c]) + (rb[xa + c] + rb[xb + c])) * 0.25f;
  }
}

// 2x2 box average, edge clamped (the last row/column of an odd size averages with itself).
// With `rows`: also each output row's level1_row_sum (the level-1 energy of the input).
ImageF down2(const ImageF& src, std::vector<std::array<double, 3>>* rows = nullptr) {
  const int w = src.width(), h = src.height();
  const int w2 = (w + 1) / 2, h2 = (h + 1) / 2;
  ImageF dst(w2, h2, 3, uninitialized, src.unit());
  if (rows) rows->assign(h2, {0, 0, 0});
#pragma omp parallel for schedule(static) if (static_cast<int64_t>(w2) * h2 > kParallelPixels / 4)
  for (int y = 0; y < h2; ++y) {
    const float* ra = src.row(2 * y);
    const float* rb = src.row(std::min(2 * y + 1, h - 1));
    float* o = dst.row(y);
    down2_row(ra, rb, w, o);
    if (rows) (*rows)[y] = level1_row_sum(o, w2, w);
  }
  return dst;
}

// down_1331's interior along a row: o[3x + k] for 1 <= x < end, from s[3(2x − 1) + k] on.
__attribute__((target_clones("avx2", "default")))
void taps1331_row(const float* __restrict s, int end, float* __restrict o) {
  for (int x = 1; x < end; ++x) {
    const float* a = s + 3 * (2 * x - 1);
    for (int k = 0; k < 3; ++k)
      o[3 * x + k] = (0.125f * a[k] + 0.375f * a[3 + k]) + (0.375f * a[6 + k] + 0.125f * a[9 + k]);
  }
}
// down_1331 along columns: one output row from its four input rows.
__attribute__((target_clones("avx2", "default")))
void taps1331_cols(const float* __restrict a, const float* __restrict b, const float* __restrict c,
                   const float* __restrict d, size_t n, float* __restrict o) {
  for (size_t j = 0; j < n; ++j) o[j] = (0.125f * a[j] + 0.375f * b[j]) + (0.375f * c[j] + 0.125f * d[j]);
}

// Down one octave with the taps (1, 3, 3, 1)/8 per axis, the transpose of the bilinear
// upsampling (mirror borders): unlike a 2x2 box it keeps a point source's centroid where it
// was, so coarse levels spread a lamp's glare around the lamp, not around a coarse pixel
// centre up to 2^(l-1) px away. Rows first, then columns; each sum in this order.
ImageF down_1331(const ImageF& src) {
  const int w = src.width(), h = src.height();
  const int w2 = (w + 1) / 2, h2 = (h + 1) / 2;
  ImageF t(w2, h, 3, uninitialized, src.unit()), dst(w2, h2, 3, uninitialized, src.unit());
#pragma omp parallel for schedule(static) if (static_cast<int64_t>(w2) * h > kParallelPixels)
  for (int y = 0; y < h; ++y) {
    const float* s = src.row(y);
    float* o = t.row(y);
    auto at = [&](int x) {
      const float* a = s + 3 * glare_mirror(2 * x - 1, w);
      const float* b = s + 3 * glare_mirror(2 * x, w);
      const float* c = s + 3 * glare_mirror(2 * x + 1, w);
      const float* d = s + 3 * glare_mirror(2 * x + 2, w);
      for (int k = 0; k < 3; ++k)
        o[3 * x + k] = (0.125f * a[k] + 0.375f * b[k]) + (0.375f * c[k] + 0.125f * d[k]);
    };
    const int inner_end = std::max(1, (w - 1) / 2);  // x < inner_end: 2x + 2 <= w − 1, no mirror
    at(0);
    taps1331_row(s, inner_end, o);
    for (int x = std::max(1, inner_end); x < w2; ++x) at(x);
  }
#pragma omp parallel for schedule(static) if (static_cast<int64_t>(w2) * h2 > kParallelPixels)
  for (int y = 0; y < h2; ++y) {
    const float* a = t.row(glare_mirror(2 * y - 1, h));
    const float* b = t.row(glare_mirror(2 * y, h));
    const float* c = t.row(glare_mirror(2 * y + 1, h));
    const float* d = t.row(glare_mirror(2 * y + 2, h));
    taps1331_cols(a, b, c, d, 3 * static_cast<size_t>(w2), dst.row(y));
  }
  return dst;
}

// Separable blur along rows (taps centre first), mirror borders: each row is first copied into
// a padded row (the mirror resolved once), then every output sums its taps from −R to R.
ImageF blur_rows(const ImageF& src, const std::array<float, kGlareBlurRadius + 1>& g) {
  const int w = src.width(), h = src.height();
  constexpr int R = kGlareBlurRadius;
  ImageF dst(w, h, 3, uninitialized, src.unit());
#pragma omp parallel if (static_cast<int64_t>(w) * h > kParallelPixels)
  {
    std::vector<float> pad(3 * static_cast<size_t>(w + 2 * R));
#pragma omp for schedule(static)
    for (int y = 0; y < h; ++y) {
      const float* s = src.row(y);
      for (int x = -R; x < w + R; ++x)
        for (int c = 0; c < 3; ++c) pad[3 * (x + R) + c] = s[3 * glare_mirror(x, w) + c];
      float* o = dst.row(y);
      for (int j = 0; j < 3 * w; ++j) o[j] = 0.f;
      for (int k = -R; k <= R; ++k) {
        const float wk = g[std::abs(k)];
        add_tap(o, wk, pad.data() + 3 * (R + k), 3 * static_cast<size_t>(w));
      }
    }
  }
  return dst;
}

// The blur along columns, weighted and added to the upsampled coarser accumulator:
// acc_l = w·blur_col(t) + up(acc_{l+1}) (the second term only when `coarse` is not empty;
// w = 0 with an empty `t`: acc_l = up(acc_{l+1}), the levels finer than lo). Per sample: the
// upsampled value u (vertical interpolation first, then horizontal), the column sum
// a = Σ_{k=−R..R} g_|k|·t(y + k) in that order, then w·a + u.
ImageF blur_cols_add(const ImageF& t, const ImageF& coarse, float w, int width, int height,
                     const std::array<float, kGlareBlurRadius + 1>& g,
                     std::vector<std::array<double, 3>>* rows = nullptr, int full_width = 0) {
  constexpr int R = kGlareBlurRadius;
  ImageF dst(width, height, 3, uninitialized, unit::radiance);
  const bool blur = !t.empty(), up = !coarse.empty();
  const int cw = up ? coarse.width() : 0, ch = up ? coarse.height() : 0;
  const size_t n = 3 * static_cast<size_t>(width);
  if (rows) rows->assign(height, {0, 0, 0});
#pragma omp parallel if (static_cast<int64_t>(width) * height > kParallelPixels)
  {
    std::vector<float> tmp(up ? 9 * static_cast<size_t>(cw) : 0), u(up ? n : 0);  // t, then e, o of upsample_row
#pragma omp for schedule(static)
    for (int y = 0; y < height; ++y) {
      float* o = dst.row(y);
      if (up) {
        const UpTap ty = glare_up_tap(y, ch);
        const float* r0 = coarse.row(ty.i0);
        const float* r1 = coarse.row(ty.i1);
        lerp_row(ty.w0, r0, ty.w1, r1, 3 * static_cast<size_t>(cw), tmp.data());
        upsample_row(tmp.data(), cw, width, blur ? u.data() : o, tmp.data() + 3 * cw, tmp.data() + 6 * cw);
      }
      if (!blur) {
        if (rows) (*rows)[y] = level1_row_sum(o, width, full_width);
        continue;
      }
      for (size_t j = 0; j < n; ++j) o[j] = 0.f;
      for (int k = -R; k <= R; ++k) {
        const float wk = g[std::abs(k)];
        add_tap(o, wk, t.row(glare_mirror(y + k, height)), n);
      }
      weigh_add(o, w, up ? u.data() : nullptr, n);
      if (rows) (*rows)[y] = level1_row_sum(o, width, full_width);
    }
  }
  return dst;
}
}  // namespace

double px_per_degree(double focal_length_mm, double pixel_pitch_um) {
  return focal_length_mm * 1e-3 / (pixel_pitch_um * 1e-6) * units::pi / 180.0;
}

std::array<float, kGlareBlurRadius + 1> glare_blur_taps() {
  // Gaussian σ = 1 level pixel sampled at the integers, cut at 3σ, normalised in double.
  double g[kGlareBlurRadius + 1], sum = 0;
  for (int k = 0; k <= kGlareBlurRadius; ++k) {
    g[k] = std::exp(-0.5 * k * k);
    sum += k == 0 ? g[k] : 2 * g[k];
  }
  std::array<float, kGlareBlurRadius + 1> out{};
  for (int k = 0; k <= kGlareBlurRadius; ++k) out[k] = static_cast<float>(g[k] / sum);
  return out;
}

GlarePlan plan_glare(const LensGlare& glare, double px_per_deg) {
  GlarePlan p;
  if (!glare.enabled || !(glare.veiling_glare_index > 0)) return p;
  if (!(px_per_deg > 0) || !std::isfinite(px_per_deg))
    fail("glare: pixels per degree must be positive and finite");
  const auto g = glare_blur_taps();
  double var_b = 0;  // the discrete blur's variance (level px²)
  for (int k = 1; k <= kGlareBlurRadius; ++k) var_b += 2.0 * k * k * g[k];
  // A point source's spread on level l (px² per axis, phase-averaged): the 2x2 box to level 1
  // adds 1/4, each (1,3,3,1)/8 step m = 2..l adds 3/4·4^(m−1), each bilinear step m = 1..l back
  // up adds 3/16·4^m, the blur σ_b²·4^l: in all 4^l·(σ_b² + 1/2) − 1.
  auto sigma = [&](int l) {
    const double f = std::ldexp(1.0, 2 * l);
    return std::sqrt(f * (var_b + 0.5) - 1.0);
  };
  auto nearest = [&](double target_px) {
    int best = 1;
    for (int l = 2; l <= kMaxLevel; ++l)
      if (std::fabs(std::log(sigma(l) / target_px)) < std::fabs(std::log(sigma(best) / target_px))) best = l;
    return best;
  };
  p.active = true;
  p.eta = glare.veiling_glare_index;
  p.keep = static_cast<float>(1.0 - glare.veiling_glare_index);
  p.lo = nearest(glare.core_deg * px_per_deg);
  p.hi = std::max(p.lo, nearest(0.5 * glare.reach_deg * px_per_deg));
  // A sum of unit Gaussians at σ_l with weights ∝ σ_l^(2−p) has density ∝ Σ σ_l^(−p)·e^(−θ²/2σ_l²)
  // ≈ θ^(−p) between σ_lo and σ_hi.
  double total = 0;
  for (int l = p.lo; l <= p.hi; ++l) {
    p.sigma_px.push_back(sigma(l));
    total += std::pow(sigma(l), 2.0 - glare.skirt_exponent);
  }
  for (int l = p.lo; l <= p.hi; ++l)
    p.weight.push_back(static_cast<float>(std::pow(sigma(l), 2.0 - glare.skirt_exponent) / total));
  return p;
}

std::array<double, 3> glare_level1_energy(const ImageF& v, int full_width, int full_height) {
  std::vector<std::array<double, 3>> rows(v.height());
  for (int i = 0; i < v.height(); ++i) rows[i] = level1_row_sum(v.row(i), v.width(), full_width);
  return combine_rows(rows, full_height);
}

GlareSkirt glare_skirt(const ImageF& in, const GlarePlan& plan) {
  GlareSkirt s;
  s.width = in.width();
  s.height = in.height();
  if (!plan.active) return s;
  if (in.channels() != 3) fail("glare: the irradiance must have 3 channels");
  if (in.width() < 1 || in.height() < 1) return s;
  const auto g = glare_blur_taps();
  // The level-1 energies' row sums come out of the passes that write level 1 and acc_1 (the
  // same sums as glare_level1_energy, without another pass over memory).
  std::vector<std::array<double, 3>> rows_in, rows_skirt;
  std::vector<ImageF> lv(plan.hi + 1);
  lv[1] = down2(in, &rows_in);
  for (int l = 2; l <= plan.hi; ++l) lv[l] = down_1331(lv[l - 1]);
  ImageF acc;
  for (int l = plan.hi; l >= 1; --l) {
    const int w = lv[l].width(), h = lv[l].height();
    auto* rows = l == 1 ? &rows_skirt : nullptr;
    if (l >= plan.lo) acc = blur_cols_add(blur_rows(lv[l], g), acc, plan.weight[l - plan.lo], w, h, g, rows, s.width);
    else acc = blur_cols_add(ImageF(), acc, 0.f, w, h, g, rows, s.width);
  }
  const auto e_in = combine_rows(rows_in, s.height);
  const auto e_skirt = combine_rows(rows_skirt, s.height);
  for (int c = 0; c < 3; ++c)
    s.scale[c] = e_skirt[c] > 0 ? static_cast<float>(plan.eta * e_in[c] / e_skirt[c]) : 0.f;
  s.keep = plan.keep;
  s.acc1 = std::move(acc);
  return s;
}

void glare_row(const GlareSkirt& s, int y, const float* in, float* out, float* tmp) {
  const ImageF& a = s.acc1;
  const int aw = a.width(), ah = a.height();
  const UpTap ty = glare_up_tap(y, ah);
  const float* r0 = a.row(ty.i0);
  const float* r1 = a.row(ty.i1);
  float* t = tmp;                  // 3·aw: the vertical interpolation
  float* u = tmp + 3 * aw;         // 3·width: then the horizontal one
  float* e = u + 3 * static_cast<size_t>(s.width);  // 2·3·aw: upsample_row's scratch
  lerp_row(ty.w0, r0, ty.w1, r1, 3 * static_cast<size_t>(aw), t);
  upsample_row(t, aw, s.width, u, e, e + 3 * aw);
  mix_row(s.keep, s.scale.data(), in, u, 3 * static_cast<size_t>(s.width), out);
}

ImageF apply_glare(const ImageF& in, const LensGlare& glare, double px_per_deg) {
  const GlareSkirt s = glare_skirt(in, plan_glare(glare, px_per_deg));
  if (!s.active()) return in;
  ImageF out(in.width(), in.height(), 3, uninitialized, in.unit());
#pragma omp parallel
  {
    std::vector<float> tmp(glare_row_scratch(s));
#pragma omp for schedule(static)
    for (int y = 0; y < in.height(); ++y) glare_row(s, y, in.row(y), out.row(y), tmp.data());
  }
  return out;
}

}  // namespace photosite
