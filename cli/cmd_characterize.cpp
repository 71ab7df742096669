// `photosite characterize`: measures a simulated camera with the EMVA 1288 (R4.0) photon-transfer
// method (sensor/emva.cpp, which sees the camera only through frames) and prints the results
// beside the values the preset implies.
#include <cmath>
#include <cstdio>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "backend.h"
#include "photosite/error.h"
#include "photosite/sensor/emva_sim.h"
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
  if (c.roi < 16 || c.roi > 4096) fail(fmt::format("--roi {} must be in [16, 4096]", c.roi));
  const int w = std::min(c.roi, r.camera.width_px), h = std::min(c.roi, r.camera.height_px);
  const FixedPatternMaps fpn = r.store.load_or_create(r.camera, r.device_id, w, h);
  SensorRunner runner(resolve_backend(c.backend));
  emva::SimulatedCamera cam(r.camera, r.lens, r.settings, fpn, c.wavelength_nm,
                            [&runner](const ImageF& m, const CameraPreset& p, const ResolvedExposure& ex,
                                      const ExposureSettings& s, const FixedPatternMaps& f) {
                              return runner.sense(m, p, ex, s, f);
                            });
  const emva::Plan plan = emva::plan_for(r.camera, c.wavelength_nm);
  const emva::Result m = emva::measure(cam, plan);
  const emva::Result e = emva::expected(r.camera, r.settings, plan, m.pixels_measured, c.wavelength_nm);
  struct Row { const char* key; const char* label; const char* unit; emva::Value meas; emva::Value exp; };
  const Row rows[] = {
      {"system_gain_dn_per_e", "system gain K", "DN/e-", m.system_gain_dn_per_e, e.system_gain_dn_per_e},
      {"read_noise_e", "temporal dark noise", "e-", m.temporal_dark_noise_e, e.temporal_dark_noise_e},
      {"qe_525nm", "quantum efficiency", "", m.qe, e.qe},
      {"saturation_capacity_e", "saturation capacity", "e-", m.saturation_capacity_e, e.saturation_capacity_e},
      {"dark_current_e_per_s", "dark current", "e-/s", m.dark_current_e_per_s, e.dark_current_e_per_s},
      {"dsnu_e", "DSNU1288", "e-", m.dsnu_e, e.dsnu_e},
      {"prnu_percent", "PRNU1288", "%", m.prnu_percent, e.prnu_percent},
      {"snr_max_db", "SNR max", "dB", m.snr_max_db, e.snr_max_db},
      {"dynamic_range_db", "dynamic range", "dB", m.dynamic_range_db, e.dynamic_range_db},
  };
  const char colour = to_string(cfa_color(r.camera.cfa, plan.x0, plan.y0))[0];
  if (c.json) {
    nlohmann::json j;
    j["preset"] = r.camera.name;
    j["device_id"] = r.device_id;
    j["wavelength_nm"] = c.wavelength_nm;
    j["pixels_measured"] = m.pixels_measured;
    j["cfa_colour"] = std::string(1, colour);
    j["roi"] = {w, h};
    for (const auto& row : rows)
      j[row.key] = {{"measured", row.meas.value}, {"uncertainty", row.meas.uncertainty}, {"preset", row.exp.value},
                    {"preset_device_uncertainty", row.exp.uncertainty},
                    {"z", (row.meas.value - row.exp.value) / std::max(1e-300, std::hypot(row.meas.uncertainty, row.exp.uncertainty))}};
    nlohmann::json ptc = nlohmann::json::array();
    for (const auto& p : m.ptc) ptc.push_back({p.photons, p.mean_dn, p.var_dn2});
    j["photon_transfer"] = ptc;
    std::printf("%s\n", j.dump(2).c_str());
    return;
  }
  std::printf("EMVA 1288 R4.0 photon transfer: %s (device %s), %dx%d region, %d %c pixels, %.0f nm\n",
              r.camera.name.c_str(), r.device_id.c_str(), w, h, m.pixels_measured, colour, c.wavelength_nm);
  std::printf("%-22s %12s %10s %12s %10s %10s %6s\n", "quantity", "measured", "+/- 1 se", "preset", "+/- device",
              "deviation", "z");
  for (const auto& row : rows) {
    const double dev = row.exp.value != 0 ? (row.meas.value - row.exp.value) / row.exp.value * 100 : 0;
    const double z = (row.meas.value - row.exp.value) / std::max(1e-300, std::hypot(row.meas.uncertainty, row.exp.uncertainty));
    std::printf("%-22s %12.5g %10.3g %12.5g %10.3g %9.2f%% %6.2f  %s\n", row.label, row.meas.value, row.meas.uncertainty,
                row.exp.value, row.exp.uncertainty, dev, z, row.unit);
  }
  std::printf("z: deviation in combined standard errors (measurement and finite-device sampling)\n");
}
}  // namespace

static Registrar reg("e-characterize", [](CLI::App& app) {
  auto cmd = std::make_shared<CharacterizeCmd>();
  auto* sub = app.add_subcommand("characterize", "measure a simulated camera with the EMVA 1288 method");
  cmd->sensor.add(sub);
  sub->add_flag("--json", cmd->json, "print JSON (measured, uncertainty and preset value per quantity)");
  sub->add_option("--roi", cmd->roi, "side of the measured region in pixels")->capture_default_str();
  sub->add_option("--wavelength-nm", cmd->wavelength_nm, "wavelength of the light")->capture_default_str();
  add_backend_option(sub, cmd->backend);
  sub->callback([cmd] { run(*cmd); });
});
}  // namespace photosite::cli
