#include "sensor_options.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdlib>
#include <filesystem>
#include <map>

#include <fmt/format.h>

#include "photosite/error.h"

namespace photosite::cli {

namespace {
// --seed as written: a whole number from 0 to 2^64 − 1. CLI11 reads it with strtoull, which takes
// "-1" as 2^64 − 1 and gives 2^64 − 1 for anything larger, so two different seeds would make one noise.
const CLI::Validator kSeedText(
    [](std::string& s) -> std::string {
      errno = 0;
      if (!s.empty() && std::all_of(s.begin(), s.end(), [](unsigned char c) { return std::isdigit(c); })) {
        std::strtoull(s.c_str(), nullptr, 10);
        if (errno != ERANGE) return {};
      }
      return "'" + s + "' is not a whole number from 0 to 18446744073709551615";
    },
    "UINT64");
// An option given an empty value (an unset shell variable, --device-store "$STORE") is refused
// with `message`, where it would silently mean the default: the home folder's store, the default
// device <preset>-0 (whose maps it would write), the camera's default lens.
CLI::Validator non_empty(const char* message, const char* type) {
  return CLI::Validator([message](std::string& s) -> std::string { return s.empty() ? message : ""; }, type);
}
const CLI::Validator kNonEmptyFolder = non_empty("an empty folder name is not a device store", "DIR");
const CLI::Validator kNonEmptyDeviceId =
    non_empty("an empty device id; leave --device-id out for the default <preset>-0", "ID");
const CLI::Validator kNonEmptyLens =
    non_empty("an empty lens name; leave --lens out for the camera's default lens", "LENS");
}  // namespace

void SensorOptions::add(CLI::App* sub, bool preset_required, unsigned extras) {
  auto* p = sub->add_option("--preset", preset, "camera preset: a bundled name or a .toml path");
  if (preset_required) p->required();
  this->extras = extras;
  if (extras & kLens) sub->add_option("--lens", lens, "lens preset (default: the camera's default lens)")->check(kNonEmptyLens);
  if (extras & kExposure) sub->add_option("--exposure-s", exposure_s, "exposure time in seconds")->capture_default_str();
  if (extras & kFNumber) sub->add_option("--f-number", f_number, "f-number N (default: the lens preset's)");
  sub->add_option("--gain-db", gain_db, "analog gain in dB above the base system gain")->capture_default_str();
  sub->add_option("--temperature-c", temperature_c, "die temperature in C (default: the preset's)");
  sub->add_option("--seed", seed, "seed of the temporal noise")->capture_default_str()->check(kSeedText);
  if (extras & kFrames)
    sub->add_option("--frames", frames, "number of frames (output name needs a # run)")->capture_default_str();
  sub->add_option("--device-id", device_id, "device identity for the fixed-pattern maps (default <preset>-0)")->check(kNonEmptyDeviceId);
  sub->add_option("--device-store", device_store,
                  "folder of device fixed-pattern maps (default $PHOTOSITE_DEVICE_STORE, else "
                  "$XDG_DATA_HOME/photosite/devices, else ~/.local/share/photosite/devices)")
      ->check(kNonEmptyFolder);
  if (extras & kDemosaic)
    sub->add_option("--demosaic", demosaic, "demosaic method for the R,G,B output")->capture_default_str();
  sub->add_option("--poisson", poisson, "shot-noise sampler: exact, cornish-fisher or normal")->capture_default_str();
}

SensorOptions::Resolved SensorOptions::resolve() const {
  if (frames < 1 || frames > 100000) fail(fmt::format("--frames {} must be in [1, 100000]", frames));
  CameraPreset cam = load_camera_preset(preset);
  std::string lens_name = lens.empty() ? cam.default_lens : lens;
  if (lens_name.empty() && (extras & kLens)) fail("camera preset " + cam.file + " names no default_lens; pass --lens");
  LensPreset l = lens_name.empty() ? LensPreset{} : load_lens_preset(lens_name);  // no lens acts without --lens
  ExposureSettings s;
  s.exposure_s = exposure_s;
  s.f_number = f_number;
  s.gain_db = gain_db;
  s.temperature_c = temperature_c;
  s.seed = seed;
  s.demosaic = parse_demosaic_method(demosaic);
  s.poisson = parse_poisson_method(poisson);
  std::string id = device_id.empty() ? cam.name + "-0" : device_id;
  photosite::resolve(cam, l, s);  // validate the settings before any work
  return Resolved{{std::move(cam), std::move(l), s, id}, DeviceStore(device_store)};
}

std::vector<std::string> frame_outputs(const std::string& pattern, int frames, bool overwrite) {
  // The frame number goes into the run of '#' of the file's name; a '#' in a folder's name is part
  // of that name (take#2/), never a frame number: frames of one run are written into one folder
  // (which must exist, as photosite creates no output folder), and a folder named with a '#' is
  // not rewritten into another (take#2/ into take02/). A second run in the name would be left in
  // it as a '#': bad input, so the number has one place.
  const std::filesystem::path p(pattern);
  const std::string name = p.filename().string();
  const auto first = name.find('#');
  if (frames > 1 && first == std::string::npos)
    fail_at(pattern, pattern.find('#') == std::string::npos
                         ? "--frames > 1 needs a run of '#' in the output name for the frame number"
                         : "--frames > 1 needs a run of '#' in the output file's name for the frame number (a "
                           "'#' in a folder's name is part of the name: the frames go into one folder)");
  if (first != std::string::npos && name.find('#', name.find_first_not_of('#', first)) != std::string::npos)
    fail_at(pattern, "the output file's name holds two runs of '#'; the frame number takes one run (the "
                     "other would be left in the name as '#')");
  std::vector<std::string> out;
  for (int f = 0; f < frames; ++f) {
    out.push_back((p.parent_path() / frame_path(name, f)).string());
    check_output_path(out.back(), overwrite);
  }
  return out;
}

namespace {
// One file under two names: the same file when both exist (links, "./x" and "x"), else the same
// absolute, lexically normal path.
bool same_file(const std::string& a, const std::string& b) {
  namespace fs = std::filesystem;
  std::error_code ea, eb, ec;
  if (fs::exists(a, ea) && fs::exists(b, eb)) {
    const bool same = fs::equivalent(a, b, ec);
    if (!ec) return same;
  }
  return fs::absolute(a, ea).lexically_normal() == fs::absolute(b, eb).lexically_normal();
}
}  // namespace

// Whether `file` lies in `folder` or below it, through links (both made canonical as far as they
// exist).
bool inside(const std::string& file, const std::string& folder) {
  namespace fs = std::filesystem;
  std::error_code ec;
  fs::path f = fs::weakly_canonical(fs::absolute(file, ec), ec);
  if (ec) f = fs::absolute(file).lexically_normal();
  fs::path d = fs::weakly_canonical(fs::absolute(folder, ec), ec);
  if (ec) d = fs::absolute(folder).lexically_normal();
  const fs::path rel = f.lexically_relative(d);
  return !rel.empty() && *rel.begin() != "..";
}

void check_run_outputs(const std::vector<RunOutput>& outputs, const std::vector<RunInput>& inputs,
                       const std::string& device_store) {
  namespace fs = std::filesystem;
  for (const auto& o : outputs)
    for (const auto& p : o.paths)
      for (const auto& in : inputs)
        if (!in.path.empty() && same_file(p, in.path))
          fail_at(p, o.option + " is the run's " + in.option + " input" + (p == in.path ? "" : " " + in.path) +
                         ": refused, the output would replace the file being read (even with -y)");
  // The device store holds the devices' fixed-pattern maps, which every run of a device reads:
  // an output there could replace one (`--out` at the map's own path with -y did), and the
  // frames made with it would no longer match their recorded checksum.
  if (!device_store.empty())
    for (const auto& o : outputs)
      for (const auto& p : o.paths)
        if (inside(p, device_store))
          fail_at(p, o.option + " is inside the device store " + device_store +
                         ", the folder of the devices' fixed-pattern maps: photosite writes no output there (even with -y)");
  std::map<std::string, std::pair<std::string, std::string>> seen;  // the file, absolute and normal: option, path
  for (const auto& o : outputs)
    for (const auto& p : o.paths) {
      std::error_code ec;
      fs::path key = fs::weakly_canonical(fs::absolute(p, ec), ec);
      if (ec) key = fs::absolute(p).lexically_normal();
      const auto [it, fresh] = seen.emplace(key.string(), std::make_pair(o.option, p));
      if (!fresh)
        fail_at(p, o.option + ": the same file is also the run's " + it->second.first + " output" +
                       (it->second.second == p ? "" : " " + it->second.second) + " (one file per output)");
    }
  for (const auto& o : outputs)
    for (const auto& p : o.paths) {
      if (!o.extension.empty() && lower_extension(p) != o.extension)
        fail_at(p, o.option + ": the file is written as " + o.extension.substr(1) + ", so its name must end in " + o.extension);
    }
}

void PreviewFlags::add(CLI::App* sub) {
  isp_option = sub->add_option("--preview-isp", isp, "preview ISP: simple (white balance, p99 exposure, sRGB) or camera (+ noise reduction from the sensor's noise model, JPEG; docs/realism.md); needs --preview")->capture_default_str();
  wb_option = sub->add_option("--preview-wb", wb, "preview white balance: fixed (the camera preset's gains) or auto (gray-world AWB of the frame, bounded to the camera's 2000-10000 K black-body gains; docs/realism.md); needs --preview")->capture_default_str();
  ccm_option = sub->add_option("--preview-ccm", ccm, "preview colour matrix: none (camera RGB shown as sRGB) or camera (the camera's colour correction matrix, derived from its spectral response; docs/sensor.md section 9); needs --preview")->capture_default_str();
  denoise_option = sub->add_option("--preview-denoise", camera.denoise, "camera ISP: luma noise-reduction strength, 0-10 (0: off; chroma gets twice it); needs --preview-isp camera")->capture_default_str();
  jpeg_option = sub->add_option("--preview-jpeg-quality", camera.jpeg_quality, "camera ISP: JPEG round trip quality 1-100 (0: none); needs --preview-isp camera")->capture_default_str();
}

PreviewOptions PreviewFlags::resolve(const std::string& preview) const {
  PreviewOptions o;
  o.isp = parse_preview_isp(isp);
  o.wb = parse_preview_wb(wb);
  o.ccm = parse_preview_ccm(ccm);
  o.camera = camera;
  o.camera.chroma_denoise = 2 * camera.denoise;  // isp.h's default ratio
  check_camera_isp_options(o.camera);
  const auto given = [](const CLI::Option* opt) { return opt && opt->count() > 0; };
  for (const CLI::Option* opt : {isp_option, wb_option, ccm_option, denoise_option, jpeg_option})
    if (given(opt) && preview.empty())
      fail(opt->get_name() + " " + opt->as<std::string>() + ": no preview is written (add --preview FILE.png), so it would do nothing");
  if (o.isp != PreviewIsp::Camera)
    for (const CLI::Option* opt : {denoise_option, jpeg_option})
      if (given(opt))
        fail(opt->get_name() + " " + opt->as<std::string>() + ": acts only with --preview-isp camera (the " + isp +
             " ISP has no noise reduction or JPEG step), so it would do nothing");
  return o;
}

}  // namespace photosite::cli
