// Fixed-pattern noise: maps that belong to one physical device (a preset + a device id), made once
// and reused by every later run and frame. PRNU is a per-pixel gain, DSNU an offset in electrons
// plus a per-pixel dark-current rate factor (hot pixels included), all drawn from the
// counter-based generator keyed by the device seed, so the same device id gives the same maps
// on any machine. The DeviceStore keeps them as EXR files, verified on every load.
#pragma once
#include <cstdint>
#include <memory>
#include <string>

#include "photosite/checksum.h"
#include "photosite/image.h"
#include "photosite/sensor/preset.h"

namespace photosite {

struct FixedPatternMaps {
  std::string device_id;
  std::string preset_name;
  uint64_t device_seed = 0;
  int width = 0, height = 0;
  ImageF prnu_gain;         // 1 + δ (dimensionless); empty when the preset has no PRNU
  ImageF dsnu_offset_e;     // e-; empty when the preset has no offset DSNU
  ImageF dark_rate_factor;  // multiplies the mean dark rate; empty when uniform and no hot pixels
  // FNV-1a 64 of the map contents (hex): the map's identity, recorded in every output's header
  // (photosite/fpn_checksum) since the first device store.
  std::string checksum;
  // XXH3-64 of the same bytes (hex), what a load verifies (the faster of the two, see
  // photosite/checksum.h); empty for a map loaded from a file written before it was recorded, which is
  // verified by its FNV-1a instead.
  std::string checksum_xxh3;
};

FixedPatternMaps generate_fixed_pattern(const CameraPreset& preset, int width, int height,
                                        const std::string& device_id);
std::string fixed_pattern_checksum(const FixedPatternMaps& maps, ChecksumAlgorithm algorithm);

class DeviceStore {
 public:
  // dir empty: $PHOTOSITE_DEVICE_STORE, else $XDG_DATA_HOME/photosite/devices, else
  // ~/.local/share/photosite/devices. A relative folder (given or from the variable) is made
  // absolute here, once, against the working folder of the moment: dir() is that absolute path,
  // and a later change of the working folder does not move the store.
  explicit DeviceStore(std::string dir = {});
  static std::string default_dir();
  const std::string& dir() const { return dir_; }
  std::string path_for(const CameraPreset& preset, const std::string& device_id, int width,
                       int height) const;
  // Loads the device's maps, or generates and stores them (atomically, under a lock) when
  // absent. A map whose preset, size, parameters or checksum do not match is an error, never
  // silently regenerated or overwritten.
  FixedPatternMaps load_or_create(const CameraPreset& preset, const std::string& device_id,
                                  int width, int height) const;
  FixedPatternMaps load(const std::string& path, const CameraPreset& preset,
                        const std::string& device_id, int width, int height) const;
  // Keep every map this store (or a copy of it) loads or makes in memory, and answer a later
  // load_or_create of the same map from there while its file is unchanged (same device, inode,
  // size and modification time; the preset's FPN parameters as when it was read), up to 4 maps,
  // the least recently used going first: the copy costs a memcpy instead of reading and
  // verifying the file again. For callers that run frame after frame in one process (the Python
  // Camera); off by default, as the CLI loads a map once per process and its peak memory should
  // not carry a second copy.
  void keep_loaded(bool on);

 private:
  struct Kept;
  FixedPatternMaps load_or_keep(const std::string& path, const CameraPreset& preset, const std::string& device_id,
                                int width, int height) const;
  void keep(const std::string& path, const CameraPreset& preset, const FixedPatternMaps& m) const;
  std::string dir_;
  std::shared_ptr<Kept> kept_;  // null: nothing kept
};

}  // namespace photosite
