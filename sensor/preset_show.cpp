#include "photosite/sensor/preset.h"

namespace photosite {

std::string show_preset(const std::string& name, int indent) {
  for (const auto& e : list_presets())
    if (e.name == name && e.kind == "lens") return to_json(load_lens_preset(name), indent);
  return to_json(load_camera_preset(name), indent);
}

}  // namespace photosite
