// Street lighting in metres (scene/street.cpp): luminaires as point sources on detected poles or
// along the road edges, their illuminance on the ground E = Σ I(γ)·cos γ / d², scaled so that the
// scene preset's EN 13201 average road luminance holds, and the lamp heads sized in metres.
#pragma once
#include <string>
#include <vector>

#include "photosite/scene/night.h"
#include "photosite/scene/road_line.h"

namespace photosite::scene {

struct StreetLamp { double X_m, Y_m, D_m; bool from_pole; };
// A camera pose in the sequence's world frame: the camera's foot at (X_m, D_m) in the road
// coordinates of the sequence's first frame, its heading turned by yaw_rad from that frame's
// (positive toward +X). Crops of one frame (a pan of the image plane) and a camera at rest: all
// zero — a crop's shifted principal point is in its rig (CameraGeometry::cx_px), and the road
// coordinates of every crop are the same.
struct CameraPose {
  double X_m = 0, D_m = 0, yaw_rad = 0;
  bool at_origin() const { return X_m == 0 && D_m == 0 && yaw_rad == 0; }
};
struct StreetLighting {
  std::vector<StreetLamp> lamps;         // sorted by D
  // Where the luminaires come from: "road_edges" (rows along the road edges) or
  // "poles+road_edges" (those rows with detected poles in place of the nearest ones) from
  // plan_street_lighting and the luminaire tracker (scene/luminaires.cpp); "design_one_sided" or
  // "design_staggered" for street_design_layout's layouts (lamps or, on an unlit road, none);
  // "none" when a scene gets no luminaire (`note` says why). A frame's header
  // (photosite/night/street_lamp_source) takes a scene's: never a design layout's.
  std::string source = "none";
  double road_left_m = 0, road_right_m = 0;  // road extent across (X) used for the grid
  // The left road edge was measured on at least 10 rows 20..60 m ahead and its 10th-90th
  // percentile spread is within half a lane (vehicle_lamps.lane_width_m / 2): the carriageway
  // runs straight ahead, so a vehicle's X there tells its lane (scene/lights.cpp, head or tail).
  bool road_straight = false;
  double peak_intensity_cd = 0;          // I(γ ≤ cut-off)
  double grid_D0_m = 0;                  // start of the calculation field (one spacing long)
  double avg_luminance_cd_m2 = 0, uniformity_u0 = 0;
  // With source "none": why no luminaire was placed (the header's street_lamp_note). After the
  // members above, so their aggregate initialisations keep their order.
  std::string note;
  // The frame's pose in its sequence's world (night_scene sets it from SequenceState::pose; a
  // single frame's is 0): the façade windows are laid out and drawn in that world
  // (add_facade_windows), so they stay on their façades when the camera drives or turns.
  CameraPose pose;
  // The draw key of each façade plane's windows (one per BuildingFacades::planes entry, from a
  // sequence's FacadeSet: scene/luminaires.h); empty: each plane's facade_key.
  std::vector<uint64_t> facade_keys;
  // The road ahead measured from the frame's kerbs 10-100 m ahead (measure_road_ahead,
  // scene/road_line.h). Where it is "curved" the road-edge layout follows it: its rows stand along
  // the fitted road line, at its kerbs' offsets, instead of straight ahead at the kerbs' medians.
  RoadAhead road_ahead;
};
// The cut-off distribution relative to its peak: 1 up to cutoff_deg from the nadir, then
// exp(-(γ - cutoff)/falloff).
double lamp_relative_intensity(double gamma_rad, const ScenePreset& p);
// The horizontal distance from a lamp's foot beyond which its light is dropped (the pools' and the
// vertical street light's footprint): H·tan(min(85°, cutoff + 2·falloff)).
double street_lamp_reach_m(double mount_height_m, const ScenePreset& p);
// The road-edge layout's phase along the road, S·u with u uniform from the run seed (the first
// right-hand luminaire of plan_street_lighting's layout stands at D = phase).
double street_layout_phase_m(const ScenePreset& p, uint64_t seed);
// Horizontal illuminance (lx) at ground point (X, D) from all lamps at peak intensity I0.
double street_illuminance_lux(double X_m, double D_m, const StreetLighting& s, const ScenePreset& p);
// EN 13201-3's calculation field (one spacing long from D0_m, 10 x 6 points over the carriageway
// left_m..right_m): the average horizontal illuminance (lx) and, when u0 is given, E_min/E_avg.
double street_calculation_field_lux(const StreetLighting& lay, double left_m, double right_m, double D0_m,
                                    const ScenePreset& p, double* u0);
// The preset's design layout: one row at the kerb over a carriageway as wide as the mounting
// height H, or (staggered) two rows on opposite kerbs, S/2 apart along the road, over one 1.5 H
// wide; spacing S. Its peak intensity is set so its calculation field averages the class luminance
// (street.road_luminance_cd_m2); its avg_luminance_cd_m2 and uniformity_u0 are that field's. A
// scene's luminaires take the peak intensity of the layout of its kind (plan_street_lighting). No
// lamps when the road is unlit.
StreetLighting street_design_layout(const ScenePreset& p, bool staggered = false);
// Places the luminaires and scales them to the preset's road luminance (no lamps when it is 0).
StreetLighting plan_street_lighting(const LabelMap& labels, const CameraGeometry& g, const ScenePreset& p,
                                    uint64_t seed);
// Adds the ground's diffuse reflection of the street lighting (f_k·t_k·E/π, texture f, street
// tint t) on ground classes below the horizon, and the lamp heads (discs of head_diameter_m at
// streetlamp_luminance_cd_m2) to `L`, a head only where `depth_m` (when given) does not hide it:
// hidden whole when more than half of its footprint lies on surfaces in front of it by more than
// the depth's uncertainty there (scene/street.cpp head_hidden). Returns the number of heads drawn.
int add_street_lighting(ImageF& L, const ImageF& texture, const ImageU16& labels, const CameraGeometry& g,
                        const StreetLighting& s, const ScenePreset& p, const ImageF* depth_m = nullptr);

// Adds the street lighting's diffuse reflection on vertical surfaces (every non-ground, non-sky
// pixel): the pixel's point from its metric depth `depth_m`, its horizontal normal from its
// façade plane (building_facades) on buildings, else turned toward the camera, and
//   E_v = Σ I(γ)·max(0, cos β) / d²
// over the lamps within reach_m of it along the road (the ground pools' rule), β between the
// normal and the direction to the lamp, γ that direction's angle from the lamp's nadir (nothing
// for γ >= 90°), d² at least (5·head diameter)². Added to `L` as f_k·t_k·E_v/π like the ground
// pools (texture f, street tint t).
// `facades`: building_facades(labels, g, p.max_depth_m) when the caller has it, else computed here.
void add_vertical_street_light(ImageF& L, const ImageF& texture, const ImageU16& labels, const ImageF& depth_m,
                               const CameraGeometry& g, const StreetLighting& s, const ScenePreset& p,
                               const BuildingFacades* facades = nullptr);

// Lit windows on building façades, in metres: every building pixel's point from its metric
// depth, laid out in its façade's plane (building_facades: the plane fitted to the region's
// ground contacts, the one metric_depth took the depth from), with s the horizontal coordinate
// along the plane (increasing away from the camera; toward +X on a plane facing it) and Y the
// height: storeys of window_storey_m, windows of window_width_m x window_height_m centred in cells
// of window_pitch_m, perspective following from the projection. The lit draw is keyed by (run
// seed, the plane's azimuth in 5° and distance in 5 m steps, cell, storey), all in world
// coordinates (the road coordinates of the frame at `pose`, the frame's pose in its sequence's
// world; 0 for a single frame), so windows stay on their façade when the camera moves. A window's glass is its
// opening less window_frame_m on every side, split by a central window_mullion_m (two lights); a
// lit window is behind curtains with probability window_curtained_share (luminance
// window_curtained_luminance_cd_m2 instead of window_luminance_cd_m2, each ×0.5..1.5). The ground
// floor is cut into units of shop_frontage_m, a seeded shop_share of them shops (the others get the
// storeys' windows), each lit or dark as a whole: panes of shop_width_m on the window
// pitch from shop_sill_m to shop_sill_m + shop_height_m, shop_luminance_factor brighter, at
// shop_cct_K. Pixels whose footprint exceeds half a window width (z/f > window_width_m/2) get
// none (they would alias). Returns the number of lit windows and shops drawn.
// `facades` as for add_vertical_street_light. With the day's reflectance `texture` (and the
// preset's windows.detect_contrast above 0) the windows are first looked for in the photo: where it
// resolves a façade, the windows lit are the ones it shows (scene/facade_windows.cpp), each a
// seeded draw as the grid's; the grid lays out only the parts of the façades it does not resolve.
// A façade plane of the frame at `pose` in its sequence's world: its normal turned by the yaw,
// its distance d + n_w·T (T the camera's foot). At pose 0 the plane itself.
FacadePlane facade_in_world(const FacadePlane& f, const CameraPose& pose);
// The key of a façade plane's window draws: the normal's azimuth in 5° steps and the distance
// from the world's origin in 5 m steps, of `world` (facade_in_world's).
uint64_t facade_key(const FacadePlane& world);
int add_facade_windows(ImageF& L, const ImageU16& labels, const ImageF& depth_m, const CameraGeometry& g,
                       const ScenePreset& p, uint64_t seed, const BuildingFacades* facades = nullptr,
                       const ImageF* texture = nullptr, const CameraPose& pose = {},
                       const std::vector<uint64_t>* facade_keys = nullptr);

}  // namespace photosite::scene
