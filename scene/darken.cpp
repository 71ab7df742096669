// Linearization and per-class darkening under night illumination (stage 1).
#include <algorithm>
#include <climits>
#include <cmath>
#include <fmt/format.h>
#include <vector>
#if defined(__x86_64__)
#include <immintrin.h>
#endif

#include "photosite/error.h"
#include "photosite/scene/night.h"
#include "photosite/sensor/isp.h"
#include "photosite/sensor/spectrum.h"
#include "photosite/units.h"
#include "scene/darken_detail.h"

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
  const int64_t y = index / day.width(), x = index % day.width();
  fail_at(info.path, fmt::format("pixel ({}, {}) is {}: NaN and Inf are not light; the image is damaged",
                                 x, y, day.at(static_cast<int>(x), static_cast<int>(y), 0)));
}

namespace {
// The decode of a value v in [0, 1]: linear interpolation in srgb_decode_table.
inline float decode_interp(float v, const float* lut) {
  const float t = v * 4096.f;
  const int i = std::min(4095, static_cast<int>(t));
  return lut[i] + (lut[i + 1] - lut[i]) * (t - i);
}
// 8-bit files: read_image gives the 256 values code·(1/255) (OpenImageIO's conversion). Their
// decodes, by decode_interp itself, in a 256-entry table: a value that is one of them reads the
// table, any other value interpolates, so the result is the same to the bit either way.
struct Decode8 { float in[256], out[256]; };
const Decode8& decode8() {
  static const Decode8 d = [] {
    Decode8 t;
    const float* lut = srgb_decode_table().data();
    for (int c = 0; c < 256; ++c) {
      t.in[c] = c * (1.f / 255);
      t.out[c] = decode_interp(t.in[c], lut);
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
    const __m256 is_code = _mm256_cmp_ps(_mm256_i32gather_ps(d8.in, code, 4), v, _CMP_EQ_OQ);
    if (_mm256_movemask_ps(_mm256_and_ps(in_range, is_code)) != 0xff) return j;
    _mm256_storeu_ps(o + j, _mm256_i32gather_ps(d8.out, code, 4));
  }
  return j;
}
#endif
}  // namespace

ImageF linearize(const ImageF& day, const ImageFileInfo& info) {
  const int c = day.channels();
  ImageF out(day.width(), day.height(), 3, uninitialized, "linear sRGB");
  const float* lut = srgb_decode_table().data();
  const bool decode = !info.is_float;
  const Decode8* d8 = decode && info.bits_per_sample == 8 ? &decode8() : nullptr;
  // NaN and Inf in a linear (EXR) day image are damage, not light: refused, first one named.
  // Negatives are kept as out-of-gamut colour and clipped to 0 like integer files' codes.
  int64_t bad = INT64_MAX;  // first damaged pixel in reading order (y·width + x)
#if defined(__x86_64__)
  static const bool avx2 = __builtin_cpu_supports("avx2");
#endif
#pragma omp parallel for schedule(static) reduction(min : bad)
  for (int y = 0; y < day.height(); ++y) {
    const float* in = day.row(y);
    float* o = out.row(y);
    if (c == 3 && d8) {
      // 8-bit RGB: one flat loop over the row's samples; the checks below, for a value outside
      // [0, 1] (NaN, Inf, negative, above white), are taken only when one is.
      const int n = 3 * day.width();
      for (int j = 0; j < n; ++j) {
#if defined(__x86_64__)
        if (avx2 && (j & 7) == 0) {  // eight at a time while all eight are table codes
          j = decode8_codes_avx2(in, j, n, *d8, o);
          if (j >= n) break;
        }
#endif
        float v = in[j];
        if (!(v >= 0.f && v <= 1.f)) [[unlikely]] {
          if (!std::isfinite(v)) {
            bad = std::min(bad, static_cast<int64_t>(y) * day.width() + j / 3);
            v = 0;
          }
          if (v < 0) v = 0;
          v = std::min(v, 1.f);
        }
        const int code = static_cast<int>(v * 255.f + 0.5f);
        o[j] = d8->in[code] == v ? d8->out[code] : decode_interp(v, lut);
      }
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

namespace {
// Box RGB (M·s, negatives clipped) of n pixels into f and each pixel's luminous efficacy
// Y = Σ_r K_r·(M·s)_r into y: per pixel the same operations in the same order whatever the
// instruction set (no contraction into fused multiply-adds: -ffp-contract=off), so the same bits;
// the loop carries no dependence, so the AVX2 clone runs four pixels at once.
constexpr int kBoxBlock = 256;
__attribute__((target_clones("avx2", "default")))
void box_rgb_block(const float* s, int n, const std::array<std::array<double, 3>, 3>& Mr,
                   const std::array<double, 3>& Kr, float* f, double* y) {
  const double M00 = Mr[0][0], M01 = Mr[0][1], M02 = Mr[0][2], M10 = Mr[1][0], M11 = Mr[1][1], M12 = Mr[1][2],
               M20 = Mr[2][0], M21 = Mr[2][1], M22 = Mr[2][2], K0 = Kr[0], K1 = Kr[1], K2 = Kr[2];
  for (int i = 0; i < n; ++i) {
    const double r = s[3 * i], g = s[3 * i + 1], b = s[3 * i + 2];
    const double v0 = std::max(0.0, M00 * r + M01 * g + M02 * b);
    const double v1 = std::max(0.0, M10 * r + M11 * g + M12 * b);
    const double v2 = std::max(0.0, M20 * r + M21 * g + M22 * b);
    f[3 * i] = static_cast<float>(v0);
    f[3 * i + 1] = static_cast<float>(v1);
    f[3 * i + 2] = static_cast<float>(v2);
    y[i] = ((0.0 + K0 * v0) + K1 * v1) + K2 * v2;
  }
}
}  // namespace

ImageF reflectance_texture(const ImageF& day, const ImageU16& labels, const ScenePreset& p, ClassMeans* carried) {
  const auto& K = spectrum::band_luminous_efficacy_lm_per_W();
  const auto& M = spectrum::linear_srgb_to_box();
  // Luminous efficacy of a linear sRGB colour through the box basis: Y = Σ_r K_r (M·s)_r
  // (before clipping negatives, which only out-of-gamut colours have).
  const size_t n = day.pixel_count();
  ImageF f(day.width(), day.height(), 3, uninitialized, "W.lm-1");
  // Pass 1: box RGB into f (reused as scratch) and the class sums of Y, over a fixed set of
  // chunks summed in order afterwards, so the result does not depend on the thread count.
  constexpr int kChunks = 64;
  std::vector<std::array<double, 2 * kLabelCount>> part(kChunks);
#pragma omp parallel for schedule(static)
  for (int ch = 0; ch < kChunks; ++ch) {
    auto& ps = part[ch];
    ps.fill(0.0);
    const size_t i0 = n * ch / kChunks, i1 = n * (ch + 1) / kChunks;
    // The class's running sum is held in a register along a run of one label and stored at its
    // end: the same additions in the same order as adding into ps per pixel, without a store and
    // reload between them (which would bound the loop by their latency).
    const uint16_t* lab = labels.data();
    const float* day_px = day.data();
    float* f_px = f.data();
    double ys[kBoxBlock];
    for (size_t i = i0; i < i1;) {
      const int id = lab[i];
      double acc = ps[id];
      size_t e = i + 1;
      while (e < i1 && lab[e] == id) ++e;
      for (size_t b = i; b < e; b += kBoxBlock) {
        const int nb = static_cast<int>(std::min<size_t>(kBoxBlock, e - b));
        box_rgb_block(day_px + 3 * b, nb, M, K, f_px + 3 * b, ys);
        for (int j = 0; j < nb; ++j) acc += ys[j];
      }
      ps[id] = acc;
      ps[kLabelCount + id] += static_cast<double>(e - i);  // a count: exact in a double (< 2^53)
      i = e;
    }
  }
  double sum[kLabelCount] = {}, cnt[kLabelCount] = {};
  for (const auto& ps : part)
    for (int id = 0; id < kLabelCount; ++id) { sum[id] += ps[id]; cnt[id] += ps[kLabelCount + id]; }
  float scale[kLabelCount];
  for (int id = 0; id < kLabelCount; ++id) {
    double mean = cnt[id] > 0 ? sum[id] / cnt[id] : 0;
    if (carried && carried->mean[id] > 0) mean = carried->mean[id];
    else if (carried && mean > 1e-9 && cnt[id] >= kClassMeanMinShare * static_cast<double>(n)) carried->mean[id] = mean;
    scale[id] = mean > 1e-9 ? static_cast<float>(class_reflectance(id, p) / mean) : 0.f;
  }
  const float flat = static_cast<float>(1.0 / (K[0] + K[1] + K[2]));  // grey where the class is black
  const float cap = static_cast<float>(5.0 / (K[0] + K[1] + K[2]));   // a pixel at most 5× its class
  // Pass 2, per run of one label: its scale on every sample (or its flat grey), capped.
#pragma omp parallel for schedule(static)
  for (int ch = 0; ch < kChunks; ++ch) {
    const uint16_t* lab = labels.data();
    float* f_px = f.data();
    const size_t i0 = n * ch / kChunks, i1 = n * (ch + 1) / kChunks;
    for (size_t i = i0; i < i1;) {
      const int id = lab[i];
      size_t e = i + 1;
      while (e < i1 && lab[e] == id) ++e;
      float* o = f_px + 3 * i;
      const size_t m = 3 * (e - i);
      if (scale[id] > 0) {
        const float s = scale[id];
        for (size_t j = 0; j < m; ++j) o[j] = std::min(s * o[j], cap);
      } else {
        std::fill(o, o + m, std::min(static_cast<float>(class_reflectance(id, p)) * flat, cap));
      }
      i = e;
    }
  }
  return f;
}

std::array<double, 3> illuminant_tint(double cct_K) {
  const auto a = spectrum::blackbody_rgb(cct_K, 1.0), d = spectrum::blackbody_rgb(6504.0, 1.0);
  return {a[0] / d[0], a[1] / d[1], a[2] / d[2]};
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
