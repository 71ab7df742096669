// The EXR layers and header attributes of sensor outputs and night frames (see outputs.h).
#include "photosite/outputs.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "photosite/error.h"
#include "photosite/night_chain.h"
#include "photosite/sensor/pipeline.h"

namespace photosite {

namespace {
constexpr std::pair<const char*, Layer> kLayerNames[] = {
    {"sensor", Layer::Sensor}, {"raw", Layer::Raw},       {"electrons", Layer::Electrons},
    {"radiance", Layer::Radiance}, {"lights", Layer::Lights}, {"depth", Layer::Depth},
    {"labels", Layer::Labels}};
}  // namespace

LayerSet parse_layers(const std::string& list, LayerSet applicable, const std::string& what,
                      const std::string& command) {
  LayerSet s = 0;
  size_t b = 0;
  while (b <= list.size()) {
    size_t e = list.find(',', b);
    if (e == std::string::npos) e = list.size();
    const std::string name = list.substr(b, e - b);
    b = e + 1;
    if (name.empty()) continue;
    bool known = false;
    for (const auto& [n, l] : kLayerNames)
      if (name == n) {
        known = true;
        if (!has(applicable, l))
          fail(fmt::format("{} {}: {} does not write the layer '{}' (it writes {})", what, list, command, name,
                           layers_text(applicable)));
        // A name given twice is most likely a slip for another layer (sensor,sensor for
        // sensor,radiance): refused rather than read as once.
        if (has(s, l)) fail(fmt::format("{} {}: the layer '{}' is named twice", what, list, name));
        s |= static_cast<unsigned>(l);
      }
    if (!known)
      fail(fmt::format("{} {}: unknown layer '{}' (layers: {})", what, list, name, layers_text(applicable)));
  }
  if (s == 0) fail(fmt::format("{} '{}': no layer named", what, list));
  return s;
}

std::string layers_text(LayerSet s) {
  std::string t;
  for (const auto& [n, l] : kLayerNames)
    if (has(s, l)) t += (t.empty() ? "" : ",") + std::string(n);
  return t;
}

std::map<std::string, ExrAttribute> sensor_attributes(const SensorSetup& r,
                                                      const ResolvedExposure& ex,
                                                      const FixedPatternMaps& fpn) {
  std::map<std::string, ExrAttribute> a = camera_attributes(r.camera);  // cfa, bit_depth, black_level_dn
  // Where this exposure's raw clips (clip_level, sensor/pipeline.h): a raw DN at or above
  // clipped_at_dn is clipped, and the clear patterns' R,G,B take clip_neutral_dn (DN above black)
  // there; `demosaic` reads both from a raw mosaic's header.
  const ClipLevel clip = clip_level(r.camera, ex);
  a.insert({{"photosite/clipped_at_dn", clip.clipped_at_dn}, {"photosite/clip_neutral_dn", clip.neutral_dn}});
  a.insert({{"photosite/version", std::string(PHOTOSITE_VERSION)},
            {"photosite/preset", r.camera.name},
            {"photosite/lens", r.lens.name},
            {"photosite/preset_xxh3_64", r.camera.text_xxh3_64},
            {"photosite/lens_xxh3_64", r.lens.text_xxh3_64},
            {"photosite/device_id", r.device_id},
            {"photosite/fpn_checksum", fpn.checksum},
            {"photosite/seed", std::to_string(r.settings.seed)},
            {"photosite/frame", static_cast<int>(r.settings.frame)},
            {"photosite/exposure_s", ex.exposure_s},
            {"photosite/f_number", ex.f_number},
            {"photosite/gain_db", ex.gain_db},
            {"photosite/gain", ex.gain_linear},
            {"photosite/system_gain_dn_per_e", ex.system_gain_dn_per_e},
            {"photosite/temperature_c", ex.temperature_c},
            {"photosite/demosaic", std::string(to_string(r.settings.demosaic))},
            {"photosite/poisson", std::string(to_string(r.settings.poisson))}});
  return a;
}

std::vector<ExrChannelGroup> sensor_channels(const SensorOutput& out, LayerSet layers) {
  // raw.Y (ADC codes) and electrons.Y (counted charges) are integers: UINT channels, exact. R,G,B
  // (demosaiced, fractional DN up to 2^bit_depth) stay float32: half's 11-bit significand would
  // step 2 DN at 4095, coarser than the ADC.
  std::vector<ExrChannelGroup> g;
  if (has(layers, Layer::Raw)) g.push_back({{"raw.Y"}, &out.raw_dn, unit::dn, ExrPixel::Uint});
  if (has(layers, Layer::Sensor)) g.push_back({{"R", "G", "B"}, &out.rgb, "DN above black level"});
  if (has(layers, Layer::Electrons)) g.push_back({{"electrons.Y"}, &out.electrons, unit::electrons, ExrPixel::Uint});
  return g;
}

ImageF label_image(const scene::LabelMap& labels) {
  ImageF img(labels.ids.width(), labels.ids.height(), 1, 0.f, unit::label_id);
  for (size_t i = 0; i < img.pixel_count(); ++i) img[i] = labels.ids[i];
  return img;
}

std::vector<ExrChannelGroup> night_channels(const SensorOutput& out, const scene::NightScene& ns,
                                            const scene::LabelMap& labels, LayerSet layers) {
  auto groups = sensor_channels(out, layers);
  if (has(layers, Layer::Radiance)) groups.push_back({{"night_radiance.R", "night_radiance.G", "night_radiance.B"}, &ns.radiance, unit::radiance});
  // depth.Z in metres (metric_depth, the EXR convention: distance along the optical axis) as
  // half: relative spacing 2^-11 (0.05%), far below the flat-ground model's own error; the sky is
  // the largest finite half, 65504 (header photosite/night/depth_infinity_m). night_radiance and
  // lights stay float32: physical radiances whose range is set by the scene preset, not bounded
  // by half's [6.1e-5, 65504] normal range.
  if (has(layers, Layer::Depth)) groups.push_back({{"depth.Z"}, &ns.depth, "m", ExrPixel::Half});
  if (has(layers, Layer::Lights)) groups.push_back({{"lights.R", "lights.G", "lights.B"}, &ns.lights, unit::radiance});
  if (has(layers, Layer::Labels))  // class ids, straight from their 16-bit samples
    groups.push_back({{"labels.Y"}, nullptr, unit::label_id, ExrPixel::Uint, &labels.ids});
  return groups;
}

std::map<std::string, ExrAttribute> night_attributes(const SensorSetup& r,
                                                     const ResolvedExposure& ex,
                                                     const FixedPatternMaps& fpn,
                                                     const scene::ScenePreset& sp,
                                                     const scene::NightScene& ns,
                                                     const scene::LabelMap& labels,
                                                     const NightInputs& in) {
  auto attrs = sensor_attributes(r, ex, fpn);
  const auto scene_attrs = scene::scene_attributes(sp);
  attrs.insert(scene_attrs.begin(), scene_attrs.end());
  // The radiance layers hold this camera's metamers (scene_for_camera) of the traffic signals' and
  // rear lamps' LEDs and, with hps street lamps, of CIE HP1, with led ones of CIE LED-B at the
  // heads' CCT (`..._led_heads`) and at the street light's (`..._led_street`): their band radiances
  // per cd/m², so that a reader of `night_radiance` or `lights` knows their box luminance is not
  // the photometric one (docs/night.md §7, "Lamp type" and "Signal and rear-lamp LEDs").
  const scene::ScenePreset cs = scene_for_camera(sp, r.camera);
  auto put = [&](const std::string& stem, spectrum::LampSpectrum ls) {
    const auto& w = cs.lamp_camera_rgb[static_cast<int>(ls)];
    attrs[stem + "_R"] = w[0];
    attrs[stem + "_G"] = w[1];
    attrs[stem + "_B"] = w[2];
  };
  if (sp.streetlamp_type == scene::StreetlampType::Hps)
    put("photosite/night/streetlamp_camera_rgb_per_cd_m2", spectrum::LampSpectrum::Hp1);
  if (sp.streetlamp_type == scene::StreetlampType::Led) {
    put("photosite/night/streetlamp_camera_rgb_per_cd_m2_led_heads", spectrum::LampSpectrum::LedBHeads);
    put("photosite/night/streetlamp_camera_rgb_per_cd_m2_led_street", spectrum::LampSpectrum::LedBStreet);
  }
  put("photosite/night/signal_camera_rgb_per_cd_m2_red", spectrum::LampSpectrum::RedLed);
  put("photosite/night/signal_camera_rgb_per_cd_m2_amber", spectrum::LampSpectrum::AmberLed);
  put("photosite/night/signal_camera_rgb_per_cd_m2_green", spectrum::LampSpectrum::GreenLed);
  attrs["photosite/night/image"] = in.image;
  if (!in.image_note.empty()) attrs["photosite/night/image_note"] = in.image_note;
  if (!in.image_file_note.empty()) attrs["photosite/night/image_file_note"] = in.image_file_note;
  attrs["photosite/night/labels"] = in.labels;
  attrs["photosite/night/label_format"] = std::string(scene::label_format_name(labels.format));
  if (!in.instances.empty()) attrs["photosite/night/instances"] = in.instances;
  attrs["photosite/night/vanishing_point_x"] = ns.vp.x;
  attrs["photosite/night/vanishing_point_y"] = ns.vp.y;
  attrs["photosite/night/vanishing_point_confidence"] = ns.vp.confidence;
  attrs["photosite/night/vanishing_point_method"] = std::string(scene::vp_method_name(ns.vp.method));
  attrs["photosite/night/vanishing_point_support"] = ns.vp.support;
  if (!ns.vp.note.empty()) attrs["photosite/night/vanishing_point_note"] = ns.vp.note;
  const auto& g = ns.geometry;
  attrs["photosite/night/horizon_y"] = g.horizon_y;
  attrs["photosite/night/horizon_source"] = g.horizon_source;
  attrs["photosite/night/horizon_confidence"] = g.horizon_confidence;
  if (!g.note.empty()) attrs["photosite/night/geometry_note"] = g.note;
  attrs["photosite/night/camera_rig"] = g.rig;
  attrs["photosite/night/camera_pitch_deg"] = g.pitch_rad * 180 / M_PI;
  attrs["photosite/night/focal_length_px"] = g.f_px;
  // The focal length the optics used (cos⁴ falloff, glare): the frame's own, lens_for_frame.
  attrs["photosite/night/optics_focal_length_mm"] = lens_for_frame(r.lens, r.camera, g).focal_length_mm;
  attrs["photosite/night/mount_height_m"] = g.mount_height_m;
  attrs["photosite/night/depth_infinity_m"] = static_cast<double>(scene::kDepthInfinity_m);
  attrs["photosite/night/lines"] = static_cast<int>(ns.lines_work.size());
  attrs["photosite/night/work_scale"] = ns.work_scale;
  attrs["photosite/night/tram_rail_pixels"] = ns.tram_rail_pixels;
  attrs["photosite/night/sky_gap_pixels"] = static_cast<int>(ns.sky_gap_pixels);  // vegetation taken for sky (take_sky_gaps)
  attrs["photosite/night/sky_fringe_pixels"] = static_cast<int>(ns.sky_fringe_pixels);  // unmix_sky_fringe
  // The day sky's and leaves' levels the crowns were read against (take_sky_gaps).
  attrs["photosite/night/sky_day_luminance"] = static_cast<double>(ns.sky_day_luminance);
  attrs["photosite/night/leaf_day_luminance"] = static_cast<double>(ns.leaf_day_luminance);
  // Ground pixels in the shadow of the left lamp only, the right lamp only, both (docs/night.md §6c).
  attrs["photosite/night/beam_shadow_left_pixels"] = static_cast<int>(ns.beam_shadow.one_lamp[0]);
  attrs["photosite/night/beam_shadow_right_pixels"] = static_cast<int>(ns.beam_shadow.one_lamp[1]);
  attrs["photosite/night/beam_shadow_both_pixels"] = static_cast<int>(ns.beam_shadow.both);
  // The same on vertical surfaces (below the cut-off's top, BeamVerticalRows::shadow_stats).
  attrs["photosite/night/beam_shadow_vertical_left_pixels"] = static_cast<int>(ns.beam_shadow_vertical.one_lamp[0]);
  attrs["photosite/night/beam_shadow_vertical_right_pixels"] = static_cast<int>(ns.beam_shadow_vertical.one_lamp[1]);
  attrs["photosite/night/beam_shadow_vertical_both_pixels"] = static_cast<int>(ns.beam_shadow_vertical.both);
  attrs["photosite/night/lights_signals"] = ns.light_stats.signals;
  attrs["photosite/night/lights_vehicle_lamps"] = ns.light_stats.vehicle_lamps;
  attrs["photosite/night/lights_pole_lamps"] = ns.light_stats.pole_lamps;
  attrs["photosite/night/lights_windows"] = ns.light_stats.windows;
  attrs["photosite/night/vehicles_in_traffic"] = ns.light_stats.vehicles_in_traffic;
  attrs["photosite/night/vehicles_parked"] = ns.light_stats.vehicles_parked;
  attrs["photosite/night/vehicles_parked_lit"] = ns.light_stats.vehicles_parked_lit;
  attrs["photosite/night/vehicle_beams"] = ns.light_stats.vehicle_beams;  // oncoming ones
  attrs["photosite/night/vehicle_beams_going_away"] = ns.light_stats.vehicle_beams_going_away;
  attrs["photosite/night/street_lamps"] = ns.light_stats.street_lamps;
  attrs["photosite/night/street_lamp_source"] = ns.light_stats.street_lamp_source;
  if (!ns.light_stats.street_lamp_note.empty())
    attrs["photosite/night/street_lamp_note"] = ns.light_stats.street_lamp_note;
  attrs["photosite/night/street_lamp_shadow_pixels"] = static_cast<int>(ns.light_stats.street_shadow_pixels);
  attrs["photosite/night/street_peak_intensity_cd"] = ns.light_stats.street_peak_intensity_cd;
  attrs["photosite/night/road_luminance_avg_cd_m2"] = ns.light_stats.road_luminance_avg_cd_m2;
  attrs["photosite/night/road_uniformity_u0"] = ns.light_stats.road_uniformity_u0;
  attrs["photosite/night/road_ahead"] = ns.light_stats.road_ahead;
  attrs["photosite/night/road_curvature_per_m"] = ns.light_stats.road_curvature_per_m;
  attrs["photosite/night/road_curve_start_m"] = ns.light_stats.road_curve_start_m;
  attrs["photosite/night/road_curvature_se_per_m"] = ns.light_stats.road_curvature_se_per_m;
  // The day photo's white balance the texture was made with (reflectance.day_white_balance).
  attrs["photosite/night/day_white_balance"] = ns.day_balance.state();
  attrs["photosite/night/day_white_balance_gain_R"] = ns.day_balance.gain[0];
  attrs["photosite/night/day_white_balance_gain_G"] = ns.day_balance.gain[1];
  attrs["photosite/night/day_white_balance_gain_B"] = ns.day_balance.gain[2];
  attrs["photosite/night/day_white_balance_road_samples"] = static_cast<int>(ns.day_balance.samples);
  attrs["photosite/night/day_white_balance_road_cct_K"] = ns.day_balance.road_cct_K;
  return attrs;
}

std::string day_image_note(const ImageF& day, const ImageFileInfo& info) {
  if (!info.is_float) return {};
  const int c = day.channels(), used = c >= 3 ? 3 : 1;  // the channels linearize() reads
  const int64_t n = static_cast<int64_t>(day.pixel_count());
  int64_t pixels = 0;
  float least = 0.f;
#pragma omp parallel for schedule(static) reduction(+ : pixels) reduction(min : least)
  for (int64_t i = 0; i < n; ++i) {
    bool negative = false;
    for (int k = 0; k < used; ++k) {
      const float v = day[i * c + k];
      negative |= v < 0.f;
      least = std::min(least, v);
    }
    pixels += negative;
  }
  if (pixels == 0) return {};
  // The first sample in reading order that holds the least value (a count and a minimum are the
  // same for any thread count; so is this).
  int64_t at = 0;
  while (day[at] != least || (c >= 3 ? at % c >= 3 : at % c != 0)) ++at;
  static const char* const kRgb[] = {"R", "G", "B"};
  const int64_t p = at / c;
  const std::string where = fmt::format("{}at pixel ({}, {})", used == 3 ? std::string(kRgb[at % c]) + " " : "",
                                        p % day.width(), p / day.width());
  return fmt::format("{} of {} pixels have negative values, clipped to 0; the most negative {} ({})", pixels, n,
                     least, where);
}

PreviewIsp parse_preview_isp(const std::string& name) {
  if (name == "simple") return PreviewIsp::Simple;
  if (name == "camera") return PreviewIsp::Camera;
  fail_parameter("preview_isp", "", ": '" + name + "' is not simple or camera");
}

PreviewWb parse_preview_wb(const std::string& name) {
  if (name == "fixed") return PreviewWb::Fixed;
  if (name == "auto") return PreviewWb::Auto;
  fail_parameter("preview_wb", "", ": '" + name + "' is not fixed or auto");
}

PreviewCcm parse_preview_ccm(const std::string& name) {
  if (name == "none") return PreviewCcm::None;
  if (name == "camera") return PreviewCcm::Camera;
  fail_parameter("preview_ccm", "", ": '" + name + "' is not none or camera");
}

std::array<double, 3> preview_wb_gains(const ImageF& rgb, const CameraPreset& camera, const ResolvedExposure& exposure,
                                       PreviewWb wb) {
  const auto fixed = white_balance_gains(camera);
  if (wb == PreviewWb::Fixed) return fixed;
  return auto_white_balance_gains(rgb, sensor_full_scale_dn(camera, exposure), camera_awb_bounds(camera), fixed);
}

void check_preview_frame(const PreviewOptions& o, int width, int height) {
  if (o.isp == PreviewIsp::Camera) check_camera_isp_frame(o.camera, width, height);
}

void check_preview_camera(const PreviewOptions& o, const CameraPreset& camera) {
  if (o.ccm == PreviewCcm::Camera) colour_correction_matrix(camera);
}

ImageU8 preview_image(const SensorOutput& out, const SensorSetup& setup, const ResolvedExposure& exposure,
                      const PreviewOptions& options) {
  const auto wb = preview_wb_gains(out.rgb, setup.camera, exposure, options.wb);
  const double min_white = preview_min_white(setup.camera, exposure, wb);
  // The colour matrix keeps neutrals (its rows sum to 1), so the white floor keeps its meaning.
  ImageF corrected;
  if (options.ccm == PreviewCcm::Camera) corrected = apply_colour_matrix(out.rgb, colour_correction_matrix(setup.camera), wb);
  const ImageF& rgb = options.ccm == PreviewCcm::Camera ? corrected : out.rgb;
  if (options.isp == PreviewIsp::Simple) return preview_srgb8(rgb, wb, 0.99, 1.0, min_white);
  CameraIspOptions camera = options.camera;
  if (camera.min_white == 0) camera.min_white = min_white;
  return preview_camera8(rgb, wb, {exposure.system_gain_dn_per_e, setup.camera.read_noise_e}, camera);
}

}  // namespace photosite
