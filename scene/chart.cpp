// The night test chart (include/photosite/scene/chart.h).
#include "photosite/scene/chart.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include <fmt/format.h>

#include "photosite/error.h"
#include "photosite/sensor/isp.h"
#include "photosite/sensor/spectrum.h"
#include "photosite/units.h"

namespace photosite::scene {
namespace {
// ColorChecker sRGB (8-bit, D65) values as published by BabelColor (ColorChecker 2005 data).
constexpr unsigned char kPatches[24][3] = {
    {115, 82, 68},   {194, 150, 130}, {98, 122, 157},  {87, 108, 67},   {133, 128, 177}, {103, 189, 170},
    {214, 126, 44},  {80, 91, 166},   {193, 90, 99},   {94, 60, 108},   {157, 188, 64},  {224, 163, 46},
    {56, 61, 150},   {70, 148, 73},   {175, 54, 60},   {231, 199, 31},  {187, 86, 149},  {8, 133, 161},
    {243, 243, 242}, {200, 200, 200}, {160, 160, 160}, {122, 122, 121}, {85, 85, 85},    {52, 52, 52}};

void check(const ChartOptions& o) {
  if (o.width < 64 || o.width > 16384)
    fail_parameter("width", "chart size: ", fmt::format(" {} is outside [64, 16384] pixels (the chart size must be between 64x48 and 16384x16384)", o.width));
  if (o.height < 48 || o.height > 16384)
    fail_parameter("height", "chart size: ", fmt::format(" {} is outside [48, 16384] pixels (the chart size must be between 64x48 and 16384x16384)", o.height));
  if (!(o.illuminance_lux >= 0)) fail_parameter("illuminance_lux", "chart: ", fmt::format(" {} lux must be a number >= 0", o.illuminance_lux));
  if (!(o.cct_k >= 1000 && o.cct_k <= 25000))
    fail_parameter("cct_k", "chart: ", fmt::format(" {} K is outside the CCT range [1000, 25000] K", o.cct_k));
  if (!(o.lamp_cd_m2 >= 0)) fail_parameter("lamp_cd_m2", "chart: ", fmt::format(" {} cd/m2 must be a number >= 0", o.lamp_cd_m2));
  if (!(o.background_cd_m2 >= 0))
    fail_parameter("background_cd_m2", "chart: ", fmt::format(" {} cd/m2 must be a number >= 0", o.background_cd_m2));
}

// A radiance the option made must be a finite float (the EXR stores float32; Inf is not a
// radiance, and `expose` refuses it).
void check_representable(const float* px, const char* parameter, double value, const char* unit_name) {
  for (int k = 0; k < 3; ++k)
    if (!std::isfinite(px[k]))
      fail_parameter(parameter, "chart: ",
                     fmt::format(" {:g} {} gives a radiance beyond float's range ({:g} W.sr-1.m-2): not representable",
                                 value, unit_name, static_cast<double>(std::numeric_limits<float>::max())));
}
}  // namespace

const unsigned char* chart_patch_srgb8(int patch) { return kPatches[patch]; }

ChartRect chart_patch_rect(const ChartOptions& o, int p) {
  // 6 x 4 grid in the upper 70% of the frame.
  const int cw = o.width / 7, ch = static_cast<int>(o.height * 0.7) / 5, gap = cw / 8;
  const int gx = p % 6, gy = p / 6;
  const int x0 = gap + gx * (cw + gap / 2), y0 = gap + gy * (ch + gap / 2);
  return {x0, y0, std::min(x0 + cw, o.width), std::min(y0 + ch, o.height)};
}

ChartRect chart_wedge_rect(const ChartOptions& o, int s) {
  const int y0 = static_cast<int>(o.height * 0.78), y1 = static_cast<int>(o.height * 0.92);
  return {s * o.width / 20, y0, (s + 1) * o.width / 20, y1};
}

double chart_wedge_luminance_cd_m2(int s) { return std::pow(10.0, -3.0 + 5.0 * s / 19.0); }

ImageF render_chart(const ChartOptions& o) {
  check(o);
  // Illuminant colour in the box basis, normalised to unit luminance.
  const auto illum = spectrum::blackbody_rgb(o.cct_k, 1.0);
  const auto& to_box = spectrum::linear_srgb_to_box();
  // Luminance of a Lambertian white under E lux: L = E/π cd/m².
  const double white_cd_m2 = o.illuminance_lux / 3.14159265358979;
  // Box-space reflectance ρ_k = (M⁻¹·sRGB_lin)_k / (M⁻¹·1)_k, clamped at 0, so a perfect white is
  // ρ = (1,1,1); the illuminant (unit luminance) multiplies band by band, scaled to E/π cd/m².
  auto radiance_of = [&](const double srgb_lin[3], double luminance_scale, float* px) {
    for (int k = 0; k < 3; ++k) {
      double rho = 0, white = 0;
      for (int j = 0; j < 3; ++j) {
        rho += to_box[k][j] * srgb_lin[j];
        white += to_box[k][j];
      }
      px[k] = static_cast<float>(std::max(0.0, rho / white) * illum[k] * luminance_scale);
    }
  };
  // Every colour first, each checked against the option that sets it, before the frame is made.
  const auto as_float = [](const auto& v) { return std::array<float, 3>{static_cast<float>(v[0]), static_cast<float>(v[1]), static_cast<float>(v[2])}; };
  const auto bg = as_float(spectrum::blackbody_rgb(4000, o.background_cd_m2));
  check_representable(bg.data(), "background_cd_m2", o.background_cd_m2, "cd/m2");
  float patch[24][3];
  for (int p = 0; p < 24; ++p) {
    double lin[3];
    for (int j = 0; j < 3; ++j) lin[j] = srgb_decode(kPatches[p][j] / 255.0);
    radiance_of(lin, white_cd_m2, patch[p]);
    check_representable(patch[p], "illuminance_lux", o.illuminance_lux, "lux");
  }
  const double cts[2] = {2000.0, 4000.0};  // the lamp heads: sodium-like 2000 K and LED 4000 K
  std::array<float, 3> lamp[2];
  for (int l = 0; l < 2; ++l) {
    lamp[l] = as_float(spectrum::blackbody_rgb(cts[l], o.lamp_cd_m2));
    check_representable(lamp[l].data(), "lamp_cd_m2", o.lamp_cd_m2, "cd/m2");
  }
  ImageF img(o.width, o.height, 3, 0.f, unit::radiance);
  for (size_t i = 0; i < img.pixel_count(); ++i)
    for (int k = 0; k < 3; ++k) img[3 * i + k] = bg[k];
  for (int p = 0; p < 24; ++p) {
    const float* px = patch[p];
    const ChartRect r = chart_patch_rect(o, p);
    for (int y = r.y0; y < r.y1; ++y)
      for (int x = r.x0; x < r.x1; ++x)
        for (int k = 0; k < 3; ++k) img.at(x, y, k) = px[k];
  }
  for (int s = 0; s < 20; ++s) {
    const auto v = spectrum::blackbody_rgb(o.cct_k, chart_wedge_luminance_cd_m2(s));
    const ChartRect r = chart_wedge_rect(o, s);
    for (int y = r.y0; y < r.y1; ++y)
      for (int x = r.x0; x < r.x1; ++x)
        for (int k = 0; k < 3; ++k) img.at(x, y, k) = static_cast<float>(v[k]);
  }
  // The two lamp heads at the right edge, upper area.
  for (int l = 0; l < 2; ++l) {
    const auto& v = lamp[l];
    const int cx = o.width - o.width / 14, cy = o.height / 6 + l * o.height / 4, r = std::max(2, o.width / 80);
    for (int y = cy - r; y <= cy + r; ++y)
      for (int x = cx - r; x <= cx + r; ++x)
        if ((x - cx) * (x - cx) + (y - cy) * (y - cy) <= r * r)
          for (int k = 0; k < 3; ++k) img.at(x, y, k) = static_cast<float>(v[k]);
  }
  return img;
}

std::map<std::string, ExrAttribute> chart_attributes(const ChartOptions& o) {
  return {{"photosite/version", std::string(PHOTOSITE_VERSION)},
          {"photosite/content", std::string("night test chart: ColorChecker, grey wedge, lamps")},
          {"photosite/illuminance_lux", o.illuminance_lux},
          {"photosite/cct_k", o.cct_k},
          {"photosite/lamp_cd_m2", o.lamp_cd_m2},
          {"photosite/background_cd_m2", o.background_cd_m2}};
}

}  // namespace photosite::scene
