// LMMSE pass 4: at R/B sites the LMMSE estimates of Delta along the row and the column over
// 9-pixel windows, fused with weights inversely proportional to their error variances: d = G - X
// there, 0 at green sites (lmmse_estimate() in sensor/demosaic_lmmse.cpp, in its order).
#version 450
#extension GL_GOOGLE_include_directive : enable
#include "common/lmmse.glsl"
layout(std430, binding = 1) readonly buffer Dv { float dv[]; };
layout(std430, binding = 2) readonly buffer Zh { float zh[]; };
layout(std430, binding = 3) readonly buffer Sv { float sv[]; };
layout(std430, binding = 4) readonly buffer Sh { float sh[]; };
layout(std430, binding = 5) writeonly buffer D { float d[]; };

// 1/9 as the C++ code's 1.f / 9.f (the correctly rounded float, by its bits).
float ninth() { return uintBitsToFloat(0x3de38e39u); }

// Estimate from observation o and the window's low-pass s[0..8] and observations z[0..8].
float estimate(float o, float s[9], float z[9], out float err) {
  precise float mu = 0.0;
  for (int k = 0; k < 9; ++k) mu += s[k];
  mu *= ninth();
  precise float var_s = 1e-10, var_n = 1e-10;
  for (int k = 0; k < 9; ++k) {
    precise float a = s[k] - mu;
    precise float b = z[k] - s[k];
    var_s += a * a;
    var_n += b * b;
  }
  precise float inv = div_rn(1.0, var_s + var_n);
  precise float e = var_s * var_n * inv;
  err = e;
  precise float r = mu + var_s * inv * (o - mu);
  return r;
}

void main() {
  const uint i = linear_invocation();
  if (!frame_setup(i)) return;
  const int x = int(i % P.width), y = int(i / P.width);
  const int t = cell_type(x, y);
  if (t == 1 || t == 2) {
    d[i] = 0.0;
    return;
  }
  const int wz = W + 16, ws = W + 8;
  float s[9], z[9];
  for (int k = 0; k < 9; ++k) {
    s[k] = sh[y * ws + x + 4 + k - kHalf];
    z[k] = zh[y * wz + x + 8 + k - kHalf];
  }
  float eh, ev;
  precise float xh = estimate(zh[y * wz + x + 8], s, z, eh);
  for (int k = 0; k < 9; ++k) {
    const int yy = reflect101(y + k - kHalf, H);
    s[k] = sv[yy * W + x];
    z[k] = dv[yy * W + x];
  }
  precise float xv = estimate(dv[i], s, z, ev);
  precise float r = div_rn(xh * ev + xv * eh, eh + ev);
  d[i] = r;
}
