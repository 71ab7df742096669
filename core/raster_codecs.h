// Image file codecs on the format's own library (private header, core/ and tests only): OpenEXR
// through OpenEXR, PNG through libspng (the data sets' plain PNGs through core/png_codec.h first),
// JPEG through libjpeg-turbo, TIFF through libtiff. They replaced OpenImageIO, whose dependency
// closure (about 260 shared libraries: GDAL, DCMTK, FFmpeg, libheif, Poppler...) cost every
// start of the command and of the Python module about 0.3 s of dynamic linking
// (docs/benchmarks.md "Start-up"). The samples they give are OpenImageIO's for the same files
// (tests/codecs_test.cpp reads each file both ways).
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace photosite::codec {

enum class Sample { U8, U16, U32, Half, F32 };
int sample_bytes(Sample s);

// A decoded file: samples interleaved by channel, rows top to bottom, in host byte order.
struct Raster {
  std::string format;  // "png", "jpeg", "tiff", "openexr"
  int width = 0, height = 0, channels = 0;
  Sample sample = Sample::U8;
  // Per channel (OpenEXR: the file's per-channel types; every other format: `sample`).
  std::vector<Sample> channel_samples;
  std::vector<std::string> channel_names;  // OpenEXR's names; empty for the other formats
  bool linear = false;  // the file says its values are linear (float formats; PNG gAMA 1.0)
  std::vector<uint8_t> bytes;  // width * height * (sum of the channels' sample bytes)
  std::map<std::string, std::string> attributes;  // OpenEXR's header attributes as text
  std::string note;  // ImageFileInfo::note: what the reader said of the file on the standard error
};

// The whole file at `path`; bad input naming it when it cannot be opened or read.
std::vector<uint8_t> read_file(const std::string& path);

// Every reader refuses (fail_at(path, ...), exit 2) a damaged or truncated file, a frame outside
// check_frame_size before allocating it, and more than 64 channels.
Raster read_jpeg(const std::string& path);
Raster read_tiff(const std::string& path);

// Writes an 8- or 16-bit (U8 / U16) TIFF, 1 to 4 channels, Deflate-compressed, no date tag.
void write_tiff(const std::string& path, const Raster& image);

// JPEG of 8-bit RGB samples in memory, and back: the same bytes and pixels as OpenCV's
// imencode(".jpg", quality) / imdecode(IMREAD_COLOR) of the same image (libjpeg-turbo with
// jpeg_set_defaults: 4:2:0 chroma, baseline, the islow DCT, fancy upsampling).
std::vector<uint8_t> encode_jpeg_rgb8(const uint8_t* rgb, int width, int height, int quality);
// The largest width or height a JPEG holds (libjpeg's JPEG_MAX_DIMENSION, 65500 px).
int jpeg_max_dimension();
std::vector<uint8_t> decode_jpeg_rgb8(const std::vector<uint8_t>& jpeg, int expect_width, int expect_height);

}  // namespace photosite::codec
