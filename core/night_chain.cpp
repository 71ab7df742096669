#include "photosite/night_chain.h"

#include <chrono>
#include <cmath>

#include <fmt/format.h>

#include "photosite/error.h"
#include "photosite/sensor/glare.h"
#include "photosite/sensor/pipeline.h"
#include "photosite/sensor/spectrum.h"
#include "scene/texture_detail.h"

namespace photosite {

namespace {
// prepare_night of a day image given as its floats (`day`) or, for an 8-bit file, as its codes
// (`codes`, when not empty).
NightChain prepare(SensorRunner& runner, ImageF day, ImageU8 codes, const ImageFileInfo& info,
                   scene::LabelMap& labels, const scene::ScenePreset& sp, const SensorSetup& setup,
                   const DeviceStore& store,
                   const std::function<void(const ImageF&, const scene::NightScene&)>& inspect) {
  using clock = std::chrono::steady_clock;
  NightChain c;
  auto t = clock::now();
  auto lap = [&](const char* name) {
    const auto now = clock::now();
    c.timings.push_back({name, std::chrono::duration<double, std::milli>(now - t).count()});
    t = now;
  };
  // The linearisation runs on the CPU on every backend, as `batch`'s does: the scene stages that
  // read its result (the texture, the lanes' luminance) run on the CPU, so on Vulkan the kernel
  // would send the day image up and the linear image back (2 × 24 MB at 2048x1024) for a per-pixel
  // table lookup. It also makes the reflectance texture's class sums (pass 1) from each block while
  // it is in cache (scene::linearize_with_texture_sums): one pass over the 24 MB linear image
  // fewer. An 8-bit file's codes are linearised from the codes themselves (6 MB read instead of
  // their 24 MB of floats). All three give the same bits as the kernel (Gpu.LinearizeBitEqualToCpu).
  // With the preset's sun/shade split on, the same pass also makes the split's block sums (its
  // phase 1) from the Y it computes, for the block rows that lie in one of its chunks (every row
  // of a 2048x1024 frame), so the split does not read the linear image for them.
  // The sky seen through tree crowns is taken for sky before the class sums read the labels
  // (scene::linearize_taking_sky_gaps); the file's ids are back when the scene is made.
  scene::SkyGapsRestore restore(labels);
  scene::TextureSums sums;
  ImageF lin = scene::linearize_taking_sky_gaps(day, &codes, info, labels, &sums, sp);
  c.width = lin.width();
  c.height = lin.height();
  day = ImageF();  // frames are freed as soon as no later stage reads them (peak memory)
  codes = ImageU8();
  lap("linearize");
  c.scene = night_scene_for(runner, lin, labels, sp, setup.settings.seed, static_cast<bool>(inspect), setup, nullptr,
                            &sums);
  sums = scene::TextureSums();  // not held through the sensor stages
  scene::restore_sky_gaps(labels);
  for (auto& st : c.scene.timings) c.timings.push_back(st);
  t = clock::now();
  if (inspect) {
    inspect(lin, c.scene);
    lap("write maps");
  }
  lin = ImageF();
  // The low beam's two full-frame images were read by the light map and the compose (or the
  // device's tail), both inside night_scene; no output and no later stage reads them, so they are
  // not held through the sensor stages (16 MB at 2048x1024: peak memory, docs/robustness.md).
  c.scene.beam_input = ImageF();
  c.scene.beam_lux = ImageF();
  c.exposure = resolve(setup.camera, setup.lens, setup.settings);
  // On Vulkan the radiance is read where the scene tail left it, and the mean signal stays on the
  // device for every frame (the host copies are for the outputs and the CPU path).
  c.mean_e = runner.mean_signal_electrons(c.scene.radiance, setup.camera,
                                          lens_for_frame(setup.lens, setup.camera, c.scene.geometry), c.exposure,
                                          c.scene.resident_radiance, c.scene.glare_level1.get());
  c.mean_e_on_device = runner.resident_mean_e();
  c.scene.glare_level1.reset();  // read by the glare above only (peak memory)
  c.fpn = store.load_or_create(setup.camera, setup.device_id, c.scene.radiance.width(),
                               c.scene.radiance.height());
  lap("sensor: optics, FPN");
  return c;
}
}  // namespace

scene::ScenePreset scene_for_camera(const scene::ScenePreset& sp, const CameraPreset& camera) {
  scene::ScenePreset s = sp;
  for (int i = 0; i < spectrum::kLampSpectrumCount; ++i) {
    const auto ls = static_cast<spectrum::LampSpectrum>(i);
    // HP1 only where the street lamps are hps, CIE LED-B only where they are led: the heads' at
    // lamps.streetlamp_cct_K, their light on the street's at street.cct_K (the two keys keep their
    // meanings; equal in the bundled presets, then the same numbers twice).
    const bool led_b = ls == spectrum::LampSpectrum::LedBHeads || ls == spectrum::LampSpectrum::LedBStreet;
    if (ls == spectrum::LampSpectrum::Hp1 && s.streetlamp_type != scene::StreetlampType::Hps) continue;
    if (led_b && s.streetlamp_type != scene::StreetlampType::Led) continue;
    const double cct = ls == spectrum::LampSpectrum::LedBHeads ? s.streetlamp_cct_K : s.street_cct_K;
    s.lamp_camera_rgb[i] = camera_metamer_rgb(camera, ls, led_b ? cct : 0.0);
  }
  return s;
}

scene::NightScene night_scene_for(SensorRunner& runner, const ImageF& day_linear, const scene::LabelMap& labels,
                                  const scene::ScenePreset& sp, uint64_t seed, bool keep_darkened,
                                  const SensorSetup& setup, scene::SequenceState* sequence,
                                  const scene::TextureSums* sums) {
  // On the CPU runner.night_scene is scene::night_scene itself (core/backend.cpp), and its compose
  // pass also makes the lens glare's level 1 (its 2x2 box) from each row pair while it is in
  // cache, so that the sensor's glare never reads the full-resolution radiance again
  // (NightScene::glare_level1; the same bits).
  const bool glare = lens_glare_plan(setup.camera, setup.lens).active;
  return scene::night_scene(day_linear, labels, scene_for_camera(sp, setup.camera), seed, keep_darkened, runner,
                            sequence, sums, glare);
}

LensPreset lens_for_frame(const LensPreset& lens, const CameraPreset& camera, const scene::CameraGeometry& g) {
  if (!(g.f_px > 0) || !std::isfinite(g.f_px)) internal_error("lens_for_frame: the geometry has no focal length");
  LensPreset l = lens;
  l.focal_length_mm = g.f_px * camera.pixel_pitch_um * 1e-3;
  return l;
}

NightChain prepare_night(SensorRunner& runner, ImageF day, const ImageFileInfo& info,
                         scene::LabelMap& labels, const scene::ScenePreset& sp,
                         const SensorSetup& setup, const DeviceStore& store,
                         const std::function<void(const ImageF&, const scene::NightScene&)>& inspect) {
  return prepare(runner, std::move(day), ImageU8(), info, labels, sp, setup, store, inspect);
}

NightChain prepare_night(SensorRunner& runner, ImageU8 day_codes, const ImageFileInfo& info,
                         scene::LabelMap& labels, const scene::ScenePreset& sp,
                         const SensorSetup& setup, const DeviceStore& store,
                         const std::function<void(const ImageF&, const scene::NightScene&)>& inspect) {
  if (day_codes.empty()) fail("prepare_night: no day image codes");
  return prepare(runner, ImageF(), std::move(day_codes), info, labels, sp, setup, store, inspect);
}

NightChain prepare_night(SensorRunner& runner, ImageF day, const ImageFileInfo& info,
                         const scene::LabelMap& labels, const scene::ScenePreset& sp,
                         const SensorSetup& setup, const DeviceStore& store,
                         const std::function<void(const ImageF&, const scene::NightScene&)>& inspect) {
  scene::LabelMap own = labels;
  return prepare_night(runner, std::move(day), info, own, sp, setup, store, inspect);
}

NightChain prepare_night(SensorRunner& runner, ImageU8 day_codes, const ImageFileInfo& info,
                         const scene::LabelMap& labels, const scene::ScenePreset& sp,
                         const SensorSetup& setup, const DeviceStore& store,
                         const std::function<void(const ImageF&, const scene::NightScene&)>& inspect) {
  scene::LabelMap own = labels;
  return prepare_night(runner, std::move(day_codes), info, own, sp, setup, store, inspect);
}

void set_ambient_lux(scene::ScenePreset& sp, double lux) {
  if (!(lux >= 0 && lux <= 10)) fail_parameter("ambient_lux", "", fmt::format(" {} must be in [0, 10] lx", lux));
  // Keep the preset's moon/sky-glow proportions, rescaled to the requested total.
  const double sum = sp.moon_lux + sp.skyglow_lux;
  if (sum > 0) {
    sp.moon_lux *= lux / sum;
    sp.skyglow_lux *= lux / sum;
  } else {
    sp.moon_lux = lux;
  }
}

void set_streetlamp_type(scene::ScenePreset& sp, const std::string& name) {
  try {
    sp.streetlamp_type = scene::parse_streetlamp_type(name);
  } catch (const Error&) {
    fail_parameter("streetlamp_type", "", fmt::format(" '{}' is not one of {}", name, scene::kStreetlampTypeNames));
  }
}

SensorOutput night_frame(SensorRunner& runner, const NightChain& c, const SensorSetup& setup, uint32_t frame) {
  ExposureSettings s = setup.settings;
  s.frame = frame;
  return runner.sense(c.mean_e, setup.camera, c.exposure, s, c.fpn, c.mean_e_on_device);
}

namespace {
// The float of every code of type T (all 2^bits of them), in code order, made on first use:
// code · (1/max code) in float, OpenImageIO's conversion, which every reader of the library
// (core/io.cpp to_float) and the data sets' files read through it have used
// (tests/sensor_test.cpp compares the table with OpenImageIO's own convert_pixel_values).
template <class T>
const float* code_table() {
  static const std::vector<float> table = [] {
    constexpr size_t n = size_t{1} << (8 * sizeof(T));
    constexpr float scale = 1.f / static_cast<float>(n - 1);
    std::vector<float> t(n);
    for (size_t i = 0; i < n; ++i) t[i] = static_cast<float>(i) * scale;
    return t;
  }();
  return table.data();
}
// The floats of n codes, from their table.
template <class T>
void codes_row(const T* c, size_t n, const float* table, float* o) {
  for (size_t i = 0; i < n; ++i) o[i] = table[c[i]];
}
}  // namespace

ImageF image_from_codes(const void* codes, int bits, int width, int height, int channels) {
  if (bits != 8 && bits != 16) internal_error("image_from_codes: bits must be 8 or 16");
  ImageF img(width, height, channels, uninitialized);
  // Every code's float (code_table) made once per bit depth for all 256 or 65,536 codes and read
  // per sample: converting one value at a time (OpenImageIO's convert_pixel_values, before)
  // took about 2 ns each (12 ms of `ps.night`'s own time for a 2048x1024 frame, perf,
  // 2026-11-28).
  const float* table = bits == 8 ? code_table<uint8_t>() : code_table<uint16_t>();
  const size_t row = static_cast<size_t>(width) * channels;
#pragma omp parallel for schedule(static)
  for (int y = 0; y < height; ++y) {
    if (bits == 8) codes_row(static_cast<const uint8_t*>(codes) + y * row, row, table, img.row(y));
    else codes_row(static_cast<const uint16_t*>(codes) + y * row, row, table, img.row(y));
  }
  return img;
}

}  // namespace photosite
