// Hough line segments with angle and border rejection (stage 4).
#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "photosite/scene/night.h"

namespace photosite::scene {

namespace {

// Whether a segment runs along the boundary of what is not the scene: the frame's own car (its
// bonnet's edge, a gentle curve across the bottom of every Cityscapes frame) or the
// rectification's border. Its Canny edge lies within a pixel of the boundary and Hough's segment
// within about a pixel of its edge points, so a point of such a segment has a non-scene pixel
// within 3 px; the test takes points every 2 px and asks it of more than half of them (a road
// line that merely ends at the bonnet touches it with its last few points only).
bool along_non_scene(const Segment& s, const ImageU16& labels) {
  const int W = labels.width(), H = labels.height();
  const double len = std::hypot(s.x1 - s.x0, s.y1 - s.y0);
  const int n = std::max(2, static_cast<int>(len / 2) + 1);
  int near = 0;
  for (int k = 0; k < n; ++k) {
    const double t = static_cast<double>(k) / (n - 1);
    const int x = static_cast<int>(std::lround(s.x0 + t * (s.x1 - s.x0)));
    const int y = static_cast<int>(std::lround(s.y0 + t * (s.y1 - s.y0)));
    bool hit = false;
    for (int dy = -3; dy <= 3 && !hit; ++dy)
      for (int dx = -3; dx <= 3 && !hit; ++dx) {
        const int u = x + dx, v = y + dy;
        if (u >= 0 && u < W && v >= 0 && v < H && is_not_scene(labels.at(u, v))) hit = true;
      }
    near += hit;
  }
  return 2 * near > n;
}

}  // namespace

std::vector<Segment> detect_lines(const ImageU8& edges, const ScenePreset& p, const ImageU16* labels) {
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
    const Segment seg{static_cast<float>(l[0]), static_cast<float>(l[1]), static_cast<float>(l[2]),
                      static_cast<float>(l[3])};
    // Lines from 5° of horizontal (geometry.line_reject_angle_deg) keep the bonnet's edge, whose
    // chords lean 5-7° on Cityscapes frames; it is the camera's own car, not a line of the scene.
    if (labels && along_non_scene(seg, *labels)) continue;
    out.push_back(seg);
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
