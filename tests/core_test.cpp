#include <gtest/gtest.h>
#include <Imath/half.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fmt/format.h>
#include <unistd.h>
#include <fstream>

#include "photosite/error.h"
#include "photosite/io.h"
#include "photosite/night_chain.h"
#include "photosite/rng.h"
#include "photosite/sensor/cfa.h"
#include "photosite/sensor/demosaic.h"
#include "test_util.h"

using namespace photosite;

// Known-answer vectors from Random123's kat_vectors (philox4x32, 10 rounds).
TEST(Philox, KnownAnswers) {
  auto a = Philox4x32::generate({0, 0, 0, 0}, {0, 0});
  EXPECT_EQ(a[0], 0x6627e8d5u);
  EXPECT_EQ(a[1], 0xe169c58du);
  EXPECT_EQ(a[2], 0xbc57ac4cu);
  EXPECT_EQ(a[3], 0x9b00dbd8u);
  auto b = Philox4x32::generate({0xffffffffu, 0xffffffffu, 0xffffffffu, 0xffffffffu},
                                {0xffffffffu, 0xffffffffu});
  EXPECT_EQ(b[0], 0x408f276du);
  EXPECT_EQ(b[1], 0x41c83b0eu);
  EXPECT_EQ(b[2], 0xa20bc7c6u);
  EXPECT_EQ(b[3], 0x6d5451fdu);
  auto c = Philox4x32::generate({0x243f6a88u, 0x85a308d3u, 0x13198a2eu, 0x03707344u},
                                {0xa4093822u, 0x299f31d0u});
  EXPECT_EQ(c[0], 0xd16cfe09u);
  EXPECT_EQ(c[1], 0x94fdccebu);
  EXPECT_EQ(c[2], 0x5001e420u);
  EXPECT_EQ(c[3], 0x24126ea1u);
}

TEST(Philox, DeviceIdSeedIsStableAndDistinct) {
  EXPECT_EQ(seed_from_device_id("cam0"), seed_from_device_id("cam0"));
  EXPECT_NE(seed_from_device_id("cam0"), seed_from_device_id("cam1"));
}

TEST(Cfa, PatternsAndColours) {
  EXPECT_EQ(cfa_color(CfaPattern::RGGB, 0, 0), FilterColor::R);
  EXPECT_EQ(cfa_color(CfaPattern::RGGB, 1, 1), FilterColor::B);
  EXPECT_EQ(cfa_color(CfaPattern::GBRG, 0, 1), FilterColor::R);
  EXPECT_EQ(cfa_color(CfaPattern::GRBG, 1, 0), FilterColor::R);
  EXPECT_EQ(cfa_color(CfaPattern::BGGR, 0, 0), FilterColor::B);
  EXPECT_EQ(cfa_color(CfaPattern::RCCB, 1, 0), FilterColor::C);
  EXPECT_EQ(cfa_colors(CfaPattern::RCCC).size(), 2u);
  EXPECT_EQ(parse_cfa("rccb"), CfaPattern::RCCB);
  EXPECT_THROW(parse_cfa("RGBW"), Error);
}

TEST(Demosaic, BilinearRecoversFlatColourOnEveryPattern) {
  for (auto p : all_cfa_patterns()) {
    if (p == CfaPattern::Mono) continue;
    ImageF rgb(17, 11, 3);
    for (size_t i = 0; i < rgb.pixel_count(); ++i) {
      rgb[3 * i] = 0.3f;
      rgb[3 * i + 1] = 0.5f;
      rgb[3 * i + 2] = 0.2f;
    }
    const ImageF mos = mosaic(rgb, p);
    ImageF out = demosaic_bilinear(mos, p);
    float expect[3] = {0.3f, 0.5f, 0.2f};
    if (p == CfaPattern::RCCC) expect[1] = expect[2] = 0.35f;  // (C - R) / 2
    // The flat-area rounding bound of tests/demosaic_test.cpp (AllMethodsRecoverFlatAreasToRounding,
    // derived there; bilinear is one of the methods it covers): 48·u·max x, u = 2⁻²⁴, max x the
    // largest mosaic sample, and for RCCB's G = (C − R̂) − B̂ three interpolated terms and the clear
    // level's roundings, (3·48 + 3.5)·u·max x. (The expected values are the representable ones of
    // that test: float 0.3, 0.5, 0.2, and RCCC's 0.35f.)
    const double max_x = *std::max_element(mos.vec().begin(), mos.vec().end());
    const double tol = (p == CfaPattern::RCCB ? 3 * 48 + 3.5 : 48.0) * 0x1p-24 * max_x;
    for (size_t i = 0; i < out.pixel_count(); ++i)
      for (int c = 0; c < 3; ++c) ASSERT_NEAR(out[3 * i + c], expect[c], tol) << to_string(p);
  }
}

TEST(Io, FramePathPadsTheHashRun) {
  EXPECT_EQ(frame_path("out_###.exr", 7), "out_007.exr");
  EXPECT_EQ(frame_path("out.exr", 7), "out.exr");
  EXPECT_EQ(frame_path("a#b", 12), "a12b");
}

TEST(Io, ExrRoundTripKeepsChannelsUnitsAndAttributes) {
  test::TempDir dir;
  ImageF raw(5, 4, 1), rgb(5, 4, 3);
  for (size_t i = 0; i < raw.size(); ++i) raw[i] = static_cast<float>(i);
  for (size_t i = 0; i < rgb.size(); ++i) rgb[i] = 0.25f * static_cast<float>(i);
  std::string path = dir.file("x.exr");
  write_exr(path, {{{"raw.Y"}, &raw, "DN"}, {{"R", "G", "B"}, &rgb, "e-"}},
            {{"photosite/preset", std::string("test")}, {"photosite/frame", 3}});
  auto c = read_exr(path);
  ASSERT_EQ(c.channels.count("raw.Y"), 1u);
  EXPECT_EQ(c.channels.at("raw.Y").at(2, 1), raw.at(2, 1));
  EXPECT_EQ(c.channels.at("G").at(4, 3), rgb.at(4, 3, 1));
  EXPECT_EQ(c.channels.at("raw.Y").unit(), "DN");
  EXPECT_EQ(c.attributes.at("photosite/preset"), "test");
  EXPECT_EQ(c.attributes.at("photosite/frame"), "3");
}

TEST(Io, ExrTypedChannelsRoundTripExactly) {
  // UINT channels hold the integers exactly (up to 2^24, where read_exr's float is still exact),
  // half channels round to half, float channels are untouched; each channel's type reads back.
  test::TempDir dir;
  ImageF ids(7, 5, 1), dn(7, 5, 1), depth(7, 5, 1), rad(7, 5, 3);
  for (size_t i = 0; i < ids.size(); ++i) {
    ids[i] = static_cast<float>(i * 97 % 34);
    dn[i] = static_cast<float>((1u << 24) - i * 1021);
    depth[i] = static_cast<float>(i) / 34.f;
  }
  for (size_t i = 0; i < rad.size(); ++i) rad[i] = 1e-7f * static_cast<float>(i + 1) / 3.f;
  const std::string path = dir.file("typed.exr");
  write_exr(path, {{{"raw.Y"}, &dn, "DN", ExrPixel::Uint}, {{"R", "G", "B"}, &rad, "x"},
                   {{"depth.Z"}, &depth, "", ExrPixel::Half}, {{"labels.Y"}, &ids, "", ExrPixel::Uint}},
            {});
  const auto c = read_exr(path);
  EXPECT_EQ(c.pixel_types.at("raw.Y"), ExrPixel::Uint);
  EXPECT_EQ(c.pixel_types.at("labels.Y"), ExrPixel::Uint);
  EXPECT_EQ(c.pixel_types.at("depth.Z"), ExrPixel::Half);
  EXPECT_EQ(c.pixel_types.at("G"), ExrPixel::Float);
  EXPECT_EQ(c.channels.at("raw.Y").vec(), dn.vec());
  EXPECT_EQ(c.channels.at("labels.Y").vec(), ids.vec());
  for (size_t i = 0; i < depth.size(); ++i) {
    EXPECT_EQ(c.channels.at("depth.Z")[i], static_cast<float>(half(depth[i]))) << i;
    // half keeps 11 significant bits: relative error at most 2^-11 for these normal values.
    EXPECT_LE(std::abs(c.channels.at("depth.Z")[i] - depth[i]), depth[i] * 0x1p-11f) << i;
  }
  for (size_t p = 0; p < rad.pixel_count(); ++p) EXPECT_EQ(c.channels.at("B")[p], rad.at(p % 7, p / 7, 2));
  // A UINT channel refuses what is not a non-negative integer, and leaves no file behind.
  ImageF frac(7, 5, 1, 0.5f);
  EXPECT_ANY_THROW(write_exr(dir.file("bad.exr"), {{{"raw.Y"}, &frac, "DN", ExrPixel::Uint}}, {}));
  EXPECT_FALSE(std::filesystem::exists(dir.file("bad.exr")));
}

TEST(Io, OneRowAndOneColumnImagesAreImagesButNoSensorFrames) {
  // An image of one row or one column (a line profile, a 1-D table) is a valid image: written and
  // read back as it is, by EXR and by PNG. Only where it becomes the sensor's frame (the day photo
  // of night and batch) is it refused, naming the file: a frame holds at least one 2x2 CFA tile.
  test::TempDir dir;
  for (const auto& [w, h] : {std::pair{5, 1}, std::pair{1, 4}, std::pair{1, 1}}) {
    ImageF a(w, h, 3);
    for (size_t i = 0; i < a.size(); ++i) a[i] = 0.125f * static_cast<float>(i);
    const std::string exr = dir.file(fmt::format("line_{}x{}.exr", w, h));
    write_exr(exr, {{{"R", "G", "B"}, &a, "x"}}, {});
    const ExrContents c = read_exr(exr);
    ASSERT_EQ(c.width, w);
    ASSERT_EQ(c.height, h);
    for (size_t p = 0; p < a.pixel_count(); ++p) EXPECT_EQ(c.channels.at("B")[p], a[3 * p + 2]) << p;
    ImageF codes(w, h, 3);
    for (size_t i = 0; i < codes.size(); ++i) codes[i] = static_cast<float>(i % 256) * (1.f / 255);  // read_image's codes
    const std::string png = dir.file(fmt::format("line_{}x{}.png", w, h));
    write_png(png, codes, 8);
    const ImageF back = read_image(png);
    ASSERT_EQ(back.width(), w);
    ASSERT_EQ(back.height(), h);
    EXPECT_EQ(back.vec(), codes.vec());
    try {
      read_day_image(png, nullptr);
      ADD_FAILURE() << png << " taken as a day photo";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(png), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("too small"), std::string::npos) << e.what();
    }
  }
}

TEST(Io, RefusesToOverwriteAndMissingFolders) {
  test::TempDir dir;
  ImageF raw(2, 2, 1);
  std::string path = dir.file("y.exr");
  write_exr(path, {{{"Y"}, &raw, ""}}, {});
  EXPECT_THROW(check_output_path(path, false), Error);
  EXPECT_NO_THROW(check_output_path(path, true));
  EXPECT_THROW(check_output_path(dir.file("nope/z.exr"), false), Error);
  EXPECT_THROW(read_image(dir.file("missing.png")), Error);
}

// A temporary's name is predictable ('.<stem>.tmp-<scope>-<pid>-<n><ext>'), so in a folder others
// can write to (a shared device store or output folder) a symbolic link may wait under the next
// names. The write must neither go through it (the link's target is a file of the user's) nor
// publish it: the temporary is created exclusively and written through its descriptor.
TEST(Io, TemporaryNeverWritesThroughAPlantedLink) {
  namespace fs = std::filesystem;
  test::TempDir dir;
  const std::string victim = dir.file("victim.txt");
  std::ofstream(victim) << "precious";
  auto text = [](const std::string& p) {
    std::ifstream f(p);
    return std::string(std::istreambuf_iterator<char>(f), {});
  };
  // This process's next temporary number, from a probe write's temporary (the only file named so).
  auto next_number = [&](const std::string& stem) {
    long n = -1;
    atomic_write(dir.file(stem + ".exr"), [&](const std::string& via) {
      for (const auto& e : fs::directory_iterator(dir.path())) {
        const std::string name = e.path().filename().string();
        const std::string head = fmt::format(".{}.tmp-{}-{}-", stem, temporary_pid_scope(), getpid());
        if (name.rfind(head, 0) == 0) n = std::stol(name.substr(head.size()));
      }
      std::ofstream(via) << "probe";
    });
    return n + 1;
  };
  for (bool replace : {true, false}) {
    SCOPED_TRACE(replace ? "atomic_write" : "atomic_create");
    const std::string stem = replace ? "x" : "y";
    const long n = next_number(stem + "probe");
    ASSERT_GT(n, 0);
    for (long k = n; k < n + 20; ++k)
      fs::create_symlink(victim, dir.file(fmt::format(".{}.tmp-{}-{}-{}.exr", stem, temporary_pid_scope(), getpid(), k)));
    auto write = [](const std::string& via) { std::ofstream(via) << "payload"; };
    if (replace) atomic_write(dir.file(stem + ".exr"), write);
    else EXPECT_TRUE(atomic_create(dir.file(stem + ".exr"), write));
    EXPECT_EQ(text(victim), "precious");
    EXPECT_FALSE(fs::is_symlink(dir.file(stem + ".exr")));
    EXPECT_EQ(text(dir.file(stem + ".exr")), "payload");
    // The planted links are someone else's: left as they were.
    EXPECT_TRUE(fs::is_symlink(dir.file(fmt::format(".{}.tmp-{}-{}-{}.exr", stem, temporary_pid_scope(), getpid(), n))));
  }
}
