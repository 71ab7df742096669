// Veiling glare of the lens as a point-spread function of the lens preset, applied to the
// image-plane irradiance in the optics stage (docs/model_glare.md):
//
//   PSF(θ) = (1 − η)·δ(θ) + η·S(θ),   S(θ) ∝ (θ² + θ0²)^(−p/2) for θ ≲ reach, ∫S dΩ = 1.
//
// η is the veiling glare index of ISO 9358:1994 (the share of the image-plane flux scattered
// into a wide halo; a few % for coated lenses). The skirt's shape, a power law with exponent
// p = 2 flattened inside a core θ0, is the CIE 146:2002 / Vos disability-glare shape of the
// eye's stray light (L_veil ∝ E/θ²), ADOPTED FOR A CAMERA LENS AS AN ASSUMPTION (lens glare
// spread functions measured by Talvala et al. 2007 also fall as a power law of about that slope).
//
// The angles are turned into pixels by the lens's focal length and the sensor's pixel pitch
// (px_per_degree), so the reach is fixed in degrees, not as a fraction of the image.
//
// Implementation: a reduced-resolution pyramid. Level 1 is the irradiance 2x2 box-averaged,
// each further level the one above filtered by (1,3,3,1)/8 per axis and decimated by 2 (the
// transpose of bilinear upsampling: a point's centroid stays put); on the levels lo..hi a
// separable Gaussian (σ_b = 1 level pixel) blurs it; coarse to fine,
// acc_l = w_l·blur(level_l) + up(acc_{l+1}) with bilinear upsampling. A point source thus
// spreads on level l with variance σ_l² = 4^l·(σ_b² + 1/2) − 1 px² per axis (glare.cpp has the
// sum), i.e. octave-spaced Gaussian-like kernels. A sum of normalised Gaussians at octave scales with weights w_l ∝ σ_l^(2−p) falls as
// θ^(−p) between the finest and the coarsest σ (APPROXIMATION: the sum ripples about the power
// law; docs/model_glare.md bounds it). lo is the level whose σ is closest to θ0, hi the one
// closest to reach/2. The last upsample to full resolution is fused with the mix
//   out = (1 − η)·in + s_c·up(acc_1),   s_c = η·E_in,c / E_skirt,c,
// where the energies are exact sums (double, fixed order) at level 1, so Σ out = Σ in per
// channel up to float rounding whatever the image size (the blurs' half-sample mirror borders
// already conserve energy; s_c corrects what odd level sizes leave).
#pragma once
#include <array>
#include <cstddef>
#include <memory>
#include <vector>

#include "photosite/image.h"

namespace photosite {

// The lens preset's [glare] table. A lens without it has no glare (enabled = false).
struct LensGlare {
  bool enabled = false;
  double veiling_glare_index = 0.0;  // η, fraction of the flux in the skirt
  double core_deg = 0.1;             // θ0, where the skirt flattens
  double reach_deg = 10.0;           // where the power law ends (coarsest level σ = reach/2)
  double skirt_exponent = 2.0;       // p
};

// On-axis pixels per degree: f / pitch per radian (APPROXIMATION: off axis a degree spans
// 1/cos²θ more pixels; the PSF is applied shift-invariant).
double px_per_degree(double focal_length_mm, double pixel_pitch_um);

// The Gaussian taps of the per-level blur, centre first (σ_b = 1 level px, radius 3; normalised
// in double, then float).
inline constexpr int kGlareBlurRadius = 3;
std::array<float, kGlareBlurRadius + 1> glare_blur_taps();

// The pyramid's levels for a lens at a pixel scale: blur levels lo..hi (1 <= lo <= hi), their
// weights (sum 1) and the per-axis spread σ_l (px) each level gives a point source.
struct GlarePlan {
  bool active = false;  // η > 0 and glare enabled
  int lo = 1, hi = 1;
  std::vector<float> weight;         // weight[l - lo]
  std::vector<double> sigma_px;      // sigma_px[l - lo]
  float keep = 1.0f;                 // 1 − η
  double eta = 0.0;
};
GlarePlan plan_glare(const LensGlare& glare, double px_per_deg);

// Level sizes: level l is ceil(w / 2^l) x ceil(h / 2^l).
inline int glare_level_size(int n, int level) {
  for (int l = 0; l < level; ++l) n = (n + 1) / 2;
  return n;
}

// The reduced-resolution part: acc_1 (level 1, 3 channels) and the per-channel scale s_c.
// acc_1's buffer belongs to the calling thread's pyramid workspace (sensor/glare.cpp), shared
// with the skirt: the thread's next glare_skirt() writes it again once no skirt holds it (and
// makes a new one while one does), so frame after frame its pages are not faulted in afresh.
struct GlareSkirt {
  int width = 0, height = 0;           // full resolution
  std::shared_ptr<const ImageF> acc1;  // ceil(w/2) x ceil(h/2) x 3; null or empty: no glare
  float keep = 1.0f;                   // 1 − η
  std::array<float, 3> scale{0.f, 0.f, 0.f};
  bool active() const { return acc1 && !acc1->empty(); }
};
GlareSkirt glare_skirt(const ImageF& irradiance_rgb, const GlarePlan& plan);

// The pyramid's level 1 (the 2x2 box of the irradiance, ceil(w/2) x ceil(h/2) x 3) and each of
// its rows' level-1 energy sums, made by a caller that writes the irradiance row by row while
// the row pair is in cache (the scene's compose pass: scene::light_map), so that the glare never
// reads the full-resolution frame again. glare_level1_row makes level row j from input rows 2j
// and min(2j + 1, h − 1) with the pyramid's own row kernels (the same operations in the same
// order: the same bits), in any order and on any thread (each row alone); glare_level1_sums
// then the energy sums of level rows [j0, j1) (made already), eight rows at a time as the
// pyramid sums them (each row's sum its own chain in its own order: any split gives the same).
struct GlareLevel1 {
  int full_width = 0, full_height = 0;
  ImageF image;                                 // level 1 (radiance units of the input)
  std::vector<std::array<double, 3>> row_sums;  // [j]: Σ_x n_x·v over level row j, per channel
  GlareLevel1() = default;
  GlareLevel1(int full_width, int full_height);
};
void glare_level1_row(const ImageF& irradiance_rgb, int j, GlareLevel1& level1);
void glare_level1_sums(GlareLevel1& level1, int j0, int j1);
inline constexpr int kGlareLevel1SumRows = 8;  // the rows glare_level1_sums takes at once
// glare_skirt with level 1 made already (null: as glare_skirt(in, plan)): the same skirt, bit for
// bit; level1 must be that of `in` (its sizes are checked, its values are not).
GlareSkirt glare_skirt(const ImageF& irradiance_rgb, const GlarePlan& plan, const GlareLevel1* level1);

// Where glare_row's four row buffers lie inside its scratch (offsets in floats): t, the vertical
// interpolation (3·aw, aw = acc_1's width), u, the horizontal one (3·width), and e, o, the
// latter's even and odd samples (3·aw each). Buffer i starts 256·i floats (1 KiB·i) into a
// 4 KiB page, counted from the scratch's start, so no two of the streams the row loops load and
// store at once share their offset within a page: a load whose address bits 0-11 match an
// earlier store still in flight waits for it ("4K aliasing", Intel optimization manual 3.6.8);
// packed end to end at width 2048, all four began at one offset (3·1024 floats = 3 pages apart).
struct GlareRowLayout {
  size_t t, u, e, o, total;
};
// The first offset >= end (floats) that lies 256·i floats into a 4 KiB page.
inline size_t glare_page_stagger(size_t end, size_t i) { return end + (256 * i + 1024 - end % 1024) % 1024; }
inline GlareRowLayout glare_row_layout(const GlareSkirt& s) {
  const size_t aw = s.active() ? static_cast<size_t>(s.acc1->width()) : 0, w = static_cast<size_t>(s.width);
  constexpr auto place = glare_page_stagger;
  GlareRowLayout l{};
  l.t = 0;
  l.u = place(l.t + 3 * aw, 1);
  l.e = place(l.u + 3 * w, 2);
  l.o = place(l.e + 3 * aw, 3);
  l.total = l.o + 3 * aw;
  return l;
}
// One full-resolution row of the glared image, out = keep·in + s_c·bilinear(acc_1) (float, in
// this order). `tmp` holds glare_row_scratch(skirt) floats (the row's vertical, then horizontal
// interpolation, and the latter's scratch: glare_row_layout).
inline size_t glare_row_scratch(const GlareSkirt& s) { return glare_row_layout(s).total; }
void glare_row(const GlareSkirt& skirt, int y, const float* in_rgb, float* out_rgb, float* tmp);
// glare_row's first part alone: row y of bilinear(acc_1), the upsampled skirt u (3·width floats,
// inside tmp, returned), for a caller that fuses the mix keep·in + s_c·u into its own row loop
// (the photon stage: sensor/pipeline.cpp).
const float* glare_skirt_row(const GlareSkirt& skirt, int y, float* tmp);

// The whole glare as an image (tests, docs); mean_signal_electrons() and expose() fuse
// glare_skirt_row and the mix into their photon rows instead.
ImageF apply_glare(const ImageF& irradiance_rgb, const LensGlare& glare, double px_per_deg);

// Energy sums of a level-1 image as the skirt computes them: Σ_i n_y(i)·Σ_j n_x(j)·v, in double,
// rows then columns in order (n = number of full-resolution children: 2, or 1 at an odd edge).
std::array<double, 3> glare_level1_energy(const ImageF& level1, int full_width, int full_height);

}  // namespace photosite
