#include <toml++/toml.h>

#include "photosite/error.h"
#include "photosite/sensor/preset.h"

namespace photosite {

// A bundled name is looked up among the cameras and the lenses; a .toml path (or any argument
// with a '/') is a lens when its table has a lens's keys and no pixel pitch, else a camera (whose
// schema then names what is wrong with it).
std::string show_preset(const std::string& name, int indent) {
  if (name.find('/') != std::string::npos || name.ends_with(".toml")) {
    bool lens = false;
    try {
      const toml::table t = toml::parse_file(name);
      lens = !t.contains("pixel_pitch_um") && (t.contains("f_number") || t.contains("focal_length_mm"));
    } catch (const toml::parse_error&) {
      // Not TOML (or not readable): the camera loader says so, naming the file.
    }
    return lens ? to_json(load_lens_preset(name), indent) : to_json(load_camera_preset(name), indent);
  }
  std::string cameras, lenses;
  for (const auto& e : list_presets()) {
    if (e.name == name) return e.kind == "lens" ? to_json(load_lens_preset(name), indent) : to_json(load_camera_preset(name), indent);
    std::string& known = e.kind == "lens" ? lenses : cameras;
    known += (known.empty() ? "" : ", ") + e.name;
  }
  fail("unknown preset '" + name + "': not a bundled camera (" + cameras + ") or lens (" + lenses + ")");
}

}  // namespace photosite
