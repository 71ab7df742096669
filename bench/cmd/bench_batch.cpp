// `photosite bench batch`: per-image time of each pipeline part measured alone (read + decode,
// compute, EXR write) against the end-to-end wall time per image of `photosite batch`, on the
// Cityscapes samples (2048x1024) beside the source tree.
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include <fmt/format.h>

#include "bench.h"
#include "photosite/outputs.h"
#include "photosite/batch.h"
#include "photosite/error.h"

namespace photosite::bench {
namespace {
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t) { return std::chrono::duration<double, std::milli>(Clock::now() - t).count(); }

struct BenchBatchOptions {
  std::string root = std::string(PHOTOSITE_SOURCE_DIR) + "/../shared/data/cityscapes";
  std::string out_dir = std::string(PHOTOSITE_SOURCE_DIR) + "/docs";
};

void run_bench(const BenchBatchOptions& o) {
  const auto items = batch::discover(batch::Dataset::Cityscapes, o.root);
  const fs::path tmp = fs::temp_directory_path() / fmt::format("photosite-bench-batch-{}", getpid());
  fs::remove_all(tmp);
  fs::create_directories(tmp);
  setenv("PHOTOSITE_DEVICE_STORE", (tmp / "store").c_str(), 1);
  SensorSetup r;
  r.camera = load_camera_preset("onsemi-ar0331");
  r.lens = load_lens_preset(r.camera.default_lens);
  r.device_id = r.camera.name + "-0";
  resolve(r.camera, r.lens, r.settings);  // the command's defaults (ExposureSettings{}), checked
  const DeviceStore store;  // $PHOTOSITE_DEVICE_STORE, set above
  const auto sp = scene::load_scene_preset("night-urban");
  double t_read = 0, t_compute = 0, t_write = 0;
  // Warm the device store (map creation is a one-off per device and size).
  { auto f = store.load_or_create(r.camera, r.device_id, 2048, 1024); (void)f; }
  for (const auto& it : items) {
    auto t = Clock::now();
    ImageFileInfo info;
    ImageF day = read_image(it.image, &info);
    auto labels = scene::read_labels(it.labels, it.instances, day.width(), day.height(), scene::LabelFormat::Auto,
                                     scene::ResizeLabels::None);
    ImageF lin = scene::linearize(day, info);
    t_read += ms_since(t);
    t = Clock::now();
    auto ns = scene::night_scene(lin, labels, sp, 1);
    const auto fpn = store.load_or_create(r.camera, r.device_id, lin.width(), lin.height());
    const auto ex = resolve(r.camera, r.lens, r.settings);
    auto out = expose(ns.radiance, r.camera, r.lens, r.settings, fpn);
    auto attrs = night_attributes(r, ex, fpn, sp, ns, labels, {it.image, it.labels, it.instances});
    t_compute += ms_since(t);
    t = Clock::now();
    ExrWriteOptions wo;
    wo.reproducible = true;
    wo.compression = "piz";  // batch's default: the fastest lossless codec on noisy float data here
    write_exr((tmp / "alone.exr").string(), night_channels(out, ns, labels, kBatchLayers), attrs, wo);
    fs::copy_file(it.labels, tmp / "labels.png", fs::copy_options::overwrite_existing);
    t_write += ms_since(t);
  }
  const double n = static_cast<double>(items.size());
  t_read /= n;
  t_compute /= n;
  t_write /= n;
  // End to end through the pipeline, in a child process, as a user runs it.
  const auto t = Clock::now();
  const std::string cmd = fmt::format("'/proc/{}/exe' batch --dataset cityscapes --root '{}' --out '{}' --quiet", getpid(),
                                      o.root, (tmp / "out").string());
  if (std::system(cmd.c_str()) != 0) internal_error("bench batch: the batch run failed");
  const double t_e2e = ms_since(t) / n;
  const double slowest = std::max({t_read, t_compute, t_write});
  std::printf("batch pipeline, %zu Cityscapes images (2048x1024), %s\n", items.size(), machine_description().c_str());
  std::printf("  read + decode + linearize alone   %8.1f ms/image\n", t_read);
  std::printf("  compute (scene + sensor) alone    %8.1f ms/image\n", t_compute);
  std::printf("  EXR write + label copy alone      %8.1f ms/image\n", t_write);
  std::printf("  end to end (photosite batch)      %8.1f ms/image  = %.2fx the slowest part (target <= 1.2x)\n",
              t_e2e, t_e2e / slowest);
  std::printf("  throughput: %.0f images per core-hour\n", 3.6e6 / t_e2e / 2.0);
  std::ofstream f(o.out_dir + "/bench_batch.csv");
  f << "part,ms_per_image\n"
    << fmt::format("read,{:.1f}\ncompute,{:.1f}\nwrite,{:.1f}\nend_to_end,{:.1f}\nratio_to_slowest,{:.3f}\n", t_read,
                   t_compute, t_write, t_e2e, t_e2e / slowest)
    << "# " << items.size() << " Cityscapes 2048x1024 images, onsemi-ar0331, EXR piz, batch default layers (sensor,raw,electrons,depth,labels; typed); " << machine_description() << "\n";
  fs::remove_all(tmp);
  std::printf("wrote %s/bench_batch.csv\n", o.out_dir.c_str());
}
}  // namespace

static BenchRegistrar reg("batch", "batch pipeline: each part alone vs end to end", [](CLI::App* sub) {
  auto o = std::make_shared<BenchBatchOptions>();
  sub->add_option("--root", o->root, "Cityscapes-layout root")->capture_default_str();
  sub->add_option("--out-dir", o->out_dir, "where the CSV goes")->capture_default_str();
  sub->callback([o] { run_bench(*o); });
});
}  // namespace photosite::bench
