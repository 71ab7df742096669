// Camera and lens presets: TOML files in presets/cameras and presets/lenses, every number with
// its unit in the key name and its source in a comment. Each kind's keys are declared once, in a
// schema table in sensor/preset.cpp (core/toml_schema_detail.h): it drives the reader, to_json
// and the docs. Unknown keys, missing keys and out-of-range values are errors
// "file:line: key: problem" (pbrt-v4's ReportUnused idea).
#pragma once
#include <array>
#include <map>
#include <string>
#include <vector>

#include "photosite/io.h"
#include "photosite/sensor/cfa.h"
#include "photosite/sensor/glare.h"

namespace photosite {

// Quantum efficiency per filter colour, tabulated on one wavelength grid (nm). A colour the
// pattern does not use has an empty table.
struct QeTable {
  std::vector<double> wavelength_nm;
  std::array<std::vector<double>, 4> qe;  // indexed by FilterColor; fraction 0..1
  double at(FilterColor c, double wavelength_nm) const;  // linear interpolation, 0 outside
};

struct CameraPreset {
  std::string name;         // file stem, e.g. "onsemi-ar0331"
  std::string file;         // where it was loaded from
  std::string text_xxh3_64; // XXH3-64 of the file's text (16 hex digits): an edited copy of a bundled
                            // preset keeps its name, not this (outputs record both)
  std::string description;  // free text
  std::string default_lens; // lens preset name, may be empty
  CfaPattern cfa = CfaPattern::RGGB;
  int width_px = 0, height_px = 0;  // native active array
  int bit_depth = 12;
  double pixel_pitch_um = 0;
  double fill_factor = 1.0;         // fraction of pixel area that collects (microlenses: ~1)
  double full_well_e = 0;
  double system_gain_dn_per_e = 0;  // K at 0 dB analog gain
  double max_gain_db = 24;
  double read_noise_e = 0;          // temporal dark noise, σ in e-
  double read_noise_tukey_lambda = 0;  // 0: Gaussian; else Tukey-lambda shape (heavy tail < 0)
  double dark_current_e_per_s = 0;  // mean, at dark_current_reference_c
  double dark_current_reference_c = 25;
  double dark_current_doubling_c = 6.5;
  double dark_current_nonuniformity_percent = 0;  // σ/mean of the per-pixel dark rate
  double dsnu_e = 0;                // offset fixed-pattern σ in e- (independent of exposure)
  double prnu_percent = 0;          // σ of the per-pixel gain, percent
  double black_level_dn = 0;
  double temperature_c = 25;        // operating die temperature
  double row_noise_e = 0, column_noise_e = 0;    // temporal, σ in e-, 0 = off
  double hot_pixel_fraction = 0;                 // fraction of pixels that are hot, 0 = off
  double hot_pixel_dark_current_e_per_s = 0;     // their mean rate at the reference temperature
  QeTable qe;
};

struct LensPreset {
  std::string name, file, description;
  std::string text_xxh3_64;  // XXH3-64 of the file's text, as CameraPreset's
  double f_number = 2.0;
  double focal_length_mm = 6.0;
  double transmittance = 0.9;  // lens + IR-cut filter, fraction
  double magnification = 0.0;  // |m|, ~0 for scenes at distance
  bool cos4_falloff = true;    // natural vignetting cos⁴θ
  LensGlare glare;             // [glare]: veiling glare PSF (sensor/glare.h); absent: none
};

// name_or_path: a bundled preset's name ("onsemi-ar0331") or a path to a .toml file.
CameraPreset load_camera_preset(const std::string& name_or_path);
LensPreset load_lens_preset(const std::string& name_or_path);
// Parse from text (file is used only in messages).
CameraPreset parse_camera_preset(const std::string& toml_text, const std::string& file);
LensPreset parse_lens_preset(const std::string& toml_text, const std::string& file);
// Physical sanity checks (also run by the loaders); throw bad-input Errors naming file and key.
void validate(const CameraPreset& p);

// `preset_file` false: the entry is no preset file (a folder named x.toml, a symbolic link to
// nothing), its description saying what it is; such entries are left out of the "bundled: ..."
// lists of the errors. A flag, not the description's text, so no preset's own description can be
// taken for one.
struct PresetEntry {
  std::string name, kind, description, file;
  bool preset_file = true;
};
// The bundled presets: cameras, lenses, scenes, then camera rigs (kind "camera", "lens", "scene",
// "rig"), each kind sorted by name.
std::vector<PresetEntry> list_presets();
std::string preset_dir();  // $PHOTOSITE_PRESET_DIR, else data_dir()/presets (environment.h)

// JSON text (an object, keys sorted); indent as nlohmann::json::dump's: -1 compact, else pretty.
// Text, not a JSON library's type, so that this header pulls in no third-party library.
std::string to_json(const CameraPreset& p, int indent = -1);
std::string to_json(const LensPreset& p, int indent = -1);
// `presets show --json`: the JSON of the bundled preset of that name (camera, lens, scene or rig),
// or of a .toml path (its kind told by its keys).
std::string show_preset(const std::string& name, int indent = -1);
// The reference tables of the camera, lens, scene and camera rig keys (Markdown), generated from
// the same schemas the readers use (sensor/preset.cpp, scene/scene_preset.cpp, scene/rig.cpp);
// `photosite presets doc` prints it, and docs/presets.md holds it between generated-section
// markers (a test compares them).
std::string presets_doc_markdown();
// The camera's keys that an output's EXR header carries (the rows of its schema marked so):
// "photosite/cfa", "photosite/bit_depth", "photosite/black_level_dn".
std::map<std::string, ExrAttribute> camera_attributes(const CameraPreset& p);

}  // namespace photosite
