// Private (not installed): the lens glare's per-pixel maths, written once in
// kernels/common/glare.glsl (the C++/GLSL common subset, prelude in kernels/common/prelude.glsl)
// and compiled here as C++ in namespace photosite::shader; kernels/glare_*.comp and photon.comp
// compile the same file.
#pragma once
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>

#include "photosite/sensor/glare.h"

namespace photosite::shader {
#include "common/prelude.glsl"
#include "common/glare.glsl"
#include "common/prelude_end.glsl"
}  // namespace photosite::shader

namespace photosite::detail {
// glare_skirt_row's vertical step alone: row y of acc_1 interpolated between its two nearest
// rows, t (3·acc_1 width floats, interleaved RGB, inside tmp at glare_row_layout's t, returned),
// for a caller that forms the horizontal step in its own loop (glare_row's AVX-512 pairs).
const float* glare_skirt_vertical_row(const GlareSkirt& skirt, int y, float* tmp);
// That step's two rows of acc_1 and their weights for row y: t[k] = glare_lerp(w0, a[k], w1, b[k])
// for k < 3·acc_1 width, for a caller that forms t inside its own loop (the photon stage's
// AVX-512 and AVX2 rows) instead of storing it and reading it back.
struct GlareVerticalTaps {
  const float* a;
  const float* b;
  float w0, w1;
};
GlareVerticalTaps glare_skirt_vertical_taps(const GlareSkirt& skirt, int y);
// t[k] of those taps for k in [k0, k1) only, into t[k0, k1): the samples glare_skirt_vertical_row
// stores there (the same loop over a part of the row).
void glare_vertical_lerp(const GlareVerticalTaps& v, size_t k0, size_t k1, float* t);

// Pixel x of the bilinear 2x upsampling along a row (glare_up_tap's taps, edge clamped) of t,
// cw interleaved RGB pixels, into u3[0..2].
inline void glare_up_pixel(const float* t, int cw, int x, float* u3) {
  const shader::GlareTap tx = shader::glare_up_tap(x, cw);
  for (int c = 0; c < 3; ++c) u3[c] = shader::glare_lerp(tx.w0, t[3 * tx.i0 + c], tx.w1, t[3 * tx.i1 + c]);
}
// glare_level1_energy's row sums (Σ_j n_x(j)·v per channel, in double and in order) of nr <= 8
// rows r[0 .. nr) of w pixels at once into out[0 .. nr), as the pyramid forms them
// (sensor/glare.cpp: eight independent chains of adds; AVX2 where the CPU has it).
void glare_level1_row_sums(const float* const* r, int nr, int w, int full_width, std::array<double, 3>* out);
// The glare skirts (process-wide, since start) whose pyramid read the full-resolution irradiance
// for its level 1 because no level 1 was handed in (glare_skirt(in, plan, nullptr), plan
// active): what shows that a caller (batch, the night chain) handed the compose pass's level on.
uint64_t glare_full_resolution_level1_count();

}  // namespace photosite::detail
