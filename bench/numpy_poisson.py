#!/usr/bin/python3
"""Times numpy's Poisson sampler (PTRS for mean >= 10, inversion below) on the benchmark's frame
of means, and its KS distance at the benchmark's means 0.5 .. 1e6. Prints one CSV row for bench_noise."""
import math, sys, time
import numpy as np

means = np.fromfile(sys.argv[1], dtype=np.float32).astype(np.float64)
repeats = int(sys.argv[2])
rng = np.random.default_rng(1234)
best = 1e300
for _ in range(repeats):
    t0 = time.perf_counter()
    rng.poisson(means)
    best = min(best, (time.perf_counter() - t0) * 1e3)

def ks(samples, mu):
    # pmf from lgamma (no underflow at large means); mass below mu - 15 sqrt(mu) - 20 (< e^-100) is 0
    s = np.sort(samples)
    kmin = max(0, int(mu - 15 * math.sqrt(mu) - 20))
    worst = np.searchsorted(s, kmin, side="left") / len(s)
    cdf = 0.0
    for k in range(kmin, int(mu + 15 * math.sqrt(mu) + 40) + 1):
        cdf += math.exp(-mu + k * math.log(mu) - math.lgamma(k + 1))
        worst = max(worst, abs(np.searchsorted(s, k, side="right") / len(s) - cdf))
    return worst

vals = [ks(rng.poisson(mu, 400000), mu) for mu in (0.5, 2.0, 8.0, 30.0, 200.0, 1e4, 1e6)]
print(f'"numpy Generator.poisson (PCG64)",1,{best:.3f},{len(means) / best / 1e3:.1f},' +
      ",".join(f"{v:.5f}" for v in vals) + f",{max(vals):.5f}")
