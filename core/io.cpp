#include "photosite/io.h"

#include <Imath/half.h>
#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfDoubleAttribute.h>
#include <OpenEXR/ImfFloatAttribute.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfIntAttribute.h>
#include <OpenEXR/ImfOutputFile.h>
#include <OpenEXR/ImfStandardAttributes.h>
#include <OpenEXR/ImfStringAttribute.h>
#include <OpenEXR/ImfThreading.h>
#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <spng.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cstdio>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <cctype>
#include <cmath>
#include <mutex>
#include <optional>
#include <regex>
#include <filesystem>
#include <fstream>
#include <ctime>
#include <thread>
#include <vector>
#include <fmt/format.h>
#include <fmt/ranges.h>

#include "core/io_detail.h"
#include "core/png_codec.h"
#include "core/raster_codecs.h"
#include "photosite/checksum.h"
#include "photosite/environment.h"
#include "photosite/error.h"
#include "photosite/night_chain.h"
#include "photosite/output_set.h"

namespace photosite {
namespace fs = std::filesystem;
using codec::Raster;
using codec::Sample;

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
  if (!f) return;  // the reader reports it
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
  // For the offset table's check below: version bits 9 (tiled) and 11 (deep data).
  const bool tiled_or_deep = head[5] & 0x0a;
  int64_t data_window[4] = {0, 0, -1, -1};  // xmin, ymin, xmax, ymax
  int compression = -1;
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
      if (name == "dataWindow" && type == "box2i") {
        unsigned char v[16];
        if (std::fread(v, 1, 16, f) != 16) bad("is truncated");
        for (int i = 0; i < 4; ++i)
          data_window[i] = static_cast<int32_t>(v[4 * i] | v[4 * i + 1] << 8 | v[4 * i + 2] << 16 | uint32_t{v[4 * i + 3]} << 24);
      } else if (name == "compression" && type == "compression") {
        compression = std::fgetc(f);
      } else if (type == "chlist") {  // channels: "name\0" + 16 bytes each, ended by an empty name
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
  // A single-part scan-line file: its header is followed by the offset table, one 64-bit file
  // offset per chunk of lines (1, 16, 32 or 256 lines by the compression), then the chunks.
  // OpenEXR reads an offset only when it reads that chunk, after the whole data window has been
  // allocated: a file cut short (or a header whose data window was damaged) asked for gigabytes
  // before failing (a 25 kB file whose header says 16384x16384 float RGB: 3.2 GB). An offset
  // outside the file is such damage; a 0 is an offset the writer never filled in (OpenEXR then
  // rebuilds the table by walking the chunks), left to OpenEXR.
  static const int lines_per_chunk[10] = {1, 1, 1, 16, 32, 16, 32, 32, 32, 256};  // NO ... DWAB_COMPRESSION
  if (multipart || tiled_or_deep || compression < 0 || compression > 9 || data_window[2] < data_window[0] ||
      data_window[3] < data_window[1])
    return;
  const int64_t width = data_window[2] - data_window[0] + 1, height = data_window[3] - data_window[1] + 1;
  const int64_t chunks = (height + lines_per_chunk[compression] - 1) / lines_per_chunk[compression];
  const int64_t table_start = std::ftell(f), table_end = table_start + 8 * chunks;
  if (table_end > file_size)
    fail_at(path, fmt::format("corrupt or truncated EXR (the file's {} bytes end inside the offset table of its {} "
                              "chunks, for a {}x{} data window); refused before allocating it",
                              file_size, chunks, width, height));
  for (int64_t i = 0; i < chunks; ++i) {
    unsigned char b[8];
    if (std::fread(b, 1, 8, f) != 8) fail_at(path, "corrupt or truncated EXR (read error in the offset table)");
    uint64_t offset = 0;
    for (int k = 7; k >= 0; --k) offset = offset << 8 | b[k];
    // A chunk starts with its first line's y and its data's size (8 bytes) after the table.
    if (offset != 0 && (offset < static_cast<uint64_t>(table_end) || offset > static_cast<uint64_t>(file_size - 8)))
      fail_at(path, fmt::format("corrupt or truncated EXR (the offset table puts chunk {} of {} at byte {}, outside "
                                "the file's chunks, bytes {} to {}: a file cut short?); refused before allocating "
                                "its {}x{} data window",
                                i, chunks, offset, table_end, file_size, width, height));
  }
}


// ---- the formats ----------------------------------------------------------------------------
enum class Format { Png, Jpeg, Tiff, Exr, Unknown };

// By the file's first bytes (its signature), not its name: PNG 89 50 4E 47 0D 0A 1A 0A, JPEG
// FF D8 FF, TIFF "II*\0" or "MM\0*", OpenEXR 76 2F 31 01. Every reader starts here, so the
// input checks are made here (check_input_file: a pipe would block or lose its first bytes).
Format sniff(const std::string& path) {
  check_input_file(path);
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) fail_at(path, std::string("cannot open (") + std::strerror(errno) + ")");
  unsigned char b[8] = {};
  const size_t n = std::fread(b, 1, 8, f);
  std::fclose(f);
  static const unsigned char png_sig[8] = {0x89, 'P', 'N', 'G', 0x0d, 0x0a, 0x1a, 0x0a};
  if (n >= 8 && std::memcmp(b, png_sig, 8) == 0) return Format::Png;
  if (n >= 3 && b[0] == 0xff && b[1] == 0xd8 && b[2] == 0xff) return Format::Jpeg;
  if (n >= 4 && ((b[0] == 'I' && b[1] == 'I' && b[2] == 42 && b[3] == 0) || (b[0] == 'M' && b[1] == 'M' && b[2] == 0 && b[3] == 42)))
    return Format::Tiff;
  if (n >= 4 && b[0] == 0x76 && b[1] == 0x2f && b[2] == 0x31 && b[3] == 0x01) return Format::Exr;
  return Format::Unknown;
}

}  // namespace

std::vector<uint8_t> codec::read_file(const std::string& path) {
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) fail_at(path, std::string("cannot open (") + std::strerror(errno) + ")");
  std::error_code ec;
  std::vector<uint8_t> bytes(fs::file_size(path, ec));
  const size_t got = ec ? 0 : std::fread(bytes.data(), 1, bytes.size(), f);
  const bool bad = ec || got != bytes.size() || std::ferror(f);
  std::fclose(f);
  if (bad) fail_at(path, "read error" + (ec ? " (" + ec.message() + ")" : std::string()));
  return bytes;
}

namespace {

// Any PNG through libspng (the plain data-set files go through core/png_codec.h first): 8- and
// 16-bit samples as stored; palette images expanded to RGB, 1/2/4-bit grey to 8 bits, a tRNS
// chunk to an alpha channel (what libpng's png_set_expand gives, OpenImageIO's reader).
// Alpha is kept as stored, not premultiplied into the colour.
// A header's size is checked before libspng sees it (libspng answered 2^31-1 x 2^31-1 with
// "arithmetic overflow"), and the file's length against what its pixels need at deflate's
// largest expansion: a 200-byte file whose header says 16384x16384 RGBA 16-bit had libspng
// allocate its 2.1 GB before finding the data short.
void check_png_header_size(const std::string& path, const std::vector<uint8_t>& bytes) {
  static const uint8_t ihdr_start[16] = {0x89, 'P', 'N', 'G', 0x0d, 0x0a, 0x1a, 0x0a, 0, 0, 0, 13, 'I', 'H', 'D', 'R'};
  if (bytes.size() < 33 || std::memcmp(bytes.data(), ihdr_start, 16) != 0) return;  // libspng names it
  const auto be32 = [&](size_t i) {
    return int64_t{bytes[i]} << 24 | int64_t{bytes[i + 1]} << 16 | int64_t{bytes[i + 2]} << 8 | int64_t{bytes[i + 3]};
  };
  const int64_t w = be32(16), h = be32(20), bits = bytes[24];
  if (w == 0 || h == 0) return;  // libspng's "invalid width/height"
  check_image_size(path, w, h);
  // Samples a pixel: grey 1, RGB 3, palette index 1, grey + alpha 2, RGBA 4 (PNG 2nd ed. 11.2.2).
  static const int samples[7] = {1, 0, 3, 1, 2, 0, 4};
  const int colour = bytes[25];
  if (colour > 6 || samples[colour] == 0 || bits < 1 || bits > 16) return;  // libspng names it
  // The samples alone, without the rows' filter bytes or Adam7's extra rows: a lower bound (in
  // double: PHOTOSITE_MAX_PIXELS may allow more pixels than an int64 holds bits of).
  const double sample_bytes = std::ceil(static_cast<double>(w) * static_cast<double>(h) * samples[colour] * bits / 8);
  const double most = static_cast<double>(png::kMaxDeflateRatio) * static_cast<double>(bytes.size());
  if (sample_bytes > most)
    fail_at(path, fmt::format("corrupt or truncated image (PNG data: the header's {}x{} pixels need {:.0f} bytes of "
                              "samples, more than the file's {} bytes hold at deflate's largest expansion, 1032:1); "
                              "refused before allocating them",
                              w, h, sample_bytes, bytes.size()));
}

Raster read_png_any(const std::string& path) {
  const std::vector<uint8_t> bytes = codec::read_file(path);
  check_png_header_size(path, bytes);
  std::unique_ptr<spng_ctx, void (*)(spng_ctx*)> ctx(spng_ctx_new(0), spng_ctx_free);
  if (!ctx) internal_error("libspng: no context");
  const auto check = [&](int e, const char* what) {
    if (e) fail_at(path, fmt::format("corrupt or truncated image (PNG {}: {})", what, spng_strerror(e)));
  };
  check(spng_set_png_buffer(ctx.get(), bytes.data(), bytes.size()), "header");
  spng_ihdr ihdr{};
  check(spng_get_ihdr(ctx.get(), &ihdr), "header");
  check_image_size(path, ihdr.width, ihdr.height);
  spng_trns trns{};
  const bool has_trns = spng_get_trns(ctx.get(), &trns) == 0;
  Raster r;
  r.format = "png";
  r.width = static_cast<int>(ihdr.width);
  r.height = static_cast<int>(ihdr.height);
  const bool deep = ihdr.bit_depth == 16;
  int fmt_ = SPNG_FMT_PNG, flags = 0;
  switch (ihdr.color_type) {
    case SPNG_COLOR_TYPE_GRAYSCALE:
      r.channels = has_trns ? 2 : 1;
      if (has_trns) fmt_ = deep ? SPNG_FMT_GA16 : SPNG_FMT_GA8, flags = SPNG_DECODE_TRNS;
      else if (ihdr.bit_depth < 8) fmt_ = SPNG_FMT_G8;
      break;
    case SPNG_COLOR_TYPE_TRUECOLOR:
      r.channels = has_trns ? 4 : 3;
      if (has_trns) fmt_ = deep ? SPNG_FMT_RGBA16 : SPNG_FMT_RGBA8, flags = SPNG_DECODE_TRNS;
      break;
    case SPNG_COLOR_TYPE_INDEXED:
      r.channels = has_trns ? 4 : 3;
      fmt_ = has_trns ? SPNG_FMT_RGBA8 : SPNG_FMT_RGB8;
      flags = has_trns ? SPNG_DECODE_TRNS : 0;
      break;
    case SPNG_COLOR_TYPE_GRAYSCALE_ALPHA: r.channels = 2; break;
    case SPNG_COLOR_TYPE_TRUECOLOR_ALPHA: r.channels = 4; break;
    default: fail_at(path, "corrupt or truncated image (PNG colour type)");
  }
  r.sample = deep && ihdr.color_type != SPNG_COLOR_TYPE_INDEXED ? Sample::U16 : Sample::U8;
  r.channel_samples.assign(r.channels, r.sample);
  size_t size = 0;
  check(spng_decoded_image_size(ctx.get(), fmt_, &size), "size");
  if (size != static_cast<size_t>(r.width) * r.height * r.channels * codec::sample_bytes(r.sample))
    internal_error(fmt::format("{}: libspng's decoded size {} differs from the expected layout", path, size));
  r.bytes.resize(size);
  check(spng_decode_image(ctx.get(), r.bytes.data(), size, fmt_, flags), "data");
  // A gAMA of 1.0 without an sRGB chunk says the codes are linear (OpenImageIO names it "Linear").
  uint8_t intent = 0;
  double gamma = 0;
  r.linear = spng_get_srgb(ctx.get(), &intent) != 0 && spng_get_gama(ctx.get(), &gamma) == 0 &&
             gamma > 0.99 && gamma < 1.01;
  return r;
}

// OpenImageIO's order of an OpenEXR file's channels (its exrinput.cpp, query_channels): by layer
// (the name up to its last '.'), then within a layer R, G, B, Y, ..., A, ..., Z (or R, G, B, X, Y,
// Z, ... where X comes with Y or Z), then the file's own (alphabetical) order. So a file's "B",
// "G", "R" read as R, G, B, as every reader of the library has had them.
std::vector<int> exr_channel_order(const std::vector<std::string>& names) {
  struct Ch { std::string layer, suffix; int n, special; };
  std::vector<Ch> ch;
  for (int i = 0; i < static_cast<int>(names.size()); ++i) {
    const auto dot = names[i].find_last_of('.');
    ch.push_back(dot == std::string::npos ? Ch{"", names[i], i, 10000}
                                          : Ch{names[i].substr(0, dot + 1), names[i].substr(dot + 1), i, 10000});
  }
  const auto iequals = [](const std::string& a, const char* b) {
    return a.size() == std::strlen(b) && std::equal(a.begin(), a.end(), b, [](char x, char y) {
             return std::tolower(static_cast<unsigned char>(x)) == std::tolower(static_cast<unsigned char>(y));
           });
  };
  std::stable_sort(ch.begin(), ch.end(), [](const Ch& a, const Ch& b) { return a.layer < b.layer; });
  static const char* usual[] = {"R", "Red", "G", "Green", "B", "Blue", "Y", "real", "imag", "A", "Alpha",
                                "AR", "RA", "AG", "GA", "AB", "BA", "Z", "Depth", "Zback", nullptr};
  static const char* xyz[] = {"R", "Red", "G", "Green", "B", "Blue", "X", "Y", "Z", "real", "imag", "A",
                              "Alpha", "AR", "RA", "AG", "GA", "AB", "BA", "Depth", "Zback", nullptr};
  for (auto b = ch.begin(); b != ch.end();) {
    auto e = b + 1;
    while (e != ch.end() && e->layer == b->layer) ++e;
    const auto has = [&](const char* s) { return std::any_of(b, e, [&](const Ch& c) { return iequals(c.suffix, s); }); };
    const char** table = has("X") && (has("Y") || has("Z")) ? xyz : usual;
    for (auto c = b; c != e; ++c)
      for (int i = 0; table[i]; ++i)
        if (iequals(c->suffix, table[i])) { c->special = i; break; }
    std::sort(b, e, [](const Ch& x, const Ch& y) { return x.special != y.special ? x.special < y.special : x.n < y.n; });
    b = e;
  }
  std::vector<int> order;
  for (const auto& c : ch) order.push_back(c.n);
  return order;
}

Sample sample_of(Imf::PixelType t) {
  return t == Imf::UINT ? Sample::U32 : t == Imf::HALF ? Sample::Half : Sample::F32;
}
Imf::PixelType pixel_type_of(Sample s) {
  return s == Sample::U32 ? Imf::UINT : s == Sample::Half ? Imf::HALF : Imf::FLOAT;
}

// The names OpenImageIO gave OpenEXR's compressions (and `--compression` takes).
const std::pair<const char*, Imf::Compression> kExrCompressions[] = {
    {"none", Imf::NO_COMPRESSION}, {"rle", Imf::RLE_COMPRESSION},     {"zips", Imf::ZIPS_COMPRESSION},
    {"zip", Imf::ZIP_COMPRESSION}, {"piz", Imf::PIZ_COMPRESSION},     {"pxr24", Imf::PXR24_COMPRESSION},
    {"b44", Imf::B44_COMPRESSION}, {"b44a", Imf::B44A_COMPRESSION},   {"dwaa", Imf::DWAA_COMPRESSION},
    {"dwab", Imf::DWAB_COMPRESSION}};

// OpenEXR's worker threads (its global pool), one per hardware thread, set once: line blocks are
// compressed and decompressed in parallel. $PHOTOSITE_EXR_THREADS (fuzzing: 0, no pool) overrides.
void init_exr_threads() {
  static const bool once = [] {
    int n = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
    if (const auto e = env::get(env::Var::ExrThreads)) {
      char* end = nullptr;
      const long v = std::strtol(e->c_str(), &end, 10);
      if (!end || *end || v < 0 || v > 1024) fail(std::string("PHOTOSITE_EXR_THREADS='") + *e + "' is not a whole number from 0 to 1024");
      n = static_cast<int>(v);
    }
    Imf::setGlobalThreadCount(n);
    return true;
  }();
  (void)once;
}

// An attribute's value as text: strings as they are, ints and floats as OpenImageIO printed them
// (%g for floats), doubles as the shortest text that reads back to the same double (%g's six
// digits lost a raw's clip level, photosite/clipped_at_dn, and any count above 999,999),
// vectors and boxes as comma lists; other types by their type name.
std::string attribute_text(const Imf::Attribute& a) {
  if (const auto* s = dynamic_cast<const Imf::StringAttribute*>(&a)) return s->value();
  if (const auto* i = dynamic_cast<const Imf::IntAttribute*>(&a)) return fmt::format("{}", i->value());
  if (const auto* f = dynamic_cast<const Imf::FloatAttribute*>(&a)) return fmt::format("{:g}", f->value());
  if (const auto* d = dynamic_cast<const Imf::DoubleAttribute*>(&a)) return fmt::format("{}", d->value());
  return a.typeName();
}

// An OpenEXR header's data window not at (0, 0), or a display window other than the data window:
// the readers take the data window's pixels as the image, from (0, 0), and keep neither window
// (an image here is its pixels, with no origin). "" when there is nothing to say.
bool exr_windows_plain(const Imf::Header& h) {
  return h.dataWindow().min == Imath::V2i(0, 0) && h.dataWindow() == h.displayWindow();
}
std::string box_text(const Imath::Box2i& b) {  // "xmin,ymin,xmax,ymax", OpenEXR's box2i
  return fmt::format("{},{},{},{}", b.min.x, b.min.y, b.max.x, b.max.y);
}
std::string exr_window_note(const Imf::Header& h) {
  if (exr_windows_plain(h)) return {};
  const Imath::Box2i d = h.dataWindow(), v = h.displayWindow();
  const auto size = [](const Imath::Box2i& b) {
    return fmt::format("{}x{}", int64_t{b.max.x} - b.min.x + 1, int64_t{b.max.y} - b.min.y + 1);
  };
  return fmt::format("its data window is {} at ({}, {}), its display window {} at ({}, {}): read as the data "
                     "window's {} pixels, from (0, 0); neither the origin nor the display window is kept",
                     size(d), d.min.x, d.min.y, size(v), v.min.x, v.min.y, size(d));
}

// Said on the standard error by both pixel readers (read_exr_raster, read_exr: every command and
// the Python module; the commands' own output, on the standard output, stays what it was), after
// the pixels are read; `expose` also records both windows in its header. The note ("" when there
// is nothing to say), for the reader's Raster::note.
std::string note_exr_windows(const std::string& path, const Imf::Header& h) {
  std::string note = exr_window_note(h);
  if (!note.empty()) std::fprintf(stderr, "photosite: note: %s: %s\n", path.c_str(), note.c_str());
  return note;
}

// The header's attributes beyond the layout, by name, as text (attribute_text); capDate as
// OpenImageIO's DateTime, the compression by its name. The data and display windows only where
// they say more than the image's size (exr_window_note), as "xmin,ymin,xmax,ymax".
std::map<std::string, std::string> exr_attributes(const Imf::Header& h) {
  std::map<std::string, std::string> a;
  for (auto it = h.begin(); it != h.end(); ++it) {
    const std::string n = it.name();
    if (n == "channels" || n == "dataWindow" || n == "displayWindow" || n == "lineOrder" || n == "compression") continue;
    a[n == "capDate" ? "DateTime" : n] = attribute_text(it.attribute());
  }
  for (const auto& [name, c] : kExrCompressions)
    if (c == h.compression()) a["compression"] = name;
  if (!exr_windows_plain(h)) {
    a["dataWindow"] = box_text(h.dataWindow());
    a["displayWindow"] = box_text(h.displayWindow());
  }
  return a;
}

// Runs f(file, data window, width, height) on the first part of the OpenEXR file at `path`,
// opened after the header walk (check_exr_header), with the data window's size and the channel
// list (1 to 64 channels, none subsampled) checked before any pixel is allocated; OpenEXR's
// exceptions (Iex) become bad input naming the file.
template <class F>
auto with_exr_file(const std::string& path, F&& f) {
  init_exr_threads();
  check_exr_header(path);
  try {
    Imf::InputFile file(path.c_str());
    const Imath::Box2i dw = file.header().dataWindow();
    const int64_t w = int64_t{dw.max.x} - dw.min.x + 1, h = int64_t{dw.max.y} - dw.min.y + 1;
    check_image_size(path, w, h);
    int channels = 0;
    for (auto it = file.header().channels().begin(); it != file.header().channels().end(); ++it, ++channels)
      if (it.channel().xSampling != 1 || it.channel().ySampling != 1)
        fail_at(path, fmt::format("cannot read image (channel {} is subsampled, {}x{})", it.name(),
                                  it.channel().xSampling, it.channel().ySampling));
    if (channels == 0) fail_at(path, "image has no channels");
    if (channels > 64) fail_at(path, fmt::format("image declares {} channels", channels));
    return f(file, dw, static_cast<int>(w), static_cast<int>(h));
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {
    fail_at(path, std::string("corrupt or truncated EXR (") + e.what() + ")");
  }
}

// The whole first part of an OpenEXR file (scan lines or tiles) in each channel's own type,
// channels in OpenImageIO's order (exr_channel_order).
Raster read_exr_raster(const std::string& path) {
  return with_exr_file(path, [&](Imf::InputFile& file, const Imath::Box2i& dw, int w, int hh) {
    const Imf::Header& h = file.header();
    Raster r;
    r.format = "openexr";
    r.linear = true;
    std::vector<std::string> names;
    std::vector<Imf::Channel> chans;
    for (auto it = h.channels().begin(); it != h.channels().end(); ++it) {
      names.push_back(it.name());
      chans.push_back(it.channel());
    }
    r.width = w;
    r.height = hh;
    r.channels = static_cast<int>(names.size());
    size_t pixel_bytes = 0;
    std::vector<size_t> offset;
    for (int i : exr_channel_order(names)) {
      r.channel_names.push_back(names[i]);
      r.channel_samples.push_back(sample_of(chans[i].type));
      offset.push_back(pixel_bytes);
      pixel_bytes += codec::sample_bytes(r.channel_samples.back());
    }
    r.sample = r.channel_samples[0];
    r.bytes.resize(static_cast<size_t>(w) * hh * pixel_bytes);
    const size_t row_bytes = static_cast<size_t>(w) * pixel_bytes;
    // OpenEXR addresses pixel (x, y) of the data window at base + x·xStride + y·yStride.
    char* base = reinterpret_cast<char*>(r.bytes.data()) - static_cast<ptrdiff_t>(dw.min.x) * static_cast<ptrdiff_t>(pixel_bytes) -
                 static_cast<ptrdiff_t>(dw.min.y) * static_cast<ptrdiff_t>(row_bytes);
    Imf::FrameBuffer fb;
    for (int c = 0; c < r.channels; ++c)
      fb.insert(r.channel_names[c], Imf::Slice(pixel_type_of(r.channel_samples[c]), base + offset[c], pixel_bytes, row_bytes));
    file.setFrameBuffer(fb);
    file.readPixels(dw.min.y, dw.max.y);
    r.attributes = exr_attributes(h);
    r.note = note_exr_windows(path, h);
    return r;
  });
}

// The format of the image file at `path`, which must be a regular file (sniff checks it).
Format format_of_file(const std::string& path) { return sniff(path); }

// The file as it is stored: by its signature, through its format's codec.
Raster read_raster(const std::string& path) {
  Raster r;
  switch (format_of_file(path)) {
    case Format::Png: r = read_png_any(path); break;
    case Format::Jpeg: r = codec::read_jpeg(path); break;
    case Format::Tiff: r = codec::read_tiff(path); break;
    case Format::Exr: r = read_exr_raster(path); break;
    case Format::Unknown: fail_at(path, "cannot read image (not a PNG, JPEG, TIFF or OpenEXR file)");
  }
  if (r.channels <= 0) fail_at(path, "image has no channels");
  if (r.channels > 64) fail_at(path, fmt::format("image declares {} channels", r.channels));
  return r;
}

ImageFileInfo info_of(const std::string& path, const Raster& r) {
  ImageFileInfo info;
  info.path = path;
  info.format = r.format;
  info.width = r.width;
  info.height = r.height;
  info.channels = r.channels;
  info.bits_per_sample = codec::sample_bytes(r.sample) * 8;
  info.is_float = r.sample == Sample::Half || r.sample == Sample::F32;
  info.srgb_encoded = !info.is_float && !r.linear;
  info.note = r.note;
  return info;
}

// A stored sample as float, as OpenImageIO converts: integers scaled to [0, 1] by their largest
// code (code · (1/max) in float), half and float as they are.
ImageF to_float(const Raster& r) {
  ImageF img(r.width, r.height, r.channels, uninitialized);
  const size_t n = static_cast<size_t>(r.width) * r.height;
  size_t pixel_bytes = 0;
  for (Sample s : r.channel_samples) pixel_bytes += codec::sample_bytes(s);
  size_t off = 0;
  for (int c = 0; c < r.channels; ++c) {
    const Sample s = r.channel_samples[c];
    const uint8_t* src = r.bytes.data() + off;
    float* dst = img.data() + c;
    const int ch = r.channels;
    switch (s) {
      case Sample::U8: for (size_t p = 0; p < n; ++p) dst[p * ch] = src[p * pixel_bytes] * (1.f / 255); break;
      case Sample::U16:
        for (size_t p = 0; p < n; ++p) { uint16_t v; std::memcpy(&v, src + p * pixel_bytes, 2); dst[p * ch] = v * (1.f / 65535); }
        break;
      case Sample::U32:
        for (size_t p = 0; p < n; ++p) { uint32_t v; std::memcpy(&v, src + p * pixel_bytes, 4); dst[p * ch] = static_cast<float>(v) * (1.f / 4294967295.f); }
        break;
      case Sample::Half:
        for (size_t p = 0; p < n; ++p) { half v; std::memcpy(&v, src + p * pixel_bytes, 2); dst[p * ch] = static_cast<float>(v); }
        break;
      case Sample::F32: for (size_t p = 0; p < n; ++p) std::memcpy(&dst[p * ch], src + p * pixel_bytes, 4); break;
    }
    off += codec::sample_bytes(s);
  }
  return img;
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

void check_image_size(const std::string& what, int64_t width, int64_t height) {
  if (width < 1 || height < 1) fail_at(what, fmt::format("image size {}x{} is empty", width, height));
  if (width * height > max_frame_pixels())
    fail_at(what, fmt::format("frame size {}x{} is larger than the limit of {} pixels "
                              "(PHOTOSITE_MAX_PIXELS); refused before allocating it",
                              width, height, max_frame_pixels()));
}

void check_frame_size(const std::string& what, int64_t width, int64_t height) {
  if (width < 2 || height < 2)
    fail_at(what, fmt::format("frame size {}x{} is too small (at least 2x2 pixels, one CFA tile)",
                              width, height));
  check_image_size(what, width, height);
}

ImageFileInfo probe_image(const std::string& path) {
  if (format_of_file(path) == Format::Exr)  // the header alone
    return with_exr_file(path, [&](Imf::InputFile& file, const Imath::Box2i&, int w, int h) {
      std::vector<std::string> names;
      std::vector<Imf::PixelType> types;
      for (auto it = file.header().channels().begin(); it != file.header().channels().end(); ++it)
        names.push_back(it.name()), types.push_back(it.channel().type);
      Raster r;
      r.format = "openexr";
      r.linear = true;
      r.width = w;
      r.height = h;
      r.channels = static_cast<int>(names.size());
      r.sample = sample_of(types[exr_channel_order(names)[0]]);
      return info_of(path, r);
    });
  return info_of(path, read_raster(path));
}

namespace {
// The plain PNGs of the data sets (8/16-bit grey or RGB, not interlaced, no colour chunks but sRGB's)
// decoded by core/png_codec.cpp: 1.2x to 2.6x less CPU than OpenImageIO's libpng reader and
// float conversion (`photosite bench batch`, docs/cli.md "PNG input and output"). Anything else
// (another format, a PNG the decoder does not take, a damaged file) returns nullopt and goes
// through read_raster (above): each format's own library, libspng for any other PNG, which also
// words the errors. (OpenImageIO is not linked into the library; where these comments say "as
// OpenImageIO", they name the conversions the readers keep from it, which the tests check.)
std::optional<png::Decoded> read_plain_png(const std::string& path, ImageFileInfo* info) {
  const fs::path p(path);
  const std::string ext = lower_extension(path);
  std::error_code ec;
  if (ext != ".png" || !fs::is_regular_file(p, ec)) return std::nullopt;
  auto d = png::decode(codec::read_file(path), max_frame_pixels());
  if (!d) return std::nullopt;
  check_image_size(path, d->width, d->height);
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
  const Raster r = read_raster(path);
  if (info) *info = info_of(path, r);
  return to_float(r);
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
  // The day photo becomes the sensor's frame: at least one CFA tile.
  check_frame_size(path, d.width(), d.height());
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
  const Raster r = read_raster(path);
  if (r.sample == Sample::Half || r.sample == Sample::F32)
    fail_at(path, "expected an integer (8- or 16-bit) image, found floating point");
  if (r.sample == Sample::U32) fail_at(path, "unsupported 32-bit integer samples");
  ImageU16 img(r.width, r.height, r.channels, uninitialized);
  if (r.sample == Sample::U8) std::copy(r.bytes.begin(), r.bytes.end(), img.data());
  else std::memcpy(img.data(), r.bytes.data(), r.bytes.size());
  if (info) *info = info_of(path, r);
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
  init_exr_threads();
  std::vector<std::string> names;
  std::vector<Sample> formats;  // per channel
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
    const Sample t = g.pixel == ExrPixel::Uint ? Sample::U32
                     : g.pixel == ExrPixel::Half || options.half ? Sample::Half
                                                                 : Sample::F32;
    for (const auto& n : g.channel_names) names.push_back(n), formats.push_back(t);
  }
  const int nch = static_cast<int>(names.size());
  // The header: OpenEXR's required attributes (data and display window the frame, pixel aspect
  // 1, increasing-y line order), the compression, and the units and provenance.
  Imf::Header header(w, h);
  for (const auto& [n, c] : kExrCompressions)
    if (options.compression == n) header.compression() = c;
  // DWA's quality in the header, at OpenEXR's default 45, as OpenImageIO wrote it.
  if (header.compression() == Imf::DWAA_COMPRESSION || header.compression() == Imf::DWAB_COMPRESSION)
    header.insert("dwaCompressionLevel", Imf::FloatAttribute(45.f));
  for (int c = 0; c < nch; ++c) {
    if (header.channels().findChannel(names[c])) internal_error("write_exr: channel " + names[c] + " twice in " + path);
    header.channels().insert(names[c], Imf::Channel(pixel_type_of(formats[c])));
  }
  // The capture date OpenImageIO wrote (its "DateTime"): the wall clock, or a fixed string for
  // byte-reproducible files.
  std::string date = "0000:00:00 00:00:00";
  if (!options.reproducible) {
    const std::time_t now = std::time(nullptr);
    std::tm tm{};
    localtime_r(&now, &tm);
    char b[32];
    std::strftime(b, sizeof b, "%Y:%m:%d %H:%M:%S", &tm);
    date = b;
  }
  Imf::addCapDate(header, date);
  for (const auto& g : groups)
    if (!g.unit.empty())
      for (const auto& n : g.channel_names) header.insert("photosite/unit/" + n, Imf::StringAttribute(g.unit));
  for (const auto& [key, v] : attributes) {
    const std::string& k = key;  // a plain reference: clang 14 cannot capture a structured binding
    std::visit([&](const auto& x) {
      using X = std::decay_t<decltype(x)>;
      if constexpr (std::is_same_v<X, std::string>) header.insert(k, Imf::StringAttribute(x));
      else if constexpr (std::is_same_v<X, int>) header.insert(k, Imf::IntAttribute(x));
      else header.insert(k, Imf::FloatAttribute(static_cast<float>(x)));
    }, v);
    if (std::holds_alternative<double>(v))  // keep full precision as text too
      header.insert(k + "_text", Imf::StringAttribute(fmt::format("{:.17g}", std::get<double>(v))));
  }
  // OpenEXR reads each float channel straight from its image (a slice: the first sample's
  // address and the steps between pixels and rows) while its worker threads compress the line
  // blocks before: no interleaved copy of the frame (a night result's 13 channels are 109 MB at
  // 2048x1024) and no pass of ours over the float layers. Its writer converts no pixel type, so
  // the half and UINT channels are converted here, a strip at a time (below): half by Imath's
  // half(float) (round to nearest even), UINT by truncation, exact on the integers checked here;
  // 16-bit class ids are widened to 32 bits, never through float. The file's bytes are those
  // written before, through OpenImageIO (Codecs.ExrWrittenAsOpenImageIOWroteIt). UINT channels
  // from float images must hold integers in [0, 2^32).
  for (const auto& g : groups) {
    if (g.image_u16 || g.pixel != ExrPixel::Uint) continue;
    const int gc = static_cast<int>(g.channel_names.size());
    const float* src = g.image->data();
    const size_t n = g.image->size();
    bool ok = true;
    for (size_t i = 0; i < n; ++i) ok &= src[i] >= 0.f && src[i] < 4294967296.f && src[i] == std::floor(src[i]);
    if (!ok)
      for (size_t i = 0; i < n; ++i)
        if (!(src[i] >= 0.f && src[i] < 4294967296.f) || src[i] != std::floor(src[i]))
          internal_error(fmt::format("write_exr: {} holds {} at pixel {}, not a 32-bit unsigned integer",
                                     g.channel_names[i % gc], src[i], i / gc));
  }
  // The converted channels, a strip of rows at a time into buffers of their own (a multiple of 32
  // rows, OpenEXR's largest line block, and about 8 MB; the file's bytes do not depend on the
  // strip's height), so the conversion holds no copy of the frame.
  struct Converted {
    const ExrChannelGroup* g;
    int c;         // channel within the group
    Sample type;   // Half or U32
    size_t offset; // in a strip row of the buffer
  };
  std::vector<Converted> conv;
  size_t conv_row = 0;  // bytes per pixel of the converted channels
  {
    int c0 = 0;
    for (const auto& g : groups) {
      const int gc = static_cast<int>(g.channel_names.size());
      for (int c = 0; c < gc; ++c)
        if (g.image_u16 || formats[c0 + c] != Sample::F32) {
          conv.push_back({&g, c, formats[c0 + c], conv_row});
          conv_row += codec::sample_bytes(formats[c0 + c]);
        }
      c0 += gc;
    }
  }
  const size_t conv_row_bytes = conv_row * static_cast<size_t>(w);
  const int strip = conv.empty() ? h : std::min(h, std::max(32, static_cast<int>((8u << 20) / conv_row_bytes) / 32 * 32));
  std::vector<unsigned char> buf(conv_row_bytes * (conv.empty() ? 0 : strip));
  // The float channels' slices: the same for every strip.
  Imf::FrameBuffer direct;
  {
    int c0 = 0;
    for (const auto& g : groups) {
      const int gc = static_cast<int>(g.channel_names.size());
      if (!g.image_u16 && formats[c0] == Sample::F32) {
        char* base = reinterpret_cast<char*>(const_cast<float*>(g.image->data()));
        for (int c = 0; c < gc; ++c)
          direct.insert(g.channel_names[c], Imf::Slice(Imf::FLOAT, base + 4 * c, 4 * gc, static_cast<size_t>(w) * gc * 4));
      }
      c0 += gc;
    }
  }
  const auto write = [&](const std::string& tmp) {
    try {
      Imf::OutputFile out(tmp.c_str(), header, Imf::globalThreadCount());
      for (int y0 = 0; y0 < h; y0 += strip) {
        const int y1 = std::min(h, y0 + strip);
        const size_t n = static_cast<size_t>(w) * (y1 - y0);
        Imf::FrameBuffer fb = direct;
        // The strip's row y0 is the buffer's first: OpenEXR addresses pixel (x, y) at
        // base + x·xStride + y·yStride.
        char* sbase = reinterpret_cast<char*>(buf.data()) - static_cast<ptrdiff_t>(y0) * static_cast<ptrdiff_t>(conv_row_bytes);
        for (const auto& v : conv) {
          const int gc = static_cast<int>(v.g->channel_names.size());
          unsigned char* dst = buf.data() + v.offset;
          const size_t first = static_cast<size_t>(y0) * w;
          if (v.g->image_u16) {
            const uint16_t* src = v.g->image_u16->data() + first * gc + v.c;
            for (size_t p = 0; p < n; ++p) {
              const uint32_t u = src[p * gc];
              std::memcpy(dst + p * conv_row, &u, 4);
            }
          } else if (v.type == Sample::U32) {
            const float* src = v.g->image->data() + first * gc + v.c;
            for (size_t p = 0; p < n; ++p) {
              const uint32_t u = static_cast<uint32_t>(src[p * gc]);
              std::memcpy(dst + p * conv_row, &u, 4);
            }
          } else {
            const float* src = v.g->image->data() + first * gc + v.c;
            for (size_t p = 0; p < n; ++p) {
              const half hv(src[p * gc]);
              std::memcpy(dst + p * conv_row, &hv, 2);
            }
          }
          fb.insert(v.g->channel_names[v.c], Imf::Slice(v.type == Sample::Half ? Imf::HALF : Imf::UINT, sbase + v.offset,
                                                         conv_row, conv_row_bytes));
        }
        out.setFrameBuffer(fb);
        out.writePixels(y1 - y0);
      }
    } catch (const Error&) {
      throw;
    } catch (const std::exception& e) {  // OpenEXR's Iex exceptions: a full disk, a lost folder
      fail_at(path, std::string("write failed (") + e.what() + ")");
    }
  };
  if (options.create_only) return atomic_create(path, write);
  atomic_write(path, write);
  return true;
}

ExrContents read_exr(const std::string& path) {
  if (sniff(path) != Format::Exr) fail_at(path, "not an OpenEXR file");
  // Each channel read straight into a float plane of its own: OpenEXR widens half and UINT
  // samples as it reads ((float) of each, exact for every half and for UINT values below 2^24),
  // with no interleaved copy of the file's pixels.
  return with_exr_file(path, [&](Imf::InputFile& file, const Imath::Box2i& dw, int w, int hh) {
    const Imf::Header& h = file.header();
    ExrContents r;
    r.width = w;
    r.height = hh;
    r.attributes = exr_attributes(h);
    Imf::FrameBuffer fb;
    for (auto it = h.channels().begin(); it != h.channels().end(); ++it) {
      const Imf::Channel& c = it.channel();
      const std::string name = it.name();
      ImageF& plane = r.channels.emplace(name, ImageF(w, hh, 1, uninitialized)).first->second;
      if (const auto u = r.attributes.find("photosite/unit/" + name); u != r.attributes.end()) plane.set_unit(u->second);
      r.pixel_types[name] = c.type == Imf::UINT ? ExrPixel::Uint : c.type == Imf::HALF ? ExrPixel::Half : ExrPixel::Float;
      // OpenEXR addresses pixel (x, y) of the data window at base + x·xStride + y·yStride.
      char* base = reinterpret_cast<char*>(plane.data()) - static_cast<ptrdiff_t>(dw.min.x) * 4 -
                   static_cast<ptrdiff_t>(dw.min.y) * static_cast<ptrdiff_t>(w) * 4;
      fb.insert(name, Imf::Slice(Imf::FLOAT, base, 4, static_cast<size_t>(w) * 4));
    }
    file.setFrameBuffer(fb);
    file.readPixels(dw.min.y, dw.max.y);
    note_exr_windows(path, h);
    return r;
  });
}

std::map<std::string, std::string> read_exr_attributes(const std::string& path) {
  if (sniff(path) != Format::Exr) fail_at(path, "not an OpenEXR file");
  return with_exr_file(path, [](Imf::InputFile& file, const Imath::Box2i&, int, int) { return exr_attributes(file.header()); });
}

uint8_t float_to_code8(float v) {
  // OpenImageIO's scaled conversion: v·255 ± 0.5 (away from zero), clamped, truncated.
  float s = v * 255.f;
  s += s < 0 ? -0.5f : 0.5f;
  return static_cast<uint8_t>(std::clamp(s, 0.f, 255.f));
}
uint16_t float_to_code16(float v) {
  float s = v * 65535.f;
  s += s < 0 ? -0.5f : 0.5f;
  return static_cast<uint16_t>(std::clamp(s, 0.f, 65535.f));
}

namespace {
// n bytes into the temporary tmp of path. A failed write, flush or close names the reason the
// C library gave for that call (a full disk, a file-size limit): the writers took the errno of
// fclose alone, which after a short fwrite had nothing left to flush and succeeded, so a full
// disk was reported as "Input/output error" (thirty-fourth session, a 1 MB tmpfs).
void write_bytes(const std::string& path, const std::string& tmp, const void* data, size_t n) {
  std::FILE* f = std::fopen(tmp.c_str(), "wb");
  if (!f) fail_at(path, std::string("cannot write (") + std::strerror(errno) + ")");
  errno = 0;
  int err = 0;
  if (std::fwrite(data, 1, n, f) != n || std::fflush(f) != 0) err = errno != 0 ? errno : EIO;
  if (std::fclose(f) != 0 && err == 0) err = errno != 0 ? errno : EIO;
  if (err != 0) fail_at(path, std::string("write failed (") + std::strerror(err) + ")");
}
}  // namespace

void write_png(const std::string& path, const ImageF& image, int bits) {
  if (bits != 8 && bits != 16) internal_error("write_png: bits must be 8 or 16");
  const int w = image.width(), h = image.height(), ch = image.channels();
  if (ch < 1 || ch > 4) fail_at(path, fmt::format("cannot write {} channels as an image file (1 to 4)", ch));
  const std::string ext = lower_extension(path);
  Raster r;
  r.width = w;
  r.height = h;
  r.channels = ch;
  r.sample = bits == 16 ? Sample::U16 : Sample::U8;
  r.channel_samples.assign(ch, r.sample);
  r.bytes.resize(image.size() * (bits / 8));
  if (bits == 8) for (size_t i = 0; i < image.size(); ++i) r.bytes[i] = float_to_code8(image[i]);
  else for (size_t i = 0; i < image.size(); ++i) { const uint16_t v = float_to_code16(image[i]); std::memcpy(&r.bytes[2 * i], &v, 2); }
  if (ext == ".tif" || ext == ".tiff") {
    atomic_write(path, [&](const std::string& tmp) { codec::write_tiff(tmp, r); });
    return;
  }
  if (ext != ".png") fail_at(path, "no image writer for this file extension (.png, .tif or .tiff)");
  // zlib level 1 (libspng's default is 6): `batch --format png --layers sensor,labels` went from
  // 716 to 352 ms per 2048x1024 image end to end for 6 % larger files when this was set
  // (docs/benchmarks.md); PNG stays lossless either way. No time or text chunks.
  std::unique_ptr<spng_ctx, void (*)(spng_ctx*)> ctx(spng_ctx_new(SPNG_CTX_ENCODER), spng_ctx_free);
  if (!ctx) internal_error("libspng: no encoder context");
  spng_set_option(ctx.get(), SPNG_ENCODE_TO_BUFFER, 1);
  spng_set_option(ctx.get(), SPNG_IMG_COMPRESSION_LEVEL, 1);
  spng_ihdr ihdr{};
  ihdr.width = static_cast<uint32_t>(w);
  ihdr.height = static_cast<uint32_t>(h);
  ihdr.bit_depth = static_cast<uint8_t>(bits);
  ihdr.color_type = ch == 1 ? SPNG_COLOR_TYPE_GRAYSCALE : ch == 2 ? SPNG_COLOR_TYPE_GRAYSCALE_ALPHA
                    : ch == 3 ? SPNG_COLOR_TYPE_TRUECOLOR : SPNG_COLOR_TYPE_TRUECOLOR_ALPHA;
  int e = spng_set_ihdr(ctx.get(), &ihdr);
  if (!e) e = spng_encode_image(ctx.get(), r.bytes.data(), r.bytes.size(), SPNG_FMT_PNG, SPNG_ENCODE_FINALIZE);
  if (e) fail_at(path, fmt::format("cannot write ({})", spng_strerror(e)));
  size_t len = 0;
  std::unique_ptr<void, void (*)(void*)> png(spng_get_png_buffer(ctx.get(), &len, &e), std::free);
  if (!png || e) fail_at(path, fmt::format("cannot write ({})", spng_strerror(e)));
  atomic_write(path, [&](const std::string& tmp) { write_bytes(path, tmp, png.get(), len); });
}

void write_png8(const std::string& path, const ImageU8& image) {
  const int ch = image.channels();
  if (ch != 1 && ch != 3) internal_error(fmt::format("write_png8: {} channels", ch));
  // One filter for every row and one whole-buffer deflate (core/png_codec.h; the setting and
  // its measurement against the others in docs/cli.md "PNG input and output").
  const std::string bytes = png::encode(image.data(), image.width(), image.height(), ch, png::default_encode_options());
  atomic_write(path, [&](const std::string& tmp) { write_bytes(path, tmp, bytes.data(), bytes.size()); });
}

// An input file must be a regular file (or a link to one). A pipe or device is refused: the file
// is read twice (its signature, then the image), and a pipe's first bytes would be gone by the
// second read.
void check_input_file(const std::string& path) {
  std::error_code ec;
  const fs::file_status st = fs::status(path, ec);
  if (st.type() == fs::file_type::not_found) fail_missing(path, "no such file");
  if (ec) fail_at(path, "cannot open (" + ec.message() + ")");  // e.g. a folder on the way the user cannot enter
  if (fs::is_directory(st)) fail_at(path, "is a folder, not an image file");
  if (!fs::is_regular_file(st))
    fail_at(path, "not a regular file (a pipe, socket or device); photosite reads an input file twice, so give a file");
}

void check_output_path(const std::string& path, bool overwrite) {
  if (path.empty()) fail("no output path given");
  fs::path p(path);
  fs::path dir = p.parent_path().empty() ? fs::path(".") : p.parent_path();
  std::error_code ec;
  const fs::file_status dst = fs::status(dir, ec);
  if (ec && dst.type() != fs::file_type::not_found)  // e.g. a folder on the way the user cannot enter
    fail_at(path, "cannot reach the output folder " + dir.string() + " (" + ec.message() + ")");
  if (!fs::is_directory(dst)) fail_at(path, "output folder " + dir.string() + " does not exist");
  // A folder there is never replaced, --overwrite or not (the rename would fail after the work).
  if (fs::is_directory(p, ec)) fail_at(path, "is a folder; name the output file");
  if (fs::exists(p, ec) && !overwrite)
    fail_parameter("overwrite", path + ": already exists; photosite never overwrites a file unless ", " is given");
  if (access(dir.c_str(), W_OK) != 0) fail_at(path, "output folder is not writable");
}

namespace {
// The temporaries being written, for remove_partial_outputs(): each slot null or the name of a
// live temporary (the std::string stays put while its write runs). Lock-free, so a signal handler
// may read them.
constexpr int kTemporarySlots = 64;
std::atomic<const char*> g_temporaries[kTemporarySlots];
static_assert(std::atomic<const char*>::is_always_lock_free);
struct TemporarySlot {
  int slot = -1;
  explicit TemporarySlot(const char* name) {
    for (int k = 0; k < kTemporarySlots && slot < 0; ++k) {
      const char* empty = nullptr;
      if (g_temporaries[k].compare_exchange_strong(empty, name)) slot = k;
    }
  }
  ~TemporarySlot() {
    if (slot >= 0) g_temporaries[slot].store(nullptr);
  }
};

// Writes through a temporary beside the target ('.<stem>.tmp-<scope>-<pid>-<n><ext>':
// hidden, its kind still shown by its extension, temporary_pid_scope() naming where its pid has
// a meaning), then publishes it: rename (replacing) or link (never replacing). The temporary is
// removed on every error, and by remove_partial_outputs.
//
// The temporary is created by this process, exclusively (O_CREAT | O_EXCL | O_NOFOLLOW, mode
// 0666 & ~umask as fopen's): its name is predictable, and in a folder others may write into (a
// shared device store or output folder) a name planted beforehand, a symbolic link to a file of
// the user's, would otherwise be opened through and that file overwritten. A name taken is
// skipped for the next. The writer is then given /proc/self/fd/<fd>, which opens this very file
// whatever its name has become since (replacing the name after the creation needs write access
// to the folder too, and reaches only the name); the link is made from the descriptor the same
// way. Without /proc the writer gets the name (the exclusive creation still stands).
std::atomic<OutputSet*> g_output_set{nullptr};
}  // namespace

namespace detail {
std::atomic<LinkatFn> publish_linkat{&::linkat};
std::atomic<Renameat2Fn> publish_renameat2{&::renameat2};
}  // namespace detail

namespace {

// Whether the name tmp is still the file (dev, ino) that was written there: if not, another
// process replaced it, and it must not be published (write_then_publish, OutputSet::commit).
bool still_the_file(const std::string& tmp, dev_t dev, ino_t ino) {
  struct stat b{};
  return ::lstat(tmp.c_str(), &b) == 0 && b.st_dev == dev && b.st_ino == ino;
}

// A finished temporary renamed onto its path (write_then_publish, OutputSet::commit).
void move_into_place(const std::string& tmp, const std::string& path) {
  std::error_code ec;
  fs::rename(tmp, path, ec);
  if (ec) fail_at(path, "cannot move the finished file into place: " + ec.message());
}

// Publishing without replacing (atomic_create, write_exr's create_only: the device store's maps).
// The first way is link(): atomic, and EEXIST when the name exists, so a published file is never
// replaced and never seen half-written. A file system without hard links (FAT, exFAT: EPERM; some
// FUSE and network file systems: EOPNOTSUPP, ENOSYS, or EXDEV for a link even within one folder)
// left no way to publish at all before the thirty-seventh session: a camera could not make its
// maps there, so it could not run. The fallbacks keep the guarantee as far as the file system
// allows:
//  1. renameat2(RENAME_NOREPLACE) of the finished temporary onto the name (Linux 3.15, glibc 2.28;
//     Debian 12 has glibc 2.36): as atomic as the link and refused alike (EEXIST) when the name
//     exists. Linux's own vfat and exfat drivers take the flag (their rename refuses only other
//     flags; not run here: this VM has neither driver), as ext4, xfs, btrfs and tmpfs do.
//  2. Where the flag is not honoured either (EINVAL: NFS, CIFS, file systems on libfuse 2 such as
//     fusefat, measured in docs/cli.md "Edge cases (thirty-seventh session)"): the name is created
//     exclusively (O_CREAT | O_EXCL, the one no-replace step every file system has, NFSv3
//     included), and the finished temporary is copied into it in full and fsync'd. An existing
//     file is still never replaced, but the name now exists while it is filled: a reader that
//     comes then finds a short file, which the device store's reader refuses (its header's size,
//     the data's checksum) and reads once more under the folder's lock that its creator holds
//     while it writes (DeviceStore::load_or_create). A copy that fails or is interrupted (SIGINT,
//     SIGTERM: remove_partial_outputs) is removed; only SIGKILL or a crash in the copy can leave
//     a short map, which the reader refuses naming the file and the remedy (remove it).
// Chosen over an exclusive create alone (writing the final name from the start): the copy keeps
// the window in which a partial file is visible to one read and write of the finished bytes
// instead of the whole encode.
bool no_hard_links(int e) { return e == EPERM || e == EOPNOTSUPP || e == ENOSYS || e == EXDEV; }

// Whether the name tmp is still the file open as fd.
bool still_the_file_fd(const std::string& tmp, int fd) {
  struct stat a{};
  return ::fstat(fd, &a) == 0 && still_the_file(tmp, a.st_dev, a.st_ino);
}

// A note, once per process and way (1: the no-replace rename, 2: the exclusive create and copy),
// that the file system made photosite publish without a link.
void publish_note(const std::string& path, int way, int link_errno, int rename_errno) {
  static std::atomic<bool> said[3] = {};
  if (said[way].exchange(true)) return;
  const std::string dir = fs::path(path).parent_path().string();
  if (way == 1)
    std::fprintf(stderr, "photosite: note: %s: the file system makes no hard links (link: %s); publishing new "
                 "files with a no-replace rename instead\n", dir.c_str(), std::strerror(link_errno));
  else
    std::fprintf(stderr, "photosite: note: %s: the file system makes no hard links (link: %s) and has no "
                 "no-replace rename (renameat2: %s); new files are created exclusively and filled in place\n",
                 dir.c_str(), std::strerror(link_errno), std::strerror(rename_errno));
}

// Way 2 above: path created exclusively, the finished temporary tmp (open for writing as fd)
// copied in and fsync'd. False when path exists (nothing touched); on an error the part written is
// removed. The temporary is read through a descriptor of its own, opened by name and checked to be
// fd's file: fusefat refuses reads through the descriptor the file was created with (EPERM).
bool create_and_copy(const std::string& path, const std::string& tmp, int fd) {
  struct Source {
    int fd;
    ~Source() {
      if (fd >= 0) ::close(fd);
    }
  } source{::open(tmp.c_str(), O_RDONLY | O_NOFOLLOW | O_CLOEXEC)};
  const int from = source.fd;
  struct stat a{}, b{};
  if (from < 0 || ::fstat(fd, &a) != 0 || ::fstat(from, &b) != 0 || a.st_dev != b.st_dev || a.st_ino != b.st_ino)
    fail_at(path, "the temporary " + tmp + " was replaced by another process while it was written; nothing published");
  const int out = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0666);
  if (out < 0) {
    if (errno == EEXIST) return false;
    fail_at(path, std::string("cannot create (") + std::strerror(errno) + ")");
  }
  struct Partial {
    const std::string& path;
    int out;
    TemporarySlot slot;  // a signal during the copy removes the part written
    bool done = false;
    ~Partial() {
      struct stat a{};
      // Removed only while the name is still the file this process created.
      if (!done && ::fstat(out, &a) == 0 && still_the_file(path, a.st_dev, a.st_ino)) ::unlink(path.c_str());
      ::close(out);
    }
  } partial{path, out, TemporarySlot(path.c_str())};
  std::vector<char> buffer(size_t{1} << 20);
  for (off_t at = 0;;) {
    const ssize_t n = ::pread(from, buffer.data(), buffer.size(), at);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) fail_at(path, std::string("cannot read back the finished temporary (") + std::strerror(errno) + ")");
    if (n == 0) break;
    for (ssize_t put = 0; put < n;) {
      const ssize_t w = ::write(out, buffer.data() + put, static_cast<size_t>(n - put));
      if (w < 0 && errno == EINTR) continue;
      if (w < 0) fail_at(path, std::string("cannot write (") + std::strerror(errno) + ")");
      put += w;
    }
    at += n;
  }
  if (::fsync(out) != 0) fail_at(path, std::string("cannot write (fsync: ") + std::strerror(errno) + ")");
  partial.done = true;
  return true;
}

bool write_then_publish(const std::string& path, const std::function<void(const std::string&)>& write,
                        bool replace) {
  static std::atomic<unsigned> counter{0};
  fs::path p(path);
  std::string tmp;
  // Registered before the file exists, so a signal that arrives once it does removes it.
  std::optional<TemporarySlot> slot;
  int fd = -1;
  for (int attempt = 0; fd < 0; ++attempt) {
    slot.reset();
    tmp = (p.parent_path() / ("." + p.stem().string() +
                              fmt::format(".tmp-{}-{}-{}", temporary_pid_scope(), getpid(), counter++)))
              .string() +
          p.extension().string();
    slot.emplace(tmp.c_str());
    fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0666);
    if (fd < 0 && !(errno == EEXIST && attempt < 1000)) {
      const int e = errno;
      slot.reset();
      fail_at(path, std::string("cannot write (") + std::strerror(e) + (e == EEXIST ? ": every temporary name is taken)" : ")"));
    }
  }
  struct Remove {
    const std::string& tmp;
    int fd;
    std::optional<TemporarySlot>& slot;
    bool keep = false;  // held by the live OutputSet
    ~Remove() {
      slot.reset();  // released before the file is removed
      std::error_code ec;
      if (!keep) fs::remove(tmp, ec);
      ::close(fd);
    }
  } remove{tmp, fd, slot};
  static const bool proc_fd = [] {
    std::error_code ec;
    return fs::is_directory("/proc/self/fd", ec);
  }();
  const std::string via = proc_fd ? fmt::format("/proc/self/fd/{}", fd) : tmp;
  write(via);
  if (replace) {
    // The name must still be this file (else someone replaced it: nothing is published).
    struct stat a{};
    if (::fstat(fd, &a) != 0 || !still_the_file(tmp, a.st_dev, a.st_ino))
      fail_at(path, "the temporary " + tmp + " was replaced by another process while it was written; nothing published");
    if (OutputSet* set = g_output_set.load()) {
      auto held = std::make_unique<OutputSet::Pending>(tmp, path, a.st_dev, a.st_ino);
      remove.keep = true;  // the set's slot (registered by Pending) now covers it
      set->hold(std::move(held));
      return true;
    }
    move_into_place(tmp, path);
    return true;
  }
  if (detail::publish_linkat.load()(AT_FDCWD, via.c_str(), AT_FDCWD, path.c_str(), proc_fd ? AT_SYMLINK_FOLLOW : 0) == 0)
    return true;
  if (errno == EEXIST) return false;
  if (!no_hard_links(errno))
    fail_at(path, std::string("cannot move the finished file into place: ") + std::strerror(errno));
  const int link_errno = errno;
  if (!still_the_file_fd(tmp, fd))
    fail_at(path, "the temporary " + tmp + " was replaced by another process while it was written; nothing published");
  if (detail::publish_renameat2.load()(AT_FDCWD, tmp.c_str(), AT_FDCWD, path.c_str(), RENAME_NOREPLACE) == 0) {
    remove.keep = true;  // the temporary's name is now the file's
    publish_note(path, 1, link_errno, 0);
    return true;
  }
  if (errno == EEXIST) return false;
  if (errno != EINVAL && errno != ENOSYS && !no_hard_links(errno))
    fail_at(path, std::string("cannot move the finished file into place: ") + std::strerror(errno));
  publish_note(path, 2, link_errno, errno);
  return create_and_copy(path, tmp, fd);
}
}  // namespace

const std::string& temporary_pid_scope() {
  // A pid names a process only on its own machine, during one boot, in its own pid namespace (a
  // container, or `unshare --pid`): all three go into the hash, so a shared output folder tells
  // the temporaries of this pid space from those of every other machine or container, even
  // machines of one host name. (The boot id also keeps a pid of an earlier boot, reused by
  // another process since, from being taken for that process.)
  static const std::string scope = [] {
    char host[256] = {};
    if (gethostname(host, sizeof host - 1) != 0) host[0] = '\0';
    std::string boot;
    std::ifstream("/proc/sys/kernel/random/boot_id") >> boot;
    std::error_code ec;
    const std::string ns = fs::read_symlink("/proc/self/ns/pid", ec).string();  // "pid:[4026531836]"
    const std::string id = std::string(host) + "\n" + boot + "\n" + ns;
    return fmt::format("{:08x}", static_cast<uint32_t>(fnv1a_64(id.data(), id.size()) >> 32));
  }();
  return scope;
}

bool is_stale_temporary(const std::string& filename) {
  // Exactly write_then_publish's pattern, so no file of anyone else's is taken for one.
  static const std::regex pattern(R"(\..+\.tmp-([0-9a-f]{8})-([0-9]{1,9})-[0-9]{1,10}(\.[^.]*)?)");
  std::smatch m;
  if (!std::regex_match(filename, m, pattern) || m[1].str() != temporary_pid_scope()) return false;
  const long pid = std::stol(m[2].str());
  if (pid <= 0 || pid == getpid()) return false;  // our own: a write in progress
  return ::kill(static_cast<pid_t>(pid), 0) != 0 && errno == ESRCH;  // EPERM: alive, someone else's
}

// Under `folder`, files of exactly write_then_publish's pattern, of this pid space, whose process
// is gone (is_stale_temporary); links and other files are never touched.
void remove_stale_temporaries(const std::string& folder) {
  std::error_code ec;
  for (auto it = fs::recursive_directory_iterator(folder, fs::directory_options::skip_permission_denied, ec);
       it != fs::recursive_directory_iterator(); it.increment(ec)) {
    if (ec) break;
    std::error_code fec;
    if (!it->is_regular_file(fec) || it->is_symlink(fec)) continue;
    if (is_stale_temporary(it->path().filename().string())) fs::remove(it->path(), fec);
  }
}

void remove_partial_outputs() noexcept {
  for (auto& t : g_temporaries)
    if (const char* name = t.load()) ::unlink(name);
}

// A finished temporary waiting for its set's commit, registered for remove_partial_outputs as
// while it was written (its name lives here, on the heap, as long as the slot).
struct OutputSet::Pending {
  std::string tmp, path;
  dev_t dev;
  ino_t ino;
  std::optional<TemporarySlot> slot;
  Pending(std::string t, std::string p, dev_t d, ino_t i) : tmp(std::move(t)), path(std::move(p)), dev(d), ino(i) {
    slot.emplace(tmp.c_str());
  }
  ~Pending() {
    slot.reset();
    std::error_code ec;
    if (!tmp.empty()) fs::remove(tmp, ec);  // not published: removed
  }
};

OutputSet::OutputSet() {
  OutputSet* none = nullptr;
  if (!g_output_set.compare_exchange_strong(none, this)) internal_error("OutputSet: one set at a time");
}

OutputSet::~OutputSet() {
  g_output_set.store(nullptr);
  pending_.clear();  // without commit: every temporary removed
}

void OutputSet::hold(std::unique_ptr<Pending> p) {
  static std::mutex m;  // files written by several threads at once
  const std::lock_guard<std::mutex> lock(m);
  pending_.push_back(std::move(p));
}

void OutputSet::commit() {
  g_output_set.store(nullptr);  // later writes publish at once
  for (auto& p : pending_) {
    if (!still_the_file(p->tmp, p->dev, p->ino))
      fail_at(p->path, "the temporary " + p->tmp + " was replaced by another process before it was published; not published");
    move_into_place(p->tmp, p->path);
    p->tmp.clear();  // published
  }
  pending_.clear();
}

void atomic_write(const std::string& path, const std::function<void(const std::string&)>& write) {
  write_then_publish(path, write, true);
}

bool atomic_create(const std::string& path, const std::function<void(const std::string&)>& write) {
  return write_then_publish(path, write, false);
}

std::string lower_extension(const std::string& path) {
  std::string e = fs::path(path).extension().string();
  for (auto& ch : e) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
  return e;
}

std::string frame_path(const std::string& pattern, int frame) {
  auto first = pattern.find('#');
  if (first == std::string::npos) return pattern;
  auto last = pattern.find_first_not_of('#', first);
  size_t n = (last == std::string::npos ? pattern.size() : last) - first;
  return pattern.substr(0, first) + fmt::format("{:0{}d}", frame, n) + pattern.substr(first + n);
}

}  // namespace photosite
