// photon.comp's push constants (gpu::PhotonParams); see common/push_constants.glsl.
#include "common/push_constants.glsl"
PS_PUSH_CONSTANTS(PhotonParams) {
  uint width;
  uint height;
  uint cfa_cell;  // the CFA pattern's 2x2 cell (gpu::pack_cfa)
  uint glare;     // 1: mix the glare skirt in
  double pitch_over_f;  // 0: no cos⁴ falloff
  double cx;            // optical centre (pixels)
  double cy;
  float keep;  // 1 − η
  uint pad;
} PS_PUSH_INSTANCE;
