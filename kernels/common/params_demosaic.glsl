// The push constants of the demosaic kernels (demosaic_<method>.comp), defined once for both
// languages; see common/push_constants.glsl. Every kernel reads the frame (gpu::DemosaicParams);
// the LMMSE and MLRI kernels read their method's parameters after it (gpu::LmmseParams,
// gpu::MlriParams). The field lists are macros, so that each is written once and both languages
// build their types from it: C++ gets the three structs (LmmseParams and MlriParams hold the frame
// as their first member, `frame`, which std430 lays out as the frame's fields in place: 20 bytes,
// 4-byte aligned); a kernel gets one block, the frame's fields followed by those of the method
// named by DEMOSAIC_PARAMS_LMMSE or DEMOSAIC_PARAMS_MLRI, defined before common/demosaic.glsl is
// included (common/lmmse.glsl, common/mlri.glsl). gpu/kernels.h pins sizes and offsets.
#ifndef PHOTOSITE_PARAMS_DEMOSAIC_GLSL
#define PHOTOSITE_PARAMS_DEMOSAIC_GLSL
#include "common/push_constants.glsl"

// The frame (common/demosaic.glsl): the size; the 2x2 CFA cell (gpu::pack_cfa, common/cfa.glsl);
// planes_to_rgb (gpu::planes_mode): 0 R,G,B planes, 1 RCCB (G = C - R - B), 2 RCCC
// (G = B = (C - R)/2), 3 mono (C/3); black_dn, subtracted from every mosaic sample first.
#define PS_DEMOSAIC_FRAME_FIELDS \
  uint width;                    \
  uint height;                   \
  uint cfa_cell;                 \
  uint planes_to_rgb;            \
  float black_dn;

// LMMSE (common/lmmse.glsl): the 9 Gaussian weights, sigma 2, as sensor/demosaic_lmmse.cpp
// computes them (detail::lmmse_gauss_weights).
#define PS_DEMOSAIC_LMMSE_FIELDS float gw[9];

// MLRI (common/mlri.glsl): the stage's direction and its margins around the frame, the planes'
// margin, and the float constants of detail::MlriConstants.
#define PS_DEMOSAIC_MLRI_FIELDS \
  uint dir;                     \
  int mx;                       \
  int my;                       \
  int margin;                   \
  float gw[5];                  \
  float tau_n_g[2];             \
  float inv_n_g[2];             \
  float tau_n_b[4];             \
  float inv_n_b[4];             \
  float inv_box_g;              \
  float inv_box_b;

#ifdef __cplusplus
struct DemosaicParams {
  PS_DEMOSAIC_FRAME_FIELDS
};
struct LmmseParams {
  DemosaicParams frame;
  PS_DEMOSAIC_LMMSE_FIELDS
};
struct MlriParams {
  DemosaicParams frame;
  PS_DEMOSAIC_MLRI_FIELDS
};
#undef PS_DEMOSAIC_FRAME_FIELDS
#undef PS_DEMOSAIC_LMMSE_FIELDS
#undef PS_DEMOSAIC_MLRI_FIELDS
#elif defined(DEMOSAIC_PARAMS_LMMSE)
PS_PUSH_CONSTANTS(LmmseParams) {
  PS_DEMOSAIC_FRAME_FIELDS
  PS_DEMOSAIC_LMMSE_FIELDS
} PS_PUSH_INSTANCE;
#elif defined(DEMOSAIC_PARAMS_MLRI)
PS_PUSH_CONSTANTS(MlriParams) {
  PS_DEMOSAIC_FRAME_FIELDS
  PS_DEMOSAIC_MLRI_FIELDS
} PS_PUSH_INSTANCE;
#else
PS_PUSH_CONSTANTS(DemosaicParams) {
  PS_DEMOSAIC_FRAME_FIELDS
} PS_PUSH_INSTANCE;
#endif
#endif
