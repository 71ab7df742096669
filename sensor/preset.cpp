// Preset loading in the spirit of pbrt-v4's PixelSensor::Create + ReportUnused: every key is
// declared once with its range; anything else in the file is an error with file, line and key.
#include "photosite/sensor/preset.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "photosite/checksum.h"
#include "photosite/environment.h"
#include "core/toml_schema_detail.h"
#include "photosite/error.h"
#include "photosite/scene/rig.h"
#include "photosite/scene/scene_preset.h"
#include "photosite/sensor/spectrum.h"

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

using schema::Exr;
using schema::Kind;
using schema::Need;
using schema::Param;
constexpr double inf = schema::kUnbounded;

// The camera preset's keys. The ranges are physical plausibility bounds, not sensor-class limits;
// cross-key conditions are checked by validate(). A default is the initialiser in CameraPreset.
const std::vector<Param<CameraPreset>>& camera_schema() {
  using P = CameraPreset;
  static const std::vector<Param<P>> rows{
      {"description", Kind::Text, PHOTOSITE_AT(P, description), "", -inf, inf, Need::Optional,
       "one line, shown by `presets list`", "free text"},
      {"default_lens", Kind::Text, PHOTOSITE_AT(P, default_lens), "", -inf, inf, Need::Optional,
       "lens preset used when `--lens` is not given", "the camera's documented or typical lens"},
      {"cfa", Kind::Choice,
       schema::Choice<P>{[](P& p, const std::string& s) { p.cfa = parse_cfa(s); },
                         [](const P& p) -> std::string { return to_string(p.cfa); }, "RGGB, BGGR, GRBG, GBRG, RCCB, RCCC, MONO"},
       "", -inf, inf, Need::Required, "top-left 2×2 filter cell, row by row", "datasheet", {}, Exr::Header},
      {"width_px", Kind::Integer, PHOTOSITE_AT(P, width_px), "px", 1, 100000, Need::Required,
       "native active array width", "datasheet"},
      {"height_px", Kind::Integer, PHOTOSITE_AT(P, height_px), "px", 1, 100000, Need::Required,
       "native active array height", "datasheet"},
      {"bit_depth", Kind::Integer, PHOTOSITE_AT(P, bit_depth), "bit", 1, 24, Need::Required, "ADC resolution",
       "datasheet", {}, Exr::Header},
      {"pixel_pitch_um", Kind::Number, PHOTOSITE_AT(P, pixel_pitch_um), "µm", 0.1, 100, Need::Required,
       "pixel pitch", "datasheet"},
      {"fill_factor", Kind::Number, PHOTOSITE_AT(P, fill_factor), "fraction", 0.01, 1.0, Need::Optional,
       "collecting fraction of the pixel area", "usually absorbed into the QE (microlenses: ~1)"},
      {"full_well_e", Kind::Number, PHOTOSITE_AT(P, full_well_e), "e⁻", 1, 1e8, Need::Required,
       "saturation capacity of the photodiode", "EMVA 1288 saturation capacity", "> read_noise_e"},
      {"system_gain_dn_per_e", Kind::Number, PHOTOSITE_AT(P, system_gain_dn_per_e), "DN/e⁻", 1e-6, 1e3,
       Need::Required, "overall system gain K at 0 dB analog gain", "EMVA 1288 K (photon transfer)"},
      {"max_gain_db", Kind::Number, PHOTOSITE_AT(P, max_gain_db), "dB", 0, 60, Need::Optional,
       "upper limit of `--gain-db`", "datasheet"},
      {"read_noise_e", Kind::Number, PHOTOSITE_AT(P, read_noise_e), "e⁻ rms", 0, 1e4, Need::Required,
       "temporal dark noise σ", "EMVA 1288 temporal dark noise"},
      {"read_noise_tukey_lambda", Kind::Number, PHOTOSITE_AT(P, read_noise_tukey_lambda), "—", -0.5, 0.5,
       Need::Optional, "0: Gaussian; else Tukey-λ shape (normalised to σ; heavy tail < 0)",
       "Wei et al. 2020 (ELD) noise calibration"},
      {"dark_current_e_per_s", Kind::Number, PHOTOSITE_AT(P, dark_current_e_per_s), "e⁻/s", 0, 1e7,
       Need::Required, "mean dark current at the reference temperature", "EMVA 1288 dark current"},
      {"dark_current_reference_c", Kind::Number, PHOTOSITE_AT(P, dark_current_reference_c), "°C", -100, 200,
       Need::Optional, "temperature at which dark_current_e_per_s holds", "datasheet condition"},
      {"dark_current_doubling_c", Kind::Number, PHOTOSITE_AT(P, dark_current_doubling_c), "°C", 1, 50,
       Need::Optional, "temperature step that doubles the dark current",
       "EMVA 1288 doubling temperature; 6.5 °C typical of silicon (an estimate)"},
      {"dark_current_nonuniformity_percent", Kind::Number, PHOTOSITE_AT(P, dark_current_nonuniformity_percent),
       "%", 0, 1000, Need::Required, "coefficient of variation of the per-pixel dark rate", "EMVA 1288 DSNU of dark current"},
      {"dsnu_e", Kind::Number, PHOTOSITE_AT(P, dsnu_e), "e⁻", 0, 1e5, Need::Required,
       "offset fixed-pattern σ (exposure independent)", "EMVA 1288 DSNU"},
      {"prnu_percent", Kind::Number, PHOTOSITE_AT(P, prnu_percent), "%", 0, 50, Need::Required,
       "σ of the per-pixel gain", "EMVA 1288 PRNU"},
      {"black_level_dn", Kind::Number, PHOTOSITE_AT(P, black_level_dn), "DN", 0, inf, Need::Required,
       "pedestal added before the ADC clip", "datasheet or camera register", "< 2^bit_depth − 1", Exr::Header},
      {"temperature_c", Kind::Number, PHOTOSITE_AT(P, temperature_c), "°C", -100, 200, Need::Required,
       "die temperature in operation (`--temperature-c` overrides)", "estimate of the operating point"},
      {"row_noise_e", Kind::Number, PHOTOSITE_AT(P, row_noise_e), "e⁻ rms", 0, 1e4, Need::Optional,
       "temporal row noise σ, 0 = off", "noise calibration (ELD) or estimate"},
      {"column_noise_e", Kind::Number, PHOTOSITE_AT(P, column_noise_e), "e⁻ rms", 0, 1e4, Need::Optional,
       "temporal column noise σ, 0 = off", "noise calibration or estimate"},
      {"hot_pixel_fraction", Kind::Number, PHOTOSITE_AT(P, hot_pixel_fraction), "fraction", 0, 0.1,
       Need::Optional, "share of hot pixels, 0 = off", "dark-frame statistics or estimate"},
      {"hot_pixel_dark_current_e_per_s", Kind::Number, PHOTOSITE_AT(P, hot_pixel_dark_current_e_per_s), "e⁻/s",
       0, 1e8, Need::Optional, "hot pixels' mean dark rate at the reference temperature",
       "dark-frame statistics or estimate"},
      {"qe", Kind::Table, {}, "", -inf, inf, Need::Required, "quantum efficiency per filter colour",
       "EMVA 1288 QE where measured, else modelled (scripts/model_qe.py)"},
      {"qe.wavelength_nm", Kind::NumberList, PHOTOSITE_AT(P, qe.wavelength_nm), "nm", 0, inf, Need::Required,
       "the QE grid", "", "increasing, ≥ 2 values, from ≤ 400 to ≥ 700 (the radiance basis's range)"},
      {"qe.r", Kind::NumberList, PHOTOSITE_AT(P, qe.qe[0]), "fraction", 0, 1, Need::Optional,
       "QE of the red filter on the grid", "", "where the CFA has R; one value per wavelength"},
      {"qe.g", Kind::NumberList, PHOTOSITE_AT(P, qe.qe[1]), "fraction", 0, 1, Need::Optional,
       "QE of the green filter on the grid", "", "where the CFA has G; one value per wavelength"},
      {"qe.b", Kind::NumberList, PHOTOSITE_AT(P, qe.qe[2]), "fraction", 0, 1, Need::Optional,
       "QE of the blue filter on the grid", "", "where the CFA has B; one value per wavelength"},
      {"qe.c", Kind::NumberList, PHOTOSITE_AT(P, qe.qe[3]), "fraction", 0, 1, Need::Optional,
       "QE of the clear filter on the grid", "", "where the CFA has C; one value per wavelength"},
  };
  return rows;
}

// The lens preset's keys. [glare] is the veiling-glare PSF of sensor/glare.h (docs/model_glare.md).
const std::vector<Param<LensPreset>>& lens_schema() {
  using P = LensPreset;
  static const std::vector<Param<P>> rows{
      {"description", Kind::Text, PHOTOSITE_AT(P, description), "", -inf, inf, Need::Optional,
       "one line, shown by `presets list`", "free text"},
      {"f_number", Kind::Number, PHOTOSITE_AT(P, f_number), "—", 0.5, 64, Need::Required,
       "default aperture (`--f-number` overrides)", "lens datasheet"},
      {"focal_length_mm", Kind::Number, PHOTOSITE_AT(P, focal_length_mm), "mm", 0.5, 2000, Need::Required,
       "for the cos⁴ falloff and the glare's pixels per degree", "lens datasheet or camera intrinsics"},
      {"transmittance", Kind::Number, PHOTOSITE_AT(P, transmittance), "fraction", 0.01, 1.0, Need::Required,
       "lens + IR-cut filter (+ windscreen)", "usually an estimate"},
      {"magnification", Kind::Number, PHOTOSITE_AT(P, magnification), "—", 0, 10, Need::Optional,
       "|m| in the camera equation, ≈0 for road scenes", "geometry"},
      {"cos4_falloff", Kind::Boolean, PHOTOSITE_AT(P, cos4_falloff), "", -inf, inf, Need::Optional,
       "natural vignetting cos⁴θ", "the camera equation"},
      {"glare", Kind::Table, PHOTOSITE_AT(P, glare.enabled), "", -inf, inf, Need::Optional,
       "the lens's veiling-glare PSF (docs/model_glare.md); absent: no glare",
       "no lens measured: the bundled values are estimates"},
      {"glare.veiling_glare_index", Kind::Number, PHOTOSITE_AT(P, glare.veiling_glare_index), "fraction", 0, 0.5,
       Need::Required, "η, share of the image-plane flux in the skirt", "ISO 9358:1994 veiling glare index"},
      {"glare.core_deg", Kind::Number, PHOTOSITE_AT(P, glare.core_deg), "°", 1e-3, 10, Need::Required,
       "θ0, where the skirt flattens", "CIE 146:2002 glare function starts at 0.1°"},
      {"glare.reach_deg", Kind::Number, PHOTOSITE_AT(P, glare.reach_deg), "°", 0.01, 180, Need::Required,
       "where the power law ends", "photosite's choice", "> glare.core_deg"},
      {"glare.skirt_exponent", Kind::Number, PHOTOSITE_AT(P, glare.skirt_exponent), "—", 1, 4, Need::Optional,
       "p in S ∝ (θ² + θ0²)^(−p/2)", "CIE 146:2002 / Vos (eye), assumed for the lens"},
  };
  return rows;
}

std::string read_text(const std::string& path) {
  // A folder opens as a stream of no bytes: it was read as an empty preset ("cfa: required key is
  // missing", presets show /tmp).
  if (std::error_code ec; fs::is_directory(path, ec)) fail_at(path, "is a folder, not a preset file");
  std::ifstream f(path);
  if (!f) fail_at(path, "cannot open preset file");
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

// kind: the presets' folder ("cameras" or "lenses"); singular: its entries' kind as list_presets
// names it ("camera", "lens").
std::string resolve_preset_path(const std::string& name_or_path, const std::string& kind, const std::string& singular) {
  std::error_code ec;
  if (name_or_path.find('/') != std::string::npos || name_or_path.ends_with(".toml")) {
    if (!fs::exists(name_or_path, ec)) fail_missing(name_or_path, "no such preset file");
    return name_or_path;
  }
  fs::path p = fs::path(preset_dir()) / kind / (name_or_path + ".toml");
  if (fs::exists(p, ec)) return p.string();
  schema::fail_if_dangling(p.string());
  // The bundled ones of this kind, as the scene presets' error lists them: the folder's preset
  // files (no folder or link to nothing), sorted.
  fail("unknown " + singular + " preset '" + name_or_path + "' (bundled: " +
       schema::comma_list(schema::preset_names(fs::path(preset_dir()) / kind)) + ")");
}

}  // namespace

namespace {
std::string text_checksum(const std::string& text) {
  Checksum c(ChecksumAlgorithm::Xxh3_64);
  c.update(text.data(), text.size());
  return c.hex();
}
}  // namespace

std::string preset_dir() {
  if (auto e = env::get(env::Var::PresetDir)) {
    std::error_code ec;
    if (!fs::is_directory(*e, ec)) fail("PHOTOSITE_PRESET_DIR=" + *e + ": no such folder (it names the folder of the presets)");
    return *e;
  }
  return (fs::path(data_dir()) / "presets").string();
}

CameraPreset parse_camera_preset(const std::string& text, const std::string& file) {
  const toml::table t = schema::parse_toml(text, file);
  CameraPreset p;
  p.file = file;
  p.name = fs::path(file).stem().string();
  p.text_xxh3_64 = text_checksum(text);
  schema::read<CameraPreset>(t, camera_schema(), file, p);
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
  // expose integrates each radiance band over its box (include/photosite/sensor/spectrum.h): a
  // grid that stops short of the basis would take QE = 0 beyond it without a word.
  const double need_lo = std::min({spectrum::kBandLoNm[0], spectrum::kBandLoNm[1], spectrum::kBandLoNm[2]});
  const double need_hi = std::max({spectrum::kBandHiNm[0], spectrum::kBandHiNm[1], spectrum::kBandHiNm[2]});
  if (wl.front() > need_lo || wl.back() < need_hi)
    fail(where(f, 0, "qe.wavelength_nm") +
         fmt::format(": the grid covers {} to {} nm, but the radiance basis needs QE from {} to {} nm "
                     "(expose integrates every band over it; outside the grid QE would be taken as 0)",
                     wl.front(), wl.back(), need_lo, need_hi));
  for (auto c : cfa_colors(p.cfa)) {
    const auto& q = p.qe.qe[static_cast<int>(c)];
    const std::string key = std::string("qe.") + static_cast<char>(std::tolower(to_string(c)[0]));
    if (q.empty()) fail(where(f, 0, key) + ": the CFA " + to_string(p.cfa) + " needs this QE curve");
    if (q.size() != wl.size())
      fail(where(f, 0, key) + fmt::format(": has {} values but qe.wavelength_nm has {}", q.size(), wl.size()));
  }
  // The device store keeps each pixel's dark rate as a factor of the mean rate (fpn.cpp), so hot
  // pixels need a mean dark current to be a factor of: with none they would vanish silently.
  if (p.hot_pixel_fraction > 0 && p.hot_pixel_dark_current_e_per_s > 0 && !(p.dark_current_e_per_s > 0))
    fail(where(f, 0, "dark_current_e_per_s") +
         fmt::format(": hot pixels ({} of the pixels at {} e-/s) need a mean dark current above 0 (the stored map "
                     "keeps each pixel's rate as a factor of it); give the array's mean dark current",
                     p.hot_pixel_fraction, p.hot_pixel_dark_current_e_per_s));
  if (p.full_well_e <= p.read_noise_e)
    fail(where(f, 0, "full_well_e") + fmt::format(": full well {} e- is not above the read noise {} e-",
                                                  p.full_well_e, p.read_noise_e));
  const double max_code = std::ldexp(1.0, p.bit_depth) - 1;
  if (p.black_level_dn >= max_code)
    fail(where(f, 0, "black_level_dn") + fmt::format(": {} DN leaves no range below the {}-bit maximum {}",
                                                     p.black_level_dn, p.bit_depth, max_code));
}

LensPreset parse_lens_preset(const std::string& text, const std::string& file) {
  const toml::table t = schema::parse_toml(text, file);
  LensPreset l;
  l.file = file;
  l.name = fs::path(file).stem().string();
  l.text_xxh3_64 = text_checksum(text);
  schema::read<LensPreset>(t, lens_schema(), file, l);
  const LensGlare& lg = l.glare;
  if (lg.enabled && !(lg.reach_deg > lg.core_deg))
    schema::key_error(file, schema::line_of(*t.get("glare")), "glare.reach_deg",
                      fmt::format("reach {} deg must exceed the core {} deg", lg.reach_deg, lg.core_deg));
  return l;
}

CameraPreset load_camera_preset(const std::string& name_or_path) {
  std::string path = resolve_preset_path(name_or_path, "cameras", "camera");
  return parse_camera_preset(read_text(path), path);
}

LensPreset load_lens_preset(const std::string& name_or_path) {
  std::string path = resolve_preset_path(name_or_path, "lenses", "lens");
  return parse_lens_preset(read_text(path), path);
}

std::vector<PresetEntry> list_presets() {
  std::vector<PresetEntry> out;
  const std::pair<const char*, const char*> kinds[] = {
      {"cameras", "camera"}, {"lenses", "lens"}, {"scenes", "scene"}, {"rigs", "rig"}};
  for (const auto& [kind, singular] : kinds) {
    fs::path dir = fs::path(preset_dir()) / kind;
    std::error_code ec;
    if (!fs::is_directory(dir, ec)) continue;
    std::vector<PresetEntry> group;
    for (const auto& e : fs::directory_iterator(dir)) {
      if (e.path().extension() != ".toml") continue;
      PresetEntry pe{e.path().stem().string(), singular, "", e.path().string()};
      // A folder of that name was listed with no description, and a link to nothing as
      // "(malformed)": each is now named for what it is.
      std::error_code fe;
      if (!e.is_regular_file(fe)) {
        pe.preset_file = false;
        pe.description = std::string("(not a preset file: ") +
                         (e.is_directory(fe) ? "a folder)" : e.is_symlink(fe) ? "a symbolic link to nothing)" : "not a regular file)");
        group.push_back(pe);
        continue;
      }
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
  nlohmann::json j = schema::to_json<CameraPreset>(camera_schema(), p);
  j["name"] = p.name;
  j["file"] = p.file;
  return j.dump(indent);
}

std::string to_json(const LensPreset& l, int indent) {
  nlohmann::json j = schema::to_json<LensPreset>(lens_schema(), l);
  j["name"] = l.name;
  j["file"] = l.file;
  return j.dump(indent);
}

std::map<std::string, ExrAttribute> camera_attributes(const CameraPreset& p) {
  return schema::attributes<CameraPreset>(camera_schema(), p, "photosite/");
}

std::string presets_doc_markdown() {
  return "### Camera keys (`presets/cameras/*.toml`)\n\n" +
         schema::markdown_table(schema::doc_rows<CameraPreset>(camera_schema())) +
         "\n### Lens keys (`presets/lenses/*.toml`)\n\n" +
         schema::markdown_table(schema::doc_rows<LensPreset>(lens_schema())) +
         "\n### Scene keys (`presets/scenes/*.toml`)\n\n" + scene::scene_presets_doc_markdown() +
         "\n### Camera rig keys (`presets/rigs/*.toml`)\n\n" + scene::camera_rigs_doc_markdown();
}

}  // namespace photosite
