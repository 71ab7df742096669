// compose.comp's push constants (gpu::ComposeParams); see common/push_constants.glsl.
#include "common/push_constants.glsl"
PS_PUSH_CONSTANTS(ComposeParams) {
  uint width;
  uint height;
  uvec2 ground_mask;  // bit id: class id is a ground class
  float tint_over_pi[3];
  uint pad;
} PS_PUSH_INSTANCE;
