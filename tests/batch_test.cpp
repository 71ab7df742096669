// Whole data sets: layouts, shards that give the same bytes as one run, resume after a kill,
// and the parameter guard.
#include <gtest/gtest.h>
#include <signal.h>
#include <unistd.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sys/wait.h>
#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <atomic>
#include <functional>

#include "photosite/batch.h"
#include "photosite/checksum.h"
#include "photosite/error.h"
#include "photosite/io.h"
#include "photosite/scene/night.h"
#include "photosite/scene/rig.h"
#include "photosite/sensor/glare.h"
#include "photosite/sensor/preset.h"
#include "photosite/sensor/isp.h"
#include "scene/texture_detail.h"
#include "sensor/glare_detail.h"
#include "test_util.h"

using namespace photosite;
namespace fs = std::filesystem;
using test::error_of;

namespace {
// A small KITTI-layout data set from the synthetic road generator: `n` independent frames and a
// numbered sequence of `seq` frames.
void make_kitti(const fs::path& root, int n, int seq) {
  fs::create_directories(root / "image_2" / "seq01");
  fs::create_directories(root / "semantic" / "seq01");
  auto write = [&](const std::string& rel, int i) {
    scene::SyntheticOptions o;
    o.width = 160;
    o.height = 80;
    o.vp_x = 70 + 3 * i;
    o.vp_y = 30;
    const auto s = scene::make_synthetic_road(o);
    ImageF srgb = s.day_linear_srgb;
    for (auto& v : srgb.vec()) v = static_cast<float>(srgb_encode(v));
    write_png((root / "image_2" / rel).string(), srgb);
    ImageF ids(o.width, o.height, 1);
    for (size_t k = 0; k < ids.size(); ++k) ids[k] = s.labels.ids[k] / 255.0f;
    write_png((root / "semantic" / rel).string(), ids);
  };
  for (int i = 0; i < n; ++i) write(fmt::format("{:06d}_10.png", i), i);
  for (int i = 0; i < seq; ++i) write(fmt::format("seq01/{:010d}.png", i), i);
}

std::map<std::string, std::string> tree_bytes(const fs::path& dir) {
  std::map<std::string, std::string> out;
  for (const auto& e : fs::recursive_directory_iterator(dir)) {
    if (!e.is_regular_file()) continue;
    const std::string rel = fs::relative(e.path(), dir).generic_string();
    if (rel.rfind(".photosite-batch", 0) == 0) continue;  // manifests name their shard
    std::ifstream f(e.path(), std::ios::binary);
    out[rel] = std::string((std::istreambuf_iterator<char>(f)), {});
  }
  return out;
}
}  // namespace

TEST(Batch, KittiLayoutGroupsNumberedFramesIntoOneSequence) {
  test::TempDir dir;
  make_kitti(dir.path() / "kitti", 2, 3);
  auto items = batch::discover(batch::Dataset::Kitti, (dir.path() / "kitti").string());
  ASSERT_EQ(items.size(), 5u);
  std::map<std::string, std::vector<int>> groups;
  for (const auto& it : items) groups[it.group].push_back(it.frame);
  EXPECT_EQ(groups.size(), 3u);  // two single frames and one sequence
  EXPECT_EQ(groups["image_2/seq01/seq"], (std::vector<int>{0, 1, 2}));
  // Shards partition the groups and keep a sequence together.
  size_t total = 0;
  for (int i = 0; i < 3; ++i) {
    auto s = batch::shard(items, i, 3);
    total += s.size();
    std::set<std::string> g;
    for (const auto& it : s) g.insert(it.group);
    for (const auto& it : items)
      if (g.count(it.group)) EXPECT_TRUE(std::any_of(s.begin(), s.end(), [&](auto& x) { return x.key == it.key; }));
  }
  EXPECT_EQ(total, items.size());
  EXPECT_THROW(batch::parse_shard("3/3"), Error);
  EXPECT_THROW(batch::parse_shard("x"), Error);
}

TEST(Batch, ThreeShardsGiveTheSameBytesAsOneRun) {
  test::TempDir dir;
  make_kitti(dir.path() / "kitti", 3, 3);
  const std::string root = (dir.path() / "kitti").string();
  const std::string common = " --dataset kitti --root '" + root + "' --format both --quiet --seed 4";
  auto r = test::run_cli("batch" + common + " --out '" + dir.file("one") + "'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  for (int i = 0; i < 3; ++i) {
    r = test::run_cli("batch" + common + " --shard " + std::to_string(i) + "/3 --out '" + dir.file("three") + "'");
    ASSERT_EQ(r.exit_code, 0) << r.output;
  }
  const auto one = tree_bytes(dir.path() / "one"), three = tree_bytes(dir.path() / "three");
  EXPECT_EQ(one.size(), 6u * 3);  // exr, png and the label copy per image
  ASSERT_EQ(one.size(), three.size());
  for (const auto& [k, v] : one) {
    ASSERT_TRUE(three.count(k)) << k;
    EXPECT_TRUE(three.at(k) == v) << k << " differs between 1 and 3 shards";
  }
  // Labels are carried over unchanged.
  std::ifstream a(root + "/semantic/000001_10.png", std::ios::binary), b(dir.file("one/semantic/000001_10.png"), std::ios::binary);
  EXPECT_EQ(std::string((std::istreambuf_iterator<char>(a)), {}), std::string((std::istreambuf_iterator<char>(b)), {}));
  // Frames of the sequence carry consecutive frame numbers.
  auto c = read_exr(dir.file("one/image_2/seq01/0000000002.exr"));
  EXPECT_EQ(c.attributes["photosite/frame"], "2");
}

TEST(Batch, ResumesAfterAKillAndRefusesOtherParameters) {
  test::TempDir dir;
  constexpr int kImages = 6;
  make_kitti(dir.path() / "kitti", kImages, 0);
  const std::string root = (dir.path() / "kitti").string();
  const std::string base = " batch --dataset kitti --root '" + root + "' --quiet";
  const std::string args = base + " --out '" + dir.file("out") + "'";
  ASSERT_EQ(test::run_cli(base.substr(1) + " --out '" + dir.file("ref") + "'").exit_code, 0);
  // Kill a run (SIGKILL) as soon as its manifest records the first finished image — not after a
  // fixed delay, which under load can fall before any image is done — then run it again.
  // `exec` makes the shell become photosite, so the kill reaches the batch itself.
  const pid_t pid = fork();
  if (pid == 0) {
    execl("/bin/sh", "sh", "-c", (std::string("exec '") + PHOTOSITE_BIN + "'" + args + " > /dev/null 2>&1").c_str(), nullptr);
    _exit(127);
  }
  auto finished_in_manifest = [&] {
    int n = 0;
    std::error_code ec;
    for (const auto& e : fs::directory_iterator(dir.path() / "out" / ".photosite-batch", ec)) {
      std::ifstream f(e.path());
      for (std::string line; std::getline(f, line);) n += line.find("\"key\":") != std::string::npos;
    }
    return n;
  };
  int done_at_kill = 0;
  for (int waited_ms = 0; waited_ms < 300000 && (done_at_kill = finished_in_manifest()) == 0; waited_ms += 2)
    usleep(2000);
  kill(pid, SIGKILL);
  int st;
  waitpid(pid, &st, 0);
  ASSERT_GE(done_at_kill, 1) << "the batch recorded no finished image within 300 s";
  ASSERT_TRUE(WIFSIGNALED(st)) << "the batch finished before it could be killed";
  EXPECT_LT(finished_in_manifest(), kImages) << "nothing was left to resume";
  auto r = test::run_cli(args.substr(1));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto ref = tree_bytes(dir.path() / "ref"), out = tree_bytes(dir.path() / "out");
  EXPECT_EQ(ref.size(), out.size());
  for (const auto& [k, v] : ref) EXPECT_TRUE(out.count(k) && out.at(k) == v) << k;
  for (const auto& e : fs::recursive_directory_iterator(dir.path() / "out"))
    EXPECT_EQ(e.path().filename().string().find(".tmp-"), std::string::npos) << e.path();
  // A finished run does nothing the second time; a damaged output is redone.
  fs::remove(dir.file("out/image_2/000002_10.exr"));
  r = test::run_cli(args.substr(1));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(tree_bytes(dir.path() / "out") == out);
  // Other parameters into the same folder: refused, nothing changed.
  r = test::run_cli(args.substr(1) + " --exposure-s 0.03");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("other parameters"), std::string::npos) << r.output;
  EXPECT_TRUE(tree_bytes(dir.path() / "out") == out);
}

TEST(Batch, ManifestItemsAndBadInput) {
  test::TempDir dir;
  make_kitti(dir.path() / "kitti", 2, 0);
  {
    std::ofstream m(dir.file("list.txt"));
    m << "# image, labels\nkitti/image_2/000000_10.png, kitti/semantic/000000_10.png\n"
      << "kitti/image_2/000001_10.png kitti/semantic/000001_10.png\n";
  }
  auto r = test::run_cli("batch --manifest '" + dir.file("list.txt") + "' --quiet --out '" + dir.file("o") + "'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(fs::exists(dir.file("o/kitti/image_2/000001_10.exr")));
  EXPECT_TRUE(fs::exists(dir.file("o/labels/kitti/semantic/000001_10.png")));
  { std::ofstream(dir.file("bad.txt")) << "kitti/image_2/000000_10.png\n"; }
  r = test::run_cli("batch --manifest '" + dir.file("bad.txt") + "' --out '" + dir.file("o2") + "'");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("bad.txt:1"), std::string::npos) << r.output;
  fs::remove(dir.path() / "kitti/semantic/000001_10.png");
  r = test::run_cli("batch --dataset kitti --root '" + dir.file("kitti") + "' --out '" + dir.file("o3") + "'");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("no labels"), std::string::npos) << r.output;
}

// --layers: the EXR holds the chosen layers, the manifest records the set, a rerun with another
// set into the same folder is refused, and an unknown name is bad input before any file.
TEST(Batch, LayersAreWrittenRecordedAndChecked) {
  test::TempDir dir;
  make_kitti(dir.path() / "kitti", 1, 0);
  const std::string base = "batch --dataset kitti --root '" + dir.file("kitti") + "' --quiet --out '" + dir.file("o") + "'";
  auto r = test::run_cli(base + " --layers raw,labels");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const ExrContents e = read_exr(dir.file("o/image_2/000000_10.exr"));
  EXPECT_EQ(e.channels.size(), 2u);
  EXPECT_EQ(e.pixel_types.at("raw.Y"), ExrPixel::Uint);
  EXPECT_EQ(e.pixel_types.at("labels.Y"), ExrPixel::Uint);
  std::ifstream m(dir.file("o/.photosite-batch/shard-0-of-1.jsonl"));
  const std::string manifest((std::istreambuf_iterator<char>(m)), std::istreambuf_iterator<char>());
  EXPECT_NE(manifest.find("\"layers\":\"raw,labels\""), std::string::npos) << manifest;
  r = test::run_cli(base + " --layers raw");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  r = test::run_cli("batch --dataset kitti --root '" + dir.file("kitti") + "' --quiet --out '" + dir.file("o2") +
                    "' --layers raw,bogus");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("unknown layer 'bogus'"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(dir.file("o2/image_2/000000_10.exr")));
}

// --streetlamp-type: as night's, for every image; the EXR header records the type, the manifest
// records it when it is not the LED (earlier manifests stay valid), a rerun with the other type into
// the same folder is refused, and a bad value is bad input naming the option, before any file.
TEST(Batch, StreetlampTypeIsRecordedAndChecked) {
  test::TempDir dir;
  make_kitti(dir.path() / "kitti", 1, 0);
  const std::string base = "batch --dataset kitti --root '" + dir.file("kitti") + "' --quiet --layers lights --out '";
  auto r = test::run_cli(base + dir.file("o") + "' --streetlamp-type hps");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(read_exr(dir.file("o/image_2/000000_10.exr")).attributes.at("photosite/scene/lamps.streetlamp_type"), "hps");
  std::ifstream m(dir.file("o/.photosite-batch/shard-0-of-1.jsonl"));
  const std::string manifest((std::istreambuf_iterator<char>(m)), std::istreambuf_iterator<char>());
  EXPECT_NE(manifest.find("\"streetlamp_type\":\"hps\""), std::string::npos) << manifest;
  r = test::run_cli(base + dir.file("o") + "'");  // the preset's led into the hps run's folder
  EXPECT_EQ(r.exit_code, 2) << r.output;
  r = test::run_cli(base + dir.file("o2") + "' --streetlamp-type sodium");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("sodium"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(dir.file("o2/image_2/000000_10.exr")));
}

// `batch --backend vulkan` runs darken and compose (and the sensor with the lens glare) on the device for every image (one set
// of device buffers reused across images, sizes differing): the same images as the CPU run, bit
// for bit (docs/vulkan.md).
TEST(Batch, VulkanBackendAgreesWithCpu) {
  // As tests/gpu_test.cpp: lavapipe unless a driver was chosen, validation on in the children.
  const char* lvp = "/usr/share/vulkan/icd.d/lvp_icd.x86_64.json";
  if (!std::getenv("VK_DRIVER_FILES") && !std::getenv("VK_ICD_FILENAMES") && fs::exists(lvp)) {
    setenv("VK_DRIVER_FILES", lvp, 1);
    setenv("VK_ICD_FILENAMES", lvp, 1);
  }
  setenv("PHOTOSITE_VK_VALIDATION", "1", 0);
  test::TempDir dir;
  make_kitti(dir.path() / "kitti", 2, 2);
  const std::string root = (dir.path() / "kitti").string();
  const std::string common = " --dataset kitti --root '" + root + "' --format exr --layers sensor,raw,electrons,radiance,lights,depth,labels --quiet --seed 4 --device-store '" +
                             dir.file("store") + "'";
  for (const char* b : {"cpu", "vulkan"}) {
    auto r = test::run_cli(std::string("batch --backend ") + b + common + " --out '" + dir.file(b) + "'");
    if (std::string(b) == "vulkan" && r.exit_code == 2 && std::getenv("PHOTOSITE_ALLOW_NO_VULKAN") &&
        std::string(std::getenv("PHOTOSITE_ALLOW_NO_VULKAN")) == "1")
      GTEST_SKIP() << "*** Vulkan unavailable, skipped (PHOTOSITE_ALLOW_NO_VULKAN=1): " << r.output;
    ASSERT_EQ(r.exit_code, 0) << b << ": " << r.output;
    EXPECT_EQ(r.output.find("validation"), std::string::npos) << r.output;
  }
  size_t files = 0;
  for (const auto& e : fs::recursive_directory_iterator(dir.path() / "cpu")) {
    if (!e.is_regular_file() || e.path().extension() != ".exr") continue;
    const fs::path rel = fs::relative(e.path(), dir.path() / "cpu");
    const auto a = read_exr(e.path().string()).channels;
    const auto v = read_exr((dir.path() / "vulkan" / rel).string()).channels;
    ASSERT_EQ(a.size(), v.size()) << rel;
    // Every layer bit-equal, as `night` (Gpu.CliBackendsAgreeOnFlatAndNight): darken and compose
    // are bit-equal on the device (compose reads the low beam as an image made on the CPU) and so
    // are the glare and the sensor stages; the same radiance then draws the same noise. (The
    // former bounds, 2e-6 of the peak on the radiance and a count of differing raw samples, were
    // those of the device's own low-beam exp, gone since 2026-11-25.)
    for (const auto& [name, img] : a) {
      const ImageF& w = v.at(name);
      ASSERT_EQ(img.size(), w.size()) << rel << " " << name;
      size_t differ = 0;
      for (size_t i = 0; i < img.size(); ++i) differ += std::memcmp(&img[i], &w[i], sizeof(float)) != 0;
      EXPECT_EQ(differ, 0u) << rel << " " << name;
    }
    ++files;
  }
  EXPECT_EQ(files, 4u);
}

// "The preset's value" is recorded as null; manifests of earlier runs recorded it as f_number -1
// and temperature_c -999, and must still resume (read as null), while a real value is kept.
TEST(Batch, OldManifestsWithMinusOneForThePresetsValueStillResume) {
  EXPECT_EQ(batch::upgrade_params(R"({"f_number":-1.0,"gain_db":0.0,"temperature_c":-999.0})"),
            R"({"f_number":null,"gain_db":0.0,"temperature_c":null})");
  EXPECT_EQ(batch::upgrade_params(R"({"f_number":2.8,"temperature_c":-20.0})"),
            R"({"f_number":2.8,"temperature_c":-20.0})");

  test::TempDir dir;
  make_kitti(dir.path() / "kitti", 2, 0);
  const std::string args = "batch --dataset kitti --root '" + (dir.path() / "kitti").string() + "' --out '" +
                           dir.file("out") + "'";
  auto r = test::run_cli(args + " --quiet");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto out = tree_bytes(dir.path() / "out");
  // Rewrite the manifest's parameters as an earlier photosite wrote them.
  const fs::path manifest = dir.path() / "out" / ".photosite-batch" / "shard-0-of-1.jsonl";
  std::ifstream in(manifest);
  std::string first, rest, line;
  std::getline(in, first);
  while (std::getline(in, line)) rest += line + "\n";
  in.close();
  nlohmann::json head = nlohmann::json::parse(first);
  ASSERT_TRUE(head["params"]["f_number"].is_null()) << first;
  ASSERT_TRUE(head["params"]["temperature_c"].is_null()) << first;
  auto rewrite = [&](double f_number, double temperature_c) {
    head["params"]["f_number"] = f_number;
    head["params"]["temperature_c"] = temperature_c;
    std::ofstream(manifest) << head.dump() << "\n" << rest;
  };
  rewrite(-1.0, -999.0);
  r = test::run_cli(args);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("2 already done, 0 to do"), std::string::npos) << r.output;
  EXPECT_TRUE(tree_bytes(dir.path() / "out") == out);
  // A value that is a real f-number is not the preset's: refused as other parameters.
  rewrite(2.8, -999.0);
  r = test::run_cli(args);
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("other parameters"), std::string::npos) << r.output;
}

// ---- the engine in process (batch::run) ------------------------------------------------------
namespace {
// The options `photosite batch --dataset kitti` resolves to (its default camera and lens), with
// an isolated device store.
batch::Options kitti_options(const test::TempDir& dir, const std::string& root, const std::string& out) {
  batch::Options o;
  o.out = out;
  o.root = root;
  o.source = "kitti " + root;
  o.format = "both";
  o.sensor.camera = load_camera_preset("sony-icx267-flea2");
  o.sensor.lens = load_lens_preset(o.sensor.camera.default_lens);
  o.sensor.device_id = o.sensor.camera.name + "-0";
  o.sensor.settings.seed = 4;
  o.device_store = dir.file("store");
  o.scene = scene::load_scene_preset("night-urban");
  return o;
}
}  // namespace

// Writer threads, compute threads and queue depth change only the order in which items are
// done, never a byte of what is written. Every run hands each frame's lens-glare level 1, made in
// the scene's compose pass, on to the sensor (night_scene_for, as the night chain does): no
// frame's glare reads the full-resolution radiance for its pyramid's level 1
// (detail::glare_full_resolution_level1_count stays put through all the runs; a skirt made
// without the level, at the end, moves it).
TEST(Batch, BytesDoNotDependOnThreadsOrQueueDepth) {
  test::TempDir dir;
  make_kitti(dir.path() / "kitti", 3, 3);
  const std::string root = dir.file("kitti");
  const auto items = batch::discover(batch::Dataset::Kitti, root);
  SensorRunner cpu(Backend::Cpu);
  auto a = kitti_options(dir, root, dir.file("a"));
  const GlarePlan plan =
      plan_glare(a.sensor.lens.glare, px_per_degree(a.sensor.lens.focal_length_mm, a.sensor.camera.pixel_pitch_um));
  ASSERT_TRUE(plan.active) << a.sensor.lens.name << " has no glare: the level-1 check needs a lens with one";
  const uint64_t full_resolution_level1 = detail::glare_full_resolution_level1_count();
  const uint64_t own_class_sums = scene::texture_own_class_sums_count();
  a.jobs = 1, a.queue_depth = 1, a.compute_threads = 1;
  auto b = kitti_options(dir, root, dir.file("b"));
  b.jobs = 3, b.queue_depth = 5, b.compute_threads = 2;
  const auto ra = batch::run(items, a, cpu), rb = batch::run(items, b, cpu);
  EXPECT_TRUE(ra.errors.empty() && rb.errors.empty());
  EXPECT_EQ(ra.progress.written, 6u);
  EXPECT_EQ(rb.progress.written, 6u);
  const auto ta = tree_bytes(dir.path() / "a"), tb = tree_bytes(dir.path() / "b");
  EXPECT_EQ(ta.size(), 6u * 3);  // exr, png and the label copy per image
  ASSERT_EQ(ta.size(), tb.size());
  for (const auto& [k, v] : ta) EXPECT_TRUE(tb.count(k) && tb.at(k) == v) << k << " differs";
  for (const auto* r : {&ra, &rb}) {  // every stage's CPU time is counted
    EXPECT_GT(r->stages.reader_cpu_ms, 0);
    EXPECT_GT(r->stages.compute_cpu_ms, 0);
    EXPECT_GT(r->stages.writer_cpu_ms, 0);
  }

  // On the CPU, items go to min(queue_depth, cores) workers; with sequences a worker takes a
  // whole group in frame order with the group's own state: one worker of one thread and two of
  // two threads each write the same bytes.
  auto c = a, d = b;
  c.out = dir.file("c"), d.out = dir.file("d");
  c.sequences = d.sequences = true;
  // (A sequence's later frames take the group's first white balance, ClassMeans::balance: their
  // reader keeps it too and makes their sums with it, so they are not summed again; checked below.)
  const auto rc = batch::run(items, c, cpu), rd = batch::run(items, d, cpu);
  EXPECT_TRUE(rc.errors.empty() && rd.errors.empty());
  EXPECT_EQ(rd.progress.written, 6u);
  const auto tc = tree_bytes(dir.path() / "c"), td = tree_bytes(dir.path() / "d");
  EXPECT_EQ(tc.size(), 6u * 3);
  ASSERT_EQ(tc.size(), td.size());
  for (const auto& [k, v] : tc) EXPECT_TRUE(td.count(k) && td.at(k) == v) << k << " differs with sequences";

  // PNG only (the reader / compute / writer stages on the CPU): the same files as the workers'.
  auto e = a, f = b;
  e.out = dir.file("e"), f.out = dir.file("f");
  e.format = f.format = "png";
  const auto re = batch::run(items, e, cpu), rf = batch::run(items, f, cpu);
  EXPECT_TRUE(re.errors.empty() && rf.errors.empty());
  const auto te = tree_bytes(dir.path() / "e"), tf = tree_bytes(dir.path() / "f");
  EXPECT_EQ(te.size(), 6u * 2);  // png and the label copy per image
  EXPECT_TRUE(te == tf);
  for (const auto& [k, v] : te) EXPECT_TRUE(ta.count(k) && ta.at(k) == v) << k << " differs from the workers' file";
  // And with sequences (the reader thread keeps the group's balance): the workers' sequence files.
  auto g = e;
  g.out = dir.file("g");
  g.sequences = true;
  EXPECT_TRUE(batch::run(items, g, cpu).errors.empty());
  const auto tg = tree_bytes(dir.path() / "g");
  EXPECT_EQ(tg.size(), 6u * 2);
  for (const auto& [k, v] : tg) EXPECT_TRUE(tc.count(k) && tc.at(k) == v) << k << " differs from the workers' sequence file";

  EXPECT_EQ(detail::glare_full_resolution_level1_count(), full_resolution_level1)
      << "a batch frame's glare made its level 1 from the full-resolution radiance";
  // Every frame's texture took the class sums its reader made with the linearisation, in sequences
  // too (their later frames' sums made with the group's first white balance).
  EXPECT_EQ(scene::texture_own_class_sums_count(), own_class_sums)
      << "a batch frame's texture made its own class sums (the reader's were not handed on)";
  ImageF radiance(160, 80, 3);
  radiance.vec().assign(radiance.size(), 1.f);
  (void)glare_skirt(radiance, plan);
  EXPECT_EQ(detail::glare_full_resolution_level1_count(), full_resolution_level1 + 1);
}

// An interrupted run resumes where it stopped and ends with the bytes of an uninterrupted one;
// temporaries of a dead process are removed (a live process's are kept); other parameters, and
// a file the batch did not write, are refused before anything is written.
TEST(Batch, LibraryResumesRefusesAndCleansUp) {
  test::TempDir dir;
  constexpr size_t kImages = 6;
  make_kitti(dir.path() / "kitti", kImages, 0);
  const std::string root = dir.file("kitti");
  const auto items = batch::discover(batch::Dataset::Kitti, root);
  SensorRunner cpu(Backend::Cpu);
  ASSERT_TRUE(batch::run(items, kitti_options(dir, root, dir.file("ref")), cpu).errors.empty());

  std::atomic<bool> stop{false};
  auto o = kitti_options(dir, root, dir.file("out"));
  o.queue_depth = 1;
  o.stop = &stop;
  // Stop once the first item is written: the reader then reads no further item, so at most the
  // five in flight are finished (being written, in each of the two queues, being computed, and
  // the one the reader holds).
  const auto first = batch::run(items, o, cpu, [&](const batch::Progress& p) {
    if (p.written >= 1) stop = true;
  });
  EXPECT_TRUE(first.interrupted);
  EXPECT_GE(first.progress.written, 1u);
  EXPECT_LE(first.progress.written, 5u);

  const fs::path dead = dir.path() / fmt::format("out/image_2/.000005_10.tmp-{}-999999999-0.exr",
                                                 temporary_pid_scope());  // above pid_max
  const fs::path live =
      dir.path() / fmt::format("out/image_2/.000004_10.tmp-{}-{}-999999.exr", temporary_pid_scope(), getpid());
  std::ofstream(dead) << "half-written";
  std::ofstream(live) << "being written";
  o.stop = nullptr;
  const auto second = batch::run(items, o, cpu);
  EXPECT_TRUE(second.errors.empty());
  EXPECT_FALSE(second.interrupted);
  EXPECT_EQ(second.progress.already_done, first.progress.written);
  EXPECT_EQ(second.progress.written, kImages - first.progress.written);
  EXPECT_FALSE(fs::exists(dead));
  EXPECT_TRUE(fs::exists(live));
  fs::remove(live);
  const auto ref = tree_bytes(dir.path() / "ref"), out = tree_bytes(dir.path() / "out");
  ASSERT_EQ(ref.size(), out.size());
  for (const auto& [k, v] : ref) EXPECT_TRUE(out.count(k) && out.at(k) == v) << k;

  // Finished: nothing to do. Other parameters: refused, nothing changed.
  EXPECT_EQ(batch::run(items, o, cpu).progress.to_do, 0u);
  auto other = o;
  other.sensor.settings.exposure_s = 0.03;
  EXPECT_NE(error_of([&] { batch::run(items, other, cpu); }).find("other parameters"), std::string::npos);
  other = o;
  other.layers = kNightLayers;
  EXPECT_NE(error_of([&] { batch::run(items, other, cpu); }).find("other parameters"), std::string::npos);
  EXPECT_TRUE(tree_bytes(dir.path() / "out") == out);

  // A file the batch did not write, where an output goes: refused, left as it was.
  fs::create_directories(dir.path() / "foreign/image_2");
  std::ofstream(dir.file("foreign/image_2/000003_10.exr")) << "someone else's";
  auto f = kitti_options(dir, root, dir.file("foreign"));
  EXPECT_NE(error_of([&] { batch::run(items, f, cpu); }).find("never overwrites"), std::string::npos);
  EXPECT_EQ(tree_bytes(dir.path() / "foreign").size(), 1u);
}

namespace {
// Two KITTI items run to the end into dir/out: the options, the output tree, and the manifest's
// lines (the parameters, then per item its "writing" and its finished record).
struct FinishedRun {
  std::vector<batch::Item> items;
  batch::Options options;
  std::map<std::string, std::string> out;
  fs::path manifest;
  std::vector<std::string> lines;
};
FinishedRun finished_two_items(const test::TempDir& dir, SensorRunner& cpu) {
  make_kitti(dir.path() / "kitti", 2, 0);
  FinishedRun r;
  r.items = batch::discover(batch::Dataset::Kitti, dir.file("kitti"));
  r.options = kitti_options(dir, dir.file("kitti"), dir.file("out"));
  EXPECT_TRUE(batch::run(r.items, r.options, cpu).errors.empty());
  r.out = tree_bytes(dir.path() / "out");
  r.manifest = dir.path() / "out" / ".photosite-batch" / "shard-0-of-1.jsonl";
  std::ifstream in(r.manifest);
  for (std::string line; std::getline(in, line);) r.lines.push_back(line);
  return r;
}
}  // namespace

// Each written file is recorded with its XXH3-64 checksum; records of earlier runs carry FNV-1a
// 64 under "fnv" and still verify, so their finished items are skipped. A damaged output fails
// either check and its item is done again, back to the same bytes.
TEST(Batch, ChecksumsXxh3AndEarlierFnvRecordsVerify) {
  test::TempDir dir;
  SensorRunner cpu(Backend::Cpu);
  const FinishedRun run = finished_two_items(dir, cpu);
  const auto& [items, o, out, manifest, text] = run;
  std::vector<nlohmann::json> lines;
  for (const auto& t : text) lines.push_back(nlohmann::json::parse(t));
  ASSERT_EQ(lines.size(), 5u);
  size_t recorded = 0;
  std::vector<size_t> finished;
  for (size_t i = 1; i < lines.size(); ++i) {
    if (!lines[i].contains("key")) continue;
    finished.push_back(i);
    for (auto& f : lines[i]["files"]) {
      const std::string path = (dir.path() / "out" / f["path"].get<std::string>()).string();
      ASSERT_EQ(f["xxh3_64"].get<std::string>(), file_checksum_hex(path, ChecksumAlgorithm::Xxh3_64)) << path;
      ASSERT_FALSE(f.contains("fnv"));
      f.erase("xxh3_64");
      f["fnv"] = *file_checksum_hex(path, ChecksumAlgorithm::Fnv1a_64);
      ++recorded;
    }
  }
  ASSERT_EQ(finished.size(), 2u);
  EXPECT_EQ(recorded, 2u * 3u);  // EXR, PNG and the labels' copy per item
  {
    std::ofstream mo(manifest);
    for (const auto& j : lines) mo << j.dump() << "\n";
  }
  auto again = batch::run(items, o, cpu);
  EXPECT_EQ(again.progress.already_done, 2u);
  EXPECT_EQ(again.progress.to_do, 0u);
  // One byte of one PNG changed: that item is redone, and the tree is the first run's again.
  const std::string png = lines[finished[0]]["files"][1]["path"].get<std::string>();
  ASSERT_NE(png.find(".png"), std::string::npos) << png;
  {
    std::fstream f(dir.file("out/" + png), std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(100);
    f.put('\x5a');
  }
  again = batch::run(items, o, cpu);
  EXPECT_EQ(again.progress.already_done, 1u);
  EXPECT_EQ(again.progress.written, 1u);
  EXPECT_TRUE(tree_bytes(dir.path() / "out") == out);
}

// A run killed after publishing an item's first file but before recording the item finished
// leaves that file beside a "writing" record only: the re-run knows it as its own and redoes
// the item (the same bytes). Without the record, the same file is someone else's and refused.
TEST(Batch, KilledWhilePublishingAnItemResumes) {
  test::TempDir dir;
  SensorRunner cpu(Backend::Cpu);
  const FinishedRun run = finished_two_items(dir, cpu);
  const auto& [items, o, out, manifest, lines] = run;
  ASSERT_EQ(lines.size(), 5u);
  // The manifest as the kill left it: the last item's finished record never written.
  ASSERT_NE(lines.back().find("\"key\""), std::string::npos) << lines.back();
  const nlohmann::json last = nlohmann::json::parse(lines.back());
  auto write_manifest = [&](bool with_writing_record) {
    std::ofstream m(manifest);
    for (size_t i = 0; i + 1 < lines.size(); ++i) {
      const nlohmann::json j = nlohmann::json::parse(lines[i]);
      if (!with_writing_record && j.contains("writing") && j["writing"] == last["key"]) continue;
      m << lines[i] << "\n";
    }
  };
  write_manifest(true);
  const auto again = batch::run(items, o, cpu);
  EXPECT_TRUE(again.errors.empty());
  EXPECT_EQ(again.progress.already_done, 1u);
  EXPECT_EQ(again.progress.written, 1u);
  EXPECT_TRUE(tree_bytes(dir.path() / "out") == out);
  write_manifest(false);
  EXPECT_NE(error_of([&] { batch::run(items, o, cpu); }).find("was not written by this batch"), std::string::npos);
}

// A data set reached through a symbolic link is the same data set: writing into its root is
// refused by either name. The compression is checked by name before any work, recorded in the
// header, and integer layers stay exact under a lossy codec (OpenEXR stores UINT losslessly).
TEST(Batch, LinkedDataSetAndCompressionName) {
  test::TempDir dir;
  make_kitti(dir.path() / "kitti", 1, 0);
  fs::create_directory_symlink(dir.path() / "kitti", dir.path() / "link");
  const std::string link = dir.file("link");
  const auto items = batch::discover(batch::Dataset::Kitti, link);
  ASSERT_EQ(items.size(), 1u);
  SensorRunner cpu(Backend::Cpu);
  auto into_root = kitti_options(dir, link, dir.file("kitti"));
  EXPECT_NE(error_of([&] { batch::run(items, into_root, cpu); }).find("data set's own root"), std::string::npos);

  auto bad = kitti_options(dir, link, dir.file("bad"));
  bad.compression = "zip9";
  const std::string msg = error_of([&] { batch::run(items, bad, cpu); });
  EXPECT_NE(msg.find("--compression 'zip9'"), std::string::npos) << msg;
  EXPECT_NE(msg.find("piz"), std::string::npos) << msg;  // lists the names
  EXPECT_FALSE(fs::exists(dir.path() / "bad"));

  std::map<std::string, ExrContents> by_codec;
  for (const char* codec : {"rle", "dwaa"}) {
    auto o = kitti_options(dir, link, dir.file(codec));
    o.format = "exr";
    o.compression = codec;
    o.layers = kNightLayers;
    const auto r = batch::run(items, o, cpu);
    ASSERT_TRUE(r.errors.empty());
    by_codec[codec] = read_exr(dir.file(std::string(codec) + "/image_2/000000_10.exr"));
    EXPECT_EQ(by_codec[codec].attributes["compression"], codec);
    std::ifstream m(dir.file(std::string(codec) + "/.photosite-batch/shard-0-of-1.jsonl"));
    const std::string manifest((std::istreambuf_iterator<char>(m)), {});
    EXPECT_NE(manifest.find(fmt::format("\"compression\":\"{}\"", codec)), std::string::npos) << manifest;
  }
  for (const char* name : {"raw.Y", "electrons.Y", "labels.Y"}) {
    EXPECT_EQ(by_codec["dwaa"].pixel_types.at(name), ExrPixel::Uint) << name;
    EXPECT_TRUE(by_codec["dwaa"].channels.at(name).vec() == by_codec["rle"].channels.at(name).vec()) << name;
  }
}

// Linked files keep the names they are listed or found under (fs::relative resolved the links:
// a linked label's "copy" went outside --out, a linked KITTI image was paired with itself as
// labels, a manifest's outputs took the targets' names), and numbered KITTI frames at the top of
// image_2 form the group "image_2/seq" (was "image_2//seq").
TEST(Batch, LinkedFilesKeepTheirListedNames) {
  test::TempDir dir;
  make_kitti(dir.path() / "real", 1, 0);
  const fs::path ds = dir.path() / "ds";
  fs::create_directories(ds / "image_2");
  fs::create_directories(ds / "semantic");
  fs::create_symlink(dir.path() / "real/image_2/000000_10.png", ds / "image_2/000000_10.png");
  fs::create_symlink(dir.path() / "real/semantic/000000_10.png", ds / "semantic/000000_10.png");
  fs::copy_file(dir.path() / "real/image_2/000000_10.png", ds / "image_2/0000000007.png");
  fs::copy_file(dir.path() / "real/semantic/000000_10.png", ds / "semantic/0000000007.png");
  auto items = batch::discover(batch::Dataset::Kitti, ds.string());
  ASSERT_EQ(items.size(), 2u);
  std::sort(items.begin(), items.end(), [](const auto& a, const auto& b) { return a.key < b.key; });
  EXPECT_EQ(items[0].key, "image_2/0000000007");
  EXPECT_EQ(items[0].group, "image_2/seq");
  EXPECT_EQ(items[1].key, "image_2/000000_10");
  EXPECT_EQ(items[1].labels, (ds / "semantic/000000_10.png").string());
  EXPECT_EQ(items[1].labels_rel, "semantic/000000_10.png");
  SensorRunner cpu(Backend::Cpu);
  auto o = kitti_options(dir, ds.string(), dir.file("out"));
  o.format = "png";
  ASSERT_TRUE(batch::run(items, o, cpu).errors.empty());
  EXPECT_TRUE(fs::is_regular_file(dir.path() / "out/image_2/000000_10.png"));
  EXPECT_TRUE(fs::is_regular_file(dir.path() / "out/semantic/000000_10.png"));
  // A manifest of links: the outputs take the listed names.
  fs::create_symlink(dir.path() / "real/image_2/000000_10.png", dir.path() / "day.png");
  fs::create_symlink(dir.path() / "real/semantic/000000_10.png", dir.path() / "lab.png");
  std::ofstream(dir.file("m.txt")) << "day.png lab.png\n";
  const auto m = batch::read_manifest(dir.file("m.txt"));
  ASSERT_EQ(m.size(), 1u);
  EXPECT_EQ(m[0].key, "day");
  EXPECT_EQ(m[0].labels_rel, "labels/lab.png");
}

// An item's own Cityscapes camera file is a parameter of that item: edited after the item was
// written, the item is redone on the next run (before, "1 already done" kept the output made with
// the old file; an edited --rig file is refused as other parameters).
TEST(Batch, AnItemWhoseCameraFileChangedIsRedone) {
  test::TempDir dir;
  const fs::path root = dir.path() / "cs";
  for (const char* d : {"leftImg8bit/val/city", "gtFine/val/city", "camera/val/city"}) fs::create_directories(root / d);
  make_kitti(dir.path() / "k", 1, 0);
  fs::copy_file(dir.path() / "k/image_2/000000_10.png", root / "leftImg8bit/val/city/city_000000_000019_leftImg8bit.png");
  fs::copy_file(dir.path() / "k/semantic/000000_10.png", root / "gtFine/val/city/city_000000_000019_gtFine_labelIds.png");
  const fs::path cam = root / "camera/val/city/city_000000_000019_camera.json";
  auto write_camera = [&](double pitch) {
    std::ofstream(cam) << fmt::format(R"({{"extrinsic": {{"pitch": {}, "z": 1.2}}, "intrinsic": {{"fx": 200, "fy": 200, "u0": 80, "v0": 40}}}})", pitch);
  };
  write_camera(0.05);
  const auto items = batch::discover(batch::Dataset::Cityscapes, root.string());
  ASSERT_EQ(items.size(), 1u);
  ASSERT_EQ(items[0].camera, cam.string());
  SensorRunner cpu(Backend::Cpu);
  auto o = kitti_options(dir, root.string(), dir.file("out"));
  o.format = "exr";
  o.layers = static_cast<unsigned>(Layer::Depth);
  o.item_cameras = true;
  const std::string exr = dir.file("out/leftImg8bit/val/city/city_000000_000019_leftImg8bit.exr");
  auto pitch = [&] { return read_exr(exr).attributes.at("photosite/night/camera_pitch_deg"); };
  ASSERT_EQ(batch::run(items, o, cpu).progress.written, 1u);
  const std::string before = pitch();
  EXPECT_EQ(batch::run(items, o, cpu).progress.written, 0u);  // unchanged: done
  write_camera(0.03);
  EXPECT_EQ(batch::run(items, o, cpu).progress.written, 1u);  // edited: redone
  EXPECT_NE(pitch(), before);
  EXPECT_EQ(batch::run(items, o, cpu).progress.written, 0u);
}

// Every data set's default camera is a bundled camera preset and its rig a bundled rig (or auto).
TEST(Batch, DatasetCamerasAreBundledPresets) {
  for (auto d : {batch::Dataset::Cityscapes, batch::Dataset::Kitti, batch::Dataset::Bdd100k}) {
    const auto dc = batch::dataset_camera(d);
    EXPECT_EQ(load_camera_preset(dc.camera).name, dc.camera) << batch::to_string(d);
    if (std::string(dc.rig) != "auto") EXPECT_EQ(scene::load_camera_rig(dc.rig).name, dc.rig) << batch::to_string(d);
  }
  EXPECT_STREQ(batch::dataset_camera(batch::Dataset::Kitti).camera, "sony-icx267-flea2");
  EXPECT_STREQ(batch::dataset_camera(batch::Dataset::Cityscapes).rig, "cityscapes");
}

// ---- the exploratory test's findings (docs/robustness.md) -------------------------------------
namespace {
// A small Cityscapes layout: each frame "SPLIT/CITY/CITY_SEQ_FRAME" gets the KITTI generator's
// image and labels as leftImg8bit/...png and gtFine/..._gtFine_labelIds.png.
void make_cityscapes(const fs::path& root, const std::vector<std::string>& frames) {
  const fs::path src = root.parent_path() / (root.filename().string() + "_src");
  make_kitti(src, static_cast<int>(frames.size()), 0);
  for (size_t i = 0; i < frames.size(); ++i) {
    const fs::path f(frames[i]);
    fs::create_directories(root / "leftImg8bit" / f.parent_path());
    fs::create_directories(root / "gtFine" / f.parent_path());
    const std::string k = fmt::format("{:06d}_10.png", i);
    fs::copy_file(src / "image_2" / k, root / "leftImg8bit" / (frames[i] + "_leftImg8bit.png"));
    fs::copy_file(src / "semantic" / k, root / "gtFine" / (frames[i] + "_gtFine_labelIds.png"));
  }
}
std::string slurp_text(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(f)), {});
}
std::vector<std::string> lines_of(const fs::path& p) {
  std::vector<std::string> v;
  std::ifstream f(p);
  for (std::string line; std::getline(f, line);) v.push_back(line);
  return v;
}
}  // namespace

// Temporaries are named after this machine's pid space ('.name.tmp-<scope>-<pid>-<n>.ext'), and
// the start-up sweep removes only those of exactly that pattern, of this scope, whose process is
// gone. Before, it removed any dot-file with ".tmp-" whose pid did not run here: another
// machine's temporaries being written into a shared --out (its rename then failed) and user files.
TEST(Batch, SweepRemovesOnlyThisPidSpacesDeadTemporaries) {
  const std::string scope = temporary_pid_scope();
  ASSERT_EQ(scope.size(), 8u);
  EXPECT_EQ(scope.find_first_not_of("0123456789abcdef"), std::string::npos) << scope;
  test::TempDir dir;
  // The name atomic_write gives its temporary carries the scope and this pid.
  std::string seen;
  atomic_write(dir.file("x.exr"), [&](const std::string& via) {  // via: /proc/self/fd/<fd> of it
    for (const auto& e : fs::directory_iterator(dir.path())) seen = e.path().filename().string();
    std::ofstream(via) << "x";
  });
  EXPECT_EQ(seen.rfind(fmt::format(".x.tmp-{}-{}-", scope, getpid()), 0), 0u) << seen;
  EXPECT_EQ(fs::path(seen).extension(), ".exr");

  make_kitti(dir.path() / "kitti", 1, 0);
  const std::string root = dir.file("kitti");
  const auto items = batch::discover(batch::Dataset::Kitti, root);
  const std::string other = scope == "00000000" ? "00000001" : "00000000";  // another machine's
  fs::create_directories(dir.path() / "out/image_2");
  fs::create_directories(dir.path() / "out/mydocs");
  const std::vector<std::string> kept = {
      fmt::format("out/image_2/.000000_10.tmp-{}-999999999-0.exr", other),  // another machine's, its pid unknown here
      fmt::format("out/image_2/.000000_10.tmp-{}-{}-7.exr", scope, getpid()),  // alive
      "out/mydocs/.report.tmp-draft.txt",  // the user's: not the pattern
      "out/mydocs/.cache.tmp-99999-0.bin",  // the pattern before scopes: not ours to judge
      fmt::format("out/mydocs/notes.tmp-{}-999999999-0.txt", scope),  // no leading dot
  };
  const std::string dead = fmt::format("out/image_2/.000000_10.tmp-{}-999999999-3.exr", scope);  // above pid_max
  for (const auto& f : kept) std::ofstream(dir.file(f)) << "keep";
  std::ofstream(dir.file(dead)) << "half-written";
  EXPECT_TRUE(is_stale_temporary(fs::path(dead).filename().string()));
  for (const auto& f : kept) EXPECT_FALSE(is_stale_temporary(fs::path(f).filename().string())) << f;
  SensorRunner cpu(Backend::Cpu);
  auto o = kitti_options(dir, root, dir.file("out"));
  o.format = "exr";
  ASSERT_TRUE(batch::run(items, o, cpu).errors.empty());
  EXPECT_FALSE(fs::exists(dir.file(dead)));
  for (const auto& f : kept) EXPECT_EQ(slurp_text(dir.file(f)), "keep") << f;
}

// The start of a resume manifest is repaired, not trusted blindly: an empty one (a kill between
// creating it and writing its first record) gets its parameter record; one whose last line was
// cut short gets a newline before the next record. One whose first readable line is not the
// parameters is a damaged manifest, named as such (was: "other parameters", and an empty one
// made every later run refuse the folder).
TEST(Batch, ManifestStartIsRepairedOrReportedDamaged) {
  test::TempDir dir;
  SensorRunner cpu(Backend::Cpu);
  const FinishedRun run = finished_two_items(dir, cpu);
  const auto& [items, o, out, manifest, lines] = run;
  ASSERT_EQ(lines.size(), 5u);

  // Empty: the run writes the parameters first; the next run resumes.
  fs::remove_all(dir.path() / "out");
  fs::create_directories(manifest.parent_path());
  std::ofstream(manifest).close();
  ASSERT_TRUE(batch::run(items, o, cpu).errors.empty());
  EXPECT_EQ(lines_of(manifest).at(0), lines[0]);
  auto again = batch::run(items, o, cpu);
  EXPECT_EQ(again.progress.already_done, 2u);
  EXPECT_TRUE(tree_bytes(dir.path() / "out") == out);

  // The last record cut in half, and one output gone: the redone item's records start on a line
  // of their own, so they parse, and the next run finds every item finished.
  const nlohmann::json cut = nlohmann::json::parse(lines_of(manifest).back());  // a finished record
  ASSERT_TRUE(cut.contains("key")) << cut;
  {
    const std::string text = slurp_text(manifest);
    ASSERT_EQ(text.back(), '\n');
    std::ofstream(manifest, std::ios::binary | std::ios::trunc) << text.substr(0, text.size() - 40);
  }
  fs::remove(dir.path() / "out" / (cut["key"].get<std::string>() + ".exr"));
  again = batch::run(items, o, cpu);
  EXPECT_TRUE(again.errors.empty());
  EXPECT_EQ(again.progress.written, 1u);
  const auto now = lines_of(manifest);
  size_t readable = 0;
  for (const auto& l : now) readable += !nlohmann::json::parse(l, nullptr, false).is_discarded();
  EXPECT_EQ(readable, now.size() - 1) << "only the cut line is unreadable:\n" << slurp_text(manifest);
  EXPECT_EQ(batch::run(items, o, cpu).progress.already_done, 2u);
  EXPECT_TRUE(tree_bytes(dir.path() / "out") == out);

  // The parameter record damaged: named as a damaged manifest, not as other parameters.
  {
    const std::string text = slurp_text(manifest);
    std::ofstream(manifest, std::ios::binary | std::ios::trunc) << "garbage " << text;
  }
  const std::string msg = error_of([&] { batch::run(items, o, cpu); });
  EXPECT_NE(msg.find("shard-0-of-1.jsonl: is a damaged batch manifest"), std::string::npos) << msg;
  EXPECT_EQ(msg.find("other parameters"), std::string::npos) << msg;
}

// A folder under --out that cannot be made (here a file holds its name) fails the items that go
// there, naming the folder, exit 2; the other items are written and no temporary is left. Before,
// create_directories' exception left a worker's or writer's thread: std::terminate, exit 134.
TEST(Batch, FolderThatCannotBeCreatedFailsItsItems) {
  test::TempDir dir;
  make_kitti(dir.path() / "kitti", 2, 2);
  for (const char* format : {"exr", "png"}) {
    const fs::path out = dir.path() / format;
    fs::create_directories(out / "image_2");
    std::ofstream(out / "image_2" / "seq01") << "a file where a folder goes";
    const auto r = test::run_cli("batch --dataset kitti --root '" + dir.file("kitti") + "' --quiet --format " + format +
                                 " --out '" + out.string() + "'");
    EXPECT_EQ(r.exit_code, 2) << format << ": " << r.output;
    EXPECT_NE(r.output.find((out / "image_2" / "seq01").string() + ": cannot create the folder"), std::string::npos)
        << r.output;
    EXPECT_NE(r.output.find("2 of 4 items failed (the others are written"), std::string::npos) << r.output;
    EXPECT_TRUE(fs::exists(out / "image_2" / (std::string("000001_10.") + format))) << format;
    for (const auto& e : fs::recursive_directory_iterator(out))
      EXPECT_EQ(e.path().filename().string().find(".tmp-"), std::string::npos) << e.path();
  }
}

// Cityscapes discovery enters linked folders (a split on another volume, linked in) but not a
// link back up the tree (a cycle), and takes "_leftImg8bit.PNG" as "_leftImg8bit.png". Before,
// both were skipped without a word.
TEST(Batch, DiscoveryFollowsFolderLinksAndAnyCaseOfPng) {
  test::TempDir dir;
  const fs::path root = dir.path() / "cs";
  make_cityscapes(root, {"train/aachen/aachen_000000_000019", "train/aachen/aachen_000001_000019"});
  make_cityscapes(dir.path() / "elsewhere", {"val/lindau/lindau_000000_000019"});
  fs::create_directory_symlink(dir.path() / "elsewhere/leftImg8bit/val", root / "leftImg8bit/val");
  fs::create_directory_symlink(dir.path() / "elsewhere/gtFine/val", root / "gtFine/val");
  fs::create_directory_symlink("../..", root / "leftImg8bit/train/aachen/loop");  // back to leftImg8bit
  fs::rename(root / "leftImg8bit/train/aachen/aachen_000001_000019_leftImg8bit.png",
             root / "leftImg8bit/train/aachen/aachen_000001_000019_leftImg8bit.PNG");
  const auto items = batch::discover(batch::Dataset::Cityscapes, root.string());
  std::set<std::string> keys;
  for (const auto& it : items) keys.insert(it.key);
  EXPECT_EQ(keys, (std::set<std::string>{"leftImg8bit/train/aachen/aachen_000000_000019_leftImg8bit",
                                         "leftImg8bit/train/aachen/aachen_000001_000019_leftImg8bit",
                                         "leftImg8bit/val/lindau/lindau_000000_000019_leftImg8bit"}));
  for (const auto& it : items) EXPECT_TRUE(fs::exists(it.labels)) << it.labels;
  // The layout's error points at the page that describes the layouts.
  fs::create_directories(dir.path() / "empty");
  EXPECT_NE(error_of([&] { batch::discover(batch::Dataset::Cityscapes, dir.file("empty")); }).find("docs/cli.md"),
            std::string::npos);
}

// Every output path of the run comes from one input: two different label files mirrored to one
// copy ("x/lab.png" and "../x/lab.png"), or a PNG preview and a label copy of one name, are
// refused before any work, naming both manifest lines. Before, one item's label copy was the
// other's, and every re-run rewrote it. One label file shared by two images is fine.
TEST(Batch, TwoInputsToOneOutputAreRefused) {
  test::TempDir dir;
  make_kitti(dir.path() / "k", 3, 0);
  const fs::path m = dir.path() / "m";
  for (const char* d : {"m/x", "x", "m/i", "m/labels/x", "m/l"}) fs::create_directories(dir.path() / d);
  auto img = [&](int i) { return dir.path() / "k/image_2" / fmt::format("{:06d}_10.png", i); };
  auto lab = [&](int i) { return dir.path() / "k/semantic" / fmt::format("{:06d}_10.png", i); };
  fs::copy_file(lab(0), m / "x/lab.png");
  fs::copy_file(lab(1), dir.path() / "x/lab.png");
  fs::copy_file(img(0), m / "i/a.png");
  fs::copy_file(img(1), m / "i/b.png");
  fs::copy_file(img(2), m / "labels/x/a.png");
  fs::copy_file(lab(2), m / "l/la.png");
  fs::copy_file(lab(0), m / "x/a.png");
  SensorRunner cpu(Backend::Cpu);
  auto run = [&](const std::string& text, const std::string& format) {
    std::ofstream(m / "m.txt") << text;
    auto o = kitti_options(dir, "", dir.file("out"));
    o.format = format;
    return error_of([&] { batch::run(batch::read_manifest((m / "m.txt").string()), o, cpu); });
  };
  std::string msg = run("i/a.png x/lab.png\ni/b.png ../x/lab.png\n", "exr");
  EXPECT_NE(msg.find("m.txt:2) and labels"), std::string::npos) << msg;
  EXPECT_NE(msg.find("m.txt:1) would both be written to labels/x/lab.png"), std::string::npos) << msg;
  EXPECT_FALSE(fs::exists(dir.path() / "out"));
  // A preview and a label copy: only where previews are written.
  msg = run("labels/x/a.png l/la.png\ni/b.png x/a.png\n", "png");
  EXPECT_NE(msg.find("would both be written to labels/x/a.png"), std::string::npos) << msg;
  EXPECT_FALSE(fs::exists(dir.path() / "out"));
  EXPECT_EQ(run("labels/x/a.png l/la.png\ni/b.png x/a.png\n", "exr"), "");
  fs::remove_all(dir.path() / "out");
  // Two images, one label file: one copy of one file.
  EXPECT_EQ(run("i/a.png x/lab.png\ni/b.png x/lab.png\n", "exr"), "");
  EXPECT_EQ(slurp_text(dir.path() / "out/labels/x/lab.png"), slurp_text(m / "x/lab.png"));
}

// --out inside the data set's image folder: its previews (named like day images) are not found
// as inputs, so the re-run resumes (was: "no labels found" for its own previews). --out being
// the image folder itself is refused before any work.
TEST(Batch, OutputFolderInsideTheDataSetIsNotDiscovered) {
  test::TempDir dir;
  const fs::path root = dir.path() / "cs";
  make_cityscapes(root, {"train/aachen/aachen_000000_000019"});
  const std::string args = "batch --dataset cityscapes --root '" + root.string() + "' --format png --out '" +
                           (root / "leftImg8bit/night").string() + "'";
  auto r = test::run_cli(args + " --quiet");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  ASSERT_TRUE(fs::exists(root / "leftImg8bit/night/leftImg8bit/train/aachen/aachen_000000_000019_leftImg8bit.png"));
  r = test::run_cli(args);
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("1 items in shard 0/1, 1 already done, 0 to do"), std::string::npos) << r.output;
  const std::string msg = error_of([&] {
    batch::discover(batch::Dataset::Cityscapes, root.string(), (root / "leftImg8bit").string());
  });
  EXPECT_NE(msg.find("data set's own image folder"), std::string::npos) << msg;
}

// The refusal of other parameters names the first that differs, with both values. `--root DIR/`
// and `--root ./DIR` are `--root DIR`: the same run (the manifest's source), and the same bytes
// (the EXR header's input paths, lexically normal).
TEST(Batch, OtherParametersAreNamedAndRootSpellingsAgree) {
  test::TempDir dir;
  make_kitti(dir.path() / "kitti", 1, 0);
  const std::string cd = "cd '" + dir.path().string() + "' && '" + PHOTOSITE_BIN + "' ";
  auto sh = [&](const std::string& args) {  // run_cli with the temp folder as the working folder
    test::CliResult r;
    FILE* p = popen((cd + args + " 2>&1").c_str(), "r");
    char buf[4096];
    for (size_t n; (n = fread(buf, 1, sizeof buf, p)) > 0;) r.output.append(buf, n);
    const int st = pclose(p);
    r.exit_code = WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
    return r;
  };
  const std::string common = " --format exr --seed 1 --device-store store";
  auto r = sh("batch --dataset kitti --root kitti --out a" + common);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  r = sh("batch --dataset kitti --root ./kitti/ --out b" + common);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(slurp_text(dir.path() / "a/image_2/000000_10.exr"), slurp_text(dir.path() / "b/image_2/000000_10.exr"));
  r = sh("batch --dataset kitti --root kitti/ --out a" + common);
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("1 already done, 0 to do"), std::string::npos) << r.output;
  r = sh("batch --dataset kitti --root kitti --out a --format exr --seed 2 --device-store store");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("other parameters (shard-0-of-1.jsonl: seed: 1 in the folder, 2 now)"), std::string::npos)
      << r.output;
  // Manifests written with a trailing '/' in the source read as without it.
  EXPECT_EQ(batch::upgrade_params(R"({"source":"kitti /data/kitti/"})"), R"({"source":"kitti /data/kitti"})");
  EXPECT_EQ(batch::upgrade_params(R"({"source":"kitti /"})"), R"({"source":"kitti /"})");
}

// SIGTERM (a scheduler), SIGINT (Ctrl-C) and SIGHUP (a closed terminal) let the items in
// progress finish, then the run exits with 128 + the signal: not 2, which is bad input or
// failed items, so a scheduler knows that running the command again finishes the shard.
TEST(Batch, SignalStopsWithExitStatus128PlusSignal) {
  test::TempDir dir;
  make_kitti(dir.path() / "kitti", 8, 0);
  for (const int sig : {SIGTERM, SIGHUP}) {
    const fs::path out = dir.path() / fmt::format("out{}", sig);
    std::fflush(stdout);
    std::fflush(stderr);
    const pid_t pid = fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
      std::freopen("/dev/null", "w", stdout);
      std::freopen("/dev/null", "w", stderr);
      const std::string root = dir.file("kitti"), o = out.string(), store = dir.file("store");
      execl(PHOTOSITE_BIN, PHOTOSITE_BIN, "batch", "--dataset", "kitti", "--root", root.c_str(), "--out", o.c_str(),
            "--device-store", store.c_str(), "--queue-depth", "1", "--format", "exr", "--quiet",
            static_cast<char*>(nullptr));
      _exit(127);
    }
    // As soon as the first item is recorded finished: 7 are left, one at a time.
    bool recorded = false;
    for (int ms = 0; ms < 300000 && !recorded; ms += 2) {
      recorded = slurp_text(out / ".photosite-batch/shard-0-of-1.jsonl").find("\"key\":") != std::string::npos;
      if (!recorded) usleep(2000);
    }
    ASSERT_TRUE(recorded) << "no item finished within 300 s";
    kill(pid, sig);
    int status = 0;
    ASSERT_EQ(waitpid(pid, &status, 0), pid);
    ASSERT_TRUE(WIFEXITED(status)) << "died of signal " << WTERMSIG(status);
    EXPECT_EQ(WEXITSTATUS(status), 128 + sig);
    const auto r = test::run_cli("batch --dataset kitti --root '" + dir.file("kitti") + "' --out '" + out.string() +
                                 "' --device-store '" + dir.file("store") + "' --format exr");
    EXPECT_EQ(r.exit_code, 0) << r.output;
    EXPECT_EQ(r.output.find("0 to do"), std::string::npos) << "the signal stopped nothing: " << r.output;
  }
}

// An item finished without a camera file is redone once one exists for it, as an item whose
// camera file changed is (before, it stayed "done": a resume differed from a fresh run).
TEST(Batch, AnItemFinishedWithoutACameraFileIsRedoneWhenOneAppears) {
  test::TempDir dir;
  const fs::path root = dir.path() / "cs";
  make_cityscapes(root, {"val/city/city_000000_000019", "val/city/city_000001_000019"});
  fs::create_directories(root / "camera/val/city");
  const std::string camera = R"({"extrinsic": {"pitch": 0.05, "z": 1.2}, "intrinsic": {"fx": 200, "fy": 200, "u0": 80, "v0": 40}})";
  std::ofstream(root / "camera/val/city/city_000000_000019_camera.json") << camera;
  SensorRunner cpu(Backend::Cpu);
  auto o = kitti_options(dir, root.string(), dir.file("out"));
  o.format = "exr";
  o.layers = static_cast<unsigned>(Layer::Depth);
  ASSERT_EQ(batch::run(batch::discover(batch::Dataset::Cityscapes, root.string()), o, cpu).progress.written, 2u);
  std::ofstream(root / "camera/val/city/city_000001_000019_camera.json") << camera;
  const auto items = batch::discover(batch::Dataset::Cityscapes, root.string());
  const auto r = batch::run(items, o, cpu);
  EXPECT_EQ(r.progress.already_done, 1u);
  EXPECT_EQ(r.progress.written, 1u);
  EXPECT_EQ(batch::run(items, o, cpu).progress.written, 0u);
}

// The PNG route writes the preview and the label copies whatever the layer set: `--format png`
// and `--format png --layers sensor,labels` are one run (a manifest of the former, written before
// the record followed the files, resumes too). A manifest with a byte-order mark reads as one
// without; a folder given as the manifest is named as such.
TEST(Batch, PngRouteLayersManifestBomAndFolder) {
  test::TempDir dir;
  make_kitti(dir.path() / "kitti", 1, 0);
  auto o = kitti_options(dir, dir.file("kitti"), dir.file("out"));
  o.format = "png";
  const auto items = batch::discover(batch::Dataset::Kitti, o.root);
  SensorRunner cpu(Backend::Cpu);
  ASSERT_EQ(batch::run(items, o, cpu).progress.written, 1u);
  o.layers = static_cast<unsigned>(Layer::Sensor) | static_cast<unsigned>(Layer::Labels);
  EXPECT_EQ(batch::run(items, o, cpu).progress.already_done, 1u);
  EXPECT_EQ(batch::upgrade_params(R"({"format":"png","layers":"sensor,raw,electrons,depth,labels"})"),
            R"({"format":"png","layers":"sensor,labels"})");
  EXPECT_EQ(batch::upgrade_params(R"({"format":"exr","layers":"raw"})"), R"({"format":"exr","layers":"raw"})");

  std::ofstream(dir.file("bom.txt")) << "\xEF\xBB\xBFkitti/image_2/000000_10.png kitti/semantic/000000_10.png\n";
  const auto m = batch::read_manifest(dir.file("bom.txt"));
  ASSERT_EQ(m.size(), 1u);
  EXPECT_EQ(m[0].image, dir.file("kitti/image_2/000000_10.png"));
  EXPECT_NE(error_of([&] { batch::read_manifest(o.root); }).find("is a folder, not a manifest file"), std::string::npos);
}

// ---- the odometry a sequence's poses come from, in the resume manifest ------------------------
namespace {
// The files (relative paths, manifests aside) whose bytes differ between two output folders, or
// that only one holds, as "a, b, ...".
std::string differing_files(const fs::path& a, const fs::path& b) {
  const auto ta = tree_bytes(a), tb = tree_bytes(b);
  std::string d;
  for (const auto& [rel, bytes] : ta)
    if (!tb.count(rel) || tb.at(rel) != bytes) d += (d.empty() ? "" : ", ") + rel;
  for (const auto& [rel, bytes] : tb)
    if (!ta.count(rel)) d += (d.empty() ? "" : ", ") + rel;
  return d;
}
// `batch --sequence` over a data set with odometry files, in process: each run discovers the
// items afresh (a calibration folder is found by discover) and writes the depth layer only (the
// EXR's header holds the frame's pose).
struct OdometryRuns {
  test::TempDir& dir;
  batch::Dataset dataset;
  std::string root;
  bool item_cameras = true;
  SensorRunner cpu{Backend::Cpu};
  batch::Result run(const std::string& out) {
    auto o = kitti_options(dir, root, out);
    o.format = "exr";
    o.layers = static_cast<unsigned>(Layer::Depth);
    o.sequences = true;
    o.item_cameras = item_cameras;
    return batch::run(batch::discover(dataset, root), o, cpu);
  }
  // The pose the header of `out`/`key`.exr records, as text (17 digits: the doubles).
  static std::string pose(const std::string& out, const std::string& key) {
    const auto a = read_exr_attributes(out + "/" + key + ".exr");
    return a.at("photosite/batch/pose_X_m_text") + " " + a.at("photosite/batch/pose_D_m_text") + " " +
           a.at("photosite/batch/pose_yaw_rad_text");
  }
  // `edit` a source, then re-run into `out`: the whole sequence is redone (frame 0 too: a group
  // with an unfinished frame is redone whole), the poses of frames keys[0..first_changed) stay,
  // those of the later ones change, and the folder holds the bytes of a fresh run into another
  // folder with the edited sources; a re-run then has nothing to do.
  void expect_redone(const std::string& out, const std::vector<std::string>& keys, const std::function<void()>& edit,
                     size_t first_changed, const std::string& fresh) {
    std::vector<std::string> before;
    for (const auto& k : keys) before.push_back(pose(out, k));
    edit();
    const auto r = run(out);
    EXPECT_TRUE(r.errors.empty()) << r.errors.front();
    EXPECT_EQ(r.progress.already_done, 0u);
    EXPECT_EQ(r.progress.written, keys.size());
    for (size_t f = 0; f < keys.size(); ++f) {
      if (f < first_changed) {
        EXPECT_EQ(pose(out, keys[f]), before[f]) << keys[f];
      } else {
        EXPECT_NE(pose(out, keys[f]), before[f]) << keys[f] << ": the same pose after the edit";
      }
    }
    ASSERT_TRUE(run(fresh).errors.empty());
    EXPECT_EQ(differing_files(out, fresh), "") << "a resumed run differs from a fresh one";
    EXPECT_EQ(run(out).progress.written, 0u);
  }
};
// A KITTI raw drive's odometry (for make_kitti's sequence seq01: under oxts/seq01 and
// calib/seq01): frame f's OXTS record in `oxts`/data (vf `speed_m_s`, wu 0.2 rad/s: a left turn,
// so the camera's lever arm moves its pose), and calibration files in `c` placing camera 2
// `forward_m` ahead of the OXTS unit, looking ahead (the chain's rotations the axes'
// permutation: x_cam = (−y, −z, x)).
void write_kitti_oxts(const fs::path& oxts, int f, double speed_m_s) {
  std::string line;
  for (int k = 0; k < 30; ++k)
    line += (k == 8 ? fmt::format("{}", speed_m_s) : k == 22 ? std::string("0.2") : std::string("0")) + (k < 29 ? " " : "\n");
  fs::create_directories(oxts / "data");
  std::ofstream(oxts / "data" / fmt::format("{:010d}.txt", f)) << line;
}
void write_kitti_calib(const fs::path& c, double forward_m) {
  fs::create_directories(c);
  std::ofstream(c / "calib_imu_to_velo.txt") << fmt::format("R: 1 0 0 0 1 0 0 0 1\nT: {} 0 0\n", -forward_m);
  std::ofstream(c / "calib_velo_to_cam.txt") << "R: 0 -1 0 0 0 -1 1 0 0\nT: 0 0 0\n";
  std::ofstream(c / "calib_cam_to_cam.txt") << "R_rect_00: 1 0 0 0 1 0 0 0 1\nP_rect_02: 200 0 80 0 0 200 40 0 0 0 1 0\n";
}
// The resume manifest with `key` taken out of every record: one written before it was kept.
void strip_record_key(const fs::path& out, const char* key) {
  const fs::path m = out / ".photosite-batch/shard-0-of-1.jsonl";
  std::string text;
  for (const auto& line : lines_of(m)) {
    auto j = nlohmann::json::parse(line);
    j.erase(key);
    text += j.dump() + "\n";
  }
  std::ofstream(m, std::ios::binary) << text;
}
}  // namespace

// A KITTI drive's odometry files are what its frames' poses are computed from: each frame's record
// keeps its OXTS file's checksum, its timestamps line and the calibration files' checksums
// (odometry_sources), and an edit of any of them redoes the sequence, whose poses then follow the
// edit. Before, a re-run found every frame "already done" and kept the poses of the old odometry.
// An edit of a timestamps line no frame reads redoes nothing; a manifest written before the
// sources were kept is redone once; a broken OXTS line fails its frame, naming the file, and
// with the line restored the sequence is redone (the frames after it were computed without it).
TEST(Batch, EditedKittiOdometryRedoesItsSequence) {
  test::TempDir dir;
  const fs::path root = dir.path() / "kitti";
  make_kitti(root, 0, 4);
  std::vector<std::string> keys, stamps;
  for (int f = 0; f < 4; ++f) {
    keys.push_back(fmt::format("image_2/seq01/{:010d}", f));
    write_kitti_oxts(root / "oxts/seq01", f, 10);
    stamps.push_back(fmt::format("2011-09-26 13:02:2{}.{}00", f / 2, f % 2 ? 5 : 0));
  }
  auto write_stamps = [&] {
    std::string text;
    for (const auto& s : stamps) text += s + "\n";
    std::ofstream(root / "oxts/seq01/timestamps.txt") << text;
  };
  write_stamps();
  write_kitti_calib(root / "calib/seq01", 1.5);
  OdometryRuns runs{dir, batch::Dataset::Kitti, root.string()};
  const std::string out = dir.file("out");
  auto r = runs.run(out);
  ASSERT_TRUE(r.errors.empty()) << r.errors.front();
  ASSERT_EQ(r.progress.written, 4u);
  r = runs.run(out);  // untouched: nothing redone
  EXPECT_EQ(r.progress.already_done, 4u);
  EXPECT_EQ(r.progress.written, 0u);
  const std::string frame0 = slurp_text(out + "/" + keys[0] + ".exr");
  {
    SCOPED_TRACE("frame 1's OXTS record: vf 10 -> 12 m/s");
    runs.expect_redone(out, keys, [&] { write_kitti_oxts(root / "oxts/seq01", 1, 12); }, 1, dir.file("fresh_oxts"));
    EXPECT_TRUE(slurp_text(out + "/" + keys[0] + ".exr") == frame0) << "frame 0 redone with other bytes";
  }
  {
    SCOPED_TRACE("frame 2's timestamps line: 0.1 s later");
    runs.expect_redone(out, keys, [&] { stamps[2] = "2011-09-26 13:02:21.100"; write_stamps(); }, 2, dir.file("fresh_stamps"));
    EXPECT_TRUE(slurp_text(out + "/" + keys[0] + ".exr") == frame0) << "frame 0 redone with other bytes";
  }
  {
    SCOPED_TRACE("the calibration: camera 2 1.5 -> 0.5 m ahead of the OXTS unit");
    runs.expect_redone(out, keys, [&] { write_kitti_calib(root / "calib/seq01", 0.5); }, 1, dir.file("fresh_calib"));
  }
  // A line no frame reads (the drive's next frame, whose image is not in the data set): the file
  // changed, every frame's own line did not.
  stamps.push_back("2011-09-26 13:02:22.000");
  write_stamps();
  r = runs.run(out);
  EXPECT_EQ(r.progress.already_done, 4u);
  EXPECT_EQ(r.progress.written, 0u);
  // A manifest written before the sources were kept: its frames' poses cannot be checked, so they
  // are redone (to the same bytes), once.
  const auto bytes = tree_bytes(out);
  strip_record_key(out, "odometry_sources");
  r = runs.run(out);
  EXPECT_EQ(r.progress.already_done, 0u);
  EXPECT_EQ(r.progress.written, 4u);
  EXPECT_TRUE(tree_bytes(out) == bytes) << "redone to other bytes";
  EXPECT_EQ(runs.run(out).progress.written, 0u);
  // Frame 1's OXTS record broken: that frame fails naming its file, on this run and the next (its
  // record is not trusted), and no temporary is left.
  std::ofstream(root / "oxts/seq01/data/0000000001.txt") << "10 0.2\n";
  for (int pass = 0; pass < 2; ++pass) {
    r = runs.run(out);
    ASSERT_EQ(r.errors.size(), 1u);
    EXPECT_NE(r.errors[0].find("seq01/data/0000000001.txt: holds 2 numbers"), std::string::npos) << r.errors[0];
    EXPECT_EQ(r.progress.written, 3u);
  }
  for (const auto& e : fs::recursive_directory_iterator(out))
    EXPECT_EQ(e.path().filename().string().find(".tmp-"), std::string::npos) << e.path();
  // The record restored as it was: frame 1's earlier record, which matches it again, no longer
  // stands (frames 2 and 3 were computed without frame 1): the sequence is redone, to the bytes
  // of a fresh run. Before, every frame was "already done" and frames 2 and 3 kept their poses
  // integrated over the gap.
  write_kitti_oxts(root / "oxts/seq01", 1, 12);
  r = runs.run(out);
  EXPECT_TRUE(r.errors.empty()) << r.errors.front();
  EXPECT_EQ(r.progress.written, 4u);
  ASSERT_TRUE(runs.run(dir.file("fresh_restored")).errors.empty());
  EXPECT_EQ(differing_files(out, dir.file("fresh_restored")), "") << "a resumed run differs from a fresh one";
  EXPECT_EQ(runs.run(out).progress.written, 0u);
}

// A frame removed from a KITTI drive (its image, labels and OXTS record: a gap in the numbering,
// as a user who drops a bad frame leaves it): the frames after it integrate their poses over the
// gap now (and carry the sequence's lamps without it), so they are redone, with the sequence
// (frame 0 to its same bytes), to the bytes of a fresh run on the shortened drive. Before, their
// records still matched their files and sources ("sequence_frames_xxh3_64" absent): the re-run
// found frames 0, 2 and 3 done and kept poses integrated through the removed frame. The same for
// a frame put back; a manifest whose records lack the key is redone once; an untouched re-run
// redoes nothing.
TEST(Batch, RemovedKittiFrameRedoesItsSequence) {
  test::TempDir dir;
  const fs::path root = dir.path() / "kitti";
  make_kitti(root, 0, 4);
  std::vector<std::string> keys;
  std::string stamps;
  for (int f = 0; f < 4; ++f) {
    keys.push_back(fmt::format("image_2/seq01/{:010d}", f));
    write_kitti_oxts(root / "oxts/seq01", f, 10);
    stamps += fmt::format("2011-09-26 13:02:2{}.{}00\n", f / 2, f % 2 ? 5 : 0);
  }
  std::ofstream(root / "oxts/seq01/timestamps.txt") << stamps;
  write_kitti_calib(root / "calib/seq01", 1.5);
  OdometryRuns runs{dir, batch::Dataset::Kitti, root.string()};
  const std::string out = dir.file("out");
  ASSERT_TRUE(runs.run(out).errors.empty());
  std::vector<std::string> before;
  for (const auto& k : keys) before.push_back(OdometryRuns::pose(out, k));
  const std::string frame0 = slurp_text(out + "/" + keys[0] + ".exr");
  // Frame 1 taken out of the data set (its files moved aside).
  const fs::path aside = dir.path() / "aside";
  fs::create_directories(aside);
  for (const char* rel : {"image_2/seq01/0000000001.png", "semantic/seq01/0000000001.png", "oxts/seq01/data/0000000001.txt"})
    fs::rename(root / rel, aside / fs::path(rel).filename().string().insert(0, fs::path(rel).begin()->string() + "_"));
  auto r = runs.run(out);
  EXPECT_TRUE(r.errors.empty()) << r.errors.front();
  EXPECT_EQ(r.progress.already_done, 0u);
  EXPECT_EQ(r.progress.written, 3u);
  EXPECT_TRUE(slurp_text(out + "/" + keys[0] + ".exr") == frame0) << "frame 0 redone with other bytes";
  for (const size_t f : {2u, 3u}) EXPECT_NE(OdometryRuns::pose(out, keys[f]), before[f]) << keys[f] << ": the pose through the removed frame";
  ASSERT_TRUE(runs.run(dir.file("fresh_removed")).errors.empty());
  // The removed frame's old output stays in `out` (the run does not delete what the data set no
  // longer lists); every file of the fresh run is the same.
  for (const auto& k : {keys[0], keys[2], keys[3]})
    EXPECT_TRUE(slurp_text(out + "/" + k + ".exr") == slurp_text(dir.file("fresh_removed") + "/" + k + ".exr")) << k;
  r = runs.run(out);
  EXPECT_EQ(r.progress.written, 0u);
  EXPECT_EQ(r.progress.already_done, 3u);
  // Put back: the sequence is redone again, to its first poses.
  for (const char* rel : {"image_2/seq01/0000000001.png", "semantic/seq01/0000000001.png", "oxts/seq01/data/0000000001.txt"})
    fs::rename(aside / fs::path(rel).filename().string().insert(0, fs::path(rel).begin()->string() + "_"), root / rel);
  r = runs.run(out);
  EXPECT_TRUE(r.errors.empty()) << r.errors.front();
  EXPECT_EQ(r.progress.written, 4u);
  for (size_t f = 0; f < keys.size(); ++f) EXPECT_EQ(OdometryRuns::pose(out, keys[f]), before[f]) << keys[f];
  // A manifest written before the key was kept: redone once, to the same bytes.
  const auto bytes = tree_bytes(out);
  strip_record_key(out, "sequence_frames_xxh3_64");
  r = runs.run(out);
  EXPECT_EQ(r.progress.written, 4u);
  EXPECT_TRUE(tree_bytes(out) == bytes) << "redone to other bytes";
  EXPECT_EQ(runs.run(out).progress.written, 0u);
}

// A KITTI drive's timestamps file is read once per run, for the records' lines and the frames'
// poses alike: missing, every frame of the drive fails naming it (on this run and the next: no
// frame is recorded done) and nothing is written; a folder in its place likewise; put back, the
// drive is written whole, to the bytes of a fresh run.
TEST(Batch, UnreadableKittiTimestampsFailEachFrameNamingThem) {
  test::TempDir dir;
  const fs::path root = dir.path() / "kitti";
  make_kitti(root, 0, 3);
  std::string stamps;
  for (int f = 0; f < 3; ++f) {
    write_kitti_oxts(root / "oxts/seq01", f, 10);
    stamps += fmt::format("2011-09-26 13:02:20.{}00\n", 2 * f);
  }
  const fs::path ts = root / "oxts/seq01/timestamps.txt";
  OdometryRuns runs{dir, batch::Dataset::Kitti, root.string()};
  const std::string out = dir.file("out");
  for (const char* how : {"missing", "a folder"}) {
    SCOPED_TRACE(how);
    fs::remove_all(ts);
    if (std::string(how) == "a folder") fs::create_directories(ts);
    for (int pass = 0; pass < 2; ++pass) {
      const auto r = runs.run(out);
      ASSERT_EQ(r.errors.size(), 3u);
      for (const auto& e : r.errors) {
        EXPECT_NE(e.find(ts.string() + ": "), std::string::npos) << e;
        EXPECT_NE(e.find(std::string(how) == "missing" ? "no such file" : "is a folder"), std::string::npos) << e;
      }
      EXPECT_EQ(r.progress.written, 0u);
      EXPECT_EQ(r.progress.already_done, 0u);
    }
    for (const auto& e : fs::recursive_directory_iterator(out))
      EXPECT_NE(e.path().extension(), ".exr") << e.path();
  }
  fs::remove_all(ts);
  std::ofstream(ts) << stamps;
  const auto r = runs.run(out);
  EXPECT_TRUE(r.errors.empty()) << r.errors.front();
  EXPECT_EQ(r.progress.written, 3u);
  ASSERT_TRUE(runs.run(dir.file("fresh")).errors.empty());
  EXPECT_EQ(differing_files(out, dir.file("fresh")), "") << "a resumed run differs from a fresh one";
  EXPECT_EQ(runs.run(out).progress.written, 0u);
}

// The same for a Cityscapes sequence: its frames' vehicle JSON, timestamp and camera files (the
// camera's place on the vehicle, read with --rig too, where the camera file's own checksum is not
// recorded as the item's rig).
TEST(Batch, EditedCityscapesOdometryRedoesItsSequence) {
  test::TempDir dir;
  const fs::path root = dir.path() / "cs";
  const std::vector<std::string> stems = {"city_000000_000018", "city_000000_000019"};
  make_cityscapes(root, {"val/city/" + stems[0], "val/city/" + stems[1]});
  for (const char* d : {"camera/val/city", "vehicle/val/city", "timestamp/val/city"}) fs::create_directories(root / d);
  auto write_vehicle = [&](int f, double speed_m_s) {
    std::ofstream(root / "vehicle/val/city" / (stems[f] + "_vehicle.json"))
        << fmt::format(R"({{"speed": {}, "yawRate": 0.1}})", speed_m_s);
  };
  auto write_camera = [&](int f, double yaw_rad) {
    std::ofstream(root / "camera/val/city" / (stems[f] + "_camera.json")) << fmt::format(
        R"({{"extrinsic": {{"pitch": 0.05, "x": 1.7, "y": 0.1, "yaw": {}, "z": 1.2}}, "intrinsic": {{"fx": 200, "fy": 200, "u0": 80, "v0": 40}}}})",
        yaw_rad);
  };
  std::vector<std::string> keys;
  for (int f = 0; f < 2; ++f) {
    keys.push_back("leftImg8bit/val/city/" + stems[f] + "_leftImg8bit");
    write_vehicle(f, 12);
    write_camera(f, -0.02);
    std::ofstream(root / "timestamp/val/city" / (stems[f] + "_timestamp.txt")) << f * 58823529 << "\n";  // 1/17 s apart
  }
  OdometryRuns runs{dir, batch::Dataset::Cityscapes, root.string()};
  runs.item_cameras = false;  // as with --rig: the camera files give the camera's place only
  const std::string out = dir.file("out");
  auto r = runs.run(out);
  ASSERT_TRUE(r.errors.empty()) << r.errors.front();
  ASSERT_EQ(r.progress.written, 2u);
  EXPECT_EQ(runs.run(out).progress.written, 0u);
  {
    SCOPED_TRACE("frame 19's vehicle file: 12 -> 15 m/s");
    runs.expect_redone(out, keys, [&] { write_vehicle(1, 15); }, 1, dir.file("fresh_vehicle"));
  }
  {
    SCOPED_TRACE("frame 19's timestamp: 1/17 -> 1/10 s");
    runs.expect_redone(
        out, keys, [&] { std::ofstream(root / "timestamp/val/city" / (stems[1] + "_timestamp.txt")) << "100000000\n"; }, 1,
        dir.file("fresh_timestamp"));
  }
  {
    SCOPED_TRACE("frame 19's camera file: turned 0.02 rad further left on the vehicle");
    runs.expect_redone(out, keys, [&] { write_camera(1, 0.0); }, 1, dir.file("fresh_camera"));
  }
  // A manifest written before the sources were kept is redone once.
  strip_record_key(out, "odometry_sources");
  r = runs.run(out);
  EXPECT_EQ(r.progress.written, 2u);
  EXPECT_EQ(runs.run(out).progress.written, 0u);
}

// A KITTI raw download as it ships (DATE/DATE_drive_NNNN_sync/image_02/data/*.png, its oxts/
// folder, DATE/calib_*.txt) is read through folder links into batch's layout, as docs/cli.md
// tells: image_2/DRIVE and oxts/DRIVE link to the drive's folders, calib/DRIVE to the date's,
// semantic/DRIVE holds the labels (KITTI raw has none). The frames get the poses, from the same
// odometry and calibration, of the same drive copied into the layout.
TEST(Batch, KittiRawDriveIsReadThroughFolderLinks) {
  test::TempDir dir;
  const fs::path copy = dir.path() / "copy";
  make_kitti(copy, 0, 3);
  const fs::path date = dir.path() / "raw/2011_09_26", drive = date / "2011_09_26_drive_0001_sync";
  fs::create_directories(drive / "image_02/data");
  std::string stamps;
  for (int f = 0; f < 3; ++f) {
    const std::string name = fmt::format("{:010d}", f);
    write_kitti_oxts(copy / "oxts/seq01", f, 8 + f);
    write_kitti_oxts(drive / "oxts", f, 8 + f);
    fs::copy_file(copy / "image_2/seq01" / (name + ".png"), drive / "image_02/data" / (name + ".png"));
    stamps += fmt::format("2011-09-26 13:02:2{}.000000000\n", f);
  }
  std::ofstream(copy / "oxts/seq01/timestamps.txt") << stamps;
  std::ofstream(drive / "oxts/timestamps.txt") << stamps;
  write_kitti_calib(copy / "calib/seq01", 1.2);
  write_kitti_calib(date, 1.2);
  const fs::path linked = dir.path() / "linked";
  for (const char* d : {"image_2", "oxts", "calib"}) fs::create_directories(linked / d);
  fs::create_symlink(drive / "image_02/data", linked / "image_2/2011_09_26_drive_0001");
  fs::create_symlink(drive / "oxts", linked / "oxts/2011_09_26_drive_0001");
  fs::create_symlink(date, linked / "calib/2011_09_26_drive_0001");
  fs::create_directories(linked / "semantic");
  fs::copy(copy / "semantic/seq01", linked / "semantic/2011_09_26_drive_0001");
  const auto items = batch::discover(batch::Dataset::Kitti, linked.string());
  ASSERT_EQ(items.size(), 3u);
  EXPECT_EQ(items[2].key, "image_2/2011_09_26_drive_0001/0000000002");
  EXPECT_EQ(items[2].odometry_calib, (linked / "calib/2011_09_26_drive_0001").string());
  OdometryRuns from_copy{dir, batch::Dataset::Kitti, copy.string()}, from_links{dir, batch::Dataset::Kitti, linked.string()};
  ASSERT_TRUE(from_copy.run(dir.file("out_copy")).errors.empty());
  const auto r = from_links.run(dir.file("out_linked"));
  ASSERT_TRUE(r.errors.empty()) << r.errors.front();
  EXPECT_EQ(r.progress.written, 3u);
  for (int f = 1; f < 3; ++f)
    EXPECT_EQ(OdometryRuns::pose(dir.file("out_linked"), fmt::format("image_2/2011_09_26_drive_0001/{:010d}", f)),
              OdometryRuns::pose(dir.file("out_copy"), fmt::format("image_2/seq01/{:010d}", f)));
  const auto a = read_exr_attributes(dir.file("out_linked/image_2/2011_09_26_drive_0001/0000000002.exr"));
  EXPECT_NE(a.at("photosite/batch/camera_mount").find("KITTI calibration"), std::string::npos);
  EXPECT_EQ(std::stod(a.at("photosite/batch/camera_forward_m_text")), 1.2);
}
