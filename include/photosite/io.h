// Image files: PNG (libspng, and core/png_codec.h for the data sets' plain files), JPEG
// (libjpeg-turbo), TIFF (libtiff) and OpenEXR (OpenEXR) read into float or integer images,
// multi-channel OpenEXR written with named layers, units and provenance in the header, and PNG
// (or TIFF) previews. Every write goes to a temporary name in the target folder and is renamed into
// place only when complete, so a failed or killed run never leaves a half-written file.
#pragma once
#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <variant>
#include <vector>

#include "photosite/image.h"

namespace photosite {

struct ImageFileInfo {
  std::string path;
  std::string format;  // "png", "openexr", "tiff", "jpeg", ...
  int width = 0, height = 0, channels = 0;
  int bits_per_sample = 0;  // 8, 16, 32 (float)...
  bool is_float = false;    // stored as float/half: taken as linear
  bool srgb_encoded = false;  // integer formats: sRGB transfer unless the file says linear
  // What the reader noted of the file beyond its pixels, as it says it on the standard error: an
  // OpenEXR data window not at (0, 0) or unlike its display window, a JPEG's Exif orientation
  // (neither is applied: the pixels are read as stored). "" when there is nothing to say.
  std::string note;
};

ImageFileInfo probe_image(const std::string& path);

// The largest frame photosite accepts, in pixels: $PHOTOSITE_MAX_PIXELS or 2^28 (16384x16384).
// Image headers are checked against it before any pixel buffer is allocated, so a file that
// declares 40000x40000 is refused instead of exhausting memory.
int64_t max_frame_pixels();
// Bad input (exit 2, "<what>: ...") unless width x height is a possible image: at least 1x1 and
// at most max_frame_pixels(). The readers and write_exr check this: an image file of one row (a
// line profile, a 1-D lookup table) is a valid image.
void check_image_size(const std::string& what, int64_t width, int64_t height);
// Bad input (exit 2, "<what>: ...") unless width x height is a possible sensor frame: an image
// (check_image_size) of at least 2x2 pixels, one CFA tile. Checked where an image becomes a frame
// the sensor exposes or demosaics (expose's radiance, night's and batch's day photo, a mosaic).
void check_frame_size(const std::string& what, int64_t width, int64_t height);

// Reads every channel as float. Integer files are normalised to [0, 1] (value / max code).
ImageF read_image(const std::string& path, ImageFileInfo* info = nullptr);
// Reads raw integer codes (8 or 16-bit files), unscaled: labels, instance ids, mosaics.
ImageU16 read_image_u16(const std::string& path, ImageFileInfo* info = nullptr);

// ---- OpenEXR ------------------------------------------------------------------------------
// The EXR pixel type of a channel. Float: float32, or half when ExrWriteOptions::half. Half:
// always half. Uint: 32-bit unsigned integer; the source values must be integers in
// [0, 2^32) (write_exr refuses others), stored exactly.
enum class ExrPixel { Float, Half, Uint };
const char* to_string(ExrPixel p);  // "float", "half", "uint"

struct ExrChannelGroup {
  std::vector<std::string> channel_names;  // full names, e.g. {"raw.Y"} or {"R","G","B"}
  const ImageF* image = nullptr;           // channels() == channel_names.size()
  std::string unit;                        // recorded as header attribute "photosite/unit/<name>"
  ExrPixel pixel = ExrPixel::Float;
  // Instead of `image`, for pixel Uint: 16-bit integer samples (class ids), widened to the UINT
  // channel as they are, with no float in between.
  const ImageU16* image_u16 = nullptr;
};
using ExrAttribute = std::variant<std::string, int, float, double>;

// The compressions this OpenEXR (3.1) writes, by the names OpenImageIO gave them: none, rle, zips, zip, piz
// (lossless), pxr24 (lossy for float32: rounds to 24 bits), b44, b44a, dwaa, dwab (lossy for
// half and float; integer channels are always stored losslessly, OpenEXR's rule).
const std::vector<std::string>& exr_compressions();
bool exr_compression_lossless(const std::string& name);
// Bad input naming `what` (e.g. "--compression") unless `name` is one of exr_compressions().
void check_exr_compression(const std::string& name, const std::string& what);
// The default of `expose`, `night` and `batch`: of the lossless codecs, the one that wrote the
// typed night layers smallest, in about half zip's time; none and rle were faster at 4-5x the
// bytes (docs/bench_exr.csv, `photosite bench exr`).
inline constexpr const char* kDefaultExrCompression = "piz";

struct ExrWriteOptions {
  bool half = false;                // store as half instead of float32
  std::string compression = "zip";  // none, rle, zips, zip, piz, pxr24, b44, dwaa, dwab
  // Byte-reproducible files: the header's capture date (capDate, read back as "DateTime") is
  // "0000:00:00 00:00:00" instead of the wall clock, so the same inputs give the same bytes on
  // any machine and any day.
  bool reproducible = false;
  // Never replace: the finished file is published with link(), which fails when the name
  // exists; write_exr then discards its own file and returns false (someone else's is there).
  // Where the file system has no hard links: a no-replace rename, else an exclusive create of the
  // name filled from the finished file (atomic_create; core/io.cpp, write_then_publish).
  bool create_only = false;
};

// Returns true when the file was written; false only with create_only and an existing file.
bool write_exr(const std::string& path, const std::vector<ExrChannelGroup>& groups,
               const std::map<std::string, ExrAttribute>& attributes,
               const ExrWriteOptions& options = {});

struct ExrContents {
  int width = 0, height = 0;
  std::map<std::string, ImageF> channels;  // one single-channel image per channel name
  std::map<std::string, std::string> attributes;  // every attribute, as text
  std::map<std::string, ExrPixel> pixel_types;    // each channel's stored type
};
ExrContents read_exr(const std::string& path);
// Every header attribute as text, as ExrContents::attributes has them, without the pixels: for a
// reader that decides from a file's header (photosite/unit/<channel>, photosite/cfa) whether and
// how to read it. Bad input naming the file when it is missing, not OpenEXR or damaged.
std::map<std::string, std::string> read_exr_attributes(const std::string& path);

// 8- or 16-bit PNG (or TIFF, by the extension .tif / .tiff) from float [0,1] samples, rounded
// by float_to_code8 / float_to_code16; 1 to 4 channels.
void write_png(const std::string& path, const ImageF& image, int bits = 8);
// A [0, 1] sample as an 8- or 16-bit code, as OpenImageIO converted (and the files photosite
// wrote through it hold): v·max + 0.5 (− 0.5 below zero), clamped to the codes, truncated.
uint8_t float_to_code8(float v);
uint16_t float_to_code16(float v);
// 8-bit PNG of the codes as they are (1 grey or 3 RGB channels), through libpng: zlib
// level 1 and the Sub filter, no time or text chunks (the same bytes on any day). Written
// atomically like every output.
void write_png8(const std::string& path, const ImageU8& image);

// Refuses (bad input, exit 2) an input that is missing (MissingFileError), unreachable (the
// system's reason), a folder, or not a regular file (a pipe: inputs are read twice).
void check_input_file(const std::string& path);

// ---- safe output ----------------------------------------------------------------------------
// Refuses (bad input, exit 2) when the folder is missing or the file exists and !overwrite.
void check_output_path(const std::string& path, bool overwrite);
// Runs write(temp_path) and renames temp_path to path; removes the temporary on any error.
void atomic_write(const std::string& path, const std::function<void(const std::string&)>& write);
// The same, but never replacing: false (temporary removed) when path already exists.
bool atomic_create(const std::string& path, const std::function<void(const std::string&)>& write);
// The temporaries are named '.<stem>.tmp-<scope>-<pid>-<n><ext>' beside their target. <scope> is
// this: 8 hex digits of a hash of the host name, the boot id and the pid namespace: the space in which <pid>
// names a process (several machines or containers may write into one shared folder).
const std::string& temporary_pid_scope();
// True for a file name of exactly that pattern, of this pid scope, whose process is gone: a
// temporary that a killed run left behind and nobody is writing. Anything else is false:
// another machine's temporaries and other people's files are never taken for stale.
bool is_stale_temporary(const std::string& filename);
// Removes, under `folder` (recursively), the regular files that are stale temporaries: what a run
// killed outright (SIGKILL, no handler) left there. Links and every other file are left alone. Used
// by batch on --out at start and by the device store under its lock.
void remove_stale_temporaries(const std::string& folder);
// Removes the temporaries of the writes in progress (unlink only: async-signal-safe). A program
// calls it from its SIGINT/SIGTERM handler before it dies, so an interrupted run leaves no
// half-written file behind (the error paths remove theirs as they unwind).
void remove_partial_outputs() noexcept;
// A path's extension in lower case, with its dot (".png"; "" when it has none): what the readers,
// the writers, batch's file search and the command line's output checks compare.
std::string lower_extension(const std::string& path);
// Replaces the run of '#' in a pattern with the zero-padded frame number ("out_###.exr").
std::string frame_path(const std::string& pattern, int frame);

}  // namespace photosite
