// Metric depth against stereo ground truth: KITTI stereo 2015's disparity maps (disp_occ_0/, the
// same 200 training frames as KITTI's semantic benchmark, so image_2/ and semantic/ pair with
// them by name) turned into camera z, and the errors issue 14 asks for: the median relative error
// of depth.Z on road pixels (target <= 10%) and at vehicle ground contacts (<= 15%).
#pragma once
#include <string>
#include <vector>

#include "photosite/image.h"
#include "photosite/scene/labels.h"

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

}  // namespace photosite::scene
