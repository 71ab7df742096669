// Numbers read from a data set's own files (Cityscapes' camera and vehicle JSON, KITTI raw's text
// records): refused, naming the file and the key, when missing, not a number, or outside the
// range of what the file can hold (scene/rig_json.cpp, scene/ego_motion.cpp, core/batch.cpp's
// manifest fields).
#pragma once
#include <cmath>
#include <string>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "photosite/error.h"

namespace photosite::scene::detail {

// A camera's place on its vehicle: within a vehicle's length of the odometry's reference point;
// its heading along the road within a few degrees (Cityscapes about −0.02 rad, KITTI's camera 2
// 0.001 rad): 0.5 rad (29°) and more is not a forward camera, or another unit (degrees). The
// limits of a Cityscapes camera file's extrinsic x, y, yaw (scene/rig_json.cpp) and of KITTI's
// calibrated camera 2 (scene/ego_motion.cpp).
constexpr double kMaxCameraLever_m = 20, kMaxCameraYaw_rad = 0.5;

// A road vehicle's speed and yaw rate: a value beyond these is a file of another kind or in other
// units (km/h, deg/s), refused rather than integrated. 100 m/s is 360 km/h; 5 rad/s turns a full
// circle in 1.3 s (a car at its steering lock at walking pace turns about 0.5 rad/s). The limits
// of Cityscapes' vehicle files, KITTI's OXTS records (scene/ego_motion.cpp) and a batch
// manifest's odometry fields (core/batch.cpp).
constexpr double kMaxSpeed_m_s = 100, kMaxYawRate_rad_s = 5;
constexpr const char* kNotOdometry = " (not a road vehicle's odometry)";

// v, named `name` (unit `unit`) in `file`: bad input "file: name: v unit is outside [lo, hi]why"
// unless finite and within [lo, hi].
inline double number_in_range(double v, double lo, double hi, const std::string& name, const char* unit,
                              const std::string& file, const char* why = "") {
  if (!std::isfinite(v) || !(v >= lo && v <= hi))
    fail_at(file, fmt::format("{}: {} {} is outside [{}, {}]{}", name, v, unit, lo, hi, why));
  return v;
}

// obj[key] (`name` in messages): bad input when missing or not a number, then as number_in_range.
inline double json_number_in_range(const nlohmann::json& obj, const char* key, const std::string& name, double lo,
                                   double hi, const char* unit, const std::string& file, const char* why = "") {
  if (!obj.contains(key)) fail_at(file, name + ": missing");
  if (!obj[key].is_number()) fail_at(file, name + ": not a number");
  return number_in_range(obj[key].get<double>(), lo, hi, name, unit, file, why);
}

}  // namespace photosite::scene::detail
