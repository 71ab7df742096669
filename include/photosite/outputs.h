// What the sensor commands write: the EXR layers (channel groups) and the header attributes of
// `expose`/`flat` (sensor outputs) and of `night`/`batch` (night frames). A library module so
// that every face — the command line, the batch engine, the Python module — writes the same
// layout from the same code.
#pragma once
#include <map>
#include <string>
#include <vector>

#include "photosite/io.h"
#include "photosite/scene/night.h"
#include "photosite/sensor/fpn.h"
#include "photosite/sensor/pipeline.h"
#include "photosite/sensor/preset.h"

namespace photosite {

// The resolved identity of a sensor run: camera, lens, settings and the device whose
// fixed-pattern maps were used. Recorded in every output's header.
struct SensorSetup {
  CameraPreset camera;
  LensPreset lens;
  ExposureSettings settings;
  std::string device_id;
};

// The header attributes every sensor output carries ("photosite/..."): version, preset, lens,
// device and its fixed-pattern checksum, seed, frame, the resolved exposure, CFA, bit depth,
// black level and demosaic method.
std::map<std::string, ExrAttribute> sensor_attributes(const SensorSetup& setup,
                                                      const ResolvedExposure& ex,
                                                      const FixedPatternMaps& fpn);
// The channel groups of a sensor output: raw.Y, R,G,B, electrons.Y.
std::vector<ExrChannelGroup> sensor_channels(const SensorOutput& out);

// ---- night frames (`night`, `batch`) ----------------------------------------------------------
struct NightInputs {
  std::string image, labels, instances;
};

// Channel groups: the sensor's (raw.Y, R,G,B, electrons.Y), night_radiance.R/G/B, depth.Z,
// lights.R/G/B, labels.Y. `label_img` must outlive the returned groups.
std::vector<ExrChannelGroup> night_channels(const SensorOutput& out, const scene::NightScene& ns,
                                            const ImageF& label_img);
// The label ids as a one-channel image (unit label_id) for the labels.Y layer.
ImageF label_image(const scene::LabelMap& labels);

// Header: the sensor attributes, every scene parameter, the inputs, the vanishing point (with
// confidence, method and fallback note) and the light counts.
std::map<std::string, ExrAttribute> night_attributes(const SensorSetup& setup,
                                                     const ResolvedExposure& ex,
                                                     const FixedPatternMaps& fpn,
                                                     const scene::ScenePreset& sp,
                                                     const scene::NightScene& ns,
                                                     const scene::LabelMap& labels,
                                                     const NightInputs& in);

}  // namespace photosite
