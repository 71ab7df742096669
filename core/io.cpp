#include "photosite/io.h"

#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imageio.h>
#include <Imath/half.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cstdio>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <cctype>
#include <optional>
#include <filesystem>
#include <fmt/format.h>
#include <fmt/ranges.h>

#include "core/png_codec.h"
#include "photosite/environment.h"
#include "photosite/error.h"
#include "photosite/night_chain.h"

namespace photosite {
namespace fs = std::filesystem;
using namespace OIIO;

namespace {
// OpenEXR header walk, before OpenEXR reads it. The header is a list of attributes, each
// "name\0type\0" + int32 size + size bytes, ended by an empty name (one header per part in a
// multi-part file, the list of headers ended by an empty header); see "The OpenEXR File Layout",
// openexr.com/en/latest/OpenEXRFileLayout.html. OpenEXR 3.1 allocates an attribute's declared
// size before reading it, so a damaged size turns a 1 kB file into a 2 GB allocation (found by
// fuzz_device_map, docs/robustness.md): sizes beyond the end of the file are refused here.
// Bytes of a value of a fixed-size OpenEXR attribute type, or -1 (strings, vectors, channel
// lists, previews and unknown types, whose size is the declared one).
int64_t exr_fixed_size(const std::string& type) {
  static const std::pair<const char*, int> sizes[] = {
      {"int", 4},       {"float", 4},     {"double", 8},  {"box2i", 16},      {"box2f", 16},
      {"v2i", 8},       {"v2f", 8},       {"v2d", 16},    {"v3i", 12},        {"v3f", 12},
      {"v3d", 24},      {"m33f", 36},     {"m33d", 72},   {"m44f", 64},       {"m44d", 128},
      {"compression", 1}, {"lineOrder", 1}, {"envmap", 1}, {"deepImageState", 1},
      {"tiledesc", 9},  {"rational", 8},  {"timecode", 8}, {"keycode", 28},   {"chromaticities", 32}};
  for (const auto& [t, n] : sizes)
    if (type == t) return n;
  return -1;
}

void check_exr_header(const std::string& path) {
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) return;  // OpenImageIO reports it
  struct Closer {
    std::FILE* f;
    ~Closer() { std::fclose(f); }
  } closer{f};
  unsigned char head[8];
  if (std::fread(head, 1, 8, f) != 8 || head[0] != 0x76 || head[1] != 0x2f || head[2] != 0x31 ||
      head[3] != 0x01)
    return;  // not OpenEXR
  std::error_code ec;
  const auto file_size = static_cast<int64_t>(fs::file_size(path, ec));
  if (ec) return;
  const bool multipart = head[5] & 0x10;  // version field bit 12
  auto read_string = [&](std::string& out) {  // NUL-terminated, at most 255 characters
    out.clear();
    for (int c; (c = std::fgetc(f)) != 0;) {
      if (c == EOF) fail_at(path, "corrupt or truncated EXR header (ends inside an attribute name)");
      if (out.size() == 255) fail_at(path, "corrupt EXR header (attribute name longer than 255 characters)");
      out.push_back(static_cast<char>(c));
    }
  };
  std::string name, type;
  for (int part = 0;; ++part) {
    for (int attributes = 0;; ++attributes) {
      read_string(name);
      if (name.empty()) break;
      read_string(type);
      unsigned char b[4];
      if (std::fread(b, 1, 4, f) != 4) fail_at(path, "corrupt or truncated EXR header (attribute " + name + ")");
      const int64_t size = static_cast<int32_t>(b[0] | b[1] << 8 | b[2] << 16 | uint32_t{b[3]} << 24);
      const int64_t left = file_size - std::ftell(f);
      if (size < 0 || size > left)
        fail_at(path, fmt::format("corrupt EXR header: attribute '{}' declares {} bytes, the file has {} left",
                                  name, size, left));
      // OpenEXR reads a typed value by its type, not by the declared size: where the two differ
      // its walk and this one part ways and OpenEXR goes on to read garbage sizes (a 1 kB map
      // kept fuzz_device_map in a 2 GB string fill for 10 s). So the size must be the type's.
      const auto bad = [&](const std::string& why) {
        fail_at(path, fmt::format("corrupt EXR header: attribute '{}' of type {} {}", name, type, why));
      };
      if (const int64_t fixed = exr_fixed_size(type); fixed >= 0 && size != fixed)
        bad(fmt::format("declares {} bytes, the type has {}", size, fixed));
      const long value_start = std::ftell(f);
      if (type == "chlist") {  // channels: "name\0" + 16 bytes each, ended by an empty name
        std::string channel;
        for (int n = 0;; ++n) {
          read_string(channel);
          if (channel.empty()) break;
          if (std::fseek(f, 16, SEEK_CUR) != 0 || n > 4096) bad("has a damaged channel list");
          if (std::ftell(f) - value_start > size) break;
        }
        if (std::ftell(f) - value_start != size) bad(fmt::format("declares {} bytes, its channel list differs", size));
      } else if (type == "preview") {  // width, height (uint32), then 4 bytes a pixel
        unsigned char wh[8];
        if (size < 8 || std::fread(wh, 1, 8, f) != 8) bad("is truncated");
        const auto u32 = [](const unsigned char* q) { return uint64_t{q[0]} | uint64_t{q[1]} << 8 | uint64_t{q[2]} << 16 | uint64_t{q[3]} << 24; };
        const uint64_t pw = u32(wh), ph = u32(wh + 4);  // below 2^24 each, so 4*pw*ph cannot wrap
        if (pw >= (1u << 24) || ph >= (1u << 24) || 8 + 4 * pw * ph != static_cast<uint64_t>(size))
          bad(fmt::format("declares {} bytes for a {}x{} preview", size, u32(wh), u32(wh + 4)));
      }
      std::fseek(f, value_start + static_cast<long>(size), SEEK_SET);
      if (attributes > 10000) fail_at(path, "corrupt EXR header (more than 10000 attributes)");
    }
    if (!multipart || part > 10000) break;
    const int c = std::fgetc(f);  // an empty header (a lone NUL) ends the list of parts
    if (c == 0 || c == EOF) break;
    std::ungetc(c, f);
  }
}

std::unique_ptr<ImageInput> open_input(const std::string& path) {
  std::error_code ec;
  if (!fs::exists(path, ec)) fail_at(path, "no such file");
  if (fs::is_directory(path, ec)) fail_at(path, "is a folder, not an image file");
  check_exr_header(path);
  auto in = ImageInput::open(path);
  if (!in) {
    std::string msg = OIIO::geterror();
    fail_at(path, "cannot read image (" + (msg.empty() ? std::string("unknown format") : msg) + ")");
  }
  const ImageSpec& spec = in->spec();
  if (spec.nchannels <= 0) fail_at(path, "image has no channels");
  check_frame_size(path, spec.width, spec.height);
  if (spec.nchannels > 64) fail_at(path, fmt::format("image declares {} channels", spec.nchannels));
  return in;
}

ImageFileInfo info_from(const std::string& path, const ImageInput& in) {
  const ImageSpec& spec = in.spec();
  ImageFileInfo info;
  info.path = path;
  info.format = in.format_name();
  info.width = spec.width;
  info.height = spec.height;
  info.channels = spec.nchannels;
  info.bits_per_sample = static_cast<int>(spec.format.size() * 8);
  info.is_float = spec.format.is_floating_point();
  std::string cs = spec.get_string_attribute("oiio:ColorSpace");
  info.srgb_encoded = !info.is_float && cs != "Linear" && cs != "linear";
  return info;
}
}  // namespace

int64_t max_frame_pixels() {
  static const int64_t limit = [] {
    if (const auto e = env::get(env::Var::MaxPixels)) {
      char* end = nullptr;
      const long long v = std::strtoll(e->c_str(), &end, 10);
      if (end && *end == 0 && v >= 4) return static_cast<int64_t>(v);
      fail(std::string("PHOTOSITE_MAX_PIXELS='") + *e + "' is not a whole number >= 4");
    }
    return int64_t{1} << 28;
  }();
  return limit;
}

void check_frame_size(const std::string& what, int64_t width, int64_t height) {
  if (width < 2 || height < 2)
    fail_at(what, fmt::format("frame size {}x{} is too small (at least 2x2 pixels, one CFA tile)",
                              width, height));
  if (width * height > max_frame_pixels())
    fail_at(what, fmt::format("frame size {}x{} is larger than the limit of {} pixels "
                              "(PHOTOSITE_MAX_PIXELS); refused before allocating it",
                              width, height, max_frame_pixels()));
}

ImageFileInfo probe_image(const std::string& path) {
  auto in = open_input(path);
  auto info = info_from(path, *in);
  in->close();
  return info;
}

namespace {
// The plain PNGs of the data sets (8/16-bit grey or RGB, not interlaced, no colour chunks but sRGB's)
// decoded by core/png_codec.cpp: 1.2x to 2.6x less CPU than OpenImageIO's libpng reader and
// float conversion (`photosite bench batch`, docs/cli.md "PNG input and output"). Anything else
// (another format, a PNG the decoder does not take, a damaged file) returns nullopt and goes
// through OpenImageIO, which also words the errors.
std::optional<png::Decoded> read_plain_png(const std::string& path, ImageFileInfo* info) {
  const fs::path p(path);
  std::string ext = p.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  std::error_code ec;
  if (ext != ".png" || !fs::is_regular_file(p, ec)) return std::nullopt;
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) return std::nullopt;
  std::vector<uint8_t> bytes(fs::file_size(p, ec));
  const size_t got = ec ? 0 : std::fread(bytes.data(), 1, bytes.size(), f);
  std::fclose(f);
  if (ec || got != bytes.size()) return std::nullopt;
  auto d = png::decode(bytes, max_frame_pixels());
  if (!d) return std::nullopt;
  check_frame_size(path, d->width, d->height);
  if (info) {  // as info_from() reports OpenImageIO's spec of the same file
    *info = ImageFileInfo{};
    info->path = path;
    info->format = "png";
    info->width = d->width;
    info->height = d->height;
    info->channels = d->channels;
    info->bits_per_sample = d->bits;
    info->is_float = false;
    info->srgb_encoded = true;  // no colour chunk, or sRGB's: OpenImageIO names it sRGB
  }
  return d;
}
}  // namespace

ImageF detail::read_image_general(const std::string& path, ImageFileInfo* info) {
  auto in = open_input(path);
  const ImageSpec& spec = in->spec();
  ImageF img(spec.width, spec.height, spec.nchannels, uninitialized);
  // Some readers (libtiff's strips) report damage as an error message but still "succeed"
  // with the missing part zero-filled: any reported error is a corrupt file.
  if (!in->read_image(0, 0, 0, spec.nchannels, TypeDesc::FLOAT, img.data()) || in->has_error())
    fail_at(path, "corrupt or truncated image (" + in->geterror() + ")");
  if (info) *info = info_from(path, *in);
  in->close();
  return img;
}

ImageF read_image(const std::string& path, ImageFileInfo* info) {
  if (auto d = read_plain_png(path, info); d && d->bits == 8) {
    // OpenImageIO's 8-bit to float conversion, code * (1/255) in float (the values
    // scene::linearize's exact table expects); 16-bit files go through it unchanged.
    ImageF img(d->width, d->height, d->channels, uninitialized);
    float* o = img.data();
    const uint8_t* s = d->u8.data();
    for (size_t i = 0; i < d->u8.size(); ++i) o[i] = s[i] * (1.f / 255);
    return img;
  }
  return detail::read_image_general(path, info);
}

std::optional<ImageU8> read_image_codes8(const std::string& path, ImageFileInfo* info) {
  ImageFileInfo got;
  auto d = read_plain_png(path, &got);
  if (!d || d->bits != 8 || d->channels != 3) return std::nullopt;
  ImageU8 img(d->width, d->height, d->channels, uninitialized);
  std::copy(d->u8.begin(), d->u8.end(), img.data());
  if (info) *info = got;
  return img;
}

DayImage read_day_image(const std::string& path, ImageFileInfo* info) {
  DayImage d;
  d.codes = read_image_codes8(path, info);
  if (!d.codes) d.floats = read_image(path, info);
  return d;
}

ImageU16 read_image_u16(const std::string& path, ImageFileInfo* info) {
  if (auto d = read_plain_png(path, info)) {
    ImageU16 img(d->width, d->height, d->channels, uninitialized);
    if (d->bits == 8) std::copy(d->u8.begin(), d->u8.end(), img.data());
    else std::copy(d->u16.begin(), d->u16.end(), img.data());
    return img;
  }
  return detail::read_image_u16_general(path, info);
}

ImageU16 detail::read_image_u16_general(const std::string& path, ImageFileInfo* info) {
  auto in = open_input(path);
  const ImageSpec& spec = in->spec();
  if (spec.format.is_floating_point())
    fail_at(path, "expected an integer (8- or 16-bit) image, found floating point");
  ImageU16 img(spec.width, spec.height, spec.nchannels, uninitialized);
  bool ok;
  if (spec.format.size() == 1) {
    ImageU8 tmp(spec.width, spec.height, spec.nchannels, uninitialized);
    ok = in->read_image(0, 0, 0, spec.nchannels, TypeDesc::UINT8, tmp.data());
    for (size_t i = 0; i < tmp.size(); ++i) img[i] = tmp[i];
  } else if (spec.format.size() == 2) {
    ok = in->read_image(0, 0, 0, spec.nchannels, TypeDesc::UINT16, img.data());
  } else {
    fail_at(path, fmt::format("unsupported {}-bit integer samples", spec.format.size() * 8));
  }
  if (!ok || in->has_error()) fail_at(path, "corrupt or truncated image (" + in->geterror() + ")");
  if (info) *info = info_from(path, *in);
  in->close();
  return img;
}

const char* to_string(ExrPixel p) {
  switch (p) {
    case ExrPixel::Float: return "float";
    case ExrPixel::Half: return "half";
    case ExrPixel::Uint: return "uint";
  }
  return "?";
}

const std::vector<std::string>& exr_compressions() {
  static const std::vector<std::string> names = {"none", "rle",  "zips", "zip",  "piz",
                                                 "pxr24", "b44", "b44a", "dwaa", "dwab"};
  return names;
}

bool exr_compression_lossless(const std::string& name) {
  return name == "none" || name == "rle" || name == "zips" || name == "zip" || name == "piz";
}

void check_exr_compression(const std::string& name, const std::string& what) {
  const auto& all = exr_compressions();
  if (std::find(all.begin(), all.end(), name) == all.end())
    fail(fmt::format("{} '{}': not an OpenEXR compression (one of {})", what, name, fmt::join(all, ", ")));
}

bool write_exr(const std::string& path, const std::vector<ExrChannelGroup>& groups,
               const std::map<std::string, ExrAttribute>& attributes,
               const ExrWriteOptions& options) {
  if (groups.empty()) internal_error("write_exr: no channels");
  check_exr_compression(options.compression, "EXR compression");
  std::vector<std::string> names;
  std::vector<TypeDesc> formats;  // per channel
  const auto shape = [](const ExrChannelGroup& g) {
    return g.image ? std::array<int, 3>{g.image->width(), g.image->height(), g.image->channels()}
           : g.image_u16 ? std::array<int, 3>{g.image_u16->width(), g.image_u16->height(), g.image_u16->channels()}
                         : std::array<int, 3>{0, 0, 0};
  };
  const int w = shape(groups[0])[0], h = shape(groups[0])[1];
  for (const auto& g : groups) {
    if (!g.image == !g.image_u16 || (g.image_u16 && g.pixel != ExrPixel::Uint) ||
        shape(g) != std::array<int, 3>{w, h, static_cast<int>(g.channel_names.size())})
      internal_error("write_exr: channel group shape mismatch for " + path);
    const TypeDesc t = g.pixel == ExrPixel::Uint ? TypeDesc::UINT
                       : g.pixel == ExrPixel::Half || options.half ? TypeDesc::HALF
                                                                   : TypeDesc::FLOAT;
    for (const auto& n : g.channel_names) names.push_back(n), formats.push_back(t);
  }
  const int nch = static_cast<int>(names.size());
  const bool mixed = std::any_of(formats.begin(), formats.end(), [&](TypeDesc t) { return t != formats[0]; });
  ImageSpec spec(w, h, nch, formats[0]);
  spec.channelnames = names;
  if (mixed) spec.channelformats = formats;
  spec.alpha_channel = -1;
  spec.attribute("compression", options.compression);
  spec.attribute("oiio:ColorSpace", "Linear");
  if (options.reproducible) spec.attribute("DateTime", "0000:00:00 00:00:00");
  for (const auto& g : groups)
    if (!g.unit.empty())
      for (const auto& n : g.channel_names) spec.attribute("photosite/unit/" + n, g.unit);
  for (const auto& [key, v] : attributes) {
    const std::string& k = key;  // a plain reference: clang 14 cannot capture a structured binding
    std::visit([&](const auto& x) {
      using X = std::decay_t<decltype(x)>;
      if constexpr (std::is_same_v<X, std::string>) spec.attribute(k, x);
      else if constexpr (std::is_same_v<X, int>) spec.attribute(k, x);
      else spec.attribute(k, static_cast<float>(x));
    }, v);
    if (std::holds_alternative<double>(v))  // keep full precision as text too
      spec.attribute(k + "_text", fmt::format("{:.17g}", std::get<double>(v)));
  }
  // Interleaved and written a strip of rows at a time: a night result has 13 channels, and one
  // interleaved copy of the whole frame (109 MB at 2048x1024) was the largest single buffer of
  // a run. Strips are a multiple of 32 rows (OpenEXR's largest line block, PIZ/B44) and about
  // 16 MB, so OpenEXR still compresses several blocks of each strip in parallel. The file's
  // bytes do not depend on the strip height.
  // Each pixel is stored in the file's own per-channel types (OpenImageIO's "native" layout,
  // TypeUnknown), so integers go to UINT channels without a float detour and half channels are
  // converted once, here.
  std::vector<size_t> offset(nch);
  size_t pixel_bytes = 0;
  for (int c = 0; c < nch; ++c) offset[c] = pixel_bytes, pixel_bytes += formats[c].size();
  const size_t row_bytes = static_cast<size_t>(w) * pixel_bytes;
  const int strip = std::max(32, static_cast<int>((16u << 20) / row_bytes) / 32 * 32);
  std::vector<unsigned char> buf(row_bytes * std::min(strip, h));
  const auto write = [&](const std::string& tmp) {
    auto out = ImageOutput::create("openexr");
    if (!out) internal_error("OpenImageIO has no OpenEXR writer");
    if (!out->open(tmp, spec)) fail_at(path, "cannot write (" + out->geterror() + ")");
    for (int y0 = 0; y0 < h; y0 += strip) {
      const int y1 = std::min(h, y0 + strip);
      int c0 = 0;
      for (const auto& g : groups) {
        const int gc = static_cast<int>(g.channel_names.size());
        const size_t n = static_cast<size_t>(w) * (y1 - y0);
        if (g.image_u16) {  // integers widened as they are
          const uint16_t* src = g.image_u16->data() + static_cast<size_t>(y0) * w * gc;
          for (int c = 0; c < gc; ++c) {
            unsigned char* dst = buf.data() + offset[c0 + c];
            for (size_t p = 0; p < n; ++p) {
              const uint32_t u = src[p * gc + c];
              std::memcpy(dst + p * pixel_bytes, &u, 4);
            }
          }
          c0 += gc;
          continue;
        }
        const float* src = g.image->data() + static_cast<size_t>(y0) * w * gc;
        for (int c = 0; c < gc; ++c) {
          unsigned char* dst = buf.data() + offset[c0 + c];
          const TypeDesc t = formats[c0 + c];
          if (t == TypeDesc::UINT) {
            for (size_t p = 0; p < n; ++p) {
              const float v = src[p * gc + c];
              if (!(v >= 0.f && v < 4294967296.f) || v != std::floor(v))
                internal_error(fmt::format("write_exr: {} holds {} at pixel {}, not a 32-bit unsigned integer",
                                           names[c0 + c], v, p));
              const uint32_t u = static_cast<uint32_t>(v);
              std::memcpy(dst + p * pixel_bytes, &u, 4);
            }
          } else if (t == TypeDesc::HALF) {
            for (size_t p = 0; p < n; ++p) {
              const half v(src[p * gc + c]);
              std::memcpy(dst + p * pixel_bytes, &v, 2);
            }
          } else {
            for (size_t p = 0; p < n; ++p) std::memcpy(dst + p * pixel_bytes, &src[p * gc + c], 4);
          }
        }
        c0 += gc;
      }
      if (!out->write_scanlines(y0, y1, 0, TypeUnknown, buf.data()))
        fail_at(path, "write failed (" + out->geterror() + ")");
    }
    if (!out->close()) fail_at(path, "write failed (" + out->geterror() + ")");
  };
  if (options.create_only) return atomic_create(path, write);
  atomic_write(path, write);
  return true;
}

ExrContents read_exr(const std::string& path) {
  auto in = open_input(path);
  const ImageSpec& spec = in->spec();
  ExrContents r;
  r.width = spec.width;
  r.height = spec.height;
  const int nch = spec.nchannels;
  // Read in the file's own per-channel types (OpenImageIO would scale UINT to [0, 1] when asked
  // for float), then widen each channel to float: UINT values below 2^24 and every half are exact.
  const size_t pixel_bytes = spec.pixel_bytes(true);
  std::vector<unsigned char> buf(static_cast<size_t>(spec.width) * spec.height * pixel_bytes);
  if (!in->read_image(0, 0, 0, nch, TypeUnknown, buf.data()) || in->has_error())
    fail_at(path, "corrupt or truncated EXR (" + in->geterror() + ")");
  for (int c = 0, offset = 0; c < nch; offset += static_cast<int>(spec.channelformat(c).size()), ++c) {
    ImageF ch(spec.width, spec.height, 1, uninitialized);
    const TypeDesc t = spec.channelformat(c);
    const unsigned char* src = buf.data() + offset;
    for (size_t p = 0, n = ch.size(); p < n; ++p, src += pixel_bytes) {
      if (t == TypeDesc::UINT) { uint32_t u; std::memcpy(&u, src, 4); ch[p] = static_cast<float>(u); }
      else if (t == TypeDesc::HALF) { half v; std::memcpy(&v, src, 2); ch[p] = static_cast<float>(v); }
      else if (t == TypeDesc::FLOAT) std::memcpy(&ch[p], src, 4);
      else fail_at(path, fmt::format("channel {} has pixel type {}, not float, half or uint", c, t.c_str()));
    }
    std::string name = c < static_cast<int>(spec.channelnames.size()) ? spec.channelnames[c]
                                                                       : fmt::format("ch{}", c);
    auto u = spec.find_attribute("photosite/unit/" + name);
    if (u) ch.set_unit(u->get_string());
    r.pixel_types[name] = t == TypeDesc::UINT ? ExrPixel::Uint : t == TypeDesc::HALF ? ExrPixel::Half : ExrPixel::Float;
    r.channels.emplace(name, std::move(ch));
  }
  for (const auto& a : spec.extra_attribs) r.attributes[a.name().string()] = a.get_string();
  in->close();
  return r;
}

void write_png(const std::string& path, const ImageF& image, int bits) {
  ImageSpec spec(image.width(), image.height(), image.channels(),
                 bits == 16 ? TypeDesc::UINT16 : TypeDesc::UINT8);
  spec.attribute("DateTime", "0000:00:00 00:00:00");  // previews carry no wall-clock time
  // zlib level 1 instead of OpenImageIO's default 6: `batch --format png --layers sensor,labels`
  // went from 716 to 352 ms per 2048x1024 image end to end for 6 % larger files
  // (docs/benchmarks.md); PNG stays lossless either way.
  spec.attribute("png:compressionLevel", 1);
  atomic_write(path, [&](const std::string& tmp) {
    // Keep the real extension on the temporary so OIIO picks the right writer.
    auto out = ImageOutput::create(path);
    if (!out) fail_at(path, "no image writer for this file extension");
    if (!out->open(tmp, spec)) fail_at(path, "cannot write (" + out->geterror() + ")");
    if (!out->write_image(TypeDesc::FLOAT, image.data()))
      fail_at(path, "write failed (" + out->geterror() + ")");
    if (!out->close()) fail_at(path, "write failed (" + out->geterror() + ")");
  });
}

void write_png8(const std::string& path, const ImageU8& image) {
  const int ch = image.channels();
  if (ch != 1 && ch != 3) internal_error(fmt::format("write_png8: {} channels", ch));
  // One filter for every row and one whole-buffer deflate (core/png_codec.h; the setting and
  // its measurement against the others in docs/cli.md "PNG input and output").
  const std::string bytes = png::encode(image.data(), image.width(), image.height(), ch, png::default_encode_options());
  atomic_write(path, [&](const std::string& tmp) {
    std::FILE* f = std::fopen(tmp.c_str(), "wb");
    if (!f) fail_at(path, std::string("cannot write (") + std::strerror(errno) + ")");
    const bool written = std::fwrite(bytes.data(), 1, bytes.size(), f) == bytes.size() && std::fflush(f) == 0;
    const int close_errno = std::fclose(f) == 0 ? 0 : errno;
    if (!written || close_errno) fail_at(path, std::string("write failed (") + std::strerror(close_errno ? close_errno : EIO) + ")");
  });
}

void check_output_path(const std::string& path, bool overwrite) {
  if (path.empty()) fail("no output path given");
  fs::path p(path);
  fs::path dir = p.parent_path().empty() ? fs::path(".") : p.parent_path();
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) fail_at(path, "output folder " + dir.string() + " does not exist");
  if (fs::exists(p, ec) && !overwrite)
    fail_parameter("overwrite", path + ": already exists; photosite never overwrites a file unless ", " is given");
  if (access(dir.c_str(), W_OK) != 0) fail_at(path, "output folder is not writable");
}

namespace {
// Writes through a temporary beside the target ('.<stem>.tmp-<pid>-<n><ext>', the extension kept
// so OpenImageIO picks the writer), then publishes it: rename (replacing) or link (never
// replacing). The temporary is removed on every error.
bool write_then_publish(const std::string& path, const std::function<void(const std::string&)>& write,
                        bool replace) {
  static std::atomic<unsigned> counter{0};
  fs::path p(path);
  std::string tmp = (p.parent_path() / ("." + p.stem().string() + fmt::format(".tmp-{}-{}", getpid(), counter++))).string() + p.extension().string();
  struct Remove {
    const std::string& tmp;
    ~Remove() {
      std::error_code ec;
      fs::remove(tmp, ec);
    }
  } remove{tmp};
  write(tmp);
  if (replace) {
    std::error_code ec;
    fs::rename(tmp, path, ec);
    if (ec) fail_at(path, "cannot move the finished file into place: " + ec.message());
    return true;
  }
  if (::link(tmp.c_str(), path.c_str()) == 0) return true;
  if (errno == EEXIST) return false;
  fail_at(path, std::string("cannot move the finished file into place: ") + std::strerror(errno));
}
}  // namespace

void atomic_write(const std::string& path, const std::function<void(const std::string&)>& write) {
  write_then_publish(path, write, true);
}

bool atomic_create(const std::string& path, const std::function<void(const std::string&)>& write) {
  return write_then_publish(path, write, false);
}

std::string frame_path(const std::string& pattern, int frame) {
  auto first = pattern.find('#');
  if (first == std::string::npos) return pattern;
  auto last = pattern.find_first_not_of('#', first);
  size_t n = (last == std::string::npos ? pattern.size() : last) - first;
  return pattern.substr(0, first) + fmt::format("{:0{}d}", frame, n) + pattern.substr(first + n);
}

}  // namespace photosite
