// The day photo's windows found on each façade plane (find_facade_windows, scene/street_detail.h).
//
// Why. add_facade_windows lays a grid of storeys and bays on each façade (the preset's storey_m
// and pitch_m, from the ground and from the plane's origin): a rule of thumb whose lit panes fall
// on wall as often as on the photo's windows, and which lights windows on a blank wall. Where the
// photo resolves the façade, it shows where its windows are.
//
// How. Each fitted façade plane's pixels (building pixels whose column takes the plane and whose
// depth is the plane's) are mapped to the plane's own coordinates, s along it and Y up it (the
// grid's coordinates: scene/street.cpp, WindowGeom), and their day luminance averaged in cells of
// kCell_m x kCell_m: the façade rectified, its windows axis-aligned rectangles at their true size.
// Where the façade recedes, one pixel spans several cells along s: a gap of up to kMaxGap_m
// between cells holding samples is filled by linear interpolation along s. A column of cells is
// resolved when at least half of its filled cells hold samples of their own; the far, stretched
// part of a grazing façade is not, and keeps the grid there; so does each 8 m stretch of façade on
// which fewer than a quarter of the grid's windows are found (its glass no darker than its wall, or
// a blank wall).
// A window in daylight is a recess of dark glass: darker than its wall. Each cell's darkness is
// (t − m)/t, m its mean and t the mean of the filled cells within kTrend_m x kTrend_m around it
// (a façade's storeys and materials differ in brightness: a window is a local dip). Cells darker
// than the preset's windows.detect_contrast are joined 4-connected; a component is a window when
// its box is kMinWidth_m–kMaxWidth_m wide and kMinHeight_m–kMaxHeight_m tall with at least
// kMinFill of the box dark (cornice shadows, plinths and dark wall are too long, too low or too
// sparse), in resolved columns. Its cells are its glass; each window's lit draw is keyed, like the
// grid's, by the plane's key and its centre in 0.5 m steps of s and Y (world coordinates).
// Not found: windows brighter than their wall (sky reflected in the glass, white blinds), and
// windows whose dark part is split by bars or mullions into parts smaller than the minima.
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <omp.h>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <utility>
#include <vector>

#include "scene/runs_detail.h"
#include "scene/street_detail.h"

namespace photosite::scene {

namespace {
constexpr double kCell_m = FacadeWindowsFound::kCell_m;  // rectified cells (a window spans ≥ 3 of them)
constexpr double kMaxGap_m = 1.0;                         // gaps along s filled by interpolation (photosite choice)
constexpr double kTrend_m = 3.1;                          // the wall's local mean: about one bay by one storey [U]
constexpr double kMinWidth_m = 0.3, kMaxWidth_m = 3.5;    // window openings: narrow sashes to shop bays [U]
constexpr double kMinHeight_m = 0.5, kMaxHeight_m = 4.5;  // basement lights to arched ground-floor windows [U]
constexpr double kStretch_m = 8;                          // stretches of façade judged alone (about a building's width; photosite choice)
constexpr double kMinFill = 0.5;                          // dark share of the box (photosite choice)
constexpr double kMaxAspect = 3.5;                        // box height to width and width to height at most [U]
constexpr int kRowStep = 3;                               // sampled rows (every column)
constexpr double kMaxFootprint_m = 2 * kCell_m;           // a pixel's extent along the façade at most
constexpr int kMaxCells = 4'000'000;                      // a plane's rectified grid at most (400 m x 100 m)

struct Sample {
  float s, Y, v;  // (float: 0.1 m cells within 200 m of the camera need 2⁻¹¹ relative at most)
};

// The first column from x (below limit) of a building region (reg[x] ≥ 0), or limit. Off the
// building class the region is −1: with SSE2 (every x86-64) eight columns at a time by their sign
// bits (most of a row), asking as it goes for the same columns of `next`, the row read after
// this one (see the sampling loop); elsewhere one at a time.
inline int next_building_column(const int32_t* reg, int x, int limit, const int32_t* next) {
#if defined(__SSE2__)
  for (; x + 8 <= limit; x += 8) {
    __builtin_prefetch(next + x);
    const __m128i a = _mm_loadu_si128(reinterpret_cast<const __m128i*>(reg + x));
    const __m128i b = _mm_loadu_si128(reinterpret_cast<const __m128i*>(reg + x + 4));
    if (_mm_movemask_ps(_mm_castsi128_ps(_mm_and_si128(a, b))) == 0xf) continue;  // all eight negative
    const unsigned neg = static_cast<unsigned>(_mm_movemask_ps(_mm_castsi128_ps(a))) |
                         static_cast<unsigned>(_mm_movemask_ps(_mm_castsi128_ps(b))) << 4;
    return x + std::countr_zero(~neg);  // the lowest lane whose sign bit is clear
  }
#endif
  while (x < limit && reg[x] < 0) ++x;
  return x;
}

// Samples' bounds: their least and greatest s and Y (floats, so exact: a minimum of minima is the
// minimum, and a NaN sample is passed over either way).
struct Bounds {
  float s_lo = INFINITY, s_hi = -INFINITY, y_lo = INFINITY, y_hi = -INFINITY;
  void add(const Bounds& b) {
    s_lo = std::min(s_lo, b.s_lo), s_hi = std::max(s_hi, b.s_hi);
    y_lo = std::min(y_lo, b.y_lo), y_hi = std::max(y_hi, b.y_hi);
  }
};
}  // namespace

std::vector<CellComponent> cell_components(const uint8_t* mask, int w, int h) {
  // The 4-connected components by runs (mask_runs: each component's root its first run in raster
  // order).
  const std::vector<MaskRun> runs = mask_runs(mask, w, h, false);
  // Each root's component numbered in root order (the raster order of first cells).
  std::vector<int> number(runs.size(), -1);
  std::vector<CellComponent> out;
  std::vector<int> right, bottom;
  for (size_t r = 0; r < runs.size(); ++r) {
    const MaskRun& q = runs[r];
    const int root = q.root;
    if (number[root] < 0) {
      number[root] = static_cast<int>(out.size());
      out.push_back({q.x0, q.y, 0, 0, 0});
      right.push_back(q.x1);
      bottom.push_back(q.y);
    }
    const int c = number[root];
    CellComponent& o = out[c];
    o.left = std::min(o.left, q.x0);
    right[c] = std::max(right[c], q.x1);
    bottom[c] = std::max(bottom[c], q.y);
    o.area += q.x1 - q.x0;
  }
  for (size_t c = 0; c < out.size(); ++c) {
    out[c].width = right[c] - out[c].left;
    out[c].height = bottom[c] - out[c].top + 1;
  }
  return out;
}

FacadeWindowsFound find_facade_windows(const ImageF& texture, const ImageF& depth_m, const CameraGeometry& g,
                                       const BuildingFacades& fac, const ScenePreset& p, const double* tX,
                                       const double* tD, double zmax) {
  FacadeWindowsFound out;
  const int nplanes = static_cast<int>(fac.planes.size());
  out.planes.resize(nplanes);
  const double tau = p.window_detect_contrast;
  if (nplanes == 0 || texture.empty() || !(tau > 0)) return out;
  const int W = texture.width(), H = texture.height();
  const double c = std::cos(g.pitch_rad), sn = std::sin(g.pitch_rad), h = g.mount_height_m;
  // The samples per plane in row order: the sampled rows in chunks of kChunkRows, taken by the
  // threads as they come (building rows cluster in the upper half of a frame: contiguous halves
  // left one thread most of the work), each chunk's samples appended to its thread's lists and
  // their range recorded, then read chunk by chunk (for_samples): the same order at any thread
  // count. Each chunk's bounds per plane are taken from its samples while they are in cache (kept
  // per sample, in memory, they were a sixth of this loop; taken per plane afterwards, from
  // memory, an eighth of the plane's work, on the plane's one thread).
  constexpr int kChunkRows = 4;
  const int nrows = (H + kRowStep - 1) / kRowStep, nchunks = (nrows + kChunkRows - 1) / kChunkRows;
  std::vector<std::vector<std::vector<Sample>>> per_thread;
  std::vector<int> chunk_thread(nchunks);
  std::vector<uint32_t> chunk_begin(static_cast<size_t>(nchunks) * nplanes), chunk_end(chunk_begin.size());
  std::vector<Bounds> chunk_bounds(chunk_begin.size());
  // Per plane: the footprint limit kMaxFootprint_m·d·f (the test below, z²·k_D against it).
  std::vector<double> foot(nplanes);
  for (int k = 0; k < nplanes; ++k) foot[k] = kMaxFootprint_m * fac.planes[k].d_m * g.f_px;
  // Per region, its columns' planes where a column is on its plane and the plane fitted, else −1
  // (the three tests per pixel before, made once per column).
  std::vector<std::vector<int>> sampled_plane(fac.regions.size());
  for (size_t r = 0; r < fac.regions.size(); ++r) {
    const BuildingFacades::Region& R = fac.regions[r];
    std::vector<int>& sp = sampled_plane[r];
    sp.resize(R.column_plane.size());
    for (size_t i = 0; i < sp.size(); ++i) {
      const int pi = R.column_plane[i];
      sp[i] = pi >= 0 && R.on_plane[i] && fac.planes[pi].fitted ? pi : -1;
    }
  }
#pragma omp parallel
  {
#pragma omp single
    {
      per_thread.resize(omp_get_num_threads());
    }
    const int me = omp_get_thread_num();
    std::vector<std::vector<Sample>>& mine = per_thread[me];
    mine.resize(nplanes);
#pragma omp for schedule(dynamic)
    for (int ci = 0; ci < nchunks; ++ci) {
      chunk_thread[ci] = me;
      uint32_t* const begin = chunk_begin.data() + static_cast<size_t>(ci) * nplanes;
      for (int k = 0; k < nplanes; ++k) begin[k] = static_cast<uint32_t>(mine[k].size());
      for (int y = ci * kChunkRows * kRowStep; y < std::min(H, (ci + 1) * kChunkRows * kRowStep); y += kRowStep) {
        const int32_t* reg = fac.region.row(y);
        const float* z = depth_m.row(y);
        const float* t = texture.row(y);
        const double yn = (y - g.cy_px) / g.f_px, kD = c - yn * sn, kY = yn * c + sn;
        // The next sampled row's lines asked for (__builtin_prefetch) while this one is read: the
        // sampled rows lie three rows apart, so each started cold, its reads waiting for memory (a
        // sixth of this loop's profile on the region's load at the head of the column loop, a
        // twelfth on the texture's). Its regions at every column; its depth and texture at this
        // row's sampled columns (a façade's columns change little over three rows). Asked for all
        // at once at a row's start, its regions' 128 lines stalled the loop instead (probably the
        // prefetches waiting for free miss buffers): docs/benchmarks.md, "The photo's windows,
        // twenty-fourth session".
        const int y_next = std::min(H - 1, y + kRowStep);
        const int32_t* reg_next = fac.region.row(y_next);
        const float* z_next = depth_m.row(y_next);
        const float* t_next = texture.row(y_next);
        // Each run of one building region (the columns off the building class, most of a row,
        // skipped by next_building_column), its columns' planes read from the region once.
        for (int x = next_building_column(reg, 0, W, reg_next); x < W; x = next_building_column(reg, x, W, reg_next)) {
          const int r = reg[x];
          const int e = run_end(reg, x, W);
          for (int b = x; b < e; b += 16) __builtin_prefetch(reg_next + b);
          const int* sp = sampled_plane[r].data() - fac.regions[r].x0;
          for (; x < e; ++x) {
            const int pi = sp[x];
            if (pi < 0) continue;
            __builtin_prefetch(t_next + 3 * x);
            __builtin_prefetch(z_next + x);
            const double zz = z[x];
            if (!(zz > 0) || zz > zmax) continue;
            // A pixel spans z²·k_D/(d·f) along the plane (s = z·(t·r), z = d/(n·r) for the ray r =
            // (x_n, k_D) per unit z, t ⊥ n: ds/dx = d·k_D/(f·(n·r)²)); beyond kMaxFootprint_m the
            // receding façade is too compressed to show its windows.
            if (zz * zz * kD > foot[pi]) continue;
            const double X = zz * (x - g.cx_px) / g.f_px, D = zz * kD, Y = h - zz * kY;
            if (Y < 0) continue;
            const Sample q{static_cast<float>(tX[pi] * X + tD[pi] * D), static_cast<float>(Y),
                           t[3 * x] + t[3 * x + 1] + t[3 * x + 2]};
            mine[pi].push_back(q);
          }
        }
      }
      uint32_t* const end = chunk_end.data() + static_cast<size_t>(ci) * nplanes;
      Bounds* const bounds = chunk_bounds.data() + static_cast<size_t>(ci) * nplanes;
      for (int k = 0; k < nplanes; ++k) {
        end[k] = static_cast<uint32_t>(mine[k].size());
        Bounds& b = bounds[k];
        for (uint32_t i = begin[k]; i < end[k]; ++i) {
          const Sample& q = mine[k][i];
          b.s_lo = std::min(b.s_lo, q.s), b.s_hi = std::max(b.s_hi, q.s);
          b.y_lo = std::min(b.y_lo, q.Y), b.y_hi = std::max(b.y_hi, q.Y);
        }
      }
    }
  }
  // Plane k's samples in row order.
  auto for_samples = [&](int k, auto&& f) {
    for (int ci = 0; ci < nchunks; ++ci) {
      const std::vector<Sample>& v = per_thread[chunk_thread[ci]][k];
      const size_t i = static_cast<size_t>(ci) * nplanes + k;
      for (uint32_t q = chunk_begin[i]; q < chunk_end[i]; ++q) f(v[q]);
    }
  };
  const int gap = static_cast<int>(std::lround(kMaxGap_m / kCell_m));
  const int half = static_cast<int>(std::lround(0.5 * kTrend_m / kCell_m));
  std::vector<std::vector<FacadeWindowsFound::Window>> found(nplanes);
  // The planes with samples enough, the most samples first (a plane's work grows with its samples
  // and its cells: taken by the threads as they come, the largest first leaves the least idle
  // at the end); each plane's results are its own, so the order changes no bit.
  std::vector<std::pair<size_t, int>> order;
  for (int k = 0; k < nplanes; ++k) {
    size_t count = 0;
    for (size_t th = 0; th < per_thread.size(); ++th) count += per_thread[th][k].size();
    out.planes[k].samples = static_cast<int>(count);
    if (count >= 100) order.push_back({count, k});
  }
  std::sort(order.begin(), order.end(), [](const auto& a, const auto& b) {
    return a.first != b.first ? a.first > b.first : a.second < b.second;
  });
#pragma omp parallel for schedule(dynamic)
  for (size_t o = 0; o < order.size(); ++o) {
    const int k = order[o].second;
    // The samples' bounds, its chunks' (converted to double, the bounds of the samples as doubles).
    Bounds b;
    for (int ci = 0; ci < nchunks; ++ci) b.add(chunk_bounds[static_cast<size_t>(ci) * nplanes + k]);
    const double s_lo = b.s_lo, s_hi = b.s_hi, y_lo = b.y_lo, y_hi = b.y_hi;
    const int ns = static_cast<int>((s_hi - s_lo) / kCell_m) + 1, ny = static_cast<int>((y_hi - y_lo) / kCell_m) + 1;
    if (static_cast<double>(ns) * ny > kMaxCells) continue;
    // The cells' means (the rectified façade).
    // Consecutive samples mostly fall in one cell (a near pixel is smaller than a cell): a cell's
    // sum and count are carried in registers while its samples last, then stored (each cell's
    // additions in the samples' order as before, so the same floats; added in memory, each
    // sample waited for the previous one's store).
    cv::Mat sum(ny, ns, CV_32F, cv::Scalar(0)), cnt(ny, ns, CV_32F, cv::Scalar(0));
    float* const S0 = sum.ptr<float>(0);
    float* const N0 = cnt.ptr<float>(0);
    size_t cell = SIZE_MAX;
    float cell_s = 0, cell_n = 0;
    for_samples(k, [&](const Sample& q) {
      const int i = std::min(ns - 1, static_cast<int>((q.s - s_lo) / kCell_m));
      const int j = std::min(ny - 1, static_cast<int>((q.Y - y_lo) / kCell_m));
      const size_t c = static_cast<size_t>(j) * ns + i;
      if (c != cell) {
        if (cell != SIZE_MAX) S0[cell] = cell_s, N0[cell] = cell_n;
        cell = c, cell_s = S0[c], cell_n = N0[c];
      }
      cell_s += q.v;
      cell_n += 1;
    });
    if (cell != SIZE_MAX) S0[cell] = cell_s, N0[cell] = cell_n;
    cv::Mat m(ny, ns, CV_32F, cv::Scalar(0)), valid(ny, ns, CV_32F, cv::Scalar(0));
    std::vector<int> own(ns, 0), filled(ns, 0);
    for (int j = 0; j < ny; ++j) {
      const float* S = sum.ptr<float>(j);
      const float* N = cnt.ptr<float>(j);
      float* M = m.ptr<float>(j);
      float* V = valid.ptr<float>(j);
      int last = -1;
      for (int i = 0; i < ns; ++i) {
        if (N[i] == 0) continue;
        M[i] = S[i] / N[i];
        V[i] = 1;
        ++own[i];
        ++filled[i];
        if (last >= 0 && i - last > 1 && i - last <= gap + 1)  // fill the gap along s
          for (int q = last + 1; q < i; ++q) {
            const double w = static_cast<double>(q - last) / (i - last);
            M[q] = static_cast<float>((1 - w) * M[last] + w * M[i]);
            V[q] = 1;
            ++filled[q];
          }
        last = i;
      }
    }
    // The wall's local mean over the filled cells: box sums of m and of the filled mask from their
    // integral images (double, made in one order: the same sums at any thread count).
    cv::Mat mi, vi;
    cv::integral(m, mi, CV_64F);
    cv::integral(valid, vi, CV_64F);
    cv::Mat dark(ny, ns, CV_8U, cv::Scalar(0));
    for (int j = 0; j < ny; ++j) {
      const float* M = m.ptr<float>(j);
      const float* V = valid.ptr<float>(j);
      const int j0 = std::max(0, j - half), j1 = std::min(ny, j + half + 1);
      const double *mt = mi.ptr<double>(j0), *mb = mi.ptr<double>(j1), *vt = vi.ptr<double>(j0), *vb = vi.ptr<double>(j1);
      uint8_t* d = dark.ptr<uint8_t>(j);
      for (int i = 0; i < ns; ++i) {
        if (V[i] == 0) continue;
        const int i0 = std::max(0, i - half), i1 = std::min(ns, i + half + 1);
        const double a = mb[i1] - mb[i0] - mt[i1] + mt[i0], b = vb[i1] - vb[i0] - vt[i1] + vt[i0];
        if (!(b > 0)) continue;
        const double t = a / b;
        d[i] = t > 0 && (t - M[i]) / t > tau;
      }
    }
    // (cell_components: OpenCV's components in OpenCV's order, by runs: a tenth of
    // cv::connectedComponentsWithStats' time on these grids.)
    const std::vector<CellComponent> comps = cell_components(dark.ptr<uint8_t>(0), ns, ny);
    FacadeWindowsFound::Plane& P = out.planes[k];
    P.used = true;
    P.s0 = s_lo;
    P.ns = ns;
    P.resolved.resize(ns);
    for (int i = 0; i < ns; ++i) P.resolved[i] = filled[i] > 0 && 2 * own[i] >= filled[i];
    const FacadePlane& f = fac.planes[k];
    for (const CellComponent& cc : comps) {
      const int bw = cc.width, bh = cc.height, area = cc.area, left = cc.left, top = cc.top;
      const double w_m = bw * kCell_m, h_m = bh * kCell_m;
      if (w_m < kMinWidth_m || w_m > kMaxWidth_m || h_m < kMinHeight_m || h_m > kMaxHeight_m) continue;
      if (area < kMinFill * bw * bh || bh > kMaxAspect * bw || bw > kMaxAspect * bh) continue;
      if (!P.resolved[std::clamp(left + bw / 2, 0, ns - 1)]) continue;
      // A window's glass is its component's box (a window is a rectangle: the photo's dark cells
      // leave out its reflections and the lit side of its recess).
      FacadeWindowsFound::Window wdw;
      wdw.plane = k;
      wdw.s_lo = s_lo + left * kCell_m;
      wdw.s_hi = s_lo + (left + bw) * kCell_m;
      wdw.y_lo = y_lo + top * kCell_m;
      wdw.y_hi = y_lo + (top + bh) * kCell_m;
      // The box's bounds in the image: its corners projected (the point d·n + s·t at height Y),
      // widened by a pixel; a corner behind the camera takes the image's bounds.
      double u0 = W - 1, u1 = 0, v0 = H - 1, v1 = 0;
      for (const double sc : {wdw.s_lo, wdw.s_hi})
        for (const double yc : {wdw.y_lo, wdw.y_hi}) {
          double u, v;
          if (!g.project(f.d_m * f.nX + sc * tX[k], yc, f.d_m * f.nD + sc * tD[k], &u, &v, nullptr)) {
            u0 = 0, u1 = W - 1, v0 = 0, v1 = H - 1;
            continue;
          }
          u0 = std::min(u0, u), u1 = std::max(u1, u), v0 = std::min(v0, v), v1 = std::max(v1, v);
        }
      wdw.x0 = static_cast<int>(std::clamp(std::floor(u0) - 1, 0.0, W - 1.0));
      wdw.x1 = static_cast<int>(std::clamp(std::ceil(u1) + 1, 0.0, W - 1.0));
      wdw.y0 = static_cast<int>(std::clamp(std::floor(v0) - 1, 0.0, H - 1.0));
      wdw.y1 = static_cast<int>(std::clamp(std::ceil(v1) + 1, 0.0, H - 1.0));
      found[k].push_back(wdw);
    }
    // A stretch of façade whose windows the photo does not show (its glass no darker than its
    // wall, or a blank wall): per kStretch_m of s, fewer found windows than a quarter of the grid's
    // (one per pitch_m x storey_m) over its resolved cells keeps the grid there (photosite choice:
    // the grid lit such façades before); its columns count as unresolved.
    const int stretch = std::max(1, static_cast<int>(std::lround(kStretch_m / kCell_m)));
    auto stretch_of = [&](const FacadeWindowsFound::Window& w) {  // the stretch of a window's centre
      return std::clamp(static_cast<int>(((w.s_lo + w.s_hi) / 2 - s_lo) / kCell_m), 0, ns - 1) / stretch;
    };
    std::vector<int> found_in((ns + stretch - 1) / stretch, 0);
    for (const auto& w : found[k]) ++found_in[stretch_of(w)];
    std::vector<uint8_t> keep(found_in.size(), 0);
    for (size_t b = 0; b < found_in.size(); ++b) {
      double m2 = 0;
      for (int i = static_cast<int>(b) * stretch; i < std::min(ns, static_cast<int>(b + 1) * stretch); ++i)
        if (P.resolved[i]) m2 += filled[i] * kCell_m * kCell_m;
      keep[b] = m2 > 0 && found_in[b] >= 0.25 * m2 / (p.window_pitch_m * p.window_storey_m);
    }
    for (int i = 0; i < ns; ++i) P.resolved[i] = P.resolved[i] && keep[i / stretch];
    std::erase_if(found[k], [&](const FacadeWindowsFound::Window& w) { return !keep[stretch_of(w)]; });
  }
  for (int k = 0; k < nplanes; ++k) out.windows.insert(out.windows.end(), found[k].begin(), found[k].end());
  return out;
}

}  // namespace photosite::scene
