// The Poisson modes as the sensor runs them (poisson_fill / poisson_block, float, Philox words),
// against the Poisson law: χ² goodness of fit and KS distance of the exact mode over means
// 1e-3 .. 1e6, negative controls that the same statistic rejects, PTRS's vector loop against its
// scalar reference, and the Cornish-Fisher mode's CDF error as docs/sensor.md states it.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <cstdio>
#include <vector>

#include "photosite/sensor/poisson.h"
#include "sensor/poisson_detail.h"

using namespace photosite;

namespace {

// log p(k) of Poisson(μ) in double (lgamma: no cancellation issue at the 1e-9 level up to 1e6).
double log_pmf(long k, double mu) { return -mu + k * std::log(mu) - std::lgamma(k + 1.0); }

struct Fit {
  double chi2 = 0, critical = 0, ks = 0, ks_critical = 0;
  int dof = 0;
};

// χ² of n draws (a histogram `counts`) against Poisson(μ), cells merged left to right until each
// expects >= 20 draws (the χ² approximation to the multinomial statistic is good there;
// Cochran 1954). Under the null, χ² ~ χ²(dof) with dof = cells − 1; its 1 − 1e-6 quantile by
// Wilson & Hilferty (1931): q = d(1 − 2/(9d) + z√(2/(9d)))³, z = 4.7534 the 1 − 1e-6 normal
// quantile (relative error of the approximation < 1% for d >= 10, far inside the margin
// between a sampler that is exact and one that is not). KS: D = max_k |F_n(k) − F(k)|; for a
// discrete law P(√n D > t) is at most the continuous Kolmogorov tail 2Σ(−1)^{j−1}e^{−2j²t²}
// (Noether 1963), so t = √(ln(2/1e-6)/2) = 2.693 bounds it at p = 1e-6.
Fit fit(const std::vector<long>& counts, long n, double mu) {
  Fit f;
  const double sd = std::sqrt(mu);
  const long lo = std::max(0L, static_cast<long>(mu - 15 * sd - 20));
  const long hi = static_cast<long>(mu + 15 * sd + 40);
  double cdf = 0, ecdf = 0, exp_acc = 0, obs_acc = 0;
  long counted = 0;
  for (long k = 0; k < lo; ++k) counted += k < static_cast<long>(counts.size()) ? counts[k] : 0;
  obs_acc = counted;
  ecdf = static_cast<double>(counted) / n;
  // Mass below lo is below e^-100 (15σ + 20 under the mean): taken as 0.
  int cells = 0;
  for (long k = lo; k <= hi; ++k) {
    const double p = std::exp(log_pmf(k, mu));
    const long c = k < static_cast<long>(counts.size()) ? counts[k] : 0;
    cdf += p;
    ecdf += static_cast<double>(c) / n;
    f.ks = std::max(f.ks, std::fabs(ecdf - cdf));
    exp_acc += p * n;
    obs_acc += c;
    if (exp_acc >= 20 && (1 - cdf) * n >= 20) {
      f.chi2 += (obs_acc - exp_acc) * (obs_acc - exp_acc) / exp_acc;
      exp_acc = obs_acc = 0;
      ++cells;
    }
  }
  // The last cell: everything above.
  long above = 0;
  for (long k = hi + 1; k < static_cast<long>(counts.size()); ++k) above += counts[k];
  obs_acc += above;
  exp_acc += std::max(0.0, 1 - cdf) * n;
  if (exp_acc > 0) {
    f.chi2 += (obs_acc - exp_acc) * (obs_acc - exp_acc) / exp_acc;
    ++cells;
  }
  f.dof = std::max(1, cells - 1);
  const double d = f.dof, z = 4.7534;
  f.critical = d * std::pow(1 - 2 / (9 * d) + z * std::sqrt(2 / (9 * d)), 3);
  f.ks_critical = 2.693 / std::sqrt(static_cast<double>(n));
  return f;
}

Fit draw_and_fit(double mu, long n, PoissonMethod method, uint32_t frame = 11) {
  std::vector<float> mean(n, static_cast<float>(mu)), out(n);
  poisson_fill(mean.data(), out.data(), n, 0, 0xC0FFEE, frame, 1, method);
  std::vector<long> counts;
  for (float k : out) {
    const long i = static_cast<long>(k);
    if (i >= static_cast<long>(counts.size())) counts.resize(i + 1);
    counts[i]++;
  }
  return fit(counts, n, static_cast<double>(static_cast<float>(mu)));
}

// Means from 1e-3 to 1e6, four per decade, plus both sides of the regime switch.
std::vector<double> test_means() {
  std::vector<double> m;
  for (int i = 0; i <= 36; ++i) m.push_back(std::pow(10.0, -3.0 + i * 0.25));
  m.push_back(9.99);
  m.push_back(10.0);
  m.push_back(10.01);
  return m;
}

}  // namespace

// The exact mode passes χ² and KS at p = 1e-6 at every mean, with 1e6 draws per mean.
// The same holds for cornish-fisher: its CDF error (below 2.9e-5, Poisson.CorrectedNormal...)
// is beyond what 1e6 draws resolve (a KS difference of 2.9e-5 needs ~(1.36/2.9e-5)² ≈ 2e9).
static void expect_passes(PoissonMethod method) {
  double worst_z = -1e9, worst_ks = 0;  // z = (χ² − d)/√(2d), the statistic in null standard deviations
  for (double mu : test_means()) {
    const Fit f = draw_and_fit(mu, 1000000, method);
    EXPECT_LT(f.chi2, f.critical) << to_string(method) << " mean " << mu << " dof " << f.dof;
    EXPECT_LT(f.ks, f.ks_critical) << to_string(method) << " mean " << mu;
    worst_z = std::max(worst_z, (f.chi2 - f.dof) / std::sqrt(2.0 * f.dof));
    worst_ks = std::max(worst_ks, f.ks / f.ks_critical);
  }
  std::printf("%s, 1e6 draws at each of %zu means 1e-3..1e6: largest chi2 z-score %.2f (critical ~4.75), "
              "largest KS/critical %.3f\n",
              to_string(method), test_means().size(), worst_z, worst_ks);
}
TEST(PoissonAccuracy, ExactModePassesChiSquareAndKsFrom1em3To1e6) { expect_passes(PoissonMethod::Exact); }
TEST(PoissonAccuracy, CornishFisherIsBeyondTheReachOfAMillionDraws) { expect_passes(PoissonMethod::CornishFisher); }

// Negative controls, the same statistic and thresholds: the rounded normal fails wherever its
// bias is within reach of 1e6 draws; and an exact sampler run at a mean 0.5% off (a biased
// sampler of the right shape) fails at μ = 1e4 (its shift, 0.5σ, moves the CDF by ~0.2 >> KS 0.0027).
TEST(PoissonAccuracy, TheSameTestRejectsBiasedSamplers) {
  for (double mu : {0.3, 3.0, 30.0, 300.0}) {
    const Fit f = draw_and_fit(mu, 1000000, PoissonMethod::Normal);
    EXPECT_GT(f.chi2, f.critical) << "normal at mean " << mu;
  }
  std::vector<float> mean(1000000, 1e4f * 1.005f), out(mean.size());
  poisson_fill(mean.data(), out.data(), mean.size(), 0, 7, 0, 1, PoissonMethod::Exact);
  std::vector<long> counts;
  for (float k : out) {
    const long i = static_cast<long>(k);
    if (i >= static_cast<long>(counts.size())) counts.resize(i + 1);
    counts[i]++;
  }
  const Fit f = fit(counts, static_cast<long>(out.size()), 1e4);
  EXPECT_GT(f.chi2, f.critical);
  EXPECT_GT(f.ks, f.ks_critical);
}

// PTRS's vector loop (compaction, full test, masked retries on list Philox) gives the scalar
// reference detail::ptrs_sample's bits at every pixel, for means 10 .. 1e6.
TEST(PoissonAccuracy, PtrsBlockEqualsScalarReference) {
  const int n = 200000;
  std::vector<float> mean(n), out(n);
  for (int i = 0; i < n; ++i) mean[i] = static_cast<float>(10.0 * std::pow(1e5, (i % 5000) / 5000.0));
  const uint64_t first = 0xFFFFF000ull, key = 99;  // crosses a 2^32 pixel boundary
  poisson_fill(mean.data(), out.data(), n, first, key, 4, 1, PoissonMethod::Exact);
  for (int i = 0; i < n; ++i) {
    const auto w = random_words(key, 4, first + i, Stream::PhotonShot);
    ASSERT_EQ(out[i], detail::ptrs_sample(mean[i], w[0], w[1], key, 4, first + i, 1)) << i << " mean " << mean[i];
  }
}

// Blocks that mix dark (inversion) and lit (PTRS) pixels, as a night frame's rows do: the block
// kernel draws PTRS on the lit lanes compacted (ptrs_high_lanes in sensor/poisson.cpp), with each
// lane's own pixel index for its retries. Every pixel must still equal the scalar reference:
// ptrs_sample for mean >= 10 (means near 10, where PTRS rejects most often, so retries occur in
// mixed blocks), inversion below, 0 for zero, negative and NaN means. Runs of 2048 pixels (one
// block of poisson_block) are all dark, all lit, or mixed at random, and the range crosses a 2^32
// pixel boundary.
TEST(PoissonAccuracy, MixedBlocksEqualScalarReference) {
  const int n = 32 * 1024;
  std::vector<float> mean(n), out(n);
  uint64_t h = 12345;
  auto next = [&] {  // SplitMix64: deterministic test data
    uint64_t z = (h += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
  };
  for (int i = 0; i < n; ++i) {
    const int kind = (i / 2048) % 4;  // 0: all dark, 1: all lit, 2, 3: mixed
    const double u = static_cast<double>(next() >> 11) * 0x1p-53;
    const bool lit = kind == 1 || (kind >= 2 && (next() & (kind == 2 ? 1 : 7)) == 0);
    mean[i] = lit ? static_cast<float>(10.0 + 30.0 * u) : static_cast<float>(10.0 * u);
    if (!lit && i % 97 == 0) mean[i] = i % 2 ? -1.f : std::numeric_limits<float>::quiet_NaN();
  }
  const uint64_t first = 0xFFFFF000ull + 37, key = 7;
  poisson_fill(mean.data(), out.data(), n, first, key, 2, 1, PoissonMethod::Exact);
  int retried = 0;
  for (int i = 0; i < n; ++i) {
    const auto w = random_words(key, 2, first + i, Stream::PhotonShot);
    float want = 0.f;
    if (mean[i] >= 10.f) {
      want = detail::ptrs_sample(mean[i], w[0], w[1], key, 2, first + i, 1);
      retried += detail::ptrs_attempt(detail::ptrs_setup(mean[i]), w[0], w[1]) < 0.f;
    } else if (mean[i] > 0.f) {
      want = detail::poisson_inversion(mean[i], w[0]);
    }
    ASSERT_EQ(out[i], want) << i << " mean " << mean[i];
  }
  EXPECT_GT(retried, 0);  // the retry path with compacted lanes was exercised
}

// log p(k) of ptrs.glsl against lgamma in double, within 8σ of the mean, up to μ = 1e6. Bound
// from the rounding: at most ~6 float roundings (relative 6e-8 each, fast_log's ~1e-7
// included) of terms no larger than |log p| + ½log(2πk) <= 40 at 8σ: 6·40·6e-8 ≈ 1.4e-5 < 2e-5.
// The naive float −μ + k log μ − log k! would be off by ~1 at μ = 1e6 (k log μ ≈ 1.4e7).
TEST(PoissonAccuracy, PtrsLogPmfIsAccurateInFloat) {
  double worst = 0;
  for (double mu : {10.0, 10.5, 33.0, 128.0, 1000.0, 31623.0, 1e6}) {
    const float m = static_cast<float>(mu);
    const auto s = detail::ptrs_setup(m);
    const double sd = std::sqrt(mu);
    for (long k = std::max(0L, static_cast<long>(mu - 8 * sd)); k <= static_cast<long>(mu + 8 * sd); ++k) {
      const double err = std::fabs(detail::ptrs_log_pmf(s, static_cast<float>(k)) - log_pmf(k, m));
      worst = std::max(worst, err);
    }
  }
  std::printf("worst |log p(k) error| of the float PTRS pmf: %.2e\n", worst);
  EXPECT_LT(worst, 2e-5);
}
