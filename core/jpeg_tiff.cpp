// JPEG through libjpeg-turbo and TIFF through libtiff (core/raster_codecs.h). The samples are the
// ones OpenImageIO 2.4's readers gave for the same files in their native types; the in-memory JPEG
// pair gives OpenCV 4.6's imencode / imdecode bytes and pixels (both link the same libjpeg).
#include <algorithm>
#include <cmath>
#include <csetjmp>
#include <cerrno>
#include <cstdarg>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <limits>
#include <type_traits>

#include <fmt/format.h>
#include <jpeglib.h>  // after <cstdio>: it uses size_t and FILE without including them
#include <tiffio.h>

#include "core/png_codec.h"
#include "core/raster_codecs.h"
#include "photosite/error.h"
#include "photosite/io.h"

namespace photosite::codec {

int sample_bytes(Sample s) {
  switch (s) {
    case Sample::U8: return 1;
    case Sample::U16: case Sample::Half: return 2;
    case Sample::U32: case Sample::F32: return 4;
  }
  internal_error("sample_bytes: unknown sample type");
}

namespace {
// ---------------------------------------------------------------------------------------- JPEG
// libjpeg reports a fatal error through error_exit, which must not return (libjpeg.txt "Error
// handling"): ours keeps the message and longjmps back. Warnings (corrupt or missing data, which
// libjpeg pads with grey) come through emit_message(-1); we count them instead of printing, or,
// where a warning is an error (`warnings_fatal`), leave at the first as error_exit does: a file
// cut short then stops being decoded where its data ends (libjpeg would decode the rest of the
// image from the grey it pads with, touching every row of the output and of its coefficient
// buffer). Leaving from emit_message is as safe as from error_exit: libjpeg may call either at
// any point, and jpeg_destroy_decompress frees what it had allocated.
struct JpegErr {
  jpeg_error_mgr pub;
  std::jmp_buf jump;
  char message[JMSG_LENGTH_MAX] = "";
  int warnings = 0;
  bool warnings_fatal = false;
};
void on_error(j_common_ptr c) {
  auto* e = reinterpret_cast<JpegErr*>(c->err);
  c->err->format_message(c, e->message);
  std::longjmp(e->jump, 1);
}
void on_message(j_common_ptr c, int level) {
  auto* e = reinterpret_cast<JpegErr*>(c->err);
  if (level >= 0) return;
  if (e->warnings++ == 0) c->err->format_message(c, e->message);  // keep the first
  if (e->warnings_fatal) std::longjmp(e->jump, 1);
}
// Runs libjpeg calls under setjmp. `f` must create no object with a destructor: longjmp skips
// destructors. Returns false on a libjpeg error (message in e.message).
template <class F> bool guarded(JpegErr& e, F&& f) {
  if (setjmp(e.jump)) return false;
  f();
  return true;
}

struct JpegDecoder {
  jpeg_decompress_struct cinfo{};
  JpegErr err;
  JpegDecoder() {
    cinfo.err = jpeg_std_error(&err.pub);
    err.pub.error_exit = on_error;
    err.pub.emit_message = on_message;
    jpeg_create_decompress(&cinfo);  // cannot fail: it only allocates the memory manager
  }
  ~JpegDecoder() { jpeg_destroy_decompress(&cinfo); }
  JpegDecoder(const JpegDecoder&) = delete;  // libjpeg keeps &err
  JpegDecoder& operator=(const JpegDecoder&) = delete;
};

// The least entropy-coded data a Huffman-coded JPEG of this frame holds, or "" where the bytes
// after the first scan's header (everything that follows: the scans' data, later tables and scan
// headers, EOI) can hold it. A lower bound, from ITU-T T.81:
//  - A Huffman code is at least 1 bit long (B.2.4.2: the table lists the codes of each length
//    1 to 16), and byte stuffing and restart markers (B.1.1.5, F.1.2.3) only add bytes.
//  - Sequential DCT (Annex F, SOF0/SOF1): each component is coded in exactly one scan, which codes
//    every one of its 8x8 blocks (an interleaved scan also its MCUs' padding blocks: more). A
//    block is its DC difference's category code (F.1.2.1, at least 1 bit, even for a zero
//    difference) and then its AC codes (F.1.2.2): an EOB after the last non-zero coefficient, or
//    the code of a coefficient at position 63; either way at least one more code of at least 1
//    bit. So at least 2 bits a block.
//  - Progressive DCT (Annex G, SOF2): "for each component, a first DC scan shall precede any AC
//    scans" (G.1.1.1.1), and the first DC scan codes each block's DC difference as the sequential
//    process does (G.1.2.1): at least 1 bit a block. The AC scans' EOB runs (G.1.2.2: EOBRUN up
//    to 32767 blocks in one code) can code whole bands of many blocks in a few bits, so they are
//    not counted; refinement scans neither.
// A file that codes no first DC scan for some component is not a conforming one (libjpeg decodes
// that component as grey, silently), and is refused alike: the bound is the frame's, not the
// scans', so every file it lets through holds at least 1 bit of data for each block libjpeg
// allocates (its coefficient buffer, 128 bytes a block, and our output, 64 pixels of at most 3
// bytes a block of a full-resolution component). Arithmetic coding (SOF9/SOF10, Annex D) has no
// such floor: its adaptive coder codes a decision of probability near 1 in a small fraction of a
// bit (a uniform image's blocks in far under a bit each), so its files are not bounded this way.
std::string jpeg_entropy_shortfall(const jpeg_decompress_struct* c) {
  if (c->arith_code) return {};
  const int bits_a_block = c->progressive_mode ? 1 : 2;
  double blocks = 0;  // in double: no overflow whatever the header says
  for (int i = 0; i < c->num_components; ++i)
    blocks += static_cast<double>(c->comp_info[i].width_in_blocks) * c->comp_info[i].height_in_blocks;
  const double need = std::ceil(blocks * bits_a_block / 8);
  const double have = static_cast<double>(c->src->bytes_in_buffer);
  if (need <= have) return {};
  return fmt::format("JPEG data: the header's {}x{} pixels in {} component{} are {:.0f} blocks of 8x8, whose {} "
                     "Huffman codes need at least {:.0f} bytes ({} bit{} a block), more than the file's {:.0f} bytes "
                     "after its first scan header hold; refused before allocating them",
                     c->image_width, c->image_height, c->num_components, c->num_components == 1 ? "" : "s",
                     blocks, c->progressive_mode ? "progressive" : "sequential", need, bits_a_block,
                     bits_a_block == 1 ? "" : "s", have);
}

// Decodes with libjpeg's defaults (JDCT_ISLOW, fancy upsampling), as OpenImageIO and OpenCV do.
// rgb: every file as 3-channel RGB (imdecode IMREAD_COLOR; greyscale is replicated by libjpeg);
// otherwise 1 channel for greyscale files, 3 for colour (OpenImageIO). `header` sees w, h, channels
// before the pixels are allocated and may throw. Returns "" or why the file is refused (libjpeg's
// message, or jpeg_entropy_shortfall's).
template <class H>
std::string jpeg_decode(const std::vector<uint8_t>& in, bool rgb, bool warnings_fatal, H&& header,
                        Raster& out) {
  JpegDecoder d;
  d.err.warnings_fatal = warnings_fatal;
  jpeg_decompress_struct* c = &d.cinfo;
  if (!guarded(d.err, [&] {
        jpeg_mem_src(c, in.data(), static_cast<unsigned long>(in.size()));
        jpeg_read_header(c, TRUE);
      }))
    return d.err.message;
  out.width = static_cast<int>(c->image_width);
  out.height = static_cast<int>(c->image_height);
  out.channels = c->num_components;
  header(out);  // may throw: outside `guarded`, and d's destructor releases libjpeg's memory
  if (c->num_components != 1 && c->num_components != 3)
    return fmt::format("{} colour components (CMYK / YCCK JPEG is not supported)", c->num_components);
  if (std::string s = jpeg_entropy_shortfall(c); !s.empty()) return s;
  c->out_color_space = rgb || c->num_components == 3 ? JCS_RGB : JCS_GRAYSCALE;
  if (!guarded(d.err, [&] { jpeg_calc_output_dimensions(c); })) return d.err.message;
  out.channels = c->output_components;  // scale 1/1: output size == image size
  const size_t row = static_cast<size_t>(out.width) * out.channels;
  // The output's memory is reserved (address space only) and its rows are made as they are
  // decoded: a file whose data ends early costs the rows it held, not the whole image.
  out.bytes.clear();
  out.bytes.reserve(row * out.height);
  std::vector<uint8_t>& bytes = out.bytes;  // a reference: `guarded` code creates no object
  if (!guarded(d.err, [&] {
        jpeg_start_decompress(c);
        while (c->output_scanline < c->output_height) {
          bytes.resize(row * (c->output_scanline + 1));  // within the reserve: no reallocation
          JSAMPROW r = bytes.data() + row * c->output_scanline;
          jpeg_read_scanlines(c, &r, 1);
        }
        jpeg_finish_decompress(c);
      }))
    return d.err.message;
  if (warnings_fatal && d.err.warnings) return d.err.message;
  return {};
}
}  // namespace

namespace {
// The Exif orientation of a JPEG (the Orientation tag, 274, of the Exif APP1 segment's IFD0: Exif
// 2.32 §4.6.4 A, its values those of TIFF 6.0's tag), or 0 where there is none or it cannot be
// read. The marker segments before the first SOS are walked by their lengths (T.81 B.1.1.4).
int jpeg_exif_orientation(const std::vector<uint8_t>& d) {
  size_t at = 2;  // after SOI
  while (at + 4 <= d.size() && d[at] == 0xff) {
    const uint8_t marker = d[at + 1];
    if (marker == 0xda || marker == 0xd9) break;  // SOS, EOI: no more header segments
    const size_t len = size_t{d[at + 2]} << 8 | d[at + 3];
    if (len < 2 || at + 2 + len > d.size()) break;
    const size_t seg = at + 4, end = at + 2 + len;
    static const uint8_t kExif[6] = {'E', 'x', 'i', 'f', 0, 0};
    if (marker == 0xe1 && end - seg >= 14 && std::memcmp(&d[seg], kExif, 6) == 0) {
      const size_t tiff = seg + 6;  // the TIFF header: II or MM, 42, the offset of IFD0
      const bool le = d[tiff] == 'I' && d[tiff + 1] == 'I';
      if (!le && !(d[tiff] == 'M' && d[tiff + 1] == 'M')) return 0;
      auto u16 = [&](size_t i) { return le ? d[i] | d[i + 1] << 8 : d[i] << 8 | d[i + 1]; };
      auto u32 = [&](size_t i) {
        return le ? uint32_t{d[i]} | uint32_t{d[i + 1]} << 8 | uint32_t{d[i + 2]} << 16 | uint32_t{d[i + 3]} << 24
                  : uint32_t{d[i]} << 24 | uint32_t{d[i + 1]} << 16 | uint32_t{d[i + 2]} << 8 | uint32_t{d[i + 3]};
      };
      const uint64_t ifd = tiff + uint64_t{u32(tiff + 4)};
      if (ifd + 2 > end) return 0;
      const int entries = u16(static_cast<size_t>(ifd));
      for (int k = 0; k < entries; ++k) {
        const uint64_t e = ifd + 2 + 12 * uint64_t(k);
        if (e + 12 > end) return 0;
        if (u16(static_cast<size_t>(e)) == 274 && u16(static_cast<size_t>(e) + 2) == 3)  // SHORT
          return u16(static_cast<size_t>(e) + 8);
      }
      return 0;
    }
    at = end;
  }
  return 0;
}
}  // namespace

Raster read_jpeg(const std::string& path) {
  const std::vector<uint8_t> data = read_file(path);
  Raster r;
  r.format = "jpeg";
  r.sample = Sample::U8;
  // Any libjpeg warning is an error: OpenImageIO's reader reports each one ("Premature end of
  // JPEG file" for a truncated file, "Corrupt JPEG data: ..." for damaged entropy data).
  const std::string err = jpeg_decode(data, false, true, [&](const Raster& h) {
    check_image_size(path, h.width, h.height);
    // OpenImageIO converted CMYK / YCCK (Adobe) JPEGs to RGB; we refuse them, clearly.
    if (h.channels != 1 && h.channels != 3)
      fail_at(path, fmt::format("unsupported JPEG ({} colour components: CMYK or YCCK)", h.channels));
  }, r);
  if (!err.empty()) fail_at(path, "corrupt or truncated image (" + err + ")");
  r.channel_samples.assign(r.channels, Sample::U8);
  // A camera held sideways stores its rows as the sensor read them and says in Exif how viewers
  // should turn them. photosite reads the pixels as stored (as OpenImageIO did); said on the
  // standard error, since labels made from the picture as viewers show it fit the stored pixels
  // only after the same turn.
  static const char* const kShown[9] = {"", "", "mirrored left to right", "turned 180 degrees",
                                        "mirrored top to bottom", "mirrored about its main diagonal",
                                        "turned 90 degrees clockwise", "mirrored about its other diagonal",
                                        "turned 90 degrees counter-clockwise"};
  if (const int o = jpeg_exif_orientation(data); o >= 2 && o <= 8) {
    r.note = fmt::format("its Exif orientation ({}) has viewers show it {}; photosite reads its {}x{} pixels as stored, "
                         "not turned (labels and instance ids must be of the stored pixels)", o, kShown[o], r.width, r.height);
    std::fprintf(stderr, "photosite: note: %s: %s\n", path.c_str(), r.note.c_str());
  }
  return r;
}

std::vector<uint8_t> decode_jpeg_rgb8(const std::vector<uint8_t>& jpeg, int expect_width, int expect_height) {
  Raster r;
  // Warnings are not errors here: imdecode returns libjpeg's padded pixels.
  const std::string err = jpeg_decode(jpeg, true, false, [&](const Raster& h) {
    if (h.width != expect_width || h.height != expect_height)
      internal_error(fmt::format("decode_jpeg_rgb8: JPEG is {}x{}, expected {}x{}", h.width, h.height,
                                 expect_width, expect_height));
  }, r);
  if (!err.empty()) internal_error("decode_jpeg_rgb8: " + err);
  return std::move(r.bytes);
}

int jpeg_max_dimension() { return static_cast<int>(JPEG_MAX_DIMENSION); }

std::vector<uint8_t> encode_jpeg_rgb8(const uint8_t* rgb, int width, int height, int quality) {
  // OpenCV's JpegEncoder::write: jpeg_set_defaults (4:2:0, baseline, Huffman tables not optimised,
  // JFIF header), then jpeg_set_quality(q, force_baseline TRUE), rows handed over as JCS_RGB.
  jpeg_compress_struct c{};
  JpegErr e;
  c.err = jpeg_std_error(&e.pub);
  e.pub.error_exit = on_error;
  e.pub.emit_message = on_message;
  unsigned char* buf = nullptr;  // jpeg_mem_dest grows it with malloc; we free it
  unsigned long size = 0;
  const bool ok = guarded(e, [&] {
    jpeg_create_compress(&c);
    jpeg_mem_dest(&c, &buf, &size);
    c.image_width = static_cast<JDIMENSION>(width);
    c.image_height = static_cast<JDIMENSION>(height);
    c.input_components = 3;
    c.in_color_space = JCS_RGB;
    jpeg_set_defaults(&c);
    jpeg_set_quality(&c, std::clamp(quality, 0, 100), TRUE);
    jpeg_start_compress(&c, TRUE);
    while (c.next_scanline < c.image_height) {
      JSAMPROW r = const_cast<uint8_t*>(rgb) + static_cast<size_t>(c.next_scanline) * width * 3;
      jpeg_write_scanlines(&c, &r, 1);
    }
    jpeg_finish_compress(&c);
  });
  jpeg_destroy_compress(&c);
  std::vector<uint8_t> out;
  if (ok) out.assign(buf, buf + size);
  std::free(buf);
  if (!ok) internal_error(std::string("encode_jpeg_rgb8: ") + e.message);
  return out;
}

// ---------------------------------------------------------------------------------------- TIFF
namespace {
// Per-file handlers (libtiff 4.5 TIFFOpenOptionsSetErrorHandlerExtR): the first error message is
// kept in this call's string (so concurrent reads never share state, and the process-wide handlers
// other code may rely on stay untouched), warnings are dropped; returning 1 stops the global handler.
int tiff_error(TIFF*, void* user, const char* module, const char* f, va_list ap) {
  auto* msg = static_cast<std::string*>(user);
  if (msg->empty()) {
    char b[1024];
    std::vsnprintf(b, sizeof b, f, ap);
    *msg = module && *module ? fmt::format("{}: {}", module, b) : b;
  }
  return 1;
}
int tiff_warning(TIFF*, void*, const char*, const char*, va_list) { return 1; }

struct Tiff {
  std::string error;
  TIFF* tif = nullptr;
  Tiff(const std::string& path, const char* mode) {
    TIFFOpenOptions* o = TIFFOpenOptionsAlloc();
    TIFFOpenOptionsSetErrorHandlerExtR(o, tiff_error, &error);
    TIFFOpenOptionsSetWarningHandlerExtR(o, tiff_warning, nullptr);
    tif = TIFFOpenExt(path.c_str(), mode, o);
    TIFFOpenOptionsFree(o);
  }
  ~Tiff() { if (tif) TIFFClose(tif); }
  Tiff(const Tiff&) = delete;  // libtiff keeps &error
  Tiff& operator=(const Tiff&) = delete;
  std::string message(const char* fallback) const { return error.empty() ? fallback : error; }
};

template <class T> void premultiply(uint8_t* p, size_t pixels, int nch, int alpha) {
  // OpenImageIO delivers associated alpha: colour * alpha in float, rounded back (OIIO::premult).
  for (size_t i = 0; i < pixels; ++i) {
    T* px = reinterpret_cast<T*>(p) + i * nch;
    if constexpr (std::is_floating_point_v<T>) {
      for (int c = 0; c < nch; ++c) if (c != alpha) px[c] *= px[alpha];
    } else {
      constexpr float mx = static_cast<float>(std::numeric_limits<T>::max());
      const float a = px[alpha] * (1.0f / mx);
      for (int c = 0; c < nch; ++c)
        if (c != alpha) px[c] = static_cast<T>(std::clamp(a * (px[c] * (1.0f / mx)) * mx + 0.5f, 0.0f, mx));
    }
  }
}
}  // namespace

Raster read_tiff(const std::string& path) {
  Tiff t(path, "rm");  // "m": no memory-mapping, so a truncated file reads as an error, not SIGBUS
  // The caller (core/io.cpp) found TIFF's signature, so a file libtiff cannot open is damaged.
  if (!t.tif) fail_at(path, "corrupt or truncated image (" + t.message("not a TIFF file") + ")");
  TIFF* tif = t.tif;
  const auto bad = [&](const char* fallback) { fail_at(path, "corrupt or truncated image (" + t.message(fallback) + ")"); };
  uint32_t w = 0, h = 0;
  uint16_t spp = 1, bps = 1, format = SAMPLEFORMAT_UINT, planar = PLANARCONFIG_CONTIG, photo = PHOTOMETRIC_MINISBLACK;
  if (!TIFFGetField(tif, TIFFTAG_IMAGEWIDTH, &w) || !TIFFGetField(tif, TIFFTAG_IMAGELENGTH, &h)) bad("no image size");
  TIFFGetFieldDefaulted(tif, TIFFTAG_SAMPLESPERPIXEL, &spp);
  TIFFGetFieldDefaulted(tif, TIFFTAG_BITSPERSAMPLE, &bps);
  TIFFGetFieldDefaulted(tif, TIFFTAG_SAMPLEFORMAT, &format);
  TIFFGetFieldDefaulted(tif, TIFFTAG_PLANARCONFIG, &planar);
  TIFFGetField(tif, TIFFTAG_PHOTOMETRIC, &photo);
  check_image_size(path, w, h);
  if (spp > 64) fail_at(path, fmt::format("image declares {} channels", spp));
  if (spp == 0) fail_at(path, "image declares 0 channels");
  uint16_t compression = COMPRESSION_NONE;
  TIFFGetFieldDefaulted(tif, TIFFTAG_COMPRESSION, &compression);
  // Whether the size checks below held the strips' bytes against the header's size (uncompressed
  // or a codec with an expansion bound, not YCbCr, the file's size known).
  bool size_checked = false;
  // The strips (or tiles) must lie in the file, and uncompressed ones hold the samples the size
  // asks for: libtiff reads a strip only when asked, after the image has been allocated, so a
  // 9 kB file whose tags say 16384x16384 RGB had 800 MB allocated before failing.
  {
    std::error_code ec;
    const uint64_t file_bytes = std::filesystem::file_size(path, ec);
    const uint32_t striles = TIFFIsTiled(tif) ? TIFFNumberOfTiles(tif) : TIFFNumberOfStrips(tif);
    uint64_t stored = 0;
    for (uint32_t i = 0; !ec && i < striles; ++i) {
      const uint64_t at = TIFFGetStrileOffset(tif, i), n = TIFFGetStrileByteCount(tif, i);
      if (at > file_bytes || n > file_bytes - at)
        fail_at(path, fmt::format("corrupt or truncated image (TIFF {} {} of {} is bytes {} to {}, beyond the file's {} "
                                  "bytes: a file cut short?); refused before allocating its {}x{} pixels",
                                  TIFFIsTiled(tif) ? "tile" : "strip", i, striles, at, at + n, file_bytes, w, h));
      stored += n;
    }
    // The samples without row padding, a lower bound for contiguous and planar files alike (not
    // for YCbCr, whose chroma may be subsampled).
    const double needed = std::floor(static_cast<double>(w) * h * spp * bps / 8);
    if (!ec && compression == COMPRESSION_NONE && photo != PHOTOMETRIC_YCBCR && static_cast<double>(stored) < needed)
      fail_at(path, fmt::format("corrupt or truncated image (uncompressed TIFF: its {}x{} pixels, {} sample{} of {} "
                                "bits each, need {:.0f} bytes; its {} hold {}); refused before allocating them",
                                w, h, spp, spp == 1 ? "" : "s", bps, needed, TIFFIsTiled(tif) ? "tiles" : "strips", stored));
    // Compressed strips expand by at most their codec's largest ratio, so their bytes bound the
    // samples they can give (a predictor, TIFF 6.0 §14, changes no size):
    //  - Deflate (8, and 32946 the old code): 1032:1 (png::kMaxDeflateRatio, RFC 1951).
    //  - PackBits (32773, TIFF 6.0 §9): a run is a count byte and one byte repeated at most 128
    //    times, 2 bytes for 128: 64:1.
    //  - LZW (5, TIFF 6.0 §13): a code is at least 9 bits; each table entry after the 256 literals
    //    and the Clear and EOI codes is an earlier entry plus one byte, so entry k (258 to 4095)
    //    is at most k − 256 bytes and no code gives more than 3839: 3839 × 8 / 9 < 3413:1.
    // Other codecs (JPEG, CCITT fax, LZMA, ZSTD, ...) are left to libtiff, which refuses such a
    // file when a strip fails to decode; the samples' buffer below grows with the rows decoded.
    const struct { uint16_t code; double ratio; const char* name; } kExpansion[] = {
        {COMPRESSION_ADOBE_DEFLATE, static_cast<double>(png::kMaxDeflateRatio), "Deflate"},
        {COMPRESSION_DEFLATE, static_cast<double>(png::kMaxDeflateRatio), "Deflate"},
        {COMPRESSION_PACKBITS, 64, "PackBits"},
        {COMPRESSION_LZW, 3413, "LZW"}};
    const auto bound = std::find_if(std::begin(kExpansion), std::end(kExpansion),
                                    [&](const auto& c) { return c.code == compression; });
    const bool bounded = bound != std::end(kExpansion), checkable = !ec && photo != PHOTOMETRIC_YCBCR;
    size_checked = checkable && (compression == COMPRESSION_NONE || bounded);
    if (checkable && bounded && static_cast<double>(stored) * bound->ratio < needed)
      fail_at(path, fmt::format("corrupt or truncated image (TIFF data: its {}x{} pixels, {} sample{} of {} bits each, "
                                "need {:.0f} bytes; its {} hold {} bytes of {}, which expand at most {:.0f}:1); "
                                "refused before allocating them",
                                w, h, spp, spp == 1 ? "" : "s", bps, needed, TIFFIsTiled(tif) ? "tiles" : "strips",
                                stored, bound->name, bound->ratio));
  }
  if (photo == PHOTOMETRIC_YCBCR && compression == COMPRESSION_JPEG) {  // libtiff converts (tiff(3) JPEGCOLORMODE)
    TIFFSetField(tif, TIFFTAG_JPEGCOLORMODE, JPEGCOLORMODE_RGB);
    photo = PHOTOMETRIC_RGB;
  }

  if (format == SAMPLEFORMAT_INT || format == SAMPLEFORMAT_COMPLEXINT || format == SAMPLEFORMAT_COMPLEXIEEEFP)
    fail_at(path, "unsupported TIFF (signed integer or complex samples)");
  Raster r;
  r.format = "tiff";
  r.width = static_cast<int>(w);
  r.height = static_cast<int>(h);
  const bool palette = photo == PHOTOMETRIC_PALETTE && spp == 1 && bps <= 8;
  const bool ints = format == SAMPLEFORMAT_UINT || format == SAMPLEFORMAT_VOID;
  const bool direct = (photo == PHOTOMETRIC_MINISBLACK || photo == PHOTOMETRIC_MINISWHITE || photo == PHOTOMETRIC_RGB) &&
                      ((ints && (bps == 1 || bps == 2 || bps == 4 || bps == 8 || bps == 16 || bps == 32)) ||
                       (format == SAMPLEFORMAT_IEEEFP && (bps == 16 || bps == 32)));
  if (!palette && !direct) {
    // Everything else (CMYK, YCbCr without JPEG, CIELab, LogLuv, odd bit depths...): libtiff's RGBA
    // interface, 8-bit RGBA top row first (TIFFReadRGBAImage(3tiff)).
    r.channels = 4;
    r.sample = Sample::U8;
    char emsg[1024] = "";
    if (!TIFFRGBAImageOK(tif, emsg)) fail_at(path, fmt::format("unsupported TIFF layout ({})", emsg));
    // libtiff's RGBA reader allocates and zeroes a whole strip or tile before decoding it, and one
    // strip may hold the whole image (1 GiB of CMYK at the pixel limit). So where the codec's
    // strips were not held against the size above (a codec without an expansion bound, or YCbCr)
    // the first row of the first strip or tile is decoded first, alone: data that does not decode
    // at all is refused before that (Memory.DamagedTiffCostsTheRowsItHolds). Not for JPEG (old or
    // new), whose codec reads whole scanlines of its own size.
    if (!size_checked && compression != COMPRESSION_JPEG && compression != COMPRESSION_OJPEG) {
      const tmsize_t first = TIFFIsTiled(tif) ? TIFFTileRowSize(tif) : TIFFScanlineSize(tif);
      if (first > 0) {
        std::vector<uint8_t> row(static_cast<size_t>(first));
        if ((TIFFIsTiled(tif) ? TIFFReadEncodedTile(tif, 0, row.data(), first)
                              : TIFFReadEncodedStrip(tif, 0, row.data(), first)) < 0)
          bad("cannot decode its first row");
      }
    }
    // libtiff's raster, not zeroed: it is written as the strips or tiles decode (a damaged file
    // costs the pages they reached, Memory.DamagedTiffCostsTheRowsItHolds); the samples are made
    // only from a raster read whole.
    const auto raster = std::make_unique_for_overwrite<uint32_t[]>(size_t{w} * h);
    if (!TIFFReadRGBAImageOriented(tif, w, h, raster.get(), ORIENTATION_TOPLEFT, 1)) bad("cannot decode as RGBA");
    r.bytes.resize(size_t{w} * h * 4);
    for (size_t i = 0; i < size_t{w} * h; ++i) {  // ABGR in a host uint32 -> R, G, B, A bytes
      const uint32_t v = raster[i];
      const uint8_t px[4] = {uint8_t(TIFFGetR(v)), uint8_t(TIFFGetG(v)), uint8_t(TIFFGetB(v)), uint8_t(TIFFGetA(v))};
      std::memcpy(&r.bytes[i * 4], px, 4);
    }
    r.channel_samples.assign(4, Sample::U8);
    return r;
  }

  // Read the packed samples: one buffer per plane (planar separate: one channel a plane), rows of
  // ceil(width * values * bits / 8) bytes, from strips (scanline by scanline) or tiles.
  const bool separate = planar == PLANARCONFIG_SEPARATE && spp > 1;
  const int planes = separate ? spp : 1, vals = separate ? 1 : spp;
  const size_t rowbytes = (size_t{w} * vals * bps + 7) / 8, planebytes = rowbytes * h;
  // Reserved (address space only) and made row by row as libtiff decodes them, plane after plane
  // (the JPEG reader does the same): a damaged file costs the rows it held, not what its header
  // asks for. The codecs without an expansion bound above (JPEG, CCITT fax, LZMA, ZSTD, ...) are
  // refused only once a strip fails to decode, and a 1 kB file whose tags said 16384x16384 RGB had
  // 805 MB zeroed before that (Memory.DamagedTiffCostsTheRowsItHolds).
  std::vector<uint8_t> packed;
  packed.reserve(planebytes * planes);
  if (TIFFIsTiled(tif)) {
    uint32_t tw = 0, th = 0;
    TIFFGetField(tif, TIFFTAG_TILEWIDTH, &tw);
    TIFFGetField(tif, TIFFTAG_TILELENGTH, &th);
    const tmsize_t tsize = TIFFTileSize(tif), trow = TIFFTileRowSize(tif);
    if (tw == 0 || th == 0 || tsize <= 0 || trow <= 0) bad("bad tile size");
    // Not zeroed: libtiff decodes into it row by row, so a damaged tile costs the pages it reached
    // (one tile may be the whole image).
    const auto tile = std::make_unique_for_overwrite<uint8_t[]>(static_cast<size_t>(tsize));
    for (int p = 0; p < planes; ++p)
      for (uint32_t ty = 0; ty < h; ty += th) {
        for (uint32_t tx = 0; tx < w; tx += tw) {
          if (TIFFReadTile(tif, tile.get(), tx, ty, 0, static_cast<uint16_t>(p)) < 0) bad("cannot read a tile");
          if (tx == 0) packed.resize(p * planebytes + std::min(h, ty + th) * rowbytes);  // this row of tiles, once one is read
          const size_t x0 = size_t{tx} * vals * bps / 8;  // tile widths are multiples of 16 (TIFF 6.0)
          const size_t n = std::min<size_t>(static_cast<size_t>(trow), rowbytes - x0);
          for (uint32_t y = ty; y < std::min(h, ty + th); ++y)
            std::memcpy(&packed[p * planebytes + y * rowbytes + x0], &tile[(y - ty) * static_cast<size_t>(trow)], n);
        }
      }
  } else {
    if (static_cast<size_t>(TIFFScanlineSize(tif)) != rowbytes) bad("bad scanline size");
    for (int p = 0; p < planes; ++p)  // plane by plane: libtiff reads compressed strips in order
      for (uint32_t y = 0; y < h; ++y) {
        packed.resize(p * planebytes + (y + 1) * rowbytes);  // within the reserve: no reallocation
        if (TIFFReadScanline(tif, &packed[p * planebytes + y * rowbytes], y, static_cast<uint16_t>(p)) < 0)
          bad("cannot read a scanline");
      }
  }
  if (!t.error.empty()) bad("");

  // Unpack value i of a packed row (TIFF 6.0: most significant bits first).
  const auto value = [&](const uint8_t* row, size_t i) -> uint32_t {
    const size_t bit = i * bps;
    return (row[bit / 8] >> (8 - bps - bit % 8)) & ((1u << bps) - 1);
  };
  const size_t pixels = size_t{w} * h;
  if (palette) {  // OpenImageIO: 8-bit RGB, the 16-bit colour map divided by 257
    uint16_t *cr = nullptr, *cg = nullptr, *cb = nullptr;
    if (!TIFFGetField(tif, TIFFTAG_COLORMAP, &cr, &cg, &cb)) bad("palette image without a colour map");
    r.channels = 3;
    r.sample = Sample::U8;
    r.bytes.resize(pixels * 3);
    for (uint32_t y = 0; y < h; ++y)
      for (uint32_t x = 0; x < w; ++x) {
        const uint32_t i = bps == 8 ? packed[y * rowbytes + x] : value(&packed[y * rowbytes], x);
        uint8_t* o = &r.bytes[(size_t{y} * w + x) * 3];
        o[0] = cr[i] / 257, o[1] = cg[i] / 257, o[2] = cb[i] / 257;
      }
  } else {
    r.channels = spp;
    r.sample = format == SAMPLEFORMAT_IEEEFP ? (bps == 16 ? Sample::Half : Sample::F32)
               : bps <= 8 ? Sample::U8 : bps == 16 ? Sample::U16 : Sample::U32;
    r.linear = format == SAMPLEFORMAT_IEEEFP;
    const int sb = sample_bytes(r.sample);
    r.bytes.resize(pixels * spp * sb);
    if (bps < 8) {  // OpenImageIO scales 1/2/4-bit values to 8 bits: v * 255 / (2^bits - 1)
      for (int p = 0; p < planes; ++p)
        for (uint32_t y = 0; y < h; ++y)
          for (size_t i = 0; i < size_t{w} * vals; ++i)
            r.bytes[(size_t{y} * w * spp) + (separate ? i * spp + p : i)] =
                static_cast<uint8_t>(value(&packed[p * planebytes + y * rowbytes], i) * 255 / ((1u << bps) - 1));
    } else if (!separate) {
      r.bytes = std::move(packed);
    } else {
      for (size_t i = 0; i < pixels; ++i)
        for (int p = 0; p < planes; ++p)
          std::memcpy(&r.bytes[(i * spp + p) * sb], &packed[p * planebytes + i * sb], sb);
    }
    // OpenImageIO inverts min-is-white only for 8-bit results (TIFFInput::invert_photometric).
    if (photo == PHOTOMETRIC_MINISWHITE && r.sample == Sample::U8)
      for (auto& b : r.bytes) b = static_cast<uint8_t>(255 - b);
    // Unassociated alpha is premultiplied, as OpenImageIO's reader does unless told otherwise.
    uint16_t nextra = 0;
    uint16_t* extra = nullptr;
    TIFFGetField(tif, TIFFTAG_EXTRASAMPLES, &nextra, &extra);
    for (int i = 0; i < nextra; ++i)
      if (extra[i] == EXTRASAMPLE_UNASSALPHA) {
        const int alpha = spp - nextra + i;
        if (r.sample == Sample::U8) premultiply<uint8_t>(r.bytes.data(), pixels, spp, alpha);
        else if (r.sample == Sample::U16) premultiply<uint16_t>(r.bytes.data(), pixels, spp, alpha);
        else if (r.sample == Sample::F32) premultiply<float>(r.bytes.data(), pixels, spp, alpha);
        break;
      }
  }
  r.channel_samples.assign(r.channels, r.sample);
  return r;
}

void write_tiff(const std::string& path, const Raster& image) {
  const int nch = image.channels, sb = image.sample == Sample::U16 ? 2 : 1;
  if ((image.sample != Sample::U8 && image.sample != Sample::U16) || nch < 1 || nch > 4 ||
      image.bytes.size() != size_t(image.width) * image.height * nch * sb)
    internal_error(fmt::format("write_tiff: {}x{}x{} image of {} bytes", image.width, image.height, nch, image.bytes.size()));
  Tiff t(path, "w");
  if (!t.tif) fail_at(path, "cannot write (" + t.message("cannot create the file") + ")");
  TIFF* tif = t.tif;
  // As OpenImageIO's TIFF writer: contiguous samples, Deflate with the horizontal predictor, and a
  // 2nd / 4th channel marked as associated alpha, so OpenImageIO (which premultiplies unassociated
  // alpha when reading) and read_tiff give back the same samples. No DateTime or Software tag.
  const uint16_t alpha = EXTRASAMPLE_ASSOCALPHA;
  bool ok = TIFFSetField(tif, TIFFTAG_IMAGEWIDTH, uint32_t(image.width)) &&
            TIFFSetField(tif, TIFFTAG_IMAGELENGTH, uint32_t(image.height)) &&
            TIFFSetField(tif, TIFFTAG_SAMPLESPERPIXEL, uint16_t(nch)) &&
            TIFFSetField(tif, TIFFTAG_BITSPERSAMPLE, uint16_t(8 * sb)) &&
            TIFFSetField(tif, TIFFTAG_SAMPLEFORMAT, SAMPLEFORMAT_UINT) &&
            TIFFSetField(tif, TIFFTAG_PLANARCONFIG, PLANARCONFIG_CONTIG) &&
            TIFFSetField(tif, TIFFTAG_ORIENTATION, ORIENTATION_TOPLEFT) &&
            TIFFSetField(tif, TIFFTAG_PHOTOMETRIC, nch >= 3 ? PHOTOMETRIC_RGB : PHOTOMETRIC_MINISBLACK) &&
            TIFFSetField(tif, TIFFTAG_COMPRESSION, COMPRESSION_ADOBE_DEFLATE) &&
            TIFFSetField(tif, TIFFTAG_PREDICTOR, PREDICTOR_HORIZONTAL) &&
            TIFFSetField(tif, TIFFTAG_ROWSPERSTRIP, uint32_t(64)) &&
            (nch % 2 == 1 || TIFFSetField(tif, TIFFTAG_EXTRASAMPLES, uint16_t(1), &alpha));
  const size_t row = size_t(image.width) * nch * sb;
  std::vector<uint8_t> scratch(row);  // TIFFWriteScanline may modify its buffer (the predictor)
  for (int y = 0; ok && y < image.height; ++y) {
    std::memcpy(scratch.data(), &image.bytes[y * row], row);
    ok = TIFFWriteScanline(tif, scratch.data(), uint32_t(y), 0) >= 0;
  }
  ok = ok && TIFFFlush(tif);
  TIFFClose(tif);
  t.tif = nullptr;
  if (!ok || !t.error.empty()) fail_at(path, "cannot write (" + t.message("libtiff failed") + ")");
}

}  // namespace photosite::codec
