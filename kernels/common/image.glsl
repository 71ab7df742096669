// Interleaved RGB float images in storage buffers, and OpenCV's default border
// (BORDER_REFLECT_101: ... c b | a b c ... | b a ...) that the CPU bloom's cv:: calls use.
#ifndef PHOTOSITE_IMAGE_GLSL
#define PHOTOSITE_IMAGE_GLSL
int reflect101(int i, int n) {
  if (n == 1) return 0;
  while (i < 0 || i >= n) i = i < 0 ? -i : 2 * n - 2 - i;
  return i;
}
#endif
