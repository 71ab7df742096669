// PNG by hand for the data-set route (private header, core/ and tests only): the plain files
// Cityscapes, KITTI and BDD100K ship (8- or 16-bit grey or RGB, not interlaced, no transparency,
// no colour chunk but sRGB's) decoded with libdeflate's inflate, and 8-bit grey / RGB written
// with one filter for every row and one whole-buffer deflate (libdeflate, or zlib with a chosen
// strategy). The file format is the PNG specification's (ISO/IEC 15948:2004, W3C PNG 2nd ed.):
// signature, IHDR, IDAT (a zlib stream of filtered rows), IEND, each chunk with its CRC-32.
// Files the decoder does not take (anything else) go through OpenImageIO (core/io.cpp); the
// results are the same (tests/png_codec_test.cpp).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "photosite/io.h"

namespace photosite::detail {
// read_image and read_image_u16 through OpenImageIO alone, the decoder above bypassed (the
// tests compare the two paths).
ImageF read_image_general(const std::string& path, ImageFileInfo* info = nullptr);
ImageU16 read_image_u16_general(const std::string& path, ImageFileInfo* info = nullptr);
}  // namespace photosite::detail

namespace photosite::png {

// A decoded file: samples in reading order, channels interleaved; 16-bit samples in host order.
struct Decoded {
  int width = 0, height = 0, channels = 0, bits = 0;
  std::vector<uint8_t> u8;    // bits == 8
  std::vector<uint16_t> u16;  // bits == 16
};

// Deflate's largest expansion (RFC 1951 §3.2.5-3.2.7): the longest match, 258 bytes, is coded by
// at least one bit of its length code and one of its distance code (each Huffman alphabet in use
// has codes of at least one bit), so one byte of stream inflates to at most 4 x 258 = 1032 bytes.
// A PNG whose IDAT data is shorter than its header's rows over this is damaged or truncated.
inline constexpr int64_t kMaxDeflateRatio = 1032;

// Decodes `bytes` (a whole file) when it is a PNG this decoder takes; std::nullopt when it is
// not (another format, interlaced, palette, alpha, tRNS / iCCP / sBIT chunks, gAMA or cHRM
// without an sRGB chunk, any damage: bad CRC, short data, unknown filter), so the caller's
// general reader handles it and reports damage in its own words. `max_pixels` refuses oversized frames before allocating.
std::optional<Decoded> decode(const std::vector<uint8_t>& bytes, int64_t max_pixels);

// The row filter (PNG filter type 0..4; Adaptive: per row the one of the five with the smallest
// sum of |signed bytes|, libpng's heuristic).
enum class Filter { None = 0, Sub = 1, Up = 2, Average = 3, Paeth = 4, Adaptive = 5 };
// HuffmanOnly: core/huffman_deflate.h's literal-only blocks (level and strategy unused).
enum class Deflater { Libdeflate, Zlib, HuffmanOnly };
struct EncodeOptions {
  Deflater deflater = Deflater::HuffmanOnly;
  int level = 1;         // libdeflate 1..12, zlib 0..9
  int zlib_strategy = 2;  // Z_DEFAULT_STRATEGY 0, Z_FILTERED 1, Z_HUFFMAN_ONLY 2, Z_RLE 3 (zlib only)
  Filter filter = Filter::Average;
};
// What write_png8 uses: Huffman-only coding (no string matching) of Average-filtered rows, by
// core/huffman_deflate.h: the stream zlib's Z_HUFFMAN_ONLY strategy writes, in less time
// (bench_png.csv, docs/cli.md "PNG input and output"). Sensor noise leaves LZ77 few matches,
// so a match search costs time and its matches cost bits.
EncodeOptions default_encode_options();

// The whole PNG file of an 8-bit grey (channels 1) or RGB (3) image.
std::string encode(const uint8_t* samples, int width, int height, int channels, const EncodeOptions& o);

}  // namespace photosite::png
