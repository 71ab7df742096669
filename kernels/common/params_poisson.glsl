// poisson.comp's and philox_words.comp's push constants (gpu::PoissonParams; philox_words
// ignores `method`); see common/push_constants.glsl.
#include "common/push_constants.glsl"
PS_PUSH_CONSTANTS(PoissonParams) {
  uint n;
  uint frame;
  uint stream;
  uint method;  // PoissonMethod: 0 exact, 1 cornish-fisher, 2 normal
  uvec2 first_pixel;
  uvec2 key;
} PS_PUSH_INSTANCE;
