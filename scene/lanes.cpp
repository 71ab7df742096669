// Working-resolution images and lane-marking segmentation (stage 2).
#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "photosite/scene/night.h"
#include "photosite/sensor/isp.h"

namespace photosite::scene {

WorkImages make_work_images(const ImageF& day, const ImageU16& labels, int work_max_width) {
  WorkImages w;
  const int W = day.width(), H = day.height();
  w.scale = W > work_max_width ? static_cast<double>(work_max_width) / W : 1.0;
  const int ww = std::max(1, static_cast<int>(std::lround(W * w.scale)));
  const int wh = std::max(1, static_cast<int>(std::lround(H * w.scale)));
  // Luminance (Rec. 709 weights on linear sRGB), area-averaged to the working size, then
  // sRGB-encoded so that contrasts are perceptual.
  cv::Mat lum(H, W, CV_32F);
#pragma omp parallel for schedule(static)
  for (int y = 0; y < H; ++y) {
    const float* r = day.row(y);
    float* o = lum.ptr<float>(y);
    for (int x = 0; x < W; ++x) o[x] = 0.2126f * r[3 * x] + 0.7152f * r[3 * x + 1] + 0.0722f * r[3 * x + 2];
  }
  cv::Mat small;
  if (ww != W) cv::resize(lum, small, cv::Size(ww, wh), 0, 0, cv::INTER_AREA);
  else small = lum;
  w.luma = ImageF(ww, wh, 1);
#pragma omp parallel for schedule(static)
  for (int y = 0; y < wh; ++y) {
    const float* in = small.ptr<float>(y);
    float* o = w.luma.row(y);
    for (int x = 0; x < ww; ++x) o[x] = static_cast<float>(srgb_encode(std::clamp(in[x], 0.f, 1.f)));
  }
  w.labels = ww == W ? labels : resize_nearest(labels, ww, wh);
  return w;
}

ImageU8 lane_markings(const ImageF& luma, const ImageU16& labels, const ScenePreset& p) {
  const int W = luma.width(), H = luma.height();
  ImageU8 out(W, H, 1, 0);
  auto road = [&](int x, int y) {
    const int id = labels.at(x, y);
    return id == static_cast<int>(Label::Road) || id == static_cast<int>(Label::Parking);
  };
  int y_top = -1;
  for (int y = 0; y < H && y_top < 0; ++y)
    for (int x = 0; x < W; ++x)
      if (road(x, y)) { y_top = y; break; }
  if (y_top < 0) return out;  // no road: no markings
  cv::Mat src(H, W, CV_32F, const_cast<float*>(luma.data())), blur;
  if (p.lane_blur_sigma_px > 0) cv::GaussianBlur(src, blur, cv::Size(0, 0), p.lane_blur_sigma_px);
  else blur = src;
  const float thr = static_cast<float>(p.lane_contrast_threshold);
  // Marking width in pixels grows linearly below the top of the road (perspective): about 1.5%
  // of the width at the bottom row (a 0.15 m line on a ~10 m wide view), at least 2 px.
  const double span = std::max(1, H - 1 - y_top);
#pragma omp parallel for schedule(static, 8)  // road pixels crowd the lower rows: interleave
  for (int y = y_top; y < H; ++y) {
    const float* r = blur.ptr<float>(y);
    const int w = std::max(2, static_cast<int>(std::lround(0.015 * W * (y - y_top) / span)));
    const int wv = std::max(1, w / 2);
    for (int x = w; x < W - w; ++x) {
      if (!road(x, y)) continue;
      // Horizontal accumulation (Batista et al.): brighter than both sides by the threshold,
      // with the side asymmetry subtracted so road edges and shadows do not respond.
      const float l = r[x - w], c = r[x], rr = r[x + w];
      const float h = 2 * c - l - rr - std::fabs(l - rr);
      float v = 0;
      if (y - wv >= 0 && y + wv < H) {  // vertical pass: transverse markings, stop lines
        const float u = blur.ptr<float>(y - wv)[x], d = blur.ptr<float>(y + wv)[x];
        v = 2 * c - u - d - std::fabs(u - d);
      }
      if (h > 2 * thr || v > 2 * thr) out.at(x, y) = 255;
    }
  }
  return out;
}

}  // namespace photosite::scene
