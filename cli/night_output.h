// The EXR layers and header of a night frame, shared by `night` and `batch`.
#pragma once
#include <map>
#include <string>
#include <vector>

#include "photosite/scene/night.h"
#include "sensor_options.h"

namespace photosite::cli {

struct NightInputs {
  std::string image, labels, instances;
};

// Channel groups: the sensor's (raw.Y, R,G,B, electrons.Y), night_radiance.R/G/B, depth.Z,
// lights.R/G/B, labels.Y. `label_img` must outlive the returned groups.
std::vector<ExrChannelGroup> night_channels(const SensorOutput& out, const scene::NightScene& ns,
                                            const ImageF& label_img);
ImageF label_image(const scene::LabelMap& labels);

// Header: the sensor attributes, every scene parameter, the inputs, the vanishing point (with
// confidence, method and fallback note) and the light counts.
std::map<std::string, ExrAttribute> night_attributes(const SensorOptions::Resolved& r,
                                                     const ResolvedExposure& ex,
                                                     const FixedPatternMaps& fpn,
                                                     const scene::ScenePreset& sp,
                                                     const scene::NightScene& ns,
                                                     const scene::LabelMap& labels,
                                                     const NightInputs& in);

}  // namespace photosite::cli
