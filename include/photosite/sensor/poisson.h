// Poisson sampling, exact in distribution at every mean, from counter-based random words.
#pragma once
#include <cstdint>

namespace photosite {

enum class PoissonMethod {
  Exact,     // photosite's sampler: inversion, PTRS, and the corrected normal only where
             // it is indistinguishable from the exact law (see poisson.cpp)
  Normal,    // plain rounded normal N(μ, μ) everywhere (an approximation, for comparison)
};

// One Poisson(mean) draw for (seed, frame, pixel, stream).
float poisson_sample(double mean, uint64_t seed, uint32_t frame, uint64_t pixel, uint32_t stream,
                     PoissonMethod method = PoissonMethod::Exact);

// Fills out[i] ~ Poisson(mean[i]) for pixels first_pixel .. first_pixel+n-1 (multi-threaded).
void poisson_fill(const float* mean, float* out, uint64_t n, uint64_t first_pixel, uint64_t seed,
                  uint32_t frame, uint32_t stream, PoissonMethod method = PoissonMethod::Exact);

// Above this mean the exact sampler uses the Cornish-Fisher-corrected normal, whose CDF differs
// from the Poisson CDF by less than kPoissonApproxMaxCdfError (proved in tests).
inline constexpr double kPoissonApproxThreshold = 128.0;
inline constexpr double kPoissonApproxMaxCdfError = 1e-4;

}  // namespace photosite
