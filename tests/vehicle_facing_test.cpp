// Which way each vehicle faces (issue 14 §2 "Head or tail"): light_map's decision per vehicle
// (the test hook of scene/vehicle_facing_detail.h) against our own annotation of the shared day
// frames, tests/data/vehicle_facing.csv.
#include <gtest/gtest.h>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <algorithm>
#include <array>
#include <map>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>
#include "photosite/io.h"
#include "photosite/scene/labels.h"
#include "photosite/scene/night.h"
#include "photosite/scene/rig.h"
#include "photosite/scene/scene_preset.h"
#include "scene/night_detail.h"
#include "scene/vehicle_facing_detail.h"
#include "test_util.h"

using namespace photosite;
using namespace photosite::scene;

namespace {

struct Truth {
  std::string dataset, frame;
  int instance = 0, x0 = 0, y0 = 0, x1 = 0, y1 = 0, pixels = 0;
  std::string facing, traffic, note;
};

std::vector<Truth> read_truth() {
  std::ifstream f(std::string(PHOTOSITE_SOURCE_DIR) + "/tests/data/vehicle_facing.csv");
  EXPECT_TRUE(f) << "tests/data/vehicle_facing.csv";
  std::vector<Truth> rows;
  std::string line;
  bool header = false;
  while (std::getline(f, line)) {
    if (line.empty() || line[0] == '#') continue;
    if (!header) {
      header = true;
      continue;
    }
    std::stringstream ss(line);
    std::vector<std::string> cells;
    std::string cell;
    for (int k = 0; k < 10 && std::getline(ss, cell, ','); ++k) cells.push_back(cell);
    std::getline(ss, cell);
    cells.push_back(cell);
    if (cells.size() != 11) {
      ADD_FAILURE() << "bad row: " << line;
      continue;
    }
    Truth t{cells[0], cells[1], std::stoi(cells[2]), std::stoi(cells[3]), std::stoi(cells[4]), std::stoi(cells[5]),
            std::stoi(cells[6]), std::stoi(cells[7]), cells[8], cells[9], cells[10]};
    rows.push_back(t);
  }
  return rows;
}

// A shared frame: the day image linearized and its labels (Cityscapes with instance ids; KITTI's
// semantic labels in the day image's frame, test::kitti_labels_in_frame).
std::pair<ImageF, LabelMap> shared_frame(const Truth& t) {
  const auto dir = test::shared_dir() / "data" / t.dataset;
  ImageFileInfo info;
  if (t.dataset == "cityscapes") {
    const ImageF day = read_image((dir / "leftImg8bit" / (t.frame + "_leftImg8bit.png")).string(), &info);
    LabelMap lab = read_labels((dir / "gtFine" / (t.frame + "_gtFine_labelIds.png")).string(),
                               (dir / "gtFine" / (t.frame + "_gtFine_instanceIds.png")).string(), day.width(),
                               day.height(), LabelFormat::Auto, ResizeLabels::None);
    return {linearize(day, info), std::move(lab)};
  }
  const auto lab_path = dir / "semantic" / (t.frame + ".png");
  const ImageF day = linearize(read_image((dir / "image_2" / (t.frame + ".png")).string(), &info), info);
  const ImageU16 crop = test::kitti_labels_in_frame(read_image_u16(lab_path.string()), day.width(), day.height());
  return {day, decode_labels(crop, LabelFormat::Auto, lab_path.string())};
}

// The lamps a vehicle gets: head (in traffic, facing the camera), tail (in traffic, facing away)
// or dark (parked: dark, or a seeded few with position lamps).
std::string lamps(const VehicleDecision& d) { return d.state != 1 ? "dark" : d.faces_camera ? "head" : "tail"; }

struct Tally {
  std::map<std::string, std::map<std::string, int>> confusion;  // [truth facing][lamps]
  int facing_n = 0, facing_right = 0;  // vehicles seen front or back: decision == truth
  std::map<std::string, int> rear_cue;    // [truth facing]: vehicles whose red blobs say "rear"
  // In traffic or parked (issue 14 §2 "Which vehicles"): [truth][decision], truth "traffic" or
  // "parked" ("unclear" left out), decision "traffic" (state 1) or "parked" (state 0 or 2).
  std::map<std::string, std::map<std::string, int>> traffic;
  int traffic_n = 0, traffic_right = 0;
  void add(const Truth& t, const VehicleDecision& d) {
    ++confusion[t.facing][lamps(d)];
    if (t.traffic != "unclear") {
      const std::string got = d.state == 1 ? "traffic" : "parked";
      ++traffic[t.traffic][got];
      ++traffic_n;
      traffic_right += got == t.traffic;
    }
    rear_cue[t.facing] += shows_rear(d.red_px, d.lens_px, d.pixels);
    if (t.facing == "side") return;
    ++facing_n;
    facing_right += d.faces_camera == (t.facing == "camera");
  }
  void print(const char* name) const {
    std::fprintf(stderr, "[facing %s] truth \\ lamps:   head  tail  dark\n", name);
    for (const char* f : {"camera", "away", "side"}) {
      auto it = confusion.find(f);
      auto get = [&](const char* l) {
        if (it == confusion.end()) return 0;
        auto j = it->second.find(l);
        return j == it->second.end() ? 0 : j->second;
      };
      std::fprintf(stderr, "[facing %s] %-8s            %4d  %4d  %4d\n", name, f, get("head"), get("tail"), get("dark"));
    }
    auto at = [](const std::map<std::string, int>& m, const char* k) { auto i = m.find(k); return i == m.end() ? 0 : i->second; };
    std::fprintf(stderr, "[facing %s] red blobs say rear on %d facing the camera, %d away, %d side-on\n", name,
                 at(rear_cue, "camera"), at(rear_cue, "away"), at(rear_cue, "side"));
    std::fprintf(stderr, "[facing %s] facing right on %d of %d vehicles seen front or back (%.1f%%)\n", name,
                 facing_right, facing_n, facing_n ? 100.0 * facing_right / facing_n : 0.0);
    auto tr = [&](const char* truth, const char* got) {
      auto i = traffic.find(truth);
      return i == traffic.end() ? 0 : at(i->second, got);
    };
    std::fprintf(stderr, "[traffic %s] truth \\ photosite:  traffic  parked\n", name);
    for (const char* t : {"traffic", "parked"})
      std::fprintf(stderr, "[traffic %s] %-8s              %5d   %5d\n", name, t, tr(t, "traffic"), tr(t, "parked"));
    std::fprintf(stderr, "[traffic %s] right on %d of %d vehicles judged in traffic or parked (%.1f%%)\n", name,
                 traffic_right, traffic_n, traffic_n ? 100.0 * traffic_right / traffic_n : 0.0);
  }
};

// Runs night_scene on every annotated frame of `dataset` and tallies the decisions.
Tally measure(const std::vector<Truth>& truth, const std::string& dataset) {
  Tally tally;
  std::map<std::string, std::vector<const Truth*>> by_frame;
  for (const Truth& t : truth)
    if (t.dataset == dataset) by_frame[t.frame].push_back(&t);
  for (const auto& [frame, rows] : by_frame) {
    const auto [day, lab] = shared_frame(*rows.front());
    ScenePreset p = load_scene_preset("night-urban");
    p.rig = rig_for_image(day.width(), day.height());
    std::vector<VehicleDecision> seen;
    set_vehicle_decision_sink(&seen);
    (void)night_scene(day, lab, p, 1);
    set_vehicle_decision_sink(nullptr);
    for (const Truth* t : rows) {
      const VehicleDecision* d = nullptr;
      for (const VehicleDecision& v : seen)
        if (v.instance == t->instance && v.x0 == t->x0 && v.y0 == t->y0 && v.x1 == t->x1 && v.y1 == t->y1) d = &v;
      if (!d) {
        ADD_FAILURE() << frame << ": no vehicle " << t->instance << " [" << t->x0 << ", " << t->y0 << ", " << t->x1
                      << ", " << t->y1 << "] in light_map";
        continue;
      }
      EXPECT_EQ(d->pixels, t->pixels) << frame << " " << t->instance;
      std::fprintf(stderr, "[facing] %s %5d [%4d %4d %4d %4d] truth %-6s %-7s lamps %-4s X %6.2f D %6.1f divide %5.2f red %d lens %d"
                   " | road %.2f..%.2f outer %.2f row %d median beside %d across %d gap %.2f strip %.2f%s\n",
                   frame.c_str(), t->instance, t->x0, t->y0, t->x1, t->y1, t->facing.c_str(), t->traffic.c_str(),
                   lamps(*d).c_str(), d->X, d->D, d->travel_divide, d->red_px, d->lens_px, d->road_left, d->road_right,
                   d->outer_X, d->kerb_row, d->beside_median, d->across_median, d->kerb_gap_m, d->strip_m,
                   t->traffic == "unclear" || (d->state == 1) == (t->traffic == "traffic") ? "" : "  <- wrong");
      tally.add(*t, *d);
    }
  }
  return tally;
}

}  // namespace

// The share of vehicles seen front or back whose facing light_map gets right, on each data set,
// must reach what the rule reached when it was written (Cityscapes 28 of 32, KITTI 8 of 8;
// docs/night.md "Head or tail") less 4 binomial standard errors: a rule that is as good passes
// whatever the luck of these few vehicles, one that is clearly worse fails. SE = sqrt(p(1 − p)/n)
// with p = (k + 1)/(n + 2) (Laplace's estimate: with k = n the plain k/n has SE 0), so the floors
// are 28/32 − 4·sqrt(0.853·0.147/32) = 0.625 and 8/8 − 4·sqrt(0.9·0.1/8) = 0.576. (The rule before
// the red lens cue got 27/32 and 7/8, inside these floors: it is the synthetic test below that
// fails without the cue.) Each vehicle's line and the confusion of lamps against the annotation
// are printed.
TEST(VehicleFacing, AnnotatedSharedFramesReachTheMeasuredAccuracy) {
  PHOTOSITE_REQUIRE_SHARED("data/cityscapes");
  PHOTOSITE_REQUIRE_SHARED("data/kitti");
  const std::vector<Truth> truth = read_truth();
  ASSERT_GE(truth.size(), 80u);
  const Tally cs = measure(truth, "cityscapes"), kitti = measure(truth, "kitti");
  cs.print("cityscapes");
  kitti.print("kitti");
  auto floor_of = [](int k, int n) {
    const double p = (k + 1.0) / (n + 2.0);
    return static_cast<double>(k) / n - 4 * std::sqrt(p * (1 - p) / n);
  };
  ASSERT_EQ(cs.facing_n, 32);
  ASSERT_EQ(kitti.facing_n, 8);
  EXPECT_GE(static_cast<double>(cs.facing_right) / cs.facing_n, floor_of(28, 32));
  EXPECT_GE(static_cast<double>(kitti.facing_right) / kitti.facing_n, floor_of(8, 8));
  // In traffic or parked (issue 14 §2 "Which vehicles"; docs/night.md "Which are lit"), on the
  // vehicles the annotation calls one or the other: held the same way to what the rule reached
  // when it was written (Cityscapes 42 of 47, KITTI 14 of 18) less 4 binomial standard errors:
  // 42/47 − 4·sqrt(0.878·0.122/47) = 0.702 and 14/18 − 4·sqrt(0.75·0.25/18) = 0.369. (The rule
  // before the row, local-kerb and median cues got 33/47 = 0.702 and 13/18: at the Cityscapes
  // floor; the synthetic VehicleTraffic tests below fail without the cues.)
  ASSERT_EQ(cs.traffic_n, 47);
  ASSERT_EQ(kitti.traffic_n, 18);
  EXPECT_GE(static_cast<double>(cs.traffic_right) / cs.traffic_n, floor_of(42, 47));
  EXPECT_GE(static_cast<double>(kitti.traffic_right) / kitti.traffic_n, floor_of(14, 18));
}

namespace {
SyntheticCameraOptions camera_scene() {
  SyntheticCameraOptions o;
  o.camera = camera_geometry(load_camera_rig("cityscapes"), o.width, o.height, VanishingPoint{});
  o.boxes = {{-3.5, 12, 1.8, 1.5, 4.5}, {3.2, 20, 1.8, 1.5, 4.5}};
  return o;
}
// light_map's decision for instance `instance` of a synthetic scene.
VehicleDecision decision(const ImageF& day, const LabelMap& lm, int instance) {
  ScenePreset p = load_scene_preset("night-urban");
  p.rig = load_camera_rig("cityscapes");
  std::vector<VehicleDecision> seen;
  set_vehicle_decision_sink(&seen);
  (void)night_scene(day, lm, p, 1);
  set_vehicle_decision_sink(nullptr);
  for (const VehicleDecision& d : seen)
    if (d.instance == instance) return d;
  ADD_FAILURE() << "no vehicle " << instance;
  return {};
}
}  // namespace

// The road's grey takes out the frame's colour cast: a neutral road photographed with a cast
// (R, G, B) x c = (0.75, 1, 0.8) gives gains g_k = mean(c)/c_k, so the balanced road is grey at
// its mean level. Rounding (scene/lights.cpp road_grey_gains sums floats in double): each cast
// sample is one float product, 2⁻²⁴ relative, so each channel's sum is c_k·S·(1 + Δ_k) with
// |Δ_k| ≤ 2⁻²⁴ (all terms positive), and a gain, a ratio of such sums, is within 2·2⁻²⁴; the
// float casts 0.75f, 1.0f are exact and 0.8f is 0.8 within 2⁻²⁴ (this side's m and m/c_k use
// 0.8); the n ≤ W·H/16 double additions and the gains' 4 operations add (n + 4)·2⁻⁵³.
TEST(VehicleFacing, RoadGreyGainsUndoACast) {
  const SyntheticCameraOptions o = camera_scene();
  SyntheticCameraScene s = make_synthetic_camera_scene(o);
  // Exact: the synthetic road's samples are equal in R, G and B, so the three sums are equal.
  EXPECT_EQ(road_grey_gains(s.day_linear_srgb, s.labels.ids)[0], 1.0);  // the synthetic road is grey
  const double n = static_cast<double>(s.labels.ids.size()) / 16 + 1;
  const double tol = 3 * 0x1p-24 + (n + 4) * 0x1p-53;
  const float cast[3] = {0.75f, 1.0f, 0.8f};
  for (size_t i = 0; i < s.day_linear_srgb.size(); ++i) s.day_linear_srgb[i] *= cast[i % 3];
  const auto g = road_grey_gains(s.day_linear_srgb, s.labels.ids);
  const double m = (0.75 + 1 + 0.8) / 3;
  // tol (above): 3 float roundings and the n + 4 double additions of the sums.
  EXPECT_NEAR(g[0], m / 0.75, tol * m / 0.75);
  EXPECT_NEAR(g[1], m / 1.0, tol * m);
  EXPECT_NEAR(g[2], m / 0.8, tol * m / 0.8);
  // No road: no balance.
  LabelMap none = s.labels;
  for (size_t i = 0; i < none.ids.size(); ++i)
    if (none.ids[i] == static_cast<uint16_t>(Label::Road)) none.ids[i] = static_cast<uint16_t>(Label::Sidewalk);
  EXPECT_EQ(road_grey_gains(s.day_linear_srgb, none.ids), (std::array<double, 3>{1, 1, 1}));
}

// A car seen from behind in daylight shows unlit rear lamps: a darker, paler red than a lit lamp.
// Box 0 (X = −3.5 m, left of the divide: oncoming by the side rule) gets two such lenses, 12 x 8 px
// in its front face's outer quarters (linear sRGB (0.2, 0.05, 0.04): a* 25, under the lit-lamp
// cue's 40), and the frame a green cast like Cityscapes' ((0.75, 1, 0.8): the lenses' a* 18, hue
// 42°, no longer a lens colour). The red lens cue on the road-balanced colours (a* 24, hue 32°)
// says it shows its rear: tail lamps. Without the cue (a* > 40 only) or without the balance it
// stays oncoming: head lamps. Without the lenses it is oncoming too.
TEST(VehicleFacing, DullRedRearLampsUnderAColourCastMeanTailLamps) {
  const SyntheticCameraOptions o = camera_scene();
  SyntheticCameraScene s = make_synthetic_camera_scene(o);
  // A grey car (the synthetic boxes are red: a red body, more than 20 % of the vehicle, is no
  // lens), then the cast over the whole frame.
  for (int y = 0; y < o.height; ++y)
    for (int x = 0; x < o.width; ++x)
      if (s.labels.instances.at(x, y) == 26000)
        for (int k = 0; k < 3; ++k) s.day_linear_srgb.at(x, y, k) = s.box_front.at(x, y) ? 0.15f : 0.1f;
  const float cast[3] = {0.75f, 1.0f, 0.8f};
  for (size_t i = 0; i < s.day_linear_srgb.size(); ++i) s.day_linear_srgb[i] *= cast[i % 3];
  const VehicleDecision plain = decision(s.day_linear_srgb, s.labels, 26000);
  ASSERT_EQ(plain.state, 1);  // in traffic
  EXPECT_TRUE(plain.faces_camera);
  EXPECT_EQ(plain.lens_px, 0);
  int x0 = o.width, y0 = o.height, x1 = -1, y1 = -1;
  for (int y = 0; y < o.height; ++y)
    for (int x = 0; x < o.width; ++x)
      if (s.labels.instances.at(x, y) == 26000 && s.box_front.at(x, y)) {
        x0 = std::min(x0, x); x1 = std::max(x1, x); y0 = std::min(y0, y); y1 = std::max(y1, y);
      }
  ASSERT_GT(x1 - x0, 100);
  ImageF rear = s.day_linear_srgb;
  const float lens[3] = {0.2f * cast[0], 0.05f * cast[1], 0.04f * cast[2]};
  for (int bx : {x0 + (x1 - x0) / 8, x1 - (x1 - x0) / 8 - 12})
    for (int y = y0 + 4 * (y1 - y0) / 10; y < y0 + 4 * (y1 - y0) / 10 + 8; ++y)
      for (int x = bx; x < bx + 12; ++x) {
        ASSERT_EQ(s.labels.instances.at(x, y), 26000);
        for (int k = 0; k < 3; ++k) rear.at(x, y, k) = lens[k];
      }
  const VehicleDecision d = decision(rear, s.labels, 26000);
  EXPECT_EQ(d.red_px, 0);       // the lit-lamp cue does not see them
  EXPECT_GE(d.lens_px, 2 * 6 * 10);  // each lens's interior (its border pixels have < 5 like neighbours)
  EXPECT_EQ(d.state, 1);
  EXPECT_FALSE(d.faces_camera);  // tail lamps
  // The cue's colour test itself: the cast lens is a lens colour only once balanced.
  const auto g = road_grey_gains(rear, s.labels.ids);
  EXPECT_TRUE(rear_lens_colour(lens, g));
  EXPECT_FALSE(rear_lens_colour(lens, {1, 1, 1}));
}

namespace {
// The synthetic road (half width 7 m, sidewalks to 10 m, façades beyond) with `boxes` and its
// labels relabelled by `relabel(x, y, X, label)` (X the pixel centre's ground X, m; only ground
// pixels below the horizon are offered); the decisions of every box, by box index.
std::vector<VehicleDecision> decisions(const std::vector<SyntheticBox>& boxes,
                                       const std::function<Label(int, int, double, Label)>& relabel) {
  SyntheticCameraOptions o = camera_scene();
  o.boxes = boxes;
  SyntheticCameraScene s = make_synthetic_camera_scene(o);
  for (int y = 0; y < o.height; ++y)
    for (int x = 0; x < o.width; ++x) {
      double X;
      if (!o.camera.ground_point(x + 0.5, y + 0.5, &X, nullptr, nullptr)) continue;
      uint16_t& id = s.labels.ids.at(x, y);
      id = static_cast<uint16_t>(relabel(x, y, X, static_cast<Label>(id)));
    }
  ScenePreset p = load_scene_preset("night-urban");
  p.rig = load_camera_rig("cityscapes");
  std::vector<VehicleDecision> seen;
  set_vehicle_decision_sink(&seen);
  (void)night_scene(s.day_linear_srgb, s.labels, p, 1);
  set_vehicle_decision_sink(nullptr);
  std::vector<VehicleDecision> out(boxes.size());
  for (const VehicleDecision& d : seen)
    if (d.instance >= 26000 && d.instance - 26000 < static_cast<int>(boxes.size())) out[d.instance - 26000] = d;
  for (size_t i = 0; i < boxes.size(); ++i) EXPECT_GT(out[i].pixels, 0) << "no vehicle for box " << i;
  return out;
}
}  // namespace

// Four cars parked nose to tail facing the camera 0.1 m inside the left edge of the road (X =
// −6 m, 1.8 m wide, 4.5 m long, 6 m apart: a parallel parking bay's length [U]), 16-34 m ahead,
// where the left sidewalk is paved as road up to the façades at X = −10 m (a forecourt, a
// junction's mouth: the measured carriageway reaches the façades and no kerb shows beside
// them). Seen from the ego lane they stand side by side in the image, each showing its front:
// a row of vehicles facing the camera, which moving traffic (a 2 s gap: 15 m or more at 30 km/h)
// would not form: parked, dark. The old rule (outer side more than kerb_strip_m = 1 m inside the
// measured edge) gave all four head lamps. The nearest alone is oncoming traffic: head lamps.
TEST(VehicleTraffic, ARowNoseToTailFacingTheCameraIsParked) {
  auto paved = [](int, int, double X, Label l) { return l == Label::Sidewalk && X < 0 ? Label::Road : l; };
  std::vector<SyntheticBox> row;
  for (int k = 0; k < 4; ++k) row.push_back({-6.0, 16.0 + 6 * k, 1.8, 1.5, 4.5});
  const std::vector<VehicleDecision> d = decisions(row, paved);
  for (int k = 0; k < 4; ++k) {
    EXPECT_NE(d[k].state, 1) << "car " << k << " of the row counts as in traffic";
    EXPECT_EQ(d[k].kerb_row, 4) << "car " << k;
    EXPECT_TRUE(d[k].faces_camera) << "car " << k;
  }
  const std::vector<VehicleDecision> one = decisions({row.front()}, paved);
  EXPECT_EQ(one[0].state, 1);
  EXPECT_EQ(one[0].kerb_row, 0);
  EXPECT_TRUE(one[0].faces_camera);
}

// A median: a 1 m strip of terrain at X = −3.5..−2.5 m splits the road into the ego carriageway
// (X > −2.5 m, measured from the labels) and a far one (−7..−3.5 m). Box 0 drives on the far
// carriageway (X = −5.25 m, 0.85 m off its kerb): oncoming traffic, head lamps (the old rule:
// outside the measured carriageway, parked). Box 1 drives in the ego carriageway's left lane
// beside the median (X = −1.4 m, its outer side 0.2 m from it, 30 m ahead): nobody parks against
// a median, in traffic (the old rule: within kerb_strip_m of the edge, parked). Box 2 stands at
// the right kerb (X = 6 m, 0.1 m off it): parked, as before, by the kerb beside it.
TEST(VehicleTraffic, AMedianIsNoKerbAndBeyondItIsOncomingTraffic) {
  auto median = [](int, int, double X, Label l) {
    return l == Label::Road && X > -3.5 && X < -2.5 ? Label::Terrain : l;
  };
  const std::vector<VehicleDecision> d =
      decisions({{-5.25, 20, 1.8, 1.5, 4.5}, {-1.4, 30, 1.8, 1.5, 4.5}, {6.0, 18, 1.8, 1.5, 4.5}}, median);
  // The measured ego carriageway ends at the median, exactly: street.cpp measures each row's edge
  // at 20-60 m to within one pixel of the true boundary (D/f_px ≤ 60/f_px across) and rounds the
  // rows' median to quarter metres; 60/f_px < 0.125, so an edge on the quarter grid comes back
  // exactly (as StreetLighting.PoolsAlongTheRoadEdgesHoldTheClassAverage).
  ASSERT_LT(60 / camera_scene().camera.f_px, 0.125);
  EXPECT_EQ(d[0].road_left, -2.5);
  EXPECT_TRUE(d[0].across_median);
  EXPECT_EQ(d[0].state, 1);
  EXPECT_TRUE(d[0].faces_camera);
  EXPECT_TRUE(d[1].beside_median);
  EXPECT_EQ(d[1].state, 1);
  // Box 2's kerb gap: 0.1 m (its outer side at X = 6.9 m, the sidewalk from road_half_width_m =
  // 7 m) to the walk's pixel: probe_beside counts the road pixels from the box's outer column on
  // its contact row, each z/f_px wide on the flat ground at that row's camera depth z. The labels
  // are drawn per pixel centre, and the first column beside the box has its centre outside the
  // box, at X ≥ 6.9 (the contact row lies on the box's near face, whose ground is no nearer than
  // the face): at most 0.1/(z/f_px) + 1 centres fall in [6.9, 7), so the measured gap is at
  // most 0.1 m + one pixel (k·(z/f_px) in double, 2⁻⁵³ relative). kKerbContact_m (0.5) is the
  // rule it must pass; the derived bound is tighter.
  double z = 0;
  ASSERT_TRUE(camera_scene().camera.ground_point(d[2].x1 + 1, d[2].y1 + 0.5, nullptr, nullptr, &z));
  const double px_m = z / camera_scene().camera.f_px;
  std::printf("kerb gap %.4f m, bound %.4f m (pixel %.4f m)\n", d[2].kerb_gap_m, 0.1 + px_m, px_m);
  EXPECT_LE(d[2].kerb_gap_m, (0.1 + px_m) * (1 + 0x1p-52));
  EXPECT_NE(d[2].state, 1);
}

namespace {
// Two grey cars of the synthetic road (camera_scene) under a green cast like Cityscapes': car 0
// (instance 26000) with two dull red rear-lamp lenses (the red lens cue only, as in
// DullRedRearLampsUnderAColourCastMeanTailLamps), car 1 (26001) with two saturated red lamps
// (a* > 40: the lit-lamp cue) and a near-white highlight in its lower half (the white cue).
// `red_lamps` false: car 1 without its red lamps.
SyntheticCameraScene cued_cars(bool red_lamps = true) {
  const SyntheticCameraOptions o = camera_scene();
  SyntheticCameraScene s = make_synthetic_camera_scene(o);
  const float cast[3] = {0.75f, 1.0f, 0.8f};
  for (int y = 0; y < o.height; ++y)
    for (int x = 0; x < o.width; ++x) {
      const int q = s.labels.instances.at(x, y);
      for (int k = 0; k < 3; ++k) {
        float& v = s.day_linear_srgb.at(x, y, k);
        if (q == 26000 || q == 26001) v = s.box_front.at(x, y) ? 0.15f : 0.1f;
        v *= cast[k];
      }
    }
  for (int q : {26000, 26001}) {
    int x0 = o.width, y0 = o.height, x1 = -1, y1 = -1;
    for (int y = 0; y < o.height; ++y)
      for (int x = 0; x < o.width; ++x)
        if (s.labels.instances.at(x, y) == q && s.box_front.at(x, y)) {
          x0 = std::min(x0, x); x1 = std::max(x1, x); y0 = std::min(y0, y); y1 = std::max(y1, y);
        }
    EXPECT_GT(x1 - x0, 40) << q;
    const int w = std::max(4, (x1 - x0) / 10), h = std::max(4, (y1 - y0) / 10);
    auto paint = [&](int bx, int by, const float* c) {
      for (int y = by; y < by + h; ++y)
        for (int x = bx; x < bx + w; ++x)
          if (s.labels.instances.at(x, y) == q)
            for (int k = 0; k < 3; ++k) s.day_linear_srgb.at(x, y, k) = c[k];
    };
    const int ly = y0 + 4 * (y1 - y0) / 10;
    if (q == 26000) {
      const float lens[3] = {0.2f * cast[0], 0.05f * cast[1], 0.04f * cast[2]};
      for (int bx : {x0 + (x1 - x0) / 8, x1 - (x1 - x0) / 8 - w}) paint(bx, ly, lens);
    }
    if (q == 26001) {
      const float red[3] = {0.8f, 0.02f, 0.02f}, white[3] = {0.95f, 0.95f, 0.95f};
      if (red_lamps)
        for (int bx : {x0 + (x1 - x0) / 8, x1 - (x1 - x0) / 8 - w}) paint(bx, ly, red);
      paint((x0 + x1) / 2 - w / 2, y0 + 7 * (y1 - y0) / 10, white);
    }
  }
  return s;
}

// The light map of a scene with the chain's own inputs (night_scene's geometry, depth, beam and
// lane mask), with the vehicle parts `vehicles` (null: made inside), with or without the
// geometry, and the vehicles' decisions it recorded (the test hook).
struct VehicleRun {
  LightMap map;
  std::vector<VehicleDecision> seen;
};
struct VehicleInputs {
  ScenePreset p;
  NightScene ns;
  ImageF tex;
  BuildingFacades fac;
  ImageU8 lanes;
  VehicleInputs(const ImageF& day, const LabelMap& lm) {
    p = load_scene_preset("night-urban");
    p.rig = load_camera_rig("cityscapes");
    ns = night_scene(day, lm, p, 1);
    tex = reflectance_texture(day, lm.ids, p);
    fac = building_facades(lm.ids, ns.geometry, p.max_depth_m);
    lanes = lanes_at_frame(ns.lanes_work, lm.ids);
  }
  VehicleRun run(const ImageF& day, const LabelMap& lm, const VehicleParts* vehicles, bool geometry) const {
    VehicleRun r;
    set_vehicle_decision_sink(&r.seen);
    r.map = geometry ? light_map_with(day, tex, lm, lanes, ns.beam_input, ns.vp, p, 1, &ns.geometry, &ns.depth,
                                      &ns.beam_lux, &fac, nullptr, true, false, vehicles)
                     : light_map_with(day, tex, lm, lanes, ns.beam_input, ns.vp, p, 1, nullptr, nullptr, nullptr,
                                      nullptr, nullptr, false, false, vehicles);
    set_vehicle_decision_sink(nullptr);
    return r;
  }
};
size_t differing_bytes(const ImageF& a, const ImageF& b) {
  if (!a.same_shape(b) || a.channels() != b.channels()) return SIZE_MAX;
  const auto* x = reinterpret_cast<const unsigned char*>(a.data());
  const auto* y = reinterpret_cast<const unsigned char*>(b.data());
  size_t n = 0;
  for (size_t i = 0; i < a.size() * sizeof(float); ++i) n += x[i] != y[i];
  return n;
}
// The same vehicles, decisions, lamps and light (radiance and night radiance) bit for bit.
void expect_same_run(const VehicleRun& got, const VehicleRun& want, const std::string& what) {
  EXPECT_EQ(differing_bytes(got.map.radiance, want.map.radiance), 0u) << what;
  EXPECT_EQ(differing_bytes(got.map.composed, want.map.composed), 0u) << what;
  EXPECT_EQ(got.map.stats.vehicle_lamps, want.map.stats.vehicle_lamps) << what;
  EXPECT_EQ(got.map.stats.vehicles_in_traffic, want.map.stats.vehicles_in_traffic) << what;
  EXPECT_EQ(got.map.stats.vehicles_parked, want.map.stats.vehicles_parked) << what;
  ASSERT_EQ(got.seen.size(), want.seen.size()) << what;
  for (size_t i = 0; i < got.seen.size(); ++i) {
    const VehicleDecision &g = got.seen[i], &w = want.seen[i];
    EXPECT_EQ(std::make_tuple(g.instance, g.cls, g.x0, g.y0, g.x1, g.y1, g.pixels, g.state, g.faces_camera, g.red_px,
                              g.lens_px),
              std::make_tuple(w.instance, w.cls, w.x0, w.y0, w.x1, w.y1, w.pixels, w.state, w.faces_camera, w.red_px,
                              w.lens_px))
        << what << ", vehicle " << i;
  }
}
}  // namespace

// The vehicle analysis's labels-and-day-image parts made ahead (night_scene makes the vehicle
// rows beside Canny, vehicle_rows_part, and the components, boxes and colour cues beside the
// Hough transform, add_vehicle_parts) and handed to the light map, the rows alone or all,
// give the light map's own result bit for bit: the same vehicles (boxes, pixel counts), cue and
// lens pixels, decisions, lamps and light, with the scene geometry and without (the image-space
// lamps), for instance ids, for the vehicle classes' connected components (no instance ids), and
// for a vehicle in the instance ids only (car 0's labels road: its rows, below and above car 1's,
// are found in the instance ids). The scene exercises every cue: car 0's lens pixels turn it to
// tail lamps, car 1's red lamps are red blobs.
TEST(VehicleParts, MadeAheadTheyGiveTheLightMapItsOwnLampsBitForBit) {
  const SyntheticCameraScene s = cued_cars();
  LabelMap no_instances = s.labels, instance_only = s.labels;
  no_instances.instances = ImageU16();
  for (size_t i = 0; i < instance_only.ids.size(); ++i)
    if (instance_only.instances[i] == 26000) instance_only.ids[i] = static_cast<uint16_t>(Label::Road);
  const std::vector<std::pair<std::string, const LabelMap*>> kinds = {
      {"instances", &s.labels}, {"components", &no_instances}, {"car 0 in the instance ids only", &instance_only}};
  for (const auto& [kind, lm] : kinds) {
    const VehicleInputs in(s.day_linear_srgb, *lm);
    const std::shared_ptr<VehicleParts> rows = vehicle_rows_part(*lm), all = vehicle_rows_part(*lm);
    add_vehicle_parts(*all, s.day_linear_srgb, *lm);
    for (const bool geometry : {true, false}) {
      const VehicleRun own = in.run(s.day_linear_srgb, *lm, nullptr, geometry);
      EXPECT_GT(own.map.stats.vehicle_lamps, 0) << kind;
      if (geometry && lm != &instance_only) {
        ASSERT_EQ(own.seen.size(), 2u) << kind;
        EXPECT_GT(own.seen[0].lens_px, 0) << kind;       // car 0: the lens cue ...
        EXPECT_FALSE(own.seen[0].faces_camera) << kind;  // ... makes it show its rear
        EXPECT_GT(own.seen[1].red_px, 0) << kind;        // car 1: red blobs
      }
      const std::string where = kind + (geometry ? ", geometry" : ", image space");
      expect_same_run(in.run(s.day_linear_srgb, *lm, rows.get(), geometry), own, where + ", the rows");
      expect_same_run(in.run(s.day_linear_srgb, *lm, all.get(), geometry), own, where + ", all parts");
    }
  }
}

// Parts made of other labels (other buffers: here the same scene with car 1 relabelled as road)
// are not taken, nor cues made of another day image (here without car 1's red lamps): the light
// map then makes them itself and gives its own result. (Taken, they would not: car 1 would have
// no lamps, or no red blobs.) add_vehicle_parts on rows of other labels makes them again.
TEST(VehicleParts, PartsOfOtherLabelsOrAnotherDayImageAreNotTaken) {
  const SyntheticCameraScene s = cued_cars(), plain = cued_cars(false);
  const VehicleInputs in(s.day_linear_srgb, s.labels);
  const VehicleRun own = in.run(s.day_linear_srgb, s.labels, nullptr, true);
  ASSERT_EQ(own.seen.size(), 2u);
  LabelMap other = s.labels;
  for (size_t i = 0; i < other.ids.size(); ++i)
    if (other.instances[i] == 26001) {
      other.ids[i] = static_cast<uint16_t>(Label::Road);
      other.instances[i] = static_cast<uint16_t>(Label::Road);
    }
  ASSERT_EQ(in.run(s.day_linear_srgb, other, nullptr, true).seen.size(), 1u);
  ASSERT_EQ(in.run(plain.day_linear_srgb, s.labels, nullptr, true).seen.at(1).red_px, 0);
  const std::shared_ptr<VehicleParts> rows_of_other = vehicle_rows_part(other), of_other = vehicle_rows_part(other);
  add_vehicle_parts(*of_other, s.day_linear_srgb, other);
  expect_same_run(in.run(s.day_linear_srgb, s.labels, rows_of_other.get(), true), own, "rows of other labels");
  expect_same_run(in.run(s.day_linear_srgb, s.labels, of_other.get(), true), own, "parts of other labels");
  const std::shared_ptr<VehicleParts> of_plain = vehicle_rows_part(s.labels);
  add_vehicle_parts(*of_plain, plain.day_linear_srgb, s.labels);
  expect_same_run(in.run(s.day_linear_srgb, s.labels, of_plain.get(), true), own, "cues of another day image");
  const std::shared_ptr<VehicleParts> remade = vehicle_rows_part(other);
  add_vehicle_parts(*remade, s.day_linear_srgb, s.labels);
  expect_same_run(in.run(s.day_linear_srgb, s.labels, remade.get(), true), own, "rows of other labels, made again");
}
