// `photosite bench batch`: images per core-hour of the batch engine (batch::run, what `photosite
// batch` runs) end to end on the Cityscapes samples (2048x1024), for the default EXR route and
// the PNG route (`--format png --layers sensor,labels`), beside its parts measured alone (read +
// decode + linearize, compute, write) and beside peers writing the same layers in the same run:
// OpenCV's imwrite (EXR through its own OpenEXR path, PNG through libpng; a module loaded when the
// bench runs, bench/peers/opencv_imwrite.cpp) and oiiotool.
// Then the PNG route's codecs alone (bench_png.csv, chart bench_png.png): the day and label PNGs
// decoded by ours (core/png_codec.cpp), the general reader (libspng through core/io.cpp, for the
// files ours does not take), libspng alone and libpng;
// the sensor preview encoded with every filter, zlib strategy and level and libdeflate level
// (bytes per frame and CPU ms), beside libpng and libspng at the previous setting.
#include <png.h>
#include <spng.h>
#include <time.h>
#include <zlib.h>
#include <sys/resource.h>
#include <dlfcn.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <map>
#include <optional>
#include <thread>
#include <tuple>

#include <fmt/format.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "bench.h"
#include "core/png_codec.h"
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
  bool codecs_only = false;
  bool end_to_end_only = false;
  int cycles = 1;
};

// CPU time of the calling thread, in ms: what a codec call costs the machine, which the other
// jobs on a shared VM disturb far less than wall time (a preempted thread's wait is not counted).
double thread_cpu_ms() {
  timespec t;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return t.tv_sec * 1e3 + t.tv_nsec * 1e-6;
}
template <class F>
double cpu_time_ms(F&& f) {
  const double c0 = thread_cpu_ms();
  f();
  return thread_cpu_ms() - c0;
}

std::vector<uint8_t> file_bytes(const std::string& path) {
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) fail_at(path, "cannot read");
  std::vector<uint8_t> b(fs::file_size(path));
  const size_t got = std::fread(b.data(), 1, b.size(), f);
  std::fclose(f);
  if (got != b.size()) fail_at(path, "short read");
  return b;
}

// libspng: decode to 8-bit samples as stored (grey or RGB; 16-bit kept), or encode 8-bit.
size_t spng_decode_bytes(const std::vector<uint8_t>& file) {
  spng_ctx* c = spng_ctx_new(0);
  spng_set_png_buffer(c, file.data(), file.size());
  spng_ihdr ih{};
  spng_get_ihdr(c, &ih);
  const int fmt = ih.bit_depth == 16 ? SPNG_FMT_RAW : ih.color_type == SPNG_COLOR_TYPE_GRAYSCALE ? SPNG_FMT_G8 : SPNG_FMT_RGB8;
  size_t n = 0;
  spng_decoded_image_size(c, fmt, &n);
  std::vector<uint8_t> out(n);
  const int e = spng_decode_image(c, out.data(), n, fmt, 0);
  spng_ctx_free(c);
  if (e) internal_error(std::string("bench batch: libspng: ") + spng_strerror(e));
  return n;
}
size_t spng_encode_size(const uint8_t* px, int w, int h, int level, int strategy, int filter_mask) {
  spng_ctx* c = spng_ctx_new(SPNG_CTX_ENCODER);
  spng_set_option(c, SPNG_ENCODE_TO_BUFFER, 1);
  spng_set_option(c, SPNG_IMG_COMPRESSION_LEVEL, level);
  spng_set_option(c, SPNG_IMG_COMPRESSION_STRATEGY, strategy);
  spng_set_option(c, SPNG_FILTER_CHOICE, filter_mask);
  spng_ihdr ih{};
  ih.width = static_cast<uint32_t>(w);
  ih.height = static_cast<uint32_t>(h);
  ih.bit_depth = 8;
  ih.color_type = SPNG_COLOR_TYPE_TRUECOLOR;
  spng_set_ihdr(c, &ih);
  const int e = spng_encode_image(c, px, static_cast<size_t>(w) * h * 3, SPNG_FMT_PNG, SPNG_ENCODE_FINALIZE);
  size_t n = 0;
  int err = 0;
  void* buf = spng_get_png_buffer(c, &n, &err);
  std::free(buf);
  spng_ctx_free(c);
  if (e || err) internal_error("bench batch: libspng encode failed");
  return n;
}
// libpng, the previous writer's calls (level, filter, strategy), into memory; the file's bytes.
size_t libpng_encode_size(const uint8_t* px, int w, int h, int level, int filter_mask, int strategy) {
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png_create_info_struct(png);
  size_t n = 0;
  png_set_write_fn(png, &n, [](png_structp p, png_bytep, png_size_t len) { *static_cast<size_t*>(png_get_io_ptr(p)) += len; },
                   nullptr);
  png_set_compression_level(png, level);
  png_set_compression_strategy(png, strategy);
  png_set_filter(png, PNG_FILTER_TYPE_BASE, filter_mask);
  png_set_IHDR(png, info, static_cast<png_uint_32>(w), static_cast<png_uint_32>(h), 8, PNG_COLOR_TYPE_RGB,
               PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_BASE, PNG_FILTER_TYPE_BASE);
  png_write_info(png, info);
  for (int y = 0; y < h; ++y) png_write_row(png, px + static_cast<size_t>(y) * w * 3);
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  return n;
}
size_t libpng_decode_bytes(const std::string& path) {
  png_image im{};
  im.version = PNG_IMAGE_VERSION;
  if (!png_image_begin_read_from_file(&im, path.c_str())) internal_error("bench batch: libpng cannot read " + path);
  std::vector<uint8_t> out(PNG_IMAGE_SIZE(im));
  png_image_finish_read(&im, nullptr, out.data(), 0, nullptr);
  return out.size();
}

const char* filter_name(png::Filter f) {
  static const char* names[] = {"none", "sub", "up", "average", "paeth", "adaptive"};
  return names[static_cast<int>(f)];
}
const char* strategy_name(int s) {
  static const char* names[] = {"default", "filtered", "huffman", "rle"};
  return names[s];
}

// The PNG route's codecs alone on the data set's frames and their night previews.
void codec_bench(const std::vector<batch::Item>& items, const std::vector<ImageU8>& previews, const std::string& out_dir) {
  const double n = static_cast<double>(items.size());
  // ---- decode -------------------------------------------------------------------------------
  double d_ours = 0, d_oiio = 0, d_spng = 0, d_libpng = 0, l_ours = 0, l_oiio = 0, l_spng = 0, l_libpng = 0;
  for (const auto& it : items) {
    d_ours += cpu_time_ms([&] { auto im = read_image(it.image); });
    d_oiio += cpu_time_ms([&] { auto im = detail::read_image_general(it.image); });
    d_spng += cpu_time_ms([&] { spng_decode_bytes(file_bytes(it.image)); });
    d_libpng += cpu_time_ms([&] { libpng_decode_bytes(it.image); });
    for (const std::string& f : {it.labels, it.instances}) {
      if (f.empty()) continue;
      l_ours += cpu_time_ms([&] { auto im = read_image_u16(f); });
      l_oiio += cpu_time_ms([&] { auto im = detail::read_image_u16_general(f); });
      l_spng += cpu_time_ms([&] { spng_decode_bytes(file_bytes(f)); });
      l_libpng += cpu_time_ms([&] { libpng_decode_bytes(f); });
    }
  }
  std::printf("PNG decode, CPU ms per frame (mean of %zu):  day RGB8 to samples  | its labels (labelIds 8-bit + instanceIds 16-bit)\n", items.size());
  std::printf("  ours (libdeflate inflate, core/png_codec) %6.1f  |  %6.1f   (read_image: floats; read_image_u16)\n", d_ours / n, l_ours / n);
  std::printf("  general reader (libspng, read_image_general) %6.1f  |  %6.1f   (ours %.2fx | %.2fx its time)\n", d_oiio / n, l_oiio / n, d_ours / d_oiio, l_ours / l_oiio);
  std::printf("  libspng 0.7 (to 8-bit / raw samples)      %6.1f  |  %6.1f   (ours %.2fx | %.2fx its time)\n", d_spng / n, l_spng / n, d_ours / d_spng, l_ours / l_spng);
  std::printf("  libpng simplified API (to 8-bit samples)  %6.1f  |  %6.1f   (ours %.2fx | %.2fx its time)\n", d_libpng / n, l_libpng / n, d_ours / d_libpng, l_ours / l_libpng);

  // ---- encode -------------------------------------------------------------------------------
  struct Setting {
    std::string encoder, deflate;
    int level;
    std::string filter;
    std::function<size_t(const ImageU8&)> run;
  };
  std::vector<Setting> settings;
  std::string last;  // our last file, read back (untimed) after each encode
  const auto ours = [&last](png::EncodeOptions o) {
    return [o, &last](const ImageU8& p) {
      last = png::encode(p.data(), p.width(), p.height(), 3, o);
      return last.size();
    };
  };
  const png::Filter filters[] = {png::Filter::None, png::Filter::Sub, png::Filter::Up, png::Filter::Average,
                                 png::Filter::Paeth, png::Filter::Adaptive};
  for (const auto f : filters) {  // core/huffman_deflate.h: literal-only blocks of 64 KiB
    png::EncodeOptions o{png::Deflater::HuffmanOnly, 0, 0, f};
    settings.push_back({"ours", "huffman-only", 0, filter_name(f), ours(o)});
  }
  for (int strategy = 0; strategy < 4; ++strategy)
    for (const auto f : filters) {
      png::EncodeOptions o{png::Deflater::Zlib, 1, strategy, f};
      settings.push_back({"ours", fmt::format("zlib {}", strategy_name(strategy)), 1, filter_name(f), ours(o)});
    }
  for (const int level : {2, 3, 6})
    for (const int strategy : {0, 2, 3}) {
      png::EncodeOptions o{png::Deflater::Zlib, level, strategy, png::Filter::Sub};
      settings.push_back({"ours", fmt::format("zlib {}", strategy_name(strategy)), level, "sub", ours(o)});
    }
  for (const int level : {1, 2, 4, 6, 9})
    for (const auto f : filters) {
      if (level > 2 && (f == png::Filter::Average || f == png::Filter::Up)) continue;
      png::EncodeOptions o{png::Deflater::Libdeflate, level, 0, f};
      settings.push_back({"ours", "libdeflate", level, filter_name(f), ours(o)});
    }
  settings.push_back({"libpng 1.6 (previous writer)", "zlib default", 1, "sub",
                      [](const ImageU8& p) { return libpng_encode_size(p.data(), p.width(), p.height(), 1, PNG_FILTER_SUB, Z_DEFAULT_STRATEGY); }});
  settings.push_back({"libpng 1.6", "zlib huffman", 1, "sub",
                      [](const ImageU8& p) { return libpng_encode_size(p.data(), p.width(), p.height(), 1, PNG_FILTER_SUB, Z_HUFFMAN_ONLY); }});
  settings.push_back({"libpng 1.6", "zlib default", 6, "adaptive",
                      [](const ImageU8& p) { return libpng_encode_size(p.data(), p.width(), p.height(), 6, PNG_ALL_FILTERS, Z_DEFAULT_STRATEGY); }});
  settings.push_back({"libspng 0.7", "zlib default", 1, "sub",
                      [](const ImageU8& p) { return spng_encode_size(p.data(), p.width(), p.height(), 1, Z_DEFAULT_STRATEGY, SPNG_FILTER_CHOICE_SUB); }});
  settings.push_back({"libspng 0.7", "zlib huffman", 1, "sub",
                      [](const ImageU8& p) { return spng_encode_size(p.data(), p.width(), p.height(), 1, Z_HUFFMAN_ONLY, SPNG_FILTER_CHOICE_SUB); }});
  const png::EncodeOptions def = png::default_encode_options();
  std::string csv = "encoder,deflate,level,filter,cpu_ms_per_frame,mb_per_frame,default\n";
  std::printf("PNG encode of the night previews (2048x1024 RGB8), CPU ms and MB per frame (mean of %zu), all lossless (each read back):\n",
              previews.size());
  for (const auto& st : settings) {
    double ms = 0, mb = 0;
    for (const auto& p : previews) {
      size_t bytes = 0;
      last.clear();
      ms += cpu_time_ms([&] { bytes = st.run(p); });
      mb += bytes / 1e6;
      if (!last.empty()) {  // lossless: our file decodes to the preview
        const auto back = png::decode(std::vector<uint8_t>(last.begin(), last.end()), int64_t{1} << 40);
        if (!back || !std::equal(back->u8.begin(), back->u8.end(), p.vec().begin(), p.vec().end()))
          internal_error("bench batch: a PNG setting did not read back unchanged");
      }
    }
    ms /= previews.size();
    mb /= previews.size();
    const std::string def_deflate = def.deflater == png::Deflater::Libdeflate    ? std::string("libdeflate")
                                    : def.deflater == png::Deflater::HuffmanOnly ? std::string("huffman-only")
                                                                                 : fmt::format("zlib {}", strategy_name(def.zlib_strategy));
    const bool is_default = st.encoder == "ours" && st.deflate == def_deflate &&
                            (def.deflater == png::Deflater::HuffmanOnly || st.level == def.level) &&
                            st.filter == filter_name(def.filter);
    std::printf("  %-28s %-16s level %d  %-8s %7.1f ms  %5.2f MB%s\n", st.encoder.c_str(), st.deflate.c_str(), st.level,
                st.filter.c_str(), ms, mb, is_default ? "   <- default" : "");
    csv += fmt::format("{},{},{},{},{:.1f},{:.3f},{}\n", st.encoder, st.deflate, st.level, st.filter, ms, mb, is_default ? 1 : 0);
  }
  csv += fmt::format("# decode CPU ms per frame, day RGB8 / labels: ours {:.1f} / {:.1f}, general reader (libspng) {:.1f} / {:.1f}, libspng {:.1f} / {:.1f}, libpng {:.1f} / {:.1f}\n",
                     d_ours / n, l_ours / n, d_oiio / n, l_oiio / n, d_spng / n, l_spng / n, d_libpng / n, l_libpng / n);
  csv += fmt::format("# {} Cityscapes frames' night previews (onsemi-ar0331, night-urban), encode time as the thread's CPU time; {}\n",
                     items.size(), machine_description());
  const std::string csv_path = write_bench_csv(out_dir, "bench_png.csv", csv);
  const std::string chart = fs::path(csv_path).replace_extension(".png").string();
  draw_chart("bench/chart_png.py", csv_path, chart);
}

// CPU time (user + system) this process has used, in ms: on a shared machine the core-hours a
// run actually took, whatever share of the cores the other jobs left it.
double cpu_ms() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return (u.ru_utime.tv_sec + u.ru_stime.tv_sec) * 1e3 + (u.ru_utime.tv_usec + u.ru_stime.tv_usec) / 1e3;
}

// A float image as an OpenCV matrix (no copy).
// OpenCV's imwrite from the module beside the command (libphotosite_opencv_peers.so), loaded on
// first use; bad input if it is missing (a build without it), before anything is timed.
using ImwriteFn = int (*)(const char*, int, int, int, void*, size_t, const int*, int);
ImwriteFn opencv_imwrite_fn() {
  static const ImwriteFn fn = [] {
    std::error_code ec;
    const fs::path module = fs::read_symlink("/proc/self/exe", ec).parent_path() / "libphotosite_opencv_peers.so";
    void* h = ec ? nullptr : dlopen(module.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (!h) fail_at(module.string(), std::string("bench batch: cannot load OpenCV's peer module (") + (ec ? ec.message() : dlerror()) + "); build the target photosite_opencv_peers");
    auto f = reinterpret_cast<ImwriteFn>(dlsym(h, "photosite_peer_imwrite"));
    if (!f) fail_at(module.string(), "bench batch: no photosite_peer_imwrite in the module");
    return f;
  }();
  return fn;
}
void cv_imwrite(const std::string& path, const cv::Mat& m, const std::vector<int>& params) {
  if (!opencv_imwrite_fn()(path.c_str(), m.rows, m.cols, m.type(), m.data, m.step, params.data(), static_cast<int>(params.size())))
    internal_error("bench batch: OpenCV's imwrite failed for " + path);
}

cv::Mat mat_of(const ImageF& img) {
  return cv::Mat(img.height(), img.width(), CV_32FC(img.channels()), const_cast<float*>(img.data()));
}

void run_bench(const BenchBatchOptions& o) {
  if (o.repeats < 1 || o.repeats > 20) fail("--repeats must be in [1, 20]");
  if (o.cycles < 1 || o.cycles > 100) fail("--cycles must be in [1, 100]");
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
  // A one-off per device; batch::run loads it once per frame size too (its fixed-pattern cache),
  // so the compute part below does not load it per image.
  const FixedPatternMaps fpn = store.load_or_create(r.camera, r.device_id, 2048, 1024);

  // ---- the parts alone, and the peers on the same data ----------------------------------------
  const bool parts = !o.end_to_end_only;
  double t_read = 0, t_compute = 0, t_exr = 0, t_png = 0, t_copy = 0;
  double t_cv_exr = 0, t_cv_png = 0, t_oiio_exr = 0, t_oiio_png = 0;
  double mb_exr = 0, mb_png = 0, mb_cv_exr = 0, t_preview = 0;
  std::vector<ImageU8> previews;
  if (!o.codecs_only) (void)opencv_imwrite_fn();  // the peer's module loaded before anything is timed
  for (const auto& it : items) {
    if (!parts) break;
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
      if (fpn.width != day.width() || fpn.height != day.height()) internal_error("bench batch: a frame not 2048x1024");
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
    t_preview += time_ms([&] { previews.push_back(preview_srgb8(out->rgb, wb)); });
    if (o.codecs_only) continue;
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
      cv_imwrite((tmp / "cv_sensor.exr").string(), bgr, piz);
      cv_imwrite((tmp / "cv_raw.exr").string(), mat_of(out->raw_dn), piz);
      cv_imwrite((tmp / "cv_electrons.exr").string(), mat_of(out->electrons), piz);
      cv_imwrite((tmp / "cv_depth.exr").string(), mat_of(ns->depth), piz_half);
      cv_imwrite((tmp / "cv_labels.exr").string(), mat_of(label_f), piz);
    });
    for (const char* f : {"cv_sensor", "cv_raw", "cv_electrons", "cv_depth", "cv_labels"})
      mb_cv_exr += fs::file_size(tmp / (std::string(f) + ".exr")) / 1e6;
    const ImageU8 preview = preview_srgb8(out->rgb, wb);
    const cv::Mat p8(preview.height(), preview.width(), CV_8UC3, const_cast<uint8_t*>(preview.data()));
    cv::Mat p8_bgr;
    cv::cvtColor(p8, p8_bgr, cv::COLOR_RGB2BGR);
    t_cv_png += time_ms([&] { cv_imwrite((tmp / "cv.png").string(), p8_bgr, {cv::IMWRITE_PNG_COMPRESSION, 1}); });

    // oiiotool: rewrites our uncompressed file of the same layers (types kept) with PIZ, and the
    // preview from uncompressed TIFF to PNG at zlib level 1; its time includes starting the
    // process and reading the uncompressed input.
    ExrWriteOptions none = wo;
    none.compression = "none";
    write_exr((tmp / "none.exr").string(), groups, attrs, none);
    cv_imwrite((tmp / "preview.tif").string(), p8_bgr, {cv::IMWRITE_TIFF_COMPRESSION, 1});
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
                    &mb_exr, &mb_png, &mb_cv_exr, &t_preview})
    *t /= n;
  if (parts) {
    codec_bench(items, previews, o.out_dir);
    std::printf("  preview ISP alone (preview_srgb8, all threads) %.1f ms/image (wall)\n", t_preview);
  }
  if (o.codecs_only) return;

  // ---- end to end: batch::run in this process, as `photosite batch` runs it ------------------
  SensorRunner cpu(Backend::Cpu);
  // Wall ms per image (median) and CPU ms per image (median) of each route.
  // --cycles N: each run takes the frames N times over (copy k under cycle<k>/, its own group,
  // so its own seed), the data set's steady state: a run's fixed costs (the fixed-pattern maps'
  // load, the first read, the last write with the other cores idle) spread over N times the
  // images.
  std::vector<batch::Item> run_items;
  for (int k = 0; k < o.cycles; ++k)
    for (batch::Item it : items) {
      if (o.cycles > 1) {
        const std::string pre = fmt::format("cycle{}/", k);
        it.key = pre + it.key, it.group = pre + it.group;
        if (!it.labels_rel.empty()) it.labels_rel = pre + it.labels_rel;
        if (!it.instances_rel.empty()) it.instances_rel = pre + it.instances_rel;
      }
      run_items.push_back(it);
    }
  const double n_run = static_cast<double>(run_items.size());
  // Where the threads went (batch::Result::stages), per image, the mean over the runs.
  auto end_to_end = [&](const std::string& name, batch::Options opt) {
    std::vector<double> ms, cpu_per_image;
    batch::StageTimes sum;
    const double n = n_run;
    for (int k = 0; k < o.repeats; ++k) {
      opt.out = (tmp / fmt::format("{}-{}", name, k)).string();
      const double c0 = cpu_ms();
      const auto res = batch::run(run_items, opt, cpu);
      cpu_per_image.push_back((cpu_ms() - c0) / n);
      if (!res.errors.empty()) internal_error("bench batch: " + res.errors.front());
      ms.push_back(res.progress.elapsed_s * 1e3 / n);
      fs::remove_all(opt.out);
      const auto& s = res.stages;
      for (auto [acc, v] : {std::pair{&sum.reader_cpu_ms, s.reader_cpu_ms}, {&sum.compute_cpu_ms, s.compute_cpu_ms},
                            {&sum.writer_cpu_ms, s.writer_cpu_ms}, {&sum.reader_wait_ms, s.reader_wait_ms},
                            {&sum.compute_wait_in_ms, s.compute_wait_in_ms}, {&sum.compute_wait_out_ms, s.compute_wait_out_ms},
                            {&sum.writer_wait_ms, s.writer_wait_ms}})
        *acc += v / (n * o.repeats);
    }
    std::printf("  %s route, per image (mean of %d runs): CPU reader %.1f, compute thread %.1f, process rest (OpenMP workers) %.1f, writers %.1f ms; "
                "waits: reader on full queue %.1f, compute for input %.1f, compute on full queue %.1f, writers for work %.1f ms\n",
                name.c_str(), o.repeats, sum.reader_cpu_ms, sum.compute_cpu_ms,
                median(cpu_per_image) - sum.reader_cpu_ms - sum.compute_cpu_ms - sum.writer_cpu_ms, sum.writer_cpu_ms,
                sum.reader_wait_ms, sum.compute_wait_in_ms, sum.compute_wait_out_ms, sum.writer_wait_ms);
    return std::pair{median(ms), median(cpu_per_image)};
  };
  const auto [e2e_exr, cpu_exr] = end_to_end("exr", bo);
  batch::Options png_opt = bo;
  png_opt.format = "png";
  png_opt.layers = static_cast<unsigned>(Layer::Sensor) | static_cast<unsigned>(Layer::Labels);
  const auto [e2e_png, cpu_png] = end_to_end("png", png_opt);

  if (!parts) {  // --end-to-end-only: no parts to compare with, no CSV
    std::printf("batch, %zu Cityscapes images (2048x1024) x %d cycles, %s; end to end the median of %d runs\n", items.size(),
                o.cycles, machine_description().c_str(), o.repeats);
    for (const auto& [name, ms, c] : {std::tuple{"EXR default route", e2e_exr, cpu_exr}, {"PNG sensor,labels", e2e_png, cpu_png}})
      std::printf("  end to end, %-18s %8.1f ms/image: %.0f images per core-hour of wall time x %d cores; CPU %.1f ms/image: %.0f images per CPU core-hour used\n",
                  name, ms, per_core_hour(ms), cores, c, 3.6e6 / c);
    return;
  }
  const double exr_parts = t_read + t_compute + t_exr + t_copy, png_parts = t_read + t_compute + t_png + t_copy;
  std::printf("batch, %zu Cityscapes images (2048x1024), %s; end to end the median of %d runs of %d cycle(s) of the images\n",
              items.size(), machine_description().c_str(), o.repeats, o.cycles);
  std::printf("  read + decode + linearize alone   %8.1f ms/image\n", t_read);
  std::printf("  compute (scene + sensor) alone    %8.1f ms/image\n", t_compute);
  std::printf("  EXR write alone (%s, default layers) %5.1f ms/image  %.2f MB\n", bo.compression.c_str(), t_exr, mb_exr);
  std::printf("    peer OpenCV imwrite, same layers  %7.1f ms/image  %.2f MB  (ours %.2fx its time)\n", t_cv_exr,
              mb_cv_exr, t_exr / t_cv_exr);
  std::printf("    peer oiiotool none->piz           %7.1f ms/image            (ours %.2fx its time)\n", t_oiio_exr,
              t_exr / t_oiio_exr);
  std::printf("  PNG preview alone (sRGB8 + encode) %7.1f ms/image  %.2f MB (of it the preview ISP %.1f ms)\n", t_png, mb_png, t_preview);
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
  csv += fmt::format("# {} Cityscapes 2048x1024 images ({} cycle(s) per end-to-end run), onsemi-ar0331, batch::run in process (CPU backend), "
                     "default layers {} with {}; images_per_core_hour from wall time x {} hardware threads, and (rows *_cpu_time) from the CPU time the run used; {}\n",
                     items.size(), o.cycles, layers_text(kBatchLayers), bo.compression, cores, machine_description());
  write_bench_csv(o.out_dir, "bench_batch.csv", csv);
}
}  // namespace

static BenchRegistrar reg("batch", "batch engine end to end (EXR and PNG routes) beside its parts and OpenCV/oiiotool",
                          [](CLI::App* sub) {
                            auto o = std::make_shared<BenchBatchOptions>();
                            sub->add_option("--root", o->root, "Cityscapes-layout root")->capture_default_str();
                            sub->add_option("--repeats", o->repeats, "end-to-end runs per route (median), 1 to 20")
                                ->capture_default_str();
                            sub->add_option("--out-dir", o->out_dir, "where the CSVs and the chart go (default docs/)");
                            sub->add_flag("--codecs-only", o->codecs_only,
                                          "only the PNG codecs (decode and encode settings), not the end-to-end runs");
                            sub->add_option("--cycles", o->cycles,
                                            "end to end: the frames this many times per run (the data set's steady state)")
                                ->capture_default_str();
                            sub->add_flag("--end-to-end-only", o->end_to_end_only,
                                          "only the end-to-end runs of both routes (no parts, peers, codecs or CSV)");
                            sub->callback([o] { run_bench(*o); });
                          });
}  // namespace photosite::bench
