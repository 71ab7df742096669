// `photosite night`: a day photo and its Cityscapes-format labels in, the night scene radiance
// and the camera's exposure of it out (docs/night.md). `photosite demo` runs it on the bundled
// KITTI frame.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <sstream>

#include <fmt/format.h>

#include "photosite/environment.h"
#include "photosite/batch.h"
#include "photosite/checksum.h"
#include "photosite/error.h"
#include "photosite/io.h"
#include "photosite/scene/night.h"
#include "photosite/sensor/isp.h"
#include "photosite/sensor/spectrum.h"
#include "photosite/night_chain.h"
#include "photosite/output_set.h"
#include "photosite/outputs.h"
#include "photosite/visualize.h"
#include "backend.h"
#include "registry.h"
#include "sensor_options.h"

namespace photosite::cli {

struct NightCmd {
  std::string image, labels, instances, out, preview, maps;
  std::string scene_preset = "night-urban";
  std::string rig = "auto";
  std::string label_format = "auto";
  std::string resize_labels = "none";
  std::optional<double> ambient_lux;  // none: the scene preset's
  std::optional<std::string> streetlamp_type;  // none: the scene preset's
  bool timings = false, overwrite = false, half = false;
  SensorOptions sensor;
  std::string backend = "auto";
  std::string layers;  // empty: every layer
  std::string compression = kDefaultExrCompression;
  PreviewFlags preview_flags;
};

// The --maps pictures' record: `<folder>/.photosite-maps`, one line per picture written, "<XXH3-64 of
// its bytes> <file name>". The pictures have plain names (day.png, labels.png, depth.png, ...)
// that a user's own files in the folder may carry, and a user's file is never replaced, -y or
// not; with -y a picture replaces only photosite's own earlier one: a file the record lists with
// the bytes it has now (batch's rule for its output folder, the resume manifest's checksums).
namespace {
constexpr const char* kMapsRecord = ".photosite-maps";

std::map<std::string, std::string> read_maps_record(const std::string& folder) {
  std::map<std::string, std::string> sums;  // file name -> checksum
  std::ifstream f(std::filesystem::path(folder) / kMapsRecord);
  for (std::string sum, name; f >> sum >> name;) sums[name] = sum;
  return sums;
}

// Before any work: with -y, every picture name that exists in the folder must be photosite's own.
void check_maps_replace_only_their_own(const std::string& folder) {
  const auto sums = read_maps_record(folder);
  for (const auto& name : night_map_picture_files()) {
    const std::string path = (std::filesystem::path(folder) / name).string();
    std::error_code ec;
    if (!std::filesystem::exists(path, ec)) continue;
    const auto it = sums.find(name);
    if (it == sums.end() || file_checksum_hex(path, ChecksumAlgorithm::Xxh3_64) != it->second)
      fail_at(path, std::string("exists and is not a --maps picture of an earlier run (") + kMapsRecord +
                        (it == sums.end() ? " does not list it" : " lists other bytes") +
                        "); photosite never replaces a user's file, even with -y: move it, or give another --maps folder");
  }
}

// After the pictures are published: their record, replaced whole.
void record_maps(const std::string& folder) {
  std::ostringstream text;
  for (const auto& name : night_map_picture_files())
    if (const auto sum = file_checksum_hex((std::filesystem::path(folder) / name).string(), ChecksumAlgorithm::Xxh3_64))
      text << *sum << ' ' << name << '\n';
  const std::string path = (std::filesystem::path(folder) / kMapsRecord).string();
  atomic_write(path, [&](const std::string& tmp) {
    std::ofstream f(tmp, std::ios::binary);
    f << text.str();
    if (!f.flush()) fail_at(path, "cannot write the --maps pictures' record");
  });
}
}  // namespace

// The bundled KITTI sample (samples/kitti, CC BY-NC-SA 3.0, see its ATTRIBUTION.md).
std::string night_sample_dir() {
  if (auto e = env::get(env::Var::SampleDir)) return *e;
  return data_dir() + "/samples";
}

void run_night(NightCmd c) {
  const LayerSet layers = c.layers.empty() ? kNightLayers : parse_layers(c.layers, kNightLayers, "--layers", "night");
  check_exr_compression(c.compression, "--compression");
  const PreviewOptions preview_options = c.preview_flags.resolve(c.preview);
  using clock = std::chrono::steady_clock;
  const auto t_start = clock::now();
  const bool bundled = c.image.empty() && c.labels.empty();
  if (bundled) {
    c.image = night_sample_dir() + "/kitti/image_2/000000_10.png";
    c.labels = night_sample_dir() + "/kitti/semantic/000000_10.png";
    if (c.sensor.preset.empty()) c.sensor.preset = batch::dataset_camera(batch::Dataset::Kitti).camera;
  } else if (c.image.empty() || c.labels.empty()) {
    fail("night: give both --image and --labels, or neither to run on the bundled KITTI sample");
  }
  if (c.sensor.preset.empty()) c.sensor.preset = batch::dataset_camera(batch::Dataset::Cityscapes).camera;
  scene::ScenePreset sp = scene::load_scene_preset(c.scene_preset);
  if (c.ambient_lux) set_ambient_lux(sp, *c.ambient_lux);
  if (c.streetlamp_type) set_streetlamp_type(sp, *c.streetlamp_type);
  const auto fmt_label = scene::parse_label_format(c.label_format);
  scene::ResizeLabels resize;
  if (c.resize_labels == "none") resize = scene::ResizeLabels::None;
  else if (c.resize_labels == "nearest") resize = scene::ResizeLabels::Nearest;
  else fail("--resize-labels: '" + c.resize_labels + "' is not none or nearest");
  auto r = c.sensor.resolve();
  SensorRunner runner = make_backend(c.backend, &r.camera);
  const auto outputs = frame_outputs(c.out, c.sensor.frames, c.overwrite);
  const auto previews = c.preview.empty() ? std::vector<std::string>{}
                                          : frame_outputs(c.preview, c.sensor.frames, c.overwrite);
  std::vector<std::string> map_files;
  if (!c.maps.empty())
    for (const auto& f : night_map_picture_files()) map_files.push_back((std::filesystem::path(c.maps) / f).string());
  check_run_outputs({{"--out", outputs, ".exr"}, {"--preview", previews, ".png"}, {"--maps", map_files, ""}},
                    {{"--image", c.image}, {"--labels", c.labels}, {"--instances", c.instances}}, r.store.dir());

  std::vector<scene::StageTiming> times;
  auto t = clock::now();
  auto lap = [&](const char* name) {
    const auto now = clock::now();
    times.push_back({name, std::chrono::duration<double, std::milli>(now - t).count()});
    t = now;
  };
  if (!std::filesystem::exists(c.image)) fail_at(c.image, "image file not found");
  if (!c.maps.empty() && !std::filesystem::is_directory(c.maps)) fail_at(c.maps, "--maps: folder does not exist");
  if (!c.maps.empty() && c.overwrite) check_maps_replace_only_their_own(c.maps);
  ImageFileInfo info;
  // A plain 8-bit RGB PNG (Cityscapes' frames) stays as its codes: the chain linearises them
  // directly (prepare_night), the same bits as from read_image()'s floats.
  DayImage day_file = read_day_image(c.image, &info);
  const int day_w = day_file.width(), day_h = day_file.height();
  const std::string image_note = day_file.codes ? std::string() : day_image_note(day_file.floats, info);
  if (!previews.empty()) check_preview_camera(preview_options, r.camera);
  if (!previews.empty()) check_preview_frame(preview_options, day_w, day_h);
  scene::LabelMap labels = scene::read_labels(c.labels, c.instances, day_w, day_h, fmt_label, resize);
  sp.rig = scene::resolve_camera_rig(bundled && c.rig == "auto" ? batch::dataset_camera(batch::Dataset::Kitti).rig : c.rig, day_w, day_h, c.image);
  lap("read inputs");
  // Each frame's files (the first frame's with the --maps pictures) are published together, when
  // all are written: a run that fails on the way leaves none of them (include/photosite/output_set.h).
  std::optional<OutputSet> publish(std::in_place);
  std::function<void(const ImageF&, const scene::NightScene&)> maps;
  if (!c.maps.empty())
    maps = [&](const ImageF& day, const scene::NightScene& ns) {
      write_pictures(c.maps, night_map_pictures(day, labels, ns), c.overwrite);
    };
  const NightChain chain = day_file.codes
                               ? prepare_night(runner, std::move(*day_file.codes), info, labels, sp, r, r.store, maps)
                               : prepare_night(runner, std::move(day_file.floats), info, labels, sp, r, r.store, maps);
  const scene::NightScene& ns = chain.scene;
  const int frame_w = chain.width, frame_h = chain.height;
  for (const auto& st : chain.timings) times.push_back(st);
  t = clock::now();

  for (int f = 0; f < c.sensor.frames; ++f) {
    r.settings.frame = static_cast<uint32_t>(f);
    SensorOutput out = night_frame(runner, chain, r, r.settings.frame);
    lap("sensor: noise, ADC, demosaic");
    const auto groups = night_channels(out, ns, labels, layers);
    const auto attrs = night_attributes(r, chain.exposure, chain.fpn, sp, ns, labels, {c.image, c.labels, c.instances, image_note, info.note});
    ExrWriteOptions wo;
    wo.half = c.half;
    wo.compression = c.compression;
    if (!publish) publish.emplace();
    write_exr(outputs[f], groups, attrs, wo);
    if (!previews.empty()) write_png8(previews[f], preview_image(out, r, chain.exposure, preview_options));
    publish->commit();
    publish.reset();
    if (f == 0 && !c.maps.empty()) record_maps(c.maps);
    std::printf("%s\n", outputs[f].c_str());
    if (!previews.empty()) std::printf("%s\n", previews[f].c_str());
    lap("write outputs");
  }
  std::printf("vanishing point (%.1f, %.1f) px, method %s, confidence %.2f%s%s\n", ns.vp.x, ns.vp.y,
              scene::vp_method_name(ns.vp.method), ns.vp.confidence, ns.vp.note.empty() ? "" : ": ",
              ns.vp.note.c_str());
  std::printf("horizon y %.1f px from the %s (confidence %.2f), rig %s: f %.1f px, height %.2f m, pitch %.2f deg\n",
              ns.geometry.horizon_y, ns.geometry.horizon_source == "rig" ? "rig's nominal pitch" : "vanishing point",
              ns.geometry.horizon_confidence, ns.geometry.rig.c_str(), ns.geometry.f_px, ns.geometry.mount_height_m,
              ns.geometry.pitch_rad * 180 / M_PI);
  std::printf("labels read as %s%s\n", scene::label_format_name(labels.format),
              c.label_format == "auto" ? " (detected)" : "");
  if (!image_note.empty()) std::printf("note: %s: %s\n", c.image.c_str(), image_note.c_str());
  if (!labels.note.empty()) std::printf("note: %s\n", labels.note.c_str());
  if (!ns.geometry.note.empty()) std::printf("note: %s\n", ns.geometry.note.c_str());
  if (!ns.light_stats.street_lamp_note.empty())
    std::printf("note: no street lamps: %s\n", ns.light_stats.street_lamp_note.c_str());
  if (c.timings) {
    std::printf("\n%-32s %10s   (%dx%d, %s)\n", "stage", "ms", frame_w, frame_h,
                r.camera.name.c_str());
    double scene_ms = 0;
    for (const auto& st : times) {
      std::printf("%-32s %10.2f\n", st.stage.c_str(), st.ms);
      if (st.stage != "read inputs" && st.stage.rfind("sensor", 0) != 0 && st.stage != "write outputs" &&
          st.stage != "write maps")
        scene_ms += st.ms;
    }
    const double total = std::chrono::duration<double, std::milli>(clock::now() - t_start).count();
    std::printf("%-32s %10.2f\n%-32s %10.2f\n", "scene stages (linearize..compose)", scene_ms,
                "total (with file I/O)", total);
    if (runner.backend() == Backend::Vulkan) {
      const auto tr = runner.transfers();
      std::printf("%-32s %10.1f\n%-32s %10.1f\n%-32s %10s\n", "host->device (MB)", tr.uploaded / 1e6,
                  "device->host (MB)", tr.downloaded / 1e6, "transfers", tr.staged ? "staged" : "mapped");
      if (tr.imported) std::printf("%-32s %10.1f\n", "of which from imported pages (MB)", tr.imported / 1e6);
    }
  }
}

void add_night_options(CLI::App* sub, NightCmd& c) {
  sub->add_option("--image", c.image, "day image: 8/16-bit PNG, JPEG, TIFF (sRGB) or linear EXR");
  sub->add_option("--labels", c.labels, "Cityscapes-format labels: labelIds, trainIds or colour palette");
  sub->add_option("--instances", c.instances, "Cityscapes *_instanceIds.png (per-vehicle lights)");
  sub->add_option("--out", c.out, "output EXR (with --frames, a # run takes the frame number)")->required();
  sub->add_option("--scene-preset", c.scene_preset, "scene preset: name in presets/scenes or a .toml path")
      ->capture_default_str();
  sub->add_option("--rig", c.rig, "camera rig: name in presets/rigs (kitti, cityscapes), a .toml path, a Cityscapes camera .json, or auto (the image's Cityscapes camera file when beside it in the data set's layout, else the nearest native aspect ratio)")
      ->capture_default_str();
  sub->add_option("--ambient-lux", c.ambient_lux, "night ambient illuminance (moon + sky glow) in lx");
  sub->add_option("--streetlamp-type", c.streetlamp_type,
                  "street lamps' light source: led (phosphor white LED, CIE LED-B at the preset's CCTs) or hps (high-pressure sodium, CIE HP1), each as the camera records its spectrum (docs/night.md §7); "
                  "default: the scene preset's lamps.streetlamp_type");
  sub->add_option("--label-format", c.label_format, "auto, labelIds, trainIds or color")->capture_default_str();
  sub->add_option("--resize-labels", c.resize_labels, "none or nearest (labels of another size)")
      ->capture_default_str();
  sub->add_option("--preview", c.preview, "also write an sRGB PNG preview (never changes the EXR)");
  c.preview_flags.add(sub);
  sub->add_flag("--timings", c.timings, "print the per-stage time table");
  sub->add_option("--maps", c.maps, "an existing folder for the intermediate maps as PNGs (day, labels, lanes, edges, lines and vanishing point, depth, darkened, lights, night radiance; written with the first frame)");
  sub->add_flag("--half", c.half, "store channels as half floats");
  sub->add_option("--layers", c.layers, "comma list of layers to write: sensor,raw,electrons,radiance,lights,depth,labels (default: all)");
  sub->add_option("--compression", c.compression, "EXR compression: none, rle, zips, zip, piz (lossless); pxr24, b44, b44a, dwaa, dwab (lossy)")->capture_default_str();
  c.sensor.add(sub, false);
  add_backend_option(sub, c.backend);
  add_overwrite_flag(sub, c.overwrite);
}

static Registrar reg("c-night", [](CLI::App& app) {
  auto cmd = std::make_shared<NightCmd>();
  auto* sub = app.add_subcommand(
      "night", "day photo + semantic labels -> night scene radiance and camera exposure");
  add_night_options(sub, *cmd);
  sub->callback([cmd] { run_night(*cmd); });
});

}  // namespace photosite::cli

namespace photosite::cli {
void run_demo(const std::string& out, const std::string& preview, bool overwrite, bool timings,
              const std::string& backend, const std::string& poisson) {
  NightCmd c;
  c.sensor.poisson = poisson;
  c.backend = backend;
  c.out = out;
  c.preview = preview;
  c.overwrite = overwrite;
  c.timings = timings;
  run_night(c);
}
}  // namespace photosite::cli
