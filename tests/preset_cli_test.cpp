// Presets (schema, errors with file, line and key) and the sensor commands' contracts.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "photosite/checksum.h"
#include "photosite/error.h"
#include "photosite/io.h"
#include "photosite/scene/rig.h"
#include "photosite/scene/scene_preset.h"
#include "photosite/sensor/preset.h"
#include "test_util.h"

using namespace photosite;
namespace fs = std::filesystem;

namespace {
std::string base_camera_toml() {
  std::ifstream f(std::string(PHOTOSITE_PRESET_DIR) + "/cameras/sony-imx174.toml");
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}
std::string error_of(const std::string& text) {
  try {
    parse_camera_preset(text, "cam.toml");
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}
std::string replace_line(std::string text, const std::string& key, const std::string& line) {
  auto p = text.find("\n" + key + " ");
  auto e = text.find('\n', p + 1);
  return text.substr(0, p + 1) + line + text.substr(e);
}
}  // namespace

TEST(Presets, AllBundledPresetsLoad) {
  std::map<std::string, int> count;
  for (const auto& e : list_presets()) {
    ++count[e.kind];
    if (e.kind == "camera") {
      auto p = load_camera_preset(e.name);
      EXPECT_FALSE(p.default_lens.empty()) << e.name;
      EXPECT_NO_THROW(load_lens_preset(p.default_lens)) << e.name;
    } else if (e.kind == "lens") {
      load_lens_preset(e.name);
    } else if (e.kind == "scene") {
      scene::load_scene_preset(e.name);
    } else {
      EXPECT_EQ(e.kind, "rig") << e.name;
      scene::load_camera_rig(e.name);
    }
    EXPECT_FALSE(e.description.empty()) << e.name;
  }
  EXPECT_GE(count["camera"], 4);
  EXPECT_GE(count["lens"], 2);
  EXPECT_EQ(count["scene"], 2);  // night-urban, night-rural
  EXPECT_EQ(count["rig"], 2);    // cityscapes, kitti
}

// The device map keeps each pixel's dark rate as a factor of the mean rate, so hot pixels without
// a mean dark current would vanish silently: such a preset is refused, naming the key.
TEST(Presets, HotPixelsNeedAMeanDarkCurrent) {
  const std::string t = replace_line(base_camera_toml(), "dark_current_e_per_s",
                                    "dark_current_e_per_s = 0\nhot_pixel_fraction = 0.01\nhot_pixel_dark_current_e_per_s = 50");
  const std::string msg = error_of(t);
  EXPECT_NE(msg.find("cam.toml: dark_current_e_per_s: hot pixels"), std::string::npos) << msg;
  EXPECT_EQ(error_of(replace_line(t, "dark_current_e_per_s", "dark_current_e_per_s = 0.1")), "");
  EXPECT_EQ(error_of(replace_line(t, "hot_pixel_fraction", "hot_pixel_fraction = 0")), "");
}

TEST(Presets, UnknownKeyNamesFileLineAndKey) {
  std::string t = base_camera_toml() + "\nfull_wel_e = 5\n";
  const std::string msg = error_of(t);
  EXPECT_NE(msg.find("cam.toml:"), std::string::npos) << msg;
  EXPECT_NE(msg.find("full_wel_e: unknown key"), std::string::npos) << msg;
  const int line = static_cast<int>(std::count(t.begin(), t.end(), '\n'));
  EXPECT_NE(msg.find(":" + std::to_string(line) + ":"), std::string::npos) << msg;
}

TEST(Presets, UnknownKeyInsideQeTable) {
  const std::string msg = error_of(base_camera_toml() + "x = [0.1]\n");
  EXPECT_NE(msg.find("qe.x"), std::string::npos) << msg;
}

TEST(Presets, OutOfRangeMissingAndMalformed) {
  const std::string base = base_camera_toml();
  EXPECT_NE(error_of(replace_line(base, "prnu_percent", "prnu_percent = -1")).find("prnu_percent"),
            std::string::npos);
  EXPECT_NE(error_of(replace_line(base, "bit_depth", "bit_depth = 12.5")).find("bit_depth"),
            std::string::npos);
  EXPECT_NE(error_of(replace_line(base, "read_noise_e", "read_noise_e = \"6 e-\"")).find("expected a number"),
            std::string::npos);
  EXPECT_NE(error_of(replace_line(base, "full_well_e", "full_well_e = 5")).find("full well"),
            std::string::npos);
  EXPECT_NE(error_of(replace_line(base, "read_noise_e", "# removed")).find("read_noise_e: required"),
            std::string::npos);
  EXPECT_NE(error_of(replace_line(base, "cfa", "cfa = \"RGBW\"")).find("cfa"), std::string::npos);
  EXPECT_NE(error_of(base + "\n[[broken").find("malformed TOML"), std::string::npos);
  // QE above 1 is impossible.
  std::string qe = base;
  auto p = qe.find("\ng = [");
  qe.insert(p + 6, "1.5, ");
  EXPECT_NE(error_of(qe).find("outside [0, 1]"), std::string::npos) << error_of(qe);
}

TEST(Presets, UnknownPresetNameListsTheBundledOnes) {
  try {
    load_camera_preset("no-such-camera");
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("sony-imx174"), std::string::npos) << e.what();
  }
}

TEST(Cli, PresetsListAndShowJson) {
  auto r = test::run_cli("presets list");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(r.output.rfind("onsemi-ar0132at-rccc\t", 0), 0u) << r.output;
  EXPECT_NE(r.output.find("\nsony-icx267-flea2\t"), std::string::npos);
  r = test::run_cli("presets show onsemi-ar0331 --json");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  auto j = nlohmann::json::parse(r.output);
  for (const char* k : {"name", "cfa", "bit_depth", "pixel_pitch_um", "full_well_e", "system_gain_dn_per_e",
                        "read_noise_e", "dark_current_e_per_s", "dsnu_e", "dark_current_nonuniformity_percent",
                        "prnu_percent", "black_level_dn", "temperature_c", "qe"})
    EXPECT_TRUE(j.contains(k)) << k;
  EXPECT_TRUE(j["qe"].contains("wavelength_nm"));
  EXPECT_TRUE(j["qe"].contains("g"));
  EXPECT_EQ(j["qe"]["g"].size(), j["qe"]["wavelength_nm"].size());
  EXPECT_EQ(test::run_cli("presets show nope --json").exit_code, 2);

  // Scenes and camera rigs too (`presets list` names their kind; `show` by name or by path).
  r = test::run_cli("presets list");
  EXPECT_NE(r.output.find("\nnight-urban\tscene\t"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("\nkitti\trig\t"), std::string::npos) << r.output;
  r = test::run_cli("presets show night-rural --json");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  j = nlohmann::json::parse(r.output);
  EXPECT_EQ(j["name"], "night-rural");
  EXPECT_EQ(j["reflectance"]["sign"], scene::load_scene_preset("night-rural").rho_sign);
  EXPECT_TRUE(j.contains("street") && j.contains("ego_beam")) << r.output;
  r = test::run_cli("presets show '" + std::string(PHOTOSITE_PRESET_DIR) + "/rigs/kitti.toml' --json");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  j = nlohmann::json::parse(r.output);
  EXPECT_EQ(j["native_width_px"], scene::load_camera_rig("kitti").native_width_px);
  r = test::run_cli("presets show '" + std::string(PHOTOSITE_PRESET_DIR) + "/scenes/night-urban.toml' --json");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(nlohmann::json::parse(r.output)["name"], "night-urban");
  r = test::run_cli("presets show nope");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("night-urban"), std::string::npos) << r.output;  // the error lists every kind
  EXPECT_NE(r.output.find("cityscapes"), std::string::npos) << r.output;
}

// The header names a preset by its file stem, so an edited copy of a bundled preset looks the
// same by name: the XXH3-64 of each preset file's text tells them apart.
TEST(Cli, OutputsRecordThePresetFilesChecksums) {
  test::TempDir dir;
  const std::string store = "--device-store '" + dir.file("store") + "'";
  auto r = test::run_cli("chart --out '" + dir.file("scene.exr") + "' --width 64 --height 48");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const std::string bundled = (fs::path(PHOTOSITE_PRESET_DIR) / "cameras/sony-imx490.toml").string();
  const std::string edited = dir.file("sony-imx490.toml");
  fs::copy_file(bundled, edited);
  std::ofstream(edited, std::ios::app) << "\n# a user's edit: a comment changes no figure\n";
  r = test::run_cli("expose --radiance '" + dir.file("scene.exr") + "' --preset sony-imx490 --out '" +
                    dir.file("a.exr") + "' " + store);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  r = test::run_cli("expose --radiance '" + dir.file("scene.exr") + "' --preset '" + edited + "' --out '" +
                    dir.file("b.exr") + "' " + store);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  auto a = read_exr(dir.file("a.exr"));
  auto b = read_exr(dir.file("b.exr"));
  EXPECT_EQ(a.attributes["photosite/preset"], b.attributes["photosite/preset"]);
  EXPECT_EQ(a.attributes["photosite/preset_xxh3_64"], file_checksum_hex(bundled, ChecksumAlgorithm::Xxh3_64).value());
  EXPECT_EQ(b.attributes["photosite/preset_xxh3_64"], file_checksum_hex(edited, ChecksumAlgorithm::Xxh3_64).value());
  EXPECT_NE(a.attributes["photosite/preset_xxh3_64"], b.attributes["photosite/preset_xxh3_64"]);
  EXPECT_EQ(a.attributes["photosite/lens_xxh3_64"], b.attributes["photosite/lens_xxh3_64"]);
  EXPECT_EQ(a.attributes["photosite/lens_xxh3_64"].size(), 16u);
}

// flat is given photons per pixel: no lens or aperture acts on them, so its header names neither
// (before: the unused --lens and --f-number were recorded as the optics used).
TEST(Cli, FlatHeaderNamesNoLensOrFNumber) {
  test::TempDir dir;
  auto r = test::run_cli("flat --photons 100 --wavelength-nm 525 --width 16 --height 16 --preset sony-imx174 --device-store '" +
                         dir.file("store") + "' --out '" + dir.file("f.exr") + "'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto a = read_exr(dir.file("f.exr")).attributes;
  EXPECT_EQ(a.count("photosite/lens"), 0u);
  EXPECT_EQ(a.count("photosite/f_number"), 0u);
  EXPECT_EQ(a.count("photosite/lens_xxh3_64"), 0u);
  EXPECT_EQ(a.count("photosite/photons_per_pixel"), 1u);
  EXPECT_EQ(a.count("photosite/preset"), 1u);
}

TEST(Cli, ExposeWritesTheContractChannelsAndFrames) {
  test::TempDir dir;
  const std::string store = "--device-store '" + dir.file("store") + "'";
  auto r = test::run_cli("chart --out '" + dir.file("scene.exr") + "' --width 96 --height 64");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  r = test::run_cli("expose --radiance '" + dir.file("scene.exr") + "' --preset sony-imx490 --out '" +
                    dir.file("o_##.exr") + "' --frames 2 --seed 5 " + store);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  auto a = read_exr(dir.file("o_00.exr"));
  auto b = read_exr(dir.file("o_01.exr"));
  for (const char* ch : {"raw.Y", "R", "G", "B", "electrons.Y", "radiance.R", "radiance.G", "radiance.B"})
    EXPECT_EQ(a.channels.count(ch), 1u) << ch;
  for (const char* at : {"photosite/version", "photosite/preset", "photosite/device_id", "photosite/seed",
                         "photosite/frame", "photosite/exposure_s", "photosite/f_number", "photosite/gain",
                         "photosite/temperature_c", "photosite/unit/raw.Y", "photosite/unit/electrons.Y",
                         "photosite/unit/radiance.R"})
    EXPECT_EQ(a.attributes.count(at), 1u) << at;
  EXPECT_EQ(a.attributes["photosite/frame"], "0");
  EXPECT_EQ(b.attributes["photosite/frame"], "1");
  EXPECT_NE(a.channels["raw.Y"].vec(), b.channels["raw.Y"].vec());
  // Raw DN is integer-valued and includes the black level; raw and electrons are UINT channels.
  for (float v : a.channels["raw.Y"].vec()) ASSERT_EQ(v, std::floor(v));
  EXPECT_EQ(a.pixel_types.at("raw.Y"), ExrPixel::Uint);
  EXPECT_EQ(a.pixel_types.at("electrons.Y"), ExrPixel::Uint);
  EXPECT_EQ(a.pixel_types.at("radiance.R"), ExrPixel::Float);
  // The same command again (other file name) reproduces frame 0 bit for bit.
  r = test::run_cli("expose --radiance '" + dir.file("scene.exr") + "' --preset sony-imx490 --out '" +
                    dir.file("again.exr") + "' --seed 5 " + store);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(read_exr(dir.file("again.exr")).channels["raw.Y"].vec(), a.channels["raw.Y"].vec());
  // Flat fields.
  r = test::run_cli("flat --photons 1000 --wavelength-nm 525 --preset sony-imx174 --width 40 --height 30 "
                    "--frames 1 --out '" + dir.file("flat.exr") + "' " + store);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(read_exr(dir.file("flat.exr")).channels.count("electrons.Y"), 1u);
}

TEST(Cli, BadInputExitsTwoAndLeavesNoOutput) {
  test::TempDir dir;
  const std::string store = " --device-store '" + dir.file("store") + "'";
  ASSERT_EQ(test::run_cli("chart --out '" + dir.file("scene.exr") + "' --width 64 --height 48").exit_code, 0);
  // A radiance file with NaN.
  ImageF nan_img(8, 8, 3, 0.1f);
  nan_img.at(3, 2, 0) = std::nanf("");
  write_exr(dir.file("nan.exr"), {{{"R", "G", "B"}, &nan_img, ""}}, {});
  ImageF neg_img(8, 8, 3, -0.1f);
  write_exr(dir.file("neg.exr"), {{{"R", "G", "B"}, &neg_img, ""}}, {});
  { std::ofstream(dir.file("corrupt.exr")) << "not an exr at all"; }
  const std::string scene = " --radiance '" + dir.file("scene.exr") + "'";
  struct Case { std::string args, expect; };
  const std::vector<Case> cases = {
      {"expose --radiance '" + dir.file("missing.exr") + "' --preset sony-imx174", "no such file"},
      {"expose --radiance '" + dir.file("corrupt.exr") + "' --preset sony-imx174", "corrupt.exr"},
      {"expose --radiance '" + dir.file("nan.exr") + "' --preset sony-imx174", "NaN"},
      {"expose --radiance '" + dir.file("neg.exr") + "' --preset sony-imx174", "negative"},
      {"expose" + scene + " --preset no-such-camera", "unknown camera preset"},
      {"expose" + scene + " --preset sony-imx174 --f-number 0", "f-number"},
      {"expose" + scene + " --preset sony-imx174 --exposure-s -1", "exposure"},
      {"expose" + scene + " --preset sony-imx174 --gain-db 99", "gain"},
      {"expose" + scene + " --preset sony-imx174 --frames 3", "#"},
      {"expose" + scene + " --preset sony-imx174 --demosaic nope", "demosaic"},
      {"expose" + scene + " --preset sony-imx174 --device-id 'a/b'", "device id"},
      {"flat --photons -5 --wavelength-nm 525 --preset sony-imx174 --width 4 --height 4", "photons"},
      {"flat --photons 5 --wavelength-nm 525 --preset sony-imx174 --width 0 --height 4", "size"},
  };
  for (const auto& c : cases) {
    const std::string out = dir.file("out.exr");
    auto r = test::run_cli(c.args + " --out '" + out + "'" + store);
    EXPECT_EQ(r.exit_code, 2) << c.args << "\n" << r.output;
    EXPECT_NE(r.output.find(c.expect), std::string::npos) << c.args << "\n" << r.output;
    EXPECT_FALSE(std::filesystem::exists(out)) << c.args;
  }
  // Output folder missing; existing output without --overwrite is refused and untouched.
  auto r = test::run_cli("expose" + scene + " --preset sony-imx174 --out '" + dir.file("no/dir/x.exr") + "'" + store);
  EXPECT_EQ(r.exit_code, 2) << r.output;
  { std::ofstream(dir.file("keep.exr")) << "user data"; }
  r = test::run_cli("expose" + scene + " --preset sony-imx174 --out '" + dir.file("keep.exr") + "'" + store);
  EXPECT_EQ(r.exit_code, 2) << r.output;
  std::ifstream f(dir.file("keep.exr"));
  std::string content((std::istreambuf_iterator<char>(f)), {});
  EXPECT_EQ(content, "user data");
  // No temporary files left behind in the folder.
  for (const auto& e : std::filesystem::directory_iterator(dir.path()))
    EXPECT_EQ(e.path().filename().string().find(".tmp-"), std::string::npos) << e.path();
}
