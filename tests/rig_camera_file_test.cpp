// Cityscapes' per-image camera files (camera/<split>/<city>/<stem>_camera.json) as camera rigs:
// parsing, finding them beside an image of the data set's layout, and batch using each image's
// own calibration (scene/rig_json.cpp).
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>

#include <fmt/format.h>

#include "photosite/backend.h"
#include "photosite/batch.h"
#include "photosite/error.h"
#include "photosite/io.h"
#include "photosite/scene/night.h"
#include "photosite/scene/rig.h"
#include "photosite/sensor/isp.h"
#include "photosite/sensor/preset.h"
#include "test_util.h"

using namespace photosite;
namespace fs = std::filesystem;
using test::error_of;

namespace {
// The layout and keys of a Cityscapes camera file, with the values of the aachen camera that the
// bundled presets/rigs/cityscapes.toml also holds; height and pitch as given.
std::string camera_json(double z_m, double pitch_rad) {
  return fmt::format(R"({{
    "extrinsic": {{"baseline": 0.209313, "pitch": {}, "roll": 0.0, "x": 1.7, "y": 0.1, "yaw": -0.0195, "z": {}}},
    "intrinsic": {{"fx": 2262.52, "fy": 2265.3017905988554, "u0": 1096.98, "v0": 513.137}}
}})",
                     pitch_rad, z_m);
}

void write_text(const fs::path& p, const std::string& text) {
  fs::create_directories(p.parent_path());
  std::ofstream(p) << text;
}


// One synthetic road frame in the Cityscapes layout (2:1, the leftImg8bit aspect ratio, so the
// intrinsics scale by width/2048), with or without its camera file.
void make_cityscapes(const fs::path& root, const std::string* camera) {
  const fs::path img = root / "leftImg8bit/val/testcity/testcity_000000_000019_leftImg8bit.png";
  const fs::path lab = root / "gtFine/val/testcity/testcity_000000_000019_gtFine_labelIds.png";
  fs::create_directories(img.parent_path());
  fs::create_directories(lab.parent_path());
  scene::SyntheticOptions o;
  o.width = 256;
  o.height = 128;
  o.vp_x = 128;
  o.vp_y = 60;
  const auto s = scene::make_synthetic_road(o);
  ImageF srgb = s.day_linear_srgb;
  for (auto& v : srgb.vec()) v = static_cast<float>(srgb_encode(v));
  write_png(img.string(), srgb);
  ImageF ids(o.width, o.height, 1);
  for (size_t k = 0; k < ids.size(); ++k) ids[k] = s.labels.ids[k] / 255.0f;
  write_png(lab.string(), ids);
  if (camera) write_text(root / "camera/val/testcity/testcity_000000_000019_camera.json", *camera);
}
}  // namespace

TEST(RigCameraFile, ParsesTheCityscapesKeysAndUnits) {
  const auto r = scene::parse_cityscapes_camera(camera_json(1.22, 0.038), "aachen_camera.json");
  EXPECT_EQ(r.native_width_px, 2048);
  EXPECT_EQ(r.native_height_px, 1024);
  EXPECT_EQ(r.fx_px, 2262.52);
  EXPECT_EQ(r.cx_px, 1096.98);
  EXPECT_EQ(r.cy_px, 513.137);
  EXPECT_EQ(r.mount_height_m, 1.22);
  EXPECT_DOUBLE_EQ(r.pitch_deg, 0.038 * 180 / std::numbers::pi);  // radians in the file
  EXPECT_EQ(r.name, "aachen_camera");
  // The bundled Cityscapes rig holds the same camera: the file and the preset agree.
  const auto preset = scene::load_camera_rig("cityscapes");
  EXPECT_EQ(preset.fx_px, r.fx_px);
  EXPECT_EQ(preset.mount_height_m, r.mount_height_m);
  EXPECT_NEAR(preset.pitch_deg, r.pitch_deg, 0.005);  // the preset rounds to 0.01 deg
}

TEST(RigCameraFile, BadFilesNameTheFileAndTheKey) {
  const std::string f = "x_camera.json";
  EXPECT_NE(error_of([&] { scene::parse_cityscapes_camera("{not json", f); }).find("x_camera.json: not a JSON object"),
            std::string::npos);
  EXPECT_NE(error_of([&] { scene::parse_cityscapes_camera(R"({"intrinsic": {"fx": 1, "u0": 1, "v0": 1}})", f); })
                .find("no \"extrinsic\" object"),
            std::string::npos);
  std::string no_z = camera_json(1.22, 0.038);
  no_z.replace(no_z.find("\"z\""), 3, "\"q\"");
  EXPECT_NE(error_of([&] { scene::parse_cityscapes_camera(no_z, f); }).find("extrinsic.z: missing"), std::string::npos);
  EXPECT_NE(error_of([&] { scene::parse_cityscapes_camera(camera_json(0.01, 0.038), f); }).find("extrinsic.z: 0.01 m is outside"),
            std::string::npos);
  EXPECT_NE(error_of([&] { scene::parse_cityscapes_camera(camera_json(1.2, 1.0), f); }).find("extrinsic.pitch"),
            std::string::npos);
  EXPECT_NE(error_of([&] { scene::load_camera_rig("/nonexistent/y_camera.json"); }).find("cannot read camera file"),
            std::string::npos);
}

TEST(RigCameraFile, FoundBesideTheImageAndUsedByAutoOnly) {
  test::TempDir dir;
  const std::string cam = camera_json(2.44, 0.02);
  make_cityscapes(dir.path() / "cs", &cam);
  const std::string img = dir.file("cs/leftImg8bit/val/testcity/testcity_000000_000019_leftImg8bit.png");
  const std::string want = dir.file("cs/camera/val/testcity/testcity_000000_000019_camera.json");
  EXPECT_EQ(scene::cityscapes_camera_file(img), want);
  EXPECT_EQ(scene::resolve_camera_rig("auto", 256, 128, img).mount_height_m, 2.44);
  EXPECT_EQ(scene::resolve_camera_rig("cityscapes", 256, 128, img).mount_height_m, 1.22);  // explicit wins
  EXPECT_EQ(scene::resolve_camera_rig(want, 256, 128).mount_height_m, 2.44);               // the file itself
  // Not in the layout, or no file: nothing found, auto falls back to the aspect ratio.
  EXPECT_EQ(scene::cityscapes_camera_file(dir.file("elsewhere/testcity_000000_000019_leftImg8bit.png")), "");
  EXPECT_EQ(scene::cityscapes_camera_file(""), "");
  fs::remove(want);
  EXPECT_EQ(scene::cityscapes_camera_file(img), "");
  EXPECT_EQ(scene::resolve_camera_rig("auto", 256, 128, img).name, "cityscapes");
}

// batch over the Cityscapes layout uses each image's own camera file: with a camera mounted twice
// as high (and the same pitch and intrinsics), flat-ground depth Z = f·h/(y − y_h) and the
// vehicles' contact depths double (façade planes are fitted with thresholds in metres, so
// buildings are not compared). Doubling is exact in binary floating point and survives the
// half-float depth layer exactly (a power-of-two scale of a normal half), so the bound below is
// one half ulp of the larger value, 2^-11 relative, for rounding differences upstream of the
// layer (none expected).
TEST(RigCameraFile, BatchUsesEachImagesOwnCameraFile) {
  test::TempDir dir;
  const std::string cam = camera_json(2.44, 0.038);  // the bundled rig's values with h doubled
  make_cityscapes(dir.path() / "cs", &cam);
  const std::string root = dir.file("cs");
  const auto items = batch::discover(batch::Dataset::Cityscapes, root);
  ASSERT_EQ(items.size(), 1u);
  EXPECT_EQ(items[0].camera, dir.file("cs/camera/val/testcity/testcity_000000_000019_camera.json"));
  auto options = [&](const std::string& out, bool item_cameras) {
    batch::Options o;
    o.out = dir.file(out);
    o.root = root;
    o.source = "cityscapes " + root;
    o.format = "exr";
    o.sensor.camera = load_camera_preset("onsemi-ar0331");
    o.sensor.lens = load_lens_preset(o.sensor.camera.default_lens);
    o.sensor.device_id = o.sensor.camera.name + "-0";
    o.device_store = dir.file("store");
    o.scene = scene::load_scene_preset("night-urban");
    o.scene.rig = scene::load_camera_rig("cityscapes");  // as `batch --dataset cityscapes`
    o.item_cameras = item_cameras;
    return o;
  };
  SensorRunner cpu(Backend::Cpu);
  ASSERT_TRUE(batch::run(items, options("own", true), cpu).errors.empty());
  ASSERT_TRUE(batch::run(items, options("rig", false), cpu).errors.empty());
  const std::string rel = "leftImg8bit/val/testcity/testcity_000000_000019_leftImg8bit.exr";
  const ExrContents own = read_exr(dir.file("own/" + rel)), rig = read_exr(dir.file("rig/" + rel));
  EXPECT_EQ(own.attributes.at("photosite/night/camera_rig"), "testcity_000000_000019_camera");
  EXPECT_EQ(rig.attributes.at("photosite/night/camera_rig"), "cityscapes");
  const ImageF& d2 = own.channels.at("depth.Z");
  const ImageF& d1 = rig.channels.at("depth.Z");
  ASSERT_EQ(d1.size(), d2.size());
  const float cap_m = static_cast<float>(scene::load_scene_preset("night-urban").max_depth_m);
  size_t finite = 0;
  const ImageF& ids = rig.channels.at("labels.Y");
  for (size_t i = 0; i < d1.size(); ++i) {
    const int id = static_cast<int>(ids[i]);
    if (!scene::is_ground(id) && !scene::is_vehicle(id) && id != static_cast<int>(scene::Label::Sky)) continue;
    if (d1[i] >= 65504.0f) {  // sky: infinite in both
      EXPECT_GE(d2[i], 65504.0f) << i;
      continue;
    }
    if (2 * d1[i] >= cap_m) continue;  // doubled past the preset's depth cap
    ++finite;
    EXPECT_NEAR(d2[i], 2 * d1[i], 2 * d1[i] * 0x1p-11f) << i;
  }
  EXPECT_GT(finite, d1.size() / 4);  // road, sidewalks and cars
}
