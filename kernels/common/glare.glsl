// Shared by kernels/glare_*.comp and photon.comp: the lens-glare pyramid's borders and taps,
// as sensor/glare.cpp (mirror(), up_tap()).
#ifndef PHOTOSITE_GLARE_GLSL
#define PHOTOSITE_GLARE_GLSL
// Half-sample symmetric mirror, periodic: equal to glare.cpp's mirror() for every i and n >= 1.
int glare_mirror(int i, int n) {
  const int period = 2 * n;
  int m = i < 0 ? -1 - i : i;  // the mirror about −1/2 (f(−1 − i) = f(i))
  m = m % period;
  return m < n ? m : period - 1 - m;
}
// Bilinear 2x upsampling taps (fine x at coarse x/2 − 1/4, edge clamped), lower index first.
void glare_up_tap(int x, int n_coarse, out int i0, out int i1, out float w0, out float w1) {
  const int j = x >> 1;
  if ((x & 1) != 0) {
    i0 = j; i1 = min(j + 1, n_coarse - 1); w0 = 0.75; w1 = 0.25;
  } else {
    i0 = max(j - 1, 0); i1 = j; w0 = 0.25; w1 = 0.75;
  }
}
#endif
