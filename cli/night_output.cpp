#include "night_output.h"

namespace photosite::cli {

ImageF label_image(const scene::LabelMap& labels) {
  ImageF img(labels.ids.width(), labels.ids.height(), 1, 0.f, unit::label_id);
  for (size_t i = 0; i < img.pixel_count(); ++i) img[i] = labels.ids[i];
  return img;
}

std::vector<ExrChannelGroup> night_channels(const SensorOutput& out, const scene::NightScene& ns,
                                            const ImageF& label_img) {
  auto groups = sensor_channels(out);
  groups.push_back({{"night_radiance.R", "night_radiance.G", "night_radiance.B"}, &ns.radiance, unit::radiance});
  groups.push_back({{"depth.Z"}, &ns.depth, unit::dimensionless});
  groups.push_back({{"lights.R", "lights.G", "lights.B"}, &ns.lights, unit::radiance});
  groups.push_back({{"labels.Y"}, &label_img, unit::label_id});
  return groups;
}

std::map<std::string, ExrAttribute> night_attributes(const SensorOptions::Resolved& r,
                                                     const ResolvedExposure& ex,
                                                     const FixedPatternMaps& fpn,
                                                     const scene::ScenePreset& sp,
                                                     const scene::NightScene& ns,
                                                     const scene::LabelMap& labels,
                                                     const NightInputs& in) {
  auto attrs = sensor_attributes(r, ex, fpn);
  const auto scene_attrs = scene::scene_attributes(sp);
  attrs.insert(scene_attrs.begin(), scene_attrs.end());
  attrs["photosite/night/image"] = in.image;
  attrs["photosite/night/labels"] = in.labels;
  attrs["photosite/night/label_format"] = std::string(scene::label_format_name(labels.format));
  if (!in.instances.empty()) attrs["photosite/night/instances"] = in.instances;
  attrs["photosite/night/vanishing_point_x"] = ns.vp.x;
  attrs["photosite/night/vanishing_point_y"] = ns.vp.y;
  attrs["photosite/night/vanishing_point_confidence"] = ns.vp.confidence;
  attrs["photosite/night/vanishing_point_method"] = std::string(scene::vp_method_name(ns.vp.method));
  attrs["photosite/night/vanishing_point_support"] = ns.vp.support;
  if (!ns.vp.note.empty()) attrs["photosite/night/vanishing_point_note"] = ns.vp.note;
  attrs["photosite/night/lines"] = static_cast<int>(ns.lines_work.size());
  attrs["photosite/night/work_scale"] = ns.work_scale;
  attrs["photosite/night/lights_signals"] = ns.light_stats.signals;
  attrs["photosite/night/lights_vehicle_lamps"] = ns.light_stats.vehicle_lamps;
  attrs["photosite/night/lights_pole_lamps"] = ns.light_stats.pole_lamps;
  attrs["photosite/night/lights_windows"] = ns.light_stats.windows;
  return attrs;
}

}  // namespace photosite::cli
