// The colour filter over pixel (x, y), from the pattern's 2x2 cell packed by the host
// (gpu::pack_cfa: byte ((y&1)<<1 | (x&1)) = cfa_color(pattern, x&1, y&1)), so the patterns are
// defined once, in include/photosite/sensor/cfa.h.
#ifndef PHOTOSITE_CFA_GLSL
#define PHOTOSITE_CFA_GLSL
uint cfa_color(uint cell, uint x, uint y) { return (cell >> (8u * (((y & 1u) << 1) | (x & 1u)))) & 0xffu; }
#endif
