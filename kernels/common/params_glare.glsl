// The push constants of glare_down.comp, glare_blur.comp, glare_up.comp and glare_norm.comp (one
// block for all four, gpu::GlareParams); see common/push_constants.glsl.
#include "common/push_constants.glsl"
PS_PUSH_CONSTANTS(GlareParams) {
  int src_w, src_h, dst_w, dst_h;
  int mode, flags;
  float weight;
  float taps[4];
  uint pad;
  double eta;
} PS_PUSH_INSTANCE;
