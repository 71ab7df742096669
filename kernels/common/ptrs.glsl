// Hörmann's PTRS, one attempt of it per call, written ONCE for both languages in the C++/GLSL
// common subset (common/prelude.glsl has the subset and the prelude that maps its differences):
// the C++ library includes this file through sensor/poisson_detail.h, the kernels through
// common/poisson.glsl, after common/fastmath.glsl (fast_log), so the CPU and Vulkan paths run
// the same float operations in the same order: the same bits.
//
// PTRS (W. Hörmann, "The transformed rejection method for generating Poisson random
// variables", Insurance: Mathematics and Economics 12 (1993) 39-45), for μ >= 10:
//   b = 0.931 + 2.53√μ,  a = −0.059 + 0.02483 b,  1/α = 1.1239 + 1.1328/(b − 3.4),
//   v_r = 0.9277 − 3.6224/(b − 2);
//   U uniform on (−½, ½), V uniform on (0, 1), u_s = ½ − |U|,
//   k = ⌊(2a/u_s + b) U + μ + 0.43⌋;
//   accept at once if u_s >= 0.07 and V <= v_r (the squeeze: the region under the Poisson pmf);
//   reject if k < 0, or u_s < 0.013 and V > u_s;
//   else accept iff log(V·(1/α)/(a/u_s² + b)) <= log p(k) = −μ + k log μ − log k!.
// The transformed hat h(U) = (2a/u_s + b)U + μ + 0.43 dominates the pmf scaled by α, so the
// accepted k are exactly Poisson(μ); most draws need one attempt.
//
// Float care (what makes the float version exact up to its uniform grids):
//  * k is formed as ⌊μ⌋ + ⌊(2a/u_s + b)U + (μ − ⌊μ⌋ + 0.43)⌋: the lattice boundaries are found
//    on a number of size ~σ, not ~μ (at μ = 1e6 the float spacing near μ is 1/16, which would
//    move the boundaries by up to 1/32 of a count);
//  * log p(k) for k >= 10 is Loader's saddle-point form (C. Loader, "Fast and accurate
//    computation of binomial probabilities", 2000):
//      log p(k) = −stirlerr(k) − bd0(k, μ) − ½ log(2πk),
//      bd0(k, μ) = k log(k/μ) + μ − k, summed as (k − μ)v + 2k Σ_j v^{2j+1}/(2j+1) with
//      v = (k − μ)/(k + μ) when |k − μ| < 0.25(k + μ), to v^19 (truncation < v^20 < 1e-12; no
//      cancellation between k log(k/μ) and μ − k), and stirlerr(k) = log k! − (k + ½)log k + k − ½log 2π = 1/(12k) − 1/(360k³) +
//      1/(1260k⁵) (Stirling series, next term 1/(1680k⁷) < 1e-10 at k = 10);
//    for k < 10, −μ + k log μ − log k!, with k! formed exactly in float. The absolute error of log p(k)
//    is then ~1e-6 at every μ up to 1e6 (float's 1e-7 on terms of size ~10), where the naive
//    −μ + k log μ − log k! loses everything to cancellation (k log μ ≈ 1.4e7 at μ = 1e6);
//  * U and V are on the 2^-23 grid of uniform23 (exactly representable, open intervals).
#ifndef PHOTOSITE_PTRS_GLSL
#define PHOTOSITE_PTRS_GLSL

// A uniform on the open interval (0, 1) from the top 23 bits of w: (j + ½)·2^-23, exact in float
// (j + ½ needs 24 significant bits), and U = u − ½ is exact as well.
PS_FN float uniform23(uint w) {
  precise float u = (float(int(w >> 9u)) + 0.5f) * 1.1920928955078125e-7f;
  return u;
}

// The per-mean constants of PTRS.
struct PtrsSetup {
  float mu, mu_int, mu_frac, a, b, inv_alpha, v_r;
};

PS_FN PtrsSetup ptrs_setup(float mu) {
  PtrsSetup s;
  precise float smu = sqrt_rn(mu);
  precise float b = 0.931f + 2.53f * smu;
  precise float a = -0.059f + 0.02483f * b;
  precise float inv_alpha = 1.1239f + div_rn(1.1328f, b - 3.4f);
  precise float v_r = 0.9277f - div_rn(3.6224f, b - 2.0f);
  precise float mu_int = floor(mu);
  precise float mu_frac = mu - mu_int;  // exact (Sterbenz)
  s.mu = mu;
  s.mu_int = mu_int;
  s.mu_frac = mu_frac;
  s.a = a;
  s.b = b;
  s.inv_alpha = inv_alpha;
  s.v_r = v_r;
  return s;
}

// One attempt's candidate from the words (wu, wv): k, u_s, V and the quick decision.
struct PtrsCandidate {
  float k, us, v;
  float verdict;  // 1: accepted by the squeeze, -1: rejected at once, 0: needs the full test
};

PS_FN PtrsCandidate ptrs_candidate(PtrsSetup s, uint wu, uint wv) {
  PtrsCandidate c;
  precise float u = uniform23(wu) - 0.5f;  // (−½, ½), exact
  precise float us = 0.5f - abs(u);         // exact
  precise float v = uniform23(wv);
  precise float t = (div_rn(2.0f * s.a, us) + s.b) * u + (s.mu_frac + 0.43f);
  precise float k = s.mu_int + floor(t);
  c.k = k;
  c.us = us;
  c.v = v;
  const bool squeeze = us >= 0.07f && v <= s.v_r;
  const bool reject = k < 0.0f || (us < 0.013f && v > us);
  c.verdict = squeeze ? 1.0f : (reject ? -1.0f : 0.0f);
  return c;
}

// log p(k) for Poisson(μ), k >= 0 an integer (the header comment's forms), as r − log q, so that
// the acceptance test log(V·(1/α)/h) <= log p(k) takes one logarithm: log(V·(1/α)/h·q) <= r.
//   k < 10:  q = k!,          r = −μ + k log μ
//   k >= 10: q = √(2πk),      r = −stirlerr(k) − bd0(k, μ)
// Both forms are evaluated and one is selected (no data-dependent branch, so the C++ loop
// vectorizes); the one logarithm they need is log μ or log(k/μ), selected likewise.
struct PtrsPmf {
  float q, r;
};

PS_FN PtrsPmf ptrs_pmf(PtrsSetup s, float k) {
  const bool low = k < 10.0f;
  // k! = Π_{j<=k} j, exact in float (<= 362880 < 2^24), as a product of selects (no table: a
  // table lookup is a gather, which keeps the C++ loop from vectorizing).
  precise float fact = 1.0f;
  for (int j = 2; j <= 9; ++j) fact *= float(j) <= k ? float(j) : 1.0f;
  precise float kk = max(k, 10.0f);
  precise float d = kk - s.mu;  // exact when k and μ are within a factor 2 (Sterbenz)
  precise float sum = kk + s.mu;
  precise float v = div_rn(d, sum);
  precise float v2 = v * v;
  precise float series = d * v + 2.0f * kk * v * (v2 * (0.333333343f + v2 * (0.200000003f + v2 * (0.142857149f +
                         v2 * (0.111111112f + v2 * (0.0909090936f + v2 * (0.0769230798f + v2 * (0.0666666701f +
                         v2 * (0.0588235296f + v2 * 0.0526315793f)))))))));
  precise float lg = fast_log(low ? s.mu : div_rn(kk, s.mu));
  precise float direct = kk * lg + (s.mu - kk);
  precise float bd0 = abs(d) < 0.25f * sum ? series : direct;
  precise float rk = div_rn(1.0f, kk);
  precise float rk2 = rk * rk;
  precise float stirlerr = rk * (0.0833333358f - rk2 * (0.00277777785f - rk2 * 0.000793650805f));
  precise float q = low ? fact : sqrt_rn(6.28318548f * kk);
  precise float r = low ? -s.mu + k * lg : -(stirlerr + bd0);
  PtrsPmf p;
  p.q = q;
  p.r = r;
  return p;
}

// log p(k) itself (for the tests).
PS_FN float ptrs_log_pmf(PtrsSetup s, float k) {
  const PtrsPmf p = ptrs_pmf(s, k);
  precise float l = p.r - fast_log(p.q);
  return l;
}

// The full acceptance test of a candidate with verdict 0.
PS_FN bool ptrs_accept(PtrsSetup s, PtrsCandidate c) {
  const PtrsPmf p = ptrs_pmf(s, c.k);
  // V·(1/α)/h with h = a/u_s² + b = (a + b u_s²)/u_s²: one division.
  precise float us2 = c.us * c.us;
  precise float lhs = fast_log(div_rn(c.v * s.inv_alpha * us2, s.a + s.b * us2) * p.q);
  return lhs <= p.r;
}

// One whole attempt: k >= 0 when accepted, −1 when rejected.
PS_FN float ptrs_attempt(PtrsSetup s, uint wu, uint wv) {
  const PtrsCandidate c = ptrs_candidate(s, wu, wv);
  const bool full = ptrs_accept(s, c);  // evaluated always: no branch, so the loop vectorizes
  const bool ok = c.verdict == 1.0f || (c.verdict == 0.0f && full);
  return ok ? c.k : -1.0f;
}

// Retries draw fresh words from the same (seed, frame, pixel) Philox counter with the stream
// word stream + r·kPtrsRetryStreamStep, r = 1 .. kPtrsMaxRetryCalls (every named stream is
// below 256, so these never meet another stream). Each call's four words give two attempts:
// (w0, w1) then (w2, w3). The first attempt uses the pixel's own words 0, 1. An attempt is
// rejected with probability below 0.25 (the worst case, μ = 10), so the chance that all
// 1 + 2·31 attempts fail is below 0.25^63 < 1e-37; the mode ⌊μ⌋ is returned then.
const uint kPtrsRetryStreamStep = 256u;
const int kPtrsMaxRetryCalls = 31;

#endif
