// `photosite bench exr`: every OpenEXR compression this OpenEXR writes, on the typed night layers
// of one Cityscapes frame (2048x1024): ms to write (median of --repeats, through write_exr as
// `night` and `batch` write, OpenEXR's thread pool on every core) and MB per frame, for all
// seven layers (`night`'s default) and for batch's default set. Lossy codecs are measured for
// completeness; the default is chosen among the lossless ones (docs/cli.md). Writes
// docs/bench_exr.csv and the chart docs/bench_exr.png (bench/chart_exr.py, Debian matplotlib).
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "bench.h"
#include "photosite/batch.h"
#include "photosite/error.h"
#include "photosite/outputs.h"

namespace photosite::bench {
namespace {
namespace fs = std::filesystem;

struct ExrBench {
  std::string root = std::string(PHOTOSITE_SOURCE_DIR) + "/../shared/data/cityscapes";
  std::string out_dir;
  int repeats = 5;
};

void run(const ExrBench& b) {
  if (b.repeats < 1 || b.repeats > 100) fail("--repeats must be in [1, 100]");
  const auto items = batch::discover(batch::Dataset::Cityscapes, b.root);
  const auto& it = items.front();
  const ScratchDir scratch("exr");
  const fs::path& tmp = scratch.path();

  // One night frame, as `batch` computes it (onsemi-ar0331, night-urban, seed 0).
  SensorSetup r;
  r.camera = load_camera_preset("onsemi-ar0331");
  r.lens = load_lens_preset(r.camera.default_lens);
  r.device_id = r.camera.name + "-0";
  const ResolvedExposure ex = resolve(r.camera, r.lens, r.settings);
  const DeviceStore store((tmp / "store").string());
  const auto sp = scene::load_scene_preset("night-urban");
  ImageFileInfo info;
  const ImageF day = read_image(it.image, &info);
  const auto labels = scene::read_labels(it.labels, it.instances, day.width(), day.height(),
                                         scene::LabelFormat::Auto, scene::ResizeLabels::None);
  const auto ns = scene::night_scene(scene::linearize(day, info), labels, sp, 0);
  const auto fpn = store.load_or_create(r.camera, r.device_id, day.width(), day.height());
  const SensorOutput out = expose(ns.radiance, r.camera, r.lens, r.settings, fpn);
  const auto attrs = night_attributes(r, ex, fpn, sp, ns, labels, {it.image, it.labels, it.instances});

  std::printf("EXR compressions on the typed night layers of %s (%dx%d), median of %d writes, %s\n",
              fs::path(it.image).filename().c_str(), day.width(), day.height(), b.repeats,
              machine_description().c_str());
  std::printf("  %-8s %-8s %-42s %10s %10s\n", "codec", "lossless", "layers", "ms/frame", "MB/frame");
  std::string csv = "compression,lossless,layers,channels,ms_write_median,ms_write_min,mb_per_frame\n";
  for (const LayerSet layers : {kNightLayers, kBatchLayers}) {
    const auto groups = night_channels(out, ns, labels, layers);
    size_t channels = 0;
    for (const auto& g : groups) channels += g.channel_names.size();
    for (const auto& codec : exr_compressions()) {
      ExrWriteOptions wo;
      wo.compression = codec;
      wo.reproducible = true;
      const std::string path = (tmp / (codec + ".exr")).string();
      std::vector<double> ms;
      for (int k = 0; k < b.repeats; ++k) ms.push_back(time_ms([&] { write_exr(path, groups, attrs, wo); }));
      const double mb = static_cast<double>(fs::file_size(path)) / 1e6;
      const double best = *std::min_element(ms.begin(), ms.end());
      const bool lossless = exr_compression_lossless(codec);
      std::printf("  %-8s %-8s %-42s %10.1f %10.2f\n", codec.c_str(), lossless ? "yes" : "no",
                  layers_text(layers).c_str(), median(ms), mb);
      csv += fmt::format("{},{},\"{}\",{},{:.1f},{:.1f},{:.2f}\n", codec, lossless ? 1 : 0, layers_text(layers),
                         channels, median(ms), best, mb);
    }
  }
  csv += fmt::format("# {} ({}x{}), onsemi-ar0331, night-urban; write_exr through OpenEXR 3.1; {}\n",
                     fs::path(it.image).filename().string(), day.width(), day.height(), machine_description());
  const std::string csv_path = write_bench_csv(b.out_dir, "bench_exr.csv", csv);
  const std::string png = (fs::path(csv_path).parent_path() / "bench_exr.png").string();
  if (draw_chart("bench/chart_exr.py", csv_path, png)) std::printf("%s\n", png.c_str());
}
}  // namespace

static BenchRegistrar reg("exr", "every OpenEXR compression on the typed night layers: ms to write and MB per frame",
                          [](CLI::App* sub) {
                            auto b = std::make_shared<ExrBench>();
                            sub->add_option("--root", b->root, "Cityscapes-layout root (its first frame is used)")
                                ->capture_default_str();
                            sub->add_option("--repeats", b->repeats, "writes per compression")->capture_default_str();
                            sub->add_option("--out-dir", b->out_dir, "where CSV and chart go (default docs/)");
                            sub->callback([b] { run(*b); });
                          });
}  // namespace photosite::bench
