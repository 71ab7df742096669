// Camera rig presets (see rig.h).
#include "photosite/scene/rig.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <toml++/toml.h>

#include "photosite/error.h"
#include "photosite/sensor/preset.h"

namespace photosite::scene {
namespace {
struct Field { double* v; double lo, hi; };
std::vector<std::pair<std::string, Field>> fields(CameraRig& r) {
  return {{"native_width_px", {&r.native_width_px, 16, 65536}},
          {"native_height_px", {&r.native_height_px, 16, 65536}},
          {"fx_px", {&r.fx_px, 1, 1e6}},
          {"cx_px", {&r.cx_px, -1e5, 1e5}},
          {"cy_px", {&r.cy_px, -1e5, 1e5}},
          {"mount_height_m", {&r.mount_height_m, 0.1, 50}},
          {"pitch_deg", {&r.pitch_deg, -30, 30}}};
}
std::filesystem::path rig_dir() { return std::filesystem::path(preset_dir()) / "rigs"; }
}  // namespace

CameraRig parse_camera_rig(const std::string& text, const std::string& file) {
  toml::table t;
  try {
    t = toml::parse(text, file);
  } catch (const toml::parse_error& e) {
    fail(where(file, static_cast<int>(e.source().begin.line)) + ": malformed TOML: " +
         std::string(e.description()));
  }
  CameraRig r;
  r.file = file;
  r.name = std::filesystem::path(file).stem().string();
  auto fs = fields(r);
  std::map<std::string, bool> seen;
  for (const auto& [k, node] : t) {
    const std::string key(k.str());
    const int line = static_cast<int>(node.source().begin.line);
    if (key == "description") {
      if (!node.is_string()) fail(where(file, line, key) + ": must be a string");
      r.description = node.value_or(std::string());
      continue;
    }
    auto it = std::find_if(fs.begin(), fs.end(), [&](auto& f) { return f.first == key; });
    if (it == fs.end()) fail(where(file, line, key) + ": unknown key");
    auto num = node.value<double>();
    if (!num) fail(where(file, line, key) + ": must be a number");
    if (!(*num >= it->second.lo && *num <= it->second.hi))
      fail(where(file, line, key) + ": value " + std::to_string(*num) + " is outside [" +
           std::to_string(it->second.lo) + ", " + std::to_string(it->second.hi) + "]");
    *it->second.v = *num;
    seen[key] = true;
  }
  for (auto& f : fs)
    if (!seen.count(f.first)) fail(where(file, 0, f.first) + ": missing key");
  return r;
}

CameraRig load_camera_rig(const std::string& name_or_path) {
  namespace fs = std::filesystem;
  std::string path = name_or_path;
  if (name_or_path.find('/') == std::string::npos && !name_or_path.ends_with(".toml")) {
    path = (rig_dir() / (name_or_path + ".toml")).string();
    if (!fs::exists(path)) {
      std::string known;
      for (const auto& n : bundled_rigs()) known += (known.empty() ? "" : ", ") + n;
      fail("--rig: unknown camera rig '" + name_or_path + "' (bundled: " + known + ", or auto, or a .toml path)");
    }
  }
  std::ifstream in(path);
  if (!in) fail_at(path, "cannot read camera rig");
  std::stringstream ss;
  ss << in.rdbuf();
  return parse_camera_rig(ss.str(), path);
}

std::vector<std::string> bundled_rigs() {
  std::vector<std::string> names;
  std::error_code ec;
  for (const auto& e : std::filesystem::directory_iterator(rig_dir(), ec))
    if (e.path().extension() == ".toml") names.push_back(e.path().stem().string());
  std::sort(names.begin(), names.end());
  return names;
}

CameraRig rig_for_image(int width, int height) {
  const auto names = bundled_rigs();
  if (names.empty()) fail_at(rig_dir().string(), "no camera rig presets (*.toml) found");
  const double a = static_cast<double>(width) / height;
  CameraRig best;
  double best_d = 1e300;
  for (const auto& n : names) {
    CameraRig r = load_camera_rig(n);
    const double d = std::fabs(std::log(a * r.native_height_px / r.native_width_px));
    if (d < best_d) { best_d = d; best = r; }
  }
  return best;
}

CameraRig resolve_camera_rig(const std::string& flag, int width, int height) {
  if (flag.empty() || flag == "auto") return rig_for_image(width, height);
  return load_camera_rig(flag);
}

CameraIntrinsics scaled_intrinsics(const CameraRig& r, int width, int height) {
  const double aspect = static_cast<double>(width) / height;
  const double native = r.native_width_px / r.native_height_px;
  if (std::fabs(aspect / native - 1) <= 0.01) {
    const double s = width / r.native_width_px;
    // Pixel centres: a resize maps x+0.5 to (x+0.5)·s.
    return {r.fx_px * s, (r.cx_px + 0.5) * s - 0.5, (r.cy_px + 0.5) * s - 0.5};
  }
  return {r.fx_px, r.cx_px - 0.5 * (r.native_width_px - width), r.cy_px - 0.5 * (r.native_height_px - height)};
}

}  // namespace photosite::scene
