#include "photosite/sensor/isp.h"

#include <algorithm>
#include <bit>
#include <cstdint>
#include <limits>
#include <cmath>
#include <vector>

#if defined(__x86_64__)
#include <immintrin.h>
#endif

#include <fmt/format.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "core/isa_detail.h"
#include "core/raster_codecs.h"
#include "photosite/error.h"
#include "photosite/sensor/spectrum.h"

namespace photosite {

namespace {
// The camera's photon matrix on axis at 1 s (the white balance's scale drops out of its ratios).
PhotonMatrix unit_photon_matrix(const CameraPreset& p) {
  LensPreset lens;
  lens.cos4_falloff = false;
  ExposureSettings s;
  s.exposure_s = 1.0;
  return photon_matrix(p, lens, resolve(p, lens, s));
}
// The camera RGB (its filter planes through filter_planes_to_rgb) of box radiances w.
void camera_rgb_of(const CameraPreset& p, const PhotonMatrix& m, const std::array<double, 3>& w, float rgb[3]) {
  float planes[4];
  for (int c = 0; c < 4; ++c) planes[c] = static_cast<float>(m[c][0] * w[0] + m[c][1] * w[1] + m[c][2] * w[2]);
  filter_planes_to_rgb(p.cfa, planes, rgb);
}
}  // namespace

std::array<double, 3> white_balance_gains(const CameraPreset& p) {
  float rgb[3];
  camera_rgb_of(p, unit_photon_matrix(p), {1, 1, 1}, rgb);  // x * 1 is exact: the same sums as before
  std::array<double, 3> g{};
  for (int c = 0; c < 3; ++c) g[c] = rgb[c] > 0 ? rgb[1] / rgb[c] : 1.0;
  return g;
}

// ---- the colour correction matrix (isp.h: colour_correction_matrix) ----
ColourMatrix colour_correction_matrix(const CameraPreset& p) {
  const PhotonMatrix pm = unit_photon_matrix(p);
  ColourMatrix M{};  // M[r][k]: camera channel r per unit radiance in box k
  for (int k = 0; k < 3; ++k) {
    std::array<double, 3> e{};
    e[k] = 1;
    float rgb[3];
    camera_rgb_of(p, pm, e, rgb);
    for (int r = 0; r < 3; ++r) M[r][k] = rgb[r];
  }
  // Singular (to the bound of isp.h): the determinant against the product of the columns' norms,
  // the largest it can be (Hadamard's inequality), so the ratio does not depend on the units.
  const double det = M[0][0] * (M[1][1] * M[2][2] - M[1][2] * M[2][1]) -
                     M[0][1] * (M[1][0] * M[2][2] - M[1][2] * M[2][0]) +
                     M[0][2] * (M[1][0] * M[2][1] - M[1][1] * M[2][0]);
  double norms = 1;
  for (int k = 0; k < 3; ++k) norms *= std::sqrt(M[0][k] * M[0][k] + M[1][k] * M[1][k] + M[2][k] * M[2][k]);
  if (!(std::abs(det) >= 1e-6 * norms))
    fail_parameter("preview_ccm", "",
                   fmt::format(": camera '{}' ({}) has no three independent colour channels (det/Hadamard bound {:.3g}), so no "
                               "colour matrix; use --preview-ccm none",
                               p.name, to_string(p.cfa), norms > 0 ? std::abs(det) / norms : 0.0));
  const ColourMatrix Mi = spectrum::invert3(M);
  const ColourMatrix& B = spectrum::box_to_linear_srgb();
  const std::array<double, 3> wb = white_balance_gains(p);
  const double s = M[1][0] + M[1][1] + M[1][2];  // (M·1)_G
  ColourMatrix C{};
  for (int r = 0; r < 3; ++r) {
    const double white = B[r][0] + B[r][1] + B[r][2];  // (B·1)_r: the equal-energy white's sRGB
    for (int c = 0; c < 3; ++c) {
      double t_mi = 0;  // (B·M⁻¹)[r][c]
      for (int k = 0; k < 3; ++k) t_mi += B[r][k] * Mi[k][c];
      C[r][c] = s * t_mi / white / wb[c];
    }
  }
  return C;
}

ImageF apply_colour_matrix(const ImageF& rgb, const ColourMatrix& C, const std::array<double, 3>& wb) {
  if (rgb.channels() != 3) internal_error("apply_colour_matrix: 3-channel RGB expected");
  double A[3][3];  // diag(1/wb)·C·diag(wb)
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) A[r][c] = C[r][c] * wb[c] / wb[r];
  ImageF out(rgb.width(), rgb.height(), 3, uninitialized);
  const int64_t n = static_cast<int64_t>(rgb.width()) * rgb.height();
  const float* in = rgb.data();
  float* o = out.data();
#pragma omp parallel for schedule(static)
  for (int64_t i = 0; i < n; ++i) {
    const double x[3] = {in[3 * i], in[3 * i + 1], in[3 * i + 2]};
    for (int r = 0; r < 3; ++r) o[3 * i + r] = static_cast<float>(A[r][0] * x[0] + A[r][1] * x[1] + A[r][2] * x[2]);
  }
  return out;
}

// ---- auto white balance (isp.h: auto_white_balance_gains) ----
AwbBounds camera_awb_bounds(const CameraPreset& p, double cct_lo_K, double cct_hi_K) {
  if (!(cct_lo_K > 0 && cct_lo_K <= cct_hi_K) || !std::isfinite(cct_hi_K))
    fail_parameter("awb_cct_range", "", fmt::format(": {}-{} K is not a colour-temperature range", cct_lo_K, cct_hi_K));
  const PhotonMatrix m = unit_photon_matrix(p);
  AwbBounds b;
  b.lo = {std::numeric_limits<double>::infinity(), 1, std::numeric_limits<double>::infinity()};
  b.hi = {0, 1, 0};
  constexpr int kSteps = 64;
  for (int i = 0; i <= kSteps; ++i) {  // uniform in mired (1e6 / T), the locus's near-uniform scale
    const double mired = 1e6 / cct_hi_K + (1e6 / cct_lo_K - 1e6 / cct_hi_K) * i / kSteps;
    float rgb[3];
    camera_rgb_of(p, m, spectrum::blackbody_rgb(1e6 / mired, 1.0), rgb);
    for (int c : {0, 2}) {
      const double g = rgb[c] > 0 ? rgb[1] / rgb[c] : 1.0;
      b.lo[c] = std::min(b.lo[c], g);
      b.hi[c] = std::max(b.hi[c], g);
    }
  }
  return b;
}

std::array<double, 3> auto_white_balance_gains(const ImageF& rgb, double full_scale_dn, const AwbBounds& bounds,
                                               const std::array<double, 3>& fallback, double clip) {
  if (rgb.channels() != 3) internal_error("auto_white_balance_gains: 3-channel RGB expected");
  if (!(full_scale_dn > 0) || !std::isfinite(full_scale_dn))
    fail_parameter("full_scale_dn", "", fmt::format(": {} is not a sensor full scale", full_scale_dn));
  if (!(clip > 0 && clip <= 1)) fail_parameter("awb_clip", "", fmt::format(": {} is not a fraction in (0, 1]", clip));
  for (int c = 0; c < 3; ++c)
    if (!(bounds.lo[c] > 0 && bounds.lo[c] <= bounds.hi[c]) || !std::isfinite(bounds.hi[c]))
      fail_parameter("awb_bounds", "", fmt::format(": channel {} range {}-{} is not a gain range", c, bounds.lo[c], bounds.hi[c]));
  const int64_t n = static_cast<int64_t>(rgb.pixel_count());
  const double top = clip * full_scale_dn;
  constexpr int64_t kChunk = 1 << 16;
  const int64_t chunks = (n + kChunk - 1) / kChunk;
  // Per chunk: count, sum and sum of squares of each channel over the metered pixels.
  std::vector<std::array<double, 7>> part(chunks);
  const float* px = rgb.data();
#pragma omp parallel for schedule(static)
  for (int64_t c = 0; c < chunks; ++c) {
    std::array<double, 7> a{};
    for (int64_t i = c * kChunk, e = std::min(n, i + kChunk); i < e; ++i) {
      const float* q = px + 3 * i;
      bool ok = true;
      for (int k = 0; k < 3; ++k) ok = ok && std::isfinite(q[k]) && q[k] < top;
      if (!ok) continue;
      a[0] += 1;
      for (int k = 0; k < 3; ++k) {
        a[1 + k] += q[k];
        a[4 + k] += static_cast<double>(q[k]) * q[k];
      }
    }
    part[c] = a;
  }
  std::array<double, 7> t{};
  for (const auto& a : part)
    for (int k = 0; k < 7; ++k) t[k] += a[k];
  const double count = t[0];
  if (count < 2) return fallback;
  std::array<double, 3> mean{};
  for (int k = 0; k < 3; ++k) {
    mean[k] = t[1 + k] / count;
    const double var = std::max(0.0, (t[4 + k] - count * mean[k] * mean[k]) / (count - 1));
    // Signal, not noise: the mean at least 3 standard errors (sqrt(var / count)) above 0.
    if (!(mean[k] > 3 * std::sqrt(var / count))) return fallback;
  }
  std::array<double, 3> g{};
  for (int k = 0; k < 3; ++k) g[k] = std::clamp(mean[1] / mean[k], bounds.lo[k], bounds.hi[k]);
  return g;
}

double srgb_encode(double x) {
  x = std::clamp(x, 0.0, 1.0);
  return x <= 0.0031308 ? 12.92 * x : 1.055 * std::pow(x, 1.0 / 2.4) - 0.055;
}
double srgb_decode(double v) {
  return v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4);
}

// The k-th smallest of v (0-based), the value std::nth_element would put at k, by a radix
// select: floats map to unsigned keys in the same order (sign bit flipped for positives, all bits
// for negatives; -0 sorts just below +0, which compare equal), a histogram of the keys' top 16
// bits (per-thread counts summed in a fixed order: exact, any thread count) finds the bucket that
// holds rank k, and nth_element runs over that bucket's values only. v holds no NaN.
float kth_smallest(const std::vector<float>& v, size_t k) {
  auto key = [](float f) {
    const uint32_t u = std::bit_cast<uint32_t>(f);
    return u & 0x80000000u ? ~u : u | 0x80000000u;
  };
  constexpr int kBuckets = 1 << 16;
  const int64_t n = static_cast<int64_t>(v.size());
  std::vector<uint64_t> hist(kBuckets, 0);
#pragma omp parallel
  {
    std::vector<uint32_t> h(kBuckets, 0);
#pragma omp for schedule(static) nowait
    for (int64_t i = 0; i < n; ++i) ++h[key(v[i]) >> 16];
#pragma omp critical
    for (int b = 0; b < kBuckets; ++b) hist[b] += h[b];  // integer sums: order does not matter
  }
  uint64_t below = 0;
  int bucket = 0;
  while (below + hist[bucket] <= k) below += hist[bucket++];
  std::vector<float> in;
  in.reserve(hist[bucket]);
  for (int64_t i = 0; i < n; ++i)
    if (static_cast<int>(key(v[i]) >> 16) == bucket) in.push_back(v[i]);
  std::nth_element(in.begin(), in.begin() + static_cast<int64_t>(k - below), in.end());
  return in[k - below];
}

namespace {
// The exposure scale of a preview: the `percentile` luminance maps to `white_point`.
double preview_scale(const ImageF& rgb, const std::array<double, 3>& wb, double percentile, double white_point,
                     double min_white) {
  const size_t n = rgb.pixel_count();
  std::vector<float> lum(n);
#pragma omp parallel for schedule(static)
  for (int64_t i = 0; i < static_cast<int64_t>(n); ++i)
    lum[i] = static_cast<float>(0.2126 * wb[0] * rgb[3 * i] + 0.7152 * wb[1] * rgb[3 * i + 1] +
                                0.0722 * wb[2] * rgb[3 * i + 2]);
  double scale = 1.0;
  if (n) {
    const size_t k = std::min(n - 1, static_cast<size_t>(percentile * (n - 1)));
    const double at_k = std::max<double>(kth_smallest(lum, k), min_white);
    if (at_k > 0) scale = white_point / at_k;
  }
  return scale;
}

// 8-bit sRGB encoding by decision levels. level[k] (k = 1..255) is the smallest float x whose
// code is at least k, i.e. x >= srgb_decode((k - 1/2) / 255); level[0] = -inf, level[256] =
// +inf. A table indexed by a float's exponent and top 11 mantissa bits holds the code at the
// bin's lower edge for x in [2^-14, 1); within a bin the code rises by at most one (the sRGB
// curve gains at most 255 · 1.055 / 2.4 = 112 codes per unit of ln x, a bin spans 2^-11 of it:
// 0.055 codes), so one more comparison finishes. Below 2^-14 (< level[1] = 1.5e-4) the code
// is 0, from 1 on it is 255; NaN gives 0.
class Srgb8Levels {
 public:
  Srgb8Levels() {
    level_[0] = -std::numeric_limits<float>::infinity();
    level_[256] = std::numeric_limits<float>::infinity();
    for (int k = 1; k <= 255; ++k) {
      const double t = srgb_decode((k - 0.5) / 255.0);
      float f = static_cast<float>(t);
      if (static_cast<double>(f) < t) f = std::nextafter(f, 2.f);
      level_[k] = f;
    }
    lut_.assign(kBins + 3, 0);  // + 3: the vector path reads each entry as the low byte of 4
    int k = 0;
    for (uint32_t i = 0; i < kBins; ++i) {
      const float lo = std::bit_cast<float>(kLowBits + (i << kShift));
      while (lo >= level_[k + 1]) ++k;
      lut_[i] = static_cast<uint8_t>(k);
    }
  }
  uint8_t operator()(float x) const {
    if (!(x >= kLow)) return 0;  // also NaN
    if (x >= 1.f) return 255;
    int k = lut_[(std::bit_cast<uint32_t>(x) - kLowBits) >> kShift];
    while (x >= level_[k + 1]) ++k;
    return static_cast<uint8_t>(k);
  }
  // dst[j] = (*this)(src[j] · gain[j mod 3]) for j < n: the samples of n / 3 RGB pixels.
  void encode_rgb(const float* src, size_t n, const float gain[3], uint8_t* dst, bool vector) const {
    size_t j = 0;
#if defined(__x86_64__)
    static const bool avx2 = photosite::detail::have_avx2();
    if (avx2 && vector) j = encode_rgb_avx2(src, n, gain, dst);
#endif
    for (; j < n; ++j) dst[j] = (*this)(src[j] * gain[j % 3]);
  }

 private:
#if defined(__x86_64__)
  // Eight samples at a time, the scalar comparisons on each lane: in [2^-14, 1) the table's code
  // k (a byte, gathered as the low byte of a 32-bit word) and one comparison with level[k + 1];
  // below (NaN included) 0, from 1 on 255. Blocks of 24 samples (8 pixels: the gains' pattern
  // repeats); returns the samples done.
  __attribute__((target("avx2"))) __m256i codes8(__m256 x) const {
    const __m256 in_lo = _mm256_cmp_ps(x, _mm256_set1_ps(kLow), _CMP_GE_OQ);
    const __m256 hi = _mm256_cmp_ps(x, _mm256_set1_ps(1.f), _CMP_GE_OQ);
    const __m256i in = _mm256_castps_si256(_mm256_andnot_ps(hi, in_lo));
    __m256i bin = _mm256_srli_epi32(_mm256_sub_epi32(_mm256_castps_si256(x), _mm256_set1_epi32(kLowBits)), kShift);
    bin = _mm256_and_si256(bin, in);  // lanes outside [2^-14, 1) read entry 0
    __m256i k = _mm256_and_si256(_mm256_i32gather_epi32(reinterpret_cast<const int*>(lut_.data()), bin, 1),
                                 _mm256_set1_epi32(0xFF));
    const __m256 next = _mm256_i32gather_ps(level_ + 1, k, 4);
    k = _mm256_sub_epi32(k, _mm256_castps_si256(_mm256_cmp_ps(x, next, _CMP_GE_OQ)));  // + 1 where x >= level[k + 1]
    return _mm256_or_si256(_mm256_and_si256(k, in), _mm256_and_si256(_mm256_castps_si256(hi), _mm256_set1_epi32(255)));
  }
  __attribute__((target("avx2"))) size_t encode_rgb_avx2(const float* src, size_t n, const float gain[3], uint8_t* dst) const {
    const __m256 g[3] = {_mm256_setr_ps(gain[0], gain[1], gain[2], gain[0], gain[1], gain[2], gain[0], gain[1]),
                         _mm256_setr_ps(gain[2], gain[0], gain[1], gain[2], gain[0], gain[1], gain[2], gain[0]),
                         _mm256_setr_ps(gain[1], gain[2], gain[0], gain[1], gain[2], gain[0], gain[1], gain[2])};
    // The low byte of each 32-bit lane to the lane's first 4 bytes, then both lanes' to the low 8.
    const __m256i bytes = _mm256_setr_epi8(0, 4, 8, 12, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1,
                                           0, 4, 8, 12, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1);
    const __m256i lanes = _mm256_setr_epi32(0, 4, 1, 1, 1, 1, 1, 1);
    size_t j = 0;
    for (; j + 24 <= n; j += 24)
      for (int q = 0; q < 3; ++q) {
        const __m256i k = codes8(_mm256_mul_ps(_mm256_loadu_ps(src + j + 8 * q), g[q]));
        const __m256i packed = _mm256_permutevar8x32_epi32(_mm256_shuffle_epi8(k, bytes), lanes);
        _mm_storel_epi64(reinterpret_cast<__m128i*>(dst + j + 8 * q), _mm256_castsi256_si128(packed));
      }
    return j;
  }
#endif

 private:
  static constexpr float kLow = 0x1p-14f;
  static constexpr uint32_t kLowBits = 113u << 23;  // 2^-14
  static constexpr int kShift = 23 - 11;
  static constexpr uint32_t kBins = (127u - 113u) << 11;  // exponents 2^-14 .. 2^-1
  float level_[257];
  std::vector<uint8_t> lut_;
};
}  // namespace

const Srgb8Levels& srgb8_levels() {
  static const Srgb8Levels levels;
  return levels;
}

uint8_t srgb_encode8(float x) { return srgb8_levels()(x); }

void srgb_encode8_rgb(const float* src, size_t n, const float gain[3], uint8_t* dst, bool vector) {
  srgb8_levels().encode_rgb(src, n, gain, dst, vector);
}

namespace {
// 8-bit sRGB codes of rgb · wb · scale (preview_srgb8's and preview_srgb8_auto's encoding).
ImageU8 preview_srgb8_scaled(const ImageF& rgb, const std::array<double, 3>& wb, double scale) {
  const Srgb8Levels& encode = srgb8_levels();
  const float g[3] = {static_cast<float>(wb[0] * scale), static_cast<float>(wb[1] * scale),
                      static_cast<float>(wb[2] * scale)};
  const int64_t n = static_cast<int64_t>(rgb.pixel_count());
  ImageU8 out(rgb.width(), rgb.height(), 3, uninitialized, "sRGB code");
  const float* src = rgb.data();
  uint8_t* dst = out.data();
  constexpr int64_t kChunk = 4096;  // pixels per task
#pragma omp parallel for schedule(static)
  for (int64_t i = 0; i < n; i += kChunk)
    encode.encode_rgb(src + 3 * i, static_cast<size_t>(3 * std::min(kChunk, n - i)), g, dst + 3 * i, true);
  return out;
}
}  // namespace

ImageU8 preview_srgb8(const ImageF& rgb, const std::array<double, 3>& wb, double percentile, double white_point,
                      double min_white) {
  return preview_srgb8_scaled(rgb, wb, preview_scale(rgb, wb, percentile, white_point, min_white));
}

// ---- auto-exposure preview (isp.h: AutoExposure) ----
AutoExposure camera_auto_exposure(const CameraPreset& camera, const ResolvedExposure& exposure) {
  AutoExposure ae;
  ae.max_gain = std::max(1.0, std::pow(10.0, camera.max_gain_db / 20) / exposure.gain_linear);
  return ae;
}

double preview_min_white(const CameraPreset& camera, const ResolvedExposure& exposure,
                         const std::array<double, 3>& wb) {
  return std::min({wb[0], wb[1], wb[2]}) * sensor_full_scale_dn(camera, exposure) /
         camera_auto_exposure(camera, exposure).max_gain;
}

double auto_exposure_gain(const ImageF& rgb, const std::array<double, 3>& wb, double full_scale_dn,
                          const AutoExposure& ae) {
  if (!(full_scale_dn > 0) || !std::isfinite(full_scale_dn))
    fail_parameter("full_scale_dn", "", fmt::format(": {} is not a sensor full scale", full_scale_dn));
  if (!(ae.target > 0 && ae.target < 1))
    fail_parameter("auto_exposure_target", "", fmt::format(": {} is not a fraction of full scale in (0, 1)", ae.target));
  if (!(ae.max_gain >= 1) || !std::isfinite(ae.max_gain))
    fail_parameter("auto_exposure_max_gain", "", fmt::format(": {} is not a gain of at least 1", ae.max_gain));
  if (!(ae.clip_fraction >= 0 && ae.clip_fraction < 1))
    fail_parameter("auto_exposure_clip_fraction", "", fmt::format(": {} is not a fraction in [0, 1)", ae.clip_fraction));
  const double g_min = std::min({wb[0], wb[1], wb[2]});
  const double k = 1.0 / (g_min * full_scale_dn);
  const int64_t n = static_cast<int64_t>(rgb.pixel_count());
  if (n == 0) return ae.max_gain;
  std::vector<float> y(n);
#pragma omp parallel for schedule(static)
  for (int64_t i = 0; i < n; ++i) {
    const double v = k * (0.2126 * wb[0] * rgb[3 * i] + 0.7152 * wb[1] * rgb[3 * i + 1] + 0.0722 * wb[2] * rgb[3 * i + 2]);
    y[i] = std::isfinite(v) ? static_cast<float>(std::max(v, 0.0)) : 0.f;  // NaN (no signal) meters as black
  }
  // The metered mean at gain G: per-chunk sums in double over fixed chunks, added in chunk order,
  // so the result is the same for any thread count.
  constexpr int64_t kChunk = 1 << 16;
  const int64_t chunks = (n + kChunk - 1) / kChunk;
  std::vector<double> part(chunks);
  auto metered = [&](double gain) {
    const float g = static_cast<float>(gain);
#pragma omp parallel for schedule(static)
    for (int64_t c = 0; c < chunks; ++c) {
      double s = 0;
      for (int64_t i = c * kChunk, e = std::min(n, i + kChunk); i < e; ++i) s += std::min(g * y[i], 1.f);
      part[c] = s;
    }
    double s = 0;
    for (double v : part) s += v;
    return s / static_cast<double>(n);
  };
  double max_gain = ae.max_gain;
  if (ae.clip_fraction > 0) {  // highlight protection: y_(k) * G <= 1
    const size_t kth = static_cast<size_t>((1 - ae.clip_fraction) * static_cast<double>(n - 1));
    const double y_k = kth_smallest(y, std::min(kth, static_cast<size_t>(n - 1)));
    if (y_k > 0) max_gain = std::clamp(1.0 / y_k, 1.0, max_gain);
  }
  if (metered(max_gain) <= ae.target) return max_gain;  // the night case: out of the gain range
  if (metered(1.0) >= ae.target) return 1.0;
  // The metered mean rises monotonically with the gain: bisection in log gain. 48 halvings of at
  // most ln(max_gain) (60 dB: 6.9) leave 2.5e-14 relative, below the float product's rounding.
  double lo = 0, hi = std::log(max_gain);
  for (int it = 0; it < 48; ++it) {
    const double mid = 0.5 * (lo + hi);
    (metered(std::exp(mid)) < ae.target ? lo : hi) = mid;
  }
  return std::exp(0.5 * (lo + hi));
}

ImageU8 preview_srgb8_auto(const ImageF& rgb, const std::array<double, 3>& wb, double full_scale_dn,
                           const AutoExposure& ae, double* gain_out) {
  const double gain = auto_exposure_gain(rgb, wb, full_scale_dn, ae);
  if (gain_out) *gain_out = gain;
  return preview_srgb8_scaled(rgb, wb, gain / (std::min({wb[0], wb[1], wb[2]}) * full_scale_dn));
}

ImageF preview_srgb(const ImageF& rgb, const std::array<double, 3>& wb, double percentile,
                    double white_point, double min_white) {
  const size_t n = rgb.pixel_count();
  const double scale = preview_scale(rgb, wb, percentile, white_point, min_white);
  ImageF out(rgb.width(), rgb.height(), 3, uninitialized, "sRGB");
#pragma omp parallel for schedule(static)
  for (int64_t i = 0; i < static_cast<int64_t>(n); ++i)
    for (int c = 0; c < 3; ++c)
      out[3 * i + c] = static_cast<float>(srgb_encode(rgb[3 * i + c] * wb[c] * scale));
  return out;
}

// ---- camera-ISP preview (isp.h: CameraIspOptions) ----
namespace {
// Mean over the (2r+1)² window clipped at the image border (the mean over the pixels inside).
// Two separable passes of running sums in double: each row (first pass) and each column (second)
// is summed by one thread in a fixed order, so the result does not depend on the thread count.
void box_mean(const float* src, float* dst, int w, int h, int r) {
  std::vector<float> tmp(static_cast<size_t>(w) * h);
#pragma omp parallel
  {
    std::vector<double> prefix(w + 1);
#pragma omp for schedule(static)
    for (int y = 0; y < h; ++y) {
      const float* s = src + static_cast<size_t>(y) * w;
      prefix[0] = 0;
      for (int x = 0; x < w; ++x) prefix[x + 1] = prefix[x] + s[x];
      float* t = tmp.data() + static_cast<size_t>(y) * w;
      const double inv = 1.0 / (2 * r + 1);  // full windows: a multiply instead of a division
      for (int x = 0; x < w; ++x) {
        const int a = std::max(x - r, 0), b = std::min(x + r + 1, w);
        t[x] = static_cast<float>(b - a == 2 * r + 1 ? (prefix[b] - prefix[a]) * inv : (prefix[b] - prefix[a]) / (b - a));
      }
    }
  }
  constexpr int kStrip = 64;  // columns per task: each column is still summed top to bottom
  const int strips = (w + kStrip - 1) / kStrip;
#pragma omp parallel for schedule(static)
  for (int sidx = 0; sidx < strips; ++sidx) {
    const int x0 = sidx * kStrip, x1 = std::min(w, x0 + kStrip);
    double acc[kStrip] = {};
    // Window rows [y - r, y + r] ∩ [0, h): start with rows 0..r-1, then add y + r, drop y - r - 1.
    for (int y = 0; y < std::min(r, h); ++y)
      for (int x = x0; x < x1; ++x) acc[x - x0] += tmp[static_cast<size_t>(y) * w + x];
    for (int y = 0; y < h; ++y) {
      if (y + r < h)
        for (int x = x0; x < x1; ++x) acc[x - x0] += tmp[static_cast<size_t>(y + r) * w + x];
      if (y - r - 1 >= 0)
        for (int x = x0; x < x1; ++x) acc[x - x0] -= tmp[static_cast<size_t>(y - r - 1) * w + x];
      const double inv = 1.0 / (std::min(y + r + 1, h) - std::max(y - r, 0));
      for (int x = x0; x < x1; ++x) dst[static_cast<size_t>(y) * w + x] = static_cast<float>(acc[x - x0] * inv);
    }
  }
}
}  // namespace

ImageF guided_filter_self(const ImageF& p, int r, double eps) {
  if (p.channels() != 1) internal_error("guided_filter_self: one plane expected");
  const int w = p.width(), h = p.height();
  const size_t n = p.pixel_count();
  ImageF out(w, h, 1, uninitialized);
  if (r <= 0 || eps <= 0 || n == 0) {
    std::copy(p.data(), p.data() + n, out.data());
    return out;
  }
  std::vector<float> sq(n), mean(n), mean_sq(n), a(n), b(n);
  for (size_t i = 0; i < n; ++i) sq[i] = p[i] * p[i];
  box_mean(p.data(), mean.data(), w, h, r);
  box_mean(sq.data(), mean_sq.data(), w, h, r);
  // He et al. 2010, eqs. 5-6 with I = p: a = var/(var + ε), b = (1 - a)·mean.
#pragma omp parallel for schedule(static)
  for (int64_t i = 0; i < static_cast<int64_t>(n); ++i) {
    const double var = std::max(0.0, static_cast<double>(mean_sq[i]) - static_cast<double>(mean[i]) * mean[i]);
    const double ai = var / (var + eps);
    a[i] = static_cast<float>(ai);
    b[i] = static_cast<float>((1 - ai) * mean[i]);
  }
  box_mean(a.data(), mean.data(), w, h, r);
  box_mean(b.data(), mean_sq.data(), w, h, r);
#pragma omp parallel for schedule(static)
  for (int64_t i = 0; i < static_cast<int64_t>(n); ++i) out[i] = mean[i] * p[i] + mean_sq[i];
  return out;
}

void check_camera_isp_options(const CameraIspOptions& o) {
  auto bad = [](const char* name, const std::string& why) { fail_parameter(name, "", ": " + why); };
  if (!(o.denoise >= 0 && o.denoise <= 10))
    bad("preview_denoise", fmt::format("{} is not a strength in [0, 10] (0: off, 1: ε = σ²)", o.denoise));
  if (!(o.chroma_denoise >= 0 && o.chroma_denoise <= 20))
    bad("preview_chroma_denoise", fmt::format("{} is not a strength in [0, 20]", o.chroma_denoise));
  if (o.luma_radius_px < 1 || o.luma_radius_px > 16)
    bad("preview_luma_radius", fmt::format("{} px is not in [1, 16]", o.luma_radius_px));
  if (o.chroma_radius_px < 1 || o.chroma_radius_px > 16)
    bad("preview_chroma_radius", fmt::format("{} px is not in [1, 16]", o.chroma_radius_px));
  if (!(o.sharpen >= 0 && o.sharpen <= 4))
    bad("preview_sharpen", fmt::format("{} is not an unsharp-mask amount in [0, 4]", o.sharpen));
  if (o.jpeg_quality < 0 || o.jpeg_quality > 100)
    bad("preview_jpeg_quality", fmt::format("{} is not 0 (no JPEG) or a quality 1-100", o.jpeg_quality));
  if (!(o.full_scale_dn >= 0)) bad("preview_full_scale", fmt::format("{} DN is not a full scale (0: percentile exposure)", o.full_scale_dn));
  if (!(o.min_white >= 0) || !std::isfinite(o.min_white))
    bad("preview_min_white", fmt::format("{} is not a luminance floor (0: none)", o.min_white));
  if (!(o.percentile > 0 && o.percentile <= 1) || !(o.white_point > 0))
    bad("preview_percentile", fmt::format("percentile {} / white point {} out of range", o.percentile, o.white_point));
}

void check_camera_isp_frame(const CameraIspOptions& o, int width, int height) {
  check_camera_isp_options(o);
  const int limit = codec::jpeg_max_dimension();
  if (o.jpeg_quality > 0 && (width > limit || height > limit))
    fail_parameter("preview_jpeg_quality", "",
                   fmt::format(" {}: the camera ISP's JPEG round trip takes frames of at most {} px a side, this one is "
                               "{}x{} (0 skips the round trip)", o.jpeg_quality, limit, width, height));
}

ImageU8 preview_camera8(const ImageF& rgb, const std::array<double, 3>& wb, const PreviewNoise& noise,
                        const CameraIspOptions& o) {
  check_camera_isp_frame(o, rgb.width(), rgb.height());
  if (rgb.channels() != 3) internal_error("preview_camera8: 3-channel RGB expected");
  if (!(noise.gain_dn_per_e > 0) || !(noise.read_noise_e >= 0))
    fail(fmt::format("preview_camera8: noise model gain {} DN/e-, read noise {} e- out of range", noise.gain_dn_per_e,
                     noise.read_noise_e));
  const int w = rgb.width(), h = rgb.height();
  const int64_t n = static_cast<int64_t>(rgb.pixel_count());
  const double k = noise.gain_dn_per_e;
  // Read noise plus ADC quantization (1/12 DN²), in e-².
  const double var0_e = noise.read_noise_e * noise.read_noise_e + 1.0 / 12.0 / (k * k);
  const double c = var0_e + 3.0 / 8.0;
  // 1. variance stabilisation and the opponent transform.
  ImageF y(w, h, 1, uninitialized), c1(w, h, 1, uninitialized), c2(w, h, 1, uninitialized);
#pragma omp parallel for schedule(static)
  for (int64_t i = 0; i < n; ++i) {
    float t[3];
    for (int ch = 0; ch < 3; ++ch) t[ch] = static_cast<float>(2.0 * std::sqrt(std::max(rgb[3 * i + ch] / k + c, 0.0)));
    y[i] = (t[0] + t[1] + t[2]) / 3.f;
    c1[i] = (t[0] - t[2]) / 2.f;
    c2[i] = (t[0] - 2.f * t[1] + t[2]) / 4.f;
  }
  // 2. noise reduction, ε from the noise of each channel (unit noise per stabilised channel).
  const double sy = std::sqrt(3.0) / 3, sc1 = std::sqrt(2.0) / 2, sc2 = std::sqrt(6.0) / 4;
  // The three planes in parallel, one thread each: the filters' own loops then run inside this
  // region (nested, so serially) and a loaded machine pays one barrier, not one per loop. Each
  // plane's arithmetic is the same in either case.
  ImageF* planes[3] = {&y, &c1, &c2};
  const int radius[3] = {o.luma_radius_px, o.chroma_radius_px, o.chroma_radius_px};
  const double eps[3] = {std::pow(o.denoise * sy, 2), std::pow(o.chroma_denoise * sc1, 2),
                         std::pow(o.chroma_denoise * sc2, 2)};
#pragma omp parallel for schedule(dynamic, 1)
  for (int k = 0; k < 3; ++k)
    if (eps[k] > 0) *planes[k] = guided_filter_self(*planes[k], radius[k], eps[k]);
  // 3. back to DN: inverse opponent transform, algebraic inverse of the stabilisation.
  ImageF lin(w, h, 3, uninitialized);
#pragma omp parallel for schedule(static)
  for (int64_t i = 0; i < n; ++i) {
    const float t[3] = {y[i] + c1[i] + 2.f * c2[i] / 3.f, y[i] - 4.f * c2[i] / 3.f, y[i] - c1[i] + 2.f * c2[i] / 3.f};
    for (int ch = 0; ch < 3; ++ch) {
      const double half = 0.5 * t[ch];
      lin[3 * i + ch] = static_cast<float>((half * half - c) * k);
    }
  }
  // 4. white balance, exposure, sRGB, 8 bits (preview_srgb8's path).
  ImageU8 out(w, h, 3, uninitialized, "sRGB code");
  if (o.full_scale_dn > 0) {
    const double g_min = std::min({wb[0], wb[1], wb[2]});
    const float g[3] = {static_cast<float>(wb[0] / g_min / o.full_scale_dn), static_cast<float>(wb[1] / g_min / o.full_scale_dn),
                        static_cast<float>(wb[2] / g_min / o.full_scale_dn)};
    const Srgb8Levels& encode = srgb8_levels();  // 1 and above: 255 (the clip)
#pragma omp parallel for schedule(static)
    for (int64_t i = 0; i < n; ++i)
      for (int ch = 0; ch < 3; ++ch) out[3 * i + ch] = encode(lin[3 * i + ch] * g[ch]);
  } else {
    out = preview_srgb8(lin, wb, o.percentile, o.white_point, o.min_white);
  }
  // 5. sharpening and JPEG.
  if (o.sharpen > 0 || o.jpeg_quality > 0) {
    cv::Mat m(h, w, CV_8UC3, out.data());
    if (o.sharpen > 0) {
      // Unsharp mask, out = in + amount·(in - G_σ=1 ∗ in), on each channel. OpenCV's Gaussian
      // blur of 8-bit images is bit-exact (fixed-point, since OpenCV 4.0), and addWeighted rounds
      // and saturates, so the result is the same on every run and thread count.
      cv::Mat blur, sharp;
      cv::GaussianBlur(m, blur, cv::Size(5, 5), 1.0, 1.0, cv::BORDER_REPLICATE);
      cv::addWeighted(m, 1.0 + o.sharpen, blur, -o.sharpen, 0.0, sharp);
      sharp.copyTo(m);
    }
    if (o.jpeg_quality > 0) {
      // Encode and decode in memory through libjpeg-turbo with its defaults (4:2:0 chroma, the
      // islow DCT, fancy upsampling): the bytes and pixels OpenCV's imencode / imdecode gave,
      // which made this preview before (tests/codecs_test.cpp compares the two).
      const std::vector<uint8_t> jpeg = codec::encode_jpeg_rgb8(out.data(), w, h, o.jpeg_quality);
      const std::vector<uint8_t> back = codec::decode_jpeg_rgb8(jpeg, w, h);
      std::copy(back.begin(), back.end(), out.data());
    }
  }
  return out;
}

}  // namespace photosite
