#include <toml++/toml.h>

#include <map>

#include "core/toml_schema_detail.h"
#include "photosite/error.h"
#include "photosite/scene/rig.h"
#include "photosite/scene/scene_preset.h"
#include "photosite/sensor/preset.h"

namespace photosite {

namespace {
std::string show_kind(const std::string& kind, const std::string& name, int indent) {
  if (kind == "lens") return to_json(load_lens_preset(name), indent);
  if (kind == "scene") return scene::to_json(scene::load_scene_preset(name), indent);
  if (kind == "rig") return scene::to_json(scene::load_camera_rig(name), indent);
  return to_json(load_camera_preset(name), indent);
}
}  // namespace

// A bundled name is looked up among every kind (list_presets; no two bundled presets share a
// name). A .toml path (or any argument with a '/') is told by its keys: a scene has a
// [reflectance] table, a rig a native_width_px, a lens a lens's keys and no pixel pitch, anything
// else is read as a camera (whose schema then names what is wrong with it).
std::string show_preset(const std::string& name, int indent) {
  if (name.find('/') != std::string::npos || name.ends_with(".toml")) {
    std::string kind = "camera";
    try {
      const toml::table t = toml::parse_file(name);
      if (t.contains("reflectance")) kind = "scene";
      else if (t.contains("native_width_px")) kind = "rig";
      else if (!t.contains("pixel_pitch_um") && (t.contains("f_number") || t.contains("focal_length_mm"))) kind = "lens";
    } catch (const toml::parse_error&) {
      // Not TOML (or not readable): the camera loader says so, naming the file.
    }
    return show_kind(kind, name, indent);
  }
  std::map<std::string, std::string> known;  // kind -> its names
  for (const auto& e : list_presets()) {
    if (e.name == name) return show_kind(e.kind, name, indent);
    if (!e.preset_file) continue;  // a folder, a link to nothing
    std::string& k = known[e.kind];
    k += (k.empty() ? "" : ", ") + e.name;
  }
  fail("unknown preset '" + name + "': not a bundled camera (" + known["camera"] + "), lens (" + known["lens"] +
       "), scene (" + known["scene"] + ") or camera rig (" + known["rig"] + ")");
}

}  // namespace photosite
