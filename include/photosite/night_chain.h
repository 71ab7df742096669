// The `night` chain as one library call: a decoded day image and its labels in, the night scene
// and the camera's frames of it out, on a chosen backend. The command line (`photosite night`,
// `demo`) and the Python module (`photosite.night`) both call it, so they give the same numbers.
#pragma once
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "photosite/backend.h"
#include "photosite/io.h"
#include "photosite/outputs.h"
#include "photosite/scene/labels.h"
#include "photosite/scene/night.h"
#include "photosite/scene/scene_preset.h"
#include "photosite/sensor/fpn.h"
#include "photosite/sensor/pipeline.h"

namespace photosite {

// Everything the frames of one night scene share: the scene, the resolved exposure, the device's
// fixed-pattern maps and the mean signal (left on the device on Vulkan for a run of frames).
struct NightChain {
  scene::NightScene scene;
  ResolvedExposure exposure;
  FixedPatternMaps fpn;
  ImageF mean_e;                  // mean signal, e- per pixel
  DeviceImage mean_e_on_device;  // SensorRunner::resident_mean_e() of mean_e
  int width = 0, height = 0;
  // "linearize", the scene stages, "write maps" (with `inspect`) and "sensor: optics, FPN".
  std::vector<scene::StageTiming> timings;
};

// day: read_image()'s samples with their file info (integer files as code / max code, sRGB
// encoded; float files linear); consumed, freed as soon as no later stage reads it.
// inspect: when given, called with the linear day image and the scene (with its darkened map)
// before the sensor stages — the command line's --maps.
// labels: the scene's stages see the sky through tree crowns as sky (scene::take_sky_gaps);
// labels.ids is the file's again when it returns (or throws).
NightChain prepare_night(SensorRunner& runner, ImageF day, const ImageFileInfo& info,
                         scene::LabelMap& labels, const scene::ScenePreset& sp,
                         const SensorSetup& setup, const DeviceStore& store,
                         const std::function<void(const ImageF&, const scene::NightScene&)>& inspect = {});

// The same from an 8-bit sRGB file's codes (interleaved, as read_image_codes8 gives them): on the
// CPU linearised from the codes (a quarter of the bytes of their floats), the same scene to the
// bit as prepare_night of read_image()'s floats of the same file.
NightChain prepare_night(SensorRunner& runner, ImageU8 day_codes, const ImageFileInfo& info,
                         scene::LabelMap& labels, const scene::ScenePreset& sp,
                         const SensorSetup& setup, const DeviceStore& store,
                         const std::function<void(const ImageF&, const scene::NightScene&)>& inspect = {});
// The same for labels the caller cannot lend (a copy of them takes the sky gaps).
NightChain prepare_night(SensorRunner& runner, ImageF day, const ImageFileInfo& info,
                         const scene::LabelMap& labels, const scene::ScenePreset& sp,
                         const SensorSetup& setup, const DeviceStore& store,
                         const std::function<void(const ImageF&, const scene::NightScene&)>& inspect = {});
NightChain prepare_night(SensorRunner& runner, ImageU8 day_codes, const ImageFileInfo& info,
                         const scene::LabelMap& labels, const scene::ScenePreset& sp,
                         const SensorSetup& setup, const DeviceStore& store,
                         const std::function<void(const ImageF&, const scene::NightScene&)>& inspect = {});
// The scene of a day image for the sensor `setup` on `runner`: night_scene(..., runner) with,
// on the CPU and where setup's lens has a glare (plan_glare active), the glare's level 1 made in
// the compose pass (NightScene::glare_level1, for mean_signal_electrons / expose). What
// prepare_night and `batch` both run. `seed`: the scene's seed (batch: the group's).
// The scene preset as the run's camera needs it (ScenePreset::lamp_camera_rgb): the camera's
// metamers of the traffic signals' and rear lamps' LEDs and, with streetlamp_type hps, of CIE HP1.
scene::ScenePreset scene_for_camera(const scene::ScenePreset& sp, const CameraPreset& camera);
scene::NightScene night_scene_for(SensorRunner& runner, const ImageF& day_linear, const scene::LabelMap& labels,
                                  const scene::ScenePreset& sp, uint64_t seed, bool keep_darkened,
                                  const SensorSetup& setup, scene::SequenceState* sequence = nullptr,
                                  const scene::TextureSums* sums = nullptr);

// The lens as a day frame is imaged through it: the frame's field angles are those of the camera
// that took it, whose focal length in pixels at this image size the rig gives (g.f_px), so the
// optics' cos⁴ falloff and the glare's pixels per degree use f = f_px · pixel pitch in place of
// the lens preset's nominal focal length (KITTI's rectified frames: 721.5 px · 4.65 µm = 3.36 mm
// against the nominal 4 mm lens; Cityscapes: 2262.5 px · 2.2 µm = 4.98 mm, the preset's own).
// Everything else (f-number, transmittance, glare shape) is the preset's.
LensPreset lens_for_frame(const LensPreset& lens, const CameraPreset& camera, const scene::CameraGeometry& g);

// A plain 8-bit RGB PNG's codes with its file info (the info read_image() gives), else nothing
// (any other file: read_image() then).
std::optional<ImageU8> read_image_codes8(const std::string& path, ImageFileInfo* info);
// A day image file as the chain takes it (`night`, `batch`): a plain 8-bit RGB PNG's codes
// (read_image_codes8: linearised directly, a quarter of the bytes), else read_image()'s floats.
struct DayImage {
  std::optional<ImageU8> codes;
  ImageF floats;  // empty when `codes` holds the image
  int width() const { return codes ? codes->width() : floats.width(); }
  int height() const { return codes ? codes->height() : floats.height(); }
};
DayImage read_day_image(const std::string& path, ImageFileInfo* info);

// Sets the night ambient illuminance (moon + sky glow) to `lux` in [0, 10] lx, keeping the
// preset's moon/sky-glow proportions; bad input naming `what` outside that range.
void set_ambient_lux(scene::ScenePreset& sp, double lux);  // ParameterError "ambient_lux" outside [0, 10]
// Sets the street lamps' type (scene preset key lamps.streetlamp_type) by its name, "led" or "hps";
// ParameterError "streetlamp_type" for any other name.
void set_streetlamp_type(scene::ScenePreset& sp, const std::string& name);

// One frame of the camera (noise drawn for setup.settings.seed and `frame`).
SensorOutput night_frame(SensorRunner& runner, const NightChain& chain, const SensorSetup& setup,
                         uint32_t frame);

// Integer codes (8- or 16-bit, interleaved) as read_image() returns them from a file: the same
// conversion (OpenImageIO's), so an array and the PNG it came from give the same floats.
ImageF image_from_codes(const void* codes, int bits, int width, int height, int channels);

}  // namespace photosite
