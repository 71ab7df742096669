// The thesis baseline (photosite::thesis_night, Baek 2020 Chapter 3) and `photosite bench realism`.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <cmath>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <omp.h>

#include <random>

#include "photosite/error.h"
#include "photosite/io.h"
#include "photosite/outputs.h"
#include "photosite/rng.h"
#include "photosite/scene/labels.h"
#include "photosite/sensor/isp.h"
#include "photosite/thesis_baseline.h"
#include "test_util.h"

namespace photosite {
namespace {
using scene::Label;

// A W x H scene of vertical stripes, one class per stripe, every stripe the same day colour.
struct Stripes {
  ImageU8 day;
  ImageU16 labels;
};
Stripes stripes(const std::vector<Label>& classes, int stripe_w, int h, std::array<uint8_t, 3> rgb) {
  const int W = stripe_w * static_cast<int>(classes.size());
  Stripes s{ImageU8(W, h, 3), ImageU16(W, h, 1)};
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < W; ++x) {
      s.labels.at(x, y) = static_cast<uint16_t>(classes[x / stripe_w]);
      for (int k = 0; k < 3; ++k) s.day.at(x, y, k) = rgb[k];
    }
  return s;
}

TEST(ThesisBaseline, ReflectancesAreTable1) {
  // Table 1 of the thesis (p. 11); classes it does not name get the 'unlabeled' mean (p. 12).
  EXPECT_EQ(thesis_reflectance(static_cast<int>(Label::TrafficSign)), 0.7);
  EXPECT_EQ(thesis_reflectance(static_cast<int>(Label::TrafficLight)), 0.7);
  EXPECT_EQ(thesis_reflectance(static_cast<int>(Label::Building)), 0.3);
  EXPECT_EQ(thesis_reflectance(static_cast<int>(Label::Tunnel)), 0.3);
  EXPECT_EQ(thesis_reflectance(static_cast<int>(Label::Person)), 0.25);
  EXPECT_EQ(thesis_reflectance(static_cast<int>(Label::Terrain)), 0.2);
  EXPECT_EQ(thesis_reflectance(static_cast<int>(Label::Bicycle)), 0.2);
  EXPECT_EQ(thesis_reflectance(static_cast<int>(Label::Sky)), 0.1);
  EXPECT_EQ(thesis_reflectance(static_cast<int>(Label::Parking)), 0.1);
  const double mean = (0.7 + 0.3 + 0.25 + 0.2 + 0.2 + 0.1 + 0.1) / 7;
  EXPECT_DOUBLE_EQ(thesis_reflectance(static_cast<int>(Label::Unlabeled)), mean);
  EXPECT_DOUBLE_EQ(thesis_reflectance(static_cast<int>(Label::Sidewalk)), mean);
  EXPECT_DOUBLE_EQ(thesis_reflectance(static_cast<int>(Label::Pole)), mean);
}

// §3.1: V (the largest of R, G, B) is scaled by the class reflectance; hue and saturation stay.
// Tolerance of V: half an 8-bit code, the rounding of V·ρ to its code (std::lround), and the float
// product V·ρ_f with ρ rounded to float (2⁻²⁴ relative each); OpenCV's 8-bit HSV→RGB gives the
// largest channel V' itself (its float V'/255·255 rounds back to V').
TEST(ThesisBaseline, DarkenScalesValueByClassReflectance) {
  const std::vector<Label> cls = {Label::TrafficSign, Label::Building, Label::Person, Label::Car,
                                  Label::Sky, Label::Road, Label::Sidewalk};
  const std::array<uint8_t, 3> day = {200, 150, 100};
  const Stripes s = stripes(cls, 8, 4, day);
  const ImageU8 out = thesis_darken(s.day, s.labels);
  for (size_t c = 0; c < cls.size(); ++c) {
    const int x = static_cast<int>(c) * 8 + 3;
    const double rho = thesis_reflectance(static_cast<int>(cls[c]));
    const int r = out.at(x, 1, 0), g = out.at(x, 1, 1), b = out.at(x, 1, 2);
    // Half a code for the 8-bit rounding plus two float roundings (2^-24 relative each) of 200·ρ.
    EXPECT_NEAR(std::max({r, g, b}), 200 * rho, 0.5 + 2 * 200 * rho * 0x1p-24) << scene::label_name(static_cast<int>(cls[c]));
    // The order of the channels (the hue) is kept: R > G > B as in the day colour.
    EXPECT_GE(r, g);
    EXPECT_GE(g, b);
    // Saturation (max-min)/max of the day colour is 0.5; 8-bit rounding of three codes near V·ρ
    // (V·ρ >= 20 here) moves it by at most 2/20.
    EXPECT_NEAR(static_cast<double>(r - b) / std::max(r, 1), 0.5, 2.0 / (200 * rho));
  }
}

TEST(ThesisBaseline, LightsOnlyAddAndSpritesLandOnBuildings) {
  // Left half building, right half plain road (flat colour: no lane markings, no signs, no
  // vehicles): the night image equals the darkened one on the road far from the building, and is
  // at least the darkened one everywhere (the light map is added).
  const Stripes s = stripes({Label::Building, Label::Road}, 200, 120, {120, 120, 120});
  ThesisBaselineOptions o;
  o.bloom_levels = 0;  // no bloom: sprite glow stays within 3σ of the building
  const ImageU8 dark = thesis_darken(s.day, s.labels, o);
  const ImageU8 night = thesis_night(s.day, s.labels, o);
  const int reach = static_cast<int>(std::ceil(3 * o.sprite_sigma_fraction * 400)) + 1;
  int64_t added_building = 0;
  for (int y = 0; y < 120; ++y)
    for (int x = 0; x < 400; ++x)
      for (int k = 0; k < 3; ++k) {
        ASSERT_GE(night.at(x, y, k), dark.at(x, y, k));
        if (x >= 200 + reach) ASSERT_EQ(night.at(x, y, k), dark.at(x, y, k)) << x << "," << y;
        if (x < 200) added_building += night.at(x, y, k) - dark.at(x, y, k);
      }
  // 150 sprites per building megapixel on 200x120 px: round(3.6) = 4 sprites, each a Gaussian of
  // σ = 1.2 px and peak colour (255,180,107) centred on a building pixel (core/thesis_baseline.cpp),
  // where it adds its whole colour before the 8-bit clip: at least one centre pixel's
  // Σ_k min(255 − dark_k, colour_k), less half a code of rounding per channel, whatever the
  // other sprites and their overlaps add (the light only adds).
  int dark_max[3] = {0, 0, 0};
  for (int y = 0; y < 120; ++y)
    for (int x = 0; x < 200; ++x)
      for (int k = 0; k < 3; ++k) dark_max[k] = std::max(dark_max[k], static_cast<int>(dark.at(x, y, k)));
  const int colour[3] = {255, 180, 107};
  double one_centre = -1.5;
  for (int k = 0; k < 3; ++k) one_centre += std::min(255 - dark_max[k], colour[k]);
  EXPECT_GE(added_building, one_centre);
}

TEST(ThesisBaseline, DeterministicAndKeyedBySeed) {
  const Stripes s = stripes({Label::Building, Label::Car, Label::Road}, 300, 200, {90, 110, 130});
  ThesisBaselineOptions o;
  const ImageU8 a = thesis_night(s.day, s.labels, o), b = thesis_night(s.day, s.labels, o);
  EXPECT_TRUE(a.vec() == b.vec());
  o.seed = 7;
  const ImageU8 c = thesis_night(s.day, s.labels, o);
  EXPECT_FALSE(a.vec() == c.vec()) << "another seed should splat the sprites elsewhere";
}

TEST(ThesisBaseline, RedVehiclePixelsBecomeLights) {
  // A saturated red on a car (a tail lamp by the thesis's colour rule) keeps its day value; the
  // same red on a building is only darkened.
  Stripes s = stripes({Label::Car, Label::Wall}, 40, 40, {220, 30, 30});
  ThesisBaselineOptions o;
  o.bloom_levels = 0;
  const ImageU8 night = thesis_night(s.day, s.labels, o);
  EXPECT_EQ(night.at(20, 20, 0), 255);  // darkened 44 + the day 220, clipped
  // Half a code and float rounding, as in DarkenScalesValueByClassReflectance.
  EXPECT_NEAR(night.at(60, 20, 0), 220 * 0.3, 0.5 + 2 * 220 * 0.3 * 0x1p-24);
}

TEST(ThesisBaseline, RefusesMismatchedInputs) {
  const Stripes s = stripes({Label::Road}, 10, 10, {1, 2, 3});
  EXPECT_THROW(thesis_night(s.day, ImageU16(9, 10, 1)), Error);
  EXPECT_THROW(thesis_night(ImageU8(10, 10, 1), s.labels), Error);
  ImageU16 bad = s.labels;
  bad[5] = 40;
  EXPECT_THROW(thesis_night(s.day, bad), Error);
}

// ---- the camera-ISP preview (isp.h: preview_camera8) ----

// A plane of independent Gaussian noise (σ 1) on a step from `lo` to `hi` at the middle column.
ImageF noisy_step(int w, int h, float lo, float hi, uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<float> n(0.f, 1.f);
  ImageF p(w, h, 1);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) p.at(x, y) = (x < w / 2 ? lo : hi) + n(rng);
  return p;
}

TEST(CameraIsp, GuidedFilterLimits) {
  const ImageF p = noisy_step(37, 23, 0.f, 5.f, 1);
  // ε → ∞: a = 0, b = box mean, output = the box mean of the box mean (He et al. eq. 8, a = 0).
  // ε → 0 with var > 0: a = 1, b = 0, output = the box mean of 1 times p = p. Brute force here.
  const int r = 2;
  auto box = [&](const ImageF& im, int x, int y) {
    double s = 0;
    int n = 0;
    for (int yy = std::max(0, y - r); yy <= std::min(im.height() - 1, y + r); ++yy)
      for (int xx = std::max(0, x - r); xx <= std::min(im.width() - 1, x + r); ++xx) s += im.at(xx, yy), ++n;
    return s / n;
  };
  ImageF m(p.width(), p.height(), 1);
  for (int y = 0; y < p.height(); ++y)
    for (int x = 0; x < p.width(); ++x) m.at(x, y) = static_cast<float>(box(p, x, y));
  const double eps_big = 1e30, eps_small = 1e-12;
  const ImageF big = guided_filter_self(p, r, eps_big), small = guided_filter_self(p, r, eps_small);
  // Bounds (u = 2⁻²⁴; M = max |p|, which bounds every box mean of p and of b; box_mean sums in
  // double (prefix sums up to w·M over w additions, running column sums: at most 4·(w² + h²)·2⁻⁵³·M
  // over two box means, added) and stores each of its two passes to float).
  // ε → ∞: out = mean(a)·p + mean(b), b = mean of p (1 − a rounds to 1 in double), a ≤ var/ε ≤ M²/ε.
  // mean(b) is box(box(p)) through 4 float stores (2 per box_mean), the multiply-add 1 more, the
  // reference box(m) one (m stored to float): 6 half-ulps, 3·u·M, plus |mean(a)·p| ≤ M³/ε.
  // ε → 0: a = var/(var + ε) ≥ 1 − ε/var_min; var_min (the smallest window variance, here in
  // double; the library's, from float means, is within 2·u·M² of it: var_lo is var_min less 4·u·M²)
  // ≫ ε, so a stores as 1 up to ε/var_lo + u/2 and its box mean as well (a box mean of values within
  // δ of 1 is within δ + u of 1); |b| = (1 − a)·|mean| ≤ (ε/var_lo)·M. out − p: (1 − mean a)·M + |mean b|
  // + the multiply-add's half ulp: (2·ε/var_lo + 2·u)·M.
  const double u = 0x1p-24;
  double M = 0, var_min = INFINITY;
  for (int y = 0; y < p.height(); ++y)
    for (int x = 0; x < p.width(); ++x) {
      M = std::max(M, static_cast<double>(std::fabs(p.at(x, y))));
      double s = 0, s2 = 0;
      int n = 0;
      for (int yy = std::max(0, y - r); yy <= std::min(p.height() - 1, y + r); ++yy)
        for (int xx = std::max(0, x - r); xx <= std::min(p.width() - 1, x + r); ++xx)
          s += p.at(xx, yy), s2 += double(p.at(xx, yy)) * p.at(xx, yy), ++n;
      var_min = std::min(var_min, s2 / n - (s / n) * (s / n));
    }
  const double var_lo = var_min - 4 * u * M * M;
  ASSERT_GT(var_lo, 1e6 * eps_small);  // the premise: a rounds to 1
  const double dbl = 4.0 * (p.width() * p.width() + p.height() * p.height()) * 0x1p-53 * M;
  const double tol_big = 3 * u * M + M * M * M / eps_big + dbl;
  const double tol_small = (2 * eps_small / var_lo + 2 * u) * M + dbl;
  for (int y = 0; y < p.height(); ++y)
    for (int x = 0; x < p.width(); ++x) {
      EXPECT_NEAR(big.at(x, y), box(m, x, y), tol_big) << x << "," << y;
      EXPECT_NEAR(small.at(x, y), p.at(x, y), tol_small) << x << "," << y;
    }
}

TEST(CameraIsp, GuidedFilterSmoothsNoiseAndKeepsAStep) {
  // A step of 40σ with ε = σ²: in flat parts the local variance is ~σ², a ≈ 1/2 and the noise
  // falls; at the step the variance is ~(40σ)²/4 ≫ ε, a ≈ 1, the step stays.
  const ImageF p = noisy_step(200, 200, 0.f, 40.f, 2);
  const ImageF q = guided_filter_self(p, 2, 1.0);
  auto stats = [](const ImageF& im, int x0, int x1) {
    double s = 0, s2 = 0;
    int n = 0;
    for (int y = 0; y < im.height(); ++y)
      for (int x = x0; x < x1; ++x) s += im.at(x, y), s2 += im.at(x, y) * im.at(x, y), ++n;
    const double mean = s / n;
    return std::pair{mean, std::sqrt(s2 / n - mean * mean)};
  };
  const auto [m_in, sd_in] = stats(p, 10, 90);
  const auto [m_out, sd_out] = stats(q, 10, 90);
  EXPECT_NEAR(sd_in, 1.0, 5 * 1.0 / std::sqrt(2.0 * 16000));  // 5 SE of a sample σ over 16000 px
  // At most half the noise left: a ≤ 1/2 on average plus the box mean's 1/5 (a 5x5 window).
  EXPECT_LT(sd_out, 0.6 * sd_in);
  EXPECT_NEAR(m_out, m_in, 5 / std::sqrt(16000.0));  // the mean kept (5 SE of the mean: 5/sqrt(16000) = 0.04)
  // The step: the columns just beside the edge keep their side's level. With Ā the mean of a
  // over the 25 windows (5x5, r = 2) that cover a pixel and b_c = (1 - a_c)·μ_c, for any level L
  //   q - L = Ā·(p - L) + mean_c (1 - a_c)(μ_c - L),   0 ≤ a_c = var_c/(var_c + ε) < 1,
  // so |q - L| ≤ |p - L| + mean_c ε|μ_c - L|/(var_c + ε). At x = 99 (L = 0, the low side) the
  // windows' centre columns are 97..101, holding k = 0..4 of the high columns; at x = 100
  // (L = 40) mirrored. Premises, checked on this input: every pixel of columns 95..104 within
  // 5σ of its level, and every window mean μ_c within 5 SE of a 25-pixel mean (5/√25 = 1) of its
  // noise-free 40k/5. Then a flat window (k = 0) adds at most |μ_c - L| ≤ 1, and a mixed one
  // (k high of 5, f = k/5) has |μ_c - L| ≤ 40f + 1 over a population variance of at least its
  // two groups' f(1 - f)(40 - 2·5)² (the groups' means are ≥ 30 apart). A box mean (a = 0)
  // would leave 16 at x = 99. Float rounding (u = 2⁻²⁴): var from mean_sq and mean² stored as
  // floats, ≤ 6u·45² absolute, which moves a by ≤ ε·6u·45²/(var + ε)² and b by |μ| ≤ 1 times
  // that in the flat window (the mixed ones' (var + ε)² ≥ 145² make it negligible, bounded by
  // the same term times 45/145²); a and b stored (u each), their box means (2u), q's product
  // and sum (2u): 8u·45 on a level of at most 45.
  const double eps = 1.0, dev = 5.0, mean_dev = 5.0 / 5.0, gap = 40.0 - 2 * dev;
  for (int y = 1; y < 199; ++y)  // the rows of the windows that cover rows 5..194
    for (int x = 95; x < 105; ++x) ASSERT_LE(std::fabs(p.at(x, y) - (x < 100 ? 0.0 : 40.0)), dev) << x << "," << y;
  for (int y = 3; y < 197; ++y)  // the windows' centre rows
    for (int c = 97; c <= 102; ++c) {
      double s = 0;
      for (int yy = y - 2; yy <= y + 2; ++yy)
        for (int xx = c - 2; xx <= c + 2; ++xx) s += p.at(xx, yy);
      ASSERT_LE(std::fabs(s / 25 - 40.0 * std::clamp(c + 3 - 100, 0, 5) / 5), mean_dev) << c << "," << y;
    }
  double windows = mean_dev;  // the flat window (k = 0)
  for (int k = 1; k <= 4; ++k) {
    const double f = k / 5.0;
    windows += eps * (40 * f + mean_dev) / (f * (1 - f) * gap * gap + eps);
  }
  windows /= 5;
  const double u = 0x1p-24;
  const double rounding = 6 * u * 45 * 45 * (1 + 45 / (145.0 * 145)) + 8 * u * 45;
  for (int y = 5; y < 195; ++y) {
    EXPECT_LE(std::fabs(q.at(99, y) - 0.0), std::fabs(p.at(99, y) - 0.0) + windows + rounding) << y;
    EXPECT_LE(std::fabs(q.at(100, y) - 40.0), std::fabs(p.at(100, y) - 40.0) + windows + rounding) << y;
  }
}

// A flat field in DN above black with Poisson-Gaussian noise (K DN/e-, read noise in e-).
ImageF flat_dn(int w, int h, double electrons, double k, double read_e, uint32_t seed) {
  std::mt19937 rng(seed);
  std::poisson_distribution<int> shot(electrons);
  std::normal_distribution<double> read(0, read_e);
  ImageF rgb(w, h, 3);
  for (size_t i = 0; i < rgb.size(); ++i) rgb[i] = static_cast<float>((shot(rng) + read(rng)) * k);
  return rgb;
}

TEST(CameraIsp, NoiseReductionFromTheNoiseModel) {
  const double k = 0.25, read_e = 3;
  const ImageF rgb = flat_dn(256, 128, 40, k, read_e, 3);
  ImageF bright = rgb;
  for (size_t i = 0; i < 3 * 200; ++i) bright[i] = 400.f;  // 200 px (0.6 %) of lamp at 40x the field
  const std::array<double, 3> wb{1, 1, 1};
  CameraIspOptions off;
  off.denoise = off.chroma_denoise = 0;
  off.jpeg_quality = 0;
  const ImageU8 plain = preview_camera8(bright, wb, {k, read_e}, off);
  // Without noise reduction, sharpening or JPEG the camera ISP is the simple one: the
  // stabilisation and its inverse round-trip to float rounding, which moves a sample across an
  // 8-bit decision level only when it lies that close to it. The round trip (sensor/isp.cpp,
  // u = 2⁻²⁴, T the pixel's largest stabilised value t = 2√(x/K + c)): t's rounding (u·T), the
  // opponent transform's sums and quotient (y: 8/3 u·T; c1, c2 of near-equal values: ≤ u·T/4)
  // and its inverse's two sums (2u·T) leave each t within 6u·T, so x = K((t/2)² − c) within
  // 3u·K·T² = 12u·(x_max + cK), and lin's float rounding adds u·|x|. The white (the 99th
  // percentile of luminance) moves by that bound at its own level (a monotone perturbation moves
  // an order statistic by the perturbation there), and the encoder's product by the gain rounds
  // each side once more (u·v). A sample at linear level v moves by Δv, i.e. 255·srgb'(v)·Δv codes,
  // and differs only if a decision level lies in between: for a level position uniform over the
  // code, with probability min(1, that). The count of differing samples, a sum of independent
  // Bernoulli trials, stays below E + 5√E + 1 (5σ of a Poisson-binomial, variance ≤ E), E the
  // sum of those probabilities; a difference is at most one code.
  const ImageU8 simple = preview_srgb8(bright, wb);
  int differ = 0, max_diff = 0;
  for (size_t i = 0; i < plain.size(); ++i) {
    const int d = std::abs(int(plain[i]) - int(simple[i]));
    differ += d != 0;
    max_diff = std::max(max_diff, d);
  }
  const double u = 0x1p-24, var0 = read_e * read_e + 1.0 / 12.0 / (k * k), cK = (var0 + 3.0 / 8.0) * k;
  const size_t npx = bright.pixel_count();
  std::vector<float> lum(npx);
  std::vector<double> x_max(npx);
  for (size_t i = 0; i < npx; ++i) {
    lum[i] = static_cast<float>(0.2126 * bright[3 * i] + 0.7152 * bright[3 * i + 1] + 0.0722 * bright[3 * i + 2]);
    x_max[i] = std::max({std::fabs(bright[3 * i]), std::fabs(bright[3 * i + 1]), std::fabs(bright[3 * i + 2])});
  }
  std::vector<float> sorted = lum;
  const size_t kth = static_cast<size_t>(0.99 * static_cast<double>(npx - 1));
  std::nth_element(sorted.begin(), sorted.begin() + kth, sorted.end());
  const double white = sorted[kth], d_white = (12 * u * (white + cK) + 2 * u * white) / white;
  double expected = 0;
  for (size_t i = 0; i < plain.size(); ++i) {
    const double x = bright[i], v = x / white;
    const double dv = (12 * u * (x_max[i / 3] + cK) + u * std::fabs(x)) / white + std::fabs(v) * (d_white + 2 * u);
    if (v - dv >= 1 || v + dv <= 0) continue;  // 255 or 0 on both sides
    const double lo = std::max(v - dv, 0.0);
    const double slope = lo <= 0.0031308 ? 12.92 : 1.055 / 2.4 * std::pow(lo, 1 / 2.4 - 1);  // srgb' falls with v
    expected += std::min(1.0, 255 * slope * dv);
  }
  std::printf("camera ISP without NR: %d of %zu codes differ from the simple ISP's (bound %.1f)\n", differ, plain.size(),
              expected + 5 * std::sqrt(expected) + 1);
  EXPECT_LE(max_diff, 1);
  EXPECT_LE(differ, expected + 5 * std::sqrt(expected) + 1);
  CameraIspOptions on = off;
  on.denoise = 1;
  on.chroma_denoise = 2;
  const ImageU8 nr = preview_camera8(bright, wb, {k, read_e}, on);
  auto sd = [](const ImageU8& im) {
    double s = 0, s2 = 0;
    int n = 0;
    for (int y = 8; y < im.height(); ++y)  // below the bright rows
      for (int x = 0; x < im.width(); ++x)
        for (int c = 0; c < 3; ++c) s += im.at(x, y, c), s2 += double(im.at(x, y, c)) * im.at(x, y, c), ++n;
    return std::sqrt(s2 / n - (s / n) * (s / n));
  };
  // ε = σ² in the stabilised domain leaves at most ~0.6 of the noise (GuidedFilterSmoothsNoise...).
  EXPECT_LT(sd(nr), 0.6 * sd(plain)) << sd(nr) << " vs " << sd(plain);
  EXPECT_GT(sd(plain), 2.0);  // the test has noise to remove: several codes
}

TEST(CameraIsp, DeterministicForAnyThreadCount) {
  const ImageF rgb = flat_dn(301, 97, 30, 0.5, 2, 4);
  CameraIspOptions o;
  o.sharpen = 0.5;
  const int before = omp_get_max_threads();
  omp_set_num_threads(1);
  const ImageU8 one = preview_camera8(rgb, {1.5, 1, 2}, {0.5, 2}, o);
  omp_set_num_threads(3);
  const ImageU8 three = preview_camera8(rgb, {1.5, 1, 2}, {0.5, 2}, o);
  omp_set_num_threads(before);
  ASSERT_EQ(one.size(), three.size());
  EXPECT_TRUE(std::equal(one.data(), one.data() + one.size(), three.data()));
}

TEST(CameraIsp, BadOptionsAreRefused) {
  const ImageF rgb = flat_dn(8, 8, 10, 1, 1, 5);
  auto refused = [&](CameraIspOptions o, const char* what) {
    try {
      preview_camera8(rgb, {1, 1, 1}, {1, 1}, o);
      ADD_FAILURE() << what << " accepted";
    } catch (const ParameterError& e) {
      EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
    }
  };
  CameraIspOptions o;
  o.denoise = -1;
  refused(o, "preview_denoise");
  o = {};
  o.jpeg_quality = 101;
  refused(o, "preview_jpeg_quality");
  o = {};
  o.sharpen = std::nan("");
  refused(o, "preview_sharpen");
}

TEST(CameraIsp, NightPreviewChangesButTheExrDoesNot) {
  test::TempDir tmp;
  const auto s = test::run_cli("night --out '" + tmp.file("s.exr") + "' --preview '" + tmp.file("s.png") + "'");
  ASSERT_EQ(s.exit_code, 0) << s.output;
  const auto c = test::run_cli("night --out '" + tmp.file("c.exr") + "' --preview '" + tmp.file("c.png") +
                               "' --preview-isp camera --preview-denoise 2 --preview-jpeg-quality 85");
  ASSERT_EQ(c.exit_code, 0) << c.output;
  const ExrContents a = read_exr(tmp.file("s.exr")), b = read_exr(tmp.file("c.exr"));
  ASSERT_EQ(a.channels.size(), b.channels.size());
  for (const auto& [name, im] : a.channels) {
    const ImageF& other = b.channels.at(name);
    ASSERT_EQ(im.size(), other.size()) << name;
    EXPECT_EQ(0, std::memcmp(im.data(), other.data(), im.size() * sizeof(float))) << name;
  }
  const ImageF ps = read_image(tmp.file("s.png")), pc = read_image(tmp.file("c.png"));
  ASSERT_EQ(ps.size(), pc.size());
  EXPECT_NE(0, std::memcmp(ps.data(), pc.data(), ps.size() * sizeof(float)));
  // The same options give the same bytes.
  const auto again = test::run_cli("night --out '" + tmp.file("c2.exr") + "' --preview '" + tmp.file("c2.png") +
                                   "' --preview-isp camera --preview-denoise 2 --preview-jpeg-quality 85");
  ASSERT_EQ(again.exit_code, 0) << again.output;
  const ImageF pc2 = read_image(tmp.file("c2.png"));
  EXPECT_EQ(0, std::memcmp(pc.data(), pc2.data(), pc.size() * sizeof(float)));
}

TEST(CameraIsp, NightRefusesBadPreviewOptions) {
  test::TempDir tmp;
  for (const auto& [args, what] : std::vector<std::pair<std::string, std::string>>{
           {"--preview-isp jpeg", "--preview-isp: 'jpeg' is not simple or camera"},
           {"--preview-isp camera --preview-denoise -0.5", "--preview-denoise"},
           {"--preview-isp camera --preview-jpeg-quality 101", "--preview-jpeg-quality"}}) {
    const auto r = test::run_cli("night --out '" + tmp.file("o.exr") + "' --preview '" + tmp.file("o.png") + "' " + args);
    EXPECT_EQ(r.exit_code, 2) << args << "\n" << r.output;
    EXPECT_NE(r.output.find(what), std::string::npos) << r.output;
    EXPECT_FALSE(std::filesystem::exists(tmp.file("o.exr"))) << args;  // refused before any output
  }
}

TEST(RealismBench, BadRealFolderIsRefused) {
  PHOTOSITE_REQUIRE_SHARED("data/cityscapes");
  const auto r = test::run_cli("bench realism --real /nonexistent/night --no-stats");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("/nonexistent/night"), std::string::npos) << r.output;
  test::TempDir empty;  // a folder without photos is refused before any frame is run
  const auto e = test::run_cli("bench realism --real '" + empty.path().string() + "' --no-stats");
  EXPECT_EQ(e.exit_code, 2) << e.output;
  EXPECT_NE(e.output.find("at least 2 needed"), std::string::npos) << e.output;
  EXPECT_EQ(e.output.find("ms/frame"), std::string::npos) << e.output;
}

TEST(RealismBench, OneFramePerDataSetGivesEveryMethodAndTheRealSet) {
  PHOTOSITE_REQUIRE_SHARED("data/night_real");
  PHOTOSITE_REQUIRE_SHARED("data/cityscapes");
  PHOTOSITE_REQUIRE_SHARED("data/kitti");
  test::TempDir tmp;
  const auto r = test::run_cli("bench realism --max-frames 1 --previews '" + tmp.file("prev") + "' --out-dir '" +
                               tmp.path().string() + "'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::ifstream f(tmp.file("realism.csv"));
  ASSERT_TRUE(f) << r.output;
  std::string header, line;
  std::getline(f, header);
  EXPECT_NE(header.find("balanced_accuracy"), std::string::npos);
  EXPECT_NE(header.find("luma_emd"), std::string::npos);
  std::vector<std::string> methods;
  while (std::getline(f, line)) methods.push_back(line.substr(0, line.find(',')));
  for (const char* m : {"real night", "photosite", "thesis baseline", "day photo"})
    EXPECT_NE(std::find(methods.begin(), methods.end(), m), methods.end()) << m << "\n" << r.output;
  // Every compared method has a classifier row with a balanced accuracy in [0, 1] and 1 image
  // per data set (2) against the 8 real photos. (Its power is tested on synthetic patches in
  // tests/python/test_realism_stats.py: one training image per side is too few to expect it here.)
  std::ifstream c(tmp.file("realism_classifier.csv"));
  ASSERT_TRUE(c);
  bool seen_day = false;
  while (std::getline(c, line))
    if (line.rfind("day photo,", 0) == 0) {
      seen_day = true;
      std::stringstream ss(line.substr(line.find(',') + 1));
      double ba, se;
      char comma;
      int n_a;
      ss >> ba >> comma >> se >> comma >> n_a;
      EXPECT_GE(ba, 0.0);
      EXPECT_LE(ba, 1.0);
      EXPECT_GE(se, 0.0);
      EXPECT_EQ(n_a, 2) << line;
    }
  EXPECT_TRUE(seen_day);
}

// --methods writes only the methods named (the photosite chain still runs: the auto-exposure
// previews are of its sensor frame), in the manifest and as files.
TEST(RealismBench, MethodsListWritesOnlyThoseMethods) {
  PHOTOSITE_REQUIRE_SHARED("data/night_real");
  PHOTOSITE_REQUIRE_SHARED("data/cityscapes");
  PHOTOSITE_REQUIRE_SHARED("data/kitti");
  test::TempDir tmp;
  const auto r = test::run_cli("bench realism --max-frames 1 --no-stats --previews '" + tmp.file("prev") +
                               "' --methods 'photosite auto exposure,day photo'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::ifstream f(tmp.file("prev") + "/manifest.csv");
  ASSERT_TRUE(f) << r.output;
  std::string line;
  std::getline(f, line);
  std::vector<std::string> methods;
  while (std::getline(f, line)) methods.push_back(line.substr(0, line.find(',')));
  EXPECT_EQ(methods, (std::vector<std::string>{"\"photosite auto exposure\"", "\"day photo\"",
                                               "\"photosite auto exposure\"", "\"day photo\""}))
      << r.output;
  int pngs = 0;
  for (const auto& e : std::filesystem::directory_iterator(tmp.file("prev"))) pngs += e.path().extension() == ".png";
  EXPECT_EQ(pngs, 2);  // the two auto-exposure previews; the day photos are the inputs themselves
}

// A misspelt --methods name is refused with the list of methods, before any frame is run or
// any preview folder is made (it used to be skipped silently, writing nothing for it).
TEST(RealismBench, UnknownMethodIsRefused) {
  PHOTOSITE_REQUIRE_SHARED("data/night_real");
  PHOTOSITE_REQUIRE_SHARED("data/cityscapes");
  test::TempDir tmp;
  const auto r = test::run_cli("bench realism --max-frames 1 --no-stats --previews '" + tmp.file("prev") +
                               "' --methods 'photosite,thesis basline'");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("unknown method 'thesis basline'"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("thesis baseline"), std::string::npos) << r.output;  // the list names the right one
  EXPECT_EQ(r.output.find("ms/frame"), std::string::npos) << r.output;
  EXPECT_FALSE(std::filesystem::exists(tmp.file("prev")));
}

}  // namespace
}  // namespace photosite

namespace photosite {
// The library's preview choice (outputs.h preview_image), which expose and night write: the
// simple ISP is preview_srgb8, the camera ISP preview_camera8 with the exposure's system gain and
// the preset's read noise as its noise model; an unknown name is a ParameterError.
TEST(CameraIsp, PreviewImageDispatchesToTheChosenIsp) {
  SensorSetup setup;
  setup.camera = load_camera_preset("onsemi-ar0331");
  setup.lens = load_lens_preset(setup.camera.default_lens);
  setup.settings.exposure_s = 0.02;
  const ResolvedExposure ex = resolve(setup.camera, setup.lens, setup.settings);
  SensorOutput out;
  out.rgb = ImageF(64, 48, 3, 0.f);
  for (size_t i = 0; i < out.rgb.size(); ++i) out.rgb[i] = static_cast<float>((i * 7919) % 4000) / 4.0f;
  const auto wb = white_balance_gains(setup.camera);
  const ImageU8 s = preview_image(out, setup, ex);
  const ImageU8 s_ref = preview_srgb8(out.rgb, wb);
  ASSERT_EQ(s.size(), s_ref.size());
  EXPECT_EQ(0, std::memcmp(s.data(), s_ref.data(), s.size()));
  PreviewOptions o;
  o.isp = PreviewIsp::Camera;
  o.camera.jpeg_quality = 0;
  const ImageU8 c = preview_image(out, setup, ex, o);
  const ImageU8 c_ref = preview_camera8(out.rgb, wb, {ex.system_gain_dn_per_e, setup.camera.read_noise_e}, o.camera);
  ASSERT_EQ(c.size(), c_ref.size());
  EXPECT_EQ(0, std::memcmp(c.data(), c_ref.data(), c.size()));
  EXPECT_NE(0, std::memcmp(c.data(), s.data(), c.size()));
  EXPECT_EQ(parse_preview_isp("camera"), PreviewIsp::Camera);
  try {
    parse_preview_isp("jpeg");
    ADD_FAILURE() << "no error";
  } catch (const ParameterError& e) {
    EXPECT_EQ(e.parameter(), "preview_isp");
    EXPECT_EQ(e.message_for("--preview-isp"), "--preview-isp: 'jpeg' is not simple or camera");
  }
  // The white balance (PreviewWb): Auto is the AWB's gains (auto_white_balance_gains within
  // camera_awb_bounds, the preset's as fallback) and their white floor; Fixed, the default, the
  // preset's (s above).
  o = {};
  o.wb = PreviewWb::Auto;
  const ImageU8 a = preview_image(out, setup, ex, o);
  const auto awb = auto_white_balance_gains(out.rgb, sensor_full_scale_dn(setup.camera, ex),
                                            camera_awb_bounds(setup.camera), wb);
  EXPECT_EQ(awb, preview_wb_gains(out.rgb, setup.camera, ex, PreviewWb::Auto));
  EXPECT_EQ(wb, preview_wb_gains(out.rgb, setup.camera, ex, PreviewWb::Fixed));
  EXPECT_NE(awb, wb);
  const ImageU8 a_ref = preview_srgb8(out.rgb, awb, 0.99, 1.0, preview_min_white(setup.camera, ex, awb));
  ASSERT_EQ(a.size(), a_ref.size());
  EXPECT_EQ(0, std::memcmp(a.data(), a_ref.data(), a.size()));
  EXPECT_NE(0, std::memcmp(a.data(), s.data(), a.size()));
  EXPECT_EQ(parse_preview_wb("auto"), PreviewWb::Auto);
  EXPECT_EQ(parse_preview_wb("fixed"), PreviewWb::Fixed);
  try {
    parse_preview_wb("grey");
    ADD_FAILURE() << "no error";
  } catch (const ParameterError& e) {
    EXPECT_EQ(e.message_for("--preview-wb"), "--preview-wb: 'grey' is not fixed or auto");
  }
}

// expose takes the same preview flags as night, checked before anything is read or written.
TEST(CameraIsp, ExposeRefusesBadPreviewOptions) {
  test::TempDir tmp;
  const auto r = test::run_cli("expose --preset onsemi-ar0331 --radiance '" + tmp.file("none.exr") + "' --out '" +
                               tmp.file("o.exr") + "' --preview '" + tmp.file("o.png") + "' --preview-isp jpeg");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("--preview-isp: 'jpeg' is not simple or camera"), std::string::npos) << r.output;
  EXPECT_FALSE(std::filesystem::exists(tmp.file("o.exr")));
}
}  // namespace photosite

namespace photosite {
// kth_smallest (the previews' percentile) against std::nth_element: negatives, ±0, ties and a
// bucket that holds most of the values, at several ranks and thread counts.
TEST(CameraIsp, KthSmallestIsNthElement) {
  std::mt19937 rng(7);
  std::normal_distribution<float> z(0.f, 1.f);
  std::vector<float> v(300001);
  for (size_t i = 0; i < v.size(); ++i) v[i] = i % 5 == 0 ? 0.f : i % 7 == 0 ? -0.f : i % 3 == 0 ? 1.0f + 1e-7f * (i % 4) : 50 * z(rng);
  const int team = omp_get_max_threads();
  for (const size_t k : {size_t{0}, size_t{1}, v.size() / 3, v.size() / 2, v.size() * 99 / 100, v.size() - 1})
    for (const int threads : {1, 2, 3}) {
      omp_set_num_threads(threads);
      std::vector<float> ref = v;
      std::nth_element(ref.begin(), ref.begin() + static_cast<long>(k), ref.end());
      EXPECT_EQ(kth_smallest(v, k), ref[k]) << k << " " << threads;
    }
  omp_set_num_threads(team);
}
}  // namespace photosite

namespace photosite {
namespace {
// The metered mean at gain g, in double, straight from the definition (isp.h auto_exposure_gain).
double metered_mean(const ImageF& rgb, const std::array<double, 3>& wb, double fs, double g) {
  const double k = 1.0 / (std::min({wb[0], wb[1], wb[2]}) * fs);
  double s = 0;
  for (size_t i = 0; i < rgb.pixel_count(); ++i)
    s += std::min(1.0, g * k * (0.2126 * wb[0] * rgb[3 * i] + 0.7152 * wb[1] * rgb[3 * i + 1] + 0.0722 * wb[2] * rgb[3 * i + 2]));
  return s / static_cast<double>(rgb.pixel_count());
}
}  // namespace

// The AE reaches its target when the target is within the gain range. Frame: 5 % of the pixels
// at half of full scale (clipped at any gain >= 2), 95 % at 1 % of full scale; the metered mean
// is 0.05 + 0.95 * 0.01 * G, so G = (target - 0.05) / 0.0095 = 13.31 (inside 1 .. 15.85).
// Tolerance: each pixel's luminance is rounded to float, the gain is rounded to float and the
// two are multiplied in float (sensor/isp.cpp): three relative roundings of at most 2^-24 on each
// unclipped term; the clipped terms are exactly 1 and the sums are in double (n u = 20000 * 2^-53
// = 2e-12, negligible). The unclipped terms sum to 0.0095 G = target - 0.05 of the mean, so the
// metered mean is off by at most 3 * 2^-24 * 0.0095 G, which moves G by that over the slope
// 0.0095: 3 * 2^-24 relative; the bisection ends within 2.5e-14 relative (its own comment). The
// metered mean against the target in double (metered_mean here): the same 3 * 2^-24 *
// (target - 0.05) / target, less than 3 * 2^-24 relative.
constexpr double kAeGainTolerance = 3 * 0x1p-24 + 2.5e-14;
TEST(AutoExposure, MeteringReachesItsTarget) {
  const int w = 200, h = 100, bright = w * h / 20;
  const double fs = 1000;
  ImageF rgb(w, h, 3, 10.f);
  for (int i = 0; i < bright; ++i)
    for (int c = 0; c < 3; ++c) rgb[3 * static_cast<size_t>(i) * 20 + c] = 500.f;  // every 20th pixel
  const std::array<double, 3> wb{1, 1, 1};
  AutoExposure ae;
  ae.max_gain = std::pow(10.0, 24.0 / 20);
  const double g = auto_exposure_gain(rgb, wb, fs, ae);
  const double expected = (ae.target - 0.05) / (0.95 * 0.01);
  EXPECT_NEAR(g / expected, 1.0, kAeGainTolerance) << g;
  EXPECT_NEAR(metered_mean(rgb, wb, fs, g) / ae.target, 1.0, kAeGainTolerance);
  // The preview shows full scale / G as white: the dim pixels at 0.01 * G of white, the bright ones white.
  double got = 0;
  const ImageU8 p = preview_srgb8_auto(rgb, wb, fs, ae, &got);
  EXPECT_EQ(got, g);
  EXPECT_EQ(p[0], 255);
  EXPECT_EQ(p[3], srgb_encode8(static_cast<float>(10.0 * (g / fs))));
  // The white-balance gains count in the metering and are normalised to the smallest: with
  // gains (2, 1, 4) and the frame divided by them, the balanced frame is the same grey.
  const std::array<double, 3> wb2{2, 1, 4};
  ImageF rgb2 = rgb;
  for (size_t i = 0; i < rgb2.pixel_count(); ++i)
    for (int c = 0; c < 3; ++c) rgb2[3 * i + c] = static_cast<float>(rgb[3 * i + c] / wb2[c]);
  // rgb / 2 and rgb / 4 are exact in float (10, 500 over powers of two): the same bound.
  EXPECT_NEAR(auto_exposure_gain(rgb2, wb2, fs, ae) / expected, 1.0, kAeGainTolerance);
  // Highlight protection: with at most 1 % clipping, the 5 % at half of full scale hold the gain
  // at 2 (their 99th percentile is 0.5 of full scale), where the frame meters 0.069 < target.
  ae.clip_fraction = 0.01;
  EXPECT_DOUBLE_EQ(auto_exposure_gain(rgb, wb, fs, ae), 2.0);
  ae.clip_fraction = 0.2;  // the 80th percentile is a dim pixel: 1 / 0.01 = 100 > max_gain, no limit
  EXPECT_NEAR(auto_exposure_gain(rgb, wb, fs, ae) / expected, 1.0, kAeGainTolerance);
}

// Out of range: a dim frame (the night case) and an all-black one get the largest gain, a frame
// that meters above the target at the simulated exposure keeps it (gain 1), and a frame saturated
// in every channel is white whatever the camera's white balance.
TEST(AutoExposure, GainRangeLimitsAndDegenerateFrames) {
  const CameraPreset cam = load_camera_preset("onsemi-ar0331");
  const auto wb = white_balance_gains(cam);
  const double fs = 3780;
  AutoExposure ae;
  ae.max_gain = 8;
  EXPECT_EQ(auto_exposure_gain(ImageF(64, 32, 3, 1.f), wb, fs, ae), 8.0);  // meters 2.6e-4 * 8 << target
  const ImageF black(64, 32, 3, 0.f);
  double g = 0;
  const ImageU8 pb = preview_srgb8_auto(black, wb, fs, ae, &g);
  EXPECT_EQ(g, 8.0);
  EXPECT_TRUE(std::all_of(pb.data(), pb.data() + pb.size(), [](uint8_t v) { return v == 0; }));
  ImageF nan_frame(8, 8, 3, 0.f);
  nan_frame[5] = std::nanf("");
  EXPECT_EQ(auto_exposure_gain(nan_frame, wb, fs, ae), 8.0);
  EXPECT_EQ(auto_exposure_gain(ImageF(64, 32, 3, 0.5f * 3780), wb, fs, ae), 1.0);  // meters >= 0.5
  const ImageF saturated(64, 32, 3, static_cast<float>(fs));
  const ImageU8 ps = preview_srgb8_auto(saturated, wb, fs, ae, &g);
  EXPECT_EQ(g, 1.0);
  EXPECT_TRUE(std::all_of(ps.data(), ps.data() + ps.size(), [](uint8_t v) { return v == 255; }));
  // The camera's range: 24 dB above a 0 dB exposure, nothing above a 24 dB one; the AR0331's full
  // scale is its full well (9000 e- x 0.42 DN/e- = 3780 DN), below the ADC's 4095 - 168.
  LensPreset lens = load_lens_preset(cam.default_lens);
  ExposureSettings s;
  // Exact: the code's pow(10, 24 / 20) divided by the 0 dB exposure's gain, pow(10, 0) = 1.
  EXPECT_EQ(camera_auto_exposure(cam, resolve(cam, lens, s)).max_gain, std::pow(10.0, 24.0 / 20));
  EXPECT_DOUBLE_EQ(sensor_full_scale_dn(cam, resolve(cam, lens, s)), 3780);
  s.gain_db = 24;
  EXPECT_EQ(camera_auto_exposure(cam, resolve(cam, lens, s)).max_gain, 1.0);
}

// The percentile previews' floor (preview_min_white): no more gain than the camera's range. A
// frame of read noise alone (σ = 3 e- × 0.42 DN/e-, as onsemi-ar0331 at 0 dB; the tester's
// `night --exposure-s 0`) was stretched to white: its 99th percentile became full brightness.
// With the floor, white is the full scale over the camera's remaining gain (3780 DN / 10^(24/20)
// = 238.5 DN, times min(wb)), so no sample brighter than max_sample · max(wb) / floor can reach a
// higher code than srgb_encode8 of that ratio; without the floor the 99th percentile code is 255.
// A frame whose 99th percentile is above the floor keeps its preview bit for bit.
TEST(Preview, NoSignalIsNotStretchedToWhiteButLitFramesKeepTheirPreview) {
  const CameraPreset cam = load_camera_preset("onsemi-ar0331");
  const LensPreset lens = load_lens_preset(cam.default_lens);
  const ResolvedExposure ex = resolve(cam, lens, ExposureSettings{});
  const auto wb = white_balance_gains(cam);
  const double floor_lum = preview_min_white(cam, ex, wb);
  // The same pow on both sides (so no difference there); the code rounds FW·K, the product by
  // min(wb) and the quotient, this side the product and the quotient: 5 double roundings, 5u
  // relative (u = 2⁻⁵³).
  EXPECT_NEAR(floor_lum, std::min({wb[0], wb[1], wb[2]}) * 3780 / std::pow(10.0, 24.0 / 20), 5 * 0x1p-53 * floor_lum);
  ImageF noise(256, 128, 3);
  float top = 0;
  for (size_t i = 0; i < noise.size(); ++i) {
    const auto w = random_words(5, 0, i, Stream::Test);
    const double z = std::sqrt(-2 * std::log(uniform_open(w[0]))) * std::cos(2 * M_PI * uniform_open(w[1]));
    noise[i] = static_cast<float>(std::max(0.0, 3 * 0.42 * z));  // DN above black, clipped at black as the ADC does
    top = std::max(top, noise[i]);
  }
  auto p99 = [](const ImageU8& p) {
    std::vector<uint8_t> v(p.data(), p.data() + p.size());
    std::nth_element(v.begin(), v.begin() + v.size() * 99 / 100, v.end());
    return v[v.size() * 99 / 100];
  };
  EXPECT_EQ(p99(preview_srgb8(noise, wb)), 255);  // the old behaviour: noise at full brightness
  const ImageU8 floored = preview_srgb8(noise, wb, 0.99, 1.0, floor_lum);
  const uint8_t bound = srgb_encode8(static_cast<float>(top * std::max({wb[0], wb[1], wb[2]}) / floor_lum));
  EXPECT_LE(*std::max_element(floored.data(), floored.data() + floored.size()), bound);
  EXPECT_LT(bound, 128);
  // A lit frame: 2 % of the pixels at 2000 DN, the rest at 100 DN: its 99th percentile (2000 DN) is
  // above the floor, so the floor changes nothing.
  ImageF lit(256, 128, 3, 100.f);
  for (size_t px = 0; px < lit.pixel_count(); px += 50)
    for (int c = 0; c < 3; ++c) lit[3 * px + c] = 2000.f;
  const ImageU8 a = preview_srgb8(lit, wb), b = preview_srgb8(lit, wb, 0.99, 1.0, floor_lum);
  EXPECT_EQ(std::memcmp(a.data(), b.data(), a.size()), 0);
}

TEST(AutoExposure, DeterministicForAnyThreadCount) {
  std::mt19937 rng(7);
  std::exponential_distribution<float> e(1.0f / 40);  // a dim frame with a long bright tail
  ImageF rgb(333, 211, 3);
  for (size_t i = 0; i < rgb.size(); ++i) rgb[i] = std::min(e(rng), 1000.f);
  AutoExposure ae;
  ae.max_gain = 16;
  const int before = omp_get_max_threads();
  std::vector<double> g;
  for (int t : {1, 2, 3}) {
    omp_set_num_threads(t);
    g.push_back(auto_exposure_gain(rgb, {1.5, 1, 2}, 1000, ae));
  }
  omp_set_num_threads(before);
  EXPECT_GT(g[0], 1.0);
  EXPECT_LT(g[0], 16.0);  // the target is inside the range: the bisection ran
  EXPECT_EQ(g[0], g[1]);
  EXPECT_EQ(g[0], g[2]);
}

TEST(AutoExposure, BadSettingsAreRefused) {
  const ImageF rgb(4, 4, 3, 1.f);
  auto parameter_of = [&](double fs, double target, double max_gain) -> std::string {
    AutoExposure ae;
    ae.target = target;
    ae.max_gain = max_gain;
    try {
      auto_exposure_gain(rgb, {1, 1, 1}, fs, ae);
    } catch (const ParameterError& e) {
      return e.parameter();
    }
    return "";
  };
  EXPECT_EQ(parameter_of(0, 0.2, 2), "full_scale_dn");
  EXPECT_EQ(parameter_of(NAN, 0.2, 2), "full_scale_dn");
  EXPECT_EQ(parameter_of(1000, 0, 2), "auto_exposure_target");
  EXPECT_EQ(parameter_of(1000, 1, 2), "auto_exposure_target");
  EXPECT_EQ(parameter_of(1000, 0.2, 0.5), "auto_exposure_max_gain");
  EXPECT_EQ(parameter_of(1000, 0.2, INFINITY), "auto_exposure_max_gain");
  EXPECT_EQ(parameter_of(1000, 0.2, 2), "");
  AutoExposure bad;
  bad.max_gain = 2;
  bad.clip_fraction = 1;
  EXPECT_THROW(auto_exposure_gain(rgb, {1, 1, 1}, 1000, bad), ParameterError);
}
}  // namespace photosite
