// The previews' colour correction matrix (isp.h: colour_correction_matrix, apply_colour_matrix;
// outputs.h: PreviewCcm, `night --preview-ccm`).
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "photosite/error.h"
#include "photosite/outputs.h"
#include "photosite/sensor/demosaic.h"
#include "photosite/sensor/isp.h"
#include "photosite/sensor/spectrum.h"
#include "test_util.h"

namespace photosite {
namespace {

using Mat3 = std::array<std::array<double, 3>, 3>;

// The camera's RGB per unit radiance in each box (its photon matrix on axis at 1 s through the CFA's
// filter_planes_to_rgb, each plane rounded to float as a frame's samples are): M[r][k].
Mat3 camera_matrix(const CameraPreset& cam) {
  LensPreset lens;
  lens.cos4_falloff = false;
  ExposureSettings s;
  s.exposure_s = 1.0;
  const PhotonMatrix m = photon_matrix(cam, lens, resolve(cam, lens, s));
  Mat3 M{};
  for (int k = 0; k < 3; ++k) {
    float planes[4], rgb[3];
    for (int c = 0; c < 4; ++c) planes[c] = static_cast<float>(m[c][k]);
    filter_planes_to_rgb(cam.cfa, planes, rgb);
    for (int r = 0; r < 3; ++r) M[r][k] = rgb[r];
  }
  return M;
}
double norm_inf(const Mat3& A) {
  double n = 0;
  for (const auto& row : A) n = std::max(n, std::abs(row[0]) + std::abs(row[1]) + std::abs(row[2]));
  return n;
}

const char* const kRgbCameras[] = {"onsemi-ar0331", "sony-a7s2", "sony-icx267-flea2", "sony-imx174", "sony-imx490"};

// The defining property: through the white balance and the matrix, the camera's response to any box
// radiance b is shown as s·T·b, T = diag(1/(B·1))·B the boxes' sRGB colours (B = box_to_linear_srgb)
// scaled so that the equal-energy white is neutral, s = (M·1)_G. Checked on 200 random radiances
// per bundled RGB camera, against T·b computed here from B alone (not through M⁻¹).
// Tolerance: C is s·B·M⁻¹ in double; inverting M moves its entries by at most ~κ(M)·u relative
// (u = 2^-53, κ the ∞-norm condition number: Higham, Accuracy and Stability of Numerical Algorithms,
// §14.1, for the adjugate-over-determinant inverse with a small constant), and the products and sums
// of 3-term rows add a few u. So |shown − expected| <= 64·κ(M)·u·(|s·T|·|b|)_r per channel: a
// bound with a generous constant, still ~1e-12 for these cameras, so any wrong entry of C (a
// transposed matrix, the white balance not undone, no matrix at all) fails by orders of magnitude.
TEST(ColourMatrix, ShowsEveryBoxRadianceAsItsSrgbColour) {
  const Mat3& B = spectrum::box_to_linear_srgb();
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  for (const char* name : kRgbCameras) {
    SCOPED_TRACE(name);
    const CameraPreset cam = load_camera_preset(name);
    const Mat3 M = camera_matrix(cam);
    const Mat3 C = colour_correction_matrix(cam);
    const auto wb = white_balance_gains(cam);
    const double kappa = norm_inf(M) * norm_inf(spectrum::invert3(M));
    double det = 0, hadamard = 1;
    det = M[0][0] * (M[1][1] * M[2][2] - M[1][2] * M[2][1]) - M[0][1] * (M[1][0] * M[2][2] - M[1][2] * M[2][0]) +
          M[0][2] * (M[1][0] * M[2][1] - M[1][1] * M[2][0]);
    for (int k = 0; k < 3; ++k) hadamard *= std::sqrt(M[0][k] * M[0][k] + M[1][k] * M[1][k] + M[2][k] * M[2][k]);
    const double s = M[1][0] + M[1][1] + M[1][2];
    std::printf("%-20s det/Hadamard %.3f  kappa %.1f  C = [%.3f %.3f %.3f; %.3f %.3f %.3f; %.3f %.3f %.3f]\n", name,
                std::abs(det) / hadamard, kappa, C[0][0], C[0][1], C[0][2], C[1][0], C[1][1], C[1][2], C[2][0], C[2][1],
                C[2][2]);
    const double tol = 64 * kappa * 0x1p-53;
    double worst = 0;
    for (int t = 0; t < 200; ++t) {
      const std::array<double, 3> b{u01(rng), u01(rng), u01(rng)};
      double c[3];
      for (int r = 0; r < 3; ++r) c[r] = M[r][0] * b[0] + M[r][1] * b[1] + M[r][2] * b[2];
      for (int r = 0; r < 3; ++r) {
        const double shown = C[r][0] * wb[0] * c[0] + C[r][1] * wb[1] * c[1] + C[r][2] * wb[2] * c[2];
        const double white = B[r][0] + B[r][1] + B[r][2];
        const double expected = s * (B[r][0] * b[0] + B[r][1] * b[1] + B[r][2] * b[2]) / white;
        const double scale = s * (std::abs(B[r][0]) * b[0] + std::abs(B[r][1]) * b[1] + std::abs(B[r][2]) * b[2]) / white;
        worst = std::max(worst, std::abs(shown - expected) / (tol * scale));
        ASSERT_LE(std::abs(shown - expected), tol * scale) << "box " << b[0] << " " << b[1] << " " << b[2] << " channel " << r;
      }
    }
    std::printf("%-20s worst error %.3f of the bound\n", name, worst);
  }
}

// Every row sums to 1: a neutral (R = G = B after the white balance) keeps its value, so the
// previews' exposure, white floor and the camera ISP's noise model keep their meaning. To the
// precision of the white balance: the preset's gains are ratios of the equal-energy white's
// filter responses, each a float (rounded once, 2^-24 relative; white_balance_gains), where C is
// built from M's columns, each rounded alike; the columns are non-negative, so their double sum is
// within 2^-24 of the exact response too. Each gain is then within 2·2^-24 of the ratio C inverts,
// and so is C·1 (1/g_c enters entry C_rc once): |Σ_c C_rc − 1| <= 4·2^-24·Σ_c|C_rc| (the two
// roundings of each ratio, doubled for the double arithmetic's few u = 2^-53 and the quotient).
TEST(ColourMatrix, RowsSumToOneSoNeutralsKeepTheirValue) {
  for (const char* name : kRgbCameras) {
    SCOPED_TRACE(name);
    const Mat3 C = colour_correction_matrix(load_camera_preset(name));
    for (int r = 0; r < 3; ++r) {
      const double sum = C[r][0] + C[r][1] + C[r][2];
      const double mag = std::abs(C[r][0]) + std::abs(C[r][1]) + std::abs(C[r][2]);
      EXPECT_LE(std::abs(sum - 1), 4 * 0x1p-24 * mag) << "row " << r;
      // A real matrix: the camera's filters overlap, so the diagonal exceeds 1 and some entry is negative.
      EXPECT_GT(C[r][r], 1.0) << "row " << r;
    }
  }
}

// apply_colour_matrix keeps the preview's white balance outside: a preview of its output with the
// gains wb shows C·(wb ∘ c). Its samples are floats: each output sample is the double product
// rounded once (2^-24 relative), and diag(1/wb)·C·diag(wb) in double adds a few u (2^-53) per entry:
// |wb_r·o_r − (C·(wb∘c))_r| <= 2^-24·|exact| + 8·u·Σ_c |C_rc·wb_c·c_c|, times wb_r's own rounding
// (the product wb_r·o_r is taken in double here, exact to u).
TEST(ColourMatrix, AppliedBeforeTheWhiteBalanceGains) {
  const CameraPreset cam = load_camera_preset("onsemi-ar0331");
  const Mat3 C = colour_correction_matrix(cam);
  const std::array<double, 3> wb{1.7, 1.0, 2.3};  // not the preset's: an AWB's gains pass through alike
  ImageF rgb(37, 11, 3);
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(-50.f, 4000.f);  // DN above black, read noise below 0 too
  for (size_t i = 0; i < rgb.size(); ++i) rgb[i] = u(rng);
  const ImageF out = apply_colour_matrix(rgb, C, wb);
  ASSERT_EQ(out.width(), 37);
  ASSERT_EQ(out.height(), 11);
  ASSERT_EQ(out.channels(), 3);
  for (size_t p = 0; p < rgb.pixel_count(); ++p)
    for (int r = 0; r < 3; ++r) {
      double exact = 0, mag = 0;
      for (int c = 0; c < 3; ++c) {
        exact += C[r][c] * wb[c] * rgb[3 * p + c];
        mag += std::abs(C[r][c] * wb[c] * rgb[3 * p + c]);
      }
      const double shown = wb[r] * out[3 * p + r];
      ASSERT_LE(std::abs(shown - exact), 0x1p-24 * std::abs(exact) + 8 * 0x1p-53 * mag + 0x1p-53 * std::abs(shown))
          << "pixel " << p << " channel " << r;
    }
}

// A camera without three independent colour channels has no matrix: RCCC's G and B are both
// (C − R)/2 (filter_planes_to_rgb), so M is singular. The error names the option; the preview
// without the matrix is still made for it.
TEST(ColourMatrix, RcccCameraHasNoneAndSaysSo) {
  const CameraPreset rccc = load_camera_preset("onsemi-ar0132at-rccc");
  try {
    colour_correction_matrix(rccc);
    ADD_FAILURE() << "no error";
  } catch (const ParameterError& e) {
    EXPECT_EQ(e.parameter(), "preview_ccm");
    const std::string m = e.message_for("--preview-ccm");
    EXPECT_NE(m.find("onsemi-ar0132at-rccc"), std::string::npos) << m;
    EXPECT_NE(m.find("RCCC"), std::string::npos) << m;
  }
  PreviewOptions o;
  EXPECT_NO_THROW(check_preview_camera(o, rccc));
  o.ccm = PreviewCcm::Camera;
  EXPECT_THROW(check_preview_camera(o, rccc), ParameterError);
  EXPECT_NO_THROW(check_preview_camera(o, load_camera_preset("onsemi-ar0331")));
  EXPECT_EQ(parse_preview_ccm("camera"), PreviewCcm::Camera);
  EXPECT_EQ(parse_preview_ccm("none"), PreviewCcm::None);
  try {
    parse_preview_ccm("srgb");
    ADD_FAILURE() << "no error";
  } catch (const ParameterError& e) {
    EXPECT_EQ(e.message_for("--preview-ccm"), "--preview-ccm: 'srgb' is not none or camera");
  }
}

// preview_image with PreviewCcm::Camera is the simple (or camera) ISP of apply_colour_matrix's
// output, and what it does to a colour: the camera's response to light in the long-wave box alone
// (a red lamp) is shown without the matrix as a desaturated red (its G and B filters see some of
// it), with the matrix as the box's own sRGB colour, its G and B at or below 0 and clipped there.
TEST(ColourMatrix, PreviewImageShowsTheSceneColourNotTheFilters) {
  SensorSetup setup;
  setup.camera = load_camera_preset("onsemi-ar0331");
  setup.lens = load_lens_preset(setup.camera.default_lens);
  setup.settings.exposure_s = 0.02;
  const ResolvedExposure ex = resolve(setup.camera, setup.lens, setup.settings);
  const Mat3 M = camera_matrix(setup.camera);
  SensorOutput out;
  out.rgb = ImageF(16, 8, 3, 0.f);
  // Left half: a grey wall (box 1, 1, 1); right half: the red lamp (box 1, 0, 0); scaled to DN.
  for (int y = 0; y < 8; ++y)
    for (int x = 0; x < 16; ++x) {
      const std::array<double, 3> b = x < 8 ? std::array<double, 3>{1, 1, 1} : std::array<double, 3>{1, 0, 0};
      for (int r = 0; r < 3; ++r)
        out.rgb.at(x, y, r) = static_cast<float>(1000 * (M[r][0] * b[0] + M[r][1] * b[1] + M[r][2] * b[2]) / M[1][1]);
    }
  const auto wb = white_balance_gains(setup.camera);
  PreviewOptions o;
  o.ccm = PreviewCcm::Camera;
  const ImageU8 with = preview_image(out, setup, ex, o);
  const ImageU8 ref = preview_srgb8(apply_colour_matrix(out.rgb, colour_correction_matrix(setup.camera), wb), wb, 0.99,
                                    1.0, preview_min_white(setup.camera, ex, wb));
  ASSERT_EQ(with.size(), ref.size());
  EXPECT_EQ(0, std::memcmp(with.data(), ref.data(), with.size()));
  const ImageU8 without = preview_image(out, setup, ex);
  // The grey stays grey either way (rows sum to 1); the red loses its filters' crosstalk.
  const int gx = 2, rx = 12, y = 3;
  for (const ImageU8* p : {&with, &without}) {
    EXPECT_EQ(p->at(gx, y, 0), p->at(gx, y, 1));
    EXPECT_EQ(p->at(gx, y, 1), p->at(gx, y, 2));
  }
  std::printf("red lamp: without the matrix %d %d %d, with it %d %d %d\n", without.at(rx, y, 0), without.at(rx, y, 1),
              without.at(rx, y, 2), with.at(rx, y, 0), with.at(rx, y, 1), with.at(rx, y, 2));
  EXPECT_GT(without.at(rx, y, 1), 0);  // the G filter's response to 600-700 nm shows as green
  const Mat3& B = spectrum::box_to_linear_srgb();
  for (int r = 1; r < 3; ++r)  // where the box's own sRGB colour has G, B <= 0, the preview shows 0
    if (B[r][0] <= 0) EXPECT_EQ(with.at(rx, y, r), 0) << "channel " << r;
  EXPECT_LT(with.at(rx, y, 1), without.at(rx, y, 1));
}


// The flag: bad values and a camera without a matrix exit 2 naming it, before any output; it needs
// --preview. With it the bundled KITTI frame's preview differs from the one without.
TEST(ColourMatrix, CommandLineFlag) {
  test::TempDir tmp;
  test::expect_preview_flag_refused(
      tmp, {{"night --out '{o}' --preview '{p}' --preview-ccm srgb", "--preview-ccm: 'srgb' is not none or camera"},
           {"night --out '{o}' --preview-ccm camera", "--preview-ccm camera: no preview is written"},
           {"night --out '{o}' --preview '{p}' --preview-ccm camera --preset onsemi-ar0132at-rccc",
            "--preview-ccm: camera 'onsemi-ar0132at-rccc' (RCCC) has no three independent colour channels"},
           {"expose --preset onsemi-ar0331 --radiance '{r}' --out '{o}' --preview '{p}' --preview-ccm Camera",
            "--preview-ccm: 'Camera' is not none or camera"}});
  const auto a = test::run_cli("night --backend cpu --compression none --out '" + tmp.file("a.exr") + "' --preview '" +
                               tmp.file("a.png") + "'");
  ASSERT_EQ(a.exit_code, 0) << a.output;
  const auto b = test::run_cli("night --backend cpu --compression none --out '" + tmp.file("b.exr") + "' --preview '" +
                               tmp.file("b.png") + "' --preview-ccm camera");
  ASSERT_EQ(b.exit_code, 0) << b.output;
  auto bytes = [](const std::string& f) {
    std::ifstream in(f, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
  };
  EXPECT_FALSE(bytes(tmp.file("a.png")).empty());
  EXPECT_NE(bytes(tmp.file("a.png")), bytes(tmp.file("b.png")));
}

}  // namespace
}  // namespace photosite
