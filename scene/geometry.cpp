// Metric scene geometry: camera model from the rig, horizon, flat-ground and vertical-plane depth
// (see night.h for the equations).
#include <algorithm>
#include <bit>
#include <climits>
#include <cmath>
#include <cstring>
#include <memory>
#include <numeric>
#include <omp.h>

#include <fmt/format.h>

#include "photosite/error.h"
#include "photosite/scene/night.h"
#include "core/isa_detail.h"
#include "scene/night_detail.h"
#include "scene/runs_detail.h"

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
  // are guesses about where the horizon might be, not measurements of it. The VP's pitch must also
  // agree with the rig's nominal pitch within what a car-mounted camera's pitch varies
  // (rig.pitch_tolerance_deg, derived in rig.cpp): further off, the lines that made it are not the
  // road's (façade edges, a turning road) and the nominal pitch is the better horizon.
  const double nominal_pitch = rig.pitch_deg * M_PI / 180;
  if (vp.method == VpMethod::Hough && vp.confidence >= 0.3 &&
      std::fabs(vp_pitch - nominal_pitch) <= rig.pitch_tolerance_deg * M_PI / 180) {
    g.pitch_rad = vp_pitch;
    g.horizon_source = "vanishing_point";
    g.horizon_confidence = vp.confidence;
  } else {
    g.pitch_rad = nominal_pitch;
    g.horizon_source = "rig";
    g.horizon_confidence = 0;
  }
  g.horizon_y = k.cy_px - k.f_px * std::tan(g.pitch_rad);
  // Every row's ray must point ahead of the camera: its forward component per unit z,
  // cos θ − y_n·sin θ (plane_depth_m's denominator, y_n = (v − c_y)/f), positive, i.e. the ray
  // within 90° of the horizontal (θ + atan y_n in (−90°, 90°)). A rig whose field of view reaches
  // past straight down (or up) at this frame's edge rows (fx_px of a few px, c_y far off the
  // frame, |pitch| up to 30°: each within the rig schema's ranges) has ground points behind the
  // camera (D < 0) and fronto-parallel planes at z = D/0 or D/(negative): the depth map then held
  // −∞ and the façade windows converted ±∞ and NaN to integers (undefined behaviour, UBSan's
  // float-cast-overflow, docs/robustness.md). The forward component is monotonic in v, so the two
  // edges (v = −0.5 and H − 0.5) bound every row. Refused as bad input naming the rig.
  for (const double v : {-0.5, height - 0.5}) {
    const double yn = (v - k.cy_px) / k.f_px;
    if (!(std::cos(g.pitch_rad) - yn * std::sin(g.pitch_rad) > 0))
      fail(fmt::format("--rig {}{}: at pitch {:.2f} deg, f {:.4g} px and c_y {:.4g} px (for this {}x{} frame) the {} "
                       "row's ray points {:.1f} deg {} the horizontal, past straight {}: the flat-ground model needs "
                       "every row's ray ahead of the camera; check the rig's fx_px, cy_px and pitch_deg",
                       rig.name, rig.file.empty() ? "" : " (" + rig.file + ")", g.pitch_rad * 180 / M_PI, k.f_px,
                       k.cy_px, width, height, v < 0 ? "top" : "bottom",
                       std::fabs(g.pitch_rad + std::atan(yn)) * 180 / M_PI, yn > 0 ? "below" : "above",
                       yn > 0 ? "down" : "up"));
  }
  // What the user should hear about (each a likely wrong --rig, or a frame no rig describes).
  auto add = [&](const std::string& s) { g.note += (g.note.empty() ? "" : "; ") + s; };
  const double aspect = static_cast<double>(width) / height, native = rig.native_width_px / rig.native_height_px;
  // Three decimals down to 0.1 (every rig's and the usual frames' ratios); below, three
  // significant digits: an 8x16384 strip is 0.000488, not 0.000.
  const auto ratio = [](double a) { return a >= 0.1 ? fmt::format("{:.3f}", a) : fmt::format("{:.3g}", a); };
  if (std::fabs(aspect / native - 1) > 0.01)  // scaled_intrinsics' crop branch
    add(fmt::format("the frame's aspect ratio {} is not rig {}'s ({:.0f}x{:.0f}, {:.3f}): taken as a centred "
                    "crop of that frame at its f {:.1f} px{}; pass --rig with this camera's intrinsics",
                    ratio(aspect), rig.name, rig.native_width_px, rig.native_height_px, native, k.f_px,
                    width > rig.native_width_px || height > rig.native_height_px ? ", although it is larger" : ""));
  if (vp.method == VpMethod::Hough && vp.confidence >= 0.3 && g.horizon_source == "rig")
    add(fmt::format("the vanishing point (confidence {:.2f}) puts the pitch at {:.2f} deg, {:.2f} deg from rig {}'s "
                    "{:.2f} deg (tolerance {:.2f} deg): the rig's horizon is used; check --rig",
                    vp.confidence, vp_pitch * 180 / M_PI, std::fabs(vp_pitch - nominal_pitch) * 180 / M_PI, rig.name,
                    rig.pitch_deg, rig.pitch_tolerance_deg));
  if (g.horizon_y >= height - 0.5)
    add(fmt::format("the horizon (y {:.1f} px) lies below the frame: no ground is in view and every ground pixel "
                    "is at the depth cap; check --rig's pitch",
                    g.horizon_y));
  return g;
}

namespace {
// 0: ground-like (flat-ground model), 1: sky, 2: object.
int kind_of(int id) {
  if (id == static_cast<int>(Label::Sky)) return 1;
  if (is_ground(id) || is_not_scene(id)) return 0;
  return 2;
}
bool single_plane_class(int id) {
  return is_vehicle(id) || id == static_cast<int>(Label::Person) || id == static_cast<int>(Label::Rider);
}
int find(std::vector<int>& p, int a) {
  while (p[a] != a) a = p[a] = p[p[a]];
  return a;
}

// Runs of equal key per row and their 4-connected components: a union-find over runs of one key
// that overlap in consecutive rows (far cheaper than a per-pixel labelling, as labels come in
// long runs). segments(y, emit) calls emit(x0, x1, key) for pieces that cover row y from left to
// right (key < 0: no run there); touching pieces of one key are one run, so the runs are the
// maximal runs of equal key of a per-pixel scan whatever the pieces. Runs are in row order, row
// y's from row_start[y] to row_start[y + 1]; comp[i] numbers run i's component in the order of
// its first run (reading order), count of them. The rows are scanned in parallel, in fixed bands
// joined in row order: the same runs for any thread count.
struct KeyedRun { int y, x0, x1, key; };
struct RunComponents {
  std::vector<KeyedRun> runs;
  std::vector<int> row_start;
  std::vector<int> comp;
  int count = 0;
};
template <class Segments>
RunComponents run_components(int H, const Segments& segments) {
  RunComponents rc;
  auto& runs = rc.runs;
  auto& row_start = rc.row_start;
  constexpr int kBands = 16;
  std::vector<std::vector<KeyedRun>> band(kBands);
  std::vector<int> row_runs(H);
#pragma omp parallel for schedule(static)
  for (int b = 0; b < kBands; ++b) {
    std::vector<KeyedRun>& out = band[b];
    out.reserve(1024);
    for (int y = H * b / kBands; y < H * (b + 1) / kBands; ++y) {
      const size_t before = out.size();
      int cx0 = 0, cx1 = -1, ckey = INT_MIN;  // the run being extended
      segments(y, [&](int x0, int x1, int key) {
        if (key == ckey) { cx1 = x1; return; }
        if (ckey >= 0) out.push_back({y, cx0, cx1, ckey});
        cx0 = x0; cx1 = x1; ckey = key;
      });
      if (ckey >= 0) out.push_back({y, cx0, cx1, ckey});
      row_runs[y] = static_cast<int>(out.size() - before);
    }
  }
  size_t total = 0;
  for (const auto& b : band) total += b.size();
  runs.reserve(total);
  for (const auto& b : band) runs.insert(runs.end(), b.begin(), b.end());
  row_start.assign(H + 1, 0);
  for (int y = 0; y < H; ++y) row_start[y + 1] = row_start[y] + row_runs[y];
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
  rc.comp.assign(runs.size(), -1);
  std::vector<int> index(runs.size(), -1);
  for (size_t i = 0; i < runs.size(); ++i) {
    const int r = find(parent, static_cast<int>(i));
    if (index[r] < 0) index[r] = rc.count++;
    rc.comp[i] = index[r];
  }
  return rc;
}

// The lowest row of each column of each component, written into col_ymax[col_off(run) + x - x0(run)]
// for the runs that take part (col_off(run) < 0: skipped). Rows ascend, so the last write is the
// lowest; the columns are split into fixed strips written in parallel (each strip sees every run
// in order: the same result for any thread count).
template <class ColOff, class X0>
void lowest_rows(const std::vector<KeyedRun>& runs, int W, const ColOff& col_off, const X0& x0_of,
                 int* col_ymax) {
  // One strip per thread the loop gets (at most 8): each strip walks the whole run list, so
  // strips beyond the threads only repeat that walk (inside night_scene's side-by-side halves,
  // a nested region, the loop gets one thread).
  const int kStrips = omp_in_parallel() ? 1 : std::clamp(omp_get_max_threads(), 1, 8);
#pragma omp parallel for schedule(static)
  for (int s = 0; s < kStrips; ++s) {
    const int sa = W * s / kStrips, sb = W * (s + 1) / kStrips;
    for (size_t i = 0; i < runs.size(); ++i) {
      const KeyedRun& u = runs[i];
      if (u.x1 < sa || u.x0 >= sb) continue;
      const long off = col_off(i);
      if (off < 0) continue;
      const int x0 = x0_of(i), row = u.y;
      int* c = col_ymax + off;
      for (int x = std::max(u.x0, sa), xe = std::min(u.x1 + 1, sb); x < xe; ++x) c[x - x0] = row;
    }
  }
}
// The façade plane's depth z = d / (n_X·x_n + n_D·k) over columns [a, b) of a row (k: the row's
// cos θ − y_n·sin θ), where the denominator is positive (> 1e-9): the other pixels keep their
// value (written back unchanged, so that the AVX2 clone blends four at a time; the same
// operations per pixel either way).
__attribute__((target_clones("avx2", "default")))
void facade_span(float* o, const double* xn, int a, int b, double nX, double nD, double k, double d_m, double max_depth_m) {
  for (int x = a; x < b; ++x) {
    const double den = nX * xn[x] + nD * k;
    o[x] = den > 1e-9 ? static_cast<float>(std::min(d_m / den, max_depth_m)) : o[x];
  }
}
// o[i] = min(p·D[i], max) in double, rounded to float, over n pixels (a row's run of one object
// component); the clones take four or eight at a time, the same operations per pixel.
PHOTOSITE_TARGET_CLONES
void plane_fill(float* o, const double* D, int n, double p, double max_depth_m) {
  for (int i = 0; i < n; ++i) o[i] = static_cast<float>(std::min(p * D[i], max_depth_m));
}
}  // namespace

// metric_depth's part that reads only the labels (scene/night_detail.h): the object pixels'
// label-run components, each component's extent and kind, and the per-column lowest rows.
struct MetricDepthRuns {
  struct Comp { int ymax = -1, x0 = 1 << 30, x1 = -1; bool single = false; size_t col_off = 0; };
  LabelsMadeOf labels;  // the labels it was made of (metric_depth takes it for those only)
  RunComponents rc;
  std::vector<Comp> comps;
  std::vector<int> col_ymax;
};

std::shared_ptr<const LabelRuns> label_runs(const ImageU16& ids) {
  const int W = ids.width(), H = ids.height();
  auto m = std::make_shared<LabelRuns>();
  m->labels = LabelsMadeOf(ids);
  m->width = W;
  // Rows in fixed bands, joined in row order: the same runs for any thread count.
  constexpr int kBands = 16;
  std::vector<std::vector<int>> bx(kBands);
  std::vector<std::vector<uint16_t>> bid(kBands);
  std::vector<int> row_runs(H);
#pragma omp parallel for schedule(static)
  for (int b = 0; b < kBands; ++b)
    for (int y = H * b / kBands; y < H * (b + 1) / kBands; ++y) {
      const uint16_t* r = ids.row(y);
      const size_t before = bx[b].size();
      for (int x = 0; x < W; x = run_end(r, x, W)) {
        bx[b].push_back(x);
        bid[b].push_back(r[x]);
      }
      row_runs[y] = static_cast<int>(bx[b].size() - before);
    }
  m->row_start.assign(H + 1, 0);
  for (int y = 0; y < H; ++y) m->row_start[y + 1] = m->row_start[y] + row_runs[y];
  m->x0.reserve(m->row_start[H]);
  m->id.reserve(m->row_start[H]);
  for (int b = 0; b < kBands; ++b) {
    m->x0.insert(m->x0.end(), bx[b].begin(), bx[b].end());
    m->id.insert(m->id.end(), bid[b].begin(), bid[b].end());
  }
  return m;
}

namespace {
// Calls f(x0, x1, id) for row y's runs of one label (x1 inclusive), from `runs` when made of
// `ids`, else by scanning the row.
template <class F>
inline void for_label_runs(const ImageU16& ids, const LabelRuns* runs, int y, const F& f) {
  if (runs) {
    for (int i = runs->row_start[y]; i < runs->row_start[y + 1]; ++i) f(runs->x0[i], runs->end(i, y) - 1, runs->id[i]);
    return;
  }
  const uint16_t* r = ids.row(y);
  const int W = ids.width();
  for (int x = 0; x < W;) {
    const int e = run_end(r, x, W);
    f(x, e - 1, static_cast<int>(r[x]));
    x = e;
  }
}
}  // namespace

std::shared_ptr<const MetricDepthRuns> metric_depth_runs(const LabelMap& lm, const LabelRuns* lruns) {
  const ImageU16& ids = lm.ids;
  const int W = ids.width(), H = ids.height();
  if (lruns && !lruns->made_of(ids)) lruns = nullptr;
  const bool inst = !lm.instances.empty();
  auto m = std::make_shared<MetricDepthRuns>();
  m->labels = LabelsMadeOf(lm);
  uint8_t kinds[kLabelCount];
  for (int i = 0; i < kLabelCount; ++i) kinds[i] = static_cast<uint8_t>(kind_of(i));
  auto kind_fast = [&](int id) { return id < kLabelCount ? kinds[id] : 2; };
  // Components of equal key (class id, or instance code for instance pixels) on object pixels.
  // The key of a pixel: -1 off objects, else its instance code + 1000 where it has one (>= 1000),
  // else its class id. Pieces: runs of one class id, cut where the instance code changes.
  m->rc = run_components(H, [&](int y, auto&& emit) {
    const uint16_t* in = inst ? lm.instances.row(y) : nullptr;
    for_label_runs(ids, lruns, y, [&](int x, int x1, int id) {
      const int e = x1 + 1;
      if (kind_fast(id) != 2) emit(x, x1, -1);
      else if (!in) emit(x, x1, id);
      else
        for (int s = x; s < e;) {
          const int t = run_end(in, s, e), c = in[s];
          emit(s, t - 1, c >= 1000 ? 1000 + c : id);
          s = t;
        }
    });
  });
  const std::vector<KeyedRun>& runs = m->rc.runs;
  const std::vector<int>& comp = m->rc.comp;
  // Components: lowest row, x range; per-column lowest rows for the per-column kind.
  std::vector<MetricDepthRuns::Comp>& comps = m->comps;
  comps.resize(m->rc.count);
  std::vector<uint8_t> seen(m->rc.count, 0);
  for (size_t i = 0; i < runs.size(); ++i) {
    MetricDepthRuns::Comp& c = comps[comp[i]];
    if (!seen[comp[i]]) {  // the component's first run gives its key
      seen[comp[i]] = 1;
      c.single = runs[i].key >= 1000 || single_plane_class(runs[i].key);
    }
    c.ymax = std::max(c.ymax, runs[i].y);
    c.x0 = std::min(c.x0, runs[i].x0);
    c.x1 = std::max(c.x1, runs[i].x1);
  }
  size_t cols = 0;
  for (auto& c : comps)
    if (!c.single) { c.col_off = cols; cols += c.x1 - c.x0 + 1; }
  m->col_ymax.assign(cols, -1);
  lowest_rows(
      runs, W,
      [&](size_t i) { const MetricDepthRuns::Comp& c = comps[comp[i]]; return c.single ? -1L : static_cast<long>(c.col_off); },
      [&](size_t i) { return comps[comp[i]].x0; }, m->col_ymax.data());
  return m;
}

ImageF metric_depth(const LabelMap& lm, const CameraGeometry& g, double max_depth_m, const BuildingFacades* facades) {
  return metric_depth_with(lm, g, max_depth_m, facades, nullptr);
}

ImageF metric_depth_with(const LabelMap& lm, const CameraGeometry& g, double max_depth_m, const BuildingFacades* facades,
                         const MetricDepthRuns* made) {
  const ImageU16& ids = lm.ids;
  const int W = ids.width(), H = ids.height();
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
  uint8_t kinds[kLabelCount];
  for (int i = 0; i < kLabelCount; ++i) kinds[i] = static_cast<uint8_t>(kind_of(i));
  auto kind_fast = [&](int id) { return id < kLabelCount ? kinds[id] : 2; };
  // The label-only part (metric_depth_runs): made beside the Hough stage by night_scene, else
  // here; taken only when made of these labels.
  std::shared_ptr<const MetricDepthRuns> computed_runs;
  if (!(made && made->labels.same_labels(LabelsMadeOf(lm)))) {
    computed_runs = metric_depth_runs(lm);
    made = computed_runs.get();
  }
  using Comp = MetricDepthRuns::Comp;
  const std::vector<KeyedRun>& runs = made->rc.runs;
  const std::vector<int>& row_start = made->rc.row_start;
  const std::vector<int>& comp = made->rc.comp;
  const std::vector<Comp>& comps = made->comps;
  const std::vector<int>& col_ymax = made->col_ymax;
  const size_t cols = col_ymax.size();
  // The ground line of a vertical plane is a straight image line. Columns whose lowest pixel
  // stands on a ground class may show the contact; a straight line fitted to them (least squares,
  // at least 8 columns and a fifth of the region's) gives the hidden columns theirs, so that a
  // façade behind parked cars or hedges stays one plane; it is never taken above the column's own
  // lowest pixel. With fewer such columns the median row of the lowest ones is the contact (a
  // fronto-parallel plane).
  // Overhangs: a tree's crown, an awning, a balcony, a sign board above the pavement end above
  // ground that the photo shows beneath them, a contact they do not have. Taken as contacts they
  // put each such column at the ground's distance there, farther than the object by a different
  // amount per column. So the line is fitted to the contacts at or below it, trimmed in turn: each
  // fit drops the contacts more than overhang_px(row) above it and refits (at most 8 times) until
  // none is dropped. overhang_px is the rows by which a contact may sit above the line before its
  // depth differs from the line's by more than 5 % (z ∝ 1/(v − y_h): δ rows at Δ rows below the
  // horizon change z by about δ/Δ), the accuracy issue 14 §1 asks of objects, and at least one row
  // (the labels' quantisation). Without a line, the contacts within overhang_px of the lowest one
  // give the median. A column that shows a contact keeps it when it lies within overhang_px above
  // its line (or median row); one higher up takes the line's.
  // A region that shows no contact (a tree behind parked cars, a wall behind a hedge) stands
  // behind the objects below it: a column's bottom of the stack of objects below it is the nearest
  // its hidden contact can be, where those objects stand in front of it. Where they stand behind
  // it (the façade seen under a tree's crown) it is no bound at all, and taken column by column
  // those rows jumped between a car's foot and a building's: the light map lit such crowns in
  // vertical stripes. So such a region is one fronto-parallel plane at the median of its lowest
  // stack bottoms (within overhang_px of the lowest: the objects in front of it), every column
  // alike; no line, which the bottoms of a car's front and side would tilt.
  constexpr double kObjectDepthTolerance = 0.05;  // issue 14 §1: objects within 5 %
  auto overhang_px = [&](double row) { return std::max(1.0, kObjectDepthTolerance * (row - g.horizon_y)); };
  std::vector<double> col_D(cols, max_depth_m);
  auto D_at = [&](double row) {  // horizontal distance of the ground at a (fractional) row edge
    double D = 0;
    return g.ground_point(g.cx_px, row, nullptr, &D, nullptr) ? std::min(D, max_depth_m) : max_depth_m;
  };
  auto shows_contact = [&](int x, int y) { return y + 1 < H && kind_fast(ids.at(x, y + 1)) == 0; };
  // The bottom of the stack of objects below (x, y) for every column that shows no contact: the
  // last row of the column's run of object pixels from y + 1 down (y itself when (x, y + 1) is no
  // object). One sweep from the bottom row up over the object runs, end[x] the last row of the
  // object run through (x, r) in column x (-1 off objects), instead of a walk down each column.
  struct StackQuery { size_t col; int x, y; };
  std::vector<StackQuery> stack_q;
  std::vector<int> stack_bottom(cols, -1);
  // (Only the regions that show no contact read their stack bottoms.)
  for (const auto& c : comps) {
    if (c.single) continue;
    bool shown = false;
    for (int x = c.x0; x <= c.x1 && !shown; ++x) {
      const int y = col_ymax[c.col_off + (x - c.x0)];
      shown = y >= 0 && shows_contact(x, y);
    }
    if (shown) continue;
    for (int x = c.x0; x <= c.x1; ++x) {
      const int y = col_ymax[c.col_off + (x - c.x0)];
      if (y >= 0) stack_q.push_back({c.col_off + (x - c.x0), x, y});
    }
  }
  if (!stack_q.empty()) {
    std::stable_sort(stack_q.begin(), stack_q.end(), [](const StackQuery& a, const StackQuery& b) { return a.y > b.y; });
    size_t qi = 0;
    for (; qi < stack_q.size() && stack_q[qi].y + 1 >= H; ++qi) stack_bottom[stack_q[qi].col] = stack_q[qi].y;
    std::vector<int> end(W, -1);
    for (int r = H - 1; r >= 1 && qi < stack_q.size(); --r) {
      int x = 0;
      int* e = end.data();
      for (int i = row_start[r]; i < row_start[r + 1]; ++i) {
        const int x0 = runs[i].x0, x1 = runs[i].x1;  // locals: the stores below cannot change them
        std::fill(e + x, e + x0, -1);
        for (int xx = x0; xx <= x1; ++xx) e[xx] = std::max(e[xx], r);
        x = x1 + 1;
      }
      std::fill(end.begin() + x, end.end(), -1);
      for (; qi < stack_q.size() && stack_q[qi].y + 1 == r; ++qi) {
        const StackQuery& q = stack_q[qi];
        stack_bottom[q.col] = end[q.x] >= 0 ? end[q.x] : q.y;
      }
    }
  }
  std::vector<int> px, py;    // a component's contacts (shown, else its stack bottoms): columns, rows
  std::vector<uint8_t> keep;  // the contacts the current line keeps
  for (const auto& c : comps) {
    if (c.single) continue;
    int ncol = 0;
    px.clear();
    py.clear();
    for (int x = c.x0; x <= c.x1; ++x) {
      const int y = col_ymax[c.col_off + (x - c.x0)];
      if (y < 0) continue;
      ++ncol;
      if (shows_contact(x, y)) px.push_back(x), py.push_back(y);
    }
    const bool shown = !px.empty();
    if (!shown)
      for (int x = c.x0; x <= c.x1; ++x)
        if (col_ymax[c.col_off + (x - c.x0)] >= 0) px.push_back(x), py.push_back(stack_bottom[c.col_off + (x - c.x0)]);
    const int m = static_cast<int>(px.size());
    keep.assign(m, 1);
    bool line = false;
    double a = 0, b = 0;
    for (int it = 0; it < 8 && shown; ++it) {
      double sx = 0, sy = 0, sxx = 0, sxy = 0;
      int n = 0;
      for (int i = 0; i < m; ++i)
        if (keep[i]) sx += px[i], sy += py[i], sxx += double(px[i]) * px[i], sxy += double(px[i]) * py[i], ++n;
      const double det = n * sxx - sx * sx;
      line = n >= 8 && 5 * n >= ncol && det > 0;
      if (!line) break;
      b = (n * sxy - sx * sy) / det, a = (sy - b * sx) / n;
      bool dropped = false;
      for (int i = 0; i < m; ++i) {
        const double at = a + b * px[i];
        if (keep[i] && py[i] < at - overhang_px(at)) keep[i] = 0, dropped = true;
      }
      if (!dropped) break;
    }
    double med = -1;
    if (!line && m > 0) {
      const int lowest = *std::max_element(py.begin(), py.end());
      std::vector<int> rows;
      for (int i = 0; i < m; ++i)
        if (py[i] >= lowest - overhang_px(lowest)) rows.push_back(py[i]);
      std::nth_element(rows.begin(), rows.begin() + rows.size() / 2, rows.end());
      med = rows[rows.size() / 2];
    }
    for (int x = c.x0; x <= c.x1; ++x) {
      const int y = col_ymax[c.col_off + (x - c.x0)];
      if (y < 0) continue;
      const double ref = line ? a + b * x : med;
      // (m > 0 here: every column of the component is a contact or a stack bottom, so ref is set.)
      const double yc = shown && shows_contact(x, y) && y >= ref - overhang_px(ref) ? y : std::max<double>(y, ref);
      col_D[c.col_off + (x - c.x0)] = D_at(yc + 0.5);
    }
  }
  // Buildings: the fitted façade plane of their column (building_facades), where the column's
  // pixels lie above its foot line; elsewhere the per-column plane below.
  const BuildingFacades computed = facades ? BuildingFacades() : building_facades(ids, g, max_depth_m);
  const BuildingFacades& fac = facades ? *facades : computed;
  // z = d / (n_X·x_n + n_D·k), x_n = (u − c_x)/f per column, k = cos θ − y_n·sin θ per row
  // (facade_depth_m, unrolled).
  std::vector<double> xn(W);
  for (int x = 0; x < W; ++x) xn[x] = (x - g.cx_px) / g.f_px;
  // Per region, the end (a column offset from its x0) of each column's span of equal façade plane
  // and on-plane flag: the row pass below takes spans whole instead of comparing column by column.
  std::vector<std::vector<int>> plane_span_end(fac.regions.size());
  for (size_t r = 0; r < fac.regions.size(); ++r) {
    const BuildingFacades::Region& R = fac.regions[r];
    const int w = static_cast<int>(R.column_plane.size());
    std::vector<int>& e = plane_span_end[r];
    e.resize(w);
    for (int i = w - 1; i >= 0; --i)
      e[i] = i + 1 < w && R.column_plane[i + 1] == R.column_plane[i] && (R.on_plane[i + 1] != 0) == (R.on_plane[i] != 0)
                 ? e[i + 1]
                 : i + 1;
  }
  const double cp = std::cos(g.pitch_rad), sp = std::sin(g.pitch_rad);
  // One pass per row: ground and sky per pixel between the object runs, each object run from its
  // component's plane, and on building pixels (all inside object runs: the building class is an
  // object) the façade plane over that.
#pragma omp parallel for schedule(static)
  for (int y = 0; y < H; ++y) {
    float* o = depth.row(y);
    const uint16_t* r = ids.row(y);
    const int32_t* reg = fac.region.row(y);
    const float zgy = zg[y];
    const double k = cp - (y - g.cy_px) / g.f_px * sp;
    int x = 0;
    for (int i = row_start[y];; ++i) {
      const int gap_end = i < row_start[y + 1] ? runs[i].x0 : W;
      while (x < gap_end) {  // per run of one label: sky or ground (no objects between the runs)
        const int e = run_end(r, x, gap_end);
        std::fill(o + x, o + e, kind_fast(r[x]) == 1 ? kDepthInfinity_m : zgy);
        x = e;
      }
      if (i == row_start[y + 1]) break;
      const KeyedRun& u = runs[i];
      const Comp& c = comps[comp[i]];
      if (c.single) {
        const float z = static_cast<float>(std::min(plane[y] * d_edge[c.ymax], max_depth_m));
        std::fill(o + u.x0, o + u.x1 + 1, z);
      } else {
        const double py = plane[y];
        const double* cd = col_D.data() + c.col_off;
        const int cx0 = c.x0, x1 = u.x1;  // locals: the stores below cannot change them
        plane_fill(o + u.x0, cd + (u.x0 - cx0), x1 + 1 - u.x0, py, max_depth_m);
      }
      // Per span of one region and, within it, of one façade plane (and on-plane flag).
      for (int xx = u.x0, x1 = u.x1; xx <= x1;) {
        const int rr = reg[xx];
        const int xe = run_end(reg, xx, x1 + 1);
        if (rr < 0) {
          xx = xe;
          continue;
        }
        const BuildingFacades::Region& R = fac.regions[rr];
        const int* cplane = R.column_plane.data();
        const uint8_t* on = R.on_plane.data();
        const int* same_end = plane_span_end[rr].data();
        const int rx0 = R.x0;
        for (int a = xx; a < xe;) {
          const int pi = cplane[a - rx0];
          const bool on_a = on[a - rx0] != 0;
          const int b = std::min(xe, rx0 + same_end[a - rx0]);
          if (pi >= 0 && on_a && fac.planes[pi].fitted) {
            const FacadePlane& f = fac.planes[pi];
            facade_span(o, xn.data(), a, b, f.nX, f.nD, k, f.d_m, max_depth_m);
          }
          a = b;
        }
        xx = xe;
      }
      x = u.x1 + 1;
    }
  }
  return depth;
}

}  // namespace photosite::scene

// ---- building façades ---------------------------------------------------------------------

namespace photosite::scene {

const FacadePlane* BuildingFacades::plane_at(int x, int y, bool* on_plane) const {
  const int r = region.at(x, y);
  if (r < 0) return nullptr;
  const int i = plane_of_region(r, x);
  if (on_plane) *on_plane = regions[r].on_plane[x - regions[r].x0] != 0;
  return i >= 0 ? &planes[i] : nullptr;
}

double facade_depth_m(const CameraGeometry& g, const FacadePlane& f, double u, double v) {
  // The ray of pixel (u, v) per unit camera z: X = x_n, D = cos θ − y_n·sin θ.
  const double xn = (u - g.cx_px) / g.f_px, yn = (v - g.cy_px) / g.f_px;
  const double den = f.nX * xn + f.nD * (std::cos(g.pitch_rad) - yn * std::sin(g.pitch_rad));
  return den > 1e-9 ? f.d_m / den : INFINITY;
}

namespace {
struct Contact { int x; double v; };
struct Line { double a = 0, b = 0; int n = 0; };
// Least squares v = a + b·u over the contacts flagged in `use`.
bool least_squares(const std::vector<Contact>& c, const std::vector<uint8_t>& use, Line* L) {
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  int n = 0;
  for (size_t i = 0; i < c.size(); ++i)
    if (use[i]) { sx += c[i].x; sy += c[i].v; sxx += double(c[i].x) * c[i].x; sxy += c[i].x * c[i].v; ++n; }
  const double det = n * sxx - sx * sx;
  if (n < 2 || det <= 0) return false;
  L->b = (n * sxy - sx * sy) / det;
  L->a = (sy - L->b * sx) / n;
  return true;
}
int mark_inliers(const std::vector<Contact>& c, const std::vector<uint8_t>& free, const Line& L, std::vector<uint8_t>* in) {
  int n = 0;
  for (size_t i = 0; i < c.size(); ++i) {
    (*in)[i] = free[i] && std::fabs(c[i].v - (L.a + L.b * c[i].x)) <= kFacadeInlier_px;
    n += (*in)[i];
  }
  return n;
}
// RANSAC over deterministic pairs of the free contacts (ordered by column): pairs at gaps of 1/2,
// 1/4, 1/8, 1/16 of their count, 16 starts each; then least squares on the inliers, twice.
bool fit_line(const std::vector<Contact>& c, const std::vector<uint8_t>& free, Line* best, std::vector<uint8_t>* in) {
  std::vector<int> idx;
  for (size_t i = 0; i < c.size(); ++i)
    if (free[i]) idx.push_back(static_cast<int>(i));
  const int n = static_cast<int>(idx.size());
  if (n < kMinFacadeContacts) return false;
  std::vector<uint8_t> tmp(c.size());
  best->n = 0;
  for (int gdiv : {2, 4, 8, 16}) {
    const int gap = std::max(3, n / gdiv);
    if (gap >= n) continue;
    for (int k = 0; k < 16; ++k) {
      const int i = static_cast<int>(static_cast<int64_t>(k) * (n - 1 - gap) / 15);
      const Contact &p = c[idx[i]], &q = c[idx[i + gap]];
      if (q.x == p.x) continue;
      Line L;
      L.b = (q.v - p.v) / (q.x - p.x);
      L.a = p.v - L.b * p.x;
      L.n = mark_inliers(c, free, L, &tmp);
      if (L.n > best->n) *best = L;
    }
  }
  if (best->n < kMinFacadeContacts) return false;
  for (int it = 0; it < 2; ++it) {
    mark_inliers(c, free, *best, in);
    Line L = *best;
    if (!least_squares(c, *in, &L)) break;
    L.n = mark_inliers(c, free, L, &tmp);
    if (L.n < best->n) break;  // keep the better of the two
    *best = L;
  }
  best->n = mark_inliers(c, free, *best, in);
  return best->n >= kMinFacadeContacts;
}
}  // namespace

// building_facades' part that reads only the labels (scene/night_detail.h): the building
// regions (their label runs and components) and their columns' lowest rows.
struct BuildingRegions {
  LabelsMadeOf labels;  // the labels it was made of (building_facades_with takes it for those only)
  RunComponents rc;                              // the building class's runs and their regions
  std::vector<BuildingFacades::Region> regions;  // x0 and the per-column vectors sized (-1, 0)
  std::vector<long> col_off;                     // region r's columns at ymax_all[col_off[r]...]
  std::vector<int> ymax_all;                     // each column's lowest row of its region
};

std::shared_ptr<BuildingRegions> building_regions(const ImageU16& ids, const LabelRuns* lruns) {
  const int W = ids.width(), H = ids.height();
  if (lruns && !lruns->made_of(ids)) lruns = nullptr;
  const uint16_t building = static_cast<uint16_t>(Label::Building);
  auto m = std::make_shared<BuildingRegions>();
  m->labels = LabelsMadeOf(ids);
  // 4-connected regions of building pixels, numbered in reading order, with their column extent.
  m->rc = run_components(H, [&](int y, auto&& emit) {
    for_label_runs(ids, lruns, y, [&](int x, int x1, int id) { emit(x, x1, id == building ? 0 : -1); });
  });
  const RunComponents& rc = m->rc;
  const std::vector<KeyedRun>& runs = rc.runs;
  const std::vector<int>& run_region = rc.comp;
  std::vector<BuildingFacades::Region>& regions = m->regions;
  regions.resize(rc.count);
  std::vector<int> x1s(rc.count, -1);
  for (auto& r : regions) r.x0 = 1 << 30;
  for (size_t i = 0; i < runs.size(); ++i) {
    const int r = run_region[i];
    regions[r].x0 = std::min(regions[r].x0, runs[i].x0);
    x1s[r] = std::max(x1s[r], runs[i].x1);
  }
  // Per region, its columns' lowest rows, one block of them for all regions (col_off[r] onwards).
  std::vector<long>& col_off = m->col_off;
  col_off.assign(regions.size() + 1, 0);
  for (size_t r = 0; r < regions.size(); ++r) {
    const int w = x1s[r] - regions[r].x0 + 1;
    regions[r].column_plane.assign(w, -1);
    regions[r].on_plane.assign(w, 0);
    col_off[r + 1] = col_off[r] + w;
  }
  m->ymax_all.assign(col_off.back(), -1);
  lowest_rows(
      runs, W, [&](size_t i) { return col_off[run_region[i]]; },
      [&](size_t i) { return regions[run_region[i]].x0; }, m->ymax_all.data());
  return m;
}

BuildingFacades building_facades(const ImageU16& ids, const CameraGeometry& g, double max_depth_m) {
  return building_facades_with(ids, g, max_depth_m, nullptr);
}

BuildingFacades building_facades_with(const ImageU16& ids, const CameraGeometry& g, double max_depth_m,
                                      BuildingRegions* made) {
  const int W = ids.width(), H = ids.height();
  // The labels-only part: made beside the Hough stage by night_scene, else here; taken (its
  // regions moved out) only when made of these labels.
  std::shared_ptr<BuildingRegions> computed;
  if (!(made && made->labels.same_labels(LabelsMadeOf(ids)))) {
    computed = building_regions(ids);
    made = computed.get();
  }
  BuildingFacades out;
  out.regions = std::move(made->regions);
  made->labels = LabelsMadeOf();  // taken: a second call makes its own
  const std::vector<long>& col_off = made->col_off;
  const std::vector<int>& ymax_all = made->ymax_all;
  const std::vector<KeyedRun>& runs = made->rc.runs;
  const std::vector<int>& row_start = made->rc.row_start;
  const std::vector<int>& run_region = made->rc.comp;
  // The region of every pixel (-1 off the building class), one pass per row.
  out.region = ImageI32(W, H, 1, uninitialized, "region");
#pragma omp parallel for schedule(static)
  for (int y = 0; y < H; ++y) {
    int32_t* o = out.region.row(y);
    int x = 0;
    for (int i = row_start[y]; i < row_start[y + 1]; ++i) {
      std::fill(o + x, o + runs[i].x0, -1);
      std::fill(o + runs[i].x0, o + runs[i].x1 + 1, run_region[i]);
      x = runs[i].x1 + 1;
    }
    std::fill(o + x, o + W, -1);
  }
  auto object = [&](int id) {  // neither ground nor sky: something standing in front
    return !is_ground(id) && id != static_cast<int>(Label::Sky) && !is_not_scene(id);
  };
  for (size_t r = 0; r < out.regions.size(); ++r) {
    auto& R = out.regions[r];
    const int* ym = ymax_all.data() + col_off[r];
    const int w = static_cast<int>(col_off[r + 1] - col_off[r]);
    std::vector<Contact> cs;
    for (int i = 0; i < w; ++i) {
      const int x = R.x0 + i, y = ym[i];
      if (y < 0 || y + 1 >= H || !is_ground(ids.at(x, y + 1)) || y + 0.5 < g.horizon_y + 1) continue;
      cs.push_back({x, y + 0.5});
    }
    R.contacts = static_cast<int>(cs.size());
    std::vector<int> plane_of;
    // Sequential RANSAC: up to kMaxFacadePlanes lines, each on the contacts the earlier ones left.
    auto fit_planes = [&](const std::vector<Contact>& pts, bool occluded) {
      std::vector<uint8_t> free(pts.size(), 1), in(pts.size());
      plane_of.assign(pts.size(), -1);
      const int first_plane = static_cast<int>(out.planes.size());
      const int min_left = std::max(kMinFacadeContacts, static_cast<int>(0.15 * pts.size()));
      int found = 0;
      // On stack feet, one plane: lines of lower bounds (a sign post here, a hedge there) do not
      // tell a façade's corner from the things in front of it.
      for (int k = 0; k < (occluded ? 1 : kMaxFacadePlanes); ++k) {
        int left = 0;
        for (auto f : free) left += f;
        if (left < (k == 0 ? kMinFacadeContacts : min_left)) break;
        Line L;
        if (!fit_line(pts, free, &L, &in) || (k > 0 && L.n < min_left)) break;
        // A later line within 3 bands (mean over its inliers) of an earlier façade's foot line is
        // that façade's noisier contacts (label noise grows with distance), not a new façade: its
        // inliers join the earlier plane, and the search goes on.
        {
          int same = -1;
          for (int q = first_plane; q < static_cast<int>(out.planes.size()) && same < 0; ++q) {
            double sum = 0;
            for (size_t i = 0; i < pts.size(); ++i)
              if (in[i]) sum += std::fabs((L.a + L.b * pts[i].x) - (out.planes[q].line_a + out.planes[q].line_b * pts[i].x));
            if (sum / L.n < 3 * kFacadeInlier_px) same = q;
          }
          if (same >= 0) {
            for (size_t i = 0; i < pts.size(); ++i)
              if (in[i]) { plane_of[i] = same; free[i] = 0; }
            continue;
          }
        }
        int i0 = -1, i1 = -1;
        for (size_t i = 0; i < pts.size(); ++i)
          if (in[i]) { if (i0 < 0) i0 = static_cast<int>(i); i1 = static_cast<int>(i); }
        const double u0 = pts[i0].x, u1 = pts[i1].x;
        double X0, D0, X1, D1;
        if (u1 <= u0 || !g.ground_point(u0, L.a + L.b * u0, &X0, &D0, nullptr) ||
            !g.ground_point(u1, L.a + L.b * u1, &X1, &D1, nullptr) || D0 > max_depth_m || D1 > max_depth_m)
          break;
        const double tx = X1 - X0, td = D1 - D0, len = std::hypot(tx, td);
        if (len < 1e-6) break;
        FacadePlane f;
        f.nX = -td / len;
        f.nD = tx / len;
        f.d_m = f.nX * X0 + f.nD * D0;
        if (f.d_m < 0) { f.nX = -f.nX; f.nD = -f.nD; f.d_m = -f.d_m; }
        if (f.d_m < 0.5) break;  // a plane through the camera's foot, seen edge-on
        f.line_a = L.a;
        f.line_b = L.b;
        f.inliers = L.n;
        f.fitted = true;
        f.occluded = occluded;
        const int idx = static_cast<int>(out.planes.size());
        out.planes.push_back(f);
        ++found;
        for (size_t i = 0; i < pts.size(); ++i)
          if (in[i]) { plane_of[i] = idx; free[i] = 0; }
      }
      return found;
    };
    if (!fit_planes(cs, false)) {
      // No façade on unoccluded contacts: the feet of what stands in front (the bottom of the
      // stack of objects below each column's lowest building pixel), the nearest the hidden foot
      // can be. First only stacks of fixed structures (fences, walls, hedges, poles: they stand
      // at the property line, close before the façade), then also through vehicles and people
      // (parked at the kerb, metres before it: a looser bound).
      for (bool movable : {false, true}) {
        cs.clear();
        for (int i = 0; i < w; ++i) {
          int y = ym[i];
          if (y < 0) continue;
          const int x = R.x0 + i;
          bool through_movable = false;
          while (y + 1 < H && object(ids.at(x, y + 1))) {
            const int id = ids.at(x, y + 1);
            through_movable = through_movable || is_vehicle(id) || id == static_cast<int>(Label::Person) ||
                              id == static_cast<int>(Label::Rider);
            ++y;
          }
          if ((!through_movable || movable) && y + 1 < H && is_ground(ids.at(x, y + 1)) && y + 0.5 >= g.horizon_y + 1)
            cs.push_back({x, y + 0.5});
        }
        if (fit_planes(cs, true)) break;
      }
    }
    // Columns: the façade of the nearest inlier contact (left one on a tie).
    std::vector<int> col_plane(w, -1);
    std::vector<int> inlier_x;
    std::vector<int> inlier_p;
    for (size_t i = 0; i < cs.size(); ++i)
      if (plane_of[i] >= 0) { inlier_x.push_back(cs[i].x); inlier_p.push_back(plane_of[i]); }
    const bool stack = !inlier_x.empty() && out.planes[inlier_p[0]].occluded;
    if (!inlier_x.empty()) {
      size_t j = 0;
      for (int i = 0; i < w; ++i) {
        if (ym[i] < 0) continue;
        const int x = R.x0 + i;
        while (j + 1 < inlier_x.size() && inlier_x[j + 1] <= x) ++j;
        size_t k = j;
        if (j + 1 < inlier_x.size() && std::abs(inlier_x[j + 1] - x) < std::abs(inlier_x[j] - x)) k = j + 1;
        const int p = inlier_p[k];
        R.column_plane[i] = p;
        const FacadePlane& f = out.planes[p];
        const double foot = f.line_a + f.line_b * x;
        // On a plane fitted to the stacks' feet, the building's own pixels stand above the foot
        // line by construction (the objects in between).
        R.on_plane[i] = foot > g.horizon_y + 0.5 && (stack || ym[i] + 0.5 <= foot + kFacadeInlier_px);
      }
    } else {
      // No façade fitted: an unfitted plane for the window layout, from the median ground point of
      // the columns' bottoms (below a hidden foot: the bottom of the stack of objects in front).
      std::vector<double> xs, ds;
      for (int i = 0; i < w; ++i) {
        int y = ym[i];
        if (y < 0) continue;
        const int x = R.x0 + i;
        while (y + 1 < H && object(ids.at(x, y + 1))) ++y;
        double X, D;
        if (g.ground_point(x, y + 0.5, &X, &D, nullptr)) { xs.push_back(X); ds.push_back(std::min(D, max_depth_m)); }
      }
      FacadePlane f;
      if (!xs.empty()) {
        std::nth_element(xs.begin(), xs.begin() + xs.size() / 2, xs.end());
        std::nth_element(ds.begin(), ds.begin() + ds.size() / 2, ds.end());
        const double Xm = xs[xs.size() / 2];
        if (std::fabs(Xm) > 3) { f.nX = Xm > 0 ? 1 : -1; f.nD = 0; f.d_m = std::fabs(Xm); }
        else { f.nX = 0; f.nD = 1; f.d_m = ds[ds.size() / 2]; }
      }
      const int idx = static_cast<int>(out.planes.size());
      out.planes.push_back(f);
      for (int i = 0; i < w; ++i)
        if (ym[i] >= 0) R.column_plane[i] = idx;
    }
  }
  return out;
}

}  // namespace photosite::scene
