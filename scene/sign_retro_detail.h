// A traffic sign's coefficient of retroreflection R_A(α, β) (cd·lx⁻¹·m⁻²) as the light map
// evaluates it per sign pixel and headlamp: one arithmetic, written once over a lane type V, that
// the scalar code (V = double) and the AVX2 and AVX-512 lanes (V = __m256d, __m512d: GCC vector
// types, whose +, −, ·, / and comparisons are lane by lane) run with the same IEEE operations in
// the same order, so every lane gives the scalar code's bits. No libm call inside: the observation
// angle's acos and the power law's pow and the entrance factor's log and exp are the polynomials
// below (each within a few units in the last place of the exact function over its range, derived
// at each), which the vector lanes can run too; before the forty-eighth session the lanes between
// the table's two observation angles (most sign pixels: 26,246 of 35,696 on aachen_000000) fell
// back to the scalar code's acos and pow one at a time.
//
// The model (ScenePreset::sign_RA_*; docs/night.md §7, the signs' paragraph): each entrance-angle
// column k of the RA2 table (β_k) is a power law in α between α0 = sign_RA_alpha_deg and
// α1 = sign_RA_alpha_max_deg, R_k(α) = R0_k·(α/α0)^−K_k, held at R0_k below α0 and at R1_k beyond
// α1, with R0_k = sign_RA·F0_k and R1_k = sign_RA·(α1/α0)^−k·F1_k (k = sign_RA_alpha_exponent,
// F0, F1 the preset's entrance factors), so K_k = k + ln(F0_k/F1_k)/ln(α1/α0); R_A is linear in
// tan β between the columns and held outside them. Without an entrance table one column, F = 1.
#pragma once

#include <bit>
#include <cmath>
#include <cstdint>
#include <type_traits>
#include <vector>

#include "photosite/scene/night.h"
#include "photosite/scene/road_line.h"
#include "photosite/scene/scene_preset.h"

// (The lanes' templates take and return vector types; they are always inlined into their callers,
// the vector functions with their target attribute, so no such value crosses a call: GCC's note on
// the ABI of vector returns does not apply.)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wpsabi"
namespace photosite::scene::detail {

struct SignRA {
  int n = 1;                             // columns
  std::vector<double> t, inv_dt;         // tan β_k; 1/(tan β_k − tan β_{k−1}) (index k − 1)
  std::vector<double> R0, R1, K;         // held values below α0 and beyond α1; the power law's exponent
  double cos_a0 = 1, cos_a1 = 1;         // cos α0, cos α1
  double inv_a0_rad = 1;                 // 1/α0 (rad⁻¹)
  bool mid = false;                      // α1 > α0: a power-law range between them
  explicit SignRA(const ScenePreset& p) {
    const double a0 = p.sign_RA_alpha_deg, a1 = std::max(p.sign_RA_alpha_deg, p.sign_RA_alpha_max_deg);
    cos_a0 = std::cos(a0 * M_PI / 180);
    cos_a1 = std::cos(a1 * M_PI / 180);
    inv_a0_rad = 1 / (a0 * M_PI / 180);
    const double Lam = std::log(a1 / a0), RA_max = sign_RA_at(p.sign_RA_alpha_max_deg, p);  // held beyond α1
    const size_t m = p.sign_RA_entrance_deg.size();
    const bool table = m > 0 && p.sign_RA_entrance_factor.size() == m && p.sign_RA_entrance_factor_alpha_max.size() == m;
    n = table ? static_cast<int>(m) : 1;
    // A power-law range needs α1 > α0 by a margin (ln(α1/α0) ≥ 0.01): then |K_k·ln(α/α0)| ≤
    // k·ln(α1/α0) + |ln(F0/F1)| ≤ 5·ln 500 + ln 10⁷ < 48 over the schema's ranges, so the exp below
    // stays far from overflow and from subnormals. Closer angles are held at one or the other.
    mid = Lam >= 0.01;
    for (int k = 0; k < n; ++k) {
      const double f0 = table ? p.sign_RA_entrance_factor[k] : 1, f1 = table ? p.sign_RA_entrance_factor_alpha_max[k] : 1;
      R0.push_back(p.sign_RA * f0);
      R1.push_back(RA_max * f1);
      K.push_back(mid ? p.sign_RA_alpha_exponent + std::log(f0 / f1) / Lam : 0);
      t.push_back(table ? std::tan(p.sign_RA_entrance_deg[k] * M_PI / 180) : 0);
      if (k > 0) inv_dt.push_back(1 / (t[k] - t[k - 1]));
    }
  }
};

// Bits of a double lane and back: std::bit_cast for the scalar code, a vector reinterpretation for
// the lanes.
typedef long long i64x4 __attribute__((vector_size(32)));
typedef long long i64x8 __attribute__((vector_size(64)));
[[gnu::always_inline]] inline int64_t lane_bits(double x) { return std::bit_cast<int64_t>(x); }
[[gnu::always_inline]] inline double lane_from_bits(int64_t b, double) { return std::bit_cast<double>(b); }
template <class V>
[[gnu::always_inline]] inline auto lane_bits(const V& x) {
  if constexpr (sizeof(V) == 32) return std::bit_cast<i64x4>(x);
  else return std::bit_cast<i64x8>(x);
}
template <class I, class V>
[[gnu::always_inline]] inline V lane_from_bits(const I& b, const V&) {
  return std::bit_cast<V>(b);
}
template <class V>
[[gnu::always_inline]] inline V lane_splat(double c) {
  return V{} + c;
}

// 2^n for integral n in [−1022, 1023] (here |n| ≤ 70): n + 1.5·2⁵² puts n in the low mantissa bits
// (exact for |n| < 2⁵¹), and (n + 1023) << 52 is the double 2^n.
template <class V>
[[gnu::always_inline]] inline V lane_pow2i(const V& n) {
  const auto b = lane_bits(n + 0x1.8p52);
  return lane_from_bits((b - 0x4338000000000000LL + 1023) << 52, n);
}

// ln y for 1 ≤ y < 2¹⁸ (y = (α/α0)², α/α0 ≤ 5°/0.01°): y = m·2^e with m in [1, 2) from y's
// exponent and mantissa bits (exact), then m in [√2/2, √2) by one halving where m ≥ √2 (exact;
// e as a double by the 2⁵² bias: exact for 0 ≤ e < 2⁵²), then ln m = 2·atanh(z) =
// 2·Σ z^(2j+1)/(2j+1), z = (m − 1)/(m + 1), |z| ≤ 0.1716: the series to z²¹/21 leaves
// z²³/23 ≤ 0.02944¹¹/23 < 10⁻¹⁸ of z. Its roundings: z's (two, relative; m − 1 is exact), the
// Horner sum of positive terms (a few ulp), e·ln 2 and the sum, where ln m may be negative but
// |ln m| ≤ ln √2 ≤ e·ln 2 / 2 (at most a factor 2 lost): a few ulp of ln y. (Until the session's
// end the exponent was taken by up to eighteen halvings: the same m and e, so the same bits, for
// every y in the range.)
template <class V>
[[gnu::always_inline]] inline V lane_log_1_2p18(const V& y) {
  const auto b = lane_bits(y);
  V m = lane_from_bits((b & 0x000fffffffffffffLL) | 0x3ff0000000000000LL, y);
  V e = lane_from_bits(((b >> 52) - 1023) + 0x4330000000000000LL, y) - 0x1p52;
  const auto big = m >= 1.4142135623730951;
  m = big ? m * 0.5 : m;
  e = big ? e + 1.0 : e;
  const V z = (m - 1.0) / (m + 1.0), z2 = z * z;
  V s = lane_splat<V>(1.0 / 21);
  for (int d = 19; d >= 1; d -= 2) s = s * z2 + 1.0 / d;
  return e * 0.6931471805599453 + 2.0 * z * s;
}

// e^t for |t| ≤ 48: t = n·ln 2 + r (n the nearest integer to t/ln 2 by the 1.5·2⁵² rounding,
// r by Cody and Waite's two-part ln 2, whose high part has 11 trailing zero bits so n·hi is exact
// for |n| < 2¹¹), |r| ≤ ln 2/2 + ε, e^r by Taylor to r¹³/13! (the rest ≤ 0.347¹⁴/14! < 5·10⁻¹⁸),
// times 2^n (exact): a few ulp.
template <class V>
[[gnu::always_inline]] inline V lane_exp_48(const V& t) {
  const V n = (t * 1.4426950408889634 + 0x1.8p52) - 0x1.8p52;
  const V r = (t - n * 0x1.62e42fee00000p-1) - n * 0x1.a39ef35793c76p-33;
  V s = lane_splat<V>(1.0 / 6227020800.0);  // 1/13!
  constexpr double inv_fact[13] = {1.0,         1.0,           1.0 / 2,        1.0 / 6,         1.0 / 24,
                                   1.0 / 120,   1.0 / 720,     1.0 / 5040,     1.0 / 40320,     1.0 / 362880,
                                   1.0 / 3628800, 1.0 / 39916800, 1.0 / 479001600};
  for (int k = 12; k >= 0; --k) s = s * r + inv_fact[k];
  return s * lane_pow2i(n);
}

// The observation angle α (rad) from its cosine c, squared, for α up to 5° (the schema's largest
// α1): α = 2·asin(x), x = sin(α/2), x² = (1 − c)/2, asin x = x·Σ_j a_j x^(2j) to x¹⁰ (a = 1, 1/6,
// 3/40, 5/112, 35/1152, 63/2816; the rest 231/13312·x¹² ≤ 0.0174·(1.9·10⁻³)⁶ < 10⁻¹⁸ at 5°), so
// α² = 4·x²·(Σ)² with no square root. 1 − c inherits c's rounding (a few 2⁻⁵³ absolute) relative to
// α²/2 ≥ 1.5·10⁻⁸ at 0.01°: acos(c) amplifies the same rounding the same way.
template <class V>
[[gnu::always_inline]] inline V lane_angle2_from_cos(const V& c) {
  const V s2 = (1.0 - c) * 0.5;
  V p = lane_splat<V>(63.0 / 2816);
  p = p * s2 + 35.0 / 1152;
  p = p * s2 + 5.0 / 112;
  p = p * s2 + 3.0 / 40;
  p = p * s2 + 1.0 / 6;
  p = p * s2 + 1.0;
  return 4.0 * s2 * (p * p);
}

// R_A at cos α = ca and tan β = tb (see the top of the file), per lane.
// any_mid: whether any lane lies between α0 and α1 (the vector callers' test on their lanes; the
// scalar code derives it from its one lane); where none does, the power law is not evaluated (it
// would be selected away).
template <class V>
[[gnu::always_inline]] inline V sign_RA_lanes(const SignRA& s, const V& ca, const V& tb, bool any_mid = true) {
  const auto lo = ca >= s.cos_a0, hi = ca <= s.cos_a1;
  if constexpr (std::is_same_v<V, double>) any_mid = !(lo || hi);
  const bool power = s.mid && any_mid;
  // L = ln(α/α0) = ½·ln((α/α0)²)
  V L = lane_splat<V>(0);
  if (power) L = 0.5 * lane_log_1_2p18(lane_angle2_from_cos(ca) * (s.inv_a0_rad * s.inv_a0_rad));
  V Rprev{}, R{};
  for (int k = 0; k < s.n; ++k) {
    V Rk = hi ? lane_splat<V>(s.R1[k]) : lane_splat<V>(s.R0[k]);
    if (power) Rk = (lo || hi) ? Rk : s.R0[k] * lane_exp_48(L * -s.K[k]);
    if (k == 0) {
      R = Rk;
    } else {
      const auto in = tb > s.t[k - 1];
      R = in ? Rprev + (tb - s.t[k - 1]) * ((Rk - Rprev) * s.inv_dt[k - 1]) : R;
    }
    Rprev = Rk;
  }
  if (s.n > 1) R = tb >= s.t[s.n - 1] ? Rprev : R;
  return R;
}

// Which way a sign faces: toward the traffic that reads it, its normal n = −(sin ψ, 0, cos ψ) in
// road coordinates (X across, Y up, D along the camera's axis), ψ (RoadPiece's convention: from +D,
// positive toward +X) that traffic's course the reading distance d (ScenePreset::
// sign_read_distance_m) before the sign along the road. The camera car is such traffic: up to the
// curve's start its course, the camera's heading ψ = 0, stands for the road's. Where the frame's
// road ahead was measured curved (RoadAhead: straight at the fitted heading ψ0 to the curve's start
// P0, then an arc of curvature κ about C = P0 + (cos ψ0, −sin ψ0)/κ for at most a quarter turn, then
// straight on: road_ahead_pieces), a sign at ground point (X, D) stands at the angle Δ about C from
// the start (the heading of the circle about C through it, (sin, cos) = sgn κ·(w_D, −w_X)/|w|, w =
// (X, D) − C, is ψ0 + sgn κ·Δ: the road line's heading at the point nearest across, the arc's
// concentric circles sharing it), so at arc length Δ/|κ| past the start, and the road d before it
// has turned by sgn κ·(Δ − |κ|·d) since the start: ψ is that turn, 0 where the reading point lies
// before the start, ±90° (the quarter turn's end) beyond it; 0 for a sign before the start. The
// fitted ψ0 places the arc and is not added: it is the fit's heading of the road at the camera,
// which a car driving along the road shares (on aachen_000000, whose kerbs fit ψ0 = −0.26 rad round
// a traffic island, the island's sign faces the camera squarely in the photo). (Past the quarter
// turn, on the straight after it, Δ is the point's angle about C, 90° + atan(s/R) for s along that
// straight, not 90° + s/R: a sign there faces less turned than the road line would make it, by at
// most x − atan x, x = |κ|·d: 0.009 rad on a 200 m radius, 0.06 on 100 m, 0.56 on aachen_000000's
// 38 m, at d = 60 m; an approximation that keeps every lane's work to products.) Else (straight, or
// not measured) the sign faces the camera's heading, ψ = 0. The lanes below take ψ as the
// unnormalised direction (u, v) = |w|·(sin ψ, cos ψ) with w2 = |w|² (1 where ψ is 0 or ±90°): the
// entrance angle's tangent and the two facing tests need no square root of their own, and the
// turn back by |κ|·d and ψ0 is one fixed rotation.
struct SignFacing {
  bool curved = false;
  double s0 = 0, c0 = 1;      // sin ψ0, cos ψ0
  double P0X = 0, P0D = 0;    // the curve's start
  double CX = 0, CD = 0;      // the arc's centre
  double k = 1;               // sgn κ
  double sr = 0, cr = 1;      // sin, cos of −κ·d − ψ0 (|κ|·d held at π)
  // In a sequence, the arc continued back b = RoadAhead::turning_behind_m (held at d and at a
  // quarter turn): sin, cos of |κ|·b.
  bool back = false;
  double sb = 0, cb = 1;
  SignFacing() = default;
  SignFacing(const RoadAhead& r, double read_distance_m) {
    if (!r.curved || !(r.kappa_per_m != 0) || !std::isfinite(r.kappa_per_m)) return;
    curved = true;
    s0 = std::sin(r.heading_rad);
    c0 = std::cos(r.heading_rad);
    P0X = r.curve_start_m * s0;
    P0D = r.curve_start_m * c0;
    CX = P0X + c0 / r.kappa_per_m;
    CD = P0D - s0 / r.kappa_per_m;
    k = r.kappa_per_m > 0 ? 1.0 : -1.0;
    const double back = -k * std::min(std::fabs(r.kappa_per_m) * std::max(0.0, read_distance_m), M_PI) - r.heading_rad;
    sr = std::sin(back);
    cr = std::cos(back);
    if (r.turning_behind_m > 0 && r.curve_start_m <= kBendAtCameraM) {
      const double turned = std::min(std::fabs(r.kappa_per_m) * std::min(r.turning_behind_m, std::max(0.0, read_distance_m)),
                                     0.5 * M_PI);
      if (turned > 0) {
        this->back = true;
        sb = std::sin(turned);
        cb = std::cos(turned);
      }
    }
  }
};

// (u, v, w2) of SignFacing at ground points (X, D), lane by lane (the scalar code: V = double).
// Only where f.curved (else (0, 1, 1)).
template <class V>
[[gnu::always_inline]] inline void sign_facing_lanes(const SignFacing& f, const V& X, const V& D, V& u, V& v, V& w2) {
  const V wX = X - f.CX, wD = D - f.CD;
  const V us = f.k * wD, vs = -f.k * wX;  // the sign's own circle's heading, times |w|
  w2 = wX * wX + wD * wD;
  // the turn since the start, back to the reading point: the rotation by −κ·d − ψ0
  u = us * f.cr + vs * f.sr;
  v = vs * f.cr - us * f.sr;
  // turned against the bend: the reading point lies before the start (0); by more than 90°:
  // beyond the quarter turn (its end's ±90°)
  const auto early = f.k * u < 0.0;
  const auto late = v < 0.0;
  const V u0 = u, v0 = v, w20 = w2;  // the turn as read (kept on a sequence's arc continued back)
  u = late ? lane_splat<V>(f.k) : u;
  v = late ? lane_splat<V>(0.0) : v;
  w2 = late ? lane_splat<V>(1.0) : w2;
  // a sign before the curve's start: 0 (as one whose reading point is before it)
  auto before = (X - f.P0X) * f.s0 + (D - f.P0D) * f.c0 <= 0.0;
  if (f.back) {
    // A sequence's arc continued back by |κ|·b (SignFacing::back): a reading point turned back by
    // less keeps its turn; one turned back further takes the arc's start behind, −sgn κ·|κ|·b.
    // (sin(sgn κ·ψ + |κ|·b) ≥ 0, times |w|: the turn is at least −|κ|·b.)
    const auto kept = f.k * u0 * f.cb + v0 * f.sb >= 0.0;
    u = early ? (kept ? u0 : lane_splat<V>(-f.k * f.sb)) : u;
    v = early ? (kept ? v0 : lane_splat<V>(f.cb)) : v;
    w2 = early ? (kept ? w20 : lane_splat<V>(1.0)) : w2;
  } else {
    before = before | early;  // a reading point before the start: 0
  }
  u = before ? lane_splat<V>(0.0) : u;
  v = before ? lane_splat<V>(1.0) : v;
  w2 = before ? lane_splat<V>(1.0) : w2;
}

}  // namespace photosite::scene::detail
#pragma GCC diagnostic pop
