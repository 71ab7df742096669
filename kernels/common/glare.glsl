// The lens glare's per-pixel maths (sensor/glare.h, docs/model_glare.md), written once in the
// C++/GLSL common subset (common/prelude.glsl): the pyramid's mirrored borders, its bilinear 2x
// upsampling taps and steps, and the final mix keep·L + s_c·u. kernels/glare_*.comp and
// photon.comp include it after the prelude; sensor/glare_detail.h compiles it as C++ for
// sensor/glare.cpp (glare_skirt, glare_row), so both backends run the same float operations in
// the same order (the Gpu.* glare tests compare them bit for bit).
#ifndef PHOTOSITE_GLARE_GLSL
#define PHOTOSITE_GLARE_GLSL

// Half-sample symmetric mirror, periodic (…, 1, 0 | 0, 1, …, n−1 | n−1, …), for every i and
// n >= 1: a symmetric kernel applied with it conserves the sum exactly, for any offset.
PS_FN int glare_mirror(int i, int n) {
  const int period = 2 * n;
  int m = i < 0 ? -1 - i : i;  // the mirror about −1/2 (f(−1 − i) = f(i))
  m = m % period;
  return m < n ? m : period - 1 - m;
}

// Bilinear 2x upsampling taps, pixel-centre aligned (fine x sits at coarse x/2 − 1/4), edge
// clamped, lower coarse index first. The column sums of this operator equal the number of fine
// children of each coarse pixel (2, or 1 for the last one of an odd size), so Σ over the fine
// image = Σ n·coarse.
struct GlareTap {
  int i0;
  int i1;
  float w0;
  float w1;
};
PS_FN GlareTap glare_up_tap(int x, int n_coarse) {
  GlareTap t;
  const int j = x >> 1;
  if ((x & 1) != 0) {
    t.i0 = j;
    t.i1 = min(j + 1, n_coarse - 1);
    t.w0 = 0.75f;
    t.w1 = 0.25f;
  } else {
    t.i0 = max(j - 1, 0);
    t.i1 = j;
    t.w0 = 0.25f;
    t.w1 = 0.75f;
  }
  return t;
}

// One bilinear step between two taps: w0·a + w1·b (rows first, then columns).
PS_FN float glare_lerp(float w0, float a, float w1, float b) {
  precise float v = w0 * a + w1 * b;
  return v;
}

// The glared radiance of one channel: keep·L + s_c·u, keep = 1 − η the share left in place, s_c
// the channel's skirt scale, u the upsampled skirt (sensor/glare.h).
PS_FN float glare_mix(float keep, float l, float s, float u) {
  precise float g = keep * l + s * u;
  return g;
}

#endif
