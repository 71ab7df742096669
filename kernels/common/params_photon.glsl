// photon.comp's push constants (gpu::PhotonParams); see common/push_constants.glsl.
#include "common/push_constants.glsl"
PS_PUSH_CONSTANTS(PhotonParams) {
  uint width;
  uint height;
  uint cfa_cell;  // the CFA pattern's 2x2 cell (gpu::pack_cfa)
  uint pad;
  double pitch_over_f;  // 0: no cos⁴ falloff
  double cx;            // optical centre (pixels)
  double cy;
} PS_PUSH_INSTANCE;
