// The per-pixel stages on the Vulkan backend, each the device twin of a CPU function (the
// parity tests in tests/gpu_test.cpp hold them to it).
#pragma once
#include <cstdint>
#include <vector>

#include "photosite/gpu/context.h"
#include "photosite/image.h"
#include "photosite/sensor/cfa.h"
#include "photosite/sensor/demosaic.h"
#include "photosite/sensor/poisson.h"

namespace photosite::gpu {
class Sequence;

// poisson_fill(..., method) on the device: the same draws, bit for bit.
void poisson_fill(Context& ctx, const float* mean, float* out, uint64_t n, uint64_t first_pixel,
                  uint64_t seed, uint32_t frame, uint32_t stream, PoissonMethod method = PoissonMethod::Exact);
// The same kernel recorded into a sequence over buffers already on the device (n floats each).
void record_poisson(Context& ctx, Sequence& s, Buffer& mean, Buffer& out, uint64_t n, uint64_t first_pixel,
                    uint64_t seed, uint32_t frame, uint32_t stream, PoissonMethod method = PoissonMethod::Exact);
// The four Philox words of pixels first_pixel.. (random_words() on the device), 4n words.
std::vector<uint32_t> philox_words(Context& ctx, uint64_t n, uint64_t first_pixel, uint64_t seed,
                                   uint32_t frame, uint32_t stream);
// The device's correctly rounded division and square root (div_rn, sqrt_rn in
// kernels/common/prelude.glsl), each settled from a first value moved shift_ulps floats away from
// the driver's own float division and square root: {a0/b0, sqrt(a0), a1/b1, sqrt(a1), ...} for the pairs ab = {a0, b0, a1,
// b1, ...} (for the test that they reach IEEE 754's result wherever a driver's arithmetic leaves them).
std::vector<float> rounding_probe(Context& ctx, const std::vector<float>& ab, int shift_ulps);

// The demosaic methods that have kernels: bilinear and Malvar-He-Cutler (one pass each),
// Hamilton-Adams (green pass, then colour pass), LMMSE (observations, low-pass, estimates and
// fusion, colour: five passes). Every method today; kept for methods added later.
bool has_demosaic_kernel(DemosaicMethod m);
// demosaic(mosaic, pattern, method) on the device, bit for bit; a method without a kernel is an
// internal error (callers check has_demosaic_kernel()).
// With device_ms, the device time of its dispatches (timestamps; -1 without them).
ImageF demosaic(Context& ctx, const ImageF& mosaic, CfaPattern pattern, DemosaicMethod method,
                double* device_ms = nullptr);
// demosaic_bilinear(mosaic, pattern) on the device.
inline ImageF demosaic_bilinear(Context& ctx, const ImageF& mosaic, CfaPattern pattern) {
  return demosaic(ctx, mosaic, pattern, DemosaicMethod::Bilinear);
}

}  // namespace photosite::gpu
