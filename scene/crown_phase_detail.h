// Private (not installed): the Lambert sphere's phase law for tree crowns, shared by the street
// lamps' vertical light (scene/street.cpp) and the ego low beam's (scene/lights.cpp).
#pragma once
#include <algorithm>
#include <cmath>
#include <immintrin.h>

namespace photosite::scene {

// Tree crowns (Label::Vegetation) are not a face turned to the camera but a volume of leaves
// showing faces to every side: a lamp beside a crown lights the half of it that the camera sees
// from the side, which a camera-facing plane (cos β ≤ 0 there) leaves dark. photosite takes a
// crown as a Lambert sphere (a sphere of Lambertian surface elements of the texture's reflectance
// ρ): seen at phase angle α (the angle at the crown between the directions to the lamp and to the
// camera), the mean radiance of its disc is ρ·E⊥/π·Φ(α) with
//   Φ(α) = (2/(3π))·(sin α + (π − α)·cos α)
// (Russell 1916, "On the light variations of asteroids and satellites", ApJ 43, 173: the
// Lambert sphere's phase law; Φ(0) = 2/3 is its geometric albedo over ρ), E⊥ = I(γ)/d² the
// illuminance normal to the lamp's direction. Stated approximations (photosite's choices): every
// crown pixel takes the disc's mean, not its own surface element's (the crown's shape is not known
// from the labels); the sphere is opaque (no light transmitted through the leaves from a lamp
// behind it, Φ(π) = 0) and has no hot spot (the leaves' own shadows at α → 0). Evaluated from
// c = cos α: with a = |c| and s = √(1 − a), sin α = s·√(1 + a) and (π − α)·c = a·(π − arccos a)
// for c ≥ 0, −a·arccos a for c < 0, so Φ = (2/(3π))·(s·Q(a) + [c ≥ 0]·π·a) with the smooth
// Q(a) = √(1 + a) − a·arccos(a)/√(1 − a), here a degree-5 polynomial within 7.75·10⁻⁷ of Q on
// [0, 1] (scripts/crown_phase_fit.py, which prints the coefficients and the error): |ΔΦ| ≤
// 1.7·10⁻⁷ from the polynomial, plus the float evaluation's rounding; one square root. Φ is
// clamped at 0 (the polynomial's error where s·Q → 0 at α → π).
// crown_phase, crown_phase8 and crown_phase16: the same IEEE operations in the same order.
struct CrownPhaseConsts {
  static constexpr float q0 = 0.999999225f, q1 = -1.07076108f, q2 = 0.0892240331f, q3 = -0.0248672515f,
                         q4 = 0.00794185605f, q5 = -0.00153741299f;
  static constexpr float pi = 3.14159265358979f, k = static_cast<float>(2.0 / (3.0 * 3.14159265358979323846));
};
[[gnu::always_inline]] inline float crown_phase(float c) {
  using K = CrownPhaseConsts;
  const float a = std::min(std::fabs(c), 1.f), sa = std::sqrt(1.f - a);
  const float q = ((((K::q5 * a + K::q4) * a + K::q3) * a + K::q2) * a + K::q1) * a + K::q0;
  const float t = sa * q;
  return std::max(K::k * (c >= 0 ? t + K::pi * a : t), 0.f);
}
__attribute__((target("avx2"), always_inline)) inline __m256 crown_phase8(__m256 c) {
  using K = CrownPhaseConsts;
  const __m256 a = _mm256_min_ps(_mm256_and_ps(c, _mm256_castsi256_ps(_mm256_set1_epi32(0x7fffffff))), _mm256_set1_ps(1.f));
  const __m256 sa = _mm256_sqrt_ps(_mm256_sub_ps(_mm256_set1_ps(1.f), a));
  __m256 q = _mm256_add_ps(_mm256_mul_ps(_mm256_set1_ps(K::q5), a), _mm256_set1_ps(K::q4));
  q = _mm256_add_ps(_mm256_mul_ps(q, a), _mm256_set1_ps(K::q3));
  q = _mm256_add_ps(_mm256_mul_ps(q, a), _mm256_set1_ps(K::q2));
  q = _mm256_add_ps(_mm256_mul_ps(q, a), _mm256_set1_ps(K::q1));
  q = _mm256_add_ps(_mm256_mul_ps(q, a), _mm256_set1_ps(K::q0));
  const __m256 t = _mm256_mul_ps(sa, q);
  const __m256 u = _mm256_blendv_ps(t, _mm256_add_ps(t, _mm256_mul_ps(_mm256_set1_ps(K::pi), a)),
                                    _mm256_cmp_ps(c, _mm256_setzero_ps(), _CMP_GE_OQ));
  return _mm256_max_ps(_mm256_mul_ps(_mm256_set1_ps(K::k), u), _mm256_setzero_ps());
}
__attribute__((target("avx512f"), always_inline)) inline __m512 crown_phase16(__m512 c) {
  using K = CrownPhaseConsts;
  const __m512 a = _mm512_min_ps(_mm512_abs_ps(c), _mm512_set1_ps(1.f));
  const __m512 sa = _mm512_sqrt_ps(_mm512_sub_ps(_mm512_set1_ps(1.f), a));
  __m512 q = _mm512_add_ps(_mm512_mul_ps(_mm512_set1_ps(K::q5), a), _mm512_set1_ps(K::q4));
  q = _mm512_add_ps(_mm512_mul_ps(q, a), _mm512_set1_ps(K::q3));
  q = _mm512_add_ps(_mm512_mul_ps(q, a), _mm512_set1_ps(K::q2));
  q = _mm512_add_ps(_mm512_mul_ps(q, a), _mm512_set1_ps(K::q1));
  q = _mm512_add_ps(_mm512_mul_ps(q, a), _mm512_set1_ps(K::q0));
  const __m512 t = _mm512_mul_ps(sa, q);
  const __m512 u = _mm512_mask_add_ps(t, _mm512_cmp_ps_mask(c, _mm512_setzero_ps(), _CMP_GE_OQ), t,
                                      _mm512_mul_ps(_mm512_set1_ps(K::pi), a));
  return _mm512_max_ps(_mm512_mul_ps(_mm512_set1_ps(K::k), u), _mm512_setzero_ps());
}

}  // namespace photosite::scene
