// Physical relations of the night stages (scene/lights.cpp, scene/darken.cpp, scene/night.cpp),
// checked through the public chain on synthetic scenes: retroreflection of lane markings, the
// low beam's illuminance against depth, traffic-signal detection and vehicle colour cues. The
// relations are independent of how depth is parameterised, so they hold for any geometry model.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>
#include <vector>

#include "photosite/night_chain.h"
#include "photosite/scene/night.h"
#include "photosite/sensor/pipeline.h"
#include "photosite/sensor/spectrum.h"

using namespace photosite;
using namespace photosite::scene;

namespace {
// The urban preset: each pixel of the light map holds only what was put there (glare is the
// lens's, applied later in the sensor).
ScenePreset no_bloom() { return load_scene_preset("night-urban"); }
double lum(const ImageF& img, size_t i) {
  const float c[3] = {img[3 * i], img[3 * i + 1], img[3 * i + 2]};
  return spectrum::luminance_cd_m2(c);
}
double median(std::vector<double> v) {
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}
}  // namespace

// Retroreflection (EN 1436): a lane marking under the ego beam has luminance L = R_L · E⊥, E⊥ the
// illuminance on a plane perpendicular to the direction of the incident light (CIE ILV 17-24-104),
// not the horizontal E_h the beam gives the road. The code takes E⊥ = E_h·d_c/h_l (d_c the ground
// point's distance from the lamps' midpoint; scene/lights.cpp marking_perp). Checked in two steps:
// 1. The code's formula: E_h at a marking pixel is the beam image's float value there, which is
//    low_beam_lux_f32 at the pixel's ground point bit for bit (EgoLowBeam.TableProjectedOntoThe-
//    MetricGround); L is recovered from the lights layer, Σ_k K_k·fl(lum·t_k/Σ K t) with lum =
//    R_L·E_h·(d_c/h_l) in double: each channel's float rounding u = 2⁻²⁴ (all terms ≥ 0) and the
//    double products' 10⁻¹⁵, so L/(R_L·E_h·d_c/h_l) is 1 within 2u at every marking pixel that no
//    other light reaches, and so at the median (the cars' lamp discs may cover a few).
// 2. The approximation against the definition, in double: at each such pixel's ground point
//    E_h·d_c/h_l (low_beam_lux) lies within [1/√(1 + q), 1/√(1 − q)] of E⊥ = Σ_lamps I/d²
//    (sign_beam_lux at Y = 0), q = (2a|X| + a²)/d_c², a the half spacing (both double, the same
//    angles: 10⁻¹² for their rounding).
// The old code used E_h itself: L/(R_L·E_h·d_c/h_l) = h_l/d_c, 0.02-0.1 here: step 1 fails.
TEST(ScenePhysics, MarkingLuminanceIsRLTimesBeamIlluminance) {
  ScenePreset p = no_bloom();
  p.street_road_luminance_cd_m2 = 0;  // no lamp pools: the light map's markings are retroreflection alone
  const SyntheticScene s = make_synthetic_road({});
  const NightScene n = night_scene(s.day_linear_srgb, s.labels, p, 1);
  ASSERT_EQ(n.lanes_work.width(), n.radiance.width()) << "the synthetic scene is below work_max_width";
  const int W = n.radiance.width();
  const double hl = p.beam_lamp_height_m, a = 0.5 * p.beam_lamp_spacing_m;
  std::vector<double> ratio;
  double worst_perp = 0, min_gain = 1e300, max_gain = 0;
  for (size_t i = 0; i < n.radiance.pixel_count(); ++i) {
    if (!n.lanes_work[i]) continue;
    double X, D, z;
    if (!n.geometry.ground_point(static_cast<double>(i % W), static_cast<double>(i / W), &X, &D, &z)) continue;
    const double E_h = low_beam_lux_f32(X, D, p);
    if (!(E_h > 0)) continue;
    const double dc = std::sqrt(X * X + D * D + hl * hl);
    ratio.push_back(lum(n.lights, i) / (p.marking_RL * E_h * dc / hl));
    // Step 2, in double at the ground point.
    const double perp = sign_beam_lux(X, 0, D, p), approx = low_beam_lux(X, D, p) * dc / hl;
    const double q = (2 * a * std::fabs(X) + a * a) / (dc * dc);
    ASSERT_GT(perp, 0);
    EXPECT_GE(approx / perp, 1 / std::sqrt(1 + q) - 1e-12) << X << " " << D;
    EXPECT_LE(approx / perp, 1 / std::sqrt(1 - q) + 1e-12) << X << " " << D;
    worst_perp = std::max(worst_perp, std::fabs(approx / perp - 1));
    min_gain = std::min(min_gain, dc / hl), max_gain = std::max(max_gain, dc / hl);
  }
  ASSERT_GE(ratio.size(), 100u);
  const double m = median(ratio);
  std::fprintf(stderr, "[scene] %zu marking pixels: median L / (R_L E_h d_c/h_l) = %.9f (%.3g u off); E⊥/E_h "
               "%.1f..%.1f; the approximation within %.2g of Σ I/d²\n", ratio.size(), m, (m - 1) / 0x1p-24, min_gain,
               max_gain, worst_perp);
  // (2u, u = 2⁻²⁴: step 1 of the derivation above the test)
  EXPECT_NEAR(m, 1.0, 2 * 0x1p-24);
}

// A lane marking's retroreflection belongs to the paint on the road, not to a car, a sign or a
// person standing on it. The lane mask is found at the working resolution (1024 wide for a
// 2048-wide frame: each working pixel is the frame pixel (2x + 1, 2y + 1) of the labels, resized
// by nearest neighbour) and read back over blocks of 2 x 2 frame pixels (lanes_at_frame), so a
// block can reach frame pixels of another class. Here the synthetic road at 2048 x 1024 is marked
// once; then, inside every marked block, the three frame pixels that the working labels do not
// read are relabelled car, traffic sign or person (bands of 16 columns in turn): the working
// images, and so the working mask, are the same, and on the old code all those pixels took the
// markings' L = R_L·E⊥. Every relabelled pixel's lights must be the light map's with no lane
// mask at all, bit for bit (the sign's own retroreflection on the signs, nothing on the car and
// person pixels), and the chain must still light the road's markings. That the test can see the
// difference: the light map with the mask read back without the labels differs on many of them.
TEST(ScenePhysics, MarkingRetroreflectionLeavesPixelsLabelledCarSignOrPerson) {
  ScenePreset p = no_bloom();
  p.street_road_luminance_cd_m2 = 0;  // no lamp pools: the lights are emitters and retroreflection
  SyntheticOptions o;
  o.width = 2048, o.height = 1024, o.vp_x = 1024, o.vp_y = 416, o.cars = 0;
  SyntheticScene s = make_synthetic_road(o);
  const int W = o.width, H = o.height;
  const ImageU8 work = night_scene(s.day_linear_srgb, s.labels, p, 1).lanes_work;
  ASSERT_EQ(work.width() * 2, W) << "the exact halving";
  const Label classes[3] = {Label::Car, Label::TrafficSign, Label::Person};
  std::vector<uint8_t> relabelled(static_cast<size_t>(W) * H, 0);
  ImageU8 unlabelled(W, H, 1, 0);  // the working mask read back without the labels (the old code's)
  int moved = 0;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      if (!work.at(x / 2, y / 2)) continue;
      unlabelled.at(x, y) = 255;
      if (x % 2 == 1 && y % 2 == 1) continue;  // read by the working labels: stays road
      s.labels.ids.at(x, y) = static_cast<uint16_t>(classes[(x / 16) % 3]);
      relabelled[static_cast<size_t>(y) * W + x] = 1;
      ++moved;
    }
  ASSERT_GT(moved, 1000);
  const NightScene n = night_scene(s.day_linear_srgb, s.labels, p, 1);
  ASSERT_EQ(n.lanes_work.vec(), work.vec()) << "the working mask must not see the relabelling";
  const ImageF tex = reflectance_texture(s.day_linear_srgb, s.labels.ids, p);
  const BuildingFacades fac = building_facades(s.labels.ids, n.geometry, p.max_depth_m);
  auto map = [&](const ImageU8& lanes) {
    return light_map(s.day_linear_srgb, tex, s.labels, lanes, n.beam_input, n.vp, p, 1, &n.geometry, &n.depth,
                     &n.beam_lux, &fac)
        .radiance;
  };
  const ImageF none = map(ImageU8(W, H, 1, 0)), old = map(unlabelled);
  int differ_old = 0, road_lit = 0;
  for (size_t i = 0; i < relabelled.size(); ++i) {
    if (!relabelled[i]) {
      road_lit += unlabelled[i] && lum(n.lights, i) > 0;
      continue;
    }
    for (int c = 0; c < 3; ++c)
      ASSERT_EQ(n.lights[3 * i + c], none[3 * i + c])
          << "pixel " << i % W << "," << i / W << " (class " << s.labels.ids[i] << "), channel " << c;
    differ_old += old[3 * i] != none[3 * i] || old[3 * i + 1] != none[3 * i + 1] || old[3 * i + 2] != none[3 * i + 2];
  }
  std::fprintf(stderr, "[markings] %d pixels relabelled, %d of them lit as markings by the unlabelled mask; %d road "
               "marking pixels lit\n", moved, differ_old, road_lit);
  EXPECT_GT(differ_old, moved / 4);
  EXPECT_GT(road_lit, 1000);
}

namespace {
// A small hand-made scene for the light map: every pixel Sky (no lights of its own) unless set.
struct Canvas {
  int w, h;
  ImageF day;
  LabelMap labels;
  Canvas(int w_, int h_) : w(w_), h(h_), day(w_, h_, 3, 0.05f, unit::dimensionless) {
    labels.ids = ImageU16(w, h, 1, static_cast<uint16_t>(Label::Sky));
  }
  void fill(int x0, int y0, int x1, int y1, Label l, float r, float g, float b) {
    for (int y = y0; y < y1; ++y)
      for (int x = x0; x < x1; ++x) {
        labels.ids.at(x, y) = static_cast<uint16_t>(l);
        day.at(x, y, 0) = r, day.at(x, y, 1) = g, day.at(x, y, 2) = b;
      }
  }
  LightMap lights(const ScenePreset& p, double vp_x, double vp_y) const {
    const ImageF tex = reflectance_texture(day, labels.ids, p);
    VanishingPoint vp;
    vp.x = vp_x, vp.y = vp_y;
    return light_map(day, tex, labels, ImageU8(w, h, 1, 0), ImageF(w, h, 1, 0.f), vp, p, 1);
  }
  double lum_at(const ImageF& L, int x, int y) const { return lum(L, static_cast<size_t>(y) * w + x); }
};
}  // namespace

// A lamp's radiance: its colour scaled to the luminance in double and stored as float, 2⁻²⁴
// relative per channel; the channels are ≥ 0, so the luminance Σ_k K_k c_k is off by at most 2⁻²⁴
// of it too (twice that for the double arithmetic on both sides).
constexpr double kLampRounding = 2 * 0x1p-24;

// Without the metric geometry a tall pole whose top is above the vanishing point carries a lamp
// head, a disc at lamps.streetlamp_luminance_cd_m2 in the lamps' colour: with
// lamps.streetlamp_type = "hps" CIE HP1's (spectrum::kHp1BandIntegral's ratios), each channel the
// colour scaled in double and stored as float (the ratios within 2·2⁻²⁴, the luminance within
// kLampRounding).
TEST(ScenePhysics, PoleLampsWithoutGeometryTakeTheStreetLampType) {
  ScenePreset p = no_bloom();
  p.streetlamp_type = StreetlampType::Hps;
  Canvas c(64, 80);
  c.fill(30, 10, 32, 75, Label::Pole, 0.3f, 0.3f, 0.3f);
  const LightMap m = c.lights(p, 32, 40);
  EXPECT_EQ(m.stats.pole_lamps, 1);
  const double* h = spectrum::kHp1BandIntegral;
  int lit = 0;
  for (size_t i = 0; i < m.radiance.pixel_count(); ++i) {
    const double r = m.radiance[3 * i], g = m.radiance[3 * i + 1], b = m.radiance[3 * i + 2];
    if (!(g > 0)) continue;
    ++lit;
    // Each channel scaled in double and stored as float (2⁻²⁴): a ratio of two within 2·2⁻²⁴.
    EXPECT_NEAR(r / g, h[0] / h[1], 2 * 0x1p-24 * h[0] / h[1]) << i;
    EXPECT_NEAR(b / g, h[2] / h[1], 2 * 0x1p-24 * h[2] / h[1]) << i;
    EXPECT_NEAR(lum(m.radiance, i), p.streetlamp_luminance_cd_m2, kLampRounding * p.streetlamp_luminance_cd_m2) << i;
  }
  EXPECT_GT(lit, 4);
}

// Traffic signals: a lit lens (a traffic-light pixel of signal colour, CIELAB L* ≥ 25 and chroma
// ≥ 30) emits the preset's signal luminance (a 200-400 cd LED signal over a 200 mm lens, ~1e4
// cd/m²) in its colour; the dark housing, and the same red outside a traffic light, emit nothing.
// The lamp colour (in a scene made without a camera, as here: the box guesses) is scaled so
// Σ_k K_k c_k is that luminance: exact up to float rounding (kLampRounding).
TEST(ScenePhysics, LitSignalLensesEmitTheSignalLuminanceInTheirColour) {
  const ScenePreset p = no_bloom();
  Canvas c(64, 40);
  c.fill(4, 4, 10, 10, Label::TrafficLight, 0.8f, 0.03f, 0.03f);    // red lens
  c.fill(14, 4, 20, 10, Label::TrafficLight, 0.8f, 0.35f, 0.01f);   // amber lens
  c.fill(24, 4, 30, 10, Label::TrafficLight, 0.02f, 0.5f, 0.3f);    // green (blue-green) lens
  c.fill(34, 4, 40, 10, Label::TrafficLight, 0.03f, 0.03f, 0.03f);  // unlit housing
  c.fill(44, 4, 50, 10, Label::Static, 0.8f, 0.03f, 0.03f);         // red, but not a signal
  const LightMap m = c.lights(p, 32, 20);
  EXPECT_EQ(m.stats.signals, 3 * 36);
  for (int x0 : {4, 14, 24})
    for (int y = 4; y < 10; ++y)
      for (int x = x0; x < x0 + 6; ++x)
        EXPECT_NEAR(c.lum_at(m.radiance, x, y), p.signal_luminance_cd_m2, kLampRounding * p.signal_luminance_cd_m2) << x << "," << y;
  auto at = [&](int x, int k) { return m.radiance.at(x, 6, k); };
  EXPECT_GT(at(6, 0), 10 * at(6, 1));                       // red: R dominates
  EXPECT_GT(at(16, 0), at(16, 1));                          // amber: R over G, G well above 0
  EXPECT_GT(at(16, 1), 0.2 * at(16, 0));
  EXPECT_EQ(at(26, 0), 0.f);                                // green: no R, G over B
  EXPECT_GT(at(26, 1), at(26, 2));
  for (int x0 : {34, 44})
    for (int k = 0; k < 3; ++k) EXPECT_EQ(at(x0 + 2, k), 0.f) << x0;
}

// The same lenses and a rear lamp in the night chain's scene for a camera (scene_for_camera): each
// takes that camera's metamer of its LED (spectrum::kRedLed, kAmberLed, kGreenLed; camera_metamer_rgb,
// Spectrum.SignalLedCameraMetamersAreTheClosestNonNegativeBoxes) times the preset's photometric
// luminance: each channel w_k·L in double stored as float (2⁻²⁴ relative). The luminance is the
// LED's photometric one (683 ∫ S·V dλ), so the box luminance Σ_k K_k c_k of the pixel is not
// signal_luminance_cd_m2 (docs/night.md §7); the test above keeps the box guesses of a scene made
// without a camera. The old code drew the box guesses whatever the camera.
TEST(ScenePhysics, SignalsAndRearLampsTakeTheCamerasMetamerOfTheirLed) {
  const CameraPreset cam = load_camera_preset("onsemi-ar0331");
  const ScenePreset p = scene_for_camera(no_bloom(), cam);
  Canvas c(120, 60);
  c.fill(4, 4, 10, 10, Label::TrafficLight, 0.8f, 0.03f, 0.03f);    // red lens
  c.fill(14, 4, 20, 10, Label::TrafficLight, 0.8f, 0.35f, 0.01f);   // amber lens
  c.fill(24, 4, 30, 10, Label::TrafficLight, 0.02f, 0.5f, 0.3f);    // green (blue-green) lens
  c.fill(70, 30, 110, 54, Label::Car, 0.1f, 0.1f, 0.12f);            // right of the VP: seen from behind
  c.fill(74, 46, 80, 51, Label::Car, 0.8f, 0.02f, 0.02f);            // its red lens
  const LightMap m = c.lights(p, 60, 20);
  EXPECT_EQ(m.stats.signals, 3 * 36);
  auto expect_led = [&](int x, int y, spectrum::LampSpectrum s, double L) {
    const auto w = camera_metamer_rgb(cam, s);
    ASSERT_GT(w[0] + w[1] + w[2], 0);
    for (int k = 0; k < 3; ++k)
      // The LED metamer times L, stored as float: one rounding, 2^-24 relative.
      EXPECT_NEAR(m.radiance.at(x, y, k), w[k] * L, 0x1p-24 * w[k] * L) << x << "," << y << " box " << k;
  };
  for (int y = 4; y < 10; ++y)
    for (int x = 0; x < 6; ++x) {
      expect_led(4 + x, y, spectrum::LampSpectrum::RedLed, p.signal_luminance_cd_m2);
      expect_led(14 + x, y, spectrum::LampSpectrum::AmberLed, p.signal_luminance_cd_m2);
      expect_led(24 + x, y, spectrum::LampSpectrum::GreenLed, p.signal_luminance_cd_m2);
    }
  for (int y = 47; y < 50; ++y)  // inside the rear lamp's lens (all 8 neighbours red)
    for (int x = 75; x < 79; ++x) expect_led(x, y, spectrum::LampSpectrum::RedLed, p.taillamp_luminance_cd_m2);
}

// Vehicle colour cues: a saturated red blob on a car (a tail-lamp lens) lights with the
// preset's tail-lamp luminance (ECE R7: 4-12 cd over ~0.02 m², ~500 cd/m²); each car also gets
// its placed pair of lamps, tail lamps right of the vanishing point and head lamps (the
// headlamp luminance at its CCT) left of it; the car body elsewhere stays dark.
TEST(ScenePhysics, VehicleLampsFromColourCuesAndPlacement) {
  const ScenePreset p = no_bloom();
  Canvas c(120, 60);
  c.fill(70, 30, 110, 54, Label::Car, 0.1f, 0.1f, 0.12f);  // right of the VP: seen from behind
  c.fill(74, 46, 80, 51, Label::Car, 0.8f, 0.02f, 0.02f);  // red lens in the lower half
  c.fill(10, 30, 50, 54, Label::Car, 0.1f, 0.1f, 0.12f);   // left of the VP: oncoming
  const LightMap m = c.lights(p, 60, 20);
  EXPECT_EQ(m.stats.vehicle_lamps, 4);
  // Inside the red lens (pixels with all 8 neighbours red): exactly the tail-lamp luminance.
  for (int y = 47; y < 50; ++y)
    for (int x = 75; x < 79; ++x)
      EXPECT_NEAR(c.lum_at(m.radiance, x, y), p.taillamp_luminance_cd_m2, kLampRounding * p.taillamp_luminance_cd_m2) << x << "," << y;
  // Placed lamps at 55% of the height, 15% in from each side.
  const int ly = static_cast<int>(30 + 0.55 * 24);
  EXPECT_NEAR(c.lum_at(m.radiance, static_cast<int>(110 - 1 - 0.15 * 40), ly), p.taillamp_luminance_cd_m2,
              kLampRounding * p.taillamp_luminance_cd_m2);
  EXPECT_NEAR(c.lum_at(m.radiance, static_cast<int>(10 + 0.15 * 40), ly), p.headlamp_luminance_cd_m2,
              kLampRounding * p.headlamp_luminance_cd_m2);
  EXPECT_EQ(c.lum_at(m.radiance, 90, 33), 0.0);  // the body, away from any lamp
  EXPECT_EQ(c.lum_at(m.radiance, 30, 33), 0.0);
}

// The ego low beam (scene/lights.cpp): the preset's intensity table holds the ECE R112 class B
// test points (per headlamp, in cd: the 01 series' table) and nothing above the cut-off; on
// the road the pair gives E = Σ I(h, v)·cos θ / d². With the lamps coincident (spacing 0) on the
// axis (h = 0) at the distance D where v = −atan(h_l/D) is a table row, E = 2·I_row·(h_l/d)/d².
// Tolerance (u = 2⁻⁵³): the intensity at the row itself is the table's node exactly (weights 0 and
// 1); E's own arithmetic is about 6 roundings in the code (d², d, cos θ, the quotient, the
// product, the angle's scaling) and 5 here, 12u relative; and the code's v = atan(h_l/D)·180/π
// comes back to the row only to D's 4 roundings here (the product, the quotient by 180, tan, the
// quotient) and atan's and the scaling's 3, 7u·|row| degrees, which the table's slope next to the
// node (computed: its larger side, relative to the node, per degree) turns into intensity.
TEST(ScenePhysics, LowBeamIlluminanceAtSetDepths) {
  ScenePreset p = no_bloom();
  // UN/ECE R112, 01 series, §6.2's passing-beam table, class B, right-hand traffic (cd; the
  // source in presets/scenes/night-urban.toml at [ego_beam]).
  EXPECT_GE(low_beam_intensity_cd(1.72, -0.86, p), 10100.0);  // 50R
  EXPECT_GE(low_beam_intensity_cd(1.15, -0.57, p), 10100.0);  // 75R
  EXPECT_GE(low_beam_intensity_cd(0.0, -0.86, p), 5100.0);    // 50V
  EXPECT_LE(low_beam_intensity_cd(-3.43, -0.86, p), 13200.0); // 50L
  EXPECT_LE(low_beam_intensity_cd(-3.43, -0.57, p), 10600.0); // 75L
  EXPECT_LE(low_beam_intensity_cd(-3.43, 0.57, p), 350.0);    // B50L
  EXPECT_LE(low_beam_intensity_cd(2.5, 1.0, p), 1750.0);      // BR
  EXPECT_GE(low_beam_intensity_cd(-9, -1.72, p), 1700.0);     // 25L
  EXPECT_GE(low_beam_intensity_cd(9, -1.72, p), 1700.0);      // 25R
  EXPECT_LE(p.beam_above_cutoff_cd, 625.0);                   // any point of zone III (above the cut-off)
  for (double h = -5.15; h <= 5.15; h += 0.5)                  // Zone IV >= 3 lx at 25 m ([U]: the 00 series)
    for (double v = -1.72; v <= -0.86; v += 0.1) EXPECT_GE(low_beam_intensity_cd(h, v, p), 3 * 625.0) << h << " " << v;
  // The cut-off: horizontal at cutoff_v_deg on the left, nothing above; rising at 15° on the right.
  EXPECT_GT(low_beam_intensity_cd(-2, p.beam_cutoff_v_deg - 1e-9, p), 1000.0);
  EXPECT_EQ(low_beam_intensity_cd(-2, p.beam_cutoff_v_deg + 1e-9, p), 0.0);
  EXPECT_GT(low_beam_intensity_cd(2, -0.1, p), 1000.0);  // right of the elbow, below the rising line
  EXPECT_EQ(low_beam_intensity_cd(0.5, 0.0, p), 0.0);

  p.beam_lamp_spacing_m = 0;
  const double hl = p.beam_lamp_height_m;
  // (Not the 0.57° D row: it is the cut-off, where rounding decides between the row and 0.)
  const double rows[] = {-0.86, -1.3, -1.72, -3};
  for (size_t r = 0; r < 4; ++r) {
    const double D = hl / std::tan(-rows[r] * M_PI / 180), d2 = D * D + hl * hl, d = std::sqrt(d2);
    const double I = low_beam_intensity_cd(0, rows[r], p);
    const size_t iv = std::find(p.beam_v_deg.begin(), p.beam_v_deg.end(), rows[r]) - p.beam_v_deg.begin();
    const size_t ih = std::find(p.beam_h_deg.begin(), p.beam_h_deg.end(), 0.0) - p.beam_h_deg.begin();
    ASSERT_LT(iv, p.beam_v_deg.size());
    const size_t nh = p.beam_h_deg.size();
    const double node = p.beam_intensity_cd[iv * nh + ih];
    EXPECT_EQ(I, node);  // exact: v and h are grid values, the bilinear weights 0 and 1
    double slope = 0;  // relative, per degree
    for (const size_t jv : {iv - 1, iv + 1})
      if (jv < p.beam_v_deg.size())
        slope = std::max(slope, std::fabs(p.beam_intensity_cd[jv * nh + ih] - node) /
                                    (std::fabs(p.beam_v_deg[jv] - rows[r]) * node));
    const double u = 0x1p-53, want = 2 * I * (hl / d) / d2;
    // (12u for the closed form, 7u·|row| degrees times the table's slope: derived above the test)
    EXPECT_NEAR(low_beam_lux(0, D, p), want, (12 * u + slope * 7 * u * std::fabs(rows[r])) * want) << D;
  }
  // Beyond the cut-off (farther than h_l / tan 0.57° ≈ 65 m, left of the axis) and behind the car: dark.
  EXPECT_EQ(low_beam_lux(-3, 100, p), 0.0);
  EXPECT_EQ(low_beam_lux(0, -5, p), 0.0);
}

// compose() (scene/lights.cpp) against its definition, bit for bit: the darkened texture
// (darken(), the same darken_pixel) plus, per channel, (t_k·fl(tint_k/π))·E + l_k, E the beam's
// illuminance on the classes it lights (beam_lit_class_bits: the ground and vertical classes) and
// 0 elsewhere (sky, signs, ...). Its vector path
// takes eight pixels at a time where none is sky and the scalar loop elsewhere; the scene here
// mixes runs of one class (whole groups of eight without sky), single sky pixels inside them
// and every class id, at an odd width (a scalar tail on every row), so both paths and their
// seams are compared.
TEST(SceneCompose, IsDarkenPlusBeamPlusLightsBitForBit) {
  const ScenePreset p = no_bloom();
  const int W = 203, H = 37;
  std::mt19937 rng(1128);
  std::uniform_real_distribution<float> u01(0.f, 1.f);
  ImageF tex(W, H, 3, 0.f, unit::dimensionless), lights(W, H, 3, 0.f, unit::radiance), beam(W, H, 1, 0.f);
  ImageU16 ids(W, H, 1, 0);
  int sky = 0;
  for (int y = 0; y < H; ++y) {
    int x = 0;
    while (x < W) {  // runs of one class, 1..24 pixels
      const int run = 1 + static_cast<int>(rng() % 24);
      const uint16_t id = static_cast<uint16_t>(rng() % kLabelCount);
      for (int k = 0; k < run && x < W; ++k, ++x) {
        ids.at(x, y) = rng() % 16 == 0 ? static_cast<uint16_t>(Label::Sky) : id;
        sky += ids.at(x, y) == static_cast<uint16_t>(Label::Sky);
      }
    }
    for (int x2 = 0; x2 < W; ++x2) {
      for (int k = 0; k < 3; ++k) {
        tex.at(x2, y, k) = rng() % 8 == 0 ? 0.f : u01(rng);
        lights.at(x2, y, k) = rng() % 2 ? 0.f : 100.f * u01(rng);
      }
      beam.at(x2, y) = rng() % 4 == 0 ? 0.f : 50.f * u01(rng);
    }
  }
  ASSERT_GT(sky, 100);
  const ImageF got = compose(tex, lights, ids, beam, p);
  const ImageF dark = darken(tex, ids, p);
  const DarkenParams dp = darken_params(p);
  const auto tb = illuminant_tint(p.beam_cct_K);
  const float tbf[3] = {static_cast<float>(tb[0] / M_PI), static_cast<float>(tb[1] / M_PI), static_cast<float>(tb[2] / M_PI)};
  ImageF want(W, H, 3, 0.f, unit::radiance);
  size_t lit = 0;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const int id = ids.at(x, y);
      const float e = (beam_lit_class_bits() >> id & 1) ? beam.at(x, y) : 0.f;
      lit += e > 0;
      for (int k = 0; k < 3; ++k) {
        const float t = tex.at(x, y, k), b = t * tbf[k], be = b * e, le = be + lights.at(x, y, k);
        want.at(x, y, k) = dark.at(x, y, k) + le;
      }
    }
  EXPECT_GT(lit, 500u);  // the beam term is exercised
  ASSERT_EQ(got.size(), want.size());
  size_t differ = 0;
  for (size_t i = 0; i < got.size(); ++i) differ += std::memcmp(&got[i], &want[i], sizeof(float)) != 0;
  EXPECT_EQ(differ, 0u);
}
