#include "photosite/sensor/preset.h"

namespace photosite {

nlohmann::json show_preset(const std::string& name) {
  for (const auto& e : list_presets())
    if (e.name == name && e.kind == "lens") return to_json(load_lens_preset(name));
  return to_json(load_camera_preset(name));
}

}  // namespace photosite
