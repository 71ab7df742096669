// Poisson sampling, exact in distribution at every mean, from counter-based random words.
#pragma once
#include <cstdint>

namespace photosite {

enum class PoissonMethod {
  Exact,     // photosite's sampler: inversion below mean 10, the corrected normal above,
             // where it is indistinguishable from the exact law (poisson_detail.h)
  Normal,    // plain rounded normal N(μ, μ) everywhere (an approximation, for comparison)
};

// One Poisson(mean) draw for (seed, frame, pixel, stream).
float poisson_sample(double mean, uint64_t seed, uint32_t frame, uint64_t pixel, uint32_t stream,
                     PoissonMethod method = PoissonMethod::Exact);

// Fills out[i] ~ Poisson(mean[i]) for pixels first_pixel .. first_pixel+n-1 (multi-threaded).
void poisson_fill(const float* mean, float* out, uint64_t n, uint64_t first_pixel, uint64_t seed,
                  uint32_t frame, uint32_t stream, PoissonMethod method = PoissonMethod::Exact);

// From this mean up the exact sampler uses the Sheppard-corrected Cornish-Fisher quantile,
// whose CDF differs from the Poisson CDF by less than kPoissonApproxMaxCdfError at every k
// (proved in tests/poisson_test.cpp); below it, inversion.
inline constexpr double kPoissonApproxThreshold = 10.0;
inline constexpr double kPoissonApproxMaxCdfError = 5e-5;

// Fills n Poisson draws for consecutive pixels first_pixel.. from ONE Philox call per pixel:
// words 0, 1 drive the Poisson draw, words 2, 3 a standard normal written to `normal2` (the
// sensor's read noise) when it is not null. The vectorized kernel behind expose().
void poisson_block(const float* mean, float* out, float* normal2, int n, uint64_t first_pixel,
                   uint64_t key, uint32_t frame, uint32_t stream);

}  // namespace photosite
