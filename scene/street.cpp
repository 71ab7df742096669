// Street lighting as point sources in road coordinates (see street.h).
//
// Photometry: a luminaire of intensity I(γ) (cd, γ from the nadir) at height H above the ground
// gives the horizontal illuminance E = I(γ)·cos γ / d² at a ground point at distance d (inverse
// square and cosine laws). The road's luminance is L = ρ·E/π (Lambertian road, an approximation:
// EN 13201-3 uses the r-table of the surface, which brightens the road toward grazing view).
// EN 13201-3 evaluates L_avg and U0 = L_min/L_avg on a grid over one luminaire spacing: here 10
// points along by 6 across the road.
#include "photosite/scene/street.h"

#include <algorithm>
#include <atomic>
#include <bit>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <memory>
#include <immintrin.h>
#include <numeric>
#include <omp.h>
#include <optional>
#include <thread>
#include <unordered_set>

#include "core/isa_detail.h"
#include "photosite/environment.h"
#include "photosite/rng.h"
#include "photosite/sensor/spectrum.h"
#include "scene/crown_phase_detail.h"
#include "scene/night_detail.h"
#include "scene/street_detail.h"

namespace photosite::scene {

double lamp_relative_intensity(double gamma, const ScenePreset& p) {
  const double gc = p.lamp_cutoff_deg * M_PI / 180;
  if (gamma <= gc) return 1;
  return std::exp(-(gamma - gc) / (p.lamp_falloff_deg * M_PI / 180));
}

namespace {
// The horizontal reach beyond which a lamp's contribution is dropped: γ = cutoff + 2·falloff
// (13.5% of the peak intensity; with cos³γ the illuminance there is 0.24% of the nadir value at
// the preset's 65° + 2·5°), at most 85°.
double reach_m(double H, const ScenePreset& p) {
  const double g = std::min(85.0, p.lamp_cutoff_deg + 2 * p.lamp_falloff_deg) * M_PI / 180;
  return H * std::tan(g);
}
double cos_cut(const ScenePreset& p) { return std::cos(p.lamp_cutoff_deg * M_PI / 180); }
// The distribution beyond the cut-off as a table over cos γ in [0, cos γ_c] (4096 steps, linear
// interpolation: relative error below 1e-6 at the presets' 5° falloff, as the function is smooth
// there; (h/φ)²/8 in general, h the step in γ), built per preset:
// acos and exp per pixel and luminaire were most of the light map's time.
struct RelTable {
  double cc = 0, step = 0, cutoff = -1, falloff = -1;
  std::vector<double> v;
  // The float32 copy the image paths use (pools, vertical light): v[i] and v[i + 1] − v[i] rounded
  // to float, cos γ_c rounded, and the inverse step, so the argument is one product (atf).
  std::vector<float> fv, fdv;
  // The same pairs interleaved (fv[i], fdv[i] at 2i, 2i + 1), 8-byte aligned: the vector paths
  // fetch both by one 64-bit gather per lane, half the loads of a gather from each.
  std::vector<double> fpair;
  float fcc = 0, finv_step = 0;
  // The same distribution as 16 quartic pieces over [0, cos γ_c] (piece j on [j, j + 1]·h, h =
  // cos γ_c/16, in s = c/h − j ∈ [0, 1]), their float coefficients pc[k][j] of s^k: 16 floats per
  // power, one vector register on AVX-512 (two on AVX2), so the vector paths take a piece's
  // coefficients by a permute instead of gathering table entries from memory, most of the
  // vertical light's time beyond the cut-off. Interpolated at the Chebyshev nodes of each piece;
  // used (poly) only where its measured relative error, the float coefficients evaluated in
  // double at 64 points per piece and at both ends, is within kPolyMaxRelErr (the 4096-step
  // table's own bound): at the presets' 65° + 5° it is 1.2·10⁻⁷; a falloff steeper than about 3°
  // takes the table instead. (rel_table builds it; poly_max_rel_err records the measured error.)
  static constexpr double kPolyMaxRelErr = 1e-6;
  bool poly = false;
  double poly_max_rel_err = 0;
  float fseg = 0;  // 16/cos γ_c rounded to float
  alignas(64) float pc[5][16] = {};
  // The piece's value at c in float: u = c·fseg, j = ⌊u⌋ clamped to [0, 15], s = u − j (exact),
  // Horner from the highest power.
  float polyf(float c) const {
    const float u = c * fseg;
    const int j = std::max(0, std::min(15, static_cast<int>(u)));
    const float x = u - static_cast<float>(j);
    return (((pc[4][j] * x + pc[3][j]) * x + pc[2][j]) * x + pc[1][j]) * x + pc[0][j];
  }
  // polyf by Estrin's scheme, the vertical light's form (its lamp loop waits on one lit term's
  // dependent chain, which Horner's eight steps lengthened; docs/benchmarks.md, "Thirty-second
  // session"): with x² = x·x, ((p0 + p1·x) + x²·(p2 + p3·x)) + (x²·x²)·p4, five dependent steps
  // instead of eight. Rounding over positive coefficients (the presets' pieces) and x ∈ [0, 1]: each
  // monomial's path passes at most 6 roundings (p3·x³: p3·x, the sum, x², the product, two sums;
  // p4·x⁴: x² twice in x⁴, x⁴, ·p4, the last sum), so within 6·2⁻²⁴ relative to first order,
  // against Horner's 8.
  float polyf_estrin(float c) const {
    const float u = c * fseg;
    const int j = std::max(0, std::min(15, static_cast<int>(u)));
    const float x = u - static_cast<float>(j), x2 = x * x;
    return ((pc[0][j] + pc[1][j] * x) + x2 * (pc[2][j] + pc[3][j] * x)) + (x2 * x2) * pc[4][j];
  }
  // kEstrin: the pieces by polyf_estrin (the vertical light), else polyf (the pools).
  template <bool kEstrin = false>
  float atf(float c) const {
    if (!(c < fcc)) return 1.f;
    if (poly) return kEstrin ? polyf_estrin(c) : polyf(c);
    const float u = c * finv_step;
    const int i = std::max(0, std::min(4095, static_cast<int>(u)));
    return fv[i] + fdv[i] * (u - static_cast<float>(i));
  }
  // I(γ)/I0 at cos γ = c: 1 inside the cut-off cone (c >= cc), else linear between the entries.
  double at(double c) const {
    if (!(c < cc)) return 1.0;
    const double u = c / step;
    const int i = std::min(4095, static_cast<int>(u));
    return v[i] + (v[i + 1] - v[i]) * (u - i);
  }
};
// RelTable's quartic pieces (see there) and whether they are used.
void fit_rel_pieces(RelTable& t, const ScenePreset& p) {
  const double h = t.cc / 16;
  t.fseg = static_cast<float>(16 / t.cc);
  auto f = [&](double c) { return lamp_relative_intensity(std::acos(std::min(1.0, std::max(0.0, c))), p); };
  double worst = 0;
  for (int j = 0; j < 16; ++j) {
    // Interpolation at the five Chebyshev nodes of [0, 1]: the Vandermonde system solved by
    // Gaussian elimination with partial pivoting (5×5, in double).
    double A[5][6];
    for (int i = 0; i < 5; ++i) {
      const double x = 0.5 * (1 + std::cos((2 * i + 1) * M_PI / 10));
      double xp = 1;
      for (int k = 0; k < 5; ++k, xp *= x) A[i][k] = xp;
      A[i][5] = f((j + x) * h);
    }
    for (int col = 0; col < 5; ++col) {
      int piv = col;
      for (int r = col + 1; r < 5; ++r)
        if (std::fabs(A[r][col]) > std::fabs(A[piv][col])) piv = r;
      std::swap(A[col], A[piv]);
      for (int r = 0; r < 5; ++r) {
        if (r == col) continue;
        const double m = A[r][col] / A[col][col];
        for (int k = col; k < 6; ++k) A[r][k] -= m * A[col][k];
      }
    }
    for (int k = 0; k < 5; ++k) t.pc[k][j] = static_cast<float>(A[k][5] / A[k][k]);
    for (int i = 0; i <= 64; ++i) {
      const double x = i / 64.0, c = (j + x) * h;
      const double v = (((double{t.pc[4][j]} * x + t.pc[3][j]) * x + t.pc[2][j]) * x + t.pc[1][j]) * x + t.pc[0][j];
      worst = std::max(worst, std::fabs(v / f(c) - 1));
    }
  }
  t.poly_max_rel_err = worst;
  t.poly = worst <= RelTable::kPolyMaxRelErr;
}
const RelTable& rel_table(const ScenePreset& p) {
  thread_local RelTable t;
  if (t.cutoff != p.lamp_cutoff_deg || t.falloff != p.lamp_falloff_deg) {
    t.cutoff = p.lamp_cutoff_deg;
    t.falloff = p.lamp_falloff_deg;
    t.cc = cos_cut(p);
    t.v.resize(4097);
    t.step = t.cc / 4096;
    for (int i = 0; i <= 4096; ++i) t.v[i] = lamp_relative_intensity(std::acos(std::min(1.0, i * t.step)), p);
    t.fv.resize(4096);
    t.fdv.resize(4096);
    t.fpair.resize(4096);
    for (int i = 0; i < 4096; ++i) {
      t.fv[i] = static_cast<float>(t.v[i]);
      t.fdv[i] = static_cast<float>(t.v[i + 1] - t.v[i]);
      const float pr[2] = {t.fv[i], t.fdv[i]};
      std::memcpy(&t.fpair[i], pr, sizeof pr);
    }
    t.fcc = static_cast<float>(t.cc);
    t.finv_step = static_cast<float>(1 / t.step);
    fit_rel_pieces(t, p);
  }
  return t;
}
inline double lamp_E(double dx, double dz, double H, double I0, const RelTable& t) {
  const double d2 = dx * dx + dz * dz + H * H, d = std::sqrt(d2), c = H / d;
  return I0 * t.at(c) * c / d2;
}
// The ground pools in float32, eight lanes (issue 16 §3: the rounding difference stated here).
// The row's lamps within reach: X_l (double), and dz², H², H, I0 rounded to float once per row.
// Per pixel and lamp, with u = 2⁻²⁴ and every IEEE operation correctly rounded (|rel. err.| ≤ u):
//   dx = fl(X − X_l)            the difference in double, rounded once     1u
//   d² = (dx² + dz²) + H²       dx² 3u, dz² and H² 1u each (positive: the sum keeps the largest), 2 adds   5u
//   d = √d², c = H/d            2.5 + 1; then H 1 + d 3.5 + 1            d 3.5u, c 5.5u
//   inside the cut-off (rel = 1): e = ((I0·1)·c)/d²: I0 1 + c 5.5 + 1 + d² 5 + 1          13.5u
//   beyond it, rel(c) from the float table at c·(1/step) (argument 5.5 + 1 + 1 = 7.5u, amplified by
//   s = |d ln rel/d ln cos γ| = cot γ/φ_f ≤ cot γ_c/φ_f, φ_f the falloff in radians; the entries
//   and the lerp 3u) and one more product: 13.5 + 1 + 3 + 7.5·s
//   so per term k = 17.5 + 7.5·s (s = 5.34 at the presets' 65° + 5°: k = 57.6);
//   from the quartic pieces (RelTable::polyf, used where they fit, as at the presets' angles) the
//   argument c·(16/cos γ_c) is 7.5u as well and Horner's 4 products and 4 sums over positive
//   coefficients (the presets' pieces) 8u instead of 3u: k = 22.5 + 7.5·s (62.6),
// and the sum of n positive terms adds n roundings of partial sums ≤ E, so to first order
//   |E_float − E| ≤ (k + n)·2⁻²⁴·Σ|terms| = (k + n)·2⁻²⁴·E,
// E the exact value of the same formula (and table or pieces, each within 10⁻⁶ of the law): at
// most 3.9e-6·E for 3 lamps at the presets' angles. (The double path this replaced was within ~1e-15·E; the image stores E as a float
// anyway, 2⁻²⁴.) pool_row_avx2 and pool_row_scalar perform the same float operations in the same
// order, so the same bits with or without AVX2.
struct PoolLamps {
  std::vector<double> Xl;
  std::vector<float> dz2, H2, Hl;
  void clear() { Xl.clear(); dz2.clear(); H2.clear(); Hl.clear(); }
  void add(double X, double dz, double H) {
    Xl.push_back(X);
    dz2.push_back(static_cast<float>(dz * dz));
    H2.push_back(static_cast<float>(H * H));
    Hl.push_back(static_cast<float>(H));
  }
  int size() const { return static_cast<int>(Xl.size()); }
};
[[gnu::always_inline]] inline float pool_term(float dx, float dz2, float H2, float Hl, float I0, const RelTable& t) {
  const float d2 = (dx * dx + dz2) + H2, d = std::sqrt(d2), c = Hl / d;
  return ((I0 * t.atf(c)) * c) / d2;
}
// The pools of one row: e[i] for the pixels of the groups of eight holding a ground pixel
// (mask[i/8] != 0), from the pixels' ground X (Xg, the row's (x − c_x)·k_x); other groups are
// not computed (nothing reads them).
void pool_row_scalar(float* e, const double* Xg, const uint8_t* mask, int n, const PoolLamps& pl, float I0,
                     const RelTable& t) {
  const int nl = pl.size();
  for (int i = 0; i < n; ++i) {
    if (!mask[i / 8]) continue;
    float acc = 0.f;
    for (int k = 0; k < nl; ++k)
      acc += pool_term(static_cast<float>(Xg[i] - pl.Xl[k]), pl.dz2[k], pl.H2[k], pl.Hl[k], I0, t);
    e[i] = acc;
  }
}
// The widest instruction set the light paths take: 2 AVX-512 (its functions use F and VL: the
// AVX2 code compiled with 32 vector registers), 1 AVX2, 0 the scalar twins; the machine's level
// (core/isa_detail.h), 0 with PHOTOSITE_SCALAR_LIGHTS=1 (to check that all give the same bits),
// capped by street_light_max_isa (tests).
const int kMachineIsa =
    env::get(env::Var::ScalarLights).value_or("0") == "1" ? 0 : photosite::detail::machine_isa_level();
int g_isa_cap = 2;
int light_isa() { return std::min(kMachineIsa, g_isa_cap); }
// RelTable::polyf for eight lanes: the piece's coefficients by two permutes of the sixteen (lanes
// j < 8 from the first eight, else the second) and a blend; the same operations.
__attribute__((target("avx2"), always_inline)) inline __m256 piece_coef8(const float* pc, __m256i j, __m256 hi) {
  return _mm256_blendv_ps(_mm256_permutevar8x32_ps(_mm256_load_ps(pc), j), _mm256_permutevar8x32_ps(_mm256_load_ps(pc + 8), j),
                          hi);
}
// kEstrin: RelTable::polyf_estrin's operations, the piece's index by a rounding down (u ≥ 0 on
// every lane whose value is kept: the same j and x as the scalar's truncation, two dependent
// conversions fewer).
template <bool kEstrin>
__attribute__((target("avx2"), always_inline)) inline __m256 rel_poly8(const RelTable& t, __m256 c) {
  const __m256 u = _mm256_mul_ps(c, _mm256_set1_ps(t.fseg));
  if (kEstrin) {
    const __m256 fj = _mm256_min_ps(_mm256_round_ps(u, _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC), _mm256_set1_ps(15.f));
    const __m256i j = _mm256_cvttps_epi32(fj);
    const __m256 x = _mm256_sub_ps(u, fj), x2 = _mm256_mul_ps(x, x);
    const __m256 hi = _mm256_castsi256_ps(_mm256_cmpgt_epi32(j, _mm256_set1_epi32(7)));
    const __m256 a = _mm256_add_ps(piece_coef8(t.pc[0], j, hi), _mm256_mul_ps(piece_coef8(t.pc[1], j, hi), x));
    const __m256 b = _mm256_add_ps(piece_coef8(t.pc[2], j, hi), _mm256_mul_ps(piece_coef8(t.pc[3], j, hi), x));
    return _mm256_add_ps(_mm256_add_ps(a, _mm256_mul_ps(x2, b)),
                         _mm256_mul_ps(_mm256_mul_ps(x2, x2), piece_coef8(t.pc[4], j, hi)));
  }
  const __m256i j = _mm256_max_epi32(_mm256_min_epi32(_mm256_cvttps_epi32(u), _mm256_set1_epi32(15)),
                                     _mm256_setzero_si256());
  const __m256 x = _mm256_sub_ps(u, _mm256_cvtepi32_ps(j));
  const __m256 hi = _mm256_castsi256_ps(_mm256_cmpgt_epi32(j, _mm256_set1_epi32(7)));
  __m256 v = _mm256_add_ps(_mm256_mul_ps(piece_coef8(t.pc[4], j, hi), x), piece_coef8(t.pc[3], j, hi));
  v = _mm256_add_ps(_mm256_mul_ps(v, x), piece_coef8(t.pc[2], j, hi));
  v = _mm256_add_ps(_mm256_mul_ps(v, x), piece_coef8(t.pc[1], j, hi));
  return _mm256_add_ps(_mm256_mul_ps(v, x), piece_coef8(t.pc[0], j, hi));
}
// RelTable::atf for eight lanes beyond the cut-off (the caller blends the others): the pieces
// (rel_poly8) or the table's entries by gathers (the index clamped to [0, 4095] so that lanes
// whose result is dropped stay inside the table): the same operations.
// (kEstrin: the pieces as RelTable::atf<true>.)
template <bool kEstrin = false>
__attribute__((target("avx2"), always_inline)) inline __m256 rel_lerp_f(const RelTable& t, __m256 c) {
  if (t.poly) return rel_poly8<kEstrin>(t, c);
  const __m256 u = _mm256_mul_ps(c, _mm256_set1_ps(t.finv_step));
  const __m256i j = _mm256_max_epi32(_mm256_min_epi32(_mm256_cvttps_epi32(u), _mm256_set1_epi32(4095)),
                                     _mm256_setzero_si256());
  // The pairs of lanes 0-3 and 4-7 (each 64-bit lane: fv, fdv), split into the eight fv and fdv
  // (within each 128-bit half the even and odd floats of both gathers, then the halves' middle
  // quarters swapped into lane order).
  // (The masked form with every lane on: the unmasked one starts from an undefined register, which
  // GCC 12 warns of.)
  const double* tp = t.fpair.data();
  const __m256d zd = _mm256_setzero_pd(), all = _mm256_castsi256_pd(_mm256_set1_epi64x(-1));
  const __m256 g0 = _mm256_castpd_ps(_mm256_mask_i32gather_pd(zd, tp, _mm256_castsi256_si128(j), all, 8));
  const __m256 g1 = _mm256_castpd_ps(_mm256_mask_i32gather_pd(zd, tp, _mm256_extracti128_si256(j, 1), all, 8));
  const __m256 v = _mm256_castpd_ps(_mm256_permute4x64_pd(_mm256_castps_pd(_mm256_shuffle_ps(g0, g1, 0x88)), 0xd8));
  const __m256 dv = _mm256_castpd_ps(_mm256_permute4x64_pd(_mm256_castps_pd(_mm256_shuffle_ps(g0, g1, 0xdd)), 0xd8));
  return _mm256_add_ps(v, _mm256_mul_ps(dv, _mm256_sub_ps(u, _mm256_cvtepi32_ps(j))));
}
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"  // GCC 12's _mm512_undefined_*() (as in darken.cpp)
// Two float32x8 halves as one float32x16 (lo in lanes 0-7).
__attribute__((target("avx512f"), always_inline)) inline __m512 join16(__m256 lo, __m256 hi) {
  return _mm512_castpd_ps(_mm512_insertf64x4(_mm512_castps_pd(_mm512_castps256_ps512(lo)), _mm256_castps_pd(hi), 1));
}
// fl(a − b) per lane for sixteen lanes held as two float64x8 (b0: lanes 0-7, b1: 8-15), a broadcast.
__attribute__((target("avx512f"), always_inline)) inline __m512 diff16(__m512d a, __m512d b0, __m512d b1) {
  return join16(_mm512_cvtpd_ps(_mm512_sub_pd(a, b0)), _mm512_cvtpd_ps(_mm512_sub_pd(a, b1)));
}
// RelTable::atf (rel_lerp_f) for sixteen lanes: on the lanes of `beyond` (beyond the cut-off) the
// same operations (the pieces' coefficients by permutes, or the table's entries gathered for those
// lanes only); 1 on the others. (kEstrin: the pieces as RelTable::atf<true>, rel_poly8's.)
template <bool kEstrin = false>
__attribute__((target("avx512f"), always_inline)) inline __m512 rel_lerp16(const RelTable& t, __m512 c,
                                                                          __mmask16 beyond) {
  if (t.poly && kEstrin) {  // RelTable::polyf_estrin
    const __m512 u = _mm512_mul_ps(c, _mm512_set1_ps(t.fseg));
    const __m512 fj = _mm512_min_ps(_mm512_roundscale_ps(u, _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC), _mm512_set1_ps(15.f));
    const __m512i j = _mm512_cvttps_epi32(fj);
    const __m512 x = _mm512_sub_ps(u, fj), x2 = _mm512_mul_ps(x, x);
    const __m512 a = _mm512_add_ps(_mm512_permutexvar_ps(j, _mm512_load_ps(t.pc[0])),
                                   _mm512_mul_ps(_mm512_permutexvar_ps(j, _mm512_load_ps(t.pc[1])), x));
    const __m512 b = _mm512_add_ps(_mm512_permutexvar_ps(j, _mm512_load_ps(t.pc[2])),
                                   _mm512_mul_ps(_mm512_permutexvar_ps(j, _mm512_load_ps(t.pc[3])), x));
    return _mm512_mask_add_ps(_mm512_set1_ps(1.f), beyond, _mm512_add_ps(a, _mm512_mul_ps(x2, b)),
                              _mm512_mul_ps(_mm512_mul_ps(x2, x2), _mm512_permutexvar_ps(j, _mm512_load_ps(t.pc[4]))));
  }
  if (t.poly) {  // RelTable::polyf: the piece's coefficients by one permute each
    const __m512 u = _mm512_mul_ps(c, _mm512_set1_ps(t.fseg));
    const __m512i j = _mm512_max_epi32(_mm512_min_epi32(_mm512_cvttps_epi32(u), _mm512_set1_epi32(15)),
                                       _mm512_setzero_si512());
    const __m512 x = _mm512_sub_ps(u, _mm512_cvtepi32_ps(j));
    const __m512 c4 = _mm512_permutexvar_ps(j, _mm512_load_ps(t.pc[4])), c3 = _mm512_permutexvar_ps(j, _mm512_load_ps(t.pc[3]));
    const __m512 c2 = _mm512_permutexvar_ps(j, _mm512_load_ps(t.pc[2])), c1 = _mm512_permutexvar_ps(j, _mm512_load_ps(t.pc[1]));
    const __m512 c0 = _mm512_permutexvar_ps(j, _mm512_load_ps(t.pc[0]));
    __m512 v = _mm512_add_ps(_mm512_mul_ps(c4, x), c3);
    v = _mm512_add_ps(_mm512_mul_ps(v, x), c2);
    v = _mm512_add_ps(_mm512_mul_ps(v, x), c1);
    return _mm512_mask_add_ps(_mm512_set1_ps(1.f), beyond, _mm512_mul_ps(v, x), c0);
  }
  const __m512 u = _mm512_mul_ps(c, _mm512_set1_ps(t.finv_step));
  const __m512i j = _mm512_max_epi32(_mm512_min_epi32(_mm512_cvttps_epi32(u), _mm512_set1_epi32(4095)),
                                     _mm512_setzero_si512());
  // Lanes 0-7 and 8-15 as pairs (fv, fdv) by one 64-bit gather each, then the even and odd
  // floats of both: the sixteen fv and the sixteen fdv in lane order.
  const double* tp = t.fpair.data();
  const __m512d zd = _mm512_setzero_pd();
  const __m512 g0 = _mm512_castpd_ps(
      _mm512_mask_i32gather_pd(zd, static_cast<__mmask8>(beyond), _mm512_castsi512_si256(j), tp, 8));
  const __m512 g1 = _mm512_castpd_ps(_mm512_mask_i32gather_pd(
      zd, static_cast<__mmask8>(beyond >> 8), _mm256_castpd_si256(_mm512_extractf64x4_pd(_mm512_castsi512_pd(j), 1)), tp, 8));
  const __m512i even = _mm512_setr_epi32(0, 2, 4, 6, 8, 10, 12, 14, 16, 18, 20, 22, 24, 26, 28, 30);
  const __m512 v = _mm512_permutex2var_ps(g0, even, g1);
  const __m512 dv = _mm512_permutex2var_ps(g0, _mm512_add_epi32(even, _mm512_set1_epi32(1)), g1);
  return _mm512_mask_add_ps(_mm512_set1_ps(1.f), beyond, v, _mm512_mul_ps(dv, _mm512_sub_ps(u, _mm512_cvtepi32_ps(j))));
}
#pragma GCC diagnostic pop
// pool_row_scalar eight pixels at a time (Xg padded to a multiple of 8; e written for whole groups).
__attribute__((target("avx2"), always_inline)) inline void pool_row_body(float* e, const double* Xg, const uint8_t* mask,
                                                                          int n, const PoolLamps& pl, float I0,
                                                                          const RelTable& t) {
  const __m256 vcc = _mm256_set1_ps(t.fcc), vI0 = _mm256_set1_ps(I0), one = _mm256_set1_ps(1.f);
  const int nl = pl.size();
  for (int i = 0; i < n; i += 8) {
    if (!mask[i / 8]) continue;
    const __m256d X0 = _mm256_loadu_pd(Xg + i), X1 = _mm256_loadu_pd(Xg + i + 4);
    __m256 acc = _mm256_setzero_ps();
    for (int k = 0; k < nl; ++k) {
      const __m256d xl = _mm256_broadcast_sd(&pl.Xl[k]);
      const __m256 dx = _mm256_set_m128(_mm256_cvtpd_ps(_mm256_sub_pd(X1, xl)), _mm256_cvtpd_ps(_mm256_sub_pd(X0, xl)));
      const __m256 d2 = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(dx, dx), _mm256_broadcast_ss(&pl.dz2[k])),
                                      _mm256_broadcast_ss(&pl.H2[k]));
      const __m256 c = _mm256_div_ps(_mm256_broadcast_ss(&pl.Hl[k]), _mm256_sqrt_ps(d2));
      const __m256 beyond = _mm256_cmp_ps(c, vcc, _CMP_LT_OQ);  // γ beyond the cut-off: the table
      __m256 rel = one;
      if (_mm256_movemask_ps(beyond)) rel = _mm256_blendv_ps(one, rel_lerp_f(t, c), beyond);
      acc = _mm256_add_ps(acc, _mm256_div_ps(_mm256_mul_ps(_mm256_mul_ps(vI0, rel), c), d2));
    }
    _mm256_storeu_ps(e + i, acc);
  }
  _mm256_zeroupper();
}
__attribute__((target("avx2"))) void pool_row_avx2(float* e, const double* Xg, const uint8_t* mask, int n,
                                                  const PoolLamps& pl, float I0, const RelTable& t) {
  pool_row_body(e, Xg, mask, n, pl, I0, t);
}
// The shadows' step (PoolPass::shade) eight pixels at a time: on the columns x0 .. x1 − 1 of a row
// (whole groups of eight from x0; returns where it stopped, the rest left to the scalar loop), each
// ground pixel (bit x of gb) loses one lamp's term, pool_term at its ground X = (x − c_x)·k_x, held
// at 0 or above: pool_row_body's operations for that lamp (the same float term as the scalar
// pool_term), then fl(acc − t') and max(·, 0), the other pixels kept; the same bits as the scalar
// loop. t' = the term where m ≥ ns, else term·fl(m·per_point) (lose()'s share), m the count of the
// lamp's points in shadow: cnt[x] per column, or one m for all (cnt null). *shaded counts the
// ground pixels.
__attribute__((target("avx2"))) int shade_cols_avx2(float* acc, const uint8_t* gb, const int32_t* cnt, int m_all,
                                                    int x0, int x1, int ns, float per_point, double cx_px, double kx,
                                                    double Xl, float dz2, float H2, float Hl, float I0,
                                                    const RelTable& t, long long* shaded) {
  const __m256 vcc = _mm256_set1_ps(t.fcc), vI0 = _mm256_set1_ps(I0), one = _mm256_set1_ps(1.f);
  const __m256 vdz2 = _mm256_set1_ps(dz2), vH2 = _mm256_set1_ps(H2), vHl = _mm256_set1_ps(Hl);
  const __m256 vpp = _mm256_set1_ps(per_point), zero = _mm256_setzero_ps();
  const __m256d vcx = _mm256_set1_pd(cx_px), vkx = _mm256_set1_pd(kx), xl = _mm256_set1_pd(Xl);
  const __m256i lane_bit = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128), nsm1 = _mm256_set1_epi32(ns - 1);
  const __m256i m_one = _mm256_set1_epi32(m_all);
  int x = x0;
  for (; x + 8 <= x1; x += 8) {
    const unsigned bits = ((static_cast<unsigned>(gb[x >> 3]) | static_cast<unsigned>(gb[(x >> 3) + 1]) << 8) >> (x & 7)) & 255u;
    if (!bits) continue;
    const __m256d xs = _mm256_setr_pd(x, x + 1, x + 2, x + 3);
    const __m256d X0 = _mm256_mul_pd(_mm256_sub_pd(xs, vcx), vkx);
    const __m256d X1 = _mm256_mul_pd(_mm256_sub_pd(_mm256_add_pd(xs, _mm256_set1_pd(4.0)), vcx), vkx);
    const __m256 dx = _mm256_set_m128(_mm256_cvtpd_ps(_mm256_sub_pd(X1, xl)), _mm256_cvtpd_ps(_mm256_sub_pd(X0, xl)));
    const __m256 d2 = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(dx, dx), vdz2), vH2);
    const __m256 c = _mm256_div_ps(vHl, _mm256_sqrt_ps(d2));
    const __m256 beyond = _mm256_cmp_ps(c, vcc, _CMP_LT_OQ);
    __m256 rel = one;
    if (_mm256_movemask_ps(beyond)) rel = _mm256_blendv_ps(one, rel_lerp_f(t, c), beyond);
    const __m256 term = _mm256_div_ps(_mm256_mul_ps(_mm256_mul_ps(vI0, rel), c), d2);
    const __m256i m = cnt ? _mm256_loadu_si256(reinterpret_cast<const __m256i*>(cnt + x)) : m_one;
    const __m256 whole = _mm256_castsi256_ps(_mm256_cmpgt_epi32(m, nsm1));  // m ≥ ns
    const __m256 part = _mm256_mul_ps(term, _mm256_mul_ps(_mm256_cvtepi32_ps(m), vpp));
    const __m256 a = _mm256_loadu_ps(acc + x);
    const __m256 lost = _mm256_max_ps(_mm256_sub_ps(a, _mm256_blendv_ps(part, term, whole)), zero);
    const __m256 on = _mm256_castsi256_ps(
        _mm256_cmpeq_epi32(_mm256_and_si256(_mm256_set1_epi32(static_cast<int>(bits)), lane_bit), lane_bit));
    _mm256_storeu_ps(acc + x, _mm256_blendv_ps(a, lost, on));
    *shaded += std::popcount(bits);
  }
  _mm256_zeroupper();
  return x;
}
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"  // GCC 12's _mm512_undefined_*() (as in darken.cpp)
// The same row compiled for AVX-512VL (32 vector registers; the same operations, no FMA
// contraction: the same bits; see vertical_row_avx512). (Sixteen lanes at a time, as the vertical
// light, measured no faster here: pools + heads alone 9.7-10.7 ms against 10.1-10.2, 1 thread.)
__attribute__((target("avx2,avx512f,avx512vl"))) void pool_row_avx512(float* e, const double* Xg, const uint8_t* mask,
                                                                     int n, const PoolLamps& pl, float I0,
                                                                     const RelTable& t) {
  pool_row_body(e, Xg, mask, n, pl, I0, t);
}
// The ground pixels of a row as bits, one byte per aligned group of eight (bit k of bits[q]: pixel
// 8q + k): class id in `classes` (bit id of the mask; ids of 64 and above in no class). Scalar,
// and eight pixels at a time with AVX2 (the same bits).
void class_bits_scalar(const uint16_t* id, int W, uint64_t classes, uint8_t* bits) {
  for (int q = 0; 8 * q < W; ++q) {
    unsigned m = 0;
    for (int k = 0; k < 8 && 8 * q + k < W; ++k) {
      const int c = id[8 * q + k];
      m |= static_cast<unsigned>(c < 64 && (classes >> c & 1)) << k;
    }
    bits[q] = static_cast<uint8_t>(m);
  }
}
__attribute__((target("avx2"))) void class_bits_avx2(const uint16_t* id, int W, uint64_t classes, uint8_t* bits) {
  const __m256i mlo = _mm256_set1_epi32(static_cast<int32_t>(classes & 0xffffffffu)),
                mhi = _mm256_set1_epi32(static_cast<int32_t>(classes >> 32)), one = _mm256_set1_epi32(1),
                k32 = _mm256_set1_epi32(32);
  int q = 0;
  for (; 8 * q + 8 <= W; ++q) {
    const __m256i k = _mm256_cvtepu16_epi32(_mm_loadu_si128(reinterpret_cast<const __m128i*>(id + 8 * q)));
    // Bit k of the mask: the low word shifted by k (0 for k ≥ 32), the high word by k − 32 (0
    // for k < 32, where the count wraps to a huge unsigned value, and for k ≥ 64).
    const __m256i bit = _mm256_and_si256(
        _mm256_or_si256(_mm256_srlv_epi32(mlo, k), _mm256_srlv_epi32(mhi, _mm256_sub_epi32(k, k32))), one);
    bits[q] = static_cast<uint8_t>(_mm256_movemask_ps(_mm256_castsi256_ps(_mm256_cmpeq_epi32(bit, one))));
  }
  if (8 * q < W) class_bits_scalar(id + 8 * q, W - 8 * q, classes, bits + q);
}
// The reflection into L (pools, vertical surfaces) over the groups qa .. qb − 1: o += (t·tint)·e on the pixels whose
// bit is set (the same float operations per channel as the scalar loop; the other pixels keep
// their bits). AVX2 for whole groups (the 24 floats of eight pixels, e and the bits spread to
// the channels by lane permutations), the scalar loop for the rest.
void add_reflection_scalar(float* o, const float* tx, const float* e, const uint8_t* bits, int qa, int qb, int W,
                           const float* tint) {
  const float t0 = tint[0], t1 = tint[1], t2 = tint[2];  // in registers (o's stores may alias tint otherwise)
  for (int x = 8 * qa; x < std::min(W, 8 * qb); ++x) {
    if (!(bits[x / 8] >> (x % 8) & 1)) continue;
    const float ef = e[x];
    o[3 * x] += tx[3 * x] * t0 * ef;
    o[3 * x + 1] += tx[3 * x + 1] * t1 * ef;
    o[3 * x + 2] += tx[3 * x + 2] * t2 * ef;
  }
}
// add_reflection_avx2's constants: the lane permutations spreading eight pixels' E and bits to
// their 24 channel floats, and the tint in channel order.
struct Reflect8 {
  __m256i s0, s1, s2, lane_bit;
  __m256 tp0, tp1, tp2;
};
__attribute__((target("avx2"), always_inline)) inline Reflect8 reflect8_consts(const float* tint) {
  const float t0 = tint[0], t1 = tint[1], t2 = tint[2];
  return {_mm256_setr_epi32(0, 0, 0, 1, 1, 1, 2, 2), _mm256_setr_epi32(2, 3, 3, 3, 4, 4, 4, 5),
          _mm256_setr_epi32(5, 5, 6, 6, 6, 7, 7, 7), _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128),
          _mm256_setr_ps(t0, t1, t2, t0, t1, t2, t0, t1), _mm256_setr_ps(t2, t0, t1, t2, t0, t1, t2, t0),
          _mm256_setr_ps(t1, t2, t0, t1, t2, t0, t1, t2)};
}
// One group of eight pixels (o3, t3: their 24 floats): o += (t·tint)·e where bit k of `bits` is set.
__attribute__((target("avx2"), always_inline)) inline void reflect8_avx2(float* o3, const float* t3, __m256 ef,
                                                                         unsigned bits, const Reflect8& c) {
  const __m256i m = _mm256_cmpeq_epi32(_mm256_and_si256(_mm256_set1_epi32(static_cast<int>(bits)), c.lane_bit), c.lane_bit);
  const __m256 ov0 = _mm256_loadu_ps(o3), ov1 = _mm256_loadu_ps(o3 + 8), ov2 = _mm256_loadu_ps(o3 + 16);
  const __m256 n0 = _mm256_add_ps(ov0, _mm256_mul_ps(_mm256_mul_ps(_mm256_loadu_ps(t3), c.tp0), _mm256_permutevar8x32_ps(ef, c.s0)));
  const __m256 n1 = _mm256_add_ps(ov1, _mm256_mul_ps(_mm256_mul_ps(_mm256_loadu_ps(t3 + 8), c.tp1), _mm256_permutevar8x32_ps(ef, c.s1)));
  const __m256 n2 = _mm256_add_ps(ov2, _mm256_mul_ps(_mm256_mul_ps(_mm256_loadu_ps(t3 + 16), c.tp2), _mm256_permutevar8x32_ps(ef, c.s2)));
  _mm256_storeu_ps(o3, _mm256_blendv_ps(ov0, n0, _mm256_castsi256_ps(_mm256_permutevar8x32_epi32(m, c.s0))));
  _mm256_storeu_ps(o3 + 8, _mm256_blendv_ps(ov1, n1, _mm256_castsi256_ps(_mm256_permutevar8x32_epi32(m, c.s1))));
  _mm256_storeu_ps(o3 + 16, _mm256_blendv_ps(ov2, n2, _mm256_castsi256_ps(_mm256_permutevar8x32_epi32(m, c.s2))));
}
__attribute__((target("avx2"))) void add_reflection_avx2(float* o, const float* tx, const float* e, const uint8_t* bits,
                                                        int qa, int qb, int W, const float* tint) {
  const Reflect8 c = reflect8_consts(tint);
  const int qfull = std::min(qb, W / 8);
  for (int q = qa; q < qfull; ++q)
    if (bits[q]) reflect8_avx2(o + 24 * q, tx + 24 * q, _mm256_loadu_ps(e + 8 * q), bits[q], c);
  if (qfull < qb) add_reflection_scalar(o, tx, e, bits, std::max(qa, qfull), qb, W, tint);
  _mm256_zeroupper();
}
// (below, beside reflect16_avx512)
void add_reflection_avx512(float* o, const float* tx, const float* e, const uint8_t* bits, int qa, int qb, int W,
                           const float* tint);
// vzeroupper: clears the upper halves of the vector registers. Vector code run earlier in the
// chain leaves them dirty, and every SSE (non-VEX) instruction after it then waits on a merge with
// them: add_vertical_street_light's loop ran 3.3× slower inside the light map than alone on the
// same inputs (bench night, AMD EPYC with AVX-512, 2026-11-25: 105 ms against 32 ms, one thread;
// 33 ms there after a vzeroupper). Where the state is left dirty is not found yet.
__attribute__((target("avx"))) void clear_upper_vector_state() { _mm256_zeroupper(); }
// Not the paths' level (core/isa_detail.h) on purpose: any CPU with AVX has the upper vector
// state to clear, also one without AVX2.
const bool kHaveAvx = __builtin_cpu_supports("avx");
}  // namespace

double street_lamp_reach_m(double H, const ScenePreset& p) { return reach_m(H, p); }
double street_layout_phase_m(const ScenePreset& p, uint64_t seed) {
  return p.lamp_spacing_ratio * p.lamp_mount_height_m * uniform_open(random_words(seed, 0, 0x57ee7u, Stream::Scene)[0]);
}

double street_illuminance_lux(double X, double D, const StreetLighting& s, const ScenePreset& p) {
  double e = 0;
  const RelTable& t = rel_table(p);
  for (const auto& l : s.lamps) e += lamp_E(X - l.X_m, D - l.D_m, l.Y_m, s.peak_intensity_cd, t);
  return e;
}

float lamp_relative_intensity_float(float c, const ScenePreset& p, bool* pieces, double* max_rel_err, bool estrin) {
  const RelTable& t = rel_table(p);
  if (pieces) *pieces = t.poly;
  if (max_rel_err) *max_rel_err = t.poly_max_rel_err;
  return estrin ? t.atf<true>(c) : t.atf(c);
}
void street_light_max_isa(int isa) { g_isa_cap = std::clamp(isa, 0, 2); }

std::vector<PoleBox> pole_components(const ImageU16& labels, const LabelRuns* lruns) {
  const int W = labels.width(), H = labels.height();
  if (lruns && !lruns->made_of(labels)) lruns = nullptr;
  // Each row's runs of pole pixels (first and last column, in pairs), rows in parallel: from the
  // label runs when given (touching runs of the two pole classes joined), else by a scan in which
  // blocks of 32 labels without a pole pixel are skipped by a branch-free test the compiler
  // vectorizes (poles are a few percent of a street frame).
  std::vector<std::vector<int>> runs(H);
#pragma omp parallel for schedule(static, 8)
  for (int y = 0; y < H; ++y) {
    if (lruns) {
      const uint16_t pole = static_cast<uint16_t>(Label::Pole), group = static_cast<uint16_t>(Label::PoleGroup);
      std::vector<int>& out = runs[y];
      bool open = false;
      for (int i = lruns->row_start[y]; i < lruns->row_start[y + 1]; ++i) {
        const uint16_t id = lruns->id[i];
        if (id != pole && id != group) {
          open = false;
          continue;
        }
        if (open) out.back() = lruns->end(i, y) - 1;
        else {
          out.push_back(lruns->x0[i]);
          out.push_back(lruns->end(i, y) - 1);
          open = true;
        }
      }
      continue;
    }
    const uint16_t* r = labels.row(y);
    const int Wr = W;  // a local: the pushes might alias the shared one otherwise
    const uint16_t pole = static_cast<uint16_t>(Label::Pole), group = static_cast<uint16_t>(Label::PoleGroup);
    std::vector<int>& out = runs[y];
    for (int x = 0; x < Wr;) {
      if ((x & 31) == 0 && x + 32 <= Wr) {
        unsigned any = 0;
        for (int k = x; k < x + 32; ++k) any |= (r[k] == pole) | (r[k] == group);
        if (!any) {
          x += 32;
          continue;
        }
      }
      if (!((r[x] == pole) | (r[x] == group))) {
        ++x;
        continue;
      }
      const int a = x;
      while (x < Wr && ((r[x] == pole) | (r[x] == group))) ++x;
      out.push_back(a);
      out.push_back(x - 1);
    }
  }
  // Union-find over the runs (numbered in raster order): runs of neighbouring rows touching in
  // the 8-neighbourhood (a.x0 ≤ b.x1 + 1 and b.x0 ≤ a.x1 + 1) are one component.
  std::vector<int> first(H + 1, 0);
  for (int y = 0; y < H; ++y) first[y + 1] = first[y] + static_cast<int>(runs[y].size() / 2);
  const int n = first[H];
  std::vector<int> parent(n);
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](int i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  };
  for (int y = 1; y < H; ++y) {
    const std::vector<int>&a = runs[y - 1], &b = runs[y];
    size_t i = 0, j = 0;
    while (i < a.size() && j < b.size()) {
      if (a[i + 1] + 1 < b[j]) i += 2;           // a ends before b starts (no diagonal contact)
      else if (b[j + 1] + 1 < a[i]) j += 2;      // b ends before a starts
      else {
        const int ra = find(first[y - 1] + static_cast<int>(i / 2)), rb = find(first[y] + static_cast<int>(j / 2));
        if (ra != rb) parent[std::max(ra, rb)] = std::min(ra, rb);
        // The run that ends first touches no later run of the other row (runs of a row are at
        // least one pixel apart).
        if (a[i + 1] < b[j + 1]) i += 2;
        else j += 2;
      }
    }
  }
  // Per component: its box and its first 2x2 block (y/2, x/2) in raster order of the blocks,
  // the order OpenCV numbers its components in (cv::connectedComponents, 8-connected: its
  // block-based scan (Spaghetti/BBDT, and the parallel version's stripes of even height) gives a
  // new provisional label to the first block of each component, the smallest of the component's
  // labels, which the final numbering keeps in increasing order).
  struct Comp { uint64_t key = ~0ull; PoleBox b{1 << 30, 1 << 30, -1, -1}; };
  std::vector<Comp> comp(n);
  for (int y = 0; y < H; ++y)
    for (size_t i = 0; i < runs[y].size(); i += 2) {
      Comp& c = comp[find(first[y] + static_cast<int>(i / 2))];
      const int x0 = runs[y][i], x1 = runs[y][i + 1];
      c.key = std::min(c.key, static_cast<uint64_t>(y >> 1) << 32 | static_cast<uint64_t>(x0 >> 1));
      c.b.x0 = std::min(c.b.x0, x0);
      c.b.x1 = std::max(c.b.x1, x1);
      c.b.y0 = std::min(c.b.y0, y);
      c.b.y1 = std::max(c.b.y1, y);
    }
  std::vector<const Comp*> roots;
  for (int i = 0; i < n; ++i)
    if (parent[i] == i) roots.push_back(&comp[i]);
  std::sort(roots.begin(), roots.end(), [](const Comp* a, const Comp* b) { return a->key < b->key; });
  std::vector<PoleBox> out;
  out.reserve(roots.size());
  for (const Comp* c : roots) out.push_back(c->b);
  return out;
}

std::shared_ptr<const PoleComponents> pole_components_of(const ImageU16& ids, const LabelRuns* runs) {
  auto m = std::make_shared<PoleComponents>();
  m->labels = LabelsMadeOf(ids);
  m->boxes = pole_components(ids, runs);
  return m;
}

StreetLighting plan_street_lighting(const LabelMap& lm, const CameraGeometry& g, const ScenePreset& p, uint64_t seed) {
  return plan_street_lighting_with(lm, g, p, seed, nullptr);
}

StreetLighting plan_street_lighting_with(const LabelMap& lm, const CameraGeometry& g, const ScenePreset& p,
                                         uint64_t seed, const PoleComponents* components) {
  StreetLighting s;
  const ImageU16& ids = lm.ids;
  const int W = ids.width(), H = ids.height();
  const double S = p.lamp_spacing_ratio * p.lamp_mount_height_m;
  // Road extent across: per row with the ground 20..60 m ahead, the carriageway the camera looks
  // along: from the principal column outward over road and the vehicles standing on it, to the
  // first other pixel (the kerb); a run reaching the image border says nothing about that side.
  // Medians over the rows. (Taking this run rather than the outermost road pixels keeps side
  // streets entering the view from moving the edges.)
  std::vector<double> lefts, rights, lefts_seen;
  const int xc = static_cast<int>(std::lround(g.cx_px));
  int rows_ahead = 0, rows_on_road = 0;  // for the note when no edge is found
  for (int y = std::max(0, static_cast<int>(std::ceil(g.horizon_y)) + 1); y < H && xc >= 0 && xc < W; ++y) {
    double D;
    if (!g.ground_point(g.cx_px, y, nullptr, &D, nullptr) || D < 20 || D > 60) continue;
    ++rows_ahead;
    if (ids.at(xc, y) != static_cast<int>(Label::Road)) continue;
    ++rows_on_road;
    int x0, x1;
    carriageway_run(ids, xc, y, &x0, &x1);
    double Xa, Xb;
    g.ground_point(x0 - 0.5, y, &Xa, nullptr, nullptr);
    g.ground_point(x1 + 0.5, y, &Xb, nullptr, nullptr);
    if (x0 > 0) lefts.push_back(Xa);
    // The run ends on road: its end is the kerb (a run that ends on a vehicle ends where the
    // vehicle hides the kerb).
    if (x0 > 0 && !is_vehicle(ids.at(x0, y))) lefts_seen.push_back(Xa);
    if (x1 < W - 1) rights.push_back(Xb);
  }
  // No road edge on a side: no layout to place luminaires along, and no lamps (the frame keeps
  // the ambient light, the vehicles' and the windows'); the header says why (street_lamp_note).
  if (lefts.empty() || rights.empty()) {
    s.note = rows_ahead == 0     ? "no ground row 20-60 m ahead of the camera in the frame"
             : rows_on_road == 0 ? "no road at the principal column 20-60 m ahead"
             : lefts.empty() && rights.empty()
                 ? "the road reaches both image borders 20-60 m ahead: no kerb seen"
                 : (lefts.empty() ? "the road reaches the image's left border 20-60 m ahead: no left kerb seen"
                                  : "the road reaches the image's right border 20-60 m ahead: no right kerb seen");
    return s;
  }
  auto median = [](std::vector<double> v) {
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    return v[v.size() / 2];
  };
  // In quarter metres: the layout (and the intensity scaled to it) then does not jitter as the
  // rows that enter the medians change with the view.
  s.road_left_m = 0.25 * std::round(4 * median(lefts));
  s.road_right_m = 0.25 * std::round(4 * median(rights));
  // Straight ahead: enough rows, and the left edge's 10th-90th percentile spread (a kerb that
  // bends, or a junction's mouth, spreads it) within half a lane. Only rows whose left run ends on
  // road count: a vehicle taller than the camera hides the kerb of the rows behind it, and a run
  // that ends on it ends beyond the kerb as at a junction. Ten rows: a photosite choice (fewer are a glimpse of kerb
  // between vehicles or at a junction's far side).
  if (lefts_seen.size() >= 10) {
    std::vector<double> l = lefts_seen;
    std::sort(l.begin(), l.end());
    const size_t n = l.size();
    s.road_straight = l[n - 1 - n / 10] - l[n / 10] <= 0.5 * p.veh_lane_width_m;
  }
  // A scene without street lighting (rural) keeps the road's extent, measured from the labels
  // alone: the vehicle lamps' in-traffic test reads it (the kerb strip), lit or not.
  if (p.street_road_luminance_cd_m2 <= 0) {
    s.note = "street.road_luminance_cd_m2 is 0: an unlit road";
    return s;
  }
  // Poles: connected pole regions standing on the ground (their lowest pixel below the horizon),
  // at least min_pole_height_m tall, not capped by a sign or signal (those carry none), taken in
  // the order of OpenCV's 8-connected labels of the pole mask (pole_components; made ahead from
  // these same labels, else made here).
  {
    const bool ahead = components && components->labels.same_labels(LabelsMadeOf(ids));
    const std::vector<PoleBox> made = ahead ? std::vector<PoleBox>() : pole_components(ids);
    for (const PoleBox& pb : ahead ? components->boxes : made) {
      const int x0 = pb.x0, w = pb.x1 - pb.x0 + 1;
      const int y0 = pb.y0, h = pb.y1 - pb.y0 + 1;
      // A pole cut by the left or right border may be a sign post or a lamp column: not used.
      if (x0 == 0 || x0 + w >= W) continue;
      // The base: the pole's lowest pixel, or below it the bottom of whatever object hides it
      // (a parked car), the nearest the hidden base can be.
      int yb = y0 + h - 1;
      const int xm = std::clamp(x0 + w / 2, 0, W - 1);
      while (yb + 1 < H) {
        const int id = ids.at(xm, yb + 1);
        if (is_ground(id) || id == static_cast<int>(Label::Sky) || id == 0) break;
        ++yb;
      }
      double X, D;
      if (!g.ground_point(x0 + 0.5 * w - 0.5, yb + 0.5, &X, &D, nullptr) || D > p.lamp_max_distance_m) continue;
      // Height of the top on the vertical line at D: Y = h − t·(yn cos θ + sin θ), t = D/(cos θ − yn sin θ).
      const double yn = (y0 - 0.5 - g.cy_px) / g.f_px, c0 = std::cos(g.pitch_rad), s0 = std::sin(g.pitch_rad);
      const double t = D / (c0 - yn * s0), Ytop = g.mount_height_m - t * (yn * c0 + s0);
      if (Ytop < p.lamp_min_pole_height_m) continue;
      bool capped = false;
      for (int y = std::max(0, y0 - 3); y < y0 && !capped; ++y)
        for (int x = std::max(0, x0 - 2); x < std::min(W, x0 + w + 2); ++x) {
          const int id = ids.at(x, y);
          if (id == static_cast<int>(Label::TrafficSign) || id == static_cast<int>(Label::TrafficLight)) capped = true;
        }
      if (capped) continue;
      // A pole cut by the image top is taller than it looks: the preset's height then. (A top
      // hidden by a tree crown is not detected: the luminaire sits at the visible top.)
      s.lamps.push_back({X, y0 > 0 ? Ytop : std::max(Ytop, p.lamp_mount_height_m), D, true});
    }
  }
  // The standard layout along the road edges: staggered rows on both edges for a road wider
  // than the mounting height, else one row on the right (CIE 115 / EN 13201 layout practice
  // [U]); the phase along the road from the run seed. Each detected pole then replaces the
  // layout's luminaire nearest to it on its side (within half a spacing), so a pole entering or
  // leaving the view moves one luminaire, not the whole row.
  std::vector<StreetLamp> poles;
  poles.swap(s.lamps);
  // Where the road bends ahead (measure_road_ahead: the kerbs 10-100 m ahead fitted with a road
  // line that curves), the rows follow the fitted line, at along-line distances a = phase + k·S,
  // each at its kerb's offset at the camera plus the setback; a pole then replaces the luminaire
  // nearest to it along the line on its side of the line's middle. On a straight road the rows run
  // straight ahead at the kerbs' medians, as before the fit (the same bits).
  s.road_ahead = measure_road_ahead(ids, g);
  // Two staggered rows on a road wider than the mounting height (at the kerbs the rows stand along).
  const bool both = (s.road_ahead.curved ? s.road_ahead.right_m - s.road_ahead.left_m : s.road_right_m - s.road_left_m) >
                    p.lamp_mount_height_m;
  if (s.road_ahead.curved) {
    const RoadAhead& ra = s.road_ahead;
    const std::vector<RoadPiece> line = road_ahead_pieces(ra);
    struct Placed { StreetLamp l; double a, off; };
    std::vector<Placed> rows;
    auto place = [&](double a, bool right) {
      const RoadPiece q = road_line_piece(line, a);
      Placed w{{0, p.lamp_mount_height_m, 0, false}, a, right ? q.right_m + p.lamp_setback_m : q.left_m - p.lamp_setback_m};
      road_piece_point(q, a, right ? q.right_m : q.left_m, right ? p.lamp_setback_m : -p.lamp_setback_m, &w.l.X_m, &w.l.D_m);
      rows.push_back(w);
    };
    const double phase = street_layout_phase_m(p, seed);
    for (int k = -1; k * S <= p.lamp_max_distance_m; ++k) {
      place(phase + k * S, true);
      if (both) place(phase + k * S + 0.5 * S, false);
    }
    const double mid = 0.5 * (ra.left_m + ra.right_m);
    for (const auto& pole : poles) {
      double a, off;
      RoadPiece on;
      road_line_project(line, pole.X_m, pole.D_m, &a, &off, &on);
      int best = -1;
      for (int i = 0; i < static_cast<int>(rows.size()); ++i) {
        const auto& w = rows[i];
        if (w.l.from_pole || (w.off - mid) * (off - mid) <= 0 || std::fabs(w.a - a) > 0.5 * S) continue;
        if (best < 0 || std::fabs(w.a - a) < std::fabs(rows[best].a - a)) best = i;
      }
      if (best >= 0) rows[best] = {pole, a, off};
      else rows.push_back({pole, a, off});
    }
    for (const auto& w : rows) s.lamps.push_back(w.l);
  } else {
    {
      const double phase = street_layout_phase_m(p, seed);
      for (int k = -1; k * S <= p.lamp_max_distance_m; ++k) {
        const double D = phase + k * S;
        s.lamps.push_back({s.road_right_m + p.lamp_setback_m, p.lamp_mount_height_m, D, false});
        if (both) s.lamps.push_back({s.road_left_m - p.lamp_setback_m, p.lamp_mount_height_m, D + 0.5 * S, false});
      }
    }
    const double mid = 0.5 * (s.road_left_m + s.road_right_m);
    for (const auto& pole : poles) {
      int best = -1;
      for (int i = 0; i < static_cast<int>(s.lamps.size()); ++i) {
        const auto& l = s.lamps[i];
        if (l.from_pole || (l.X_m - mid) * (pole.X_m - mid) <= 0 || std::fabs(l.D_m - pole.D_m) > 0.5 * S) continue;
        if (best < 0 || std::fabs(l.D_m - pole.D_m) < std::fabs(s.lamps[best].D_m - pole.D_m)) best = i;
      }
      if (best >= 0) s.lamps[best] = pole;
      else s.lamps.push_back(pole);
    }
  }
  s.source = poles.empty() ? "road_edges" : "poles+road_edges";
  std::sort(s.lamps.begin(), s.lamps.end(), [](const auto& a, const auto& b) { return a.D_m < b.D_m; });
  // Luminous intensity: a luminaire's is a property of the installation, not of the view. It is
  // set on the design layout of this street's kind (street_design_layout: one-sided, or staggered
  // when the layout above has two rows) so that its EN 13201-3 calculation field averages the class
  // luminance; L_avg and U0 are then reported on this scene's own layout and road extent.
  s.peak_intensity_cd = street_design_layout(p, both).peak_intensity_cd;
  s.grid_D0_m = std::max(10.0, S);
  const double avg = street_calculation_field_lux(s, s.road_left_m, s.road_right_m, s.grid_D0_m, p, &s.uniformity_u0);
  s.avg_luminance_cd_m2 = p.rho_road * avg / M_PI;
  return s;
}

double street_calculation_field_lux(const StreetLighting& lay, double left_m, double right_m, double D0_m,
                                    const ScenePreset& p, double* u0) {
  // EN 13201-3's field: one spacing S long from D0, 10 points along and 6 across the carriageway
  // (the standard's 3 per lane for two lanes), each at the centre of its cell.
  const double S = p.lamp_spacing_ratio * p.lamp_mount_height_m;
  double sum = 0, mn = 1e300;
  for (int i = 0; i < 10; ++i)
    for (int j = 0; j < 6; ++j) {
      const double e = street_illuminance_lux(left_m + (j + 0.5) * (right_m - left_m) / 6, D0_m + (i + 0.5) * S / 10, lay, p);
      sum += e;
      mn = std::min(mn, e);
    }
  const double avg = sum / 60;
  if (u0) *u0 = avg > 0 ? mn / avg : 0;
  return avg;
}

StreetLighting street_design_layout(const ScenePreset& p, bool staggered) {
  // The layouts of the one-sided and staggered rules of thumb, each over the widest carriageway
  // it serves: one row at the kerb over a carriageway as wide as the mounting height H, or two
  // rows on opposite kerbs, staggered by S/2, over one 1.5 H wide (vonpower.com, mocled.com [S];
  // a pole-spacing table allows H ≥ W for one-sided and H ≥ 0.7 W, W ≤ 1.43 H, for staggered
  // cut-off layouts, ycbright.com [S]). Each row at spacing S, 0.5 m set back (the preset's);
  // seven luminaires a row, k = -3..3: a field point 0..S ahead has every luminaire within the
  // reach (H·tan 75° = 37.3 m at the presets') on each side, since 3·S ≥ 37.3 m for S ≥ 12.5 m.
  // I0 = π·L_class / (ρ_road·Ē(I0 = 1)), so that L_avg = ρ_road·Ē/π = L_class: a street with two
  // rows has dimmer luminaires than one with one row, as its designer would choose them.
  StreetLighting d;
  d.source = staggered ? "design_staggered" : "design_one_sided";
  const double Hm = p.lamp_mount_height_m, S = p.lamp_spacing_ratio * Hm, W = staggered ? 1.5 * Hm : Hm;
  d.road_left_m = 0;
  d.road_right_m = W;
  d.road_straight = true;
  if (p.street_road_luminance_cd_m2 <= 0) {
    d.note = "street.road_luminance_cd_m2 is 0: an unlit road";
    return d;
  }
  for (int k = -3; k <= 3; ++k) {
    d.lamps.push_back({W + p.lamp_setback_m, Hm, k * S, false});
    if (staggered) d.lamps.push_back({-p.lamp_setback_m, Hm, k * S + 0.5 * S, false});
  }
  std::sort(d.lamps.begin(), d.lamps.end(), [](const auto& a, const auto& b) { return a.D_m < b.D_m; });
  d.peak_intensity_cd = 1;
  d.peak_intensity_cd = M_PI * p.street_road_luminance_cd_m2 / (p.rho_road * street_calculation_field_lux(d, 0, W, 0, p, nullptr));
  d.grid_D0_m = 0;
  const double avg = street_calculation_field_lux(d, 0, W, 0, p, &d.uniformity_u0);
  d.avg_luminance_cd_m2 = p.rho_road * avg / M_PI;
  return d;
}

namespace {
// ---- The ground pools at adaptive sample columns (scene preset street_lamps.interp_tolerance) ----
// On the flat ground an image row is one forward distance D, and the row's lamps are fixed (those
// within reach of D, for every pixel alike), so E(X) = Σ I(γ)·cos γ/d² is one continuous function
// of the column, smooth except at each lamp's cut-off knee (γ = γ_c, where I(γ) turns from constant
// to the exponential falloff): it varies over metres (a luminaire 8-12 m up: tens to hundreds of
// pixels). It is evaluated exactly (the per-pixel kernel, the same bits) at sample columns only
// and linearly interpolated between (tol = the preset's tolerance, relative):
//   1. samples every `step` columns from the span's first column, and at its last: step =
//      kInterpStep_m_per_H·H_min of ground (H_min the row's lowest luminaire, so a lamp's pool,
//      whose scale is its height, spans at least 4 steps), at most kInterpStep_px, at least 2;
//   2. each interval [a, b] (b − a ≥ 4; shorter ones: every column evaluated) is tested at its
//      midpoint m and its quarters q1, q3: E(m) against the chord through E(a) and E(b), E(q1)
//      against the chord through E(a) and E(m), E(q3) against the one through E(m) and E(b). It is
//      accepted when no lamp's cut-off knee lies in (a, b] (each lamp's knee columns found per row,
//      below) and each deviation is ≤ tol·min(the five E);
//      then [a, b] is filled by the four quarter chords; else [a, m] and [m, b] are tested the same
//      way (their midpoints known: q1, q3), down to intervals shorter than 4 columns (all exact).
//      So every knee is bracketed by samples at adjacent columns, and an accepted interval holds
//      none.
// The bound. For f with a constant second derivative a chord's error on an interval of length h
// is f''·(x − a)(b − x)/2, largest at the midpoint, h²f''/8. The quarter test measures the half
// chord's (length h/2) midpoint deviation, f''h²/32; the quarter chords drawn err by at most
// f''h²/128, a quarter of it: ≤ (tol/4)·min E. So the result stays within tol·E while |f''| varies
// by less than a factor 4 over each half (within a knee-free interval f is analytic; its curvature
// changes over the lamps' height scale, which `step` keeps at 4 or more intervals). Testing each
// half (not only the midpoint of the whole, which an inflection, f'' changing sign across m, can
// leave on the chord while both halves bend: measured 3.8x the tolerance on a Cityscapes row
// before the quarters were tested) leaves an inflection inside one quarter, where |f''| is near 0.
// A lamp's whole cone crossing between two samples (both knees inside one interval) is caught
// too: the test is on the knee columns, not on the samples' sides of them. The tests check every
// ground pixel of the synthetic street and of three Cityscapes frames against tol·E (worst measured: 0.35·tol at
// 6e-4; docs/lightmap_interp.csv for the chain's lights layer).
// The vertical light stays exact (its reach, the γ = 90° limit and faces turning away are steps
// within a façade run; an interpolated façade path, and one interpolating down the columns
// between exact even rows, measured slower than the exact AVX-512 one: docs/night.md §7). The sample columns depend on the row and its span only (labels, geometry,
// the preset), never on threads or bands.
// The tolerance: the smallest relative noise any output pixel can show is the photon shot noise
// at full well, 1/√(full well); the presets' largest well (sony-a7s2, 168,000 e-) gives 2.4e-3,
// so tol ≤ 1/(4·√168,000) = 6.1e-4 stays 4x below the noise of the brightest pixel of any camera
// preset (a bias, not noise: averaged over ≥ 16 pixels of one grey level the shot noise falls
// below it, so it is not invisible to every statistic).
constexpr int kInterpStep_px = 128;
constexpr double kInterpStep_m_per_H = 0.25;
}  // namespace

bool beyond_cutoff(double X_m, double lamp_X_m, float dz2_m2, float H2_m2, double cc2) {
  const double dx = X_m - lamp_X_m, H2 = H2_m2;
  return H2 < cc2 * (dx * dx + dz2_m2 + H2);
}

void cutoff_columns(double lamp_X_m, float dz2_m2, float H2_m2, double cc2, double cx_px, double kx, int x0, int x1,
                    int* lo, int* hi) {
  // The predicate grows with |dx| only (each rounded step, dx², + dz², + H², · cos²γ_c, is
  // monotone), and dx with the column (k_x > 0 below the horizon), so the columns within the cone
  // are one run, around the column of the smallest |dx|. Its ends from the knee, then each moved
  // column by column until the predicate itself changes there (a rounding step or two at most).
  const auto X = [&](int x) { return (x - cx_px) * kx; };
  const auto in_cone = [&](int x) { return !beyond_cutoff(X(x), lamp_X_m, dz2_m2, H2_m2, cc2); };
  const auto column = [&](double Xm) {  // the column at ground X, clamped to [x0 − 1, x1 + 1]
    return static_cast<int>(std::clamp(std::floor(Xm / kx + cx_px), x0 - 1.0, x1 + 1.0));
  };
  int c = std::clamp(column(lamp_X_m), x0, x1);  // the last column with X ≤ X_l (or x0)
  while (c < x1 && X(c + 1) <= lamp_X_m) ++c;
  while (c > x0 && X(c) > lamp_X_m) --c;
  const int z = in_cone(c) ? c : (c < x1 && in_cone(c + 1) ? c + 1 : x0 - 1);
  if (z < x0) {  // the smallest |dx| is beyond the cut-off: every column is
    *lo = *hi = x0;
    return;
  }
  // The knee: γ = γ_c at |X − X_l| = sqrt((H·tan γ_c)² − dz²), H²·tan²γ_c = H²·(1/cos²γ_c − 1).
  const double r2 = H2_m2 * (1 / cc2 - 1) - dz2_m2, r = r2 > 0 ? std::sqrt(r2) : 0.0;
  int h = std::clamp(column(lamp_X_m + r) + 1, z + 1, x1 + 1);  // the first column past the cone
  while (h > z + 1 && !in_cone(h - 1)) --h;
  while (h <= x1 && in_cone(h)) ++h;
  int l = std::clamp(column(lamp_X_m - r), x0, z);  // the first column within it
  while (l < z && !in_cone(l)) ++l;
  while (l > x0 && in_cone(l - 1)) --l;
  *lo = l;
  *hi = h;
}

namespace {
struct AdaptiveScratch {
  std::vector<int32_t> xs, a, b, na, nb;
  std::vector<uint8_t> mid, nmid;
};
// The chord from (a, ev[a]) to (b, ev[b]) over the columns strictly between.
inline void fill_chord(float* ev, int a, int b) {
  const float fa = ev[a], d = ev[b] - fa, inv = 1.f / static_cast<float>(b - a);
  for (int x = a + 1; x < b; ++x) ev[x] = fa + d * (static_cast<float>(x - a) * inv);
}
// ev[x] for x0 ≤ x ≤ x1 by the scheme above, first samples every `step` columns; eval(xs, n)
// writes the exact ev[xs[i]] for n columns; knee_free(a, b) says whether no knee lies in (a, b].
// Intervals of
// fewer than 4 columns get every column evaluated. An interval's entry `mid` says its midpoint
// is known already (the children of a rejected interval: their midpoints are its quarters).
template <class Eval, class KneeFree>
void adaptive_span(int x0, int x1, int step, float tol, float* ev, AdaptiveScratch& s, Eval&& eval,
                   KneeFree&& knee_free) {
  s.xs.clear();
  s.a.clear();
  s.b.clear();
  s.mid.clear();
  for (int x = x0; x < x1; x += step) s.xs.push_back(x);
  s.xs.push_back(x1);
  eval(s.xs.data(), static_cast<int>(s.xs.size()));
  for (size_t i = 0; i + 1 < s.xs.size(); ++i)
    if (s.xs[i + 1] - s.xs[i] >= 2) {
      s.a.push_back(s.xs[i]);
      s.b.push_back(s.xs[i + 1]);
      s.mid.push_back(0);
    }
  // The deviation of f(m) from the chord through (a, f(a)) and (b, f(b)) within the tolerance.
  auto on_chord = [&](int a, int m, int b, float lo) {
    const float fa = ev[a];
    const float chord = fa + (ev[b] - fa) * (static_cast<float>(m - a) / static_cast<float>(b - a));
    return std::fabs(ev[m] - chord) <= tol * lo;
  };
  while (!s.a.empty()) {  // one level per pass, its new samples evaluated in one call
    const size_t n = s.a.size();
    s.xs.clear();
    for (size_t j = 0; j < n; ++j) {
      const int a = s.a[j], b = s.b[j], m = (a + b) / 2;
      if (b - a < 4) {
        for (int x = a + 1; x < b; ++x)
          if (x != m || !s.mid[j]) s.xs.push_back(x);
        continue;
      }
      if (!s.mid[j]) s.xs.push_back(m);
      s.xs.push_back((a + m) / 2);
      s.xs.push_back((m + b) / 2);
    }
    if (!s.xs.empty()) eval(s.xs.data(), static_cast<int>(s.xs.size()));
    s.na.clear();
    s.nb.clear();
    s.nmid.clear();
    for (size_t j = 0; j < n; ++j) {
      const int a = s.a[j], b = s.b[j];
      if (b - a < 4) continue;  // every column exact
      const int m = (a + b) / 2, q1 = (a + m) / 2, q3 = (m + b) / 2;
      const float lo = std::min(std::min(std::min(ev[a], ev[q1]), std::min(ev[m], ev[q3])), ev[b]);
      if (knee_free(a, b) && on_chord(a, m, b, lo) && on_chord(a, q1, m, lo) && on_chord(m, q3, b, lo)) {
        fill_chord(ev, a, q1);
        fill_chord(ev, q1, m);
        fill_chord(ev, m, q3);
        fill_chord(ev, q3, b);
        continue;
      }
      s.na.push_back(a), s.nb.push_back(m), s.nmid.push_back(1);
      s.na.push_back(m), s.nb.push_back(b), s.nmid.push_back(1);
    }
    s.a.swap(s.na);
    s.b.swap(s.nb);
    s.mid.swap(s.nmid);
  }
}
}  // namespace

namespace {
// ---- The street lamps' shadows on the ground (street_lamps.shadows) --------------------------
// What casts them: the solid things that stand on the street between the lamps and the ground,
// vehicles (car to bicycle), people and riders, poles, signs, signals, fences and guard rails.
// Not buildings and walls (the lamps stand on the street side of them, and what a façade hides
// from a lamp lies behind it, out of view), not vegetation (a crown's leaves pass part of the light
// and their transmission is not known here; a trunk is not told from its crown in the labels).
const std::array<bool, kLabelCount>& street_shadow_classes() {
  static const std::array<bool, kLabelCount> t = [] {
    std::array<bool, kLabelCount> c{};
    for (Label l : {Label::Person, Label::Rider, Label::Car, Label::Truck, Label::Bus, Label::Caravan, Label::Trailer,
                    Label::Train, Label::Motorcycle, Label::Bicycle, Label::Pole, Label::PoleGroup,
                    Label::TrafficLight, Label::TrafficSign, Label::Fence, Label::GuardRail})
      c[static_cast<int>(l)] = true;
    return c;
  }();
  return t;
}
// A lamp's own pole stands under it: pixels within this horizontal distance of a lamp's foot
// cast no shadow of that lamp (the pole's shadow from its own luminaire falls at its foot; the
// labelled pole's pixels scatter its points by the depth's error around the foot, which would
// otherwise throw long radial streaks). A photosite choice: about a luminaire's outreach.
constexpr double kOwnPole_m = 1.0;
// Runs of one class in an image column are one occluder while their points' forward distance D
// stays within this of the run's lowest pixel (the depth stage puts an object on one vertical
// plane: D is constant along its column; a step of more is another object behind or in front).
// A photosite choice.
constexpr double kRunStep_m = 0.5;
// Columns are joined into one quadrilateral only within blocks of this many (the threads' bands
// are whole blocks, so the quadrilaterals, and their pixels, do not depend on the thread count).
constexpr int kShadowBlock = 128;

// A thread's spans as quad_spans makes them, each joined at once to the last one it made of the
// same lamp and row where the two overlap or touch (x0 ≤ last x1 and last x0 ≤ x1): their union
// is one span, the one finish()'s merge would make of the two, so the merged spans are the same
// and finish() sorts and merges fewer (the columns of one occluder cast overlapping quadrilaterals,
// cast from left to right in take_blocks: on the bench frame, in the order of the runs' bottom rows,
// 12,855 spans made, 936 after the merge). One slot per lamp: the ids of one lamp's spans here are
// one (k without penumbrae, k·(n + 1) + n with them; the points' own go to PointSpanSink).
struct SpanSink {
  std::vector<ShadowSpan> spans;
  std::vector<int32_t> last;  // per (slot, row): the index in spans of its last span, −1: none yet
  int H = 0;
  SpanSink(size_t lamps, int height) : last(lamps * static_cast<size_t>(height), -1), H(height) {
    spans.reserve(4096);
  }
  // The span of id `lamp` (ShadowSpan::lamp) kept as the last one of its (slot, row).
  void add(int y, int x0, int x1, int lamp, int slot) {
    int32_t& at = last[static_cast<size_t>(slot) * H + y];
    if (at >= 0) {
      ShadowSpan& p = spans[at];
      if (x0 <= p.x1 && p.x0 <= x1) {
        p.x0 = std::min(p.x0, x0);
        p.x1 = std::max(p.x1, x1);
        return;
      }
    }
    at = static_cast<int32_t>(spans.size());
    spans.push_back({y, x0, x1, lamp});
  }
};

}  // namespace

// The pixels of row y whose centres lie inside the quadrilateral (u[i], v[i]), i = 0..3 in order
// around it (slope[i]: du/dv of edge (i, i + 1), 0 where it lies along a row): from the least to
// the largest u where the row's centre line crosses its edges (exact for a convex quadrilateral; a
// twisted one is filled to its hull on the row), as columns x0 .. x1 − 1 within 0 .. W − 1; false:
// none. lo and hi are clamped to [−1, W] before ceil/floor: the same columns (ceil(max(lo, −1)) =
// max(ceil(lo), −1), then max(0, ·)), and every value converted fits an int.
bool quad_row_span(const double* u, const double* v, const double* slope, int W, int y, int* x0, int* x1) {
  double lo = INFINITY, hi = -INFINITY;
  for (int i = 0; i < 4; ++i) {
    const int j = (i + 1) & 3;
    const double va = v[i], vb = v[j];
    if ((va - y) * (vb - y) > 0) continue;  // the edge does not reach this row
    if (va == vb) {                         // along the row: both ends
      lo = std::min({lo, u[i], u[j]});
      hi = std::max({hi, u[i], u[j]});
      continue;
    }
    const double ux = u[i] + (y - va) * slope[i];
    lo = std::min(lo, ux);
    hi = std::max(hi, ux);
  }
  if (!(lo <= hi)) return false;
  *x0 = std::max(0, static_cast<int>(std::ceil(std::max(lo, -1.0))));
  *x1 = std::min(W - 1, static_cast<int>(std::floor(std::min(hi, static_cast<double>(W))))) + 1;
  return *x0 < *x1;
}

// The edges' slopes of quad_row_span.
void quad_slopes(const double* u, const double* v, double* slope) {
  for (int i = 0; i < 4; ++i) {
    const int j = (i + 1) & 3;
    slope[i] = v[i] != v[j] ? (u[j] - u[i]) / (v[j] - v[i]) : 0;
  }
}

// quad_row_span for the disc's kLampDiscSamples points' quadrilaterals at once, four points to a
// vector of doubles: the same operations on each lane (a comparison's mask where the scalar code
// branches; min/max of the same values, so the same columns), so the same columns as
// quad_row_span on each point (test StreetLampShadows.DiscRowSpansAreEachPointsOwn). Lanes of a
// point not drawn carry v = −1e30 at every corner: no row reaches them.
__attribute__((target("avx2"))) unsigned disc_row_spans_avx2(const DiscQuads& q, int W, int y, int32_t* x0,
                                                              int32_t* x1) {
  const __m256d yv = _mm256_set1_pd(y), zero = _mm256_setzero_pd();
  const __m256d lo_clamp = _mm256_set1_pd(-1.0), hi_clamp = _mm256_set1_pd(W);
  const __m128i wm1 = _mm_set1_epi32(W - 1), izero = _mm_setzero_si128();
  unsigned valid = 0;
  for (int g = 0; g < DiscQuads::kPoints; g += 4) {
    __m256d lo = _mm256_set1_pd(INFINITY), hi = _mm256_set1_pd(-INFINITY);
    for (int i = 0; i < 4; ++i) {
      const int j = (i + 1) & 3;
      const __m256d ua = _mm256_load_pd(&q.u[i][g]), ub = _mm256_load_pd(&q.u[j][g]);
      const __m256d va = _mm256_load_pd(&q.v[i][g]), vb = _mm256_load_pd(&q.v[j][g]);
      const __m256d reach =
          _mm256_cmp_pd(_mm256_mul_pd(_mm256_sub_pd(va, yv), _mm256_sub_pd(vb, yv)), zero, _CMP_NGT_UQ);
      const __m256d along = _mm256_cmp_pd(va, vb, _CMP_EQ_OQ);
      const __m256d ux = _mm256_add_pd(ua, _mm256_mul_pd(_mm256_sub_pd(yv, va), _mm256_load_pd(&q.slope[i][g])));
      // Along the row: both ends (min(u_a, u_b) and max); across it: the crossing.
      const __m256d cl = _mm256_blendv_pd(ux, _mm256_min_pd(ua, ub), along);
      const __m256d ch = _mm256_blendv_pd(ux, _mm256_max_pd(ua, ub), along);
      lo = _mm256_blendv_pd(lo, _mm256_min_pd(lo, cl), reach);
      hi = _mm256_blendv_pd(hi, _mm256_max_pd(hi, ch), reach);
    }
    const __m256d has = _mm256_cmp_pd(lo, hi, _CMP_LE_OQ);
    const unsigned ok = static_cast<unsigned>(_mm256_movemask_pd(has));
    if (!ok) continue;
    const __m256d lc = _mm256_round_pd(_mm256_max_pd(lo, lo_clamp), _MM_FROUND_TO_POS_INF | _MM_FROUND_NO_EXC);
    const __m256d hc = _mm256_round_pd(_mm256_min_pd(hi, hi_clamp), _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC);
    // Lanes without a span (lo > hi) may hold ±inf: their conversions are not used.
    const __m128i a = _mm_max_epi32(izero, _mm256_cvttpd_epi32(_mm256_blendv_pd(zero, lc, has)));
    const __m128i b =
        _mm_add_epi32(_mm_min_epi32(wm1, _mm256_cvttpd_epi32(_mm256_blendv_pd(zero, hc, has))), _mm_set1_epi32(1));
    _mm_storeu_si128(reinterpret_cast<__m128i*>(x0 + g), a);
    _mm_storeu_si128(reinterpret_cast<__m128i*>(x1 + g), b);
    const unsigned nonempty = static_cast<unsigned>(_mm_movemask_ps(_mm_castsi128_ps(_mm_cmplt_epi32(a, b))));
    valid |= (ok & nonempty) << g;
  }
  return valid;
}

unsigned disc_row_spans_scalar(const DiscQuads& q, int W, int y, int32_t* x0, int32_t* x1) {
  unsigned valid = 0;
  for (int j = 0; j < DiscQuads::kPoints; ++j) {
    const double u[4] = {q.u[0][j], q.u[1][j], q.u[2][j], q.u[3][j]};
    const double v[4] = {q.v[0][j], q.v[1][j], q.v[2][j], q.v[3][j]};
    const double sl[4] = {q.slope[0][j], q.slope[1][j], q.slope[2][j], q.slope[3][j]};
    int a, b;
    if (quad_row_span(u, v, sl, W, y, &a, &b)) {
      x0[j] = a, x1[j] = b;
      valid |= 1u << j;
    }
  }
  return valid;
}

// The quadrilateral from the point (SX, H, SD): its vertices' ground images, projected; with
// `shift_px`, the most a vertex moves in the image when the point moves by 1 m within the disc's
// plane (below). False where a vertex lies behind the camera.
bool cast_quad(const QuadCast& q, double SX, double SD, double* u, double* v, double* shift_px) {
  constexpr double kCapMargin = 1 - 1e-9;
  const double Hl = q.H_m, h = q.h_m, c = q.cos_pitch, sn = q.sin_pitch;
  for (int i = 0; i < 4; ++i) {
    const double dX = q.X[i] - SX, dD = q.D[i] - SD, r2 = dX * dX + dD * dD;
    // λ: the ground point of the ray over P; capped at the lamp's reach, and so that the
    // shadow does not run past the nearest ground in view toward the camera.
    // Each cap's quotient is computed only where it can bind: λ ≥ 1 here (Y ≥ 0), and where
    // λ²·r² < reach²·(1 − 1e-9) (or λ·(−dD) < (D_s − D_bottom)·(1 − 1e-9)) the cap exceeds λ
    // by far more than the few ulps of the products' and the quotient's rounding, so the
    // min keeps λ, bit for bit, as if the quotient had been taken.
    double lam = q.Y[i] < Hl * (1 - 1e-6) ? Hl / (Hl - q.Y[i]) : INFINITY;
    if (r2 > 0 && lam > 1 && !(lam * lam * r2 < q.reach2_m2 * kCapMargin))
      lam = std::min(lam, std::max(1.0, q.reach_m / std::sqrt(r2)));
    if (dD < 0 && !(lam * -dD < (SD - q.D_bottom_m) * kCapMargin))
      lam = std::min(lam, std::max(0.0, (SD - q.D_bottom_m) / -dD));
    if (!std::isfinite(lam)) lam = 1;
    const double GX = SX + lam * dX, GD = SD + lam * dD;
    const double zc = h * sn + GD * c;  // CameraGeometry::project of (GX, 0, GD)
    if (zc <= 0.05) return false;
    u[i] = q.cx_px + q.f_px * GX / zc;
    v[i] = q.cy_px + q.f_px * (h * c - GD * sn) / zc;
    // G = S + λ(P − S) moves by (1 − λ)·ΔS when S moves by ΔS in its plane (λ, a ratio of
    // heights, stays); a ground step of 1 m at (GX, GD) moves the image point by at most
    // (f/z)·(1 + (|GX| + h)/z) px (u = c_x + f·X/z, v's and z's change with D).
    if (shift_px) *shift_px = std::max(*shift_px, std::fabs(lam - 1) * q.f_px / zc * (1 + (std::fabs(GX) + h) / zc));
  }
  return true;
}

namespace {
// A point's lanes when it casts nothing (a vertex behind the camera): no row reaches them.
void disc_point_out(DiscQuads& q, int j) {
  for (int i = 0; i < 4; ++i) q.u[i][j] = 0, q.v[i][j] = -1e30, q.slope[i][j] = 0;
}
}  // namespace

unsigned disc_quads_scalar(const QuadCast& in, const double* SX, const double* SD, DiscQuads& q, double* vlo,
                           double* vhi) {
  unsigned drawn = 0;
  *vlo = INFINITY, *vhi = -INFINITY;
  for (int j = 0; j < DiscQuads::kPoints; ++j) {
    double u[4], v[4], sl[4];
    if (!cast_quad(in, SX[j], SD[j], u, v, nullptr)) {
      disc_point_out(q, j);
      continue;
    }
    quad_slopes(u, v, sl);
    for (int i = 0; i < 4; ++i) {
      q.u[i][j] = u[i], q.v[i][j] = v[i], q.slope[i][j] = sl[i];
      *vlo = std::min(*vlo, v[i]), *vhi = std::max(*vhi, v[i]);
    }
    drawn |= 1u << j;
  }
  return drawn;
}

// cast_quad of the disc's points four to a vector: each branch of the scalar code a mask and a
// blend of the value it would take (both sides computed; a quotient masked off may be ±inf or NaN
// and is not used), std::min(a, b) as _mm256_min_pd(b, a) and std::max(a, b) as
// _mm256_max_pd(b, a) (the same operand returned on ties and NaN), each product, sum, quotient and
// square root one IEEE operation as in the scalar code (the library builds with
// -ffp-contract=off), so the same corners and slopes on every lane (test
// StreetLampShadows.DiscQuadsAreEachPointsOwn).
__attribute__((target("avx2"))) unsigned disc_quads_avx2(const QuadCast& in, const double* SX, const double* SD,
                                                          DiscQuads& q, double* vlo, double* vhi) {
  constexpr double kCapMargin = 1 - 1e-9;
  const double Hl = in.H_m, h = in.h_m, c = in.cos_pitch, sn = in.sin_pitch;
  const __m256d one = _mm256_set1_pd(1.0), zero = _mm256_setzero_pd(), inf = _mm256_set1_pd(INFINITY);
  const __m256d sign = _mm256_set1_pd(-0.0);
  const __m256d reach2m = _mm256_set1_pd(in.reach2_m2 * kCapMargin), reach = _mm256_set1_pd(in.reach_m);
  const __m256d Db = _mm256_set1_pd(in.D_bottom_m), margin = _mm256_set1_pd(kCapMargin);
  const __m256d hsn = _mm256_set1_pd(h * sn), cv = _mm256_set1_pd(c), snv = _mm256_set1_pd(sn);
  const __m256d hc = _mm256_set1_pd(h * c), f = _mm256_set1_pd(in.f_px), cx = _mm256_set1_pd(in.cx_px);
  const __m256d cy = _mm256_set1_pd(in.cy_px), near = _mm256_set1_pd(0.05), sentinel = _mm256_set1_pd(-1e30);
  double lam0[4];
  for (int i = 0; i < 4; ++i) lam0[i] = in.Y[i] < Hl * (1 - 1e-6) ? Hl / (Hl - in.Y[i]) : INFINITY;
  unsigned drawn = 0;
  __m256d lo = inf, hi = _mm256_set1_pd(-INFINITY);
  for (int g = 0; g < DiscQuads::kPoints; g += 4) {
    const __m256d sx = _mm256_loadu_pd(SX + g), sd = _mm256_loadu_pd(SD + g);
    const __m256d DbS = _mm256_mul_pd(_mm256_sub_pd(sd, Db), margin), SmDb = _mm256_sub_pd(sd, Db);
    __m256d u[4], v[4], behind = zero;
    for (int i = 0; i < 4; ++i) {
      const __m256d dX = _mm256_sub_pd(_mm256_set1_pd(in.X[i]), sx), dD = _mm256_sub_pd(_mm256_set1_pd(in.D[i]), sd);
      const __m256d r2 = _mm256_add_pd(_mm256_mul_pd(dX, dX), _mm256_mul_pd(dD, dD));
      __m256d lam = _mm256_set1_pd(lam0[i]);
      // The reach's cap where r2 > 0, λ > 1 and not λ²·r² < reach²·(1 − 1e-9).
      const __m256d c1 = _mm256_and_pd(
          _mm256_and_pd(_mm256_cmp_pd(r2, zero, _CMP_GT_OQ), _mm256_cmp_pd(lam, one, _CMP_GT_OQ)),
          _mm256_cmp_pd(_mm256_mul_pd(_mm256_mul_pd(lam, lam), r2), reach2m, _CMP_NLT_UQ));
      // The quotients only where a lane takes them (mostly none: the caps seldom bind).
      if (_mm256_movemask_pd(c1)) {
        const __m256d cap1 = _mm256_max_pd(_mm256_div_pd(reach, _mm256_sqrt_pd(r2)), one);
        lam = _mm256_blendv_pd(lam, _mm256_min_pd(cap1, lam), c1);
      }
      // The nearest ground's cap where dD < 0 and not λ·(−dD) < (D_s − D_bottom)·(1 − 1e-9).
      const __m256d ndD = _mm256_xor_pd(dD, sign);
      const __m256d c2 = _mm256_and_pd(_mm256_cmp_pd(dD, zero, _CMP_LT_OQ),
                                       _mm256_cmp_pd(_mm256_mul_pd(lam, ndD), DbS, _CMP_NLT_UQ));
      if (_mm256_movemask_pd(c2)) {
        const __m256d cap2 = _mm256_max_pd(_mm256_div_pd(SmDb, ndD), zero);
        lam = _mm256_blendv_pd(lam, _mm256_min_pd(cap2, lam), c2);
      }
      // Not finite (|λ| < inf fails for ±inf and NaN): 1.
      lam = _mm256_blendv_pd(one, lam, _mm256_cmp_pd(_mm256_andnot_pd(sign, lam), inf, _CMP_LT_OQ));
      const __m256d GX = _mm256_add_pd(sx, _mm256_mul_pd(lam, dX)), GD = _mm256_add_pd(sd, _mm256_mul_pd(lam, dD));
      const __m256d zc = _mm256_add_pd(hsn, _mm256_mul_pd(GD, cv));
      behind = _mm256_or_pd(behind, _mm256_cmp_pd(zc, near, _CMP_LE_OQ));
      u[i] = _mm256_add_pd(cx, _mm256_div_pd(_mm256_mul_pd(f, GX), zc));
      v[i] = _mm256_add_pd(cy, _mm256_div_pd(_mm256_mul_pd(f, _mm256_sub_pd(hc, _mm256_mul_pd(GD, snv))), zc));
    }
    const unsigned out = static_cast<unsigned>(_mm256_movemask_pd(behind));
    drawn |= (~out & 15u) << g;
    for (int i = 0; i < 4; ++i) {
      const int j = (i + 1) & 3;
      const __m256d du = _mm256_sub_pd(u[j], u[i]), dv = _mm256_sub_pd(v[j], v[i]);
      const __m256d sl = _mm256_blendv_pd(_mm256_div_pd(du, dv), zero, _mm256_cmp_pd(v[i], v[j], _CMP_EQ_OQ));
      _mm256_store_pd(&q.u[i][g], _mm256_blendv_pd(u[i], zero, behind));
      _mm256_store_pd(&q.v[i][g], _mm256_blendv_pd(v[i], sentinel, behind));
      _mm256_store_pd(&q.slope[i][g], _mm256_blendv_pd(sl, zero, behind));
      // The rows' range over the points drawn: min(vlo, v) as the scalar code takes it.
      lo = _mm256_blendv_pd(_mm256_min_pd(v[i], lo), lo, behind);
      hi = _mm256_blendv_pd(_mm256_max_pd(v[i], hi), hi, behind);
    }
  }
  alignas(32) double l4[4], h4[4];
  _mm256_store_pd(l4, lo);
  _mm256_store_pd(h4, hi);
  *vlo = std::min(std::min(l4[0], l4[1]), std::min(l4[2], l4[3]));
  *vhi = std::max(std::max(h4[0], h4[1]), std::max(h4[2], h4[3]));
  return drawn;
}

namespace {
// SpanSink for the disc's points (penumbrae): per (lamp, row) the last span of each of its
// kLampDiscSamples points, the points side by side (one place per lamp and row instead of one per
// point id, ids k·(n + 1) + j, spread over the image's height), a row's new spans of all points
// joined to them at once (lanes where the two overlap or touch: their union, as SpanSink::add),
// the others' last span stored (to `spans`, as SpanSink's) and replaced. A (lamp, row) is set up
// on its first span; flush() stores the last spans at the end. The same union per point id and
// row as SpanSink's (finish() merges what is left: the same spans).
struct PointSpanSink {
  static constexpr int n = DiscQuads::kPoints;
  // ((k·H + y)·n + j): point j's last span, x0 ≥ x1: none; not initialised (set up on first use).
  std::unique_ptr<int32_t[]> x0, x1;
  std::vector<uint8_t> used;     // (k·H + y) set up
  std::vector<int32_t> touched;  // the (k·H + y) set up, in order
  int H = 0, ids = 1;
  PointSpanSink(size_t lamps, int height, int ids_per_lamp)
      : x0(std::make_unique_for_overwrite<int32_t[]>(lamps * height * n)),
        x1(std::make_unique_for_overwrite<int32_t[]>(lamps * height * n)), used(lamps * height, 0), H(height),
        ids(ids_per_lamp) {}
  void add(size_t k, int y, const int32_t* nx0, const int32_t* nx1, unsigned valid, bool avx2,
           std::vector<ShadowSpan>& spans) {
    const size_t r = k * H + y;
    int32_t* p0 = &x0[r * n];
    int32_t* p1 = &x1[r * n];
    if (!used[r]) {
      used[r] = 1;
      touched.push_back(static_cast<int32_t>(r));
      std::fill_n(p0, n, 0);
      std::fill_n(p1, n, 0);
    }
    // The lanes whose span is not joined: their last span (if any) stored, then replaced.
    unsigned apart = avx2 ? add_avx2(p0, p1, nx0, nx1, valid) : add_scalar(p0, p1, nx0, nx1, valid);
    while (apart) {
      const int j = std::countr_zero(apart);
      apart &= apart - 1;
      if (p0[j] < p1[j]) spans.push_back({y, p0[j], p1[j], static_cast<int32_t>(k) * ids + j});
      p0[j] = nx0[j], p1[j] = nx1[j];
    }
  }
  // The lanes of `valid` that overlap or touch their last span take the union; returns the others.
  static unsigned add_scalar(int32_t* p0, int32_t* p1, const int32_t* nx0, const int32_t* nx1, unsigned valid) {
    unsigned apart = 0;
    for (unsigned b = valid; b; b &= b - 1) {
      const int j = std::countr_zero(b);
      if (p0[j] < p1[j] && nx0[j] <= p1[j] && p0[j] <= nx1[j]) {
        p0[j] = std::min(p0[j], nx0[j]);
        p1[j] = std::max(p1[j], nx1[j]);
      } else {
        apart |= 1u << j;
      }
    }
    return apart;
  }
  __attribute__((target("avx2"))) static unsigned add_avx2(int32_t* p0, int32_t* p1, const int32_t* nx0,
                                                          const int32_t* nx1, unsigned valid) {
    unsigned apart = 0;
    const __m256i lane_bit = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
    for (int g = 0; g < n; g += 8) {
      const unsigned vb = valid >> g & 255u;
      if (!vb) continue;
      const __m256i a0 = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(p0 + g));
      const __m256i a1 = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(p1 + g));
      const __m256i b0 = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(nx0 + g));
      const __m256i b1 = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(nx1 + g));
      const __m256i vm = _mm256_cmpeq_epi32(_mm256_and_si256(_mm256_set1_epi32(static_cast<int>(vb)), lane_bit), lane_bit);
      // Joined: valid, a last span (a0 < a1), b0 ≤ a1 and a0 ≤ b1.
      const __m256i join = _mm256_andnot_si256(
          _mm256_or_si256(_mm256_cmpgt_epi32(b0, a1), _mm256_cmpgt_epi32(a0, b1)),
          _mm256_and_si256(vm, _mm256_cmpgt_epi32(a1, a0)));
      _mm256_storeu_si256(reinterpret_cast<__m256i*>(p0 + g), _mm256_blendv_epi8(a0, _mm256_min_epi32(a0, b0), join));
      _mm256_storeu_si256(reinterpret_cast<__m256i*>(p1 + g), _mm256_blendv_epi8(a1, _mm256_max_epi32(a1, b1), join));
      const unsigned jm = static_cast<unsigned>(_mm256_movemask_ps(_mm256_castsi256_ps(join)));
      apart |= (vb & ~jm) << g;
    }
    return apart;
  }
  void flush(std::vector<ShadowSpan>& spans) {
    for (const int32_t r : touched) {
      const int k = r / H, y = r % H;
      for (int j = 0; j < n; ++j)
        if (x0[static_cast<size_t>(r) * n + j] < x1[static_cast<size_t>(r) * n + j])
          spans.push_back({y, x0[static_cast<size_t>(r) * n + j], x1[static_cast<size_t>(r) * n + j], k * ids + j});
    }
  }
};

// The pixels whose centres (x, y) lie inside the quadrilateral (u[i], v[i]), i = 0..3 in order
// around it, row by row (quad_row_span).
void quad_spans(const double* u, const double* v, int W, int H, int lamp, int slot, SpanSink& out) {
  double vmin = v[0], vmax = v[0];
  for (int i = 1; i < 4; ++i) vmin = std::min(vmin, v[i]), vmax = std::max(vmax, v[i]);
  const int y0 = std::max(0, static_cast<int>(std::ceil(vmin))), y1 = std::min(H - 1, static_cast<int>(std::floor(vmax)));
  double slope[4];
  quad_slopes(u, v, slope);
  for (int y = y0; y <= y1; ++y) {
    int x0, x1;
    if (quad_row_span(u, v, slope, W, y, &x0, &x1)) out.add(y, x0, x1, lamp, slot);
  }
}

// Each column's open run in a block: its top and bottom rows (top −1: none open), its class and
// the forward distance D = z·k_D of its last pixel.
struct RunState {
  std::vector<int32_t> top, bottom, id;
  std::vector<float> Dlast;
  explicit RunState(int n) : top(n + 8, -1), bottom(n + 8, -1), id(n + 8, -1), Dlast(n + 8, 0.f) {}
};
// The lanes b < n of a solid label run (class `lab`, columns xa + i + b, row y) that continue
// their column's open run: a run open (top ≥ 0) whose last row is the row above, of class `lab`,
// whose D = z·k_D lies within kRunStep_m of its last D. They take y as their run's bottom and D as
// its last distance (blends and plain stores: a masked store is slow on AMD's cores); the float
// operations of StreetShadowBuilder's per-pixel test (solid_pixel), eight lanes at once; returns
// the continuing lanes' bits. The others (a run starting, or closed and one started) are left to
// the caller's solid_pixel (z[0..7] must be readable).
__attribute__((target("avx2"))) unsigned continue_run_lanes_avx2(const float* z, int i, int n, int lab, float kD,
                                                                 int y, RunState& r) {
  const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
  const __m256i valid = _mm256_cmpgt_epi32(_mm256_set1_epi32(n), lane);
  const __m256i open = _mm256_cmpgt_epi32(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(&r.top[i])),
                                          _mm256_set1_epi32(-1));
  const __m256i above = _mm256_cmpeq_epi32(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(&r.bottom[i])),
                                           _mm256_set1_epi32(y - 1));
  const __m256i same = _mm256_cmpeq_epi32(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(&r.id[i])),
                                          _mm256_set1_epi32(lab));
  const __m256i cand = _mm256_and_si256(_mm256_and_si256(valid, open), _mm256_and_si256(above, same));
  const __m256 D = _mm256_mul_ps(_mm256_loadu_ps(z), _mm256_set1_ps(kD));
  const __m256 Dl = _mm256_loadu_ps(&r.Dlast[i]);
  const __m256 absd = _mm256_andnot_ps(_mm256_set1_ps(-0.f), _mm256_sub_ps(D, Dl));
  const __m256 near = _mm256_cmp_ps(absd, _mm256_set1_ps(static_cast<float>(kRunStep_m)), _CMP_LE_OQ);
  const __m256i m = _mm256_and_si256(cand, _mm256_castps_si256(near));
  const unsigned cont = static_cast<unsigned>(_mm256_movemask_ps(_mm256_castsi256_ps(m)));
  if (cont) {
    __m256i* pb = reinterpret_cast<__m256i*>(&r.bottom[i]);
    _mm256_storeu_si256(pb, _mm256_blendv_epi8(_mm256_loadu_si256(pb), _mm256_set1_epi32(y), m));
    _mm256_storeu_ps(&r.Dlast[i], _mm256_blendv_ps(Dl, D, _mm256_castsi256_ps(m)));
  }
  return cont;
}
}  // namespace

// Where each lamp's light on the ground is blocked, from the metric scene. A lamp S = (X_s, H, D_s)
// and a solid point P = (X, Y, D) below it (Y < H): the ray from S through P meets the ground at
//   G = S + λ·(P − S),  λ = H / (H − Y),
// and every ground point on the segment from P's foot-side G(Y = its lowest) to G(its highest)
// is hidden from S by the column of solid points between. Each image column's run of one solid
// class (an occluder's pixels in that column; their points from depth_m, camera z, and the camera
// model) is taken as its pixel's width at its lowest and highest points, x ± ½ at rows y_b + ½ and
// y_t − ½: four points whose ground images G make a quadrilateral on the ground, projected into
// the image; the pixels inside it lie in that lamp's shadow. The columns' quadrilaterals tile the
// occluder's shadow. Only lamps within reach_m of the run's foot (beyond it a lamp's light is
// dropped), not under 1 m from it (its own pole), and above the run's lowest point are taken; a
// shadow reaching beyond the lamp's reach, or toward the camera past the nearest visible ground,
// is cut there (λ capped: nothing it would cover there receives that lamp's light or is in view).
// What the camera does not see of an occluder casts nothing (its far side, what another object
// hides); an occluder on one plane has no thickness along the ray, so a car's shadow starts at its
// visible face, not under its far side. Deterministic: the spans are merged per row and lamp and
// sorted, whatever the threads' order.
StreetShadowBuilder::StreetShadowBuilder(const ImageU16& labels, const ImageF& depth_m, const CameraGeometry& g,
                                         const StreetLighting& s, const ScenePreset& p, const LabelRuns* runs)
    : labels_(labels), depth_(depth_m), g_(g), s_(s), reach_(s.lamps.size()) {
  // The label runs handed where they were made of these labels, else made here (over the
  // threads where this is not inside a parallel region): the scan visits only the solid runs.
  if (runs && runs->made_of(labels)) {
    runs_ = runs;
  } else if (!s.lamps.empty()) {
    own_runs_ = label_runs(labels);
    runs_ = own_runs_.get();
  }
  for (size_t k = 0; k < s.lamps.size(); ++k) reach_[k] = reach_m(s.lamps[k].Y_m, p);
  disc_ = lamp_disc_samples(p.lamp_head_diameter_m, lamp_shadow_samples(p));
  disc_radius_ = 0.5 * p.lamp_head_diameter_m;
  // The nearest ground in view: the bottom row's (less half a metre); a shadow is cut there.
  double D;
  if (g.ground_point(g.cx_px, labels.height() - 0.5, nullptr, &D, nullptr)) D_bottom_ = std::max(0.1, D - 0.5);
  blocks_ = std::make_unique<BlockRuns[]>((labels.width() + kShadowBlock - 1) / kShadowBlock);
}

// Blocks of kShadowBlock columns, taken from the shared counter; each is scanned row by row,
// keeping each column's open run.
void StreetShadowBuilder::take_blocks() {
  const ImageU16& labels = labels_;
  const ImageF& depth_m = depth_;
  const CameraGeometry& g = g_;
  const StreetLighting& s = s_;
  const std::vector<double>& reach = reach_;
  std::vector<double> reach2(reach.size());
  for (size_t k = 0; k < reach.size(); ++k) reach2[k] = reach[k] * reach[k];
  const LabelRuns* runs = runs_;
  const double D_bottom = D_bottom_;
  const int W = labels.width(), H = labels.height();
  if (s.lamps.empty()) return;
  const uint64_t solid = label_bits(street_shadow_classes());
  const bool avx2 = light_isa() >= 1;
  const double c = std::cos(g.pitch_rad), sn = std::sin(g.pitch_rad), h = g.mount_height_m;
  const int nbw = (W + kShadowBlock - 1) / kShadowBlock;
  const std::vector<std::array<double, 2>>& disc = disc_;
  const int ns = static_cast<int>(disc.size());
  const int ids = LampShadowRows::ids_per_lamp(ns);
  // One slot per lamp: its spans with one point, or those of all its points at once (id
  // k·(n + 1) + n); the points' own in `points`.
  SpanSink mine(s.lamps.size(), H);
  long long my_quads = 0;
  DiscQuads dq;  // with penumbrae: one (run, lamp)'s points' quadrilaterals
  std::optional<PointSpanSink> points;  // with penumbrae: the points' spans
  if (ns > 1) points.emplace(s.lamps.size(), H, ids);
  // The disc's points of each lamp, S_j = S + (ΔX_j, 0, ΔD_j) (ns == 1: the centre).
  std::vector<double> SXk(s.lamps.size() * ns), SDk(s.lamps.size() * ns);
  for (size_t k = 0; k < s.lamps.size(); ++k)
    for (int j = 0; j < ns; ++j) {
      SXk[k * ns + j] = s.lamps[k].X_m + disc[j][0];
      SDk[k * ns + j] = s.lamps[k].D_m + disc[j][1];
    }
  // A closed run's quadrilateral from lamp k (its points with penumbrae) into this thread's sinks.
  auto cast_run = [&](const CastRun& run, size_t k) {
    const double* X = run.X;
    const double* Dp = run.D;
    const double* Yp = run.Y;
    const double Yb = Yp[0], Db = Dp[0];
    const bool pole = run.pole;
    const StreetLamp& l = s.lamps[k];
    const double Hl = l.Y_m;
    if (!(Yb < Hl)) return;
    // The run's foot nearest the lamp's: within its reach, and not its own pole.
    const double dx = std::max({X[0] - l.X_m, 0.0, l.X_m - X[1]}), dd = Db - l.D_m, rb2 = dx * dx + dd * dd;
    if (rb2 > reach2[k] || (pole && rb2 < kOwnPole_m * kOwnPole_m)) return;
    const QuadCast cast{X, Dp, Yp, Hl, reach[k], reach2[k], D_bottom, g.cx_px, g.cy_px, g.f_px, h, c, sn};
    double u[4], v[4];
    if (ns == 1) {  // the lamp a point: its centre
      if (!cast_quad(cast, l.X_m, l.D_m, u, v, nullptr)) return;
      quad_spans(u, v, W, H, static_cast<int>(k), static_cast<int>(k), mine);
      ++my_quads;
      return;
    }
    // Penumbrae: where no vertex of the centre's quadrilateral moves by half a pixel as the
    // point goes over the disc (radius R: R·shift_px < ½), the disc's points all cast the
    // centre's pixels but for the one pixel at an edge whose centre lies within that
    // half-pixel: the quadrilateral is drawn once, for all of them (id k·(n + 1) + n: an
    // occluder far from the camera or low against its lamp's height). Else each sample
    // point S_j = S + (ΔX_j, 0, ΔD_j) of the disc casts its own: the disc lies at the mount
    // height, so λ's first form is the same for every point; the caps are each point's own.
    double shift = 0;
    if (cast_quad(cast, l.X_m, l.D_m, u, v, &shift) && disc_radius_ * shift < 0.5) {
      quad_spans(u, v, W, H, static_cast<int>(k) * ids + ns, static_cast<int>(k), mine);
      ++my_quads;
      return;
    }
    // The points' quadrilaterals (four to a vector on AVX2: the same corners), then each
    // row's spans of all of them at once (disc_row_spans_*: the same columns as quad_spans on
    // each).
    double vlo, vhi;
    const bool drawn = (avx2 ? disc_quads_avx2(cast, SXk.data() + k * ns, SDk.data() + k * ns, dq, &vlo, &vhi)
                             : disc_quads_scalar(cast, SXk.data() + k * ns, SDk.data() + k * ns, dq, &vlo, &vhi)) != 0;
    if (!drawn) return;
    ++my_quads;
    const int ry0 = std::max(0, static_cast<int>(std::ceil(vlo)));
    const int ry1 = std::min(H - 1, static_cast<int>(std::floor(vhi)));
    for (int y = ry0; y <= ry1; ++y) {
      alignas(32) int32_t x0[DiscQuads::kPoints], x1[DiscQuads::kPoints];
      const unsigned valid = avx2 ? disc_row_spans_avx2(dq, W, y, x0, x1) : disc_row_spans_scalar(dq, W, y, x0, x1);
      if (valid) points->add(k, y, x0, x1, valid, avx2, mine.spans);
    }
  };
  // The lamps of block b's runs, taken one by one from its counter (by any thread, once it is
  // published).
  auto cast_block = [&](int b) {
    BlockRuns& job = blocks_[b];
    for (int k = job.next_lamp++; k < static_cast<int>(s.lamps.size()); k = job.next_lamp++)
      for (const CastRun& run : job.runs) cast_run(run, static_cast<size_t>(k));
  };
  for (int blk = next_block_++; blk < nbw; blk = next_block_++) {
    const int xa = blk * kShadowBlock, xb = std::min(W, xa + kShadowBlock);
    RunState r(xb - xa);
    BlockRuns& job = blocks_[blk];
    // Runs of columns xl .. xr, each from row yt (top) to yb (bottom), of one class and the same
    // depths at both ends, closed: their quadrilaterals, one per lamp (the columns' own tile it:
    // their points lie on the same two horizontal lines of one plane, whose ground images from a
    // point are two straight lines): the corners P_i, for cast_run.
    auto emit = [&](int x_l, int x_r, int yt, int yb, int id) {
      CastRun& run = job.runs.emplace_back();
      // The run's lowest and highest points (pixel edges), each from its own depth.
      const double zb = depth_m.at(x_l, yb), zt = depth_m.at(x_l, yt);
      const double ynb = (yb + 0.5 - g.cy_px) / g.f_px, ynt = (yt - 0.5 - g.cy_px) / g.f_px;
      const double Db = zb * (c - ynb * sn), Dt = zt * (c - ynt * sn);
      const double Yb = std::max(0.0, h - zb * (ynb * c + sn)), Yt = std::max(Yb, h - zt * (ynt * c + sn));
      const double xl = (x_l - 0.5 - g.cx_px) / g.f_px, xr = (x_r + 0.5 - g.cx_px) / g.f_px;
      const double X[4] = {zb * xl, zb * xr, zt * xr, zt * xl}, Dp[4] = {Db, Db, Dt, Dt}, Yp[4] = {Yb, Yb, Yt, Yt};
      for (int i = 0; i < 4; ++i) run.X[i] = X[i], run.D[i] = Dp[i], run.Y[i] = Yp[i];
      run.x = x_l;
      run.pole = id == static_cast<int>(Label::Pole) || id == static_cast<int>(Label::PoleGroup);
    };
    // The block's runs as they close (column, rows, class, the depths at both ends); after the
    // scan, neighbouring columns' runs with the same rows, class and depths are joined into one
    // quadrilateral (sorted by bottom row and column: the same joins whichever path found them).
    struct Closed {
      int yb, x, yt, id;
      float zt, zb;
    };
    std::vector<Closed> closed;
    auto close = [&](int x, int yt, int yb, int id) {
      closed.push_back({yb, x, yt, id, depth_m.at(x, yt), depth_m.at(x, yb)});
    };
    // A solid pixel (x, y) of class `lab` at camera depth zx: continues its column's run (the same
    // class, the row below the run's last, D within kRunStep_m of its last), or closes it and
    // starts one (not on a pixel of infinite or no depth: the sky's value, a hole).
    const float step = static_cast<float>(kRunStep_m);
    auto solid_pixel = [&](int x, int y, int lab, float zx, float kD) {
      const int i = x - xa;
      if (r.top[i] >= 0) {
        const float D = zx * kD;
        if (r.bottom[i] == y - 1 && r.id[i] == lab && std::fabs(D - r.Dlast[i]) <= step) {
          r.bottom[i] = y;
          r.Dlast[i] = D;
          return;
        }
        close(x, r.top[i], r.bottom[i], r.id[i]);
      }
      if (zx < kDepthInfinity_m && zx > 0) {
        r.top[i] = r.bottom[i] = y;
        r.id[i] = lab;
        r.Dlast[i] = zx * kD;
      } else {
        r.top[i] = -1;
      }
    };
    // The label runs (the chain's, made beside the Hough stage, or the constructor's): only the
    // solid ones are visited; a run that a non-solid pixel ended is closed when its column's next
    // solid pixel comes (its bottom is then not the row above) or after the last row.
    for (int y = 0; y < H; ++y) {
      const float* z = depth_m.row(y);
      const float kD = static_cast<float>(c - (y - g.cy_px) / g.f_px * sn);
      const int r0 = runs->row_start[y], r1 = runs->row_start[y + 1];
      // The row's first run reaching column xa.
      int k = static_cast<int>(std::upper_bound(runs->x0.begin() + r0, runs->x0.begin() + r1, xa) - runs->x0.begin()) - 1;
      for (k = std::max(k, r0); k < r1 && runs->x0[k] < xb; ++k) {
        const int lab = runs->id[k];
        if (!(lab < 64 && (solid >> lab & 1))) continue;
        const int x1 = std::min(runs->end(k, y), xb);
        // Eight columns at a time where the row has eight from x on (continue_run_lanes_avx2):
        // most of a solid run's pixels continue their columns' runs; the rest one by one.
        for (int x = std::max(runs->x0[k], xa); x < x1;) {
          if (avx2 && x + 8 <= W) {
            const int n = std::min(8, x1 - x);
            unsigned rest = ((1u << n) - 1) & ~continue_run_lanes_avx2(z + x, x - xa, n, lab, kD, y, r);
            while (rest) {
              const int b = std::countr_zero(rest);
              rest &= rest - 1;
              solid_pixel(x + b, y, lab, z[x + b], kD);
            }
            x += n;
          } else {
            solid_pixel(x, y, lab, z[x], kD);
            ++x;
          }
        }
      }
    }
    for (int i = 0; i < xb - xa; ++i)
      if (r.top[i] >= 0) close(xa + i, r.top[i], r.bottom[i], r.id[i]);
    std::sort(closed.begin(), closed.end(),
              [](const Closed& p, const Closed& q) { return p.yb != q.yb ? p.yb < q.yb : p.x < q.x; });
    for (size_t j = 0; j < closed.size();) {
      size_t e = j + 1;
      while (e < closed.size() && closed[e].yb == closed[j].yb && closed[e].x == closed[e - 1].x + 1 &&
             closed[e].yt == closed[j].yt && closed[e].id == closed[j].id && closed[e].zt == closed[j].zt &&
             closed[e].zb == closed[j].zb)
        ++e;
      emit(closed[j].x, closed[e - 1].x, closed[j].yt, closed[j].yb, closed[j].id);
      j = e;
    }
    // Cast from left to right: the quadrilaterals of an occluder's neighbouring columns overlap,
    // so each point's span on a row mostly joins the last one made (SpanSink, PointSpanSink)
    // instead of another occluder's coming between (in the order of their bottom rows, 14 times
    // the spans that the merge keeps on the bench frame, each stored and sorted by finish()).
    // Any order gives the same merged spans.
    std::sort(job.runs.begin(), job.runs.end(), [](const CastRun& p, const CastRun& q) { return p.x < q.x; });
    // Published: its lamps are now shared with the threads that find no block left to scan.
    job.ready.store(true, std::memory_order_release);
    cast_block(blk);
  }
  // No block left to scan: help with the lamps of the blocks still being cast (a block not yet
  // published is being scanned by a thread that took it, which publishes it when done). The
  // blocks' work is uneven (the occluders near the lamps cluster in a few columns), and a lamp
  // of a block is the unit shared: the same spans whichever thread casts which.
  for (int b = 0; b < nbw; ++b) {
    if (blocks_[b].next_lamp.load(std::memory_order_relaxed) >= static_cast<int>(s.lamps.size())) continue;
    while (!blocks_[b].ready.load(std::memory_order_acquire)) std::this_thread::yield();
    cast_block(b);
  }
  if (points) points->flush(mine.spans);
  quads_ += my_quads;
  std::lock_guard<std::mutex> lock(parts_mutex_);
  parts_.push_back(std::move(mine.spans));
}

LampShadowRows StreetShadowBuilder::finish() {
  const int H = labels_.height();
  LampShadowRows out;
  out.row_start.assign(H + 1, 0);
  const std::vector<std::vector<ShadowSpan>>& part = parts_;
  // The threads' spans by row (a counting sort), then per row sorted by (lamp, x0) and merged
  // where they touch: the same spans whatever the threads' order.
  size_t n = 0;
  for (const auto& pt : part) {
    n += pt.size();
    for (const ShadowSpan& sp : pt) ++out.row_start[sp.y + 1];
  }
  for (int y = 0; y < H; ++y) out.row_start[y + 1] += out.row_start[y];
  std::vector<int32_t> at(out.row_start.begin(), out.row_start.end() - 1);
  out.spans.resize(n);
  for (const auto& pt : part)
    for (const ShadowSpan& sp : pt) out.spans[at[sp.y]++] = sp;
  // Each row's spans merged in place (rows in parallel), then the rows packed in order.
  std::vector<int32_t> kept(H, 0);
#pragma omp parallel for schedule(dynamic, 32)
  for (int y = 0; y < H; ++y) {
    const int32_t a = out.row_start[y], b = out.row_start[y + 1];
    if (a == b) continue;
    std::sort(out.spans.begin() + a, out.spans.begin() + b, [](const ShadowSpan& p, const ShadowSpan& q) {
      return p.lamp != q.lamp ? p.lamp < q.lamp : p.x0 < q.x0;
    });
    int32_t w = a;
    for (int32_t i = a + 1; i < b; ++i) {
      ShadowSpan& last = out.spans[w];
      if (out.spans[i].lamp == last.lamp && out.spans[i].x0 <= last.x1) last.x1 = std::max(last.x1, out.spans[i].x1);
      else out.spans[++w] = out.spans[i];
    }
    kept[y] = w + 1 - a;
  }
  int32_t w = 0;
  for (int y = 0; y < H; ++y) {
    const int32_t a = out.row_start[y];
    out.row_start[y] = w;
    for (int32_t i = 0; i < kept[y]; ++i) out.spans[w + i] = out.spans[a + i];  // a ≥ w: forward copy is safe
    w += kept[y];
  }
  out.row_start[H] = w;
  out.spans.resize(w);
  out.quads = quads_;
  out.lamps = s_.lamps.size();
  out.samples = static_cast<int>(disc_.size());
  return out;
}

LampShadowRows street_lamp_shadow_spans(const ImageU16& labels, const ImageF& depth_m, const CameraGeometry& g,
                                        const StreetLighting& s, const ScenePreset& p, const LabelRuns* runs) {
  StreetShadowBuilder b(labels, depth_m, g, s, p, runs);
#pragma omp parallel
  b.take_blocks();
  return b.finish();
}

// The luminaire's emitting face as n points of equal area (street_lamps.penumbrae): the face's
// luminance is taken as uniform (a stated assumption: an LED luminaire's lens array spreads its
// flux over the face; no measured map of it is at hand), so a ground point's share of the lamp's
// light is the share of the disc's area it sees past the occluders, and each point stands for
// 1/n of it. The Vogel spiral (H. Vogel, "A better way to construct the sunflower head", Math.
// Biosci. 44:179–189, 1979) puts point i in the middle, by area, of the i-th of n equal-area
// annuli (r² = (i + ½)/n of R²) and turns each by the golden angle, so that a straight edge
// across the disc, the case of a shadow's edge, cuts off nearly its area's share of the points
// (the half-plane discrepancy in street_detail.h). No point sits at the centre: the innermost
// annulus is a disc whose middle by area lies at r = R·√(½/n), and a point at r = 0 would weight
// the centre more than its area.
std::vector<std::array<double, 2>> lamp_disc_samples(double diameter_m, int n) {
  if (n <= 1) return {{0.0, 0.0}};
  std::vector<std::array<double, 2>> pts(n);
  const double golden = M_PI * (3 - std::sqrt(5.0));
  for (int i = 0; i < n; ++i) {
    const double r = 0.5 * diameter_m * std::sqrt((i + 0.5) / n), th = i * golden;
    pts[i] = {r * std::cos(th), r * std::sin(th)};
  }
  return pts;
}

int lamp_shadow_samples(const ScenePreset& p) { return p.lamp_penumbrae ? kLampDiscSamples : 1; }

namespace {
// What the pools and the vertical light share: their inputs, the street light's tint over π (the
// Lambertian reflection L = ρ·E/π per channel) and the intensity table.
struct LitRows {
  const ImageF& texture;
  const ImageU16& labels;
  const CameraGeometry& g;
  const int W;
  float tlf[3];
  const RelTable table;  // a copy: the threads each read it
  LitRows(const ImageF& texture_, const ImageU16& labels_, const CameraGeometry& g_, const ScenePreset& p, int width)
      : texture(texture_), labels(labels_), g(g_), W(width), table(rel_table(p)) {
    const auto tl = streetlamp_tint(p);
    for (int k = 0; k < 3; ++k) tlf[k] = static_cast<float>(tl[k] / M_PI);
  }
};
// add_street_lighting's pools row by row: the set-up once, then any row on any thread with its own
// scratch (add_street_lighting runs it over the frame; add_street_light_rows with the vertical
// light and the windows in one pass over the rows).
struct PoolPass : LitRows {
  const StreetLighting& s;
  const int y_start;
  const uint64_t ground_mask;
  const int isa;
  std::vector<double> reach;  // each lamp's reach_m, once (not per row)
  const float I0;
  const float tol;  // street_lamps.interp_tolerance (0: every pixel exactly)
  // The lamps' shadows on the ground (street_lamps.shadows with the metric depth), else null.
  const LampShadowRows* shadows = nullptr;
  PoolPass(const ImageF& texture_, const ImageU16& labels_, const CameraGeometry& g_, const StreetLighting& s_,
           const ScenePreset& p, int width)
      : LitRows(texture_, labels_, g_, p, width), s(s_),
        y_start(std::max(0, static_cast<int>(std::floor(g_.horizon_y)) + 1)), ground_mask(label_bits(ground_classes())),
        isa(light_isa()), reach(s_.lamps.size()), I0(static_cast<float>(s_.peak_intensity_cd)),
        tol(static_cast<float>(p.lamp_interp_tolerance)) {
    for (size_t k = 0; k < s.lamps.size(); ++k) reach[k] = reach_m(s.lamps[k].Y_m, p);
  }
  struct Scratch {
    std::vector<float> acc;
    std::vector<double> Xg;
    std::vector<uint8_t> gbits;
    PoolLamps pl;
    // The interpolated path: the sample columns' ground X and E (compacted), all-ground bits.
    std::vector<double> Xs;
    std::vector<float> es;
    std::vector<uint8_t> ones;
    std::vector<int> lo, hi, ends;  // per lamp: its columns within the cone [lo, hi); their ends, sorted
    std::vector<int> lamp_index;    // the row's lamps (pl) by their index in StreetLighting::lamps
    std::vector<std::pair<int32_t, int32_t>> events;  // shade's span ends of a lamp's points on a row (column, ±count)
    std::vector<int32_t> counts;  // shade: per column of a covered stretch, the lamp's points in shadow
    long long shaded = 0;           // (ground pixel, lamp) pairs taken off by the shadows
    AdaptiveScratch ad;
    explicit Scratch(int W)
        : acc(W + 8), Xg(W + 8), gbits(W / 8 + 2), Xs(W + 16), es(W + 16), ones(W / 8 + 4, 0xff), counts(W + 8) {}
  };
  // The exact pools at n columns xs (compacted, into sc.es): the row kernel on their ground X
  // (the same expression as the full row's), each lane its own pixel: the same bits as at those
  // columns in the full row.
  void pool_at(const int32_t* xs, int n, double kx, Scratch& sc) const {
    for (int i = 0; i < n; ++i) sc.Xs[i] = (xs[i] - g.cx_px) * kx;
    const int np = (n + 7) / 8 * 8;
    for (int i = n; i < np; ++i) sc.Xs[i] = sc.Xs[n - 1];
    if (isa >= 2) pool_row_avx512(sc.es.data(), sc.Xs.data(), sc.ones.data(), np, sc.pl, I0, table);
    else if (isa >= 1) pool_row_avx2(sc.es.data(), sc.Xs.data(), sc.ones.data(), np, sc.pl, I0, table);
    else pool_row_scalar(sc.es.data(), sc.Xs.data(), sc.ones.data(), np, sc.pl, I0, table);
  }
  void row(ImageF& L, int y, Scratch& sc) const {
    double D0, t;
    if (y < y_start || !g.ground_point(g.cx_px, y, nullptr, &D0, &t)) return;
    const uint16_t* id = labels.row(y);
    // The row's ground pixels as bits per group of eight columns (from column 0), and the
    // groups qa .. qb − 1 from the first to the last holding one.
    const int ng = (W + 7) / 8;
    if (isa >= 1) class_bits_avx2(id, W, ground_mask, sc.gbits.data());
    else class_bits_scalar(id, W, ground_mask, sc.gbits.data());
    int qa = 0, qb = ng;
    while (qa < qb && !sc.gbits[qa]) ++qa;
    while (qb > qa && !sc.gbits[qb - 1]) --qb;
    if (qa == qb) return;
    // Each lamp over its footprint, the band of rows within its reach along the road (the
    // ground row is a line of constant D; reach_m: beyond it a lamp gives at most
    // rel(γ_reach)·cos³γ_reach = 0.24% of its nadir illuminance I0/H², dropped), summed per
    // pixel over the row's lamps in their order (float32: see pool_term). (A disc of radius
    // reach_m around the foot instead of the band measured 5% faster on the bench frame and
    // changed dim pixels by up to 4%: not taken.)
    const double kx = t / g.f_px;
    sc.pl.clear();
    sc.lamp_index.clear();
    for (size_t k = 0; k < s.lamps.size(); ++k) {
      const auto& l = s.lamps[k];
      if (std::fabs(D0 - l.D_m) <= reach[k]) {
        sc.pl.add(l.X_m, D0 - l.D_m, l.Y_m);
        sc.lamp_index.push_back(static_cast<int>(k));
      }
    }
    if (sc.pl.size() == 0) return;  // nothing is written in this row
    // The groups holding a ground pixel are computed (a pixel's E does not depend on its
    // group: each lane is its own), the others not; the columns past W of the last group are
    // computed and not read.
    const int xa = 8 * qa, n = 8 * (qb - qa);
    float* o = L.row(y);
    const float* tx = texture.row(y);
    if (tol > 0) {
      // Adaptive samples over the span's columns (adaptive_span: E(X) is one smooth function
      // along the row, also across the non-ground pixels between), then the reflection.
      float* acc = sc.acc.data();
      double Hmin = 1e300;
      for (int k = 0; k < sc.pl.size(); ++k) Hmin = std::min(Hmin, static_cast<double>(sc.pl.Hl[k]));
      const int step = static_cast<int>(std::clamp(kInterpStep_m_per_H * Hmin / kx, 2.0, double{kInterpStep_px}));
      // The knees: each lamp's columns within its cone, [lo, hi), once per row (cutoff_columns:
      // from the knee's X, moved to where the double predicate H² < cos²γ_c·d² itself changes,
      // column by column), and their ends sorted. An interval holding an end in (a, b] is never
      // accepted, so every knee is bracketed by exact samples at adjacent columns and an accepted
      // interval holds no knee at all.
      const double cc2 = table.cc * table.cc;
      const int x1 = std::min(W, xa + n) - 1;
      const int nl = sc.pl.size();
      sc.lo.resize(nl);
      sc.hi.resize(nl);
      sc.ends.clear();
      for (int k = 0; k < nl; ++k) {
        cutoff_columns(sc.pl.Xl[k], sc.pl.dz2[k], sc.pl.H2[k], cc2, g.cx_px, kx, xa, x1, &sc.lo[k], &sc.hi[k]);
        if (sc.lo[k] == sc.hi[k]) continue;  // beyond its cut-off on every column
        if (sc.lo[k] > xa) sc.ends.push_back(sc.lo[k]);
        if (sc.hi[k] <= x1) sc.ends.push_back(sc.hi[k]);
      }
      std::sort(sc.ends.begin(), sc.ends.end());
      adaptive_span(
          xa, x1, step, tol, acc, sc.ad,
          [&](const int32_t* xs, int m) {
            pool_at(xs, m, kx, sc);
            for (int i = 0; i < m; ++i) acc[xs[i]] = sc.es[i];
          },
          [&](int a, int b) {
            // Accepted only with no run end in (a, b]: no lamp's knee inside, also where a whole
            // cone crosses between two samples (both its ends inside, the samples' signatures
            // alike): such an interval is split down to exact columns on both sides of each knee.
            const auto e = std::upper_bound(sc.ends.begin(), sc.ends.end(), a);
            return e == sc.ends.end() || *e > b;
          });
      shade(y, kx, acc, sc);
      if (isa >= 2) add_reflection_avx512(o, tx, acc, sc.gbits.data(), qa, qb, W, tlf);
      else if (isa >= 1) add_reflection_avx2(o, tx, acc, sc.gbits.data(), qa, qb, W, tlf);
      else add_reflection_scalar(o, tx, acc, sc.gbits.data(), qa, qb, W, tlf);
      return;
    }
    for (int i = 0; i < n; ++i) sc.Xg[i] = (xa + i - g.cx_px) * kx;  // the pixel's ground X
    if (isa >= 1) {
      if (isa >= 2) pool_row_avx512(sc.acc.data() + xa, sc.Xg.data(), sc.gbits.data() + qa, n, sc.pl, I0, table);
      else pool_row_avx2(sc.acc.data() + xa, sc.Xg.data(), sc.gbits.data() + qa, n, sc.pl, I0, table);
      shade(y, kx, sc.acc.data(), sc);
      if (isa >= 2) add_reflection_avx512(o, tx, sc.acc.data(), sc.gbits.data(), qa, qb, W, tlf);
      else add_reflection_avx2(o, tx, sc.acc.data(), sc.gbits.data(), qa, qb, W, tlf);
    } else {
      pool_row_scalar(sc.acc.data() + xa, sc.Xg.data(), sc.gbits.data() + qa, n, sc.pl, I0, table);
      shade(y, kx, sc.acc.data(), sc);
      add_reflection_scalar(o, tx, sc.acc.data(), sc.gbits.data(), qa, qb, W, tlf);
    }
  }
  // The shadows of row y: each ground pixel in lamp k's shadow loses k's term (pool_term, the
  // bits it added to the sum), held at 0 or above (the sum's rounding, or an interpolated sum
  // within street_lamps.interp_tolerance of the exact one). With penumbrae (n sample points per
  // lamp) a pixel in the shadow of m of k's points loses m/n of it: the points' spans counted per
  // pixel (+1 at a span's start, −1 at its end, summed along the row); m = n, the umbra, takes
  // off the whole term as one point does, the same float operation.
  void shade(int y, double kx, float* acc, Scratch& sc) const {
    if (!shadows) return;
    const int32_t a = shadows->row_start[y], b = shadows->row_start[y + 1];
    if (a == b) return;
    const uint8_t* gb = sc.gbits.data();
    size_t j = 0;  // the row's lamp of the span (both lists ascend by lamp index)
    const size_t nl = sc.lamp_index.size();
    const int ns = shadows->samples;
    // Pixels x0 .. x1 − 1 of lamp j's row in the shadow of m of its ns points lose m/ns of its
    // term (pool_term, the bits it added); m >= ns, the umbra, the whole term.
    const float per_point = 1.f / static_cast<float>(ns);
    auto lose = [&](int x0, int x1, int m) {
      const float share = m >= ns ? 1.f : static_cast<float>(m) * per_point;
      int x = x0;
      if (isa >= 1)
        x = shade_cols_avx2(acc, gb, nullptr, m, x0, x1, ns, per_point, g.cx_px, kx, sc.pl.Xl[j], sc.pl.dz2[j],
                            sc.pl.H2[j], sc.pl.Hl[j], I0, table, &sc.shaded);
      for (; x < x1; ++x) {
        if (!(gb[x >> 3] >> (x & 7) & 1)) continue;
        const float t = pool_term(static_cast<float>((x - g.cx_px) * kx - sc.pl.Xl[j]), sc.pl.dz2[j], sc.pl.H2[j],
                                  sc.pl.Hl[j], I0, table);
        acc[x] = std::max(0.f, acc[x] - (m >= ns ? t : t * share));
        ++sc.shaded;
      }
    };
    // Columns x0 .. x1 − 1 with their counts (sc.counts[x] ≥ 1) of lamp j's points in shadow, with AVX2.
    auto lose_counts = [&](int x0, int x1) {
      const int32_t* cnt = sc.counts.data();
      const int x = shade_cols_avx2(acc, gb, cnt, 0, x0, x1, ns, per_point, g.cx_px, kx, sc.pl.Xl[j], sc.pl.dz2[j],
                                    sc.pl.H2[j], sc.pl.Hl[j], I0, table, &sc.shaded);
      for (int xe = x; xe < x1;) {  // the rest: runs of one count
        int e = xe + 1;
        while (e < x1 && cnt[e] == cnt[xe]) ++e;
        lose(xe, e, cnt[xe]);
        xe = e;
      }
    };
    if (ns == 1) {  // one point per lamp: each span its whole term (no counting needed)
      for (int32_t si = a; si < b; ++si) {
        const ShadowSpan& sp = shadows->spans[si];
        while (j < nl && sc.lamp_index[j] < sp.lamp) ++j;
        if (j == nl) break;
        if (sc.lamp_index[j] != sp.lamp) continue;  // not within reach of this row
        lose(sp.x0, sp.x1, 1);
      }
      return;
    }
    const int ids = shadows->ids_per_lamp();
    for (int32_t si = a; si < b;) {
      const int lamp = shadows->spans[si].lamp / ids;
      int32_t se = si + 1;  // the spans of lamp's points: si .. se − 1
      while (se < b && shadows->spans[se].lamp / ids == lamp) ++se;
      while (j < nl && sc.lamp_index[j] < lamp) ++j;
      if (j == nl) break;
      if (sc.lamp_index[j] != lamp) {  // not within reach of this row
        si = se;
        continue;
      }
      // Each point's spans are disjoint (merged per id and row), a span of all of them counts n:
      // the points in shadow are min(n, the count). The count changes only at the spans' ends:
      // they are sorted once and only the columns between ends with a count above 0 are visited
      // (not the gaps between one lamp's shadows on the row).
      auto& ev = sc.events;
      ev.clear();
      for (int32_t i = si; i < se; ++i) {
        const ShadowSpan& sp = shadows->spans[i];
        const int32_t wgt = sp.lamp % ids == ns ? ns : 1;
        ev.push_back({sp.x0, wgt});
        ev.push_back({sp.x1, -wgt});
      }
      std::sort(ev.begin(), ev.end(), [](const std::pair<int32_t, int32_t>& p, const std::pair<int32_t, int32_t>& q) {
        return p.first < q.first;
      });
      int m = 0;
      if (isa < 1) {
        for (size_t e = 0; e + 1 < ev.size(); ++e) {
          m += ev[e].second;
          if (m > 0) lose(ev[e].first, ev[e + 1].first, m);
        }
      } else {
        // Each stretch of columns with a count above 0 at once, eight columns at a time with each
        // column's own count (a penumbra's counts change every few columns): the same operations
        // per pixel as lose().
        int32_t* cnt = sc.counts.data();
        int s0 = -1;
        for (size_t e = 0; e + 1 < ev.size(); ++e) {
          m += ev[e].second;
          const int xa = ev[e].first, xb = ev[e + 1].first;
          if (m > 0) {
            if (s0 < 0) s0 = xa;
            std::fill(cnt + xa, cnt + xb, m);
          } else if (s0 >= 0) {
            lose_counts(s0, xa);
            s0 = -1;
          }
        }
        if (s0 >= 0) lose_counts(s0, ev.back().first);
      }
      si = se;
    }
  }
};
// The lamp heads (below add_street_lighting).
int draw_lamp_heads(ImageF& L, const CameraGeometry& g, const StreetLighting& s, const ScenePreset& p,
                    const ImageF* depth_m, const ImageU16& labels);
}  // namespace

int add_street_lighting(ImageF& L, const ImageF& texture, const ImageU16& labels, const CameraGeometry& g,
                        const StreetLighting& s, const ScenePreset& p, const ImageF* depth_m) {
  if (s.lamps.empty()) return 0;
  const PoolPass pools(texture, labels, g, s, p, L.width());
#pragma omp parallel
  {
    PoolPass::Scratch sc(L.width());
#pragma omp for schedule(static, 8)
    for (int y = pools.y_start; y < L.height(); ++y) pools.row(L, y, sc);
  }
  return draw_lamp_heads(L, g, s, p, depth_m, labels);
}

namespace {
// The lamp heads in the frame, at the luminance the luminaire's own intensity distribution sends
// toward the camera, only over their footprint.
//
// The emitting face is the luminaire's flat, horizontal bottom (a full cut-off head with a flat
// glass: the photometry the pools use, lamp_relative_intensity, is a cut-off one): a disc of
// street_lamps.head_diameter_m facing the nadir. Seen from the camera along a direction at γ from
// the nadir (the lamp-to-camera direction), its projected area is A·cos γ, so its luminance is
// L = I0·rel(γ) / (A·cos γ) and the flux per steradian toward the lens is the luminaire's I(γ),
// the distribution that lights the pools (as the vehicle lamps are drawn at I/A). A lamp seen in
// the frame is beyond its cut-off (γ ≳ 77° for a 10 m mount and a ±12.7° vertical field): the face
// is seen nearly edge-on, a thin ellipse cos γ ≈ 0.1-0.3 of its width high, 3-10 times the
// luminance of a face seen head-on. (Until the twenty-seventh session the head was a disc facing
// the camera, L = I/A: the same flux over 3-10 times the pixels.)
//
// Its image is the disc through the projection's Jacobian at the head's centre (the affine
// approximation of the pinhole, exact to first order in d/z): with (X, Y, D) the centre in road
// coordinates and z its depth (CameraGeometry::project), u = cx + f·X/z and v = cy + f·y_c/z give
//   J = ∂(u, v)/∂(X, D) = [[f/z, −f·X·cos θ/z²], [0, f·(Y − h)/z²]]
// (θ the pitch, h the camera height; ∂v/∂D = −f·(h − Y)/z² since sin θ·z + cos θ·y_c = h − Y), and
// the disc {(X, D) + w : |w| ≤ d/2} maps to the ellipse {J·w}: S = (d/2)²·J·Jᵀ, inside where
// Δᵀ·S⁻¹·Δ ≤ 1. Its area π·(d/2)²·|det J| in pixels, each of solid angle cos³(off-axis)/f², is
// A·cos γ/dist²: the flux above, to the same first order.
//
// Drawn by its coverage of each pixel (kHeadSub² sub-pixel samples: L·covered share), and never
// narrower than 2 px (one period of the colour filter array) along either axis: a thinner one is
// drawn 2 px wide there with its luminance lowered in proportion, so that a far head still sends
// I(γ). Why: a source narrower than the CFA's 2×2 cell lands on one or two of its colours and
// comes out of the demosaic as a coloured dot (a far head seen edge-on is a fraction of a pixel
// high); a real camera spreads it by its lens's blur (and often an optical low-pass filter), which
// photosite's lens model does not have (its PSF is a delta plus the glare's skirt). A 2×2 box at
// any position gives each of the cell's four sites a quarter of its flux, and a covered ellipse
// 2 px across nearly so. This is a photosite choice standing in for that blur, not a model of it.
// (Before: a disc facing the camera at I/A, sampled at pixel centres, its radius raised to 0.5 px
// with more flux than the lamp's.)
struct HeadDisc {
  double u, v, z;
  double q11, q12, q22;  // S⁻¹ of the drawn ellipse (pixels⁻²)
  std::array<double, 3> head;
  int y0, y1, x0, x1;  // the rows and columns of its bounding box inside the frame
  bool from_pole = false;  // the luminaire of a detected pole (StreetLamp::from_pole)
};
std::vector<HeadDisc> lamp_head_discs(const CameraGeometry& g, const StreetLighting& s, const ScenePreset& p, int W,
                                      int H) {
  const auto head1 = streetlamp_rgb(p, 1.0);
  const double rho = 0.5 * p.lamp_head_diameter_m, head_area_m2 = M_PI * rho * rho;
  const double cos_pitch = std::cos(g.pitch_rad);
  std::vector<HeadDisc> out;
  for (const auto& l : s.lamps) {
    double u, v, z;
    if (!g.project(l.X_m, l.Y_m, l.D_m, &u, &v, &z)) continue;
    const double rise = l.Y_m - g.mount_height_m;  // the face looks down: seen only from below it
    if (!(rise > 0)) continue;
    const double dist = std::sqrt(l.X_m * l.X_m + l.D_m * l.D_m + rise * rise);
    const double cos_gamma = rise / dist, gamma = std::atan2(std::hypot(l.X_m, l.D_m), rise);
    const double j11 = g.f_px / z, j12 = -g.f_px * l.X_m * cos_pitch / (z * z), j22 = g.f_px * rise / (z * z);
    // S = ρ²·J·Jᵀ (J's lower-left entry is 0), its eigenvalues (squared semi-axes) and those raised
    // to 1 px² (a 2 px axis) where smaller.
    const double s11 = rho * rho * (j11 * j11 + j12 * j12), s12 = rho * rho * j12 * j22, s22 = rho * rho * j22 * j22;
    const double mean = 0.5 * (s11 + s22), dev = std::hypot(0.5 * (s11 - s22), s12);
    const double l1 = mean + dev, l2 = std::max(0.0, mean - dev);
    const double m1 = std::max(l1, 1.0), m2 = std::max(l2, 1.0);
    // The drawn S: the same axes, raised eigenvalues (S' = S + (m1 − l1)·e1e1ᵀ + (m2 − l2)·e2e2ᵀ).
    double e1x = 1, e1y = 0;  // e1, the major axis (any axis where S is a multiple of the identity)
    if (dev > 0) {
      e1x = s12, e1y = l1 - s11;
      if (std::abs(e1x) + std::abs(e1y) < 1e-12 * (std::abs(l1) + 1)) e1x = l1 - s22, e1y = s12;
      const double n = std::hypot(e1x, e1y);
      e1x /= n, e1y /= n;
    }
    const double t11 = m1 * e1x * e1x + m2 * e1y * e1y, t12 = (m1 - m2) * e1x * e1y,
                 t22 = m1 * e1y * e1y + m2 * e1x * e1x;
    const double det = t11 * t22 - t12 * t12;
    // The luminance, lowered by the true area over the drawn one where an axis was raised.
    const double Lh = s.peak_intensity_cd * lamp_relative_intensity(gamma, p) / (head_area_m2 * cos_gamma) *
                      std::sqrt(l1 * l2 / (m1 * m2));
    // The box's half-width and half-height: the ellipse's extent plus the half pixel its covered
    // pixels reach beyond it.
    const double hx = std::sqrt(t11) + 0.5, hy = std::sqrt(t22) + 0.5;
    if (u + hx < 0 || u - hx >= W || v + hy < 0 || v - hy >= H) continue;
    out.push_back({u, v, z, t22 / det, -t12 / det, t11 / det, {head1[0] * Lh, head1[1] * Lh, head1[2] * Lh},
                   std::max(0, static_cast<int>(std::floor(v - hy))), std::min(H - 1, static_cast<int>(std::ceil(v + hy))),
                   std::max(0, static_cast<int>(std::floor(u - hx))), std::min(W - 1, static_cast<int>(std::ceil(u + hx)))});
    out.back().from_pole = l.from_pole;
  }
  return out;
}
// The share of pixel (x, y)'s kHeadSub × kHeadSub sub-pixel samples (centres at (i + ½)/kHeadSub
// − ½ of a pixel from its centre) inside head d's ellipse, as a count.
constexpr int kHeadSub = 4;
inline int head_samples_in(const HeadDisc& d, int x, int y) {
  int in = 0;
  for (int j = 0; j < kHeadSub; ++j) {
    const double dy = y + (j + 0.5) / kHeadSub - 0.5 - d.v;
    for (int i = 0; i < kHeadSub; ++i) {
      const double dx = x + (i + 0.5) / kHeadSub - 0.5 - d.u;
      in += d.q11 * dx * dx + 2 * d.q12 * dx * dy + d.q22 * dy * dy <= 1;
    }
  }
  return in;
}
// Head d's pixels in row y (inside its box rows), each at the head's luminance times its share of
// samples inside the ellipse, as a maximum over L; whether any was drawn.
bool draw_head_row(ImageF& L, const HeadDisc& d, int y) {
  bool any = false;
  for (int x = d.x0; x <= d.x1; ++x) {
    const int in = head_samples_in(d, x, y);
    if (!in) continue;
    const double share = static_cast<double>(in) / (kHeadSub * kHeadSub);
    for (int k = 0; k < 3; ++k) L.at(x, y, k) = std::max(L.at(x, y, k), static_cast<float>(d.head[k] * share));
    any = true;
  }
  return any;
}
// Whether head d stands behind what the metric depth puts in front of it (issue 14 §2: a luminaire
// behind a building does not glow on its façade). A whole-head decision: hidden when more than
// half of its samples (the drawn ellipse, head_samples_in) fall on pixels whose surface lies in
// front of the head by more than that depth's own uncertainty; otherwise drawn whole. Why whole:
// a head is 2-10 px, and a per-pixel test cut heads at silhouettes whose depth moves with the
// columns in view (a façade or crown whose contact is hidden takes its depth from the columns that
// show one), so parts of heads came and went from frame to frame (the panning test,
// MetricLights.PanningCrops*, lost 6 points on Cityscapes with the 1 m per-pixel rule of before).
// The uncertainty: every vertical surface's depth comes from a ground contact row through the
// flat-ground model z = f·h/((v − y_h)·cos θ) (CameraGeometry::ground_point; the vertical plane
// through the contact keeps that z up the column, to first order), so a contact row off by δv
// rows moves it by δz = z²·cos θ·δv/(f·h); δv = kFacadeInlier_px (1.5 px: the row's quantisation
// ±0.5 px and the labels' boundary ±1 px, the band the façade planes are fitted with). That is
// 0.5 m at 30 m, 2 m at 60 m, 5.4 m at 100 m for Cityscapes' 2048-px frame (f 2262 px, h 1.22 m),
// twice that at half the width; at the depth cap (no contact) or the sky nothing hides a head.
// Every class with a depth counts (buildings, walls, fences, vehicles, poles, signs, vegetation:
// a crown hides the lamps behind it as a wall does, up to its gaps).
// Except a pole's own luminaire where the labels show its pole reaching up to the head (a pole
// pixel under it: in the head's columns, in the two rows from its centre's down, the centre lying
// on the top pixel's upper edge where plan_street_lighting puts it, at the pole's visible top; the
// columns, not the centre's alone, as the pole's image leans with the pitch and its box's middle
// column is not its top's): the photo shows the sight line to it clear, whatever depth the
// surfaces around it got. Those are the depths least known: a crown or a building whose ground
// contact is hidden gets one plane from the objects below it (docs/night.md §6b), and on
// aachen_000001 and _000002 that put poles seen in front of a spire or a canopy behind them.
bool head_hidden(const HeadDisc& d, const ImageF& depth_m, const ImageU16& labels, const CameraGeometry& g) {
  if (d.from_pole) {
    const int yc = static_cast<int>(std::lround(d.v));
    for (int y = std::max(0, yc); y <= std::min(labels.height() - 1, yc + 1); ++y)
      for (int x = d.x0; x <= d.x1; ++x) {
        const int id = labels.at(x, y);
        if (id == static_cast<int>(Label::Pole) || id == static_cast<int>(Label::PoleGroup)) return false;
      }
  }
  const double k = std::cos(g.pitch_rad) * kFacadeInlier_px / (g.f_px * g.mount_height_m);
  long all = 0, front = 0;
  for (int y = d.y0; y <= d.y1; ++y)
    for (int x = d.x0; x <= d.x1; ++x) {
      const int in = head_samples_in(d, x, y);
      if (!in) continue;
      all += in;
      const double zs = depth_m.at(x, y);
      if (zs + k * zs * zs < d.z) front += in;
    }
  return 2 * front > all;
}
// lamp_head_discs less the heads that depth_m (when given) hides (head_hidden).
std::vector<HeadDisc> visible_head_discs(const CameraGeometry& g, const StreetLighting& s, const ScenePreset& p, int W,
                                         int H, const ImageF* depth_m, const ImageU16& labels) {
  std::vector<HeadDisc> heads = lamp_head_discs(g, s, p, W, H);
  if (depth_m) std::erase_if(heads, [&](const HeadDisc& d) { return head_hidden(d, *depth_m, labels, g); });
  return heads;
}
int draw_lamp_heads(ImageF& L, const CameraGeometry& g, const StreetLighting& s, const ScenePreset& p,
                    const ImageF* depth_m, const ImageU16& labels) {
  int drawn = 0;
  for (const HeadDisc& d : visible_head_discs(g, s, p, L.width(), L.height(), depth_m, labels)) {
    bool any = false;
    for (int y = d.y0; y <= d.y1; ++y) any |= draw_head_row(L, d, y);
    drawn += any;
  }
  return drawn;
}
}  // namespace

namespace {
// One row's vertical-surface pixels, compacted (add_vertical_street_light's scalar path):
// column, camera z and, for façade pixels, the lit normal of their plane (plane = -1; 0: the
// normal turned to the camera, from the point), and whether it is a crown's (vegetation).
struct VerticalRow {
  std::vector<int32_t> x, plane;
  std::vector<uint8_t> crown;
  std::vector<double> z, pnX, pnD;
  std::vector<float> e;
  explicit VerticalRow(int W)
      : x(W + 8), plane(W + 8), crown(W + 8), z(W + 8), pnX(W + 8), pnD(W + 8), e(W + 8) {}
};
// The AVX2 path's eight pixels of one group of columns, as VerticalRow's fields (crown: −1 on a
// crown's lane, else 0).
struct VerticalGroup {
  alignas(32) double z[8], pnX[8], pnD[8];
  alignas(32) int32_t x[8], plane[8], crown[8];
};
// The pixel's point in road coordinates (X right, Y up, D ahead; camera foot at the origin) from
// its camera z: X = z·(x − c_x)/f, D = z·kD, Y = h − z·kY, with the row's kD = cos θ − y_n·sin θ
// and kY = y_n·cos θ + sin θ.
struct RowGeom { double cx, f, kD, kY, h; };
// The lamps as arrays, with each one's reach along the road (float: see vertical_term).
struct LampArrays {
  std::vector<double> X, Y, D;
  std::vector<float> reach;
  double max_reach = 0, max_Y = -1e300;
};
// The lamps k = lo .. hi − 1 whose D lies within max_reach (plus 1 m, so that the rounding of the
// bounds never leaves one out) of [Dmin, Dmax]: every lamp outside is beyond its own reach
// (reach_k <= max_reach) of every pixel in that range, which the per-pixel loop skips anyway,
// so the window changes nothing (the lamps are sorted by D).
inline void lamp_window(const LampArrays& la, double Dmin, double Dmax, size_t* lo, size_t* hi) {
  const double pad = la.max_reach + 1.0;
  *lo = std::lower_bound(la.D.begin(), la.D.end(), Dmin - pad) - la.D.begin();
  *hi = std::upper_bound(la.D.begin() + *lo, la.D.end(), Dmax + pad) - la.D.begin();
}
// lamp_window from the window of a nearby range (*lo, *hi: any indices in [0, n]; the groups of a
// row move along it slowly): each bound stepped down or up to the same index as the binary
// searches', lo the first lamp with D >= Dmin − pad, hi the first after it with D > Dmax + pad.
inline void lamp_window_from(const LampArrays& la, double Dmin, double Dmax, size_t* lo, size_t* hi) {
  const double pad = la.max_reach + 1.0, a = Dmin - pad, b = Dmax + pad;
  const double* D = la.D.data();
  const size_t n = la.D.size();
  size_t l = *lo, h = *hi;
  while (l > 0 && D[l - 1] >= a) --l;
  while (l < n && D[l] < a) ++l;
  if (h < l) h = l;
  while (h > l && D[h - 1] > b) --h;
  while (h < n && D[h] <= b) ++h;
  *lo = l;
  *hi = h;
}
// The pixel's point (X, Y, D) and its lit normal (nX, nY, nD) in double; ok = false where the
// camera-facing normal is undefined (X = D = 0). A crown's "normal" is the unit vector to the
// camera, (−X, h − Y, −D)/√((X² + D²) + (h − Y)²) (vertical_term's cos α).
[[gnu::always_inline]] inline bool vertical_point(const VerticalRow& r, int i, const RowGeom& q, double* X, double* Y,
                                                  double* D, double* nX, double* nY, double* nD) {
  const double zz = r.z[i];
  *X = zz * (r.x[i] - q.cx) / q.f;
  *D = zz * q.kD;
  *Y = q.h - zz * q.kY;
  *nY = 0;
  if (r.plane[i]) {
    *nX = r.pnX[i];
    *nD = r.pnD[i];
    return true;
  }
  if (r.crown[i]) {
    const double H = q.h - *Y, rr = std::sqrt((*X * *X + *D * *D) + H * H);
    if (!(rr > 0)) return false;
    *nX = -*X / rr;
    *nY = H / rr;
    *nD = -*D / rr;
    return true;
  }
  // Cars, people, poles, vegetation, walls: a vertical face turned to the camera (an
  // approximation: their own orientation is not known from the labels).
  const double rr = std::sqrt(*X * *X + *D * *D);
  if (!(rr > 0)) return false;
  *nX = -*X / rr;
  *nD = -*D / rr;
  return true;
}
// One lamp's E_v at a pixel in float32: v = lamp − point (the difference in double, rounded once),
// nothing beyond the lamp's reach along the road (|v_D| ≤ reach, both rounded to float: a pixel
// within 2⁻²³·reach of the rim may fall either side), above the luminaire (a cut-off luminaire
// emits no light upward: γ < 90°, an approximation of its upward light output ratio as 0) or on
// faces turned away; else I0·rel(γ)·(cos β)/max(d², d²_min), evaluated as rel·((cos β)·(I0·r_m))
// with r² = 1/d² and d = √d² side by side from d² (the division does not wait on the root),
// cos γ = (v_Y·r²)·d, cos β = ((n·v)·r²)·d, r_m = min(r², 1/d²_min) (= 1/max(d², d²_min) rounded:
// the reciprocal is monotone) and the pieces by Estrin's scheme (RelTable::polyf_estrin): one
// division instead of three, and from d² to the sum 13 dependent operations instead of 20 (now √,
// two products, the piece's argument 4, Estrin 5, ·rel, the sum, w made beside rel(γ); before √,
// ÷, the argument 6, Horner 8, two products, ÷, the sum). The error per term (u = 2⁻²⁴): v 1u
// each; d² = (v_X² + v_Y²) + v_D² 5u (δ); r²·d ∝ (1 + δ)^(−1/2), so δ enters cos γ and cos β as
// 2.5u, with r²'s and d's roundings 1u each and the two products 2u: cos γ = 1 + 2.5 + 1 + 1 + 2
// = 7.5u; |v|·cos β = n_X·v_X + n_D·v_D with the normal rounded 1u: (3κ + 1)u with the condition
// number κ = (|n_X·v_X| + |n_D·v_D|)/(n·v) ≥ 1 (1 for a face squarely lit); cos β: 3κ + 7.5;
// I0·r_m: I0 1 + δ 5 + r² 1 + 1 = 8u; inside the cut-off (rel = 1, its product exact) e =
// (3κ + 7.5) + 8 + 1 = 16.5 + 3κ (the former quotients' 13.5 + 3κ), beyond it + 1 (·rel) + 3 +
// 9.5·s (the table, as pool_term, its argument cos γ·(1/step) 7.5 + 1 + 1) or + 1 + 6 + 9.5·s
// (the pieces by Estrin): per term k = 20.5 + 3κ + 9.5·s (23.5 + 3κ + 9.5·s; the former 17.5 +
// 3κ + 7.5·s and 22.5 + 3κ + 7.5·s), and for the n-term sum |E_float − E| ≤ (k + n)·2⁻²⁴·E to
// first order.
// A crown pixel (crown = true; n = (nX, nY, nD) the unit vector to the camera) takes
// I(γ)·Φ(α)/d² instead, cos α = (n·v)/d with n·v = (n_X·v_X + n_D·v_D) + n_Y·v_Y, and no face
// turned away (Φ ≥ 0 on every side); crown_phase's error above adds to its terms'.
[[gnu::always_inline]] inline float vertical_term(float vX, float vY, float vD, float nX, float nY, float nD, bool crown,
                                                  float reach, float I0, float inv_d2_min, const RelTable& t) {
  if (!(std::fabs(vD) <= reach)) return 0.f;
  float cb = nX * vX + nD * vD;  // |v|·cos β
  if (crown) cb = cb + nY * vY;  // |v|·cos α
  if (!(vY > 0) || !(crown || cb > 0)) return 0.f;
  const float dv2 = (vX * vX + vY * vY) + vD * vD, dv = std::sqrt(dv2), r2 = 1.f / dv2;
  const float cg = (vY * r2) * dv, cf = (cb * r2) * dv;  // cos γ, cos β (cos α)
  const float f = crown ? crown_phase(cf) : cf;
  const float w = f * (I0 * std::min(r2, inv_d2_min));  // I0·cos β / max(d², d²_min), or I0·Φ(α) / …
  return t.atf<true>(cg) * w;                           // I(γ)·cos β / d², or I(γ)·Φ(α) / d²
}
// E_v = Σ_k vertical_term over the lamps in order, per pixel (a skipped lamp adds +0.0, which
// leaves the non-negative sum's bits unchanged). A pixel whose camera-facing normal is undefined
// gets 0.
void vertical_e_scalar(VerticalRow& r, int n, const RowGeom& q, const LampArrays& la, float I0, float inv_d2_min,
                       const RelTable& t) {
  for (int i = 0; i < n; ++i) {
    double X, Y, D, nX, nY, nD;
    r.e[i] = 0;
    if (!vertical_point(r, i, q, &X, &Y, &D, &nX, &nY, &nD)) continue;
    size_t lo, hi;
    lamp_window(la, D, D, &lo, &hi);
    const float nXf = static_cast<float>(nX), nYf = static_cast<float>(nY), nDf = static_cast<float>(nD);
    const bool crown = r.crown[i] && !r.plane[i];
    float e = 0;
    for (size_t k = lo; k < hi; ++k)
      e += vertical_term(static_cast<float>(la.X[k] - X), static_cast<float>(la.Y[k] - Y),
                         static_cast<float>(la.D[k] - D), nXf, nYf, nDf, crown, la.reach[k], I0, inv_d2_min, t);
    r.e[i] = e;
  }
}
// vertical_point for the four pixels from i0 of a VerticalGroup: the same double operations per
// lane; the normal rounded to float and the lane mask (ok) as float lanes.
__attribute__((target("avx2"), always_inline)) inline void point4(const VerticalGroup& r, int i0, const RowGeom& q,
                                                                  __m256d& X, __m256d& Y, __m256d& D, __m128& nX,
                                                                  __m128& nY, __m128& nD, __m128& ok) {
  const __m256d zerod = _mm256_setzero_pd();
  const __m256d sign = _mm256_castsi256_pd(_mm256_set1_epi64x(static_cast<int64_t>(0x8000000000000000ull)));
  const __m256d zz = _mm256_loadu_pd(&r.z[i0]);
  const __m256d xd = _mm256_cvtepi32_pd(_mm_loadu_si128(reinterpret_cast<const __m128i*>(&r.x[i0])));  // exact
  X = _mm256_div_pd(_mm256_mul_pd(zz, _mm256_sub_pd(xd, _mm256_set1_pd(q.cx))), _mm256_set1_pd(q.f));
  D = _mm256_mul_pd(zz, _mm256_set1_pd(q.kD));
  Y = _mm256_sub_pd(_mm256_set1_pd(q.h), _mm256_mul_pd(zz, _mm256_set1_pd(q.kY)));
  const __m128 pm = _mm_castsi128_ps(_mm_loadu_si128(reinterpret_cast<const __m128i*>(&r.plane[i0])));
  __m256d nXd = _mm256_loadu_pd(&r.pnX[i0]), nDd = _mm256_loadu_pd(&r.pnD[i0]), nYd = zerod;
  ok = pm;
  if (_mm_movemask_ps(pm) != 0xf) {
    const __m256d pmd = _mm256_castsi256_pd(_mm256_cvtepi32_epi64(_mm_castps_si128(pm)));
    const __m256d XX_DD = _mm256_add_pd(_mm256_mul_pd(X, X), _mm256_mul_pd(D, D));
    const __m256d rr = _mm256_sqrt_pd(XX_DD);
    __m256d okd = _mm256_or_pd(pmd, _mm256_cmp_pd(rr, zerod, _CMP_GT_OQ));
    nXd = _mm256_blendv_pd(_mm256_div_pd(_mm256_xor_pd(X, sign), rr), nXd, pmd);
    nDd = _mm256_blendv_pd(_mm256_div_pd(_mm256_xor_pd(D, sign), rr), nDd, pmd);
    const __m128i cm = _mm_loadu_si128(reinterpret_cast<const __m128i*>(&r.crown[i0]));
    if (_mm_movemask_ps(_mm_castsi128_ps(cm))) {
      // Crown lanes (never on a façade plane): the unit vector to the camera (vertical_point's).
      const __m256d cmd = _mm256_castsi256_pd(_mm256_cvtepi32_epi64(cm));
      const __m256d H = _mm256_sub_pd(_mm256_set1_pd(q.h), Y);
      const __m256d r3 = _mm256_sqrt_pd(_mm256_add_pd(XX_DD, _mm256_mul_pd(H, H)));
      okd = _mm256_blendv_pd(okd, _mm256_cmp_pd(r3, zerod, _CMP_GT_OQ), cmd);
      nXd = _mm256_blendv_pd(nXd, _mm256_div_pd(_mm256_xor_pd(X, sign), r3), cmd);
      nDd = _mm256_blendv_pd(nDd, _mm256_div_pd(_mm256_xor_pd(D, sign), r3), cmd);
      nYd = _mm256_and_pd(cmd, _mm256_div_pd(H, r3));
    }
    ok = _mm_cmp_ps(_mm256_cvtpd_ps(_mm256_and_pd(okd, _mm256_set1_pd(-1.0))), _mm_setzero_ps(), _CMP_NEQ_OQ);
  }
  nX = _mm256_cvtpd_ps(nXd);
  nY = _mm256_cvtpd_ps(nYd);
  nD = _mm256_cvtpd_ps(nDd);
}
// add_vertical_street_light's candidate test for the eight pixels from column x (id, z: the row's),
// as bits (bit k: column x + k): the class not in `dark` (bit k of the mask; ids of 64 and above
// are in no class), 0 < z < kDepthInfinity_m in float, and in double Y = h − z·kY < max_Y,
// D_lo ≤ D = z·kD ≤ D_hi (the scalar loop's operations and comparisons).
struct Candidates8 {
  __m256i mlo, mhi, one, k32;
  __m256 zero, inf;
  __m256d kD, kY, h, mY, lo, hi;
};
__attribute__((target("avx2"), always_inline)) inline int candidates8_avx2(const uint16_t* id, const float* z, int x,
                                                                           const Candidates8& c) {
  const __m256i k = _mm256_cvtepu16_epi32(_mm_loadu_si128(reinterpret_cast<const __m128i*>(id + x)));
  // Bit k of the mask: the low word shifted by k (0 for k ≥ 32), the high word by k − 32 (0
  // for k < 32, where the count wraps to a huge unsigned value, and for k ≥ 64).
  const __m256i bit = _mm256_and_si256(
      _mm256_or_si256(_mm256_srlv_epi32(c.mlo, k), _mm256_srlv_epi32(c.mhi, _mm256_sub_epi32(k, c.k32))), c.one);
  const __m256 zz = _mm256_loadu_ps(z + x);
  const __m256 zok = _mm256_and_ps(_mm256_cmp_ps(zz, c.zero, _CMP_GT_OQ), _mm256_cmp_ps(zz, c.inf, _CMP_LT_OQ));
  const int m = _mm256_movemask_ps(_mm256_andnot_ps(_mm256_castsi256_ps(_mm256_cmpeq_epi32(bit, c.one)), zok));
  if (!m) return 0;
  const __m256d z0 = _mm256_cvtps_pd(_mm256_castps256_ps128(zz)), z1 = _mm256_cvtps_pd(_mm256_extractf128_ps(zz, 1));
  const __m256d D0 = _mm256_mul_pd(z0, c.kD), Y0 = _mm256_sub_pd(c.h, _mm256_mul_pd(z0, c.kY));
  const __m256d D1 = _mm256_mul_pd(z1, c.kD), Y1 = _mm256_sub_pd(c.h, _mm256_mul_pd(z1, c.kY));
  const __m256d in0 = _mm256_and_pd(_mm256_cmp_pd(Y0, c.mY, _CMP_LT_OQ),
                                    _mm256_and_pd(_mm256_cmp_pd(D0, c.lo, _CMP_GE_OQ), _mm256_cmp_pd(D0, c.hi, _CMP_LE_OQ)));
  const __m256d in1 = _mm256_and_pd(_mm256_cmp_pd(Y1, c.mY, _CMP_LT_OQ),
                                    _mm256_and_pd(_mm256_cmp_pd(D1, c.lo, _CMP_GE_OQ), _mm256_cmp_pd(D1, c.hi, _CMP_LE_OQ)));
  return m & (_mm256_movemask_pd(in0) | _mm256_movemask_pd(in1) << 4);
}
// What the AVX2 row needs besides the row's own data.
struct VerticalCtx {
  const LampArrays* la;
  const BuildingFacades* fac;
  const RelTable* t;
  const float* tint;
  uint64_t dark;
  double D_lo, D_hi;
  float I0, inv_d2_min;  // 1/d²_min rounded to float (vertical_term)
  int building, vegetation;
};
// Candidates8 for the row (vertical_row_body's; vertical_row_avx512 makes the same test on sixteen
// lanes).
__attribute__((target("avx2"), always_inline)) inline Candidates8 candidates8_consts(const RowGeom& q,
                                                                                    const VerticalCtx& v) {
  return {_mm256_set1_epi32(static_cast<int32_t>(v.dark & 0xffffffffu)),
          _mm256_set1_epi32(static_cast<int32_t>(v.dark >> 32)),
          _mm256_set1_epi32(1),
          _mm256_set1_epi32(32),
          _mm256_setzero_ps(),
          _mm256_set1_ps(kDepthInfinity_m),
          _mm256_set1_pd(q.kD),
          _mm256_set1_pd(q.kY),
          _mm256_set1_pd(q.h),
          _mm256_set1_pd(v.la->max_Y),
          _mm256_set1_pd(v.D_lo),
          _mm256_set1_pd(v.D_hi)};
}
// One group's eight lanes (columns x .. x + 7) in gr: the candidates' (bit k of m: column x + k)
// depth and, on buildings, their façade plane (BuildingFacades::plane_index); the other lanes
// take column `fill` (a candidate's, so that their values are a real pixel's; they are dropped).
// Inside a façade (eight candidates on one building region whose eight columns take one plane:
// 45% of the groups on the bench frame) the same values without the per-lane lookups.
__attribute__((target("avx2"), always_inline)) inline void vertical_group(VerticalGroup& gr, int x, int m, int fill,
                                                                         const uint16_t* id, const float* z,
                                                                         const int32_t* reg, const VerticalCtx& v) {
  const BuildingFacades& fac = *v.fac;
  const int r0 = reg[x];
  bool one_plane = false;
  if (m == 0xff && r0 >= 0) {
    const __m256i rv = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(reg + x));
    const __m256i iv = _mm256_cvtepu16_epi32(_mm_loadu_si128(reinterpret_cast<const __m128i*>(id + x)));
    const BuildingFacades::Region& R = fac.regions[r0];
    const int c0 = x - R.x0;
    if (_mm256_movemask_epi8(_mm256_and_si256(_mm256_cmpeq_epi32(rv, _mm256_set1_epi32(r0)),
                                              _mm256_cmpeq_epi32(iv, _mm256_set1_epi32(v.building)))) == -1 &&
        c0 >= 0 && c0 + 8 <= static_cast<int>(R.column_plane.size())) {
      const int pi = R.column_plane[c0];
      const __m256i pv = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(R.column_plane.data() + c0));
      if (pi >= 0 && _mm256_movemask_epi8(_mm256_cmpeq_epi32(pv, _mm256_set1_epi32(pi))) == -1) {
        const FacadePlane& f = fac.planes[pi];
        const __m256i xv = _mm256_add_epi32(_mm256_set1_epi32(x), _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7));
        _mm256_store_si256(reinterpret_cast<__m256i*>(gr.x), xv);
        _mm256_store_si256(reinterpret_cast<__m256i*>(gr.plane), _mm256_set1_epi32(-1));
        _mm256_store_si256(reinterpret_cast<__m256i*>(gr.crown), _mm256_setzero_si256());
        const __m256 zv = _mm256_loadu_ps(z + x);
        _mm256_store_pd(gr.z, _mm256_cvtps_pd(_mm256_castps256_ps128(zv)));
        _mm256_store_pd(gr.z + 4, _mm256_cvtps_pd(_mm256_extractf128_ps(zv, 1)));
        const __m256d nx = _mm256_set1_pd(-f.nX), nd = _mm256_set1_pd(-f.nD);
        _mm256_store_pd(gr.pnX, nx);
        _mm256_store_pd(gr.pnX + 4, nx);
        _mm256_store_pd(gr.pnD, nd);
        _mm256_store_pd(gr.pnD + 4, nd);
        one_plane = true;
      }
    }
  }
  if (one_plane) return;
  // The other groups (cars, people, poles, vegetation, a region's edge, dropped lanes: more than
  // half of them on the bench frame) lane by lane, lane k at column xk (x + k for a candidate,
  // else `fill`): its depth; on a building pixel with a region, the plane of its column
  // (column_plane; -1: none); plane −1 and the lit normal −(n_X, n_D) where it has one, else 0
  // and +0.0. The lanes are built in vector registers and stored whole, as the façade groups'
  // are: point4 reads them with vector loads, which per-lane stores would stall (a load is not
  // forwarded from several smaller stores).
  const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
  const __m256i bit = _mm256_sllv_epi32(_mm256_set1_epi32(1), lane);
  const __m256i cand = _mm256_cmpeq_epi32(_mm256_and_si256(_mm256_set1_epi32(m), bit), bit);
  const __m256i xv = _mm256_blendv_epi8(_mm256_set1_epi32(fill), _mm256_add_epi32(_mm256_set1_epi32(x), lane), cand);
  const __m256i idv = _mm256_blendv_epi8(_mm256_set1_epi32(id[fill]),
                                         _mm256_cvtepu16_epi32(_mm_loadu_si128(reinterpret_cast<const __m128i*>(id + x))), cand);
  const __m256i rv = _mm256_blendv_epi8(_mm256_set1_epi32(reg[fill]),
                                        _mm256_loadu_si256(reinterpret_cast<const __m256i*>(reg + x)), cand);
  const __m256 zv = _mm256_blendv_ps(_mm256_set1_ps(z[fill]), _mm256_loadu_ps(z + x), _mm256_castsi256_ps(cand));
  _mm256_store_si256(reinterpret_cast<__m256i*>(gr.x), xv);
  _mm256_store_si256(reinterpret_cast<__m256i*>(gr.crown), _mm256_cmpeq_epi32(idv, _mm256_set1_epi32(v.vegetation)));
  _mm256_store_pd(gr.z, _mm256_cvtps_pd(_mm256_castps256_ps128(zv)));  // float to double: exact
  _mm256_store_pd(gr.z + 4, _mm256_cvtps_pd(_mm256_extractf128_ps(zv, 1)));
  int bm = _mm256_movemask_ps(_mm256_castsi256_ps(_mm256_and_si256(
      _mm256_cmpeq_epi32(idv, _mm256_set1_epi32(v.building)), _mm256_cmpgt_epi32(rv, _mm256_set1_epi32(-1)))));
  __m256i pv = _mm256_set1_epi32(-1);  // the lanes' plane indices
  while (bm) {
    const int k = __builtin_ctz(bm);
    bm &= bm - 1;
    const int xk = (m >> k & 1) ? x + k : fill;
    pv = _mm256_blendv_epi8(pv, _mm256_set1_epi32(fac.plane_of_region(reg[xk], xk)), _mm256_cmpeq_epi32(lane, _mm256_set1_epi32(k)));
  }
  const __m256i has = _mm256_cmpgt_epi32(pv, _mm256_set1_epi32(-1));
  _mm256_store_si256(reinterpret_cast<__m256i*>(gr.plane), has);  // −1 with a plane, else 0
  __m256d nx0 = _mm256_setzero_pd(), nx1 = nx0, nd0 = nx0, nd1 = nx0;
  if (_mm256_movemask_epi8(has)) {
    // −n_X and −n_D gathered from the planes (a masked lane keeps +0.0), the sign flipped: the
    // exact negation, as −f->nX.
    static_assert(sizeof(FacadePlane) % sizeof(double) == 0, "planes gathered in steps of doubles");
    const __m256i ix = _mm256_mullo_epi32(_mm256_max_epi32(pv, _mm256_setzero_si256()),
                                          _mm256_set1_epi32(static_cast<int>(sizeof(FacadePlane) / sizeof(double))));
    const __m128i i0 = _mm256_castsi256_si128(ix), i1 = _mm256_extracti128_si256(ix, 1);
    const __m256d h0 = _mm256_castsi256_pd(_mm256_cvtepi32_epi64(_mm256_castsi256_si128(has)));
    const __m256d h1 = _mm256_castsi256_pd(_mm256_cvtepi32_epi64(_mm256_extracti128_si256(has, 1)));
    const double* bX = &fac.planes[0].nX;
    const double* bD = &fac.planes[0].nD;
    const __m256d sign = _mm256_castsi256_pd(_mm256_set1_epi64x(static_cast<int64_t>(0x8000000000000000ull)));
    const __m256d zd = _mm256_setzero_pd();
    nx0 = _mm256_and_pd(h0, _mm256_xor_pd(sign, _mm256_mask_i32gather_pd(zd, bX, i0, h0, 8)));
    nx1 = _mm256_and_pd(h1, _mm256_xor_pd(sign, _mm256_mask_i32gather_pd(zd, bX, i1, h1, 8)));
    nd0 = _mm256_and_pd(h0, _mm256_xor_pd(sign, _mm256_mask_i32gather_pd(zd, bD, i0, h0, 8)));
    nd1 = _mm256_and_pd(h1, _mm256_xor_pd(sign, _mm256_mask_i32gather_pd(zd, bD, i1, h1, 8)));
  }
  _mm256_store_pd(gr.pnX, nx0);
  _mm256_store_pd(gr.pnX + 4, nx1);
  _mm256_store_pd(gr.pnD, nd0);
  _mm256_store_pd(gr.pnD + 4, nd1);
}
// add_vertical_street_light's row with AVX2, the groups of eight columns 0 .. 8⌊W/8⌋ − 1 (returns
// 8⌊W/8⌋; the rest go the scalar way): per group the candidates (candidates8_avx2; none: nothing
// to do), their points and normals (point4; the group's other lanes take the first candidate's
// column and are dropped), E_v = Σ_k vertical_term over the lamps in order per lane (the same
// float operations as vertical_e_scalar; a lamp's lanes outside its reach, above it or facing
// away masked to +0.0, and a lamp whose every lane is masked skipped: its contribution is
// exactly zero; the lamps outside the group's lamp_window are beyond reach of every lane; two
// groups side by side go through one lamp loop, lamp_sums8), then o += (t·tint)·E_v on the
// candidates with E_v > 0 (reflect8_avx2: add_reflection_scalar's operations). Each lane is its
// own pixel, so the same bits as the scalar path, where the pixels are compacted first. Ends with
// vzeroupper (see clear_upper_vector_state).
// One group's lanes for its lamp loop (lamp_sum8): points, lit normals, the lanes with a point
// (ok) and the crowns' lanes (crown).
struct LampLanes8 {
  __m256d X0, X1, Y0, Y1, D0, D1;
  __m256 nX, nY, nD, ok, crown;
};
// What the row pass (add_street_light_rows) reads after the vertical light, asked for from memory
// (prefetches) while the vertical light's groups run: its lamp loops are arithmetic (square roots
// and divisions), the memory idle meanwhile, and the reads after it came from memory one row at a
// time (perf annotate: most of the pools' reflection samples on its texture loads). The texture
// of the groups holding a ground-class lane (the pools' reflection reads it right after); with
// compose, every group's texture, the row's beam illuminance and the composed row (compose reads
// the first two and writes the third); and, where the next row is this thread's, that row of L
// (written first: zeroed by light_map's retroreflection row) and its depth (read first by the
// next vertical row). A prefetch changes no value. (Measured: docs/benchmarks.md, "Light map,
// twenty-fifth session".)
struct RowAhead {
  bool ground = false;                // the pools follow on this row: its ground groups' texture
  const float* L_next = nullptr;      // row y + 1 of L (nullptr: not this thread's, or none)
  const float* z_next = nullptr;      // row y + 1 of the depth (likewise)
  const float* composed = nullptr;    // compose follows: the row of its output (nullptr: no compose)
  const float* beam = nullptr;        // and of the beam illuminance it reads
};
// E_v = Σ_k vertical_term over the lamps lo .. hi − 1 on N groups of eight lanes (g[0 .. N − 1],
// their sums into acc[0 .. N − 1]; vertical_row_body's lamp loop): a lamp's lanes outside its
// reach, above it or (kCrown: but on a crown's lane) facing away masked to +0.0, and a lamp whose
// every lane in the N groups is masked skipped; a group none of whose lanes a lamp lights, while
// another's are, adds +0.0 on every lane. kCrown adds n_Y·v_Y to n·v on every lane (n_Y = +0.0
// off the crowns: the sum's bits stay, up to the sign of a zero, which no comparison or kept term
// sees) and takes crown_phase8 of cos α on the crowns' lanes. With N = 2 (two groups side by
// side, as vertical_row_avx512's sixteen lanes) the window lo .. hi covers both groups': a lamp
// outside a group's own window is beyond reach of each of its lanes, so each group's sum has the
// bits of its loop alone, with half as many loop turns and tests per lane (at the avx2 cap the
// vertical light's row took 1.5 times vertical_row_avx512's time).
template <bool kCrown, int N>
__attribute__((target("avx2"), always_inline)) inline void lamp_sums8(const LampArrays& la, const RelTable& t, size_t lo,
                                                                      size_t hi, const LampLanes8* g, __m256 vI0,
                                                                      __m256 vinvd2min, __m256* acc) {
  static_assert(N == 1 || N == 2, "one or two groups");
  const __m256 zero = _mm256_setzero_ps(), one = _mm256_set1_ps(1.f), vcc = _mm256_set1_ps(t.fcc);
  const __m256 absmask = _mm256_castsi256_ps(_mm256_set1_epi32(0x7fffffff));
  // Whether any lane of the N groups' masks is set.
  auto any = [](const __m256* m) __attribute__((target("avx2"), always_inline)) {
    return _mm256_movemask_ps(N == 1 ? m[0] : _mm256_or_ps(m[0], m[N - 1])) != 0;
  };
  for (int j = 0; j < N; ++j) acc[j] = zero;
  for (size_t k = lo; k < hi; ++k) {
    const __m256d lD = _mm256_broadcast_sd(&la.D[k]);
    __m256 vD[N], in_reach[N];
    for (int j = 0; j < N; ++j) {
      vD[j] = _mm256_set_m128(_mm256_cvtpd_ps(_mm256_sub_pd(lD, g[j].D1)), _mm256_cvtpd_ps(_mm256_sub_pd(lD, g[j].D0)));
      in_reach[j] = _mm256_and_ps(
          g[j].ok, _mm256_cmp_ps(_mm256_and_ps(vD[j], absmask), _mm256_broadcast_ss(&la.reach[k]), _CMP_LE_OQ));
    }
    if (!any(in_reach)) continue;
    const __m256d lX = _mm256_broadcast_sd(&la.X[k]), lY = _mm256_broadcast_sd(&la.Y[k]);
    __m256 vX[N], vY[N], cb[N], lit[N];
    for (int j = 0; j < N; ++j) {
      vX[j] = _mm256_set_m128(_mm256_cvtpd_ps(_mm256_sub_pd(lX, g[j].X1)), _mm256_cvtpd_ps(_mm256_sub_pd(lX, g[j].X0)));
      vY[j] = _mm256_set_m128(_mm256_cvtpd_ps(_mm256_sub_pd(lY, g[j].Y1)), _mm256_cvtpd_ps(_mm256_sub_pd(lY, g[j].Y0)));
      cb[j] = _mm256_add_ps(_mm256_mul_ps(g[j].nX, vX[j]), _mm256_mul_ps(g[j].nD, vD[j]));
      __m256 facing = _mm256_cmp_ps(cb[j], zero, _CMP_GT_OQ);
      if (kCrown) {
        cb[j] = _mm256_add_ps(cb[j], _mm256_mul_ps(g[j].nY, vY[j]));
        facing = _mm256_or_ps(_mm256_cmp_ps(cb[j], zero, _CMP_GT_OQ), g[j].crown);
      }
      lit[j] = _mm256_and_ps(in_reach[j], _mm256_and_ps(_mm256_cmp_ps(vY[j], zero, _CMP_GT_OQ), facing));
    }
    if (!any(lit)) continue;
    for (int j = 0; j < N; ++j) {
      const __m256 dv2 =
          _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(vX[j], vX[j]), _mm256_mul_ps(vY[j], vY[j])), _mm256_mul_ps(vD[j], vD[j]));
      const __m256 dv = _mm256_sqrt_ps(dv2), r2 = _mm256_div_ps(one, dv2);
      const __m256 cg = _mm256_mul_ps(_mm256_mul_ps(vY[j], r2), dv);
      const __m256 beyond = _mm256_and_ps(lit[j], _mm256_cmp_ps(cg, vcc, _CMP_LT_OQ));  // γ beyond the cut-off
      __m256 f = _mm256_mul_ps(_mm256_mul_ps(cb[j], r2), dv);
      if (kCrown) f = _mm256_blendv_ps(f, crown_phase8(f), g[j].crown);
      const __m256 w = _mm256_mul_ps(f, _mm256_mul_ps(vI0, _mm256_min_ps(r2, vinvd2min)));
      // rel·w; rel = 1 on every lane (1·w = w exactly) where none is beyond the cut-off.
      const __m256 ek =
          _mm256_movemask_ps(beyond) ? _mm256_mul_ps(_mm256_blendv_ps(one, rel_lerp_f<true>(t, cg), beyond), w) : w;
      acc[j] = _mm256_add_ps(acc[j], _mm256_and_ps(lit[j], ek));
    }
  }
}
// One group's lamp loop (lamp_sums8 with N = 1).
template <bool kCrown>
__attribute__((target("avx2"), always_inline)) inline __m256 lamp_sum8(const LampArrays& la, const RelTable& t, size_t lo,
                                                                      size_t hi, const LampLanes8& g, __m256 vI0,
                                                                      __m256 vinvd2min) {
  __m256 acc;
  lamp_sums8<kCrown, 1>(la, t, lo, hi, &g, vI0, vinvd2min, &acc);
  return acc;
}
// The lines holding bytes p .. p + kBytes − 1 asked for (for writing: kWrite), whatever p's offset.
// (prfchw: kWrite as PREFETCHW, which AMD's CPUs have and Intel's since Broadwell; Intel's earlier
// ones execute it as a no-op.)
template <int kBytes, int kWrite>
__attribute__((target("prfchw"), always_inline)) inline void prefetch_lines(const float* p) {
  const char* c = reinterpret_cast<const char*>(p);
  for (int o = 0; o < kBytes; o += 64) __builtin_prefetch(c + o, kWrite, 3);
  __builtin_prefetch(c + kBytes - 1, kWrite, 3);
}
// The look-ahead of one group of kGroup columns from x (RowAhead; dark: the group holds a lane of
// the classes the vertical light leaves dark, sky or ground): its texture floats, its floats of
// the next row of L and of the composed row (12·kGroup bytes each), its depths of the next row
// and beam values (4·kGroup bytes).
template <int kGroup>
__attribute__((target("prfchw"), always_inline)) inline void row_ahead(const RowAhead& ahead, int x, bool dark,
                                                                      const float* tx) {
  if (ahead.composed) {
    prefetch_lines<12 * kGroup, 1>(ahead.composed + 3 * x);
    prefetch_lines<4 * kGroup, 0>(ahead.beam + x);
  }
  if (ahead.composed || (ahead.ground && dark)) prefetch_lines<12 * kGroup, 0>(tx + 3 * x);
  if (ahead.L_next) prefetch_lines<12 * kGroup, 1>(ahead.L_next + 3 * x);
  if (ahead.z_next) prefetch_lines<4 * kGroup, 0>(ahead.z_next + x);
}
template <bool kAhead>
__attribute__((target("avx2,prfchw"), always_inline)) inline int vertical_row_body(float* o, const float* tx,
                                                                                  const uint16_t* id, const float* z,
                                                                                  const int32_t* reg, int W,
                                                                                  const RowGeom& q, const VerticalCtx& v,
                                                                                  const RowAhead& ahead) {
  const LampArrays& la = *v.la;
  const RelTable& t = *v.t;
  const Candidates8 cc = candidates8_consts(q, v);
  const Reflect8 rc = reflect8_consts(v.tint);
  const __m256 vI0 = _mm256_set1_ps(v.I0), vinvd2min = _mm256_set1_ps(v.inv_d2_min), zero = _mm256_setzero_ps();
  const __m256i lane_bit = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
  VerticalGroup gr;
  size_t win_lo = 0, win_hi = 0;  // the last lamp window
  // Group x's look-ahead (RowAhead; the dark classes' lanes as candidates8_avx2 finds them: bit k
  // of the class mask).
  auto ahead8 = [&](int x) __attribute__((target("avx2,prfchw"), always_inline)) {
    const __m256i k = _mm256_cvtepu16_epi32(_mm_loadu_si128(reinterpret_cast<const __m128i*>(id + x)));
    const __m256i bit = _mm256_and_si256(
        _mm256_or_si256(_mm256_srlv_epi32(cc.mlo, k), _mm256_srlv_epi32(cc.mhi, _mm256_sub_epi32(k, cc.k32))), cc.one);
    row_ahead<8>(ahead, x, _mm256_movemask_epi8(_mm256_cmpeq_epi32(bit, cc.one)) != 0, tx);
  };
  // Group x's lanes for the lamp loop from its candidates m (vertical_group, point4; the lanes that
  // are not candidates take the first candidate's column and are dropped), widening [Dmin, Dmax] to
  // its D range; false where no candidate has a point.
  auto lanes8 = [&](int x, int m, LampLanes8& ll, double& Dmin, double& Dmax)
                    __attribute__((target("avx2"), always_inline)) {
    vertical_group(gr, x, m, x + __builtin_ctz(m), id, z, reg, v);
    __m256d X0, X1, Y0, Y1, D0, D1;
    __m128 nXa, nXb, nYa, nYb, nDa, nDb, oka, okb;
    point4(gr, 0, q, X0, Y0, D0, nXa, nYa, nDa, oka);
    point4(gr, 4, q, X1, Y1, D1, nXb, nYb, nDb, okb);
    const __m256 cand = _mm256_castsi256_ps(
        _mm256_cmpeq_epi32(_mm256_and_si256(_mm256_set1_epi32(m), lane_bit), lane_bit));
    const __m256 ok = _mm256_and_ps(cand, _mm256_set_m128(okb, oka));
    if (!_mm256_movemask_ps(ok)) return false;
    const __m256 crown = _mm256_and_ps(ok, _mm256_load_ps(reinterpret_cast<const float*>(gr.crown)));
    const __m256d Dlo = _mm256_min_pd(D0, D1), Dhi = _mm256_max_pd(D0, D1);
    const __m256d m1 = _mm256_min_pd(Dlo, _mm256_permute2f128_pd(Dlo, Dlo, 1)), M1 = _mm256_max_pd(Dhi, _mm256_permute2f128_pd(Dhi, Dhi, 1));
    Dmin = std::min(Dmin, _mm256_cvtsd_f64(_mm256_min_pd(m1, _mm256_permute_pd(m1, 5))));
    Dmax = std::max(Dmax, _mm256_cvtsd_f64(_mm256_max_pd(M1, _mm256_permute_pd(M1, 5))));
    ll = {X0, X1, Y0, Y1, D0, D1, _mm256_set_m128(nXb, nXa), _mm256_set_m128(nYb, nYa), _mm256_set_m128(nDb, nDa), ok, crown};
    return true;
  };
  // o += (t·tint)·E_v on group x's candidates m with E_v > 0.
  auto reflect = [&](int x, int m, __m256 acc) __attribute__((target("avx2"), always_inline)) {
    const unsigned lit_px = static_cast<unsigned>(m & _mm256_movemask_ps(_mm256_cmp_ps(acc, zero, _CMP_GT_OQ)));
    if (lit_px) reflect8_avx2(o + 3 * x, tx + 3 * x, acc, lit_px, rc);
  };
  // A lone group x's lamp loop over lo .. hi (lamp_sum8, with the crowns' terms where it has a
  // crown lane) and its reflection.
  auto one_group = [&](int x, int m, const LampLanes8& ll, size_t lo, size_t hi)
                       __attribute__((target("avx2"), always_inline)) {
    reflect(x, m, _mm256_movemask_ps(ll.crown) ? lamp_sum8<true>(la, t, lo, hi, ll, vI0, vinvd2min)
                                               : lamp_sum8<false>(la, t, lo, hi, ll, vI0, vinvd2min));
  };
  int x = 0;
  // Pairs of groups (sixteen columns) through one lamp loop (lamp_sums8, N = 2) where both have a
  // candidate with a point, the window covering both; a lone group through lamp_sum8.
  for (; x + 16 <= W; x += 16) {
    if (kAhead) ahead8(x), ahead8(x + 8);
    const int m[2] = {candidates8_avx2(id, z, x, cc), candidates8_avx2(id, z, x + 8, cc)};
    if (!(m[0] | m[1])) continue;
    LampLanes8 ll[2];
    double Dmin = INFINITY, Dmax = -INFINITY;
    const bool has0 = m[0] && lanes8(x, m[0], ll[0], Dmin, Dmax), has1 = m[1] && lanes8(x + 8, m[1], ll[1], Dmin, Dmax);
    if (!has0 && !has1) continue;
    lamp_window_from(la, Dmin, Dmax, &win_lo, &win_hi);
    const size_t lo = win_lo, hi = win_hi;
    if (has0 && has1) {
      __m256 acc[2];
      if (_mm256_movemask_ps(_mm256_or_ps(ll[0].crown, ll[1].crown)))
        lamp_sums8<true, 2>(la, t, lo, hi, ll, vI0, vinvd2min, acc);
      else
        lamp_sums8<false, 2>(la, t, lo, hi, ll, vI0, vinvd2min, acc);
      reflect(x, m[0], acc[0]);
      reflect(x + 8, m[1], acc[1]);
    } else {
      const int j = has0 ? 0 : 1;
      one_group(x + 8 * j, m[j], ll[j], lo, hi);
    }
  }
  for (; x + 8 <= W; x += 8) {
    if (kAhead) ahead8(x);
    const int m = candidates8_avx2(id, z, x, cc);
    if (!m) continue;
    LampLanes8 ll;
    double Dmin = INFINITY, Dmax = -INFINITY;
    if (!lanes8(x, m, ll, Dmin, Dmax)) continue;
    lamp_window_from(la, Dmin, Dmax, &win_lo, &win_hi);
    one_group(x, m, ll, win_lo, win_hi);
  }
  _mm256_zeroupper();
  return x;
}
template <bool kAhead>
__attribute__((target("avx2,prfchw"))) int vertical_row_avx2(float* o, const float* tx, const uint16_t* id, const float* z,
                                                             const int32_t* reg, int W, const RowGeom& q,
                                                             const VerticalCtx& v, const RowAhead& ahead) {
  return vertical_row_body<kAhead>(o, tx, id, z, reg, W, q, v, ahead);
}
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"  // GCC 12's _mm512_undefined_*() (as in darken.cpp)
// reflect8_avx2 for sixteen pixels (o3, t3: their 48 floats, three vectors): the lane of pixel i
// of channel c, 3i + c, takes e_i, t_c and bit i of `bits` (the lanes' indices i in s0, s1, s2,
// the tint in tp0..2); o += (t·tint)·e on those bits, the same operations as reflect8_avx2 and
// add_reflection_scalar.
struct Reflect16 {
  __m512i s0, s1, s2;
  __m512 tp0, tp1, tp2;
};
__attribute__((target("avx512f"), always_inline)) inline Reflect16 reflect16_consts(const float* tint) {
  alignas(64) int32_t s[48];
  alignas(64) float tp[48];
  for (int l = 0; l < 48; ++l) {
    s[l] = l / 3;
    tp[l] = tint[l % 3];
  }
  return {_mm512_load_si512(s), _mm512_load_si512(s + 16), _mm512_load_si512(s + 32),
          _mm512_load_ps(tp), _mm512_load_ps(tp + 16), _mm512_load_ps(tp + 32)};
}
__attribute__((target("avx512f"), always_inline)) inline void reflect16_avx512(float* o3, const float* t3, __m512 ef,
                                                                               __mmask16 bits, const Reflect16& c) {
  const __m512i on = _mm512_maskz_set1_epi32(bits, -1);
  const __m512i s[3] = {c.s0, c.s1, c.s2};
  const __m512 tp[3] = {c.tp0, c.tp1, c.tp2};
  for (int j = 0; j < 3; ++j) {
    const __m512i lit = _mm512_permutexvar_epi32(s[j], on);
    const __mmask16 k = _mm512_test_epi32_mask(lit, lit);
    if (!k) continue;
    const __m512 ov = _mm512_loadu_ps(o3 + 16 * j);
    _mm512_mask_storeu_ps(o3 + 16 * j, k,
                          _mm512_add_ps(ov, _mm512_mul_ps(_mm512_mul_ps(_mm512_loadu_ps(t3 + 16 * j), tp[j]),
                                                          _mm512_permutexvar_ps(s[j], ef))));
  }
}
// add_reflection_avx2 sixteen pixels at a time (the pools' reflection with AVX-512): two bytes of
// bits, 48 channel floats, by reflect16_avx512 (the vertical light's: the same operations per lane
// as reflect8_avx2, the unlit lanes left by a masked store where reflect8_avx2 blends their old
// values back: the same floats); an odd last group and the row's last W mod 8 pixels as there.
// (−4 % of the pools' CPU on the Zen 5 host: docs/benchmarks.md, "Fortieth session".)
__attribute__((target("avx2,avx512f"))) void add_reflection_avx512(float* o, const float* tx, const float* e,
                                                                  const uint8_t* bits, int qa, int qb, int W,
                                                                  const float* tint) {
  const Reflect16 c = reflect16_consts(tint);
  const int qfull = std::min(qb, W / 8);
  int q = qa;
  for (; q + 2 <= qfull; q += 2) {
    const unsigned b16 = bits[q] | static_cast<unsigned>(bits[q + 1]) << 8;
    if (b16) reflect16_avx512(o + 24 * q, tx + 24 * q, _mm512_loadu_ps(e + 8 * q), static_cast<__mmask16>(b16), c);
  }
  if (q < qb) add_reflection_avx2(o, tx, e, bits, q, qb, W, tint);
  _mm256_zeroupper();
}
// −a on the lanes of `k` (the sign bit flipped: exact), a on the others (AVX-512F has no xor_pd).
__attribute__((target("avx512f"), always_inline)) inline __m512d neg_pd(__m512d a, __mmask8 k) {
  return _mm512_castsi512_pd(_mm512_mask_xor_epi64(_mm512_castpd_si512(a), k, _mm512_castpd_si512(a),
                                                   _mm512_set1_epi64(static_cast<int64_t>(0x8000000000000000ull))));
}
// Columns x .. x + 7 of a row as a group: −2 when none is a building pixel (region −1 on each),
// the façade plane when all eight lie in one building region whose eight columns take one plane,
// else −1 (the group then goes column by column).
__attribute__((target("avx2"), always_inline)) inline int window_group_plane(const int32_t* reg, int x,
                                                                             const BuildingFacades& fac) {
  const __m256i rv = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(reg + x));
  const int neg = _mm256_movemask_ps(_mm256_castsi256_ps(rv));
  if (neg == 0xff) return -2;
  const int r0 = reg[x];
  if (neg != 0 || _mm256_movemask_epi8(_mm256_cmpeq_epi32(rv, _mm256_set1_epi32(r0))) != -1) return -1;
  const BuildingFacades::Region& R = fac.regions[r0];
  const int c0 = x - R.x0;
  if (c0 < 0 || c0 + 8 > static_cast<int>(R.column_plane.size())) return -1;
  const int pi = R.column_plane[c0];
  if (pi < 0 || _mm256_movemask_epi8(_mm256_cmpeq_epi32(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(R.column_plane.data() + c0)),
                                                        _mm256_set1_epi32(pi))) != -1)
    return -1;
  return pi;
}
// One half (eight lanes, columns x .. x + 7) of vertical_row_avx512's group: the lit normals
// −(n_X, n_D) of the lanes' façade planes in double (+0.0 where a lane has none) and the mask of
// the lanes with one (has), for the candidates of `mh` (bit k: column x + k): vertical_group's
// rules (BuildingFacades::plane_index), without its stores. A half of eight candidates on one
// building region whose eight columns take one plane (window_group_plane, as the windows' layout
// tests it; 45% of the groups of eight on the bench frame) takes that plane's normal without
// per-lane lookups; otherwise each candidate building
// lane with a region looks up its column's plane, and the normals are gathered.
__attribute__((target("avx2,avx512f,avx512vl"), always_inline)) inline void facade_normals8(
    int x, unsigned mh, const uint16_t* id, const int32_t* reg, const VerticalCtx& v, __m512d& nx, __m512d& nd,
    __mmask8& has) {
  const BuildingFacades& fac = *v.fac;
  const __m256i iv = _mm256_cvtepu16_epi32(_mm_loadu_si128(reinterpret_cast<const __m128i*>(id + x)));
  const __m256i rv = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(reg + x));
  if (mh == 0xff && _mm256_movemask_epi8(_mm256_cmpeq_epi32(iv, _mm256_set1_epi32(v.building))) == -1) {
    const int pi = window_group_plane(reg, x, fac);
    if (pi >= 0) {
      const FacadePlane& f = fac.planes[pi];
      nx = _mm512_set1_pd(-f.nX);
      nd = _mm512_set1_pd(-f.nD);
      has = 0xff;
      return;
    }
  }
  unsigned bm = mh & static_cast<unsigned>(_mm256_movemask_ps(_mm256_castsi256_ps(_mm256_and_si256(
                         _mm256_cmpeq_epi32(iv, _mm256_set1_epi32(v.building)), _mm256_cmpgt_epi32(rv, _mm256_set1_epi32(-1))))));
  __m256i pv = _mm256_set1_epi32(-1);  // the lanes' plane indices
  while (bm) {
    const int k = __builtin_ctz(bm);
    bm &= bm - 1;
    pv = _mm256_mask_set1_epi32(pv, static_cast<__mmask8>(1u << k), fac.plane_of_region(reg[x + k], x + k));
  }
  has = _mm256_cmpgt_epi32_mask(pv, _mm256_set1_epi32(-1));
  nx = nd = _mm512_setzero_pd();
  if (has) {
    // −n_X and −n_D gathered from the planes (a lane without one keeps +0.0), the sign flipped:
    // the exact negation, as −f->nX.
    static_assert(sizeof(FacadePlane) % sizeof(double) == 0, "planes gathered in steps of doubles");
    const __m256i ix = _mm256_mullo_epi32(_mm256_max_epi32(pv, _mm256_setzero_si256()),
                                          _mm256_set1_epi32(static_cast<int>(sizeof(FacadePlane) / sizeof(double))));
    nx = neg_pd(_mm512_maskz_mov_pd(has, _mm512_mask_i32gather_pd(nx, has, ix, &fac.planes[0].nX, 8)), has);
    nd = neg_pd(_mm512_maskz_mov_pd(has, _mm512_mask_i32gather_pd(nd, has, ix, &fac.planes[0].nD, 8)), has);
  }
}
// One half's points (X, Y, D) and lit normals in double (vertical_point's operations per lane:
// X = z·(x − c_x)/f, the camera-facing normal −(X, D)/√(X² + D²) where the lane has no façade
// plane, on a crown's lane (crown) the unit vector to the camera), the normals rounded to float;
// ok: the lanes with a plane or with √(X² + D²) > 0 (a crown's: its √((X² + D²) + (h − Y)²) > 0).
// (Y and D come from the candidate test, which computes them with the same operations.)
__attribute__((target("avx2,avx512f,avx512vl"), always_inline)) inline void points8(
    int x, __m512d zz, const RowGeom& q, __m512d Dv, __m512d Yv, __m512d nx, __m512d nd, __mmask8 has, __mmask8 crown,
    __m512d& X, __m256& nXf, __m256& nYf, __m256& nDf, __mmask8& ok) {
  const __m512d xd = _mm512_cvtepi32_pd(_mm256_add_epi32(_mm256_set1_epi32(x), _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7)));
  X = _mm512_div_pd(_mm512_mul_pd(zz, _mm512_sub_pd(xd, _mm512_set1_pd(q.cx))), _mm512_set1_pd(q.f));
  ok = has;
  __m512d ny = _mm512_setzero_pd();
  if (has != 0xff) {
    const __m512d XX_DD = _mm512_add_pd(_mm512_mul_pd(X, X), _mm512_mul_pd(Dv, Dv));
    const __m512d rr = _mm512_sqrt_pd(XX_DD);
    ok = has | _mm512_cmp_pd_mask(rr, _mm512_setzero_pd(), _CMP_GT_OQ);
    nx = _mm512_mask_blend_pd(has, _mm512_div_pd(neg_pd(X, 0xff), rr), nx);
    nd = _mm512_mask_blend_pd(has, _mm512_div_pd(neg_pd(Dv, 0xff), rr), nd);
    if (crown) {  // never on a façade plane
      const __m512d H = _mm512_sub_pd(_mm512_set1_pd(q.h), Yv);
      const __m512d r3 = _mm512_sqrt_pd(_mm512_add_pd(XX_DD, _mm512_mul_pd(H, H)));
      ok = (ok & static_cast<__mmask8>(~crown)) | (crown & _mm512_cmp_pd_mask(r3, _mm512_setzero_pd(), _CMP_GT_OQ));
      nx = _mm512_mask_div_pd(nx, crown, neg_pd(X, 0xff), r3);
      nd = _mm512_mask_div_pd(nd, crown, neg_pd(Dv, 0xff), r3);
      ny = _mm512_maskz_div_pd(crown, H, r3);
    }
  }
  nXf = _mm512_cvtpd_ps(nx);
  nYf = _mm512_cvtpd_ps(ny);
  nDf = _mm512_cvtpd_ps(nd);
}
// lamp_sum8 on sixteen lanes (vertical_row_avx512's lamp loop; the masks as k-registers).
struct LampLanes16 {
  __m512d X0, X1, Y0, Y1, D0, D1;
  __m512 nX, nY, nD;
  __mmask16 ok, crown;
};
// lamp_sums8 on sixteen lanes (vertical_row_avx512's lamp loop; the masks as k-registers): N
// groups of sixteen (g[0 .. N − 1], their sums into acc[0 .. N − 1]) through one loop over the
// lamps lo .. hi − 1, a lamp whose every lane in the N groups is out of reach or unlit skipped.
// With N = 2 the window covers both groups' (a lamp outside a group's own window is beyond reach
// of each of its lanes, so each group's sum has the bits of its loop alone, as lamp_sums8's).
template <bool kCrown, int N>
__attribute__((target("avx2,avx512f,avx512vl"), always_inline)) inline void lamp_sums16(
    const LampArrays& la, const RelTable& t, size_t lo, size_t hi, const LampLanes16* g, __m512 vI0, __m512 vinvd2min,
    __m512* acc) {
  static_assert(N == 1 || N == 2, "one or two groups");
  const __m512 zero = _mm512_setzero_ps(), vcc = _mm512_set1_ps(t.fcc);
  for (int j = 0; j < N; ++j) acc[j] = zero;
  for (size_t k = lo; k < hi; ++k) {
    const __m512d lD = _mm512_set1_pd(la.D[k]);
    const __m512 reach = _mm512_set1_ps(la.reach[k]);
    __m512 vD[N];
    __mmask16 in_reach[N];
    for (int j = 0; j < N; ++j) {
      vD[j] = diff16(lD, g[j].D0, g[j].D1);
      in_reach[j] = _mm512_mask_cmp_ps_mask(g[j].ok, _mm512_abs_ps(vD[j]), reach, _CMP_LE_OQ);
    }
    if (!(N == 1 ? in_reach[0] : static_cast<__mmask16>(in_reach[0] | in_reach[N - 1]))) continue;
    const __m512d lX = _mm512_set1_pd(la.X[k]), lY = _mm512_set1_pd(la.Y[k]);
    __m512 vX[N], vY[N], cb[N];
    __mmask16 lit[N];
    for (int j = 0; j < N; ++j) {
      vX[j] = diff16(lX, g[j].X0, g[j].X1);
      vY[j] = diff16(lY, g[j].Y0, g[j].Y1);
      cb[j] = _mm512_add_ps(_mm512_mul_ps(g[j].nX, vX[j]), _mm512_mul_ps(g[j].nD, vD[j]));
      if (kCrown) cb[j] = _mm512_add_ps(cb[j], _mm512_mul_ps(g[j].nY, vY[j]));
      const __mmask16 up = _mm512_mask_cmp_ps_mask(in_reach[j], vY[j], zero, _CMP_GT_OQ);
      lit[j] = kCrown ? static_cast<__mmask16>(_mm512_mask_cmp_ps_mask(up, cb[j], zero, _CMP_GT_OQ) | (up & g[j].crown))
                      : _mm512_mask_cmp_ps_mask(up, cb[j], zero, _CMP_GT_OQ);
    }
    if (!(N == 1 ? lit[0] : static_cast<__mmask16>(lit[0] | lit[N - 1]))) continue;
    for (int j = 0; j < N; ++j) {
      const __m512 dv2 =
          _mm512_add_ps(_mm512_add_ps(_mm512_mul_ps(vX[j], vX[j]), _mm512_mul_ps(vY[j], vY[j])), _mm512_mul_ps(vD[j], vD[j]));
      const __m512 dv = _mm512_sqrt_ps(dv2), r2 = _mm512_div_ps(_mm512_set1_ps(1.f), dv2);
      const __m512 cg = _mm512_mul_ps(_mm512_mul_ps(vY[j], r2), dv);
      const __mmask16 beyond = _mm512_mask_cmp_ps_mask(lit[j], cg, vcc, _CMP_LT_OQ);  // γ beyond the cut-off
      __m512 f = _mm512_mul_ps(_mm512_mul_ps(cb[j], r2), dv);
      if (kCrown) f = _mm512_mask_mov_ps(f, g[j].crown, crown_phase16(f));
      const __m512 w = _mm512_mul_ps(f, _mm512_mul_ps(vI0, _mm512_min_ps(r2, vinvd2min)));
      const __m512 ek = beyond ? _mm512_mul_ps(rel_lerp16<true>(t, cg, beyond), w) : w;  // rel·w (lamp_sums8's)
      acc[j] = _mm512_add_ps(acc[j], _mm512_maskz_mov_ps(lit[j], ek));
    }
  }
}
// vertical_row_body for AVX-512: groups of sixteen columns, the lamp loop on sixteen lanes at once
// over the lamps of the group's window (the candidates' D range). Per group the candidate test
// (candidates8_avx2's operations on sixteen lanes), then each half of eight lanes' façade normals
// (facade_normals8) and points (points8) straight in 512-bit registers, the candidates' Y and D
// taken from the test; the lanes that are not candidates are computed from their own column and
// dropped (okm). Per lane the same IEEE operations in the same order as vertical_point and
// vertical_term (the differences in double rounded to float, the masks as k-registers where the
// AVX2 row ANDs with all-ones lanes: a masked lane adds +0.0 either way; no FMA contraction:
// -ffp-contract=off), so the same bits as the AVX2 and scalar paths. Columns 16⌊W/16⌋ .. W − 1 go
// the scalar way. Two groups side by side (32 columns) go through one lamp loop where both have a
// candidate with a point (lamp_sums16 with N = 2, the window covering both; as the AVX2 row's
// pairs of eight): half as many loop turns, reach and lit tests per lane, and two independent
// terms a turn for the out-of-order window, where Zen 5 runs each 512-bit operation whole (Zen 4
// split it in two halves): −4 % of the vertical light's CPU on the Zen 5 host (docs/benchmarks.md,
// "Fortieth session"). (The set-up was four of point4's quads from vertical_group's stores, the candidates as two
// groups of eight; in 512-bit registers it measured faster: docs/benchmarks.md, "Light map,
// twenty-second session".)
// (prfchw: PREFETCHW, on every CPU with AVX-512. kAhead: any look-ahead asked for; without, the
// add_vertical_street_light pass's row has none of its tests.)
template <bool kAhead>
__attribute__((target("avx2,avx512f,avx512vl,prfchw"))) int vertical_row_avx512(float* o, const float* tx,
                                                                               const uint16_t* id, const float* z,
                                                                               const int32_t* reg, int W, const RowGeom& q,
                                                                               const VerticalCtx& v, const RowAhead& ahead) {
  const LampArrays& la = *v.la;
  const RelTable& t = *v.t;
  const Reflect16 rc16 = reflect16_consts(v.tint);
  const __m512 vI0 = _mm512_set1_ps(v.I0), vinvd2min = _mm512_set1_ps(v.inv_d2_min), zero = _mm512_setzero_ps();
  // The candidate test's constants (Candidates8's).
  const __m512i mlo = _mm512_set1_epi32(static_cast<int32_t>(v.dark & 0xffffffffu));
  const __m512i mhi = _mm512_set1_epi32(static_cast<int32_t>(v.dark >> 32));
  const __m512i onei = _mm512_set1_epi32(1), k32 = _mm512_set1_epi32(32);
  const __m512 zinf = _mm512_set1_ps(kDepthInfinity_m);
  const __m512d kD = _mm512_set1_pd(q.kD), kY = _mm512_set1_pd(q.kY), hh = _mm512_set1_pd(q.h);
  const __m512d mY = _mm512_set1_pd(la.max_Y), Dlo = _mm512_set1_pd(v.D_lo), Dhi = _mm512_set1_pd(v.D_hi);
  const __m512d dinf = _mm512_set1_pd(INFINITY);
  const __m512i vveg = _mm512_set1_epi32(v.vegetation);
  size_t win_lo = 0, win_hi = 0;  // the last lamp window
  // Group x's lanes for the lamp loop (ll), its candidates (m) and their D range [Dmin, Dmax] (the
  // window of every candidate, with or without a point: vertical_row_body's); false where no
  // candidate has a point.
  auto group16 = [&](int x, LampLanes16& ll, unsigned& m, double& Dmin, double& Dmax)
                     __attribute__((target("avx2,avx512f,avx512vl,prfchw"), always_inline)) {
    // The candidate test (candidates8_avx2 on sixteen lanes): bit k of the class mask off (the
    // low word shifted by k, the high word by k − 32: 0 outside each word's range), 0 < z <
    // kDepthInfinity_m, and in double Y = h − z·kY < max_Y, D_lo ≤ D = z·kD ≤ D_hi.
    const __m512i k = _mm512_cvtepu16_epi32(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(id + x)));
    const __m512i bit = _mm512_and_si512(
        _mm512_or_si512(_mm512_srlv_epi32(mlo, k), _mm512_srlv_epi32(mhi, _mm512_sub_epi32(k, k32))), onei);
    const __m512 zf = _mm512_loadu_ps(z + x);
    if (kAhead) row_ahead<16>(ahead, x, _mm512_cmpeq_epi32_mask(bit, onei) != 0, tx);  // (RowAhead)
    const __mmask16 m0 = _mm512_mask_cmp_ps_mask(
        _mm512_mask_cmp_ps_mask(_mm512_cmpneq_epi32_mask(bit, onei), zf, zero, _CMP_GT_OQ), zf, zinf, _CMP_LT_OQ);
    if (!m0) return false;
    const __m512d z0 = _mm512_cvtps_pd(_mm512_castps512_ps256(zf));  // float to double: exact
    const __m512d z1 = _mm512_cvtps_pd(_mm256_castpd_ps(_mm512_extractf64x4_pd(_mm512_castps_pd(zf), 1)));
    const __m512d D0 = _mm512_mul_pd(z0, kD), Y0 = _mm512_sub_pd(hh, _mm512_mul_pd(z0, kY));
    const __m512d D1 = _mm512_mul_pd(z1, kD), Y1 = _mm512_sub_pd(hh, _mm512_mul_pd(z1, kY));
    const __mmask8 in0 = _mm512_mask_cmp_pd_mask(
        _mm512_mask_cmp_pd_mask(_mm512_cmp_pd_mask(Y0, mY, _CMP_LT_OQ), D0, Dlo, _CMP_GE_OQ), D0, Dhi, _CMP_LE_OQ);
    const __mmask8 in1 = _mm512_mask_cmp_pd_mask(
        _mm512_mask_cmp_pd_mask(_mm512_cmp_pd_mask(Y1, mY, _CMP_LT_OQ), D1, Dlo, _CMP_GE_OQ), D1, Dhi, _CMP_LE_OQ);
    m = m0 & (in0 | static_cast<unsigned>(in1) << 8);
    if (!m) return false;
    __m512d nx0 = _mm512_setzero_pd(), nd0 = nx0, nx1 = nx0, nd1 = nx0, X0 = nx0, X1 = nx0;
    __mmask8 has0 = 0, has1 = 0, ok0 = 0, ok1 = 0;
    __m256 nXf0 = _mm256_setzero_ps(), nDf0 = nXf0, nXf1 = nXf0, nDf1 = nXf0, nYf0 = nXf0, nYf1 = nXf0;
    const unsigned crown = m & _mm512_cmpeq_epi32_mask(k, vveg);
    if (m & 0xff) {
      facade_normals8(x, m & 0xff, id, reg, v, nx0, nd0, has0);
      points8(x, z0, q, D0, Y0, nx0, nd0, has0, static_cast<__mmask8>(crown), X0, nXf0, nYf0, nDf0, ok0);
    }
    if (m >> 8) {
      facade_normals8(x + 8, m >> 8, id, reg, v, nx1, nd1, has1);
      points8(x + 8, z1, q, D1, Y1, nx1, nd1, has1, static_cast<__mmask8>(crown >> 8), X1, nXf1, nYf1, nDf1, ok1);
    }
    const __mmask16 okm = static_cast<__mmask16>(m & (ok0 | static_cast<unsigned>(ok1) << 8));
    if (!okm) return false;
    const __mmask16 crownm = static_cast<__mmask16>(crown) & okm;
    Dmin = std::min(Dmin, _mm512_reduce_min_pd(_mm512_min_pd(_mm512_mask_mov_pd(dinf, static_cast<__mmask8>(m), D0),
                                                             _mm512_mask_mov_pd(dinf, static_cast<__mmask8>(m >> 8), D1))));
    Dmax = std::max(Dmax, _mm512_reduce_max_pd(_mm512_max_pd(_mm512_mask_mov_pd(-dinf, static_cast<__mmask8>(m), D0),
                                                             _mm512_mask_mov_pd(-dinf, static_cast<__mmask8>(m >> 8), D1))));
    ll = LampLanes16{X0, X1, Y0, Y1, D0, D1, join16(nXf0, nXf1), crownm ? join16(nYf0, nYf1) : zero, join16(nDf0, nDf1),
                     okm, crownm};
    return true;
  };
  // o += (t·tint)·E_v on group x's candidates m with E_v > 0.
  auto reflect = [&](int x, unsigned m, __m512 acc) __attribute__((target("avx2,avx512f,avx512vl"), always_inline)) {
    const unsigned lit_px = m & _mm512_cmp_ps_mask(acc, zero, _CMP_GT_OQ);
    if (lit_px) reflect16_avx512(o + 3 * x, tx + 3 * x, acc, static_cast<__mmask16>(lit_px), rc16);
  };
  // A lone group's lamp loop (with the crowns' terms where it has a crown lane) and its reflection.
  auto one_group = [&](int x, unsigned m, const LampLanes16& ll, size_t lo, size_t hi)
                       __attribute__((target("avx2,avx512f,avx512vl"), always_inline)) {
    __m512 acc;
    if (ll.crown) lamp_sums16<true, 1>(la, t, lo, hi, &ll, vI0, vinvd2min, &acc);
    else lamp_sums16<false, 1>(la, t, lo, hi, &ll, vI0, vinvd2min, &acc);
    reflect(x, m, acc);
  };
  int x = 0;
  // Pairs of groups (32 columns) through one lamp loop (lamp_sums16, N = 2) where both have a
  // candidate with a point, the window covering both; a lone group through the loop alone.
  for (; x + 32 <= W; x += 32) {
    LampLanes16 ll[2];
    unsigned m[2] = {0, 0};
    double Dmin = INFINITY, Dmax = -INFINITY;
    const bool has0 = group16(x, ll[0], m[0], Dmin, Dmax), has1 = group16(x + 16, ll[1], m[1], Dmin, Dmax);
    if (!has0 && !has1) continue;
    lamp_window_from(la, Dmin, Dmax, &win_lo, &win_hi);
    const size_t lo = win_lo, hi = win_hi;
    if (has0 && has1) {
      __m512 acc[2];
      if (ll[0].crown | ll[1].crown) lamp_sums16<true, 2>(la, t, lo, hi, ll, vI0, vinvd2min, acc);
      else lamp_sums16<false, 2>(la, t, lo, hi, ll, vI0, vinvd2min, acc);
      reflect(x, m[0], acc[0]);
      reflect(x + 16, m[1], acc[1]);
    } else {
      const int j = has0 ? 0 : 1;
      one_group(x + 16 * j, m[j], ll[j], lo, hi);
    }
  }
  for (; x + 16 <= W; x += 16) {
    LampLanes16 ll;
    unsigned m = 0;
    double Dmin = INFINITY, Dmax = -INFINITY;
    if (!group16(x, ll, m, Dmin, Dmax)) continue;
    lamp_window_from(la, Dmin, Dmax, &win_lo, &win_hi);
    one_group(x, m, ll, win_lo, win_hi);
  }
  _mm256_zeroupper();
  return x;
}
#pragma GCC diagnostic pop
}  // namespace

namespace {
// add_vertical_street_light row by row: the set-up once (the lamps as arrays, the façade planes,
// the constants), then any row on any thread with its own VerticalRow (add_vertical_street_light
// runs it over the frame; add_street_light_rows with the pools and the windows in one pass).
struct VerticalPass : LitRows {
  const ImageF& depth_m;
  // Façade pixels: the plane metric_depth took their depth from (and add_facade_windows lays its
  // windows in); its normal (n_X, n_D) points away from the camera, the lit face the other way.
  const BuildingFacades computed;
  const BuildingFacades& fac;
  LampArrays la;
  // The point-source law E = I/d² holds to 1% beyond five times the source's size (the
  // photometric "five-times rule": an on-axis Lambertian disc of diameter a gives I/(d² + a²/4));
  // nearer (the top of a lamp's own pole) d² is held at (5a)², a stated approximation that keeps
  // E finite. (The ground pools do not apply it: their d is at least the mounting height, 8-10 m
  // in the presets.) Kept as its reciprocal, 1/fl(d²_min) rounded (vertical_term's r_m).
  const float inv_d2_min;
  const double c, sn, h;
  const int building = static_cast<int>(Label::Building);
  const int vegetation = static_cast<int>(Label::Vegetation);  // crowns (vertical_term)
  // The classes that get no vertical light (sky and the ground classes) as a bit mask over the
  // label ids (all below 64); ids beyond kLabelCount are not among them.
  const uint64_t dark_classes = uint64_t{1} << static_cast<int>(Label::Sky) | label_bits(ground_classes());
  const float I0;
  // The lamps' D range widened by the largest reach and 1 m (lamp_window's rule; the lamps are
  // sorted by D).
  double D_lo = 0, D_hi = 0;
  VerticalCtx ctx{};
  const int isa = light_isa();
  VerticalPass(const ImageF& texture_, const ImageU16& labels_, const ImageF& depth_m_, const CameraGeometry& g_,
               const StreetLighting& s, const ScenePreset& p, const BuildingFacades* facades, int width)
      : LitRows(texture_, labels_, g_, p, width), depth_m(depth_m_),
        computed(facades ? BuildingFacades() : building_facades(labels_, g_, p.max_depth_m)),
        fac(facades ? *facades : computed),
        inv_d2_min(1.f / static_cast<float>(25 * p.lamp_head_diameter_m * p.lamp_head_diameter_m)),
        c(std::cos(g_.pitch_rad)), sn(std::sin(g_.pitch_rad)), h(g_.mount_height_m),
        I0(static_cast<float>(s.peak_intensity_cd)) {
    for (const auto& l : s.lamps) {
      la.X.push_back(l.X_m);
      la.Y.push_back(l.Y_m);
      la.D.push_back(l.D_m);
      la.reach.push_back(static_cast<float>(reach_m(l.Y_m, p)));
      la.max_reach = std::max(la.max_reach, reach_m(l.Y_m, p));
      la.max_Y = std::max(la.max_Y, l.Y_m);
    }
    D_lo = la.D.front() - la.max_reach - 1.0;
    D_hi = la.D.back() + la.max_reach + 1.0;
    ctx = VerticalCtx{&la, &fac, &table, tlf, dark_classes, D_lo, D_hi, I0, inv_d2_min, building, vegetation};
  }
  VerticalPass(const VerticalPass&) = delete;
  VerticalPass& operator=(const VerticalPass&) = delete;
  // Row y, with AVX2: groups of eight columns (vertical_row_avx2), the row's last W mod 8 columns
  // then as below; without: the lit pixels compacted, their points, normals and E_v over the
  // lamps (vertical_e_scalar), then the reflection into L. Each pixel's sum is its own, so rows
  // may go to any thread. With AVX2 or AVX-512, `ahead` says what the row pass reads next (RowAhead).
  void row(ImageF& L, int y, VerticalRow& r, const RowAhead& ahead = RowAhead()) const {
    const float* z = depth_m.row(y);
    const uint16_t* id = labels.row(y);
    const int32_t* reg = fac.region.row(y);
    const float* tx = texture.row(y);
    float* o = L.row(y);
    const double yn = (y - g.cy_px) / g.f_px;
    const RowGeom q{g.cx_px, g.f_px, c - yn * sn, yn * c + sn, h};
    const bool any = ahead.ground || ahead.L_next || ahead.z_next || ahead.composed;
    const int x0 = isa >= 2 ? (any ? vertical_row_avx512<true>(o, tx, id, z, reg, W, q, ctx, ahead)
                                   : vertical_row_avx512<false>(o, tx, id, z, reg, W, q, ctx, ahead))
                   : isa >= 1 ? (any ? vertical_row_avx2<true>(o, tx, id, z, reg, W, q, ctx, ahead)
                                     : vertical_row_avx2<false>(o, tx, id, z, reg, W, q, ctx, ahead))
                              : 0;
    // The pixels lit at all: not sky or ground, a finite positive depth, and a point below the
    // highest lamp and within reach of one along the road (a point at or above every lamp, v_Y ≤ 0
    // for each, or beyond every lamp's reach gets exactly nothing in vertical_term: not compacted;
    // vertical_point's D and Y).
    int n = 0;
    int32_t* xs = r.x.data();
    for (int x = x0; x < W; ++x) {
      const int k = id[x];
      if (k < 64 && (dark_classes >> k & 1)) continue;
      const float zz = z[x];
      if (!(zz > 0) || zz >= kDepthInfinity_m) continue;
      const double Dp = zz * q.kD, Yp = q.h - zz * q.kY;
      if (!(Yp < la.max_Y) || !(Dp >= D_lo && Dp <= D_hi)) continue;
      xs[n++] = x;
    }
    if (n == 0) return;
    // The candidates' depth and, on buildings, their façade plane (BuildingFacades::plane_index),
    // through local pointers.
    {
      int32_t* plane = r.plane.data();
      uint8_t* crown = r.crown.data();
      double *zs = r.z.data(), *pnX = r.pnX.data(), *pnD = r.pnD.data();
      const int count = n;
      for (int i = 0; i < count; ++i) {
        const int x = xs[i];
        const FacadePlane* f = nullptr;
        if (id[x] == building)
          if (const int pi = fac.plane_index(reg, x); pi >= 0) f = &fac.planes[pi];
        zs[i] = z[x];
        crown[i] = id[x] == vegetation;
        plane[i] = f ? -1 : 0;
        pnX[i] = f ? -f->nX : 0.0;
        pnD[i] = f ? -f->nD : 0.0;
      }
    }
    vertical_e_scalar(r, n, q, la, I0, inv_d2_min, table);
    const float* e = r.e.data();
    const float t0 = tlf[0], t1 = tlf[1], t2 = tlf[2];  // in registers (o's stores may alias tlf otherwise)
    for (int i = 0; i < n; ++i) {
      const float ef = e[i];
      if (!(ef > 0)) continue;
      const int x = xs[i];
      o[3 * x] += tx[3 * x] * t0 * ef;
      o[3 * x + 1] += tx[3 * x + 1] * t1 * ef;
      o[3 * x + 2] += tx[3 * x + 2] * t2 * ef;
    }
  }
};
}  // namespace

void add_vertical_street_light(ImageF& L, const ImageF& texture, const ImageU16& labels, const ImageF& depth_m,
                               const CameraGeometry& g, const StreetLighting& s, const ScenePreset& p,
                               const BuildingFacades* facades) {
  if (s.lamps.empty()) return;
  const VerticalPass v(texture, labels, depth_m, g, s, p, facades, L.width());
#pragma omp parallel
  {
    if (kHaveAvx) clear_upper_vector_state();  // on each thread (see clear_upper_vector_state)
    VerticalRow r(L.width());
#pragma omp for schedule(static, 8)
    for (int y = 0; y < L.height(); ++y) v.row(L, y, r);
  }
}

}  // namespace photosite::scene

namespace photosite::scene {

namespace {
// The window layout's geometry for one row (add_facade_windows): the pixel's point from its camera
// z (X = z·(x − c_x)/f, D = z·kD, Y = h − z·kY, kD and kY the row's), s along its façade, the
// storey j = ⌊Y/storey⌋, the window-pitch cell ⌊s/pitch⌋ and (ground floor) the shop unit
// ⌊s/frontage⌋. Two pane tests per pixel: a window's glass (a window_width_m × window_height_m
// opening centred in its pitch × storey cell, inset by the frame window_frame_m on every side and
// split by a central mullion window_mullion_m: two lights), and on the ground floor a shop pane
// (shop_width_m wide on the pitch, from shop_sill_m to shop_sill_m + shop_height_m). Which of the
// two a ground-floor pixel shows depends on its unit's seeded shop draw, made by the caller. The
// twins below (scalar and AVX2, four pixels a lane each) do the same IEEE double operations, so the
// same panes.
struct WindowGeom {
  double cx, f, kD, kY, h;
  double storey, pitch, frontage, half_pitch;
  double half_glass_width, half_storey, half_glass_height, half_mullion;  // frame and mullion taken off
  double half_shop, sill, sill_top;
  double inv_storey, inv_pitch, inv_frontage;  // 1/storey, 1/pitch, 1/frontage (window_block_avx512's floors)
};
// One row's building pixels with a façade plane, compacted: column, the plane's along-façade axis
// (tX, tD) and camera z; out: kind (bit 1: in a window's glass; bit 2: in a shop pane, ground floor
// only; 0: neither), and where kind ≠ 0 the storey j, the pitch cell and (j = 0) the shop unit.
// Padded to a multiple of 4 (kind to 8: read a word at a time).
struct WindowRow {
  std::vector<int32_t> x, j;
  std::vector<double> z, tX, tD, so;
  std::vector<int64_t> cell, unit;
  std::vector<uint8_t> kind;
  explicit WindowRow(int W)
      : x(W + 4), j(W + 4), z(W + 4), tX(W + 4), tD(W + 4), so(W + 4), cell(W + 4), unit(W + 4), kind(W + 8) {}
  void pad(int n) {
    for (int i = n; i % 4; ++i) x[i] = x[n - 1], z[i] = z[n - 1], tX[i] = tX[n - 1], tD[i] = tD[n - 1], so[i] = so[n - 1];
  }
};
void window_geom_scalar(WindowRow& r, int n, const WindowGeom& w) {
  for (int i = 0; i < n; ++i) {
    r.kind[i] = 0;
    const double zz = r.z[i], X = zz * (r.x[i] - w.cx) / w.f, D = zz * w.kD, Y = w.h - zz * w.kY;
    if (Y < 0) continue;
    // Along the façade (m) from the camera's foot, and from the world's origin (the grid's).
    const double s = r.tX[i] * X + r.tD[i] * D, sw = s + r.so[i];
    const int j = static_cast<int>(std::floor(Y / w.storey));
    const double y_in = Y - j * w.storey;
    const int64_t c = static_cast<int64_t>(std::floor(sw / w.pitch));
    const double ds = std::fabs(sw - c * w.pitch - w.half_pitch);
    const bool glass = !(ds > w.half_glass_width || std::fabs(y_in - w.half_storey) > w.half_glass_height ||
                         ds < w.half_mullion);
    const bool pane = j == 0 && !(ds > w.half_shop || y_in < w.sill || y_in > w.sill_top);
    r.kind[i] = static_cast<uint8_t>((glass ? 1 : 0) | (pane ? 2 : 0));
    if (!r.kind[i]) continue;
    r.j[i] = j;
    r.cell[i] = c;
    if (j == 0) r.unit[i] = static_cast<int64_t>(std::floor(sw / w.frontage));
  }
}
// window_geom_scalar four pixels at a time: the floors as doubles (exact integers; j·storey and
// c·pitch then equal the scalar's int→double products for |j| < 2³¹, |c| < 2⁶³: the points lie
// within max_depth of the camera), converted to integers only for the pane pixels (the same
// conversions as the scalar's). The shop unit ⌊s/frontage⌋ only where a ground-floor lane is in
// either pane.
// Four lanes' bits (bit k of the index) as the bytes of a little-endian word (byte k: 0 or 1).
constexpr uint32_t kLaneBytes[16] = {0x00000000, 0x00000001, 0x00000100, 0x00000101, 0x00010000, 0x00010001,
                                     0x00010100, 0x00010101, 0x01000000, 0x01000001, 0x01000100, 0x01000101,
                                     0x01010000, 0x01010001, 0x01010100, 0x01010101};
// With the day photo's windows (found: its planes, BuildingFacades::planes' indices; nullptr
// without), a pane lane (bit k of `in`) in a column its plane (plane[k]) has resolved leaves the
// panes (kind 0): WindowPass::photo_resolved's test from the lane's s (along_plane's operations,
// in its order), the same cell ⌊(s − s0)·(1/kCell_m)⌋ and ordered tests, the table read for the
// lanes in range only. The draw loop took these steps pixel by pixel, with X's division again, a
// floor and two branches (window_block_avx512 filters its lanes the same way). The lanes of one
// plane at a time (a quad holds one plane but where the candidates pass from one façade to the next).
__attribute__((target("avx2"), always_inline)) inline int resolved_lanes4(__m256d s, int in, const int32_t* plane,
                                                                          const FacadeWindowsFound::Plane* found) {
  const __m256d inv_cell = _mm256_set1_pd(1 / FacadeWindowsFound::kCell_m);
  const __m128i pl = _mm_loadu_si128(reinterpret_cast<const __m128i*>(plane));
  int res = 0;
  for (int todo = in; todo;) {
    const int pi = plane[std::countr_zero(static_cast<unsigned>(todo))];
    const int same = todo & _mm_movemask_ps(_mm_castsi128_ps(_mm_cmpeq_epi32(pl, _mm_set1_epi32(pi))));
    todo &= ~same;
    const FacadeWindowsFound::Plane& F = found[pi];
    if (!F.used) continue;
    const __m256d ci = _mm256_floor_pd(_mm256_mul_pd(_mm256_sub_pd(s, _mm256_set1_pd(F.s0)), inv_cell));
    const int in_range = same & _mm256_movemask_pd(_mm256_cmp_pd(ci, _mm256_setzero_pd(), _CMP_GE_OQ)) &
                         _mm256_movemask_pd(_mm256_cmp_pd(ci, _mm256_set1_pd(F.ns), _CMP_LT_OQ));
    if (!in_range) continue;
    alignas(16) int32_t idx[4];
    _mm_store_si128(reinterpret_cast<__m128i*>(idx), _mm256_cvttpd_epi32(ci));  // (read for in_range only)
    const uint8_t* tab = F.resolved.data();
    for (int k = 0; k < 4; ++k) res |= ((in_range >> k & 1) && tab[idx[k]] != 0) << k;
  }
  return res;
}
__attribute__((target("avx2"), always_inline)) inline void window_geom_body(WindowRow& r, int n, const WindowGeom& w,
                                                                           const int32_t* plane,
                                                                           const FacadeWindowsFound::Plane* found) {
  const __m256d cx = _mm256_set1_pd(w.cx), f = _mm256_set1_pd(w.f), kD = _mm256_set1_pd(w.kD), kY = _mm256_set1_pd(w.kY),
                h = _mm256_set1_pd(w.h), storey = _mm256_set1_pd(w.storey), pitch = _mm256_set1_pd(w.pitch),
                frontage = _mm256_set1_pd(w.frontage), half_pitch = _mm256_set1_pd(w.half_pitch),
                half_glass_width = _mm256_set1_pd(w.half_glass_width), half_storey = _mm256_set1_pd(w.half_storey),
                half_glass_height = _mm256_set1_pd(w.half_glass_height), half_mullion = _mm256_set1_pd(w.half_mullion),
                half_shop = _mm256_set1_pd(w.half_shop), sill = _mm256_set1_pd(w.sill), sill_top = _mm256_set1_pd(w.sill_top),
                zero = _mm256_setzero_pd();
  const __m256d absmask = _mm256_castsi256_pd(_mm256_set1_epi64x(0x7fffffffffffffffll));
  for (int i = 0; i < n; i += 4) {
    const __m256d zz = _mm256_loadu_pd(&r.z[i]);
    const __m256d xd = _mm256_cvtepi32_pd(_mm_loadu_si128(reinterpret_cast<const __m128i*>(&r.x[i])));  // exact
    const __m256d X = _mm256_div_pd(_mm256_mul_pd(zz, _mm256_sub_pd(xd, cx)), f);
    const __m256d D = _mm256_mul_pd(zz, kD), Y = _mm256_sub_pd(h, _mm256_mul_pd(zz, kY));
    const __m256d s = _mm256_add_pd(_mm256_mul_pd(_mm256_loadu_pd(&r.tX[i]), X), _mm256_mul_pd(_mm256_loadu_pd(&r.tD[i]), D));
    const __m256d sw = _mm256_add_pd(s, _mm256_loadu_pd(&r.so[i]));  // from the world's origin
    const __m256d jd = _mm256_floor_pd(_mm256_div_pd(Y, storey));
    const __m256d y_in = _mm256_sub_pd(Y, _mm256_mul_pd(jd, storey));
    const __m256d cd = _mm256_floor_pd(_mm256_div_pd(sw, pitch));
    const __m256d ds = _mm256_and_pd(_mm256_sub_pd(_mm256_sub_pd(sw, _mm256_mul_pd(cd, pitch)), half_pitch), absmask);
    // The scalar's tests (ordered comparisons: a NaN fails none there either).
    const __m256d below = _mm256_cmp_pd(Y, zero, _CMP_LT_OQ);
    const __m256d ground_floor = _mm256_cmp_pd(jd, zero, _CMP_EQ_OQ);
    const __m256d out_glass = _mm256_or_pd(
        _mm256_or_pd(_mm256_cmp_pd(ds, half_glass_width, _CMP_GT_OQ), _mm256_cmp_pd(ds, half_mullion, _CMP_LT_OQ)),
        _mm256_cmp_pd(_mm256_and_pd(_mm256_sub_pd(y_in, half_storey), absmask), half_glass_height, _CMP_GT_OQ));
    const __m256d out_shop = _mm256_or_pd(_mm256_cmp_pd(ds, half_shop, _CMP_GT_OQ),
                                          _mm256_or_pd(_mm256_cmp_pd(y_in, sill, _CMP_LT_OQ), _mm256_cmp_pd(y_in, sill_top, _CMP_GT_OQ)));
    const int not_below = ~_mm256_movemask_pd(below) & 0xf, gf = _mm256_movemask_pd(ground_floor);
    int glass = ~_mm256_movemask_pd(out_glass) & not_below, pane = ~_mm256_movemask_pd(out_shop) & not_below & gf;
    // (The lanes past n, r.pad's copies, have no plane of their own: not tested.)
    if (const int in = (glass | pane) & (n - i >= 4 ? 0xf : (1 << (n - i)) - 1); found && in) {
      const int res = resolved_lanes4(s, in, plane + i, found);
      glass &= ~res;
      pane &= ~res;
    }
    // Without a branch on the lanes' panes (they change every few quads along a row: a
    // mispredicted branch there exposed the divisions' latency): the four kinds in one store, and
    // the storey, cell and (a ground-floor lane in the quad) unit of every lane, read only where
    // the kind is not 0 (there the scalar's conversions, the same truncations).
    const uint32_t kinds = kLaneBytes[glass] | kLaneBytes[pane] << 1;
    std::memcpy(&r.kind[i], &kinds, 4);
    _mm_storeu_si128(reinterpret_cast<__m128i*>(&r.j[i]), _mm256_cvttpd_epi32(jd));
    alignas(32) double cv[4];
    _mm256_store_pd(cv, cd);
    for (int k = 0; k < 4; ++k) r.cell[i + k] = static_cast<int64_t>(cv[k]);
    if (gf & (glass | pane)) {
      alignas(32) double uv[4];
      _mm256_store_pd(uv, _mm256_floor_pd(_mm256_div_pd(sw, frontage)));
      for (int k = 0; k < 4; ++k) r.unit[i + k] = static_cast<int64_t>(uv[k]);
    }
  }
}
__attribute__((target("avx2"))) void window_geom_avx2(WindowRow& r, int n, const WindowGeom& w, const int32_t* plane,
                                                     const FacadeWindowsFound::Plane* found) {
  window_geom_body(r, n, w, plane, found);
}
// The same compiled for AVX-512VL (its sixteen constants and the lanes' values in 32 registers;
// the same operations, no FMA contraction: the same panes).
__attribute__((target("avx2,avx512f,avx512vl"))) void window_geom_avx512(WindowRow& r, int n, const WindowGeom& w,
                                                                        const int32_t* plane,
                                                                        const FacadeWindowsFound::Plane* found) {
  window_geom_body(r, n, w, plane, found);
}
// A façade plane's horizontal unit vector along it (in the frame's road coordinates), the
// coordinate along it of the camera's foot measured from the world's origin (s0: the grid's cells
// and shop units are laid out from the world's origin, so they stay on the façade when the camera
// moves), and the key of its lit draws (add_facade_windows).
struct FacadeFrame { double tX, tD, s0; uint64_t key; };
// Pixel x of the row as a window candidate (a building pixel with a plane, z ≤ zmax): its column,
// z, plane axis, plane offset and plane index appended at n.
[[gnu::always_inline]] inline void window_candidate(int x, const int32_t* reg, const float* z, double zmax,
                                                    const BuildingFacades& fac, const FacadeFrame* fr, int32_t* rx,
                                                    double* rz, double* rtX, double* rtD, double* rso, int32_t* rp,
                                                    int& n) {
  if (reg[x] < 0 || z[x] > zmax) return;
  const int pi = fac.plane_of_region(reg[x], x);
  if (pi < 0) return;
  rx[n] = x;
  rz[n] = z[x];
  rtX[n] = fr[pi].tX;
  rtD[n] = fr[pi].tD;
  rso[n] = fr[pi].s0;
  rp[n] = pi;
  ++n;
}
// add_facade_windows's compaction of columns x0 .. x1 − 1 of a row (its scalar loop: a building pixel with a plane and
// z ≤ zmax gets column, z, the plane's axis and index) with AVX2: eight columns of one building
// region whose eight columns take one plane and whose depths are all within zmax (inside a façade:
// most groups) by vector loads and stores, groups of no building pixel skipped (on their labels
// id first, as window_block_avx512 does: no region without a building label), other groups and
// the last (x1 − x0) mod 8 columns one by one. The same entries in the same order. Returns their count.
__attribute__((target("avx2"))) int window_candidates_avx2(const int32_t* reg, const float* z, int x0, int x1, double zmax,
                                                          const BuildingFacades& fac, const FacadeFrame* fr,
                                                          WindowRow& r, int32_t* rp, const uint16_t* id) {
  int32_t* rx = r.x.data();
  double *rz = r.z.data(), *rtX = r.tX.data(), *rtD = r.tD.data(), *rso = r.so.data();
  int n = 0;
  auto one = [&](int x) { window_candidate(x, reg, z, zmax, fac, fr, rx, rz, rtX, rtD, rso, rp, n); };
  const __m256d vzmax = _mm256_set1_pd(zmax);
  const __m128i building = _mm_set1_epi16(static_cast<int16_t>(Label::Building));
  int x = x0;
  for (; x + 8 <= x1; x += 8) {
    if (_mm_movemask_epi8(_mm_cmpeq_epi16(_mm_loadu_si128(reinterpret_cast<const __m128i*>(id + x)), building)) == 0)
      continue;
    const int pi = window_group_plane(reg, x, fac);
    if (pi == -2) continue;  // no building region
    if (pi >= 0) {
      const __m256 zv = _mm256_loadu_ps(z + x);
      const __m256d z0 = _mm256_cvtps_pd(_mm256_castps256_ps128(zv)), z1 = _mm256_cvtps_pd(_mm256_extractf128_ps(zv, 1));
      if (!(_mm256_movemask_pd(_mm256_cmp_pd(z0, vzmax, _CMP_GT_OQ)) | _mm256_movemask_pd(_mm256_cmp_pd(z1, vzmax, _CMP_GT_OQ)))) {
        _mm256_storeu_si256(reinterpret_cast<__m256i*>(rx + n),
                            _mm256_add_epi32(_mm256_set1_epi32(x), _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7)));
        _mm256_storeu_si256(reinterpret_cast<__m256i*>(rp + n), _mm256_set1_epi32(pi));
        _mm256_storeu_pd(rz + n, z0);
        _mm256_storeu_pd(rz + n + 4, z1);
        const __m256d tX = _mm256_set1_pd(fr[pi].tX), tD = _mm256_set1_pd(fr[pi].tD);
        _mm256_storeu_pd(rtX + n, tX);
        _mm256_storeu_pd(rtX + n + 4, tX);
        _mm256_storeu_pd(rtD + n, tD);
        _mm256_storeu_pd(rtD + n + 4, tD);
        const __m256d so = _mm256_set1_pd(fr[pi].s0);
        _mm256_storeu_pd(rso + n, so);
        _mm256_storeu_pd(rso + n + 4, so);
        n += 8;
        continue;
      }
    }
    for (int k = 0; k < 8; ++k) one(x + k);
  }
  for (; x < x1; ++x) one(x);
  _mm256_zeroupper();
  return n;
}
// A block's candidates in a pane (kind ≠ 0) only, as add_facade_windows draws them: column,
// plane, storey, kind, and the floors of the pitch cell and (ground floor) the shop unit as
// doubles (the draw converts them with the scalar's truncation). Sized for a block plus one
// group's compressed stores.
struct WindowPanes {
  std::vector<int32_t> x, plane, j, kind;
  std::vector<double> cell, unit;
  explicit WindowPanes(int n) : x(n + 16), plane(n + 16), j(n + 16), kind(n + 16), cell(n + 16), unit(n + 16) {}
};
// The compaction and the geometry of columns x0 .. x1 − 1 fused, eight lanes of double in one
// AVX-512 register: a group of eight columns of one building region and one façade plane with
// every depth within zmax (window_candidates_avx2's fast case, most groups inside a façade) is
// laid out straight from the depth row, without storing its candidates, and only its lanes in a
// pane are appended to P (compressed stores; most façade pixels are in none). The lanes' operations
// are window_geom_scalar's, in its order (the column as an exact double, the divisions, floors by
// rounding toward −∞, the ordered comparisons): the same panes, storeys, cells and units. Every
// other group and the last (x1 − x0) mod 8 columns go to the candidates in r and rp as
// window_candidate compacts them (*n_slow of them), for window_geom_avx512 after. Returns the
// count appended to P. Each pane's draw is a function of its key alone, so drawing P's entries and
// then the rest, instead of in column order, draws the same windows.
// |v| on eight lanes (the sign bit cleared: fabs).
__attribute__((target("avx2,avx512f,avx512vl"), always_inline)) inline __m512d fabs8(__m512d v, __m512i absmask) {
  return _mm512_castsi512_pd(_mm512_and_si512(_mm512_castpd_si512(v), absmask));
}
// ⌊a/b⌋ on eight lanes with the quotient a/b rounded as a division rounds it, from q' = a·(1/b)
// (inv_b = 1/b rounded) instead of the division (one AVX-512 division of doubles takes 16
// cycles of the divider for eight lanes). With u = 2⁻⁵³: |q' − a/b| <= 2u·|a/b| (two roundings,
// to second order) and the division's q = RN(a/b) has |q − a/b| <= u·|a/b|. Where q' lies more
// than 8u·|q'| from its nearest integer n, a/b (within 2u·|a/b| of q', and 8u·|q'| >= 7u·|a/b|) and
// q (within u·|a/b| of a/b) lie on q''s side of n, strictly, and no other integer is nearer:
// ⌊q⌋ = ⌊q'⌋. A lane nearer an integer (probability ~10⁻¹⁴ a lane), a NaN or a zero: the
// division itself, for the eight lanes.
__attribute__((target("avx2,avx512f,avx512vl"), always_inline)) inline __m512d floor_div8(__m512d a, double b, double inv_b,
                                                                                         __m512i absmask) {
  constexpr int kFloor = _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC, kNearest = _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC;
  const __m512d q = _mm512_mul_pd(a, _mm512_set1_pd(inv_b));
  const __m512d off = fabs8(_mm512_sub_pd(q, _mm512_roundscale_pd(q, kNearest)), absmask);
  if (_mm512_cmp_pd_mask(off, _mm512_mul_pd(fabs8(q, absmask), _mm512_set1_pd(0x1p-50)), _CMP_GT_OQ) != 0xff)
    return _mm512_roundscale_pd(_mm512_div_pd(a, _mm512_set1_pd(b)), kFloor);
  return _mm512_roundscale_pd(q, kFloor);
}
__attribute__((target("avx2,avx512f,avx512vl"))) void floor_div_avx512(const double* a, int n, double b, double* out) {
  const __m512i absmask = _mm512_set1_epi64(0x7fffffffffffffffll);
  const double inv_b = 1.0 / b;
  for (int i = 0; i < n; i += 8) {
    const __mmask8 m = static_cast<__mmask8>(n - i >= 8 ? 0xff : (1u << (n - i)) - 1);
    // (The lanes past n as 1: a value of no concern to the floors of the others.)
    const __m512d v = _mm512_mask_loadu_pd(_mm512_set1_pd(1.0), m, a + i);
    _mm512_mask_storeu_pd(out + i, m, floor_div8(v, b, inv_b, absmask));
  }
}
// v on eight lanes.
__attribute__((target("avx2,avx512f,avx512vl"), always_inline)) inline __m512d bcast8(double v) { return _mm512_set1_pd(v); }
__attribute__((target("avx2,avx512f,avx512vl"))) int window_block_avx512(const int32_t* reg, const float* z, int x0, int x1,
                                                                          double zmax, const BuildingFacades& fac,
                                                                          const FacadeFrame* fr, const WindowGeom& w,
                                                                          WindowRow& r, int32_t* rp, int* n_slow,
                                                                          WindowPanes& P,
                                                                          const FacadeWindowsFound::Plane* found,
                                                                          const uint16_t* id) {
  int32_t* rx = r.x.data();
  double *rz = r.z.data(), *rtX = r.tX.data(), *rtD = r.tD.data(), *rso = r.so.data();
  int n = 0, np = 0;
  auto one = [&](int x) { window_candidate(x, reg, z, zmax, fac, fr, rx, rz, rtX, rtD, rso, rp, n); };
  // (The preset's numbers broadcast where used: AVX-512 reads them as memory operands.)
  const __m512d zero = _mm512_setzero_pd(), iota = _mm512_setr_pd(0, 1, 2, 3, 4, 5, 6, 7);
  const __m512i absmask = _mm512_set1_epi64(0x7fffffffffffffffll);
  const __m256i iota32 = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7), one32 = _mm256_set1_epi32(1), two32 = _mm256_set1_epi32(2);
  const __m128i building = _mm_set1_epi16(static_cast<int16_t>(Label::Building));
  int x = x0;
  for (; x + 8 <= x1; x += 8) {
    // A group of no building label has no building region (the façades are made of these labels:
    // a region's runs are building pixels): skipped on the 16 bytes of its labels, which the row's
    // street light has just read, instead of the 32 of its region ids (most groups: the region
    // image, 8 MB a frame, was the pass's largest wait, perf annotate, twenty-fourth session).
    if (_mm_movemask_epi8(_mm_cmpeq_epi16(_mm_loadu_si128(reinterpret_cast<const __m128i*>(id + x)), building)) == 0)
      continue;
    const int pi = window_group_plane(reg, x, fac);
    if (pi == -2) continue;  // no building region
    if (pi >= 0) {
      const __m512d zz = _mm512_cvtps_pd(_mm256_loadu_ps(z + x));  // exact
      if (_mm512_cmp_pd_mask(zz, bcast8(zmax), _CMP_GT_OQ) == 0) {
        const __m512d xd = _mm512_add_pd(_mm512_set1_pd(x), iota);  // exact integers
        const __m512d X = _mm512_div_pd(_mm512_mul_pd(zz, _mm512_sub_pd(xd, bcast8(w.cx))), bcast8(w.f));
        const __m512d D = _mm512_mul_pd(zz, bcast8(w.kD)), Y = _mm512_sub_pd(bcast8(w.h), _mm512_mul_pd(zz, bcast8(w.kY)));
        const __m512d s = _mm512_add_pd(_mm512_mul_pd(_mm512_set1_pd(fr[pi].tX), X), _mm512_mul_pd(_mm512_set1_pd(fr[pi].tD), D));
        const __m512d sw = _mm512_add_pd(s, _mm512_set1_pd(fr[pi].s0));  // from the world's origin
        const __m512d jd = floor_div8(Y, w.storey, w.inv_storey, absmask);
        const __m512d y_in = _mm512_sub_pd(Y, _mm512_mul_pd(jd, bcast8(w.storey)));
        const __m512d cd = floor_div8(sw, w.pitch, w.inv_pitch, absmask);
        const __m512d ds = fabs8(_mm512_sub_pd(_mm512_sub_pd(sw, _mm512_mul_pd(cd, bcast8(w.pitch))), bcast8(w.half_pitch)), absmask);
        const __mmask8 not_below = static_cast<__mmask8>(~_mm512_cmp_pd_mask(Y, zero, _CMP_LT_OQ));
        const __mmask8 gf = _mm512_cmp_pd_mask(jd, zero, _CMP_EQ_OQ);
        const __mmask8 out_glass = _mm512_cmp_pd_mask(ds, bcast8(w.half_glass_width), _CMP_GT_OQ) |
                                   _mm512_cmp_pd_mask(ds, bcast8(w.half_mullion), _CMP_LT_OQ) |
                                   _mm512_cmp_pd_mask(fabs8(_mm512_sub_pd(y_in, bcast8(w.half_storey)), absmask), bcast8(w.half_glass_height), _CMP_GT_OQ);
        const __mmask8 out_shop = _mm512_cmp_pd_mask(ds, bcast8(w.half_shop), _CMP_GT_OQ) | _mm512_cmp_pd_mask(y_in, bcast8(w.sill), _CMP_LT_OQ) |
                                  _mm512_cmp_pd_mask(y_in, bcast8(w.sill_top), _CMP_GT_OQ);
        const __mmask8 glass = static_cast<__mmask8>(~out_glass & not_below);
        const __mmask8 pane = static_cast<__mmask8>(~out_shop & not_below & gf);
        __mmask8 in = glass | pane;
        if (in == 0) continue;
        // Where the photo resolves this plane's column (WindowPass::photo_resolved: its windows
        // replace the grid's there), the lane leaves P: the same s (along_plane's operations, in
        // its order), the same cell ⌊(s − s0)·(1/kCell_m)⌋ and ordered tests, the table read for
        // the lanes in range only (the others read cell 0 and are masked off). Before, each of P's
        // pixels took these steps in the draw loop, scalar, with a division and two branches that
        // mispredict along a row (perf annotate, twenty-fourth session).
        if (found && found[pi].used) {
          const FacadeWindowsFound::Plane& F = found[pi];
          const __m512d ci = _mm512_roundscale_pd(
              _mm512_mul_pd(_mm512_sub_pd(s, bcast8(F.s0)), bcast8(1 / FacadeWindowsFound::kCell_m)),
              _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC);
          const __mmask8 in_range = static_cast<__mmask8>(
              in & _mm512_cmp_pd_mask(ci, zero, _CMP_GE_OQ) & _mm512_cmp_pd_mask(ci, bcast8(F.ns), _CMP_LT_OQ));
          if (in_range) {  // (then ns >= 1: cell 0 exists)
            alignas(32) int32_t idx[8];
            _mm256_store_si256(reinterpret_cast<__m256i*>(idx), _mm512_maskz_cvttpd_epi32(in_range, ci));
            const uint8_t* res = F.resolved.data();
            unsigned resolved = 0;
            for (int k = 0; k < 8; ++k) resolved |= static_cast<unsigned>(res[idx[k]] != 0) << k;
            in &= static_cast<__mmask8>(~(resolved & in_range));
            if (in == 0) continue;
          }
        }
        // Compressed in registers, then stored whole (P has room for a group past its count): a
        // compress with a memory destination is microcoded on AMD Zen 4, several times slower.
        _mm256_storeu_si256(reinterpret_cast<__m256i*>(P.x.data() + np),
                            _mm256_maskz_compress_epi32(in, _mm256_add_epi32(_mm256_set1_epi32(x), iota32)));
        _mm256_storeu_si256(reinterpret_cast<__m256i*>(P.plane.data() + np), _mm256_set1_epi32(pi));
        _mm256_storeu_si256(reinterpret_cast<__m256i*>(P.j.data() + np), _mm256_maskz_compress_epi32(in, _mm512_cvttpd_epi32(jd)));
        _mm256_storeu_si256(
            reinterpret_cast<__m256i*>(P.kind.data() + np),
            _mm256_maskz_compress_epi32(in, _mm256_or_si256(_mm256_maskz_mov_epi32(glass, one32), _mm256_maskz_mov_epi32(pane, two32))));
        _mm512_storeu_pd(P.cell.data() + np, _mm512_maskz_compress_pd(in, cd));
        if (gf & in)
          _mm512_storeu_pd(P.unit.data() + np, _mm512_maskz_compress_pd(in, floor_div8(sw, w.frontage, w.inv_frontage, absmask)));
        np += __builtin_popcount(in);
        continue;
      }
    }
    for (int k = 0; k < 8; ++k) one(x + k);
  }
  for (; x < x1; ++x) one(x);
  _mm256_zeroupper();
  *n_slow = n;
  return np;
}
}  // namespace

namespace {
// add_facade_windows row by row: the set-up once (the façade planes' frames and draw keys, the
// window colours), then any row on any thread with its own scratch, whose `seen` collects the
// keys of the lit windows drawn (add_facade_windows runs it over the frame; add_street_light_rows
// after the street light in one pass over the rows).
struct WindowPass {
  static constexpr int kWindowBlock = 256;  // columns a step (a multiple of 8: the same groups)
  const ImageU16& labels;
  const ImageF& depth_m;
  const CameraGeometry& g;
  const ScenePreset& p;
  const uint64_t seed;
  const int W;
  const double c, sn, h;
  const double max_z;  // footprint z/f <= width/2
  // Each building pixel's façade: the plane fitted to its region's ground contacts (or the
  // region's unfitted plane), the same that gave metric_depth its depth.
  const BuildingFacades computed;
  const BuildingFacades& fac;
  // Per plane: the horizontal unit vector along it, oriented by its direction in the world (the
  // sequence's first frame's road coordinates: toward increasing D there; a plane facing that
  // frame squarely runs toward +X), the camera foot's coordinate along it from the world's origin
  // (the grid's cells are counted from there), and the key of its lit draws: the normal's azimuth
  // in 5° steps and its distance from the world's origin in 5 m steps (facade_key), or in a
  // sequence the key of the façade it was matched to (FacadeSet, scene/luminaires.h, handed in as
  // `keys`). All in the world, so a
  // façade keeps its windows' layout and draws when the camera pans, drives or turns (`pose`:
  // the frame's pose in its sequence's world; a single frame's is 0, the world its own road
  // coordinates).
  std::vector<FacadeFrame> frames;
  // Unit-luminance colours of the three window CCTs (a blackbody's box RGB is linear in its
  // luminance; spectrum::blackbody_rgb integrates Planck's law, far too slow per pixel).
  const decltype(spectrum::blackbody_rgb(0.0, 1.0)) warm1, cool1, shop1;
  const int isa = light_isa();
  // The day photo's windows (find_facade_windows; none without a texture or with
  // windows.detect_contrast 0), each one's draw keyed by its plane's key and its centre on the
  // plane in 0.5 m steps (bit 38 keeps the keys apart from the grid's).
  FacadeWindowsFound found;
  struct FoundDraw {
    uint64_t key = 0;
    bool lit = false;
    float col[3] = {0, 0, 0};
  };
  std::vector<FoundDraw> found_draws;
  std::vector<std::vector<int32_t>> found_rows;  // per image row, the lit found windows crossing it
  bool any_found = false;
  // Pixel x's coordinate s along its plane pi from its camera z (window_geom_scalar's X, D and s).
  double along_plane(int x, int pi, double zz, const WindowGeom& wg) const {
    const double X = zz * (x - wg.cx) / wg.f, D = zz * wg.kD;
    return frames[pi].tX * X + frames[pi].tD * D;
  }
  // Whether pixel x (camera z, plane pi) lies in a column of its plane that the photo resolves
  // (FacadeWindowsFound::Plane::resolved): there the photo's windows replace the grid's. (Only
  // with any_found: the planes are found's then.)
  bool photo_resolved(int x, int pi, double zz, const WindowGeom& wg) const {
    const FacadeWindowsFound::Plane& P = found.planes[pi];
    if (!P.used) return false;
    const double ci = std::floor((along_plane(x, pi, zz, wg) - P.s0) * (1 / FacadeWindowsFound::kCell_m));
    return ci >= 0 && ci < P.ns && P.resolved[static_cast<size_t>(ci)];
  }
  WindowPass(const ImageU16& labels_, const ImageF& depth_m_, const CameraGeometry& g_, const ScenePreset& p_,
             uint64_t seed_, const BuildingFacades* facades, int width, const ImageF* texture, const CameraPose& pose,
             const std::vector<uint64_t>* keys)
      : labels(labels_), depth_m(depth_m_), g(g_), p(p_), seed(seed_), W(width), c(std::cos(g_.pitch_rad)),
        sn(std::sin(g_.pitch_rad)), h(g_.mount_height_m), max_z(0.5 * p_.window_width_m * g_.f_px),
        computed(facades ? BuildingFacades() : building_facades(labels_, g_, p_.max_depth_m)),
        fac(facades ? *facades : computed), frames(fac.planes.size()),
        warm1(spectrum::blackbody_rgb(p_.window_cct_K, 1.0)), cool1(spectrum::blackbody_rgb(p_.window_cool_cct_K, 1.0)),
        shop1(spectrum::blackbody_rgb(p_.shop_cct_K, 1.0)) {
    // The frame's road coordinates → the world's (luminaires.cpp's Pose2): a direction v turns to
    // R·v, R = [[cos ψ, sin ψ], [−sin ψ, cos ψ]] (ψ the yaw), a point to T + R·v (T the camera's
    // foot). A plane n·P = d (n its unit normal toward the plane from the camera) is n_w·P_w = d +
    // n_w·T in the world, and a point's coordinate along it t_w·P_w = s + t_w·T: the offset s0.
    // At pose 0 none of this is taken (the same operations, so the same bits, as before poses).
    const bool moved = !pose.at_origin();
    const double cy = std::cos(pose.yaw_rad), sy = std::sin(pose.yaw_rad);
    for (size_t k = 0; k < fac.planes.size(); ++k) {
      const FacadePlane& f = fac.planes[k];
      double tX = f.nD, tD = -f.nX, s0 = 0;
      if (!moved) {
        if (tD < 0 || (tD == 0 && tX < 0)) { tX = -tX; tD = -tD; }
      } else {
        double tXw = tX * cy + tD * sy, tDw = -tX * sy + tD * cy;
        if (tDw < 0 || (tDw == 0 && tXw < 0)) { tX = -tX; tD = -tD; tXw = -tXw; tDw = -tDw; }
        s0 = tXw * pose.X_m + tDw * pose.D_m;
      }
      // A sequence's keys (FacadeSet: a plane keeps the key of the façade it was matched to).
      frames[k] = {tX, tD, s0, keys && keys->size() == fac.planes.size() ? (*keys)[k] : facade_key(facade_in_world(f, pose))};
    }
    if (texture && p.window_detect_contrast > 0) {
      std::vector<double> tXs(frames.size()), tDs(frames.size());
      for (size_t k = 0; k < frames.size(); ++k) tXs[k] = frames[k].tX, tDs[k] = frames[k].tD;
      found = find_facade_windows(*texture, depth_m_, g_, fac, p_, tXs.data(), tDs.data(), max_z);
      for (const FacadeWindowsFound::Plane& P : found.planes) any_found |= P.used;
      found_draws.resize(found.windows.size());
      for (size_t i = 0; i < found.windows.size(); ++i) {
        const FacadeWindowsFound::Window& w = found.windows[i];
        // (The window's centre from the world's origin: s_lo, s_hi are from the camera's foot.)
        const uint64_t qs =
            static_cast<uint64_t>(std::llround(((w.s_lo + w.s_hi) / 2 + frames[w.plane].s0) / 0.5) + (1 << 19)) & 0xfffff;
        const uint64_t qy = static_cast<uint64_t>(std::llround((w.y_lo + w.y_hi) / 2 / 0.5)) & 0x3f;
        FoundDraw& d = found_draws[i];
        d.key = frames[w.plane].key << 40 | 1ull << 38 | qs << 12 | qy;
        d.lit = lit_colour(d.key, false, d.col);
      }
      found_rows.resize(depth_m_.height());
      for (size_t i = 0; i < found.windows.size(); ++i)
        if (found_draws[i].lit)
          for (int y = found.windows[i].y0; y <= found.windows[i].y1; ++y) found_rows[y].push_back(static_cast<int32_t>(i));
    }
  }
  // A window's (or, `shop`, a shop unit's) seeded draw: lit or not, and where lit its colour.
  bool lit_colour(uint64_t key, bool shop, float* col) const {
    const auto w = random_words(seed, 0, 0xfacade0000000000ull ^ key, Stream::Scene);
    if (!(uniform_open(w[0]) < p.window_lit_fraction)) return false;
    double lum = p.window_luminance_cd_m2 * (0.5 + uniform_open(w[1]));  // 0.5..1.5×
    const auto* unit = uniform_open(w[2]) < p.window_warm_share ? &warm1 : &cool1;
    // A share of the lit windows is seen through drawn curtains or blinds: their
    // luminance, 0.5..1.5× window_curtained_luminance_cd_m2, replaces the open window's.
    if (!shop && uniform_open(w[3]) < p.window_curtained_share)
      lum = p.window_curtained_luminance_cd_m2 * (0.5 + uniform_open(w[1]));
    if (shop) { lum *= p.shop_luminance_factor; unit = &shop1; }
    for (int k = 0; k < 3; ++k) col[k] = static_cast<float>((*unit)[k] * lum);
    return true;
  }
  WindowPass(const WindowPass&) = delete;
  WindowPass& operator=(const WindowPass&) = delete;
  struct Scratch {
    std::unordered_set<uint64_t> seen;
    WindowRow r;
    std::vector<int32_t> plane_of;
    WindowPanes panes;
    explicit Scratch(int W)  // a block's
        : r(std::min(W, kWindowBlock)), plane_of(std::min(W, kWindowBlock) + 4), panes(std::min(W, kWindowBlock)) {}
  };
  // The draw's memo: neighbouring pane pixels mostly share a window (and a ground floor its shop
  // unit), whose draw is kept; each draw is a function of its key only.
  struct DrawMemo {
    uint64_t last_key = ~0ull, last_unit = ~0ull;
    bool last_lit = false, last_unit_shop = false;
    float col[3] = {0, 0, 0};
  };
  // One pane pixel (column x, plane pi, storey j, kind: bit 1 window glass, bit 2 shop pane; the
  // pitch cell and, on the ground floor, the shop unit): its window's or shop's draw, and where lit
  // its colour as a maximum into the row o.
  [[gnu::always_inline]] inline void draw_pane(float* o, int x, int pi, int j, int kind, int64_t cell_i, int64_t unit_i,
                                               DrawMemo& m, std::unordered_set<uint64_t>& seen) const {
    const uint64_t fkey = frames[pi].key << 40;
    bool shop = false;
    if (j == 0) {
      // The ground floor is a shop front on a seeded share of the shop units (shop_frontage_m
      // along the façade), each unit's draw keyed like the windows' (world coordinates).
      const uint64_t unit = static_cast<uint64_t>(unit_i + (1 << 19)) & 0xfffff;
      const uint64_t ukey = fkey | (unit << 12);
      if (ukey != m.last_unit) {
        m.last_unit = ukey;
        m.last_unit_shop = uniform_open(random_words(seed, 0, 0x5a0b000000000000ull ^ ukey, Stream::Scene)[0]) < p.shop_share;
      }
      shop = m.last_unit_shop;
    }
    // A shop unit shows its panes (kind bit 2), every other cell its window lights (bit 1).
    if (!(kind & (shop ? 2 : 1))) return;
    const uint64_t cell = static_cast<uint64_t>((shop ? unit_i : cell_i) + (1 << 19)) & 0xfffff;
    // Bits 32-39 are free (cell: 20 bits from bit 12); bit 39 keeps a ground floor's windows
    // apart from the shop unit of the same cell index.
    const uint64_t key = fkey | (cell << 12) | (static_cast<uint64_t>(j) & 0xfff) | (j == 0 && !shop ? 1ull << 39 : 0);
    if (key != m.last_key) {
      m.last_key = key;
      m.last_lit = lit_colour(key, shop, m.col);
      if (m.last_lit) seen.insert(key);
    }
    if (!m.last_lit) return;
    for (int k = 0; k < 3; ++k) o[3 * x + k] = std::max(o[3 * x + k], m.col[k]);
  }
  void row(ImageF& L, int y, Scratch& sc) const {
    const float* z = depth_m.row(y);
    const int32_t* reg = fac.region.row(y);
    float* o = L.row(y);
    const double yn = (y - g.cy_px) / g.f_px;
    // (Through local pointers and copies of the width and the depth limit: the stores might
    // alias the shared ones otherwise, which the compiler would reload at every pixel.)
    const int Wr = W;
    const double zmax = max_z;
    int32_t *rx = sc.r.x.data(), *rp = sc.plane_of.data();
    double *rz = sc.r.z.data(), *rtX = sc.r.tX.data(), *rtD = sc.r.tD.data(), *rso = sc.r.so.data();
    const FacadeFrame* fr = frames.data();
    const WindowGeom wg{g.cx_px, g.f_px, c - yn * sn, yn * c + sn, h,
                        p.window_storey_m, p.window_pitch_m, p.shop_frontage_m, 0.5 * p.window_pitch_m,
                        0.5 * p.window_width_m - p.window_frame_m, 0.5 * p.window_storey_m,
                        0.5 * p.window_height_m - p.window_frame_m, 0.5 * p.window_mullion_m,
                        0.5 * p.shop_width_m, p.shop_sill_m, p.shop_sill_m + p.shop_height_m,
                        1.0 / p.window_storey_m, 1.0 / p.window_pitch_m, 1.0 / p.shop_frontage_m};
    DrawMemo memo;
    // The row in blocks of kWindowBlock columns, each compacted, laid out and drawn before the
    // next (the block's candidates, ~13 kB, stay in the first-level cache between the three
    // steps; a whole row's, ~110 kB, did not). Each pane's draw is a function of its key and
    // the colour goes in as a maximum, so the order of the draws (column order, or with AVX-512
    // the groups laid out straight from the depth row first) does not change the windows.
    for (int x0 = 0; x0 < Wr; x0 += kWindowBlock) {
      const int x1 = std::min(Wr, x0 + kWindowBlock);
      // The block's building pixels with a plane (BuildingFacades::plane_index), compacted.
      int n = 0;
      if (isa >= 2) {
        // With AVX-512: the groups inside one façade plane laid out as they are read, their pane
        // pixels drawn; the other candidates below (window_block_avx512).
        const WindowPanes& P = sc.panes;
        // (Its lanes in a column the photo resolves are left out of P: photo_resolved is done.)
        const int np = window_block_avx512(reg, z, x0, x1, zmax, fac, fr, wg, sc.r, rp, &n, sc.panes,
                                           any_found ? found.planes.data() : nullptr, labels.row(y));
        for (int i = 0; i < np; ++i) {
          const int j = P.j[i];
          draw_pane(o, P.x[i], P.plane[i], j, P.kind[i], static_cast<int64_t>(P.cell[i]),
                    j == 0 ? static_cast<int64_t>(P.unit[i]) : 0, memo, sc.seen);
        }
      } else if (isa == 1) {
        n = window_candidates_avx2(reg, z, x0, x1, zmax, fac, fr, sc.r, rp, labels.row(y));
      }
      for (int x = x0; x < x1 && isa == 0; ++x) {
        // Eight pixels of no building region (region −1: the AND of their ids keeps the sign bit
        // only when every one has it) skipped at once: building pixels come in long runs.
        if ((x & 7) == 0 && x + 8 <= x1 &&
            (reg[x] & reg[x + 1] & reg[x + 2] & reg[x + 3] & reg[x + 4] & reg[x + 5] & reg[x + 6] & reg[x + 7]) < 0) {
          x += 7;
          continue;
        }
        window_candidate(x, reg, z, zmax, fac, fr, rx, rz, rtX, rtD, rso, rp, n);
      }
      if (n == 0) continue;
      if (isa >= 1) {
        sc.r.pad(n);
        // (The photo-resolved lanes' kinds cleared there: photo_resolved is done.)
        const FacadeWindowsFound::Plane* fp = any_found ? found.planes.data() : nullptr;
        if (isa >= 2) window_geom_avx512(sc.r, n, wg, rp, fp);
        else window_geom_avx2(sc.r, n, wg, rp, fp);
      } else {
        window_geom_scalar(sc.r, n, wg);
      }
      // The candidates in a pane (kind ≠ 0), in column order, eight kinds a word: a word of none
      // skipped, the others' pane bytes found by their high bits (a byte's 7 low bits plus 0x7f
      // carry into its high bit unless 0); the bytes from n on masked off.
      for (int i8 = 0; i8 < n; i8 += 8) {
        uint64_t kinds;
        std::memcpy(&kinds, &sc.r.kind[i8], 8);
        if (n - i8 < 8) kinds &= (1ull << (8 * (n - i8))) - 1;
        uint64_t in_pane = (((kinds & 0x7f7f7f7f7f7f7f7full) + 0x7f7f7f7f7f7f7f7full) | kinds) & 0x8080808080808080ull;
        for (; in_pane; in_pane &= in_pane - 1) {
          const int i = i8 + (std::countr_zero(in_pane) >> 3);
          const int j = sc.r.j[i];
          if (any_found && isa == 0 && photo_resolved(sc.r.x[i], sc.plane_of[i], sc.r.z[i], wg)) continue;
          draw_pane(o, sc.r.x[i], sc.plane_of[i], j, sc.r.kind[i], sc.r.cell[i], j == 0 ? sc.r.unit[i] : 0, memo, sc.seen);
        }
      }
    }
    if (!any_found) return;
    // The photo's lit windows crossing this row (found_rows), each over its image box: the pixels
    // of its plane whose façade coordinates lie in the window's box on the plane.
    for (const int32_t id : found_rows[y]) {
      const FacadeWindowsFound::Window& w = found.windows[id];
      const FoundDraw& d = found_draws[id];
      const int pi = w.plane;
      bool drawn = false;
      for (int x = w.x0; x <= w.x1; ++x) {
        if (reg[x] < 0 || z[x] > zmax) continue;
        const BuildingFacades::Region& R = fac.regions[reg[x]];
        if (R.column_plane[x - R.x0] != pi) continue;
        const double zz = z[x], Y = wg.h - zz * wg.kY, s = along_plane(x, pi, zz, wg);
        if (!(s >= w.s_lo && s < w.s_hi && Y >= w.y_lo && Y < w.y_hi)) continue;
        for (int k = 0; k < 3; ++k) o[3 * x + k] = std::max(o[3 * x + k], d.col[k]);
        drawn = true;
      }
      if (drawn) sc.seen.insert(d.key);
    }
  }
};
}  // namespace

FacadePlane facade_in_world(const FacadePlane& f, const CameraPose& pose) {
  // (At pose 0 the frame's own values: the same operations, so the same keys, as before poses.)
  if (pose.at_origin()) return f;
  const double cy = std::cos(pose.yaw_rad), sy = std::sin(pose.yaw_rad);
  FacadePlane w = f;
  w.nX = f.nX * cy + f.nD * sy;
  w.nD = -f.nX * sy + f.nD * cy;
  w.d_m = f.d_m + w.nX * pose.X_m + w.nD * pose.D_m;
  return w;
}

uint64_t facade_key(const FacadePlane& world) {
  const uint64_t az = static_cast<uint64_t>(std::lround(std::atan2(world.nX, world.nD) * 180 / M_PI / 5.0) + 64) & 127;
  const uint64_t dist = static_cast<uint64_t>(std::lround(world.d_m / 5.0)) & 1023;
  return (az << 10) | dist;
}

int add_facade_windows(ImageF& L, const ImageU16& labels, const ImageF& depth_m, const CameraGeometry& g,
                       const ScenePreset& p, uint64_t seed, const BuildingFacades* facades, const ImageF* texture,
                       const CameraPose& pose, const std::vector<uint64_t>* facade_keys) {
  const WindowPass w(labels, depth_m, g, p, seed, facades, L.width(), texture, pose, facade_keys);
  std::unordered_set<uint64_t> all;
#pragma omp parallel
  {
    WindowPass::Scratch sc(L.width());
#pragma omp for schedule(static, 8)
    for (int y = 0; y < L.height(); ++y) w.row(L, y, sc);
#pragma omp critical
    all.insert(sc.seen.begin(), sc.seen.end());
  }
  return static_cast<int>(all.size());
}

bool window_floor_div_avx512(const double* a, int n, double b, double* out) {
  if (kMachineIsa < 2) return false;
  floor_div_avx512(a, n, b, out);
  return true;
}

StreetRowsResult add_street_light_rows(ImageF& L, const ImageF& texture, const ImageU16& labels, const ImageF& depth_m,
                                       const CameraGeometry& g, const StreetLighting& s, const ScenePreset& p,
                                       uint64_t seed, const BuildingFacades* facades, const ComposeRows* compose,
                                       const std::function<void(int)>* first, const std::function<void()>* side,
                                       int side_y0, int side_y1, const LampShadowRows* shadows) {
  const int W = L.width(), H = L.height();
  const BuildingFacades computed = facades ? BuildingFacades() : building_facades(labels, g, p.max_depth_m);
  const BuildingFacades* fac = facades ? facades : &computed;
  const bool lamps = !s.lamps.empty();
  std::optional<VerticalPass> vertical;
  std::optional<PoolPass> pools;
  LampShadowRows shadow_rows;
  if (lamps) {
    vertical.emplace(texture, labels, depth_m, g, s, p, fac, W);
    pools.emplace(texture, labels, g, s, p, W);
    if (p.lamp_shadows) {
      const bool given = shadows && shadows->lamps == s.lamps.size() && shadows->samples == lamp_shadow_samples(p);
      if (!given) shadow_rows = street_lamp_shadow_spans(labels, depth_m, g, s, p);
      pools->shadows = given ? shadows : &shadow_rows;
    }
  }
  long long shaded = 0;
  const WindowPass windows(labels, depth_m, g, p, seed, fac, W, &texture, s.pose, &s.facade_keys);
  // With compose or `first` (light_map's row pass, with or without its night radiance), the heads
  // row by row in the pass (each row's share of every disc crossing it, a maximum after the row's
  // windows, as draw_lamp_heads' after all rows), and each head's "drawn" from any thread's rows:
  // nothing runs on one thread alone after the pass. (Without either, as add_street_lighting, after
  // the pass: light_map's separate steps, its definition.)
  const bool heads_in_pass = (compose || first) && lamps;
  const std::vector<HeadDisc> heads = heads_in_pass ? visible_head_discs(g, s, p, W, H, &depth_m, labels) : std::vector<HeadDisc>();
  std::vector<uint8_t> head_drawn(heads.size(), 0);
  std::unordered_set<uint64_t> all;
  // The rows in chunks of 8, those outside the side job's band [b0, b1] first, then the band's;
  // each thread takes the next chunk. With `side`, thread 0 first runs it while the others take
  // the chunks outside the band; a chunk in the band waits until it has returned (at one thread:
  // the side job, then every row). Each row is made by the same function whichever thread takes
  // it, and nothing a row writes is read by another, so the order changes no bit.
  const int b0 = side ? std::max(0, side_y0) : 0, b1 = side ? std::min(H - 1, side_y1) : -1;
  std::vector<std::pair<int, int>> chunks;
  auto add_chunks = [&](int y0, int y1) {  // rows y0 .. y1 − 1
    for (int y = y0; y < y1; y += 8) chunks.push_back({y, std::min(y1, y + 8)});
  };
  const size_t outside_end = [&] {
    if (b1 < b0) {
      add_chunks(0, H);
      return chunks.size();
    }
    add_chunks(0, b0);
    add_chunks(b1 + 1, H);
    const size_t n = chunks.size();
    add_chunks(b0, b1 + 1);
    return n;
  }();
  std::atomic<size_t> next{0};
  std::atomic<bool> side_done{side == nullptr};
  std::exception_ptr side_failed;
#pragma omp parallel
  {
    if (side && omp_get_thread_num() == 0) {
      try {
        (*side)();
      } catch (...) {
        side_failed = std::current_exception();
      }
      side_done.store(true, std::memory_order_release);
    }
    if (kHaveAvx) clear_upper_vector_state();  // on each thread (see clear_upper_vector_state)
    VerticalRow vr(W);
    PoolPass::Scratch ps(W);
    WindowPass::Scratch ws(W);
    std::vector<uint8_t> drawn(heads.size(), 0);
    for (size_t c = next++; c < chunks.size(); c = next++) {
      if (c >= outside_end)
        while (!side_done.load(std::memory_order_acquire)) std::this_thread::yield();
      if (side_failed) break;  // (its exception is rethrown below; the rows are not needed)
      for (int y = chunks[c].first; y < chunks[c].second; ++y) {
        if (first) (*first)(y);
        if (lamps) {
          // The look-ahead (RowAhead): the next row only where it is this chunk's (another
          // thread's row of L would move between the cores).
          const bool next_mine = y + 1 < chunks[c].second;
          const RowAhead ahead{y >= pools->y_start, next_mine ? L.row(y + 1) : nullptr,
                               next_mine ? depth_m.row(y + 1) : nullptr, compose ? compose->night.row(y) : nullptr,
                               compose ? compose->beam_lux.row(y) : nullptr};
          vertical->row(L, y, vr, ahead);
          pools->row(L, y, ps);
        }
        windows.row(L, y, ws);
        for (size_t k = 0; k < heads.size(); ++k)
          if (y >= heads[k].y0 && y <= heads[k].y1 && draw_head_row(L, heads[k], y)) drawn[k] = 1;
        if (compose) compose->row(y);
      }
    }
#pragma omp critical
    {
      all.insert(ws.seen.begin(), ws.seen.end());
      for (size_t k = 0; k < heads.size(); ++k) head_drawn[k] |= drawn[k];
      shaded += ps.shaded;
    }
  }
  if (side_failed) std::rethrow_exception(side_failed);
  StreetRowsResult out;
  out.windows = static_cast<int>(all.size());
  out.shadow_quads = pools && pools->shadows ? pools->shadows->quads : 0;
  out.shadow_pixels = shaded;
  if (lamps) {
    if (heads_in_pass) out.pole_lamps = static_cast<int>(std::count(head_drawn.begin(), head_drawn.end(), uint8_t{1}));
    else out.pole_lamps = draw_lamp_heads(L, g, s, p, &depth_m, labels);
  }
  return out;
}

}  // namespace photosite::scene


