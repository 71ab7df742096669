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

// `bench depth --synthetic`: the horizon's error and the depth errors on streets rendered from a
// known camera, the true pitch off the rig's nominal. The first fifteen cases are the straight
// street with the camera 20, 40 and 50 m from its origin, each at pitch offsets 0, +0.5, −0.5, +1.0
// and −1.0 degrees (on this build both horizons occur among them: 5 of the 15 take the rig's).
// Checked: one row per case with every column; the renderer's own geometry gives its depth back on
// the road (true_road_median_rel: the plane's depth in double, both stored as float, so within a
// few float roundings, 2⁻²⁴ each: 1e-6 is 16 of them); where the rig's horizon is taken its error
// is the offset itself (−offset degrees, printed to 3 decimals) and the road error as run is the
// rig's (the same ground plane); --synthetic with --kitti, and neither, are refused naming them.
TEST(DepthEval, SyntheticBenchMeasuresTheHorizonOnRenderedStreets) {
  test::TempDir dir;
  const auto r = test::run_cli("bench depth --synthetic --max-frames 15 --out-dir '" + dir.path().string() + "'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::fprintf(stderr, "%s", r.output.c_str());
  const auto rows = read_csv(dir.file("bench_depth_synthetic.csv"));
  ASSERT_EQ(rows.size(), 16u) << r.output;  // header and fifteen cases
  ASSERT_EQ(rows[0].size(), 18u);
  EXPECT_EQ(rows[0][7], "horizon_error_px");
  const double offsets[5] = {0, 0.5, -0.5, 1.0, -1.0};
  int rig_rows = 0;
  for (int k = 1; k <= 15; ++k) {
    const auto& c = rows[k];
    ASSERT_EQ(c.size(), 18u);
    SCOPED_TRACE(::testing::Message() << "case " << k);
    EXPECT_EQ(std::stod(c[0]), 0);  // straight
    EXPECT_DOUBLE_EQ(std::stod(c[2]), offsets[(k - 1) % 5]);
    EXPECT_GT(std::stol(c[10]), 1000) << "road pixels";
    EXPECT_LE(std::stod(c[17]), 1e-6) << "the renderer's geometry against its own depth";
    if (c[6] == "rig") {
      ++rig_rows;
      // The printed degrees are rounded to 3 decimals: half a unit, 5e-4.
      EXPECT_NEAR(std::stod(c[8]), -offsets[(k - 1) % 5], 5e-4);
      EXPECT_EQ(c[11], c[15]) << "road error as run against the rig's";
    } else {
      EXPECT_EQ(c[6], "vanishing_point");
      EXPECT_EQ(c[4], "hough");
    }
  }
  std::fprintf(stderr, "[bench depth --synthetic] %d of 15 cases took the rig's horizon\n", rig_rows);
  const auto both = test::run_cli("bench depth --synthetic --kitti /nonexistent --out-dir '" + dir.path().string() + "'");
  EXPECT_EQ(both.exit_code, 2) << both.output;
  EXPECT_NE(both.output.find("--synthetic and --kitti: give one"), std::string::npos) << both.output;
  const auto neither = test::run_cli("bench depth --out-dir '" + dir.path().string() + "'");
  EXPECT_EQ(neither.exit_code, 2) << neither.output;
  EXPECT_NE(neither.output.find("--kitti: give the folder"), std::string::npos) << neither.output;
}

// ---------------------------------------------------------------------------------------------
// Dashed markings as rulers (`photosite bench markings`).
namespace {
// The Cityscapes rig at its native 2048 x 1024 with its nominal pitch, a straight road whose lane
// lines are dashed as an advisory cycle lane's (ERA 2010: 1 m dash, 1 m gap), no boxes.
SyntheticCameraOptions dashed_road(double dash_m = 1, double period_m = 2) {
  SyntheticCameraOptions o;
  o.width = 2048;
  o.height = 1024;
  o.camera = camera_geometry(load_camera_rig("cityscapes"), o.width, o.height, VanishingPoint{});
  o.dash_m = dash_m;
  o.dash_period_m = period_m;
  return o;
}
ImageU8 markings_of(const SyntheticCameraScene& s, const ScenePreset& p, const CameraGeometry& g) {
  const WorkImages w = make_work_images(s.day_linear_srgb, s.labels.ids, s.day_linear_srgb.width());
  return metric_marking_mask(w.luma, w.labels, g, p.lane_blur_sigma_px, p.lane_contrast_threshold);
}
// The ground a row spans at distance D (between the edges half a row either side of its row).
double row_span_m(const CameraGeometry& g, double D) {
  double u, v, z, D0, D1;
  g.project(0, 0, D, &u, &v, &z);
  g.ground_point(u, v - 0.5, nullptr, &D1, nullptr);
  g.ground_point(u, v + 0.5, nullptr, &D0, nullptr);
  return D1 - D0;
}
// How far (rows) the marking detector's mask reaches past a dash's true end: the end is a step of
// contrast c blurred by a Gaussian of σ = lane_blur_sigma_px, marked while the blurred excess over
// the road stays above lane_contrast_threshold t, i.e. to σ·Φ⁻¹(1 − t/c) beyond the edge. c: the
// synthetic marking (0.8) against the asphalt's darkest checker (0.08 × 1.1), sRGB-encoded as
// the detector sees them; the 0.5 row of the pixel-centre sampling comes on top.
double end_reach_rows(const ScenePreset& p) {
  const double c = srgb_encode(0.8) - srgb_encode(0.08 * 1.1), q = 1 - p.lane_contrast_threshold / c;
  // Φ⁻¹(q) by bisection on erfc.
  double lo = 0, hi = 8;
  for (int i = 0; i < 60; ++i) {
    const double m = 0.5 * (lo + hi);
    (0.5 * std::erfc(-m / std::sqrt(2.0)) < q ? lo : hi) = m;
  }
  return p.lane_blur_sigma_px * lo + 0.5;
}
}  // namespace

TEST(MarkingDashes, SyntheticDashesGiveTheRayCastPeriod) {
  const SyntheticCameraOptions o = dashed_road();
  const SyntheticCameraScene s = make_synthetic_camera_scene(o);
  const ScenePreset p = load_scene_preset("night-urban");
  const ImageU8 marks = markings_of(s, p, o.camera);
  const std::vector<MarkingDash> dashes = marking_dashes(marks, s.labels.ids, o.camera);
  const std::vector<DashedLine> lines = dashed_lines(dashes);
  ASSERT_EQ(lines.size(), 2u) << dashes.size() << " dashes";  // the two lane lines at X = ±1.75 m
  const double e = end_reach_rows(p);
  for (const DashedLine& L : lines) {
    std::fprintf(stderr, "[dashes] line at X %.2f m: %zu dashes, %.1f-%.1f m, period %.4f m (sd %.4f), dash %.3f m, slope %.2e ± %.1e\n",
                 L.X_m, L.dashes.size(), L.dashes.front().near_D_m, L.dashes.back().far_D_m, L.period_median_m,
                 L.period_sd_m, L.dash_median_m, L.slope, L.slope_se);
    // The detected centre within the 0.15 m line's half-width (night.h: lane lines 0.15 m wide) plus
    // the ground one row spans at the nearest dash (the mask's row quantisation).
    EXPECT_NEAR(std::fabs(L.X_m), 1.75, 0.075 + row_span_m(o.camera, L.dashes[0].near_D_m)) << "the line's centre";
    EXPECT_GE(L.dashes.size(), 10u);  // 5-28 m of 2 m periods
    for (size_t i = 0; i < L.periods_m.size(); ++i) {
      EXPECT_TRUE(L.regular[i]) << i;
      // Each end within e rows of the true edge (sampling and blur), the same reach at the start of
      // both dashes: a period's error is at most e·(span at one dash's end + span at the other's),
      // averaged over the near and far ends.
      const MarkingDash &a = L.dashes[i], &b = L.dashes[i + 1];
      const double bound = 0.5 * e * (row_span_m(o.camera, a.near_D_m) + row_span_m(o.camera, b.near_D_m) +
                                       row_span_m(o.camera, a.far_D_m) + row_span_m(o.camera, b.far_D_m));
      EXPECT_NEAR(L.periods_m[i], 2.0, bound) << "period " << i << " at " << L.at_D_m[i] << " m";
    }
    // The dash: its two ends reach e rows each beyond the paint.
    const MarkingDash& far = L.dashes.back();
    EXPECT_NEAR(L.dash_median_m, 1.0, e * (row_span_m(o.camera, far.near_D_m) + row_span_m(o.camera, far.far_D_m)));
    // The painted length, the intercept of the lengths against the end rows' spans: the blur's
    // reach is the same number of rows at every end here, so what remains is each end's sampling,
    // within half a row: ε_i ≤ (s_near + s_far)/2. The OLS intercept is Σ w_i·L_i with
    // w_i = 1/n − x̄·(x_i − x̄)/Sxx, so its error is at most Σ|w_i| · max ε_i.
    {
      const size_t n = L.dashes.size();
      double xm = 0, sxx = 0, eps = 0, wsum = 0;
      std::vector<double> x(n);
      for (size_t i = 0; i < n; ++i) x[i] = L.dashes[i].near_row_m + L.dashes[i].far_row_m, xm += x[i] / n;
      for (size_t i = 0; i < n; ++i) sxx += (x[i] - xm) * (x[i] - xm), eps = std::max(eps, x[i] / 2);
      for (size_t i = 0; i < n; ++i) wsum += std::fabs(1.0 / n - xm * (x[i] - xm) / sxx);
      std::fprintf(stderr, "[dashes] painted %.4f m (bound %.4f), reach %.2f rows (blur's %.2f)\n", L.dash_painted_m,
                   wsum * eps, L.reach_rows, e - 0.5);
      EXPECT_NEAR(L.dash_painted_m, 1.0, wsum * eps);
    }
    // At the right horizon the periods have no slope within 4 standard errors, and the horizon
    // they imply is the rig's within 4 of its standard errors.
    EXPECT_LE(std::fabs(L.slope), 4 * L.slope_se);
    const FlatHorizon fh = flat_period_horizon(L, o.camera);
    ASSERT_TRUE(std::isfinite(fh.shift_px));
    EXPECT_LE(std::fabs(fh.shift_px), 4 * fh.se_px) << fh.shift_px << " ± " << fh.se_px;
    const DashStandard* st = nearest_dash_standard(L.period_median_m, L.dash_median_m);
    ASSERT_NE(st, nullptr);
    EXPECT_EQ(st->dash_m, 1.0);
    EXPECT_EQ(st->gap_m, 1.0);
  }
}

TEST(MarkingDashes, AShiftedHorizonShowsInThePeriods) {
  const SyntheticCameraOptions o = dashed_road();
  const SyntheticCameraScene s = make_synthetic_camera_scene(o);
  const ScenePreset p = load_scene_preset("night-urban");
  // The rows are measured through a horizon 10 rows too low: farther ground comes out ever
  // farther, so the periods grow along the road by 2·δ·P/(f·h) per metre (depth_eval.h).
  const CameraGeometry wrong = shift_horizon(o.camera, 10);
  const std::vector<DashedLine> lines = dashed_lines(marking_dashes(markings_of(s, p, wrong), s.labels.ids, wrong));
  ASSERT_EQ(lines.size(), 2u);
  for (const DashedLine& L : lines) {
    const double expected = 2 * 10 * L.period_mean_m / (o.camera.f_px * o.camera.mount_height_m);
    std::fprintf(stderr, "[dashes] horizon +10 rows: slope %.2e ± %.1e (first order %.2e)\n", L.slope, L.slope_se, expected);
    EXPECT_GT(L.slope, 4 * L.slope_se);
    // The first-order slope within 4 standard errors plus its second-order term: the exact
    // dD'/dD = 1/(1 − δ·D/(f·h))² grows by 3·(δ·D/(f·h))² beyond 1 + 2·δ·D/(f·h), at most at the
    // line's far end.
    const double x = 10 * L.dashes.back().far_D_m / (o.camera.f_px * o.camera.mount_height_m);
    EXPECT_NEAR(L.slope, expected, 4 * L.slope_se + 3 * x * x * L.period_mean_m / L.dashes.back().far_D_m);
    const FlatHorizon fh = flat_period_horizon(L, wrong);
    ASSERT_TRUE(std::isfinite(fh.shift_px));
    // 4 SE of the fitted shift (flat_period_horizon's own standard error).
    EXPECT_NEAR(fh.shift_px, -10, 4 * fh.se_px) << fh.shift_px << " ± " << fh.se_px;
  }
}

TEST(MarkingDashes, HiddenCutOrMissingDashesAreNoRulers) {
  const ScenePreset p = load_scene_preset("night-urban");
  // A car standing on the right lane line at 12-16.5 m: the dashes it hides are cut, not short.
  SyntheticCameraOptions o = dashed_road();
  o.boxes = {{1.75, 12, 1.8, 1.5, 4.5}};
  const SyntheticCameraScene s = make_synthetic_camera_scene(o);
  const std::vector<MarkingDash> dashes = marking_dashes(markings_of(s, p, o.camera), s.labels.ids, o.camera);
  ASSERT_FALSE(dashes.empty());
  for (const MarkingDash& d : dashes) {
    // Every dash kept is whole: its length within the reach of its ends of the painted 1 m.
    const double e = end_reach_rows(p);
    EXPECT_NEAR(d.far_D_m - d.near_D_m, 1.0, e * (row_span_m(o.camera, d.near_D_m) + row_span_m(o.camera, d.far_D_m)))
        << "dash at " << d.near_D_m << " m, X " << d.near_X_m;
    // And none lies in the car's shadow of view: the car hides the ground behind it from 12 m on.
    EXPECT_FALSE(d.near_X_m > 0 && d.far_D_m > 12 && d.near_D_m < 20) << "dash at " << d.near_D_m << " m behind the car";
  }
  // No markings at all, a mask of another size, a tiny frame: no lines, or a clear error.
  EXPECT_TRUE(dashed_lines(marking_dashes(ImageU8(2048, 1024, 1, uint8_t{0}), s.labels.ids, o.camera)).empty());
  EXPECT_THROW(marking_dashes(ImageU8(16, 8, 1, uint8_t{0}), s.labels.ids, o.camera), Error);
  EXPECT_TRUE(marking_dashes(ImageU8(1, 1, 1, uint8_t{255}), ImageU16(1, 1, 1, uint16_t{7}), o.camera).empty());
  // A continuous line (dash as long as the period) is no dashed line.
  const SyntheticCameraOptions solid = dashed_road(2, 2);
  const SyntheticCameraScene ss = make_synthetic_camera_scene(solid);
  EXPECT_TRUE(dashed_lines(marking_dashes(markings_of(ss, p, solid.camera), ss.labels.ids, solid.camera)).empty());
}

TEST(MarkingDashes, BenchOnARenderedFrame) {
  // A shared-data layout holding the dashed road as a Cityscapes frame (and no KITTI frame): the
  // command runs the night scene (the vanishing point's horizon) and writes a row per line.
  test::TempDir dir;
  const fs::path cs = dir.path() / "data" / "cityscapes";
  for (const char* d : {"leftImg8bit", "gtFine"}) fs::create_directories(cs / d);
  fs::create_directories(dir.path() / "data" / "kitti" / "image_2");
  const SyntheticCameraOptions o = dashed_road();
  const SyntheticCameraScene s = make_synthetic_camera_scene(o);
  ImageF srgb = s.day_linear_srgb;
  for (auto& v : srgb.vec()) v = static_cast<float>(srgb_encode(v));
  write_png((cs / "leftImg8bit" / "road_000000_000019_leftImg8bit.png").string(), srgb);
  ImageF ids(o.width, o.height, 1);
  for (size_t i = 0; i < ids.size(); ++i) ids[i] = s.labels.ids[i] / 255.0f;
  write_png((cs / "gtFine" / "road_000000_000019_gtFine_labelIds.png").string(), ids);
  const auto r = test::run_cli("bench markings --shared '" + dir.path().string() + "' --out-dir '" + dir.path().string() + "'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::fprintf(stderr, "%s", r.output.c_str());
  const auto rows = read_csv(dir.file("bench_markings.csv"));
  ASSERT_EQ(rows.size(), 3u) << r.output;  // header and the two lane lines
  ASSERT_EQ(rows[0][18], "standard");
  ASSERT_EQ(rows[0][19], "period_over_standard");
  for (size_t k = 1; k < rows.size(); ++k) {
    ASSERT_EQ(rows[k].size(), rows[0].size()) << k;
    EXPECT_EQ(rows[k][0], "road_000000_000019");
    EXPECT_EQ(rows[k][1], "vanishing_point");
    EXPECT_NE(rows[k][18].find("ERA 2010"), std::string::npos) << rows[k][18];
    // The chain's horizon is within 2 rows of the true one (MetricDepth.SyntheticCameraSceneThroughTheChain's
    // bound), which moves the periods by at most 2·2·D/(f·h) at the line's far end, on top of the
    // ends' reach (at most e rows of the farthest row's span at each of two ends, over a 2 m period).
    const double D_far = std::stod(rows[k][8]);
    const double bound = 2 * 2 * D_far / (o.camera.f_px * o.camera.mount_height_m) +
                         2 * end_reach_rows(load_scene_preset("night-urban")) * row_span_m(o.camera, D_far) / 2;
    EXPECT_NEAR(std::stod(rows[k][19]), 1.0, bound) << "period over the standard's";
  }
  // The same frame given as the user's own, with its rig named: the same lines.
  const std::string img = (cs / "leftImg8bit" / "road_000000_000019_leftImg8bit.png").string(),
                    lab = (cs / "gtFine" / "road_000000_000019_gtFine_labelIds.png").string();
  fs::create_directories(dir.path() / "own");
  const auto own = test::run_cli("bench markings --image '" + img + "' --labels '" + lab + "' --rig cityscapes --out-dir '" +
                                 dir.file("own") + "'");
  ASSERT_EQ(own.exit_code, 0) << own.output;
  const auto own_rows = read_csv(dir.file("own/bench_markings.csv"));
  ASSERT_EQ(own_rows.size(), rows.size()) << own.output;
  for (size_t k = 1; k < rows.size(); ++k)
    for (size_t c = 1; c < rows[k].size(); ++c) EXPECT_EQ(own_rows[k][c], rows[k][c]) << "row " << k << " column " << rows[0][c];
  const auto half = test::run_cli("bench markings --image '" + img + "' --out-dir '" + dir.path().string() + "'");
  EXPECT_EQ(half.exit_code, 2) << half.output;
  EXPECT_NE(half.output.find("--image: give its labels too"), std::string::npos) << half.output;
  // Bad input: no shared data there.
  const auto bad = test::run_cli("bench markings --shared '" + dir.file("nowhere") + "' --out-dir '" + dir.path().string() + "'");
  EXPECT_EQ(bad.exit_code, 2) << bad.output;
  EXPECT_NE(bad.output.find("needs cityscapes/leftImg8bit"), std::string::npos) << bad.output;
}
