// The sensor model: optics, photon integral, dark current, fixed pattern, read noise and ADC,
// sequences and determinism.
#include <gtest/gtest.h>

#include <limits>
#include <omp.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstring>
#include <functional>
#include <string>
#include <numeric>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <OpenImageIO/imageio.h>

#include "core/isa_detail.h"
#include "photosite/error.h"
#include "photosite/io.h"
#include "photosite/night_chain.h"
#include "photosite/sensor/cfa.h"
#include "photosite/sensor/fpn.h"
#include "photosite/sensor/pipeline.h"
#include "photosite/sensor/preset.h"
#include "photosite/sensor/spectrum.h"
#include "photosite/units.h"
#include "sensor/demosaic_detail.h"
#include "sensor/pixel_detail.h"
#include "test_util.h"

using namespace photosite;

namespace {
CameraPreset flat_qe_camera(double qe = 0.5) {
  CameraPreset p;
  p.name = "test-cam";
  p.file = "test-cam.toml";
  p.cfa = CfaPattern::RGGB;
  p.bit_depth = 12;
  p.pixel_pitch_um = 4.0;
  p.full_well_e = 20000;
  p.system_gain_dn_per_e = 0.2;
  p.read_noise_e = 3.0;
  p.black_level_dn = 64;
  p.temperature_c = 25;
  p.qe.wavelength_nm = {380, 720};
  for (int c = 0; c < 4; ++c) p.qe.qe[c] = {qe, qe};
  return p;
}
LensPreset simple_lens(bool cos4 = false) {
  LensPreset l;
  l.f_number = 2.0;
  l.transmittance = 1.0;
  l.cos4_falloff = cos4;
  return l;
}
double mean_of(const ImageF& img) {
  return std::accumulate(img.vec().begin(), img.vec().end(), 0.0) / img.size();
}
double var_of(const ImageF& img) {
  const double m = mean_of(img);
  double s = 0;
  for (float v : img.vec()) s += (v - m) * (v - m);
  return s / (img.size() - 1);
}
FixedPatternMaps no_fpn(const CameraPreset& p, int w, int h) {
  FixedPatternMaps m;
  m.preset_name = p.name;
  m.device_id = "test";
  m.device_seed = 7;
  m.width = w;
  m.height = h;
  return m;
}
}  // namespace

TEST(Optics, ImagePlaneIrradianceFollowsTheCameraEquation) {
  // E/L = π T / (1 + 4 (N(1+|m|))²). Exact: at these inputs every intermediate (q = 2 or 4,
  // 1 + 4q² = 17 or 65, π·1 and π·0.5) is exact in double, so both sides are the one rounding
  // of the same quotient.
  EXPECT_EQ(irradiance_per_radiance(2.0, 0.0, 1.0), units::pi / 17.0);
  EXPECT_EQ(irradiance_per_radiance(2.0, 1.0, 0.5), 0.5 * units::pi / 65.0);
}

TEST(PhotonIntegral, MatchesTheClosedFormForAFlatQe) {
  CameraPreset p = flat_qe_camera(0.5);
  LensPreset l = simple_lens();
  ExposureSettings s;
  s.exposure_s = 0.01;
  const auto ex = resolve(p, l, s);
  const auto m = photon_matrix(p, l, ex);
  // With constant QE the band integral is QE · mean(λ)/(hc) over the band = QE · λ_mid/(hc).
  const double area = std::pow(4e-6, 2), el = units::pi / 17.0;
  for (int k = 0; k < 3; ++k) {
    const double mid = 0.5 * (spectrum::kBandLoNm[k] + spectrum::kBandHiNm[k]);
    const double expect = 0.01 * area * el * 0.5 / units::photon_energy_J(mid);
    // λ/(hc) is linear in λ, so the code's 0.5 nm midpoint rule is exact on it: what is left is
    // double rounding, one rounding per term of the n-term sum (n·2⁻⁵³ relative, the recursive
    // summation bound) and about ten more in each product chain (energy, area, E/L, the scaling),
    // on both sides: 2·(n + 10)·2⁻⁵³, four times over (9e-14 for n = 200).
    const double n = (spectrum::kBandHiNm[k] - spectrum::kBandLoNm[k]) / 0.5;
    EXPECT_NEAR(m[0][k] / expect, 1.0, 4 * 2 * (n + 10) * 0x1p-53) << k;
  }
}

TEST(PhotonIntegral, Cos4FalloffDarkensTheCorners) {
  CameraPreset p = flat_qe_camera();
  LensPreset l = simple_lens(true);
  l.focal_length_mm = 2.0;
  ImageF radiance(201, 101, 3, 1.0f);
  const auto ex = resolve(p, l, ExposureSettings{});
  ImageF e = mean_signal_electrons(radiance, p, l, ex);
  // Same filter colour at the centre (100, 50) and a corner (0, 0).
  // The code computes each pixel in double and rounds it to float once (2⁻²⁴ relative each, two
  // in the ratio); double rounding adds ~1e-15. Twice that bounds it.
  const double r2 = (100.0 * 100 + 50.0 * 50) * std::pow(4e-3 / 2.0, 2), want = 1.0 / ((1 + r2) * (1 + r2));
  EXPECT_NEAR(e.at(0, 0) / e.at(100, 50), want, 2 * 2 * 0x1p-24 * want);
}

TEST(PhotonIntegral, RejectsNanInfAndNegativeRadiance) {
  CameraPreset p = flat_qe_camera();
  LensPreset l = simple_lens();
  const auto ex = resolve(p, l, ExposureSettings{});
  for (float bad : {std::nanf(""), INFINITY, -1.0f}) {
    ImageF r(8, 8, 3, 1.0f);
    r.at(5, 3, 1) = bad;
    try {
      mean_signal_electrons(r, p, l, ex);
      FAIL() << "accepted " << bad;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("(5, 3)"), std::string::npos) << e.what();
    }
  }
}

TEST(Exposure, ImpossibleSettingsAreBadInput) {
  CameraPreset p = flat_qe_camera();
  LensPreset l = simple_lens();
  ExposureSettings s;
  s.f_number = 0;
  EXPECT_THROW(resolve(p, l, s), Error);
  s = {};
  s.exposure_s = -1;
  EXPECT_THROW(resolve(p, l, s), Error);
  s = {};
  s.gain_db = 100;
  EXPECT_THROW(resolve(p, l, s), Error);
}

TEST(DarkCurrent, DoublesEveryDoublingTemperature) {
  CameraPreset p = flat_qe_camera();
  p.dark_current_e_per_s = 10;
  p.dark_current_reference_c = 25;
  p.dark_current_doubling_c = 6;
  ExposureSettings s;
  s.temperature_c = 37;
  // Exact: (37 − 25)/6 = 2 exactly, exp2(2) = 4 is representable (an exp2 within 1 ulp, as
  // glibc's, then returns it exactly) and 10 · 4 = 40.
  EXPECT_EQ(resolve(p, simple_lens(), s).dark_current_e_per_s, 40.0);
}

TEST(DarkCurrent, DarkFrameMeanAndShotNoiseGrowWithExposure) {
  CameraPreset p = flat_qe_camera();
  p.read_noise_e = 0.5;
  p.dark_current_e_per_s = 200;
  const int w = 256, h = 256;
  auto fpn = no_fpn(p, w, h);
  ImageF zero(w, h, 1, 0.f);
  for (double t : {0.1, 1.0}) {
    ExposureSettings s;
    s.exposure_s = t;
    const ResolvedExposure ex = resolve(p, simple_lens(), s);
    auto out = sense(zero, p, ex, s, fpn);
    // The dark charge is Poisson with mean μ = D t (D the resolved rate). Over n pixels the sample
    // mean has standard error √(μ/n); the sample variance s² has Var(s²) = (μ₄ − σ⁴)/n with the
    // Poisson μ₄ = μ + 3μ², so SE(s²/μ) = √((1/μ + 2)/n). Both within 5 standard errors.
    const double mu = ex.dark_current_e_per_s * t, n = static_cast<double>(w) * h;
    EXPECT_EQ(mu, 200 * t);  // no temperature scaling (exp2(0) = 1): the same product, exactly
    EXPECT_NEAR(mean_of(out.electrons), mu, 5 * std::sqrt(mu / n));
    EXPECT_NEAR(var_of(out.electrons) / mu, 1.0, 5 * std::sqrt((1 / mu + 2) / n));  // variance = mean
  }
}

TEST(Adc, QuantizationNoiseIsTheIdealTwelfth) {
  // A dark frame with read noise only: var(DN) = K² σ² + 1/12 (one rounding, no more).
  CameraPreset p = flat_qe_camera();
  p.read_noise_e = 2.0;
  p.system_gain_dn_per_e = 0.5;
  const int w = 512, h = 512;
  ImageF zero(w, h, 1, 0.f);
  ExposureSettings s;
  s.exposure_s = 0;
  auto out = sense(zero, p, resolve(p, simple_lens(), s), s, no_fpn(p, w, h));
  const double expect = 0.25 * 4.0 + 1.0 / 12;
  // Over n = 512² samples: the sample variance's relative standard error is sqrt(2 / n) = 0.28 %
  // (near-normal DN: kurtosis 3), the mean's sqrt(expect / n) = 0.0020 DN (the rounded normal
  // centred on the code 64 has mean 64 by symmetry); both within 5 SE.
  const double n = static_cast<double>(w) * h;
  EXPECT_NEAR(var_of(out.raw_dn), expect, 5 * std::sqrt(2 / n) * expect);
  EXPECT_NEAR(mean_of(out.raw_dn), 64.0, 5 * std::sqrt(expect / n));
  for (float v : out.raw_dn.vec()) ASSERT_EQ(v, std::floor(v));
}

TEST(Adc, FullWellAndAdcClip) {
  CameraPreset p = flat_qe_camera();
  const int w = 32, h = 32;
  ImageF huge(w, h, 1, 1e7f);
  ExposureSettings s;
  auto out = sense(huge, p, resolve(p, simple_lens(), s), s, no_fpn(p, w, h));
  for (size_t i = 0; i < out.electrons.size(); ++i) {
    ASSERT_EQ(out.electrons[i], 20000.f);
    ASSERT_LE(out.raw_dn[i], 4095.f);
  }
  // With a gain making the ADC clip first, every code is the maximum.
  s.gain_db = 12;
  out = sense(huge, p, resolve(p, simple_lens(), s), s, no_fpn(p, w, h));
  for (float v : out.raw_dn.vec()) ASSERT_EQ(v, 4095.f);
}

// A flat field far beyond full well through the clear patterns (F4 of the sensor-extremes
// exploration): every sample clipped carries no colour, so every pixel reads the white at the clip
// level, R = G = B = clip / 3 (neutralize_clipped_highlights), never G = -C (RCCB) or G = B = 0
// (RCCC, a saturated red), with the well clipping first and with the ADC clipping first (12 dB),
// for every method and on the bundled RCCC camera. An RGGB frame keeps the demosaic's bits.
TEST(ClipHighlights, BeyondFullWellTheClearPatternsReadNeutralAtTheClipLevel) {
  const int w = 32, h = 24;
  ImageF huge(w, h, 1, 1e7f);
  auto check = [&](const CameraPreset& p, const ExposureSettings& s, const SensorOutput& out, double neutral) {
    const std::string what = fmt::format("{} {} {} dB", p.name, to_string(s.demosaic), s.gain_db);
    const float want = static_cast<float>(clip_level(p, resolve(p, simple_lens(), s)).neutral_dn);
    // The clip level above black, over 3: the one rounding to float (2⁻²⁴ relative) and, before
    // it, at most two double roundings of FW·K (or the gain's 10^(dB/20)) over 3 (2⁻⁵³ each).
    EXPECT_NEAR(want, neutral, (0x1p-24 + 4 * 0x1p-53) * neutral) << what;
    for (size_t i = 0; i < out.rgb.size(); ++i) ASSERT_EQ(out.rgb[i], want) << what << " sample " << i;
  };
  for (CfaPattern cfa : {CfaPattern::RCCB, CfaPattern::RCCC})
    for (DemosaicMethod m : all_demosaic_methods())
      for (double gain_db : {0.0, 12.0}) {
        CameraPreset p = flat_qe_camera();
        p.cfa = cfa;
        p.dsnu_e = 2;
        p.row_noise_e = 1;
        ExposureSettings s;
        s.demosaic = m;
        s.gain_db = gain_db;
        const SensorOutput out = sense(huge, p, resolve(p, simple_lens(), s), s, generate_fixed_pattern(p, w, h, "clip"));
        // FW·K = 20000 · 0.2 = 4000 DN; at 12 dB the ADC's top code 4095 less the black level 64.
        check(p, s, out, gain_db == 0 ? 4000.0 / 3 : (4095.0 - 64) / 3);
      }
  const CameraPreset rccc = load_camera_preset("onsemi-ar0132at-rccc");
  ExposureSettings s;
  const SensorOutput out = flat_field(1e7, 525, w, h, rccc, simple_lens(), s, generate_fixed_pattern(rccc, w, h, "clip"));
  check(rccc, s, out, std::min(rccc.full_well_e * rccc.system_gain_dn_per_e, std::ldexp(1.0, rccc.bit_depth) - 1 - rccc.black_level_dn) / 3);
  CameraPreset bayer = flat_qe_camera();
  const SensorOutput b = sense(huge, bayer, resolve(bayer, simple_lens(), s), s, no_fpn(bayer, w, h));
  ImageF above_black(w, h, 1);
  for (size_t i = 0; i < above_black.size(); ++i) above_black[i] = b.raw_dn[i] - static_cast<float>(bayer.black_level_dn);
  EXPECT_EQ(b.rgb.vec(), demosaic(above_black, bayer.cfa).vec());
}

// A mean signal beyond float (+Inf: a radiance or photon count near float's largest value, which
// the radiance check lets through when each band is finite) or merely enormous fills the well and
// reads the saturation code, with every Poisson sampler, on the CPU: sense_mean_e holds the mean
// at 2^31 e⁻ (kernels/common/sensor_pixel.glsl). Before, the exact sampler drew NaN (the run
// failed in the EXR writer, exit 1), and Cornish-Fisher and the rounded normal read 0 e⁻, black.
TEST(Adc, AnOverflowedSignalSaturatesThePixel) {
  CameraPreset p = flat_qe_camera();
  const int w = 16, h = 16;
  ImageF sig(w, h, 1, 100.f);
  const float kInf = std::numeric_limits<float>::infinity();
  const float big[] = {kInf, 3.4e38f, 1e34f, 2147483648.f, 1e12f};
  for (int i = 0; i < w * h; i += 7) sig[i] = big[(i / 7) % 5];
  for (PoissonMethod m : {PoissonMethod::Exact, PoissonMethod::CornishFisher, PoissonMethod::Normal}) {
    ExposureSettings s;
    s.poisson = m;
    const auto out = sense(sig, p, resolve(p, simple_lens(), s), s, no_fpn(p, w, h));
    // Full well 20000 e⁻ at K = 0.2 DN/e⁻ above black 64: 4064 DN ± read noise (3 e⁻ = 0.6 DN,
    // so ±4 DN is over 6σ).
    for (int i = 0; i < w * h; ++i) {
      ASSERT_TRUE(std::isfinite(out.electrons[i])) << to_string(m) << " pixel " << i;
      if (i % 7 == 0) {
        ASSERT_EQ(out.electrons[i], 20000.f) << to_string(m) << " pixel " << i << " mean " << sig[i];
        // (±4 DN: over 6σ of the 0.6 DN read noise, above)
        ASSERT_NEAR(out.raw_dn[i], 64 + 0.2 * 20000, 4) << to_string(m) << " pixel " << i;
      } else {
        ASSERT_LT(out.electrons[i], 200.f) << to_string(m) << " pixel " << i;
      }
    }
  }
}

TEST(Adc, SignalMeanFollowsGainAndBlackLevel) {
  CameraPreset p = flat_qe_camera();
  const int w = 256, h = 256;
  ImageF sig(w, h, 1, 1000.f);
  ExposureSettings s;
  s.gain_db = 6.0206;  // ×2
  auto out = sense(sig, p, resolve(p, simple_lens(), s), s, no_fpn(p, w, h));
  // DN variance K²(μ + σ_read²) + 1/12 with K = 0.4 DN/e⁻ (6.0206 dB is ×2 to 4e-6, which moves the
  // mean by 0.0007 DN). Over n pixels the mean's standard error is √(var/n) = 0.050 DN and the
  // sample variance's var·√(2/n) (kurtosis 3 + 1/μ: near normal); both within 5 SE.
  const double var = 0.16 * (1000 + 9) + 1.0 / 12, n = static_cast<double>(w) * h;
  EXPECT_NEAR(mean_of(out.raw_dn), 64 + 0.4 * 1000, 5 * std::sqrt(var / n));
  EXPECT_NEAR(var_of(out.raw_dn), var, 5 * std::sqrt(2 / n) * var);
}

TEST(FixedPattern, MapsHaveTheirStatisticsAndAreDeterministic) {
  CameraPreset p = flat_qe_camera();
  p.prnu_percent = 1.5;
  p.dsnu_e = 4.0;
  p.dark_current_e_per_s = 10;
  p.dark_current_nonuniformity_percent = 30;
  auto a = generate_fixed_pattern(p, 300, 200, "unit-a");
  auto b = generate_fixed_pattern(p, 300, 200, "unit-a");
  auto c = generate_fixed_pattern(p, 300, 200, "unit-b");
  EXPECT_EQ(a.checksum, b.checksum);
  EXPECT_NE(a.checksum, c.checksum);
  // n independent draws (sensor/fpn.cpp): the mean's standard error is σ/√n; the sample standard
  // deviation's is σ·√((β₂ − 1)/n)/2 (delta method on Var(s²) = (μ₄ − σ⁴)/n, β₂ the kurtosis):
  // σ/√(2n) for the normal PRNU and DSNU maps. The dark-rate factor is lognormal with mean 1 and
  // cv 0.3: β₂ = e^{4s²} + 2e^{3s²} + 3e^{2s²} − 3 with s² = ln(1 + cv²). All within 5 SE.
  const double n = 300.0 * 200;
  auto se_sd = [n](double sigma, double beta2) { return sigma * std::sqrt((beta2 - 1) / n) / 2; };
  const double s2 = std::log1p(0.3 * 0.3);
  const double beta2_ln = std::exp(4 * s2) + 2 * std::exp(3 * s2) + 3 * std::exp(2 * s2) - 3;
  // (5 SE each: σ/√n for the means, σ·√((β₂ − 1)/n)/2 for the SDs, above)
  EXPECT_NEAR(mean_of(a.prnu_gain), 1.0, 5 * 0.015 / std::sqrt(n));
  EXPECT_NEAR(std::sqrt(var_of(a.prnu_gain)), 0.015, 5 * se_sd(0.015, 3));
  EXPECT_NEAR(mean_of(a.dsnu_offset_e), 0.0, 5 * 4.0 / std::sqrt(n));
  EXPECT_NEAR(std::sqrt(var_of(a.dsnu_offset_e)), 4.0, 5 * se_sd(4.0, 3));
  EXPECT_NEAR(mean_of(a.dark_rate_factor), 1.0, 5 * 0.30 / std::sqrt(n));
  EXPECT_NEAR(std::sqrt(var_of(a.dark_rate_factor)), 0.30, 5 * se_sd(0.30, beta2_ln));
  // Stages the preset does not ask for are skipped: no maps at all.
  auto none = generate_fixed_pattern(flat_qe_camera(), 30, 20, "unit-a");
  EXPECT_TRUE(none.prnu_gain.empty() && none.dsnu_offset_e.empty() && none.dark_rate_factor.empty());
}

TEST(FixedPattern, HotPixelsAppearAtTheirFraction) {
  CameraPreset p = flat_qe_camera();
  p.dark_current_e_per_s = 10;
  p.hot_pixel_fraction = 0.01;
  p.hot_pixel_dark_current_e_per_s = 1000;
  auto m = generate_fixed_pattern(p, 400, 250, "hot");
  size_t hot = 0;
  for (float f : m.dark_rate_factor.vec()) hot += f > 50;
  // Each pixel is hot with probability 0.01 on its own (sensor/fpn.cpp): the binomial standard
  // error of the fraction over 1e5 pixels is sqrt(0.01 · 0.99 / 1e5) = 3.1e-4; within 5 SE.
  const double n = 400.0 * 250, f = 0.01;
  EXPECT_NEAR(hot / n, f, 5 * std::sqrt(f * (1 - f) / n));
}

// A camera with PRNU (1 %) and DSNU (2 e-): a device map with two channels.
static CameraPreset fpn_camera() {
  CameraPreset p = flat_qe_camera();
  p.prnu_percent = 1;
  p.dsnu_e = 2;
  return p;
}
// 64 bytes near a file's end overwritten in place (same inode and size; the time moves).
static void corrupt_in_place(const std::string& path) {
  std::FILE* f = std::fopen(path.c_str(), "r+b");
  ASSERT_TRUE(f);
  std::fseek(f, -200, SEEK_END);
  const char junk[64] = "corrupted bytes corrupted bytes corrupted bytes corrupted by";
  std::fwrite(junk, 1, sizeof junk, f);
  std::fclose(f);
}

TEST(DeviceStore, CreatesOnceReusesAndRefusesMismatches) {
  test::TempDir dir;
  const CameraPreset p = fpn_camera();
  DeviceStore store(dir.path().string());
  auto a = store.load_or_create(p, "cam7", 64, 48);
  const std::string path = store.path_for(p, "cam7", 64, 48);
  ASSERT_TRUE(std::filesystem::exists(path));
  const auto mtime = std::filesystem::last_write_time(path);
  auto b = store.load_or_create(p, "cam7", 64, 48);
  EXPECT_EQ(a.checksum, b.checksum);
  EXPECT_EQ(a.prnu_gain.vec(), b.prnu_gain.vec());
  EXPECT_EQ(std::filesystem::last_write_time(path), mtime);  // reused, not rewritten
  // Another preset's parameters against the same file: an error, and the file is untouched.
  CameraPreset q = p;
  q.prnu_percent = 2;
  EXPECT_THROW(store.load(path, q, "cam7", 64, 48), Error);
  EXPECT_THROW(store.load(path, p, "cam7", 32, 48), Error);
  q = p;
  q.name = "other";
  EXPECT_THROW(store.load(path, q, "cam7", 64, 48), Error);
  EXPECT_THROW(store.load_or_create(p, "bad/id", 64, 48), Error);
  // A corrupted map is an error, never silently regenerated.
  corrupt_in_place(path);
  EXPECT_THROW(store.load_or_create(p, "cam7", 64, 48), Error);
  EXPECT_TRUE(std::filesystem::exists(path));
}

// image_from_codes (the Python faces' codes to floats) by its table: every sample as OIIO's own
// conversion of that sample, for every 8- and 16-bit code, at 1 and 2 threads, on an odd size.
TEST(ImageFromCodes, IsOiiosConversionOfEveryCode) {
  const int saved_threads = omp_get_max_threads();
  for (int bits : {8, 16}) {
    const int W = 257, H = 131, C = 3;  // 101,001 samples: every 16-bit code at least once
    std::vector<uint16_t> c16(static_cast<size_t>(W) * H * C);
    std::vector<uint8_t> c8(c16.size());
    for (size_t i = 0; i < c16.size(); ++i) {
      c16[i] = static_cast<uint16_t>((i * 40503u) & 0xffffu);  // odd multiplier: a permutation
      c8[i] = static_cast<uint8_t>(i * 7u);
    }
    const void* codes = bits == 8 ? static_cast<const void*>(c8.data()) : static_cast<const void*>(c16.data());
    std::vector<float> ref(c16.size());
    ASSERT_TRUE(OIIO::convert_pixel_values(bits == 8 ? OIIO::TypeDesc::UINT8 : OIIO::TypeDesc::UINT16, codes,
                                           OIIO::TypeDesc::FLOAT, ref.data(), static_cast<int>(ref.size())));
    for (int threads : {1, 2}) {
      omp_set_num_threads(threads);
      const ImageF img = image_from_codes(codes, bits, W, H, C);
      ASSERT_EQ(img.size(), ref.size());
      EXPECT_EQ(std::memcmp(img.data(), ref.data(), ref.size() * sizeof(float)), 0) << bits << "-bit, " << threads;
    }
  }
  omp_set_num_threads(saved_threads);
}

// keep_loaded (the Python Camera's store): a later load of an unchanged file is answered from
// memory, so bytes damaged in place behind the same size and modification time go unseen by it
// but not by a store that reads the file; once the file's modification time (or inode, size)
// changes, the file is read and verified again. A copy of the store shares what it keeps; other
// parameters or another device id never take a kept map.
TEST(DeviceStore, KeepLoadedAnswersFromMemoryWhileTheFileIsUnchanged) {
  test::TempDir dir;
  const CameraPreset p = fpn_camera();
  DeviceStore kept(dir.path().string());
  kept.keep_loaded(true);
  const auto a = kept.load_or_create(p, "cam7", 64, 48);  // made, and kept
  const std::string path = kept.path_for(p, "cam7", 64, 48);
  const auto mtime = std::filesystem::last_write_time(path);
  corrupt_in_place(path);
  std::filesystem::last_write_time(path, mtime);  // same inode, size and time: unchanged to stat
  const DeviceStore copy = kept;
  const auto b = copy.load_or_create(p, "cam7", 64, 48);
  EXPECT_EQ(b.checksum, a.checksum);
  EXPECT_EQ(b.prnu_gain.vec(), a.prnu_gain.vec());
  EXPECT_EQ(b.dsnu_offset_e.vec(), a.dsnu_offset_e.vec());
  EXPECT_THROW(DeviceStore(dir.path().string()).load_or_create(p, "cam7", 64, 48), Error);  // reads the file
  CameraPreset q = p;
  q.prnu_percent = 2;
  EXPECT_THROW(kept.load_or_create(q, "cam7", 64, 48), Error);  // other parameters: the file, refused
  std::filesystem::last_write_time(path, mtime + std::chrono::seconds(1));
  EXPECT_THROW(kept.load_or_create(p, "cam7", 64, 48), Error);  // changed: read again, and refused
  // At most 4 maps kept, the least recently used going first: of five sizes, the first one made
  // is read from its file again (its damage seen), the most recent still kept (its damage not).
  DeviceStore few((dir.path() / "few").string());
  few.keep_loaded(true);
  for (int w : {40, 41, 42, 43, 44}) few.load_or_create(p, "cam8", w, 30);
  for (int w : {40, 44}) {
    const std::string pw = few.path_for(p, "cam8", w, 30);
    const auto t = std::filesystem::last_write_time(pw);
    corrupt_in_place(pw);
    std::filesystem::last_write_time(pw, t);
  }
  EXPECT_THROW(few.load_or_create(p, "cam8", 40, 30), Error);
  EXPECT_NO_THROW(few.load_or_create(p, "cam8", 44, 30));
}

// Maps are written uncompressed (sensor/fpn.cpp: noise does not deflate); a map that an earlier
// version wrote with ZIP, same attributes and pixels, still loads to the same maps.
TEST(DeviceStore, WritesUncompressedWithXxh3AndReadsEarlierZipFnvMaps) {
  test::TempDir dir;
  const CameraPreset p = fpn_camera();
  DeviceStore store((dir.path() / "new").string());
  const auto a = store.load_or_create(p, "cam7", 64, 48);
  const std::string path = store.path_for(p, "cam7", 64, 48);
  {
    auto in = OIIO::ImageInput::open(path);
    ASSERT_TRUE(in);
    EXPECT_EQ(in->spec().get_string_attribute("compression"), "none");
  }
  // Both checksums recorded: FNV-1a 64 (the identity outputs carry) and XXH3-64 (verified).
  ExrContents c = read_exr(path);
  EXPECT_EQ(c.attributes.at("photosite/checksum"), fixed_pattern_checksum(a, ChecksumAlgorithm::Fnv1a_64));
  EXPECT_EQ(c.attributes.at("photosite/checksum_xxh3_64"), fixed_pattern_checksum(a, ChecksumAlgorithm::Xxh3_64));
  EXPECT_EQ(a.checksum, c.attributes.at("photosite/checksum"));
  EXPECT_EQ(a.checksum_xxh3, c.attributes.at("photosite/checksum_xxh3_64"));
  const auto reloaded = store.load_or_create(p, "cam7", 64, 48);
  EXPECT_EQ(reloaded.checksum, a.checksum);
  EXPECT_EQ(reloaded.checksum_xxh3, a.checksum_xxh3);
  // The same maps rewritten as the store wrote them before (ZIP, the FNV-1a only), or with one
  // checksum damaged, each into a store of its own.
  std::vector<ExrChannelGroup> groups;
  for (const char* ch : {"prnu.Y", "dsnu.Y", "dark_rate.Y"})
    if (c.channels.count(ch)) groups.push_back({{ch}, &c.channels.at(ch), ""});
  ASSERT_FALSE(groups.empty());
  auto rewritten = [&](const std::string& store_name, const std::string& fnv, const std::string& xxh3) {
    std::map<std::string, ExrAttribute> attrs;
    for (const char* k : {"photosite/version", "photosite/preset", "photosite/device_id", "photosite/fpn_params"})
      attrs[k] = c.attributes.at(k);
    attrs["photosite/checksum"] = fnv;
    if (!xxh3.empty()) attrs["photosite/checksum_xxh3_64"] = xxh3;
    DeviceStore s((dir.path() / store_name).string());
    const std::string old_path = s.path_for(p, "cam7", 64, 48);
    std::filesystem::create_directories(std::filesystem::path(old_path).parent_path());
    ExrWriteOptions wo;
    wo.compression = "zip";
    EXPECT_TRUE(write_exr(old_path, groups, attrs, wo));
    return s;
  };
  const DeviceStore old_store = rewritten("old", a.checksum, "");
  {
    auto in = OIIO::ImageInput::open(old_store.path_for(p, "cam7", 64, 48));
    ASSERT_TRUE(in);
    EXPECT_EQ(in->spec().get_string_attribute("compression"), "zip");
  }
  const auto b = old_store.load_or_create(p, "cam7", 64, 48);
  EXPECT_EQ(b.checksum, a.checksum);
  EXPECT_TRUE(b.checksum_xxh3.empty());
  EXPECT_EQ(a.prnu_gain.vec(), b.prnu_gain.vec());
  EXPECT_EQ(a.dsnu_offset_e.vec(), b.dsnu_offset_e.vec());
  EXPECT_EQ(a.dark_rate_factor.vec(), b.dark_rate_factor.vec());
  const std::string flipped_fnv = a.checksum.substr(0, 15) + (a.checksum.back() == '0' ? "1" : "0");
  const std::string flipped_xxh3 = a.checksum_xxh3.substr(0, 15) + (a.checksum_xxh3.back() == '0' ? "1" : "0");
  const DeviceStore bad_old = rewritten("bad_old", flipped_fnv, "");
  const std::string e1 = test::error_of([&] { bad_old.load_or_create(p, "cam7", 64, 48); });
  EXPECT_NE(e1.find("corrupt (FNV-1a 64 checksum"), std::string::npos) << e1;
  const DeviceStore bad_new = rewritten("bad_new", a.checksum, flipped_xxh3);
  const std::string e2 = test::error_of([&] { bad_new.load_or_create(p, "cam7", 64, 48); });
  EXPECT_NE(e2.find("corrupt (XXH3-64 checksum"), std::string::npos) << e2;
}

TEST(Sequence, FramesShareFixedPatternAndHaveIndependentTemporalNoise) {
  CameraPreset p = flat_qe_camera();
  p.prnu_percent = 2;
  p.dsnu_e = 5;
  const int w = 256, h = 128;
  auto fpn = generate_fixed_pattern(p, w, h, "seq");
  ImageF sig(w, h, 1, 500.f);
  ExposureSettings s;
  const auto ex = resolve(p, simple_lens(), s);
  s.frame = 0;
  auto f0 = sense(sig, p, ex, s, fpn);
  s.frame = 1;
  auto f1 = sense(sig, p, ex, s, fpn);
  s.frame = 0;
  auto f0b = sense(sig, p, ex, s, fpn);
  EXPECT_EQ(f0.raw_dn.vec(), f0b.raw_dn.vec());  // same seed and frame: bit for bit
  EXPECT_NE(f0.raw_dn.vec(), f1.raw_dn.vec());
  // Temporal parts (frame minus the two-frame mean) are uncorrelated; the fixed pattern is
  // shared, so the frames themselves correlate through it.
  double sab = 0, saa = 0, sbb = 0, cab = 0;
  const double m0 = mean_of(f0.raw_dn), m1 = mean_of(f1.raw_dn);
  for (size_t i = 0; i < f0.raw_dn.size(); ++i) {
    const double a = f0.raw_dn[i] - m0, b = f1.raw_dn[i] - m1;
    sab += a * b;
    saa += a * a;
    sbb += b * b;
  }
  const double corr = sab / std::sqrt(saa * sbb);
  // Expected correlation = FPN variance / total variance (PRNU 2% of 500 e- = 10 e-, DSNU 5 e-;
  // shot 500 e-, read 3 e-), in DN: K² times each, and the rounding's 1/12 DN² temporal. A sample
  // correlation of n pairs has standard error (1 − ρ²)/√n (normal pairs, to first order); the
  // map's own sample variance (relative SE √(2/n) = 0.8 %) moves ρ by less than 0.2 of that.
  // Within 5 SE.
  const double K = p.system_gain_dn_per_e, fpn_var = K * K * (100 + 25), temporal = K * K * (500 + 9) + 1.0 / 12;
  const double rho = fpn_var / (fpn_var + temporal), n = static_cast<double>(w) * h;
  EXPECT_NEAR(corr, rho, 5 * (1 - rho * rho) / std::sqrt(n));
  (void)cab;
}

TEST(Sequence, IndependentOfThreadCount) {
  CameraPreset p = flat_qe_camera();
  p.prnu_percent = 1;
  p.row_noise_e = 1;
  const int w = 300, h = 170;
  auto fpn = generate_fixed_pattern(p, w, h, "thr");
  ImageF sig(w, h, 1);
  for (size_t i = 0; i < sig.size(); ++i) sig[i] = static_cast<float>(i % 997) * 3.0f;
  ExposureSettings s;
  s.seed = 99;
  const auto ex = resolve(p, simple_lens(), s);
  const int saved = omp_get_max_threads();
  omp_set_num_threads(1);
  auto a = sense(sig, p, ex, s, fpn);
  omp_set_num_threads(4);
  auto b = sense(sig, p, ex, s, fpn);
  omp_set_num_threads(saved);
  EXPECT_EQ(a.raw_dn.vec(), b.raw_dn.vec());
  EXPECT_EQ(a.rgb.vec(), b.rgb.vec());
}

TEST(ReadNoise, TukeyLambdaHasTheStatedStandardDeviationAndHeavierTails) {
  CameraPreset p = flat_qe_camera();
  p.read_noise_e = 4.0;
  p.read_noise_tukey_lambda = -0.1;
  p.system_gain_dn_per_e = 4.0;  // fine DN steps so the read noise dominates quantization
  p.bit_depth = 16;
  p.black_level_dn = 2000;
  const int w = 512, h = 512;
  ImageF zero(w, h, 1, 0.f);
  ExposureSettings s;
  s.exposure_s = 0;
  auto out = sense(zero, p, resolve(p, simple_lens(), s), s, no_fpn(p, w, h));
  const double sd_e = std::sqrt(var_of(out.raw_dn) - 1.0 / 12) / 4.0;
  const double m = mean_of(out.raw_dn);
  double m2 = 0, m4 = 0, m6 = 0, m8 = 0;
  for (float v : out.raw_dn.vec()) {
    const double d = v - m, d2 = d * d;
    m2 += d2;
    m4 += d2 * d2;
    m6 += d2 * d2 * d2;
    m8 += d2 * d2 * d2 * d2;
  }
  const double n = out.raw_dn.size();
  m2 /= n;
  m4 /= n;
  m6 /= n;
  m8 /= n;
  // The sample standard deviation's standard error is σ·√((β₂ − 1)/n)/2 (Var(s²) = (μ₄ − σ⁴)/n
  // and the delta method), β₂ the kurtosis, here the sample's own m₄/m₂²; the rounding's 1/12 DN²
  // is Sheppard's correction, exact to far below that at σ = 16 DN. Within 5 SE.
  const double beta2 = m4 / (m2 * m2);
  EXPECT_NEAR(sd_e, 4.0, 5 * 4.0 * std::sqrt((beta2 - 1) / n) / 2);
  // The kurtosis itself, against the Tukey-λ law's: its raw moments (mean 0 by symmetry) are
  // E[Q^k] = λ^-k Σ_j C(k, j)(−1)^j B(λ(k − j) + 1, λj + 1) for λk > −1 (Q(u) = (u^λ − (1 − u)^λ)/λ),
  // so β₂ = E[Q⁴]/E[Q²]² = 6.79 at λ = −0.1 (a Gaussian has 3). Rounding to DN moves m₄ by
  // Sheppard's m₂/2 + 7/240, 3e-4 of it at σ = 16 DN. The sample kurtosis b₂ = m₄/m₂² has, by the
  // delta method for a symmetric law, Var(b₂) = (μ₈/μ₂⁴ − 4μ₄μ₆/μ₂⁵ + 4μ₄³/μ₂⁶ − μ₄²/μ₂⁴)/n,
  // taken with the sample's own moments (the law's μ₈ exists for λ > −1/8); within 5 SE.
  auto beta_fn = [](double a, double b) { return std::exp(std::lgamma(a) + std::lgamma(b) - std::lgamma(a + b)); };
  auto tukey_moment = [&](int k, double lam) {
    double sum = 0, binom = 1;
    for (int j = 0; j <= k; ++j) {
      sum += (j % 2 ? -1 : 1) * binom * beta_fn(lam * (k - j) + 1, lam * j + 1);
      binom = binom * (k - j) / (j + 1);
    }
    return sum / std::pow(lam, k);
  };
  const double lam = p.read_noise_tukey_lambda, beta2_model = tukey_moment(4, lam) / std::pow(tukey_moment(2, lam), 2);
  const double var_b2 = (m8 / std::pow(m2, 4) - 4 * m4 * m6 / std::pow(m2, 5) + 4 * std::pow(m4, 3) / std::pow(m2, 6) -
                         m4 * m4 / std::pow(m2, 4)) / n;
  std::printf("Tukey lambda %g: sample kurtosis %.3f, the law's %.3f, SE %.3f\n", lam, beta2, beta2_model, std::sqrt(var_b2));
  // 5 SE of the sample kurtosis (var_b2: the delta-method variance above).
  EXPECT_NEAR(beta2, beta2_model, 5 * std::sqrt(var_b2));
  EXPECT_GT(beta2_model, 3 + 5 * std::sqrt(var_b2));  // heavier tails than a Gaussian's, beyond the noise
}

TEST(Spectrum, BandEfficaciesAndConversions) {
  const auto& e = spectrum::band_luminous_efficacy_lm_per_W();
  EXPECT_GT(e[1], e[0]);  // green band is the most efficient
  EXPECT_GT(e[1], e[2]);
  // CIE 1924 V(λ) at 10 nm from 500 to 600 nm (CIE 15:2004 table), Simpson mean 0.8096. The code
  // integrates the Wyman et al. fit of ȳ (spectrum.cpp); Simpson's weights are positive and sum
  // to 1, so the two means differ by at most the fit's largest deviation from the table at its
  // nodes (0.0066 at 500 nm, computed here) plus Simpson's own error on the smooth fit,
  // h⁴/180·max|f⁗| ≈ 1e4/180 · 3/45⁴ nm⁻⁴ = 4e-5 (ȳ is about a Gaussian of σ = 45 nm).
  const double v[11] = {0.323, 0.503, 0.710, 0.862, 0.954, 0.995, 0.995, 0.952, 0.870, 0.757, 0.631};
  double vm = 0, worst_node = 0;
  for (int i = 0; i <= 10; ++i) {
    vm += (i == 0 || i == 10 ? 1 : i % 2 ? 4 : 2) * v[i] / 30;
    worst_node = std::max(worst_node, std::fabs(spectrum::cie_y_bar(500 + 10 * i) - v[i]));
  }
  // The fit's worst node deviation plus Simpson's error (4e-5, above), relative to the table's mean.
  EXPECT_NEAR(e[1] / (683.0 * vm), 1.0, (worst_node + 4e-5) / vm);
  // The luminance of the rounded-to-float colour: each band is off by at most 2⁻²⁴ relative, and
  // the terms are all positive, so the sum is off by at most 2⁻²⁴ of it (twice that for the double
  // arithmetic around it).
  const auto rgb = spectrum::blackbody_rgb(3000, 2.5);
  const float f[3] = {float(rgb[0]), float(rgb[1]), float(rgb[2])};
  EXPECT_NEAR(spectrum::luminance_cd_m2(f), 2.5, 2 * 2.5 * 0x1p-24);
  EXPECT_GT(rgb[0], rgb[2]);  // warm light: more red than blue
  const auto& a = spectrum::box_to_linear_srgb();
  const auto& b = spectrum::linear_srgb_to_box();
  // A·A⁻¹ = I to the rounding of the inverse (the adjugate over the determinant, spectrum.cpp):
  // each cofactor is two products and a difference, the determinant three more terms and the
  // quotient one rounding, so each entry of the computed inverse is off by at most about
  // 10u·κ(A)·|A⁻¹| (u = 2⁻⁵³, κ the ∞-norm condition number; Higham 2002, §14.1, the forward error
  // of an inverse ∝ κu); the check's own three-term sum adds γ₃·(|A||A⁻¹|) ≤ 3u·‖A‖‖A⁻¹‖. Both
  // under 16u·κ(A) per entry of the product; the bound is twice that.
  double norm_a = 0, norm_b = 0;
  for (int i = 0; i < 3; ++i) {
    norm_a = std::max(norm_a, std::fabs(a[i][0]) + std::fabs(a[i][1]) + std::fabs(a[i][2]));
    norm_b = std::max(norm_b, std::fabs(b[i][0]) + std::fabs(b[i][1]) + std::fabs(b[i][2]));
  }
  const double inverse_bound = 2 * 16 * 0x1p-53 * norm_a * norm_b;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      double s = 0;
      for (int k = 0; k < 3; ++k) s += a[i][k] * b[k][j];
      EXPECT_NEAR(s, i == j ? 1.0 : 0.0, inverse_bound) << i << "," << j;
    }
  // The sRGB luminance row of box → sRGB equals the band efficacies: exactly, for the luminance
  // row of the inverse of the XYZ→sRGB matrix spectrum.cpp uses (IEC 61966-2-1), here to 14
  // digits (Rec. 709's 0.2126, 0.7152, 0.0722 round it to 4, which moves y by up to 4e-4). The
  // tolerance: those 14 digits (5e-15 each) and the double rounding of the three-term sums.
  const double w[3] = {0.21267284631836, 0.71515216715488, 0.07217499957321};
  for (int k = 0; k < 3; ++k) {
    double y = 0, bound = 0;
    for (int i = 0; i < 3; ++i) {
      y += w[i] * a[i][k];
      bound += (5e-15 + 16 * 0x1p-53 * w[i]) * std::fabs(a[i][k]);
    }
    EXPECT_NEAR(y / e[k], 1.0, bound / e[k]) << k;
  }
}

// blackbody_rgb keeps each thread's last few temperatures' band integrals (spectrum.cpp): every
// result must be the definition's bits, the integrals of Planck's law (project_to_rgb) scaled to
// the luminance, whatever was asked before it. Twelve temperatures (more than are kept, so entries
// are replaced) asked in three orders, each at three luminances, and ±0 K, whose integrals differ
// (hc/(λk·T) is ±∞ there): every answer bit for bit the definition's, on each of two threads.
TEST(Spectrum, BlackbodyRgbIsItsDefinitionWhateverWasAskedBefore) {
  auto definition = [](double T, double L) {
    std::array<double, 3> rgb = spectrum::project_to_rgb([T](double l) { return spectrum::planck_W_sr_m2_nm(l, T); });
    const auto& e = spectrum::band_luminous_efficacy_lm_per_W();
    const double lum = e[0] * rgb[0] + e[1] * rgb[1] + e[2] * rgb[2];
    for (auto& v : rgb) v *= L / lum;
    return rgb;
  };
  std::vector<double> temps;
  for (int i = 0; i < 12; ++i) temps.push_back(1900.0 + 450.0 * i);
  std::vector<double> order = temps;
  for (const double T : temps) order.push_back(T);                    // again, in order
  for (auto it = temps.rbegin(); it != temps.rend(); ++it) order.push_back(*it);  // reversed
  for (int i = 0; i < 12; ++i) order.push_back(temps[(5 * i) % 12]);  // strided
  for (int i = 0; i < 6; ++i) order.push_back(temps[i % 2]);          // two alternating
  order.push_back(0.0);
  order.push_back(-0.0);
  order.push_back(0.0);
  const auto want0 = definition(0.0, 1.0), wantm0 = definition(-0.0, 1.0);
  EXPECT_NE(std::memcmp(want0.data(), wantm0.data(), sizeof want0), 0) << "+0 and -0 K integrate alike: not a case";
  long checked = 0;
#pragma omp parallel num_threads(2) reduction(+ : checked)
  for (const double T : order)
    for (const double L : {1.0, 2.5, 4e4}) {
      const auto got = spectrum::blackbody_rgb(T, L), want = definition(T, L);
      for (int k = 0; k < 3; ++k) {
        EXPECT_EQ(std::bit_cast<uint64_t>(got[k]), std::bit_cast<uint64_t>(want[k])) << T << " K, " << L << ", band " << k;
        ++checked;
      }
    }
  EXPECT_EQ(checked, 2 * 3 * 3 * static_cast<long>(order.size()));
}

// CIE illuminant HP1 (high-pressure sodium) in the box basis (spectrum::hp1_rgb): the band ratios
// are those scripts/lamp_spectra.py prints from the CIE 015:2018 table (B/R 0.223395, G/R 1.945392,
// printed to 6 decimals: within 5e-7 of the table's), and the luminance luminance_cd_m2 reads back
// from the float radiance is the one asked: each channel stored as float (2^-24 relative) and
// summed with positive weights (so within 2^-24 of the sum), plus the double scaling (a few 2^-53).
TEST(Spectrum, Hp1IsTheCieTablesBandsAtTheAskedLuminance) {
  const double* b = spectrum::kHp1BandIntegral;
  EXPECT_NEAR(b[2] / b[0], 0.223395, 5e-7);
  EXPECT_NEAR(b[1] / b[0], 1.945392, 5e-7);
  for (const double L : {1.0, 2.5, 7909.0, 4e4}) {
    const auto rgb = spectrum::hp1_rgb(L);
    // Each channel one double product of the table's value: the ratios to 2·2^-53 relative.
    EXPECT_NEAR(rgb[2] / rgb[0], b[2] / b[0], 4 * 0x1p-53 * (b[2] / b[0])) << L;
    EXPECT_NEAR(rgb[1] / rgb[0], b[1] / b[0], 4 * 0x1p-53 * (b[1] / b[0])) << L;
    const float f[3] = {static_cast<float>(rgb[0]), static_cast<float>(rgb[1]), static_cast<float>(rgb[2])};
    // (2⁻²⁴ for the float radiance, 8·2⁻⁵³ for the double scaling: derived above the test)
    EXPECT_NEAR(spectrum::luminance_cd_m2(f), L, (0x1p-24 + 8 * 0x1p-53) * L) << L;
  }
  // Not a Planck radiator at any CCT: where a black body's B/R is within half of HP1's (0.11-0.34,
  // 2400-3300 K) its G/R is below half of HP1's (sodium's D line puts twice R's power in G).
  for (double T = 1000; T <= 20000; T += 50) {
    const auto p = spectrum::blackbody_rgb(T, 1.0);
    if (std::fabs(p[2] / p[0] - b[2] / b[0]) < 0.5 * b[2] / b[0]) EXPECT_LT(p[1] / p[0], b[1] / b[0] / 2) << T << " K";
  }
}

namespace {
// A camera metamer w of a spectrum S(λ) (camera_metamer_rgb), checked through the camera's own
// photon matrix M (photon_matrix, what the sensor multiplies band radiance by): every filter
// colour's electrons come out in the same ratios as S's own, the spectrum's photon integral done
// here independently (0.5-nm midpoints of S(λ)·QE_c(λ)·λ/(hc) over 380-780 nm): a few hundred
// positive double terms a side (≤ 10³·2⁻⁵³ relative each) and a 3x3 solve (the matrices'
// condition numbers are below 10³): 10⁻⁹ relative. The radiances are non-negative, not all 0.
// Returns the spectrum's electrons per filter colour (0 where the camera has none).
std::array<double, 4> expect_metamer_gives_raw_colour(const CameraPreset& cam, const PhotonMatrix& M,
                                                      const std::array<double, 3>& w,
                                                      const std::function<double(double)>& S) {
  EXPECT_GE(w[0], 0);
  EXPECT_GE(w[1], 0);
  EXPECT_GE(w[2], 0);
  EXPECT_GT(w[0] + w[1] + w[2], 0);
  std::array<double, 4> e{};
  for (double l = 380.25; l < 780; l += 0.5)
    for (int c = 0; c < 4; ++c)
      if (!cam.qe.qe[c].empty()) e[c] += 0.5 * S(l) * cam.qe.at(static_cast<FilterColor>(c), l) / units::photon_energy_J(l);
  int colours = 0;
  int ref = -1;
  for (int c = 0; c < 4; ++c) {
    if (cam.qe.qe[c].empty()) continue;
    ++colours;
    if (ref < 0) ref = c;
    const double got = (M[c][0] * w[0] + M[c][1] * w[1] + M[c][2] * w[2]) /
                       (M[ref][0] * w[0] + M[ref][1] * w[1] + M[ref][2] * w[2]);
    // (10⁻⁹ relative: the bound derived above expect_metamer_gives_raw_colour)
    EXPECT_NEAR(got, e[c] / e[ref], 1e-9 * e[c] / e[ref]) << "filter colour " << c;
  }
  EXPECT_GE(colours, 2);
  return e;
}

// A 5-nm table from 380 nm, linear between its samples (the CIE tables' own reading).
double table_at(const double* t, double l) {
  const double u = (l - 380) / 5;
  const int i = std::min(79, static_cast<int>(u));
  return t[i] + (u - i) * (t[i + 1] - t[i]);
}
}  // namespace

// HP1 as each bundled camera records it (camera_metamer_rgb): its raw colour is the spectrum's
// (expect_metamer_gives_raw_colour, S linear between the CIE table's 5-nm samples).
// Through the band integrals instead (spectrum::hp1_rgb) the same cameras' G/R comes out more than
// twice the spectrum's: what the metamer is for (docs/night.md §7, "Lamp type").
TEST(Spectrum, Hp1CameraMetamerGivesEachCameraTheSpectrumsRawColour) {
  int cameras = 0;
  for (const auto& entry : list_presets()) {
    if (entry.kind != "camera") continue;
    const CameraPreset cam = load_camera_preset(entry.name);
    const LensPreset lens = load_lens_preset(cam.default_lens);
    const ResolvedExposure ex = resolve(cam, lens, ExposureSettings());
    const PhotonMatrix M = photon_matrix(cam, lens, ex);
    const auto w = camera_metamer_rgb(cam, spectrum::kHp1Spd5nm, 81);
    SCOPED_TRACE(entry.name);
    const auto e = expect_metamer_gives_raw_colour(cam, M, w, [](double l) { return table_at(spectrum::kHp1Spd5nm, l); });
    const auto h = spectrum::hp1_rgb(1.0);
    const int g = !cam.qe.qe[1].empty() ? 1 : 3;  // green, or clear where there is none
    const double band_gr = (M[g][0] * h[0] + M[g][1] * h[1] + M[g][2] * h[2]) / (M[0][0] * h[0] + M[0][1] * h[1] + M[0][2] * h[2]);
    std::fprintf(stderr, "[hp1 %s] raw %s/R: spectrum %.4f, metamer %.4f, band integrals %.4f\n", entry.name.c_str(),
                 g == 1 ? "G" : "C", e[g] / e[0],
                 (M[g][0] * w[0] + M[g][1] * w[1] + M[g][2] * w[2]) / (M[0][0] * w[0] + M[0][1] * w[1] + M[0][2] * w[2]),
                 band_gr);
    if (g == 1) EXPECT_GT(band_gr, 2 * e[g] / e[0]);
    ++cameras;
  }
  EXPECT_GE(cameras, 5);
}

// CIE LED-B (phosphor white LEDs, led street lamps) as each bundled camera records it
// (camera_metamer_rgb(cam, LedBHeads or LedBStreet, T)): its raw colour is the spectrum's
// (expect_metamer_gives_raw_colour) at each CIE table's CCT (S: that table, linear between its
// samples), between two tables (S: both, each scaled to Σ S_i·ȳ(λ_i) = 1, blended linearly in
// mired, the documented photosite choice) and beyond the range (the nearest table). The two
// LED-B names give the same metamer at the same CCT. The Planck proxy at the CCT (the scene
// without a camera) misses the spectrum's raw G/R on the RGB cameras by more than 5 % (printed;
// −10 % on the AR0331 at 4000 K, scripts/lamp_spectra.py): what the metamer is for.
TEST(Spectrum, LedBCameraMetamerGivesEachCameraTheSpectrumsRawColour) {
  std::array<double, 5> lum{};  // each table's Σ S_i·ȳ(λ_i)
  for (int t = 0; t < 5; ++t)
    for (int i = 0; i < 81; ++i) lum[t] += spectrum::kLedBSpd5nm[t][i] * spectrum::cie_y_bar(380 + 5.0 * i);
  auto blend = [&](int t, double a) {  // (1 − a)·table t + a·table t+1, each at Σ S·ȳ = 1
    return [&lum, t, a](double l) {
      const double x = table_at(spectrum::kLedBSpd5nm[t], l) / lum[t];
      return a == 0 ? x : (1 - a) * x + a * table_at(spectrum::kLedBSpd5nm[t + 1], l) / lum[t + 1];
    };
  };
  auto mired = [](double T) { return 1e6 / T; };
  struct Case {
    double T;
    int t;
    double a;
  };
  std::vector<Case> cases;
  for (int t = 0; t < 5; ++t) cases.push_back({spectrum::kLedBCct_K[t], t, 0.0});
  for (const double T : {2850.0, 3500.0, 4500.0, 5800.0}) {
    int t = 0;
    while (!(T < spectrum::kLedBCct_K[t + 1])) ++t;
    const double m0 = mired(spectrum::kLedBCct_K[t]), m1 = mired(spectrum::kLedBCct_K[t + 1]);
    cases.push_back({T, t, (m0 - mired(T)) / (m0 - m1)});
  }
  cases.push_back({2000.0, 0, 0.0});  // beyond the tables: the nearest
  cases.push_back({9000.0, 4, 0.0});
  int cameras = 0;
  for (const auto& entry : list_presets()) {
    if (entry.kind != "camera") continue;
    const CameraPreset cam = load_camera_preset(entry.name);
    const LensPreset lens = load_lens_preset(cam.default_lens);
    const PhotonMatrix M = photon_matrix(cam, lens, resolve(cam, lens, ExposureSettings()));
    for (const Case& c : cases) {
      SCOPED_TRACE(entry.name + " at " + std::to_string(c.T) + " K");
      const auto w = camera_metamer_rgb(cam, spectrum::LampSpectrum::LedBHeads, c.T);
      EXPECT_EQ(camera_metamer_rgb(cam, spectrum::LampSpectrum::LedBStreet, c.T), w);
      const auto e = expect_metamer_gives_raw_colour(cam, M, w, blend(c.t, c.a));
      if (cam.qe.qe[1].empty()) continue;  // no green filter (RCCC)
      const auto b = spectrum::blackbody_rgb(c.T, 1.0);
      const double proxy_gr = (M[1][0] * b[0] + M[1][1] * b[1] + M[1][2] * b[2]) / (M[0][0] * b[0] + M[0][1] * b[1] + M[0][2] * b[2]);
      std::fprintf(stderr, "[led-b %s %.0f K] raw G/R: spectrum %.4f, Planck proxy %.4f (%+.1f %%)\n", entry.name.c_str(),
                   c.T, e[1] / e[0], proxy_gr, 100 * (proxy_gr / (e[1] / e[0]) - 1));
      if (c.T == 4000) EXPECT_GT(std::fabs(proxy_gr / (e[1] / e[0]) - 1), 0.05);
    }
    ++cameras;
  }
  EXPECT_GE(cameras, 5);
}

// The traffic signals' and rear lamps' LEDs as each bundled camera records them
// (camera_metamer_rgb(cam, LampSpectrum)): non-negative box radiances, not all 0, and the closest
// such to the spectrum's own electrons in least squares over the camera's filter colours. The
// spectrum's electrons per cd/m² e_c and the boxes' A[c][k] = ∫ b_k QE_c λ/(hc) dλ are computed
// here independently (0.5-nm midpoints; the Gaussian of spectrum::kRedLed etc. at each point).
// Optimality is checked by its conditions, not by a second solver: for the convex problem
// min ‖A·w − e‖² over w ≥ 0, w is the optimum iff the gradient g = Aᵀ(A·w − e) is 0 on the boxes
// with w_k > 0 and ≥ 0 on those with w_k = 0 (Karush-Kuhn-Tucker). Tolerance on g_k: 10⁻⁹ of
// Σ_c A[c][k]·e_c, the size of its terms: the library's sums and these differ only in rounding
// (a few hundred positive terms, ≤ 10³·2⁻⁵³ relative) and its solve's error is ≲ κ·2⁻⁵³ with the
// boxes' condition numbers κ < 10³ (Spectrum.Hp1CameraMetamerGivesEachCameraTheSpectrumsRawColour).
// Where the solve needs no clipping (all of w > 0 on a camera with ≥ 3 colours) that is the
// spectrum's raw colour exactly; the printed rows give each camera's G/R and B/R (RCCC: C/R) of the
// spectrum, of the metamer and of the old box guesses (scene/lights.cpp), docs/night.md §7.
// On the old code (a negative box returned all 0: the box guesses) the green LED's w is 0 on
// every camera.
TEST(Spectrum, SignalLedCameraMetamersAreTheClosestNonNegativeBoxes) {
  using spectrum::LampSpectrum;
  struct Led {
    LampSpectrum s;
    spectrum::LedLine line;
    std::array<double, 3> old_boxes;
    const char* name;
  };
  const Led leds[] = {{LampSpectrum::RedLed, spectrum::kRedLed, {1, 0.03, 0}, "red"},
                      {LampSpectrum::AmberLed, spectrum::kAmberLed, {1, 0.45, 0}, "amber"},
                      {LampSpectrum::GreenLed, spectrum::kGreenLed, {0, 1, 0.6}, "green"}};
  int cameras = 0;
  for (const auto& entry : list_presets()) {
    if (entry.kind != "camera") continue;
    const CameraPreset cam = load_camera_preset(entry.name);
    SCOPED_TRACE(entry.name);
    std::vector<int> colours;
    for (int c = 0; c < 4; ++c)
      if (!cam.qe.qe[c].empty()) colours.push_back(c);
    ASSERT_GE(colours.size(), 2u);
    std::array<std::array<double, 3>, 4> A{};
    for (int c : colours)
      for (int k = 0; k < 3; ++k) {
        double s = 0;
        for (double l = spectrum::kBandLoNm[k] + 0.25; l < spectrum::kBandHiNm[k]; l += 0.5)
          s += cam.qe.at(static_cast<FilterColor>(c), l) / units::photon_energy_J(l);
        A[c][k] = s * 0.5 / (spectrum::kBandHiNm[k] - spectrum::kBandLoNm[k]);
      }
    for (const Led& led : leds) {
      SCOPED_TRACE(led.name);
      const auto w = camera_metamer_rgb(cam, led.s);
      EXPECT_GE(w[0], 0);
      EXPECT_GE(w[1], 0);
      EXPECT_GE(w[2], 0);
      ASSERT_GT(w[0] + w[1] + w[2], 0);
      auto S = [&](double l) {
        const double t = (l - led.line.peak_nm) / led.line.fwhm_nm;
        return std::exp(-4 * std::log(2.0) * t * t);
      };
      double Lv = 0;
      std::array<double, 4> e{};
      for (double l = 380.25; l < 780; l += 0.5) {
        Lv += 683 * 0.5 * S(l) * spectrum::cie_y_bar(l);
        for (int c : colours) e[c] += 0.5 * S(l) * cam.qe.at(static_cast<FilterColor>(c), l) / units::photon_energy_J(l);
      }
      for (int c : colours) e[c] /= Lv;
      std::array<double, 4> got{}, old{};
      for (int c : colours)
        for (int k = 0; k < 3; ++k) got[c] += A[c][k] * w[k], old[c] += A[c][k] * led.old_boxes[k];
      for (int k = 0; k < 3; ++k) {
        double g = 0, scale = 0;
        for (int c : colours) g += A[c][k] * (got[c] - e[c]), scale += A[c][k] * e[c];
        const double tol = 1e-9 * scale;
        if (w[k] > 0) EXPECT_NEAR(g, 0, tol) << "box " << k;
        else EXPECT_GE(g, -tol) << "box " << k;
      }
      const int r = colours[0], g2 = colours[1];
      const int b = colours.size() > 2 ? colours[2] : colours[1];
      std::fprintf(stderr,
                   "[led %s %s] raw %s/R, B/R: spectrum %.4f %.4f, metamer %.4f %.4f, old boxes %.4f %.4f; w %.4g %.4g %.4g\n",
                   entry.name.c_str(), led.name, colours.size() > 2 ? "G" : "C", e[g2] / e[r], e[b] / e[r],
                   got[g2] / got[r], got[b] / got[r], old[g2] / old[r], old[b] / old[r], w[0], w[1], w[2]);
    }
    ++cameras;
  }
  EXPECT_GE(cameras, 5);
}

// Every bundled camera through its default lens, against the photon integral done here
// independently: a pixel of filter colour c under band radiance L (W·sr⁻¹·m⁻², equal in R, G, B)
// collects on average
//   μ = t · A_pix · FF · πT / (1 + 4N²) · cos⁴θ · g_PRNU · Σ_k L / (λ_hi − λ_lo) ∫_k QE_c(λ) λ/(hc) dλ
// photo-electrons plus the dark charge D t · (dark-rate factor), with at most the full well. The QE
// table is piecewise linear, so each table segment's QE(λ)·λ is a quadratic and Simpson's rule
// integrates it exactly. The code sums 0.5 nm midpoints (sensor/pipeline.cpp photon_matrix), whose
// cells the 10 nm table nodes and the band edges bound, so on each cell f = QE·λ·κ (κ = 1/(hc) in
// the units used) has f'' = 2κ·QE' and the midpoint rule errs by h³/24·|f''|: over a band,
// (h²/12)·κ·TV(QE) with TV the band's total variation of QE (Σ|ΔQE| over its segments). Relative
// to the band's integral and taken at its largest over the three bands (all terms positive), plus
// the mean signal's rounding to float (2⁻²⁴): the model's allowance.
// Per colour the mean of n_c Poisson counts has standard error √(Σμ_i)/n_c: tolerance 5 of them.
// The raw DN mean is then K·(mean electrons + mean DSNU offset) + black level: read noise,
// one rounding (1/12 DN²) and row/column noise shared along a row/column (over at least h/2
// rows and w/2 columns of each colour) give its standard error; tolerance 5 of them.
TEST(Expose, WholeChainOnEveryBundledCamera) {
  const int w = 64, h = 48;
  int cameras = 0;
  for (const auto& entry : list_presets()) {
    if (entry.kind != "camera") continue;
    ++cameras;
    CameraPreset p = load_camera_preset(entry.name);
    LensPreset l = load_lens_preset(p.default_lens);
    ExposureSettings s;
    const ResolvedExposure ex = resolve(p, l, s);
    // Electrons per unit radiance in every band, per filter colour.
    std::array<double, kFilterColorCount> per_L{}, midpoint_rel{};
    const double area = std::pow(p.pixel_pitch_um * 1e-6, 2) * p.fill_factor;
    const double q = ex.f_number * (1 + std::fabs(l.magnification));
    const double optics = units::pi * l.transmittance / (1 + 4 * q * q);
    for (int c = 0; c < kFilterColorCount; ++c) {
      const auto& grid = p.qe.wavelength_nm;
      for (int k = 0; k < 3; ++k) {
        const double lo = spectrum::kBandLoNm[k], hi = spectrum::kBandHiNm[k];
        std::vector<double> nodes{lo, hi};
        for (double g : grid) if (g > lo && g < hi) nodes.push_back(g);
        std::sort(nodes.begin(), nodes.end());
        double integral = 0, tv = 0;
        auto qe = [&](double nm) { return p.qe.at(static_cast<FilterColor>(c), nm); };
        auto f = [&](double nm) { return qe(nm) / units::photon_energy_J(nm); };
        for (size_t i = 0; i + 1 < nodes.size(); ++i) {
          const double a = nodes[i], b = nodes[i + 1];
          // Simpson on the open interval's interior values (QE is continuous inside a segment).
          const double e = 1e-9 * (b - a);
          integral += (b - a) / 6 * (f(a + e) + 4 * f(0.5 * (a + b)) + f(b - e));
          tv += std::fabs(qe(b - e) - qe(a + e));
        }
        const double kappa = 1 / (units::photon_energy_J(500) * 500), h_nm = 0.5;
        if (integral > 0) midpoint_rel[c] = std::max(midpoint_rel[c], h_nm * h_nm / 12 * kappa * tv / integral);
        per_L[c] += ex.exposure_s * area * optics * integral / (hi - lo);
      }
    }
    const double L = 0.2 * p.full_well_e / *std::max_element(per_L.begin(), per_L.end());
    ImageF radiance(w, h, 3, static_cast<float>(L));
    auto fpn = generate_fixed_pattern(p, w, h, "x");
    auto out = expose(radiance, p, l, s, fpn);
    ASSERT_EQ(out.raw_dn.width(), w);
    ASSERT_EQ(out.rgb.channels(), 3);
    const double pitch_over_f = l.cos4_falloff ? p.pixel_pitch_um * 1e-3 / l.focal_length_mm : 0.0;
    const double K = ex.system_gain_dn_per_e, dark_e = ex.dark_current_e_per_s * ex.exposure_s;
    for (FilterColor c : cfa_colors(p.cfa)) {
      double mu_sum = 0, e_sum = 0, dn_sum = 0, off_sum = 0, n = 0;
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
          if (cfa_color(p.cfa, x, y) != c) continue;
          const double r2 = (std::pow(x - 0.5 * (w - 1), 2) + std::pow(y - 0.5 * (h - 1), 2)) * pitch_over_f * pitch_over_f;
          const double g = fpn.prnu_gain.empty() ? 1.0 : fpn.prnu_gain.at(x, y, 0);
          const double df = fpn.dark_rate_factor.empty() ? 1.0 : fpn.dark_rate_factor.at(x, y, 0);
          mu_sum += std::min(p.full_well_e, L * per_L[static_cast<int>(c)] * g / ((1 + r2) * (1 + r2)) + dark_e * df);
          off_sum += fpn.dsnu_offset_e.empty() ? 0.0 : fpn.dsnu_offset_e.at(x, y, 0);
          e_sum += out.electrons.at(x, y, 0);
          dn_sum += out.raw_dn.at(x, y, 0);
          n += 1;
        }
      const double mu = mu_sum / n;
      const double model_rel = midpoint_rel[static_cast<int>(c)] + 0x1p-24;
      // 5 SE of the electrons' mean (Poisson: √Σμ / n) plus the model's midpoint-rule error.
      EXPECT_NEAR(e_sum / n, mu, 5 * std::sqrt(mu_sum) / n + model_rel * mu) << entry.name << " colour " << static_cast<int>(c);
      const double dn_var = K * K * (mu + p.read_noise_e * p.read_noise_e) + 1.0 / 12;
      const double dn_se = std::sqrt(dn_var / n + K * K * (std::pow(p.row_noise_e, 2) / (h / 2) + std::pow(p.column_noise_e, 2) / (w / 2)));
      // 5 SE of the DN mean: K²(μ + σ_r²) + 1/12 per pixel over n, and the row and column noise's share.
      EXPECT_NEAR(dn_sum / n, K * (e_sum + off_sum) / n + p.black_level_dn, 5 * dn_se) << entry.name << " colour " << static_cast<int>(c);
    }
  }
  EXPECT_GE(cameras, 1);
}

// The fused sense + demosaic loop (sensor/pipeline.cpp, sense_frame) against its definition:
// RGB = demosaic(raw DN − black level) of the whole mosaic, computed apart here from the raw
// output, bit for bit, at 1, 2 and 3 threads (thread ranges, their halo rows and the band
// buffer's wrap all move with the thread count and the height), for every Bayer phase, RCCB
// (the fused path), RCCC and a non-bilinear method (the whole-frame path), heights from 2 rows
// to several bands per thread. The electrons and raw DN must not move with the thread count.
// At every vector level the CPU has (detail::interleave_rgb_max_isa, which also caps the fused
// bilinear row): the pair loop then interleave_rgb (0), and the interior in one pass with the
// interleave on AVX2 (1, bilinear_interior_avx2) and AVX-512 (2, bilinear_interior_avx512).
TEST(SenseFused, EqualsTheUnfusedDefinition) {
  const std::pair<CfaPattern, DemosaicMethod> cases[] = {
      {CfaPattern::RGGB, DemosaicMethod::Bilinear}, {CfaPattern::BGGR, DemosaicMethod::Bilinear},
      {CfaPattern::GRBG, DemosaicMethod::Bilinear}, {CfaPattern::GBRG, DemosaicMethod::Bilinear},
      {CfaPattern::RCCB, DemosaicMethod::Bilinear}, {CfaPattern::RCCC, DemosaicMethod::Bilinear},
      {CfaPattern::RGGB, DemosaicMethod::Malvar}};
  // 150, 231 and 97 wide: rows of 64 interior pixels and more, which take the AVX-512 or AVX2
  // bilinear row (demosaic.cpp's bilinear_interior_avx512, _avx2) where the CPU has it, with
  // every head and tail length as the rows' output alignment changes.
  const std::pair<int, int> sizes[] = {{2, 2}, {7, 3}, {33, 5}, {150, 71}, {64, 140}, {231, 9}, {97, 18}};
  const int saved = omp_get_max_threads();
  struct UncapOnExit {
    ~UncapOnExit() { detail::interleave_rgb_max_isa(2); }
  } uncap;
  int fused_cases = 0;
  for (int isa = 0; isa <= detail::machine_isa_level(); ++isa)
  for (const auto& [cfa, method] : cases)
    for (const auto& [w, h] : sizes) {
      detail::interleave_rgb_max_isa(isa);
      CameraPreset p = flat_qe_camera();
      p.cfa = cfa;
      p.prnu_percent = 1;
      p.row_noise_e = 1;
      p.column_noise_e = 0.5;
      const auto fpn = generate_fixed_pattern(p, w, h, "fused");
      ImageF sig(w, h, 1);
      for (size_t i = 0; i < sig.size(); ++i) sig[i] = static_cast<float>((i * 7919) % 1013) * 4.0f;
      ExposureSettings s;
      s.seed = 5;
      s.frame = 3;
      s.demosaic = method;
      const auto ex = resolve(p, simple_lens(), s);
      fused_cases += method == DemosaicMethod::Bilinear && detail::bilinear_row_path(w, h, cfa);
      SensorOutput first;
      for (int threads : {1, 2, 3}) {
        omp_set_num_threads(threads);
        const SensorOutput out = sense(sig, p, ex, s, fpn);
        ImageF above_black(w, h, 1);
        for (size_t i = 0; i < above_black.size(); ++i)
          above_black[i] = out.raw_dn[i] - static_cast<float>(p.black_level_dn);
        const ImageF ref = demosaic(above_black, cfa, method);
        const std::string what =
            fmt::format("{} {} {}x{} at {} threads, vector level {}", to_string(cfa), to_string(method), w, h,
                        threads, isa);
        ASSERT_EQ(out.rgb.channels(), 3) << what;
        EXPECT_EQ(out.rgb.vec(), ref.vec()) << what;
        if (threads == 1) {
          first = out;
        } else {
          EXPECT_EQ(out.electrons.vec(), first.electrons.vec()) << what;
          EXPECT_EQ(out.raw_dn.vec(), first.raw_dn.vec()) << what;
        }
      }
    }
  omp_set_num_threads(saved);
  // every Bayer phase and RCCB at every size and level took the fused path
  EXPECT_EQ(fused_cases, 5 * 7 * (detail::machine_isa_level() + 1));
}

// expose() (the photon stage with the lens glare, fused row by row into sense and the band
// demosaic, its halo rows made twice) against its definition, mean_signal_electrons() then
// sense() through the whole-frame mean signal, at 1 and 2 threads and every vector level the CPU
// has (detail::photon_row_max_isa: the glared photon row's AVX-512 and AVX2 loops form the
// mean); and both into a reused SensorOutput (a previous frame's images of the same shape,
// overwritten) against fresh ones.
// expose()'s glared photon row forms the sense stage's mean (sense_mean_e: signal·PRNU +
// dark·(dark-rate factor), held at kMeanElectronsCap = 2^31 e⁻) in its AVX-512 and AVX2 loops
// (at every vector level the CPU has, detail::photon_row_max_isa): against
// mean_signal_electrons() then sense() on a scene whose lamps (1e38 W·sr⁻¹·m⁻² a band, R+G+B still
// finite, so physical) put the photon count past float's range: +Inf at every pixel, the glare
// skirt carrying it over the frame (6,400 of 6,400 when written). Every draw, raw DN and RGB value
// equal (without the cap the exact sampler draws NaN from an infinite mean, test
// Adc.AnOverflowedSignalSaturatesThePixel).
TEST(SenseFused, ExposeHoldsTheMeanCapInTheGlaredPhotonRow) {
  const CameraPreset p = load_camera_preset("onsemi-ar0331");
  const LensPreset lens = load_lens_preset(p.default_lens);
  ASSERT_TRUE(lens_glare_plan(p, lens).active);
  const int w = 160, h = 40;
  ImageF radiance(w, h, 3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < 3; ++c)
        radiance.at(x, y, c) = (x * 31 + y * 17) % 89 == 0 ? 1e38f : 0.002f * ((x + 2 * y + c) % 13);
  const auto fpn = generate_fixed_pattern(p, w, h, "fused-cap");
  ExposureSettings s;
  s.seed = 3;
  const ResolvedExposure ex = resolve(p, lens, s);
  struct UncapOnExit {
    ~UncapOnExit() { detail::photon_row_max_isa(2); }
  } uncap;
  for (int isa = 0; isa <= detail::machine_isa_level(); ++isa) {
    detail::photon_row_max_isa(isa);
    const ImageF mean_e = mean_signal_electrons(radiance, p, lens, ex);
    int capped = 0;
    for (size_t i = 0; i < mean_e.size(); ++i) capped += mean_e[i] * 0.9f > 2147483648.f;
    EXPECT_GT(capped, w * h / 2) << "the scene should put the means past the cap";
    const SensorOutput ref = sense(mean_e, p, ex, s, fpn);
    const SensorOutput out = expose(radiance, p, lens, s, fpn);
    EXPECT_EQ(out.electrons.vec(), ref.electrons.vec()) << "vector level " << isa;
    EXPECT_EQ(out.raw_dn.vec(), ref.raw_dn.vec()) << "vector level " << isa;
    EXPECT_EQ(out.rgb.vec(), ref.rgb.vec()) << "vector level " << isa;
  }
}

TEST(SenseFused, ExposeEqualsOpticsThenSenseAndReusedOutputsEqualFresh) {
  const CameraPreset p = load_camera_preset("onsemi-ar0331");
  const LensPreset lens = load_lens_preset(p.default_lens);
  const int w = 160, h = 90;
  ImageF radiance(w, h, 3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < 3; ++c)  // a dim scene with a few bright lamps (the glare's skirt)
        radiance.at(x, y, c) = ((x * 31 + y * 17 + c * 7) % 97 == 0 ? 40.f : 0.002f * ((x + 2 * y + c) % 13));
  const auto fpn = generate_fixed_pattern(p, w, h, "fused-expose");
  ExposureSettings s;
  s.seed = 11;
  const int saved = omp_get_max_threads();
  struct UncapOnExit {
    ~UncapOnExit() { detail::photon_row_max_isa(2); }
  } uncap;
  for (int isa = 0; isa <= detail::machine_isa_level(); ++isa)
  for (int threads : {1, 2}) {
    SCOPED_TRACE(fmt::format("vector level {}", isa));
    detail::photon_row_max_isa(isa);
    omp_set_num_threads(threads);
    s.frame = 0;
    const ResolvedExposure ex = resolve(p, lens, s);
    const SensorOutput ref = sense(mean_signal_electrons(radiance, p, lens, ex), p, ex, s, fpn);
    SensorOutput out = expose(radiance, p, lens, s, fpn);
    EXPECT_EQ(out.electrons.vec(), ref.electrons.vec()) << threads;
    EXPECT_EQ(out.raw_dn.vec(), ref.raw_dn.vec()) << threads;
    EXPECT_EQ(out.rgb.vec(), ref.rgb.vec()) << threads;
    // Frame 1 into frame 0's outputs, against frame 1 fresh.
    s.frame = 1;
    const float* kept = out.rgb.data();
    expose(radiance, p, lens, s, fpn, out);
    EXPECT_EQ(out.rgb.data(), kept) << "the reused RGB buffer was replaced";
    const SensorOutput fresh = expose(radiance, p, lens, s, fpn);
    EXPECT_EQ(out.electrons.vec(), fresh.electrons.vec()) << threads;
    EXPECT_EQ(out.raw_dn.vec(), fresh.raw_dn.vec()) << threads;
    EXPECT_EQ(out.rgb.vec(), fresh.rgb.vec()) << threads;
    EXPECT_NE(out.raw_dn.vec(), ref.raw_dn.vec()) << "frame 1 drew the same noise as frame 0";
    SensorOutput sensed = ref;
    sense(mean_signal_electrons(radiance, p, lens, ex), p, ex, s, fpn, sensed);
    EXPECT_EQ(sensed.rgb.vec(), fresh.rgb.vec()) << threads;
  }
  omp_set_num_threads(saved);
}
