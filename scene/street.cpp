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
#include <cmath>
#include <immintrin.h>
#include <opencv2/imgproc.hpp>
#include <unordered_set>

#include "photosite/rng.h"
#include "photosite/sensor/spectrum.h"

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
// interpolation: relative error below 1e-6, as the function is smooth there), built per preset:
// acos and exp per pixel and luminaire were most of the light map's time.
struct RelTable {
  double cc = 0, step = 0, cutoff = -1, falloff = -1;
  std::vector<double> v;
  std::vector<double> vd;  // (v[i], v[i + 1] − v[i]) pairs, i = 0 .. 4095: one load per lane
  // I(γ)/I0 at cos γ = c: 1 inside the cut-off cone (c >= cc), else linear between the entries.
  double at(double c) const {
    if (!(c < cc)) return 1.0;
    const double u = c / step;
    const int i = std::min(4095, static_cast<int>(u));
    return v[i] + (v[i + 1] - v[i]) * (u - i);
  }
};
const RelTable& rel_table(const ScenePreset& p) {
  thread_local RelTable t;
  if (t.cutoff != p.lamp_cutoff_deg || t.falloff != p.lamp_falloff_deg) {
    t.cutoff = p.lamp_cutoff_deg;
    t.falloff = p.lamp_falloff_deg;
    t.cc = cos_cut(p);
    t.v.resize(4097);
    t.step = t.cc / 4096;
    for (int i = 0; i <= 4096; ++i) t.v[i] = lamp_relative_intensity(std::acos(std::min(1.0, i * t.step)), p);
    t.vd.resize(2 * 4096);
    for (int i = 0; i < 4096; ++i) {
      t.vd[2 * i] = t.v[i];
      t.vd[2 * i + 1] = t.v[i + 1] - t.v[i];
    }
  }
  return t;
}
inline double lamp_E(double dx, double dz, double H, double I0, const RelTable& t) {
  const double d2 = dx * dx + dz * dz + H * H, d = std::sqrt(d2), c = H / d;
  return I0 * t.at(c) * c / d2;
}
// One lamp's E over the ground points X = (x − c_x)·k_x of a row (x = x0 .. x0 + n − 1, at the
// lamp distance dz along the road), into e: lamp_E's operations in the same order (the path
// without AVX2; with it, pool_row_avx2 below gives the same bits).
void lamp_row_scalar(double* e, int x0, int n, double cx, double kx, double Xl, double dz, double Hl, double I0,
                     const RelTable& t) {
  for (int i = 0; i < n; ++i) e[i] = lamp_E((x0 + i - cx) * kx - Xl, dz, Hl, I0, t);
}
const bool kHaveAvx2 = __builtin_cpu_supports("avx2");
// RelTable::at's interpolation v[j] + (v[j + 1] − v[j])·(u − j) for four lanes, the pairs read by
// one 16-byte load per lane instead of two gathers; j clamped to [0, 4095] so that lanes whose
// result is dropped stay inside the table. The same operations, so the same bits.
__attribute__((target("avx2"), always_inline)) inline __m256d rel_lerp(const RelTable& t, __m256d u) {
  const __m128i j = _mm_max_epi32(_mm_min_epi32(_mm256_cvttpd_epi32(u), _mm_set1_epi32(4095)), _mm_setzero_si128());
  const double* vd = t.vd.data();
  const __m128d p0 = _mm_loadu_pd(vd + 2 * _mm_extract_epi32(j, 0)), p1 = _mm_loadu_pd(vd + 2 * _mm_extract_epi32(j, 1));
  const __m128d p2 = _mm_loadu_pd(vd + 2 * _mm_extract_epi32(j, 2)), p3 = _mm_loadu_pd(vd + 2 * _mm_extract_epi32(j, 3));
  const __m256d a = _mm256_set_m128d(p2, p0), b = _mm256_set_m128d(p3, p1);
  const __m256d v0 = _mm256_unpacklo_pd(a, b), dv = _mm256_unpackhi_pd(a, b);
  return _mm256_add_pd(v0, _mm256_mul_pd(dv, _mm256_sub_pd(u, _mm256_cvtepi32_pd(j))));
}
// The ground pools of one row, lamps inner: for each group of four pixels holding a ground pixel
// (mask[g] != 0, g = i/4), E = Σ_k lamp_E over the row's lamps k = 0 .. nl − 1 in their order, from
// the pixels' ground X (Xg, the row's (x − c_x)·k_x) and each lamp's X_l, dz², H², H. The same IEEE
// operations per lane as lamp_row_avx2 and the per-row sum over the lamps (the first lamp's E
// added to +0.0 is that E), so the same bits; the sum stays in a register instead of a row
// buffer. Groups without ground pixels are not computed (nothing reads them).
__attribute__((target("avx2")))
void pool_row_avx2(double* e, const double* Xg, const uint8_t* mask, int n, const double* Xl, const double* dz2,
                   const double* H2, const double* Hl, int nl, double I0, const RelTable& t) {
  const __m256d vstep = _mm256_set1_pd(t.step), vcc = _mm256_set1_pd(t.cc), vI0 = _mm256_set1_pd(I0);
  const __m256d one = _mm256_set1_pd(1.0), zero = _mm256_setzero_pd();
  for (int i = 0; i < n; i += 4) {
    if (!mask[i / 4]) continue;
    const __m256d X = _mm256_loadu_pd(Xg + i);
    __m256d acc = zero;
    for (int k = 0; k < nl; ++k) {
      const __m256d dx = _mm256_sub_pd(X, _mm256_broadcast_sd(Xl + k));
      const __m256d d2 = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(dx, dx), _mm256_broadcast_sd(dz2 + k)),
                                       _mm256_broadcast_sd(H2 + k));
      const __m256d c = _mm256_div_pd(_mm256_broadcast_sd(Hl + k), _mm256_sqrt_pd(d2));
      const __m256d beyond = _mm256_cmp_pd(c, vcc, _CMP_LT_OQ);  // γ beyond the cut-off: the table
      __m256d rel = one;
      if (_mm256_movemask_pd(beyond)) {
        rel = _mm256_blendv_pd(one, rel_lerp(t, _mm256_div_pd(c, vstep)), beyond);
      }
      acc = _mm256_add_pd(acc, _mm256_div_pd(_mm256_mul_pd(_mm256_mul_pd(vI0, rel), c), d2));
    }
    _mm256_storeu_pd(e + i, acc);
  }
  _mm256_zeroupper();
}
// vzeroupper: clears the upper halves of the vector registers. Vector code run earlier in the
// chain leaves them dirty, and every SSE (non-VEX) instruction after it then waits on a merge with
// them: add_vertical_street_light's loop ran 3.3× slower inside the light map than alone on the
// same inputs (bench night, AMD EPYC with AVX-512, 2026-11-25: 105 ms against 32 ms, one thread;
// 33 ms there after a vzeroupper). Where the state is left dirty is not found yet.
__attribute__((target("avx"))) void clear_upper_vector_state() { _mm256_zeroupper(); }
const bool kHaveAvx = __builtin_cpu_supports("avx");
bool is_pole(int id) { return id == static_cast<int>(Label::Pole) || id == static_cast<int>(Label::PoleGroup); }
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

StreetLighting plan_street_lighting(const LabelMap& lm, const CameraGeometry& g, const ScenePreset& p, uint64_t seed) {
  StreetLighting s;
  if (p.street_road_luminance_cd_m2 <= 0) return s;
  const ImageU16& ids = lm.ids;
  const int W = ids.width(), H = ids.height();
  const double S = p.lamp_spacing_ratio * p.lamp_mount_height_m;
  // Road extent across: per row with the ground 20..60 m ahead, the carriageway the camera looks
  // along: from the principal column outward over road and the vehicles standing on it, to the
  // first other pixel (the kerb); a run reaching the image border says nothing about that side.
  // Medians over the rows. (Taking this run rather than the outermost road pixels keeps side
  // streets entering the view from moving the edges.)
  std::vector<double> lefts, rights;
  auto carriageway = [&](int id) { return id == static_cast<int>(Label::Road) || is_vehicle(id); };
  const int xc = static_cast<int>(std::lround(g.cx_px));
  for (int y = std::max(0, static_cast<int>(std::ceil(g.horizon_y)) + 1); y < H && xc >= 0 && xc < W; ++y) {
    double D;
    if (!g.ground_point(g.cx_px, y, nullptr, &D, nullptr) || D < 20 || D > 60) continue;
    if (ids.at(xc, y) != static_cast<int>(Label::Road)) continue;
    int x0 = xc, x1 = xc;
    while (x0 > 0 && carriageway(ids.at(x0 - 1, y))) --x0;
    while (x1 < W - 1 && carriageway(ids.at(x1 + 1, y))) ++x1;
    double Xa, Xb;
    g.ground_point(x0 - 0.5, y, &Xa, nullptr, nullptr);
    g.ground_point(x1 + 0.5, y, &Xb, nullptr, nullptr);
    if (x0 > 0) lefts.push_back(Xa);
    if (x1 < W - 1) rights.push_back(Xb);
  }
  if (lefts.empty() || rights.empty()) return s;
  auto median = [](std::vector<double> v) {
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    return v[v.size() / 2];
  };
  // In quarter metres: the layout (and the intensity scaled to it) then does not jitter as the
  // rows that enter the medians change with the view.
  s.road_left_m = 0.25 * std::round(4 * median(lefts));
  s.road_right_m = 0.25 * std::round(4 * median(rights));
  // Poles: connected pole regions standing on the ground (their lowest pixel below the horizon),
  // at least min_pole_height_m tall, not capped by a sign or signal (those carry none).
  {
    cv::Mat mask(H, W, CV_8U);
#pragma omp parallel for schedule(static)
    for (int y = 0; y < H; ++y) {
      const uint16_t* r = ids.row(y);
      uint8_t* m = mask.ptr<uint8_t>(y);
      for (int x = 0; x < W; ++x) m[x] = is_pole(r[x]) ? 255 : 0;
    }
    // The components' labels from OpenCV, their bounding boxes from the pole pixels here: what
    // connectedComponentsWithStats gives (LEFT, TOP, WIDTH, HEIGHT), without its per-pixel area
    // and centroid sums over the whole frame, background included (12 of this function's 14 ms
    // on a 2048x1024 frame).
    cv::Mat cc;
    const int n = cv::connectedComponents(mask, cc, 8, CV_32S);
    struct Box { int x0 = 1 << 30, y0 = 1 << 30, x1 = -1, y1 = -1; };
    std::vector<Box> box(n);
    for (int y = 0; y < H; ++y) {
      const uint8_t* m = mask.ptr<uint8_t>(y);
      const int* l = cc.ptr<int>(y);
      for (int x = 0; x < W; ++x)
        if (m[x]) {
          Box& b = box[l[x]];
          b.x0 = std::min(b.x0, x);
          b.x1 = std::max(b.x1, x);
          b.y0 = std::min(b.y0, y);
          b.y1 = y;  // rows ascend
        }
    }
    for (int c = 1; c < n; ++c) {
      const int x0 = box[c].x0, w = box[c].x1 - box[c].x0 + 1;
      const int y0 = box[c].y0, h = box[c].y1 - box[c].y0 + 1;
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
  {
    const double phase = street_layout_phase_m(p, seed);
    const bool both = s.road_right_m - s.road_left_m > p.lamp_mount_height_m;
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
  s.source = poles.empty() ? "road_edges" : "poles+road_edges";
  std::sort(s.lamps.begin(), s.lamps.end(), [](const auto& a, const auto& b) { return a.D_m < b.D_m; });
  // Luminous intensity: a luminaire's is a property of the installation, not of the view. It is
  // set on the design layout (one row at the kerb, spacing S, height H, over a carriageway as
  // wide as the mounting height, the rule of thumb for one-sided layouts [U]) so that the EN
  // 13201-3 calculation field (one spacing long, 10 x 6 points) averages the class luminance:
  //   L_avg = ρ_road·Ē/π = L_class  →  I0 = π·L_class / (ρ_road·Ē(I0 = 1)).
  // L_avg and U0 are then reported on this scene's own layout and road extent.
  auto field = [&](const StreetLighting& lay, double left, double right, double D0, double* u0) {
    double sum = 0, mn = 1e300;
    for (int i = 0; i < 10; ++i)
      for (int j = 0; j < 6; ++j) {
        const double e = street_illuminance_lux(left + (j + 0.5) * (right - left) / 6, D0 + (i + 0.5) * S / 10, lay, p);
        sum += e;
        mn = std::min(mn, e);
      }
    const double avg = sum / 60;
    if (u0) *u0 = avg > 0 ? mn / avg : 0;
    return avg;
  };
  {
    StreetLighting design;
    design.peak_intensity_cd = 1;
    const double Hm = p.lamp_mount_height_m;
    for (int k = -3; k <= 3; ++k) design.lamps.push_back({Hm + p.lamp_setback_m, Hm, k * S, false});
    s.peak_intensity_cd = M_PI * p.street_road_luminance_cd_m2 / (p.rho_road * field(design, 0, Hm, 0, nullptr));
  }
  s.grid_D0_m = std::max(10.0, S);
  const double avg = field(s, s.road_left_m, s.road_right_m, s.grid_D0_m, &s.uniformity_u0);
  s.avg_luminance_cd_m2 = p.rho_road * avg / M_PI;
  return s;
}

int add_street_lighting(ImageF& L, const ImageF& texture, const ImageU16& labels, const CameraGeometry& g,
                        const StreetLighting& s, const ScenePreset& p, const ImageF* depth_m) {
  if (s.lamps.empty()) return 0;
  const int W = L.width(), H = L.height();
  const auto tl = illuminant_tint(p.street_cct_K);
  const float tlf[3] = {static_cast<float>(tl[0] / M_PI), static_cast<float>(tl[1] / M_PI), static_cast<float>(tl[2] / M_PI)};
  const RelTable table = rel_table(p);  // a copy: the loop's threads each read it
  const int y_start = std::max(0, static_cast<int>(std::floor(g.horizon_y)) + 1);
  const auto& ground = ground_classes();
#pragma omp parallel
  {
    std::vector<double> acc(W + 4), one(W), Xg(W + 4), Xl, dz2, H2, Hl;
    std::vector<uint8_t> gmask(W / 4 + 2);
#pragma omp for schedule(static, 8)
    for (int y = y_start; y < H; ++y) {
      double D0, t;
      if (!g.ground_point(g.cx_px, y, nullptr, &D0, &t)) continue;
      const uint16_t* id = labels.row(y);
      int xa = 0, xb = W;  // the row's ground pixels lie in [xa, xb)
      while (xa < xb && (id[xa] >= kLabelCount || !ground[id[xa]])) ++xa;
      while (xb > xa && (id[xb - 1] >= kLabelCount || !ground[id[xb - 1]])) --xb;
      if (xa == xb) continue;
      // Each lamp over its footprint, the band of rows within its reach along the road (the
      // ground row is a line of constant D; reach_m: beyond it a lamp gives at most
      // rel(γ_reach)·cos³γ_reach = 0.24% of its nadir illuminance I0/H², dropped), added over the
      // row's ground span in the lamps' order: every pixel's sum runs over the same lamps in the
      // same order as a per-pixel loop would, so the result is the same to the bit. (A disc of
      // radius reach_m around the foot instead of the band measured 5% faster on the bench frame
      // and changed dim pixels by up to 4%: not taken.)
      bool any = false;
      const double kx = t / g.f_px;
      if (kHaveAvx2) {
        Xl.clear();
        dz2.clear();
        H2.clear();
        Hl.clear();
        for (const auto& l : s.lamps) {
          if (!(std::fabs(D0 - l.D_m) <= reach_m(l.Y_m, p))) continue;
          const double dz = D0 - l.D_m;
          Xl.push_back(l.X_m);
          dz2.push_back(dz * dz);
          H2.push_back(l.Y_m * l.Y_m);
          Hl.push_back(l.Y_m);
        }
        any = !Xl.empty();
        if (!any) continue;
        // Pixels from xa in groups of four (the last padded with columns past xb, computed
        // and not read); a group is computed when it holds a ground pixel.
        const int n = xb - xa;
        for (int i = 0; i < n + 3; ++i) Xg[i] = (xa + i - g.cx_px) * kx;  // lamp_row's (x − c_x)·k_x
        for (int q = 0; 4 * q < n; ++q) {
          uint8_t m = 0;
          for (int x = xa + 4 * q; x < std::min(xb, xa + 4 * q + 4); ++x) m |= id[x] < kLabelCount && ground[id[x]];
          gmask[q] = m;
        }
        pool_row_avx2(acc.data() + xa, Xg.data(), gmask.data(), n, Xl.data(), dz2.data(), H2.data(), Hl.data(),
                      static_cast<int>(Xl.size()), s.peak_intensity_cd, table);
      } else {
        for (const auto& l : s.lamps) {
          if (!(std::fabs(D0 - l.D_m) <= reach_m(l.Y_m, p))) continue;
          lamp_row_scalar(any ? one.data() : acc.data() + xa, xa, xb - xa, g.cx_px, kx, l.X_m, D0 - l.D_m, l.Y_m,
                   s.peak_intensity_cd, table);
          if (any)
            for (int x = xa; x < xb; ++x) acc[x] += one[x - xa];
          any = true;
        }
      }
      if (!any) continue;
      const float* tx = texture.row(y);
      float* o = L.row(y);
      for (int x = xa; x < xb; ++x) {
        if (id[x] >= kLabelCount || !ground[id[x]]) continue;
        const float ef = static_cast<float>(acc[x]);
        for (int k = 0; k < 3; ++k) o[3 * x + k] += tx[3 * x + k] * tlf[k] * ef;
      }
    }
  }
  // Lamp heads: discs of the head's diameter at its projected size, only over their footprint.
  const auto head = spectrum::blackbody_rgb(p.streetlamp_cct_K, p.streetlamp_luminance_cd_m2);
  int drawn = 0;
  for (const auto& l : s.lamps) {
    double u, v, z;
    if (!g.project(l.X_m, l.Y_m, l.D_m, &u, &v, &z)) continue;
    const double r = std::max(0.5, 0.5 * g.f_px * p.lamp_head_diameter_m / z);
    if (u + r < 0 || u - r >= W || v + r < 0 || v - r >= H) continue;
    bool any = false;
    for (int y = std::max(0, static_cast<int>(std::floor(v - r))); y <= std::min(H - 1, static_cast<int>(std::ceil(v + r))); ++y)
      for (int x = std::max(0, static_cast<int>(std::floor(u - r))); x <= std::min(W - 1, static_cast<int>(std::ceil(u + r))); ++x)
        if ((x - u) * (x - u) + (y - v) * (y - v) <= r * r && (!depth_m || depth_m->at(x, y) >= z - 1.0)) {
          for (int k = 0; k < 3; ++k) L.at(x, y, k) = std::max(L.at(x, y, k), static_cast<float>(head[k]));
          any = true;
        }
    drawn += any;
  }
  return drawn;
}

namespace {
// One row's vertical-surface pixels, compacted (add_vertical_street_light): column, camera z and,
// for façade pixels, the lit normal of their plane (plane = -1; 0: the normal turned to the
// camera, from the point). Padded to a multiple of 4 by repeating the last pixel (its lanes are
// computed and dropped).
struct VerticalRow {
  std::vector<int32_t> x;
  std::vector<int64_t> plane;
  std::vector<double> z, pnX, pnD, e;
  explicit VerticalRow(int W) : x(W + 4), plane(W + 4), z(W + 4), pnX(W + 4), pnD(W + 4), e(W + 4) {}
  void pad(int n) {
    for (int i = n; i % 4; ++i) {
      x[i] = x[n - 1];
      plane[i] = plane[n - 1];
      z[i] = z[n - 1];
      pnX[i] = pnX[n - 1];
      pnD[i] = pnD[n - 1];
    }
  }
};
// The pixel's point in road coordinates (X right, Y up, D ahead; camera foot at the origin) from
// its camera z: X = z·(x − c_x)/f, D = z·kD, Y = h − z·kY, with the row's kD = cos θ − y_n·sin θ
// and kY = y_n·cos θ + sin θ.
struct RowGeom { double cx, f, kD, kY, h; };
// The lamps as arrays, with each one's reach along the road.
struct LampArrays {
  std::vector<double> X, Y, D, reach;
  double max_reach = 0;
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
// E_v = Σ_k I0·rel(cos γ)·(cos β)/max(d², d²_min) over the lamps in order, per pixel (a skipped
// lamp adds nothing; in the vector path it adds +0.0, which leaves the non-negative sum's bits
// unchanged). A pixel whose camera-facing normal is undefined (X = D = 0) gets 0.
void vertical_e_scalar(VerticalRow& r, int n, const RowGeom& q, const LampArrays& la, double I0, double d2_min,
                       const RelTable& t) {
  for (int i = 0; i < n; ++i) {
    const double zz = r.z[i];
    const double X = zz * (r.x[i] - q.cx) / q.f, D = zz * q.kD, Y = q.h - zz * q.kY;
    double nX, nD;  // the surface's horizontal unit normal, toward the half-space it is lit from
    r.e[i] = 0;
    if (r.plane[i]) {
      nX = r.pnX[i];
      nD = r.pnD[i];
    } else {
      // Cars, people, poles, vegetation, walls: a vertical face turned to the camera (an
      // approximation: their own orientation is not known from the labels).
      const double rr = std::sqrt(X * X + D * D);
      if (!(rr > 0)) continue;
      nX = -X / rr;
      nD = -D / rr;
    }
    size_t lo, hi;
    lamp_window(la, D, D, &lo, &hi);
    double e = 0;
    for (size_t k = lo; k < hi; ++k) {
      // The ground pools' footprint rule: a lamp is evaluated only within reach_m of its foot
      // along the road.
      if (!(std::fabs(D - la.D[k]) <= la.reach[k])) continue;
      const double vX = la.X[k] - X, vY = la.Y[k] - Y, vD = la.D[k] - D;
      const double cb = nX * vX + nD * vD;  // |v|·cos β
      // Nothing above the luminaire (a cut-off luminaire emits no light upward: γ < 90°, an
      // approximation of its upward light output ratio as 0) nor on faces turned away.
      if (!(vY > 0) || !(cb > 0)) continue;
      const double dv2 = vX * vX + vY * vY + vD * vD, dv = std::sqrt(dv2), cg = vY / dv;
      e += I0 * t.at(cg) * (cb / dv) / std::max(dv2, d2_min);  // I(γ)·cos β / d²
    }
    r.e[i] = e;
  }
}
// vertical_e_scalar four pixels at a time: the same IEEE operations in the same order per lane
// (the table read by masked gathers; a lamp's lanes outside its reach, above it or facing away
// masked to +0.0), so the same bits. Lamps whose every lane is masked are skipped whole: their
// contribution is exactly zero. Ends with vzeroupper (see clear_upper_vector_state).
__attribute__((target("avx2")))
void vertical_e_avx2(VerticalRow& r, int n, const RowGeom& q, const LampArrays& la, double I0, double d2_min,
                     const RelTable& t) {
  const __m256d vI0 = _mm256_set1_pd(I0), vd2min = _mm256_set1_pd(d2_min), zero = _mm256_setzero_pd();
  const __m256d vstep = _mm256_set1_pd(t.step), vcc = _mm256_set1_pd(t.cc), one = _mm256_set1_pd(1.0);
  const __m256d absmask = _mm256_castsi256_pd(_mm256_set1_epi64x(0x7fffffffffffffffll));
  const __m256d sign = _mm256_castsi256_pd(_mm256_set1_epi64x(static_cast<int64_t>(0x8000000000000000ull)));
  const __m256d cx = _mm256_set1_pd(q.cx), f = _mm256_set1_pd(q.f), kD = _mm256_set1_pd(q.kD),
                kY = _mm256_set1_pd(q.kY), h = _mm256_set1_pd(q.h);
  for (int i = 0; i < n; i += 4) {
    const __m256d zz = _mm256_loadu_pd(&r.z[i]);
    const __m256d xd = _mm256_cvtepi32_pd(_mm_loadu_si128(reinterpret_cast<const __m128i*>(&r.x[i])));  // exact
    const __m256d X = _mm256_div_pd(_mm256_mul_pd(zz, _mm256_sub_pd(xd, cx)), f);
    const __m256d D = _mm256_mul_pd(zz, kD), Y = _mm256_sub_pd(h, _mm256_mul_pd(zz, kY));
    const __m256d pm = _mm256_castsi256_pd(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(&r.plane[i])));
    __m256d nX = _mm256_loadu_pd(&r.pnX[i]), nD = _mm256_loadu_pd(&r.pnD[i]), ok = pm;
    if (_mm256_movemask_pd(pm) != 0xf) {
      const __m256d rr = _mm256_sqrt_pd(_mm256_add_pd(_mm256_mul_pd(X, X), _mm256_mul_pd(D, D)));
      ok = _mm256_or_pd(pm, _mm256_cmp_pd(rr, zero, _CMP_GT_OQ));
      nX = _mm256_blendv_pd(_mm256_div_pd(_mm256_xor_pd(X, sign), rr), nX, pm);
      nD = _mm256_blendv_pd(_mm256_div_pd(_mm256_xor_pd(D, sign), rr), nD, pm);
    }
    const __m256d m1 = _mm256_min_pd(D, _mm256_permute2f128_pd(D, D, 1)), M1 = _mm256_max_pd(D, _mm256_permute2f128_pd(D, D, 1));
    const double Dmin = _mm256_cvtsd_f64(_mm256_min_pd(m1, _mm256_permute_pd(m1, 5)));
    const double Dmax = _mm256_cvtsd_f64(_mm256_max_pd(M1, _mm256_permute_pd(M1, 5)));
    size_t lo, hi;
    lamp_window(la, Dmin, Dmax, &lo, &hi);
    __m256d acc = zero;
    for (size_t k = lo; k < hi; ++k) {
      const __m256d lD = _mm256_broadcast_sd(&la.D[k]);
      const __m256d in_reach = _mm256_and_pd(
          ok, _mm256_cmp_pd(_mm256_and_pd(_mm256_sub_pd(D, lD), absmask), _mm256_broadcast_sd(&la.reach[k]), _CMP_LE_OQ));
      if (!_mm256_movemask_pd(in_reach)) continue;
      const __m256d vX = _mm256_sub_pd(_mm256_broadcast_sd(&la.X[k]), X);
      const __m256d vY = _mm256_sub_pd(_mm256_broadcast_sd(&la.Y[k]), Y);
      const __m256d vD = _mm256_sub_pd(lD, D);
      const __m256d cb = _mm256_add_pd(_mm256_mul_pd(nX, vX), _mm256_mul_pd(nD, vD));
      const __m256d lit = _mm256_and_pd(in_reach, _mm256_and_pd(_mm256_cmp_pd(vY, zero, _CMP_GT_OQ),
                                                                _mm256_cmp_pd(cb, zero, _CMP_GT_OQ)));
      if (!_mm256_movemask_pd(lit)) continue;
      const __m256d dv2 = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(vX, vX), _mm256_mul_pd(vY, vY)), _mm256_mul_pd(vD, vD));
      const __m256d dv = _mm256_sqrt_pd(dv2), cg = _mm256_div_pd(vY, dv);
      const __m256d beyond = _mm256_and_pd(lit, _mm256_cmp_pd(cg, vcc, _CMP_LT_OQ));  // γ beyond the cut-off
      __m256d rel = one;
      if (_mm256_movemask_pd(beyond)) {
        rel = _mm256_blendv_pd(one, rel_lerp(t, _mm256_div_pd(cg, vstep)), beyond);
      }
      const __m256d ek = _mm256_div_pd(_mm256_mul_pd(_mm256_mul_pd(vI0, rel), _mm256_div_pd(cb, dv)), _mm256_max_pd(dv2, vd2min));
      acc = _mm256_add_pd(acc, _mm256_and_pd(lit, ek));
    }
    _mm256_storeu_pd(&r.e[i], acc);
  }
  _mm256_zeroupper();
}
}  // namespace

void add_vertical_street_light(ImageF& L, const ImageF& texture, const ImageU16& labels, const ImageF& depth_m,
                               const CameraGeometry& g, const StreetLighting& s, const ScenePreset& p,
                               const BuildingFacades* facades) {
  if (s.lamps.empty()) return;
  const int W = L.width(), H = L.height();
  const auto tl = illuminant_tint(p.street_cct_K);
  const float tlf[3] = {static_cast<float>(tl[0] / M_PI), static_cast<float>(tl[1] / M_PI), static_cast<float>(tl[2] / M_PI)};
  const RelTable table = rel_table(p);  // a copy: the loop's threads each read it
  const auto& ground = ground_classes();
  // Façade pixels: the plane metric_depth took their depth from (and add_facade_windows lays its
  // windows in); its normal (n_X, n_D) points away from the camera, the lit face the other way.
  const BuildingFacades computed = facades ? BuildingFacades() : building_facades(labels, g, p.max_depth_m);
  const BuildingFacades& fac = facades ? *facades : computed;
  LampArrays la;
  for (const auto& l : s.lamps) {
    la.X.push_back(l.X_m);
    la.Y.push_back(l.Y_m);
    la.D.push_back(l.D_m);
    la.reach.push_back(reach_m(l.Y_m, p));
    la.max_reach = std::max(la.max_reach, la.reach.back());
  }
  // The point-source law E = I/d² holds to 1% beyond five times the source's size (the
  // photometric "five-times rule": an on-axis Lambertian disc of diameter a gives I/(d² + a²/4));
  // nearer (the top of a lamp's own pole) d² is held at (5a)², a stated approximation that keeps
  // E finite. (The ground pools do not apply it: their d is at least the mounting height, 8-10 m
  // in the presets.)
  const double d2_min = 25 * p.lamp_head_diameter_m * p.lamp_head_diameter_m;
  const double c = std::cos(g.pitch_rad), sn = std::sin(g.pitch_rad), h = g.mount_height_m;
  const int sky = static_cast<int>(Label::Sky), building = static_cast<int>(Label::Building);
  const double I0 = s.peak_intensity_cd;
  // Per row: the lit pixels compacted (scalar), then their points, normals and E_v over the lamps
  // (vectorized), then the reflection into L. Each pixel's sum is its own, so rows may go to any
  // thread.
#pragma omp parallel
  {
  if (kHaveAvx) clear_upper_vector_state();  // on each thread (see clear_upper_vector_state)
  VerticalRow r(W);
#pragma omp for schedule(static, 8)
  for (int y = 0; y < H; ++y) {
    const float* z = depth_m.row(y);
    const uint16_t* id = labels.row(y);
    const int32_t* reg = fac.region.row(y);
    const double yn = (y - g.cy_px) / g.f_px;
    const RowGeom q{g.cx_px, g.f_px, c - yn * sn, yn * c + sn, h};
    int n = 0;
    for (int x = 0; x < W; ++x) {
      const int k = id[x];
      if (k == sky || (k < kLabelCount && ground[k])) continue;
      const float zz = z[x];
      if (!(zz > 0) || zz >= kDepthInfinity_m) continue;
      // On buildings the pixel's façade plane (BuildingFacades::plane_at, inlined).
      const FacadePlane* f = nullptr;
      if (k == building && reg[x] >= 0) {
        const BuildingFacades::Region& R = fac.regions[reg[x]];
        const int pi = R.column_plane[x - R.x0];
        if (pi >= 0) f = &fac.planes[pi];
      }
      r.x[n] = x;
      r.z[n] = zz;
      r.plane[n] = f ? -1 : 0;
      r.pnX[n] = f ? -f->nX : 0.0;
      r.pnD[n] = f ? -f->nD : 0.0;
      ++n;
    }
    if (n == 0) continue;
    if (kHaveAvx2) {
      r.pad(n);
      vertical_e_avx2(r, n, q, la, I0, d2_min, table);
    } else {
      vertical_e_scalar(r, n, q, la, I0, d2_min, table);
    }
    const float* tx = texture.row(y);
    float* o = L.row(y);
    for (int i = 0; i < n; ++i) {
      const double e = r.e[i];
      if (!(e > 0)) continue;
      const int x = r.x[i];
      const float ef = static_cast<float>(e);
      for (int qq = 0; qq < 3; ++qq) o[3 * x + qq] += tx[3 * x + qq] * tlf[qq] * ef;
    }
  }
  }
}

}  // namespace photosite::scene

namespace photosite::scene {

int add_facade_windows(ImageF& L, const ImageU16& labels, const ImageF& depth_m, const CameraGeometry& g,
                       const ScenePreset& p, uint64_t seed, const BuildingFacades* facades) {
  const int W = L.width(), H = L.height();
  const double c = std::cos(g.pitch_rad), sn = std::sin(g.pitch_rad), h = g.mount_height_m;
  const double max_z = 0.5 * p.window_width_m * g.f_px;  // footprint z/f <= width/2
  // Each building pixel's façade: the plane fitted to its region's ground contacts (or the
  // region's unfitted plane), the same that gave metric_depth its depth.
  const BuildingFacades computed = facades ? BuildingFacades() : building_facades(labels, g, p.max_depth_m);
  const BuildingFacades& fac = facades ? *facades : computed;
  // Per plane: the horizontal unit vector along it, oriented away from the camera (increasing D;
  // a plane facing the camera squarely runs toward +X), and the key of its lit draws: the
  // normal's azimuth in 5° steps and its distance from the camera's foot in 5 m steps, both in
  // the world, so a façade keeps its windows' draws when the camera moves.
  struct Frame { double tX, tD; uint64_t key; };
  std::vector<Frame> frames(fac.planes.size());
  for (size_t k = 0; k < fac.planes.size(); ++k) {
    const FacadePlane& f = fac.planes[k];
    double tX = f.nD, tD = -f.nX;
    if (tD < 0 || (tD == 0 && tX < 0)) { tX = -tX; tD = -tD; }
    const uint64_t az = static_cast<uint64_t>(std::lround(std::atan2(f.nX, f.nD) * 180 / M_PI / 5.0) + 64) & 127;
    const uint64_t dist = static_cast<uint64_t>(std::lround(f.d_m / 5.0)) & 1023;
    frames[k] = {tX, tD, (az << 10) | dist};
  }
  // Unit-luminance colours of the three window CCTs (a blackbody's box RGB is linear in its
  // luminance; spectrum::blackbody_rgb integrates Planck's law, far too slow per pixel).
  const auto warm1 = spectrum::blackbody_rgb(p.window_cct_K, 1.0), cool1 = spectrum::blackbody_rgb(p.window_cool_cct_K, 1.0),
             shop1 = spectrum::blackbody_rgb(p.shop_cct_K, 1.0);
  std::unordered_set<uint64_t> all;
#pragma omp parallel
  {
    std::unordered_set<uint64_t> seen;
#pragma omp for schedule(static, 8)
    for (int y = 0; y < H; ++y) {
      const float* z = depth_m.row(y);
      const int32_t* reg = fac.region.row(y);
      float* o = L.row(y);
      uint64_t last_key = ~0ull;
      bool last_lit = false;
      float last_col[3] = {0, 0, 0};
      const double yn = (y - g.cy_px) / g.f_px;
      for (int x = 0; x < W; ++x) {
        if (reg[x] < 0 || z[x] > max_z) continue;
        // The pixel's façade plane (BuildingFacades::plane_at, inlined).
        const BuildingFacades::Region& R = fac.regions[reg[x]];
        const int pi = R.column_plane[x - R.x0];
        if (pi < 0) continue;
        const Frame& fr = frames[pi];
        const double zz = z[x], X = zz * (x - g.cx_px) / g.f_px, D = zz * (c - yn * sn), Y = h - zz * (yn * c + sn);
        if (Y < 0) continue;
        const double s = fr.tX * X + fr.tD * D;  // along the façade (m)
        const int j = static_cast<int>(std::floor(Y / p.window_storey_m));
        const double y_in = Y - j * p.window_storey_m;
        uint64_t cell;
        bool shop = j == 0;
        if (!shop) {
          // Upper storeys: a window_width_m x window_height_m window centred in each pitch x storey cell.
          const int64_t i = static_cast<int64_t>(std::floor(s / p.window_pitch_m));
          const double s_in = s - i * p.window_pitch_m;
          if (std::fabs(s_in - 0.5 * p.window_pitch_m) > 0.5 * p.window_width_m ||
              std::fabs(y_in - 0.5 * p.window_storey_m) > 0.5 * p.window_height_m)
            continue;
          cell = static_cast<uint64_t>(i + (1 << 19)) & 0xfffff;
        } else {
          // Ground floor: shops of shop_frontage_m, each a row of panes shop_width_m wide on the
          // window pitch (piers between them), from shop_sill_m to shop_sill_m + shop_height_m;
          // a shop is lit or dark as a whole.
          const int64_t i = static_cast<int64_t>(std::floor(s / p.window_pitch_m));
          const double s_in = s - i * p.window_pitch_m;
          if (std::fabs(s_in - 0.5 * p.window_pitch_m) > 0.5 * p.shop_width_m || y_in < p.shop_sill_m ||
              y_in > p.shop_sill_m + p.shop_height_m)
            continue;
          cell = static_cast<uint64_t>(static_cast<int64_t>(std::floor(s / p.shop_frontage_m)) + (1 << 19)) & 0xfffff;
        }
        const uint64_t key = (fr.key << 40) | (cell << 12) | (static_cast<uint64_t>(j) & 0xfff);
        // Neighbouring pixels of a row mostly share a window: its draw is kept.
        if (key != last_key) {
          last_key = key;
          const auto w = random_words(seed, 0, 0xfacade0000000000ull ^ key, Stream::Scene);
          last_lit = uniform_open(w[0]) < p.window_lit_fraction;
          if (last_lit) {
            double lum = p.window_luminance_cd_m2 * (0.5 + uniform_open(w[1]));  // 0.5..1.5×
            const auto* unit = uniform_open(w[2]) < p.window_warm_share ? &warm1 : &cool1;
            if (shop) { lum *= p.shop_luminance_factor; unit = &shop1; }
            for (int k = 0; k < 3; ++k) last_col[k] = static_cast<float>((*unit)[k] * lum);
            seen.insert(key);
          }
        }
        if (!last_lit) continue;
        for (int k = 0; k < 3; ++k) o[3 * x + k] = std::max(o[3 * x + k], last_col[k]);
      }
    }
#pragma omp critical
    all.insert(seen.begin(), seen.end());
  }
  return static_cast<int>(all.size());
}

}  // namespace photosite::scene
