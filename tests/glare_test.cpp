// The lens's veiling glare (sensor/glare.h, docs/model_glare.md): energy conservation, reach
// fixed in degrees, the power-law skirt's slope, lens dependence, thread-count independence,
// the [glare] table of the lens presets, and (tests/gpu_test.cpp) CPU/Vulkan parity.
#include <gtest/gtest.h>
#include <omp.h>

#include <cmath>
#include <cstring>
#include <numeric>
#include <vector>

#include "photosite/error.h"
#include "photosite/rng.h"
#include "photosite/sensor/glare.h"
#include "photosite/sensor/pipeline.h"
#include "photosite/sensor/preset.h"

namespace photosite {
namespace {

constexpr double kEps = 0x1p-24;  // float unit roundoff
// The glare's energy bound, relative (ConservesEnergyOnOddAndEvenSizes's derivation): 11 float
// roundings, and one double rounding per addition of a sum over `pixels` pixels.
double energy_rel(double pixels) { return 11 * kEps + pixels * 0x1p-53; }

LensGlare test_glare(double eta = 0.05, double core_deg = 0.1, double reach_deg = 20, double p = 2) {
  LensGlare g;
  g.enabled = true;
  g.veiling_glare_index = eta;
  g.core_deg = core_deg;
  g.reach_deg = reach_deg;
  g.skirt_exponent = p;
  return g;
}

// Radiance over 7 decades (lamps and dark road in one frame), from the counter-based generator.
ImageF wide_radiance(int w, int h) {
  ImageF r(w, h, 3, 0.f, unit::radiance);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < 3; ++c) {
        const uint32_t u = random_words(7, 0, static_cast<uint64_t>(y) * w + x, Stream::Test)[c];
        r.at(x, y, c) = static_cast<float>(std::exp(16.0 * uniform_open(u) - 12.0));
      }
  return r;
}

// The skirt alone, s_c·up(acc_1), at full resolution (glare_row of a zero input).
ImageF skirt_image(const ImageF& in, const LensGlare& g, double ppd) {
  const GlareSkirt s = glare_skirt(in, plan_glare(g, ppd));
  ImageF out(in.width(), in.height(), 3, 0.f);
  std::vector<float> zero(3 * static_cast<size_t>(in.width()), 0.f), tmp(glare_row_scratch(s));
  for (int y = 0; y < in.height(); ++y) glare_row(s, y, zero.data(), out.row(y), tmp.data());
  return out;
}

std::array<double, 3> channel_sums(const ImageF& img) {
  std::array<double, 3> s{0, 0, 0};
  for (size_t i = 0; i < img.pixel_count(); ++i)
    for (int c = 0; c < 3; ++c) s[c] += img[3 * i + c];
  return s;
}

bool bit_equal(const ImageF& a, const ImageF& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

// Σ out = Σ in per channel. Bound: every input value is non-negative, so relative rounding
// errors of the terms bound that of the sums. Per output pixel, out = keep·x + s·u has 2
// roundings after u, and u (bilinear: 2 products and a sum per axis) 6; the level-1 energy E_in
// that fixes s carries the 2x2 average's 3 roundings (the ×1/4 is exact); E_skirt is the exact
// (double) sum of acc_1, whose own rounding cancels in s·Σu. So |Σout − Σin| ≤ 11ε·Σin, plus
// 2^-53 per double addition of the sums (kEnergyRel; the test allowed 16ε before 2026-12-02).
TEST(Glare, ConservesEnergyOnOddAndEvenSizes) {
  for (auto [w, h] : {std::pair{301, 157}, std::pair{256, 128}, std::pair{1, 9}, std::pair{17, 1}}) {
    const ImageF in = wide_radiance(w, h);
    const ImageF out = apply_glare(in, test_glare(), 35.0);
    const auto si = channel_sums(in), so = channel_sums(out);
    for (int c = 0; c < 3; ++c) EXPECT_LE(std::fabs(so[c] - si[c]), energy_rel(w * h) * si[c]) << w << "x" << h << " c" << c;
    if (w > 100) {  // and glare moved light: the bound above is far below what changed
      double moved = 0;
      for (size_t i = 0; i < in.size(); ++i) moved += std::fabs(out[i] - in[i]);
      EXPECT_GT(moved, 1e3 * 16 * kEps * (si[0] + si[1] + si[2]));
    }
  }
}

// A single lamp keeps 1 − η of its flux in its own pixel, plus only the skirt's value there;
// the rest lands around it.
TEST(Glare, APointKeepsOneMinusEtaAndSpreadsTheRest) {
  const int n = 257;
  ImageF in(n, n, 3, 0.f);
  for (int c = 0; c < 3; ++c) in.at(128, 128, c) = 1.f;
  const LensGlare g = test_glare(0.05);
  const ImageF out = apply_glare(in, g, 35.0);
  const ImageF sk = skirt_image(in, g, 35.0);
  for (int c = 0; c < 3; ++c) {
    EXPECT_FLOAT_EQ(out.at(128, 128, c), 0.95f + sk.at(128, 128, c));
    EXPECT_LT(sk.at(128, 128, c), 0.05f * 0.1f);  // the skirt is wide: little of it on the lamp
    // The skirt's energy is η of the input's, within ConservesEnergyOnOddAndEvenSizes's rounding
    // bound (the skirt alone has fewer roundings than the output: u's 6, s·u's 1, E_in's 3).
    EXPECT_NEAR(channel_sums(sk)[c], 0.05, energy_rel(n * n));
  }
}

// Reach in degrees, not pixels or image fractions: the same scene seen through the same lens at
// half the pixel pitch (twice the pixels per degree). A horizontal line (1 px, or 2 px at half
// pitch: the same angular width) gives the line-spread function; its variance about its
// centroid follows from the pyramid exactly (glare.cpp, plan_glare): per level, the (1,3,3,1)/8
// steps m = 2..l add 3/4·4^(m−1) px², the bilinear steps back 3/16·4^m, the blur σ_b²·4^l, and
// the 2x2 box of level 1 nothing for a line it maps onto one row: V = Σ w_l·(4^l(σ_b² + 1/2) −
// 5/4) / Σ w_l. At half pitch every level is one octave finer in degrees and one level deeper,
// so in degrees the two RMS reaches differ only by the fixed sub-pixel terms:
// V_2 = 4·V_1 + 15/4. Float rounding, counted (every step a sum of non-negative terms, so relative
// errors add along a sample's path; a weighted sum of n terms errs by at most n·ε): a level-L
// contribution passes the 2x2 box (3ε), L − 1 (1,3,3,1) steps (4ε per axis: 8ε), the 7-tap blur
// (7ε per axis: 14ε) and its weight (ε), L − 1 upsamplings (2ε per axis) and accumulations (ε):
// 5ε each, and the full-resolution row's u (6ε) and s·u (ε): δ ≤ (13·L + 12)ε, L ≤ hi; a sum of
// the levels' contributions keeps the largest. A variance about the centroid with weights off
// by δ moves by at most 2δ·V (|Σ v δ ((y − μ)² − V)| ≤ δ Σ v ((y − μ)² + V)); the float taps'
// sum, off 1 by |Σ g − 1|, scales the blur's share of V by as much (the levels' weights are the
// plan's floats, the same in predicted()). The two reaches' ratio
// √(V_2/4V_1): half the sum of the two relative bounds. (The double moments: negligible.)
TEST(Glare, ReachIsFixedInDegreesNotPixels) {
  const LensGlare g = test_glare(0.05, 0.2, 10);
  const CameraPreset cam = load_camera_preset("onsemi-ar0331");
  LensPreset lens = load_lens_preset(cam.default_lens);
  const double ppd1 = px_per_degree(lens.focal_length_mm, 4 * cam.pixel_pitch_um);
  const double ppd2 = px_per_degree(lens.focal_length_mm, 2 * cam.pixel_pitch_um);
  ASSERT_DOUBLE_EQ(ppd2, 2 * ppd1);
  const GlarePlan p1 = plan_glare(g, ppd1), p2 = plan_glare(g, ppd2);
  ASSERT_EQ(p2.lo, p1.lo + 1);
  ASSERT_EQ(p2.hi, p1.hi + 1);
  const auto taps = glare_blur_taps();
  double var_b = 0;
  for (int k = 1; k <= kGlareBlurRadius; ++k) var_b += 2.0 * k * k * taps[k];
  auto predicted = [&](const GlarePlan& p) {
    double num = 0, den = 0;
    for (int l = p.lo; l <= p.hi; ++l) {
      num += p.weight[l - p.lo] * (std::ldexp(1.0, 2 * l) * (var_b + 0.5) - 1.25);
      den += p.weight[l - p.lo];
    }
    return num / den;
  };
  const int h1 = 1024;
  ImageF a(8, h1, 3, 0.f), b(16, 2 * h1, 3, 0.f);
  for (int x = 0; x < 8; ++x)
    for (int c = 0; c < 3; ++c) a.at(x, 500, c) = 1.f;
  for (int x = 0; x < 16; ++x)
    for (int c = 0; c < 3; ++c) b.at(x, 1000, c) = b.at(x, 1001, c) = 1.f;
  auto variance = [](const ImageF& s) {  // of the column profile, about its centroid (px²)
    double m0 = 0, m1 = 0, m2 = 0;
    for (int y = 0; y < s.height(); ++y) {
      const double v = s.at(0, y, 1);
      m0 += v, m1 += v * y, m2 += v * y * y;
    }
    const double mean = m1 / m0;
    return m2 / m0 - mean * mean;
  };
  const double v1 = variance(skirt_image(a, g, ppd1)), v2 = variance(skirt_image(b, g, ppd2));
  const double rms_deg1 = std::sqrt(v1) / ppd1, rms_deg2 = std::sqrt(v2) / ppd2;
  std::fprintf(stderr, "[glare] RMS reach %.5f deg (%.2f px) at %.2f px/deg, %.5f deg (%.2f px) at %.2f px/deg\n",
               rms_deg1, std::sqrt(v1), ppd1, rms_deg2, std::sqrt(v2), ppd2);
  double tap_sum = taps[0];
  for (int k = 1; k <= kGlareBlurRadius; ++k) tap_sum += 2.0 * taps[k];
  auto rel_bound = [&](const GlarePlan& p) { return 2 * (13.0 * p.hi + 12) * kEps + std::fabs(tap_sum - 1); };
  EXPECT_NEAR(v1, predicted(p1), rel_bound(p1) * v1);
  EXPECT_NEAR(v2, predicted(p2), rel_bound(p2) * v2);
  const double ratio = std::sqrt((4 * v1 + 3.75) / (4 * v1));
  // The ratio of two such RMS reaches: half the sum of the two variances' relative bounds.
  EXPECT_NEAR(rms_deg2 / rms_deg1, ratio, 0.5 * (rel_bound(p1) + rel_bound(p2)) * ratio);
  // And it is tied to the lens's reach: the coarsest level's σ is within a factor √2 of reach/2.
  EXPECT_GT(p1.sigma_px.back(), 0.5 * g.reach_deg * ppd1 / std::sqrt(2.0));
  EXPECT_LT(p1.sigma_px.back(), 0.5 * g.reach_deg * ppd1 * std::sqrt(2.0));
}

// The skirt falls as θ^(−p): the log-log slope of the radial profile of a point's skirt between
// 4 core radii and a quarter of the coarsest σ. Expected: the regression slope of the model
// (θ² + θ0²)^(−p/2) itself over the same bins (the core bends it slightly). Tolerance, derived:
//  * octave ripple: Σ_l σ_l^(−2) e^(−θ²/2σ_l²) over octave σ_l is θ^(−2) times a log-periodic
//    factor whose first harmonic (Poisson summation) has relative amplitude 2|Γ(1 + iy)| with
//    y = 2π/ln 4, |Γ(1 + iy)|² = πy/sinh(πy): 8.6e-3, i.e. a local-slope ripple of amplitude
//    8.6e-3 · 2π/ln 2 = 0.078 (bounding the regression's bias by the full amplitude);
//  * the missing levels above the coarsest: a relative deficit ≤ (r/σ_hi)²·ln4/6 at r, 0.0145 at
//    r = σ_hi/4, bending the slope by at most twice that, 0.03;
//  * 4 standard errors of the fitted slope.
TEST(Glare, SkirtFallsAsThePowerLaw) {
  const LensGlare g = test_glare(0.05, 0.1, 20, 2.0);
  const double ppd = 20;
  const int n = 1024, c0 = 512;
  ImageF in(n, n, 3, 0.f);
  for (int c = 0; c < 3; ++c) in.at(c0, c0, c) = 1.f;
  const double cc = c0 + 0.5;  // the 2x2 box of level 1 centres the skirt on the box's centre
  const GlarePlan plan = plan_glare(g, ppd);
  const ImageF sk = skirt_image(in, g, ppd);
  const double core_px = g.core_deg * ppd;
  const double r_lo = std::max(4 * core_px, 2 * plan.sigma_px.front()), r_hi = plan.sigma_px.back() / 4;
  ASSERT_GT(r_hi, 3 * r_lo) << "the fit needs more than 1.5 octaves";
  // Annuli of 1/8 octave: mean skirt value against the annulus's geometric centre.
  std::vector<double> lx, ly, lm;
  for (double r = r_lo; r * std::exp2(0.125) <= r_hi; r *= std::exp2(0.125)) {
    const double r2 = r * std::exp2(0.125);
    double sum = 0;
    int count = 0;
    for (int y = c0 - static_cast<int>(r2) - 1; y <= c0 + static_cast<int>(r2) + 1; ++y)
      for (int x = c0 - static_cast<int>(r2) - 1; x <= c0 + static_cast<int>(r2) + 1; ++x) {
        const double d = std::hypot(x - cc, y - cc);
        if (d >= r && d < r2) sum += sk.at(x, y, 1), ++count;
      }
    ASSERT_GT(count, 0);
    const double rc = std::sqrt(r * r2);
    lx.push_back(std::log(rc));
    ly.push_back(std::log(sum / count));
    lm.push_back(std::log(std::pow(rc * rc + core_px * core_px, -g.skirt_exponent / 2)));
  }
  auto fit = [&](const std::vector<double>& yv, double* se) {
    const double k = static_cast<double>(lx.size());
    const double mx = std::accumulate(lx.begin(), lx.end(), 0.0) / k;
    const double my = std::accumulate(yv.begin(), yv.end(), 0.0) / k;
    double sxx = 0, sxy = 0;
    for (size_t i = 0; i < lx.size(); ++i) sxx += (lx[i] - mx) * (lx[i] - mx), sxy += (lx[i] - mx) * (yv[i] - my);
    const double b = sxy / sxx;
    if (se) {
      double rss = 0;
      for (size_t i = 0; i < lx.size(); ++i) {
        const double e = yv[i] - my - b * (lx[i] - mx);
        rss += e * e;
      }
      *se = std::sqrt(rss / (k - 2) / sxx);
    }
    return b;
  };
  double se = 0;
  const double slope = fit(ly, &se), expected = fit(lm, nullptr);
  const double y = 2 * 3.14159265358979 / std::log(4.0);
  const double ripple = 2 * std::sqrt(3.14159265358979 * y / std::sinh(3.14159265358979 * y)) * 2 *
                        3.14159265358979 / std::log(2.0);
  const double truncation = 2 * std::pow(r_hi / plan.sigma_px.back(), 2) * std::log(4.0) / 6;
  const double tol = ripple + truncation + 4 * se;
  std::fprintf(stderr, "[glare] skirt slope %.4f over %.1f..%.1f px (model %.4f, tolerance %.4f = ripple %.4f + "
               "truncation %.4f + 4 SE %.4f)\n", slope, r_lo, r_hi, expected, tol, ripple, truncation, 4 * se);
  EXPECT_NEAR(slope, expected, tol);
  EXPECT_LT(tol, 0.15 * g.skirt_exponent);  // the test can tell p = 2 from p = 1.7 or 2.3
}

// Another lens, another glare: η scales the skirt, the reach moves it outward.
TEST(Glare, TwoLensesGiveDifferentGlare) {
  const ImageF in = wide_radiance(200, 120);
  const LensGlare a = test_glare(0.02, 0.1, 10), b = test_glare(0.04, 0.1, 20);
  const ImageF sa = skirt_image(in, a, 35), sb = skirt_image(in, b, 35);
  const auto ea = channel_sums(sa), eb = channel_sums(sb), ei = channel_sums(in);
  for (int c = 0; c < 3; ++c) {
    // η_a and η_b of the input's energy, within ConservesEnergyOnOddAndEvenSizes's bound.
    EXPECT_NEAR(ea[c], 0.02 * ei[c], energy_rel(200 * 120) * ei[c]);
    EXPECT_NEAR(eb[c], 0.04 * ei[c], energy_rel(200 * 120) * ei[c]);
  }
  EXPECT_FALSE(bit_equal(apply_glare(in, a, 35), apply_glare(in, b, 35)));
  // The wider lens spreads its skirt further: the line-spread variance of its skirt, on a frame
  // tall enough (4096 px, ±2048 around the line, > 6 σ of the coarsest level) for the borders
  // not to matter. Level σ_l doubles per level and the weights are equal (p = 2), so one more
  // level (reach 20° against 10°: hi = 8 against 7) must more than double the variance.
  ImageF line(8, 4096, 3, 0.f);
  for (int x = 0; x < 8; ++x)
    for (int c = 0; c < 3; ++c) line.at(x, 2048, c) = 1.f;
  auto variance = [](const ImageF& sk) {
    double m0 = 0, m1 = 0, m2 = 0;
    for (int y = 0; y < sk.height(); ++y) {
      const double v = sk.at(0, y, 1);
      m0 += v, m1 += v * y, m2 += v * y * y;
    }
    return m2 / m0 - (m1 / m0) * (m1 / m0);
  };
  ASSERT_EQ(plan_glare(b, 35).hi, plan_glare(a, 35).hi + 1);
  EXPECT_GT(variance(skirt_image(line, b, 35)), 2 * variance(skirt_image(line, a, 35)));
}

// Thread count never changes a result; the fused optics stage equals glare then optics.
TEST(Glare, ThreadCountIndependentAndFusedEqualsSeparate) {
  // Level 1 above 2^18 pixels, so its passes (and the full-resolution ones) run in parallel.
  const ImageF in = wide_radiance(2048, 600);
  const LensGlare g = test_glare();
  const int before = omp_get_max_threads();
  omp_set_num_threads(1);
  const ImageF one = apply_glare(in, g, 35);
  omp_set_num_threads(3);
  const ImageF three = apply_glare(in, g, 35);
  omp_set_num_threads(before);
  EXPECT_TRUE(bit_equal(one, three));

  const CameraPreset cam = load_camera_preset("onsemi-ar0331");
  LensPreset lens = load_lens_preset(cam.default_lens);
  lens.glare = g;
  LensPreset plain = lens;
  plain.glare = LensGlare{};
  const ResolvedExposure ex = resolve(cam, lens, ExposureSettings{});
  const ImageF fused = mean_signal_electrons(in, cam, lens, ex);
  const ImageF separate = mean_signal_electrons(
      apply_glare(in, g, px_per_degree(lens.focal_length_mm, cam.pixel_pitch_um)), cam, plain, ex);
  EXPECT_TRUE(bit_equal(fused, separate));
  EXPECT_FALSE(bit_equal(fused, mean_signal_electrons(in, cam, plain, ex)));
}

TEST(Glare, PxPerDegreeFromFocalLengthAndPitch) {
  // Cityscapes: f = 4.98 mm, 2.2 µm → fx = 2263.6 px per radian, 39.51 px per degree.
  // Rounding (u = 2⁻⁵³): glare.cpp reads 4.98, 1e-3, 2.2, 1e-6 and π (half an ulp each) and does
  // five operations (7.5u); this side reads three literals and does three (4.5u), and its
  // 15-digit π is short of π by a relative 1.0e-15 (computed here).
  const double want = 4.98e-3 / 2.2e-6 * 3.14159265358979 / 180;
  const double pi_short = std::fabs(M_PI - 3.14159265358979) / M_PI;
  EXPECT_NEAR(px_per_degree(4.98, 2.2), want, (12 * 0x1p-53 + pi_short) * want);
}

// The lens preset's [glare] table: every key checked; no table, no glare.
TEST(Glare, LensPresetTable) {
  const std::string head =
      "description = \"t\"\nf_number = 2.0\nfocal_length_mm = 5.0\ntransmittance = 0.9\ncos4_falloff = true\n";
  const LensPreset none = parse_lens_preset(head, "none.toml");
  EXPECT_FALSE(none.glare.enabled);
  EXPECT_FALSE(plan_glare(none.glare, 35).active);
  const LensPreset l = parse_lens_preset(
      head + "[glare]\nveiling_glare_index = 0.03\ncore_deg = 0.1\nreach_deg = 20\nskirt_exponent = 2.0\n", "l.toml");
  EXPECT_TRUE(l.glare.enabled);
  EXPECT_DOUBLE_EQ(l.glare.veiling_glare_index, 0.03);
  EXPECT_DOUBLE_EQ(l.glare.reach_deg, 20);
  auto message = [&](const std::string& glare) {
    try {
      parse_lens_preset(head + "[glare]\n" + glare, "bad.toml");
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(message("veiling_glare_index = 0.03\ncore_deg = 0.1\nreach_deg = 20\nbloom = 1\n")
                .find("bad.toml:10: glare.bloom: unknown key"), std::string::npos);
  EXPECT_NE(message("veiling_glare_index = 0.03\ncore_deg = 0.1\n").find("glare.reach_deg: required key is missing"),
            std::string::npos);
  EXPECT_NE(message("veiling_glare_index = 0.9\ncore_deg = 0.1\nreach_deg = 20\n").find("bad.toml:7: glare.veiling_glare_index"),
            std::string::npos);
  EXPECT_NE(message("veiling_glare_index = 0.03\ncore_deg = 5\nreach_deg = 2\n").find("must exceed the core"),
            std::string::npos);
}

}  // namespace
}  // namespace photosite
