// Parity of the Vulkan kernels with the native C++ path, on lavapipe (Mesa's CPU Vulkan driver)
// unless the caller picked a driver, with the Khronos validation layer on: any validation
// message fails the test. Without a usable Vulkan device these tests FAIL, unless
// PHOTOSITE_ALLOW_NO_VULKAN=1 (then they skip, loudly).
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <memory>
#include <sys/mman.h>

#include "photosite/error.h"
#include "photosite/rng.h"
#include "photosite/sensor/poisson.h"

#ifdef PHOTOSITE_HAVE_VULKAN
#include "photosite/gpu/context.h"
#include "photosite/gpu/stages.h"
#endif

namespace photosite {
namespace {

#ifdef PHOTOSITE_HAVE_VULKAN
// The test context: lavapipe (when no driver was chosen) and validation on.
std::unique_ptr<gpu::Context>& test_context_holder() {
  static std::unique_ptr<gpu::Context> ctx;
  return ctx;
}

// The test context is destroyed when the tests end, not among the static destructors at exit: by
// then NVIDIA's driver (580.159.04, on an H200) has torn down its own state, and vkDestroyDevice
// there ended every run of the test binary with a segmentation fault after all tests had passed.
class GpuContextEnvironment : public ::testing::Environment {
 public:
  void TearDown() override { test_context_holder().reset(); }
};
[[maybe_unused]] const ::testing::Environment* const kGpuContextEnvironment =
    ::testing::AddGlobalTestEnvironment(new GpuContextEnvironment);

gpu::Context* test_context(std::string* why) {
  std::unique_ptr<gpu::Context>& ctx = test_context_holder();
  static std::string error;
  static bool tried = false;
  if (!tried) {
    tried = true;
    const char* lvp = "/usr/share/vulkan/icd.d/lvp_icd.x86_64.json";
    if (!std::getenv("VK_DRIVER_FILES") && !std::getenv("VK_ICD_FILENAMES") && std::filesystem::exists(lvp)) {
      setenv("VK_DRIVER_FILES", lvp, 1);
      setenv("VK_ICD_FILENAMES", lvp, 1);
    }
    setenv("PHOTOSITE_VK_VALIDATION", "1", 0);
    try {
      ctx = std::make_unique<gpu::Context>();
      std::fprintf(stderr, "[gpu] device: %s (%s)%s%s%s\n", ctx->device().name.c_str(), ctx->device().type.c_str(),
                   ctx->validation() ? ", validation on" : "", ctx->device().staged ? ", staged transfers" : "",
                   ctx->device().host_import ? " (host-page import offered)" : "");
    } catch (const std::exception& e) {
      error = e.what();
    }
  }
  if (why) *why = error;
  return ctx.get();
}
#endif

bool allow_no_vulkan() {
  const char* e = std::getenv("PHOTOSITE_ALLOW_NO_VULKAN");
  return e && std::string(e) == "1";
}

}  // namespace

// Fixture: a context or a failure (a loud skip only where allowed), and no validation message
// from anything the test ran.
class Gpu : public ::testing::Test {
 protected:
#ifdef PHOTOSITE_HAVE_VULKAN
  gpu::Context* ctx = nullptr;
  size_t messages_before = 0;
#endif
  void SetUp() override {
#ifdef PHOTOSITE_HAVE_VULKAN
    std::string why;
    ctx = test_context(&why);
    if (!ctx) {
      if (allow_no_vulkan()) GTEST_SKIP() << "*** Vulkan unavailable, skipped (PHOTOSITE_ALLOW_NO_VULKAN=1): " << why;
      FAIL() << "Vulkan unavailable: " << why << " (set PHOTOSITE_ALLOW_NO_VULKAN=1 to skip)";
    }
    messages_before = ctx->messages().size();
#else
    if (allow_no_vulkan()) GTEST_SKIP() << "*** built without the Vulkan backend, skipped (PHOTOSITE_ALLOW_NO_VULKAN=1)";
    FAIL() << "built without the Vulkan backend (PHOTOSITE_VULKAN=OFF)";
#endif
  }
  void TearDown() override {
#ifdef PHOTOSITE_HAVE_VULKAN
    if (!ctx) return;
    const auto m = ctx->messages();
    for (size_t i = messages_before; i < m.size(); ++i) ADD_FAILURE() << "Vulkan validation: " << m[i];
#endif
  }
};

#ifdef PHOTOSITE_HAVE_VULKAN
TEST_F(Gpu, ContextHasValidationAndADevice) {
  EXPECT_TRUE(ctx->validation()) << "tests run with PHOTOSITE_VK_VALIDATION=1";
  EXPECT_FALSE(ctx->device().name.empty());
}

TEST_F(Gpu, PhiloxWordsEqualRngH) {
  // Pixel indices across the 2^32 boundary exercise the 64-bit counter's carry.
  for (uint64_t first : {uint64_t{0}, uint64_t{0xFFFFFF00u}, uint64_t{123456789012ull}}) {
    const uint64_t n = 1000, seed = 0x0123456789ABCDEFull;
    const auto w = gpu::philox_words(*ctx, n, first, seed, 7, static_cast<uint32_t>(Stream::PhotonShot));
    for (uint64_t i = 0; i < n; ++i) {
      const auto e = random_words(seed, 7, first + i, Stream::PhotonShot);
      for (int k = 0; k < 4; ++k) ASSERT_EQ(w[4 * i + k], e[k]) << "pixel " << first + i << " word " << k;
    }
  }
}

TEST_F(Gpu, PoissonBitEqualToCpuAtEveryMean) {
  // Every mode; means log-spaced from e^-4 to 1e6 (inversion < 10 <= PTRS or the corrected
  // normal; PTRS's retries on the retry streams), the threshold itself, zero, negative and NaN;
  // 200k pixels, so each mean recurs 50 times with different words.
  const uint64_t n = 200000;
  std::vector<float> mean(n);
  const double top = std::log(1e6);
  for (uint64_t i = 0; i < n; ++i)
    mean[i] = static_cast<float>(std::exp((static_cast<double>(i % 4000) / 3999.0) * (top + 4.0) - 4.0));
  mean[0] = 0.f, mean[1] = -3.f, mean[2] = std::nanf(""), mean[3] = 10.f, mean[4] = 9.999999f, mean[5] = 1e-30f;
  mean[6] = 1e6f;
  for (PoissonMethod method : {PoissonMethod::Exact, PoissonMethod::CornishFisher, PoissonMethod::Normal}) {
    std::vector<float> cpu(n), dev(n);
    poisson_fill(mean.data(), cpu.data(), n, 5000, 42, 3, 1, method);
    gpu::poisson_fill(*ctx, mean.data(), dev.data(), n, 5000, 42, 3, 1, method);
    uint64_t differ = 0;
    for (uint64_t i = 0; i < n; ++i)
      if (cpu[i] != dev[i] && ++differ < 5)
        ADD_FAILURE() << to_string(method) << " pixel " << i << " mean " << mean[i] << ": cpu " << cpu[i] << " gpu " << dev[i];
    EXPECT_EQ(differ, 0u) << to_string(method);
  }
}

// The device's division and square root are IEEE 754's (div_rn, sqrt_rn in common/prelude.glsl),
// whatever the driver's own float division and sqrt give: started from the driver's values moved
// up to 3 more ulps off (Vulkan allows a 32-bit division 2.5 ulps), they settle on the CPU's bits. Random
// pairs over 2^-40..2^40 of either sign, and quotients near powers of two (where the float spacing
// halves) and exact ones; lavapipe divides correctly, so the moved start is what exercises the
// settling steps there. A settle that stops one step short, or moves the wrong way, fails here.
TEST_F(Gpu, DivisionAndSquareRootAreCorrectlyRoundedFromAnyStart) {
  std::vector<float> ab;
  uint64_t state = 0x9E3779B97F4A7C15ull;
  auto next = [&] {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    return static_cast<uint32_t>(state >> 32);
  };
  for (int i = 0; i < 100000; ++i) {
    const auto draw = [&] {
      const float mant = 1.f + static_cast<float>(next() >> 8) * 0x1p-24f;
      const int e = static_cast<int>(next() % 81) - 40;
      return std::ldexp(mant, e) * ((next() & 1) ? -1.f : 1.f);
    };
    ab.push_back(draw());
    ab.push_back(draw());
  }
  for (float a : {1.f, 2.f, 3.f, 0.5f, 7.f, 1e-3f, 4.f, std::nextafter(4.f, 5.f), std::nextafter(4.f, 3.f)})
    for (float b : {1.f, 3.f, 0.5f, 7.f, 1e-3f, std::nextafter(1.f, 2.f), std::nextafter(1.f, 0.f)}) {
      ab.push_back(a);
      ab.push_back(b);
    }
  for (int shift = -3; shift <= 3; ++shift) {
    const std::vector<float> dev = gpu::rounding_probe(*ctx, ab, shift);
    uint64_t wrong = 0;
    for (size_t i = 0; i < ab.size() / 2; ++i) {
      const float a = ab[2 * i], b = ab[2 * i + 1], q = a / b, r = std::sqrt(a);
      const bool q_ok = std::bit_cast<uint32_t>(q) == std::bit_cast<uint32_t>(dev[2 * i]);
      const bool r_ok = std::isnan(r) ? std::isnan(dev[2 * i + 1]) : std::bit_cast<uint32_t>(r) == std::bit_cast<uint32_t>(dev[2 * i + 1]);
      if ((!q_ok || !r_ok) && ++wrong <= 5)
        ADD_FAILURE() << "shift " << shift << ": " << a << " / " << b << " = " << q << " (device " << dev[2 * i]
                      << "), sqrt " << r << " (device " << dev[2 * i + 1] << ")";
    }
    EXPECT_EQ(wrong, 0u) << "shift " << shift;
  }
}

// Beyond parity: the device sampler itself has the Poisson law's mean and variance at means in
// both regimes (200k draws each: the sample mean within 5 standard errors, the variance within 5
// of its standard errors, var(s²) ≈ (2μ² + μ)/n for a Poisson).
// Every kernel indexes pixels with a 32-bit invocation index (linear_invocation): a job whose grid
// would pass 2^32 invocations is refused as bad input before anything is allocated or read
// (the pointers here are never touched).
TEST_F(Gpu, DispatchBeyondThe32BitIndexIsRefused) {
  for (uint64_t n : {uint64_t{1} << 32, uint64_t{4294901761}, uint64_t{1} << 40}) {
    try {
      gpu::poisson_fill(*ctx, nullptr, nullptr, n, 0, 1, 0, 1);
      ADD_FAILURE() << n << " items were accepted";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("32-bit invocation index"), std::string::npos) << e.what();
    }
  }
}

TEST_F(Gpu, PoissonDrawsHaveThePoissonMeanAndVariance) {
  const uint64_t n = 200000;
  for (float mu : {0.5f, 3.f, 9.5f, 10.f, 40.f, 2500.f}) {
    std::vector<float> mean(n, mu), out(n);
    gpu::poisson_fill(*ctx, mean.data(), out.data(), n, 0, 1234, 0, 1);
    double s = 0, s2 = 0;
    for (float k : out) s += k, s2 += static_cast<double>(k) * k;
    const double m = s / n, var = s2 / n - m * m;
    // 5 SE each: the mean's √(μ/n); the sample variance's √((μ₄ − σ⁴)/n) with the Poisson
    // μ₄ = μ + 3μ², σ⁴ = μ²: √((2μ² + μ)/n).
    EXPECT_NEAR(m, mu, 5 * std::sqrt(mu / n)) << "mean " << mu;
    EXPECT_NEAR(var, mu, 5 * std::sqrt((2.0 * mu * mu + mu) / n)) << "mean " << mu;
  }
}
#endif

// Compiled with or without the backend: a build or machine without Vulkan fails here (unless
// PHOTOSITE_ALLOW_NO_VULKAN=1), so the GPU tests never go missing silently.
// Where the backend is built, the device it opened meets what the kernels need and reports
// itself consistently: Vulkan 1.1 or later (encoded major << 22 | minor << 12, the spec's
// VK_MAKE_API_VERSION), a known device type, the CPU flag set exactly for a CPU device (it decides
// what `auto` picks), and a positive timestamp period wherever timestamps are offered.
TEST_F(Gpu, BackendIsBuiltAndADeviceOpens) {
#ifdef PHOTOSITE_HAVE_VULKAN
  const gpu::DeviceInfo& d = ctx->device();
  EXPECT_GE(d.api_version, (1u << 22) | (1u << 12)) << d.name;
  const std::string type = d.type;
  EXPECT_TRUE(type == "discrete" || type == "integrated" || type == "virtual" || type == "cpu" || type == "other") << type;
  EXPECT_EQ(d.cpu, type == "cpu") << d.name;
  if (d.timestamps) EXPECT_GT(d.timestamp_period_ns, 0.0) << d.name;
#endif
}

}  // namespace photosite

#ifdef PHOTOSITE_HAVE_VULKAN
#include "photosite/error.h"
#include "photosite/gpu/sensor.h"
#include "photosite/sensor/demosaic.h"
#include "photosite/sensor/fpn.h"
#include "photosite/sensor/preset.h"

namespace photosite {
namespace {
// A radiance field spanning dark to bright, every pixel different (odd size: partial groups).
ImageF test_radiance(int w, int h, double scale) {
  ImageF r(w, h, 3, 0.f, unit::radiance);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < 3; ++c) {
        const uint32_t u = random_words(99, 0, static_cast<uint64_t>(y) * w + x, Stream::Test)[c];
        r.at(x, y, c) = static_cast<float>(scale * std::exp(18.0 * uniform_open(u) - 16.0));
      }
  return r;
}
size_t count_differences(const ImageF& a, const ImageF& b) {
  if (a.size() != b.size()) return SIZE_MAX;
  size_t d = 0;
  for (size_t i = 0; i < a.size(); ++i) d += std::memcmp(&a[i], &b[i], sizeof(float)) != 0;
  return d;
}
}  // namespace

TEST_F(Gpu, PhotonIntegralBitEqualWithAndWithoutVignetting) {
  const CameraPreset cam = load_camera_preset("onsemi-ar0331");
  for (bool cos4 : {true, false}) {
    LensPreset lens = load_lens_preset(cam.default_lens);
    lens.cos4_falloff = cos4;
    ExposureSettings s;
    const ResolvedExposure ex = resolve(cam, lens, s);
    const ImageF rad = test_radiance(333, 123, 1.0);
    gpu::SensorChain chain(*ctx);
    const ImageF cpu = mean_signal_electrons(rad, cam, lens, ex);
    const ImageF dev = chain.mean_signal_electrons(rad, cam, lens, ex);
    EXPECT_EQ(count_differences(cpu, dev), 0u) << "cos4 " << cos4;
  }
}

// The lens's veiling glare (sensor/glare.h) in the photon stage: the pyramid kernels
// (glare_down, glare_blur, glare_up, glare_norm) and the mix in photon.comp repeat the CPU's float
// operations in its order (no contraction on either side) and its double sums in its order, so
// the mean electrons are bit-equal: odd and even sizes, single rows and columns, a lens whose
// core is finer than level 1 and one whose blur starts deeper, and the whole chain once.
TEST_F(Gpu, GlareInThePhotonStageBitEqualToCpu) {
  const CameraPreset cam = load_camera_preset("onsemi-ar0331");
  for (auto [eta, core, reach] : {std::tuple{0.04, 0.1, 20.0}, std::tuple{0.02, 0.5, 5.0}}) {
    LensPreset lens = load_lens_preset(cam.default_lens);
    lens.glare.enabled = true;
    lens.glare.veiling_glare_index = eta;
    lens.glare.core_deg = core;
    lens.glare.reach_deg = reach;
    const ResolvedExposure ex = resolve(cam, lens, ExposureSettings{});
    gpu::SensorChain chain(*ctx);
    for (auto [w, h] : {std::pair{333, 123}, std::pair{256, 128}, std::pair{1, 9}, std::pair{17, 1}, std::pair{64, 41}}) {
      const ImageF rad = test_radiance(w, h, 1.0);
      const ImageF cpu = mean_signal_electrons(rad, cam, lens, ex);
      const ImageF dev = chain.mean_signal_electrons(rad, cam, lens, ex);
      EXPECT_EQ(count_differences(cpu, dev), 0u) << w << "x" << h << " eta " << eta;
    }
    LensPreset plain = lens;
    plain.glare = LensGlare{};
    const ImageF rad = test_radiance(64, 41, 1.0);
    EXPECT_GT(count_differences(mean_signal_electrons(rad, cam, lens, ex), mean_signal_electrons(rad, cam, plain, ex)),
              64u * 41u / 2);  // and the glare changed the frame
    const FixedPatternMaps fpn = generate_fixed_pattern(cam, 64, 41, "glare-gpu-test");
    ExposureSettings s;
    s.seed = 3;
    const SensorOutput a = expose(rad, cam, lens, s, fpn), b = chain.expose(rad, cam, lens, s, fpn);
    EXPECT_EQ(count_differences(a.raw_dn, b.raw_dn), 0u);
  }
}

TEST_F(Gpu, PhotonRejectsTheSameFirstBadPixelAsCpu) {
  const CameraPreset cam = load_camera_preset("onsemi-ar0331");
  const LensPreset lens = load_lens_preset(cam.default_lens);
  const ResolvedExposure ex = resolve(cam, lens, ExposureSettings{});
  ImageF rad = test_radiance(64, 40, 1.0);
  rad.at(50, 30, 1) = -1.f;
  rad.at(7, 31, 2) = std::nanf("");
  rad.at(3, 20, 0) = 3e38f, rad.at(3, 20, 1) = 3e38f;  // finite samples whose sum overflows
  std::string cpu_msg, dev_msg;
  try { mean_signal_electrons(rad, cam, lens, ex); } catch (const Error& e) { cpu_msg = e.what(); }
  gpu::SensorChain chain(*ctx);
  try { chain.mean_signal_electrons(rad, cam, lens, ex); } catch (const Error& e) { dev_msg = e.what(); }
  EXPECT_NE(cpu_msg.find("(3, 20)"), std::string::npos) << cpu_msg;
  EXPECT_EQ(cpu_msg, dev_msg);
}

// The whole chain (photon with the lens glare → sense → demosaic) on every bundled camera: electrons and DN bit-equal
// (integer-valued, so "equal" is exact), demosaiced RGB bit-equal; two frames, the second
// reusing the fixed-pattern maps already on the device.
TEST_F(Gpu, ExposeBitEqualToCpuOnEveryCamera) {
  for (const char* name : {"onsemi-ar0331", "onsemi-ar0132at-rccc", "sony-icx267-flea2", "sony-imx174", "sony-imx490"}) {
    const CameraPreset cam = load_camera_preset(name);
    const LensPreset lens = load_lens_preset(cam.default_lens);
    const int w = 301, h = 97;
    const FixedPatternMaps fpn = generate_fixed_pattern(cam, w, h, std::string(name) + "-gpu-test");
    // From a few electrons to far beyond full well: both Poisson regimes and clipping occur.
    const ImageF rad = test_radiance(w, h, 40.0);
    gpu::SensorChain chain(*ctx);
    for (uint32_t frame = 0; frame < 4; ++frame) {
      ExposureSettings s;
      s.exposure_s = 0.01;
      s.temperature_c = -40;  // little dark charge, so the darkest pixels see means below 10
      s.seed = 5;
      s.frame = frame;
      // Each demosaic method's kernels once inside the chain, on the device mosaic (Malvar's 5x5
      // stencil, Hamilton-Adams's two passes, LMMSE's five).
      const DemosaicMethod per_frame[] = {DemosaicMethod::Bilinear, DemosaicMethod::Malvar,
                                          DemosaicMethod::HamiltonAdams, DemosaicMethod::Lmmse};
      s.demosaic = per_frame[frame];
      // Frames 0 and 1 through the camera's default lens with its veiling glare (parity of the
      // glare kernels inside the chain); frames 2 and 3 without it. The test radiance is white
      // noise over 7 decades, and the glare adds η times its local mean to every pixel, which
      // lifts the darkest means far above 10 e-: the regime checks below need the glare off.
      const bool glare = frame < 2;
      LensPreset used = lens;
      if (!glare) used.glare = LensGlare{};
      const SensorOutput cpu = expose(rad, cam, used, s, fpn);
      const SensorOutput dev = chain.expose(rad, cam, used, s, fpn);
      EXPECT_EQ(count_differences(cpu.electrons, dev.electrons), 0u) << name << " frame " << frame;
      EXPECT_EQ(count_differences(cpu.raw_dn, dev.raw_dn), 0u) << name << " frame " << frame;
      EXPECT_EQ(count_differences(cpu.rgb, dev.rgb), 0u) << name << " frame " << frame;
      float lo = 1e30f, hi = -1e30f;
      for (size_t i = 0; i < cpu.electrons.size(); ++i) lo = std::min(lo, cpu.electrons[i]), hi = std::max(hi, cpu.electrons[i]);
      if (glare) continue;
      EXPECT_LT(lo, 10.f) << name;  // the inversion regime is exercised
      EXPECT_GT(hi, 100.f) << name;  // and PTRS
      EXPECT_EQ(hi, static_cast<float>(cam.full_well_e)) << name;  // and full-well clipping
      if (cam.cfa == CfaPattern::RCCC) {  // and the clear pattern's clipped highlights made neutral
        const float neutral = static_cast<float>(clip_level(cam, resolve(cam, used, s)).neutral_dn);
        size_t n = 0;
        for (size_t i = 0; i < cpu.rgb.pixel_count(); ++i)
          n += cpu.rgb[3 * i] == neutral && cpu.rgb[3 * i + 1] == neutral && cpu.rgb[3 * i + 2] == neutral;
        EXPECT_GT(n, 0u) << name << " frame " << frame;
      }
    }
  }
}

TEST_F(Gpu, SenseFromMeanElectronsBitEqualAndTukeyIsRefused) {
  const CameraPreset cam = load_camera_preset("sony-imx490");
  const LensPreset lens = load_lens_preset(cam.default_lens);
  const int w = 129, h = 65;
  ImageF mean(w, h, 1, 0.f, unit::electrons);
  for (size_t i = 0; i < mean.size(); ++i) mean[i] = static_cast<float>(std::pow(10.0, 6.0 * (i % 1000) / 1000.0 - 1.5));
  // Means at and beyond the cap of sense_mean_e (2^31 e⁻), up to +Inf: the saturated pixels agree too.
  const float beyond[] = {2147483648.f, 1e20f, 3.4e38f, std::numeric_limits<float>::infinity()};
  for (size_t k = 0; k < 4; ++k) mean[37 + 101 * k] = beyond[k];
  const FixedPatternMaps fpn = generate_fixed_pattern(cam, w, h, "sense-gpu-test");
  ExposureSettings s;
  s.gain_db = 6;
  const ResolvedExposure ex = resolve(cam, lens, s);
  gpu::SensorChain chain(*ctx);
  for (PoissonMethod method : {PoissonMethod::Exact, PoissonMethod::CornishFisher, PoissonMethod::Normal}) {
    s.poisson = method;  // sense.comp reads it from the flags word
    const SensorOutput cpu = sense(mean, cam, ex, s, fpn), dev = chain.sense(mean, cam, ex, s, fpn);
    EXPECT_EQ(count_differences(cpu.electrons, dev.electrons), 0u) << to_string(method);
    EXPECT_EQ(count_differences(cpu.raw_dn, dev.raw_dn), 0u) << to_string(method);
    EXPECT_EQ(count_differences(cpu.rgb, dev.rgb), 0u) << to_string(method);
  }
  const CameraPreset tukey = load_camera_preset("sony-a7s2");
  const FixedPatternMaps f2 = generate_fixed_pattern(tukey, w, h, "tukey-gpu-test");
  const ResolvedExposure ex2 = resolve(tukey, load_lens_preset(tukey.default_lens), ExposureSettings{});
  EXPECT_THROW(chain.sense(mean, tukey, ex2, ExposureSettings{}, f2), Error);
}

TEST_F(Gpu, DemosaicKernelsBitEqualOnEveryPatternAndSize) {
  // Every method with a kernel, every CFA pattern, frames with mirrored borders on all sides, the
  // smallest Bayer frames (2x2, 3x5: the 5x5 Malvar stencil reflects twice) and a 1-pixel-wide
  // one (the generic path).
  const int sizes[][2] = {{77, 41}, {2, 2}, {3, 5}, {1, 7}, {6, 1}};
  for (DemosaicMethod meth : all_demosaic_methods()) {
    if (!gpu::has_demosaic_kernel(meth)) continue;
    for (const auto& sz : sizes) {
      ImageF m(sz[0], sz[1], 1, 0.f, unit::dn);
      for (size_t i = 0; i < m.size(); ++i)
        m[i] = static_cast<float>(random_words(3, 0, i, Stream::Test)[0] >> 20) - 100.f;
      for (CfaPattern p : all_cfa_patterns())
        EXPECT_EQ(count_differences(demosaic(m, p, meth), gpu::demosaic(*ctx, m, p, meth)), 0u)
            << to_string(meth) << " " << to_string(p) << " " << sz[0] << "x" << sz[1];
    }
  }
  for (DemosaicMethod meth : all_demosaic_methods())
    EXPECT_TRUE(gpu::has_demosaic_kernel(meth)) << to_string(meth) << " has no Vulkan kernel";
}

TEST_F(Gpu, MlriKernelsBitEqualOnFramesLargerThanACpuTile) {
  // MLRI's CPU path runs in 512-px-wide tiles with 23-px margins, its kernels over whole planes: on
  // frames spanning several tiles (odd sizes, partial tiles at the right and bottom), every
  // Bayer phase and RCCB give the same bits, with samples from 0 to 4095 DN (full detail).
  const int sizes[][2] = {{1037, 523}, {517, 261}};
  for (const auto& sz : sizes) {
    ImageF m(sz[0], sz[1], 1, 0.f, unit::dn);
    for (size_t i = 0; i < m.size(); ++i) m[i] = static_cast<float>(random_words(17, 0, i, Stream::Test)[0] >> 20);
    for (CfaPattern p : {CfaPattern::RGGB, CfaPattern::BGGR, CfaPattern::GRBG, CfaPattern::GBRG, CfaPattern::RCCB})
      EXPECT_EQ(count_differences(demosaic(m, p, DemosaicMethod::Mlri), gpu::demosaic(*ctx, m, p, DemosaicMethod::Mlri)),
                0u)
          << to_string(p) << " " << sz[0] << "x" << sz[1];
  }
}

}  // namespace photosite
#endif

#ifdef PHOTOSITE_HAVE_VULKAN
#include "photosite/gpu/scene.h"
#include "photosite/scene/night.h"
#include "scene/night_detail.h"

namespace photosite {

// SceneStages::tail (what SensorRunner::night_tail runs on Vulkan) as night_scene's tail, on a
// test's own context.
static scene::NightTail tail_on(std::shared_ptr<gpu::SceneStages> stages) {
  return [stages](const ImageF& t, ImageF& lights, const ImageU16& ids, const ImageF& beam_lux,
                  const scene::ScenePreset& p, bool keep_darkened) {
    return stages->tail(t, lights, ids, beam_lux, p, keep_darkened);
  };
}

// Also with texture pixels at the per-class caps (scene::class_reflectance_max): every 7th day
// pixel ×50, so diffuse classes (road, building, vegetation) sit at band reflectance 1 and
// vehicles and signs at their glint bound (the texture is the CPU's on both paths; the kernel
// multiplies it by the ambient illuminance, the same float product: bit-equal).
TEST_F(Gpu, DarkenBitEqualToCpu) {
  scene::SyntheticOptions so;
  so.width = 321, so.height = 161, so.vp_x = 160, so.vp_y = 60;
  const auto road = scene::make_synthetic_road(so);
  const auto sp = scene::load_scene_preset("night-urban");
  ImageF bright = road.day_linear_srgb;
  for (size_t i = 0; i < bright.pixel_count(); i += 7)
    for (int k = 0; k < 3; ++k) bright[3 * i + k] *= 50.f;
  for (const ImageF* day : std::initializer_list<const ImageF*>{&road.day_linear_srgb, &bright}) {
    const ImageF tex = scene::reflectance_texture(*day, road.labels.ids, sp);
    const ImageF cpu = scene::darken(tex, road.labels.ids, sp);
    const ImageF dev = gpu::darken(*ctx, tex, road.labels.ids, sp);
    ASSERT_EQ(cpu.size(), dev.size());
    size_t differ = 0;
    for (size_t i = 0; i < cpu.size(); ++i) differ += std::memcmp(&cpu[i], &dev[i], sizeof(float)) != 0;
    EXPECT_EQ(differ, 0u) << (day == &bright ? "capped texture" : "synthetic road");
  }
}

// Linearization: the same table and float operations, bit-equal for 1 to 4 channels, integer
// codes and linear floats; a NaN or Inf is refused with the CPU's message (the first pixel).
// 8-bit files take the CPU's 256-entry table (scene/darken.cpp) for the values code·(1/255) they
// read as and interpolate any other value (every 7th here): still the kernel's bits.
TEST_F(Gpu, LinearizeBitEqualToCpu) {
  for (int c = 1; c <= 4; ++c)
    for (int kind = 0; kind < 3; ++kind) {  // 16-bit codes, linear floats, 8-bit codes
      const bool is_float = kind == 1;
      ImageF day(97, 41, c, 0.f);
      for (size_t i = 0; i < day.size(); ++i) {
        const double u = uniform_open(random_words(11, 0, i, Stream::Test)[0]);
        day[i] = is_float    ? static_cast<float>(4 * u - 0.5)  // negatives and > 1 in a linear EXR
                 : kind == 0 ? static_cast<float>(std::floor(u * 65536) / 65535.0)
                 : i % 7 == 0 ? static_cast<float>(u)
                              : static_cast<float>(std::floor(u * 256)) * (1.f / 255);
      }
      ImageFileInfo info;
      info.path = "day.png";
      info.is_float = is_float;
      info.bits_per_sample = kind == 2 ? 8 : kind == 0 ? 16 : 32;
      const ImageF cpu = scene::linearize(day, info), dev = gpu::linearize(*ctx, day, info);
      ASSERT_EQ(cpu.size(), dev.size());
      size_t differ = 0;
      for (size_t i = 0; i < cpu.size(); ++i) differ += std::memcmp(&cpu[i], &dev[i], sizeof(float)) != 0;
      EXPECT_EQ(differ, 0u) << c << " channels, kind " << kind;
    }
  ImageF day(31, 17, 3, 0.25f);
  day.at(20, 9, 1) = std::numeric_limits<float>::infinity();
  day.at(6, 4, 0) = std::numeric_limits<float>::quiet_NaN();
  ImageFileInfo info;
  info.path = "broken.exr";
  info.is_float = true;
  std::string cpu_msg, dev_msg;
  try { (void)scene::linearize(day, info); } catch (const Error& e) { cpu_msg = e.what(); }
  try { (void)gpu::linearize(*ctx, day, info); } catch (const Error& e) { dev_msg = e.what(); }
  EXPECT_NE(cpu_msg.find("(6, 4)"), std::string::npos) << cpu_msg;
  EXPECT_EQ(dev_msg, cpu_msg);
}

// Composition: darken (bit-equal) + low beam + lights. The beam illuminance is an input image
// (scene::low_beam_illuminance, on the CPU) and the float operations are the CPU's in its order:
// bit-equal.
TEST_F(Gpu, ComposeMatchesCpuToOneUlp) {
  for (auto [w, h] : {std::pair{640, 320}, std::pair{321, 161}}) {
    scene::SyntheticOptions so;
    so.width = w, so.height = h, so.vp_x = w / 2.0, so.vp_y = h * 0.4;
    const auto road = scene::make_synthetic_road(so);
    const auto sp = scene::load_scene_preset("night-urban");
    const ImageF tex = scene::reflectance_texture(road.day_linear_srgb, road.labels.ids, sp);
    scene::VanishingPoint vp;
    vp.x = so.vp_x, vp.y = so.vp_y;
    const ImageF depth = scene::low_beam_illuminance(
        scene::camera_geometry(scene::rig_for_image(w, h), w, h, vp), w, h, sp);
    ImageF lights(w, h, 3, 0.f, unit::radiance);
    for (size_t i = 0; i < lights.size(); ++i)
      lights[i] = static_cast<float>(uniform_open(random_words(12, 0, i, Stream::Test)[0]) * 0.01);
    const ImageF cpu = scene::compose(tex, lights, road.labels.ids, depth, sp);
    const ImageF dev = gpu::compose(*ctx, tex, lights, road.labels.ids, depth, sp);
    ASSERT_EQ(cpu.size(), dev.size());
    size_t differ = 0;
    int64_t worst_ulp = 0;
    for (size_t i = 0; i < cpu.size(); ++i) {
      int32_t a, b;
      std::memcpy(&a, &cpu[i], 4), std::memcpy(&b, &dev[i], 4);
      differ += a != b;
      worst_ulp = std::max<int64_t>(worst_ulp, std::llabs(static_cast<int64_t>(a) - b));
    }
    std::fprintf(stderr, "[gpu] compose %dx%d: %zu of %zu samples differ, worst %lld ulp\n", w, h, differ, cpu.size(),
                 static_cast<long long>(worst_ulp));
    EXPECT_EQ(worst_ulp, 0) << w << "x" << h;
    EXPECT_EQ(differ, 0u) << w << "x" << h;
    // The low beam lit the road: compose exceeds darken + lights there by far more than a ulp.
    const ImageF dark = scene::darken(tex, road.labels.ids, sp);
    double beam = 0;
    for (size_t i = 0; i < cpu.size(); ++i) beam = std::max(beam, cpu[i] - static_cast<double>(dark[i]) - lights[i]);
    EXPECT_GT(beam, 1e-4) << w << "x" << h;
  }
}

// The night chain keeps its images on the device: the tail (darken, compose) uploads the
// texture, light map, labels and depth once each and downloads the radiance (and the darkened
// image when asked); the sensor then reads the radiance where the tail left it, and a run of frames reads
// the mean signal where the photon integral left it. Same results as the uploading path, bit
// for bit; a stale token falls back to the upload.
TEST_F(Gpu, NightChainKeepsImagesOnTheDevice) {
  const int w = 640, h = 320;
  scene::SyntheticOptions so;
  const auto road = scene::make_synthetic_road(so);
  const auto sp = scene::load_scene_preset("night-urban");
  auto stages = std::make_shared<gpu::SceneStages>(*ctx);
  const size_t n = static_cast<size_t>(w) * h;
  auto before = ctx->transfers();
  const scene::NightScene dev = scene::night_scene_with(road.day_linear_srgb, road.labels, sp, 3, true,
                                                        tail_on(stages));
  auto after = ctx->transfers();
  // texture + lights (3 floats) + depth (1 float) + labels (uint16) up; darkened + radiance down.
  EXPECT_EQ(after.uploaded - before.uploaded, n * (12 + 12 + 4 + 2));
  EXPECT_EQ(after.downloaded - before.downloaded, n * (12 + 12));
  ASSERT_TRUE(dev.resident_radiance);
  ASSERT_NE(stages->resident_radiance(dev.resident_radiance), nullptr);
  const scene::NightScene cpu = scene::night_scene(road.day_linear_srgb, road.labels, sp, 3, true);
  EXPECT_FALSE(cpu.resident_radiance);
  EXPECT_EQ(count_differences(cpu.darkened, dev.darkened), 0u);
  // Bit-equal: compose reads the low beam's illuminance as an image made on the CPU, so no exp is
  // evaluated on the device (ComposeMatchesCpuToOneUlp requires 0 ulp); the light map is made on
  // the CPU and only carried. (The former 2e-6 of the peak was the one-ulp allowance of the
  // image-space beam evaluated on the device, gone since 2026-11-25.)
  EXPECT_GT(*std::max_element(cpu.radiance.vec().begin(), cpu.radiance.vec().end()), 0.f);
  EXPECT_EQ(count_differences(cpu.radiance, dev.radiance), 0u);
  EXPECT_EQ(count_differences(cpu.lights, dev.lights), 0u);

  const CameraPreset cam = load_camera_preset("onsemi-ar0331");
  const LensPreset lens = load_lens_preset(cam.default_lens);
  const FixedPatternMaps fpn = generate_fixed_pattern(cam, w, h, "resident-gpu-test");
  ExposureSettings s;
  s.exposure_s = 0.03;
  s.seed = 9;
  gpu::SensorChain chain(*ctx);
  const SensorOutput uploaded = chain.expose(dev.radiance, cam, lens, s, fpn);  // also loads the maps
  before = ctx->transfers();
  const SensorOutput resident =
      chain.expose(dev.radiance, cam, lens, s, fpn, stages->resident_radiance(dev.resident_radiance));
  after = ctx->transfers();
  EXPECT_LT(after.uploaded - before.uploaded, n);  // the w + h row/column noise draws only
  EXPECT_EQ(count_differences(uploaded.raw_dn, resident.raw_dn), 0u);
  EXPECT_EQ(count_differences(uploaded.rgb, resident.rgb), 0u);

  // Frames from the mean signal left on the device.
  const ResolvedExposure ex = resolve(cam, lens, s);
  const ImageF mean_e = chain.mean_signal_electrons(dev.radiance, cam, lens, ex,
                                                    stages->resident_radiance(dev.resident_radiance));
  const DeviceImage token = chain.resident_mean_e();
  ASSERT_TRUE(token);
  for (uint32_t f = 0; f < 2; ++f) {
    s.frame = f;
    before = ctx->transfers();
    const SensorOutput a = chain.sense(mean_e, cam, ex, s, fpn, token);
    after = ctx->transfers();
    EXPECT_LT(after.uploaded - before.uploaded, n) << "frame " << f;
    const SensorOutput b = sense(mean_e, cam, ex, s, fpn);
    EXPECT_EQ(count_differences(a.raw_dn, b.raw_dn), 0u) << "frame " << f;
  }
  // expose() overwrites the mean signal: the token is stale, and sense() uploads (same result).
  (void)chain.expose(dev.radiance, cam, lens, s, fpn);
  EXPECT_FALSE(chain.resident_mean_e());
  EXPECT_FALSE(chain.resident_mean_e() == token);
  before = ctx->transfers();
  const SensorOutput c = chain.sense(mean_e, cam, ex, s, fpn, token);
  after = ctx->transfers();
  EXPECT_GE(after.uploaded - before.uploaded, n * 4);
  EXPECT_EQ(count_differences(c.raw_dn, sense(mean_e, cam, ex, s, fpn).raw_dn), 0u);
  // A later composition overwrites the radiance: the scene's token no longer names a buffer.
  (void)stages->compose(scene::reflectance_texture(road.day_linear_srgb, road.labels.ids, sp), cpu.lights,
                        road.labels.ids, cpu.beam_lux, sp);
  EXPECT_EQ(stages->resident_radiance(dev.resident_radiance), nullptr);
  EXPECT_EQ(stages->resident_radiance(DeviceImage()), nullptr);
}

// Staged transfers (a discrete GPU's path: device-local storage buffers, copies through a
// host-cached staging buffer) give what mapped buffers give, bit for bit: forced on lavapipe,
// with validation (synchronization validation included) watching every copy and barrier.
// The memory types a buffer lands in, on the tables drivers report (flags: 1 device-local,
// 2 host-visible, 4 coherent, 8 cached). No device needed.
TEST(GpuMemory, BuffersAndStagingPickTheRightMemoryTypes) {
  const uint32_t DL = 1, HV = 2, HC = 4, CA = 8, all = 0xffffffffu;
  // A discrete GPU without resizable BAR: VRAM, system memory (plain and cached), a 256 MB BAR.
  const std::vector<uint32_t> discrete = {DL | HV | HC, DL, HV | HC, HV | HC | CA};
  EXPECT_FALSE(gpu::unified_memory(discrete));                                   // Auto stages
  EXPECT_EQ(gpu::pick_memory_type(discrete, all, 0, DL, HV), 1);                // staged storage: VRAM
  EXPECT_EQ(gpu::pick_memory_type(discrete, all, HV | HC, CA, DL), 3);          // staging: cached sysmem
  EXPECT_EQ(gpu::pick_memory_type(discrete, all, HV | HC, DL), 0);              // mapped storage: the BAR
  EXPECT_EQ(gpu::pick_memory_type(discrete, all & ~2u, 0, DL, HV), 0);          // VRAM not allowed: BAR
  EXPECT_EQ(gpu::pick_memory_type(discrete, 1u << 2, HV | HC, CA, DL), 2);      // only plain sysmem allowed
  EXPECT_EQ(gpu::pick_memory_type(discrete, 1u << 1, HV | HC, DL), -1);         // none host-visible allowed
  // lavapipe and integrated GPUs: one type that is everything; Auto maps.
  const std::vector<uint32_t> unified = {DL | HV | HC | CA};
  EXPECT_TRUE(gpu::unified_memory(unified));
  EXPECT_EQ(gpu::pick_memory_type(unified, all, 0, DL, HV), 0);
  EXPECT_EQ(gpu::pick_memory_type(unified, all, HV | HC, CA, DL), 0);
}

TEST_F(Gpu, StagedTransfersAgreeWithMappedBuffers) {
  // Both staged routes: every copy through the staging buffer's slots, and (buffers asked to, where
  // the device offers VK_EXT_external_memory_host: lavapipe does) copies of 1 MB or more straight
  // from and to the caller's imported pages. A context made without import never imports.
  for (const int route : {0, 1, 2}) {  // slots; imported pages; asked to, on a context without
    gpu::ContextOptions o;
    o.staging = gpu::Staging::Staged;
    o.host_import = route != 2;
    gpu::Context staged(o);
    ASSERT_TRUE(staged.device().staged);
    if (route == 2) EXPECT_FALSE(staged.device().host_import);
    if (staged.device().cpu && route != 2) EXPECT_TRUE(staged.device().host_import) << "lavapipe offers host-pointer import";
    const bool imports = route == 1 && staged.device().host_import;
    const bool import = route != 0;
    // Sizes around the staging buffer's two 4 MB slots (one chunk, one short of a chunk, two and a
    // word, three), at an offset of a word.
    for (const size_t bytes : {size_t{4} << 20, (size_t{4} << 20) - 4, (size_t{8} << 20) + 4, size_t{12} << 20}) {
      const size_t words = bytes / 4;
      std::vector<uint32_t> in(words), out(words, 0);
      for (size_t i = 0; i < words; ++i) in[i] = static_cast<uint32_t>((i + bytes) * 2246822519u);
      gpu::Buffer b(staged, bytes + 4);
      b.set_host_import(import);
      const auto t0 = staged.transfers();
      b.upload(in.data(), bytes, 4);
      b.download(out.data(), bytes, 4);
      EXPECT_EQ(in, out) << bytes << " import " << import;
      EXPECT_EQ(staged.transfers().imported - t0.imported, imports ? 2 * bytes : 0) << bytes;
    }
    // A buffer of many chunks, at an offset, and a part read back (12 bytes: through the slots).
    {
      const size_t words = (40u << 20) / 4;
      std::vector<uint32_t> in(words), out(words, 0);
      for (size_t i = 0; i < words; ++i) in[i] = static_cast<uint32_t>(i * 2654435761u);
      gpu::Buffer b(staged, (words + 2) * 4);
      b.set_host_import(import);
      b.upload(in.data(), words * 4, 8);
      b.download(out.data(), words * 4, 8);
      EXPECT_EQ(in, out);
      const auto t0 = staged.transfers();
      uint32_t part[3];
      b.download(part, sizeof(part), 8 + 4 * (words - 3));
      EXPECT_TRUE(part[0] == in[words - 3] && part[2] == in[words - 1]);
      EXPECT_EQ(staged.transfers().imported, t0.imported) << "12 bytes are not imported";
    }
    for (const auto& m : staged.messages()) ADD_FAILURE() << "Vulkan validation: " << m;
  }
  gpu::ContextOptions o;
  o.staging = gpu::Staging::Staged;
  gpu::Context staged(o);
  // The sensor chain, two frames (the fixed-pattern maps stay on the device).
  const CameraPreset cam = load_camera_preset("sony-imx490");
  const LensPreset lens = load_lens_preset(cam.default_lens);
  const int w = 257, h = 129;
  const FixedPatternMaps fpn = generate_fixed_pattern(cam, w, h, "staged-gpu-test");
  const ImageF rad = test_radiance(w, h, 40.0);
  gpu::SensorChain a(*ctx), b(staged);
  for (uint32_t frame = 0; frame < 2; ++frame) {
    ExposureSettings s;
    s.exposure_s = 0.01, s.seed = 4, s.frame = frame;
    s.demosaic = frame ? DemosaicMethod::Lmmse : DemosaicMethod::Bilinear;
    const SensorOutput x = a.expose(rad, cam, lens, s, fpn), y = b.expose(rad, cam, lens, s, fpn);
    EXPECT_EQ(count_differences(x.raw_dn, y.raw_dn), 0u) << frame;
    EXPECT_EQ(count_differences(x.rgb, y.rgb), 0u) << frame;
  }
  // The night tail, then the sensor on the radiance it left on the device.
  scene::SyntheticOptions so;
  so.width = 320, so.height = 160, so.vp_x = 160, so.vp_y = 65;
  const auto road = scene::make_synthetic_road(so);
  const auto sp = scene::load_scene_preset("night-urban");
  auto sa = std::make_shared<gpu::SceneStages>(*ctx), sb = std::make_shared<gpu::SceneStages>(staged);
  const auto na = scene::night_scene_with(road.day_linear_srgb, road.labels, sp, 2, true, tail_on(sa));
  const auto nb = scene::night_scene_with(road.day_linear_srgb, road.labels, sp, 2, true, tail_on(sb));
  EXPECT_EQ(count_differences(na.lights, nb.lights), 0u);
  EXPECT_EQ(count_differences(na.darkened, nb.darkened), 0u);
  EXPECT_EQ(count_differences(na.radiance, nb.radiance), 0u);
  const FixedPatternMaps f2 = generate_fixed_pattern(cam, so.width, so.height, "staged-gpu-test-2");
  ExposureSettings s;
  const SensorOutput x = a.expose(na.radiance, cam, lens, s, f2, sa->resident_radiance(na.resident_radiance));
  const SensorOutput y = b.expose(nb.radiance, cam, lens, s, f2, sb->resident_radiance(nb.resident_radiance));
  EXPECT_EQ(count_differences(x.raw_dn, y.raw_dn), 0u);
  // Linearize, with its bad-pixel flag read back through the staging buffer.
  ImageFileInfo info;
  info.path = "staged";
  ImageF day(64, 32, 3, 0.5f);
  EXPECT_EQ(count_differences(gpu::linearize(*ctx, day, info), gpu::linearize(staged, day, info)), 0u);
  day[3 * (5 * 64 + 7)] = std::numeric_limits<float>::quiet_NaN();
  EXPECT_THROW(gpu::linearize(staged, day, info), Error);
  for (const auto& m : staged.messages()) ADD_FAILURE() << "Vulkan validation: " << m;
}

// An imported copy widens the import to whole pages (the device's minImportedHostPointerAlignment)
// but touches only the bytes asked for: the bytes of the same pages before and after a download's
// range keep their values. Memory the driver will not import (a read-only mapping on some
// drivers) still uploads, through the staging buffer. A BufferCache's setting reaches its
// buffers, and the sensor chain with its copies imported gives the direct context's bits.
TEST_F(Gpu, ImportedHostPagesCopyOnlyTheirRange) {
  gpu::ContextOptions o;
  o.staging = gpu::Staging::Staged;
  gpu::Context staged(o);
  if (!staged.device().host_import) {
    ASSERT_FALSE(staged.device().cpu) << "lavapipe offers host-pointer import";
    GTEST_SKIP() << "this device does not offer VK_EXT_external_memory_host";
  }
  const size_t page = 4096, pages = 600, n = (pages - 2) * page - 2 * 1234;  // 2.4 MB, off the page grid
  const size_t words = (n + 4) / 4;
  std::vector<uint32_t> in(words);
  for (size_t i = 0; i < words; ++i) in[i] = static_cast<uint32_t>(i * 2654435761u + 17);
  gpu::Buffer b(staged, n + 64);
  b.set_host_import(true);
  // Page-aligned host memory; the range starts 1234 + 4 bytes into its second page.
  void* mem = mmap(nullptr, pages * page, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
  ASSERT_NE(mem, MAP_FAILED);
  auto* host = static_cast<unsigned char*>(mem);
  const size_t at = page + 1238;
  std::memcpy(host + at, in.data(), n);
  const auto t0 = staged.transfers();
  b.upload(host + at, n, 12);
  std::memset(host, 0xA5, pages * page);
  b.download(host + at, n, 12);
  EXPECT_EQ(staged.transfers().imported - t0.imported, 2 * n);
  EXPECT_EQ(std::memcmp(host + at, in.data(), n), 0);
  size_t touched = 0;
  for (size_t i = 0; i < pages * page; ++i)
    if (i < at || i >= at + n) touched += host[i] != 0xA5;
  EXPECT_EQ(touched, 0u) << "bytes outside the range changed";
  // A read-only mapping uploads too (imported where the driver allows it, else staged).
  std::memcpy(host + at, in.data(), n);
  ASSERT_EQ(mprotect(mem, pages * page, PROT_READ), 0);
  b.upload(host + at, n, 0);
  std::vector<uint32_t> back(words, 0);
  b.download(back.data(), n, 0);
  EXPECT_EQ(std::memcmp(back.data(), in.data(), n), 0);
  munmap(mem, pages * page);
  // A cache's setting reaches the buffers it made before and after it.
  gpu::BufferCache cache(staged);
  gpu::Buffer& early = cache.get("early", 64);
  cache.set_host_import(true);
  EXPECT_TRUE(early.host_import());
  EXPECT_TRUE(cache.get("late", 64).host_import());
  cache.set_host_import(false);
  EXPECT_FALSE(early.host_import() || cache.get("late", 64).host_import());
  // The sensor chain as batch runs it (its large copies from and to imported pages) gives the
  // direct context's bits: 512 x 256 (the radiance 1.5 MB, the RGB output 1.5 MB, imported).
  const CameraPreset cam = load_camera_preset("sony-imx490");
  const LensPreset lens = load_lens_preset(cam.default_lens);
  const FixedPatternMaps fpn = generate_fixed_pattern(cam, 512, 256, "imported-gpu-test");
  const ImageF rad = test_radiance(512, 256, 40.0);
  gpu::SensorChain direct(*ctx), imported(staged);
  imported.set_host_import(true);
  ExposureSettings s;
  s.exposure_s = 0.01, s.seed = 9;
  const auto t1 = staged.transfers();
  const SensorOutput x = direct.expose(rad, cam, lens, s, fpn), y = imported.expose(rad, cam, lens, s, fpn);
  EXPECT_GE(staged.transfers().imported - t1.imported, 2 * rad.size() * sizeof(float));
  EXPECT_EQ(count_differences(x.raw_dn, y.raw_dn), 0u);
  EXPECT_EQ(count_differences(x.rgb, y.rgb), 0u);
  for (const auto& m : staged.messages()) ADD_FAILURE() << "Vulkan validation: " << m;
}

}  // namespace photosite
#endif

#include "photosite/backend.h"
#include "photosite/io.h"
#include "photosite/night_chain.h"
#include "scene/texture_detail.h"
#include "test_util.h"

#ifdef PHOTOSITE_HAVE_VULKAN
namespace photosite {

// prepare_night on Vulkan linearises on the host, as `batch` does (core/night_chain.cpp): the
// day image does not go up and the linear image does not come back. What must cross: the tail's
// texture, light map (3 floats each), beam illuminance (1 float) and labels (uint16) up, 30 bytes
// a pixel (NightChainKeepsImagesOnTheDevice counts them); the radiance (12 bytes) and the mean
// signal (4) down; besides those only the photon stage's small tables (under a byte a pixel).
// The day image would add 12 bytes a pixel each way. The scene equals the CPU's bit for bit
// (compose is bit-equal, ComposeMatchesCpuToOneUlp), its depth and labels too.
TEST_F(Gpu, PrepareNightLinearizesOnTheHost) {
  scene::SyntheticOptions so;
  so.width = 320;
  so.height = 160;
  const auto road = scene::make_synthetic_road(so);
  const int w = road.labels.ids.width(), h = road.labels.ids.height();
  const size_t n = static_cast<size_t>(w) * h;
  ImageU8 codes(w, h, 3);  // an 8-bit frame's codes, as read_image_codes8 gives them
  for (size_t i = 0; i < codes.size(); ++i) codes[i] = static_cast<uint8_t>((i * 37 + i / 97) % 251);
  ImageFileInfo info;  // as read_image_codes8 describes an 8-bit sRGB PNG
  info.format = "png";
  info.width = w;
  info.height = h;
  info.channels = 3;
  info.bits_per_sample = 8;
  info.srgb_encoded = true;
  const auto sp = scene::load_scene_preset("night-urban");
  SensorSetup setup;
  setup.camera = load_camera_preset("onsemi-ar0331");
  setup.lens = load_lens_preset(setup.camera.default_lens);
  setup.settings.exposure_s = 0.03;
  setup.device_id = "prepare-night-host";
  test::TempDir dir;
  const DeviceStore store(dir.file("store"));
  SensorRunner cpu(Backend::Cpu), vk(Backend::Vulkan);
  const uint64_t own_class_sums = scene::texture_own_class_sums_count();
  const NightChain a = prepare_night(cpu, codes, info, road.labels, sp, setup, store);
  const auto before = vk.transfers();
  const NightChain b = prepare_night(vk, codes, info, road.labels, sp, setup, store);
  const auto after = vk.transfers();
  // On both backends the texture took the class sums made with the linearisation.
  EXPECT_EQ(scene::texture_own_class_sums_count(), own_class_sums);
  EXPECT_LT(after.uploaded - before.uploaded, n * 31);
  EXPECT_GE(after.uploaded - before.uploaded, n * 30);
  EXPECT_LT(after.downloaded - before.downloaded, n * 17);
  EXPECT_GE(after.downloaded - before.downloaded, n * 16);
  EXPECT_EQ(count_differences(a.scene.depth, b.scene.depth), 0u);
  EXPECT_GT(*std::max_element(a.scene.radiance.vec().begin(), a.scene.radiance.vec().end()), 0.f);
  EXPECT_EQ(count_differences(a.scene.radiance, b.scene.radiance), 0u);
}

// `--backend vulkan` gives the same output as `--backend cpu` (flat and night through the CLI);
// the children inherit PHOTOSITE_VK_VALIDATION=1 and print any validation message.
TEST_F(Gpu, CliCharacterizeBackendsAgree) {
  // The EMVA 1288 measurement of the simulated camera with its sense stage on Vulkan reports the
  // same numbers, digit for digit, as on the CPU.
  test::TempDir dir;
  std::string out[2];
  int k = 0;
  for (const char* b : {"cpu", "vulkan"}) {
    const auto r = test::run_cli(std::string("characterize --preset sony-imx174 --json --roi 64 --backend ") + b +
                                 " --device-store '" + dir.file("store") + "'");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    out[k++] = r.output.substr(r.output.find('{'));
  }
  EXPECT_EQ(out[0], out[1]);
  EXPECT_NE(out[0].find("system_gain_dn_per_e"), std::string::npos);
}

TEST_F(Gpu, CliDemosaicBackendsAgreeForEveryMethod) {
  // `photosite demosaic --backend vulkan` runs the method's kernels; the file equals the CPU one.
  test::TempDir dir;
  const std::string store = " --device-store '" + dir.file("store") + "'";
  auto r = test::run_cli("flat --photons 500 --wavelength-nm 525 --preset sony-imx174 --width 61 --height 37 --seed 3"
                         " --backend cpu --out '" + dir.file("flat.exr") + "'" + store);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const ImageF raw = read_exr(dir.file("flat.exr")).channels.at("raw.Y");
  write_exr(dir.file("mosaic.exr"), {{{"Y"}, &raw, "DN"}}, {});
  for (DemosaicMethod m : all_demosaic_methods()) {
    for (const char* b : {"cpu", "vulkan"}) {
      r = test::run_cli(std::string("demosaic --in '") + dir.file("mosaic.exr") + "' --cfa GBRG --method " + to_string(m) +
                        " --backend " + b + " --out '" + dir.file(std::string(to_string(m)) + "-" + b + ".exr") + "'");
      ASSERT_EQ(r.exit_code, 0) << r.output;
      EXPECT_EQ(r.output.find("validation"), std::string::npos) << r.output;
    }
    const ImageF a = read_image(dir.file(std::string(to_string(m)) + "-cpu.exr"));
    const ImageF v = read_image(dir.file(std::string(to_string(m)) + "-vulkan.exr"));
    ASSERT_EQ(a.size(), v.size());
    size_t differ = 0;
    for (size_t i = 0; i < a.size(); ++i) differ += std::memcmp(&a[i], &v[i], sizeof(float)) != 0;
    EXPECT_EQ(differ, 0u) << to_string(m);
  }
}

TEST_F(Gpu, CliBackendsAgreeOnFlatAndNight) {
  test::TempDir dir;
  const std::string store = " --device-store '" + dir.file("store") + "'";
  for (const char* b : {"cpu", "vulkan"}) {
    auto r = test::run_cli(std::string("flat --photons 500 --wavelength-nm 525 --preset sony-imx174 --width 64 --height 48 --seed 3 --backend ") +
                           b + " --out '" + dir.file(std::string("flat-") + b + ".exr") + "'" + store);
    ASSERT_EQ(r.exit_code, 0) << r.output;
    r = test::run_cli(std::string("night --backend ") + b + " --out '" +  // the bundled KITTI sample
                      dir.file(std::string("night-") + b + ".exr") + "'" + store);
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_EQ(r.output.find("validation"), std::string::npos) << r.output;  // the child ran with validation on
  }
  {  // flat: the sensor chain alone, bit-equal
    const ImageF a = read_image(dir.file("flat-cpu.exr"));
    const ImageF b = read_image(dir.file("flat-vulkan.exr"));
    ASSERT_EQ(a.size(), b.size());
    size_t differ = 0;
    for (size_t i = 0; i < a.size(); ++i) differ += std::memcmp(&a[i], &b[i], sizeof(float)) != 0;
    EXPECT_EQ(differ, 0u);
  }
  // night: linearize, darken and compose are bit-equal (LinearizeBitEqualToCpu, DarkenBitEqualToCpu,
  // ComposeMatchesCpuToOneUlp, which requires 0 ulp), the lens glare and the sensor too
  // (GlareInThePhotonStageBitEqualToCpu, ExposeBitEqualToCpuOnEveryCamera): every channel of the
  // EXR is equal. (Earlier, with the scene-space bloom, the light map and radiance agreed to 2e-6
  // of their peak and a few raw samples differed; the bloom is gone.)
  const auto a = read_exr(dir.file("night-cpu.exr")).channels;
  const auto v = read_exr(dir.file("night-vulkan.exr")).channels;
  ASSERT_EQ(a.size(), v.size());
  for (const auto& [name, img] : a) {
    ASSERT_TRUE(v.count(name)) << name;
    const ImageF& w = v.at(name);
    ASSERT_EQ(img.size(), w.size()) << name;
    double peak = 0, worst = 0;
    size_t differ = 0;
    for (size_t i = 0; i < img.size(); ++i) {
      peak = std::max(peak, std::fabs(static_cast<double>(img[i])));
      worst = std::max(worst, std::fabs(static_cast<double>(img[i]) - w[i]));
      differ += std::memcmp(&img[i], &w[i], sizeof(float)) != 0;
    }
    const double frac = static_cast<double>(differ) / img.size();
    std::fprintf(stderr, "[gpu] night %-18s differing %.2e of samples, max |cpu - vulkan| / peak %.2e\n", name.c_str(),
                 frac, peak > 0 ? worst / peak : 0.0);
    EXPECT_EQ(differ, 0u) << name;
  }
}

}  // namespace photosite
#endif

namespace photosite {
// `auto` on a GPU host picked Vulkan whatever the camera, and sony-a7s2 (Tukey-lambda read noise,
// which the kernels lack) was then refused: the default flags failed with a bundled preset. auto
// now keeps the CPU path for a camera the kernels cannot run (the choice as a pure function, so
// that it is tested on a machine without a GPU too).
TEST(GpuCli, AutoKeepsTheCpuForACameraTheKernelsCannotRun) {
  const CameraPreset tukey = load_camera_preset("sony-a7s2"), plain = load_camera_preset("sony-imx174");
  ASSERT_NE(tukey.read_noise_tukey_lambda, 0);
  EXPECT_FALSE(vulkan_runs_camera(tukey));
  EXPECT_TRUE(vulkan_runs_camera(plain));
  EXPECT_EQ(choose_auto(true, &tukey), Backend::Cpu);
  EXPECT_EQ(choose_auto(true, &plain), Backend::Vulkan);
  EXPECT_EQ(choose_auto(true, nullptr), Backend::Vulkan);
  EXPECT_EQ(choose_auto(false, &plain), Backend::Cpu);  // a CPU Vulkan driver: the native path
  EXPECT_EQ(resolve_backend("auto", &tukey), Backend::Cpu);
}

// No Vulkan driver: `--backend vulkan` is a clear error with exit 2, `auto` falls back to the CPU.
// (Runs with or without the backend built in.)
TEST(GpuCli, BackendVulkanWithoutADeviceIsBadInput) {
  test::TempDir dir;
  const char* saved_icd = std::getenv("VK_ICD_FILENAMES");
  const char* saved_drv = std::getenv("VK_DRIVER_FILES");
  const std::string keep_icd = saved_icd ? saved_icd : "", keep_drv = saved_drv ? saved_drv : "";
  setenv("VK_ICD_FILENAMES", dir.file("no-such-driver.json").c_str(), 1);
  setenv("VK_DRIVER_FILES", dir.file("no-such-driver.json").c_str(), 1);
  const std::string args = " --photons 10 --wavelength-nm 525 --preset sony-imx174 --width 16 --height 8 --device-store '" +
                           dir.file("store") + "' --out '";
  auto r = test::run_cli("flat --backend vulkan" + args + dir.file("v.exr") + "'");
  auto a = test::run_cli("flat --backend auto" + args + dir.file("a.exr") + "'");
  auto v = test::run_cli("version --backends");
  // bench night checks its --backend before it reads or times anything (a missing image is not
  // what it reports), and writes no CSV.
  auto bn = test::run_cli("bench night --backend vulkan --image '" + dir.file("no-such-day.png") + "' --labels '" +
                          dir.file("no-such-labels.png") + "' --out-dir '" + dir.path().string() + "'");
  if (saved_icd) setenv("VK_ICD_FILENAMES", keep_icd.c_str(), 1); else unsetenv("VK_ICD_FILENAMES");
  if (saved_drv) setenv("VK_DRIVER_FILES", keep_drv.c_str(), 1); else unsetenv("VK_DRIVER_FILES");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("--backend vulkan"), std::string::npos) << r.output;
  EXPECT_FALSE(std::filesystem::exists(dir.file("v.exr")));
  EXPECT_EQ(a.exit_code, 0) << a.output;
  // `version --backends` says why there is no Vulkan device and that auto runs the CPU path.
  EXPECT_EQ(v.exit_code, 0) << v.output;
  EXPECT_NE(v.output.find("vulkan: unavailable: Vulkan: no Vulkan driver found"), std::string::npos) << v.output;
  EXPECT_NE(v.output.find("auto: cpu"), std::string::npos) << v.output;
  EXPECT_EQ(bn.exit_code, 2) << bn.output;
  EXPECT_NE(bn.output.find("--backend vulkan"), std::string::npos) << bn.output;
  EXPECT_EQ(bn.output.find("no-such-day.png"), std::string::npos) << bn.output;
  EXPECT_FALSE(std::filesystem::exists(dir.file("night_bench.csv")));
}

// With lavapipe: the device, its transfer mode, and auto still on the CPU (lavapipe is slower
// than the native path, docs/vulkan.md).
TEST_F(Gpu, CliVersionListsTheBackends) {
  const auto r = test::run_cli("version --backends");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("cpu: native C++"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("vulkan: " + ctx->device().name), std::string::npos) << r.output;
  EXPECT_NE(r.output.find(ctx->device().staged ? "staged transfers" : "mapped buffers"), std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find(ctx->device().cpu ? "auto: cpu" : "auto: vulkan"), std::string::npos) << r.output;
}

// `bench night --backend vulkan` (issue 16 §4's command for a GPU machine): the chain timed on the
// device beside the CPU rows in the same run, the device named, and its radiance equal to the
// CPU's (CliBackendsAgreeOnFlatAndNight: every channel bit-equal), so the difference printed is 0.
TEST_F(Gpu, BenchNightTimesTheChainOnTheDevice) {
  test::TempDir dir;
  const auto r = test::run_cli("bench night --backend vulkan --repeats 1 --out-dir '" + dir.path().string() + "'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("vulkan device: " + ctx->device().name), std::string::npos) << r.output;
  std::ifstream f(dir.file("night_bench.csv"));
  const std::string csv((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  for (const char* row : {"\"whole chain\"", "\"vulkan: whole chain\"", "\"vulkan: sensor (expose)\"",
                          "\"vulkan: compose\""})
    EXPECT_NE(csv.find(row), std::string::npos) << row << "\n" << csv;
  const std::string key = "radiance max |diff| ";
  const size_t at = r.output.find(key);
  ASSERT_NE(at, std::string::npos) << r.output;
  EXPECT_EQ(std::stod(r.output.substr(at + key.size())), 0.0) << r.output;
  const std::string raw_key = "raw samples differing ";
  const size_t raw_at = r.output.find(raw_key);
  ASSERT_NE(raw_at, std::string::npos) << r.output;
  EXPECT_EQ(std::stod(r.output.substr(raw_at + raw_key.size())), 0.0) << r.output;
}
}  // namespace photosite
