// The parameter structs of the kernels, each defined once, in kernels/common/params_*.glsl, which
// both languages read (common/push_constants.glsl). The static_asserts pin every size and offset
// to the kernels' std430 layout (scalars 4-byte aligned, uvec2 8, double 8).
#pragma once
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>

#include <fmt/format.h>

#include "photosite/error.h"
#include "photosite/gpu/kernel.h"
#include "photosite/sensor/cfa.h"
#include "photosite/sensor/demosaic.h"

// The push-constant blocks defined once for C++ and GLSL (kernels/common/push_constants.glsl).
namespace photosite::shader {
#include "common/prelude.glsl"
#include "common/params_photon.glsl"
#include "common/params_sense.glsl"
#include "common/params_darken.glsl"
#include "common/params_compose.glsl"
#include "common/params_linearize.glsl"
#include "common/params_poisson.glsl"
#include "common/params_glare.glsl"
#include "common/params_demosaic.glsl"
#include "common/params_rounding.glsl"
#include "common/prelude_end.glsl"
}  // namespace photosite::shader

namespace photosite::gpu {

// {low, high} halves of a 64-bit value, as GLSL's uvec2.
struct U64 {
  uint32_t lo, hi;
  static U64 of(uint64_t v) { return {static_cast<uint32_t>(v), static_cast<uint32_t>(v >> 32)}; }
  operator shader::uvec2() const { return shader::uvec2(lo, hi); }  // for the shared blocks
};

// poisson.comp, philox_words.comp (which ignores `method`, the PoissonMethod's value)
using shader::PoissonParams;  // kernels/common/params_poisson.glsl
static_assert(sizeof(PoissonParams) == 32 && offsetof(PoissonParams, first_pixel) == 16 &&
              offsetof(PoissonParams, key) == 24);

// rounding.comp (gpu::rounding_probe)
using shader::RoundingParams;  // kernels/common/params_rounding.glsl
static_assert(sizeof(RoundingParams) == 8 && offsetof(RoundingParams, shift_ulps) == 4);

// A 1-D job of n items in groups of `local`, laid out as x * y groups (x <= 65535, the
// guaranteed maxComputeWorkGroupCount), matching linear_invocation() in common/philox.glsl.
// That index is 32-bit: a grid of more than 2^32 invocations would wrap it onto pixels already
// done (compose adds in place: twice), and UINT32_MAX is the kernels' "no bad pixel" mark, so
// such a job is refused here, for every kernel (PHOTOSITE_MAX_PIXELS refuses it sooner).
struct Grid { uint32_t x, y; };
inline Grid grid_1d(uint64_t n, uint32_t local = 256) {
  const uint64_t groups = (n + local - 1) / local;
  const Grid g = groups <= 65535 ? Grid{static_cast<uint32_t>(groups ? groups : 1), 1}
                                 : Grid{65535, static_cast<uint32_t>((groups + 65534) / 65535)};
  if (static_cast<uint64_t>(g.x) * g.y * local >= (uint64_t{1} << 32))
    fail(fmt::format("Vulkan: a dispatch over {} items is beyond the kernels' 32-bit invocation index "
                     "(at most {} per dispatch)",
                     n, ((uint64_t{1} << 32) - 1) / (65535ull * local) * 65535ull * local));
  return g;
}

}  // namespace photosite::gpu

namespace photosite::gpu {

// photon.comp
using shader::PhotonParams;  // kernels/common/params_photon.glsl
static_assert(sizeof(PhotonParams) == 48 && offsetof(PhotonParams, pitch_over_f) == 16 &&
              offsetof(PhotonParams, cy) == 32 && offsetof(PhotonParams, keep) == 40);

// glare_down.comp, glare_blur.comp, glare_up.comp, glare_norm.comp (one block for all four)
using shader::GlareParams;  // kernels/common/params_glare.glsl
static_assert(sizeof(GlareParams) == 56 && offsetof(GlareParams, weight) == 24 &&
              offsetof(GlareParams, taps) == 28 && offsetof(GlareParams, eta) == 48);

// sense.comp
using shader::SenseParams;  // kernels/common/params_sense.glsl
static_assert(sizeof(SenseParams) == 64 && offsetof(SenseParams, key) == 16 &&
              offsetof(SenseParams, flags) == 24 && offsetof(SenseParams, read_noise_e) == 36 &&
              offsetof(SenseParams, gain_dn_per_e) == 40 && offsetof(SenseParams, max_code) == 56);
enum SenseFlags : uint32_t { kHasPrnu = 1, kHasDsnu = 2, kHasDarkRate = 4, kHasRowNoise = 8, kHasColumnNoise = 16 };
inline constexpr int kSensePoissonShift = 8;  // flags bits 8-9: the PoissonMethod's value

// A pattern's 2x2 cell for common/cfa.glsl: byte ((y&1)<<1 | (x&1)) = cfa_color(p, x, y).
inline uint32_t pack_cfa(CfaPattern p) {
  uint32_t cell = 0;
  for (int y = 0; y < 2; ++y)
    for (int x = 0; x < 2; ++x) cell |= static_cast<uint32_t>(cfa_color(p, x, y)) << (8 * ((y << 1) | x));
  return cell;
}
// filter_planes_to_rgb's cases (sensor/demosaic.cpp) as demosaic_bilinear.comp numbers them.
inline uint32_t planes_mode(CfaPattern p) {
  switch (p) {
    case CfaPattern::RCCB: return 1;
    case CfaPattern::RCCC: return 2;
    case CfaPattern::Mono: return 3;
    default: return 0;
  }
}

// demosaic_<method>.comp: the frame every method reads; LMMSE's and MLRI's own parameters after it
// (kernels/common/params_demosaic.glsl; LmmseParams and MlriParams hold the frame as `frame`).
using shader::DemosaicParams;
using shader::LmmseParams;  // the 9 Gaussian weights (common/lmmse.glsl)
using shader::MlriParams;   // direction, margins, detail::MlriConstants (common/mlri.glsl)
static_assert(sizeof(DemosaicParams) == 20 && offsetof(DemosaicParams, cfa_cell) == 8 &&
              offsetof(DemosaicParams, planes_to_rgb) == 12 && offsetof(DemosaicParams, black_dn) == 16);
static_assert(sizeof(LmmseParams) == 56 && offsetof(LmmseParams, gw) == 20);
static_assert(sizeof(MlriParams) == 112 && offsetof(MlriParams, dir) == 20 && offsetof(MlriParams, margin) == 32 &&
              offsetof(MlriParams, gw) == 36 && offsetof(MlriParams, tau_n_g) == 56 &&
              offsetof(MlriParams, inv_n_g) == 64 && offsetof(MlriParams, tau_n_b) == 72 &&
              offsetof(MlriParams, inv_n_b) == 88 && offsetof(MlriParams, inv_box_g) == 104 &&
              offsetof(MlriParams, inv_box_b) == 108);

class Sequence;
class Buffer;

// Scratch planes of a multi-pass method on the device, by name and size in bytes (kept by the
// caller, e.g. reused frame to frame by the sensor chain).
using ScratchBuffers = std::function<Buffer&(const std::string& name, size_t bytes)>;

// Records a demosaic of `raw` (width x height floats, black_dn subtracted on the fly) into `rgb`
// (3 floats per pixel) with the method's kernels (gpu/stages.cpp): one dispatch for bilinear and
// Malvar, two for Hamilton-Adams, five for LMMSE, fourteen for MLRI, their intermediate planes from
// `scratch`.
// `label` names the dispatches in stage timings.
void record_demosaic(Context& ctx, Sequence& s, DemosaicMethod method, const DemosaicParams& p, Buffer& raw,
                     Buffer& rgb, const ScratchBuffers& scratch, const std::string& label = {});

}  // namespace photosite::gpu

namespace photosite::gpu {

// darken.comp, from scene::DarkenParams
using shader::DarkenParams;  // kernels/common/params_darken.glsl
static_assert(sizeof(DarkenParams) == 80 && offsetof(DarkenParams, K) == 16 &&
              offsetof(DarkenParams, rho_sky) == 40 && offsetof(DarkenParams, glow) == 48 &&
              offsetof(DarkenParams, n) == 72);

// compose.comp
using shader::ComposeParams;  // kernels/common/params_compose.glsl
static_assert(sizeof(ComposeParams) == 32 && offsetof(ComposeParams, beam_mask) == 8 &&
              offsetof(ComposeParams, tint_over_pi) == 16);

// linearize.comp
using shader::LinearizeParams;  // kernels/common/params_linearize.glsl
static_assert(sizeof(LinearizeParams) == 16);

}  // namespace photosite::gpu
