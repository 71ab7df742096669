// `photosite batch`: a whole data set to night, on one machine or as one shard of many. The
// engine is the library's batch::run (photosite/batch.h); this file holds the flags, the signal
// handling, the progress bar and the printing.
#include <unistd.h>

#include <atomic>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <optional>
#include <string>

#include <fmt/format.h>

#include "photosite/batch.h"
#include "photosite/night_chain.h"
#include "photosite/scene/rig.h"
#include "photosite/error.h"
#include "backend.h"
#include "registry.h"
#include "sensor_options.h"

namespace photosite::cli {
namespace fs = std::filesystem;

namespace {
// SIGINT, SIGTERM and SIGHUP stop the run after the items in progress (batch::Options::stop);
// g_signal keeps which one came, for the exit status 128 + signal (the shell's convention).
std::atomic<bool> g_stop{false};
std::atomic<int> g_signal{0};
static_assert(std::atomic<bool>::is_always_lock_free && std::atomic<int>::is_always_lock_free);  // signal-safe
void on_signal(int sig) {
  g_signal = sig;
  g_stop = true;
}

// An absolute, lexically normal path without a trailing separator ("cs/" and "./cs" are "cs"),
// as the manifest records the source.
std::string normal_absolute(const std::string& path) {
  fs::path p = fs::absolute(path).lexically_normal();
  if (!p.has_filename() && p != p.root_path()) p = p.parent_path();
  return p.string();
}

struct BatchCmd {
  std::string dataset, root, manifest, shard = "0/1", scene_preset = "night-urban";
  std::string rig = "auto";  // auto: the data set's rig (kitti, cityscapes), else by aspect ratio
  std::string layers;  // not given: kBatchLayers
  CLI::Option* layers_option = nullptr;
  bool quiet = false;
  batch::Options options;
  SensorOptions sensor;
  std::string backend = "auto";
  std::optional<std::string> streetlamp_type;  // none: the scene preset's
  std::string ego_motion = "auto";  // auto: the data set's odometry where it has it (with --sequence); none
  CLI::Option* ego_motion_option = nullptr;
};

// The run; its exit status when that is not 0 or 2 (bad input is thrown as Error): 128 + the
// signal when one stopped the run before every item of the shard was written.
int run(BatchCmd& c) {
  batch::Options& o = c.options;
  const bool rig_given = c.rig != "auto";
  if (c.dataset.empty() == c.manifest.empty()) fail("batch: give either --dataset with --root, or --manifest");
  if (!c.dataset.empty() && c.root.empty()) fail("batch: --dataset needs --root");
  if (o.format != "exr" && o.format != "png" && o.format != "both") fail("--format must be exr, png or both");
  // Given, even as '' (parse_layers refuses a list naming no layer); not given: the default set.
  const bool layers_given = c.layers_option && c.layers_option->count() > 0;
  o.layers = layers_given ? parse_layers(c.layers, kNightLayers, "--layers", "batch") : kBatchLayers;
  // The PNG route writes the sensor preview and copies the labels: another layer would be
  // silently left out, so it is bad input there.
  if (o.format == "png" && layers_given) {
    parse_layers(c.layers, kPngRouteLayers, "--layers", "batch --format png");
    if (!has(o.layers, Layer::Sensor))
      fail("--layers " + c.layers + ": batch --format png writes the sensor preview, so the list must name sensor");
  }
  check_exr_compression(o.compression, "--compression");
  if (c.ego_motion != "auto" && c.ego_motion != "none")
    fail("--ego-motion '" + c.ego_motion + "' must be auto (the data set's odometry, where it has it) or none");
  if (c.ego_motion_option->count() > 0 && !o.sequences)
    fail("--ego-motion " + c.ego_motion + ": the camera's motion is read for sequences only; add --sequence");
  o.ego_motion = c.ego_motion == "auto";
  if (o.jobs < 1 || o.jobs > 64) fail("--jobs must be in [1, 64]");
  std::tie(o.shard_index, o.shard_count) = batch::parse_shard(c.shard);
  std::vector<batch::Item> items;
  if (!c.manifest.empty()) {
    items = batch::read_manifest(c.manifest);
    o.source = "manifest " + normal_absolute(c.manifest);
  } else {
    const auto ds = batch::parse_dataset(c.dataset);
    items = batch::discover(ds, c.root, o.out);
    o.source = std::string(batch::to_string(ds)) + " " + normal_absolute(c.root);
    o.root = c.root;
    if (c.sensor.preset.empty()) c.sensor.preset = batch::dataset_camera(ds).camera;
    if (c.rig == "auto") c.rig = batch::dataset_camera(ds).rig;  // where an item has no camera file
  }
  if (c.sensor.preset.empty()) c.sensor.preset = batch::dataset_camera(batch::Dataset::Cityscapes).camera;
  auto r = c.sensor.resolve();  // impossible settings name their option (ParameterError)
  o.sensor = r;
  o.device_store = r.store.dir();
  // The device store holds the maps every run of a device reads; the batch replaces no file it
  // did not write, but its outputs would lie among the maps (expose, flat and night refuse it too).
  if (inside(o.out, o.device_store))
    fail_at(o.out, "--out is inside the device store " + o.device_store +
                       ", the folder of the devices' fixed-pattern maps: photosite writes no output there");
  o.scene = scene::load_scene_preset(c.scene_preset);
  if (c.streetlamp_type) set_streetlamp_type(o.scene, *c.streetlamp_type);
  if (c.rig != "auto") o.scene.rig = scene::load_camera_rig(c.rig);  // auto: per image (rig_for_image)
  o.item_cameras = !rig_given;  // an explicit --rig wins over Cityscapes' per-image camera files
  SensorRunner runner(resolve_backend(c.backend, &r.camera));

  for (int sig : {SIGINT, SIGTERM, SIGHUP}) std::signal(sig, on_signal);
  o.stop = &g_stop;
  const bool tty = !c.quiet && isatty(2);
  bool started = false;
  auto progress = [&](const batch::Progress& p) {
    if (!started) {
      started = true;
      if (!c.quiet)
        std::fprintf(stderr, "batch: %zu items in shard %d/%d, %zu already done, %zu to do\n", p.items,
                     o.shard_index, o.shard_count, p.already_done, p.to_do);
      return;
    }
    if (!tty) return;
    const size_t n = p.written + p.failed;
    const double rate = p.elapsed_s > 0 ? p.written / p.elapsed_s : 0;
    const double left = rate > 0 ? (p.to_do - n) / rate : 0;
    const int bar = p.to_do ? static_cast<int>(30.0 * n / p.to_do) : 30;
    std::fprintf(stderr, "\r[%s%s] %zu/%zu  %.2f img/s  %02d:%02d left ", std::string(bar, '#').c_str(),
                 std::string(30 - bar, ' ').c_str(), n, p.to_do, rate, static_cast<int>(left) / 60,
                 static_cast<int>(left) % 60);
  };
  const batch::Result res = batch::run(items, o, runner, progress);
  const auto& p = res.progress;
  // Stopped by a signal with items of the shard not yet tried: 128 + the signal, so a scheduler
  // tells an interruption (run it again) from bad input or failed items (2). A signal that came
  // after the last item was done changes nothing.
  const bool interrupted = (res.interrupted || g_stop) && p.already_done + p.written + p.failed < p.items;
  if (tty) std::fprintf(stderr, "\n");
  if (!c.quiet)
    std::fprintf(stderr, "batch: wrote %zu items in %.1f s (%.2f s per item)%s\n", p.written, p.elapsed_s,
                 p.written ? p.elapsed_s / p.written : 0.0, interrupted ? ", interrupted" : "");
  for (const auto& e : res.errors) std::fprintf(stderr, "photosite: error: %s\n", e.c_str());
  const std::string failed =
      res.errors.empty() ? std::string()
                         : fmt::format("batch: {} of {} items failed ({}; re-run to retry)", res.errors.size(), p.to_do,
                                       p.written ? "the others are written" : "none was written");
  if (interrupted) {
    if (!failed.empty()) std::fprintf(stderr, "photosite: error: %s\n", failed.c_str());
    const int sig = g_signal.load();
    std::fprintf(stderr, "photosite: batch: interrupted by signal %d with %zu of %zu items not written; re-run the same "
                 "command to finish\n", sig, p.items - p.already_done - p.written, p.items);
    return 128 + sig;
  }
  if (!failed.empty()) fail(failed);
  return 0;
}
}  // namespace

static Registrar reg("f-batch", [](CLI::App& app) {
  auto c = std::make_shared<BatchCmd>();
  auto& o = c->options;
  auto* sub = app.add_subcommand("batch", "translate a whole data set to night (resumable, shardable)");
  sub->add_option("--dataset", c->dataset, "cityscapes, kitti or bdd100k (with --root)");
  sub->add_option("--root", c->root, "the data set's root folder");
  sub->add_option("--manifest", c->manifest, "file of 'image labels [instances]' lines instead of --dataset");
  sub->add_option("--out", o.out, "output folder (mirrors the data set's layout)")->required();
  sub->add_option("--shard", c->shard, "I/N: process the I-th of N deterministic shards")->capture_default_str();
  sub->add_option("--format", o.format, "exr, png (8-bit sRGB preview) or both")->capture_default_str();
  c->layers_option = sub->add_option("--layers", c->layers, "comma list of layers to write: sensor,raw,electrons,radiance,lights,depth,labels (default: sensor,raw,electrons,depth,labels)");
  sub->add_flag("--half", o.half, "store the float EXR layers as half floats");
  sub->add_option("--compression", o.compression, "EXR compression: none, rle, zips, zip, piz (lossless); pxr24, b44, b44a, dwaa, dwab (lossy)")->capture_default_str();
  sub->add_option("--jobs", o.jobs, "writer threads (--format png or a GPU backend; otherwise each worker writes its images)")->capture_default_str();
  sub->add_option("--compute-threads", o.compute_threads,
                  "OpenMP threads for the scene and sensor, per worker where there are workers (0: automatic)")
      ->capture_default_str();
  sub->add_option("--queue-depth", o.queue_depth, "images in flight (bounds memory; at most this many workers)")->capture_default_str();
  sub->add_option("--scene-preset", c->scene_preset, "scene preset")->capture_default_str();
  sub->add_option("--streetlamp-type", c->streetlamp_type,
                  "street lamps' light source for every image: led or hps (as night --streetlamp-type); "
                  "default: the scene preset's lamps.streetlamp_type");
  sub->add_option("--rig", c->rig, "camera rig (presets/rigs name, .toml path or Cityscapes camera .json; auto: each Cityscapes image's own camera file where the data set has it, else the data set's rig, else by aspect ratio)")
      ->capture_default_str();
  sub->add_flag("--sequence", o.sequences,
                "carry each sequence's street luminaires, reflectance normalisation and pitch from frame to frame "
                "(the camera's motion from the data set's odometry where it has it, see --ego-motion; else at rest "
                "or crops of one view)");
  c->ego_motion_option =
      sub->add_option("--ego-motion", c->ego_motion,
                      "with --sequence: auto (each frame's camera pose from the data set's odometry: Cityscapes "
                      "vehicle and timestamp files, KITTI raw OXTS) or none (every frame at pose 0)")
          ->capture_default_str();
  sub->add_flag("--quiet", c->quiet, "no progress output");
  c->sensor.add(sub, false, SensorOptions::kAllExtras & ~SensorOptions::kFrames);  // frames come from the data set
  add_backend_option(sub, c->backend);
  sub->callback([c] {
    // The runner and the engine are gone when run returns; only the status is left to give.
    if (const int status = run(*c); status != 0) {
      std::fflush(nullptr);
      std::exit(status);
    }
  });
});

}  // namespace photosite::cli
