// libFuzzer target: the preset parsers (camera, lens, scene) on arbitrary text. The first byte
// picks the parser, the rest is the TOML. A bad preset must end as photosite::Error (exit 2 in
// the CLI); anything else — another exception, a crash, a sanitizer report — is a finding.
#include <cstdint>
#include <string>

#include "photosite/error.h"
#include "photosite/scene/scene_preset.h"
#include "photosite/sensor/preset.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  const std::string text(reinterpret_cast<const char*>(data) + 1, size - 1);
  try {
    switch (data[0] % 3) {
      case 0: {
        const auto p = photosite::parse_camera_preset(text, "fuzz.toml");
        (void)photosite::to_json(p);
        break;
      }
      case 1: (void)photosite::to_json(photosite::parse_lens_preset(text, "fuzz.toml")); break;
      default: (void)photosite::scene::scene_attributes(photosite::scene::parse_scene_preset(text, "fuzz.toml"));
    }
  } catch (const photosite::Error&) {
  }
  return 0;
}
