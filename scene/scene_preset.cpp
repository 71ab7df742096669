// Scene presets: read by the one preset reader (core/toml_schema_detail.h) from the table below,
// which also gives the docs' reference table (`photosite presets doc`) and the EXR header
// attributes "photosite/scene/<key>" (every number: num() and integer() mark their rows).
#include "photosite/scene/scene_preset.h"

#include <algorithm>
#include <filesystem>
#include <string>
#include <vector>

#include "core/toml_schema_detail.h"
#include "photosite/error.h"
#include "photosite/sensor/preset.h"

namespace photosite::scene {
namespace {
using schema::Kind;
using schema::Need;
constexpr double inf = schema::kUnbounded;
// Sources: [T1] Baek 2020 thesis Table 1; NP: ../shared/reference/night-photometry.md (its
// primary sources are named there; each preset's comments name the section); [U] regulation or
// design-guide figures from general knowledge, not in ../shared; "photosite choice" where no
// source fixes the value. The rows' sources name where a value comes from in the bundled presets.
const std::vector<schema::Param<ScenePreset>>& scene_schema() {
  using P = ScenePreset;
  auto table = [](std::string_view key, std::string_view meaning, std::string_view source) {
    return schema::Param<P>{key, Kind::Table, {}, "", -inf, inf, Need::Required, meaning, source};
  };
  auto num = [](std::string_view key, double& (*at)(P&), std::string_view unit, double lo, double hi,
                std::string_view meaning, std::string_view source, std::string_view check = {}) {
    return schema::Param<P>{key, Kind::Number, at, unit, lo, hi, Need::Required, meaning, source, check,
                            schema::Exr::Header};
  };
  auto integer = [](std::string_view key, int& (*at)(P&), std::string_view unit, double lo, double hi,
                    std::string_view meaning, std::string_view source) {
    return schema::Param<P>{key, Kind::Integer, at, unit, lo, hi, Need::Required, meaning, source, {},
                            schema::Exr::Header};
  };
  // An enumerated key (Choice: its parser, its name, the names listed).
  auto choice = [](std::string_view key, schema::Choice<P> c, std::string_view meaning, std::string_view source) {
    return schema::Param<P>{key, Kind::Choice, std::move(c), "", -inf, inf, Need::Optional, meaning, source, {},
                            schema::Exr::Header};
  };
  static const std::vector<schema::Param<P>> rows{
      {"description", Kind::Text, PHOTOSITE_AT(P, description), "", -inf, inf, Need::Optional, "one line",
       "free text"},
      table("reflectance", "diffuse reflectance ρ of the label classes", "[T1]"),
      // Above 0: a sign's retroreflection takes its day texture's pattern as the texture over ρ
      // (scene/lights.cpp retro_put), and at ρ = 0 the texture is 0 too: 0/0 made the sign pixels
      // NaN (a run refused at the sensor with no key named; thirty-fourth session). 0.001 as the road's.
      num("reflectance.sign", PHOTOSITE_AT(P, rho_sign), "—", 1e-3, 1,
          "traffic signs and lights (above 0: their retroreflection is the day texture over ρ)", "[T1] aluminium"),
      num("reflectance.construction", PHOTOSITE_AT(P, rho_construction), "—", 0, 1, "buildings, walls, fences",
          "[T1] concrete; NP §4"),
      num("reflectance.human", PHOTOSITE_AT(P, rho_human), "—", 0, 1, "persons, riders", "[T1] skin"),
      num("reflectance.nature", PHOTOSITE_AT(P, rho_nature), "—", 0, 1, "vegetation, terrain",
          "NP §4 vegetation, visible (the thesis's [T1] 0.2 is broadband)"),
      num("reflectance.vehicle", PHOTOSITE_AT(P, rho_vehicle), "—", 0, 1, "vehicles", "[T1] steel"),
      num("reflectance.sky", PHOTOSITE_AT(P, rho_sky), "—", 0, 1,
          "sky, in the unlabelled mean only (the sky uses ambient.sky_luminance_cd_m2)", "[T1] lunar albedo"),
      num("reflectance.road", PHOTOSITE_AT(P, rho_road), "—", 1e-3, 1, "road, sidewalk, parking: E = π·L/ρ",
          "[T1] asphalt; NP §4 L/E (Hollan)"),
      num("reflectance.diffuse_max", PHOTOSITE_AT(P, rho_diffuse_max), "—", 1e-3, 1,
          "band reflectance bound of a texture pixel of a diffuse class (ground, buildings, vegetation, persons)",
          "energy conservation of a passive Lambertian surface: ρ ≤ 1"),
      num("reflectance.glint_max", PHOTOSITE_AT(P, rho_glint_max), "—", 1, 100,
          "band reflectance bound of a texture pixel of a specular or retroreflective class (vehicles, signs, "
          "traffic lights, poles, guard rails), the sky and unlabelled pixels",
          "photosite choice (the texture's earlier single cap)"),
      num("reflectance.sun_shade_ratio_max", PHOTOSITE_AT(P, sun_shade_ratio_max), "—", 1, 100,
          "the day's sun/shade ratio divided out of a diffuse class's sunlit level at most (1: off)",
          "[S] daylight: 100,000 lx in the open against 10,000 lx in a tree's shade (CIBSE via IES VE)"),
      num("reflectance.sun_shade_ratio_min", PHOTOSITE_AT(P, sun_shade_ratio_min), "—", 1, 100,
          "a class whose two levels differ by less is not split", "photosite choice",
          "≤ reflectance.sun_shade_ratio_max"),
      num("reflectance.sun_shade_window_fraction", PHOTOSITE_AT(P, sun_shade_window_fraction), "fraction", 1e-3,
          0.5, "the sun/shade opening's square, of the image width (wider than a lane marking)", "photosite choice"),
      // Optional (default 0.6, ScenePreset): scene files written before it keep loading.
      {"reflectance.sky_gap_fraction", Kind::Number, PHOTOSITE_AT(P, sky_gap_fraction), "fraction", 0, 1,
       Need::Optional,
       "vegetation pixels at least this fraction of the sky's median day luminance, joined to the labelled sky "
       "through such pixels, are sky seen through the crown, and the scene takes them for sky (0: none)",
       "photosite choice (docs/night.md §1, \"Sky through the crowns\"; docs/realism.md)", {}, schema::Exr::Header},
      num("reflectance.sun_cct_K", PHOTOSITE_AT(P, sun_cct_K), "K", 1000, 20000,
          "direct sunlight's CCT (the sunlit level's colour with the sky's)",
          "[S] noon direct sunlight about 5000-5500 K (photography and lighting references)"),
      num("reflectance.shade_sky_cct_K", PHOTOSITE_AT(P, shade_sky_cct_K), "K", 1000, 100000,
          "the CCT of the sky's light in the shade, at its reddest: a class whose shade is not bluer than this "
          "against the sun (at a step of sun_shade_ratio_min) is not split",
          "[S] thin cloud or haze 6500-7000 K, clear blue sky 12,000-18,000 K (same references)",
          "> reflectance.sun_cct_K"),
      choice("reflectance.day_white_balance",
             {[](P& p, const std::string& s) { p.day_white_balance = parse_day_white_balance(s); },
              [](const P& p) -> std::string { return day_white_balance_name(p.day_white_balance); },
              kDayWhiteBalanceNames},
             "the day photo's own camera cast, taken out before its colours become albedos: road (gains that move "
             "the mean linear colour of its road pixels to the nearest point of the CIE daylight locus, green kept; "
             "none where the road is under 100 samples or the gains would spread over 2x: not a cast) or none (the "
             "photo's colours as they are)",
             "photosite choice: asphalt and concrete are near-neutral (docs/night.md §1, \"The day photo's white "
             "balance\"); default road"),
      table("ambient", "moonlight and sky glow on every surface, the sky's luminance", "NP §2"),
      num("ambient.moon_lux", PHOTOSITE_AT(P, moon_lux), "lx", 0, 1, "moonlight illuminance", "NP §2"),
      num("ambient.moon_cct_K", PHOTOSITE_AT(P, moon_cct_K), "K", 1000, 20000, "moonlight CCT", "NP §2"),
      num("ambient.skyglow_lux", PHOTOSITE_AT(P, skyglow_lux), "lx", 0, 10, "sky-glow illuminance on the ground",
          "NP §2 (E = π·L of the sky)"),
      num("ambient.skyglow_cct_K", PHOTOSITE_AT(P, skyglow_cct_K), "K", 1000, 20000, "sky-glow CCT", "NP §0"),
      num("ambient.sky_luminance_cd_m2", PHOTOSITE_AT(P, sky_luminance_cd_m2), "cd/m²", 0, 10,
          "luminance of the sky pixels", "NP §2"),
      table("street", "road lighting: the road luminance target and the light's colour",
            "EN 13201 via NP §1"),
      num("street.road_luminance_cd_m2", PHOTOSITE_AT(P, street_road_luminance_cd_m2), "cd/m²", 0, 10,
          "maintained average road luminance (EN 13201 M class)", "NP §1"),
      num("street.cct_K", PHOTOSITE_AT(P, street_cct_K), "K", 1000, 20000, "street-lighting CCT", "NP §1"),
      table("street_lamps", "luminaires as point sources (scene/street.cpp)",
            "[S] mounting height, spacing, cut-off class; [U] head size"),
      num("street_lamps.mount_height_m", PHOTOSITE_AT(P, lamp_mount_height_m), "m", 2, 30, "luminaire height",
          "[S] 8-12 m (GDCI street-design text via engineeringdiscoveries.com; gyandarpan.in)"),
      num("street_lamps.spacing_ratio", PHOTOSITE_AT(P, lamp_spacing_ratio), "—", 1, 10,
          "spacing as a multiple of the mounting height",
          "[S] <= 3 for cut-off luminaires (ycbright.com); 2.5-3 (GDCI text via engineeringdiscoveries.com)"),
      num("street_lamps.setback_m", PHOTOSITE_AT(P, lamp_setback_m), "m", -5, 10,
          "luminaire outside the road edge", "photosite choice"),
      num("street_lamps.cutoff_deg", PHOTOSITE_AT(P, lamp_cutoff_deg), "°", 10, 89,
          "intensity constant up to this angle from the nadir", "[S] cut-off class: peak within 65° (ycbright.com)"),
      num("street_lamps.falloff_deg", PHOTOSITE_AT(P, lamp_falloff_deg), "°", 0.1, 45,
          "beyond the cut-off I ∝ exp(−(γ − cutoff)/falloff)",
          "[D] within the cut-off class's 30 / 10 cd/klm at 80° / 90° [S]"),
      num("street_lamps.head_diameter_m", PHOTOSITE_AT(P, lamp_head_diameter_m), "m", 0.05, 3,
          "luminaire head size", "[U] LED street luminaires"),
      num("street_lamps.max_distance_m", PHOTOSITE_AT(P, lamp_max_distance_m), "m", 10, 2000,
          "placed lamps (no poles labelled) reach this far ahead", "photosite choice"),
      num("street_lamps.min_pole_height_m", PHOTOSITE_AT(P, lamp_min_pole_height_m), "m", 1, 30,
          "a taller labelled pole carries a luminaire", "photosite choice"),
      num("street_lamps.interp_tolerance", PHOTOSITE_AT(P, lamp_interp_tolerance), "fraction", 0, 0.1,
          "the ground pools evaluated at adaptive sample columns of each row and interpolated within "
          "this relative error (0: every pixel exactly)",
          "[C] ≤ 1/(4·√full_well) of the largest camera full well, 168,000 e- (sony-a7s2): 6.1e-4 (scene/street.cpp)"),
      {"street_lamps.shadows", Kind::Boolean, PHOTOSITE_AT(P, lamp_shadows), "", -inf, inf, Need::Optional,
       "the luminaires' shadows on the ground: a ground pixel that a vehicle, person, pole, sign, signal, fence or "
       "guard rail hides from a lamp loses that lamp's light (docs/night.md §7)",
       "photosite choice (default true)", {}, schema::Exr::Header},
      {"street_lamps.penumbrae", Kind::Boolean, PHOTOSITE_AT(P, lamp_penumbrae), "", -inf, inf, Need::Optional,
       "with shadows: each luminaire's face a disc of head_diameter_m, so a ground pixel hidden from part of it "
       "loses that part's share of the lamp's light (the shadows' edges soft; docs/night.md §7)",
       "photosite choice (default false): on costs the chain about 4-5 % (docs/benchmarks.md)", {},
       schema::Exr::Header},
      table("vehicle_lamps", "head, tail and parking lamps per vehicle (scene/lights.cpp)",
            "ECE R48 [S]; R7, R112 [U]"),
      num("vehicle_lamps.height_m", PHOTOSITE_AT(P, veh_lamp_height_m), "m", 0.2, 3,
          "lamp height above the ground contact",
          "[S] ECE R48: dipped beam 500-1200 mm, rear position 350-1500 mm (UK lighting table; 2009/67/EC)"),
      num("vehicle_lamps.inset_m", PHOTOSITE_AT(P, veh_lamp_inset_m), "m", 0, 1, "lamp centre in from the side",
          "[S] ECE R48: lamp edge within 400 mm of the side"),
      num("vehicle_lamps.head_diameter_m", PHOTOSITE_AT(P, veh_head_diameter_m), "m", 0.02, 1,
          "headlamp lens diameter", "[S] the 7-inch round headlamp (jfuehr.com)"),
      num("vehicle_lamps.tail_diameter_m", PHOTOSITE_AT(P, veh_tail_diameter_m), "m", 0.02, 1,
          "rear lamp lens diameter", "[U]"),
      num("vehicle_lamps.head_intensity_cd", PHOTOSITE_AT(P, veh_head_intensity_cd), "cd", 0, 1e6,
          "oncoming headlamp toward the camera", "NP §3; [S] ECE R112 B50L (01 series)"),
      num("vehicle_lamps.tail_intensity_cd", PHOTOSITE_AT(P, veh_tail_intensity_cd), "cd", 0, 1e4,
          "tail lamp toward the camera", "NP §3; [U] ECE R7"),
      num("vehicle_lamps.parking_intensity_cd", PHOTOSITE_AT(P, veh_parking_intensity_cd), "cd", 0, 1e4,
          "position lamp of a parked vehicle", "[S] UN R148 Table 3 (front: 4 cd minimum); [U] ECE R7 (rear)"),
      num("vehicle_lamps.parked_lit_fraction", PHOTOSITE_AT(P, veh_parked_lit_fraction), "fraction", 0, 1,
          "seeded share of parked vehicles with lamps on", "photosite choice"),
      num("vehicle_lamps.kerb_strip_m", PHOTOSITE_AT(P, veh_kerb_strip_m), "m", 0, 10,
          "a vehicle this near the road edge is parked", "photosite choice"),
      num("vehicle_lamps.lane_width_m", PHOTOSITE_AT(P, veh_lane_width_m), "m", 2, 5,
          "traffic lane width: the ego lane's half width sets the head-or-tail divide on a straight road",
          "[S] RAS-Q: 2.75-3.75 m, 3.25 m on built-up main roads (sicherestrassen.de)"),
      {"vehicle_lamps.beams_on_road", Kind::Boolean, PHOTOSITE_AT(P, veh_beams_on_road), "", -inf, inf, Need::Optional,
       "vehicles' low beams light the ground ahead of them: the [ego_beam] table at height_m at their head lamps, "
       "aimed along the road toward the camera (oncoming) or away from it from their fronts (going away) "
       "(docs/night.md §7)",
       "[U] ECE R112 class B (the [ego_beam] table); default true", {}, schema::Exr::Header},
      table("lamps", "luminances and CCTs of the light sources' own pixels", "NP §3"),
      num("lamps.streetlamp_luminance_cd_m2", PHOTOSITE_AT(P, streetlamp_luminance_cd_m2), "cd/m²", 0, 1e8,
          "street luminaire face", "NP §3"),
      num("lamps.streetlamp_cct_K", PHOTOSITE_AT(P, streetlamp_cct_K), "K", 1000, 20000, "street luminaire CCT",
          "NP §1"),
      choice("lamps.streetlamp_type",
             {[](P& p, const std::string& s) { p.streetlamp_type = parse_streetlamp_type(s); },
              [](const P& p) -> std::string { return streetlamp_type_name(p.streetlamp_type); },
              kStreetlampTypeNames},
             "the street lamps' light source, one per scene: led (phosphor white LED, CIE LED-B at streetlamp_cct_K "
             "and street.cct_K as the camera records it; Planck at them in a scene without a camera) or hps "
             "(high-pressure sodium, CIE illuminant HP1; the CCT keys unused)",
             "CIE 015:2018 HP1, LED-B1..B5 via scripts/lamp_spectra.py (efficacies 395, 305-319 lm/W: NP §0)"),
      num("lamps.headlamp_luminance_cd_m2", PHOTOSITE_AT(P, headlamp_luminance_cd_m2), "cd/m²", 0, 1e8,
          "headlamp lens", "NP §3 [D]"),
      num("lamps.headlamp_cct_K", PHOTOSITE_AT(P, headlamp_cct_K), "K", 1000, 20000, "headlamp CCT", "NP §3"),
      num("lamps.taillamp_luminance_cd_m2", PHOTOSITE_AT(P, taillamp_luminance_cd_m2), "cd/m²", 0, 1e8,
          "tail lamp lens", "[D] ECE R7 intensity over the lens area"),
      num("lamps.signal_luminance_cd_m2", PHOTOSITE_AT(P, signal_luminance_cd_m2), "cd/m²", 0, 1e8,
          "traffic signal", "[D] LED signal intensity over the lens area"),
      num("lamps.window_luminance_cd_m2", PHOTOSITE_AT(P, window_luminance_cd_m2), "cd/m²", 0, 1e4,
          "lit window", "NP §3"),
      num("lamps.window_cct_K", PHOTOSITE_AT(P, window_cct_K), "K", 1000, 20000, "warm windows' CCT", "NP §0"),
      num("lamps.window_lit_fraction", PHOTOSITE_AT(P, window_lit_fraction), "fraction", 0, 1,
          "seeded share of lit windows", "[U]"),
      num("lamps.window_cell_fraction", PHOTOSITE_AT(P, window_cell_fraction), "fraction", 0.002, 0.5,
          "window grid cell, of the image width (façades without metric layout)", "photosite choice"),
      num("lamps.window_warm_share", PHOTOSITE_AT(P, window_warm_share), "fraction", 0, 1,
          "share of lit windows at window_cct_K, the rest at window_cool_cct_K", "[U] photosite choice"),
      num("lamps.window_cool_cct_K", PHOTOSITE_AT(P, window_cool_cct_K), "K", 1000, 20000,
          "the other windows' CCT", "NP §0"),
      num("lamps.window_curtained_share", PHOTOSITE_AT(P, window_curtained_share), "fraction", 0, 1,
          "seeded share of lit windows behind curtains or blinds", "[E]"),
      num("lamps.window_curtained_luminance_cd_m2", PHOTOSITE_AT(P, window_curtained_luminance_cd_m2), "cd/m²", 0,
          1e4, "lit window behind curtains (0.5..1.5× this)", "NP §3"),
      table("windows", "façade window layout (scene/street.cpp)", "[U] architectural rules of thumb; [S] where named"),
      num("windows.storey_m", PHOTOSITE_AT(P, window_storey_m), "m", 1.5, 10, "floor-to-floor height",
          "[S] 3.1 m in residences (reference.com)"),
      num("windows.pitch_m", PHOTOSITE_AT(P, window_pitch_m), "m", 0.3, 10, "window axis spacing", "[U]"),
      num("windows.width_m", PHOTOSITE_AT(P, window_width_m), "m", 0.1, 10, "window width",
          "[S] a standard width (windows24.com)",
          "≤ windows.pitch_m"),
      num("windows.height_m", PHOTOSITE_AT(P, window_height_m), "m", 0.1, 10, "window height",
          "[S] a standard height (windows24.com)",
          "≤ windows.storey_m"),
      num("windows.frame_m", PHOTOSITE_AT(P, window_frame_m), "m", 0, 1,
          "window frame and sash face around the glass, each side", "[U]", "< windows.width_m/2, windows.height_m/2"),
      num("windows.mullion_m", PHOTOSITE_AT(P, window_mullion_m), "m", 0, 1,
          "central mullion between a window's two sashes", "[U]", "≤ windows.width_m − 2·windows.frame_m"),
      num("windows.shop_share", PHOTOSITE_AT(P, shop_share), "fraction", 0, 1,
          "seeded share of ground-floor shop units that are shops", "[E]"),
      num("windows.shop_luminance_factor", PHOTOSITE_AT(P, shop_luminance_factor), "—", 0, 100,
          "ground-floor shop front luminance over a lit window's", "photosite choice (NP §3)"),
      num("windows.shop_cct_K", PHOTOSITE_AT(P, shop_cct_K), "K", 1000, 20000, "shop lighting CCT", "NP §0"),
      num("windows.shop_width_m", PHOTOSITE_AT(P, shop_width_m), "m", 0.1, 10,
          "shop-window pane width, on the window pitch", "[U]", "≤ windows.pitch_m"),
      num("windows.shop_sill_m", PHOTOSITE_AT(P, shop_sill_m), "m", 0, 10, "shop-window sill above the pavement", "[U]"),
      num("windows.shop_height_m", PHOTOSITE_AT(P, shop_height_m), "m", 0.1, 10, "shop-window pane height", "[U]",
          "shop_sill_m + shop_height_m ≤ windows.storey_m"),
      num("windows.shop_frontage_m", PHOTOSITE_AT(P, shop_frontage_m), "m", 0.5, 100,
          "frontage of one shop unit (lit or dark as a whole)", "[U]"),
      num("windows.detect_contrast", PHOTOSITE_AT(P, window_detect_contrast), "fraction", 0, 1,
          "the day photo's windows found on each façade: glass darker than its wall's local mean by this share "
          "(0: not looked for, the grid everywhere)",
          "photosite choice"),
      table("retroreflection", "retroreflective markings and signs", "NP §4"),
      num("retroreflection.marking_RL", PHOTOSITE_AT(P, marking_RL), "cd·m⁻²·lx⁻¹", 0, 5,
          "lane markings' coefficient of retroreflected luminance R_L", "NP §4 (EN 1436)"),
      num("retroreflection.sign_RA", PHOTOSITE_AT(P, sign_RA), "cd·lx⁻¹·m⁻²", 0, 2000,
          "signs' coefficient of retroreflection R_A", "NP §4 (EN 12899 RA2)"),
      num("retroreflection.sign_RA_alpha_deg", PHOTOSITE_AT(P, sign_RA_alpha_deg), "°", 0.01, 5,
          "observation angle at which sign_RA holds", "EN 12899-1 RA2 at 0.33° [S]"),
      num("retroreflection.sign_RA_alpha_exponent", PHOTOSITE_AT(P, sign_RA_alpha_exponent), "—", 0, 5,
          "R_A ∝ α^−exponent beyond sign_RA_alpha_deg",
          "[D] RA2 (\"Typ 2\") white 180 → 5 over 0.33° → 2°, entrance 5°: Austrian StVZVO 1998 Anlage 2 [S]"),
      num("retroreflection.sign_RA_alpha_max_deg", PHOTOSITE_AT(P, sign_RA_alpha_max_deg), "°", 0.01, 5,
          "R_A held at its value here for larger α (an upper bound)", "that table's largest α, 2° [S]",
          "≥ retroreflection.sign_RA_alpha_deg"),
      {"retroreflection.sign_RA_entrance_deg", Kind::NumberList, PHOTOSITE_AT(P, sign_RA_entrance_deg), "°", 0, 89,
       Need::Optional,
       "entrance angles (the lamp's ray against the sign's normal) of the factors below; R_A is linear in tan β "
       "between them and held outside them (empty: no entrance-angle dependence)",
       "[S] RA2 (\"Typ 2\") columns β 5°, 30°, 40°: Austrian StVZVO 1998 Anlage 2",
       "strictly increasing; the factor lists have one value per angle"},
      {"retroreflection.sign_RA_entrance_factor", Kind::NumberList, PHOTOSITE_AT(P, sign_RA_entrance_factor), "—",
       1e-6, 10, Need::Optional, "R_A at each entrance angle over R_A at the first, at sign_RA_alpha_deg and below",
       "[D] white RA2 at 0.33°: 180 / 100 / 95 (that table)", "one value per sign_RA_entrance_deg entry"},
      {"retroreflection.sign_RA_entrance_factor_alpha_max", Kind::NumberList,
       PHOTOSITE_AT(P, sign_RA_entrance_factor_alpha_max), "—", 1e-6, 10, Need::Optional,
       "the same at sign_RA_alpha_max_deg and beyond (geometric in α between the two)",
       "[D] white RA2 at 2°: 5 / 2.5 / 1.5 (that table)", "one value per sign_RA_entrance_deg entry"},
      // Optional (default 60, ScenePreset): scene files written before it keep loading.
      {"retroreflection.sign_read_distance_m", Kind::Number, PHOTOSITE_AT(P, sign_read_distance_m), "m", 0, 500,
       Need::Optional,
       "where the road ahead bends, a sign faces the road's heading this far before it, where the traffic "
       "that reads it approaches (0: the heading at the sign)",
       "[S] visible for at least 60 m to approaching traffic: Ontario Reg. 615 s. 45"},
      table("ego_beam", "the camera car's low beam: E = Σ_lamps I(h, v)·cos θ / d² on the metric ground",
            "NP §3; [S] ECE R112 class B points (01 series; zone IV [U]); [S] R48 heights, cut-off geometry"),
      num("ego_beam.cct_K", PHOTOSITE_AT(P, beam_cct_K), "K", 1000, 20000, "low-beam CCT", "NP §3"),
      num("ego_beam.sign_lux", PHOTOSITE_AT(P, beam_sign_lux), "lx", 0, 1000,
          "illuminance on signs without the metric geometry (with it: the beam at the sign)", "NP §3"),
      num("ego_beam.lamp_height_m", PHOTOSITE_AT(P, beam_lamp_height_m), "m", 0.2, 2, "headlamps above the road",
          "[S] ECE R48: 500-1200 mm"),
      num("ego_beam.lamp_spacing_m", PHOTOSITE_AT(P, beam_lamp_spacing_m), "m", 0, 3, "headlamp centres apart",
          "[U] car width; [S] R48: edges within 400 mm of the side"),
      num("ego_beam.cutoff_v_deg", PHOTOSITE_AT(P, beam_cutoff_v_deg), "°", -5, 5,
          "cut-off line left of the v-v line (positive up)",
          "[S] 1 % below the lamp (euromotor.org)"),
      num("ego_beam.cutoff_rise_deg", PHOTOSITE_AT(P, beam_cutoff_rise_deg), "°", 0, 60,
          "rise of the cut-off right of the elbow",
          "[S] 15° (euromotor.org; wien.gerichts-sv.at)"),
      num("ego_beam.cutoff_max_v_deg", PHOTOSITE_AT(P, beam_cutoff_max_v_deg), "°", -5, 5,
          "where the rising cut-off stops", "photosite choice"),
      num("ego_beam.above_cutoff_cd", PHOTOSITE_AT(P, beam_above_cutoff_cd), "cd", 0, 1e5,
          "one headlamp's intensity above the cut-off (lights signs and vertical surfaces, not the road)",
          "[S] low-beam glare limit above the cut-off, 1 lx at 25 m (euromotor ECE lighting course)"),
      {"ego_beam.lens_diameter_m", Kind::Number, PHOTOSITE_AT(P, beam_lens_diameter_m), "m", 0.01, 1, Need::Optional,
       "headlamp aperture: nearer than 5× it, E on vertical surfaces is held at its value there",
       "[U] passenger-car headlamp lenses 0.1-0.25 m; five-diameter rule of photometric distance (Ryer 1997)", {},
       schema::Exr::Header},
      {"ego_beam.shadows", Kind::Boolean, PHOTOSITE_AT(P, beam_shadows), "", -inf, inf, Need::Optional,
       "the lamps' shadows on the ground and, below the cut-off's top, on vertical surfaces (docs/night.md §6c)",
       "photosite choice (default true): off saves about 3 ms of the chain at 2 threads (docs/benchmarks.md)", {},
       schema::Exr::Header},
      {"ego_beam.h_deg", Kind::NumberList, PHOTOSITE_AT(P, beam_h_deg), "°", -90, 90, Need::Required,
       "horizontal angles of the intensity grid, positive right", "[S] ECE R112 test points",
       "strictly increasing, ≥ 2 values"},
      {"ego_beam.v_deg", Kind::NumberList, PHOTOSITE_AT(P, beam_v_deg), "°", -90, 90, Need::Required,
       "vertical angles of the intensity grid, positive up", "[S] ECE R112 test points",
       "strictly increasing, ≥ 2 values"},
      {"ego_beam.intensity_cd", Kind::NumberRows,
       schema::Rows<P>{PHOTOSITE_AT(P, beam_intensity_cd), [](const P& p) { return p.beam_h_deg.size(); }}, "cd", 0,
       1e6, Need::Required, "one headlamp's intensity below the cut-off, a row per v_deg",
       "[S] ECE R112 class B, 01 series (cd; zone IV [U]), and photosite choice between", "one row per v_deg, one value per h_deg"},
      table("geometry", "lanes, edges, lines and the vanishing point", "photosite choices (docs/night.md)"),
      integer("geometry.work_max_width", PHOTOSITE_AT(P, work_max_width), "px", 64, 8192,
              "the geometry stages run at this width at most", "photosite choice"),
      num("geometry.lane_blur_sigma_px", PHOTOSITE_AT(P, lane_blur_sigma_px), "px", 0, 20,
          "Gaussian blur before the lane-marking test", "photosite choice"),
      num("geometry.lane_contrast_threshold", PHOTOSITE_AT(P, lane_contrast_threshold), "—", 0, 1,
          "luma excess over the blurred road that marks a lane line", "photosite choice"),
      num("geometry.canny_low", PHOTOSITE_AT(P, canny_low), "—", 0, 1000, "Canny hysteresis low threshold (L2 gradient)",
          "photosite choice", "≤ geometry.canny_high"),
      num("geometry.canny_high", PHOTOSITE_AT(P, canny_high), "—", 0, 1000, "Canny hysteresis high threshold",
          "photosite choice"),
      integer("geometry.hough_threshold", PHOTOSITE_AT(P, hough_threshold), "votes", 1, 10000,
              "probabilistic Hough accumulator threshold", "photosite choice"),
      num("geometry.hough_min_length_fraction", PHOTOSITE_AT(P, hough_min_length_fraction), "fraction", 0, 1,
          "shortest line, of the image width (≥ 5 px)", "photosite choice"),
      num("geometry.hough_max_gap_fraction", PHOTOSITE_AT(P, hough_max_gap_fraction), "fraction", 0, 1,
          "largest gap within a line, of the image width (≥ 1 px)", "photosite choice"),
      num("geometry.line_reject_angle_deg", PHOTOSITE_AT(P, line_reject_angle_deg), "°", 0, 45,
          "lines this near horizontal or vertical are dropped", "photosite choice"),
      num("geometry.border_fraction", PHOTOSITE_AT(P, border_fraction), "fraction", 0, 0.4,
          "lines with both ends in this frame border are dropped", "photosite choice"),
      num("geometry.vp_cluster_radius_fraction", PHOTOSITE_AT(P, vp_cluster_radius_fraction), "fraction", 0.001, 1,
          "vanishing-point cluster radius, of the image diagonal", "photosite choice"),
      integer("geometry.vp_min_support", PHOTOSITE_AT(P, vp_min_support), "lines", 1, 10000,
              "fewer intersections in the cluster: no vanishing point", "photosite choice"),
      num("geometry.max_depth_m", PHOTOSITE_AT(P, max_depth_m), "m", 10, 60000,
          "metric depth cap (ground near the horizon, objects without a ground contact)", "photosite choice"),
      {"geometry.tram_gauges_m", Kind::NumberList, PHOTOSITE_AT(P, tram_gauges_m), "m", 0.5, 2.0, Need::Optional,
       "tram track gauges: marking pairs this far apart (plus a rail head) are rails, not markings",
       "[S] standard gauge 1435 mm (UIC) and metre gauge 1000 mm, the gauges of German and Swiss tramways"},
  };
  return rows;
}

// The cross-key conditions, at the line of the key they name.
void validate(const ScenePreset& p, const toml::table& t, const std::string& file) {
  auto err = [&](const char* key, const std::string& problem) {
    schema::key_error(file, schema::line_at(t, key), key, problem);
  };
  auto increasing = [&](const char* key, const std::vector<double>& a) {
    for (size_t i = 1; i < a.size(); ++i)
      if (!(a[i] > a[i - 1])) err(key, "angles must increase strictly");
  };
  for (const char* key : {"ego_beam.h_deg", "ego_beam.v_deg"}) {
    const auto& a = std::string_view(key) == "ego_beam.h_deg" ? p.beam_h_deg : p.beam_v_deg;
    if (a.size() < 2) err(key, "needs at least two angles");
    increasing(key, a);
  }
  const toml::array* rows = t.at_path("ego_beam.intensity_cd").as_array();  // read() found it an array
  if (!rows || rows->size() != p.beam_v_deg.size() ||
      p.beam_intensity_cd.size() != p.beam_h_deg.size() * p.beam_v_deg.size())
    err("ego_beam.intensity_cd", "needs one row per v_deg entry (" + std::to_string(p.beam_v_deg.size()) +
                                     "), each with one value per h_deg entry (" +
                                     std::to_string(p.beam_h_deg.size()) + ")");
  if (p.window_width_m > p.window_pitch_m) err("windows.width_m", "exceeds windows.pitch_m");
  if (p.window_height_m > p.window_storey_m) err("windows.height_m", "exceeds windows.storey_m");
  if (p.shop_width_m > p.window_pitch_m) err("windows.shop_width_m", "exceeds windows.pitch_m");
  if (2 * p.window_frame_m >= std::min(p.window_width_m, p.window_height_m))
    err("windows.frame_m", "leaves no glass (2·frame_m ≥ width_m or height_m)");
  if (p.window_mullion_m > p.window_width_m - 2 * p.window_frame_m)
    err("windows.mullion_m", "exceeds the glass width windows.width_m − 2·frame_m");
  if (p.shop_sill_m + p.shop_height_m > p.window_storey_m)
    err("windows.shop_height_m", "shop_sill_m + shop_height_m exceeds windows.storey_m");
  if (p.canny_low > p.canny_high) err("geometry.canny_low", "exceeds canny_high");
  if (p.sign_RA_alpha_max_deg < p.sign_RA_alpha_deg)
    err("retroreflection.sign_RA_alpha_max_deg", "is below sign_RA_alpha_deg");
  const char* const entrance_key = "retroreflection.sign_RA_entrance_deg";
  increasing(entrance_key, p.sign_RA_entrance_deg);
  const std::pair<const char*, const std::vector<double>*> factors[] = {
      {"retroreflection.sign_RA_entrance_factor", &p.sign_RA_entrance_factor},
      {"retroreflection.sign_RA_entrance_factor_alpha_max", &p.sign_RA_entrance_factor_alpha_max}};
  for (const auto& [key, f] : factors)
    if (f->size() != p.sign_RA_entrance_deg.size())
      err(f->empty() ? entrance_key : key, "needs one value of " + std::string(key) + " per sign_RA_entrance_deg entry (" +
                                               std::to_string(p.sign_RA_entrance_deg.size()) + "), has " +
                                               std::to_string(f->size()));
  if (p.sun_shade_ratio_min > p.sun_shade_ratio_max && p.sun_shade_ratio_max > 1)
    err("reflectance.sun_shade_ratio_min", "is above sun_shade_ratio_max (no class could split)");
  if (p.shade_sky_cct_K <= p.sun_cct_K)
    err("reflectance.shade_sky_cct_K", "is not above sun_cct_K (the shade would not be bluer than the sun)");
}
}  // namespace

const char* streetlamp_type_name(StreetlampType t) { return t == StreetlampType::Hps ? "hps" : "led"; }

StreetlampType parse_streetlamp_type(const std::string& name) {
  if (name == "led") return StreetlampType::Led;
  if (name == "hps") return StreetlampType::Hps;
  fail("unknown street lamp type '" + name + "' (expected " + kStreetlampTypeNames + ")");
}

const char* day_white_balance_name(DayWhiteBalance m) { return m == DayWhiteBalance::Road ? "road" : "none"; }

DayWhiteBalance parse_day_white_balance(const std::string& name) {
  if (name == "road") return DayWhiteBalance::Road;
  if (name == "none") return DayWhiteBalance::None;
  fail("unknown day white balance '" + name + "' (expected " + kDayWhiteBalanceNames + ")");
}

ScenePreset parse_scene_preset(const std::string& text, const std::string& file) {
  const toml::table t = schema::parse_toml(text, file);
  if (const toml::node* bloom = t.get("bloom"))  // the scene-space bloom is gone: glare is the lens's now
    schema::key_error(file, schema::line_of(*bloom), "bloom",
                      "the scene-space bloom was removed; veiling glare is a property of the lens: set it in the "
                      "lens preset's [glare] table (presets/lenses/*.toml, docs/model_glare.md)");
  ScenePreset p;
  p.file = file;
  p.name = std::filesystem::path(file).stem().string();
  schema::read<ScenePreset>(t, scene_schema(), file, p);
  validate(p, t, file);
  return p;
}

ScenePreset load_scene_preset(const std::string& name_or_path) {
  const auto dir = std::filesystem::path(preset_dir()) / "scenes";
  const auto path = schema::preset_file(dir, name_or_path);
  if (!path)
    fail("unknown scene preset '" + name_or_path + "' (bundled: " + schema::comma_list(schema::preset_names(dir)) +
         ")");
  return parse_scene_preset(schema::read_text(*path, "scene preset"), *path);
}

std::map<std::string, ExrAttribute> scene_attributes(const ScenePreset& p) {
  auto a = schema::attributes<ScenePreset>(scene_schema(), p, "photosite/scene/");
  a["photosite/scene/preset"] = p.name;
  return a;
}

std::string to_json(const ScenePreset& p, int indent) {
  nlohmann::json j = schema::to_json<ScenePreset>(scene_schema(), p);
  j["name"] = p.name;
  j["file"] = p.file;
  return j.dump(indent);
}

std::string scene_presets_doc_markdown() {
  return schema::markdown_table(schema::doc_rows<ScenePreset>(scene_schema()));
}

}  // namespace photosite::scene
