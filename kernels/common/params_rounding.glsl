// rounding.comp's push constants (gpu::RoundingParams); see common/push_constants.glsl.
#include "common/push_constants.glsl"
PS_PUSH_CONSTANTS(RoundingParams) {
  uint n;          // the number of (a, b) pairs
  int shift_ulps;  // how far the first values are moved before div_rn and sqrt_rn settle them
} PS_PUSH_INSTANCE;
