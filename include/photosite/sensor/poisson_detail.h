// The per-pixel Poisson sampler, inline so the sensor loop and the benchmark share one copy.
// Three regimes, each exact in distribution or provably indistinguishable from it:
//  * mean < 12: inversion by sequential search on a 32-bit uniform (exact up to the 2^-32 grid);
//  * 12 <= mean < kPoissonApproxThreshold: PTRS, Hörmann's transformed rejection with squeeze
//    (W. Hörmann, "The transformed rejection method for generating Poisson random variables",
//    Insurance: Mathematics and Economics 12, 1993), exact;
//  * above: the Cornish-Fisher-corrected normal  K = ⌊μ + √μ z + (z²−1)/6 + (z−z³)/(72√μ) + ½⌋,
//    whose CDF is within kPoissonApproxMaxCdfError of the Poisson CDF at every k (tests/
//    poisson_test.cpp computes that distance exactly for a grid of means).
#pragma once
#include <cmath>
#include <algorithm>
#include <array>
#include <cstdint>

#include "photosite/rng.h"
#include "photosite/sensor/poisson.h"

namespace photosite::detail {

// log(k!) from a table for small k, Stirling's series beyond (error < 1e-12 for k >= 256).
double log_factorial(uint32_t k);

inline double poisson_inversion(double mean, uint32_t w) {
  const double u = uniform_open(w);
  double p = std::exp(-mean), cdf = p;
  uint32_t k = 0;
  // The cap (far beyond any mass the 2^-32 grid can reach for mean < 12) only guards rounding.
  while (u > cdf && k < 200) {
    ++k;
    p *= mean / k;
    cdf += p;
  }
  return k;
}

inline double poisson_ptrs(double mean, std::array<uint32_t, 4> w, uint64_t key, uint32_t frame,
                           uint64_t pixel, uint32_t stream) {
  const double slam = std::sqrt(mean), loglam = std::log(mean);
  const double b = 0.931 + 2.53 * slam, a = -0.059 + 0.02483 * b;
  const double inv_alpha = 1.1239 + 1.1328 / (b - 3.4), vr = 0.9277 - 3.6224 / (b - 2);
  // The first attempt uses words 0 and 1 only (words 2 and 3 belong to the read noise); later
  // attempts draw fresh words with the attempt number in the stream word and use both pairs.
  int pairs = 1;
  for (uint32_t iter = 1;; ++iter) {
    for (int pair = 0; pair < pairs; ++pair) {
      const double U = uniform_open(w[2 * pair]) - 0.5, V = uniform_open(w[2 * pair + 1]);
      const double us = 0.5 - std::fabs(U);
      const double k = std::floor((2 * a / us + b) * U + mean + 0.43);
      if (us >= 0.07 && V <= vr) return k;  // the squeeze: most draws end here, no logs
      if (k < 0 || (us < 0.013 && V > us)) continue;
      if (std::log(V) + std::log(inv_alpha) - std::log(a / (us * us) + b) <=
          -mean + k * loglam - log_factorial(static_cast<uint32_t>(k)))
        return k;
    }
    // Rejected: fresh words from the same key, the iteration number in the stream word.
    w = random_words(key, frame, pixel, static_cast<Stream>(stream | (iter << 8)));
    pairs = 2;
  }
}

inline double normal_corrected_poisson(double mean, uint32_t w0, uint32_t w1) {
  const double z = normal_from_words(w0, w1);
  const double s = std::sqrt(mean);
  const double x = mean + s * z + (z * z - 1.0) / 6.0 + (z - z * z * z) / (72.0 * s);
  return std::max(0.0, std::floor(x + 0.5));
}

// One Poisson draw, given the pixel's first Philox words: only words 0 and 1 are used (PTRS
// draws further words when it rejects), so words 2 and 3 are free for the read noise. Returns a non-negative integer as double.
inline double poisson_from_words(double mean, const std::array<uint32_t, 4>& w, uint64_t key,
                                 uint32_t frame, uint64_t pixel, uint32_t stream) {
  if (!(mean > 0)) return 0.0;
  if (mean < 12.0) return poisson_inversion(mean, w[0]);
  if (mean < kPoissonApproxThreshold) return poisson_ptrs(mean, w, key, frame, pixel, stream);
  return normal_corrected_poisson(mean, w[0], w[1]);
}

}  // namespace photosite::detail
