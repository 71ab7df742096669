// Camera rigs: what a road camera needs beyond the camera and lens presets to put the scene in
// metres: the intrinsics in pixels at the data set's native image size, the mounting height above
// the road and the nominal pitch. presets/rigs/<name>.toml, every number with its source; unknown
// or missing keys and out-of-range values are errors naming file and line.
#pragma once
#include <optional>
#include <string>
#include <vector>

namespace photosite::scene {

// The default pitch tolerance of a camera fixed to a passenger car (derivation in scene/rig.cpp):
// body pitch under load (0.57°) plus under service braking (1.03°).
inline constexpr double kPitchToleranceDeg = 1.6;

struct CameraRig {
  std::string name, file, description;
  double native_width_px = 0, native_height_px = 0;  // the image size the intrinsics refer to
  double fx_px = 0, cx_px = 0, cy_px = 0;            // pinhole focal length and principal point
  double mount_height_m = 0;                         // optical centre above the road
  double pitch_deg = 0;                              // nominal pitch, positive looking down
  // How far the camera's actual pitch to the road under it may stray from pitch_deg while
  // driving: a vanishing-point horizon further off than this is a mis-detection (camera_geometry
  // falls back to the nominal pitch). Default kPitchToleranceDeg (rig.cpp derives it).
  double pitch_tolerance_deg = kPitchToleranceDeg;
  // Where the camera sits on its vehicle, in the vehicle frame of ISO 8855 (x forward, y left,
  // z up; Cityscapes: the origin on the ground below the rear axle's centre): its place ahead of
  // (x) and left of (y) that origin in m, and its heading against the vehicle's in rad (yaw about
  // z, positive turned to the left). A Cityscapes camera file's extrinsic x, y and yaw
  // (parse_cityscapes_camera); absent in the rig presets and in camera files without those keys.
  // `batch --sequence` places the camera on the odometry's path with them (scene/ego_motion.h).
  std::optional<double> mount_forward_m, mount_left_m, mount_yaw_rad;
};

CameraRig parse_camera_rig(const std::string& toml_text, const std::string& file);
// A name in presets/rigs, a .toml path, or a Cityscapes camera .json path.
CameraRig load_camera_rig(const std::string& name_or_path);
std::vector<std::string> bundled_rigs();                     // names in presets/rigs, sorted
// `--rig auto`: the bundled rig whose native aspect ratio is nearest the image's (KITTI 3.31,
// Cityscapes 2.0); ties go to the first name.
CameraRig rig_for_image(int width, int height);
// `--rig` value: "auto" (rig_for_image), a bundled name, a .toml path or a Cityscapes camera
// .json. With "auto" and an image path in the Cityscapes layout whose camera file exists
// (cityscapes_camera_file), that image's own calibration.
CameraRig resolve_camera_rig(const std::string& flag, int width, int height, const std::string& image_path = {});

// Cityscapes' per-image calibration (camera/<split>/<city>/<stem>_camera.json: extrinsic z and
// pitch, intrinsic fx, u0, v0; extrinsic x, y, yaw where the file has them) as a rig of the
// 2048x1024 leftImg8bit frames (scene/rig_json.cpp). Bad input (file: key: problem) on a missing
// key, a non-number or a value outside the rig schema's ranges (x, y within 20 m of the vehicle's
// reference point; |yaw| <= 0.5 rad).
CameraRig parse_cityscapes_camera(const std::string& json_text, const std::string& file);
CameraRig load_cityscapes_camera(const std::string& path);
// The camera file of an image in the Cityscapes layout (leftImg8bit[_sequence]/<split>/<city>/
// <stem>_leftImg8bit.png → camera/<split>/<city>/<stem>_camera.json) when it exists, else "".
std::string cityscapes_camera_file(const std::string& image_path);

// The rig's intrinsics at an image of width x height. An image of the native aspect ratio (within
// 1%) is taken as resized: fx, cx, cy scale by width / native width. Another aspect ratio is taken
// as a centred crop of the native frame: fx unchanged, the principal point shifted by half the
// size difference. (Which of the two happened cannot be told from the image; named approximation.)
struct CameraIntrinsics { double f_px, cx_px, cy_px; };
CameraIntrinsics scaled_intrinsics(const CameraRig& rig, int width, int height);

// The Markdown reference table of the rig keys (part of `presets_doc_markdown()`).
std::string camera_rigs_doc_markdown();
// `presets show`'s JSON text of a rig (keys as in its TOML file, plus name and file).
std::string to_json(const CameraRig& r, int indent = -1);

}  // namespace photosite::scene
