// The lens-glare energies and scale (sensor/glare.cpp glare_level1_energy, glare_skirt), in
// double and in the CPU's order. mode 0: invocation r < 2·h1 sums row r mod h1 of level 1
// (r < h1) or of acc_1 (r >= h1): Σ_j n_x(j)·v, n = number of full-resolution children (2, or
// 1 at an odd edge). mode 1 (one invocation): E = Σ_i n_y(i)·row_i per image, and the scale
// s_c = float(η·E_in,c / E_skirt,c) (0 when E_skirt is 0).
// src_w x src_h: the full-resolution size; dst_w x dst_h: level 1.
#version 450
#extension GL_GOOGLE_include_directive : enable
#include "common/philox.glsl"
layout(local_size_x = 64) in;

// gpu::GlareParams (gpu/kernels.h)
#include "common/params_glare.glsl"
layout(std430, binding = 0) readonly buffer Level1 { float level1[]; };
layout(std430, binding = 1) readonly buffer Acc1 { float acc1[]; };
layout(std430, binding = 2) buffer Rows { double rows[]; };  // [image][row][channel]
layout(std430, binding = 3) writeonly buffer Scale { float scale[]; };

void main() {
  const uint i = linear_invocation();
  const int h1 = P.dst_h, w1 = P.dst_w;
  if (P.mode == 0) {
    if (i >= uint(2 * h1)) return;
    const int r = int(i) % h1;
    const bool skirt = int(i) >= h1;
    precise double s0 = 0.0lf, s1 = 0.0lf, s2 = 0.0lf;
    for (int j = 0; j < w1; ++j) {
      const double n = 2 * j + 1 < P.src_w ? 2.0lf : 1.0lf;
      const int k = 3 * (r * w1 + j);
      const float v0 = skirt ? acc1[k] : level1[k];
      const float v1 = skirt ? acc1[k + 1] : level1[k + 1];
      const float v2 = skirt ? acc1[k + 2] : level1[k + 2];
      s0 += n * double(v0);
      s1 += n * double(v1);
      s2 += n * double(v2);
    }
    rows[3 * i] = s0;
    rows[3 * i + 1] = s1;
    rows[3 * i + 2] = s2;
    return;
  }
  if (i != 0u) return;
  precise double e[6] = double[6](0.0lf, 0.0lf, 0.0lf, 0.0lf, 0.0lf, 0.0lf);
  for (int img = 0; img < 2; ++img)
    for (int r = 0; r < h1; ++r) {
      const double n = 2 * r + 1 < P.src_h ? 2.0lf : 1.0lf;
      for (int c = 0; c < 3; ++c) e[3 * img + c] += n * rows[3 * (img * h1 + r) + c];
    }
  for (int c = 0; c < 3; ++c) {
    precise double q = P.eta * e[c];
    scale[c] = e[3 + c] > 0.0lf ? float(q / e[3 + c]) : 0.0;
  }
}
