// Scene preset loading: a flat table of "section.key" → number with range checks.
#include "photosite/scene/scene_preset.h"

#include <filesystem>
#include <fstream>
#include <sstream>
#include <toml++/toml.h>
#include <vector>

#include "core/toml_schema_detail.h"
#include "photosite/error.h"
#include "photosite/sensor/preset.h"

namespace photosite::scene {
namespace {
struct Field {
  double* d = nullptr;
  int* i = nullptr;
  double lo, hi;
};

std::vector<std::pair<std::string, Field>> fields(ScenePreset& p) {
  auto D = [](double& v, double lo, double hi) { return Field{&v, nullptr, lo, hi}; };
  auto I = [](int& v, double lo, double hi) { return Field{nullptr, &v, lo, hi}; };
  return {
      {"reflectance.sign", D(p.rho_sign, 0, 1)},
      {"reflectance.construction", D(p.rho_construction, 0, 1)},
      {"reflectance.human", D(p.rho_human, 0, 1)},
      {"reflectance.nature", D(p.rho_nature, 0, 1)},
      {"reflectance.vehicle", D(p.rho_vehicle, 0, 1)},
      {"reflectance.sky", D(p.rho_sky, 0, 1)},
      {"reflectance.road", D(p.rho_road, 1e-3, 1)},
      {"ambient.moon_lux", D(p.moon_lux, 0, 1)},
      {"ambient.moon_cct_K", D(p.moon_cct_K, 1000, 20000)},
      {"ambient.skyglow_lux", D(p.skyglow_lux, 0, 10)},
      {"ambient.skyglow_cct_K", D(p.skyglow_cct_K, 1000, 20000)},
      {"ambient.sky_luminance_cd_m2", D(p.sky_luminance_cd_m2, 0, 10)},
      {"street.road_luminance_cd_m2", D(p.street_road_luminance_cd_m2, 0, 10)},
      {"street.vertical_fraction", D(p.street_vertical_fraction, 0, 1)},
      {"street.cct_K", D(p.street_cct_K, 1000, 20000)},
      {"street_lamps.mount_height_m", D(p.lamp_mount_height_m, 2, 30)},
      {"street_lamps.spacing_ratio", D(p.lamp_spacing_ratio, 1, 10)},
      {"street_lamps.setback_m", D(p.lamp_setback_m, -5, 10)},
      {"street_lamps.cutoff_deg", D(p.lamp_cutoff_deg, 10, 89)},
      {"street_lamps.falloff_deg", D(p.lamp_falloff_deg, 0.1, 45)},
      {"street_lamps.head_diameter_m", D(p.lamp_head_diameter_m, 0.05, 3)},
      {"street_lamps.max_distance_m", D(p.lamp_max_distance_m, 10, 2000)},
      {"street_lamps.min_pole_height_m", D(p.lamp_min_pole_height_m, 1, 30)},
      {"vehicle_lamps.height_m", D(p.veh_lamp_height_m, 0.2, 3)},
      {"vehicle_lamps.inset_m", D(p.veh_lamp_inset_m, 0, 1)},
      {"vehicle_lamps.head_diameter_m", D(p.veh_head_diameter_m, 0.02, 1)},
      {"vehicle_lamps.tail_diameter_m", D(p.veh_tail_diameter_m, 0.02, 1)},
      {"vehicle_lamps.head_intensity_cd", D(p.veh_head_intensity_cd, 0, 1e6)},
      {"vehicle_lamps.tail_intensity_cd", D(p.veh_tail_intensity_cd, 0, 1e4)},
      {"vehicle_lamps.parking_intensity_cd", D(p.veh_parking_intensity_cd, 0, 1e4)},
      {"vehicle_lamps.parked_lit_fraction", D(p.veh_parked_lit_fraction, 0, 1)},
      {"vehicle_lamps.kerb_strip_m", D(p.veh_kerb_strip_m, 0, 10)},
      {"lamps.streetlamp_luminance_cd_m2", D(p.streetlamp_luminance_cd_m2, 0, 1e8)},
      {"lamps.streetlamp_cct_K", D(p.streetlamp_cct_K, 1000, 20000)},
      {"lamps.headlamp_luminance_cd_m2", D(p.headlamp_luminance_cd_m2, 0, 1e8)},
      {"lamps.headlamp_cct_K", D(p.headlamp_cct_K, 1000, 20000)},
      {"lamps.taillamp_luminance_cd_m2", D(p.taillamp_luminance_cd_m2, 0, 1e8)},
      {"lamps.signal_luminance_cd_m2", D(p.signal_luminance_cd_m2, 0, 1e8)},
      {"lamps.window_luminance_cd_m2", D(p.window_luminance_cd_m2, 0, 1e4)},
      {"lamps.window_cct_K", D(p.window_cct_K, 1000, 20000)},
      {"lamps.window_lit_fraction", D(p.window_lit_fraction, 0, 1)},
      {"lamps.window_cell_fraction", D(p.window_cell_fraction, 0.002, 0.5)},
      {"lamps.window_warm_share", D(p.window_warm_share, 0, 1)},
      {"lamps.window_cool_cct_K", D(p.window_cool_cct_K, 1000, 20000)},
      {"windows.storey_m", D(p.window_storey_m, 1.5, 10)},
      {"windows.pitch_m", D(p.window_pitch_m, 0.3, 10)},
      {"windows.width_m", D(p.window_width_m, 0.1, 10)},
      {"windows.height_m", D(p.window_height_m, 0.1, 10)},
      {"windows.shop_luminance_factor", D(p.shop_luminance_factor, 0, 100)},
      {"windows.shop_cct_K", D(p.shop_cct_K, 1000, 20000)},
      {"windows.shop_width_m", D(p.shop_width_m, 0.1, 10)},
      {"windows.shop_sill_m", D(p.shop_sill_m, 0, 10)},
      {"windows.shop_height_m", D(p.shop_height_m, 0.1, 10)},
      {"windows.shop_frontage_m", D(p.shop_frontage_m, 0.5, 100)},
      {"retroreflection.marking_RL", D(p.marking_RL, 0, 5)},
      {"retroreflection.sign_RA", D(p.sign_RA, 0, 2000)},
      {"ego_beam.cct_K", D(p.beam_cct_K, 1000, 20000)},
      {"ego_beam.lamp_height_m", D(p.beam_lamp_height_m, 0.2, 2)},
      {"ego_beam.lamp_spacing_m", D(p.beam_lamp_spacing_m, 0, 3)},
      {"ego_beam.cutoff_v_deg", D(p.beam_cutoff_v_deg, -5, 5)},
      {"ego_beam.cutoff_rise_deg", D(p.beam_cutoff_rise_deg, 0, 60)},
      {"ego_beam.cutoff_max_v_deg", D(p.beam_cutoff_max_v_deg, -5, 5)},
      {"ego_beam.sign_lux", D(p.beam_sign_lux, 0, 1000)},
      {"geometry.work_max_width", I(p.work_max_width, 64, 8192)},
      {"geometry.lane_blur_sigma_px", D(p.lane_blur_sigma_px, 0, 20)},
      {"geometry.lane_contrast_threshold", D(p.lane_contrast_threshold, 0, 1)},
      {"geometry.canny_low", D(p.canny_low, 0, 1000)},
      {"geometry.canny_high", D(p.canny_high, 0, 1000)},
      {"geometry.hough_threshold", I(p.hough_threshold, 1, 10000)},
      {"geometry.hough_min_length_fraction", D(p.hough_min_length_fraction, 0, 1)},
      {"geometry.hough_max_gap_fraction", D(p.hough_max_gap_fraction, 0, 1)},
      {"geometry.line_reject_angle_deg", D(p.line_reject_angle_deg, 0, 45)},
      {"geometry.border_fraction", D(p.border_fraction, 0, 0.4)},
      {"geometry.vp_cluster_radius_fraction", D(p.vp_cluster_radius_fraction, 0.001, 1)},
      {"geometry.vp_min_support", I(p.vp_min_support, 1, 10000)},
      {"geometry.max_depth_m", D(p.max_depth_m, 10, 60000)},
  };
}

// [ego_beam] h_deg, v_deg (arrays of at least two strictly increasing angles within ±90°) and
// intensity_cd (an array of rows, numbers >= 0).
void read_beam_table(const std::string& full, const toml::node& v, const std::string& file, int line,
                     ScenePreset& p) {
  const toml::array* a = v.as_array();
  if (!a) fail(where(file, line, full) + ": must be an array");
  auto number = [&](const toml::node& n) {
    auto x = n.value<double>();
    if (!x) fail(where(file, line, full) + ": entries must be numbers");
    return *x;
  };
  if (full == "ego_beam.intensity_cd") {
    p.beam_intensity_cd.clear();
    size_t cols = 0;
    for (const auto& row : *a) {
      const toml::array* r = row.as_array();
      if (!r) fail(where(file, line, full) + ": must be an array of rows (arrays)");
      if (cols && r->size() != cols) fail(where(file, line, full) + ": rows differ in length");
      cols = r->size();
      for (const auto& n : *r) {
        const double x = number(n);
        if (!(x >= 0 && x <= 1e6)) fail(where(file, line, full) + ": value " + std::to_string(x) + " is outside [0, 1e6] cd");
        p.beam_intensity_cd.push_back(x);
      }
    }
    return;
  }
  std::vector<double>& out = full == "ego_beam.h_deg" ? p.beam_h_deg : p.beam_v_deg;
  out.clear();
  for (const auto& n : *a) {
    const double x = number(n);
    if (!(x >= -90 && x <= 90)) fail(where(file, line, full) + ": angle " + std::to_string(x) + " is outside [-90, 90]");
    if (!out.empty() && !(x > out.back())) fail(where(file, line, full) + ": angles must increase strictly");
    out.push_back(x);
  }
  if (out.size() < 2) fail(where(file, line, full) + ": needs at least two angles");
}
}  // namespace

ScenePreset parse_scene_preset(const std::string& text, const std::string& file) {
  // The camera and lens readers' wording (core/toml_schema_detail.h): "file:line: key: problem".
  const toml::table t = schema::parse_toml(text, file);
  ScenePreset p;
  p.file = file;
  p.name = std::filesystem::path(file).stem().string();
  auto fs = fields(p);
  std::map<std::string, bool> seen;
  for (const auto& [k, node] : t) {
    const std::string key(k.str());
    const int line = static_cast<int>(node.source().begin.line);
    if (key == "description") {
      if (!node.is_string()) schema::key_error(file, line, key, "expected a string");
      p.description = node.value_or(std::string());
      continue;
    }
    if (key == "bloom")  // the scene-space bloom is gone: glare is the lens's now
      fail(where(file, line, key) +
           ": the scene-space bloom was removed; veiling glare is a property of the lens: set it in the "
           "lens preset's [glare] table (presets/lenses/*.toml, docs/model_glare.md)");
    const toml::table* sec = node.as_table();
    if (!sec) fail(where(file, line, key) + ": unknown key");
    for (const auto& [k2, v] : *sec) {
      const std::string full = key + "." + std::string(k2.str());
      const int l2 = static_cast<int>(v.source().begin.line);
      if (full == "ego_beam.h_deg" || full == "ego_beam.v_deg" || full == "ego_beam.intensity_cd") {
        read_beam_table(full, v, file, l2, p);
        seen[full] = true;
        continue;
      }
      auto it = std::find_if(fs.begin(), fs.end(), [&](auto& f) { return f.first == full; });
      if (it == fs.end()) fail(where(file, l2, full) + ": unknown key");
      auto num = v.value<double>();
      if (!num) schema::key_error(file, l2, full, "expected a number");
      const Field& f = it->second;
      if (!(*num >= f.lo && *num <= f.hi)) schema::key_error(file, l2, full, schema::out_of_range(*num, f.lo, f.hi, {}));
      if (f.d) *f.d = *num;
      else {
        if (*num != static_cast<int>(*num)) schema::key_error(file, l2, full, "expected an integer");
        *f.i = static_cast<int>(*num);
      }
      seen[full] = true;
    }
  }
  for (auto& f : fs)
    if (!seen.count(f.first)) fail(where(file, 0, f.first) + ": missing key");
  for (const char* k : {"ego_beam.h_deg", "ego_beam.v_deg", "ego_beam.intensity_cd"})
    if (!seen.count(k)) fail(where(file, 0, k) + ": missing key");
  if (p.beam_intensity_cd.size() != p.beam_h_deg.size() * p.beam_v_deg.size())
    fail(where(file, 0, "ego_beam.intensity_cd") + ": needs one row per v_deg entry (" +
         std::to_string(p.beam_v_deg.size()) + "), each with one value per h_deg entry (" +
         std::to_string(p.beam_h_deg.size()) + ")");
  if (p.window_width_m > p.window_pitch_m) fail(where(file, 0, "windows.width_m") + ": exceeds windows.pitch_m");
  if (p.window_height_m > p.window_storey_m) fail(where(file, 0, "windows.height_m") + ": exceeds windows.storey_m");
  if (p.shop_width_m > p.window_pitch_m) fail(where(file, 0, "windows.shop_width_m") + ": exceeds windows.pitch_m");
  if (p.shop_sill_m + p.shop_height_m > p.window_storey_m)
    fail(where(file, 0, "windows.shop_height_m") + ": shop_sill_m + shop_height_m exceeds windows.storey_m");
  if (p.canny_low > p.canny_high) fail(where(file, 0, "geometry.canny_low") + ": exceeds canny_high");
  return p;
}

ScenePreset load_scene_preset(const std::string& name_or_path) {
  namespace fs = std::filesystem;
  std::string path = name_or_path;
  if (name_or_path.find('/') == std::string::npos && !name_or_path.ends_with(".toml")) {
    path = (fs::path(preset_dir()) / "scenes" / (name_or_path + ".toml")).string();
    if (!fs::exists(path)) {
      std::string known;
      std::error_code ec;
      for (const auto& e : fs::directory_iterator(fs::path(preset_dir()) / "scenes", ec))
        if (e.path().extension() == ".toml")
          known += (known.empty() ? "" : ", ") + e.path().stem().string();
      fail("unknown scene preset '" + name_or_path + "' (bundled: " + known + ")");
    }
  }
  std::ifstream in(path);
  if (!in) fail_at(path, "cannot read scene preset");
  std::stringstream ss;
  ss << in.rdbuf();
  return parse_scene_preset(ss.str(), path);
}

std::map<std::string, ExrAttribute> scene_attributes(const ScenePreset& p) {
  std::map<std::string, ExrAttribute> a;
  a["photosite/scene/preset"] = p.name;
  ScenePreset copy = p;
  for (auto& [k, f] : fields(copy)) {
    if (f.d) a["photosite/scene/" + k] = *f.d;
    else a["photosite/scene/" + k] = *f.i;
  }
  return a;
}

}  // namespace photosite::scene
