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

  // The options only some commands use (characterize measures with its own exposures and frames,
  // through no lens aperture and no demosaic): a command adds just those it reads.
  // (flat and characterize are given photons per pixel, so no lens or aperture acts on them.)
  enum Extra : unsigned { kExposure = 1, kFNumber = 2, kFrames = 4, kDemosaic = 8, kLens = 16, kAllExtras = 31 };
  unsigned extras = kAllExtras;  // as added
  // Adds the options; `preset_required` for commands where --preset has no default.
  void add(CLI::App* sub, bool preset_required = true, unsigned extras = kAllExtras);

  // The camera, lens, settings and device id (what outputs record) and the device store.
  struct Resolved : SensorSetup {
    DeviceStore store;
  };
  Resolved resolve() const;
};

// The preview flags of the commands that write a PNG preview (expose, night): --preview-isp,
// --preview-wb, --preview-denoise, --preview-jpeg-quality, resolved into the library's PreviewOptions.
struct PreviewFlags {
  std::string isp = "simple";
  std::string wb = "fixed";
  std::string ccm = "none";
  CameraIspOptions camera;
  // The options as added (null when the flags were set in code, e.g. by `demo`): count() > 0
  // when given on the command line.
  const CLI::Option *isp_option = nullptr, *wb_option = nullptr, *ccm_option = nullptr, *denoise_option = nullptr, *jpeg_option = nullptr;
  void add(CLI::App* sub);
  // Throws ParameterError naming the parameter; bad input when a flag is given that cannot act:
  // any of them without a preview (`preview` empty), or the camera ISP's knobs with the simple ISP.
  PreviewOptions resolve(const std::string& preview) const;
};

// Output paths for N frames: with frames > 1 the file name of the pattern must hold a '#' run (a
// '#' in its folder part is part of the folder's name), and it may hold only one.
std::vector<std::string> frame_outputs(const std::string& pattern, int frames, bool overwrite);

// One output option of a run and the files it names.
struct RunOutput {
  std::string option;              // "--out"
  std::vector<std::string> paths;
  std::string extension;           // ".exr", ".png" (compared case-insensitively); empty: any
};
// One input option of a run and the file it names.
struct RunInput {
  std::string option;  // "--radiance"
  std::string path;
};
// Whether `file` lies in `folder` or below it (or is it), through links.
bool inside(const std::string& file, const std::string& folder);

// Bad input (exit 2) before anything is written: a file named by two outputs of the run (the
// second write would replace the first: --out and --preview one file, or a --maps picture), an
// output that is one of the run's inputs (-y replaces an existing output, never the input being
// read), an output inside `device_store` (the folder of the fixed-pattern maps the run reads), or
// an output without its format's extension (an EXR written to x.png).
void check_run_outputs(const std::vector<RunOutput>& outputs, const std::vector<RunInput>& inputs = {},
                       const std::string& device_store = {});

}  // namespace photosite::cli
