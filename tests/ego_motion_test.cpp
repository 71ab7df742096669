// The camera's motion over a sequence from the data sets' odometry (scene/ego_motion.cpp): the
// dead reckoning against closed forms, the readers of Cityscapes' vehicle and timestamp files and
// of KITTI raw's OXTS records, and their bad input.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

#include "photosite/error.h"
#include "photosite/io.h"
#include "photosite/scene/ego_motion.h"
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
  const OdometrySample s = read_cityscapes_odometry(tmp.file("v.json"), tmp.file("t.txt"), tmp.file("c.json"));
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
  write_text(tmp.file("sideways.json"), R"({"extrinsic": {"x": 1.7, "y": 0.1, "yaw": 90}})");  // degrees
  expect_refused([&] { read_cityscapes_odometry(tmp.file("v.json"), tmp.file("t.txt"), tmp.file("sideways.json")); },
                 {"sideways.json", "extrinsic.yaw: 90"});
  write_text(tmp.file("nox.json"), R"({"extrinsic": {"y": 0.1}})");
  expect_refused([&] { read_cityscapes_odometry(tmp.file("v.json"), tmp.file("t.txt"), tmp.file("nox.json")); },
                 {"nox.json", "x: missing"});
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
  std::fprintf(stderr, "[cityscapes odometry] frame 19 pose: X %s m, D %s m, yaw %s rad\n",
               a1.at("photosite/batch/pose_X_m_text").c_str(), a1.at("photosite/batch/pose_D_m_text").c_str(),
               a1.at("photosite/batch/pose_yaw_rad_text").c_str());
}
