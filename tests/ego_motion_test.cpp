// The camera's motion over a sequence from the data sets' odometry (scene/ego_motion.cpp): the
// dead reckoning against closed forms, the readers of Cityscapes' vehicle and timestamp files and
// of KITTI raw's OXTS records, and their bad input.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <filesystem>
#include <iterator>
#include <numbers>

#include <fmt/format.h>
#include <fstream>
#include <string>

#include "photosite/error.h"
#include "photosite/io.h"
#include "photosite/scene/ego_motion.h"
#include "photosite/scene/rig.h"
#include "test_util.h"

using namespace photosite;
using namespace photosite::scene;

namespace {
void write_text(const std::string& path, const std::string& text) {
  std::ofstream f(path, std::ios::binary);
  f << text;
}
OdometrySample sample(double t_s, double v, double w, double fwd = 0, double left = 0) {
  OdometrySample s;
  s.time_ns = std::llround(t_s * 1e9);
  s.speed_m_s = v;
  s.yaw_rate_rad_s = w;
  s.camera_forward_m = fwd;
  s.camera_left_m = left;
  return s;
}
// Expects `f` to throw photosite::Error whose message holds every one of `parts`.
template <class F>
void expect_refused(F&& f, std::initializer_list<std::string> parts) {
  try {
    f();
    ADD_FAILURE() << "accepted; expected an error holding " << *parts.begin();
  } catch (const Error& e) {
    for (const auto& p : parts) EXPECT_NE(std::string(e.what()).find(p), std::string::npos) << e.what();
  }
}
}  // namespace

// Driving straight on: the camera moves v̄·dt ahead whatever its lever arm, and a speed that
// changes linearly over the interval (constant acceleration) is integrated exactly by the mean.
TEST(EgoMotion, StraightAheadMovesByTheMeanSpeed) {
  const CameraPose p0;
  const CameraPose p1 = advance_pose(p0, sample(0, 10, 0, 1.7, 0.1), sample(0.5, 14, 0, 1.7, 0.1), "t");
  EXPECT_EQ(p1.yaw_rad, 0);
  // D = ((0 − 1.7) + 6) + 1.7: three roundings of terms below 8, each within 2⁻⁵³·8 (relative
  // 2⁻⁵³, values < 8): 3·8·2⁻⁵³. X: (0 + 0.1) + 0 − 0.1 is exact.
  EXPECT_NEAR(p1.D_m, 6.0, 3 * 8 * 0x1p-53);
  EXPECT_EQ(p1.X_m, 0);
  // From a turned pose the same run goes along the heading.
  CameraPose turned;
  turned.yaw_rad = 0.3;
  const CameraPose p2 = advance_pose(turned, sample(0, 12, 0), sample(0.5, 12, 0), "t");
  // 6 m along (sin 0.3, cos 0.3): each coordinate one product and one sum, 2 roundings of < 6.
  EXPECT_NEAR(p2.X_m, 6 * std::sin(0.3), 2 * 6 * 0x1p-53);
  EXPECT_NEAR(p2.D_m, 6 * std::cos(0.3), 2 * 6 * 0x1p-53);
  // A camera turned 0.02 rad to the left on its vehicle (Cityscapes' extrinsic yaw is of this
  // size) sees the straight run go 0.02 rad to the right of its own heading, which stays 0.
  OdometrySample a = sample(0, 20, 0), b = sample(0.5, 20, 0);
  a.camera_yaw_rad = b.camera_yaw_rad = 0.02;
  const CameraPose p3 = advance_pose(CameraPose{}, a, b, "t");
  // 10 m along (sin 0.02, cos 0.02): one product and one sum each, 2 roundings of < 10.
  EXPECT_NEAR(p3.X_m, 10 * std::sin(0.02), 2 * 10 * 0x1p-53);
  EXPECT_NEAR(p3.D_m, 10 * std::cos(0.02), 2 * 10 * 0x1p-53);
  EXPECT_EQ(p3.yaw_rad, 0);  // (0 + 0.02) − 0 − 0.02, exact
}

// A constant turn: the vehicle's reference point runs on the circle of radius R = v/ω about the
// turn's centre (R to the left: X = −R at the start), its heading turned by ω·t; a camera ahead
// of the reference point runs on the concentric circle of radius √(R² + a²). Stepped at KITTI's
// 10 Hz over 40 frames (a quarter turn and more), every pose against the closed form.
TEST(EgoMotion, AConstantTurnStaysOnItsCircle) {
  const double v = 8, w = 0.45, R = v / w, dt = 0.1;  // 29 km/h, turning left
  for (double ahead : {0.0, 1.7}) {
    CameraPose p;
    p.D_m = ahead;  // the first frame's camera at (0, ahead) when the reference point is at the origin
    for (int k = 1; k <= 40; ++k) {
      p = advance_pose(p, sample((k - 1) * dt, v, w, ahead), sample(k * dt, v, w, ahead), "t");
      const double t = k * dt, phi = w * t;
      // Closed form: reference point (−R(1 − cos φ), R sin φ), heading −φ (to the left: toward −X);
      // the camera `ahead` along the heading (−sin φ, cos φ).
      const double X = -R * (1 - std::cos(phi)) - ahead * std::sin(phi), D = R * std::sin(phi) + ahead * std::cos(phi);
      // Each step adds about 20 rounded operations on values below R + ahead (< 20 m): ≤ 20·2⁻⁵³·20 m
      // each, summed over k steps (the errors of earlier steps carried unchanged).
      const double tol = k * 20 * 20 * 0x1p-53;
      EXPECT_NEAR(p.X_m, X, tol) << "ahead " << ahead << ", frame " << k;
      EXPECT_NEAR(p.D_m, D, tol) << "ahead " << ahead << ", frame " << k;
      // The heading: a sum of k equal steps w·dt (k roundings of ≤ 2 rad).
      EXPECT_NEAR(p.yaw_rad, -phi, k * 2 * 0x1p-53 + 0x1p-53 * 2) << k;
      EXPECT_NEAR(std::hypot(p.X_m + R, p.D_m), std::hypot(R, ahead), tol) << "on the circle, frame " << k;
    }
  }
  // Turning right (ω < 0) mirrors it.
  const CameraPose l = advance_pose(CameraPose{}, sample(0, 8, 0.45), sample(1, 8, 0.45), "t");
  const CameraPose r = advance_pose(CameraPose{}, sample(0, 8, -0.45), sample(1, 8, -0.45), "t");
  EXPECT_EQ(l.X_m, -r.X_m);
  EXPECT_EQ(l.D_m, r.D_m);
  EXPECT_EQ(l.yaw_rad, -r.yaw_rad);
  EXPECT_LT(l.X_m, 0);  // left is −X
}

// Frames out of order or a timestamp repeated: refused, naming where.
TEST(EgoMotion, TimeMustAdvance) {
  expect_refused([] { advance_pose(CameraPose{}, sample(1, 5, 0), sample(1, 5, 0), "ts.txt"); }, {"ts.txt", "not after"});
  expect_refused([] { advance_pose(CameraPose{}, sample(1, 5, 0), sample(0.5, 5, 0), "ts.txt"); }, {"ts.txt", "not after"});
}

// Cityscapes' files (cityscapesScripts' csCalibration.pdf §3: speed in m/s, yawRate in rad/s;
// README: timestamps in ns), read as they are shipped, with the camera file's lever arm.
TEST(EgoMotion, ReadsCityscapesVehicleAndTimestampFiles) {
  test::TempDir tmp;
  write_text(tmp.file("v.json"), R"({"gpsHeading": 281.2, "gpsLatitude": 50.78, "gpsLongitude": 6.08,
    "outsideTemperature": 19.5, "speed": 8.25, "yawRate": -0.0175})");
  write_text(tmp.file("t.txt"), "117647058\n");
  write_text(tmp.file("c.json"), R"({"extrinsic": {"baseline": 0.21, "pitch": 0.038, "roll": 0.0, "x": 1.7, "y": 0.1,
    "yaw": -0.0195, "z": 1.22}, "intrinsic": {"fx": 2262.52, "fy": 2265.3, "u0": 1096.98, "v0": 513.137}})");
  const OdometrySample s =
      read_cityscapes_odometry(tmp.file("v.json"), tmp.file("t.txt"), cityscapes_camera_mount(load_cityscapes_camera(tmp.file("c.json"))));
  EXPECT_EQ(s.speed_m_s, 8.25);
  EXPECT_EQ(s.yaw_rate_rad_s, -0.0175);
  EXPECT_EQ(s.time_ns, 117647058);
  EXPECT_EQ(s.camera_forward_m, 1.7);
  EXPECT_EQ(s.camera_left_m, 0.1);
  EXPECT_EQ(s.camera_yaw_rad, -0.0195);
  const OdometrySample n = read_cityscapes_odometry(tmp.file("v.json"), tmp.file("t.txt"));
  EXPECT_EQ(n.camera_forward_m, 0);  // no camera file: the reference point
  // Bad input names the file and the key.
  write_text(tmp.file("nospeed.json"), R"({"yawRate": 0.1})");
  expect_refused([&] { read_cityscapes_odometry(tmp.file("nospeed.json"), tmp.file("t.txt")); }, {"nospeed.json", "speed: missing"});
  write_text(tmp.file("text.json"), R"({"speed": "fast", "yawRate": 0.1})");
  expect_refused([&] { read_cityscapes_odometry(tmp.file("text.json"), tmp.file("t.txt")); }, {"text.json", "speed: not a number"});
  write_text(tmp.file("kmh.json"), R"({"speed": 130, "yawRate": 0.1})");  // km/h
  expect_refused([&] { read_cityscapes_odometry(tmp.file("kmh.json"), tmp.file("t.txt")); }, {"kmh.json", "speed: 130"});
  write_text(tmp.file("deg.json"), R"({"speed": 10, "yawRate": 12.5})");  // deg/s
  expect_refused([&] { read_cityscapes_odometry(tmp.file("deg.json"), tmp.file("t.txt")); }, {"deg.json", "yawRate: 12.5"});
  write_text(tmp.file("list.json"), "[1, 2]");
  expect_refused([&] { read_cityscapes_odometry(tmp.file("list.json"), tmp.file("t.txt")); }, {"list.json", "not a JSON object"});
  write_text(tmp.file("frac.txt"), "1176.5");
  expect_refused([&] { read_cityscapes_odometry(tmp.file("v.json"), tmp.file("frac.txt")); }, {"frac.txt", "whole ns"});
  expect_refused([&] { read_cityscapes_odometry(tmp.file("v.json"), tmp.file("missing.txt")); }, {"missing.txt"});
  // The camera file's extrinsics, read with the rest of the file as its rig: a yaw in degrees
  // is refused by the rig's reader; a file without x is a rig (night needs no x) but no mount.
  auto camera_file = [](const std::string& extrinsic) {
    return R"({"extrinsic": {"pitch": 0.038, "z": 1.22)" + extrinsic +
           R"(}, "intrinsic": {"fx": 2262.52, "fy": 2265.3, "u0": 1096.98, "v0": 513.137}})";
  };
  write_text(tmp.file("sideways.json"), camera_file(R"(, "x": 1.7, "y": 0.1, "yaw": 90)"));  // degrees
  expect_refused([&] { load_cityscapes_camera(tmp.file("sideways.json")); }, {"sideways.json", "extrinsic.yaw: 90"});
  write_text(tmp.file("far.json"), camera_file(R"(, "x": 1.7, "y": 25, "yaw": 0)"));
  expect_refused([&] { load_cityscapes_camera(tmp.file("far.json")); }, {"far.json", "extrinsic.y: 25 m is outside [-20, 20]"});
  write_text(tmp.file("nox.json"), camera_file(R"(, "y": 0.1, "yaw": 0)"));
  const CameraRig nox = load_cityscapes_camera(tmp.file("nox.json"));
  EXPECT_FALSE(nox.mount_forward_m.has_value());
  EXPECT_EQ(nox.mount_left_m, 0.1);
  expect_refused([&] { cityscapes_camera_mount(nox); }, {"nox.json", "extrinsic.x: missing"});
}

// KITTI raw's OXTS records (the devkit's dataformat.txt: 30 values, vf the 9th, wu the 23rd) and
// its timestamps, one line a frame.
TEST(EgoMotion, ReadsKittiOxtsRecordsAndTimestamps) {
  test::TempDir tmp;
  // lat lon alt roll pitch yaw vn ve vf vl vu ax ay az af al au wx wy wz wf wl wu pos vel navstat numsats posmode velmode orimode
  write_text(tmp.file("o.txt"),
             "49.015 8.43 116.4 0.035 0.005 -1.18 -3.3 1.1 3.51 0.037 -0.038 -0.29 0.037 9.99 -0.30 -0.19 9.99 "
             "-0.017 0.024 0.145 -0.0175 0.0214 0.1456 0.49 0.068 4 10 4 4 0\n");
  write_text(tmp.file("ts.txt"),
             "2011-09-26 13:02:25.964389445\n2011-09-26 13:02:26.067575800\r\n2011-09-26 23:59:59.99\n2011-09-27 00:00:00.01\n");
  const OdometrySample s = read_kitti_oxts(tmp.file("o.txt"), tmp.file("ts.txt"), 1);
  EXPECT_EQ(s.speed_m_s, 3.51);
  EXPECT_EQ(s.yaw_rate_rad_s, 0.1456);
  const OdometrySample s0 = read_kitti_oxts(tmp.file("o.txt"), tmp.file("ts.txt"), 0);
  EXPECT_EQ(s.time_ns - s0.time_ns, 103186355);  // 26.067575800 − 25.964389445 s
  // Across midnight: 20 ms (the date's day count is used).
  EXPECT_EQ(read_kitti_oxts(tmp.file("o.txt"), tmp.file("ts.txt"), 3).time_ns -
                read_kitti_oxts(tmp.file("o.txt"), tmp.file("ts.txt"), 2).time_ns,
            20000000);
  EXPECT_EQ(parse_kitti_timestamp_ns("1970-01-02 00:00:00", "x"), 86400LL * 1000000000LL);
  // The drive's timestamps read once (batch's path) give every frame the same sample, and the
  // same refusal beyond the file's lines.
  const std::vector<std::string> lines = read_kitti_timestamps(tmp.file("ts.txt"));
  for (long k = 0; k < 4; ++k) {
    const OdometrySample a = read_kitti_oxts(tmp.file("o.txt"), tmp.file("ts.txt"), k);
    const OdometrySample b = read_kitti_oxts(tmp.file("o.txt"), tmp.file("ts.txt"), lines, k, CameraMount{});
    EXPECT_EQ(a.time_ns, b.time_ns);
    EXPECT_EQ(a.speed_m_s, b.speed_m_s);
    EXPECT_EQ(a.yaw_rate_rad_s, b.yaw_rate_rad_s);
  }
  expect_refused([&] { read_kitti_oxts(tmp.file("o.txt"), tmp.file("ts.txt"), lines, 4, CameraMount{}); }, {"ts.txt", "has 4 lines", "frame 4"});
  // Bad input.
  expect_refused([&] { read_kitti_oxts(tmp.file("o.txt"), tmp.file("ts.txt"), 4); }, {"ts.txt", "has 4 lines", "frame 4"});
  write_text(tmp.file("short.txt"), "1 2 3\n");
  expect_refused([&] { read_kitti_oxts(tmp.file("short.txt"), tmp.file("ts.txt"), 0); }, {"short.txt", "holds 3 numbers"});
  write_text(tmp.file("word.txt"), "1 2 three\n");
  expect_refused([&] { read_kitti_oxts(tmp.file("word.txt"), tmp.file("ts.txt"), 0); }, {"word.txt", "and then text"});
  for (const char* bad : {"2011-13-01 00:00:00", "2011-02-30 00:00:00", "2011-09-26T13:02:25", "2011-09-26 25:00:00",
                          "2011-09-26 13:02:25.", "2011-09-26 13:02:25 x", ""})
    expect_refused([&] { parse_kitti_timestamp_ns(bad, "ts.txt:7"); }, {"ts.txt:7", "not a time"});
}

// `batch --sequence` with odometry on the command line: the flag's bad values, a sequence frame
// that lost its OXTS record (that frame fails naming it; the others are written), and the resume
// manifest's record (a run without odometry is not resumed by one that reads it).
TEST(EgoMotion, BatchFlagMissingRecordAndResume) {
  test::TempDir tmp;
  const auto root = tmp.path() / "kitti";
  for (const char* d : {"image_2/drive", "semantic/drive", "oxts/drive/data"}) std::filesystem::create_directories(root / d);
  ImageF day(64, 32, 3, 0.25f);
  ImageF ids(64, 32, 1, 7 / 255.0f);  // road
  for (int y = 0; y < 12; ++y)
    for (int x = 0; x < 64; ++x) ids.at(x, y) = 23 / 255.0f;  // sky above
  std::string oxts;
  for (int k = 0; k < 30; ++k) oxts += (k == 8 ? "10" : "0") + std::string(k < 29 ? " " : "\n");
  std::string stamps;
  for (int f = 0; f < 3; ++f) {
    const std::string name = "000000000" + std::to_string(f);
    write_png((root / "image_2" / "drive" / (name + ".png")).string(), day);
    write_png((root / "semantic" / "drive" / (name + ".png")).string(), ids);
    if (f != 1) write_text((root / "oxts" / "drive" / "data" / (name + ".txt")).string(), oxts);
    stamps += "2011-09-26 13:02:2" + std::to_string(f) + ".000\n";
  }
  write_text((root / "oxts" / "drive" / "timestamps.txt").string(), stamps);
  const std::string base = "batch --dataset kitti --root '" + root.string() + "' --layers lights --quiet --device-store '" +
                           tmp.file("store") + "' --out '";
  // The flag.
  auto r = test::run_cli(base + tmp.file("a") + "' --sequence --ego-motion sideways");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("--ego-motion 'sideways' must be auto"), std::string::npos) << r.output;
  r = test::run_cli(base + tmp.file("a") + "' --ego-motion none");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("add --sequence"), std::string::npos) << r.output;
  EXPECT_FALSE(std::filesystem::exists(tmp.file("a")));
  // Frame 1 without its record: it fails, naming the file it looked for; frames 0 and 2 are written.
  r = test::run_cli(base + tmp.file("b") + "' --sequence");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("drive/data/0000000001.txt: cannot read KITTI OXTS (no such file)"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("1 of 3 items failed"), std::string::npos) << r.output;
  EXPECT_TRUE(std::filesystem::exists(tmp.file("b") + "/image_2/drive/0000000002.exr"));
  EXPECT_FALSE(std::filesystem::exists(tmp.file("b") + "/image_2/drive/0000000001.exr"));
  // Frame 2's pose: 2 s at 10 m/s from frame 0 (frame 1 skipped: one arc over both intervals).
  const auto attrs = read_exr_attributes(tmp.file("b") + "/image_2/drive/0000000002.exr");
  ASSERT_TRUE(attrs.count("photosite/batch/pose_D_m"));
  EXPECT_NEAR(std::stod(attrs.at("photosite/batch/pose_D_m_text")), 20.0, 4 * 32 * 0x1p-53);  // a few roundings of < 32
  // No calib/ folder: the OXTS unit taken as the camera's place, and the header says so.
  EXPECT_EQ(attrs.at("photosite/batch/camera_mount"), "none: the OXTS unit's place");
  EXPECT_EQ(std::stod(attrs.at("photosite/batch/camera_forward_m_text")), 0.0);
  // A run at pose 0 is not resumed by one that reads the odometry, and is by one that does not.
  write_text((root / "oxts" / "drive" / "data" / "0000000001.txt").string(), oxts);
  r = test::run_cli(base + tmp.file("c") + "' --sequence --ego-motion none");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  r = test::run_cli(base + tmp.file("c") + "' --sequence");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("ego_motion"), std::string::npos) << r.output;
  r = test::run_cli(base + tmp.file("c") + "' --sequence --ego-motion none");
  EXPECT_EQ(r.exit_code, 0) << r.output;
}

// The Cityscapes sequence layout: leftImg8bit_sequence frames with their vehicle_sequence and
// timestamp_sequence files and camera files (camera/, as batch reads them). Two frames 1/17 s
// apart at 12 m/s straight on; the camera 0.02 rad to the right on its vehicle (extrinsic yaw
// −0.02), 1.7 m ahead of the rear axle: in its road coordinates it moves s = 12 m/s · dt along
// its vehicle's heading, (s·sin(−0.02), s·cos(−0.02)), its own heading unchanged.
TEST(EgoMotion, CityscapesSequenceLayout) {
  test::TempDir tmp;
  const auto root = tmp.path() / "cs";
  for (const char* d : {"leftImg8bit_sequence/val/city", "gtFine/val/city", "camera/val/city", "vehicle_sequence/val/city",
                        "timestamp_sequence/val/city"})
    std::filesystem::create_directories(root / d);
  ImageF day(128, 64, 3, 0.25f);
  ImageF ids(128, 64, 1, 7 / 255.0f);
  for (int y = 0; y < 24; ++y)
    for (int x = 0; x < 128; ++x) ids.at(x, y) = 23 / 255.0f;
  const int64_t dt_ns = 58823529;  // 1/17 s
  for (int f : {18, 19}) {
    const std::string stem = "city_000000_0000" + std::to_string(f);
    write_png((root / "leftImg8bit_sequence/val/city" / (stem + "_leftImg8bit.png")).string(), day);
    write_png((root / "gtFine/val/city" / (stem + "_gtFine_labelIds.png")).string(), ids);
    write_text((root / "camera/val/city" / (stem + "_camera.json")).string(),
               R"({"extrinsic": {"baseline": 0.21, "pitch": 0.038, "roll": 0, "x": 1.7, "y": 0.1, "yaw": -0.02, "z": 1.22},
                   "intrinsic": {"fx": 2262.52, "fy": 2265.3, "u0": 1096.98, "v0": 513.137}})");
    write_text((root / "vehicle_sequence/val/city" / (stem + "_vehicle.json")).string(), R"({"speed": 12.0, "yawRate": 0.0})");
    write_text((root / "timestamp_sequence/val/city" / (stem + "_timestamp.txt")).string(), std::to_string((f - 18) * dt_ns));
  }
  const auto r = test::run_cli("batch --dataset cityscapes --root '" + root.string() + "' --out '" + tmp.file("out") +
                               "' --layers depth --quiet --device-store '" + tmp.file("store") + "' --sequence");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const std::string dir = tmp.file("out") + "/leftImg8bit_sequence/val/city/";
  const auto a0 = read_exr_attributes(dir + "city_000000_000018_leftImg8bit.exr");
  const auto a1 = read_exr_attributes(dir + "city_000000_000019_leftImg8bit.exr");
  EXPECT_EQ(std::stod(a0.at("photosite/batch/pose_D_m_text")), 0.0);
  const double s = 12 * (dt_ns * 1e-9);
  // A dozen rounded operations on values below 2 m (lever arms and the run): 12·2·2⁻⁵³ (the header's
  // _text attribute holds the double in 17 significant digits, which round-trip it).
  EXPECT_NEAR(std::stod(a1.at("photosite/batch/pose_X_m_text")), s * std::sin(-0.02), 12 * 2 * 0x1p-53);
  EXPECT_NEAR(std::stod(a1.at("photosite/batch/pose_D_m_text")), s * std::cos(-0.02), 12 * 2 * 0x1p-53);
  EXPECT_NEAR(std::stod(a1.at("photosite/batch/pose_yaw_rad_text")), 0.0, 2 * 0x1p-53 * 0.02);
  // The header records the mount the pose was computed with: the camera file's extrinsics, as read.
  EXPECT_EQ(std::stod(a1.at("photosite/batch/camera_forward_m_text")), 1.7);
  EXPECT_EQ(std::stod(a1.at("photosite/batch/camera_left_m_text")), 0.1);
  EXPECT_EQ(std::stod(a1.at("photosite/batch/camera_yaw_rad_text")), -0.02);
  EXPECT_NE(a1.at("photosite/batch/camera_mount").find("Cityscapes camera file"), std::string::npos);
  EXPECT_NE(a1.at("photosite/batch/camera_mount").find("city_000000_000019_camera.json"), std::string::npos);
  std::fprintf(stderr, "[cityscapes odometry] frame 19 pose: X %s m, D %s m, yaw %s rad\n",
               a1.at("photosite/batch/pose_X_m_text").c_str(), a1.at("photosite/batch/pose_D_m_text").c_str(),
               a1.at("photosite/batch/pose_yaw_rad_text").c_str());
}

namespace {
using M3 = std::array<std::array<double, 3>, 3>;
using V3 = std::array<double, 3>;
M3 mat_mul(const M3& a, const M3& b) {
  M3 c{};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < 3; ++k) c[i][j] += a[i][k] * b[k][j];
  return c;
}
V3 mat_vec(const M3& a, const V3& x) {
  V3 y{};
  for (int i = 0; i < 3; ++i)
    for (int k = 0; k < 3; ++k) y[i] += a[i][k] * x[k];
  return y;
}
M3 transposed(const M3& a) {
  M3 t{};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) t[i][j] = a[j][i];
  return t;
}
std::string numbers(std::initializer_list<double> v) {
  std::string s;
  for (double x : v) s += fmt::format(" {:.17g}", x);  // 17 digits: the doubles themselves
  return s;
}
std::string mat_text(const M3& r) {
  return numbers({r[0][0], r[0][1], r[0][2], r[1][0], r[1][1], r[1][2], r[2][0], r[2][1], r[2][2]});
}
// KITTI raw calibration files (the devkit's three per date) of a camera 2 whose centre lies at
// `centre` in the OXTS frame (x forward, y left, z up), looking along the road turned `yaw` to the
// left, built backwards from that closed form through a chain of other transforms: the IMU to
// Velodyne turned 0.01 rad about z, a rectifying rotation of 0.005 rad about the camera's x, and
// camera 2 offset t from the rectified camera 0 (P_rect_02 = K·[I | t]).
void write_kitti_calib(const std::filesystem::path& dir, V3 centre, double yaw) {
  std::filesystem::create_directories(dir);
  // x_cam2 = M·x_imu + m: the camera's axes (x right, y down, z forward) in the OXTS frame as rows.
  const M3 M{{{std::sin(yaw), -std::cos(yaw), 0}, {0, 0, -1}, {std::cos(yaw), std::sin(yaw), 0}}};
  const V3 Mc = mat_vec(M, centre), m{-Mc[0], -Mc[1], -Mc[2]};
  const double a = 0.01, b = 0.005;
  const M3 r_vi{{{std::cos(a), -std::sin(a), 0}, {std::sin(a), std::cos(a), 0}, {0, 0, 1}}};
  const V3 t_vi{-0.81, 0.32, -0.80};
  const M3 r_rect{{{1, 0, 0}, {0, std::cos(b), -std::sin(b)}, {0, std::sin(b), std::cos(b)}}};
  const V3 t{0.06, -0.0004, 0.0027};
  const double f = 721.5, cx = 609.6, cy = 172.9;
  // R_cv = R_rectᵀ·M·R_viᵀ, T_cv = R_rectᵀ·(m − t) − R_cv·T_vi: then R_rect·(R_cv·(R_vi·x + T_vi) + T_cv) + t = M·x + m.
  const M3 r_cv = mat_mul(transposed(r_rect), mat_mul(M, transposed(r_vi)));
  const V3 u = mat_vec(transposed(r_rect), V3{m[0] - t[0], m[1] - t[1], m[2] - t[2]}), w = mat_vec(r_cv, t_vi);
  const V3 t_cv{u[0] - w[0], u[1] - w[1], u[2] - w[2]};
  write_text((dir / "calib_imu_to_velo.txt").string(),
             "calib_time: 25-May-2012 16:47:16\nR:" + mat_text(r_vi) + "\nT:" + numbers({t_vi[0], t_vi[1], t_vi[2]}) + "\n");
  write_text((dir / "calib_velo_to_cam.txt").string(), "calib_time: 15-Mar-2012 11:37:16\nR:" + mat_text(r_cv) + "\nT:" +
                                                          numbers({t_cv[0], t_cv[1], t_cv[2]}) +
                                                          "\ndelta_f: 0 0\ndelta_c: 0 0\n");
  write_text((dir / "calib_cam_to_cam.txt").string(),
             "calib_time: 09-Jan-2012 13:57:47\ncorner_dist: 9.950000e-02\nR_rect_00:" + mat_text(r_rect) +
                 "\nP_rect_00:" + numbers({f, 0, cx, 0, 0, f, cy, 0, 0, 0, 1, 0}) + "\nP_rect_02:" +
                 numbers({f, 0, cx, f * t[0] + cx * t[2], 0, f, cy, f * t[1] + cy * t[2], 0, 0, 1, t[2]}) + "\n");
}
// The pose of a camera mounted `fwd` ahead of and `left` of the reference point, turned `yaw` to
// the left on its vehicle, after the vehicle ran time t on a circle at speed v and yaw rate w
// (left) from the first frame's pose 0, in photosite's road coordinates (X right, D ahead, a
// heading h's unit vectors ahead (sin h, cos h) and left (−cos h, sin h)): the vehicle's heading
// starts at yaw, the reference point at the camera less the lever, the circle's centre R = v/w
// to its left.
CameraPose turned_pose(double fwd, double left, double yaw, double v, double w, double t) {
  auto ahead_of = [](double h) { return std::array<double, 2>{std::sin(h), std::cos(h)}; };
  auto left_of = [](double h) { return std::array<double, 2>{-std::cos(h), std::sin(h)}; };
  const double R = v / w, h0 = yaw, h = yaw - w * t;
  const auto a0 = ahead_of(h0), l0 = left_of(h0), a = ahead_of(h), l = left_of(h);
  const double ref0X = -fwd * a0[0] - left * l0[0], ref0D = -fwd * a0[1] - left * l0[1];
  const double cX = ref0X + R * l0[0], cD = ref0D + R * l0[1];
  CameraPose p;
  p.X_m = cX - R * l[0] + fwd * a[0] + left * l[0];
  p.D_m = cD - R * l[1] + fwd * a[1] + left * l[1];
  p.yaw_rad = -w * t;
  return p;
}
}  // namespace

// KITTI raw's calibration chain (IMU → Velodyne → camera 0 → rectified → camera 2) read back to
// the camera's place and heading on the vehicle: synthetic files of a camera 1.2 m ahead of and
// 0.3 m left of the OXTS unit, turned 2° to the left; then a constant turn with that mount against
// its circle.
TEST(EgoMotion, KittiCalibrationPlacesCameraTwo) {
  test::TempDir tmp;
  const double yaw = 2 * std::numbers::pi / 180;
  write_kitti_calib(tmp.path() / "calib", {1.2, 0.3, 0.75}, yaw);
  const CameraMount m = read_kitti_camera_mount((tmp.path() / "calib").string());
  // The files hold the doubles (17 digits). The test's construction and the reader's composition
  // each take at most 6 products of orthonormal 3x3 matrices with each other or with vectors below
  // 2 m; each product's entries are 3-term dot products of a unit row, within 3·2⁻⁵³·√3·2 m of the
  // exact (Higham's γ₃): 12 products, 12·3·2·2·2⁻⁵³ m (√3 < 2). The yaw: atan2 of two such
  // entries of a unit vector, the same bound relative to 1 rad.
  EXPECT_NEAR(m.forward_m, 1.2, 12 * 3 * 2 * 2 * 0x1p-53);
  EXPECT_NEAR(m.left_m, 0.3, 12 * 3 * 2 * 2 * 0x1p-53);
  EXPECT_NEAR(m.yaw_rad, yaw, 12 * 3 * 2 * 0x1p-53);
  // A left turn at 8 m/s, 0.45 rad/s, stepped at KITTI's 10 Hz over 40 frames.
  const double v = 8, w = 0.45, dt = 0.1;
  CameraPose p;
  for (int k = 1; k <= 40; ++k) {
    OdometrySample a = sample((k - 1) * dt, v, w, m.forward_m, m.left_m), b = sample(k * dt, v, w, m.forward_m, m.left_m);
    a.camera_yaw_rad = b.camera_yaw_rad = m.yaw_rad;
    p = advance_pose(p, a, b, "t");
    const CameraPose c = turned_pose(m.forward_m, m.left_m, m.yaw_rad, v, w, k * dt);
    // As AConstantTurnStaysOnItsCircle, with the lever's left and yaw terms: about 40 rounded
    // operations a step (three vehicle-to-world turns, the arc, the sums) on values below 20 m,
    // the errors of earlier steps carried; the closed form's own two dozen, once.
    const double tol = (k + 1) * 40 * 20 * 0x1p-53;
    EXPECT_NEAR(p.X_m, c.X_m, tol) << "frame " << k;
    EXPECT_NEAR(p.D_m, c.D_m, tol) << "frame " << k;
    // The heading: three roundings a step ((yaw + ψ) − θ − ψ) of values below 2 rad, and the
    // closed form's product.
    EXPECT_NEAR(p.yaw_rad, c.yaw_rad, (3 * k + 2) * 2 * 0x1p-53) << "frame " << k;
  }
  // Without the lever arm and yaw (the OXTS unit taken as the camera's place) the same turn ends
  // 1.01 m elsewhere (the lever turned by 1.8 rad, and the path turned by the 2° yaw).
  const CameraPose c = turned_pose(0, 0, 0, v, w, 40 * dt);
  EXPECT_GT(std::hypot(p.X_m - c.X_m, p.D_m - c.D_m), 1.0);
}

// KITTI raw 2011_09_26's own calibration (calib_imu_to_velo.txt, calib_velo_to_cam.txt of
// 15-Mar-2012 11:37:16, calib_cam_to_cam.txt of 09-Jan-2012 13:57:47; quoted in
// https://nameidi.com/n/w2me18oz.html (imu_to_velo), https://xfxia.com/114260.html (R_rect_00), and
// the KITTI object benchmark's calib files, whose P2, R0_rect, Tr_velo_to_cam, Tr_imu_to_velo are
// that date's P_rect_02, R_rect_00, velo_to_cam, imu_to_velo): its 7-digit rotations pass the
// rounding bound, and the camera's place comes out as a generic 4x4 inversion of the chain puts it.
TEST(EgoMotion, KittiCalibrationOf20110926) {
  test::TempDir tmp;
  const auto dir = tmp.path() / "2011_09_26";
  std::filesystem::create_directories(dir);
  write_text((dir / "calib_imu_to_velo.txt").string(),
             "calib_time: 25-May-2012 15:08:45\nR: 9.999976e-01 7.553071e-04 -2.035826e-03 -7.854027e-04 9.998898e-01 "
             "-1.482298e-02 2.024406e-03 1.482454e-02 9.998881e-01\nT: -8.086759e-01 3.195559e-01 -7.997231e-01\n");
  write_text((dir / "calib_velo_to_cam.txt").string(),
             "calib_time: 15-Mar-2012 11:37:16\nR: 7.533745e-03 -9.999714e-01 -6.166020e-04 1.480249e-02 7.280733e-04 "
             "-9.998902e-01 9.998621e-01 7.523790e-03 1.480755e-02\nT: -4.069766e-03 -7.631618e-02 -2.717806e-01\n"
             "delta_f: 0.000000e+00 0.000000e+00\ndelta_c: 0.000000e+00 0.000000e+00\n");
  write_text((dir / "calib_cam_to_cam.txt").string(),
             "calib_time: 09-Jan-2012 13:57:47\ncorner_dist: 9.950000e-02\n"
             "R_rect_00: 9.999239e-01 9.837760e-03 -7.445048e-03 -9.869795e-03 9.999421e-01 -4.278459e-03 7.402527e-03 "
             "4.351614e-03 9.999631e-01\n"
             "P_rect_02: 7.215377e+02 0.000000e+00 6.095593e+02 4.485728e+01 0.000000e+00 7.215377e+02 1.728540e+02 "
             "2.163791e-01 0.000000e+00 0.000000e+00 1.000000e+00 2.745884e-03\n");
  const CameraMount m = read_kitti_camera_mount(dir.string());
  // The chain as one 4x4 matrix A (x_img-free: x_cam2 = A·x_imu, homogeneous), P_rect_02's K⁻¹
  // applied to its 4th column, then the camera's centre as the solution of A·[c; 1] = 0 by
  // Gaussian elimination (no orthonormality assumed).
  const double P[3][4] = {{721.5377, 0, 609.5593, 44.85728}, {0, 721.5377, 172.854, 0.2163791}, {0, 0, 1, 0.002745884}};
  const double tz = P[2][3], ty = (P[1][3] - P[1][2] * tz) / P[1][1], tx = (P[0][3] - P[0][2] * tz) / P[0][0];
  auto h = [](std::initializer_list<double> r, std::initializer_list<double> t) {
    std::array<std::array<double, 4>, 4> a{};
    auto ri = r.begin(), ti = t.begin();
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) a[i][j] = *ri++;
      a[i][3] = *ti++;
    }
    a[3][3] = 1;
    return a;
  };
  auto mul4 = [](const auto& a, const auto& b) {
    std::array<std::array<double, 4>, 4> c{};
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 4; ++j)
        for (int k = 0; k < 4; ++k) c[i][j] += a[i][k] * b[k][j];
    return c;
  };
  const auto A = mul4(h({1, 0, 0, 0, 1, 0, 0, 0, 1}, {tx, ty, tz}),
                      mul4(h({9.999239e-01, 9.837760e-03, -7.445048e-03, -9.869795e-03, 9.999421e-01, -4.278459e-03,
                              7.402527e-03, 4.351614e-03, 9.999631e-01}, {0, 0, 0}),
                           mul4(h({7.533745e-03, -9.999714e-01, -6.166020e-04, 1.480249e-02, 7.280733e-04, -9.998902e-01,
                                   9.998621e-01, 7.523790e-03, 1.480755e-02}, {-4.069766e-03, -7.631618e-02, -2.717806e-01}),
                                h({9.999976e-01, 7.553071e-04, -2.035826e-03, -7.854027e-04, 9.998898e-01, -1.482298e-02,
                                   2.024406e-03, 1.482454e-02, 9.998881e-01}, {-8.086759e-01, 3.195559e-01, -7.997231e-01}))));
  // Solve A₃ₓ₃·c = −A[:,3] (partial pivoting).
  double g[3][4];
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) g[i][j] = A[i][j];
    g[i][3] = -A[i][3];
  }
  for (int col = 0; col < 3; ++col) {
    int piv = col;
    for (int r = col + 1; r < 3; ++r)
      if (std::fabs(g[r][col]) > std::fabs(g[piv][col])) piv = r;
    std::swap(g[col], g[piv]);
    for (int r = 0; r < 3; ++r)
      if (r != col) {
        const double q = g[r][col] / g[col][col];
        for (int j = col; j < 4; ++j) g[r][j] -= q * g[col][j];
      }
  }
  const double cx = g[0][3] / g[0][0], cy = g[1][3] / g[1][1];
  // The reader inverts M by its transpose: M's rows are orthonormal only to the files' 7 digits,
  // each entry of M·Mᵀ − I within 3·1.01·10⁻⁷ to first order (three factors, each within the
  // reader's bound, at most 1.01·10⁻⁷ for these entries), so Mᵀ − M⁻¹ too, and the centre
  // −Mᵀ·m differs by at most that times |m|₁ <= √3·|c| < 1.75·1.4 m.
  EXPECT_NEAR(m.forward_m, cx, 3 * 1.01e-7 * 1.75 * 1.4);
  EXPECT_NEAR(m.left_m, cy, 3 * 1.01e-7 * 1.75 * 1.4);
  // The heading: the optical axis is A's third row (exact in both; only the roundings of the
  // products, 12 products as above relative to 1 rad).
  EXPECT_NEAR(m.yaw_rad, std::atan2(A[2][1], A[2][0]), 12 * 3 * 2 * 0x1p-53);
  std::fprintf(stderr, "[kitti 2011_09_26] camera 2 on the vehicle: %.4f m ahead of the OXTS unit, %.4f m left, yaw %.5f rad\n",
               m.forward_m, m.left_m, m.yaw_rad);
}

// Bad calibration files: refused naming the file and the line.
TEST(EgoMotion, KittiCalibrationBadInput) {
  test::TempDir tmp;
  const auto dir = tmp.path() / "c";
  auto refused = [&](const std::string& file, const std::string& from, const std::string& to,
                     std::initializer_list<std::string> parts) {
    write_kitti_calib(dir, {1.2, 0.3, 0.75}, 0.03);
    const std::string path = (dir / file).string();
    std::ifstream in(path, std::ios::binary);
    std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    in.close();
    const auto at = text.find(from);
    ASSERT_NE(at, std::string::npos) << from;
    text.replace(at, from.size(), to);
    write_text(path, text);
    expect_refused([&] { read_kitti_camera_mount(dir.string()); }, parts);
  };
  refused("calib_imu_to_velo.txt", "T:", "Tx:", {"calib_imu_to_velo.txt", "no line \"T: ...\""});
  refused("calib_velo_to_cam.txt", "R: ", "R: 1 ", {"calib_velo_to_cam.txt", "R: holds 10 numbers, not 9"});
  refused("calib_cam_to_cam.txt", "P_rect_02: ", "P_rect_02: x ", {"calib_cam_to_cam.txt", "P_rect_02: holds 0 numbers and then text"});
  // R_rect_00's first entry 1 + 10⁻⁵: (R·Rᵀ)[0][0] 2·10⁻⁵ off the identity's, 20 times the bound
  // (10⁻⁶ for an entry near 1 written to 7 digits).
  refused("calib_cam_to_cam.txt", "R_rect_00: 1 ", "R_rect_00: 1.00001 ", {"calib_cam_to_cam.txt", "R_rect_00: not a rotation"});
  // A reflection (x negated) is orthonormal but not a rotation.
  refused("calib_cam_to_cam.txt", "R_rect_00: 1 ", "R_rect_00: -1 ", {"calib_cam_to_cam.txt", "R_rect_00: not a rotation: a reflection"});
  refused("calib_imu_to_velo.txt", "T: -0.81", "T: -30.81", {"calib_imu_to_velo.txt", "ahead of the OXTS unit: ", "outside [-20, 20]"});
  write_kitti_calib(dir, {1.2, 0.3, 0.75}, 0.7);  // 40°: not a forward camera
  expect_refused([&] { read_kitti_camera_mount(dir.string()); }, {"calib_imu_to_velo.txt", "heading on the vehicle: ", "rad is outside [-0.5, 0.5]"});
  std::filesystem::remove(dir / "calib_cam_to_cam.txt");
  expect_refused([&] { read_kitti_camera_mount(dir.string()); }, {"calib_cam_to_cam.txt", "cannot read KITTI calibration"});
}

// `batch --sequence` over a KITTI drive with its calibration at calib/<sub>/: the frames' poses
// follow the camera 1.2 m ahead of and 0.3 m left of the OXTS unit, turned 2° left, through a
// left turn (the closed form of KittiCalibrationPlacesCameraTwo); the header records the mount.
// A broken calibration file fails every frame, naming it.
TEST(EgoMotion, BatchKittiWithCalibration) {
  test::TempDir tmp;
  const auto root = tmp.path() / "kitti";
  for (const char* d : {"image_2/drive", "semantic/drive", "oxts/drive/data"}) std::filesystem::create_directories(root / d);
  const double yaw = 2 * std::numbers::pi / 180, v = 8, w = 0.45;
  write_kitti_calib(root / "calib" / "drive", {1.2, 0.3, 0.75}, yaw);
  ImageF day(64, 32, 3, 0.25f);
  ImageF ids(64, 32, 1, 7 / 255.0f);  // road
  for (int y = 0; y < 12; ++y)
    for (int x = 0; x < 64; ++x) ids.at(x, y) = 23 / 255.0f;  // sky above
  std::string oxts;
  for (int k = 0; k < 30; ++k) oxts += (k == 8 ? "8" : k == 22 ? "0.45" : "0") + std::string(k < 29 ? " " : "\n");
  std::string stamps;
  for (int f = 0; f < 3; ++f) {
    const std::string name = "000000000" + std::to_string(f);
    write_png((root / "image_2" / "drive" / (name + ".png")).string(), day);
    write_png((root / "semantic" / "drive" / (name + ".png")).string(), ids);
    write_text((root / "oxts" / "drive" / "data" / (name + ".txt")).string(), oxts);
    stamps += "2011-09-26 13:02:2" + std::to_string(f) + ".000\n";  // 1 s apart
  }
  write_text((root / "oxts" / "drive" / "timestamps.txt").string(), stamps);
  const std::string base = "batch --dataset kitti --root '" + root.string() + "' --layers lights --quiet --device-store '" +
                           tmp.file("store") + "' --sequence --out '";
  auto r = test::run_cli(base + tmp.file("a") + "'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto attrs = read_exr_attributes(tmp.file("a") + "/image_2/drive/0000000002.exr");
  const CameraPose c = turned_pose(1.2, 0.3, yaw, v, w, 2.0);
  // Two steps of about 40 roundings of values below 20 m and the closed form's (KittiCalibration-
  // PlacesCameraTwo: 3·40·20·2⁻⁵³), the mount's place error (12·3·2·2·2⁻⁵³ m) at both ends of the
  // run, and its yaw error (12·3·2·2⁻⁵³ rad) turning the 16 m run: 16·12·3·2·2⁻⁵³ m.
  const double tol = (3 * 40 * 20 + 2 * 12 * 3 * 2 * 2 + 16 * 12 * 3 * 2) * 0x1p-53;
  EXPECT_NEAR(std::stod(attrs.at("photosite/batch/pose_X_m_text")), c.X_m, tol);
  EXPECT_NEAR(std::stod(attrs.at("photosite/batch/pose_D_m_text")), c.D_m, tol);
  // The heading: the mount's yaw is added and taken off again each step; three roundings a step.
  EXPECT_NEAR(std::stod(attrs.at("photosite/batch/pose_yaw_rad_text")), c.yaw_rad, (3 * 2 + 2) * 2 * 0x1p-53);
  EXPECT_NEAR(std::stod(attrs.at("photosite/batch/camera_forward_m_text")), 1.2, 12 * 3 * 2 * 2 * 0x1p-53);
  EXPECT_NEAR(std::stod(attrs.at("photosite/batch/camera_left_m_text")), 0.3, 12 * 3 * 2 * 2 * 0x1p-53);
  EXPECT_NEAR(std::stod(attrs.at("photosite/batch/camera_yaw_rad_text")), yaw, 12 * 3 * 2 * 0x1p-53);
  EXPECT_NE(attrs.at("photosite/batch/camera_mount").find("KITTI calibration"), std::string::npos);
  // The OXTS unit's path alone (main's pose before the calibration was read) puts frame 2's camera
  // 0.56 m away: far outside the tolerance.
  const CameraPose bare = turned_pose(0, 0, 0, v, w, 2.0);
  EXPECT_GT(std::hypot(c.X_m - bare.X_m, c.D_m - bare.D_m), 0.5);
  std::fprintf(stderr, "[kitti calib] frame 2 pose: X %s m, D %s m (OXTS unit alone: X %.6f m, D %.6f m)\n",
               attrs.at("photosite/batch/pose_X_m_text").c_str(), attrs.at("photosite/batch/pose_D_m_text").c_str(),
               bare.X_m, bare.D_m);
  // A run that took the OXTS unit's place is not resumed by one that reads the calibration (the
  // resume manifest's camera_mount), nor the reverse.
  std::filesystem::rename(root / "calib", root / "calib.off");
  r = test::run_cli(base + tmp.file("c") + "'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::filesystem::rename(root / "calib.off", root / "calib");
  r = test::run_cli(base + tmp.file("c") + "'");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("camera_mount"), std::string::npos) << r.output;
  r = test::run_cli(base + tmp.file("a") + "'");  // the same run again: resumed (all done)
  EXPECT_EQ(r.exit_code, 0) << r.output;
  std::filesystem::rename(root / "calib", root / "calib.off");
  r = test::run_cli(base + tmp.file("a") + "'");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("camera_mount"), std::string::npos) << r.output;
  std::filesystem::rename(root / "calib.off", root / "calib");
  // A calibration file without its T line: every frame fails, naming it; nothing is written.
  write_text((root / "calib" / "drive" / "calib_velo_to_cam.txt").string(), "R: 1 0 0 0 1 0 0 0 1\n");
  r = test::run_cli(base + tmp.file("b") + "'");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("calib_velo_to_cam.txt: no line \"T: ...\""), std::string::npos) << r.output;
  EXPECT_FALSE(std::filesystem::exists(tmp.file("b") + "/image_2/drive/0000000000.exr"));
}
