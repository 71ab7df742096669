// From mean photo-electrons to DN, photosite::sense() (sensor/pipeline.cpp) with the same per-pixel
// functions (common/sensor_pixel.glsl, common/poisson.glsl, written once for both):
//   μ = signal·PRNU + dark·(dark-rate factor)           (float)
//   e = min(Poisson(μ), full well)                      (one Philox call: words 0,1 the Poisson
//                                                        draw, words 2,3 the read-noise normal;
//                                                        PTRS retries draw on retry streams)
//   v = e + DSNU + σ_read·z + row + column              (double)
//   DN = clamp(⌊v·K + black + ½⌋, 0, 2^bits − 1)        (double)
// Row and column noise are one normal per row / column per frame, drawn on the host (w + h
// draws) and read from small buffers.
#version 450
#extension GL_GOOGLE_include_directive : enable
#include "common/philox.glsl"
#include "common/poisson.glsl"
#include "common/sensor_pixel.glsl"
layout(local_size_x = 256) in;

#include "common/params_sense.glsl"
layout(std430, binding = 0) readonly buffer Signal { float signal_e[]; };
layout(std430, binding = 1) readonly buffer Prnu { float prnu[]; };
layout(std430, binding = 2) readonly buffer Dsnu { float dsnu[]; };
layout(std430, binding = 3) readonly buffer DarkRate { float dark_rate[]; };
layout(std430, binding = 4) readonly buffer RowNoise { float row_e[]; };
layout(std430, binding = 5) readonly buffer ColNoise { float col_e[]; };
layout(std430, binding = 6) writeonly buffer Electrons { float electrons[]; };
layout(std430, binding = 7) writeonly buffer Raw { float raw_dn[]; };

void main() {
  const uint i = linear_invocation();
  if (i >= P.width * P.height) return;
  const uint x = i % P.width, y = i / P.width;
  const float g = (P.flags & 1u) != 0u ? prnu[i] : 1.0;
  const float off = (P.flags & 2u) != 0u ? dsnu[i] : 0.0;
  const float df = (P.flags & 4u) != 0u ? dark_rate[i] : 1.0;
  const float row = (P.flags & 8u) != 0u ? row_e[y] : 0.0;
  const float col = (P.flags & 16u) != 0u ? col_e[x] : 0.0;
  const float mean = sense_mean_e(signal_e[i], g, P.dark_mean_e, df);
  const uvec4 w = random_words(P.key, P.frame, uvec2(i, 0u), P.stream);
  const float k = poisson_from_words(mean, w, P.key, P.frame, uvec2(i, 0u), P.stream, (P.flags >> 8) & 3u);
  const float read = normal_from_words_f(w.z, w.w);
  const float e = sense_electrons(k, P.full_well_e);
  electrons[i] = e;
  raw_dn[i] = sense_raw_dn(e, off, P.read_noise_e, read, row, col, P.gain_dn_per_e, P.black_dn, P.max_code);
}
