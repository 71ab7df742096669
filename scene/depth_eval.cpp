// Metric depth against stereo ground truth (see depth_eval.h).
#include "photosite/scene/depth_eval.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>

#include <fmt/format.h>
#include <opencv2/imgproc.hpp>

#include "photosite/error.h"
#include "scene/lanes_detail.h"

namespace photosite::scene {
namespace {
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
}  // namespace

double nearest_rank_quantile(std::vector<double> v, double q) {
  if (v.empty()) return kNaN;
  const size_t k = std::min(v.size() - 1, static_cast<size_t>(q * static_cast<double>(v.size() - 1) + 0.5));
  std::nth_element(v.begin(), v.begin() + static_cast<long>(k), v.end());
  return v[k];
}

StereoCalibration read_kitti_stereo_calibration(const std::string& path) {
  std::ifstream in(path);
  if (!in) fail_at(path, "cannot read the stereo calibration");
  std::map<std::string, std::vector<double>> rows;
  std::string line;
  while (std::getline(in, line)) {
    const auto colon = line.find(':');
    if (colon == std::string::npos) continue;
    const std::string key = line.substr(0, colon);
    if (key != "P_rect_02" && key != "P_rect_03") continue;
    std::istringstream ss(line.substr(colon + 1));
    std::vector<double> v;
    double x;
    while (ss >> x) v.push_back(x);
    if (v.size() != 12) fail_at(path, fmt::format("{}: expected 12 numbers (a 3x4 projection matrix), found {}", key, v.size()));
    rows[key] = v;
  }
  for (const char* k : {"P_rect_02", "P_rect_03"})
    if (!rows.count(k)) fail_at(path, std::string(k) + ": missing (a KITTI calib_cam_to_cam file has P_rect_02 and P_rect_03)");
  StereoCalibration c;
  c.fx_px = rows["P_rect_02"][0];
  // P_rect_0i[0][3] = −fx·(x offset of camera i from the reference camera 0).
  c.baseline_m = (rows["P_rect_02"][3] - rows["P_rect_03"][3]) / c.fx_px;
  if (!(c.fx_px > 0) || !(c.baseline_m > 0))
    fail_at(path, fmt::format("fx {} px and baseline {} m must be positive", c.fx_px, c.baseline_m));
  return c;
}

ImageF depth_from_kitti_disparity(const ImageU16& codes, const StereoCalibration& c) {
  ImageF z(codes.width(), codes.height(), 1, uninitialized);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const double fb = c.fx_px * c.baseline_m * 256.0;  // z = fx·B / (code / 256)
  for (size_t i = 0; i < codes.size(); ++i) z[i] = codes[i] ? static_cast<float>(fb / codes[i]) : nan;
  return z;
}

DepthErrors depth_errors(const ImageF& depth_m, const ImageF& truth_m, const LabelMap& labels, double max_depth_m,
                         int min_vehicle_px) {
  const int W = depth_m.width(), H = depth_m.height();
  if (truth_m.width() != W || truth_m.height() != H || labels.ids.width() != W || labels.ids.height() != H)
    fail(fmt::format("depth_errors: depth {}x{}, truth {}x{} and labels {}x{} must be one size", W, H,
                     truth_m.width(), truth_m.height(), labels.ids.width(), labels.ids.height()));
  auto measured = [&](size_t i) { return std::isfinite(truth_m[i]) && truth_m[i] > 0 && truth_m[i] <= max_depth_m; };
  DepthErrors e;
  std::vector<double> road;
  for (size_t i = 0; i < depth_m.size(); ++i)
    if (labels.ids[i] == static_cast<uint16_t>(Label::Road) && measured(i))
      road.push_back(std::fabs(static_cast<double>(depth_m[i]) - truth_m[i]) / truth_m[i]);
  e.road_pixels = road.size();
  e.road_median_rel = nearest_rank_quantile(road, 0.5);
  e.road_p90_rel = nearest_rank_quantile(road, 0.9);

  // Vehicles: instance codes where given, else 8-connected regions of one vehicle class.
  cv::Mat comp(H, W, CV_32S, cv::Scalar(0));
  int next = 1;
  const bool inst = !labels.instances.empty();
  std::map<int, int> by_code;  // instance code → component
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const int id = labels.ids.at(x, y);
      if (!is_vehicle(id)) continue;
      const int code = inst ? labels.instances.at(x, y) : 0;
      if (code >= 1000) {
        auto [it, fresh] = by_code.try_emplace(code, 0);
        if (fresh) it->second = next++;
        comp.at<int>(y, x) = it->second;
      }
    }
  for (int cls = 0; cls < kLabelCount; ++cls) {
    if (!is_vehicle(cls)) continue;
    cv::Mat mask(H, W, CV_8U, cv::Scalar(0));
    bool any = false;
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x)
        if (labels.ids.at(x, y) == cls && comp.at<int>(y, x) == 0) mask.at<uint8_t>(y, x) = 255, any = true;
    if (!any) continue;
    cv::Mat cc;
    const int n = cv::connectedComponents(mask, cc, 8, CV_32S);
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x)
        if (const int c = cc.at<int>(y, x); c > 0) comp.at<int>(y, x) = next + c - 1;
    next += n - 1;
  }
  std::vector<int> count(next, 0), bottom(next, -1), first(next, -1);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x)
      if (const int c = comp.at<int>(y, x)) {
        ++count[c];
        bottom[c] = std::max(bottom[c], y);
        if (first[c] < 0) first[c] = y * W + x;
      }
  std::vector<int> order;
  for (int c = 1; c < next; ++c)
    if (count[c] >= min_vehicle_px) order.push_back(c);
  std::sort(order.begin(), order.end(), [&](int a, int b) { return first[a] < first[b]; });
  for (const int c : order) {
    std::vector<double> z, t;
    const int y = bottom[c];
    for (int x = 0; x < W; ++x) {
      const size_t i = static_cast<size_t>(y) * W + x;
      if (comp.at<int>(y, x) == c && measured(i)) {
        z.push_back(depth_m[i]);
        t.push_back(truth_m[i]);
      }
    }
    if (t.empty()) continue;
    const double zt = nearest_rank_quantile(t, 0.5);
    e.contact_rel.push_back(std::fabs(nearest_rank_quantile(z, 0.5) - zt) / zt);
  }
  e.contacts = e.contact_rel.size();
  e.contact_median_rel = nearest_rank_quantile(e.contact_rel, 0.5);
  return e;
}


// ---------------------------------------------------------------------------------------------
// Dashed markings as rulers (depth_eval.h).

ImageU8 metric_marking_mask(const ImageF& luma_srgb, const ImageU16& labels, const CameraGeometry& g,
                            double blur_sigma_px, double threshold, double side_m) {
  const int W = luma_srgb.width(), H = luma_srgb.height();
  if (luma_srgb.channels() != 1 || !labels.same_shape(W, H) || labels.channels() != 1)
    fail(fmt::format("metric_marking_mask: a one-channel luminance and labels of one size (luminance {}x{}x{}, labels {}x{})",
                     W, H, luma_srgb.channels(), labels.width(), labels.height()));
  ImageU8 out(W, H, 1, uint8_t{0});
  const ImageF blurred = blur_sigma_px > 0 ? lane_blur(luma_srgb, blur_sigma_px) : ImageF();
  const ImageF& b = blur_sigma_px > 0 ? blurred : luma_srgb;
  const int y0 = std::max(0, static_cast<int>(std::floor(g.horizon_y)) + 1);
#pragma omp parallel for schedule(static, 8)
  for (int y = y0; y < H; ++y) {
    const double z = g.ground_depth_m(y);
    if (!std::isfinite(z)) continue;
    // The lane stage's row filter (horizontal pass only), its side pixels side_m away on the ground.
    const int w = std::max(2, static_cast<int>(std::lround(side_m * g.f_px / z)));
    lane_row(b.row(y), nullptr, nullptr, labels.row(y), W, w, static_cast<float>(threshold), out.row(y));
  }
  return out;
}

namespace {
// A dash's ends on the ground and the ground a row spans there; false where an end (or the row's
// far edge) is at or above the horizon.
bool ground_ends(MarkingDash& d, const CameraGeometry& g) {
  double D0, D1, D2, D3;
  if (!g.ground_point(d.near_u, d.near_v, &d.near_X_m, &d.near_D_m, nullptr) ||
      !g.ground_point(d.far_u, d.far_v, &d.far_X_m, &d.far_D_m, nullptr) ||
      !g.ground_point(d.near_u, d.near_v - 0.5, nullptr, &D0, nullptr) ||
      !g.ground_point(d.near_u, d.near_v + 0.5, nullptr, &D1, nullptr) ||
      !g.ground_point(d.far_u, d.far_v - 0.5, nullptr, &D2, nullptr) ||
      !g.ground_point(d.far_u, d.far_v + 0.5, nullptr, &D3, nullptr))
    return false;
  d.near_row_m = D0 - D1;
  d.far_row_m = D2 - D3;
  return true;
}
}  // namespace

std::vector<MarkingDash> marking_dashes(const ImageU8& markings, const ImageU16& labels, const CameraGeometry& g) {
  const int W = markings.width(), H = markings.height();
  std::vector<MarkingDash> out;
  if (!labels.same_shape(W, H) || labels.channels() != 1)
    fail(fmt::format("marking_dashes: labels {}x{} and markings {}x{} must be one size", labels.width(), labels.height(), W, H));
  if (W < 2 || H < 2) return out;
  // What lies just beyond an end: road or parking for two rows (the marking's own ground).
  auto open_end = [&](double u, int y0, int step) {
    const int x = static_cast<int>(std::lround(u));
    for (int k = 1; k <= 2; ++k) {
      const int y = y0 + step * k;
      if (y < 0 || y >= H || x < 0 || x >= W) return false;
      const int id = labels.at(x, y);
      if (id != static_cast<int>(Label::Road) && id != static_cast<int>(Label::Parking)) return false;
    }
    return true;
  };
  cv::Mat mask(H, W, CV_8U, const_cast<uint8_t*>(markings.data())), cc, stats, centroids;
  const int n = cv::connectedComponentsWithStats(mask, cc, stats, centroids, 8, CV_32S);
  // Per component: the columns on its first and last rows, and its pixels' lateral extent on the
  // ground (X at each pixel centre).
  struct Acc { double su_top = 0, su_bot = 0; int n_top = 0, n_bot = 0; double Xmin = INFINITY, Xmax = -INFINITY; bool above = false; };
  std::vector<Acc> acc(n);
  for (int y = 0; y < H; ++y) {
    const int* row = cc.ptr<int>(y);
    for (int x = 0; x < W; ++x) {
      const int c = row[x];
      if (c <= 0) continue;
      Acc& a = acc[c];
      const int top = stats.at<int>(c, cv::CC_STAT_TOP), bot = top + stats.at<int>(c, cv::CC_STAT_HEIGHT) - 1;
      if (y == top) a.su_top += x, ++a.n_top;
      if (y == bot) a.su_bot += x, ++a.n_bot;
      double X;
      if (g.ground_point(x, y, &X, nullptr, nullptr)) a.Xmin = std::min(a.Xmin, X), a.Xmax = std::max(a.Xmax, X);
      else a.above = true;
    }
  }
  for (int c = 1; c < n; ++c) {
    const Acc& a = acc[c];
    const int area = stats.at<int>(c, cv::CC_STAT_AREA);
    if (a.above || area < 8) continue;
    const int top = stats.at<int>(c, cv::CC_STAT_TOP), bot = top + stats.at<int>(c, cv::CC_STAT_HEIGHT) - 1;
    MarkingDash d;
    d.pixels = area;
    // Pixel centres sit at integer coordinates (ground_point's convention, as metric_depth reads
    // them): the dash's ends are the edges half a row beyond its first and last rows.
    d.near_v = bot + 0.5;
    d.far_v = top - 0.5;
    d.near_u = a.su_bot / a.n_bot;
    d.far_u = a.su_top / a.n_top;
    if (d.far_v - g.horizon_y < 2) continue;  // too near the horizon: rows span tens of metres
    if (!open_end(d.near_u, bot, 1) || !open_end(d.far_u, top, -1)) continue;
    if (!ground_ends(d, g)) continue;
    const double L = d.far_D_m - d.near_D_m;
    if (L < 0.3 || L > 12) continue;
    if (a.Xmax - a.Xmin > 0.35 + 0.2 * L) continue;
    // One row's ground span at the far end, D²/(f·h) (flat ground, small pitch): at most a
    // quarter of the dash.
    if (d.far_D_m * d.far_D_m / (g.f_px * g.mount_height_m) > 0.25 * L) continue;
    out.push_back(d);
  }
  std::sort(out.begin(), out.end(), [](const MarkingDash& a, const MarkingDash& b) { return a.near_D_m < b.near_D_m; });
  return out;
}

namespace {
// A least-squares line y = intercept + slope·x through points (x[i], y[i]), from centred sums: the
// means first, then Sxx = Σ(x − x̄)², Sxy = Σ(x − x̄)(y − ȳ), Syy = Σ(y − ȳ)². The one-pass form
// Σx² − (Σx)²/n subtracts two nearly equal numbers when the x lie far from 0 against their spread
// (the dashes' distances, 10-40 m across a few metres), losing about log10(x̄²/var(x)) of double's
// 16 digits; the centred sums lose none of them (Chan, Golub & LeVeque, "Algorithms for computing
// the sample variance", The American Statistician 37(3), 1983). measure() fits three lines with it.
struct LineFit {
  size_t n = 0;
  double x_mean = NAN, y_mean = NAN, sxx = 0, sxy = 0, syy = 0;
  // NaN when the x do not vary (no line through them).
  double slope() const { return sxx > 0 ? sxy / sxx : NAN; }
  double intercept_at(double slope) const { return y_mean - slope * x_mean; }
  // OLS standard error of the slope: sqrt(SSR / (n − 2) / Sxx), SSR = Syy − slope·Sxy (the
  // residuals' sum of squares); NaN below three points.
  double slope_se() const {
    if (n <= 2 || !(sxx > 0)) return NAN;
    return std::sqrt(std::max(0.0, syy - slope() * sxy) / static_cast<double>(n - 2) / sxx);
  }
};
LineFit fit_line(const std::vector<double>& x, const std::vector<double>& y) {
  LineFit f;
  f.n = x.size();
  double sx = 0, sy = 0;
  for (size_t i = 0; i < f.n; ++i) sx += x[i], sy += y[i];
  f.x_mean = sx / static_cast<double>(f.n);
  f.y_mean = sy / static_cast<double>(f.n);
  for (size_t i = 0; i < f.n; ++i) {
    const double dx = x[i] - f.x_mean, dy = y[i] - f.y_mean;
    f.sxx += dx * dx, f.sxy += dx * dy, f.syy += dy * dy;
  }
  return f;
}

// The line's periods and statistics from its dashes' ground ends; keep_flags: keep the regular set
// as it is (a re-measurement), else choose it.
void measure(DashedLine& L, bool keep_flags) {
  const size_t n = L.dashes.size();
  // The line on the ground, X = a + b·D, by least squares over the dashes' ends, and the farthest
  // end from it: a period is the distance along the line, ΔD·√(1 + b²).
  {
    std::vector<double> ends_D, ends_X;
    for (const MarkingDash& d : L.dashes) {
      ends_D.insert(ends_D.end(), {d.near_D_m, d.far_D_m});
      ends_X.insert(ends_X.end(), {d.near_X_m, d.far_X_m});
    }
    const LineFit line = fit_line(ends_D, ends_X);
    L.direction = line.sxx > 0 ? line.slope() : 0;
    const double a = line.intercept_at(L.direction);
    L.straightness_m = 0;
    for (size_t i = 0; i < ends_D.size(); ++i)
      L.straightness_m = std::max(L.straightness_m, std::fabs(ends_X[i] - a - L.direction * ends_D[i]));
  }
  const double along = std::sqrt(1 + L.direction * L.direction);
  L.periods_m.assign(n - 1, 0);
  L.at_D_m.assign(n - 1, 0);
  for (size_t i = 0; i + 1 < n; ++i) {
    const MarkingDash &a = L.dashes[i], &b = L.dashes[i + 1];
    L.periods_m[i] = along * 0.5 * ((b.near_D_m - a.near_D_m) + (b.far_D_m - a.far_D_m));
    L.at_D_m[i] = 0.25 * (a.near_D_m + a.far_D_m + b.near_D_m + b.far_D_m);
  }
  if (!keep_flags) {
    const double med = nearest_rank_quantile(L.periods_m, 0.5);
    L.regular.assign(n - 1, 0);
    for (size_t i = 0; i + 1 < n; ++i) L.regular[i] = std::fabs(L.periods_m[i] / med - 1) <= 0.25;
  }
  std::vector<double> P, D, lengths, spans;
  for (size_t i = 0; i + 1 < n; ++i)
    if (L.regular[i]) P.push_back(L.periods_m[i]), D.push_back(L.at_D_m[i]);
  for (const MarkingDash& d : L.dashes) {
    lengths.push_back(along * (d.far_D_m - d.near_D_m));
    spans.push_back(along * (d.near_row_m + d.far_row_m));
  }
  L.period_median_m = nearest_rank_quantile(P, 0.5);
  L.dash_median_m = nearest_rank_quantile(lengths, 0.5);
  {
    // Painted length and reach: lengths against the sum of the end rows' spans, least squares.
    const LineFit f = fit_line(spans, lengths);
    // The spans must vary: at least a row's worth at the nearest dash's distance across the line.
    const bool fit = n >= 3 && f.sxx > 0 && std::sqrt(f.sxx / static_cast<double>(n)) > 0.1 * f.x_mean;
    L.reach_rows = fit ? f.slope() : NAN;
    L.dash_painted_m = fit ? f.intercept_at(L.reach_rows) : NAN;
  }
  L.X_m = L.dashes[0].near_X_m;
  // The periods against distance: their mean and spread, and the slope with its standard error.
  const LineFit f = fit_line(D, P);
  L.period_mean_m = f.y_mean;
  L.period_sd_m = f.n > 1 ? std::sqrt(f.syy / static_cast<double>(f.n - 1)) : NAN;
  L.slope = f.slope();
  L.slope_se = f.slope_se();
}
}  // namespace

std::vector<DashedLine> dashed_lines(const std::vector<MarkingDash>& dashes) {
  std::vector<DashedLine> out;
  std::vector<char> used(dashes.size(), 0);
  for (size_t i = 0; i < dashes.size(); ++i) {
    if (used[i]) continue;
    DashedLine L;
    L.dashes.push_back(dashes[i]);
    used[i] = 1;
    for (;;) {
      const MarkingDash& a = L.dashes.back();
      const double len = a.far_D_m - a.near_D_m, b = (a.far_X_m - a.near_X_m) / len;  // X per metre along the road
      int best = -1;
      for (size_t j = 0; j < dashes.size(); ++j) {
        if (used[j]) continue;
        const MarkingDash& c = dashes[j];
        const double gap = c.near_D_m - a.far_D_m;
        if (gap < 0.2 || gap > 15) continue;
        if (std::fabs(c.near_X_m - (a.far_X_m + b * gap)) > 0.25 + 0.02 * gap) continue;
        if (best < 0 || c.near_D_m < dashes[best].near_D_m) best = static_cast<int>(j);
      }
      if (best < 0) break;
      L.dashes.push_back(dashes[best]);
      used[best] = 1;
    }
    if (L.dashes.size() < 4) continue;
    measure(L, false);
    // A line runs straight along the road: its ends within 0.15 m of their fitted line (a 0.12-0.30 m
    // line's centre, and a pixel's width at 60 m in a Cityscapes frame, 0.03 m); a curve's
    // forward distances are not lengths along it, and dashes of different lines or transverse
    // marks that happen to follow one another are not one line.
    if (L.straightness_m > 0.15) continue;
    const size_t n_regular = static_cast<size_t>(std::count(L.regular.begin(), L.regular.end(), 1));
    if (n_regular < 3 || 3 * n_regular < 2 * L.regular.size()) continue;
    out.push_back(std::move(L));
  }
  return out;
}

CameraGeometry shift_horizon(const CameraGeometry& g, double shift_px) {
  CameraGeometry s = g;
  s.horizon_y = g.horizon_y + shift_px;
  s.pitch_rad = std::atan((g.cy_px - s.horizon_y) / g.f_px);
  return s;
}

DashedLine remeasure(const DashedLine& line, const CameraGeometry& g) {
  DashedLine L = line;
  for (MarkingDash& d : L.dashes)
    if (!ground_ends(d, g))
      fail(fmt::format("remeasure: a dash's end (row {:.1f}) lies at or above the horizon ({:.1f})", d.far_v, g.horizon_y));
  measure(L, true);
  return L;
}

FlatHorizon flat_period_horizon(const DashedLine& line, const CameraGeometry& g, double search_px) {
  FlatHorizon r;
  // Moving the horizon down past a dash's far end leaves that end without a ground point: the
  // search stops a row short of the highest dash.
  double hi = search_px;
  for (const MarkingDash& d : line.dashes) hi = std::min(hi, d.far_v - g.horizon_y - 1);
  double lo = -search_px;
  if (!(hi > lo)) return r;
  auto slope = [&](double s) { return remeasure(line, shift_horizon(g, s)).slope; };
  double s_lo = slope(lo), s_hi = slope(hi);
  if (!(s_lo * s_hi < 0)) return r;
  for (int it = 0; it < 60 && hi - lo > 1e-3; ++it) {
    const double mid = 0.5 * (lo + hi), s_mid = slope(mid);
    if ((s_mid < 0) == (s_lo < 0)) lo = mid, s_lo = s_mid;
    else hi = mid, s_hi = s_mid;
  }
  r.shift_px = 0.5 * (lo + hi);
  // Standard error through the slope's: the slope is near linear in the shift (2P/(f·h) per row).
  const double d = slope(r.shift_px + 0.5) - slope(r.shift_px - 0.5);  // per row
  r.se_px = remeasure(line, shift_horizon(g, r.shift_px)).slope_se / std::fabs(d);
  return r;
}

// German practice (the shared frames are German streets: Cityscapes' 50 cities, KITTI's
// Karlsruhe). Verified against public copies, not the standards themselves [S]:
//  - ERA 2010 (FGSV, Empfehlungen für Radverkehrsanlagen): a Schutzstreifen (advisory cycle lane)
//    is marked by a Leitlinie of 1 m dashes and 1 m gaps (ADFC Forchheim, "Schutzstreifen",
//    quoting the ERA; width 1.25-1.5 m);
//  - RMS-1 (FGSV 1993, Richtlinien für die Markierung von Straßen): a Leitlinie (lane line) has
//    dash : gap = 1 : 2 away from junctions, 6 m : 12 m on motorways, a dash of usually 3 m in
//    built-up areas (Colliseum wiki "Fahrbahnmarkierung"; gutefrage.net quoting Wikipedia), and
//    "sometimes 1 : 1" (the same Wikipedia text): the 1 : 1 pattern with the built-up areas'
//    3 m dash is that combination, not a figure either source gives [D].
const std::vector<DashStandard>& dash_standards() {
  static const std::vector<DashStandard> s = {
      {1, 1, "ERA 2010 advisory cycle lane (Schutzstreifen): 1 m dash and 1 m gap"},
      {3, 6, "RMS-1 lane line (Leitlinie) in built-up areas: 3 m dash and 6 m gap"},
      {3, 3, "RMS-1 lane line (Leitlinie) 1:1 variant with the built-up 3 m dash: 3 m dash and 3 m gap"},
      {6, 12, "RMS-1 lane line (Leitlinie) on motorways: 6 m dash and 12 m gap"},
  };
  return s;
}

const DashStandard* nearest_dash_standard(double period_m, double dash_m) {
  const DashStandard* best = nullptr;
  double best_r = std::log(1.5);  // a pattern more than 1.5x off in period is not that pattern
  for (const DashStandard& d : dash_standards()) {
    const double P = d.dash_m + d.gap_m;
    if (std::fabs(dash_m / period_m - d.dash_m / P) > 0.1) continue;
    const double r = std::fabs(std::log(period_m / P));
    if (r < best_r) best_r = r, best = &d;
  }
  return best;
}

}  // namespace photosite::scene
