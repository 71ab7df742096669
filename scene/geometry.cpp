// Metric scene geometry: camera model from the rig, horizon, flat-ground and vertical-plane depth
// (see night.h for the equations).
#include <algorithm>
#include <cmath>
#include <numeric>

#include "photosite/scene/night.h"

namespace photosite::scene {

bool CameraGeometry::ground_point(double u, double v, double* X, double* D, double* z) const {
  const double xn = (u - cx_px) / f_px, yn = (v - cy_px) / f_px;
  const double c = std::cos(pitch_rad), s = std::sin(pitch_rad);
  const double den = yn * c + s;  // the ray's downward component per unit z
  if (den <= 0) return false;
  const double t = mount_height_m / den;  // = camera z of the ground point
  if (X) *X = t * xn;
  if (D) *D = t * (c - yn * s);
  if (z) *z = t;
  return true;
}

double CameraGeometry::ground_depth_m(double v) const {
  const double den = (v - cy_px) / f_px * std::cos(pitch_rad) + std::sin(pitch_rad);
  return den > 0 ? mount_height_m / den : INFINITY;
}

double CameraGeometry::plane_depth_m(double v, double D_plane) const {
  const double yn = (v - cy_px) / f_px;
  const double den = std::cos(pitch_rad) - yn * std::sin(pitch_rad);  // forward component per unit z
  return den > 0 ? D_plane / den : INFINITY;
}

bool CameraGeometry::project(double X, double Y, double D, double* u, double* v, double* z) const {
  const double c = std::cos(pitch_rad), s = std::sin(pitch_rad);
  const double zc = (mount_height_m - Y) * s + D * c;
  if (zc <= 0.05) return false;
  const double yc = (mount_height_m - Y) * c - D * s;
  if (u) *u = cx_px + f_px * X / zc;
  if (v) *v = cy_px + f_px * yc / zc;
  if (z) *z = zc;
  return true;
}

CameraGeometry camera_geometry(const CameraRig& rig, int width, int height, const VanishingPoint& vp) {
  CameraGeometry g;
  const CameraIntrinsics k = scaled_intrinsics(rig, width, height);
  g.rig = rig.name;
  g.f_px = k.f_px;
  g.cx_px = k.cx_px;
  g.cy_px = k.cy_px;
  g.mount_height_m = rig.mount_height_m;
  const double vp_pitch = std::atan((k.cy_px - vp.y) / k.f_px);
  // A Hough VP is at least 0.31 confident (vanishing.cpp); the label priors are at most 0.2 and
  // are guesses about where the horizon might be, not measurements of it.
  if (vp.method == VpMethod::Hough && vp.confidence >= 0.3 && std::fabs(vp_pitch) <= 15 * M_PI / 180) {
    g.pitch_rad = vp_pitch;
    g.horizon_source = "vanishing_point";
    g.horizon_confidence = vp.confidence;
  } else {
    g.pitch_rad = rig.pitch_deg * M_PI / 180;
    g.horizon_source = "rig";
    g.horizon_confidence = 0;
  }
  g.horizon_y = k.cy_px - k.f_px * std::tan(g.pitch_rad);
  return g;
}

namespace {
// 0: ground-like (flat-ground model), 1: sky, 2: object.
int kind_of(int id) {
  if (id == static_cast<int>(Label::Sky)) return 1;
  if (is_ground(id) || id == static_cast<int>(Label::EgoVehicle) ||
      id == static_cast<int>(Label::RectificationBorder) || id == static_cast<int>(Label::OutOfRoi))
    return 0;
  return 2;
}
bool single_plane_class(int id) {
  return is_vehicle(id) || id == static_cast<int>(Label::Person) || id == static_cast<int>(Label::Rider);
}
int find(std::vector<int>& p, int a) {
  while (p[a] != a) a = p[a] = p[p[a]];
  return a;
}
}  // namespace

ImageF metric_depth(const LabelMap& lm, const CameraGeometry& g, double max_depth_m) {
  const ImageU16& ids = lm.ids;
  const int W = ids.width(), H = ids.height();
  const bool inst = !lm.instances.empty();
  ImageF depth(W, H, 1, uninitialized, "m");
  // Per-row ground depth, and the horizontal distance D of the ground at each row's lower pixel
  // edge (y + 0.5: an object's lowest pixel meets the ground at its lower edge).
  std::vector<float> zg(H);
  std::vector<double> d_edge(H), plane(H);  // plane[y]: z per metre of D at row y (plane_depth_m(y, 1))
  for (int y = 0; y < H; ++y) {
    plane[y] = g.plane_depth_m(y, 1.0);
    const double z = g.ground_depth_m(y);
    zg[y] = static_cast<float>(std::isfinite(z) ? std::min(z, max_depth_m) : max_depth_m);
    double D = 0;
    d_edge[y] = g.ground_point(g.cx_px, y + 0.5, nullptr, &D, nullptr) ? std::min(D, max_depth_m) : max_depth_m;
  }
  // Runs of equal key (class id, or instance code for instance pixels) on object pixels.
  struct Run { int y, x0, x1, key; };
  std::vector<Run> runs;
  std::vector<int> row_start(H + 1, 0);
  uint8_t kinds[kLabelCount];
  for (int i = 0; i < kLabelCount; ++i) kinds[i] = static_cast<uint8_t>(kind_of(i));
  auto kind_fast = [&](int id) { return id < kLabelCount ? kinds[id] : 2; };
  auto key_at = [&](int x, int y) -> int {
    const int id = ids.at(x, y);
    if (kind_fast(id) != 2) return -1;
    if (inst) {
      const int c = lm.instances.at(x, y);
      if (c >= 1000) return 1000 + c;
    }
    return id;
  };
  for (int y = 0; y < H; ++y) {
    row_start[y] = static_cast<int>(runs.size());
    int x = 0;
    while (x < W) {
      const int k = key_at(x, y);
      int e = x + 1;
      while (e < W && key_at(e, y) == k) ++e;
      if (k >= 0) runs.push_back({y, x, e - 1, k});
      x = e;
    }
  }
  row_start[H] = static_cast<int>(runs.size());
  // Union of 4-connected runs with equal keys (overlapping x ranges in consecutive rows).
  std::vector<int> parent(runs.size());
  std::iota(parent.begin(), parent.end(), 0);
  for (int y = 1; y < H; ++y) {
    int j = row_start[y - 1];
    for (int i = row_start[y]; i < row_start[y + 1]; ++i) {
      while (j < row_start[y] && runs[j].x1 < runs[i].x0) ++j;
      for (int k = j; k < row_start[y] && runs[k].x0 <= runs[i].x1; ++k)
        if (runs[k].key == runs[i].key) {
          const int a = find(parent, i), b = find(parent, k);
          if (a != b) parent[std::max(a, b)] = std::min(a, b);
        }
    }
  }
  // Components: lowest row, x range; per-column lowest rows for the per-column kind.
  std::vector<int> comp(runs.size());
  struct Comp { int ymax = -1, x0 = 1 << 30, x1 = -1; bool single = false; size_t col_off = 0; };
  std::vector<Comp> comps;
  {
    std::vector<int> index(runs.size(), -1);
    for (size_t i = 0; i < runs.size(); ++i) {
      const int r = find(parent, static_cast<int>(i));
      if (index[r] < 0) {
        index[r] = static_cast<int>(comps.size());
        comps.push_back({});
        const int key = runs[i].key;
        comps.back().single = key >= 1000 || single_plane_class(key);
      }
      comp[i] = index[r];
      Comp& c = comps[comp[i]];
      c.ymax = std::max(c.ymax, runs[i].y);
      c.x0 = std::min(c.x0, runs[i].x0);
      c.x1 = std::max(c.x1, runs[i].x1);
    }
  }
  size_t cols = 0;
  for (auto& c : comps)
    if (!c.single) { c.col_off = cols; cols += c.x1 - c.x0 + 1; }
  std::vector<int> col_ymax(cols, -1);
  for (size_t i = 0; i < runs.size(); ++i) {  // rows ascend: the last write is the lowest
    const Comp& c = comps[comp[i]];
    if (c.single) continue;
    for (int x = runs[i].x0; x <= runs[i].x1; ++x) col_ymax[c.col_off + (x - c.x0)] = runs[i].y;
  }
  // The ground line of a vertical plane is a straight image line. Columns whose lowest pixel
  // stands on a ground class show the contact and keep it; a straight line fitted to them (least
  // squares, at least 8 columns and a fifth of the region's) gives the hidden columns theirs, so
  // that a façade behind parked cars or hedges stays one plane; it is never taken above the
  // column's own lowest pixel. With fewer such columns their median row is the contact (a fronto-parallel
  // plane); with none, a column's contact is the bottom of the stack of objects below it (a
  // façade behind a car: the nearest the hidden contact can be, a lower bound on the depth).
  std::vector<double> col_D(cols, max_depth_m);
  auto D_at = [&](double row) {  // horizontal distance of the ground at a (fractional) row edge
    double D = 0;
    return g.ground_point(g.cx_px, row, nullptr, &D, nullptr) ? std::min(D, max_depth_m) : max_depth_m;
  };
  for (auto& c : comps) {
    if (c.single) continue;
    double sx = 0, sy = 0, sxx = 0, sxy = 0;
    int n = 0, ncol = 0;
    std::vector<int> rows;
    for (int x = c.x0; x <= c.x1; ++x) {
      const int y = col_ymax[c.col_off + (x - c.x0)];
      if (y < 0) continue;
      ++ncol;
      if (y + 1 < H && kind_fast(ids.at(x, y + 1)) == 0) {
        sx += x; sy += y; sxx += double(x) * x; sxy += double(x) * y; ++n;
        rows.push_back(y);
      }
    }
    const double det = n * sxx - sx * sx;
    const bool line = n >= 8 && 5 * n >= ncol && det > 0;
    const double b = line ? (n * sxy - sx * sy) / det : 0, a = line ? (sy - b * sx) / n : 0;
    double med = -1;
    if (!line && n > 0) {
      std::nth_element(rows.begin(), rows.begin() + rows.size() / 2, rows.end());
      med = rows[rows.size() / 2];
    }
    for (int x = c.x0; x <= c.x1; ++x) {
      int y = col_ymax[c.col_off + (x - c.x0)];
      if (y < 0) continue;
      double yc;
      if (y + 1 < H && kind_fast(ids.at(x, y + 1)) == 0) yc = y;  // a column that shows its contact keeps it
      else if (line) yc = std::max<double>(y, a + b * x);
      else if (med >= 0) yc = std::max<double>(y, med);
      else {
        while (y + 1 < H && kind_fast(ids.at(x, y + 1)) == 2) ++y;
        yc = y;
      }
      col_D[c.col_off + (x - c.x0)] = D_at(yc + 0.5);
    }
  }
  // Fill: ground and sky per pixel, objects per run.
#pragma omp parallel for schedule(static)
  for (int y = 0; y < H; ++y) {
    float* o = depth.row(y);
    const uint16_t* r = ids.row(y);
    for (int x = 0; x < W; ++x) {
      o[x] = kind_fast(r[x]) == 1 ? kDepthInfinity_m : zg[y];  // objects overwritten below
    }
    for (int i = row_start[y]; i < row_start[y + 1]; ++i) {
      const Comp& c = comps[comp[i]];
      if (c.single) {
        const float z = static_cast<float>(std::min(plane[y] * d_edge[c.ymax], max_depth_m));
        std::fill(o + runs[i].x0, o + runs[i].x1 + 1, z);
      } else {
        for (int x = runs[i].x0; x <= runs[i].x1; ++x) {
          o[x] = static_cast<float>(std::min(plane[y] * col_D[c.col_off + (x - c.x0)], max_depth_m));
        }
      }
    }
  }
  return depth;
}

}  // namespace photosite::scene
