// The one parameter schema (issue 18 §4): the camera and lens readers, `presets show --json` and
// the docs' reference tables come from one table per preset kind (sensor/preset.cpp).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include <nlohmann/json.hpp>

#include "photosite/error.h"
#include "photosite/scene/scene_preset.h"
#include "photosite/sensor/preset.h"
#include "test_util.h"

using namespace photosite;

namespace {
namespace fs = std::filesystem;

std::string slurp(const fs::path& p) {
  std::ifstream f(p);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

// tests/data/presets_before/<name>.json: `presets show NAME --json` of every bundled preset as the
// readers before the schema (commit 260993b) loaded them.
std::vector<fs::path> golden_files() {
  std::vector<fs::path> out;
  for (const auto& e : fs::directory_iterator(fs::path(PHOTOSITE_SOURCE_DIR) / "tests/data/presets_before"))
    if (e.path().extension() == ".json") out.push_back(e.path());
  std::sort(out.begin(), out.end());
  return out;
}

std::vector<double> list_or_empty(const nlohmann::json& j, const char* key) {
  return j.contains(key) ? j[key].get<std::vector<double>>() : std::vector<double>{};
}

template <class F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "no error";
}

const std::string kLensHead =
    "description = \"t\"\nf_number = 2.0\nfocal_length_mm = 5.0\ntransmittance = 0.9\ncos4_falloff = true\n";
}  // namespace

// Every bundled camera and lens loads to the values it had before the schema, field by field
// (exact: the golden numbers are nlohmann's round-trip text), and `presets show --json` is the
// same JSON (keys and values) apart from the file's path.
TEST(PresetSchema, BundledPresetsLoadToTheSameValuesAsBefore) {
  const auto files = golden_files();
  ASSERT_EQ(files.size(), 11u);  // the 6 cameras and 5 lenses bundled when the goldens were written
  for (const auto& path : files) {
    const std::string name = path.stem().string();
    SCOPED_TRACE(name);
    nlohmann::json before = nlohmann::json::parse(slurp(path));
    if (before.contains("cfa")) {
      const CameraPreset p = load_camera_preset(name);
      EXPECT_EQ(p.name, before["name"]);
      EXPECT_EQ(p.description, before["description"]);
      EXPECT_EQ(p.default_lens, before["default_lens"]);
      EXPECT_EQ(std::string(to_string(p.cfa)), before["cfa"]);
      EXPECT_EQ(p.width_px, before["width_px"]);
      EXPECT_EQ(p.height_px, before["height_px"]);
      EXPECT_EQ(p.bit_depth, before["bit_depth"]);
      EXPECT_EQ(p.pixel_pitch_um, before["pixel_pitch_um"]);
      EXPECT_EQ(p.fill_factor, before["fill_factor"]);
      EXPECT_EQ(p.full_well_e, before["full_well_e"]);
      EXPECT_EQ(p.system_gain_dn_per_e, before["system_gain_dn_per_e"]);
      EXPECT_EQ(p.max_gain_db, before["max_gain_db"]);
      EXPECT_EQ(p.read_noise_e, before["read_noise_e"]);
      EXPECT_EQ(p.read_noise_tukey_lambda, before["read_noise_tukey_lambda"]);
      EXPECT_EQ(p.dark_current_e_per_s, before["dark_current_e_per_s"]);
      EXPECT_EQ(p.dark_current_reference_c, before["dark_current_reference_c"]);
      EXPECT_EQ(p.dark_current_doubling_c, before["dark_current_doubling_c"]);
      EXPECT_EQ(p.dark_current_nonuniformity_percent, before["dark_current_nonuniformity_percent"]);
      EXPECT_EQ(p.dsnu_e, before["dsnu_e"]);
      EXPECT_EQ(p.prnu_percent, before["prnu_percent"]);
      EXPECT_EQ(p.black_level_dn, before["black_level_dn"]);
      EXPECT_EQ(p.temperature_c, before["temperature_c"]);
      EXPECT_EQ(p.row_noise_e, before["row_noise_e"]);
      EXPECT_EQ(p.column_noise_e, before["column_noise_e"]);
      EXPECT_EQ(p.hot_pixel_fraction, before["hot_pixel_fraction"]);
      EXPECT_EQ(p.hot_pixel_dark_current_e_per_s, before["hot_pixel_dark_current_e_per_s"]);
      const auto& qe = before["qe"];
      EXPECT_EQ(p.qe.wavelength_nm, list_or_empty(qe, "wavelength_nm"));
      EXPECT_EQ(p.qe.qe[0], list_or_empty(qe, "r"));
      EXPECT_EQ(p.qe.qe[1], list_or_empty(qe, "g"));
      EXPECT_EQ(p.qe.qe[2], list_or_empty(qe, "b"));
      EXPECT_EQ(p.qe.qe[3], list_or_empty(qe, "c"));
    } else {
      const LensPreset l = load_lens_preset(name);
      EXPECT_EQ(l.name, before["name"]);
      EXPECT_EQ(l.description, before["description"]);
      EXPECT_EQ(l.f_number, before["f_number"]);
      EXPECT_EQ(l.focal_length_mm, before["focal_length_mm"]);
      EXPECT_EQ(l.transmittance, before["transmittance"]);
      EXPECT_EQ(l.magnification, before["magnification"]);
      EXPECT_EQ(l.cos4_falloff, before["cos4_falloff"]);
      const auto& g = before["glare"];
      EXPECT_EQ(l.glare.enabled, !g.is_null());
      const LensGlare none;
      EXPECT_EQ(l.glare.veiling_glare_index, g.is_null() ? none.veiling_glare_index : g["veiling_glare_index"].get<double>());
      EXPECT_EQ(l.glare.core_deg, g.is_null() ? none.core_deg : g["core_deg"].get<double>());
      EXPECT_EQ(l.glare.reach_deg, g.is_null() ? none.reach_deg : g["reach_deg"].get<double>());
      EXPECT_EQ(l.glare.skirt_exponent, g.is_null() ? none.skirt_exponent : g["skirt_exponent"].get<double>());
    }
    // The JSON contract: the same keys, types and values.
    nlohmann::json now = nlohmann::json::parse(show_preset(name));
    before.erase("file");
    now.erase("file");
    EXPECT_EQ(now, before) << now.dump(2);
  }
}

// Every member of ScenePreset that a scene file sets.
#define PHOTOSITE_SCENE_FIELDS(X) \
  X(rho_sign) X(rho_construction) X(rho_human) X(rho_nature) X(rho_vehicle) X(rho_sky) X(rho_road) \
  X(rho_diffuse_max) X(rho_glint_max) X(sun_shade_ratio_max) X(sun_shade_ratio_min) X(sun_shade_window_fraction) X(sky_gap_fraction) \
  X(sun_cct_K) X(shade_sky_cct_K) \
  X(moon_lux) X(moon_cct_K) X(skyglow_lux) X(skyglow_cct_K) X(sky_luminance_cd_m2) \
  X(street_road_luminance_cd_m2) X(street_cct_K) \
  X(lamp_mount_height_m) X(lamp_spacing_ratio) X(lamp_setback_m) X(lamp_cutoff_deg) X(lamp_falloff_deg) \
  X(lamp_head_diameter_m) X(lamp_max_distance_m) X(lamp_min_pole_height_m) X(lamp_interp_tolerance) \
  X(veh_lamp_height_m) X(veh_lamp_inset_m) X(veh_head_diameter_m) X(veh_tail_diameter_m) \
  X(veh_head_intensity_cd) X(veh_tail_intensity_cd) X(veh_parking_intensity_cd) X(veh_parked_lit_fraction) \
  X(veh_kerb_strip_m) X(veh_lane_width_m) \
  X(window_storey_m) X(window_pitch_m) X(window_width_m) X(window_height_m) X(shop_luminance_factor) X(shop_cct_K) \
  X(shop_width_m) X(shop_sill_m) X(shop_height_m) X(shop_frontage_m) X(window_detect_contrast) X(window_frame_m) X(window_mullion_m) X(shop_share) \
  X(streetlamp_luminance_cd_m2) X(streetlamp_cct_K) X(headlamp_luminance_cd_m2) X(headlamp_cct_K) \
  X(taillamp_luminance_cd_m2) X(signal_luminance_cd_m2) X(window_luminance_cd_m2) X(window_cct_K) \
  X(window_lit_fraction) X(window_cell_fraction) X(window_warm_share) X(window_cool_cct_K) \
  X(window_curtained_share) X(window_curtained_luminance_cd_m2) \
  X(marking_RL) X(sign_RA) X(sign_RA_alpha_deg) X(sign_RA_alpha_exponent) X(sign_RA_alpha_max_deg) \
  X(sign_RA_entrance_deg) X(sign_RA_entrance_factor) X(sign_RA_entrance_factor_alpha_max) X(sign_read_distance_m) \
  X(beam_cct_K) X(beam_sign_lux) X(beam_lamp_height_m) X(beam_lamp_spacing_m) X(beam_cutoff_v_deg) \
  X(beam_cutoff_rise_deg) X(beam_cutoff_max_v_deg) X(beam_above_cutoff_cd) X(beam_h_deg) X(beam_v_deg) X(beam_intensity_cd) \
  X(work_max_width) X(lane_blur_sigma_px) X(lane_contrast_threshold) X(canny_low) X(canny_high) \
  X(hough_threshold) X(hough_min_length_fraction) X(hough_max_gap_fraction) X(line_reject_angle_deg) \
  X(border_fraction) X(vp_cluster_radius_fraction) X(vp_min_support) X(max_depth_m)

// Every bundled scene loads to the values it had before the scene keys moved into the schema table
// (tests/data/scenes_before/<name>.json, written by the hand-written reader of commit d6cd607 with
// a program that printed each member above by name, and scene_attributes()), member by member and
// exactly (nlohmann's round-trip text); and the EXR header attributes keep their names, types and
// values. Keys added since are appended to those files by hand with their bundled values
// (windows.frame_m, mullion_m, shop_share; lamps.window_curtained_share, _luminance_cd_m2;
// ego_beam.above_cutoff_cd; retroreflection.sign_RA_alpha_deg, _alpha_exponent, _alpha_max_deg;
// retroreflection.sign_RA_entrance_deg, _entrance_factor, _entrance_factor_alpha_max (lists, no attribute);
// reflectance.diffuse_max, glint_max; reflectance.sun_shade_ratio_max, _ratio_min, _window_fraction; reflectance.sky_gap_fraction;
// street_lamps.interp_tolerance, street_lamps.shadows and street_lamps.penumbrae (attributes only, as ego_beam.shadows); reflectance.sun_cct_K, shade_sky_cct_K; vehicle_lamps.beams_on_road;
// lamps.streetlamp_type and reflectance.day_white_balance, attributes only, the members being enums). Values changed since, by hand
// with the commit that changed them: reflectance.nature 0.2 -> 0.08 (the visible reflectance of
// vegetation, NP §4); reflectance.sun_shade_ratio_max 1 -> 10 (the split on, with its colour test);
// street_lamps.spacing_ratio 3.5 -> 3.0 (≤ 3 for cut-off luminaires, docs/night.md "Street lamp spacing");
// geometry.line_reject_angle_deg 12 -> 5 (the kerbs of streets wider than a lane each way kept;
// docs/night.md §2–6, `photosite bench depth --synthetic`); retroreflection.sign_RA_alpha_exponent
// 1.056 -> 1.989 and sign_RA_alpha_max_deg 0.5 -> 2 (RA2 white sheeting's 2° figure, found: docs/night.md §7).
TEST(PresetSchema, BundledScenesLoadToTheSameValuesAsBefore) {
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(fs::path(PHOTOSITE_SOURCE_DIR) / "tests/data/scenes_before"))
    if (e.path().extension() == ".json") files.push_back(e.path());
  std::sort(files.begin(), files.end());
  ASSERT_EQ(files.size(), 2u);  // night-rural, night-urban
  for (const auto& path : files) {
    const std::string name = path.stem().string();
    SCOPED_TRACE(name);
    const nlohmann::json before = nlohmann::json::parse(slurp(path));
    const scene::ScenePreset p = scene::load_scene_preset(name);
    EXPECT_EQ(p.name, before["name"]);
    EXPECT_EQ(p.description, before["description"]);
    const auto& f = before["fields"];
    size_t n = 0;
#define X(m)                                                   \
  EXPECT_EQ(p.m, f[#m].get<decltype(scene::ScenePreset::m)>()) \
      << #m;                                                   \
  ++n;
    PHOTOSITE_SCENE_FIELDS(X)
#undef X
    EXPECT_EQ(n, f.size());
    nlohmann::json now = nlohmann::json::object();
    for (const auto& [k, v] : scene::scene_attributes(p))
      std::visit(
          [&](const auto& x) {
            using T = std::decay_t<decltype(x)>;
            const char* type = std::is_same_v<T, std::string> ? "string"
                               : std::is_same_v<T, int>       ? "int"
                               : std::is_same_v<T, float>     ? "float"
                                                              : "double";
            now[k] = {{"type", type}, {"value", x}};
          },
          v);
    EXPECT_EQ(now, before["attributes"]) << now.dump(1);
  }
}

// The camera keys an output's EXR header carries come from the rows marked Exr::Header: the same
// attribute names (contracts), types and values as the hand-written list they replaced.
TEST(PresetSchema, CameraAttributesAreTheMarkedRows) {
  for (const char* name : {"sony-imx174", "onsemi-ar0132at-rccc"}) {
    SCOPED_TRACE(name);
    const CameraPreset p = load_camera_preset(name);
    const auto a = camera_attributes(p);
    ASSERT_EQ(a.size(), 3u);
    EXPECT_EQ(std::get<std::string>(a.at("photosite/cfa")), to_string(p.cfa));
    EXPECT_EQ(std::get<int>(a.at("photosite/bit_depth")), p.bit_depth);
    EXPECT_EQ(std::get<double>(a.at("photosite/black_level_dn")), p.black_level_dn);
  }
}

// The bundled urban scene preset with one line's `key` replaced (with), and that line's number.
struct UrbanWithLine {
  std::string urban, key, line;
  size_t at = std::string::npos;
  explicit UrbanWithLine(const std::string& k)
      : urban(slurp(fs::path(PHOTOSITE_PRESET_DIR) / "scenes/night-urban.toml")), key(k), at(urban.find(k)) {
    if (at != std::string::npos)
      line = std::to_string(std::count(urban.begin(), urban.begin() + static_cast<long>(at), '\n') + 1);
  }
  std::string with(const std::string& to) const {
    std::string t = urban;
    t.replace(at, key.size(), to);
    return t;
  }
};

// lamps.streetlamp_type: "led" (the bundled presets' value, and the default when the key is absent)
// or "hps"; any other value, or a number, is refused at its line; the EXR header records it.
TEST(PresetSchema, StreetlampTypeIsLedOrHpsAndTheHeaderRecordsIt) {
  const UrbanWithLine u("streetlamp_type = \"led\"");
  ASSERT_NE(u.at, std::string::npos);
  const std::string& urban = u.urban;
  const std::string& line = u.line;
  auto with = [&](const std::string& to) { return u.with(to); };
  EXPECT_EQ(scene::parse_scene_preset(urban, "s.toml").streetlamp_type, scene::StreetlampType::Led);
  const scene::ScenePreset hps = scene::parse_scene_preset(with("streetlamp_type = \"hps\""), "s.toml");
  EXPECT_EQ(hps.streetlamp_type, scene::StreetlampType::Hps);
  EXPECT_EQ(std::get<std::string>(scene::scene_attributes(hps).at("photosite/scene/lamps.streetlamp_type")), "hps");
  EXPECT_EQ(scene::parse_scene_preset(with(""), "s.toml").streetlamp_type, scene::StreetlampType::Led);
  const std::string e1 = error_of([&] { scene::parse_scene_preset(with("streetlamp_type = \"sodium\""), "s.toml"); });
  EXPECT_NE(e1.find("s.toml:" + line + ": lamps.streetlamp_type: unknown street lamp type 'sodium' (expected led, hps)"),
            std::string::npos)
      << e1;
  const std::string e2 = error_of([&] { scene::parse_scene_preset(with("streetlamp_type = 2000"), "s.toml"); });
  EXPECT_NE(e2.find("s.toml:" + line + ": lamps.streetlamp_type: expected a string"), std::string::npos) << e2;
}

// reflectance.day_white_balance: "road" (the bundled presets' value and the default when the key is
// absent) or "none"; any other value is refused at its line; the EXR header records it.
TEST(PresetSchema, DayWhiteBalanceIsRoadOrNoneAndTheHeaderRecordsIt) {
  const UrbanWithLine u("day_white_balance = \"road\"");
  ASSERT_NE(u.at, std::string::npos);
  EXPECT_EQ(scene::parse_scene_preset(u.urban, "s.toml").day_white_balance, scene::DayWhiteBalance::Road);
  const scene::ScenePreset none = scene::parse_scene_preset(u.with("day_white_balance = \"none\""), "s.toml");
  EXPECT_EQ(none.day_white_balance, scene::DayWhiteBalance::None);
  EXPECT_EQ(std::get<std::string>(scene::scene_attributes(none).at("photosite/scene/reflectance.day_white_balance")),
            "none");
  EXPECT_EQ(scene::parse_scene_preset(u.with(""), "s.toml").day_white_balance, scene::DayWhiteBalance::Road);
  const std::string e = error_of([&] { scene::parse_scene_preset(u.with("day_white_balance = \"grey_world\""), "s.toml"); });
  EXPECT_NE(e.find("s.toml:" + u.line +
                   ": reflectance.day_white_balance: unknown day white balance 'grey_world' (expected road, none)"),
            std::string::npos)
      << e;
}

// A scene file's errors have the camera's and lens's form, "file:line: key: problem".
TEST(PresetSchema, SceneErrorsNameFileLineKeyRangeAndUnit) {
  const std::string urban = slurp(fs::path(PHOTOSITE_PRESET_DIR) / "scenes/night-urban.toml");
  auto line_of = [&](const std::string& key) {
    const auto p = urban.find("\n" + key + " ");
    return std::to_string(std::count(urban.begin(), urban.begin() + static_cast<long>(p) + 1, '\n') + 1);
  };
  auto error = [&](const std::string& from, const std::string& to) {
    std::string bad = urban;
    bad.replace(bad.find(from), from.size(), to);
    return error_of([&] { scene::parse_scene_preset(bad, "s.toml"); });
  };
  EXPECT_NE(error("moon_lux = 0.1", "moon_lux = 2").find("s.toml:" + line_of("moon_lux") +
                                                          ": ambient.moon_lux: value 2 is out of range, outside [0, 1] (lx)"),
            std::string::npos)
      << error("moon_lux = 0.1", "moon_lux = 2");
  EXPECT_NE(error("moon_lux = 0.1", "moon_lx = 0.1").find("s.toml:" + line_of("moon_lux") + ": ambient.moon_lx: unknown key (expected moon_lux,"),
            std::string::npos);
  EXPECT_NE(error("work_max_width = 1024", "work_max_width = 1024.5")
                .find("s.toml:" + line_of("work_max_width") + ": geometry.work_max_width: expected an integer"),
            std::string::npos);
  EXPECT_NE(error("canny_low = 40", "canny_low = 400").find("s.toml:" + line_of("canny_low") + ": geometry.canny_low: exceeds canny_high"),
            std::string::npos);
  EXPECT_NE(error("h_deg = [-25, -9,", "h_deg = [-9, -25,").find("s.toml:" + line_of("h_deg") + ": ego_beam.h_deg: angles must increase strictly"),
            std::string::npos);
  EXPECT_NE(error("[0, 0, 0, 0, 0, 0, 0],", "[0, 0, 0, 0, 0, 0],").find(": ego_beam.intensity_cd: rows differ in length"),
            std::string::npos);
  // An empty first row is a row too; and as many rows as v_deg entries, of one length each.
  EXPECT_NE(error("[0, 0, 0, 0, 0, 0, 0],", "[],").find(": ego_beam.intensity_cd: rows differ in length"),
            std::string::npos);
  EXPECT_NE(error("[0, 0, 0, 0, 0, 0, 0],", "").find(": ego_beam.intensity_cd: needs one row per v_deg entry (8)"),
            std::string::npos);
  EXPECT_NE(error("[2, 4, 6, 8, 8, 6, 2],", "[2, 4, 6, 8, 8, 6, 2e7],").find(": ego_beam.intensity_cd: value 2e7 is out of range, outside [0, 1e6] (cd)"),
            std::string::npos);
  EXPECT_NE(error("sky_gap_fraction = 0.6 ", "sky_gap_fraction = 1.5 ")
                .find("s.toml:" + line_of("sky_gap_fraction") +
                      ": reflectance.sky_gap_fraction: value 1.5 is out of range, outside [0, 1] (fraction)"),
            std::string::npos)
      << error("sky_gap_fraction = 0.6 ", "sky_gap_fraction = 1.5 ");
  {  // optional: a scene file written before the key loads, with its default
    std::string old_file = urban;
    const auto at = old_file.find("\nsky_gap_fraction = ");
    ASSERT_NE(at, std::string::npos);
    old_file.erase(at + 1, old_file.find('\n', at + 1) - at);
    EXPECT_EQ(old_file.find("sky_gap_fraction = "), std::string::npos);
    EXPECT_EQ(scene::parse_scene_preset(old_file, "s.toml").sky_gap_fraction, 0.6);
  }
  EXPECT_NE(error("sign_RA_alpha_max_deg = 2 ", "sign_RA_alpha_max_deg = 0.2 ")
                .find("s.toml:" + line_of("sign_RA_alpha_max_deg") +
                      ": retroreflection.sign_RA_alpha_max_deg: is below sign_RA_alpha_deg"),
            std::string::npos);
  EXPECT_NE(error("sign_RA_entrance_deg = [5, 30, 40]", "sign_RA_entrance_deg = [5, 40, 30]")
                .find("s.toml:" + line_of("sign_RA_entrance_deg") +
                      ": retroreflection.sign_RA_entrance_deg: angles must increase strictly"),
            std::string::npos);
  EXPECT_NE(error("sign_RA_entrance_factor_alpha_max = [1, 0.5, 0.3]", "sign_RA_entrance_factor_alpha_max = [1, 0.5]")
                .find("s.toml:" + line_of("sign_RA_entrance_factor_alpha_max") +
                      ": retroreflection.sign_RA_entrance_factor_alpha_max: needs one value of "
                      "retroreflection.sign_RA_entrance_factor_alpha_max per sign_RA_entrance_deg entry (3), has 2"),
            std::string::npos)
      << error("sign_RA_entrance_factor_alpha_max = [1, 0.5, 0.3]", "sign_RA_entrance_factor_alpha_max = [1, 0.5]");
  EXPECT_NE(error("sign_RA_entrance_factor = [1, 0.5556, 0.5278]", "sign_RA_entrance_factor = [1, 0, 0.5278]")
                .find(": retroreflection.sign_RA_entrance_factor: value 0 is out of range, outside [1e-6, 10]"),
            std::string::npos)
      << error("sign_RA_entrance_factor = [1, 0.5556, 0.5278]", "sign_RA_entrance_factor = [1, 0, 0.5278]");
  {  // the split's lower bound above its upper
    std::string bad = urban;
    const std::string min20 = "sun_shade_ratio_min = 2 ";
    bad.replace(bad.find(min20), min20.size(), "sun_shade_ratio_min = 20 ");
    EXPECT_NE(error_of([&] { scene::parse_scene_preset(bad, "s.toml"); })
                  .find("s.toml:" + line_of("sun_shade_ratio_min") +
                        ": reflectance.sun_shade_ratio_min: is above sun_shade_ratio_max"),
              std::string::npos);
  }
  EXPECT_NE(error("shade_sky_cct_K = 7000", "shade_sky_cct_K = 4000")
                .find("s.toml:" + line_of("shade_sky_cct_K") +
                      ": reflectance.shade_sky_cct_K: is not above sun_cct_K"),
            std::string::npos);
  EXPECT_NE(error("[retroreflection]", "[retro]").find(": retro: unknown key"), std::string::npos);
  const std::string missing = error("sign_RA = 180", "");
  EXPECT_NE(missing.find(": retroreflection.sign_RA: required key is missing"), std::string::npos) << missing;
}

// docs/presets.md's reference tables are the generator's output, so the docs cannot drift from
// the schema. To update them: `photosite presets doc`, pasted between the markers.
TEST(PresetSchema, DocsTablesAreGenerated) {
  const std::string doc = slurp(fs::path(PHOTOSITE_SOURCE_DIR) / "docs/presets.md");
  const std::string begin = "<!-- BEGIN GENERATED by `photosite presets doc`: do not edit by hand -->\n";
  const std::string end = "<!-- END GENERATED -->";
  const auto b = doc.find(begin), e = doc.find(end);
  ASSERT_NE(b, std::string::npos);
  ASSERT_NE(e, std::string::npos);
  ASSERT_LT(b, e);
  EXPECT_EQ(doc.substr(b + begin.size(), e - b - begin.size()), presets_doc_markdown())
      << "docs/presets.md is stale: replace its generated section with `photosite presets doc`";
  // Every key of the reader is in the docs: one row per key (here spot-checked on both kinds).
  for (const char* row : {"| `full_well_e` | e⁻ | yes | [1, 1e8]; > read_noise_e |", "| `qe.wavelength_nm` |",
                          "| `glare.skirt_exponent` | — | no (2) | [1, 4] |", "| `[glare]` | table | no (absent) |"})
    EXPECT_NE(presets_doc_markdown().find(row), std::string::npos) << row;
  auto r = test::run_cli("presets doc");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(r.output, presets_doc_markdown());
}

// One error form for every key, "file:line: key: problem"; a value out of range names the
// range and the unit.
TEST(PresetSchema, ErrorsNameFileLineKeyRangeAndUnit) {
  const std::string cam = slurp(fs::path(PHOTOSITE_PRESET_DIR) / "cameras/sony-imx174.toml");
  auto line_of = [](const std::string& text, const std::string& key) {
    const auto p = text.find("\n" + key + " ");
    return static_cast<int>(std::count(text.begin(), text.begin() + static_cast<long>(p) + 1, '\n')) + 1;
  };
  const int prnu_line = line_of(cam, "prnu_percent");
  std::string bad = cam;
  bad.replace(bad.find("prnu_percent = 0.6"), 18, "prnu_percent = 60");
  EXPECT_NE(error_of([&] { parse_camera_preset(bad, "cam.toml"); })
                .find("cam.toml:" + std::to_string(prnu_line) + ": prnu_percent: value 60 is out of range, outside [0, 50] (%)"),
            std::string::npos)
      << error_of([&] { parse_camera_preset(bad, "cam.toml"); });
  bad = cam;
  bad.replace(bad.find("bit_depth = 12"), 14, "bit_depth = 30");
  EXPECT_NE(error_of([&] { parse_camera_preset(bad, "cam.toml"); }).find("bit_depth: value 30 is out of range, outside [1, 24] (bit)"),
            std::string::npos);

  auto lens_error = [&](const std::string& text) { return error_of([&] { parse_lens_preset(text, "l.toml"); }); };
  EXPECT_NE(lens_error(kLensHead + "[glare]\nveiling_glare_index = 0.03\ncore_deg = 20\nreach_deg = 30\n")
                .find("l.toml:8: glare.core_deg: value 20 is out of range, outside [0.001, 10] (°)"),
            std::string::npos);
  // Inside a table, an unknown key lists the table's keys; a missing one names the table's line.
  EXPECT_NE(lens_error(kLensHead + "[glare]\nveiling_glare_index = 0.03\ncore_dg = 0.1\n")
                .find("l.toml:8: glare.core_dg: unknown key (expected veiling_glare_index, core_deg, reach_deg, "
                      "skirt_exponent)"),
            std::string::npos);
  EXPECT_NE(lens_error(kLensHead + "[glare]\nveiling_glare_index = 0.03\ncore_deg = 0.1\n")
                .find("l.toml:6: glare.reach_deg: required key is missing"),
            std::string::npos);
  EXPECT_NE(lens_error(kLensHead + "f_numbr = 2\n").find("l.toml:6: f_numbr: unknown key"), std::string::npos);
  EXPECT_NE(lens_error(kLensHead + "glare = 1\n").find("l.toml:6: glare: expected a table [glare]"), std::string::npos);
  EXPECT_NE(lens_error("f_number = 2.0\nfocal_length_mm = 5.0\ntransmittance = 0.9\ncos4_falloff = 1\n")
                .find("l.toml:4: cos4_falloff: expected true or false"),
            std::string::npos);
  EXPECT_NE(lens_error("f_number = 2.0\ntransmittance = 0.9\n").find("l.toml: focal_length_mm: required key is missing"),
            std::string::npos);
  // A quoted key with a dot is not the table's key.
  EXPECT_NE(lens_error(kLensHead + "\"glare.core_deg\" = 0.1\n").find("glare.core_deg: unknown key"), std::string::npos);
}
