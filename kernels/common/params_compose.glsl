// compose.comp's push constants (gpu::ComposeParams); see common/push_constants.glsl.
#include "common/push_constants.glsl"
PS_PUSH_CONSTANTS(ComposeParams) {
  uint width;
  uint height;
  uvec2 beam_mask;  // bit id: the beam lights class id (scene::beam_lit_class_bits: ground and vertical)
  float tint_over_pi[3];
  uint pad;
} PS_PUSH_INSTANCE;
