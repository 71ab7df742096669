// Vanishing point from line intersections, with label priors as fallback (stage 5), and the
// coarse depth it implies (stage 6).
#include <algorithm>
#include <cmath>
#include <map>

#include "photosite/scene/night.h"
#include "core/isa_detail.h"
#include "scene/night_detail.h"

namespace photosite::scene {

const char* vp_method_name(VpMethod m) {
  switch (m) {
    case VpMethod::Hough: return "hough";
    case VpMethod::RoadPrior: return "road_prior";
    case VpMethod::GroundPrior: return "ground_prior";
    case VpMethod::SkyPrior: return "sky_prior";
    case VpMethod::ImageCentre: return "image_centre";
  }
  return "?";
}

namespace {
// The pixels of a row (W ids) that are road or parking: branch-free, so that the clones count 16
// or 32 at a time (the per-pixel test and branch took ~0.8 ms of a 1024x512 working frame).
PHOTOSITE_TARGET_CLONES
int count_road(const uint16_t* __restrict r, int W) {
  constexpr uint16_t road = static_cast<uint16_t>(Label::Road), parking = static_cast<uint16_t>(Label::Parking);
  int n = 0;
  for (int x = 0; x < W; ++x) n += (r[x] == road) | (r[x] == parking);
  return n;
}
// Per column, the last row so far whose pixel is sky: low[x] = y where row y's pixel is sky.
PHOTOSITE_TARGET_CLONES
void sky_rows(const uint16_t* __restrict r, int W, int y, int* __restrict low) {
  constexpr uint16_t sky = static_cast<uint16_t>(Label::Sky);
  for (int x = 0; x < W; ++x) low[x] = r[x] == sky ? y : low[x];
}

// The horizon prior from the labels: the far end of the road (its topmost rows, robustly),
// else of any ground class (sidewalk, terrain, ...), else the lowest sky boundary, else the
// image centre. The scans go row by row (counts and last rows: the same numbers in any order).
VanishingPoint label_prior(const ImageU16& labels, const std::string& why) {
  const int W = labels.width(), H = labels.height();
  VanishingPoint vp;
  vp.note = why;
  auto is_road = [](int id) { return id == static_cast<int>(Label::Road) || id == static_cast<int>(Label::Parking); };
  // row_count(r): the class's pixels in row r.
  auto far_end = [&](auto&& member, auto&& row_count, VpMethod method, double confidence) {
    std::vector<size_t> rows(H, 0);
    size_t total = 0;
    for (int y = 0; y < H; ++y) {
      rows[y] = static_cast<size_t>(row_count(labels.row(y)));
      total += rows[y];
    }
    if (total < std::max<size_t>(16, labels.pixel_count() / 500)) return false;
    // Top: the first row with 0.5% of the class's pixels above it.
    size_t acc = 0;
    int y_top = 0;
    for (int y = 0; y < H; ++y) {
      acc += rows[y];
      if (acc >= total / 200 + 1) { y_top = y; break; }
    }
    if (y_top >= H - 1) return false;  // the class only touches the bottom row: no horizon
    double sx = 0, n = 0;
    const int y_end = std::min(H - 1, y_top + std::max(1, H / 50));
    for (int y = y_top; y <= y_end; ++y) {
      const uint16_t* r = labels.row(y);
      for (int x = 0; x < W; ++x)
        if (member(r[x])) { sx += x; ++n; }
    }
    vp.x = n > 0 ? sx / n : W / 2.0;
    vp.y = y_top;
    vp.method = method;
    vp.confidence = confidence;
    return true;
  };
  if (far_end(is_road, [&](const uint16_t* r) { return count_road(r, W); }, VpMethod::RoadPrior, 0.3)) return vp;
  const auto& ground = ground_classes();
  auto is_ground_id = [&](int id) { return id < kLabelCount && ground[id]; };
  auto count_ground = [&](const uint16_t* r) {
    int n = 0;
    for (int x = 0; x < W; ++x) n += is_ground_id(r[x]);
    return n;
  };
  if (far_end(is_ground_id, count_ground, VpMethod::GroundPrior, 0.2)) return vp;
  // Sky: per column the lowest sky row, over columns where the sky ends above the bottom; the
  // 90th percentile (the deepest view between buildings) approximates the horizon.
  std::vector<int> low(W, -1);
  for (int y = 0; y < H; ++y) sky_rows(labels.row(y), W, y, low.data());
  std::vector<int> sky_bottom;
  for (int x = 0; x < W; ++x)
    if (low[x] >= 0 && low[x] < H - 1) sky_bottom.push_back(low[x]);
  if (!sky_bottom.empty() && sky_bottom.size() >= static_cast<size_t>(std::max(1, W / 10))) {
    const size_t k = sky_bottom.size() * 9 / 10;
    std::nth_element(sky_bottom.begin(), sky_bottom.begin() + k, sky_bottom.end());
    vp.x = W / 2.0;
    vp.y = sky_bottom[k];
    vp.method = VpMethod::SkyPrior;
    vp.confidence = 0.1;
    return vp;
  }
  vp.x = W / 2.0;
  vp.y = H / 2.0;
  vp.method = VpMethod::ImageCentre;
  vp.confidence = 0;
  return vp;
}

// Whether two segments span nearby bands of rows: their row ranges overlap, or lie apart by at
// most half the shorter one's span. On flat ground a row is one distance ahead, so the two are
// chords of road lines (markings, kerbs, the sides of vehicles) over nearby stretches of road. Why
// only those pairs: any two ground lines of one direction meet on the horizon, two of different
// directions at a ground point, below the horizon where they converge ahead, above it where they
// diverge. On a bend of radius R the road's lines are concentric arcs: chords of them over the
// same stretch are parallel, while chords over stretches ΔD apart differ in direction by about
// ΔD/R. A near chord of one line paired with a far one of another drew the vanishing point up to
// 36 px (1.8°) off the horizon at 1024x512 near 100-400 m bends (`photosite bench depth
// --synthetic`, docs/night.md §6b); with this rule at most 7.3 px. On a straight road all pairs are
// of one direction and those left out add no other witness; with fewer intersections a frame of
// few lines falls back to a prior more often (1 of that bench's 15 near straight cases). Measured,
// not derived: requiring an overlap of 0 to 0.75 of the shorter span gave the same medians on the
// bends, but the straight street with three vehicles of MetricDepth.SyntheticCameraSceneThroughTheChain
// lost pairs whose rows lie apart (its horizon 1.02 → 2.02 px off); a gap of half the shorter span
// keeps them (1.02 px) and the bends' medians. A photosite choice. (Test:
// SceneGeometry.FarChordsOfABendDoNotDrawTheVanishingPoint.)
bool share_rows(const Segment& a, const Segment& b) {
  const double a0 = std::min(a.y0, a.y1), a1 = std::max(a.y0, a.y1);
  const double b0 = std::min(b.y0, b.y1), b1 = std::max(b.y0, b.y1);
  return std::min(a1, b1) - std::max(a0, b0) >= -0.5 * std::min(a1 - a0, b1 - b0);
}

// Whether the point (x, y) lies on the segment's line beyond its ends (within 2 px of an end
// counts as beyond: a line drawn up to its vanishing point). A line's image ends at its vanishing
// point, so the segment lies wholly on one side of it; a point well inside a segment is where it
// crosses another line. On kitti_000002_10 (a street corner), with lines kept from 5° of
// horizontal, the chords Hough cut of the corner's curved kerb crossed one another inside
// themselves and drew a vanishing point 16 px (1.3°) below the rig's horizon; with this rule the
// frame falls back to the rig, as it did with the 12° rule (docs/night.md §2–6).
bool beyond_ends(const Segment& s, double x, double y) {
  const double dx = s.x1 - s.x0, dy = s.y1 - s.y0, len2 = dx * dx + dy * dy;
  if (!(len2 > 0)) return true;
  const double t = ((x - s.x0) * dx + (y - s.y0) * dy) / len2, m = 2 / std::sqrt(len2);
  return t <= m || t >= 1 - m;
}

}  // namespace

VanishingPoint vanishing_point(const std::vector<Segment>& lines, const ImageU16& labels,
                               const ScenePreset& p) {
  const int W = labels.width(), H = labels.height();
  if (lines.size() < 2) return label_prior(labels, "fewer than 2 lines");
  struct Pt { double x, y; };
  std::vector<Pt> pts;
  pts.reserve(lines.size() * lines.size() / 2);
  for (size_t i = 0; i < lines.size(); ++i)
    for (size_t j = i + 1; j < lines.size(); ++j) {
      const Segment &a = lines[i], &b = lines[j];
      if (!share_rows(a, b)) continue;  // chords of stretches of road far apart
      const double a1 = a.y1 - a.y0, b1 = a.x0 - a.x1, c1 = a1 * a.x0 + b1 * a.y0;
      const double a2 = b.y1 - b.y0, b2 = b.x0 - b.x1, c2 = a2 * b.x0 + b2 * b.y0;
      const double det = a1 * b2 - a2 * b1;
      const double na = std::hypot(a1, b1), nb = std::hypot(a2, b2);
      if (std::fabs(det) < 0.1 * na * nb) continue;  // within ~6° of parallel
      const double x = (b2 * c1 - b1 * c2) / det, y = (a1 * c2 - a2 * c1) / det;
      if (!beyond_ends(a, x, y) || !beyond_ends(b, x, y)) continue;  // a line does not run past its vanishing point
      if (x < -W || x > 2.0 * W || y < -H || y > 2.0 * H) continue;
      pts.push_back({x, y});
    }
  if (pts.empty()) return label_prior(labels, "no line intersections near the image (of lines over nearby rows)");
  // Densest cluster: vote in a grid of cells of the cluster radius, take the best 3x3
  // neighbourhood, then two mean-shift steps with a flat kernel of that radius.
  const double r = p.vp_cluster_radius_fraction * std::hypot(W, H);
  std::map<std::pair<int, int>, int> grid;
  for (const auto& q : pts) ++grid[{static_cast<int>(std::floor(q.x / r)), static_cast<int>(std::floor(q.y / r))}];
  int best = -1;
  std::pair<int, int> bc{0, 0};
  for (const auto& [c, n] : grid) {
    int s = 0;
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) {
        auto it = grid.find({c.first + dx, c.second + dy});
        if (it != grid.end()) s += it->second;
      }
    if (s > best || (s == best && c < bc)) { best = s; bc = c; }
  }
  double cx = (bc.first + 0.5) * r, cy = (bc.second + 0.5) * r;
  int support = 0;
  for (int it = 0; it < 3; ++it) {
    double sx = 0, sy = 0;
    int n = 0;
    for (const auto& q : pts)
      if (std::hypot(q.x - cx, q.y - cy) <= 1.5 * r) { sx += q.x; sy += q.y; ++n; }
    if (n == 0) break;
    cx = sx / n;
    cy = sy / n;
    support = n;
  }
  VanishingPoint vp;
  vp.x = cx;
  vp.y = cy;
  vp.support = support;
  if (support < p.vp_min_support)
    return label_prior(labels, "largest intersection cluster has " + std::to_string(support) +
                                   " points (< " + std::to_string(p.vp_min_support) + ")");
  if (cx < 0 || cx >= W || cy < 0 || cy >= H)
    return label_prior(labels, "intersection cluster lies outside the image");
  vp.method = VpMethod::Hough;
  // Confidence: the share of intersections that agree, saturating with the number of lines.
  vp.confidence = std::min(1.0, (static_cast<double>(support) / pts.size()) *
                                    std::min(1.0, lines.size() / 6.0));
  vp.confidence = std::max(vp.confidence, 0.31);  // a Hough VP is trusted above any prior
  return vp;
}

namespace {
// One row of coarse_depth: min(1, max(tx, ty)) in double, rounded to float; the clones take four
// or eight pixels at a time, the same operations per pixel (max and min in the operand order of
// std::max and std::min).
PHOTOSITE_TARGET_CLONES
void coarse_depth_row(float* row, const double* txs, double ty, int W) {
  for (int x = 0; x < W; ++x) row[x] = static_cast<float>(std::min(1.0, std::max(txs[x], ty)));
}
}  // namespace

CoarseDepthRows::CoarseDepthRows(int W, int H, double vx, double vy) : width(W), height(H), txs(W) {
  vx = std::clamp(vx, 0.0, W - 1.0);
  vy_ = std::clamp(vy, 0.0, H - 1.0);
  const double left = std::max(vx, 1e-9), right = std::max(W - 1 - vx, 1e-9);
  top = std::max(vy_, 1e-9);
  bottom = std::max(H - 1 - vy_, 1e-9);
  // The column term once per column (the same expression, so the same values): one division
  // per column instead of one per pixel.
  for (int x = 0; x < W; ++x) txs[x] = x >= vx ? (x - vx) / right : (vx - x) / left;
}

void CoarseDepthRows::row(ImageF& d, int y) const {
  const double ty = y >= vy_ ? (y - vy_) / bottom : (vy_ - y) / top;
  coarse_depth_row(d.row(y), txs.data(), ty, width);
}

ImageF coarse_depth(int W, int H, double vx, double vy) {
  ImageF d(W, H, 1, uninitialized, unit::dimensionless);
  const CoarseDepthRows rows(W, H, vx, vy);
#pragma omp parallel for schedule(static)
  for (int y = 0; y < H; ++y) rows.row(d, y);
  return d;
}

}  // namespace photosite::scene
