// Baek 2020's day-to-night method (Chapter 3), the realism bench's baseline. See
// include/photosite/thesis_baseline.h for what is reproduced and what is not.
#include "photosite/thesis_baseline.h"

#include <algorithm>
#include <cmath>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

#include <fmt/format.h>

#include "photosite/error.h"
#include "photosite/rng.h"
#include "photosite/scene/labels.h"
#include "photosite/scene/night.h"
#include "photosite/scene/scene_preset.h"
#include "photosite/sensor/isp.h"

namespace photosite {
using scene::Label;

double thesis_reflectance(int id, const ThesisBaselineOptions& o) {
  switch (static_cast<Label>(id)) {
    case Label::TrafficSign: case Label::TrafficLight: return o.rho_sign;
    case Label::Building: case Label::Wall: case Label::Fence: case Label::GuardRail:
    case Label::Bridge: case Label::Tunnel: return o.rho_construction;
    case Label::Person: case Label::Rider: return o.rho_human;
    case Label::Vegetation: case Label::Terrain: return o.rho_nature;
    case Label::Car: case Label::Truck: case Label::Bus: case Label::Caravan: case Label::Trailer:
    case Label::Train: case Label::Motorcycle: case Label::Bicycle: return o.rho_vehicle;
    case Label::Sky: return o.rho_sky;
    case Label::Road: case Label::Parking: return o.rho_road;
    default:  // not in Table 1: the thesis's 'unlabeled' rule, the mean of the seven values
      return (o.rho_sign + o.rho_construction + o.rho_human + o.rho_nature + o.rho_vehicle + o.rho_sky +
              o.rho_road) / 7.0;
  }
}

namespace {
void check_inputs(const ImageU8& day, const ImageU16& labels) {
  if (day.channels() != 3)
    fail(fmt::format("thesis baseline: the day image has {} channels, expected 3 (RGB)", day.channels()));
  if (labels.channels() != 1 || !labels.same_shape(day))
    fail(fmt::format("thesis baseline: labels are {}x{}x{}, the day image {}x{}: expected one channel of that size",
                     labels.width(), labels.height(), labels.channels(), day.width(), day.height()));
  for (size_t i = 0; i < labels.size(); ++i)
    if (labels[i] >= scene::kLabelCount)
      fail(fmt::format("thesis baseline: label {} at pixel {} is not a Cityscapes labelId (0..33)", labels[i], i));
}

cv::Mat as_mat(const ImageU8& img) {
  return cv::Mat(img.height(), img.width(), CV_8UC3, const_cast<uint8_t*>(img.data()));
}
}  // namespace

// §3.1: "the image gets converted to HSV color space. Thereby, only the brightness value (V) of
// the color for each pixel in the image can be adjusted" by the class reflectance (Table 1).
// 8-bit HSV as the thesis's OpenCV pipeline has it: V' = round(V·ρ), H and S kept.
ImageU8 thesis_darken(const ImageU8& day, const ImageU16& labels, const ThesisBaselineOptions& o) {
  check_inputs(day, labels);
  float rho[scene::kLabelCount];
  for (int id = 0; id < scene::kLabelCount; ++id) rho[id] = static_cast<float>(thesis_reflectance(id, o));
  cv::Mat hsv;
  cv::cvtColor(as_mat(day), hsv, cv::COLOR_RGB2HSV);
  const size_t n = day.pixel_count();
  for (size_t i = 0; i < n; ++i) {
    uint8_t& v = hsv.data[3 * i + 2];
    v = static_cast<uint8_t>(std::lround(v * rho[labels[i]]));
  }
  ImageU8 out(day.width(), day.height(), 3, uninitialized);
  cv::Mat out_m = as_mat(out);
  cv::cvtColor(hsv, out_m, cv::COLOR_HSV2RGB);
  return out;
}

ImageU8 thesis_night(const ImageU8& day, const ImageU16& labels, const ThesisBaselineOptions& o) {
  const ImageU8 adjusted = thesis_darken(day, labels, o);  // also checks the inputs
  const int W = day.width(), H = day.height();
  const size_t n = day.pixel_count();
  // The light map, sRGB-encoded floats in [0, 1] (the thesis's "separate light map texture").
  cv::Mat light(H, W, CV_32FC3, cv::Scalar(0, 0, 0));
  auto put_day_pixel = [&](size_t i) {
    float* l = light.ptr<float>() + 3 * i;
    for (int k = 0; k < 3; ++k) l[k] = day[3 * i + k] / 255.f;
  };
  // §3.3: "reflective scene elements (i.e. traffic sign) are selected. The image pixels belong to
  // the selected elements are automatically added to the separate light map texture. Here, the
  // segments of lane marking, that we acquired on previous step, are also added".
  {
    std::vector<float> lut(256);
    for (int v = 0; v < 256; ++v) lut[v] = static_cast<float>(srgb_decode(v / 255.0));
    ImageF lin(W, H, 3, uninitialized);
    for (size_t i = 0; i < 3 * n; ++i) lin[i] = lut[day[i]];
    scene::ScenePreset sp;  // the §3.2A lane detector at photosite's defaults, full resolution
    const scene::WorkImages w = scene::make_work_images(lin, labels, W);
    const ImageU8 lanes = scene::lane_markings(w.luma, w.labels, sp);
    for (size_t i = 0; i < n; ++i)
      if (labels[i] == static_cast<int>(Label::TrafficSign) || lanes[i]) put_day_pixel(i);
  }
  // §3.3: light sources by colour in CIELAB: "green, red, and yellow is searched in traffic lights
  // while red and white is searched for the vehicle" (thresholds: ours, see the header).
  {
    cv::Mat lab;
    cv::cvtColor(as_mat(day), lab, cv::COLOR_RGB2Lab);
    for (size_t i = 0; i < n; ++i) {
      const int id = labels[i];
      const bool tl = id == static_cast<int>(Label::TrafficLight), veh = scene::is_vehicle(id);
      if (!tl && !veh) continue;
      const double L = lab.data[3 * i] * 100.0 / 255, a = lab.data[3 * i + 1] - 128.0, b = lab.data[3 * i + 2] - 128.0;
      const bool red = a > 25 && L > 40, green = a < -20 && L > 40, yellow = b > 40 && L > 40;
      const bool white = L > 85 && std::abs(a) < 10 && std::abs(b) < 10;
      if ((tl && (red || green || yellow)) || (veh && (red || white))) put_day_pixel(i);
    }
  }
  // §3.3A bloom: "we generate mipmap of texture which contains the extracted pixels. Then, the
  // values are sampled from mipmapped texture as the intensity of the bloom effect, while the
  // Gaussian filter is applied." Each level: halve (pyrDown), Gaussian σ, back to full size;
  // the mean over levels, times bloom_weight, is added.
  if (o.bloom_levels > 0 && o.bloom_weight > 0) {
    cv::Mat level = light, acc(H, W, CV_32FC3, cv::Scalar(0, 0, 0)), blurred, up;
    int used = 0;
    for (int l = 0; l < o.bloom_levels && level.cols >= 2 && level.rows >= 2; ++l) {
      cv::Mat down;
      cv::pyrDown(level, down);
      level = down;
      cv::GaussianBlur(level, blurred, cv::Size(0, 0), o.bloom_sigma_px);
      cv::resize(blurred, up, cv::Size(W, H), 0, 0, cv::INTER_LINEAR);
      acc += up;
      ++used;
    }
    if (used) light += acc * (o.bloom_weight / used);
  }
  // §3.3B: "our framework randomly splats pre-rendered light sprites over the selected scene
  // elements ... we sample random position only with the area of selected scene elements (i.e.,
  // building)". Sprite k lands on the building pixel picked by draw (seed, k).
  {
    std::vector<uint32_t> building;
    for (size_t i = 0; i < n; ++i)
      if (labels[i] == static_cast<int>(Label::Building)) building.push_back(static_cast<uint32_t>(i));
    const int count = static_cast<int>(std::lround(o.sprites_per_building_mpx * building.size() / 1e6));
    const double sigma = std::max(0.5, o.sprite_sigma_fraction * W);
    const int r = static_cast<int>(std::ceil(3 * sigma));
    const float colour[3] = {255 / 255.f, 180 / 255.f, 107 / 255.f};
    for (int k = 0; k < count && !building.empty(); ++k) {
      const auto u = random_words(o.seed, 0, static_cast<uint64_t>(k), Stream::Scene);
      const uint32_t p = building[std::min(building.size() - 1,
                                           static_cast<size_t>(uniform_open(u[0]) * building.size()))];
      const int cx = static_cast<int>(p % W), cy = static_cast<int>(p / W);
      for (int y = std::max(0, cy - r); y <= std::min(H - 1, cy + r); ++y)
        for (int x = std::max(0, cx - r); x <= std::min(W - 1, cx + r); ++x) {
          const double d2 = (x - cx) * (x - cx) + (y - cy) * (y - cy);
          const float g = static_cast<float>(std::exp(-0.5 * d2 / (sigma * sigma)));
          float* l = light.ptr<float>(y) + 3 * x;
          for (int c = 0; c < 3; ++c) l[c] += g * colour[c];
        }
    }
  }
  // §3.4 composition: the adjusted image plus the light map (additive: light adds), 8-bit clip.
  ImageU8 out(W, H, 3, uninitialized);
  const float* l = light.ptr<float>();
  for (size_t i = 0; i < 3 * n; ++i)
    out[i] = static_cast<uint8_t>(std::clamp(std::lround(adjusted[i] + 255.0 * l[i]), 0L, 255L));
  return out;
}

}  // namespace photosite
