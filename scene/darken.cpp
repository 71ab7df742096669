// Linearization and per-class darkening under night illumination (stage 1).
#include <algorithm>
#include <bit>
#include <atomic>
#include <climits>
#include <cstdint>
#include <cmath>
#include <limits>
#include <cstring>
#include <fmt/format.h>
#include <vector>
#if defined(__x86_64__)
#include <immintrin.h>
#endif

#include "core/isa_detail.h"
#include "photosite/error.h"
#include "photosite/scene/night.h"
#include "photosite/sensor/isp.h"
#include "photosite/sensor/spectrum.h"
#include "photosite/units.h"
#include "scene/darken_detail.h"
#include "scene/lanes_detail.h"
#include "scene/runs_detail.h"
#include "scene/texture_detail.h"

namespace photosite::scene {

const std::vector<float>& srgb_decode_table() {
  // sRGB decode through a 4096-entry table (inputs are 8/16-bit codes normalised to [0,1]),
  // interpolated linearly; the Vulkan kernel (kernels/linearize.comp) reads the same table.
  static const std::vector<float> lut = [] {
    std::vector<float> t(4097);
    for (int i = 0; i <= 4096; ++i) t[i] = static_cast<float>(srgb_decode(i / 4096.0));
    return t;
  }();
  return lut;
}

void fail_damaged_pixel(const ImageF& day, const ImageFileInfo& info, int64_t index) {
  const int x = static_cast<int>(index % day.width()), y = static_cast<int>(index / day.width());
  // The damaged sample itself, by its channel's name (a NaN in G was reported as R's finite value).
  const int c = day.channels();
  int k = 0;
  while (k + 1 < c && std::isfinite(day.at(x, y, k))) ++k;
  static const char* const kRgba[] = {"R", "G", "B", "A"}, *const kYa[] = {"Y", "A"};
  const std::string channel = c == 1   ? ""
                              : c == 2 ? std::string(" ") + kYa[k]
                              : c <= 4 ? std::string(" ") + kRgba[k]
                                       : fmt::format(" channel {}", k);
  fail_at(info.path, fmt::format("pixel ({}, {}){} is {}: NaN and Inf are not light; the image is damaged", x, y,
                                 channel, day.at(x, y, k)));
}

namespace {
// The widest instruction set the per-pixel loops below may take (texture_detail.h).
int max_isa = 2;
// The decode of a value v in [0, 1]: linear interpolation in srgb_decode_table.
inline float decode_interp(float v, const float* lut) {
  const float t = v * 4096.f;
  const int i = std::min(4095, static_cast<int>(t));
  return lut[i] + (lut[i + 1] - lut[i]) * (t - i);
}
// 8-bit files: read_image gives the 256 values code·(1/255) (OpenImageIO's conversion, kept). Their
// decodes, by decode_interp itself, in a 256-entry table: a value that is one of them reads the
// table, any other value interpolates, so the result is the same to the bit either way. `plane`
// holds byte b of each out[k] in plane[b][k] (decode8_samples_vbmi's byte permutes read them).
struct Decode8 {
  float in[256], out[256];
  alignas(64) uint8_t plane[4][256];
};
const Decode8& decode8() {
  static const Decode8 d = [] {
    Decode8 t;
    const float* lut = srgb_decode_table().data();
    for (int c = 0; c < 256; ++c) {
      t.in[c] = c * (1.f / 255);
      t.out[c] = decode_interp(t.in[c], lut);
      uint32_t u;
      std::memcpy(&u, &t.out[c], 4);
      for (int b = 0; b < 4; ++b) t.plane[b][c] = static_cast<uint8_t>(u >> (8 * b));
    }
    return t;
  }();
  return d;
}
#if defined(__x86_64__)
// The 8-bit path's table read, eight samples at a time from j (a multiple of 8) while all eight
// are in [0, 1] and one of the 256 code values (the test and the code exactly as the scalar loop
// computes them); returns where it stopped: n, or the first block of eight with any other value,
// which the scalar loop takes.
__attribute__((target("avx2")))
int decode8_codes_avx2(const float* in, int j, int n, const Decode8& d8, float* o) {
  const __m256 zero = _mm256_setzero_ps(), one = _mm256_set1_ps(1.f);
  const __m256 k255 = _mm256_set1_ps(255.f), half = _mm256_set1_ps(0.5f);
  for (; j + 8 <= n; j += 8) {
    const __m256 v = _mm256_loadu_ps(in + j);
    const __m256 in_range = _mm256_and_ps(_mm256_cmp_ps(v, zero, _CMP_GE_OQ), _mm256_cmp_ps(v, one, _CMP_LE_OQ));
    // Out-of-range lanes index code 0 (the mask keeps the gather inside the table).
    const __m256i code = _mm256_and_si256(_mm256_cvttps_epi32(_mm256_add_ps(_mm256_mul_ps(v, k255), half)),
                                          _mm256_castps_si256(in_range));
    // d8.in[code] is code·(1/255) rounded to float: computed here as Decode8 computes it (an
    // exact int-to-float conversion and one rounded product) rather than gathered.
    const __m256 in_code = _mm256_mul_ps(_mm256_cvtepi32_ps(code), _mm256_set1_ps(1.f / 255));
    const __m256 is_code = _mm256_cmp_ps(in_code, v, _CMP_EQ_OQ);
    if (_mm256_movemask_ps(_mm256_and_ps(in_range, is_code)) != 0xff) return j;
    _mm256_storeu_ps(o + j, _mm256_i32gather_ps(d8.out, code, 4));
  }
  return j;
}
#endif
}  // namespace

const float* srgb8_decodes() { return decode8().out; }

namespace {
#if defined(__x86_64__)
const bool kAvx2 = photosite::detail::have_avx2();
#endif
// n samples of an RGB day image (3 per pixel, the first of pixel `pixel0`) to linear sRGB: the
// per-sample definition of linearize() (a flat loop: RGB samples need no channel mapping). `bad`:
// lowered to the first damaged (NaN, Inf) pixel's index in reading order.
void linearize_rgb_samples(const float* in, float* o, int n, int64_t pixel0, bool decode, const Decode8* d8,
                           const float* lut, int64_t* bad) {
  if (d8) {
    // 8-bit RGB: the checks below, for a value outside [0, 1] (NaN, Inf, negative, above
    // white), are taken only when one is.
    for (int j = 0; j < n; ++j) {
#if defined(__x86_64__)
      if (kAvx2 && max_isa >= 1 && (j & 7) == 0) {  // eight at a time while all eight are table codes
        j = decode8_codes_avx2(in, j, n, *d8, o);
        if (j >= n) break;
      }
#endif
      float v = in[j];
      if (!(v >= 0.f && v <= 1.f)) [[unlikely]] {
        if (!std::isfinite(v)) {
          *bad = std::min(*bad, pixel0 + j / 3);
          v = 0;
        }
        if (v < 0) v = 0;
        v = std::min(v, 1.f);
      }
      const int code = static_cast<int>(v * 255.f + 0.5f);
      o[j] = d8->in[code] == v ? d8->out[code] : decode_interp(v, lut);
    }
    return;
  }
  for (int j = 0; j < n; ++j) {
    float v = in[j];
    if (!std::isfinite(v)) {
      *bad = std::min(*bad, pixel0 + j / 3);
      v = 0;
    }
    if (v < 0) v = 0;
    if (decode) v = decode_interp(std::min(v, 1.f), lut);
    o[j] = v;
  }
}
}  // namespace

void linearize_day_pixel(const ImageF& day, const ImageFileInfo& info, size_t i, float* c) {
  const bool decode = !info.is_float;
  const Decode8* d8 = decode && info.bits_per_sample == 8 ? &decode8() : nullptr;
  int64_t ignored = INT64_MAX;  // a damaged sample decodes as 0; linearize names it
  linearize_rgb_samples(day.data() + 3 * i, c, 3, static_cast<int64_t>(i), decode, d8, srgb_decode_table().data(),
                        &ignored);
}

ImageF linearize(const ImageF& day, const ImageFileInfo& info) {
  const int c = day.channels();
  ImageF out(day.width(), day.height(), 3, uninitialized, "linear sRGB");
  const float* lut = srgb_decode_table().data();
  const bool decode = !info.is_float;
  const Decode8* d8 = decode && info.bits_per_sample == 8 ? &decode8() : nullptr;
  // NaN and Inf in a linear (EXR) day image are damage, not light: refused, first one named.
  // Negatives are kept as out-of-gamut colour and clipped to 0 like integer files' codes.
  int64_t bad = INT64_MAX;  // first damaged pixel in reading order (y·width + x)
#pragma omp parallel for schedule(static) reduction(min : bad)
  for (int y = 0; y < day.height(); ++y) {
    const float* in = day.row(y);
    float* o = out.row(y);
    if (c == 3) {
      linearize_rgb_samples(in, o, 3 * day.width(), static_cast<int64_t>(y) * day.width(), decode, d8, lut, &bad);
      continue;
    }
    for (int x = 0; x < day.width(); ++x) {
      for (int k = 0; k < 3; ++k) {
        float v = in[x * c + (c >= 3 ? k : 0)];
        if (!std::isfinite(v)) {
          bad = std::min(bad, static_cast<int64_t>(y) * day.width() + x);
          v = 0;
        }
        if (v < 0) v = 0;
        if (decode) {
          v = std::min(v, 1.f);
          const int code = static_cast<int>(v * 255.f + 0.5f);
          v = d8 && d8->in[code] == v ? d8->out[code] : decode_interp(v, lut);
        }
        o[3 * x + k] = v;
      }
    }
  }
  if (bad != INT64_MAX) fail_damaged_pixel(day, info, bad);
  return out;
}

ImageF linear_srgb_to_box_rgb(const ImageF& s) {
  const auto& M = spectrum::linear_srgb_to_box();
  ImageF out(s.width(), s.height(), 3, uninitialized, "box RGB (relative)");
  const size_t n = s.pixel_count();
#pragma omp parallel for schedule(static)
  for (size_t i = 0; i < n; ++i)
    for (int r = 0; r < 3; ++r) {
      const double v = M[r][0] * s[3 * i] + M[r][1] * s[3 * i + 1] + M[r][2] * s[3 * i + 2];
      out[3 * i + r] = static_cast<float>(std::max(0.0, v));  // out-of-gamut negatives clipped
    }
  return out;
}

double class_reflectance(int id, const ScenePreset& p) {
  switch (static_cast<Label>(id)) {
    case Label::TrafficSign: case Label::TrafficLight: return p.rho_sign;
    case Label::Building: case Label::Wall: case Label::Fence: case Label::GuardRail:
    case Label::Bridge: case Label::Tunnel: case Label::Pole: case Label::PoleGroup:
      return p.rho_construction;  // poles: concrete/galvanised, grouped with construction
    case Label::Person: case Label::Rider: return p.rho_human;
    case Label::Vegetation: case Label::Terrain: return p.rho_nature;
    case Label::Car: case Label::Truck: case Label::Bus: case Label::Caravan: case Label::Trailer:
    case Label::Train: case Label::Motorcycle: case Label::Bicycle: return p.rho_vehicle;
    case Label::Sky: return p.rho_sky;
    case Label::Road: case Label::Parking: case Label::Sidewalk: case Label::Ground:
    case Label::RailTrack: return p.rho_road;
    default:  // unlabeled, ego vehicle, border, out of roi, static, dynamic: mean of the others
      return (p.rho_sign + p.rho_construction + p.rho_human + p.rho_nature + p.rho_vehicle +
              p.rho_sky + p.rho_road) / 7.0;
  }
}

bool diffuse_class(int id) {
  switch (static_cast<Label>(id)) {
    case Label::Ground: case Label::Road: case Label::Sidewalk: case Label::Parking: case Label::RailTrack:
    case Label::Building: case Label::Wall: case Label::Fence: case Label::Bridge: case Label::Tunnel:
    case Label::Vegetation: case Label::Terrain: case Label::Person: case Label::Rider:
      return true;
    default:
      return false;
  }
}

double class_reflectance_max(int id, const ScenePreset& p) {
  // Diffuse surfaces (diffuse_class): a passive Lambertian reflector reflects at most the light it
  // receives (energy conservation), ρ ≤ 1 at every wavelength and so in every band. A brighter day
  // pixel under such a label is not the surface (kitti_000000: a sunlit façade seen through a
  // labelled tree crown) and is held at diffuse_max.
  if (diffuse_class(id)) return p.rho_diffuse_max;
  switch (static_cast<Label>(id)) {
    // Specular or retroreflective surfaces: a mirror lobe (car paint's clear coat, glass, chrome,
    // galvanised steel, a lamp's lens) or a retroreflector's cone sends more light toward the
    // camera than a white Lambertian surface would, so a pixel may exceed band reflectance 1
    // there (a glint), up to the preset's glint_max.
    case Label::Car: case Label::Truck: case Label::Bus: case Label::Caravan: case Label::Trailer:
    case Label::Train: case Label::Motorcycle: case Label::Bicycle:
    case Label::TrafficSign: case Label::TrafficLight: case Label::Pole: case Label::PoleGroup:
    case Label::GuardRail:
      return p.rho_glint_max;
    // The sky is no reflector (its texture is the day's relative luminance pattern, darken's
    // glow scale), and unlabeled, static, dynamic, ego vehicle and border pixels may be any
    // material: no reflectance bound applies; they keep the glint bound.
    default:
      return p.rho_glint_max;
  }
}

namespace {
// Box RGB v = M·s of a linear sRGB pixel s, negatives clipped (std::max(0.0, ·)), and its luminous
// efficacy Y = Σ_r K_r·v_r, in double: per pixel the same operations in the same order on every
// path below (no contraction into fused multiply-adds: -ffp-contract=off), so the same bits.
struct BoxCoef {
  double M[3][3], K[3];
};
// `gain`: the day photo's white balance (DayBalance), taken into the matrix, M·diag(gain): a
// gain of exactly 1 leaves M's coefficients as they are (the same bits as without a balance).
BoxCoef box_coef(const std::array<double, 3>& gain = {1.0, 1.0, 1.0}) {
  const auto& M = spectrum::linear_srgb_to_box();
  const auto& K = spectrum::band_luminous_efficacy_lm_per_W();
  BoxCoef c;
  for (int r = 0; r < 3; ++r) {
    for (int k = 0; k < 3; ++k) c.M[r][k] = M[r][k] * gain[k];
    c.K[r] = K[r];
  }
  return c;
}
inline void box_px(const float* s, const BoxCoef& c, double v[3]) {
  const double r = s[0], g = s[1], b = s[2];
  for (int k = 0; k < 3; ++k) v[k] = std::max(0.0, c.M[k][0] * r + c.M[k][1] * g + c.M[k][2] * b);
}
inline double box_y(const double v[3], const BoxCoef& c) { return ((0.0 + c.K[0] * v[0]) + c.K[1] * v[1]) + c.K[2] * v[2]; }

// Y of n pixels into y (pass 1 of reflectance_texture), and min(scale_k·float(v_k), cap) of n pixels
// into o (pass 2; one scale per band): the scalar loops, and AVX2 ones four pixels at a time with the same operations
// per pixel (max_pd(v, 0) is std::max(0.0, v) for every v, NaN and -0 included; min_ps(cap, p) is
// std::min(p, cap)).
void box_y_scalar(const float* s, int n, const BoxCoef& c, double* y) {
  for (int i = 0; i < n; ++i) {
    double v[3];
    box_px(s + 3 * i, c, v);
    y[i] = box_y(v, c);
  }
}
void box_scaled_scalar(const float* s, int n, const BoxCoef& c, const float* scale, float cap, float* o) {
  for (int i = 0; i < n; ++i) {
    double v[3];
    box_px(s + 3 * i, c, v);
    for (int k = 0; k < 3; ++k) o[3 * i + k] = std::min(scale[k] * static_cast<float>(v[k]), cap);
  }
}
#if defined(__x86_64__)
constexpr int sh(int a, int b, int c, int d) { return a | b << 2 | c << 4 | d << 6; }
struct BoxV { __m256d v[3]; };
// Four pixels' R, G and B (float) to their box RGB in double.
__attribute__((target("avx2"), always_inline)) inline BoxV box_math4(__m128 R, __m128 G, __m128 B, const BoxCoef& c) {
  const __m256d r = _mm256_cvtps_pd(R), g = _mm256_cvtps_pd(G), bl = _mm256_cvtps_pd(B), zero = _mm256_setzero_pd();
  BoxV o;
  for (int k = 0; k < 3; ++k) {
    const __m256d m = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(_mm256_set1_pd(c.M[k][0]), r),
                                                  _mm256_mul_pd(_mm256_set1_pd(c.M[k][1]), g)),
                                    _mm256_mul_pd(_mm256_set1_pd(c.M[k][2]), bl));
    o.v[k] = _mm256_max_pd(m, zero);
  }
  return o;
}
// Four interleaved RGB pixels (12 floats from s) to their box RGB in double.
__attribute__((target("avx2"))) inline BoxV box_x4(const float* s, const BoxCoef& c) {
  const __m128 a = _mm_loadu_ps(s), b = _mm_loadu_ps(s + 4), d = _mm_loadu_ps(s + 8);  // r0g0b0r1 g1b1r2g2 b2r3g3b3
  const __m128 R = _mm_shuffle_ps(a, _mm_shuffle_ps(b, d, sh(2, 2, 1, 1)), sh(0, 3, 0, 2));
  const __m128 G = _mm_shuffle_ps(_mm_shuffle_ps(a, b, sh(1, 1, 0, 0)), _mm_shuffle_ps(b, d, sh(3, 3, 2, 2)), sh(0, 2, 0, 2));
  const __m128 B = _mm_shuffle_ps(_mm_shuffle_ps(a, b, sh(2, 2, 1, 1)), _mm_shuffle_ps(d, d, sh(0, 3, 0, 3)), sh(0, 2, 0, 1));
  return box_math4(R, G, B, c);
}
// Y = ((0 + K0·v0) + K1·v1) + K2·v2 of four pixels' box RGB (box_y's operations). The first
// addition is left out: K0 > 0 and v0 = max(0, ·) >= +0 (never NaN or -0: max_pd gives its second
// operand, +0, for those), so K0·v0 is +0 or positive and 0 + K0·v0 is K0·v0 to the bit.
__attribute__((target("avx2"), always_inline)) inline __m256d box_y4(const BoxV& b, __m256d K0, __m256d K1, __m256d K2) {
  return _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(K0, b.v[0]), _mm256_mul_pd(K1, b.v[1])), _mm256_mul_pd(K2, b.v[2]));
}
// Eight interleaved RGB pixels (24 floats from s, three loads) as two BoxV (pixels 0-3, 4-7): each
// channel's eight floats picked from the three vectors by two blends (R as R0 R3 R6 R1 R4 R7 R2 R5,
// G as G5 G0 G3 G6 G1 G4 G7 G2, B as B2 B5 B0 B3 B6 B1 B4 B7) and put in pixel order by one lane
// permutation, then box_math4 on each half. (box_x4 takes eight 128-bit shuffles for four pixels,
// and box_scaled_avx2 nine more to interleave them back: in a profile of the night chain at the
// avx2 cap on this Zen 4 host, 1 thread, box_scaled_avx2 drew 591 samples and box_y_avx2 381
// against 373 and 284 for the AVX-512 twins, which split and join eight pixels by two-register
// permutes.)
struct BoxV2 { BoxV lo, hi; };
__attribute__((target("avx2"), always_inline)) inline BoxV2 box_x8_avx2(const float* s, const BoxCoef& c) {
  const __m256 a = _mm256_loadu_ps(s), b = _mm256_loadu_ps(s + 8), d = _mm256_loadu_ps(s + 16);
  const __m256 R = _mm256_permutevar8x32_ps(_mm256_blend_ps(_mm256_blend_ps(a, b, 0x92), d, 0x24),
                                            _mm256_setr_epi32(0, 3, 6, 1, 4, 7, 2, 5));
  const __m256 G = _mm256_permutevar8x32_ps(_mm256_blend_ps(_mm256_blend_ps(a, b, 0x24), d, 0x49),
                                            _mm256_setr_epi32(1, 4, 7, 2, 5, 0, 3, 6));
  const __m256 B = _mm256_permutevar8x32_ps(_mm256_blend_ps(_mm256_blend_ps(a, b, 0x49), d, 0x92),
                                            _mm256_setr_epi32(2, 5, 0, 3, 6, 1, 4, 7));
  return {box_math4(_mm256_castps256_ps128(R), _mm256_castps256_ps128(G), _mm256_castps256_ps128(B), c),
          box_math4(_mm256_extractf128_ps(R, 1), _mm256_extractf128_ps(G, 1), _mm256_extractf128_ps(B, 1), c)};
}
__attribute__((target("avx2"))) void box_y_avx2(const float* s, int n, const BoxCoef& c, double* y) {
  const __m256d K0 = _mm256_set1_pd(c.K[0]), K1 = _mm256_set1_pd(c.K[1]), K2 = _mm256_set1_pd(c.K[2]);
  int i = 0;
  for (; i + 8 <= n; i += 8) {
    const BoxV2 b = box_x8_avx2(s + 3 * i, c);
    _mm256_storeu_pd(y + i, box_y4(b.lo, K0, K1, K2));
    _mm256_storeu_pd(y + i + 4, box_y4(b.hi, K0, K1, K2));
  }
  for (; i + 4 <= n; i += 4) _mm256_storeu_pd(y + i, box_y4(box_x4(s + 3 * i, c), K0, K1, K2));
  // GCC 12 jumps to the scalar tail (a sibling call) without the vzeroupper that it puts before a
  // return, so the upper halves of the vector registers stayed dirty after every call: then each
  // SSE instruction of the generic code that follows (the split's block sums, its levels, its
  // opening, the texture's class sums) paid for them: the split's levels took 0.58 ms and its
  // opening 0.55 ms at 1 thread on aachen_000000, 0.23 and 0.33 ms with this vzeroupper (Zen 4;
  // docs/benchmarks.md "twenty-first session"). vzeroupper changes no value: it clears only the
  // registers' upper halves, and the tail's operands are scalars in the low lanes.
  _mm256_zeroupper();
  box_y_scalar(s + 3 * i, n - i, c, y + i);
}
// Eight pixels a step (box_x8_avx2), then four (box_x4), then the scalar tail. The eight are joined
// back as box_x8_avx2 split them: each channel's lanes permuted to the places they take in the
// three output vectors, then two blends a vector.
__attribute__((target("avx2"))) void box_scaled_avx2(const float* s, int n, const BoxCoef& c, const float* scale, float cap, float* o) {
  const __m128 sR = _mm_set1_ps(scale[0]), sG = _mm_set1_ps(scale[1]), sB = _mm_set1_ps(scale[2]), cp = _mm_set1_ps(cap);
  const __m256 sR8 = _mm256_set1_ps(scale[0]), sG8 = _mm256_set1_ps(scale[1]), sB8 = _mm256_set1_ps(scale[2]);
  const __m256 cp8 = _mm256_set1_ps(cap);
  int i = 0;
  for (; i + 8 <= n; i += 8) {
    const BoxV2 b = box_x8_avx2(s + 3 * i, c);
    // min(cap, scale·float(v)) per lane: the four-pixel loop's operations.
    auto band = [&](int k, __m256 sc) __attribute__((target("avx2"), always_inline)) {
      return _mm256_min_ps(cp8, _mm256_mul_ps(sc, _mm256_set_m128(_mm256_cvtpd_ps(b.hi.v[k]), _mm256_cvtpd_ps(b.lo.v[k]))));
    };
    const __m256 R = _mm256_permutevar8x32_ps(band(0, sR8), _mm256_setr_epi32(0, 3, 6, 1, 4, 7, 2, 5));
    const __m256 G = _mm256_permutevar8x32_ps(band(1, sG8), _mm256_setr_epi32(5, 0, 3, 6, 1, 4, 7, 2));
    const __m256 B = _mm256_permutevar8x32_ps(band(2, sB8), _mm256_setr_epi32(2, 5, 0, 3, 6, 1, 4, 7));
    float* q = o + 3 * i;
    _mm256_storeu_ps(q, _mm256_blend_ps(_mm256_blend_ps(R, G, 0x92), B, 0x24));       // R0 G0 B0 R1 G1 B1 R2 G2
    _mm256_storeu_ps(q + 8, _mm256_blend_ps(_mm256_blend_ps(R, G, 0x24), B, 0x49));   // B2 R3 G3 B3 R4 G4 B4 R5
    _mm256_storeu_ps(q + 16, _mm256_blend_ps(_mm256_blend_ps(R, G, 0x49), B, 0x92));  // G5 B5 R6 G6 B6 R7 G7 B7
  }
  for (; i + 4 <= n; i += 4) {
    const BoxV b = box_x4(s + 3 * i, c);
    const __m128 R = _mm_min_ps(cp, _mm_mul_ps(sR, _mm256_cvtpd_ps(b.v[0])));
    const __m128 G = _mm_min_ps(cp, _mm_mul_ps(sG, _mm256_cvtpd_ps(b.v[1])));
    const __m128 B = _mm_min_ps(cp, _mm_mul_ps(sB, _mm256_cvtpd_ps(b.v[2])));
    float* q = o + 3 * i;
    _mm_storeu_ps(q, _mm_shuffle_ps(_mm_shuffle_ps(R, G, sh(0, 0, 0, 0)), _mm_shuffle_ps(B, R, sh(0, 0, 1, 1)), sh(0, 2, 0, 2)));
    _mm_storeu_ps(q + 4, _mm_shuffle_ps(_mm_shuffle_ps(G, B, sh(1, 1, 1, 1)), _mm_shuffle_ps(R, G, sh(2, 2, 2, 2)), sh(0, 2, 0, 2)));
    _mm_storeu_ps(q + 8, _mm_shuffle_ps(_mm_shuffle_ps(B, R, sh(2, 2, 3, 3)), _mm_shuffle_ps(G, B, sh(3, 3, 3, 3)), sh(0, 2, 0, 2)));
  }
  box_scaled_scalar(s + 3 * i, n - i, c, scale, cap, o + 3 * i);
}
// The same, eight pixels at a time in 512-bit registers: the 24 floats of eight pixels split into
// R, G and B by two-register permutes (and joined back the same way).
// (GCC 12's 512-bit intrinsics start from _mm512_undefined_*(), a self-initialised variable
// that -Wmaybe-uninitialized reports inside avx512fintrin.h: silenced for these functions only.)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#define PHOTOSITE_AVX512 __attribute__((target("avx512f")))
struct BoxV8 { __m512d v[3]; };
PHOTOSITE_AVX512 inline BoxV8 box_x8(const float* s, const BoxCoef& c) {
  const __m512 a = _mm512_loadu_ps(s), b = _mm512_castps256_ps512(_mm256_loadu_ps(s + 16));
  const __m512i iR = _mm512_setr_epi32(0, 3, 6, 9, 12, 15, 18, 21, 0, 0, 0, 0, 0, 0, 0, 0);
  const __m512i iG = _mm512_setr_epi32(1, 4, 7, 10, 13, 16, 19, 22, 0, 0, 0, 0, 0, 0, 0, 0);
  const __m512i iB = _mm512_setr_epi32(2, 5, 8, 11, 14, 17, 20, 23, 0, 0, 0, 0, 0, 0, 0, 0);
  const __m512d r = _mm512_cvtps_pd(_mm512_castps512_ps256(_mm512_permutex2var_ps(a, iR, b)));
  const __m512d g = _mm512_cvtps_pd(_mm512_castps512_ps256(_mm512_permutex2var_ps(a, iG, b)));
  const __m512d bl = _mm512_cvtps_pd(_mm512_castps512_ps256(_mm512_permutex2var_ps(a, iB, b)));
  const __m512d zero = _mm512_setzero_pd();
  BoxV8 o;
  for (int k = 0; k < 3; ++k) {
    const __m512d m = _mm512_add_pd(_mm512_add_pd(_mm512_mul_pd(_mm512_set1_pd(c.M[k][0]), r),
                                                  _mm512_mul_pd(_mm512_set1_pd(c.M[k][1]), g)),
                                    _mm512_mul_pd(_mm512_set1_pd(c.M[k][2]), bl));
    o.v[k] = _mm512_max_pd(m, zero);
  }
  return o;
}
PHOTOSITE_AVX512 void box_y_avx512(const float* s, int n, const BoxCoef& c, double* y) {
  const __m512d K0 = _mm512_set1_pd(c.K[0]), K1 = _mm512_set1_pd(c.K[1]), K2 = _mm512_set1_pd(c.K[2]);
  int i = 0;
  for (; i + 8 <= n; i += 8) {
    const BoxV8 b = box_x8(s + 3 * i, c);
    // box_y4's operations (its first addition, of +0, left out to the same bits).
    const __m512d t = _mm512_add_pd(_mm512_add_pd(_mm512_mul_pd(K0, b.v[0]), _mm512_mul_pd(K1, b.v[1])),
                                    _mm512_mul_pd(K2, b.v[2]));
    _mm512_storeu_pd(y + i, t);
  }
  _mm256_zeroupper();  // before the sibling call to the scalar tail (see box_y_avx2)
  box_y_scalar(s + 3 * i, n - i, c, y + i);
}
PHOTOSITE_AVX512 void box_scaled_avx512(const float* s, int n, const BoxCoef& c, const float* scale, float cap, float* o) {
  const __m256 sR = _mm256_set1_ps(scale[0]), sG = _mm256_set1_ps(scale[1]), sB = _mm256_set1_ps(scale[2]);
  const __m256 cp = _mm256_set1_ps(cap);
  // Output lanes: r0 g0 b0 r1 ... from R (lanes 0-7 of rg), G (lanes 8-15 of rg) and B (lanes 0-7 of bb).
  const __m512i i0 = _mm512_setr_epi32(0, 8, 16, 1, 9, 17, 2, 10, 18, 3, 11, 19, 4, 12, 20, 5);
  const __m512i i1 = _mm512_setr_epi32(13, 21, 6, 14, 22, 7, 15, 23, 0, 0, 0, 0, 0, 0, 0, 0);
  int i = 0;
  for (; i + 8 <= n; i += 8) {
    const BoxV8 b = box_x8(s + 3 * i, c);
    const __m256 R = _mm256_min_ps(cp, _mm256_mul_ps(sR, _mm512_cvtpd_ps(b.v[0])));
    const __m256 G = _mm256_min_ps(cp, _mm256_mul_ps(sG, _mm512_cvtpd_ps(b.v[1])));
    const __m256 B = _mm256_min_ps(cp, _mm256_mul_ps(sB, _mm512_cvtpd_ps(b.v[2])));
    const __m512 rg = _mm512_castpd_ps(_mm512_insertf64x4(_mm512_castps_pd(_mm512_castps256_ps512(R)), _mm256_castps_pd(G), 1));
    const __m512 bb = _mm512_castps256_ps512(B);
    _mm512_storeu_ps(o + 3 * i, _mm512_permutex2var_ps(rg, i0, bb));
    _mm256_storeu_ps(o + 3 * i + 16, _mm512_castps512_ps256(_mm512_permutex2var_ps(rg, i1, bb)));
  }
  box_scaled_scalar(s + 3 * i, n - i, c, scale, cap, o + 3 * i);
}
#undef PHOTOSITE_AVX512
#pragma GCC diagnostic pop
// 2: AVX-512, 1: AVX2, 0: scalar; texture_max_isa() caps it (tests run each path).
const int kIsa = photosite::detail::machine_isa_level();
#else
constexpr int kIsa = 0;
#endif
void box_y_block(const float* s, int n, const BoxCoef& c, double* y) {
#if defined(__x86_64__)
  const int isa = std::min(kIsa, max_isa);
  if (isa == 2) return box_y_avx512(s, n, c, y);
  if (isa == 1) return box_y_avx2(s, n, c, y);
#endif
  box_y_scalar(s, n, c, y);
}
void box_scaled_block(const float* s, int n, const BoxCoef& c, const float* scale, float cap, float* o) {
#if defined(__x86_64__)
  const int isa = std::min(kIsa, max_isa);
  if (isa == 2) return box_scaled_avx512(s, n, c, scale, cap, o);
  if (isa == 1) return box_scaled_avx2(s, n, c, scale, cap, o);
#endif
  box_scaled_scalar(s, n, c, scale, cap, o);
}
// The sun/shade split's placement of n pixels by their own light (sun_shade_split): o[i] becomes 1
// where the pixel is brighter than lum_mid (Y = Σ K_k v_k) and of the sun's colour (v_B <
// chroma·v_R), 0 where darker and of the shade's colour, and o[i] & 1 (its block's side) where the
// two disagree. The scalar loop, and AVX2 four pixels at a time with the same operations per
// pixel (box_x4), so the same bits.
void own_light_scalar(const float* s, int n, const BoxCoef& c, double lum_mid, double chroma, uint8_t* o) {
  for (int i = 0; i < n; ++i) {
    double v[3];
    box_px(s + 3 * i, c, v);
    const bool lum = box_y(v, c) > lum_mid;
    const bool col = v[2] < chroma * v[0];
    o[i] = lum == col ? lum : o[i] & 1;
  }
}
#if defined(__x86_64__)
__attribute__((target("avx2"))) void own_light_avx2(const float* s, int n, const BoxCoef& c, double lum_mid, double chroma,
                                                    uint8_t* o) {
  const __m256d K0 = _mm256_set1_pd(c.K[0]), K1 = _mm256_set1_pd(c.K[1]), K2 = _mm256_set1_pd(c.K[2]);
  const __m256d mid = _mm256_set1_pd(lum_mid), ch = _mm256_set1_pd(chroma);
  int i = 0;
  for (; i + 4 <= n; i += 4) {
    const BoxV b = box_x4(s + 3 * i, c);
    const __m256d y = box_y4(b, K0, K1, K2);
    const int lum = _mm256_movemask_pd(_mm256_cmp_pd(y, mid, _CMP_GT_OQ));
    const int col = _mm256_movemask_pd(_mm256_cmp_pd(b.v[2], _mm256_mul_pd(ch, b.v[0]), _CMP_LT_OQ));
    for (int k = 0; k < 4; ++k) {
      const int l = lum >> k & 1;
      o[i + k] = l == (col >> k & 1) ? static_cast<uint8_t>(l) : o[i + k] & 1;
    }
  }
  _mm256_zeroupper();  // before the sibling call to the scalar tail (see box_y_avx2)
  own_light_scalar(s + 3 * i, n - i, c, lum_mid, chroma, o + i);
}
#endif
void own_light_block(const float* s, int n, const BoxCoef& c, double lum_mid, double chroma, uint8_t* o) {
#if defined(__x86_64__)
  if (std::min(kIsa, max_isa) >= 1) return own_light_avx2(s, n, c, lum_mid, chroma, o);
#endif
  own_light_scalar(s, n, c, lum_mid, chroma, o);
}
// The sun/shade split's 3 x 3 majority (sun_shade_split) at pixel x of row y: 1 where more than
// half of the pixels of x's label in its neighbourhood (clipped at the frame's edges; up/dn null
// at the first and last rows) are sunlit in the levels lv (up, dn: the rows above and below).
inline uint8_t majority_px(const uint16_t* lu, const uint16_t* lr, const uint16_t* ld, const uint8_t* up,
                           const uint8_t* lv, const uint8_t* dn, int x, int W) {
  const int a = std::max(0, x - 1), b = std::min(W - 1, x + 1);
  const uint16_t id = lr[x];
  int n_all = 0, n_sun = 0;
  auto count = [&](const uint16_t* l, const uint8_t* v) {
    for (int xx = a; xx <= b; ++xx) {
      const int same = l[xx] == id;
      n_all += same;
      n_sun += same & v[xx];
    }
  };
  if (up) count(lu, up);
  count(lr, lv);
  if (dn) count(ld, dn);
  return 2 * n_sun > n_all;
}
// majority_px of the pixels x0 .. x1 - 1 into o. With AVX2 sixteen pixels at a time where their
// neighbourhoods lie inside the row (1 ≤ x, x + 16 ≤ W − 1): the same counts in 16-bit lanes, so
// the same values; the rest one by one.
void majority_scalar(const uint16_t* lu, const uint16_t* lr, const uint16_t* ld, const uint8_t* up, const uint8_t* lv,
                     const uint8_t* dn, int x0, int x1, int W, uint8_t* o) {
  for (int x = x0; x < x1; ++x) o[x] = majority_px(lu, lr, ld, up, lv, dn, x, W);
}
#if defined(__x86_64__)
// One row's three neighbours of sixteen pixels (l, v at the first pixel) counted into n_all (same
// label as id) and n_sun (and sunlit).
__attribute__((target("avx2"), always_inline)) inline void majority_count16(const uint16_t* l, const uint8_t* v, __m256i id,
                                                                           __m256i& n_all, __m256i& n_sun) {
  for (int d = -1; d <= 1; ++d) {
    const __m256i eq = _mm256_cmpeq_epi16(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(l + d)), id);
    const __m256i vv = _mm256_cvtepu8_epi16(_mm_loadu_si128(reinterpret_cast<const __m128i*>(v + d)));
    n_all = _mm256_sub_epi16(n_all, eq);  // eq is −1 where the label is the same
    n_sun = _mm256_add_epi16(n_sun, _mm256_and_si256(eq, vv));
  }
}
__attribute__((target("avx2"))) void majority_avx2(const uint16_t* lu, const uint16_t* lr, const uint16_t* ld,
                                                   const uint8_t* up, const uint8_t* lv, const uint8_t* dn, int x0,
                                                   int x1, int W, uint8_t* o) {
  int x = x0;
  if (x == 0 && x < x1) {
    o[0] = majority_px(lu, lr, ld, up, lv, dn, 0, W);
    x = 1;
  }
  const __m256i lane = _mm256_setr_epi16(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
  const __m256i one = _mm256_set1_epi16(1);
  for (; x < x1 && x + 16 <= W - 1; x += 16) {
    const __m256i id = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(lr + x));
    __m256i n_all = _mm256_setzero_si256(), n_sun = _mm256_setzero_si256();
    if (up) majority_count16(lu + x, up + x, id, n_all, n_sun);
    majority_count16(lr + x, lv + x, id, n_all, n_sun);
    if (dn) majority_count16(ld + x, dn + x, id, n_all, n_sun);
    const __m256i maj = _mm256_and_si256(_mm256_cmpgt_epi16(_mm256_slli_epi16(n_sun, 1), n_all), one);
    // Lanes x + k ≥ x1 keep what o holds.
    const __m256i in = _mm256_cmpgt_epi16(_mm256_set1_epi16(static_cast<int16_t>(std::min(16, x1 - x))), lane);
    const __m256i old = _mm256_cvtepu8_epi16(_mm_loadu_si128(reinterpret_cast<const __m128i*>(o + x)));
    const __m256i r = _mm256_blendv_epi8(old, maj, in);
    _mm_storeu_si128(reinterpret_cast<__m128i*>(o + x),
                     _mm_packus_epi16(_mm256_castsi256_si128(r), _mm256_extracti128_si256(r, 1)));
  }
  majority_scalar(lu, lr, ld, up, lv, dn, x, x1, W, o);
}
#endif
void majority_block(const uint16_t* lu, const uint16_t* lr, const uint16_t* ld, const uint8_t* up, const uint8_t* lv,
                    const uint8_t* dn, int x0, int x1, int W, uint8_t* o) {
#if defined(__x86_64__)
  if (std::min(kIsa, max_isa) >= 1) return majority_avx2(lu, lr, ld, up, lv, dn, x0, x1, W, o);
#endif
  majority_scalar(lu, lr, ld, up, lv, dn, x0, x1, W, o);
}
constexpr int kBoxBlock = 256;
// Pass 1 of reflectance_texture: per chunk ch of kTextureChunks (pixels [n·ch/64, n·(ch+1)/64)),
// the sums of Y per class (in pixel order) and the pixel counts, into part[ch]. block(ch, first,
// count) gives the linear sRGB pixels first..first+count-1 (3 floats each) of chunk ch: the
// image itself, or a block that the linearisation has just written (linearize_with_texture_sums).
// The box RGB is not stored: pass 2 computes it again from the linear image (cheaper than
// writing it out and reading it back).
constexpr int kTextureChunks = 64;
// after(first, count, y) is called with the Y of each block of pixels first .. first + count − 1
// once it is computed (the sun/shade split's block sums take them there: SunPassRows).
template <class Block, class After>
void texture_class_sums(const uint16_t* lab, size_t n, const BoxCoef& coef, std::array<double, 2 * kLabelCount>* part,
                        const Block& block, const After& after) {
  constexpr int kChunks = kTextureChunks;
  // Each chunk's sums are a chain of dependent additions (Y of each pixel added to its class's
  // running sum, in pixel order), bound by the adder's latency; kStreams chunks are walked side by
  // side, pixel j of each in turn, so that their chains overlap. A class's running sum is held in
  // a register along a run of one label and stored at its end. Per chunk, the same additions in
  // the same order as adding pixel by pixel into its sums: the same bits.
  constexpr int kStreams = 4;
  static_assert(kChunks % kStreams == 0);
#pragma omp parallel for schedule(static)
  for (int grp = 0; grp < kChunks / kStreams; ++grp) {
    struct Stream {
      size_t base = 0, len = 0, start = 0;  // chunk's first pixel, its length, current run's start (from base)
      int cur = 0;                          // current run's label
      double acc = 0;                       // its class's running sum
      double* ps = nullptr;                 // the chunk's sums, then counts
    } st[kStreams];
    size_t common = SIZE_MAX;
    for (int k = 0; k < kStreams; ++k) {
      const int ch = grp * kStreams + k;
      Stream& S = st[k];
      S.ps = part[ch].data();
      part[ch].fill(0.0);
      S.base = n * ch / kChunks;
      S.len = n * (ch + 1) / kChunks - S.base;
      S.cur = S.len > 0 ? lab[S.base] : 0;
      common = std::min(common, S.len);
    }
    auto step = [&](Stream& S, size_t j, double y) {
      const int id = lab[S.base + j];
      if (id != S.cur) [[unlikely]] {
        S.ps[S.cur] = S.acc;
        S.ps[kLabelCount + S.cur] += static_cast<double>(j - S.start);  // a count: exact in a double (< 2^53)
        S.cur = id;
        S.acc = S.ps[id];
        S.start = j;
      }
      S.acc += y;
    };
    double ys[kStreams][kBoxBlock];
    for (size_t b = 0; b < common; b += kBoxBlock) {
      const int nb = static_cast<int>(std::min<size_t>(kBoxBlock, common - b));
      for (int k = 0; k < kStreams; ++k) {
        box_y_block(block(grp * kStreams + k, st[k].base + b, nb), nb, coef, ys[k]);
        after(st[k].base + b, nb, ys[k]);
      }
      for (int j = 0; j < nb; ++j) {
#pragma GCC unroll 4
        for (int k = 0; k < kStreams; ++k) step(st[k], b + j, ys[k][j]);
      }
    }
    for (int k = 0; k < kStreams; ++k) {  // the chunks' last pixels beyond the common length (at most one)
      Stream& S = st[k];
      for (size_t j = common; j < S.len; ++j) {
        double y;
        box_y_block(block(grp * kStreams + k, S.base + j, 1), 1, coef, &y);
        after(S.base + j, 1, &y);
        step(S, j, y);
      }
      S.ps[S.cur] = S.acc;
      S.ps[kLabelCount + S.cur] += static_cast<double>(S.len - S.start);
    }
  }
}
}  // namespace

// ---- The day's sunlight in the texture ------------------------------------------------------
// Model. A diffuse (Lambertian) surface of reflectance ρ(x) under the day's illuminance E(x) is
// seen as Y(x) ∝ ρ(x)·E(x). Outdoors E is two levels: the shade, lit by the sky alone, and the
// sunlit parts, lit by the sky and the direct sun, brighter by g = (E_sky + E_sun)/E_sky: about 5
// at midday under a clear sky (bright sunlight 110,000 lx against 20,000 lx in the shade lit by the
// whole clear sky; Wikipedia "Daylight" table) and up to 10 in the shade of a tree (100,000 lx in
// the open, 10,000 lx under a tree, summer, cloudless; CIBSE via the IES VE manual, "Examples of
// illuminance"), both read through the `search` tool [S]. At night neither the sun nor the sky
// lights the scene, so the texture must carry ρ alone: the sunlit level is divided by g. Within a
// class, sunlit and shaded regions are assumed to share one distribution of reflectance (the same
// asphalt, the same façade), so g is the ratio of the two levels' mean luminances, held to
// [1, sun_shade_ratio_max].
// Where the sun falls is found from the illumination's scale: sunlit and shaded regions are large
// (metres), the texture and the reflectance's own fine detail are small. Per class: the mean Y over
// blocks of the image (about 1/256 of its width; every other row sampled), its log, then a
// grey-scale opening (erosion then dilation, each over the class's own blocks only) with a square
// of sun_shade_window_fraction of the image width. The opening removes every bright structure
// narrower than the square, such as a lane marking (white paint, a reflectance: it must survive
// and does, since its block values never enter the level decision) and sunlit slivers too thin to
// be told from texture, and keeps the level of larger regions with their edges in place. The two
// levels are split by the isodata threshold (Ridler and Calvard 1978: the threshold halfway between
// the means of the two sides). A class is split only when each level covers at least one square,
// their ratio is at least sun_shade_ratio_min (a smaller step is as likely a change of material
// or of orientation as a shadow; photosite choice), and the shade is bluer than the sunlit level
// by at least what the sun against the sky's light makes (sun_blue_contrast; levels closer in
// colour are a material, an orientation or an overcast sky's shading). Then each pixel of the
// class is placed by its own light: by its luminance against the levels' geometric mean and by its
// colour, since the shade is lit by the blue sky alone and the sunlit level mostly by the far
// redder sun, while a white marking takes the colour of the light it lies under (where the two
// disagree, its block's side); then by the majority of its 3 x 3 neighbours. So shadow edges are
// placed to the pixel, not on the block grid, a marking in the shade stays in the shade, and sun
// or shade narrower than the opening's square (a wedge's tip, a pole's shadow) is still found. The shade level also loses the
// sky's blue cast: per band, the factor that gives it the sunlit level's colour at its own
// luminance (von Kries; the day camera's white balance made the sunlit level neutral).
// What it does not model: penumbrae and gradual shading (one ratio per class, two levels), surfaces
// at several angles to the sun (one g per class), and a step of material that looks like a shadow
// (a white façade beside a dark one is flattened as one material would be).
namespace {
struct SunGrid {
  int B = 1, nbx = 0, nby = 0, r = 1;
  size_t nb() const { return static_cast<size_t>(nbx) * nby; }
};
SunGrid sun_grid(int width, int height, double window_fraction) {
  SunGrid g;
  g.B = std::max(1, (width + 255) / 256);
  g.nbx = (width + g.B - 1) / g.B;
  g.nby = (height + g.B - 1) / g.B;
  // The opening's square, (2r + 1) blocks: the odd count nearest window_fraction of the width (at least 3).
  g.r = std::max(1, static_cast<int>(std::lround((window_fraction * width / g.B - 1) / 2)));
  return g;
}
struct BlockBox { int x0, x1, y0, y1; };  // blocks' bounding box (inclusive)
// The grey-scale opening of a class's block levels v (a w x h box of the grid, row-major): a
// separable masked min (erosion) then max (dilation), each over a (2r+1)² square clipped at the
// box; absent blocks (present[i] == 0) neither give nor take a value. Blocks outside the box are
// all absent, so the same values as over the whole grid. Absent blocks hold the operation's
// neutral value (+inf for min, -inf for max), so each pass is a plain min or max over shifted rows
// (vectorised); the eroded field is taken into the dilation as it is, its absent blocks set to
// -inf.
// (Clones for AVX-512 and AVX2: min and max of floats without NaN are exact, so the same values
// sixteen or eight at a time.)
PHOTOSITE_TARGET_CLONES
void masked_opening(std::vector<float>& v, const std::vector<uint8_t>& present, int w, int h, int r) {
  const size_t nl = static_cast<size_t>(w) * h;
  std::vector<float> src(nl), t(nl);
  for (size_t i = 0; i < nl; ++i) src[i] = present[i] ? v[i] : INFINITY;
  for (int erode = 1; erode >= 0; --erode) {
    const float none = erode ? INFINITY : -INFINITY;
    auto pick = [erode](float a, float b) { return erode ? std::min(a, b) : std::max(a, b); };
    std::fill(t.begin(), t.end(), none);
    for (int y = 0; y < h; ++y) {  // along rows
      const float* in = src.data() + static_cast<size_t>(y) * w;
      float* o = t.data() + static_cast<size_t>(y) * w;
      for (int d = -r; d <= r; ++d) {
        const int x0 = std::max(0, -d), x1 = std::min(w, w - d);
        for (int x = x0; x < x1; ++x) o[x] = pick(o[x], in[x + d]);
      }
    }
    std::fill(src.begin(), src.end(), none);
    for (int y = 0; y < h; ++y) {  // along columns
      float* o = src.data() + static_cast<size_t>(y) * w;
      for (int yy = std::max(0, y - r); yy <= std::min(h - 1, y + r); ++yy) {
        const float* in = t.data() + static_cast<size_t>(yy) * w;
        for (int x = 0; x < w; ++x) o[x] = pick(o[x], in[x]);
      }
    }
    if (erode)
      for (size_t i = 0; i < nl; ++i) src[i] = present[i] ? src[i] : -INFINITY;
  }
  for (size_t i = 0; i < nl; ++i)
    if (present[i]) v[i] = src[i];
}
// The split's edge blocks over a class's w x h box: ed[i] = 1 where block i is absent (present[i]
// = 0), or present with a present neighbour (8-connected, inside the box) on the other side (sd:
// 0 or 1, 0 where absent). Branch-free over each row's interior columns (an absent neighbour
// adds present = 0; the block itself adds sd ^ own = 0), so the AVX2 clone takes 32 blocks at a
// time; the same flags as testing the neighbours one by one.
__attribute__((target_clones("avx2", "default")))
void edge_blocks_of(const uint8_t* __restrict present, const uint8_t* __restrict sd, int w, int h, uint8_t* __restrict ed) {
  for (int y = 0; y < h; ++y) {
    const uint8_t* own = sd + static_cast<size_t>(y) * w;
    uint8_t* e = ed + static_cast<size_t>(y) * w;
    std::fill(e, e + w, 0);
    for (int yy = std::max(0, y - 1); yy <= std::min(h - 1, y + 1); ++yy) {
      const uint8_t* P = present + static_cast<size_t>(yy) * w;
      const uint8_t* S = sd + static_cast<size_t>(yy) * w;
      for (int x = 1; x + 1 < w; ++x)
        e[x] |= (P[x - 1] & (S[x - 1] ^ own[x])) | (P[x] & (S[x] ^ own[x])) | (P[x + 1] & (S[x + 1] ^ own[x]));
      for (int x : {0, w - 1}) {  // the box's first and last columns (one column when w = 1)
        for (int xx = std::max(0, x - 1); xx <= std::min(w - 1, x + 1); ++xx) e[x] |= P[xx] & (S[xx] ^ own[x]);
        if (w == 1) break;
      }
    }
    const uint8_t* pr = present + static_cast<size_t>(y) * w;
    for (int x = 0; x < w; ++x) e[x] = pr[x] ? e[x] : 1;
  }
}
// The sun/shade split's block sums (sun_shade_split, phase 1): the Y values y[0 .. x1 − x0) of
// pixels x0 .. x1 − 1, a run of one class in one row (or a piece of it: a run taken in pieces
// adds the same values in the same order to each block), added into the sums ys[bx] and counts yc[bx] of the blocks they lie in
// (bx = x / B). Each block's sum takes its pixels in pixel order, in one running sum, as adding
// pixel by pixel does; L whole blocks are added side by side, pixel j of each in turn, so that the
// blocks' chains of dependent additions (each bound by the adder's latency) overlap instead of
// following each other. The same additions in the same order per block: the same bits.
// (BC: the block edge B as a constant where it is 8 — frames 1793 to 2048 pixels wide, Cityscapes'
// — so that the compiler unrolls the blocks' pixels; 0: B at run time. The same additions.)
template <int L, int BC>
inline void add_blocks_side_by_side(const double* y, int B, double* ys, double* yc) {
  if constexpr (BC > 0) B = BC;
  double acc[L];
  for (int k = 0; k < L; ++k) acc[k] = ys[k];
  for (int j = 0; j < B; ++j)
    for (int k = 0; k < L; ++k) acc[k] += y[k * B + j];
  for (int k = 0; k < L; ++k) {
    ys[k] = acc[k];
    yc[k] += B;
  }
}
template <int BC>
void add_run_to_blocks_b(const double* y, int x0, int x1, int B, double* ys, double* yc) {
  if constexpr (BC > 0) B = BC;
  for (int x = x0, bx = x0 / B; x < x1;) {  // y[x − x0]: pixel x's Y
    const int whole = x % B == 0 ? (x1 - x) / B : 0;  // whole blocks from x on
    const int k = whole >= 8 ? 8 : whole >= 4 ? 4 : whole >= 2 ? 2 : 1;
    if (k == 8) add_blocks_side_by_side<8, BC>(y + (x - x0), B, ys + bx, yc + bx);
    else if (k == 4) add_blocks_side_by_side<4, BC>(y + (x - x0), B, ys + bx, yc + bx);
    else if (k == 2) add_blocks_side_by_side<2, BC>(y + (x - x0), B, ys + bx, yc + bx);
    else {  // one block, or the run's part of it
      const int xe = std::min(x1, (bx + 1) * B);
      double acc = ys[bx];
      for (int xi = x; xi < xe; ++xi) acc += y[xi - x0];
      ys[bx] = acc;
      yc[bx] += xe - x;
      x = xe;
      ++bx;
      continue;
    }
    x += k * B;
    bx += k;
  }
}
void add_run_to_blocks(const double* y, int x0, int x1, int B, double* ys, double* yc) {
  if (B == 8) add_run_to_blocks_b<8>(y, x0, x1, B, ys, yc);
  else add_run_to_blocks_b<0>(y, x0, x1, B, ys, yc);
}
// Phase 1 of the split over pixels x0 .. x1 − 1 of row `lr` (labels), a row of block row by: per
// run of one label whose class has a slot (slot[id] >= 0; runs cut at x0 and x1), its Y
// (y_of(x, e): a pointer to the Y of pixels x .. e − 1) added into the class's blocks
// (add_run_to_blocks: ysum, ycnt at slot·nb, block by·nbx + bx) and the block row's range of
// blocks [row_x0, row_x1] (at slot·nby + by) widened to the run's. The blocks new to the range
// are zeroed first, so each block's sum starts from 0 whichever run reaches it first (the arrays
// need not be zeroed beforehand), and the same sums whichever pieces the rows come in.
template <class YOf>
void add_row_to_blocks(const uint16_t* lr, int x0, int x1, int by, const int* slot, const SunGrid& g, const YOf& y_of,
                       double* ysum, double* ycnt, int* row_x0, int* row_x1) {
  for (int x = x0; x < x1;) {
    const int e = run_end(lr, x, x1);
    const int s = lr[x] < kLabelCount ? slot[lr[x]] : -1;
    if (s < 0) { x = e; continue; }
    const size_t b0 = s * g.nb() + static_cast<size_t>(by) * g.nbx;
    const size_t r = static_cast<size_t>(s) * g.nby + by;
    const int bx0 = x / g.B, bx1 = (e - 1) / g.B;
    auto zero = [&](int a, int b) {  // blocks a .. b
      std::fill(ysum + b0 + a, ysum + b0 + b + 1, 0.0);
      std::fill(ycnt + b0 + a, ycnt + b0 + b + 1, 0.0);
    };
    if (row_x0[r] > row_x1[r]) {
      zero(bx0, bx1);
      row_x0[r] = bx0;
      row_x1[r] = bx1;
    } else {
      if (bx0 < row_x0[r]) zero(bx0, row_x0[r] - 1), row_x0[r] = bx0;
      if (bx1 > row_x1[r]) zero(row_x1[r] + 1, bx1), row_x1[r] = bx1;
    }
    add_run_to_blocks(y_of(x, e), x, e, g.B, ysum + b0, ycnt + b0);
    x = e;
  }
}
// Whether row y of the grid is sampled by phase 1 (every other row of a block; all where B = 1).
inline bool sun_row_sampled(int y, const SunGrid& g) { return g.B == 1 || (y % g.B) % 2 == 0; }
// The diffuse classes' slots (sun_diffuse_slot) and their count.
struct DiffuseSlots {
  int slot[kLabelCount], count = 0;
  DiffuseSlots() {
    for (int id = 0; id < kLabelCount; ++id) slot[id] = diffuse_class(id) ? count++ : -1;
  }
};
const DiffuseSlots& diffuse_slots() {
  static const DiffuseSlots d;
  return d;
}
// SunBlockSums for a W x H frame, its arrays allocated (not zeroed: add_row_to_blocks zeroes what
// it reaches) and no block row's range set; `chunks` > 0: made only the block rows whose sampled
// pixels lie in one of that many chunks (pixels [n·c/chunks, n·(c + 1)/chunks), texture_class_sums'),
// else every block row.
std::shared_ptr<SunBlockSums> new_sun_block_sums(const float* image, const uint16_t* labels, int W, int H, int chunks) {
  const SunGrid g = sun_grid(W, H, 0.03);  // (the block edge depends on the width alone)
  auto s = std::make_shared<SunBlockSums>();
  s->image = image;
  s->labels = labels;
  s->width = W;
  s->height = H;
  s->block_px = g.B;
  s->nbx = g.nbx;
  s->nby = g.nby;
  const size_t nd = diffuse_slots().count;
  s->ysum.reset(new double[nd * g.nb()]);
  s->ycnt.reset(new double[nd * g.nb()]);
  s->row_x0.assign(nd * g.nby, g.nbx);
  s->row_x1.assign(nd * g.nby, -1);
  s->made.assign(g.nby, 1);
  const size_t n = static_cast<size_t>(W) * H;
  for (int by = 0; by < g.nby && chunks > 0; ++by) {
    const int y0 = by * g.B, y_end = std::min(H, (by + 1) * g.B);
    int y1 = y0;  // the last sampled row
    for (int y = y0; y < y_end; ++y)
      if (sun_row_sampled(y, g)) y1 = y;
    const size_t first = static_cast<size_t>(y0) * W, last = (static_cast<size_t>(y1) + 1) * W - 1;
    for (int c = 1; c < chunks; ++c) {
      const size_t start = n * c / chunks;
      if (first < start && start <= last) s->made[by] = 0;  // a chunk starts inside the row's samples
    }
  }
  return s;
}
// texture_class_sums' `after` for the split's block sums made in the linearisation's pass: the Y
// of each block of pixels added into the block rows it made (SunBlockSums::made), row piece by
// row piece. Each made block row lies in one chunk, whose pixels one thread walks in order, so
// each block's sum takes its pixels in pixel order: the split's own additions (its phase 1).
struct SunPassRows {
  SunBlockSums* s = nullptr;  // null: nothing to make
  SunGrid g;
  void operator()(size_t first, int count, const double* y) const {
    if (!s) return;
    const size_t W = static_cast<size_t>(s->width);
    for (size_t p = first, end = first + count; p < end;) {
      const size_t row = p / W, e = std::min(end, (row + 1) * W);
      const int by = static_cast<int>(row) / g.B;
      if (s->made[by] && sun_row_sampled(static_cast<int>(row), g)) {
        const double* yp = y + (p - first);
        const int x0 = static_cast<int>(p - row * W);
        add_row_to_blocks(s->labels + row * W, x0, static_cast<int>(e - row * W), by, diffuse_slots().slot, g,
                          [&](int x, int) { return yp + (x - x0); }, s->ysum.get(), s->ycnt.get(), s->row_x0.data(),
                          s->row_x1.data());
      }
      p = e;
    }
  }
};
SunPassRows sun_pass_rows(const ScenePreset* split, const float* image, const uint16_t* labels, int W, int H,
                          TextureSums* sums) {
  SunPassRows r;
  if (!split || split->sun_shade_ratio_max <= 1 || W == 0 || H == 0) return r;
  auto s = new_sun_block_sums(image, labels, W, H, kTextureChunks);
  s->gain = sums->balance.gain;  // the pass's Y are taken with the day white balance
  if (std::find(s->made.begin(), s->made.end(), 1) == s->made.end()) return r;  // no row lies in one chunk
  r.s = s.get();
  r.g = sun_grid(W, H, split->sun_shade_window_fraction);
  sums->sun = std::move(s);
  return r;
}
std::atomic<uint64_t> g_sun_rows_summed{0};
}  // namespace

double sun_blue_contrast(const ScenePreset& p) {
  // The shade is lit by the sky alone (luminance E_sky), the sunlit level by the sun and the sky,
  // (g − 1)·E_sky + E_sky at a step g; each light's box bands per unit luminance from its CCT
  // (Planck's law through the camera-independent box basis). The sunlit level's B/R moves toward
  // the sun's as g grows, so the contrast is smallest at the smallest step that splits, ratio_min.
  const auto& M = spectrum::linear_srgb_to_box();
  auto box = [&](double cct, double* b) {
    const auto c = spectrum::blackbody_rgb(cct, 1.0);
    for (int k = 0; k < 3; ++k) b[k] = M[k][0] * c[0] + M[k][1] * c[1] + M[k][2] * c[2];
  };
  double sun[3], sky[3];
  box(p.sun_cct_K, sun);
  box(p.shade_sky_cct_K, sky);
  const double g = std::max(1.0, p.sun_shade_ratio_min);
  const double lit_r = (g - 1) * sun[0] + sky[0], lit_b = (g - 1) * sun[2] + sky[2];
  return (sky[2] / sky[0]) / (lit_b / lit_r);
}

namespace {
// Whether a sum of the n values a[i] (and of any subset of them, in any order) is exact in double
// arithmetic, so that every order of the additions gives the same bits: each a[i] is a multiple of
// 2^e, the quantum of the finest of them (from its exponent and its significand's trailing zeros),
// and Σ|a[i]| < 2^(52 + e) (a factor 2 below 2^53·2^e, which covers the rounding of that check's own
// sum, at most n·2⁻⁵³ relative). Then every partial sum is a multiple of 2^e of magnitude below
// 2^53·2^e, so a double holds it exactly and no addition rounds. False for a NaN or an infinity.
bool sums_exact(const double* a, size_t n) {
  int e_min = INT_MAX;
  double abs_sum = 0;
  for (size_t i = 0; i < n; ++i) {
    uint64_t u;
    std::memcpy(&u, &a[i], sizeof u);
    const int be = static_cast<int>(u >> 52 & 0x7ff);
    uint64_t m = u & ((uint64_t{1} << 52) - 1);
    if (be == 0x7ff) return false;  // NaN or infinity
    if (be == 0 && m == 0) continue;  // ±0 adds nothing
    if (be != 0) m |= uint64_t{1} << 52;  // normal: the hidden bit (subnormals have none)
    e_min = std::min(e_min, (be == 0 ? 1 : be) - 1075 + std::countr_zero(m));
    abs_sum += std::fabs(a[i]);
  }
  return e_min == INT_MAX || abs_sum < std::ldexp(1.0, std::min(52 + e_min, 1100));
}

// The sums of w[i] and wl[i] over the levels lvl[i] above t, in any order (for sums that
// sums_exact found exact): four interleaved partial sums, or AVX2's four lanes in two registers
// each; the levels at most t add +0.0 (masked out).
void upper_sums_scalar(const double* lvl, const double* w, const double* wl, size_t n, double t, double& w1, double& m1) {
  double sw[4] = {0, 0, 0, 0}, sm[4] = {0, 0, 0, 0};
  size_t i = 0;
  for (; i + 4 <= n; i += 4)
    for (int k = 0; k < 4; ++k) {
      const bool up = lvl[i + k] > t;
      sw[k] += up ? w[i + k] : 0.0;
      sm[k] += up ? wl[i + k] : 0.0;
    }
  for (; i < n; ++i) {
    const bool up = lvl[i] > t;
    sw[0] += up ? w[i] : 0.0;
    sm[0] += up ? wl[i] : 0.0;
  }
  w1 = (sw[0] + sw[1]) + (sw[2] + sw[3]);
  m1 = (sm[0] + sm[1]) + (sm[2] + sm[3]);
}
#if defined(__x86_64__)
__attribute__((target("avx2"))) void upper_sums_avx2(const double* lvl, const double* w, const double* wl, size_t n,
                                                     double t, double& w1, double& m1) {
  const __m256d tt = _mm256_set1_pd(t);
  __m256d wa = _mm256_setzero_pd(), wb = wa, ma = wa, mb = wa;
  size_t i = 0;
  for (; i + 8 <= n; i += 8) {
    const __m256d ua = _mm256_cmp_pd(_mm256_loadu_pd(lvl + i), tt, _CMP_GT_OQ);
    const __m256d ub = _mm256_cmp_pd(_mm256_loadu_pd(lvl + i + 4), tt, _CMP_GT_OQ);
    wa = _mm256_add_pd(wa, _mm256_and_pd(ua, _mm256_loadu_pd(w + i)));
    wb = _mm256_add_pd(wb, _mm256_and_pd(ub, _mm256_loadu_pd(w + i + 4)));
    ma = _mm256_add_pd(ma, _mm256_and_pd(ua, _mm256_loadu_pd(wl + i)));
    mb = _mm256_add_pd(mb, _mm256_and_pd(ub, _mm256_loadu_pd(wl + i + 4)));
  }
  double sw[4], sm[4], rw, rm;
  _mm256_storeu_pd(sw, _mm256_add_pd(wa, wb));
  _mm256_storeu_pd(sm, _mm256_add_pd(ma, mb));
  _mm256_zeroupper();  // the rest in generic code (see box_y_avx2)
  upper_sums_scalar(lvl + i, w + i, wl + i, n - i, t, rw, rm);
  w1 = ((sw[0] + sw[1]) + (sw[2] + sw[3])) + rw;
  m1 = ((sm[0] + sm[1]) + (sm[2] + sm[3])) + rm;
}
#endif
void upper_sums(const double* lvl, const double* w, const double* wl, size_t n, double t, double& w1, double& m1) {
#if defined(__x86_64__)
  if (std::min(kIsa, max_isa) >= 1) return upper_sums_avx2(lvl, w, wl, n, t, w1, m1);
#endif
  upper_sums_scalar(lvl, w, wl, n, t, w1, m1);
}
}  // namespace

double sun_isodata_threshold(const double* w, const double* lvl, size_t n, bool* exact) {
  // The threshold halfway between the weighted means of the levels at most t and above t, from the
  // weighted mean of all, until it stays put (Ridler and Calvard 1978), at most 100 times. Each
  // side's sums are the sums in list order of w[i] and w[i]·lvl[i] over its levels.
  if (n == 0) return 0;
  std::vector<double> wl(n);
  for (size_t i = 0; i < n; ++i) wl[i] = w[i] * lvl[i];
  // When every such sum is exact (sums_exact of the weights and of the products: integer sample
  // counts, and levels that are floats well away from 0, as the split's are), any order of the
  // additions gives the same bits as list order. Then the sums above t are taken in four
  // interleaved partial sums (no chain of dependent additions through the whole list) and the
  // sums at most t as the totals less them (exact too: a difference that a double holds). Else
  // list order, one running sum per side: the same bits on both paths.
  const bool fast = sums_exact(w, n) && sums_exact(wl.data(), n);
  if (exact) *exact = fast;
  auto total = [&](const double* a) {
    double s[4] = {0, 0, 0, 0};
    size_t i = 0;
    for (; i + 4 <= n; i += 4)
      for (int k = 0; k < 4; ++k) s[k] += a[i + k];
    for (; i < n; ++i) s[0] += a[i];
    return (s[0] + s[1]) + (s[2] + s[3]);
  };
  double t = 0, w_all = 0, m_all = 0;
  if (fast) {
    w_all = total(w);
    m_all = total(wl.data());
    t = m_all / w_all;
  } else {
    double sw = 0;
    for (size_t i = 0; i < n; ++i) {
      t += wl[i];
      sw += w[i];
    }
    t /= sw;
  }
  for (int it = 0; it < 100; ++it) {
    double w0 = 0, w1 = 0, m0 = 0, m1 = 0;
    if (fast) {
      upper_sums(lvl, w, wl.data(), n, t, w1, m1);
      w0 = w_all - w1;
      m0 = m_all - m1;
    } else {
      // Each side's sums in list order; the other side adds +0.0, which leaves a sum as it is,
      // so the same bits as adding to one side only (branch-free, the sums in registers).
      for (size_t i = 0; i < n; ++i) {
        const bool k = lvl[i] > t;
        const double a = w[i], am = wl[i];
        w0 += k ? 0.0 : a;
        w1 += k ? a : 0.0;
        m0 += k ? 0.0 : am;
        m1 += k ? am : 0.0;
      }
    }
    if (w0 == 0 || w1 == 0) break;
    const double nt = 0.5 * (m0 / w0 + m1 / w1);
    if (nt == t) break;
    t = nt;
  }
  return t;
}

void sun_edge_blocks(const uint8_t* present, const uint8_t* sd, int w, int h, uint8_t* ed) {
  edge_blocks_of(present, sd, w, h, ed);
}

int sun_diffuse_slot(int id) { return id >= 0 && id < kLabelCount ? diffuse_slots().slot[id] : -1; }

uint64_t sun_block_rows_summed_count() { return g_sun_rows_summed.load(std::memory_order_relaxed); }

std::shared_ptr<SunBlockSums> sun_block_sums(const ImageF& day, const ImageU16& labels,
                                             const std::array<double, 3>& gain) {
  const int W = day.width(), H = day.height();
  if (day.channels() != 3 || labels.width() != W || labels.height() != H) fail("sun_block_sums: image and labels differ");
  auto s = new_sun_block_sums(day.data(), labels.data(), W, H, 0);
  const SunGrid g = sun_grid(W, H, 0.03);
  const BoxCoef coef = box_coef(gain);
  std::vector<double> yrow(W);
  for (int y = 0; y < H; ++y)
    if (sun_row_sampled(y, g))
      add_row_to_blocks(labels.row(y), 0, W, y / g.B, diffuse_slots().slot, g, [&](int x, int e) {
        box_y_block(day.row(y) + 3 * x, e - x, coef, yrow.data() + x);
        return yrow.data() + x;
      }, s->ysum.get(), s->ycnt.get(), s->row_x0.data(), s->row_x1.data());
  return s;
}

SunShadeSplit sun_shade_split(const ImageF& day, const ImageU16& labels, const ScenePreset& p, const double* class_px,
                              const SunBlockSums* made, const std::array<double, 3>& gain) {
  SunShadeSplit out;
  out.ratio.fill(1.0);
  out.shade_tint.fill({1.0, 1.0, 1.0});
  const int W = day.width(), H = day.height();
  if (p.sun_shade_ratio_max <= 1 || W == 0 || H == 0) return out;
  const SunGrid g = sun_grid(W, H, p.sun_shade_window_fraction);
  out.block_px = g.B;
  out.opening_radius_blocks = g.r;
  const double square_px = std::pow((2.0 * g.r + 1) * g.B, 2);
  // The classes that may split: diffuse, and large enough for two levels of a square each.
  int slot[kLabelCount], ids[kLabelCount], ns = 0;
  for (int id = 0; id < kLabelCount; ++id) {
    slot[id] = -1;
    if (diffuse_class(id) && class_px[id] >= 2 * square_px) ids[slot[id] = ns++] = id;
  }
  if (ns == 0) return out;
  const BoxCoef coef = box_coef(gain);
  const size_t nb = g.nb();
  const double q_min = sun_blue_contrast(p);
  // Block sums of Y and sample counts per class (every other row of a block sampled: a block's
  // level is a mean, and the opening's square spans several blocks). One block row per task:
  // taken from the linearisation's pass where it made the row (`made`, of this image and these
  // labels: a copy of each candidate class's blocks), else summed here, reading the day image.
  std::vector<double> ysum(ns * nb, 0.0), ycnt(ns * nb, 0.0);
  // Per class and block row, the first and last blocks with samples (none: first > last).
  std::vector<int> row_x0(static_cast<size_t>(ns) * g.nby, g.nbx), row_x1(static_cast<size_t>(ns) * g.nby, -1);
  const bool take = made && made->image == day.data() && made->labels == labels.data() && made->width == W &&
                    made->height == H && made->block_px == g.B && made->gain == gain;
  uint64_t own_rows = 0;
#pragma omp parallel reduction(+ : own_rows)
  {
    std::vector<double> yrow(W);
#pragma omp for schedule(dynamic)
    for (int by = 0; by < g.nby; ++by) {
      if (take && made->made[by]) {
        for (int s = 0; s < ns; ++s) {
          const size_t d = static_cast<size_t>(sun_diffuse_slot(ids[s]));  // a candidate is diffuse
          const size_t rm = d * g.nby + by, r = static_cast<size_t>(s) * g.nby + by;
          const int lo = made->row_x0[rm], hi = made->row_x1[rm];
          if (lo > hi) continue;
          row_x0[r] = lo;
          row_x1[r] = hi;
          const size_t om = d * nb + static_cast<size_t>(by) * g.nbx, o = s * nb + static_cast<size_t>(by) * g.nbx;
          std::copy(made->ysum.get() + om + lo, made->ysum.get() + om + hi + 1, ysum.data() + o + lo);
          std::copy(made->ycnt.get() + om + lo, made->ycnt.get() + om + hi + 1, ycnt.data() + o + lo);
        }
        continue;
      }
      ++own_rows;
      for (int y = by * g.B; y < std::min(H, (by + 1) * g.B); ++y)
        if (sun_row_sampled(y, g))  // per run of one label; Y only where the class may split
          add_row_to_blocks(labels.row(y), 0, W, by, slot, g, [&](int x, int e) {
            box_y_block(day.row(y) + 3 * x, e - x, coef, yrow.data() + x);
            return yrow.data() + x;
          }, ysum.data(), ycnt.data(), row_x0.data(), row_x1.data());
    }
  }
  g_sun_rows_summed.fetch_add(own_rows, std::memory_order_relaxed);
  // Per class: the opened log level per block, its split, and g.
  std::vector<std::vector<uint8_t>> side(ns);
  std::vector<double> chroma(ns, 0.0), lum_mid(ns, 0.0);
  bool any = false;
#pragma omp parallel for schedule(dynamic) reduction(|| : any)
  for (int s = 0; s < ns; ++s) {
    const double* S = ysum.data() + s * nb;
    const double* C = ycnt.data() + s * nb;
    // The class's blocks over its bounding box (phase 1 found it; outside it every block is
    // absent), row-major there: local block i = (by − bb.y0)·w + (bx − bb.x0).
    BlockBox bb{g.nbx, -1, g.nby, -1};
    for (int by = 0; by < g.nby; ++by) {
      const size_t r = static_cast<size_t>(s) * g.nby + by;
      if (row_x0[r] > row_x1[r]) continue;
      bb = {std::min(bb.x0, row_x0[r]), std::max(bb.x1, row_x1[r]), std::min(bb.y0, by), by};
    }
    if (bb.x1 < 0) continue;  // no block: the class only on rows the blocks do not sample
    const int w = bb.x1 - bb.x0 + 1, h = bb.y1 - bb.y0 + 1;
    const size_t nl = static_cast<size_t>(w) * h;
    auto grid = [&](size_t i) { return static_cast<size_t>(bb.y0 + i / w) * g.nbx + bb.x0 + i % w; };
    std::vector<uint8_t> present(nl);
    std::vector<float> v(nl, 0.f);
    std::vector<uint32_t> list;  // the present blocks, in grid order (local indices)
    std::vector<double> lw;      // their sample counts
    list.reserve(nl);
    lw.reserve(nl);
    double samples = 0;
    for (int y = 0; y < h; ++y) {
      const size_t r = static_cast<size_t>(s) * g.nby + bb.y0 + y;
      const double* Sr = S + static_cast<size_t>(bb.y0 + y) * g.nbx + bb.x0;
      const double* Cr = C + static_cast<size_t>(bb.y0 + y) * g.nbx + bb.x0;
      for (int x = row_x0[r] - bb.x0; x <= row_x1[r] - bb.x0; ++x) {  // empty where the row has no block
        if (!(Cr[x] > 0)) continue;
        const size_t i = static_cast<size_t>(y) * w + x;
        present[i] = 1;
        v[i] = static_cast<float>(std::log(std::max(Sr[x] / Cr[x], 1e-30)));
        samples += Cr[x];
        list.push_back(static_cast<uint32_t>(i));
        lw.push_back(Cr[x]);
      }
    }
    masked_opening(v, present, w, h, g.r);
    // Isodata threshold on the opened levels, weighted by the blocks' samples (sun_isodata_threshold).
    // (The present blocks' weights and levels gathered into two arrays once, in grid order.)
    std::vector<double> lvl(list.size());
    for (size_t k = 0; k < list.size(); ++k) lvl[k] = v[list[k]];
    const double t = sun_isodata_threshold(lw.data(), lvl.data(), list.size());
    std::vector<uint8_t> sd(nl, 0), ed(nl, 1);  // absent blocks are edge blocks
    for (uint32_t i : list) sd[i] = v[i] > t;
    // Edge blocks: absent, or with a present neighbour (8-connected) on the other side. The
    // levels' means are taken over the interior blocks (a block across the edge is neither).
    // (Neighbours outside the box are absent, like those outside the grid.)
    double sum[2] = {0, 0}, cnt[2] = {0, 0}, all_sum[2] = {0, 0}, all_cnt[2] = {0, 0}, lev[2] = {0, 0},
           all_lev[2] = {0, 0};
    edge_blocks_of(present.data(), sd.data(), w, h, ed.data());
    for (int y = 0; y < h; ++y) {
      const double* Sr = S + static_cast<size_t>(bb.y0 + y) * g.nbx + bb.x0;
      const double* Cr = C + static_cast<size_t>(bb.y0 + y) * g.nbx + bb.x0;
      for (int x = 0; x < w; ++x) {
        const size_t i = static_cast<size_t>(y) * w + x;
        if (!present[i]) continue;
        const uint8_t own = sd[i];
        const bool e = ed[i];
        all_sum[own] += Sr[x];
        all_cnt[own] += Cr[x];
        all_lev[own] += Cr[x] * v[i];
        if (!e) { sum[own] += Sr[x]; cnt[own] += Cr[x]; lev[own] += Cr[x] * v[i]; }
      }
    }
    for (int k = 0; k < 2; ++k)
      if (cnt[k] == 0) { sum[k] = all_sum[k]; cnt[k] = all_cnt[k]; lev[k] = all_lev[k]; }
    const int id = ids[s];
    const double px_per_sample = class_px[id] / samples;
    const bool big = all_cnt[0] * px_per_sample >= square_px && all_cnt[1] * px_per_sample >= square_px;
    // Two levels of illumination: the opened levels' (geometric) means apart by ratio_min, which
    // a bright structure narrower than the square cannot fake (the opening took it out), and the
    // levels' mean luminances too; g is the latter, the ratio that makes the two sides' means equal.
    const double level_ratio = big && cnt[0] > 0 && cnt[1] > 0 ? std::exp(lev[1] / cnt[1] - lev[0] / cnt[0]) : 1.0;
    const double ratio = big && sum[0] > 0 ? (sum[1] / cnt[1]) / (sum[0] / cnt[0]) : 1.0;
    if (std::min(ratio, level_ratio) >= p.sun_shade_ratio_min && ratio > 1) {
      // The two illuminants' colours: the shade is lit by the blue sky alone, the sunlit level by
      // the sun and the sky (far redder), so the levels' B/R differ while a white marking or a
      // grey texture takes the colour of the light it is under. From one pixel at the centre of
      // each interior block: per side the sums of the box bands' B and R.
      double br[2][3] = {{0, 0, 0}, {0, 0, 0}};
      for (uint32_t i : list) {
        const int bx = bb.x0 + static_cast<int>(i % w), by = bb.y0 + static_cast<int>(i / w);
        const int cx = std::min(W - 1, bx * g.B + g.B / 2), cy = std::min(H - 1, by * g.B + g.B / 2);
        if (ed[i] || labels.at(cx, cy) != id) continue;
        double c[3];
        box_px(day.row(cy) + 3 * cx, coef, c);
        for (int k = 0; k < 3; ++k) br[sd[i]][k] += c[k];
      }
      bool coloured = true;
      for (int k = 0; k < 3; ++k) coloured = coloured && br[0][k] > 0 && br[1][k] > 0;
      const double q_shade = coloured ? br[0][2] / br[0][0] : 0, q_sun = coloured ? br[1][2] / br[1][0] : 0;
      // The shade's colour cast: per band, the sunlit level's mean colour over the shade's, at
      // equal luminance (Σ K_k t_k m_shade,k = Y_shade): a von Kries correction that gives the
      // shade the colour of the sunlit level, which the day camera's white balance made neutral.
      // The class mean then stays ρ to within the spread of the shade pixels' colours.
      if (coloured) {
        const double y_shade = box_y(br[0], coef), y_sun = box_y(br[1], coef);
        for (int k = 0; k < 3; ++k) out.shade_tint[id][k] = (br[1][k] / y_sun) / (br[0][k] / y_shade);
      }
      // A shadow cast by the sun has a bluer shade: the split is taken only when the shade's B/R
      // exceeds the sunlit level's by at least q_min (sun_blue_contrast: direct sun against the
      // sky's light at its reddest, at a step of ratio_min). Levels closer in colour are a step of
      // material or orientation, or an overcast sky's shading (under a car, under eaves), not
      // the sun's.
      chroma[s] = coloured && q_shade > q_min * q_sun ? std::sqrt(q_shade * q_sun) : 0;
      if (chroma[s] == 0) {
        out.shade_tint[id] = {1.0, 1.0, 1.0};
        continue;
      }
      lum_mid[s] = std::sqrt((sum[1] / cnt[1]) * (sum[0] / cnt[0]));
      out.ratio[id] = std::min(ratio, p.sun_shade_ratio_max);
      side[s].assign(nb, 0);  // over the grid, for the per-pixel placement
      for (uint32_t i : list) side[s][grid(i)] = sd[i];
      any = true;
    }
  }
  if (!any) return out;
  // Per pixel of a split class: placed by its own light, its block's side where luminance and
  // colour disagree (make_level below), then a 3 x 3 majority; the sums of Y over the sunlit
  // pixels per row, then over rows in order (the same whatever the thread count). One pass over the
  // rows in bands of 32 (schedule(dynamic, 32): the split classes' pixels are not spread evenly
  // over the frame). Each thread keeps the placed levels of the last three rows it made in a ring,
  // so a row's placement is made once per band (twice at a band's edges), and no full-frame
  // intermediate is written.
  out.sunlit.assign(static_cast<size_t>(W) * H, 0);
  std::vector<double> row_sum(static_cast<size_t>(H) * kLabelCount, 0.0);
  // A row's levels (1: sunlit) and the stretches [x0, x1) of pixels placed by their own light (the
  // runs of a split class).
  struct Level {
    int y = -1;
    std::vector<uint8_t> lv;
    std::vector<std::pair<int, int>> own;
  };
  auto make_level = [&](int y, Level& L) {
    L.y = y;
    L.own.clear();
    uint8_t* lv = L.lv.data();
    std::memset(lv, 0, W);
    const uint16_t* lr = labels.row(y);
    const int by = y / g.B;
    for (int x = 0; x < W;) {
      const int id = lr[x];
      const int e = run_end(lr, x, W);
      const int s = id < kLabelCount ? slot[id] : -1;
      if (s < 0 || side[s].empty()) { x = e; continue; }
      const uint8_t* sd = side[s].data();
      // Per block of the run its side (the opened levels' split), then each pixel of the run by its
      // own light (own_light_block): sunlit when brighter than the two levels' geometric mean and
      // of the sun's colour (B/R below the levels' geometric mean); shade when darker and of the
      // shade's colour. A pixel whose luminance and colour disagree (a white marking in the shade
      // is bright but sky-blue; a dark material in the sun is dark but sun-coloured) keeps its
      // block's side. Every pixel, not only those near the opened levels' edge: the opening takes
      // out what is narrower than its square, so a sunlit wedge's tip, a thin shadow across a
      // sunlit road (a pole's, a trunk's) or a sliver of sun would otherwise take its blocks' side.
      for (int bx = x / g.B, xb = x; xb < e; ++bx) {
        const int xe = std::min(e, (bx + 1) * g.B);
        const size_t b = static_cast<size_t>(by) * g.nbx + bx;
        if (sd[b]) {
          if (xe - xb == 8) std::memcpy(lv + xb, "\1\1\1\1\1\1\1\1", 8);
          else std::memset(lv + xb, 1, xe - xb);
        }
        xb = xe;
      }
      own_light_block(day.row(y) + 3 * x, e - x, coef, lum_mid[s], chroma[s], lv + x);
      L.own.emplace_back(x, e);
      x = e;
    }
  };
#pragma omp parallel
  {
    std::vector<double> yrow(W);
    Level ring[3];
    for (Level& L : ring) L.lv.resize(W);
    auto level = [&](int y) -> const Level& {  // row y's levels, made once while in the ring
      Level& L = ring[y % 3];
      if (L.y != y) make_level(y, L);
      return L;
    };
#pragma omp for schedule(dynamic, 32)
    for (int y = 0; y < H; ++y) {
      const uint16_t* lr = labels.row(y);
      uint8_t* mr = out.sunlit.data() + static_cast<size_t>(y) * W;
      const Level& L = level(y);
      std::memcpy(mr, L.lv.data(), W);
      if (!L.own.empty()) {
        // A pixel placed by its own light takes the majority of its class's pixels in its 3 x 3
        // neighbourhood (a single pixel of texture does not flip alone).
        const uint8_t* up = y > 0 ? level(y - 1).lv.data() : nullptr;
        const uint8_t* dn = y + 1 < H ? level(y + 1).lv.data() : nullptr;
        const uint8_t* lv = L.lv.data();
        const uint16_t* lu = y > 0 ? labels.row(y - 1) : nullptr;
        const uint16_t* ld = y + 1 < H ? labels.row(y + 1) : nullptr;
        for (const auto& [x0, x1] : L.own) majority_block(lu, lr, ld, up, lv, dn, x0, x1, W, mr);
      }
      // The sums of Y over the row's sunlit pixels per class: per run of a split class, Y of each
      // pixel (box_y_block), summed in four interleaved partial sums (pixel i of the run into sum
      // i mod 4; a shaded pixel adds +0.0, which leaves a sum as it is), then (s0 + s1) + (s2 + s3)
      // added to the row's class sum: the same operations on every path and thread count. (A
      // reordering against one running sum: the sums differ by rounding, at most ~n·2⁻⁵³
      // relative for n pixels, and the texture is linear in the class mean.)
      double* rs = row_sum.data() + static_cast<size_t>(y) * kLabelCount;
      for (int x = 0; x < W;) {
        const int id = lr[x];
        const int e = run_end(lr, x, W);
        const int s = id < kLabelCount ? slot[id] : -1;
        if (s < 0 || side[s].empty() || !std::memchr(mr + x, 1, e - x)) { x = e; continue; }
        const int n = e - x;
        box_y_block(day.row(y) + 3 * x, n, coef, yrow.data());
        const double* yy = yrow.data();
        const uint8_t* m = mr + x;
        double p0 = 0, p1 = 0, p2 = 0, p3 = 0;
        int i = 0;
        for (; i + 4 <= n; i += 4) {
          p0 += m[i] ? yy[i] : 0.0;
          p1 += m[i + 1] ? yy[i + 1] : 0.0;
          p2 += m[i + 2] ? yy[i + 2] : 0.0;
          p3 += m[i + 3] ? yy[i + 3] : 0.0;
        }
        if (i < n) p0 += m[i] ? yy[i] : 0.0;
        if (i + 1 < n) p1 += m[i + 1] ? yy[i + 1] : 0.0;
        if (i + 2 < n) p2 += m[i + 2] ? yy[i + 2] : 0.0;
        rs[id] += (p0 + p1) + (p2 + p3);
        x = e;
      }
    }
  }
  for (int y = 0; y < H; ++y)
    for (int id = 0; id < kLabelCount; ++id) out.sun_sum[id] += row_sum[static_cast<size_t>(y) * kLabelCount + id];
  return out;
}

SunShadeSplit sun_shade_split(const ImageF& day, const ImageU16& labels, const ScenePreset& p) {
  double px[kLabelCount] = {};
  const size_t n = labels.pixel_count();
  for (size_t i = 0; i < n; ++i)
    if (labels[i] < kLabelCount) px[labels[i]] += 1;
  return sun_shade_split(day, labels, p, px);
}

void texture_max_isa(int isa) { max_isa = isa; }

ImageF reflectance_texture(const ImageF& day, const ImageU16& labels, const ScenePreset& p, ClassMeans* carried) {
  return reflectance_texture_with(day, labels, p, carried, nullptr);
}

namespace {
std::atomic<uint64_t> g_texture_own_class_sums{0};  // texture_own_class_sums_count
}  // namespace
uint64_t texture_own_class_sums_count() { return g_texture_own_class_sums.load(std::memory_order_relaxed); }

namespace {
// The sun/shade split's penumbrae (reflectance_texture_with, after its pass 2). The split puts each
// pixel of a split class on one level, sunlit (divided by g) or shade; but a shadow's edge is a
// penumbra a few pixels wide (the sun's disc is 0.53° across: 9 cm at 10 m behind the occluder,
// several pixels on a near road), whose pixels lie between the levels: those placed in the shade
// kept their extra light and drew a bright outline round every former sun patch, those placed in
// the sun a dark one. Near the levels' boundary a pixel whose light lies between the levels takes
// a sunlit share α ∈ (0, 1) and the scales' geometric mean scale_shade^(1−α)·scale_sun^α:
//  - the band: pixels of a split class within kPenumbraBand px of a boundary pixel (a pixel of the
//    class with a 4-neighbour of the class on the other level);
//  - the levels: per class the median Y on each level outside the band (robust to the markings and
//    glints a level also holds), and the levels' colours (box B/R); one pair per class, as g is
//    one per class (local means in a 17 x 17 window round each pixel were tried: they took
//    `darken` on the bundled KITTI frame from 3.1 to 28 ms);
//  - the share by light, α_light = ln(Y/Ȳ_shade)/ln(Ȳ_sun/Ȳ_shade), and by colour, α_colour =
//    ln((B/R)/(B/R)_shade)/ln((B/R)_sun/(B/R)_shade), each clamped to [0, 1]. In the shade the
//    smaller of the two: a penumbra is both brighter and redder than the shade (part of the sun's
//    light added to the sky's), a white marking in the shade only brighter. On the sunlit level
//    α_light: its penumbra keeps the sun's colour (the sun's light dominates it until the sky's is
//    most of what is left);
//  - a pixel within kPenumbraTexture of its level (its share within that factor's log over the
//    levels' log ratio) keeps it; else α is the median (the upper of two middles) of the shares of the 3 x 3 band pixels
//    of its class on its level (edge-preserving: a pebble's own reflectance, which the share reads
//    as light, is outvoted by its neighbours), again kept on the level within kPenumbraTexture.
// What it costs a sharp edge: none within kPenumbraTexture of the level (the texture there keeps
// its bits: SunShade.FlattensASunlitStep… checks every pixel); a darker or brighter texture next to
// a boundary may move by up to its own excess. A penumbra's pixels placed on the wrong level were
// off by up to g (2-10).
// (A dead zone of two standard deviations of each level's texture was tried and dropped: on the
// KITTI roads, whose texture includes markings and rails, it covered the penumbrae.)
// The class means stay those of the two levels (the band is a small share of a class). Each pixel
// from the day image, the labels and the split's placement only, in a fixed order of sums, so any
// thread count gives the same bits. Costs nothing where no class splits (the overcast Cityscapes
// frames).
constexpr int kPenumbraBand = 3;
std::atomic<bool> g_sun_penumbrae{true};  // sun_penumbrae_enabled (tests)
// A pixel within this factor of its level's median Y is on that level: the level's own texture (a
// road's asphalt varies by some ±20 % in luminance factor; a photosite choice), where a sharp edge
// keeps its bits; a penumbra's pixels lie further in.
constexpr double kPenumbraTexture = 1.3;
void soften_sun_edges(const ImageF& day, const ImageU16& labels, const SunShadeSplit& sun, const BoxCoef& coef,
                      const float (*scale_shade)[3], const float* scale_sun, const float* cap, ImageF& f) {
  const int W = day.width(), H = day.height();
  const size_t n = static_cast<size_t>(W) * H;
  const uint8_t* sunlit = sun.sunlit.data();
  // Each pixel's class and level as one code, 2·id + sunlit on split classes, 0xffff elsewhere:
  // two pixels are of one split class on different levels exactly when their codes differ in bit 0
  // alone (0xffff ^ code is never 1 for a class id below kLabelCount).
  uint16_t split_code[kLabelCount];
  for (int id = 0; id < kLabelCount; ++id) split_code[id] = sun.ratio[id] > 1 ? static_cast<uint16_t>(2 * id) : 0xffff;
  // Per call: scratch kept from frame to frame saved 0.15 ms on the bundled KITTI frame (6.49-6.58
  // against 6.63-6.72 ms), not worth 8 bytes a pixel left allocated.
  std::vector<uint16_t> code(n);
#pragma omp parallel for schedule(static, 4)
  for (int y = 0; y < H; ++y) {
    const uint16_t* l = labels.row(y);
    const uint8_t* s = sunlit + static_cast<size_t>(y) * W;
    uint16_t* c = code.data() + static_cast<size_t>(y) * W;
    for (int x = 0; x < W; ++x) {
      const uint16_t b = l[x] < kLabelCount ? split_code[l[x]] : 0xffff;
      c[x] = b == 0xffff ? b : static_cast<uint16_t>(b | s[x]);
    }
  }
  // Boundary pixels (a 4-neighbour of the class on the other level), then the band: the boundary
  // dilated by kPenumbraBand, on split-class pixels (rows, then columns).
  std::vector<uint8_t> hrow(n), band(n);
  std::vector<uint8_t> row_edge(H, 0), row_band(H, 0);  // rows with a boundary pixel, a band pixel
#pragma omp parallel for schedule(static, 4)
  for (int y = 0; y < H; ++y) {
    const uint16_t* c = code.data() + static_cast<size_t>(y) * W;
    const uint16_t* cu = y > 0 ? c - W : c;
    const uint16_t* cd = y + 1 < H ? c + W : c;
    uint8_t* h = hrow.data() + static_cast<size_t>(y) * W;  // zero (a new vector)
    bool any_e = false;
    for (int x = 0; x < W; ++x) {
      const uint16_t v = c[x];
      if (v == 0xffff) continue;
      const bool e = (v ^ cu[x]) == 1 || (v ^ cd[x]) == 1 || (x > 0 && (v ^ c[x - 1]) == 1) ||
                     (x + 1 < W && (v ^ c[x + 1]) == 1);
      if (!e) continue;
      any_e = true;
      for (int k = std::max(0, x - kPenumbraBand); k <= std::min(W - 1, x + kPenumbraBand); ++k) h[k] = 1;
    }
    row_edge[y] = any_e;
  }
  bool any = false;
#pragma omp parallel for schedule(static, 4) reduction(|| : any)
  for (int y = 0; y < H; ++y) {
    const uint16_t* c = code.data() + static_cast<size_t>(y) * W;
    uint8_t* __restrict b = band.data() + static_cast<size_t>(y) * W;  // zero (a new vector)
    bool near = false;
    for (int yy = std::max(0, y - kPenumbraBand); yy <= std::min(H - 1, y + kPenumbraBand); ++yy) near = near || row_edge[yy];
    if (!near) continue;
    for (int yy = std::max(0, y - kPenumbraBand); yy <= std::min(H - 1, y + kPenumbraBand); ++yy) {
      if (!row_edge[yy]) continue;
      const uint8_t* __restrict h = hrow.data() + static_cast<size_t>(yy) * W;
      for (int x = 0; x < W; ++x) b[x] |= h[x];
    }
    uint8_t a = 0;
    for (int x = 0; x < W; ++x) {
      b[x] = b[x] & (c[x] != 0xffff);
      a |= b[x];
    }
    row_band[y] = a;
    any = any || a;
  }
  if (!any) return;
  // The levels: per class the median Y on each level outside the band (robust to the markings and
  // glints a level also holds), over every other row and column, from histograms of log2 Y in
  // steps of 1/16 (4.4 %; integer counts, the same in any order), and the levels' mean box R and B
  // (their colours; per-row sums added over the rows in order: any thread count gives the same
  // bits).
  constexpr int kBins = 1024;  // log2 Y from −32 to +32
  auto bin_of = [](double yv) { return std::clamp(static_cast<int>(std::floor((std::log2(yv) + 32) * 16)), 0, kBins - 1); };
  std::vector<int> split_ids;
  int slot[kLabelCount];
  for (int id = 0; id < kLabelCount; ++id) slot[id] = split_code[id] != 0xffff ? (split_ids.push_back(id), static_cast<int>(split_ids.size()) - 1) : -1;
  const int ns = static_cast<int>(split_ids.size());
  const int nr = (H + 1) / 2;
  std::vector<uint64_t> tot_all(static_cast<size_t>(ns) * 2 * kBins, 0);
  std::vector<double> rb(static_cast<size_t>(nr) * ns * 4, 0.0);
#pragma omp parallel
  {
  std::vector<uint32_t> h(static_cast<size_t>(ns) * 2 * kBins, 0);
#pragma omp for schedule(static, 4)
  for (int r = 0; r < nr; ++r) {
    const int y = 2 * r;
    const uint16_t* c = code.data() + static_cast<size_t>(y) * W;
    const uint8_t* b = band.data() + static_cast<size_t>(y) * W;
    const float* d = day.row(y);
    double* q = rb.data() + static_cast<size_t>(r) * ns * 4;
    for (int x = 0; x < W; x += 2) {
      if (c[x] == 0xffff || b[x]) continue;
      double v[3];
      box_px(d + 3 * x, coef, v);
      const double yv = box_y(v, coef);
      if (!(yv > 0)) continue;
      const int k = 2 * slot[c[x] >> 1] + (c[x] & 1);
      ++h[static_cast<size_t>(k) * kBins + bin_of(yv)];
      q[2 * k] += v[0];
      q[2 * k + 1] += v[2];
    }
  }
#pragma omp critical(penumbra_hist)
  for (size_t j = 0; j < h.size(); ++j) tot_all[j] += h[j];
  }
  double level[kLabelCount][2] = {}, blue_red[kLabelCount][2] = {};
  for (int si = 0; si < ns; ++si)
    for (int side = 0; side < 2; ++side) {
      const int k = 2 * si + side;
      const uint64_t* tot = tot_all.data() + static_cast<size_t>(k) * kBins;
      double R = 0, B = 0;
      for (int r = 0; r < nr; ++r) {
        R += rb[(static_cast<size_t>(r) * ns * 2 + k) * 2];
        B += rb[(static_cast<size_t>(r) * ns * 2 + k) * 2 + 1];
      }
      uint64_t n_all = 0;
      for (int j = 0; j < kBins; ++j) n_all += tot[j];
      if (n_all == 0) continue;
      // The median: the centre of the bin where the cumulative count first reaches half.
      uint64_t acc = 0;
      int j = 0;
      for (; j < kBins - 1; ++j)
        if (static_cast<double>(acc += tot[j]) >= 0.5 * static_cast<double>(n_all)) break;
      const int id = split_ids[si];
      level[id][side] = std::exp2((j + 0.5) / 16 - 32);
      blue_red[id][side] = R > 0 ? B / R : 0;
    }
  // 1/ln(Ȳ_sun/Ȳ_shade) per class (0: levels less than 1.5x apart, placement kept), the share within
  // which a pixel is on its level (kPenumbraTexture in that log ratio's units), and
  // ln(scale_sun/scale_shade_k) per class and band: the band's scales are scale_shade_k·exp(α·that).
  float inv_log_ratio[kLabelCount] = {}, inv_log_br[kLabelCount] = {}, log_scale_ratio[kLabelCount][3] = {},
        snap[kLabelCount] = {};
  for (int id = 0; id < kLabelCount; ++id) {
    if (!(level[id][0] > 0) || !(level[id][1] > 1.5 * level[id][0])) continue;
    // The shade bluer than the sunlit level (the split's colour test): else no colour share.
    if (!(blue_red[id][1] > 0) || !(blue_red[id][0] > blue_red[id][1])) continue;
    inv_log_ratio[id] = static_cast<float>(1 / std::log(level[id][1] / level[id][0]));
    snap[id] = static_cast<float>(std::log(kPenumbraTexture) / std::log(level[id][1] / level[id][0]));
    inv_log_br[id] = static_cast<float>(1 / std::log(blue_red[id][1] / blue_red[id][0]));
    for (int k = 0; k < 3; ++k)
      if (scale_shade[id][k] > 0 && scale_sun[id] > 0)
        log_scale_ratio[id][k] = static_cast<float>(std::log(double{scale_sun[id]} / scale_shade[id][k]));
  }
  // α_raw per band pixel (−1 elsewhere and where the class keeps its placement).
  std::vector<float> araw(n);
#pragma omp parallel for schedule(static, 4)
  for (int y = 0; y < H; ++y) {
    const uint16_t* c = code.data() + static_cast<size_t>(y) * W;
    const uint8_t* b = band.data() + static_cast<size_t>(y) * W;
    const float* d = day.row(y);
    float* o = araw.data() + static_cast<size_t>(y) * W;
    std::fill_n(o, W, -1.f);
    if (!row_band[y]) continue;
    for (int x = 0; x < W; ++x) {
      if (!b[x]) continue;
      const int id = c[x] >> 1;
      if (inv_log_ratio[id] == 0) continue;
      double v[3];
      box_px(d + 3 * x, coef, v);
      const double yp = box_y(v, coef);
      if (!(yp > 0) || !(v[0] > 0) || !(v[2] > 0)) continue;
      // In the shade, the share by light and by colour, whichever is smaller: a penumbra is both
      // brighter and redder than the shade (part of the sun's light added to the sky's), a white
      // marking in the shade only brighter. On the sunlit level by light alone: its penumbra keeps
      // the sun's colour (the sun's light dominates it until the sky's is most of what is left).
      const float by_light = std::clamp(std::log(static_cast<float>(yp / level[id][0])) * inv_log_ratio[id], 0.f, 1.f);
      const float by_colour =
          std::clamp(std::log(static_cast<float>(v[2] / v[0] / blue_red[id][0])) * inv_log_br[id], 0.f, 1.f);
      o[x] = (c[x] & 1) ? by_light : std::min(by_light, by_colour);
    }
  }
  // α, the median of α_raw over the 3 x 3 band pixels of the class on the pixel's level; the pixel's
  // texture anew where it is not its level's.
#pragma omp parallel for schedule(static, 4)
  for (int y = 0; y < H; ++y) {
    if (!row_band[y]) continue;
    const uint16_t* c = code.data() + static_cast<size_t>(y) * W;
    const float* ar = araw.data() + static_cast<size_t>(y) * W;
    for (int x = 0; x < W; ++x) {
      if (ar[x] < 0) continue;
      // A pixel whose own light is its level's keeps it (its neighbours' median could move it only
      // where most of them lie off its level, which a penumbra's pixels on its level's side of
      // the snap do not need: they are as lit as the level).
      const bool on_sun = c[x] & 1;
      const int id = c[x] >> 1;
      if (on_sun ? ar[x] > 1 - snap[id] : ar[x] < snap[id]) continue;
      // The m shares of the neighbourhood's band pixels of the class on the level, the others +inf,
      // sorted by a network of compare-exchanges (no data-dependent branch: an insertion sort's
      // mispredicted branches were half of this function's time on the bundled KITTI frame), so
      // the first m are the shares in order and v[m / 2] is the median an insertion sort of the m
      // gives (equal shares are equal floats: their order does not change the value; a −0 share
      // against a +0 one is below every snap, so it ends at 0 either way).
      float v[9];
      int m = 0;
      for (int dy = -1; dy <= 1; ++dy) {
        const int yy = y + dy;
        const bool row_in = yy >= 0 && yy < H;
        const size_t o = static_cast<size_t>(row_in ? yy : y) * W;
        for (int dx = -1; dx <= 1; ++dx) {
          const int xx = x + dx;
          const size_t j = o + static_cast<size_t>(std::clamp(xx, 0, W - 1));
          const bool take = row_in && xx >= 0 && xx < W && code[j] == c[x] && araw[j] >= 0;
          v[3 * (dy + 1) + dx + 1] = take ? araw[j] : std::numeric_limits<float>::infinity();
          m += take;
        }
      }
      sort9(v);
      float a = v[m / 2];
      // On the sunlit level only a pixel more shade than sun (α < 1/2: its own light would have
      // put it in the shade, the split's 3 x 3 majority put it in the sun) leaves it: a sunlit
      // pixel near a shadow speck that is only somewhat darker is as likely dark asphalt (on the
      // bundled KITTI frame, moving those too lifted a sunlit patch's night texture to 2.01x a
      // shaded stretch of the same road, past asphalt's factor 2; SunShade.BundledKittiRoad…).
      if (on_sun && a >= 0.5f) a = 1;
      if (a < snap[id]) a = 0;  // within kPenumbraTexture of a level is on it
      else if (a > 1 - snap[id]) a = 1;
      if ((a == 0 && !on_sun) || (a == 1 && on_sun)) continue;  // its level's scale, as before
      const size_t i = static_cast<size_t>(y) * W + x;
      float sc[3];
      for (int k = 0; k < 3; ++k) sc[k] = scale_shade[id][k] * std::exp(a * log_scale_ratio[id][k]);
      box_scaled_block(day.data() + 3 * i, 1, coef, sc, cap[id], f.data() + 3 * i);  // pass 2's arithmetic
    }
  }
}
}  // namespace

void sun_penumbrae_enabled(bool on) { g_sun_penumbrae.store(on, std::memory_order_relaxed); }

ImageF reflectance_texture_with(const ImageF& day, const ImageU16& labels, const ScenePreset& p, ClassMeans* carried,
                                ImageF* work_luma, const TextureSums* sums, DayBalance* balance_used) {
  if (work_luma && (day.width() != 2 * work_luma->width() || day.height() != 2 * work_luma->height()))
    fail("reflectance_texture: the working luminance must be half the frame's size");
  const auto& K = spectrum::band_luminous_efficacy_lm_per_W();
  // The day photo's white balance: a sequence's carried one, else the one the linearisation's pass
  // found (the same as day_white_balance of this image), else found here.
  const bool sums_of_this = sums && sums->image == day.data() && sums->labels == labels.data();
  DayBalance balance;
  if (carried && carried->balance_set) balance = carried->balance;
  else if (sums_of_this && p.day_white_balance == DayWhiteBalance::Road && sums->balance.use != DayBalance::Use::Off &&
           !sums->balance_carried)
    balance = sums->balance;
  else balance = day.channels() == 3 && labels.width() == day.width() && labels.height() == day.height()
                     ? day_white_balance(day, labels, p)
                     : DayBalance();
  if (carried && !carried->balance_set && balance.use == DayBalance::Use::Road) {
    carried->balance = balance;
    carried->balance_set = true;
  }
  if (balance_used) *balance_used = balance;
  const BoxCoef coef = box_coef(balance.gain);
  // Luminous efficacy of a linear sRGB colour through the box basis: Y = Σ_r K_r (M·s)_r
  // (after clipping negatives, which only out-of-gamut colours have).
  const size_t n = day.pixel_count();
  ImageF f(day.width(), day.height(), 3, uninitialized, "W.lm-1");
  // Pass 1: the class sums of Y, over a fixed set of chunks summed in order afterwards, so the
  // result does not depend on the thread count (texture_class_sums); made by the linearisation's
  // pass when it was given the labels (linearize_with_texture_sums).
  std::vector<std::array<double, 2 * kLabelCount>> computed;
  const bool have = sums_of_this && sums->part.size() == static_cast<size_t>(kTextureChunks) &&
                    day.channels() == 3 && labels.pixel_count() == n && sums->balance.gain == balance.gain;
  if (!have) {
    g_texture_own_class_sums.fetch_add(1, std::memory_order_relaxed);
    computed.resize(kTextureChunks);
    texture_class_sums(labels.data(), n, coef, computed.data(),
                       [&](int, size_t first, int) { return day.data() + 3 * first; }, SunPassRows());
  }
  const auto& part = have ? sums->part : computed;
  double sum[kLabelCount] = {}, cnt[kLabelCount] = {};
  for (const auto& ps : part)
    for (int id = 0; id < kLabelCount; ++id) { sum[id] += ps[id]; cnt[id] += ps[kLabelCount + id]; }
  // The day's sunlight out of the diffuse classes: their sunlit pixels divided by g, so the class
  // mean is taken over Y with that division, Σ Y − (1 − 1/g)·Σ_sunlit Y (sun_shade_split).
  const SunShadeSplit sun = sun_shade_split(day, labels, p, cnt, have ? sums->sun.get() : nullptr, balance.gain);
  float scale[kLabelCount], scale_sun[kLabelCount], scale_shade[kLabelCount][3];
  for (int id = 0; id < kLabelCount; ++id) {
    const double g = sun.ratio[id];
    const double flattened = g > 1 ? sum[id] - (1 - 1 / g) * sun.sun_sum[id] : sum[id];
    double mean = cnt[id] > 0 ? flattened / cnt[id] : 0;
    if (carried && carried->mean[id] > 0) mean = carried->mean[id];
    else if (carried && mean > 1e-9 && cnt[id] >= kClassMeanMinShare * static_cast<double>(n)) carried->mean[id] = mean;
    scale[id] = mean > 1e-9 ? static_cast<float>(class_reflectance(id, p) / mean) : 0.f;
    scale_sun[id] = mean > 1e-9 ? static_cast<float>(class_reflectance(id, p) / (mean * g)) : 0.f;
    // The shade's pixels of a split class also lose the blue sky's colour cast (shade_tint).
    for (int k = 0; k < 3; ++k)
      scale_shade[id][k] = mean > 1e-9 ? static_cast<float>(class_reflectance(id, p) / mean * sun.shade_tint[id][k]) : 0.f;
  }
  const uint8_t* sunlit = sun.sunlit.empty() ? nullptr : sun.sunlit.data();
  const float flat = static_cast<float>(1.0 / (K[0] + K[1] + K[2]));  // grey where the class is black
  // Each band of f at most the class's band reflectance bound ρ_max (class_reflectance_max):
  // f_k = ρ_max/ΣK is a surface reflecting ρ_max in band k (a grey of that reflectance has
  // Y = Σ K_k f_k = ρ_max), so the luminance factor Y is at most ρ_max too.
  float cap[kLabelCount];
  for (int id = 0; id < kLabelCount; ++id)
    cap[id] = static_cast<float>(class_reflectance_max(id, p) / (K[0] + K[1] + K[2]));
  // Pass 2, per run of one label: its scale times the box RGB (or its flat grey), capped.
#pragma omp parallel for schedule(static)
  for (int ch = 0; ch < kTextureChunks; ++ch) {
    const uint16_t* lab = labels.data();
    const float* day_px = day.data();
    float* f_px = f.data();
    const size_t i0 = n * ch / kTextureChunks, i1 = n * (ch + 1) / kTextureChunks;
    for (size_t i = i0; i < i1;) {
      const int id = lab[i];
      size_t e = run_end(lab, i, i1);
      float sc[3] = {scale[id], scale[id], scale[id]};
      if (sunlit && sun.ratio[id] > 1) {  // runs of one label and one side of the sun/shade split
        const uint8_t m = sunlit[i];
        for (size_t k = i + 1; k < e; ++k)
          if (sunlit[k] != m) { e = k; break; }
        for (int k = 0; k < 3; ++k) sc[k] = m ? scale_sun[id] : scale_shade[id][k];
      }
      float* o = f_px + 3 * i;
      if (scale[id] > 0) {
        for (size_t b = i; b < e; b += kBoxBlock) {
          const int nb = static_cast<int>(std::min<size_t>(kBoxBlock, e - b));
          box_scaled_block(day_px + 3 * b, nb, coef, sc, cap[id], f_px + 3 * b);
        }
      } else {
        std::fill(o, o + 3 * (e - i), std::min(static_cast<float>(class_reflectance(id, p)) * flat, cap[id]));
      }
      i = e;
    }
    // The working luminance's rows whose last day pixel lies in this chunk, (2y + 2)·W in
    // (i0, i1]: read back from cache (the chunk's day pixels were just read above), each row
    // computed by one chunk, so the same rows whatever the thread count.
    if (work_luma) {
      const size_t row_pair = 2 * static_cast<size_t>(day.width());
      for (size_t y = i0 / row_pair; y < i1 / row_pair; ++y)
        work_luma_row(day, static_cast<int>(y), work_luma->row(static_cast<int>(y)));
    }
  }
  if (sunlit && g_sun_penumbrae.load(std::memory_order_relaxed))
    soften_sun_edges(day, labels, sun, coef, scale_shade, scale_sun, cap, f);
  return f;
}

std::array<double, 2> daylight_log_ratios(double cct_K) {
  // CIE 015:2018 §4.1.2 (Judd, MacAdam and Wyszecki 1964): the chromaticity of the CIE daylight
  // phase at a correlated colour temperature T, 4000-25000 K.
  const double T = cct_K, T2 = T * T, T3 = T2 * T;
  const double x = T <= 7000 ? -4.6070e9 / T3 + 2.9678e6 / T2 + 0.09911e3 / T + 0.244063
                             : -2.0064e9 / T3 + 1.9018e6 / T2 + 0.24748e3 / T + 0.237040;
  const double y = -3.000 * x * x + 2.870 * x - 0.275;
  // XYZ (Y = 1) to linear sRGB (D65 white, Rec. 709 primaries): the box basis's matrix.
  const double X = x / y, Z = (1 - x - y) / y;
  const auto& m = spectrum::kXyzToLinearSrgb;
  const double r = m[0][0] * X + m[0][1] + m[0][2] * Z, g = m[1][0] * X + m[1][1] + m[1][2] * Z,
               b = m[2][0] * X + m[2][1] + m[2][2] * Z;
  return {std::log(r / g), std::log(b / g)};
}

namespace {
// The daylight locus from 4000 to 25000 K, kDaylightLocusPoints points evenly spaced in mired
// (10⁶/T: 250 to 40), in the log-ratio plane: the polyline nearest_daylight searches first.
constexpr int kDaylightLocusPoints = 1024;
const std::vector<std::array<double, 2>>& daylight_locus() {
  static const std::vector<std::array<double, 2>> pts = [] {
    std::vector<std::array<double, 2>> v(kDaylightLocusPoints);
    for (int i = 0; i < kDaylightLocusPoints; ++i)
      v[i] = daylight_log_ratios(1e6 / (250.0 - 210.0 * i / (kDaylightLocusPoints - 1)));
    return v;
  }();
  return pts;
}
}  // namespace

std::array<double, 3> nearest_daylight(const std::array<double, 2>& q) {
  // The polyline's nearest segment first (the global search), then Newton's method on the curve
  // itself in mired m, on g(m) = (C(m) − q)·C'(m) = 0 with C' and C'' by central differences
  // (h = 10⁻³ mired): the polyline alone is off the curve by up to 2.7e-6 (its sagitta at the
  // formula's 7000 K seam), which a cast 0.3 off the locus turns into gains off by ~1e-5.
  const auto& L = daylight_locus();
  double best = std::numeric_limits<double>::infinity(), m = 250.0;
  for (size_t i = 0; i + 1 < L.size(); ++i) {
    const double dx = L[i + 1][0] - L[i][0], dy = L[i + 1][1] - L[i][1];
    const double t = std::clamp(((q[0] - L[i][0]) * dx + (q[1] - L[i][1]) * dy) / (dx * dx + dy * dy), 0.0, 1.0);
    const double px = L[i][0] + t * dx, py = L[i][1] + t * dy;
    const double d = (q[0] - px) * (q[0] - px) + (q[1] - py) * (q[1] - py);
    if (d < best) {
      best = d;
      m = 250.0 - 210.0 * (static_cast<double>(i) + t) / (kDaylightLocusPoints - 1);
    }
  }
  auto C = [](double mired) { return daylight_log_ratios(1e6 / mired); };
  constexpr double h = 1e-3;
  for (int it = 0; it < 4; ++it) {
    if (m - h < 40.0 || m + h > 250.0) break;  // at an end of the locus: the end itself
    const auto c0 = C(m), cp = C(m + h), cm = C(m - h);
    double g = 0, dg = 0;
    for (int k = 0; k < 2; ++k) {
      const double d1 = (cp[k] - cm[k]) / (2 * h), d2 = (cp[k] - 2 * c0[k] + cm[k]) / (h * h);
      g += (c0[k] - q[k]) * d1;
      dg += d1 * d1 + (c0[k] - q[k]) * d2;
    }
    if (!(dg > 0)) break;
    m = std::clamp(m - g / dg, 40.0, 250.0);
  }
  const auto c = C(m);
  return {c[0], c[1], 1e6 / m};
}

namespace {
// The day photo's white balance by its road (DayBalance, include/photosite/scene/night.h), from
// road_samples' sums of the linear sRGB of its road pixels (the linear image, or the day image's
// codes or floats decoded as linearize() decodes them: the same floats, so the same gains on
// every path): every 4th row and column (131,072 samples at 2048x1024 at most), summed in reading
// order (the same double sums at any thread count).
//
// Why: the darkening keeps each pixel's colour as the surface's (f_k ∝ c_k), so a cast of the day
// camera's (its white balance, a data set's processing) stays in every albedo: Cityscapes' frames
// carry a green one (mean linear G/R 1.29-1.37 over the five shared frames, KITTI's 0.99-1.09;
// docs/realism.md). Asphalt and concrete are near-neutral, so the road's mean colour is the light
// that fell on it as the camera saw it. Daylight, sunlit or in the shade of the blue sky, lies on
// the CIE daylight locus (a blue-yellow line); what takes the road's colour off that line (green or
// magenta) is not daylight but the camera. So only that departure is taken out: the gains move the
// road's mean (ln R/G, ln B/G) to the nearest point of the locus. The light's own colour stays (a
// road in the sky's shade stays blue; the sun/shade split takes that out where it splits a class),
// and green is kept (the raw converters' convention: gains relative to G).
//
// road_samples' `use`: a clipped channel (1: the file's white) or a black one has lost the sample's
// colour.
bool keeps_its_colour(const float* c) {
  return c[0] > 0.f && c[0] < 1.f && c[1] > 0.f && c[1] < 1.f && c[2] > 0.f && c[2] < 1.f;
}
// The balance from those samples' sums.
DayBalance road_day_balance(const RoadSums& r) {
  DayBalance b;
  const double* sum = r.sum;
  const long n = r.n;
  b.samples = n;
  if (n > 0)
    for (int k = 0; k < 3; ++k) b.road_mean[k] = sum[k] / static_cast<double>(n);
  if (n < kDayBalanceMinSamples) {
    b.use = DayBalance::Use::Fallback;
    b.why = fmt::format("{} road samples (under {})", n, kDayBalanceMinSamples);
    return b;
  }
  const std::array<double, 2> q{std::log(sum[0] / sum[1]), std::log(sum[2] / sum[1])};
  const std::array<double, 3> d = nearest_daylight(q);
  const std::array<double, 3> g{std::exp(d[0] - q[0]), 1.0, std::exp(d[1] - q[1])};
  b.road_cct_K = d[2];
  const double spread = std::max({g[0], g[1], g[2]}) / std::min({g[0], g[1], g[2]});
  if (!(spread <= kDayBalanceMaxSpread)) {
    b.use = DayBalance::Use::Fallback;
    b.why = fmt::format("the road's mean colour ({:.4g}, {:.4g}, {:.4g}) is {:.3g}x off the daylight locus "
                        "(over {}): not a camera cast",
                        b.road_mean[0], b.road_mean[1], b.road_mean[2], spread, kDayBalanceMaxSpread);
    return b;
  }
  b.gain = g;
  b.use = DayBalance::Use::Road;
  return b;
}
}  // namespace

namespace {
// The white balance a linearisation's class sums are made with (sums->balance), when `split` uses
// the road's: a sequence's carried one (their `carried`, marked sums->balance_carried), else the
// road's, from its samples as px(x, y, rgb) decodes them.
// `exact`: px decodes 8-bit codes through linearize()'s table, and the frame has at most 2^18
// samples (road_samples_sum_is_exact): its rows are then summed on the threads, each its own rows'
// sums, added in any order, since every partial sum is exact.
template <class Px>
void sums_day_balance(const ScenePreset* split, const DayBalance* carried, int W, int H, const uint16_t* labels,
                      const Px& px, TextureSums* sums, bool exact = false) {
  if (!split || split->day_white_balance != DayWhiteBalance::Road) return;
  if (carried && carried->use == DayBalance::Use::Road) {
    sums->balance = *carried;
    sums->balance_carried = true;
    return;
  }
  if (!exact) {
    sums->balance = road_day_balance(road_samples(W, H, labels, px, keeps_its_colour));
    return;
  }
  // Bands of 64 sampled rows (256 frame rows), taken as they come; each band's sums, then the bands'
  // added in band order (exact: any order gives these bits).
  const int bands = (H + 255) / 256;
  std::vector<RoadSums> part(bands);
#pragma omp parallel for schedule(dynamic)
  for (int b = 0; b < bands; ++b) {
    const int y0 = 256 * b, rows = std::min(H, y0 + 256) - y0;
    part[b] = road_samples(W, rows, labels + static_cast<size_t>(y0) * W,
                           [&](int x, int y, float* c) { px(x, y0 + y, c); }, keeps_its_colour);
  }
  RoadSums r;
  for (const RoadSums& q : part) {
    for (int k = 0; k < 3; ++k) r.sum[k] += q.sum[k];
    r.n += q.n;
  }
  sums->balance = road_day_balance(r);
}
// Whether road_samples' double sums over a W x H frame of 8-bit codes decoded by linearize()'s
// table are exact, so that any order of addition gives the same bits. The samples it keeps lie in
// (0, 1) (keeps_its_colour); the least nonzero decoded code, 1/(255·12.92) = 3.04e-4, lies in
// [2^-12, 2^-11), so every kept sample is a float that is a multiple of 2^-35 (a float's 24-bit
// significand; larger ones are multiples of coarser powers). With n samples each below 1, every
// partial sum is a multiple of 2^-35 below n; a double holds every such multiple exactly while
// n·2^35 ≤ 2^53, n ≤ 2^18. road_samples takes every 4th row and column: ⌈H/4⌉·⌈W/4⌉ samples at
// most (131,072 at 2048x1024; a 4096x2048 frame, 524,288, is summed in reading order on one thread).
// (The table's entries are checked once rather than assumed: each one in (0, 1) times 2^35 is a
// whole number.)
bool road_samples_sum_is_exact(int W, int H) {
  static const bool table_on_the_grid = [] {
    for (const float v : decode8().out)
      if (v > 0.f && v < 1.f && std::ldexp(static_cast<double>(v), 35) != std::floor(std::ldexp(static_cast<double>(v), 35)))
        return false;
    return true;
  }();
  return table_on_the_grid && static_cast<int64_t>((W + 3) / 4) * ((H + 3) / 4) <= (int64_t{1} << 18);
}
}  // namespace

DayBalance day_white_balance(const ImageF& day, const ImageU16& labels, const ScenePreset& p) {
  if (p.day_white_balance == DayWhiteBalance::None) return DayBalance();
  if (day.channels() != 3 || labels.width() != day.width() || labels.height() != day.height())
    fail("day_white_balance: the image and its labels differ in size");
  return road_day_balance(road_samples(day, labels, keeps_its_colour));
}

ImageF linearize_with_texture_sums(const ImageF& day, const ImageFileInfo& info, const ImageU16& labels,
                                   TextureSums* sums, const ScenePreset* split, const DayBalance* carried) {
  *sums = TextureSums();
  if (day.channels() != 3 || labels.width() != day.width() || labels.height() != day.height())
    return linearize(day, info);
  ImageF out(day.width(), day.height(), 3, uninitialized, "linear sRGB");
  const float* lut = srgb_decode_table().data();
  const bool decode = !info.is_float;
  const Decode8* d8 = decode && info.bits_per_sample == 8 ? &decode8() : nullptr;
  // Each block of pixels linearised (linearize()'s per-sample definition) right before pass 1
  // reads it back from L1; the first damaged pixel per chunk (each chunk's blocks ascend).
  std::vector<int64_t> bad(kTextureChunks, INT64_MAX);
  sums->part.resize(kTextureChunks);
  // The day white balance first: a sequence's carried one, else from the road's samples decoded as
  // the pass decodes them (day_white_balance of the linear image, to the bit); a damaged sample
  // decodes as 0, which the balance skips, and the pass below names it.
  int64_t ignored = INT64_MAX;
  sums_day_balance(split, carried, day.width(), day.height(), labels.data(), [&](int x, int y, float* c) {
    linearize_rgb_samples(day.row(y) + 3 * x, c, 3, static_cast<int64_t>(y) * day.width() + x, decode, d8, lut,
                          &ignored);
  }, sums);
  // With the split on, its block sums from the same Y (sun_pass_rows).
  const SunPassRows sun = sun_pass_rows(split, out.data(), labels.data(), day.width(), day.height(), sums);
  texture_class_sums(labels.data(), day.pixel_count(), box_coef(sums->balance.gain), sums->part.data(), [&](int ch, size_t first, int count) {
    linearize_rgb_samples(day.data() + 3 * first, out.data() + 3 * first, 3 * count, static_cast<int64_t>(first), decode,
                          d8, lut, &bad[ch]);
    return static_cast<const float*>(out.data() + 3 * first);
  }, sun);
  const int64_t first_bad = *std::min_element(bad.begin(), bad.end());
  if (first_bad != INT64_MAX) fail_damaged_pixel(day, info, first_bad);
  sums->image = out.data();
  sums->labels = labels.data();
  return out;
}

namespace {
// n samples of 8-bit sRGB codes to linear sRGB: d8.out[code], which is what linearize() gives
// their floats code·(1/255) (each is one of the 256 values Decode8::in, so it reads the table).
void decode8_samples_scalar(const uint8_t* c, int n, const Decode8& d8, float* o) {
  for (int j = 0; j < n; ++j) o[j] = d8.out[c[j]];
}
#if defined(__x86_64__)
// The same table read eight (AVX2) or sixteen (AVX-512) samples at a time by a gather.
__attribute__((target("avx2"))) void decode8_samples_avx2(const uint8_t* c, int n, const Decode8& d8, float* o) {
  int j = 0;
  for (; j + 8 <= n; j += 8) {
    const __m256i code = _mm256_cvtepu8_epi32(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(c + j)));
    _mm256_storeu_ps(o + j, _mm256_i32gather_ps(d8.out, code, 4));
  }
  decode8_samples_scalar(c + j, n - j, d8, o + j);
}
__attribute__((target("avx512f"))) void decode8_samples_avx512(const uint8_t* c, int n, const Decode8& d8, float* o) {
  int j = 0;
  for (; j + 16 <= n; j += 16) {
    const __m512i code = _mm512_cvtepu8_epi32(_mm_loadu_si128(reinterpret_cast<const __m128i*>(c + j)));
    _mm512_storeu_ps(o + j, _mm512_i32gather_ps(code, d8.out, 4));
  }
  decode8_samples_scalar(c + j, n - j, d8, o + j);
}
// With AVX-512 VBMI (Ice Lake, Zen 4 on), 64 samples at a time without a gather (a 16-lane
// gather is about one sample per cycle on Zen 4): the table's 256 floats as four planes of their
// bytes, 256 bytes a plane in four registers; each plane's 64 bytes by two two-register byte
// permutes (the code's low 7 bits) and a blend on its top bit; the four byte planes interleaved
// back into floats (bytes, then 16-bit pairs), whose order the codes' own permute (kDecode8Order)
// has undone beforehand (Decode8::plane). The floats are the table's, bit for bit.
// After the unpacks, float e of 16-byte lane L of output vector k is the byte at position
// 16L + 4k + e; the codes are permuted so that it holds code 16k + 4L + e, making output vector k
// the floats 16k .. 16k + 15 (the permutation swaps L and k: its own inverse).
struct Decode8Order {
  alignas(64) uint8_t idx[64];
  Decode8Order() {
    for (int L = 0; L < 4; ++L)
      for (int k = 0; k < 4; ++k)
        for (int e = 0; e < 4; ++e) idx[16 * L + 4 * k + e] = static_cast<uint8_t>(16 * k + 4 * L + e);
  }
};
const Decode8Order kDecode8Order;
const bool kHaveVbmi = [] {
#if defined(__GNUC__)
  __builtin_cpu_init();
  return __builtin_cpu_supports("avx512vbmi") != 0;
#else
  return false;
#endif
}();
bool decode8_vbmi = kHaveVbmi;  // texture_decode_vbmi() turns it off (tests run both paths)
__attribute__((target("avx512f,avx512bw,avx512vbmi"))) void decode8_samples_vbmi(const uint8_t* c, int n, const Decode8& d8,
                                                                                   float* o) {
  __m512i t[4][4];
  for (int b = 0; b < 4; ++b)
    for (int q = 0; q < 4; ++q) t[b][q] = _mm512_load_si512(d8.plane[b] + 64 * q);
  const __m512i order = _mm512_load_si512(kDecode8Order.idx);
  int j = 0;
  for (; j + 64 <= n; j += 64) {
    const __m512i code = _mm512_maskz_permutexvar_epi8(~__mmask64{0}, order, _mm512_loadu_si512(c + j));
    const __mmask64 upper = _mm512_movepi8_mask(code);  // code >= 128
    __m512i byte[4];
    for (int b = 0; b < 4; ++b)
      byte[b] = _mm512_mask_blend_epi8(upper, _mm512_permutex2var_epi8(t[b][0], code, t[b][1]),
                                       _mm512_permutex2var_epi8(t[b][2], code, t[b][3]));
    const __m512i lo01 = _mm512_unpacklo_epi8(byte[0], byte[1]), hi01 = _mm512_unpackhi_epi8(byte[0], byte[1]);
    const __m512i lo23 = _mm512_unpacklo_epi8(byte[2], byte[3]), hi23 = _mm512_unpackhi_epi8(byte[2], byte[3]);
    _mm512_storeu_si512(o + j, _mm512_unpacklo_epi16(lo01, lo23));
    _mm512_storeu_si512(o + j + 16, _mm512_unpackhi_epi16(lo01, lo23));
    _mm512_storeu_si512(o + j + 32, _mm512_unpacklo_epi16(hi01, hi23));
    _mm512_storeu_si512(o + j + 48, _mm512_unpackhi_epi16(hi01, hi23));
  }
  decode8_samples_scalar(c + j, n - j, d8, o + j);  // the last n mod 64
}
#endif
void decode8_samples(const uint8_t* c, int n, const Decode8& d8, float* o) {
#if defined(__x86_64__)
  const int isa = std::min(kIsa, max_isa);
  if (isa == 2 && decode8_vbmi) return decode8_samples_vbmi(c, n, d8, o);
  if (isa == 2) return decode8_samples_avx512(c, n, d8, o);
  if (isa == 1) return decode8_samples_avx2(c, n, d8, o);
#endif
  decode8_samples_scalar(c, n, d8, o);
}
}  // namespace

void texture_decode_vbmi(bool on) {
#if defined(__x86_64__)
  decode8_vbmi = on && kHaveVbmi;
#else
  (void)on;
#endif
}

namespace {
// linearize() of the codes' floats, as read_image gives them (channel counts other than RGB).
ImageF linearize_code_floats(const ImageU8& codes, const Decode8& d8) {
  ImageF day(codes.width(), codes.height(), codes.channels(), uninitialized);
  for (size_t i = 0; i < codes.size(); ++i) day[i] = d8.in[codes[i]];
  ImageFileInfo info;
  info.bits_per_sample = 8;
  info.srgb_encoded = true;
  return linearize(day, info);
}
}  // namespace

ImageF linearize_codes_with_texture_sums(const ImageU8& codes, const ImageU16& labels, TextureSums* sums,
                                         const ScenePreset* split, const DayBalance* carried) {
  *sums = TextureSums();
  const Decode8& d8 = decode8();
  // Not the fused case: linearize() of the codes' floats.
  if (codes.channels() != 3 || labels.width() != codes.width() || labels.height() != codes.height())
    return linearize_code_floats(codes, d8);
  ImageF out(codes.width(), codes.height(), 3, uninitialized, "linear sRGB");
  // Each block of pixels decoded right before pass 1 reads it back from L1 (as
  // linearize_with_texture_sums; codes have no damaged values to look for).
  sums->part.resize(kTextureChunks);
  // The day white balance first (a sequence's carried one, else from the road's codes read through
  // the same table).
  // (On the threads where its sums are exact: serial, it was 0.35-0.39 ms of the stage's 2.2-2.4
  // at 2 threads on the bench frame, the second thread idle; docs/benchmarks.md, "Forty-seventh session".)
  sums_day_balance(split, carried, codes.width(), codes.height(), labels.data(), [&](int x, int y, float* c) {
    const uint8_t* s = codes.data() + 3 * (static_cast<size_t>(y) * codes.width() + x);
    c[0] = d8.out[s[0]], c[1] = d8.out[s[1]], c[2] = d8.out[s[2]];
  }, sums, road_samples_sum_is_exact(codes.width(), codes.height()));
  const SunPassRows sun = sun_pass_rows(split, out.data(), labels.data(), codes.width(), codes.height(), sums);
  texture_class_sums(labels.data(), codes.pixel_count(), box_coef(sums->balance.gain), sums->part.data(), [&](int, size_t first, int count) {
    decode8_samples(codes.data() + 3 * first, 3 * count, d8, out.data() + 3 * first);
    return static_cast<const float*>(out.data() + 3 * first);
  }, sun);
  sums->image = out.data();
  sums->labels = labels.data();
  return out;
}

namespace {
// A light of luminance 1 relative to D65's Planck proxy (6504 K) at luminance 1, per band.
std::array<double, 3> relative_to_d65(const std::array<double, 3>& a) {
  const auto d = spectrum::blackbody_rgb(6504.0, 1.0);
  return {a[0] / d[0], a[1] / d[1], a[2] / d[2]};
}
}  // namespace

std::array<double, 3> illuminant_tint(double cct_K) { return relative_to_d65(spectrum::blackbody_rgb(cct_K, 1.0)); }

const std::array<double, 3>* lamp_camera_rgb(const ScenePreset& p, spectrum::LampSpectrum s) {
  const auto& w = p.lamp_camera_rgb[static_cast<int>(s)];
  return w[0] > 0 || w[1] > 0 || w[2] > 0 ? &w : nullptr;
}

std::array<double, 3> streetlamp_rgb(const ScenePreset& p, double luminance) {
  switch (p.streetlamp_type) {
    case StreetlampType::Hps:
      if (const auto* w = lamp_camera_rgb(p, spectrum::LampSpectrum::Hp1))
        return {(*w)[0] * luminance, (*w)[1] * luminance, (*w)[2] * luminance};
      return spectrum::hp1_rgb(luminance);
    case StreetlampType::Led:
      if (const auto* w = lamp_camera_rgb(p, spectrum::LampSpectrum::LedBHeads))
        return {(*w)[0] * luminance, (*w)[1] * luminance, (*w)[2] * luminance};
      break;  // without a camera: the Planck proxy
  }
  return spectrum::blackbody_rgb(p.streetlamp_cct_K, luminance);
}

std::array<double, 3> streetlamp_tint(const ScenePreset& p) {
  switch (p.streetlamp_type) {
    case StreetlampType::Hps:
      if (const auto* w = lamp_camera_rgb(p, spectrum::LampSpectrum::Hp1)) return relative_to_d65(*w);
      return relative_to_d65(spectrum::hp1_rgb(1.0));
    case StreetlampType::Led:
      if (const auto* w = lamp_camera_rgb(p, spectrum::LampSpectrum::LedBStreet)) return relative_to_d65(*w);
      break;  // without a camera: the Planck proxy
  }
  return illuminant_tint(p.street_cct_K);
}

DarkenParams darken_params(const ScenePreset& p) {
  const auto& K = spectrum::band_luminous_efficacy_lm_per_W();
  const auto tm = illuminant_tint(p.moon_cct_K), ts = illuminant_tint(p.skyglow_cct_K);
  // Ambient only (moon and sky glow, on every surface alike): the street lighting reaches the
  // ground as lamp pools and vertical surfaces as each pixel's own E_v from the same lamps, both
  // in metres and added in the light map (scene/street.cpp add_street_lighting,
  // add_vertical_street_light), so none of it is counted here.
  DarkenParams d;
  for (int k = 0; k < 3; ++k) {
    const double amb = p.moon_lux * tm[k] + p.skyglow_lux * ts[k];
    d.ambient[k] = static_cast<float>(amb / units::pi);
  }
  // Sky: its own luminance, with the day's relative luminance pattern (clouds) kept and the
  // colour of the glow (the night sky does not keep the day's blue): L = L_sky·(Y/Ȳ)·s(CCT).
  const auto glow = spectrum::blackbody_rgb(p.skyglow_cct_K, p.sky_luminance_cd_m2);
  d.rho_sky = std::max(1e-6, p.rho_sky);
  for (int k = 0; k < 3; ++k) {
    d.K[k] = K[k];
    d.glow[k] = glow[k];
  }
  std::copy(ground_classes().begin(), ground_classes().end(), d.ground_class);
  return d;
}

ImageF darken(const ImageF& f, const ImageU16& labels, const ScenePreset& p) {
  const DarkenParams d = darken_params(p);
  ImageF out(f.width(), f.height(), 3, uninitialized, unit::radiance);
  const size_t n = out.pixel_count();
#pragma omp parallel for schedule(static)
  for (size_t i = 0; i < n; ++i) darken_pixel(f.data() + 3 * i, labels[i], d, out.data() + 3 * i);
  return out;
}

}  // namespace photosite::scene
