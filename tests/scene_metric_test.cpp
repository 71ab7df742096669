// Metric scene geometry: camera rig presets, horizon, flat-ground and vertical-plane depth, on
// scenes rendered from a known camera (scene/synthetic.cpp make_synthetic_camera_scene).
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <omp.h>
#include <fmt/format.h>
#include <opencv2/imgproc.hpp>
#include <random>
#include <thread>
#include <tuple>
#include <vector>

#include "photosite/error.h"
#include "photosite/io.h"
#include "photosite/night_chain.h"
#include "photosite/rng.h"
#include "photosite/scene/ego_motion.h"
#include "photosite/scene/luminaires.h"
#include "photosite/scene/road_line.h"
#include "photosite/scene/night.h"
#include "photosite/scene/street.h"
#include "photosite/sensor/glare.h"
#include "photosite/sensor/isp.h"
#include "photosite/sensor/pipeline.h"
#include "photosite/sensor/preset.h"
#include "photosite/sensor/spectrum.h"
#include "core/isa_detail.h"
#include "scene/night_detail.h"
#include "scene/sign_retro_detail.h"
#include "scene/street_detail.h"
#include "scene/vehicle_facing_detail.h"
#include "test_util.h"

using namespace photosite;
using namespace photosite::scene;

namespace {
ScenePreset urban() { return load_scene_preset("night-urban"); }

// The Cityscapes rig at 1024 x 512 (a resize: f 1131.26 px) with its nominal pitch.
SyntheticCameraOptions camera_scene(int W = 1024, int H = 512) {
  SyntheticCameraOptions o;
  o.width = W;
  o.height = H;
  VanishingPoint none;  // method ImageCentre: the rig's pitch
  o.camera = camera_geometry(load_camera_rig("cityscapes"), W, H, none);
  o.boxes = {{-3.5, 12, 1.8, 1.5, 4.5}, {3.2, 20, 1.8, 1.5, 4.5}, {0.0, 32, 2.5, 3.0, 10}};
  return o;
}
double quantile(std::vector<double> v, double q) {
  if (v.empty()) return NAN;
  const size_t k = std::min(v.size() - 1, static_cast<size_t>(q * v.size()));
  std::nth_element(v.begin(), v.begin() + k, v.end());
  return v[k];
}
}  // namespace

TEST(CameraRig, BundledRigsCarryTheirCalibration) {
  const CameraRig k = load_camera_rig("kitti");
  EXPECT_DOUBLE_EQ(k.fx_px, 721.5377);
  EXPECT_DOUBLE_EQ(k.native_width_px, 1242);
  EXPECT_DOUBLE_EQ(k.mount_height_m, 1.65);
  const CameraRig c = load_camera_rig("cityscapes");
  EXPECT_DOUBLE_EQ(c.fx_px, 2262.52);
  EXPECT_DOUBLE_EQ(c.native_width_px, 2048);
  EXPECT_DOUBLE_EQ(c.mount_height_m, 1.22);  // presets/rigs/cityscapes.toml: the camera JSON's extrinsic z
  // Auto picks by aspect ratio: KITTI 1242x375, Cityscapes 2048x1024.
  EXPECT_EQ(rig_for_image(1242, 375).name, "kitti");
  EXPECT_EQ(rig_for_image(1224, 370).name, "kitti");
  EXPECT_EQ(rig_for_image(2048, 1024).name, "cityscapes");
  // A resize scales the focal length in pixels; a crop keeps it and shifts the principal point.
  const auto half = scaled_intrinsics(c, 1024, 512);
  EXPECT_DOUBLE_EQ(half.f_px, 2262.52 / 2);
  EXPECT_DOUBLE_EQ(half.cx_px, (1096.98 + 0.5) / 2 - 0.5);
  const auto crop = scaled_intrinsics(c, 1600, 1024);
  EXPECT_DOUBLE_EQ(crop.f_px, 2262.52);
  EXPECT_DOUBLE_EQ(crop.cx_px, 1096.98 - 224);
}

TEST(CameraRig, UnknownKeysAndBadValuesNameFileAndLine) {
  const std::string good = "native_width_px = 100\nnative_height_px = 50\nfx_px = 80\ncx_px = 50\ncy_px = 25\n"
                           "mount_height_m = 1.5\npitch_deg = 0\n";
  EXPECT_NO_THROW(parse_camera_rig(good, "r.toml"));
  try {
    parse_camera_rig(good + "focal_mm = 3\n", "r.toml");
    FAIL() << "unknown key accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("r.toml:8"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("unknown key"), std::string::npos) << e.what();
  }
  try {
    parse_camera_rig("native_width_px = 100\nnative_height_px = 50\nfx_px = 80\ncx_px = 50\ncy_px = 25\n"
                     "mount_height_m = -1\npitch_deg = 0\n", "r.toml");
    FAIL() << "negative height accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("r.toml:6"), std::string::npos) << e.what();
  }
  EXPECT_THROW(parse_camera_rig("fx_px = 80\n", "r.toml"), Error);  // missing keys
  EXPECT_THROW(load_camera_rig("no-such-rig"), Error);
}

// The flat-ground equation z = f·h / ((v − y_h)·cos θ) and the projection agree: a ground point
// projected and back-projected returns itself.
TEST(MetricDepth, GroundModelRoundTrips) {
  const SyntheticCameraOptions o = camera_scene();
  const CameraGeometry& g = o.camera;
  for (double D : {3.0, 10.0, 40.0, 200.0})
    for (double X : {-6.0, 0.0, 4.0}) {
      double u, v, z, X2, D2, z2;
      ASSERT_TRUE(g.project(X, 0, D, &u, &v, &z));
      ASSERT_TRUE(g.ground_point(u, v, &X2, &D2, &z2));
      // Double rounding (e = 2⁻⁵³), propagated: u and v carry about 4 roundings of their terms
      // (δu, δv); ground_point's yn = (v − c_y)/f then errs by δv/f, which the ray's downward
      // component den = yn·cos θ + sin θ divides (the ill-conditioned step far away, where den is
      // small), plus den's own 4 roundings: t = h/den and z, X = t·xn, D = t·(cos θ − yn·sin θ)
      // carry that relative error, a few more roundings (8e), X the error of xn = (u − c_x)/f times
      // t and D that of its factor, δyn·|sin θ| over it.
      const double e = 0x1p-53, c = std::cos(g.pitch_rad), sn = std::sin(g.pitch_rad);
      const double yn = (v - g.cy_px) / g.f_px, den = yn * c + sn, fwd = c - yn * sn;
      const double du = 4 * e * (std::fabs(g.cx_px) + std::fabs(u - g.cx_px));
      const double dv = 4 * e * (std::fabs(g.cy_px) + std::fabs(v - g.cy_px));
      const double rel = (dv / g.f_px * c + 4 * e * (std::fabs(yn * c) + std::fabs(sn))) / den + 8 * e;
      const double rel_D = rel + (dv / g.f_px * std::fabs(sn) + 4 * e * (c + std::fabs(yn * sn))) / fwd;
      EXPECT_NEAR(X2, X, rel * std::fabs(X) + du / g.f_px * z);
      EXPECT_NEAR(D2, D, rel_D * D);
      EXPECT_NEAR(z2, z, rel * z);
      // ground_depth_m's own denominator is den above (rel·z bounds its rounding; its δv part,
      // which does not arise here with v the same input on both sides, only adds); this side's
      // horizon y_h = c_y − f·tan θ carries tan's, the product's and the difference's roundings,
      // 3e·(|f tan θ| + |y_h|), relative to v − y_h, and four more roundings (the difference,
      // the two products, the quotient).
      const double yh_err = 3 * e * (std::fabs(g.f_px * std::tan(g.pitch_rad)) + std::fabs(g.horizon_y));
      EXPECT_NEAR(g.ground_depth_m(v), g.f_px * g.mount_height_m / ((v - g.horizon_y) * std::cos(g.pitch_rad)),
                  (rel + yh_err / std::fabs(v - g.horizon_y) + 4 * e) * z);
    }
}

// A turned box (SyntheticBox::yaw_rad, turned about its front face's centre, its length along
// (sin yaw, cos yaw)): turned a quarter right, a car 1.8 m wide and 4.5 m long with its front
// face's centre at (X, D) covers X to X + 4.5 and D − 0.9 to D + 0.9, the footprint of an
// unturned box 4.5 m wide and 1.8 m long whose front face (centre X + 2.25) stands at D − 0.9. Its
// depth then agrees to the box frame's rounding: the ray's origin and direction turned by cos and
// sin of π/2 (cos = 6e-17) and back, a few ulps of the ray parameter t ≤ 40 m (1e-12 m is far
// above, far below a millimetre; depth_m is a float, so the float rounding of z ≤ 40 m, 2⁻²⁴·40 =
// 2.4e-6 m, bounds it). Labels agree except where a pixel's ray passes within that rounding of
// an edge, which no pixel centre of this scene does (the test fails if more than none differ).
// And a turned box is not the unturned one: 30° turned, its pixels differ.
TEST(MetricDepth, ATurnedSyntheticBoxIsItsFootprintsBox) {
  SyntheticCameraOptions a = camera_scene();
  a.boxes = {{1.0, 14, 1.8, 1.5, 4.5}};
  a.boxes[0].yaw_rad = M_PI / 2;
  SyntheticCameraOptions b = a;
  b.boxes = {{1.0 + 2.25, 14 - 0.9, 4.5, 1.5, 1.8}};
  const SyntheticCameraScene sa = make_synthetic_camera_scene(a), sb = make_synthetic_camera_scene(b);
  int on_box = 0, label_diff = 0;
  double worst = 0;
  for (int y = 0; y < a.height; ++y)
    for (int x = 0; x < a.width; ++x) {
      if (sa.labels.instances.at(x, y) != sb.labels.instances.at(x, y)) ++label_diff;
      if (sa.labels.instances.at(x, y) == 0) continue;
      ++on_box;
      worst = std::max(worst, std::fabs(double(sa.depth_m.at(x, y)) - sb.depth_m.at(x, y)));
    }
  EXPECT_GT(on_box, 1000);  // the box is in view: 1.5 m tall at 13-18 m, over 90 rows
  EXPECT_EQ(label_diff, 0);
  EXPECT_LE(worst, 2.4e-6);  // one float rounding of z ≤ 40 m (above)
  SyntheticCameraOptions c = a;
  c.boxes[0].yaw_rad = M_PI / 6;
  const SyntheticCameraScene sc = make_synthetic_camera_scene(c);
  int turned_diff = 0;
  for (size_t i = 0; i < sc.labels.instances.pixel_count(); ++i) turned_diff += sc.labels.instances[i] != sb.labels.instances[i];
  EXPECT_GT(turned_diff, 100);
}

// Recovered depth on a scene rendered from the known camera. With the horizon from the rig (the
// true pitch) the ground is exact up to float rounding, and a box's ground contact is found to
// within half a pixel row (the lowest pixel centre whose ray hits the box lies within one row
// above the true contact line; its lower edge, which the model takes, within ±0.5 row): the
// relative error is then at most 0.5 / (v_contact − y_h), 1.1% for the farthest box (32 m:
// v − y_h = f·h/(z·cos θ) = 1131·1.22/32 = 43 px). The issue's bounds: 2% ground, 5% boxes.
TEST(MetricDepth, SyntheticCameraSceneWithTheRigHorizon) {
  const SyntheticCameraOptions o = camera_scene();
  const SyntheticCameraScene s = make_synthetic_camera_scene(o);
  const ImageF d = metric_depth(s.labels, o.camera, 1000);
  EXPECT_EQ(d.unit(), std::string("m"));
  double worst_ground = 0, worst_front = 0;
  int n_front = 0, n_sky = 0;
  for (int y = 0; y < o.height; ++y)
    for (int x = 0; x < o.width; ++x) {
      const double t = s.depth_m.at(x, y), r = d.at(x, y);
      const int id = s.labels.ids.at(x, y);
      if (id == static_cast<int>(Label::Sky)) {
        ++n_sky;
        EXPECT_EQ(r, kDepthInfinity_m);
        continue;
      }
      if (is_ground(id) && t < 1000) worst_ground = std::max(worst_ground, std::fabs(r / t - 1));
      if (s.box_front.at(x, y)) {
        worst_front = std::max(worst_front, std::fabs(r / t - 1));
        ++n_front;
      }
    }
  EXPECT_GT(n_front, 1000);
  EXPECT_GT(n_sky, 1000);
  std::fprintf(stderr, "[metric] rig horizon: worst ground %.3g, worst box front %.3g\n", worst_ground, worst_front);
  // Exact on the ground: the synthetic scene's ray (h/(yn·cos θ + sin θ), synthetic.cpp) and
  // ground_depth_m are the same double operations at the same row, each rounded to float once.
  EXPECT_EQ(worst_ground, 0.0);
  // Box fronts: the contact row's quantisation (0.5/43 above), and the two depths' roundings to
  // float (2⁻²⁴ relative each) on top.
  EXPECT_LE(worst_front, 0.5 / 43 + 2 * 0x1p-24 * (1 + 0.5 / 43));
}

namespace {
// A synthetic tree's depth against the truth: over its front-face pixels, depth / true depth (ratio
// for each), and per column the label just below the column's lowest tree pixel (below).
struct TreeDepth {
  int front = 0;
  double lo = INFINITY, hi = 0;  // depth / truth
  std::vector<int> below;        // per column: the label under the lowest tree pixel (-1: none)
};
TreeDepth tree_depth(const SyntheticCameraScene& s, const ImageF& d) {
  TreeDepth t;
  const int W = d.width(), H = d.height();
  t.below.assign(W, -1);
  for (int x = 0; x < W; ++x) {
    int lowest = -1;
    for (int y = 0; y < H; ++y) {
      if (s.labels.ids.at(x, y) != static_cast<int>(Label::Vegetation)) continue;
      lowest = y;
      if (!s.box_front.at(x, y)) continue;
      const double r = static_cast<double>(d.at(x, y)) / s.depth_m.at(x, y);
      t.lo = std::min(t.lo, r), t.hi = std::max(t.hi, r);
      ++t.front;
    }
    if (lowest >= 0 && lowest + 1 < H) t.below[x] = s.labels.ids.at(x, lowest + 1);
  }
  return t;
}
}  // namespace

// A tree whose foot is hidden: its crown (4 m wide over the kerb, 2.5 to 6 m high) and its trunk
// stand at D = 25 m behind a car parked at the kerb (front at D = 20 m, 1.5 m high), so no column
// of the tree shows its ground contact. Below the crown the photo shows the car or the building
// façade beyond (X = 10 m). Each column's own lower bound (the bottom of the stack of objects
// below it) put the crown's columns over the façade at the façade's foot (about 40 m): the light
// map lit such crowns in vertical stripes. One plane per region now: every tree pixel lies between
// the car's distance (the nearest its hidden contact can be: 20/25 of its true depth) and its true
// depth, each with the 5 % issue 14 §1 allows objects.
TEST(MetricDepth, ATreeBehindAParkedCarIsOnePlaneNotItsColumnsBounds) {
  SyntheticCameraOptions o = camera_scene();
  o.boxes = {{6.5, 20, 1.8, 1.5, 4.5},
             {6.5, 25, 4.0, 6.0, 2.0, Label::Vegetation, 2.5},  // the crown
             {6.5, 25, 0.4, 2.5, 0.4, Label::Vegetation}};      // the trunk
  const SyntheticCameraScene s = make_synthetic_camera_scene(o);
  const ImageF d = metric_depth(s.labels, o.camera, 1000);
  const TreeDepth t = tree_depth(s, d);
  const long columns_over_facade = std::count(t.below.begin(), t.below.end(), static_cast<int>(Label::Building));
  std::fprintf(stderr, "[tree] %d front pixels, depth / truth %.4f .. %.4f; columns over the facade %ld\n", t.front, t.lo,
               t.hi, columns_over_facade);
  // The premises: the tree is seen, and some of its columns end over the façade.
  ASSERT_GT(t.front, 1000);
  ASSERT_GT(columns_over_facade, 10);
  EXPECT_GE(t.lo, 20.0 / 25.0 * (1 - 0.05));
  EXPECT_LE(t.hi, 1 + 0.05);
}

// An overhang over visible ground: a crown hanging down to 0.5 m (below the camera's 1.22 m) on a
// median strip 3 m right of the camera, its trunk in view. Under the crown's lower edge the photo
// shows the road beyond it, a contact the crown does not have: each such column stood at the
// road's distance there, farther by a different amount per column. Trimmed from the line (or median) of the region's
// contacts as lying more than the 5 % depth tolerance above it, those columns take the trunk's:
// every tree pixel within 5 % of its true depth (issue 14 §1).
TEST(MetricDepth, ACrownOverThePavementStandsAtItsTrunk) {
  SyntheticCameraOptions o = camera_scene();
  o.boxes = {{3.0, 25, 4.0, 6.0, 2.0, Label::Vegetation, 0.5},  // the crown
             {3.0, 25, 0.4, 0.5, 0.4, Label::Vegetation}};      // the trunk
  const SyntheticCameraScene s = make_synthetic_camera_scene(o);
  const ImageF d = metric_depth(s.labels, o.camera, 1000);
  const TreeDepth t = tree_depth(s, d);
  const long columns_over_ground =
      std::count_if(t.below.begin(), t.below.end(), [](int id) { return id >= 0 && is_ground(id); });
  const double worst = std::max(1 - t.lo, t.hi - 1);
  std::fprintf(stderr, "[crown] %d front pixels, worst relative depth error %.4f; columns over the ground %ld\n", t.front,
               worst, columns_over_ground);
  // The premises: the tree is seen, and most of its columns end over the ground beyond it.
  ASSERT_GT(t.front, 1000);
  ASSERT_GT(columns_over_ground, 100);
  EXPECT_LE(worst, 0.05);
}

// The whole chain: the horizon now comes from the vanishing point of the rendered lane lines. A
// horizon error δ (px) makes the ground depth wrong by δ / (v − y_h) (z ∝ 1/(v − y_h)): the 2%
// bound holds on rows at least 50·δ below the horizon. δ itself: Hough segments have endpoints
// quantised to ±0.5 px over lengths of at least 41 px (4% of the width), so each line's angle is
// off by up to ~0.5/41·√2 rad; the VP is the mean of a cluster of hundreds of intersections,
// which averages this down; 2 px is asserted (a third of the cluster radius, 4% of the diagonal /
// 6). Boxes also take the ±0.5-row contact quantisation: 5%.
TEST(MetricDepth, SyntheticCameraSceneThroughTheChain) {
  const SyntheticCameraOptions o = camera_scene();
  const SyntheticCameraScene s = make_synthetic_camera_scene(o);
  ScenePreset p = urban();
  p.rig = load_camera_rig("cityscapes");
  const NightScene n = night_scene(s.day_linear_srgb, s.labels, p, 1);
  ASSERT_EQ(n.geometry.horizon_source, "vanishing_point") << n.vp.note;
  const double delta = std::fabs(n.geometry.horizon_y - o.camera.horizon_y);
  EXPECT_LE(delta, 2.0) << n.geometry.horizon_y << " vs " << o.camera.horizon_y;
  std::vector<double> ground_err, front_err;
  double z_far = 0;
  for (int y = 0; y < o.height; ++y)
    for (int x = 0; x < o.width; ++x) {
      const double t = s.depth_m.at(x, y), r = n.depth.at(x, y);
      const int id = s.labels.ids.at(x, y);
      if (is_ground(id) && y - n.geometry.horizon_y >= 50 * delta) {
        ground_err.push_back(std::fabs(r / t - 1));
        z_far = std::max(z_far, t);
      }
      if (s.box_front.at(x, y)) front_err.push_back(std::fabs(r / t - 1));
    }
  std::fprintf(stderr, "[metric] horizon error %.2f px; ground checked to %.1f m: worst %.2f%%, median %.3f%%; "
               "box fronts worst %.2f%%\n", delta, z_far, 100 * quantile(ground_err, 1.0), 100 * quantile(ground_err, 0.5),
               100 * quantile(front_err, 1.0));
  ASSERT_GT(ground_err.size(), 10000u);
  EXPECT_LE(quantile(ground_err, 1.0), 0.02);
  EXPECT_LE(quantile(front_err, 1.0), 0.05);
}

// No lines at all (flat labels: sky over road): the VP falls back to a label prior, the horizon to
// the rig's pitch, and depth stays metric.
TEST(MetricDepth, FallbackHorizonStaysMetric) {
  const int W = 640, H = 320;
  LabelMap lm;
  lm.ids = ImageU16(W, H, 1, static_cast<uint16_t>(Label::Road), unit::label_id);
  for (int y = 0; y < 150; ++y)
    for (int x = 0; x < W; ++x) lm.ids.at(x, y) = static_cast<uint16_t>(Label::Sky);
  ImageF day(W, H, 3, 0.2f, "linear sRGB");
  ScenePreset p = urban();
  p.rig = load_camera_rig("cityscapes");
  const NightScene n = night_scene(day, lm, p, 1);
  EXPECT_NE(n.vp.method, VpMethod::Hough);
  EXPECT_EQ(n.geometry.horizon_source, "rig");
  const auto k = scaled_intrinsics(p.rig, W, H);
  const double th = p.rig.pitch_deg * M_PI / 180, yh = k.cy_px - k.f_px * std::tan(th);
  EXPECT_EQ(n.geometry.horizon_y, yh);  // exact: camera_geometry's rig branch is this expression
  for (int y : {200, 250, 319})
    // The code's double formula (another order of the same operations, ~1e-15) stored as float:
    // half an ulp, at most 2⁻²⁴ relative.
    EXPECT_NEAR(n.depth.at(100, y), k.f_px * p.rig.mount_height_m / ((y - yh) * std::cos(th)),
                (0x1p-24 + 1e-14) * n.depth.at(100, y));
  EXPECT_EQ(n.depth.at(100, 10), kDepthInfinity_m);
}

// The horizon gate (issue 14 §1): a Hough vanishing point is used only when its pitch agrees with
// the rig's nominal pitch within the rig's pitch tolerance (1.6° by default: a passenger car's body
// pitch under load and service braking, derived in scene/rig.cpp); further off it falls back to
// the nominal horizon, with the header contract kept (source "rig", confidence 0). The case that
// motivated it: aachen_000003's VP at y = 345.5 px (pitch 4.24°, 2.06° above the Cityscapes rig's
// 2.18°), accepted by the old ±15° gate.
TEST(MetricDepth, VanishingPointFarFromTheRigsPitchFallsBack) {
  const CameraRig rig = load_camera_rig("cityscapes");
  ASSERT_DOUBLE_EQ(rig.pitch_tolerance_deg, kPitchToleranceDeg);  // no key in the bundled file: the default
  const int W = 2048, H = 1024;
  const auto k = scaled_intrinsics(rig, W, H);
  auto vp_at_pitch = [&](double pitch_deg) {
    VanishingPoint vp;
    vp.x = k.cx_px;
    vp.y = k.cy_px - k.f_px * std::tan(pitch_deg * M_PI / 180);
    vp.confidence = 0.91;
    vp.method = VpMethod::Hough;
    vp.support = 100;
    return vp;
  };
  const double nominal = rig.pitch_deg, tol = rig.pitch_tolerance_deg;
  // A horizon row through a pitch and back (atan, tan, a product and a difference in double):
  // a few roundings of 2⁻⁵³ of numbers below cy + |f·tan θ|; 8 of them bound it.
  auto row_tol = [&](double y) { return 8 * 0x1p-53 * (k.cy_px + std::fabs(y - k.cy_px)); };
  // Within the bound (either side, up to 0.01° inside it): the VP's horizon is kept.
  for (const double d : {0.0, 0.5, -1.0, tol - 0.01, -(tol - 0.01)}) {
    const VanishingPoint vp = vp_at_pitch(nominal + d);
    const CameraGeometry g = camera_geometry(rig, W, H, vp);
    EXPECT_EQ(g.horizon_source, "vanishing_point") << d;
    EXPECT_DOUBLE_EQ(g.horizon_confidence, 0.91) << d;
    EXPECT_NEAR(g.horizon_y, vp.y, row_tol(vp.y)) << d;
    EXPECT_EQ(g.note, "") << d;  // nothing to tell: the VP agrees with the rig
  }
  // Beyond it: the rig's horizon, confidence 0.
  const double yh_rig = k.cy_px - k.f_px * std::tan(nominal * M_PI / 180);
  for (const double d : {tol + 0.01, -(tol + 0.01), 3.0, -5.0, 14.0}) {
    const CameraGeometry g = camera_geometry(rig, W, H, vp_at_pitch(nominal + d));
    EXPECT_EQ(g.horizon_source, "rig") << d;
    EXPECT_EQ(g.horizon_confidence, 0) << d;
    EXPECT_NEAR(g.horizon_y, yh_rig, row_tol(yh_rig)) << d;
    // The refused VP is reported (a likely wrong --rig: a sign-flipped pitch, another data set's rig).
    EXPECT_NE(g.note.find("the vanishing point (confidence 0.91)"), std::string::npos) << d << ": " << g.note;
    EXPECT_NE(g.note.find("check --rig"), std::string::npos) << g.note;
  }
  // A frame of another aspect ratio (BDD100K's 1280x720) is a crop of the rig's frame: said so.
  const CameraGeometry bdd = camera_geometry(rig, 1280, 720, vp_at_pitch(nominal));
  EXPECT_NE(bdd.note.find("aspect ratio 1.778 is not rig cityscapes's"), std::string::npos) << bdd.note;
  EXPECT_EQ(bdd.note.find("larger"), std::string::npos) << bdd.note;
  // A strip's ratio below 0.1 in three significant digits: 8/1024 printed as 0.008, 8/16384 as
  // 0.000 (thirty-eighth session); three decimals from 0.1 up, as BDD100K's above.
  const CameraGeometry strip = camera_geometry(rig, 8, 1024, vp_at_pitch(nominal));
  EXPECT_NE(strip.note.find("aspect ratio 0.00781 is not rig cityscapes's"), std::string::npos) << strip.note;
  const CameraGeometry narrow = camera_geometry(rig, 103, 1024, vp_at_pitch(nominal));  // 0.1006
  EXPECT_NE(narrow.note.find("aspect ratio 0.101 is not rig cityscapes's"), std::string::npos) << narrow.note;
  EXPECT_NE(camera_geometry(rig, 4000, 1000, vp_at_pitch(nominal)).note.find("although it is larger"),
            std::string::npos);
  // A horizon below the frame: no ground in view.
  const CameraRig down = parse_camera_rig(
      "native_width_px = 2048\nnative_height_px = 1024\nfx_px = 2262.52\ncx_px = 1096.98\ncy_px = 513.137\n"
      "mount_height_m = 1.22\npitch_deg = -20\n",
      "down.toml");
  EXPECT_NE(camera_geometry(down, W, H, VanishingPoint{}).note.find("lies below the frame"), std::string::npos);
  // aachen_000003's VP row, at its own 2048x1024 size.
  VanishingPoint aachen = vp_at_pitch(0);
  aachen.y = 345.5;
  EXPECT_EQ(camera_geometry(rig, W, H, aachen).horizon_source, "rig");
  EXPECT_NEAR(camera_geometry(rig, W, H, aachen).horizon_y, yh_rig, row_tol(yh_rig));  // the rig's horizon, 427 px
  // The tolerance is the rig file's key: a rig that allows 15° keeps that VP.
  const CameraRig loose = parse_camera_rig(
      "native_width_px = 2048\nnative_height_px = 1024\nfx_px = 2262.52\ncx_px = 1096.98\ncy_px = 513.137\n"
      "mount_height_m = 1.22\npitch_deg = 2.18\npitch_tolerance_deg = 15\n",
      "loose.toml");
  EXPECT_DOUBLE_EQ(loose.pitch_tolerance_deg, 15);
  const CameraGeometry gl = camera_geometry(loose, W, H, aachen);
  EXPECT_EQ(gl.horizon_source, "vanishing_point");
  // y_h = c_y − f·tan(atan((c_y − 345.5)/f)) = 345.5 up to rounding: the difference, the quotient,
  // atan, tan and the product each round a value of about |c_y − 345.5| (relative 2⁻⁵³; atan and
  // tan have slope about 1 near 0), the last difference rounds one of |345.5|.
  EXPECT_NEAR(gl.horizon_y, 345.5, 0x1p-53 * (5 * std::fabs(gl.cy_px - 345.5) + 345.5));
  // A label prior is never used, however near the nominal pitch.
  VanishingPoint prior = vp_at_pitch(nominal);
  prior.method = VpMethod::RoadPrior;
  prior.confidence = 0.2;
  EXPECT_EQ(camera_geometry(rig, W, H, prior).horizon_source, "rig");
}

// The EXR says which horizon was used, how sure, and with which rig; depth.Z is in metres.
TEST(MetricDepth, NightExrHeaderNamesTheHorizon) {
  test::TempDir tmp;
  const auto r = test::run_cli("night --rig kitti --layers depth,labels --out " + tmp.file("n.exr"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const ExrContents c = read_exr(tmp.file("n.exr"));
  const auto& a = c.attributes;
  for (const char* k : {"horizon_y", "horizon_source", "horizon_confidence", "camera_rig", "camera_pitch_deg",
                        "focal_length_px", "mount_height_m", "depth_infinity_m"})
    EXPECT_TRUE(a.count(std::string("photosite/night/") + k)) << k;
  EXPECT_EQ(a.at("photosite/night/camera_rig"), "kitti");
  const std::string src = a.at("photosite/night/horizon_source");
  EXPECT_TRUE(src == "vanishing_point" || src == "rig") << src;
  EXPECT_DOUBLE_EQ(std::stod(a.at("photosite/night/mount_height_m")), 1.65);
  EXPECT_DOUBLE_EQ(std::stod(a.at("photosite/night/depth_infinity_m")), 65504.0);
  const ImageF& z = c.channels.at("depth.Z");
  const ImageF& ids = c.channels.at("labels.Y");
  int sky = 0, road = 0;
  for (size_t i = 0; i < z.pixel_count(); ++i) {
    if (ids[i] == static_cast<float>(Label::Sky)) { EXPECT_EQ(z[i], 65504.f); ++sky; }
    if (ids[i] == static_cast<float>(Label::Road)) { EXPECT_GT(z[i], 1.0f); EXPECT_LE(z[i], 1000.f); ++road; }
  }
  EXPECT_GT(sky, 0);
  EXPECT_GT(road, 0);
  const auto bad = test::run_cli("night --rig nonesuch --out " + tmp.file("m.exr"));
  EXPECT_EQ(bad.exit_code, 2) << bad.output;
  EXPECT_NE(bad.output.find("nonesuch"), std::string::npos) << bad.output;
}

// `night --streetlamp-type` overrides the scene preset's lamps.streetlamp_type, and the EXR header
// records the type that was used (the preset's "led" without the option) and, with hps, the
// camera's metamer the lamps took, with led its metamers of CIE LED-B at the heads' and the street
// light's CCTs; and always the camera's metamers the signals' and rear lamps' LEDs took.
TEST(StreetLampType, NightCommandRecordsTheTypeInTheHeader) {
  test::TempDir tmp;
  for (const char* type : {"", "hps", "led"}) {
    SCOPED_TRACE(type);
    const std::string out = tmp.file(std::string("n") + type + ".exr");
    const auto r = test::run_cli(std::string("night --rig kitti --layers lights --out ") + out +
                                 (*type ? std::string(" --streetlamp-type ") + type : std::string()));
    ASSERT_EQ(r.exit_code, 0) << r.output;
    const auto attrs = read_exr(out).attributes;
    EXPECT_EQ(attrs.at("photosite/scene/lamps.streetlamp_type"), *type ? type : "led");
    // With hps the header gives the run's camera's metamer of HP1, the lamps' band radiances per
    // cd/m² (scene_for_camera): camera_metamer_rgb of the camera it names (the exact _text copies).
    const bool hps = std::string(type) == "hps";
    EXPECT_EQ(attrs.count("photosite/night/streetlamp_camera_rgb_per_cd_m2_G"), hps ? 1u : 0u);
    if (hps) {
      const auto w = camera_metamer_rgb(load_camera_preset(attrs.at("photosite/preset")), spectrum::kHp1Spd5nm, 81);
      EXPECT_EQ(std::stod(attrs.at("photosite/night/streetlamp_camera_rgb_per_cd_m2_R_text")), w[0]);
      EXPECT_EQ(std::stod(attrs.at("photosite/night/streetlamp_camera_rgb_per_cd_m2_G_text")), w[1]);
      EXPECT_EQ(std::stod(attrs.at("photosite/night/streetlamp_camera_rgb_per_cd_m2_B_text")), w[2]);
    }
    // Whatever the type, the signals' and rear lamps' LEDs as this camera records them.
    const CameraPreset cam = load_camera_preset(attrs.at("photosite/preset"));
    // With led, the camera's metamers of CIE LED-B at the heads' and at the street light's CCT.
    for (const auto& [name, ls, key] : {std::tuple{"heads", spectrum::LampSpectrum::LedBHeads, "lamps.streetlamp_cct_K"},
                                        std::tuple{"street", spectrum::LampSpectrum::LedBStreet, "street.cct_K"}}) {
      const std::string stem = std::string("photosite/night/streetlamp_camera_rgb_per_cd_m2_led_") + name;
      ASSERT_EQ(attrs.count(stem + "_G_text"), hps ? 0u : 1u) << stem;
      if (hps) continue;
      const auto w = camera_metamer_rgb(cam, ls, std::stod(attrs.at(std::string("photosite/scene/") + key)));
      EXPECT_EQ(std::stod(attrs.at(stem + "_R_text")), w[0]) << stem;
      EXPECT_EQ(std::stod(attrs.at(stem + "_G_text")), w[1]) << stem;
      EXPECT_EQ(std::stod(attrs.at(stem + "_B_text")), w[2]) << stem;
    }
    for (const auto& [name, ls] : {std::pair{"red", spectrum::LampSpectrum::RedLed},
                                   std::pair{"amber", spectrum::LampSpectrum::AmberLed},
                                   std::pair{"green", spectrum::LampSpectrum::GreenLed}}) {
      const auto w = camera_metamer_rgb(cam, ls);
      const std::string stem = std::string("photosite/night/signal_camera_rgb_per_cd_m2_") + name;
      ASSERT_EQ(attrs.count(stem + "_R_text"), 1u) << stem;
      EXPECT_EQ(std::stod(attrs.at(stem + "_R_text")), w[0]) << stem;
      EXPECT_EQ(std::stod(attrs.at(stem + "_G_text")), w[1]) << stem;
      EXPECT_EQ(std::stod(attrs.at(stem + "_B_text")), w[2]) << stem;
    }
  }
}

// A shared Cityscapes frame (../shared/data/cityscapes, 2048x1024): its day image linearized, and
// its labels with the instance ids. (The caller skips without ../shared.)
namespace {
std::pair<ImageF, LabelMap> cityscapes_frame(const std::string& base) {
  const auto dir = test::shared_dir() / "data/cityscapes";
  ImageFileInfo info;
  const ImageF day = read_image((dir / "leftImg8bit" / (base + "_leftImg8bit.png")).string(), &info);
  LabelMap lab = read_labels((dir / "gtFine" / (base + "_gtFine_labelIds.png")).string(),
                             (dir / "gtFine" / (base + "_gtFine_instanceIds.png")).string(), 2048, 1024,
                             LabelFormat::Auto, ResizeLabels::None);
  return {linearize(day, info), std::move(lab)};
}
// The samples of two images whose bits differ (all of both when their sizes differ).
size_t differing_samples(const ImageF& a, const ImageF& b) {
  if (a.size() != b.size()) return a.size() + b.size();
  size_t n = 0;
  for (size_t i = 0; i < a.size(); ++i) n += std::memcmp(&a[i], &b[i], sizeof(float)) != 0;
  return n;
}
}  // namespace

// A luminaire is a point source: E = I(γ)·cos γ / d², i.e. I0/H² at the nadir and
// I0·H/(r² + H²)^{3/2} at horizontal distance r inside the cut-off; beyond it the distribution's
// exponential fall.
TEST(StreetLighting, PointSourceInverseSquareAndCosine) {
  ScenePreset p = urban();
  StreetLighting s;
  s.lamps = {{0, 10, 20, false}};
  s.peak_intensity_cd = 5000;
  // Exact at the nadir: d² = 100, d = 10, cos γ = 1 and rel(1) = 1 are exact, 5000/100 = 50.
  EXPECT_EQ(street_illuminance_lux(0, 20, s, p), 5000 / 100.0);
  const double r = 15;  // γ = atan(1.5) = 56.3° < 65°
  // d² = 325 exactly; street.cpp rounds √d², H/d, I0·c and the quotient (4 roundings), this side
  // pow (within 1 ulp) and the quotient: 6·2⁻⁵³ relative.
  const double e_r = 5000 * 10 / std::pow(r * r + 100, 1.5);
  EXPECT_NEAR(street_illuminance_lux(r, 20, s, p), e_r, 6 * 0x1p-53 * e_r);
  const double r2 = 40;  // γ = 76° > 65°
  const double g = std::atan(4.0), d = std::hypot(40.0, 10.0);
  const double e_far = 5000 * std::exp(-(g - 65 * M_PI / 180) / (5 * M_PI / 180)) * std::cos(g) / (d * d);
  EXPECT_NEAR(street_illuminance_lux(0, 20 + r2, s, p), e_far, 1e-6 * e_far);  // the table's interpolation (street.cpp)
  EXPECT_DOUBLE_EQ(lamp_relative_intensity(0.5, p), 1.0);
}

// plan_street_lighting takes the poles in the order of OpenCV's 8-connected labels of the pole
// mask (the order decides which layout luminaire a pole replaces when two compete), found from
// the rows' runs of pole pixels (pole_components, street.cpp) instead of labelling the frame.
// Checked on random masks of thin poles with arms, blobs and single pixels (small frames, and
// frames of 2048x1024 so that OpenCV's parallel labelling runs, at 1 and 2 OpenCV threads): the
// same components, the same boxes, in the same order as cv::connectedComponentsWithStats on the
// whole mask. A labelling that numbered by the first pixel instead of the first 2x2 block, merged
// only 4-connected runs or dropped a component fails.
TEST(StreetLighting, PoleComponentsAreOpenCVsInItsOrder) {
  std::mt19937 rng(20261128);
  int compared = 0, multi = 0;
  const int threads = cv::getNumThreads();
  for (int trial = 0; trial < 320; ++trial) {
    const bool big = trial >= 300;
    const int W = big ? 2048 : 40 + static_cast<int>(rng() % 300), H = big ? 1024 : 40 + static_cast<int>(rng() % 200);
    cv::Mat m(H, W, CV_8U, cv::Scalar(0));
    // The foreground inside a random sub-box (odd or even corner).
    const int x0 = 1 + static_cast<int>(rng() % (W / 3)), y0 = 1 + static_cast<int>(rng() % (H / 3));
    const int x1 = W - 1 - static_cast<int>(rng() % (W / 3)), y1 = H - 1 - static_cast<int>(rng() % (H / 3));
    auto rx = [&] { return x0 + static_cast<int>(rng() % (x1 - x0)); };
    auto ry = [&] { return y0 + static_cast<int>(rng() % (y1 - y0)); };
    const int scale = big ? 20 : 1;
    for (int k = static_cast<int>(rng() % (12 * scale)); k > 0; --k) {  // poles: 1-3 px wide vertical bars, some with an arm
      const int x = rx(), ya = ry(), yb = ry(), w = 1 + static_cast<int>(rng() % 3);
      for (int y = std::min(ya, yb); y <= std::max(ya, yb); ++y)
        for (int dx = 0; dx < w && x + dx < x1; ++dx) m.at<uint8_t>(y, x + dx) = 255;
      if (rng() % 2)
        for (int dx = 0; dx < 6 && x + dx < x1; ++dx) m.at<uint8_t>(std::min(ya, yb), x + dx) = 255;
    }
    for (int k = static_cast<int>(rng() % (40 * scale)); k > 0; --k) m.at<uint8_t>(ry(), rx()) = 255;  // single pixels
    for (int k = static_cast<int>(rng() % (4 * scale)); k > 0; --k) {  // blobs
      const int cx = rx(), cy = ry(), r = 1 + static_cast<int>(rng() % 5);
      for (int y = std::max(y0, cy - r); y < std::min(y1, cy + r); ++y)
        for (int x = std::max(x0, cx - r); x < std::min(x1, cx + r); ++x)
          if ((x - cx) * (x - cx) + (y - cy) * (y - cy) <= r * r) m.at<uint8_t>(y, x) = 255;
    }
    // The mask as labels: poles and pole groups alike, every other pixel another class.
    ImageU16 labels(W, H, 1, static_cast<uint16_t>(Label::Building));
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x)
        if (m.at<uint8_t>(y, x)) labels.at(x, y) = static_cast<uint16_t>((x + y) % 5 ? Label::Pole : Label::PoleGroup);
    const std::vector<PoleBox> runs = pole_components(labels);
    for (const int cv_threads : {1, 2}) {
      if (!big && cv_threads == 2) continue;
      cv::setNumThreads(cv_threads);
      cv::Mat cc, stats, cent;
      const int n = cv::connectedComponentsWithStats(m, cc, stats, cent, 8, CV_32S);
      cv::setNumThreads(threads);
      ASSERT_EQ(static_cast<int>(runs.size()), n - 1) << "trial " << trial;
      for (int c = 1; c < n; ++c) {
        const PoleBox& b = runs[c - 1];
        ASSERT_EQ(b.x0, stats.at<int>(c, cv::CC_STAT_LEFT)) << "trial " << trial << " component " << c;
        ASSERT_EQ(b.y0, stats.at<int>(c, cv::CC_STAT_TOP)) << "trial " << trial << " component " << c;
        ASSERT_EQ(b.x1 - b.x0 + 1, stats.at<int>(c, cv::CC_STAT_WIDTH)) << "trial " << trial << " component " << c;
        ASSERT_EQ(b.y1 - b.y0 + 1, stats.at<int>(c, cv::CC_STAT_HEIGHT)) << "trial " << trial << " component " << c;
      }
      ++compared;
      multi += n > 3;
    }
  }
  EXPECT_GT(compared, 300);
  EXPECT_GT(multi, 150);  // many masks with several components, whose order is what is compared
}

// The street light's row paths (pools, vertical surfaces, façade windows) at every instruction
// set this machine has: AVX-512VL (the AVX2 code with 32 registers), AVX2 and the scalar twins
// (street_light_max_isa) give the light map of a shared Cityscapes frame (poles, façades,
// vehicles) in the same bits, as do the other per-pixel stages' twins (each lane does the same
// IEEE operations). Where the machine lacks AVX-512 or AVX2 the capped runs take the same path
// and the test checks determinism.
// Both forms of the lamps' distribution beyond the cut-off are covered: the quartic pieces (the
// preset's 5° falloff) and the 4096-step table (a 1° falloff, too steep for the pieces).
TEST(StreetLighting, LightMapIsTheSameBitsAtEveryInstructionSet) {
  PHOTOSITE_REQUIRE_SHARED("data/cityscapes");
  const auto frame = cityscapes_frame("aachen_000001_000019");
  const ImageF& lin = frame.first;
  const LabelMap& lab = frame.second;
  for (const double falloff_deg : {5.0, 1.0}) {
    ScenePreset p = load_scene_preset("night-urban");
    p.lamp_falloff_deg = falloff_deg;
    bool pieces = false;
    lamp_relative_intensity_float(0.5f, p, &pieces);
    EXPECT_EQ(pieces, falloff_deg == 5.0) << falloff_deg << "°";
    std::vector<ImageF> lights;
    for (const int isa : {2, 1, 0}) {
      street_light_max_isa(isa);
      lights.push_back(night_scene(lin, lab, p, 1).lights);
    }
    street_light_max_isa(2);
    double sum = 0;
    for (size_t i = 0; i < lights[2].size(); ++i) sum += lights[2][i];
    EXPECT_GT(sum, 0.0);
    for (int k = 0; k < 2; ++k)
      EXPECT_EQ(differing_samples(lights[k], lights[2]), 0u)
          << (k == 0 ? "AVX-512" : "AVX2") << " against the scalar twins, falloff " << falloff_deg << "°";
  }
}

// The float paths' lamp distribution beyond the cut-off (pools, vertical light: 16 quartic pieces
// in cos γ, street.cpp RelTable) against the law rel(γ) = exp(−(γ − γ_c)/φ) in double, at 200,001
// values of cos γ over [0, cos γ_c]. Bound: the pieces' own error (measured when they are built
// and used only within 10⁻⁶) plus the float evaluation: Horner's 4 products and 4 sums over
// positive terms (the presets' pieces have positive coefficients) 8·2⁻²⁴, and the argument
// c·(16/cos γ_c) rounded twice, 2·2⁻²⁴ relative in c, amplified by s = |d ln rel/d ln cos γ| =
// cot γ/φ ≤ cot γ_c/φ (5.34 at 65° + 5°). The vertical light's form, the pieces by Estrin's scheme
// (RelTable::polyf_estrin), within 6·2⁻²⁴ instead of Horner's 8 (each monomial's path: at most six
// roundings), the rest alike. Inside the cut-off the value is exactly 1. A 1° falloff is too steep
// for 16 pieces: the table is used instead.
TEST(StreetLighting, LampDistributionPiecesFollowTheLawBeyondTheCutOff) {
  const ScenePreset p = load_scene_preset("night-urban");
  bool pieces = false;
  double fit = 0;
  lamp_relative_intensity_float(0.5f, p, &pieces, &fit);
  ASSERT_TRUE(pieces);
  EXPECT_LE(fit, 1e-6);
  const double gc = p.lamp_cutoff_deg * M_PI / 180, phi = p.lamp_falloff_deg * M_PI / 180, cc = std::cos(gc);
  const double s_max = 1 / (std::tan(gc) * phi);
  for (const bool estrin : {false, true}) {
    const double tol = fit + ((estrin ? 6 : 8) + 2 * s_max) * std::ldexp(1.0, -24);
    double worst = 0;
    for (int i = 0; i <= 200000; ++i) {
      const float c = static_cast<float>(cc * i / 200000);
      const double want = lamp_relative_intensity(std::acos(static_cast<double>(c)), p);
      const double got = lamp_relative_intensity_float(c, p, nullptr, nullptr, estrin);
      if (!(c < static_cast<float>(cc))) {
        EXPECT_EQ(got, 1.0) << c;
        continue;
      }
      worst = std::max(worst, std::fabs(got / want - 1));
    }
    EXPECT_LE(worst, tol) << (estrin ? "Estrin" : "Horner");
    std::fprintf(stderr, "[lamp pieces] falloff %.0f°, %s: pieces' fit %.2e, worst relative error in float %.2e (bound %.2e)\n",
                 p.lamp_falloff_deg, estrin ? "Estrin (vertical light)" : "Horner (pools)", fit, worst, tol);
  }
  ScenePreset steep = p;
  steep.lamp_falloff_deg = 1;
  double fit_steep = 0;
  lamp_relative_intensity_float(0.5f, steep, &pieces, &fit_steep);
  EXPECT_FALSE(pieces) << "pieces' error " << fit_steep;
  EXPECT_GT(fit_steep, 1e-6);
}

// The façade windows alone (add_facade_windows) at every instruction set this machine has: the
// AVX-512VL and AVX2 rows (the candidates' compaction, the pane geometry with its kinds stored
// four at a time, the pane pixels found eight kinds a word) give the scalar twins' windows in the
// same bits and count, on three shared Cityscapes frames (their depth and façades as the chain
// makes them), at 1 and 2 threads, and the same bits at 2 threads as at 1.
TEST(FacadeWindows, VectorRowsAreTheScalarTwins) {
  PHOTOSITE_REQUIRE_SHARED("data/cityscapes");
  const ScenePreset p = load_scene_preset("night-urban");
  const int before = omp_get_max_threads();
  for (const char* base : {"aachen_000000_000019", "aachen_000001_000019", "aachen_000003_000019"}) {
    const auto [lin, lab] = cityscapes_frame(base);
    const NightScene ns = night_scene(lin, lab, p, 1);
    const BuildingFacades fac = building_facades(lab.ids, ns.geometry, p.max_depth_m);
    const ImageF texture = reflectance_texture(lin, lab.ids, p);
    std::vector<ImageF> one_thread;  // the scalar twins' maps at 1 thread (grid, photo's windows)
    for (const int threads : {1, 2}) {
      omp_set_num_threads(threads);
      std::vector<ImageF> maps;
      std::vector<int> counts;
      // Without the day texture (the grid on every façade) and with it (the photo's windows where it
      // resolves a façade: those planes' pixels leave the kernels for the per-pixel path).
      for (const ImageF* tex : {static_cast<const ImageF*>(nullptr), &texture})
        for (const int isa : {2, 1, 0}) {
          street_light_max_isa(isa);
          ImageF L(lin.width(), lin.height(), 3, 0.f, unit::radiance);
          counts.push_back(add_facade_windows(L, lab.ids, ns.depth, ns.geometry, p, 7, &fac, tex));
          maps.push_back(std::move(L));
        }
      street_light_max_isa(2);
      for (int t = 0; t < 2; ++t) {
        const char* how = t == 0 ? " (grid)" : " (the photo's windows)";
        EXPECT_GT(counts[3 * t + 2], 0) << base << how;
        for (int k = 0; k < 2; ++k) {
          EXPECT_EQ(counts[3 * t + k], counts[3 * t + 2])
              << base << how << (k == 0 ? " AVX-512" : " AVX2") << ", " << threads << " threads";
          EXPECT_EQ(differing_samples(maps[3 * t + k], maps[3 * t + 2]), 0u)
              << base << how << (k == 0 ? " AVX-512" : " AVX2") << " against the scalar twins, " << threads << " threads";
        }
        // The thread count changes nothing either (the photo's windows: each thread's rows of samples
        // appended in row order, the cells' sums in that order).
        if (threads == 1) one_thread.push_back(maps[3 * t + 2]);
        else EXPECT_EQ(differing_samples(maps[3 * t + 2], one_thread[t]), 0u) << base << how << " at 2 threads against 1";
      }
    }
  }
  omp_set_num_threads(before);
}

namespace {
// A synthetic street at 2048x1024 with no boxes whose façades show dark windows: 1.2 x 1.6 m glass
// every 2.7 m along the road, storeys of 3.4 m (neither is the preset grid's 1.3 m bay or 3 m
// storey).
SyntheticCameraOptions windowed_street() {
  SyntheticCameraOptions o = camera_scene(2048, 1024);
  o.boxes.clear();
  o.window_pitch_m = 2.7;
  o.window_phase_m = 0.35;
  return o;
}
}  // namespace

// window_block_avx512 leaves the photo-resolved pane lanes out of P eight at a time: a lane's cell
// ⌊(s − s0)/kCell_m⌋ is read from the plane's table only where it lies in [0, ns) (the range
// mask; the others read cell 0 and are masked off). VectorRowsAreTheScalarTwins did not see that
// mask: the lanes beyond the table must be pane lanes of groups inside one façade plane (the fast
// groups) on a plane whose table is used and whose cell 0 is resolved, and its frames show few or
// none. Here they are the rule: a synthetic street whose façades (the planes X = ±10 m) show dark
// windows, so that the photo resolves them near the camera (cell 0, the nearest sampled column,
// holds samples of its own and its 8 m stretch keeps its windows), and run far ahead, where a
// pixel spans more than kMaxFootprint_m = 2·kCell_m along the façade (z²·k_D > 2·kCell_m·d·f:
// find_facade_windows samples none of them, so their cells lie past ns) while z stays within the
// window pass's zmax: there the grid's panes are drawn, by the fast groups. Every window lit. The
// AVX-512 and AVX2 rows against the scalar twins, bit for bit, and the lit pixels beyond the
// footprint limit counted (the lanes the range mask keeps).
TEST(FacadeWindows, VectorRowsKeepThePanesBeyondThePhotosCells) {
  const SyntheticCameraOptions o = windowed_street();
  const SyntheticCameraScene s = make_synthetic_camera_scene(o);
  const CameraGeometry& g = o.camera;
  ScenePreset p = urban();
  p.window_lit_fraction = 1.0;
  p.max_depth_m = 1000;
  const ImageF depth = metric_depth(s.labels, g, p.max_depth_m);
  const BuildingFacades fac = building_facades(s.labels.ids, g, p.max_depth_m);
  const ImageF tex = reflectance_texture(s.day_linear_srgb, s.labels.ids, p);
  std::vector<ImageF> maps;
  std::vector<int> counts;
  for (const int isa : {2, 1, 0}) {
    street_light_max_isa(isa);
    ImageF L(o.width, o.height, 3, 0.f, unit::radiance);
    counts.push_back(add_facade_windows(L, s.labels.ids, depth, g, p, 3, &fac, &tex));
    maps.push_back(std::move(L));
  }
  street_light_max_isa(2);
  const double foot = 2 * FacadeWindowsFound::kCell_m * g.f_px;  // ×d: the footprint limit
  long far_lit = 0, near_lit = 0;
  for (int y = 0; y < o.height; ++y)
    for (int x = 0; x < o.width; ++x) {
      const FacadePlane* f = fac.plane_at(x, y);
      if (!f || !(maps[2].at(x, y, 0) + maps[2].at(x, y, 1) + maps[2].at(x, y, 2) > 0)) continue;
      const double z = depth.at(x, y), kD = std::cos(g.pitch_rad) - (y - g.cy_px) / g.f_px * std::sin(g.pitch_rad);
      (z * z * kD > foot * f->d_m ? far_lit : near_lit) += 1;
    }
  std::fprintf(stderr, "[windows] %d windows; lit pixels %ld within the footprint limit, %ld beyond it\n", counts[2],
               near_lit, far_lit);
  EXPECT_GT(near_lit, 1000);
  EXPECT_GT(far_lit, 1000);
  for (int k = 0; k < 2; ++k) {
    EXPECT_EQ(counts[k], counts[2]) << (k == 0 ? "AVX-512" : "AVX2");
    EXPECT_EQ(differing_samples(maps[k], maps[2]), 0u) << (k == 0 ? "AVX-512" : "AVX2") << " against the scalar twins";
  }
}

// find_facade_windows samples, on the rows y ≡ 0 (mod kRowStep = 3) and every column, the pixels
// of a building region whose column takes a fitted plane it is on (Region::column_plane,
// on_plane), with 0 < z ≤ zmax, a footprint along the plane z²·k_D ≤ kMaxFootprint_m·d·f
// (kMaxFootprint_m = 2·kCell_m) and Y ≥ 0; a sample's s = fl(t_X·X + t_D·D) and Y as floats
// (X = z·(x − c_x)/f, D = z·k_D, Y = h − z·k_Y). Each plane's count of samples, its cells' origin
// s0 = min s and their count ns = ⌊(max s − s0)/kCell_m⌋ + 1, and whether its table is used (at
// least 100 samples and at most kMaxCells cells) are computed here from that definition, on
// random façades: region runs of every length starting at any column (its SIMD scan for the next
// building column, eight at a time), columns without a plane, off their plane or on an unfitted
// one, odd depths (NaN, ±∞, 0, negative, beyond zmax) and depths beyond the footprint limit; at 1
// and 2 threads (the rows in chunks taken as they come). A change of which pixels are sampled
// changes a count.
TEST(FacadeWindows, SampledPixelsAreTheDefinitions) {
  SyntheticCameraOptions o = camera_scene();
  const CameraGeometry& g = o.camera;
  const int W = o.width, H = o.height;
  ScenePreset p = urban();
  ASSERT_GT(p.window_detect_contrast, 0);
  std::mt19937_64 rng(4242);
  std::uniform_real_distribution<double> U(0, 1);
  BuildingFacades fac;
  fac.region = ImageI32(W, H, 1, -1);
  fac.planes = {{0.98, 0.2, 9, 0, 0, 12, true}, {-0.95, 0.31, 7, 0, 0, 12, true}, {0.1, 0.995, 30, 0, 0, 12, true},
                {1, 0, 11, 0, 0, 0, false}};
  const int nplanes = static_cast<int>(fac.planes.size());
  for (const auto [x0, x1] : {std::pair{0, W}, {137, 611}, {503, W - 9}}) {
    BuildingFacades::Region R;
    R.x0 = x0;
    int pi = 0;
    for (int x = x0; x < x1; ++x) {
      if (U(rng) < 0.02) pi = static_cast<int>(U(rng) * (nplanes + 1)) - 1;  // runs of planes, -1 among them
      R.column_plane.push_back(pi);
      R.on_plane.push_back(U(rng) < 0.9);
    }
    fac.regions.push_back(R);
  }
  ImageF depth(W, H, 1, 0.f), tex(W, H, 3, 0.f);
  const float odd[] = {NAN, INFINITY, -INFINITY, 0.f, -2.f, 900.f};
  for (int y = 0; y < H; ++y) {
    for (int x = 0; x < W;) {  // runs of one region (or none) of 1 to 40 columns
      const int r = static_cast<int>(U(rng) * 4) - 1, len = 1 + static_cast<int>(U(rng) * 40);
      for (int e = std::min(W, x + len); x < e; ++x) {
        const bool inside = r >= 0 && x >= fac.regions[r].x0 &&
                            x < fac.regions[r].x0 + static_cast<int>(fac.regions[r].column_plane.size());
        fac.region.at(x, y) = inside ? r : -1;
      }
    }
    for (int x = 0; x < W; ++x) {
      depth.at(x, y) = U(rng) < 0.03 ? odd[static_cast<int>(U(rng) * 6)] : static_cast<float>(2 + 78 * U(rng));
      for (int c = 0; c < 3; ++c) tex.at(x, y, c) = static_cast<float>(U(rng));
    }
  }
  std::vector<double> tX(nplanes), tD(nplanes);
  for (int k = 0; k < nplanes; ++k) tX[k] = fac.planes[k].nD, tD[k] = -fac.planes[k].nX;  // along each plane
  const double zmax = 60;
  // The definition.
  struct Ref {
    long n = 0;
    float s_lo = INFINITY, s_hi = -INFINITY, y_lo = INFINITY, y_hi = -INFINITY;
  };
  std::vector<Ref> ref(nplanes);
  const double c = std::cos(g.pitch_rad), sn = std::sin(g.pitch_rad), h = g.mount_height_m;
  for (int y = 0; y < H; y += 3)
    for (int x = 0; x < W; ++x) {
      const int r = fac.region.at(x, y);
      if (r < 0) continue;
      const BuildingFacades::Region& R = fac.regions[r];
      const int pi = R.column_plane[x - R.x0];
      if (pi < 0 || !R.on_plane[x - R.x0] || !fac.planes[pi].fitted) continue;
      const double zz = depth.at(x, y), yn = (y - g.cy_px) / g.f_px, kD = c - yn * sn, kY = yn * c + sn;
      if (!(zz > 0) || zz > zmax || zz * zz * kD > 2 * FacadeWindowsFound::kCell_m * fac.planes[pi].d_m * g.f_px) continue;
      const double X = zz * (x - g.cx_px) / g.f_px, D = zz * kD, Y = h - zz * kY;
      if (Y < 0) continue;
      const float s = static_cast<float>(tX[pi] * X + tD[pi] * D), Yf = static_cast<float>(Y);
      Ref& q = ref[pi];
      ++q.n;
      q.s_lo = std::min(q.s_lo, s), q.s_hi = std::max(q.s_hi, s), q.y_lo = std::min(q.y_lo, Yf), q.y_hi = std::max(q.y_hi, Yf);
    }
  const int before = omp_get_max_threads();
  for (const int threads : {1, 2}) {
    omp_set_num_threads(threads);
    const FacadeWindowsFound f = find_facade_windows(tex, depth, g, fac, p, tX.data(), tD.data(), zmax);
    ASSERT_EQ(f.planes.size(), static_cast<size_t>(nplanes));
    int used = 0;
    for (int k = 0; k < nplanes; ++k) {
      const Ref& q = ref[k];
      const double cell = FacadeWindowsFound::kCell_m;
      const long ns = q.n ? static_cast<long>((static_cast<double>(q.s_hi) - q.s_lo) / cell) + 1 : 0;
      const long ny = q.n ? static_cast<long>((static_cast<double>(q.y_hi) - q.y_lo) / cell) + 1 : 0;
      std::fprintf(stderr, "[photo windows] %d threads, plane %d: %ld samples, s %.3f..%.3f m, %ld x %ld cells\n",
                   threads, k, q.n, q.s_lo, q.s_hi, ns, ny);
      EXPECT_EQ(f.planes[k].samples, q.n) << "plane " << k << ", " << threads << " threads";
      const bool use = q.n >= 100 && ns * ny <= 4'000'000;
      ASSERT_EQ(f.planes[k].used, use) << "plane " << k << ", " << threads << " threads";
      if (!use) continue;
      ++used;
      EXPECT_EQ(f.planes[k].s0, static_cast<double>(q.s_lo)) << "plane " << k;
      EXPECT_EQ(f.planes[k].ns, ns) << "plane " << k;
    }
    EXPECT_EQ(used, 3) << "the fitted planes, each with samples enough";
  }
  omp_set_num_threads(before);
}

// find_facade_windows' components of the dark cells (cell_components, by runs) are OpenCV's:
// cv::connectedComponentsWithStats(4-connected)'s labels 1 .. n − 1 in order, with the same box and
// area, on random masks of every density (from isolated cells to one component winding through
// the grid), masks whose components join only rows below their first cells (combs, a spiral, a
// U whose arms merge at the bottom), a single row or column, an empty and a full mask, with
// OpenCV at 1 thread and at 2 (its parallel labelling by stripes). Fails if the runs join
// 8-connected (diagonal runs), if the components come in another order (by their roots' last runs,
// or by size), or if a run is not joined to every run above it that it touches.
TEST(FacadeWindows, CellComponentsAreOpenCVs) {
  std::mt19937_64 rng(2311);
  std::vector<cv::Mat> masks;
  for (const auto [w, h] : {std::pair{1, 1}, {1, 37}, {53, 1}, {17, 9}, {64, 64}, {251, 142}, {273, 134}, {95, 30}})
    for (const double density : {0.0, 0.05, 0.3, 0.5, 0.6, 0.75, 0.95, 1.0}) {
      cv::Mat m(h, w, CV_8U);
      std::bernoulli_distribution B(density);
      for (int j = 0; j < h; ++j)
        for (int i = 0; i < w; ++i) m.at<uint8_t>(j, i) = B(rng) ? 1 : 0;
      masks.push_back(m);
    }
  {
    cv::Mat comb(40, 61, CV_8U, cv::Scalar(0));  // teeth down from row 0, joined by the bottom row
    for (int i = 0; i < 61; i += 2) comb.col(i).setTo(1);
    comb.row(39).setTo(1);
    comb.at<uint8_t>(39, 60) = 0;
    masks.push_back(comb);
    cv::Mat up(40, 61, CV_8U, cv::Scalar(0));  // teeth up from the bottom, joined by the top row
    for (int i = 1; i < 61; i += 2) up.col(i).setTo(1);
    up.row(0).setTo(1);
    masks.push_back(up);
    cv::Mat u(30, 30, CV_8U, cv::Scalar(0));  // arms begun apart, met at the bottom
    u.col(3).setTo(1), u.col(20).setTo(1), u.row(29).setTo(1);
    u.at<uint8_t>(5, 10) = 1;
    masks.push_back(u);
    cv::Mat spiral(41, 41, CV_8U, cv::Scalar(0));
    for (int r = 0; 2 * r < 41; r += 2) {
      cv::rectangle(spiral, cv::Rect(r, r, 41 - 2 * r, 41 - 2 * r), cv::Scalar(1), 1);
      if (r + 1 < 41) spiral.at<uint8_t>(r + 1, r) = 0;
    }
    masks.push_back(spiral);
    cv::Mat diag(20, 20, CV_8U, cv::Scalar(0));  // diagonal cells: 20 components 4-connected
    for (int i = 0; i < 20; ++i) diag.at<uint8_t>(i, i) = 1;
    masks.push_back(diag);
  }
  const int before = cv::getNumThreads();
  long compared = 0;
  for (const int threads : {1, 2}) {
    cv::setNumThreads(threads);
    for (size_t k = 0; k < masks.size(); ++k) {
      const cv::Mat& m = masks[k];
      cv::Mat lab, stats, cents;
      const int n = cv::connectedComponentsWithStats(m, lab, stats, cents, 4, CV_32S);
      const std::vector<CellComponent> got = cell_components(m.ptr<uint8_t>(0), m.cols, m.rows);
      ASSERT_EQ(static_cast<int>(got.size()), n - 1) << "mask " << k << " (" << m.cols << "x" << m.rows << "), " << threads
                                                      << " OpenCV threads";
      for (int q = 1; q < n; ++q) {
        const CellComponent& c = got[q - 1];
        EXPECT_EQ(c.left, stats.at<int>(q, cv::CC_STAT_LEFT)) << "mask " << k << " component " << q;
        EXPECT_EQ(c.top, stats.at<int>(q, cv::CC_STAT_TOP)) << "mask " << k << " component " << q;
        EXPECT_EQ(c.width, stats.at<int>(q, cv::CC_STAT_WIDTH)) << "mask " << k << " component " << q;
        EXPECT_EQ(c.height, stats.at<int>(q, cv::CC_STAT_HEIGHT)) << "mask " << k << " component " << q;
        ASSERT_EQ(c.area, stats.at<int>(q, cv::CC_STAT_AREA)) << "mask " << k << " component " << q;
        ++compared;
      }
    }
  }
  cv::setNumThreads(before);
  std::fprintf(stderr, "[windows] %ld components equal OpenCV's\n", compared);
  EXPECT_GT(compared, 1000);
}

// The AVX-512 window layout's floors ⌊a/b⌋ (storey, pitch cell, shop unit) from the product with
// the reciprocal (window_floor_div_avx512) are the division's floors on every lane, where they
// matter most: a = k·b rounded and its neighbours one and two ulps away on either side (where the
// product and the division can round to different sides of the integer k), a few ulps off k·b
// in relative terms, zeros, and random values, for the three divisors the urban preset takes and
// awkward ones. Fails if the fallback to the division is dropped (the product alone gives other
// floors next to the multiples) or its margin taken below the error of the product.
TEST(FacadeWindows, ReciprocalFloorsAreTheDivisionsFloors) {
  std::vector<double> a;
  std::mt19937_64 rng(12345);
  std::uniform_real_distribution<double> U(-3000.0, 3000.0);
  const ScenePreset p = load_scene_preset("night-urban");
  const double divisors[] = {p.window_storey_m, p.window_pitch_m, p.shop_frontage_m, 0.1, 1.0 / 3, 7.77, 2.9999999999999996};
  long checked = 0, off_product = 0;
  for (const double b : divisors) {
    a.clear();
    for (int k = -1000; k <= 1000; ++k) {
      double v = k * b;
      a.push_back(v);
      for (int step = 0; step < 2; ++step) {
        v = std::nextafter(v, INFINITY);
        a.push_back(v);
      }
      v = k * b;
      for (int step = 0; step < 2; ++step) {
        v = std::nextafter(v, -INFINITY);
        a.push_back(v);
      }
      for (const double r : {1 - 0x1p-52, 1 + 0x1p-52, 1 - 0x1p-50, 1 + 0x1p-50, 1 - 0x1p-48, 1 + 0x1p-48})
        a.push_back(k * b * r);
    }
    a.push_back(0.0);
    a.push_back(-0.0);
    for (int i = 0; i < 200000; ++i) a.push_back(U(rng));
    std::vector<double> got(a.size());
    if (!window_floor_div_avx512(a.data(), static_cast<int>(a.size()), b, got.data()))
      GTEST_SKIP() << "no AVX-512F/VL here (or PHOTOSITE_SCALAR_LIGHTS=1): the AVX-512 window layout is not taken";
    const double inv = 1.0 / b;
    for (size_t i = 0; i < a.size(); ++i) {
      const double want = std::floor(a[i] / b);
      ASSERT_EQ(std::bit_cast<uint64_t>(got[i]), std::bit_cast<uint64_t>(want)) << a[i] << " / " << b;
      off_product += std::floor(a[i] * inv) != want;
      ++checked;
    }
  }
  std::fprintf(stderr, "[windows] %ld floors equal the division's; the product alone would differ on %ld\n", checked,
               off_product);
  EXPECT_GT(off_product, 0);  // the inputs reach the cases the fallback exists for
}

// The light map's one pass over the rows (light_map_fused_rows on, the default: each row begins
// with its retroreflection and vehicle lamps, and night_scene's ends with its night radiance,
// LightMap::composed, the lamp heads then drawn row by row) pinned to its definition, the separate
// steps (light_map_fused_rows off: the retroreflection over the frame, the vehicle lamps, the
// street rows, the heads after them, then compose()): on a shared Cityscapes frame (poles with
// heads, façade windows, vehicles, signs) at 1 and 2 threads and at AVX-512, AVX2 and the scalar
// twins, the chain's lights and the light map alone equal the steps' light map, the chain's
// radiance equals compose() of it, bit for bit, with the same counts.
TEST(StreetLighting, LightMapsRowPassAndItsRadianceAreTheSeparateSteps) {
  PHOTOSITE_REQUIRE_SHARED("data/cityscapes");
  const auto [lin, file_labels] = cityscapes_frame("aachen_000000_000019");
  const ScenePreset p = load_scene_preset("night-urban");
  // The labels as the chain's stages see them, the sky through the crowns taken (take_sky_gaps;
  // night_scene takes them itself only from labels where they were not).
  LabelMap lab = file_labels;
  ASSERT_GT(take_sky_gaps(lab, lin, p), 0u);
  ImageF tex = reflectance_texture(lin, lab.ids, p);
  ASSERT_GT(unmix_sky_fringe(tex, lin, lab, p), 0u);  // as night_scene's texture
  const int before = omp_get_max_threads();
  for (const int isa : {2, 1, 0})
    for (const int threads : {1, 2}) {
      street_light_max_isa(isa);
      omp_set_num_threads(threads);
      const NightScene ns = night_scene(lin, lab, p, 1);
      bool fused = false;
      for (const StageTiming& st : ns.timings) fused |= st.stage == "lights+compose";
      EXPECT_TRUE(fused) << "the chain composed after the light map, not inside it";
      const BuildingFacades fac = building_facades(lab.ids, ns.geometry, p.max_depth_m);
      const ImageU8 lanes = lanes_at_frame(ns.lanes_work, lab.ids);
      auto map = [&](bool rows) {
        light_map_fused_rows(rows);
        LightMap m = light_map(lin, tex, lab, lanes, ns.beam_input, ns.vp, p, 1, &ns.geometry, &ns.depth, &ns.beam_lux, &fac);
        light_map_fused_rows(true);
        return m;
      };
      const LightMap steps = map(false), alone = map(true);
      ASSERT_TRUE(steps.composed.empty());
      EXPECT_GT(steps.stats.pole_lamps, 0);  // heads to draw row by row
      EXPECT_GT(steps.stats.windows, 0);
      EXPECT_GT(steps.stats.vehicle_lamps, 0);
      for (const LightStats* st : {&ns.light_stats, &alone.stats}) {
        EXPECT_EQ(st->pole_lamps, steps.stats.pole_lamps);
        EXPECT_EQ(st->windows, steps.stats.windows);
        EXPECT_EQ(st->signals, steps.stats.signals);
        EXPECT_EQ(st->vehicle_lamps, steps.stats.vehicle_lamps);
      }
      EXPECT_EQ(differing_samples(ns.lights, steps.radiance), 0u) << "chain's lights, isa " << isa << ", " << threads << " threads";
      EXPECT_EQ(differing_samples(alone.radiance, steps.radiance), 0u) << "light map, isa " << isa << ", " << threads << " threads";
      const ImageF want = compose(tex, steps.radiance, lab.ids, ns.beam_lux, p);
      EXPECT_EQ(differing_samples(ns.radiance, want), 0u) << "radiance, isa " << isa << ", " << threads << " threads";
    }
  street_light_max_isa(2);
  omp_set_num_threads(before);
}


namespace {
// Level 1 of an image by glare_level1_row, row after row, then its sums (itself held to the
// pyramid's whole-image definition by GlareFastPath.Level1MadeByTheCallerGivesTheSameSkirt).
GlareLevel1 level1_in_order(const ImageF& radiance) {
  GlareLevel1 l1(radiance.width(), radiance.height());
  for (int j = 0; j < l1.image.height(); ++j) glare_level1_row(radiance, j, l1);
  glare_level1_sums(l1, 0, l1.image.height());
  return l1;
}
bool same_level1(const GlareLevel1& a, const GlareLevel1& b) {
  return differing_samples(a.image, b.image) == 0 && a.row_sums.size() == b.row_sums.size() &&
         std::memcmp(a.row_sums.data(), b.row_sums.data(), a.row_sums.size() * sizeof(a.row_sums[0])) == 0;
}
}  // namespace

// ComposeRows with the lens glare's level 1: rows composed in any order on any thread (here two
// threads taking rows from both ends, and one thread in a shuffled order) make every level row,
// each from its pair once both are composed, equal to glare_level1_row over the finished image,
// bit for bit: odd and even heights (the last level row from one row), an odd width; the night
// radiance itself equals compose()'s.
TEST(SceneChain, ComposePassMakesTheGlareLevel1OfItsRadiance) {
  const ScenePreset p = load_scene_preset("night-urban");
  for (const auto& size : {std::pair{333, 101}, std::pair{64, 40}, std::pair{17, 1}}) {
    const int W = size.first, H = size.second;
    ImageF tex(W, H, 3, 0.f), lights(W, H, 3, 0.f, unit::radiance), beam(W, H, 1, 0.f);
    ImageU16 ids(W, H, 1, uint16_t{0});
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x) {
        const auto u = random_words(17, 0, static_cast<uint64_t>(y) * W + x, Stream::Test);
        for (int c = 0; c < 3; ++c) {
          tex.at(x, y, c) = static_cast<float>(uniform_open(u[c]));
          lights.at(x, y, c) = static_cast<float>(std::pow(10.0, 8.0 * uniform_open(u[3]) - 4.0) * (c + 1));
        }
        beam.at(x, y) = static_cast<float>(40.0 * uniform_open(u[3] ^ u[0]));
        ids.at(x, y) = static_cast<uint16_t>(u[0] % kLabelCount);
      }
    const ImageF want = compose(tex, lights, ids, beam, p);
    const GlareLevel1 want1 = level1_in_order(want);
    // Two threads from both ends (rows meet in the middle, pairs split between the threads).
    {
      ImageF night(W, H, 3, 0.f, unit::radiance);
      GlareLevel1 l1(W, H);
      const ComposeRows rows(tex, lights, ids, beam, p, night, &l1);
#pragma omp parallel for num_threads(2) schedule(static, 1)
      for (int i = 0; i < H; ++i) rows.row(i % 2 == 0 ? i / 2 : H - 1 - i / 2);
      EXPECT_EQ(differing_samples(night, want), 0u) << W << "x" << H;
      EXPECT_TRUE(same_level1(l1, want1)) << W << "x" << H << ", two threads";
    }
    // One thread, the rows shuffled.
    {
      std::vector<int> order(H);
      for (int y = 0; y < H; ++y) order[y] = y;
      std::shuffle(order.begin(), order.end(), std::mt19937(7));
      ImageF night(W, H, 3, 0.f, unit::radiance);
      GlareLevel1 l1(W, H);
      const ComposeRows rows(tex, lights, ids, beam, p, night, &l1);
      for (const int y : order) rows.row(y);
      EXPECT_TRUE(same_level1(l1, want1)) << W << "x" << H << ", shuffled";
    }
  }
}

// night_scene asked for the glare's level 1 makes it in the light map's row pass: the radiance is
// the same as without it, and the level equals glare_level1_row over that radiance, bit for bit,
// on a shared Cityscapes frame at 1 and 2 threads; not asked, none is made.
TEST(SceneChain, NightSceneMakesTheGlareLevel1OfItsRadiance) {
  PHOTOSITE_REQUIRE_SHARED("data/cityscapes");
  const auto [lin, lab] = cityscapes_frame("aachen_000003_000019");
  const ScenePreset p = load_scene_preset("night-urban");
  const int before = omp_get_max_threads();
  for (const int threads : {1, 2}) {
    omp_set_num_threads(threads);
    const NightScene plain = night_scene(lin, lab, p, 1);
    EXPECT_EQ(plain.glare_level1, nullptr);
    const NightScene ns = night_scene(lin, lab, p, 1, false, nullptr, nullptr, true);
    ASSERT_NE(ns.glare_level1, nullptr) << threads << " threads";
    EXPECT_EQ(differing_samples(ns.radiance, plain.radiance), 0u) << threads << " threads";
    EXPECT_TRUE(same_level1(*ns.glare_level1, level1_in_order(ns.radiance))) << threads << " threads";
  }
  omp_set_num_threads(before);
}

// A scene without street lighting (night-rural: road luminance 0) still measures the road's extent
// from the labels, as the lit one does: the vehicle lamps' in-traffic test (the kerb strip) reads
// it. Before, the plan returned at once and every vehicle on road pixels counted as in traffic
// (KITTI 000000_10: 4 in traffic under night-rural, 2 under night-urban).
TEST(StreetLighting, RoadExtentIsMeasuredWithoutStreetLighting) {
  SyntheticCameraOptions o = camera_scene();
  o.boxes.clear();
  const SyntheticCameraScene sc = make_synthetic_camera_scene(o);
  ScenePreset lit = urban(), unlit = urban();
  unlit.street_road_luminance_cd_m2 = 0;
  const StreetLighting a = plan_street_lighting(sc.labels, o.camera, lit, 7);
  const StreetLighting b = plan_street_lighting(sc.labels, o.camera, unlit, 7);
  EXPECT_FALSE(a.lamps.empty());
  EXPECT_TRUE(b.lamps.empty());
  // Exact: see PoolsAlongTheRoadEdgesHoldTheClassAverage.
  EXPECT_EQ(b.road_left_m, -o.road_half_width_m);
  EXPECT_EQ(b.road_right_m, o.road_half_width_m);
  EXPECT_EQ(b.road_left_m, a.road_left_m);
  EXPECT_EQ(b.road_right_m, a.road_right_m);
}

// Every bundled scene preset with a lit road meets its EN 13201-2 M class on its own design layout
// (street_design_layout: one row at the kerb, the preset's spacing and height, a carriageway as
// wide as the mounting height): the field averages the class luminance and its overall uniformity
// U0 = E_min/E_avg reaches the class's (M1-M4 ≥ 0.40, M5-M6 ≥ 0.35; EN 13201-2:2015 via NP §1;
// the class is the one whose L̄ the preset asks, classes M1..M6 = 2.0, 1.5, 1.0, 0.75, 0.5, 0.3).
// U0 here is the illuminance's (the road taken as Lambertian, docs/night.md §7), and falls as the
// spacing grows: night-urban's luminaires at 4 × their height would give 0.35, below M3's 0.40.
TEST(StreetLighting, DesignLayoutMeetsThePresetsClass) {
  int lit = 0;
  for (const auto& entry : std::filesystem::directory_iterator(std::filesystem::path(preset_dir()) / "scenes")) {
    if (entry.path().extension() != ".toml") continue;
    const ScenePreset p = load_scene_preset(entry.path().string());
    if (p.street_road_luminance_cd_m2 <= 0) {
      EXPECT_TRUE(street_design_layout(p).lamps.empty()) << entry.path();
      continue;
    }
    ++lit;
    const double L = p.street_road_luminance_cd_m2;
    ASSERT_GE(L, 0.3) << entry.path() << ": below EN 13201-2's least M class (M6, 0.30 cd/m²)";
    const double u0_class = L >= 0.75 ? 0.40 : 0.35;
    double I0[2];
    for (const bool staggered : {false, true}) {
      const StreetLighting d = street_design_layout(p, staggered);
      const double W = (staggered ? 1.5 : 1.0) * p.lamp_mount_height_m;
      ASSERT_EQ(d.lamps.size(), staggered ? 14u : 7u);
      EXPECT_EQ(d.road_right_m - d.road_left_m, W);
      // The field's average: I0 = π·L/(ρ·Ē(1)) and Ē(I0) = I0·Ē(1) up to the roundings of
      // PoolsAlongTheRoadEdgesHoldTheClassAverage's bound (60 points × the lamps).
      EXPECT_NEAR(d.avg_luminance_cd_m2, L, (3 + 2 * 60.0 * d.lamps.size() + 6) * 0x1p-53 * L) << entry.path();
      EXPECT_GE(d.uniformity_u0, u0_class) << entry.path() << ": spacing_ratio " << p.lamp_spacing_ratio;
      // The field is the one every scene reports: the same function, points and sums.
      double u0;
      EXPECT_EQ(p.rho_road * street_calculation_field_lux(d, 0, W, 0, p, &u0) / M_PI, d.avg_luminance_cd_m2)
          << entry.path();
      EXPECT_EQ(u0, d.uniformity_u0);
      I0[staggered] = d.peak_intensity_cd;
      std::fprintf(stderr, "[street design] %s, %s: S %.1f m, I0 %.0f cd, L_avg %.3f cd/m², U0 %.3f (class ≥ %.2f)\n",
                   entry.path().filename().c_str(), staggered ? "staggered" : "one-sided",
                   p.lamp_spacing_ratio * p.lamp_mount_height_m, d.peak_intensity_cd, d.avg_luminance_cd_m2,
                   d.uniformity_u0, u0_class);
    }
    // Two rows over 1.5 times the width: each luminaire gives less light than one of a single row
    // (2 rows / 1.5 the area: about 0.75 of it, less the far row's light lost beyond the kerb).
    EXPECT_LT(I0[1], I0[0]) << entry.path();
  }
  EXPECT_GE(lit, 1) << "no bundled scene preset lights its road";
  // The spacing moves U0 the way the physics says: wider gaps between the pools, a lower minimum.
  ScenePreset p = urban();
  double last = 1;
  for (double r : {2.5, 3.0, 3.5, 4.0}) {
    p.lamp_spacing_ratio = r;
    const double u0 = street_design_layout(p).uniformity_u0;
    EXPECT_LT(u0, last) << "spacing_ratio " << r;
    last = u0;
  }
  EXPECT_LT(last, 0.40);  // 4 × the height: below M3
}

// Without poles the lamps go along the road edges at the preset's height and spacing; their
// intensity is set so the design layout's EN 13201 calculation field averages the class
// luminance; the road shows pools under the lamps and darker gaps between them.
TEST(StreetLighting, PoolsAlongTheRoadEdgesHoldTheClassAverage) {
  SyntheticCameraOptions o = camera_scene();
  o.boxes.clear();
  const SyntheticCameraScene sc = make_synthetic_camera_scene(o);
  ScenePreset p = urban();
  const StreetLighting s = plan_street_lighting(sc.labels, o.camera, p, 7);
  ASSERT_EQ(s.source, "road_edges");
  // Each row's edge is the outer boundary of its last road pixel, within one pixel of the true
  // kerb: at most D/f_px = 60 m / 1131 px = 0.053 m across at the farthest row used (60 m). The
  // medians are rounded to quarter metres (scene/street.cpp), and 0.053 m < 0.125 m, so a road
  // edge on the quarter-metre grid (here ±7 m) comes back exactly.
  ASSERT_LT(60 / o.camera.f_px, 0.125);
  ASSERT_EQ(std::round(4 * o.road_half_width_m), 4 * o.road_half_width_m);
  EXPECT_EQ(s.road_left_m, -o.road_half_width_m);
  EXPECT_EQ(s.road_right_m, o.road_half_width_m);
  const double S = p.lamp_spacing_ratio * p.lamp_mount_height_m;
  // The layout's D = phase + k·S and D + S/2 (S/2 exact): each D is off by at most
  // 2⁻⁵³·(|k·S| + |D|) per rounding, two for the second row, and the difference here rounds once
  // more; with |k·S| ≤ max|D| + S (phase in [0, S)): within 8·2⁻⁵³·(max|D| + S).
  double max_D = 0;
  for (const auto& l : s.lamps) max_D = std::max(max_D, std::fabs(l.D_m));
  for (size_t i = 1; i < s.lamps.size(); ++i)
    // (8·2⁻⁵³·(max|D| + S): the layout's roundings above)
    EXPECT_NEAR(s.lamps[i].D_m - s.lamps[i - 1].D_m, S / 2, 8 * 0x1p-53 * (max_D + S));
  // The intensity is set on the design layout (one row at the kerb, carriageway as wide as the
  // mounting height): its EN 13201-3 field averages L_M.
  auto field = [&](const StreetLighting& lay, double left, double right, double D0, double* mn) {
    double sum = 0;
    *mn = 1e300;
    for (int i = 0; i < 10; ++i)
      for (int j = 0; j < 6; ++j) {
        const double e = street_illuminance_lux(left + (j + 0.5) * (right - left) / 6, D0 + (i + 0.5) * S / 10, lay, p);
        sum += e;
        *mn = std::min(*mn, e);
      }
    return sum / 60;
  };
  // This street (14 m) is wider than the mounting height: two staggered rows, and the design is
  // the staggered one, over a carriageway 1.5 H wide, the rows S/2 apart along the road.
  ASSERT_GT(s.road_right_m - s.road_left_m, p.lamp_mount_height_m);
  StreetLighting design;
  design.peak_intensity_cd = s.peak_intensity_cd;
  const double Hm = p.lamp_mount_height_m, Wd = 1.5 * Hm;
  for (int k = -3; k <= 3; ++k) {
    design.lamps.push_back({Wd + p.lamp_setback_m, Hm, k * S, false});
    design.lamps.push_back({-p.lamp_setback_m, Hm, k * S + 0.5 * S, false});
  }
  double mn;
  // street.cpp sets I0 = π·L/(ρ·Ē(I0 = 1)) on this same field; Ē is linear in I0 but not its
  // rounding: each of the n = 60 × lamps positive terms moves by about 3 roundings when scaled,
  // the two sums of n terms by at most n roundings each (recursive summation, positive terms),
  // and I0's and this side's products and quotients add 6: (3 + 2n + 6)·2⁻⁵³ of L, whatever
  // order each side sums its lamps in (street.cpp sorts them by D).
  const double n_terms = 60.0 * design.lamps.size();
  EXPECT_NEAR(p.rho_road * field(design, 0, Wd, 0, &mn) / M_PI, p.street_road_luminance_cd_m2,
              (3 + 2 * n_terms + 6) * 0x1p-53 * p.street_road_luminance_cd_m2);
  // This scene's own field: the reported L_avg and U0.
  const double avg = field(s, s.road_left_m, s.road_right_m, s.grid_D0_m, &mn);
  // Exact: street.cpp evaluates this same field (the same points, order and sums) and reports
  // these same expressions.
  EXPECT_EQ(s.avg_luminance_cd_m2, p.rho_road * avg / M_PI);
  EXPECT_EQ(s.uniformity_u0, mn / avg);
  std::fprintf(stderr, "[street] %zu lamps, I0 %.0f cd, L_avg %.3f cd/m², U0 %.3f\n", s.lamps.size(), s.peak_intensity_cd,
               s.avg_luminance_cd_m2, s.uniformity_u0);
  // Pools: along the right lamp row's kerb line (X 1 m inside the edge), the lights layer's road
  // luminance under a lamp against halfway between two lamps of that row follows the E ratio;
  // the road texture (checker 0.9/1.1 of the class mean) bounds the pixel-to-pixel factor.
  ImageF L(o.width, o.height, 3, 0.f, unit::radiance);
  const ImageF tex = reflectance_texture(sc.day_linear_srgb, sc.labels.ids, p);
  add_street_lighting(L, tex, sc.labels.ids, o.camera, s, p);
  const double X = o.road_half_width_m - 1;
  // The nearest right-hand lamp beyond 12 m whose kerb-line point and the gap S/2 beyond it are
  // both in the frame (a near lamp's point on the kerb line can lie right of the image).
  auto in_frame = [&](double D) {
    double u, v;
    return o.camera.project(X, 0, D, &u, &v, nullptr) && std::lround(u) >= 0 && std::lround(u) < o.width &&
           std::lround(v) >= 0 && std::lround(v) < o.height;
  };
  const StreetLamp* lamp = nullptr;
  for (const auto& l : s.lamps)
    if (l.X_m > 0 && l.D_m > 12 && !lamp && in_frame(l.D_m) && in_frame(l.D_m + S / 2)) lamp = &l;
  ASSERT_NE(lamp, nullptr);
  // Luminance at the pixel nearest the ground point, and E at that pixel centre's own ground point.
  auto at = [&](double D) {
    double u, v, Xp, Dp;
    EXPECT_TRUE(o.camera.project(X, 0, D, &u, &v, nullptr));
    const long px = std::lround(u), py = std::lround(v);
    EXPECT_TRUE(px >= 0 && px < o.width && py >= 0 && py < o.height) << "(" << px << ", " << py << ")";
    EXPECT_TRUE(o.camera.ground_point(px, py, &Xp, &Dp, nullptr));
    const size_t i = static_cast<size_t>(py) * o.width + px;
    const float c[3] = {L[3 * i], L[3 * i + 1], L[3 * i + 2]};
    return std::pair{spectrum::luminance_cd_m2(c), street_illuminance_lux(Xp, Dp, s, p)};
  };
  const auto [under, e_under] = at(lamp->D_m);
  const auto [gap, e_gap] = at(lamp->D_m + S / 2);
  EXPECT_GT(e_under / e_gap, 2.0);  // a visible pool: at least twice the gap
  // The image drops, per row, lamps beyond the reach H·tan(min(85°, cut-off + 2·falloff))
  // (street.cpp): their share of each point's E widens the bound.
  auto dropped = [&](double D) {
    StreetLighting far = s;
    far.lamps.clear();
    const double reach = p.lamp_mount_height_m * std::tan(std::min(85.0, p.lamp_cutoff_deg + 2 * p.lamp_falloff_deg) * M_PI / 180);
    for (const auto& l : s.lamps)
      if (std::fabs(D - l.D_m) > reach) far.lamps.push_back(l);
    return street_illuminance_lux(X, D, far, p);
  };
  // And the float pools' rounding at each of the two pixels, (k + n + 2)·2⁻²⁴ relative (the
  // derivation at street.cpp's pool_term: k = 22.5 + 7.5·cot γ_c/φ_f for the quartic pieces, n
  // lamps, and the texture's and tint's products), twice.
  const double k_pool = 22.5 + 7.5 / std::tan(p.lamp_cutoff_deg * M_PI / 180) / (p.lamp_falloff_deg * M_PI / 180);
  const double pool_rel = (k_pool + static_cast<double>(s.lamps.size()) + 2) * 0x1p-24;
  const double slack = dropped(lamp->D_m) / e_under + dropped(lamp->D_m + S / 2) / e_gap + 2 * pool_rel;
  EXPECT_GE(under / gap, e_under / e_gap * 0.9 / 1.1 * (1 - slack));
  EXPECT_LE(under / gap, e_under / e_gap * 1.1 / 0.9 * (1 + slack));
}

namespace {
// The synthetic street without boxes and its planned luminaires (seed 7).
struct OpenStreet {
  SyntheticCameraOptions o;
  SyntheticCameraScene sc;
  ScenePreset p;
  StreetLighting s;
};
OpenStreet open_street() {
  OpenStreet r;
  r.o = camera_scene();
  r.o.boxes.clear();
  r.sc = make_synthetic_camera_scene(r.o);
  r.p = urban();
  r.s = plan_street_lighting(r.sc.labels, r.o.camera, r.p, 7);
  return r;
}
// Every lit pixel of the street lamps' heads (drawn on black) has R:G:B of rg : 1 : bg within the
// relative tolerance tol; returns how many there were.
long expect_head_ratios(const ImageF& heads, double rg, double bg, double tol) {
  long n = 0;
  for (size_t i = 0; i < heads.pixel_count(); ++i) {
    const double r = heads[3 * i], g = heads[3 * i + 1], b = heads[3 * i + 2];
    if (!(g > 0)) continue;
    EXPECT_NEAR(r / g, rg, tol * rg) << "head pixel " << i;
    EXPECT_NEAR(b / g, bg, tol * bg) << "head pixel " << i;
    ++n;
  }
  return n;
}
// A scene for a camera (scene_for_camera) whose street lamps' metamer per cd/m² is w: streetlamp_rgb
// scales it to the luminance asked (one double product per band: 2^-53), the class stays the
// camera-free scene's whatever the colour, and the heads drawn on the open street take w's R:G:B
// (within 2·2^-24 + 2^-50, as HpsHeadsPoolsAndVerticalLightAreCieHp1's (1)).
void expect_heads_take(const OpenStreet& street, const ScenePreset& cs, const std::array<double, 3>& w) {
  const auto& [o, sc, p, s] = street;
  const auto rgb = streetlamp_rgb(cs, 7909.0);
  // One double product per band in streetlamp_rgb and one in the test's 7909·w: 2·2⁻⁵³ = 2⁻⁵².
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(rgb[k], 7909.0 * w[k], 0x1p-52 * 7909.0 * w[k]) << k;
  const StreetLighting s_cs = plan_street_lighting(sc.labels, o.camera, cs, 7);
  EXPECT_EQ(s_cs.peak_intensity_cd, s.peak_intensity_cd);  // the class, whatever the colour
  const ImageF black(o.width, o.height, 3, 0.f);
  ImageF heads(o.width, o.height, 3, 0.f, unit::radiance);
  add_street_lighting(heads, black, sc.labels.ids, o.camera, s_cs, cs);
  EXPECT_GT(expect_head_ratios(heads, w[0] / w[1], w[2] / w[1], 2 * 0x1p-24 + 0x1p-50), 20);
}
// Every lit pixel of a label with a positive texture has the light's tint (per band over the
// texture) in the ratios rg : 1 : bg within tol; returns how many there were.
long expect_tint(const ImageF& L, const ImageF& tex, const ImageU16& labels, Label label, double rg, double bg,
                 double tol, const char* what) {
  long n = 0;
  for (size_t i = 0; i < L.pixel_count(); ++i) {
    if (labels[i] != static_cast<int>(label)) continue;
    const double f[3] = {tex[3 * i], tex[3 * i + 1], tex[3 * i + 2]};
    if (!(L[3 * i + 1] > 0 && f[0] > 0 && f[1] > 0 && f[2] > 0)) continue;
    const double q[3] = {L[3 * i] / f[0], L[3 * i + 1] / f[1], L[3 * i + 2] / f[2]};
    EXPECT_NEAR(q[0] / q[1], rg, tol * rg) << what << " pixel " << i;
    EXPECT_NEAR(q[2] / q[1], bg, tol * bg) << what << " pixel " << i;
    ++n;
  }
  return n;
}
}  // namespace

// add_street_light_rows' side job (light_map's vehicle analysis) runs on one thread while the
// others make the rows outside its band, and the rows inside the band wait for it. On the open
// synthetic street the side job sleeps 200 ms, then marks itself done; each row's `first` records
// whether it was. Every band row must see it done (with the wait removed, the second thread
// reaches them during the sleep), at two threads some row outside the band is made before it is
// (the overlap), and the light equals the pass without a side job, bit for bit.
TEST(StreetLighting, RowPassSideJobOverlapsTheRowsOutsideItsBand) {
  const OpenStreet r = open_street();
  const ImageF tex = reflectance_texture(r.sc.day_linear_srgb, r.sc.labels.ids, r.p);
  const int W = r.o.width, H = r.o.height, b0 = H / 2, b1 = H / 2 + 40;
  ImageF want(W, H, 3, 0.f, unit::radiance);
  add_street_light_rows(want, tex, r.sc.labels.ids, r.sc.depth_m, r.o.camera, r.s, r.p, 1, nullptr);
  double sum = 0;
  for (size_t i = 0; i < want.size(); ++i) sum += want[i];
  EXPECT_GT(sum, 0.0);
  const int before = omp_get_max_threads();
  for (const int threads : {1, 2}) {
    omp_set_num_threads(threads);
    ImageF L(W, H, 3, 0.f, unit::radiance);
    std::atomic<bool> done{false};
    std::vector<int> saw(H, -1);
    const std::function<void()> side = [&] {
      std::this_thread::sleep_for(std::chrono::milliseconds(200));
      done = true;
    };
    const std::function<void(int)> first = [&](int y) { saw[y] = done ? 1 : 0; };
    add_street_light_rows(L, tex, r.sc.labels.ids, r.sc.depth_m, r.o.camera, r.s, r.p, 1, nullptr, nullptr, &first,
                          &side, b0, b1);
    int early = 0;
    for (int y = 0; y < H; ++y) {
      ASSERT_NE(saw[y], -1) << "row " << y << " not made";
      if (y >= b0 && y <= b1) EXPECT_EQ(saw[y], 1) << "band row " << y << " made before the side job returned";
      else early += saw[y] == 0;
    }
    if (threads == 2) EXPECT_GT(early, 0) << "no row made beside the side job";
    EXPECT_EQ(differing_samples(L, want), 0u) << threads << " threads";
  }
  omp_set_num_threads(before);
}

// Each luminaire is drawn only over its footprint, the ground within R = H·tan(γ_R),
// γ_R = min(85°, cut-off + 2·falloff), of its foot along the road (|D − D_l| ≤ R, street.cpp).
// On every road pixel the pools then hold E from exactly the lamps whose band holds the pixel's
// ground point: the image's
// E (recovered from L = t·(tint/π)·E, the green channel: two float products, each within 2⁻²⁴
// relative, and the pixel's X from (x − c_x)·(t/f) against the test's t·((x − c_x)/f), ~1e-15)
// agrees with Σ over those n lamps to (k + n + 2)·2⁻²⁴ relative: the pools are evaluated in
// float32, k = 17.5 + 7.5·cot γ_c/φ_f roundings per term and n for the sum (the derivation at
// street.cpp's pool_term; φ_f the falloff in radians). A dropped lamp lies beyond R, where
// E ≤ E_R = I0·rel(γ_R)·cos³γ_R / H² (rel and cos falling with γ): the truncation at a pixel is
// at most (number of lamps dropped there)·E_R. Pixels within 1e-6·R of a band's edge are skipped
// (the image's and the test's rounding may put them on either side).
TEST(StreetLighting, EachLampOnlyOverItsFootprint) {
  OpenStreet street = open_street();
  street.p.lamp_interp_tolerance = 0;  // the exact per-pixel path (the interpolated one: below)
  const auto& [o, sc, p, s] = street;
  ASSERT_GT(s.lamps.size(), 4u);
  const ImageF tex = reflectance_texture(sc.day_linear_srgb, sc.labels.ids, p);
  ImageF L(o.width, o.height, 3, 0.f, unit::radiance);
  add_street_lighting(L, tex, sc.labels.ids, o.camera, s, p);
  const double gR = std::min(85.0, p.lamp_cutoff_deg + 2 * p.lamp_falloff_deg) * M_PI / 180;
  const double H = p.lamp_mount_height_m, R = H * std::tan(gR);
  const double E_R = s.peak_intensity_cd * lamp_relative_intensity(gR, p) * std::pow(std::cos(gR), 3) / (H * H);
  const double E_avg = M_PI * s.avg_luminance_cd_m2 / p.rho_road;  // the road's average E (EN 13201 field)
  const float tg = static_cast<float>(illuminant_tint(p.street_cct_K)[1] / M_PI);
  double worst_share = 0, worst_bound_share = 0, worst_rel = 0, worst_tol = 0;
  int checked = 0, rim = 0;
  for (int y = 0; y < o.height; ++y)
    for (int x = 0; x < o.width; ++x) {
      double X, D;
      if (sc.labels.ids.at(x, y) != static_cast<int>(Label::Road) || !o.camera.ground_point(x, y, &X, &D, nullptr)) continue;
      const float t = tex.at(x, y, 1);
      if (!(t > 0)) continue;
      StreetLighting in = s, out = s;
      in.lamps.clear();
      out.lamps.clear();
      bool on_rim = false;
      for (const auto& l : s.lamps) {
        const double r = std::fabs(D - l.D_m);
        on_rim = on_rim || std::fabs(r - R) < 1e-6 * R;
        (r <= R ? in : out).lamps.push_back(l);
      }
      if (on_rim) {
        ++rim;
        continue;
      }
      const double e_in = street_illuminance_lux(X, D, in, p), e_out = street_illuminance_lux(X, D, out, p);
      const double e_img = L.at(x, y, 1) / (static_cast<double>(t) * tg);
      const double k_term = 17.5 + 7.5 / std::tan(p.lamp_cutoff_deg * M_PI / 180) / (p.lamp_falloff_deg * M_PI / 180);
      const double tol = (k_term + static_cast<double>(in.lamps.size()) + 2) * std::ldexp(1.0, -24);
      worst_rel = std::max(worst_rel, std::fabs(e_img / e_in - 1));
      worst_tol = std::max(worst_tol, tol);
      // tol: the float evaluation's bound above; the 1e-30 lux is an absolute floor with no physical
      // meaning, below any illuminance a lamp gives here (it only matters where e_in is 0).
      ASSERT_NEAR(e_img, e_in, tol * e_in + 1e-30) << x << "," << y;
      // Beyond the rim by more than 1e-6·R each dropped lamp's E has fallen below E_R by at least
      // d ln E/d ln r·1e-6 (≈ 5.7e-6 at the presets' reach: the falloff's 1/φ_f and cos³'s 3·tan γ
      // over d γ/d ln r = sin γ cos γ), more than the table's 1e-6 from the law (street.cpp): what
      // is left is rounding, E_R's and each term's few double operations (≤ 8 each, 2⁻⁵³) and the
      // sum's: (16 + n)·2⁻⁵³.
      ASSERT_LE(e_out, out.lamps.size() * E_R * (1 + (16 + static_cast<double>(out.lamps.size())) * 0x1p-53))
          << x << "," << y;
      worst_share = std::max(worst_share, e_out / E_avg);
      worst_bound_share = std::max(worst_bound_share, out.lamps.size() * E_R / E_avg);
      ++checked;
    }
  EXPECT_GT(checked, 10000);
  EXPECT_LT(rim, checked / 100);
  std::fprintf(stderr, "[street] footprint R %.1f m, E_R %.4f lx = %.2e of the road average %.2f lx; dropped at most "
               "%.2e of the average (bound %.2e), %d pixels checked, %d on a rim\n",
               R, E_R, E_R / E_avg, E_avg, worst_share, worst_bound_share, checked, rim);
  std::fprintf(stderr, "[street] float32 pools: worst relative error %.2e (bound up to %.2e)\n", worst_rel, worst_tol);
}

// The ground pools at adaptive sample columns (street_lamps.interp_tolerance = tol > 0,
// scene/street.cpp adaptive_span) against the exact per-pixel evaluation (tol = 0, the reference
// and the oracle). The bound: the samples are the exact path's own values (the same kernel on the
// same ground X: the same bits), and between them the quarter chords stay within tol/4·E of the
// exact E where |E''| varies by less than 4x over each tested half, no cut-off knee lying in an
// accepted interval (street.cpp's derivation: within tol·E with that margin). On top of that
// float rounding: the chord fa + (fb − fa)·((x − a)·(1/(b − a)))
// rounds 4 times on values up to max(fa, fb) ≤ (1 + tol)·2·E within an accepted interval (its
// ends within 2x of E: the midpoint test admits no steeper interval at these tolerances, checked
// by the bound itself), 8u, and L = (t·tint)·E in both images 2 products each, 4u more: so every
// pool sample (each channel) of the interpolated image is within (tol + 12·2⁻²⁴)·L_exact of the
// exact image, and a pixel the exact path leaves dark stays dark. The pixels off the ground are
// not touched by the pools: the same bits.
namespace {
struct InterpCheck {
  double worst_rel = 0;
  size_t checked = 0, differ = 0, bad = 0;
};
InterpCheck pools_against_exact(const ImageF& tex, const ImageU16& ids, const CameraGeometry& g, const StreetLighting& s,
                                ScenePreset p, double tol) {
  const int W = ids.width(), H = ids.height();
  ImageF exact(W, H, 3, 0.f, unit::radiance), approx(W, H, 3, 0.f, unit::radiance);
  p.lamp_interp_tolerance = 0;
  add_street_lighting(exact, tex, ids, g, s, p);
  p.lamp_interp_tolerance = tol;
  add_street_lighting(approx, tex, ids, g, s, p);
  const double bound = tol + 12 * std::ldexp(1.0, -24);
  InterpCheck r;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x)
      for (int c = 0; c < 3; ++c) {
        const double e = exact.at(x, y, c), a = approx.at(x, y, c);
        if (!is_ground(ids.at(x, y)) || !(e > 0)) {
          const float ef = exact.at(x, y, c), af = approx.at(x, y, c);
          if (std::memcmp(&ef, &af, sizeof ef) != 0 && ++r.bad <= 5)
            ADD_FAILURE() << "pixel " << x << "," << y << " channel " << c << ": " << a << " where the exact path has " << e;
          continue;
        }
        const double rel = std::fabs(a / e - 1);
        r.worst_rel = std::max(r.worst_rel, rel);
        ++r.checked;
        r.differ += a != e;
        if (rel > bound && ++r.bad <= 5)
          ADD_FAILURE() << "pixel " << x << "," << y << " channel " << c << ": relative error " << rel << " > " << bound
                        << " (tolerance " << tol << ")";
      }
  return r;
}
}  // namespace

// On the synthetic street (open, and with its boxes): every lit ground sample within the bound
// above for three tolerances, some samples interpolated (the path runs), and the EN 13201 L_avg and
// U0 the header reports are the same numbers (they come from the luminaires' double formula on
// the calculation grid, not from the image: the tolerance cannot move them).
TEST(StreetLighting, InterpolatedPoolsStayWithinTheirTolerance) {
  for (const bool boxes : {false, true}) {
    SyntheticCameraOptions o = camera_scene();
    if (!boxes) o.boxes.clear();
    const SyntheticCameraScene sc = make_synthetic_camera_scene(o);
    ScenePreset p = urban();
    p.lamp_interp_tolerance = 0;
    const StreetLighting s0 = plan_street_lighting(sc.labels, o.camera, p, 7);
    const ImageF tex = reflectance_texture(sc.day_linear_srgb, sc.labels.ids, p);
    for (const double tol : {6e-4, 1e-3, 1e-2}) {
      ScenePreset pt = p;
      pt.lamp_interp_tolerance = tol;
      const StreetLighting st = plan_street_lighting(sc.labels, o.camera, pt, 7);
      EXPECT_EQ(st.avg_luminance_cd_m2, s0.avg_luminance_cd_m2);
      EXPECT_EQ(st.uniformity_u0, s0.uniformity_u0);
      EXPECT_EQ(st.peak_intensity_cd, s0.peak_intensity_cd);
      const InterpCheck r = pools_against_exact(tex, sc.labels.ids, o.camera, s0, p, tol);
      EXPECT_EQ(r.bad, 0u) << (boxes ? "boxes" : "open") << ", tolerance " << tol;
      EXPECT_GT(r.checked, 100000u);
      EXPECT_GT(r.differ, r.checked / 2) << "the interpolated path did not run";
      std::fprintf(stderr, "[street] interpolated pools (%s street), tolerance %.0e: worst relative error %.2e over %zu "
                   "samples, %zu differ from the exact path\n", boxes ? "boxed" : "open", tol, r.worst_rel, r.checked,
                   r.differ);
    }
  }
}

// The same on three shared Cityscapes frames (their geometry and luminaires as the chain plans them).
TEST(StreetLighting, InterpolatedPoolsStayWithinTheirToleranceOnCityscapes) {
  PHOTOSITE_REQUIRE_SHARED("data/cityscapes");
  for (const char* base : {"aachen_000000_000019", "aachen_000001_000019", "aachen_000003_000019"}) {
    const auto [lin, lab] = cityscapes_frame(base);
    ScenePreset p = load_scene_preset("night-urban");
    p.lamp_interp_tolerance = 0;
    const NightScene ns = night_scene(lin, lab, p, 1);
    const StreetLighting s = plan_street_lighting(lab, ns.geometry, p, 1);
    ASSERT_FALSE(s.lamps.empty());
    const ImageF tex = reflectance_texture(lin, lab.ids, p);
    for (const double tol : {1e-4, 6e-4, 1e-2}) {
      const InterpCheck r = pools_against_exact(tex, lab.ids, ns.geometry, s, p, tol);
      EXPECT_EQ(r.bad, 0u) << base << ", tolerance " << tol;
      EXPECT_GT(r.differ, r.checked / 2) << "the interpolated path did not run";
      std::fprintf(stderr, "[street] interpolated pools (%s), tolerance %.0e: worst relative error %.2e over %zu "
                   "samples\n", base, tol, r.worst_rel, r.checked);
    }
  }
}

// The sample columns depend on the row and its span only: the street rows (add_street_light_rows,
// pools, vertical light, windows, heads) with a tolerance give the same bits at 1 and 2 threads
// and at every instruction set (AVX-512, AVX2, the scalar twins).
TEST(StreetLighting, InterpolatedPoolsAreTheSameAtEveryThreadCountAndInstructionSet) {
  OpenStreet r = open_street();
  r.p.lamp_interp_tolerance = 1e-3;
  const ImageF tex = reflectance_texture(r.sc.day_linear_srgb, r.sc.labels.ids, r.p);
  const int before = omp_get_max_threads();
  std::vector<ImageF> maps;
  for (const int threads : {1, 2})
    for (const int isa : {2, 1, 0}) {
      omp_set_num_threads(threads);
      street_light_max_isa(isa);
      ImageF L(r.o.width, r.o.height, 3, 0.f, unit::radiance);
      add_street_light_rows(L, tex, r.sc.labels.ids, r.sc.depth_m, r.o.camera, r.s, r.p, 1, nullptr);
      maps.push_back(std::move(L));
    }
  street_light_max_isa(2);
  omp_set_num_threads(before);
  for (size_t k = 1; k < maps.size(); ++k) EXPECT_EQ(differing_samples(maps[k], maps[0]), 0u) << "run " << k;
}

// A degenerate case falls back to exact values: on an image 3 columns wide (the open street's
// luminaires over the same rig's centre columns) every row's span has
// at most 3 columns, all of them samples (an interval of 2 columns has its midpoint evaluated),
// so the interpolated image is the exact one bit for bit.
TEST(StreetLighting, InterpolatedPoolsOnATinyImageAreExact) {
  const OpenStreet street = open_street();  // its luminaires (in metres), planned at 1024 x 512
  const StreetLighting& s = street.s;
  SyntheticCameraOptions o = camera_scene(3, 512);
  o.boxes.clear();
  const SyntheticCameraScene sc = make_synthetic_camera_scene(o);
  ScenePreset p = urban();
  ImageF exact(3, 512, 3, 0.f, unit::radiance), approx(3, 512, 3, 0.f, unit::radiance);
  const ImageF tex = reflectance_texture(sc.day_linear_srgb, sc.labels.ids, p);
  p.lamp_interp_tolerance = 0;
  add_street_lighting(exact, tex, sc.labels.ids, o.camera, s, p);
  p.lamp_interp_tolerance = 1e-2;
  add_street_lighting(approx, tex, sc.labels.ids, o.camera, s, p);
  double sum = 0;
  for (size_t i = 0; i < exact.size(); ++i) sum += exact[i];
  EXPECT_GT(sum, 0.0);
  EXPECT_EQ(differing_samples(approx, exact), 0u);
}

// The pools' knee test: cutoff_columns (each lamp's run of columns within its cone on a row, from
// the knee's X) against beyond_cutoff (the per-sample predicate the first version of the adaptive
// pools evaluated at every sample) at every column, over lamps at many heights, offsets along the
// road (dz from 0 to past the cone's reach: no run at all), feet inside, between and outside the
// columns, row scales k_x from far rows to near ones, cut-off angles, and knees placed on a
// column's X exactly (the rounding boundary). The decisions must agree column by column (so the
// adaptive samples, their signatures and the image are those of the per-sample predicate).
TEST(StreetLighting, PoolKneeColumnsAreThePredicateAtEveryColumn) {
  const double cx = 511.5;
  size_t columns = 0, runs = 0, cut_both = 0, empty = 0, mismatches = 0;
  for (const double gamma_deg : {60.0, 70.0, 72.5, 80.0}) {
    const double cc = std::cos(gamma_deg * M_PI / 180), cc2 = cc * cc;
    for (const double kx : {0.004, 0.0173, 0.05, 0.21})
      for (const double H : {6.0, 8.5, 10.0, 12.0})
        for (int iz = 0; iz < 9; ++iz)
          for (const double foot_col : {-300.0, 0.0, 37.25, 200.5, 511.5, 700.0, 1023.0, 1500.0}) {
            const double tanc2 = 1 / cc2 - 1, reach = H * std::sqrt(tanc2);
            const float H2 = static_cast<float>(H * H);
            const double Xl = (foot_col - cx) * kx;
            // dz over [0, 1.1·reach]; iz 8: the knee on column 600's X exactly (dz² from it).
            float dz2 = static_cast<float>(std::pow(iz * reach * 1.1 / 7, 2));
            if (iz == 8) {
              const double dX = (600 - cx) * kx - Xl;
              dz2 = static_cast<float>(H2 * tanc2 - dX * dX);
              if (dz2 < 0) dz2 = 0;
            }
            for (const auto& [x0, x1] : {std::pair{0, 1023}, std::pair{100, 700}, std::pair{600, 601}}) {
              int lo = 0, hi = 0;
              cutoff_columns(Xl, dz2, H2, cc2, cx, kx, x0, x1, &lo, &hi);
              runs += lo < hi;
              empty += lo == hi;
              cut_both += lo > x0 && hi <= x1;
              for (int x = x0; x <= x1; ++x, ++columns)
                mismatches += beyond_cutoff((x - cx) * kx, Xl, dz2, H2, cc2) != (x < lo || x >= hi);
            }
          }
  }
  EXPECT_EQ(mismatches, 0u) << "of " << columns << " columns";
  EXPECT_GT(cut_both, 100u);  // runs with both knees inside the columns
  EXPECT_GT(empty, 100u);     // lamps beyond their cut-off everywhere
  EXPECT_GT(runs, 1000u);
}

// A lamp head is the luminaire's flat, horizontal face (street.cpp lamp_head_discs), drawn at the
// luminance its own intensity distribution sends toward the camera: L = I0·rel(γ) / (A·cos γ), γ
// the angle from the nadir of the lamp-to-camera direction, A the face (π d²/4), A·cos γ its
// projected area, each pixel at L times the share of its 4×4 sub-pixel samples inside the face's
// ellipse, the ellipse never narrower than 2 px (a thinner axis raised to 2 px, L lowered by the
// area). The ellipse is the face through the projection's Jacobian, here taken by central
// differences of project() (1 mm), not the code's closed form. Checked per head:
// (1) and (3) on heads not raised (both semi-axes ≥ 1 px): every pixel's luminance is L times its
// sample share as this test counts it (pixels with a sample within 1e-6 of the edge, the
// differences' error, not judged), to float rounding: blackbody_rgb's three channels scaled in
// double, stored as float (2^-24 each) and summed back with the luminous efficacies: 4·2^-24;
// the fully covered ones are L itself;
// (2) on every head, the raised ones too: the flux per steradian the drawn pixels send toward the
// lens is the luminaire's I(γ): Σ L·Ω_px = I(γ)/dist², Ω_px = cos³(off-axis)/f² the pixel's solid
// angle. The drawn area is the count of samples inside over 16; for a convex shape K of area A_K
// and perimeter P_K the sample cells (1/4 px squares) whose centre is inside lie within K grown by
// their half-diagonal r = √2/8 px and cover K shrunk by it, so A_K − P_K·r ≤ count/16 ≤ A_K +
// P_K·r + π·r² (Steiner's formula; the inner body's area is at least A_K − P_K·r for a convex K).
// With P_K ≤ 2π·a (a the major semi-axis) that bounds the flux ratio, the other factors being
// rounding (2^-20) and Ω_px's variation over the head (its extent over f, below 1e-3 here).
// (4) every head's drawn pixels reach two rows and two columns at least.
// Heads whose box meets another's or the frame's edge are skipped.
TEST(StreetLighting, LampHeadLuminanceIsItsIntensityTowardTheCamera) {
  const OpenStreet street = open_street();
  const auto& [o, sc, p, planned] = street;
  ASSERT_GT(planned.lamps.size(), 4u);
  // The planned luminaires plus one on the right-hand row at the nearest distance (in 0.5 m steps)
  // at which its head lies in the frame with 4 px to spare: seen the largest, its ellipse at least
  // a pixel across, so the pixels' shares below are checked whatever the layout's phase and
  // spacing put in view (the heads in view are otherwise ≥ 40 m away and may all be narrower).
  StreetLighting s = planned;
  for (double D = 10; D < 80; D += 0.5) {
    double u, v;
    const double X = s.road_right_m + p.lamp_setback_m;
    if (o.camera.project(X, p.lamp_mount_height_m, D, &u, &v, nullptr) && v >= 4 && u + 4 < o.width) {
      s.lamps.push_back({X, p.lamp_mount_height_m, D + 1, false});
      break;
    }
  }
  ASSERT_EQ(s.lamps.size(), planned.lamps.size() + 1);
  std::sort(s.lamps.begin(), s.lamps.end(), [](const auto& a, const auto& b) { return a.D_m < b.D_m; });
  const ImageF black(o.width, o.height, 3, 0.f);
  ImageF L(o.width, o.height, 3, 0.f, unit::radiance);
  add_street_lighting(L, black, sc.labels.ids, o.camera, s, p);
  const CameraGeometry& g = o.camera;
  const double rho = 0.5 * p.lamp_head_diameter_m, area = M_PI * rho * rho;
  struct Head {
    double u, v, a, b, S11, S12, S22, dist, want_flux, want_L;
  };
  std::vector<Head> heads;
  for (const auto& l : s.lamps) {
    double u, v, z;
    if (!g.project(l.X_m, l.Y_m, l.D_m, &u, &v, &z)) continue;
    const double rise = l.Y_m - g.mount_height_m, dist = std::sqrt(l.X_m * l.X_m + l.D_m * l.D_m + rise * rise);
    const double gamma = std::atan2(std::hypot(l.X_m, l.D_m), rise);
    const double I = s.peak_intensity_cd * lamp_relative_intensity(gamma, p);
    constexpr double e = 1e-3;
    double ua, va, ub, vb, uc, vc, ud, vd;
    ASSERT_TRUE(g.project(l.X_m + e, l.Y_m, l.D_m, &ua, &va, nullptr));
    ASSERT_TRUE(g.project(l.X_m - e, l.Y_m, l.D_m, &ub, &vb, nullptr));
    ASSERT_TRUE(g.project(l.X_m, l.Y_m, l.D_m + e, &uc, &vc, nullptr));
    ASSERT_TRUE(g.project(l.X_m, l.Y_m, l.D_m - e, &ud, &vd, nullptr));
    const double j11 = (ua - ub) / (2 * e), j21 = (va - vb) / (2 * e), j12 = (uc - ud) / (2 * e), j22 = (vc - vd) / (2 * e);
    const double S11 = rho * rho * (j11 * j11 + j12 * j12), S12 = rho * rho * (j11 * j21 + j12 * j22),
                 S22 = rho * rho * (j21 * j21 + j22 * j22);
    const double mean = 0.5 * (S11 + S22), dev = std::hypot(0.5 * (S11 - S22), S12);
    heads.push_back({u, v, std::sqrt(mean + dev), std::sqrt(std::max(0.0, mean - dev)), S11, S12, S22, dist,
                     I / (dist * dist), I / (area * rise / dist)});
  }
  int fluxes = 0;
  long shaped = 0, full = 0;
  double lowest = 1e300, highest = 0;
  for (size_t k = 0; k < heads.size(); ++k) {
    const Head& h = heads[k];
    const double hx = std::sqrt(std::max(h.S11, 1.0)) + 2, hy = std::sqrt(std::max(h.S22, 1.0)) + 2;
    const int x0 = static_cast<int>(std::floor(h.u - hx)), x1 = static_cast<int>(std::ceil(h.u + hx));
    const int y0 = static_cast<int>(std::floor(h.v - hy)), y1 = static_cast<int>(std::ceil(h.v + hy));
    if (x0 < 0 || y0 < 0 || x1 >= o.width || y1 >= o.height) continue;
    bool overlapped = false;
    for (size_t m = 0; m < heads.size(); ++m) {
      if (m == k) continue;
      const double mx = std::sqrt(std::max(heads[m].S11, 1.0)) + 2, my = std::sqrt(std::max(heads[m].S22, 1.0)) + 2;
      overlapped |= std::abs(heads[m].u - h.u) <= hx + mx && std::abs(heads[m].v - h.v) <= hy + my;
    }
    if (overlapped) continue;
    const bool raised = h.b < 1;
    double flux = 0;
    int row_lo = y1 + 1, row_hi = y0 - 1, col_lo = x1 + 1, col_hi = x0 - 1;  // the drawn pixels' extent
    const double det = h.S11 * h.S22 - h.S12 * h.S12;
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) {
        const size_t i = static_cast<size_t>(y) * o.width + x;
        const float c[3] = {L[3 * i], L[3 * i + 1], L[3 * i + 2]};
        const double lum = spectrum::luminance_cd_m2(c);
        // The pixel's solid angle: cos³ of its ray's angle off the optical axis over f².
        const double xn = (x - g.cx_px) / g.f_px, yn = (y - g.cy_px) / g.f_px;
        const double cos_off = 1 / std::sqrt(1 + xn * xn + yn * yn);
        flux += lum * cos_off * cos_off * cos_off / (g.f_px * g.f_px);
        if (lum > 0) row_lo = std::min(row_lo, y), row_hi = std::max(row_hi, y), col_lo = std::min(col_lo, x),
                     col_hi = std::max(col_hi, x);
        if (raised) continue;
        // (1), (3): the share of the pixel's 4×4 samples inside Δᵀ·S⁻¹·Δ ≤ 1.
        int in = 0;
        bool edge = false;
        for (int jj = 0; jj < 4; ++jj)
          for (int ii = 0; ii < 4; ++ii) {
            const double dx = x + (ii + 0.5) / 4 - 0.5 - h.u, dy = y + (jj + 0.5) / 4 - 0.5 - h.v;
            const double q = (h.S22 * dx * dx - 2 * h.S12 * dx * dy + h.S11 * dy * dy) / det;
            in += q <= 1;
            edge |= std::abs(q - 1) <= 1e-6;
          }
        if (edge) continue;
        // Coverage in 1/16ths from the 4x4 supersampling, to 4 float roundings of the luminance.
        EXPECT_NEAR(lum, h.want_L * in / 16, 4 * 0x1p-24 * h.want_L)
            << "pixel (" << x << ", " << y << ") of the head at (" << h.u << ", " << h.v << "), " << in << "/16 inside";
        ++shaped;
        full += in == 16;
      }
    // Every head reaches at least two rows and two columns: one cell of the colour filter array.
    EXPECT_GE(row_hi - row_lo, 1) << "head at (" << h.u << ", " << h.v << "), semi-axes " << h.a << ", " << h.b;
    EXPECT_GE(col_hi - col_lo, 1) << "head at (" << h.u << ", " << h.v << "), semi-axes " << h.a << ", " << h.b;
    // The drawn ellipse: raised to 1 px along a narrower semi-axis (its area then π·a'·b').
    const double a = std::max(h.a, 1.0), b = std::max(h.b, 1.0), r = std::sqrt(2.0) / 8;
    const double AK = M_PI * a * b, PK = 2 * M_PI * a;
    const double lo = (AK - PK * r) / AK - 0x1p-20, hi = (AK + PK * r + M_PI * r * r) / AK + 0x1p-20 + 1e-3;
    EXPECT_GE(flux / h.want_flux, lo) << "head at (" << h.u << ", " << h.v << "), semi-axes " << h.a << ", " << h.b;
    EXPECT_LE(flux / h.want_flux, hi) << "head at (" << h.u << ", " << h.v << "), semi-axes " << h.a << ", " << h.b;
    ++fluxes;
    lowest = std::min(lowest, h.want_L);
    highest = std::max(highest, h.want_L);
  }
  EXPECT_GE(fluxes, 3);
  EXPECT_GT(shaped, 100);
  EXPECT_GE(full, 1);
  std::fprintf(stderr,
               "[lamp heads] %zu in view, %d flux-checked (luminance %.0f-%.0f cd/m²), %ld pixels' share checked "
               "(%ld fully covered), I0 %.0f cd\n",
               heads.size(), fluxes, lowest, highest, shaped, full, s.peak_intensity_cd);
}

// Vertical surfaces lit by the same lamps (street.cpp add_vertical_street_light): one lamp of
// known intensity I0 at (X, Y, D) = (0, 8, 14) m in front of a box on the road axis.
namespace {
struct VerticalRig {
  SyntheticCameraOptions o;
  SyntheticCameraScene sc;
  ScenePreset p = urban();
  StreetLighting s;
  ImageF tex, L;
  explicit VerticalRig(double box_D_m, Label box_label = Label::Car) {
    o = camera_scene();
    o.boxes = {{0.0, box_D_m, 2.0, 1.5, 4.5, box_label}};
    sc = make_synthetic_camera_scene(o);
    s.peak_intensity_cd = 5000;
    s.lamps = {{0.0, 8.0, 14.0, false}};
    tex = reflectance_texture(sc.day_linear_srgb, sc.labels.ids, p);
    L = ImageF(o.width, o.height, 3, 0.f, unit::radiance);
  }
  // The pixel's point from its depth, as street.cpp takes it (road coordinates, camera foot at 0).
  std::array<double, 3> point(int x, int y) const {
    const CameraGeometry& g = o.camera;
    const double z = sc.depth_m.at(x, y), yn = (y - g.cy_px) / g.f_px;
    const double c = std::cos(g.pitch_rad), sn = std::sin(g.pitch_rad);
    return {z * (x - g.cx_px) / g.f_px, g.mount_height_m - z * (yn * c + sn), z * (c - yn * sn)};
  }
  // E recovered from the light map's green channel: L = t·float(tint/π)·float(E).
  double E_at(int x, int y) const {
    const float tg = static_cast<float>(illuminant_tint(p.street_cct_K)[1] / M_PI);
    return L.at(x, y, 1) / (static_cast<double>(tex.at(x, y, 1)) * tg);
  }
  // The condition number of n·v at P (street.cpp's vertical_term): (|n_X·v_X| + |n_D·v_D|)/(n·v).
  double kappa(const std::array<double, 3>& P) const {
    const StreetLamp& l = s.lamps[0];
    const double r = std::hypot(P[0], P[2]), nX = -P[0] / r, nD = -P[2] / r;
    const double vX = l.X_m - P[0], vD = l.D_m - P[2];
    return (std::fabs(nX * vX) + std::fabs(nD * vD)) / (nX * vX + nD * vD);
  }
  // I0·rel(γ)·cos β / d² at point P with the camera-facing horizontal normal, and cos γ.
  double E_formula(const std::array<double, 3>& P, double* cos_gamma = nullptr) const {
    const StreetLamp& l = s.lamps[0];
    const double r = std::hypot(P[0], P[2]), nX = -P[0] / r, nD = -P[2] / r;
    const double vX = l.X_m - P[0], vY = l.Y_m - P[1], vD = l.D_m - P[2], d = std::sqrt(vX * vX + vY * vY + vD * vD);
    if (cos_gamma) *cos_gamma = vY / d;
    return s.peak_intensity_cd * lamp_relative_intensity(std::acos(vY / d), p) * std::max(0.0, (nX * vX + nD * vD) / d) / (d * d);
  }
};
}  // namespace

// The box front (camera-facing, the lamp 6 m in front of it and 8 m up: γ 37-53°, inside the
// 65° cut-off, rel = 1) gets E = I0·cos β/d² per pixel. The image's E, recovered from
// L = t·(tint/π)·E: two float products, each within 2⁻²⁴ relative, the test's t·tint and
// division in double exact to 2⁻⁵³ (a product of two floats is exact in double); E evaluated in
// float32 (street.cpp's vertical_term: 16.5 + 3κ roundings inside the cut-off, κ = (|n_X·v_X| +
// |n_D·v_D|)/(n·v) the condition of cos β, plus one for the sum over the n = 1 lamp): within
// (16.5 + 3κ + 1 + 2)·2⁻²⁴ relative per pixel. (The term's quotients cb/d and …/max(d², d²_min)
// were 13.5 + 3κ; their products with r² = 1/d², 3 more: see vertical_term.)
TEST(VerticalStreetLight, BoxFrontGetsIntensityCosOverDistanceSquared) {
  VerticalRig r(20);
  add_vertical_street_light(r.L, r.tex, r.sc.labels.ids, r.sc.depth_m, r.o.camera, r.s, r.p);
  const double cc = std::cos(r.p.lamp_cutoff_deg * M_PI / 180);
  double worst = 0, lo = 1e300, hi = 0, tol_max = 0;
  int n = 0;
  for (int y = 0; y < r.o.height; ++y)
    for (int x = 0; x < r.o.width; ++x) {
      if (!r.sc.box_front.at(x, y)) continue;
      double cg;
      const double e = r.E_formula(r.point(x, y), &cg);
      ASSERT_GT(cg, cc);  // inside the cut-off: the test's formula needs no table
      ASSERT_GT(e, 0);
      const double rel = std::fabs(r.E_at(x, y) / e - 1);
      worst = std::max(worst, rel);
      const double tol = (19.5 + 3 * r.kappa(r.point(x, y))) * std::ldexp(1.0, -24);
      tol_max = std::max(tol_max, tol);
      EXPECT_LE(rel, tol) << x << "," << y;
      lo = std::min(lo, e);
      hi = std::max(hi, e);
      ++n;
    }
  EXPECT_GT(n, 1000);
  std::fprintf(stderr, "[vertical] box front at 20 m, lamp 8 m up at 14 m, I0 %.0f cd: %d pixels, E %.2f..%.2f lx, "
               "worst relative error %.2e (bound up to %.2e)\n", r.s.peak_intensity_cd, n, lo, hi, worst, tol_max);
}

// Tree crowns (street.cpp crown_phase): a vegetation box stands for a crown, lit as a Lambert
// sphere, E = I0·rel(γ)·Φ(α)/d² with Φ(α) = (2/(3π))·(sin α + (π − α)·cos α), α the angle at the
// pixel's point between the directions to the lamp and to the camera (Φ in double here, arccos
// exact). Lamp A beside the crown and 1 m behind its face (α ≈ 96°): a car's camera-facing face
// there is turned away from it and gets nothing, the crown gets about a fifth of I0/d². Lamp B in
// front (the rig's, α ≈ 50°): the crown gets Φ where the face gets cos β. Tolerance, per pixel:
// the float Φ against the exact one, |ΔΦ| ≤ 1.7·10⁻⁷ (crown_phase's polynomial for Q, within
// 7.75·10⁻⁷ of it, times 2/(3π): scripts/crown_phase_fit.py) + 6u (its roundings: Horner's ten on
// values up to 1.1, √(1 − a), s·Q, π·a and the sum, about 23u before the factor 2/(3π), and the
// last product's 1u) + (2/3)·18u (Φ′ = (2/(3π))·(π − α) ≤ 2/3, times cos α's error: n·v's three
// products and two sums with n and v rounded, at most 6u·Σ|n_i·v_i| ≤ 6√3u·d, then cos α =
// ((n·v)·r²)·d: d²'s error halved 3.5u, r² = 1/d² and d = √d² 1u each, the two products 2u),
// u = 2⁻²⁴; then as the face's: d² with v rounded 7u and r²'s 1u, I0·r², ·Φ and rel· 3u, the
// sum 1u and the recovery from L 2u: |E_image/E − 1| ≤ (1.7·10⁻⁷ + 18u)/Φ + 14u, taken as
// (1.7·10⁻⁷ + 32u)/Φ + 16u. (With vertical_term's former quotients (n·v)/d and …/d²: 16u and 13u.)
TEST(VerticalStreetLight, CrownIsLitAsALambertSphereWhereAFaceIsTurnedAway) {
  const double u = std::ldexp(1.0, -24);
  auto phi = [](double c) {
    const double a = std::acos(std::clamp(c, -1.0, 1.0));
    return 2 / (3 * M_PI) * (std::sin(a) + (M_PI - a) * c);
  };
  for (const bool beside : {true, false}) {
    VerticalRig crown(20, Label::Vegetation), car(20, Label::Car);
    for (VerticalRig* r : {&crown, &car}) {
      if (beside) r->s.lamps = {{4.0, 8.0, 21.0, false}};
      add_vertical_street_light(r->L, r->tex, r->sc.labels.ids, r->sc.depth_m, r->o.camera, r->s, r->p);
    }
    const CameraGeometry& g = crown.o.camera;
    const StreetLamp& l = crown.s.lamps[0];
    double worst = 0, lo = 1e300, hi = 0, car_max = 0;
    int n = 0;
    for (int y = 0; y < crown.o.height; ++y)
      for (int x = 0; x < crown.o.width; ++x) {
        if (!crown.sc.box_front.at(x, y)) continue;
        ASSERT_EQ(crown.sc.labels.ids.at(x, y), static_cast<int>(Label::Vegetation));
        const auto P = crown.point(x, y);
        const double vX = l.X_m - P[0], vY = l.Y_m - P[1], vD = l.D_m - P[2];
        const double d = std::sqrt(vX * vX + vY * vY + vD * vD);
        const double cX = -P[0], cY = g.mount_height_m - P[1], cD = -P[2], cn = std::sqrt(cX * cX + cY * cY + cD * cD);
        const double ph = phi((cX * vX + cY * vY + cD * vD) / (cn * d));
        const double e = crown.s.peak_intensity_cd * lamp_relative_intensity(std::acos(vY / d), crown.p) * ph / (d * d);
        ASSERT_GT(e, 0);
        const double rel = std::fabs(crown.E_at(x, y) / e - 1);
        EXPECT_LE(rel, (1.7e-7 + 32 * u) / ph + 16 * u) << x << "," << y << (beside ? " beside" : " in front");
        worst = std::max(worst, rel);
        lo = std::min(lo, crown.E_at(x, y));
        hi = std::max(hi, crown.E_at(x, y));
        if (beside) EXPECT_EQ(car.L.at(x, y, 1), 0.f) << x << "," << y;  // the face turned away
        car_max = std::max(car_max, static_cast<double>(car.L.at(x, y, 1)) > 0 ? car.E_at(x, y) : 0.0);
        ++n;
      }
    EXPECT_GT(n, 1000);
    std::fprintf(stderr, "[vertical] crown at 20 m, lamp %s: %d pixels, E %.2f..%.2f lx (a car's face there: up to "
                 "%.2f lx), worst relative error against the Lambert sphere %.2e\n",
                 beside ? "beside it and 1 m behind its face" : "8 m up 6 m in front", n, lo, hi, car_max, worst);
  }
}

// lamps.streetlamp_type = "hps": every place the street lamps' colour reaches takes CIE HP1's
// band ratios (spectrum::kHp1BandIntegral, scripts/lamp_spectra.py) instead of the LED's Planck
// proxy. On the open synthetic street (luminaires planned, seed 7):
// (1) the lamp heads (a black texture, so the light map holds the heads alone): each head pixel is
//     float(head_k·share), head_k = hp1_k·L in double (the ratios to a few 2^-53), one float
//     rounding per channel: R:G:B within 2·2^-24 (+ 2^-50) relative of HP1's;
// (2) the pools on the road and (3) the light on a box's front (VerticalRig) are f_k·t_k·E per
//     channel, t = float(tint_k/π), tint = HP1 over the 6504 K Planck proxy of D65 (both at
//     luminance 1), E common to the channels: three float roundings per channel (t, f·t, ·E), so
//     the ratios (L_k/f_k)/(L_G/f_G) within 6·2^-24 (+ 2^-50) of tint_k/tint_G.
// And the luminaires' intensity is the class's, whatever their colour: I0 and the field's L_avg
// (photopic, from the geometry) equal the LED street's bit for bit.
TEST(StreetLampType, HpsHeadsPoolsAndVerticalLightAreCieHp1) {
  OpenStreet street = open_street();
  auto& [o, sc, p, s] = street;
  p.lamp_interp_tolerance = 0;  // the exact per-pixel pools
  ScenePreset hps = p;
  hps.streetlamp_type = StreetlampType::Hps;
  const StreetLighting s_hps = plan_street_lighting(sc.labels, o.camera, hps, 7);
  EXPECT_EQ(s_hps.peak_intensity_cd, s.peak_intensity_cd);
  EXPECT_EQ(s_hps.avg_luminance_cd_m2, s.avg_luminance_cd_m2);
  const double* h = spectrum::kHp1BandIntegral;
  const double want_rg = h[0] / h[1], want_bg = h[2] / h[1];
  const ImageF black(o.width, o.height, 3, 0.f);
  ImageF heads(o.width, o.height, 3, 0.f, unit::radiance);
  add_street_lighting(heads, black, sc.labels.ids, o.camera, s_hps, hps);
  const long head_px = expect_head_ratios(heads, want_rg, want_bg, 2 * 0x1p-24 + 0x1p-50);
  EXPECT_GT(head_px, 20);
  const auto a = spectrum::hp1_rgb(1.0), d = spectrum::blackbody_rgb(6504.0, 1.0);
  const double tint_rg = (a[0] / d[0]) / (a[1] / d[1]), tint_bg = (a[2] / d[2]) / (a[1] / d[1]);
  const double tol2 = 6 * 0x1p-24 + 0x1p-50;
  auto check_tint = [&](const ImageF& L, const ImageF& tex, const ImageU16& labels, Label label, const char* what) {
    return expect_tint(L, tex, labels, label, tint_rg, tint_bg, tol2, what);
  };
  const ImageF tex = reflectance_texture(sc.day_linear_srgb, sc.labels.ids, hps);
  ImageF pools(o.width, o.height, 3, 0.f, unit::radiance);
  add_street_lighting(pools, tex, sc.labels.ids, o.camera, s_hps, hps);
  const long pool_px = check_tint(pools, tex, sc.labels.ids, Label::Road, "pool");
  EXPECT_GT(pool_px, 10000);
  VerticalRig r(20);
  r.p.streetlamp_type = StreetlampType::Hps;
  add_vertical_street_light(r.L, r.tex, r.sc.labels.ids, r.sc.depth_m, r.o.camera, r.s, r.p);
  const long box_px = check_tint(r.L, r.tex, r.sc.labels.ids, Label::Car, "box");
  EXPECT_GT(box_px, 100);
  std::fprintf(stderr, "[hps] %ld head, %ld pool, %ld box pixels; head R:G:B 1 : %.6f : %.6f, tint %.6f : 1 : %.6f\n",
               head_px, pool_px, box_px, 1 / want_rg, want_bg / want_rg, tint_rg, tint_bg);
}

// The night chain's scene for its camera (scene_for_camera, what night_scene_for and bench
// realism run): with hps the lamps' colour is that camera's metamer of CIE HP1 (camera_metamer_rgb,
// Spectrum.Hp1CameraMetamerGivesEachCameraTheSpectrumsRawColour), which streetlamp_rgb scales to the
// luminance asked (one double product per band: 2^-53) and the heads on the open street take (their
// R:G:B within 2·2^-24 + 2^-50 of the metamer's, as HpsHeadsPoolsAndVerticalLightAreCieHp1's (1));
// with led there is no HP1 metamer (and with hps no LED-B one), and a scene made without a camera
// has none.
TEST(StreetLampType, TheChainsSceneTakesItsCamerasMetamerOfHp1) {
  OpenStreet street = open_street();
  auto& [o, sc, p, s] = street;
  const CameraPreset cam = load_camera_preset("onsemi-ar0331");
  EXPECT_EQ(scene_for_camera(p, cam).lamp_camera_rgb[0], (std::array<double, 3>{0, 0, 0}));  // led: no HP1
  ScenePreset hps = p;
  hps.streetlamp_type = StreetlampType::Hps;
  const ScenePreset hc = scene_for_camera(hps, cam);
  const auto w = camera_metamer_rgb(cam, spectrum::kHp1Spd5nm, 81);
  ASSERT_EQ(hc.lamp_camera_rgb[0], w);
  for (const auto ls : {spectrum::LampSpectrum::LedBHeads, spectrum::LampSpectrum::LedBStreet})
    EXPECT_EQ(hc.lamp_camera_rgb[static_cast<int>(ls)], (std::array<double, 3>{0, 0, 0}));  // hps: no LED-B
  for (int i = 1; i <= static_cast<int>(spectrum::LampSpectrum::GreenLed); ++i) {  // the signals' and rear lamps' LEDs
    const auto wi = camera_metamer_rgb(cam, static_cast<spectrum::LampSpectrum>(i));
    EXPECT_GT(wi[0] + wi[1] + wi[2], 0) << i;
    EXPECT_EQ(hc.lamp_camera_rgb[i], wi) << i;
    EXPECT_EQ(scene_for_camera(p, cam).lamp_camera_rgb[i], wi) << i;
    EXPECT_EQ(p.lamp_camera_rgb[i], (std::array<double, 3>{0, 0, 0})) << i;  // a scene made without a camera
  }
  ASSERT_GT(w[1], 0);
  expect_heads_take(street, hc, w);
}

// The night chain's scene for its camera with led street lamps (the presets' type): the heads take
// the camera's metamer of CIE LED-B at lamps.streetlamp_cct_K, the light on the street (pools,
// vertical light) the one at street.cct_K, each the metamer of that CIE table where the CCT is a
// table's (camera_metamer_rgb of kLedBSpd5nm[t] through the 5-nm table overload: the same
// quadrature of the same spectrum up to its scale, which the metamer divides out, a few hundred
// double terms and a 3x3 solve of condition < 10³: 10⁻⁹ relative, as
// Spectrum.LedBCameraMetamerGivesEachCameraTheSpectrumsRawColour). The heads' R:G:B within
// 2·2^-24 + 2^-50 of the metamer's and the pools' and a box's tint within 6·2^-24 + 2^-50 of
// LED-B's over D65's Planck proxy (HpsHeadsPoolsAndVerticalLightAreCieHp1's bounds, the same float
// steps). Two different CCTs give two metamers; a scene made without a camera keeps the Planck
// proxy, bit for bit. On the old code (Planck at both CCTs with a camera too) the heads' G/R on the
// AR0331 is the proxy's, 11 % off LED-B3's metamer.
TEST(StreetLampType, TheChainsSceneTakesItsCamerasMetamerOfLedB) {
  OpenStreet street = open_street();
  auto& [o, sc, p, s] = street;
  p.lamp_interp_tolerance = 0;  // the exact per-pixel pools
  ASSERT_EQ(p.streetlamp_type, StreetlampType::Led);
  ASSERT_EQ(p.streetlamp_cct_K, 4000);  // the bundled presets' (LED-B3's CCT)
  ASSERT_EQ(p.street_cct_K, 4000);
  const CameraPreset cam = load_camera_preset("onsemi-ar0331");
  constexpr int kHeads = static_cast<int>(spectrum::LampSpectrum::LedBHeads);
  constexpr int kStreet = static_cast<int>(spectrum::LampSpectrum::LedBStreet);
  auto expect_metamer = [&](const std::array<double, 3>& got, int table, const char* what) {
    const auto want = camera_metamer_rgb(cam, spectrum::kLedBSpd5nm[table], 81);
    // 1e-9 relative: the bound sensor_test.cpp derives for camera_metamer_rgb (10³ double terms a
    // side, a 3x3 solve of condition below 10³).
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(got[k], want[k], 1e-9 * want[k]) << what << " LED-B" << table + 1 << " box " << k;
  };
  const ScenePreset lc = scene_for_camera(p, cam);
  expect_metamer(lc.lamp_camera_rgb[kHeads], 2, "heads");
  expect_metamer(lc.lamp_camera_rgb[kStreet], 2, "street");
  EXPECT_EQ(lc.lamp_camera_rgb[0], (std::array<double, 3>{0, 0, 0}));  // led: no HP1
  const auto w = lc.lamp_camera_rgb[kHeads];
  ASSERT_GT(w[0], 0);
  ASSERT_GT(w[1], 0);
  ASSERT_GT(w[2], 0);
  expect_heads_take(street, lc, w);
  const StreetLighting s_led = plan_street_lighting(sc.labels, o.camera, lc, 7);
  const auto ws = lc.lamp_camera_rgb[kStreet];
  const auto d = spectrum::blackbody_rgb(6504.0, 1.0);
  const double tint_rg = (ws[0] / d[0]) / (ws[1] / d[1]), tint_bg = (ws[2] / d[2]) / (ws[1] / d[1]);
  auto check_tint = [&](const ImageF& L, const ImageF& tex, const ImageU16& labels, Label label, const char* what) {
    return expect_tint(L, tex, labels, label, tint_rg, tint_bg, 6 * 0x1p-24 + 0x1p-50, what);
  };
  const ImageF tex = reflectance_texture(sc.day_linear_srgb, sc.labels.ids, lc);
  ImageF pools(o.width, o.height, 3, 0.f, unit::radiance);
  add_street_lighting(pools, tex, sc.labels.ids, o.camera, s_led, lc);
  EXPECT_GT(check_tint(pools, tex, sc.labels.ids, Label::Road, "pool"), 10000);
  VerticalRig r(20);
  r.p = scene_for_camera(r.p, cam);
  ASSERT_EQ(r.p.street_cct_K, 4000);
  add_vertical_street_light(r.L, r.tex, r.sc.labels.ids, r.sc.depth_m, r.o.camera, r.s, r.p);
  EXPECT_GT(check_tint(r.L, r.tex, r.sc.labels.ids, Label::Car, "box"), 100);
  // The Planck proxy's raw G/R on this camera against the metamer's (what the change is for).
  const PhotonMatrix M = photon_matrix(cam, load_lens_preset(cam.default_lens),
                                       resolve(cam, load_lens_preset(cam.default_lens), ExposureSettings()));
  auto raw_gr = [&](const std::array<double, 3>& x) {
    return (M[1][0] * x[0] + M[1][1] * x[1] + M[1][2] * x[2]) / (M[0][0] * x[0] + M[0][1] * x[1] + M[0][2] * x[2]);
  };
  const double gr_proxy = raw_gr(spectrum::blackbody_rgb(4000, 1.0)), gr_led = raw_gr(w);
  std::fprintf(stderr, "[led-b] AR0331 raw G/R of the heads: LED-B3 metamer %.4f, Planck 4000 K proxy %.4f\n", gr_led,
               gr_proxy);
  EXPECT_GT(gr_led, 1.05 * gr_proxy);
  // Two CCTs, two metamers: heads at LED-B2's 3000 K, the street at LED-B4's 5000 K.
  ScenePreset q = p;
  q.streetlamp_cct_K = 3000;
  q.street_cct_K = 5000;
  const ScenePreset qc = scene_for_camera(q, cam);
  expect_metamer(qc.lamp_camera_rgb[kHeads], 1, "heads");
  expect_metamer(qc.lamp_camera_rgb[kStreet], 3, "street");
  const auto wq = qc.lamp_camera_rgb[kStreet];
  const auto tq = streetlamp_tint(qc);
  // The code's quotient and the test's, one double rounding each: 2⁻⁵² relative.
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(tq[k], wq[k] / d[k], 0x1p-52 * wq[k] / d[k]) << k;
  // Without a camera: the Planck proxy at both CCTs, the same bits as before.
  for (const ScenePreset* x : {&p, &q}) {
    EXPECT_EQ(x->lamp_camera_rgb[kHeads], (std::array<double, 3>{0, 0, 0}));
    EXPECT_EQ(streetlamp_rgb(*x, 7909.0), spectrum::blackbody_rgb(x->streetlamp_cct_K, 7909.0));
    EXPECT_EQ(streetlamp_tint(*x), illuminant_tint(x->street_cct_K));
  }
}

// A box beyond every lamp's reach (its front at 50 m, the lamp's footprint ends at
// 14 + 8·tan(75°) = 43.9 m) gets no lamp light, although the unbounded formula gives it some
// (γ ≈ 79°, rel ≈ 6%): the ground pools' footprint rule holds for vertical surfaces too.
TEST(VerticalStreetLight, NothingBeyondEveryLampsReach) {
  VerticalRig r(50);
  add_vertical_street_light(r.L, r.tex, r.sc.labels.ids, r.sc.depth_m, r.o.camera, r.s, r.p);
  const double reach = r.s.lamps[0].Y_m * std::tan(std::min(85.0, r.p.lamp_cutoff_deg + 2 * r.p.lamp_falloff_deg) * M_PI / 180);
  int n = 0, lit_inside = 0;
  for (int y = 0; y < r.o.height; ++y)
    for (int x = 0; x < r.o.width; ++x) {
      const int id = r.sc.labels.ids.at(x, y);
      if (id != static_cast<int>(Label::Car) && id != static_cast<int>(Label::Building)) continue;
      const auto P = r.point(x, y);
      // |v_D| and the reach are compared in float (street.cpp's vertical_term): each rounded
      // within 2⁻²⁴, the double difference within 2⁻⁵³, so pixels within 3·2⁻²⁴·reach of the
      // rim may fall either side.
      if (std::fabs(P[2] - r.s.lamps[0].D_m) > reach * (1 + 3 * std::ldexp(1.0, -24))) {
        if (id == static_cast<int>(Label::Car)) EXPECT_GT(r.E_formula(P), 0);
        EXPECT_EQ(r.L.at(x, y, 0), 0.f);
        EXPECT_EQ(r.L.at(x, y, 1), 0.f);
        EXPECT_EQ(r.L.at(x, y, 2), 0.f);
        n += id == static_cast<int>(Label::Car);
      } else if (std::fabs(P[2] - r.s.lamps[0].D_m) < reach * (1 - 3 * std::ldexp(1.0, -24))) {
        lit_inside += r.L.at(x, y, 1) > 0;
      }
    }
  EXPECT_GT(n, 100);
  EXPECT_GT(lit_inside, 100);  // façade pixels within reach facing the lamp are lit
}

// Pool continuity: at the box's foot the road (horizontal, add_street_lighting) and the box's
// lowest pixel (vertical, add_vertical_street_light) see the same lamp at the same d and γ, so
// E_v/E_h = cos β/cos γ = (n·v)/H at the foot point F = (X_b, 0, D_b) below the box pixel's
// point P_b. The two pixels' points are not F: ln E_h = const − 3 ln d has gradient 3/d, and on
// the vertical segment P_b–F only d changes (n·v is constant: n horizontal), so
//   |ln(measured / (n·v)/H)| ≤ 3|P_r − F|/d_min + 3|P_b − F|/d_min + (16.5 + 19.5 + 3κ)·2⁻²⁴
// (mean value theorem, d_min = |v_F| − the longer offset; the two recovered E's each within
// (k + 1 + 2)·2⁻²⁴ of their float32 evaluation, k = 13.5 on the road and 16.5 + 3κ on the box
// inside the cut-off, κ the condition of n·v: street.cpp's pool_term and vertical_term).
// The same at two box distances: the light on the face follows the lamp's distance.
TEST(VerticalStreetLight, PoolIsContinuousAtTheBoxFoot) {
  for (double D_box : {17.0, 22.0}) {
    VerticalRig r(D_box);
    add_street_lighting(r.L, r.tex, r.sc.labels.ids, r.o.camera, r.s, r.p);
    add_vertical_street_light(r.L, r.tex, r.sc.labels.ids, r.sc.depth_m, r.o.camera, r.s, r.p);
    const int x = static_cast<int>(std::lround(r.o.camera.cx_px));
    int yb = -1;
    for (int y = 0; y < r.o.height; ++y)
      if (r.sc.box_front.at(x, y)) yb = y;
    ASSERT_GE(yb, 0);
    ASSERT_EQ(r.sc.labels.ids.at(x, yb + 1), static_cast<int>(Label::Road));
    const auto Pb = r.point(x, yb);
    double Xr, Dr;
    ASSERT_TRUE(r.o.camera.ground_point(x, yb + 1, &Xr, &Dr, nullptr));
    const StreetLamp& l = r.s.lamps[0];
    const std::array<double, 3> F = {Pb[0], 0.0, Pb[2]};
    const double rr = std::hypot(F[0], F[2]), nv = (-F[0] * (l.X_m - F[0]) - F[2] * (l.D_m - F[2])) / rr;
    const double dF = std::sqrt(std::pow(l.X_m - F[0], 2) + l.Y_m * l.Y_m + std::pow(l.D_m - F[2], 2));
    const double off_r = std::hypot(Xr - F[0], Dr - F[2]), off_b = std::fabs(Pb[1]);
    const double dmin = dF - std::max(off_r, off_b);
    const double bound = 3 * off_r / dmin + 3 * off_b / dmin + (36 + 3 * r.kappa(Pb)) * std::ldexp(1.0, -24);
    const double Ev = r.E_at(x, yb), Eh = r.E_at(x, yb + 1), expect = nv / l.Y_m;
    ASSERT_GT(Eh, 0);
    EXPECT_LE(std::fabs(std::log(Ev / Eh / expect)), bound);
    // Both the road and the box inside the cut-off (rel = 1), so the ratio is geometry alone.
    EXPECT_GT(l.Y_m / dF, std::cos(r.p.lamp_cutoff_deg * M_PI / 180) + 0.05);
    std::fprintf(stderr, "[vertical] box at %.0f m: road E_h %.2f lx, box foot E_v %.2f lx, ratio %.4f, cos β/cos γ at "
                 "the foot %.4f, |ln| %.4f (bound %.4f)\n", D_box, Eh, Ev, Ev / Eh, expect,
                 std::fabs(std::log(Ev / Eh / expect)), bound);
  }
}

// The vertical light's vector rows (AVX-512: groups of sixteen columns; AVX2: eight) build each
// group's lanes in registers (street.cpp, vertical_group): inside one façade plane by broadcast,
// elsewhere lane by lane (a candidate's column or the group's fill column, its depth, its façade
// plane by region and column, the lit normal gathered and negated, +0.0 without a plane). Pinned to
// its definition, the scalar twin's per-pixel loop (the candidates compacted, plane_at inlined,
// vertical_e_scalar), bit for bit, on the synthetic street: façades on both sides (groups at their
// edges and between a façade and the sky or the road), cars and a hedge (camera-facing normals),
// with lamps 40 m apart at the kerbs and 1 m apart at the kerbs and over the road (a group's window
// of some 280 lamps; far lamps beyond the cut-off, whose rel(γ) the vector rows take from the
// table's interleaved (entry, step) pairs). It failed with the gathered normal's sign left
// unflipped, with the pairs' steps read as their entries, and with the AVX-512 row's quads of
// four lanes skipped when only their fourth lane is a candidate.
TEST(VerticalStreetLight, VectorRowsBuildTheScalarLanes) {
  SyntheticCameraOptions o = camera_scene();
  o.boxes.push_back({5.5, 26, 6.0, 1.2, 1.0, Label::Vegetation});  // a hedge at the right kerb
  const SyntheticCameraScene sc = make_synthetic_camera_scene(o);
  const ScenePreset p = urban();
  const ImageF tex = reflectance_texture(sc.day_linear_srgb, sc.labels.ids, p);
  for (const double spacing_m : {40.0, 1.0}) {
    StreetLighting s;
    s.peak_intensity_cd = 5000;
    // Lamps sorted by D (as plan_street_lighting gives them), at both kerbs and over the road.
    for (double D = 4; D < 120; D += spacing_m)
      for (const double X : {-8.0, 8.0, -2.0, 2.0}) {
        if (spacing_m > 10 && std::fabs(X) < 5) continue;
        s.lamps.push_back({X, std::fabs(X) < 5 ? 9.0 : 8.0, D, false});
      }
    std::vector<ImageF> L;
    for (const int isa : {2, 1, 0}) {
      street_light_max_isa(isa);
      L.emplace_back(o.width, o.height, 3, 0.f, unit::radiance);
      add_vertical_street_light(L.back(), tex, sc.labels.ids, sc.depth_m, o.camera, s, p);
    }
    street_light_max_isa(2);
    size_t lit = 0;
    for (size_t i = 0; i < L[2].size(); ++i) lit += L[2][i] > 0;
    EXPECT_GT(lit, 30000u) << spacing_m << " m";  // façades and boxes lit
    EXPECT_EQ(differing_samples(L[0], L[2]), 0u) << "AVX-512 against the scalar twin, lamps " << spacing_m << " m apart";
    EXPECT_EQ(differing_samples(L[1], L[2]), 0u) << "AVX2 against the scalar twin, lamps " << spacing_m << " m apart";
  }
}

namespace {
// The light map split by kind, to say where unmatched energy lies (1 channel: R+G+B radiance).
// Built from the same public stages light_map() calls, on the same street-lighting plan and
// façades: street lamp heads (add_street_lighting on a black texture), ground pools (the same
// with the texture, the heads' pixels removed), light on vertical surfaces, windows (shops dark:
// shop_luminance_factor 0), shop panes (all façade lights less the windows), and what light_map()
// adds besides, split by the label under it (signs, signals, vehicle lamps; "other" should be 0).
// light_map composes heads and windows as a maximum over what lies there, so the rest is
// clamped at 0 and the kinds sum to the light map only up to those overlaps.
constexpr int kKinds = 9;
const char* const kKindName[kKinds] = {"lamp heads", "ground pools", "vertical street light", "windows",
                                       "shop panes", "signs", "signals", "vehicle lamps", "other"};
std::vector<ImageF> light_kinds(const ImageF& full, const ImageF& tex, const LabelMap& lm, const CameraGeometry& g,
                                const ImageF& depth, const StreetLighting& sl, const ScenePreset& p, uint64_t seed) {
  const int W = full.width(), H = full.height();
  const BuildingFacades fac = building_facades(lm.ids, g, p.max_depth_m);
  auto blank = [&] { return ImageF(W, H, 3, 0.f, unit::radiance); };
  ImageF heads = blank(), pools = blank(), vert = blank(), win = blank(), all_win = blank();
  const ImageF black(W, H, 3, 0.f, tex.unit());
  add_street_lighting(heads, black, lm.ids, g, sl, p);
  add_street_lighting(pools, tex, lm.ids, g, sl, p);
  add_vertical_street_light(vert, tex, lm.ids, depth, g, sl, p, &fac);
  ScenePreset no_shops = p;
  no_shops.shop_luminance_factor = 0;
  add_facade_windows(win, lm.ids, depth, g, no_shops, seed, &fac);
  add_facade_windows(all_win, lm.ids, depth, g, p, seed, &fac);
  std::vector<ImageF> k(kKinds, ImageF(W, H, 1, 0.f));
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      double v[5] = {0, 0, 0, 0, 0}, f = 0;
      for (int c = 0; c < 3; ++c) {
        v[0] += heads.at(x, y, c);
        v[1] += heads.at(x, y, c) > 0 ? 0 : pools.at(x, y, c);
        v[2] += vert.at(x, y, c);
        v[3] += win.at(x, y, c);
        v[4] += all_win.at(x, y, c) - win.at(x, y, c);
        f += full.at(x, y, c);
      }
      double rest = f;
      for (int q = 0; q < 5; ++q) {
        k[q].at(x, y) = static_cast<float>(v[q]);
        rest -= v[q];
      }
      if (rest <= 1e-6 * f) continue;
      const int id = lm.ids.at(x, y);
      const int q = id == static_cast<int>(Label::TrafficSign) ? 5 : id == static_cast<int>(Label::TrafficLight) ? 6
                    : is_vehicle(id) ? 7 : 8;
      k[q].at(x, y) = static_cast<float>(rest);
    }
  return k;
}

// Share of the light energy of frame t at x + k found again at x in frame t+1 (to 1%), away from
// the lateral borders, over crops of one frame (day image `lin`, labels `lab`) k px apart, each
// with its own principal point (the crop offset moves the image plane: c_x − offset). The light
// map is built on the rig's horizon: the lamps, pools and windows are what is tested, not the
// vanishing point (whose jitter from crop to crop is printed). Per kind (light_kinds) it prints
// each kind's energy, the share of it that matches on its own, and its part of the unmatched
// energy of the whole light map (each unmatched pixel's energy shared out by the kinds' parts).
// `sequence`: the crops as one sequence (SequenceState: the reflectance texture's class means and
// the street luminaires carried from frame to frame, every crop at pose 0 — a crop moves the
// principal point, not the camera); else each crop alone.
std::vector<double> panning_shares(const ImageF& lin, const LabelMap& lab, const CameraRig& base, int k, int frames,
                                   const char* name, bool sequence) {
  const int CW = lin.width() - k * (frames - 1), CH = lin.height();
  ScenePreset p = urban();
  SequenceState st;
  std::vector<ImageF> lights;
  std::vector<std::vector<ImageF>> kinds;
  for (int t = 0; t < frames; ++t) {
    const int off = k * t;
    ImageF day(CW, CH, 3, 0.f, lin.unit());
    LabelMap lm;
    lm.ids = ImageU16(CW, CH, 1, 0, unit::label_id);
    lm.instances = ImageU16(CW, CH, 1, 0, "instance id");
    for (int y = 0; y < CH; ++y)
      for (int x = 0; x < CW; ++x) {
        for (int c = 0; c < 3; ++c) day.at(x, y, c) = lin.at(x + off, y, c);
        lm.ids.at(x, y) = lab.ids.at(x + off, y);
        if (!lab.instances.empty()) lm.instances.at(x, y) = lab.instances.at(x + off, y);
      }
    p.rig = base;
    p.rig.native_width_px = CW;
    p.rig.native_height_px = CH;
    p.rig.cx_px = base.cx_px - off;
    const NightScene n = night_scene(day, lm, p, 5);
    const CameraGeometry g = camera_geometry(p.rig, CW, CH, VanishingPoint{});
    const ImageF depth = metric_depth(lm, g, p.max_depth_m);
    const ImageF tex = reflectance_texture(day, lm.ids, p, sequence ? &st.reflectance : nullptr);
    const StreetLighting plan = plan_street_lighting(lm, g, p, 5);
    const StreetLighting sl = sequence ? st.luminaires.update(plan, g, CW, CH, CameraPose{}, p, 5) : plan;
    const double vx = g.cx_px, vy = g.horizon_y;  // the ramp (sign retroreflection) from the same horizon
    LightMap m = light_map(day, tex, lm, ImageU8(CW, CH, 1, 0), coarse_depth(CW, CH, vx, vy),
                           VanishingPoint{vx, vy, 0, VpMethod::ImageCentre, 0, ""}, p, 5, &g, &depth, nullptr, nullptr,
                           &sl);
    kinds.push_back(light_kinds(m.radiance, tex, lm, g, depth, sl, p, 5));
    lights.push_back(std::move(m.radiance));
    std::fprintf(stderr, "[panning %s] frame %d: chain's VP horizon %.2f (%s); rig horizon %.2f: %d street lamps (%s), "
                 "%d windows, %d vehicle lamps; road edges %.2f / %.2f m\n", name, t, n.geometry.horizon_y,
                 n.geometry.horizon_source.c_str(), g.horizon_y, m.stats.street_lamps,
                 m.stats.street_lamp_source.c_str(), m.stats.windows, m.stats.vehicle_lamps, sl.road_left_m,
                 sl.road_right_m);
    for (const auto& l : sl.lamps)
      if (l.from_pole) std::fprintf(stderr, "    pole lamp X %.2f Y %.2f D %.2f m\n", l.X_m, l.Y_m, l.D_m);
  }
  const int margin = CW / 20;
  std::vector<double> shares;
  for (int t = 0; t + 1 < frames; ++t) {
    double total = 0, matched = 0;
    double kin[kKinds] = {}, kin_matched[kKinds] = {}, kin_unmatched[kKinds] = {};
    for (int y = 0; y < CH; ++y)
      for (int x = margin; x < CW - margin - k; ++x) {
        double a = 0, b = 0;  // content at x + k in frame t is at x in frame t+1
        for (int c = 0; c < 3; ++c) {
          a += lights[t].at(x + k, y, c);
          b += lights[t + 1].at(x, y, c);
        }
        total += a;
        const bool match = std::fabs(a - b) <= 0.01 * std::max(a, b) + 1e-12;
        if (match) matched += a;
        double parts = 0;
        for (int q = 0; q < kKinds; ++q) {
          const double ka = kinds[t][q].at(x + k, y), kb = kinds[t + 1][q].at(x, y);
          kin[q] += ka;
          parts += ka;
          if (std::fabs(ka - kb) <= 0.01 * std::max(ka, kb) + 1e-12) kin_matched[q] += ka;
        }
        if (!match && parts > 0)
          for (int q = 0; q < kKinds; ++q) kin_unmatched[q] += a * kinds[t][q].at(x + k, y) / parts;
      }
    shares.push_back(total > 0 ? matched / total : 0);
    std::fprintf(stderr, "[panning %s%s] frames %d->%d: %.2f%% of the light energy matches\n", name,
                 sequence ? ", as a sequence" : ", frame by frame", t, t + 1, 100 * shares.back());
    std::fprintf(stderr, "  %-22s %9s %10s %12s\n", "kind", "energy %", "self-match", "unmatched %");
    for (int q = 0; q < kKinds; ++q)
      if (kin[q] > 0)
        std::fprintf(stderr, "  %-22s %8.2f%% %9.2f%% %11.3f%%\n", kKindName[q], 100 * kin[q] / total,
                     100 * kin_matched[q] / kin[q], 100 * kin_unmatched[q] / total);
  }
  return shares;
}
// The same share for the whole chain (night_scene: its own vanishing point, lane markings lit by
// the low beam), over the crops as one sequence (`sequence`: SequenceState, the first crop's
// pitch, class means and luminaires carried on) or each crop alone.
std::vector<double> chain_shares(const ImageF& lin, const LabelMap& lab, const CameraRig& base, int k, int frames,
                                 const char* name, bool sequence) {
  const int CW = lin.width() - k * (frames - 1), CH = lin.height();
  ScenePreset p = urban();
  SequenceState st;
  std::vector<ImageF> lights;
  for (int t = 0; t < frames; ++t) {
    const int off = k * t;
    ImageF day(CW, CH, 3, 0.f, lin.unit());
    LabelMap lm;
    lm.ids = ImageU16(CW, CH, 1, 0, unit::label_id);
    lm.instances = ImageU16(CW, CH, 1, 0, "instance id");
    for (int y = 0; y < CH; ++y)
      for (int x = 0; x < CW; ++x) {
        for (int c = 0; c < 3; ++c) day.at(x, y, c) = lin.at(x + off, y, c);
        lm.ids.at(x, y) = lab.ids.at(x + off, y);
        if (!lab.instances.empty()) lm.instances.at(x, y) = lab.instances.at(x + off, y);
      }
    p.rig = base;
    p.rig.native_width_px = CW;
    p.rig.native_height_px = CH;
    p.rig.cx_px = base.cx_px - off;
    NightScene n = night_scene(day, lm, p, 5, false, sequence ? &st : nullptr);
    std::fprintf(stderr, "[chain %s] frame %d: VP y %.2f, horizon %.2f (%s)\n", name, t, n.vp.y, n.geometry.horizon_y,
                 n.geometry.horizon_source.c_str());
    lights.push_back(std::move(n.lights));
  }
  const int margin = CW / 20;
  std::vector<double> shares;
  for (int t = 0; t + 1 < frames; ++t) {
    double total = 0, matched = 0;
    for (int y = 0; y < CH; ++y)
      for (int x = margin; x < CW - margin - k; ++x) {
        double a = 0, b = 0;
        for (int c = 0; c < 3; ++c) {
          a += lights[t].at(x + k, y, c);
          b += lights[t + 1].at(x, y, c);
        }
        total += a;
        if (std::fabs(a - b) <= 0.01 * std::max(a, b) + 1e-12) matched += a;
      }
    shares.push_back(total > 0 ? matched / total : 0);
    std::fprintf(stderr, "[chain %s, %s] frames %d->%d: %.2f%% of the light energy matches\n", name,
                 sequence ? "as a sequence" : "frame by frame", t, t + 1, 100 * shares.back());
  }
  return shares;
}
}  // namespace

// Lights stay put when the camera moves (issue 14 §3): the lights layer of frame t+1 equals frame
// t shifted by k for at least 95% of the light energy away from the borders. The 95% is the
// issue's requirement, not an estimate: "The `lights` layer of frame t+1 must equal frame t
// shifted by k px for at least 95% of the light energy away from the borders." A pixel matches when
// the two agree to 1% (float sums in another order differ by ~1e-6; a lamp disc edge moving by
// half a pixel is a mismatch). On the scene rendered from a known camera (road-edge luminaires,
// façade windows, vehicles), where nothing enters or leaves the view that the lights depend on:
// frame by frame and as a sequence. (On a real frame a labelled pole leaving the view takes its
// luminaire with it frame by frame: the next test.)
// Which way a vehicle faces, and the border rule, on the scene rendered from a known camera. Box 0
// (X = −3.5 m, D = 12 m) stands left of the road's centre line: by the side rule it is oncoming,
// with white head lamps. Red lamp-like blobs in its day pixels (a tail lamp's lens) say it shows
// its rear: then tail lamps, red, wherever it stands. And a vehicle whose box meets the labels'
// frame of no image content (Cityscapes' "out of roi" columns) is cut by the border: parked, dark.
TEST(MetricLights, RedLampsInTheDayPhotoMeanTailLampsAndTheLabelBorderCutsAVehicle) {
  const SyntheticCameraOptions o = camera_scene();
  const SyntheticCameraScene s = make_synthetic_camera_scene(o);
  ScenePreset p = urban();
  p.rig = load_camera_rig("cityscapes");
  struct Seen { double lum = 0, r_over_g = 0; int in_traffic = 0; };
  auto brightest_on_box0 = [&](const ImageF& day, const LabelMap& lm) {
    const NightScene n = night_scene(day, lm, p, 1);
    Seen r;
    r.in_traffic = n.light_stats.vehicles_in_traffic;
    for (int y = 0; y < o.height; ++y)
      for (int x = 0; x < o.width; ++x) {
        if (lm.instances.at(x, y) != 26000) continue;
        float c[3] = {n.lights.at(x, y, 0), n.lights.at(x, y, 1), n.lights.at(x, y, 2)};
        const double L = spectrum::luminance_cd_m2(c);
        if (L > r.lum) {
          r.lum = L;
          r.r_over_g = c[1] > 0 ? c[0] / c[1] : 1e9;
        }
      }
    return r;
  };
  const Seen plain = brightest_on_box0(s.day_linear_srgb, s.labels);
  ASSERT_GT(plain.lum, 1000.0);     // a head lamp (350 cd over a 0.18 m disc: about 13,750 cd/m²)
  EXPECT_LT(plain.r_over_g, 3.0);  // white: a 3200 K blackbody's R/G in the box basis is about 1.5
  // A red lens, 12 x 8 px, on box 0's front face (0.4 % of its pixels; a red body would be > 20 %).
  int x0 = o.width, y0 = o.height, x1 = -1, y1 = -1, n0 = 0;
  for (int y = 0; y < o.height; ++y)
    for (int x = 0; x < o.width; ++x)
      if (s.labels.instances.at(x, y) == 26000) {
        x0 = std::min(x0, x); x1 = std::max(x1, x); y0 = std::min(y0, y); y1 = std::max(y1, y); ++n0;
      }
  ASSERT_GT(n0, 5000);
  ImageF red_day = s.day_linear_srgb;
  const int bx = x0 + (x1 - x0) / 5, by = y0 + 6 * (y1 - y0) / 10;
  for (int y = by; y < by + 8; ++y)
    for (int x = bx; x < bx + 12; ++x) {
      ASSERT_EQ(s.labels.instances.at(x, y), 26000);
      red_day.at(x, y, 0) = 0.8f; red_day.at(x, y, 1) = 0.02f; red_day.at(x, y, 2) = 0.02f;
    }
  const Seen rear = brightest_on_box0(red_day, s.labels);
  EXPECT_EQ(rear.in_traffic, plain.in_traffic);
  EXPECT_GT(rear.r_over_g, 10.0);  // red: tail lamps and the lens itself
  EXPECT_LT(rear.lum, 0.2 * plain.lum);  // no head lamp left
  // A column of the labels' border frame beside the box: cut, so parked (dark unless its seeded
  // share lit it).
  LabelMap framed = s.labels;
  for (int y = 0; y < o.height; ++y) framed.ids.at(x0 - 1, y) = static_cast<uint16_t>(Label::OutOfRoi);
  const Seen cut = brightest_on_box0(s.day_linear_srgb, framed);
  EXPECT_EQ(cut.in_traffic, plain.in_traffic - 1);
  EXPECT_LT(cut.lum, 0.2 * plain.lum);
}

// Right-hand traffic: the ego car drives right of the centre line, so on a straight road a vehicle
// in the ego lane (|X| < lane_width_m / 2 = 1.625 m) travels its way and shows its rear (tail
// lamps), even left of the carriageway's middle (X = 0: the synthetic road is ±7 m); aachen_000001's
// two cars ahead were drawn with head lamps by the middle alone. Where the left kerb does not run
// straight (a side road's mouth 40-60 m ahead, the kerb 5 m farther out there) the lane cannot be
// read and the middle decides again.
TEST(MetricLights, AVehicleInTheEgoLaneShowsItsRearOnAStraightRoad) {
  SyntheticCameraOptions o = camera_scene();
  o.boxes = {{-1.3, 20, 1.6, 1.5, 4.5}, {-4.0, 14, 1.8, 1.5, 4.5}};
  const SyntheticCameraScene s = make_synthetic_camera_scene(o);
  ScenePreset p = urban();
  p.rig = load_camera_rig("cityscapes");
  ASSERT_DOUBLE_EQ(p.veh_lane_width_m, 3.25);
  // The lamps' colour on an instance: R/G of its brightest light (a 3200 K head lamp about 1.5,
  // a red tail lamp over 10).
  auto lamp_r_over_g = [&](const SyntheticCameraScene& s, const LabelMap& lm, int instance) {
    const NightScene n = night_scene(s.day_linear_srgb, lm, p, 1);
    double best = 0, rg = 0;
    for (int y = 0; y < o.height; ++y)
      for (int x = 0; x < o.width; ++x) {
        if (lm.instances.at(x, y) != instance) continue;
        float c[3] = {n.lights.at(x, y, 0), n.lights.at(x, y, 1), n.lights.at(x, y, 2)};
        const double L = spectrum::luminance_cd_m2(c);
        if (L > best) {
          best = L;
          rg = c[1] > 0 ? c[0] / c[1] : 1e9;
        }
      }
    EXPECT_GT(best, 0.0) << "instance " << instance << " has no lamp";
    return rg;
  };
  EXPECT_TRUE(plan_street_lighting(s.labels, o.camera, p, 1).road_straight);
  EXPECT_GT(lamp_r_over_g(s, s.labels, 26000), 10.0);  // ego lane: tail lamps
  EXPECT_LT(lamp_r_over_g(s, s.labels, 26001), 3.0);   // X = -4 m, the other lane: head lamps
  // A lit stop lamp saturates to white in a day photo: a near-white blob (12 x 8 px) in the lower
  // half of the vehicle going away is a rear lamp, drawn in the tail colour (it was drawn as a head
  // lamp, the brightest light on that car).
  {
    SyntheticCameraScene lit = s;
    int x0 = o.width, y0 = o.height, x1 = -1, y1 = -1;
    for (int y = 0; y < o.height; ++y)
      for (int x = 0; x < o.width; ++x)
        if (s.labels.instances.at(x, y) == 26000) {
          x0 = std::min(x0, x); x1 = std::max(x1, x); y0 = std::min(y0, y); y1 = std::max(y1, y);
        }
    const int bx = x0 + (x1 - x0) / 5, by = y0 + 6 * (y1 - y0) / 10;
    for (int y = by; y < by + 8; ++y)
      for (int x = bx; x < bx + 12; ++x) {
        ASSERT_EQ(s.labels.instances.at(x, y), 26000);
        for (int k = 0; k < 3; ++k) lit.day_linear_srgb.at(x, y, k) = 0.95f;
      }
    EXPECT_GT(lamp_r_over_g(lit, lit.labels, 26000), 10.0);
  }
  // The side road's mouth: the sidewalk 7..12 m left of the camera, 40..60 m ahead, becomes road
  // (in the scene without the second vehicle, which would hide that kerb; each pixel's ground
  // point where make_synthetic_camera_scene samples it, at (x, y)).
  o.boxes.resize(1);
  const SyntheticCameraScene s1 = make_synthetic_camera_scene(o);
  EXPECT_GT(lamp_r_over_g(s1, s1.labels, 26000), 10.0);
  LabelMap mouth = s1.labels;
  int widened = 0;
  for (int y = 0; y < o.height; ++y)
    for (int x = 0; x < o.width; ++x) {
      double X, D;
      if (mouth.ids.at(x, y) == static_cast<uint16_t>(Label::Road) || is_vehicle(mouth.ids.at(x, y))) continue;
      if (!o.camera.ground_point(x, y, &X, &D, nullptr) || D < 40 || D > 60 || X < -12 || X > -7) continue;
      mouth.ids.at(x, y) = static_cast<uint16_t>(Label::Road);
      ++widened;
    }
  ASSERT_GT(widened, 100);
  EXPECT_FALSE(plan_street_lighting(mouth, o.camera, p, 1).road_straight);
  EXPECT_LT(lamp_r_over_g(s1, mouth, 26000), 3.0);  // X = -1 m, left of the middle: head lamps
}

TEST(MetricLights, PanningCropsKeepLightsInTheWorld) {
  SyntheticCameraOptions o = camera_scene(1088, 512);
  o.camera = camera_geometry(load_camera_rig("cityscapes"), 1024, 512, VanishingPoint{});
  o.camera.cx_px += 32;  // the 1088-px frame holds 1024-px crops 0, 32, 64 px in
  const SyntheticCameraScene s = make_synthetic_camera_scene(o);
  CameraRig rig = load_camera_rig("cityscapes");
  rig.fx_px = o.camera.f_px;
  rig.cx_px = o.camera.cx_px;
  rig.cy_px = o.camera.cy_px;
  rig.pitch_deg = o.camera.pitch_rad * 180 / M_PI;
  for (bool sequence : {false, true})
    for (double share : panning_shares(s.day_linear_srgb, s.labels, rig, 32, 3, "synthetic", sequence))
      EXPECT_GE(share, 0.95);
  for (double share : chain_shares(s.day_linear_srgb, s.labels, rig, 32, 3, "synthetic", true)) EXPECT_GE(share, 0.95);
}

// The same measurement on a real Cityscapes frame (aachen_000000_000019), the crops as a sequence
// (SequenceState): a pole that leaves the view keeps its luminaire while its light reaches the
// view, and the reflectance texture keeps the class means of the first crop (the mean over the
// visible part of a class moves with the view). Frame by frame (each crop alone, reported, not
// asserted) the luminaire of the pole that leaves and the per-frame class means cost the first
// pair its 95%; docs/night.md has the table by kind. As a sequence the 95% is issue 14 §3's
// requirement (quoted above PanningCropsKeepLightsInTheWorld), asserted as it stands.
TEST(MetricLights, PanningCropsOfACityscapesFrameReported) {
  PHOTOSITE_REQUIRE_SHARED("data/cityscapes");
  const auto frame = cityscapes_frame("aachen_000000_000019");
  const ImageF& lin = frame.first;
  const LabelMap& lab = frame.second;
  const CameraRig rig = load_camera_rig("cityscapes");
  for (double share : panning_shares(lin, lab, rig, 32, 3, "aachen_000000", false)) {
    EXPECT_GT(share, 0.0);
    EXPECT_LE(share, 1.0);
  }
  for (double share : panning_shares(lin, lab, rig, 32, 3, "aachen_000000", true)) EXPECT_GE(share, 0.95);
  // The whole chain as `batch --sequence` runs it (its first crop's VP horizon kept), and alone.
  for (double share : chain_shares(lin, lab, rig, 32, 3, "aachen_000000", true)) EXPECT_GE(share, 0.95);
  for (double share : chain_shares(lin, lab, rig, 32, 3, "aachen_000000", false)) EXPECT_LE(share, 1.0);
}

// LuminaireSet (scene/luminaires.cpp): a pole luminaire seen once stays where it is in the world
// as the camera moves (its frame coordinates follow the pose exactly), the road-edge layout stays
// on its world positions, a re-detection from nearer moves it and one from farther does not, and
// a luminaire whose light no longer reaches the view is forgotten. Two sets fed the same frames
// give the same lamps.
// At a pose the line ahead was decided at, a sequence keeps that decision (LuminaireSet::update):
// two views of one street from one place (crops of a view, a camera at rest) can fit a bend
// differently by more than their standard errors, and the luminaires ahead moved with each fit
// (crops of aachen_000000 32 px apart measured heading −0.025 and −0.253 rad). Two plans of one
// pose whose road ahead curves, measured differently (κ 0.010 from 20 m at heading 0; κ 0.012 from
// 15 m at heading 0.02 rad), each with kerb errors of 1 cm, far from the straight line's
// extrapolation: fed one after the other at pose 0 the second frame's lamps are the first's, bit
// for bit; a set given the second alone places them elsewhere (each fit is taken, where it is the
// first at its pose); and 2 m further along the road the frame's plan decides anew.
TEST(Luminaires, TheLineAheadDecidedAtAPoseIsKeptThere) {
  const ScenePreset p = urban();
  VanishingPoint none;
  const CameraGeometry g = camera_geometry(load_camera_rig("cityscapes"), 1024, 512, none);
  auto plan = [](double kappa, double start, double heading) {
    StreetLighting s;
    s.road_left_m = -7;
    s.road_right_m = 7;
    s.peak_intensity_cd = 1000;
    RoadAhead& r = s.road_ahead;
    r.state = "curved";
    r.curved = true;
    r.kappa_per_m = kappa;
    r.curve_start_m = start;
    r.heading_rad = heading;
    r.left_m = -7;
    r.right_m = 7;
    r.reach_m = 60;
    r.covariance[0] = r.covariance[5] = 1e-4;  // 1 cm on each kerb
    r.covariance[10] = 1e-8;                    // 1e-4 rad of heading
    r.covariance[15] = 1e-12;                   // 1e-6 1/m of curvature
    return s;
  };
  const StreetLighting A = plan(0.010, 20, 0), B = plan(0.012, 15, 0.02);
  auto same = [](const StreetLighting& a, const StreetLighting& b) {
    if (a.lamps.size() != b.lamps.size()) return false;
    for (size_t i = 0; i < a.lamps.size(); ++i)
      if (a.lamps[i].X_m != b.lamps[i].X_m || a.lamps[i].D_m != b.lamps[i].D_m) return false;
    return true;
  };
  LuminaireSet set, fresh;
  const StreetLighting a0 = set.update(A, g, 1024, 512, CameraPose{}, p, 7);
  ASSERT_GT(a0.lamps.size(), 4u);
  const StreetLighting b0 = set.update(B, g, 1024, 512, CameraPose{}, p, 7);
  EXPECT_TRUE(same(a0, b0)) << "the second view of the same place moved the luminaires ahead";
  const StreetLighting b_alone = fresh.update(B, g, 1024, 512, CameraPose{}, p, 7);
  EXPECT_FALSE(same(a0, b_alone)) << "premise: the two fits place the luminaires differently";
  // Two metres on, the frame's own fit decides again: after A and B at pose 0 (A kept), B at the
  // new pose gives the lamps of a set that saw A at pose 0 and B there (the same path, anchored by
  // A), and not those of one that saw A at both poses (premise: the fits differ there too).
  const CameraPose on{0, 2, 0};
  LuminaireSet y, z;
  (void)y.update(A, g, 1024, 512, CameraPose{}, p, 7);
  (void)z.update(A, g, 1024, 512, CameraPose{}, p, 7);
  const StreetLighting b2 = set.update(B, g, 1024, 512, on, p, 7), y2 = y.update(B, g, 1024, 512, on, p, 7),
                       z2 = z.update(A, g, 1024, 512, on, p, 7);
  EXPECT_TRUE(same(b2, y2)) << "at a new pose the line ahead is the frame's own measurement";
  EXPECT_FALSE(same(y2, z2)) << "premise: the two fits place the luminaires differently from there";
}

TEST(Luminaires, PolesStayInTheWorldAsTheCameraMoves) {
  const ScenePreset p = urban();
  VanishingPoint none;
  const CameraGeometry g = camera_geometry(load_camera_rig("cityscapes"), 1024, 512, none);
  const double S = p.lamp_spacing_ratio * p.lamp_mount_height_m, phase = street_layout_phase_m(p, 7);
  auto plan = [&](std::vector<StreetLamp> poles) {
    StreetLighting s;
    s.road_left_m = -5;
    s.road_right_m = 5;
    s.peak_intensity_cd = 1000;
    s.lamps = std::move(poles);
    return s;
  };
  auto pole_in = [](const StreetLighting& s) {
    std::vector<StreetLamp> v;
    for (const auto& l : s.lamps)
      if (l.from_pole) v.push_back(l);
    return v;
  };
  LuminaireSet set, twin;
  auto step = [&](const StreetLighting& pl, const CameraPose& pose) {
    const StreetLighting a = set.update(pl, g, 1024, 512, pose, p, 7), b = twin.update(pl, g, 1024, 512, pose, p, 7);
    EXPECT_EQ(a.lamps.size(), b.lamps.size());
    for (size_t i = 0; i < std::min(a.lamps.size(), b.lamps.size()); ++i) {
      EXPECT_EQ(a.lamps[i].X_m, b.lamps[i].X_m);
      EXPECT_EQ(a.lamps[i].D_m, b.lamps[i].D_m);
    }
    return a;
  };
  // Frame 0: a pole 6 m left, 20 m ahead (seen from 20.9 m).
  StreetLighting s = step(plan({{-6, 8, 20, true}}), CameraPose{});
  ASSERT_EQ(pole_in(s).size(), 1u);
  EXPECT_EQ(pole_in(s)[0].D_m, 20);
  // The layout's right row at D = phase + k·S (pose 0: the frame is the world).
  for (const auto& l : s.lamps)
    // D = phase + k·S rounds k·S and the sum (2⁻⁵³ of |k·S| ≤ |D| + S and of |D|), the difference
    // here once more (remainder is exact): within 4·2⁻⁵³·(|D| + S).
    if (!l.from_pole && l.X_m > 0) EXPECT_NEAR(std::remainder(l.D_m - phase, S), 0, 4 * 0x1p-53 * (std::fabs(l.D_m) + S)) << l.D_m;
  // Frame 1: 5 m further along, no pole detected (hidden): the luminaire stays, 15 m ahead.
  s = step(plan({}), CameraPose{0, 5, 0});
  ASSERT_EQ(pole_in(s).size(), 1u);
  // Exact: at yaw 0 the pose maps are shifts (luminaires.cpp), and 20 − 5, −6 + 0 are exact.
  EXPECT_EQ(pole_in(s)[0].D_m, 15);
  EXPECT_EQ(pole_in(s)[0].X_m, -6);
  // As above, with the shift to the world and back (two more roundings of |D| + 5) and the + 5.
  for (const auto& l : s.lamps)  // the layout did not move in the world
    if (!l.from_pole && l.X_m > 0)
      EXPECT_NEAR(std::remainder(l.D_m + 5 - phase, S), 0, 8 * 0x1p-53 * (std::fabs(l.D_m) + 5 + S)) << l.D_m;
  // Frame 2: re-detected 0.4 m off from farther away (camera back at 0): kept where it was.
  s = step(plan({{-6.4, 8, 20, true}}), CameraPose{0, 0, 0});
  ASSERT_EQ(pole_in(s).size(), 1u);
  EXPECT_EQ(pole_in(s)[0].X_m, -6);  // exact, as frame 1
  // Frame 3: re-detected 0.4 m off from nearer (camera 10 m on): moved there.
  s = step(plan({{-6.4, 8, 10, true}}), CameraPose{0, 10, 0});
  ASSERT_EQ(set.poles().size(), 1u);
  EXPECT_EQ(set.poles()[0].X_m, -6.4);  // exact: −6.4·1 + 10·0 and 10 + 10·1 at yaw 0
  EXPECT_EQ(set.poles()[0].D_m, 20);
  // Turned by 10° to the right: the same world point in the frame's rotated road coordinates.
  const double yaw = 10 * M_PI / 180;
  s = step(plan({}), CameraPose{0, 10, yaw});
  ASSERT_EQ(pole_in(s).size(), 1u);
  // Exact: luminaires.cpp's to_frame computes these same expressions (dx = −6.4 − 0, dd = 20 − 10
  // exact) with the same cos and sin of the same yaw.
  EXPECT_EQ(pole_in(s)[0].X_m, -6.4 * std::cos(yaw) - 10 * std::sin(yaw));
  EXPECT_EQ(pole_in(s)[0].D_m, -6.4 * std::sin(yaw) + 10 * std::cos(yaw));
  // Driven past: 20 m + the pole's reach behind the camera, its light cannot reach the view.
  const double reach = street_lamp_reach_m(8, p);
  s = step(plan({}), CameraPose{0, 20 + reach + 1, 0});
  EXPECT_TRUE(pole_in(s).empty());
  EXPECT_TRUE(set.poles().empty());
}

namespace {
// A frame's point (x across, d ahead) in the world, the frame at pose q (luminaires.cpp's Pose2).
void frame_to_world(const CameraPose& q, double x, double d, double* X, double* D) {
  const double c = std::cos(q.yaw_rad), s = std::sin(q.yaw_rad);
  *X = q.X_m + x * c + d * s;
  *D = q.D_m - x * s + d * c;
}
// The labels of a road seen from pose q with camera g (W x H): each ground pixel's point in the
// world, road where its offset across the road's centre line (offset(X, D), + right) lies between
// the kerbs, sidewalk elsewhere; sky above the horizon.
LabelMap road_labels(const CameraGeometry& g, int W, int H, const CameraPose& q,
                     const std::function<double(double, double)>& offset, double left, double right) {
  LabelMap lm;
  lm.ids = ImageU16(W, H, 1, static_cast<uint16_t>(Label::Sky), unit::label_id);
  lm.instances = ImageU16(W, H, 1, 0, "instance id");
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      double X, D, Xw, Dw;
      if (!g.ground_point(x, y, &X, &D, nullptr)) continue;
      frame_to_world(q, X, D, &Xw, &Dw);
      const double o = offset(Xw, Dw);
      lm.ids.at(x, y) = static_cast<uint16_t>(o >= left && o <= right ? Label::Road : Label::Sidewalk);
    }
  return lm;
}
}  // namespace

// A drive straight along +D, then round a circle of radius R entered Dc ahead, turning toward +X
// (sigma 1) or −X (−1), in the world of the sequence's first frame.
struct CircleDrive {
  double R, Dc, sigma;
  bool on_circle(double X, double D) const { return D > Dc || sigma * X > R; }
  // A world point's offset across the camera's path (+ right).
  double offset(double X, double D) const {
    return on_circle(X, D) ? sigma * (R - std::hypot(X - sigma * R, D - Dc)) : X;
  }
  CameraPose pose_at(double s) const {  // the camera after s metres
    if (s <= Dc) return CameraPose{0, s, 0};
    const double th = (s - Dc) / R;
    return CameraPose{sigma * (R - R * std::cos(th)), Dc + R * std::sin(th), sigma * th};
  }
};

// The road-edge layout follows a curving road (issue 14 §3, lights stay put). A road straight for
// 60 m, then turning on a circle of 100 m radius (the camera's path; a photosite choice within the
// 60-150 m of city streets' curves) through a quarter turn, to the right and to the left. The
// camera drives in its right lane (kerbs 5.25 m left and 3.5 m right of it, quarter metres, so that
// the plan's medians give them exactly) 9 m a frame (18 m/s, 0.5 s: the KITTI-layout tests'),
// its poses on that path with their headings along it. Each frame's plan is plan_street_lighting
// of the frame's labels (road between the kerbs, sidewalk outside, sky above the horizon), seen
// from its pose. Asserted:
//  * every road-edge luminaire within the view lies on its row's curve (its offset from the
//    camera's path the kerb's plus the setback) where the path's last step has the curvature of the
//    road under the luminaire (a straight step and a luminaire on the straight, a step on the
//    circle and one on the circle): there the extrapolation is the road;
//  * a luminaire in two consecutive frames that lies behind the earlier frame's camera (on the
//    path driven) is at the same world point, and so is every one in the earlier frame's view
//    while both steps lie on the circle;
//  * the path kept stays bounded.
// Reported: how far the luminaires ahead lie off their curve and move between frames where the
// extrapolation changes (entering the curve). Main's straight world rows put the luminaires on the
// circle metres off it.
TEST(Luminaires, RoadEdgeLayoutFollowsACurvingRoad) {
  const ScenePreset p = urban();
  const int W = 1024, H = 512;
  const CameraGeometry g = camera_geometry(load_camera_rig("cityscapes"), W, H, VanishingPoint{});
  const double R = 100, Dc = 60, left = -5.25, right = 3.5, step = 9, S = p.lamp_spacing_ratio * p.lamp_mount_height_m;
  const uint64_t seed = 7;
  const double ul = (-0.5 - g.cx_px) / g.f_px, ur = (W - 0.5 - g.cx_px) / g.f_px;
  // Rounding: a luminaire's world point is a few dozen roundings (2⁻⁵³ relative) of magnitudes
  // below 500 m (poses, R, the layout's 150 m reach), ≤ 64·2⁻⁵³·500 m = 3.6e-12 m, and an arc's
  // centre and angle carry the rounding of the turn between two poses' yaws (≤ 2·2⁻⁵³·π/2 against
  // a turn of step/R = 0.09 rad: 4e-15 relative) over ≤ 250 m: 1e-12 m. 1e-9 m bounds both.
  const double tol = 1e-9;
  // On its kerb's curve: the road line follows the step that enters the circle (part straight,
  // part on it) as one arc of its turn, whose end lies beside the true path's by at most h²/(2R)
  // (both end between the straight and the full circle's h²/(2R) off the tangent), 0.41 m at
  // h = 9 m; the steps after it continue the circle from there.
  const double tol_curve = step * step / (2 * R) + tol;
  for (const double sigma : {1.0, -1.0}) {  // turning right (+X, yaw growing), then left
    const CircleDrive c{R, Dc, sigma};
    auto on_circle = [&](double X, double D) { return c.on_circle(X, D); };
    auto offset = [&](double X, double D) { return c.offset(X, D); };
    auto pose_at = [&](double s) { return c.pose_at(s); };
    const auto to_world = frame_to_world;
    auto labels_at = [&](const CameraPose& q) { return road_labels(g, W, H, q, offset, left, right); };
    LuminaireSet set;
    std::vector<std::vector<std::array<double, 2>>> seen;  // each frame's road-edge luminaires in the world
    std::vector<CameraPose> poses;
    double worst_ahead = 0, worst_move = 0, worst_checked = 0;
    int checked = 0, kept = 0;
    std::string entering;  // per frame: the farthest off its curve of the luminaires in view not asserted
    for (int f = 0; step * f <= Dc + R * M_PI / 2; ++f) {
      const CameraPose q = pose_at(step * f);
      const StreetLighting plan = plan_street_lighting(labels_at(q), g, p, seed);
      if (f == 0) {  // the kerbs as measured: exact (a pixel is ≤ 0.05 m at 60 m, the medians are in quarter metres)
        ASSERT_EQ(plan.road_left_m, left);
        ASSERT_EQ(plan.road_right_m, right);
      }
      const StreetLighting s = set.update(plan, g, W, H, q, p, seed);
      // The last step's kind: straight (both poses on the straight), on the circle, or across.
      const bool last_straight = step * f <= Dc, last_circle = f > 0 && step * (f - 1) >= Dc;
      std::vector<std::array<double, 2>> w;
      double frame_worst = 0;  // the farthest off its curve of this frame's luminaires in view not asserted
      for (const auto& l : s.lamps) {
        if (l.from_pole) continue;
        double X, D;
        to_world(q, l.X_m, l.D_m, &X, &D);
        w.push_back({X, D});
        if (!(l.D_m > 0 && l.X_m >= ul * l.D_m && l.X_m <= ur * l.D_m)) continue;  // not in view
        const double o = offset(X, D), err = std::min(std::fabs(o - (right + p.lamp_setback_m)), std::fabs(o - (left - p.lamp_setback_m)));
        if ((last_straight && !on_circle(X, D)) || (last_circle && on_circle(X, D))) {
          EXPECT_LE(err, last_straight ? tol : tol_curve) << "frame " << f << ": luminaire at frame (" << l.X_m << ", " << l.D_m << ") off its kerb's curve";
          ++checked;
          worst_checked = std::max(worst_checked, err);
        } else {
          worst_ahead = std::max(worst_ahead, err);
          frame_worst = std::max(frame_worst, err);
        }
      }
      if (f > 0) {
        const CameraPose& b = poses.back();
        const bool steady = last_circle && step * (f - 2) >= Dc;
        for (const auto& a : seen.back()) {
          // The nearest of this frame's luminaires; within a quarter spacing it is the same one.
          double best = INFINITY;
          for (const auto& c : w) best = std::min(best, std::hypot(c[0] - a[0], c[1] - a[1]));
          if (best > 0.25 * S) continue;
          const double dx = a[0] - b.X_m, dd = a[1] - b.D_m;
          // Behind frame f − 1's camera, or ahead in its view (x/d between the borders' slopes).
          const double x = dx * std::cos(b.yaw_rad) - dd * std::sin(b.yaw_rad), d = dx * std::sin(b.yaw_rad) + dd * std::cos(b.yaw_rad);
          const bool behind = d < 0, in_view = d > 0 && x >= ul * d && x <= ur * d;
          if (behind || (steady && in_view)) {
            EXPECT_LE(best, tol) << "frame " << f << ": a luminaire " << (behind ? "on the path driven" : "ahead on the circle") << " moved";
            ++kept;
          } else if (in_view) {
            worst_move = std::max(worst_move, best);
          }
        }
      }
      if (frame_worst > 0) entering += fmt::format(" {}: {:.2f} m", f, frame_worst);
      seen.push_back(w);
      poses.push_back(q);
      // The path kept: the pieces from three spacings behind the camera, one per step of 9 m at most (and the one it grows).
      EXPECT_LE(set.path_pieces(), static_cast<size_t>(std::ceil(3 * S / step)) + 2);
    }
    EXPECT_GT(checked, 20);
    EXPECT_GT(kept, 50);
    std::fprintf(stderr, "[curving road] turning %s on R = %g m over %zu frames: %d luminaires in view checked on their kerb's curve (up to %.3g m off), "
                 "%d seen again at the same place; where the extrapolation changes (entering the curve): luminaires in view up to %.3f m "
                 "off their curve (by frame:%s), those matched within a quarter spacing moving up to %.3f m between frames; "
                 "path pieces kept %zu\n",
                 sigma > 0 ? "right" : "left", R, poses.size(), checked, worst_checked, kept, worst_ahead, entering.c_str(), worst_move,
                 set.path_pieces());
  }
}

// Round a bend (RoadEdgeLayoutFollowsACurvingRoad's circle of 100 m radius entered 60 m ahead,
// 9 m steps), each frame's road ahead says how far behind the camera the vehicle has been
// turning its way (RoadAhead::turning_behind_m) where the frame's bend starts at the camera: the
// line driven on the circle, between the arc length driven on it and one step more (the step that
// enters the circle turns as one arc over its whole length), up to the line kept (three spacings
// behind the camera, and the pieces back to the first that starts before that: at most one step
// more). A single frame knows none (0). And a sign standing beside the circle keeps its facing in
// the world from frame to frame while the camera, within its reading distance, turns by 0.09 rad a
// step: printed with the camera's turn, and asserted within 5 of the fits' standard errors of the
// heading at the reading point (the frame's heading and curvature errors, propagated over the
// arc length from the camera to it: σψ² + s²·σκ² + 2·s·cov, s the reading point's signed arc
// length; the world's true heading there the circle's).
TEST(Luminaires, SequenceSignsKeepTheirFacingRoundABend) {
  const ScenePreset p = urban();
  const int W = 1024, H = 512;
  const CameraGeometry g = camera_geometry(load_camera_rig("cityscapes"), W, H, VanishingPoint{});
  const double R = 100, Dc = 60, left = -5.25, right = 3.5, step = 9, S = p.lamp_spacing_ratio * p.lamp_mount_height_m;
  const double sigma = -1;  // turning left
  const CircleDrive c{R, Dc, sigma};
  auto offset = [&](double X, double D) { return c.offset(X, D); };
  auto pose_at = [&](double s) { return c.pose_at(s); };
  // A sign on the circle's right edge (the outside of a left bend), 130 m along the path: its
  // reading point 60 m before it, at path length 70 m, on the circle; the road's heading there
  // sigma·(70 − 60)/R in the world.
  const double s_sign = 130, th_sign = (s_sign - Dc) / R, edge = R + right + 1;
  const double sX = sigma * (R - edge * std::cos(th_sign)), sD = Dc + edge * std::sin(th_sign);
  const double truth = sigma * (s_sign - p.sign_read_distance_m - Dc) / R;
  LuminaireSet set;
  int measured = 0, compared = 0;
  double worst_behind = 0;
  std::string row;
  for (int f = 0; step * f <= s_sign - 5; ++f) {
    const double s = step * f;
    const CameraPose q = pose_at(s);
    const StreetLighting plan = plan_street_lighting(road_labels(g, W, H, q, offset, left, right), g, p, 7);
    EXPECT_EQ(plan.road_ahead.turning_behind_m, 0) << "a single frame";
    const StreetLighting sl = set.update(plan, g, W, H, q, p, 7);
    const RoadAhead& ra = sl.road_ahead;
    if (!(ra.curved && ra.curve_start_m <= kBendAtCameraM)) {
      EXPECT_EQ(ra.turning_behind_m, 0) << f;
      continue;
    }
    const double on = std::max(0.0, s - Dc);  // driven on the circle
    const double lo = std::min(on, 3 * S), hi = on + step;
    if (on > 0) {
      EXPECT_GE(ra.turning_behind_m, lo - 1e-9) << "frame " << f;
      EXPECT_LE(ra.turning_behind_m, hi + 1e-9) << "frame " << f;
      worst_behind = std::max(worst_behind, std::fabs(ra.turning_behind_m - on));
      ++measured;
    }
    // The sign, in this frame: its facing in the world, where its reading point lies behind the camera.
    const double dx = sX - q.X_m, dd = sD - q.D_m;
    const double x = dx * std::cos(q.yaw_rad) - dd * std::sin(q.yaw_rad), d = dx * std::sin(q.yaw_rad) + dd * std::cos(q.yaw_rad);
    const double s_read = s_sign - p.sign_read_distance_m - s;  // the reading point's arc length from the camera
    if (s_read >= 0 || d <= 0) continue;
    const double world = sign_facing_heading_rad(ra, x, d, p.sign_read_distance_m) + q.yaw_rad;
    RoadAhead single = ra;
    single.turning_behind_m = 0;
    const double world_single = sign_facing_heading_rad(single, x, d, p.sign_read_distance_m) + q.yaw_rad;
    // The fit's heading error at the reading point: ψ's and κ's variances and covariance
    // (covariance rows: left, right, heading, curvature).
    const auto& C = ra.covariance;
    const double se = std::sqrt(std::max(0.0, C[10] + s_read * s_read * C[15] + 2 * s_read * C[11]));
    // 5 SE; plus the circle's entry step's one-arc approximation (its end off the true path's heading by
    // at most step/(2R): the step's turn spread over its whole length).
    EXPECT_NEAR(world, truth, 5 * se + step / (2 * R)) << "frame " << f;
    row += fmt::format(" {}: {:+.4f} ({:+.4f}; camera {:+.3f})", f, world - truth, world_single - truth, q.yaw_rad);
    ++compared;
  }
  EXPECT_GT(measured, 3);
  EXPECT_GT(compared, 2);
  std::fprintf(stderr, "[signs] round a 100 m bend: turning behind within %.2f m of the arc driven in %d frames; the sign's facing "
               "less the road's at its reading point, by frame (without the arc driven; the camera's yaw):%s\n",
               worst_behind, measured, row.c_str());
}

// A vehicle that turns on a straight road (a lane change: 18 m/s, 0.5 s a frame, turning left at
// 0.05 rad/s for 2 s, then right for 2 s, 3.6 m across by the end) does not bend the road-edge
// layout: the frames' kerbs (plan_street_lighting of the straight road seen from each pose) shift
// as the camera's offset and heading predict, so the road line runs straight on and every
// road-edge luminaire in view stays on the straight rows (the kerbs plus the setback), exactly
// (the one straight piece of a straight drive: to rounding, 1e-9 m as in
// RoadEdgeLayoutFollowsACurvingRoad). Following the vehicle's turns alone would bend the rows
// with every steering movement.
TEST(Luminaires, RoadEdgeLayoutStaysStraightThroughALaneChange) {
  const ScenePreset p = urban();
  const int W = 1024, H = 512;
  const CameraGeometry g = camera_geometry(load_camera_rig("cityscapes"), W, H, VanishingPoint{});
  const double left = -5.25, right = 3.5, tol = 1e-9;
  const uint64_t seed = 7;
  const double ul = (-0.5 - g.cx_px) / g.f_px, ur = (W - 0.5 - g.cx_px) / g.f_px;
  const std::vector<double> yaw_rate = {0, 0.05, 0.05, 0.05, 0.05, -0.05, -0.05, -0.05, -0.05, 0, 0, 0};  // ISO 8855: + left
  LuminaireSet set;
  CameraPose q;
  int checked = 0;
  double max_yaw = 0;
  for (size_t f = 0; f < yaw_rate.size(); ++f) {
    if (f > 0) {
      OdometrySample a, b;
      a.time_ns = 500'000'000ll * static_cast<int64_t>(f - 1);
      b.time_ns = 500'000'000ll * static_cast<int64_t>(f);
      a.speed_m_s = b.speed_m_s = 18;
      a.yaw_rate_rad_s = yaw_rate[f - 1];
      b.yaw_rate_rad_s = yaw_rate[f];
      q = advance_pose(q, a, b, "test");
    }
    max_yaw = std::max(max_yaw, std::fabs(q.yaw_rad));
    const StreetLighting plan = plan_street_lighting(road_labels(g, W, H, q, [](double X, double) { return X; }, left, right), g, p, seed);
    ASSERT_GT(plan.road_right_m, plan.road_left_m) << "frame " << f << ": no kerbs measured (" << plan.note << "), pose " << q.X_m << " " << q.D_m << " " << q.yaw_rad;
    const StreetLighting s = set.update(plan, g, W, H, q, p, seed);
    for (const auto& l : s.lamps) {
      if (l.from_pole || !(l.D_m > 0 && l.X_m >= ul * l.D_m && l.X_m <= ur * l.D_m)) continue;
      double X, D;
      frame_to_world(q, l.X_m, l.D_m, &X, &D);
      EXPECT_LE(std::min(std::fabs(X - (right + p.lamp_setback_m)), std::fabs(X - (left - p.lamp_setback_m))), tol)
          << "frame " << f << ": luminaire at world (" << X << ", " << D << ") off the straight rows";
      ++checked;
    }
  }
  EXPECT_LT(q.X_m, -3) << "the vehicle did not change lanes";
  EXPECT_GT(checked, 20);
  EXPECT_EQ(set.path_pieces(), 1u);
  std::fprintf(stderr, "[lane change] %zu frames, %.2f m across, up to %.3f rad turned: %d luminaires in view on the straight rows\n",
               yaw_rate.size(), -q.X_m, max_yaw, checked);
}

namespace {
// A 0.3 m wide lamp pole painted into `lm`: its foot projected at (u0, v0) from depth z0, its top
// at row v1 (f_px: the camera's focal length in pixels); the part inside the image.
void paint_pole(LabelMap& lm, double u0, double v0, double z0, double v1, double f_px) {
  const double half = 0.5 * f_px * 0.3 / z0;
  const int W = lm.ids.width(), H = lm.ids.height();
  for (int y = std::max(0, static_cast<int>(std::ceil(v1))); y <= std::min(H - 1, static_cast<int>(std::floor(v0))); ++y)
    for (int x = std::max(0, static_cast<int>(std::ceil(u0 - half))); x <= std::min(W - 1, static_cast<int>(std::floor(u0 + half))); ++x)
      lm.ids.at(x, y) = static_cast<uint16_t>(Label::Pole);
}
// A KITTI-raw-layout sequence under `root` (image_2/drive, semantic/drive, oxts/drive): frame f
// the day photo days[f] (linear sRGB) with labels frames[f], its OXTS record vf = speed_m_s and
// wu = yaw_rate_rad_s (ISO 8855: positive turning left), the timestamps 0.5 s apart.
// (With one yaw rate per frame: yaw_rates_rad_s[f].)
void write_kitti_sequence(const std::filesystem::path& root, const std::vector<const ImageF*>& days,
                          const std::vector<LabelMap>& frames, double speed_m_s, const std::vector<double>& yaw_rates_rad_s) {
  for (const char* d : {"image_2/drive", "semantic/drive", "oxts/drive/data"}) std::filesystem::create_directories(root / d);
  std::string stamps;
  for (size_t f = 0; f < frames.size(); ++f) {
    std::string oxts;
    for (int k = 0; k < 30; ++k)
      oxts += (k == 8 ? fmt::format("{}", speed_m_s) : k == 22 ? fmt::format("{}", yaw_rates_rad_s[f]) : "0") +
              std::string(k < 29 ? " " : "\n");
    const std::string name = fmt::format("{:010d}", f);
    ImageF srgb = *days[f];
    for (auto& v : srgb.vec()) v = static_cast<float>(srgb_encode(v));
    write_png((root / "image_2" / "drive" / (name + ".png")).string(), srgb);
    ImageF ids(frames[f].ids.width(), frames[f].ids.height(), 1);
    for (size_t k = 0; k < ids.size(); ++k) ids[k] = frames[f].ids[k] / 255.0f;
    write_png((root / "semantic" / "drive" / (name + ".png")).string(), ids);
    std::ofstream((root / "oxts" / "drive" / "data" / (name + ".txt")).string()) << oxts;
    stamps += fmt::format("2011-09-26 13:02:{:02d}.{:03d}\n", 25 + static_cast<int>(f) / 2, 500 * (static_cast<int>(f) % 2));
  }
  std::ofstream((root / "oxts" / "drive" / "timestamps.txt").string()) << stamps;
}
void write_kitti_sequence(const std::filesystem::path& root, const std::vector<const ImageF*>& days,
                          const std::vector<LabelMap>& frames, double speed_m_s, double yaw_rate_rad_s) {
  write_kitti_sequence(root, days, frames, speed_m_s, std::vector<double>(frames.size(), yaw_rate_rad_s));
}
// The same for the synthetic street `sc` seen in every frame, the camera driving `step_m` between
// frames (OXTS vf = step_m / 0.5 s, wu 0).
void write_driving_sequence(const std::filesystem::path& root, const SyntheticCameraScene& sc,
                            const std::vector<LabelMap>& frames, double step_m) {
  write_kitti_sequence(root, std::vector<const ImageF*>(frames.size(), &sc.day_linear_srgb), frames, step_m / 0.5, 0);
}
}  // namespace

// `batch --sequence` over a KITTI-layout sequence of two frames of one view (the camera at
// rest), the second with a lamp pole's labels taken out (as if hidden): frame by frame the
// pole's lamp head goes out in frame 1; as a sequence it stays lit, at the value of frame 0.
// (--rig cityscapes: the scene was rendered with that rig.)
TEST(Luminaires, BatchSequenceKeepsAPolesLampWhenItsLabelGoes) {
  SyntheticCameraOptions o = camera_scene();
  o.boxes.clear();  // nothing in front of the pole's foot
  const SyntheticCameraScene sc = make_synthetic_camera_scene(o);
  const int W = o.width, H = o.height;
  // A 0.3 m pole 7 m tall on the right sidewalk, 50 m ahead (its top in view).
  double u0, v0, z0, u1, v1, z1;
  ASSERT_TRUE(o.camera.project(8.0, 0, 50, &u0, &v0, &z0));
  ASSERT_TRUE(o.camera.project(8.0, 7, 50, &u1, &v1, &z1));
  ASSERT_GT(v1, 10);
  LabelMap with_pole = sc.labels;
  paint_pole(with_pole, u0, v0, z0, v1, o.camera.f_px);
  test::TempDir dir;
  const auto root = dir.path() / "kitti";
  std::filesystem::create_directories(root / "image_2" / "seq");
  std::filesystem::create_directories(root / "semantic" / "seq");
  ImageF srgb = sc.day_linear_srgb;
  for (auto& v : srgb.vec()) v = static_cast<float>(srgb_encode(v));
  for (int f = 0; f < 2; ++f) {
    const std::string name = f == 0 ? "seq/0000000000.png" : "seq/0000000001.png";
    write_png((root / "image_2" / name).string(), srgb);
    const LabelMap& lm = f == 0 ? with_pole : sc.labels;
    ImageF ids(W, H, 1);
    for (size_t k = 0; k < ids.size(); ++k) ids[k] = lm.ids[k] / 255.0f;
    write_png((root / "semantic" / name).string(), ids);
  }
  auto lights = [&](bool sequence, const std::string& out) {
    const auto r = test::run_cli("batch --dataset kitti --root '" + root.string() + "' --out '" + dir.file(out) +
                                 "' --rig cityscapes --layers lights --quiet --seed 3 --device-store '" + dir.file("store") + "'" +
                                 (sequence ? " --sequence" : ""));
    EXPECT_EQ(r.exit_code, 0) << r.output;
    std::vector<ImageF> v;
    for (const char* f : {"/image_2/seq/0000000000.exr", "/image_2/seq/0000000001.exr"})
      v.push_back(read_exr(dir.file(out) + f).channels.at("lights.G"));
    return v;
  };
  const auto alone = lights(false, "alone"), seq = lights(true, "seq");
  // The lamp head: frame 0's brightest light within 1 m (at the pole's distance) of its top.
  const int r = static_cast<int>(std::ceil(o.camera.f_px / z1));
  int hx = -1, hy = -1;
  float best = 0;
  for (int y = std::max(0, static_cast<int>(v1) - r); y <= std::min(H - 1, static_cast<int>(v1) + r); ++y)
    for (int x = std::max(0, static_cast<int>(u1) - r); x <= std::min(W - 1, static_cast<int>(u1) + r); ++x)
      if (alone[0].at(x, y) > best) {
        best = alone[0].at(x, y);
        hx = x;
        hy = y;
      }
  ASSERT_GE(hx, 0);
  // A lamp head (streetlamp_luminance_cd_m2, 10^4 cd/m² and more) against anything lit around it.
  const ScenePreset p = urban();
  EXPECT_GE(best, 0.01 * p.streetlamp_luminance_cd_m2 / 683) << "no lamp head at the pole's top";
  EXPECT_EQ(seq[0].at(hx, hy), alone[0].at(hx, hy));
  EXPECT_EQ(seq[1].at(hx, hy), seq[0].at(hx, hy)) << "as a sequence the lamp stays";
  EXPECT_LT(alone[1].at(hx, hy), 0.01f * best) << "frame by frame it goes out";
  std::fprintf(stderr, "[batch sequence] lamp head at (%d, %d): frame 0 %.4g, frame 1 alone %.4g, as a sequence %.4g\n",
               hx, hy, best, alone[1].at(hx, hy), seq[1].at(hx, hy));
}

// `batch --sequence` over a KITTI-raw-layout sequence whose camera drives 9 m on between two
// frames (its OXTS records: vf 18 m/s, timestamps 0.5 s apart): frame 0 sees a lamp pole 50 m
// ahead, frame 1 (the same straight street, 41 m from the pole) has lost the pole's labels. With
// the odometry (--ego-motion auto, the default) the luminaire stays at its place in the world: in
// frame 1 its head is drawn at the projection of the pole's top 41 m ahead, and nothing at the
// pixel of frame 0's head. Without it (--ego-motion none: every frame at pose 0) the luminaire
// rides with the camera and frame 1 shows it at frame 0's pixel, 50 m ahead, where no pole is.
TEST(Luminaires, BatchSequenceFollowsTheOdometry) {
  SyntheticCameraOptions o = camera_scene();
  o.boxes.clear();  // nothing in front of the pole's foot; the street then looks the same 9 m on
  o.dash_period_m = 9;  // (the lane line's dashes too: one period)
  const SyntheticCameraScene sc = make_synthetic_camera_scene(o);
  const int W = o.width, H = o.height;
  auto top = [&](double D, double* u, double* v) {
    double z;
    ASSERT_TRUE(o.camera.project(8.0, 7, D, u, v, &z));
  };
  double u0, v0, z0, u1, v1;
  ASSERT_TRUE(o.camera.project(8.0, 0, 50, &u0, &v0, &z0));
  top(50, &u1, &v1);
  ASSERT_GT(v1, 10);
  LabelMap with_pole = sc.labels;
  paint_pole(with_pole, u0, v0, z0, v1, o.camera.f_px);
  test::TempDir dir;
  const auto root = dir.path() / "kitti";
  write_driving_sequence(root, sc, {with_pole, sc.labels}, 9);  // vf 18 m/s, 0.5 s apart
  auto lights = [&](const std::string& ego, const std::string& out) {
    const auto r = test::run_cli("batch --dataset kitti --root '" + root.string() + "' --out '" + dir.file(out) +
                                 "' --rig cityscapes --layers lights --quiet --seed 3 --device-store '" + dir.file("store") +
                                 "' --sequence --ego-motion " + ego);
    EXPECT_EQ(r.exit_code, 0) << r.output;
    std::vector<ImageF> v;
    for (const char* f : {"/image_2/drive/0000000000.exr", "/image_2/drive/0000000001.exr"})
      v.push_back(read_exr(dir.file(out) + f).channels.at("lights.G"));
    return v;
  };
  const auto moving = lights("auto", "moving"), still = lights("none", "still");
  // The brightest light within the head's reach (1 m at its distance) of a pole top's projection.
  auto head = [&](const ImageF& img, double D, int* hx, int* hy) {
    double u, v;
    top(D, &u, &v);
    const int r = static_cast<int>(std::ceil(o.camera.f_px / D));
    float best = 0;
    for (int y = std::max(0, static_cast<int>(v) - r); y <= std::min(H - 1, static_cast<int>(v) + r); ++y)
      for (int x = std::max(0, static_cast<int>(u) - r); x <= std::min(W - 1, static_cast<int>(u) + r); ++x)
        if (img.at(x, y) > best) {
          best = img.at(x, y);
          *hx = x;
          *hy = y;
        }
    return best;
  };
  // A lamp head (streetlamp_luminance_cd_m2, 10^4 cd/m² and more) against anything lit around it.
  const float lit = static_cast<float>(0.01 * urban().streetlamp_luminance_cd_m2 / 683);
  int hx = -1, hy = -1, mx = -1, my = -1;
  ASSERT_GE(head(moving[0], 50, &hx, &hy), lit) << "no lamp head at the pole's top in frame 0";
  EXPECT_EQ(still[0].at(hx, hy), moving[0].at(hx, hy));  // the first frame does not depend on the motion
  // Frame 1, driven 9 m on: the head 41 m ahead, and gone from frame 0's pixel.
  EXPECT_GE(head(moving[1], 41, &mx, &my), lit) << "the luminaire did not stay at its place in the world";
  EXPECT_LT(moving[1].at(hx, hy), lit) << "frame 0's head pixel is still lit";
  // At pose 0 the luminaire rides along: still at frame 0's pixel, and not 41 m ahead.
  EXPECT_EQ(still[1].at(hx, hy), still[0].at(hx, hy));
  EXPECT_LT(still[1].at(mx, my), lit);
  // The header records the pose: 9 m on (mean speed 18 m/s over 0.5 s; rounded products of values
  // below 20: within 4·2⁻⁵³·20; the _text attribute's 17 digits round-trip the double).
  const auto attrs = read_exr_attributes(dir.file("moving") + "/image_2/drive/0000000001.exr");
  ASSERT_TRUE(attrs.count("photosite/batch/pose_D_m"));
  EXPECT_NEAR(std::stod(attrs.at("photosite/batch/pose_D_m_text")), 9.0, 4 * 20 * 0x1p-53);
  EXPECT_EQ(std::stod(attrs.at("photosite/batch/pose_X_m_text")), 0.0);
  EXPECT_FALSE(read_exr_attributes(dir.file("still") + "/image_2/drive/0000000001.exr").count("photosite/batch/pose_D_m"));
  std::fprintf(stderr, "[batch odometry] frame 0 head (%d, %d); frame 1 moving: head (%d, %d) %.4g, old pixel %.4g; "
               "at pose 0: old pixel %.4g, new pixel %.4g\n", hx, hy, mx, my, moving[1].at(mx, my), moving[1].at(hx, hy),
               still[1].at(hx, hy), still[1].at(mx, my));
}

// How well the luminaires stay put while the camera drives on: a synthetic street with three lamp
// poles 10 m tall (the preset's mounting height, so a pole cut by the image top is placed as it
// is), driven 9 m a frame over four frames. A sequence that sees the poles in its first frame
// only, each later frame's light map against the same sequence seeing every pole in every frame
// (the poles then re-detected from nearer each frame): the share of light energy both put at the
// same pixels, Σ min(a, b) / Σ b over lights.G. What is left is where frame 0 located a pole's
// ground contact from 50-80 m (a pixel of contact row is D²/(f·h), 1.8-4.6 m there at f 1131 px, h 1.22 m) against a later
// frame from nearer: reported (docs/night.md), with the ordering asserted.
TEST(Luminaires, DrivingOnKeepsTheLightOfPolesSeenOnce) {
  SyntheticCameraOptions o = camera_scene();
  o.boxes.clear();
  const SyntheticCameraScene sc = make_synthetic_camera_scene(o);
  const double step = 9;
  const std::vector<std::pair<double, double>> poles = {{8, 50}, {8, 80}, {-8, 65}};  // (X, D) in the world
  auto labels_at = [&](int f, bool with_poles) {
    LabelMap lm = sc.labels;
    if (with_poles)
      for (const auto& [X, Dw] : poles) {
        double u0, v0, z0, u1, v1, z1;
        const double D = Dw - step * f;
        if (!o.camera.project(X, 0, D, &u0, &v0, &z0) || !o.camera.project(X, 10, D, &u1, &v1, &z1)) continue;
        paint_pole(lm, u0, v0, z0, v1, o.camera.f_px);
      }
    return lm;
  };
  test::TempDir dir;
  std::vector<LabelMap> seen_once, seen_always;
  for (int f = 0; f < 4; ++f) {
    seen_once.push_back(labels_at(f, f == 0));
    seen_always.push_back(labels_at(f, true));
  }
  write_driving_sequence(dir.path() / "once", sc, seen_once, step);
  write_driving_sequence(dir.path() / "always", sc, seen_always, step);
  auto lights = [&](const std::string& set, const std::string& out, const std::string& mode) {
    const auto r = test::run_cli("batch --dataset kitti --root '" + (dir.path() / set).string() + "' --out '" + dir.file(out) +
                                 "' --rig cityscapes --layers lights --quiet --seed 3 --device-store '" + dir.file("store") +
                                 "' " + mode);
    EXPECT_EQ(r.exit_code, 0) << r.output;
    std::vector<ImageF> v;
    for (int f = 0; f < 4; ++f) v.push_back(read_exr(dir.file(out) + fmt::format("/image_2/drive/{:010d}.exr", f)).channels.at("lights.G"));
    return v;
  };
  const auto once = lights("once", "out_once", "--sequence"), always = lights("always", "out_always", "--sequence"),
             still = lights("once", "out_still", "--sequence --ego-motion none"), alone = lights("once", "out_alone", "");
  auto share = [](const ImageF& a, const ImageF& b) {
    double num = 0, den = 0;
    for (size_t k = 0; k < b.size(); ++k) {
      num += std::min(a[k], b[k]);
      den += b[k];
    }
    return num / den;
  };
  EXPECT_EQ(share(once[0], always[0]), 1.0);  // the same first frame
  for (int f = 1; f < 4; ++f) {
    const double s = share(once[f], always[f]), z = share(still[f], always[f]), a = share(alone[f], always[f]);
    // The odometry's sequence keeps more of the light where the poles are than the same sequence
    // at pose 0 (its luminaires ride along with the camera) and than each frame alone (the lost
    // poles' luminaires gone, the layout's in their slots).
    EXPECT_GT(s, z) << "frame " << f;
    EXPECT_GT(s, a) << "frame " << f;
    std::fprintf(stderr, "[driving] frame %d (%g m on): as a sequence %.4f, at pose 0 %.4f, frame by frame %.4f of the light energy\n",
                 f, step * f, s, z, a);
  }
}

namespace {
// One frame of a `batch --sequence --layers lights,depth` run: lights.G, depth.Z and the pitch
// photosite used (the header's 17 digits).
struct WindowFrame { ImageF lights, depth; double pitch_rad; };
std::vector<WindowFrame> window_frames(const std::filesystem::path& root, const std::string& out, const std::string& ego,
                                       int n, const test::TempDir& dir) {
  const auto r = test::run_cli("batch --dataset kitti --root '" + root.string() + "' --out '" + dir.file(out) +
                               "' --rig cityscapes --layers lights,depth --quiet --seed 3 --device-store '" +
                               dir.file("store") + "' --sequence --ego-motion " + ego);
  EXPECT_EQ(r.exit_code, 0) << r.output;
  std::vector<WindowFrame> v;
  for (int f = 0; f < n; ++f) {
    const ExrContents e = read_exr(dir.file(out) + fmt::format("/image_2/drive/{:010d}.exr", f));
    v.push_back({e.channels.at("lights.G"), e.channels.at("depth.Z"),
                 std::stod(e.attributes.at("photosite/night/camera_pitch_deg_text")) * M_PI / 180});
  }
  return v;
}
// The share of frame a's façade light found at the same place in the world in frame b (issue 14
// §3's criterion: at least 95 % of the light energy equal): Σ min(a(x), max₃ₓ₃ b) / Σ a over a's
// building pixels, each pixel's point from `depth_a` (camera z) with camera g at pose pa, carried
// into frame b's road coordinates (pose pb) and projected there with g, the largest value of b in
// the 3 x 3 pixels around the projection (its rounding to a pixel moves a pane's edge by up to a
// pixel); only points landing on b's building pixels 2 px inside its frame and 3-195 m along the
// street (the façades' extent) count.
double window_light_kept(const ImageF& a, const LabelMap& la, const ImageF& depth_a, const CameraPose& pa,
                         const ImageF& b, const LabelMap& lb, const CameraPose& pb, const CameraGeometry& g) {
  const int W = a.width(), H = a.height();
  const double c = std::cos(g.pitch_rad), sn = std::sin(g.pitch_rad);
  const uint16_t building = static_cast<uint16_t>(Label::Building);
  double num = 0, den = 0;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      if (la.ids.at(x, y) != building || a.at(x, y) <= 0) continue;
      const double z = depth_a.at(x, y), xn = (x - g.cx_px) / g.f_px, yn = (y - g.cy_px) / g.f_px;
      const double X = z * xn, Y = g.mount_height_m - z * (yn * c + sn), D = z * (c - yn * sn);
      // Frame a → the world → frame b (luminaires.cpp's Pose2).
      const double ca = std::cos(pa.yaw_rad), sa = std::sin(pa.yaw_rad), cb = std::cos(pb.yaw_rad), sb = std::sin(pb.yaw_rad);
      const double Xw = pa.X_m + X * ca + D * sa, Dw = pa.D_m - X * sa + D * ca;
      if (Dw < 3 || Dw > 195) continue;
      const double dx = Xw - pb.X_m, dd = Dw - pb.D_m, Xb = dx * cb - dd * sb, Db = dx * sb + dd * cb;
      double u, v, zb;
      if (!g.project(Xb, Y, Db, &u, &v, &zb)) continue;
      const int ub = static_cast<int>(std::lround(u)), vb = static_cast<int>(std::lround(v));
      if (ub < 2 || vb < 2 || ub >= W - 2 || vb >= H - 2 || lb.ids.at(ub, vb) != building) continue;
      float m = 0;
      for (int ddy = -1; ddy <= 1; ++ddy)
        for (int ddx = -1; ddx <= 1; ++ddx) m = std::max(m, b.at(ub + ddx, vb + ddy));
      num += std::min(a.at(x, y), m);
      den += a.at(x, y);
    }
  return den > 0 ? num / den : NAN;
}
}  // namespace

// The façade windows stay on their façades while the camera drives on (issue 14 §3: "batch over
// a sequence keeps windows and lamps attached to buildings and poles"). The synthetic street with
// its two 12 m façades (X = ±10 m, D 3-200 m) is driven 9 m a frame; the street is the same every
// 9 m (its checker 1 m, its dashes 9 m), so every frame shows the same labels and photo, and the
// windows are the grid's (plain façades: none found in the photo). Each frame's façade light
// against the previous frame's at the same world point (window_light_kept), both ways. Asserted
// in photosite's own geometry (its depth.Z and the sequence's pitch from the header): where the
// windows are laid out. In the true geometry (the scene's depth and camera) the same shares are
// reported: there the depth's own error (the vanishing point's horizon against the true one:
// 1-6 % deeper on these façades, growing with distance) moves a window along its façade by that
// error times the 9 m. At pose 0 (--ego-motion none) the grid rides with the camera: the same
// pixels lit in every frame, so a world point's window is lit or not at random between frames.
TEST(Luminaires, DrivingKeepsTheWindowsOnTheirFacades) {
  SyntheticCameraOptions o = camera_scene();
  o.boxes.clear();
  const SyntheticCameraScene sc = make_synthetic_camera_scene(o);
  const double step = 9;
  test::TempDir dir;
  write_driving_sequence(dir.path() / "drive", sc, {sc.labels, sc.labels, sc.labels}, step);
  const auto moving = window_frames(dir.path() / "drive", "moving", "auto", 3, dir),
             still = window_frames(dir.path() / "drive", "still", "none", 3, dir);
  for (int f = 1; f < 3; ++f) {
    ASSERT_EQ(moving[f].pitch_rad, moving[0].pitch_rad);  // the sequence keeps its first frame's pitch
    CameraGeometry g = o.camera;
    g.pitch_rad = moving[f].pitch_rad;
    const CameraPose pa{0, step * f, 0}, pb{0, step * (f - 1), 0};
    auto both = [&](const std::vector<WindowFrame>& s, const CameraPose& a, const CameraPose& b, bool own) {
      const CameraGeometry& gg = own ? g : o.camera;
      return std::pair{window_light_kept(s[f].lights, sc.labels, own ? s[f].depth : sc.depth_m, a, s[f - 1].lights, sc.labels, b, gg),
                       window_light_kept(s[f - 1].lights, sc.labels, own ? s[f - 1].depth : sc.depth_m, b, s[f].lights, sc.labels, a, gg)};
    };
    const auto [fwd, back] = both(moving, pa, pb, true);
    const auto [fwd_true, back_true] = both(moving, pa, pb, false);
    // At pose 0 the frames are the same, but the world still moved 9 m: compared at the true places.
    const auto [fwd0, back0] = both(still, pa, pb, true);
    EXPECT_GE(fwd, 0.95) << "frame " << f << ": its windows' light not in the previous frame's at the same place";
    EXPECT_GE(back, 0.95) << "frame " << f << ": the previous frame's windows' light not in this frame's";
    EXPECT_LT(fwd0, fwd) << "frame " << f;
    EXPECT_LT(back0, back) << "frame " << f;
    std::fprintf(stderr, "[driving windows] frame %d (%g m on): façade light energy kept (this frame's in the last's / "
                 "the last's in this one's): with odometry %.4f / %.4f (true geometry %.4f / %.4f), at pose 0 %.4f / %.4f\n",
                 f, step * f, fwd, back, fwd_true, back_true, fwd0, back0);
  }
}

namespace {
// A world façade plane in the frame of a camera at `pose` (facade_in_world inverted: the normal
// turned back by the yaw, the distance less the normal's component of the pose's place).
FacadePlane in_frame(const FacadePlane& w, const CameraPose& pose) {
  const double c = std::cos(pose.yaw_rad), sn = std::sin(pose.yaw_rad);
  FacadePlane f = w;
  f.nX = w.nX * c - w.nD * sn;
  f.nD = w.nX * sn + w.nD * c;
  f.d_m = w.d_m - (w.nX * pose.X_m + w.nD * pose.D_m);
  return f;
}
}  // namespace

// A sequence's façades keep their windows' draw keys while each frame fits their planes anew
// (FacadeSet): facade_key quantises the distance to 5 m, so a façade fitted at 12.49 m in one
// frame and 12.51 m in the next would change its key (and every window's lit draw); matched to
// the remembered façade it keeps frame 0's. A plane more than half a step away (in distance or
// azimuth) is another façade; a façade beyond forget_m of the camera is forgotten.
TEST(Luminaires, FacadesKeepTheirKeysAcrossAFitsStepEdge) {
  auto plane = [](double az_deg, double d) {
    FacadePlane f;
    f.nX = std::sin(az_deg * M_PI / 180);
    f.nD = std::cos(az_deg * M_PI / 180);
    f.d_m = d;
    f.fitted = true;
    return f;
  };
  FacadeSet set;
  const CameraPose p0{};
  const FacadePlane near_edge = plane(90, 12.49), across = plane(90, 12.51), other = plane(90, 20), turned = plane(80, 12.5);
  ASSERT_NE(facade_key(facade_in_world(near_edge, p0)), facade_key(facade_in_world(across, p0)));  // the step's edge lies between them
  const auto k0 = set.keys({near_edge, other}, p0, 200);
  ASSERT_EQ(k0.size(), 2u);
  EXPECT_EQ(k0[0], facade_key(facade_in_world(near_edge, p0)));  // a first sighting: its own key
  EXPECT_EQ(k0[1], facade_key(facade_in_world(other, p0)));
  // Driven 9 m on and turned 2° (the plane given in that frame's coordinates): the same façade,
  // fitted 0.02 m farther, keeps frame 0's key; 10° off is another façade.
  const CameraPose p1{0, 9, 2 * M_PI / 180};
  const auto k1 = set.keys({in_frame(across, p1), in_frame(turned, p1)}, p1, 200);
  EXPECT_EQ(facade_key(facade_in_world(in_frame(across, p1), p1)), facade_key(facade_in_world(across, p0)));  // the world's own key: the step moved
  EXPECT_EQ(k1[0], k0[0]) << "the façade took a new key when its fit crossed a step's edge";
  EXPECT_NE(k1[1], k0[0]);
  EXPECT_EQ(set.size(), 3u);
  // 300 m to their left (on their side), every façade is beyond forget_m and forgotten: the plane
  // across the edge is then seen afresh, with its own key.
  const CameraPose far{-300, 9, 0};
  const auto k2 = set.keys({in_frame(across, far)}, far, 200);
  EXPECT_EQ(k2[0], facade_key(facade_in_world(across, p0)));
  EXPECT_EQ(set.size(), 1u);
}

// A sequence's fitted façades also keep their planes (FacadeSet::hold): the same façade fitted
// 0.4 m farther and 1° turned in a later frame (a flat-ground depth with a horizon slightly off)
// is given back as first fitted, carried into that frame, so its windows stand where they stood;
// the frame's foot line and flags stay. A plane that was not fitted (a default façade) is neither
// replaced nor replaces; another façade keeps its own fit.
TEST(Luminaires, FacadesKeepTheirFirstFittedPlaneInASequence) {
  auto plane = [](double az_deg, double d, bool fitted) {
    FacadePlane f;
    f.nX = std::sin(az_deg * M_PI / 180);
    f.nD = std::cos(az_deg * M_PI / 180);
    f.d_m = d;
    f.fitted = fitted;
    f.line_a = 300;
    f.line_b = 0.25;
    return f;
  };
  FacadeSet set;
  const CameraPose p0{}, p1{0.5, 9, 3 * M_PI / 180};
  const FacadePlane first = plane(90, 12.5, true), unfitted = plane(-90, 9, false), other = plane(60, 30, true);
  std::vector<FacadePlane> f0{first, unfitted};
  set.hold(&f0, p0, 200);
  EXPECT_EQ(f0[0].d_m, 12.5);  // a first sighting: its own fit
  // Frame 1: the same façade fitted 0.4 m farther and 1° turned (in the world), the unfitted one
  // now fitted 0.3 m nearer, and another façade.
  FacadePlane refit = in_frame(plane(91, 12.9, true), p1);
  refit.line_a = 280;
  refit.line_b = -0.1;
  std::vector<FacadePlane> f1{refit, in_frame(plane(-90, 8.7, true), p1), in_frame(other, p1)};
  const std::vector<FacadePlane> given = f1;
  const auto k1 = set.hold(&f1, p1, 200);
  const FacadePlane want = in_frame(first, p1);
  // 1e-12: a rotation and a dot product of values below 20 in double (a few ulps of 20, 4e-15).
  EXPECT_NEAR(f1[0].nX, want.nX, 1e-12);
  EXPECT_NEAR(f1[0].nD, want.nD, 1e-12);
  EXPECT_NEAR(f1[0].d_m, want.d_m, 1e-12);
  EXPECT_GT(std::fabs(given[0].d_m - want.d_m), 0.3);  // the fit given was another plane
  EXPECT_EQ(f1[0].line_a, 280);  // the frame's own foot line
  EXPECT_EQ(f1[0].line_b, -0.1);
  EXPECT_TRUE(f1[0].fitted);
  EXPECT_EQ(f1[1].d_m, given[1].d_m);  // matched to an unfitted façade: its own fit
  EXPECT_EQ(f1[1].nX, given[1].nX);
  EXPECT_EQ(f1[2].d_m, given[2].d_m);  // another façade: its own fit
  EXPECT_EQ(k1.size(), 3u);
  // keys() gives the same keys and leaves the planes as they were.
  FacadeSet again;
  std::vector<FacadePlane> g0{first, unfitted};
  again.hold(&g0, p0, 200);
  EXPECT_EQ(again.keys(given, p1, 200), k1);
}

// Parked vehicles keep their parking lights over a sequence whose camera drives on. A row of
// cars parked on the right sidewalk (X 8.5 m, every 6.5 m from 14 m on), the camera driving
// 9 m a frame (each frame rendered from its pose), their instance codes numbered anew in each
// frame (as a segmentation model numbers them: each parked vehicle's draw is keyed by its code,
// which then names another car in the next frame), half the parked vehicles lit
// (vehicle_lamps.parked_lit_fraction 0.5, so that a change shows). Each vehicle's decision is
// read from the test hook, its car known from its code. As a sequence (ParkedSet, which matches
// them by their place in the world) no parked car seen in two frames changes its lights; frame by
// frame about half of them do (each a fresh draw).
TEST(Luminaires, ParkedVehiclesKeepTheirParkingLightsWhileDriving) {
  const double step = 9;
  const int n = 3;
  ScenePreset p = urban();
  p.rig = load_camera_rig("cityscapes");
  p.veh_parked_lit_fraction = 0.5;
  std::vector<SyntheticCameraScene> scenes;
  for (int f = 0; f < n; ++f) {
    SyntheticCameraOptions o = camera_scene();
    o.boxes.clear();
    for (int k = 0; k < 9; ++k) o.boxes.push_back({8.5, 14 + 6.5 * k, 1.8, 1.5, 4.5});
    o.world_D_m = step * f;
    scenes.push_back(make_synthetic_camera_scene(o));
    // The instance codes numbered anew each frame (the same car another code in each frame).
    for (auto& v : scenes.back().labels.instances.vec())
      if (v) v = static_cast<uint16_t>(26000 + (v - 26000 + 4 * f) % 9);
  }
  // Each decision's car (its box: the code's numbering undone) and state.
  struct Seen { int car, state; };
  auto decisions = [&](bool sequence) {
    SequenceState st;
    std::vector<std::vector<Seen>> out(n);
    for (int f = 0; f < n; ++f) {
      st.pose = CameraPose{0, step * f, 0};
      std::vector<VehicleDecision> seen;
      set_vehicle_decision_sink(&seen);
      night_scene(scenes[f].day_linear_srgb, scenes[f].labels, p, 5, false, sequence ? &st : nullptr);
      set_vehicle_decision_sink(nullptr);
      for (const auto& d : seen)
        if (d.state != 1 && d.instance) out[f].push_back({((d.instance - 26000 - 4 * f) % 9 + 9) % 9, d.state});
    }
    return out;
  };
  // Over consecutive frames, the parked cars seen in both (`matched`, of them `lit` in the later
  // frame) and how many changed their lights.
  auto changes = [&](const std::vector<std::vector<Seen>>& s, int* matched, int* lit) {
    int changed = 0;
    *matched = *lit = 0;
    for (int f = 1; f < n; ++f)
      for (const Seen& a : s[f])
        for (const Seen& b : s[f - 1])
          if (a.car == b.car) {
            ++*matched;
            *lit += a.state == 2;
            changed += a.state != b.state;
          }
    return changed;
  };
  int m_seq, lit_seq, m_alone, lit_alone;
  const int seq_changes = changes(decisions(true), &m_seq, &lit_seq), alone_changes = changes(decisions(false), &m_alone, &lit_alone);
  std::fprintf(stderr, "[parked] vehicles seen parked in two frames: as a sequence %d (%d lit), %d changed their lights; "
               "frame by frame %d (%d lit), %d changed\n", m_seq, lit_seq, seq_changes, m_alone, lit_alone, alone_changes);
  ASSERT_GE(m_seq, 8) << "too few parked vehicles matched between frames for the test to say anything";
  ASSERT_GT(lit_seq, 0);
  EXPECT_EQ(seq_changes, 0) << "a parked vehicle's lights changed between frames of the sequence";
  EXPECT_GT(alone_changes, 0);
}

namespace {
// The synthetic street (no boxes) seen from the poses a vehicle reaches at 18 m/s turning left at
// 0.1 rad/s (OXTS vf, wu; advance_pose's arc, 0.5 s a frame: 9 m and 2.9° a frame), each frame
// rendered from its pose, written as a KITTI drive with its OXTS records under `root`.
struct TurningStreet {
  std::vector<CameraPose> poses;
  std::vector<SyntheticCameraScene> scenes;
  std::vector<LabelMap> labels;
};
TurningStreet write_turning_street(const std::filesystem::path& root, int n) {
  const double speed = 18, yaw_rate = 0.1;
  TurningStreet t;
  t.poses.resize(n);
  for (int f = 1; f < n; ++f) {
    OdometrySample a, b;
    a.time_ns = 500'000'000ll * (f - 1);
    b.time_ns = 500'000'000ll * f;
    a.speed_m_s = b.speed_m_s = speed;
    a.yaw_rate_rad_s = b.yaw_rate_rad_s = yaw_rate;
    t.poses[f] = advance_pose(t.poses[f - 1], a, b, "test");
  }
  for (int f = 0; f < n; ++f) {
    SyntheticCameraOptions o = camera_scene();
    o.boxes.clear();
    o.world_X_m = t.poses[f].X_m;
    o.world_D_m = t.poses[f].D_m;
    o.world_yaw_rad = t.poses[f].yaw_rad;
    t.scenes.push_back(make_synthetic_camera_scene(o));
  }
  std::vector<const ImageF*> days;
  for (const auto& sc : t.scenes) {
    days.push_back(&sc.day_linear_srgb);
    t.labels.push_back(sc.labels);
  }
  write_kitti_sequence(root, days, t.labels, speed, yaw_rate);
  return t;
}
}  // namespace

// The same while the camera turns: the synthetic street seen from the poses a vehicle reaches at
// 18 m/s turning left at 0.1 rad/s (OXTS vf, wu; advance_pose's arc, 0.5 s a frame: 9 m and
// 2.9° a frame), each frame rendered from its pose, so the façades run obliquely through the
// view and their planes are fitted anew each frame. The window grid is laid out in the world
// (the plane's direction, its distance and the cells turned and moved by the pose), so frame t's
// façade light is found at the same world points in frame t − 1 (asserted ≥ 95 % both ways in
// photosite's own geometry); the pose-0 sequence of the same frames keeps far less.
TEST(Luminaires, TurningKeepsTheWindowsOnTheirFacades) {
  const int n = 3;
  test::TempDir dir;
  const TurningStreet t = write_turning_street(dir.path() / "drive", n);
  const std::vector<CameraPose>& poses = t.poses;
  const std::vector<SyntheticCameraScene>& scenes = t.scenes;
  const std::vector<LabelMap>& labels = t.labels;
  ASSERT_LT(poses[2].yaw_rad, -0.09);  // turning left: toward −X
  const SyntheticCameraOptions o = camera_scene();
  const auto moving = window_frames(dir.path() / "drive", "moving", "auto", n, dir),
             still = window_frames(dir.path() / "drive", "still", "none", n, dir);
  for (int f = 1; f < n; ++f) {
    CameraGeometry g = o.camera;
    g.pitch_rad = moving[f].pitch_rad;
    auto both = [&](const std::vector<WindowFrame>& s, bool own) {
      const CameraGeometry& gg = own ? g : o.camera;
      const ImageF &za = own ? s[f].depth : scenes[f].depth_m, &zb = own ? s[f - 1].depth : scenes[f - 1].depth_m;
      return std::pair{
          window_light_kept(s[f].lights, labels[f], za, poses[f], s[f - 1].lights, labels[f - 1], poses[f - 1], gg),
          window_light_kept(s[f - 1].lights, labels[f - 1], zb, poses[f - 1], s[f].lights, labels[f], poses[f], gg)};
    };
    const auto [fwd, back] = both(moving, true);
    const auto [fwd_true, back_true] = both(moving, false);
    const auto [fwd0, back0] = both(still, true);
    EXPECT_GE(fwd, 0.95) << "frame " << f;
    EXPECT_GE(back, 0.95) << "frame " << f;
    EXPECT_LT(fwd0, fwd) << "frame " << f;
    EXPECT_LT(back0, back) << "frame " << f;
    std::fprintf(stderr, "[turning windows] frame %d (pose X %.3f m, D %.3f m, yaw %.4f rad): façade light energy kept "
                 "(this frame's in the last's / the last's in this one's): with odometry %.4f / %.4f (true geometry "
                 "%.4f / %.4f), at pose 0 %.4f / %.4f; pitch %.5f rad (the renderer's %.5f)\n",
                 f, poses[f].X_m, poses[f].D_m, poses[f].yaw_rad, fwd, back, fwd_true, back_true, fwd0, back0, g.pitch_rad,
                 o.camera.pitch_rad);
  }
}

namespace {
// Lamp heads in a `lights` layer: the 4-connected groups of pixels at or above `thr`, each as its
// energy-weighted centre (u, v: pixel centres at integer coordinates, as draw_head_row samples
// them) and whether it touches the frame's border (its centre then cut).
struct HeadBlob { double u, v; bool border; };
std::vector<HeadBlob> head_blobs(const ImageF& L, float thr) {
  const int W = L.width(), H = L.height();
  std::vector<uint8_t> seen(static_cast<size_t>(W) * H, 0);
  std::vector<HeadBlob> out;
  for (int y0 = 0; y0 < H; ++y0)
    for (int x0 = 0; x0 < W; ++x0) {
      if (seen[static_cast<size_t>(y0) * W + x0] || !(L.at(x0, y0) >= thr)) continue;
      double su = 0, sv = 0, s = 0;
      bool border = false;
      std::vector<std::pair<int, int>> stack{{x0, y0}};
      seen[static_cast<size_t>(y0) * W + x0] = 1;
      while (!stack.empty()) {
        const auto [x, y] = stack.back();
        stack.pop_back();
        const double w = L.at(x, y);
        su += w * x, sv += w * y, s += w;
        border = border || x == 0 || y == 0 || x == W - 1 || y == H - 1;
        for (const auto [dx, dy] : {std::pair{1, 0}, {-1, 0}, {0, 1}, {0, -1}}) {
          const int u = x + dx, v = y + dy;
          if (u < 0 || v < 0 || u >= W || v >= H || seen[static_cast<size_t>(v) * W + u] || !(L.at(u, v) >= thr)) continue;
          seen[static_cast<size_t>(v) * W + u] = 1;
          stack.push_back({u, v});
        }
      }
      out.push_back({su / s, sv / s, border});
    }
  return out;
}
}  // namespace

// End to end on a rendered curving street (issue 14 §3, lights stay put): the synthetic street
// (no boxes) straight for 58.5 m, then curving on a circle of 100 m radius (road40's choice, within
// city streets' 60-150 m), to the right and to the left; the vehicle drives along its centre line at
// 18 m/s, 0.5 s a frame (9 m), each frame rendered from its true pose on that line. Its OXTS records
// give yaw rate 0 on the straight and ∓18/100 rad/s (ISO 8855: + left) from the first pose on the
// circle; the curve starts half a step before that pose, so the step across it, which advance_pose
// turns by the mean of the two rates (half), turns by exactly what the road does (4.5 m on the
// circle): the odometry's headings are the true ones, its positions a few centimetres off (the
// step's arc against straight-then-circle; computed below and added to the bound). `batch
// --sequence --layers lights,depth` with that odometry. Where do the street luminaires stand? Each
// lamp head in lights.G (a flat disc at the mount height, drawn only within the cutoff's reach, some
// 25 m, so the lamps near the camera) is taken at its energy-weighted centre, its ray through
// photosite's camera (its pitch from the EXR) met with the plane of the mount height, and the point
// carried into the street by the frame's true pose: its offset across the street's centre line
// (synthetic_street_coordinates) must be the kerb's (7 m) plus the setback, either side. Asserted
// in every frame whose step lies on the circle (there the road line is the road) and in frames on
// the straight for the heads on the straight; reported for all, with the heads found and off. (The
// heads on the curve seen from the straight stand on the road ahead each frame measures from its
// kerbs, measure_road_ahead: within a few metres on the right-hand curve; on the left-hand one this
// sequence's vanishing point puts the pitch 0.0021 rad low, which bends the measured kerbs less:
// reported, docs/night.md §7 "The road ahead".)
// The bound: h²/(2R) (the road line follows the step across the curve's start as one arc, whose end
// lies beside the true path by at most that: RoadEdgeLayoutFollowsACurvingRoad), the odometry's
// offset from the true poses, the kerbs photosite measures in frame 0 (its plan with its pitch,
// quarter metres) against the true 7 m, and half a pixel of the head's centre at its distance across
// (z/f) and along the ray (z²/(f·rise), the plane met at a grazing angle), a bound on the drawn
// ellipse's centroid (coverage in 1/4-pixel sub-samples, symmetric about the projection).
TEST(Luminaires, BatchSequenceKeepsLampsBesideACurvingRoad) {
  const ScenePreset p = urban();
  const double speed = 18, step = 9, R = 100, Dc = 6 * step + 0.5 * step;
  const int n = 14;  // 117 m: 58.5 m of circle, a third of a radian
  for (const double sigma : {1.0, -1.0}) {
    SCOPED_TRACE(sigma > 0 ? "turning right" : "turning left");
    SyntheticCameraOptions o = camera_scene();
    o.boxes.clear();
    o.road_radius_m = sigma * R;
    o.curve_start_D_m = Dc;
    // The true poses on the centre line (arc length s) and the OXTS yaw rates at them.
    std::vector<CameraPose> truth(n), odo(n);
    std::vector<double> wu(n);
    for (int f = 0; f < n; ++f) {
      const double s = step * f;
      if (s <= Dc) {
        truth[f] = {0, s, 0};
        wu[f] = 0;
      } else {
        const double th = (s - Dc) / R;
        truth[f] = {sigma * (R - R * std::cos(th)), Dc + R * std::sin(th), sigma * th};
        wu[f] = -sigma * speed / R;
      }
    }
    double pose_err = 0;
    for (int f = 1; f < n; ++f) {
      OdometrySample a, b;
      a.time_ns = 500'000'000ll * (f - 1);
      b.time_ns = 500'000'000ll * f;
      a.speed_m_s = b.speed_m_s = speed;
      a.yaw_rate_rad_s = wu[f - 1];
      b.yaw_rate_rad_s = wu[f];
      odo[f] = advance_pose(odo[f - 1], a, b, "test");
      pose_err = std::max(pose_err, std::hypot(odo[f].X_m - truth[f].X_m, odo[f].D_m - truth[f].D_m));
      // The headings agree (to rounding: a few roundings of angles below 1 rad).
      ASSERT_NEAR(odo[f].yaw_rad, truth[f].yaw_rad, 1e-12) << "frame " << f;
    }
    std::vector<SyntheticCameraScene> scenes;
    std::vector<LabelMap> labels;
    std::vector<const ImageF*> days;
    for (int f = 0; f < n; ++f) {
      SyntheticCameraOptions of = o;
      of.world_X_m = truth[f].X_m;
      of.world_D_m = truth[f].D_m;
      of.world_yaw_rad = truth[f].yaw_rad;
      scenes.push_back(make_synthetic_camera_scene(of));
    }
    for (const auto& sc : scenes) {
      labels.push_back(sc.labels);
      days.push_back(&sc.day_linear_srgb);
    }
    test::TempDir dir;
    write_kitti_sequence(dir.path() / "drive", days, labels, speed, wu);
    const auto r = test::run_cli("batch --dataset kitti --root '" + (dir.path() / "drive").string() + "' --out '" +
                                 dir.file("out") + "' --rig cityscapes --layers lights,depth --quiet --seed 3 --device-store '" +
                                 dir.file("store") + "' --sequence");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    const double row = o.road_half_width_m + p.lamp_setback_m, Hm = p.lamp_mount_height_m;
    // A head pixel: at least 1% of the lamp's luminance (BatchSequenceKeepsAPolesLampWhenItsLabelGoes);
    // nothing else in this street's lights comes near (pools, windows: a few cd/m² to hundreds).
    const float thr = static_cast<float>(0.01 * p.streetlamp_luminance_cd_m2 / 683);
    double kerb_err = -1, worst_asserted = 0;
    int heads = 0, asserted = 0;
    std::string by_frame;
    double pitch0 = 0;  // the sequence's pitch (its first frame's)
    for (int f = 0; f < n; ++f) {
      const ExrContents e = read_exr(dir.file("out") + fmt::format("/image_2/drive/{:010d}.exr", f));
      CameraGeometry g = o.camera;
      g.pitch_rad = std::stod(e.attributes.at("photosite/night/camera_pitch_deg_text")) * M_PI / 180;
      if (f == 0) {
        pitch0 = g.pitch_rad;
        const StreetLighting plan = plan_street_lighting(labels[0], g, p, 3);
        kerb_err = std::max(std::fabs(plan.road_right_m - o.road_half_width_m), std::fabs(plan.road_left_m + o.road_half_width_m));
      }
      const bool on_circle = step * (f - 1) >= Dc, on_straight = step * f <= Dc;
      const double c = std::cos(g.pitch_rad), sn = std::sin(g.pitch_rad), rise = Hm - g.mount_height_m;
      double frame_worst = 0;
      int frame_heads = 0, frame_off = 0, frame_asserted = 0;
      for (const HeadBlob& b : head_blobs(e.channels.at("lights.G"), thr)) {
        if (b.border) continue;
        const double xn = (b.u - g.cx_px) / g.f_px, yn = (b.v - g.cy_px) / g.f_px, dY = -(yn * c + sn);
        if (!(dY > 0)) continue;  // a head is above the camera
        const double z = rise / dY, X = z * xn, D = z * (c - yn * sn);
        const CameraPose& q = truth[f];
        const double Xw = q.X_m + X * std::cos(q.yaw_rad) + D * std::sin(q.yaw_rad), Dw = q.D_m - X * std::sin(q.yaw_rad) + D * std::cos(q.yaw_rad);
        double off, along;
        synthetic_street_coordinates(o, Xw, Dw, &off, &along);
        const double err = std::fabs(std::fabs(off) - row);
        ++frame_heads;
        frame_worst = std::max(frame_worst, err);
        const double tol = step * step / (2 * R) + pose_err + kerb_err + 0.5 * z / g.f_px * (1 + z / rise);
        frame_off += err > tol;
        if (on_circle || (on_straight && along <= Dc)) {
          EXPECT_LE(err, tol) << "frame " << f << ": lamp head at (" << b.u << ", " << b.v << ") stands " << off
                              << " m across the street, " << along << " m along it";
          ++asserted;
          ++frame_asserted;
          worst_asserted = std::max(worst_asserted, err);
        }
      }
      heads += frame_heads;
      // On the circle the outer row (a luminaire every S = 30 m, 7.5 m outside the centre line) is in
      // view from 20 m ahead (the image's top edge, 24° above the axis: rise / tan 24°) to beyond
      // 50 m (a sight line to it 50 m ahead passes 99.5 m from the circle's centre, clear of the
      // inner façade at 90 m), more than a spacing: at least one head is seen.
      if (on_circle) EXPECT_GE(frame_asserted, 1) << "frame " << f << ": no lamp head beside the road in view";
      by_frame += fmt::format(" {}: {} heads, {} off, worst {:.2f} m;", f, frame_heads, frame_off, frame_worst);
    }
    std::fprintf(stderr, "[curving street] turning %s on R = %g m from %g m: pitch %.5f rad (the renderer's %.5f), photosite's kerbs "
                 "off by %.2f m, odometry off by %.3f m; %d lamp heads, %d asserted (worst %.3f m off the kerb + setback, bound "
                 "h²/(2R) + those + half a pixel); by frame:%s\n",
                 sigma > 0 ? "right" : "left", R, Dc, pitch0, o.camera.pitch_rad, kerb_err, pose_err, heads, asserted,
                 worst_asserted, by_frame.c_str());
  }
}

// A single frame on a curving street (issue 14 §2: the urban preset's luminaires along the road
// edges in ground coordinates): the street of the tests above curving on R = 100 m from 0, 20 or
// 40 m ahead, either way, planned with the renderer's own camera (plan_street_lighting). Every
// road-edge luminaire up to lamp_max_distance_m ahead must stand at its kerb's 7 m plus the setback
// across the street's centre line (synthetic_street_coordinates), within the fitted kerb's 5
// standard errors at its distance along the road (road_ahead_kerb_se_m) plus the start grid's half
// metre turned by the arc (|κ|·(a − c)·0.5 m). Straight rows at the kerbs' medians (main's rows
// before the fit: the state "straight" forced) stand off the curve by up to (a − c)²/(2R) there.
TEST(RoadAhead, SingleFrameLayoutFollowsTheCurve) {
  const ScenePreset p = urban();
  const double R = 100;
  for (const double sigma : {1.0, -1.0})
    for (const double start : {0.0, 20.0, 40.0}) {
      SCOPED_TRACE(::testing::Message() << "R " << sigma * R << ", start " << start);
      SyntheticCameraOptions o = camera_scene();
      o.boxes.clear();
      o.road_radius_m = sigma * R;
      o.curve_start_D_m = start;
      const SyntheticCameraScene sc = make_synthetic_camera_scene(o);
      const StreetLighting plan = plan_street_lighting(sc.labels, o.camera, p, 3);
      ASSERT_EQ(plan.road_ahead.state, "curved");
      const RoadAhead& ra = plan.road_ahead;
      const double row = o.road_half_width_m + p.lamp_setback_m;
      int checked = 0;
      double worst = 0, worst_straight = 0;
      int straight_off = 0;
      for (const StreetLamp& l : plan.lamps) {
        if (l.from_pole || l.D_m < 0) continue;
        double off, along;
        synthetic_street_coordinates(o, l.X_m, l.D_m, &off, &along);
        const bool right = off > 0;
        const double err = std::fabs(std::fabs(off) - row);
        const double tol = 5 * road_ahead_kerb_se_m(ra, along, right) + std::fabs(ra.kappa_per_m) * std::max(0.0, along - ra.curve_start_m) * 0.5;
        EXPECT_LE(err, tol) << "luminaire at (" << l.X_m << ", " << l.D_m << "): " << off << " m across the street, " << along << " m along it";
        worst = std::max(worst, err);
        ++checked;
      }
      // The same layout with the bend not followed: straight rows at the kerbs' medians.
      {
        const double S = p.lamp_spacing_ratio * p.lamp_mount_height_m, phase = street_layout_phase_m(p, 3);
        for (int k = 0; k * S <= p.lamp_max_distance_m; ++k)
          for (const bool right : {true, false}) {
            const double X = right ? plan.road_right_m + p.lamp_setback_m : plan.road_left_m - p.lamp_setback_m;
            double off, along;
            synthetic_street_coordinates(o, X, phase + k * S + (right ? 0 : 0.5 * S), &off, &along);
            const double err = std::fabs(std::fabs(off) - row);
            worst_straight = std::max(worst_straight, err);
            straight_off += err > 5 * road_ahead_kerb_se_m(ra, along, right) + std::fabs(ra.kappa_per_m) * std::max(0.0, along - ra.curve_start_m) * 0.5;
          }
      }
      EXPECT_GE(checked, 8);
      EXPECT_GT(straight_off, 0);  // the straight rows fail the same bound
      std::fprintf(stderr, "[curve single frame] R %g from %g m: %d road-edge luminaires ahead, at most %.3f m off the kerb + setback "
                   "(straight rows at the medians %.2f / %.2f m: up to %.1f m off, %d beyond the bound)\n", sigma * R, start, checked, worst,
                   plan.road_left_m, plan.road_right_m, worst_straight, straight_off);
    }
}

// Lamp heads behind what stands in front of them (issue 14 §2: a luminaire behind a building does
// not glow on its façade; scene/street.cpp head_hidden). The synthetic street, straight and
// curving (R = ±100 m from 58.5 m, as the test above), the camera on the straight at D = 0 and
// 30 m; the luminaires of two straight rows at X = ±(7 m + setback), 10 m mount, one every 10 m
// from 5 to 300 m ahead: on the straight street all stand in front of the façades at ±10 m, on the
// curve those beyond the bend stand behind its façades (the layout's rows before they follow a
// curve). Each head in the frame is drawn alone on black with the depth the chain has (metric_depth
// of the labels: an estimate) and without depth: its footprint F, each pixel weighted by its drawn
// share. Judged against the TRUE depth (make_synthetic_camera_scene's ray casting):
// * a head whose F lies more than half on pixels whose true surface is in front of it by more than
//   2·δz, δz = z²·cos θ·1.5 px/(f·h), must not be drawn: one δz is the rule's own margin (the depth
//   of a contact row off by kFacadeInlier_px = 1.5 px), one the estimate's error within that band,
//   so such a pixel is in front by more than the margin in the estimate too;
// * a head with no true surface in front of it anywhere on F must be drawn whole (the estimate
//   within δz of the truth: it is not put in front by more than the margin).
// Heads in between are counted, not judged. light_map's row pass (add_street_light_rows with a row
// hook) must draw as many heads of the whole set as the heads drawn alone. On main before this
// rule every head was drawn: the hidden ones failed here.
TEST(StreetLighting, HeadsBehindAFacadeAreHiddenAndHeadsInClearViewDrawn) {
  const ScenePreset p = urban();
  const double row = 7 + p.lamp_setback_m, Hm = p.lamp_mount_height_m;
  int hidden_judged = 0, clear_judged = 0, between = 0;
  for (const double R : {0.0, 100.0, -100.0})
    for (const double D_cam : {0.0, 30.0}) {
      SCOPED_TRACE(fmt::format("R {} m, camera at D {} m", R, D_cam));
      SyntheticCameraOptions o = camera_scene();
      o.boxes.clear();
      o.road_radius_m = R;
      o.curve_start_D_m = R != 0 ? 58.5 : 0;
      o.world_D_m = D_cam;
      const SyntheticCameraScene sc = make_synthetic_camera_scene(o);
      const CameraGeometry& g = o.camera;
      const ImageF depth = metric_depth(sc.labels, g, p.max_depth_m);
      const ImageF black(o.width, o.height, 3, 0.f);
      StreetLighting all;
      all.road_left_m = -7;
      all.road_right_m = 7;
      all.peak_intensity_cd = 5000;
      const double kz = std::cos(g.pitch_rad) * kFacadeInlier_px / (g.f_px * g.mount_height_m);
      int drawn_alone = 0, scene_hidden = 0, scene_clear = 0;
      StreetLamp first_hidden{};
      double worst_est = 0;  // the estimate's largest error over the judged footprints, in δz
      for (double Dw = 5; Dw <= 300; Dw += 10)
        for (const double side : {-1.0, 1.0}) {
          const StreetLamp lamp{side * row, Hm, Dw - D_cam, false};
          double u, v, z;
          if (!g.project(lamp.X_m, lamp.Y_m, lamp.D_m, &u, &v, &z)) continue;
          if (u < -8 || v < -8 || u > o.width + 8 || v > o.height + 8) continue;
          StreetLighting one = all;
          one.lamps = {lamp};
          ImageF F(o.width, o.height, 3, 0.f, unit::radiance), with(o.width, o.height, 3, 0.f, unit::radiance);
          if (add_street_lighting(F, black, sc.labels.ids, g, one, p) == 0) continue;  // not in the frame
          const int drawn = add_street_lighting(with, black, sc.labels.ids, g, one, p, &depth);
          all.lamps.push_back(lamp);
          drawn_alone += drawn;
          double w = 0, w_front = 0, w_any_front = 0, est_err = 0;
          bool same = true;
          for (int y = 0; y < o.height; ++y)
            for (int x = 0; x < o.width; ++x) {
              const double f = F.at(x, y, 1);
              if (!(f > 0)) continue;
              const double zt = sc.depth_m.at(x, y), dz = kz * zt * zt;
              w += f;
              if (zt + 2 * dz < z) w_front += f;
              if (zt < z) w_any_front += f;
              if (zt < 1000) est_err = std::max(est_err, std::fabs(depth.at(x, y) - zt) / dz);
              same = same && with.at(x, y, 1) == f;
            }
          if (2 * w_front > w) {
            if (scene_hidden == 0) first_hidden = lamp;
            ++hidden_judged, ++scene_hidden;
            worst_est = std::max(worst_est, est_err);
            EXPECT_EQ(drawn, 0) << "a head at (" << u << ", " << v << "), " << z << " m deep, is drawn with "
                                << 100 * w_front / w << "% of it behind a surface in front of it (lamp X " << lamp.X_m
                                << " m, D " << lamp.D_m << " m)";
          } else if (w_any_front == 0) {
            ++clear_judged, ++scene_clear;
            worst_est = std::max(worst_est, est_err);
            EXPECT_EQ(drawn, 1) << "a head in clear view at (" << u << ", " << v << "), " << z << " m deep, is not drawn";
            EXPECT_TRUE(same) << "a head in clear view at (" << u << ", " << v << ") is not drawn whole";
          } else {
            ++between;
          }
        }
      // light_map's row pass draws the heads inside it (a row hook given): the same heads.
      ImageF L(o.width, o.height, 3, 0.f, unit::radiance);
      const std::function<void(int)> hook = [](int) {};
      const StreetRowsResult r = add_street_light_rows(L, black, sc.labels.ids, depth, g, all, p, 3, nullptr, nullptr, &hook);
      EXPECT_EQ(r.pole_lamps, drawn_alone);
      std::fprintf(stderr, "[heads hidden] R %g m, camera at D %g m: %zu heads in the frame, %d drawn (row pass %d); "
                   "judged hidden %d, in clear view %d; the depth estimate's worst error on them %.2f dz\n",
                   R, D_cam, all.lamps.size(), drawn_alone, r.pole_lamps, scene_hidden, scene_clear, worst_est);
      // On the straight street every luminaire stands before the façades (7.5 m against 10 m across).
      if (R == 0) EXPECT_EQ(scene_hidden, 0);
      // On the curve the outer row's lamps from about 105 m ahead on (95 m for the camera 30 m on)
      // stand behind the outer façade: a sight line to them meets that cylinder, 110 m from the
      // circle's centre, below its 12 m top and 87-98 m deep (58-70 m), 18-197 m in front of the
      // head against 2·δz = 16-21 m (7-11 m) there (f 1131 px, h 1.22 m; the sight lines
      // from the pinhole to the cylinder, pitch neglected). Both kinds are judged in every scene.
      else EXPECT_GE(scene_hidden, 1);
      EXPECT_GE(scene_clear, 1);
      // A pole's own luminaire whose pole the labels show reaching up to it is in view whatever the
      // depth around it (the labels are the photo's word that the sight line is clear): the first
      // hidden head as a detected pole's, a pole painted into the labels from its centre's row 20 px
      // down its column (the depth left as it was), is drawn; as a layout luminaire it stays hidden.
      if (scene_hidden > 0) {
        double u, v;
        ASSERT_TRUE(g.project(first_hidden.X_m, first_hidden.Y_m, first_hidden.D_m, &u, &v, nullptr));
        ImageU16 poled = sc.labels.ids;
        const int xc = static_cast<int>(std::lround(u)), yc = static_cast<int>(std::lround(v));
        ASSERT_TRUE(xc >= 0 && xc < o.width && yc >= 0 && yc + 20 < o.height);
        for (int y = yc; y <= yc + 20; ++y) poled.at(xc, y) = static_cast<uint16_t>(Label::Pole);
        for (const bool pole : {true, false}) {
          StreetLighting one = all;
          one.lamps = {{first_hidden.X_m, first_hidden.Y_m, first_hidden.D_m, pole}};
          ImageF out(o.width, o.height, 3, 0.f, unit::radiance);
          EXPECT_EQ(add_street_lighting(out, black, poled, g, one, p, &depth), pole ? 1 : 0)
              << (pole ? "a pole's luminaire on its labelled pole" : "a layout luminaire") << " at (" << u << ", " << v << ")";
        }
      }
    }
  std::fprintf(stderr, "[heads hidden] judged hidden %d, in clear view %d, between %d\n", hidden_judged, clear_judged, between);
}

// Every vector level gives a moving sequence the same bits. SceneNightCli.EveryIsaCapGivesTheSameNight
// checks a single frame, at pose 0, where the window kernels' per-plane offset along the façade
// (FacadeFrame::s0, scene/street.cpp) is 0 and the planes are not turned. Here the turning street
// of the test above (9 m and 2.9° a frame) is run as a sequence at each PHOTOSITE_MAX_ISA level
// this machine has: the scalar, AVX2 and AVX-512 window rows then add non-zero s0 to turned façade
// coordinates, and every channel of every frame (lights and depth) must be the same bits.
TEST(Luminaires, EveryIsaCapGivesTheSameTurningSequence) {
  const int n = 3;
  test::TempDir dir;
  const std::vector<LabelMap> labels = write_turning_street(dir.path() / "drive", n).labels;
  const auto machine = test::run_cli("version --backends");
  ASSERT_EQ(machine.exit_code, 0) << machine.output;
  std::vector<std::string> caps = {"scalar"};
  if (machine.output.find(", AVX2") != std::string::npos) caps.push_back("avx2");
  if (machine.output.find(", AVX-512") != std::string::npos) caps.push_back("avx512");
  std::string names;
  for (const auto& c : caps) names += (names.empty() ? "" : ", ") + c;
  std::fprintf(stderr, "[isa sequence] levels compared: %zu (%s)\n", caps.size(), names.c_str());
  std::vector<std::vector<ExrContents>> runs;
  for (const std::string& cap : caps) {
    setenv("PHOTOSITE_MAX_ISA", cap.c_str(), 1);
    const std::string out = dir.file("out_" + cap);
    const auto r = test::run_cli("batch --dataset kitti --root '" + (dir.path() / "drive").string() + "' --out '" + out +
                                 "' --rig cityscapes --layers lights,depth --quiet --seed 3 --device-store '" +
                                 dir.file("store") + "' --sequence --ego-motion auto");
    unsetenv("PHOTOSITE_MAX_ISA");
    ASSERT_EQ(r.exit_code, 0) << "PHOTOSITE_MAX_ISA=" << cap << ": " << r.output;
    std::vector<ExrContents> frames;
    for (int f = 0; f < n; ++f) frames.push_back(read_exr(out + fmt::format("/image_2/drive/{:010d}.exr", f)));
    runs.push_back(std::move(frames));
  }
  // The windows' light is there to compare: frame 2 (turned 0.1 rad, 18 m on) has lit panes.
  double windows = 0;
  const ImageF& lights2 = runs[0][2].channels.at("lights.G");
  for (int y = 0; y < lights2.height(); ++y)
    for (int x = 0; x < lights2.width(); ++x)
      if (labels[2].ids.at(x, y) == static_cast<uint16_t>(Label::Building)) windows += lights2.at(x, y);
  EXPECT_GT(windows, 0.0);
  for (size_t c = 1; c < runs.size(); ++c)
    for (int f = 0; f < n; ++f) {
      ASSERT_EQ(runs[c][f].channels.size(), runs[0][f].channels.size());
      for (const auto& [name, img] : runs[0][f].channels) {
        const ImageF& other = runs[c][f].channels.at(name);
        ASSERT_EQ(other.size(), img.size());
        size_t differ = 0;
        for (size_t k = 0; k < img.size(); ++k) differ += std::memcmp(&img[k], &other[k], sizeof(float)) != 0;
        EXPECT_EQ(differ, 0u) << "frame " << f << ", " << name << ": " << caps[c] << " against scalar";
      }
    }
}

// A manifest's own odometry (read_manifest's key=value fields, include/photosite/batch.h): the
// turning street's three frames listed in a manifest with sequence=, time_s, speed_m_s and
// yaw_rate_rad_s (the values of its OXTS records and timestamps) give each frame the pose the
// KITTI layout's OXTS records give it, to the bit (the same samples into advance_pose: 0.5 s, 18
// m/s, 0.1 rad/s, the camera at the odometry's reference point in both). The lines are listed out
// of order between another sequence's (frames in line order per sequence). Bad lines are refused
// before any work, naming the line.
TEST(Luminaires, ManifestSequenceFollowsItsOdometryFields) {
  const int n = 3;
  test::TempDir dir;
  const auto root = dir.path() / "drive";
  write_turning_street(root, n);
  std::filesystem::copy_file(root / "image_2/drive/0000000000.png", root / "x.png");
  std::filesystem::copy_file(root / "semantic/drive/0000000000.png", root / "x_labels.png");
  auto line = [](int f, const std::string& extra) {
    return fmt::format("image_2/drive/{0:010d}.png semantic/drive/{0:010d}.png {1}\n", f, extra);
  };
  auto odo = [](int f) { return fmt::format("sequence=turn time_s={} speed_m_s=18 yaw_rate_rad_s=0.1", 25 + 0.5 * f); };
  // Sequence "turn": frames 0, 1, 2 in line order, another sequence's line between them.
  std::ofstream(root / "m.txt") << "# a video's frames\n" << line(0, odo(0)) << "x.png x_labels.png sequence=other\n"
                                << line(1, odo(1)) << line(2, odo(2));
  auto run = [&](const std::string& args) {
    return test::run_cli("batch " + args + " --rig cityscapes --layers lights --quiet --seed 3 --device-store '" +
                         dir.file("store") + "'");
  };
  const auto m = run("--manifest '" + (root / "m.txt").string() + "' --out '" + dir.file("out_m") + "' --sequence");
  ASSERT_EQ(m.exit_code, 0) << m.output;
  const auto k = run("--dataset kitti --root '" + root.string() + "' --out '" + dir.file("out_k") + "' --sequence");
  ASSERT_EQ(k.exit_code, 0) << k.output;
  for (int f = 0; f < n; ++f) {
    const auto am = read_exr_attributes(dir.file("out_m") + fmt::format("/image_2/drive/{:010d}.exr", f));
    const auto ak = read_exr_attributes(dir.file("out_k") + fmt::format("/image_2/drive/{:010d}.exr", f));
    for (const char* key : {"photosite/batch/pose_X_m_text", "photosite/batch/pose_D_m_text", "photosite/batch/pose_yaw_rad_text"})
      EXPECT_EQ(am.at(key), ak.at(key)) << "frame " << f << " " << key;
    EXPECT_EQ(am.at("photosite/batch/group"), "sequence:turn");
    EXPECT_NE(am.at("photosite/batch/camera_mount").find("m.txt:"), std::string::npos) << am.at("photosite/batch/camera_mount");
    if (f > 0) EXPECT_GT(std::stod(am.at("photosite/batch/pose_D_m_text")), 8.0 * f) << f;  // 9 m a frame
  }
  // The other sequence has no odometry: no pose in its header.
  EXPECT_EQ(read_exr_attributes(dir.file("out_m") + "/x.exr").count("photosite/batch/pose_D_m_text"), 0u);
  // Resumed: nothing to do. A frame's odometry edited: its sequence is redone whole (3 frames), the
  // other sequence not (the item's record keeps its fields, core/batch_run.cpp).
  auto resume = [&] {
    return test::run_cli("batch --manifest '" + (root / "m.txt").string() + "' --out '" + dir.file("out_m") +
                         "' --sequence --rig cityscapes --layers lights --seed 3 --device-store '" + dir.file("store") + "'");
  };
  const auto again = resume();
  ASSERT_EQ(again.exit_code, 0) << again.output;
  EXPECT_NE(again.output.find("4 already done, 0 to do"), std::string::npos) << again.output;
  std::ofstream(root / "m.txt") << line(0, odo(0)) << "x.png x_labels.png sequence=other\n"
                                << line(1, "sequence=turn time_s=25.5 speed_m_s=17 yaw_rate_rad_s=0.1") << line(2, odo(2));
  const auto edited = resume();
  ASSERT_EQ(edited.exit_code, 0) << edited.output;
  EXPECT_NE(edited.output.find("1 already done, 3 to do"), std::string::npos) << edited.output;
  // With --ego-motion none the same manifest takes every frame at pose 0 (no pose recorded).
  const auto none = run("--manifest '" + (root / "m.txt").string() + "' --out '" + dir.file("out_none") + "' --sequence --ego-motion none");
  ASSERT_EQ(none.exit_code, 0) << none.output;
  EXPECT_EQ(read_exr_attributes(dir.file("out_none") + "/image_2/drive/0000000002.exr").count("photosite/batch/pose_D_m_text"), 0u);

  // Bad lines: exit 2 naming the line, nothing written.
  const std::vector<std::pair<std::string, std::string>> bad = {
      {line(1, odo(1)) + line(0, odo(0)), "m_bad.txt:2: sequence turn: time_s is not after the previous line's ("},
      {line(0, odo(0)) + line(1, "sequence=turn"), "m_bad.txt:2: sequence turn has no odometry on this line but has on "},
      {line(0, "sequence=turn time_s=1 speed_m_s=3"), "m_bad.txt:1: yaw_rate_rad_s missing"},
      {line(0, "sequence=turn time_s=1 speed_m_s=200 yaw_rate_rad_s=0"), "speed_m_s: 200 m/s is outside [-100, 100]"},
      {line(0, "sequence=turn time_s=1s speed_m_s=1 yaw_rate_rad_s=0"), "m_bad.txt:1: time_s=1s: not a number"},
      {line(0, "sequence=turn camera_left_m=0.3"), "give time_s, speed_m_s and yaw_rate_rad_s too"},
      {line(0, "sequence=turn sequence=b"), "m_bad.txt:1: sequence given twice"},
      {line(0, "sequnce=turn"), "m_bad.txt:1: unknown field key 'sequnce'"},
      {line(0, "sequence="), "m_bad.txt:1: sequence= names no sequence"},
      {"sequence=turn " + line(0, ""), "m_bad.txt:1: 'image_2/drive/0000000000.png' after the key=value fields"},
  };
  for (const auto& [text, want] : bad) {
    std::ofstream(root / "m_bad.txt") << text;
    const std::string out = dir.file("out_bad");
    const auto r = run("--manifest '" + (root / "m_bad.txt").string() + "' --out '" + out + "' --sequence");
    EXPECT_EQ(r.exit_code, 2) << text << r.output;
    EXPECT_NE(r.output.find(want), std::string::npos) << text << "\n" << r.output;
    EXPECT_FALSE(std::filesystem::exists(out + "/image_2")) << text;
  }
}

// The ego low beam projected onto the metric ground (scene/lights.cpp low_beam_illuminance), on
// the synthetic camera scene without boxes (the centre line free to the horizon).
namespace {
// The preset's table read independently of the code: bilinear between the grid points, 0
// above the cut-off line and outside the table.
double table_cd(const ScenePreset& p, double h, double v) {
  const double cut = std::min(p.beam_cutoff_max_v_deg,
                              p.beam_cutoff_v_deg + std::max(0.0, h) * std::tan(p.beam_cutoff_rise_deg * M_PI / 180));
  const auto &H = p.beam_h_deg, &V = p.beam_v_deg;
  if (v > cut || h < H.front() || h > H.back() || v < V.front() || v > V.back()) return 0;
  size_t j = 0, i = 0;
  while (j + 2 < H.size() && h >= H[j + 1]) ++j;
  while (i + 2 < V.size() && v >= V[i + 1]) ++i;
  const double a = (h - H[j]) / (H[j + 1] - H[j]), b = (v - V[i]) / (V[i + 1] - V[i]);
  auto I = [&](size_t r, size_t c) { return p.beam_intensity_cd[r * H.size() + c]; };
  return (1 - a) * (1 - b) * I(i, j) + a * (1 - b) * I(i, j + 1) + (1 - a) * b * I(i + 1, j) + a * b * I(i + 1, j + 1);
}
// The table's largest slopes S_h, S_v (cd/°, between neighbouring grid points) and its largest
// |grid angles| A_h, A_v (°): the float evaluations' error bounds read them.
std::array<double, 4> table_slopes(const ScenePreset& p) {
  const auto &Hg = p.beam_h_deg, &Vg = p.beam_v_deg;
  double S_h = 0, S_v = 0, A_h = 0, A_v = 0;
  for (size_t i = 0; i < Vg.size(); ++i)
    for (size_t j = 0; j < Hg.size(); ++j) {
      const double I = p.beam_intensity_cd[i * Hg.size() + j];
      if (j + 1 < Hg.size()) S_h = std::max(S_h, std::fabs(p.beam_intensity_cd[i * Hg.size() + j + 1] - I) / (Hg[j + 1] - Hg[j]));
      if (i + 1 < Vg.size()) S_v = std::max(S_v, std::fabs(p.beam_intensity_cd[(i + 1) * Hg.size() + j] - I) / (Vg[i + 1] - Vg[i]));
    }
  for (double a : Hg) A_h = std::max(A_h, std::fabs(a));
  for (double a : Vg) A_v = std::max(A_v, std::fabs(a));
  return {S_h, S_v, A_h, A_v};
}
// The synthetic camera scene without boxes (the centre line free to the horizon); o its options.
SyntheticCameraScene free_road(SyntheticCameraOptions& o) {
  o = camera_scene();
  o.boxes.clear();
  return make_synthetic_camera_scene(o);
}
// One headlamp's E = I(h, v)·cos θ/d² at a ground point dx to the right of the lamp and D ahead of
// it in the lamp's own frame (the double reference: atan2, the table read by table_cd), with the
// bound of the float evaluation's error derived above EgoLowBeam.TableProjectedOntoTheMetricGround
// (X and x_l: the ground point's and the lamp's X as the float code rounds them, |Δdx| ≤ u·(|X| +
// |x_l| + |dx|)), and whether (h, v) lies within that error of a discontinuity of I.
struct LampRef {
  double E = 0, bound = 0;
  bool lit = false, near_edge = false;
};
struct BeamRef {
  const ScenePreset& p;
  const double u = std::ldexp(1.0, -24), rise = std::tan(p.beam_cutoff_rise_deg * M_PI / 180);
  const std::array<double, 4> slopes = table_slopes(p);  // S_h, S_v, A_h, A_v
  LampRef lamp(double X, double xl, double dx, double D, double hl) const {
    const auto [S_h, S_v, A_h, A_v] = slopes;
    const auto &Hg = p.beam_h_deg, &Vg = p.beam_v_deg;
    const double d2 = dx * dx + D * D + hl * hl;
    const double h = std::atan2(dx, D) * 180 / M_PI, v = -std::atan2(hl, std::hypot(dx, D)) * 180 / M_PI;
    const double ddx = u * (std::fabs(X) + std::fabs(xl) + std::fabs(dx));
    const double dh = 180 / M_PI * ddx / D + 9 * u * std::fabs(h) + 12 * u * A_h;
    const double dv = std::fabs(v) * (ddx / D + 11 * u) + 12 * u * A_v;
    const double cut = std::min(p.beam_cutoff_max_v_deg, p.beam_cutoff_v_deg + std::max(0.0, h) * rise);
    const double dcut = dv + rise * dh +
                        4 * u * (std::fabs(p.beam_cutoff_v_deg) + std::fabs(p.beam_cutoff_max_v_deg) + std::fabs(h) * rise);
    LampRef r;
    r.near_edge = std::fabs(v - cut) <= dcut || std::fabs(h - Hg.front()) <= dh || std::fabs(h - Hg.back()) <= dh ||
                  std::fabs(v - Vg.front()) <= dv || std::fabs(v - Vg.back()) <= dv;
    const double I = table_cd(p, h, v), w = (hl / std::sqrt(d2)) / d2;
    r.lit = I > 0;
    r.E = I * w;
    r.bound = (21 * u + 3 * ddx / D) * I * w + w * (S_h * dh + S_v * dv);
    return r;
  }
};
}  // namespace

// E at a pixel = Σ over the two lamps (±spacing/2, h_l, 0) of I(h, v)·cos θ/d² for its ground point
// (X, D); the reference here in double (atan2, the table read independently). The image evaluates
// it in float (lights.cpp) and must equal low_beam_lux_f32 at the pixel's ground point bit for bit.
// Its error against the double reference, to first order in u = 2⁻²⁴ (each IEEE float operation
// and each rounding of an input to float rel. ≤ u; Cephes' atanf rel. ≤ 1.9e-7 < 4u, its stated
// peak), per lamp with dx = X − x_l, horiz = √(dx² + D²) ≥ D:
//   the inputs: |Δdx| ≤ u·(|X| + |x_l| + |dx|)      (X, x_l rounded to float, the subtraction)
//   h = atan(dx·(1/D))·(180/π): the argument rel. Δdx/dx + 3u (D, 1/D, ×), atan' = 1/(1 + q²) ≤ atan(q)/q,
//     so δh ≤ (180/π)·|Δdx|/D + (3u + 4u + 2u)·|h|                  (2u: 180/π and ×)
//   v = −atan(h_l/horiz)·(180/π): horiz² rel. ≤ 2|Δdx|/horiz + 4u (dx², D², +), horiz rel. ≤ |Δdx|/horiz + 3u,
//     the argument + 2u (h_l, ÷), so δv ≤ |v|·(|Δdx|/D + 11u)
//   the grid: angles rounded to float (≤ u·A, A the largest |grid angle|), the weight a = (h − H_j)·fl(1/(H_j+1 − H_j))
//     off by ≤ (1 + 2 + 3·2)u·A in angle (h − H_j, 1/Δ, ×, the rounded nodes in Δ): δ += 12u·A per axis
//   I (bilinear, nonnegative weights and values): rel. ≤ 7u (4 weights' 1 − a, 2 levels of × and +, the table's
//     rounding) at the float angles; the angles' error moves it by ≤ S_h·δh + S_v·δv, S the table's largest slopes
//   cos θ/d² = h_l/(d²·d): d² rel. ≤ 2|Δdx|/D + 5u, d² · √d² rel. ≤ 1.5× that + 2u, ÷ and h_l 2u: ≤ 3|Δdx|/D + 12u
//   I·w and the sum of the two (nonnegative) lamps: 2u.
// So |E_f − E| ≤ Σ_lamps [(21u + 3|Δdx|/D)·I·w + w·(S_h·δh + S_v·δv)]·(1 + 1e-6), the factor for the second-order
// terms (u² ~ 1e-14) and the double reference's own rounding (~1e-15). A lamp whose (h, v) lies within the
// angles' error of a discontinuity of I (the cut-off v = min(v_max, v_c + max(0, h)·tan rise), moved by
// tan rise·δh and the float cut-off's rounding 4u·(|v_c| + |v_max| + |h|·tan rise), or the table's edges
// h = H_0, H_n, v = V_0, V_n) may be lit in one evaluation and 0 in the other: those pixels are excluded and
// counted (the band is ~1e-5° wide against a pixel pitch of 1/f rad ≈ 0.05°: a small fraction). Elsewhere
// above the cut-off (for both lamps) exactly 0, and 0 above the horizon. The beam's road luminance ρE/π along
// the centre line (the column under the principal point) peaks 20-40 m ahead (issue 14 §2).
TEST(EgoLowBeam, TableProjectedOntoTheMetricGround) {
  SyntheticCameraOptions o;
  const SyntheticCameraScene s = free_road(o);
  const ScenePreset p = urban();
  const CameraGeometry& g = o.camera;
  const ImageF E = low_beam_illuminance(g, o.width, o.height, p);
  const double hl = p.beam_lamp_height_m;
  const BeamRef ref{p};
  int checked = 0, beyond_cutoff = 0, band = 0;
  double worst = 0;  // the largest |E_f − E| / bound seen
  const int xc = static_cast<int>(std::lround(g.cx_px));
  std::vector<double> centre_ref(o.height, -1), centre_bound(o.height, 0);  // the centre column's E and bound
  for (int y = 0; y < o.height; ++y)
    for (int x = 0; x < o.width; ++x) {
      double X, D, z;
      if (!g.ground_point(x, y, &X, &D, &z)) {
        ASSERT_EQ(E.at(x, y), 0.f) << x << "," << y;
        continue;
      }
      // The image's per-row evaluation (D and t once per row, 8 pixels a vector) gives the
      // float point function's bits at the pixel's ground point.
      ASSERT_EQ(E.at(x, y), low_beam_lux_f32(X, D, p)) << x << "," << y;
      double expect = 0, bound = 0;
      bool lit = false, near_edge = false;
      for (double xl : {-0.5 * p.beam_lamp_spacing_m, 0.5 * p.beam_lamp_spacing_m}) {
        const LampRef r = ref.lamp(X, xl, X - xl, D, hl);
        near_edge = near_edge || r.near_edge;
        lit = lit || r.lit;
        expect += r.E;
        bound += r.bound;
      }
      bound *= 1 + 1e-6;
      if (near_edge) {
        ++band;
        continue;
      }
      if (x == xc) centre_ref[y] = expect, centre_bound[y] = bound;
      if (!lit) {
        ++beyond_cutoff;
        ASSERT_EQ(E.at(x, y), 0.f) << x << "," << y << " D " << D;
      } else {
        ASSERT_NEAR(E.at(x, y), expect, bound) << x << "," << y << " D " << D;
        worst = std::max(worst, std::fabs(E.at(x, y) - expect) / bound);
        ++checked;
      }
    }
  std::fprintf(stderr, "[beam] float image vs double reference: %d lit pixels within the derived bound (largest "
               "error/bound %.3f), %d dark, %d in the cut-off/edge band\n", checked, worst, beyond_cutoff, band);
  EXPECT_GT(checked, 10000);
  EXPECT_GT(beyond_cutoff, 1000);  // the far road beyond the cut-off is dark: a visible cut-off
  EXPECT_LT(band, checked / 100);  // the band is a small fraction (above)
  // Set depths on the centre line: the image's brightest road row is the table's, i.e. its
  // reference E (the table read independently, above) is within the two rows' bounds of the
  // largest reference E of the column (each image value within its bound of its reference).
  double best = -1, best_D = 0, ref_max = -1, ref_max_bound = 0;
  int best_y = -1;
  for (int y = 0; y < o.height; ++y) {
    double X, D, z;
    if (s.labels.ids.at(xc, y) != static_cast<int>(Label::Road) || !g.ground_point(xc, y, &X, &D, &z) || centre_ref[y] < 0)
      continue;
    const double L = p.rho_road * E.at(xc, y) / M_PI;
    if (L > best) best = L, best_D = D, best_y = y;
    if (centre_ref[y] > ref_max) ref_max = centre_ref[y], ref_max_bound = centre_bound[y];
  }
  std::fprintf(stderr, "[beam] centre-line road luminance from the low beam peaks at %.1f m: %.4f cd/m² (E %.3f lx)\n",
               best_D, best, best * M_PI / p.rho_road);
  ASSERT_GE(best_y, 0);
  EXPECT_GE(centre_ref[best_y], ref_max - (centre_bound[best_y] + ref_max_bound)) << "row " << best_y;
  // The chain uses the same values wherever they are read (ground classes, lane markings) and
  // computes none elsewhere.
  ScenePreset pc = p;
  pc.rig = load_camera_rig("cityscapes");
  const NightScene n = night_scene(s.day_linear_srgb, s.labels, pc, 1);
  ImageF En = low_beam_illuminance(n.geometry, o.width, o.height, pc);
  // and shades them where a solid object hides a lamp (shade_low_beam_ground). On this street only
  // the façades could, and they hide no lamp from the road: their feet run along it (the
  // margin's case) and end 200 m ahead, where the ground beside a façade's end may share a cell
  // with it (an edge placed to within a cell): every shaded pixel lies beyond 190 m.
  const ImageF En_unshaded = En;
  shade_low_beam_ground(En, n.geometry, s.labels.ids, n.depth, pc);
  int shaded = 0;
  for (int y = 0; y < o.height; ++y)
    for (int x = 0; x < o.width; ++x) {
      if (En.at(x, y) == En_unshaded.at(x, y)) continue;
      double X, D, z;
      ASSERT_TRUE(n.geometry.ground_point(x, y, &X, &D, &z));
      EXPECT_GT(D, 190) << x << "," << y;
      ++shaded;
    }
  std::fprintf(stderr, "[beam] %d ground pixels shaded, all beyond 190 m\n", shaded);
  ASSERT_EQ(n.beam_lux.size(), En.size());
  size_t read = 0;
  for (size_t i = 0; i < En.size(); ++i) {
    if (is_ground(s.labels.ids[i])) {
      ++read;
      EXPECT_EQ(n.beam_lux[i], En[i]) << i;
    }
  }
  EXPECT_GT(read, En.size() / 4);  // the ground is a large part of a road scene
}

// The ego low beam's rows (LowBeamRows: AVX2 blocks of eight, the lit test and the arctangents'
// reduction test skipped inside LowBeamRows::sure_columns, the scalar tail; the scalar loop) at
// every instruction-set cap (beam_max_isa 2, 1, 0) are low_beam_lux_f32 at each pixel's ground
// point bit for bit, 0 off the ground classes (labels with runs of ground, other and unknown ids,
// so that blocks are whole, mixed and empty) and at and above the horizon. The cameras put every
// bound of the sure columns inside some image: odd widths (blocks and tails, widths 1 to 17),
// rows right below the horizon (the far road beyond the cut-off: no sure columns), a wide field of
// view (|h| beyond tan⁻¹ of the reduction's tan(π/8) and beyond the table's ±25°), a high, steep
// camera (the near rows' v below the table's −10°). The sure columns must occur, whole rows and
// rows where they end inside the row, so that the skipped path is the one checked.
TEST(EgoLowBeam, RowsAreThePointFunctionAtEveryIsa) {
  const ScenePreset p = urban();
  struct Cam {
    int w, h;
    double f, cx, cy, mount, pitch;
  };
  const Cam cams[] = {{1001, 337, 1105.0, 537.3, 151.7, 1.22, 0.038},  // Cityscapes' rig at about half size
                      {999, 301, 260.0, 480.2, 40.5, 1.3, 0.0},        // ±62° wide, horizon at row 40.5
                      {517, 263, 300.0, 250.9, 20.2, 3.5, 0.35},       // 3.5 m up, pitched 20° down
                      {17, 60, 30.0, 8.4, 5.5, 1.22, 0.0},            {15, 60, 40.0, 7.1, 3.5, 1.22, 0.0},
                      {9, 60, 20.0, 4.1, 10.3, 1.22, 0.0},            {8, 60, 25.0, 3.6, 2.0, 1.2, 0.0},
                      {7, 60, 25.0, 3.3, 2.0, 1.2, 0.0},              {1, 60, 25.0, 0.0, 2.0, 1.2, 0.0}};
  const uint16_t ids[] = {7, 8, 9, 26, 11, 23, 300, 6, 10};  // road, sidewalk, parking, car, building, sky, unknown, ground, rail
  int whole_rows = 0, partial_rows = 0;
  long sure_px = 0, other_px = 0;
  for (const Cam& cam : cams) {
    CameraGeometry g;
    g.f_px = cam.f, g.cx_px = cam.cx, g.cy_px = cam.cy, g.mount_height_m = cam.mount, g.pitch_rad = cam.pitch;
    ImageU16 labels(cam.w, cam.h);
    for (int y = 0; y < cam.h; ++y)  // runs of 3 to 13 pixels of one id
      for (int x = 0, k = y; x < cam.w; ++k) {
        const int run = 3 + (k * 7 + y) % 11;
        for (int i = 0; i < run && x < cam.w; ++i, ++x) labels.at(x, y) = ids[(k * 5 + y / 3) % 9];
      }
    const LowBeamRows rows(g, cam.w, cam.h, p, nullptr);
    for (int y = 0; y < cam.h; ++y) {
      const auto [lo, hi] = rows.sure_columns(y);
      if (hi > lo) ++(lo == 0 && hi == cam.w ? whole_rows : partial_rows);
      sure_px += hi - lo, other_px += cam.w - (hi - lo);
    }
    for (int isa : {2, 1, 0}) {
      beam_max_isa(isa);
      for (const ImageU16* lab : std::initializer_list<const ImageU16*>{nullptr, &labels}) {
        const ImageF E = low_beam_illuminance(g, cam.w, cam.h, p, lab);
        for (int y = 0; y < cam.h; ++y)
          for (int x = 0; x < cam.w; ++x) {
            double X, D, z;
            const uint16_t id = labels.at(x, y);
            const bool read = !lab || (id < kLabelCount && ground_classes()[id]);
            const float expect = read && g.ground_point(x, y, &X, &D, &z) ? low_beam_lux_f32(X, D, p) : 0.f;
            ASSERT_EQ(std::bit_cast<uint32_t>(E.at(x, y)), std::bit_cast<uint32_t>(expect))
                << "cap " << isa << (lab ? ", labels" : "") << ", " << cam.w << "x" << cam.h << " at " << x << "," << y;
          }
      }
    }
    beam_max_isa(2);
  }
  EXPECT_GT(whole_rows, 0);
  EXPECT_GT(partial_rows, 0);
  EXPECT_GT(sure_px, 0);
  EXPECT_GT(other_px, 0);
}

// Vehicles' low beams on the road (vehicle_lamps.beams_on_road; VehicleBeamRows in
// scene/lights.cpp), checked on an unlit road (no street lamps: street_road_luminance 0) of the
// scene rendered from a known camera. The reference, in double: each of a vehicle's two lamps at
// (X_k, vehicle_lamps.height_m, D_k) (X_k = X ± (width/2 − inset), its contact's X, D and metric
// width as light_map's vehicle states record them) is the [ego_beam] table aimed along σ·D:
// oncoming (σ = −1, D_k = D_v), a ground point (X, D) lies D' = D_k − D ahead of the lamp and
// dx = X_k − X to its right (its right is the camera's left); going away (σ = +1, D_k = D_v + the
// class's length, vehicle_length_m), D' = D − D_k ahead and dx = X − X_k to its right (as the
// ego's). A ground pixel lit by nothing else (beams off: 0) carries f·(t·E) per channel (f the
// reflectance texture, t the 3200 K head lamps' tint over π), so E = L_G/(f_G·t_G) within the ego
// beam's derived float bound (BeamRef, above, in the lamp's frame: |X'| = |X|, |x'| = |X_k|) summed
// over the vehicles' lamps that reach it, plus the roundings of L: f·(t·E_v) per vehicle (2u·E_v)
// and the sum over vehicles (u·E each), within 2u·E per vehicle. Pixels within the bound of the
// table's edges or the cut-off are left out and counted; pixels ahead of no vehicle's lamps
// (D' ≤ 0 for every one) are 0 exactly.
namespace {
// The synthetic road with `boxes` on an unlit road (no street lamps: street_road_luminance 0, as
// night-rural), rendered with the vehicles' beams on (with each vehicle's decision) and off.
struct VehicleBeamScenes {
  SyntheticCameraScene s;
  ScenePreset p;
  std::vector<VehicleDecision> seen;
  NightScene on, off;
};
VehicleBeamScenes vehicle_beam_scenes(const std::vector<SyntheticBox>& boxes) {
  VehicleBeamScenes r;
  SyntheticCameraOptions o = camera_scene();
  o.boxes = boxes;
  r.s = make_synthetic_camera_scene(o);
  r.p = urban();
  r.p.rig = load_camera_rig("cityscapes");
  r.p.street_road_luminance_cd_m2 = 0;  // nothing but the beams on the ground
  r.p.veh_beams_on_road = true;          // (night-urban leaves them off)
  set_vehicle_decision_sink(&r.seen);
  r.on = night_scene(r.s.day_linear_srgb, r.s.labels, r.p, 1);
  set_vehicle_decision_sink(nullptr);
  ScenePreset p_off = r.p;
  p_off.veh_beams_on_road = false;
  r.off = night_scene(r.s.day_linear_srgb, r.s.labels, p_off, 1);
  return r;
}
// The vector rows are the scalar twins' bits: the light map at beam_max_isa 1 and 0 is `on`'s.
void expect_same_bits_at_every_isa(const VehicleBeamScenes& b) {
  for (const int isa : {1, 0}) {
    beam_max_isa(isa);
    const NightScene n = night_scene(b.s.day_linear_srgb, b.s.labels, b.p, 1);
    beam_max_isa(2);
    EXPECT_EQ(differing_samples(n.lights, b.on.lights), 0u) << "beam_max_isa " << isa;
  }
}
struct VehicleBeamSource {
  double lamps[2];  // X_k of its pair
  double D_k;       // the lamps' depth
  bool away;        // σ = +1
};
VehicleBeamSource beam_source(const VehicleDecision& v, const ScenePreset& p) {
  const double half = std::max(0.0, 0.5 * v.width_m - p.veh_lamp_inset_m);
  const bool away = !v.faces_camera;
  return {{v.X - half, v.X + half}, away ? v.D + vehicle_length_m(v.cls) : v.D, away};
}
struct VehicleBeamCheck {
  int checked = 0, dark = 0, band = 0, unreached = 0;
  double worst = 0;  // the largest |E − E_ref| / bound
};
// Every ground pixel of `on` (beams on) that `off` (beams off) leaves at 0, against the sum of
// `sources`' references.
VehicleBeamCheck check_vehicle_beams(const VehicleBeamScenes& b, const std::vector<VehicleBeamSource>& sources) {
  const SyntheticCameraScene& s = b.s;
  const NightScene &on = b.on, &off = b.off;
  const ScenePreset& p = b.p;
  VehicleBeamCheck r;
  const ImageF tex = reflectance_texture(s.day_linear_srgb, s.labels.ids, p);
  const auto tint = illuminant_tint(p.headlamp_cct_K);
  const float tG = static_cast<float>(tint[1] / M_PI);
  const BeamRef ref{p};
  const double u = ref.u, hl = p.veh_lamp_height_m;
  const CameraGeometry& g = on.geometry;
  for (int y = 0; y < s.labels.ids.height(); ++y)
    for (int x = 0; x < s.labels.ids.width(); ++x) {
      double X, D, z;
      if (!ground_classes()[s.labels.ids.at(x, y)] || !g.ground_point(x, y, &X, &D, &z)) continue;
      if (off.lights.at(x, y, 0) != 0 || off.lights.at(x, y, 1) != 0 || off.lights.at(x, y, 2) != 0) continue;
      const float LG = on.lights.at(x, y, 1);
      double expect = 0, bound = 0;
      bool lit = false, near_edge = false, reached = false;
      for (const VehicleBeamSource& v : sources) {
        const double Dp = v.away ? D - v.D_k : v.D_k - D;
        if (!(Dp > 0)) continue;  // behind its lamps: no beam of it
        reached = true;
        for (double Xk : v.lamps) {
          const LampRef l = ref.lamp(X, Xk, v.away ? X - Xk : Xk - X, Dp, hl);
          near_edge = near_edge || l.near_edge;
          lit = lit || l.lit;
          expect += l.E;
          bound += l.bound;
        }
      }
      if (!reached) {
        ++r.unreached;
        EXPECT_EQ(LG, 0.f) << x << "," << y << " X " << X << " D " << D;
        continue;
      }
      if (near_edge) {
        ++r.band;
        continue;
      }
      if (!lit) {
        ++r.dark;
        EXPECT_EQ(LG, 0.f) << x << "," << y << " X " << X << " D " << D;
        continue;
      }
      const double E = LG / (static_cast<double>(tex.at(x, y, 1)) * tG);
      const double tol = (bound + 2 * u * sources.size() * (expect + bound)) * (1 + 1e-6);
      EXPECT_NEAR(E, expect, tol) << x << "," << y << " X " << X << " D " << D;
      r.worst = std::max(r.worst, std::fabs(E - expect) / tol);
      ++r.checked;
    }
  return r;
}
// Class B is asymmetric above 1.72°D: at 1.72° right of its axis a lamp gives more than at 1.72°
// left (at 1.3°D 8,000 cd against 5,000, between 50L's column and the axis; the table's rows
// further down are symmetric). On each row 25-38 m ahead of a vehicle's lamps (0.7 m up they see
// it 1.6-1.05° down), the ground 1.72° to the lamps' right of their midpoint against 1.72° to their
// left (the image's own values, independently of the reference): returns {rows, rows where the
// camera's left is brighter}. An oncoming lamp's right is the camera's left; a going-away one's the
// camera's right.
std::pair<int, int> kerb_side_rows(const VehicleBeamScenes& b, const VehicleBeamSource& v) {
  const SyntheticCameraScene& s = b.s;
  const NightScene& on = b.on;
  const ScenePreset& p = b.p;
  const ImageF tex = reflectance_texture(s.day_linear_srgb, s.labels.ids, p);
  const CameraGeometry& g = on.geometry;
  const double Xc = 0.5 * (v.lamps[0] + v.lamps[1]);
  int rows = 0, left_brighter = 0;
  for (int y = 0; y < s.labels.ids.height(); ++y) {
    double X0, D, z;
    if (!g.ground_point(g.cx_px, y, &X0, &D, &z)) continue;
    const double Dp = v.away ? D - v.D_k : v.D_k - D;
    if (!(Dp >= 25 && Dp <= 38)) continue;
    const double delta = Dp * std::tan(1.72 * M_PI / 180), k = g.f_px / z;  // columns per metre at this row
    const int xl = static_cast<int>(std::lround(g.cx_px + (Xc - delta) * k));
    const int xr = static_cast<int>(std::lround(g.cx_px + (Xc + delta) * k));
    if (xl < 0 || xr >= s.labels.ids.width() || s.labels.ids.at(xl, y) != static_cast<int>(Label::Road) ||
        s.labels.ids.at(xr, y) != static_cast<int>(Label::Road))
      continue;
    // Asphalt only: a lane marking (day value 0.8, the asphalt's 0.08 x texture) adds its
    // retroreflection, which the texture does not divide out (the beam's 1.72° sample of row 238
    // fell on a dash once the vanishing point, not the rig, set the horizon).
    if (s.day_linear_srgb.at(xl, y, 1) > 0.5f || s.day_linear_srgb.at(xr, y, 1) > 0.5f) continue;
    const double El = on.lights.at(xl, y, 1) / tex.at(xl, y, 1), Er = on.lights.at(xr, y, 1) / tex.at(xr, y, 1);
    ++rows;
    left_brighter += El > Er;
  }
  return {rows, left_brighter};
}
const VehicleDecision* decision_of(const std::vector<VehicleDecision>& seen, int instance) {
  for (const VehicleDecision& d : seen)
    if (d.instance == instance) return &d;
  return nullptr;
}
}  // namespace

// Box 0 (X = −3.5 m, D = 40 m, left of the divide: oncoming, in traffic) lights the ground between
// itself and the camera; box 1 (X = 3.2 m, D = 50 m, right of the divide: going away) the ground
// beyond its front (D > 50 m + the car's length), so the ground from box 0's front to box 1's is
// reached by neither. Class B's kerb side mirrored: on the rows 25-38 m in front of box 0 the
// ground 1.72° to the camera's left of its lamps is the brighter. At every vector level of the beam
// rows (beam_max_isa 2, 1, 0) the same bits.
TEST(MetricLights, AnOncomingVehiclesLowBeamLightsTheRoadInFrontOfIt) {
  const VehicleBeamScenes b = vehicle_beam_scenes({{-3.5, 40, 1.8, 1.5, 4.5}, {3.2, 50, 1.8, 1.5, 4.5}});
  EXPECT_EQ(b.on.light_stats.vehicle_beams, 1);
  EXPECT_EQ(b.on.light_stats.vehicle_beams_going_away, 1);
  EXPECT_EQ(b.off.light_stats.vehicle_beams, 0);
  EXPECT_EQ(b.off.light_stats.vehicle_beams_going_away, 0);
  const VehicleDecision *v = decision_of(b.seen, 26000), *w = decision_of(b.seen, 26001);
  ASSERT_NE(v, nullptr);
  ASSERT_NE(w, nullptr);
  ASSERT_EQ(v->state, 1);
  ASSERT_TRUE(v->faces_camera);
  ASSERT_EQ(w->state, 1);
  ASSERT_FALSE(w->faces_camera);
  const VehicleBeamSource src = beam_source(*v, b.p), away = beam_source(*w, b.p);
  const VehicleBeamCheck c = check_vehicle_beams(b, {src, away});
  std::fprintf(stderr, "[oncoming beam] %d lit ground pixels within the derived bound (largest error/bound %.3f), "
               "%d dark in front of them, %d reached by neither, %d in the edge band\n", c.checked, c.worst, c.dark,
               c.unreached, c.band);
  EXPECT_GT(c.checked, 10000);
  EXPECT_GT(c.unreached, 1000);  // the road from box 0's front to box 1's
  EXPECT_LT(c.band, c.checked / 100);
  const auto [rows, rows_left_brighter] = kerb_side_rows(b, src);
  std::fprintf(stderr, "[oncoming beam] brighter 1.72° to the camera's left on %d of %d rows\n", rows_left_brighter, rows);
  EXPECT_GT(rows, 5);
  EXPECT_EQ(rows_left_brighter, rows);
  expect_same_bits_at_every_isa(b);
}

// A car going away (X = 3.2 m, in the lane right of the ego's, its rear 15 m ahead: right of the
// divide, in traffic, tail lamps) lights the road beyond its front (its rear + vehicle_length_m, a
// 4.28 m car) and nothing between the camera and its front; its own pixels hide the ground right
// behind it, and the camera, 3.2 m to its left, sees the road beyond it beside that. Class B's kerb
// side: its right is the camera's right, so on the rows 25-38 m beyond its front the ground 1.72°
// to the camera's right of its lamps is the brighter (an oncoming car's mirror image, above).
// At every vector level of the beam rows (beam_max_isa 2, 1, 0) the same bits. Twice: a car 1.5 m
// tall (above the camera's 1.22 m: it reaches above the horizon) and one 1.1 m tall (below it, as
// every car is from KITTI's 1.65 m), whose lit road lies in rows above every vehicle row (the row
// pass's band for the beams starts at the horizon).
TEST(MetricLights, AGoingAwayVehiclesLowBeamLightsTheRoadBeyondIt) {
  for (const double height : {1.5, 1.1}) {
    SCOPED_TRACE(height);
    const VehicleBeamScenes b =
        vehicle_beam_scenes({{3.2, 15, 1.8, height, vehicle_length_m(static_cast<int>(Label::Car))}});
    EXPECT_EQ(b.on.light_stats.vehicle_beams, 0);
    EXPECT_EQ(b.on.light_stats.vehicle_beams_going_away, 1);
    EXPECT_EQ(b.off.light_stats.vehicle_beams_going_away, 0);
    const VehicleDecision* v = decision_of(b.seen, 26000);
    ASSERT_NE(v, nullptr);
    ASSERT_EQ(v->state, 1);
    ASSERT_FALSE(v->faces_camera);
    // Its contact: its rear. One row at 15 m spans D²/(f·h) = 0.16 m (f = 1131 px at 1024 wide,
    // h = 1.22 m); 0.5 m (3 rows) is a regression guard, not a derived bound.
    EXPECT_NEAR(v->D, 15, 0.5);
    if (height < b.on.geometry.mount_height_m) {  // every vehicle row below the horizon
      const double y_h = b.on.geometry.cy_px - b.on.geometry.f_px * std::tan(b.on.geometry.pitch_rad);
      EXPECT_GT(v->y0, y_h + 1);
    }
    const VehicleBeamSource src = beam_source(*v, b.p);
    ASSERT_TRUE(src.away);
    const VehicleBeamCheck c = check_vehicle_beams(b, {src});
    std::fprintf(stderr, "[going-away beam, car %.1f m tall] %d lit ground pixels within the derived bound (largest "
                 "error/bound %.3f), %d dark beyond it, %d between the camera and its front, %d in the edge band\n",
                 height, c.checked, c.worst, c.dark, c.unreached, c.band);
    EXPECT_GT(c.checked, 10000);
    EXPECT_GT(c.unreached, 10000);  // the road up to its front: 0
    EXPECT_LT(c.band, c.checked / 100);
    const auto [rows, rows_left_brighter] = kerb_side_rows(b, src);
    std::fprintf(stderr, "[going-away beam, car %.1f m tall] brighter 1.72° to the camera's right on %d of %d rows\n",
                 height, rows - rows_left_brighter, rows);
    EXPECT_GT(rows, 5);
    EXPECT_EQ(rows_left_brighter, 0);
    expect_same_bits_at_every_isa(b);
  }
}

// Traffic signs with the metric geometry are lit by the beam's own intensity at their point
// (sign_beam_lux): E⊥ = Σ_lamps I(h, v)/d², the table below the cut-off and the glare zone's
// limit above it (night-urban: 625 cd = 1 lx at 25 m), not a constant illuminance.
TEST(EgoLowBeam, SignsLitByTheTableBelowTheCutOffAndTheGlareLimitAbove) {
  ScenePreset p = urban();
  ASSERT_EQ(p.beam_above_cutoff_cd, 625);
  const double hl = p.beam_lamp_height_m, xl = 0.5 * p.beam_lamp_spacing_m;
  // Above h-h straight ahead (v ≈ 5.4° for both lamps): the glare limit from each lamp.
  {
    const double d2 = xl * xl + (3.0 - hl) * (3.0 - hl) + 25.0 * 25.0;
    // Exact: each lamp gives 625/d² with the same d² (dx = ±xl squares alike, summed in this
    // order), and 625/d² + 625/d² = 2·(625/d²) = 1250/d² (doubling commutes with rounding).
    EXPECT_EQ(sign_beam_lux(0, 3.0, 25, p), 2 * 625 / d2);
    // The limit's own figure, 625 cd = 1 lx per lamp at 25 m on the lamps' axis (2 lx from two),
    // less only the inverse-square loss of the sign's offset from that axis, off² = xl² + (3 − hl)²:
    // 2·625/(625 + off²) = 2/(1 + ε), ε = off²/625, within 2·ε below 2 lx (1 − 1/(1 + ε) < ε).
    const double eps_off = (xl * xl + (3.0 - hl) * (3.0 - hl)) / (25.0 * 25.0);
    EXPECT_LE(sign_beam_lux(0, 3.0, 25, p), 2.0);
    EXPECT_GE(sign_beam_lux(0, 3.0, 25, p), 2.0 * (1 - eps_off));
  }
  // On h-h, 9° right of the right lamp: inside the rising cut-off, where the table is lit
  // (1500 cd at (9°R, 0°)); the left lamp sees it at 11.8°R, between table columns.
  {
    const double D = 30, X = xl + D * std::tan(9 * M_PI / 180);
    double ref = 0;
    for (const double x0 : {-xl, xl}) {
      const double dx = X - x0, d2 = dx * dx + D * D;
      ref += table_cd(p, std::atan2(dx, D) * 180 / M_PI, 0.0) / d2;
    }
    EXPECT_EQ(table_cd(p, 9, 0), 1500);  // exact: a grid point, weights 1 and 0
    EXPECT_GT(ref, 0);
    // Exact: at the lamps' height dy = 0 and v = 0 exactly, and lights.cpp's lamp_lux then does
    // this side's operations (the same atan2, d², cell, weights (1 − a)·I₀ + a·I₁ with b = 0
    // exact, the two lamps summed in the same order).
    EXPECT_EQ(sign_beam_lux(X, hl, D, p), ref);
  }
  // Outside the table's horizontal range (more than 25° left of both lamps): no light.
  EXPECT_EQ(sign_beam_lux(-20, 3.0, 10, p), 0);
  EXPECT_EQ(sign_beam_lux(0, 3.0, 0, p), 0);  // at or behind the lamps
  // Without the glare zone (the table's "nothing above the cut-off") a sign above h-h is dark.
  p.beam_above_cutoff_cd = 0;
  EXPECT_EQ(sign_beam_lux(0, 3.0, 25, p), 0);
}

// Signs beside the beam table's horizontal range [−25°, 25°] get nothing from that lamp, and a
// sign just inside it gets the table's light: below the cut-off (0.3 m up, 0.35 m below the
// lamps), at relative distances ε from the right lamp's 25° edge, dx = D·tan 25°·(1 − ε) (the
// left lamp sees it beyond 25°). Inside by 10⁻¹¹ to 10⁻⁸ (closer than lights.cpp's 10⁻⁹ margin of
// the shortcut beside the table, and farther): lit, as the angle path finds h < 25°; outside by
// as much: dark. Fails if the shortcut's margin is turned inward (then it takes points just
// inside the range for points beside it) or its test looks at the wrong side.
TEST(EgoLowBeam, SignsBesideTheBeamTableDarkJustInsideLit) {
  const ScenePreset p = urban();
  ASSERT_EQ(p.beam_h_deg.back(), 25);
  const double xl = 0.5 * p.beam_lamp_spacing_m, t = std::tan(25 * M_PI / 180);
  for (const double D : {4.0, 10.0, 30.0})
    for (const double eps : {1e-11, 1e-10, 3e-10, 1e-9, 3e-9, 1e-8}) {
      EXPECT_GT(sign_beam_lux(xl + D * t * (1 - eps), 0.3, D, p), 0) << "D " << D << " m, inside by " << eps;
      EXPECT_EQ(sign_beam_lux(xl + D * t * (1 + eps), 0.3, D, p), 0) << "D " << D << " m, outside by " << eps;
      EXPECT_EQ(sign_beam_lux(-xl - D * t * (1 + eps), 0.3, D, p), 0) << "D " << D << " m, left, outside by " << eps;
    }
}

// R_A falls with the observation angle α between the lamp and the camera seen from the sign: the
// preset's 180 (RA2) holds at 0.33°, R_A ∝ α^−1.989 up to 2°, held beyond (an upper bound): the
// class's white figures 180 and 5 cd·lx⁻¹·m⁻² at 0.33° and 2° (entrance 5°; Austrian StVZVO 1998
// Anlage 2, "Typ 2", whose 0.2° and 0.33° figures are EN 12899-1's RA2). The camera (1.22 m up on
// the car's centre line) sees the headlamps (0.65 m up, ±0.75 m) at α ≈ 5.4° from a sign 10 m
// ahead (held), ≈ 0.2° from 300 m.
TEST(EgoLowBeam, SignRetroreflectionFallsWithTheObservationAngle) {
  const ScenePreset p = urban();
  EXPECT_EQ(sign_RA_at(0.1, p), p.sign_RA);
  EXPECT_EQ(sign_RA_at(0.33, p), p.sign_RA);
  const double at2 = p.sign_RA * std::pow(2.0 / 0.33, -p.sign_RA_alpha_exponent);
  EXPECT_EQ(sign_RA_at(2.0, p), at2);  // exact: lights.cpp's sign_RA_at is this expression
  // The table's 2° figure, 5: the preset states k to four digits (1.989, within 5e-4 of
  // ln(36)/ln(2/0.33) = 1.98884), which moves (2/0.33)^−k by a relative ln(2/0.33)·5e-4 = 9e-4.
  EXPECT_NEAR(at2, 5.0, 5.0 * std::log(2.0 / 0.33) * 5e-4);
  EXPECT_EQ(sign_RA_at(5.0, p), at2);  // held beyond 2°
  EXPECT_GT(sign_RA_at(1.0, p), at2);
  EXPECT_LT(sign_RA_at(1.0, p), p.sign_RA);
  const double h_cam = 1.22;
  // A sign on the centre line 3 m up sees both lamps (±0.75 m, 0.65 m up) at one entrance angle β,
  // tan β = √(0.75² + 2.35²)/D: 13.9° at 10 m, where R_A is the 2° column's, F1 = 1 + (tan β −
  // tan 5°)·(0.5 − 1)/(tan 30° − tan 5°) (the preset's factors, linear in tan β), 0.84; 0.47° at
  // 300 m, below the table's 5°: F0 = 1. The code sums R_A·E⊥ per lamp (R_A = RA_max·F1: per lamp
  // two products and the sum, 3 roundings of the total), this side multiplies the summed E⊥ (the
  // sum, the products at2·F1 and ·E: 3 roundings), F1 being the same double (the same operations
  // in the same order on the same tan β): within 8·2⁻⁵³ of it.
  ASSERT_EQ(p.sign_RA_entrance_deg, (std::vector<double>{5, 30, 40}));
  const double t5 = std::tan(5 * M_PI / 180), t30 = std::tan(30 * M_PI / 180);
  const double tb10 = std::sqrt(0.75 * 0.75 + (0.65 - 3.0) * (0.65 - 3.0)) / 10;
  ASSERT_EQ(p.beam_lamp_spacing_m, 1.5);
  ASSERT_EQ(p.beam_lamp_height_m, 0.65);
  const double F1 = p.sign_RA_entrance_factor_alpha_max[0] +
                    (tb10 - t5) * ((p.sign_RA_entrance_factor_alpha_max[1] - p.sign_RA_entrance_factor_alpha_max[0]) / (t30 - t5));
  EXPECT_NEAR(F1, 0.8375, 1e-4);  // (tan β 0.24667: 1 − 0.5·0.15918/0.48986)
  const double near_L = at2 * F1 * sign_beam_lux(0, 3.0, 10, p), far_L = p.sign_RA * sign_beam_lux(0, 3.0, 300, p);
  EXPECT_GT(near_L, 0);
  EXPECT_NEAR(sign_retroreflected_cd_m2(0, 3.0, 10, h_cam, p), near_L, 8 * 0x1p-53 * near_L);
  EXPECT_NEAR(sign_retroreflected_cd_m2(0, 3.0, 300, h_cam, p), far_L, 4 * 0x1p-53 * far_L);
  EXPECT_EQ(sign_retroreflected_cd_m2(0, 3.0, 0, h_cam, p), 0);
}

// R_A falls with the entrance angle β as the RA2 white sheeting's table ("Typ 2", Austrian StVZVO
// 1998 Anlage 2): 180 / 100 / 95 at β 5° / 30° / 40° for α 0.33°, 5 / 2.5 / 1.5 at α 2°. The
// preset's factors give 100/180 and 95/180 to four digits (0.5556, 0.5278: within 5·10⁻⁵ of
// each), and at 2° R_A itself is the table's 5 within 9·10⁻⁴ relative (the exponent's four
// digits, above): the bounds below are those roundings. Below 5° R_A is the 5° column's, beyond 40°
// held at 40°'s; between the angles linear in tan β (the midpoint of tan 5° and tan 30° gets the
// mean factor), between the α columns geometric in α.
TEST(EgoLowBeam, SignRetroreflectionFallsWithTheEntranceAngle) {
  const ScenePreset p = urban();
  EXPECT_NEAR(sign_RA_at(0.33, 30, p), 100, 180 * 5e-5);
  EXPECT_NEAR(sign_RA_at(0.33, 40, p), 95, 180 * 5e-5);
  EXPECT_NEAR(sign_RA_at(2.0, 30, p), 2.5, 2.5 * 9e-4);
  EXPECT_NEAR(sign_RA_at(2.0, 40, p), 1.5, 1.5 * 9e-4);
  for (const double a : {0.1, 0.33, 1.0, 2.0, 5.0}) {
    EXPECT_EQ(sign_RA_at(a, 5, p), sign_RA_at(a, p)) << a;  // the first column: factor 1
    EXPECT_EQ(sign_RA_at(a, 0, p), sign_RA_at(a, p)) << a;  // held below it
    EXPECT_EQ(sign_RA_at(a, 70, p), sign_RA_at(a, 40, p)) << a;  // held beyond 40°
    EXPECT_LT(sign_RA_at(a, 35, p), sign_RA_at(a, 30, p)) << a;
    EXPECT_LT(sign_RA_at(a, 20, p), sign_RA_at(a, 10, p)) << a;
  }
  // Linear in tan β: half way between tan 5° and tan 30° (β 17.4°) the mean of the two factors,
  // within the rounding of tan(atan(x)) and the interpolation's four operations (a few 2⁻⁵³).
  const double tm = 0.5 * (std::tan(5 * M_PI / 180) + std::tan(30 * M_PI / 180)), bm = std::atan(tm) * 180 / M_PI;
  const double mean0 = 0.5 * (p.sign_RA_entrance_factor[0] + p.sign_RA_entrance_factor[1]);
  EXPECT_NEAR(sign_RA_at(0.33, bm, p), p.sign_RA * mean0, 16 * 0x1p-53 * p.sign_RA);
  // Between α 0.33° and 2° the factor lies between the two columns' (geometric: at α = √(0.33·2),
  // u = 1/2, the geometric mean √(F0·F1)).
  const double am = std::sqrt(0.33 * 2.0);
  const double Fm = sign_RA_at(am, 40, p) / sign_RA_at(am, p);
  // (u's rounding, |ln F1 − ln F0| < 1 times a few 2⁻⁵³, and the log, exp, product and quotient, one
  // rounding each: within 16·2⁻⁵³ of Fm)
  EXPECT_NEAR(Fm, std::sqrt(p.sign_RA_entrance_factor[2] * p.sign_RA_entrance_factor_alpha_max[2]), 16 * 0x1p-53 * Fm);
  EXPECT_GT(Fm, p.sign_RA_entrance_factor_alpha_max[2]);
  EXPECT_LT(Fm, p.sign_RA_entrance_factor[2]);
  // A sign beside the road, 10 m ahead, 5 m right of the centre line and 2.5 m up: only the right
  // lamp reaches it (the left one sees it at h 29.9°, beside the table's ±25°), at tan β =
  // √(4.25² + 1.85²)/10 (β 24.9°), so at α beyond 2° it returns F1 = 1 + (tan β − tan 5°)·(0.5 −
  // 1)/(tan 30° − tan 5°) = 0.62 of what a sign facing the lamp would; one on the centre line at
  // that depth and height sees both lamps at tan β = √(0.75² + 1.85²)/10, F1 = 0.89. (Ratios of two
  // sums of the same E⊥ terms, the factor's four operations and the quotient: within 16·2⁻⁵³.)
  const double t5 = std::tan(5 * M_PI / 180), t30 = std::tan(30 * M_PI / 180);
  const auto& f1 = p.sign_RA_entrance_factor_alpha_max;
  auto F1_at = [&](double tb) { return f1[0] + (tb - t5) * ((f1[1] - f1[0]) / (t30 - t5)); };
  ScenePreset flat = p;
  flat.sign_RA_entrance_deg.clear();
  flat.sign_RA_entrance_factor.clear();
  flat.sign_RA_entrance_factor_alpha_max.clear();
  const double side = sign_retroreflected_cd_m2(5, 2.5, 10, 1.22, p) / sign_retroreflected_cd_m2(5, 2.5, 10, 1.22, flat);
  const double mid = sign_retroreflected_cd_m2(0, 2.5, 10, 1.22, p) / sign_retroreflected_cd_m2(0, 2.5, 10, 1.22, flat);
  std::fprintf(stderr, "[signs] entrance factor at 10 m, 2.5 m up: %.3f beside the road (5 m right), %.3f on the centre line\n",
               side, mid);
  const double F_side = F1_at(std::sqrt(4.25 * 4.25 + 1.85 * 1.85) / 10), F_mid = F1_at(std::sqrt(0.75 * 0.75 + 1.85 * 1.85) / 10);
  // The comment's figures, to their three digits (half a unit in the last: 5·10⁻⁴).
  EXPECT_NEAR(F_side, 0.616, 5e-4);
  EXPECT_NEAR(F_mid, 0.886, 5e-4);
  // The ratios within 16·2⁻⁵³ (derived in the comment above the lambda).
  EXPECT_NEAR(side, F_side, 16 * 0x1p-53);
  EXPECT_NEAR(mid, F_mid, 16 * 0x1p-53);
}

// A road ahead bending left round a traffic island, as aachen_000000_000019's kerbs measure it
// (docs/night.md §7 "The road ahead": κ −0.026 1/m from 15 m ahead), at a heading of 0.02 rad.
RoadAhead left_bend() {
  RoadAhead r;
  r.state = "curved";
  r.curved = true;
  r.heading_rad = 0.02;
  r.curve_start_m = 15;
  r.kappa_per_m = -0.026;
  r.left_m = -4;
  r.right_m = 3.5;
  return r;
}

// On a road that bends (RoadAhead curved) a sign faces the traffic that reads it: its normal
// −(sin ψ, 0, cos ψ), ψ that traffic's course the reading distance d before it
// (sign_facing_heading_rad): the camera's heading turned by the bend since its start. On the road
// line of left_bend (road_ahead_pieces: straight at 0.02 rad to 15 m, the arc of κ −0.026 1/m for a
// quarter turn, straight on), at offsets across from the kerb to 6 m beyond it, ψ at along-line
// coordinate a is the line's turn at a − d: 0 before the start, κ·(a − d − 15) on the arc, −90°
// beyond it (for d = 0 everywhere; for d > 0 up to the quarter turn's end, and beyond it the
// approximation, within x − atan x, x = |κ|·d, on the line: scene/sign_retro_detail.h). The point's
// coordinates come from road_piece_point (a cos, a sin and a few products: some 2⁻⁵³ of the 40-100 m
// magnitudes), and the code's heading from them by a difference with the centre, a fixed rotation
// and atan2, so within 1e-12 rad (|w| ≥ 28 m, the radius 38.5 m less the 10 m offsets: 1e-12 rad is
// 2.8e-11 m, far above those roundings). Then the luminance of a sign lit by one lamp: its entrance
// factor is the table's at the angle β between that lamp's ray and the turned normal (cos β =
// l·n/|l| by libm, tan β = tan(acos)); with c = cos β formed by about 8 roundings (8·2⁻⁵³
// relative), tan β = √(1 − c²)/c moves by 8·2⁻⁵³/sin²β relative, and the factor F = F0 + (tan β −
// tan 5°)·slope by |slope|·tan β times that, plus its own four operations and the ratio's (16·2⁻⁵³).
TEST(EgoLowBeam, SignsOnABendFaceTheTrafficThatReadsThem) {
  const ScenePreset p = urban();
  EXPECT_EQ(p.sign_read_distance_m, 60);
  const RoadAhead r = left_bend();
  const std::vector<RoadPiece> line = road_ahead_pieces(r);
  const double quarter = 0.5 * M_PI / std::fabs(r.kappa_per_m), end = 15 + quarter;
  const double x60 = std::fabs(r.kappa_per_m) * 60, bound60 = x60 - std::atan(x60);
  int checked = 0, approximated = 0;
  for (const double d : {0.0, 20.0, 60.0})
    for (double a = 2; a < end + 80; a += 3.7)
      for (const double off : {0.0, r.right_m, r.right_m + 6, r.left_m, r.left_m - 6}) {
        const RoadPiece q = road_line_piece(line, a);
        double X, D;
        road_piece_point(q, a, off, 0, &X, &D);
        const double ar = a - d;  // the reading point
        const double want = ar <= 15 ? 0.0 : ar <= end ? r.kappa_per_m * (ar - 15) : -0.5 * M_PI;
        const double got = sign_facing_heading_rad(r, X, D, d);
        if (d > 0 && a > end) {
          // Past the quarter turn: the approximation, the point's angle Δ about the arc's centre
          // (libm's atan2 here, the code's fixed rotation there) less |κ|·d, held in [0, 90°]; on
          // the road line itself it faces less turned than the line's heading d before it, by at
          // most x − atan x (1e-12 rad for the roundings, derived above).
          const double k = r.kappa_per_m > 0 ? 1 : -1, s0 = std::sin(r.heading_rad), c0 = std::cos(r.heading_rad);
          const double CX = 15 * s0 + c0 / r.kappa_per_m, CD = 15 * c0 - s0 / r.kappa_per_m;
          const double psi_s = std::atan2(k * (D - CD), -k * (X - CX));
          const double turn = std::remainder(k * (psi_s - r.heading_rad), 2 * M_PI) - std::fabs(r.kappa_per_m) * d;
          // (1e-12 rad: the roundings, derived above the test)
          EXPECT_NEAR(got, k * std::clamp(turn, 0.0, 0.5 * M_PI), 1e-12) << "d " << d << ", a " << a;
          if (off == 0) {
            const double x = std::fabs(r.kappa_per_m) * d, diff = got - want;  // (κ < 0: less turned is larger)
            EXPECT_GE(diff, -1e-12) << "d " << d << ", a " << a;
            EXPECT_LE(diff, x - std::atan(x) + 1e-12) << "d " << d << ", a " << a;
          }
          ++approximated;
          continue;
        }
        // (1e-12 rad: |w| ≥ 28 m, so 2.8e-11 m across, far above the coordinates' roundings: derived above)
        EXPECT_NEAR(got, want, 1e-12) << "d " << d << " m, a " << a << " m, off " << off << " m";
        ++checked;
      }
  std::fprintf(stderr, "[signs] facing on the bend: %d points exact, %d past the quarter turn within x − atan x (%.2f rad at d 60 m)\n",
               checked, approximated, bound60);
  EXPECT_GT(checked, 200);
  EXPECT_GT(approximated, 20);
  // Straight (or not measured): the camera's heading, and the luminance of the sign facing it.
  RoadAhead straight = r;
  straight.curved = false;
  EXPECT_EQ(sign_facing_heading_rad(straight, 5, 40, 60), 0);
  EXPECT_EQ(sign_retroreflected_cd_m2(5, 2.5, 40, 1.22, p, straight), sign_retroreflected_cd_m2(5, 2.5, 40, 1.22, p));
  // The luminance: with one headlamp (spacing 0: both at the centre line) the ratio of a sign's
  // luminance to that of the same sign without the entrance table (one_flat) is that lamp's
  // entrance factor. At the distances where α lies beyond 2° (the camera 0.57 m above the lamps:
  // within about 16 m) it is the 2° column's, F1(tan β), so the bend is taken from 3 m ahead here
  // (the same κ) and the reading distance 0 and 4 m, to put such signs' normals on the arc.
  RoadAhead near = r;
  near.curve_start_m = 3;
  ScenePreset one = p, one_flat = p;
  one.beam_lamp_spacing_m = 0;
  one_flat.beam_lamp_spacing_m = 0;
  one_flat.sign_RA_entrance_deg.clear();
  one_flat.sign_RA_entrance_factor.clear();
  one_flat.sign_RA_entrance_factor_alpha_max.clear();
  const double t5 = std::tan(5 * M_PI / 180), t30 = std::tan(30 * M_PI / 180), t40 = std::tan(40 * M_PI / 180);
  const auto& f1 = p.sign_RA_entrance_factor_alpha_max;
  auto F1_at = [&](double tb) {  // the 2° column
    if (tb <= t5) return f1[0];
    if (tb <= t30) return f1[0] + (tb - t5) * ((f1[1] - f1[0]) / (t30 - t5));
    if (tb <= t40) return f1[1] + (tb - t30) * ((f1[2] - f1[1]) / (t40 - t30));
    return f1[2];
  };
  int compared = 0;
  for (const double d : {0.0, 4.0}) {
    one.sign_read_distance_m = one_flat.sign_read_distance_m = d;
    for (const auto& [X, Y, D] : {std::array<double, 3>{5, 2.5, 12}, {3, 2.5, 14}, {-6, 3, 10}, {1, 2.5, 6}, {-2, 2, 8}}) {
      const double psi = sign_facing_heading_rad(near, X, D, d);
      const double Lr = sign_retroreflected_cd_m2(X, Y, D, 1.22, one, near);
      const double Lf = sign_retroreflected_cd_m2(X, Y, D, 1.22, one_flat, near);
      if (!(Lf > 0)) continue;
      // The lamp at (0, 0.65, 0): l = (−X, 0.65 − Y, −D); n = −(sin ψ, 0, cos ψ).
      const double lX = -X, lY = one.beam_lamp_height_m - Y, lD = -D, ln = std::sqrt(lX * lX + lY * lY + lD * lD);
      const double c = -(lX * std::sin(psi) + lD * std::cos(psi)) / ln, beta = std::acos(c);
      // (α at the sign between the lamp and the camera: the F1 column's signs only)
      const double cam[3] = {-X, 1.22 - Y, -D}, cn = std::sqrt(cam[0] * cam[0] + cam[1] * cam[1] + cam[2] * cam[2]);
      const double alpha_deg = std::acos((cam[0] * lX + cam[1] * lY + cam[2] * lD) / (cn * ln)) * 180 / M_PI;
      if (alpha_deg < 2.001) continue;
      const double tb = std::tan(beta), F = F1_at(tb);
      const double slope = std::fabs((f1[1] - f1[0]) / (t30 - t5)) + std::fabs((f1[2] - f1[1]) / (t40 - t30));
      const double tol = (slope * tb * 8 / (std::sin(beta) * std::sin(beta)) + 16) * 0x1p-53;
      std::fprintf(stderr,
                   "[signs] on the bend at (%.0f, %.1f, %.0f) m, d %.0f m: ψ %.3f rad, β %.1f° (facing the camera's heading: %.1f°), F %.3f\n",
                   X, Y, D, d, psi, beta * 180 / M_PI, std::atan(std::sqrt(lX * lX + lY * lY) / D) * 180 / M_PI, F);
      EXPECT_NEAR(Lr / Lf, F, tol) << X << ", " << D << ", d " << d;
      ++compared;
    }
  }
  EXPECT_GE(compared, 8);
}

// The sign lanes' own log, exp and angle (scene/sign_retro_detail.h: no libm inside, so the vector
// lanes run them too) against libm's: each within 16·2⁻⁵³ relative, the bound the header derives
// ("a few ulp": z's and the Horner sums' roundings, and for ln y with e ≥ 1 the sum e·ln 2 + ln m,
// whose terms may differ in sign but |ln m| ≤ ln √2 ≤ e·ln 2 / 2, losing at most a factor 2; libm's
// own ≤ 1 ulp). Over their whole ranges: y in [1, 2¹⁸), t in [−48, 48], α up to 5°.
TEST(EgoLowBeam, SignLanesLogExpAndAngleAreLibmsToAFewUlp) {
  const double u = 0x1p-53;
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> U(0, 1);
  double worst_log = 0, worst_exp = 0, worst_ang = 0;
  for (int i = 0; i < 200000; ++i) {
    const double y = std::pow(2.0, 18 * U(rng)) * (1 - 1e-15), ly = std::log(y);
    if (ly > 0) worst_log = std::max(worst_log, std::fabs(scene::detail::lane_log_1_2p18(y) - ly) / ly);
    const double t = -48 + 96 * U(rng), et = std::exp(t);
    worst_exp = std::max(worst_exp, std::fabs(scene::detail::lane_exp_48(t) - et) / et);
    const double a = 5 * M_PI / 180 * U(rng) + 1e-6, c = std::cos(a), ref = std::acos(c) * std::acos(c);
    worst_ang = std::max(worst_ang, std::fabs(scene::detail::lane_angle2_from_cos(c) - ref) / ref);
  }
  for (const double y : {1.0, 1.4142135623730951, std::nextafter(1.4142135623730951, 0.0), 2.0, 0x1p17, std::nextafter(0x1p18, 0.0)})
    if (std::log(y) > 0) worst_log = std::max(worst_log, std::fabs(scene::detail::lane_log_1_2p18(y) - std::log(y)) / std::log(y));
  EXPECT_EQ(scene::detail::lane_log_1_2p18(1.0), 0.0);
  for (const double t : {-48.0, -0.5 * M_LN2, 0.0, 0.5 * M_LN2, 48.0})
    worst_exp = std::max(worst_exp, std::fabs(scene::detail::lane_exp_48(t) - std::exp(t)) / std::exp(t));
  std::fprintf(stderr, "[signs] lanes against libm, relative: ln %.2g, exp %.2g, α² %.2g (units of 2⁻⁵³: %.1f, %.1f, %.1f)\n",
               worst_log, worst_exp, worst_ang, worst_log / u, worst_exp / u, worst_ang / u);
  EXPECT_LE(worst_log, 16 * u);
  EXPECT_LE(worst_exp, 16 * u);
  // (acos of a c near 1 is itself within 1 ulp of the true angle of that c; both sides see the same c)
  EXPECT_LE(worst_ang, 16 * u);
}

// R_A as the light map's lanes evaluate it from cos α (scene::detail::sign_RA_lanes, scalar instance, the
// vector lanes' bits: SignPixelsEightAtATimeAreTheScalarBits) against sign_RA_at(α, β) (libm's
// log and exp on α itself), over α 0.05°..5° and β 0°..60°. The lanes see α only through its
// rounded cosine c: an error δ ≤ 2⁻⁵³ in c moves α² = 2(1 − c) + … by 2δ, ln α by δ/α², and R_A by
// K·δ/α² relative (K ≤ 2.4, the steepest column's exponent: k + ln(F0/F1)/ln(α1/α0) = 1.989 +
// ln(0.5278/0.3)/ln(2/0.33) = 2.30); the polynomials add 16·2⁻⁵³ each (above), the column's
// product and the interpolation in tan β a few more: within (2.4/α² + 64)·2⁻⁵³ relative.
TEST(EgoLowBeam, SignLanesGiveTheModelsRA) {
  const ScenePreset p = urban();
  const scene::detail::SignRA s(p);
  double K_max = 0;
  for (const double K : s.K) K_max = std::max(K_max, K);
  EXPECT_NEAR(K_max, 1.989 + std::log(0.5278 / 0.3) / std::log(2 / 0.33), 1e-12);  // (the 40° column's; 1e-12: a few roundings of ~2)
  long n = 0;
  double worst = 0;
  for (double a_deg = 0.05; a_deg < 5; a_deg *= 1.013)
    for (double b_deg = 0; b_deg <= 60; b_deg += 1.7) {
      const double a = a_deg * M_PI / 180;
      const double lanes = scene::detail::sign_RA_lanes<double>(s, std::cos(a), std::tan(b_deg * M_PI / 180));
      const double ref = sign_RA_at(a_deg, b_deg, p), tol = (2.4 / (a * a) + 64) * 0x1p-53 * ref;
      // (on the α0 and α1 boundaries the lanes decide held or power law by cos α and the reference by
      // α: where they differ both give the column's value there within the tolerance: continuity)
      EXPECT_NEAR(lanes, ref, tol) << "α " << a_deg << "°, β " << b_deg << "°";
      worst = std::max(worst, std::fabs(lanes - ref) / tol);
      ++n;
    }
  std::fprintf(stderr, "[signs] %ld (α, β) pairs: the lanes' R_A within %.2f of the derived bound of the model's\n", n, worst);
  EXPECT_GT(n, 10000);
}

// The free road with signs that only the ego beam lights (no street lamps): labels, metric depth
// and texture to draw the signs into, and the light map of them.
struct BeamSignScene {
  SyntheticCameraOptions o;
  SyntheticCameraScene s = free_road(o);
  ScenePreset p = urban();
  LabelMap lm = s.labels;
  ImageF depth = s.depth_m;
  ImageF tex = ImageF(o.width, o.height, 3, 0.f);
  StreetLighting street;  // no street lamps; its road_ahead where a test bends the road
  LightMap lights() const {
    const CameraGeometry& g = o.camera;
    return light_map(s.day_linear_srgb, tex, lm, ImageU8(o.width, o.height, 1, 0),
                     coarse_depth(o.width, o.height, g.cx_px, g.horizon_y),
                     VanishingPoint{g.cx_px, g.horizon_y, 0, VpMethod::ImageCentre, 0, ""}, p, 1, &g, &depth, nullptr,
                     nullptr, &street);
  }
};



// In a sequence the road behind the camera is known (LuminaireSet: the line driven). Where the
// frame's bend starts at the camera and the vehicle has been turning its way for b metres
// (RoadAhead::turning_behind_m), a sign whose reading point lies behind the camera takes the
// arc continued back: ψ = κ·(a − d) down to −|κ|·min(b, d) (and at most a quarter turn back), not
// the camera's heading, so a sign within the reading distance of a camera driving round the bend
// keeps its facing in the world as the camera turns. Bend at 0 m, κ −0.026 1/m, d = 60 m, along
// the road line (road_piece_point) at offsets across; 1e-12 rad as in
// SignsOnABendFaceTheTrafficThatReadsThem (|w| ≥ 28 m; the same operations and roundings).
TEST(EgoLowBeam, SignsInASequenceTakeTheArcDrivenBehindTheCamera) {
  RoadAhead r = left_bend();
  r.curve_start_m = 0;
  const double d = 60, k = r.kappa_per_m;
  const std::vector<RoadPiece> line = road_ahead_pieces(r);
  const double end = 0.5 * M_PI / std::fabs(k);  // the quarter turn's end (60.4 m)
  int checked = 0, back = 0, held = 0;
  for (const double b : {0.0, 10.0, 40.0, 100.0}) {
    r.turning_behind_m = b;
    const double reach = std::min({b, d, end});  // how far back the arc runs
    for (double a = 1; a < end; a += 2.3)
      for (const double off : {0.0, r.right_m, r.left_m, r.left_m - 6}) {
        const RoadPiece q = road_line_piece(line, a);
        double X, D;
        road_piece_point(q, a, off, 0, &X, &D);
        const double ar = a - d;
        const double want = ar >= 0 ? k * ar : ar >= -reach ? k * ar : -k * reach;
        // (1e-12 rad: derived above the test)
        EXPECT_NEAR(sign_facing_heading_rad(r, X, D, d), want, 1e-12) << "b " << b << " m, a " << a << " m, off " << off;
        ++checked;
        back += ar < 0 && ar >= -reach && b > 0;
        held += ar < -reach && b > 0;
      }
  }
  EXPECT_GT(back, 100);
  EXPECT_GT(held, 20);
  // A bend that starts ahead of the camera (beyond kBendAtCameraM) is not continued back: the
  // vehicle's turning behind it belongs to another bend.
  RoadAhead ahead = left_bend();
  ahead.turning_behind_m = 40;
  const RoadAhead plain = left_bend();
  for (const double a : {20.0, 40.0, 70.0}) {
    double X, D;
    road_piece_point(road_line_piece(road_ahead_pieces(plain), a), a, 0, 0, &X, &D);
    EXPECT_EQ(sign_facing_heading_rad(ahead, X, D, d), sign_facing_heading_rad(plain, X, D, d)) << a;
  }
  std::fprintf(stderr, "[signs] a sequence's bend at the camera: %d points, %d read on the arc continued back, %d at its start\n",
               checked, back, held);
}

// The sign pixels' luminances eight at a time (AVX-512, beam_max_isa 2: sign_luminances_avx512)
// and four at a time (AVX2, beam_max_isa 1: sign_luminances_avx2; on a machine without AVX-512
// cap 2 takes it too) are the scalar code's bits (beam_max_isa 0), pixel by pixel: every row of the synthetic frame
// made of signs in runs that leave every remainder of eight, at random camera z from 0.3 to 400 m
// (R_A at 0.33° and below, between 0.33° and 2° (the lanes' own log and exp), and above; the glare zone
// above the cut-off, the table below it, and signs beside the table's ±25° both sides of its edge),
// with depths that are not finite or not positive, and every row from the top to the bottom (D
// down to its smallest, Y below the lamps). Fails if a lane's branch (R_A's two limits, the glare
// zone, beside the table) is taken where the scalar code takes another, or a lane is missed.
TEST(EgoLowBeam, SignPixelsEightAtATimeAreTheScalarBits) {
  BeamSignScene b;
  const int W = b.o.width, H = b.o.height;
  std::mt19937_64 rng(4242);
  std::uniform_real_distribution<double> U(0, 1);
  const float odd[] = {NAN, INFINITY, -INFINITY, 0.f, -0.f, -3.f, 1e-30f, 0.05f};
  long signs = 0;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W;) {
      const int run = 1 + static_cast<int>(U(rng) * 19), gap = static_cast<int>(U(rng) * 6);
      for (int e = std::min(W, x + run); x < e; ++x, ++signs) {
        b.lm.ids.at(x, y) = static_cast<uint16_t>(Label::TrafficSign);
        b.depth.at(x, y) = U(rng) < 0.02 ? odd[static_cast<int>(U(rng) * 8)]
                                         : static_cast<float>(0.3 * std::pow(400 / 0.3, U(rng)));
        for (int c = 0; c < 3; ++c) b.tex.at(x, y, c) = static_cast<float>(0.05 + 0.3 * U(rng));
      }
      x += gap;
    }
  // Twice: the signs facing the camera's heading, and on a road bending left (left_bend: the signs
  // then face their stretch of road, SignLight::facing; the random depths put them before the
  // curve, on it, and beyond its quarter turn).
  // A fourth time: a sequence's bend starting at the camera, driven for 40 m behind it
  // (RoadAhead::turning_behind_m: the arc continued back, SignFacing::back).
  ImageF scalar_maps[4];
  for (const int bend : {0, 1, 2, 3}) {  // straight; the bend at the preset's reading distance; at 0; driven
    if (bend) b.street.road_ahead = left_bend();
    if (bend == 3) b.street.road_ahead.curve_start_m = 0, b.street.road_ahead.turning_behind_m = 40;
    b.p.sign_read_distance_m = bend == 2 ? 0 : urban().sign_read_distance_m;
    std::vector<ImageF> maps;
    for (const int isa : {2, 1, 0}) {
      beam_max_isa(isa);
      maps.push_back(b.lights().radiance);
    }
    beam_max_isa(2);
    long lit = 0, dark = 0;
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x)
        if (b.lm.ids.at(x, y) == static_cast<uint16_t>(Label::TrafficSign)) (maps[2].at(x, y, 1) > 0 ? lit : dark) += 1;
    std::fprintf(stderr, "[signs] %ld sign pixels%s: %ld lit, %ld dark\n", signs,
                 bend == 1   ? " (the road bending)"
                 : bend == 2 ? " (the road bending, read at the sign)"
                 : bend == 3 ? " (a sequence's bend at the camera, driven 40 m)"
                             : "",
                 lit, dark);
    EXPECT_GT(lit, signs / 4);
    EXPECT_GT(dark, signs / 20);  // beside the table, behind the camera, no depth
    EXPECT_EQ(differing_samples(maps[0], maps[2]), 0u) << "eight at a time against the scalar code, bend " << bend;
    EXPECT_EQ(differing_samples(maps[1], maps[2]), 0u) << "four at a time against the scalar code, bend " << bend;
    if (bend) b.street.road_ahead = RoadAhead{};
    scalar_maps[bend] = maps[2];
  }
  // (and the bend turned the signs: read at the sign, most sign pixels beyond the curve's start
  // (15 m) return another luminance; read 60 m before, those beyond about 75 m along it, a smaller
  // share of the depths drawn log-uniform over 0.3-400 m)
  const size_t turned = differing_samples(scalar_maps[0], scalar_maps[1]), turned0 = differing_samples(scalar_maps[0], scalar_maps[2]);
  std::fprintf(stderr, "[signs] samples the bend changed: %zu (read at 60 m), %zu (at the sign)\n", turned, turned0);
  EXPECT_GT(turned, static_cast<size_t>(signs / 20));
  EXPECT_GT(turned0, static_cast<size_t>(signs / 2));
  EXPECT_GT(turned0, turned);
  // (the arc continued back turns the signs whose reading point lies behind the camera)
  RoadAhead at_camera = left_bend();
  at_camera.curve_start_m = 0;
  b.street.road_ahead = at_camera;
  const ImageF undriven = b.lights().radiance;
  b.street.road_ahead = RoadAhead{};
  const size_t driven = differing_samples(undriven, scalar_maps[3]);
  std::fprintf(stderr, "[signs] samples the 40 m driven changed: %zu\n", driven);
  EXPECT_GT(driven, static_cast<size_t>(signs / 20));
  b.p.sign_read_distance_m = urban().sign_read_distance_m;
}

// The light map reads the sign pixel's point from depth_m through the camera model: sign pixels
// in the synthetic scene's sky, placed at chosen camera depths, get luminances in the ratio of
// sign_retroreflected_cd_m2 (Σ R_A(α)·E⊥) at the points whose projection they are (the test finds
// the point by the forward projection CameraGeometry::project, not by the code's inverse). The
// texture is one colour on every sign pixel, so the ratio of any channel is the ratio of the
// luminances (two float products per pixel on each side, the ratio within 8·2⁻²⁴ relative).
TEST(EgoLowBeam, SignPixelsLitAtTheirMetricPoint) {
  BeamSignScene b;
  const SyntheticCameraOptions& o = b.o;
  const ScenePreset& p = b.p;
  const CameraGeometry& g = o.camera;
  // Two signs above the horizon: one at camera z 20 m, one at 45 m (4x4 pixels each).
  struct Sign { int x0, y0; float z; };
  const Sign signs[2] = {{o.width / 2 + 120, 40, 20.f}, {o.width / 2 + 40, 80, 45.f}};
  for (const Sign& sg : signs)
    for (int y = sg.y0; y < sg.y0 + 4; ++y)
      for (int x = sg.x0; x < sg.x0 + 4; ++x) {
        ASSERT_LT(y, g.horizon_y);
        b.lm.ids.at(x, y) = static_cast<uint16_t>(Label::TrafficSign);
        b.depth.at(x, y) = sg.z;
        for (int c = 0; c < 3; ++c) b.tex.at(x, y, c) = 0.2f;
      }
  const LightMap m = b.lights();
  // The road point of pixel (x, y) at camera z: found by solving project(X, Y, D) = (x, y, z).
  struct RoadPoint { double X, Y, D, yc; };  // yc: the camera y (down) at depth z
  auto point_at = [&](int x, int y, double z) {
    const double c = std::cos(g.pitch_rad), sn = std::sin(g.pitch_rad);
    const double yc = (y - g.cy_px) / g.f_px * z;
    return RoadPoint{(x - g.cx_px) / g.f_px * z, g.mount_height_m - (z * sn + yc * c), z * c - yc * sn, yc};
  };
  auto point_L = [&](int x, int y, double z) {
    const auto [X, Y, D, yc] = point_at(x, y, z);
    double u, v, zz;
    EXPECT_TRUE(g.project(X, Y, D, &u, &v, &zz));
    // The round trip's rounding (u = 2⁻⁵³): every metric quantity of the chain (D, Y, h − Y, the
    // rotation's products and sums, zc and yc) is at most M = z + |yc| + h, and each is formed by
    // at most 12 roundings of such terms (|cos|, |sin| ≤ 1), so zc and yc are within 12u·M; the
    // projection f·(X or yc)/zc maps that to f·12u·M/z·(1 + |X or yc|/z) px, and its product,
    // quotient and the principal point's sum add 3 roundings of |c| + |x − c| and X's own one
    // (X = (x − c)/f·z): 16u on each term covers the 12 + 3 + 1.
    const double rnd = 0x1p-53, M = z + std::fabs(yc) + g.mount_height_m;
    const double px = 16 * rnd * (g.f_px * M / z * (1 + (std::fabs(x - g.cx_px) + std::fabs(y - g.cy_px)) / g.f_px) +
                                  std::fabs(g.cx_px) + std::fabs(g.cy_px) + std::fabs(x - g.cx_px) + std::fabs(y - g.cy_px));
    EXPECT_NEAR(u, x, px);
    EXPECT_NEAR(v, y, px);
    // 16 roundings (rnd = 2⁻⁵³) of the projection's magnitude, as for u and v above.
    EXPECT_NEAR(zz, z, 16 * rnd * M);
    return sign_retroreflected_cd_m2(X, Y, D, g.mount_height_m, p);
  };
  const double Lw0 = point_L(signs[0].x0, signs[0].y0, signs[0].z);
  const double L0 = m.radiance.at(signs[0].x0, signs[0].y0, 1);
  ASSERT_GT(Lw0, 0);
  ASSERT_GT(L0, 0);
  int n = 0;
  for (const Sign& sg : signs)
    for (int y = sg.y0; y < sg.y0 + 4; ++y)
      for (int x = sg.x0; x < sg.x0 + 4; ++x) {
        const double Lw = point_L(x, y, sg.z), L = m.radiance.at(x, y, 1);
        // (8·2⁻²⁴: two float products per pixel on each side of the ratio, derived above the test)
        EXPECT_NEAR(L / L0, Lw / Lw0, 8 * std::ldexp(1.0, -24) * (Lw / Lw0)) << x << "," << y;
        ++n;
      }
  EXPECT_EQ(n, 32);
  // Farther and seen from the glare zone: the far sign gets less light, E⊥ about the inverse square,
  // but returns more of it: the observation angle between each lamp and the camera (0.9-1.3 m
  // apart) is about 1.2° at 45 m (R_A 12-16 on the α^−1.989 law) and beyond the table's 2° at 20 m
  // (R_A held at 5). So with E its E⊥ at the same point, Lw = Σ_lamps R_A·E_lamp lies between
  // R_A's least and greatest times E: Lw0 = 5·E0, Lw1 > 5·E1, so Lw1/Lw0 > E1/E0; and it stays
  // dimmer (E1/E0 ≈ (20/45)² ≈ 0.2 against R_A's ratio of at most 16.3/5).
  const double Lw1 = point_L(signs[1].x0, signs[1].y0, signs[1].z);
  auto point_E = [&](int x, int y, double z) {  // E⊥ of both lamps at pixel (x, y) at camera z (point_L's point)
    const RoadPoint q = point_at(x, y, z);
    return sign_beam_lux(q.X, q.Y, q.D, p);
  };
  const double E0 = point_E(signs[0].x0, signs[0].y0, signs[0].z), E1 = point_E(signs[1].x0, signs[1].y0, signs[1].z);
  ASSERT_GT(E1, 0);
  EXPECT_LT(Lw1, Lw0);
  EXPECT_GT(Lw1 / Lw0, E1 / E0);
  // Both lamps beyond 2° at 20 m: R_A held, times each lamp's entrance factor (the 2° column at its
  // β, which lies between the two lamps' β; the sign faces along the road): without the entrance
  // table Lw0 is R_A(2°)·E0, with it between the two lamps' factors times that.
  ScenePreset flat = p;
  flat.sign_RA_entrance_deg.clear();
  flat.sign_RA_entrance_factor.clear();
  flat.sign_RA_entrance_factor_alpha_max.clear();
  const RoadPoint q0 = point_at(signs[0].x0, signs[0].y0, signs[0].z);
  const double Lflat = sign_retroreflected_cd_m2(q0.X, q0.Y, q0.D, g.mount_height_m, flat);
  // (within 4·2⁻⁵³: the roundings of SignRetroreflectionFallsWithTheObservationAngle's near_L)
  EXPECT_NEAR(Lflat, sign_RA_at(2.0, p) * E0, 4 * 0x1p-53 * Lflat);
  double F_lo = INFINITY, F_hi = 0;
  for (const double xl : {-0.5 * p.beam_lamp_spacing_m, 0.5 * p.beam_lamp_spacing_m}) {
    const double b = std::atan(std::hypot(xl - q0.X, p.beam_lamp_height_m - q0.Y) / q0.D) * 180 / M_PI;
    const double F = sign_RA_at(2.0, b, p) / sign_RA_at(2.0, p);
    F_lo = std::min(F_lo, F);
    F_hi = std::max(F_hi, F);
  }
  EXPECT_LT(F_hi, 1);  // the sign is beside and above the lamps: β beyond 5°
  // Lw0 = Σ F_lamp·R_A·E_lamp is a weighted mean of the two F times Lflat; the sides' roundings (the
  // tangent's round trip through atan in sign_RA_at, the quotient, the sums and products: a few
  // 2⁻⁵³ each) within 16·2⁻⁵³.
  EXPECT_GE(Lw0, F_lo * Lflat * (1 - 16 * 0x1p-53));
  EXPECT_LE(Lw0, F_hi * Lflat * (1 + 16 * 0x1p-53));
  std::fprintf(stderr, "[signs] L = Σ R_A(α)·E⊥ = %.0f cd/m² at z 20 m, %.0f cd/m² at z 45 m\n", Lw0, Lw1);
}

// ---- The low beam on vertical surfaces (scene/lights.cpp add_low_beam_vertical) -----------------
namespace {
// A street with things standing in the beam: a person 15 m ahead on the centre line, a car 20 m
// ahead to the right, a crown (vegetation) 25 m ahead to the left, a wall 30 m ahead on the left,
// and a sign 18 m ahead (lit by its retroreflection, not here). (The camera's half field of view,
// atan(512/1131) = 24.4°, lies inside the table's ±25°: nothing in view is beside the table.)
struct BeamVerticalScene {
  SyntheticCameraOptions o;
  SyntheticCameraScene sc;
  ScenePreset p = urban();
  BeamVerticalScene() {
    o = camera_scene();
    o.boxes = {{0.0, 15, 0.6, 1.8, 0.4, Label::Person},      {2.6, 20, 1.8, 1.5, 4.5, Label::Car},
               {-3.0, 25, 3.0, 4.0, 3.0, Label::Vegetation}, {-8.0, 30, 4.0, 2.5, 1.0, Label::Wall},
               {4.0, 18, 0.7, 2.7, 0.1, Label::TrafficSign, 2.0}};
    sc = make_synthetic_camera_scene(o);
  }
  ImageF beam() const {
    ImageF E = low_beam_illuminance(o.camera, o.width, o.height, p, &sc.labels.ids);
    add_low_beam_vertical(E, o.camera, sc.labels.ids, sc.depth_m, nullptr, p);
    return E;
  }
  // The rule alone, without the lamps' shadows (the person 15 m ahead shades what lies behind it).
  ImageF beam_without_shadows() const {
    ImageF E = low_beam_illuminance(o.camera, o.width, o.height, p, &sc.labels.ids);
    const BeamVerticalRows rows(E, o.camera, sc.labels.ids, sc.depth_m, nullptr, p, false);
    for (int y = 0; y < o.height; ++y) rows.row(y);
    return E;
  }
  // The pixel's point as add_low_beam_vertical takes it (float: X = z·x_n, D = z·kD, H = z·kY,
  // Y = h − H, the per-column x_n and per-row kD, kY rounded to float once).
  std::array<float, 4> point(int x, int y) const {
    const CameraGeometry& g = o.camera;
    const double yn = (y - g.cy_px) / g.f_px, c = std::cos(g.pitch_rad), s = std::sin(g.pitch_rad);
    const float xn = static_cast<float>((x - g.cx_px) / g.f_px), kD = static_cast<float>(c - yn * s),
                kY = static_cast<float>(s + yn * c), z = sc.depth_m.at(x, y);
    const float H = z * kY;
    return {z * xn, static_cast<float>(g.mount_height_m) - H, z * kD, H};
  }
};
}  // namespace

// E on a vertical surface element = Σ over the two lamps of I(h, v)·cos β/d² (a crown: I·Φ(α)/d²),
// the reference low_beam_vertical_lux in double (atan2, the table read by beam_intensity_cd) at
// the float point the rows use (BeamVerticalScene::point), with the normal turned to the camera
// (a crown's: the unit vector to the camera). The rows evaluate it in float; to first order in
// u = 2⁻²⁴ (each IEEE float operation and each rounding to float rel. ≤ u; Cephes' atanf ≤ 4u),
// per lamp with dx = X − x_l, dy = Y − h_l (|Δdx| ≤ u|dx|, |Δdy| ≤ u|dy|: one subtraction each):
//   h = atan(dx/D)·(180/π): δh ≤ (180/π)·|Δdx|/D + 7u·|h| + 12u·A_h (÷, atan, 180/π, ×; the grid's
//     rounded nodes and weights as in TableProjectedOntoTheMetricGround)
//   v = atan(dy/√(dx² + D²))·(180/π): δv ≤ |v|·(|Δdx|/D + 12u) + 12u·A_v
//   I: rel. 7u at the float angles, plus S_h·δh + S_v·δv (the table's largest slopes)
//   m·(L − P) = −(m_X·dx + m_D·D [+ m_Y·dy]), m exact at the float point (−X, H, −D): the
//     products and sums 3u of Σ|terms|, the inputs |m_X||Δdx| + |m_Y||Δdy|: δ ≤ 4u·Σ|terms|
//   s = √(X² + D² [+ H²]) 4u (5u), d² = dx² + D² + dy² 6u, d 4u, s·d 9u, s·d·d² 16u, I·cb and ÷ 2u
// so |E_f − E| ≤ Σ_lamps I·w·(25u·|cb| + 4u·Σ|terms|) + w·|cb|·(S_h·δh + S_v·δv), w = 1/(s·d·d²), for
// faces; for crowns cos α = cb/(s·d) moves by ≤ 4u·Σ|terms|/(s·d) + 11u, Φ by k·π·that (|dΦ/dc| =
// k·(π − α) ≤ k·π, k = 2/(3π)) plus the polynomial's 1.7·10⁻⁷ and 12u of its evaluation, and
// E = I·Φ/d²: the same I terms, and I·|ΔΦ|/d² + I·Φ·9u/d². Times (1 + 10⁻⁶) for the second
// order and the double reference's own rounding. A lamp whose (h, v) lies within δ of a
// discontinuity of I (the cut-off, the table's edges, the top of the cut-off) is lit in one
// evaluation and not the other: those pixels are excluded and counted.
TEST(EgoLowBeamVertical, FloatRowsAgainstTheDoubleReference) {
  const BeamVerticalScene s;
  const ScenePreset& p = s.p;
  const ImageF ground = low_beam_illuminance(s.o.camera, s.o.width, s.o.height, p, &s.sc.labels.ids);
  const ImageF E = s.beam_without_shadows();
  const double u = std::ldexp(1.0, -24), rise = std::tan(p.beam_cutoff_rise_deg * M_PI / 180), k = 2 / (3 * M_PI);
  const auto &Hg = p.beam_h_deg, &Vg = p.beam_v_deg;
  const auto [S_h, S_v, A_h, A_v] = table_slopes(p);
  const auto& lit_class = beam_vertical_classes();
  std::map<int, std::array<double, 4>> per;  // class: pixels, E below 0.4 m (sum, n), E above 1.2 m (sum)
  std::map<int, int> per_hi;
  int checked = 0, band = 0, unchanged = 0;
  double worst = 0;
  for (int y = 0; y < s.o.height; ++y)
    for (int x = 0; x < s.o.width; ++x) {
      const int id = s.sc.labels.ids.at(x, y);
      const float z = s.sc.depth_m.at(x, y);
      if (!lit_class[id] || !(z > 0 && z < kDepthInfinity_m)) {
        ASSERT_EQ(E.at(x, y), ground.at(x, y)) << x << "," << y << " class " << id;  // not touched
        ++unchanged;
        continue;
      }
      const auto P = s.point(x, y);
      const double X = P[0], Y = P[1], D = P[2], Hc = P[3];
      const bool crown = id == static_cast<int>(Label::Vegetation);
      const double mX = -X, mY = crown ? Hc : 0.0, mD = -D, sn = std::sqrt(X * X + D * D + mY * mY);
      double expect = low_beam_vertical_lux(X, Y, D, mX / sn, mY / sn, mD / sn, crown, p), bound = 0;
      bool near_edge = false;
      for (double xl : {-0.5 * p.beam_lamp_spacing_m, 0.5 * p.beam_lamp_spacing_m}) {
        const double dx = X - xl, dy = Y - p.beam_lamp_height_m, d2 = dx * dx + dy * dy + D * D, d = std::sqrt(d2);
        const double h = std::atan2(dx, D) * 180 / M_PI, v = std::atan2(dy, std::hypot(dx, D)) * 180 / M_PI;
        const double dh = 180 / M_PI * u * std::fabs(dx) / D + 7 * u * std::fabs(h) + 12 * u * A_h;
        const double dv = std::fabs(v) * (u * std::fabs(dx) / D + 12 * u) + 12 * u * A_v;
        const double cut = std::min(p.beam_cutoff_max_v_deg, p.beam_cutoff_v_deg + std::max(0.0, h) * rise);
        const double dcut = dv + rise * dh +
                            4 * u * (std::fabs(p.beam_cutoff_v_deg) + std::fabs(p.beam_cutoff_max_v_deg) + std::fabs(h) * rise);
        near_edge = near_edge || std::fabs(v - cut) <= dcut || std::fabs(v - p.beam_cutoff_max_v_deg) <= dcut ||
                    std::fabs(h - Hg.front()) <= dh || std::fabs(h - Hg.back()) <= dh || std::fabs(v - Vg.front()) <= dv;
        const double cb = mX * -dx + mY * -dy + mD * -D, terms = std::fabs(mX * dx) + std::fabs(mY * dy) + std::fabs(mD * D);
        const double I = std::max(table_cd(p, h, v), v > cut && h >= Hg.front() && h <= Hg.back() ? p.beam_above_cutoff_cd : 0.0);
        const double w = 1 / (sn * d * d2);
        if (!crown) {
          bound += I * w * (25 * u * std::fabs(cb) + 4 * u * terms) + w * std::fabs(cb) * (S_h * dh + S_v * dv);
        } else {
          const double c = cb / (sn * d), a = std::acos(std::clamp(c, -1.0, 1.0));
          const double phi = k * (std::sin(a) + (M_PI - a) * c);
          const double dphi = k * M_PI * (4 * u * terms / (sn * d) + 11 * u) + 1.7e-7 + 12 * u;
          bound += (I * phi / d2) * (16 * u) + (I * dphi + phi * (S_h * dh + S_v * dv)) / d2;
        }
      }
      bound *= 1 + 1e-6;
      if (near_edge) {
        ++band;
        continue;
      }
      ASSERT_NEAR(E.at(x, y), expect, bound) << x << "," << y << " class " << id;
      worst = std::max(worst, std::fabs(E.at(x, y) - expect) / bound);
      ++checked;
      auto& a = per[id];
      a[0] += 1;
      if (Y < 0.4) a[1] += E.at(x, y), a[2] += 1;
      if (Y > 1.2) a[3] += E.at(x, y), per_hi[id] += 1;
    }
  std::fprintf(stderr, "[beam vertical] %d lit pixels within the derived bound (largest error/bound %.3f), %d in the "
               "cut-off/edge band, %d untouched\n", checked, worst, band, unchanged);
  for (const auto& [id, a] : per)
    std::fprintf(stderr, "[beam vertical]   class %2d: %6.0f px, E below 0.4 m %.2f lx, above 1.2 m %.3f lx\n", id, a[0],
                 a[2] > 0 ? a[1] / a[2] : 0.0, per_hi[id] > 0 ? a[3] / per_hi[id] : 0.0);
  EXPECT_GT(checked, 5000);
  EXPECT_LT(band, checked / 50);
  // The person's legs below 0.4 m (v from −2.5° at the foot to −0.95° at 15 m: below the cut-off,
  // the table's 800 to 11,000 cd on the v-v line) against its chest above 1.2 m (above the
  // cut-off: the glare zone's 625 cd): more than 4× brighter on average (the table's mean over that
  // v range on the centre line is about 6,000 cd), and both lit.
  const auto& person = per.at(static_cast<int>(Label::Person));
  ASSERT_GT(person[2], 0);
  ASSERT_GT(per_hi[static_cast<int>(Label::Person)], 0);
  EXPECT_GT(person[1] / person[2], 4 * person[3] / per_hi[static_cast<int>(Label::Person)]);
  EXPECT_GT(person[3], 0);
  EXPECT_GT(per.count(static_cast<int>(Label::Wall)), 0u);
  EXPECT_GT(per.count(static_cast<int>(Label::Vegetation)), 0u);
  // The sign's beam light is its retroreflection (the light map), not this.
  int sign = 0;
  for (int y = 0; y < s.o.height; ++y)
    for (int x = 0; x < s.o.width; ++x)
      if (s.sc.labels.ids.at(x, y) == static_cast<int>(Label::TrafficSign)) {
        ASSERT_EQ(E.at(x, y), 0.f);
        ++sign;
      }
  EXPECT_GT(sign, 50);
}

// The rows eight (AVX2) and sixteen (AVX-512) pixels at a time are the scalar rows' bits: random classes (the lit
// ones, the ground, sky, signs, ids of 64 and more), depths (odd ones: NaN, ±∞, ±0, negative,
// tiny, and the sky's: the lit classes' pixels there written 0), and façade planes of a region whose columns change plane
// (one plane, two, none) and of pixels outside any region.
TEST(EgoLowBeamVertical, VectorRowsAreTheScalarBits) {
  SyntheticCameraOptions o = camera_scene();
  const int W = o.width, H = o.height;
  const ScenePreset p = urban();
  std::mt19937_64 rng(909);
  std::uniform_real_distribution<double> U(0, 1);
  const uint16_t ids[] = {static_cast<uint16_t>(Label::Car),        static_cast<uint16_t>(Label::Person),
                          static_cast<uint16_t>(Label::Vegetation), static_cast<uint16_t>(Label::Building),
                          static_cast<uint16_t>(Label::Building),   static_cast<uint16_t>(Label::Pole),
                          static_cast<uint16_t>(Label::TrafficSign), static_cast<uint16_t>(Label::Sky),
                          static_cast<uint16_t>(Label::Road),       70};
  const float odd[] = {NAN, INFINITY, -INFINITY, 0.f, -0.f, -3.f, 1e-30f, kDepthInfinity_m};
  ImageU16 lab(W, H, 1, 0);
  ImageF depth(W, H, 1, 0.f);
  BuildingFacades fac;
  fac.region = ImageI32(W, H, 1, -1);
  fac.planes = {{0.3, 0.954, 10, 0, 0, 12, true}, {-1, 0, 6, 0, 0, 12, true}, {0, 1, 40, 0, 0, 0, false}};
  BuildingFacades::Region R;
  R.x0 = 100;
  for (int x = R.x0; x < W - 50; ++x) R.column_plane.push_back(x < 300 ? 0 : x < 420 ? (x % 7 == 0 ? 1 : 0) : x < 600 ? 2 : -1);
  R.on_plane.assign(R.column_plane.size(), 1);
  fac.regions = {R};
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const uint16_t id = ids[static_cast<int>(U(rng) * 10)];
      lab.at(x, y) = id;
      depth.at(x, y) = U(rng) < 0.03 ? odd[static_cast<int>(U(rng) * 8)] : static_cast<float>(0.3 * std::pow(200 / 0.3, U(rng)));
      if (id == static_cast<uint16_t>(Label::Building) && x >= R.x0 && x < R.x0 + static_cast<int>(R.column_plane.size()) &&
          U(rng) < 0.9)
        fac.region.at(x, y) = 0;
    }
  std::vector<ImageF> out;
  for (const int isa : {0, 1, 2}) {
    beam_max_isa(isa);
    ImageF E(W, H, 1, -1.f);  // the untouched pixels keep it
    add_low_beam_vertical(E, o.camera, lab, depth, &fac, p);
    out.push_back(std::move(E));
  }
  beam_max_isa(2);
  // A cut-off whose top lies above the lamps (cutoff_max_v_deg > 0: its shadows' maps reach above
  // the lamps' height, the top's test decides which points and pixels take part): the same bits.
  {
    ScenePreset q = p;
    q.beam_cutoff_max_v_deg = 3;
    std::vector<ImageF> outq;
    for (const int isa : {0, 1, 2}) {
      beam_max_isa(isa);
      ImageF E(W, H, 1, -1.f);
      add_low_beam_vertical(E, o.camera, lab, depth, &fac, q);
      outq.push_back(std::move(E));
    }
    beam_max_isa(2);
    EXPECT_EQ(differing_samples(outq[1], outq[0]), 0u) << "cut-off top at 3°: AVX2 against the scalar code";
    EXPECT_EQ(differing_samples(outq[2], outq[0]), 0u) << "cut-off top at 3°: AVX-512 against the scalar code";
  }
  long lit = 0, untouched = 0;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      lit += out[0].at(x, y) > 0;
      untouched += out[0].at(x, y) == -1.f;
    }
  std::fprintf(stderr, "[beam vertical] %ld lit, %ld untouched of %d pixels\n", lit, untouched, W * H);
  EXPECT_GT(lit, W * H / 10);
  EXPECT_GT(untouched, W * H / 10);
  EXPECT_EQ(differing_samples(out[1], out[0]), 0u) << "eight at a time (AVX2) against the scalar code";
  EXPECT_EQ(differing_samples(out[2], out[0]), 0u) << "sixteen at a time (AVX-512) against the scalar code";
}

// compose() adds the beam's diffuse reflection on the vertical classes as on the ground:
// o = d + (fl(t·fl(tint/π))·E + l), so with the lights 0 the radiance with a beam image differs from
// the one without by exactly fl(fl(t·tint_f)·E) on every pixel of beam_lit_class_bits, and by
// nothing on the others (signs, sky). The old compose lit the ground classes only.
TEST(EgoLowBeamVertical, ComposeReflectsItOnTheVerticalClasses) {
  const BeamVerticalScene s;
  const ImageF tex = reflectance_texture(s.sc.day_linear_srgb, s.sc.labels.ids, s.p);
  const ImageF beam = s.beam();
  const ImageF none(s.o.width, s.o.height, 3, 0.f, unit::radiance), zero(s.o.width, s.o.height, 1, 0.f);
  const ImageF with = compose(tex, none, s.sc.labels.ids, beam, s.p), without = compose(tex, none, s.sc.labels.ids, zero, s.p);
  const auto tint = illuminant_tint(s.p.beam_cct_K);
  const uint64_t lit = beam_lit_class_bits();
  int vertical = 0;
  for (int y = 0; y < s.o.height; ++y)
    for (int x = 0; x < s.o.width; ++x) {
      const int id = s.sc.labels.ids.at(x, y);
      const bool on = id < 64 && (lit >> id & 1);
      for (int c = 0; c < 3; ++c) {
        const float tb = static_cast<float>(tint[c] / M_PI);
        const float add = on ? tex.at(x, y, c) * tb * beam.at(x, y) : 0.f;
        ASSERT_EQ(with.at(x, y, c), without.at(x, y, c) + (add + 0.f)) << x << "," << y << " class " << id;
      }
      vertical += on && !ground_classes()[id] && beam.at(x, y) > 0;
    }
  EXPECT_GT(vertical, 1000);
  EXPECT_FALSE(lit >> static_cast<int>(Label::TrafficSign) & 1);
  EXPECT_FALSE(lit >> static_cast<int>(Label::Sky) & 1);
}

// A pixel of a vertical class takes its beam from the vertical rule alone, whatever E the image
// held there before: compose applies the image on the vertical classes, so the vertical rule must
// replace the ground's E (E of the pixel's surface, 0 where the rule lights nothing). In the chain
// the ground's image is 0 there (low_beam_illuminance computes only the ground classes; the lane
// markings lie on road and parking, lanes_at_frame clearing the upsampled mask's pixels off
// them), but an image made without labels (the ground's E at every pixel, as a caller's own
// image, or a lane marking lit on any class, may hold) must give the same: the ground's E at every
// pixel against the labelled image, every pixel of a vertical class the same beam, bit for bit,
// and the ground's E on the vertical pixels (nonzero below the horizon) shows the test can see the
// difference.
TEST(EgoLowBeamVertical, LaneMarkingPixelsOfAVerticalClassTakeTheVerticalRuleOnly) {
  const BeamVerticalScene s;
  const int W = s.o.width, H = s.o.height;
  const ImageF plain = s.beam();
  const ImageF ground = low_beam_illuminance(s.o.camera, W, H, s.p);
  ImageF marked = ground;
  add_low_beam_vertical(marked, s.o.camera, s.sc.labels.ids, s.sc.depth_m, nullptr, s.p);
  const auto& vertical = beam_vertical_classes();
  int pixels = 0, ground_lit = 0;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const int id = s.sc.labels.ids.at(x, y);
      if (!vertical[id]) continue;
      ++pixels;
      ground_lit += ground.at(x, y) > 0 && ground.at(x, y) != plain.at(x, y);
      ASSERT_EQ(marked.at(x, y), plain.at(x, y)) << x << "," << y << " class " << id << ", the ground's E "
                                                 << ground.at(x, y);
    }
  std::fprintf(stderr, "[beam vertical] %d marked pixels of vertical classes, %d with another ground E\n", pixels,
               ground_lit);
  EXPECT_GT(ground_lit, 1000);
}

// Façades (issue 14 §2): each building region's façade is a vertical plane fitted to its
// unoccluded ground contacts (building_facades), and depth.Z on the building is that plane's.
// The synthetic street's façades are the planes X = ±(road + sidewalk) = ±10 m; parked cars on
// the right sidewalk and a hedge on the left hide stretches of their feet, and the road's cars
// hide more. The façade's depth must hold the issue's 5% for boxes on every building pixel,
// including the columns whose foot is hidden (counted, so the occlusion is really exercised).
TEST(Facades, PlaneFittedThroughAnOccludedFootHoldsFivePercent) {
  SyntheticCameraOptions o = camera_scene();
  o.boxes.push_back({8.4, 26, 1.8, 1.5, 4.5});
  o.boxes.push_back({8.4, 38, 1.8, 1.5, 4.5});
  o.boxes.push_back({-9.0, 24, 1.0, 2.2, 14, Label::Vegetation});
  const SyntheticCameraScene s = make_synthetic_camera_scene(o);
  const CameraGeometry& g = o.camera;
  const BuildingFacades fac = building_facades(s.labels.ids, g, 1000);
  const ImageF d = metric_depth(s.labels, g, 1000);
  const int W = o.width, H = o.height;
  // Columns whose lowest building pixel does not stand on a ground class: hidden feet.
  int hidden_cols = 0;
  std::vector<uint8_t> hidden(W, 0);
  for (int x = 0; x < W; ++x) {
    int yb = -1;
    for (int y = 0; y < H; ++y)
      if (s.labels.ids.at(x, y) == static_cast<int>(Label::Building)) yb = y;
    if (yb >= 0 && yb + 1 < H && !is_ground(s.labels.ids.at(x, yb + 1))) { hidden[x] = 1; ++hidden_cols; }
  }
  std::vector<double> err, err_hidden;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      if (s.labels.ids.at(x, y) != static_cast<int>(Label::Building)) continue;
      const double e = std::fabs(d.at(x, y) / s.depth_m.at(x, y) - 1);
      err.push_back(e);
      if (hidden[x]) err_hidden.push_back(e);
      const FacadePlane* f = fac.plane_at(x, y);
      ASSERT_NE(f, nullptr);
      EXPECT_TRUE(f->fitted) << x << "," << y;
    }
  // The plane is the line through the ground points of its foot line v = a + b·u at the first and
  // last inlier columns u0, u1. Every inlier lies within kFacadeInlier_px of that line and, a
  // contact being the boundary between a building pixel's centre and the ground pixel's below
  // (centres on integer rows: v = y + 0.5), within 0.5 px of the true foot: so at u0 and u1 the line
  // is within δ = kFacadeInlier_px + 0.5 of it. The bounds on nX and d are the largest changes of
  // the plane when its two end points move by ±δ in v (the four corners; each end point moves
  // along its ray, monotonically in v), computed with the geometry's own ground_point.
  auto plane_through = [&](double u0, double v0, double u1, double v1, double* nX, double* d) {
    double X0, D0, X1, D1;
    if (!g.ground_point(u0, v0, &X0, &D0, nullptr) || !g.ground_point(u1, v1, &X1, &D1, nullptr)) return false;
    const double len = std::hypot(X1 - X0, D1 - D0);
    *nX = std::fabs(D1 - D0) / len;
    *d = std::fabs((X0 * (D1 - D0) - D0 * (X1 - X0)) / len);
    return true;
  };
  int fitted = 0;
  for (const auto& f : fac.planes)
    if (f.fitted) {
      ++fitted;
      int u0 = -1, u1 = -1;  // the first and last inlier contacts of this plane
      for (int x = 0; x < W; ++x) {
        int yb = -1;
        for (int y = 0; y < H; ++y)
          if (s.labels.ids.at(x, y) == static_cast<int>(Label::Building)) yb = y;
        if (yb < 0 || yb + 1 >= H || !is_ground(s.labels.ids.at(x, yb + 1))) continue;
        if (std::fabs(yb + 0.5 - (f.line_a + f.line_b * x)) > kFacadeInlier_px) continue;
        if (u0 < 0) u0 = x;
        u1 = x;
      }
      ASSERT_LT(u0, u1);
      const double delta = kFacadeInlier_px + 0.5, va = f.line_a + f.line_b * u0, vb = f.line_a + f.line_b * u1;
      double nX0, d0, tol_nX = 0, tol_d = 0;
      ASSERT_TRUE(plane_through(u0, va, u1, vb, &nX0, &d0));
      for (const double e0 : {-delta, delta})
        for (const double e1 : {-delta, delta}) {
          double nX, d;
          ASSERT_TRUE(plane_through(u0, va + e0, u1, vb + e1, &nX, &d));
          tol_nX = std::max(tol_nX, std::fabs(nX - nX0));
          tol_d = std::max(tol_d, std::fabs(d - d0));
        }
      std::fprintf(stderr, "[facade] plane: inliers %d..%d, |nX| %.5f (bound %.2g), d %.3f m (bound %.3f m)\n", u0, u1,
                   std::fabs(f.nX), tol_nX, f.d_m, tol_d);
      // The true planes: normal (±1, 0), 10 m from the camera's foot. The normal within its bound
      // (about 2e-4 here); the distance within the issue's 5 % of 10 m, the requirement the depth
      // checks below hold too: the quantisation's worst case (0.7 and 0.85 m here, printed) is wider,
      // so that is the requirement's bound, not a guarantee of the fit.
      EXPECT_NEAR(std::fabs(f.nX), 1.0, tol_nX);
      EXPECT_NEAR(f.d_m, 10.0, 0.05 * 10.0);
    }
  std::fprintf(stderr, "[facade] %d planes, %d columns with a hidden foot; building depth worst %.2f%%, median %.3f%%; "
               "hidden-foot columns worst %.2f%%\n", fitted, hidden_cols, 100 * quantile(err, 1.0), 100 * quantile(err, 0.5),
               100 * quantile(err_hidden, 1.0));
  EXPECT_EQ(fitted, 2);
  EXPECT_GT(hidden_cols, 40);
  ASSERT_GT(err_hidden.size(), 1000u);
  EXPECT_LE(quantile(err, 1.0), 0.05);
  EXPECT_LE(quantile(err_hidden, 1.0), 0.05);
}

// Windows are laid out in the façade plane (issue 14 §2): on the right façade of the synthetic
// street, with every window lit, the lit run on the image row through a light's centre (a
// window's glass is two lights: the opening s_c ± width/2 less the frame on each side, split by
// the mullion) has its centre where the light's two vertical edges (along the fitted plane)
// project on that row. Pixel quantisation: a run covers the pixel centres inside [u_left,
// u_right], so its midpoint (first + last)/2 lies within 0.5 px of (u_left + u_right)/2; the
// spacing of two neighbouring lights' centres then matches their spacing projected at their depth,
//   Δu = u(s_2) − u(s_1) ≈ f·Δs·d/D² on a plane d to the side,
// within 2·0.5 = 1 px. (float depth.Z adds a relative 2⁻²⁴ = 6e-8 of the position, measured from
// the principal point, so at most 2⁻²⁴·W px per centre.)
// Ground-floor shops (shop_share 1): panes of shop_width_m on the same pitch, checked alike, with
// piers between them (runs end: not a filled block); with shop_share 0 the ground floor has the
// upper storeys' windows instead.
TEST(Facades, WindowSpacingIsThePitchInPerspective) {
  // Full Cityscapes size: the 0.1 m mullion spans ≥ 2 px (f·0.1·d/D² with d = 10 m) up to D = 34 m,
  // and the right façade enters the view at D = 24 m; at 1024 px both are 24 m.
  SyntheticCameraOptions o = camera_scene(2048, 1024);
  o.boxes.clear();
  const SyntheticCameraScene s = make_synthetic_camera_scene(o);
  const CameraGeometry& g = o.camera;
  const ScenePreset bundled = urban();
  ASSERT_GT(bundled.window_frame_m, 0);  // the bundled windows have frames and two lights
  ASSERT_GT(bundled.window_mullion_m, 0);
  const double max_depth_m = 1000;
  const ImageF depth = metric_depth(s.labels, g, max_depth_m);
  const BuildingFacades fac = building_facades(s.labels.ids, g, max_depth_m);
  // The right façade's plane (normal toward +X).
  const FacadePlane* f = nullptr;
  for (const auto& q : fac.planes)
    if (q.fitted && q.nX > 0.9) f = &q;
  ASSERT_NE(f, nullptr);
  double tX = f->nD, tD = -f->nX;  // along the plane, oriented toward increasing D
  if (tD < 0) tX = -tX, tD = -tD;
  const double c = std::cos(g.pitch_rad), sn = std::sin(g.pitch_rad);
  // Column where row y meets the plane at coordinate s along it: with k = cos θ − y_n·sin θ,
  // s·(n_X·x_n + n_D·k) = d·(t_X·x_n + t_D·k)  →  x_n = k·(d·t_D − s·n_D)/(s·n_X − d·t_X).
  auto u_at = [&](double s_m, int y) {
    const double k = c - (y - g.cy_px) / g.f_px * sn;
    return g.cx_px + g.f_px * k * (f->d_m * tD - s_m * f->nD) / (s_m * f->nX - f->d_m * tX);
  };
  for (const double shop_share : {1.0, 0.0}) {
    ScenePreset p = bundled;
    p.window_lit_fraction = 1.0;
    p.window_curtained_share = 0.5;  // curtained windows are lit too (dimmer)
    p.shop_share = shop_share;
    p.max_depth_m = max_depth_m;
    ImageF L(o.width, o.height, 3, 0.f, unit::radiance);
    add_facade_windows(L, s.labels.ids, depth, g, p, 3);
    auto lit = [&](int x, int y) { return L.at(x, y, 0) + L.at(x, y, 1) + L.at(x, y, 2) > 0; };
    // Storeys 0 and 1: storey 2 (Y 6-9 m) enters the view only beyond D = 34 m, where the mullion
    // is under 2 px.
    for (int storey : {0, 1}) {
      const bool shop = storey == 0 && shop_share == 1.0;
      const double Yc = shop ? p.shop_sill_m + 0.5 * p.shop_height_m : (storey + 0.5) * p.window_storey_m;
      // The lit pieces along the façade, [s_left, s_right] in m, in order.
      std::vector<std::pair<double, double>> pieces;
      for (int i = 0; i < 200; ++i) {
        const double sc = (i + 0.5) * p.window_pitch_m;
        if (shop) {
          pieces.push_back({sc - 0.5 * p.shop_width_m, sc + 0.5 * p.shop_width_m});
        } else {
          const double half = 0.5 * p.window_width_m - p.window_frame_m, m = 0.5 * p.window_mullion_m;
          pieces.push_back({sc - half, sc - m});
          pieces.push_back({sc + m, sc + half});
        }
      }
      double prev_meas = NAN, prev_pred = NAN;
      int lights = 0, pairs = 0;
      for (size_t k = 0; k + 1 < pieces.size(); ++k) {
        const auto [sl, sr] = pieces[k];
        const double sc = 0.5 * (sl + sr);
        double u, v;
        // The light's centre point on the plane: d·n + s·t.
        if (!g.project(f->d_m * f->nX + sc * tX, Yc, f->d_m * f->nD + sc * tD, &u, &v, nullptr)) { prev_meas = NAN; continue; }
        const int y = static_cast<int>(std::lround(v));
        const double ul = u_at(sl, y), ur = u_at(sr, y);
        const double lo = std::min(ul, ur), hi = std::max(ul, ur);
        const double gap = std::fabs(u_at(pieces[k + 1].first, y) - ur);  // to the next light
        const double gap_before = k > 0 ? std::fabs(ul - u_at(pieces[k - 1].second, y)) : 1e9;
        if (y < 0 || y >= o.height || lo < 1 || hi > o.width - 2 || hi - lo < 3 || gap < 2 || gap_before < 2) {
          prev_meas = NAN;
          continue;
        }
        const int xc = static_cast<int>(std::lround(0.5 * (lo + hi)));
        ASSERT_TRUE(lit(xc, y)) << "storey " << storey << " light " << k << " at " << xc << "," << y;
        int a = xc, b = xc;
        while (a > 0 && lit(a - 1, y)) --a;
        while (b + 1 < o.width && lit(b + 1, y)) ++b;
        const double meas = 0.5 * (a + b), pred = 0.5 * (lo + hi);
        EXPECT_LE(std::fabs(meas - pred), 0.5 + 0x1p-24 * o.width) << "storey " << storey << " light " << k << " run " << a << ".."
                                                      << b << " predicted " << lo << ".." << hi;
        ++lights;
        if (std::isfinite(prev_meas)) {
          EXPECT_LE(std::fabs((meas - prev_meas) - (pred - prev_pred)), 1.0 + 2 * 0x1p-24 * o.width)
              << "storey " << storey << " pair " << k;
          ++pairs;
        }
        prev_meas = meas;
        prev_pred = pred;
      }
      std::fprintf(stderr, "[windows] shop_share %g storey %d: %d lights measured, %d spacings\n", shop_share, storey,
                   lights, pairs);
      EXPECT_GE(pairs, 5) << "storey " << storey;
    }
  }
}

// The windows lit are the photo's (add_facade_windows with the day texture: scene/facade_windows.cpp).
// A synthetic street whose façades show dark windows (1.2 x 1.6 m glass every 2.7 m along the road,
// storeys of 3.4 m: neither is the preset grid's 1.3 m bay or 3 m storey), every window lit
// (window_lit_fraction 1). Measured over the building pixels up to 30 m ahead (where a 0.1 m cell
// spans ≥ 1 px along the façade at this size), against the photo's own window pixels:
// - precision, the lit pixels that are window in the photo: a rectified cell (kCell_m = 0.1 m)
//   across a window's edge is dark when the window fills enough of it, so lit pixels reach at most
//   one cell beyond the glass: at most the band 2(w + h)·c around each w x h window is lit wall,
//   precision ≥ w·h / (w·h + 2(w + h)·c) = 1.92 / 2.48 = 0.77;
// - recall, the window pixels lit: inside, at most the same band of edge cells falls short,
//   recall ≥ (w·h − 2(w + h)·c) / (w·h) = 0.71.
// The preset's grid (windows.detect_contrast 0) on the same street lights wall about as often as
// the windows cover the façade (1.92 / (2.7·3.4) = 0.21 of it): it must fall below both bounds.
// A plain façade (no window to find) keeps the grid.
TEST(Facades, LitWindowsAreThePhotosWindows) {
  const SyntheticCameraOptions o = windowed_street();
  const SyntheticCameraScene s = make_synthetic_camera_scene(o);
  const CameraGeometry& g = o.camera;
  const double max_depth_m = 1000;
  const ImageF depth = metric_depth(s.labels, g, max_depth_m);
  const BuildingFacades fac = building_facades(s.labels.ids, g, max_depth_m);
  ScenePreset p = urban();
  ASSERT_GT(p.window_detect_contrast, 0);  // the bundled preset looks for the photo's windows
  p.window_lit_fraction = 1.0;
  p.max_depth_m = max_depth_m;
  const ImageF tex = reflectance_texture(s.day_linear_srgb, s.labels.ids, p);
  const double c = FacadeWindowsFound::kCell_m, w = o.window_width_m, hh = o.window_height_m;
  const double band = 2 * (w + hh) * c, precision_min = w * hh / (w * hh + band), recall_min = (w * hh - band) / (w * hh);
  auto measure = [&](const ScenePreset& q, double* precision, double* recall) {
    ImageF L(o.width, o.height, 3, 0.f, unit::radiance);
    add_facade_windows(L, s.labels.ids, depth, g, q, 3, &fac, &tex);
    double lit_win = 0, lit_wall = 0, win = 0;
    for (int y = 0; y < o.height; ++y)
      for (int x = 0; x < o.width; ++x) {
        if (s.labels.ids.at(x, y) != static_cast<int>(Label::Building)) continue;
        const double z = s.depth_m.at(x, y), D = z * (std::cos(g.pitch_rad) - (y - g.cy_px) / g.f_px * std::sin(g.pitch_rad));
        if (D > 30) continue;
        const bool window = s.day_linear_srgb.at(x, y, 0) < 0.1f;
        const bool lit = L.at(x, y, 0) + L.at(x, y, 1) + L.at(x, y, 2) > 0;
        win += window;
        lit_win += lit && window;
        lit_wall += lit && !window;
      }
    *precision = lit_win / std::max(1.0, lit_win + lit_wall);
    *recall = lit_win / std::max(1.0, win);
    std::fprintf(stderr, "[photo windows] detect_contrast %.2f: %.0f window px, lit %.0f on windows, %.0f on wall: "
                 "precision %.3f (bound %.3f), recall %.3f (bound %.3f)\n", q.window_detect_contrast, win, lit_win,
                 lit_wall, *precision, precision_min, *recall, recall_min);
  };
  double precision, recall;
  measure(p, &precision, &recall);
  EXPECT_GE(precision, precision_min);
  EXPECT_GE(recall, recall_min);
  ScenePreset grid = p;
  grid.window_detect_contrast = 0;
  measure(grid, &precision, &recall);
  EXPECT_LT(precision, precision_min);
  EXPECT_LT(recall, recall_min);
  // A plain façade shows no windows to find: it keeps the grid, bit for bit.
  SyntheticCameraOptions plain = o;
  plain.window_pitch_m = 0;
  const SyntheticCameraScene sp = make_synthetic_camera_scene(plain);
  const ImageF tex_plain = reflectance_texture(sp.day_linear_srgb, sp.labels.ids, p);
  ImageF with_photo(o.width, o.height, 3, 0.f, unit::radiance), grid_only(o.width, o.height, 3, 0.f, unit::radiance);
  EXPECT_GT(add_facade_windows(with_photo, sp.labels.ids, depth, g, p, 3, &fac, &tex_plain), 0);
  add_facade_windows(grid_only, sp.labels.ids, depth, g, grid, 3, &fac, &tex_plain);
  EXPECT_EQ(differing_samples(with_photo, grid_only), 0u);
}

// The same on the five shared Cityscapes frames, where no window is annotated: every window lit
// (window_lit_fraction 1), the share of the lit façade pixels whose day luminance lies below 0.8 of
// their building region's median (the photo's dark glass, recesses and shadows), with the photo's
// windows and with the grid alone. Reported per frame; asserted over the five together: the photo's
// windows must land on darker pixels than the grid's, which knows nothing of the photo.
TEST(Facades, SharedFramesLitWindowsOnThePhotosDarkPixels) {
  PHOTOSITE_REQUIRE_SHARED("data/cityscapes");
  ScenePreset p = urban();
  p.window_lit_fraction = 1.0;
  ScenePreset grid = p;
  grid.window_detect_contrast = 0;
  double dark_found = 0, lit_found = 0, dark_grid = 0, lit_grid = 0;
  for (const char* base : {"aachen_000000_000019", "aachen_000001_000019", "aachen_000002_000019",
                           "aachen_000003_000019", "aachen_000004_000019"}) {
    const auto [lin, lab] = cityscapes_frame(base);
    const NightScene ns = night_scene(lin, lab, p, 1);
    const BuildingFacades fac = building_facades(lab.ids, ns.geometry, p.max_depth_m);
    const ImageF tex = reflectance_texture(lin, lab.ids, p);
    // Each building region's median day luminance (Rec. 709 weights on the linear day image).
    auto Y = [&](int x, int y) { return 0.2126 * lin.at(x, y, 0) + 0.7152 * lin.at(x, y, 1) + 0.0722 * lin.at(x, y, 2); };
    std::vector<std::vector<float>> values(fac.regions.size());
    for (int y = 0; y < lin.height(); ++y)
      for (int x = 0; x < lin.width(); ++x)
        if (fac.region.at(x, y) >= 0) values[fac.region.at(x, y)].push_back(static_cast<float>(Y(x, y)));
    std::vector<double> median(values.size(), 0.0);
    for (size_t r = 0; r < values.size(); ++r)
      if (!values[r].empty()) {
        std::nth_element(values[r].begin(), values[r].begin() + values[r].size() / 2, values[r].end());
        median[r] = values[r][values[r].size() / 2];
      }
    double share[2];
    int windows[2];
    for (int t = 0; t < 2; ++t) {
      ImageF L(lin.width(), lin.height(), 3, 0.f, unit::radiance);
      windows[t] = add_facade_windows(L, lab.ids, ns.depth, ns.geometry, t == 0 ? p : grid, 7, &fac, &tex);
      double lit = 0, dark = 0;
      for (int y = 0; y < lin.height(); ++y)
        for (int x = 0; x < lin.width(); ++x) {
          const int r = fac.region.at(x, y);
          if (r < 0 || L.at(x, y, 0) + L.at(x, y, 1) + L.at(x, y, 2) <= 0) continue;
          lit += 1;
          dark += Y(x, y) < 0.8 * median[r];
        }
      share[t] = dark / std::max(1.0, lit);
      (t == 0 ? dark_found : dark_grid) += dark;
      (t == 0 ? lit_found : lit_grid) += lit;
    }
    std::fprintf(stderr, "[photo windows] %s: lit façade pixels on the photo's darker pixels: %.3f with its windows "
                 "(%d drawn), %.3f with the grid (%d drawn)\n", base, share[0], windows[0], share[1], windows[1]);
  }
  const double found = dark_found / lit_found, by_grid = dark_grid / lit_grid;
  std::fprintf(stderr, "[photo windows] the five frames: %.3f with the photo's windows, %.3f with the grid\n", found, by_grid);
  EXPECT_GT(found, by_grid);
}

// Shop fronts only on a seeded share of the ground-floor units (shop_frontage_m along the
// façade, issue 14 §2): on the synthetic street with every window and shop lit, the ground-floor
// units whose lit pixels have the shops' colour (shop_cct_K set to 1000 K, which no window has:
// blue under 3% of red, against ~10% at 2700 K) are near shop_share of the units seen. Bound: the
// units are independent Bernoulli(0.3) draws, so over n units the share's standard error is
// sqrt(0.3·0.7/n); 4.5 SE is asserted. shop_share 0 and 1 give none and all.
TEST(Facades, ShopFrontsOnASeededShareOfGroundFloorUnits) {
  SyntheticCameraOptions o = camera_scene(2048, 1024);
  o.boxes.clear();
  const SyntheticCameraScene s = make_synthetic_camera_scene(o);
  const CameraGeometry& g = o.camera;
  const double max_depth_m = 1000;
  const ImageF depth = metric_depth(s.labels, g, max_depth_m);
  const BuildingFacades fac = building_facades(s.labels.ids, g, max_depth_m);
  auto share_of_shops = [&](double shop_share, int* units_seen) {
    ScenePreset p = urban();
    p.window_lit_fraction = 1.0;
    p.window_curtained_share = 0;
    p.shop_share = shop_share;
    p.shop_cct_K = 1000;  // a colour no window has: the shops are told apart by it
    ImageF L(o.width, o.height, 3, 0.f, unit::radiance);
    add_facade_windows(L, s.labels.ids, depth, g, p, 11);
    // Per façade plane and ground-floor unit (floor(s / shop_frontage_m)), whether a shop-coloured
    // pixel is in it and whether any lit pixel is.
    std::map<std::pair<int, int64_t>, std::pair<bool, bool>> units;
    const double cth = std::cos(g.pitch_rad), sth = std::sin(g.pitch_rad);
    for (int y = 0; y < o.height; ++y) {
      const double yn = (y - g.cy_px) / g.f_px;
      for (int x = 0; x < o.width; ++x) {
        const float* v = &L.at(x, y, 0);
        if (!(v[0] + v[1] + v[2] > 0)) continue;
        bool on = false;
        const FacadePlane* pl = fac.plane_at(x, y, &on);
        if (!pl) continue;
        const double z = depth.at(x, y), X = z * (x - g.cx_px) / g.f_px, D = z * (cth - yn * sth),
                     Y = g.mount_height_m - z * (yn * cth + sth);
        if (Y >= p.window_storey_m) continue;
        double tX = pl->nD, tD = -pl->nX;
        if (tD < 0 || (tD == 0 && tX < 0)) tX = -tX, tD = -tD;
        const int64_t unit = static_cast<int64_t>(std::floor((tX * X + tD * D) / p.shop_frontage_m));
        auto& u = units[{static_cast<int>(pl - fac.planes.data()), unit}];
        u.second = true;
        if (v[2] < 0.03f * v[0]) u.first = true;
      }
    }
    int n = 0, shops = 0;
    for (const auto& [k, u] : units)
      if (u.second) { ++n; shops += u.first; }
    *units_seen = n;
    return n ? static_cast<double>(shops) / n : NAN;
  };
  int n = 0;
  const double share = share_of_shops(0.3, &n);
  const double se = std::sqrt(0.3 * 0.7 / n);
  std::fprintf(stderr, "[shops] %d ground-floor units seen, shop share %.3f (expected 0.3 ± %.3f SE)\n", n, share, se);
  ASSERT_GE(n, 20);
  EXPECT_LE(std::fabs(share - 0.3), 4.5 * se);
  EXPECT_EQ(share_of_shops(0.0, &n), 0.0);
  EXPECT_EQ(share_of_shops(1.0, &n), 1.0);
}

// The bundled KITTI frame (samples/kitti): the façades the fit finds, per building region,
// printed (no ground truth here); every building pixel gets a façade.
TEST(Facades, KittiSamplePlanesReported) {
  const test::KittiSample k = test::bundled_kitti_sample();
  const ImageF& day = k.day;
  const ImageFileInfo& info = k.info;
  const LabelMap& lab = k.labels;
  ScenePreset p = urban();
  p.rig = load_camera_rig("kitti");
  const NightScene n = night_scene(linearize(day, info), lab, p, 1);
  const BuildingFacades fac = building_facades(lab.ids, n.geometry, p.max_depth_m);
  std::vector<int64_t> px(fac.regions.size(), 0), fitted_px(fac.regions.size(), 0);
  for (int y = 0; y < day.height(); ++y)
    for (int x = 0; x < day.width(); ++x) {
      const int r = fac.region.at(x, y);
      if (r < 0) continue;
      ++px[r];
      const FacadePlane* f = fac.plane_at(x, y);
      ASSERT_NE(f, nullptr) << x << "," << y;
      fitted_px[r] += f->fitted;
    }
  for (size_t r = 0; r < fac.regions.size(); ++r) {
    if (px[r] < 500) continue;
    const auto& R = fac.regions[r];
    std::fprintf(stderr, "[facades kitti] region %zu: columns %d..%zu, %lld px (%lld on fitted planes), %d contacts\n", r,
                 R.x0, R.x0 + R.column_plane.size() - 1, static_cast<long long>(px[r]), static_cast<long long>(fitted_px[r]),
                 R.contacts);
    std::vector<int> used;
    for (int i : R.column_plane)
      if (i >= 0 && std::find(used.begin(), used.end(), i) == used.end()) used.push_back(i);
    for (int i : used) {
      const FacadePlane& f = fac.planes[i];
      std::fprintf(stderr, "    plane %d: n (%.3f, %.3f), d %.1f m, azimuth %.1f deg, %d inliers%s%s\n", i, f.nX, f.nD, f.d_m,
                   std::atan2(f.nX, f.nD) * 180 / M_PI, f.inliers, f.fitted ? "" : ", unfitted", f.occluded ? ", occluded (stack feet)" : "");
    }
  }
}

// A building region with two façades meeting at a corner — the left side of the street
// (X = −12 m) and a block facing the camera across its end (D = 60 m) — whose foot rows carry label
// noise: on the block across the end, +4 rows on every 3rd column (beyond the inlier band: a line
// of their own 4 px below the true one, a third of that façade's contacts, above the 15% a façade
// needs), and −1 on every 5th column of both. The fit finds exactly those two planes
// (the offset line joins its façade instead of becoming a third one), and
// every column away from the corner takes its own façade. Bounds from the inlier band τ = 1.5 px:
// a foot line off by at most τ at the row v_c of the corner (the contacts' farthest point, the
// smallest v − y_h) puts the plane's distance off by at most τ/(v_c − y_h) relative; its two
// ends each off by τ turn it by at most atan(2τ·D/(v_c − y_h) / span), span the façade's
// extent across (m) in view.
TEST(Facades, TwoFacadesAtACornerWithLabelNoise) {
  const SyntheticCameraOptions o = camera_scene();
  const CameraGeometry& g = o.camera;
  const int W = o.width, H = o.height;
  const double c = std::cos(g.pitch_rad), sn = std::sin(g.pitch_rad), h = g.mount_height_m;
  const double XA = -12, DB = 60, XB_end = 5;
  // Foot row of the façades at column u (continuous at the corner).
  auto foot_A = [&](double u) {  // on X = XA: z = XA / x_n, D = (z − h·sin θ)/cos θ
    const double xn = (u - g.cx_px) / g.f_px, z = XA / xn, D = (z - h * sn) / c;
    return g.cy_px + g.f_px * (h * c - D * sn) / z;
  };
  const double zB = h * sn + DB * c, vB = g.cy_px + g.f_px * (h * c - DB * sn) / zB;
  const double u_corner = g.cx_px + g.f_px * XA / zB, u_end = g.cx_px + g.f_px * XB_end / zB;
  auto foot = [&](double u) { return u < u_corner ? foot_A(u) : vB; };
  LabelMap lm;
  lm.ids = ImageU16(W, H, 1, static_cast<uint16_t>(Label::Sky), unit::label_id);
  for (int x = 0; x < W; ++x) {
    const double v = foot(x);
    int yb = static_cast<int>(std::ceil(v)) - 1;  // the lowest pixel centre above the foot
    const bool in_region = x < u_end && std::isfinite(v) && v > g.horizon_y + 2;
    if (in_region) yb += 4 * (x >= u_corner && x % 3 == 0) - (x % 5 == 0);
    for (int y = 0; y < H; ++y) {
      if (y > g.horizon_y) lm.ids.at(x, y) = static_cast<uint16_t>(Label::Road);
      if (in_region && y <= yb && y >= yb - 60) lm.ids.at(x, y) = static_cast<uint16_t>(Label::Building);
    }
  }
  const BuildingFacades fac = building_facades(lm.ids, g, 1000);
  ASSERT_EQ(fac.regions.size(), 1u);
  const auto& R = fac.regions[0];
  std::vector<int> used;
  for (int i : R.column_plane)
    if (i >= 0 && std::find(used.begin(), used.end(), i) == used.end()) used.push_back(i);
  ASSERT_EQ(used.size(), 2u);
  const double tau = kFacadeInlier_px, vc = vB - g.horizon_y;
  const FacadePlane* A = nullptr;
  const FacadePlane* B = nullptr;
  for (int i : used) (std::fabs(fac.planes[i].nX) > std::fabs(fac.planes[i].nD) ? A : B) = &fac.planes[i];
  ASSERT_NE(A, nullptr);
  ASSERT_NE(B, nullptr);
  const double u_first = std::max(0.0, static_cast<double>(R.x0));
  double X_first = 0;  // the left end of the view on façade A: its extent along D
  {
    const double xn = (u_first - g.cx_px) / g.f_px;
    X_first = (XA / xn - h * sn) / c;
  }
  const double turn_A = std::atan(2 * tau * DB / vc / std::fabs(DB - X_first));
  const double turn_B = std::atan(2 * tau * DB / vc / (XB_end - XA));
  std::fprintf(stderr, "[corner] A: n (%.4f, %.4f) d %.2f m; B: n (%.4f, %.4f) d %.2f m; bounds: d %.1f%%, turn A %.1f°, B %.1f°\n",
               A->nX, A->nD, A->d_m, B->nX, B->nD, B->d_m, 100 * tau / vc, turn_A * 180 / M_PI, turn_B * 180 / M_PI);
  EXPECT_LE(std::fabs(A->d_m / -XA - 1), tau / vc);
  EXPECT_LE(std::fabs(B->d_m / DB - 1), tau / vc);
  EXPECT_LE(std::acos(std::min(1.0, -A->nX)), turn_A);  // true normal (−1, 0)
  EXPECT_LE(std::acos(std::min(1.0, B->nD)), turn_B);   // true normal (0, 1)
  // Columns away from the corner (where the two foot lines are more than 2τ + 1 px apart).
  int checked = 0;
  for (int x = R.x0; x < R.x0 + static_cast<int>(R.column_plane.size()); ++x) {
    if (std::fabs(foot_A(x) - vB) <= 2 * tau + 1) continue;
    const FacadePlane* want = x < u_corner ? A : B;
    EXPECT_EQ(&fac.planes[R.column_plane[x - R.x0]], want) << "column " << x;
    ++checked;
  }
  EXPECT_GT(checked, 200);
}

// Tram rails (drop_tram_rails, texture_under_rails): the synthetic street, no boxes, 16 m wide,
// with a standard-gauge track set in its right lanes (rails 0.065 m wide at X = 3.6 and 5.1 m:
// 1.435 m gauge plus a head; the markings at X = ±1.75 and ±7.8 m lie 1.85 m or more from either,
// so no marking pairs with a rail), day value 0.5 against the asphalt's 0.08. The lane stage takes the rails for markings; the rule
// clears them and nothing else: every marking pixel off the rails is kept, and every pixel it
// clears lies on a rail: within half the head's width in pixels (0.0325·f/z, across the road: at
// least its width across the projected line) plus 2.5 px of a rail's projected centre line (half
// a pixel, and the lane stage's blur, σ = 1 px, to 2σ).
namespace {
SyntheticCameraOptions tram_street(bool rails) {
  SyntheticCameraOptions o = camera_scene();
  o.boxes.clear();
  o.road_half_width_m = 8;
  if (rails) o.rail_X_m = {3.6, 5.1};
  return o;
}
}  // namespace
TEST(TramRails, APairAtTheGaugeIsClearedFromTheMarkingsAndNothingElse) {
  const SyntheticCameraOptions o = tram_street(true);
  const SyntheticCameraScene sc = make_synthetic_camera_scene(o);
  const ScenePreset p = urban();
  const WorkImages w = make_work_images(sc.day_linear_srgb, sc.labels.ids, p.work_max_width);
  ASSERT_EQ(w.scale, 1.0);
  ImageU8 lanes = lane_markings(w.luma, w.labels, p);
  const ImageU8 before = lanes;
  ImageU8 rails;
  const int cleared = drop_tram_rails(lanes, w.scale, o.camera, p, &rails);
  int on_rail = 0, rail_found = 0, marking_kept = 0, marking_lost = 0;
  // Pixel distance from (x, y) to rail X_r's projected centre line (through its points 10 and 30 m ahead).
  auto line_px = [&](double Xr, double x, double y) {
    double u1, v1, u2, v2, z;
    o.camera.project(Xr, 0, 10, &u1, &v1, &z);
    o.camera.project(Xr, 0, 30, &u2, &v2, &z);
    return std::fabs((u2 - u1) * (y - v1) - (v2 - v1) * (x - u1)) / std::hypot(u2 - u1, v2 - v1);
  };
  for (int y = 0; y < o.height; ++y)
    for (int x = 0; x < o.width; ++x) {
      double X, D, z;
      if (!before.at(x, y) || !o.camera.ground_point(x, y, &X, &D, &z)) continue;
      const double reach = 0.0325 * o.camera.f_px / z + 2.5;
      const bool rail = line_px(3.6, x, y) <= reach || line_px(5.1, x, y) <= reach;
      if (rails.at(x, y)) {
        EXPECT_EQ(lanes.at(x, y), 0);
        ++rail_found;
        on_rail += rail;
      } else if (!rail) {
        marking_kept += lanes.at(x, y) != 0;
        marking_lost += lanes.at(x, y) == 0;
      }
    }
  std::fprintf(stderr, "[rails] %d marking pixels cleared as rails (%d on the rails), markings kept %d, lost %d\n",
               cleared, on_rail, marking_kept, marking_lost);
  EXPECT_EQ(cleared, rail_found);
  EXPECT_GT(rail_found, 200);
  EXPECT_EQ(on_rail, rail_found);
  EXPECT_GT(marking_kept, 500);
  EXPECT_EQ(marking_lost, 0);
  // Without rails nothing is cleared; with no gauge in the preset neither.
  ScenePreset none = p;
  none.tram_gauges_m.clear();
  ImageU8 again = before;
  EXPECT_EQ(drop_tram_rails(again, w.scale, o.camera, none), 0);
  const SyntheticCameraScene plain = make_synthetic_camera_scene(tram_street(false));
  const WorkImages wp = make_work_images(plain.day_linear_srgb, plain.labels.ids, p.work_max_width);
  ImageU8 plain_lanes = lane_markings(wp.luma, wp.labels, p);
  EXPECT_EQ(drop_tram_rails(plain_lanes, wp.scale, o.camera, p), 0);
}

// Through the chain, the rails' night texture is the asphalt's: night_scene's darkened layer
// (texture times the ambient light: no geometry in it) on the rails that drop_tram_rails finds in
// the lane stage's markings (as above; the chain's own working images are the same at this size),
// against the same pixels of the scene without rails, over the
// same ratio on ordinary road (the class normalisation: the rails raise the road's mean day
// luminance): within the asphalt's own checker pattern (0.9 and 1.1 of its mean; a rail pixel
// takes the mean of asphalt pixels nearby, each 0.9 or 1.1, where its own is 0.9 or 1.1 in the
// scene without rails), [0.9/1.1, 1.1/0.9], widened by 64u (u = 2⁻²⁴: the float texture's and the
// darkened layer's roundings in the four values of the ratio of ratios, about ten each, and the
// median's). Before the rule
// the rails were up to 0.5/0.08 ≈ 6× the asphalt.
TEST(TramRails, TheirNightTextureIsTheAsphaltsBesideThem) {
  const SyntheticCameraOptions o = tram_street(true);
  const SyntheticCameraScene plain = make_synthetic_camera_scene(tram_street(false));
  const SyntheticCameraScene sc = make_synthetic_camera_scene(o);
  ScenePreset p = urban();
  p.rig = load_camera_rig("cityscapes");
  const NightScene a = night_scene(sc.day_linear_srgb, sc.labels, p, 1, true);
  const NightScene b = night_scene(plain.day_linear_srgb, plain.labels, p, 1, true);
  const WorkImages w = make_work_images(sc.day_linear_srgb, sc.labels.ids, p.work_max_width);
  ASSERT_EQ(w.scale, 1.0);
  ImageU8 lanes = lane_markings(w.luma, w.labels, p), rails;
  ASSERT_GT(drop_tram_rails(lanes, w.scale, o.camera, p, &rails), 200);
  // The normalisation ratio on road pixels away from the rails (−1.5 < X < −0.5 m).
  std::vector<double> k;
  for (int y = 0; y < o.height; y += 3)
    for (int x = 0; x < o.width; x += 3) {
      double X, D, z;
      if (sc.labels.ids.at(x, y) != static_cast<int>(Label::Road) || !o.camera.ground_point(x, y, &X, &D, &z) || X > -0.5 ||
          X < -1.5)
        continue;
      k.push_back(a.darkened.at(x, y, 1) / b.darkened.at(x, y, 1));
    }
  ASSERT_GT(k.size(), 100u);
  const double kn = quantile(k, 0.5), slack = 64 * std::ldexp(1.0, -24);
  int n = 0, inside = 0;
  double lo = 1e9, hi = 0;
  for (int y = 0; y < o.height; ++y)
    for (int x = 0; x < o.width; ++x) {
      if (!rails.at(x, y)) continue;
      const double r = a.darkened.at(x, y, 1) / b.darkened.at(x, y, 1) / kn;
      ++n;
      inside += r >= 0.9 / 1.1 * (1 - slack) && r <= 1.1 / 0.9 * (1 + slack);
      lo = std::min(lo, r);
      hi = std::max(hi, r);
    }
  std::fprintf(stderr, "[rails] %d pixels on the rails found: night texture over the asphalt's "
               "%.3f..%.3f (normalisation %.4f), %d inside [0.818, 1.222]\n", n, lo, hi, kn, inside);
  ASSERT_GT(n, 200);
  EXPECT_EQ(inside, n);
}

namespace {
// Whether the segment from the lamp L to the point (X, Y, D) (the ground's: Y = 0) passes through
// the box (its solid volume: |X − X_b| ≤ w/2, base ≤ Y ≤ height, D_b ≤ D ≤ D_b + length), by the
// slab method on the segment's parameter λ ∈ (0, t_end) (t_end < 1: stop short of a point on a
// box's face, which the segment reaches at λ = 1).
bool segment_hits_box(double xl, double hl, double X, double Y, double D, const SyntheticBox& B, double t_end = 1) {
  const double o[3] = {xl, hl, 0}, d[3] = {X - xl, Y - hl, D};
  const double lo[3] = {B.X_m - B.width_m / 2, B.base_m, B.D_m}, hi[3] = {B.X_m + B.width_m / 2, B.height_m, B.D_m + B.length_m};
  double t0 = 0, t1 = t_end;
  for (int a = 0; a < 3; ++a) {
    if (d[a] == 0) {
      if (o[a] < lo[a] || o[a] > hi[a]) return false;
      continue;
    }
    double ta = (lo[a] - o[a]) / d[a], tb = (hi[a] - o[a]) / d[a];
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta), t1 = std::min(t1, tb);
  }
  return t0 < t1;
}
// The shadows' street: a road without façades in view, a lead car 15 m ahead, a car parked on the
// left at 10 m, a block 0.4 m high (lower than the lamps) and a 4 m pole.
SyntheticCameraOptions beam_shadow_street() {
  SyntheticCameraOptions o = camera_scene();
  o.road_half_width_m = 1000;  // façades at X = ±1003 m: out of view at every D ≤ 200 m
  o.boxes = {{0.3, 15, 1.8, 1.5, 4.5},
             {-3.5, 10, 1.8, 1.5, 4.5},
             {2.8, 9, 1.2, 0.4, 0.3, Label::Wall},
             {-1.6, 20, 0.15, 4, 0.15, Label::Pole}};
  return o;
}
// The vertical shadows' street: the road of beam_shadow_street with the lead car, the parked car
// and the pole, a wall 26 m ahead behind the lead car and a pedestrian 13 m ahead behind a low
// block (0.55 m at 8 m).
SyntheticCameraOptions beam_shadow_vertical_street() {
  SyntheticCameraOptions o = camera_scene();
  o.road_half_width_m = 1000;
  o.boxes = {{0.3, 15, 1.8, 1.5, 4.5},
             {-3.5, 10, 1.8, 1.5, 4.5},
             {-1.6, 20, 0.15, 4, 0.15, Label::Pole},
             {0.0, 26, 8, 3, 0.3, Label::Wall},
             {-1.2, 8, 2.0, 0.55, 0.3, Label::Wall},
             {-1.2, 13, 0.6, 1.8, 0.3, Label::Person}};
  return o;
}
// The shadow tests' set-up on a street (beam_shadow_street or beam_shadow_vertical_street): its
// options, its scene, the urban preset, the camera geometry and the unshaded beam image
// (low_beam_illuminance on the ground classes). A test binds them by name:
//   const BeamShadowSetUp su(beam_shadow_street());
//   const auto& [o, s, p, g, E0] = su;
struct BeamShadowSetUp {
  explicit BeamShadowSetUp(SyntheticCameraOptions street)
      : o(std::move(street)), s(make_synthetic_camera_scene(o)), p(urban()), g(o.camera),
        E0(low_beam_illuminance(g, o.width, o.height, p, &s.labels.ids)) {}
  BeamShadowSetUp(const BeamShadowSetUp&) = delete;  // g refers to o's camera
  BeamShadowSetUp& operator=(const BeamShadowSetUp&) = delete;
  const SyntheticCameraOptions o;
  const SyntheticCameraScene s;
  const ScenePreset p;
  const CameraGeometry& g;
  const ImageF E0;
};
}  // namespace

// Shadows of the low beam on the ground (shade_low_beam_ground, docs/night.md §6c): a street of
// road only (the façades out of view) with a lead car 15 m ahead, a car parked on the left, a low
// block (0.4 m, lower than the lamps: a shadow of finite length) and a pole, their depth the ray
// cast's. The geometric shadow of each lamp is computed here from the boxes' volumes (the segment
// from the lamp to the ground point through a box). The shadow map places an edge to within its
// cell (2 px) and a pixel's samples lie up to a pixel apart, so a pixel whose lamp-view direction
// (u, v) = ((X − x_l)/D, h_l/D) lies within r = √2·cell + 1.5 px of an edge of the geometric shadow
// may go either way, and the margin (a solid point must be nearer than the ground one cell nearer)
// may leave unshaded the ground up to one cell nearer than the shadow's near end: such pixels
// (the classification not the same for every direction within r, or up to a cell + r nearer) are
// counted, not checked. Every other lit pixel: outside both shadows the old value exactly, in one
// lamp's shadow the other lamp's share (low_beam_lamp_lux_f32), in both 0.
TEST(EgoLowBeamShadow, GroundBehindABoxLosesTheLampsItHides) {
  const BeamShadowSetUp su(beam_shadow_street());
  const auto& [o, s, p, g, E0] = su;
  ImageF E = E0;
  const int threads = omp_get_max_threads();
  omp_set_num_threads(1);
  const BeamShadowStats st = shade_low_beam_ground(E, g, s.labels.ids, s.depth_m, p);
  omp_set_num_threads(2);
  ImageF E2 = E0;
  shade_low_beam_ground(E2, g, s.labels.ids, s.depth_m, p);
  omp_set_num_threads(threads);
  ASSERT_EQ(std::memcmp(E.data(), E2.data(), E.size() * sizeof(float)), 0) << "1 and 2 threads differ";
  // The chain hands its label runs: the same image from them.
  ImageF E3 = E0;
  shade_low_beam_ground_with(E3, g, s.labels.ids, s.depth_m, p, label_runs(s.labels.ids).get());
  ASSERT_EQ(std::memcmp(E.data(), E3.data(), E.size() * sizeof(float)), 0) << "with the label runs";
  // The solid points placed one by one (ISA cap 0), eight at a time (cap 1: place_row_avx2, where
  // the machine has AVX2) and sixteen at a time (AVX-512, where the machine has it): the same image.
  for (const int isa : {0, 1}) {
    beam_max_isa(isa);
    ImageF E4 = E0;
    shade_low_beam_ground(E4, g, s.labels.ids, s.depth_m, p);
    beam_max_isa(2);
    ASSERT_EQ(std::memcmp(E.data(), E4.data(), E.size() * sizeof(float)), 0) << "ISA cap " << isa;
  }
  const double hl = p.beam_lamp_height_m, xls[2] = {-0.5 * p.beam_lamp_spacing_m, 0.5 * p.beam_lamp_spacing_m};
  const double cell = 2 / g.f_px, r = (std::sqrt(2.0) * 2 + 1.5) / g.f_px;
  // Geometric shadow of lamp k at the ground point in lamp-view direction (u, v).
  auto shadowed = [&](int k, double u, double v) {
    const double D = hl / v, X = xls[k] + u * D;
    for (const SyntheticBox& B : o.boxes)
      if (segment_hits_box(xls[k], hl, X, 0, D, B)) return true;
    return false;
  };
  int kept = 0, one[2] = {0, 0}, both = 0, band = 0, changed_share = 0;
  for (int y = 0; y < o.height; ++y)
    for (int x = 0; x < o.width; ++x) {
      if (!(E0.at(x, y) > 0)) {
        ASSERT_EQ(E.at(x, y), E0.at(x, y)) << x << "," << y;
        continue;
      }
      double X, D, z;
      ASSERT_TRUE(g.ground_point(x, y, &X, &D, &z));
      bool sh[2], sure = true;
      for (int k = 0; k < 2 && sure; ++k) {
        const double u = (X - xls[k]) / D, v = hl / D;
        sh[k] = shadowed(k, u, v);
        for (const double dv : {-r, -r / 2, 0.0, r / 2, r, cell + r / 2, cell + r})
          for (const double du : {-r, -r / 2, 0.0, r / 2, r})
            if (v + dv > 0 && shadowed(k, u + du, v + dv) != sh[k]) sure = false;
      }
      if (!sure) {
        ++band;
        continue;
      }
      if (!sh[0] && !sh[1]) {
        ASSERT_EQ(E.at(x, y), E0.at(x, y)) << x << "," << y;
        ++kept;
      } else if (sh[0] && sh[1]) {
        ASSERT_EQ(E.at(x, y), 0.f) << x << "," << y;
        ++both;
      } else {
        const int lit = sh[0] ? 1 : 0;
        const float share = low_beam_lamp_lux_f32(X, D, lit, p);
        ASSERT_EQ(E.at(x, y), share) << x << "," << y << " lamp " << lit;
        changed_share += share != E0.at(x, y);
        ++one[1 - lit];
      }
    }
  std::fprintf(stderr, "[beam shadow] %d lit pixels kept, %d in the left lamp's shadow only, %d in the right's "
               "only (%d of them changed), %d in both, %d within the edge band; shaded: %lld left, %lld right, %lld both\n",
               kept, one[0], one[1], changed_share, both, band, st.one_lamp[0], st.one_lamp[1], st.both);
  EXPECT_GT(kept, 10000);
  EXPECT_GT(one[0], 100);
  EXPECT_GT(one[1], 100);
  EXPECT_GT(changed_share, 100);
  EXPECT_GT(both, 100);
}

// Shadows of the low beam on vertical surfaces (BeamVerticalRows, docs/night.md §6c): the ground
// test's street with a wall 26 m ahead behind the lead car (each lamp's shadow of the car reaches
// beside the car's silhouette as the camera sees it) and a pedestrian 13 m ahead behind a low
// block (0.55 m at 8 m: the camera sees the pedestrian's legs over it, from 0.13 m up; both lamps'
// shadows cover them up to 0.49 m). Only what lies below the cut-off's top is shaded (the urban
// preset: below the lamps' height). Each lamp's geometric shadow at a vertical pixel's point P
// (from the depth, the rule's expressions in double) is computed from the boxes' volumes: the
// segment from the lamp to P, stopped 0.2 % short of P (P lies on its own box's face; 5 cm at
// 26 m, far less than any gap between the boxes), where P's direction lies below the top. The
// map places an edge to within its cell and a pixel's samples lie up to a pixel apart, so a pixel
// whose lamp-view direction lies within r = √2·cell + 1.5 px of an edge of the geometric shadow
// (same D) may go either way: counted, not checked. Every other lit vertical pixel: outside both
// shadows the old value exactly (the two lamps' shares summed, the rule's sum), in one lamp's
// shadow the other lamp's share (BeamVerticalRows::lamp_lux), in both 0. A front face's own points
// (one D) and a receding side's (its slope's margin) must not shade it.
TEST(EgoLowBeamShadow, VerticalSurfacesBehindABoxLoseTheLampsItHides) {
  const BeamShadowSetUp su(beam_shadow_vertical_street());
  const auto& [o, s, p, g, E0] = su;
  const int threads = omp_get_max_threads();
  std::vector<ImageF> out;
  for (const int t : {1, 2}) {
    omp_set_num_threads(t);
    for (const int isa : {2, 1, 0}) {
      beam_max_isa(isa);
      ImageF E = E0;
      add_low_beam_vertical(E, g, s.labels.ids, s.depth_m, nullptr, p);
      out.push_back(std::move(E));
    }
  }
  beam_max_isa(2);
  omp_set_num_threads(threads);
  for (size_t i = 1; i < out.size(); ++i)
    ASSERT_EQ(std::memcmp(out[0].data(), out[i].data(), out[0].size() * sizeof(float)), 0) << "run " << i << " differs";
  const ImageF& E = out[0];
  ImageF scratch = E0;
  const BeamVerticalRows rows(scratch, g, s.labels.ids, s.depth_m, nullptr, p);
  const auto& cls = beam_vertical_classes();
  const double hl = p.beam_lamp_height_m, xls[2] = {-0.5 * p.beam_lamp_spacing_m, 0.5 * p.beam_lamp_spacing_m};
  const double r = (std::sqrt(2.0) * 2 + 1.5) / g.f_px, c = std::cos(g.pitch_rad), sn = std::sin(g.pitch_rad);
  // Geometric shadow of lamp k at the point D ahead in lamp-view direction (u, v), below the
  // cut-off's top (dy = −v·D ≤ t·D·√(1 + u²), t = tan cutoff_max_v_deg ≥ 0 here).
  const double t_top = std::tan(p.beam_cutoff_max_v_deg * M_PI / 180);
  ASSERT_GE(t_top, 0);
  auto shadowed = [&](int k, double u, double v, double D) {
    if (-v > t_top * std::sqrt(1 + u * u)) return false;
    for (const SyntheticBox& B : o.boxes)
      if (segment_hits_box(xls[k], hl, xls[k] + u * D, hl - v * D, D, B, 0.998)) return true;
    return false;
  };
  int kept = 0, one[2] = {0, 0}, both = 0, band = 0, changed_share = 0, wall_or_person_shaded = 0;
  for (int y = 0; y < o.height; ++y)
    for (int x = 0; x < o.width; ++x) {
      const int id = s.labels.ids.at(x, y);
      if (!cls[id]) {
        ASSERT_EQ(E.at(x, y), E0.at(x, y)) << x << "," << y;
        continue;
      }
      const float s0 = rows.lamp_lux(x, y, 0), s1 = rows.lamp_lux(x, y, 1), old = s0 + s1;
      if (!(old > 0)) {
        ASSERT_EQ(E.at(x, y), old) << x << "," << y;
        continue;
      }
      const double z = s.depth_m.at(x, y), xn = (x - g.cx_px) / g.f_px, yn = (y - g.cy_px) / g.f_px;
      const double X = z * xn, D = z * (c - yn * sn), Y = g.mount_height_m - z * (sn + yn * c);
      bool sh[2], sure = true;
      for (int k = 0; k < 2 && sure; ++k) {
        const double u = (X - xls[k]) / D, v = (hl - Y) / D;
        sh[k] = shadowed(k, u, v, D);
        for (const double dv : {-r, -r / 2, 0.0, r / 2, r})
          for (const double du : {-r, -r / 2, 0.0, r / 2, r})
            if (shadowed(k, u + du, v + dv, D) != sh[k]) sure = false;
      }
      if (!sure) {
        ++band;
        continue;
      }
      if (!sh[0] && !sh[1]) {
        ASSERT_EQ(E.at(x, y), old) << x << "," << y;
        ++kept;
        continue;
      }
      wall_or_person_shaded += id == static_cast<int>(Label::Wall) || id == static_cast<int>(Label::Person);
      if (sh[0] && sh[1]) {
        ASSERT_EQ(E.at(x, y), 0.f) << x << "," << y;
        ++both;
      } else {
        const float share = sh[0] ? s1 : s0;
        ASSERT_EQ(E.at(x, y), share) << x << "," << y << " lamp " << (sh[0] ? 0 : 1) << " shaded";
        changed_share += share != old;
        ++one[sh[0] ? 0 : 1];
      }
    }
  std::fprintf(stderr, "[beam shadow, vertical] %d lit pixels kept, %d in the left lamp's shadow only, %d in the "
               "right's only (%d of them changed), %d in both (%d of the shaded on the wall or the pedestrian), "
               "%d within the edge band\n", kept, one[0], one[1], changed_share, both, wall_or_person_shaded, band);
  EXPECT_GT(kept, 10000);
  EXPECT_GT(one[0], 100);
  EXPECT_GT(one[1], 100);
  EXPECT_GT(changed_share, 100);
  EXPECT_GT(both, 100);
  EXPECT_GT(wall_or_person_shaded, 500);
}

// The vertical shadows' counts (BeamVerticalRows::shadow_stats: the EXR header's
// photosite/night/beam_shadow_vertical_{left,right,both}_pixels) on the vertical test's street
// (beam_shadow_vertical_street: the wall behind the lead car lies in each lamp's shadow alone
// beside the car and in both behind it, the pedestrian's legs in both; the ground test's street
// has only 13 shaded vertical pixels, all in both shadows, which would not tell the lamps apart;
// it is the chain's test below): with shadows on,
// a pixel in the left lamp's shadow alone holds the right lamp's share (lamp_lux(·, 1)), in the
// right's alone the left's, in both 0, so a direct count of the pixels whose E fell against the
// rule alone (shadows off), each classed by the value it now holds, gives the three counts. (A
// shaded pixel whose hidden lamp gave nothing keeps its value and would be counted by the rows
// only: none on this street, so the counts must match exactly.) Shadows off: all 0. The same at
// 1 and 2 threads and at each ISA cap (beam_max_isa(0): the counting of pixel()'s path; 1: of
// pixel() on the AVX2 candidates' columns; 2: the AVX-512 decision's).
TEST(EgoLowBeamShadow, VerticalCountsAreThePixelsWhoseBeamFell) {
  const BeamShadowSetUp su(beam_shadow_vertical_street());
  const auto& [o, s, p, g, E0] = su;
  auto run = [&](ImageF& E, bool shadows) {
    const BeamVerticalRows rows(E, g, s.labels.ids, s.depth_m, nullptr, p, shadows);
#pragma omp parallel for schedule(dynamic, 3)
    for (int y = 0; y < E.height(); ++y) rows.row(y);
    return rows.shadow_stats();
  };
  ImageF off = E0;
  const BeamShadowStats st_off = run(off, false);
  EXPECT_EQ(st_off.one_lamp[0], 0);
  EXPECT_EQ(st_off.one_lamp[1], 0);
  EXPECT_EQ(st_off.both, 0);
  const int threads = omp_get_max_threads();
  for (const int t : {1, 2})
    for (const int isa : {2, 1, 0}) {
      omp_set_num_threads(t);
      beam_max_isa(isa);
      ImageF on = E0;
      const BeamShadowStats st = run(on, true);
      beam_max_isa(2);
      omp_set_num_threads(threads);
      ImageF scratch = E0;
      const BeamVerticalRows rows(scratch, g, s.labels.ids, s.depth_m, nullptr, p, false);
      long long n[3] = {0, 0, 0};  // left only, right only, both
      for (int y = 0; y < o.height; ++y)
        for (int x = 0; x < o.width; ++x) {
          const float a = on.at(x, y), b = off.at(x, y);
          ASSERT_LE(a, b) << x << "," << y << " (shading only removes a lamp's share)";
          if (!(a < b)) continue;
          if (a == 0.f) ++n[2];
          else if (a == rows.lamp_lux(x, y, 1)) ++n[0];
          else if (a == rows.lamp_lux(x, y, 0)) ++n[1];
          else FAIL() << x << "," << y << ": " << a << " is neither lamp's share of " << b;
        }
      std::fprintf(stderr, "[beam shadow, vertical counts] %d thread(s), ISA cap %d: %lld / %lld / %lld (left / "
                   "right / both), direct %lld / %lld / %lld\n", t, isa, st.one_lamp[0], st.one_lamp[1], st.both,
                   n[0], n[1], n[2]);
      EXPECT_GT(n[0], 100);
      EXPECT_GT(n[1], 100);
      EXPECT_GT(n[2], 100);
      EXPECT_EQ(st.one_lamp[0], n[0]) << t << " thread(s), ISA cap " << isa;
      EXPECT_EQ(st.one_lamp[1], n[1]) << t << " thread(s), ISA cap " << isa;
      EXPECT_EQ(st.both, n[2]) << t << " thread(s), ISA cap " << isa;
    }
}

// ego_beam.shadows = false: the chain's beam image is the unshaded one. With the preset's default
// (true) the same scene (the ground test's boxes: a lead car, a parked car, a block and a pole,
// through night_scene) has shaded ground and vertical pixels; switched off, no pixel has less
// beam than with shadows on (shading only removes a lamp's share), some have more, the header's
// counts are 0, and the preset's value goes into the EXR header as 1 / 0.
TEST(EgoLowBeamShadow, SwitchedOffTheChainLightsAsIfNothingStoodBetween) {
  const SyntheticCameraOptions o = beam_shadow_street();
  const SyntheticCameraScene s = make_synthetic_camera_scene(o);
  ScenePreset p = urban();
  p.rig = load_camera_rig("cityscapes");
  ASSERT_TRUE(p.beam_shadows);  // the default
  const NightScene on = night_scene(s.day_linear_srgb, s.labels, p, 1);
  ScenePreset q = p;
  q.beam_shadows = false;
  const NightScene off = night_scene(s.day_linear_srgb, s.labels, q, 1);
  EXPECT_GT(on.beam_shadow.one_lamp[0] + on.beam_shadow.one_lamp[1] + on.beam_shadow.both, 0);
  EXPECT_EQ(off.beam_shadow.one_lamp[0] + off.beam_shadow.one_lamp[1] + off.beam_shadow.both, 0);
  const BeamShadowStats& v_on = on.beam_shadow_vertical, &v_off = off.beam_shadow_vertical;
  EXPECT_GT(v_on.one_lamp[0] + v_on.one_lamp[1] + v_on.both, 0) << "the chain hands the rows' vertical counts";
  EXPECT_EQ(v_off.one_lamp[0] + v_off.one_lamp[1] + v_off.both, 0);
  ASSERT_EQ(on.beam_lux.size(), off.beam_lux.size());
  long long more = 0, less = 0;
  for (size_t i = 0; i < on.beam_lux.size(); ++i) {
    const float a = on.beam_lux.data()[i], b = off.beam_lux.data()[i];
    if (b > a) ++more;
    if (b < a) ++less;
  }
  EXPECT_EQ(less, 0);
  EXPECT_GT(more, 1000) << "the lead car's wedge alone covers thousands of ground pixels";
  const auto a_on = scene_attributes(p), a_off = scene_attributes(q);
  ASSERT_TRUE(a_on.count("photosite/scene/ego_beam.shadows")) << "the header carries the switch";
  EXPECT_EQ(std::get<int>(a_on.at("photosite/scene/ego_beam.shadows")), 1);
  EXPECT_EQ(std::get<int>(a_off.at("photosite/scene/ego_beam.shadows")), 0);
}

// night_scene makes both kinds of the low beam's shadow maps inside its depth stage, on the first
// of its two threads (GroundShadowMaps, BeamVerticalRows' set-up: their fills then run in a nested
// region, of one thread), shares the low beam's rows between its two halves, and shades the ground
// after the stage. On the vertical shadows' street (ground and vertical pixels in each lamp's
// shadow), at 1 and 2 threads: the chain's beam image (the vertical surfaces' rows run in the light
// map's row pass) and its three shadow counts of each kind are the stage functions called one after
// the other at 1 thread on the chain's own geometry, depth and lane mask, bit for bit, and the night
// radiance is the same at both thread counts.
TEST(EgoLowBeamShadow, ChainShadowsAreTheirFunctionsAtOneAndTwoThreads) {
  const SyntheticCameraOptions o = beam_shadow_vertical_street();
  const SyntheticCameraScene s = make_synthetic_camera_scene(o);
  ScenePreset p = urban();
  p.rig = load_camera_rig("cityscapes");
  ASSERT_TRUE(p.beam_shadows);
  const int before = omp_get_max_threads();
  ImageF radiance[2];
  for (const int threads : {1, 2}) {
    omp_set_num_threads(threads);
    const NightScene ns = night_scene(s.day_linear_srgb, s.labels, p, 1);
    radiance[threads - 1] = ns.radiance;
    omp_set_num_threads(1);
    const CameraGeometry& g = ns.geometry;
    const BuildingFacades fac = building_facades(s.labels.ids, g, p.max_depth_m);
    ImageF beam = low_beam_illuminance(g, o.width, o.height, p, &s.labels.ids);
    const BeamShadowStats ground = shade_low_beam_ground(beam, g, s.labels.ids, ns.depth, p);
    const BeamVerticalRows rows(beam, g, s.labels.ids, ns.depth, &fac, p, true);
    for (int y = 0; y < o.height; ++y) rows.row(y);
    const BeamShadowStats vertical = rows.shadow_stats();
    omp_set_num_threads(before);
    EXPECT_GT(ground.one_lamp[0] + ground.one_lamp[1] + ground.both, 100) << "the street shades the ground";
    EXPECT_GT(vertical.one_lamp[0] + vertical.one_lamp[1] + vertical.both, 100) << "and vertical surfaces";
    EXPECT_EQ(ns.beam_lux.vec(), beam.vec()) << threads << " threads";
    for (int k = 0; k < 2; ++k) {
      EXPECT_EQ(ns.beam_shadow.one_lamp[k], ground.one_lamp[k]) << threads << " threads, lamp " << k;
      EXPECT_EQ(ns.beam_shadow_vertical.one_lamp[k], vertical.one_lamp[k]) << threads << " threads, lamp " << k;
    }
    EXPECT_EQ(ns.beam_shadow.both, ground.both) << threads << " threads";
    EXPECT_EQ(ns.beam_shadow_vertical.both, vertical.both) << threads << " threads";
  }
  EXPECT_EQ(radiance[0].vec(), radiance[1].vec()) << "the night radiance at 1 and 2 threads";
}

namespace {
// The mean forward distance D of a label's pixels at the metric depth (the synthetic car's one
// plane, D_c) and their count.
std::pair<double, int> label_plane_D_m(const ImageU16& ids, int label, const ImageF& depth, const CameraGeometry& g) {
  double D = 0;
  int n = 0;
  for (int y = 0; y < ids.height(); ++y)
    for (int x = 0; x < ids.width(); ++x)
      if (ids.at(x, y) == label) {
        const double yn = (y - g.cy_px) / g.f_px;
        D += depth.at(x, y) * (std::cos(g.pitch_rad) - yn * std::sin(g.pitch_rad));
        ++n;
      }
  return {n ? D / n : 0, n};
}
// add_street_light_rows at 1 and 3 threads (the column blocks in another order) and at every
// instruction set (the runs' eight-lane test and the class bits): the bits of `ref` and, given
// (≥ 0), its count of shaded (pixel, lamp) pairs.
void expect_street_rows_everywhere(const ImageF& ref, const ImageF& tex, const ImageU16& ids, const ImageF& depth,
                                   const CameraGeometry& g, const StreetLighting& s, const ScenePreset& p,
                                   long long shadow_pixels) {
  const int before = omp_get_max_threads();
  for (const int isa : {2, 1, 0})
    for (const int threads : {1, 3}) {
      street_light_max_isa(isa);
      omp_set_num_threads(threads);
      ImageF again(ref.width(), ref.height(), 3, 0.f, unit::radiance);
      const StreetRowsResult r = add_street_light_rows(again, tex, ids, depth, g, s, p, 1, nullptr);
      if (shadow_pixels >= 0) EXPECT_EQ(r.shadow_pixels, shadow_pixels) << isa << " " << threads;
      EXPECT_EQ(std::memcmp(again.data(), ref.data(), ref.size() * sizeof(float)), 0) << isa << " " << threads;
    }
  street_light_max_isa(2);
  omp_set_num_threads(before);
}
}  // namespace

// street_lamps.shadows (docs/night.md §7, "Shadows of the street lamps"): a car on the synthetic
// street (photosite's metric depth: one fronto-parallel plane at its contact, D_c) under two
// luminaires, one beyond it and to its left, one nearer the camera and to its right. The reference
// is a ray cast that does not share the rows' quadrilaterals: for a ground pixel's point G and a
// lamp S, the segment G→S crosses the car's plane at C = G + μ(S − G), μ = (D_c − D_G)/(D_S − D_G)
// in (0, 1); C projected into the image lands on the car's labelled silhouette (blocked) or not.
// Pixels whose crossing lies within 2 px of the silhouette's edge (the quadrilaterals' pixel
// edges against the labels' pixel centres, ±1 px, doubled) are not judged for that lamp. Every
// judged pixel must have lost exactly the blocked lamps' terms: (L_off − L_on)/(f·t/π) against
// Σ blocked E_k (the double law), within the derived float bound in the comment below; every
// pixel blocked from no lamp is bit-identical with and without shadows. The lamps are points here
// (street_lamps.penumbrae off: the sharp edges; the penumbrae's own test is below).
TEST(StreetLampShadows, ACarHidesTheGroundBehindItFromEachLamp) {
  SyntheticCameraOptions o = camera_scene();
  o.boxes = {{1.0, 15, 1.8, 1.5, 4.5}};
  const SyntheticCameraScene sc = make_synthetic_camera_scene(o);
  ScenePreset p = urban();
  ASSERT_FALSE(p.lamp_penumbrae);  // the default
  const CameraGeometry& g = o.camera;
  const int W = o.width, H = o.height;
  const ImageF depth = metric_depth(sc.labels, g, p.max_depth_m);
  const ImageF tex = reflectance_texture(sc.day_linear_srgb, sc.labels.ids, p);
  StreetLighting s;
  s.lamps = {{-2.0, 10, 24, false}, {4.5, 8, 9, false}};  // sorted by D in a plan; the rows need no order
  std::sort(s.lamps.begin(), s.lamps.end(), [](const StreetLamp& a, const StreetLamp& b) { return a.D_m < b.D_m; });
  s.peak_intensity_cd = 6000;
  ImageF on(W, H, 3, 0.f, unit::radiance), off(W, H, 3, 0.f, unit::radiance);
  ScenePreset p_off = p;
  p_off.lamp_shadows = false;
  ASSERT_TRUE(p.lamp_shadows);  // the default
  const StreetRowsResult r_on = add_street_light_rows(on, tex, sc.labels.ids, depth, g, s, p, 1, nullptr);
  const StreetRowsResult r_off = add_street_light_rows(off, tex, sc.labels.ids, depth, g, s, p_off, 1, nullptr);
  EXPECT_GT(r_on.shadow_quads, 0);
  EXPECT_EQ(r_off.shadow_pixels, 0);
  // The car's plane and silhouette.
  const int car = static_cast<int>(Label::Car);
  const std::pair<double, int> plane = label_plane_D_m(sc.labels.ids, car, depth, g);
  const double Dc = plane.first;  // a plain variable: the lambdas below take it
  ASSERT_GT(plane.second, 1000);
  auto car_near = [&](double u, double v, int r, bool* any, bool* all) {
    *any = false, *all = true;
    const int xc = static_cast<int>(std::lround(u)), yc = static_cast<int>(std::lround(v));
    for (int dy = -r; dy <= r; ++dy)
      for (int dx = -r; dx <= r; ++dx) {
        const int x = xc + dx, y = yc + dy;
        const bool c = x >= 0 && y >= 0 && x < W && y < H && sc.labels.ids.at(x, y) == car;
        *any |= c, *all &= c;
      }
  };
  const auto tl = streetlamp_tint(p);
  const double tG = static_cast<float>(tl[1] / M_PI);
  int blocked_px[2] = {0, 0}, lit_px = 0, unsure = 0;
  double worst = 0;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      double X, D;
      if (!ground_classes()[sc.labels.ids.at(x, y)] || !g.ground_point(x, y, &X, &D, nullptr)) continue;
      double lost = 0, Esum = 0;
      bool judged = true;
      int nb = 0, which = -1;
      for (size_t k = 0; k < s.lamps.size(); ++k) {
        const StreetLamp& l = s.lamps[k];
        const double Ek = street_illuminance_lux(X, D, StreetLighting{{l}, "", 0, 0, false, s.peak_intensity_cd}, p);
        if (std::fabs(D - l.D_m) > street_lamp_reach_m(l.Y_m, p)) continue;  // the row drops it: no term
        Esum += Ek;
        const double mu = (Dc - D) / (l.D_m - D);
        if (!(mu > 0 && mu < 1)) continue;
        const double Xc = X + mu * (l.X_m - X), Yc = mu * l.Y_m;
        double u, v;
        if (!g.project(Xc, Yc, Dc, &u, &v, nullptr)) continue;
        bool any, all;
        car_near(u, v, 2, &any, &all);
        if (all) lost += Ek, ++nb, which = static_cast<int>(k);
        else if (any) judged = false;
      }
      if (!judged) {
        ++unsure;
        continue;
      }
      if (nb == 0) {
        ++lit_px;
        for (int ch = 0; ch < 3; ++ch) ASSERT_EQ(on.at(x, y, ch), off.at(x, y, ch)) << x << "," << y;
        continue;
      }
      if (nb == 1) ++blocked_px[which];
      const double f = tex.at(x, y, 1) * tG;
      const double dE = (static_cast<double>(off.at(x, y, 1)) - on.at(x, y, 1)) / f;
      // Bound (u = 2⁻²⁴): a lamp's float term is within (62.6 + n)u of its law (street.cpp,
      // pool_term: ≤ 65u for n ≤ 2 lamps), the table within 1e-6 of the law; the interpolated
      // sum (interp_tolerance) is the same in both images, so it cancels, but where the shaded
      // sum is held at 0 (an interpolated sum below the blocked terms) dE falls short of them by
      // at most tol_interp·Esum; L = fl(fl(f·t)·E) in each image (2u each of L ≈ f·t·Esum) and
      // the shaded sum fl(E − e_k) 1u of Esum: so
      // |dE − lost| ≤ 65u·lost + 1e-6·lost + (6u + tol_interp)·Esum.
      const double tol = 65 * 0x1p-24 * lost + (6 * 0x1p-24 + p.lamp_interp_tolerance) * Esum + 1e-6 * lost;
      ASSERT_NEAR(dE, lost, tol) << x << "," << y << " X " << X << " D " << D << " lamps blocked " << nb;
      worst = std::max(worst, std::fabs(dE - lost) / tol);
    }
  std::fprintf(stderr, "[street lamp shadows] blocked from lamp 0 only %d, lamp 1 only %d px; %d lit, %d in the "
               "edge band; largest error/bound %.3f\n", blocked_px[0], blocked_px[1], lit_px, unsure, worst);
  EXPECT_GT(blocked_px[0], 200);
  EXPECT_GT(blocked_px[1], 200);
  EXPECT_GT(lit_px, 100000);
  EXPECT_LT(unsure, blocked_px[0] + blocked_px[1]);
  // The same bits at 1 and 3 threads and at every instruction set.
  expect_street_rows_everywhere(on, tex, sc.labels.ids, depth, g, s, p, r_on.shadow_pixels);
  // The spans from the label runs handed (the chain's depth stage hands them), from none (the
  // builder makes them: the light map alone, add_street_light_rows above) and from the runs of
  // other labels (not taken: made again) are the same, and handed to the rows they give the same
  // light. The other labels are road throughout: their runs, taken, would give no span.
  const std::shared_ptr<const LabelRuns> runs = label_runs(sc.labels.ids);
  ImageU16 road = sc.labels.ids;
  std::fill(road.data(), road.data() + road.size(), static_cast<uint16_t>(Label::Road));
  const std::shared_ptr<const LabelRuns> elsewhere = label_runs(road);
  auto spans_of = [&](const ImageU16& ids, const LabelRuns* lr) {
    StreetShadowBuilder b(ids, depth, g, s, p, lr);
#pragma omp parallel
    b.take_blocks();
    return b.finish();
  };
  const LampShadowRows a = spans_of(sc.labels.ids, nullptr), b = spans_of(sc.labels.ids, runs.get()),
                       c = spans_of(sc.labels.ids, elsewhere.get());
  ASSERT_GT(a.spans.size(), 0u);
  EXPECT_EQ(spans_of(road, elsewhere.get()).spans.size(), 0u);
  for (const auto& [q, which] : {std::pair(&b, "its runs"), std::pair(&c, "other labels' runs")}) {
    EXPECT_EQ(a.quads, q->quads) << which;
    EXPECT_EQ(a.row_start, q->row_start) << which;
    ASSERT_EQ(a.spans.size(), q->spans.size()) << which;
    for (size_t i = 0; i < a.spans.size(); ++i)
      ASSERT_TRUE(a.spans[i].y == q->spans[i].y && a.spans[i].x0 == q->spans[i].x0 &&
                  a.spans[i].x1 == q->spans[i].x1 && a.spans[i].lamp == q->spans[i].lamp)
          << which << " " << i;
  }
  ImageF handed(W, H, 3, 0.f, unit::radiance);
  add_street_light_rows(handed, tex, sc.labels.ids, depth, g, s, p, 1, nullptr, nullptr, nullptr, nullptr, 0, -1, &b);
  EXPECT_EQ(std::memcmp(handed.data(), on.data(), on.size() * sizeof(float)), 0);
}

// The disc's points' quadrilaterals four to a vector (disc_quads_avx2, StreetShadowBuilder's path
// with penumbrae on an AVX2 machine) against cast_quad from each point alone (the scalar path's),
// on random occluder runs and lamps around a Cityscapes-like camera: corners above the lamp (λ
// infinite, the reach's cap), runs near their lamp's reach and lamps beside the nearest ground in
// view (both caps binding on some points and not on others), points whose quadrilateral runs
// behind the camera (not drawn). The same bits of every corner and slope, the same points drawn
// and the same range of rows.
TEST(StreetLampShadows, DiscQuadsAreEachPointsOwn) {
  if (!photosite::detail::have_avx2()) GTEST_SKIP() << "no AVX2 here (or PHOTOSITE_MAX_ISA caps it): the vector path is not taken";
  constexpr int n = DiscQuads::kPoints;
  std::mt19937_64 rng(1201);
  std::uniform_real_distribution<double> U01(0.0, 1.0);
  const auto disc = lamp_disc_samples(0.5, n);
  long long drawn_pts = 0, out_pts = 0, inf_corners = 0;
  for (int trial = 0; trial < 20000; ++trial) {
    const double Hl = 6 + 4 * U01(rng), reach = 15 + 25 * U01(rng), Dbot = 1 + 4 * U01(rng);
    const double SXc = -8 + 16 * U01(rng), SDc = Dbot - 3 + 40 * U01(rng);
    const double pitch = 0.02 * (U01(rng) - 0.5);
    const double xb = -10 + 20 * U01(rng), wdt = 0.05 + 2 * U01(rng);
    const double Db = SDc + (trial % 3 == 0 ? -(1 + 12 * U01(rng)) : -4 + 20 * U01(rng)), Dt = Db + 0.3 * (U01(rng) - 0.5);
    const double Yb = 2 * U01(rng) * U01(rng), Yt = trial % 5 == 0 ? Hl * (1 + 0.2 * U01(rng)) : Yb + (Hl - Yb) * U01(rng);
    const double X[4] = {xb, xb + wdt, xb + wdt * 1.1, xb * 1.01}, D[4] = {Db, Db, Dt, Dt}, Y[4] = {Yb, Yb, Yt, Yt};
    inf_corners += Yt >= Hl * (1 - 1e-6);
    const QuadCast in{X, D, Y, Hl, reach, reach * reach, Dbot, 1024.0, 512.0, 2262.0, 1.22, std::cos(pitch),
                      std::sin(pitch)};
    double SX[n], SD[n];
    for (int j = 0; j < n; ++j) SX[j] = SXc + disc[j][0], SD[j] = SDc + disc[j][1];
    DiscQuads a, b;
    double alo, ahi, blo, bhi;
    const unsigned da = disc_quads_avx2(in, SX, SD, a, &alo, &ahi), db = disc_quads_scalar(in, SX, SD, b, &blo, &bhi);
    ASSERT_EQ(da, db) << "trial " << trial;
    if (da) {
      ASSERT_EQ(std::ceil(alo), std::ceil(blo)) << "trial " << trial;
      ASSERT_EQ(std::floor(ahi), std::floor(bhi)) << "trial " << trial;
    }
    for (int j = 0; j < n; ++j) {
      double u[4], v[4];
      const bool one = cast_quad(in, SX[j], SD[j], u, v, nullptr);
      ASSERT_EQ(one, (da >> j & 1) != 0) << "trial " << trial << " point " << j;
      (one ? drawn_pts : out_pts) += 1;
      for (int i = 0; i < 4; ++i) {
        ASSERT_EQ(std::bit_cast<uint64_t>(a.u[i][j]), std::bit_cast<uint64_t>(b.u[i][j])) << trial << " " << j << " " << i;
        ASSERT_EQ(std::bit_cast<uint64_t>(a.v[i][j]), std::bit_cast<uint64_t>(b.v[i][j])) << trial << " " << j << " " << i;
        ASSERT_EQ(std::bit_cast<uint64_t>(a.slope[i][j]), std::bit_cast<uint64_t>(b.slope[i][j]))
            << trial << " " << j << " " << i;
        if (one) ASSERT_EQ(std::bit_cast<uint64_t>(a.u[i][j]), std::bit_cast<uint64_t>(u[i]));
        if (one) ASSERT_EQ(std::bit_cast<uint64_t>(a.v[i][j]), std::bit_cast<uint64_t>(v[i]));
      }
    }
  }
  std::fprintf(stderr, "[disc quads] %lld points drawn, %lld behind the camera; %lld runs reaching above their lamp\n",
               drawn_pts, out_pts, inf_corners);
  EXPECT_GT(drawn_pts, 100000);
  EXPECT_GT(out_pts, 1000);
  EXPECT_GT(inf_corners, 1000);
}

// The disc's points' row spans at once (disc_row_spans_avx2, four points to a vector, the path
// StreetShadowBuilder takes with penumbrae on an AVX2 machine) against quad_row_span on each
// point's quadrilateral alone (the one-point path's routine), on random quadrilaterals: convex
// ones with rows along their top and bottom edges (the occluder runs' shape: both ends of a run's
// bottom, and of its top, share one image row), twisted ones, corners on half-pixel and whole-pixel
// values (crossings exactly at pixel centres and rows exactly at corners), quadrilaterals partly or
// wholly outside the image and points not drawn (v = −1e30). The same columns on every row, exactly.
TEST(StreetLampShadows, DiscRowSpansAreEachPointsOwn) {
  if (!photosite::detail::have_avx2()) GTEST_SKIP() << "no AVX2 here (or PHOTOSITE_MAX_ISA caps it): the vector path is not taken";
  constexpr int W = 300, H = 200, n = DiscQuads::kPoints;
  std::mt19937_64 rng(20261201);
  std::uniform_real_distribution<double> U(-60.0, 360.0), V(-40.0, 240.0), d(-20.0, 20.0);
  std::uniform_int_distribution<int> kind(0, 5);
  long long rows = 0, spans = 0, lanes_out = 0;
  for (int trial = 0; trial < 4000; ++trial) {
    DiscQuads q;
    for (int j = 0; j < n; ++j) {
      double u[4], v[4];
      const int k = kind(rng);
      if (k == 5) {  // not drawn
        for (int i = 0; i < 4; ++i) q.u[i][j] = 0, q.v[i][j] = -1e30, q.slope[i][j] = 0;
        ++lanes_out;
        continue;
      }
      if (k <= 2) {  // a run's quadrilateral: bottom edge (0, 1) and top edge (2, 3) each along a row
        const double vb = V(rng), vt = vb - std::fabs(d(rng)) * 3, ub = U(rng), ut = ub + d(rng) * 2;
        u[0] = ub, u[1] = ub + std::fabs(d(rng)), u[2] = ut + std::fabs(d(rng)) * 2, u[3] = ut;
        v[0] = v[1] = vb, v[2] = v[3] = vt;
      } else {  // any four corners (twisted ones too)
        for (int i = 0; i < 4; ++i) u[i] = U(rng), v[i] = V(rng);
      }
      if (k == 1 || k == 3) {  // on the half-pixel grid: crossings at pixel centres, rows at corners
        for (int i = 0; i < 4; ++i) u[i] = std::round(2 * u[i]) / 2, v[i] = std::round(2 * v[i]) / 2;
      }
      double sl[4];
      quad_slopes(u, v, sl);
      for (int i = 0; i < 4; ++i) q.u[i][j] = u[i], q.v[i][j] = v[i], q.slope[i][j] = sl[i];
    }
    for (int y = 0; y < H; ++y) {
      alignas(32) int32_t a0[n], a1[n];
      const unsigned got = disc_row_spans_avx2(q, W, y, a0, a1);
      for (int j = 0; j < n; ++j) {
        const double u[4] = {q.u[0][j], q.u[1][j], q.u[2][j], q.u[3][j]};
        const double v[4] = {q.v[0][j], q.v[1][j], q.v[2][j], q.v[3][j]};
        const double sl[4] = {q.slope[0][j], q.slope[1][j], q.slope[2][j], q.slope[3][j]};
        int x0 = -1, x1 = -1;
        const bool want = quad_row_span(u, v, sl, W, y, &x0, &x1);
        ASSERT_EQ(want, (got >> j & 1) != 0) << "trial " << trial << " point " << j << " row " << y;
        if (want) {
          ASSERT_EQ(a0[j], x0) << "trial " << trial << " point " << j << " row " << y;
          ASSERT_EQ(a1[j], x1) << "trial " << trial << " point " << j << " row " << y;
          ASSERT_TRUE(x0 >= 0 && x0 < x1 && x1 <= W);
          ++spans;
        }
      }
      // The scalar twin (the path at PHOTOSITE_MAX_ISA=scalar) is quad_row_span on each point.
      alignas(32) int32_t s0[n], s1[n];
      ASSERT_EQ(disc_row_spans_scalar(q, W, y, s0, s1), got);
      for (unsigned b = got; b; b &= b - 1) {
        const int j = std::countr_zero(b);
        ASSERT_TRUE(s0[j] == a0[j] && s1[j] == a1[j]);
      }
      ++rows;
    }
  }
  std::fprintf(stderr, "[disc row spans] %lld rows of 16 points, %lld spans, %lld points not drawn\n", rows, spans,
               lanes_out);
  EXPECT_GT(spans, 1000000);
}

// street_lamps.penumbrae (docs/night.md §7, "Shadows of the street lamps"): each luminaire's face
// is a horizontal disc of head_diameter_m at the mount height, taken as n = kLampDiscSamples
// points of equal area (lamp_disc_samples); a ground pixel in the shadow of m of lamp k's points
// loses m/n of k's term. On the car street of the test above, at head diameters 0.5 m (the
// presets') and 1 m, the reference casts rays that share nothing with the quadrilaterals: from the
// ground pixel's point G to a point Q of the disc the segment crosses the car's plane D_c at
// C = G + μ(Q − G), μ = (D_c − D_G)/(D_Q − D_G) in (0, 1), and C projected into the image lands on
// the car's labelled silhouette (blocked) or not. The disc's image on the car's plane is convex
// (a central projection of a disc), so the box around 48 rim points' crossings, padded by 2 px,
// holds it: where that box is all car or all not car the whole disc is hidden or seen.
//  (a) The builder's count m (its spans) against the reference's count m_ref of the same n points:
//      a point whose crossing lies within 2 px of the silhouette's edge (the test above's band)
//      may go either way, so m_ref ≤ m ≤ m_ref + u with u such points (counted unblocked in m_ref).
//  (b) The share m/n against the disc's exact visible share A, integrated by the reference over a
//      polar grid of n_r × n_t equal-area cells (a point at each cell's middle), where the part of
//      the disc hidden is a half-plane: the padded box meets the silhouette only along one column
//      edge (a straight line on the car's plane, whose preimage on the disc's plane through G is a
//      straight line; the box's rows all car there). Then |m/n − A| ≤ δ_n + ε_grid + u/n, with
//      δ_n the layout's half-plane discrepancy, sup over lines of |#(points beyond)/n − the
//      disc's area share beyond|, computed here (for each direction the count changes only at
//      the points' projections and the area share is monotone in the offset, so the sup is at
//      those ends; directions every 0.05°, between which the share moves by at most 2Δθ/π), and
//      ε_grid = (1 + 2n_r + n_t/2)/(n_r·n_t): a line crosses each of the n_r ring circles at most
//      twice and each of the n_t/2 diameters at most once, so it passes through at most that many
//      cells, each off by at most its own weight.
//  (c) The light: (L_off − L_on)/(f·t/π) against Σ_k E_k·m_k/n with the builder's m_k, within the
//      test above's float bound with 1 u more per term (the product e·(m/n)): an umbra pixel
//      (m = n) loses its whole term, a pixel in no lamp's shadow is bit-identical to shadows off.
//  (d) A pixel whose padded box is uniform for every lamp within reach is bit-identical to the
//      point lamps' image (penumbrae off).
// It fails with the head's size ignored (every point at the centre: (a) and (b)) or with the
// penumbrae off (m ∈ {0, n}: (b)). 1 and 3 threads and every instruction set give the same bits.
TEST(StreetLampShadows, PenumbraeAreTheDiscsVisibleShare) {
  SyntheticCameraOptions o = camera_scene();
  o.boxes = {{1.0, 15, 1.8, 1.5, 4.5}};
  const SyntheticCameraScene sc = make_synthetic_camera_scene(o);
  const CameraGeometry& g = o.camera;
  const int W = o.width, H = o.height;
  ScenePreset p = urban();
  ASSERT_TRUE(p.lamp_shadows && !p.lamp_penumbrae);  // the defaults
  p.lamp_penumbrae = true;
  const ImageF depth = metric_depth(sc.labels, g, p.max_depth_m);
  const ImageF tex = reflectance_texture(sc.day_linear_srgb, sc.labels.ids, p);
  StreetLighting s;
  s.lamps = {{4.5, 8, 9, false}, {-2.0, 10, 24, false}};  // by D
  s.peak_intensity_cd = 6000;
  const int n = kLampDiscSamples, nL = static_cast<int>(s.lamps.size());
  ASSERT_EQ(lamp_shadow_samples(p), n);
  // δ_n on the unit disc.
  double delta = 0;
  {
    const auto pts = lamp_disc_samples(2.0, n);
    auto beyond = [](double d) {
      d = std::clamp(d, -1.0, 1.0);
      return (std::acos(d) - d * std::sqrt(1 - d * d)) / M_PI;
    };
    std::vector<double> pr(n);
    const int na = 3600;
    for (int a = 0; a < na; ++a) {
      const double th = a * M_PI / na;
      for (int i = 0; i < n; ++i) pr[i] = pts[i][0] * std::cos(th) + pts[i][1] * std::sin(th);
      std::sort(pr.begin(), pr.end());
      for (int i = 0; i < n; ++i) {
        const double A = beyond(pr[i]);  // n − i points beyond just below pr[i], n − i − 1 just above
        delta = std::max({delta, std::fabs((n - i) / double(n) - A), std::fabs((n - i - 1) / double(n) - A)});
      }
    }
    delta += 2 * (M_PI / na) / M_PI;
  }
  std::fprintf(stderr, "[penumbrae] half-plane discrepancy of the %d points %.4f\n", n, delta);
  EXPECT_LT(delta, 0.145) << "street_detail.h states 0.144";
  constexpr int n_r = 64, n_t = 256;
  const double eps_grid = (1 + 2.0 * n_r + n_t / 2.0) / (n_r * n_t);
  // The car's plane and silhouette (as in the test above).
  const int car = static_cast<int>(Label::Car);
  const std::pair<double, int> plane = label_plane_D_m(sc.labels.ids, car, depth, g);
  const double Dc = plane.first;  // a plain variable: the lambdas below take it
  ASSERT_GT(plane.second, 1000);
  auto is_car = [&](int x, int y) { return x >= 0 && y >= 0 && x < W && y < H && sc.labels.ids.at(x, y) == car; };
  // The crossing of G → Q with the car's plane, projected; false: the plane is not between them.
  auto crossing = [&](double X, double D, double QX, double QY, double QD, double* u, double* v) {
    const double mu = (Dc - D) / (QD - D);
    if (!(mu > 0 && mu < 1)) return false;
    return g.project(X + mu * (QX - X), mu * QY, Dc, u, v, nullptr);
  };
  const auto tl = streetlamp_tint(p);
  const double tG = static_cast<float>(tl[1] / M_PI);
  const double u24 = 0x1p-24;
  long long penumbra_pairs[2] = {0, 0};
  ScenePreset p_point = p, p_off = p;
  p_point.lamp_penumbrae = false;
  p_off.lamp_shadows = false;
  ImageF on05;
  for (const double dia : {0.5, 1.0}) {
    const int di = dia < 0.75 ? 0 : 1;
    p.lamp_head_diameter_m = p_point.lamp_head_diameter_m = p_off.lamp_head_diameter_m = dia;
    const LampShadowRows spans = street_lamp_shadow_spans(sc.labels.ids, depth, g, s, p);
    ASSERT_EQ(spans.samples, n);
    // m per (lamp, pixel): a point's span counts 1, a span of all points n (street_detail.h), at most n.
    ASSERT_EQ(spans.ids_per_lamp(), n + 1);
    std::vector<uint8_t> m_code(static_cast<size_t>(nL) * W * H, 0);
    for (int y = 0; y < H; ++y)
      for (int32_t i = spans.row_start[y]; i < spans.row_start[y + 1]; ++i) {
        const ShadowSpan& sp = spans.spans[i];
        const int wgt = sp.lamp % (n + 1) == n ? n : 1;
        for (int x = sp.x0; x < sp.x1; ++x) {
          uint8_t& m = m_code[(static_cast<size_t>(sp.lamp / (n + 1)) * H + y) * W + x];
          m = static_cast<uint8_t>(std::min(n, m + wgt));
        }
      }
    ImageF on(W, H, 3, 0.f, unit::radiance), point(W, H, 3, 0.f, unit::radiance), off(W, H, 3, 0.f, unit::radiance);
    add_street_light_rows(on, tex, sc.labels.ids, depth, g, s, p, 1, nullptr);
    add_street_light_rows(point, tex, sc.labels.ids, depth, g, s, p_point, 1, nullptr);
    add_street_light_rows(off, tex, sc.labels.ids, depth, g, s, p_off, 1, nullptr);
    if (di == 0) on05 = on;
    const auto pts = lamp_disc_samples(dia, n);
    const double R = 0.5 * dia;
    long long judged_a = 0, judged_b = 0, umbra = 0, lit = 0, far = 0, mixed = 0;
    double worst_b = 0, worst_c = 0;
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x) {
        double X, D;
        if (!ground_classes()[sc.labels.ids.at(x, y)] || !g.ground_point(x, y, &X, &D, nullptr)) continue;
        double lost = 0, Esum = 0;
        bool uniform_all = true, any_m = false;
        for (int k = 0; k < nL; ++k) {
          const StreetLamp& l = s.lamps[k];
          if (std::fabs(D - l.D_m) > street_lamp_reach_m(l.Y_m, p)) continue;  // the row drops it: no term
          const double Ek = street_illuminance_lux(X, D, StreetLighting{{l}, "", 0, 0, false, s.peak_intensity_cd}, p);
          const int m = m_code[(static_cast<size_t>(k) * H + y) * W + x];
          Esum += Ek;
          lost += Ek * m / n;
          any_m |= m > 0;
          if (m > 0 && m < n) ++penumbra_pairs[di];
          // The disc's image: its rim's crossings and its centre's.
          int crossed = 0;
          double umin = INFINITY, umax = -INFINITY, vmin = INFINITY, vmax = -INFINITY;
          for (int i = 0; i <= 48; ++i) {
            const double th = 2 * M_PI * i / 48, r = i < 48 ? R : 0;
            double u, v;
            if (!crossing(X, D, l.X_m + r * std::cos(th), l.Y_m, l.D_m + r * std::sin(th), &u, &v)) continue;
            ++crossed;
            umin = std::min(umin, u), umax = std::max(umax, u), vmin = std::min(vmin, v), vmax = std::max(vmax, v);
          }
          if (crossed == 0) {  // the car's plane is not between G and the disc: seen whole
            ASSERT_EQ(m, 0) << x << "," << y << " lamp " << k;
            continue;
          }
          if (crossed < 49) {  // the disc straddles G's D: not judged
            ++mixed;
            uniform_all = false;
            continue;
          }
          const int bx0 = static_cast<int>(std::floor(umin - 2)), bx1 = static_cast<int>(std::ceil(umax + 2));
          const int by0 = static_cast<int>(std::floor(vmin - 2)), by1 = static_cast<int>(std::ceil(vmax + 2));
          int ncar_box = 0, columns_constant = 1, transitions = 0;
          for (int bx = bx0; bx <= bx1; ++bx) {
            const bool c0 = is_car(bx, by0);
            for (int by = by0; by <= by1; ++by) {
              const bool c = is_car(bx, by);
              ncar_box += c;
              columns_constant &= c == c0;
            }
            if (bx > bx0 && c0 != is_car(bx - 1, by0)) ++transitions;
          }
          const int box = (bx1 - bx0 + 1) * (by1 - by0 + 1);
          if (ncar_box == 0 || ncar_box == box) {  // the whole disc seen or hidden
            ASSERT_EQ(m, ncar_box ? n : 0) << x << "," << y << " lamp " << k << " d " << dia;
            if (m == n) ++umbra;
            continue;
          }
          uniform_all = false;
          // (a) the same n points, cast.
          int m_ref = 0, unsure = 0;
          for (const auto& q : pts) {
            double u, v;
            ASSERT_TRUE(crossing(X, D, l.X_m + q[0], l.Y_m, l.D_m + q[1], &u, &v));
            bool any = false, all = true;
            const int xc = static_cast<int>(std::lround(u)), yc = static_cast<int>(std::lround(v));
            for (int dy = -2; dy <= 2; ++dy)
              for (int dx = -2; dx <= 2; ++dx) {
                const bool c = is_car(xc + dx, yc + dy);
                any |= c, all &= c;
              }
            if (all) ++m_ref;
            else if (any) ++unsure;
          }
          ASSERT_TRUE(m >= m_ref && m <= m_ref + unsure)
              << x << "," << y << " lamp " << k << " d " << dia << ": m " << m << ", reference " << m_ref << " + "
              << unsure << " in the edge band";
          ++judged_a;
          // (b) where the hidden part is a half-plane: the exact share over the polar grid.
          if (!(columns_constant && transitions == 1)) continue;
          int hidden = 0;
          for (int ir = 0; ir < n_r; ++ir) {
            const double r = R * std::sqrt((ir + 0.5) / n_r);
            for (int it = 0; it < n_t; ++it) {
              const double th = 2 * M_PI * (it + 0.5) / n_t;
              double u, v;
              ASSERT_TRUE(crossing(X, D, l.X_m + r * std::cos(th), l.Y_m, l.D_m + r * std::sin(th), &u, &v));
              hidden += is_car(static_cast<int>(std::lround(u)), static_cast<int>(std::lround(v)));
            }
          }
          const double A = static_cast<double>(hidden) / (n_r * n_t), bound = delta + eps_grid + double(unsure) / n;
          ASSERT_LE(std::fabs(double(m) / n - A), bound)
              << x << "," << y << " lamp " << k << " d " << dia << ": m/n " << double(m) / n << ", exact " << A;
          worst_b = std::max(worst_b, std::fabs(double(m) / n - A) / bound);
          ++judged_b;
        }
        // (c) the light.
        if (!any_m) {
          ++lit;
          for (int ch = 0; ch < 3; ++ch) ASSERT_EQ(on.at(x, y, ch), off.at(x, y, ch)) << x << "," << y;
        } else {
          const double f = tex.at(x, y, 1) * tG;
          const double dE = (static_cast<double>(off.at(x, y, 1)) - on.at(x, y, 1)) / f;
          const double tol = 66 * u24 * lost + (6 * u24 + p.lamp_interp_tolerance) * Esum + 1e-6 * lost;
          ASSERT_NEAR(dE, lost, tol) << x << "," << y << " d " << dia;
          worst_c = std::max(worst_c, std::fabs(dE - lost) / tol);
        }
        // (d) far from every edge: the point lamps' bits.
        if (uniform_all) {
          ++far;
          for (int ch = 0; ch < 3; ++ch) ASSERT_EQ(on.at(x, y, ch), point.at(x, y, ch)) << x << "," << y;
        }
      }
    std::fprintf(stderr,
                 "[penumbrae] head %.1f m: %lld (pixel, lamp) pairs in a penumbra, %lld in an umbra; (a) %lld pairs "
                 "judged; (b) %lld half-plane pairs, largest error/bound %.3f; (c) largest error/bound %.3f, %lld "
                 "pixels lit by both; (d) %lld pixels far from every edge; %lld pairs not judged\n",
                 dia, penumbra_pairs[di], umbra, judged_a, judged_b, worst_b, worst_c, lit, far, mixed);
    EXPECT_GT(umbra, 1000) << "the umbrae behind the car";
    EXPECT_GT(judged_b, 200) << "the side edges' penumbrae";
    EXPECT_GT(far, 100000);
  }
  // The penumbrae's widths w = d·|G − P|/|P − S| grow with the head's diameter d (each pixel's
  // share is checked above against the exact geometry at both).
  EXPECT_GT(penumbra_pairs[1], penumbra_pairs[0]);
  // The same bits at 1 and 3 threads and at every instruction set.
  p.lamp_head_diameter_m = 0.5;
  expect_street_rows_everywhere(on05, tex, sc.labels.ids, depth, g, s, p, -1);
}
