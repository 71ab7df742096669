// depth.Z against stereo ground truth (scene/depth_eval.cpp, `photosite bench depth`): KITTI
// calibration and disparity decoding, the error measures, and the whole bench on a scene
// rendered from a known camera whose true depth is written as a KITTI disparity map.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "photosite/error.h"
#include "photosite/io.h"
#include "photosite/scene/depth_eval.h"
#include "photosite/scene/night.h"
#include "photosite/scene/rig.h"
#include "photosite/sensor/isp.h"
#include "test_util.h"

using namespace photosite;
using namespace photosite::scene;
namespace fs = std::filesystem;

namespace {
// A calib_cam_to_cam.txt in KITTI's format, with the rectified projections of the 2011_09_26
// drives (fx 721.5377 px; the right colour camera 0.5327 m to the right of the left one).
const char* kCalib =
    "calib_time: 09-Jan-2012 13:57:47\n"
    "P_rect_02: 7.215377e+02 0.000000e+00 6.095593e+02 4.485728e+01 0.000000e+00 7.215377e+02 1.728540e+02 "
    "2.163791e-01 0.000000e+00 0.000000e+00 1.000000e+00 2.745884e-03\n"
    "P_rect_03: 7.215377e+02 0.000000e+00 6.095593e+02 -3.395242e+02 0.000000e+00 7.215377e+02 1.728540e+02 "
    "2.199936e+00 0.000000e+00 0.000000e+00 1.000000e+00 2.729905e-03\n";

std::vector<std::vector<std::string>> read_csv(const std::string& path) {
  std::ifstream in(path);
  std::vector<std::vector<std::string>> rows;
  std::string line;
  while (std::getline(in, line)) {
    std::vector<std::string> cells;
    std::stringstream ss(line);
    std::string c;
    while (std::getline(ss, c, ',')) cells.push_back(c);
    rows.push_back(cells);
  }
  return rows;
}
}  // namespace

TEST(DepthEval, KittiCalibrationAndDisparity) {
  test::TempDir dir;
  std::ofstream(dir.file("calib.txt")) << kCalib;
  const StereoCalibration c = read_kitti_stereo_calibration(dir.file("calib.txt"));
  EXPECT_DOUBLE_EQ(c.fx_px, 721.5377);
  EXPECT_DOUBLE_EQ(c.baseline_m, (44.85728 + 339.5242) / 721.5377);  // 0.5327 m
  // z = fx·B / d with d = code / 256; code 0 is no measurement.
  ImageU16 codes(3, 1, 1, 0);
  codes[0] = 2560;   // 10 px
  codes[1] = 65535;  // 255.996 px
  const ImageF z = depth_from_kitti_disparity(codes, c);
  EXPECT_FLOAT_EQ(z[0], static_cast<float>(c.fx_px * c.baseline_m / 10));
  EXPECT_FLOAT_EQ(z[1], static_cast<float>(c.fx_px * c.baseline_m * 256 / 65535));
  EXPECT_TRUE(std::isnan(z[2]));
  // A file without P_rect_03, or with a short row, names the file and the row.
  std::ofstream(dir.file("short.txt")) << "P_rect_02: 1 2 3\n";
  EXPECT_NE(test::error_of([&] { read_kitti_stereo_calibration(dir.file("short.txt")); }).find("P_rect_02: expected 12"),
            std::string::npos);
  std::ofstream(dir.file("one.txt")) << std::string(kCalib).substr(0, std::string(kCalib).find("P_rect_03"));
  EXPECT_NE(test::error_of([&] { read_kitti_stereo_calibration(dir.file("one.txt")); }).find("P_rect_03: missing"),
            std::string::npos);
}

// The measures themselves: a depth map 20% short of the truth everywhere gives exactly 0.2 on the
// road and at every vehicle contact; unmeasured pixels and pixels beyond the cap are left out.
// Nearest rank: rank round(q (n - 1)); the median of an even count is the upper one (rank n/2),
// which the pooled medians of `photosite bench depth` rely on.
TEST(DepthEval, NearestRankQuantile) {
  EXPECT_TRUE(std::isnan(nearest_rank_quantile({}, 0.5)));
  EXPECT_EQ(nearest_rank_quantile({7}, 0.9), 7);
  EXPECT_EQ(nearest_rank_quantile({4, 1, 3, 2}, 0.5), 3);     // ranks 0..3: round(1.5) = 2
  EXPECT_EQ(nearest_rank_quantile({5, 1, 4, 2, 3}, 0.5), 3);  // round(2) = 2
  EXPECT_EQ(nearest_rank_quantile({5, 1, 4, 2, 3}, 0.0), 1);
  EXPECT_EQ(nearest_rank_quantile({5, 1, 4, 2, 3}, 1.0), 5);
  EXPECT_EQ(nearest_rank_quantile({10, 9, 8, 7, 6, 5, 4, 3, 2, 1}, 0.9), 9);  // round(8.1) = 8
}

TEST(DepthEval, ErrorsOfAKnownScaleError) {
  const int W = 40, H = 20;
  LabelMap lm;
  lm.ids = ImageU16(W, H, 1, static_cast<uint16_t>(Label::Road));
  for (int y = 0; y < 6; ++y)
    for (int x = 0; x < W; ++x) lm.ids.at(x, y) = static_cast<uint16_t>(Label::Sky);
  for (int y = 8; y < 14; ++y)  // two cars, 8 x 6 px each, no instance file
    for (int x : {4, 5, 6, 7, 8, 9, 10, 11, 24, 25, 26, 27, 28, 29, 30, 31}) lm.ids.at(x, y) = static_cast<uint16_t>(Label::Car);
  ImageF truth(W, H, 1), depth(W, H, 1);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      truth.at(x, y) = y < 6 ? NAN : 5.0f + 100.0f / (y - 5);  // unmeasured sky
      depth.at(x, y) = truth.at(x, y) * 0.8f;
    }
  truth.at(0, 19) = 2000;  // beyond the 1000 m cap: left out
  depth.at(0, 19) = 1;
  const DepthErrors e = depth_errors(depth, truth, lm, 1000, 20);
  EXPECT_EQ(e.road_pixels, static_cast<size_t>(14 * W - 2 * 8 * 6 - 1));
  // depth = fl(truth·0.8f): 0.8f is 0.8 within 2⁻²⁴ relative and the product rounds once more,
  // so depth/truth = 0.8(1 + δ) with |δ| ≤ 2·2⁻²⁴, and |depth − truth|/truth = 0.2 − 0.8δ (the
  // difference of two floats is exact in double, the quotient rounds once, 2⁻⁵³).
  const double rel_tol = 0.8 * 2 * 0x1p-24 + 0x1p-53;
  EXPECT_NEAR(e.road_median_rel, 0.2, rel_tol);
  EXPECT_NEAR(e.road_p90_rel, 0.2, rel_tol);
  ASSERT_EQ(e.contacts, 2u);
  EXPECT_NEAR(e.contact_median_rel, 0.2, rel_tol);
  // Too small to count as vehicles: none.
  EXPECT_EQ(depth_errors(depth, truth, lm, 1000, 49).contacts, 0u);
  EXPECT_NE(test::error_of([&] { depth_errors(depth, ImageF(W, H + 1, 1), lm, 1000); }).find("must be one size"),
            std::string::npos);
}

// The bench end to end on a scene rendered from the Cityscapes rig at 1024x512 (what `--rig
// auto` picks for a 2:1 image), its true depth written as a KITTI disparity map with the rig's fx
// and the 0.54 m fallback baseline (no calibration file): the errors must meet the issue's
// synthetic-scene bounds, 2% on the ground and 5% at box contacts (tests/scene_metric_test.cpp
// derives them), plus the disparity's rounding to 1/256 px: at most 0.5/code relative, 0.3% at
// 1000 m (code 156).
TEST(DepthEval, BenchOnARenderedSceneMeetsTheSyntheticBounds) {
  test::TempDir dir;
  SyntheticCameraOptions o;
  o.width = 1024;
  o.height = 512;
  VanishingPoint none;
  o.camera = camera_geometry(load_camera_rig("cityscapes"), o.width, o.height, none);
  o.boxes = {{-3.5, 12, 1.8, 1.5, 4.5}, {3.2, 20, 1.8, 1.5, 4.5}, {0.0, 32, 2.5, 3.0, 10}};
  const SyntheticCameraScene s = make_synthetic_camera_scene(o);
  for (const char* d : {"image_2", "semantic", "instance", "disp_occ_0"}) fs::create_directories(dir.path() / "k" / d);
  ImageF srgb = s.day_linear_srgb;
  for (auto& v : srgb.vec()) v = static_cast<float>(srgb_encode(v));
  write_png(dir.file("k/image_2/000007_10.png"), srgb);
  ImageF ids(o.width, o.height, 1), inst(o.width, o.height, 1), disp(o.width, o.height, 1);
  const double fb256 = o.camera.f_px * 0.54 * 256;
  for (size_t i = 0; i < ids.size(); ++i) {
    ids[i] = s.labels.ids[i] / 255.0f;
    inst[i] = s.labels.instances.empty() ? 0.f : s.labels.instances[i] / 65535.0f;
    const double z = s.depth_m[i];
    const double code = z < kDepthInfinity_m ? std::round(fb256 / z) : 0;
    disp[i] = static_cast<float>(std::min(code, 65535.0) / 65535.0);
  }
  write_png(dir.file("k/semantic/000007_10.png"), ids);
  write_png(dir.file("k/instance/000007_10.png"), inst, 16);
  write_png(dir.file("k/disp_occ_0/000007_10.png"), disp, 16);
  const auto r = test::run_cli("bench depth --kitti '" + dir.file("k") + "' --out-dir '" + dir.path().string() + "'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::fprintf(stderr, "%s", r.output.c_str());
  const auto rows = read_csv(dir.file("bench_depth.csv"));
  ASSERT_EQ(rows.size(), 3u) << r.output;  // header, the frame, the pooled row
  const auto& f = rows[1];
  ASSERT_EQ(f.size(), 10u);
  EXPECT_EQ(f[0], "000007_10");
  EXPECT_EQ(f[4], "rig fx; baseline 0.54 m");  // no calibration file
  EXPECT_GT(std::stol(f[5]), 10000) << r.output;  // road pixels with a measurement
  EXPECT_LE(std::stod(f[6]), 0.02 + 0.003) << r.output;
  EXPECT_EQ(std::stol(f[8]), 3) << r.output;  // the three boxes
  EXPECT_LE(std::stod(f[9]), 0.05 + 0.003) << r.output;
  // The pooled row: the counts summed over the frames (one frame here), in the same columns.
  const auto& all = rows[2];
  ASSERT_EQ(all.size(), 10u);
  EXPECT_EQ(all[0], "all");
  EXPECT_EQ(all[5], f[5]) << "road_pixels";
  EXPECT_EQ(all[6], f[6]) << "the median of one frame's median";
  EXPECT_EQ(all[8], f[8]) << "contacts";
  // Bad input: no ground truth folder.
  fs::remove_all(dir.path() / "k" / "disp_occ_0");
  const auto bad = test::run_cli("bench depth --kitti '" + dir.file("k") + "' --out-dir '" + dir.path().string() + "'");
  EXPECT_EQ(bad.exit_code, 2) << bad.output;
  EXPECT_NE(bad.output.find("disp_occ_0: not a folder"), std::string::npos) << bad.output;
}
