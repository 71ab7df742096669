// The camera's motion over a sequence from the data set's odometry (see ego_motion.h).
#include "photosite/scene/ego_motion.h"

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <sstream>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "core/toml_schema_detail.h"
#include "photosite/error.h"

namespace photosite::scene {

namespace {
// A road vehicle's speed and yaw rate: a value beyond these is a file of another kind or in other
// units (km/h, deg/s), refused rather than integrated. 100 m/s is 360 km/h; 5 rad/s turns a full
// circle in 1.3 s (a car at its steering lock at walking pace turns about 0.5 rad/s).
constexpr double kMaxSpeed_m_s = 100, kMaxYawRate_rad_s = 5;

double checked(double v, double limit, const char* name, const char* unit, const std::string& file) {
  if (!std::isfinite(v) || std::fabs(v) > limit)
    fail_at(file, fmt::format("{}: {} {} is outside [-{}, {}] (not a road vehicle's odometry)", name, v, unit, limit, limit));
  return v;
}

double json_number(const nlohmann::json& j, const char* key, const std::string& file) {
  if (!j.contains(key)) fail_at(file, std::string(key) + ": missing");
  if (!j[key].is_number()) fail_at(file, std::string(key) + ": not a number");
  return j[key].get<double>();
}

nlohmann::json json_object(const std::string& file, const char* what) {
  const nlohmann::json j = nlohmann::json::parse(schema::read_text(file, what), nullptr, false);
  if (j.is_discarded() || !j.is_object()) fail_at(file, std::string("not a JSON object (expected a ") + what + " file)");
  return j;
}

// A whole number of ns written as text (leading and trailing white space allowed).
int64_t whole_ns(const std::string& text, const std::string& file) {
  std::istringstream ss(text);
  long long v = 0;
  if (!(ss >> v) || !(ss >> std::ws).eof() || v < 0) fail_at(file, "not a time in whole ns (a Cityscapes timestamp file holds one)");
  return v;
}
}  // namespace

OdometrySample read_cityscapes_odometry(const std::string& vehicle_json, const std::string& timestamp_txt,
                                        const std::string& camera_json) {
  OdometrySample s;
  const nlohmann::json v = json_object(vehicle_json, "Cityscapes vehicle");
  s.speed_m_s = checked(json_number(v, "speed", vehicle_json), kMaxSpeed_m_s, "speed", "m/s", vehicle_json);
  s.yaw_rate_rad_s = checked(json_number(v, "yawRate", vehicle_json), kMaxYawRate_rad_s, "yawRate", "rad/s", vehicle_json);
  s.time_ns = whole_ns(schema::read_text(timestamp_txt, "Cityscapes timestamp"), timestamp_txt);
  if (!camera_json.empty()) {
    const nlohmann::json c = json_object(camera_json, "Cityscapes camera");
    if (!c.contains("extrinsic") || !c["extrinsic"].is_object()) fail_at(camera_json, "no \"extrinsic\" object");
    // Within a vehicle's length of its reference point.
    s.camera_forward_m = checked(json_number(c["extrinsic"], "x", camera_json), 20, "extrinsic.x", "m", camera_json);
    s.camera_left_m = checked(json_number(c["extrinsic"], "y", camera_json), 20, "extrinsic.y", "m", camera_json);
    // A camera looks along the road within a few degrees (Cityscapes: about −0.02 rad); 0.5 rad
    // (29°) and more is not a forward camera, or another unit.
    s.camera_yaw_rad = checked(json_number(c["extrinsic"], "yaw", camera_json), 0.5, "extrinsic.yaw", "rad", camera_json);
  }
  return s;
}

int64_t parse_kitti_timestamp_ns(const std::string& text, const std::string& where) {
  int y = 0, mo = 0, d = 0, h = 0, mi = 0, sec = 0;
  char c1 = 0, c2 = 0, c3 = 0, c4 = 0;
  std::istringstream ss(text);
  auto bad = [&] { fail_at(where, "'" + text + "' is not a time of the form YYYY-MM-DD HH:MM:SS.fffffffff"); };
  if (!(ss >> y >> c1 >> mo >> c2 >> d >> h >> c3 >> mi >> c4 >> sec) || c1 != '-' || c2 != '-' || c3 != ':' || c4 != ':')
    bad();
  int64_t frac_ns = 0;
  if (ss.peek() == '.') {
    ss.get();
    int digits = 0;
    while (std::isdigit(ss.peek())) {
      if (digits++ < 9) frac_ns = frac_ns * 10 + (ss.get() - '0');
      else ss.get();
    }
    if (digits == 0) bad();
    for (int k = std::min(digits, 9); k < 9; ++k) frac_ns *= 10;
  }
  if (!(ss >> std::ws).eof()) bad();
  const std::chrono::year_month_day ymd{std::chrono::year{y}, std::chrono::month{static_cast<unsigned>(mo)},
                                        std::chrono::day{static_cast<unsigned>(d)}};
  if (!ymd.ok() || h < 0 || h > 23 || mi < 0 || mi > 59 || sec < 0 || sec > 60) bad();
  const int64_t days = std::chrono::sys_days(ymd).time_since_epoch().count();
  return ((days * 24 + h) * 60 + mi) * 60 * int64_t(1000000000) + sec * int64_t(1000000000) + frac_ns;
}

OdometrySample read_kitti_oxts(const std::string& oxts_txt, const std::string& timestamps_txt, long index) {
  OdometrySample s;
  std::istringstream ss(schema::read_text(oxts_txt, "KITTI OXTS"));
  std::vector<double> v;
  for (double x; ss >> x;) v.push_back(x);
  if (!ss.eof() || v.size() != 30)
    fail_at(oxts_txt, fmt::format("holds {} numbers{}: a KITTI OXTS line holds 30 (lat lon alt roll pitch yaw vn ve vf ... wu ...)",
                                  v.size(), ss.eof() ? "" : " and then text"));
  s.speed_m_s = checked(v[8], kMaxSpeed_m_s, "vf", "m/s", oxts_txt);
  s.yaw_rate_rad_s = checked(v[22], kMaxYawRate_rad_s, "wu", "rad/s", oxts_txt);
  std::istringstream ts(schema::read_text(timestamps_txt, "KITTI timestamps"));
  std::string line;
  for (long k = 0; k <= index; ++k)
    if (!std::getline(ts, line))
      fail_at(timestamps_txt, fmt::format("has {} lines; frame {} needs line {}", k, index, index + 1));
  if (!line.empty() && line.back() == '\r') line.pop_back();
  s.time_ns = parse_kitti_timestamp_ns(line, fmt::format("{}:{}", timestamps_txt, index + 1));
  return s;
}

CameraPose advance_pose(const CameraPose& pa, const OdometrySample& a, const OdometrySample& b, const std::string& where) {
  if (b.time_ns <= a.time_ns)
    fail_at(where, fmt::format("recorded at {} ns, not after the sequence's previous frame ({} ns): frames out of order or "
                               "a timestamp repeated", b.time_ns, a.time_ns));
  const double dt = 1e-9 * static_cast<double>(b.time_ns - a.time_ns);
  const double v = 0.5 * (a.speed_m_s + b.speed_m_s), w = 0.5 * (a.yaw_rate_rad_s + b.yaw_rate_rad_s);
  // The arc at speed v and yaw rate w over dt (ISO 8855: theta > 0 turns left): the reference
  // point moves v·dt·sin(theta)/theta ahead and v·dt·(1 − cos theta)/theta = v·dt·2 sin²(theta/2)/theta
  // to the left of its heading at a (the second form keeps its digits for small theta).
  const double theta = w * dt, run = v * dt;
  const double ahead = theta == 0 ? run : run * std::sin(theta) / theta;
  const double left = theta == 0 ? 0 : run * 2 * std::pow(std::sin(0.5 * theta), 2) / theta;
  // Photosite's road coordinates: X to the right, D ahead, the heading's yaw positive toward +X
  // (luminaires.cpp: a frame's (x, d) is (X + x·cos + d·sin, D − x·sin + d·cos) in the world).
  // The vehicle's heading is the camera's less the camera's own yaw on the vehicle (ISO's left
  // is photosite's −yaw): vehicle-frame vectors (left, ahead) go to the world by it.
  auto to_world = [](double yaw, double left_m, double ahead_m, double* X, double* D) {
    *X = -left_m * std::cos(yaw) + ahead_m * std::sin(yaw);
    *D = left_m * std::sin(yaw) + ahead_m * std::cos(yaw);
  };
  const double va = pa.yaw_rad + a.camera_yaw_rad;  // the vehicle's heading at a
  double lx, ld;  // the lever arm at a, in the world
  to_world(va, a.camera_left_m, a.camera_forward_m, &lx, &ld);
  double mx, md;  // the reference point's move
  to_world(va, left, ahead, &mx, &md);
  const double vb = va - theta;  // the vehicle's heading at b
  CameraPose pb;
  pb.yaw_rad = vb - b.camera_yaw_rad;
  double bx, bd;  // the lever arm at b
  to_world(vb, b.camera_left_m, b.camera_forward_m, &bx, &bd);
  pb.X_m = pa.X_m - lx + mx + bx;
  pb.D_m = pa.D_m - ld + md + bd;
  return pb;
}

}  // namespace photosite::scene
