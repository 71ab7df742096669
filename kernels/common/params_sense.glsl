// sense.comp's push constants (gpu::SenseParams); see common/push_constants.glsl.
#include "common/push_constants.glsl"
PS_PUSH_CONSTANTS(SenseParams) {
  uint width;
  uint height;
  uint frame;
  uint stream;
  uvec2 key;   // temporal key (low, high)
  uint flags;  // 1 PRNU, 2 DSNU, 4 dark-rate map, 8 row noise, 16 column noise;
               // bits 8-9: the PoissonMethod (0 exact, 1 cornish-fisher, 2 normal)
  float dark_mean_e;
  float full_well_e;
  float read_noise_e;
  double gain_dn_per_e;
  double black_dn;
  double max_code;
} PS_PUSH_INSTANCE;
