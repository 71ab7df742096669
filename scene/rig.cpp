// Camera rig presets (see rig.h).
#include "photosite/scene/rig.h"

#include <cmath>
#include <filesystem>

#include "core/toml_schema_detail.h"
#include "photosite/error.h"
#include "photosite/sensor/preset.h"

namespace photosite::scene {

// kPitchToleranceDeg (rig.h): how far a car-mounted camera's pitch to the road it stands on strays
// from its calibrated nominal pitch. The camera is bolted to the body, so it is the body's pitch
// on its suspension (stated physical limits; [U]: figures from general knowledge, not in
// /work/shared):
//  1. Load. ECE R48 §6.2.6.1 keeps a car's dipped-beam inclination within −0.5 % … −2.5 % over
//     the loading states of its Annex 5 (driver only to fully laden) [U]: the body pitch the load
//     causes spans at most 2 % = 1.15°; the calibration lies inside that span, so ±0.57° about it.
//  2. Braking and acceleration. Weight transfer ΔF = m·a·h_cg/L compresses the front wheel
//     springs (rate k each) by ΔF/2k and extends the rear ones as much: θ = ΔF/(k·L) =
//     m·a·h_cg/(k·L²) (no anti-dive geometry: an upper bound). Passenger car m = 1500 kg, h_cg =
//     0.55 m, wheelbase L = 2.7 m, wheel rate k = (m/4)·(2π·1.2 Hz)² = 21.3 kN/m (ride frequency
//     1–1.5 Hz, Gillespie, Fundamentals of Vehicle Dynamics, 1992, ch. 5 [U]) → 0.30° per m/s².
//     At AASHTO's design deceleration 3.4 m/s² (A Policy on Geometric Design of Highways and
//     Streets, 2011, §3.2.2: most drivers brake harder than this only in emergencies [U]): 1.03°.
//  Sum: 0.57 + 1.03 = 1.6°. Not included: emergency stops (8 m/s²: 2.4°), rare in recorded
//  frames; and road grade: on a constant grade the car pitches with the road (no change relative
//  to it), while a change of grade ahead bends the road away from the one plane of the flat-ground
//  model, which no single horizon fixes. A vanishing point 2° off the nominal pitch (aachen_000003
//  of the shared frames: horizon 345.5 px against the rig's 427 px at f 2262 px) is therefore a
//  mis-detection, not the camera's pitch.
static_assert(kPitchToleranceDeg > 0);

namespace {
using schema::Kind;
using schema::Need;
constexpr double inf = schema::kUnbounded;
// The rig's keys, read by the one preset reader (core/toml_schema_detail.h).
const std::vector<schema::Param<CameraRig>>& rig_schema() {
  using P = CameraRig;
  static const std::vector<schema::Param<P>> rows{
      {"description", Kind::Text, PHOTOSITE_AT(P, description), "", -inf, inf, Need::Optional,
       "one line", "free text"},
      {"native_width_px", Kind::Number, PHOTOSITE_AT(P, native_width_px), "px", 16, 65536, Need::Required,
       "image width the intrinsics refer to", "data set calibration"},
      {"native_height_px", Kind::Number, PHOTOSITE_AT(P, native_height_px), "px", 16, 65536, Need::Required,
       "image height the intrinsics refer to", "data set calibration"},
      {"fx_px", Kind::Number, PHOTOSITE_AT(P, fx_px), "px", 1, 1e6, Need::Required, "pinhole focal length",
       "data set calibration"},
      {"cx_px", Kind::Number, PHOTOSITE_AT(P, cx_px), "px", -1e5, 1e5, Need::Required, "principal point x",
       "data set calibration"},
      {"cy_px", Kind::Number, PHOTOSITE_AT(P, cy_px), "px", -1e5, 1e5, Need::Required, "principal point y",
       "data set calibration"},
      {"mount_height_m", Kind::Number, PHOTOSITE_AT(P, mount_height_m), "m", 0.1, 50, Need::Required,
       "optical centre above the road", "data set paper"},
      {"pitch_deg", Kind::Number, PHOTOSITE_AT(P, pitch_deg), "°", -30, 30, Need::Required,
       "nominal pitch, positive looking down", "estimate"},
      {"pitch_tolerance_deg", Kind::Number, PHOTOSITE_AT(P, pitch_tolerance_deg), "°", 0, 30, Need::Optional,
       "largest |VP pitch − pitch_deg| accepted (default 1.6: passenger car, load + service braking)",
       "scene/rig.cpp derivation"},
  };
  return rows;
}
std::filesystem::path rig_dir() { return std::filesystem::path(preset_dir()) / "rigs"; }
}  // namespace

CameraRig parse_camera_rig(const std::string& text, const std::string& file) {
  const toml::table t = schema::parse_toml(text, file);
  CameraRig r;
  r.file = file;
  r.name = std::filesystem::path(file).stem().string();
  schema::read<CameraRig>(t, rig_schema(), file, r);
  return r;
}

CameraRig load_camera_rig(const std::string& name_or_path) {
  if (name_or_path.ends_with(".json")) return load_cityscapes_camera(name_or_path);
  const auto path = schema::preset_file(rig_dir(), name_or_path);
  if (!path)
    fail("--rig: unknown camera rig '" + name_or_path + "' (bundled: " + schema::comma_list(bundled_rigs()) +
         ", or auto, or a .toml path, or a Cityscapes camera .json)");
  return parse_camera_rig(schema::read_text(*path, "camera rig"), *path);
}

std::vector<std::string> bundled_rigs() { return schema::preset_names(rig_dir()); }

CameraRig rig_for_image(int width, int height) {
  const auto names = bundled_rigs();
  if (names.empty()) fail_at(rig_dir().string(), "no camera rig presets (*.toml) found");
  const double a = static_cast<double>(width) / height;
  CameraRig best;
  double best_d = 1e300;
  for (const auto& n : names) {
    CameraRig r = load_camera_rig(n);
    const double d = std::fabs(std::log(a * r.native_height_px / r.native_width_px));
    if (d < best_d) { best_d = d; best = r; }
  }
  return best;
}

CameraRig resolve_camera_rig(const std::string& flag, int width, int height, const std::string& image_path) {
  if (flag.empty() || flag == "auto") {
    if (const std::string cam = cityscapes_camera_file(image_path); !cam.empty()) return load_cityscapes_camera(cam);
    return rig_for_image(width, height);
  }
  return load_camera_rig(flag);
}

CameraIntrinsics scaled_intrinsics(const CameraRig& r, int width, int height) {
  const double aspect = static_cast<double>(width) / height;
  const double native = r.native_width_px / r.native_height_px;
  if (std::fabs(aspect / native - 1) <= 0.01) {
    const double s = width / r.native_width_px;
    // Pixel centres: a resize maps x+0.5 to (x+0.5)·s.
    return {r.fx_px * s, (r.cx_px + 0.5) * s - 0.5, (r.cy_px + 0.5) * s - 0.5};
  }
  return {r.fx_px, r.cx_px - 0.5 * (r.native_width_px - width), r.cy_px - 0.5 * (r.native_height_px - height)};
}

std::string camera_rigs_doc_markdown() { return schema::markdown_table(schema::doc_rows<CameraRig>(rig_schema())); }

std::string to_json(const CameraRig& r, int indent) {
  nlohmann::json j = schema::to_json<CameraRig>(rig_schema(), r);
  j["name"] = r.name;
  j["file"] = r.file;
  return j.dump(indent);
}

}  // namespace photosite::scene
