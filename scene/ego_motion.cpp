// The camera's motion over a sequence from the data set's odometry (see ego_motion.h).
#include "photosite/scene/ego_motion.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <sstream>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "core/toml_schema_detail.h"
#include "photosite/error.h"
#include "scene/data_file_detail.h"

namespace photosite::scene {

namespace {
using detail::kMaxCameraLever_m, detail::kMaxCameraYaw_rad;  // a camera's place on its vehicle
using detail::kMaxSpeed_m_s, detail::kMaxYawRate_rad_s, detail::kNotOdometry;  // a road vehicle's motion

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

CameraMount cityscapes_camera_mount(const CameraRig& camera) {
  auto need = [&](const std::optional<double>& v, const char* key) {
    if (!v) fail_at(camera.file, std::string("extrinsic.") + key + ": missing (the camera's place on its vehicle, which the odometry needs)");
    return *v;
  };
  return CameraMount{need(camera.mount_forward_m, "x"), need(camera.mount_left_m, "y"), need(camera.mount_yaw_rad, "yaw")};
}

namespace {
using Mat3 = std::array<std::array<double, 3>, 3>;
using Vec3 = std::array<double, 3>;

// The numbers of line "KEY: v1 v2 ..." of a KITTI calibration file: exactly n of them.
std::vector<double> calib_line(const std::string& text, const std::string& key, size_t n, const std::string& file) {
  std::istringstream lines(text);
  for (std::string line; std::getline(lines, line);) {
    if (line.compare(0, key.size() + 1, key + ":") != 0) continue;
    std::istringstream ss(line.substr(key.size() + 1));
    std::vector<double> v;
    for (double x; ss >> x;) v.push_back(x);
    if (!ss.eof() || v.size() != n)
      fail_at(file, fmt::format("{}: holds {} numbers{}, not {}", key, v.size(), ss.eof() ? "" : " and then text", n));
    for (double x : v)
      if (!std::isfinite(x)) fail_at(file, key + ": holds a number that is not finite");
    return v;
  }
  fail_at(file, fmt::format("no line \"{}: ...\" ({} numbers; a KITTI raw calibration file)", key, n));
}

// A rotation written with 7 significant digits (the devkit's files print "%e": d.dddddde±XX).
// Each entry is then within δ = half a unit of its 7th digit of the true one (a 0 is exact), so
// for R = R₀ + E with R₀ orthonormal, |E_ik| <= δ_ik, each entry of R·Rᵀ − I = R₀Eᵀ + ER₀ᵀ + EEᵀ is
// within Σ_k (|r_ik| + δ_ik)·δ_jk + δ_ik·(|r_jk| + δ_jk) + δ_ik·δ_jk, plus the 4 roundings of the
// sum (4·2⁻⁵³·2). A matrix outside that is not a rotation rounded, nor is one with det < 0.
Mat3 rotation(const std::vector<double>& v, const std::string& key, const std::string& file) {
  Mat3 r{}, d{};
  for (int i = 0; i < 3; ++i)
    for (int k = 0; k < 3; ++k) {
      r[i][k] = v[3 * i + k];
      const double a = std::fabs(r[i][k]);
      d[i][k] = a == 0 ? 0 : 0.5 * std::pow(10.0, std::floor(std::log10(a)) - 6);
    }
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      double dot = 0, bound = 4 * 0x1p-53 * 2;
      for (int k = 0; k < 3; ++k) {
        dot += r[i][k] * r[j][k];
        bound += (std::fabs(r[i][k]) + d[i][k]) * d[j][k] + d[i][k] * (std::fabs(r[j][k]) + d[j][k]) + d[i][k] * d[j][k];
      }
      const double dev = std::fabs(dot - (i == j ? 1 : 0));
      if (!(dev <= bound))
        fail_at(file, fmt::format("{}: not a rotation: (R·Rᵀ)[{}][{}] is {} off the identity's, beyond the {:.3g} its "
                                  "7 significant digits allow", key, i, j, dev, bound));
    }
  const double det = r[0][0] * (r[1][1] * r[2][2] - r[1][2] * r[2][1]) - r[0][1] * (r[1][0] * r[2][2] - r[1][2] * r[2][0]) +
                     r[0][2] * (r[1][0] * r[2][1] - r[1][1] * r[2][0]);
  if (det < 0) fail_at(file, key + ": not a rotation: a reflection (determinant −1)");
  return r;
}

Mat3 mul(const Mat3& a, const Mat3& b) {
  Mat3 c{};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < 3; ++k) c[i][j] += a[i][k] * b[k][j];
  return c;
}
Vec3 mul(const Mat3& a, const Vec3& x) {
  Vec3 y{};
  for (int i = 0; i < 3; ++i)
    for (int k = 0; k < 3; ++k) y[i] += a[i][k] * x[k];
  return y;
}
}  // namespace

CameraMount read_kitti_camera_mount(const std::string& calib_dir) {
  const std::filesystem::path dir(calib_dir);
  const std::string f_iv = (dir / kKittiCalibFiles[0]).string(), f_vc = (dir / kKittiCalibFiles[1]).string(),
                    f_cc = (dir / kKittiCalibFiles[2]).string();
  const std::string t_iv = schema::read_text(f_iv, "KITTI calibration"), t_vc = schema::read_text(f_vc, "KITTI calibration"),
                    t_cc = schema::read_text(f_cc, "KITTI calibration");
  const Mat3 r_vi = rotation(calib_line(t_iv, "R", 9, f_iv), "R", f_iv);
  const std::vector<double> tv_vi = calib_line(t_iv, "T", 3, f_iv);
  const Mat3 r_cv = rotation(calib_line(t_vc, "R", 9, f_vc), "R", f_vc);
  const std::vector<double> tv_cv = calib_line(t_vc, "T", 3, f_vc);
  const Mat3 r_rect = rotation(calib_line(t_cc, "R_rect_00", 9, f_cc), "R_rect_00", f_cc);
  const std::vector<double> p = calib_line(t_cc, "P_rect_02", 12, f_cc);
  // P_rect_02 = K·[I | t] (the devkit's rectified projection, K upper triangular): t = K⁻¹ times
  // its 4th column, by back substitution. (Its first row alone, P[0][3]/P[0][0], gives 6.22 cm
  // for 2011_09_26 instead of t_x = 5.98 cm: K's principal point times t_z = 2.7 mm enters it.)
  auto P = [&](int i, int j) { return p[4 * i + j]; };
  if (P(1, 0) != 0 || P(2, 0) != 0 || P(2, 1) != 0 || !(P(0, 0) > 0) || !(P(1, 1) > 0) || !(P(2, 2) > 0))
    fail_at(f_cc, "P_rect_02: not a rectified projection K·[I | t] (K upper triangular with a positive diagonal)");
  Vec3 t{};
  t[2] = P(2, 3) / P(2, 2);
  t[1] = (P(1, 3) - P(1, 2) * t[2]) / P(1, 1);
  t[0] = (P(0, 3) - P(0, 1) * t[1] - P(0, 2) * t[2]) / P(0, 0);
  // x_cam2 = R_rect·(R_cv·(R_vi·x_imu + T_vi) + T_cv) + t = M·x_imu + m.
  const Mat3 m_rot = mul(r_rect, mul(r_cv, r_vi));
  const Vec3 a = mul(r_cv, Vec3{tv_vi[0], tv_vi[1], tv_vi[2]});
  const Vec3 b = mul(r_rect, Vec3{a[0] + tv_cv[0], a[1] + tv_cv[1], a[2] + tv_cv[2]});
  const Vec3 m{b[0] + t[0], b[1] + t[1], b[2] + t[2]};
  // The camera's centre (x_cam2 = 0): x_imu = −Mᵀ·m (M orthonormal to the files' 7 digits: the
  // transpose for the inverse errs by ~10⁻⁷ of a lever arm of a metre or two, 0.2 µm).
  CameraMount mount;
  mount.forward_m = -(m_rot[0][0] * m[0] + m_rot[1][0] * m[1] + m_rot[2][0] * m[2]);
  mount.left_m = -(m_rot[0][1] * m[0] + m_rot[1][1] * m[1] + m_rot[2][1] * m[2]);
  // The optical axis (the camera's z) in the OXTS frame is M's third row; its heading in the x-y
  // plane, positive to the left (y).
  mount.yaw_rad = std::atan2(m_rot[2][1], m_rot[2][0]);
  const std::string files = fmt::format("{} with {} and {}", f_iv, kKittiCalibFiles[1], kKittiCalibFiles[2]);
  detail::number_in_range(mount.forward_m, -kMaxCameraLever_m, kMaxCameraLever_m, "camera 2's place ahead of the OXTS unit", "m", files,
                          " (not a camera on the vehicle)");
  detail::number_in_range(mount.left_m, -kMaxCameraLever_m, kMaxCameraLever_m, "camera 2's place left of the OXTS unit", "m", files,
                          " (not a camera on the vehicle)");
  detail::number_in_range(mount.yaw_rad, -kMaxCameraYaw_rad, kMaxCameraYaw_rad, "camera 2's heading on the vehicle", "rad",
                          files, " (not a forward camera)");
  return mount;
}

OdometrySample read_cityscapes_odometry(const std::string& vehicle_json, const std::string& timestamp_txt,
                                        const CameraMount& mount) {
  OdometrySample s;
  const nlohmann::json v = json_object(vehicle_json, "Cityscapes vehicle");
  s.speed_m_s = detail::json_number_in_range(v, "speed", "speed", -kMaxSpeed_m_s, kMaxSpeed_m_s, "m/s", vehicle_json, kNotOdometry);
  s.yaw_rate_rad_s = detail::json_number_in_range(v, "yawRate", "yawRate", -kMaxYawRate_rad_s, kMaxYawRate_rad_s, "rad/s",
                                                  vehicle_json, kNotOdometry);
  s.time_ns = whole_ns(schema::read_text(timestamp_txt, "Cityscapes timestamp"), timestamp_txt);
  s.camera_forward_m = mount.forward_m;
  s.camera_left_m = mount.left_m;
  s.camera_yaw_rad = mount.yaw_rad;
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

namespace {
// The OXTS line's speed and yaw rate, with the camera's mount (read_kitti_oxts' first half).
OdometrySample kitti_oxts_sample(const std::string& oxts_txt, const CameraMount& mount) {
  OdometrySample s;
  std::istringstream ss(schema::read_text(oxts_txt, "KITTI OXTS"));
  std::vector<double> v;
  for (double x; ss >> x;) v.push_back(x);
  if (!ss.eof() || v.size() != 30)
    fail_at(oxts_txt, fmt::format("holds {} numbers{}: a KITTI OXTS line holds 30 (lat lon alt roll pitch yaw vn ve vf ... wu ...)",
                                  v.size(), ss.eof() ? "" : " and then text"));
  s.speed_m_s = detail::number_in_range(v[8], -kMaxSpeed_m_s, kMaxSpeed_m_s, "vf", "m/s", oxts_txt, kNotOdometry);
  s.yaw_rate_rad_s = detail::number_in_range(v[22], -kMaxYawRate_rad_s, kMaxYawRate_rad_s, "wu", "rad/s", oxts_txt, kNotOdometry);
  s.camera_forward_m = mount.forward_m;
  s.camera_left_m = mount.left_m;
  s.camera_yaw_rad = mount.yaw_rad;
  return s;
}
// Line `index` of the timestamps file's lines, as the sample's time (read_kitti_oxts' second half).
void kitti_time(OdometrySample* s, const std::string& timestamps_txt, const std::vector<std::string>& lines, long index) {
  if (index < 0 || static_cast<size_t>(index) >= lines.size())
    fail_at(timestamps_txt, fmt::format("has {} lines; frame {} needs line {}", lines.size(), index, index + 1));
  s->time_ns = parse_kitti_timestamp_ns(lines[static_cast<size_t>(index)], fmt::format("{}:{}", timestamps_txt, index + 1));
}
}  // namespace

OdometrySample read_kitti_oxts(const std::string& oxts_txt, const std::string& timestamps_txt, long index,
                               const CameraMount& mount) {
  OdometrySample s = kitti_oxts_sample(oxts_txt, mount);
  kitti_time(&s, timestamps_txt, read_kitti_timestamps(timestamps_txt), index);
  return s;
}

OdometrySample read_kitti_oxts(const std::string& oxts_txt, const std::string& timestamps_txt,
                               const std::vector<std::string>& timestamps_lines, long index, const CameraMount& mount) {
  OdometrySample s = kitti_oxts_sample(oxts_txt, mount);
  kitti_time(&s, timestamps_txt, timestamps_lines, index);
  return s;
}

std::vector<std::string> read_kitti_timestamps(const std::string& timestamps_txt) {
  return kitti_timestamps_lines(schema::read_text(timestamps_txt, "KITTI timestamps"));
}

std::vector<std::string> kitti_timestamps_lines(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream ts(text);
  for (std::string line; std::getline(ts, line);) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    lines.push_back(std::move(line));
  }
  return lines;
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
