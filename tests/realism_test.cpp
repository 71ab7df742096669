// The thesis baseline (photosite::thesis_night, Baek 2020 Chapter 3) and `photosite bench realism`.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>
#include <string>

#include "photosite/error.h"
#include "photosite/scene/labels.h"
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
// Tolerance: one 8-bit code, the rounding of V·ρ and of OpenCV's 8-bit HSV→RGB.
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
    EXPECT_NEAR(std::max({r, g, b}), 200 * rho, 1.0) << scene::label_name(static_cast<int>(cls[c]));
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
  // σ = 1.2 px and peak colour (255,180,107): together well above zero.
  EXPECT_GT(added_building, 100);
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
  EXPECT_NEAR(night.at(60, 20, 0), 220 * 0.3, 1.0);
}

TEST(ThesisBaseline, RefusesMismatchedInputs) {
  const Stripes s = stripes({Label::Road}, 10, 10, {1, 2, 3});
  EXPECT_THROW(thesis_night(s.day, ImageU16(9, 10, 1)), Error);
  EXPECT_THROW(thesis_night(ImageU8(10, 10, 1), s.labels), Error);
  ImageU16 bad = s.labels;
  bad[5] = 40;
  EXPECT_THROW(thesis_night(s.day, bad), Error);
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

}  // namespace
}  // namespace photosite
