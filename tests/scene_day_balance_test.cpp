// The day photo's white balance (reflectance.day_white_balance, scene/darken.cpp
// day_white_balance): a camera's cast on the day photo is taken out by the grey of its road before
// the texture keeps the photo's colours as albedos.
#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "photosite/scene/night.h"
#include "photosite/sensor/spectrum.h"
#include "scene/texture_detail.h"
#include "test_util.h"

using namespace photosite;
using namespace photosite::scene;

namespace {
struct Rnd {  // xorshift64*: a fixed pseudo-random sequence, uniform in [0, 1)
  uint64_t st = 0x2545f4914f6cdd1dull;
  double operator()() {
    st ^= st >> 12; st ^= st << 25; st ^= st >> 27;
    return static_cast<double>((st * 2685821657736338717ull) >> 11) * 0x1p-53;
  }
};
constexpr int kW = 256, kH = 128;
// A street as a camera without a cast records it (linear sRGB): a road below row kH − road_rows in
// the colour `road` (relative, G = 1; grey, or a daylight's colour) with a ±20 % texture around
// 0.2, a reddish brick façade above with its own texture. `cast` multiplies each channel, as a
// camera's white balance would.
struct Street {
  ImageF day{kW, kH, 3, 0.f};
  ImageU16 ids{kW, kH, 1, 0};
};
Street street(const std::array<double, 3>& cast, int road_rows = kH / 2,
              const std::array<double, 3>& road = {1, 1, 1}) {
  Street s;
  Rnd rnd;
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) {
      const bool on_road = y >= kH - road_rows;
      const double t = 1 + 0.2 * (2 * rnd() - 1);
      const double c[3] = {on_road ? 0.2 * t * road[0] : 0.30 * t, on_road ? 0.2 * t * road[1] : 0.18 * t,
                           on_road ? 0.2 * t * road[2] : 0.12 * t};
      for (int k = 0; k < 3; ++k) {
        const float truth = static_cast<float>(c[k]);  // the camera's float without the cast
        s.day.at(x, y, k) = static_cast<float>(truth * cast[k]);
      }
      s.ids.at(x, y) = static_cast<uint16_t>(on_road ? Label::Road : Label::Building);
    }
  return s;
}
// The road colour of the CIE daylight at T (G = 1).
std::array<double, 3> daylight_rgb(double T) {
  const auto l = daylight_log_ratios(T);
  return {std::exp(l[0]), 1.0, std::exp(l[1])};
}
// The nearest point of the locus to q by the test's own search: golden-section minimisation of
// the distance over mired on the curve, from a coarse scan (the distance is unimodal near its
// minimum), to 1e-12 mired: (distance, mired).
std::array<double, 2> nearest_by_search(const std::array<double, 2>& q) {
  auto dist = [&](double m) {
    const auto c = daylight_log_ratios(1e6 / m);
    return std::hypot(c[0] - q[0], c[1] - q[1]);
  };
  double m0 = 40;
  for (double m = 40; m <= 250; m += 0.5)
    if (dist(m) < dist(m0)) m0 = m;
  double a = std::max(40.0, m0 - 0.5), b = std::min(250.0, m0 + 0.5);
  const double r = (std::sqrt(5.0) - 1) / 2;
  while (b - a > 1e-12) {
    const double c = b - r * (b - a), d = a + r * (b - a);
    if (dist(c) < dist(d)) b = d;
    else a = c;
  }
  return {dist((a + b) / 2), (a + b) / 2};
}
// How far nearest_daylight's point may be from the curve's nearest (its Newton steps' finite
// differences, h = 1e-3 mired: O(h²) in the derivatives; checked against nearest_by_search below).
constexpr double kNearestTol = 1e-9;
ScenePreset preset(DayWhiteBalance m) {
  ScenePreset p;
  p.day_white_balance = m;
  p.sun_shade_ratio_max = 1;  // the sun/shade split off: the balance alone
  return p;
}
bool same_bits(const ImageF& a, const ImageF& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}
// The box basis' amplification of a relative error in the linear channels: for band k of a pixel
// s, Σ_j |M_kj s_j| / |Σ_j M_kj s_j| (1 where M's row is all positive).
double kappa(const float* s) {
  const auto& M = spectrum::linear_srgb_to_box();
  double w = 1;
  for (int k = 0; k < 3; ++k) {
    double v = 0, a = 0;
    for (int j = 0; j < 3; ++j) v += M[k][j] * s[j], a += std::fabs(M[k][j] * s[j]);
    w = std::max(w, a / std::fabs(v));
  }
  return w;
}
}  // namespace

// The locus: CIE D65 (6504 K) is sRGB's white, and D50 (5003 K; x 0.3457, y 0.3585) is
// (1.1761, 0.9757, 0.7217) in linear sRGB through kXyzToLinearSrgb, computed by hand from XYZ
// (0.9642, 1, 0.8249) (IEC 61966-2-1's four-decimal matrix gives (1.1761, 0.9758, 0.7216): ln
// ratios within 2.5e-4 of these). Tolerance 2e-3 in ln: the references' 4-digit chromaticities
// (±5e-5 in x and y) move ln R/G and ln B/G by up to about 1e-3.
TEST(DayWhiteBalance, DaylightLocusMatchesTheCieWhites) {
  const auto d65 = daylight_log_ratios(6504), d50 = daylight_log_ratios(5003);
  EXPECT_NEAR(d65[0], 0.0, 2e-3);
  EXPECT_NEAR(d65[1], 0.0, 2e-3);
  EXPECT_NEAR(d50[0], std::log(1.1761 / 0.9757), 2e-3);
  EXPECT_NEAR(d50[1], std::log(0.7217 / 0.9757), 2e-3);
  // The shade's light is bluer, the morning sun's redder: B/G rises and R/G falls with T.
  EXPECT_GT(daylight_log_ratios(15000)[1], d65[1]);
  EXPECT_LT(daylight_log_ratios(15000)[0], d65[0]);
  // A point on the locus is its own nearest point, with its CCT; points off it (either side of the
  // formula's seam at 7000 K, where its two pieces meet with a jump of ~5e-6 that a point exactly
  // on the seam can land on either side of; the ends; Cityscapes-like green; far magenta) are where
  // the test's own search puts them.
  const auto n = nearest_daylight(daylight_log_ratios(9000));
  EXPECT_NEAR(n[0], daylight_log_ratios(9000)[0], kNearestTol);
  EXPECT_NEAR(n[1], daylight_log_ratios(9000)[1], kNearestTol);
  EXPECT_NEAR(n[2], 9000, 9000 * 1e-6);
  for (const std::array<double, 2> q : {daylight_log_ratios(6999.5), daylight_log_ratios(7000.5),
                                         std::array<double, 2>{-0.32, -0.29}, std::array<double, 2>{0.9, -0.8},
                                         std::array<double, 2>{-0.9, 0.9}, std::array<double, 2>{0.5, 0.6},
                                         std::array<double, 2>{-0.51, 0.55}}) {
    const auto got = nearest_daylight(q);
    const auto want = nearest_by_search(q);
    EXPECT_NEAR(std::hypot(got[0] - q[0], got[1] - q[1]), want[0], kNearestTol) << q[0] << ", " << q[1];
    // 1e-4 mired: a regression guard, not a derived bound (the distance, the quantity both minimise,
    // is held to kNearestTol above; along the curve the minimum is flat, and no bound is derived here).
    EXPECT_NEAR(1e6 / got[2], want[1], 1e-4) << q[0] << ", " << q[1];
  }
}

// The locus is CIE 15:2004's formula for the chromaticity of daylight (§3.1; CIE 015:2018
// §4.1.2), written here as the standard writes it, in powers of 10³/T:
//   x_D = −4.6070 (10³/T)³ + 2.9678 (10³/T)² + 0.09911 (10³/T) + 0.244063   (4000 K to 7000 K)
//   x_D = −2.0064 (10³/T)³ + 1.9018 (10³/T)² + 0.24748 (10³/T) + 0.237040   (7000 K to 25000 K)
//   y_D = −3.000 x_D² + 2.870 x_D − 0.275
// daylight_log_ratios' (ln R/G, ln B/G) is taken back to (x, y) through the inverse of the matrix
// it used (kXyzToLinearSrgb; R, G, B ∝ M·(X, Y, Z), so X, Y, Z ∝ M⁻¹·(e^l₀, 1, e^l₁)). The two
// sides differ by rounding alone: each evaluates x and y in under 20 operations (relative error
// ≤ 20ε each, ε = 2⁻⁵³, x and y ≤ 0.42), and the way through linear sRGB and back multiplies a
// relative error by at most κ∞(M) = ‖M‖∞·‖M⁻¹‖∞ (computed below, 5.8) twice more, with
// exp, log and the sums a few ε each: |Δx|, |Δy| ≤ 100·κ∞²·ε ≈ 4e-13, under the bound 1e-12·κ∞
// taken (and under the 4-digit reference test above by 8 orders). A fourth-digit typo in a
// constant moves x by ≥ 1e-5 (0.244063 → 0.2441: 3.7e-5). CIE 15.2's worked example for D5000
// (T = 5000 K: x 0.34574, y 0.35867, to 5 decimals) checks the transcription here: within 5e-6.
TEST(DayWhiteBalance, DaylightLocusIsTheCieFormulaToRounding) {
  const auto& M = spectrum::kXyzToLinearSrgb;
  // M⁻¹ by cofactors.
  double inv[3][3];
  const double det = M[0][0] * (M[1][1] * M[2][2] - M[1][2] * M[2][1]) -
                     M[0][1] * (M[1][0] * M[2][2] - M[1][2] * M[2][0]) +
                     M[0][2] * (M[1][0] * M[2][1] - M[1][1] * M[2][0]);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      const int r0 = (j + 1) % 3, r1 = (j + 2) % 3, c0 = (i + 1) % 3, c1 = (i + 2) % 3;
      inv[i][j] = (M[r0][c0] * M[r1][c1] - M[r0][c1] * M[r1][c0]) / det;
    }
  double norm = 0, norm_inv = 0;
  for (int i = 0; i < 3; ++i) {
    double a = 0, b = 0;
    for (int j = 0; j < 3; ++j) a += std::fabs(M[i][j]), b += std::fabs(inv[i][j]);
    norm = std::max(norm, a), norm_inv = std::max(norm_inv, b);
  }
  const double kappa_inf = norm * norm_inv, tol = 1e-12 * kappa_inf;
  ASSERT_GT(kappa_inf, 1.0);
  ASSERT_LT(kappa_inf, 20.0);
  auto xy_of = [&](double T) {  // the code's locus point as CIE 1931 (x, y)
    const auto l = daylight_log_ratios(T);
    const double rgb[3] = {std::exp(l[0]), 1.0, std::exp(l[1])};
    double xyz[3];
    for (int i = 0; i < 3; ++i) xyz[i] = inv[i][0] * rgb[0] + inv[i][1] * rgb[1] + inv[i][2] * rgb[2];
    const double sum = xyz[0] + xyz[1] + xyz[2];
    return std::array<double, 2>{xyz[0] / sum, xyz[1] / sum};
  };
  auto cie = [](double T) {  // CIE 15:2004, as above
    const double u = 1e3 / T;
    const double x = T <= 7000 ? -4.6070 * u * u * u + 2.9678 * u * u + 0.09911 * u + 0.244063
                               : -2.0064 * u * u * u + 1.9018 * u * u + 0.24748 * u + 0.237040;
    return std::array<double, 2>{x, -3.000 * x * x + 2.870 * x - 0.275};
  };
  for (double T = 4000; T <= 25000; T += 25) {
    const auto got = xy_of(T), want = cie(T);
    EXPECT_NEAR(got[0], want[0], tol) << T << " K";
    EXPECT_NEAR(got[1], want[1], tol) << T << " K";
  }
  const auto d5000 = cie(5000);
  // The published 5 decimals: ±5e-6.
  EXPECT_NEAR(d5000[0], 0.34574, 5e-6);
  EXPECT_NEAR(d5000[1], 0.35867, 5e-6);
  EXPECT_NEAR(xy_of(5000)[0], 0.34574, 5e-6 + tol);
  EXPECT_NEAR(xy_of(5000)[1], 0.35867, 5e-6 + tol);
}

// A street under daylight at T0 (its road that daylight's colour) recorded by a camera with a cast
// off the locus (ln gains along the locus' normal at T0, 0.3: about the size of Cityscapes' green)
// gives, balanced by its road, the texture of the same street without the cast. Tolerance per band
// (u = 2⁻²⁴): each cast pixel is the cast-free float times the cast, rounded once (≤ u); the
// road's mean ratios carry that (≤ 2u) and the nearest point is the curve's within kNearestTol,
// so each gain is the inverse cast within e = kNearestTol + 2u (the normal by central differences
// of ±1e-6 T: its error, O(1e-12), moves the foot far less); a gain times a pixel, ≤ e + u per channel,
// becomes ≤ κ(e + u) in a box band (κ above); the class mean divided out the same; the float
// texture one more u: |Δf_k| ≤ (2κ(e + u) + u)·|f_k|, taken with a factor 2 for the double
// roundings ignored. Without the balance the cast stays: the test also checks that it would fail.
TEST(DayWhiteBalance, TakesACamerasCastOutOfTheTexture) {
  for (const double T0 : {5000.0, 6504.0, 12000.0}) {
    const auto a = daylight_log_ratios(T0 * (1 - 1e-6)), b = daylight_log_ratios(T0 * (1 + 1e-6));
    const double tx = b[0] - a[0], ty = b[1] - a[1], tn = std::hypot(tx, ty);
    const std::array<double, 2> normal{-ty / tn, tx / tn};
    const std::array<double, 3> cast{std::exp(0.3 * normal[0]), 1.0, std::exp(0.3 * normal[1])};
    const Street neutral = street({1, 1, 1}, kH / 2, daylight_rgb(T0)), cast_photo = street(cast, kH / 2, daylight_rgb(T0));
    const ImageF want = reflectance_texture(neutral.day, neutral.ids, preset(DayWhiteBalance::None));
    DayBalance bal;
    const ImageF got = reflectance_texture_with(cast_photo.day, cast_photo.ids, preset(DayWhiteBalance::Road), nullptr,
                                                nullptr, nullptr, &bal);
    const std::string at = "T0 " + std::to_string(T0);
    ASSERT_EQ(bal.state(), "road") << at;
    const double e = kNearestTol + 2 * 0x1p-24;
    EXPECT_NEAR(bal.gain[0] * cast[0], 1.0, e) << at;
    EXPECT_EQ(bal.gain[1], 1.0) << at;
    EXPECT_NEAR(bal.gain[2] * cast[2], 1.0, e) << at;
    // T0 to 1e-6 relative: a regression guard on nearest_daylight's solve, not a derived bound.
    EXPECT_NEAR(bal.road_cct_K, T0, T0 * 1e-6) << at;
    EXPECT_EQ(bal.samples, (kW / 4) * (kH / 2 / 4)) << at;  // every 4th row and column of the road
    const ImageF unbalanced = reflectance_texture(cast_photo.day, cast_photo.ids, preset(DayWhiteBalance::None));
    double worst = 0, worst_without = 0;
    for (int y = 0; y < kH; ++y)
      for (int x = 0; x < kW; ++x) {
        const double k = kappa(neutral.day.data() + 3 * (static_cast<size_t>(y) * kW + x));
        const double tol = 2 * (2 * k * (e + 0x1p-24) + 0x1p-24);
        for (int c = 0; c < 3; ++c) {
          const double w = want.at(x, y, c);
          worst = std::max(worst, std::fabs(got.at(x, y, c) - w) / (std::fabs(w) * tol + 0x1p-149));
          worst_without =
              std::max(worst_without, std::fabs(unbalanced.at(x, y, c) - w) / (std::fabs(w) * tol + 0x1p-149));
        }
      }
    EXPECT_LE(worst, 1.0) << at << ": the worst band's error in units of its bound";
    EXPECT_GT(worst_without, 1e3) << at << ": the cast must matter at this bound, or the test could not fail";
  }
}

// A road in daylight's own colour, the sun's or the blue sky's in the shade, is not a cast: its
// gains are 1 within kNearestTol and the rounding (its light's colour is the sun/shade split's to
// take out, where it splits the road).
TEST(DayWhiteBalance, KeepsTheDaylightsOwnColour) {
  for (const double T : {4500.0, 6504.0, 15000.0, 24000.0}) {
    const Street s = street({1, 1, 1}, kH / 2, daylight_rgb(T));
    const DayBalance b = day_white_balance(s.day, s.ids, preset(DayWhiteBalance::Road));
    EXPECT_EQ(b.state(), "road");
    // kNearestTol for the nearest point and two float roundings of the road's mean ratios.
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(b.gain[k], 1.0, kNearestTol + 2 * 0x1p-24) << T << " K, channel " << k;
  }
}

// Where the road cannot say what the camera did, the photo is left as it is and the state says why:
// too little road (under kDayBalanceMinSamples samples), a road too far from grey to be a cast (a
// green one), samples with a clipped or black channel left out of the mean.
TEST(DayWhiteBalance, DegradesToNoneAndSaysWhy) {
  const ScenePreset road = preset(DayWhiteBalance::Road), none = preset(DayWhiteBalance::None);
  // 4 road rows (124-127): one sampled row (124) of 64 samples.
  const Street sliver = street({0.75, 1, 0.8}, 4);
  const DayBalance b1 = day_white_balance(sliver.day, sliver.ids, road);
  EXPECT_EQ(b1.samples, 64);
  EXPECT_EQ(b1.use, DayBalance::Use::Fallback);
  EXPECT_EQ(b1.state(), "none: 64 road samples (under 100)");
  EXPECT_EQ(b1.gain, (std::array<double, 3>{1, 1, 1}));
  EXPECT_TRUE(same_bits(reflectance_texture(sliver.day, sliver.ids, road), reflectance_texture(sliver.day, sliver.ids, none)));
  // A grey road 2.5x greener than red and blue (q = (ln 0.4, ln 0.4), whose nearest daylight is
  // near white): gains spread about 2.5 > kDayBalanceMaxSpread.
  const Street red = street({0.4, 1, 0.4});
  const DayBalance b2 = day_white_balance(red.day, red.ids, road);
  EXPECT_EQ(b2.use, DayBalance::Use::Fallback);
  EXPECT_EQ(b2.state().rfind("none: the road's mean colour", 0), 0u) << b2.state();
  EXPECT_NE(b2.state().find("not a camera cast"), std::string::npos) << b2.state();
  EXPECT_EQ(b2.gain, (std::array<double, 3>{1, 1, 1}));
  EXPECT_TRUE(same_bits(reflectance_texture(red.day, red.ids, road), reflectance_texture(red.day, red.ids, none)));
  // Clipped (1) and black (0) channels: those samples are skipped, the others balance as before.
  Street clipped = street({0.75, 1, 0.8});
  long kept = 0;
  for (int y = kH / 2; y < kH; y += 4)
    for (int x = 0; x < kW; x += 4) {
      if (x % 8 == 0) clipped.day.at(x, y, 1) = 1.f;
      else if (x % 12 == 4) clipped.day.at(x, y, 2) = 0.f;
      else ++kept;
    }
  const DayBalance b3 = day_white_balance(clipped.day, clipped.ids, road);
  EXPECT_EQ(b3.samples, kept);
  EXPECT_EQ(b3.use, DayBalance::Use::Road);
  EXPECT_EQ(b3.state(), "road");
  // Every road pixel has the cast's chromaticity (a grey road times the cast), so the kept samples'
  // mean has it too: the gains of the whole road, within the rounding (2u each way).
  const DayBalance whole = day_white_balance(street({0.75, 1, 0.8}).day, clipped.ids, road);
  EXPECT_NEAR(b3.gain[0], whole.gain[0], 4 * 0x1p-24);
  EXPECT_NEAR(b3.gain[2], whole.gain[2], 4 * 0x1p-24);
  // "none" in the preset: no gains whatever the road.
  const DayBalance off = day_white_balance(clipped.day, clipped.ids, none);
  EXPECT_EQ(off.use, DayBalance::Use::Off);
  EXPECT_EQ(off.state(), "none");
}

// The chain finds the balance in the linearisation's pass (from the codes or the floats, before
// the class sums that need it), the same as day_white_balance of the linear image; the texture
// takes those sums and gives what it gives alone.
TEST(DayWhiteBalance, FoundInTheLinearisationPassAsFromTheLinearImage) {
  const Street s = street({0.75, 1, 0.8});
  // 8-bit codes of the cast photo, and their floats code/255 as read_image gives them.
  ImageU8 codes(kW, kH, 3);
  ImageF floats(kW, kH, 3);
  for (size_t i = 0; i < codes.size(); ++i) {
    const double v = s.day[i] <= 0.0031308 ? 12.92 * s.day[i] : 1.055 * std::pow(double(s.day[i]), 1 / 2.4) - 0.055;
    codes[i] = static_cast<uint8_t>(std::lround(std::clamp(v, 0.0, 1.0) * 255));
    floats[i] = codes[i] * (1.f / 255);
  }
  ImageFileInfo info;
  info.bits_per_sample = 8;
  info.srgb_encoded = true;
  for (const DayWhiteBalance m : {DayWhiteBalance::Road, DayWhiteBalance::None})
    for (const bool from_codes : {true, false}) {
      const ScenePreset p = preset(m);
      TextureSums sums;
      const ImageF lin = from_codes ? linearize_codes_with_texture_sums(codes, s.ids, &sums, &p)
                                    : linearize_with_texture_sums(floats, info, s.ids, &sums, &p);
      const DayBalance want = day_white_balance(lin, s.ids, p);
      const std::string at = std::string(day_white_balance_name(m)) + (from_codes ? " codes" : " floats");
      EXPECT_EQ(sums.balance.state(), want.state()) << at;
      EXPECT_EQ(sums.balance.gain, want.gain) << at;
      EXPECT_EQ(sums.balance.samples, want.samples) << at;
      if (m == DayWhiteBalance::Road) EXPECT_GT(want.gain[0], 1.2) << at;
      const uint64_t own = texture_own_class_sums_count();
      const ImageF with = reflectance_texture_with(lin, s.ids, p, nullptr, nullptr, &sums);
      EXPECT_EQ(texture_own_class_sums_count(), own) << at << ": the pass's sums were not taken";
      EXPECT_TRUE(same_bits(with, reflectance_texture(lin, s.ids, p))) << at;
    }
}

// From 8-bit codes the road's samples are summed on the threads, in bands of 256 rows added in
// band order (scene/darken.cpp, road_samples_sum_is_exact: every kept sample a multiple of 2^-35
// below 1, at most 2^18 of them, so each partial sum is exact and the order cannot show). Over a
// frame of several bands with a textured road, at 1 and 2 threads: the same gains, road mean and
// sample count to the bit as day_white_balance's serial sums over the linear image: each band reads
// its own rows' samples, none twice or missed (a band reading the first band's rows instead fails
// it). A frame of more than 2^18 samples is summed serially: the same there too.
TEST(DayWhiteBalance, CodesSummedOnTheThreadsGiveTheSerialSums) {
  for (const int side : {1024, 2100}) {
    ImageU8 codes(side, side, 3);
    ImageU16 ids(side, side, 1);
    Rnd rnd;
    for (int y = 0; y < side; ++y)
      for (int x = 0; x < side; ++x) {
        const bool on_road = y >= side / 3;  // the road in the lower two thirds: every band
        ids.at(x, y) = static_cast<uint16_t>(on_road ? Label::Road : Label::Building);
        const double t = 1 + 0.3 * (2 * rnd() - 1);
        const double c[3] = {0.35 * t, 0.45 * t, 0.33 * t};  // a green cast
        for (int k = 0; k < 3; ++k) codes.at(x, y, k) = static_cast<uint8_t>(std::lround(255 * c[k] * (0.9 + 0.2 * rnd())));
      }
    const ScenePreset p = preset(DayWhiteBalance::Road);
    const int before = omp_get_max_threads();
    for (const int threads : {1, 2}) {
      omp_set_num_threads(threads);
      TextureSums sums;
      const ImageF lin = linearize_codes_with_texture_sums(codes, ids, &sums, &p);
      const DayBalance want = day_white_balance(lin, ids, p);
      const std::string at = std::to_string(side) + "^2 at " + std::to_string(threads) + " threads";
      ASSERT_EQ(want.use, DayBalance::Use::Road) << at;
      EXPECT_EQ(sums.balance.samples, want.samples) << at;
      EXPECT_EQ(sums.balance.road_mean, want.road_mean) << at;
      EXPECT_EQ(sums.balance.gain, want.gain) << at;
    }
    omp_set_num_threads(before);
  }
}

// A sequence keeps the first frame's gains (ClassMeans::balance): a later frame with another cast
// is balanced as the first was, so a surface's colour does not change with the view.
TEST(DayWhiteBalance, ASequenceKeepsTheFirstFramesGains) {
  const ScenePreset p = preset(DayWhiteBalance::Road);
  ClassMeans carried;
  const Street f1 = street({0.75, 1, 0.8}), f2 = street({0.9, 1, 0.7});
  DayBalance b1, b2;
  reflectance_texture_with(f1.day, f1.ids, p, &carried, nullptr, nullptr, &b1);
  ASSERT_TRUE(carried.balance_set);
  reflectance_texture_with(f2.day, f2.ids, p, &carried, nullptr, nullptr, &b2);
  EXPECT_EQ(b2.gain, b1.gain);
  EXPECT_NE(day_white_balance(f2.day, f2.ids, p).gain, b1.gain);
}
