// _photosite: the Python face of the photosite library (pybind11). Every function here converts
// arguments, calls the same library functions the command line calls (photosite/night_chain.h,
// backend.h, outputs.h, characterize.h, io.h) and wraps the results; no stage is written twice.
//
// Conventions:
//  - Arrays in are C-contiguous, H x W (one channel) or H x W x C, of the dtypes each function
//    names; anything else is a ValueError naming the argument. Integer images are codes, read as
//    code / max code exactly as the command line reads an 8/16-bit file (OpenImageIO's conversion).
//  - The library's Image owns its samples, so an input array is copied once into it (memcpy or
//    the code conversion); outputs are the library's own buffers, moved into a capsule that the
//    returned NumPy array owns (no copy out).
//  - The GIL is released for every computation, so Python threads run concurrently.
//  - photosite::Error of kind BadInput becomes ValueError with the library's message, missing
//    files FileNotFoundError, internal errors RuntimeError.
#include <omp.h>
#include <nlohmann/json.hpp>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>
#include <optional>

#include <OpenEXR/ImfThreading.h>
#include <Imath/half.h>
#include <fmt/format.h>

#include "photosite/environment.h"
#include "photosite/backend.h"
#include "photosite/characterize.h"
#include "photosite/error.h"
#include "photosite/frame_buffers.h"
#include "photosite/io.h"
#include "photosite/night_chain.h"
#include "photosite/outputs.h"
#include "photosite/scene/chart.h"
#include "photosite/scene/rig.h"
#include "photosite/scene/scene_preset.h"
#include "photosite/sensor/demosaic.h"
#include "photosite/sensor/isp.h"
#include "photosite/sensor/preset.h"

namespace py = pybind11;
using namespace photosite;

namespace {

// A missing input file: MissingFileError, FileNotFoundError in Python.
void require_file(const std::string& path, const std::string& what) {
  if (!std::filesystem::exists(path)) fail_missing(path, what + " not found");
}

// ---- arrays in ----------------------------------------------------------------------------
struct ArrayShape {
  int height = 0, width = 0, channels = 1;
};

// Checks C-contiguity, dimensions (2 or 3) and allowed channel counts; `what` names the argument.
// The sizes are checked as NumPy's 64-bit values before they become int: a side of 2^31 or more
// is refused, never truncated.
// A sensor frame (the default) is at least 2x2, one CFA tile (check_frame_size); with frame = false
// any image of at least 1x1 (check_image_size: write_exr's layers).
ArrayShape check_image_array(const py::array& a, const std::string& what, std::initializer_list<int> channels,
                             bool frame = true) {
  if (!(a.flags() & py::array::c_style))
    fail(what + ": the array must be C-contiguous (use numpy.ascontiguousarray)");
  if (a.ndim() != 2 && a.ndim() != 3)
    fail(fmt::format("{}: expected an H x W or H x W x C array, got {} dimensions", what, a.ndim()));
  const int64_t h = a.shape(0), w = a.shape(1), nc = a.ndim() == 3 ? a.shape(2) : 1;
  bool ok = false;
  for (int c : channels) ok |= c == nc;
  if (!ok) {
    std::string list;
    for (int c : channels) list += (list.empty() ? "" : " or ") + std::to_string(c);
    fail(fmt::format("{}: expected {} channel(s), got {}", what, list, nc));
  }
  constexpr int64_t kMaxSide = std::numeric_limits<int>::max();
  if (w > kMaxSide || h > kMaxSide)
    fail(fmt::format("{}: frame size too large: {}x{} (a side of 2^31 pixels or more)", what, w, h));
  if (frame) check_frame_size(what, w, h);
  else check_image_size(what, w, h);
  ArrayShape s;
  s.height = static_cast<int>(h);
  s.width = static_cast<int>(w);
  s.channels = static_cast<int>(nc);
  return s;
}

// An integer argument (a Python int, bool or NumPy integer: anything with __index__) in
// [lo, hi], checked at any size; a TypeError or ValueError naming the argument otherwise
// (pybind11's own casters answer with the whole signature, or wrap a negative value).
template <class T>
T int_arg(const py::handle& v, const char* name, T lo = std::numeric_limits<T>::min(),
          T hi = std::numeric_limits<T>::max()) {
  if (PyFloat_Check(v.ptr()) || !PyIndex_Check(v.ptr()))
    throw py::type_error(fmt::format("{}: expected an int, got {}", name, Py_TYPE(v.ptr())->tp_name));
  const auto i = py::reinterpret_steal<py::object>(PyNumber_Index(v.ptr()));
  if (!i) throw py::error_already_set();
  if (i < py::int_(lo) || i > py::int_(hi))
    fail(fmt::format("{} {} must be in [{}, {}]", name, py::str(i).cast<std::string>(), lo, hi));
  return i.cast<T>();
}

std::string dtype_name(const py::array& a) { return py::str(a.dtype()).cast<std::string>(); }

// device_store: None is the default store (PHOTOSITE_DEVICE_STORE, XDG, home); an empty string is
// refused, as the command line refuses --device-store "" (an unset variable, e.g.
// os.environ.get("STORE", ""), would otherwise put the maps in the home store unasked).
std::string checked_store(const std::optional<std::string>& device_store) {
  if (device_store && device_store->empty())
    fail("device_store: an empty folder name is not a device store (None: the default store)");
  return device_store.value_or("");
}

bool is_dtype(const py::array& a, const py::dtype& d) { return a.dtype().is(d) || a.dtype().equal(d); }

// A float32 array as an ImageF (one copy); NaN or infinity is bad input naming the pixel.
ImageF float_image(const py::array& a, const std::string& what, const ArrayShape& s, bool finite = true) {
  ImageF img(s.width, s.height, s.channels, uninitialized);
  std::memcpy(img.data(), a.data(), img.size() * sizeof(float));
  if (finite)
    for (size_t i = 0; i < img.size(); ++i)
      if (!std::isfinite(img[i])) {
        const size_t p = i / s.channels;
        fail(fmt::format("{}: sample {} at pixel ({}, {}) is not finite", what, img[i], p % s.width, p / s.width));
      }
  return img;
}

// Integer codes as ImageU16 (labels, instance ids).
// n codes from an array's buffer into a fresh image, converted to Dst, in blocks over the threads:
// the destination's first touch (its page faults) and the copy shared by the cores, as the
// chain's own passes are. Each element is written once from its own source: any thread count,
// the same bytes.
template <class Src, class Dst>
void copy_codes(const Src* src, Dst* dst, size_t n) {
  constexpr int64_t kBlock = 1 << 16;
  const int64_t blocks = (static_cast<int64_t>(n) + kBlock - 1) / kBlock;
#pragma omp parallel for schedule(static)
  for (int64_t b = 0; b < blocks; ++b) {
    const size_t i0 = static_cast<size_t>(b) * kBlock, i1 = std::min(n, i0 + kBlock);
    std::copy(src + i0, src + i1, dst + i0);
  }
}

ImageU16 code_image(const py::array& a, const std::string& what, const ArrayShape& s) {
  ImageU16 img(s.width, s.height, s.channels, uninitialized);
  if (is_dtype(a, py::dtype::of<uint16_t>()))
    copy_codes(static_cast<const uint16_t*>(a.data()), img.data(), img.size());
  else if (is_dtype(a, py::dtype::of<uint8_t>()))
    copy_codes(static_cast<const uint8_t*>(a.data()), img.data(), img.size());
  else
    fail(what + ": expected dtype uint8 or uint16 (label codes), got " + dtype_name(a));
  return img;
}

// ---- arrays out ---------------------------------------------------------------------------
// The image's buffer, owned by the returned array (the Image is moved into the capsule).
template <class T>
py::array_t<T> to_array(Image<T>&& img) {
  auto* owner = new Image<T>(std::move(img));
  py::capsule cap(owner, [](void* p) { delete static_cast<Image<T>*>(p); });
  std::vector<py::ssize_t> shape = {owner->height(), owner->width()};
  if (owner->channels() > 1) shape.push_back(owner->channels());
  return py::array_t<T>(shape, owner->data(), cap);
}

// Integer-valued DN (0..2^bit_depth-1) as uint16 for cameras of up to 16 bits, else uint32 (the
// schema allows 24): the codes of the CLI's UINT raw.Y, never wrapped.
template <class T>
py::array_t<T> codes_as(const ImageF& raw_dn) {
  Image<T> r(raw_dn.width(), raw_dn.height(), 1, uninitialized, unit::dn);
  const int64_t n = static_cast<int64_t>(r.size());
#pragma omp parallel for schedule(static)
  for (int64_t i = 0; i < n; ++i) r[i] = static_cast<T>(raw_dn[i]);
  return to_array(std::move(r));
}
py::array raw_codes(const ImageF& raw_dn, int bit_depth) {
  if (bit_depth <= 16) return codes_as<uint16_t>(raw_dn);
  return codes_as<uint32_t>(raw_dn);
}

py::dict attributes_dict(const std::map<std::string, ExrAttribute>& attrs) {
  py::dict d;
  for (const auto& [k, v] : attrs) {
    const std::string key = k.rfind("photosite/", 0) == 0 ? k.substr(10) : k;
    std::visit([&](const auto& x) { d[py::str(key)] = x; }, v);
  }
  return d;
}

py::object json_to_python(const nlohmann::json& j) {
  return py::module_::import("json").attr("loads")(j.dump());
}

// ---- results ------------------------------------------------------------------------------
struct SensorResult {
  py::array raw;                  // DN, CFA mosaic with black level: uint16 (<= 16 bits) or uint32
  py::array_t<float> rgb;         // DN above black, demosaiced
  py::array_t<float> electrons;   // e-
  py::dict metadata;
  std::array<double, 3> wb_gains{1, 1, 1};
  PreviewNoise noise;  // the camera-ISP preview's noise model: system gain and read noise
  double min_white = 0;  // the previews' white floor (preview_min_white: no more gain than the camera's)
  // For wb="auto" (`night --preview-wb auto`, the library's preview_wb_gains): the camera and the exposure.
  CameraPreset camera;
  ResolvedExposure exposure;
};

SensorResult wrap_sensor(SensorOutput&& out, std::map<std::string, ExrAttribute> attrs, const CameraPreset& cam,
                         const ResolvedExposure& exposure) {
  SensorResult r;
  r.raw = raw_codes(out.raw_dn, cam.bit_depth);
  out.raw_dn = ImageF();
  r.rgb = to_array(std::move(out.rgb));
  r.electrons = to_array(std::move(out.electrons));
  r.metadata = attributes_dict(attrs);
  r.wb_gains = white_balance_gains(cam);
  if (auto it = attrs.find("photosite/system_gain_dn_per_e"); it != attrs.end())
    if (const double* k = std::get_if<double>(&it->second)) r.noise.gain_dn_per_e = *k;
  r.noise.read_noise_e = cam.read_noise_e;
  r.min_white = preview_min_white(cam, exposure, r.wb_gains);
  r.camera = cam;
  r.exposure = exposure;
  return r;
}

// The sRGB preview (photosite/sensor/isp.h) as uint8, rounded as a PNG preview is: the simple
// ISP, or with isp="camera" the camera-ISP preview (`night --preview-isp camera`); wb="fixed" the
// preset's white balance, "auto" the AWB of the frame (`night --preview-wb auto`).
// jpeg_quality: a Python int, range-checked at any size (0: no JPEG round trip, else 1-100).
py::array_t<uint8_t> preview_u8(const SensorResult& s, const std::string& isp, double denoise,
                                const py::object& jpeg_quality_arg, const std::string& wb_name, const std::string& ccm) {
  if (isp != "simple" && isp != "camera") throw Error("isp: '" + isp + "' is not simple or camera");
  if (wb_name != "fixed" && wb_name != "auto") throw Error("wb: '" + wb_name + "' is not fixed or auto");
  if (ccm != "none" && ccm != "camera") throw Error("ccm: '" + ccm + "' is not none or camera");
  const int jpeg_quality = int_arg<int>(jpeg_quality_arg, "jpeg_quality", 0, 100);
  const auto rgb = s.rgb;
  ImageF in(static_cast<int>(rgb.shape(1)), static_cast<int>(rgb.shape(0)), 3, uninitialized);
  std::memcpy(in.data(), rgb.data(), in.size() * sizeof(float));
  std::array<double, 3> wb = s.wb_gains;
  double min_white = s.min_white;
  if (wb_name == "auto") {
    wb = preview_wb_gains(in, s.camera, s.exposure, PreviewWb::Auto);
    min_white = preview_min_white(s.camera, s.exposure, wb);
  }
  if (ccm == "camera") {  // `night --preview-ccm camera`: the camera's colour matrix after the white balance
    ColourMatrix C;
    try {
      C = colour_correction_matrix(s.camera);
    } catch (const ParameterError& e) {
      throw Error(e.message_for("ccm"));
    }
    in = apply_colour_matrix(in, C, wb);
  }
  ImageU8 out(in.width(), in.height(), 3, uninitialized);
  if (isp == "camera") {
    CameraIspOptions o;
    o.denoise = denoise;
    o.chroma_denoise = 2 * denoise;  // isp.h's default ratio, as the command line
    o.jpeg_quality = jpeg_quality;
    o.min_white = min_white;
    try {
      check_camera_isp_frame(o, in.width(), in.height());  // the options, and JPEG's 65500 px a side
    } catch (const ParameterError& e) {  // the keyword's name: denoise, jpeg_quality
      std::string kw = e.parameter();
      if (kw.rfind("preview_", 0) == 0) kw = kw.substr(8);
      throw Error(e.message_for(kw));
    }
    py::gil_scoped_release nogil;
    out = preview_camera8(in, wb, s.noise, o);
  } else {
    py::gil_scoped_release nogil;
    // The command's own 8-bit encoder (preview_srgb8, as preview_image), not preview_srgb's floats
    // rounded here: those agree on every code only where no sample lies within a float rounding of
    // a decision level, which the colour matrix's outputs did not always keep (3 codes of 1.36 M).
    out = preview_srgb8(in, wb, 0.99, 1.0, min_white);
  }
  return to_array(std::move(out));
}

struct NightResult {
  py::array_t<float> radiance, lights, depth;
  py::array_t<uint16_t> labels;
  py::tuple vanishing_point;
  SensorResult sensor;
  // The library chain's own time: labels_from_codes, make_backend, prepare_night, night_frame,
  // night_attributes and releasing the intermediates (for `photosite bench python`).
  double chain_ms = 0;
};

// ---- the camera ---------------------------------------------------------------------------
struct Camera {
  SensorSetup setup;
  DeviceStore store;

  Camera(const std::string& preset, std::optional<std::string> lens, std::optional<std::string> device_id,
         std::optional<std::string> device_store)
      : store(checked_store(device_store)) {
    // A Camera runs frame after frame: its device's maps are read and verified once, then kept
    // (DeviceStore::keep_loaded; about 24 MB at 2048x1024).
    store.keep_loaded(true);
    setup.camera = load_camera_preset(preset);
    const std::string lens_name = lens.value_or(setup.camera.default_lens);
    if (lens_name.empty()) fail("camera preset " + setup.camera.file + " names no default_lens; pass lens=");
    setup.lens = load_lens_preset(lens_name);
    setup.device_id = device_id.value_or(setup.camera.name + "-0");
    // The id names its maps' file: checked here (path_for checks it), not at the first expose.
    (void)store.path_for(setup.camera, setup.device_id, 2, 2);
  }

  // The settings of one call, validated before any work (as the CLI's SensorOptions::resolve).
  // seed and frame: Python ints, range-checked here (uint64, uint32).
  SensorSetup with(double exposure_s, std::optional<double> f_number, double gain_db,
                   std::optional<double> temperature_c, const py::object& seed, const py::object& frame,
                   const std::string& demosaic, const std::string& poisson) const {
    SensorSetup s = setup;
    s.settings.exposure_s = exposure_s;
    s.settings.f_number = f_number;
    s.settings.gain_db = gain_db;
    s.settings.temperature_c = temperature_c;
    s.settings.seed = int_arg<uint64_t>(seed, "seed");
    // [0, 2^31 - 1]: the outputs' header keeps the frame as OpenEXR's (signed 32-bit) int attribute,
    // so a larger one would be recorded negative (and a result not reproducible from its header).
    s.settings.frame = int_arg<uint32_t>(frame, "frame", 0, static_cast<uint32_t>(std::numeric_limits<int32_t>::max()));
    s.settings.demosaic = parse_demosaic_method(demosaic);
    s.settings.poisson = parse_poisson_method(poisson);
    photosite::resolve(s.camera, s.lens, s.settings);
    return s;
  }

  SensorResult expose(const py::array& radiance, double exposure_s, std::optional<double> f_number, double gain_db,
                      std::optional<double> temperature_c, const py::object& seed, const py::object& frame,
                      const std::string& demosaic, const std::string& backend, const std::string& poisson) const {
    if (!is_dtype(radiance, py::dtype::of<float>()))
      fail("radiance: expected dtype float32 (W.sr-1.m-2, linear), got " + dtype_name(radiance));
    const ArrayShape shape = check_image_array(radiance, "radiance", {1, 3});
    const SensorSetup s = with(exposure_s, f_number, gain_db, temperature_c, seed, frame, demosaic, poisson);
    SensorOutput out;
    ResolvedExposure ex;
    FixedPatternMaps fpn;
    {
      py::gil_scoped_release nogil;
      ImageF rad = float_image(radiance, "radiance", shape);
      if (rad.channels() == 1) {  // grey radiance: equal band radiance in R, G, B (as `expose`)
        ImageF rgb(rad.width(), rad.height(), 3, uninitialized);
        for (size_t i = 0; i < rad.pixel_count(); ++i) rgb[3 * i] = rgb[3 * i + 1] = rgb[3 * i + 2] = rad[i];
        rad = std::move(rgb);
      }
      rad.set_unit(unit::radiance);
      SensorRunner runner = make_backend(backend, &s.camera);
      ex = photosite::resolve(s.camera, s.lens, s.settings);
      ImageF mean_e;
      try {
        mean_e = runner.mean_signal_electrons(rad, s.camera, s.lens, ex);
      } catch (const Error& e) {
        fail(std::string("radiance: ") + e.what());
      }
      fpn = store.load_or_create(s.camera, s.device_id, rad.width(), rad.height());
      out = runner.sense(mean_e, s.camera, ex, s.settings, fpn);
    }
    return wrap_sensor(std::move(out), sensor_attributes(s, ex, fpn), s.camera, ex);
  }
};

NightResult night(const py::array& day_rgb, const py::array& labels, const std::optional<py::array>& instances,
                  const Camera& camera, const std::string& scene_preset, double exposure_s,
                  std::optional<double> f_number, double gain_db, std::optional<double> temperature_c,
                  const py::object& seed, const py::object& frame, const std::string& demosaic,
                  const std::string& backend, const std::string& label_format, std::optional<double> ambient_lux,
                  const std::string& resize_labels, const std::string& rig, const std::string& poisson,
                  const std::optional<std::string>& streetlamp_type) {
  // H x W (grey) or H x W x 3, as `night --image` takes a grey or an RGB file.
  const ArrayShape ds = check_image_array(day_rgb, "day_rgb", {1, 3});
  const bool day_float = is_dtype(day_rgb, py::dtype::of<float>());
  const bool day_u8 = is_dtype(day_rgb, py::dtype::of<uint8_t>());
  const bool day_u16 = is_dtype(day_rgb, py::dtype::of<uint16_t>());
  if (!day_float && !day_u8 && !day_u16)
    fail("day_rgb: expected dtype uint8 or uint16 (sRGB codes) or float32 (linear), got " + dtype_name(day_rgb));
  const ArrayShape ls = check_image_array(labels, "labels", {1, 3});
  ArrayShape is;
  if (instances) is = check_image_array(*instances, "instances", {1});
  // Codes are copied with the GIL held: the dtype checks need it and the copy is small.
  ImageU16 label_codes = code_image(labels, "labels", ls);
  ImageU16 instance_codes = instances ? code_image(*instances, "instances", is) : ImageU16();
  const auto fmt_label = scene::parse_label_format(label_format);
  scene::ResizeLabels resize;
  if (resize_labels == "none") resize = scene::ResizeLabels::None;
  else if (resize_labels == "nearest") resize = scene::ResizeLabels::Nearest;
  else fail("resize_labels: '" + resize_labels + "' is not none or nearest");
  scene::ScenePreset sp = scene::load_scene_preset(scene_preset);
  if (ambient_lux) set_ambient_lux(sp, *ambient_lux);
  if (streetlamp_type) set_streetlamp_type(sp, *streetlamp_type);
  // As `night --rig`: "auto" picks by aspect ratio (an array has no data-set path to find a
  // Cityscapes camera file by; pass the file itself).
  sp.rig = scene::resolve_camera_rig(rig, ds.width, ds.height);
  SensorSetup s = camera.with(exposure_s, f_number, gain_db, temperature_c, seed, frame, demosaic, poisson);

  NightResult r;
  std::optional<NightChain> chain;
  std::optional<SensorOutput> out;
  scene::LabelMap lm;
  std::map<std::string, ExrAttribute> attrs;
  {
    py::gil_scoped_release nogil;
    ImageFileInfo info;
    info.path = "day_rgb";
    info.format = "array";
    info.width = ds.width;
    info.height = ds.height;
    info.channels = ds.channels;
    info.is_float = day_float;
    info.bits_per_sample = day_float ? 32 : day_u8 ? 8 : 16;
    info.srgb_encoded = !day_float;
    // RGB uint8 codes go to the chain as codes (linearised directly, as `night` takes an 8-bit
    // RGB PNG: the same bits as their floats); grey or uint16 codes and float32 as floats, as
    // `night` reads any other file (read_day_image).
    const bool as_codes = day_u8 && ds.channels == 3;
    ImageU8 codes;
    if (as_codes) {
      codes = ImageU8(ds.width, ds.height, 3, uninitialized);
      copy_codes(static_cast<const uint8_t*>(day_rgb.data()), codes.data(), codes.size());
    }
    ImageF day = day_float ? float_image(day_rgb, "day_rgb", ds)
                 : as_codes ? ImageF()
                            : image_from_codes(day_rgb.data(), info.bits_per_sample, ds.width, ds.height, ds.channels);
    const std::string image_note = day_float ? day_image_note(day, info) : std::string();
    const auto t0 = std::chrono::steady_clock::now();
    lm = scene::labels_from_codes(std::move(label_codes), instances ? &instance_codes : nullptr, ds.width, ds.height,
                                  fmt_label, resize, "labels", "instances");
    SensorRunner runner = make_backend(backend, &s.camera);
    chain.emplace(as_codes ? prepare_night(runner, std::move(codes), info, lm, sp, s, camera.store)
                         : prepare_night(runner, std::move(day), info, lm, sp, s, camera.store));
    out.emplace(night_frame(runner, *chain, s, s.settings.frame));
    attrs = night_attributes(s, chain->exposure, chain->fpn, sp, chain->scene, lm,
                             {"<array day_rgb>", "<array labels>", instances ? "<array instances>" : "", image_note});
    // The intermediates no output keeps are released here, as a C++ caller's scope would.
    chain->mean_e = ImageF();
    chain->fpn = FixedPatternMaps();
    chain->scene.darkened = ImageF();
    r.chain_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  }
  scene::NightScene& ns = chain->scene;
  r.vanishing_point = py::make_tuple(ns.vp.x, ns.vp.y, ns.vp.confidence, scene::vp_method_name(ns.vp.method));
  r.radiance = to_array(std::move(ns.radiance));
  r.lights = to_array(std::move(ns.lights));
  r.depth = to_array(std::move(ns.depth));
  r.labels = to_array(std::move(lm.ids));
  r.sensor = wrap_sensor(std::move(*out), std::move(attrs), s.camera, chain->exposure);
  return r;
}

py::array_t<float> demosaic_array(const py::array& mosaic, const std::string& cfa, const std::string& method,
                                  const std::string& backend, std::optional<double> white_level) {
  const ArrayShape ms = check_image_array(mosaic, "mosaic", {1});
  const bool f32 = is_dtype(mosaic, py::dtype::of<float>());
  const bool u8 = is_dtype(mosaic, py::dtype::of<uint8_t>()), u16 = is_dtype(mosaic, py::dtype::of<uint16_t>());
  if (!f32 && !u8 && !u16)
    fail("mosaic: expected dtype float32 (any unit) or uint8/uint16 (codes, read as code / max code), got " +
         dtype_name(mosaic));
  const CfaPattern pattern = parse_cfa(cfa);
  const DemosaicMethod m = parse_demosaic_method(method);
  // white_level: in the array's values (codes for uint8/uint16), as the command's --white-level.
  if (white_level) {
    if (!is_clear_pattern(pattern))
      throw Error(fmt::format("white_level: clip handling is for the clear patterns RCCB and RCCC, not {}", to_string(pattern)));
    if (!(*white_level > 0) || !std::isfinite(*white_level))
      throw Error(fmt::format("white_level: {} is not a level above 0", *white_level));
  }
  ImageF rgb;
  {
    py::gil_scoped_release nogil;
    ImageF img = f32 ? float_image(mosaic, "mosaic", ms)
                     : image_from_codes(mosaic.data(), u8 ? 8 : 16, ms.width, ms.height, 1);
    SensorRunner runner = make_backend(backend);
    rgb = runner.demosaic(img, pattern, m);
    if (white_level)
      neutralize_at_white_level(rgb, img, pattern, *white_level, 0.0, f32 ? 1.0 : 1.0 / (u8 ? 255.0 : 65535.0), !f32);
  }
  return to_array(std::move(rgb));
}

py::dict characterize_py(const py::object& camera, std::optional<std::string> lens, std::optional<std::string> device_id,
                         std::optional<std::string> device_store, std::optional<double> exposure_s, double gain_db,
                         const py::object& seed, const py::object& roi_arg, double wavelength_nm,
                         const std::string& backend, std::optional<double> temperature_c,
                         const std::string& poisson) {
  std::optional<Camera> own;
  const Camera* cam = nullptr;
  if (py::isinstance<py::str>(camera)) {
    own.emplace(camera.cast<std::string>(), lens, device_id, device_store);
    cam = &*own;
  } else if (py::isinstance<Camera>(camera)) {
    cam = &camera.cast<const Camera&>();
  } else {
    throw py::type_error(fmt::format("camera: expected a Camera or a camera preset name (str), got {}",
                                     Py_TYPE(camera.ptr())->tp_name));
  }
  const int roi = int_arg<int>(roi_arg, "roi", 16, 4096);  // the library's range (characterize.h)
  const SensorSetup s =
      // None: emva::Plan's 1 ms, the command's default (characterize.h).
      cam->with(exposure_s.value_or(emva::Plan{}.exposure_s), std::nullopt, gain_db, temperature_c, seed, py::int_(0),
                "bilinear", poisson);
  nlohmann::json j;
  {
    py::gil_scoped_release nogil;
    SensorRunner runner = make_backend(backend, &s.camera);
    j = nlohmann::json::parse(to_json(characterize(s, cam->store, runner, roi, wavelength_nm)));
  }
  return json_to_python(j);
}

// ---- EXR ----------------------------------------------------------------------------------
py::tuple read_exr_py(const std::string& path) {
  require_file(path, "EXR file");
  ExrContents c;
  {
    py::gil_scoped_release nogil;
    c = read_exr(path);
  }
  py::dict channels, attrs, types;
  for (auto& [name, img] : c.channels) channels[py::str(name)] = to_array(std::move(img));
  for (const auto& [k, v] : c.attributes) attrs[py::str(k)] = v;
  for (const auto& [k, v] : c.pixel_types) types[py::str(k)] = to_string(v);
  return py::make_tuple(channels, attrs, types);
}

// Why `name` cannot be a write_exr attribute (empty: it can). OpenEXR keeps names of at most 255
// bytes (Imf::Name cuts longer ones short), and the header's own attributes are reserved: the
// required ones, those of multi-part, tiled and multi-view files, and what the library's
// write_exr sets (capDate, dwaCompressionLevel, photosite/unit/<channel>).
std::string exr_attribute_name_problem(const std::string& name) {
  static const char* const reserved[] = {"channels", "compression", "dataWindow", "displayWindow", "lineOrder",
                                         "pixelAspectRatio", "screenWindowCenter", "screenWindowWidth", "tiles",
                                         "name", "type", "version", "chunkCount", "view", "capDate",
                                         "dwaCompressionLevel"};
  if (name.empty()) return "an attribute name cannot be empty";
  if (name.size() > 255) return fmt::format("a name of {} bytes, more than OpenEXR's 255", name.size());
  for (const char* r : reserved)
    if (name == r) return "reserved: the EXR header sets this attribute itself";
  if (name.rfind("photosite/unit/", 0) == 0) return "reserved: write_exr sets photosite/unit/<channel> itself";
  return {};
}

// Every check is made before the file is opened, so bad input leaves no file; each names the
// layer or attribute (`layers['b']`, `attributes['k']`).
void write_exr_py(const std::string& path, const py::dict& layers, const py::dict& attributes, bool half,
                  bool overwrite) {
  check_output_path(path, overwrite);
  if (layers.empty()) fail("layers: no layers (give at least one name -> array)");
  std::vector<ImageF> images;
  images.reserve(layers.size());
  std::vector<ExrChannelGroup> groups;
  std::map<std::string, std::string> channel_layer;  // channel name -> the layer that made it
  std::vector<std::string> layer_names;              // groups[i]'s layer
  std::string first_layer;
  ArrayShape first;
  for (const auto& [k, v] : layers) {
    if (!py::isinstance<py::str>(k))
      throw Error(fmt::format("layers[{}]: a layer name must be a str, got {}", py::repr(k).cast<std::string>(),
                              Py_TYPE(k.ptr())->tp_name));
    const std::string name = k.cast<std::string>();
    const std::string what = "layers['" + name + "']";
    if (!py::isinstance<py::array>(v)) fail(what + ": expected a NumPy array");
    const py::array a = v.cast<py::array>();
    const ArrayShape s = check_image_array(a, what, {1, 2, 3, 4}, /*frame=*/false);
    if (groups.empty()) {
      first_layer = name;
      first = s;
    } else if (s.width != first.width || s.height != first.height) {
      fail(fmt::format("{}: {}x{} pixels, but layers['{}'] is {}x{} (every layer must have the same size)", what,
                       s.width, s.height, first_layer, first.width, first.height));
    }
    if (name.empty() && s.channels == 1)
      fail(what + ": the name \"\" is for an H x W x 3 or 4 layer (channels R, G, B, A); name a one-channel layer");
    ExrChannelGroup g;
    static const char* rgba[] = {"R", "G", "B", "A"};
    if (s.channels == 1) g.channel_names = {name};
    else
      for (int c = 0; c < s.channels; ++c)
        g.channel_names.push_back(name.empty() ? rgba[c] : name + "." + (s.channels >= 3 ? rgba[c] : std::to_string(c)));
    for (const auto& n : g.channel_names) {
      // OpenEXR keeps names of at most 255 bytes (Imf::Name), cutting longer ones short.
      if (n.size() > 255) fail(fmt::format("{}: channel name of {} bytes, more than OpenEXR's 255", what, n.size()));
      const auto [it, fresh] = channel_layer.emplace(n, name);
      if (!fresh)
        fail(fmt::format("{}: channel '{}' is also made by layers['{}'] (each channel once)", what, n, it->second));
    }
    if (is_dtype(a, py::dtype::of<float>())) {
      images.push_back(float_image(a, what, s, false));
    } else if (is_dtype(a, py::dtype("float16"))) {
      const ImageF f(s.width, s.height, s.channels, uninitialized);
      images.push_back(f);
      const Imath::half* hv = static_cast<const Imath::half*>(a.data());
      float* fv = images.back().data();
      for (size_t i = 0; i < f.size(); ++i) fv[i] = static_cast<float>(hv[i]);  // exact
      g.pixel = ExrPixel::Half;
    } else if (is_dtype(a, py::dtype::of<uint8_t>()) || is_dtype(a, py::dtype::of<uint16_t>()) ||
               is_dtype(a, py::dtype::of<uint32_t>())) {
      // UINT channels: exact integers (the library stores them through float, exact below 2^24,
      // and refuses larger ones rather than rounding).
      ImageF f(s.width, s.height, s.channels, uninitialized);
      const size_t n = f.size();
      if (is_dtype(a, py::dtype::of<uint8_t>())) std::copy_n(static_cast<const uint8_t*>(a.data()), n, f.data());
      else if (is_dtype(a, py::dtype::of<uint16_t>())) std::copy_n(static_cast<const uint16_t*>(a.data()), n, f.data());
      else {
        const auto* p = static_cast<const uint32_t*>(a.data());
        for (size_t i = 0; i < n; ++i) {
          if (p[i] > (1u << 24)) fail(what + ": uint32 value above 2^24 cannot be stored exactly");
          f[i] = static_cast<float>(p[i]);
        }
      }
      images.push_back(std::move(f));
      g.pixel = ExrPixel::Uint;
    } else {
      fail(what + ": expected dtype float32, float16 or uint8/16/32, got " + dtype_name(a));
    }
    groups.push_back(std::move(g));
    layer_names.push_back(name);
  }
  for (size_t i = 0; i < groups.size(); ++i) groups[i].image = &images[i];
  // The float layers hold finite values only, and with half=True values that a half can hold:
  // photosite's EXR layers are physical quantities with units (radiance, electrons, metres), where
  // NaN or infinity is a bug upstream, and a file that carries one poisons every mean, filter and
  // loss that reads it later, far from its cause. The first bad sample in reading order is named
  // with its channel and pixel, before the file is opened. (OpenEXR's half rounds to nearest even:
  // values of magnitude 65520 and above become infinity, 65504 is the largest finite.)
  for (size_t gi = 0; gi < groups.size(); ++gi) {
    const ExrChannelGroup& g = groups[gi];
    if (g.pixel == ExrPixel::Uint) continue;
    const bool to_half = g.pixel == ExrPixel::Half || half;
    const ImageF& f = images[gi];
    const int c = f.channels();
    for (size_t i = 0; i < f.size(); ++i) {
      const float v = f[i];
      const bool overflows = to_half && std::isfinite(v) && !std::isfinite(static_cast<float>(Imath::half(v)));
      if (std::isfinite(v) && !overflows) continue;
      const size_t p = i / c;
      fail(fmt::format("layers['{}']: channel {} is {} at pixel ({}, {}){}; nothing was written", layer_names[gi],
                       g.channel_names[i % c], v, p % f.width(), p / f.width(),
                       overflows ? ", beyond a half's largest value 65504 (write it with half=False)"
                                 : ": NaN and infinity are not values of a physical quantity (fix it upstream)"));
    }
  }
  std::map<std::string, ExrAttribute> attrs;
  for (const auto& [k, v] : attributes) {
    if (!py::isinstance<py::str>(k))
      throw Error(fmt::format("attributes[{}]: an attribute name must be a str, got {}",
                              py::repr(k).cast<std::string>(), Py_TYPE(k.ptr())->tp_name));
    const std::string key = k.cast<std::string>();
    const std::string what = "attributes['" + key + "']";
    if (const std::string why = exr_attribute_name_problem(key); !why.empty()) fail(what + ": " + why);
    if (py::isinstance<py::bool_>(v)) attrs[key] = static_cast<int>(v.cast<bool>());
    else if (py::isinstance<py::int_>(v)) {  // an EXR int attribute is 32-bit
      constexpr int lo = std::numeric_limits<int>::min(), hi = std::numeric_limits<int>::max();
      if (v < py::int_(lo) || v > py::int_(hi))
        fail(fmt::format("{}: {} is outside an EXR int attribute's range [{}, {}] (pass a float or str)", what,
                         py::str(v).cast<std::string>(), lo, hi));
      attrs[key] = v.cast<int>();
    }
    else if (py::isinstance<py::float_>(v)) attrs[key] = v.cast<double>();
    else if (py::isinstance<py::str>(v)) attrs[key] = v.cast<std::string>();
    else fail(what + ": expected str, int or float");
  }
  // A float attribute x is also written as the text x_text (write_exr): that name is taken.
  for (const auto& [key, v] : attrs)
    if (std::holds_alternative<double>(v) && attrs.count(key + "_text"))
      fail(fmt::format("attributes['{}_text']: write_exr writes that name itself, the text copy of the float "
                       "attributes['{}']", key, key));
  ExrWriteOptions wo;
  wo.half = half;
  py::gil_scoped_release nogil;
  write_exr(path, groups, attrs, wo);
}


// OpenEXR's global thread pool is not fork-safe: a forked child (a DataLoader worker) inherits
// the pool's bookkeeping but not its threads, and its first EXR read (the device store's
// fixed-pattern maps) waits on them for ever. The package's os.register_at_fork hooks stop the
// pool before a fork, so the child reads EXRs in the calling thread, and restart it in the parent.
int exr_threads_before_fork = -1;
void before_fork() {
  exr_threads_before_fork = Imf::globalThreadCount();
  if (exr_threads_before_fork > 0) Imf::setGlobalThreadCount(0);
}
void after_fork_in_parent() {
  if (exr_threads_before_fork > 0) Imf::setGlobalThreadCount(exr_threads_before_fork);
}
// GNU OpenMP's thread team does not survive fork() either: a child's first parallel region with
// more than one thread waits for the parent's workers, which it does not have. The child runs its
// OpenMP regions on one thread (as torch's DataLoader workers do); the results do not depend on
// the thread count. The Vulkan device a parent opened is refused in the child
// (gpu::shared_context), whose `auto` runs the CPU path.
void after_fork_in_child() { omp_set_num_threads(1); }

}  // namespace

PYBIND11_MODULE(_photosite, m) {
  m.doc() = "photosite's C++ library (the extension under the photosite package)";
  // OMP_NUM_THREADS beyond kMaxOpenmpThreads crashed the interpreter at the first parallel loop
  // (include/photosite/environment.h): refused here, an ImportError with the message.
  check_openmp_threads();
  m.def("_before_fork", &before_fork);
  m.def("_after_fork_in_parent", &after_fork_in_parent);
  m.def("_after_fork_in_child", &after_fork_in_child);

  // A frame loop in Python would otherwise page-fault every frame's buffers in afresh (glibc
  // returns freed ones to the kernel; the module must not change the host process's malloc
  // settings): the library keeps its own freed frame buffers, freeing the sizes a loop no longer
  // asks for (the stale rule), up to 1 GiB or a quarter of the machine's memory if less
  // (include/photosite/frame_buffers.h, docs/python.md).
  set_frame_buffer_cache_free_stale(true);
  set_frame_buffer_cache_limit(std::min(kFrameBufferDefaultLimit, frame_buffer_cache_machine_limit()));
  m.def("frame_buffer_cache", [](const py::object& limit_bytes, const py::object& free_stale) {
    if (!limit_bytes.is_none()) {
      if (PyIndex_Check(limit_bytes.ptr()) && !PyFloat_Check(limit_bytes.ptr()) && limit_bytes < py::int_(0))
        throw Error(fmt::format("frame_buffer_cache: limit_bytes is {}: must be 0 or more",
                                py::str(limit_bytes).cast<std::string>()));
      set_frame_buffer_cache_limit(static_cast<size_t>(int_arg<int64_t>(limit_bytes, "limit_bytes", 0)));
    }
    if (!free_stale.is_none()) {
      if (!PyBool_Check(free_stale.ptr()))
        throw py::type_error(fmt::format("free_stale: expected a bool or None, got {}", Py_TYPE(free_stale.ptr())->tp_name));
      set_frame_buffer_cache_free_stale(free_stale.cast<bool>());
    }
    const FrameBufferCacheStats s = frame_buffer_cache_stats();
    py::dict d;
    d["limit_bytes"] = s.limit_bytes;
    d["held_bytes"] = s.held_bytes;
    d["held_buffers"] = s.held_buffers;
    d["reused"] = s.reused;
    d["allocated"] = s.allocated;
    d["free_stale"] = s.free_stale;
    d["stale_after_requests"] = s.stale_after_requests;
    d["in_use_bytes"] = s.in_use_bytes;
    d["peak_bytes"] = s.peak_bytes;
    return d;
  }, py::arg("limit_bytes") = py::none(), py::arg("free_stale") = py::none());

  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const MissingFileError& e) {
      PyErr_SetString(PyExc_FileNotFoundError, e.what());
    } catch (const Error& e) {
      if (e.kind() == Error::Kind::BadInput) {
        PyErr_SetString(PyExc_ValueError, e.what());
      } else {
        PyErr_SetString(PyExc_RuntimeError, e.what());
      }
    }
  });

  py::class_<SensorResult>(m, "SensorResult")
      .def_readonly("raw", &SensorResult::raw, "uint16 H x W (uint32 for cameras of more than 16 bits): raw DN mosaic (with black level)")
      .def_readonly("rgb", &SensorResult::rgb, "float32 H x W x 3: demosaiced DN above black")
      .def_readonly("electrons", &SensorResult::electrons, "float32 H x W: collected e- per pixel")
      .def_readonly("metadata", &SensorResult::metadata, "dict: the command's photosite/ header attributes without the prefix, less the *_text copies, "
                    "unit/<channel> and radiance_file; floats in full, seed a str (docs/python.md)")
      .def("preview", &preview_u8, py::arg("isp") = "simple", py::arg("denoise") = 1.0, py::arg("jpeg_quality") = py::int_(90),
           py::arg("wb") = "fixed", py::arg("ccm") = "none",
           "uint8 H x W x 3 sRGB preview: isp='simple' (white balance, p99 exposure, sRGB) or 'camera' (+ noise "
           "reduction of strength `denoise` from the sensor's noise model and a JPEG round trip at `jpeg_quality`, 0: "
           "none; docs/realism.md); wb='fixed' (the camera preset's gains) or 'auto' (gray-world AWB of the frame "
           "within the camera's 2000-10000 K black-body gains, `night --preview-wb auto`); ccm='none' (camera RGB shown as "
           "sRGB) or 'camera' (the camera's colour correction matrix, `night --preview-ccm camera`)");

  py::class_<NightResult>(m, "NightResult")
      .def_readonly("radiance", &NightResult::radiance, "float32 H x W x 3: night scene radiance, W.sr-1.m-2")
      .def_readonly("lights", &NightResult::lights, "float32 H x W x 3: artificial light radiance, W.sr-1.m-2")
      .def_readonly("depth", &NightResult::depth, "float32 H x W: metres along the optical axis (sky 65504, the largest half), from the rig")
      .def_readonly("labels", &NightResult::labels, "uint16 H x W: Cityscapes labelIds")
      .def_readonly("vanishing_point", &NightResult::vanishing_point, "(x px, y px, confidence 0..1, method)")
      .def_readonly("sensor", &NightResult::sensor, "SensorResult: the camera's frame of the night scene")
      .def_readonly("chain_ms", &NightResult::chain_ms, "ms spent in the library chain (labels .. sensor)")
      .def("preview", [](const NightResult& r, const std::string& isp, double denoise, const py::object& jpeg_quality,
                         const std::string& wb, const std::string& ccm) {
             return preview_u8(r.sensor, isp, denoise, jpeg_quality, wb, ccm);
           },
           py::arg("isp") = "simple", py::arg("denoise") = 1.0, py::arg("jpeg_quality") = py::int_(90), py::arg("wb") = "fixed",
           py::arg("ccm") = "none",
           "uint8 H x W x 3 sRGB preview of the sensor frame (isp, denoise, jpeg_quality, wb, ccm: as SensorResult.preview)");

  py::class_<Camera>(m, "Camera")
      .def(py::init<const std::string&, std::optional<std::string>, std::optional<std::string>,
                    std::optional<std::string>>(),
           py::arg("preset"), py::arg("lens") = py::none(), py::arg("device_id") = py::none(),
           py::arg("device_store") = py::none())
      .def_property_readonly("preset", [](const Camera& c) { return c.setup.camera.name; }, "str: the camera preset's name (file stem)")
      .def_property_readonly("lens", [](const Camera& c) { return c.setup.lens.name; }, "str: the lens preset's name")
      .def_property_readonly("device_id", [](const Camera& c) { return c.setup.device_id; }, "str: the device identity of the fixed-pattern maps")
      .def_property_readonly("device_store", [](const Camera& c) { return c.store.dir(); }, "str: the folder of the device's fixed-pattern maps, absolute (a relative device_store, or "
                             "PHOTOSITE_DEVICE_STORE, is taken against the working folder when the Camera is made)")
      .def_property_readonly("width_px", [](const Camera& c) { return c.setup.camera.width_px; }, "int: the sensor's native active width, px")
      .def_property_readonly("height_px", [](const Camera& c) { return c.setup.camera.height_px; }, "int: the sensor's native active height, px")
      .def_property_readonly("bit_depth", [](const Camera& c) { return c.setup.camera.bit_depth; }, "int: the ADC's bits")
      .def_property_readonly("cfa", [](const Camera& c) { return std::string(to_string(c.setup.camera.cfa)); },
                             "str: the colour filter array (RGGB, GRBG, ..., RCCB, RCCC, MONO)")
      .def("expose", &Camera::expose, py::arg("radiance"), py::arg("exposure_s") = 0.02,
           py::arg("f_number") = py::none(), py::arg("gain_db") = 0.0, py::arg("temperature_c") = py::none(),
           py::arg("seed") = 0, py::arg("frame") = 0, py::arg("demosaic") = "bilinear", py::arg("backend") = "auto",
           py::arg("poisson") = "exact");

  m.def("night", &night, py::arg("day_rgb"), py::arg("labels"), py::arg("instances") = py::none(),
        py::arg("camera"), py::arg("scene_preset") = "night-urban", py::arg("exposure_s") = 0.02,
        py::arg("f_number") = py::none(), py::arg("gain_db") = 0.0, py::arg("temperature_c") = py::none(),
        py::arg("seed") = 0, py::arg("frame") = 0, py::arg("demosaic") = "bilinear", py::arg("backend") = "auto",
        py::arg("label_format") = "auto", py::arg("ambient_lux") = py::none(), py::arg("resize_labels") = "none",
        py::arg("rig") = "auto", py::arg("poisson") = "exact", py::arg("streetlamp_type") = py::none());
  m.def("demosaic", &demosaic_array, py::arg("mosaic"), py::arg("cfa") = "RGGB", py::arg("method") = "bilinear",
        py::arg("backend") = "auto", py::arg("white_level") = py::none());
  m.def("characterize", &characterize_py, py::arg("camera"), py::arg("lens") = py::none(),
        py::arg("device_id") = py::none(), py::arg("device_store") = py::none(), py::arg("exposure_s") = py::none(),
        py::arg("gain_db") = 0.0, py::arg("seed") = 0, py::arg("roi") = 256, py::arg("wavelength_nm") = 525.0,
        py::arg("backend") = "auto", py::arg("temperature_c") = py::none(), py::arg("poisson") = "exact");
  m.def("chart", [](const py::object& width_arg, const py::object& height_arg, double illuminance_lux, double cct_k, double lamp_cd_m2,
                    double background_cd_m2) {
    scene::ChartOptions o;
    o.width = int_arg<int>(width_arg, "width");
    o.height = int_arg<int>(height_arg, "height");
    o.illuminance_lux = illuminance_lux;
    o.cct_k = cct_k;
    o.lamp_cd_m2 = lamp_cd_m2;
    o.background_cd_m2 = background_cd_m2;
    ImageF img;
    {
      py::gil_scoped_release nogil;
      img = scene::render_chart(o);
    }
    return to_array(std::move(img));
  }, py::arg("width") = 640, py::arg("height") = 480, py::arg("illuminance_lux") = 10.0, py::arg("cct_k") = 3000.0,
        py::arg("lamp_cd_m2") = 2e4, py::arg("background_cd_m2") = 0.005);
  m.def("read_exr", &read_exr_py, py::arg("path"));
  m.def("write_exr", &write_exr_py, py::arg("path"), py::arg("layers"), py::arg("attributes") = py::dict(),
        py::arg("half") = false, py::arg("overwrite") = false);
  m.def("preset_names", [](const std::string& kind) {
    std::vector<std::string> names;
    for (const auto& e : list_presets())  // a folder or a link to nothing named x.toml is no preset
      if (e.kind == kind && e.preset_file) names.push_back(e.name);
    return names;
  }, py::arg("kind"));
  m.def("show_preset", [](const std::string& name) { return json_to_python(nlohmann::json::parse(show_preset(name))); }, py::arg("name"));
  m.def("read_image", [](const std::string& path) {
    require_file(path, "image file");
    ImageF img;
    {
      py::gil_scoped_release nogil;
      img = read_image(path);
    }
    return to_array(std::move(img));
  }, py::arg("path"));
  m.def("read_codes", [](const std::string& path) -> py::array {
    require_file(path, "image file");
    ImageU16 img;
    ImageFileInfo info;
    {
      py::gil_scoped_release nogil;
      img = read_image_u16(path, &info);
    }
    if (info.bits_per_sample != 8) return to_array(std::move(img));
    ImageU8 u8(img.width(), img.height(), img.channels(), uninitialized);
    std::copy_n(img.data(), img.size(), u8.data());
    return to_array(std::move(u8));
  }, py::arg("path"));
}
