#include "photosite/characterize.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "photosite/error.h"
#include "photosite/sensor/emva_sim.h"

namespace photosite {
namespace {
// The QE row's key names the wavelength it was measured at ("qe_525nm", "qe_532.5nm").
std::string qe_key(double wavelength_nm) { return fmt::format("qe_{:g}nm", wavelength_nm); }
}  // namespace

Characterization characterize(const SensorSetup& setup, const DeviceStore& store, SensorRunner& runner,
                              int roi, double wavelength_nm) {
  if (roi < 16 || roi > 4096) fail_parameter("roi", "", fmt::format(" {} must be in [16, 4096]", roi));
  detail::check_flat_field_wavelength(wavelength_nm, setup.camera);  // before the device store is touched
  const ResolvedExposure ex = resolve(setup.camera, setup.lens, setup.settings);  // the exposure, gain, temperature
  // The dark charge of the sweep's exposure shares the well with the photo-electrons: the
  // signal clips at the full well or the ADC's top code, whichever comes first (in e⁻;
  // emva::expected's clip), and a dark charge at or above that leaves no photo-signal to measure.
  // Refused naming the exposure, before the device store is touched (the sweep would end in
  // "too few points in the linear range"). The mean per-pixel rate is at least the preset's
  // (the hot pixels' factors only add), so D·t is a lower bound on the mean dark charge.
  const double clip_e = std::min(setup.camera.full_well_e,
                                 (std::ldexp(1.0, setup.camera.bit_depth) - 1 - setup.camera.black_level_dn) /
                                     ex.system_gain_dn_per_e);
  const double dark_e = ex.dark_current_e_per_s * ex.exposure_s;
  if (dark_e >= clip_e)
    fail_parameter("exposure_s", "",
                   fmt::format(" {} s: the dark charge alone, {:.4g} e- ({:.4g} e-/s at {:g} C), fills the well ({:.4g} e- to "
                               "the clip), so no photo-signal is left to measure; give a shorter exposure",
                               ex.exposure_s, dark_e, ex.dark_current_e_per_s, ex.temperature_c, clip_e));
  const int w = std::min(roi, setup.camera.width_px), h = std::min(roi, setup.camera.height_px);
  const FixedPatternMaps fpn = store.load_or_create(setup.camera, setup.device_id, w, h);
  emva::SimulatedCamera cam(setup.camera, setup.lens, setup.settings, fpn, wavelength_nm,
                            [&runner](const ImageF& m, const CameraPreset& p, const ResolvedExposure& ex,
                                      const ExposureSettings& s, const FixedPatternMaps& f) {
                              return runner.sense(m, p, ex, s, f);
                            });
  emva::Plan plan = emva::plan_for(setup.camera, wavelength_nm);
  plan.exposure_s = ex.exposure_s;  // the sweep at the caller's exposure time (characterize.h)
  // Where the dark charge takes much of the well the sweep may still find too few linear points:
  // the message then says how much the exposure's dark charge took.
  const emva::Result m = [&] {
    try {
      return emva::measure(cam, plan);
    } catch (const ParameterError&) {
      throw;
    } catch (const Error& err) {
      if (err.kind() != Error::Kind::BadInput || !(dark_e > 0)) throw;
      fail_parameter("exposure_s", std::string(err.what()) + " (the dark charge at ",
                     fmt::format(" {} s, {:.4g} e-, takes {:.0f}% of the well's {:.4g} e-: a shorter exposure leaves "
                                 "the photo-signal more room)",
                                 ex.exposure_s, dark_e, 100 * dark_e / clip_e, clip_e));
    }
  }();
  const emva::Result e = emva::expected(setup.camera, setup.settings, plan, m.pixels_measured, wavelength_nm);
  Characterization c;
  c.preset = setup.camera.name;
  c.device_id = setup.device_id;
  c.preset_xxh3_64 = setup.camera.text_xxh3_64;
  c.gain_db = ex.gain_db;
  c.exposure_s = ex.exposure_s;
  c.temperature_c = ex.temperature_c;
  c.seed = setup.settings.seed;
  c.poisson = to_string(setup.settings.poisson);
  c.wavelength_nm = wavelength_nm;
  c.pixels_measured = m.pixels_measured;
  c.cfa_colour = to_string(cfa_color(setup.camera.cfa, plan.x0, plan.y0))[0];
  c.roi_w = w;
  c.roi_h = h;
  c.rows = {
      {"system_gain_dn_per_e", "system gain K", "DN/e-", m.system_gain_dn_per_e, e.system_gain_dn_per_e},
      {"read_noise_e", "temporal dark noise", "e-", m.temporal_dark_noise_e, e.temporal_dark_noise_e},
      {qe_key(wavelength_nm), "quantum efficiency", "", m.qe, e.qe},
      {"saturation_capacity_e", "saturation capacity", "e-", m.saturation_capacity_e, e.saturation_capacity_e},
      {"dark_current_e_per_s", "dark current", "e-/s", m.dark_current_e_per_s, e.dark_current_e_per_s},
      {"dsnu_e", "DSNU1288", "e-", m.dsnu_e, e.dsnu_e},
      {"prnu_percent", "PRNU1288", "%", m.prnu_percent, e.prnu_percent},
      {"snr_max_db", "SNR max", "dB", m.snr_max_db, e.snr_max_db},
      {"dynamic_range_db", "dynamic range", "dB", m.dynamic_range_db, e.dynamic_range_db},
  };
  c.photon_transfer = m.ptc;
  c.dark_exposures_s = m.dark_exposures_s;
  c.warnings = m.warnings;
  return c;
}

double z_score(const Characterization::Row& row) {
  return (row.measured.value - row.preset.value) /
         std::max(1e-300, std::hypot(row.measured.uncertainty, row.preset.uncertainty));
}

std::string to_json(const Characterization& c, int indent) {
  nlohmann::json j;
  j["preset"] = c.preset;
  j["device_id"] = c.device_id;
  j["wavelength_nm"] = c.wavelength_nm;
  j["pixels_measured"] = c.pixels_measured;
  j["cfa_colour"] = std::string(1, c.cfa_colour);
  j["roi"] = {c.roi_w, c.roi_h};
  // The seed as text, as in the EXR header (a 64-bit value; JSON readers keep doubles).
  j["conditions"] = {{"preset_xxh3_64", c.preset_xxh3_64}, {"exposure_s", c.exposure_s}, {"gain_db", c.gain_db},
                     {"temperature_c", c.temperature_c}, {"seed", std::to_string(c.seed)},
                     {"poisson", c.poisson}};
  for (const auto& row : c.rows)
    j[row.key] = {{"measured", row.measured.value}, {"uncertainty", row.measured.uncertainty},
                  {"preset", row.preset.value}, {"preset_device_uncertainty", row.preset.uncertainty},
                  {"z", z_score(row)}};
  nlohmann::json ptc = nlohmann::json::array();
  for (const auto& p : c.photon_transfer) ptc.push_back({p.photons, p.mean_dn, p.var_dn2});
  j["photon_transfer"] = ptc;
  j["dark_exposures_s"] = c.dark_exposures_s;
  j["warnings"] = c.warnings;
  return j.dump(indent);
}

}  // namespace photosite
