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
  }
  return t;
}
inline double lamp_E(double dx, double dz, double H, double I0, const RelTable& t) {
  const double d2 = dx * dx + dz * dz + H * H, d = std::sqrt(d2), c = H / d;
  return I0 * t.at(c) * c / d2;
}
// One lamp's E over the ground points X = (x − c_x)·k_x of a row (x = x0 .. x0 + n − 1, at the
// lamp distance dz along the road), into e: lamp_E's operations in the same order. With AVX2
// four pixels at a time (the table read by a gather); the same IEEE operations either way, so the
// same bits.
void lamp_row_scalar(double* e, int x0, int n, double cx, double kx, double Xl, double dz, double Hl, double I0,
                     const RelTable& t) {
  for (int i = 0; i < n; ++i) e[i] = lamp_E((x0 + i - cx) * kx - Xl, dz, Hl, I0, t);
}
__attribute__((target("avx2")))
void lamp_row_avx2(double* e, int x0, int n, double cx, double kx, double Xl, double dz, double Hl, double I0,
                   const RelTable& t) {
  const __m256d vcx = _mm256_set1_pd(cx), vkx = _mm256_set1_pd(kx), vXl = _mm256_set1_pd(Xl);
  const __m256d dz2 = _mm256_set1_pd(dz * dz), H2 = _mm256_set1_pd(Hl * Hl), vH = _mm256_set1_pd(Hl);
  const __m256d vstep = _mm256_set1_pd(t.step), vcc = _mm256_set1_pd(t.cc), vI0 = _mm256_set1_pd(I0);
  const __m256d one = _mm256_set1_pd(1.0), lane = _mm256_set_pd(3, 2, 1, 0);
  const __m128i jmax = _mm_set1_epi32(4095);
  const __m256d all = _mm256_castsi256_pd(_mm256_set1_epi64x(-1));
  int i = 0;
  for (; i + 4 <= n; i += 4) {
    const __m256d x = _mm256_add_pd(_mm256_set1_pd(static_cast<double>(x0 + i)), lane);  // exact integers
    const __m256d dx = _mm256_sub_pd(_mm256_mul_pd(_mm256_sub_pd(x, vcx), vkx), vXl);
    const __m256d d2 = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(dx, dx), dz2), H2);
    const __m256d c = _mm256_div_pd(vH, _mm256_sqrt_pd(d2));
    const __m256d beyond = _mm256_cmp_pd(c, vcc, _CMP_LT_OQ);  // γ beyond the cut-off: the table
    __m256d rel = one;
    if (_mm256_movemask_pd(beyond)) {
      const __m256d u = _mm256_div_pd(c, vstep);
      const __m128i j = _mm_min_epi32(_mm256_cvttpd_epi32(u), jmax);
      const __m256d v0 = _mm256_mask_i32gather_pd(_mm256_setzero_pd(), t.v.data(), j, all, 8);
      const __m256d v1 = _mm256_mask_i32gather_pd(_mm256_setzero_pd(), t.v.data() + 1, j, all, 8);
      const __m256d r = _mm256_add_pd(v0, _mm256_mul_pd(_mm256_sub_pd(v1, v0), _mm256_sub_pd(u, _mm256_cvtepi32_pd(j))));
      rel = _mm256_blendv_pd(one, r, beyond);
    }
    _mm256_storeu_pd(e + i, _mm256_div_pd(_mm256_mul_pd(_mm256_mul_pd(vI0, rel), c), d2));
  }
  lamp_row_scalar(e + i, x0 + i, n - i, cx, kx, Xl, dz, Hl, I0, t);
}
const bool kHaveAvx2 = __builtin_cpu_supports("avx2");
void lamp_row(double* e, int x0, int n, double cx, double kx, double Xl, double dz, double Hl, double I0,
              const RelTable& t) {
  if (kHaveAvx2) lamp_row_avx2(e, x0, n, cx, kx, Xl, dz, Hl, I0, t);
  else lamp_row_scalar(e, x0, n, cx, kx, Xl, dz, Hl, I0, t);
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
    std::vector<double> acc(W), one(W);  // the row's E, one lamp's E (from xa on)
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
      for (const auto& l : s.lamps) {
        if (!(std::fabs(D0 - l.D_m) <= reach_m(l.Y_m, p))) continue;
        lamp_row(any ? one.data() : acc.data() + xa, xa, xb - xa, g.cx_px, kx, l.X_m, D0 - l.D_m, l.Y_m,
                 s.peak_intensity_cd, table);
        if (any)
          for (int x = xa; x < xb; ++x) acc[x] += one[x - xa];
        any = true;
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
  std::vector<double> reach(s.lamps.size());
  for (size_t i = 0; i < s.lamps.size(); ++i) reach[i] = reach_m(s.lamps[i].Y_m, p);
  // The point-source law E = I/d² holds to 1% beyond five times the source's size (the
  // photometric "five-times rule": an on-axis Lambertian disc of diameter a gives I/(d² + a²/4));
  // nearer (the top of a lamp's own pole) d² is held at (5a)², a stated approximation that keeps
  // E finite. (The ground pools do not apply it: their d is at least the mounting height, 8-10 m
  // in the presets.)
  const double d2_min = 25 * p.lamp_head_diameter_m * p.lamp_head_diameter_m;
  const double c = std::cos(g.pitch_rad), sn = std::sin(g.pitch_rad), h = g.mount_height_m;
  const int sky = static_cast<int>(Label::Sky), building = static_cast<int>(Label::Building);
  const double I0 = s.peak_intensity_cd;
#pragma omp parallel
  {
  if (kHaveAvx) clear_upper_vector_state();  // on each thread (see clear_upper_vector_state)
#pragma omp for schedule(static, 8)
  for (int y = 0; y < H; ++y) {
    const float* z = depth_m.row(y);
    const uint16_t* id = labels.row(y);
    const int32_t* reg = fac.region.row(y);
    const float* tx = texture.row(y);
    float* o = L.row(y);
    const double yn = (y - g.cy_px) / g.f_px;
    for (int x = 0; x < W; ++x) {
      const int k = id[x];
      if (k == sky || (k < kLabelCount && ground[k])) continue;
      const double zz = z[x];
      if (!(zz > 0) || zz >= kDepthInfinity_m) continue;
      // The pixel's point in road coordinates (X right, Y up, D ahead; camera foot at the origin).
      const double X = zz * (x - g.cx_px) / g.f_px, D = zz * (c - yn * sn), Y = h - zz * (yn * c + sn);
      double nX, nD;  // the surface's horizontal unit normal, toward the half-space it is lit from
      const FacadePlane* f = k == building && reg[x] >= 0 ? fac.plane_at(x, y) : nullptr;
      if (f) {
        nX = -f->nX;
        nD = -f->nD;
      } else {
        // Cars, people, poles, vegetation, walls: a vertical face turned to the camera (an
        // approximation: their own orientation is not known from the labels).
        const double r = std::sqrt(X * X + D * D);
        if (!(r > 0)) continue;
        nX = -X / r;
        nD = -D / r;
      }
      double e = 0;
      for (size_t i = 0; i < s.lamps.size(); ++i) {
        const StreetLamp& l = s.lamps[i];
        // The ground pools' footprint rule: a lamp is evaluated only within reach_m of its foot
        // along the road.
        if (!(std::fabs(D - l.D_m) <= reach[i])) continue;
        const double vX = l.X_m - X, vY = l.Y_m - Y, vD = l.D_m - D;
        const double cb = nX * vX + nD * vD;  // |v|·cos β
        // Nothing above the luminaire (a cut-off luminaire emits no light upward: γ < 90°, an
        // approximation of its upward light output ratio as 0) nor on faces turned away.
        if (!(vY > 0) || !(cb > 0)) continue;
        const double dv2 = vX * vX + vY * vY + vD * vD, dv = std::sqrt(dv2), cg = vY / dv;
        e += I0 * table.at(cg) * (cb / dv) / std::max(dv2, d2_min);  // I(γ)·cos β / d²
      }
      if (!(e > 0)) continue;
      const float ef = static_cast<float>(e);
      for (int q = 0; q < 3; ++q) o[3 * x + q] += tx[3 * x + q] * tlf[q] * ef;
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
        const FacadePlane* f = fac.plane_at(x, y);
        if (!f) continue;
        const Frame& fr = frames[f - fac.planes.data()];
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
