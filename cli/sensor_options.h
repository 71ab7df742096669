// Options shared by the commands that run the sensor (expose, flat, night, characterize):
// preset, lens, exposure, device and seed, with their resolution into library types.
#pragma once
#include <CLI/CLI.hpp>
#include <map>
#include <optional>
#include <string>

#include "photosite/io.h"
#include "photosite/outputs.h"
#include "photosite/sensor/fpn.h"
#include "photosite/sensor/pipeline.h"
#include "photosite/sensor/preset.h"

namespace photosite::cli {

struct SensorOptions {
  std::string preset;
  std::string lens;  // empty: the camera's default lens
  double exposure_s = 0.02;
  std::optional<double> f_number;       // none: the lens preset's
  double gain_db = 0.0;
  std::optional<double> temperature_c;  // none: the camera preset's
  uint64_t seed = 0;
  int frames = 1;
  std::string device_id;  // empty: "<preset>-0"
  std::string device_store;
  std::string demosaic = "bilinear";
  std::string poisson = "exact";

  // Adds the options; `preset_required` for commands where --preset has no default.
  void add(CLI::App* sub, bool preset_required = true);

  // The camera, lens, settings and device id (what outputs record) and the device store.
  struct Resolved : SensorSetup {
    DeviceStore store;
  };
  Resolved resolve() const;
};

// The preview flags of the commands that write a PNG preview (expose, night): --preview-isp,
// --preview-denoise, --preview-jpeg-quality, resolved into the library's PreviewOptions.
struct PreviewFlags {
  std::string isp = "simple";
  CameraIspOptions camera;
  void add(CLI::App* sub);
  PreviewOptions resolve() const;  // throws ParameterError naming the parameter
};

// Output paths for N frames: with frames > 1 the pattern must hold a '#' run.
std::vector<std::string> frame_outputs(const std::string& pattern, int frames, bool overwrite);

}  // namespace photosite::cli
