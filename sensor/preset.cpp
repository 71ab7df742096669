// Preset loading in the spirit of pbrt-v4's PixelSensor::Create + ReportUnused: every key is
// declared once with its range; anything else in the file is an error with file, line and key.
#include "photosite/sensor/preset.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <sstream>
#include <toml++/toml.h>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "photosite/environment.h"
#include "photosite/error.h"

namespace photosite {
namespace fs = std::filesystem;

double QeTable::at(FilterColor c, double wl) const {
  const auto& q = qe[static_cast<int>(c)];
  if (q.empty() || wavelength_nm.empty() || wl < wavelength_nm.front() || wl > wavelength_nm.back())
    return 0.0;
  auto it = std::upper_bound(wavelength_nm.begin(), wavelength_nm.end(), wl);
  if (it == wavelength_nm.end()) return q.back();
  size_t i = static_cast<size_t>(it - wavelength_nm.begin());
  if (i == 0) return q.front();
  const double t = (wl - wavelength_nm[i - 1]) / (wavelength_nm[i] - wavelength_nm[i - 1]);
  return q[i - 1] + t * (q[i] - q[i - 1]);
}

namespace {

int line_of(const toml::node& n) { return static_cast<int>(n.source().begin.line); }

struct Field {
  std::function<void(const toml::node&, const std::string& file, const std::string& key)> set;
  bool required;
};

// Declares a number field with an allowed closed range.
Field number(double* target, double lo, double hi, bool required = true) {
  return {[=](const toml::node& n, const std::string& file, const std::string& key) {
            auto v = n.value<double>();
            if (!v) fail(where(file, line_of(n), key) + ": expected a number");
            if (!std::isfinite(*v) || *v < lo || *v > hi)
              fail(where(file, line_of(n), key) +
                   fmt::format(": value {} is out of range [{}, {}]", *v, lo, hi));
            *target = *v;
          },
          required};
}
Field integer(int* target, int lo, int hi, bool required = true) {
  return {[=](const toml::node& n, const std::string& file, const std::string& key) {
            // The type first: toml++ 3.3's value<int64_t>() of a float casts it unchecked, which
            // is undefined for 15E60 (UBSan, found by fuzz_preset; docs/robustness.md).
            if (!n.is_integer()) fail(where(file, line_of(n), key) + ": expected an integer");
            const auto v = n.value<int64_t>();
            if (*v < lo || *v > hi)
              fail(where(file, line_of(n), key) +
                   fmt::format(": value {} is out of range [{}, {}]", *v, lo, hi));
            *target = static_cast<int>(*v);
          },
          required};
}
Field string_field(std::string* target, bool required = false) {
  return {[=](const toml::node& n, const std::string& file, const std::string& key) {
            auto v = n.value<std::string>();
            if (!v) fail(where(file, line_of(n), key) + ": expected a string");
            *target = *v;
          },
          required};
}
Field boolean(bool* target, bool required = false) {
  return {[=](const toml::node& n, const std::string& file, const std::string& key) {
            auto v = n.value<bool>();
            if (!v) fail(where(file, line_of(n), key) + ": expected true or false");
            *target = *v;
          },
          required};
}

toml::table parse_toml(const std::string& text, const std::string& file) {
  try {
    return toml::parse(text, file);
  } catch (const toml::parse_error& e) {
    fail(where(file, static_cast<int>(e.source().begin.line)) + ": malformed TOML: " +
         std::string(e.description()));
  }
}

void apply_fields(const toml::table& table, const std::map<std::string, Field>& fields,
                  const std::string& file, const std::string& prefix,
                  const std::function<bool(const std::string&, const toml::node&)>& extra = {}) {
  for (const auto& [k, node] : table) {
    const std::string key(k.str());
    auto it = fields.find(key);
    if (it != fields.end()) {
      it->second.set(node, file, prefix + key);
    } else if (!(extra && extra(key, node))) {
      fail(where(file, line_of(node), prefix + key) + ": unknown key");
    }
  }
  for (const auto& [key, f] : fields)
    if (f.required && !table.contains(key))
      fail(where(file, 0, prefix + key) + ": required key is missing");
}

std::vector<double> number_array(const toml::node& n, const std::string& file,
                                 const std::string& key) {
  const toml::array* a = n.as_array();
  if (!a) fail(where(file, line_of(n), key) + ": expected an array of numbers");
  std::vector<double> out;
  for (const auto& e : *a) {
    auto v = e.value<double>();
    if (!v || !std::isfinite(*v)) fail(where(file, line_of(e), key) + ": expected a number");
    out.push_back(*v);
  }
  return out;
}

std::string read_text(const std::string& path) {
  std::ifstream f(path);
  if (!f) fail_at(path, "cannot open preset file");
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

std::string resolve_preset_path(const std::string& name_or_path, const std::string& kind) {
  std::error_code ec;
  if (name_or_path.find('/') != std::string::npos || name_or_path.ends_with(".toml")) {
    if (!fs::exists(name_or_path, ec)) fail_at(name_or_path, "no such preset file");
    return name_or_path;
  }
  fs::path p = fs::path(preset_dir()) / kind / (name_or_path + ".toml");
  if (fs::exists(p, ec)) return p.string();
  std::string known;
  for (const auto& e : list_presets())
    if (e.kind + "s" == kind) known += (known.empty() ? "" : ", ") + e.name;
  fail("unknown " + kind.substr(0, kind.size() - 1) + " preset '" + name_or_path +
       "' (bundled: " + known + ")");
}

}  // namespace

std::string preset_dir() {
  if (auto e = env::get(env::Var::PresetDir)) return *e;
  return (fs::path(data_dir()) / "presets").string();
}

CameraPreset parse_camera_preset(const std::string& text, const std::string& file) {
  toml::table t = parse_toml(text, file);
  CameraPreset p;
  p.file = file;
  p.name = fs::path(file).stem().string();
  std::string cfa;
  const double inf = 1e300;
  std::map<std::string, Field> fields{
      {"description", string_field(&p.description)},
      {"default_lens", string_field(&p.default_lens)},
      {"cfa", string_field(&cfa, true)},
      {"width_px", integer(&p.width_px, 1, 100000)},
      {"height_px", integer(&p.height_px, 1, 100000)},
      {"bit_depth", integer(&p.bit_depth, 1, 24)},
      {"pixel_pitch_um", number(&p.pixel_pitch_um, 0.1, 100)},
      {"fill_factor", number(&p.fill_factor, 0.01, 1.0, false)},
      {"full_well_e", number(&p.full_well_e, 1, 1e8)},
      {"system_gain_dn_per_e", number(&p.system_gain_dn_per_e, 1e-6, 1e3)},
      {"max_gain_db", number(&p.max_gain_db, 0, 60, false)},
      {"read_noise_e", number(&p.read_noise_e, 0, 1e4)},
      {"read_noise_tukey_lambda", number(&p.read_noise_tukey_lambda, -0.5, 0.5, false)},
      {"dark_current_e_per_s", number(&p.dark_current_e_per_s, 0, 1e7)},
      {"dark_current_reference_c", number(&p.dark_current_reference_c, -100, 200, false)},
      {"dark_current_doubling_c", number(&p.dark_current_doubling_c, 1, 50, false)},
      {"dark_current_nonuniformity_percent", number(&p.dark_current_nonuniformity_percent, 0, 1000)},
      {"dsnu_e", number(&p.dsnu_e, 0, 1e5)},
      {"prnu_percent", number(&p.prnu_percent, 0, 50)},
      {"black_level_dn", number(&p.black_level_dn, 0, inf)},
      {"temperature_c", number(&p.temperature_c, -100, 200)},
      {"row_noise_e", number(&p.row_noise_e, 0, 1e4, false)},
      {"column_noise_e", number(&p.column_noise_e, 0, 1e4, false)},
      {"hot_pixel_fraction", number(&p.hot_pixel_fraction, 0, 0.1, false)},
      {"hot_pixel_dark_current_e_per_s", number(&p.hot_pixel_dark_current_e_per_s, 0, 1e8, false)},
  };
  bool have_qe = false;
  apply_fields(t, fields, file, "", [&](const std::string& key, const toml::node& node) {
    if (key != "qe") return false;
    const toml::table* q = node.as_table();
    if (!q) fail(where(file, line_of(node), "qe") + ": expected a table [qe]");
    have_qe = true;
    for (const auto& [k, n] : *q) {
      const std::string kk(k.str());
      const std::string full = "qe." + kk;
      if (kk == "wavelength_nm") {
        p.qe.wavelength_nm = number_array(n, file, full);
        continue;
      }
      int c = kk == "r" ? 0 : kk == "g" ? 1 : kk == "b" ? 2 : kk == "c" ? 3 : -1;
      if (c < 0) fail(where(file, line_of(n), full) + ": unknown key (expected wavelength_nm, r, g, b or c)");
      p.qe.qe[c] = number_array(n, file, full);
      for (double v : p.qe.qe[c])
        if (v < 0 || v > 1)
          fail(where(file, line_of(n), full) + fmt::format(": QE {} is outside [0, 1]", v));
    }
    return true;
  });
  if (!have_qe) fail(where(file, 0, "qe") + ": required table is missing");
  try {
    p.cfa = parse_cfa(cfa);
  } catch (const Error& e) {
    fail(where(file, line_of(*t.get("cfa")), "cfa") + ": " + e.what());
  }
  validate(p);
  return p;
}

void validate(const CameraPreset& p) {
  const std::string& f = p.file;
  const auto& wl = p.qe.wavelength_nm;
  if (wl.size() < 2) fail(where(f, 0, "qe.wavelength_nm") + ": needs at least two wavelengths");
  for (size_t i = 1; i < wl.size(); ++i)
    if (!(wl[i] > wl[i - 1]))
      fail(where(f, 0, "qe.wavelength_nm") + ": wavelengths must increase");
  for (auto c : cfa_colors(p.cfa)) {
    const auto& q = p.qe.qe[static_cast<int>(c)];
    const std::string key = std::string("qe.") + static_cast<char>(std::tolower(to_string(c)[0]));
    if (q.empty()) fail(where(f, 0, key) + ": the CFA " + to_string(p.cfa) + " needs this QE curve");
    if (q.size() != wl.size())
      fail(where(f, 0, key) + fmt::format(": has {} values but qe.wavelength_nm has {}", q.size(), wl.size()));
  }
  if (p.full_well_e <= p.read_noise_e)
    fail(where(f, 0, "full_well_e") + fmt::format(": full well {} e- is not above the read noise {} e-",
                                                  p.full_well_e, p.read_noise_e));
  const double max_code = std::ldexp(1.0, p.bit_depth) - 1;
  if (p.black_level_dn >= max_code)
    fail(where(f, 0, "black_level_dn") + fmt::format(": {} DN leaves no range below the {}-bit maximum {}",
                                                     p.black_level_dn, p.bit_depth, max_code));
}

LensPreset parse_lens_preset(const std::string& text, const std::string& file) {
  toml::table t = parse_toml(text, file);
  LensPreset l;
  l.file = file;
  l.name = fs::path(file).stem().string();
  std::map<std::string, Field> fields{
      {"description", string_field(&l.description)},
      {"f_number", number(&l.f_number, 0.5, 64)},
      {"focal_length_mm", number(&l.focal_length_mm, 0.5, 2000)},
      {"transmittance", number(&l.transmittance, 0.01, 1.0)},
      {"magnification", number(&l.magnification, 0, 10, false)},
      {"cos4_falloff", boolean(&l.cos4_falloff)},
  };
  apply_fields(t, fields, file, "", [&](const std::string& key, const toml::node& node) {
    if (key != "glare") return false;
    const toml::table* g = node.as_table();
    if (!g) fail(where(file, line_of(node), "glare") + ": expected a table [glare]");
    // The veiling-glare PSF (sensor/glare.h, docs/model_glare.md). Without this table the lens
    // has no glare.
    LensGlare& lg = l.glare;
    lg.enabled = true;
    std::map<std::string, Field> gf{
        {"veiling_glare_index", number(&lg.veiling_glare_index, 0, 0.5)},
        {"core_deg", number(&lg.core_deg, 1e-3, 10)},
        {"reach_deg", number(&lg.reach_deg, 0.01, 180)},
        {"skirt_exponent", number(&lg.skirt_exponent, 1, 4, false)},
    };
    apply_fields(*g, gf, file, "glare.");
    if (!(lg.reach_deg > lg.core_deg))
      fail(where(file, line_of(node), "glare.reach_deg") +
           fmt::format(": reach {} deg must exceed the core {} deg", lg.reach_deg, lg.core_deg));
    return true;
  });
  return l;
}

CameraPreset load_camera_preset(const std::string& name_or_path) {
  std::string path = resolve_preset_path(name_or_path, "cameras");
  return parse_camera_preset(read_text(path), path);
}

LensPreset load_lens_preset(const std::string& name_or_path) {
  std::string path = resolve_preset_path(name_or_path, "lenses");
  return parse_lens_preset(read_text(path), path);
}

std::vector<PresetEntry> list_presets() {
  std::vector<PresetEntry> out;
  for (const char* kind : {"cameras", "lenses"}) {
    fs::path dir = fs::path(preset_dir()) / kind;
    std::error_code ec;
    if (!fs::is_directory(dir, ec)) continue;
    std::vector<PresetEntry> group;
    for (const auto& e : fs::directory_iterator(dir)) {
      if (e.path().extension() != ".toml") continue;
      PresetEntry pe{e.path().stem().string(), std::string(kind) == "cameras" ? "camera" : "lens", "",
                     e.path().string()};
      try {
        auto t = toml::parse_file(e.path().string());
        pe.description = t["description"].value_or(std::string());
      } catch (const toml::parse_error&) {
        pe.description = "(malformed)";
      }
      group.push_back(pe);
    }
    std::sort(group.begin(), group.end(), [](auto& a, auto& b) { return a.name < b.name; });
    out.insert(out.end(), group.begin(), group.end());
  }
  return out;
}

std::string to_json(const CameraPreset& p, int indent) {
  nlohmann::json j;
  j["name"] = p.name;
  j["file"] = p.file;
  j["description"] = p.description;
  j["default_lens"] = p.default_lens;
  j["cfa"] = to_string(p.cfa);
  j["width_px"] = p.width_px;
  j["height_px"] = p.height_px;
  j["bit_depth"] = p.bit_depth;
  j["pixel_pitch_um"] = p.pixel_pitch_um;
  j["fill_factor"] = p.fill_factor;
  j["full_well_e"] = p.full_well_e;
  j["system_gain_dn_per_e"] = p.system_gain_dn_per_e;
  j["max_gain_db"] = p.max_gain_db;
  j["read_noise_e"] = p.read_noise_e;
  j["read_noise_tukey_lambda"] = p.read_noise_tukey_lambda;
  j["dark_current_e_per_s"] = p.dark_current_e_per_s;
  j["dark_current_reference_c"] = p.dark_current_reference_c;
  j["dark_current_doubling_c"] = p.dark_current_doubling_c;
  j["dsnu_e"] = p.dsnu_e;
  j["dark_current_nonuniformity_percent"] = p.dark_current_nonuniformity_percent;
  j["prnu_percent"] = p.prnu_percent;
  j["black_level_dn"] = p.black_level_dn;
  j["temperature_c"] = p.temperature_c;
  j["row_noise_e"] = p.row_noise_e;
  j["column_noise_e"] = p.column_noise_e;
  j["hot_pixel_fraction"] = p.hot_pixel_fraction;
  j["hot_pixel_dark_current_e_per_s"] = p.hot_pixel_dark_current_e_per_s;
  nlohmann::json qe;
  qe["wavelength_nm"] = p.qe.wavelength_nm;
  for (auto c : cfa_colors(p.cfa)) {
    std::string k(1, static_cast<char>(std::tolower(to_string(c)[0])));
    qe[k] = p.qe.qe[static_cast<int>(c)];
  }
  j["qe"] = qe;
  return j.dump(indent);
}

std::string to_json(const LensPreset& l, int indent) {
  return nlohmann::json{{"name", l.name},           {"file", l.file},
          {"description", l.description}, {"f_number", l.f_number},
          {"focal_length_mm", l.focal_length_mm}, {"transmittance", l.transmittance},
          {"magnification", l.magnification}, {"cos4_falloff", l.cos4_falloff},
          {"glare", l.glare.enabled ? nlohmann::json{{"veiling_glare_index", l.glare.veiling_glare_index},
                                                      {"core_deg", l.glare.core_deg},
                                                      {"reach_deg", l.glare.reach_deg},
                                                      {"skirt_exponent", l.glare.skirt_exponent}}
                                    : nlohmann::json(nullptr)}}.dump(indent);
}

}  // namespace photosite
