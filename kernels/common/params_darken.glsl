// darken.comp's push constants (gpu::DarkenParams, from scene::darken_params()); see
// common/push_constants.glsl.
#include "common/push_constants.glsl"
PS_PUSH_CONSTANTS(DarkenParams) {
  float ground[3];
  float vertical[3];
  double K[3];
  double rho_sky;
  double glow[3];
  uvec2 ground_mask;  // bit id: class id is a ground class
  uint n;
  uint sky_id;
} PS_PUSH_INSTANCE;
