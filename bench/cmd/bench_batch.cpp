// `photosite bench batch`: images per core-hour of the batch engine (batch::run, what `photosite
// batch` runs) end to end on the Cityscapes samples (2048x1024), for the default EXR route and
// the PNG route (`--format png --layers sensor,labels`), beside its parts measured alone (read +
// decode + linearize, compute, write) and beside peers writing the same layers in the same run:
// OpenCV's imwrite (EXR through its own OpenEXR path, PNG through libpng) and oiiotool.
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <map>
#include <optional>
#include <thread>

#include <fmt/format.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "bench.h"
#include "photosite/batch.h"
#include "photosite/error.h"
#include "photosite/outputs.h"
#include "photosite/sensor/isp.h"

namespace photosite::bench {
namespace {
namespace fs = std::filesystem;

struct BenchBatchOptions {
  std::string root = std::string(PHOTOSITE_SOURCE_DIR) + "/../shared/data/cityscapes";
  std::string out_dir;
  int repeats = 3;
};

// CPU time (user + system) this process has used, in ms: on a shared machine the core-hours a
// run actually took, whatever share of the cores the other jobs left it.
double cpu_ms() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return (u.ru_utime.tv_sec + u.ru_stime.tv_sec) * 1e3 + (u.ru_utime.tv_usec + u.ru_stime.tv_usec) / 1e3;
}

// A float image as an OpenCV matrix (no copy).
cv::Mat mat_of(const ImageF& img) {
  return cv::Mat(img.height(), img.width(), CV_32FC(img.channels()), const_cast<float*>(img.data()));
}

void run_bench(const BenchBatchOptions& o) {
  if (o.repeats < 1 || o.repeats > 20) fail("--repeats must be in [1, 20]");
  const auto items = batch::discover(batch::Dataset::Cityscapes, o.root);
  const ScratchDir scratch("batch");
  const fs::path& tmp = scratch.path();
  const int cores = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  const auto per_core_hour = [&](double ms_per_image) { return 3.6e6 / (ms_per_image * cores); };

  // What `photosite batch --dataset cityscapes` resolves to.
  batch::Options bo;
  bo.source = "cityscapes " + o.root;
  bo.root = o.root;
  bo.sensor.camera = load_camera_preset("onsemi-ar0331");
  bo.sensor.lens = load_lens_preset(bo.sensor.camera.default_lens);
  bo.sensor.device_id = bo.sensor.camera.name + "-0";
  bo.device_store = (tmp / "store").string();
  bo.scene = scene::load_scene_preset("night-urban");
  const auto& r = bo.sensor;
  const ResolvedExposure ex = resolve(r.camera, r.lens, r.settings);
  const DeviceStore store(bo.device_store);
  const auto wb = white_balance_gains(r.camera);
  { auto f = store.load_or_create(r.camera, r.device_id, 2048, 1024); (void)f; }  // a one-off per device

  // ---- the parts alone, and the peers on the same data ----------------------------------------
  double t_read = 0, t_compute = 0, t_exr = 0, t_png = 0, t_copy = 0;
  double t_cv_exr = 0, t_cv_png = 0, t_oiio_exr = 0, t_oiio_png = 0;
  double mb_exr = 0, mb_png = 0, mb_cv_exr = 0;
  for (const auto& it : items) {
    ImageFileInfo info;
    ImageF day;
    scene::LabelMap labels;
    t_read += time_ms([&] {
      day = read_image(it.image, &info);
      labels = scene::read_labels(it.labels, it.instances, day.width(), day.height(), scene::LabelFormat::Auto,
                                  scene::ResizeLabels::None);
      day = scene::linearize(day, info);
    });
    std::optional<scene::NightScene> ns;
    std::optional<SensorOutput> out;
    std::map<std::string, ExrAttribute> attrs;
    t_compute += time_ms([&] {
      ns = scene::night_scene(day, labels, bo.scene, 1);
      const auto fpn = store.load_or_create(r.camera, r.device_id, day.width(), day.height());
      out = expose(ns->radiance, r.camera, r.lens, r.settings, fpn);
      attrs = night_attributes(r, ex, fpn, bo.scene, *ns, labels, {it.image, it.labels, it.instances});
    });
    ExrWriteOptions wo;
    wo.reproducible = true;
    wo.compression = bo.compression;
    const auto groups = night_channels(*out, *ns, labels, kBatchLayers);
    const std::string exr = (tmp / "alone.exr").string(), png = (tmp / "alone.png").string();
    t_exr += time_ms([&] { write_exr(exr, groups, attrs, wo); });
    mb_exr += fs::file_size(exr) / 1e6;
    t_png += time_ms([&] { write_png8(png, preview_srgb8(out->rgb, wb)); });
    mb_png += fs::file_size(png) / 1e6;
    t_copy += time_ms([&] { fs::copy_file(it.labels, tmp / "labels.png", fs::copy_options::overwrite_existing); });

    // OpenCV: the same five layers and codec; it writes no UINT channels (float32 for the
    // integers, half for depth) and one part per file.
    const std::vector<int> piz = {cv::IMWRITE_EXR_COMPRESSION, cv::IMWRITE_EXR_COMPRESSION_PIZ};
    std::vector<int> piz_half = piz;
    piz_half.insert(piz_half.end(), {cv::IMWRITE_EXR_TYPE, cv::IMWRITE_EXR_TYPE_HALF});
    ImageF label_f(labels.ids.width(), labels.ids.height(), 1, uninitialized);
    t_cv_exr += time_ms([&] {
      for (size_t i = 0; i < label_f.size(); ++i) label_f[i] = labels.ids[i];
      cv::Mat bgr;
      cv::cvtColor(mat_of(out->rgb), bgr, cv::COLOR_RGB2BGR);
      cv::imwrite((tmp / "cv_sensor.exr").string(), bgr, piz);
      cv::imwrite((tmp / "cv_raw.exr").string(), mat_of(out->raw_dn), piz);
      cv::imwrite((tmp / "cv_electrons.exr").string(), mat_of(out->electrons), piz);
      cv::imwrite((tmp / "cv_depth.exr").string(), mat_of(ns->depth), piz_half);
      cv::imwrite((tmp / "cv_labels.exr").string(), mat_of(label_f), piz);
    });
    for (const char* f : {"cv_sensor", "cv_raw", "cv_electrons", "cv_depth", "cv_labels"})
      mb_cv_exr += fs::file_size(tmp / (std::string(f) + ".exr")) / 1e6;
    const ImageU8 preview = preview_srgb8(out->rgb, wb);
    const cv::Mat p8(preview.height(), preview.width(), CV_8UC3, const_cast<uint8_t*>(preview.data()));
    cv::Mat p8_bgr;
    cv::cvtColor(p8, p8_bgr, cv::COLOR_RGB2BGR);
    t_cv_png += time_ms([&] { cv::imwrite((tmp / "cv.png").string(), p8_bgr, {cv::IMWRITE_PNG_COMPRESSION, 1}); });

    // oiiotool: rewrites our uncompressed file of the same layers (types kept) with PIZ, and the
    // preview from uncompressed TIFF to PNG at zlib level 1; its time includes starting the
    // process and reading the uncompressed input.
    ExrWriteOptions none = wo;
    none.compression = "none";
    write_exr((tmp / "none.exr").string(), groups, attrs, none);
    cv::imwrite((tmp / "preview.tif").string(), p8_bgr, {cv::IMWRITE_TIFF_COMPRESSION, 1});
    t_oiio_exr += time_ms([&] {
      const std::string cmd = fmt::format("oiiotool '{}' --compression piz -o '{}'", (tmp / "none.exr").string(),
                                          (tmp / "oiio.exr").string());
      if (std::system(cmd.c_str()) != 0) internal_error("bench batch: oiiotool failed");
    });
    t_oiio_png += time_ms([&] {
      const std::string cmd = fmt::format("oiiotool '{}' --attrib png:compressionLevel 1 -o '{}'",
                                          (tmp / "preview.tif").string(), (tmp / "oiio.png").string());
      if (std::system(cmd.c_str()) != 0) internal_error("bench batch: oiiotool failed");
    });
  }
  const double n = static_cast<double>(items.size());
  for (double* t : {&t_read, &t_compute, &t_exr, &t_png, &t_copy, &t_cv_exr, &t_cv_png, &t_oiio_exr, &t_oiio_png,
                    &mb_exr, &mb_png, &mb_cv_exr})
    *t /= n;

  // ---- end to end: batch::run in this process, as `photosite batch` runs it ------------------
  SensorRunner cpu(Backend::Cpu);
  // Wall ms per image (median) and CPU ms per image (median) of each route.
  auto end_to_end = [&](const std::string& name, batch::Options opt) {
    std::vector<double> ms, cpu_per_image;
    for (int k = 0; k < o.repeats; ++k) {
      opt.out = (tmp / fmt::format("{}-{}", name, k)).string();
      const double c0 = cpu_ms();
      const auto res = batch::run(items, opt, cpu);
      cpu_per_image.push_back((cpu_ms() - c0) / n);
      if (!res.errors.empty()) internal_error("bench batch: " + res.errors.front());
      ms.push_back(res.progress.elapsed_s * 1e3 / n);
      fs::remove_all(opt.out);
    }
    return std::pair{median(ms), median(cpu_per_image)};
  };
  const auto [e2e_exr, cpu_exr] = end_to_end("exr", bo);
  batch::Options png_opt = bo;
  png_opt.format = "png";
  png_opt.layers = static_cast<unsigned>(Layer::Sensor) | static_cast<unsigned>(Layer::Labels);
  const auto [e2e_png, cpu_png] = end_to_end("png", png_opt);

  const double exr_parts = t_read + t_compute + t_exr + t_copy, png_parts = t_read + t_compute + t_png + t_copy;
  std::printf("batch, %zu Cityscapes images (2048x1024), %s; end to end the median of %d runs\n", items.size(),
              machine_description().c_str(), o.repeats);
  std::printf("  read + decode + linearize alone   %8.1f ms/image\n", t_read);
  std::printf("  compute (scene + sensor) alone    %8.1f ms/image\n", t_compute);
  std::printf("  EXR write alone (%s, default layers) %5.1f ms/image  %.2f MB\n", bo.compression.c_str(), t_exr, mb_exr);
  std::printf("    peer OpenCV imwrite, same layers  %7.1f ms/image  %.2f MB  (ours %.2fx its time)\n", t_cv_exr,
              mb_cv_exr, t_exr / t_cv_exr);
  std::printf("    peer oiiotool none->piz           %7.1f ms/image            (ours %.2fx its time)\n", t_oiio_exr,
              t_exr / t_oiio_exr);
  std::printf("  PNG preview alone (sRGB8 + libpng) %7.1f ms/image  %.2f MB\n", t_png, mb_png);
  std::printf("    peer OpenCV imwrite PNG level 1   %7.1f ms/image            (ours %.2fx its time)\n", t_cv_png,
              t_png / t_cv_png);
  std::printf("    peer oiiotool tif->png level 1    %7.1f ms/image            (ours %.2fx its time)\n", t_oiio_png,
              t_png / t_oiio_png);
  std::printf("  label copy alone                  %8.1f ms/image\n", t_copy);
  std::printf("  end to end, EXR default route     %8.1f ms/image = %.2fx compute alone, %.2fx the parts' sum: %.0f images per core-hour of wall time x %d cores (target >= 4000); CPU %.1f ms/image: %.0f images per CPU core-hour used\n",
              e2e_exr, e2e_exr / t_compute, e2e_exr / exr_parts, per_core_hour(e2e_exr), cores, cpu_exr, 3.6e6 / cpu_exr);
  std::printf("  end to end, PNG sensor,labels     %8.1f ms/image = %.2fx compute alone, %.2fx the parts' sum: %.0f images per core-hour of wall time x %d cores (target >= 10000); CPU %.1f ms/image: %.0f images per CPU core-hour used\n",
              e2e_png, e2e_png / t_compute, e2e_png / png_parts, per_core_hour(e2e_png), cores, cpu_png, 3.6e6 / cpu_png);
  std::string csv = "part,ms_per_image,mb_per_image,images_per_core_hour\n";
  csv += fmt::format("read,{:.1f},,\ncompute,{:.1f},,\n", t_read, t_compute);
  csv += fmt::format("write_exr_{},{:.1f},{:.2f},\n", bo.compression, t_exr, mb_exr);
  csv += fmt::format("peer_opencv_imwrite_exr_piz,{:.1f},{:.2f},\n", t_cv_exr, mb_cv_exr);
  csv += fmt::format("peer_oiiotool_exr_none_to_piz,{:.1f},,\n", t_oiio_exr);
  csv += fmt::format("write_png_preview,{:.1f},{:.2f},\n", t_png, mb_png);
  csv += fmt::format("peer_opencv_imwrite_png_level1,{:.1f},,\n", t_cv_png);
  csv += fmt::format("peer_oiiotool_tif_to_png_level1,{:.1f},,\n", t_oiio_png);
  csv += fmt::format("label_copy,{:.1f},,\n", t_copy);
  csv += fmt::format("end_to_end_exr_default,{:.1f},,{:.0f}\n", e2e_exr, per_core_hour(e2e_exr));
  csv += fmt::format("end_to_end_png_sensor_labels,{:.1f},,{:.0f}\n", e2e_png, per_core_hour(e2e_png));
  csv += fmt::format("end_to_end_exr_default_cpu_time,{:.1f},,{:.0f}\n", cpu_exr, 3.6e6 / cpu_exr);
  csv += fmt::format("end_to_end_png_sensor_labels_cpu_time,{:.1f},,{:.0f}\n", cpu_png, 3.6e6 / cpu_png);
  csv += fmt::format("# {} Cityscapes 2048x1024 images, onsemi-ar0331, batch::run in process (CPU backend), "
                     "default layers {} with {}; images_per_core_hour from wall time x {} hardware threads, and (rows *_cpu_time) from the CPU time the run used; {}\n",
                     items.size(), layers_text(kBatchLayers), bo.compression, cores, machine_description());
  write_bench_csv(o.out_dir, "bench_batch.csv", csv);
}
}  // namespace

static BenchRegistrar reg("batch", "batch engine end to end (EXR and PNG routes) beside its parts and OpenCV/oiiotool",
                          [](CLI::App* sub) {
                            auto o = std::make_shared<BenchBatchOptions>();
                            sub->add_option("--root", o->root, "Cityscapes-layout root")->capture_default_str();
                            sub->add_option("--repeats", o->repeats, "end-to-end runs per route (median)")
                                ->capture_default_str();
                            sub->add_option("--out-dir", o->out_dir, "where the CSV goes (default docs/)");
                            sub->callback([o] { run_bench(*o); });
                          });
}  // namespace photosite::bench
