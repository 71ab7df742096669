// Metric depth against stereo ground truth (see depth_eval.h).
#include "photosite/scene/depth_eval.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>

#include <fmt/format.h>
#include <opencv2/imgproc.hpp>

#include "photosite/error.h"

namespace photosite::scene {
namespace {
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
}  // namespace

double nearest_rank_quantile(std::vector<double> v, double q) {
  if (v.empty()) return kNaN;
  const size_t k = std::min(v.size() - 1, static_cast<size_t>(q * static_cast<double>(v.size() - 1) + 0.5));
  std::nth_element(v.begin(), v.begin() + static_cast<long>(k), v.end());
  return v[k];
}

StereoCalibration read_kitti_stereo_calibration(const std::string& path) {
  std::ifstream in(path);
  if (!in) fail_at(path, "cannot read the stereo calibration");
  std::map<std::string, std::vector<double>> rows;
  std::string line;
  while (std::getline(in, line)) {
    const auto colon = line.find(':');
    if (colon == std::string::npos) continue;
    const std::string key = line.substr(0, colon);
    if (key != "P_rect_02" && key != "P_rect_03") continue;
    std::istringstream ss(line.substr(colon + 1));
    std::vector<double> v;
    double x;
    while (ss >> x) v.push_back(x);
    if (v.size() != 12) fail_at(path, fmt::format("{}: expected 12 numbers (a 3x4 projection matrix), found {}", key, v.size()));
    rows[key] = v;
  }
  for (const char* k : {"P_rect_02", "P_rect_03"})
    if (!rows.count(k)) fail_at(path, std::string(k) + ": missing (a KITTI calib_cam_to_cam file has P_rect_02 and P_rect_03)");
  StereoCalibration c;
  c.fx_px = rows["P_rect_02"][0];
  // P_rect_0i[0][3] = −fx·(x offset of camera i from the reference camera 0).
  c.baseline_m = (rows["P_rect_02"][3] - rows["P_rect_03"][3]) / c.fx_px;
  if (!(c.fx_px > 0) || !(c.baseline_m > 0))
    fail_at(path, fmt::format("fx {} px and baseline {} m must be positive", c.fx_px, c.baseline_m));
  return c;
}

ImageF depth_from_kitti_disparity(const ImageU16& codes, const StereoCalibration& c) {
  ImageF z(codes.width(), codes.height(), 1, uninitialized);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const double fb = c.fx_px * c.baseline_m * 256.0;  // z = fx·B / (code / 256)
  for (size_t i = 0; i < codes.size(); ++i) z[i] = codes[i] ? static_cast<float>(fb / codes[i]) : nan;
  return z;
}

DepthErrors depth_errors(const ImageF& depth_m, const ImageF& truth_m, const LabelMap& labels, double max_depth_m,
                         int min_vehicle_px) {
  const int W = depth_m.width(), H = depth_m.height();
  if (truth_m.width() != W || truth_m.height() != H || labels.ids.width() != W || labels.ids.height() != H)
    fail(fmt::format("depth_errors: depth {}x{}, truth {}x{} and labels {}x{} must be one size", W, H,
                     truth_m.width(), truth_m.height(), labels.ids.width(), labels.ids.height()));
  auto measured = [&](size_t i) { return std::isfinite(truth_m[i]) && truth_m[i] > 0 && truth_m[i] <= max_depth_m; };
  DepthErrors e;
  std::vector<double> road;
  for (size_t i = 0; i < depth_m.size(); ++i)
    if (labels.ids[i] == static_cast<uint16_t>(Label::Road) && measured(i))
      road.push_back(std::fabs(static_cast<double>(depth_m[i]) - truth_m[i]) / truth_m[i]);
  e.road_pixels = road.size();
  e.road_median_rel = nearest_rank_quantile(road, 0.5);
  e.road_p90_rel = nearest_rank_quantile(road, 0.9);

  // Vehicles: instance codes where given, else 8-connected regions of one vehicle class.
  cv::Mat comp(H, W, CV_32S, cv::Scalar(0));
  int next = 1;
  const bool inst = !labels.instances.empty();
  std::map<int, int> by_code;  // instance code → component
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const int id = labels.ids.at(x, y);
      if (!is_vehicle(id)) continue;
      const int code = inst ? labels.instances.at(x, y) : 0;
      if (code >= 1000) {
        auto [it, fresh] = by_code.try_emplace(code, 0);
        if (fresh) it->second = next++;
        comp.at<int>(y, x) = it->second;
      }
    }
  for (int cls = 0; cls < kLabelCount; ++cls) {
    if (!is_vehicle(cls)) continue;
    cv::Mat mask(H, W, CV_8U, cv::Scalar(0));
    bool any = false;
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x)
        if (labels.ids.at(x, y) == cls && comp.at<int>(y, x) == 0) mask.at<uint8_t>(y, x) = 255, any = true;
    if (!any) continue;
    cv::Mat cc;
    const int n = cv::connectedComponents(mask, cc, 8, CV_32S);
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x)
        if (const int c = cc.at<int>(y, x); c > 0) comp.at<int>(y, x) = next + c - 1;
    next += n - 1;
  }
  std::vector<int> count(next, 0), bottom(next, -1), first(next, -1);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x)
      if (const int c = comp.at<int>(y, x)) {
        ++count[c];
        bottom[c] = std::max(bottom[c], y);
        if (first[c] < 0) first[c] = y * W + x;
      }
  std::vector<int> order;
  for (int c = 1; c < next; ++c)
    if (count[c] >= min_vehicle_px) order.push_back(c);
  std::sort(order.begin(), order.end(), [&](int a, int b) { return first[a] < first[b]; });
  for (const int c : order) {
    std::vector<double> z, t;
    const int y = bottom[c];
    for (int x = 0; x < W; ++x) {
      const size_t i = static_cast<size_t>(y) * W + x;
      if (comp.at<int>(y, x) == c && measured(i)) {
        z.push_back(depth_m[i]);
        t.push_back(truth_m[i]);
      }
    }
    if (t.empty()) continue;
    const double zt = nearest_rank_quantile(t, 0.5);
    e.contact_rel.push_back(std::fabs(nearest_rank_quantile(z, 0.5) - zt) / zt);
  }
  e.contacts = e.contact_rel.size();
  e.contact_median_rel = nearest_rank_quantile(e.contact_rel, 0.5);
  return e;
}

}  // namespace photosite::scene
