// Poisson sampling from counter-based random words: an exact sampler at every mean, and two
// approximations kept for comparison and speed (sensor/poisson_detail.h and kernels/common/poisson_draws.glsl have the maths).
#pragma once
#include <cstdint>
#include <string>

namespace photosite {

enum class PoissonMethod {
  Exact,          // "exact": inversion below mean 10, Hörmann's PTRS rejection sampler above
  CornishFisher,  // "cornish-fisher": inversion below 10, the Cornish-Fisher corrected normal
                  // above (CDF error < kPoissonApproxMaxCdfError; an approximation)
  Normal,         // "normal": the plain rounded normal N(μ, μ) everywhere (an approximation)
};
const char* to_string(PoissonMethod m);
PoissonMethod parse_poisson_method(const std::string& name);  // bad input on unknown names

// One Poisson(mean) draw for (seed, frame, pixel, stream).
float poisson_sample(double mean, uint64_t seed, uint32_t frame, uint64_t pixel, uint32_t stream,
                     PoissonMethod method = PoissonMethod::Exact);

// Fills out[i] ~ Poisson(mean[i]) for pixels first_pixel .. first_pixel+n-1 (multi-threaded).
void poisson_fill(const float* mean, float* out, uint64_t n, uint64_t first_pixel, uint64_t seed,
                  uint32_t frame, uint32_t stream, PoissonMethod method = PoissonMethod::Exact);

// From this mean up, PoissonMethod::Exact uses PTRS and PoissonMethod::CornishFisher the
// Sheppard-corrected Cornish-Fisher quantile, whose CDF differs from the Poisson CDF by less
// than kPoissonApproxMaxCdfError at every k (computed in tests/poisson_test.cpp); below it,
// both use inversion.
inline constexpr double kPoissonApproxThreshold = 10.0;
inline constexpr double kPoissonApproxMaxCdfError = 5e-5;

// Fills n Poisson draws for consecutive pixels first_pixel.. from one Philox call per pixel:
// words 0, 1 drive the Poisson draw, words 2, 3 a standard normal written to `normal2` (the
// sensor's read noise) when it is not null. PTRS attempts that are rejected draw more words
// from the same (key, frame, pixel) counter on retry streams (kernels/common/poisson_draws.glsl). The
// vectorized kernel behind expose().
void poisson_block(const float* mean, float* out, float* normal2, int n, uint64_t first_pixel,
                   uint64_t key, uint32_t frame, uint32_t stream,
                   PoissonMethod method = PoissonMethod::Exact);

}  // namespace photosite
