// Private (not installed): which way each vehicle faces in light_map's vehicle lamps
// (scene/lights.cpp), and a test hook that records the decision per vehicle, so the rule can be
// measured against an annotation (tests/vehicle_facing_test.cpp, tests/data/vehicle_facing.csv).
#pragma once
#include <array>
#include <vector>
#include <cmath>
#include "photosite/image.h"
#include "photosite/scene/night.h"

namespace photosite::scene {

// One vehicle as light_map's vehicle lamps saw it (with the scene geometry).
struct VehicleDecision {
  int instance = 0;  // the gtFine instance code (class·1000 + n), 0 for a connected component
  int cls = 0;       // its label id
  int x0 = 0, y0 = 0, x1 = 0, y1 = 0, pixels = 0;  // its box (inclusive) and pixel count
  int state = 0;              // 0 parked dark, 1 in traffic, 2 parked with position lamps
  bool faces_camera = false;  // head (white) lamps toward the camera; else tail (red) lamps
  int red_px = 0;             // pixels of red lamp-like blobs in its day photo (the lit-lamp cue)
  int lens_px = 0;            // pixels of red lens blobs in its road-balanced day photo (rear_lens_colour)
  double X = 0, D = 0;        // its ground contact in road coordinates, m (X right of the camera)
  double travel_divide = 0;   // the divide between the directions of travel at this frame, m
  // Which vehicles are in traffic (issue 14 §2 "Which vehicles"), what the decision read:
  double road_left = 0, road_right = 0;  // the measured carriageway's edges (X, m; equal: none)
  double outer_X = 0;         // its outer side at the contact depth (toward the nearer edge), m
  int kerb_row = 0;           // vehicles in the row parked nose to tail it stands in (0: none)
  bool beside_median = false; // its outer side faces a median (road again beyond a narrow strip)
  bool across_median = false; // it stands on a road separated from the ego carriageway by a median
  double kerb_gap_m = INFINITY;  // road beside its outer side before the first off-carriageway label, m
  double strip_m = 0;            // that off-carriageway run's width, m
  double width_m = 0;            // its metric width at the contact depth (the lamps' spacing reads it), m
};

// The colour of the frame's road relative to grey: gains g_k = m̄/m_k per linear sRGB channel,
// m_k the mean of channel k over the road pixels (labels == Road; every 4th row and column) and m̄
// the mean of the three, which make the road neutral at its mean level.
// Asphalt is close to a neutral grey (reflectance about 0.1, nearly flat over the visible), so its colour in a day
// photo is the light's and the camera's cast (Cityscapes' frames are green: g ≈ (1.1, 0.8,
// 1.1)). {1, 1, 1} where fewer than 100 road samples are seen or a channel's mean is not positive.
std::array<double, 3> road_grey_gains(const ImageF& day_linear_srgb, const ImageU16& labels);
// Whether a linear sRGB day pixel, balanced by `gain`, has the colour of a red lamp lens: CIELAB
// (D65) L* > 25, a* > 20, hue −20°..40° (the lit-lamp cue's bounds, but a* > 20 instead of 40:
// an unlit lens in daylight reflects and is darker and paler than a lit one; a photosite choice).
bool rear_lens_colour(const float* rgb, const std::array<double, 3>& gain);
// Whether a vehicle of `pixels` pixels shows its rear, from its pixels of red lamp-like blobs:
// `red_px` of the lit-lamp cue (a* > 40 unbalanced) or `lens_px` of rear_lens_colour; either counts
// when it is at least 3 px and 0.2 % of the vehicle and at most 20 % (more is a red body, not
// lenses: a car's two rear lamp lenses are a few % of its rear view; both bounds photosite choices).
bool shows_rear(int red_px, int lens_px, int pixels);

// What lies beside a vehicle at its contact depth: its labels' row `y` walked from column `x` in
// direction `dir` (+1 right, −1 left), distances in ground metres across (X of the flat ground at
// that row, CameraGeometry::ground_point). Road and the objects standing on it (vehicles, people,
// poles, signs, static and dynamic objects, unlabelled pixels: they hide the ground, which is
// taken as road) come first; the first run of off-carriageway labels (sidewalk, parking, terrain,
// vegetation, ground, fences, guard rails, walls, buildings, bridges, tunnels, rail track) is the
// kerb side; road again beyond it makes that run a median (objects standing in it do not end
// it). The walk ends at the image's or the labels' frame (ego vehicle,
// rectification border, out of ROI, sky) or `max_m` from its start.
struct BesideProbe {
  double road_m = INFINITY;  // road (and hidden ground) before the first off-carriageway pixel; ∞: none met
  double strip_m = 0;        // width of that off-carriageway run (to where road resumes or the walk ends)
  bool road_beyond = false;  // road again after the run, within max_m
};
BesideProbe probe_beside(const ImageU16& labels, const CameraGeometry& g, int x, int y, int dir, double max_m);

// The length from a going-away vehicle's ground contact (its rear) to its head lamps at its front,
// per label id (car, truck, bus, motorcycle; others as a car), m: where light_map puts such a
// vehicle's low beam (docs/night.md §7 "Going-away beams"; the sources in scene/lights.cpp).
double vehicle_length_m(int cls);

// The test hook: while a sink is set, every light_map with geometry appends one VehicleDecision
// per vehicle to it (from the thread that runs the vehicle lamps: one light_map at a time). Null
// (the default) records nothing. For tests; returns the previous sink.
std::vector<VehicleDecision>* set_vehicle_decision_sink(std::vector<VehicleDecision>* sink);

}  // namespace photosite::scene
