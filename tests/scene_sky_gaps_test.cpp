// Sky seen through tree crowns (scene::take_sky_gaps, scene/sky_gaps.cpp): which vegetation
// pixels the scene takes for sky, from every form of the day image alike, and that the night then
// renders them as it renders sky labelled so in the file.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "photosite/image.h"
#include "photosite/scene/night.h"
#include "photosite/sensor/spectrum.h"
#include "scene/texture_detail.h"

using namespace photosite;
using namespace photosite::scene;

namespace {

constexpr uint16_t kVeg = static_cast<uint16_t>(Label::Vegetation);
constexpr uint16_t kSky = static_cast<uint16_t>(Label::Sky);
constexpr uint16_t kBuilding = static_cast<uint16_t>(Label::Building);

// A grey 8-bit sRGB frame with labels: rows [0, 16) sky at code 188 (linear 0.50), rows [16, 48)
// vegetation at code 48 (linear 0.030), with placed pixels; `expect` lists those that join the sky.
struct Crown {
  static constexpr int W = 64, H = 48;
  ImageU8 codes{W, H, 3, 0};
  LabelMap labels;
  std::vector<uint32_t> expect;
  Crown() {
    labels.ids = ImageU16(W, H, 1, kVeg);
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x) put(x, y, y < 16 ? kSky : kVeg, y < 16 ? 188 : 48);
    // The threshold is 0.6 of the sky's 0.5029: 0.3018 (code 150 decodes to 0.3050, 149 to 0.3005).
    for (int x = 10; x < 15; ++x) put(x, 16, kVeg, 170, true);               // the crown's rim
    for (int k = 0; k < 5; ++k) put(20 + k, 16 + k, kVeg, 150, true);        // a diagonal chain from it
    for (int y = 30; y < 33; ++y)
      for (int x = 30; x < 33; ++x) put(x, y, kVeg, 188);                    // a hole no chain joins
    put(40, 16, kVeg, 149);                                                  // below the threshold,
    put(40, 17, kVeg, 188);                                                  // so this one stays
    put(50, 16, kBuilding, 255);                                             // a bright façade, and
    put(50, 17, kVeg, 188);  // vegetation below it, beside dim leaves only (49/51,16 are leaves)
    std::sort(expect.begin(), expect.end());
  }
  void put(int x, int y, uint16_t id, uint8_t code, bool joins = false) {
    labels.ids.at(x, y) = id;
    for (int c = 0; c < 3; ++c) codes.at(x, y, c) = code;
    if (joins) expect.push_back(static_cast<uint32_t>(y * W + x));
  }
};

ScenePreset with_fraction(double f) {
  ScenePreset p = load_scene_preset("night-urban");
  p.sky_gap_fraction = f;
  return p;
}

}  // namespace

// The rim and the chain joined to it are taken, from the codes, from read_image's floats of the
// same file, and from the linear image alike; the hole, the pixel behind a dim one and the one
// under a bright façade stay vegetation; restore gives the file's ids back.
TEST(SkyGaps, TakesBrightVegetationJoinedToTheSkyOnly) {
  const Crown c;
  const ScenePreset p = with_fraction(0.6);
  const float threshold = static_cast<float>(0.6 * srgb8_decodes()[188]);  // the construction's premise (Crown)
  ASSERT_GE(srgb8_decodes()[150], threshold);
  ASSERT_LT(srgb8_decodes()[149], threshold);
  ImageF floats(Crown::W, Crown::H, 3);
  for (size_t i = 0; i < floats.size(); ++i) floats[i] = c.codes[i] * (1.f / 255);
  ImageFileInfo info;
  info.bits_per_sample = 8;
  const ImageF lin = linearize(floats, info);
  for (int form = 0; form < 3; ++form) {
    LabelMap l = c.labels;
    const size_t n = form == 0 ? take_sky_gaps(l, c.codes, p) : form == 1 ? take_sky_gaps(l, floats, info, p)
                                                                           : take_sky_gaps(l, lin, p);
    EXPECT_TRUE(l.sky_gaps_taken);
    EXPECT_EQ(n, c.expect.size()) << "form " << form;
    EXPECT_EQ(l.sky_gaps, c.expect) << "form " << form;
    for (const uint32_t i : c.expect) EXPECT_EQ(l.ids[i], kSky);
    restore_sky_gaps(l);
    EXPECT_FALSE(l.sky_gaps_taken);
    EXPECT_EQ(l.ids.vec(), c.labels.ids.vec()) << "form " << form;
  }
}

// None where the preset says 0, where the sky has fewer than 64 pixels (its level unknown), or
// where its median is 0; 64 sky pixels are enough.
TEST(SkyGaps, NoneWithoutASkyLevel) {
  Crown c;
  {
    LabelMap l = c.labels;
    EXPECT_EQ(take_sky_gaps(l, c.codes, with_fraction(0)), 0u);
    EXPECT_TRUE(l.sky_gaps_taken);
    EXPECT_EQ(l.ids.vec(), c.labels.ids.vec());
  }
  // Sky left only in row 15's first k pixels (the rest of rows 0-15: building, as dim as leaves).
  for (const int k : {63, 64}) {
    Crown s;
    for (int y = 0; y < 16; ++y)
      for (int x = 0; x < Crown::W; ++x)
        if (y < 15 || x >= k) s.put(x, y, kBuilding, 48);
    LabelMap l = s.labels;
    const size_t n = take_sky_gaps(l, s.codes, with_fraction(0.6));
    if (k == 63) EXPECT_EQ(n, 0u);
    else EXPECT_GT(n, 0u);  // the rim at x 10-14 and the chain at x 20-24 lie under it
  }
  Crown black;
  for (int y = 0; y < 16; ++y)
    for (int x = 0; x < Crown::W; ++x) black.put(x, y, kSky, 0);
  LabelMap l = black.labels;
  EXPECT_EQ(take_sky_gaps(l, black.codes, with_fraction(0.6)), 0u);
}

// The night of a crown whose rim shows the sky: with the gaps taken (night_scene takes them on a
// copy when its caller did not) it is, to the bit, the night of the same frame with those pixels
// labelled sky in the file; without (fraction 0) the rim renders otherwise.
TEST(SkyGaps, NightRendersThemAsSkyLabelledInTheFile) {
  SyntheticOptions o;  // 640x320, sky above row 130 between x 243 and 396 and over rows 0-50
  o.cars = 1;
  SyntheticScene s = make_synthetic_road(o);
  // A crown in the sky, rows 60-110, x 270-370: leaves, a rim of sky along its top row and
  // sides, and a sky-bright hole in the middle that no chain joins.
  std::vector<uint32_t> rim;
  for (int y = 60; y <= 110; ++y)
    for (int x = 270; x <= 370; ++x) {
      const bool edge = y == 60 || x == 270 || x == 370;
      const bool hole = y >= 80 && y < 84 && x >= 316 && x < 320;
      s.labels.ids.at(x, y) = kVeg;
      const float* sky = edge || hole ? &s.day_linear_srgb.at(x, 40) : nullptr;  // the sky's colour
      const float leaf[3] = {0.05f, 0.12f, 0.03f};
      for (int ch = 0; ch < 3; ++ch) s.day_linear_srgb.at(x, y, ch) = sky ? sky[ch] : leaf[ch];
      if (edge) rim.push_back(static_cast<uint32_t>(y * o.width + x));
    }
  std::sort(rim.begin(), rim.end());
  const ScenePreset p = with_fraction(0.6);
  const NightScene taken = night_scene(s.day_linear_srgb, s.labels, p, 7);
  EXPECT_EQ(taken.sky_gap_pixels, rim.size());
  LabelMap filed = s.labels;
  for (const uint32_t i : rim) filed.ids[i] = kSky;
  const NightScene as_sky = night_scene(s.day_linear_srgb, filed, p, 7);
  EXPECT_EQ(as_sky.sky_gap_pixels, 0u);
  EXPECT_EQ(taken.radiance.vec(), as_sky.radiance.vec());
  EXPECT_EQ(taken.lights.vec(), as_sky.lights.vec());
  EXPECT_EQ(taken.depth.vec(), as_sky.depth.vec());
  const NightScene leaves = night_scene(s.day_linear_srgb, s.labels, with_fraction(0), 7);
  EXPECT_EQ(leaves.sky_gap_pixels, 0u);
  size_t differ = 0;
  for (const uint32_t i : rim)
    for (int ch = 0; ch < 3; ++ch) differ += leaves.radiance[3 * i + ch] != taken.radiance[3 * i + ch];
  EXPECT_GT(differ, 0u);  // (how much: on real frames, docs/night.md §1)
}

// The crown's edge left as vegetation (unmix_sky_fringe): a vegetation pixel beside the sky at
// half the sky's day luminance keeps at most half the vegetation's reflectance, scaled
// in all three bands alike; vegetation not beside the sky, the sky and the other classes keep
// their texture to the bit; with sky_gap_fraction 0 nothing is scaled.
TEST(SkyGaps, FringeKeepsTheLeafsShareOnly) {
  constexpr int W = 64, H = 48;
  ImageF lin(W, H, 3, 0.f, "linear sRGB");
  LabelMap labels;
  labels.ids = ImageU16(W, H, 1, kVeg);
  auto put = [&](int x, int y, uint16_t id, float v) {
    labels.ids.at(x, y) = id;
    for (int c = 0; c < 3; ++c) lin.at(x, y, c) = v;
  };
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) put(x, y, y < 16 ? kSky : kVeg, y < 16 ? 0.5f : 0.03f);
  for (int x = 8; x < 40; ++x) put(x, 16, kVeg, 0.25f);  // half sky: below 0.6 of it, not taken
  put(50, 20, kVeg, 0.25f);                              // as bright, but not beside the sky
  for (int x = 44; x < 48; ++x) put(x, 16, kBuilding, 0.25f);  // a façade's edge: not vegetation
  const ScenePreset p = with_fraction(0.6);
  LabelMap l = labels;
  ASSERT_EQ(take_sky_gaps(l, lin, p), 0u);
  EXPECT_FLOAT_EQ(l.sky_day_luminance, 0.5f);
  // The leaves' level: the median of the vegetation under 0.6 × 0.5 (every pixel here: under 64
  // in the 1/64 sample, so all of them), the 0.03 of the crown.
  EXPECT_FLOAT_EQ(l.leaf_day_luminance, 0.03f);
  const ImageF before = reflectance_texture(lin, l.ids, p);
  ImageF tex = before;
  const size_t n = unmix_sky_fringe(tex, lin, l, p);
  const auto& K = spectrum::band_luminous_efficacy_lm_per_W();
  const double rho = class_reflectance(kVeg, p);
  auto lum = [&](const ImageF& t, int x, int y) { return K[0] * t.at(x, y, 0) + K[1] * t.at(x, y, 1) + K[2] * t.at(x, y, 2); };
  size_t fringe = 0;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const bool edge = y == 16 && labels.ids.at(x, y) == kVeg;  // every vegetation pixel of row 16
      if (!edge) {
        for (int c = 0; c < 3; ++c) ASSERT_EQ(tex.at(x, y, c), before.at(x, y, c)) << x << "," << y;
        continue;
      }
      ++fringe;
      // The pixel as a mix of sky (0.5) and leaves (0.03): f = (0.25 − 0.03)/(0.5 − 0.03) at the
      // half-sky pixels, 0 at the leaves of row 16. The scaled texture's luminance factor is the
      // bound up to the float rounding of the three products t_k·k (each within 2⁻²⁴ relative):
      // at most (1 − f)·ρ·(1 + 2⁻²²).
      const double f = std::max(0.0, (lin.at(x, y, 0) - double{0.03f}) / (0.5 - double{0.03f}));
      EXPECT_LE(lum(tex, x, y), (1 - f) * rho * (1 + std::ldexp(1.0, -22))) << x;
      if (lum(before, x, y) > (1 - f) * rho) {  // scaled: all bands by one factor k ≤ 1, to the bound
        // Each band's t_k·k is rounded to float (2⁻²⁴ relative), so two bands' ratios agree to
        // 2·2⁻²⁴·k ≤ 2⁻²³; 2⁻²² bounds it.
        EXPECT_NEAR(tex.at(x, y, 1) / before.at(x, y, 1), tex.at(x, y, 0) / before.at(x, y, 0), std::ldexp(1.0, -22));
        // (the bound to 2⁻²² relative, as above)
        EXPECT_NEAR(lum(tex, x, y), (1 - f) * rho, (1 - f) * rho * std::ldexp(1.0, -22));
      } else {
        for (int c = 0; c < 3; ++c) EXPECT_EQ(tex.at(x, y, c), before.at(x, y, c));
      }
    }
  EXPECT_EQ(fringe, static_cast<size_t>(W - 4));
  // The 32 half-sky pixels (their texture twice the leaves' luminance factor over half of it)
  // are scaled; the leaves of row 16, pure leaves by the mix (f = 0), are not.
  EXPECT_EQ(n, 32u);
  // Without a leaves' level (fewer than 64 vegetation pixels under the threshold): Y_leaf = 0, so
  // f = Y / Y_sky, and the leaves of the edge are scaled to (1 − 0.03/0.5)·ρ too.
  {
    ImageF lin2 = lin;
    LabelMap few = labels;
    for (int y = 16; y < H; ++y)
      for (int x = 0; x < W; ++x) {
        if (y > 16) few.ids.at(x, y) = kBuilding;
        for (int c = 0; c < 3; ++c) lin2.at(x, y, c) = 0.03f;  // row 16: leaves only
      }
    ASSERT_EQ(take_sky_gaps(few, lin2, p), 0u);
    EXPECT_EQ(few.leaf_day_luminance, 0.f);  // the 60 leaves of row 16 only
    ImageF t2 = reflectance_texture(lin2, few.ids, p);
    const ImageF t2_before = t2;
    EXPECT_EQ(unmix_sky_fringe(t2, lin2, few, p), static_cast<size_t>(W - 4));
    for (int x = 0; x < W; ++x) {
      if (few.ids.at(x, 16) != kVeg) continue;
      const double f = lin2.at(x, 16, 0) / 0.5;
      EXPECT_LE(lum(t2, x, 16), (1 - f) * rho * (1 + std::ldexp(1.0, -22))) << x;
      EXPECT_LT(lum(t2, x, 16), lum(t2_before, x, 16)) << x;
    }
  }
  // Off: no sky level, nothing scaled.
  LabelMap off = labels;
  take_sky_gaps(off, lin, with_fraction(0));
  ImageF same = before;
  EXPECT_EQ(unmix_sky_fringe(same, lin, off, with_fraction(0)), 0u);
  EXPECT_EQ(same.vec(), before.vec());
}

// Frames one pixel wide or high, and a frame whose vegetation is all sky-bright: no reads outside
// the frame (the edges' rows and columns), and the closure takes the whole bright class.
TEST(SkyGaps, ThinFramesAndAWhollyBrightCrown) {
  const ScenePreset p = with_fraction(0.6);
  for (const bool column : {true, false}) {
    const int n = 200;  // 100 sky, then 100 vegetation: the first bright, the next dim, then bright
    ImageF lin(column ? 1 : n, column ? n : 1, 3, 0.f);
    LabelMap l;
    l.ids = ImageU16(lin.width(), lin.height(), 1, kVeg);
    for (int k = 0; k < n; ++k) {
      const uint16_t id = k < 100 ? kSky : kVeg;
      const float v = k < 100 || k == 100 || k > 101 ? 0.5f : 0.01f;
      l.ids[k] = id;
      for (int c = 0; c < 3; ++c) lin[3 * k + c] = v;
    }
    EXPECT_EQ(take_sky_gaps(l, lin, p), 1u) << (column ? "column" : "row");
    EXPECT_EQ(l.sky_gaps, std::vector<uint32_t>{100});
    EXPECT_EQ(l.sky_fringe, std::vector<uint32_t>{101});  // the dim pixel beside it
  }
  {
    ImageF lin(1, 1, 3, 0.5f);
    LabelMap l;
    l.ids = ImageU16(1, 1, 1, kVeg);
    EXPECT_EQ(take_sky_gaps(l, lin, p), 0u);  // no sky
  }
  // 64 sky pixels over a crown as bright as the sky: all of it joins.
  ImageF lin(64, 40, 3, 0.5f);
  LabelMap l;
  l.ids = ImageU16(64, 40, 1, kVeg);
  for (int x = 0; x < 64; ++x) l.ids.at(x, 0) = kSky;
  EXPECT_EQ(take_sky_gaps(l, lin, p), 64u * 39u);
  EXPECT_TRUE(l.sky_fringe.empty());
}
