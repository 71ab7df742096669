#include "photosite/sensor/isp.h"

#include <algorithm>
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

ImageF preview_srgb(const ImageF& rgb, const std::array<double, 3>& wb, double percentile,
                    double white_point) {
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
  ImageF out(rgb.width(), rgb.height(), 3, uninitialized, "sRGB");
#pragma omp parallel for schedule(static)
  for (int64_t i = 0; i < static_cast<int64_t>(n); ++i)
    for (int c = 0; c < 3; ++c)
      out[3 * i + c] = static_cast<float>(srgb_encode(rgb[3 * i + c] * wb[c] * scale));
  return out;
}

}  // namespace photosite
