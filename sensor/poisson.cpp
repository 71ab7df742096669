#include "photosite/sensor/poisson.h"

#include <array>
#include <cmath>

#include "photosite/sensor/poisson_detail.h"

namespace photosite {
namespace detail {

double log_factorial(uint32_t k) {
  static const std::array<double, 256> table = [] {
    std::array<double, 256> t{};
    t[0] = 0;
    for (uint32_t i = 1; i < t.size(); ++i) t[i] = t[i - 1] + std::log(static_cast<double>(i));
    return t;
  }();
  if (k < table.size()) return table[k];
  // Stirling's series: log k! = (k+½)log(k+1) − (k+1) + ½log(2π) + 1/(12(k+1)) − 1/(360(k+1)³).
  const double n = k + 1.0;
  return (n - 0.5) * std::log(n) - n + 0.91893853320467274178 + 1.0 / (12.0 * n) -
         1.0 / (360.0 * n * n * n);
}

}  // namespace detail

float poisson_sample(double mean, uint64_t seed, uint32_t frame, uint64_t pixel, uint32_t stream,
                     PoissonMethod method) {
  const auto w = random_words(seed, frame, pixel, static_cast<Stream>(stream));
  if (method == PoissonMethod::Normal) {
    if (!(mean > 0)) return 0.f;
    const double z = normal_from_words(w[0], w[1]);
    return static_cast<float>(std::max(0.0, std::floor(mean + std::sqrt(mean) * z + 0.5)));
  }
  return static_cast<float>(detail::poisson_from_words(mean, w, seed, frame, pixel, stream));
}

void poisson_fill(const float* mean, float* out, uint64_t n, uint64_t first_pixel, uint64_t seed,
                  uint32_t frame, uint32_t stream, PoissonMethod method) {
  const int64_t count = static_cast<int64_t>(n);
#pragma omp parallel for schedule(static, 4096)
  for (int64_t i = 0; i < count; ++i)
    out[i] = poisson_sample(mean[i], seed, frame, first_pixel + i, stream, method);
}

}  // namespace photosite
