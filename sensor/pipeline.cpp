#include "photosite/sensor/pipeline.h"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <immintrin.h>
#include <atomic>
#include <limits>
#include <fmt/format.h>
#include <opencv2/core.hpp>
#include <vector>

#include "core/isa_detail.h"
#include "photosite/error.h"
#include "photosite/rng.h"
#include "photosite/sensor/glare.h"
#include "photosite/sensor/poisson.h"
#include "photosite/sensor/spectrum.h"
#include "photosite/units.h"
#include "sensor/glare_detail.h"
#include "sensor/pixel_detail.h"

namespace photosite {

ResolvedExposure resolve(const CameraPreset& p, const LensPreset& lens, const ExposureSettings& s) {
  ResolvedExposure r{};
  r.exposure_s = s.exposure_s;
  if (!std::isfinite(r.exposure_s) || r.exposure_s < 0)
    fail_parameter("exposure_s", "", fmt::format(" {} s is impossible: an exposure time must be in [0, 3600] s", r.exposure_s));
  if (r.exposure_s > 3600)
    fail_parameter("exposure_s", "", fmt::format(" {} s is beyond one hour: an exposure time must be in [0, 3600] s", r.exposure_s));
  r.f_number = s.f_number.value_or(lens.f_number);
  if (!std::isfinite(r.f_number) || r.f_number < 0.5 || r.f_number > 64)
    fail_parameter("f_number", "", fmt::format(" {} is impossible (must be in [0.5, 64])", r.f_number));
  r.gain_db = s.gain_db;
  if (!std::isfinite(r.gain_db) || r.gain_db < 0 || r.gain_db > p.max_gain_db)
    fail_parameter("gain_db", "", fmt::format(" {} dB is outside the camera's range [0, {}] dB", r.gain_db, p.max_gain_db));
  r.gain_linear = units::db_to_gain(r.gain_db);
  r.temperature_c = s.temperature_c.value_or(p.temperature_c);
  if (!std::isfinite(r.temperature_c) || r.temperature_c < -100 || r.temperature_c > 200)
    fail_parameter("temperature_c", "",
                   fmt::format(" {} C is impossible: the sensor temperature must be in [-100, 200] C", r.temperature_c));
  r.system_gain_dn_per_e = p.system_gain_dn_per_e * r.gain_linear;
  // Dark current doubles every dark_current_doubling_c degrees (Arrhenius behaviour of
  // depletion-region generation near room temperature; EMVA 1288 R4.0 Sec. 7.1, Janesick 2007).
  const double doubling =
      std::exp2((r.temperature_c - p.dark_current_reference_c) / p.dark_current_doubling_c);
  r.dark_current_e_per_s = p.dark_current_e_per_s * doubling;
  r.hot_pixel_rate_e_per_s = p.hot_pixel_dark_current_e_per_s * doubling;
  return r;
}

double irradiance_per_radiance(double f_number, double magnification, double transmittance) {
  const double q = f_number * (1.0 + std::fabs(magnification));
  return units::pi * transmittance / (1.0 + 4.0 * q * q);
}

GlarePlan lens_glare_plan(const CameraPreset& p, const LensPreset& lens) {
  return plan_glare(lens.glare, px_per_degree(lens.focal_length_mm, p.pixel_pitch_um));
}

namespace {
// ∫ b_k(λ) QE_c(λ) λ/(hc) dλ with b_k = 1/(band width): photons-to-electrons per joule of band k's
// radiance, by 0.5-nm midpoints.
double band_photon_integral(const CameraPreset& p, FilterColor color, int k) {
  const double lo = spectrum::kBandLoNm[k], hi = spectrum::kBandHiNm[k], step = 0.5;
  double s = 0;
  for (double l = lo + step / 2; l < hi; l += step) s += p.qe.at(color, l) / units::photon_energy_J(l);
  return s * (step / (hi - lo));
}
}  // namespace

PhotonMatrix photon_matrix(const CameraPreset& p, const LensPreset& lens,
                           const ResolvedExposure& ex) {
  PhotonMatrix m{};
  const double area_m2 = std::pow(p.pixel_pitch_um * 1e-6, 2) * p.fill_factor;
  const double e_per_l = irradiance_per_radiance(ex.f_number, lens.magnification, lens.transmittance);
  for (int c = 0; c < kFilterColorCount; ++c) {
    const auto color = static_cast<FilterColor>(c);
    for (int k = 0; k < 3; ++k) m[c][k] = ex.exposure_s * area_m2 * e_per_l * band_photon_integral(p, color, k);
  }
  return m;
}

namespace {
// camera_metamer_rgb of a spectrum S(λ) over [lo, hi] nm.
std::array<double, 3> metamer_of(const CameraPreset& p, const std::function<double(double)>& S, double lo,
                                 double hi) {
  // The same quadrature as photon_matrix (0.5-nm midpoints, photons per joule), without the
  // exposure's and the pixel's factors, which cancel.
  const double step = 0.5;
  double Lv = 0;
  for (double l = lo + step / 2; l < hi; l += step) Lv += S(l) * spectrum::cie_y_bar(l);
  Lv *= 683 * step;
  std::vector<std::array<double, 3>> M;  // band integrals per filter colour the camera has
  std::vector<double> e;                 // the source's electrons per filter colour, per cd/m²
  for (int c = 0; c < kFilterColorCount; ++c) {
    const auto color = static_cast<FilterColor>(c);
    if (p.qe.qe[c].empty()) continue;
    std::array<double, 3> row{};
    for (int k = 0; k < 3; ++k) row[k] = band_photon_integral(p, color, k);
    double s = 0;
    for (double l = lo + step / 2; l < hi; l += step) s += S(l) * p.qe.at(color, l) / units::photon_energy_J(l);
    M.push_back(row);
    e.push_back(s * step / Lv);
  }
  std::array<double, 3> w{};
  if (M.empty() || !(Lv > 0)) return w;
  // The boxes in `mask` (bit k: box k) solved for e: OpenCV's SVD solve (exact for as many colours
  // as boxes, least squares for more); fewer colours than boxes (RCCC's two): the least-norm
  // solution x = Aᵀ·y with (A·Aᵀ)·y = e. Returns false where the solve fails.
  const cv::Mat b(static_cast<int>(e.size()), 1, CV_64F, e.data());
  auto solve = [&](int mask, std::array<double, 3>& out) {
    std::array<int, 3> cols{};
    int nc = 0;
    for (int k = 0; k < 3; ++k)
      if (mask >> k & 1) cols[nc++] = k;
    cv::Mat A(static_cast<int>(M.size()), nc, CV_64F), x;
    for (int r = 0; r < A.rows; ++r)
      for (int j = 0; j < nc; ++j) A.at<double>(r, j) = M[r][cols[j]];
    if (A.rows >= nc) {
      if (!cv::solve(A, b, x, cv::DECOMP_SVD)) return false;
    } else {
      cv::Mat y;
      if (!cv::solve(A * A.t(), b, y, cv::DECOMP_SVD)) return false;
      x = A.t() * y;
    }
    out = {0, 0, 0};
    for (int j = 0; j < nc; ++j) out[cols[j]] = x.at<double>(j);
    return true;
  };
  if (!solve(7, w)) return {0, 0, 0};
  if (w[0] >= 0 && w[1] >= 0 && w[2] >= 0) return w;
  // No non-negative box radiances give every filter colour the spectrum's electrons: a narrow LED
  // line such as a green signal's lies outside what the flat boxes can carry through these
  // filters. Then the non-negative w closest to them in least squares (Σ_c (M·w − e)_c², all in
  // electrons per cd/m², so the weakest filter's error counts least): the optimum of that convex
  // problem solves the unconstrained least squares on the boxes it leaves free, so the best of the
  // feasible solves on the six proper subsets of boxes is it (non-negative least squares, exactly).
  std::array<double, 3> best{};
  double best_r = std::numeric_limits<double>::infinity();
  for (int mask = 1; mask < 7; ++mask) {
    std::array<double, 3> x{};
    if (!solve(mask, x) || x[0] < 0 || x[1] < 0 || x[2] < 0) continue;
    double r = 0;
    for (size_t c = 0; c < M.size(); ++c) {
      const double d = M[c][0] * x[0] + M[c][1] * x[1] + M[c][2] * x[2] - e[c];
      r += d * d;
    }
    if (r < best_r) best_r = r, best = x;
  }
  return best;
}
}  // namespace

std::array<double, 3> camera_metamer_rgb(const CameraPreset& p, const double* spd, int n) {
  const double lo = 380, hi = 380 + 5.0 * (n - 1);
  return metamer_of(p, [&](double l) { return spectrum::table_5nm(spd, n, l); }, lo, hi);
}

std::array<double, 3> camera_metamer_rgb(const CameraPreset& p, spectrum::LampSpectrum s, double cct_K) {
  // HP1 is its 5-nm table (table_5nm, as camera_metamer_rgb of the table takes it). The LEDs'
  // Gaussians are evaluated where the quadrature needs them (their 17-30 nm widths would be coarsely
  // sampled on a 5-nm table); 380-780 nm holds all of their power (≥ 7 FWHM from each peak,
  // ~e⁻¹³⁶ of it outside). LED-B (led street lamps) is its blend of the CIE tables at cct_K, linear
  // between their 5-nm samples, on the same range.
  return metamer_of(p, [s, cct_K](double l) { return spectrum::lamp_spd(s, l, cct_K); }, 380, 780);
}

// detail::analog_row (sensor/pixel_detail.h). The per-pixel definition, with AVX-512 and AVX2
// clones: its floor and clamp in double vectorize there (roundpd), the same IEEE operations as
// the scalar code, so the same bits on every clone.
PHOTOSITE_TARGET_CLONES
void detail::analog_row_definition(float* __restrict erow, const float* __restrict off, const float* __restrict read,
                                   const float* __restrict col, float row_noise, float rn, float fw, double K,
                                   double black, double max_code, int w, float* __restrict drow,
                                   float* __restrict abrow) {
  const float blk = static_cast<float>(black);
  for (int x = 0; x < w; ++x) {
    const float e = shader::sense_electrons(erow[x], fw);
    erow[x] = e;
    const float d = shader::sense_raw_dn(e, off[x], rn, read[x], row_noise, col[x], K, black, max_code);
    drow[x] = d;
    abrow[x] = d - blk;
  }
}
namespace {
// analog_row where the CPU has AVX-512: 8 pixels a step, each float input loaded 8 wide and
// widened once (vcvtps2pd), where GCC's vectorization of the definition loaded 16 floats and
// split each load into halves (vextractf64x4). Per pixel the same IEEE operations in the same
// order as sense_electrons and sense_raw_dn (kernels/common/sensor_pixel.glsl):
//   e = min(drawn, fw)              std::min(a, b) = b < a ? b : a = vminps(b, a)
//   rn·z in float, then (((e + dsnu) + rn·z) + row) + col in double, ·K, + black, + 0.5,
//   floor (vrndscalepd toward −∞), clamp(dn, 0, max) = dn < 0 ? 0 : (max < dn ? max : dn)
//   = vmaxpd(0, vminpd(max, dn)) (NaN passes through both, as through std::clamp), float(dn),
//   d − black in float.
// Returns the first pixel it left (the definition finishes the row).
// The full-mask maskz forms: GCC 12's unmasked ones pass an uninitialized vector as the merge
// source (-Wmaybe-uninitialized); every lane is written either way.
__attribute__((target("avx512f"))) inline __m512d cvt8(__m256 a) { return _mm512_maskz_cvtps_pd(0xff, a); }
__attribute__((target("avx512f")))
int analog_row_avx512(float* __restrict erow, const float* __restrict off, const float* __restrict read,
                      const float* __restrict col, float row_noise, float rn, float fw, double K, double black,
                      double max_code, int w, float* __restrict drow, float* __restrict abrow) {
  const __m256 vfw = _mm256_set1_ps(fw), vrn = _mm256_set1_ps(rn), vblk = _mm256_set1_ps(static_cast<float>(black));
  const __m512d vrow = _mm512_set1_pd(static_cast<double>(row_noise)), vK = _mm512_set1_pd(K),
                vblack = _mm512_set1_pd(black), vhalf = _mm512_set1_pd(static_cast<double>(0.5f)),
                vmax = _mm512_set1_pd(max_code), vzero = _mm512_setzero_pd();
  int x = 0;
  for (; x + 8 <= w; x += 8) {
    const __m256 e = _mm256_min_ps(vfw, _mm256_loadu_ps(erow + x));
    _mm256_storeu_ps(erow + x, e);
    const __m256 rz = _mm256_mul_ps(vrn, _mm256_loadu_ps(read + x));
    __m512d v = _mm512_add_pd(cvt8(e), cvt8(_mm256_loadu_ps(off + x)));
    v = _mm512_add_pd(v, cvt8(rz));
    v = _mm512_add_pd(v, vrow);
    v = _mm512_add_pd(v, cvt8(_mm256_loadu_ps(col + x)));
    __m512d dn = _mm512_add_pd(_mm512_add_pd(_mm512_mul_pd(v, vK), vblack), vhalf);
    dn = _mm512_maskz_roundscale_pd(0xff, dn, _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC);
    dn = _mm512_maskz_max_pd(0xff, vzero, _mm512_maskz_min_pd(0xff, vmax, dn));
    const __m256 d = _mm512_maskz_cvtpd_ps(0xff, dn);
    _mm256_storeu_ps(drow + x, d);
    _mm256_storeu_ps(abrow + x, _mm256_sub_ps(d, vblk));
  }
  return x;
}
const bool kAnalogAvx512 = photosite::detail::have_avx512();
}  // namespace
void detail::analog_row(float* erow, const float* off, const float* read, const float* col, float row_noise, float rn,
                        float fw, double K, double black, double max_code, int w, float* drow, float* abrow) {
  const int x = kAnalogAvx512 ? analog_row_avx512(erow, off, read, col, row_noise, rn, fw, K, black, max_code, w,
                                                  drow, abrow)
                              : 0;
  analog_row_definition(erow + x, off + x, read + x, col + x, row_noise, rn, fw, K, black, max_code, w - x, drow + x,
                        abrow + x);
}

namespace {
// The widest vector level the glared photon row may take: the machine's (core/isa_detail.h),
// capped by detail::photon_row_max_isa (tests).
std::atomic<int> g_photon_isa_cap{2};

// The photon stage of one frame: e = M[c]·(R, G, B) with the cos⁴θ falloff, the lens glare
// fused in row by row. One row at a time (photon_row), so that mean_signal_electrons() writes
// the rows to an image and expose() hands each row straight to the sense stage.
struct PhotonStage {
  const ImageF& radiance;
  const CameraPreset& p;
  PhotonMatrix m;
  int w, h;
  double pitch_over_f, cx, cy;
  GlareSkirt skirt;
  int isa;  // the glared row's path: 2 AVX-512, 1 AVX2, 0 the per-pixel loops

  PhotonStage(const ImageF& rad, const CameraPreset& preset, const LensPreset& lens, const ResolvedExposure& ex,
              const GlareLevel1* level1)
      : radiance(rad), p(preset), m(photon_matrix(preset, lens, ex)), w(rad.width()), h(rad.height()),
        // cos⁴θ natural vignetting (the image is a centred crop of the sensor at its native
        // pitch): tan θ = r / f, cos⁴θ = 1 / (1 + r²/f²)².
        pitch_over_f(lens.cos4_falloff ? preset.pixel_pitch_um * 1e-3 / lens.focal_length_mm : 0.0),
        cx(0.5 * (w - 1)), cy(0.5 * (h - 1)),
        // Veiling glare of the lens (sensor/glare.h): the reduced-resolution pyramid first, then
        // its last upsample and the mix, one row at a time. It acts on the irradiance before the
        // cos⁴ falloff (APPROXIMATION: scattered light falls off with the angle of the pixel
        // where it lands, not of its source; docs/model_glare.md).
        // level1: the pyramid's level 1 made by the caller (the scene's compose pass), or null.
        skirt(glare_skirt(rad, lens_glare_plan(preset, lens), level1)),
        isa(std::min(detail::machine_isa_level(), g_photon_isa_cap.load(std::memory_order_relaxed))) {}

  // The sense stage's first step (SenseStage::mean_row: sense_mean_e, the mean collected
  // electrons signal·PRNU + dark·(dark-rate factor), capped) formed by the glared photon row's
  // AVX-512 or AVX2 loop on the photon electrons it has just made (expose()): the two
  // fixed-pattern maps' rows g, df are read there, beside the loop's division, instead of in a
  // pass of their own.
  // The row reports the pixels [xa, xb) whose mean it wrote (none: xa == xb); the caller forms
  // the rest by mean_row. The same float operations per pixel as mean_row, so the same means
  // (tests SenseFused.ExposeEqualsOpticsThenSenseAndReusedOutputsEqualFresh and
  // SenseFused.ExposeHoldsTheMeanCapInTheGlaredPhotonRow). Measured on the AMD EPYC Zen 4
  // (`bench night --threads 1 --cpu-clock`, 6 alternating pairs, 2026-11-30): `cpu: sensor
  // (expose)` median 23.62 -> 22.69 ms, lower in 6 of 6 (docs/benchmarks.md). The AVX2 loop
  // (with the vertical step t formed in it, glared_row_simd), at PHOTOSITE_MAX_ISA=avx2, six
  // rounds: 27.16 -> 26.44 ms, lower in 6 of 6 ("Twenty-sixth session: the sensor's AVX2 rows").
  struct MeanFusion {
    const float* g;
    const float* df;
    float dark;
    float* mean;
    int xa = 0, xb = 0;
  };
  // Per-thread scratch of photon_row.
  struct Scratch {
    std::vector<float> tmp;
    explicit Scratch(const PhotonStage& st) : tmp(st.skirt.active() ? glare_row_scratch(st.skirt) : 0) {}
  };
  // Row y of the mean signal into o[0, w); returns the first x whose radiance is not physical
  // (NaN, Inf, negative; its o[x] is 0), or -1.
  int row(int y, float* o, Scratch& sc, MeanFusion* mf = nullptr) const {
    if (mf) mf->xa = mf->xb = 0;
    const float* r = radiance.row(y);
    const double dy2 = (y - cy) * (y - cy);
    // The CFA colour of a pixel depends on the parity of x along a row (cfa_color).
    const double* me = m[static_cast<int>(cfa_color(p.cfa, 0, y))].data();
    const double* mo = m[static_cast<int>(cfa_color(p.cfa, 1, y))].data();
    bool physical;
    if (skirt.active() && isa >= 1) {
      physical = glared_row_simd(y, r, me, mo, dy2, o, sc, mf);
    } else if (skirt.active()) {
      // glare_row's mix keep·L + s_c·u fused into the photon row: the glared row is never stored.
      const float* u = glare_skirt_row(skirt, y, sc.tmp.data());
      glared_electrons_row(r, u, skirt.keep, skirt.scale.data(), 0, w, me, mo, cx, dy2, pitch_over_f, o);
      physical = physical_row(r, w);
    } else {
      electrons_row(r, w, me, mo, cx, dy2, pitch_over_f, o);
      physical = physical_row(r, w);
    }
    if (physical) return -1;
    if (mf) mf->xa = mf->xb = 0;  // o changes below: the caller forms every mean
    int bad = -1;  // the rare damaged row: the first bad pixel, and 0 where the radiance is not physical
    for (int x = 0; x < w; ++x)
      if (!shader::radiance_is_physical(r[3 * x], r[3 * x + 1], r[3 * x + 2])) {
        if (bad < 0) bad = x;
        o[x] = 0.f;
      }
    return bad;
  }
  // kernels/common/sensor_pixel.glsl's photon_electrons over a row (e = M[c]·(R, G, B), cos⁴θ
  // falloff; me, mo: the M rows of even and odd x). AVX-512 and AVX2 clones where it vectorizes:
  // the same IEEE operations in the same order per pixel, so the same bits on every clone.
  PHOTOSITE_TARGET_CLONES
  static void electrons_row(const float* __restrict g, int w, const double* me, const double* mo, double cx,
                            double dy2, double pitch_over_f, float* __restrict o) {
    const double e0 = me[0], e1 = me[1], e2 = me[2], o0 = mo[0], o1 = mo[1], o2 = mo[2];
    for (int x = 0; x < w; ++x) {
      const bool odd = x & 1;
      o[x] = shader::photon_electrons(odd ? o0 : e0, odd ? o1 : e1, odd ? o2 : e2, g[3 * x], g[3 * x + 1],
                                      g[3 * x + 2], x - cx, dy2, pitch_over_f);
    }
  }
  // electrons_row of the glared row, its samples g = glare_mix(keep, L, s_c, u) (the lens glare's
  // mix, kernels/common/glare.glsl, as glare_row forms it) made in the same loop from the
  // radiance row L and the upsampled skirt row u: the same float operations per sample, so the
  // same bits as glare_row then electrons_row (test GlareFastPath.FusedPhotonRowEqualsGlareThenPhotons),
  // without storing the glared row and reading it back.
  // Here over the n pixels x0 .. x0 + n − 1 of the row (l, u and o start at pixel x0).
  PHOTOSITE_TARGET_CLONES
  static void glared_electrons_row(const float* __restrict l, const float* __restrict u, float keep, const float* s3,
                                   int x0, int n, const double* me, const double* mo, double cx, double dy2,
                                   double pitch_over_f, float* __restrict o) {
    const double e0 = me[0], e1 = me[1], e2 = me[2], o0 = mo[0], o1 = mo[1], o2 = mo[2];
    const float s0 = s3[0], s1 = s3[1], s2 = s3[2];
    for (int i = 0; i < n; ++i) {
      const int x = x0 + i;
      const bool odd = x & 1;
      const float R = shader::glare_mix(keep, l[3 * i], s0, u[3 * i]);
      const float G = shader::glare_mix(keep, l[3 * i + 1], s1, u[3 * i + 1]);
      const float B = shader::glare_mix(keep, l[3 * i + 2], s2, u[3 * i + 2]);
      o[i] = shader::photon_electrons(odd ? o0 : e0, odd ? o1 : e1, odd ? o2 : e2, R, G, B, x - cx, dy2, pitch_over_f);
    }
  }

  // The glared photon row where the CPU has AVX-512 or AVX2: glare_skirt_row's horizontal step,
  // the mix, the photon integral and physical_row's test in one loop over 16 (AVX-512) or 8
  // (AVX2) pixels at a time (8 or 4 pixel pairs of acc_1's row t), in registers: u, the
  // upsampled skirt row, is never stored, and the radiance row is read once. Per sample the same
  // IEEE operations in the same order as upsample_row's interior (even pixel 2j: ¼·t[j − 1] +
  // ¾·t[j]; odd 2j + 1: ¾·t[j] + ¼·t[j + 1]), glare_mix and photon_electrons (double: (m0·R +
  // m1·G) + m2·B, divided by (1 + t²)² with t² = ((dx² + dy²)·p)·p), no FMA, so the same bits as
  // glare_skirt_row then glared_electrons_row (test GlareFastPath.FusedPhotonRowEqualsGlareThenPhotons,
  // at every level). The row's ends (pixels 0, 1 and from the last whole block of pairs on)
  // take glared_electrons_row with glare_up_pixel's u. Returns whether every pixel's radiance
  // is physical (physical_row's test).
  //
  // The vertical step (t, glare_skirt_vertical_row's row of acc_1) is formed inside the loop
  // from acc_1's two rows (glared_pairs_avx512, glared_pairs_avx2), and stored for the row's
  // ends only: the whole 3·cw-float row t was written and read back per row (lerp_row, ~1.2 % of
  // perf's samples of `bench night --chain-only --threads 1`; `bench sense`'s photon stage
  // 0.3-0.5 ms lower without it on the AMD EPYC Zen 4, 2026-11-30, docs/benchmarks.md; the AVX2
  // loop since the twenty-sixth session).
  bool glared_row_simd(int y, const float* l, const double* me, const double* mo, double dy2, float* o,
                       Scratch& sc, MeanFusion* mf) const {
    const detail::GlareVerticalTaps vt = detail::glare_skirt_vertical_taps(skirt, y);
    float* t = sc.tmp.data() + glare_row_layout(skirt).t;
    const int cw = skirt.acc1->width();
    const size_t tn = 3 * static_cast<size_t>(cw);
    bool physical = true;
    // u: the ends' upsampled pixels below
    float* u = sc.tmp.data() + glare_row_layout(skirt).u;
    int j_end;
    if (isa >= 2)
      j_end = mf ? glared_pairs_avx512<true>(l, vt, cw, skirt.keep, skirt.scale.data(), me, mo, cx, dy2,
                                             pitch_over_f, o, physical, mf)
                 : glared_pairs_avx512<false>(l, vt, cw, skirt.keep, skirt.scale.data(), me, mo, cx, dy2,
                                              pitch_over_f, o, physical, nullptr);
    else
      j_end = mf ? glared_pairs_avx2<true>(l, vt, cw, skirt.keep, skirt.scale.data(), me, mo, cx, dy2, pitch_over_f,
                                           o, physical, mf)
                 : glared_pairs_avx2<false>(l, vt, cw, skirt.keep, skirt.scale.data(), me, mo, cx, dy2,
                                            pitch_over_f, o, physical, nullptr);
    if (mf && j_end > 1) mf->xa = 2, mf->xb = 2 * j_end;
    // t of the ends' taps (glare_up_pixel below): pixels 0 and 1 read pairs 0 and 1, pixels
    // from 2·j_end on the pairs from j_end − 1 on.
    detail::glare_vertical_lerp(vt, 0, std::min<size_t>(6, tn), t);
    if (std::max(2, 2 * j_end) < w) detail::glare_vertical_lerp(vt, 3 * static_cast<size_t>(j_end - 1), tn, t);
    // The rest: pixels [0, 2) and [2·j_end, w) (all of them when no block of pairs ran).
    auto rest = [&](int xa, int xb) {
      if (xa >= xb) return;
      for (int x = xa; x < xb; ++x) detail::glare_up_pixel(t, cw, x, u + 3 * (x - xa));
      glared_electrons_row(l + 3 * xa, u, skirt.keep, skirt.scale.data(), xa, xb - xa, me, mo, cx, dy2, pitch_over_f,
                           o + xa);
      physical = physical_row(l + 3 * xa, xb - xa) && physical;
    };
    rest(0, std::min(2, w));
    rest(std::max(2, 2 * j_end), w);
    return physical;
  }
  // How far ahead of the block the glared pairs' loops prefetch the radiance row (3 KB, 256
  // pixels): a frame's radiance comes from memory (the pyramid read it before), and the hardware
  // prefetcher stops at each 4 KiB page (docs/benchmarks.md: on the Intel Xeon 13.5 -> 9.7 ms for
  // the photon stage; on the AMD EPYC the AVX2 loop's, 2026-11-29, 3-6 %).
  static constexpr int kPrefetchFloats = 768;
  // glared_row_simd's blocks on AVX-512: pixel pairs j0 .. j0 + 7 (pixels 2·j0 .. 2·j0 + 15) for
  // j0 = 1, 9, 17, ... while j0 + 10 <= cw (the pairs are interior, j + 1 <= cw − 1 unclamped, and the
  // window of t read, 32 floats from 3·(j0 − 1), lies inside its 3·cw). The window of t is formed
  // from acc_1's two rows vt.a, vt.b as lerp_row forms it (glare_lerp: w0·a + w1·b in float, no
  // FMA), so the same t. Returns the first pair not done; physical is cleared if a pixel's
  // radiance is not physical.
  // (GCC 12's AVX-512 intrinsics trip -Wmaybe-uninitialized, GCC bug 105593: silenced here.)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
  template <bool Mean>
  __attribute__((target("avx512f")))
  static int glared_pairs_avx512(const float* l, const detail::GlareVerticalTaps& vt, int cw, float keep,
                                 const float* s3, const double* me, const double* mo, double cx, double dy2,
                                 double pitch_over_f, float* o, bool& physical, const MeanFusion* mf) {
    // The mean's operands (Mean): sense_mean_e's min(s·g + dark·df, cap), std::min(m, cap) =
    // cap < m ? cap : m = vminps(cap, m) (a NaN m passes, as there).
    const __m256 vdark = _mm256_set1_ps(Mean ? mf->dark : 0.f), vcap = _mm256_set1_ps(shader::kMeanElectronsCap);
    const PairIndex& ix = kPairIndex;
    const __m512 w0 = _mm512_load_ps(ix.w0), w1 = _mm512_load_ps(ix.w1), vkeep = _mm512_set1_ps(keep);
    const __m512 tw0 = _mm512_set1_ps(vt.w0), tw1 = _mm512_set1_ps(vt.w1);
    const __m512 sc[3] = {_mm512_set1_ps(s3[0]), _mm512_set1_ps(s3[1]), _mm512_set1_ps(s3[2])};
    const __m512d m[3] = {_mm512_setr_pd(me[0], mo[0], me[0], mo[0], me[0], mo[0], me[0], mo[0]),
                          _mm512_setr_pd(me[1], mo[1], me[1], mo[1], me[1], mo[1], me[1], mo[1]),
                          _mm512_setr_pd(me[2], mo[2], me[2], mo[2], me[2], mo[2], me[2], mo[2])};
    const __m512d vcx = _mm512_set1_pd(cx), vdy2 = _mm512_set1_pd(dy2), vp = _mm512_set1_pd(pitch_over_f),
                  one = _mm512_set1_pd(1.0);
    const bool falloff = pitch_over_f > 0.0;
    const __m512 zero = _mm512_setzero_ps(), fmax = _mm512_set1_ps(std::numeric_limits<float>::max());
    const __m512i sign = _mm512_set1_epi32(0x7fffffff);
    const __m256i lane8 = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
    __mmask16 ok = 0xffff;
    int j0 = 1;
    for (; j0 + 10 <= cw; j0 += 8) {
      const int x0 = 2 * j0;
      // the window of t: glare_lerp(w0, a[k], w1, b[k]) for its 32 floats
      const float *pa = vt.a + 3 * (j0 - 1), *pb = vt.b + 3 * (j0 - 1);
      const __m512 ta = _mm512_add_ps(_mm512_mul_ps(tw0, _mm512_loadu_ps(pa)), _mm512_mul_ps(tw1, _mm512_loadu_ps(pb)));
      const __m512 tb =
          _mm512_add_ps(_mm512_mul_ps(tw0, _mm512_loadu_ps(pa + 16)), _mm512_mul_ps(tw1, _mm512_loadu_ps(pb + 16)));
      const float* lw = l + 3 * x0;
      for (int k = 0; k < 48; k += 16) _mm_prefetch(reinterpret_cast<const char*>(lw + kPrefetchFloats + k), _MM_HINT_T0);
      const __m512 la = _mm512_loadu_ps(lw), lb = _mm512_loadu_ps(lw + 16), lc = _mm512_loadu_ps(lw + 32);
      __m512 g[3], L[3];
      for (int c = 0; c < 3; ++c) {
        // u: w0·X + w1·Y with X, Y the taps of each pixel (upsample_row's interior, interleaved)
        const __m512 X = _mm512_permutex2var_ps(ta, _mm512_load_si512(ix.x[c]), tb);
        const __m512 Y = _mm512_permutex2var_ps(ta, _mm512_load_si512(ix.y[c]), tb);
        const __m512 u = _mm512_add_ps(_mm512_mul_ps(w0, X), _mm512_mul_ps(w1, Y));
        // L: channel c of the 16 pixels, from the 48 interleaved floats
        L[c] = _mm512_permutex2var_ps(_mm512_permutex2var_ps(la, _mm512_load_si512(ix.la[c]), lb),
                                      _mm512_load_si512(ix.lb[c]), lc);
        g[c] = _mm512_add_ps(_mm512_mul_ps(vkeep, L[c]), _mm512_mul_ps(sc[c], u));  // glare_mix
      }
      const __m512 sum = _mm512_add_ps(_mm512_add_ps(L[0], L[1]), L[2]);
      ok &= _mm512_cmp_ps_mask(L[0], zero, _CMP_GE_OQ) & _mm512_cmp_ps_mask(L[1], zero, _CMP_GE_OQ) &
            _mm512_cmp_ps_mask(L[2], zero, _CMP_GE_OQ) &
            _mm512_cmp_ps_mask(_mm512_castsi512_ps(_mm512_and_si512(_mm512_castps_si512(sum), sign)), fmax,
                               _CMP_LE_OQ);
      __m512d gd[2][3];  // the 16 pixels' glared R, G, B in double, pixels 0-7 then 8-15
      for (int c = 0; c < 3; ++c) {
        gd[0][c] = _mm512_cvtps_pd(_mm512_castps512_ps256(g[c]));
        gd[1][c] = _mm512_cvtps_pd(_mm256_castpd_ps(_mm512_extractf64x4_pd(_mm512_castps_pd(g[c]), 1)));
      }
      for (int h = 0; h < 2; ++h) {  // photon_electrons on 8 pixels in double
        __m512d e = _mm512_add_pd(_mm512_add_pd(_mm512_mul_pd(m[0], gd[h][0]), _mm512_mul_pd(m[1], gd[h][1])),
                                  _mm512_mul_pd(m[2], gd[h][2]));
        if (falloff) {
          const __m512d dx =
              _mm512_sub_pd(_mm512_cvtepi32_pd(_mm256_add_epi32(_mm256_set1_epi32(x0 + 8 * h), lane8)), vcx);
          const __m512d t2 = _mm512_mul_pd(_mm512_mul_pd(_mm512_add_pd(_mm512_mul_pd(dx, dx), vdy2), vp), vp);
          const __m512d q = _mm512_add_pd(one, t2);
          e = _mm512_div_pd(e, _mm512_mul_pd(q, q));
        }
        const __m256 sig = _mm512_cvtpd_ps(e);
        _mm256_storeu_ps(o + x0 + 8 * h, sig);
        if constexpr (Mean) {
          const int x = x0 + 8 * h;
          const __m256 m = _mm256_add_ps(_mm256_mul_ps(sig, _mm256_loadu_ps(mf->g + x)),
                                         _mm256_mul_ps(vdark, _mm256_loadu_ps(mf->df + x)));
          _mm256_storeu_ps(mf->mean + x, _mm256_min_ps(vcap, m));
        }
      }
    }
    if (ok != 0xffff) physical = false;
    return j0;
  }
#pragma GCC diagnostic pop
  // glared_row_simd's blocks on AVX2: pixel pairs j0 .. j0 + 3 (pixels 2·j0 .. 2·j0 + 7) for
  // j0 = 1, 5, 9, ... while j0 + 8 <= cw (the pairs are interior, and the 24 floats of t read
  // from 3·(j0 − 1) lie inside its 3·cw). Pixel p of the block takes the taps X = t_c[j0 − 1 +
  // tap(p)], Y = t_c[j0 + tap(p)] with tap(p) = ⌊(p + 1)/2⌋ (even 2i: t_c[j0 − 1 + i], t_c[j0 +
  // i]; odd 2i + 1: t_c[j0 + i], t_c[j0 + 1 + i]), weights (¼, ¾) even, (¾, ¼) odd. The 24
  // interleaved floats of t from 3·(j0 − 1) (pairs j0 − 1 .. j0 + 6) and those of the radiance
  // are split by channel the same way: two blends put channel c of the 8 pairs or pixels in
  // distinct lanes of one vector (pair or pixel k at lane perm[c][k]), and one permute orders
  // them (L), or, for t, picks each pixel's taps at once: X's index perm[c][tap(p)], Y's
  // perm[c][tap(p) + 1]. The window of t is formed from acc_1's two rows vt.a, vt.b as
  // glared_pairs_avx512 forms it (glare_lerp: w0·a + w1·b in float, no FMA), so the same t. With
  // Mean, the sense stage's mean of the block's pixels as glared_pairs_avx512 forms it
  // (MeanFusion), 4 pixels at a time. The radiance is prefetched kPrefetchFloats ahead (two lines
  // cover a block's 96 bytes). Returns the first pair not done; physical is cleared if a pixel's
  // radiance is not physical.
  // Channel c of 8 interleaved RGB triples a, b, c (24 floats) into distinct lanes of v[c]:
  // element k's channel c at lane perm[c][k] of glared_pairs_avx2 (R: floats 3k from lanes 0, 3,
  // 6 of a, 1, 4, 7 of b, 2, 5 of c; G and B likewise, one lane further).
  __attribute__((target("avx2"), always_inline)) static inline void blend_channels_avx2(__m256 a, __m256 b, __m256 c,
                                                                                       __m256 v[3]) {
    v[0] = _mm256_blend_ps(_mm256_blend_ps(a, b, 0x92), c, 0x24);
    v[1] = _mm256_blend_ps(_mm256_blend_ps(a, b, 0x24), c, 0x49);
    v[2] = _mm256_blend_ps(_mm256_blend_ps(a, b, 0x49), c, 0x92);
  }
  template <bool Mean>
  __attribute__((target("avx2")))
  static int glared_pairs_avx2(const float* l, const detail::GlareVerticalTaps& vt, int cw, float keep,
                               const float* s3, const double* me, const double* mo, double cx, double dy2,
                               double pitch_over_f, float* o, bool& physical, const MeanFusion* mf) {
    int j0 = 1;
    if (j0 + 8 > cw) return j0;
    // The mean's operands (Mean), as in glared_pairs_avx512: min(s·g + dark·df, cap) = vminps(cap, m).
    const __m128 vdark = _mm_set1_ps(Mean ? mf->dark : 0.f), vcap = _mm_set1_ps(shader::kMeanElectronsCap);
    const __m256 tw0 = _mm256_set1_ps(vt.w0), tw1 = _mm256_set1_ps(vt.w1);
    const __m256i tap = _mm256_setr_epi32(0, 1, 1, 2, 2, 3, 3, 4), one_i = _mm256_set1_epi32(1);
    // pixel k of channel c at lane perm[c][k] after blend_channels_avx2
    const __m256i perm[3] = {_mm256_setr_epi32(0, 3, 6, 1, 4, 7, 2, 5), _mm256_setr_epi32(1, 4, 7, 2, 5, 0, 3, 6),
                             _mm256_setr_epi32(2, 5, 0, 3, 6, 1, 4, 7)};
    // the taps' lanes in the blended t: perm[c][tap(p)] and perm[c][tap(p) + 1]
    const __m256i xi[3] = {_mm256_permutevar8x32_epi32(perm[0], tap), _mm256_permutevar8x32_epi32(perm[1], tap),
                           _mm256_permutevar8x32_epi32(perm[2], tap)};
    const __m256i yi[3] = {_mm256_permutevar8x32_epi32(perm[0], _mm256_add_epi32(tap, one_i)),
                           _mm256_permutevar8x32_epi32(perm[1], _mm256_add_epi32(tap, one_i)),
                           _mm256_permutevar8x32_epi32(perm[2], _mm256_add_epi32(tap, one_i))};
    const __m256 w0 = _mm256_setr_ps(0.25f, 0.75f, 0.25f, 0.75f, 0.25f, 0.75f, 0.25f, 0.75f);
    const __m256 w1 = _mm256_setr_ps(0.75f, 0.25f, 0.75f, 0.25f, 0.75f, 0.25f, 0.75f, 0.25f);
    const __m256 vkeep = _mm256_set1_ps(keep), zero = _mm256_setzero_ps(),
                 fmax = _mm256_set1_ps(std::numeric_limits<float>::max()),
                 abs_mask = _mm256_castsi256_ps(_mm256_set1_epi32(0x7fffffff));
    const __m256 sc[3] = {_mm256_set1_ps(s3[0]), _mm256_set1_ps(s3[1]), _mm256_set1_ps(s3[2])};
    const __m256d m[3] = {_mm256_setr_pd(me[0], mo[0], me[0], mo[0]), _mm256_setr_pd(me[1], mo[1], me[1], mo[1]),
                          _mm256_setr_pd(me[2], mo[2], me[2], mo[2])};
    const __m256d vcx = _mm256_set1_pd(cx), vdy2 = _mm256_set1_pd(dy2), vp = _mm256_set1_pd(pitch_over_f),
                  one = _mm256_set1_pd(1.0);
    const __m128i lane4 = _mm_setr_epi32(0, 1, 2, 3);
    const bool falloff = pitch_over_f > 0.0;
    int ok = 0xff;
    for (; j0 + 8 <= cw; j0 += 4) {
      const int x0 = 2 * j0;
      const float* lw = l + 3 * x0;
      for (int k = 0; k < 24; k += 16) _mm_prefetch(reinterpret_cast<const char*>(lw + kPrefetchFloats + k), _MM_HINT_T0);
      const __m256 la = _mm256_loadu_ps(lw), lb = _mm256_loadu_ps(lw + 8), lc = _mm256_loadu_ps(lw + 16);
      __m256 L[3], T[3];
      blend_channels_avx2(la, lb, lc, L);
      for (int c = 0; c < 3; ++c) L[c] = _mm256_permutevar8x32_ps(L[c], perm[c]);
      // the window of t: glare_lerp(w0, a[k], w1, b[k]) for its 24 floats
      const float *pa = vt.a + 3 * (j0 - 1), *pb = vt.b + 3 * (j0 - 1);
      __m256 tv[3];
      for (int k = 0; k < 3; ++k)
        tv[k] = _mm256_add_ps(_mm256_mul_ps(tw0, _mm256_loadu_ps(pa + 8 * k)),
                              _mm256_mul_ps(tw1, _mm256_loadu_ps(pb + 8 * k)));
      blend_channels_avx2(tv[0], tv[1], tv[2], T);
      __m256 g[3];
      for (int c = 0; c < 3; ++c) {
        const __m256 X = _mm256_permutevar8x32_ps(T[c], xi[c]);
        const __m256 Y = _mm256_permutevar8x32_ps(T[c], yi[c]);
        const __m256 u = _mm256_add_ps(_mm256_mul_ps(w0, X), _mm256_mul_ps(w1, Y));
        g[c] = _mm256_add_ps(_mm256_mul_ps(vkeep, L[c]), _mm256_mul_ps(sc[c], u));  // glare_mix
      }
      const __m256 sum = _mm256_add_ps(_mm256_add_ps(L[0], L[1]), L[2]);
      ok &= _mm256_movemask_ps(_mm256_cmp_ps(L[0], zero, _CMP_GE_OQ)) &
            _mm256_movemask_ps(_mm256_cmp_ps(L[1], zero, _CMP_GE_OQ)) &
            _mm256_movemask_ps(_mm256_cmp_ps(L[2], zero, _CMP_GE_OQ)) &
            _mm256_movemask_ps(_mm256_cmp_ps(_mm256_and_ps(sum, abs_mask), fmax, _CMP_LE_OQ));
      for (int h = 0; h < 2; ++h) {  // photon_electrons on 4 pixels in double
        __m256d gd[3];
        for (int c = 0; c < 3; ++c)
          gd[c] = _mm256_cvtps_pd(h == 0 ? _mm256_castps256_ps128(g[c]) : _mm256_extractf128_ps(g[c], 1));
        __m256d e = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(m[0], gd[0]), _mm256_mul_pd(m[1], gd[1])),
                                  _mm256_mul_pd(m[2], gd[2]));
        if (falloff) {
          const __m256d dx = _mm256_sub_pd(_mm256_cvtepi32_pd(_mm_add_epi32(_mm_set1_epi32(x0 + 4 * h), lane4)), vcx);
          const __m256d t2 = _mm256_mul_pd(_mm256_mul_pd(_mm256_add_pd(_mm256_mul_pd(dx, dx), vdy2), vp), vp);
          const __m256d q = _mm256_add_pd(one, t2);
          e = _mm256_div_pd(e, _mm256_mul_pd(q, q));
        }
        const __m128 sig = _mm256_cvtpd_ps(e);
        _mm_storeu_ps(o + x0 + 4 * h, sig);
        if constexpr (Mean) {
          const int x = x0 + 4 * h;
          const __m128 m =
              _mm_add_ps(_mm_mul_ps(sig, _mm_loadu_ps(mf->g + x)), _mm_mul_ps(vdark, _mm_loadu_ps(mf->df + x)));
          _mm_storeu_ps(mf->mean + x, _mm_min_ps(vcap, m));
        }
      }
    }
    if (ok != 0xff) physical = false;
    return j0;
  }
  // glared_pairs_avx512's permutes and weights: pixel p of a block (pair i = p/2) takes
  // X = t[3(j0 − 1 + i) + c], Y = t[3(j0 + i) + c] when even and X = t[3(j0 + i) + c],
  // Y = t[3(j0 + 1 + i) + c] when odd (window offsets 3i + c or 3i + 3 + c, and 3i + 3 + c or
  // 3i + 6 + c), weights (¼, ¾) when even and (¾, ¼) when odd; channel c of pixel p of the
  // radiance is float 3p + c of the block's 48: first from the first 32 (la), then the rest from
  // the third vector (lb: lanes kept, or 16 + the float's index in it).
  struct PairIndex {
    alignas(64) int32_t x[3][16], y[3][16], la[3][16], lb[3][16];
    alignas(64) float w0[16], w1[16];
    PairIndex() {
      for (int c = 0; c < 3; ++c)
        for (int p = 0; p < 16; ++p) {
          const int i = p / 2, odd = p & 1;
          x[c][p] = 3 * i + c + 3 * odd;
          y[c][p] = 3 * i + 3 + c + 3 * odd;
          const int f = 3 * p + c;
          la[c][p] = f < 32 ? f : 0;
          lb[c][p] = f < 32 ? p : 16 + (f - 32);
        }
      for (int p = 0; p < 16; ++p) {
        w0[p] = p & 1 ? 0.75f : 0.25f;
        w1[p] = p & 1 ? 0.25f : 0.75f;
      }
    }
  };
  static const PairIndex kPairIndex;
  // Whether every pixel of the row is physical, as one reduction that vectorizes:
  // shader::radiance_is_physical's test (no channel negative or NaN, R+G+B finite) with
  // "finite" written |R+G+B| <= FLT_MAX, which is false for Inf and NaN alike.
  PHOTOSITE_TARGET_CLONES
  static bool physical_row(const float* __restrict r, int w) {
    int bad = 0;
    for (int x = 0; x < w; ++x) {
      const float R = r[3 * x], G = r[3 * x + 1], B = r[3 * x + 2];
      const float sum = R + G + B;
      bad |= !(R >= 0.0f) | !(G >= 0.0f) | !(B >= 0.0f) | !(std::fabs(sum) <= std::numeric_limits<float>::max());
    }
    return bad == 0;
  }
};
const PhotonStage::PairIndex PhotonStage::kPairIndex;
// The first damaged pixel in reading order over the rows' reports (bad_x[y] = -1: none).
void fail_first_bad(const ImageF& radiance, const std::vector<int>& bad_x) {
  for (int y = 0; y < static_cast<int>(bad_x.size()); ++y)
    if (bad_x[y] >= 0) detail::fail_bad_radiance(radiance, bad_x[y], y);
}
}  // namespace

void detail::photon_row_max_isa(int isa) { g_photon_isa_cap.store(std::clamp(isa, 0, 2)); }

ImageF mean_signal_electrons(const ImageF& radiance, const CameraPreset& p, const LensPreset& lens,
                             const ResolvedExposure& ex, const GlareLevel1* level1) {
  detail::check_radiance_shape(radiance);
  const PhotonStage st(radiance, p, lens, ex, level1);
  ImageF out(st.w, st.h, 1, uninitialized, unit::electrons);
  std::vector<int> bad_x(st.h, -1);
#pragma omp parallel
  {
    PhotonStage::Scratch sc(st);
#pragma omp for schedule(static)
    for (int y = 0; y < st.h; ++y) bad_x[y] = st.row(y, out.row(y), sc);
  }
  fail_first_bad(radiance, bad_x);
  return out;
}

namespace {
// Standard deviation of the Tukey-lambda distribution with unit scale (λ > -1/2).
double tukey_sd(double lambda) {
  if (std::fabs(lambda) < 1e-9) return units::pi / std::sqrt(3.0);
  const double v = 2.0 / (lambda * lambda) *
                   (1.0 / (1.0 + 2.0 * lambda) -
                    std::exp(2.0 * std::lgamma(lambda + 1.0) - std::lgamma(2.0 * lambda + 2.0)));
  return std::sqrt(v);
}
}  // namespace

namespace detail {
uint64_t temporal_key(uint64_t device_seed, uint64_t seed) {
  // Mix the run seed into the device seed (SplitMix64 step) so the key names both.
  uint64_t z = seed + 0x9e3779b97f4a7c15ull;
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  return device_seed ^ z ^ (z >> 31);
}

void check_radiance_shape(const ImageF& radiance) {
  if (radiance.channels() != 3)
    fail(fmt::format("scene radiance must have 3 channels (R, G, B), found {}", radiance.channels()));
  if (radiance.width() < 1 || radiance.height() < 1) fail("scene radiance image is empty");
}

void fail_bad_radiance(const ImageF& radiance, int x, int y) {
  const float* r = radiance.row(y) + 3 * x;
  // radiance_is_physical: each band finite and non-negative, and their sum finite in float (the
  // photon integral's sum): a pixel of finite bands can fail the last.
  const bool finite_bands = std::isfinite(r[0]) && std::isfinite(r[1]) && std::isfinite(r[2]) && r[0] >= 0 &&
                            r[1] >= 0 && r[2] >= 0;
  fail(fmt::format("radiance at pixel ({}, {}) is ({}, {}, {}): {}", x, y, r[0], r[1], r[2],
                   finite_bands ? "too large (R + G + B beyond float's range, 3.4e38)"
                                : "NaN, Inf and negative radiance are not physical"));
}

void check_sense_inputs(int w, int h, const CameraPreset& p, const FixedPatternMaps& fpn) {
  if (w < 1 || h < 1) fail("sensor input is empty");
  if ((!fpn.prnu_gain.empty() && !fpn.prnu_gain.same_shape(w, h)) ||
      (!fpn.dsnu_offset_e.empty() && !fpn.dsnu_offset_e.same_shape(w, h)) ||
      (!fpn.dark_rate_factor.empty() && !fpn.dark_rate_factor.same_shape(w, h)))
    fail(fmt::format("fixed-pattern maps of device '{}' are {}x{}, the frame is {}x{}",
                     fpn.device_id, fpn.width, fpn.height, w, h));
  if (!fpn.preset_name.empty() && fpn.preset_name != p.name)
    fail("fixed-pattern maps belong to preset '" + fpn.preset_name + "', not '" + p.name + "'");
}

void row_column_noise(const CameraPreset& p, uint64_t key, uint32_t frame, int w, int h,
                      std::vector<float>& row_e, std::vector<float>& col_e) {
  row_e.assign(p.row_noise_e > 0 ? h : 0, 0.f);
  col_e.assign(p.column_noise_e > 0 ? w : 0, 0.f);
  for (int y = 0; y < static_cast<int>(row_e.size()); ++y) {
    auto r = random_words(key, frame, y, Stream::RowNoise);
    row_e[y] = static_cast<float>(p.row_noise_e * normal_from_words(r[0], r[1]));
  }
  for (int x = 0; x < static_cast<int>(col_e.size()); ++x) {
    auto r = random_words(key, frame, x, Stream::ColumnNoise);
    col_e[x] = static_cast<float>(p.column_noise_e * normal_from_words(r[0], r[1]));
  }
}
}  // namespace detail

namespace {
// The sense stage of one frame, one row at a time (row): shot noise, dark current, fixed
// pattern, read / row / column noise, full well, gain, black level and the ADC; the mosaic above
// black for the demosaic in the same pass. sense() runs it over a mean-signal image, expose()
// over the photon stage's rows as they are made; a row's result depends on y alone.
struct SenseStage {
  const CameraPreset& p;
  const ExposureSettings& s;
  int w, h;
  uint64_t key;
  uint32_t frame;
  double dark_mean_e, K, full_well, max_code, black, read_e, tukey, tukey_norm;
  std::vector<float> row_e, col_e;
  const float* prnu;
  const float* dsnu;
  const float* darkf;
  // Absent maps and noise terms read from constant rows, so every inner loop is branch-free
  // and vectorizes; the stages themselves are skipped only in the sense that they add 0 / x1.
  std::vector<float> ones, zeros;

  SenseStage(int width, int height, const CameraPreset& preset, const ResolvedExposure& ex,
             const ExposureSettings& settings, const FixedPatternMaps& fpn)
      : p(preset), s(settings), w(width), h(height) {
    detail::check_sense_inputs(w, h, p, fpn);
    key = detail::temporal_key(fpn.device_seed, s.seed);
    frame = s.frame;
    dark_mean_e = ex.dark_current_e_per_s * ex.exposure_s;
    K = ex.system_gain_dn_per_e;
    full_well = p.full_well_e;
    max_code = std::ldexp(1.0, p.bit_depth) - 1.0;
    black = p.black_level_dn;
    read_e = p.read_noise_e;
    tukey = p.read_noise_tukey_lambda;
    tukey_norm = tukey != 0 ? 1.0 / tukey_sd(tukey) : 0.0;
    // Row and column temporal noise: one Gaussian per row / column per frame (skipped when zero).
    detail::row_column_noise(p, key, frame, w, h, row_e, col_e);
    prnu = fpn.prnu_gain.empty() ? nullptr : fpn.prnu_gain.data();
    dsnu = fpn.dsnu_offset_e.empty() ? nullptr : fpn.dsnu_offset_e.data();
    darkf = fpn.dark_rate_factor.empty() ? nullptr : fpn.dark_rate_factor.data();
    ones.assign(w, 1.f);
    zeros.assign(w, 0.f);
  }
  struct Scratch {
    std::vector<float> mean, read;
    explicit Scratch(int w) : mean(w), read(w) {}
  };
  // Row y: srow the mean signal (e-), into erow (electrons), drow (raw DN) and abrow (DN above
  // black, the demosaic's input).
  void row(int y, const float* srow, float* erow, float* drow, float* abrow, Scratch& sc) const {
    // Mean collected electrons, signal·PRNU + dark·(dark-rate factor) (sense_mean_e,
    // kernels/common/sensor_pixel.glsl, has the physics).
    mean_part(y, srow, 0, w, sc);
    row_from_mean(y, erow, drow, abrow, sc);
  }
  // Row y's PRNU and dark-rate factor maps (constant rows where absent).
  const float* prnu_row(int y) const { return prnu ? prnu + static_cast<size_t>(y) * w : ones.data(); }
  const float* dark_row(int y) const { return darkf ? darkf + static_cast<size_t>(y) * w : ones.data(); }
  float dark_e() const { return static_cast<float>(dark_mean_e); }
  // The mean of pixels [xa, xb) of row y from its mean signal srow, into sc.mean.
  void mean_part(int y, const float* srow, int xa, int xb, Scratch& sc) const {
    if (xa < xb)
      mean_row(srow + xa, prnu_row(y) + xa, dark_e(), dark_row(y) + xa, xb - xa, sc.mean.data() + xa);
  }
  // The rest of row y from the means in sc.mean.
  void row_from_mean(int y, float* erow, float* drow, float* abrow, Scratch& sc) const {
    const size_t row0 = static_cast<size_t>(y) * w;
    const float* off = dsnu ? dsnu + row0 : zeros.data();
    const float* col = col_e.empty() ? zeros.data() : col_e.data();
    float* mean = sc.mean.data();
    float* read = sc.read.data();
    // Shot noise and the read-noise normal from one Philox draw per pixel.
    poisson_block(mean, erow, read, w, row0, key, frame, static_cast<uint32_t>(Stream::PhotonShot), s.poisson);
    if (tukey != 0) {  // heavy-tailed read noise: the Tukey-λ quantile of u = Φ(z)
      for (int x = 0; x < w; ++x) {
        const double u = std::clamp(0.5 * std::erfc(-read[x] / std::sqrt(2.0)), 1e-300, 1.0 - 1e-16);
        read[x] = static_cast<float>((std::pow(u, tukey) - std::pow(1.0 - u, tukey)) / tukey * tukey_norm);
      }
    }
    analog_row(erow, off, read, col, row_e.empty() ? 0.f : row_e[y], static_cast<float>(read_e),
               static_cast<float>(full_well), K, black, max_code, w, drow, abrow);
  }
  // sense_mean_e over a row, with AVX-512 and AVX2 clones (two products and their sum per
  // pixel, no FMA: the same bits on every clone).
  PHOTOSITE_TARGET_CLONES
  static void mean_row(const float* __restrict srow, const float* __restrict g, float dark,
                       const float* __restrict df, int w, float* __restrict mean) {
    for (int x = 0; x < w; ++x) mean[x] = shader::sense_mean_e(srow[x], g[x], dark, df[x]);
  }
  // The full well, then the analog chain to DN: detail::analog_row (sensor/pixel_detail.h).
  static void analog_row(float* __restrict erow, const float* __restrict off, const float* __restrict read,
                         const float* __restrict col, float row_noise, float rn, float fw, double K, double black,
                         double max_code, int w, float* __restrict drow, float* __restrict abrow) {
    detail::analog_row(erow, off, read, col, row_noise, rn, fw, K, black, max_code, w, drow, abrow);
  }
};

// `img` as a w×h×c image of `unit`: its buffer kept where it has that shape already (a reused
// SensorOutput: no fresh pages to fault in), else a new one. Every sample is written after.
void reuse_or_make(ImageF& img, int w, int h, int c, const char* unit) {
  if (!img.same_shape(w, h) || img.channels() != c) img = ImageF(w, h, c, uninitialized, unit);
  img.set_unit(unit);
}

// Rows of the bands of the fused sense + demosaic loop (sense_frame): the band buffer holds
// kBandRows + 2 rows of the mosaic above black (2048 px: 272 KB, inside L2).
constexpr int kBandRows = 32;

// The sense stage over a frame, into out (electrons, raw DN, RGB): make_worker() gives each
// thread a row maker work(y, erow, drow, abrow, own) that writes row y's electrons, raw DN and
// mosaic above black (own: the row is this thread's to report on; the halo rows below are not).
//
// With the bilinear demosaic on a Bayer or RCCB mosaic (the default) the demosaic is fused into
// the row loop: the rows are split into one contiguous range per thread; each thread walks its
// range in order, keeping the mosaic above black of its last kBandRows + 2 rows in a band
// buffer, and demosaics row y as soon as row y+1 is made. So the whole-frame mosaic above black
// is never written (8 MB a 2048×1024 frame, with its page faults) and the demosaic reads its
// input from cache. The bilinear stencil reaches one row up and one down: the rows just outside
// a thread's range are made again into scratch (their outputs are the neighbour's to write).
// Each row's values depend on y alone, and the row demosaic is demosaic_bilinear's own row code
// (detail::demosaic_bilinear_row; on AVX-512 and AVX2 its interior in one pass with the
// interleave, the same operations per pixel), so the split, i.e. the thread count, changes no bit, and the
// result equals demosaic(mosaic above black) of the unfused path below (test
// SenseFused.EqualsTheUnfusedDefinition). Other methods and patterns: the whole frame first.
template <class MakeWorker>
void sense_frame(int w, int h, const CameraPreset& p, const ExposureSettings& s, SensorOutput& out,
                 const MakeWorker& make_worker) {
  reuse_or_make(out.electrons, w, h, 1, unit::electrons);
  reuse_or_make(out.raw_dn, w, h, 1, unit::dn);
  if (s.demosaic != DemosaicMethod::Bilinear || !detail::bilinear_row_path(w, h, p.cfa)) {
    ImageF above_black(w, h, 1, uninitialized, unit::dn);
#pragma omp parallel
    {
      auto work = make_worker();
#pragma omp for schedule(static)
      for (int y = 0; y < h; ++y) work(y, out.electrons.row(y), out.raw_dn.row(y), above_black.row(y), true);
    }
    out.rgb = demosaic(above_black, p.cfa, s.demosaic);
    out.rgb.set_unit(unit::dn);
    return;
  }
  reuse_or_make(out.rgb, w, h, 3, unit::dn);
#pragma omp parallel
  {
    const int nt = omp_get_num_threads(), t = omp_get_thread_num();
    const int ya = static_cast<int>(static_cast<int64_t>(h) * t / nt);
    const int yb = static_cast<int>(static_cast<int64_t>(h) * (t + 1) / nt);
    if (ya < yb) {
      auto work = make_worker();
      const size_t ws = static_cast<size_t>(w);
      std::vector<float> band((kBandRows + 2) * ws), planar(3 * ws), halo_e(ws), halo_d(ws);
      int first = std::max(0, ya - 1), filled = 0;  // band row i holds mosaic row first + i
      auto at = [&](int y) { return band.data() + static_cast<size_t>(y - first) * ws; };
      auto demosaic_row = [&](int y) {  // rows y-1 and y+1 mirrored at the edges (reflect-101; h >= 2)
        detail::demosaic_bilinear_row(p.cfa, at(y > 0 ? y - 1 : 1), at(y), at(y < h - 1 ? y + 1 : h - 2), y, w, h,
                                      out.rgb.row(y), planar.data());
      };
      for (int y = first; y <= std::min(h - 1, yb); ++y) {
        if (filled == kBandRows + 2) {  // keep the last two rows: row y-1's stencil needs them
          std::copy_n(band.data() + kBandRows * ws, 2 * ws, band.data());
          first += kBandRows;
          filled = 2;
        }
        const bool own = y >= ya && y < yb;
        work(y, own ? out.electrons.row(y) : halo_e.data(), own ? out.raw_dn.row(y) : halo_d.data(),
             band.data() + filled * ws, own);
        ++filled;
        if (y - 1 >= ya) demosaic_row(y - 1);
      }
      if (yb == h) demosaic_row(h - 1);
    }
  }
}
}  // namespace

double sensor_full_scale_dn(const CameraPreset& camera, const ResolvedExposure& exposure) {
  return std::min(std::ldexp(1.0, camera.bit_depth) - 1 - camera.black_level_dn,
                  camera.full_well_e * exposure.system_gain_dn_per_e);
}

ClipLevel clip_level(const CameraPreset& p, const ResolvedExposure& ex) {
  const double K = ex.system_gain_dn_per_e;
  const double top = std::ldexp(1.0, p.bit_depth) - 1.0;
  const double full_dn = p.full_well_e * K + p.black_level_dn;
  const double sigma_e = std::sqrt(p.read_noise_e * p.read_noise_e + p.dsnu_e * p.dsnu_e +
                                   p.row_noise_e * p.row_noise_e + p.column_noise_e * p.column_noise_e);
  return {std::min(top, full_dn - 4 * K * sigma_e - 0.5), sensor_full_scale_dn(p, ex) / 3};
}

size_t neutralize_clipped_highlights(SensorOutput& out, const CameraPreset& p, const ResolvedExposure& ex) {
  const ClipLevel c = clip_level(p, ex);
  return neutralize_clipped_highlights(out.rgb, out.raw_dn, p.cfa, static_cast<float>(c.clipped_at_dn),
                                       static_cast<float>(c.neutral_dn));
}

SensorOutput sense(const ImageF& mean_signal_e, const CameraPreset& p, const ResolvedExposure& ex,
                   const ExposureSettings& s, const FixedPatternMaps& fpn) {
  SensorOutput out;
  sense(mean_signal_e, p, ex, s, fpn, out);
  return out;
}

void sense(const ImageF& mean_signal_e, const CameraPreset& p, const ResolvedExposure& ex, const ExposureSettings& s,
           const FixedPatternMaps& fpn, SensorOutput& out) {
  const int w = mean_signal_e.width(), h = mean_signal_e.height();
  const SenseStage st(w, h, p, ex, s, fpn);
  sense_frame(w, h, p, s, out, [&] {
    return [&st, &mean_signal_e, sc = SenseStage::Scratch(st.w)](int y, float* e, float* d, float* ab, bool) mutable {
      st.row(y, mean_signal_e.row(y), e, d, ab, sc);
    };
  });
  neutralize_clipped_highlights(out, p, ex);
}

SensorOutput expose(const ImageF& radiance, const CameraPreset& p, const LensPreset& lens,
                    const ExposureSettings& s, const FixedPatternMaps& fpn, const GlareLevel1* level1) {
  SensorOutput out;
  expose(radiance, p, lens, s, fpn, out, level1);
  return out;
}

// The photon and sense stages fused row by row: the mean signal never goes to memory (each
// row is made and used by one thread). The same per-row functions as mean_signal_electrons()
// then sense(), so the same bits.
void expose(const ImageF& radiance, const CameraPreset& p, const LensPreset& lens, const ExposureSettings& s,
            const FixedPatternMaps& fpn, SensorOutput& out, const GlareLevel1* level1) {
  const ResolvedExposure ex = resolve(p, lens, s);
  detail::check_radiance_shape(radiance);
  const PhotonStage ph(radiance, p, lens, ex, level1);
  const int w = ph.w, h = ph.h;
  const SenseStage st(w, h, p, ex, s, fpn);
  std::vector<int> bad_x(h, -1);
  sense_frame(w, h, p, s, out, [&] {
    return [&ph, &st, &bad_x, psc = PhotonStage::Scratch(ph), ssc = SenseStage::Scratch(st.w),
            mean_e = std::vector<float>(st.w)](int y, float* e, float* d, float* ab, bool own) mutable {
      PhotonStage::MeanFusion mf{st.prnu_row(y), st.dark_row(y), st.dark_e(), ssc.mean.data()};
      const int bad = ph.row(y, mean_e.data(), psc, &mf);
      if (own) bad_x[y] = bad;
      // The photon row made the means of [xa, xb) (xa = xb = 0: none); the rest here.
      st.mean_part(y, mean_e.data(), 0, mf.xa, ssc);
      st.mean_part(y, mean_e.data(), mf.xb, st.w, ssc);
      st.row_from_mean(y, e, d, ab, ssc);
    };
  });
  fail_first_bad(radiance, bad_x);
  neutralize_clipped_highlights(out, p, ex);
}

SensorOutput flat_field(double photons, double wavelength_nm, int width, int height,
                        const CameraPreset& p, const LensPreset& lens, const ExposureSettings& s,
                        const FixedPatternMaps& fpn) {
  ImageF mean = detail::flat_field_mean(photons, wavelength_nm, width, height, p);  // checks its inputs
  const ResolvedExposure ex = resolve(p, lens, s);
  return sense(mean, p, ex, s, fpn);
}

void detail::check_flat_field_wavelength(double wavelength_nm, const CameraPreset& p) {
  if (!(wavelength_nm >= 200 && wavelength_nm <= 1200))
    fail_parameter("wavelength_nm", "", fmt::format(" {} nm is outside [200, 1200] nm", wavelength_nm));
  // The preset's QE is known on its table's grid only (QeTable::at answers 0 outside it): a flat
  // field there would be a dark frame labelled with photons.
  const auto& grid = p.qe.wavelength_nm;
  if (grid.empty() || wavelength_nm < grid.front() || wavelength_nm > grid.back())
    fail_parameter("wavelength_nm", "",
                   fmt::format(" {} nm is outside the QE table of {} ({:g} to {:g} nm)", wavelength_nm, p.name,
                               grid.empty() ? 0.0 : grid.front(), grid.empty() ? 0.0 : grid.back()));
}

ImageF detail::flat_field_mean(double photons, double wavelength_nm, int width, int height,
                               const CameraPreset& p) {
  if (!std::isfinite(photons) || photons < 0)
    fail_parameter("photons", "", fmt::format(" {} photons per pixel is impossible (a mean photon count is a finite number >= 0)", photons));
  check_flat_field_wavelength(wavelength_nm, p);
  if (width < 1 || height < 1 || static_cast<double>(width) * height > 4e8)
    fail(fmt::format("flat-field size {}x{} is impossible", width, height));
  // Photons falling on the pixel area; the fill factor and QE turn them into electrons
  // (EMVA 1288 defines QE over the whole pixel area, so its η = FF · QE here).
  float per_color[4];
  for (int c = 0; c < 4; ++c)
    per_color[c] = static_cast<float>(photons * p.fill_factor *
                                      p.qe.at(static_cast<FilterColor>(c), wavelength_nm));
  ImageF mean(width, height, 1, 0.f, unit::electrons);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) mean.at(x, y) = per_color[static_cast<int>(cfa_color(p.cfa, x, y))];
  return mean;
}

}  // namespace photosite
