// Cityscapes' own per-image camera calibration as a camera rig (see rig.h).
//
// The Cityscapes package camera_trainvaltest ships one file per image,
// <root>/camera/<split>/<city>/<city>_<seq>_<frame>_camera.json (x, y, yaw: the camera's place
// and heading in the vehicle frame of ISO 8855, csCalibration.pdf §3):
//   {"extrinsic": {"baseline": m, "pitch": rad, "roll": rad, "x": m, "y": m, "yaw": rad, "z": m},
//    "intrinsic": {"fx": px, "fy": px, "u0": px, "v0": px}}
// (Cordts et al., CVPR 2016, and the data set's README). z is the camera's height above the road
// and pitch its rotation about the lateral axis, positive looking down: for the stuttgart camera
// (pitch 0.038 rad, z 1.22 m) the Cityscapes 3D matrix sensor_T_ISO_8855 of the same camera has
// R[0][2] = −0.038 and places the optical centre 1.220 m above the ground. The intrinsics refer to
// the 2048×1024 leftImg8bit frames.
#include <cmath>
#include <filesystem>
#include <numbers>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "core/toml_schema_detail.h"
#include "photosite/error.h"
#include "photosite/scene/rig.h"
#include "scene/data_file_detail.h"

namespace photosite::scene {
namespace fs = std::filesystem;

namespace {
constexpr int kCityscapesWidthPx = 2048, kCityscapesHeightPx = 1024;  // leftImg8bit frames

const nlohmann::json& group_of(const nlohmann::json& j, const char* group, const std::string& file) {
  if (!j.contains(group) || !j[group].is_object()) fail_at(file, std::string("no \"") + group + "\" object (a Cityscapes camera file has extrinsic and intrinsic)");
  return j[group];
}
double number_at(const nlohmann::json& j, const char* group, const char* key, double lo, double hi,
                 const char* unit, const std::string& file) {
  return detail::json_number_in_range(group_of(j, group, file), key, std::string(group) + "." + key, lo, hi, unit, file);
}
// A key the file may leave out: absent, none; present, as number_at.
std::optional<double> optional_number_at(const nlohmann::json& j, const char* group, const char* key, double lo,
                                         double hi, const char* unit, const std::string& file) {
  if (!group_of(j, group, file).contains(key)) return std::nullopt;
  return number_at(j, group, key, lo, hi, unit, file);
}
}  // namespace

CameraRig parse_cityscapes_camera(const std::string& text, const std::string& file) {
  const nlohmann::json j = nlohmann::json::parse(text, nullptr, false);
  if (j.is_discarded() || !j.is_object()) fail_at(file, "not a JSON object (expected a Cityscapes camera file)");
  CameraRig r;
  r.file = file;
  r.name = fs::path(file).stem().string();
  r.description = "Cityscapes camera file";
  r.native_width_px = kCityscapesWidthPx;
  r.native_height_px = kCityscapesHeightPx;
  // The same ranges as the rig presets' schema (scene/rig.cpp), pitch converted from radians.
  r.fx_px = number_at(j, "intrinsic", "fx", 1, 1e6, "px", file);
  r.cx_px = number_at(j, "intrinsic", "u0", -1e5, 1e5, "px", file);
  r.cy_px = number_at(j, "intrinsic", "v0", -1e5, 1e5, "px", file);
  r.mount_height_m = number_at(j, "extrinsic", "z", 0.1, 50, "m", file);
  const double pitch_rad = number_at(j, "extrinsic", "pitch", -30 * std::numbers::pi / 180, 30 * std::numbers::pi / 180, "rad", file);
  r.pitch_deg = pitch_rad * 180 / std::numbers::pi;
  // The camera's place on the vehicle (ISO 8855, the origin below the rear axle's centre), within
  // detail::kMaxCameraLever_m and kMaxCameraYaw_rad (scene/data_file_detail.h).
  using detail::kMaxCameraLever_m, detail::kMaxCameraYaw_rad;
  r.mount_forward_m = optional_number_at(j, "extrinsic", "x", -kMaxCameraLever_m, kMaxCameraLever_m, "m", file);
  r.mount_left_m = optional_number_at(j, "extrinsic", "y", -kMaxCameraLever_m, kMaxCameraLever_m, "m", file);
  r.mount_yaw_rad = optional_number_at(j, "extrinsic", "yaw", -kMaxCameraYaw_rad, kMaxCameraYaw_rad, "rad", file);
  return r;
}

std::string cityscapes_camera_file(const std::string& image_path) {
  // .../leftImg8bit[_sequence]/<split>/<city>/<stem>_leftImg8bit.<ext> →
  // .../camera/<split>/<city>/<stem>_camera.json, when the data set has it.
  const fs::path p(image_path);
  const std::string name = p.filename().string();
  const std::string tag = "_leftImg8bit";
  const auto at = name.rfind(tag);
  if (at == std::string::npos) return {};
  const std::string stem = name.substr(0, at);
  const fs::path city = p.parent_path(), split = city.parent_path(), top = split.parent_path();
  const std::string top_name = top.filename().string();
  if (top_name != "leftImg8bit" && top_name != "leftImg8bit_sequence") return {};
  const fs::path cam = top.parent_path() / "camera" / split.filename() / city.filename() / (stem + "_camera.json");
  std::error_code ec;
  return fs::is_regular_file(cam, ec) ? cam.string() : std::string();
}

CameraRig load_cityscapes_camera(const std::string& path) {
  return parse_cityscapes_camera(schema::read_text(path, "camera file"), path);
}

}  // namespace photosite::scene
