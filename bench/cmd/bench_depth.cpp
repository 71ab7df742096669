// `photosite bench depth`: depth.Z against KITTI stereo ground truth (issue 14 §1: median
// relative error <= 10% on the road, <= 15% at vehicle ground contacts). KITTI's semantic
// benchmark frames are the stereo 2015 training frames, so a folder holding both downloads
// pairs them by name:
//   ROOT/image_2/<frame>_10.png        (data_semantics or data_scene_flow)
//   ROOT/semantic/<frame>_10.png       (+ instance/, data_semantics)
//   ROOT/disp_occ_0/<frame>_10.png     (data_scene_flow; disp_noc_0/ when disp_occ_0/ is absent)
//   ROOT/calib_cam_to_cam/<frame>.txt  (data_scene_flow_calib; without it: the kitti rig's fx
//                                       and the 0.54 m baseline of Geiger et al., IJRR 2013)
// photosite ships none of these (the disparity maps are not in ../shared). Each frame runs the
// whole night scene as `photosite night --rig auto` does and compares its depth.Z. Writes
// docs/bench_depth.csv (one row per frame and a pooled row).
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "bench.h"
#include "photosite/error.h"
#include "photosite/io.h"
#include "photosite/scene/depth_eval.h"
#include "photosite/scene/night.h"
#include "photosite/scene/rig.h"
#include "photosite/scene/scene_preset.h"

namespace photosite::bench {
namespace {
namespace fs = std::filesystem;

struct DepthBench {
  std::string kitti, out_dir, scene_preset = "night-urban";
  int max_frames = 0;
};

void run(const DepthBench& b) {
  if (b.kitti.empty()) fail("--kitti: give the folder holding image_2/, semantic/ and disp_occ_0/ (see `photosite bench depth --help`)");
  const fs::path root(b.kitti);
  for (const char* sub : {"image_2", "semantic"})
    if (!fs::is_directory(root / sub)) fail_at((root / sub).string(), "not a folder (KITTI semantics: image_2/ and semantic/)");
  const fs::path disp = fs::is_directory(root / "disp_occ_0") ? root / "disp_occ_0" : root / "disp_noc_0";
  if (!fs::is_directory(disp))
    fail_at((root / "disp_occ_0").string(), "not a folder: the stereo ground truth (KITTI stereo 2015, data_scene_flow) is needed");
  std::vector<fs::path> frames;
  for (const auto& e : fs::directory_iterator(disp))
    if (e.path().extension() == ".png" && fs::exists(root / "image_2" / e.path().filename()) &&
        fs::exists(root / "semantic" / e.path().filename()))
      frames.push_back(e.path().filename());
  std::sort(frames.begin(), frames.end());
  if (b.max_frames > 0 && static_cast<int>(frames.size()) > b.max_frames) frames.resize(b.max_frames);
  if (frames.empty()) fail_at(disp.string(), "no frame has an image_2/ image, semantic/ labels and a disparity map of one name");

  const scene::ScenePreset base = scene::load_scene_preset(b.scene_preset);
  std::string csv = "frame,width,height,horizon_source,calibration,road_pixels,road_median_rel,road_p90_rel,contacts,contact_median_rel\n";
  std::vector<double> road_medians, contacts;
  size_t road_pixels = 0;  // over every frame: the pooled row's road_pixels
  std::printf("depth.Z against KITTI stereo ground truth (%s), %zu frames\n", disp.c_str(), frames.size());
  std::printf("  %-14s %-16s %9s %12s %10s %9s %12s\n", "frame", "horizon", "road px", "road median", "road p90",
              "vehicles", "contact med");
  for (const auto& f : frames) {
    ImageFileInfo info;
    const ImageF day = read_image((root / "image_2" / f).string(), &info);
    const fs::path inst = root / "instance" / f;
    const auto labels = scene::read_labels((root / "semantic" / f).string(), fs::exists(inst) ? inst.string() : "",
                                           day.width(), day.height(), scene::LabelFormat::Auto, scene::ResizeLabels::None);
    scene::ScenePreset sp = base;
    sp.rig = scene::resolve_camera_rig("auto", day.width(), day.height());
    const auto ns = scene::night_scene(scene::linearize(day, info), labels, sp, 0);
    const std::string stem = f.stem().string();
    const fs::path calib = root / "calib_cam_to_cam" / (stem.substr(0, stem.find('_')) + ".txt");
    scene::StereoCalibration c;
    std::string calib_name;
    if (fs::exists(calib)) {
      c = scene::read_kitti_stereo_calibration(calib.string());
      calib_name = "calib_cam_to_cam";
    } else {
      c.fx_px = ns.geometry.f_px;  // the rig's, at this image size
      c.baseline_m = 0.54;         // Geiger et al., IJRR 2013, Fig. 3 (colour cameras 0.54 m apart)
      calib_name = "rig fx; baseline 0.54 m";
    }
    ImageFileInfo dinfo;
    const ImageU16 codes = read_image_u16((disp / f).string(), &dinfo);
    // KITTI's disparity maps are 16-bit PNG holding disparity × 256 (0: no measurement). An 8-bit map
    // (the disparity saved in whole pixels, or a picture of it) read as codes / 256 gave depths
    // of kilometres: no road pixel was measured, and the bench printed nan% with exit 0.
    if (dinfo.bits_per_sample != 16)
      fail_at((disp / f).string(), fmt::format("disparity map has {}-bit samples; KITTI's are 16-bit PNG holding the "
                                              "disparity × 256 (0: no measurement)", dinfo.bits_per_sample));
    if (codes.width() != day.width() || codes.height() != day.height() || codes.channels() != 1)
      fail_at((disp / f).string(), fmt::format("disparity map is {}x{}x{}, the image {}x{}: expected one channel of the image's size",
                                              codes.width(), codes.height(), codes.channels(), day.width(), day.height()));
    const ImageF truth = scene::depth_from_kitti_disparity(codes, c);
    const auto e = scene::depth_errors(ns.depth, truth, labels, sp.max_depth_m);
    if (e.road_pixels) road_medians.push_back(e.road_median_rel);
    road_pixels += e.road_pixels;
    contacts.insert(contacts.end(), e.contact_rel.begin(), e.contact_rel.end());
    if (e.road_pixels == 0 && e.contacts == 0)
      std::printf("  %-14s %-16s no road pixel or vehicle contact with a ground-truth disparity (nothing measured)\n",
                  stem.c_str(), ns.geometry.horizon_source.c_str());
    else
      std::printf("  %-14s %-16s %9zu %11.1f%% %9.1f%% %9zu %11.1f%%\n", stem.c_str(), ns.geometry.horizon_source.c_str(),
                  e.road_pixels, 100 * e.road_median_rel, 100 * e.road_p90_rel, e.contacts, 100 * e.contact_median_rel);
    csv += fmt::format("{},{},{},{},{},{},{:.5f},{:.5f},{},{:.5f}\n", stem, day.width(), day.height(),
                       ns.geometry.horizon_source, calib_name, e.road_pixels, e.road_median_rel, e.road_p90_rel,
                       e.contacts, e.contact_median_rel);
  }
  const double road = scene::nearest_rank_quantile(road_medians, 0.5),
               contact = scene::nearest_rank_quantile(contacts, 0.5);
  if (road_medians.empty() && contacts.empty())
    std::printf("  pooled: nothing measured: no frame has a road pixel or a vehicle contact with a ground-truth "
                "disparity (the CSV's medians are nan)\n");
  else
    std::printf("  pooled: road %.1f%% (median of the frames' medians; target <= 10%%), vehicle contacts %.1f%% "
                "(median over %zu vehicles; target <= 15%%)\n", 100 * road, 100 * contact, contacts.size());
  // Each column means what it means in the frames' rows: road_pixels and contacts summed over the
  // frames, the medians pooled as printed above.
  csv += fmt::format("all,,,,,{},{:.5f},,{},{:.5f}\n", road_pixels, road, contacts.size(), contact);
  write_bench_csv(b.out_dir, "bench_depth.csv", csv);
}

static BenchRegistrar reg("depth", "depth.Z against KITTI stereo 2015 disparity (road and vehicle-contact errors)",
                          [](CLI::App* sub) {
                            auto b = std::make_shared<DepthBench>();
                            sub->add_option("--kitti", b->kitti,
                                            "folder with image_2/, semantic/ (instance/), disp_occ_0/ and "
                                            "calib_cam_to_cam/ (KITTI semantics + stereo 2015 training)")
                                ->required();
                            sub->add_option("--max-frames", b->max_frames, "frames (0: all)")->capture_default_str();
                            sub->add_option("--scene-preset", b->scene_preset, "scene preset")->capture_default_str();
                            sub->add_option("--out-dir", b->out_dir, "where the CSV goes (default docs/)");
                            sub->callback([b] { run(*b); });
                          });
}  // namespace
}  // namespace photosite::bench
