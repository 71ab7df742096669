// Canny over the segmentation of the selected classes plus lane markings (stage 3).
#include <opencv2/imgproc.hpp>

#include "photosite/scene/night.h"
#include "core/isa_detail.h"
#include "scene/lanes_detail.h"

namespace photosite::scene {

namespace {
// One row of the grey-level rendering below: markings 255, road and parking 80, vehicles 160
// (is_vehicle: the ids Car..Bicycle, one unsigned range test), everything else 0; branch-free so
// that the clones take 32 or 64 pixels at a time.
PHOTOSITE_TARGET_CLONES
void grey_row_clones(const uint16_t* __restrict id, const uint8_t* __restrict lane, int W, uint8_t* __restrict o) {
  constexpr unsigned road = static_cast<unsigned>(Label::Road), parking = static_cast<unsigned>(Label::Parking);
  constexpr unsigned car = static_cast<unsigned>(Label::Car), vehicles = static_cast<unsigned>(Label::Bicycle) - car;
  for (int x = 0; x < W; ++x) {
    const unsigned v = id[x];
    const uint8_t g = v == road || v == parking ? 80 : v - car <= vehicles ? 160 : 0;
    o[x] = lane[x] ? 255 : g;
  }
}
}  // namespace

void segmentation_grey_row(const uint16_t* labels, const uint8_t* lanes, int W, uint8_t* o) {
  grey_row_clones(labels, lanes, W, o);
}

ImageU8 segmentation_edges(const ImageU16& labels, const ImageU8& lanes, const ScenePreset& p) {
  const int W = labels.width(), H = labels.height();
  // A grey-level rendering of the selected classes: road/parking 80, vehicles 160, markings
  // 255, everything else 0. Canny then finds the boundaries between them, not photo texture.
  // (night_scene has it made beside the markings: lane_markings_with_grey.)
  ImageU8 seg(W, H, 1, uninitialized);
#pragma omp parallel for schedule(static)
  for (int y = 0; y < H; ++y) grey_row_clones(labels.row(y), lanes.row(y), W, seg.row(y));
  return segmentation_edges_of_grey(seg, p);
}

ImageU8 segmentation_edges_of_grey(const ImageU8& grey, const ScenePreset& p) {
  const int W = grey.width(), H = grey.height();
  ImageU8 out(W, H, 1, 0);
  if (W < 3 || H < 3) return out;
  cv::Mat in(H, W, CV_8U, const_cast<uint8_t*>(grey.data())), e(H, W, CV_8U, out.data());
  cv::Canny(in, e, p.canny_low, p.canny_high, 3, true);
  return out;
}

}  // namespace photosite::scene
