// Metric depth against stereo ground truth: KITTI stereo 2015's disparity maps (disp_occ_0/, the
// same 200 training frames as KITTI's semantic benchmark, so image_2/ and semantic/ pair with
// them by name) turned into camera z, and the errors issue 14 asks for: the median relative error
// of depth.Z on road pixels (target <= 10%) and at vehicle ground contacts (<= 15%).
#pragma once
#include <cmath>
#include <string>
#include <vector>

#include "photosite/image.h"
#include "photosite/scene/labels.h"
#include "photosite/scene/night.h"

namespace photosite::scene {

struct StereoCalibration {
  double fx_px = 0;       // rectified focal length of the left camera (P_rect_02[0][0])
  double baseline_m = 0;  // (P_rect_02[0][3] − P_rect_03[0][3]) / fx: 0.532 m on KITTI
};
// KITTI's calib_cam_to_cam.txt (raw data) or calib_cam_to_cam/<frame>.txt (stereo 2015): the
// P_rect_02 and P_rect_03 rows. Bad input naming the file when either is missing or malformed.
StereoCalibration read_kitti_stereo_calibration(const std::string& path);

// KITTI disparity PNG codes (uint16; disparity = code / 256 px; 0: no measurement) → camera z in
// metres, z = fx·B / d; NaN where there is no measurement.
ImageF depth_from_kitti_disparity(const ImageU16& codes, const StereoCalibration& c);

struct DepthErrors {
  size_t road_pixels = 0;          // road pixels with a measurement below max_depth_m
  double road_median_rel = 0;      // median over them of |z − z_true| / z_true
  double road_p90_rel = 0;         // 90th percentile
  size_t contacts = 0;             // vehicles whose contact row has measurements
  double contact_median_rel = 0;   // median over vehicles of the contact's relative error
  std::vector<double> contact_rel;  // each vehicle's, in order of appearance (row-major first pixel)
};
// The q-quantile (0 <= q <= 1) of a sample by nearest rank: the element of rank
// round(q·(n − 1)) in ascending order, no interpolation (q = 0.5: the upper median of an even
// count, rank n/2); NaN for an empty sample. depth_errors' medians and percentiles, and the
// pooled medians of `photosite bench depth`.
double nearest_rank_quantile(std::vector<double> v, double q);

// Compares depth_m with truth_m (NaN: no measurement) on the labels' road pixels and at each
// vehicle's ground contact: a vehicle is an instance (id >= 1000 of a vehicle class) or, without
// instances, an 8-connected region of one vehicle class with at least min_vehicle_px pixels; its
// contact is its lowest row, and its error is |median z − median z_true| / median z_true over that
// row's pixels with a measurement. Pixels whose true depth exceeds max_depth_m are left out (the
// model caps depth there). NaN fields when nothing qualifies.
DepthErrors depth_errors(const ImageF& depth_m, const ImageF& truth_m, const LabelMap& labels,
                         double max_depth_m, int min_vehicle_px = 50);


// ---------------------------------------------------------------------------------------------
// Depth on real frames, measured by the road's own rulers (issue 14 §1, where no stereo ground
// truth is at hand). Dashed longitudinal markings are painted at standard dash and gap lengths,
// so along one line the distance from one dash's start to the next (the period) is the same
// everywhere on the road. Two checks follow from the metric depth alone:
//  - **the horizon:** with the flat-ground model D = f·h / (v − y_h) (small pitch), a horizon off
//    by δ rows gives D' = D / (1 − δ·D/(f·h)), so the measured period grows (δ > 0) or shrinks
//    along the road by dD'/dD ≈ 1 + 2·δ·D/(f·h): a slope of the periods against distance of
//    2·δ·P/(f·h) per metre. The shift that makes that slope 0 is the horizon the dashes imply;
//  - **the scale:** where the pattern is a standard one, the period against its standard value
//    (f and h set the scale; the horizon the trend).
// Neither needs anything photosite does not already have: the day photo, its labels and the
// camera geometry the night scene ran with (`photosite bench markings`, docs/night.md §6b).

// Longitudinal markings of a frame (255 = marking) at full resolution, for the rulers below: a
// road or parking pixel brighter than both pixels a metric half-width away on its row (Batista et
// al.'s accumulation, as lane_markings: h = 2c − l − r − |l − r| > 2·threshold on the luminance
// blurred by σ = blur_sigma_px, sRGB-encoded so contrasts are perceptual), with the two side pixels
// side_m on the ground either side (CameraGeometry, the row's depth): a line up to 2·side_m wide
// is marked whole at every distance. 0.25 m: half the widest German longitudinal line, a
// motorway's 0.30 m Breitstrich (Colliseum wiki "Fahrbahnmarkierung"), plus 0.10 m for the blur
// (7 px at 30 m in a Cityscapes frame); wider, neighbouring lines, kerbs and shadows reach the
// sides. (lane_markings' own width, a fraction of the image growing down the road, serves the
// night scene's vanishing point; near lines wider than twice it come out as two edge strips.)
// 0 above the horizon.
ImageU8 metric_marking_mask(const ImageF& luma_srgb, const ImageU16& labels, const CameraGeometry& g,
                            double blur_sigma_px, double threshold, double side_m = 0.25);
struct MarkingDash {
  double near_v = 0, far_v = 0;  // image rows of its near and far ends: pixel edges (last row + 0.5, first − 0.5)
  double near_u = 0, far_u = 0;  // mean column of its pixels on its nearest and farthest rows
  double near_D_m = 0, far_D_m = 0;  // ground distance of the ends (CameraGeometry::ground_point)
  double near_X_m = 0, far_X_m = 0;  // lateral ground position at the ends
  double near_row_m = 0, far_row_m = 0;  // the ground one row spans at each end (D at the row's two edges)
  int pixels = 0;
};
// The dashes of a marking mask (nonzero = marking; metric_marking_mask): 8-connected
// components that lie on the ground below the horizon and are shaped as a longitudinal dash —
// 0.3 to 12 m long along the road, at most 0.35 m + 0.2 × that length across it (a 0.12-0.30 m
// line at up to 0.2 rad to the camera's axis; stop lines, zebra bars and most arrows are wider),
// and resolved: the ground a row spans at the far end, D²/(f·h), at most a quarter of the dash's
// length (farther, one row's quantisation is a large part of it) — and whole: the labels just
// beyond both ends (2 rows, at the end's column) are road or parking, so an end hidden by a
// vehicle, a person or the frame's border (where the marking's own end is not seen) is no
// ruler. Ordered by near_D_m.
std::vector<MarkingDash> marking_dashes(const ImageU8& markings, const ImageU16& labels, const CameraGeometry& g);
// One dashed line: dashes chained from near to far, each next one starting 0.2-15 m beyond the
// end of the one before, within 0.25 m + 0.02 × the gap of where the line's direction (the last
// dash's own, X against D) puts it. Only lines of at least 4 dashes whose periods are regular
// (at least 3 periods, and 2/3 of them, within 25 % of the median period; a worn-away dash makes
// one period double), and that run straight (every dash end within 0.15 m of the line fitted
// through them on the ground) are kept; periods and dash lengths are along that line
// (ΔD·√(1 + (dX/dD)²)); the statistics are over the regular periods.
struct DashedLine {
  std::vector<MarkingDash> dashes;  // near to far
  std::vector<char> regular;        // per period (dashes.size() − 1): within 25 % of the median
  std::vector<double> periods_m;    // per period: the mean of near end to near end and far end to far end
  std::vector<double> at_D_m;       // per period: the distance it is measured at (mean of its four ends)
  double period_median_m = 0, period_mean_m = 0, period_sd_m = 0;  // over the regular periods
  double dash_median_m = 0;         // the dashes' lengths (far_D − near_D), median
  // The dashes' length without the detector's reach: the mask runs past each painted end by about
  // the same number of rows r at every distance, so a dash measures L + r·(row span at its near
  // end + at its far end); the least-squares line through the dashes' lengths against that sum of
  // spans has the painted length as its intercept and r as its slope (NaN with fewer than 3
  // dashes or spans that do not vary).
  double dash_painted_m = 0, reach_rows = 0;
  double slope = 0, slope_se = 0;   // OLS slope of the regular periods against at_D (m per m) and its standard error
  double X_m = 0;                   // lateral position of the first dash's near end
  double direction = 0;             // the line on the ground: dX/dD, least squares over the dashes' ends
  double straightness_m = 0;        // the farthest end from that line (a line is kept at 0.15 m or less)
};
std::vector<DashedLine> dashed_lines(const std::vector<MarkingDash>& dashes);
// The line's dashes re-measured with another geometry (the same rows, another horizon).
DashedLine remeasure(const DashedLine& line, const CameraGeometry& g);
// The geometry with its horizon moved by shift_px rows (+: down), pitch atan((c_y − y_h)/f).
CameraGeometry shift_horizon(const CameraGeometry& g, double shift_px);
// The horizon shift (px) at which the line's regular periods have no slope against distance,
// by bisection over ±search_px, and its standard error from the slope's (slope_se / |d slope/d shift|);
// NaN when the slope does not change sign over the search.
struct FlatHorizon { double shift_px = NAN, se_px = NAN; };
FlatHorizon flat_period_horizon(const DashedLine& line, const CameraGeometry& g, double search_px = 60);
// Standard dash patterns of longitudinal markings (German practice, the frames' country; names
// hold no comma, a CSV field): a period measured against the pattern whose period is nearest in
// ratio (within 1.5x), among those whose dash share of the period is within 0.1 of the measured
// one (dash_m: the painted length, DashedLine::dash_painted_m, where it is known). Sources in
// depth_eval.cpp.
struct DashStandard { double dash_m, gap_m; const char* name; };
const std::vector<DashStandard>& dash_standards();
const DashStandard* nearest_dash_standard(double period_m, double dash_m);

}  // namespace photosite::scene
