// Private (not installed): a test hook of scene/darken.cpp's linearize and reflectance_texture,
// and the texture pass that also makes the lane stage's working luminance.
#pragma once
#include <array>
#include <cstdint>
#include <memory>
#include <vector>

#include "photosite/scene/night.h"

namespace photosite::scene {

// The widest instruction set linearize's and reflectance_texture's per-pixel loops may take: 2 AVX-512, 1 AVX2,
// 0 the scalar loops (default 2; the machine's own support caps it). All give the same bits; the
// test runs each.
void texture_max_isa(int isa);
// Whether linearize's 8-bit decode takes the AVX-512 VBMI byte permutes where the CPU has them
// (default) or the AVX-512 gathers; the same floats either way (the test runs both).
void texture_decode_vbmi(bool on);

// linearize's decodes of the 256 codes of an 8-bit file, to the bit (what its 8-bit paths read).
const float* srgb8_decodes();
// Pixel i of an RGB day image (read_image's samples) as linearize() gives it, to the bit.
void linearize_day_pixel(const ImageF& day, const ImageFileInfo& info, size_t i, float* linear_srgb);
// How many textures made their own class sums (pass 1) because none were handed to them (or
// the ones handed were made for another image): the chain's callers (prepare_night, batch) hand
// the linearisation's, and tests check that the count stays put.
uint64_t texture_own_class_sums_count();

// reflectance_texture, and with work_luma (a ww x wh image for a 2ww x 2wh frame: the exact
// halving of scene/lanes_detail.h) also the working luminance, work_luma_row of every row,
// made in the texture's second pass while each chunk's day pixels are in cache (night_scene).
// `sums`: pass 1 made by linearize_with_texture_sums (taken when made for day and labels).
// The day's sunlight in a diffuse class's texture (reflectance.sun_shade_*; darken.cpp has the
// model): which pixels lie on their class's sunlit level, and per class the sun/shade ratio g
// divided out of them (1: the class is not split) with the sum of Y = Σ K_k c_k over them.
struct SunShadeSplit {
  std::vector<uint8_t> sunlit;              // per pixel, 1 on a sunlit level; empty when no class is split
  std::array<double, kLabelCount> ratio{};  // g per class, 1 where not split
  std::array<double, kLabelCount> sun_sum{};
  // Per class, the factors per box band that take the shade level's colour to the sunlit level's
  // at the same luminance (the blue sky's cast out); 1 where not split.
  std::array<std::array<double, 3>, kLabelCount> shade_tint{};
  int block_px = 0, opening_radius_blocks = 0;  // the block grid's edge, the opening's radius (blocks)
};
// Sorts nine floats (none NaN) ascending by a fixed network of 25 compare-exchanges (Knuth, TAOCP
// vol. 3, §5.3.4, the best known for n = 9; each a min and a max, no data-dependent branch):
// soften_sun_edges' median of a 3 x 3 neighbourhood (the absent neighbours +inf). The test
// checks it against a sort on every 0/1 input (the 0-1 principle: then it sorts every input).
inline void sort9(float v[9]) {
  auto cx = [&](int i, int j) {
    const float lo = v[i] < v[j] ? v[i] : v[j], hi = v[i] < v[j] ? v[j] : v[i];
    v[i] = lo;
    v[j] = hi;
  };
  cx(0, 3); cx(1, 7); cx(2, 5); cx(4, 8);
  cx(0, 7); cx(2, 4); cx(3, 8); cx(5, 6);
  cx(0, 2); cx(1, 3); cx(4, 5); cx(7, 8);
  cx(1, 4); cx(3, 6); cx(5, 7);
  cx(0, 1); cx(2, 4); cx(3, 5); cx(6, 8);
  cx(2, 3); cx(4, 5); cx(6, 7);
  cx(1, 2); cx(3, 4); cx(5, 6);
}
// Whether reflectance_texture softens the split's penumbrae (darken.cpp soften_sun_edges; on by
// default): a test hook for the before/after comparison. Not thread-safe: set it between textures.
void sun_penumbrae_enabled(bool on);
// The smallest ratio of the shade's B/R (box bands) to the sunlit level's that the sun against the
// sky makes at a step of sun_shade_ratio_min (reflectance.sun_cct_K, shade_sky_cct_K): a class
// whose levels differ less in colour is not split.
double sun_blue_contrast(const ScenePreset& p);
// The split's isodata threshold (Ridler and Calvard 1978) of the n levels lvl weighted by w (the
// blocks' sample counts): from the weighted mean, the point halfway between the weighted means of
// the levels at most t and above t, until it stays put (at most 100 steps). The sums are those in
// list order, to the bit; *exact (when given) tells whether they were found exact, so taken in
// any order (darken.cpp sums_exact), or added in list order.
double sun_isodata_threshold(const double* w, const double* lvl, size_t n, bool* exact = nullptr);
// The split's phase 1: per diffuse class (diffuse_class) and block of its grid (block_px = B
// pixels square), the sum of Y = Σ K_k c_k over the class's pixels on every other row of the block
// (every row when B = 1), added in pixel order, and their count; per class and block row, the
// first and last blocks holding any (none: first > last). Made in the linearisation's pass
// (linearize_*_with_texture_sums given the preset) for the block rows whose sampled pixels all lie
// in one of the pass's chunks (`made`), from the Y that pass computes for the class sums, so the
// split does not read the day image for them; the split sums the other rows itself. A block's sum
// is only meaningful inside its row's [row_x0, row_x1] (outside it, not written).
struct SunBlockSums {
  const float* image = nullptr;  // what they are of
  const uint16_t* labels = nullptr;
  int width = 0, height = 0, block_px = 0, nbx = 0, nby = 0;
  std::array<double, 3> gain{1.0, 1.0, 1.0};  // the day white balance their Y was taken with
  std::unique_ptr<double[]> ysum, ycnt;  // [diffuse slot · nbx·nby + block]
  std::vector<int> row_x0, row_x1;       // [diffuse slot · nby + block row]
  std::vector<uint8_t> made;             // per block row: 1 where summed here
};
// The split's edge blocks of a class's w x h box (row-major): ed[i] = 1 where block i is absent
// (present[i] = 0) or has a present 8-neighbour whose side sd (0 or 1; 0 where absent) is not its own.
void sun_edge_blocks(const uint8_t* present, const uint8_t* sd, int w, int h, uint8_t* ed);
// The diffuse classes' slots in SunBlockSums (-1: not diffuse; ids ≥ kLabelCount have none).
int sun_diffuse_slot(int id);
// SunBlockSums of every block row summed the split's own way (reading the day image): the
// reference for the sums made in the linearisation's pass (tests).
// `gain`: the day photo's white balance (DayBalance::gain) the Y are taken with.
std::shared_ptr<SunBlockSums> sun_block_sums(const ImageF& day_linear_srgb, const ImageU16& labels,
                                             const std::array<double, 3>& gain = {1.0, 1.0, 1.0});
// How many block rows the split has summed itself (not taken from the linearisation's pass):
// tests check that the chain's frames take them.
uint64_t sun_block_rows_summed_count();
// `class_px`: each class's pixel count in the frame (kLabelCount entries). `made`: the block sums
// made in the linearisation's pass (taken for the rows they hold when made of this image and
// these labels with this gain). `gain`: the day photo's white balance (DayBalance::gain), taken
// with the box basis as the texture takes it.
SunShadeSplit sun_shade_split(const ImageF& day_linear_srgb, const ImageU16& labels, const ScenePreset& p,
                              const double* class_px, const SunBlockSums* made = nullptr,
                              const std::array<double, 3>& gain = {1.0, 1.0, 1.0});
// The same, counting the classes' pixels itself (no white balance).
SunShadeSplit sun_shade_split(const ImageF& day_linear_srgb, const ImageU16& labels, const ScenePreset& p);

// `balance_used`: where given, the day white balance the texture was made with (NightScene::day_balance).
ImageF reflectance_texture_with(const ImageF& day_linear_srgb, const ImageU16& labels, const ScenePreset& p,
                                ClassMeans* carried, ImageF* work_luma, const TextureSums* sums = nullptr,
                                DayBalance* balance_used = nullptr);

// linearize_with_texture_sums of an 8-bit sRGB file's codes (interleaved RGB, the frame's size;
// other channel counts: linearize() alone): the same image and sums to the bit as from the
// codes' floats code·(1/255) that read_image() gives, reading a quarter of the bytes (each code's
// linear value from linearize()'s own 256-entry table for 8-bit files).
// With `split` (the scene preset, its sun/shade split on) also the split's block sums (sums->sun).
// `carried`: as linearize_with_texture_sums'.
ImageF linearize_codes_with_texture_sums(const ImageU8& codes, const ImageU16& labels, TextureSums* sums,
                                         const ScenePreset* split = nullptr, const DayBalance* carried = nullptr);

// The road's samples of a day image, for its mean colour (day_white_balance, and the vehicle-facing
// cue's road_grey_gains): every 4th row and column of the W x H labels whose label is Road, in
// reading order; px(x, y, c) writes a sample's linear sRGB into c[3], use(c) says whether it
// counts. Their channel sums (double, in that order) and their count.
struct RoadSums {
  double sum[3] = {0, 0, 0};
  long n = 0;
};
template <class Px, class Use>
RoadSums road_samples(int W, int H, const uint16_t* labels, const Px& px, const Use& use) {
  RoadSums r;
  for (int y = 0; y < H; y += 4) {
    const uint16_t* lr = labels + static_cast<size_t>(y) * W;
    for (int x = 0; x < W; x += 4) {
      if (lr[x] != static_cast<uint16_t>(Label::Road)) continue;
      float c[3];
      px(x, y, c);
      if (!use(c)) continue;
      for (int k = 0; k < 3; ++k) r.sum[k] += c[k];
      ++r.n;
    }
  }
  return r;
}
// The same over a linear sRGB image (3 channels, the labels' size) as it is.
template <class Use>
RoadSums road_samples(const ImageF& day_linear_srgb, const ImageU16& labels, const Use& use) {
  return road_samples(labels.width(), labels.height(), labels.data(),
                      [&](int x, int y, float* c) {
                        const float* s = day_linear_srgb.row(y) + 3 * x;
                        c[0] = s[0], c[1] = s[1], c[2] = s[2];
                      },
                      use);
}

}  // namespace photosite::scene
