// PNG decode / encode for the data-set route (core/png_codec.h).
#include "core/png_codec.h"

#include <libdeflate.h>
#include <zlib.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <new>

#include "core/huffman_deflate.h"
#include "photosite/error.h"

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace photosite::png {
namespace {
constexpr uint8_t kSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};

uint32_t be32(const uint8_t* p) {
  return uint32_t{p[0]} << 24 | uint32_t{p[1]} << 16 | uint32_t{p[2]} << 8 | uint32_t{p[3]};
}
void put_be32(std::string& s, uint32_t v) {
  const char b[4] = {static_cast<char>(v >> 24), static_cast<char>(v >> 16), static_cast<char>(v >> 8),
                     static_cast<char>(v)};
  s.append(b, 4);
}
bool is_type(const uint8_t* t, const char* name) { return std::memcmp(t, name, 4) == 0; }

int paeth_predictor(int a, int b, int c) {  // PNG spec 9.4: left, above, upper left
  const int p = a + b - c, pa = std::abs(p - a), pb = std::abs(p - b), pc = std::abs(p - c);
  return pa <= pb && pa <= pc ? a : pb <= pc ? b : c;
}

#if defined(__SSE2__)
// Paeth reconstruction of 3-byte pixels, one pixel per step in 16-bit lanes (the per-pixel
// dependency on the left neighbour is serial); the predictor's tie order as in the spec.
// A pixel's 3 bytes in the low lanes. Four bytes are read where the row goes on (the fourth
// lane is never stored): a 3-byte copy through the stack stalls store-to-load forwarding, which
// made the loop 4x slower (perf annotate of png::decode on the Cityscapes frames).
__m128i load3(const uint8_t* p, bool last) {
  uint32_t t = 0;
  if (last) std::memcpy(&t, p, 3);
  else std::memcpy(&t, p, 4);
  return _mm_cvtsi32_si128(static_cast<int>(t));
}
void store3(uint8_t* p, __m128i v) {
  const uint32_t t = static_cast<uint32_t>(_mm_cvtsi128_si32(v));
  std::memcpy(p, &t, 3);
}
__m128i abs16(__m128i x) { return _mm_max_epi16(x, _mm_sub_epi16(_mm_setzero_si128(), x)); }
__m128i select(__m128i m, __m128i t, __m128i e) { return _mm_or_si128(_mm_and_si128(m, t), _mm_andnot_si128(m, e)); }
void unpaeth3(uint8_t* o, const uint8_t* s, const uint8_t* up, size_t stride) {
  const __m128i zero = _mm_setzero_si128(), low = _mm_set1_epi16(0xff);
  __m128i a = zero, c = zero;
  for (size_t i = 0; i < stride; i += 3) {
    const bool last = i + 3 == stride;
    const __m128i b = _mm_unpacklo_epi8(load3(up + i, last), zero);
    __m128i pa = _mm_sub_epi16(b, c), pb = _mm_sub_epi16(a, c);  // p - a, p - b
    __m128i pc = abs16(_mm_add_epi16(pa, pb));                       // p - c
    pa = abs16(pa);
    pb = abs16(pb);
    const __m128i least = _mm_min_epi16(pc, _mm_min_epi16(pa, pb));
    const __m128i pred = select(_mm_cmpeq_epi16(least, pa), a, select(_mm_cmpeq_epi16(least, pb), b, c));
    const __m128i d = _mm_and_si128(_mm_add_epi16(_mm_unpacklo_epi8(load3(s + i, last), zero), pred), low);
    store3(o + i, _mm_packus_epi16(d, d));
    c = b;
    a = d;
  }
}
#endif

// Undoes one row's filter in place of `o` (the row's bytes s, the row above `up`, nullptr on
// the first row); false for an unknown filter type.
bool unfilter(int type, uint8_t* o, const uint8_t* s, const uint8_t* up, size_t stride, int bpp) {
  switch (type) {
    case 0: std::memcpy(o, s, stride); return true;
    case 1:
      for (int i = 0; i < bpp; ++i) o[i] = s[i];
      for (size_t i = bpp; i < stride; ++i) o[i] = static_cast<uint8_t>(s[i] + o[i - bpp]);
      return true;
    case 2:
      if (!up) std::memcpy(o, s, stride);
      else for (size_t i = 0; i < stride; ++i) o[i] = static_cast<uint8_t>(s[i] + up[i]);
      return true;
    case 3:
      for (size_t i = 0; i < stride; ++i) {
        const int a = i >= static_cast<size_t>(bpp) ? o[i - bpp] : 0, b = up ? up[i] : 0;
        o[i] = static_cast<uint8_t>(s[i] + ((a + b) >> 1));
      }
      return true;
    case 4:
      if (!up) return unfilter(1, o, s, up, stride, bpp);  // above and upper left are 0: Sub
#if defined(__SSE2__)
      if (bpp == 3) {
        unpaeth3(o, s, up, stride);
        return true;
      }
#endif
      for (size_t i = 0; i < stride; ++i) {
        const bool left = i >= static_cast<size_t>(bpp);
        o[i] = static_cast<uint8_t>(s[i] + paeth_predictor(left ? o[i - bpp] : 0, up[i], left ? up[i - bpp] : 0));
      }
      return true;
    default: return false;
  }
}

struct Compressor {
  libdeflate_compressor* c;
  ~Compressor() { libdeflate_free_compressor(c); }
};
struct Decompressor {
  libdeflate_decompressor* d;
  ~Decompressor() { libdeflate_free_decompressor(d); }
};
}  // namespace

std::optional<Decoded> decode(const std::vector<uint8_t>& bytes, int64_t max_pixels) {
  if (bytes.size() < 8 + 25 || std::memcmp(bytes.data(), kSignature, 8) != 0) return std::nullopt;
  Decoded img;
  int color_type = -1;
  std::vector<uint8_t> z;          // the IDAT chunks' data, concatenated
  const uint8_t* idat = nullptr;   // the one IDAT's data when there is only one (no copy)
  size_t idat_len = 0, idat_count = 0;
  bool ended = false, prev_idat = false;
  // gAMA and cHRM describe the samples' transfer and primaries; an sRGB chunk overrides both
  // (PNG 2nd ed. 11.3.3.5: a decoder that knows sRGB ignores gAMA and cHRM beside it), and it
  // says what the decoder reports anyway (sRGB). gAMA or cHRM alone (gamma 1.0 means linear to
  // OpenImageIO) goes to the general reader.
  bool srgb_chunk = false, gamma_or_chromaticities = false;
  for (size_t pos = 8; pos + 12 <= bytes.size(); pos += 12 + be32(&bytes[pos])) {
    const uint32_t len = be32(&bytes[pos]);
    if (len > bytes.size() - pos - 12) return std::nullopt;  // truncated
    const uint8_t* type = &bytes[pos + 4];
    const uint8_t* data = type + 4;
    if (libdeflate_crc32(0, type, len + 4) != be32(data + len)) return std::nullopt;  // damaged
    if (pos == 8) {  // IHDR comes first: width, height, bit depth, colour type, methods
      if (!is_type(type, "IHDR") || len != 13) return std::nullopt;
      const uint32_t w = be32(data), h = be32(data + 4);
      img.bits = data[8];
      color_type = data[9];
      if (w == 0 || h == 0 || w > (1u << 30) || h > (1u << 30) ||
          static_cast<int64_t>(w) * static_cast<int64_t>(h) > max_pixels)
        return std::nullopt;
      if ((img.bits != 8 && img.bits != 16) || (color_type != 0 && color_type != 2) || data[10] != 0 ||
          data[11] != 0 || data[12] != 0)  // deflate, adaptive filtering, no interlace
        return std::nullopt;
      img.width = static_cast<int>(w);
      img.height = static_cast<int>(h);
      img.channels = color_type == 2 ? 3 : 1;
    } else if (is_type(type, "IDAT")) {
      if (idat_count > 0 && !prev_idat) return std::nullopt;  // IDAT chunks must be consecutive
      if (idat_count == 1) z.assign(idat, idat + idat_len);
      if (idat_count >= 1) z.insert(z.end(), data, data + len);
      idat = data;
      idat_len = len;
      ++idat_count;
    } else if (is_type(type, "IEND")) {
      ended = true;
      break;
    } else if (is_type(type, "sRGB")) {
      srgb_chunk = true;
    } else if (is_type(type, "gAMA") || is_type(type, "cHRM")) {
      gamma_or_chromaticities = true;
    } else if (!(type[0] & 0x20) || is_type(type, "tRNS") || is_type(type, "iCCP") || is_type(type, "sBIT")) {
      // A critical chunk other than the three (PLTE in a grey / RGB file included), or one
      // that changes what the samples mean: left to the general reader.
      return std::nullopt;
    }
    prev_idat = is_type(type, "IDAT");
  }
  if (!ended || idat_count == 0 || (gamma_or_chromaticities && !srgb_chunk)) return std::nullopt;
  const uint8_t* zdata = idat_count == 1 ? idat : z.data();
  const size_t zlen = idat_count == 1 ? idat_len : z.size();
  const int bpp = img.channels * img.bits / 8;
  const size_t stride = static_cast<size_t>(img.width) * bpp;
  // Deflate expands at most 1032:1 (kMaxDeflateRatio): a file too small for its header's size is
  // damaged; the general reader refuses it before the allocation it asks for.
  if ((stride + 1) * img.height / kMaxDeflateRatio > zlen + 64) return std::nullopt;
  std::vector<uint8_t> filtered((stride + 1) * img.height);
  const Decompressor d{libdeflate_alloc_decompressor()};
  if (!d.d) throw std::bad_alloc();
  size_t got = 0;
  if (libdeflate_zlib_decompress(d.d, zdata, zlen, filtered.data(), filtered.size(), &got) != LIBDEFLATE_SUCCESS ||
      got != filtered.size())
    return std::nullopt;
  std::vector<uint8_t> out(stride * img.height);
  for (int y = 0; y < img.height; ++y) {
    const uint8_t* s = &filtered[(stride + 1) * y];
    uint8_t* o = &out[stride * y];
    if (!unfilter(s[0], o, s + 1, y > 0 ? o - stride : nullptr, stride, bpp)) return std::nullopt;
  }
  if (img.bits == 8) {
    img.u8 = std::move(out);
  } else {
    img.u16.resize(out.size() / 2);
    for (size_t i = 0; i < img.u16.size(); ++i)
      img.u16[i] = static_cast<uint16_t>(out[2 * i] << 8 | out[2 * i + 1]);  // PNG stores big-endian
  }
  return img;
}

EncodeOptions default_encode_options() { return EncodeOptions{}; }

std::string encode(const uint8_t* samples, int width, int height, int channels, const EncodeOptions& o) {
  if ((channels != 1 && channels != 3) || width < 1 || height < 1)
    internal_error("png::encode: a grey or RGB image of at least one pixel");
  const int bpp = channels;
  const size_t stride = static_cast<size_t>(width) * bpp;
  std::vector<uint8_t> rows((stride + 1) * height);
  std::vector<uint8_t> trial(o.filter == Filter::Adaptive ? 5 * stride : 0);
  for (int y = 0; y < height; ++y) {
    const uint8_t* r = samples + stride * y;
    const uint8_t* up = y > 0 ? r - stride : nullptr;
    uint8_t* f = &rows[(stride + 1) * y];
    auto apply = [&](int type, uint8_t* dst) {  // the filter's bytes of this row
      for (size_t i = 0; i < stride; ++i) {
        const int a = i >= static_cast<size_t>(bpp) ? r[i - bpp] : 0, b = up ? up[i] : 0,
                  c = up && i >= static_cast<size_t>(bpp) ? up[i - bpp] : 0;
        const int pred = type == 0 ? 0 : type == 1 ? a : type == 2 ? b : type == 3 ? (a + b) >> 1 : paeth_predictor(a, b, c);
        dst[i] = static_cast<uint8_t>(r[i] - pred);
      }
    };
    int type = static_cast<int>(o.filter);
    // Filtering has no serial dependency (it reads the unfiltered image), so each filter is a
    // plain loop that vectorizes; the first pixel (no left neighbour) and the first row (no row
    // above) by the general code.
    uint8_t* d = f + 1;
    if (o.filter == Filter::None) {
      std::memcpy(d, r, stride);
    } else if (o.filter == Filter::Sub) {
      for (int i = 0; i < bpp; ++i) d[i] = r[i];
      for (size_t i = bpp; i < stride; ++i) d[i] = static_cast<uint8_t>(r[i] - r[i - bpp]);
    } else if (o.filter == Filter::Adaptive || !up) {
      if (o.filter != Filter::Adaptive) apply(type, d);
    } else if (o.filter == Filter::Up) {
      for (size_t i = 0; i < stride; ++i) d[i] = static_cast<uint8_t>(r[i] - up[i]);
    } else if (o.filter == Filter::Average) {
      for (int i = 0; i < bpp; ++i) d[i] = static_cast<uint8_t>(r[i] - (up[i] >> 1));
      for (size_t i = bpp; i < stride; ++i) d[i] = static_cast<uint8_t>(r[i] - ((r[i - bpp] + up[i]) >> 1));
    } else {  // Paeth, branch-free
      for (int i = 0; i < bpp; ++i) d[i] = static_cast<uint8_t>(r[i] - up[i]);  // a = c = 0: predicts b
      for (size_t i = bpp; i < stride; ++i) {
        const int16_t a = r[i - bpp], b = up[i], c = up[i - bpp];
        const int16_t pa = static_cast<int16_t>(std::abs(b - c)), pb = static_cast<int16_t>(std::abs(a - c)),
                      pc = static_cast<int16_t>(std::abs(a + b - 2 * c));
        const int16_t pred = (pa <= pb && pa <= pc) ? a : (pb <= pc ? b : c);
        d[i] = static_cast<uint8_t>(r[i] - pred);
      }
    }
    if (o.filter != Filter::Adaptive) {
    } else {
      uint64_t best = UINT64_MAX;
      for (int t = 0; t < 5; ++t) {
        uint8_t* dst = &trial[t * stride];
        apply(t, dst);
        uint64_t sum = 0;  // sum of |bytes as signed|
        for (size_t i = 0; i < stride; ++i) sum += static_cast<uint64_t>(std::abs(static_cast<int8_t>(dst[i])));
        if (sum < best) best = sum, type = t;
      }
      std::memcpy(f + 1, &trial[type * stride], stride);
    }
    f[0] = static_cast<uint8_t>(type);
  }

  std::string out(reinterpret_cast<const char*>(kSignature), 8);
  auto chunk = [&](const char* type, const uint8_t* data, size_t len) {
    put_be32(out, static_cast<uint32_t>(len));
    const size_t at = out.size();
    out.append(type, 4);
    out.append(reinterpret_cast<const char*>(data), len);
    put_be32(out, libdeflate_crc32(0, out.data() + at, len + 4));
  };
  uint8_t ihdr[13];
  for (int i = 0; i < 4; ++i) {
    ihdr[i] = static_cast<uint8_t>(static_cast<uint32_t>(width) >> (24 - 8 * i));
    ihdr[4 + i] = static_cast<uint8_t>(static_cast<uint32_t>(height) >> (24 - 8 * i));
  }
  ihdr[8] = 8;
  ihdr[9] = channels == 3 ? 2 : 0;
  ihdr[10] = ihdr[11] = ihdr[12] = 0;
  chunk("IHDR", ihdr, 13);
  std::vector<uint8_t> z;
  if (o.deflater == Deflater::HuffmanOnly) {
    z = huffman_only::zlib_stream(rows.data(), rows.size());
  } else if (o.deflater == Deflater::Libdeflate) {
    const Compressor c{libdeflate_alloc_compressor(std::clamp(o.level, 1, 12))};
    if (!c.c) throw std::bad_alloc();
    z.resize(libdeflate_zlib_compress_bound(c.c, rows.size()));
    const size_t n = libdeflate_zlib_compress(c.c, rows.data(), rows.size(), z.data(), z.size());
    if (n == 0) internal_error("png::encode: libdeflate output did not fit its bound");
    z.resize(n);
  } else {
    z_stream s{};
    if (deflateInit2(&s, std::clamp(o.level, 0, 9), Z_DEFLATED, 15, 8, o.zlib_strategy) != Z_OK)
      internal_error("png::encode: deflateInit2 failed");
    z.resize(deflateBound(&s, rows.size()));
    s.next_in = rows.data();
    s.avail_in = static_cast<uInt>(rows.size());
    s.next_out = z.data();
    s.avail_out = static_cast<uInt>(z.size());
    const int rc = deflate(&s, Z_FINISH);
    z.resize(s.total_out);
    deflateEnd(&s);
    if (rc != Z_STREAM_END) internal_error("png::encode: zlib deflate did not finish");
  }
  // One IDAT (a chunk may hold 2^31 - 1 bytes; a 2048x1024 preview compresses to a few MB).
  for (size_t at = 0; at < z.size() || at == 0; at += 0x40000000) {
    chunk("IDAT", z.data() + at, std::min<size_t>(0x40000000, z.size() - at));
    if (z.empty()) break;
  }
  chunk("IEND", nullptr, 0);
  return out;
}

}  // namespace photosite::png
