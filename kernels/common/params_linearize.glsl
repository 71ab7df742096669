// linearize.comp's push constants (gpu::LinearizeParams); see common/push_constants.glsl.
#include "common/push_constants.glsl"
PS_PUSH_CONSTANTS(LinearizeParams) {
  uint n;         // pixels
  uint channels;  // of the input
  uint decode;    // 1: sRGB-encoded codes through the table; 0: linear already
  uint pad;
} PS_PUSH_INSTANCE;
