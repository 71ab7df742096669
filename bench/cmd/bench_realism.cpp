// `photosite bench realism` (issue 14 §4): how close photosite's night previews come to real night
// photos. Runs the night chain (linearize → scene → sensor → preview ISP, the `night` command's
// path without file I/O) on the shared Cityscapes and KITTI frames, for photosite's defaults and a
// few of its options, plus the thesis's own method (photosite::thesis_night) and the day photos
// themselves; writes every result as an sRGB PNG preview to a folder, with a manifest (method,
// frame, file, ms per frame), and hands that to bench/realism.py for the statistics, the charts
// and the classifier two-sample test (bench/realism_stats.py). Results: docs/realism*.csv|png.
#include <omp.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cctype>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include <fmt/format.h>

#include "bench.h"
#include "photosite/error.h"
#include "photosite/io.h"
#include "photosite/night_chain.h"
#include "photosite/scene/night.h"
#include "photosite/sensor/fpn.h"
#include "photosite/sensor/isp.h"
#include "photosite/sensor/pipeline.h"
#include "photosite/sensor/preset.h"
#include "photosite/thesis_baseline.h"

namespace photosite::bench {
namespace {
namespace fs = std::filesystem;

struct Opts {
  std::string shared = std::string(PHOTOSITE_SOURCE_DIR) + "/../shared";
  std::string real;  // default: <shared>/data/night_real
  std::string out_dir, previews;
  int threads = 2, repeats = 1;
  int max_frames = 0;  // per data set; 0: all
  bool no_stats = false;
  int permutations = 0;  // label shuffles for each method's permutation p-value (bench/realism_stats.py)
  std::string methods;  // comma list of the methods to write (empty: all); "photosite" always runs
};

// A photosite variant: a change to the scene preset and the preview's white-point percentile.
struct Variant {
  std::string method;
  std::function<void(scene::ScenePreset&)> scene;
  double white_percentile = 0.99;  // preview_srgb default: the 99th percentile maps to white
  bool full_scale_isp = false;     // preview_full_scale() instead of preview_srgb()
  bool lens_glare = true;          // false: the lens preset's [glare] off (sensor/glare.h)
};

// A camera-ISP preview (preview_camera8, isp.h) of the default variant's sensor frame: the chain
// is not rerun; its ms per frame is the default chain's plus the ISP's own (timed apart).
struct CameraVariant {
  std::string method;
  CameraIspOptions options;
};

// A camera ISP's highlight handling, as dcraw's default (-H 0, "clip"; D. Coffin, dcraw.c): white
// balance gains normalised so the smallest is 1, applied to the DN; every channel clipped at the
// sensor's full scale S; S shown as white (fixed exposure and gain: no rescaling to the scene).
// A pixel saturated in every channel is then white, as in a camera JPEG. preview_srgb() instead
// maps a luminance percentile to white and clips each channel afterwards, so with white at the
// brightest pixel a saturated lamp keeps the tint of the gains (Y' below 0.98).
ImageF preview_full_scale(const ImageF& rgb, std::array<double, 3> wb, double full_scale_dn) {
  const double g_min = std::min({wb[0], wb[1], wb[2]});
  for (double& g : wb) g /= g_min;
  ImageF out(rgb.width(), rgb.height(), 3, uninitialized, "sRGB");
  for (size_t i = 0; i < rgb.pixel_count(); ++i)
    for (int c = 0; c < 3; ++c)
      out[3 * i + c] = static_cast<float>(srgb_encode(std::min(rgb[3 * i + c] * wb[c], full_scale_dn) / full_scale_dn));
  return out;
}

ImageF u8_to_f(const ImageU8& m) {
  ImageF f(m.width(), m.height(), m.channels(), uninitialized);
  for (size_t i = 0; i < f.size(); ++i) f[i] = m[i] / 255.f;
  return f;
}

std::string quote(const std::string& s) {  // single-quoted for /bin/sh
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

void run(const Opts& o) {
  omp_set_num_threads(o.threads);
  if (o.repeats < 1) fail(fmt::format("--repeats {} must be at least 1", o.repeats));
  if (o.max_frames < 0) fail(fmt::format("--max-frames {} must be 0 (all) or more", o.max_frames));
  const fs::path shared(o.shared);
  const std::vector<SharedFrame> frames = shared_frames(shared / "data", o.max_frames, "bench realism");
  const std::string real = o.real.empty() ? (shared / "data" / "night_real").string() : o.real;
  if (!fs::is_directory(real)) fail_at(real, "--real: folder of real night photos not found");
  {
    int photos = 0;
    for (const auto& e : fs::directory_iterator(real)) {
      std::string ext = e.path().extension().string();
      std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
      photos += ext == ".png" || ext == ".jpg" || ext == ".jpeg";
    }
    if (photos < 2)  // the leave-one-out histogram and the spread need at least two
      fail_at(real, fmt::format("--real: {} .png/.jpg photos in this folder, at least 2 needed", photos));
  }

  std::vector<Variant> variants = {
      {"photosite", {}, 0.99},
      // The preview ISP's white point at the 99.9th percentile instead of the 99th: fewer pixels
      // clip, so the saturated-highlight fraction is no longer pinned near 1 %.
      {"photosite white p99.9", {}, 0.999},
      // White at the brightest pixel: where lamps saturate the sensor, the ADC's full scale is
      // white and nothing else is scaled, as a camera with a fixed exposure and gain shows it.
      {"photosite white max", {}, 1.0},
      {"photosite ISP full scale", {}, 1.0, true},
      {"photosite no glare", {}, 0.99, false, false},
      // A darker night: quarter moon and a dark sky (0.01 lx, night-photometry.md §3).
      {"photosite ambient 0.01 lx", [](scene::ScenePreset& sp) { set_ambient_lux(sp, 0.01); }, 0.99},
      // The day's sunlight left in the texture (sun_shade_split off; the bundled presets take it
      // out of the classes whose shade is bluer than the sun's, docs/night.md §1).
      {"photosite no sun-shade split", [](scene::ScenePreset& sp) { sp.sun_shade_ratio_max = 1; }, 0.99},
      // High-pressure sodium street lamps (CIE HP1) instead of the preset's 4000 K LED proxy
      // (`night --streetlamp-type hps`), at the same road luminance class.
      {"photosite hps", [](scene::ScenePreset& sp) { set_streetlamp_type(sp, "hps"); }, 0.99},
  };
  // The camera-ISP previews (`night --preview-isp camera`): its defaults, without the JPEG, with
  // twice the noise-reduction strength, and with in-camera sharpening.
  // The auto-exposure previews (preview_srgb8_auto, isp.h) of the default variant's sensor frame:
  // the AE's gain range the camera preset's (0 to max_gain_db), and TI's ADAS set-up's analog
  // cap of 8x (e2e.ti.com FAQ 1262114) as an automotive AE's narrower range.
  // With highlight protection (at most 1 % of the pixels clip, the old preview rule) the AE is
  // the 99th-percentile preview held inside the camera's gain range, white at full scale / gain.
  struct AeVariant {
    std::string method;
    double max_gain = 0;       // 0: the camera preset's
    double clip_fraction = 0;  // AutoExposure::clip_fraction
  };
  const std::vector<AeVariant> ae_variants = {{"photosite auto exposure", 0, 0},
                                              {"photosite auto exposure max 8x", 8, 0},
                                              {"photosite auto exposure clip 1%", 0, 0.01}};
  std::vector<CameraVariant> camera_variants = {{"photosite camera ISP", {}}};
  camera_variants.push_back({"photosite camera ISP no JPEG", {}});
  camera_variants.back().options.jpeg_quality = 0;
  camera_variants.push_back({"photosite camera ISP NR x2", {}});
  camera_variants.back().options.denoise *= 2;
  camera_variants.back().options.chroma_denoise *= 2;
  camera_variants.push_back({"photosite camera ISP sharpen 0.5", {}});
  camera_variants.back().options.sharpen = 0.5;
  camera_variants.push_back({"photosite camera ISP full scale", {}});  // full_scale_dn set per camera below
  // --methods, read once: the names it lists, each one of the methods above (a misspelt name is
  // an error, not a silent skip); empty: every method.
  std::vector<std::string> chosen;
  if (!o.methods.empty()) {
    std::vector<std::string> known;
    for (const Variant& v : variants) known.push_back(v.method);
    for (const AeVariant& v : ae_variants) known.push_back(v.method);
    known.push_back("photosite awb");
    known.push_back("photosite ccm");
    for (const CameraVariant& v : camera_variants) known.push_back(v.method);
    known.insert(known.end(), {"thesis baseline", "day photo"});
    std::string_view rest = o.methods;
    while (true) {
      const size_t comma = rest.find(',');
      chosen.emplace_back(rest.substr(0, comma));
      if (std::find(known.begin(), known.end(), chosen.back()) == known.end())
        fail(fmt::format("--methods: unknown method '{}'; the methods are: {}", chosen.back(), fmt::join(known, ", ")));
      if (comma == std::string_view::npos) break;
      rest.remove_prefix(comma + 1);
    }
  }
  fs::path prev = o.previews;
  if (prev.empty()) prev = fs::temp_directory_path() / fmt::format("photosite-realism-{}", ::getpid());
  fs::create_directories(prev);
  auto wanted = [&](const std::string& method) {
    return chosen.empty() || std::find(chosen.begin(), chosen.end(), method) != chosen.end();
  };
  std::string manifest = "method,dataset,frame,file,ms_per_frame,width,height\n";
  auto add = [&](const std::string& method, const SharedFrame& f, const fs::path& file, double ms, int w, int h) {
    manifest += fmt::format("\"{}\",{},{},\"{}\",{:.3f},{},{}\n", method, f.dataset, f.name, file.string(), ms, w, h);
  };
  const std::string machine = machine_description();
  std::printf("photosite bench realism: %zu frames, %d threads, best of %d\nmachine: %s\npreviews: %s\n\n",
              frames.size(), o.threads, o.repeats, machine.c_str(), prev.c_str());
  std::printf("%-28s %-34s %10s\n", "method", "frame", "ms/frame");
  for (const SharedFrame& f : frames) {
    ImageFileInfo info;
    const ImageF raw = read_image(f.image, &info);
    const scene::LabelMap lm = scene::read_labels(f.labels, f.instances, raw.width(), raw.height(),
                                                  scene::LabelFormat::Auto, scene::ResizeLabels::None);
    const CameraPreset cam = load_camera_preset(f.camera);
    const LensPreset lens_preset = load_lens_preset(cam.default_lens);
    ExposureSettings es;  // the `night` command's defaults: 20 ms, lens f-number, 0 dB
    const ResolvedExposure ex = resolve(cam, lens_preset, es);
    const FixedPatternMaps fpn = generate_fixed_pattern(cam, raw.width(), raw.height(), cam.name + "-0");
    const auto wb = white_balance_gains(cam);
    const double full_scale_dn = sensor_full_scale_dn(cam, ex);
    const double min_white = preview_min_white(cam, ex, wb);  // as night's previews
    for (const Variant& v : variants) {
      if (v.method != "photosite" && !wanted(v.method)) continue;
      scene::ScenePreset sp = scene::load_scene_preset("night-urban");
      if (v.scene) v.scene(sp);
      sp = scene_for_camera(sp, cam);  // (hps: the camera's metamer of HP1, as the night chain)
      LensPreset lens = lens_preset;
      if (!v.lens_glare) lens.glare.enabled = false;
      ImageF preview;
      SensorOutput so;
      const double ms = best_ms(o.repeats, [&] {
        const ImageF lin = scene::linearize(raw, info);
        const scene::NightScene ns = scene::night_scene(lin, lm, sp, 1);
        const ImageF mean_e = mean_signal_electrons(ns.radiance, cam, lens, ex);
        so = sense(mean_e, cam, ex, es, fpn);
        preview = v.full_scale_isp ? preview_full_scale(so.rgb, wb, full_scale_dn)
                                   : preview_srgb(so.rgb, wb, v.white_percentile, 1.0, min_white);
      });
      if (wanted(v.method)) {
        const fs::path file = prev / fmt::format("{}__{}.png", f.name, v.method);
        write_png(file.string(), preview);
        add(v.method, f, file, ms, raw.width(), raw.height());
        std::printf("%-28s %-34s %10.1f\n", v.method.c_str(), f.name.c_str(), ms);
      }
      if (v.method != "photosite") continue;
      const PreviewNoise noise{ex.system_gain_dn_per_e, cam.read_noise_e};
      // The float preview inside `ms` (replaced by the camera ISP in its methods' ms), and the
      // peer of the camera ISP: the simple ISP as `night --preview` runs it (8-bit codes).
      const double simple_ms = best_ms(o.repeats, [&] { preview = preview_srgb(so.rgb, wb, v.white_percentile, 1.0, min_white); });
      ImageU8 simple8;
      const double simple8_ms =
          best_ms(o.repeats, [&] { simple8 = preview_srgb8(so.rgb, wb, v.white_percentile, 1.0, min_white); });
      std::printf("%-28s %-34s %10.1f  (float preview %.1f ms)\n", "(simple ISP, 8-bit, alone)", f.name.c_str(),
                  simple8_ms, simple_ms);
      for (const AeVariant& av : ae_variants) {
        if (!wanted(av.method)) continue;
        AutoExposure ae = camera_auto_exposure(cam, ex);
        if (av.max_gain > 0) ae.max_gain = std::max(1.0, av.max_gain / ex.gain_linear);
        ae.clip_fraction = av.clip_fraction;
        ImageU8 p8;
        double gain = 0;
        const double ae_ms = best_ms(o.repeats, [&] { p8 = preview_srgb8_auto(so.rgb, wb, full_scale_dn, ae, &gain); });
        const fs::path afile = prev / fmt::format("{}__{}.png", f.name, av.method);
        write_png8(afile.string(), p8);
        add(av.method, f, afile, ms - simple_ms + ae_ms, raw.width(), raw.height());
        std::printf("%-28s %-34s %10.1f  (AE preview alone %.1f ms, gain %.3f = %+.2f dB)\n", av.method.c_str(),
                    f.name.c_str(), ms - simple_ms + ae_ms, ae_ms, gain, 20 * std::log10(gain));
      }
      // The auto-white-balance preview (`night --preview-wb auto`): the simple ISP of the same
      // sensor frame with the gray-world AWB's gains (isp.h auto_white_balance_gains) instead of
      // the preset's, and the white floor of those gains, as preview_image makes it.
      if (wanted("photosite awb")) {
        ImageU8 p8;
        std::array<double, 3> awb{};
        const double awb_ms = best_ms(o.repeats, [&] {
          awb = auto_white_balance_gains(so.rgb, full_scale_dn, camera_awb_bounds(cam), wb);
          p8 = preview_srgb8(so.rgb, awb, v.white_percentile, 1.0, preview_min_white(cam, ex, awb));
        });
        const fs::path afile = prev / fmt::format("{}__photosite awb.png", f.name);
        write_png8(afile.string(), p8);
        add("photosite awb", f, afile, ms - simple_ms + awb_ms, raw.width(), raw.height());
        std::printf("%-28s %-34s %10.1f  (AWB preview alone %.1f ms, gains R %.3f B %.3f, fixed R %.3f B %.3f)\n",
                    "photosite awb", f.name.c_str(), ms - simple_ms + awb_ms, awb_ms, awb[0], awb[2], wb[0], wb[2]);
      }
      // The colour-matrix preview (`night --preview-ccm camera`): the simple ISP of the same sensor
      // frame through the camera's colour correction matrix (isp.h colour_correction_matrix) after
      // the preset's white balance, as preview_image makes it.
      if (wanted("photosite ccm")) {
        ImageU8 p8;
        const double ccm_ms = best_ms(o.repeats, [&] {
          p8 = preview_srgb8(apply_colour_matrix(so.rgb, colour_correction_matrix(cam), wb), wb, v.white_percentile, 1.0,
                             min_white);
        });
        const fs::path cfile = prev / fmt::format("{}__photosite ccm.png", f.name);
        write_png8(cfile.string(), p8);
        add("photosite ccm", f, cfile, ms - simple_ms + ccm_ms, raw.width(), raw.height());
        std::printf("%-28s %-34s %10.1f  (CCM preview alone %.1f ms)\n", "photosite ccm", f.name.c_str(),
                    ms - simple_ms + ccm_ms, ccm_ms);
      }
      for (CameraVariant cv : camera_variants) {
        if (!wanted(cv.method)) continue;
        if (cv.method == "photosite camera ISP full scale") cv.options.full_scale_dn = full_scale_dn;
        cv.options.min_white = min_white;
        ImageU8 p8;
        const double isp_ms = best_ms(o.repeats, [&] { p8 = preview_camera8(so.rgb, wb, noise, cv.options); });
        const fs::path cfile = prev / fmt::format("{}__{}.png", f.name, cv.method);
        write_png8(cfile.string(), p8);
        add(cv.method, f, cfile, ms - simple_ms + isp_ms, raw.width(), raw.height());
        std::printf("%-28s %-34s %10.1f  (ISP alone %.1f ms)\n", cv.method.c_str(), f.name.c_str(),
                    ms - simple_ms + isp_ms, isp_ms);
      }
    }
    // The thesis baseline on the 8-bit day image.
    if (wanted("thesis baseline")) {
      ImageU8 day8(raw.width(), raw.height(), 3, uninitialized);
      for (size_t i = 0; i < raw.pixel_count(); ++i)
        for (int k = 0; k < 3; ++k)
          day8[3 * i + k] = static_cast<uint8_t>(std::lround(255.0 * std::clamp(raw[i * raw.channels() + std::min(k, raw.channels() - 1)], 0.f, 1.f)));
      ThesisBaselineOptions to;
      ImageU8 night8;
      const double ms = best_ms(o.repeats, [&] { night8 = thesis_night(day8, lm.ids, to); });
      fs::path file = prev / fmt::format("{}__thesis baseline.png", f.name);
      write_png(file.string(), u8_to_f(night8));
      add("thesis baseline", f, file, ms, raw.width(), raw.height());
      std::printf("%-28s %-34s %10.1f\n", "thesis baseline", f.name.c_str(), ms);
    }
    // The day photo itself: the classifier's easy case (no translation, 0 ms).
    if (wanted("day photo")) add("day photo", f, fs::path(f.image), 0, raw.width(), raw.height());
  }
  const fs::path manifest_path = prev / "manifest.csv";
  {
    std::ofstream m(manifest_path);
    m << manifest;
    if (!m) fail_at(manifest_path.string(), "cannot write the manifest");
  }
  std::printf("%s\n", manifest_path.c_str());
  if (o.no_stats) return;
  const fs::path out = output_folder(o.out_dir);
  const std::string cmd = fmt::format("/usr/bin/python3 {} --manifest {} --real {} --out-dir {} --machine {} --permutations {}",
                                      quote(std::string(PHOTOSITE_SOURCE_DIR) + "/bench/realism.py"),
                                      quote(manifest_path.string()), quote(real), quote(out.string()),
                                      quote(machine + fmt::format(", {} threads", o.threads)), o.permutations);
  std::fflush(stdout);
  const int rc = std::system(cmd.c_str());
  if (rc != 0) fail(fmt::format("bench realism: bench/realism.py failed (status {}): {}", rc, cmd));
}
}  // namespace

static BenchRegistrar reg("realism",
                          "night previews vs real night photos: statistics, classifier test (docs/realism*)",
                          [](CLI::App* sub) {
                            auto o = std::make_shared<Opts>();
                            sub->add_option("--shared", o->shared, "the shared folder (data/cityscapes, data/kitti)")
                                ->capture_default_str();
                            sub->add_option("--real", o->real, "folder of real night photos (default <shared>/data/night_real)");
                            sub->add_option("--previews", o->previews, "where the previews go (default: a new temp folder)");
                            sub->add_option("--out-dir", o->out_dir, "where CSVs and charts go (default docs/)");
                            sub->add_option("--threads", o->threads, "OpenMP threads")->capture_default_str();
                            sub->add_option("--repeats", o->repeats, "timed runs per frame (best kept)")->capture_default_str();
                            sub->add_option("--max-frames", o->max_frames, "frames per data set (0: all)")->capture_default_str();
                            sub->add_option("--methods", o->methods,
                                            "comma list of methods to write (default: all), e.g. "
                                            "'photosite,photosite auto exposure,thesis baseline,day photo'");
                            sub->add_flag("--no-stats", o->no_stats, "only write the previews and the manifest");
                            sub->add_option("--permutations", o->permutations,
                                            "classifier permutation test: label shuffles per method for its p-value "
                                            "(0: none; each costs one cross-validated classifier run)")
                                ->capture_default_str()
                                ->check(CLI::Range(0, 100000));
                            sub->callback([o] { run(*o); });
                          });
}  // namespace photosite::bench
