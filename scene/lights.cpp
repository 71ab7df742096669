// The light map (stage 7): retroreflection of signs and lane markings under the ego beam, light
// sources found by colour in CIELAB (traffic signals, vehicle lamps), head/tail lamps placed per
// vehicle instance, lamp heads on poles, seeded window lights on buildings. Glare is the lens's, in the sensor's optics stage
// (sensor/glare.h), not here.
#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstring>
#include <exception>
#include <functional>
#include <immintrin.h>
#include <map>
#include <omp.h>
#include <optional>
#include <opencv2/imgproc.hpp>

#include "core/isa_detail.h"
#include "photosite/environment.h"
#include "photosite/error.h"
#include "photosite/rng.h"
#include "photosite/scene/luminaires.h"
#include "photosite/scene/night.h"
#include "photosite/scene/street.h"
#include "photosite/sensor/glare.h"
#include "photosite/sensor/isp.h"
#include "photosite/sensor/spectrum.h"
#include "scene/crown_phase_detail.h"
#include "scene/darken_detail.h"
#include "scene/sign_retro_detail.h"
#include "scene/night_detail.h"
#include "scene/street_detail.h"
#include "scene/texture_detail.h"
#include "scene/vehicle_facing_detail.h"

namespace photosite::scene {
namespace {
// set_vehicle_decision_sink's sink (scene/vehicle_facing_detail.h): null unless a test set it.
std::atomic<std::vector<VehicleDecision>*> g_vehicle_decisions{nullptr};
}  // namespace
std::vector<VehicleDecision>* set_vehicle_decision_sink(std::vector<VehicleDecision>* sink) {
  return g_vehicle_decisions.exchange(sink);
}

namespace {
using Rgb = std::array<double, 3>;

struct Lab { double L, a, b; };
// CIELAB (D65) of a linear sRGB colour (CIE 15:2004). f(t) = t^(1/3) comes from a table on
// [0, 1] (4096 steps, linear interpolation: |error| < 1e-4, far below the thresholds used).
double lab_f(double t) {
  static const std::vector<float> lut = [] {
    std::vector<float> v(4098);
    for (int i = 0; i <= 4097; ++i) {
      const double x = i / 4096.0;
      v[i] = static_cast<float>(x > 0.008856 ? std::cbrt(x) : 7.787 * x + 16.0 / 116);
    }
    return v;
  }();
  if (t >= 1.0) return std::cbrt(t);
  if (t <= 0.0) return 16.0 / 116;
  const double u = t * 4096.0;
  const int i = static_cast<int>(u);
  return lut[i] + (lut[i + 1] - lut[i]) * (u - i);
}
Lab to_lab(const float* s) {
  const double X = (0.4124 * s[0] + 0.3576 * s[1] + 0.1805 * s[2]) / 0.95047;
  const double Y = 0.2126 * s[0] + 0.7152 * s[1] + 0.0722 * s[2];
  const double Z = (0.0193 * s[0] + 0.1192 * s[1] + 0.9505 * s[2]) / 1.08883;
  const double fx = lab_f(X), fy = lab_f(Y), fz = lab_f(Z);
  return {116 * fy - 16, 500 * (fx - fy), 200 * (fy - fz)};
}

// A coloured source of a given luminance in the box basis: the chromaticity of a saturated
// signal colour (box radiance ratios) scaled so that Σ K_k c_k = luminance.
Rgb coloured(double r, double g, double b, double luminance) {
  const auto& K = spectrum::band_luminous_efficacy_lm_per_W();
  const double y = K[0] * r + K[1] * g + K[2] * b;
  return {r * luminance / y, g * luminance / y, b * luminance / y};
}
// A traffic signal's or rear lamp's LED of photometric luminance L: the run's camera's metamer of
// its spectrum per cd/m² (spectrum::kRedLed etc., set by the night chain: lamp_camera_rgb) times L
// (its box luminance Σ K_k c_k is then not L: docs/night.md §7), or where no camera set it (a scene
// made without one) the box guess: saturated box ratios scaled so that Σ K_k c_k = L.
Rgb led_lamp(const ScenePreset& p, spectrum::LampSpectrum s, double L) {
  if (const auto* w = lamp_camera_rgb(p, s)) return {(*w)[0] * L, (*w)[1] * L, (*w)[2] * L};
  switch (s) {
    case spectrum::LampSpectrum::AmberLed: return coloured(1.0, 0.45, 0.0, L);
    case spectrum::LampSpectrum::GreenLed: return coloured(0.0, 1.0, 0.6, L);  // blue-green
    default: return coloured(1.0, 0.03, 0.0, L);                               // red signal / rear lamp
  }
}
Rgb red_lamp(const ScenePreset& p, double L) { return led_lamp(p, spectrum::LampSpectrum::RedLed, L); }
Rgb blackbody(double cct, double L) { return spectrum::blackbody_rgb(cct, L); }

// Whether the eight ints from p are all zero.
inline bool all_zero8(const int32_t* p) {
  uint64_t w[4];
  std::memcpy(w, p, sizeof w);
  return !(w[0] | w[1] | w[2] | w[3]);
}
// p[0..96) = +0 by 24 16-byte stores (SSE2, the baseline). (std::fill_n of 96 floats here became
// `rep stosq`, whose start-up, paid 32 times a row in the retroreflection rows, cost more than the
// stores: +0.4 ms of CPU per light map at 1 thread, docs/benchmarks.md "Retroreflection rows".)
inline void zero_floats96(float* p) {
  const __m128 z = _mm_setzero_ps();
#pragma GCC unroll 24
  for (int i = 0; i < 24; ++i) _mm_storeu_ps(p + 4 * i, z);
}
void put_max(ImageF& img, int x, int y, const Rgb& c) {
  for (int k = 0; k < 3; ++k) img.at(x, y, k) = std::max(img.at(x, y, k), static_cast<float>(c[k]));
}
// put_max's on an image of width x height, recorded (pixel and float colour) and drawn later row
// by row: a maximum per channel, so the order of the draws on a pixel does not matter.
class MaxDraws {
 public:
  MaxDraws(int width, int height) : W(width), H(height) {}
  int width() const { return W; }
  int height() const { return H; }
  void add(int x, int y, const Rgb& c) {
    px_.push_back({x, y, {static_cast<float>(c[0]), static_cast<float>(c[1]), static_cast<float>(c[2])}});
  }
  // Sorts the draws by row; draw_row after it.
  void finish() {
    std::sort(px_.begin(), px_.end(), [](const Px& a, const Px& b) { return a.y < b.y; });
    start_.assign(H + 1, 0);
    for (const Px& p : px_) ++start_[p.y + 1];
    for (int y = 0; y < H; ++y) start_[y + 1] += start_[y];
  }
  // Row y's draws over img.
  void draw_row(ImageF& img, int y) const {
    float* r = img.row(y);
    for (size_t i = start_[y]; i < start_[y + 1]; ++i)
      for (int k = 0; k < 3; ++k) r[3 * px_[i].x + k] = std::max(r[3 * px_[i].x + k], px_[i].c[k]);
  }

 private:
  struct Px { int x, y; float c[3]; };
  int W, H;
  std::vector<Px> px_;
  std::vector<size_t> start_;
};
void put_max(MaxDraws& d, int x, int y, const Rgb& c) { d.add(x, y, c); }
// A filled disc of radiance, limited to pixels where `keep(x,y)`, on an image or recorded.
template <class Target, class Keep>
int disc(Target& img, double cx, double cy, double r, const Rgb& c, Keep keep) {
  int n = 0;
  const int x0 = std::max(0, static_cast<int>(std::floor(cx - r))),
            x1 = std::min(img.width() - 1, static_cast<int>(std::ceil(cx + r)));
  const int y0 = std::max(0, static_cast<int>(std::floor(cy - r))),
            y1 = std::min(img.height() - 1, static_cast<int>(std::ceil(cy + r)));
  for (int y = y0; y <= y1; ++y)
    for (int x = x0; x <= x1; ++x)
      if ((x - cx) * (x - cx) + (y - cy) * (y - cy) <= r * r && keep(x, y)) {
        put_max(img, x, y, c);
        ++n;
      }
  return n;
}
}  // namespace
std::array<double, 3> road_grey_gains(const ImageF& day, const ImageU16& labels) {
  const RoadSums r = road_samples(day, labels, [](const float*) { return true; });
  const double* sum = r.sum;
  const long n = r.n;
  if (n < 100 || !(sum[0] > 0) || !(sum[1] > 0) || !(sum[2] > 0)) return {1, 1, 1};
  const double mean = (sum[0] + sum[1] + sum[2]) / 3;
  return {mean / sum[0], mean / sum[1], mean / sum[2]};
}
bool rear_lens_colour(const float* rgb, const std::array<double, 3>& gain) {
  const float s[3] = {static_cast<float>(rgb[0] * gain[0]), static_cast<float>(rgb[1] * gain[1]),
                      static_cast<float>(rgb[2] * gain[2])};
  // Necessary conditions first: L* > 25 needs Y > 0.04 (L*(0.04) = 23.7), a* > 20 needs X > Y.
  const double Xn = (0.4124 * s[0] + 0.3576 * s[1] + 0.1805 * s[2]) / 0.95047;
  const double Yn = 0.2126 * s[0] + 0.7152 * s[1] + 0.0722 * s[2];
  if (!(Yn > 0.04) || !(Xn > Yn)) return false;
  const Lab l = to_lab(s);
  if (!(l.L > 25 && l.a > 20)) return false;
  const double hue = std::atan2(l.b, l.a) * 180 / M_PI;
  return hue > -20 && hue < 40;
}
// A median, not a kerb: an off-carriageway strip at most kMedianMax_m wide with road beyond it
// (urban central reservations are 1-10 m: photosite choice); the walk beside a vehicle looks
// that far and a little more.
constexpr double kMedianMax_m = 10, kMedianProbe_m = 14;
// A vehicle whose outer side has an off-carriageway label within this of it at its own contact
// depth stands at the kerb: parked cars stand 0.2-0.5 m off the kerb [U] (the upper end; moving
// ones keep about 1 m, vehicle_lamps.kerb_strip_m, which the measured carriageway's edges use).
constexpr double kKerbContact_m = 0.5;
bool shows_rear(int red_px, int lens_px, int pixels) {
  auto share = [&](int px) { return px >= 3 && px * 500 >= pixels && px * 5 <= pixels; };
  return share(red_px) || share(lens_px);
}

BesideProbe probe_beside(const ImageU16& labels, const CameraGeometry& g, int x, int y, int dir, double max_m) {
  BesideProbe r;
  const int W = labels.width();
  if (y < 0 || y >= labels.height()) return r;
  // Along one row of the flat ground X = z·(u − c_x)/f at one camera z, so each pixel is z/f metres
  // wide: the walk's k-th pixel spans k·z/f .. (k + 1)·z/f from the vehicle's side.
  double z;
  if (!g.ground_point(x, y + 0.5, nullptr, nullptr, &z)) return r;
  const double px_m = z / g.f_px;
  double strip_from = 0;
  bool in_strip = false;
  for (int k = 0; x >= 0 && x < W; x += dir, ++k) {
    const double at_m = k * px_m, far_m = (k + 1) * px_m;  // the pixel's near and far edges
    const int id = labels.at(x, y);
    const Label l = static_cast<Label>(id);
    if (is_not_scene(id) || l == Label::Sky) break;
    const bool road = l == Label::Road;
    const bool standing = is_vehicle(id) || l == Label::Person || l == Label::Rider || l == Label::Pole ||
                          l == Label::PoleGroup || l == Label::TrafficSign || l == Label::TrafficLight ||
                          l == Label::Static || l == Label::Dynamic || l == Label::Unlabeled;
    if (!road && !standing) {
      if (!in_strip) {
        r.road_m = at_m;
        strip_from = at_m;
        in_strip = true;
      }
      r.strip_m = far_m - strip_from;
    } else if (road && in_strip) {
      r.road_beyond = true;
      break;
    }
    if (far_m > max_m) break;
  }
  return r;
}

namespace {
// low_beam_intensity_cd with tan(cutoff_rise_deg) computed once by the caller.
double beam_intensity_cd(double h_deg, double v_deg, double tan_rise, const ScenePreset& p) {
  // The cut-off: horizontal at cutoff_v_deg left of the v-v line, rising at cutoff_rise_deg to
  // the right up to cutoff_max_v_deg (ECE R112 class B, right-hand traffic); nothing above it.
  const double cut = std::min(p.beam_cutoff_max_v_deg, p.beam_cutoff_v_deg + std::max(0.0, h_deg) * tan_rise);
  if (v_deg > cut) return 0;
  const auto& H = p.beam_h_deg;
  const auto& V = p.beam_v_deg;
  const size_t nh = H.size(), nv = V.size();
  if (nh < 2 || nv < 2 || h_deg < H.front() || h_deg > H.back() || v_deg < V.front() || v_deg > V.back()) return 0;
  // Bilinear between the grid points (an approximation of the lamp's smooth distribution).
  const size_t j = std::min<size_t>(nh - 2, std::upper_bound(H.begin(), H.end(), h_deg) - H.begin() - 1);
  const size_t i = std::min<size_t>(nv - 2, std::upper_bound(V.begin(), V.end(), v_deg) - V.begin() - 1);
  const double a = (h_deg - H[j]) / (H[j + 1] - H[j]), b = (v_deg - V[i]) / (V[i + 1] - V[i]);
  const double* r0 = p.beam_intensity_cd.data() + i * nh;
  const double* r1 = r0 + nh;
  return (1 - b) * ((1 - a) * r0[j] + a * r0[j + 1]) + b * ((1 - a) * r1[j] + a * r1[j + 1]);
}

// atan(x) for finite x, Cephes' atan (S. L. Moshier, Cephes Math Library 2.8, atan.c): reduction
// to |r| <= 0.66 by atan(x) = π/4 + atan((x − 1)/(x + 1)) for 0.66 < x <= tan(3π/8) and
// π/2 − atan(1/x) above, then Cephes' (4,5) rational minimax in r². Peak relative error 1.8e-16
// (Cephes' test over ±10); against glibc's atan2(dx, D) for D > 0 measured at most 2.4e-16 (2·10⁷
// random arguments, dx/D over 2^±8): one or two ulp, a rounding difference. Branch-free (selects),
// so that the low beam's rows vectorize; IEEE +, −, ×, ÷ only, so the result is the same on every
// instruction set (no FMA contraction: -ffp-contract=off).
[[gnu::always_inline]] inline double atan_cephes(double x) {
  const double ax = std::fabs(x);
  const bool big = ax > 2.41421356237309504880, mid = ax > 0.66;
  const double num = big ? -1.0 : (mid ? ax - 1.0 : ax);
  const double den = big ? ax : (mid ? ax + 1.0 : 1.0);
  const double y0 = big ? 1.57079632679489661923 : (mid ? 0.78539816339744830962 : 0.0);
  // Cephes' MOREBITS: the part of π/2 (and half of it for π/4) below the double's last bit.
  const double more = big ? 6.123233995736765886130E-17 : (mid ? 0.5 * 6.123233995736765886130E-17 : 0.0);
  const double r = num / den, z = r * r;
  const double P = (((-8.750608600031904122785E-1 * z - 1.615753718733365076637E1) * z - 7.500855792314704667340E1) * z -
                    1.228866684490136173410E2) * z - 6.485021904942025371773E1;
  const double Q = ((((z + 2.485846490142306297962E1) * z + 1.650270098316988542046E2) * z + 4.328810604912902668951E2) * z +
                    4.853903996359136964868E2) * z + 1.945506571482613964425E2;
  const double a = y0 + ((r * (z * P / Q) + r) + more);
  return x < 0 ? -a : a;
}

// The geometry of one lamp and ground point (X, D), D > 0: the angles of the ground point seen
// from the lamp, h = atan(dx/D) (= atan2(dx, D) for D > 0) and v = −atan(h_l/√(dx² + D²)) in
// degrees, cos θ = h_l/d and d²: low_beam_lux's geometry (the image evaluates it in float below).
struct BeamRay { double h_deg, v_deg, cos_theta, d2; };
[[gnu::always_inline]] inline BeamRay beam_ray(double dx, double D2, double D_m, double hl, double hl2) {
  const double horiz2 = dx * dx + D2, horiz = std::sqrt(horiz2);
  const double d2 = horiz2 + hl2, d = std::sqrt(d2);
  return {atan_cephes(dx / D_m) * (180 / M_PI), -atan_cephes(hl / horiz) * (180 / M_PI), hl / d, d2};
}

double beam_lux(double X_m, double D_m, double tan_rise, const ScenePreset& p) {
  if (!(D_m > 0)) return 0;
  const double hl = p.beam_lamp_height_m;
  double E = 0;
  for (const double xl : {-0.5 * p.beam_lamp_spacing_m, 0.5 * p.beam_lamp_spacing_m}) {
    const BeamRay r = beam_ray(X_m - xl, D_m * D_m, D_m, hl, hl * hl);
    E += beam_intensity_cd(r.h_deg, r.v_deg, tan_rise, p) * r.cos_theta / r.d2;
  }
  return E;
}

// ---- The image: float, 8 lanes --------------------------------------------------------------
// The image (low_beam_illuminance) evaluates the same E = Σ_lamps I(h, v)·cos θ/d² in float
// (IEEE binary32), 8 pixels per AVX2 vector, and is bit-equal to low_beam_lux_f32 at the pixel's
// ground point (the scalar twin below: the same operations in the same order; no FMA
// contraction, -ffp-contract=off). Against the double reference low_beam_lux the relative error
// is a few 2⁻²⁴ plus the table's slope times the angles' float error; pixels within that angular
// error of the cut-off line or the table's edge may flip between lit and 0
// (tests/scene_metric_test.cpp derives and checks both).

// atan(x) for finite x in float: Cephes' atanf (S. L. Moshier, Cephes Math Library 2.8,
// atanf.c): reduction to |r| <= tan(π/8) by atan(x) = π/4 + atan((x − 1)/(x + 1)) for
// tan(π/8) < |x| <= tan(3π/8) and π/2 + atan(−1/x) above, then Cephes' degree-4 polynomial in
// z = r². Cephes' stated peak relative error 1.9e-7 (IEEE, ±10, 10⁵ points) ≈ 3.2·2⁻²⁴.
// Branch-free (selects); IEEE +, −, ×, ÷ only, so the scalar and the AVX2 lanes give the same bits.
[[gnu::always_inline]] inline float atanf_cephes(float x) {
  const float ax = std::fabs(x);
  const bool big = ax > 2.414213562373095f, mid = ax > 0.4142135623730950f;
  const float num = big ? -1.f : (mid ? ax - 1.f : ax);
  const float den = big ? ax : (mid ? ax + 1.f : 1.f);
  const float y0 = big ? 1.5707963267948966192f : (mid ? 0.7853981633974483096f : 0.f);
  const float r = num / den, z = r * r;
  const float P = ((8.05374449538e-2f * z - 1.38776856032e-1f) * z + 1.99777106478e-1f) * z - 3.33329491539e-1f;
  const float a = y0 + (P * z * r + r);  // >= 0
  return std::copysign(a, x);
}

// The preset's beam in float: the lamps, the cut-off, the grid with the reciprocal cell widths
// (one multiplication per bilinear weight instead of a division) and the intensities.
struct BeamF {
  bool ok = false;
  float hl = 0, hl2 = 0, xl[2] = {0, 0}, cv = 0, cmax = 0, rise = 0, deg = 0;
  int nh = 0, nv = 0;
  std::vector<float> H, V, rH, rV, I;
  // Grids of at most 8 angles also as one vector each (zero-padded), read by a lane permutation
  // instead of a gather (the same values).
  bool small = false;
  float H8[8] = {}, V8[8] = {}, rH8[8] = {}, rV8[8] = {};
  // With small grids the table itself (at most 64 values) zero-padded to 64, read by two
  // two-register lane permutations and a blend instead of a gather (the same values; a 16-lane
  // gather is slow on AMD Zen 4).
  alignas(64) float I64[64] = {};
  // Both grids non-decreasing in float (the preset's are strictly increasing): then an angle's
  // count of grid angles m = 1 .. n − 2 at or below it is j exactly when lo[j] <= angle < hi[j],
  // with lo[j] = H[j] (−∞ for j = 0) and hi[j] = H[j + 1] (+∞ for j = n − 2).
  bool sorted = false;
  std::vector<float> Hlo, Hhi, Vlo, Vhi;
  // For vertical surfaces (beam_vertical_lamp_f): the glare zone's intensity above the cut-off,
  // the tangents of the table's horizontal edges and of the cut-off's top, and the least d²
  // (five lens diameters, squared).
  float above = 0, th0 = 0, th1 = 0, tvmax = 0, tvmax2 = 0, d2_min = 0;
};
BeamF beam_f(const ScenePreset& p) {
  BeamF b;
  b.nh = static_cast<int>(p.beam_h_deg.size());
  b.nv = static_cast<int>(p.beam_v_deg.size());
  b.ok = b.nh >= 2 && b.nv >= 2 && p.beam_intensity_cd.size() == p.beam_h_deg.size() * p.beam_v_deg.size();
  if (!b.ok) return b;
  b.hl = static_cast<float>(p.beam_lamp_height_m);
  b.hl2 = b.hl * b.hl;
  b.xl[0] = static_cast<float>(-0.5 * p.beam_lamp_spacing_m);
  b.xl[1] = static_cast<float>(0.5 * p.beam_lamp_spacing_m);
  b.cv = static_cast<float>(p.beam_cutoff_v_deg);
  b.cmax = static_cast<float>(p.beam_cutoff_max_v_deg);
  b.rise = static_cast<float>(std::tan(p.beam_cutoff_rise_deg * M_PI / 180));
  b.deg = static_cast<float>(180 / M_PI);
  for (double h : p.beam_h_deg) b.H.push_back(static_cast<float>(h));
  for (double v : p.beam_v_deg) b.V.push_back(static_cast<float>(v));
  for (int j = 0; j + 1 < b.nh; ++j) b.rH.push_back(1.f / (b.H[j + 1] - b.H[j]));
  for (int i = 0; i + 1 < b.nv; ++i) b.rV.push_back(1.f / (b.V[i + 1] - b.V[i]));
  for (double c : p.beam_intensity_cd) b.I.push_back(static_cast<float>(c));
  b.sorted = std::is_sorted(b.H.begin(), b.H.end()) && std::is_sorted(b.V.begin(), b.V.end());
  b.above = static_cast<float>(p.beam_above_cutoff_cd);
  b.th0 = static_cast<float>(std::tan(p.beam_h_deg.front() * M_PI / 180));
  b.th1 = static_cast<float>(std::tan(p.beam_h_deg.back() * M_PI / 180));
  b.tvmax = static_cast<float>(std::tan(p.beam_cutoff_max_v_deg * M_PI / 180));
  b.tvmax2 = b.tvmax * b.tvmax;
  b.d2_min = static_cast<float>(25 * p.beam_lens_diameter_m * p.beam_lens_diameter_m);
  auto bounds = [](const std::vector<float>& g, std::vector<float>& lo, std::vector<float>& hi) {
    const int cells = static_cast<int>(g.size()) - 1;
    for (int j = 0; j < cells; ++j) {
      lo.push_back(j == 0 ? -INFINITY : g[j]);
      hi.push_back(j == cells - 1 ? INFINITY : g[j + 1]);
    }
  };
  bounds(b.H, b.Hlo, b.Hhi);
  bounds(b.V, b.Vlo, b.Vhi);
  b.small = b.nh <= 8 && b.nv <= 8;
  if (b.small) {
    std::copy(b.H.begin(), b.H.end(), b.H8), std::copy(b.rH.begin(), b.rH.end(), b.rH8);
    std::copy(b.V.begin(), b.V.end(), b.V8), std::copy(b.rV.begin(), b.rV.end(), b.rV8);
    std::copy(b.I.begin(), b.I.end(), b.I64);
  }
  return b;
}

// The table's bilinear intensity at angles (h, v) inside its grid, in float: the cell by counting
// the grid angles at or below the angle (upper_bound − 1 clamped to the last cell).
[[gnu::always_inline]] inline float beam_table_f(float h, float v, const BeamF& b) {
  int j = 0, i = 0;
  for (int m = 1; m + 1 < b.nh; ++m) j += b.H[m] <= h;
  for (int m = 1; m + 1 < b.nv; ++m) i += b.V[m] <= v;
  const float a = (h - b.H[j]) * b.rH[j], c = (v - b.V[i]) * b.rV[i];
  const float* r0 = b.I.data() + i * b.nh + j;
  const float* r1 = r0 + b.nh;
  const float ia = 1.f - a, ic = 1.f - c;
  return ic * (ia * r0[0] + a * r0[1]) + c * (ia * r1[0] + a * r1[1]);
}
// One lamp's I·cos θ/d² at the ground point dx = X − x_l right of it, D ahead (D2 = D², invD =
// 1/D in float): h = atan(dx/D), v = −atan(h_l/√(dx² + D²)) in degrees, the cut-off and the
// table as beam_intensity_cd (the cell index by counting the grid angles at or below the angle,
// upper_bound − 1 clamped to the last cell), cos θ/d² = h_l/(d²·d).
[[gnu::always_inline]] inline float beam_lamp_f(float dx, float D2, float invD, const BeamF& b) {
  const float horiz2 = dx * dx + D2, horiz = std::sqrt(horiz2);
  const float d2 = horiz2 + b.hl2, d = std::sqrt(d2);
  const float h = atanf_cephes(dx * invD) * b.deg, v = -(atanf_cephes(b.hl / horiz) * b.deg);
  const float cut = std::min(b.cv + std::max(h, 0.f) * b.rise, b.cmax);
  if (!(v <= cut && h >= b.H[0] && h <= b.H[b.nh - 1] && v >= b.V[0] && v <= b.V[b.nv - 1])) return 0.f;
  return beam_table_f(h, v, b) * (b.hl / (d2 * d));
}
[[gnu::always_inline]] inline float beam_lux_f(float X, float D2, float invD, const BeamF& b) {
  float E = 0.f;
  for (int k = 0; k < 2; ++k) E += beam_lamp_f(X - b.xl[k], D2, invD, b);
  return E;
}

// Cephes atanf's polynomial of the reduced argument r (z = r²): P(z)·z·r + r, on 8 lanes (its
// operations in atanf_cephes' order).
__attribute__((target("avx2"))) inline __m256 atan_poly8(__m256 r) {
  const __m256 z = _mm256_mul_ps(r, r);
  __m256 P = _mm256_sub_ps(_mm256_mul_ps(_mm256_set1_ps(8.05374449538e-2f), z), _mm256_set1_ps(1.38776856032e-1f));
  P = _mm256_add_ps(_mm256_mul_ps(P, z), _mm256_set1_ps(1.99777106478e-1f));
  P = _mm256_sub_ps(_mm256_mul_ps(P, z), _mm256_set1_ps(3.33329491539e-1f));
  return _mm256_add_ps(_mm256_mul_ps(_mm256_mul_ps(P, z), r), r);
}
// atanf_cephes on 8 lanes: the same operations (selects by blends, the sign put back by OR: a >= 0).
__attribute__((target("avx2"))) inline __m256 atanf_cephes8(__m256 x) {
  const __m256 sign = _mm256_set1_ps(-0.f), one = _mm256_set1_ps(1.f);
  const __m256 ax = _mm256_andnot_ps(sign, x);
  const __m256 mid = _mm256_cmp_ps(ax, _mm256_set1_ps(0.4142135623730950f), _CMP_GT_OQ);
  if (_mm256_movemask_ps(mid) == 0) {
    // No lane reduced (the common case for both angles): r = ax/1 = ax and y0 = 0 exactly, the
    // scalar's operations without the division by 1 and without the addition of y0 = +0: t =
    // P·z·ax + ax is +0 for ax = +0 and positive otherwise (|P·z| < 1 for ax <= tan(π/8)), a NaN
    // stays that NaN, so +0 + t = t.
    return _mm256_or_ps(atan_poly8(ax), _mm256_and_ps(x, sign));
  }
  const __m256 big = _mm256_cmp_ps(ax, _mm256_set1_ps(2.414213562373095f), _CMP_GT_OQ);
  const __m256 num = _mm256_blendv_ps(_mm256_blendv_ps(ax, _mm256_sub_ps(ax, one), mid), _mm256_set1_ps(-1.f), big);
  const __m256 den = _mm256_blendv_ps(_mm256_blendv_ps(one, _mm256_add_ps(ax, one), mid), ax, big);
  const __m256 y0 = _mm256_blendv_ps(_mm256_and_ps(mid, _mm256_set1_ps(0.7853981633974483096f)),
                                     _mm256_set1_ps(1.5707963267948966192f), big);
  const __m256 a = _mm256_add_ps(y0, atan_poly8(_mm256_div_ps(num, den)));
  return _mm256_or_ps(a, _mm256_and_ps(x, sign));
}
// atanf_cephes8 of four vectors (both lamps' h and v arguments) at once: where no lane of any of
// them is reduced (the common case) their four polynomials as one straight run of independent
// operations, which the core overlaps (one at a time, each waited on its own chain of dependent
// multiplications); otherwise atanf_cephes8 of each. The same operations on every lane.
__attribute__((target("avx2"))) inline void atanf_cephes8x4(const __m256 (&x)[4], __m256 (&out)[4]) {
  const __m256 sign = _mm256_set1_ps(-0.f), lim = _mm256_set1_ps(0.4142135623730950f);
  __m256 ax[4], mid = _mm256_setzero_ps();
  for (int q = 0; q < 4; ++q) {
    ax[q] = _mm256_andnot_ps(sign, x[q]);
    mid = _mm256_or_ps(mid, _mm256_cmp_ps(ax[q], lim, _CMP_GT_OQ));
  }
  if (_mm256_movemask_ps(mid) != 0) {
    for (int q = 0; q < 4; ++q) out[q] = atanf_cephes8(x[q]);
    return;
  }
  // atanf_cephes8's unreduced path, four times over.
  for (int q = 0; q < 4; ++q) out[q] = _mm256_or_ps(atan_poly8(ax[q]), _mm256_and_ps(x[q], sign));
}

// A table cell's numbers as vectors (every lane the same): its bounds (BeamF::sorted), grid
// angles with their reciprocal widths, and the four intensities at its corners.
struct BeamCell { __m256 lo_h, hi_h, lo_v, hi_v, Hj, rHj, Vi, rVi, r00, r01, r10, r11; };
[[gnu::always_inline]] __attribute__((target("avx2"))) inline void beam_cell(BeamCell& c, const BeamF& b, int j, int i) {
  const float* r0 = b.I.data() + i * b.nh + j;
  c.lo_h = _mm256_set1_ps(b.Hlo[j]), c.hi_h = _mm256_set1_ps(b.Hhi[j]);
  c.lo_v = _mm256_set1_ps(b.Vlo[i]), c.hi_v = _mm256_set1_ps(b.Vhi[i]);
  c.Hj = _mm256_set1_ps(b.H[j]), c.rHj = _mm256_set1_ps(b.rH[j]);
  c.Vi = _mm256_set1_ps(b.V[i]), c.rVi = _mm256_set1_ps(b.rV[i]);
  c.r00 = _mm256_set1_ps(r0[0]), c.r01 = _mm256_set1_ps(r0[1]);
  c.r10 = _mm256_set1_ps(r0[b.nh]), c.r11 = _mm256_set1_ps(r0[b.nh + 1]);
}
// The lanes whose (h, v) lie in cell c (lo <= angle < hi on both axes, BeamF::sorted's bounds).
[[gnu::always_inline]] __attribute__((target("avx2"))) inline __m256 in_beam_cell(const BeamCell& c, __m256 h, __m256 v) {
  const __m256 in_h = _mm256_and_ps(_mm256_cmp_ps(c.lo_h, h, _CMP_LE_OQ), _mm256_cmp_ps(h, c.hi_h, _CMP_LT_OQ));
  const __m256 in_v = _mm256_and_ps(_mm256_cmp_ps(c.lo_v, v, _CMP_LE_OQ), _mm256_cmp_ps(v, c.hi_v, _CMP_LT_OQ));
  return _mm256_and_ps(in_h, in_v);
}
// The table's bilinear intensity at (h, v) in a cell: grid angles Hj, Vi, reciprocal widths rHj,
// rVi, corner intensities r00 .. r11 (beam_lux_f's operations, lane by lane).
[[gnu::always_inline]] __attribute__((target("avx2"))) inline __m256 beam_bilinear8(__m256 h, __m256 v, __m256 Hj, __m256 rHj,
                                                                                 __m256 Vi, __m256 rVi, __m256 r00, __m256 r01,
                                                                                 __m256 r10, __m256 r11) {
  const __m256 one = _mm256_set1_ps(1.f);
  const __m256 a = _mm256_mul_ps(_mm256_sub_ps(h, Hj), rHj), c = _mm256_mul_ps(_mm256_sub_ps(v, Vi), rVi);
  const __m256 ia = _mm256_sub_ps(one, a), ic = _mm256_sub_ps(one, c);
  const __m256 top = _mm256_add_ps(_mm256_mul_ps(ia, r00), _mm256_mul_ps(a, r01));
  const __m256 bot = _mm256_add_ps(_mm256_mul_ps(ia, r10), _mm256_mul_ps(a, r11));
  return _mm256_add_ps(_mm256_mul_ps(ic, top), _mm256_mul_ps(c, bot));
}
// The columns [lo, hi) of a row (xn increasing: the caller's promise) where every lane is surely
// lit by each lamp evaluated (`only` as beam_row_avx2's), with v's arctangent argument at most
// tan(π/8), so that beam_row_avx2 may skip the lit test (five comparisons, the cut-off's max, ×, +
// and min per lamp) and v's reduction test there: the same bits. Empty where not derived (t <= 0,
// h_l <= 0, a table without 0 inside its h range, V₀ >= 0 or V_last < 0).
// Conditions, for a lane's float dx = fl(fl(t·x_n) − x_l) (computed here exactly as the lanes do;
// with xn increasing and t > 0 it is non-decreasing along the row, so each condition
// |dx| <= dx_max holds on one run of columns, found by bisection), D = √D2 in double, u = 2⁻²⁴,
// Cephes' atanf rel. ≤ 4u (its stated 1.9e-7), atan concave on [0, ∞) (atan(λy) <= λ·atan(y) for
// λ >= 1, >= for λ <= 1):
//   the h argument fl(dx·fl(1/D_f)) is |dx|/D·(1 ± 3u), h = fl(fl(atanf)·fl(180/π)) within (1 ± 6u):
//     |dx| <= D·tan(H_m·(1 − m)), H_m = min(−H₀, H_last): |h| <= H_m·(1 − m)(1 + 9u) < H_m: inside the table;
//   the v argument fl(h_l/horiz), horiz = fl(√fl(fl(dx²) + D2)) >= fl(√D2) (rounding is monotone and
//     fl(dx²) >= 0): the argument is positive and <= h_l/D·(1 + 3u), so with h_l/D <= λ(1 − m) unreduced
//     (λ = fl(tan(π/8)), atanf_cephes' threshold),
//     and |v| <= atan(h_l/D)·(180/π)(1 + 9u) <= |V₀| where atan(h_l/D)·180/π <= |V₀|(1 − m): v >= V₀;
//     v = −(nonnegative) <= −0 <= V_last when V_last >= 0;
//   the cut-off fl(min(fl(c_v + fl(max(h, 0)·tan rise)), c_max)) >= min(c_v, c_max) =: c (c_v + a
//     nonnegative number rounds to at least c_v); where c < 0 and dx² + D2 <= H_c², H_c = h_l/tan(|c|(1 + m)):
//     horiz <= √(dx² + D2)(1 + 3u), the argument >= h_l/√(dx² + D2)·(1 − 4u), |v| >= |c|(1 + m)(1 − 10u) > |c|,
//     so v <= c <= the cut-off: lit; where c >= 0, v <= −0 <= c always.
// m = 1e-4 is far above the 10u ≈ 6e-7 these roundings need and the double arithmetic's ~1e-15 here;
// the √(H_c² − D2) bound is shrunk by (1 − m) as well. Tests: EgoLowBeam.RowsAreThePointFunctionAtEveryIsa.
struct BeamSureSpan {
  int lo = 0, hi = 0;
};
BeamSureSpan beam_sure_span(const BeamF& b, const double* xn, int n, double t, float D2, int only) {
  BeamSureSpan span;
  if (!b.ok || n <= 0 || !(t > 0) || !(b.hl > 0) || !(D2 > 0)) return span;
  constexpr double m = 1e-4, rad = M_PI / 180, lambda = 0.4142135623730950f;  // atanf_cephes' threshold, in float
  const double D = std::sqrt(static_cast<double>(D2)), hl = b.hl;
  const double Hm = std::min(-static_cast<double>(b.H[0]), static_cast<double>(b.H[b.nh - 1]));
  const double V0 = b.V[0], c = std::min(b.cv, b.cmax);
  if (!(Hm > 0) || !(V0 < 0) || !(b.V[b.nv - 1] >= 0)) return span;
  if (!(std::atan(hl / D) / rad <= -V0 * (1 - m)) || !(hl / D <= lambda * (1 - m))) return span;
  double dx_max = D * std::tan(Hm * (1 - m) * rad);
  if (c < 0) {
    const double Hc = hl / std::tan(-c * (1 + m) * rad);
    if (!(Hc * Hc > static_cast<double>(D2))) return span;
    dx_max = std::min(dx_max, std::sqrt(Hc * Hc - static_cast<double>(D2)) * (1 - m));
  }
  const int k0 = only < 0 ? 0 : only, k1 = only < 0 ? 1 : only;
  const auto dx = [&](int x, int k) { return static_cast<double>(static_cast<float>(t * xn[x]) - b.xl[k]); };
  const auto past_lo = [&](int x) {  // every lamp's dx >= −dx_max (false, then true along the row)
    for (int k = k0; k <= k1; ++k)
      if (!(dx(x, k) >= -dx_max)) return false;
    return true;
  };
  const auto within_hi = [&](int x) {  // every lamp's dx <= dx_max (true, then false)
    for (int k = k0; k <= k1; ++k)
      if (!(dx(x, k) <= dx_max)) return false;
    return true;
  };
  int a = 0, z = n;
  while (a < z) {
    const int mid = (a + z) / 2;
    past_lo(mid) ? z = mid : a = mid + 1;
  }
  span.lo = span.hi = a;
  z = n;
  while (a < z) {
    const int mid = (a + z) / 2;
    within_hi(mid) ? a = mid + 1 : z = mid;
  }
  span.hi = a;
  return span;
}
// One row's E over pixels 0 .. n − 1 of xn ((x − c_x)/f per column; X = t·xn in double, as
// CameraGeometry::ground_point, then rounded to float), 8 at a time: beam_lux_f's operations
// lane by lane, the rest by beam_lux_f itself; the same bits. Where `id` is given, only the
// pixels that read the beam are evaluated (class id in `read_mask`, bit id for ids below 64:
// low_beam_illuminance's scalar test), the others are 0; a block of eight with none of them is not
// evaluated at all.
// The table: the cell (i, j) of each lane by counting grid angles. Along a row the angles change
// by about 1/f rad (~0.03°) per pixel, so the lit lanes of a block of eight almost always share
// their cell, and mostly with the previous block: each lamp carries the cell its last block's
// lit lanes shared, and where every lit lane of this block lies inside it (two comparisons per
// angle, BeamF::sorted: the count is then that cell) nothing is counted. A shared cell's grid
// angles and four intensities are the same numbers for every lane and are broadcast (the values
// the gathers would read, so the same bits); otherwise they are gathered per lane (grid angles by
// permutations when at most 8). Unlit lanes are masked to 0 at the end, whatever their cell.
// With `only` 0 or 1, that lamp's E alone (beam_lamp_f's bits: the ground's shadows keep it).
// Blocks of eight inside `sure` (beam_sure_span) skip the lit test, take v's arctangent without the
// reduction test and the sign (its argument is positive and unreduced there), and where both lamps'
// lanes lie in their carried cells run both tables without a branch: the same bits.
// beam_row_scalar: the same row one pixel at a time (the vector rows' definition and their tail).
void beam_row_scalar(const double* xn, int n, double t, float D2, float invD, const BeamF& b, const uint16_t* id,
                     uint64_t read_mask, float* out, int only = -1) {
  for (int x = 0; x < n; ++x) {
    const bool need = !id || (id[x] < 64 && (read_mask >> id[x] & 1));
    const float X = static_cast<float>(t * xn[x]);
    out[x] = !need ? 0.f : only < 0 ? beam_lux_f(X, D2, invD, b) : beam_lamp_f(X - b.xl[only], D2, invD, b);
  }
}
__attribute__((target("avx2")))
void beam_row_avx2(const double* xn, int n, double t, float D2, float invD, const BeamF& b, const uint16_t* id,
                   uint64_t read_mask, float* out, int only = -1, BeamSureSpan sure = {}) {
  const __m256 zero = _mm256_setzero_ps(), sign = _mm256_set1_ps(-0.f);
  const __m256 vD2 = _mm256_set1_ps(D2), vinvD = _mm256_set1_ps(invD), hl = _mm256_set1_ps(b.hl),
               hl2 = _mm256_set1_ps(b.hl2), deg = _mm256_set1_ps(b.deg);
  const __m256 cv = _mm256_set1_ps(b.cv), cmax = _mm256_set1_ps(b.cmax), rise = _mm256_set1_ps(b.rise);
  const __m256 h_lo = _mm256_set1_ps(b.H[0]), h_hi = _mm256_set1_ps(b.H[b.nh - 1]);
  const __m256 v_lo = _mm256_set1_ps(b.V[0]), v_hi = _mm256_set1_ps(b.V[b.nv - 1]);
  const __m256i vnh = _mm256_set1_epi32(b.nh);
  const __m256 H8 = _mm256_loadu_ps(b.H8), rH8 = _mm256_loadu_ps(b.rH8), V8 = _mm256_loadu_ps(b.V8), rV8 = _mm256_loadu_ps(b.rV8);
  const __m256i mlo = _mm256_set1_epi32(static_cast<int32_t>(read_mask & 0xffffffffu)),
                mhi = _mm256_set1_epi32(static_cast<int32_t>(read_mask >> 32)), ione = _mm256_set1_epi32(1),
                k32 = _mm256_set1_epi32(32), all = _mm256_set1_epi32(-1);
  const __m256d vt = _mm256_set1_pd(t);
  const float* I = b.I.data();
  BeamCell cell[2];  // each lamp's carried cell
  beam_cell(cell[0], b, 0, 0);
  beam_cell(cell[1], b, 0, 0);
  int x = 0;
  for (; x + 8 <= n; x += 8) {
    __m256 keep = _mm256_castsi256_ps(all);
    if (id) {
      const __m256i k = _mm256_cvtepu16_epi32(_mm_loadu_si128(reinterpret_cast<const __m128i*>(id + x)));
      keep = _mm256_castsi256_ps(_mm256_cmpeq_epi32(
          _mm256_and_si256(_mm256_or_si256(_mm256_srlv_epi32(mlo, k), _mm256_srlv_epi32(mhi, _mm256_sub_epi32(k, k32))), ione),
          ione));
      if (_mm256_movemask_ps(keep) == 0) {
        _mm256_storeu_ps(out + x, zero);
        continue;
      }
    }
    const bool surely_lit = x >= sure.lo && x + 8 <= sure.hi;
    const __m128 lo = _mm256_cvtpd_ps(_mm256_mul_pd(vt, _mm256_loadu_pd(xn + x)));
    const __m128 hi = _mm256_cvtpd_ps(_mm256_mul_pd(vt, _mm256_loadu_pd(xn + x + 4)));
    const __m256 X = _mm256_set_m128(hi, lo);
    __m256 acc = zero;
    // Both lamps' geometry first, as independent runs of operations (the core overlaps the two
    // lamps' chains of dependent square roots, divisions and polynomials), then each lamp's table
    // (as beam_row_avx512).
    __m256 d2s[2], ds[2], args[4], angles[4];
    for (int k = 0; k < 2; ++k) {
      const __m256 dx = _mm256_sub_ps(X, _mm256_set1_ps(b.xl[k]));
      const __m256 horiz2 = _mm256_add_ps(_mm256_mul_ps(dx, dx), vD2), horiz = _mm256_sqrt_ps(horiz2);
      d2s[k] = _mm256_add_ps(horiz2, hl2), ds[k] = _mm256_sqrt_ps(d2s[k]);
      args[2 * k] = _mm256_mul_ps(dx, vinvD);
      args[2 * k + 1] = _mm256_div_ps(hl, horiz);
    }
    if (surely_lit) {
      // h by atanf_cephes8 (its own reduction test); v by its unreduced path (beam_sure_span) for
      // the positive h_l/horiz: |x| is x, its sign bit 0 (the OR with it the identity).
      for (int k = 0; k < 2; ++k) {
        angles[2 * k] = atanf_cephes8(args[2 * k]);
        angles[2 * k + 1] = atan_poly8(args[2 * k + 1]);
      }
    } else {
      atanf_cephes8x4(args, angles);
    }
    if (surely_lit && only < 0 && b.sorted) {
      // Both lamps lit in every lane: each lamp's carried-cell test, and where every lane of both
      // lies in its lamp's carried cell, the two bilinear reads and divisions as one straight run
      // (the loop below with its branches taken: the same operations in the same order).
      __m256 h[2], v[2];
      bool carried = true;
      for (int k = 0; k < 2; ++k) {
        h[k] = _mm256_mul_ps(angles[2 * k], deg);
        v[k] = _mm256_xor_ps(_mm256_mul_ps(angles[2 * k + 1], deg), sign);
        carried = carried && _mm256_movemask_ps(in_beam_cell(cell[k], h[k], v[k])) == 0xff;
      }
      if (carried) {
        __m256 Iw[2];
        for (int k = 0; k < 2; ++k) {
          const BeamCell& q = cell[k];
          const __m256 Iv = beam_bilinear8(h[k], v[k], q.Hj, q.rHj, q.Vi, q.rVi, q.r00, q.r01, q.r10, q.r11);
          Iw[k] = _mm256_mul_ps(Iv, _mm256_div_ps(hl, _mm256_mul_ps(d2s[k], ds[k])));
        }
        _mm256_storeu_ps(out + x, _mm256_and_ps(keep, _mm256_add_ps(_mm256_add_ps(acc, Iw[0]), Iw[1])));
        continue;
      }
    }
    for (int k = 0; k < 2; ++k) {
      if (only >= 0 && k != only) continue;
      const __m256 d2 = d2s[k], d = ds[k];
      const __m256 h = _mm256_mul_ps(angles[2 * k], deg);
      const __m256 v = _mm256_xor_ps(_mm256_mul_ps(angles[2 * k + 1], deg), sign);
      __m256 lit = _mm256_castsi256_ps(all);  // every lane, inside `sure`
      int lit_bits = 0xff;
      if (!surely_lit) {
        const __m256 cut = _mm256_min_ps(_mm256_add_ps(cv, _mm256_mul_ps(_mm256_max_ps(h, zero), rise)), cmax);
        lit = _mm256_cmp_ps(v, cut, _CMP_LE_OQ);
        lit = _mm256_and_ps(lit, _mm256_and_ps(_mm256_cmp_ps(h, h_lo, _CMP_GE_OQ), _mm256_cmp_ps(h, h_hi, _CMP_LE_OQ)));
        lit = _mm256_and_ps(lit, _mm256_and_ps(_mm256_cmp_ps(v, v_lo, _CMP_GE_OQ), _mm256_cmp_ps(v, v_hi, _CMP_LE_OQ)));
        lit_bits = _mm256_movemask_ps(lit);
        if (lit_bits == 0) continue;
      }
      bool shared = false;
      __m256i j, i;
      if (b.sorted) shared = (_mm256_movemask_ps(in_beam_cell(cell[k], h, v)) & lit_bits) == lit_bits;
      if (!shared) {
        j = _mm256_setzero_si256(), i = _mm256_setzero_si256();  // cell indices as counts
        for (int m = 1; m + 1 < b.nh; ++m)
          j = _mm256_sub_epi32(j, _mm256_castps_si256(_mm256_cmp_ps(_mm256_set1_ps(b.H[m]), h, _CMP_LE_OQ)));
        for (int m = 1; m + 1 < b.nv; ++m)
          i = _mm256_sub_epi32(i, _mm256_castps_si256(_mm256_cmp_ps(_mm256_set1_ps(b.V[m]), v, _CMP_LE_OQ)));
        // The cell of the first lit lane, and whether every lit lane has it.
        const __m256i first = _mm256_set1_epi32(__builtin_ctz(static_cast<unsigned>(lit_bits)));
        const __m256i j0 = _mm256_permutevar8x32_epi32(j, first), i0 = _mm256_permutevar8x32_epi32(i, first);
        const __m256i same = _mm256_and_si256(_mm256_cmpeq_epi32(j, j0), _mm256_cmpeq_epi32(i, i0));
        shared = (_mm256_movemask_ps(_mm256_and_ps(lit, _mm256_castsi256_ps(same))) & lit_bits) == lit_bits;
        if (shared) beam_cell(cell[k], b, _mm256_cvtsi256_si32(j0), _mm256_cvtsi256_si32(i0));
      }
      __m256 Hj, rHj, Vi, rVi, r00, r01, r10, r11;
      if (shared) {
        const BeamCell& c = cell[k];
        Hj = c.Hj, rHj = c.rHj, Vi = c.Vi, rVi = c.rVi, r00 = c.r00, r01 = c.r01, r10 = c.r10, r11 = c.r11;
      } else {
        if (b.small) {
          Hj = _mm256_permutevar8x32_ps(H8, j), rHj = _mm256_permutevar8x32_ps(rH8, j);
          Vi = _mm256_permutevar8x32_ps(V8, i), rVi = _mm256_permutevar8x32_ps(rV8, i);
        } else {
          Hj = _mm256_i32gather_ps(b.H.data(), j, 4), rHj = _mm256_i32gather_ps(b.rH.data(), j, 4);
          Vi = _mm256_i32gather_ps(b.V.data(), i, 4), rVi = _mm256_i32gather_ps(b.rV.data(), i, 4);
        }
        const __m256i c0 = _mm256_add_epi32(_mm256_mullo_epi32(i, vnh), j);  // r0 + j
        r00 = _mm256_i32gather_ps(I, c0, 4), r01 = _mm256_i32gather_ps(I + 1, c0, 4);
        r10 = _mm256_i32gather_ps(I + b.nh, c0, 4), r11 = _mm256_i32gather_ps(I + b.nh + 1, c0, 4);
      }
      __m256 Iv = beam_bilinear8(h, v, Hj, rHj, Vi, rVi, r00, r01, r10, r11);
      if (!surely_lit) Iv = _mm256_and_ps(lit, Iv);
      acc = _mm256_add_ps(acc, _mm256_mul_ps(Iv, _mm256_div_ps(hl, _mm256_mul_ps(d2, d))));
    }
    _mm256_storeu_ps(out + x, _mm256_and_ps(keep, acc));
  }
  beam_row_scalar(xn + x, n - x, t, D2, invD, b, id ? id + x : nullptr, read_mask, out + x, only);
}
// PHOTOSITE_SCALAR_LIGHTS=1 (environment.h) takes the scalar path on an AVX2 machine.
const bool kHaveAvx2 = photosite::detail::have_avx2() && env::get(env::Var::ScalarLights).value_or("0") != "1";

// ---- The image: 16 lanes (AVX-512F) ---------------------------------------------------------
// beam_row_avx2 sixteen pixels at a time: the same operations on each lane in the same order
// (lane masks in mask registers instead of vectors; AVX-512F has no float and/or/xor, so the
// sign bits are set and flipped by integer operations, which are the same bit operations), the
// same carried-cell test, so the same bits; the remainder (under 16 pixels) by beam_row_avx2.
// (GCC 12's 512-bit intrinsics start from _mm512_undefined_*(), which -Wmaybe-uninitialized
// reports inside avx512fintrin.h: silenced for these functions, as in scene/darken.cpp.)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#define PHOTOSITE_AVX512 __attribute__((target("avx512f")))
PHOTOSITE_AVX512 inline __m512 or_ps16(__m512 a, __m512i bits) {
  return _mm512_castsi512_ps(_mm512_or_si512(_mm512_castps_si512(a), bits));
}
// atan_poly8 on 16 lanes.
PHOTOSITE_AVX512 inline __m512 atan_poly16(__m512 r) {
  const __m512 z = _mm512_mul_ps(r, r);
  __m512 P = _mm512_sub_ps(_mm512_mul_ps(_mm512_set1_ps(8.05374449538e-2f), z), _mm512_set1_ps(1.38776856032e-1f));
  P = _mm512_add_ps(_mm512_mul_ps(P, z), _mm512_set1_ps(1.99777106478e-1f));
  P = _mm512_sub_ps(_mm512_mul_ps(P, z), _mm512_set1_ps(3.33329491539e-1f));
  return _mm512_add_ps(_mm512_mul_ps(_mm512_mul_ps(P, z), r), r);
}
// atanf_cephes8 on 16 lanes.
PHOTOSITE_AVX512 inline __m512 atanf_cephes16(__m512 x) {
  const __m512 one = _mm512_set1_ps(1.f);
  const __m512i sign = _mm512_and_si512(_mm512_castps_si512(x), _mm512_set1_epi32(INT32_MIN));
  const __m512 ax = _mm512_castsi512_ps(_mm512_andnot_si512(_mm512_set1_epi32(INT32_MIN), _mm512_castps_si512(x)));
  const __mmask16 mid = _mm512_cmp_ps_mask(ax, _mm512_set1_ps(0.4142135623730950f), _CMP_GT_OQ);
  if (mid == 0) return or_ps16(atan_poly16(ax), sign);  // (+0 + t = t: atanf_cephes8)
  const __mmask16 big = _mm512_cmp_ps_mask(ax, _mm512_set1_ps(2.414213562373095f), _CMP_GT_OQ);
  // _mm512_mask_blend_ps(k, a, b): b where k, else a.
  const __m512 num = _mm512_mask_blend_ps(big, _mm512_mask_blend_ps(mid, ax, _mm512_sub_ps(ax, one)), _mm512_set1_ps(-1.f));
  const __m512 den = _mm512_mask_blend_ps(big, _mm512_mask_blend_ps(mid, one, _mm512_add_ps(ax, one)), ax);
  const __m512 y0 = _mm512_mask_blend_ps(big, _mm512_maskz_mov_ps(mid, _mm512_set1_ps(0.7853981633974483096f)),
                                         _mm512_set1_ps(1.5707963267948966192f));
  const __m512 a = _mm512_add_ps(y0, atan_poly16(_mm512_div_ps(num, den)));
  return or_ps16(a, sign);
}
// atanf_cephes16 of four vectors (both lamps' h and v arguments) at once: where no lane of any of
// them is reduced (the common case) their four polynomials as one straight run of independent
// operations, which the core overlaps (one at a time, each waited on its own chain of dependent
// multiplications); otherwise atanf_cephes16 of each. The same operations on every lane.
PHOTOSITE_AVX512 inline void atanf_cephes16x4(const __m512 (&x)[4], __m512 (&out)[4]) {
  const __m512i absbits = _mm512_set1_epi32(INT32_MAX);
  const __m512 lim = _mm512_set1_ps(0.4142135623730950f);
  __m512 ax[4];
  __mmask16 mid = 0;
  for (int q = 0; q < 4; ++q) {
    ax[q] = _mm512_castsi512_ps(_mm512_and_si512(_mm512_castps_si512(x[q]), absbits));
    mid |= _mm512_cmp_ps_mask(ax[q], lim, _CMP_GT_OQ);
  }
  if (mid != 0) {
    for (int q = 0; q < 4; ++q) out[q] = atanf_cephes16(x[q]);
    return;
  }
  // atanf_cephes16's unreduced path, four times over.
  for (int q = 0; q < 4; ++q)
    out[q] = or_ps16(atan_poly16(ax[q]), _mm512_and_si512(_mm512_castps_si512(x[q]), _mm512_set1_epi32(INT32_MIN)));
}
struct BeamCell16 { __m512 lo_h, hi_h, lo_v, hi_v, Hj, rHj, Vi, rVi, r00, r01, r10, r11; };
[[gnu::always_inline]] PHOTOSITE_AVX512 inline void beam_cell16(BeamCell16& c, const BeamF& b, int j, int i) {
  const float* r0 = b.I.data() + i * b.nh + j;
  c.lo_h = _mm512_set1_ps(b.Hlo[j]), c.hi_h = _mm512_set1_ps(b.Hhi[j]);
  c.lo_v = _mm512_set1_ps(b.Vlo[i]), c.hi_v = _mm512_set1_ps(b.Vhi[i]);
  c.Hj = _mm512_set1_ps(b.H[j]), c.rHj = _mm512_set1_ps(b.rH[j]);
  c.Vi = _mm512_set1_ps(b.V[i]), c.rVi = _mm512_set1_ps(b.rV[i]);
  c.r00 = _mm512_set1_ps(r0[0]), c.r01 = _mm512_set1_ps(r0[1]);
  c.r10 = _mm512_set1_ps(r0[b.nh]), c.r11 = _mm512_set1_ps(r0[b.nh + 1]);
}
// beam_table_f's steps on sixteen lanes, shared by the ground's rows (beam_row_avx512) and the
// vertical surfaces' (beam_table16). A small grid's registers (BeamF::small): the grids of at most
// 8 angles in the low lanes, read by a lane permutation, and the table's 64 values (BeamF::I64)
// in four, value k of a lane's index k (< 64) from the two-register permute of its half, chosen
// by bit 5.
struct BeamSmall16 { __m512 H8, rH8, V8, rV8, I0, I1, I2, I3; };
[[gnu::always_inline]] PHOTOSITE_AVX512 inline BeamSmall16 beam_small16(const BeamF& b) {
  return {_mm512_castps256_ps512(_mm256_loadu_ps(b.H8)), _mm512_castps256_ps512(_mm256_loadu_ps(b.rH8)),
          _mm512_castps256_ps512(_mm256_loadu_ps(b.V8)), _mm512_castps256_ps512(_mm256_loadu_ps(b.rV8)),
          _mm512_load_ps(b.I64),                         _mm512_load_ps(b.I64 + 16),
          _mm512_load_ps(b.I64 + 32),                    _mm512_load_ps(b.I64 + 48)};
}
[[gnu::always_inline]] PHOTOSITE_AVX512 inline __m512 beam_small_value16(const BeamSmall16& S, __m512i k) {
  return _mm512_mask_blend_ps(_mm512_test_epi32_mask(k, _mm512_set1_epi32(32)), _mm512_permutex2var_ps(S.I0, k, S.I1),
                              _mm512_permutex2var_ps(S.I2, k, S.I3));
}
// Each lane's cell (i, j) as counts of the inner grid angles at or below its (h, v).
[[gnu::always_inline]] PHOTOSITE_AVX512 inline void beam_cell_index16(__m512 h, __m512 v, const BeamF& b, __m512i& j,
                                                                      __m512i& i) {
  const __m512i ione = _mm512_set1_epi32(1);
  j = _mm512_setzero_si512(), i = _mm512_setzero_si512();
  for (int m = 1; m + 1 < b.nh; ++m) j = _mm512_mask_add_epi32(j, _mm512_cmp_ps_mask(_mm512_set1_ps(b.H[m]), h, _CMP_LE_OQ), j, ione);
  for (int m = 1; m + 1 < b.nv; ++m) i = _mm512_mask_add_epi32(i, _mm512_cmp_ps_mask(_mm512_set1_ps(b.V[m]), v, _CMP_LE_OQ), i, ione);
}
// A small grid's cell (i, j) per lane: its lower nodes, their reciprocal spacings and its four
// intensities (r00 = I[i·nh + j], r01 the next along h, r10, r11 the next row along v).
struct BeamCorners16 { __m512 Hj, rHj, Vi, rVi, r00, r01, r10, r11; };
[[gnu::always_inline]] PHOTOSITE_AVX512 inline BeamCorners16 beam_small_corners16(const BeamSmall16& S, __m512i j,
                                                                                 __m512i i, int nh) {
  const __m512i ione = _mm512_set1_epi32(1), vnh = _mm512_set1_epi32(nh);
  const __m512i c0 = _mm512_add_epi32(_mm512_mullo_epi32(i, vnh), j), c1 = _mm512_add_epi32(c0, vnh);
  return {_mm512_permutexvar_ps(j, S.H8),           _mm512_permutexvar_ps(j, S.rH8),
          _mm512_permutexvar_ps(i, S.V8),           _mm512_permutexvar_ps(i, S.rV8),
          beam_small_value16(S, c0),                beam_small_value16(S, _mm512_add_epi32(c0, ione)),
          beam_small_value16(S, c1),                beam_small_value16(S, _mm512_add_epi32(c1, ione))};
}
// The bilinear interpolation in the cell: beam_table_f's operations in its order.
[[gnu::always_inline]] PHOTOSITE_AVX512 inline __m512 beam_bilerp16(__m512 h, __m512 v, const BeamCorners16& q) {
  const __m512 one = _mm512_set1_ps(1.f);
  const __m512 a = _mm512_mul_ps(_mm512_sub_ps(h, q.Hj), q.rHj), c = _mm512_mul_ps(_mm512_sub_ps(v, q.Vi), q.rVi);
  const __m512 ia = _mm512_sub_ps(one, a), ic = _mm512_sub_ps(one, c);
  const __m512 top = _mm512_add_ps(_mm512_mul_ps(ia, q.r00), _mm512_mul_ps(a, q.r01));
  const __m512 bot = _mm512_add_ps(_mm512_mul_ps(ia, q.r10), _mm512_mul_ps(a, q.r11));
  return _mm512_add_ps(_mm512_mul_ps(ic, top), _mm512_mul_ps(c, bot));
}
PHOTOSITE_AVX512
void beam_row_avx512(const double* xn, int n, double t, float D2, float invD, const BeamF& b, const uint16_t* id,
                     uint64_t read_mask, float* out, int only = -1) {
  const __m512 zero = _mm512_setzero_ps();
  const __m512i sign = _mm512_set1_epi32(INT32_MIN);
  const __m512 vD2 = _mm512_set1_ps(D2), vinvD = _mm512_set1_ps(invD), hl = _mm512_set1_ps(b.hl),
               hl2 = _mm512_set1_ps(b.hl2), deg = _mm512_set1_ps(b.deg);
  const __m512 cv = _mm512_set1_ps(b.cv), cmax = _mm512_set1_ps(b.cmax), rise = _mm512_set1_ps(b.rise);
  const __m512 h_lo = _mm512_set1_ps(b.H[0]), h_hi = _mm512_set1_ps(b.H[b.nh - 1]);
  const __m512 v_lo = _mm512_set1_ps(b.V[0]), v_hi = _mm512_set1_ps(b.V[b.nv - 1]);
  const __m512i vnh = _mm512_set1_epi32(b.nh);
  const BeamSmall16 S = beam_small16(b);  // (small grids)
  const __m512i mlo = _mm512_set1_epi32(static_cast<int32_t>(read_mask & 0xffffffffu)),
                mhi = _mm512_set1_epi32(static_cast<int32_t>(read_mask >> 32)), ione = _mm512_set1_epi32(1),
                k32 = _mm512_set1_epi32(32);
  const __m512d vt = _mm512_set1_pd(t);
  const float* I = b.I.data();
  BeamCell16 cell[2];  // each lamp's carried cell
  beam_cell16(cell[0], b, 0, 0);
  beam_cell16(cell[1], b, 0, 0);
  int x = 0;
  for (; x + 16 <= n; x += 16) {
    __mmask16 keep = 0xffff;
    if (id) {
      const __m512i k = _mm512_cvtepu16_epi32(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(id + x)));
      keep = _mm512_test_epi32_mask(_mm512_or_si512(_mm512_srlv_epi32(mlo, k), _mm512_srlv_epi32(mhi, _mm512_sub_epi32(k, k32))),
                                    ione);
      if (keep == 0) {
        _mm512_storeu_ps(out + x, zero);
        continue;
      }
    }
    const __m256 lo = _mm512_cvtpd_ps(_mm512_mul_pd(vt, _mm512_loadu_pd(xn + x)));
    const __m256 hi = _mm512_cvtpd_ps(_mm512_mul_pd(vt, _mm512_loadu_pd(xn + x + 8)));
    const __m512 X = _mm512_castpd_ps(_mm512_insertf64x4(_mm512_castps_pd(_mm512_castps256_ps512(lo)), _mm256_castps_pd(hi), 1));
    __m512 acc = zero;
    // Both lamps' geometry first, as independent runs of operations (the core overlaps the two
    // lamps' chains of dependent square roots, divisions and polynomials), then each lamp's table.
    __m512 d2s[2], ds[2], args[4], angles[4];
    for (int k = 0; k < 2; ++k) {
      const __m512 dx = _mm512_sub_ps(X, _mm512_set1_ps(b.xl[k]));
      const __m512 horiz2 = _mm512_add_ps(_mm512_mul_ps(dx, dx), vD2), horiz = _mm512_sqrt_ps(horiz2);
      d2s[k] = _mm512_add_ps(horiz2, hl2), ds[k] = _mm512_sqrt_ps(d2s[k]);
      args[2 * k] = _mm512_mul_ps(dx, vinvD);
      args[2 * k + 1] = _mm512_div_ps(hl, horiz);
    }
    atanf_cephes16x4(args, angles);
    for (int k = 0; k < 2; ++k) {
      if (only >= 0 && k != only) continue;
      const __m512 d2 = d2s[k], d = ds[k];
      const __m512 h = _mm512_mul_ps(angles[2 * k], deg);
      const __m512 v = _mm512_castsi512_ps(_mm512_xor_si512(_mm512_castps_si512(_mm512_mul_ps(angles[2 * k + 1], deg)), sign));
      const __m512 cut = _mm512_min_ps(_mm512_add_ps(cv, _mm512_mul_ps(_mm512_max_ps(h, zero), rise)), cmax);
      __mmask16 lit = _mm512_cmp_ps_mask(v, cut, _CMP_LE_OQ);
      lit &= _mm512_cmp_ps_mask(h, h_lo, _CMP_GE_OQ) & _mm512_cmp_ps_mask(h, h_hi, _CMP_LE_OQ);
      lit &= _mm512_cmp_ps_mask(v, v_lo, _CMP_GE_OQ) & _mm512_cmp_ps_mask(v, v_hi, _CMP_LE_OQ);
      if (lit == 0) continue;
      bool shared = false;
      __m512i j, i;
      if (b.sorted) {
        const __mmask16 in_h = _mm512_cmp_ps_mask(cell[k].lo_h, h, _CMP_LE_OQ) & _mm512_cmp_ps_mask(h, cell[k].hi_h, _CMP_LT_OQ);
        const __mmask16 in_v = _mm512_cmp_ps_mask(cell[k].lo_v, v, _CMP_LE_OQ) & _mm512_cmp_ps_mask(v, cell[k].hi_v, _CMP_LT_OQ);
        shared = (in_h & in_v & lit) == lit;
      }
      if (!shared) {
        beam_cell_index16(h, v, b, j, i);
        const __m512i first = _mm512_set1_epi32(__builtin_ctz(static_cast<unsigned>(lit)));
        const __m512i j0 = _mm512_permutexvar_epi32(first, j), i0 = _mm512_permutexvar_epi32(first, i);
        const __mmask16 same = _mm512_cmpeq_epi32_mask(j, j0) & _mm512_cmpeq_epi32_mask(i, i0);
        shared = (lit & same) == lit;
        if (shared) beam_cell16(cell[k], b, _mm512_cvtsi512_si32(j0), _mm512_cvtsi512_si32(i0));
      }
      BeamCorners16 q;
      if (shared) {
        const BeamCell16& c = cell[k];
        q = {c.Hj, c.rHj, c.Vi, c.rVi, c.r00, c.r01, c.r10, c.r11};
      } else if (b.small) {
        q = beam_small_corners16(S, j, i, b.nh);
      } else {
        const __m512i c0 = _mm512_add_epi32(_mm512_mullo_epi32(i, vnh), j);  // r0 + j
        q = {_mm512_i32gather_ps(j, b.H.data(), 4), _mm512_i32gather_ps(j, b.rH.data(), 4),
             _mm512_i32gather_ps(i, b.V.data(), 4), _mm512_i32gather_ps(i, b.rV.data(), 4),
             _mm512_i32gather_ps(c0, I, 4),         _mm512_i32gather_ps(c0, I + 1, 4),
             _mm512_i32gather_ps(c0, I + b.nh, 4),  _mm512_i32gather_ps(c0, I + b.nh + 1, 4)};
      }
      const __m512 Iv = _mm512_maskz_mov_ps(lit, beam_bilerp16(h, v, q));
      acc = _mm512_add_ps(acc, _mm512_mul_ps(Iv, _mm512_div_ps(hl, _mm512_mul_ps(d2, d))));
    }
    _mm512_storeu_ps(out + x, _mm512_maskz_mov_ps(keep, acc));
  }
  if (x < n)
    beam_row_avx2(xn + x, n - x, t, D2, invD, b, id ? id + x : nullptr, read_mask, out + x, only);
}
// beam_table_f on sixteen lanes for a small grid (BeamF::small: the grids and the table read by
// lane permutations): the same operations per lane.
PHOTOSITE_AVX512 inline __m512 beam_table16(__m512 h, __m512 v, const BeamF& b) {
  __m512i j, i;
  beam_cell_index16(h, v, b, j, i);
  return beam_bilerp16(h, v, beam_small_corners16(beam_small16(b), j, i, b.nh));
}
#undef PHOTOSITE_AVX512
#pragma GCC diagnostic pop
// The widest path the beam image may take (beam_max_isa): 2 AVX-512, 1 AVX2, 0 scalar.
const bool kHaveAvx512 = kHaveAvx2 && photosite::detail::have_avx512();
int beam_isa_cap = 2;
bool g_fused_rows = true;  // light_map_fused_rows
}  // namespace

void beam_max_isa(int isa) { beam_isa_cap = isa; }
void light_map_fused_rows(bool on) { g_fused_rows = on; }

double low_beam_intensity_cd(double h_deg, double v_deg, const ScenePreset& p) {
  return beam_intensity_cd(h_deg, v_deg, std::tan(p.beam_cutoff_rise_deg * M_PI / 180), p);
}

double low_beam_lux(double X_m, double D_m, const ScenePreset& p) {
  // The headlamp pair at (±spacing/2, lamp_height_m, 0) in road coordinates (beside the camera,
  // whose forward offset from the lamps is neglected: an approximation), aimed along the road.
  // A ground point (X, 0, D) seen from a lamp at horizontal angle h = atan2(X − x_l, D) and
  // vertical angle v = −atan2(h_l, √((X − x_l)² + D²)) receives E = I(h, v)·cos θ / d² with
  // d² = (X − x_l)² + h_l² + D² and cos θ = h_l / d (incidence from the road's normal).
  return beam_lux(X_m, D_m, std::tan(p.beam_cutoff_rise_deg * M_PI / 180), p);
}

// One headlamp's E⊥ = I(h, v)/d² at road point (X, Y, D), the lamp at (x_l, lamp_height_m, 0): the
// table below the cut-off, beam_above_cutoff_cd above it within the table's horizontal range.
// SignLight holds what does not change from sign pixel to sign pixel (the tangents of the
// cut-off's top and of the table's horizontal edges, and R_A's columns: detail::SignRA), so that a
// point above the whole cut-off and inside the table's range (most signs) needs no atan2: v > the
// rising cut-off's maximum ⟺ dy > rh·tan(max), h in [H₀, H₁] ⟺ D·tan H₀ ≤ dx ≤ D·tan H₁ (D > 0,
// |angles| < 90°); R_A needs no libm call at any α (scene/sign_retro_detail.h). Same values as
// the angle-by-angle evaluation, up to which side of a threshold a point within rounding of it
// falls. Also without atan2: a point outside the table's horizontal range by a margin gets I = 0
// (below), the same zero as the angle-by-angle evaluation's.
namespace {
struct SignLight {
  const ScenePreset& p;
  double cam_h, tan_rise, tan_vmax, tan_h0, tan_h1;
  bool table;
  detail::SignRA ra;  // R_A(α, β): scene/sign_retro_detail.h
  detail::SignFacing facing;  // which way the signs face (the camera's heading unless the road bends)
  SignLight(const ScenePreset& pr, double camera_height_m)
      : p(pr), cam_h(camera_height_m), tan_rise(std::tan(pr.beam_cutoff_rise_deg * M_PI / 180)),
        tan_vmax(std::tan(pr.beam_cutoff_max_v_deg * M_PI / 180)), tan_h0(0), tan_h1(0),
        table(pr.beam_h_deg.size() >= 2), ra(pr) {
    if (table) {
      tan_h0 = std::tan(pr.beam_h_deg.front() * M_PI / 180);
      tan_h1 = std::tan(pr.beam_h_deg.back() * M_PI / 180);
    }
  }
  double lamp_lux(double X_m, double Y_m, double D_m, double xl) const {
    const double dx = X_m - xl, dy = Y_m - p.beam_lamp_height_m;
    const double rh = std::sqrt(dx * dx + D_m * D_m), d2 = dx * dx + dy * dy + D_m * D_m;
    if (table && dy > rh * tan_vmax && dx >= D_m * tan_h0 && dx <= D_m * tan_h1) return p.beam_above_cutoff_cd / d2;
    // Left or right of the table's horizontal range [H₀, H₁] by a margin of 10⁻⁹ of |dx| + D: the
    // angle path below gives I = 0 there at any v (beam_intensity_cd's grid test below the
    // cut-off, the glare zone's range test above it), and 0/d2 = +0. The margin: sin(h − H₁) =
    // cos H₁·(dx − D·tan H₁)/√(dx² + D²) > cos H₁·10⁻⁹ (likewise at H₀), 0.9·10⁻⁹ rad for the
    // presets' ±25°, against h's rounding of a few ulp in that path (~10⁻¹⁵): the same zero, bit
    // for bit, without two atan2 (signs beside the road: on aachen_000000 8,631 of the sign
    // pixels' 69,726 lamp terms, where the fast path above takes 54,602 and 6,493 are left).
    if (table && (dx - D_m * tan_h0 < -1e-9 * (std::abs(dx) + D_m) || dx - D_m * tan_h1 > 1e-9 * (std::abs(dx) + D_m)))
      return 0.0;
    const double h = std::atan2(dx, D_m) * 180 / M_PI, v = std::atan2(dy, rh) * 180 / M_PI;
    const double cut = std::min(p.beam_cutoff_max_v_deg, p.beam_cutoff_v_deg + std::max(0.0, h) * tan_rise);
    double I = 0;
    if (v <= cut) I = beam_intensity_cd(h, v, tan_rise, p);
    else if (table && h >= p.beam_h_deg.front() && h <= p.beam_h_deg.back()) I = p.beam_above_cutoff_cd;
    return I / d2;
  }
  // R_A at observation angle α (its cosine) and entrance angle β (its tangent; read only where the
  // preset has an entrance table): the lanes' arithmetic on one lane.
  double RA(double cos_alpha, double tan_beta) const {
    return detail::sign_RA_lanes<double>(ra, cos_alpha, tan_beta);
  }
  // L = Σ_lamps R_A(α, β)·E⊥: each lamp's light returns toward it, and the camera (on the car's
  // centre line at cam_h) sees it at the observation angle α between the sign-to-lamp and
  // sign-to-camera directions; the lamp's ray meets the sign, which faces along the road (normal
  // (0, 0, −1)), at the entrance angle β: tan β = √(lX² + lY²)/D.
  // Where the road ahead bends (facing.curved), the sign faces the traffic that reads it instead:
  // normal −(sin ψ, 0, cos ψ) (detail::SignFacing), taken as (u, v) = |w|·(sin ψ, cos ψ), w2 =
  // |w|²: tan β = |l × n|/(l·n) = √(w2·lY² + (v·lX + u·D)²)/(v·D − u·lX), l = (lX, lY, −D) toward
  // the lamp. A lamp behind the sign's face (v·D − u·lX ≤ 0) lights its back, and a camera behind
  // it (X·u + D·v ≤ 0) sees its back: nothing returns. With (u, v, w2) = (0, 1, 1) these are the
  // facing sign's expressions above, bit for bit (1·x and x + ±0 are x; the sum's terms swapped).
  bool facing_front(double X_m, double D_m, double* u, double* v, double* w2) const {
    if (!facing.curved) {
      *u = 0, *v = 1, *w2 = 1;
      return true;
    }
    detail::sign_facing_lanes<double>(facing, X_m, D_m, *u, *v, *w2);
    return X_m * *u + D_m * *v > 0;
  }
  double luminance(double X_m, double Y_m, double D_m) const {
    if (!(D_m > 0)) return 0;
    double u, v, w2;
    if (!facing_front(X_m, D_m, &u, &v, &w2)) return 0;
    const double cX = -X_m, cY = cam_h - Y_m, cD = -D_m, cn = std::sqrt(cX * cX + cY * cY + cD * cD);
    double L = 0;
    for (const double xl : {-0.5 * p.beam_lamp_spacing_m, 0.5 * p.beam_lamp_spacing_m}) {
      const double lX = xl - X_m, lY = p.beam_lamp_height_m - Y_m, lD = -D_m, ln = std::sqrt(lX * lX + lY * lY + lD * lD);
      const double ln_n = v * D_m - u * lX;
      if (!(ln_n > 0)) continue;
      const double across = v * lX + u * D_m;
      const double tb = ra.n > 1 ? std::sqrt(w2 * (lY * lY) + across * across) / ln_n : 0;
      L += RA((cX * lX + cY * lY + cD * lD) / (cn * ln), tb) * lamp_lux(X_m, Y_m, D_m, xl);
    }
    return L;
  }
};

// SignLight::luminance at sign_pos's point (light_map_with) for n sign pixels of row y, eight at a
// time: columns x[i] (as doubles), camera z z[i] (the depth's floats as doubles); kY = sin θ +
// y_n·cos θ and kD = cos θ − y_n·sin θ of the row, as sign_pos computes them. Per lane the same
// IEEE operations in the same order as the scalar code (X = z·((x − c_x)/f), Y = h − z·kY,
// D = z·kD, then luminance's; -ffp-contract=off: no fused multiply-adds), with its branches as
// lane masks: R_A at every α and β by the lane arithmetic that the scalar code runs on one lane
// (detail::sign_RA_lanes), E⊥ where lamp_lux's two fast paths hold (the glare zone's I/d², or 0
// beside the table). A lane that needs anything else (the atan2 path for E⊥, a depth that is not
// finite and positive, D ≤ 0) is out[i] = scalar(i), the scalar code itself. So the same bits as
// sign_pos pixel by pixel.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
__attribute__((target("avx512f"))) inline __m512d neg_pd8(__m512d a) {  // −a (the sign bit flipped)
  return _mm512_castsi512_pd(
      _mm512_xor_si512(_mm512_castpd_si512(a), _mm512_set1_epi64(static_cast<int64_t>(0x8000000000000000ull))));
}
__attribute__((target("avx512f"))) inline __m512d sq_pd8(__m512d a) { return _mm512_mul_pd(a, a); }
template <class Scalar>
__attribute__((target("avx512f"))) void sign_luminances_avx512(const SignLight& sl, const double* x, const double* z,
                                                               int n, double cx, double f, double h, double kY,
                                                               double kD, double* out, Scalar&& scalar) {
  const ScenePreset& p = sl.p;
  const __m512d zero = _mm512_setzero_pd(), one = _mm512_set1_pd(1.0), inf = _mm512_set1_pd(INFINITY);
  const __m512d vcx = _mm512_set1_pd(cx), vf = _mm512_set1_pd(f), vh = _mm512_set1_pd(h), vkY = _mm512_set1_pd(kY),
                vkD = _mm512_set1_pd(kD), cam_h = _mm512_set1_pd(sl.cam_h), lh = _mm512_set1_pd(p.beam_lamp_height_m);
  const __m512d tvmax = _mm512_set1_pd(sl.tan_vmax), th0 = _mm512_set1_pd(sl.tan_h0), th1 = _mm512_set1_pd(sl.tan_h1),
                above = _mm512_set1_pd(p.beam_above_cutoff_cd), lo_margin = _mm512_set1_pd(-1e-9),
                hi_margin = _mm512_set1_pd(1e-9);
  const double xls[2] = {-0.5 * p.beam_lamp_spacing_m, 0.5 * p.beam_lamp_spacing_m};
  const bool entrance = sl.ra.n > 1;
  for (int i = 0; i < n; i += 8) {
    const __mmask8 m = n - i >= 8 ? 0xff : static_cast<__mmask8>((1u << (n - i)) - 1);
    const __m512d vz = _mm512_maskz_loadu_pd(m, z + i), vx = _mm512_maskz_loadu_pd(m, x + i);
    __mmask8 fast = m & _mm512_cmp_pd_mask(vz, zero, _CMP_GT_OQ) & _mm512_cmp_pd_mask(vz, inf, _CMP_LT_OQ);
    const __m512d X = _mm512_mul_pd(vz, _mm512_div_pd(_mm512_sub_pd(vx, vcx), vf));
    const __m512d Y = _mm512_sub_pd(vh, _mm512_mul_pd(vz, vkY)), D = _mm512_mul_pd(vz, vkD);
    fast &= _mm512_cmp_pd_mask(D, zero, _CMP_GT_OQ);
    // Which way the signs face (SignLight::facing_front): (0, 1, 1) unless the road ahead bends;
    // a lane whose camera sees the sign's back returns nothing (+0, as the scalar code's return).
    __m512d u = zero, v = one, w2 = one;
    __mmask8 front = 0xff;
    if (sl.facing.curved) {
      detail::sign_facing_lanes<__m512d>(sl.facing, X, D, u, v, w2);
      front = _mm512_cmp_pd_mask(_mm512_add_pd(_mm512_mul_pd(X, u), _mm512_mul_pd(D, v)), zero, _CMP_GT_OQ);
    }
    const __m512d cX = neg_pd8(X), cY = _mm512_sub_pd(cam_h, Y), cD = neg_pd8(D);
    const __m512d cn = _mm512_sqrt_pd(_mm512_add_pd(_mm512_add_pd(sq_pd8(cX), sq_pd8(cY)), sq_pd8(cD)));
    __m512d L = zero;
    for (const double xl : xls) {
      const __m512d vxl = _mm512_set1_pd(xl);
      const __m512d lX = _mm512_sub_pd(vxl, X), lY = _mm512_sub_pd(lh, Y), lD = neg_pd8(D);
      const __m512d ln = _mm512_sqrt_pd(_mm512_add_pd(_mm512_add_pd(sq_pd8(lX), sq_pd8(lY)), sq_pd8(lD)));
      const __m512d ca = _mm512_div_pd(
          _mm512_add_pd(_mm512_add_pd(_mm512_mul_pd(cX, lX), _mm512_mul_pd(cY, lY)), _mm512_mul_pd(cD, lD)),
          _mm512_mul_pd(cn, ln));
      // R_A(α, β) by the shared lane arithmetic (scene/sign_retro_detail.h), tan β = √(w2·lY² +
      // (v·lX + u·D)²)/(v·D − u·lX) (SignLight::luminance); the lamp lights the sign's face where
      // v·D − u·lX > 0
      const __m512d ln_n = _mm512_sub_pd(_mm512_mul_pd(v, D), _mm512_mul_pd(u, lX));
      const __m512d across = _mm512_add_pd(_mm512_mul_pd(v, lX), _mm512_mul_pd(u, D));
      const __mmask8 lit = _mm512_cmp_pd_mask(ln_n, zero, _CMP_GT_OQ);
      const __m512d tb =
          entrance ? _mm512_div_pd(_mm512_sqrt_pd(_mm512_add_pd(_mm512_mul_pd(w2, sq_pd8(lY)), sq_pd8(across))), ln_n)
                   : zero;
      const bool any_mid = _mm512_cmp_pd_mask(ca, _mm512_set1_pd(sl.ra.cos_a0), _CMP_NGE_UQ) &
                           _mm512_cmp_pd_mask(ca, _mm512_set1_pd(sl.ra.cos_a1), _CMP_NLE_UQ) & m;
      const __m512d RA = detail::sign_RA_lanes<__m512d>(sl.ra, ca, tb, any_mid);
      const __m512d dx = _mm512_sub_pd(X, vxl), dy = _mm512_sub_pd(Y, lh);
      const __m512d rh = _mm512_sqrt_pd(_mm512_add_pd(sq_pd8(dx), sq_pd8(D)));
      const __m512d d2 = _mm512_add_pd(_mm512_add_pd(sq_pd8(dx), sq_pd8(dy)), sq_pd8(D));
      const __m512d Dh0 = _mm512_mul_pd(D, th0), Dh1 = _mm512_mul_pd(D, th1);
      const __mmask8 glare = _mm512_cmp_pd_mask(dy, _mm512_mul_pd(rh, tvmax), _CMP_GT_OQ) &
                             _mm512_cmp_pd_mask(dx, Dh0, _CMP_GE_OQ) & _mm512_cmp_pd_mask(dx, Dh1, _CMP_LE_OQ);
      const __m512d s = _mm512_add_pd(_mm512_abs_pd(dx), D);
      const __mmask8 beside = _mm512_cmp_pd_mask(_mm512_sub_pd(dx, Dh0), _mm512_mul_pd(lo_margin, s), _CMP_LT_OQ) |
                              _mm512_cmp_pd_mask(_mm512_sub_pd(dx, Dh1), _mm512_mul_pd(hi_margin, s), _CMP_GT_OQ);
      fast &= sl.table ? glare | beside : 0;
      const __m512d lux = _mm512_maskz_div_pd(glare, above, d2);  // (0 where beside)
      L = _mm512_add_pd(L, _mm512_maskz_mul_pd(lit, RA, lux));     // (+0 where the lamp lights its back)
    }
    L = _mm512_maskz_mov_pd(front, L);
    _mm512_mask_storeu_pd(out + i, fast, L);
    for (unsigned rest = m & ~fast; rest; rest &= rest - 1) {
      const int k = i + __builtin_ctz(rest);
      out[k] = scalar(k);
    }
  }
}
#pragma GCC diagnostic pop
// sign_luminances_avx512 on four lanes of AVX2 (beam_max_isa 1, a machine without AVX-512): per
// lane the same IEEE operations in the same order, the masks as all-ones lanes (lux where the
// glare zone holds, +0 elsewhere, as the AVX-512 form's zero-masked quotient); a lane that needs
// anything else, and the row's last n mod 4 sign pixels, are out[i] = scalar(i). So the same bits
// as sign_pos pixel by pixel. (On the Zen 3 host, AVX2 only, the scalar sign pixels took 31 % of
// light_map_with's own samples, its retroreflection rows: docs/benchmarks.md, "Thirtieth session:
// the light map alone".)
template <class Scalar>
__attribute__((target("avx2"))) void sign_luminances_avx2(const SignLight& sl, const double* x, const double* z, int n,
                                                          double cx, double f, double h, double kY, double kD,
                                                          double* out, Scalar&& scalar) {
  const ScenePreset& p = sl.p;
  const __m256d zero = _mm256_setzero_pd(), inf = _mm256_set1_pd(INFINITY), sign = _mm256_set1_pd(-0.0);
  const __m256d one = _mm256_set1_pd(1.0), all = _mm256_castsi256_pd(_mm256_set1_epi64x(-1));
  const __m256d vcx = _mm256_set1_pd(cx), vf = _mm256_set1_pd(f), vh = _mm256_set1_pd(h), vkY = _mm256_set1_pd(kY),
                vkD = _mm256_set1_pd(kD), cam_h = _mm256_set1_pd(sl.cam_h), lh = _mm256_set1_pd(p.beam_lamp_height_m);
  const __m256d tvmax = _mm256_set1_pd(sl.tan_vmax), th0 = _mm256_set1_pd(sl.tan_h0), th1 = _mm256_set1_pd(sl.tan_h1),
                above = _mm256_set1_pd(p.beam_above_cutoff_cd), lo_margin = _mm256_set1_pd(-1e-9),
                hi_margin = _mm256_set1_pd(1e-9);
  const __m256d table = _mm256_castsi256_pd(_mm256_set1_epi64x(sl.table ? -1 : 0));
  const double xls[2] = {-0.5 * p.beam_lamp_spacing_m, 0.5 * p.beam_lamp_spacing_m};
  auto sq = [](__m256d a) __attribute__((target("avx2"), always_inline)) { return _mm256_mul_pd(a, a); };
  const bool entrance = sl.ra.n > 1;
  int i = 0;
  for (; i + 4 <= n; i += 4) {
    const __m256d vz = _mm256_loadu_pd(z + i), vx = _mm256_loadu_pd(x + i);
    __m256d fast = _mm256_and_pd(_mm256_cmp_pd(vz, zero, _CMP_GT_OQ), _mm256_cmp_pd(vz, inf, _CMP_LT_OQ));
    const __m256d X = _mm256_mul_pd(vz, _mm256_div_pd(_mm256_sub_pd(vx, vcx), vf));
    const __m256d Y = _mm256_sub_pd(vh, _mm256_mul_pd(vz, vkY)), D = _mm256_mul_pd(vz, vkD);
    fast = _mm256_and_pd(fast, _mm256_cmp_pd(D, zero, _CMP_GT_OQ));
    // the signs' facing as sign_luminances_avx512's
    __m256d u = zero, v = one, w2 = one, front = all;
    if (sl.facing.curved) {
      detail::sign_facing_lanes<__m256d>(sl.facing, X, D, u, v, w2);
      front = _mm256_cmp_pd(_mm256_add_pd(_mm256_mul_pd(X, u), _mm256_mul_pd(D, v)), zero, _CMP_GT_OQ);
    }
    const __m256d cX = _mm256_xor_pd(X, sign), cY = _mm256_sub_pd(cam_h, Y), cD = _mm256_xor_pd(D, sign);
    const __m256d cn = _mm256_sqrt_pd(_mm256_add_pd(_mm256_add_pd(sq(cX), sq(cY)), sq(cD)));
    __m256d L = zero;
    for (const double xl : xls) {
      const __m256d vxl = _mm256_set1_pd(xl);
      const __m256d lX = _mm256_sub_pd(vxl, X), lY = _mm256_sub_pd(lh, Y), lD = _mm256_xor_pd(D, sign);
      const __m256d ln = _mm256_sqrt_pd(_mm256_add_pd(_mm256_add_pd(sq(lX), sq(lY)), sq(lD)));
      const __m256d ca = _mm256_div_pd(
          _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(cX, lX), _mm256_mul_pd(cY, lY)), _mm256_mul_pd(cD, lD)),
          _mm256_mul_pd(cn, ln));
      // R_A(α, β) as sign_luminances_avx512's
      const __m256d ln_n = _mm256_sub_pd(_mm256_mul_pd(v, D), _mm256_mul_pd(u, lX));
      const __m256d across = _mm256_add_pd(_mm256_mul_pd(v, lX), _mm256_mul_pd(u, D));
      const __m256d lit = _mm256_cmp_pd(ln_n, zero, _CMP_GT_OQ);
      const __m256d tb =
          entrance ? _mm256_div_pd(_mm256_sqrt_pd(_mm256_add_pd(_mm256_mul_pd(w2, sq(lY)), sq(across))), ln_n) : zero;
      const bool any_mid = _mm256_movemask_pd(_mm256_and_pd(_mm256_cmp_pd(ca, _mm256_set1_pd(sl.ra.cos_a0), _CMP_NGE_UQ),
                                                            _mm256_cmp_pd(ca, _mm256_set1_pd(sl.ra.cos_a1), _CMP_NLE_UQ)));
      const __m256d RA = detail::sign_RA_lanes<__m256d>(sl.ra, ca, tb, any_mid);
      const __m256d dx = _mm256_sub_pd(X, vxl), dy = _mm256_sub_pd(Y, lh);
      const __m256d rh = _mm256_sqrt_pd(_mm256_add_pd(sq(dx), sq(D)));
      const __m256d d2 = _mm256_add_pd(_mm256_add_pd(sq(dx), sq(dy)), sq(D));
      const __m256d Dh0 = _mm256_mul_pd(D, th0), Dh1 = _mm256_mul_pd(D, th1);
      const __m256d glare = _mm256_and_pd(
          _mm256_cmp_pd(dy, _mm256_mul_pd(rh, tvmax), _CMP_GT_OQ),
          _mm256_and_pd(_mm256_cmp_pd(dx, Dh0, _CMP_GE_OQ), _mm256_cmp_pd(dx, Dh1, _CMP_LE_OQ)));
      const __m256d s = _mm256_add_pd(_mm256_andnot_pd(sign, dx), D);
      const __m256d beside =
          _mm256_or_pd(_mm256_cmp_pd(_mm256_sub_pd(dx, Dh0), _mm256_mul_pd(lo_margin, s), _CMP_LT_OQ),
                       _mm256_cmp_pd(_mm256_sub_pd(dx, Dh1), _mm256_mul_pd(hi_margin, s), _CMP_GT_OQ));
      fast = _mm256_and_pd(fast, _mm256_and_pd(table, _mm256_or_pd(glare, beside)));
      const __m256d lux = _mm256_and_pd(glare, _mm256_div_pd(above, d2));  // (+0 where beside)
      L = _mm256_add_pd(L, _mm256_and_pd(lit, _mm256_mul_pd(RA, lux)));   // (+0 where it lights the back)
    }
    L = _mm256_and_pd(front, L);
    const int fm = _mm256_movemask_pd(fast);
    if (fm == 0xf) {
      _mm256_storeu_pd(out + i, L);
      continue;
    }
    alignas(32) double l4[4];
    _mm256_store_pd(l4, L);
    for (int k = 0; k < 4; ++k) out[i + k] = fm >> k & 1 ? l4[k] : scalar(i + k);
  }
  _mm256_zeroupper();
  for (; i < n; ++i) out[i] = scalar(i);
}
}  // namespace

double sign_beam_lux(double X_m, double Y_m, double D_m, const ScenePreset& p) {
  // E⊥ = Σ_lamps I(h, v) / d² on the plane perpendicular to each lamp's ray (the illuminance the
  // coefficient of retroreflection R_A is defined on, CIE 54.2 / EN 12899-1), from the headlamp
  // pair at (±spacing/2, lamp_height_m, 0).
  if (!(D_m > 0)) return 0;
  const SignLight s(p, 0);
  const double xl = 0.5 * p.beam_lamp_spacing_m;
  return s.lamp_lux(X_m, Y_m, D_m, -xl) + s.lamp_lux(X_m, Y_m, D_m, xl);
}

double sign_RA_at(double alpha_deg, const ScenePreset& p) {
  const double a = std::clamp(alpha_deg, p.sign_RA_alpha_deg, std::max(p.sign_RA_alpha_deg, p.sign_RA_alpha_max_deg));
  return p.sign_RA * std::pow(a / p.sign_RA_alpha_deg, -p.sign_RA_alpha_exponent);
}

double sign_RA_at(double alpha_deg, double entrance_deg, const ScenePreset& p) {
  // The model of scene/sign_retro_detail.h with libm's log and exp (a reference for the lanes'
  // polynomials): each column's power law, then linear in tan β between the columns.
  const detail::SignRA s(p);
  const double a0 = p.sign_RA_alpha_deg, a1 = std::max(p.sign_RA_alpha_deg, p.sign_RA_alpha_max_deg);
  const double tb = std::tan(entrance_deg * M_PI / 180);
  auto column = [&](int k) {
    if (!s.mid || alpha_deg <= a0) return s.R0[k];
    if (alpha_deg >= a1) return s.R1[k];
    return s.R0[k] * std::exp(-s.K[k] * std::log(alpha_deg / a0));
  };
  double R = column(0);
  for (int k = 1; k < s.n; ++k)
    if (tb > s.t[k - 1]) R = column(k - 1) + (tb - s.t[k - 1]) * ((column(k) - column(k - 1)) * s.inv_dt[k - 1]);
  if (s.n > 1 && tb >= s.t[s.n - 1]) R = column(s.n - 1);
  return R;
}

double sign_retroreflected_cd_m2(double X_m, double Y_m, double D_m, double camera_height_m, const ScenePreset& p) {
  return SignLight(p, camera_height_m).luminance(X_m, Y_m, D_m);
}

double sign_retroreflected_cd_m2(double X_m, double Y_m, double D_m, double camera_height_m, const ScenePreset& p,
                                 const RoadAhead& road) {
  SignLight s(p, camera_height_m);
  s.facing = detail::SignFacing(road, p.sign_read_distance_m);
  return s.luminance(X_m, Y_m, D_m);
}

double sign_facing_heading_rad(const RoadAhead& road, double X_m, double D_m, double read_distance_m) {
  const detail::SignFacing f(road, read_distance_m);
  if (!f.curved) return 0;
  double u, v, w2;
  detail::sign_facing_lanes<double>(f, X_m, D_m, u, v, w2);
  return std::atan2(u, v);
}

float low_beam_lux_f32(double X_m, double D_m, const ScenePreset& p) {
  const BeamF b = beam_f(p);
  const float D = static_cast<float>(D_m);
  if (!b.ok || !(D > 0)) return 0.f;
  return beam_lux_f(static_cast<float>(X_m), D * D, 1.f / D, b);
}

// low_beam_illuminance's set-up (LowBeamRows, scene/night_detail.h): the beam's table, the
// columns' x_n, the classes read and the instruction set.
struct LowBeamRows::Impl {
  const BeamF b;
  const CameraGeometry g;
  const int width, height;
  const ImageU16* labels;
  const std::array<bool, kLabelCount>& read = ground_classes();
  const uint64_t read_mask = label_bits(read);  // ids of kLabelCount and above: not read
  const double c, s;
  std::vector<double> xn;
  bool xn_increasing = true;  // (f_px > 0) beam_sure_span's premise
  const bool avx2 = kHaveAvx2 && beam_isa_cap >= 1, avx512 = kHaveAvx512 && beam_isa_cap >= 2;
  Impl(const CameraGeometry& g_, int w, int h, const ScenePreset& p, const ImageU16* labels_)
      : b(beam_f(p)), g(g_), width(w), height(h), labels(labels_), c(std::cos(g_.pitch_rad)),
        s(std::sin(g_.pitch_rad)), xn(w) {
    for (int x = 0; x < width; ++x) xn[x] = (x - g.cx_px) / g.f_px;
    for (int x = 0; x + 1 < width; ++x) xn_increasing = xn_increasing && xn[x + 1] > xn[x];
  }
  // Row y's ray parameter t, D² and 1/D in float (CameraGeometry::ground_point's expressions in
  // double, then rounded); false at and above the horizon and without a table.
  bool row_ground(int y, double& t, float& D2, float& invD) const {
    const double yn = (y - g.cy_px) / g.f_px, den = yn * c + s;
    t = g.mount_height_m / den;
    const double D = t * (c - yn * s);
    const float Df = static_cast<float>(D);
    if (!b.ok || den <= 0 || !(D > 0) || !(Df > 0)) return false;
    D2 = Df * Df, invD = 1.f / Df;
    return true;
  }
  void row(ImageF& E, int y) const;
};

LowBeamRows::LowBeamRows(const CameraGeometry& g, int width, int height, const ScenePreset& p, const ImageU16* labels)
    : impl_(std::make_unique<Impl>(g, width, height, p, labels)) {}
LowBeamRows::~LowBeamRows() = default;
void LowBeamRows::row(ImageF& E, int y) const { impl_->row(E, y); }
std::pair<int, int> LowBeamRows::sure_columns(int y) const {
  double t;
  float D2, invD;
  if (!impl_->xn_increasing || !impl_->row_ground(y, t, D2, invD)) return {0, 0};
  const BeamSureSpan span = beam_sure_span(impl_->b, impl_->xn.data(), impl_->width, t, D2, -1);
  return {span.lo, span.hi};
}

ImageF low_beam_illuminance(const CameraGeometry& g, int width, int height, const ScenePreset& p,
                            const ImageU16* labels) {
  const LowBeamRows rows(g, width, height, p, labels);
  // Written whole by the rows (zeros where nothing is computed), in parallel: no separate
  // zeroing pass, and each thread touches its own rows first.
  ImageF E(width, height, 1, uninitialized);
#pragma omp parallel for schedule(static, 8)
  for (int y = 0; y < height; ++y) rows.row(E, y);
  return E;
}

// Only the pixels that read it, when the labels are given: the ground classes (compose; and the
// light map's lane markings, which lie on road and parking pixels: lane_markings marks only those,
// lanes_at_frame clears the others). On the flat ground a row is one forward distance D and its ground points are
// X = t·x_n (CameraGeometry::ground_point, whose expressions are repeated here in double: x_n per
// column once, D and t once per row, X = t·x_n per pixel), then the float evaluation
// low_beam_lux_f32 at (X, D), 8 pixels at a time with AVX2, one by one otherwise: the same bits.
// Without a table, zeros: no light (as beam_intensity_cd).
void LowBeamRows::Impl::row(ImageF& E, int y) const {
  float* e = E.row(y);
  double t;
  float D2, invD;
  // At or above the horizon (den <= 0): no ground point.
  if (!row_ground(y, t, D2, invD)) {
    std::fill_n(e, width, 0.f);
    return;
  }
  const uint16_t* id = labels ? labels->row(y) : nullptr;
  if (avx512) return beam_row_avx512(xn.data(), width, t, D2, invD, b, id, read_mask, e);
  if (avx2)
    return beam_row_avx2(xn.data(), width, t, D2, invD, b, id, read_mask, e, -1,
                         xn_increasing ? beam_sure_span(b, xn.data(), width, t, D2, -1) : BeamSureSpan{});
  beam_row_scalar(xn.data(), width, t, D2, invD, b, id, read_mask, e);
}

// (scene/vehicle_facing_detail.h) A going-away vehicle's length, contact (its rear) to its head
// lamps, per class (docs/night.md §7 "Going-away beams"; each a photosite choice [P] of one typical
// vehicle of the class; the class does not tell a vehicle's size):
//   car 4.28 m: the Volkswagen Golf VIII, 4,284 mm (manufacturer's data [U]), a compact
//     (C-segment) car, for years Europe's best-selling model [U], between small cars (~4 m) and
//     large ones (~5 m);
//   truck 12.0 m: a rigid truck at EU Directive 96/53/EC's greatest length of a motor vehicle
//     other than a bus, 12.00 m (Annex I 1.1 [U]), a bound taken as the length; an articulated
//     vehicle (up to 16.50 m) has its lamps up to 4.5 m farther;
//   bus 12.0 m: a standard two-axle city or coach bus, within 96/53/EC's 13.50 m for two axles
//     (as amended by 2002/7/EC [U]);
//   motorcycle 2.1 m: a mid-size road motorcycle (e.g. Honda CB500F, about 2.08 m [U]).
double vehicle_length_m(int cls) {
  if (cls == static_cast<int>(Label::Truck) || cls == static_cast<int>(Label::Bus)) return 12.0;
  if (cls == static_cast<int>(Label::Motorcycle)) return 2.1;
  return 4.28;  // car
}

namespace {
// ---- Vehicles' low beams on the ground (docs/night.md §7, "Oncoming beams" and "Going-away beams")
// A vehicle in traffic (light_map's vehicle states, state 1) of a class with dipped-beam headlamps
// drives along the road with its low beam on. Each of its headlamps, at (X_k, veh_lamp_height_m,
// D_k) in road coordinates (X_k the drawn lamps' positions), is taken as the [ego_beam] table
// (ECE R112 class B, the same regulation as the ego's) aimed along σ·D, σ its direction:
//   oncoming (faces the camera, σ = −1): D_k = D_v, its ground contact's depth (the front it shows);
//   going away (seen from behind, σ = +1): D_k = D_v + its class's length (vehicle_length_m: the
//   contact is its rear, the lamps are at its front, which the camera does not see).
// In that lamp's own frame a ground point (X, 0, D) lies D' = σ·(D − D_k) ahead and σ·(X − X_k) to
// its right (an oncoming lamp's right is the camera's left; a going-away lamp's is the camera's).
// The ego beam's row evaluation gives that exactly: with the columns' x_n times σ (X' = t·(σ·x_n) =
// σ·X, a negation is exact) and the lamp at x' = σ·X_k, its dx = X' − x' = σ·(X − X_k); D' in place
// of the row's D. So E = Σ_lamps I(h, v)·cos θ/d² with the ego beam's float operations
// (low_beam_lux_f32's, the bound of docs/night.md §6c), on the ground pixels ahead of the lamps
// (D' > 0). A going-away vehicle's own pixels hide the ground behind it in the labels: only the
// road the camera sees beside and above it is lit. Not modelled: shadows (what stands between such
// a lamp and the road is not looked for), the lamps' offset from the contact (oncoming) or from the
// front (going away: taken at the class length's front), the vehicle's actual length.
struct VehicleBeam {
  BeamF b;           // the table at the vehicle's lamp height, b.xl = σ·X_k
  double D_m = 0;    // the lamps' depth along the road
  double X_lo = 0, X_hi = 0;  // its lamps' X (the same for a two-wheeler's one lamp)
  int only = -1;     // 0: one lamp (a motorcycle), −1: the pair
  bool away = false; // σ = +1 (going away) if set, −1 (oncoming) otherwise
};
struct VehicleBeamRows {
  const CameraGeometry& g;
  const int W;
  const double c, s;
  std::vector<double> xn[2];  // σ·x_n = σ·(x − c_x)/f per column: [0] σ = −1 (oncoming), [1] σ = +1 (going away)
  const uint64_t read_mask = label_bits(ground_classes());
  const bool avx2 = kHaveAvx2 && beam_isa_cap >= 1, avx512 = kHaveAvx512 && beam_isa_cap >= 2;
  BeamF lamp;     // the [ego_beam] table at the vehicles' lamp height, the lamps' x set per vehicle
  float tint[3];  // the headlamps' colour t_k/π (illuminant_tint at headlamp_cct_K): L_k += f_k·(t_k/π)·E
  std::vector<VehicleBeam> beams;
  VehicleBeamRows(const CameraGeometry& g_, int width, const ScenePreset& p)
      : g(g_), W(width), c(std::cos(g_.pitch_rad)), s(std::sin(g_.pitch_rad)), lamp(beam_f(p)) {
    xn[0].resize(W), xn[1].resize(W);
    for (int x = 0; x < W; ++x) xn[1][x] = (x - g.cx_px) / g.f_px, xn[0][x] = -xn[1][x];
    lamp.hl = static_cast<float>(p.veh_lamp_height_m);
    lamp.hl2 = lamp.hl * lamp.hl;
    const auto t = illuminant_tint(p.headlamp_cct_K);
    for (int k = 0; k < 3; ++k) tint[k] = static_cast<float>(t[k] / M_PI);
  }
  // A vehicle's beam: its lamps at xs (one or two), depth D_k, direction `away`.
  void add(const std::vector<double>& xs, double D_k, bool away) {
    VehicleBeam vb;
    vb.b = lamp;
    const float sg = away ? 1.f : -1.f;
    vb.b.xl[0] = sg * static_cast<float>(xs.front());
    vb.b.xl[1] = sg * static_cast<float>(xs.back());
    vb.D_m = D_k;
    vb.X_lo = std::min(xs.front(), xs.back());
    vb.X_hi = std::max(xs.front(), xs.back());
    vb.only = xs.size() == 1 ? 0 : -1;
    vb.away = away;
    beams.push_back(std::move(vb));
  }
  // Row y of L (3 channels) += texture·tint·E over the ground pixels each beam reaches: the columns
  // whose ground point lies within the table's horizontal range [H₀, H₁] of a lamp
  // (σ·(X − X_k) ∈ [D'·tan H₀, D'·tan H₁]), with a margin of 2 columns (outside it the evaluation
  // gives 0 anyway: the range only spares the work). `e`: W floats of scratch.
  void row(float* Lr, const float* tr, const uint16_t* id, int y, float* e) const {
    if (beams.empty()) return;
    const double yn = (y - g.cy_px) / g.f_px, den = yn * c + s;
    if (den <= 0) return;  // at or above the horizon
    const double t = g.mount_height_m / den, D = t * (c - yn * s);
    if (!(D > 0)) return;
    for (const VehicleBeam& vb : beams) {
      const double Dp = vb.away ? D - vb.D_m : vb.D_m - D;
      const float Df = static_cast<float>(Dp);
      if (!vb.b.ok || !(Df > 0)) continue;
      const double X0 = vb.away ? vb.X_lo + Dp * vb.b.th0 : vb.X_lo - Dp * vb.b.th1;  // the reached ground X
      const double X1 = vb.away ? vb.X_hi + Dp * vb.b.th1 : vb.X_hi - Dp * vb.b.th0;
      const double k = g.f_px / t;                                     // columns per metre of X
      const double xa = std::floor(g.cx_px + X0 * k) - 2, xb = std::ceil(g.cx_px + X1 * k) + 3;
      const int x0 = static_cast<int>(std::clamp(xa, 0.0, static_cast<double>(W)));
      const int x1 = static_cast<int>(std::clamp(xb, 0.0, static_cast<double>(W)));
      if (x1 <= x0) continue;
      const float D2 = Df * Df, invD = 1.f / Df;
      const int n = x1 - x0;
      const double* sx = xn[vb.away].data() + x0;
      if (avx512) beam_row_avx512(sx, n, t, D2, invD, vb.b, id + x0, read_mask, e + x0, vb.only);
      else if (avx2) beam_row_avx2(sx, n, t, D2, invD, vb.b, id + x0, read_mask, e + x0, vb.only);
      else beam_row_scalar(sx, n, t, D2, invD, vb.b, id + x0, read_mask, e + x0, vb.only);
      for (int x = x0; x < x1; ++x) {
        const float E = e[x];
        if (!(E > 0.f)) continue;
        float* l = Lr + 3 * static_cast<size_t>(x);
        const float* f = tr + 3 * static_cast<size_t>(x);
        for (int q = 0; q < 3; ++q) l[q] += f[q] * (tint[q] * E);
      }
    }
  }
};
}  // namespace

namespace {
// ---- Shadows of the low beam (docs/night.md §6c, "Shadows of the low beam") ----------------------
// A shadow map per lamp, built from the metric scene: the lamp at L = (x_l, h_l, 0) looks along
// the road (the camera's forward direction D, no pitch); a point P = (X, Y, D) ahead of it is seen
// at u = (X − x_l)/D, v = (h_l − Y)/D, and every point of the ray from L through P has the same
// (u, v) and a larger D the farther along it lies. Each pixel of a solid class (the classes the
// beam lights as vertical surfaces, with a finite metric depth) is splatted at its point's (u, v)
// into a grid of cells, keeping the least D per cell; a lit ground pixel whose point lies beyond
// the least D of its cell (by the margin below) is in that lamp's shadow. A ray from the lamp to the
// ground never rises above h_l, so only solid points below the lamp's height (v > 0) can shade
// the ground, and only they are splatted.
// The cell is kBeamShadowCellPx image pixels wide and high in (u, v) (a photosite choice): a
// surface that keeps its depth maps into the lamp's view at the camera's own scale, shifted by
// the parallax (x_l/D, (h − h_l)/D), so one sample per image pixel fills every cell a surface
// covers as long as its parallax varies by less than a cell between neighbouring pixels; a
// shadow's edge is placed to within one cell (the cell takes the least D of every point in it).
// A ground point is shaded only by a solid point nearer than the ground one cell nearer in the
// lamp's view, 1/D_Q > 1/D_P + cell/h_l (v of the ground is h_l/D): without that margin the foot
// of a wall or a car's side that runs along the road, whose points share cells with the ground
// beside it at about the same D, would shade a strip one cell wide along it. The margin excludes
// such a foot (its points in P's cell have 1/D_Q ≤ 1/D_P + cell/|X − x_l| and |X − x_l| > h_l for a
// surface farther from the lamp sideways than the lamp's height) and costs the shadow one cell
// at its near end, behind the occluder's foot, where the camera (above the lamp) sees no ground
// behind an occluder that is not much lower than itself.
constexpr int kBeamShadowCellPx = 2;
constexpr int kBeamShadowBlock = 16;
// The cell of a lamp's shadow maps: `cell` (kBeamShadowCellPx pixels' angle), doubled until each of
// the two maps holds at most 4 cells per frame pixel, at least 2^20 (16 bytes a pixel, 4 MB for a
// small frame); cells(k, c) is map k's count at cell c. A map spans the frame's directions widened by
// the lamps' parallax at kBeamShadowNear_m (ground: the rows' whole range); at kBeamShadowCellPx
// pixels that is some 10^5 × 10^3 cells for a long lens (a rig's fx_px up to 10^6: a 0.1° field of
// view, a lamp's 0.7 m offset 20° wide at 2 m), more than memory holds (the rig-corner runs of
// docs/robustness.md stopped "out of memory"). Such a frame's shadows are then coarser than 2 px (a
// photosite choice, to degrade, not stop); no rig of the data sets comes near the bound (the bench
// frame's maps: a few 10^5 cells), where the cell is returned as given.
template <class Cells>
double beam_shadow_cell(double cell, int W, int H, const Cells& cells) {
  const double max_cells =
      static_cast<double>(std::max<size_t>(size_t{1} << 20, 4 * static_cast<size_t>(W) * static_cast<size_t>(H)));
  while (!(std::max(cells(0, cell), cells(1, cell)) <= max_cells)) cell *= 2;
  return cell;
}
// The map's rows (cells of one v) are written +∞ only when a point first falls in them, and the
// map ends after its last row that holds a point (fill_shadow_maps): the points of a frame take a
// band of v near the lamps' height (on the bench frame rows 0-43 of the ground's 163 and of the
// vertical surfaces' 304; a solid point far below the lamp is a near one), so the rest is neither
// written nor read. A point that falls beyond the last row finds no point there, as it would in
// a map of the full extent: the same shadows.
struct LampShadowMap {
  float xl = 0, u_lo = 0, inv_cell = 0, v_lo = 0;  // v_lo: 0 for the ground's maps (v > 0 only)
  int nu = 0, nv = 0, nb = 0;
  std::unique_ptr<float[]> Dmin;  // nv × nu, +∞ where no solid point lies (a row once written)
  std::vector<uint8_t> written;   // per row: +∞ (and its points) written
  std::vector<float> Bmin;  // nv × nb: the least Dmin of each block of kBeamShadowBlock cells in a row
  // The extent (nu × nv cells) the points are placed over, before any is; the cells not written.
  void allocate(int nu_, int nv_) {
    nu = nu_, nv = nv_;
    Dmin.reset(new float[static_cast<size_t>(nu) * nv]);
    written.assign(nv, 0);
  }
  [[gnu::always_inline]] bool cell_at(float u, float v, int* iv, int* iu) const {
    const float cu = (u - u_lo) * inv_cell, cv = (v - v_lo) * inv_cell;
    if (!(cu >= 0 && cu < static_cast<float>(nu) && cv >= 0 && cv < static_cast<float>(nv))) return false;
    *iv = static_cast<int>(cv), *iu = static_cast<int>(cu);
    return true;
  }
  [[gnu::always_inline]] int cell(float u, float v) const {
    int iv, iu;
    return cell_at(u, v, &iv, &iu) ? iv * nu + iu : -1;
  }
  float* row(int iv) { return Dmin.get() + static_cast<size_t>(iv) * nu; }
  const float* row(int iv) const { return Dmin.get() + static_cast<size_t>(iv) * nu; }
  // Keeps D in cell (iv, iu) if it is the least there.
  [[gnu::always_inline]] void place(int iv, int iu, float D) {
    float* r = row(iv);
    if (!written[iv]) [[unlikely]] {
      std::fill_n(r, nu, INFINITY);
      written[iv] = 1;
    }
    r[iu] = std::min(r[iu], D);
  }
};
// Fills both lamps' maps (allocated) with the solid points of every row: row(y, maps, cols) places
// row y's points into `maps` (LampShadowMap::place; cols: a scratch of W ints). Where there are
// two threads, each takes every other chunk of 32 rows, the second into its own maps, then the
// least of the two per cell, lamp 0's map merged on one thread and lamp 1's on the other: the
// least D of a cell does not depend on the order the points come in, so the same maps for any
// thread count. (The ground's maps and the vertical surfaces' are filled so.) Inside another
// parallel region (night_scene's depth stage makes both maps on one of its two threads) the
// team has one thread, OpenMP's nested regions being inactive by default: the chunks follow the
// team the region got, not the one asked for. Then each map ends after its last written row
// (both lamps' maps after the later of the two where `same_rows`), the rows before it not
// written made +∞.
template <class RowFn>
void fill_shadow_maps(std::array<LampShadowMap, 2>& maps, int W, int H, bool same_rows, RowFn&& row) {
  const int asked = omp_in_parallel() ? 1 : std::min(2, omp_get_max_threads());
  std::array<LampShadowMap, 2> maps2;
  if (asked > 1)
    for (int k = 0; k < 2; ++k) {
      LampShadowMap& m2 = maps2[k];
      m2.xl = maps[k].xl, m2.u_lo = maps[k].u_lo, m2.inv_cell = maps[k].inv_cell, m2.v_lo = maps[k].v_lo;
      m2.allocate(maps[k].nu, maps[k].nv);
    }
  int end[2] = {0, 0};
#pragma omp parallel num_threads(asked)
  {
    const int team = omp_get_thread_num(), teams = omp_get_num_threads();
    std::array<LampShadowMap, 2>& mt = team == 0 ? maps : maps2;
    std::vector<int> cols(W);
    constexpr int kChunk = 32;
    for (int y0 = team * kChunk; y0 < H; y0 += teams * kChunk)
      for (int y = y0; y < std::min(H, y0 + kChunk); ++y) row(y, mt, cols.data());
    if (teams > 1) {
#pragma omp barrier
    }
    // Lamp k's map on thread k (both on thread 0 where the team has one).
    for (int k = team; k < 2; k += teams) {
      LampShadowMap& m = maps[k];
      for (int iv = 0; iv < m.nv; ++iv) {
        if (teams > 1 && maps2[k].written[iv]) {
          const float* d2 = maps2[k].row(iv);
          float* d = m.row(iv);
          if (m.written[iv])
            for (int c = 0; c < m.nu; ++c) d[c] = std::min(d[c], d2[c]);
          else
            std::copy_n(d2, m.nu, d);
          m.written[iv] = 1;
        }
        if (m.written[iv]) end[k] = iv + 1;
      }
    }
  }
  for (int k = 0; k < 2; ++k) {
    LampShadowMap& m = maps[k];
    m.nv = same_rows ? std::max(end[0], end[1]) : end[k];
    for (int iv = 0; iv < m.nv; ++iv)
      if (!m.written[iv]) std::fill_n(m.row(iv), m.nu, INFINITY), m.written[iv] = 1;
  }
}
// The columns of a label row whose class is in `solid` (bits by class id, ids below 64), in
// order, into out; returns their count. The AVX2 twin tests eight labels at a time (a lane's
// bit by variable shifts: a shift by 32 or more gives 0), the same columns.
int solid_columns(const uint16_t* id, int W, uint64_t solid, int* out) {
  int n = 0;
  for (int x = 0; x < W; ++x)
    if (id[x] < 64 && (solid >> id[x] & 1)) out[n++] = x;
  return n;
}
__attribute__((target("avx2"))) int solid_columns_avx2(const uint16_t* id, int W, uint64_t solid, int* out) {
  const __m256i mlo = _mm256_set1_epi32(static_cast<int32_t>(solid & 0xffffffffu)),
                mhi = _mm256_set1_epi32(static_cast<int32_t>(solid >> 32)), k32 = _mm256_set1_epi32(32),
                one = _mm256_set1_epi32(1);
  int n = 0, x = 0;
  for (; x + 8 <= W; x += 8) {
    const __m256i k = _mm256_cvtepu16_epi32(_mm_loadu_si128(reinterpret_cast<const __m128i*>(id + x)));
    const __m256i bit = _mm256_and_si256(
        _mm256_or_si256(_mm256_srlv_epi32(mlo, k), _mm256_srlv_epi32(mhi, _mm256_sub_epi32(k, k32))), one);
    unsigned m = static_cast<unsigned>(_mm256_movemask_ps(_mm256_castsi256_ps(_mm256_cmpeq_epi32(bit, one))));
    while (m) {
      out[n++] = x + __builtin_ctz(m);
      m &= m - 1;
    }
  }
  for (; x < W; ++x)
    if (id[x] < 64 && (solid >> id[x] & 1)) out[n++] = x;
  return n;
}
// The lanes of m, in order, to p (sixteen values stored: p needs room for 16; a compress in a
// register then a plain store, as the compressing store is slow on some cores, Zen 4's).
__attribute__((target("avx512f"))) inline void compress_store_ps(float* p, __mmask16 m, __m512 v) {
  _mm512_storeu_ps(p, _mm512_maskz_compress_ps(m, v));
}
__attribute__((target("avx512f"))) inline void compress_store_epi32(int32_t* p, __mmask16 m, __m512i v) {
  _mm512_storeu_si512(p, _mm512_maskz_compress_epi32(m, v));
}
// Lane i: x + i (the columns of a sixteen-lane step).
__attribute__((target("avx512f"))) inline __m512i columns16(int x) {
  return _mm512_add_epi32(_mm512_set1_epi32(x), _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15));
}
// The columns x0 .. x1 − 1 whose e > 0, in order, into out; returns their count. The AVX2 twin
// tests eight at a time, the AVX-512 twin sixteen (out needs room for 16 past the count).
int positive_columns(const float* e, int x0, int x1, int* out) {
  int n = 0;
  for (int x = x0; x < x1; ++x)
    if (e[x] > 0) out[n++] = x;
  return n;
}
__attribute__((target("avx2"))) int positive_columns_avx2(const float* e, int x0, int x1, int* out) {
  int n = 0, x = x0;
  for (; x + 8 <= x1; x += 8)
    for (unsigned m = static_cast<unsigned>(_mm256_movemask_ps(_mm256_cmp_ps(_mm256_loadu_ps(e + x), _mm256_setzero_ps(), _CMP_GT_OQ))); m; m &= m - 1)
      out[n++] = x + __builtin_ctz(m);
  for (; x < x1; ++x)
    if (e[x] > 0) out[n++] = x;
  return n;
}
__attribute__((target("avx512f,avx512bw,avx512vl,avx512dq"))) int positive_columns_avx512(const float* e, int x0,
                                                                                           int x1, int* out) {
  int n = 0;
  for (int x = x0; x < x1; x += 16) {
    const __mmask16 lanes = x1 - x >= 16 ? static_cast<__mmask16>(0xffff) : static_cast<__mmask16>((1u << (x1 - x)) - 1);
    const __mmask16 pos = _mm512_mask_cmp_ps_mask(lanes, _mm512_maskz_loadu_ps(lanes, e + x), _mm512_setzero_ps(), _CMP_GT_OQ);
    compress_store_epi32(out + n, pos, columns16(x));
    n += __builtin_popcount(pos);
  }
  return n;
}
// A row's solid points into both lamps' maps sixteen columns at a time (AVX-512; the last columns
// by a masked load): the scalar fills' operations on each lane (the ground's when kGround, else
// the vertical surfaces'), their tests as lane masks, then each point that a map takes placed as
// the scalar fill places it: the same maps. Most solid points of a row are not placed (above the
// lamps' height: nearer than (h − h_l)/k_Y on the row), and are dropped here sixteen at a time.
template <bool kGround>
__attribute__((target("avx512f,avx512bw,avx512vl,avx512dq"))) void place_row_avx512(
    const uint16_t* id, const float* z, const float* xn, int W, uint64_t solid, float kD, float kY, float h,
    const BeamF& b, std::array<LampShadowMap, 2>& mt) {
  const __m512i mlo = _mm512_set1_epi32(static_cast<int32_t>(solid & 0xffffffffu)),
                mhi = _mm512_set1_epi32(static_cast<int32_t>(solid >> 32)), one = _mm512_set1_epi32(1),
                k32 = _mm512_set1_epi32(32);
  const __m512 zero = _mm512_setzero_ps(), zinf = _mm512_set1_ps(kDepthInfinity_m), vkD = _mm512_set1_ps(kD),
               vkY = _mm512_set1_ps(kY), vh = _mm512_set1_ps(h), vhl = _mm512_set1_ps(b.hl), fone = _mm512_set1_ps(1.f),
               sign = _mm512_set1_ps(-0.f), tv2 = _mm512_set1_ps(b.tvmax2);
  const bool t_pos = b.tvmax >= 0;
  alignas(64) int32_t iv[2][16], iu[2][16];
  alignas(64) float Ds[16];
  for (int x = 0; x < W; x += 16) {
    const __mmask16 lanes = W - x >= 16 ? static_cast<__mmask16>(0xffff) : static_cast<__mmask16>((1u << (W - x)) - 1);
    const __m512i k = _mm512_cvtepu16_epi32(_mm256_maskz_loadu_epi16(lanes, id + x));
    // The class bit (0 for ids of 64 and above: both shifts by 32 or more give 0).
    const __m512i bit = _mm512_and_si512(
        _mm512_or_si512(_mm512_srlv_epi32(mlo, k), _mm512_srlv_epi32(mhi, _mm512_sub_epi32(k, k32))), one);
    __mmask16 m = lanes & _mm512_test_epi32_mask(bit, bit);
    if (!m) continue;
    const __m512 zz = _mm512_maskz_loadu_ps(m, z + x);
    m &= _mm512_cmp_ps_mask(zz, zero, _CMP_GT_OQ) & _mm512_cmp_ps_mask(zz, zinf, _CMP_LT_OQ);
    const __m512 D = _mm512_mul_ps(zz, vkD), Y = _mm512_sub_ps(vh, _mm512_mul_ps(zz, vkY));
    m &= _mm512_cmp_ps_mask(D, zero, _CMP_GT_OQ);
    // The ground's dv = h_l − Y > 0 (v = dv/D), the vertical surfaces' dy = Y − h_l (v = −dy/D).
    const __m512 dv = kGround ? _mm512_sub_ps(vhl, Y) : _mm512_xor_ps(_mm512_sub_ps(Y, vhl), sign);
    if (kGround) m &= _mm512_cmp_ps_mask(dv, zero, _CMP_GT_OQ);
    if (!m) continue;
    const __m512 invD = _mm512_div_ps(fone, D), X = _mm512_mul_ps(zz, _mm512_maskz_loadu_ps(lanes, xn + x));
    const __m512 v = _mm512_mul_ps(dv, invD);
    __mmask16 put[2];
    for (int l = 0; l < 2; ++l) {
      const LampShadowMap& mp = mt[l];
      const __m512 dx = _mm512_sub_ps(X, _mm512_set1_ps(mp.xl));
      const __m512 cu = _mm512_mul_ps(_mm512_sub_ps(_mm512_mul_ps(dx, invD), _mm512_set1_ps(mp.u_lo)),
                                      _mm512_set1_ps(mp.inv_cell));
      const __m512 cv = _mm512_mul_ps(_mm512_sub_ps(v, _mm512_set1_ps(mp.v_lo)), _mm512_set1_ps(mp.inv_cell));
      put[l] = m & _mm512_cmp_ps_mask(cu, zero, _CMP_GE_OQ) &
               _mm512_cmp_ps_mask(cu, _mm512_set1_ps(static_cast<float>(mp.nu)), _CMP_LT_OQ) &
               _mm512_cmp_ps_mask(cv, zero, _CMP_GE_OQ) &
               _mm512_cmp_ps_mask(cv, _mm512_set1_ps(static_cast<float>(mp.nv)), _CMP_LT_OQ);
      if (!kGround && put[l]) {
        // beam_above_top(dy, dx² + D², b): dy > 0 and dy² > (dx² + D²)·t² (t ≥ 0), else dy > 0 or dy² < that.
        const __m512 dy = _mm512_xor_ps(dv, sign), q = _mm512_mul_ps(dy, dy);
        const __m512 r = _mm512_mul_ps(_mm512_add_ps(_mm512_mul_ps(dx, dx), _mm512_mul_ps(D, D)), tv2);
        const __mmask16 dy_pos = _mm512_cmp_ps_mask(dy, zero, _CMP_GT_OQ);
        const __mmask16 top = t_pos ? dy_pos & _mm512_cmp_ps_mask(q, r, _CMP_GT_OQ)
                                    : dy_pos | _mm512_cmp_ps_mask(q, r, _CMP_LT_OQ);
        put[l] &= ~top;
      }
      if (put[l]) {
        const __m512i jv = _mm512_cvttps_epi32(cv), ju = _mm512_cvttps_epi32(cu);
        _mm512_store_si512(iv[l], jv);
        _mm512_store_si512(iu[l], ju);
        // A lane whose right neighbour falls in the same cell with a D no larger leaves the
        // cell's least D to it (along a run of lanes in one cell a least D is always kept: the
        // same maps); neighbouring columns share a 2-pixel cell about every other time.
        const __m512i cidx = _mm512_add_epi32(_mm512_mullo_epi32(jv, _mm512_set1_epi32(mp.nu)), ju);
        const __mmask16 same = _mm512_cmpeq_epi32_mask(cidx, _mm512_alignr_epi32(cidx, cidx, 1)) &
                               _mm512_cmp_ps_mask(D, _mm512_castsi512_ps(_mm512_alignr_epi32(
                                                         _mm512_castps_si512(D), _mm512_castps_si512(D), 1)),
                                                  _CMP_GE_OQ);
        put[l] &= static_cast<__mmask16>(~(same & (put[l] >> 1)));
      }
    }
    if (!(put[0] | put[1])) continue;
    _mm512_store_ps(Ds, D);
    for (int l = 0; l < 2; ++l)
      for (unsigned r = put[l]; r; r &= r - 1) {
        const int i = __builtin_ctz(r);
        mt[l].place(iv[l][i], iu[l][i], Ds[i]);
      }
  }
}
// place_row_avx512's operations on eight lanes (AVX2: a Zen 3 or an older Intel, or
// PHOTOSITE_MAX_ISA=avx2), lane masks as all-ones lanes; the last columns (under eight) by masked
// loads of z and x_n and the labels copied with the lanes beyond the row of no class. The same
// tests on each lane, the same points placed (a lane leaving its cell's least D to its right
// neighbour as there): the same maps.
template <bool kGround>
__attribute__((target("avx2"))) void place_row_avx2(const uint16_t* id, const float* z, const float* xn, int W,
                                                    uint64_t solid, float kD, float kY, float h, const BeamF& b,
                                                    std::array<LampShadowMap, 2>& mt) {
  const __m256i mlo = _mm256_set1_epi32(static_cast<int32_t>(solid & 0xffffffffu)),
                mhi = _mm256_set1_epi32(static_cast<int32_t>(solid >> 32)), one = _mm256_set1_epi32(1),
                k32 = _mm256_set1_epi32(32), lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7),
                next = _mm256_setr_epi32(1, 2, 3, 4, 5, 6, 7, 7);  // lane i: lane i + 1's (the last: its own)
  const __m256 zero = _mm256_setzero_ps(), zinf = _mm256_set1_ps(kDepthInfinity_m), vkD = _mm256_set1_ps(kD),
               vkY = _mm256_set1_ps(kY), vh = _mm256_set1_ps(h), vhl = _mm256_set1_ps(b.hl), fone = _mm256_set1_ps(1.f),
               sign = _mm256_set1_ps(-0.f), tv2 = _mm256_set1_ps(b.tvmax2);
  const bool t_pos = b.tvmax >= 0;
  alignas(32) int32_t iv[2][8], iu[2][8];
  alignas(32) float Ds[8];
  for (int x = 0; x < W; x += 8) {
    const bool full = W - x >= 8;
    const __m256i lanes = _mm256_cmpgt_epi32(_mm256_set1_epi32(W - x), lane);
    __m256i k;
    if (full) {
      k = _mm256_cvtepu16_epi32(_mm_loadu_si128(reinterpret_cast<const __m128i*>(id + x)));
    } else {
      alignas(16) uint16_t t[8] = {0xffff, 0xffff, 0xffff, 0xffff, 0xffff, 0xffff, 0xffff, 0xffff};  // of no class
      std::copy_n(id + x, W - x, t);
      k = _mm256_cvtepu16_epi32(_mm_load_si128(reinterpret_cast<const __m128i*>(t)));
    }
    // The class bit (0 for ids of 64 and above: both shifts by 32 or more give 0).
    const __m256i bit = _mm256_and_si256(
        _mm256_or_si256(_mm256_srlv_epi32(mlo, k), _mm256_srlv_epi32(mhi, _mm256_sub_epi32(k, k32))), one);
    __m256 m = _mm256_castsi256_ps(_mm256_cmpeq_epi32(bit, one));
    if (!_mm256_movemask_ps(m)) continue;
    const __m256 zz = full ? _mm256_loadu_ps(z + x) : _mm256_maskload_ps(z + x, lanes);
    m = _mm256_and_ps(m, _mm256_and_ps(_mm256_cmp_ps(zz, zero, _CMP_GT_OQ), _mm256_cmp_ps(zz, zinf, _CMP_LT_OQ)));
    const __m256 D = _mm256_mul_ps(zz, vkD), Y = _mm256_sub_ps(vh, _mm256_mul_ps(zz, vkY));
    m = _mm256_and_ps(m, _mm256_cmp_ps(D, zero, _CMP_GT_OQ));
    // The ground's dv = h_l − Y > 0 (v = dv/D), the vertical surfaces' dy = Y − h_l (v = −dy/D).
    const __m256 dv = kGround ? _mm256_sub_ps(vhl, Y) : _mm256_xor_ps(_mm256_sub_ps(Y, vhl), sign);
    if (kGround) m = _mm256_and_ps(m, _mm256_cmp_ps(dv, zero, _CMP_GT_OQ));
    if (!_mm256_movemask_ps(m)) continue;
    const __m256 invD = _mm256_div_ps(fone, D),
                 X = _mm256_mul_ps(zz, full ? _mm256_loadu_ps(xn + x) : _mm256_maskload_ps(xn + x, lanes));
    const __m256 v = _mm256_mul_ps(dv, invD);
    unsigned put[2];
    for (int l = 0; l < 2; ++l) {
      const LampShadowMap& mp = mt[l];
      const __m256 dx = _mm256_sub_ps(X, _mm256_set1_ps(mp.xl));
      const __m256 cu = _mm256_mul_ps(_mm256_sub_ps(_mm256_mul_ps(dx, invD), _mm256_set1_ps(mp.u_lo)),
                                      _mm256_set1_ps(mp.inv_cell));
      const __m256 cv = _mm256_mul_ps(_mm256_sub_ps(v, _mm256_set1_ps(mp.v_lo)), _mm256_set1_ps(mp.inv_cell));
      __m256 pm = _mm256_and_ps(
          _mm256_and_ps(m, _mm256_and_ps(_mm256_cmp_ps(cu, zero, _CMP_GE_OQ),
                                         _mm256_cmp_ps(cu, _mm256_set1_ps(static_cast<float>(mp.nu)), _CMP_LT_OQ))),
          _mm256_and_ps(_mm256_cmp_ps(cv, zero, _CMP_GE_OQ),
                        _mm256_cmp_ps(cv, _mm256_set1_ps(static_cast<float>(mp.nv)), _CMP_LT_OQ)));
      if (!kGround && _mm256_movemask_ps(pm)) {
        // beam_above_top(dy, dx² + D², b), as place_row_avx512.
        const __m256 dy = _mm256_xor_ps(dv, sign), q = _mm256_mul_ps(dy, dy);
        const __m256 r = _mm256_mul_ps(_mm256_add_ps(_mm256_mul_ps(dx, dx), _mm256_mul_ps(D, D)), tv2);
        const __m256 dy_pos = _mm256_cmp_ps(dy, zero, _CMP_GT_OQ);
        const __m256 top = t_pos ? _mm256_and_ps(dy_pos, _mm256_cmp_ps(q, r, _CMP_GT_OQ))
                                 : _mm256_or_ps(dy_pos, _mm256_cmp_ps(q, r, _CMP_LT_OQ));
        pm = _mm256_andnot_ps(top, pm);
      }
      put[l] = static_cast<unsigned>(_mm256_movemask_ps(pm));
      if (put[l]) {
        const __m256i jv = _mm256_cvttps_epi32(cv), ju = _mm256_cvttps_epi32(cu);
        _mm256_store_si256(reinterpret_cast<__m256i*>(iv[l]), jv);
        _mm256_store_si256(reinterpret_cast<__m256i*>(iu[l]), ju);
        // A lane whose right neighbour falls in the same cell with a D no larger leaves the cell's
        // least D to it (place_row_avx512's; the last lane compares with itself and is kept).
        const __m256i cidx = _mm256_add_epi32(_mm256_mullo_epi32(jv, _mm256_set1_epi32(mp.nu)), ju);
        const unsigned same = static_cast<unsigned>(_mm256_movemask_ps(_mm256_and_ps(
            _mm256_castsi256_ps(_mm256_cmpeq_epi32(cidx, _mm256_permutevar8x32_epi32(cidx, next))),
            _mm256_cmp_ps(D, _mm256_permutevar8x32_ps(D, next), _CMP_GE_OQ))));
        put[l] &= ~(same & (put[l] >> 1));
      }
    }
    if (!(put[0] | put[1])) continue;
    _mm256_store_ps(Ds, D);
    for (int l = 0; l < 2; ++l)
      for (unsigned r = put[l]; r; r &= r - 1) {
        const int i = __builtin_ctz(r);
        mt[l].place(iv[l][i], iu[l][i], Ds[i]);
      }
  }
}
}  // namespace

BeamShadowStats shade_low_beam_ground(ImageF& beam_lux, const CameraGeometry& g, const ImageU16& labels,
                                      const ImageF& depth_m, const ScenePreset& p) {
  return shade_low_beam_ground_with(beam_lux, g, labels, depth_m, p, nullptr);
}

// The ground's shadow maps (shade_low_beam_ground_with's first step): the beam's table, the
// ground rows' t and D, each lamp's map of the solid points and its blocks' least D.
struct GroundShadowMaps::Impl {
  const BeamF b;
  const ImageU16& labels;
  const int W, H;
  std::vector<double> xn;
  struct Row { double t = 0, D = 0; };
  std::vector<Row> rows;
  double cell = 0;
  std::array<LampShadowMap, 2> maps;
  bool made = false;  // the maps made (a table, a frame with ground below the horizon)
  Impl(int width, int height, const CameraGeometry& g, const ImageU16& labels_, const ImageF& depth_m,
       const ScenePreset& p, const LabelRuns* runs);
};

GroundShadowMaps::Impl::Impl(int width, int height, const CameraGeometry& g, const ImageU16& labels_,
                             const ImageF& depth_m, const ScenePreset& p, const LabelRuns* runs)
    : b(beam_f(p)), labels(labels_), W(width), H(height) {
  if (!b.ok) return;
  if (labels.width() != W || labels.height() != H || depth_m.width() != W || depth_m.height() != H)
    fail("low beam shadows: the beam, labels and depth differ in size");
  if (W == 0 || H == 0) return;
  const double c = std::cos(g.pitch_rad), s = std::sin(g.pitch_rad);
  xn.resize(W);
  std::vector<float> xnf(W);
  for (int x = 0; x < W; ++x) xnf[x] = static_cast<float>(xn[x] = (x - g.cx_px) / g.f_px);
  // The ground rows' t and D (low_beam_illuminance's expressions), and each lamp's map over the
  // (u, v) the ground pixels of the frame take: a solid point outside it shades no ground pixel.
  rows.resize(H);
  cell = kBeamShadowCellPx / g.f_px;
  double u_lo[2] = {INFINITY, INFINITY}, u_hi[2] = {-INFINITY, -INFINITY}, v_hi = 0;
  for (int y = 0; y < H; ++y) {
    const double yn = (y - g.cy_px) / g.f_px, den = yn * c + s;
    const double t = g.mount_height_m / den, D = t * (c - yn * s);
    if (den <= 0 || !(D > 0) || !(static_cast<float>(D) > 0)) continue;
    rows[y] = {t, D};
    v_hi = std::max(v_hi, b.hl / D);
    for (int k = 0; k < 2; ++k) {
      u_lo[k] = std::min(u_lo[k], (t * xn[0] - b.xl[k]) / D);
      u_hi[k] = std::max(u_hi[k], (t * xn[W - 1] - b.xl[k]) / D);
    }
  }
  if (!(v_hi > 0)) return;  // no ground below the horizon
  // Each map's cells at cell size cl (the allocation's below), the cell bounded by them.
  cell = beam_shadow_cell(cell, W, H, [&](int k, double cl) {
    return (std::ceil((u_hi[k] - u_lo[k]) / cl) + 3) * (std::ceil(v_hi / cl) + 2);
  });
  for (int k = 0; k < 2; ++k) {
    LampShadowMap& m = maps[k];
    m.xl = b.xl[k];
    m.u_lo = static_cast<float>(u_lo[k] - cell);  // a cell of margin on each side: the floats' rounding
    m.inv_cell = static_cast<float>(1 / cell);
    m.allocate(static_cast<int>(std::ceil((u_hi[k] - u_lo[k]) / cell)) + 3, static_cast<int>(std::ceil(v_hi / cell)) + 2);
  }
  // The solid points, both lamps' maps in one pass (fill_shadow_maps: the same maps for any
  // thread count; both lamps' maps end after the same row, as the ground's rows read them). A
  // point's X = z·x_n, D = z·kD, Y = h − z·kY (the camera model's, as the vertical surfaces' rows).
  const uint64_t solid = label_bits(beam_vertical_classes());
  const float h = static_cast<float>(g.mount_height_m);
  const bool with_runs = runs && runs->made_of(labels), avx512 = kHaveAvx512 && beam_isa_cap >= 2,
             avx2 = kHaveAvx2 && beam_isa_cap >= 1;
  fill_shadow_maps(maps, W, H, true, [&](int y, std::array<LampShadowMap, 2>& mt, int* cols) {
    const double yn = (y - g.cy_px) / g.f_px;
    const float kD = static_cast<float>(c - yn * s), kY = static_cast<float>(s + yn * c);
    // Y < h_l needs z·kY > h − h_l: none in a row at or above the horizon when the camera is
    // above the lamps.
    if (h > b.hl && !(kY > 0)) return;
    const float* z = depth_m.row(y);
    if (avx512) return place_row_avx512<true>(labels.row(y), z, xnf.data(), W, solid, kD, kY, h, b, mt);
    if (avx2) return place_row_avx2<true>(labels.row(y), z, xnf.data(), W, solid, kD, kY, h, b, mt);
    // The row's solid columns: from the label runs where they are at hand (the chain's, made
    // beside the Hough stage), else by testing every label.
    int n = 0;
    if (with_runs) {
      for (int i = runs->row_start[y]; i < runs->row_start[y + 1]; ++i)
        if (runs->id[i] < 64 && (solid >> runs->id[i] & 1))
          for (int x = runs->x0[i], xe = runs->end(i, y); x < xe; ++x) cols[n++] = x;
    } else {
      n = (kHaveAvx2 ? solid_columns_avx2 : solid_columns)(labels.row(y), W, solid, cols);
    }
    for (int j = 0; j < n; ++j) {
      const int x = cols[j];
      const float zz = z[x];
      if (!(zz > 0) || !(zz < kDepthInfinity_m)) continue;
      const float D = zz * kD, dv = b.hl - (h - zz * kY);
      if (!(D > 0) || !(dv > 0)) continue;
      const float invD = 1.f / D, X = zz * xnf[x], v = dv * invD;
      for (LampShadowMap& m : mt) {
        int iv, iu;
        if (m.cell_at((X - m.xl) * invD, v, &iv, &iu)) m.place(iv, iu, D);
      }
    }
  });
  // Each map row's blocks of kBeamShadowBlock cells: their least D (the rows below skip a block
  // that holds no point near enough).
  for (LampShadowMap& m : maps) {
    m.nb = (m.nu + kBeamShadowBlock - 1) / kBeamShadowBlock;
    m.Bmin.assign(static_cast<size_t>(m.nb) * m.nv, INFINITY);
    for (int iv = 0; iv < m.nv; ++iv) {
      const float* dm = m.row(iv);
      for (int jb = 0; jb < m.nb; ++jb) {
        float bmin = INFINITY;
        for (int c = jb * kBeamShadowBlock; c < std::min(m.nu, (jb + 1) * kBeamShadowBlock); ++c) bmin = std::min(bmin, dm[c]);
        m.Bmin[static_cast<size_t>(iv) * m.nb + jb] = bmin;
      }
    }
  }
  made = true;
}

GroundShadowMaps::GroundShadowMaps(int width, int height, const CameraGeometry& g, const ImageU16& labels,
                                   const ImageF& depth_m, const ScenePreset& p, const LabelRuns* runs)
    : impl_(std::make_unique<Impl>(width, height, g, labels, depth_m, p, runs)) {}
GroundShadowMaps::~GroundShadowMaps() = default;

BeamShadowStats GroundShadowMaps::shade(ImageF& beam_lux) const {
  const Impl& gm = *impl_;
  BeamShadowStats st;
  if (!gm.b.ok) return st;
  const int W = gm.W, H = gm.H;
  if (beam_lux.width() != W || beam_lux.height() != H) fail("low beam shadows: the beam, labels and depth differ in size");
  if (!gm.made) return st;
  const BeamF& b = gm.b;
  const ImageU16& labels = gm.labels;
  const std::vector<double>& xn = gm.xn;
  const std::vector<Impl::Row>& rows = gm.rows;
  const std::array<LampShadowMap, 2>& maps = gm.maps;
  const double cell = gm.cell;
  const bool avx512 = kHaveAvx512 && beam_isa_cap >= 2;
  // The lit ground pixels (as low_beam_illuminance evaluates them: the ground classes) beyond a
  // solid point of their cell (by the margin above) lose that lamp's share: the other lamp's E
  // alone (beam_lux_f's sum less the shaded term, the same bits as that lamp's E), 0 in both
  // shadows.
  const auto& read = ground_classes();
  const float cellf = static_cast<float>(cell);
  long long n0 = 0, n1 = 0, n2 = 0;
  // Per row: its cells in each lamp's map are one map row (v = h_l/D), and a pixel's cell column
  // cu(x) = ((X − x_l)/D − u_lo)/cell never decreases with x (X = t·x_n rounded to float, each
  // step monotone), so the pixels in shaded cells are found from the map row's runs of shaded
  // cells (skipping blocks of kBeamShadowBlock cells whose least D is not near enough), each run's
  // first and last pixel by cu's linear estimate corrected by cu itself: the same pixels as
  // testing each one, without visiting the others.
  // A pixel in one lamp's shadow takes the other lamp's E, computed for the row's such pixels
  // together as the beam image's rows compute it (beam_row_avx512 / _avx2 with that lamp only:
  // beam_lamp_f's bits).
  const bool avx2 = kHaveAvx2 && beam_isa_cap >= 1;
#pragma omp parallel reduction(+ : n0, n1, n2)
  {
    std::vector<uint8_t> bits(W, 0);
    std::vector<int> lit(W + 16), xs(W);
    std::vector<double> xc(W);
    std::vector<float> E1(W);
    std::vector<std::pair<int, int>> spans[2];
#pragma omp for schedule(static, 8)
    for (int y = 0; y < H; ++y) {
      const Impl::Row r = rows[y];
      if (!(r.D > 0)) continue;
      const float Df = static_cast<float>(r.D), D2 = Df * Df, invD = 1.f / Df, v = b.hl * invD;
      const float D_near = b.hl / (v + cellf);  // the ground one cell nearer: a solid point must be nearer still
      const float cv = v * maps[0].inv_cell;
      if (!(cv >= 0 && cv < static_cast<float>(maps[0].nv))) continue;
      const int iv = static_cast<int>(cv);
      for (int k = 0; k < 2; ++k) {
        spans[k].clear();
        const LampShadowMap& m = maps[k];
        auto cu = [&](int x) { return ((static_cast<float>(r.t * xn[x]) - m.xl) * invD - m.u_lo) * m.inv_cell; };
        const float cu0 = cu(0), cu1 = cu(W - 1);
        if (!(cu1 >= 0) || !(cu0 < static_cast<float>(m.nu))) continue;
        const double slope = W > 1 ? (static_cast<double>(cu1) - cu0) / (W - 1) : 1;
        // The first pixel whose cu reaches c (W where none does).
        auto first_at = [&](int c) {
          int x = slope > 0 ? static_cast<int>(std::clamp(std::ceil((c - cu0) / slope), 0.0, static_cast<double>(W))) : 0;
          while (x > 0 && cu(x - 1) >= static_cast<float>(c)) --x;
          while (x < W && cu(x) < static_cast<float>(c)) ++x;
          return x;
        };
        const int c_lo = std::max(0, static_cast<int>(std::max(cu0, 0.f))), c_hi = std::min(m.nu - 1, static_cast<int>(cu1));
        const float* dm = m.row(iv);
        const float* bm = m.Bmin.data() + static_cast<size_t>(iv) * m.nb;
        const uint8_t bit = static_cast<uint8_t>(1 << k);
        int run = -1;  // the current run's first cell
        auto close = [&](int c_end) {  // the run [run, c_end) of shaded cells: its pixels
          const int x0 = first_at(run), x1 = first_at(c_end);
          for (int x = x0; x < x1; ++x) bits[x] |= bit;
          if (x0 < x1) spans[k].emplace_back(x0, x1);
          run = -1;
        };
        for (int jb = c_lo / kBeamShadowBlock; jb <= c_hi / kBeamShadowBlock; ++jb) {
          if (!(bm[jb] < D_near)) {
            if (run >= 0) close(std::max(c_lo, jb * kBeamShadowBlock));
            continue;
          }
          const int c_a = std::max(c_lo, jb * kBeamShadowBlock), c_b = std::min(c_hi + 1, (jb + 1) * kBeamShadowBlock);
          for (int c = c_a; c < c_b; ++c) {
            const bool sh = dm[c] < D_near;
            if (sh && run < 0) run = c;
            else if (!sh && run >= 0) close(c);
          }
        }
        if (run >= 0) close(c_hi + 1);
      }
      const uint16_t* id = labels.row(y);
      float* e = beam_lux.row(y);
      // Each run of lamp k's shadow: its lit pixels (e > 0; most of a run's pixels are the
      // occluders' own, 0 in the ground's image) in both shadows 0, those in k's only the other
      // lamp's E (those in the other's only: in that lamp's runs), computed for them together.
      for (int k = 0; k < 2; ++k) {
        int m = 0;
        for (const auto& [x0, x1] : spans[k]) {
          const int np = (avx512 ? positive_columns_avx512 : avx2 ? positive_columns_avx2 : positive_columns)(e, x0, x1,
                                                                                                       lit.data());
          for (int j = 0; j < np; ++j) {
            const int x = lit[j];
            const uint8_t sb = bits[x];
            if (sb != 3 && sb != 1 << k) continue;  // in the other lamp's shadow only: its runs
            if (!(id[x] < kLabelCount && read[id[x]])) continue;
            if (sb == 3) {
              e[x] = 0.f;  // (e ≤ 0 from now on: not taken again in the other lamp's runs)
              ++n2;
            } else {
              xs[m] = x, xc[m] = xn[x], ++m;
            }
          }
        }
        if (!m) continue;
        const int other = 1 - k;
        if (avx512)
          beam_row_avx512(xc.data(), m, r.t, D2, invD, b, nullptr, 0, E1.data(), other);
        else if (avx2)
          beam_row_avx2(xc.data(), m, r.t, D2, invD, b, nullptr, 0, E1.data(), other);
        else
          for (int j = 0; j < m; ++j) E1[j] = beam_lamp_f(static_cast<float>(r.t * xc[j]) - b.xl[other], D2, invD, b);
        for (int j = 0; j < m; ++j) e[xs[j]] = E1[j];
        (k == 0 ? n0 : n1) += m;
      }
      for (int k = 0; k < 2; ++k)
        for (const auto& [x0, x1] : spans[k]) std::fill(bits.begin() + x0, bits.begin() + x1, uint8_t{0});
    }
  }
  st.one_lamp[0] = n0;
  st.one_lamp[1] = n1;
  st.both = n2;
  return st;
}

BeamShadowStats shade_low_beam_ground_with(ImageF& beam_lux, const CameraGeometry& g, const ImageU16& labels,
                                           const ImageF& depth_m, const ScenePreset& p,
                                           const LabelRuns* runs) {
  return GroundShadowMaps(beam_lux.width(), beam_lux.height(), g, labels, depth_m, p, runs).shade(beam_lux);
}

float low_beam_lamp_lux_f32(double X_m, double D_m, int lamp, const ScenePreset& p) {
  const BeamF b = beam_f(p);
  const float D = static_cast<float>(D_m);
  if (!b.ok || !(D > 0) || lamp < 0 || lamp > 1) return 0.f;
  return beam_lamp_f(static_cast<float>(X_m) - b.xl[lamp], D * D, 1.f / D, b);
}


// ---- The low beam on vertical surfaces ----------------------------------------------------------
// The headlamps light what stands in front of the car as well as the road: the legs of a
// pedestrian, the lower half of the car ahead, a wall's foot, below the cut-off with the table's
// intensity (tens of lux at 20-40 m); above it, the glare zone's beam_above_cutoff_cd. A vertical
// surface element with unit normal n at the point P receives from each lamp at L
//   E = I(h, v)·cos β / d²,   cos β = n·(L − P)/d,   d = |L − P|,
// with h and v the angles of P seen from the lamp (as the ground's, low_beam_lux), and a tree
// crown, taken as a Lambert sphere (crown_phase_detail.h), I(h, v)·Φ(α)/d² with α the angle at P
// between the lamp and the camera (a few degrees: Φ ≈ 2/3). The normal is street.cpp's: a
// building's façade plane (BuildingFacades), else the face turned to the camera (the labels do
// not tell an object's own orientation). Stated approximations: the lamps sit beside the camera
// (their forward offset neglected, as for the ground); shadows only below the cut-off's top
// (shade_vertical_row, after the row); d² is held at
// (5·lens_diameter_m)² nearer than five lens diameters (the inverse square law's range).
namespace {
// Whether a point dy above the lamp at horizontal distance √horiz2 lies above the cut-off's top,
// v > cutoff_max_v_deg, i.e. dy > √horiz2·t with t = tan(cutoff_max_v_deg), decided without the
// square root: for t ≥ 0, dy > 0 and dy² > horiz2·t²; for t < 0, dy > 0 or dy² < horiz2·t².
[[gnu::always_inline]] inline bool beam_above_top(float dy, float horiz2, const BeamF& b) {
  const float q = dy * dy, r = horiz2 * b.tvmax2;
  return b.tvmax >= 0 ? (dy > 0 && q > r) : (dy > 0 || q < r);
}
// One headlamp's E at a point dx = X − x_l right of it, dy = Y − h_l above it and D > 0 ahead,
// in float32. The surface's normal is m/s: m = (mX, mY, mD) and its length s (a face turned to the
// camera: m = (−X, 0, −D), s = √(X² + D²); a façade: its plane's lit normal, s = 1; a crown: the
// vector to the camera, m = (−X, h − Y, −D), s = |m|), so that no normal is divided out:
//   beside the table's horizontal range (dx outside [D·tan H₀, D·tan H₁]): 0;
//   a face turned away (m·(L − P) ≤ 0, not for crowns): 0;
//   above the cut-off's top (beam_above_top): the glare zone's I, no angle;
//   else h = atan(dx/D), v = atan(dy/√(dx² + D²)) in degrees: above the cut-off the glare zone's I,
//   inside the grid the table (beam_table_f), outside it 0;
// then a face's E = I·(m·(L − P))/(s·d·max(d², d²_min)) (= I·cos β/d²), a crown's
// I·Φ(m·(L − P)/(s·d))/max(d², d²_min).
// The vector rows (beam_vertical_row_avx512, _avx2) do the same operations on their lanes: the same
// bits.
[[gnu::always_inline]] inline float beam_vertical_lamp_f(float dx, float dy, float D, float mX, float mY, float mD,
                                                         float s, bool crown, const BeamF& b) {
  if (!(dx >= D * b.th0 && dx <= D * b.th1)) return 0.f;
  const float horiz2 = dx * dx + D * D;
  const float d2 = horiz2 + dy * dy, d = std::sqrt(d2);
  float nv = mX * dx + mD * D;  // −m·(L − P)
  if (crown) nv = nv + mY * dy;
  const float cb = -nv;  // m·(L − P) = s·d·cos β (cos α for a crown)
  if (!crown && !(cb > 0)) return 0.f;
  float I = b.above;
  if (!beam_above_top(dy, horiz2, b)) {
    const float horiz = std::sqrt(horiz2);
    const float h = atanf_cephes(dx / D) * b.deg, v = atanf_cephes(dy / horiz) * b.deg;
    const float cut = std::min(b.cv + std::max(h, 0.f) * b.rise, b.cmax);
    if (v <= cut) {
      if (!(h >= b.H[0] && h <= b.H[b.nh - 1] && v >= b.V[0] && v <= b.V[b.nv - 1])) return 0.f;
      I = beam_table_f(h, v, b);
    }
  }
  const float sd = s * d, dm = std::max(d2, b.d2_min);
  return crown ? (I * crown_phase(cb / sd)) / dm : (I * cb) / (sd * dm);
}

// What the rows of add_low_beam_vertical share: the beam, the camera, per column x_n = (x − c_x)/f,
// the façades and their planes' lit normals in float, the lit classes.
struct BeamVerticalCtx {
  const BeamF& b;
  const CameraGeometry& g;
  const BuildingFacades* fac;
  std::vector<float> xn;
  std::vector<float> plane_nX, plane_nD;  // each façade plane's lit normal (−n)
  uint64_t classes;
  int building, vegetation;
  float h, xl0, xl1;
};
// The pixel's point, X = z·x_n, D = z·kD, H = z·kY (the camera's height above the point),
// Y = h − H, and its normal as beam_vertical_lamp_f takes it (m, s). False where the pixel is not
// lit (not of a lit class, no finite depth, D ≤ 0).
struct BeamPoint {
  float X, Y, D, mX, mY, mD, s;
  bool crown;
};
[[gnu::always_inline]] inline bool beam_vertical_point(const BeamVerticalCtx& c, int x, const uint16_t* id,
                                                      const float* z, const int32_t* reg, float kD, float kY,
                                                      BeamPoint* p) {
  const int k = id[x];
  if (k >= 64 || !(c.classes >> k & 1)) return false;
  const float zz = z[x];
  if (!(zz > 0) || !(zz < kDepthInfinity_m)) return false;
  p->X = zz * c.xn[x];
  p->D = zz * kD;
  const float H = zz * kY;
  p->Y = c.h - H;
  if (!(p->D > 0)) return false;
  p->crown = k == c.vegetation;
  p->mX = -p->X;
  p->mY = 0.f;
  p->mD = -p->D;
  const float XD2 = p->X * p->X + p->D * p->D;
  if (k == c.building && reg) {
    if (const int pi = c.fac->plane_index(reg, x); pi >= 0) {
      p->mX = c.plane_nX[pi];
      p->mD = c.plane_nD[pi];
      p->s = 1.f;
      return true;
    }
  }
  if (p->crown) {
    p->mY = H;
    p->s = std::sqrt(XD2 + H * H);
    return true;
  }
  p->s = std::sqrt(XD2);
  return true;
}
// Both lamps' E, their terms into *t0, *t1 where asked (the shadows' rows keep one of them).
[[gnu::always_inline]] inline float beam_vertical_e(const BeamVerticalCtx& c, const BeamPoint& q, float* t0 = nullptr,
                                                    float* t1 = nullptr) {
  const float dy = q.Y - c.b.hl;
  const float e0 = beam_vertical_lamp_f(q.X - c.xl0, dy, q.D, q.mX, q.mY, q.mD, q.s, q.crown, c.b);
  const float e1 = beam_vertical_lamp_f(q.X - c.xl1, dy, q.D, q.mX, q.mY, q.mD, q.s, q.crown, c.b);
  if (t0) *t0 = e0, *t1 = e1;
  return e0 + e1;
}
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
// beam_vertical_row_scalar sixteen pixels at a time (AVX-512), over the columns 0 .. 16⌊W/16⌋ − 1
// (returned; the scalar row does the rest): the same operations per lane as beam_vertical_point
// and beam_vertical_lamp_f, their branches as lane masks, the angles and the table only for groups
// with a lane below the cut-off's top; a table that is not small (BeamF::small) takes such lanes by
// the scalar code. So the same bits as beam_vertical_row_scalar, the lamps' terms too (into t0, t1
// where they are asked, on the lit lanes).
__attribute__((target("avx512f,avx512bw,avx512vl,avx512dq"))) int beam_vertical_row_avx512(
    const BeamVerticalCtx& c, const uint16_t* id, const float* z, const int32_t* reg, float kD, float kY, float* e,
    float* t0, float* t1) {
  const int W = static_cast<int>(c.xn.size()), Wv = W & ~15;
  const BeamF& b = c.b;
  const __m512i mlo = _mm512_set1_epi32(static_cast<int32_t>(c.classes & 0xffffffffu)),
                mhi = _mm512_set1_epi32(static_cast<int32_t>(c.classes >> 32)), one = _mm512_set1_epi32(1),
                k32 = _mm512_set1_epi32(32), veg = _mm512_set1_epi32(c.vegetation), bld = _mm512_set1_epi32(c.building);
  const __m512 zero = _mm512_setzero_ps(), zinf = _mm512_set1_ps(kDepthInfinity_m), vkD = _mm512_set1_ps(kD),
               vkY = _mm512_set1_ps(kY), vh = _mm512_set1_ps(c.h), vhl = _mm512_set1_ps(b.hl),
               th0 = _mm512_set1_ps(b.th0), th1 = _mm512_set1_ps(b.th1), tv2 = _mm512_set1_ps(b.tvmax2),
               above = _mm512_set1_ps(b.above), d2min = _mm512_set1_ps(b.d2_min), fone = _mm512_set1_ps(1.f),
               sign = _mm512_set1_ps(-0.f), deg = _mm512_set1_ps(b.deg), cv = _mm512_set1_ps(b.cv),
               cmax = _mm512_set1_ps(b.cmax), rise = _mm512_set1_ps(b.rise), h_lo = _mm512_set1_ps(b.H[0]),
               h_hi = _mm512_set1_ps(b.H[b.nh - 1]), v_lo = _mm512_set1_ps(b.V[0]), v_hi = _mm512_set1_ps(b.V[b.nv - 1]);
  const bool small = b.small, t_pos = b.tvmax >= 0;
  const float xl[2] = {c.xl0, c.xl1};
  for (int x = 0; x < Wv; x += 16) {
    const __m512i k = _mm512_cvtepu16_epi32(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(id + x)));
    // The class bit (0 for ids of 64 and above: both shifts by 32 or more give 0).
    const __m512i bit = _mm512_and_si512(
        _mm512_or_si512(_mm512_srlv_epi32(mlo, k), _mm512_srlv_epi32(mhi, _mm512_sub_epi32(k, k32))), one);
    // The lanes of the lit classes (cls: each written, 0 where not lit) and of those the lit ones (m).
    const __mmask16 cls = _mm512_test_epi32_mask(bit, bit);
    if (!cls) continue;
    const __m512 vz = _mm512_loadu_ps(z + x);
    __mmask16 m = cls & _mm512_cmp_ps_mask(vz, zero, _CMP_GT_OQ) & _mm512_cmp_ps_mask(vz, zinf, _CMP_LT_OQ);
    const __m512 X = _mm512_mul_ps(vz, _mm512_loadu_ps(c.xn.data() + x)), D = _mm512_mul_ps(vz, vkD);
    const __m512 Hc = _mm512_mul_ps(vz, vkY), Y = _mm512_sub_ps(vh, Hc);
    m &= _mm512_cmp_ps_mask(D, zero, _CMP_GT_OQ);
    if (!m) {
      _mm512_mask_storeu_ps(e + x, cls, zero);
      continue;
    }
    const __mmask16 crown = m & _mm512_cmpeq_epi32_mask(k, veg);
    // The normals (m, s): a face turned to the camera, a crown's vector to the camera, a façade's plane.
    const __m512 XD2 = _mm512_add_ps(_mm512_mul_ps(X, X), _mm512_mul_ps(D, D));
    __m512 mX = _mm512_xor_ps(X, sign), mD = _mm512_xor_ps(D, sign), mY = zero;
    __m512 s = _mm512_sqrt_ps(XD2);
    if (crown) {
      mY = _mm512_maskz_mov_ps(crown, Hc);
      s = _mm512_mask_sqrt_ps(s, crown, _mm512_add_ps(XD2, _mm512_mul_ps(Hc, Hc)));
    }
    if (const __mmask16 bm = m & _mm512_cmpeq_epi32_mask(k, bld); bm && reg) {
      // The façade planes of the building lanes. All of one region (the common case): the
      // region's column planes of the sixteen columns in one load, the planes' normals broadcast
      // (one plane) or gathered; else lane by lane.
      __mmask16 planar = 0;
      const int r0 = reg[x + __builtin_ctz(bm)];
      if (r0 >= 0 && (bm & _mm512_cmpeq_epi32_mask(_mm512_loadu_si512(reg + x), _mm512_set1_epi32(r0))) == bm) {
        const BuildingFacades::Region& R = c.fac->regions[r0];
        const __m512i pv = _mm512_maskz_loadu_epi32(bm, R.column_plane.data() + (x - R.x0));
        planar = bm & _mm512_cmpge_epi32_mask(pv, _mm512_setzero_si512());
        const int p0 = R.column_plane[x + __builtin_ctz(bm) - R.x0];
        if (p0 >= 0 && (bm & _mm512_cmpeq_epi32_mask(pv, _mm512_set1_epi32(p0))) == bm) {
          // One plane for all of them (the common case): its normal broadcast.
          mX = _mm512_mask_mov_ps(mX, planar, _mm512_set1_ps(c.plane_nX[p0]));
          mD = _mm512_mask_mov_ps(mD, planar, _mm512_set1_ps(c.plane_nD[p0]));
        } else {
          mX = _mm512_mask_i32gather_ps(mX, planar, pv, c.plane_nX.data(), 4);
          mD = _mm512_mask_i32gather_ps(mD, planar, pv, c.plane_nD.data(), 4);
        }
      } else {
        alignas(64) float pX[16], pD[16];
        for (unsigned r = bm; r; r &= r - 1) {
          const int i = __builtin_ctz(r), pi = c.fac->plane_index(reg, x + i);
          if (pi < 0) continue;
          pX[i] = c.plane_nX[pi];
          pD[i] = c.plane_nD[pi];
          planar |= static_cast<__mmask16>(1u << i);
        }
        mX = _mm512_mask_load_ps(mX, planar, pX);
        mD = _mm512_mask_load_ps(mD, planar, pD);
      }
      s = _mm512_mask_mov_ps(s, planar, fone);
    }
    const __m512 dy = _mm512_sub_ps(Y, vhl), dy2 = _mm512_mul_ps(dy, dy), D2 = _mm512_mul_ps(D, D);
    const __m512 Dh0 = _mm512_mul_ps(D, th0), Dh1 = _mm512_mul_ps(D, th1);
    const __mmask16 dy_pos = _mm512_cmp_ps_mask(dy, zero, _CMP_GT_OQ);
    __m512 E = zero, El[2] = {zero, zero};
    __mmask16 slow = 0;
    for (int l = 0; l < 2; ++l) {
      const __m512 dx = _mm512_sub_ps(X, _mm512_set1_ps(xl[l]));
      const __mmask16 in = _mm512_cmp_ps_mask(dx, Dh0, _CMP_GE_OQ) & _mm512_cmp_ps_mask(dx, Dh1, _CMP_LE_OQ);
      const __m512 horiz2 = _mm512_add_ps(_mm512_mul_ps(dx, dx), D2);
      const __m512 d2 = _mm512_add_ps(horiz2, dy2), d = _mm512_sqrt_ps(d2);
      __m512 nv = _mm512_add_ps(_mm512_mul_ps(mX, dx), _mm512_mul_ps(mD, D));
      nv = _mm512_mask_add_ps(nv, crown, nv, _mm512_mul_ps(mY, dy));
      const __m512 cb = _mm512_xor_ps(nv, sign);
      const __mmask16 lit = in & m & (crown | _mm512_cmp_ps_mask(cb, zero, _CMP_GT_OQ));
      if (!lit) continue;
      const __m512 r = _mm512_mul_ps(horiz2, tv2);
      const __mmask16 top = t_pos ? dy_pos & _mm512_cmp_ps_mask(dy2, r, _CMP_GT_OQ)
                                  : dy_pos | _mm512_cmp_ps_mask(dy2, r, _CMP_LT_OQ);
      __m512 I = above;
      if (const __mmask16 below_top = lit & ~top) {
        // The angles on these lanes: the glare zone above the cut-off, the table inside its grid
        // below it, 0 outside the grid.
        if (!small) {
          slow |= below_top;
        } else {
          const __m512 horiz = _mm512_sqrt_ps(horiz2);
          const __m512 h = _mm512_mul_ps(atanf_cephes16(_mm512_div_ps(dx, D)), deg);
          const __m512 v = _mm512_mul_ps(atanf_cephes16(_mm512_div_ps(dy, horiz)), deg);
          const __m512 cut = _mm512_min_ps(_mm512_add_ps(cv, _mm512_mul_ps(_mm512_max_ps(h, zero), rise)), cmax);
          const __mmask16 under = below_top & _mm512_cmp_ps_mask(v, cut, _CMP_LE_OQ);
          const __mmask16 grid = _mm512_cmp_ps_mask(h, h_lo, _CMP_GE_OQ) & _mm512_cmp_ps_mask(h, h_hi, _CMP_LE_OQ) &
                                 _mm512_cmp_ps_mask(v, v_lo, _CMP_GE_OQ) & _mm512_cmp_ps_mask(v, v_hi, _CMP_LE_OQ);
          if (under) I = _mm512_mask_mov_ps(I, under, _mm512_maskz_mov_ps(grid, beam_table16(h, v, b)));
        }
      }
      const __m512 sd = _mm512_mul_ps(s, d), dm = _mm512_max_ps(d2, d2min);
      __m512 el = _mm512_div_ps(_mm512_mul_ps(I, cb), _mm512_mul_ps(sd, dm));
      if (const __mmask16 cl = crown & lit)
        el = _mm512_mask_div_ps(el, cl, _mm512_mul_ps(I, crown_phase16(_mm512_div_ps(cb, sd))), dm);
      El[l] = _mm512_maskz_mov_ps(lit, el);
      E = _mm512_add_ps(E, El[l]);
    }
    _mm512_mask_storeu_ps(e + x, cls & ~slow, E);  // (E is +0.0 on the lanes not lit)
    if (t0) {
      _mm512_mask_storeu_ps(t0 + x, m & ~slow, El[0]);
      _mm512_mask_storeu_ps(t1 + x, m & ~slow, El[1]);
    }
    for (unsigned r = m & slow; r; r &= r - 1) {
      const int xi = x + __builtin_ctz(r);
      BeamPoint q;
      if (beam_vertical_point(c, xi, id, z, reg, kD, kY, &q))
        e[xi] = beam_vertical_e(c, q, t0 ? t0 + xi : nullptr, t0 ? t1 + xi : nullptr);
    }
  }
  return Wv;
}
#pragma GCC diagnostic pop
// beam_table_f on eight lanes, the table read by gathers and small grids (BeamF::small) by lane
// permutations (any grid; the cell indices, counts of grid angles, lie in the grid on every lane):
// the same operations per lane.
__attribute__((target("avx2"))) inline __m256 beam_table8(__m256 h, __m256 v, const BeamF& b) {
  const __m256i vnh = _mm256_set1_epi32(b.nh);
  __m256i j = _mm256_setzero_si256(), i = _mm256_setzero_si256();
  for (int m = 1; m + 1 < b.nh; ++m)
    j = _mm256_sub_epi32(j, _mm256_castps_si256(_mm256_cmp_ps(_mm256_set1_ps(b.H[m]), h, _CMP_LE_OQ)));
  for (int m = 1; m + 1 < b.nv; ++m)
    i = _mm256_sub_epi32(i, _mm256_castps_si256(_mm256_cmp_ps(_mm256_set1_ps(b.V[m]), v, _CMP_LE_OQ)));
  __m256 Hj, rHj, Vi, rVi;
  if (b.small) {  // grids of at most 8 angles: one lane permutation each
    Hj = _mm256_permutevar8x32_ps(_mm256_loadu_ps(b.H8), j), rHj = _mm256_permutevar8x32_ps(_mm256_loadu_ps(b.rH8), j);
    Vi = _mm256_permutevar8x32_ps(_mm256_loadu_ps(b.V8), i), rVi = _mm256_permutevar8x32_ps(_mm256_loadu_ps(b.rV8), i);
  } else {
    Hj = _mm256_i32gather_ps(b.H.data(), j, 4), rHj = _mm256_i32gather_ps(b.rH.data(), j, 4);
    Vi = _mm256_i32gather_ps(b.V.data(), i, 4), rVi = _mm256_i32gather_ps(b.rV.data(), i, 4);
  }
  const __m256i c0 = _mm256_add_epi32(_mm256_mullo_epi32(i, vnh), j);
  const float* I = b.I.data();
  const __m256 r00 = _mm256_i32gather_ps(I, c0, 4), r01 = _mm256_i32gather_ps(I + 1, c0, 4);
  const __m256 r10 = _mm256_i32gather_ps(I + b.nh, c0, 4), r11 = _mm256_i32gather_ps(I + b.nh + 1, c0, 4);
  return beam_bilinear8(h, v, Hj, rHj, Vi, rVi, r00, r01, r10, r11);
}
// The lanes of v where `mask` (all-ones lanes) into p[0 .. 7], the others as they were: what
// _mm256_maskstore_ps does, as a load, a blend and a plain store (the masked store is slow on AMD's
// cores: on this Zen 4 host a fifth of beam_vertical_row_avx2's samples fell at its three masked
// stores). p's floats are the caller's row's, which no other thread writes meanwhile. Where every
// lane is on (97% of the vertical rows' groups on the bench frame) a plain store of v, without the
// load and the blend, whose result waited on that load.
[[gnu::always_inline]] __attribute__((target("avx2"))) inline void store_lanes8(float* p, __m256 mask, __m256 v) {
  if (_mm256_movemask_ps(mask) == 0xff)
    _mm256_storeu_ps(p, v);
  else
    _mm256_storeu_ps(p, _mm256_blendv_ps(_mm256_loadu_ps(p), v, mask));
}
// beam_vertical_row_scalar eight pixels at a time (AVX2), over the columns 0 .. 8⌊W/8⌋ − 1
// (returned): beam_vertical_row_avx512's steps with vector masks (all-ones lanes) and the table by
// gathers. The same operations per lane: the same bits as the scalar rows (the lamps' terms into
// t0, t1 where asked).
__attribute__((target("avx2"))) int beam_vertical_row_avx2(const BeamVerticalCtx& c, const uint16_t* id, const float* z,
                                                           const int32_t* reg, float kD, float kY, float* e, float* t0,
                                                           float* t1) {
  const int W = static_cast<int>(c.xn.size()), Wv = W & ~7;
  const BeamF& b = c.b;
  const __m256i mlo = _mm256_set1_epi32(static_cast<int32_t>(c.classes & 0xffffffffu)),
                mhi = _mm256_set1_epi32(static_cast<int32_t>(c.classes >> 32)), one = _mm256_set1_epi32(1),
                k32 = _mm256_set1_epi32(32), veg = _mm256_set1_epi32(c.vegetation), bld = _mm256_set1_epi32(c.building);
  const __m256 zero = _mm256_setzero_ps(), zinf = _mm256_set1_ps(kDepthInfinity_m), vkD = _mm256_set1_ps(kD),
               vkY = _mm256_set1_ps(kY), vh = _mm256_set1_ps(c.h), vhl = _mm256_set1_ps(b.hl),
               th0 = _mm256_set1_ps(b.th0), th1 = _mm256_set1_ps(b.th1), tv2 = _mm256_set1_ps(b.tvmax2),
               above = _mm256_set1_ps(b.above), d2min = _mm256_set1_ps(b.d2_min), fone = _mm256_set1_ps(1.f),
               sign = _mm256_set1_ps(-0.f), deg = _mm256_set1_ps(b.deg), cv = _mm256_set1_ps(b.cv),
               cmax = _mm256_set1_ps(b.cmax), rise = _mm256_set1_ps(b.rise), h_lo = _mm256_set1_ps(b.H[0]),
               h_hi = _mm256_set1_ps(b.H[b.nh - 1]), v_lo = _mm256_set1_ps(b.V[0]), v_hi = _mm256_set1_ps(b.V[b.nv - 1]);
  const bool t_pos = b.tvmax >= 0;
  const float xl[2] = {c.xl0, c.xl1};
  auto any = [](__m256 m) __attribute__((target("avx2"))) { return _mm256_movemask_ps(m) != 0; };
  for (int x = 0; x < Wv; x += 8) {
    const __m256i k = _mm256_cvtepu16_epi32(_mm_loadu_si128(reinterpret_cast<const __m128i*>(id + x)));
    const __m256i bit = _mm256_and_si256(
        _mm256_or_si256(_mm256_srlv_epi32(mlo, k), _mm256_srlv_epi32(mhi, _mm256_sub_epi32(k, k32))), one);
    // The lanes of the lit classes (cls: each written, 0 where not lit) and of those the lit ones (m).
    const __m256 cls = _mm256_castsi256_ps(_mm256_cmpeq_epi32(bit, one));
    if (!any(cls)) continue;
    const __m256 vz = _mm256_loadu_ps(z + x);
    __m256 m = _mm256_and_ps(cls, _mm256_and_ps(_mm256_cmp_ps(vz, zero, _CMP_GT_OQ), _mm256_cmp_ps(vz, zinf, _CMP_LT_OQ)));
    const __m256 X = _mm256_mul_ps(vz, _mm256_loadu_ps(c.xn.data() + x)), D = _mm256_mul_ps(vz, vkD);
    const __m256 Hc = _mm256_mul_ps(vz, vkY), Y = _mm256_sub_ps(vh, Hc);
    m = _mm256_and_ps(m, _mm256_cmp_ps(D, zero, _CMP_GT_OQ));
    if (!any(m)) {
      store_lanes8(e + x, cls, zero);
      continue;
    }
    const __m256 crown = _mm256_and_ps(m, _mm256_castsi256_ps(_mm256_cmpeq_epi32(k, veg)));
    const bool any_crown = any(crown);
    const __m256 XD2 = _mm256_add_ps(_mm256_mul_ps(X, X), _mm256_mul_ps(D, D));
    __m256 mX = _mm256_xor_ps(X, sign), mD = _mm256_xor_ps(D, sign), mY = zero;
    __m256 s = _mm256_sqrt_ps(XD2);
    if (any_crown) {
      mY = _mm256_and_ps(crown, Hc);
      s = _mm256_blendv_ps(s, _mm256_sqrt_ps(_mm256_add_ps(XD2, _mm256_mul_ps(Hc, Hc))), crown);
    }
    if (const __m256 bm = _mm256_and_ps(m, _mm256_castsi256_ps(_mm256_cmpeq_epi32(k, bld))); reg && any(bm)) {
      // The façade planes of the building lanes: all of one region and one plane (the common
      // case: 99.99% of the groups with a building lane on the bench frame) its normal broadcast,
      // else lane by lane (beam_vertical_row_avx512's test: the building lanes' column planes by
      // one masked load, which reads only those lanes' entries, the ones a loop over them read).
      const int bits = _mm256_movemask_ps(bm), i0 = __builtin_ctz(static_cast<unsigned>(bits)), r0 = reg[x + i0];
      const __m256i rv = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(reg + x));
      const int same_region = _mm256_movemask_ps(_mm256_castsi256_ps(_mm256_cmpeq_epi32(rv, _mm256_set1_epi32(r0))));
      int p0 = -1;
      bool one_plane = false;
      if (r0 >= 0 && (bits & same_region) == bits) {
        const BuildingFacades::Region& R = c.fac->regions[r0];
        p0 = R.column_plane[x + i0 - R.x0];
        if (p0 >= 0) {
          const __m256i pv = _mm256_maskload_epi32(R.column_plane.data() + (x - R.x0), _mm256_castps_si256(bm));
          const int same = _mm256_movemask_ps(_mm256_castsi256_ps(_mm256_cmpeq_epi32(pv, _mm256_set1_epi32(p0))));
          one_plane = (same & bits) == bits;
        }
      }
      if (one_plane) {
        mX = _mm256_blendv_ps(mX, _mm256_set1_ps(c.plane_nX[p0]), bm);
        mD = _mm256_blendv_ps(mD, _mm256_set1_ps(c.plane_nD[p0]), bm);
        s = _mm256_blendv_ps(s, fone, bm);
      } else {
        alignas(32) float pX[8], pD[8];
        alignas(32) int32_t pm[8];
        for (int i = 0; i < 8; ++i) {
          pm[i] = 0;
          pX[i] = pD[i] = 0.f;
          const int pi = bits >> i & 1 ? c.fac->plane_index(reg, x + i) : -1;
          if (pi < 0) continue;
          pX[i] = c.plane_nX[pi];
          pD[i] = c.plane_nD[pi];
          pm[i] = -1;
        }
        const __m256 planar = _mm256_load_ps(reinterpret_cast<const float*>(pm));
        mX = _mm256_blendv_ps(mX, _mm256_load_ps(pX), planar);
        mD = _mm256_blendv_ps(mD, _mm256_load_ps(pD), planar);
        s = _mm256_blendv_ps(s, fone, planar);
      }
    }
    const __m256 dy = _mm256_sub_ps(Y, vhl), dy2 = _mm256_mul_ps(dy, dy), D2 = _mm256_mul_ps(D, D);
    const __m256 Dh0 = _mm256_mul_ps(D, th0), Dh1 = _mm256_mul_ps(D, th1);
    const __m256 dy_pos = _mm256_cmp_ps(dy, zero, _CMP_GT_OQ);
    __m256 E = zero, El[2] = {zero, zero};
    for (int l = 0; l < 2; ++l) {
      const __m256 dx = _mm256_sub_ps(X, _mm256_set1_ps(xl[l]));
      const __m256 in = _mm256_and_ps(_mm256_cmp_ps(dx, Dh0, _CMP_GE_OQ), _mm256_cmp_ps(dx, Dh1, _CMP_LE_OQ));
      const __m256 horiz2 = _mm256_add_ps(_mm256_mul_ps(dx, dx), D2);
      const __m256 d2 = _mm256_add_ps(horiz2, dy2), d = _mm256_sqrt_ps(d2);
      __m256 nv = _mm256_add_ps(_mm256_mul_ps(mX, dx), _mm256_mul_ps(mD, D));
      if (any_crown) nv = _mm256_blendv_ps(nv, _mm256_add_ps(nv, _mm256_mul_ps(mY, dy)), crown);
      const __m256 cb = _mm256_xor_ps(nv, sign);
      const __m256 lit = _mm256_and_ps(_mm256_and_ps(in, m), _mm256_or_ps(crown, _mm256_cmp_ps(cb, zero, _CMP_GT_OQ)));
      if (!any(lit)) continue;
      const __m256 r = _mm256_mul_ps(horiz2, tv2);
      const __m256 top = t_pos ? _mm256_and_ps(dy_pos, _mm256_cmp_ps(dy2, r, _CMP_GT_OQ))
                               : _mm256_or_ps(dy_pos, _mm256_cmp_ps(dy2, r, _CMP_LT_OQ));
      __m256 I = above;
      if (const __m256 below_top = _mm256_andnot_ps(top, lit); any(below_top)) {
        const __m256 horiz = _mm256_sqrt_ps(horiz2);
        const __m256 h = _mm256_mul_ps(atanf_cephes8(_mm256_div_ps(dx, D)), deg);
        const __m256 v = _mm256_mul_ps(atanf_cephes8(_mm256_div_ps(dy, horiz)), deg);
        const __m256 cut = _mm256_min_ps(_mm256_add_ps(cv, _mm256_mul_ps(_mm256_max_ps(h, zero), rise)), cmax);
        const __m256 under = _mm256_and_ps(below_top, _mm256_cmp_ps(v, cut, _CMP_LE_OQ));
        const __m256 grid = _mm256_and_ps(
            _mm256_and_ps(_mm256_cmp_ps(h, h_lo, _CMP_GE_OQ), _mm256_cmp_ps(h, h_hi, _CMP_LE_OQ)),
            _mm256_and_ps(_mm256_cmp_ps(v, v_lo, _CMP_GE_OQ), _mm256_cmp_ps(v, v_hi, _CMP_LE_OQ)));
        if (any(under)) I = _mm256_blendv_ps(I, _mm256_and_ps(grid, beam_table8(h, v, b)), under);
      }
      const __m256 sd = _mm256_mul_ps(s, d), dm = _mm256_max_ps(d2, d2min);
      __m256 el = _mm256_div_ps(_mm256_mul_ps(I, cb), _mm256_mul_ps(sd, dm));
      if (const __m256 cl = _mm256_and_ps(crown, lit); any(cl))
        el = _mm256_blendv_ps(el, _mm256_div_ps(_mm256_mul_ps(I, crown_phase8(_mm256_div_ps(cb, sd))), dm), cl);
      El[l] = _mm256_and_ps(lit, el);
      E = _mm256_add_ps(E, El[l]);
    }
    store_lanes8(e + x, cls, E);  // (E is +0.0 on the lanes not lit)
    if (t0) {
      store_lanes8(t0 + x, m, El[0]);
      store_lanes8(t1 + x, m, El[1]);
    }
  }
  _mm256_zeroupper();
  return Wv;
}
// Every pixel of a lit class gets its E, 0 where the rule lights nothing (no finite depth, D ≤ 0,
// beside the table, a face turned away): the image's value there before (the ground's E on a
// lane marking, low_beam_illuminance) is not kept.
// The lamps' terms into t0, t1 where asked (on the pixels lit).
void beam_vertical_row_scalar(const BeamVerticalCtx& c, int x0, const uint16_t* id, const float* z,
                              const int32_t* reg, float kD, float kY, float* e, float* t0, float* t1) {
  const int W = static_cast<int>(c.xn.size());
  for (int x = x0; x < W; ++x) {
    if (id[x] >= 64 || !(c.classes >> id[x] & 1)) continue;
    BeamPoint q;
    e[x] = beam_vertical_point(c, x, id, z, reg, kD, kY, &q)
               ? beam_vertical_e(c, q, t0 ? t0 + x : nullptr, t0 ? t1 + x : nullptr)
               : 0.f;
  }
}

// ---- Shadows of the low beam on vertical surfaces (docs/night.md §6c, "Shadows of the low beam")
// A point P = (X, Y, D) of a vertical surface is hidden from the lamp L = (x_l, h_l, 0) by a solid
// point Q when Q lies on the segment L→P: in the lamp's view the same direction
// (u, v) = ((X − x_l)/D, (h_l − Y)/D) and a smaller D. The ground's maps hold only the points
// below the lamps' height (every lamp→ground ray descends); a vertical surface's point may lie
// above it (v < 0), so these maps are the ground's (the same cell, the least D per cell) over the
// lamp view that the frame's solid points below the cut-off's top take (below: why only those).
// Their extent: a point seen by the camera has X/D = x_n/k_D and H/D = k_Y/k_D (the row's and
// column's terms), so (u, v) = (X/D − x_l/D, H/D + (h_l − h)/D): the frame's range of X/D and H/D
// widened by the parallax x_l/D and (h − h_l)/D of a point kBeamShadowNear_m ahead (a photosite
// choice: a point nearer than that near the frame's edge may fall outside; it neither casts nor
// receives a shadow there, consistently, since a caster and its receiver share a direction).
// Only what lies below the cut-off's top is shaded (a photosite choice, for the cost: every solid
// point of the frame would be ~15× the ground's points): above it the lamps give the glare zone's
// beam_above_cutoff_cd (625 cd: ≤ 1 lx at 25 m), below it the table's thousands of cd. Whether a
// point lies above the top depends on its direction from the lamp alone (beam_above_top), so a
// receiver below the top is hidden only by points below the top, the only ones splatted; the maps
// then start at the top's v (0 for the urban preset's cutoff_max_v_deg = 0: the lamps' height).
constexpr double kBeamShadowNear_m = 2;
struct VerticalShadowMaps {
  std::array<LampShadowMap, 2> maps;
  double r_min = 0;  // a row whose H/D = k_Y/k_D is below it holds no point of either map (camera above the lamps)
  bool ok = false;
};
VerticalShadowMaps vertical_shadow_maps(const BeamVerticalCtx& c, const ImageU16& labels, const ImageF& depth,
                                        double cp, double sp) {
  VerticalShadowMaps vs;
  const BeamF& b = c.b;
  const CameraGeometry& g = c.g;
  const int W = labels.width(), H = labels.height();
  if (W == 0 || H == 0) return vs;
  double cell = kBeamShadowCellPx / g.f_px;
  double r_lo = INFINITY, r_hi = -INFINITY, a_lo = INFINITY, a_hi = -INFINITY;
  for (int y = 0; y < H; ++y) {
    const double yn = (y - g.cy_px) / g.f_px, kD = cp - yn * sp, kY = sp + yn * cp;
    if (!(kD > 0)) continue;
    r_lo = std::min(r_lo, kY / kD), r_hi = std::max(r_hi, kY / kD);
    a_lo = std::min(a_lo, c.xn[0] / kD), a_hi = std::max(a_hi, c.xn[W - 1] / kD);
  }
  if (!(r_hi >= r_lo)) return vs;
  const double dv = (b.hl - c.h) / kBeamShadowNear_m;
  // Lamp k's map extent at cell size cl: (u_lo, u_hi, v_lo, v_hi).
  auto extent = [&](int k, double cl) {
    const double du = -b.xl[k] / kBeamShadowNear_m;
    const double u_lo = a_lo + std::min(0.0, du) - cl, u_hi = a_hi + std::max(0.0, du) + cl;
    // Below the top: dy ≤ t·√(dx² + D²) (t = tan cutoff_max_v_deg), v = −dy/D ≥ −t·√(1 + u²) for
    // t ≥ 0, v ≥ |t| for t < 0.
    const double t = b.tvmax, umax = std::max(std::abs(u_lo), std::abs(u_hi));
    const double v_top = t >= 0 ? -t * std::sqrt(1 + umax * umax) : -t;
    const double v_lo = std::max(r_lo + std::min(0.0, dv), v_top) - cl, v_hi = r_hi + std::max(0.0, dv) + cl;
    return std::array<double, 4>{u_lo, u_hi, v_lo, v_hi};
  };
  // Each map's cells at cell size cl (the allocation's below), the cell bounded by them.
  cell = beam_shadow_cell(cell, W, H, [&](int k, double cl) {
    const auto [u_lo, u_hi, v_lo, v_hi] = extent(k, cl);
    return v_hi > v_lo ? (std::ceil((u_hi - u_lo) / cl) + 1) * (std::ceil((v_hi - v_lo) / cl) + 1) : 0.0;
  });
  vs.r_min = INFINITY;
  for (int k = 0; k < 2; ++k) {
    LampShadowMap& m = vs.maps[k];
    const auto [u_lo, u_hi, v_lo, v_hi] = extent(k, cell);
    if (!(v_hi > v_lo)) return vs;
    vs.r_min = std::min(vs.r_min, v_lo - cell);
    m.xl = b.xl[k];
    m.u_lo = static_cast<float>(u_lo), m.v_lo = static_cast<float>(v_lo);
    m.inv_cell = static_cast<float>(1 / cell);
    m.allocate(static_cast<int>(std::ceil((u_hi - u_lo) / cell)) + 1, static_cast<int>(std::ceil((v_hi - v_lo) / cell)) + 1);
  }
  // Every solid point (the rule's own X, Y, D), both lamps' maps in one pass (fill_shadow_maps;
  // sixteen columns at a time where there is AVX-512, place_row_avx512; eight with AVX2, place_row_avx2).
  const bool avx512 = kHaveAvx512 && beam_isa_cap >= 2, avx2 = kHaveAvx2 && beam_isa_cap >= 1;
  fill_shadow_maps(vs.maps, W, H, false, [&](int y, std::array<LampShadowMap, 2>& mt, int* cols) {
    const double yn = (y - g.cy_px) / g.f_px;
    // v = (h_l − h)/D + H/D < H/D when the camera is above the lamps: none in the maps here.
    if (c.h > b.hl && !((sp + yn * cp) / (cp - yn * sp) >= vs.r_min)) return;
    const float kD = static_cast<float>(cp - yn * sp), kY = static_cast<float>(sp + yn * cp);
    const float* z = depth.row(y);
    if (avx512) return place_row_avx512<false>(labels.row(y), z, c.xn.data(), W, c.classes, kD, kY, c.h, b, mt);
    if (avx2) return place_row_avx2<false>(labels.row(y), z, c.xn.data(), W, c.classes, kD, kY, c.h, b, mt);
    const int n = (kHaveAvx2 ? solid_columns_avx2 : solid_columns)(labels.row(y), W, c.classes, cols);
    for (int j = 0; j < n; ++j) {
      const int x = cols[j];
      const float zz = z[x];
      if (!(zz > 0) || !(zz < kDepthInfinity_m)) continue;
      const float D = zz * kD;
      if (!(D > 0)) continue;
      const float invD = 1.f / D, X = zz * c.xn[x], dy = (c.h - zz * kY) - b.hl, v = -dy * invD;
      for (LampShadowMap& m : mt) {
        int iv, iu;
        if (!m.cell_at((X - m.xl) * invD, v, &iv, &iu)) continue;
        const float dx = X - m.xl;
        if (!beam_above_top(dy, dx * dx + D * D, b)) m.place(iv, iu, D);
      }
    }
  });
  vs.ok = true;
  return vs;
}
// The row's lit vertical pixels (e as the rule wrote it) that a solid point of their cell hides
// from a lamp keep the other lamp's share (t0, t1: each lamp's term of the rule's sum as the rule's
// row wrote it), 0 when hidden from both.
// A surface must not shadow itself: its own points share P's cell. Near P the surface is a plane,
// on which w = 1/D is linear in the lamp's (u, v) (n·(P − L) = c₀ gives w = (n_X·u − n_Y·v + n_D)/c₀),
// so its points in P's cell (a cell's diagonal √2·cell from P at most) have w ≤ w_P + √2·cell·|∇w|.
// ∇w is measured on the depth image: the pixel's neighbours along x and along y (of a lit class,
// with a finite depth; of each pair the one with the smaller |Δw|, the same surface where one side
// is another object's edge) give the changes (Δu, Δv, Δw), and ∇w solves
// [Δu_x Δv_x; Δu_y Δv_y]·∇w = (Δw_x, Δw_y). So a point Q in P's cell hides P only when
// w_Q > w_P + √2·cell·|∇w| + 2⁻¹⁶·w_P (the last: the floats' rounding of z·k_D, a few units of
// 2⁻²⁴ on a plane facing the camera, with room: 0.4 mm at 25 m). A pixel with no such neighbour
// along an axis, or a surface seen edge-on by the lamp (the system singular), is not shaded.
// A row's candidates as shade_vertical_row's test reads them (floats; lane i of each array is the
// i-th candidate): its point (D, X, Y), each lamp's nearer point Dq where cand (bit k: lamp k's cell
// holds a nearer point, below the top), and its neighbours 0, 1: x − 1, x + 1; 2, 3: y − 1, y + 1
// (valid bit j: of a lit class with a finite depth and D > 0; else D 1, X and Y 0).
struct ShadeCands {
  std::vector<float> D, X, Y, Dq[2], nD[4], nX[4], nY[4];
  std::vector<int32_t> cand, valid;
  void resize(size_t n) {
    for (std::vector<float>* v : {&D, &X, &Y, &Dq[0], &Dq[1], &nD[0], &nD[1], &nD[2], &nD[3], &nX[0], &nX[1], &nX[2],
                                  &nX[3], &nY[0], &nY[1], &nY[2], &nY[3]})
      v->resize(n);
    cand.resize(n), valid.resize(n);
  }
};
// The row's neighbours y − 1 and y + 1 (labels and depth, null outside the frame) and their k_D, k_Y.
struct ShadeRows {
  const uint16_t* id[2];
  const float* z[2];
  float kD[2], kY[2];
};
// The columns 0 .. 16⌊W/16⌋ − 1 of a row whose pixel shade_vertical_row tests further (of a lit
// class, e > 0, its cell in a lamp's map holding a nearer point), sixteen at a time (AVX-512) by
// the scalar test's operations, in order into out; returns their count (shade_vertical_row then
// decides each one, eight at a time by shade_decide_avx512: the same pixels, the same values).
__attribute__((target("avx512f,avx512bw,avx512vl,avx512dq"))) int vertical_shadow_candidates_avx512(
    const BeamVerticalCtx& c, const VerticalShadowMaps& vs, const uint16_t* id, const float* z, const float* e,
    float kD, float kY, int* out, const ShadeRows& ry, ShadeCands& sc) {
  const int W = static_cast<int>(c.xn.size()), Wv = W & ~15;
  const __m512i mlo = _mm512_set1_epi32(static_cast<int32_t>(c.classes & 0xffffffffu)),
                mhi = _mm512_set1_epi32(static_cast<int32_t>(c.classes >> 32)), one = _mm512_set1_epi32(1),
                k32 = _mm512_set1_epi32(32);
  const __m512 zero = _mm512_setzero_ps(), vkD = _mm512_set1_ps(kD), vkY = _mm512_set1_ps(kY), vh = _mm512_set1_ps(c.h),
               vhl = _mm512_set1_ps(c.b.hl), fone = _mm512_set1_ps(1.f), sign = _mm512_set1_ps(-0.f),
               tv2 = _mm512_set1_ps(c.b.tvmax2);
  const double cell = kBeamShadowCellPx / c.g.f_px;
  int n = 0;
  for (int x = 0; x < Wv; x += 16) {
    const __m512i k = _mm512_cvtepu16_epi32(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(id + x)));
    const __m512i bit = _mm512_and_si512(
        _mm512_or_si512(_mm512_srlv_epi32(mlo, k), _mm512_srlv_epi32(mhi, _mm512_sub_epi32(k, k32))), one);
    __mmask16 m = _mm512_test_epi32_mask(bit, bit) & _mm512_cmp_ps_mask(_mm512_loadu_ps(e + x), zero, _CMP_GT_OQ);
    if (!m) continue;
    const __m512 vz = _mm512_loadu_ps(z + x), D = _mm512_mul_ps(vz, vkD), invD = _mm512_div_ps(fone, D);
    const __m512 X = _mm512_mul_ps(vz, _mm512_loadu_ps(c.xn.data() + x));
    const __m512 dy = _mm512_sub_ps(_mm512_sub_ps(vh, _mm512_mul_ps(vz, vkY)), vhl);
    const __m512 v = _mm512_mul_ps(_mm512_xor_ps(dy, sign), invD);
    __mmask16 cand = 0, cl[2] = {0, 0};
    __m512 dql[2] = {zero, zero};
    for (int l = 0; l < 2; ++l) {
      const LampShadowMap& mp = vs.maps[l];
      const __m512 cu = _mm512_mul_ps(
          _mm512_sub_ps(_mm512_mul_ps(_mm512_sub_ps(X, _mm512_set1_ps(mp.xl)), invD), _mm512_set1_ps(mp.u_lo)),
          _mm512_set1_ps(mp.inv_cell));
      const __m512 cv = _mm512_mul_ps(_mm512_sub_ps(v, _mm512_set1_ps(mp.v_lo)), _mm512_set1_ps(mp.inv_cell));
      const __mmask16 in = m & _mm512_cmp_ps_mask(cu, zero, _CMP_GE_OQ) &
                           _mm512_cmp_ps_mask(cu, _mm512_set1_ps(static_cast<float>(mp.nu)), _CMP_LT_OQ) &
                           _mm512_cmp_ps_mask(cv, zero, _CMP_GE_OQ) &
                           _mm512_cmp_ps_mask(cv, _mm512_set1_ps(static_cast<float>(mp.nv)), _CMP_LT_OQ);
      if (!in) continue;
      const __m512i i = _mm512_add_epi32(_mm512_mullo_epi32(_mm512_cvttps_epi32(cv), _mm512_set1_epi32(mp.nu)),
                                         _mm512_cvttps_epi32(cu));
      dql[l] = _mm512_mask_i32gather_ps(zero, in, i, mp.Dmin.get(), 4);
      cl[l] = in & _mm512_cmp_ps_mask(dql[l], D, _CMP_LT_OQ);
      cand |= cl[l];
    }
    // The x-neighbours' bound of the own surface's margin (shade_vertical_row's first test) in
    // float, leaving out only lanes that test certainly drops: where for every neighbour of a lit
    // class the gap is at most half its bound (the scalar test, in double, takes one of them and
    // drops when the gap is at most its bound; half: room for the float's rounding of the small
    // differences Δu, Δv, Δw, relative 10⁻³ at most for steps of a pixel), or no neighbour is lit.
    // The gap here is the scalar's plus 2⁻¹⁹·w (its slack 2⁻¹⁶·w less 2⁻¹⁹·w), more than the
    // float roundings of 1/D_Q and w (a few 2⁻²⁴·w) and of Δw where the surface faces the lamp.
    if (cand && x >= 1 && x + 17 <= W) {
      const __m512 w = invD, wslack = _mm512_mul_ps(w, _mm512_set1_ps(1.f + 0x1p-16f - 0x1p-19f));
      const __m512 Y = _mm512_sub_ps(vh, _mm512_mul_ps(vz, vkY));
      const __m512 c2 = _mm512_set1_ps(static_cast<float>(0.25 * 2 * cell * cell)), big = _mm512_set1_ps(0x1p100f),
                   tiny = _mm512_set1_ps(0x1p-100f);
      __mmask16 keep[2] = {0, 0};
      for (const int sgn : {-1, 1}) {
        const __m512i kn = _mm512_cvtepu16_epi32(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(id + x + sgn)));
        const __m512i bn = _mm512_and_si512(
            _mm512_or_si512(_mm512_srlv_epi32(mlo, kn), _mm512_srlv_epi32(mhi, _mm512_sub_epi32(kn, k32))), one);
        const __m512 zn = _mm512_loadu_ps(z + x + sgn), Dn = _mm512_mul_ps(zn, vkD);
        const __mmask16 valid = cand & _mm512_test_epi32_mask(bn, bn) & _mm512_cmp_ps_mask(zn, zero, _CMP_GT_OQ) &
                                _mm512_cmp_ps_mask(zn, _mm512_set1_ps(kDepthInfinity_m), _CMP_LT_OQ) &
                                _mm512_cmp_ps_mask(Dn, zero, _CMP_GT_OQ);
        const __m512 wn = _mm512_div_ps(fone, Dn), Xn = _mm512_mul_ps(zn, _mm512_loadu_ps(c.xn.data() + x + sgn));
        const __m512 Yn = _mm512_sub_ps(vh, _mm512_mul_ps(zn, vkY));
        const __m512 dw = _mm512_sub_ps(wn, w);
        for (int l = 0; l < 2; ++l) {
          const __m512 xl = _mm512_set1_ps(vs.maps[l].xl);
          const __m512 du = _mm512_sub_ps(_mm512_mul_ps(_mm512_sub_ps(Xn, xl), wn), _mm512_mul_ps(_mm512_sub_ps(X, xl), w));
          const __m512 dv = _mm512_sub_ps(_mm512_mul_ps(_mm512_sub_ps(vhl, Yn), wn), _mm512_mul_ps(_mm512_sub_ps(vhl, Y), w));
          const __m512 gap = _mm512_sub_ps(_mm512_div_ps(fone, dql[l]), wslack);
          const __m512 lhs = _mm512_mul_ps(_mm512_mul_ps(gap, gap), _mm512_add_ps(_mm512_mul_ps(du, du), _mm512_mul_ps(dv, dv)));
          const __m512 rhs = _mm512_mul_ps(c2, _mm512_mul_ps(dw, dw));
          // Kept (maybe shaded by lamp l as this neighbour sees it): gap > 0 and gap > bound/2.
          // (And kept where a square left the float's range, over or under: there the double's
          // test decides.)
          const __mmask16 odd = _mm512_cmp_ps_mask(lhs, big, _CMP_NLT_UQ) | _mm512_cmp_ps_mask(rhs, big, _CMP_NLT_UQ) |
                                _mm512_cmp_ps_mask(lhs, tiny, _CMP_LT_OQ);
          keep[l] |= valid & cl[l] & _mm512_cmp_ps_mask(gap, zero, _CMP_GT_OQ) & (_mm512_cmp_ps_mask(lhs, rhs, _CMP_GT_OQ) | odd);
        }
      }
      // A lamp no lit neighbour keeps is dropped by the scalar test whichever neighbour it takes;
      // a lane with no lit neighbour is dropped by it as well.
      cand &= keep[0] | keep[1];
    }
    if (!cand) continue;
    // The candidates as the scalar test reads them: each lamp's cell below the top, the point,
    // the neighbours (ShadeCands).
    const __m512 Y = _mm512_sub_ps(vh, _mm512_mul_ps(vz, vkY)), dy2 = _mm512_mul_ps(dy, dy), D2 = _mm512_mul_ps(D, D);
    const __mmask16 dy_pos = _mm512_cmp_ps_mask(dy, zero, _CMP_GT_OQ);
    __m512i cb = _mm512_setzero_si512();
    __mmask16 any = 0;
    for (int l = 0; l < 2; ++l) {
      const __m512 dx = _mm512_sub_ps(X, _mm512_set1_ps(vs.maps[l].xl));
      const __m512 r = _mm512_mul_ps(_mm512_add_ps(_mm512_mul_ps(dx, dx), D2), tv2);
      const __mmask16 top = c.b.tvmax >= 0 ? dy_pos & _mm512_cmp_ps_mask(dy2, r, _CMP_GT_OQ)
                                           : dy_pos | _mm512_cmp_ps_mask(dy2, r, _CMP_LT_OQ);
      const __mmask16 ck = cl[l] & ~top;
      cb = _mm512_mask_mov_epi32(cb, ck, _mm512_or_si512(cb, _mm512_set1_epi32(1 << l)));
      any |= ck;
    }
    const __mmask16 o = cand & any;
    if (!o) continue;
    compress_store_ps(sc.D.data() + n, o, D);
    compress_store_ps(sc.X.data() + n, o, X);
    compress_store_ps(sc.Y.data() + n, o, Y);
    compress_store_ps(sc.Dq[0].data() + n, o, dql[0]);
    compress_store_ps(sc.Dq[1].data() + n, o, dql[1]);
    compress_store_epi32(sc.cand.data() + n, o, cb);
    __m512i vb = _mm512_setzero_si512();
    for (int j = 0; j < 4; ++j) {
      // The neighbour's row and columns: x ± 1 on this row, x on rows y ∓ 1.
      const int dxn = j == 0 ? -1 : j == 1 ? 1 : 0;
      const uint16_t* idr = j < 2 ? id : ry.id[j - 2];
      const float* zr = j < 2 ? z : ry.z[j - 2];
      const float kDr = j < 2 ? kD : ry.kD[j - 2], kYr = j < 2 ? kY : ry.kY[j - 2];
      __mmask16 inside = idr ? o : 0;
      if (j == 0 && x == 0) inside &= static_cast<__mmask16>(0xfffe);
      if (j == 1 && x + 16 >= W) inside &= static_cast<__mmask16>((1u << (W - 1 - x)) - 1);
      const __m512i kn = _mm512_cvtepu16_epi32(_mm256_maskz_loadu_epi16(inside, idr ? idr + x + dxn : id));
      const __m512i bn = _mm512_and_si512(
          _mm512_or_si512(_mm512_srlv_epi32(mlo, kn), _mm512_srlv_epi32(mhi, _mm512_sub_epi32(kn, k32))), one);
      const __m512 zn = _mm512_maskz_loadu_ps(inside, zr ? zr + x + dxn : z), Dn = _mm512_mul_ps(zn, _mm512_set1_ps(kDr));
      const __mmask16 valid = inside & _mm512_test_epi32_mask(bn, bn) & _mm512_cmp_ps_mask(zn, zero, _CMP_GT_OQ) &
                              _mm512_cmp_ps_mask(zn, _mm512_set1_ps(kDepthInfinity_m), _CMP_LT_OQ) &
                              _mm512_cmp_ps_mask(Dn, zero, _CMP_GT_OQ);
      const __m512 xnn = _mm512_maskz_loadu_ps(inside, c.xn.data() + x + dxn);
      compress_store_ps(sc.nD[j].data() + n, o, _mm512_mask_mov_ps(fone, valid, Dn));
      compress_store_ps(sc.nX[j].data() + n, o, _mm512_maskz_mov_ps(valid, _mm512_mul_ps(zn, xnn)));
      compress_store_ps(sc.nY[j].data() + n, o,
                                    _mm512_maskz_mov_ps(valid, _mm512_sub_ps(vh, _mm512_mul_ps(zn, _mm512_set1_ps(kYr)))));
      vb = _mm512_mask_mov_epi32(vb, valid, _mm512_or_si512(vb, _mm512_set1_epi32(1 << j)));
    }
    compress_store_epi32(sc.valid.data() + n, o, vb);
    compress_store_epi32(out + n, o, columns16(x));
    n += __builtin_popcount(o);
  }
  return n;
}
// vertical_shadow_candidates_avx512 on AVX2: the columns 0 .. 8⌊W/8⌋ − 1 of a row that
// shade_vertical_row tests further, eight at a time, in order into out, with what the decision
// reads (ShadeCands, the same values); returns their count. A column is left out only where
// pixel() would leave its e as it is: not of a lit class, e ≤ 0, no lamp whose cell holds a nearer
// point below the top (pixel()'s own float operations), or (the AVX-512 candidates' float test of
// the x-neighbours' bound, on the lamps still in) every such lamp dropped by the bound whichever
// x-neighbour pixel() takes. The candidates' values are stored lane by lane (AVX2 has no
// compress), their neighbours (ShadeCands: 0, 1 x ∓ 1, 2, 3 rows y ∓ 1) read one by one.
__attribute__((target("avx2"))) int vertical_shadow_candidates_avx2(const BeamVerticalCtx& c,
                                                                    const VerticalShadowMaps& vs, const uint16_t* id,
                                                                    const float* z, const float* e, float kD, float kY,
                                                                    int* out, const ShadeRows& ry, ShadeCands& sc) {
  const int W = static_cast<int>(c.xn.size()), Wv = W & ~7;
  const __m256i mlo = _mm256_set1_epi32(static_cast<int32_t>(c.classes & 0xffffffffu)),
                mhi = _mm256_set1_epi32(static_cast<int32_t>(c.classes >> 32)), one = _mm256_set1_epi32(1),
                k32 = _mm256_set1_epi32(32);
  const __m256 zero = _mm256_setzero_ps(), vkD = _mm256_set1_ps(kD), vkY = _mm256_set1_ps(kY), vh = _mm256_set1_ps(c.h),
               vhl = _mm256_set1_ps(c.b.hl), fone = _mm256_set1_ps(1.f), sign = _mm256_set1_ps(-0.f),
               tv2 = _mm256_set1_ps(c.b.tvmax2), zinf = _mm256_set1_ps(kDepthInfinity_m);
  const double cell = kBeamShadowCellPx / c.g.f_px;
  // The class bits of eight labels as lane masks (0 for ids of 64 and above).
  auto lit_class = [&](const uint16_t* p) __attribute__((target("avx2"))) {
    const __m256i k = _mm256_cvtepu16_epi32(_mm_loadu_si128(reinterpret_cast<const __m128i*>(p)));
    return _mm256_castsi256_ps(_mm256_cmpeq_epi32(
        _mm256_and_si256(_mm256_or_si256(_mm256_srlv_epi32(mlo, k), _mm256_srlv_epi32(mhi, _mm256_sub_epi32(k, k32))), one),
        one));
  };
  int n = 0;
  for (int x = 0; x < Wv; x += 8) {
    const __m256 m = _mm256_and_ps(lit_class(id + x), _mm256_cmp_ps(_mm256_loadu_ps(e + x), zero, _CMP_GT_OQ));
    if (!_mm256_movemask_ps(m)) continue;
    const __m256 vz = _mm256_loadu_ps(z + x), D = _mm256_mul_ps(vz, vkD), invD = _mm256_div_ps(fone, D);
    const __m256 X = _mm256_mul_ps(vz, _mm256_loadu_ps(c.xn.data() + x));
    const __m256 dy = _mm256_sub_ps(_mm256_sub_ps(vh, _mm256_mul_ps(vz, vkY)), vhl);
    const __m256 v = _mm256_mul_ps(_mm256_xor_ps(dy, sign), invD);
    const __m256 dy_pos = _mm256_cmp_ps(dy, zero, _CMP_GT_OQ), dy2 = _mm256_mul_ps(dy, dy), D2 = _mm256_mul_ps(D, D);
    __m256 ck[2] = {zero, zero}, dql[2] = {zero, zero};
    for (int l = 0; l < 2; ++l) {
      const LampShadowMap& mp = vs.maps[l];
      const __m256 dx = _mm256_sub_ps(X, _mm256_set1_ps(mp.xl));
      const __m256 cu = _mm256_mul_ps(_mm256_sub_ps(_mm256_mul_ps(dx, invD), _mm256_set1_ps(mp.u_lo)),
                                      _mm256_set1_ps(mp.inv_cell));
      const __m256 cv = _mm256_mul_ps(_mm256_sub_ps(v, _mm256_set1_ps(mp.v_lo)), _mm256_set1_ps(mp.inv_cell));
      const __m256 in = _mm256_and_ps(
          _mm256_and_ps(m, _mm256_and_ps(_mm256_cmp_ps(cu, zero, _CMP_GE_OQ),
                                         _mm256_cmp_ps(cu, _mm256_set1_ps(static_cast<float>(mp.nu)), _CMP_LT_OQ))),
          _mm256_and_ps(_mm256_cmp_ps(cv, zero, _CMP_GE_OQ),
                        _mm256_cmp_ps(cv, _mm256_set1_ps(static_cast<float>(mp.nv)), _CMP_LT_OQ)));
      if (!_mm256_movemask_ps(in)) continue;
      const __m256i i = _mm256_add_epi32(_mm256_mullo_epi32(_mm256_cvttps_epi32(cv), _mm256_set1_epi32(mp.nu)),
                                         _mm256_cvttps_epi32(cu));
      dql[l] = _mm256_mask_i32gather_ps(zero, mp.Dmin.get(), i, in, 4);
      // Below the top (beam_above_top(dy, dx² + D², b) false), as pixel() asks it.
      const __m256 r = _mm256_mul_ps(_mm256_add_ps(_mm256_mul_ps(dx, dx), D2), tv2);
      const __m256 top = c.b.tvmax >= 0 ? _mm256_and_ps(dy_pos, _mm256_cmp_ps(dy2, r, _CMP_GT_OQ))
                                        : _mm256_or_ps(dy_pos, _mm256_cmp_ps(dy2, r, _CMP_LT_OQ));
      ck[l] = _mm256_andnot_ps(top, _mm256_and_ps(in, _mm256_cmp_ps(dql[l], D, _CMP_LT_OQ)));
    }
    __m256 cand = _mm256_or_ps(ck[0], ck[1]);
    if (!_mm256_movemask_ps(cand)) continue;
    // The x-neighbours' bound in float (vertical_shadow_candidates_avx512's test and its reasoning:
    // a lamp is left out only where every lit x-neighbour's gap is at most half its bound).
    if (x >= 1 && x + 9 <= W) {
      const __m256 w = invD, wslack = _mm256_mul_ps(w, _mm256_set1_ps(1.f + 0x1p-16f - 0x1p-19f));
      const __m256 Y = _mm256_sub_ps(vh, _mm256_mul_ps(vz, vkY));
      const __m256 c2 = _mm256_set1_ps(static_cast<float>(0.25 * 2 * cell * cell)), big = _mm256_set1_ps(0x1p100f),
                   tiny = _mm256_set1_ps(0x1p-100f);
      __m256 keep[2] = {zero, zero};
      for (const int sgn : {-1, 1}) {
        const __m256 zn = _mm256_loadu_ps(z + x + sgn), Dn = _mm256_mul_ps(zn, vkD);
        const __m256 valid = _mm256_and_ps(
            _mm256_and_ps(lit_class(id + x + sgn), _mm256_cmp_ps(zn, zero, _CMP_GT_OQ)),
            _mm256_and_ps(_mm256_cmp_ps(zn, zinf, _CMP_LT_OQ), _mm256_cmp_ps(Dn, zero, _CMP_GT_OQ)));
        const __m256 wn = _mm256_div_ps(fone, Dn), Xn = _mm256_mul_ps(zn, _mm256_loadu_ps(c.xn.data() + x + sgn));
        const __m256 Yn = _mm256_sub_ps(vh, _mm256_mul_ps(zn, vkY));
        const __m256 dw = _mm256_sub_ps(wn, w);
        for (int l = 0; l < 2; ++l) {
          const __m256 xl = _mm256_set1_ps(vs.maps[l].xl);
          const __m256 du = _mm256_sub_ps(_mm256_mul_ps(_mm256_sub_ps(Xn, xl), wn), _mm256_mul_ps(_mm256_sub_ps(X, xl), w));
          const __m256 dv = _mm256_sub_ps(_mm256_mul_ps(_mm256_sub_ps(vhl, Yn), wn), _mm256_mul_ps(_mm256_sub_ps(vhl, Y), w));
          const __m256 gap = _mm256_sub_ps(_mm256_div_ps(fone, dql[l]), wslack);
          const __m256 lhs =
              _mm256_mul_ps(_mm256_mul_ps(gap, gap), _mm256_add_ps(_mm256_mul_ps(du, du), _mm256_mul_ps(dv, dv)));
          const __m256 rhs = _mm256_mul_ps(c2, _mm256_mul_ps(dw, dw));
          const __m256 odd = _mm256_or_ps(
              _mm256_or_ps(_mm256_cmp_ps(lhs, big, _CMP_NLT_UQ), _mm256_cmp_ps(rhs, big, _CMP_NLT_UQ)),
              _mm256_cmp_ps(lhs, tiny, _CMP_LT_OQ));
          keep[l] = _mm256_or_ps(
              keep[l], _mm256_and_ps(_mm256_and_ps(valid, ck[l]),
                                     _mm256_and_ps(_mm256_cmp_ps(gap, zero, _CMP_GT_OQ),
                                                   _mm256_or_ps(_mm256_cmp_ps(lhs, rhs, _CMP_GT_OQ), odd))));
        }
      }
      cand = _mm256_or_ps(keep[0], keep[1]);
    }
    unsigned o = static_cast<unsigned>(_mm256_movemask_ps(cand));
    if (!o) continue;
    alignas(32) float vD[8], vX[8], vY[8], vq[2][8];
    _mm256_store_ps(vD, D), _mm256_store_ps(vX, X), _mm256_store_ps(vY, _mm256_sub_ps(vh, _mm256_mul_ps(vz, vkY)));
    _mm256_store_ps(vq[0], dql[0]), _mm256_store_ps(vq[1], dql[1]);
    const unsigned ck0 = static_cast<unsigned>(_mm256_movemask_ps(ck[0])), ck1 = static_cast<unsigned>(_mm256_movemask_ps(ck[1]));
    for (; o; o &= o - 1) {
      const int i = __builtin_ctz(o), xi = x + i;
      out[n] = xi;
      sc.D[n] = vD[i], sc.X[n] = vX[i], sc.Y[n] = vY[i], sc.Dq[0][n] = vq[0][i], sc.Dq[1][n] = vq[1][i];
      sc.cand[n] = static_cast<int32_t>((ck0 >> i & 1) | (ck1 >> i & 1) << 1);
      int32_t vb = 0;
      for (int j = 0; j < 4; ++j) {
        // The neighbour: x ∓ 1 on this row, x on rows y ∓ 1 (valid: inside the frame, of a lit
        // class, 0 < z < kDepthInfinity_m, D > 0; else D 1, X and Y 0, as the AVX-512 candidates').
        const int xx = j == 0 ? xi - 1 : j == 1 ? xi + 1 : xi;
        const uint16_t* idr = j < 2 ? id : ry.id[j - 2];
        const float* zr = j < 2 ? z : ry.z[j - 2];
        const float kDr = j < 2 ? kD : ry.kD[j - 2], kYr = j < 2 ? kY : ry.kY[j - 2];
        bool valid = idr && xx >= 0 && xx < W && idr[xx] < 64 && (c.classes >> idr[xx] & 1);
        const float zn = valid ? zr[xx] : 0.f, Dn = zn * kDr;
        valid = valid && zn > 0 && zn < kDepthInfinity_m && Dn > 0;
        sc.nD[j][n] = valid ? Dn : 1.f;
        sc.nX[j][n] = valid ? zn * c.xn[xx] : 0.f;
        sc.nY[j][n] = valid ? c.h - zn * kYr : 0.f;
        vb |= static_cast<int32_t>(valid) << j;
      }
      sc.valid[n++] = vb;
    }
  }
  return n;
}
// Up to eight candidates of shade_vertical_row (a lit pixel whose cell holds a nearer point, below
// the top) with their neighbours, each lane as the scalar test reads them (floats), for
// shade_decide_avx512. Neighbours 0, 1: x − 1, x + 1; 2, 3: y − 1, y + 1 (valid: of a lit class
// with a finite depth and D > 0).
struct ShadeBatch {
  alignas(32) float D[8], X[8], Y[8], Dq[2][8];
  alignas(32) float nD[4][8], nX[4][8], nY[4][8];
  uint8_t cand[2] = {0, 0}, valid[4] = {0, 0, 0, 0};
  int x[8];
};
// Eight floats widened to double; |v|.
[[gnu::always_inline]] __attribute__((target("avx512f"))) inline __m512d ld(const float* f) {
  return _mm512_cvtps_pd(_mm256_load_ps(f));
}
[[gnu::always_inline]] __attribute__((target("avx512f,avx512dq"))) inline __m512d abs_pd(__m512d v) {
  return _mm512_andnot_pd(_mm512_set1_pd(-0.0), v);
}
// shade_vertical_row's decision on eight lanes in double (AVX-512): the same operations per lane
// (the neighbour of each axis with the smaller |Δw|, the x-neighbours' bound, the plane's gradient
// from the 2 × 2 system), so the same lamps hidden; returns each lamp's mask of hidden lanes.
__attribute__((target("avx512f,avx512bw,avx512vl,avx512dq"))) void shade_decide_avx512(const ShadeBatch& t,
                                                                                        const BeamF& b, double cell,
                                                                                        __mmask8 sh[2]) {
  const __m512d one = _mm512_set1_pd(1.0), zero = _mm512_setzero_pd(), slack = _mm512_set1_pd(0x1p-16),
                hl = _mm512_set1_pd(static_cast<double>(b.hl)), c2 = _mm512_set1_pd(2 * cell * cell),
                s2c = _mm512_set1_pd(std::sqrt(2.0) * cell);
  const __m512d X = ld(t.X), w = _mm512_div_pd(one, ld(t.D));
  // (b.hl − Y) in float, as the scalar test's.
  const __m512d hlY = _mm512_cvtps_pd(_mm256_sub_ps(_mm256_set1_ps(b.hl), _mm256_load_ps(t.Y)));
  __m512d nX[2], nY[2], nw[2];
  __mmask8 have[2];
  for (int a = 0; a < 2; ++a) {
    have[a] = 0;
    nX[a] = nY[a] = nw[a] = zero;
    for (int s = 0; s < 2; ++s) {
      const int j = 2 * a + s;
      const __m512d wn = _mm512_div_pd(one, ld(t.nD[j]));
      const __mmask8 take =
          t.valid[j] & static_cast<__mmask8>(~have[a] | _mm512_cmp_pd_mask(abs_pd(_mm512_sub_pd(wn, w)),
                                                                         abs_pd(_mm512_sub_pd(nw[a], w)), _CMP_LT_OQ));
      nX[a] = _mm512_mask_mov_pd(nX[a], take, ld(t.nX[j]));
      nY[a] = _mm512_mask_mov_pd(nY[a], take, ld(t.nY[j]));
      nw[a] = _mm512_mask_mov_pd(nw[a], take, wn);
      have[a] |= t.valid[j];
    }
  }
  const __m512d wsl = _mm512_mul_pd(w, slack);
  __mmask8 cand[2];
  for (int k = 0; k < 2; ++k) {
    const __m512d xl = _mm512_set1_pd(static_cast<double>(b.xl[k]));
    const __m512d iq = _mm512_div_pd(one, ld(t.Dq[k]));
    // The x-neighbour's bound.
    const __m512d du = _mm512_sub_pd(_mm512_mul_pd(_mm512_sub_pd(nX[0], xl), nw[0]), _mm512_mul_pd(_mm512_sub_pd(X, xl), w));
    const __m512d dv = _mm512_sub_pd(_mm512_mul_pd(_mm512_sub_pd(hl, nY[0]), nw[0]), _mm512_mul_pd(hlY, w));
    const __m512d dw = _mm512_sub_pd(nw[0], w), gap = _mm512_sub_pd(_mm512_sub_pd(iq, w), wsl);
    const __m512d lhs = _mm512_mul_pd(_mm512_mul_pd(gap, gap), _mm512_add_pd(_mm512_mul_pd(du, du), _mm512_mul_pd(dv, dv)));
    const __m512d rhs = _mm512_mul_pd(_mm512_mul_pd(c2, dw), dw);
    cand[k] = t.cand[k] & have[0] & _mm512_cmp_pd_mask(gap, zero, _CMP_GT_OQ) & _mm512_cmp_pd_mask(lhs, rhs, _CMP_NLE_UQ);
    // The plane's gradient from both neighbours.
    const __m512d u0 = _mm512_mul_pd(_mm512_sub_pd(X, xl), w), v0 = _mm512_mul_pd(hlY, w);
    __m512d Du[2], Dv[2], Dw[2];
    for (int a = 0; a < 2; ++a) {
      Du[a] = _mm512_sub_pd(_mm512_mul_pd(_mm512_sub_pd(nX[a], xl), nw[a]), u0);
      Dv[a] = _mm512_sub_pd(_mm512_mul_pd(_mm512_sub_pd(hl, nY[a]), nw[a]), v0);
      Dw[a] = _mm512_sub_pd(nw[a], w);
    }
    const __m512d det = _mm512_sub_pd(_mm512_mul_pd(Du[0], Dv[1]), _mm512_mul_pd(Dv[0], Du[1]));
    const __m512d gu = _mm512_div_pd(_mm512_sub_pd(_mm512_mul_pd(Dw[0], Dv[1]), _mm512_mul_pd(Dv[0], Dw[1])), det);
    const __m512d gv = _mm512_div_pd(_mm512_sub_pd(_mm512_mul_pd(Du[0], Dw[1]), _mm512_mul_pd(Dw[0], Du[1])), det);
    const __m512d margin =
        _mm512_add_pd(_mm512_mul_pd(s2c, _mm512_sqrt_pd(_mm512_add_pd(_mm512_mul_pd(gu, gu), _mm512_mul_pd(gv, gv)))), wsl);
    sh[k] = cand[k] & have[1] & _mm512_cmp_pd_mask(abs_pd(det), zero, _CMP_GT_OQ) &
            _mm512_cmp_pd_mask(iq, _mm512_add_pd(w, margin), _CMP_GT_OQ);
  }
}
// shade_decide_avx512 on AVX2: its operations per lane in the same order, in two halves of four
// doubles (lanes h .. h + 3 of t), the lane masks as all-ones lanes; returns each lamp's bits of
// hidden lanes (bit l: lane l). So the same lamps hidden as shade_decide_avx512 and pixel().
// Four floats widened to double.
[[gnu::always_inline]] __attribute__((target("avx2"))) inline __m256d ld4(const float* f) {
  return _mm256_cvtps_pd(_mm_load_ps(f));
}
__attribute__((target("avx2"))) void shade_decide_avx2(const ShadeBatch& t, const BeamF& b, double cell,
                                                       unsigned sh[2]) {
  const __m256d one = _mm256_set1_pd(1.0), zero = _mm256_setzero_pd(), slack = _mm256_set1_pd(0x1p-16),
                hl = _mm256_set1_pd(static_cast<double>(b.hl)), c2 = _mm256_set1_pd(2 * cell * cell),
                s2c = _mm256_set1_pd(std::sqrt(2.0) * cell), absmask = _mm256_castsi256_pd(_mm256_set1_epi64x(INT64_MAX));
  const __m256i lane_bit = _mm256_setr_epi64x(1, 2, 4, 8);
  // Bits h .. h + 3 of `bits` as lanes.
  auto lanes = [&](unsigned bits, int h) __attribute__((target("avx2"))) {
    return _mm256_castsi256_pd(
        _mm256_cmpeq_epi64(_mm256_and_si256(_mm256_set1_epi64x(bits >> h), lane_bit), lane_bit));
  };
  sh[0] = sh[1] = 0;
  for (int h = 0; h < 8; h += 4) {
    const __m256d X = ld4(t.X + h), w = _mm256_div_pd(one, ld4(t.D + h));
    // (b.hl − Y) in float, as the scalar test's.
    const __m256d hlY = _mm256_cvtps_pd(_mm_sub_ps(_mm_set1_ps(b.hl), _mm_load_ps(t.Y + h)));
    __m256d nX[2], nY[2], nw[2], have[2];
    for (int a = 0; a < 2; ++a) {
      have[a] = nX[a] = nY[a] = nw[a] = zero;
      for (int s = 0; s < 2; ++s) {
        const int j = 2 * a + s;
        const __m256d wn = _mm256_div_pd(one, ld4(t.nD[j] + h)), valid = lanes(t.valid[j], h);
        const __m256d take = _mm256_and_pd(
            valid, _mm256_or_pd(_mm256_xor_pd(have[a], _mm256_castsi256_pd(_mm256_set1_epi64x(-1))),
                                _mm256_cmp_pd(_mm256_and_pd(_mm256_sub_pd(wn, w), absmask),
                                              _mm256_and_pd(_mm256_sub_pd(nw[a], w), absmask), _CMP_LT_OQ)));
        nX[a] = _mm256_blendv_pd(nX[a], ld4(t.nX[j] + h), take);
        nY[a] = _mm256_blendv_pd(nY[a], ld4(t.nY[j] + h), take);
        nw[a] = _mm256_blendv_pd(nw[a], wn, take);
        have[a] = _mm256_or_pd(have[a], valid);
      }
    }
    const __m256d wsl = _mm256_mul_pd(w, slack);
    for (int k = 0; k < 2; ++k) {
      const __m256d xl = _mm256_set1_pd(static_cast<double>(b.xl[k]));
      const __m256d iq = _mm256_div_pd(one, ld4(t.Dq[k] + h));
      // The x-neighbour's bound.
      const __m256d du = _mm256_sub_pd(_mm256_mul_pd(_mm256_sub_pd(nX[0], xl), nw[0]), _mm256_mul_pd(_mm256_sub_pd(X, xl), w));
      const __m256d dv = _mm256_sub_pd(_mm256_mul_pd(_mm256_sub_pd(hl, nY[0]), nw[0]), _mm256_mul_pd(hlY, w));
      const __m256d dw = _mm256_sub_pd(nw[0], w), gap = _mm256_sub_pd(_mm256_sub_pd(iq, w), wsl);
      const __m256d lhs = _mm256_mul_pd(_mm256_mul_pd(gap, gap), _mm256_add_pd(_mm256_mul_pd(du, du), _mm256_mul_pd(dv, dv)));
      const __m256d rhs = _mm256_mul_pd(_mm256_mul_pd(c2, dw), dw);
      const __m256d cand = _mm256_and_pd(
          _mm256_and_pd(lanes(t.cand[k], h), have[0]),
          _mm256_and_pd(_mm256_cmp_pd(gap, zero, _CMP_GT_OQ), _mm256_cmp_pd(lhs, rhs, _CMP_NLE_UQ)));
      // The plane's gradient from both neighbours.
      const __m256d u0 = _mm256_mul_pd(_mm256_sub_pd(X, xl), w), v0 = _mm256_mul_pd(hlY, w);
      __m256d Du[2], Dv[2], Dw[2];
      for (int a = 0; a < 2; ++a) {
        Du[a] = _mm256_sub_pd(_mm256_mul_pd(_mm256_sub_pd(nX[a], xl), nw[a]), u0);
        Dv[a] = _mm256_sub_pd(_mm256_mul_pd(_mm256_sub_pd(hl, nY[a]), nw[a]), v0);
        Dw[a] = _mm256_sub_pd(nw[a], w);
      }
      const __m256d det = _mm256_sub_pd(_mm256_mul_pd(Du[0], Dv[1]), _mm256_mul_pd(Dv[0], Du[1]));
      const __m256d gu = _mm256_div_pd(_mm256_sub_pd(_mm256_mul_pd(Dw[0], Dv[1]), _mm256_mul_pd(Dv[0], Dw[1])), det);
      const __m256d gv = _mm256_div_pd(_mm256_sub_pd(_mm256_mul_pd(Du[0], Dw[1]), _mm256_mul_pd(Dw[0], Du[1])), det);
      const __m256d margin =
          _mm256_add_pd(_mm256_mul_pd(s2c, _mm256_sqrt_pd(_mm256_add_pd(_mm256_mul_pd(gu, gu), _mm256_mul_pd(gv, gv)))), wsl);
      const __m256d hid = _mm256_and_pd(
          _mm256_and_pd(cand, have[1]),
          _mm256_and_pd(_mm256_cmp_pd(_mm256_and_pd(det, absmask), zero, _CMP_GT_OQ),
                        _mm256_cmp_pd(iq, _mm256_add_pd(w, margin), _CMP_GT_OQ)));
      sh[k] |= static_cast<unsigned>(_mm256_movemask_pd(hid)) << h;
    }
  }
}
// counts[0], [1], [2] (zeroed by the caller) take the row's pixels shaded from the left lamp only, the
// right only, both (sh − 1 for the hidden lamps' bits sh = 1, 2, 3): one add per shaded pixel.
void shade_vertical_row(const BeamVerticalCtx& c, const VerticalShadowMaps& vs, const ImageU16& labels,
                        const ImageF& depth, int y, double cp, double sp, bool avx512, bool avx2, float* e,
                        const float* t0, const float* t1, int* counts) {
  const BeamF& b = c.b;
  const CameraGeometry& g = c.g;
  const int W = labels.width(), H = labels.height();
  const double cell = kBeamShadowCellPx / g.f_px;
  auto ks = [&](int yy, float* kD, float* kY) {
    const double yn = (yy - g.cy_px) / g.f_px;
    *kD = static_cast<float>(cp - yn * sp), *kY = static_cast<float>(sp + yn * cp);
  };
  if (c.h > b.hl) {  // a row with no point in the maps (vertical_shadow_maps' test)
    const double yn = (y - g.cy_px) / g.f_px;
    if (!((sp + yn * cp) / (cp - yn * sp) >= vs.r_min)) return;
  }
  float kD, kY;
  ks(y, &kD, &kY);
  const uint16_t* id = labels.row(y);
  const float* z = depth.row(y);
  // A neighbour's point (X, Y, w), false where it is not of a lit class or has no finite depth.
  auto point = [&](int xx, int yy, double* X, double* Y, double* w) {
    if (xx < 0 || xx >= W || yy < 0 || yy >= H) return false;
    const int k = labels.at(xx, yy);
    if (k >= 64 || !(c.classes >> k & 1)) return false;
    const float zz = depth.at(xx, yy);
    if (!(zz > 0) || !(zz < kDepthInfinity_m)) return false;
    float kDn, kYn;
    ks(yy, &kDn, &kYn);
    const float D = zz * kDn;
    if (!(D > 0)) return false;
    *X = zz * c.xn[xx], *Y = c.h - zz * kYn, *w = 1.0 / D;
    return true;
  };
  auto pixel = [&](int x) {
    if (id[x] >= 64 || !(c.classes >> id[x] & 1) || !(e[x] > 0)) return;
    const float zz = z[x], D = zz * kD, invD = 1.f / D, X = zz * c.xn[x], Y = c.h - zz * kY;
    const float dy = Y - b.hl, v = -dy * invD;
    float Dq[2] = {INFINITY, INFINITY};
    unsigned cand = 0;
    for (int k = 0; k < 2; ++k) {
      const LampShadowMap& m = vs.maps[k];
      const int i = m.cell((X - m.xl) * invD, v);
      if (i < 0 || !(m.Dmin[i] < D)) continue;
      const float dx = X - m.xl;
      if (!beam_above_top(dy, dx * dx + D * D, b)) cand |= 1u << k, Dq[k] = m.Dmin[i];
    }
    if (!cand) return;
    // The own surface's neighbours along x (first: of the same row, and a lower bound of the
    // margin: the plane's slope along that step, |Δw_x|/|(Δu_x, Δv_x)| ≤ |∇w|, drops most of the
    // surface's own points before the neighbours along y are read) and y.
    const double w = 1.0 / D;
    double nX[2], nY[2], nw[2];
    bool have[2] = {false, false};
    for (const int sgn : {-1, 1}) {  // (point()'s test on this row's pointers and k_D, k_Y)
      const int xx = x + sgn;
      if (xx < 0 || xx >= W || id[xx] >= 64 || !(c.classes >> id[xx] & 1)) continue;
      const float zn = z[xx], Dn = zn * kD;
      if (!(zn > 0) || !(zn < kDepthInfinity_m) || !(Dn > 0)) continue;
      const double wn = 1.0 / Dn;
      if (!have[0] || std::abs(wn - w) < std::abs(nw[0] - w))
        nX[0] = zn * c.xn[xx], nY[0] = c.h - zn * kY, nw[0] = wn, have[0] = true;
    }
    if (!have[0]) return;
    for (int k = 0; k < 2; ++k) {
      if (!(cand >> k & 1)) continue;
      const double xl = b.xl[k], du = (nX[0] - xl) * nw[0] - (X - xl) * w, dv = (b.hl - nY[0]) * nw[0] - (b.hl - Y) * w;
      const double dw = nw[0] - w, gap = 1.0 / Dq[k] - w - std::ldexp(w, -16);
      // Not shaded when gap ≤ √2·cell·|dw|/|(du, dv)| (squared: both sides ≥ 0).
      if (!(gap > 0) || gap * gap * (du * du + dv * dv) <= 2 * cell * cell * dw * dw) cand &= ~(1u << k);
    }
    if (!cand) return;
    for (int a = 1; a < 2; ++a)
      for (const int sgn : {-1, 1}) {
        double Xn, Yn, wn;
        if (!point(a == 0 ? x + sgn : x, a == 0 ? y : y + sgn, &Xn, &Yn, &wn)) continue;
        if (!have[a] || std::abs(wn - w) < std::abs(nw[a] - w)) nX[a] = Xn, nY[a] = Yn, nw[a] = wn, have[a] = true;
      }
    if (!have[0] || !have[1]) return;
    unsigned sh = 0;
    for (int k = 0; k < 2; ++k) {
      if (!(cand >> k & 1)) continue;
      const double xl = b.xl[k], u0 = (X - xl) * w, v0 = (b.hl - Y) * w;
      double du[2], dv[2], dw[2];
      for (int a = 0; a < 2; ++a)
        du[a] = (nX[a] - xl) * nw[a] - u0, dv[a] = (b.hl - nY[a]) * nw[a] - v0, dw[a] = nw[a] - w;
      const double det = du[0] * dv[1] - dv[0] * du[1];
      if (!(std::abs(det) > 0)) continue;
      const double gu = (dw[0] * dv[1] - dv[0] * dw[1]) / det, gv = (du[0] * dw[1] - dw[0] * du[1]) / det;
      const double margin = std::sqrt(2.0) * cell * std::sqrt(gu * gu + gv * gv) + std::ldexp(w, -16);
      if (1.0 / Dq[k] > w + margin) sh |= 1u << k;
    }
    if (!sh) return;
    ++counts[sh - 1];
    if (sh == 3) {
      e[x] = 0.f;
      return;
    }
    e[x] = sh == 1 ? t1[x] : t0[x];
  };
  int x0 = 0;
  if (avx512 || avx2) {
    thread_local std::vector<int> cols;
    cols.resize(static_cast<size_t>(W) + 16);
    // The candidates with their neighbours as pixel() reads them (ShadeCands, sixteen at a time,
    // or eight with AVX2), then decided eight at a time in vector double (shade_decide_avx512, or
    // shade_decide_avx2 in halves of four: the same lamps hidden).
    ShadeRows ry;
    for (int s = 0; s < 2; ++s) {
      const int yy = y + (s == 0 ? -1 : 1);
      const bool in = yy >= 0 && yy < H;
      ry.id[s] = in ? labels.row(yy) : nullptr, ry.z[s] = in ? depth.row(yy) : nullptr;
      ks(yy, &ry.kD[s], &ry.kY[s]);
    }
    thread_local ShadeCands sc;
    sc.resize(static_cast<size_t>(W) + 16);
    const int n = avx512 ? vertical_shadow_candidates_avx512(c, vs, id, z, e, kD, kY, cols.data(), ry, sc)
                         : vertical_shadow_candidates_avx2(c, vs, id, z, e, kD, kY, cols.data(), ry, sc);
    ShadeBatch t;
    for (int j0 = 0; j0 < n; j0 += 8) {
      const int m = std::min(8, n - j0);
      t.cand[0] = t.cand[1] = 0;
      for (uint8_t& v : t.valid) v = 0;
      for (int l = 0; l < 8; ++l) {
        if (l >= m) {  // unused lanes: finite values, no lamp
          t.D[l] = t.X[l] = t.Y[l] = 1.f, t.Dq[0][l] = t.Dq[1][l] = 1.f;
          for (int j = 0; j < 4; ++j) t.nD[j][l] = 1.f, t.nX[j][l] = t.nY[j][l] = 0.f;
          continue;
        }
        const int i = j0 + l;
        t.x[l] = cols[i], t.D[l] = sc.D[i], t.X[l] = sc.X[i], t.Y[l] = sc.Y[i];
        for (int k = 0; k < 2; ++k) {
          t.Dq[k][l] = sc.Dq[k][i];
          t.cand[k] |= static_cast<uint8_t>((sc.cand[i] >> k & 1) << l);
        }
        for (int j = 0; j < 4; ++j) {
          t.nD[j][l] = sc.nD[j][i], t.nX[j][l] = sc.nX[j][i], t.nY[j][l] = sc.nY[j][i];
          t.valid[j] |= static_cast<uint8_t>((sc.valid[i] >> j & 1) << l);
        }
      }
      unsigned sh[2];
      if (avx512) {
        __mmask8 s8[2];
        shade_decide_avx512(t, b, cell, s8);
        sh[0] = s8[0], sh[1] = s8[1];
      } else {
        shade_decide_avx2(t, b, cell, sh);
      }
      for (int l = 0; l < m; ++l) {
        const unsigned s = (sh[0] >> l & 1) | (sh[1] >> l & 1) << 1;
        if (!s) continue;
        ++counts[s - 1];
        e[t.x[l]] = s == 3 ? 0.f : s == 1 ? t1[t.x[l]] : t0[t.x[l]];
      }
    }
    x0 = avx512 ? W & ~15 : W & ~7;
  }
  for (int x = x0; x < W; ++x) pixel(x);
}
}  // namespace

const std::array<bool, kLabelCount>& beam_vertical_classes() {
  static const std::array<bool, kLabelCount> table = [] {
    std::array<bool, kLabelCount> t{};
    const auto& ground = ground_classes();
    for (int id = 0; id < kLabelCount; ++id) t[id] = !ground[id];
    // Not lit as a diffuse vertical surface: the sky; the camera car itself (behind its lamps);
    // the frame's border and outside the region of interest (not scene); traffic signs, whose
    // beam light is their retroreflection (the light map's sign luminance, R_A holding it).
    for (const Label l : {Label::Sky, Label::EgoVehicle, Label::RectificationBorder, Label::OutOfRoi, Label::TrafficSign})
      t[static_cast<int>(l)] = false;
    return t;
  }();
  return table;
}

uint64_t beam_lit_class_bits() { return label_bits(ground_classes()) | label_bits(beam_vertical_classes()); }

double low_beam_vertical_lux(double X_m, double Y_m, double D_m, double nX, double nY, double nD, bool crown,
                             const ScenePreset& p) {
  if (!(D_m > 0)) return 0;
  // Each lamp's E⊥ = I(h, v)/d² is the signs' (SignLight::lamp_lux: the table below the cut-off,
  // the glare zone's intensity above it, 0 beside the table); a surface element takes it times
  // cos β (a crown: Φ(α)), with d² held at (5·lens_diameter_m)².
  const SignLight sl(p, 0);
  const double hl = p.beam_lamp_height_m, d2_min = 25 * p.beam_lens_diameter_m * p.beam_lens_diameter_m;
  double E = 0;
  for (const double xl : {-0.5 * p.beam_lamp_spacing_m, 0.5 * p.beam_lamp_spacing_m}) {
    const double vX = xl - X_m, vY = hl - Y_m, vD = -D_m, d2 = vX * vX + vY * vY + vD * vD, d = std::sqrt(d2);
    const double cb = (nX * vX + nY * vY + nD * vD) / d;
    if (!crown && !(cb > 0)) continue;
    double f = cb;
    if (crown) {
      const double a = std::acos(std::clamp(cb, -1.0, 1.0));
      f = 2 / (3 * M_PI) * (std::sin(a) + (M_PI - a) * cb);  // the Lambert sphere's phase law (Russell 1916)
    }
    E += sl.lamp_lux(X_m, Y_m, D_m, xl) * d2 * f / std::max(d2, d2_min);
  }
  return E;
}

struct BeamVerticalRows::Impl {
  BeamF b;
  BeamVerticalCtx c;
  ImageF& beam;
  const ImageU16& labels;
  const ImageF& depth;
  const BuildingFacades* fac;
  double cp, sp;
  bool avx512, avx2;
  VerticalShadowMaps shadow;  // each lamp's view of the solid points (shade_vertical_row)
  // Per row (shadows on): its pixels shaded from the left lamp only, the right only, both. Each
  // row(y) writes its own entry (any thread, any order, a row run again overwrites it), so their
  // sum (shadow_stats) is the same for every thread count, with no shared counter in the row pass.
  mutable std::vector<std::array<int, 3>> shaded;
  Impl(ImageF& beam_lux, const CameraGeometry& g, const ImageU16& labels_, const ImageF& depth_m,
       const BuildingFacades* facades, const ScenePreset& p, bool shadows)
      : b(beam_f(p)),
        c{b, g, facades, std::vector<float>(beam_lux.width()), {}, {}, label_bits(beam_vertical_classes()),
          static_cast<int>(Label::Building), static_cast<int>(Label::Vegetation), static_cast<float>(g.mount_height_m),
          b.xl[0], b.xl[1]},
        beam(beam_lux), labels(labels_), depth(depth_m), fac(facades), cp(std::cos(g.pitch_rad)),
        sp(std::sin(g.pitch_rad)), avx512(kHaveAvx512 && beam_isa_cap >= 2),
        avx2(kHaveAvx2 && beam_isa_cap >= 1) {
    const int W = beam.width(), H = beam.height();
    if (labels.width() != W || labels.height() != H || depth.width() != W || depth.height() != H)
      fail("low beam on vertical surfaces: the beam, labels and depth differ in size");
    for (int x = 0; x < W; ++x) c.xn[x] = static_cast<float>((x - g.cx_px) / g.f_px);
    if (facades)
      for (const FacadePlane& f : facades->planes) {
        c.plane_nX.push_back(static_cast<float>(-f.nX));
        c.plane_nD.push_back(static_cast<float>(-f.nD));
      }
    if (b.ok && shadows) shadow = vertical_shadow_maps(c, labels, depth, cp, sp);
    if (shadow.ok) shaded.assign(static_cast<size_t>(H), {0, 0, 0});
  }
};

BeamVerticalRows::BeamVerticalRows(ImageF& beam_lux, const CameraGeometry& g, const ImageU16& labels,
                                   const ImageF& depth_m, const BuildingFacades* facades, const ScenePreset& p,
                                   bool shadows)
    : impl_(std::make_unique<Impl>(beam_lux, g, labels, depth_m, facades, p, shadows)) {}
BeamVerticalRows::~BeamVerticalRows() = default;

void BeamVerticalRows::row(int y) const {
  const Impl& m = *impl_;
  if (!m.b.ok) return;  // no table: no light (as low_beam_illuminance)
  const CameraGeometry& g = m.c.g;
  const double yn = (y - g.cy_px) / g.f_px;
  const float kD = static_cast<float>(m.cp - yn * m.sp), kY = static_cast<float>(m.sp + yn * m.cp);
  const int32_t* reg = m.fac && !m.fac->region.empty() ? m.fac->region.row(y) : nullptr;
  const uint16_t* id = m.labels.row(y);
  const float* z = m.depth.row(y);
  float* e = m.beam.row(y);
  // Where shadows are on, each lamp's term of the row's E (a shaded pixel keeps the other's).
  thread_local std::vector<float> terms;
  float *t0 = nullptr, *t1 = nullptr;
  if (m.shadow.ok) {
    terms.resize(2 * static_cast<size_t>(m.beam.width()));
    t0 = terms.data(), t1 = t0 + m.beam.width();
  }
  const int x0 = m.avx512 ? beam_vertical_row_avx512(m.c, id, z, reg, kD, kY, e, t0, t1)
                 : m.avx2 ? beam_vertical_row_avx2(m.c, id, z, reg, kD, kY, e, t0, t1)
                          : 0;
  beam_vertical_row_scalar(m.c, x0, id, z, reg, kD, kY, e, t0, t1);
  if (m.shadow.ok) {
    int n[3] = {0, 0, 0};
    shade_vertical_row(m.c, m.shadow, m.labels, m.depth, y, m.cp, m.sp, m.avx512, m.avx2, e, t0, t1, n);
    m.shaded[static_cast<size_t>(y)] = {n[0], n[1], n[2]};
  }
}

BeamShadowStats BeamVerticalRows::shadow_stats() const {
  BeamShadowStats st;
  for (const std::array<int, 3>& n : impl_->shaded) st.one_lamp[0] += n[0], st.one_lamp[1] += n[1], st.both += n[2];
  return st;
}

float BeamVerticalRows::lamp_lux(int x, int y, int lamp) const {
  const Impl& m = *impl_;
  if (!m.b.ok || lamp < 0 || lamp > 1) return 0.f;
  const double yn = (y - m.c.g.cy_px) / m.c.g.f_px;
  const float kD = static_cast<float>(m.cp - yn * m.sp), kY = static_cast<float>(m.sp + yn * m.cp);
  const int32_t* reg = m.fac && !m.fac->region.empty() ? m.fac->region.row(y) : nullptr;
  BeamPoint q;
  if (!beam_vertical_point(m.c, x, m.labels.row(y), m.depth.row(y), reg, kD, kY, &q)) return 0.f;
  return beam_vertical_lamp_f(q.X - (lamp ? m.c.xl1 : m.c.xl0), q.Y - m.b.hl, q.D, q.mX, q.mY, q.mD, q.s, q.crown,
                              m.b);
}

void add_low_beam_vertical(ImageF& beam_lux, const CameraGeometry& g, const ImageU16& labels, const ImageF& depth_m,
                           const BuildingFacades* facades, const ScenePreset& p) {
  const BeamVerticalRows rows(beam_lux, g, labels, depth_m, facades, p);
#pragma omp parallel for schedule(static, 8)
  for (int y = 0; y < beam_lux.height(); ++y) rows.row(y);
}

namespace {
// The vehicle classes (is_vehicle) as a table (the call per pixel was a visible part of the light
// map), and as one id range where they form one (labels.cpp: 26..33): then a label is a vehicle
// when (uint16)(id − lo) ≤ span and an instance id q (class·1000 + n) when q ∈ [1000·lo,
// 1000·hi + 999] (q/1000 a vehicle, and q ≥ 1000): the same tests as the table's, without it or
// the division per pixel.
struct VehicleIds {
  bool table[kLabelCount];
  bool range = false;
  uint16_t lo = 0, span = 0, q_lo = 0, q_span = 0;
  VehicleIds() {
    int v_lo = -1, v_hi = -1;
    for (int id = 0; id < kLabelCount; ++id) {
      table[id] = is_vehicle(id);
      if (table[id]) {
        if (v_lo < 0) v_lo = id;
        v_hi = id;
      }
    }
    range = v_lo > 0;
    for (int id = std::max(0, v_lo); id <= v_hi; ++id) range = range && table[id];
    lo = static_cast<uint16_t>(std::max(0, v_lo));
    span = static_cast<uint16_t>(v_hi - v_lo);
    q_lo = static_cast<uint16_t>(1000 * std::max(0, v_lo));
    q_span = static_cast<uint16_t>(1000 * (v_hi - v_lo) + 999);
  }
  bool vehicle(int id) const { return id >= 0 && id < kLabelCount && table[id]; }
  bool label(uint16_t id) const { return range ? static_cast<uint16_t>(id - lo) <= span : vehicle(id); }
  bool instance(uint16_t q) const {
    return range ? static_cast<uint16_t>(q - q_lo) <= q_span : q >= 1000 && vehicle(q / 1000);
  }
};

// Whether at least 5 of the 8 neighbours of (x, y) in m are v: a lamp is a blob, not a pixel on
// a colour fringe.
bool blob_in(const ImageU8& m, int x, int y, uint8_t v) {
  int n = 0;
  for (int dy = -1; dy <= 1; ++dy)
    for (int dx = -1; dx <= 1; ++dx) n += (dx || dy) && m.at(x + dx, y + dy) == v;
  return n >= 5;
}
}  // namespace

namespace {
// The vehicles' colour cues (vehicle_cues): per pixel 1 red lamp colour, 2 white lamp colour
// (where the vehicle allows), written in the vehicle rows and the row on either side; the rows
// holding a cue; each vehicle's pixels in red blobs.
struct VehicleCues {
  ImageU8 cue;
  std::vector<uint8_t> cue_row;
  std::vector<int> red_blob_px;
};
}  // namespace

// The vehicle analysis's parts that read only the labels, the instance ids and the day image
// (vehicle_rows_part, add_vehicle_parts: scene/night_detail.h): the vehicle rows; the vehicles'
// components and boxes; their colour cues. light_map's vehicle lamps take what it holds when it
// was made of their labels (the cues: and of their day image), else make them.
struct VehicleParts {
  LabelsMadeOf labels;  // the labels (and instance ids) it was made of
  // The rows holding any vehicle pixel: [ry0, ry1] (ry1 < 0: none); all vehicle work stays
  // inside them.
  int ry0 = 0, ry1 = -1;
  // Vehicle component per pixel: instances from the instance ids, else connected components of
  // the vehicle classes; only the vehicle rows are written (0 off vehicles) and read. Component
  // c's class comp_class[c] (c = 1..ncomp) and box. `components`: made.
  bool components = false;
  ImageI32 comp;
  std::vector<int> comp_class;
  int ncomp = 0;
  struct Box { int x0 = 1 << 30, y0 = 1 << 30, x1 = -1, y1 = -1, n = 0; };
  std::vector<Box> boxes;
  // The colour cues, made of the day image at `day` (its samples, width and height).
  std::optional<VehicleCues> cues;
  const float* day = nullptr;
  int day_width = 0, day_height = 0;
  bool made_of(const LabelMap& lm) const { return labels.same_labels(LabelsMadeOf(lm)); }
  bool cues_of(const ImageF& d) const {
    return cues && day == d.data() && day_width == d.width() && day_height == d.height();
  }
};

namespace {
// The vehicle rows [ry0, ry1] of VehicleParts: those holding a vehicle label or instance id.
void vehicle_rows(const LabelMap& lm, const VehicleIds& vid, int& ry0_out, int& ry1_out) {
  const ImageU16& labels = lm.ids;
  const int W = labels.width(), H = labels.height();
  int ry0 = H, ry1 = -1;
#pragma omp parallel for schedule(static) reduction(min : ry0) reduction(max : ry1)
  for (int y = 0; y < H; ++y) {
    const uint16_t* r = labels.row(y);
    const uint16_t* q = lm.instances.empty() ? nullptr : lm.instances.row(y);
    // Whether the row holds a vehicle pixel, 64 pixels at a time (branch-free inside a block;
    // with the vehicle range, on local copies of the bounds, which the compiler vectorizes).
    bool any = false;
    const int Wr = W;
    const bool range = vid.range;
    const uint16_t lo = vid.lo, span = vid.span, qlo = vid.q_lo, qspan = vid.q_span;
    for (int x0 = 0; x0 < Wr && !any; x0 += 64) {
      const int x1 = std::min(Wr, x0 + 64);
      unsigned acc = 0;
      if (range) {
        for (int x = x0; x < x1; ++x) acc |= static_cast<uint16_t>(r[x] - lo) <= span;
        if (q)
          for (int x = x0; x < x1; ++x) acc |= static_cast<uint16_t>(q[x] - qlo) <= qspan;
      } else {
        for (int x = x0; x < x1; ++x) acc |= vid.label(r[x]);
        if (q)
          for (int x = x0; x < x1; ++x) acc |= vid.instance(q[x]);
      }
      any = acc != 0;
    }
    if (any) {
      ry0 = std::min(ry0, y);
      ry1 = std::max(ry1, y);
    }
  }
  ry0_out = ry0;
  ry1_out = ry1;
}

// VehicleParts' components and boxes in its vehicle rows (m.ry0, m.ry1 set).
void vehicle_components(VehicleParts& m, const LabelMap& lm, const VehicleIds& vid) {
  const ImageU16& labels = lm.ids;
  const int W = labels.width(), H = labels.height();
  const int ry0 = m.ry0, ry1 = m.ry1;
  // Only the vehicle rows [ry0, ry1] are zeroed and used (the lamps' discs read it through
  // `mine`, which is false outside them), so the other rows are never written, nor their pages
  // touched.
  m.comp = ImageI32(W, H, 1, uninitialized);
  ImageI32& comp = m.comp;
  std::vector<int>& comp_class = m.comp_class;
  comp_class.assign(1, 0);
#pragma omp parallel for schedule(static)
  for (int y = std::max(0, ry0); y <= ry1; ++y) std::fill_n(comp.row(y), W, 0);
  const size_t i_begin = ry1 >= 0 ? static_cast<size_t>(ry0) * W : 0;
  const size_t i_end = ry1 >= 0 ? static_cast<size_t>(ry1 + 1) * W : 0;
  if (ry1 >= 0) {
    std::map<int, int> inst_index;
    if (!lm.instances.empty()) {
      int last_v = -1, last_c = 0;
      const uint16_t* qd = lm.instances.data();
      const bool range = vid.range;
      const uint16_t qlo = vid.q_lo, qspan = vid.q_span;
      for (size_t i = i_begin; i < i_end; ++i) {
        // Sixteen pixels of no vehicle instance skipped at once (a branch-free test the compiler
        // vectorizes, on local copies of the range): such pixels change nothing here.
        if (range && (i & 15) == 0 && i + 16 <= i_end) {
          unsigned any = 0;
          for (size_t k = i; k < i + 16; ++k) any |= static_cast<uint16_t>(qd[k] - qlo) <= qspan;
          if (!any) {
            i += 15;
            continue;
          }
        }
        const int v = qd[i];
        if (vid.instance(static_cast<uint16_t>(v))) {
          if (v != last_v) {
            auto [it, fresh] = inst_index.try_emplace(v, static_cast<int>(inst_index.size()) + 1);
            if (fresh) comp_class.push_back(v / 1000);
            last_v = v;
            last_c = it->second;
          }
          comp[i] = last_c;
        }
      }
    }
    cv::Mat mask(ry1 - ry0 + 1, W, CV_8U);
    const long nb = static_cast<long>(i_begin), ne = static_cast<long>(i_end);
    // (Through local pointers, and with the vehicle range in locals: the byte stores might alias
    // the images' and the table's fields, which kept the compiler from vectorizing the loop.)
    const uint16_t* lab = labels.data();
    const int32_t* cp = comp.data();
    uint8_t* md = mask.data;
    if (vid.range) {
      const uint16_t lo = vid.lo, span = vid.span;
#pragma omp parallel for schedule(static)
      for (long i = nb; i < ne; ++i) md[i - nb] = static_cast<uint16_t>(lab[i] - lo) <= span && cp[i] == 0 ? 255 : 0;
    } else {
#pragma omp parallel for schedule(static)
      for (long i = nb; i < ne; ++i) md[i - nb] = vid.label(lab[i]) && cp[i] == 0 ? 255 : 0;
    }
    cv::Mat cc;
    const int n = cv::connectedComponents(mask, cc, 8, CV_32S);
    const int base = static_cast<int>(inst_index.size());
    for (int c = 1; c < n; ++c) comp_class.push_back(0);
    // Class of each new component: the label at its first pixel (a component is one class
    // group, vehicles; mixed-class blobs take the first met).
    const int32_t* ccd = reinterpret_cast<const int32_t*>(cc.data);
    for (size_t i = i_begin; i < i_end; ++i) {
      // Eight pixels of no new component (label 0) skipped at once: most of these rows.
      if (((i - i_begin) & 7) == 0 && i + 8 <= i_end && all_zero8(ccd + (i - i_begin))) {
        i += 7;
        continue;
      }
      const int c = ccd[i - i_begin];
      if (c > 0) {
        comp[i] = base + c;
        if (comp_class[base + c] == 0) comp_class[base + c] = labels[i];
      }
    }
    m.ncomp = static_cast<int>(comp_class.size()) - 1;
  }
  const int ncomp = m.ncomp;
  m.boxes.assign(ncomp + 1, VehicleParts::Box{});
  // Each row's runs of one component: a run [x, e) widens its box once and adds e − x pixels
  // (the same boxes and counts as pixel by pixel).
  for (int y = ry0; y <= ry1; ++y) {
    const int32_t* cr = comp.row(y);
    for (int x = 0; x < W;) {
      // Vehicle pixels are a minority of these rows: eight ids at a time skip the empty stretches.
      if ((x & 7) == 0 && x + 8 <= W && all_zero8(cr + x)) {
        x += 8;
        continue;
      }
      const int c = cr[x];
      int e = x + 1;
      while (e < W && cr[e] == c) ++e;
      if (c) {
        VehicleParts::Box& b = m.boxes[c];
        b.x0 = std::min(b.x0, x); b.x1 = std::max(b.x1, e - 1);
        b.y0 = std::min(b.y0, y); b.y1 = std::max(b.y1, y);
        b.n += e - x;
      }
      x = e;
    }
  }
}

// Colour cues inside vehicles (VehicleCues): saturated red (lamp lenses, reflectors) and,
// on vehicles where bright white is rare (so not a white body), near-white highlights in the
// lower half; and each vehicle's red cue pixels in blobs (>= 5 of 8 like neighbours), which tell
// which way it faces (light_map). Reads the components and boxes of m and the day image.
VehicleCues vehicle_cues(const VehicleParts& m, const ImageF& day) {
  const int W = day.width(), H = day.height();
  const int ry0 = m.ry0, ry1 = m.ry1;
  const ImageI32& comp = m.comp;
  VehicleCues out;
  // 1: red lamp colour, 2: white lamp colour (if the vehicle allows); written and read only in
  // the vehicle rows and the row on either side (the neighbour test), so only those are zeroed.
  out.cue = ImageU8(W, H, 1, uninitialized);
  ImageU8& cue = out.cue;
  for (int y = std::max(0, ry0 - 1); y <= std::min(H - 1, ry1 + 1); ++y) std::fill_n(cue.row(y), W, uint8_t{0});
  out.cue_row.assign(H, 0);  // rows holding a cue (only those are read again below)
  std::vector<uint8_t>& cue_row = out.cue_row;
#pragma omp parallel for schedule(static, 8)
  for (int y = std::max(0, ry0); y <= ry1; ++y) {
    const int32_t* comp_row = comp.row(y);
    for (int x = 0; x < W; ++x) {
      // Eight pixels of no vehicle skipped at once (as in the boxes' scan).
      if ((x & 7) == 0 && x + 8 <= W && all_zero8(comp_row + x)) {
        x += 7;
        continue;
      }
      const size_t i = static_cast<size_t>(y) * W + x;
      const int c = comp[i];
      if (!c) continue;
      // Necessary conditions first, in to_lab's own expressions (so the same doubles): both cues
      // need L* > 25 and L* = 116·f(Y) − 16 is non-decreasing in Y (lab_f's table lerp too, up
      // to the float rounding of its entries, ~1e-8), with L*(0.04) = 23.7: Y ≤ 0.04 is neither.
      // The red cue needs a* = 500·(f(X) − f(Y)) > 40, so X > Y; the white one L* > 92, and
      // L*(0.8) = 91.7: Y ≤ 0.8 with X ≤ Y is neither. Only the remaining pixels are converted:
      // the same cues.
      const float* s = day.data() + 3 * i;
      const double Xn = (0.4124 * s[0] + 0.3576 * s[1] + 0.1805 * s[2]) / 0.95047;
      const double Yn = 0.2126 * s[0] + 0.7152 * s[1] + 0.0722 * s[2];
      if (!(Yn > 0.04) || (!(Xn > Yn) && !(Yn > 0.8))) continue;
      const Lab l = to_lab(s);
      // The hue angle only where the red test can pass (the same tests in the same order).
      if (l.a > 40 && l.L > 25) {
        const double hue = std::atan2(l.b, l.a) * 180 / M_PI;
        if (hue > -20 && hue < 40) {
          cue[i] = 1;
          continue;
        }
      }
      if (l.L > 92 && std::hypot(l.a, l.b) < 10) cue[i] = 2;
    }
    const uint8_t* cr = cue.row(y);
    cue_row[y] = std::any_of(cr, cr + W, [](uint8_t v) { return v != 0; });
  }
  // The white cues, in the cue rows only (elsewhere cue is 0), in the order of the full scan;
  // kept on vehicles where they are rare (fewer than 1 in 20 of its pixels) and in its lower half.
  std::vector<int> white(m.ncomp + 1, 0);
  for (int y = std::max(0, ry0); y <= ry1; ++y) {
    if (!cue_row[y]) continue;
    for (size_t i = static_cast<size_t>(y) * W; i < static_cast<size_t>(y + 1) * W; ++i)
      if (cue[i] == 2) ++white[comp[i]];
  }
  for (int y = std::max(0, ry0); y <= ry1; ++y) {
    if (!cue_row[y]) continue;
    for (size_t i = static_cast<size_t>(y) * W; i < static_cast<size_t>(y + 1) * W; ++i)
      if (cue[i] == 2) {
        const VehicleParts::Box& b = m.boxes[comp[i]];
        if (!(white[comp[i]] * 20 < b.n && 2 * y > b.y0 + b.y1)) cue[i] = 0;
      }
  }
  // The red blobs' pixels per vehicle.
  out.red_blob_px.assign(m.ncomp + 1, 0);
  for (int y = std::max(1, ry0); y <= std::min(H - 2, ry1); ++y) {
    if (!cue_row[y]) continue;
    for (int x = 1; x < W - 1; ++x)
      if (cue.at(x, y) == 1 && blob_in(cue, x, y, 1)) ++out.red_blob_px[comp.at(x, y)];
  }
  return out;
}

// The red lens cue (light_map reads it with the geometry only: it tells which way a vehicle
// faces): vehicle pixels of a red lamp lens's colour once the frame's cast is taken out by the
// road's grey (road_grey_gains, rear_lens_colour: an unlit rear lamp in daylight, a* 20-40 where
// the lit-lamp cue needs 40), in blobs (>= 5 of 8 neighbours alike), counted per vehicle. Written
// and read in the vehicle rows and the row on either side only.
std::vector<int> vehicle_lens(const VehicleParts& m, const ImageF& day, const ImageU16& labels) {
  const int W = day.width(), H = day.height();
  const int ry0 = m.ry0, ry1 = m.ry1;
  const ImageI32& comp = m.comp;
  std::vector<int> lens_blob_px(m.ncomp + 1, 0);
  if (ry1 < 0) return lens_blob_px;
  const std::array<double, 3> gain = road_grey_gains(day, labels);
  ImageU8 lens(W, H, 1, uninitialized);
  for (int y = std::max(0, ry0 - 1); y <= std::min(H - 1, ry1 + 1); ++y) std::fill_n(lens.row(y), W, uint8_t{0});
#pragma omp parallel for schedule(static, 8)
  for (int y = ry0; y <= ry1; ++y) {
    const int32_t* comp_row = comp.row(y);
    uint8_t* lr = lens.row(y);
    for (int x = 0; x < W; ++x) {
      if ((x & 7) == 0 && x + 8 <= W && all_zero8(comp_row + x)) {
        x += 7;
        continue;
      }
      if (comp_row[x] && rear_lens_colour(day.data() + 3 * (static_cast<size_t>(y) * W + x), gain)) lr[x] = 1;
    }
  }
  for (int y = std::max(1, ry0); y <= std::min(H - 2, ry1); ++y)
    for (int x = 1; x < W - 1; ++x) {
      if (lens.at(x, y) && blob_in(lens, x, y, 1)) ++lens_blob_px[comp.at(x, y)];
    }
  return lens_blob_px;
}
}  // namespace

std::shared_ptr<VehicleParts> vehicle_rows_part(const LabelMap& lm) {
  auto m = std::make_shared<VehicleParts>();
  m->labels = LabelsMadeOf(lm);
  vehicle_rows(lm, VehicleIds(), m->ry0, m->ry1);
  return m;
}
void add_vehicle_parts(VehicleParts& m, const ImageF& day, const LabelMap& lm) {
  if (!m.made_of(lm)) m = std::move(*vehicle_rows_part(lm));
  vehicle_components(m, lm, VehicleIds());
  m.components = true;
  m.cues = vehicle_cues(m, day);
  m.day = day.data();
  m.day_width = day.width();
  m.day_height = day.height();
}
LightMap light_map(const ImageF& day, const ImageF& texture, const LabelMap& lm, const ImageU8& lanes,
                   const ImageF& depth, const VanishingPoint& vp, const ScenePreset& p,
                   uint64_t seed, const CameraGeometry* geometry, const ImageF* depth_m,
                   const ImageF* beam_lux, const BuildingFacades* facades, const StreetLighting* street,
                   bool with_radiance, bool with_glare_level1) {
  return light_map_with(day, texture, lm, lanes, depth, vp, p, seed, geometry, depth_m, beam_lux, facades, street,
                        with_radiance, with_glare_level1, nullptr);
}

LightMap light_map_with(const ImageF& day, const ImageF& texture, const LabelMap& lm, const ImageU8& lanes,
                        const ImageF& depth, const VanishingPoint& vp, const ScenePreset& p,
                        uint64_t seed, const CameraGeometry* geometry, const ImageF* depth_m,
                        const ImageF* beam_lux, const BuildingFacades* facades, const StreetLighting* street,
                        bool with_radiance, bool with_glare_level1, const VehicleParts* vehicles,
                        const BeamVerticalRows* beam_vertical, const LampShadowRows* street_shadows,
                        ParkedSet* parked) {
  const int W = day.width(), H = day.height();
  const ImageU16& labels = lm.ids;
  LightMap out;
  // Written whole by the first pass below (zeros where nothing retroreflects), in parallel: no
  // separate zeroing pass, and each thread touches its own rows first.
  ImageF L(W, H, 3, uninitialized, unit::radiance);
  const auto tb = illuminant_tint(p.beam_cct_K);
  const auto& K = spectrum::band_luminous_efficacy_lm_per_W();
  // A white marking's colour under the beam, scaled so its luminance is exactly R_L·E:
  // Σ_k K_k t_k / Σ_k K_k t_k = 1 (the tint preserves the luminance of D65 white, not of a flat
  // spectrum, so 1/ΣK per band would be off by Σ K t / ΣK, 2.6% for a 3200 K beam).
  const double ktb = K[0] * tb[0] + K[1] * tb[1] + K[2] * tb[2];
  auto lab_at = [&](int i) { return to_lab(day.data() + 3 * static_cast<size_t>(i)); };

  // Retroreflection: markings L = R_L·E_beam (EN 1436), signs L = R_A·E_⊥ (EN 12899), with the
  // day texture as relative pattern (texture/ρ has mean 1/ΣK per class, hence ·ΣK). E_⊥ on signs:
  // with the metric geometry the beam's own at the sign pixel's point (sign_beam_lux: the table
  // below the cut-off, the glare zone's limit above it, where most signs are), each lamp's share
  // at R_A of its observation angle toward the camera (sign_retroreflected_cd_m2); the image-space map
  // takes the preset's beam_sign_lux (NP §4: 10 kcd at 50 m give 4 lx) scaled by the coarse ramp,
  // which runs to the image border and so moved with the view (issue 14 §3). In the same pass, traffic
  // signals by colour in CIELAB (hue angle and chroma of lit signal lenses), drawn over the pixel's
  // own retroreflection (each pixel is written by itself only, so the pass's order does not matter).
  // (Rows in interleaved chunks here and below: signs, markings and vehicles cluster in bands of
  // the frame, so contiguous halves would leave one thread most of the work.)
  // A sign pixel's luminance at its point: camera z from depth_m, then road coordinates (the inverse of
  // CameraGeometry::project): X = z·x_n, height Y = h − z·(sin θ + y_n·cos θ), D = z·(cos θ − y_n·sin θ).
  // (A plain lambda, called where has_sign_pos: through a std::function it was an indirect call
  // per sign pixel.)
  const bool has_sign_pos = geometry && depth_m;
  // (its facing set from the road ahead once the street lighting's plan has measured it, below)
  SignLight sign_light(p, geometry ? geometry->mount_height_m : 0);
  static const CameraGeometry kNoGeometry;  // (read only where has_sign_pos)
  const CameraGeometry& sg = geometry ? *geometry : kNoGeometry;
  const double sign_c = std::cos(sg.pitch_rad), sign_s = std::sin(sg.pitch_rad);
  const auto sign_pos = [&g = sg, &sign_light, c = sign_c, s = sign_s](int x, int y, float z_m) {
    if (!std::isfinite(z_m) || !(z_m > 0)) return 0.0;
    const double xn = (x - g.cx_px) / g.f_px, yn = (y - g.cy_px) / g.f_px, z = z_m;
    return sign_light.luminance(z * xn, g.mount_height_m - z * (s + yn * c), z * (c - yn * s));
  };
  // With the metric geometry the light map has one pass over the rows (add_street_light_rows),
  // which makes each row from the start: this retroreflection and the signals (retro_row), the
  // vehicle lamps (veh, recorded below), then the street light, the windows and the heads, and,
  // when asked, the night radiance. Otherwise this pass runs over the frame here and the vehicle
  // lamps are drawn after it. Per pixel the same operations in the same order either way.
  const bool row_pass = geometry && depth_m && g_fused_rows;
  const int traffic_light = static_cast<int>(Label::TrafficLight);
  const int traffic_sign = static_cast<int>(Label::TrafficSign);
  // With AVX-512 (and beam_max_isa 2), the sign pixels of a row are taken eight at a time
  // (sign_luminances_avx512: the same bits as sign_pos), with AVX2 (beam_max_isa 1) four at a time
  // (sign_luminances_avx2): the row's loop records their columns and depths, and they are lit
  // after it (each pixel is written by itself only).
  const bool sign_avx512 = has_sign_pos && kHaveAvx512 && beam_isa_cap >= 2;
  const bool sign_lanes = sign_avx512 || (has_sign_pos && kHaveAvx2 && beam_isa_cap >= 1);
  // A retroreflecting pixel's radiance: the luminance lum in the beam's colour with the marking's
  // flat pattern or the day texture's.
  // (1/ktb made once: the same quotient as per pixel, without its three divisions per marking pixel.)
  const double inv_ktb = 1.0 / ktb;
  auto retro_put = [&](float* Lr, const float* tr, int x, bool marking, int id, double lum) {
    const double rho = class_reflectance(id, p);
    for (int k = 0; k < 3; ++k) {
      const double pattern = marking ? inv_ktb : tr[3 * x + k] / rho;
      Lr[3 * x + k] = static_cast<float>(lum * tb[k] * pattern);
    }
  };
  // A marking's coefficient of retroreflected luminance R_L is defined on the illuminance on a
  // plane perpendicular to the direction of the incident light, L = R_L·E⊥ (CIE S 017:2020,
  // ILV 17-24-104; EN 1436's 30 m geometry), not on the road plane: at 30 m the beam meets the
  // road at 1.2°, and the horizontal E the beam image holds (E_h = Σ_lamps I·cos θ/d², cos θ =
  // h_l/d) is 1/46 of E⊥ there. With the metric geometry the marking's E⊥ is taken as
  // E_h·d_c/h_l, d_c the distance of its ground point (X, 0, D) from the lamps' midpoint
  // (0, h_l, 0): exact for one lamp on the centre line; for the pair at x_l = ±a each lamp's
  // d_k² = d_c² − 2X·x_l + a², so E_h·d_c/h_l = Σ I_k/d_k²·(d_c/d_k) lies within
  // [1/√(1 + q), 1/√(1 − q)] of Σ I_k/d_k², q = (2a|X| + a²)/d_c² (1.5 % at X = 1.75 m, D = 10 m;
  // 6 % at 5 m): an approximation that saves the two lamps' angles per marking pixel. Without the
  // geometry (the image-space beam) E_h is used as E⊥ (factor 1).
  // The ground point is CameraGeometry::ground_point's, its row terms (t, D) made once per row.
  const double h_l = p.beam_lamp_height_m;
  struct MarkingRow {
    bool ground = false;
    double t = 0, D = 0;
  };
  auto marking_row = [&](int y) {
    MarkingRow r;
    if (!geometry || !(h_l > 0)) return r;
    const double yn = (y - sg.cy_px) / sg.f_px, den = yn * sign_c + sign_s;
    if (den <= 0) return r;
    r.ground = true;
    r.t = sg.mount_height_m / den;
    r.D = r.t * (sign_c - yn * sign_s);
    return r;
  };
  auto marking_perp = [&](const MarkingRow& r, int x) {
    if (!r.ground) return 1.0;
    const double X = r.t * ((x - sg.cx_px) / sg.f_px);
    return std::sqrt(X * X + r.D * r.D + h_l * h_l) / h_l;
  };
  // Row y of L written whole (zeros where nothing retroreflects); returns its signals.
  auto retro_row = [&](int y) {
    int signals = 0;
    // Row pointers (stores to L through the images' own accessors made the compiler reload them
    // per pixel), and pixels that are no marking, sign or signal left at once: they get nothing.
    // The row is zeroed block by block as the scan below reaches it (zeros stored where nothing
    // retroreflects, before any pixel of the block is written), not by a pass of its own first:
    // the stores of a block, whose lines come from memory (L is 24 MB a frame at 2048x1024), then
    // overlap the loads of the labels and lanes the scan waits for, and the row is gone over once.
    // The same values: +0 everywhere, then the same writes over it. (Measured: −0.5 ms of CPU in
    // lights+compose at 1 thread, nothing at 2 threads: docs/benchmarks.md "Retroreflection rows,
    // twenty-fifth session".)
    float* Lr = L.row(y);
    const uint16_t* idr = labels.row(y);
    const uint8_t* lr = lanes.row(y);
    const float* br = beam_lux ? beam_lux->row(y) : nullptr;
    const float* dr = depth.row(y);
    const float* dmr = has_sign_pos ? depth_m->row(y) : nullptr;
    const float* tr = texture.row(y);
    // (sign_lanes: the row's sign pixels' columns, depths and luminances)
    thread_local std::vector<double> sign_buf;
    if (sign_lanes && sign_buf.size() < 3 * static_cast<size_t>(W)) sign_buf.resize(3 * static_cast<size_t>(W));
    double* const sx = sign_lanes ? sign_buf.data() : nullptr;
    double* const sz = sign_lanes ? sx + W : nullptr;
    double* const slum = sign_lanes ? sz + W : nullptr;
    int nsign = 0;
    const MarkingRow mrow = marking_row(y);
    for (int x = 0; x < W; ++x) {
      // Blocks of 32 pixels with no marking, sign or signal skipped whole (a branch-free test
      // the compiler vectorizes): most of the frame.
      if ((x & 31) == 0 && x + 32 > W) std::fill_n(Lr + 3 * static_cast<size_t>(x), 3 * static_cast<size_t>(W - x), 0.f);
      if ((x & 31) == 0 && x + 32 <= W) {
        zero_floats96(Lr + 3 * static_cast<size_t>(x));
        unsigned any = 0;
        for (int k = x; k < x + 32; ++k) any |= (lr[k] != 0) | (idr[k] == traffic_sign) | (idr[k] == traffic_light);
        if (!any) {
          x += 31;
          continue;
        }
      }
      const int id = idr[x];
      if (!lr[x] && id != traffic_sign && id != traffic_light) continue;
      double lum = 0;
      if (lr[x]) lum = br ? p.marking_RL * br[x] * marking_perp(mrow, x) : 0.0;
      else if (id == traffic_sign) {
        if (sign_lanes) {  // (lit after the loop; a sign pixel is no signal)
          sx[nsign] = x, sz[nsign] = dmr[x], ++nsign;
          continue;
        }
        lum = has_sign_pos ? sign_pos(x, y, dmr[x]) : p.sign_RA * p.beam_sign_lux * std::max(0.05, static_cast<double>(dr[x]));
      }
      if (lum > 0) retro_put(Lr, tr, x, lr[x] != 0, id, lum);
      if (id != traffic_light) continue;
      const size_t i = static_cast<size_t>(y) * W + x;
      const Lab c = lab_at(static_cast<int>(i));
      const double chroma = std::hypot(c.a, c.b), hue = std::atan2(c.b, c.a) * 180 / M_PI;
      if (c.L < 25 || chroma < 30) continue;
      Rgb col;
      if (hue > -20 && hue < 40) col = red_lamp(p, p.signal_luminance_cd_m2);
      else if (hue >= 40 && hue < 85) col = led_lamp(p, spectrum::LampSpectrum::AmberLed, p.signal_luminance_cd_m2);
      else if (hue > 120 && hue < 220) col = led_lamp(p, spectrum::LampSpectrum::GreenLed, p.signal_luminance_cd_m2);
      else continue;
      put_max(L, x, y, col);
      ++signals;
    }
    if (nsign > 0) {
      const double yn = (y - sg.cy_px) / sg.f_px;  // (sign_pos's y_n, kY and kD)
      const auto scalar = [&](int i) { return sign_pos(static_cast<int>(sx[i]), y, static_cast<float>(sz[i])); };
      if (sign_avx512)
        sign_luminances_avx512(sign_light, sx, sz, nsign, sg.cx_px, sg.f_px, sg.mount_height_m, sign_s + yn * sign_c,
                               sign_c - yn * sign_s, slum, scalar);
      else
        sign_luminances_avx2(sign_light, sx, sz, nsign, sg.cx_px, sg.f_px, sg.mount_height_m, sign_s + yn * sign_c,
                             sign_c - yn * sign_s, slum, scalar);
      for (int i = 0; i < nsign; ++i)
        if (slum[i] > 0) retro_put(Lr, tr, static_cast<int>(sx[i]), false, traffic_sign, slum[i]);
    }
    return signals;
  };

  // Vehicles: instances from the instance ids, else connected components of each vehicle class
  // (VehicleParts, above). The vehicle rows, components and boxes (labels and instance ids only)
  // come from `vehicles` when it was made of these labels and holds them, the colour cues when
  // it was also made of this day image (night_scene makes the rows beside Canny and the rest
  // beside the Hough transform: vehicle_rows_part, add_vehicle_parts); the others are made here:
  // the same parts.
  const VehicleParts* handed = vehicles && vehicles->made_of(lm) ? vehicles : nullptr;
  int ry0 = H, ry1 = -1;
  if (handed) {
    ry0 = handed->ry0;
    ry1 = handed->ry1;
  }
  // The street lighting (the plan or the one given): the vehicles' states read its road extent.
  StreetLighting sl;
  if (geometry && street) sl = *street;
  const bool plan_here = geometry && !street;
  // Where the light map makes the plan and the lamps' shadows itself (light_map alone: the chain
  // hands both), the label runs (label_runs) are made with the plan, on its thread: its poles
  // (pole_components_of) and the shadows' scan (StreetShadowBuilder, below) read them, as the
  // chain's do, rather than each scanning the labels (the same boxes and spans).
  const bool runs_here = plan_here && depth_m && p.lamp_shadows && p.street_road_luminance_cd_m2 > 0 && !street_shadows;
  std::shared_ptr<const LabelRuns> runs;
  auto plan = [&] {
    if (!runs_here) {
      sl = plan_street_lighting(lm, *geometry, p, seed);
      return;
    }
    runs = label_runs(labels);
    sl = plan_street_lighting_with(lm, *geometry, p, seed, pole_components_of(labels, runs.get()).get());
  };
  if (plan_here && !handed) {
    // The plan and the vehicle rows (light_map alone: the chain hands both) each read the whole
    // label image and nothing of the other: made side by side, one on each of two threads, rather
    // than one after the other over both (each one's own parallel loop then runs on its thread
    // alone, OpenMP's nested regions being inactive by default; a serial part of the plan, its
    // poles' union-find and layout, no longer leaves the other thread idle). The same results at
    // any thread count: the plan's pole runs are made per row, the rows' bounds are a min and a max.
    std::exception_ptr plan_failed;
#pragma omp parallel sections
    {
#pragma omp section
      {
        try {
          plan();
        } catch (...) {
          plan_failed = std::current_exception();
        }
      }
#pragma omp section
      vehicle_rows(lm, VehicleIds(), ry0, ry1);
    }
    if (plan_failed) std::rethrow_exception(plan_failed);
  } else {
    if (plan_here) plan();
    if (!handed) vehicle_rows(lm, VehicleIds(), ry0, ry1);
  }
  // Where the road ahead bends, the signs face the traffic that reads them (SignLight::facing).
  if (has_sign_pos) sign_light.facing = detail::SignFacing(sl.road_ahead, p.sign_read_distance_m);
  if (!row_pass) {
    int signals = 0;
#pragma omp parallel for schedule(static, 8) reduction(+ : signals)
    for (int y = 0; y < H; ++y) signals += retro_row(y);
    out.stats.signals = signals;
  }
  const bool extent = sl.road_right_m > sl.road_left_m;
  const double road_mid = extent ? 0.5 * (sl.road_left_m + sl.road_right_m) : 0.0;
  // The divide between the two directions of travel (right-hand traffic): the carriageway's
  // middle; but the ego vehicle drives right of the centre line, so where the road runs straight
  // ahead (sl.road_straight) the divide is at most the ego lane's left edge, half a lane left of
  // the camera (mounted on the car's centre line, the car centred in its lane). A vehicle in the
  // ego lane, or right of it, travels the ego's way (an oncoming one there would be on a collision
  // course); a camera left of the middle is on a one-way carriageway or its left lane.
  const double travel_divide = extent && sl.road_straight ? std::min(road_mid, -0.5 * p.veh_lane_width_m) : road_mid;
  // The vehicle lamps' pixels (maxima over L), recorded by vehicle_lamps (below) and drawn
  // after the retroreflection, row by row; all lie in the vehicle rows [ry0, ry1].
  MaxDraws veh(W, H);
  // The vehicles' low beams on the ground (VehicleBeamRows, above): recorded by vehicle_lamps,
  // added row by row after the retroreflection and before the vehicle lamps (ground pixels only:
  // the lamps are drawn on vehicle pixels). With the row pass the rows from beam_y0 down wait for
  // vehicle_lamps (the side job's band is [beam_y0, H − 1]): an oncoming beam lights the ground
  // below its vehicle, a going-away one the ground beyond it, which lies below the horizon but may
  // lie above every vehicle row (vehicles lower than the camera); so beam_y0 is the first vehicle
  // row or the first row below the horizon (den = y_n·cos + sin > 0, VehicleBeamRows::row),
  // whichever is higher.
  std::optional<VehicleBeamRows> vehicle_beams;
  if (geometry && p.veh_beams_on_road) vehicle_beams.emplace(*geometry, W, p);
  int beam_y0 = ry0;
  if (vehicle_beams && ry1 >= ry0) {
    const double yh = geometry->cy_px - geometry->f_px * std::tan(geometry->pitch_rad);  // the horizon's row
    beam_y0 = std::min(ry0, static_cast<int>(std::clamp(std::floor(yh), 0.0, static_cast<double>(H))));
  }
  const auto vehicle_beam_row = [&](int y) {
    if (!vehicle_beams || vehicle_beams->beams.empty()) return;
    thread_local std::vector<float> e;
    if (e.size() < static_cast<size_t>(W)) e.resize(W);
    vehicle_beams->row(L.row(y), texture.row(y), labels.row(y), y, e.data());
  };
  // The vehicles' components, boxes, states, colour cues and placed lamps (those not handed),
  // recorded in veh. With the row pass, one thread runs it while the others make the rows
  // outside [ry0, ry1] (add_street_light_rows' side job: those rows read nothing it writes);
  // otherwise before the lamps are drawn. Its own scratch (component ids, cues) is freed when it
  // returns.
  auto vehicle_lamps = [&] {
    VehicleParts own;
    if (!handed || !handed->components) {
      own.ry0 = ry0;
      own.ry1 = ry1;
      vehicle_components(own, lm, VehicleIds());
    }
    const VehicleParts& parts = handed && handed->components ? *handed : own;
    const ImageI32& comp = parts.comp;
    const std::vector<int>& comp_class = parts.comp_class;
    const int ncomp = parts.ncomp;
    const std::vector<VehicleParts::Box>& boxes = parts.boxes;
    const size_t i_begin = ry1 >= 0 ? static_cast<size_t>(ry0) * W : 0;
    const size_t i_end = ry1 >= 0 ? static_cast<size_t>(ry1 + 1) * W : 0;
    using Box = VehicleParts::Box;
    // With the scene geometry: which vehicles are in traffic (issue 14 §2 "Which vehicles"). A
    // vehicle's ground contact is its lowest row; the labels just below it (3 rows across the
    // middle half of its width) say what it stands on. In traffic: on road, not cut by the frame,
    // not in a row parked nose to tail (below), and
    //  - across a median on the oncoming side (probe_beside toward the camera's column: its road,
    //    a strip of at most kMedianMax_m, road again), or
    //  - not at the kerb (its outer side more than kKerbContact_m from an off-carriageway label on
    //    its own contact row, unless that strip is a median) and inside the driving area: its
    //    outer side more than veh_kerb_strip_m inside the measured carriageway's edges, or inside
    //    them at all where its outer side faces a median (nobody parks against a median).
    // Others are parked: dark, except a seeded share (veh_parked_lit_fraction) with parking
    // lights, keyed by the instance code or by the ground position on a 2 m grid, so a vehicle
    // keeps its draw from frame to frame.
    struct VehState { int state = 0; double X = 0, D = 0, z = 0, width_m = 0; };  // 0 dark, 1 traffic, 2 parked lit
    std::vector<VehState> vs(ncomp + 1);
    // What the decision read, per vehicle (reported by the test hook): its outer side's X, the
    // road beside it before the kerb side and that strip's width (probe_beside), the size of the
    // parked row it stands in, and the median cues.
    struct VehWhy {
      double Xo = 0, kerb_gap = INFINITY, strip_m = 0;
      int row = 0;
      bool beside_median = false, across_median = false;
    };
    std::vector<VehWhy> why(ncomp + 1);
    // What each vehicle stands on and beside (here); the states once the facing cues are known
    // (below: a row of parked vehicles is told by the way they face).
    std::vector<int> inst_of(ncomp + 1, 0);
    std::vector<char> contact(ncomp + 1, 0), on_road(ncomp + 1, 0), cut(ncomp + 1, 0), in_lane(ncomp + 1, 0),
        inside(ncomp + 1, 0), at_kerb(ncomp + 1, 0);
    if (geometry) {
      const CameraGeometry& g = *geometry;
      if (!lm.instances.empty())
        for (size_t i = i_begin; i < i_end; ++i)
          if (comp[i] && lm.instances[i] >= 1000) inst_of[comp[i]] = lm.instances[i];
      for (int c = 1; c <= ncomp; ++c) {
        const Box& b = boxes[c];
        if (b.n == 0) continue;
        VehState& v = vs[c];
        if (!g.ground_point(0.5 * (b.x0 + b.x1), b.y1 + 0.5, &v.X, &v.D, nullptr)) continue;
        contact[c] = 1;
        v.z = g.plane_depth_m(b.y1 + 0.5, v.D);
        v.width_m = (b.x1 - b.x0 + 1) * v.z / g.f_px;
        int road = 0, other = 0;
        const int q = (b.x1 - b.x0 + 1) / 4;
        for (int y = b.y1 + 1; y <= std::min(H - 1, b.y1 + 3); ++y)
          for (int x = b.x0 + q; x <= b.x1 - q; ++x) {
            const int id = labels.at(x, y);
            if (id == static_cast<int>(Label::Road)) ++road;
            else if (!is_vehicle(id)) ++other;
          }
        // The outer side (toward the nearer road edge) at the contact depth: a parked vehicle's
        // lies within the kerb strip of the edge.
        const bool left = v.X < road_mid;
        double& Xo = why[c].Xo;
        Xo = v.X;
        g.ground_point(left ? b.x0 - 0.5 : b.x1 + 0.5, b.y1 + 0.5, &Xo, nullptr, nullptr);
        on_road[c] = road > other;  // a vehicle cut by the image bottom shows no contact: parked
        // A vehicle cut by the left or right border hides its outer side: taken as parked (dark),
        // the conservative reading (an approximation: a passing vehicle there stays dark too).
        // The border is the image's, or the labels' frame of no image content beside the box
        // (Cityscapes' gtFine has 5-6 columns of "out of roi" at each side; KITTI's rectified
        // frames a "rectification border"), read at the box's middle row.
        const int ymid = (b.y0 + b.y1) / 2;
        auto frame_label = [&](int x) {
          const int id = labels.at(x, ymid);
          return id == static_cast<int>(Label::OutOfRoi) || id == static_cast<int>(Label::RectificationBorder);
        };
        cut[c] = b.x0 == 0 || b.x1 == W - 1 || frame_label(b.x0 - 1) || frame_label(b.x1 + 1);
        inside[c] = !extent || (Xo > sl.road_left_m && Xo < sl.road_right_m);
        in_lane[c] = !cut[c] && (!extent || (Xo > sl.road_left_m + p.veh_kerb_strip_m &&
                                             Xo < sl.road_right_m - p.veh_kerb_strip_m));
        // Beside it at its contact depth (its own row of the labels: the ground there is at its
        // depth): outward, the kerb or a median; toward the camera's column, a median between it
        // and the ego carriageway.
        const BesideProbe out_p = probe_beside(labels, g, left ? b.x0 - 1 : b.x1 + 1, b.y1, left ? -1 : 1, kMedianProbe_m);
        why[c].beside_median = out_p.road_beyond && out_p.strip_m <= kMedianMax_m;
        why[c].kerb_gap = out_p.road_m;
        why[c].strip_m = out_p.strip_m;
        at_kerb[c] = out_p.road_m <= kKerbContact_m && !why[c].beside_median;
        // Across a median on the oncoming side: wholly left of the measured carriageway (its
        // inner side too), and between it and the camera's column its road, a strip of at most
        // kMedianMax_m, then road again (the ego carriageway). Right-hand traffic: the far
        // carriageway of a dual carriageway carries the oncoming traffic (a road beyond a strip on
        // the right is as often a service road or a car park's aisle: not read).
        double Xi = v.X;
        g.ground_point(b.x1 + 0.5, b.y1 + 0.5, &Xi, nullptr, nullptr);
        if (extent && Xi < sl.road_left_m && b.x1 + 1 < W) {
          const BesideProbe in_p = probe_beside(labels, g, b.x1 + 1, b.y1, 1, kMedianProbe_m);
          why[c].across_median = in_p.road_beyond && in_p.strip_m <= kMedianMax_m;
        }
      }
    }
    // Colour cues inside vehicles (vehicle_cues): saturated red (lamp lenses, reflectors) and, on
    // vehicles where bright white is rare (so not a white body), near-white highlights in the
    // lower half; and the red blobs' pixels per vehicle (they tell which way it faces, below).
    const Rgb tail = red_lamp(p, p.taillamp_luminance_cd_m2);
    const Rgb head = blackbody(p.headlamp_cct_K, p.headlamp_luminance_cd_m2);
    std::optional<VehicleCues> own_cues;
    if (&parts == &own || !parts.cues_of(day)) own_cues = vehicle_cues(parts, day);
    const VehicleCues& cues = own_cues ? *own_cues : *parts.cues;
    const ImageU8& cue = cues.cue;
    const std::vector<uint8_t>& cue_row = cues.cue_row;
    const std::vector<int>& red_blob_px = cues.red_blob_px;
    // A lamp is a blob, not a pixel on a colour fringe: the cues with >= 5 of 8 like neighbours
    // are drawn. With geometry, only on vehicles in traffic (a parked car's red reflectors stay
    // unlit). A white cue on a vehicle that shows its rear is a lit rear lamp (a stop lamp
    // saturates to white in a day photo): drawn in the tail colour, as the red ones.
    auto cue_comp = [&](int x, int y) { return comp.at(x, y); };
    auto blob = [&](int x, int y, uint8_t v) { return blob_in(cue, x, y, v); };
    // The red lens cue (vehicle_lens; with geometry: it only tells which way a vehicle faces,
    // below).
    const std::vector<int> lens_blob_px = geometry ? vehicle_lens(parts, day, labels) : std::vector<int>(ncomp + 1, 0);
    // Which way each vehicle faces (with geometry; below).
    std::vector<char> oncoming(ncomp + 1, 0);
    if (geometry)
      for (int c = 1; c <= ncomp; ++c)
        oncoming[c] = !shows_rear(red_blob_px[c], lens_blob_px[c], boxes[c].n) && vs[c].X < travel_divide;
    if (geometry) {
      // Rows parked nose to tail: at least three cars (car to trailer; no two-wheelers) standing
      // on road and facing the camera on the oncoming side (oncoming[]: no rear cue, left of the
      // divide), each beside the next in the image (boxes overlapping by at most 2/3 of the
      // narrower one's width, or apart by at most 1/4 of it: a vehicle queued behind another in
      // its lane is mostly hidden behind it) at a like depth (box heights within a factor 2,
      // bottoms within half the smaller height). Moving traffic keeps a gap of about 2 s (15 m
      // and more at 30 km/h; the German "halber Tacho" rule [U]), so oncoming vehicles that
      // close together stand still, and vehicles standing in a row facing the camera are parked
      // along the far kerb (where a junction's mouth widens the measured carriageway, or the
      // kerb hides behind them, the edge rules miss them). A queue of oncoming vehicles waiting
      // at a light is read as parked too: an approximation. All the bounds are photosite choices.
      std::vector<int> members;
      for (int c = 1; c <= ncomp; ++c)
        if (contact[c] && on_road[c] && !cut[c] && oncoming[c] && comp_class[c] >= static_cast<int>(Label::Car) &&
            comp_class[c] <= static_cast<int>(Label::Trailer))
          members.push_back(c);
      std::vector<int> parent(ncomp + 1);
      for (int c = 0; c <= ncomp; ++c) parent[c] = c;
      std::function<int(int)> find = [&](int c) { return parent[c] == c ? c : parent[c] = find(parent[c]); };
      for (size_t i = 0; i < members.size(); ++i)
        for (size_t j = i + 1; j < members.size(); ++j) {
          const Box &a = boxes[members[i]], &b = boxes[members[j]];
          const int wa = a.x1 - a.x0 + 1, wb = b.x1 - b.x0 + 1, ha = a.y1 - a.y0 + 1, hb = b.y1 - b.y0 + 1;
          const int overlap = std::min(a.x1, b.x1) - std::max(a.x0, b.x0) + 1;  // < 0: a gap
          const int narrow = std::min(wa, wb);
          const bool side_by_side = 3 * overlap <= 2 * narrow && -4 * overlap <= narrow;
          const bool alike = 2 * std::min(ha, hb) >= std::max(ha, hb) && 2 * std::abs(a.y1 - b.y1) <= std::min(ha, hb);
          if (side_by_side && alike) parent[find(members[i])] = find(members[j]);
        }
      std::map<int, int> row_size;
      for (int c : members) ++row_size[find(c)];
      for (int c : members) why[c].row = row_size[find(c)] >= 3 ? row_size[find(c)] : 0;
      // In a sequence, the parked vehicles' draws go through the sequence's ParkedSet (below).
      std::vector<int> parked_c;
      std::vector<ParkedSet::Sighting> sightings;
      for (int c = 1; c <= ncomp; ++c) {
        if (!contact[c]) continue;
        VehState& v = vs[c];
        const bool driving_area = in_lane[c] || (inside[c] && why[c].beside_median);
        const bool traffic =
            on_road[c] && !cut[c] && why[c].row == 0 && (why[c].across_median || (!at_kerb[c] && driving_area));
        if (traffic) {
          v.state = 1;
          ++out.stats.vehicles_in_traffic;
        } else {
          ++out.stats.vehicles_parked;
          const uint64_t key = inst_of[c] ? static_cast<uint64_t>(inst_of[c])
                                          : (static_cast<uint64_t>(std::lround(v.X / 2) + 4096) << 20) |
                                                static_cast<uint64_t>(std::lround(v.D / 2) + 4096);
          const auto w = random_words(seed, 0, 0x9a4c000000ull ^ key, Stream::Scene);
          const bool lit = uniform_open(w[0]) < p.veh_parked_lit_fraction;
          if (parked && street) {
            parked_c.push_back(c);
            // (A vehicle cut by the frame: its contact up to a car's length off, 5 m: passenger
            // cars are 3.5-5 m long.)
            sightings.push_back({v.X, v.D, cut[c] ? 5.0 : 0.0, lit});
          } else if (lit) {
            v.state = 2;
            ++out.stats.vehicles_parked_lit;
          }
        }
      }
      // In a sequence each parked vehicle takes the draw of the one remembered at its place
      // (ParkedSet, one to one), so its lights do not blink as its key moves. Matched within
      // 4 px of contact row at the farther sighting's distance: 1 px of row quantisation at
      // each sighting plus 2 px for the sequence's horizon against the true one (its error moves
      // a contact by r²·δ/(f·h), differently at the two distances; 1.7 px on the synthetic
      // street of Luminaires.ParkedVehiclesKeepTheirParkingLightsWhileDriving).
      if (!sightings.empty()) {
        const std::vector<char> lit = parked->lit(sightings, street->pose, 4 / (geometry->f_px * geometry->mount_height_m));
        for (size_t k = 0; k < lit.size(); ++k)
          if (lit[k]) {
            vs[parked_c[k]].state = 2;
            ++out.stats.vehicles_parked_lit;
          }
      }
    }
    // The test hook (scene/vehicle_facing_detail.h): each vehicle's decision, with its instance code.
    if (std::vector<VehicleDecision>* sink = g_vehicle_decisions.load(); sink && geometry) {
      for (int c = 1; c <= ncomp; ++c) {
        const Box& b = boxes[c];
        if (b.n == 0) continue;
        sink->push_back({inst_of[c], comp_class[c], b.x0, b.y0, b.x1, b.y1, b.n, vs[c].state, oncoming[c] != 0,
                         red_blob_px[c], lens_blob_px[c], vs[c].X, vs[c].D, travel_divide, sl.road_left_m,
                         sl.road_right_m, why[c].Xo, why[c].row, why[c].beside_median, why[c].across_median,
                         why[c].kerb_gap, why[c].strip_m, vs[c].width_m});
      }
    }
    for (int y = std::max(1, ry0); y <= std::min(H - 2, ry1); ++y) {
      if (!cue_row[y]) continue;
      for (int x = 1; x < W - 1; ++x) {
        const uint8_t v = cue.at(x, y);
        if (!v || !blob(x, y, v)) continue;
        const int c = cue_comp(x, y);
        if (!geometry) put_max(veh, x, y, v == 1 ? tail : head);
        else if (vs[c].state == 1) put_max(veh, x, y, v == 1 || !oncoming[c] ? tail : head);
      }
    }
    // Placed lamps. With geometry, in metres: a pair per vehicle at veh_lamp_height_m above its
    // ground contact, veh_lamp_inset_m in from its sides (its metric width from its pixel width at
    // the contact depth), one lamp for two-wheelers; discs of the lens diameter at intensity I
    // (luminance I/area; a lens smaller than a pixel puts I over the pixel's footprint (z/f)²).
    // Which way it faces. Red lamps are at a vehicle's rear only (UN ECE R48's colours: rear
    // position, stop and rear fog lamps red; front position and headlamps white [R]), so a vehicle
    // whose day photo shows red lamp-like blobs (the red cue or the red lens cue above) faces
    // away: tail lamps (shows_rear, scene/vehicle_facing_detail.h: a blob share of at least 0.2 %
    // of its pixels and 3 px, at most 20 %; photosite choices). Otherwise the direction of travel,
    // right-hand traffic: left of the divide (travel_divide: the road's centre line, on a straight
    // road at most the ego lane's left edge) in road coordinates oncoming (head lamps toward the
    // camera), right of it going away (tail lamps). Parked lit vehicles show position lamps: red when facing away, white
    // otherwise.
    // Without geometry: the image-space pair at 55% of the box height, 15% in from each side.
    for (int c = 1; c <= ncomp; ++c) {
      const Box& b = boxes[c];
      const int bw = b.x1 - b.x0 + 1, bh = b.y1 - b.y0 + 1;
      auto mine = [&](int x, int y) { return y >= ry0 && y <= ry1 && comp.at(x, y) == c; };
      const int cls = comp_class[c];
      const bool two_wheeler = cls == static_cast<int>(Label::Motorcycle) || cls == static_cast<int>(Label::Bicycle);
      if (geometry) {
        const VehState& v = vs[c];
        if (v.state == 0) continue;
        const bool faces_camera = oncoming[c];
        double I, dia;
        bool red;
        if (v.state == 1) {
          I = faces_camera ? p.veh_head_intensity_cd : p.veh_tail_intensity_cd;
          dia = faces_camera ? p.veh_head_diameter_m : p.veh_tail_diameter_m;
          red = !faces_camera;
        } else {
          I = p.veh_parking_intensity_cd;
          dia = p.veh_tail_diameter_m;
          red = !faces_camera;
        }
        const double half = std::max(0.0, 0.5 * v.width_m - p.veh_lamp_inset_m);
        std::vector<double> xs = two_wheeler ? std::vector<double>{v.X} : std::vector<double>{v.X - half, v.X + half};
        for (double X : xs) {
          double u, vv, z;
          if (!geometry->project(X, p.veh_lamp_height_m, v.D, &u, &vv, &z)) continue;
          const double r = 0.5 * geometry->f_px * dia / z;
          const double lum = r >= 0.6 ? I / (M_PI * 0.25 * dia * dia) : I * geometry->f_px * geometry->f_px / (z * z);
          const Rgb col = red ? red_lamp(p, lum) : blackbody(p.headlamp_cct_K, lum);
          int n = 0;
          if (r >= 0.6) n = disc(veh, u, vv, r, col, mine);
          else {
            const int px = static_cast<int>(std::lround(u)), py = static_cast<int>(std::lround(vv));
            if (px >= 0 && py >= 0 && px < W && py < H && mine(px, py)) { put_max(veh, px, py, col); n = 1; }
          }
          out.stats.vehicle_lamps += n > 0;
        }
        // Its low beam on the road ahead of it (VehicleBeamRows): toward the camera from its contact
        // when it faces the camera, away from it from its front (contact + its class's length) when
        // seen from behind. The head lamps' X are the drawn pair's (tail or head: the same inset).
        const bool beam_class = cls == static_cast<int>(Label::Car) || cls == static_cast<int>(Label::Truck) ||
                                cls == static_cast<int>(Label::Bus) || cls == static_cast<int>(Label::Motorcycle);
        if (vehicle_beams && v.state == 1 && beam_class) {
          if (faces_camera) {
            vehicle_beams->add(xs, v.D, false);
            ++out.stats.vehicle_beams;
          } else {
            vehicle_beams->add(xs, v.D + vehicle_length_m(cls), true);
            ++out.stats.vehicle_beams_going_away;
          }
        }
        continue;
      }
      if (b.n < 40 || bw < 8 || bh < 6) continue;
      const bool oncoming = b.x1 < vp.x;
      const Rgb& col = oncoming ? head : tail;
      const double r = std::max(1.5, 0.05 * bw), ly = b.y0 + 0.55 * bh;
      if (two_wheeler) {
        if (disc(veh, b.x0 + 0.5 * bw, ly, r, col, mine)) ++out.stats.vehicle_lamps;
      } else {
        out.stats.vehicle_lamps += disc(veh, b.x0 + 0.15 * bw, ly, r, col, mine) > 0;
        out.stats.vehicle_lamps += disc(veh, b.x1 - 0.15 * bw, ly, r, col, mine) > 0;
      }
    }

    veh.finish();
  };
  if (!row_pass) {
    vehicle_lamps();
    if (vehicle_beams && !vehicle_beams->beams.empty()) {
#pragma omp parallel for schedule(static, 8)
      for (int y = 0; y < H; ++y) vehicle_beam_row(y);
    }
    for (int y = 0; y < H; ++y) veh.draw_row(L, y);
  }

  // Street lighting in metres: luminaires on poles or along the road edges, their pools on the
  // ground and their heads (scene/street.cpp).
  if (geometry) {
    // The heads with the metric depth are hidden whole behind what stands in front of them
    // beyond the depth's uncertainty (head_hidden, scene/street.cpp: not pixel by pixel, whose
    // flips at silhouettes cost the panning test, MetricLights, 6 points on Cityscapes).
    // Vertical surfaces (cars, façades, people, poles) by the same lamps from their metric
    // depth, before the heads (drawn as a maximum over whatever light lies there). With metric
    // depth, the vertical light, the pools and the façade windows (below) in one pass over the
    // rows (add_street_light_rows: the same bits as the three calls).
    if (depth_m) {
      // Asked for the night radiance (and given the beam): each row composed in the row pass once
      // its light is final (nothing after the pass writes L on this path).
      std::optional<ComposeRows> rows;
      if (with_radiance && beam_lux && row_pass) {
        out.composed = ImageF(W, H, 3, uninitialized, unit::radiance);
        if (with_glare_level1) {
          // The level's buffer is kept per thread between frames (as the glare pyramid's own,
          // sensor/glare.cpp): reused once no scene holds it, so that its 6 MB (2048x1024) are not
          // faulted in afresh each frame; every row and sum is written again below.
          static thread_local std::shared_ptr<GlareLevel1> t_level1;
          if (!t_level1 || t_level1.use_count() > 1 || t_level1->full_width != W || t_level1->full_height != H)
            t_level1 = std::make_shared<GlareLevel1>(W, H);
          out.glare_level1 = t_level1;
        }
        rows.emplace(texture, L, labels, *beam_lux, p, out.composed, out.glare_level1.get());
        rows->beam_vertical = beam_vertical;
      }
      // Each row begins with its retroreflection and signals, then its vehicle lamps.
      std::atomic<int> signals{0};
      const std::function<void(int)> first = [&](int y) {
        signals += retro_row(y);
        if (y >= beam_y0) vehicle_beam_row(y);
        if (y >= ry0 && y <= ry1) veh.draw_row(L, y);
      };
      const std::function<void()> side = vehicle_lamps;
      // The lamps' shadow spans from the runs made with the plan (above), over the threads.
      LampShadowRows own_shadows;
      if (runs && !sl.lamps.empty()) own_shadows = street_lamp_shadow_spans(labels, *depth_m, *geometry, sl, p, runs.get());
      runs.reset();
      const StreetRowsResult r =
          add_street_light_rows(L, texture, labels, *depth_m, *geometry, sl, p, seed, facades, rows ? &*rows : nullptr,
                                row_pass ? &first : nullptr, row_pass ? &side : nullptr,
                                vehicle_beams && ry1 >= ry0 ? beam_y0 : ry0, vehicle_beams && ry1 >= ry0 ? H - 1 : ry1,
                                own_shadows.lamps ? &own_shadows : street_shadows);
      out.stats.signals = signals;
      out.stats.pole_lamps = r.pole_lamps;
      out.stats.windows = r.windows;
      out.stats.street_shadow_pixels = r.shadow_pixels;
    } else {
      out.stats.pole_lamps = add_street_lighting(L, texture, labels, *geometry, sl, p);
    }
    out.stats.street_lamps = static_cast<int>(sl.lamps.size());
    out.stats.street_lamp_source = sl.source;
    out.stats.street_lamp_note = sl.note;
    out.stats.street_peak_intensity_cd = sl.peak_intensity_cd;
    out.stats.road_luminance_avg_cd_m2 = sl.avg_luminance_cd_m2;
    out.stats.road_uniformity_u0 = sl.uniformity_u0;
    out.stats.road_ahead = sl.road_ahead.state;
    out.stats.road_curvature_per_m = sl.road_ahead.kappa_per_m;
    out.stats.road_curve_start_m = sl.road_ahead.curve_start_m;
    out.stats.road_curvature_se_per_m = sl.road_ahead.kappa_se_per_m;
  }
  // Without geometry: lamp heads on poles: tall thin pole components whose top is above the
  // horizon and not capped by a sign or signal (those poles carry no luminaire).
  if (!geometry) {
    // Components on a half-resolution mask (2x2 OR pooling keeps 1-px poles), a quarter of the
    // work; the top row and its centre are then found at full resolution.
    auto is_pole = [&](int x, int y) {
      const int id = labels.at(x, y);
      return id == static_cast<int>(Label::Pole) || id == static_cast<int>(Label::PoleGroup);
    };
    const int W2 = (W + 1) / 2, H2 = (H + 1) / 2;
    cv::Mat mask(H2, W2, CV_8U);
#pragma omp parallel for schedule(static)
    for (int y = 0; y < H2; ++y)
      for (int x = 0; x < W2; ++x) {
        bool any = false;
        for (int dy = 0; dy < 2; ++dy)
          for (int dx = 0; dx < 2; ++dx)
            any |= 2 * x + dx < W && 2 * y + dy < H && is_pole(2 * x + dx, 2 * y + dy);
        mask.at<uint8_t>(y, x) = any ? 255 : 0;
      }
    cv::Mat cc, stats, cent;
    const int n = cv::connectedComponentsWithStats(mask, cc, stats, cent, 8, CV_32S);
    const Rgb lamp = streetlamp_rgb(p, p.streetlamp_luminance_cd_m2);
    for (int c = 1; c < n; ++c) {
      const int x0 = 2 * stats.at<int>(c, cv::CC_STAT_LEFT);
      const int bw = std::min(W - x0, 2 * stats.at<int>(c, cv::CC_STAT_WIDTH));
      const int bh = 2 * stats.at<int>(c, cv::CC_STAT_HEIGHT);
      int y0 = 2 * stats.at<int>(c, cv::CC_STAT_TOP);
      if (bh < 0.08 * H || bh < 3 * bw / 2 || y0 >= vp.y) continue;
      int sx = 0, cnt = 0;  // centre of the pole's top row (full resolution)
      for (int yy = y0; yy < std::min(H, y0 + 2) && cnt == 0; ++yy)
        for (int x = x0; x < x0 + bw; ++x)
          if (is_pole(x, yy) && cc.at<int>(yy / 2, x / 2) == c) { sx += x; ++cnt; y0 = yy; }
      const double cx = cnt ? static_cast<double>(sx) / cnt : x0 + bw / 2.0;
      bool capped = false;
      for (int y = std::max(0, y0 - 3); y < y0 && !capped; ++y)
        for (int x = std::max(0, x0 - 2); x < std::min(W, x0 + bw + 2); ++x) {
          const int id = labels.at(x, y);
          if (id == static_cast<int>(Label::TrafficSign) || id == static_cast<int>(Label::TrafficLight)) capped = true;
        }
      if (capped) continue;
      const double r = std::max(2.0, 0.004 * W);
      if (disc(L, cx, y0 + r * 0.5, r, lamp, [](int, int) { return true; })) ++out.stats.pole_lamps;
    }
  }

  // Window lights. With geometry: on the façades in metres (scene/street.cpp). Without: a grid
  // anchored to the image with cells of window_cell_fraction·W; a cell's window (inner 50% x 50%)
  // is drawn when it lies entirely on building pixels and the Philox draw keyed by (seed, cell)
  // says lit.
  if (geometry && depth_m) {
    // (drawn with the street light above)
  } else {
    const int cell = std::max(4, static_cast<int>(std::lround(p.window_cell_fraction * W)));
    const int nx = W / cell + 1, ny = H / cell + 1;
    auto building = [&](int x, int y) {
      return x >= 0 && y >= 0 && x < W && y < H &&
             labels.at(x, y) == static_cast<int>(Label::Building);
    };
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        const int x0 = i * cell + cell / 4, x1 = i * cell + (3 * cell) / 4;
        const int y0 = j * cell + cell / 4, y1 = j * cell + (3 * cell) / 4;
        if (!(building(x0, y0) && building(x1, y0) && building(x0, y1) && building(x1, y1) &&
              building((x0 + x1) / 2, (y0 + y1) / 2)))
          continue;
        const auto w = random_words(seed, 0, static_cast<uint64_t>(j) * 65536u + i, Stream::Scene);
        if (uniform_open(w[0]) >= p.window_lit_fraction) continue;
        const double lum = p.window_luminance_cd_m2 * (0.5 + uniform_open(w[1]));  // 0.5..1.5×
        const double cct = uniform_open(w[2]) < p.window_warm_share ? p.window_cct_K : p.window_cool_cct_K;
        const Rgb col = blackbody(cct, lum);
        for (int y = y0; y <= y1; ++y)
          for (int x = x0; x <= x1; ++x)
            if (building(x, y)) put_max(L, x, y, col);
        ++out.stats.windows;
      }
  }
  out.radiance = std::move(L);
  return out;
}

namespace {
// One row of compose for the pixels x0 .. x1 − 1: darken_pixel, then the beam's diffuse reflection
// on ground classes and the light map, o_k = d_k + ((t_k·tint_k/π)·E + l_k).
void compose_row_scalar(float* o, const float* t, const float* l, const float* b, const uint16_t* id, int x0, int x1,
                        const DarkenParams& dp, const float* tbf, uint64_t beam_mask) {
  for (int x = x0; x < x1; ++x) {
    darken_pixel(t + 3 * x, id[x], dp, o + 3 * x);
    // Lambertian diffuse reflection of the low beam: f_k·t_k·E/π, E from low_beam_illuminance on
    // the ground classes (0 above the horizon and beyond the cut-off) and add_low_beam_vertical on
    // the vertical ones (beam_lit_class_bits).
    const float e = id[x] < 64 && (beam_mask >> id[x] & 1) ? b[x] : 0.f;
    for (int k = 0; k < 3; ++k) o[3 * x + k] += t[3 * x + k] * tbf[k] * e + l[3 * x + k];
  }
}
// compose_row_scalar eight pixels at a time where none of them is sky (darken_pixel's lit branch,
// d_k = t_k·ambient_k) and every class id is below kLabelCount: the same float operations per
// channel on the 24 floats of the eight pixels (E and the ground test spread to the channels by
// lane permutations); and where all eight are sky (darken_pixel's sky branch, below); groups with
// some sky pixels, and the row's tail, by the scalar loop.
__attribute__((target("avx2"))) void compose_row_avx2(float* o, const float* t, const float* l, const float* b,
                                                     const uint16_t* id, int W, const DarkenParams& dp,
                                                     const float* tbf, uint64_t beam_mask) {
  const __m256i s0 = _mm256_setr_epi32(0, 0, 0, 1, 1, 1, 2, 2), s1 = _mm256_setr_epi32(2, 3, 3, 3, 4, 4, 4, 5),
                s2 = _mm256_setr_epi32(5, 5, 6, 6, 6, 7, 7, 7);
  const float* a = dp.ambient;
  const __m256 am0 = _mm256_setr_ps(a[0], a[1], a[2], a[0], a[1], a[2], a[0], a[1]),
               am1 = _mm256_setr_ps(a[2], a[0], a[1], a[2], a[0], a[1], a[2], a[0]),
               am2 = _mm256_setr_ps(a[1], a[2], a[0], a[1], a[2], a[0], a[1], a[2]);
  const __m256 tb0 = _mm256_setr_ps(tbf[0], tbf[1], tbf[2], tbf[0], tbf[1], tbf[2], tbf[0], tbf[1]),
               tb1 = _mm256_setr_ps(tbf[2], tbf[0], tbf[1], tbf[2], tbf[0], tbf[1], tbf[2], tbf[0]),
               tb2 = _mm256_setr_ps(tbf[1], tbf[2], tbf[0], tbf[1], tbf[2], tbf[0], tbf[1], tbf[2]);
  const __m256i sky = _mm256_set1_epi32(static_cast<int>(Label::Sky)), count = _mm256_set1_epi32(kLabelCount - 1);
  const __m256i mlo = _mm256_set1_epi32(static_cast<int32_t>(beam_mask & 0xffffffffu)),
                mhi = _mm256_set1_epi32(static_cast<int32_t>(beam_mask >> 32)), one = _mm256_set1_epi32(1),
                k32 = _mm256_set1_epi32(32);
  // The sky branch's constants (darken_sky_relative, darken_sky_channel: yr = (K₀·t₀ + K₁·t₁ +
  // K₂·t₂)/ρ_sky in double, d_k = float(glow_k·yr)) and the channels' gather offsets.
  const __m256d K0 = _mm256_set1_pd(dp.K[0]), K1 = _mm256_set1_pd(dp.K[1]), K2 = _mm256_set1_pd(dp.K[2]),
                rho = _mm256_set1_pd(dp.rho_sky);
  const __m256i idx3 = _mm256_setr_epi32(0, 3, 6, 9, 12, 15, 18, 21);
  int x = 0;
  for (; x + 8 <= W; x += 8) {
    const __m256i k = _mm256_cvtepu16_epi32(_mm_loadu_si128(reinterpret_cast<const __m128i*>(id + x)));
    const int skym = _mm256_movemask_ps(_mm256_castsi256_ps(_mm256_cmpeq_epi32(k, sky)));
    if (skym != 0 && skym != 0xff) {
      compose_row_scalar(o, t, l, b, id, x, x + 8, dp, tbf, beam_mask);
      continue;
    }
    // The ground test by the class bit mask (as dp.ground_class[id] for ids below kLabelCount ≤ 64).
    const __m256i bit = _mm256_and_si256(
        _mm256_or_si256(_mm256_srlv_epi32(mlo, k), _mm256_srlv_epi32(mhi, _mm256_sub_epi32(k, k32))), one);
    const __m256 e = _mm256_and_ps(_mm256_castsi256_ps(_mm256_cmpeq_epi32(bit, one)), _mm256_loadu_ps(b + x));
    if (skym == 0xff) {
      // Eight sky pixels (a sixth to a third of a Cityscapes frame; before, each took the scalar
      // loop): the channels gathered to planes, yr per pixel in double as darken_sky_relative
      // ((K₀·t₀ + K₁·t₁) + K₂·t₂, then /ρ), d_k = float(glow_k·yr) (the conversion rounds to
      // nearest, as the cast), then o_k = d_k + ((t_k·tbf_k)·E + l_k) as the scalar loop, and
      // the planes written back interleaved: the same operations per pixel, so the same bits.
      const float* t3 = t + 3 * x;
      const float* l3 = l + 3 * x;
      const __m256 T[3] = {_mm256_i32gather_ps(t3, idx3, 4), _mm256_i32gather_ps(t3 + 1, idx3, 4),
                           _mm256_i32gather_ps(t3 + 2, idx3, 4)};
      __m256d yr[2];
      for (int h = 0; h < 2; ++h) {
        const __m128 r = h ? _mm256_extractf128_ps(T[0], 1) : _mm256_castps256_ps128(T[0]);
        const __m128 g = h ? _mm256_extractf128_ps(T[1], 1) : _mm256_castps256_ps128(T[1]);
        const __m128 bl = h ? _mm256_extractf128_ps(T[2], 1) : _mm256_castps256_ps128(T[2]);
        yr[h] = _mm256_div_pd(_mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(K0, _mm256_cvtps_pd(r)),
                                                          _mm256_mul_pd(K1, _mm256_cvtps_pd(g))),
                                            _mm256_mul_pd(K2, _mm256_cvtps_pd(bl))),
                              rho);
      }
      alignas(32) float out[3][8];
      for (int c = 0; c < 3; ++c) {
        const __m256d gc = _mm256_set1_pd(dp.glow[c]);
        const __m256 d = _mm256_set_m128(_mm256_cvtpd_ps(_mm256_mul_pd(gc, yr[1])), _mm256_cvtpd_ps(_mm256_mul_pd(gc, yr[0])));
        const __m256 lc = _mm256_i32gather_ps(l3 + c, idx3, 4);
        _mm256_store_ps(out[c], _mm256_add_ps(d, _mm256_add_ps(_mm256_mul_ps(_mm256_mul_ps(T[c], _mm256_set1_ps(tbf[c])), e), lc)));
      }
      float* o3 = o + 3 * x;
      for (int i = 0; i < 8; ++i)
        for (int c = 0; c < 3; ++c) o3[3 * i + c] = out[c][i];
      continue;
    }
    if (_mm256_movemask_epi8(_mm256_cmpgt_epi32(k, count))) {
      compose_row_scalar(o, t, l, b, id, x, x + 8, dp, tbf, beam_mask);
      continue;
    }
    const float* t3 = t + 3 * x;
    const float* l3 = l + 3 * x;
    float* o3 = o + 3 * x;
    const __m256 tv0 = _mm256_loadu_ps(t3), tv1 = _mm256_loadu_ps(t3 + 8), tv2 = _mm256_loadu_ps(t3 + 16);
    const __m256 d0 = _mm256_mul_ps(tv0, am0), d1 = _mm256_mul_ps(tv1, am1), d2 = _mm256_mul_ps(tv2, am2);
    _mm256_storeu_ps(o3, _mm256_add_ps(d0, _mm256_add_ps(_mm256_mul_ps(_mm256_mul_ps(tv0, tb0), _mm256_permutevar8x32_ps(e, s0)),
                                                         _mm256_loadu_ps(l3))));
    _mm256_storeu_ps(o3 + 8, _mm256_add_ps(d1, _mm256_add_ps(_mm256_mul_ps(_mm256_mul_ps(tv1, tb1), _mm256_permutevar8x32_ps(e, s1)),
                                                             _mm256_loadu_ps(l3 + 8))));
    _mm256_storeu_ps(o3 + 16, _mm256_add_ps(d2, _mm256_add_ps(_mm256_mul_ps(_mm256_mul_ps(tv2, tb2), _mm256_permutevar8x32_ps(e, s2)),
                                                              _mm256_loadu_ps(l3 + 16))));
  }
  compose_row_scalar(o, t, l, b, id, x, W, dp, tbf, beam_mask);
  _mm256_zeroupper();
}
}  // namespace

ComposeRows::ComposeRows(const ImageF& texture_, const ImageF& lights_, const ImageU16& labels_,
                         const ImageF& beam_lux_, const ScenePreset& p, ImageF& night_, GlareLevel1* level1_)
    : texture(texture_), lights(lights_), labels(labels_), beam_lux(beam_lux_), night(night_), dp(darken_params(p)),
      beam_mask(beam_lit_class_bits()), avx2(kHaveAvx2), level1(level1_) {
  const auto tb = illuminant_tint(p.beam_cct_K);
  for (int k = 0; k < 3; ++k) tbf[k] = static_cast<float>(tb[k] / M_PI);
  if (level1) {
    if (level1->full_width != night.width() || level1->full_height != night.height())
      fail("compose: the glare level 1 is not of the radiance's size");
    const int h1 = level1->image.height(), batches = (h1 + kGlareLevel1SumRows - 1) / kGlareLevel1SumRows;
    pair_rows = std::make_unique<std::atomic<uint8_t>[]>(h1);
    for (int j = 0; j < h1; ++j) pair_rows[j].store(0, std::memory_order_relaxed);
    batch_rows = std::make_unique<std::atomic<uint8_t>[]>(batches);
    for (int b = 0; b < batches; ++b) batch_rows[b].store(0, std::memory_order_relaxed);
  }
}

void ComposeRows::row(int y) const {
  const int W = texture.width();
  if (beam_vertical) beam_vertical->row(y);
  if (avx2) compose_row_avx2(night.row(y), texture.row(y), lights.row(y), beam_lux.row(y), labels.row(y), W, dp, tbf, beam_mask);
  else compose_row_scalar(night.row(y), texture.row(y), lights.row(y), beam_lux.row(y), labels.row(y), 0, W, dp, tbf, beam_mask);
  if (level1) {
    // The second of the pair's rows to be composed makes the level row (acq_rel: the other
    // row's stores, released by its own count, are seen here).
    const int j = y / 2, rows = 2 * j + 1 < night.height() ? 2 : 1;
    if (pair_rows[j].fetch_add(1, std::memory_order_acq_rel) + 1 == rows) {
      glare_level1_row(night, j, *level1);
      // The batch's sums once its last level row is made (eight chains at once, the rows in cache).
      constexpr int B = kGlareLevel1SumRows;
      const int b = j / B, j0 = b * B, j1 = std::min(level1->image.height(), j0 + B);
      if (batch_rows[b].fetch_add(1, std::memory_order_acq_rel) + 1 == j1 - j0) glare_level1_sums(*level1, j0, j1);
    }
  }
}

ImageF compose(const ImageF& texture, const ImageF& lights, const ImageU16& labels,
               const ImageF& beam_lux, const ScenePreset& p) {
  ImageF night(texture.width(), texture.height(), 3, uninitialized, unit::radiance);
  const ComposeRows rows(texture, lights, labels, beam_lux, p, night);
#pragma omp parallel for schedule(static, 8)
  for (int y = 0; y < texture.height(); ++y) rows.row(y);
  return night;
}

}  // namespace photosite::scene
