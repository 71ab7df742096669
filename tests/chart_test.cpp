// The night test chart as a library call (include/photosite/scene/chart.h): the luminances it
// promises, checked on the radiance it renders.
#include <gtest/gtest.h>

#include <cmath>

#include "photosite/error.h"
#include "photosite/scene/chart.h"
#include "photosite/sensor/isp.h"
#include "photosite/sensor/spectrum.h"

using namespace photosite;

namespace {
double luminance_at(const ImageF& img, int x, int y) {
  const float c[3] = {img.at(x, y, 0), img.at(x, y, 1), img.at(x, y, 2)};
  return spectrum::luminance_cd_m2(c);
}
// The chart is computed in double and stored as float: each of the three channels is rounded
// once (relative error <= 2^-24), so the luminance, a positive weighted sum of them, is off by at
// most 2^-24 relative, plus the double arithmetic (negligible). 4 * 2^-24 leaves room for the
// illuminant's normalisation to unit luminance, itself a double sum rounded once per channel.
constexpr double kFloatRounding = 4.0 / (1 << 24);
}  // namespace

TEST(Chart, NeutralPatchesAreLambertianUnderTheGivenIlluminance) {
  scene::ChartOptions o;
  o.illuminance_lux = 7.5;
  o.cct_k = 2700;
  const ImageF img = scene::render_chart(o);
  ASSERT_EQ(img.width(), 640);
  ASSERT_EQ(img.height(), 480);
  // Patches 19..23 are neutral (equal sRGB channels): reflectance = their linear value, so the
  // luminance is L = rho E / pi (a Lambertian surface under E lux), whatever the light's colour.
  for (int p : {19, 20, 22, 23}) {
    const auto r = scene::chart_patch_rect(o, p);
    const double rho = srgb_decode(scene::chart_patch_srgb8(p)[0] / 255.0);
    const double want = rho * o.illuminance_lux / 3.14159265358979;
    const double got = luminance_at(img, (r.x0 + r.x1) / 2, (r.y0 + r.y1) / 2);
    EXPECT_NEAR(got / want, 1.0, kFloatRounding) << "patch " << p;
  }
}

TEST(Chart, WedgeSpansFiveDecadesAndLampsHaveTheirLuminance) {
  scene::ChartOptions o;
  o.lamp_cd_m2 = 3e4;
  const ImageF img = scene::render_chart(o);
  for (int s = 0; s < 20; ++s) {
    const auto r = scene::chart_wedge_rect(o, s);
    const double got = luminance_at(img, (r.x0 + r.x1) / 2, (r.y0 + r.y1) / 2);
    EXPECT_NEAR(got / scene::chart_wedge_luminance_cd_m2(s), 1.0, kFloatRounding) << "step " << s;
  }
  // The wedge's ends: std::pow(10, −3 + 5·s/19) with the exponent exact at both (−3 and 2); glibc's
  // pow is within 1 ulp (its manual's table of errors; correctly rounded in practice) and the
  // literal 1e-3 within half of one: 1.5 ulp of the value, 2·2⁻⁵² relative covers it. At s = 19
  // the value, 100, is a double, which a result within 1 ulp can only equal or be next to.
  EXPECT_NEAR(scene::chart_wedge_luminance_cd_m2(0), 1e-3, 2 * 0x1p-52 * 1e-3);
  EXPECT_NEAR(scene::chart_wedge_luminance_cd_m2(19), 1e2, 2 * 0x1p-52 * 1e2);
  // Lamp head centres (2000 K, then 4000 K) and the background.
  const int cx = o.width - o.width / 14;
  EXPECT_NEAR(luminance_at(img, cx, o.height / 6) / o.lamp_cd_m2, 1.0, kFloatRounding);
  EXPECT_NEAR(luminance_at(img, cx, o.height / 6 + o.height / 4) / o.lamp_cd_m2, 1.0, kFloatRounding);
  EXPECT_NEAR(luminance_at(img, 0, 0) / o.background_cd_m2, 1.0, kFloatRounding);
  // The 2000 K lamp is redder than the 4000 K one (R/B of a black body falls with temperature).
  const float* warm = &img.at(cx, o.height / 6, 0);
  const float* cool = &img.at(cx, o.height / 6 + o.height / 4, 0);
  EXPECT_GT(warm[0] / warm[2], cool[0] / cool[2]);
}

TEST(Chart, BadOptionsAreBadInputNamingTheParameter) {
  auto kind_and_text = [](scene::ChartOptions o) -> std::pair<Error::Kind, std::string> {
    try {
      scene::render_chart(o);
    } catch (const Error& e) {
      return {e.kind(), e.what()};
    }
    return {Error::Kind::Internal, "no error"};
  };
  scene::ChartOptions small;
  small.width = 10;
  auto [k1, t1] = kind_and_text(small);
  EXPECT_EQ(k1, Error::Kind::BadInput);
  EXPECT_NE(t1.find("chart size"), std::string::npos) << t1;
  scene::ChartOptions cold;
  cold.cct_k = 100;
  auto [k2, t2] = kind_and_text(cold);
  EXPECT_EQ(k2, Error::Kind::BadInput);
  EXPECT_NE(t2.find("CCT"), std::string::npos) << t2;
  scene::ChartOptions dark;
  dark.illuminance_lux = -1;
  EXPECT_EQ(kind_and_text(dark).first, Error::Kind::BadInput);
}

// A luminance or illuminance whose radiance is beyond float's range (3.4e38) is bad input naming
// the parameter (before: Inf radiance written, exit 0, which expose then refused); the header
// records the lamp and background luminances beside the illuminance and CCT.
TEST(Chart, OverflowingLuminanceIsBadInputAndTheHeaderRecordsEveryLuminance) {
  const auto parameter_of = [](scene::ChartOptions o) -> std::string {
    try {
      scene::render_chart(o);
    } catch (const ParameterError& e) {
      return e.parameter();
    }
    return "no error";
  };
  scene::ChartOptions lamp, lux, bg;
  lamp.lamp_cd_m2 = 1e42;
  lux.illuminance_lux = 1e300;
  bg.background_cd_m2 = 1e42;  // about 1e39 W.sr-1.m-2 (a 4000 K white gives some 300 lm/W)
  EXPECT_EQ(parameter_of(lamp), "lamp_cd_m2");
  EXPECT_EQ(parameter_of(lux), "illuminance_lux");
  EXPECT_EQ(parameter_of(bg), "background_cd_m2");
  // A lamp 1e30 cd/m2, large but within float, is rendered, all finite.
  scene::ChartOptions bright;
  bright.width = 64;
  bright.height = 48;
  bright.lamp_cd_m2 = 1e30;
  const ImageF img = scene::render_chart(bright);
  for (float v : img.vec()) ASSERT_TRUE(std::isfinite(v));
  scene::ChartOptions o;
  o.lamp_cd_m2 = 5000;
  o.background_cd_m2 = 0.5;
  const auto a = scene::chart_attributes(o);
  EXPECT_EQ(std::get<double>(a.at("photosite/lamp_cd_m2")), 5000);
  EXPECT_EQ(std::get<double>(a.at("photosite/background_cd_m2")), 0.5);
}
