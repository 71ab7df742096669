// Canny over the segmentation of the selected classes plus lane markings (stage 3).
#include <opencv2/imgproc.hpp>

#include "photosite/scene/night.h"

namespace photosite::scene {

ImageU8 segmentation_edges(const ImageU16& labels, const ImageU8& lanes, const ScenePreset& p) {
  const int W = labels.width(), H = labels.height();
  // A grey-level rendering of the selected classes: road/parking 80, vehicles 160, markings
  // 255, everything else 0. Canny then finds the boundaries between them, not photo texture.
  ImageU8 seg(W, H, 1, 0);
  for (size_t i = 0; i < seg.pixel_count(); ++i) {
    const int id = labels[i];
    uint8_t v = 0;
    if (id == static_cast<int>(Label::Road) || id == static_cast<int>(Label::Parking)) v = 80;
    else if (is_vehicle(id)) v = 160;
    if (lanes[i]) v = 255;
    seg[i] = v;
  }
  ImageU8 out(W, H, 1, 0);
  if (W < 3 || H < 3) return out;
  cv::Mat in(H, W, CV_8U, seg.data()), e(H, W, CV_8U, out.data());
  cv::Canny(in, e, p.canny_low, p.canny_high, 3, true);
  return out;
}

}  // namespace photosite::scene
