// The thesis's own day-to-night method as a baseline for `photosite bench realism` (issue 14 §4):
// Baek 2020, "Road Scene Image Translation from Day to Night using Semantic Segmentation"
// (/work/shared/reference/baek-2020-day-to-night-thesis.txt), Chapter 3, in its own 8-bit image
// space, with none of photosite's radiometry:
//   §3.1  brightness adjustment: V of 8-bit HSV times the class reflectance of Table 1;
//   §3.3  light map: reflective elements (traffic signs, the §3.2A lane markings) and light
//         sources picked by colour in CIELAB (red/green/yellow in traffic lights, red/white on
//         vehicles), with a mip-map Gaussian bloom (§3.3A), and randomly splatted pre-rendered
//         light sprites on buildings (§3.3B);
//   §3.4  composition: the adjusted image plus the light map, clipped to 8 bits.
// Not reproduced: the coarse-depth weighting of §3.4 (the thesis gives no formula) and the sensor
// noise of §3.5 (photosite's sensor model is what this baseline is compared against). Numbers the
// thesis does not give (colour thresholds, sprite count and size, bloom weight) are our choices,
// named as such in ThesisBaselineOptions.
#pragma once
#include <cstdint>

#include "photosite/image.h"

namespace photosite {

struct ThesisBaselineOptions {
  // Table 1 of the thesis (p. 11): representative material → reflectance (dimensionless).
  double rho_sign = 0.7;          // aluminium [T1 ref 23]: traffic sign, traffic light
  double rho_construction = 0.3;  // concrete [T1 ref 25]: building, wall, fence, guard rail, bridge, tunnel
  double rho_human = 0.25;        // human skin [T1 refs 26, 27]: person, rider
  double rho_nature = 0.2;        // vegetation [T1 refs 25, 28]: vegetation, terrain
  double rho_vehicle = 0.2;       // steel [T1 ref 24]: car, truck, bus, caravan, trailer, train, motorcycle, bicycle
  double rho_sky = 0.1;           // lunar albedo [T1 ref 29]: sky
  double rho_road = 0.1;          // asphalt [T1 refs 25, 30]: road, parking
  // Every class Table 1 does not name (unlabeled, sidewalk, pole, ...) gets the thesis's
  // 'unlabeled' value: "an average of all other reflectance values" (p. 12), the mean of the 7.

  // §3.3B light sprites: the thesis gives no count or size. Ours: sprites per megapixel of
  // building pixels, Gaussian sprite of this standard deviation (fraction of the image width),
  // warm white (sRGB of a ~2700 K incandescent window, 8-bit 255,180,107).
  double sprites_per_building_mpx = 150;
  double sprite_sigma_fraction = 0.003;
  // §3.3A bloom: mip levels (each halves the size; Gaussian σ = bloom_sigma_px at each level)
  // and the weight of their mean added to the light map. The thesis gives neither number.
  int bloom_levels = 5;
  double bloom_sigma_px = 2.0;
  double bloom_weight = 1.0;
  // §3.3 light-source colours in OpenCV 8-bit CIELAB (L·255/100, a+128, b+128): the thesis names
  // the colours, not thresholds. Ours: red a* > 25, green a* < -20, yellow b* > 40 (each with
  // L* > 40); white L* > 85 with |a*|, |b*| < 10.
  uint64_t seed = 0;  // sprite positions: counter-based draws keyed by (seed, sprite index)
};

// The reflectance the thesis assigns to a Cityscapes labelId (Table 1; others: the mean of the 7).
double thesis_reflectance(int label_id, const ThesisBaselineOptions& o = {});

// One 8-bit sRGB day image (3 channels, interleaved RGB) and its labelIds (1 channel, same size)
// → the thesis's night image, 8-bit sRGB. Deterministic: the same inputs and seed give the same
// bytes, whatever the thread count. Bad input (size mismatch, not 3 channels) throws photosite::Error.
ImageU8 thesis_night(const ImageU8& day_srgb8, const ImageU16& labels, const ThesisBaselineOptions& o = {});

// Only §3.1 (the brightness adjustment), for tests and for the bench's breakdown.
ImageU8 thesis_darken(const ImageU8& day_srgb8, const ImageU16& labels, const ThesisBaselineOptions& o = {});

}  // namespace photosite
