// `photosite flat`: flat fields (or dark frames) of a given mean photon count per pixel at one
// wavelength, for characterization.
#include <cstdio>

#include <fmt/format.h>

#include "photosite/error.h"
#include "backend.h"
#include "photosite/io.h"
#include "registry.h"
#include "sensor_options.h"

namespace photosite::cli {
namespace {
struct FlatCmd {
  double photons = 0, wavelength_nm = 525;
  int width = 0, height = 0;
  std::string out;
  bool overwrite = false;
  SensorOptions sensor;
  std::string backend = "auto";
};

void run(const FlatCmd& c) {
  auto r = c.sensor.resolve();
  check_frame_size("--width/--height", c.width, c.height);
  SensorRunner runner(resolve_backend(c.backend, &r.camera));
  const auto outputs = frame_outputs(c.out, c.sensor.frames, c.overwrite);
  check_run_outputs({{"--out", outputs, ".exr"}}, {}, r.store.dir());
  const ResolvedExposure ex = resolve(r.camera, r.lens, r.settings);
  // The flat field's inputs are checked before the device store is touched (no map for a run
  // that cannot go on).
  const ImageF mean = detail::flat_field_mean(c.photons, c.wavelength_nm, c.width, c.height, r.camera);
  const FixedPatternMaps fpn = r.store.load_or_create(r.camera, r.device_id, c.width, c.height);
  for (int f = 0; f < c.sensor.frames; ++f) {
    r.settings.frame = static_cast<uint32_t>(f);
    SensorOutput out = runner.sense(mean, r.camera, ex, r.settings, fpn);
    auto attrs = sensor_attributes(r, ex, fpn);
    attrs.erase("photosite/lens");  // photons per pixel: no lens or aperture acted on them
    attrs.erase("photosite/f_number");
    attrs.erase("photosite/lens_xxh3_64");
    attrs["photosite/photons_per_pixel"] = c.photons;
    attrs["photosite/wavelength_nm"] = c.wavelength_nm;
    write_exr(outputs[f], sensor_channels(out), attrs);
    std::printf("%s\n", outputs[f].c_str());
  }
}
}  // namespace

static Registrar reg("c-flat", [](CLI::App& app) {
  auto cmd = std::make_shared<FlatCmd>();
  auto* sub = app.add_subcommand("flat", "flat-field or dark frames for characterization");
  sub->add_option("--photons", cmd->photons, "mean photons per pixel (0: dark frame)")->required();
  sub->add_option("--wavelength-nm", cmd->wavelength_nm, "wavelength of the light in nm")->required();
  sub->add_option("--width", cmd->width, "frame width in pixels")->required();
  sub->add_option("--height", cmd->height, "frame height in pixels")->required();
  sub->add_option("--out", cmd->out, "output EXR (with --frames, a # run takes the frame number)")->required();
  // --photons is per pixel: no lens or aperture acts on it, so --lens and --f-number are not taken.
  cmd->sensor.add(sub, true, SensorOptions::kAllExtras & ~(SensorOptions::kLens | SensorOptions::kFNumber));
  add_backend_option(sub, cmd->backend);
  add_overwrite_flag(sub, cmd->overwrite);
  sub->callback([cmd] { run(*cmd); });
});

}  // namespace photosite::cli
