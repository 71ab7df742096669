// What the sensor commands write: the EXR layers (channel groups) and the header attributes of
// `expose`/`flat` (sensor outputs) and of `night`/`batch` (night frames). A library module so
// that every face — the command line, the batch engine, the Python module — writes the same
// layout from the same code.
#pragma once
#include <map>
#include <string>
#include <vector>

#include "photosite/io.h"
#include "photosite/scene/night.h"
#include "photosite/sensor/fpn.h"
#include "photosite/sensor/isp.h"
#include "photosite/sensor/pipeline.h"
#include "photosite/sensor/preset.h"

namespace photosite {

// The resolved identity of a sensor run: camera, lens, settings and the device whose
// fixed-pattern maps were used. Recorded in every output's header.
struct SensorSetup {
  CameraPreset camera;
  LensPreset lens;
  ExposureSettings settings;
  std::string device_id;
};

// ---- layers -----------------------------------------------------------------------------------
// The layers a command can write, as bits of a LayerSet: sensor (R,G,B), raw (raw.Y), electrons
// (electrons.Y), radiance (radiance.R/G/B for expose, night_radiance.R/G/B for night/batch),
// lights (lights.R/G/B), depth (depth.Z), labels (labels.Y).
enum class Layer : unsigned { Sensor = 1, Raw = 2, Electrons = 4, Radiance = 8, Lights = 16, Depth = 32, Labels = 64 };
using LayerSet = unsigned;
constexpr bool has(LayerSet s, Layer l) { return (s & static_cast<unsigned>(l)) != 0; }
// What each command can write (and writes by default): expose the sensor layers and its input
// radiance; night and batch every layer.
constexpr LayerSet kExposeLayers = 1 | 2 | 4 | 8;
constexpr LayerSet kNightLayers = 127;
// batch's default: what a training set needs (sensor, raw, electrons, depth, labels) without the
// two float32 radiance layers (6 of 13 channels, most of the bytes and the write time:
// docs/benchmarks.md, "batch").
constexpr LayerSet kBatchLayers = 1 | 2 | 4 | 32 | 64;
// What batch's PNG route writes, whatever --layers says: the sensor's preview and the label copies
// (sensor, labels).
constexpr LayerSet kPngRouteLayers = 1 | 64;
// Parses a comma list of layer names ("sensor,labels"). Bad input (naming `what`, e.g. the flag)
// for an unknown name, a layer outside `applicable` (named with `command`), or an empty list.
LayerSet parse_layers(const std::string& list, LayerSet applicable, const std::string& what,
                      const std::string& command);
// The canonical comma list of a set, in the order above (recorded in batch manifests).
std::string layers_text(LayerSet s);

// The header attributes every sensor output carries ("photosite/..."): version, preset, lens,
// device and its fixed-pattern checksum, seed, frame, the resolved exposure, CFA, bit depth,
// black level and demosaic method.
std::map<std::string, ExrAttribute> sensor_attributes(const SensorSetup& setup,
                                                      const ResolvedExposure& ex,
                                                      const FixedPatternMaps& fpn);
// The channel groups of a sensor output: raw.Y, R,G,B, electrons.Y.
std::vector<ExrChannelGroup> sensor_channels(const SensorOutput& out, LayerSet layers = kExposeLayers);

// ---- night frames (`night`, `batch`) ----------------------------------------------------------
struct NightInputs {
  std::string image, labels, instances;
  // A note on the day image, written as photosite/night/image_note when not empty: its negative
  // samples, clipped to 0 (day_image_note).
  std::string image_note;
  // What the reader noted of the day image's file (ImageFileInfo::note: an OpenEXR window, a
  // JPEG's Exif orientation), written as photosite/night/image_file_note when not empty.
  std::string image_file_note;
};

// A linear day image's negative samples (a float EXR or a float32 array; integer files cannot
// hold any), which the linearisation clips to 0 (scene::linearize): "N of M pixels have negative
// values, clipped to 0; the most negative -v (B at pixel (x, y))", or empty when there are none
// (the header names the image beside it, the console note puts its path first). Real scene-referred EXRs carry small negatives, from a colour transform into
// sRGB's primaries (colours outside its gamut) or from black-level subtraction of a dark frame's
// noise, so they are taken; the note says how much was clipped, for a user to judge whether the
// image was what they meant (a whole frame below zero is no photo). Only the R, G, B samples the
// linearisation reads count (a grey image's one, not an alpha channel).
std::string day_image_note(const ImageF& day, const ImageFileInfo& info);

// Channel groups: the sensor's (raw.Y, R,G,B, electrons.Y), night_radiance.R/G/B, depth.Z,
// lights.R/G/B, labels.Y (the class ids written from their 16-bit samples to a UINT channel).
// `out`, `ns` and `labels` must outlive the returned groups. Only the layers in `layers`.
std::vector<ExrChannelGroup> night_channels(const SensorOutput& out, const scene::NightScene& ns,
                                            const scene::LabelMap& labels, LayerSet layers = kNightLayers);
// The label ids as a one-channel image (unit label_id) for the labels.Y layer.
ImageF label_image(const scene::LabelMap& labels);

// Header: the sensor attributes, every scene parameter, the inputs, the vanishing point (with
// confidence, method and fallback note) and the light counts.
std::map<std::string, ExrAttribute> night_attributes(const SensorSetup& setup,
                                                     const ResolvedExposure& ex,
                                                     const FixedPatternMaps& fpn,
                                                     const scene::ScenePreset& sp,
                                                     const scene::NightScene& ns,
                                                     const scene::LabelMap& labels,
                                                     const NightInputs& in);

// The 8-bit sRGB preview that `expose` and `night` write beside the EXR (never part of it):
// the simple ISP (preview_srgb8: white balance, the 99th percentile of luminance as white, sRGB;
// that white at least preview_min_white(), no more gain than the camera could add)
// or the camera ISP (preview_camera8: noise reduction from the sensor's own noise model,
// sharpening and a JPEG round trip, an approximation of a generic in-camera ISP; docs/realism.md).
// Either ISP white-balances with the camera preset's fixed gains (white_balance_gains, the default)
// or with an auto white balance of the frame itself (auto_white_balance_gains inside
// camera_awb_bounds, as a consumer camera's AWB; docs/realism.md).
enum class PreviewIsp { Simple, Camera };
enum class PreviewWb { Fixed, Auto };
// Either ISP shows the camera's RGB as linear sRGB (None, the default) or first maps it through the
// camera's colour correction matrix (Camera: colour_correction_matrix, sensor/isp.h).
enum class PreviewCcm { None, Camera };
struct PreviewOptions {
  PreviewIsp isp = PreviewIsp::Simple;
  CameraIspOptions camera;  // read with PreviewIsp::Camera
  PreviewWb wb = PreviewWb::Fixed;
  PreviewCcm ccm = PreviewCcm::None;
};
// "simple" or "camera"; anything else throws a ParameterError for the parameter "preview_isp".
PreviewIsp parse_preview_isp(const std::string& name);
// "fixed" or "auto"; anything else throws a ParameterError for the parameter "preview_wb".
PreviewWb parse_preview_wb(const std::string& name);
// "none" or "camera"; anything else throws a ParameterError for the parameter "preview_ccm".
PreviewCcm parse_preview_ccm(const std::string& name);
// The white-balance gains a preview of this frame uses: the preset's, or with PreviewWb::Auto the
// AWB's (metered below 0.95 of the exposure's full scale, bounded by camera_awb_bounds, the
// preset's where the frame has no signal).
std::array<double, 3> preview_wb_gains(const ImageF& rgb, const CameraPreset& camera, const ResolvedExposure& exposure,
                                       PreviewWb wb);
// Bad input when the preview cannot be made for a width x height frame (the camera ISP's JPEG round
// trip beyond JPEG's size limit): checked before a run writes anything.
void check_preview_frame(const PreviewOptions& o, int width, int height);
// Bad input when the preview cannot be made with this camera (PreviewCcm::Camera on a camera with
// no colour matrix: ParameterError "preview_ccm"): checked before a run writes anything.
void check_preview_camera(const PreviewOptions& o, const CameraPreset& camera);
// The preview of one exposure: preview_wb_gains' white balance, with PreviewCcm::Camera the
// camera's colour matrix after it (apply_colour_matrix), and for the camera ISP the
// exposure's system gain and the preset's read noise (the noise model its denoise is scaled to).
ImageU8 preview_image(const SensorOutput& out, const SensorSetup& setup, const ResolvedExposure& exposure,
                      const PreviewOptions& options = {});

}  // namespace photosite
