// Hough line segments with angle and border rejection (stage 4).
#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "photosite/scene/night.h"

namespace photosite::scene {

std::vector<Segment> detect_lines(const ImageU8& edges, const ScenePreset& p) {
  const int W = edges.width(), H = edges.height();
  std::vector<Segment> out;
  if (W < 8 || H < 8) return out;
  cv::Mat e(H, W, CV_8U, const_cast<uint8_t*>(edges.data()));
  std::vector<cv::Vec4i> raw;
  cv::HoughLinesP(e, raw, 1, CV_PI / 180, p.hough_threshold,
                  std::max(5.0, p.hough_min_length_fraction * W),
                  std::max(1.0, p.hough_max_gap_fraction * W));
  const double reject = p.line_reject_angle_deg;
  const double bx = p.border_fraction * W, by = p.border_fraction * H;
  auto in_border = [&](double x, double y) {
    return x < bx || x > W - 1 - bx || y < by || y > H - 1 - by;
  };
  for (const auto& l : raw) {
    const double dx = l[2] - l[0], dy = l[3] - l[1];
    double a = std::fabs(std::atan2(dy, dx)) * 180 / CV_PI;  // 0..180
    if (a > 90) a = 180 - a;                                   // 0 horizontal .. 90 vertical
    if (a < reject || a > 90 - reject) continue;
    if (in_border(l[0], l[1]) && in_border(l[2], l[3])) continue;  // lies along the frame
    out.push_back({static_cast<float>(l[0]), static_cast<float>(l[1]), static_cast<float>(l[2]),
                   static_cast<float>(l[3])});
  }
  // Keep the longest 200 so the pairwise intersection stage stays bounded (the thesis capped
  // its CPU loops the same way).
  if (out.size() > 200) {
    auto len = [](const Segment& s) { return std::hypot(s.x1 - s.x0, s.y1 - s.y0); };
    std::partial_sort(out.begin(), out.begin() + 200, out.end(),
                      [&](const Segment& a, const Segment& b) { return len(a) > len(b); });
    out.resize(200);
  }
  return out;
}

}  // namespace photosite::scene
