// `photosite expose`: scene radiance (linear, W·sr⁻¹·m⁻²) in, the camera's output out.
#include <cmath>
#include <cstdio>
#include <map>
#include <string>
#include <utility>

#include <fmt/format.h>

#include "photosite/error.h"
#include "photosite/io.h"
#include "photosite/output_set.h"
#include "photosite/sensor/isp.h"
#include "backend.h"
#include "registry.h"
#include "sensor_options.h"

namespace photosite::cli {
namespace {
struct ExposeCmd {
  std::string radiance, out, preview;
  bool overwrite = false;
  bool half = false;
  std::string layers;  // empty: every layer expose writes
  std::string compression = kDefaultExrCompression;
  SensorOptions sensor;
  PreviewFlags preview_flags;
  std::string backend = "auto";
};

// An EXR that records its channels' units (photosite's own outputs: photosite/unit/<channel>)
// must hold radiance in the channels read (the unlayered R, G, B or Y come first): an expose or
// night output's R,G,B are DN. The message points to a layer of the file that is radiance.
// Returns the file's attributes (read_exr_attributes).
std::map<std::string, std::string> check_radiance_units(const std::string& path) {
  const auto attrs = read_exr_attributes(path);
  const std::string prefix = "photosite/unit/";
  for (const char* ch : {"R", "G", "B", "Y"}) {
    const auto u = attrs.find(prefix + ch);
    if (u == attrs.end() || u->second == unit::radiance) continue;
    std::string layer;
    for (const auto& [k, v] : attrs)
      if (k.rfind(prefix, 0) == 0 && v == unit::radiance && k.size() > prefix.size() + 2 && k.compare(k.size() - 2, 2, ".R") == 0)
        layer = k.substr(prefix.size(), k.size() - prefix.size() - 2);
    fail_at(path, fmt::format("--radiance: the channel {} is in '{}', not radiance ({}): expose reads R,G,B as scene radiance{}",
                              ch, u->second, unit::radiance,
                              layer.empty() ? std::string()
                                            : fmt::format("; this file's radiance is its {0}.* layer, which expose does not read: "
                                                          "write {0}.R, {0}.G, {0}.B to an EXR of their own as R, G, B and expose that",
                                                          layer)));
  }
  return attrs;
}

// The scene radiance of `path` as R, G, B; `windows` gets an EXR's data and display windows where
// they say more than its size (data_window, display_window: read_exr_attributes' dataWindow and
// displayWindow).
ImageF load_radiance(const std::string& path, std::map<std::string, std::string>& windows) {
  ImageFileInfo info;
  ImageF img = read_image(path, &info);
  check_frame_size(path, img.width(), img.height());  // the sensor's frame: at least one CFA tile
  if (!info.is_float)
    fail_at(path, "scene radiance must be a floating-point (linear) image such as EXR, found " +
                      std::to_string(info.bits_per_sample) + "-bit integer " + info.format);
  if (info.format == "openexr") {
    const auto attrs = check_radiance_units(path);
    for (const auto& [file_key, key] : {std::pair{"dataWindow", "data_window"}, {"displayWindow", "display_window"}})
      if (const auto it = attrs.find(file_key); it != attrs.end()) windows[key] = it->second;
  }
  if (img.channels() == 1) {  // grey radiance: equal band radiance in R, G, B
    ImageF rgb(img.width(), img.height(), 3);
    for (size_t i = 0; i < img.pixel_count(); ++i) rgb[3 * i] = rgb[3 * i + 1] = rgb[3 * i + 2] = img[i];
    img = std::move(rgb);
  } else if (img.channels() > 3) {  // R, G, B first (read_image's order), then alpha or others: left out
    ImageF rgb(img.width(), img.height(), 3);
    for (size_t i = 0; i < img.pixel_count(); ++i)
      for (int c = 0; c < 3; ++c) rgb[3 * i + c] = img[i * img.channels() + c];
    img = std::move(rgb);
  } else if (img.channels() != 3) {
    fail_at(path, "scene radiance must have 1 channel (grey) or R, G, B (further channels, such as alpha, are ignored); found " +
                      std::to_string(img.channels()));
  }
  img.set_unit(unit::radiance);
  return img;
}

void run(const ExposeCmd& c) {
  const LayerSet layers = c.layers.empty() ? kExposeLayers : parse_layers(c.layers, kExposeLayers, "--layers", "expose");
  check_exr_compression(c.compression, "--compression");
  const PreviewOptions preview_options = c.preview_flags.resolve(c.preview);
  auto r = c.sensor.resolve();
  SensorRunner runner(resolve_backend(c.backend, &r.camera));
  const auto outputs = frame_outputs(c.out, c.sensor.frames, c.overwrite);
  const auto previews = c.preview.empty() ? std::vector<std::string>{}
                                          : frame_outputs(c.preview, c.sensor.frames, c.overwrite);
  check_run_outputs({{"--out", outputs, ".exr"}, {"--preview", previews, ".png"}}, {{"--radiance", c.radiance}},
                    r.store.dir());
  std::map<std::string, std::string> radiance_windows;
  ImageF radiance = load_radiance(c.radiance, radiance_windows);
  if (!previews.empty()) check_preview_camera(preview_options, r.camera);
  if (!previews.empty()) check_preview_frame(preview_options, radiance.width(), radiance.height());
  const ResolvedExposure ex = resolve(r.camera, r.lens, r.settings);
  ImageF mean_e;
  try {
    mean_e = runner.mean_signal_electrons(radiance, r.camera, r.lens, ex);
  } catch (const Error& e) {
    fail_at(c.radiance, message(e));
  }
  const FixedPatternMaps fpn =
      r.store.load_or_create(r.camera, r.device_id, radiance.width(), radiance.height());
  for (int f = 0; f < c.sensor.frames; ++f) {
    r.settings.frame = static_cast<uint32_t>(f);
    SensorOutput out = runner.sense(mean_e, r.camera, ex, r.settings, fpn);
    auto groups = sensor_channels(out, layers);
    if (has(layers, Layer::Radiance))
      groups.push_back({{"radiance.R", "radiance.G", "radiance.B"}, &radiance, unit::radiance});
    auto attrs = sensor_attributes(r, ex, fpn);
    attrs["photosite/radiance_file"] = c.radiance;
    // An EXR whose data window is not at (0, 0) or is not its display window: both, as it had them
    // (xmin,ymin,xmax,ymax); the frame is the data window's pixels (the reader's note).
    for (const auto& [key, value] : radiance_windows) attrs["photosite/radiance_file_" + key] = value;
    ExrWriteOptions wo;
    wo.half = c.half;
    wo.compression = c.compression;
    // The frame's EXR and preview published together (include/photosite/output_set.h).
    OutputSet publish;
    write_exr(outputs[f], groups, attrs, wo);
    if (!previews.empty()) write_png8(previews[f], preview_image(out, r, ex, preview_options));
    publish.commit();
    std::printf("%s\n", outputs[f].c_str());
    if (!previews.empty()) std::printf("%s\n", previews[f].c_str());
  }
}
}  // namespace

static Registrar reg("b-expose", [](CLI::App& app) {
  auto cmd = std::make_shared<ExposeCmd>();
  auto* sub = app.add_subcommand("expose", "expose a scene radiance EXR through a camera preset");
  sub->add_option("--radiance", cmd->radiance, "scene radiance, linear W.sr-1.m-2 (EXR)")->required();
  sub->add_option("--out", cmd->out, "output EXR (with --frames, a # run takes the frame number)")->required();
  cmd->sensor.add(sub);
  add_backend_option(sub, cmd->backend);
  sub->add_option("--preview", cmd->preview, "also write an sRGB PNG preview (docs/sensor.md; never changes the EXR)");
  cmd->preview_flags.add(sub);
  sub->add_flag("--half", cmd->half, "store channels as half floats");
  sub->add_option("--layers", cmd->layers, "comma list of layers to write: sensor,raw,electrons,radiance (default: all)");
  sub->add_option("--compression", cmd->compression, "EXR compression: none, rle, zips, zip, piz (lossless); pxr24, b44, b44a, dwaa, dwab (lossy)")->capture_default_str();
  add_overwrite_flag(sub, cmd->overwrite);
  sub->callback([cmd] { run(*cmd); });
});

}  // namespace photosite::cli
