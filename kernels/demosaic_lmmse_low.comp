// LMMSE pass 3: the Gaussian low-pass (9 taps, sigma 2) of both observation planes: sv[x, y] over
// rows of dv mirrored at the frame's top and bottom, and sh[x, y] for x in [-4, w + 4) over zh.
// Invocations [0, w h) do sv, the next (w + 8) h do sh.
#version 450
#extension GL_GOOGLE_include_directive : enable
#include "common/lmmse.glsl"
layout(std430, binding = 1) readonly buffer Dv { float dv[]; };
layout(std430, binding = 2) readonly buffer Zh { float zh[]; };
layout(std430, binding = 3) writeonly buffer Sv { float sv[]; };
layout(std430, binding = 4) writeonly buffer Sh { float sh[]; };

void main() {
  const uint i = linear_invocation();
  W = int(P.width);
  H = int(P.height);
  const uint nv = P.width * P.height;
  if (i < nv) {
    const int x = int(i % P.width), y = int(i / P.width);
    precise float s = 0.0;
    for (int k = 0; k <= 2 * kHalf; ++k) s += P.gw[k] * dv[reflect101(y + k - kHalf, H) * W + x];
    sv[i] = s;
    return;
  }
  const uint j = i - nv;
  const int ws = W + 8, wz = W + 16;
  if (j >= uint(ws) * P.height) return;
  const int xs = int(j % uint(ws)), y = int(j / uint(ws));  // x = xs - 4; zh index x + 8 = xs + 4
  precise float s = 0.0;
  for (int k = -kHalf; k <= kHalf; ++k) s += P.gw[k + kHalf] * zh[y * wz + xs + 4 + k];
  sh[j] = s;
}
