// Shared machinery of the Bayer demosaicers (sensor/demosaic*.cpp), not a public header.
//
// Every method is written once, for the RGGB arrangement, as a per-pixel formula over a fetch
// functor f(plane, dx, dy). The row driver below turns the other phases into RGGB by where it
// starts each row's pixel pairs (the cell type of a pixel is fixed by the parities of x and y
// relative to the red site), so there is no per-pixel switch on colour: each row is a loop over
// (R,G) or (G,B) pairs with the cell types as template constants, which the compiler vectorizes.
// Only the few border columns whose stencil leaves the image take a slow path with mirrored
// (reflect-101) coordinates; rows are mirrored by choosing row pointers, which costs nothing.
// Reflect-101 maps -k to k and n-1+k to n-1-k, so it keeps every pixel's parity and with it the
// CFA colour: the mirrored border is a valid mosaic of the mirrored scene.
#pragma once
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "photosite/error.h"
#include "photosite/image.h"
#include "photosite/sensor/cfa.h"
#include "photosite/sensor/demosaic.h"

namespace photosite::shader {
#include "common/prelude.glsl"
#include "common/border.glsl"
#include "common/clear_level.glsl"
#include "common/prelude_end.glsl"
}  // namespace photosite::shader

namespace photosite::detail {

// Cell types of the RGGB arrangement: 0 = R, 1 = G in a red row, 2 = G in a blue row, 3 = B.
enum CellType { kR = 0, kGr = 1, kGb = 2, kB = 3 };

// Bilinear by normalized convolution, any pattern (sensor/demosaic.cpp): the fallback of every
// method for RCCC, Mono and mosaics smaller than 2x2.
ImageF demosaic_bilinear_generic(const ImageF& m, CfaPattern pattern);

// Where the red (for RCCB also red) site sits in the 2x2 cell.
struct BayerPhase {
  int ox = 0, oy = 0;
  bool clear = false;  // RCCB: the "green" sites are clear (R+G+B)
};
inline bool has_bayer_geometry(CfaPattern p) { return is_bayer(p) || p == CfaPattern::RCCB; }
inline BayerPhase bayer_phase(CfaPattern p) {
  switch (p) {
    case CfaPattern::RGGB: return {0, 0, false};
    case CfaPattern::BGGR: return {1, 1, false};
    case CfaPattern::GRBG: return {1, 0, false};
    case CfaPattern::GBRG: return {0, 1, false};
    case CfaPattern::RCCB: return {0, 0, true};
    default: internal_error("bayer_phase: not a Bayer-geometry pattern");
  }
}
inline int cell_type(const BayerPhase& ph, int x, int y) {
  return (((y - ph.oy) & 1) << 1) | ((x - ph.ox) & 1);
}

// The mirrored Bayer path needs a Bayer-geometry pattern and at least 2x2 pixels.
inline bool bayer_path_ok(int w, int h, CfaPattern p) { return has_bayer_geometry(p) && w >= 2 && h >= 2; }
inline bool bayer_path_ok(const ImageF& m, CfaPattern p) { return bayer_path_ok(m.width(), m.height(), p); }

// Reflect-101 index into [0, n), n >= 2 (period 2(n-1), even: parity is kept), written once in
// kernels/common/border.glsl for this file and the demosaic .comp files.
inline int reflect(int i, int n) { return shader::reflect101(i, n); }

// RCCB: planes (R, C, B) at a pixel become R, G = C - R - B, B (cfa.h: a clear filter passes
// R+G+B). Bilinear's conversion; the other methods read C at green's level (GreenLevelMosaic).
inline void clear_to_rgb(float* o) { o[1] = o[1] - o[0] - o[2]; }

// The mosaic the Bayer methods other than bilinear read: for RCCB a copy with every clear sample
// times kClearToGreen (kernels/common/clear_level.glsl says why 1/3 and how the arithmetic stays
// exact where it was), else the mosaic itself. finish() then turns the method's output
// (R, Ĝ at green's level, B) into (R, G, B). Bilinear takes each plane from its own samples
// only, where the gain cancels, and reads C as it is.
class GreenLevelMosaic {
 public:
  GreenLevelMosaic(const ImageF& m, const BayerPhase& ph);
  const ImageF& get() const { return ph_.clear ? scaled_ : m_; }
  // RCCB: G = (C_hat - R) - B at every pixel of rgb (shader::rccb_green); otherwise nothing.
  void finish(ImageF& rgb) const;

 private:
  const ImageF& m_;
  BayerPhase ph_;
  ImageF scaled_;
};

// Where a kernel writes one pixel's kOut values: channel c at p[c * stride]. The fast path
// writes planar rows (unit-stride, so the pair loop vectorizes) and interleaves them after.
struct PixelOut {
  float* p;
  size_t stride;
  float& operator[](int c) const { return p[c * stride]; }
};

// The fast path over one row: npairs pixel pairs from column xs, cell types T0, T1; outputs
// planar at base[c * stride + x]. Rows away from the top and bottom are addressed from one
// centre pointer per plane and the row pitch (what lets the compiler vectorize the pair loop);
// the Rad rows at each end go through their mirrored row pointers.
template <int T0, int T1, int NPlanes, int Rad, bool Interior, class K>
inline void pair_loop(const K& k, const float* const (&rows)[NPlanes][2 * Rad + 1], ptrdiff_t pitch,
                      float* __restrict base, int stride, int xs, int npairs) {
  const size_t st = static_cast<size_t>(stride);
  if constexpr (Interior) {
    const float* c[NPlanes];
    for (int p = 0; p < NPlanes; ++p) c[p] = rows[p][Rad];
    // The planar output never overlaps the input planes.
#pragma GCC ivdep
    for (int i = 0; i < npairs; ++i) {
      const int x = xs + 2 * i;
      auto f0 = [&](int p, int dx, int dy) { return c[p][dy * pitch + x + dx]; };
      auto f1 = [&](int p, int dx, int dy) { return c[p][dy * pitch + x + 1 + dx]; };
      k.template px<T0>(f0, PixelOut{base + x, st});
      k.template px<T1>(f1, PixelOut{base + x + 1, st});
    }
  } else {
    for (int i = 0; i < npairs; ++i) {
      const int x = xs + 2 * i;
      auto f0 = [&](int p, int dx, int dy) { return rows[p][dy + Rad][x + dx]; };
      auto f1 = [&](int p, int dx, int dy) { return rows[p][dy + Rad][x + 1 + dx]; };
      k.template px<T0>(f0, PixelOut{base + x, st});
      k.template px<T1>(f1, PixelOut{base + x + 1, st});
    }
  }
}

// A row's interior pixels [xs, xe) of a one-plane, radius-1, three-channel kernel formed and
// written to the output row o (interleaved RGB) by other code: rows above, centre and below
// (the mosaic rows y − 1, y, y + 1), red_row whether row y holds the red (or blue: false) sites,
// ox the red site's column parity, clear RCCB's G = C − R − B. Returns false where it did not
// (then the pair loop and the interleave run). The bilinear row on AVX-512 and AVX2
// (sensor/demosaic.cpp).
using InteriorRow = bool (*)(const float* above, const float* centre, const float* below, bool red_row, int ox,
                             bool clear, int xs, int xe, float* o);

// One output row y of kernel K (see run_stencil): rows[p][Rad + d] is plane p's mosaic row
// reflect(y + d, h), o the output row (K::kOut channels), planar a 3w-float scratch row (unused
// for a 1-channel output). Rows away from the top and bottom take the pitch-addressed fast path
// when their 2Rad+1 rows lie one after the other at pitch w in memory (whole images, and the
// band buffer of the fused sensor loop, sensor/pipeline.cpp); otherwise the same formula reads
// through the row pointers: the same values and operations, so the same bits. interior, when
// given, forms the pair loop's pixels instead (InteriorRow).
template <bool Clear, int NPlanes, int Rad, class K>
void stencil_row(const K& k, const BayerPhase& ph, const float* const (&rows)[NPlanes][2 * Rad + 1], int y,
                 int w, int h, float* o, float* planar, InteriorRow interior = nullptr) {
  constexpr int kOut = K::kOut;
  // First column >= Rad at the red site's column parity, and the pair count that keeps every
  // fast-path stencil inside the image.
  const int xs = Rad + ((Rad - ph.ox) & 1);
  const int npairs = std::max(0, (w - Rad - xs) / 2);
  const int xe = xs + 2 * npairs;
  const bool red_row = ((y - ph.oy) & 1) == 0;
  auto slow = [&](int x) {
    auto f = [&](int p, int dx, int dy) { return rows[p][dy + Rad][reflect(x + dx, w)]; };
    const PixelOut ox{o + static_cast<size_t>(kOut) * x, 1};
    switch (cell_type(ph, x, y)) {
      case kR: k.template px<kR>(f, ox); break;
      case kGr: k.template px<kGr>(f, ox); break;
      case kGb: k.template px<kGb>(f, ox); break;
      default: k.template px<kB>(f, ox); break;
    }
    if constexpr (Clear && kOut == 3) clear_to_rgb(&ox[0]);
  };
  for (int x = 0; x < std::min(xs, w); ++x) slow(x);
  for (int x = std::max(xe, xs); x < w; ++x) slow(x);
  if constexpr (NPlanes == 1 && Rad == 1 && kOut == 3)
    if (interior && interior(rows[0][0], rows[0][1], rows[0][2], red_row, ph.ox, Clear, xs, xe, o)) return;
  float* base = kOut == 1 ? o : planar;
  const int stride = kOut == 1 ? 0 : w;
  const ptrdiff_t pitch = w;  // every plane is one channel wide
  bool contiguous = y >= Rad && y < h - Rad;
  for (int p = 0; p < NPlanes && contiguous; ++p)
    for (int d = 0; d < 2 * Rad; ++d) contiguous = contiguous && rows[p][d] + pitch == rows[p][d + 1];
  if (contiguous) {
    if (red_row) pair_loop<kR, kGr, NPlanes, Rad, true>(k, rows, pitch, base, stride, xs, npairs);
    else pair_loop<kGb, kB, NPlanes, Rad, true>(k, rows, pitch, base, stride, xs, npairs);
  } else {
    if (red_row) pair_loop<kR, kGr, NPlanes, Rad, false>(k, rows, pitch, base, stride, xs, npairs);
    else pair_loop<kGb, kB, NPlanes, Rad, false>(k, rows, pitch, base, stride, xs, npairs);
  }
  if constexpr (kOut == 3) {
    float* r = planar;
    if constexpr (Clear) {  // G = C - R - B
      float* g = r + w;
      const float* bl = r + 2 * w;
      for (int x = xs; x < xe; ++x) g[x] = g[x] - r[x] - bl[x];
    }
    interleave_rgb(r + xs, r + w + xs, r + 2 * w + xs, o + 3 * xs, xe - xs);
  }
}

// Runs kernel K over every pixel: K::template px<T>(f, out) writes K::kOut values for a pixel
// of cell type T, reading inputs through f(plane, dx, dy). `planes` are the input images (same
// size, one channel each), Rad the stencil radius. out has K::kOut channels.
template <bool Clear, int NPlanes, int Rad, class K>
void run_stencil_impl(const ImageF* const (&planes)[NPlanes], const BayerPhase& ph, ImageF& out,
                      const K& k) {
  const int w = out.width(), h = out.height();
  constexpr int kOut = K::kOut;
#pragma omp parallel
  {
    // Planar row buffers for 3-channel output (a 1-channel output is written in place).
    std::vector<float> planar(kOut == 1 ? 0 : static_cast<size_t>(3) * w);
#pragma omp for schedule(static)
    for (int y = 0; y < h; ++y) {
      const float* rows[NPlanes][2 * Rad + 1];
      for (int p = 0; p < NPlanes; ++p)
        for (int d = -Rad; d <= Rad; ++d) rows[p][d + Rad] = planes[p]->row(reflect(y + d, h));
      stencil_row<Clear, NPlanes, Rad>(k, ph, rows, y, w, h, out.row(y), planar.data());
    }
  }
}

// convert_clear: RCCB output, (R, C, B) turned into (R, G, B) as each pixel is written.
template <int Rad, int NPlanes, class K>
void run_stencil(const ImageF* const (&planes)[NPlanes], const BayerPhase& ph, ImageF& out,
                 const K& k, bool convert_clear = false) {
  if (convert_clear) run_stencil_impl<true, NPlanes, Rad>(planes, ph, out, k);
  else run_stencil_impl<false, NPlanes, Rad>(planes, ph, out, k);
}

// Caps the vector level of interleave_rgb (0 SSE2 and scalar, 1 AVX2, 2 AVX-512; the machine's
// level is the most it takes); the tests run each level. Every level writes the same floats.
void interleave_rgb_max_isa(int isa);
}  // namespace photosite::detail
