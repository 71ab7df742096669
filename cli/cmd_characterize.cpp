// `photosite characterize`: measures a simulated camera with the EMVA 1288 (R4.0) photon-transfer
// method (sensor/emva.cpp, which sees the camera only through frames) and prints the results
// beside the values the preset implies.
#include <cmath>
#include <cstdio>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "backend.h"
#include "photosite/error.h"
#include "photosite/characterize.h"
#include "registry.h"
#include "sensor_options.h"

namespace photosite::cli {
namespace {
struct CharacterizeCmd {
  SensorOptions sensor;
  bool json = false;
  int roi = 256;
  double wavelength_nm = 525;
  std::string backend = "auto";
};

void run(const CharacterizeCmd& c) {
  auto r = c.sensor.resolve();
  SensorRunner runner = make_backend(c.backend, &r.camera);
  const Characterization ch = characterize(r, r.store, runner, c.roi, c.wavelength_nm);
  if (c.json) {
    std::printf("%s\n", to_json(ch, 2).c_str());
    return;
  }
  std::printf("EMVA 1288 R4.0 photon transfer: %s (device %s), %dx%d region, %d %c pixels, %.0f nm\n",
              ch.preset.c_str(), ch.device_id.c_str(), ch.roi_w, ch.roi_h, ch.pixels_measured, ch.cfa_colour,
              c.wavelength_nm);
  std::printf("conditions: exposure %g s, gain %g dB, die temperature %g C, seed %llu, --poisson %s, preset file XXH3-64 %s\n",
              ch.exposure_s, ch.gain_db, ch.temperature_c, static_cast<unsigned long long>(ch.seed), ch.poisson.c_str(),
              ch.preset_xxh3_64.c_str());
  std::printf("%-22s %12s %10s %12s %10s %10s %6s\n", "quantity", "measured", "+/- 1 se", "preset", "+/- device",
              "deviation", "z");
  for (const auto& row : ch.rows) {
    const double dev = row.preset.value != 0 ? (row.measured.value - row.preset.value) / row.preset.value * 100 : 0;
    std::printf("%-22s %12.5g %10.3g %12.5g %10.3g %9.2f%% %6.2f  %s\n", row.label, row.measured.value,
                row.measured.uncertainty, row.preset.value, row.preset.uncertainty, dev, z_score(row), row.unit);
  }
  std::printf("z: deviation in combined standard errors (measurement and finite-device sampling)\n");
  for (const auto& w : ch.warnings) std::printf("warning: %s\n", w.c_str());
}
}  // namespace

static Registrar reg("e-characterize", [](CLI::App& app) {
  auto cmd = std::make_shared<CharacterizeCmd>();
  auto* sub = app.add_subcommand("characterize", "measure a simulated camera with the EMVA 1288 method");
  // The photon-transfer sweep's exposure time (the irradiation varies at that one time), by default emva::Plan's 1 ms; the frames and the dark-current exposures
  // are the plan's, and the photons are given per pixel (no lens, aperture or demosaic acts).
  cmd->sensor.exposure_s = emva::Plan{}.exposure_s;
  cmd->sensor.add(sub, true, SensorOptions::kExposure);
  sub->add_flag("--json", cmd->json, "print JSON (measured, uncertainty and preset value per quantity)");
  sub->add_option("--roi", cmd->roi, "side of the measured region in pixels")->capture_default_str();
  sub->add_option("--wavelength-nm", cmd->wavelength_nm, "wavelength of the light")->capture_default_str();
  add_backend_option(sub, cmd->backend);
  sub->callback([cmd] { run(*cmd); });
});
}  // namespace photosite::cli
