// Canny over the segmentation of the selected classes plus lane markings (stage 3).
#include <opencv2/imgproc.hpp>

#include "photosite/scene/night.h"

namespace photosite::scene {

ImageU8 segmentation_edges(const ImageU16& labels, const ImageU8& lanes, const ScenePreset& p) {
  const int W = labels.width(), H = labels.height();
  // A grey-level rendering of the selected classes: road/parking 80, vehicles 160, markings
  // 255, everything else 0. Canny then finds the boundaries between them, not photo texture.
  auto grey_of = [](int id) -> uint8_t {
    if (id == static_cast<int>(Label::Road) || id == static_cast<int>(Label::Parking)) return 80;
    return is_vehicle(id) ? 160 : 0;
  };
  uint8_t grey[kLabelCount];  // the same rule as a table for the label ids
  for (int id = 0; id < kLabelCount; ++id) grey[id] = grey_of(id);
  ImageU8 seg(W, H, 1, uninitialized);
#pragma omp parallel for schedule(static)
  for (int y = 0; y < H; ++y) {
    const uint16_t* id = labels.row(y);
    const uint8_t* lane = lanes.row(y);
    uint8_t* o = seg.row(y);
    for (int x = 0; x < W; ++x) o[x] = lane[x] ? 255 : (id[x] < kLabelCount ? grey[id[x]] : grey_of(id[x]));
  }
  ImageU8 out(W, H, 1, 0);
  if (W < 3 || H < 3) return out;
  cv::Mat in(H, W, CV_8U, seg.data()), e(H, W, CV_8U, out.data());
  cv::Canny(in, e, p.canny_low, p.canny_high, 3, true);
  return out;
}

}  // namespace photosite::scene
