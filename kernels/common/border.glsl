// Border handling shared by the C++ demosaic kernels (sensor/demosaic_detail.h, through the
// C++/GLSL common subset: common/prelude.glsl) and the demosaic .comp files (common/demosaic.glsl).
#ifndef PHOTOSITE_BORDER_GLSL
#define PHOTOSITE_BORDER_GLSL
// Reflect-101 index into [0, n), n >= 2: period 2(n - 1), even, so the parity (hence the CFA
// colour) of an index is kept. The mirror about 0 is taken first, so that % only sees
// non-negative operands (GLSL leaves % of a negative operand undefined); reflect-101 is even
// (f(-i) = f(i)), so this is the same index.
PS_FN int reflect101(int i, int n) {
  if (i >= 0 && i < n) return i;
  const int period = 2 * (n - 1);
  const int r = (i < 0 ? -i : i) % period;
  return r < n ? r : period - r;
}
#endif
