// The --maps pictures as a library call (include/photosite/visualize.h).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <set>

#include "photosite/error.h"
#include "photosite/io.h"
#include "photosite/scene/night.h"
#include "photosite/scene/scene_preset.h"
#include "photosite/sensor/spectrum.h"
#include "photosite/visualize.h"
#include "test_util.h"

using namespace photosite;
namespace fs = std::filesystem;

TEST(Visualize, LogLuminanceMapsSixDecadesOntoTheUnitInterval) {
  ImageF rad(3, 1, 3);
  const double lum[3] = {1e-3, 1.0, 1e3};  // the ends and the middle of the scale
  for (int i = 0; i < 3; ++i) {
    const auto v = spectrum::blackbody_rgb(4000, lum[i]);
    for (int k = 0; k < 3; ++k) rad.at(i, 0, k) = static_cast<float>(v[k]);
  }
  const ImageF p = log_luminance_picture(rad);
  // (log10 L + 3) / 6, from radiance rounded to float (relative 2^-24 per channel, so log10 moves
  // by at most 2^-24 / ln 10 / 6 < 1e-8 on the picture's scale).
  EXPECT_NEAR(p[0], 0.0, 1e-7);
  EXPECT_NEAR(p[1], 0.5, 1e-7);
  EXPECT_NEAR(p[2], 1.0, 1e-7);
}

TEST(Visualize, NightMapsAreCompleteAndRefusalWritesNothing) {
  scene::SyntheticOptions so;
  so.width = 256;
  so.height = 128;
  const auto road = scene::make_synthetic_road(so);
  const auto sp = scene::load_scene_preset("night-urban");
  const scene::NightScene ns = scene::night_scene(road.day_linear_srgb, road.labels, sp, 1, true);
  const auto pics = night_map_pictures(road.day_linear_srgb, road.labels, ns);
  std::set<std::string> names;
  for (const auto& p : pics) {
    names.insert(p.file);
    for (float v : p.image.vec()) ASSERT_TRUE(v >= 0.f && v <= 1.f) << p.file << " " << v;
  }
  const std::set<std::string> want = {"lanes.png", "edges.png", "lines_vp.png", "depth.png",
                                      "lights_log.png", "darkened_log.png", "night_radiance_log.png",
                                      "labels.png", "day.png"};
  EXPECT_EQ(names, want);
  for (const auto& p : pics)
    if (p.file == "day.png" || p.file == "labels.png" || p.file == "night_radiance_log.png") {
      EXPECT_EQ(p.image.width(), 256) << p.file;
      EXPECT_EQ(p.image.height(), 128) << p.file;
    }

  test::TempDir dir;
  write_pictures(dir.path().string(), pics, false);
  for (const auto& n : want) EXPECT_TRUE(fs::exists(dir.file(n))) << n;
  // A second set into the same folder: refused before anything is written.
  test::TempDir dir2;
  { std::ofstream(dir2.file("labels.png")) << "mine"; }
  EXPECT_THROW(write_pictures(dir2.path().string(), pics, false), Error);
  for (const auto& n : want)
    if (n != "labels.png") EXPECT_FALSE(fs::exists(dir2.file(n))) << n;
  std::ifstream kept(dir2.file("labels.png"));
  std::string content;
  kept >> content;
  EXPECT_EQ(content, "mine");
  EXPECT_THROW(write_pictures(dir.file("nope"), pics, false), Error);
}
