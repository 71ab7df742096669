// `photosite bench markings`: metric depth on real frames, measured by the road's dashed markings
// (issue 14 §1; scene/depth_eval.cpp, "Dashed markings as rulers"). KITTI's stereo ground truth
// is not in ../shared; the dashes are. Along one dashed line every period (a dash's start to the
// next one's) is the same length on the road, so with the right horizon the periods measured
// through photosite's depth do not change with distance, and where the pattern is a standard one
// their length is the standard's. Each shared frame runs the night scene as `photosite night
// --rig auto` does (its horizon: the vanishing point's or the rig's nominal pitch); its lane
// markings are found at full resolution (metric_marking_mask: the lane detector's filter at a
// metric line width), cut into dashes and chained into lines. Per line: the periods at photosite's horizon and at the
// rig's nominal one, their slope against distance, the horizon shift that flattens them, and the
// standard pattern they match. Writes docs/bench_markings.csv.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
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

struct MarkingsBench {
  std::string shared = std::string(PHOTOSITE_SOURCE_DIR) + "/../shared";
  std::string out_dir, scene_preset = "night-urban";
  std::string image, labels, instances, rig = "auto";  // one frame of the user's instead of the shared ones
  std::string resize_labels = "none";                   // with --image: labels of another size, as `night`
  int max_frames = 0;
};

// Every period of the line, near to far, in metres; an irregular one (left out of the
// statistics) in parentheses.
std::string periods_list(const scene::DashedLine& L) {
  std::string s;
  for (size_t i = 0; i < L.periods_m.size(); ++i)
    s += (i ? " " : "") + (L.regular[i] ? fmt::format("{:.2f}", L.periods_m[i]) : fmt::format("({:.2f})", L.periods_m[i]));
  return s;
}
// The distances the periods are measured at, in the same order.
std::string distances_list(const scene::DashedLine& L) {
  std::string s;
  for (size_t i = 0; i < L.at_D_m.size(); ++i) s += fmt::format("{}{:.2f}", i ? " " : "", L.at_D_m[i]);
  return s;
}
// The period's change per 10 m of distance, in % of the mean period.
double trend_pct(const scene::DashedLine& L) { return 100 * 10 * L.slope / L.period_mean_m; }

void run(const MarkingsBench& b) {
  // One frame of the user's (a rig preset checked on its own camera's frames), else the shared ones.
  if (b.image.empty() != b.labels.empty())
    fail(b.image.empty() ? "--labels: give the frame too (--image)" : "--image: give its labels too (--labels)");
  if (b.image.empty() && (!b.instances.empty() || b.rig != "auto" || b.resize_labels != "none"))
    fail("--instances, --rig and --resize-labels go with --image (the shared frames take their own cameras' rigs)");
  // One frame of the user's wrote its lines over docs/bench_markings.csv (and left the shared
  // frames' chart beside it): the default folder holds the bench's recorded results.
  if (!b.image.empty() && b.out_dir.empty())
    fail("--out-dir: give the folder for the CSV of your frame (the default, docs/, holds the shared frames' results, "
         "which it would replace)");
  scene::ResizeLabels resize = scene::ResizeLabels::None;
  if (b.resize_labels == "nearest") resize = scene::ResizeLabels::Nearest;
  else if (b.resize_labels != "none") fail("--resize-labels: '" + b.resize_labels + "' is not none or nearest");
  std::vector<SharedFrame> frames;
  if (!b.image.empty()) {
    for (const std::string* f : {&b.image, &b.labels, &b.instances})
      if (!f->empty() && !fs::is_regular_file(*f)) fail_at(*f, "bench markings: not a file");
    frames.push_back({"user", fs::path(b.image).stem().string(), b.image, b.labels, b.instances, ""});
  } else {
    frames = shared_frames(fs::path(b.shared) / "data", b.max_frames, "bench markings");
  }
  const scene::ScenePreset base = scene::load_scene_preset(b.scene_preset);
  std::string csv =
      "frame,horizon_source,horizon_y,line,dashes,regular_periods,X_m,D_from_m,D_to_m,period_median_m,period_sd_m,"
      "dash_median_m,dash_painted_m,reach_rows,trend_pct_per_10m,trend_se_pct_per_10m,flat_shift_px,flat_shift_se_px,standard,"
      "period_over_standard,rig_horizon_y,rig_period_median_m,rig_trend_pct_per_10m,periods_m,periods_at_D_m,"
      "rig_periods_m,rig_periods_at_D_m,standard_period_m\n";
  std::printf("depth on the road measured by its dashed markings (%zu frames)\n", frames.size());
  std::printf("  %-22s %-8s %5s %6s %11s %8s %12s %13s %12s %9s %s\n", "frame", "horizon", "dashes", "X m", "D m",
              "period", "dash (mask)", "trend %/10m", "flat shift", "rig: per.", "standard (period / standard)");
  int n_lines = 0;
  std::vector<double> matched;  // period over the standard's, of the lines that match one
  for (const SharedFrame& f : frames) {
    ImageFileInfo info;
    const ImageF day = read_image(f.image, &info);
    if (day.channels() != 3) fail_at(f.image, "bench markings: an RGB day photo is needed (the markings' luminance)");
    const auto labels = scene::read_labels(f.labels, f.instances, day.width(), day.height(), scene::LabelFormat::Auto,
                                           resize);
    scene::ScenePreset sp = base;
    sp.rig = scene::resolve_camera_rig(b.image.empty() ? "auto" : b.rig, day.width(), day.height(), f.image);
    const ImageF linear = scene::linearize(day, info);
    const auto ns = scene::night_scene(linear, labels, sp, 0);
    const scene::CameraGeometry& g = ns.geometry;
    // What `night` says of the geometry (a rig for another camera's frame size, a horizon below the
    // frame, a vanishing point far from the rig's pitch): the distances below rest on it.
    if (!g.note.empty()) std::fprintf(stderr, "note: %s: %s\n", f.name.c_str(), g.note.c_str());
    // The rig's nominal horizon (no vanishing point: its pitch), for comparison.
    const scene::CameraGeometry g_rig = scene::camera_geometry(sp.rig, day.width(), day.height(), scene::VanishingPoint{});
    // The markings at full resolution on the frame's sRGB-encoded luminance (make_work_images at
    // the frame's own width: no resize), with the night scene's blur and contrast threshold.
    const scene::WorkImages w = scene::make_work_images(linear, labels.ids, day.width());
    const ImageU8 marks = scene::metric_marking_mask(w.luma, w.labels, g, sp.lane_blur_sigma_px, sp.lane_contrast_threshold);
    const std::vector<scene::DashedLine> lines = scene::dashed_lines(scene::marking_dashes(marks, labels.ids, g));
    const bool road = std::any_of(labels.ids.vec().begin(), labels.ids.vec().end(), [](uint16_t id) {
      return id == static_cast<uint16_t>(scene::Label::Road) || id == static_cast<uint16_t>(scene::Label::Parking);
    });
    if (!road)
      std::printf("  %-22s %-8s   no road or parking in the labels: no markings to measure\n", f.name.c_str(),
                  g.horizon_source == "vanishing_point" ? "VP" : "rig");
    else if (lines.empty())
      std::printf("  %-22s %-8s   no dashed line of 4 or more regular dashes\n", f.name.c_str(),
                  g.horizon_source == "vanishing_point" ? "VP" : "rig");
    int k = 0;
    for (const scene::DashedLine& L : lines) {
      ++n_lines;
      const scene::FlatHorizon fh = scene::flat_period_horizon(L, g);
      const scene::DashStandard* st = scene::nearest_dash_standard(L.period_median_m, std::isfinite(L.dash_painted_m) ? L.dash_painted_m : L.dash_median_m);
      const double st_P = st ? st->dash_m + st->gap_m : NAN;
      bool rig_ok = true;
      for (const scene::MarkingDash& d : L.dashes) rig_ok = rig_ok && d.far_v - g_rig.horizon_y >= 1;
      const scene::DashedLine R = rig_ok ? scene::remeasure(L, g_rig) : scene::DashedLine{};
      const size_t regular = static_cast<size_t>(std::count(L.regular.begin(), L.regular.end(), 1));
      const double trend_se = 100 * 10 * L.slope_se / L.period_mean_m;
      std::printf("  %-22s %-8s %5zu %6.2f %5.1f-%-5.1f %7.2f %5.2f (%4.2f) %6.1f ± %-4.1f %6.1f ± %-4.1f %8.2f   %s\n",
                  (k == 0 ? f.name : std::string()).c_str(), g.horizon_source == "vanishing_point" ? "VP" : "rig",
                  L.dashes.size(), L.X_m, L.dashes.front().near_D_m, L.dashes.back().far_D_m, L.period_median_m,
                  L.dash_painted_m, L.dash_median_m, trend_pct(L), trend_se, fh.shift_px, fh.se_px,
                  rig_ok ? R.period_median_m : NAN,
                  st ? fmt::format("{:.3f}: {}", L.period_median_m / st_P, st->name).c_str() : "none within 1.5x");
      csv += fmt::format("{},{},{:.2f},{},{},{},{:.3f},{:.2f},{:.2f},{:.4f},{:.4f},{:.3f},{:.3f},{:.2f},{:.2f},{:.2f},{:.2f},{:.2f},{},{:.4f},{:.2f},{:.4f},{:.2f},{},{},{},{},{:g}\n",
                         f.name, g.horizon_source, g.horizon_y, k, L.dashes.size(), regular, L.X_m,
                         L.dashes.front().near_D_m, L.dashes.back().far_D_m, L.period_median_m, L.period_sd_m,
                         L.dash_median_m, L.dash_painted_m, L.reach_rows, trend_pct(L), trend_se, fh.shift_px, fh.se_px, st ? st->name : "",
                         st ? L.period_median_m / st_P : NAN, g_rig.horizon_y, rig_ok ? R.period_median_m : NAN,
                         rig_ok ? trend_pct(R) : NAN, periods_list(L), distances_list(L), rig_ok ? periods_list(R) : "",
                         rig_ok ? distances_list(R) : "", st_P);
      if (st) matched.push_back(L.period_median_m / st_P);
      ++k;
    }
  }
  std::printf("  %d dashed lines; dash: painted length (the mask's median length); trend: the period's change per 10 m\n"
              "  of distance (0 with the right horizon); flat shift: the horizon move (rows, + down) that makes it 0;\n"
              "  rig: the period at the rig's nominal horizon\n", n_lines);
  if (!matched.empty()) {
    std::sort(matched.begin(), matched.end());
    std::printf("  %zu of them match a standard pattern: period over the standard's %.3f to %.3f (median %.3f)\n",
                matched.size(), matched.front(), matched.back(), matched[(matched.size() - 1) / 2]);
  }
  const std::string csv_path = write_bench_csv(b.out_dir, "bench_markings.csv", csv);
  // The chart (bench/chart_markings.py, Debian matplotlib): each line's periods against distance at
  // photosite's horizon and at the rig's nominal one, the standard period drawn across. Drawn when
  // nothing was measured too (a panel saying so): a run that wrote no chart left an earlier run's
  // beside its CSV, the two disagreeing, and the folder is the user's (no file of it is removed).
  const std::string png = (fs::path(csv_path).parent_path() / "bench_markings.png").string();
  if (draw_chart("bench/chart_markings.py", csv_path, png)) std::printf("%s\n", png.c_str());
}

static BenchRegistrar reg("markings",
                          "depth on the road measured by its dashed markings' standard periods (the shared frames)",
                          [](CLI::App* sub) {
                            auto b = std::make_shared<MarkingsBench>();
                            sub->add_option("--shared", b->shared, "the shared folder (data/cityscapes, data/kitti)")
                                ->capture_default_str();
                            sub->add_option("--max-frames", b->max_frames, "frames per data set (0: all)")
                                ->capture_default_str()
                                ->check(CLI::NonNegativeNumber);
                            sub->add_option("--scene-preset", b->scene_preset, "scene preset")->capture_default_str();
                            sub->add_option("--image", b->image,
                                            "one day frame of your own instead of the shared ones (with --labels; "
                                            "checks a rig preset's scale on its camera's frames)");
                            sub->add_option("--labels", b->labels, "its Cityscapes-format labels");
                            sub->add_option("--instances", b->instances, "its instance ids (optional)");
                            sub->add_option("--rig", b->rig,
                                            "with --image: the camera rig, as `night --rig` (a name in presets/rigs, "
                                            "a .toml path, a Cityscapes camera .json, or auto)")
                                ->capture_default_str();
                            sub->add_option("--resize-labels", b->resize_labels,
                                            "with --image: none or nearest (labels of another size, as `night`)")
                                ->capture_default_str();
                            sub->add_option("--out-dir", b->out_dir,
                                            "where the CSV goes (default docs/; required with --image)");
                            sub->callback([b] { run(*b); });
                          });
}  // namespace
}  // namespace photosite::bench
