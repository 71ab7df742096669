// The previews' auto white balance (isp.h: auto_white_balance_gains, camera_awb_bounds;
// outputs.h: PreviewWb, `night --preview-wb`).
#include <gtest/gtest.h>

#include <omp.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <random>
#include <string>

#include "photosite/error.h"
#include "photosite/outputs.h"
#include "photosite/sensor/demosaic.h"
#include "photosite/sensor/isp.h"
#include "photosite/sensor/spectrum.h"
#include "test_util.h"

namespace photosite {
namespace {

const AwbBounds kWide{{1e-3, 1, 1e-3}, {1e3, 1, 1e3}};  // no bound acts

// A grey-world scene under a coloured light: greys of reflectance 100..149 (every level equally
// often, so the scene's mean is achromatic) times the light's raw colour `cast` per channel, in
// float as a sensor frame is.
ImageF grey_scene(int w, int h, const std::array<double, 3>& cast) {
  ImageF rgb(w, h, 3);
  for (size_t i = 0; i < rgb.pixel_count(); ++i)
    for (int c = 0; c < 3; ++c) rgb[3 * i + c] = static_cast<float>((100 + i % 50) * cast[c]);
  return rgb;
}

// The camera's raw colour of a grey under a black body at T (its photon matrix on blackbody_rgb,
// the box basis) and the gains that make it neutral, green 1.
std::array<double, 3> blackbody_raw(const CameraPreset& cam, double T) {
  LensPreset lens;
  lens.cos4_falloff = false;
  ExposureSettings s;
  s.exposure_s = 1.0;
  const PhotonMatrix m = photon_matrix(cam, lens, resolve(cam, lens, s));
  const auto w = spectrum::blackbody_rgb(T, 1.0);
  float planes[4], rgb[3];
  for (int c = 0; c < 4; ++c) planes[c] = static_cast<float>(m[c][0] * w[0] + m[c][1] * w[1] + m[c][2] * w[2]);
  filter_planes_to_rgb(cam.cfa, planes, rgb);
  return {rgb[0], rgb[1], rgb[2]};
}

// Gray world on a known cast: the gains are the cast's inverse relative to green, mean_G / mean_c
// = cast_G / cast_c. Tolerance: each sample is the exact grey times the cast rounded once to float
// (2^-24 relative), so each channel's mean is within 2^-24 relative of the exact one; the double
// sums of these samples (integers up to 150 x 1.7 over 12000 pixels, far below 2^53 ulp effects:
// n u = 12000 x 2^-53) add less than 2^-39; the two means and the quotient 3 roundings of 2^-53.
// So |g / expected - 1| <= 2 x 2^-24 + 2^-39 + 3 x 2^-53 (both means' errors add in the quotient).
constexpr double kCastTolerance = 2 * 0x1p-24 + 0x1p-39 + 3 * 0x1p-53;
TEST(AutoWhiteBalance, GrayWorldUndoesAKnownCast) {
  const std::array<double, 3> cast{1.7, 1.0, 0.45};  // a warm (sodium-like) light
  ImageF rgb = grey_scene(120, 100, cast);
  const double fs = 1000;
  auto g = auto_white_balance_gains(rgb, fs, kWide, {9, 9, 9});
  EXPECT_EQ(g[1], 1.0);
  EXPECT_NEAR(g[0] / (1.0 / 1.7), 1.0, kCastTolerance) << g[0];
  EXPECT_NEAR(g[2] / (1.0 / 0.45), 1.0, kCastTolerance) << g[2];
  // Clipped and NaN pixels are not metered: one 50-pixel block in 10 gets a lamp's clipped red (R
  // at full scale, so its ratio is the clip's, not the light's), one in 10 NaN in B. Whole blocks
  // hold each grey level once, so the pixels left are still a balanced grey set: the same gains.
  for (size_t b = 0; b < rgb.pixel_count() / 50; ++b) {
    if (b % 10 == 3)
      for (size_t i = 50 * b; i < 50 * b + 50; ++i) rgb[3 * i] = static_cast<float>(fs);
    if (b % 10 == 7)
      for (size_t i = 50 * b; i < 50 * b + 50; ++i) rgb[3 * i + 2] = std::nanf("");
  }
  g = auto_white_balance_gains(rgb, fs, kWide, {9, 9, 9});
  EXPECT_NEAR(g[0] / (1.0 / 1.7), 1.0, kCastTolerance) << g[0];
  EXPECT_NEAR(g[2] / (1.0 / 0.45), 1.0, kCastTolerance) << g[2];
  // The clip level is `clip` of full scale: at 0.95 a sample of 0.96 fs is not metered, one of
  // 0.9 fs is. Frame: the grey scene with its first 50-pixel block at (0.96 fs, 0.3 fs, 0.3 fs).
  ImageF hot = grey_scene(120, 100, cast);
  for (size_t i = 0; i < 50; ++i) {
    hot[3 * i] = static_cast<float>(0.96 * fs);
    hot[3 * i + 1] = hot[3 * i + 2] = static_cast<float>(0.3 * fs);
  }
  const auto ref = auto_white_balance_gains(grey_scene(120, 100, cast), fs, kWide, {9, 9, 9});
  // Without the hot block (the same grey scene less one whole 50-level cycle: the same means).
  EXPECT_NEAR(auto_white_balance_gains(hot, fs, kWide, {9, 9, 9})[0] / ref[0], 1.0, kCastTolerance);
  // With the full scale at fs / 0.9 the block (0.96 fs < 0.95 fs / 0.9) is metered: redder.
  // (mean R 211.6 -> 214.7, G 124.5 -> 125.2 DN: the gain 0.9916 of ref, far beyond the tolerance).
  EXPECT_LT(auto_white_balance_gains(hot, fs / 0.9, kWide, {9, 9, 9})[0], 0.995 * ref[0]);
}

// The bound: gains outside `bounds` are held at its edges, per channel; camera_awb_bounds is the
// camera's own black-body gains from 2000 to 10000 K, so a 1500 K light is corrected only as far
// as a 2000 K one, and the preset's fixed gains (an equal-energy white, ~5500 K) lie inside.
TEST(AutoWhiteBalance, GainsAreBoundedToTheCamerasBlackBodyRange) {
  const ImageF warm = grey_scene(100, 50, {1.7, 1.0, 0.45});  // gains 0.588, 2.22
  const AwbBounds narrow{{0.8, 1, 0.5}, {1.25, 1, 2.0}};
  const auto g = auto_white_balance_gains(warm, 1000, narrow, {9, 9, 9});
  EXPECT_EQ(g[0], 0.8);
  EXPECT_EQ(g[1], 1.0);
  EXPECT_EQ(g[2], 2.0);
  const CameraPreset cam = load_camera_preset("onsemi-ar0331");
  const AwbBounds b = camera_awb_bounds(cam);
  const auto fixed = white_balance_gains(cam);
  for (int c : {0, 2}) {
    EXPECT_LT(b.lo[c], fixed[c]) << c;
    EXPECT_GT(b.hi[c], fixed[c]) << c;
  }
  EXPECT_EQ(b.lo[1], 1.0);
  EXPECT_EQ(b.hi[1], 1.0);
  // The range's ends are the black bodies at 2000 K (least red gain, most blue gain) and 10000 K.
  // Tolerance: the same float arithmetic on both sides (sampled at exactly 1e6 / (1e6 / T)), which
  // may differ from T by one double rounding: far below float's 2^-24, so 2^-23 relative.
  const auto r2000 = blackbody_raw(cam, 2000), r10000 = blackbody_raw(cam, 10000);
  EXPECT_NEAR(b.lo[0] / (r2000[1] / r2000[0]), 1.0, 0x1p-23);
  EXPECT_NEAR(b.hi[2] / (r2000[1] / r2000[2]), 1.0, 0x1p-23);
  EXPECT_NEAR(b.hi[0] / (r10000[1] / r10000[0]), 1.0, 0x1p-23);
  EXPECT_NEAR(b.lo[2] / (r10000[1] / r10000[2]), 1.0, 0x1p-23);
  // A grey scene under a 1500 K black body, as the camera records it: corrected to 2000 K's gains.
  const auto r1500 = blackbody_raw(cam, 1500);
  const std::array<double, 3> cast{r1500[0] / r1500[1], 1.0, r1500[2] / r1500[1]};
  const auto h = auto_white_balance_gains(grey_scene(100, 50, cast), 1000, b, fixed);
  EXPECT_EQ(h[0], b.lo[0]);
  EXPECT_EQ(h[2], b.hi[2]);
  // And one under 3000 K, inside the range: corrected fully (kCastTolerance as above).
  const auto r3000 = blackbody_raw(cam, 3000);
  const auto k = auto_white_balance_gains(grey_scene(100, 50, {r3000[0] / r3000[1], 1.0, r3000[2] / r3000[1]}), 1000, b, fixed);
  EXPECT_NEAR(k[0] / (r3000[1] / r3000[0]), 1.0, kCastTolerance);
  EXPECT_NEAR(k[2] / (r3000[1] / r3000[2]), 1.0, kCastTolerance);
}

// Frames with nothing to meter keep the preset's gains (`fallback`): black, clipped everywhere,
// NaN everywhere, and zero-mean read noise alone (its means are within a few standard errors of 0).
TEST(AutoWhiteBalance, DegenerateFramesKeepTheFixedGains) {
  const std::array<double, 3> fixed{1.9, 1.0, 1.6};
  const double fs = 3780;
  EXPECT_EQ(auto_white_balance_gains(ImageF(64, 32, 3, 0.f), fs, kWide, fixed), fixed);
  EXPECT_EQ(auto_white_balance_gains(ImageF(64, 32, 3, static_cast<float>(fs)), fs, kWide, fixed), fixed);
  EXPECT_EQ(auto_white_balance_gains(ImageF(64, 32, 3, std::nanf("")), fs, kWide, fixed), fixed);
  EXPECT_EQ(auto_white_balance_gains(ImageF(0, 0, 3), fs, kWide, fixed), fixed);
  // Read noise, σ = 1.26 DN (DN above black, not clipped at black), in 3 channels, drawn as
  // pairs +z, -z in neighbouring pixels so each channel's sample mean is exactly its offset: 0.002
  // DN in every channel, above 0 but below 3 standard errors (3 x 1.26 / sqrt(32768) = 0.021 DN).
  // Noise, not a light: the fixed gains (a mean > 0 test alone would meter it).
  ImageF noise(256, 128, 3);
  std::mt19937 rng(11);
  std::normal_distribution<float> n(0.f, 1.26f);
  for (size_t px = 0; px < noise.pixel_count(); px += 2)
    for (int c = 0; c < 3; ++c) {
      const float z = n(rng);
      noise[3 * px + c] = 0.002f + z;
      noise[3 * px + 3 + c] = 0.002f - z;
    }
  EXPECT_EQ(auto_white_balance_gains(noise, fs, kWide, fixed), fixed);
  // The same noise on a dim grey light (mean 20 DN in each channel, a real signal): metered.
  for (size_t i = 0; i < noise.size(); ++i) noise[i] += 20.f;
  const auto g = auto_white_balance_gains(noise, fs, kWide, fixed);
  EXPECT_NE(g, fixed);
  // Its gains are 1 to float rounding, not merely within the noise: each channel's pairs +z, -z
  // cancel, so its sample mean is 20.002 up to the roundings of 0.002 + z and of + 20, at most
  // 2^-24 of |v - 20| and of |v| per pixel (v the stored value); a ratio of two such means is 1
  // within twice their mean over 20, plus the double sums' 2^-53 per addition. (The bound this
  // replaces, 1.5e-3, was 3 standard errors of independent means, which these are not.)
  double abs_mean = 0;
  for (float v : noise.vec()) abs_mean += (std::fabs(v) + std::fabs(v - 20.0)) / static_cast<double>(noise.size());
  const double rounding = 2 * 0x1p-24 * abs_mean / 20 + static_cast<double>(noise.pixel_count()) * 0x1p-53;
  EXPECT_NEAR(g[0], 1.0, rounding);
  EXPECT_NEAR(g[2], 1.0, rounding);
  // Bad settings are refused, naming the parameter.
  auto parameter_of = [&](double full_scale, const AwbBounds& b, double clip) -> std::string {
    try {
      auto_white_balance_gains(ImageF(4, 4, 3, 1.f), full_scale, b, fixed, clip);
    } catch (const ParameterError& e) {
      return e.parameter();
    }
    return "";
  };
  EXPECT_EQ(parameter_of(0, kWide, 0.95), "full_scale_dn");
  EXPECT_EQ(parameter_of(fs, kWide, 1.5), "awb_clip");
  EXPECT_EQ(parameter_of(fs, AwbBounds{{2, 1, 1}, {1, 1, 1}}, 0.95), "awb_bounds");
  EXPECT_EQ(parameter_of(fs, kWide, 0.95), "");
}

TEST(AutoWhiteBalance, DeterministicForAnyThreadCount) {
  std::mt19937 rng(5);
  std::exponential_distribution<float> e(1.0f / 40);
  ImageF rgb(641, 409, 3);  // 262169 pixels: 5 chunks of 65536, the last a partial one
  for (size_t i = 0; i < rgb.size(); ++i) rgb[i] = std::min(e(rng) * (i % 3 == 0 ? 1.5f : 1.f), 1000.f);
  const int before = omp_get_max_threads();
  std::vector<std::array<double, 3>> g;
  for (int t : {1, 2, 3}) {
    omp_set_num_threads(t);
    g.push_back(auto_white_balance_gains(rgb, 1000, kWide, {1, 1, 1}));
  }
  omp_set_num_threads(before);
  EXPECT_NE(g[0][0], 1.0);
  EXPECT_EQ(g[0], g[1]);
  EXPECT_EQ(g[0], g[2]);
}

// The flag: bad values exit 2 naming it, before any output; it needs --preview.
TEST(AutoWhiteBalance, CommandLineRefusesBadValues) {
  test::TempDir tmp;
  test::expect_preview_flag_refused(
      tmp, {{"night --out '{o}' --preview '{p}' --preview-wb grey", "--preview-wb: 'grey' is not fixed or auto"},
           {"night --out '{o}' --preview-wb auto", "--preview-wb auto: no preview is written"},
           {"expose --preset onsemi-ar0331 --radiance '{r}' --out '{o}' --preview '{p}' --preview-wb Auto",
            "--preview-wb: 'Auto' is not fixed or auto"}});
}

}  // namespace
}  // namespace photosite
