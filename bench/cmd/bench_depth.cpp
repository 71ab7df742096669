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
//
// `--synthetic`: the same errors on streets rendered from a known camera (make_synthetic_camera_scene),
// where the truth is exact, to measure the horizon's own error: straight and curving streets
// (radius ±60 to ±400 m from 60 m ahead of the street's origin), the camera 40 m before the bend
// to 25 m into it, its pitch the rig's nominal and 0.5 and 1.0 degrees above and below it (a
// loaded or braking car, within the rig's 1.6 degree tolerance: scene/rig.cpp). Each case runs
// night_scene as `photosite night` does; its horizon (the vanishing point's, or the rig's) is
// compared with the renderer's, and the road and contact depth errors are taken for it and for
// the rig's nominal horizon alone. Writes docs/bench_depth_synthetic.csv (one row per case).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include <fmt/format.h>

#include "bench.h"
#include "photosite/error.h"
#include "photosite/io.h"
#include "photosite/scene/depth_eval.h"
#include "photosite/scene/road_line.h"
#include "photosite/scene/night.h"
#include "photosite/scene/rig.h"
#include "photosite/scene/scene_preset.h"

namespace photosite::bench {
namespace {
namespace fs = std::filesystem;

struct DepthBench {
  std::string kitti, out_dir, scene_preset = "night-urban";
  int max_frames = 0;
  bool synthetic = false;
};

// The ground point at arc length a_m along a synthetic street's centre line and offset e_m across
// it (+ toward +X where it is straight), in the street's (X, D): the inverse of
// synthetic_street_coordinates. Straight up to Dc, then the circle of radius |R| turning toward
// sign(R)·X, centred at (R, Dc): a point at offset e lies |R| − sign(R)·e from the centre.
void street_point(double R, double Dc, double a_m, double e_m, double* X, double* D) {
  if (R == 0 || a_m <= Dc) {
    *X = e_m;
    *D = a_m;
    return;
  }
  const double rho = std::fabs(R), sg = R > 0 ? 1.0 : -1.0, th = (a_m - Dc) / rho, dist = rho - sg * e_m;
  *X = sg * rho - sg * dist * std::cos(th);
  *D = Dc + dist * std::sin(th);
}

void run_synthetic(const DepthBench& b) {
  scene::ScenePreset sp = scene::load_scene_preset(b.scene_preset);
  sp.rig = scene::load_camera_rig("cityscapes");
  constexpr double kCurveStart_m = 60;
  const scene::SyntheticCameraOptions street;  // the renderer's frame size
  // The rig's nominal geometry at that size: each case's true camera is it pitched by the offset,
  // and its horizon is the "rig's horizon alone" column.
  const scene::CameraGeometry rig_g = scene::camera_geometry(sp.rig, street.width, street.height, scene::VanishingPoint{});
  const std::vector<double> radii{0, 400, -400, 200, -200, 100, -100, 60, -60};
  const std::vector<double> positions{-40, -20, -10, 0, 10, 25};  // the camera's arc length − kCurveStart_m
  const std::vector<double> offsets{0, 0.5, -0.5, 1.0, -1.0};       // true pitch − the rig's nominal, degrees
  std::string csv =
      "radius_m,camera_from_bend_m,pitch_offset_deg,lines,vp_method,vp_confidence,horizon_source,horizon_error_px,"
      "horizon_error_deg,road_ahead,road_pixels,road_median_rel,road_p90_rel,contacts,contact_median_rel,"
      "rig_road_median_rel,rig_contact_median_rel,true_road_median_rel\n";
  struct Row { double R, rel, off; bool vp, curved; double err_px, road, rig_road; };
  std::vector<Row> rows;
  int cases = 0;
  for (const double R : radii)
    for (const double rel : positions)
      for (const double off : offsets) {
        if (b.max_frames > 0 && cases >= b.max_frames) break;
        ++cases;
        scene::SyntheticCameraOptions o = street;
        o.camera = rig_g;
        o.camera.pitch_rad += off * M_PI / 180;
        o.camera.horizon_y = o.camera.cy_px - o.camera.f_px * std::tan(o.camera.pitch_rad);
        o.road_radius_m = R;
        o.curve_start_D_m = kCurveStart_m;
        o.window_pitch_m = 2.5;  // windows in the façades' texture: their rows are lines too
        const double a = kCurveStart_m + rel;
        double X, D, Xa, Da;
        street_point(R, kCurveStart_m, a, 0, &X, &D);
        street_point(R, kCurveStart_m, a + 1, 0, &Xa, &Da);
        o.world_X_m = X;
        o.world_D_m = D;
        o.world_yaw_rad = std::atan2(Xa - X, Da - D);  // along the centre line
        // Two cars ahead in the lanes, each along its lane (turned by the street's heading at its
        // front face: on a bend the cars follow the road, as cars do).
        for (const auto& [ahead, e] : {std::pair{15.0, 1.75}, std::pair{28.0, -1.75}}) {
          street_point(R, kCurveStart_m, a + ahead, e, &X, &D);
          street_point(R, kCurveStart_m, a + ahead + 1, e, &Xa, &Da);
          scene::SyntheticBox car{X, D, 1.8, 1.5, 4.5};
          car.yaw_rad = std::atan2(Xa - X, Da - D);
          o.boxes.push_back(car);
        }
        const scene::SyntheticCameraScene sc = scene::make_synthetic_camera_scene(o);
        const scene::NightScene ns = scene::night_scene(sc.day_linear_srgb, sc.labels, sp, 0);
        const scene::CameraGeometry& g = ns.geometry;
        const double err_px = g.horizon_y - o.camera.horizon_y;
        const double err_deg = (g.pitch_rad - o.camera.pitch_rad) * 180 / M_PI;
        const auto e = scene::depth_errors(ns.depth, sc.depth_m, sc.labels, sp.max_depth_m);
        // The rig's nominal horizon alone, and the renderer's own (the evaluation's check: its
        // ground depth is the rendered one up to rounding).
        const auto er = scene::depth_errors(scene::metric_depth(sc.labels, rig_g, sp.max_depth_m), sc.depth_m, sc.labels, sp.max_depth_m);
        const auto et = scene::depth_errors(scene::metric_depth(sc.labels, o.camera, sp.max_depth_m), sc.depth_m, sc.labels, sp.max_depth_m);
        const scene::RoadAhead ra = scene::measure_road_ahead(sc.labels.ids, g);
        csv += fmt::format("{},{},{},{},{},{:.2f},{},{:.2f},{:.3f},{},{},{:.5f},{:.5f},{},{:.5f},{:.5f},{:.5f},{:.7f}\n", R, rel,
                           off, ns.lines_work.size(), scene::vp_method_name(ns.vp.method), ns.vp.confidence,
                           g.horizon_source, err_px, err_deg, ra.state.substr(0, ra.state.find(':')), e.road_pixels,
                           e.road_median_rel, e.road_p90_rel, e.contacts, e.contact_median_rel, er.road_median_rel,
                           er.contact_median_rel, et.road_median_rel);
        rows.push_back({R, rel, off, g.horizon_source == "vanishing_point", ra.curved, err_px, e.road_median_rel, er.road_median_rel});
      }
  // The summary: per |radius|, the camera before the bend (its view holding the bend's start) or
  // on it (on the straight street: the same positions, 20-50 and 60-85 m from its origin), the share of cases whose vanishing point is taken, the median and largest |horizon
  // error| of those, and the median road depth error as run and with the rig's horizon alone.
  std::printf("horizon and road depth on rendered streets (rig %s, %dx%d; %d cases)\n", sp.rig.name.c_str(),
              street.width, street.height, cases);
  std::printf("  %-9s %-12s %6s %10s %14s %14s %14s %14s %14s\n", "|radius|", "camera", "cases", "vp taken", "vp |err| med",
              "vp |err| max", "road err run", "road err rig", "curved: rig");
  for (const double absR : {0.0, 400.0, 200.0, 100.0, 60.0})
    for (const int on : {0, 1}) {
      std::vector<double> err, run, rig, pol;
      int n = 0, taken = 0;
      for (const Row& r : rows) {
        if (std::fabs(r.R) != absR || (r.rel >= 0) != (on == 1)) continue;
        ++n;
        run.push_back(r.road);
        rig.push_back(r.rig_road);
        pol.push_back(r.vp && r.curved ? r.rig_road : r.road);
        if (r.vp) {
          ++taken;
          err.push_back(std::fabs(r.err_px));
        }
      }
      if (n == 0) continue;
      const double mx = err.empty() ? NAN : *std::max_element(err.begin(), err.end());
      std::printf("  %-9s %-12s %6d %9.0f%% %11.2f px %11.2f px %13.1f%% %13.1f%% %13.1f%%\n",
                  absR == 0 ? "straight" : fmt::format("{:.0f} m", absR).c_str(),
                  absR == 0 ? (on ? "at 60-85 m" : "at 20-50 m") : (on ? "on the bend" : "before it"), n,
                  100.0 * taken / n, scene::nearest_rank_quantile(err, 0.5), mx, 100 * scene::nearest_rank_quantile(run, 0.5),
                  100 * scene::nearest_rank_quantile(rig, 0.5), 100 * scene::nearest_rank_quantile(pol, 0.5));
    }
  write_bench_csv(b.out_dir, "bench_depth_synthetic.csv", csv);
}

void run(const DepthBench& b) {
  if (b.synthetic) {
    if (!b.kitti.empty()) fail("--synthetic and --kitti: give one (the rendered streets, or KITTI's stereo frames)");
    run_synthetic(b);
    return;
  }
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

static BenchRegistrar reg("depth", "depth.Z against KITTI stereo 2015 disparity, or on rendered streets (--synthetic): road and vehicle-contact errors",
                          [](CLI::App* sub) {
                            auto b = std::make_shared<DepthBench>();
                            sub->add_option("--kitti", b->kitti,
                                            "folder with image_2/, semantic/ (instance/), disp_occ_0/ and "
                                            "calib_cam_to_cam/ (KITTI semantics + stereo 2015 training)");
                            sub->add_flag("--synthetic", b->synthetic,
                                          "instead: streets rendered from a known camera, straight and curving, the "
                                          "camera's pitch off the rig's by up to 1 degree (the horizon's error; "
                                          "docs/bench_depth_synthetic.csv)");
                            sub->add_option("--max-frames", b->max_frames, "frames (0: all; with --synthetic, the first N cases)")->capture_default_str();
                            sub->add_option("--scene-preset", b->scene_preset, "scene preset")->capture_default_str();
                            sub->add_option("--out-dir", b->out_dir, "where the CSV goes (default docs/)");
                            sub->callback([b] { run(*b); });
                          });
}  // namespace
}  // namespace photosite::bench
