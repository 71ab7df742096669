// Sky seen through tree crowns (include/photosite/scene/night.h take_sky_gaps; docs/night.md §1,
// "Sky through the crowns").
//
// Cityscapes (gtFine) and KITTI label a tree crown as one polygon: the sky between its leaves and
// along its ragged edge is labelled vegetation. In the day photo those pixels are as bright as the
// sky; taken as leaves, the texture gives them a leaf's reflectance at the diffuse cap and the
// street lamps and the low beam light them, so at night every crown against the sky carried a
// bright rim where a real night photo shows the dark sky (docs/realism.md, "Analysis: sky seen
// through foliage": 4-30x the rest of the crown on 6 of 7 frames). Here such pixels become sky
// before any stage reads the labels.
//
// Which pixels: vegetation whose day luminance Y (linear sRGB, Rec. 709 weights) is at least
// f = reflectance.sky_gap_fraction of the median Y over the labelled sky, and which joins the
// labelled sky through such pixels (8-connected). The connection is what tells the sky from a
// bright wall seen through the same crown: on KITTI's saturated frames a sunlit white façade
// behind the leaves is as bright as the sky (kitti_000000: 10,792 vegetation pixels pass the
// luminance test, 1,814 of them join the sky), and it stays vegetation, as do sky holes inside
// a crown that no chain of bright pixels joins to the open sky (what is left: docs/night.md).
//
// The crown's edge that stays vegetation (unmix_sky_fringe): a pixel beside the sky holds leaves
// and sky; its share of sky is taken from the linear mix Y = f·Y_sky + (1 − f)·Y_leaf, with Y_leaf
// the median day luminance of the frame's vegetation under the threshold (the sky-like pixels
// left out), and its texture is held to the leaves' share, (1 − f)·ρ_vegetation, instead of a
// sky-bright leaf at the diffuse cap.
#include <algorithm>
#include <cstdint>
#include <cstring>
#include <vector>

#include "core/isa_detail.h"
#include "photosite/scene/night.h"
#include "photosite/sensor/spectrum.h"
#include "scene/texture_detail.h"

namespace photosite::scene {

namespace {

constexpr uint16_t kVeg = static_cast<uint16_t>(Label::Vegetation);
constexpr uint16_t kSky = static_cast<uint16_t>(Label::Sky);
// Fewer labelled sky pixels than this (in the sample, then in the frame) give no sky level to
// compare with: 64 samples put the median within ±1/16 of the distribution's mass (its standard
// error for a fraction near 1/2 is 0.5/√64).
constexpr size_t kMinSky = 64;

// Whether a row of n labels holds vegetation (bit 0) and sky (bit 1): vectorised by the compiler
// (a predicate: every clone gives the same answer).
PHOTOSITE_TARGET_CLONES unsigned row_classes(const uint16_t* row, int n) {
  uint8_t veg = 0, sky = 0;
  for (int x = 0; x < n; ++x) {
    veg |= static_cast<uint8_t>(row[x] == kVeg);
    sky |= static_cast<uint8_t>(row[x] == kSky);
  }
  return static_cast<unsigned>(veg) | static_cast<unsigned>(sky) << 1;
}

// seed[x] = 1 where row[x] is vegetation with a sky pixel among its 8 neighbours (above and below:
// the rows beside it; at the frame's edge, the row itself), else 0; `near` is scratch of n bytes.
PHOTOSITE_TARGET_CLONES void sky_beside_veg(const uint16_t* above, const uint16_t* row, const uint16_t* below, int n,
                                            uint8_t* near, uint8_t* seed) {
  for (int x = 0; x < n; ++x)
    near[x] = static_cast<uint8_t>((above[x] == kSky) | (row[x] == kSky) | (below[x] == kSky));
  for (int x = 1; x + 1 < n; ++x)
    seed[x] = static_cast<uint8_t>((row[x] == kVeg) & (near[x - 1] | near[x] | near[x + 1]));
  seed[0] = static_cast<uint8_t>((row[0] == kVeg) & (near[0] | (n > 1 ? near[1] : 0)));
  if (n > 1) seed[n - 1] = static_cast<uint8_t>((row[n - 1] == kVeg) & (near[n - 2] | near[n - 1]));
}

// Rec. 709 luminance of linear sRGB, in float, the same operations on both paths.
inline float luma709(float r, float g, float b) { return 0.2126f * r + 0.7152f * g + 0.0722f * b; }

// `rgb(i, out)` writes pixel i's linear sRGB.
template <class Rgb>
size_t take(LabelMap& labels, const Rgb& rgb, double fraction) {
  labels.sky_gaps.clear();
  labels.sky_fringe.clear();
  labels.sky_gaps_taken = true;
  labels.sky_day_luminance = 0;
  labels.leaf_day_luminance = 0;
  if (!(fraction > 0)) return 0;
  const int W = labels.ids.width(), H = labels.ids.height();
  uint16_t* ids = labels.ids.data();
  auto Y = [&](size_t i) {
    float c[3];
    rgb(i, c);
    return luma709(c[0], c[1], c[2]);
  };
  // Which rows hold vegetation and which sky (one vectorised pass over the labels): a flood can
  // only start on a vegetation row beside a sky row.
  // (Rows split over the threads: the pass reads every label, 4 MB at 2048x1024, and one thread
  // alone does not draw the memory's bandwidth.)
  std::vector<uint8_t> has_veg(H), has_sky(H);
#pragma omp parallel for schedule(static)
  for (int y = 0; y < H; ++y) {
    const unsigned c = row_classes(ids + static_cast<size_t>(y) * W, W);
    has_veg[y] = c & 1;
    has_sky[y] = c >> 1 & 1;
  }
  // The sky's level: the median of Y over every 4th pixel of every 4th row of the sky (the sky is
  // smooth; 1/16 of its pixels, at most 131,072 on a 2048x1024 frame), over all its pixels where
  // that sample is too small.
  // The leaves' level for the crown's edge (unmix_sky_fringe) in the same loop: every 4th pixel
  // of every 16th row of the vegetation, 1/64 of it (over all of it where that sample is too
  // small). Its cost, in a throw-away harness timing this function on aachen_000000 with the
  // caches flushed (fiftieth session): medians 0.23-0.25 ms without the leaves' sample, 0.28-0.32
  // with it (every 8th pixel of every 8th row, the same share: 0.28-0.49).
  std::vector<float> sky, veg;
  for (int y = 0; y < H; y += 4) {
    const bool veg_row = y % 16 == 0 && has_veg[y];
    if (!has_sky[y] && !veg_row) continue;
    for (int x = 0; x < W; x += 4) {
      const size_t i = static_cast<size_t>(y) * W + x;
      if (ids[i] == kSky) sky.push_back(Y(i));
      else if (veg_row && ids[i] == kVeg) veg.push_back(Y(i));
    }
  }
  // (The full scans read only the rows that hold the class.)
  auto all_of_class = [&](std::vector<float>& out, uint16_t id, const std::vector<uint8_t>& rows) {
    out.clear();
    for (int y = 0; y < H; ++y)
      if (rows[y])
        for (size_t i = static_cast<size_t>(y) * W, e = i + W; i < e; ++i)
          if (ids[i] == id) out.push_back(Y(i));
  };
  if (sky.size() < kMinSky) all_of_class(sky, kSky, has_sky);
  if (sky.size() < kMinSky) return 0;
  const auto mid = sky.begin() + static_cast<std::ptrdiff_t>(sky.size() / 2);
  std::nth_element(sky.begin(), mid, sky.end());
  const float level = *mid;
  if (!(level > 0)) return 0;
  labels.sky_day_luminance = level;
  const float threshold = static_cast<float>(fraction * level);
  // The leaves: the vegetation darker than the threshold (the sky-like pixels are sky or walls).
  if (veg.size() < kMinSky) all_of_class(veg, kVeg, has_veg);
  veg.erase(std::remove_if(veg.begin(), veg.end(), [&](float v) { return !(v < threshold); }), veg.end());
  if (veg.size() >= kMinSky) {
    const auto leaf_mid = veg.begin() + static_cast<std::ptrdiff_t>(veg.size() / 2);
    std::nth_element(veg.begin(), leaf_mid, veg.end());
    labels.leaf_day_luminance = *leaf_mid;
  }
  auto bright_veg = [&](size_t i) { return ids[i] == kVeg && Y(i) >= threshold; };
  // One scan of the rows where a flood can start: a bright vegetation pixel beside the sky
  // (labelled, or taken before it) is taken and its bright vegetation neighbours after it (a
  // stack, which follows a chain onto any row). Taken pixels read as sky at once, so what is taken
  // is the connected closure whatever the order.
  std::vector<uint32_t> stack;
  std::vector<uint8_t> near(W), seed(W);
  // f(i) for each vegetation pixel i of row y beside the sky, as the row is when called, left to
  // right (the row's mask first; memchr skips its zeros).
  auto for_each_beside_sky = [&](int y, const auto& f) {
    const uint16_t* row = ids + static_cast<size_t>(y) * W;
    sky_beside_veg(y > 0 ? row - W : row, row, y + 1 < H ? row + W : row, W, near.data(), seed.data());
    for (int x = 0; x < W; ++x) {
      const void* hit = std::memchr(seed.data() + x, 1, static_cast<size_t>(W - x));
      if (!hit) return;
      x = static_cast<int>(static_cast<const uint8_t*>(hit) - seed.data());
      f(static_cast<size_t>(y) * W + x);
    }
  };
  auto sky_row_beside = [&](int y) { return has_sky[y] || (y > 0 && has_sky[y - 1]) || (y + 1 < H && has_sky[y + 1]); };
  for (int y = 0; y < H; ++y) {
    if (!has_veg[y] || !sky_row_beside(y)) continue;
    // The seeds of this row as it is now (pixels taken on it by an earlier flood are sky, and
    // their neighbours were looked at by that flood).
    for_each_beside_sky(y, [&](size_t i) {
      if (!bright_veg(i)) return;  // (a flood of this row may have taken it since: not vegetation)
      ids[i] = kSky;
      labels.sky_gaps.push_back(static_cast<uint32_t>(i));
      stack.push_back(static_cast<uint32_t>(i));
      while (!stack.empty()) {
        const uint32_t j = stack.back();
        stack.pop_back();
        const int jx = static_cast<int>(j % static_cast<uint32_t>(W)), jy = static_cast<int>(j / static_cast<uint32_t>(W));
        for (int dy = -1; dy <= 1; ++dy)
          for (int dx = -1; dx <= 1; ++dx) {
            const int xx = jx + dx, yy = jy + dy;
            if (xx < 0 || xx >= W || yy < 0 || yy >= H) continue;
            const size_t k = static_cast<size_t>(yy) * W + xx;
            if (!bright_veg(k)) continue;
            ids[k] = kSky;
            labels.sky_gaps.push_back(static_cast<uint32_t>(k));
            stack.push_back(static_cast<uint32_t>(k));
          }
      }
    });
  }
  std::sort(labels.sky_gaps.begin(), labels.sky_gaps.end());
  // The crown's edge as the gaps leave it: on the rows a flood could start from, and beside the
  // rows of the pixels taken.
  std::vector<uint8_t> edge_rows(H);
  for (int y = 0; y < H; ++y) edge_rows[y] = has_veg[y] && sky_row_beside(y);
  for (const uint32_t i : labels.sky_gaps) {
    const int y = static_cast<int>(i / static_cast<uint32_t>(W));
    for (int yy = std::max(0, y - 1); yy <= std::min(H - 1, y + 1); ++yy) edge_rows[yy] |= has_veg[yy];
  }
  for (int y = 0; y < H; ++y)
    if (edge_rows[y]) for_each_beside_sky(y, [&](size_t i) { labels.sky_fringe.push_back(static_cast<uint32_t>(i)); });
  return labels.sky_gaps.size();
}

}  // namespace

size_t take_sky_gaps(LabelMap& labels, const ImageF& day, const ScenePreset& p) {
  if (day.channels() != 3 || !labels.ids.same_shape(day)) {  // other stages refuse the mismatch
    labels.sky_gaps.clear();
    labels.sky_gaps_taken = true;
    return 0;
  }
  const float* d = day.data();
  return take(labels, [d](size_t i, float* c) { c[0] = d[3 * i], c[1] = d[3 * i + 1], c[2] = d[3 * i + 2]; },
              p.sky_gap_fraction);
}

size_t take_sky_gaps(LabelMap& labels, const ImageU8& codes, const ScenePreset& p) {
  if (codes.channels() != 3 || !labels.ids.same_shape(codes)) {  // left to the linear image's (night_scene)
    labels.sky_gaps.clear();
    labels.sky_gaps_taken = false;
    return 0;
  }
  const uint8_t* s = codes.data();
  const float* lut = srgb8_decodes();
  return take(labels, [s, lut](size_t i, float* c) {
    c[0] = lut[s[3 * i]], c[1] = lut[s[3 * i + 1]], c[2] = lut[s[3 * i + 2]];
  }, p.sky_gap_fraction);
}

size_t take_sky_gaps(LabelMap& labels, const ImageF& day, const ImageFileInfo& info, const ScenePreset& p) {
  if (day.channels() != 3 || !labels.ids.same_shape(day)) {  // left to the linear image's (night_scene)
    labels.sky_gaps.clear();
    labels.sky_gaps_taken = false;
    return 0;
  }
  return take(labels, [&day, &info](size_t i, float* c) { linearize_day_pixel(day, info, i, c); }, p.sky_gap_fraction);
}

ImageF linearize_taking_sky_gaps(const ImageF& day, const ImageU8* codes, const ImageFileInfo& info, LabelMap& labels,
                                 TextureSums* sums, const ScenePreset& split, const DayBalance* carried) {
  const bool from_codes = codes && !codes->empty();
  if (!labels.sky_gaps_taken) {  // (bench night takes them before, to time the take alone)
    if (from_codes) take_sky_gaps(labels, *codes, split);
    else take_sky_gaps(labels, day, info, split);
  }
  ImageF lin = from_codes ? linearize_codes_with_texture_sums(*codes, labels.ids, sums, &split, carried)
                          : linearize_with_texture_sums(day, info, labels.ids, sums, &split, carried);
  if (!labels.sky_gaps_taken && take_sky_gaps(labels, lin, split) > 0) *sums = TextureSums();
  return lin;
}

void restore_sky_gaps(LabelMap& labels) {
  for (const uint32_t i : labels.sky_gaps) labels.ids[i] = kVeg;
  labels.sky_gaps.clear();
  labels.sky_fringe.clear();
  labels.sky_gaps_taken = false;
  labels.sky_day_luminance = 0;
  labels.leaf_day_luminance = 0;
}

size_t unmix_sky_fringe(ImageF& texture, const ImageF& day, const LabelMap& labels, const ScenePreset& p) {
  const float level = labels.sky_day_luminance;
  if (!(level > 0) || texture.channels() != 3 || day.channels() != 3 || !texture.same_shape(labels.ids) ||
      !day.same_shape(labels.ids))
    return 0;
  const auto& K = spectrum::band_luminous_efficacy_lm_per_W();
  const double rho = class_reflectance(kVeg, p);
  // The pixel as a linear mix of sky and leaves, Y = f·Y_sky + (1 − f)·Y_leaf (the leaves' level
  // below the sky's: take_sky_gaps keeps only vegetation under the threshold for it); without a
  // leaves' level, Y_leaf = 0.
  const double leaf = labels.leaf_day_luminance > 0 && labels.leaf_day_luminance < level ? labels.leaf_day_luminance : 0.0;
  const double span = level - leaf;
  size_t scaled = 0;
  for (const uint32_t i : labels.sky_fringe) {
    const float* c = day.data() + 3 * static_cast<size_t>(i);
    const double f = std::clamp((static_cast<double>(luma709(c[0], c[1], c[2])) - leaf) / span, 0.0, 1.0);
    float* t = texture.data() + 3 * static_cast<size_t>(i);
    const double lum = K[0] * t[0] + K[1] * t[1] + K[2] * t[2];  // its luminance factor
    const double most = (1 - f) * rho;
    if (lum > most) {
      const double k = most / lum;
      for (int ch = 0; ch < 3; ++ch) t[ch] = static_cast<float>(t[ch] * k);
      ++scaled;
    }
  }
  return scaled;
}

}  // namespace photosite::scene
