// What the commands write, below the commands: 8-bit sRGB preview codes by decision levels, PNGs
// through libpng, integer EXR layers written from their integers, and compression names.
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <limits>

#include <fmt/format.h>

#include "photosite/error.h"
#include "photosite/io.h"
#include "photosite/rng.h"
#include "photosite/sensor/isp.h"
#include "test_util.h"

using namespace photosite;
namespace fs = std::filesystem;

// Every code is the one nearest to 255 · srgb_encode(x) evaluated in double, over a sweep of
// about a million floats from 1e-6 to 1.2 and the floats either side of each decision level.
// The only allowed disagreement is where 255 · srgb_encode(x) lies within 1e-9 of a half code
// (double rounding of the reference itself; none occurs in practice).
TEST(Outputs, Srgb8CodesAreTheNearestToTheTransferFunction) {
  auto expect_code = [](float x) {
    const double v = 255.0 * srgb_encode(static_cast<double>(x));
    const double nearest = std::floor(v + 0.5);
    if (std::fabs(v - std::floor(v) - 0.5) < 1e-9) return;
    ASSERT_EQ(srgb_encode8(x), static_cast<int>(nearest)) << "x = " << x;
  };
  const uint32_t lo = std::bit_cast<uint32_t>(1e-6f), hi = std::bit_cast<uint32_t>(1.2f);
  for (uint32_t b = lo; b < hi; b += 97) expect_code(std::bit_cast<float>(b));
  for (int k = 1; k <= 255; ++k) {
    const float t = static_cast<float>(srgb_decode((k - 0.5) / 255.0));
    for (float x = std::nextafter(std::nextafter(t, 0.f), 0.f); x <= std::nextafter(std::nextafter(t, 2.f), 2.f);
         x = std::nextafter(x, 2.f))
      expect_code(x);
  }
  EXPECT_EQ(srgb_encode8(-1.f), 0);
  EXPECT_EQ(srgb_encode8(0.f), 0);
  EXPECT_EQ(srgb_encode8(std::numeric_limits<float>::quiet_NaN()), 0);
  EXPECT_EQ(srgb_encode8(1.f), 255);
  EXPECT_EQ(srgb_encode8(std::numeric_limits<float>::infinity()), 255);
}

// preview_srgb8's vector path (AVX2, eight samples a lane each) gives the scalar codes for every
// float in [2^-15, 2) (the whole table and both ends), the specials, and the per-channel gains
// (rows of pixels whose lengths leave a scalar tail); the per-sample gain is applied in float as
// in srgb_encode8(x · g).
TEST(Outputs, Srgb8VectorPathGivesTheScalarCodes) {
  const float ones[3] = {1.f, 1.f, 1.f};
  constexpr size_t kBlock = 3 << 16;
  std::vector<float> x(kBlock);
  std::vector<uint8_t> vec(kBlock), ref(kBlock);
  const uint32_t lo = std::bit_cast<uint32_t>(0x1p-15f), hi = std::bit_cast<uint32_t>(2.f);
  for (uint32_t b0 = lo; b0 < hi; b0 += kBlock) {
    const size_t n = std::min<size_t>(kBlock, hi - b0) / 3 * 3;
    for (size_t j = 0; j < n; ++j) x[j] = std::bit_cast<float>(static_cast<uint32_t>(b0 + j));
    srgb_encode8_rgb(x.data(), n, ones, vec.data(), true);
    srgb_encode8_rgb(x.data(), n, ones, ref.data(), false);
    for (size_t j = 0; j < n; ++j) ASSERT_EQ(vec[j], ref[j]) << "x = " << x[j];
  }
  const float inf = std::numeric_limits<float>::infinity(), nan = std::numeric_limits<float>::quiet_NaN();
  std::vector<float> specials = {nan, -nan, inf, -inf, -0.f, 0.f, -1.f, 1e-30f, 0x1p-14f, std::nextafter(0x1p-14f, 0.f),
                                 std::nextafter(1.f, 0.f), 1.f, 3e38f, 0.5f, 0.04f, 0.0031308f, 7e-5f, 1e-4f};
  while (specials.size() % 24) specials.push_back(0.25f);
  std::vector<uint8_t> v2(specials.size()), r2(specials.size());
  srgb_encode8_rgb(specials.data(), specials.size(), ones, v2.data(), true);
  for (size_t j = 0; j < specials.size(); ++j) EXPECT_EQ(v2[j], srgb_encode8(specials[j])) << "x = " << specials[j];
  // Gains per channel, 1 to 101 pixels (the tails).
  const float gains[3] = {1.83f, 0.97f, 1.41f};
  for (size_t px = 1; px <= 101; px += 4) {
    std::vector<float> s(3 * px);
    for (size_t j = 0; j < s.size(); ++j) s[j] = static_cast<float>(uniform_open(random_words(3, px, j, Stream::ReadNoise)[0]));
    std::vector<uint8_t> v(s.size());
    srgb_encode8_rgb(s.data(), s.size(), gains, v.data(), true);
    for (size_t j = 0; j < s.size(); ++j) ASSERT_EQ(v[j], srgb_encode8(s[j] * gains[j % 3])) << px << " pixels, sample " << j;
  }
}

// The 8-bit preview is the float preview's codes: the same scale and white balance, each code
// within one of round(255 · preview_srgb) (the float preview rounds x through double, the 8-bit
// one decides on the float x; they differ only at a decision level), and equal for almost all.
TEST(Outputs, Preview8MatchesTheFloatPreview) {
  ImageF rgb(257, 131, 3, uninitialized);
  for (size_t i = 0; i < rgb.size(); ++i) rgb[i] = static_cast<float>(4095.0 * uniform_open(random_words(7, 0, i, Stream::ReadNoise)[0]));
  const std::array<double, 3> wb = {1.8, 1.0, 1.4};
  const ImageF f = preview_srgb(rgb, wb);
  const ImageU8 q = preview_srgb8(rgb, wb);
  ASSERT_EQ(q.size(), f.size());
  size_t differ = 0;
  for (size_t i = 0; i < q.size(); ++i) {
    const int ref = static_cast<int>(std::lround(255.0 * f[i]));
    ASSERT_LE(std::abs(q[i] - ref), 1) << i;
    differ += q[i] != ref;
  }
  // A code differs only when x lies within float rounding (2^-24 relative) of a level: with
  // 255 levels over [0, 1] far below one sample in 1e4.
  EXPECT_LE(differ, q.size() / 10000 + 1);
}

// libpng's PNGs read back to the same codes (grey, RGB), carry no time chunk, and two
// writes give the same bytes.
TEST(Outputs, Png8RoundTripsWithTheSameBytes) {
  test::TempDir dir;
  for (int ch : {1, 3}) {
    ImageU8 img(61, 29, ch, uninitialized);
    for (size_t i = 0; i < img.size(); ++i) img[i] = static_cast<uint8_t>(random_words(3, static_cast<uint32_t>(ch), i, Stream::ReadNoise)[0] & 0xff);
    const std::string a = dir.file(fmt::format("a{}.png", ch)), b = dir.file(fmt::format("b{}.png", ch));
    write_png8(a, img);
    write_png8(b, img);
    const ImageU16 back = read_image_u16(a);
    ASSERT_EQ(back.channels(), ch);
    ASSERT_EQ(back.size(), img.size());
    for (size_t i = 0; i < img.size(); ++i) ASSERT_EQ(back[i], img[i]) << ch << " " << i;
    std::ifstream fa(a, std::ios::binary), fb(b, std::ios::binary);
    const std::string ba((std::istreambuf_iterator<char>(fa)), {}), bb((std::istreambuf_iterator<char>(fb)), {});
    EXPECT_EQ(ba, bb);
    EXPECT_EQ(ba.find("tIME"), std::string::npos);
  }
  // A folder that cannot be written: bad input naming the file, no temporary left.
  EXPECT_THROW(write_png8(dir.file("nope/x.png"), ImageU8(4, 4, 3)), Error);
}

// 16-bit class ids go to a UINT channel as they are (no float in between), beside float and
// half layers; an unknown compression is refused naming it.
TEST(Outputs, IntegerLayersFromTheirIntegersAndCompressionNames) {
  test::TempDir dir;
  ImageU16 ids(67, 33, 1, uninitialized);
  for (size_t i = 0; i < ids.size(); ++i) ids[i] = static_cast<uint16_t>(i * 977 % 65536);
  ImageF depth(67, 33, 1, 0.25f);
  for (const auto& codec : exr_compressions()) {
    const std::string path = dir.file(codec + ".exr");
    ExrWriteOptions wo;
    wo.compression = codec;
    write_exr(path, {{{"depth.Z"}, &depth, "", ExrPixel::Half}, {{"labels.Y"}, nullptr, "label_id", ExrPixel::Uint, &ids}},
              {}, wo);
    const ExrContents c = read_exr(path);
    EXPECT_EQ(c.pixel_types.at("labels.Y"), ExrPixel::Uint) << codec;
    EXPECT_EQ(c.pixel_types.at("depth.Z"), ExrPixel::Half) << codec;
    EXPECT_EQ(c.attributes.at("compression"), codec);
    const ImageF& l = c.channels.at("labels.Y");
    for (size_t i = 0; i < ids.size(); ++i) ASSERT_EQ(l[i], static_cast<float>(ids[i])) << codec << " " << i;
  }
  ExrWriteOptions bad;
  bad.compression = "zip9";
  try {
    write_exr(dir.file("bad.exr"), {{{"labels.Y"}, nullptr, "", ExrPixel::Uint, &ids}}, {}, bad);
    ADD_FAILURE() << "zip9 accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("zip9"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(dir.file("bad.exr")));
}
