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
Characterization characterize(const SensorSetup& setup, const DeviceStore& store, SensorRunner& runner,
                              int roi, double wavelength_nm);

// z: deviation in combined standard errors (measurement and finite-device sampling).
double z_score(const Characterization::Row& row);

// The JSON text of `photosite characterize --json` (indent as nlohmann::json::dump's).
std::string to_json(const Characterization& c, int indent = -1);

}  // namespace photosite
