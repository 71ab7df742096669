// The thirty-fourth session's sweep of the faces with a demanding user's inputs (docs/cli.md
// "Edge cases (thirty-fourth session)"): each test reproduces one failure the sweep found and
// checks its mend.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <sys/file.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfOutputFile.h>
#include <fmt/format.h>
#include <tiffio.h>

#include "core/raster_codecs.h"
#include "photosite/batch.h"
#include "photosite/environment.h"
#include "photosite/error.h"
#include "photosite/io.h"
#include "photosite/output_set.h"
#include "photosite/sanitizer.h"
#include "photosite/scene/labels.h"
#include "photosite/scene/scene_preset.h"
#include "photosite/sensor/fpn.h"
#include "photosite/sensor/preset.h"
#include "core/io_detail.h"
#include "sensor/fpn_detail.h"
#include "test_util.h"

namespace fs = std::filesystem;
using namespace photosite;
using photosite::test::error_of;
using photosite::test::run_cli;
using photosite::test::TempDir;

namespace {

std::string slurp(const fs::path& p) {
  std::ifstream f(p);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

std::vector<std::string> files_in(const fs::path& dir) {
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(dir)) names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end());
  return names;
}

// The bundled KITTI sample's inputs, quoted for run_cli.
std::string bundled_inputs() {
  const std::string src = std::string(PHOTOSITE_SOURCE_DIR) + "/samples/kitti/";
  return "--image '" + src + "image_2/000000_10.png' --labels '" + src + "semantic/000000_10.png'";
}

// Sets an environment variable for the life of the object (the commands run_cli starts inherit
// it; this process's OpenMP read its own at start-up).
struct ScopedEnv {
  std::string name;
  std::optional<std::string> old;
  ScopedEnv(std::string n, const std::string& value) : name(std::move(n)) {
    if (const char* v = std::getenv(name.c_str())) old = v;
    setenv(name.c_str(), value.c_str(), 1);
  }
  ~ScopedEnv() {
    if (old) setenv(name.c_str(), old->c_str(), 1);
    else unsetenv(name.c_str());
  }
};

// A file-size limit (ulimit -f) for the life of the object, inherited by the commands run_cli
// starts (photosite ignores SIGXFSZ, so a write past it fails with EFBIG).
struct ScopedFileSizeLimit {
  rlimit old{};
  explicit ScopedFileSizeLimit(rlim_t bytes) {
    getrlimit(RLIMIT_FSIZE, &old);
    const rlimit lim{bytes, old.rlim_max};
    setrlimit(RLIMIT_FSIZE, &lim);
  }
  ~ScopedFileSizeLimit() { setrlimit(RLIMIT_FSIZE, &old); }
};

}  // namespace

// reflectance.sign = 0 was in range, and the sign pixels' retroreflection (the day texture over
// ρ, scene/lights.cpp retro_put) became 0/0: night stopped at the sensor's radiance check with
// "radiance at pixel (474, 141) is (-nan, -nan, -nan)", naming neither the preset nor the key.
// Now the preset is refused naming the key and the range; at the new minimum the frame is finite.
TEST(EdgeCases, SignReflectanceZeroIsRefusedNamingTheKey) {
  const std::string urban = slurp(fs::path(PHOTOSITE_PRESET_DIR) / "scenes/night-urban.toml");
  const std::string from = "\nsign = 0.7 ";
  ASSERT_NE(urban.find(from), std::string::npos);
  auto with_sign = [&](const std::string& v) {
    std::string s = urban;
    s.replace(s.find(from), from.size(), "\nsign = " + v + " ");
    return s;
  };
  const std::string e = error_of([&] { scene::parse_scene_preset(with_sign("0"), "s.toml"); });
  EXPECT_NE(e.find("reflectance.sign: value 0 is out of range, outside [0.001, 1]"), std::string::npos) << e;

  TempDir t;
  std::ofstream(t.file("sign.toml")) << with_sign("0.001");
  const auto r = run_cli("night --backend cpu " + bundled_inputs() + " --scene-preset '" + t.file("sign.toml") +
                         "' --layers radiance --compression none --out '" + t.file("o.exr") + "'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const ExrContents c = read_exr(t.file("o.exr"));
  for (const char* ch : {"night_radiance.R", "night_radiance.G", "night_radiance.B"}) {
    const ImageF& p = c.channels.at(ch);
    size_t bad = 0;
    for (size_t i = 0; i < p.size(); ++i) bad += !std::isfinite(p[i]);
    EXPECT_EQ(bad, 0u) << ch;
  }
}

// A PNG write that ran out of room said "write failed (Input/output error)": the writers took
// fclose's errno, and after a short fwrite fclose had nothing left to flush and succeeded. The
// reason is now the failing call's: EFBIG under a file-size limit (ENOSPC on a full disk).
TEST(EdgeCases, PngWriteThatRunsOutOfRoomNamesTheReason) {
  TempDir t;
  ImageU8 img(256, 256, 3);
  for (size_t i = 0; i < img.size(); ++i) img[i] = static_cast<uint8_t>((i * 2654435761u) >> 24);  // little to compress
  int pipe_fd[2];
  ASSERT_EQ(pipe(pipe_fd), 0);
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {  // the limit in a child of its own, so this process's writes keep theirs
    close(pipe_fd[0]);
    signal(SIGXFSZ, SIG_IGN);
    const rlimit lim{4096, RLIM_INFINITY};
    setrlimit(RLIMIT_FSIZE, &lim);
    const std::string m = error_of([&] { write_png8(t.file("p.png"), img); });
    if (write(pipe_fd[1], m.data(), m.size()) < 0) _exit(3);
    _exit(0);
  }
  close(pipe_fd[1]);
  std::string m;
  char buf[512];
  for (ssize_t n; (n = read(pipe_fd[0], buf, sizeof buf)) > 0;) m.append(buf, static_cast<size_t>(n));
  close(pipe_fd[0]);
  int status = 0;
  waitpid(pid, &status, 0);
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
  EXPECT_NE(m.find("p.png: write failed (" + std::string(std::strerror(EFBIG)) + ")"), std::string::npos) << m;
  EXPECT_EQ(m.find(std::strerror(EIO)), std::string::npos) << m;
  EXPECT_TRUE(files_in(t.path()).empty());  // no temporary left
}

// OutputSet: files written while it lives are published by commit(), all together; without
// commit none is, and no temporary stays.
TEST(EdgeCases, OutputSetPublishesAllOrNone) {
  TempDir t;
  const ImageU8 img(8, 4, 3, 7);
  {
    OutputSet set;
    write_png8(t.file("a.png"), img);
    write_png(t.file("b.png"), ImageF(8, 4, 1, 0.5f));
    EXPECT_FALSE(fs::exists(t.file("a.png")));  // held under its temporary name
    EXPECT_EQ(files_in(t.path()).size(), 2u);
  }
  EXPECT_TRUE(files_in(t.path()).empty());
  {
    OutputSet set;
    write_png8(t.file("a.png"), img);
    write_png(t.file("b.png"), ImageF(8, 4, 1, 0.5f));
    set.commit();
  }
  EXPECT_EQ(files_in(t.path()), (std::vector<std::string>{"a.png", "b.png"}));
  write_png8(t.file("c.png"), img);  // no set: published at once
  EXPECT_TRUE(fs::exists(t.file("c.png")));
}

// night --maps --preview with room for the maps but not the EXR (a file-size limit below the
// EXR's 22 MB and above every map's 0.9 MB) exited 2 and left the nine maps published; a full
// disk at the preview left the EXR. A failed run now leaves none of its files.
TEST(EdgeCases, NightThatFailsToWriteLeavesNoneOfItsFiles) {
  TempDir t;
  // The device map first, without the limit (the store publishes at once, as it should).
  const auto warm = run_cli("night --backend cpu " + bundled_inputs() + " --layers labels --out '" + t.file("warm.exr") + "'");
  ASSERT_EQ(warm.exit_code, 0) << warm.output;
  fs::create_directory(t.path() / "out");
  const std::string out = (t.path() / "out").string();
  photosite::test::CliResult r;
  {
    const ScopedFileSizeLimit limit(2 << 20);
    r = run_cli("night --backend cpu " + bundled_inputs() + " --compression none --maps '" + out + "' --preview '" + out +
                "/o.png' --out '" + out + "/o.exr'");
  }
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("o.exr: write failed"), std::string::npos) << r.output;
  EXPECT_TRUE(files_in(out).empty()) << r.output << "\nleft: " << files_in(out).size() << " files";
  // And with room, every file is there.
  const auto ok = run_cli("night --backend cpu " + bundled_inputs() + " --maps '" + out + "' --preview '" + out +
                          "/o.png' --out '" + out + "/o.exr'");
  ASSERT_EQ(ok.exit_code, 0) << ok.output;
  const auto names = files_in(out);
  EXPECT_TRUE(std::count(names.begin(), names.end(), "o.exr") == 1 && std::count(names.begin(), names.end(), "o.png") == 1 &&
              std::count(names.begin(), names.end(), "depth.png") == 1)
      << names.size();
}

// OMP_NUM_THREADS=100000 crashed every command at its first parallel loop (SIGSEGV in libgomp's
// GOMP_parallel: the threads' start records overflow the stack); bench --threads the same. Now
// bad input naming the variable (the option), before any work.
TEST(EdgeCases, HugeOpenmpTeamIsRefusedNotACrash) {
  TempDir t;
  {
    const ScopedEnv omp("OMP_NUM_THREADS", "100000");
    const auto r = run_cli("night --backend cpu " + bundled_inputs() + " --out '" + t.file("n.exr") + "'");
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_NE(r.output.find("OMP_NUM_THREADS: 100000 threads is more than photosite runs a parallel region on (at most 4096"),
              std::string::npos)
        << r.output;
  }
  {
    const ScopedEnv omp("OMP_NUM_THREADS", std::to_string(kMaxOpenmpThreads));
    const auto r = run_cli("chart --width 64 --height 48 --out '" + t.file("c.exr") + "'");
    EXPECT_FALSE(fs::exists(t.file("n.exr")));
    EXPECT_EQ(r.exit_code, 0) << r.output;  // the limit itself runs
  }
  const auto b = run_cli("bench night --threads 100000 --repeats 1 --out-dir '" + t.path().string() + "'");
  EXPECT_EQ(b.exit_code, 2) << b.output;
  EXPECT_NE(b.output.find("--threads"), std::string::npos) << b.output;
}

// A stage with nothing to work on says why in the header, as the vanishing point's fallback does:
// no road (all sky), a road from border to border (all road), an unlit scene (night-rural).
TEST(EdgeCases, NoStreetLampsSaysWhy) {
  TempDir t;
  const int w = 256, h = 128;
  ImageU8 day(w, h, 3, 90);
  write_png8(t.file("day.png"), day);
  auto note_for = [&](uint8_t label, const std::string& extra) {
    write_png8(t.file("lab.png"), ImageU8(w, h, 1, label));
    const auto r = run_cli("night --backend cpu --image '" + t.file("day.png") + "' --labels '" + t.file("lab.png") +
                           "' --layers labels -y --out '" + t.file("o.exr") + "' " + extra);
    EXPECT_EQ(r.exit_code, 0) << r.output;
    const auto a = read_exr_attributes(t.file("o.exr"));
    EXPECT_EQ(a.at("photosite/night/street_lamp_source"), "none");
    const auto n = a.find("photosite/night/street_lamp_note");
    EXPECT_NE(r.output.find("note: no street lamps: "), std::string::npos) << r.output;
    return n == a.end() ? std::string("(no note)") : n->second;
  };
  EXPECT_EQ(note_for(23, ""), "no road at the principal column 20-60 m ahead");  // sky
  EXPECT_EQ(note_for(7, ""), "the road reaches both image borders 20-60 m ahead: no kerb seen");  // road
  // A road with kerbs (sidewalk either side) under the rural preset: the edges are found, and the
  // road is unlit.
  {
    ImageU8 lab(w, h, 1, 8);  // sidewalk
    for (int y = 0; y < h; ++y)
      for (int x = w / 4; x < 3 * w / 4; ++x) lab.at(x, y) = 7;
    write_png8(t.file("kerbs.png"), lab);
    const auto r = run_cli("night --backend cpu --image '" + t.file("day.png") + "' --labels '" + t.file("kerbs.png") +
                           "' --scene-preset night-rural --layers labels -y --out '" + t.file("o.exr") + "'");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_EQ(read_exr_attributes(t.file("o.exr")).at("photosite/night/street_lamp_note"),
              "street.road_luminance_cd_m2 is 0: an unlit road");
    const auto lit = run_cli("night --backend cpu --image '" + t.file("day.png") + "' --labels '" + t.file("kerbs.png") +
                             "' --layers labels -y --out '" + t.file("o.exr") + "'");
    ASSERT_EQ(lit.exit_code, 0) << lit.output;
    const auto a = read_exr_attributes(t.file("o.exr"));
    EXPECT_NE(a.at("photosite/night/street_lamp_source"), "none");
    EXPECT_EQ(a.count("photosite/night/street_lamp_note"), 0u);  // lamps placed: no note
  }
}

// ---- the thirty-fifth session (docs/cli.md "Edge cases (thirty-fifth session)") ----------------

namespace {
void put_bytes(const std::string& path, const std::vector<uint8_t>& bytes) {
  std::ofstream(path, std::ios::binary).write(reinterpret_cast<const char*>(bytes.data()), bytes.size());
}
}  // namespace

// Label files saved as JPEG were refused only when the lossy coding happened to make a value no
// class has ("value 35 ... is not a Cityscapes labelIds value"), and read when it made another
// class's: now any JPEG given as labels or instance ids is refused, saying why.
TEST(EdgeCases, JpegLabelsAreRefusedSayingWhy) {
  TempDir t;
  const int w = 64, h = 32;
  write_png8(t.file("lab.png"), ImageU8(w, h, 1, 7));
  // A uniform car-coloured frame (0, 0, 142): a JPEG whose every pixel may decode to a palette colour.
  std::vector<uint8_t> rgb(3 * w * h);
  for (int i = 0; i < w * h; ++i) rgb[3 * i + 2] = 142;
  put_bytes(t.file("lab.jpg"), codec::encode_jpeg_rgb8(rgb.data(), w, h, 100));
  put_bytes(t.file("lab_jpeg.png"), codec::encode_jpeg_rgb8(rgb.data(), w, h, 100));  // by its bytes, not its name
  for (const char* f : {"lab.jpg", "lab_jpeg.png"}) {
    const std::string e = error_of([&] {
      scene::read_labels(t.file(f), "", w, h, scene::LabelFormat::Auto, scene::ResizeLabels::None);
    });
    EXPECT_NE(e.find(t.file(f) + ": label ids in a JPEG file: JPEG's lossy compression changes them along every "
                                 "class border, and label ids must be exact; give them as a PNG (lossless)"),
              std::string::npos)
        << e;
  }
  const std::string e = error_of([&] {
    scene::read_labels(t.file("lab.png"), t.file("lab.jpg"), w, h, scene::LabelFormat::Auto, scene::ResizeLabels::None);
  });
  EXPECT_NE(e.find(t.file("lab.jpg") + ": instance ids in a JPEG file"), std::string::npos) << e;
  // The same ids as a PNG are read.
  EXPECT_EQ(scene::read_labels(t.file("lab.png"), "", w, h, scene::LabelFormat::Auto, scene::ResizeLabels::None).ids[0], 7);
}

// A linear (EXR) day image's negative samples were clipped to 0 without a word; now the header
// and the console say how many pixels had one and the most negative value, and the frame is the
// one of the image with those samples set to 0. A NaN in G was reported as R's finite value.
TEST(EdgeCases, NegativeLinearDayImageIsClippedWithANote) {
  TempDir t;
  const int w = 128, h = 64;
  ImageU8 lab(w, h, 1, 23);  // sky over road
  for (int y = h / 2; y < h; ++y)
    for (int x = 0; x < w; ++x) lab.at(x, y) = 7;
  write_png8(t.file("lab.png"), lab);
  ImageF day(w, h, 3, 0.2f);
  ImageF clipped = day;
  day.at(5, 3, 1) = -0.25f;
  day.at(6, 3, 0) = -0.01f;
  day.at(6, 3, 2) = -0.02f;  // one pixel, two negative samples
  clipped.at(5, 3, 1) = clipped.at(6, 3, 0) = clipped.at(6, 3, 2) = 0.f;
  auto put = [&](const std::string& name, const ImageF& img) {
    std::vector<ExrChannelGroup> g{{{"R", "G", "B"}, &img, ""}};
    write_exr(t.file(name), g, {}, ExrWriteOptions());
  };
  put("neg.exr", day);
  put("zero.exr", clipped);
  auto night = [&](const std::string& img, const std::string& out) {
    return run_cli("night --backend cpu --image '" + t.file(img) + "' --labels '" + t.file("lab.png") +
                   "' --layers radiance --compression none --out '" + t.file(out) + "'");
  };
  const auto r = night("neg.exr", "neg_out.exr");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const std::string note = "2 of 8192 pixels have negative values, clipped to 0; the most negative -0.25 (G at pixel (5, 3))";
  EXPECT_NE(r.output.find("note: " + t.file("neg.exr") + ": " + note), std::string::npos) << r.output;
  EXPECT_EQ(read_exr_attributes(t.file("neg_out.exr")).at("photosite/night/image_note"), note);
  const auto z = night("zero.exr", "zero_out.exr");
  ASSERT_EQ(z.exit_code, 0) << z.output;
  EXPECT_EQ(read_exr_attributes(t.file("zero_out.exr")).count("photosite/night/image_note"), 0u);  // none: no note
  const ExrContents a = read_exr(t.file("neg_out.exr")), b = read_exr(t.file("zero_out.exr"));
  for (const char* ch : {"night_radiance.R", "night_radiance.G", "night_radiance.B"}) {
    const ImageF &pa = a.channels.at(ch), &pb = b.channels.at(ch);
    EXPECT_EQ(std::memcmp(pa.data(), pb.data(), pa.size() * sizeof(float)), 0) << ch;
  }
  // NaN and Inf stay refused, naming the damaged sample's channel and value.
  day.at(7, 4, 2) = std::nanf("");
  put("nan.exr", day);
  const auto n = night("nan.exr", "nan_out.exr");
  EXPECT_EQ(n.exit_code, 2) << n.output;
  EXPECT_NE(n.output.find(t.file("nan.exr") + ": pixel (7, 4) B is nan: NaN and Inf are not light"), std::string::npos)
      << n.output;
}

// The device store: a damaged map names itself and the remedy (removing it makes the same maps
// again: they follow from the preset and the device id); a store given as a file is named as one;
// device ids too long for a file name, or hidden, are refused before any map is made.
TEST(EdgeCases, DeviceStoreFailuresNameTheRemedy) {
  TempDir t;
  const CameraPreset cam = load_camera_preset("sony-imx174");
  const DeviceStore store(t.file("store"));
  const FixedPatternMaps made = store.load_or_create(cam, "cam1", 32, 16);
  const std::string path = store.path_for(cam, "cam1", 32, 16);
  fs::resize_file(path, fs::file_size(path) / 2);
  const std::string e = error_of([&] { store.load_or_create(cam, "cam1", 32, 16); });
  EXPECT_NE(e.find(path + ": corrupt or truncated EXR"), std::string::npos) << e;
  EXPECT_NE(e.find("; remove the file, and the next run draws device cam1's maps again (they follow from the preset "
                   "and the device id alone)"),
            std::string::npos)
      << e;
  fs::remove(path);
  EXPECT_EQ(store.load_or_create(cam, "cam1", 32, 16).checksum, made.checksum);  // the same maps
  // Another preset's map under this one's name: the same remedy.
  const CameraPreset other = load_camera_preset("onsemi-ar0331");
  (void)store.load_or_create(other, "cam1", 32, 16);
  fs::copy_file(store.path_for(other, "cam1", 32, 16), path, fs::copy_options::overwrite_existing);
  const std::string e2 = error_of([&] { store.load_or_create(cam, "cam1", 32, 16); });
  EXPECT_NE(e2.find("belongs to preset 'onsemi-ar0331', not 'sony-imx174'; remove the file"),
            std::string::npos)
      << e2;

  std::ofstream(t.file("file")) << "x";
  const std::string e3 = error_of([&] { DeviceStore(t.file("file")).load_or_create(cam, "cam1", 32, 16); });
  EXPECT_NE(e3.find(t.file("file") + ": the device store is a file, not a folder"), std::string::npos) << e3;

  const std::string e4 = error_of([&] { store.load_or_create(cam, std::string(129, 'x'), 32, 16); });
  EXPECT_NE(e4.find("device id of 129 characters is longer than 128"), std::string::npos) << e4;
  EXPECT_EQ(error_of([&] { store.load_or_create(cam, std::string(128, 'x'), 32, 16); }), "");  // the longest fits
  const std::string e5 = error_of([&] { store.load_or_create(cam, ".cam", 32, 16); });
  EXPECT_NE(e5.find("device id '.cam' starts with '.'"), std::string::npos) << e5;
}

// batch manifests: a path with spaces could not be given at all (every separator split it); now
// a line with a comma or a tab is split at those alone, and a double-quoted field is taken whole
// ('#' inside included). An image given as the manifest, an unclosed quote and a missing manifest
// are named as such.
TEST(EdgeCases, ManifestFieldsMayHoldSpaces) {
  TempDir t;
  for (const char* f : {"day two.png", "lab two.png", "f#1.png", "lab.png", "inst ü.png"}) std::ofstream(t.file(f)) << "x";
  auto items = [&](const std::string& text) {
    std::ofstream(t.file("m.txt")) << text;
    return batch::read_manifest(t.file("m.txt"));
  };
  for (const std::string& line : {std::string("\"day two.png\" \"lab two.png\"  # a comment\n"),
                                  std::string("day two.png, lab two.png\r\n"), std::string("day two.png\tlab two.png\n")}) {
    const auto v = items(line);
    ASSERT_EQ(v.size(), 1u) << line;
    EXPECT_EQ(fs::path(v[0].image).filename(), "day two.png") << line;
    EXPECT_EQ(fs::path(v[0].labels).filename(), "lab two.png") << line;
  }
  const auto q = items("\"f#1.png\",lab.png,\"inst ü.png\"\n");
  ASSERT_EQ(q.size(), 1u);
  EXPECT_EQ(fs::path(q[0].image).filename(), "f#1.png");
  EXPECT_EQ(fs::path(q[0].instances).filename(), "inst ü.png");
  // As before, spaces separate where there is no comma or tab, and '#' starts a comment.
  const std::string e1 = error_of([&] { items("f#1.png lab.png\n"); });
  EXPECT_NE(e1.find("m.txt:1: expected 'image labels [instances]', found 1 fields (a path with spaces or '#': put it "
                    "in double quotes, or separate the fields with commas or tabs)"),
            std::string::npos)
      << e1;
  const std::string e2 = error_of([&] { items("lab.png lab.png\n\"day two.png lab.png\n"); });
  EXPECT_NE(e2.find("m.txt:2: a double quote opens a field that does not close on its line"), std::string::npos) << e2;
  write_png8(t.file("img.png"), ImageU8(4, 4, 1, 0));
  const std::string e3 = error_of([&] { batch::read_manifest(t.file("img.png")); });
  EXPECT_NE(e3.find("img.png: is an image or other binary file, not a manifest"), std::string::npos) << e3;
  EXPECT_THROW(batch::read_manifest(t.file("none.txt")), MissingFileError);
}

// Bad arguments the thirty-fourth session's sweep did not reach: each exits 2 naming the problem,
// before any work (and a command whose printed output is lost, as on a full disk, fails).
TEST(EdgeCases, BadArgumentsOfTheOtherCommandsAreNamed) {
  TempDir t;
  std::ofstream(t.file("file")) << "x";
  fs::create_directory(t.path() / "dir");
  const std::string file = t.file("file"), dir = t.file("dir");
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"night --backend cpu " + bundled_inputs() + " --layers radiance,radiance --out '" + t.file("o.exr") + "'",
       "--layers radiance,radiance: the layer 'radiance' is named twice"},
      {"night --backend cpu " + bundled_inputs() + " --scene-preset '" + dir + "' --out '" + t.file("o.exr") + "'",
       dir + ": is a folder, not a scene preset file"},
      {"presets show '" + dir + "'", dir + ": is a folder, not a preset file"},
      {"bench night --labels '" + file + "' --repeats 1 --out-dir '" + dir + "'",
       "bench night: give --image with --labels"},
      {"bench sense --out-dir '" + file + "'", file + ": --out-dir: is a file, not a folder"},
      {"bench depth --kitti '" + dir + "' --max-frames -1", "--max-frames: -1 is not allowed"},
      {"batch --manifest '" + file + "' --out '" + file + "'", "found 1 fields"},
  };
  for (const auto& [args, message] : cases) {
    const auto r = run_cli(args);
    EXPECT_EQ(r.exit_code, 2) << args << "\n" << r.output;
    EXPECT_NE(r.output.find(message), std::string::npos) << args << "\n" << r.output;
  }
  EXPECT_FALSE(fs::exists(t.file("o.exr")));
  // --out a file (the manifest itself): named as a file, not as a folder that could not be made.
  write_png8(t.file("day.png"), ImageU8(8, 8, 3, 90));
  write_png8(t.file("lab.png"), ImageU8(8, 8, 1, 7));
  std::ofstream(t.file("m.txt")) << "day.png lab.png\n";
  const auto b = run_cli("batch --backend cpu --manifest '" + t.file("m.txt") + "' --out '" + t.file("m.txt") + "'");
  EXPECT_EQ(b.exit_code, 2) << b.output;
  EXPECT_NE(b.output.find(t.file("m.txt") + ": is a file, not an output folder"), std::string::npos) << b.output;
  // Standard output on a full device: the text is lost, so the command fails (it exited 0).
  const auto full = run_cli("presets doc 2>'" + t.file("err") + "' >/dev/full; exit $?");
  EXPECT_EQ(full.exit_code, 2);
  EXPECT_NE(slurp(t.file("err")).find("photosite: error: writing the standard output failed ("),
            std::string::npos)
      << slurp(t.file("err"));
  EXPECT_EQ(run_cli("presets doc >/dev/null").exit_code, 0);
}

// ---- the thirty-sixth session (docs/cli.md "Edge cases (thirty-sixth session)") ----------------

// characterize's exposure: Python's `exposure_s=` was accepted and ignored, and the command had no
// --exposure-s; the sweep ran at 1 ms whatever was asked. Now it is the photon-transfer sweep's
// exposure time on both faces, recorded in the result, and the figures follow it: at 0.5 s and
// 80 C the dark charge's shot noise (D·t, e⁻², with D the dark current at 80 C) is part of the
// temporal dark noise the preset column expects, √(σ_read² + row² + column² + D·t), and the
// measurement agrees with it. The default stays 1 ms, and so do its figures.
TEST(EdgeCases, CharacterizeMeasuresAtTheExposureGiven) {
  const std::string base = "characterize --backend cpu --preset sony-imx174 --roi 16 --json --temperature-c 80";
  auto json_of = [](const std::string& args) {
    const auto r = run_cli(args);
    EXPECT_EQ(r.exit_code, 0) << args << "\n" << r.output;
    return r.exit_code == 0 ? nlohmann::json::parse(r.output.substr(r.output.find('{'))) : nlohmann::json();
  };
  const auto d = json_of(base), l = json_of(base + " --exposure-s 0.5");
  ASSERT_TRUE(d.is_object() && l.is_object());
  EXPECT_EQ(d["conditions"]["exposure_s"].get<double>(), 1e-3);
  EXPECT_EQ(l["conditions"]["exposure_s"].get<double>(), 0.5);
  const double sd_short = d["read_noise_e"]["preset"].get<double>(), sd_long = l["read_noise_e"]["preset"].get<double>();
  const double dark = l["dark_current_e_per_s"]["preset"].get<double>();
  // √(s² + D·t): the two preset values differ by the dark shot noise of the extra 0.499 s.
  EXPECT_NEAR(sd_long * sd_long - sd_short * sd_short, dark * (0.5 - 1e-3), 1e-9 * sd_long * sd_long) << dark;
  EXPECT_GT(dark * 0.5, 1.0);  // a visible effect: more than 1 e⁻² of variance
  // The measured temporal dark noise follows: within 5 combined standard errors of the longer
  // exposure's expectation (|z| < 5), and above the short one's by more than its own error.
  EXPECT_LT(std::abs(l["read_noise_e"]["z"].get<double>()), 5.0) << l["read_noise_e"].dump();
  EXPECT_GT(l["read_noise_e"]["measured"].get<double>(),
            d["read_noise_e"]["measured"].get<double>() + l["read_noise_e"]["uncertainty"].get<double>());
  const auto bad = run_cli(base + " --exposure-s -1");
  EXPECT_EQ(bad.exit_code, 2) << bad.output;
  EXPECT_NE(bad.output.find("--exposure-s -1 s is impossible"), std::string::npos) << bad.output;
  // An hour at 80 C: the dark charge alone fills the well (the sweep ended in "EMVA 1288: too few
  // points in the linear range to fit"); refused naming the exposure and the charge.
  const auto full = run_cli(base + " --exposure-s 3600");
  EXPECT_EQ(full.exit_code, 2) << full.output;
  EXPECT_NE(full.output.find("--exposure-s 3600 s: the dark charge alone"), std::string::npos) << full.output;
}

// A relative device store (--device-store maps, PHOTOSITE_DEVICE_STORE=maps, Python's
// device_store="maps") was taken against the working folder at each use: a program that changed
// its working folder between two frames drew the device's maps again in a second store. Now it is
// made absolute once, when the store is made.
TEST(EdgeCases, RelativeDeviceStoreIsTakenOnce) {
  TempDir t;
  fs::create_directories(t.path() / "a");
  fs::create_directories(t.path() / "b");
  const fs::path was = fs::current_path();
  struct Back {
    fs::path to;
    ~Back() { fs::current_path(to); }
  } back{was};
  fs::current_path(t.path() / "a");
  const DeviceStore store("maps/");
  EXPECT_EQ(store.dir(), (fs::canonical(t.path() / "a") / "maps").string());
  fs::current_path(t.path() / "b");
  const CameraPreset cam = load_camera_preset("sony-imx174");
  (void)store.load_or_create(cam, "cam1", 32, 16);
  EXPECT_TRUE(fs::exists(t.path() / "a/maps/sony-imx174/cam1_32x16.exr"));
  EXPECT_FALSE(fs::exists(t.path() / "b/maps"));
}

// Four threads, each with a store of its own in `store`, making one map (cam1, 64x32) at once; then
// what every way of publishing must leave: each thread the generated map, one file (no
// temporary), and a map a later store reads back.
std::vector<FixedPatternMaps> four_creators_of_one_map(const std::string& store, const CameraPreset& cam) {
  std::vector<FixedPatternMaps> maps(4);
  std::vector<std::thread> threads;
  for (int i = 0; i < 4; ++i)
    threads.emplace_back([&, i] { maps[i] = DeviceStore(store).load_or_create(cam, "cam1", 64, 32); });
  for (auto& th : threads) th.join();
  return maps;
}
void expect_one_map(const std::string& store, const CameraPreset& cam, const std::vector<FixedPatternMaps>& maps) {
  const FixedPatternMaps reference = generate_fixed_pattern(cam, 64, 32, "cam1");
  for (const auto& m : maps) EXPECT_EQ(m.checksum_xxh3, reference.checksum_xxh3);
  const auto names = files_in(fs::path(store) / "sony-imx174");
  EXPECT_EQ(names, std::vector<std::string>{"cam1_64x32.exr"}) << names.size() << " files";  // no temporary left
  EXPECT_EQ(DeviceStore(store).load_or_create(cam, "cam1", 64, 32).checksum_xxh3, reference.checksum_xxh3);
}

// The device store's lock where the file system has none: flock answering ENOLCK (an NFS mount
// without a lock daemon), EOPNOTSUPP or ENOSYS. The map is made without the lock, with a note,
// and the publish decides: it links the finished map in without replacing (atomic with no lock),
// so of several processes making one map at once the first to link wins and the others load its
// map. Here four threads each with a store of their own race on one map; the lock function fails
// only once all four have reached it, so every one of them draws and tries to publish.
TEST(EdgeCases, DeviceStoreWithoutFileLocksPublishesOneMap) {
  const CameraPreset cam = load_camera_preset("sony-imx174");
  static std::atomic<int> arrived{0};
  static std::atomic<int> lock_errno{0};
  struct Restore {
    ~Restore() { detail::device_store_flock.store(&::flock); }
  } restore;
  detail::device_store_flock.store([](int, int) {
    ++arrived;
    while (arrived.load() < 4) std::this_thread::yield();
    errno = lock_errno.load();
    return -1;
  });
  for (const int e : {ENOLCK, EOPNOTSUPP, ENOSYS}) {
    TempDir t;
    arrived = 0;
    lock_errno = e;
    testing::internal::CaptureStderr();
    const std::vector<FixedPatternMaps> maps = four_creators_of_one_map(t.file("store"), cam);
    const std::string err = testing::internal::GetCapturedStderr();
    EXPECT_NE(err.find(std::string("no lock on the device store's folder (flock: ") + std::strerror(e) + ")"),
              std::string::npos)
        << err;
    expect_one_map(t.file("store"), cam, maps);
  }
}

// Outputs that would replace user data. `--out` at the device store's map (an input of every run
// of that device) replaced it with -y, and the device's next run failed on "not a photosite
// device map"; `night --maps DIR -y` replaced a user's day.png or labels.png in DIR (its pictures
// have plain names). Now no output goes into the device store, and with -y a --maps picture
// replaces only the run's own earlier one (listed in DIR/.photosite-maps with its bytes).
TEST(EdgeCases, OutputsNeverReplaceTheDeviceMapsOrAUsersFile) {
  TempDir t;
  const std::string store = t.file("store");
  ASSERT_EQ(run_cli("chart --width 64 --height 48 --out '" + t.file("rad.exr") + "'").exit_code, 0);
  const std::string expose = "expose --backend cpu --preset sony-imx174 --device-store '" + store + "' --radiance '" +
                             t.file("rad.exr") + "' --out ";
  ASSERT_EQ(run_cli(expose + "'" + t.file("o.exr") + "'").exit_code, 0);
  const std::string map = store + "/sony-imx174/sony-imx174-0_64x48.exr";
  const std::string before = slurp(map);
  const auto r = run_cli(expose + "'" + map + "' -y");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("--out is inside the device store " + store + ", the folder of the devices' fixed-pattern maps"),
            std::string::npos)
      << r.output;
  EXPECT_EQ(slurp(map), before);
  EXPECT_EQ(run_cli(expose + "'" + t.file("o.exr") + "' -y").exit_code, 0);  // the map still serves
  // batch replaces no file it did not write, but its outputs would lie among the maps.
  const std::string sample = std::string(PHOTOSITE_SOURCE_DIR) + "/samples/kitti/";
  std::ofstream(t.file("m.txt")) << sample << "image_2/000000_10.png " << sample << "semantic/000000_10.png\n";
  const auto b = run_cli("batch --backend cpu --quiet --manifest '" + t.file("m.txt") + "' --device-store '" + store +
                         "' --out '" + store + "/out'");
  EXPECT_EQ(b.exit_code, 2) << b.output;
  EXPECT_NE(b.output.find("--out is inside the device store " + store), std::string::npos) << b.output;
  EXPECT_FALSE(fs::exists(store + "/out"));

  const std::string night = "night --backend cpu " + bundled_inputs() + " --layers labels --maps '" + t.file("m") + "' --out '";
  fs::create_directory(t.path() / "m");
  std::ofstream(t.file("m/day.png")) << "a user's file";
  const auto u = run_cli(night + t.file("n.exr") + "' -y");
  EXPECT_EQ(u.exit_code, 2) << u.output;
  EXPECT_NE(u.output.find(t.file("m/day.png") + ": exists and is not a --maps picture of an earlier run (.photosite-maps does "
                          "not list it); photosite never replaces a user's file, even with -y"),
            std::string::npos)
      << u.output;
  EXPECT_EQ(slurp(t.file("m/day.png")), "a user's file");
  EXPECT_FALSE(fs::exists(t.file("n.exr")));
  // Its own pictures: written, then replaced with -y; a picture edited since is the user's.
  fs::remove(t.file("m/day.png"));
  ASSERT_EQ(run_cli(night + t.file("n.exr") + "'").exit_code, 0);
  const auto again = run_cli(night + t.file("n2.exr") + "' -y");
  EXPECT_EQ(again.exit_code, 0) << again.output;
  std::ofstream(t.file("m/labels.png"), std::ios::app) << "edited";
  const auto edited = run_cli(night + t.file("n3.exr") + "' -y");
  EXPECT_EQ(edited.exit_code, 2) << edited.output;
  EXPECT_NE(edited.output.find("labels.png: exists and is not a --maps picture of an earlier run (.photosite-maps lists other bytes)"),
            std::string::npos)
      << edited.output;
}

// --frames' '#' run: a '#' in the folder part was taken as the run (d#/f.exr wrote d0/f.exr,
// d1/f.exr; a folder take#2/ became take02/, and in d#/f#.exr the file kept a literal '#'). Now
// the run is the file name's: a folder's '#' is part of its name, and a name with two runs is bad
// input. Two frames that are one file (d#/../f.exr, before) are named with both paths.
TEST(EdgeCases, FrameNumbersGoIntoTheFileName) {
  TempDir t;
  fs::create_directory(t.path() / "take#2");
  const std::string flat = "flat --backend cpu --preset sony-imx174 --width 32 --height 16 --photons 100 --wavelength-nm 525 "
                           "--device-store '" + t.file("store") + "' --frames 2 --out '";
  const auto ok = run_cli(flat + t.file("take#2/f#.exr") + "'");
  EXPECT_EQ(ok.exit_code, 0) << ok.output;
  EXPECT_EQ(files_in(t.path() / "take#2"), (std::vector<std::string>{"f0.exr", "f1.exr"}));
  const auto folder = run_cli(flat + t.file("d#/f.exr") + "'");
  EXPECT_EQ(folder.exit_code, 2) << folder.output;
  EXPECT_NE(folder.output.find("needs a run of '#' in the output file's name for the frame number (a '#' in a folder's name is part of the name"),
            std::string::npos)
      << folder.output;
  const auto two = run_cli(flat + t.file("f#_#.exr") + "'");
  EXPECT_EQ(two.exit_code, 2) << two.output;
  EXPECT_NE(two.output.find("the output file's name holds two runs of '#'"), std::string::npos) << two.output;
  EXPECT_EQ(files_in(t.path()), (std::vector<std::string>{"store", "take#2"}));
}

// The thirty-sixth session's sweep of chart, demosaic, flat and characterize: what it mended.
TEST(EdgeCases, BadNumbersOfTheSweepCommandsAreNamed) {
  TempDir t;
  write_png8(t.file("m.png"), ImageU8(8, 8, 1, 90));
  const std::vector<std::pair<std::string, std::string>> cases = {
      // flat named no option ("photons per pixel nan is impossible").
      {"flat --backend cpu --preset sony-imx174 --width 32 --height 16 --frames 1 --wavelength-nm 525 --photons nan --out '" +
           t.file("f.exr") + "'",
       "--photons nan photons per pixel is impossible"},
      // --white-level inf "is not above m.png's black level (0)".
      {"demosaic --backend cpu --in '" + t.file("m.png") + "' --cfa RCCB --white-level inf --out '" + t.file("d.png") + "'",
       "--white-level inf is not a finite number"},
      // --list with a mosaic and an output ran the list and left them alone (exit 0).
      {"demosaic --list --in '" + t.file("m.png") + "' --out '" + t.file("d.png") + "'", "--in excludes --list"},
      // chart: "--illuminance-lux nan lux must be >= 0".
      {"chart --illuminance-lux nan --out '" + t.file("c.exr") + "'", "--illuminance-lux nan lux must be a number >= 0"},
  };
  for (const auto& [args, message] : cases) {
    const auto r = run_cli(args);
    EXPECT_EQ(r.exit_code, 2) << args << "\n" << r.output;
    EXPECT_NE(r.output.find(message), std::string::npos) << args << "\n" << r.output;
  }
  EXPECT_EQ(files_in(t.path()), std::vector<std::string>{"m.png"});
}

// ---- the thirty-seventh session (docs/cli.md "Edge cases (thirty-seventh session)") ----------------

namespace {
// Puts back the real publishing and locking calls when a test ends.
struct RestorePublish {
  ~RestorePublish() {
    detail::publish_linkat.store(&::linkat);
    detail::publish_renameat2.store(&::renameat2);
    detail::device_store_flock.store(&::flock);
  }
};
}  // namespace

// A device store on a file system without hard links (FAT/exFAT: link() answers EPERM; some FUSE
// and network file systems EOPNOTSUPP, ENOSYS or EXDEV) could make no map, so a camera could not
// run there. Now the finished map is published with renameat2(RENAME_NOREPLACE), atomic and never
// replacing as the link was. Four threads race on one map with no file lock (as
// DeviceStoreWithoutFileLocksPublishesOneMap), and every one that reaches the publish fails its
// link once all have (or after 2 s): exactly one rename wins, every other one is refused with
// EEXIST, and all four use the one map.
TEST(EdgeCases, DeviceStoreWithoutHardLinksPublishesOneMap) {
  const CameraPreset cam = load_camera_preset("sony-imx174");
  static std::atomic<int> locks{0}, links{0}, renamed{0}, refused{0};
  static std::atomic<int> link_errno{0};
  RestorePublish restore;
  detail::device_store_flock.store([](int, int) {
    ++locks;
    while (locks.load() < 4) std::this_thread::yield();
    errno = ENOLCK;
    return -1;
  });
  detail::publish_linkat.store([](int, const char*, int, const char*, int) {
    ++links;
    const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(2);
    while (links.load() < 4 && std::chrono::steady_clock::now() < until) std::this_thread::yield();
    errno = link_errno.load();
    return -1;
  });
  detail::publish_renameat2.store([](int a, const char* from, int b, const char* to, unsigned flags) {
    const int r = ::renameat2(a, from, b, to, flags);
    if (r == 0) ++renamed;
    else if (errno == EEXIST) ++refused;
    return r;
  });
  std::string all_err;
  for (const int e : {EPERM, EOPNOTSUPP, ENOSYS, EXDEV}) {
    TempDir t;
    locks = links = renamed = refused = 0;
    link_errno = e;
    testing::internal::CaptureStderr();
    const std::vector<FixedPatternMaps> maps = four_creators_of_one_map(t.file("store"), cam);
    all_err += testing::internal::GetCapturedStderr();
    EXPECT_EQ(renamed.load(), 1) << strerror(e);
    EXPECT_EQ(refused.load(), links.load() - 1) << strerror(e);
    expect_one_map(t.file("store"), cam, maps);
  }
  // The note, said once per process (this test is its first publish without a link).
  EXPECT_NE(all_err.find("the file system makes no hard links (link: Operation not permitted); publishing new files "
                         "with a no-replace rename instead"),
            std::string::npos)
      << all_err;
}

// Where the file system has no no-replace rename either (renameat2 answers EINVAL: NFS, CIFS,
// libfuse 2 file systems such as fusefat), the map's name is created exclusively and the finished
// map copied in. Four threads race on one map with the store's real lock, which serialises them:
// one creates, the others wait and read it. An existing file is never replaced, by either way:
// atomic_create returns false and leaves a user's bytes and no temporary.
TEST(EdgeCases, DeviceStoreWithoutNoReplaceRenameCreatesExclusively) {
  const CameraPreset cam = load_camera_preset("sony-imx174");
  RestorePublish restore;
  detail::publish_linkat.store([](int, const char*, int, const char*, int) {
    errno = EPERM;
    return -1;
  });
  detail::publish_renameat2.store([](int, const char*, int, const char*, unsigned) {
    errno = EINVAL;
    return -1;
  });
  TempDir t;
  testing::internal::CaptureStderr();
  const std::vector<FixedPatternMaps> maps = four_creators_of_one_map(t.file("store"), cam);
  const std::string err = testing::internal::GetCapturedStderr();
  EXPECT_NE(err.find("the file system makes no hard links (link: Operation not permitted) and has no no-replace rename "
                     "(renameat2: Invalid argument); new files are created exclusively and filled in place"),
            std::string::npos)
      << err;
  expect_one_map(t.file("store"), cam, maps);

  for (const bool rename_works : {false, true}) {
    if (rename_works) detail::publish_renameat2.store(&::renameat2);
    std::ofstream(t.file("user.txt")) << "a user's file";
    bool wrote = false;
    EXPECT_FALSE(atomic_create(t.file("user.txt"), [&](const std::string& tmp) {
      std::ofstream(tmp) << "photosite's bytes";
      wrote = true;
    }));
    EXPECT_TRUE(wrote);
    EXPECT_EQ(slurp(t.file("user.txt")), "a user's file");
    EXPECT_EQ(files_in(t.path()), (std::vector<std::string>{"store", "user.txt"}));
    EXPECT_TRUE(atomic_create(t.file("new.txt"), [&](const std::string& tmp) { std::ofstream(tmp) << "new"; }));
    EXPECT_EQ(slurp(t.file("new.txt")), "new");
    fs::remove(t.file("new.txt"));
  }
}

// A reader that meets a map being filled in place (the way above) finds it short: it is then read
// once more under the folder's lock, which its creator holds while it writes. Here the test holds
// the lock with a map cut short on file, lets the reader fail its first read and reach the lock,
// then puts the whole map in place and unlocks: the reader gets the map, not an error.
TEST(EdgeCases, DeviceStoreReaderWaitsForAMapFilledInPlace) {
  const CameraPreset cam = load_camera_preset("sony-imx174");
  TempDir t;
  const DeviceStore made(t.file("made"));
  (void)made.load_or_create(cam, "cam1", 64, 32);
  const std::string whole = slurp(made.path_for(cam, "cam1", 64, 32));
  const DeviceStore store(t.file("store"));
  const std::string path = store.path_for(cam, "cam1", 64, 32);
  fs::create_directories(fs::path(path).parent_path());
  std::ofstream(path, std::ios::binary) << whole.substr(0, whole.size() / 2);
  const int dir = ::open(fs::path(path).parent_path().c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  ASSERT_GE(dir, 0);
  ASSERT_EQ(::flock(dir, LOCK_EX), 0);
  static std::atomic<bool> reached{false};
  RestorePublish restore;
  detail::device_store_flock.store([](int fd, int op) {
    if (op & LOCK_EX) reached = true;
    return ::flock(fd, op);
  });
  FixedPatternMaps got;
  std::string error;
  testing::internal::CaptureStderr();
  std::atomic<bool> returned{false};  // a reader that never waits for the lock returns at once
  std::thread reader([&] {
    error = error_of([&] { got = store.load_or_create(cam, "cam1", 64, 32); });
    returned = true;
  });
  while (!reached.load() && !returned.load()) std::this_thread::yield();
  {
    std::ofstream f(path, std::ios::binary | std::ios::trunc);
    f << whole;
  }
  ::flock(dir, LOCK_UN);
  ::close(dir);
  reader.join();
  const std::string err = testing::internal::GetCapturedStderr();
  EXPECT_EQ(error, "");
  EXPECT_EQ(got.checksum_xxh3, generate_fixed_pattern(cam, 64, 32, "cam1").checksum_xxh3);
  EXPECT_NE(err.find("waiting for another process creating a fixed-pattern map in"), std::string::npos) << err;
}

// demosaic of a float mosaic holding NaN or Inf: the method's interpolation spread the bad sample
// over its neighbours' colours (a NaN became a patch of NaN, written to a PNG as black), exit 0.
// Now refused, naming the file, the channel and the first bad sample, with no output. Negative
// samples (a mosaic with its black level subtracted) are demosaiced as they are.
TEST(EdgeCases, DemosaicRefusesNanAndInfKeepsNegatives) {
  TempDir t;
  const int w = 16, h = 8;
  auto put = [&](const std::string& name, const ImageF& img) {
    write_exr(t.file(name), {{{"raw.Y"}, &img, ""}}, {}, ExrWriteOptions());
  };
  const std::vector<std::pair<float, std::string>> bad = {
      {std::nanf(""), "nan"}, {INFINITY, "inf"}, {-INFINITY, "-inf"}};
  for (const auto& [v, text] : bad) {
    ImageF m(w, h, 1, 0.5f);
    m.at(5, 3) = v;
    m.at(9, 6) = v;  // the first in reading order is named
    put("bad.exr", m);
    for (const char* out : {"d.exr", "d.png"}) {
      const auto r = run_cli("demosaic --backend cpu --in '" + t.file("bad.exr") + "' --out '" + t.file(out) + "'");
      EXPECT_EQ(r.exit_code, 2) << text << "\n" << r.output;
      EXPECT_NE(r.output.find(t.file("bad.exr") + ": the mosaic's sample at pixel (5, 3) of channel raw.Y is " + text +
                              ": a CFA sample must be a finite number"),
                std::string::npos)
          << r.output;
      EXPECT_FALSE(fs::exists(t.file(out)));
    }
  }
  // Negative samples: a uniform mosaic of -0.25 demosaics (bilinear) to -0.25 in every channel.
  put("neg.exr", ImageF(w, h, 1, -0.25f));
  const auto r = run_cli("demosaic --backend cpu --in '" + t.file("neg.exr") + "' --out '" + t.file("n.exr") + "'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const ExrContents c = read_exr(t.file("n.exr"));
  for (const char* ch : {"R", "G", "B"})
    for (const float s : c.channels.at(ch).vec()) ASSERT_EQ(s, -0.25f) << ch;
}

// bench markings with a user's odd frame: labels of another size were refused with the advice
// "pass --resize-labels=nearest", an option bench markings did not have; a frame without road said
// only "no dashed line"; a rig for another camera's frame size was used without the note `night`
// gives; and one frame of the user's wrote over docs/bench_markings.csv, the shared frames'
// recorded results. Now --resize-labels is there, each case says what it is, and --image needs
// --out-dir.
TEST(EdgeCases, BenchMarkingsWithAUsersOddFrame) {
  TempDir t;
  const int w = 128, h = 64;
  ImageF day(w, h, 3, 0.3f);
  write_png(t.file("day.png"), day);
  ImageU8 sky(w, h, 1, 23), road(w, h, 1, 23);
  for (int y = h / 2; y < h; ++y)
    for (int x = 0; x < w; ++x) road.at(x, y) = 7;
  write_png8(t.file("sky.png"), sky);
  write_png8(t.file("road.png"), road);
  write_png8(t.file("half.png"), ImageU8(w / 2, h / 2, 1, 7));
  fs::create_directory(t.path() / "out");
  const std::string frame = "bench markings --image '" + t.file("day.png") + "' --labels '";
  const std::string out = "' --out-dir '" + t.file("out") + "'";
  const auto no_road = run_cli(frame + t.file("sky.png") + out);
  EXPECT_EQ(no_road.exit_code, 0) << no_road.output;
  EXPECT_NE(no_road.output.find("no road or parking in the labels: no markings to measure"), std::string::npos)
      << no_road.output;
  const auto plain = run_cli(frame + t.file("road.png") + out);
  EXPECT_EQ(plain.exit_code, 0) << plain.output;
  EXPECT_NE(plain.output.find("no dashed line of 4 or more regular dashes"), std::string::npos) << plain.output;
  EXPECT_EQ(slurp(t.file("out/bench_markings.csv")).find('\n') + 1, slurp(t.file("out/bench_markings.csv")).size());
  const auto half = run_cli(frame + t.file("half.png") + out);
  EXPECT_EQ(half.exit_code, 2) << half.output;
  EXPECT_NE(half.output.find("pass --resize-labels=nearest"), std::string::npos) << half.output;
  const auto resized = run_cli(frame + t.file("half.png") + out + " --resize-labels nearest");
  EXPECT_EQ(resized.exit_code, 0) << resized.output;
  const auto kitti = run_cli(frame + t.file("road.png") + out + " --rig kitti");
  EXPECT_EQ(kitti.exit_code, 0) << kitti.output;
  EXPECT_NE(kitti.output.find("note: day: the frame's aspect ratio 2.000 is not rig kitti's (1242x375, 3.312)"),
            std::string::npos)
      << kitti.output;
  const std::string recorded = slurp(std::string(PHOTOSITE_SOURCE_DIR) + "/docs/bench_markings.csv");
  const auto docs = run_cli(frame + t.file("road.png") + "'");
  EXPECT_EQ(docs.exit_code, 2) << docs.output;
  EXPECT_NE(docs.output.find("--out-dir: give the folder for the CSV of your frame"), std::string::npos) << docs.output;
  EXPECT_EQ(slurp(std::string(PHOTOSITE_SOURCE_DIR) + "/docs/bench_markings.csv"), recorded);
}

// bench depth on a KITTI folder whose disparity maps are 8-bit (KITTI's are 16-bit: disparity ×
// 256) measured nothing and printed nan% with exit 0; now refused naming the file. A folder whose
// maps hold no measurement at all (every disparity 0) says that nothing was measured.
TEST(EdgeCases, BenchDepthNamesAnUnusableDisparity) {
  TempDir t;
  const std::string src = std::string(PHOTOSITE_SOURCE_DIR) + "/samples/kitti/";
  ImageFileInfo info;
  const ImageF day = read_image(src + "image_2/000000_10.png", &info);
  for (const char* k : {"k8", "k0"}) {
    for (const char* sub : {"image_2", "semantic", "disp_occ_0"}) fs::create_directories(t.path() / k / sub);
    fs::copy_file(src + "image_2/000000_10.png", t.path() / k / "image_2/000000_10.png");
    fs::copy_file(src + "semantic/000000_10.png", t.path() / k / "semantic/000000_10.png");
  }
  write_png8(t.file("k8/disp_occ_0/000000_10.png"), ImageU8(day.width(), day.height(), 1, 30));
  write_png(t.file("k0/disp_occ_0/000000_10.png"), ImageF(day.width(), day.height(), 1, 0.f), 16);
  const auto r8 = run_cli("bench depth --kitti '" + t.file("k8") + "' --out-dir '" + t.file("k8") + "'");
  EXPECT_EQ(r8.exit_code, 2) << r8.output;
  EXPECT_NE(r8.output.find(t.file("k8/disp_occ_0/000000_10.png") + ": disparity map has 8-bit samples; KITTI's are 16-bit PNG"),
            std::string::npos)
      << r8.output;
  EXPECT_FALSE(fs::exists(t.file("k8/bench_depth.csv")));
  const auto r0 = run_cli("bench depth --kitti '" + t.file("k0") + "' --out-dir '" + t.file("k0") + "'");
  EXPECT_EQ(r0.exit_code, 0) << r0.output;
  EXPECT_NE(r0.output.find("000000_10      vanishing_point  no road pixel or vehicle contact with a ground-truth disparity"),
            std::string::npos)
      << r0.output;
  EXPECT_NE(r0.output.find("pooled: nothing measured"), std::string::npos) << r0.output;
}

// A preset folder holding what is no preset: a folder named x.toml was listed with no description,
// a symbolic link to nothing as "(malformed)", and asking for the link said "unknown camera rig
// 'dangling' (bundled: ..., dangling, ...)". Now each is named for what it is, and a file that is
// not TOML (a PNG named .toml) stays "(malformed)" in the list and names its line when used.
TEST(EdgeCases, PresetFolderWithFilesThatAreNoPresets) {
  TempDir t;
  fs::copy(std::string(PHOTOSITE_SOURCE_DIR) + "/presets", t.path() / "presets", fs::copy_options::recursive);
  fs::create_directory(t.path() / "presets/lenses/folder.toml");
  fs::create_symlink("nowhere.toml", t.path() / "presets/rigs/dangling.toml");
  fs::copy_file(std::string(PHOTOSITE_SOURCE_DIR) + "/samples/kitti/image_2/000000_10.png", t.path() / "presets/cameras/photo.toml");
  std::ofstream(t.file("presets/cameras/notes.txt")) << "not a preset";
  const ScopedEnv env("PHOTOSITE_PRESET_DIR", t.file("presets"));
  const auto list = run_cli("presets list");
  EXPECT_EQ(list.exit_code, 0) << list.output;
  EXPECT_NE(list.output.find("folder\tlens\t(not a preset file: a folder)"), std::string::npos) << list.output;
  EXPECT_NE(list.output.find("dangling\trig\t(not a preset file: a symbolic link to nothing)"), std::string::npos) << list.output;
  EXPECT_NE(list.output.find("photo\tcamera\t(malformed)"), std::string::npos) << list.output;
  EXPECT_EQ(list.output.find("notes"), std::string::npos) << list.output;
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"presets show dangling", t.file("presets/rigs/dangling.toml") + ": a symbolic link to nothing (nowhere.toml is missing)"},
      {"presets show folder", t.file("presets/lenses/folder.toml") + ": is a folder, not a preset file"},
      {"presets show photo", t.file("presets/cameras/photo.toml") + ":1: malformed TOML"},
  };
  for (const auto& [args, message] : cases) {
    const auto r = run_cli(args);
    EXPECT_EQ(r.exit_code, 2) << args << "\n" << r.output;
    EXPECT_NE(r.output.find(message), std::string::npos) << args << "\n" << r.output;
  }
  const auto unknown = run_cli("presets show nothing-of-that-name");
  EXPECT_EQ(unknown.exit_code, 2) << unknown.output;
  EXPECT_EQ(unknown.output.find("dangling"), std::string::npos) << unknown.output;
}

// ---- thirty-eighth session ----

// A preset whose own description reads like list_presets' note on a folder or a dangling link was
// taken for one (the note was recognised by its text) and left out of the "bundled" lists; the
// entry now carries a flag.
TEST(EdgeCases, PresetDescriptionCannotPassForANonPresetFile) {
  TempDir t;
  fs::copy(std::string(PHOTOSITE_SOURCE_DIR) + "/presets", t.path() / "presets", fs::copy_options::recursive);
  std::ifstream in(std::string(PHOTOSITE_SOURCE_DIR) + "/presets/cameras/sony-imx174.toml");
  std::stringstream text;
  text << in.rdbuf();
  std::string toml = text.str();
  const std::string old = "description = \"Sony IMX174";
  ASSERT_NE(toml.find(old), std::string::npos);
  toml.replace(toml.find(old), old.size(), "description = \"(not a preset file: a folder) Sony IMX174");
  std::ofstream(t.file("presets/cameras/lookalike.toml")) << toml;
  fs::create_directory(t.path() / "presets/lenses/folder.toml");
  const ScopedEnv env("PHOTOSITE_PRESET_DIR", t.file("presets"));
  const auto unknown = run_cli("presets show nothing-of-that-name");
  EXPECT_EQ(unknown.exit_code, 2) << unknown.output;
  EXPECT_NE(unknown.output.find("lookalike"), std::string::npos) << unknown.output;  // a camera, listed
  EXPECT_EQ(unknown.output.find("folder"), std::string::npos) << unknown.output;     // no lens, left out
  const auto show = run_cli("presets show lookalike");
  EXPECT_EQ(show.exit_code, 0) << show.output;
}

// bench markings on a frame where no dashed line is measured wrote its CSV (a header alone) and no
// chart, so an earlier run's bench_markings.png in the user's --out-dir stayed beside the new CSV,
// the two disagreeing. The chart is now written for such a run too, a panel saying nothing was
// measured; no file of the folder is removed.
TEST(EdgeCases, BenchMarkingsWithNothingMeasuredReplacesItsChart) {
  if (std::system("/usr/bin/python3 -c 'import matplotlib' 2>/dev/null") != 0)
    GTEST_SKIP() << "no matplotlib for /usr/bin/python3: bench charts are not drawn";
  TempDir t;
  const int w = 128, h = 64;
  write_png(t.file("day.png"), ImageF(w, h, 3, 0.3f));
  ImageU8 road(w, h, 1, 23);
  for (int y = h / 2; y < h; ++y)
    for (int x = 0; x < w; ++x) road.at(x, y) = 7;
  write_png8(t.file("road.png"), road);
  fs::create_directory(t.path() / "out");
  const std::string stale = "an earlier run's chart";
  std::ofstream(t.file("out/bench_markings.png")) << stale;
  std::ofstream(t.file("out/notes.txt")) << "the user's";
  const auto r = run_cli("bench markings --image '" + t.file("day.png") + "' --labels '" + t.file("road.png") +
                         "' --out-dir '" + t.file("out") + "'");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("no dashed line of 4 or more regular dashes"), std::string::npos) << r.output;
  const std::string png = slurp(t.file("out/bench_markings.png"));
  EXPECT_EQ(png.compare(0, 8, "\x89PNG\r\n\x1a\n"), 0) << "the earlier chart is still there";
  EXPECT_EQ(slurp(t.file("out/notes.txt")), "the user's");
}

namespace {
// The command under an address-space limit (sh's ulimit -v, in KiB), through run_cli's shell: a
// reader that allocated what a damaged header asks for fails ("out of memory", exit 1) instead of
// naming the damage.
// Under AddressSanitizer the limit is left out: the sanitizer reserves terabytes of shadow address
// space at start and cannot start within it (scripts/sanitize.sh), so there the tests check the
// messages and exit codes, and the normal build checks the bound too.
photosite::test::CliResult run_cli_within(int64_t kib, const std::string& args) {
  if (PHOTOSITE_ASAN) return run_cli(args);
  return run_cli("--version > /dev/null; ulimit -v " + std::to_string(kib) + " && '" PHOTOSITE_BIN "' " + args);
}
// `night` of the image file `name` in t, with 3x3 labels (an image that reads is then refused
// for its size), within `kib` of address space; its output would be p.exr.
photosite::test::CliResult night_within(int64_t kib, const TempDir& t, const std::string& name) {
  write_png8(t.file("lab.png"), ImageU8(3, 3, 1, 7));
  return run_cli_within(kib, "night --backend cpu --image '" + t.file(name) + "' --labels '" + t.file("lab.png") +
                                 "' --out '" + t.file("p.exr") + "'");
}
// Writes `bytes` as t's file `name`, runs night_within on it and expects exit 2 (3x3 labels, or
// the image refused) with `text` in the output, which it returns.
std::string night_says(int64_t kib, const TempDir& t, const std::string& name, const std::string& bytes,
                       const std::string& text) {
  std::ofstream(t.file(name), std::ios::binary) << bytes;
  const auto r = night_within(kib, t, name);
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find(text), std::string::npos) << r.output;
  return r.output;
}
// The header of `night` run on the day image `image` (in t) with labels of its size w x h, all
// road (labelIds), as read_exr_attributes gives it; a failed run fails the test.
std::map<std::string, std::string> night_header_of(const TempDir& t, const std::string& image, int w, int h) {
  ImageF lab(w, h, 1);
  for (auto& v : lab.vec()) v = 7 / 255.0f;
  write_png(t.file("road_labels.png"), lab);
  const auto n = run_cli("night --backend cpu --image '" + t.file(image) + "' --labels '" + t.file("road_labels.png") +
                         "' --out '" + t.file("header_of.exr") + "' --layers depth --overwrite --device-store '" +
                         t.file("store") + "'");
  EXPECT_EQ(n.exit_code, 0) << n.output;
  return n.exit_code == 0 ? read_exr_attributes(t.file("header_of.exr")) : std::map<std::string, std::string>();
}
void put_be32(std::string& s, uint32_t v) {
  for (int k = 3; k >= 0; --k) s.push_back(static_cast<char>(v >> (8 * k)));
}
void put_le(std::string& s, uint64_t v, int bytes) {
  for (int k = 0; k < bytes; ++k) s.push_back(static_cast<char>(v >> (8 * k)));
}
}  // namespace

// Image files whose header asks for far more pixels than the file holds (a download cut short, a
// damaged header) were refused only after the readers had allocated the whole image (peak RSS
// in docs/cli.md, thirty-eighth session): a 334-byte PNG saying 16384x16384 RGBA 16-bit took
// 2.1 GB, a 5.3 kB piz OpenEXR whose data window says 16384x16384 float RGB 3.2 GB, a 9.6 kB
// TIFF whose tags say 16384x16384 RGB 800 MB. Each is now refused from its header and the file's
// length, naming the file, within 1.5 GB of address space.
TEST(EdgeCases, ImageHeaderLargerThanItsFileIsRefusedBeforeAllocating) {
  TempDir t;
  constexpr int64_t kLimitKib = 1500000;  // 1.5 GB: below each claim, above a normal small run's needs
  // PNG: IHDR 16384 x 16384, 16-bit RGBA (2.1 GB of samples), then a 16-byte IDAT and IEND (the
  // CRCs are not checked before the size is).
  std::string png = "\x89PNG\r\n\x1a\n";
  put_be32(png, 13);
  png += "IHDR";
  put_be32(png, 16384), put_be32(png, 16384);
  png += std::string("\x10\x06\x00\x00\x00", 5);
  put_be32(png, 0);
  put_be32(png, 16);
  png += "IDAT" + std::string(16, '\0');
  put_be32(png, 0);
  put_be32(png, 0);
  png += "IEND";
  put_be32(png, 0);
  std::ofstream(t.file("big.png"), std::ios::binary) << png;
  const auto p = night_within(kLimitKib, t, "big.png");
  EXPECT_EQ(p.exit_code, 2) << p.output;
  EXPECT_NE(p.output.find(t.file("big.png") + ": corrupt or truncated image (PNG data: the header's 16384x16384 pixels "
                                               "need 2147483648 bytes of samples, more than the file's " +
                          std::to_string(png.size()) + " bytes hold"),
            std::string::npos)
      << p.output;

  // OpenEXR: a 64x256 float RGB file without compression (one line a chunk), its last chunks cut
  // off; and the same file with its data window made 16384x16384 (the offset table too short).
  ImageF rad(64, 256, 3, 1e-3f);
  write_exr(t.file("whole.exr"), {{{"R", "G", "B"}, &rad, ""}}, {}, ExrWriteOptions{.compression = "none"});
  const std::string whole = slurp(t.file("whole.exr"));
  std::ofstream(t.file("cut.exr"), std::ios::binary) << whole.substr(0, whole.size() / 2);
  std::string big = whole;
  const std::string key = std::string("dataWindow\0box2i\0", 17);
  ASSERT_NE(big.find(key), std::string::npos);
  std::string box;
  for (uint32_t v : {0u, 0u, 16383u, 16383u}) put_le(box, v, 4);
  big.replace(big.find(key) + key.size() + 4, 16, box);
  std::ofstream(t.file("bigwindow.exr"), std::ios::binary) << big;
  const std::string expose = "expose --backend cpu --preset sony-imx174 --out '" + t.file("e.exr") + "' --radiance '";
  const auto whole_run = run_cli_within(kLimitKib, expose + t.file("whole.exr") + "'");
  EXPECT_EQ(whole_run.exit_code, 0) << whole_run.output;  // the check passes a whole file
  fs::remove(t.file("e.exr"));
  const auto cut = run_cli_within(kLimitKib, expose + t.file("cut.exr") + "'");
  EXPECT_EQ(cut.exit_code, 2) << cut.output;
  EXPECT_NE(cut.output.find(t.file("cut.exr") + ": corrupt or truncated EXR (the offset table puts chunk "),
            std::string::npos)
      << cut.output;
  // Its old offsets now point into its own (longer) table; cut to 60000 bytes, the table itself
  // does not fit.
  const auto window = run_cli_within(kLimitKib, expose + t.file("bigwindow.exr") + "'");
  EXPECT_EQ(window.exit_code, 2) << window.output;
  EXPECT_NE(window.output.find(t.file("bigwindow.exr") + ": corrupt or truncated EXR (the offset table puts chunk 0 of "
                                                         "16384 at byte "),
            std::string::npos)
      << window.output;
  EXPECT_NE(window.output.find("refused before allocating its 16384x16384 data window"), std::string::npos)
      << window.output;
  std::ofstream(t.file("bigwindow_cut.exr"), std::ios::binary) << big.substr(0, 60000);
  const auto table = run_cli_within(kLimitKib, expose + t.file("bigwindow_cut.exr") + "'");
  EXPECT_EQ(table.exit_code, 2) << table.output;
  EXPECT_NE(table.output.find(t.file("bigwindow_cut.exr") + ": corrupt or truncated EXR (the file's 60000 bytes end "
                                                            "inside the offset table of its 16384 chunks, for a "
                                                            "16384x16384 data window)"),
            std::string::npos)
      << table.output;
  EXPECT_FALSE(fs::exists(t.file("e.exr")));

  // TIFF: 16384 x 16384 8-bit grey, uncompressed, one strip; its byte count 64 (the file holds
  // them), or the whole image's (the file does not).
  for (const uint32_t strip_bytes : {64u, 16384u * 16384u}) {
    std::string tif = "II*";
    tif.push_back('\0');
    put_le(tif, 8, 4);
    const std::vector<std::array<uint32_t, 3>> tags = {  // tag, type (3 SHORT, 4 LONG), value
        {256, 4, 16384}, {257, 4, 16384}, {258, 3, 8}, {259, 3, 1}, {262, 3, 1},
        {273, 4, 8 + 2 + 9 * 12 + 4}, {277, 3, 1}, {278, 4, 16384}, {279, 4, strip_bytes}};
    put_le(tif, tags.size(), 2);
    for (const auto& [tag, type, value] : tags) {
      put_le(tif, tag, 2), put_le(tif, type, 2), put_le(tif, 1, 4), put_le(tif, value, 4);
    }
    put_le(tif, 0, 4);
    tif += std::string(64, '\x40');
    std::ofstream(t.file("big.tif"), std::ios::binary) << tif;
    const auto r = run_cli_within(kLimitKib, "demosaic --backend cpu --in '" + t.file("big.tif") + "' --out '" +
                                                 t.file("d.exr") + "'");
    EXPECT_EQ(r.exit_code, 2) << r.output;
    // libtiff may take a lone uncompressed strip's byte count beyond the file for a damaged one and
    // estimate it from the file's length instead: either check may then be the one that refuses.
    EXPECT_NE(r.output.find(t.file("big.tif") + ": corrupt or truncated image ("), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("TIFF"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("refused before allocating"), std::string::npos)
        << r.output;
  }
}

namespace {
// A Huffman-coded JPEG of w x h pixels in `comps` components (each sampled 1x1: one block a
// component an MCU), every DCT coefficient 0, in the fewest bits T.81 allows: one DC and one AC
// Huffman table each of a single 1-bit code ('0'), for the DC difference category 0 and for EOB.
// A sequential block is then '0' '0' (DC difference 0, EOB), a progressive file's one scan, its
// first DC scan, codes '0' a block (no AC scan: its coefficients stay 0). The entropy-coded data
// is all zero bytes; `missing` bytes of it are left out. Decodes to grey 128 in every channel.
std::string zero_jpeg(int w, int h, int comps, bool progressive, int64_t missing = 0) {
  std::string j = "\xff\xd8";
  auto segment = [&](uint8_t marker, const std::string& body) {
    j.push_back('\xff'), j.push_back(static_cast<char>(marker));
    j.push_back(static_cast<char>((body.size() + 2) >> 8)), j.push_back(static_cast<char>((body.size() + 2) & 255));
    j += body;
  };
  segment(0xdb, std::string(1, '\0') + std::string(64, '\x01'));  // DQT: table 0, all steps 1
  std::string sof = {8, static_cast<char>(h >> 8), static_cast<char>(h & 255), static_cast<char>(w >> 8),
                     static_cast<char>(w & 255), static_cast<char>(comps)};
  for (int c = 0; c < comps; ++c) sof += std::string{static_cast<char>(c + 1), '\x11', '\0'};
  segment(progressive ? 0xc2 : 0xc0, sof);
  std::string one_code(16, '\0');  // BITS: one code of length 1
  one_code[0] = 1;
  segment(0xc4, std::string(1, '\x00') + one_code + std::string(1, '\x00') +  // DC table 0: category 0
                    std::string(1, '\x10') + one_code + std::string(1, '\x00'));  // AC table 0: EOB
  std::string sos(1, static_cast<char>(comps));
  for (int c = 0; c < comps; ++c) sos += std::string{static_cast<char>(c + 1), '\0'};
  sos += progressive ? std::string{0, 0, 0} : std::string{0, 63, 0};
  segment(0xda, sos);
  const int64_t blocks = int64_t{comps} * ((w + 7) / 8) * ((h + 7) / 8);
  j += std::string(static_cast<size_t>((blocks * (progressive ? 1 : 2) + 7) / 8 - missing), '\0');
  return j + "\xff\xd9";
}
}  // namespace

// A JPEG's length bounded nothing (thirty-eighth session): a 1 kB file whose frame header said
// 16384x16384 was refused only after the reader had allocated its 805 MB of pixels (libjpeg's
// coefficient buffer too, for a progressive one). Every block of a Huffman-coded JPEG costs at
// least 2 bits of a sequential file's data, 1 of a progressive one's (core/jpeg_tiff.cpp
// jpeg_entropy_shortfall, from T.81): a file whose data after its first scan header is shorter is
// refused from its header, naming the file. The smallest files T.81 allows (zero_jpeg) are exactly
// at the bound, and still read; 3 bytes fewer (the bound then short by one byte) are refused.
TEST(EdgeCases, JpegShorterThanItsBlocksIsRefusedBeforeAllocating) {
  TempDir t;
  struct Case {
    int w, h, comps;
    bool progressive;
  };
  for (const Case& k : {Case{4096, 2048, 1, false}, Case{1000, 600, 3, false}, Case{1024, 1024, 3, true},
                        Case{999, 77, 1, true}}) {
    const std::string what = fmt::format("{}x{} {} {}", k.w, k.h, k.comps, k.progressive ? "progressive" : "sequential");
    std::ofstream(t.file("zero.jpg"), std::ios::binary) << zero_jpeg(k.w, k.h, k.comps, k.progressive);
    ImageFileInfo info;
    const ImageF img = read_image(t.file("zero.jpg"), &info);
    ASSERT_EQ(img.width(), k.w) << what;
    ASSERT_EQ(img.height(), k.h) << what;
    EXPECT_EQ(info.format, "jpeg");
    // Every coefficient 0: the level shift's 128 in Y, Cb and Cr, so 128 in R, G and B.
    EXPECT_EQ(*std::min_element(img.data(), img.data() + img.size()), 128.f / 255) << what;
    EXPECT_EQ(*std::max_element(img.data(), img.data() + img.size()), 128.f / 255) << what;
    const std::string short_file = zero_jpeg(k.w, k.h, k.comps, k.progressive, 3);
    std::ofstream(t.file("short.jpg"), std::ios::binary) << short_file;
    const int64_t blocks = int64_t{k.comps} * ((k.w + 7) / 8) * ((k.h + 7) / 8),
                  need = (blocks * (k.progressive ? 1 : 2) + 7) / 8;
    const std::string e = error_of([&] { read_image(t.file("short.jpg")); });
    EXPECT_NE(e.find(fmt::format("{}: corrupt or truncated image (JPEG data: the header's {}x{} pixels in {} component{} "
                                 "are {} blocks of 8x8, whose {} Huffman codes need at least {} bytes ({} a block), "
                                 "more than the file's {} bytes after its first scan header hold; refused before "
                                 "allocating them)",
                                 t.file("short.jpg"), k.w, k.h, k.comps, k.comps == 1 ? "" : "s", blocks,
                                 k.progressive ? "progressive" : "sequential", need,
                                 k.progressive ? "1 bit" : "2 bits", need - 1)),
              std::string::npos)
        << what << ": " << e;
  }
  // The frame header at the pixel limit, 16384x16384 in three components, with 64 bytes of data:
  // refused before allocating, within 1.5 GB of address space (the pixels alone are 805 MB, a
  // progressive file's coefficients 1.6 GB more).
  constexpr int64_t kLimitKib = 1500000;
  for (const bool progressive : {false, true}) {
    const int64_t need = 3 * 2048 * 2048 * (progressive ? 1 : 2) / 8;  // the whole data's bytes
    const std::string whole = zero_jpeg(16384, 16384, 3, progressive);
    const std::string big = whole.substr(0, whole.size() - 2 - need) + std::string(64, '\0') + "\xff\xd9";
    std::ofstream(t.file("big.jpg"), std::ios::binary) << big;
    const auto p = night_within(kLimitKib, t, "big.jpg");
    EXPECT_EQ(p.exit_code, 2) << p.output;
    EXPECT_NE(p.output.find(t.file("big.jpg") + ": corrupt or truncated image (JPEG data: the header's 16384x16384 "
                                                "pixels in 3 components are 12582912 blocks of 8x8"),
              std::string::npos)
        << p.output;
    EXPECT_NE(p.output.find("more than the file's 66 bytes after its first scan header hold; refused before "
                            "allocating them"),
              std::string::npos)
        << p.output;
    EXPECT_FALSE(fs::exists(t.file("p.exr")));
  }
}

// An OpenEXR file's data window not at (0, 0), or its display window not the data window, was read
// as the data window's pixels without a word (thirty-eighth session). The reader says so on the
// standard error, naming the file and both windows, and `expose` records them in its header.
TEST(EdgeCases, ExrWindowsAreNotedAndRecorded) {
  TempDir t;
  const std::string expose = "expose --backend cpu --preset sony-imx174 --radiance '";
  auto write = [&](const std::string& name, const Imath::Box2i& data, const Imath::Box2i& display) {
    const int w = data.max.x - data.min.x + 1, h = data.max.y - data.min.y + 1;
    std::vector<float> px(static_cast<size_t>(w) * h * 3, 1e-3f);
    Imf::Header header(display, data);
    for (const char* c : {"R", "G", "B"}) header.channels().insert(c, Imf::Channel(Imf::FLOAT));
    Imf::OutputFile out(t.file(name).c_str(), header);
    Imf::FrameBuffer fb;
    char* base = reinterpret_cast<char*>(px.data()) - (static_cast<ptrdiff_t>(data.min.x) +
                                                      static_cast<ptrdiff_t>(data.min.y) * w) * 3 * sizeof(float);
    for (int c = 0; c < 3; ++c)
      fb.insert(std::string(1, "RGB"[c]), Imf::Slice(Imf::FLOAT, base + c * sizeof(float), 3 * sizeof(float),
                                                     3 * sizeof(float) * w));
    out.setFrameBuffer(fb);
    out.writePixels(h);
  };
  struct Case {
    std::string name;
    Imath::Box2i data, display;
    std::string note, data_text, display_text;
  };
  for (const Case& k :
       {Case{"origin.exr", {{10, 20}, {73, 67}}, {{10, 20}, {73, 67}}, "its data window is 64x48 at (10, 20), its "
             "display window 64x48 at (10, 20)", "10,20,73,67", "10,20,73,67"},
        Case{"display.exr", {{0, 0}, {63, 47}}, {{0, 0}, {127, 95}}, "its data window is 64x48 at (0, 0), its display "
             "window 128x96 at (0, 0)", "0,0,63,47", "0,0,127,95"},
        Case{"negative.exr", {{-5, -7}, {58, 40}}, {{0, 0}, {31, 23}}, "its data window is 64x48 at (-5, -7), its "
             "display window 32x24 at (0, 0)", "-5,-7,58,40", "0,0,31,23"}}) {
    write(k.name, k.data, k.display);
    const auto r = run_cli(expose + t.file(k.name) + "' --out '" + t.file("e.exr") + "' --overwrite");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_NE(r.output.find("photosite: note: " + t.file(k.name) + ": " + k.note +
                            ": read as the data window's 64x48 pixels, from (0, 0); neither the origin nor the display "
                            "window is kept"),
              std::string::npos)
        << r.output;
    const auto a = read_exr_attributes(t.file("e.exr"));
    ASSERT_TRUE(a.count("photosite/radiance_file_data_window")) << k.name;
    EXPECT_EQ(a.at("photosite/radiance_file_data_window"), k.data_text);
    EXPECT_EQ(a.at("photosite/radiance_file_display_window"), k.display_text);
  }
  // As a `night` day image the note goes into the header too (photosite/night/image_file_note).
  EXPECT_EQ(night_header_of(t, "origin.exr", 64, 48)["photosite/night/image_file_note"].rfind("its data window is 64x48 at (10, 20)", 0), 0u);
  // A plain file (both windows the image at (0, 0)): no note, nothing recorded.
  write("plain.exr", {{0, 0}, {63, 47}}, {{0, 0}, {63, 47}});
  const auto r = run_cli(expose + t.file("plain.exr") + "' --out '" + t.file("e.exr") + "' --overwrite");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(r.output.find("note:"), std::string::npos) << r.output;
  EXPECT_EQ(read_exr_attributes(t.file("e.exr")).count("photosite/radiance_file_data_window"), 0u);
}

// A compressed TIFF whose tags say far more pixels than its strips could give was refused only
// after libtiff had allocated them (803 MB for a 7 kB Deflate file whose tags say 16384x16384 RGB,
// thirty-ninth session). Deflate expands at most 1032:1, PackBits 64:1, LZW under 3413:1 (core/jpeg_tiff.cpp):
// strips shorter than that are refused from the tags, within 1.5 GB of address space. The
// codecs' own best cases, all-zero images written by libtiff, still read: PackBits' is exactly at
// its bound (two bytes a run of 128); zlib's is 780:1, LZW's 155:1 (in strips of 16 rows).
TEST(EdgeCases, CompressedTiffShorterThanItsPixelsIsRefusedBeforeAllocating) {
  TempDir t;
  constexpr int64_t kLimitKib = 1500000;
  struct Codec {
    uint16_t code;
    const char* name;
    int ratio;
  };
  for (const Codec& c : {Codec{COMPRESSION_ADOBE_DEFLATE, "Deflate", 1032}, Codec{COMPRESSION_PACKBITS, "PackBits", 64},
                         Codec{COMPRESSION_LZW, "LZW", 3413}}) {
    // 4096x4096 8-bit grey, all 0, one strip of 16 rows at a time.
    TIFF* tif = TIFFOpen(t.file("zero.tif").c_str(), "w");
    ASSERT_NE(tif, nullptr);
    TIFFSetField(tif, TIFFTAG_IMAGEWIDTH, 4096u), TIFFSetField(tif, TIFFTAG_IMAGELENGTH, 4096u);
    TIFFSetField(tif, TIFFTAG_BITSPERSAMPLE, 8), TIFFSetField(tif, TIFFTAG_SAMPLESPERPIXEL, 1);
    TIFFSetField(tif, TIFFTAG_PHOTOMETRIC, PHOTOMETRIC_MINISBLACK), TIFFSetField(tif, TIFFTAG_COMPRESSION, c.code);
    TIFFSetField(tif, TIFFTAG_ROWSPERSTRIP, 16u), TIFFSetField(tif, TIFFTAG_PLANARCONFIG, PLANARCONFIG_CONTIG);
    if (c.code == COMPRESSION_ADOBE_DEFLATE) TIFFSetField(tif, TIFFTAG_ZIPQUALITY, 9);
    std::vector<uint8_t> row(4096, 0);
    for (uint32_t y = 0; y < 4096; ++y) ASSERT_EQ(TIFFWriteScanline(tif, row.data(), y, 0), 1);
    TIFFClose(tif);
    const ImageF img = read_image(t.file("zero.tif"));
    EXPECT_EQ(img.width(), 4096) << c.name;
    EXPECT_EQ(*std::max_element(img.data(), img.data() + img.size()), 0.f) << c.name;
    // 16384x16384 8-bit grey in one strip of 64 bytes (its content never read).
    std::string tif_bytes = "II*";
    tif_bytes.push_back('\0');
    put_le(tif_bytes, 8, 4);
    const std::vector<std::array<uint32_t, 3>> tags = {  // tag, type (3 SHORT, 4 LONG), value
        {256, 4, 16384}, {257, 4, 16384}, {258, 3, 8}, {259, 3, c.code}, {262, 3, 1},
        {273, 4, 8 + 2 + 9 * 12 + 4}, {277, 3, 1}, {278, 4, 16384}, {279, 4, 64}};
    put_le(tif_bytes, tags.size(), 2);
    for (const auto& [tag, type, value] : tags)
      put_le(tif_bytes, tag, 2), put_le(tif_bytes, type, 2), put_le(tif_bytes, 1, 4), put_le(tif_bytes, value, 4);
    put_le(tif_bytes, 0, 4);
    tif_bytes += std::string(64, '\x40');
    night_says(kLimitKib, t, "big.tif", tif_bytes,
               fmt::format("{}: corrupt or truncated image (TIFF data: its 16384x16384 pixels, 1 sample of 8 bits each, "
                           "need 268435456 bytes; its strips hold 64 bytes of {}, which expand at most {}:1); refused "
                           "before allocating them",
                           t.file("big.tif"), c.name, c.ratio));
  }
}

// The TIFF codecs without an expansion bound (LZMA, ZSTD, CCITT fax) are read into buffers made as
// their rows decode (Memory.DamagedTiffCostsTheRowsItHolds: a damaged file costs the rows it held),
// and CMYK goes through libtiff's RGBA raster after its first row is decoded alone. Valid files
// read as before: each codec's file, in strips of 5 rows or tiles of 16x16, planes contiguous or
// separate, gives exactly the pixels of the same image written uncompressed.
TEST(EdgeCases, UnboundedTiffCodecsReadAsUncompressed) {
  TempDir t;
  constexpr uint32_t kW = 37, kH = 23;
  struct Layout {
    uint16_t photometric, channels, bits, planar;
    bool tiled;
  };
  auto write = [&](const std::string& name, const Layout& k, uint16_t codec) {
    TIFF* tif = TIFFOpen(t.file(name).c_str(), "w");
    ASSERT_NE(tif, nullptr) << name;
    TIFFSetField(tif, TIFFTAG_IMAGEWIDTH, kW), TIFFSetField(tif, TIFFTAG_IMAGELENGTH, kH);
    TIFFSetField(tif, TIFFTAG_BITSPERSAMPLE, k.bits), TIFFSetField(tif, TIFFTAG_SAMPLESPERPIXEL, k.channels);
    TIFFSetField(tif, TIFFTAG_PHOTOMETRIC, k.photometric), TIFFSetField(tif, TIFFTAG_COMPRESSION, codec);
    TIFFSetField(tif, TIFFTAG_PLANARCONFIG, k.planar);
    const int planes = k.planar == PLANARCONFIG_SEPARATE ? k.channels : 1, vals = k.channels / planes;
    const size_t rowbytes = (size_t{kW} * vals * k.bits + 7) / 8;
    // A pattern in every sample (bilevel: a checkerboard of 3-pixel cells).
    auto sample_row = [&](uint32_t y, int p) {
      std::vector<uint8_t> row(rowbytes, 0);
      for (uint32_t x = 0; x < kW; ++x)
        for (int v = 0; v < vals; ++v) {
          if (k.bits == 1) {
            if (((x / 3) + (y / 3)) % 2) row[x / 8] |= static_cast<uint8_t>(0x80 >> (x % 8));
          } else {
            row[x * vals + v] = static_cast<uint8_t>((x * 7 + y * 13 + (p + v) * 61) % 256);
          }
        }
      return row;
    };
    if (k.tiled) {
      TIFFSetField(tif, TIFFTAG_TILEWIDTH, 16u), TIFFSetField(tif, TIFFTAG_TILELENGTH, 16u);
      std::vector<uint8_t> tile(static_cast<size_t>(TIFFTileSize(tif)));
      const size_t trow = static_cast<size_t>(TIFFTileRowSize(tif));
      for (int p = 0; p < planes; ++p)
        for (uint32_t ty = 0; ty < kH; ty += 16)
          for (uint32_t tx = 0; tx < kW; tx += 16) {
            std::fill(tile.begin(), tile.end(), 0);
            for (uint32_t y = ty; y < std::min(kH, ty + 16); ++y) {
              const auto row = sample_row(y, p);
              const size_t x0 = size_t{tx} * vals * k.bits / 8;
              std::copy_n(row.begin() + x0, std::min(trow, rowbytes - x0), tile.begin() + (y - ty) * trow);
            }
            ASSERT_GE(TIFFWriteTile(tif, tile.data(), tx, ty, 0, static_cast<uint16_t>(p)), 0) << name;
          }
    } else {
      TIFFSetField(tif, TIFFTAG_ROWSPERSTRIP, 5u);
      for (int p = 0; p < planes; ++p)
        for (uint32_t y = 0; y < kH; ++y) {
          auto row = sample_row(y, p);
          ASSERT_EQ(TIFFWriteScanline(tif, row.data(), y, static_cast<uint16_t>(p)), 1) << name;
        }
    }
    TIFFClose(tif);
  };
  for (const Layout& k : {Layout{PHOTOMETRIC_RGB, 3, 8, PLANARCONFIG_CONTIG, false},
                          Layout{PHOTOMETRIC_RGB, 3, 8, PLANARCONFIG_SEPARATE, false},
                          Layout{PHOTOMETRIC_RGB, 3, 8, PLANARCONFIG_CONTIG, true},
                          Layout{PHOTOMETRIC_RGB, 3, 8, PLANARCONFIG_SEPARATE, true},
                          Layout{PHOTOMETRIC_SEPARATED, 4, 8, PLANARCONFIG_CONTIG, false},
                          Layout{PHOTOMETRIC_SEPARATED, 4, 8, PLANARCONFIG_CONTIG, true},
                          Layout{PHOTOMETRIC_MINISWHITE, 1, 1, PLANARCONFIG_CONTIG, false}}) {
    const std::string what = fmt::format("photometric {}, {} channels of {} bits, planar {}, {}", k.photometric,
                                         k.channels, k.bits, k.planar, k.tiled ? "tiles" : "strips");
    write("plain.tif", k, COMPRESSION_NONE);
    const ImageF plain = read_image(t.file("plain.tif"));
    ASSERT_EQ(plain.width(), static_cast<int>(kW)) << what;
    const std::vector<uint16_t> codecs =
        k.bits == 1 ? std::vector<uint16_t>{COMPRESSION_CCITTFAX3, COMPRESSION_CCITTFAX4, COMPRESSION_LZMA, COMPRESSION_ZSTD}
                    : std::vector<uint16_t>{COMPRESSION_LZMA, COMPRESSION_ZSTD};
    for (const uint16_t codec : codecs) {
      ASSERT_TRUE(TIFFIsCODECConfigured(codec)) << "this libtiff lacks codec " << codec;
      write("packed.tif", k, codec);
      const ImageF img = read_image(t.file("packed.tif"));
      ASSERT_EQ(img.width(), plain.width()) << what << ", codec " << codec;
      ASSERT_EQ(img.channels(), plain.channels()) << what << ", codec " << codec;
      EXPECT_TRUE(std::equal(img.data(), img.data() + img.size(), plain.data())) << what << ", codec " << codec;
    }
    // The pattern is there (not, say, all zero in both).
    EXPECT_GT(*std::max_element(plain.data(), plain.data() + plain.size()), 0.5f) << what;
    EXPECT_NE(*std::min_element(plain.data(), plain.data() + plain.size()),
              *std::max_element(plain.data(), plain.data() + plain.size())) << what;
  }
}

// A JPEG whose Exif orientation has viewers turn or mirror it (a camera held sideways) was read as
// stored without a word, so labels made from the picture as it is shown fit it only after the
// same turn. Its orientation is now said on the standard error; the pixels stay as stored.
TEST(EdgeCases, JpegExifOrientationIsNoted) {
  TempDir t;
  constexpr int64_t kLimitKib = 1500000;  // as above: no limit meant, only the helper's form
  std::vector<uint8_t> rgb(8 * 6 * 3, 90);
  const std::vector<uint8_t> plain = codec::encode_jpeg_rgb8(rgb.data(), 8, 6, 90);
  // An APP1 Exif segment whose IFD0 holds one entry, Orientation (274) SHORT = o, in either byte
  // order, put after SOI.
  auto with_orientation = [&](int o, bool little_endian, uint32_t ifd0 = 8) {
    std::string tiff = little_endian ? std::string("II*\0", 4) : std::string("MM\0*", 4);
    auto put = [&](uint32_t v, int bytes) {
      for (int k = 0; k < bytes; ++k)
        tiff.push_back(static_cast<char>(v >> (8 * (little_endian ? k : bytes - 1 - k))));
    };
    put(ifd0, 4);                               // IFD0's offset: 8, right after this header
    put(1, 2);                                  // one entry
    put(274, 2), put(3, 2), put(1, 4), put(o, 2), put(0, 2);
    put(0, 4);                                  // no next IFD
    const std::string app1 = std::string("Exif\0\0", 6) + tiff;
    std::string j(plain.begin(), plain.begin() + 2);
    j += "\xff\xe1";
    j.push_back(static_cast<char>((app1.size() + 2) >> 8)), j.push_back(static_cast<char>((app1.size() + 2) & 255));
    return j + app1 + std::string(plain.begin() + 2, plain.end());
  };
  struct Case {
    int orientation;
    bool little_endian;
    const char* shown;
  };
  for (const Case& k : {Case{6, true, "turned 90 degrees clockwise"}, Case{8, false, "turned 90 degrees counter-clockwise"},
                        Case{3, true, "turned 180 degrees"}, Case{2, false, "mirrored left to right"}}) {
    const std::string out =
        night_says(kLimitKib, t, "o.jpg", with_orientation(k.orientation, k.little_endian),
                   fmt::format("photosite: note: {}: its Exif orientation ({}) has viewers show it {}; photosite reads "
                               "its 8x6 pixels as stored, not turned (labels and instance ids must be of the stored "
                               "pixels)",
                               t.file("o.jpg"), k.orientation, k.shown));
    EXPECT_NE(out.find("labels are 3x3 but the image is 8x6"), std::string::npos) << out;  // read, then refused
  }
  // With labels of its stored size `night` runs, and its header records the note.
  std::ofstream(t.file("o6.jpg"), std::ios::binary) << with_orientation(6, true);
  EXPECT_EQ(night_header_of(t, "o6.jpg", 8, 6)["photosite/night/image_file_note"],
            "its Exif orientation (6) has viewers show it turned 90 degrees clockwise; photosite reads its 8x6 pixels "
            "as stored, not turned (labels and instance ids must be of the stored pixels)");
  // Orientation 1 (as stored), no Exif, an IFD0 offset beyond the segment: the file reads, nothing said.
  for (const std::string& j : {with_orientation(1, true), std::string(plain.begin(), plain.end()),
                               with_orientation(6, true, 0xfffffff0u), with_orientation(6, false, 30)}) {
    const std::string out = night_says(kLimitKib, t, "o.jpg", j, "labels are 3x3 but the image is 8x6");
    EXPECT_EQ(out.find("orientation"), std::string::npos) << out;
  }
}
