// `photosite night` / `photosite demo` contracts, and every shared Cityscapes and KITTI sample.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <tuple>

#include "photosite/io.h"
#include "photosite/scene/night.h"
#include "photosite/sensor/spectrum.h"
#include "test_util.h"

using namespace photosite;
using namespace photosite::scene;
namespace fs = std::filesystem;

TEST(SceneNightCli, BundledSampleWritesEveryLayerAndHeader) {
  test::TempDir d;
  const std::string store = "--device-store '" + d.file("store") + "'";
  auto r = test::run_cli("night --out '" + d.file("n.exr") + "' --preview '" + d.file("n.png") +
                         "' --timings " + store);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("lights"), std::string::npos) << r.output;  // the timing table
  const ExrContents e = read_exr(d.file("n.exr"));
  for (const char* ch : {"raw.Y", "R", "G", "B", "electrons.Y", "night_radiance.R", "night_radiance.G",
                         "night_radiance.B", "depth.Z", "lights.R", "lights.G", "lights.B", "labels.Y"})
    EXPECT_EQ(e.channels.count(ch), 1u) << ch;
  for (const char* at : {"photosite/night/vanishing_point_x", "photosite/night/vanishing_point_y",
                         "photosite/night/vanishing_point_confidence",
                         "photosite/night/vanishing_point_method", "photosite/scene/ambient.moon_lux",
                         "photosite/scene/reflectance.road", "photosite/preset",
                         "photosite/scene/reflectance.day_white_balance", "photosite/night/day_white_balance_gain_R",
                         "photosite/night/day_white_balance_road_cct_K"})
    EXPECT_EQ(e.attributes.count(at), 1u) << at;
  // The bundled frame's road is large enough and near daylight: its cast is taken out.
  EXPECT_EQ(e.attributes.at("photosite/night/day_white_balance"), "road");
  EXPECT_EQ(e.width, 1224);
  EXPECT_EQ(e.height, 370);
  EXPECT_TRUE(fs::exists(d.file("n.png")));
  // The road is lit by lamp pools (scene/street.cpp), which the light map carries; the luminaires'
  // intensity holds the preset's EN 13201 class (M3, L_M = 1.00 cd/m²) on the design layout, and
  // the header reports this scene's own calculation field: L_avg > 0 and U0 = L_min/L_avg in (0, 1].
  const ScenePreset sp = load_scene_preset("night-urban");
  EXPECT_DOUBLE_EQ(sp.street_road_luminance_cd_m2, 1.0);  // EN 13201-2 M3
  EXPECT_GT(std::stod(e.attributes.at("photosite/night/road_luminance_avg_cd_m2")), 0.0);
  const double u0 = std::stod(e.attributes.at("photosite/night/road_uniformity_u0"));
  EXPECT_GT(u0, 0.0);
  EXPECT_LE(u0, 1.0);
  EXPECT_GT(std::stoi(e.attributes.at("photosite/night/street_lamps")), 0);
  // The bundled KITTI frame's near tram track is taken out of the markings (drop_tram_rails).
  EXPECT_GT(std::stoi(e.attributes.at("photosite/night/tram_rail_pixels")), 0);
  // Its crowns against the sky show the sky between their leaves: the scene took those pixels for
  // sky (take_sky_gaps), and labels.Y still holds the file's ids there, as everywhere.
  EXPECT_GT(std::stoi(e.attributes.at("photosite/night/sky_gap_pixels")), 0);
  // The levels they were read against: the leaves darker than the threshold, 0.6 of the sky's.
  const double sky_y = std::stod(e.attributes.at("photosite/night/sky_day_luminance"));
  const double leaf_y = std::stod(e.attributes.at("photosite/night/leaf_day_luminance"));
  EXPECT_GT(leaf_y, 0.0);
  EXPECT_LT(leaf_y, 0.6 * sky_y);
  EXPECT_LE(sky_y, 1.0);
  const LabelMap file = read_labels(PHOTOSITE_SOURCE_DIR "/samples/kitti/semantic/000000_10.png", "", e.width, e.height,
                                    LabelFormat::Auto, ResizeLabels::None);
  const ImageF& labels_y = e.channels.at("labels.Y");
  size_t not_the_files = 0;
  for (size_t i = 0; i < labels_y.pixel_count(); ++i) not_the_files += labels_y[i] != file.ids[i];
  EXPECT_EQ(not_the_files, 0u);
  // Its walls, vegetation, fences and cars hide the low beam's lamps from each other below the
  // cut-off's top (docs/night.md §6c): the header counts those vertical-surface pixels.
  int vertical_shaded = 0;
  for (const char* k : {"left", "right", "both"})
    vertical_shaded += std::stoi(e.attributes.at(std::string("photosite/night/beam_shadow_vertical_") + k + "_pixels"));
  EXPECT_GT(vertical_shaded, 0);
  // night_radiance − lights is the darkened scene plus the low beam's diffuse reflection
  // (scene/lights.cpp compose). Its road-class mean luminance is Σ_s Σ_k K_k t_s,k f̄_k E_s / π over
  // the sources s (moon, sky glow, beam) with the class-mean luminance factor Σ K_k f̄_k = ρ,
  // so it lies between Σ_s min_k t_s,k L_s and Σ_s max_k t_s,k L_s with L_s = ρ E_s / π
  // (E_beam ≥ 0 for the lower bound; for the upper, E = Σ_lamps I·cos θ/d² = Σ I·sin³|v|/h_l² on
  // the road, v the lamp's vertical angle: between table rows v_i < v_i+1 < 0, I ≤ the larger
  // row maximum and sin³|v| ≤ sin³|v_i|, 0 below the table); t_s is source s's tint
  // (illuminant_tint).
  double beam_bound_lux = 0;
  const size_t nh = sp.beam_h_deg.size();
  for (size_t i = 0; i + 1 < sp.beam_v_deg.size() && sp.beam_v_deg[i] < 0; ++i) {
    const double I = *std::max_element(sp.beam_intensity_cd.begin() + i * nh, sp.beam_intensity_cd.begin() + (i + 2) * nh);
    beam_bound_lux = std::max(beam_bound_lux, 2 * I * std::pow(std::sin(-sp.beam_v_deg[i] * M_PI / 180), 3) /
                                                  (sp.beam_lamp_height_m * sp.beam_lamp_height_m));
  }
  double lower = 0, upper = 0;
  const std::pair<double, double> sources[] = {{sp.moon_cct_K, sp.rho_road * sp.moon_lux / M_PI},
                                               {sp.skyglow_cct_K, sp.rho_road * sp.skyglow_lux / M_PI},
                                               {sp.beam_cct_K, sp.rho_road * beam_bound_lux / M_PI}};
  for (int i = 0; i < 3; ++i) {
    const auto t = illuminant_tint(sources[i].first);
    if (i < 2) lower += *std::min_element(t.begin(), t.end()) * sources[i].second;  // the beam may be 0
    upper += *std::max_element(t.begin(), t.end()) * sources[i].second;
  }
  const ImageF& lab = e.channels.at("labels.Y");
  // Rounding: the radiance is compose's float sum (the darkened colour, the beam and the light map:
  // at most 3 roundings of values no larger than the radiance, 2⁻²⁴ each) of a darkened colour made
  // by at most 4 float products (reflectance, illuminance/π, tint), and the light map's subtraction
  // here rounds once more (at most 2⁻²⁴ of the difference), so each band of c is within
  // 2⁻²⁴·(7|radiance| + |c|) of the lights-free radiance; the luminance weighs the bands
  // positively, so the mean is within the mean of that weighted bound (computed here), and the
  // double sums add n·2⁻⁵³ relative.
  double sum = 0, n = 0, err = 0;
  for (size_t i = 0; i < lab.pixel_count(); ++i)
    if (lab[i] == 7) {
      float c[3], bound[3];
      int k = 0;
      for (const char* ch : {"R", "G", "B"}) {
        const float rad = e.channels.at(std::string("night_radiance.") + ch)[i];
        c[k] = rad - e.channels.at(std::string("lights.") + ch)[i];
        bound[k] = static_cast<float>(0x1p-24 * (7 * std::fabs(rad) + std::fabs(c[k])));
        ++k;
      }
      sum += spectrum::luminance_cd_m2(c);
      err += spectrum::luminance_cd_m2(bound);
      ++n;
    }
  ASSERT_GT(n, 1000);
  const double tol = err / n + n * 0x1p-53 * sum / n;
  std::fprintf(stderr, "[night] road luminance %.3f cd/m² (bounds %.3f..%.3f, rounding %.2g)\n", sum / n, lower, upper, tol);
  EXPECT_GE(sum / n, lower - tol);
  EXPECT_LE(sum / n, upper + tol);
  // Same seed and scene: identical radiance (lights included) on a second run.
  auto r2 = test::run_cli("night --out '" + d.file("m.exr") + "' " + store);
  ASSERT_EQ(r2.exit_code, 0) << r2.output;
  EXPECT_EQ(read_exr(d.file("m.exr")).channels.at("lights.R").vec(), e.channels.at("lights.R").vec());
  // demo runs on the same sample.
  auto r3 = test::run_cli("demo --out '" + d.file("demo.exr") + "' --preview '' " );
  EXPECT_EQ(r3.exit_code, 0) << r3.output;
}

TEST(SceneNightCli, BadInputsExitTwoNamingTheFileAndLeaveNoOutput) {
  test::TempDir d;
  const std::string src = std::string(PHOTOSITE_SOURCE_DIR) + "/samples/kitti/";
  // Labels of another size than the image.
  ImageF small(10, 10, 1, 7.f / 255.f);
  write_png(d.file("small_labels.png"), small);
  auto r = test::run_cli("night --image '" + src + "image_2/000000_10.png' --labels '" +
                         d.file("small_labels.png") + "' --out '" + d.file("x.exr") + "'");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("small_labels.png"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("--resize-labels"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(d.file("x.exr")));
  r = test::run_cli("night --image '" + src + "image_2/000000_10.png' --labels '" +
                    d.file("small_labels.png") + "' --resize-labels nearest --out '" + d.file("y.exr") +
                    "' --device-store '" + d.file("store") + "'");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(fs::exists(d.file("y.exr")));
  r = test::run_cli("night --image '" + src + "image_2/000000_10.png' --out '" + d.file("x.exr") + "'");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  r = test::run_cli("night --out '" + d.file("x.exr") + "' --scene-preset nope");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_FALSE(fs::exists(d.file("x.exr")));
  r = test::run_cli("night --out '" + d.file("x.exr") + "' --ambient-lux -3");
  EXPECT_EQ(r.exit_code, 2) << r.output;
}

namespace {
void check_scene(const std::string& name, const ImageF& day, const LabelMap& lm) {
  SCOPED_TRACE(name);
  const ScenePreset p = load_scene_preset("night-urban");
  const NightScene n = night_scene(day, lm, p, 1);
  for (size_t i = 0; i < n.radiance.size(); ++i)
    ASSERT_TRUE(std::isfinite(n.radiance[i]) && n.radiance[i] >= 0);
  // Road scenes from a car: the vanishing point lies inside the image, in its middle band.
  EXPECT_GE(n.vp.x, 0);
  EXPECT_LT(n.vp.x, day.width());
  EXPECT_GT(n.vp.y, 0.2 * day.height());
  EXPECT_LT(n.vp.y, 0.75 * day.height());
  std::fprintf(stderr, "%s: VP (%.0f, %.0f) %s conf %.2f, lamps %d, windows %d\n", name.c_str(), n.vp.x,
               n.vp.y, vp_method_name(n.vp.method), n.vp.confidence, n.light_stats.vehicle_lamps,
               n.light_stats.windows);
}
}  // namespace

TEST(SceneSharedData, EveryCityscapesSample) {
  PHOTOSITE_REQUIRE_SHARED("data/cityscapes");
  const fs::path dir = test::shared_dir() / "data/cityscapes";
  int runs = 0;
  for (const auto& e : fs::directory_iterator(dir / "leftImg8bit")) {
    const std::string stem = e.path().filename().string();
    const std::string base = stem.substr(0, stem.find("_leftImg8bit"));
    const fs::path lab = dir / "gtFine" / (base + "_gtFine_labelIds.png");
    const fs::path inst = dir / "gtFine" / (base + "_gtFine_instanceIds.png");
    const fs::path col = dir / "gtFine" / (base + "_gtFine_color.png");
    if (!fs::exists(lab)) continue;
    ImageFileInfo info;
    const ImageF day = linearize(read_image(e.path().string(), &info), info);
    const LabelMap lm = read_labels(lab.string(), fs::exists(inst) ? inst.string() : "", day.width(),
                                    day.height(), LabelFormat::Auto, ResizeLabels::None);
    check_scene(base, day, lm);
    if (fs::exists(col)) {  // the palette file decodes to the same ids (black void classes → 0)
      const LabelMap pc = read_labels(col.string(), "", day.width(), day.height(), LabelFormat::Auto,
                                      ResizeLabels::None);
      EXPECT_EQ(pc.format, LabelFormat::Palette);
      size_t same = 0;
      for (size_t i = 0; i < pc.ids.pixel_count(); ++i)
        same += pc.ids[i] == lm.ids[i] || (lm.ids[i] <= 4 && pc.ids[i] == 0) ||
                (lm.ids[i] == 18 && pc.ids[i] == 17);
      EXPECT_EQ(same, pc.ids.pixel_count());
    }
    ++runs;
  }
  EXPECT_GT(runs, 0);
}

TEST(SceneSharedData, EveryKittiSample) {
  PHOTOSITE_REQUIRE_SHARED("data/kitti");
  const fs::path dir = test::shared_dir() / "data/kitti";
  int runs = 0;
  for (const auto& e : fs::directory_iterator(dir / "image_2")) {
    const fs::path lab = dir / "semantic" / e.path().filename();
    if (!fs::exists(lab)) continue;
    ImageFileInfo info;
    const ImageF day = linearize(read_image(e.path().string(), &info), info);
    const ImageU16 crop = test::kitti_labels_in_frame(read_image_u16(lab.string()), day.width(), day.height());
    check_scene(e.path().filename().string(), day, decode_labels(crop, LabelFormat::Auto, lab.string()));
    ++runs;
  }
  EXPECT_GT(runs, 0);
}

TEST(SceneNightCli, FramesKeepTheirLightsAndVaryTheNoise) {
  test::TempDir d;
  auto r = test::run_cli("night --out '" + d.file("f_#.exr") + "' --frames 2 --device-store '" +
                         d.file("store") + "'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const ExrContents a = read_exr(d.file("f_0.exr")), b = read_exr(d.file("f_1.exr"));
  EXPECT_EQ(a.channels.at("lights.G").vec(), b.channels.at("lights.G").vec());
  EXPECT_EQ(a.channels.at("night_radiance.G").vec(), b.channels.at("night_radiance.G").vec());
  EXPECT_NE(a.channels.at("raw.Y").vec(), b.channels.at("raw.Y").vec());  // temporal noise
  EXPECT_EQ(a.attributes.at("photosite/fpn_checksum"), b.attributes.at("photosite/fpn_checksum"));
}

// The light map's AVX2 paths (street-light pools and vertical surfaces in float, 8 lanes, and the
// vertical surfaces' candidate test; the façade windows' geometry in double, 4 lanes; the ego low
// beam) against their scalar twins, which do the same IEEE operations in the same order:
// PHOTOSITE_SCALAR_LIGHTS=1 (environment.h) forces the scalar paths in a child process, and every
// EXR channel of the bundled frame's night must be the same bits. (On a machine without AVX2 both
// runs take the scalar path and the test still checks determinism.)
TEST(SceneNightCli, ScalarAndAvx2LightPathsGiveTheSameBits) {
  test::TempDir tmp;
  const auto a = test::run_cli("night --backend cpu --out '" + tmp.file("v.exr") + "'");
  ASSERT_EQ(a.exit_code, 0) << a.output;
  setenv("PHOTOSITE_SCALAR_LIGHTS", "1", 1);
  const auto b = test::run_cli("night --backend cpu --out '" + tmp.file("s.exr") + "'");
  unsetenv("PHOTOSITE_SCALAR_LIGHTS");
  ASSERT_EQ(b.exit_code, 0) << b.output;
  const ExrContents v = read_exr(tmp.file("v.exr")), s = read_exr(tmp.file("s.exr"));
  ASSERT_EQ(v.channels.size(), s.channels.size());
  double lights = 0;
  for (const auto& [name, im] : v.channels) {
    const ImageF& other = s.channels.at(name);
    ASSERT_EQ(im.size(), other.size()) << name;
    EXPECT_EQ(0, std::memcmp(im.data(), other.data(), im.size() * sizeof(float))) << name;
    if (name.rfind("lights.", 0) == 0)
      for (size_t i = 0; i < im.size(); ++i) lights += im[i];
  }
  EXPECT_GT(lights, 0.0);  // the frame has lights to compare
  // and lit façade windows (the windows' twins were compared on them), as many on both paths
  EXPECT_GT(std::stoi(v.attributes.at("photosite/night/lights_windows")), 0);
  EXPECT_EQ(v.attributes.at("photosite/night/lights_windows"), s.attributes.at("photosite/night/lights_windows"));
}

// PHOTOSITE_MAX_ISA (environment.h, core/isa_detail.h) caps the vector level the CPU paths take:
// `version --backends` names the level taken, and the bundled frame's night, every EXR channel and
// attribute but the time of writing, is the same bits at each level this machine has — the rule that every path gives the
// same bits, end to end (the target_clones functions keep the CPU's own level, isa_detail.h). A
// value not among scalar, avx2 and avx512 is bad input: exit 2 naming the variable, no output.
TEST(SceneNightCli, EveryIsaCapGivesTheSameNight) {
  test::TempDir tmp;
  auto with_cap = [&](const char* cap, const std::string& args) {
    setenv("PHOTOSITE_MAX_ISA", cap, 1);
    auto r = test::run_cli(args);
    unsetenv("PHOTOSITE_MAX_ISA");
    return r;
  };
  const auto machine = test::run_cli("version --backends");
  ASSERT_EQ(machine.exit_code, 0) << machine.output;
  const bool avx2 = machine.output.find(", AVX2") != std::string::npos;
  const bool avx512 = machine.output.find(", AVX-512") != std::string::npos;
  const auto v0 = with_cap("scalar", "version --backends"), v1 = with_cap("avx2", "version --backends");
  ASSERT_EQ(v0.exit_code, 0) << v0.output;
  EXPECT_EQ(v0.output.find(", AVX2"), std::string::npos) << v0.output;
  EXPECT_EQ(v1.output.find(", AVX-512"), std::string::npos) << v1.output;
  EXPECT_EQ(v1.output.find(", AVX2") != std::string::npos, avx2) << v1.output;
  const auto bad = with_cap("avx1024", "night --backend cpu --out '" + tmp.file("bad.exr") + "'");
  EXPECT_EQ(bad.exit_code, 2) << bad.output;
  EXPECT_NE(bad.output.find("PHOTOSITE_MAX_ISA='avx1024'"), std::string::npos) << bad.output;
  EXPECT_FALSE(fs::exists(tmp.file("bad.exr")));
  std::vector<std::pair<std::string, ExrContents>> nights;
  for (const char* cap : {"avx512", "avx2", "scalar"}) {
    if ((std::string(cap) == "avx512" && !avx512) || (std::string(cap) == "avx2" && !avx2)) continue;
    const std::string out = tmp.file(std::string(cap) + ".exr");
    const auto r = with_cap(cap, "night --backend cpu --out '" + out + "'");
    ASSERT_EQ(r.exit_code, 0) << cap << ": " << r.output;
    nights.emplace_back(cap, read_exr(out));
  }
  const ExrContents& ref = nights.front().second;
  for (size_t k = 1; k < nights.size(); ++k) {
    const auto& [cap, other] = nights[k];
    ASSERT_EQ(other.channels.size(), ref.channels.size()) << cap;
    for (const auto& [name, im] : ref.channels) {
      const ImageF& o = other.channels.at(name);
      ASSERT_EQ(o.size(), im.size()) << cap << " " << name;
      EXPECT_EQ(0, std::memcmp(o.data(), im.data(), im.size() * sizeof(float))) << cap << " against " << nights.front().first << ": " << name;
    }
    auto a = other.attributes, b = ref.attributes;
    a.erase("DateTime");  // the time of writing (`cmp -i 48` skips it in the file)
    b.erase("DateTime");
    EXPECT_EQ(a, b) << cap;
  }
}

// The light map's fast paths pinned to their definition at one and two threads: a shared
// Cityscapes frame (façades, poles, parked and moving vehicles) cut to 2043 columns, not a
// multiple of 8, so the AVX2 rows of the vertical street light (groups of eight columns) end in
// columns that go the scalar way, as do the pools' and windows' last groups. The light map of the
// AVX2 paths at 1 and 2 OpenMP threads and of the scalar twins (PHOTOSITE_SCALAR_LIGHTS=1) at 1
// and 2 threads must be the same bits (each pixel's sums are its own: neither the path nor the
// thread count may change them).
TEST(SceneNightCli, LightMapFastPathsEqualScalarAtOneAndTwoThreads) {
  PHOTOSITE_REQUIRE_SHARED("data/cityscapes");
  const fs::path dir = test::shared_dir() / "data/cityscapes";
  const std::string base = "aachen_000000_000019";
  test::TempDir tmp;
  const int Wc = 2043;
  {
    const ImageF day = read_image((dir / "leftImg8bit" / (base + "_leftImg8bit.png")).string());
    const ImageU16 lab = read_image_u16((dir / "gtFine" / (base + "_gtFine_labelIds.png")).string());
    ASSERT_GT(day.width(), Wc);
    ImageU8 d8(Wc, day.height(), 3), l8(Wc, day.height(), 1);
    for (int y = 0; y < day.height(); ++y)
      for (int x = 0; x < Wc; ++x) {
        for (int k = 0; k < 3; ++k) d8.at(x, y, k) = static_cast<uint8_t>(std::lround(255 * day.at(x, y, k)));
        l8.at(x, y) = static_cast<uint8_t>(lab.at(x, y));
      }
    write_png8(tmp.file("day.png"), d8);
    write_png8(tmp.file("labels.png"), l8);
  }
  auto run = [&](const std::string& name, const char* threads, bool scalar) {
    setenv("OMP_NUM_THREADS", threads, 1);
    if (scalar) setenv("PHOTOSITE_SCALAR_LIGHTS", "1", 1);
    const auto r = test::run_cli("night --backend cpu --layers lights --compression none --image '" +
                                 tmp.file("day.png") + "' --labels '" + tmp.file("labels.png") + "' --out '" +
                                 tmp.file(name) + "' --device-store '" + tmp.file("store") + "'");
    unsetenv("PHOTOSITE_SCALAR_LIGHTS");
    unsetenv("OMP_NUM_THREADS");
    EXPECT_EQ(r.exit_code, 0) << r.output;
    return read_exr(tmp.file(name));
  };
  const ExrContents ref = run("s1.exr", "1", true);
  ASSERT_EQ(ref.width, Wc);
  double lights = 0;
  for (const char* ch : {"lights.R", "lights.G", "lights.B"}) {
    const ImageF& im = ref.channels.at(ch);
    for (size_t i = 0; i < im.size(); ++i) lights += im[i];
  }
  EXPECT_GT(lights, 0.0);
  EXPECT_GT(std::stoi(ref.attributes.at("photosite/night/lights_windows")), 0);
  for (const auto& [name, threads, scalar] :
       {std::tuple{"s2.exr", "2", true}, std::tuple{"v1.exr", "1", false}, std::tuple{"v2.exr", "2", false}}) {
    const ExrContents other = run(name, threads, scalar);
    for (const char* ch : {"lights.R", "lights.G", "lights.B"}) {
      const ImageF &a = ref.channels.at(ch), &b = other.channels.at(ch);
      ASSERT_EQ(a.size(), b.size()) << name << " " << ch;
      size_t differ = 0;
      for (size_t i = 0; i < a.size(); ++i) differ += std::memcmp(&a[i], &b[i], sizeof(float)) != 0;
      EXPECT_EQ(differ, 0u) << name << " " << ch << ": samples differing from the scalar path at 1 thread";
    }
    EXPECT_EQ(ref.attributes.at("photosite/night/lights_windows"), other.attributes.at("photosite/night/lights_windows"));
  }
}

// The chain's two-thread sections (night_scene's side_by_side pairs: edges, lines, depth) ask
// OpenMP for a team of two; where the team has one thread (OMP_THREAD_LIMIT=1 with
// OMP_NUM_THREADS=2, or OMP_DYNAMIC under load) its caller must run both halves. `night` on a
// shared Cityscapes frame (its instance ids too) so: every channel of every layer and every header
// attribute but the time of writing the same as at OMP_NUM_THREADS=1. (Before the caller ran both,
// the second half never ran there and the run crashed.)
TEST(SceneNightCli, AOneThreadTeamRunsBothHalvesOfEachPair) {
  PHOTOSITE_REQUIRE_SHARED("data/cityscapes");
  const fs::path dir = test::shared_dir() / "data/cityscapes";
  const std::string base = "aachen_000000_000019";
  test::TempDir tmp;
  auto run = [&](const std::string& name, const char* threads, const char* limit) {
    setenv("OMP_NUM_THREADS", threads, 1);
    if (limit) setenv("OMP_THREAD_LIMIT", limit, 1);
    const auto r = test::run_cli("night --backend cpu --compression none --image '" +
                                 (dir / "leftImg8bit" / (base + "_leftImg8bit.png")).string() + "' --labels '" +
                                 (dir / "gtFine" / (base + "_gtFine_labelIds.png")).string() + "' --instances '" +
                                 (dir / "gtFine" / (base + "_gtFine_instanceIds.png")).string() + "' --out '" +
                                 tmp.file(name) + "' --device-store '" + tmp.file("store") + "'");
    unsetenv("OMP_THREAD_LIMIT");
    unsetenv("OMP_NUM_THREADS");
    EXPECT_EQ(r.exit_code, 0) << r.output;
    return r.exit_code == 0 ? read_exr(tmp.file(name)) : ExrContents{};
  };
  const ExrContents one = run("one.exr", "1", nullptr);
  const ExrContents limited = run("limited.exr", "2", "1");
  ASSERT_GT(one.channels.size(), 10u);
  ASSERT_EQ(limited.channels.size(), one.channels.size());
  for (const auto& [ch, a] : one.channels) {
    const ImageF& b = limited.channels.at(ch);
    ASSERT_EQ(a.size(), b.size()) << ch;
    EXPECT_EQ(0, std::memcmp(a.data(), b.data(), a.size() * sizeof(float))) << ch;
  }
  std::map<std::string, std::string> x = one.attributes, y = limited.attributes;
  x.erase("DateTime");
  y.erase("DateTime");
  EXPECT_EQ(x, y);
}

// A long lens within the rig schema's range (fx_px 1e6: a 0.1° field of view) on a Cityscapes frame:
// the low beam's shadow maps span the frame's directions widened by the lamps' parallax at 2 m, some
// 10^5 × 10^5 cells of 2 px at that focal length, and `night` stopped "out of memory" (exit 1, the
// rig-corner runs of docs/robustness.md). The maps' cells are now bounded (scene/lights.cpp
// beam_shadow_cell, the cell widened): the run completes and writes its EXR.
TEST(SceneNightCli, ALongLensRigBoundsTheBeamShadowMaps) {
  PHOTOSITE_REQUIRE_SHARED("data/cityscapes");
  const fs::path dir = test::shared_dir() / "data/cityscapes";
  const std::string base = "aachen_000000_000019";
  test::TempDir tmp;
  {
    std::ofstream rig(tmp.file("rig.toml"));
    rig << "native_width_px = 2048\nnative_height_px = 1024\nfx_px = 1e6\ncx_px = 1096\ncy_px = 513\n"
           "mount_height_m = 0.1\npitch_deg = 0\n";
  }
  const auto r = test::run_cli("night --backend cpu --layers radiance --image '" +
                               (dir / "leftImg8bit" / (base + "_leftImg8bit.png")).string() + "' --labels '" +
                               (dir / "gtFine" / (base + "_gtFine_labelIds.png")).string() + "' --rig '" +
                               tmp.file("rig.toml") + "' --out '" + tmp.file("o.exr") + "' --device-store '" +
                               tmp.file("store") + "'");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(fs::exists(tmp.file("o.exr"))) << r.output;
}
