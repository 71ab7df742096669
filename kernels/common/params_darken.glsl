// darken.comp's push constants (gpu::DarkenParams, from scene::darken_params()); see
// common/push_constants.glsl.
#include "common/push_constants.glsl"
PS_PUSH_CONSTANTS(DarkenParams) {
  float ambient[3];  // E/π of moon and sky glow, every class but the sky
  double K[3];
  double rho_sky;
  double glow[3];
  uint n;
  uint sky_id;
} PS_PUSH_INSTANCE;
