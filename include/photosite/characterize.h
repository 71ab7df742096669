// `characterize`: an EMVA 1288 (R4.0) photon-transfer measurement of a simulated camera
// (sensor/emva.cpp sees the camera only through frames) beside the values its preset implies.
// The command line prints it as a table or JSON; the Python module returns the JSON as a dict.
#pragma once
#include <string>
#include <vector>

#include "photosite/backend.h"
#include "photosite/outputs.h"
#include "photosite/sensor/emva.h"
#include "photosite/sensor/fpn.h"

namespace photosite {

struct Characterization {
  std::string preset, device_id;
  // The conditions the camera was measured under (the same run at another gain or die
  // temperature gives other figures): the preset file's XXH3-64 (an edited copy keeps the name),
  // the analog gain, the die temperature used, the temporal-noise seed and the shot-noise sampler.
  std::string preset_xxh3_64;
  double gain_db = 0, temperature_c = 0;
  // The photon-transfer sweep's exposure time (setup.settings.exposure_s), in s.
  double exposure_s = 0;
  uint64_t seed = 0;
  std::string poisson;
  double wavelength_nm = 525;
  int pixels_measured = 0;
  char cfa_colour = 'G';  // the CFA colour of the measured sub-lattice
  int roi_w = 0, roi_h = 0;
  struct Row {
    std::string key;    // JSON key (the QE's names its wavelength: qe_525nm)
    const char* label;  // words for people
    const char* unit;
    emva::Value measured, preset;
  };
  std::vector<Row> rows;
  std::vector<emva::PtcPoint> photon_transfer;
  std::vector<double> dark_exposures_s;  // what the dark current was fitted over
  // Conditions under which some rows are biased (emva::Result::warnings); empty: none found.
  std::vector<std::string> warnings;
};

// roi: side of the measured region in pixels, [16, 4096] (ParameterError "roi" otherwise).
// setup.settings.exposure_s is the exposure time of the photon-transfer sweep, the dark pair and
// the DSNU/PRNU frames: the irradiation varies at that one time (a constant exposure time is one
// of EMVA 1288's ways to vary the radiant exposure), and the figures hold for that time (the dark
// charge's shot noise is part of the temporal dark noise, its spread part of DSNU1288). It must be
// in [0, 3600] s (ParameterError "exposure_s"). The dark current is fitted over its own exposures
// (emva::Plan::dark_exposures_s). The command line's and the Python module's default is
// emva::Plan's 1 ms: short, so that the dark charge adds little to the temporal dark noise and
// takes little of the well.
Characterization characterize(const SensorSetup& setup, const DeviceStore& store, SensorRunner& runner,
                              int roi, double wavelength_nm);

// z: deviation in combined standard errors (measurement and finite-device sampling).
double z_score(const Characterization::Row& row);

// The JSON text of `photosite characterize --json` (indent as nlohmann::json::dump's).
std::string to_json(const Characterization& c, int indent = -1);

}  // namespace photosite
