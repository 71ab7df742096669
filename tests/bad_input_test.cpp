// Bad input, table-driven, through the real `photosite` binary: every row builds a folder of
// inputs (good ones, then one thing broken), runs a command and checks the contract of
// include/photosite/error.h — exit status 2, a message naming the file (or option) and the
// problem, and no output left behind (not even a temporary). The good-input controls at the end
// run the same commands on the unbroken inputs and must succeed, so a row cannot pass because
// its inputs were broken in some other way.
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <map>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <sstream>
#include <vector>

#include <fmt/format.h>

#include "photosite/io.h"
#include "photosite/sensor/preset.h"
#include "test_util.h"

using namespace photosite;
namespace fs = std::filesystem;

namespace {

constexpr int kW = 128, kH = 64;  // the good frames

struct Ctx {
  fs::path dir;  // in/ out/ store/ under it
  std::string in(const std::string& n) const { return (dir / "in" / n).string(); }
  std::string out(const std::string& n) const { return (dir / "out" / n).string(); }
  std::string store() const { return (dir / "store").string(); }
};

std::string slurp(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}
void put(const std::string& path, const std::string& bytes) {
  std::ofstream f(path, std::ios::binary | std::ios::trunc);
  f.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}
void truncate_to(const std::string& path, double fraction) {
  const std::string b = slurp(path);
  put(path, b.substr(0, static_cast<size_t>(b.size() * fraction)));
}
// Overwrites the bytes from `fraction` of the file to its end with a fixed pseudo-random
// pattern: the header stays intact, the compressed pixel data becomes garbage.
void corrupt_tail(const std::string& path, double fraction) {
  std::string b = slurp(path);
  uint32_t x = 0x12345678u;
  for (size_t i = static_cast<size_t>(b.size() * fraction); i < b.size(); ++i) {
    x = x * 1664525u + 1013904223u;
    b[i] = static_cast<char>(x >> 24);
  }
  put(path, b);
}

uint32_t crc32(const unsigned char* p, size_t n) {  // PNG's CRC (ISO 3309), bitwise
  uint32_t c = 0xFFFFFFFFu;
  for (size_t i = 0; i < n; ++i) {
    c ^= p[i];
    for (int k = 0; k < 8; ++k) c = (c >> 1) ^ (0xEDB88320u & (0u - (c & 1u)));
  }
  return c ^ 0xFFFFFFFFu;
}
// Rewrites a PNG's IHDR to declare width x height, with a correct CRC, pixel data unchanged.
void png_declare_size(const std::string& path, uint32_t w, uint32_t h) {
  std::string b = slurp(path);
  auto be = [&](size_t at, uint32_t v) {
    for (int k = 0; k < 4; ++k) b[at + k] = static_cast<char>(v >> (24 - 8 * k));
  };
  be(16, w);
  be(20, h);
  be(29, crc32(reinterpret_cast<const unsigned char*>(b.data()) + 12, 17));
  put(path, b);
}
// Rewrites an EXR's dataWindow and displayWindow (box2i attributes) to 0..w-1 x 0..h-1.
void exr_declare_size(const std::string& path, int32_t w, int32_t h) {
  std::string b = slurp(path);
  for (const std::string name : {"dataWindow", "displayWindow"}) {
    const std::string tag = name + std::string("\0box2i\0", 7);
    const size_t at = b.find(tag);
    ASSERT_NE(at, std::string::npos) << name;
    const int32_t box[4] = {0, 0, w - 1, h - 1};
    std::memcpy(b.data() + at + tag.size() + 4, box, sizeof box);  // after the int32 size
  }
  // Room for the chunk offset table the header now implies (at most one 8-byte offset per line,
  // as an uncompressed file has: the device maps are stored so), so OpenEXR opens the file and
  // it is photosite's size check that refuses it.
  put(path, b + std::string(static_cast<size_t>(h) * 8 + 64 * 1024, '\0'));
}

// Sets the declared size of an EXR header attribute (the int32 after "name\0type\0") to `bytes`,
// as a damaged file may: OpenEXR would allocate that much before finding the file too short.
// With `relative`, `bytes` is added to the size the file declares.
void exr_attribute_size(const std::string& path, const std::string& name, const std::string& type,
                        int32_t bytes, bool relative = false) {
  std::string b = slurp(path);
  const std::string tag = name + '\0' + type + '\0';
  const size_t at = b.find(tag);
  ASSERT_NE(at, std::string::npos) << name;
  int32_t old = 0;
  std::memcpy(&old, b.data() + at + tag.size(), sizeof old);
  if (relative) bytes += old;
  std::memcpy(b.data() + at + tag.size(), &bytes, sizeof bytes);
  put(path, b);
}

ImageF day_image(int w = kW, int h = kH) {
  ImageF img(w, h, 3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < 3; ++c) img.at(x, y, c) = 0.2f + 0.6f * ((x + y + 7 * c) % 17) / 17.f;
  return img;
}
// Cityscapes labelIds: sky (23) above, building (11) in the middle, road (7) below.
ImageF label_ids(int w = kW, int h = kH, int odd_value = -1) {
  ImageF img(w, h, 1);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) img.at(x, y) = (y < h / 3 ? 23 : y < h / 2 ? 11 : 7) / 255.f;
  if (odd_value >= 0) img.at(w / 2, h / 2) = odd_value / 255.f;
  return img;
}
void write_radiance(const std::string& path, int w = kW, int h = kH, float odd = 1.f,
                    int channels = 3) {
  ImageF r(w, h, channels, 0.05f);
  r[r.size() / 2] = odd;
  std::vector<std::string> names = {"R", "G", "B"};
  names.resize(channels);
  if (channels == 2) names = {"R", "G"};
  write_exr(path, {{names, &r, "W.sr-1.m-2"}}, {});
}
// Radiance that does not compress (a hash per pixel), so most of the file is pixel data.
void write_textured_radiance(const std::string& path) {
  ImageF r(kW, kH, 3);
  uint32_t x = 0x9e3779b9u;
  for (auto& v : r.vec()) {
    x = x * 1664525u + 1013904223u;
    v = 0.01f + (x >> 8) * (1.f / 16777216.f);
  }
  write_exr(path, {{{"R", "G", "B"}, &r, "W.sr-1.m-2"}}, {});
}
void write_good_inputs(const Ctx& c) {
  write_png(c.in("day.png"), day_image());
  write_png(c.in("labels.png"), label_ids());
  write_radiance(c.in("radiance.exr"));
  put(c.in("manifest.txt"), c.in("day.png") + " " + c.in("labels.png") + "\n");
}
std::string base_camera_toml() {
  return slurp(std::string(PHOTOSITE_PRESET_DIR) + "/cameras/sony-imx174.toml");
}
std::string replace_line(std::string text, const std::string& key, const std::string& line) {
  const auto p = text.find("\n" + key + " ");
  const auto e = text.find('\n', p + 1);
  return text.substr(0, p + 1) + line + text.substr(e);
}
std::string replace_first(std::string text, const std::string& from, const std::string& to) {
  const auto p = text.find(from);
  if (p == std::string::npos) ADD_FAILURE() << "no '" << from << "' in the preset";
  else text.replace(p, from.size(), to);
  return text;
}
void write_camera(const Ctx& c, const std::string& text) { put(c.in("cam.toml"), text); }
// A device map of one preset and size, made by a real run, placed where another lookup goes.
void make_map(const Ctx& c, const std::string& preset, int w, int h) {
  auto r = test::run_cli(fmt::format("flat --photons 0 --wavelength-nm 525 --width {} --height {} "
                                     "--preset {} --device-id dev --device-store '{}' --out '{}'",
                                     w, h, preset, c.store(), c.in("mk.exr")));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  fs::remove(c.in("mk.exr"));
}
std::string map_path(const Ctx& c, const std::string& preset, int w, int h) {
  return (fs::path(c.store()) / preset / fmt::format("dev_{}x{}.exr", w, h)).string();
}
void move_map(const Ctx& c, const std::string& from_preset, int fw, int fh, const std::string& to_preset,
              int tw, int th) {
  make_map(c, from_preset, fw, fh);
  fs::create_directories(fs::path(map_path(c, to_preset, tw, th)).parent_path());
  fs::rename(map_path(c, from_preset, fw, fh), map_path(c, to_preset, tw, th));
}
// Runs the command as an unprivileged user when the tests run as root (root ignores permissions).
// That user (65534) cannot read the presets in a checkout under root's 0700 home (nor, there,
// open the build folder), so the binary and the presets are copied into the test's own folder,
// readable by all, and pointed at with PHOTOSITE_PRESET_DIR (sensor/preset.cpp; the Vulkan kernels are
// compiled into the binary). `bin` empty: run the build's binary as the current user.
struct AsUser {
  std::string prefix, bin, skip_reason;
};
AsUser as_user(const Ctx& c) {
  if (geteuid() != 0) return {};
  const fs::path d = c.dir / "as_user";
  fs::create_directories(d);
  fs::copy_file(PHOTOSITE_BIN, d / "photosite");
  fs::copy(preset_dir(), d / "presets", fs::copy_options::recursive);
  const auto readable = fs::perms::owner_all | fs::perms::group_read | fs::perms::group_exec |
                        fs::perms::others_read | fs::perms::others_exec;
  fs::permissions(d, readable);
  fs::permissions(d / "photosite", readable);
  for (const auto& e : fs::recursive_directory_iterator(d / "presets")) fs::permissions(e.path(), readable);
  fs::permissions(c.dir / "out", fs::perms::all);
  const std::string prefix = "setpriv --reuid=65534 --regid=65534 --clear-groups env PHOTOSITE_PRESET_DIR='" +
                             (d / "presets").string() + "' ";
  // The test folder's own ancestors (the temp directory) must let that user through.
  const std::string probe = prefix + "sh -c 'test -x \"" + (d / "photosite").string() + "\" && test -r \"" +
                            (d / "presets" / "cameras" / "sony-imx174.toml").string() + "\"' 2>/dev/null";
  if (std::system(probe.c_str()) != 0)
    return {"", "", "user 65534 cannot reach " + d.string() + " (is the temp directory " +
                        fs::temp_directory_path().string() + " closed to others?)"};
  return {prefix, (d / "photosite").string(), ""};
}

struct Row {
  const char* name;
  std::function<void(Ctx&)> setup;  // after the good inputs are written
  std::string args;                 // {in}/{out}/{store}/{dir} are replaced by the folders
  std::vector<std::string> expect;  // each must appear in the output (file and problem)
  std::string prefix = {};          // shell words before the command (ulimit, setpriv)
};

std::string expand(std::string s, const Ctx& c) {
  for (const auto& [k, v] : {std::pair<std::string, std::string>{"{in}", (c.dir / "in").string()},
                             {"{out}", (c.dir / "out").string()},
                             {"{store}", c.store()},
                             {"{dir}", c.dir.string()}}) {
    for (size_t p; (p = s.find(k)) != std::string::npos;) s.replace(p, k.size(), v);
  }
  return s;
}

const std::string kSensor = "--device-id dev --device-store '{store}' ";
const std::string kExpose = "expose --preset sony-imx174 " + kSensor + "--radiance '{in}/radiance.exr' --out '{out}/o.exr' ";
const std::string kFlat = "flat --preset sony-imx174 " + kSensor + "--photons 100 --wavelength-nm 525 --width 64 --height 32 --out '{out}/o.exr' ";
const std::string kNight = "night " + kSensor + "--image '{in}/day.png' --labels '{in}/labels.png' --out '{out}/o.exr' ";
const std::string kBatch = "batch --quiet " + kSensor + "--out '{out}/b' ";

std::vector<Row> rows() {
  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
  std::vector<Row> t;
  // ---- expose: the radiance file ----------------------------------------------------------
  t.push_back({"expose_missing_radiance", [](Ctx& c) { fs::remove(c.in("radiance.exr")); }, kExpose, {"radiance.exr", "no such file"}});
  t.push_back({"expose_empty_radiance", [](Ctx& c) { put(c.in("radiance.exr"), ""); }, kExpose, {"radiance.exr", "cannot read image"}});
  // The good radiance compresses to a few hundred bytes: cutting it in half cuts its header.
  t.push_back({"expose_truncated_exr", [](Ctx& c) { truncate_to(c.in("radiance.exr"), 0.5); }, kExpose, {"radiance.exr", "truncated EXR header"}});
  t.push_back({"expose_truncated_exr_pixels", [](Ctx& c) { write_textured_radiance(c.in("radiance.exr")); truncate_to(c.in("radiance.exr"), 0.6); }, kExpose, {"radiance.exr", "corrupt or truncated", "a file cut short"}});
  t.push_back({"expose_header_only_exr", [](Ctx& c) { truncate_to(c.in("radiance.exr"), 0.05); }, kExpose, {"radiance.exr"}});
  t.push_back({"expose_corrupt_exr", [](Ctx& c) { corrupt_tail(c.in("radiance.exr"), 0.6); }, kExpose, {"radiance.exr", "corrupt EXR header"}});
  t.push_back({"expose_corrupt_exr_pixels", [](Ctx& c) { write_textured_radiance(c.in("radiance.exr")); corrupt_tail(c.in("radiance.exr"), 0.6); }, kExpose, {"radiance.exr", "corrupt"}});
  t.push_back({"expose_garbage_file", [](Ctx& c) { put(c.in("radiance.exr"), std::string(5000, 'x')); }, kExpose, {"radiance.exr", "cannot read image"}});
  t.push_back({"expose_integer_png_radiance", [](Ctx& c) { fs::copy_file(c.in("day.png"), c.in("r.png")); }, "expose --preset sony-imx174 " + kSensor + "--radiance '{in}/r.png' --out '{out}/o.exr'", {"r.png", "floating-point"}});
  t.push_back({"expose_nan_radiance", [=](Ctx& c) { write_radiance(c.in("radiance.exr"), kW, kH, nan); }, kExpose, {"radiance.exr", "NaN"}});
  t.push_back({"expose_inf_radiance", [=](Ctx& c) { write_radiance(c.in("radiance.exr"), kW, kH, inf); }, kExpose, {"radiance.exr", "inf"}});
  t.push_back({"expose_negative_radiance", [](Ctx& c) { write_radiance(c.in("radiance.exr"), kW, kH, -3.f); }, kExpose, {"radiance.exr", "negative"}});
  t.push_back({"expose_one_pixel", [](Ctx& c) { write_radiance(c.in("radiance.exr"), 1, 1); }, kExpose, {"radiance.exr", "1x1", "too small"}});
  t.push_back({"expose_one_row", [](Ctx& c) { write_radiance(c.in("radiance.exr"), 64, 1); }, kExpose, {"radiance.exr", "64x1", "too small"}});
  t.push_back({"expose_declared_40000_exr", [](Ctx& c) { exr_declare_size(c.in("radiance.exr"), 40000, 40000); }, kExpose, {"radiance.exr", "40000x40000", "refused before allocating"}});
  t.push_back({"expose_exr_attribute_size_2gb", [](Ctx& c) { exr_attribute_size(c.in("radiance.exr"), "channels", "chlist", 2000000000); }, kExpose, {"radiance.exr", "corrupt EXR header", "'channels' declares 2000000000 bytes"}});
  t.push_back({"expose_two_channels", [](Ctx& c) { write_radiance(c.in("radiance.exr"), kW, kH, 1.f, 2); }, kExpose, {"radiance.exr", "must have 1 channel (grey) or R, G, B"}});
  t.push_back({"expose_radiance_is_folder", [](Ctx& c) { fs::remove(c.in("radiance.exr")); fs::create_directory(c.in("radiance.exr")); }, kExpose, {"radiance.exr", "is a folder"}});
  t.push_back({"expose_output_folder_missing", {}, "expose --preset sony-imx174 " + kSensor + "--radiance '{in}/radiance.exr' --out '{out}/nope/o.exr'", {"nope", "does not exist"}});
  t.push_back({"expose_output_exists", [](Ctx& c) { put(c.out("o.exr"), "user data"); }, kExpose, {"o.exr", "already exists"}});
  t.push_back({"expose_preview_folder_missing", {}, kExpose + "--preview '{out}/nope/p.png'", {"nope", "does not exist"}});
  t.push_back({"expose_frames_without_hash", {}, kExpose + "--frames 3", {"o.exr", "'#'"}});
  t.push_back({"expose_negative_exposure", {}, kExpose + "--exposure-s -1", {"exposure"}});
  t.push_back({"expose_bad_device_id", {}, "expose --preset sony-imx174 --device-id ../x --device-store '{store}' --radiance '{in}/radiance.exr' --out '{out}/o.exr'", {"device id", "may contain only"}});
  t.push_back({"expose_output_too_large_for_disk", [](Ctx& c) { make_map(c, "sony-imx174", kW, kH); }, kExpose, {"o.exr", "write failed"}, "ulimit -f 64; "});
  // ---- camera presets --------------------------------------------------------------------
  const std::string kCam = "expose --preset '{in}/cam.toml' " + kSensor + "--radiance '{in}/radiance.exr' --out '{out}/o.exr'";
  t.push_back({"preset_unknown_name", {}, "expose --preset no-such-camera " + kSensor + "--radiance '{in}/radiance.exr' --out '{out}/o.exr'", {"no-such-camera", "unknown camera preset"}});
  t.push_back({"preset_missing_file", {}, kCam, {"cam.toml", "no such preset file"}});
  t.push_back({"preset_unknown_key", [](Ctx& c) { write_camera(c, base_camera_toml() + "\nfull_wel_e = 5\n"); }, kCam, {"cam.toml:", "full_wel_e: unknown key"}});
  t.push_back({"preset_wrong_unit_string", [](Ctx& c) { write_camera(c, replace_line(base_camera_toml(), "read_noise_e", "read_noise_e = \"6 e-\"")); }, kCam, {"cam.toml:", "read_noise_e", "expected a number"}});
  t.push_back({"preset_wrong_unit_key", [](Ctx& c) { write_camera(c, replace_line(base_camera_toml(), "read_noise_e", "read_noise_dn = 6")); }, kCam, {"cam.toml:", "read_noise_dn: unknown key"}});
  t.push_back({"preset_out_of_range", [](Ctx& c) { write_camera(c, replace_line(base_camera_toml(), "prnu_percent", "prnu_percent = -1")); }, kCam, {"cam.toml:", "prnu_percent", "out of range"}});
  // fuzz_preset's UBSan finding: a float too large for int64 where an integer is expected.
  t.push_back({"preset_huge_float_for_integer", [](Ctx& c) { write_camera(c, replace_line(base_camera_toml(), "height_px", "height_px = 15E60")); }, kCam, {"cam.toml:", "height_px", "expected an integer"}});
  t.push_back({"preset_nan_value", [](Ctx& c) { write_camera(c, replace_line(base_camera_toml(), "dsnu_e", "dsnu_e = nan")); }, kCam, {"cam.toml:", "dsnu_e"}});
  t.push_back({"preset_missing_value", [](Ctx& c) { write_camera(c, replace_line(base_camera_toml(), "read_noise_e", "# removed")); }, kCam, {"cam.toml", "read_noise_e: required"}});
  t.push_back({"preset_malformed_toml", [](Ctx& c) { write_camera(c, base_camera_toml() + "\n[[broken"); }, kCam, {"cam.toml:", "malformed TOML"}});
  t.push_back({"preset_binary_garbage", [](Ctx& c) { write_camera(c, std::string("\x89PNG\r\n\x1a\n\0\0\xff", 11)); }, kCam, {"cam.toml"}});
  t.push_back({"preset_unknown_lens", {}, kExpose + "--lens no-such-lens", {"no-such-lens"}});
  t.push_back({"presets_show_unknown", {}, "presets show no-such-preset", {"no-such-preset"}});
  t.push_back({"presets_show_malformed", [](Ctx& c) { write_camera(c, "name = \"x\"\n[[[\n"); }, "presets show '{in}/cam.toml'", {"cam.toml", "malformed TOML"}});
  // ---- the device store -------------------------------------------------------------------
  t.push_back({"map_of_another_preset", [](Ctx& c) { move_map(c, "onsemi-ar0331", kW, kH, "sony-imx174", kW, kH); }, kExpose, {"dev_128x64.exr", "belongs to preset 'onsemi-ar0331'"}});
  t.push_back({"map_of_another_size", [](Ctx& c) { move_map(c, "sony-imx174", 64, 32, "sony-imx174", kW, kH); }, kExpose, {"dev_128x64.exr", "64x32", "128x64"}});
  t.push_back({"map_of_other_parameters", [](Ctx& c) { make_map(c, "sony-imx174", 64, 32); put(c.in("sony-imx174.toml"), replace_line(base_camera_toml(), "prnu_percent", "prnu_percent = 3.5")); }, "flat --preset '{in}/sony-imx174.toml' " + kSensor + "--photons 100 --wavelength-nm 525 --width 64 --height 32 --out '{out}/o.exr'", {"dev_64x32.exr", "other preset parameters"}});
  t.push_back({"map_truncated", [](Ctx& c) { make_map(c, "sony-imx174", 64, 32); truncate_to(map_path(c, "sony-imx174", 64, 32), 0.5); }, kFlat, {"dev_64x32.exr", "corrupt or truncated"}});
  t.push_back({"map_bits_flipped", [](Ctx& c) { make_map(c, "sony-imx174", 64, 32); corrupt_tail(map_path(c, "sony-imx174", 64, 32), 0.7); }, kFlat, {"dev_64x32.exr", "corrupt"}});
  t.push_back({"map_not_photosite", [](Ctx& c) { fs::create_directories(c.store() + "/sony-imx174"); write_radiance(map_path(c, "sony-imx174", 64, 32), 64, 32); }, kFlat, {"dev_64x32.exr", "not a photosite device map"}});
  // fuzz_device_map's out-of-memory input: a map whose header declares a 2 GB attribute.
  t.push_back({"map_attribute_size_2gb", [](Ctx& c) { make_map(c, "sony-imx174", 64, 32); exr_attribute_size(map_path(c, "sony-imx174", 64, 32), "photosite/checksum", "string", 0x7fff0000); }, kFlat, {"dev_64x32.exr", "corrupt EXR header", "'photosite/checksum' declares"}});
  // fuzz_device_map's timeout input: declared sizes that differ from what OpenEXR reads for the
  // type, so its walk through the header leaves this one and reads garbage sizes.
  t.push_back({"map_channel_list_size_wrong", [](Ctx& c) { make_map(c, "sony-imx174", 64, 32); exr_attribute_size(map_path(c, "sony-imx174", 64, 32), "channels", "chlist", 4, true); }, kFlat, {"dev_64x32.exr", "corrupt EXR header", "'channels' of type chlist"}});
  t.push_back({"map_box_size_wrong", [](Ctx& c) { make_map(c, "sony-imx174", 64, 32); exr_attribute_size(map_path(c, "sony-imx174", 64, 32), "dataWindow", "box2i", 17); }, kFlat, {"dev_64x32.exr", "'dataWindow' of type box2i declares 17 bytes, the type has 16"}});
  t.push_back({"map_declared_40000", [](Ctx& c) { make_map(c, "sony-imx174", 64, 32); exr_declare_size(map_path(c, "sony-imx174", 64, 32), 40000, 40000); }, kFlat, {"dev_64x32.exr", "40000x40000"}});
  t.push_back({"store_read_only", [](Ctx& c) { fs::create_directories(c.store()); fs::permissions(c.store(), fs::perms::owner_read | fs::perms::owner_exec | fs::perms::group_read | fs::perms::group_exec | fs::perms::others_read | fs::perms::others_exec); }, kFlat, {"store", "device store", "read-only"}});
  // No store named and no home to put the default in: refused, not a store in the working folder.
  t.push_back({"flat_no_device_store_and_no_home", {}, "flat --preset sony-imx174 --device-id dev --photons 100 --wavelength-nm 525 --width 64 --height 32 --out '{out}/o.exr'", {"--device-store", "no device store folder"}, "env -u PHOTOSITE_DEVICE_STORE -u XDG_DATA_HOME -u HOME "});
  // A pipe as an input (a FIFO here; `<(cat day.png)` in bash) is read twice: refused by name.
  t.push_back({"night_image_is_a_pipe", [](Ctx& c) { ASSERT_EQ(::mkfifo((c.dir / "in" / "pipe.png").c_str(), 0600), 0); }, "night " + kSensor + "--image '{in}/pipe.png' --labels '{in}/labels.png' --out '{out}/o.exr'", {"pipe.png", "not a regular file"}});
  // An output folder the user cannot reach exists: its reason, not "does not exist" (run as an
  // unprivileged user when the tests run as root).
  t.push_back({"flat_output_folder_unreachable", [](Ctx& c) { fs::create_directories(c.dir / "locked" / "sub"); fs::permissions(c.dir / "locked", fs::perms::none); }, "flat --preset sony-imx174 " + kSensor + "--photons 100 --wavelength-nm 525 --width 64 --height 32 --out '{dir}/locked/sub/o.exr'", {"locked/sub", "Permission denied"}});
  // A driver manifest that is not JSON: the loader answers "out of host memory"; the message names the manifest.
  t.push_back({"vulkan_driver_manifest_garbage", [](Ctx& c) { put((c.dir / "garbage_icd.json").string(), "{garbage"); }, kFlat + "--backend vulkan", {"driver manifest", "VK_ICD_FILENAMES=", "garbage_icd.json"}, "env -u VK_DRIVER_FILES VK_ICD_FILENAMES='{dir}/garbage_icd.json' "});
  t.push_back({"store_is_a_file", [](Ctx& c) { put(c.store(), "x"); }, kFlat, {"store", "device store"}});
  t.push_back({"demosaic_missing_input", {}, "demosaic --in '{in}/nope.png' --cfa RGGB --method bilinear --out '{out}/o.exr'", {"nope.png", "no such file"}});
  t.push_back({"demosaic_unknown_cfa", {}, "demosaic --in '{in}/day.png' --cfa XYZW --method bilinear --out '{out}/o.exr'", {"XYZW", "unknown CFA pattern"}});
  t.push_back({"demosaic_unknown_method", {}, "demosaic --in '{in}/day.png' --cfa RGGB --method nope --out '{out}/o.exr'", {"nope", "unknown demosaic method"}});
  // --white-level: clip handling exists for the clear patterns only, and above the black level.
  t.push_back({"demosaic_white_level_on_bayer", [](Ctx& c) { write_png(c.in("m.png"), label_ids()); }, "demosaic --in '{in}/m.png' --cfa RGGB --white-level 200 --out '{out}/o.exr'", {"--white-level", "RCCB and RCCC", "m.png is RGGB"}});
  t.push_back({"demosaic_white_level_at_black", [](Ctx& c) { write_png(c.in("m.png"), label_ids()); }, "demosaic --in '{in}/m.png' --cfa RCCB --white-level 0 --out '{out}/o.exr'", {"--white-level 0", "is not above", "m.png's black level (0)"}});
  // A raw mosaic whose header puts its clip below its black level (an edited or foreign header).
  t.push_back({"demosaic_header_clip_below_black", [](Ctx& c) {
                 ImageF m(8, 8, 1, 200.f, unit::dn);
                 write_exr(c.in("raw.exr"), {{{"raw.Y"}, &m, unit::dn, ExrPixel::Uint}},
                           {{"photosite/cfa", std::string("RCCC")}, {"photosite/black_level_dn", 168.0},
                            {"photosite/clipped_at_dn", 100.0}, {"photosite/clip_neutral_dn", 1300.0}});
               },
               "demosaic --in '{in}/raw.exr' --out '{out}/o.exr'", {"raw.exr", "photosite/clipped_at_dn 100", "black level 168"}});
  t.push_back({"store_full", {}, kFlat, {"dev_64x32.exr", "write failed"}, "ulimit -f 8; "});
  // ---- flat and chart ---------------------------------------------------------------------
  t.push_back({"flat_zero_width", {}, "flat --preset sony-imx174 " + kSensor + "--photons 1 --wavelength-nm 525 --width 0 --height 32 --out '{out}/o.exr'", {"--width", "too small"}});
  t.push_back({"flat_one_pixel", {}, "flat --preset sony-imx174 " + kSensor + "--photons 1 --wavelength-nm 525 --width 1 --height 1 --out '{out}/o.exr'", {"--width", "1x1", "too small"}});
  t.push_back({"flat_40000", {}, "flat --preset sony-imx174 " + kSensor + "--photons 1 --wavelength-nm 525 --width 40000 --height 40000 --out '{out}/o.exr'", {"--width", "40000x40000", "limit"}});
  t.push_back({"flat_negative_photons", {}, "flat --preset sony-imx174 " + kSensor + "--photons -5 --wavelength-nm 525 --width 64 --height 32 --out '{out}/o.exr'", {"photons"}});
  t.push_back({"flat_output_folder_missing", {}, "flat --preset sony-imx174 " + kSensor + "--photons 1 --wavelength-nm 525 --width 64 --height 32 --out '{out}/nope/o.exr'", {"nope", "does not exist"}});
  // A wavelength off the preset's QE table (400-700 nm for sony-imx174): a flat field there would be a dark
  // frame labelled with photons; characterize failed with "too few points in the linear range".
  t.push_back({"flat_wavelength_off_the_qe_table", {}, "flat --preset sony-imx174 " + kSensor + "--photons 100 --wavelength-nm 399 --width 64 --height 32 --out '{out}/o.exr'", {"--wavelength-nm", "399", "outside the QE table of sony-imx174 (400 to 700 nm)"}});
  t.push_back({"characterize_wavelength_off_the_qe_table", {}, "characterize --preset sony-imx174 " + kSensor + "--roi 32 --wavelength-nm 750", {"--wavelength-nm", "750", "QE table"}});
  // An empty --device-store (an unset shell variable) fell back to the home folder's store.
  t.push_back({"flat_empty_device_store", {}, "flat --preset sony-imx174 --device-id dev --device-store '' --photons 100 --wavelength-nm 525 --width 64 --height 32 --out '{out}/o.exr'", {"--device-store", "empty folder name"}});
  // Impossible settings name their option.
  t.push_back({"flat_negative_exposure", {}, kFlat + "--exposure-s -1", {"--exposure-s", "-1", "[0, 3600]"}});
  t.push_back({"flat_temperature_300", {}, kFlat + "--temperature-c 300", {"--temperature-c", "300", "[-100, 200]"}});
  // An output path that is a folder: refused before any work, --overwrite or not.
  t.push_back({"night_output_is_a_folder", [](Ctx& c) { fs::create_directories(c.dir / "out" / "o.exr"); }, kNight + "--overwrite", {"o.exr", "is a folder"}});
  t.push_back({"chart_too_small", {}, "chart --width 10 --height 10 --out '{out}/c.exr'", {"chart size"}});
  t.push_back({"chart_bad_cct", {}, "chart --cct-k 100 --out '{out}/c.exr'", {"CCT"}});
  t.push_back({"chart_output_folder_missing", {}, "chart --out '{out}/nope/c.exr'", {"nope", "does not exist"}});
  // Each option named with its value (before: one message for all five); a radiance beyond float's
  // range was written as Inf (exit 0), which expose then refused.
  t.push_back({"chart_cct_names_flag_and_value", {}, "chart --cct-k 500 --out '{out}/c.exr'", {"--cct-k", "500", "[1000, 25000]"}});
  t.push_back({"chart_width_names_flag_and_value", {}, "chart --width 10 --out '{out}/c.exr'", {"--width", "10"}});
  t.push_back({"chart_lamp_overflows_float", {}, "chart --lamp-cd-m2 1e42 --out '{out}/c.exr'", {"--lamp-cd-m2", "1e+42", "float's range"}});
  t.push_back({"chart_illuminance_overflows_float", {}, "chart --illuminance-lux 1e300 --out '{out}/c.exr'", {"--illuminance-lux", "1e+300", "float's range"}});
  t.push_back({"chart_background_overflows_float", {}, "chart --background-cd-m2 1e42 --out '{out}/c.exr'", {"--background-cd-m2", "1e+42", "float's range"}});
  // ---- an output that is an input: refused even with -y (before: the input was replaced) -----
  t.push_back({"expose_out_is_the_radiance", {}, "expose --preset sony-imx174 " + kSensor + "--radiance '{in}/radiance.exr' --out '{in}/./radiance.exr' -y", {"radiance.exr", "--out is the run's --radiance input"}});
  t.push_back({"demosaic_out_is_the_input", [](Ctx& c) { write_png(c.in("m.png"), label_ids()); }, "demosaic --in '{in}/m.png' --out '{in}/m.png' -y", {"m.png", "--out is the run's --in input"}});
  t.push_back({"night_out_is_the_image", [](Ctx& c) { write_radiance(c.in("day.exr")); }, "night " + kSensor + "--image '{in}/day.exr' --labels '{in}/labels.png' --out '{in}/day.exr' -y", {"day.exr", "--out is the run's --image input"}});
  // ---- flags that cannot act: refused (before: accepted and ignored) --------------------------
  t.push_back({"expose_preview_isp_without_preview", {}, kExpose + "--preview-isp camera", {"--preview-isp camera", "no preview is written"}});
  t.push_back({"expose_jpeg_quality_without_preview", {}, kExpose + "--preview-jpeg-quality 10", {"--preview-jpeg-quality 10", "no preview is written"}});
  t.push_back({"expose_denoise_with_simple_isp", {}, kExpose + "--preview '{out}/p.png' --preview-denoise 3", {"--preview-denoise 3", "acts only with --preview-isp camera"}});
  t.push_back({"night_jpeg_quality_with_simple_isp", {}, kNight + "--preview '{out}/p.png' --preview-isp simple --preview-jpeg-quality 10", {"--preview-jpeg-quality 10", "acts only with --preview-isp camera"}});
  t.push_back({"flat_lens_refused", {}, kFlat + "--lens generic-50mm-f1.4", {"--lens"}});
  t.push_back({"flat_f_number_refused", {}, kFlat + "--f-number 16", {"--f-number"}});
  t.push_back({"characterize_lens_refused", {}, "characterize --preset sony-imx174 " + kSensor + "--roi 32 --lens generic-50mm-f1.4", {"--lens"}});
  // Empty values (an unset shell variable) meant the default device and lens, as --device-store "" once did.
  t.push_back({"expose_empty_device_id", {}, "expose --preset sony-imx174 --device-id '' --device-store '{store}' --radiance '{in}/radiance.exr' --out '{out}/o.exr'", {"--device-id", "empty device id"}});
  t.push_back({"flat_empty_device_id", {}, "flat --preset sony-imx174 --device-id '' --device-store '{store}' --photons 100 --wavelength-nm 525 --width 64 --height 32 --out '{out}/o.exr'", {"--device-id", "empty device id"}});
  t.push_back({"expose_empty_lens", {}, kExpose + "--lens ''", {"--lens", "empty lens name"}});
  // A QE grid that stops short of the radiance basis (400-700 nm): expose took QE = 0 beyond it
  // without a word while flat and characterize refused those wavelengths; now the preset is refused.
  t.push_back({"preset_qe_grid_short_of_the_basis", [](Ctx& c) { write_camera(c, replace_first(base_camera_toml(), "wavelength_nm = [400,", "wavelength_nm = [405,")); }, "expose --preset '{in}/cam.toml' " + kSensor + "--radiance '{in}/radiance.exr' --out '{out}/o.exr'", {"cam.toml", "qe.wavelength_nm", "covers 405 to 700 nm", "400 to 700 nm"}});
  t.push_back({"flat_qe_grid_short_of_the_basis", [](Ctx& c) { write_camera(c, replace_first(base_camera_toml(), ", 700]", ", 695]")); }, "flat --preset '{in}/cam.toml' " + kSensor + "--photons 100 --wavelength-nm 525 --width 64 --height 32 --out '{out}/o.exr'", {"cam.toml", "qe.wavelength_nm", "covers 400 to 695 nm"}});
  // R,G,B that photosite itself labelled as DN (an expose output) are not radiance; the message
  // names the unit and the file's radiance layer (before: exposed as radiance, every pixel saturated).
  t.push_back({"expose_radiance_in_dn", [](Ctx& c) {
    ImageF dn(kW, kH, 3, 100.f), rad(kW, kH, 3, 0.05f);
    write_exr(c.in("e.exr"), {{{"R", "G", "B"}, &dn, "DN above black level"}, {{"night_radiance.R", "night_radiance.G", "night_radiance.B"}, &rad, "W.sr-1.m-2"}}, {});
  }, "expose --preset sony-imx174 " + kSensor + "--radiance '{in}/e.exr' --out '{out}/o.exr'", {"e.exr", "'DN above black level'", "not radiance (W.sr-1.m-2)", "night_radiance.* layer"}});
  t.push_back({"characterize_bad_roi", {}, "characterize --preset sony-imx174 " + kSensor + "--roi 5", {"--roi"}});
  t.push_back({"characterize_bad_preset", [](Ctx& c) { write_camera(c, "[[x"); }, "characterize --preset '{in}/cam.toml' " + kSensor, {"cam.toml", "malformed TOML"}});
  // ---- night: the day image -----------------------------------------------------------------
  t.push_back({"night_missing_image", [](Ctx& c) { fs::remove(c.in("day.png")); }, kNight, {"day.png", "not found"}});
  t.push_back({"night_empty_png", [](Ctx& c) { put(c.in("day.png"), ""); }, kNight, {"day.png", "cannot read image"}});
  t.push_back({"night_truncated_png", [](Ctx& c) { truncate_to(c.in("day.png"), 0.5); }, kNight, {"day.png", "corrupt or truncated"}});
  t.push_back({"night_corrupt_png", [](Ctx& c) { corrupt_tail(c.in("day.png"), 0.3); }, kNight, {"day.png"}});
  t.push_back({"night_png_header_only", [](Ctx& c) { truncate_to(c.in("day.png"), 0.02); }, kNight, {"day.png"}});
  t.push_back({"night_png_declared_40000", [](Ctx& c) { png_declare_size(c.in("day.png"), 40000, 40000); }, kNight, {"day.png", "40000x40000", "refused before allocating"}});
  t.push_back({"night_png_declared_zero", [](Ctx& c) { png_declare_size(c.in("day.png"), 0, 0); }, kNight, {"day.png"}});
  t.push_back({"night_one_pixel_png", [](Ctx& c) { write_png(c.in("day.png"), day_image(1, 1)); write_png(c.in("labels.png"), label_ids(1, 1)); }, kNight, {"day.png", "1x1", "too small"}});
  t.push_back({"night_truncated_tiff", [](Ctx& c) { write_png(c.in("day.tif"), day_image()); truncate_to(c.in("day.tif"), 0.5); }, "night " + kSensor + "--image '{in}/day.tif' --labels '{in}/labels.png' --out '{out}/o.exr'", {"day.tif", "corrupt or truncated"}});
  t.push_back({"night_corrupt_tiff_header", [](Ctx& c) { write_png(c.in("day.tif"), day_image()); std::string b = slurp(c.in("day.tif")); for (size_t i = 4; i < 8; ++i) b[i] = '\xff'; put(c.in("day.tif"), b); }, "night " + kSensor + "--image '{in}/day.tif' --labels '{in}/labels.png' --out '{out}/o.exr'", {"day.tif"}});
  t.push_back({"night_nan_exr_day", [=](Ctx& c) { write_radiance(c.in("day.exr"), kW, kH, nan); }, "night " + kSensor + "--image '{in}/day.exr' --labels '{in}/labels.png' --out '{out}/o.exr'", {"day.exr", "NaN"}});
  t.push_back({"night_inf_exr_day", [=](Ctx& c) { write_radiance(c.in("day.exr"), kW, kH, inf); }, "night " + kSensor + "--image '{in}/day.exr' --labels '{in}/labels.png' --out '{out}/o.exr'", {"day.exr", "inf"}});
  t.push_back({"night_image_is_folder", [](Ctx& c) { fs::remove(c.in("day.png")); fs::create_directory(c.in("day.png")); }, kNight, {"day.png", "folder"}});
  // ---- night: labels and instances ----------------------------------------------------------
  t.push_back({"labels_missing", [](Ctx& c) { fs::remove(c.in("labels.png")); }, kNight, {"labels.png", "not found"}});
  t.push_back({"labels_wrong_size", [](Ctx& c) { write_png(c.in("labels.png"), label_ids(64, 32)); }, kNight, {"labels.png", "64x32", "128x64"}});
  t.push_back({"labels_unknown_id", [](Ctx& c) { write_png(c.in("labels.png"), label_ids(kW, kH, 40)); }, kNight, {"labels.png", "value 40", "(64, 32)"}});
  t.push_back({"labels_unknown_train_id", [](Ctx& c) { ImageF t(kW, kH, 1, 0.f); t[kW + 3] = 19 / 255.f; write_png(c.in("labels.png"), t); }, kNight + "--label-format trainIds", {"labels.png", "value 19"}});
  t.push_back({"labels_unknown_colour", [](Ctx& c) { ImageF p(kW, kH, 3, 0.f); p[0] = 0.5f; write_png(c.in("labels.png"), p); }, kNight, {"labels.png", "not in the Cityscapes palette"}});
  t.push_back({"labels_two_channels", [](Ctx& c) { ImageF p(kW, kH, 2, 0.f); write_png(c.in("labels.png"), p); }, kNight, {"labels.png", "channels"}});
  t.push_back({"labels_truncated", [](Ctx& c) { truncate_to(c.in("labels.png"), 0.4); }, kNight, {"labels.png"}});
  t.push_back({"labels_float_exr", [](Ctx& c) { write_radiance(c.in("labels.exr"), kW, kH); }, "night " + kSensor + "--image '{in}/day.png' --labels '{in}/labels.exr' --out '{out}/o.exr'", {"labels.exr", "floating point"}});
  t.push_back({"labels_bad_format_option", {}, kNight + "--label-format rainbow", {"--label-format", "rainbow"}});
  t.push_back({"instances_wrong_size", [](Ctx& c) { write_png(c.in("inst.png"), ImageF(64, 32, 1, 0.f), 16); }, kNight + "--instances '{in}/inst.png'", {"inst.png", "64x32"}});
  t.push_back({"instances_class_beyond_33", [](Ctx& c) { ImageF i(kW, kH, 1, 0.f); i[5] = 40001 / 65535.f; write_png(c.in("inst.png"), i, 16); }, kNight + "--instances '{in}/inst.png'", {"inst.png", "40001"}});
  t.push_back({"instances_missing", {}, kNight + "--instances '{in}/inst.png'", {"inst.png", "not found"}});
  t.push_back({"scene_preset_unknown_key", [](Ctx& c) { put(c.in("scene.toml"), "name = \"s\"\nmoon_luxx = 1\n"); }, kNight + "--scene-preset '{in}/scene.toml'", {"scene.toml", "moon_luxx"}});
  t.push_back({"scene_preset_malformed", [](Ctx& c) { put(c.in("scene.toml"), "name = \"s\n"); }, kNight + "--scene-preset '{in}/scene.toml'", {"scene.toml", "malformed TOML"}});
  // A rig within the schema's ranges whose rays at this frame's rows point past straight down
  // (f 1 px, c_y 1e5 px above the frame, pitch 30°): ground points behind the camera; the depth map
  // held −∞ and the façade windows converted it to integers (UBSan float-cast-overflow).
  t.push_back({"night_rig_looks_past_straight_down", [](Ctx& c) { put(c.in("rig.toml"), "native_width_px = 2048\nnative_height_px = 1024\nfx_px = 1\ncx_px = -1e5\ncy_px = -1e5\nmount_height_m = 1.22\npitch_deg = 30\n"); }, kNight + "--rig '{in}/rig.toml'", {"rig.toml", "past straight down", "fx_px, cy_px and pitch_deg"}});
  t.push_back({"night_ambient_out_of_range", {}, kNight + "--ambient-lux 50", {"--ambient-lux"}});
  t.push_back({"night_streetlamp_type_unknown", {}, kNight + "--streetlamp-type sodium", {"--streetlamp-type", "'sodium'", "led, hps"}});
  t.push_back({"scene_preset_streetlamp_type_unknown", [](Ctx& c) { put(c.in("scene.toml"), "[lamps]\nstreetlamp_type = \"sodium\"\n"); }, kNight + "--scene-preset '{in}/scene.toml'", {"scene.toml:2: lamps.streetlamp_type", "'sodium'", "led, hps"}});
  t.push_back({"night_maps_folder_missing", {}, kNight + "--maps '{out}/nope'", {"nope", "does not exist"}});
  t.push_back({"night_output_folder_missing", {}, "night " + kSensor + "--image '{in}/day.png' --labels '{in}/labels.png' --out '{out}/nope/o.exr'", {"nope", "does not exist"}});
  // ---- batch --------------------------------------------------------------------------------
  t.push_back({"batch_missing_manifest", {}, kBatch + "--manifest '{in}/none.txt'", {"none.txt"}});
  t.push_back({"batch_manifest_missing_image", [](Ctx& c) { put(c.in("manifest.txt"), c.in("gone.png") + " " + c.in("labels.png") + "\n"); }, kBatch + "--manifest '{in}/manifest.txt'", {"manifest.txt", "gone.png", "not found"}});
  t.push_back({"batch_truncated_image", [](Ctx& c) { truncate_to(c.in("day.png"), 0.5); }, kBatch + "--manifest '{in}/manifest.txt'", {"day.png", "corrupt or truncated", "1 of 1 items failed (none was written"}});
  t.push_back({"batch_wrong_size_labels", [](Ctx& c) { write_png(c.in("labels.png"), label_ids(64, 32)); }, kBatch + "--manifest '{in}/manifest.txt'", {"labels.png", "64x32", "1 of 1 items failed", "batch has no such option"}});
  t.push_back({"batch_manifest_garbage", [](Ctx& c) { put(c.in("manifest.txt"), std::string("\0\1\2 x y z w v\n", 14)); }, kBatch + "--manifest '{in}/manifest.txt'", {"manifest.txt"}});
  t.push_back({"batch_unknown_dataset", {}, kBatch + "--dataset mnist --root '{in}'", {"mnist"}});
  t.push_back({"batch_root_missing", {}, kBatch + "--dataset cityscapes --root '{in}/nope'", {"nope"}});
  t.push_back({"batch_bad_shard", {}, kBatch + "--manifest '{in}/manifest.txt' --shard 3/2", {"3/2"}});
  t.push_back({"batch_bad_jobs", {}, kBatch + "--manifest '{in}/manifest.txt' --jobs 0", {"--jobs"}});
  // ---- EXR compression names (issue 16): checked before any work ----------------------------
  t.push_back({"expose_unknown_compression", {}, kExpose + "--compression zip9", {"--compression", "zip9", "piz"}});
  t.push_back({"night_unknown_compression", {}, kNight + "--compression lzw", {"--compression", "lzw", "piz"}});
  t.push_back({"batch_unknown_compression", {}, kBatch + "--manifest '{in}/manifest.txt' --compression jpeg", {"--compression", "jpeg", "piz"}});
  // ---- one run's outputs: each file once, each with its format's extension -------------------
  // (before: --preview at --out's path replaced the EXR with the PNG, exit 0)
  t.push_back({"night_preview_at_the_out_path", {}, kNight + "--preview '{out}/o.exr'", {"o.exr", "--preview", "also the run's --out"}});
  t.push_back({"expose_preview_at_the_out_path", {}, kExpose + "--preview '{out}/o.exr'", {"o.exr", "--preview", "also the run's --out"}});
  t.push_back({"night_preview_among_the_maps", {}, kNight + "--maps '{out}' --preview '{out}/depth.png'", {"depth.png", "--maps", "--preview"}});
  t.push_back({"night_exr_named_png", {}, "night " + kSensor + "--image '{in}/day.png' --labels '{in}/labels.png' --out '{out}/o.png'", {"o.png", "--out", "must end in .exr"}});
  t.push_back({"expose_preview_named_exr", {}, kExpose + "--preview '{out}/p.exr'", {"p.exr", "--preview", "must end in .png"}});
  t.push_back({"chart_named_png", {}, "chart --out '{out}/c.png'", {"c.png", "--out", "must end in .exr"}});
  // The camera ISP's JPEG round trip beyond JPEG's 65500 px: refused before any file is written
  // (before: exit 1 from libjpeg after the EXR was published).
  t.push_back({"expose_camera_preview_beyond_jpeg", [](Ctx& c) { write_radiance(c.in("radiance.exr"), 65501, 2); }, kExpose + "--preview '{out}/p.png' --preview-isp camera", {"--preview-jpeg-quality", "65500", "65501x2"}});
  // ---- --seed as written (before: -1 read as 2^64 − 1, larger values clamped to it) -----------
  t.push_back({"night_negative_seed", {}, kNight + "--seed -1", {"--seed", "'-1' is not a whole number"}});
  t.push_back({"expose_seed_beyond_64_bits", {}, kExpose + "--seed 18446744073709551616", {"--seed", "18446744073709551616"}});
  // ---- presets -------------------------------------------------------------------------------
  t.push_back({"expose_unknown_lens", {}, kExpose + "--lens nope", {"unknown lens preset 'nope'", "cityscapes-5mm"}});
  t.push_back({"night_preset_folder_missing", {}, kNight, {"PHOTOSITE_PRESET_DIR", "no such folder"}, "PHOTOSITE_PRESET_DIR=/nonexistent/presets "});
  t.push_back({"presets_list_folder_missing", {}, "presets list", {"PHOTOSITE_PRESET_DIR", "no such folder"}, "PHOTOSITE_PRESET_DIR=/nonexistent/presets "});
  // ---- batch ---------------------------------------------------------------------------------
  t.push_back({"batch_png_with_an_exr_layer", {}, kBatch + "--manifest '{in}/manifest.txt' --format png --layers sensor,depth", {"--layers", "batch --format png", "depth"}});
  t.push_back({"batch_png_without_sensor", {}, kBatch + "--manifest '{in}/manifest.txt' --format png --layers labels", {"--layers", "must name sensor"}});
  t.push_back({"batch_image_listed_twice", [](Ctx& c) {
    put(c.in("m2.txt"), c.in("day.png") + " " + c.in("labels.png") + "\n" + c.in("day.png") + " " + c.in("labels.png") + "\n");
  }, kBatch + "--manifest '{in}/m2.txt'", {"m2.txt:2", "image listed twice (also on line 1)"}});
  // (before: "image listed twice: day.jpg" for an image listed once)
  t.push_back({"batch_manifest_is_a_folder", {}, kBatch + "--manifest '{in}'", {"{in}: is a folder, not a manifest file"}});
  t.push_back({"batch_manifest_layers_empty", {}, kBatch + "--manifest '{in}/manifest.txt' --layers ''", {"--layers", "no layer named"}});
  t.push_back({"batch_negative_exposure", {}, kBatch + "--manifest '{in}/manifest.txt' --exposure-s -1", {"--exposure-s", "-1 s is impossible"}});
  t.push_back({"batch_two_images_one_output", [](Ctx& c) {
    fs::copy_file(c.in("day.png"), c.in("day.jpg"));
    put(c.in("m2.txt"), c.in("day.png") + " " + c.in("labels.png") + "\n" + c.in("day.jpg") + " " + c.in("labels.png") + "\n");
  }, kBatch + "--manifest '{in}/m2.txt'", {"m2.txt:2", "day.jpg and", "(line 1) would both write"}});
  // ---- bench: the options every target shares (bench/cmd/bench.cpp), refused while the command
  // line is parsed, before any work or output (bench_cli_test.cpp runs them on every target) ----
  // --repeats 0 crashed bench demosaic (exit 139) after it had rewritten the crops.
  t.push_back({"bench_demosaic_zero_repeats", {}, "bench demosaic --repeats 0 --out-dir '{out}'", {"--repeats", "0 is not allowed", "at least 1"}});
  t.push_back({"bench_night_zero_repeats", {}, "bench night --repeats 0 --out-dir '{out}'", {"--repeats", "at least 1"}});
  t.push_back({"bench_sense_zero_inner", {}, "bench sense --inner 0 --out-dir '{out}'", {"--inner", "at least 1"}});
  t.push_back({"bench_python_zero_frames", {}, "bench python --frames 0 --out-dir '{out}'", {"--frames", "at least 1"}});
  t.push_back({"bench_night_negative_threads", {}, "bench night --threads -1 --out-dir '{out}'", {"--threads", "-1 is not allowed"}});
  t.push_back({"bench_noise_zero_width", {}, "bench noise --width 0 --out-dir '{out}'", {"--width", "at least 2"}});
  t.push_back({"bench_sense_one_pixel_high", {}, "bench sense --height 1 --out-dir '{out}'", {"--height", "at least 2"}});
  t.push_back({"bench_out_dir_missing", {}, "bench exr --repeats 1 --out-dir '{out}/nope'", {"{out}/nope", "--out-dir", "does not exist"}});
  t.push_back({"bench_unknown_target", {}, "bench nosuch --out-dir '{out}'", {"unknown target 'nosuch'", "demosaic", "sense"}});
  return t;
}

// Every file under `root`, temporaries (".name.tmp-...") included; the batch's own resume
// manifest folder is not an output.
std::vector<std::string> files_under(const fs::path& root) {
  std::vector<std::string> f;
  std::error_code ec;
  for (auto it = fs::recursive_directory_iterator(root, ec); it != fs::recursive_directory_iterator();
       it.increment(ec)) {
    if (it->path().filename() == ".photosite-batch") {
      it.disable_recursion_pending();
      continue;
    }
    if (!it->is_directory()) f.push_back(it->path().string());
  }
  return f;
}

void PrintTo(const Row& r, std::ostream* os) { *os << r.name; }

// As test::run_cli, with shell words (a ulimit, setpriv) before the binary.
test::CliResult run_with_prefix(const std::string& prefix, const std::string& args,
                                const std::string& bin = PHOTOSITE_BIN) {
  test::CliResult r;
  const std::string cmd = prefix + "'" + bin + "' " + args + " 2>&1";
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) return r;
  char buf[4096];
  for (size_t n; (n = fread(buf, 1, sizeof buf, p)) > 0;) r.output.append(buf, n);
  const int st = pclose(p);
  r.exit_code = WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
  return r;
}

class BadInput : public ::testing::TestWithParam<Row> {};

TEST_P(BadInput, ExitTwoNamesFileAndProblemLeavesNoOutput) {
  const Row& row = GetParam();
  test::TempDir tmp;
  Ctx c{tmp.path()};
  fs::create_directories(c.dir / "in");
  fs::create_directories(c.dir / "out");
  write_good_inputs(c);
  if (row.setup) row.setup(c);
  std::string prefix = row.prefix, bin = PHOTOSITE_BIN;
  if (std::string(row.name) == "store_read_only" || std::string(row.name) == "flat_output_folder_unreachable") {
    const AsUser u = as_user(c);
    if (!u.skip_reason.empty()) {
      std::fprintf(stderr, "\n*** SKIPPING %s: %s ***\n\n", row.name, u.skip_reason.c_str());
      GTEST_SKIP() << u.skip_reason;
    }
    if (!u.bin.empty()) prefix = u.prefix, bin = u.bin;
  }
  const auto r = prefix.empty() ? test::run_cli(expand(row.args, c)) : run_with_prefix(expand(prefix, c), expand(row.args, c), bin);
  EXPECT_EQ(r.exit_code, 2) << r.output;
  for (const auto& e : row.expect) EXPECT_NE(r.output.find(expand(e, c)), std::string::npos) << "missing '" << e << "' in:\n" << r.output;
  EXPECT_EQ(r.output.find("internal error"), std::string::npos) << r.output;
  for (const auto& f : files_under(c.dir / "out"))
    if (std::string(row.name) != "expose_output_exists") ADD_FAILURE() << "left behind: " << f;
  for (const auto& f : files_under(c.store()))
    EXPECT_EQ(f.find(".tmp-"), std::string::npos) << "temporary left in the store: " << f;
  if (std::string(row.name) == "expose_output_exists") EXPECT_EQ(slurp(c.out("o.exr")), "user data");
  std::error_code ec;
  fs::permissions(c.store(), fs::perms::all, ec);  // so TempDir can remove it
  fs::permissions(c.dir / "locked", fs::perms::all, ec);
}

INSTANTIATE_TEST_SUITE_P(Table, BadInput, ::testing::ValuesIn(rows()),
                         [](const auto& info) { return std::string(info.param.name); });

// The table covers the binary's real command set: every subcommand that `photosite --help` lists
// has rows, except those named here with the reason, and every row starts with a subcommand the
// binary has (a misspelled command would exit 2 for the wrong reason and pass its row).
TEST(BadInput, TableCoversEverySubcommandTheBinaryHas) {
  const auto help = test::run_cli("--help");
  ASSERT_EQ(help.exit_code, 0) << help.output;
  std::vector<std::string> commands;
  std::istringstream in(help.output.substr(help.output.find("Subcommands:")));
  for (std::string line; std::getline(in, line);)
    if (line.rfind("  ", 0) == 0) {
      std::istringstream words(line);
      std::string w;
      words >> w;
      commands.push_back(w);
    }
  ASSERT_GE(commands.size(), 8u) << help.output;
  const std::map<std::string, std::string> exempt = {
      {"version", "reads no input"},
      {"demo", "runs `night` on the bundled sample; night's rows cover its options"}};
  const auto t = rows();
  for (const auto& cmd : commands) {
    size_t n = 0;
    for (const auto& r : t) n += r.args.rfind(cmd + " ", 0) == 0;
    if (exempt.count(cmd)) std::printf("  %-13s exempt: %s\n", cmd.c_str(), exempt.at(cmd).c_str());
    else EXPECT_GE(n, 1u) << "no bad-input row for `" << cmd << "`";
  }
  for (const auto& r : t) {
    const std::string first = r.args.substr(0, r.args.find(' '));
    EXPECT_NE(std::find(commands.begin(), commands.end(), first), commands.end()) << r.name << ": " << first;
  }
}

// A context on tmp whose in/ holds the good inputs, with an empty out/.
Ctx good_inputs_in(const test::TempDir& tmp) {
  Ctx c{tmp.path()};
  fs::create_directories(c.dir / "in");
  fs::create_directories(c.dir / "out");
  write_good_inputs(c);
  return c;
}

// The same commands on the unbroken inputs succeed: each row fails for its own reason.
TEST(BadInput, GoodInputControlsSucceed) {
  test::TempDir tmp;
  const Ctx c = good_inputs_in(tmp);
  write_camera(c, base_camera_toml());
  int n = 0;
  for (std::string args : std::vector<std::string>{
           kExpose, kFlat, kNight, kBatch + "--manifest '{in}/manifest.txt'",
        "expose --preset '{in}/cam.toml' " + kSensor + "--radiance '{in}/radiance.exr' --out '{out}/o.exr'",
        "night " + kSensor + "--image '{in}/day.exr' --labels '{in}/labels.png' --out '{out}/o.exr'",
        "chart --out '{out}/o.exr'"}) {
    if (n == 5) write_radiance(c.in("day.exr"));
    const std::string out = fmt::format("o{}.exr", n++);
    if (const auto p = args.find("o.exr"); p != std::string::npos) args.replace(p, 5, out);
    const auto r = test::run_cli(expand(args, c));
    EXPECT_EQ(r.exit_code, 0) << args << "\n" << r.output;
    if (args.rfind("batch", 0) != 0) EXPECT_TRUE(fs::exists(c.out(out))) << args;
  }
}

// -y replaces an existing output, never the input being read: the input under its own name and
// through a symbolic link is refused, and keeps its bytes (before: replaced by the sensor EXR).
TEST(BadInput, AnOutputThatIsTheInputIsRefusedAndTheInputKept) {
  test::TempDir tmp;
  const Ctx c = good_inputs_in(tmp);
  const std::string before = slurp(c.in("radiance.exr"));
  fs::create_symlink(c.in("radiance.exr"), c.out("link.exr"));
  for (const std::string& out : {c.in("radiance.exr"), c.out("link.exr")}) {
    const auto r = test::run_cli(expand("expose --preset sony-imx174 " + kSensor + "--radiance '{in}/radiance.exr' -y --out '", c) + out + "'");
    EXPECT_EQ(r.exit_code, 2) << out << "\n" << r.output;
    EXPECT_NE(r.output.find("--out is the run's --radiance input"), std::string::npos) << r.output;
    EXPECT_EQ(slurp(c.in("radiance.exr")), before) << out;
  }
}

// A resume manifest that cannot grow (here `ulimit -f`; a full disk or a quota alike) fails the
// items, naming the manifest, exit 2. Before, the run said "wrote 1 items" and exited 0 with its
// outputs unrecorded, and the next run refused them as someone else's. The same command without
// the limit then finishes the folder.
TEST(BadInput, BatchManifestThatCannotGrowFailsTheItems) {
  test::TempDir tmp;
  const Ctx c = good_inputs_in(tmp);
  const std::string args = expand(kBatch + "--manifest '{in}/manifest.txt'", c);
  auto r = test::run_cli(args);
  ASSERT_EQ(r.exit_code, 0) << r.output;  // into out/b: the reference, and the parameter record
  fs::rename(c.out("b"), c.out("ref"));
  const std::string manifest = c.out("b/.photosite-batch/shard-0-of-1.jsonl");
  const std::string ref = slurp(c.out("ref/.photosite-batch/shard-0-of-1.jsonl"));
  const std::string params = ref.substr(0, ref.find('\n') + 1);
  ASSERT_NE(params.find("\"params\""), std::string::npos) << params;
  // Blank lines up to 2 MiB less 50 bytes: under `ulimit -f 2048` (blocks of 512 or 1024 bytes,
  // as the shell counts them) the item's first or second record cannot be written; its frames
  // (tens of kB) can.
  fs::create_directories(fs::path(manifest).parent_path());
  put(manifest, params + std::string((2u << 20) - 50 - params.size(), '\n'));
  r = run_with_prefix("ulimit -f 2048; ", args);
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find(manifest + ": cannot write the batch manifest: File too large"), std::string::npos) << r.output;
  r = test::run_cli(args);
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(slurp(c.out("b/day.exr")), slurp(c.out("ref/day.exr")));
}

// An interrupted run leaves no temporary behind (cli/main.cpp's SIGINT/SIGTERM/SIGHUP handler
// calls io.cpp's remove_partial_outputs, then dies of the signal). `night` on a 2048x1024 frame is
// signalled as soon as its EXR's temporary appears in the output folder (the write takes about a
// second; the folder is polled every millisecond). Before the handler, the temporary stayed for good.
TEST(BadInput, InterruptedNightLeavesNoTemporary) {
  for (const int sig : {SIGINT, SIGTERM}) {
    test::TempDir tmp;
    Ctx c{tmp.path()};
    fs::create_directories(c.dir / "in");
    fs::create_directories(c.dir / "out");
    write_png(c.in("day.png"), day_image(2048, 1024));
    write_png(c.in("labels.png"), label_ids(2048, 1024));
    const std::string out = c.out("o.exr"), store = c.store();
    std::fflush(stdout);  // else the child's copy of the buffer is written again when it closes stdout
    std::fflush(stderr);
    const pid_t pid = fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
      const std::string day = c.in("day.png"), labels = c.in("labels.png");
      std::freopen("/dev/null", "w", stdout);
      execl(PHOTOSITE_BIN, PHOTOSITE_BIN, "night", "--image", day.c_str(), "--labels", labels.c_str(), "--out",
            out.c_str(), "--device-store", store.c_str(), static_cast<char*>(nullptr));
      _exit(127);
    }
    bool seen = false;
    int status = 0;
    for (int ms = 0; ms < 120000 && !seen; ++ms) {
      for (const auto& e : fs::directory_iterator(c.dir / "out"))
        if (e.path().filename().string().find(".tmp-") != std::string::npos) seen = true;
      if (!seen) {
        ASSERT_EQ(waitpid(pid, &status, WNOHANG), 0) << "night ended before its EXR's temporary was seen";
        usleep(1000);
      }
    }
    ASSERT_TRUE(seen) << "no temporary within 120 s";
    kill(pid, sig);
    ASSERT_EQ(waitpid(pid, &status, 0), pid);
    EXPECT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == sig) << "status " << status;
    EXPECT_EQ(files_under(c.dir / "out"), std::vector<std::string>{}) << "signal " << sig;
  }
}

}  // namespace
