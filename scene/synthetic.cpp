// A synthetic road scene with known geometry for tests: a flat straight road toward a chosen
// vanishing point, dashed lane markings, sky, building blocks on both sides, box cars.
#include <algorithm>
#include <cmath>

#include "photosite/scene/night.h"

namespace photosite::scene {

SyntheticScene make_synthetic_road(const SyntheticOptions& o) {
  const int W = o.width, H = o.height;
  SyntheticScene s;
  s.day_linear_srgb = ImageF(W, H, 3, 0.f, "linear sRGB");
  s.labels.ids = ImageU16(W, H, 1, 0, unit::label_id);
  s.labels.instances = ImageU16(W, H, 1, 0, "instance id");
  auto set = [&](int x, int y, Label l, float r, float g, float b) {
    s.labels.ids.at(x, y) = static_cast<uint16_t>(l);
    s.day_linear_srgb.at(x, y, 0) = r;
    s.day_linear_srgb.at(x, y, 1) = g;
    s.day_linear_srgb.at(x, y, 2) = b;
  };
  const double vx = o.vp_x, vy = o.vp_y;
  // Road edges at the bottom row: 5% and 95% of the width; lane lines at 1/3 and 2/3.
  auto xb_at = [&](double frac_bottom, double y) {  // x on the line from the VP to the bottom point
    const double xb = frac_bottom * W;
    return vx + (xb - vx) * (y - vy) / (H - 1 - vy);
  };
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const bool below = y > vy;
      if (!below) {
        if (o.buildings && (x < vx - 0.12 * W || x > vx + 0.12 * W) && y > vy - 0.25 * H)
          set(x, y, Label::Building, 0.25f, 0.22f, 0.2f);
        else if (o.sky) set(x, y, Label::Sky, 0.5f, 0.6f, 0.8f);
        else set(x, y, Label::Vegetation, 0.05f, 0.12f, 0.03f);
        continue;
      }
      const double l = xb_at(0.05, y), r = xb_at(0.95, y);
      if (o.road && x >= l && x <= r) {
        set(x, y, Label::Road, 0.08f, 0.08f, 0.085f);
        if (o.lanes) {
          // Dashes: on for alternating bands of 1/depth (equal lengths on the ground).
          const double z = (H - 1 - vy) / std::max(1e-3, y - vy);
          const bool dash_on = std::fmod(z * 4.0, 2.0) < 1.0;
          const double half = std::max(0.8, 0.006 * W * (y - vy) / (H - 1 - vy));
          for (double fr : {1.0 / 3, 2.0 / 3})
            if (dash_on && std::fabs(x - xb_at(fr, y)) <= half) set(x, y, Label::Road, 0.8f, 0.8f, 0.78f);
          // Solid edge lines.
          for (double fr : {0.07, 0.93})
            if (std::fabs(x - xb_at(fr, y)) <= half) set(x, y, Label::Road, 0.8f, 0.8f, 0.78f);
        }
      } else {
        set(x, y, Label::Sidewalk, 0.2f, 0.19f, 0.18f);
      }
    }
  // Cars: boxes standing on the road at decreasing distance, in the right and left lanes.
  for (int c = 0; c < o.cars; ++c) {
    const double yb = vy + (H - 1 - vy) * (0.35 + 0.25 * c);  // bottom row of the car
    const double scale = (yb - vy) / (H - 1 - vy);
    const double fr = c % 2 == 0 ? 0.62 : 0.25;
    const double cx = xb_at(fr, yb), cw = 0.2 * W * scale, ch = 0.13 * W * scale;
    for (int y = std::max(0, static_cast<int>(yb - ch)); y <= std::min(H - 1, static_cast<int>(yb)); ++y)
      for (int x = std::max(0, static_cast<int>(cx - cw / 2)); x <= std::min(W - 1, static_cast<int>(cx + cw / 2)); ++x) {
        set(x, y, Label::Car, 0.3f, 0.05f, 0.05f);
        s.labels.instances.at(x, y) = static_cast<uint16_t>(26000 + c);
      }
  }
  return s;
}

}  // namespace photosite::scene
