// `photosite bench pipeline`: the per-pixel stages of the night chain and the sensor on the CPU
// path and on the Vulkan backend in the same run, per step in the layout of Baek 2020's Table 6
// (2048x1024), with the thesis's GTX 1080 Ti numbers beside them and the Vulkan/CPU ratio.
// Vulkan times are device times from timestamp queries (on lavapipe: CPU time of its threads);
// steps without a kernel (geometry: lanes, Canny, Hough, depth, light placement, the reflectance
// texture's class means) run on the CPU in both columns. CSV to docs/bench_pipeline_<device>.csv.
#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <opencv2/core.hpp>

#include <fmt/format.h>

#include "bench.h"
#include "photosite/error.h"
#include "photosite/io.h"
#include "photosite/rng.h"
#include "photosite/scene/night.h"
#include "photosite/sensor/fpn.h"
#include "photosite/sensor/isp.h"
#include "photosite/sensor/pipeline.h"
#include "photosite/sensor/poisson.h"
#include "photosite/sensor/preset.h"
#ifdef PHOTOSITE_HAVE_VULKAN
#include "photosite/gpu/scene.h"
#include "photosite/gpu/sensor.h"
#include "photosite/gpu/stages.h"
#endif

namespace photosite::bench {
namespace {
const DemosaicMethod kOtherDemosaics[] = {DemosaicMethod::Malvar, DemosaicMethod::HamiltonAdams,
                                          DemosaicMethod::Lmmse};
struct Opts {
  std::string preset = "onsemi-ar0331", out_dir, backend = "vulkan";
  int repeats = 5, threads = 2;
};

void run(const Opts& o) {
  namespace fs = std::filesystem;
  if (o.backend != "vulkan" && o.backend != "cpu") fail("bench pipeline: --backend must be vulkan or cpu");
  if (o.repeats < 1) fail("bench pipeline: --repeats must be >= 1");
  omp_set_num_threads(o.threads);
  cv::setNumThreads(o.threads);
  // The frame: a Cityscapes image from ../shared, else the synthetic road, at 2048x1024.
  ImageF day, raw;  // raw: the 8-bit file as read (codes in [0,1]), for linearize
  ImageFileInfo raw_info;
  scene::LabelMap lm;
  std::string source;
  const fs::path shared = fs::path(PHOTOSITE_SOURCE_DIR) / ".." / "shared" / "data" / "cityscapes";
  if (fs::exists(shared / "leftImg8bit")) {
    ImageFileInfo& info = raw_info;
    raw = read_image((shared / "leftImg8bit/aachen_000000_000019_leftImg8bit.png").string(), &info);
    lm = scene::read_labels((shared / "gtFine/aachen_000000_000019_gtFine_labelIds.png").string(),
                            (shared / "gtFine/aachen_000000_000019_gtFine_instanceIds.png").string(), raw.width(),
                            raw.height(), scene::LabelFormat::Auto, scene::ResizeLabels::None);
    day = scene::linearize(raw, info);
    source = "Cityscapes aachen_000000_000019";
  } else {
    scene::SyntheticOptions so;
    so.width = 2048, so.height = 1024, so.vp_x = 1000, so.vp_y = 450, so.cars = 3;
    auto s = scene::make_synthetic_road(so);
    lm = s.labels;
    day = s.day_linear_srgb;
    source = "synthetic road (../shared/data/cityscapes absent)";
    raw = ImageF(day.width(), day.height(), 3, uninitialized);  // its 8-bit sRGB codes
    for (size_t i = 0; i < day.size(); ++i)
      raw[i] = static_cast<float>(std::nearbyint(srgb_encode(std::clamp(day[i], 0.f, 1.f)) * 255) / 255);
    raw_info.path = "synthetic";
  }
  const int W = day.width(), H = day.height();
  const size_t n = static_cast<size_t>(W) * H;
  const scene::ScenePreset sp = scene::load_scene_preset("night-urban");
  const CameraPreset cam = load_camera_preset(o.preset);
  const LensPreset lens = load_lens_preset(cam.default_lens);
  ExposureSettings es;
  es.exposure_s = 0.03;
  const ResolvedExposure ex = resolve(cam, lens, es);
  const FixedPatternMaps fpn = generate_fixed_pattern(cam, W, H, "bench-0");
  const ImageF texture = scene::reflectance_texture(day, lm.ids, sp);

  std::map<std::string, std::vector<double>> cpu, dev;
  double resident_up_mb = 0, resident_down_mb = 0, trips_up_mb = 0, trips_down_mb = 0;
  std::string device = "none";
#ifdef PHOTOSITE_HAVE_VULKAN
  std::unique_ptr<gpu::SensorChain> chain;
  std::unique_ptr<gpu::SceneStages> stages;
  gpu::Context* ctx = nullptr;
  if (o.backend == "vulkan") {
    try {
      ctx = &gpu::shared_context();
    } catch (const Error& e) {
      fail(std::string("bench pipeline --backend vulkan: ") + e.what());
    }
    if (!ctx->device().timestamps) fail("bench pipeline: the Vulkan device has no compute timestamps");
    device = ctx->device().name + (!ctx->device().staged           ? " (mapped buffers)"
                                       : ctx->device().host_import ? " (staged transfers; host-page import offered, not used here)"
                                                                   : " (staged transfers)");
    chain = std::make_unique<gpu::SensorChain>(*ctx);
    stages = std::make_unique<gpu::SceneStages>(*ctx);
  }
#else
  if (o.backend == "vulkan") fail("bench pipeline --backend vulkan: built without the Vulkan backend");
#endif
  std::vector<float> pmean(n), pout(n);
  for (size_t i = 0; i < n; ++i) pmean[i] = static_cast<float>(100.0 * uniform_open(random_words(1, 0, i, Stream::Test)[0]));

  for (int r = 0; r <= o.repeats; ++r) {  // round 0 warms up (pipelines, caches) and is dropped
    const bool keep = r > 0;
    auto add = [&](auto& m, const std::string& k, double ms) { if (keep) m[k].push_back(ms); };
    // ---- CPU path ----
    scene::NightScene ns = scene::night_scene(day, lm, sp, 1);
    for (const auto& st : ns.timings) add(cpu, st.stage, st.ms);
    add(cpu, "darken only", time_ms([&] { (void)scene::darken(texture, lm.ids, sp); }));
    add(cpu, "linearize", time_ms([&] { (void)scene::linearize(raw, raw_info); }));
    add(cpu, "compose only", time_ms([&] { (void)scene::compose(texture, ns.lights, lm.ids, ns.beam_lux, sp); }));
    const GlarePlan gplan = lens_glare_plan(cam, lens);
    if (gplan.active) add(cpu, "glare", time_ms([&] { (void)glare_skirt(ns.radiance, gplan); }));
    ImageF mean_e;
    add(cpu, "photon", time_ms([&] { mean_e = mean_signal_electrons(ns.radiance, cam, lens, ex); }));
    es.frame = static_cast<uint32_t>(r);
    SensorOutput so;
    const double sense_ms = time_ms([&] { so = sense(mean_e, cam, ex, es, fpn); });
    ImageF above(W, H, 1, uninitialized, unit::dn);
    for (size_t i = 0; i < n; ++i) above[i] = so.raw_dn[i] - static_cast<float>(cam.black_level_dn);
    const double dem_ms = time_ms([&] { (void)demosaic_bilinear(above, cam.cfa); });
    add(cpu, "demosaic", dem_ms);
    add(cpu, "sense", sense_ms - dem_ms);
    add(cpu, "poisson", time_ms([&] { poisson_fill(pmean.data(), pout.data(), n, 0, 1, 0, 1); }));
    for (DemosaicMethod m : kOtherDemosaics)
      add(cpu, std::string("demosaic ") + to_string(m), time_ms([&] { (void)demosaic(above, cam.cfa, m); }));
#ifdef PHOTOSITE_HAVE_VULKAN
    if (chain) {
      // The sensor chain: one upload, photon → sense → demosaic, one download.
      SensorOutput gs;
      add(dev, "sensor wall (upload, kernels, download)", time_ms([&] { gs = chain->expose(ns.radiance, cam, lens, es, fpn); }));
      {  // device times summed per label (the glare pyramid has several dispatches of each kernel)
        std::map<std::string, double> per_label;
        for (const auto& st : chain->stage_times())
          per_label[st.label.rfind("glare", 0) == 0 ? std::string("glare") : st.label] += st.ms;
        for (const auto& [label, ms] : per_label) add(dev, label, ms);
      }
      // Darken, its own sequence.
      gpu::Buffer t(*ctx, 3 * n * sizeof(float)), l(*ctx, ((n + 1) / 2) * 4), out(*ctx, 3 * n * sizeof(float));
      t.upload(texture.data(), 3 * n * sizeof(float));
      l.upload(lm.ids.data(), n * sizeof(uint16_t));
      gpu::Sequence s(*ctx);
      gpu::record_darken(*ctx, s, t, l, out, n, scene::darken_params(sp));
      s.submit_and_wait();
      for (const auto& st : s.stage_times()) add(dev, "darken only", st.ms);
      // Linearize, and compose (darken + compose kernels), device times.
      double ms = -1;
      (void)gpu::linearize(*ctx, raw, raw_info, &ms);
      add(dev, "linearize", ms);
      (void)gpu::compose(*ctx, texture, ns.lights, lm.ids, ns.beam_lux, sp, &ms);
      add(dev, "compose only", ms);
      // The night tail and the sensor as night and batch run them: one sequence for darken and
      // compose, the sensor reading the radiance where it was left; against the same kernels
      // as separate round trips (each stage uploads its inputs and downloads its output).
      {
        ImageF L1 = ns.lights, L2 = ns.lights;
        auto t0 = ctx->transfers();
        add(dev, "tail+sensor resident", time_ms([&] {
              scene::PixelTail t = stages->tail(texture, L1, lm.ids, ns.beam_lux, sp, false);
              gs = chain->expose(t.radiance, cam, lens, es, fpn, stages->resident_radiance(t.resident));
            }));
        auto t1 = ctx->transfers();
        add(dev, "tail+sensor round trips", time_ms([&] {
              const ImageF rad = stages->compose(texture, L2, lm.ids, ns.beam_lux, sp);
              gs = chain->expose(rad, cam, lens, es, fpn);
            }));
        auto t2 = ctx->transfers();
        resident_up_mb = (t1.uploaded - t0.uploaded) / 1e6, resident_down_mb = (t1.downloaded - t0.downloaded) / 1e6;
        trips_up_mb = (t2.uploaded - t1.uploaded) / 1e6, trips_down_mb = (t2.downloaded - t1.downloaded) / 1e6;
      }
      // Poisson alone: the kernel of poisson_fill over a frame already on the device.
      gpu::Buffer pm(*ctx, n * 4), po(*ctx, n * 4);
      pm.upload(pmean.data(), n * 4);
      s.begin();
      gpu::record_poisson(*ctx, s, pm, po, n, 0, 1, 0, 1);
      s.submit_and_wait();
      for (const auto& st : s.stage_times()) add(dev, "poisson", st.ms);
      // The other demosaic methods' kernels on the black-subtracted mosaic (device time, all passes).
      for (DemosaicMethod m : kOtherDemosaics) {
        double ms = -1;
        (void)gpu::demosaic(*ctx, above, cam.cfa, m, &ms);
        add(dev, std::string("demosaic ") + to_string(m), ms);
      }
    }
#endif
  }
  auto med = [](auto& m, const std::string& k) { return m.count(k) ? median(m.at(k)) : -1.0; };
  struct Row { std::string step; double thesis; double cpu_ms; double dev_ms; std::string where; };
  const bool v = o.backend == "vulkan";
  // On the CPU the chain composes inside the light map's row pass (one stage, "lights+compose"):
  // the light map row then holds the composition too, and the composition row is compose() run
  // alone as a pass of its own ("compose only").
  const bool fused = !cpu.count("lights") && cpu.count("lights+compose");
  const double lights_cpu = fused ? med(cpu, "lights+compose") : med(cpu, "lights");
  const double compose_cpu = fused ? med(cpu, "compose only") : med(cpu, "compose");
  std::vector<Row> rows = {
      {"Preprocessing (texture: linear sRGB to reflectance)", 0.08, med(cpu, "darken") - 0, -1, "cpu"},
      {"Brightness adjustment (per-class darkening)", 0.06, med(cpu, "darken only"), med(dev, "darken only"), "kernel darken"},
      {"Lane segmentation", 2.36, med(cpu, "lanes"), med(cpu, "lanes"), "cpu"},
      {"Edge detection", 0.62, med(cpu, "edges"), med(cpu, "edges"), "cpu"},
      {"Hough transform (+ vanishing point)", 3.57, med(cpu, "lines") + med(cpu, "vanishing"),
       med(cpu, "lines") + med(cpu, "vanishing"), "cpu"},
      {"Coarse depth estimation", 0.17, med(cpu, "depth"), med(cpu, "depth"), "cpu"},
      {"Light map generation", 12.01, lights_cpu, lights_cpu,
       fused ? "cpu, compose inside (glare: the lens's, in RAW conversion)" : "cpu (glare: the lens's, in RAW conversion)"},
      {"Composition", 0.37, compose_cpu, med(dev, "compose only"),
       fused ? "kernels darken + compose (cpu: compose alone; the chain's is in the light map)" : "kernels darken + compose"},
      {"RAW conversion (optics with lens glare, photon integral)", 0.28, med(cpu, "photon"),
       med(dev, "photon") + std::max(0.0, med(dev, "glare")), "kernels glare_* + photon"},
      {"  of which the lens glare pyramid", -1, med(cpu, "glare"), med(dev, "glare"),
       "kernels glare_down/blur/up/norm (the mix is in photon)"},
      {"Sensor noise (shot, dark, FPN, read, ADC)", 1.44, med(cpu, "sense"), med(dev, "sense"), "kernel sense"},
      {"Demosaicing (bilinear)", 0.83, med(cpu, "demosaic"), med(dev, "demosaic"), "kernel demosaic_bilinear"},
      {"Poisson alone (2 Mpx, means 0..100)", -1, med(cpu, "poisson"), med(dev, "poisson"), "kernel poisson"},
      {"sensor chain wall (upload + 3 kernels + download)", -1, med(cpu, "photon") + med(cpu, "sense") + med(cpu, "demosaic"),
       med(dev, "sensor wall (upload, kernels, download)"), "vulkan"},
  };
  // The other demosaic methods (not in the thesis's table; not in the sum).
  for (DemosaicMethod m : kOtherDemosaics) {
    const std::string k = std::string("demosaic ") + to_string(m);
    rows.push_back({"Demosaicing (" + std::string(to_string(m)) + ")", -1, med(cpu, k), med(dev, k),
                    m == DemosaicMethod::Lmmse ? "kernels demosaic_lmmse_* (5 passes)"
                    : m == DemosaicMethod::HamiltonAdams ? "kernels demosaic_ha_green/colour"
                                                         : "kernel demosaic_malvar"});
  }
  // Wall times, uploads and downloads included: the CPU column is the same stages' CPU sum.
  const double tail_cpu = compose_cpu + med(cpu, "photon") + med(cpu, "sense") +
                          med(cpu, "demosaic");
  rows.push_back({"night tail + sensor wall, resident (compose..demosaic)", -1, tail_cpu,
                  med(dev, "tail+sensor resident"),
                  fmt::format("one tail sequence, radiance left on device; {:.1f} MB up, {:.1f} MB down",
                              resident_up_mb, resident_down_mb)});
  rows.push_back({"night tail + sensor wall, round trips (compose..demosaic)", -1, tail_cpu,
                  med(dev, "tail+sensor round trips"),
                  fmt::format("compose, expose each upload/download; {:.1f} MB up, {:.1f} MB down",
                              trips_up_mb, trips_down_mb)});
  rows.push_back({"Linearization (sRGB decode, before the chain)", -1, med(cpu, "linearize"), med(dev, "linearize"),
                  "kernel linearize"});
  // The first row's CPU time is reflectance_texture (night_scene's "darken" lap without darken()).
  rows[0].dev_ms = rows[0].cpu_ms;
  const std::string machine = machine_description();
  std::printf("photosite bench pipeline: %s, %dx%d, %s, %d CPU threads, median of %d\nmachine: %s\nvulkan device: %s\n\n",
              source.c_str(), W, H, cam.name.c_str(), o.threads, o.repeats, machine.c_str(), device.c_str());
  std::printf("%-52s %12s %10s %10s %10s  %s\n", "step (Baek 2020 Table 6)", "thesis 1080Ti", "cpu ms",
              v ? "vulkan ms" : "-", v ? "vk/cpu" : "", "vulkan runs as");
  std::string csv = "step,thesis_gtx1080ti_ms,cpu_ms,vulkan_ms,vulkan_over_cpu,vulkan_runs_as,width,height,threads,vulkan_device,machine\n";
  double total_cpu = 0, total_dev = 0;
  for (size_t i = 0; i < rows.size(); ++i) {
    const Row& row = rows[i];
    const double ratio = v && row.cpu_ms > 0 && row.dev_ms >= 0 ? row.dev_ms / row.cpu_ms : -1;
    if (i <= 11 && i != 7) total_cpu += row.cpu_ms, total_dev += row.dev_ms;
    std::printf("%-52s %12s %10.2f %10s %10s  %s\n", row.step.c_str(),
                row.thesis > 0 ? fmt::format("{:.2f}", row.thesis).c_str() : "",
                row.cpu_ms, v && row.dev_ms >= 0 ? fmt::format("{:.2f}", row.dev_ms).c_str() : "-",
                ratio > 0 ? fmt::format("{:.2f}", ratio).c_str() : "", row.where.c_str());
    csv += fmt::format("\"{}\",{},{:.3f},{},{},\"{}\",{},{},{},\"{}\",\"{}\"\n", row.step,
                       row.thesis > 0 ? fmt::format("{:.2f}", row.thesis) : "", row.cpu_ms,
                       v && row.dev_ms >= 0 ? fmt::format("{:.3f}", row.dev_ms) : "",
                       ratio > 0 ? fmt::format("{:.3f}", ratio) : "", row.where, W, H, o.threads, device, machine);
  }
  std::printf("%-52s %12s %10.2f %10s\n", "sum of the Table 6 steps", "21.79", total_cpu,
              v ? fmt::format("{:.2f}", total_dev).c_str() : "-");
  csv += fmt::format("\"sum of the Table 6 steps\",21.79,{:.3f},{},{},\"\",{},{},{},\"{}\",\"{}\"\n", total_cpu,
                     v ? fmt::format("{:.3f}", total_dev) : "", v ? fmt::format("{:.3f}", total_dev / total_cpu) : "",
                     W, H, o.threads, device, machine);
  const double pois_ms = rows[12].dev_ms > 0 ? rows[12].dev_ms : rows[12].cpu_ms;
  std::string tag = "cpu";
#ifdef PHOTOSITE_HAVE_VULKAN
  if (ctx) tag = ctx->device().cpu ? "lavapipe" : "gpu";
#endif
  // Issue 5's GPU target is judged on a GPU only; a CPU driver (lavapipe) cannot measure it.
  const double dev_gpx = v ? n / (pois_ms * 1e6) : 0;
  const std::string target = tag != "gpu" ? "unmeasured without a GPU" : dev_gpx > 50 ? "met" : "NOT met";
  std::printf("\nPoisson: cpu %.3f Gpx/s%s (GPU target > 50 Gpx/s: %s)\n", n / (rows[12].cpu_ms * 1e6),
              v ? fmt::format(", vulkan {:.3f} Gpx/s (device time)", dev_gpx).c_str() : "", target.c_str());
  write_bench_csv(o.out_dir, "bench_pipeline_" + tag + ".csv", csv);
}
}  // namespace

static BenchRegistrar reg("pipeline",
                          "per-step ms, CPU path and Vulkan backend side by side, thesis Table 6 layout "
                          "(docs/bench_pipeline_<device>.csv)",
                          [](CLI::App* sub) {
                            auto o = std::make_shared<Opts>();
                            sub->add_option("--backend", o->backend, "vulkan (both columns) or cpu (CPU only)")
                                ->capture_default_str();
                            sub->add_option("--preset", o->preset, "camera preset")->capture_default_str();
                            sub->add_option("--repeats", o->repeats, "timed repetitions")->capture_default_str();
                            sub->add_option("--threads", o->threads, "OpenMP/OpenCV threads")->capture_default_str();
                            sub->add_option("--out-dir", o->out_dir, "where the CSV goes (default docs/)");
                            sub->callback([o] { run(*o); });
                          });
}  // namespace photosite::bench
