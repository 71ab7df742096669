#include "photosite/sensor/isp.h"

#include <algorithm>
#include <bit>
#include <cstdint>
#include <limits>
#include <cmath>
#include <vector>

namespace photosite {

std::array<double, 3> white_balance_gains(const CameraPreset& p) {
  LensPreset lens;
  lens.cos4_falloff = false;
  ExposureSettings s;
  s.exposure_s = 1.0;
  const PhotonMatrix m = photon_matrix(p, lens, resolve(p, lens, s));
  float planes[4];
  for (int c = 0; c < 4; ++c) planes[c] = static_cast<float>(m[c][0] + m[c][1] + m[c][2]);
  float rgb[3];
  filter_planes_to_rgb(p.cfa, planes, rgb);
  std::array<double, 3> g{};
  for (int c = 0; c < 3; ++c) g[c] = rgb[c] > 0 ? rgb[1] / rgb[c] : 1.0;
  return g;
}

double srgb_encode(double x) {
  x = std::clamp(x, 0.0, 1.0);
  return x <= 0.0031308 ? 12.92 * x : 1.055 * std::pow(x, 1.0 / 2.4) - 0.055;
}
double srgb_decode(double v) {
  return v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4);
}

namespace {
// The exposure scale of a preview: the `percentile` luminance maps to `white_point`.
double preview_scale(const ImageF& rgb, const std::array<double, 3>& wb, double percentile, double white_point) {
  const size_t n = rgb.pixel_count();
  std::vector<float> lum(n);
  for (size_t i = 0; i < n; ++i)
    lum[i] = static_cast<float>(0.2126 * wb[0] * rgb[3 * i] + 0.7152 * wb[1] * rgb[3 * i + 1] +
                                0.0722 * wb[2] * rgb[3 * i + 2]);
  double scale = 1.0;
  if (n) {
    size_t k = std::min(n - 1, static_cast<size_t>(percentile * (n - 1)));
    std::nth_element(lum.begin(), lum.begin() + k, lum.end());
    if (lum[k] > 0) scale = white_point / lum[k];
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
    lut_.resize(kBins);
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

ImageU8 preview_srgb8(const ImageF& rgb, const std::array<double, 3>& wb, double percentile, double white_point) {
  const Srgb8Levels& encode = srgb8_levels();
  const double scale = preview_scale(rgb, wb, percentile, white_point);
  const float g[3] = {static_cast<float>(wb[0] * scale), static_cast<float>(wb[1] * scale),
                      static_cast<float>(wb[2] * scale)};
  const int64_t n = static_cast<int64_t>(rgb.pixel_count());
  ImageU8 out(rgb.width(), rgb.height(), 3, uninitialized, "sRGB code");
  const float* src = rgb.data();
  uint8_t* dst = out.data();
#pragma omp parallel for schedule(static)
  for (int64_t i = 0; i < n; ++i)
    for (int c = 0; c < 3; ++c) dst[3 * i + c] = encode(src[3 * i + c] * g[c]);
  return out;
}

ImageF preview_srgb(const ImageF& rgb, const std::array<double, 3>& wb, double percentile,
                    double white_point) {
  const size_t n = rgb.pixel_count();
  const double scale = preview_scale(rgb, wb, percentile, white_point);
  ImageF out(rgb.width(), rgb.height(), 3, uninitialized, "sRGB");
#pragma omp parallel for schedule(static)
  for (int64_t i = 0; i < static_cast<int64_t>(n); ++i)
    for (int c = 0; c < 3; ++c)
      out[3 * i + c] = static_cast<float>(srgb_encode(rgb[3 * i + c] * wb[c] * scale));
  return out;
}

}  // namespace photosite
