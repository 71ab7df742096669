// RCCB's clear samples at green's level, shared by the C++ demosaic kernels
// (sensor/demosaic_detail.h GreenLevelMosaic, through the C++/GLSL common subset:
// common/prelude.glsl) and the demosaic .comp files (common/demosaic.glsl `fetch` and the RGB
// writers).
//
// The Bayer methods take RCCB's clear sites for the green ones, but a clear pixel is not at
// green's level: in photosite's box spectral basis it passes the red, green and blue bands
// (C = R + G + B, include/photosite/sensor/cfa.h, docs/sensor.md section 8), so C = 3G on a grey.
// Malvar's fixed Laplacian gains and the colour differences G - X of Hamilton-Adams, LMMSE and
// MLRI assume the green plane at unit gain with red and blue; with C in its place every
// correction was about three times too strong (docs/demosaic.md, "RCCB"). So those methods read
// kClearToGreen * C at the clear sites (1/3: the box basis's C/G on a grey), and their green
// output Ĝ, at that level, goes back to C_hat = kGreenToClear * Ĝ, G = (C_hat - R) - B.
//
// One constant for every entry point: a camera's QE curves would give another ratio (the
// integral of its clear curve over its green one), but that moves with the scene's spectrum, and
// the `demosaic` command and `ps.demosaic` have the pattern only, no preset.
//
// Arithmetic: 1/3 is not a power of two, so the round trip kGreenToClear * (kClearToGreen * C)
// is not C in every bit. At a clear site, where a method's Ĝ is that product, C_hat is therefore
// the clear sample itself, and G = (C - R) - B there is the arithmetic of before. Elsewhere C_hat
// is interpolated anyway; its scaling adds at most about 2.5 float roundings of C
// (kClearToGreen's own error 0.5, the two products' 1 each), so a flat field stays flat to
// that, the order of the methods' own rounding. Both factors are products, correctly rounded on
// the CPU and in Vulkan alike (a division is not: Vulkan allows it 2.5 ulp), in `precise`
// expressions (no FMA contraction), so the two backends give the same bits. Measured on the Kodak
// set (scripts/rccb_kodak.py, docs/demosaic.md): 1/3 gives LMMSE 39.4 dB where 1/4, the nearest
// power of two (an exact round trip), gives 33.6 and C as it is 21.3. Bilinear interpolates each
// plane from its own samples only, where a gain on C cancels, so it reads C as it is (its bits,
// also those of the fused sensor loop, are those of before).
#ifndef PHOTOSITE_CLEAR_LEVEL_GLSL
#define PHOTOSITE_CLEAR_LEVEL_GLSL
const float kClearToGreen = 1.0f / 3.0f;
const float kGreenToClear = 3.0f;

// A clear sample brought to green's level.
PS_FN float clear_to_green_level(float c) {
  precise float g = kClearToGreen * c;
  return g;
}

// RCCB's green from a pixel's (R, Ĝ at green's level, B): (C_hat - R) - B, C_hat the pixel's clear
// sample c at a clear site, else kGreenToClear * Ĝ.
PS_FN float rccb_green(bool clear_site, float c, float g_at_green_level, float r, float b) {
  precise float c_hat = clear_site ? c : kGreenToClear * g_at_green_level;
  precise float g = (c_hat - r) - b;
  return g;
}
#endif
