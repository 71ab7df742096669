// Scene presets: the night illumination and every parameter of the day-to-night stages, in
// presets/scenes/<name>.toml with the source of each number in a comment. Their keys are one
// schema table (scene/scene_preset.cpp) read by the one preset reader: unknown or missing keys and
// out-of-range values are errors "file:line: key: problem".
#pragma once
#include <array>
#include <map>
#include <string>
#include <vector>

#include "photosite/io.h"
#include "photosite/scene/rig.h"
#include "photosite/sensor/spectrum.h"

namespace photosite::scene {

// The street lamps' light source, one per scene (a street's luminaires are one installation):
// Led, a phosphor-converted white LED: through a camera (the night chain) that camera's metamer of
// CIE LED-B at lamps.streetlamp_cct_K (heads) and street.cct_K (their light on the street)
// (spectrum::led_b_spd; ScenePreset::lamp_camera_rgb); in a scene made without a camera a Planck
// radiator at those CCTs (a proxy: a phosphor LED is a blue pump line and a broad phosphor band,
// which a camera records about 10 % greener, raw G/R, than Planck's; docs/night.md §7); Hps, high-pressure sodium as CIE illuminant HP1 (spectrum::hp1_rgb),
// where both CCT keys are unused. The sensor reads a radiance through box-averaged QE, which puts
// sodium's 570-600 nm light in the G box: a camera sees an hps street about 2x greener (raw G/R)
// than the lamp's spectrum gives (docs/night.md §7, "Lamp type").
enum class StreetlampType { Led, Hps };
inline constexpr const char* kStreetlampTypeNames = "led, hps";
// "led" / "hps"; parse throws photosite::Error on any other name, listing the names.
const char* streetlamp_type_name(StreetlampType t);
StreetlampType parse_streetlamp_type(const std::string& name);
// How the day photo's own camera cast is taken out before its colours become albedos
// (reflectance.day_white_balance; scene/darken.cpp day_white_balance): Road, by its road (the mean
// linear colour of the road's pixels moved to the nearest point of the CIE daylight locus, green
// kept); None, the photo's colours as they are.
enum class DayWhiteBalance { None, Road };
inline constexpr const char* kDayWhiteBalanceNames = "road, none";
const char* day_white_balance_name(DayWhiteBalance m);
DayWhiteBalance parse_day_white_balance(const std::string& name);

struct ScenePreset {
  std::string name, file, description;
  // [reflectance] Table 1 of Baek 2020: representative material per class (dimensionless).
  double rho_sign = 0.7, rho_construction = 0.3, rho_human = 0.25, rho_nature = 0.2,
         rho_vehicle = 0.2, rho_sky = 0.1, rho_road = 0.1;
  // The texture's bound on a pixel's band reflectance (scene::class_reflectance_max): diffuse
  // classes at most diffuse_max (energy conservation: ≤ 1), specular/retroreflective ones
  // (glints), the sky and unlabelled classes at most glint_max.
  double rho_diffuse_max = 1.0, rho_glint_max = 5.0;
  // The day's sunlight taken out of the texture of diffuse classes (scene/darken.cpp
  // sun_shade_split): within a class, a region lit by the sun is told from the class's shade by a
  // class-masked smoothing of log luminance over a window of window_fraction of the image width,
  // and divided by the measured sun/shade ratio, held at most ratio_max; a class whose two levels
  // differ by less than ratio_min is left as it is, and so is one whose shade is not bluer than its
  // sunlit level by at least the colour contrast of direct sun (sun_cct_K) against the sky's light
  // (shade_sky_cct_K) at a step of ratio_min. ratio_max = 1 turns it off; 10 is the sources' bound
  // (presets/scenes/night-urban.toml).
  double sun_shade_ratio_min = 2, sun_shade_ratio_max = 10, sun_shade_window_fraction = 0.03;
  // reflectance.sky_gap_fraction: vegetation pixels at least this fraction of the sky's median day
  // luminance, connected to the labelled sky through such pixels, are sky seen through the crown
  // (take_sky_gaps); 0: none.
  double sky_gap_fraction = 0.6;
  double sun_cct_K = 5000, shade_sky_cct_K = 7000;
  // The day photo's camera cast (a camera's white balance or a data set's processing, e.g.
  // Cityscapes' green: mean linear G/R 1.29-1.37 over its frames against KITTI's 0.99-1.09,
  // docs/realism.md), taken out before the texture keeps the photo's colours as albedo.
  DayWhiteBalance day_white_balance = DayWhiteBalance::Road;
  // [ambient] illuminance on every surface (lx) and the sky's own luminance (cd/m²).
  double moon_lux = 0.1, moon_cct_K = 4100, skyglow_lux = 0.05, skyglow_cct_K = 2500;
  double sky_luminance_cd_m2 = 0.02;
  // [street] street lighting: road luminance target (cd/m², EN 13201 M class) → horizontal
  // illuminance on ground classes E = π·L/ρ_road (the lamps' intensity is scaled to it,
  // scene/street.cpp); vertical surfaces are lit by the same lamps.
  double street_road_luminance_cd_m2 = 1.0;
  double street_cct_K = 4000;
  // [street_lamps] luminaires as point sources (scene/street.cpp): mounting height, spacing as a
  // multiple of it, set-back from the road edge, the cut-off intensity distribution (constant to
  // cutoff_deg from the nadir, then falling as exp(-(γ - cutoff)/falloff_deg)), the lamp head's
  // size, how far placed lamps reach, the least pole height that carries a luminaire.
  double lamp_mount_height_m = 10, lamp_spacing_ratio = 3.0, lamp_setback_m = 0.5;
  double lamp_cutoff_deg = 65, lamp_falloff_deg = 5, lamp_head_diameter_m = 0.5;
  double lamp_max_distance_m = 150, lamp_min_pole_height_m = 5;
  // The ground pools' interpolation tolerance (relative; 0, a default-constructed preset's: every
  // pixel evaluated exactly): scene/street.cpp evaluates the pools at adaptively refined sample
  // columns of each row and interpolates linearly between them within it (the bundled scene
  // presets: 6e-4).
  double lamp_interp_tolerance = 0;
  // The luminaires' shadows on the ground (scene/street.cpp street_lamp_shadow_spans): a ground
  // pixel that a vehicle, person, pole, sign, signal, fence or guard rail hides from a lamp loses
  // that lamp's share of the pools (docs/night.md §7 "Shadows of the street lamps").
  bool lamp_shadows = true;
  // The shadows' penumbrae (street_lamps.penumbrae; with lamp_shadows): each luminaire's face, a
  // disc of lamp_head_diameter_m, as kLampDiscSamples points (scene/street_detail.h); a ground
  // pixel hidden from part of the disc loses that part's share of the lamp's light. Off (the
  // default: on costs the chain about 4-5 %, docs/benchmarks.md "Thirty-second session:
  // penumbrae"): the lamp is one point and the shadows' edges are sharp (docs/night.md §7).
  bool lamp_penumbrae = false;
  // [vehicle_lamps] lamps in metres per vehicle (scene/lights.cpp): height above the ground
  // contact, inset from the vehicle's side, lens diameters, intensities toward the camera, the
  // seeded share of parked vehicles with parking lights, the kerb strip where vehicles park.
  double veh_lamp_height_m = 0.7, veh_lamp_inset_m = 0.15, veh_head_diameter_m = 0.18,
         veh_tail_diameter_m = 0.12, veh_head_intensity_cd = 350, veh_tail_intensity_cd = 8,
         veh_parking_intensity_cd = 4, veh_parked_lit_fraction = 0.05, veh_kerb_strip_m = 2.5,
         veh_lane_width_m = 3.25;
  // The low beams of oncoming vehicles in traffic on the ground in front of them (scene/lights.cpp,
  // docs/night.md §7): each headlamp the [ego_beam] table (ECE R112 class B) at height
  // veh_lamp_height_m, aimed toward the camera's side along the road. Off: only their lamps drawn.
  bool veh_beams_on_road = true;
  // [windows] façade layout in metres; ground-floor shops: pane width (on the window pitch),
  // sill and pane height above the ground, and the frontage of one shop (lit as a whole).
  double window_storey_m = 3, window_pitch_m = 1.3, window_width_m = 0.9, window_height_m = 1.3,
         shop_luminance_factor = 3, shop_cct_K = 3000;
  double shop_width_m = 1.1, shop_sill_m = 0.4, shop_height_m = 2.0, shop_frontage_m = 6.5;
  // The glass of a window: inset by the frame on every side, split by a central mullion; the
  // seeded share of ground-floor shop units that are shops (the others have windows).
  double window_frame_m = 0, window_mullion_m = 0, shop_share = 1;
  // The day photo's windows found on each façade (scene/facade_windows.cpp): how much darker than
  // its wall's local mean a cell of glass is, (t − m)/t; 0: not looked for, the grid everywhere.
  double window_detect_contrast = 0;
  // [lamps] luminances of light sources (cd/m²) and CCTs (K).
  double streetlamp_luminance_cd_m2 = 3e4, streetlamp_cct_K = 4000;
  StreetlampType streetlamp_type = StreetlampType::Led;  // colour of heads, pools and vertical light
  // Not a key: each named lamp spectrum's colour per cd/m² as the run's camera records it
  // (camera_metamer_rgb, sensor/pipeline.h), indexed by spectrum::LampSpectrum: HP1 for hps street
  // lamps, CIE LED-B at lamps.streetlamp_cct_K and street.cct_K for led ones, the red, amber and
  // green LEDs for traffic signals and the red for vehicles' rear lamps. Set by the night chain
  // from its camera (scene_for_camera, photosite/night_chain.h). All 0 (a scene made without a
  // camera): HP1's band integrals (spectrum::hp1_rgb), which the cameras record 2.2-2.4 times too
  // green, the Planck proxy for led, and the signals' and rear lamps' box guesses (scene/lights.cpp).
  std::array<std::array<double, 3>, spectrum::kLampSpectrumCount> lamp_camera_rgb{};
  double headlamp_luminance_cd_m2 = 5e4, headlamp_cct_K = 3200;
  double taillamp_luminance_cd_m2 = 500;
  double signal_luminance_cd_m2 = 1e4;
  double window_luminance_cd_m2 = 30, window_cct_K = 2700, window_lit_fraction = 0.3;
  double window_cell_fraction = 0.02;  // window grid cell, fraction of the image width
  // Seeded share of lit windows seen through curtains or blinds, and their luminance.
  double window_curtained_share = 0, window_curtained_luminance_cd_m2 = 5;
  double window_warm_share = 0.7, window_cool_cct_K = 4000;  // share of windows at window_cct_K; the rest at this CCT
  // [retroreflection] EN 1436 R_L (cd·m⁻²·lx⁻¹) for lane markings, EN 12899 R_A (cd·lx⁻¹·m⁻²).
  double marking_RL = 0.2, sign_RA = 180;
  // R_A's fall with the observation angle α (lamp to sign to camera): sign_RA holds at
  // sign_RA_alpha_deg, R_A ∝ α^−sign_RA_alpha_exponent up to sign_RA_alpha_max_deg, held beyond.
  double sign_RA_alpha_deg = 0.33, sign_RA_alpha_exponent = 0, sign_RA_alpha_max_deg = 0.33;
  // R_A's fall with the entrance angle β (the lamp's ray against the sign's normal): at the angles
  // sign_RA_entrance_deg R_A is the factors sign_RA_entrance_factor (at sign_RA_alpha_deg and below)
  // and sign_RA_entrance_factor_alpha_max (at sign_RA_alpha_max_deg and beyond) times its value at
  // the first angle, linear in tan β between the angles, held outside them, and between the two α
  // geometric in α (F0^(1−t)·F1^t, t = ln(α/α0)/ln(α1/α0)). Empty: no entrance-angle dependence.
  std::vector<double> sign_RA_entrance_deg, sign_RA_entrance_factor, sign_RA_entrance_factor_alpha_max;
  // A sign faces the traffic that reads it: where the road ahead bends, its normal follows the
  // road's heading sign_read_distance_m before the sign (detail::SignFacing, scene/sign_retro_detail.h).
  double sign_read_distance_m = 60;
  // [ego_beam] low beam: CCT, illuminance on signs, and the headlamp pair: mounting height above
  // the road and lateral spacing (m), the cut-off line (v = cutoff_v_deg left of the v-v line,
  // rising at cutoff_rise_deg to the right up to cutoff_max_v_deg; nothing above it) and one
  // headlamp's luminous intensity table: intensity_cd[iv][ih] (cd) at v_deg[iv] (vertical
  // angle, positive up) and h_deg[ih] (horizontal, positive right), both strictly increasing.
  double beam_cct_K = 3200, beam_sign_lux = 5;
  double beam_lamp_height_m = 0.65, beam_lamp_spacing_m = 1.5;
  double beam_cutoff_v_deg = -0.57, beam_cutoff_rise_deg = 15, beam_cutoff_max_v_deg = 0;
  // One headlamp's intensity above the cut-off (the glare zone), within the table's horizontal
  // range: what lights signs (sign_beam_lux) and vertical surfaces above the cut-off
  // (low_beam_vertical_lux) with the metric geometry; the road never reads it.
  double beam_above_cutoff_cd = 0;
  // The headlamp's light-emitting aperture (m): nearer than five of it the inverse-square law no
  // longer holds (the five-diameter rule), and the vertical surfaces' d² is held there.
  double beam_lens_diameter_m = 0.2;
  // The lamps' shadows (docs/night.md §6c, "Shadows of the low beam"): on the ground, and below the
  // cut-off's top on vertical surfaces. Off: every pixel lit as if nothing stood between it and
  // the lamps (the chain about 3 ms faster at 2 threads, docs/benchmarks.md).
  bool beam_shadows = true;
  std::vector<double> beam_h_deg, beam_v_deg, beam_intensity_cd;  // intensity row-major over v
  // [geometry] lanes, edges, Hough, vanishing point.
  int work_max_width = 1024;             // stages 2-6 run at this width at most (documented)
  double lane_blur_sigma_px = 1.0, lane_contrast_threshold = 0.06;
  double canny_low = 40, canny_high = 120;
  int hough_threshold = 30;
  double hough_min_length_fraction = 0.04, hough_max_gap_fraction = 0.01;
  double line_reject_angle_deg = 5, border_fraction = 0.03;
  double vp_cluster_radius_fraction = 0.04;
  int vp_min_support = 4;
  double max_depth_m = 1000;  // metric depth cap for ground and objects near the horizon
  // Track gauges of trams whose rails lane_markings may take for markings (drop_tram_rails).
  std::vector<double> tram_gauges_m = {1.435, 1.0};
  // The camera rig (not a key of the scene file: chosen by `--rig`); an empty name means auto
  // (rig_for_image: the bundled rig of the nearest native aspect ratio).
  CameraRig rig;
};

ScenePreset load_scene_preset(const std::string& name_or_path);  // name in presets/scenes or path
ScenePreset parse_scene_preset(const std::string& toml_text, const std::string& file);
// Every number of the scene's schema as a header attribute "photosite/scene/<key>", and the
// preset's name as "photosite/scene/preset".
std::map<std::string, ExrAttribute> scene_attributes(const ScenePreset& p);
// The Markdown reference table of the scene keys (part of `presets_doc_markdown()`).
std::string scene_presets_doc_markdown();
// `presets show`'s JSON text of a scene preset (keys as in its TOML file, plus name and file);
// indent as photosite::to_json's.
std::string to_json(const ScenePreset& p, int indent = -1);

}  // namespace photosite::scene
