// Minimized-Laplacian residual interpolation (MLRI).
// D. Kiku, Y. Monno, M. Tanaka, M. Okutomi, "Minimized-Laplacian residual interpolation for color
// image demosaicking", Proc. SPIE 9023, Digital Photography X, 90230L (2014); built on their
// "Residual interpolation for color image demosaicking", Proc. IEEE ICIP 2013, pp. 2304-2308.
//
// Residual interpolation: instead of interpolating a colour (or the colour difference G - X, as
// Hamilton-Adams and LMMSE do), fit a local linear model X ~ a G + b of the missing colour on a
// guide, evaluate it everywhere (the "tentative" estimate), and interpolate only the residual
// X - tentative between the sites where X was measured. Where the channels are not similar (a
// saturated red edge has a jump in G - R), the residual is still smooth if the local model holds.
// MLRI fits (a, b) by minimizing the energy of the Laplacian of the residual instead of the
// residual itself (the guided filter of He, Sun & Tang, TPAMI 35(6), 2013, with its slope taken
// from Laplacians):
//     a = sum_M L(I) L(p) / sum_M L(I)^2,        b = mean_M(p) - a mean_M(I),
// the sums over the sites M of the sparse colour p in a window, L a Laplacian along the sampled
// lattice (step 2), I the guide; then (a, b) are averaged over the window (the guided filter's
// second box) and the tentative estimate is a_mean I + b_mean.
//
// What this file computes (parameters stated, chosen on the Kodak set; docs/demosaic.md):
// 1. Green, per direction d (horizontal, vertical), as in RI/MLRI: guides by 2-tap linear
//    interpolation along d (G at R/B sites, R or B at the green sites of their row/column). In
//    each row (column) two guided filters: the red (blue) samples on the green guide and the green
//    samples on the red (blue) guide, L = [-1 0 2 0 -1] along d, window 5x5 (radius kRg = 2).
//    The residuals at the measured sites are interpolated with [1/2 . 1/2] along d, giving a
//    directional colour difference G - X at every pixel.
// 2. The directional differences are combined as in GBTF (Pekkucuksen & Altunbasak, ICASSP 2010)
//    and RI: weights 1 / (sum of |difference gradient| over 3x3, taken one pixel to the N, S, W, E)^2,
//    and one-sided 5-tap Gaussian (sigma 3 px) averages of the differences towards each side;
//    green = X + combined difference at the R and B sites.
// 3. Red and blue: one MLRI guided filter each on the full green plane, the sparse R (B) samples,
//    L the 5-point cross Laplacian with step 2, window 7x7 (radius kRb = 3); residual interpolated
//    bilinearly (3x3 [1/4 1/2 1/4; 1/2 1 1/2; 1/4 1/2 1/4]); measured samples kept as they are.
// Regularization: sum L(I)^2 is clamped below at tau N mean_M(I)^2 (tau = 1e-3), a scale-free
// form of the original's fixed floor on the mean squared Laplacian; where both are 0, a = 0.
// Borders: the mosaic is extended by reflect-101 (parity-preserving: a valid mosaic of the
// mirrored scene) and every stage runs on the extended frame; the support radius is 21 px.
//
// Arithmetic: every window sum is separable, row (x) first then column (y), each a sum in
// increasing offset order, so a value does not depend on how the frame is cut into tiles or
// threads, and kernels/demosaic_mlri_*.comp reproduce it operation for operation (bit-equal;
// -ffp-contract=off, no reassociation). The CPU path runs the stages tile by tile (128x64 output
// pixels plus the 21-px margin) so that the intermediate planes stay in cache.
#include <algorithm>
#include <cmath>
#include <vector>

#include "demosaic_detail.h"
#include "photosite/sensor/demosaic.h"

namespace photosite {
namespace {

constexpr int kRg = 2;       // green guided filters: (2 kRg + 1)^2 window
constexpr int kRb = 3;       // red/blue guided filters: (2 kRb + 1)^2 window
constexpr int kMargin = 21;  // support radius of the whole method (stage margins below)
constexpr float kTau = 1e-3f;

}  // namespace

namespace detail {
// The float constants of MLRI, computed once, shared with the Vulkan kernels (push constants):
//   gw[5]      one-sided Gaussian weights (sigma 3), gw[4] at the centre, sum 1
//   tau_n_g[4] tau / N and inv_n_g[4] 1 / N of the green filters' four site relations
//   tau_n_b[4], inv_n_b[4] the same for the red/blue filters; inv_box_g = 1/25, inv_box_b = 1/49.
const MlriConstants& mlri_constants() {
  static const MlriConstants c = [] {
    MlriConstants k{};
    double s = 0, t[5];
    for (int j = 0; j < 5; ++j) s += t[j] = std::exp(-(4.0 - j) * (4.0 - j) / (2.0 * 3.0 * 3.0));
    for (int j = 0; j < 5; ++j) k.gw[j] = static_cast<float>(t[j] / s);
    // Relation k = kx | ky << 1 of a site class to the window centre: kx = 0 when the class's
    // columns have the centre's parity (ky the same for rows). N = the class's sites in a
    // (2r+1)^2 window: (offsets in [-r, r] of parity kx) x (of parity ky).
    auto count = [](int r, int par) {
      int n = 0;
      for (int d = -r; d <= r; ++d) n += (d & 1) == par;
      return n;
    };
    for (int rel = 0; rel < 4; ++rel) {
      const int ng = count(kRg, rel & 1) * count(kRg, rel >> 1), nb = count(kRb, rel & 1) * count(kRb, rel >> 1);
      k.tau_n_g[rel] = kTau / static_cast<float>(ng);
      k.inv_n_g[rel] = 1.f / static_cast<float>(ng);
      k.tau_n_b[rel] = kTau / static_cast<float>(nb);
      k.inv_n_b[rel] = 1.f / static_cast<float>(nb);
    }
    k.inv_box_g = 1.f / static_cast<float>((2 * kRg + 1) * (2 * kRg + 1));
    k.inv_box_b = 1.f / static_cast<float>((2 * kRb + 1) * (2 * kRb + 1));
    return k;
  }();
  return c;
}
int mlri_support_radius() { return kMargin; }
}  // namespace detail

namespace {

// Tile geometry: output tile TX x TY; every plane covers the tile plus kMargin on each side.
constexpr int kTX = 128, kTY = 64;
constexpr int kPS = kTX + 2 * kMargin;  // plane stride
constexpr int kPR = kTY + 2 * kMargin;  // plane rows
constexpr size_t kPlane = static_cast<size_t>(kPS) * kPR;

// Planes of a tile's scratch.
enum PlaneId {
  RAW, GUIDE, LIP, LII,
  HS0,                 // 8: H sums of (I, p, LIp, LII) x (same, other)
  A0 = HS0 + 8,        // 4: a per relation
  B0 = A0 + 4,         // 4: b per relation
  HA0 = B0 + 4,        // 4: H pass of the a box
  HB0 = HA0 + 4,       // 4: H pass of the b box
  Q0 = HB0 + 4,        // 4: q (green: own, partner; red/blue: relations 0..3)
  DIFH = Q0 + 4, DIFV, DH, WH, WV, GREEN, RES,
  kNumPlanes
};

struct Tile {
  float* buf;
  int X0, Y0;  // global coordinates of the tile's first output pixel
  // Row y of plane p, indexed by global x.
  float* row(int p, int y) const {
    return buf + p * kPlane + static_cast<size_t>(y - Y0 + kMargin) * kPS - (X0 - kMargin);
  }
};

// Loop over the region of margin m around the tile's output [X0, X1) x [Y0, Y1).
struct Region {
  int x0, x1, y0, y1;
};

// Fetch helper: value of plane p at (x + dx, y + dy) for direction D (0: along x, 1: along y).
template <int D>
struct Dir {
  // Offset `o` along the direction.
  static float at(const Tile& t, int p, int x, int y, int o) {
    return D == 0 ? t.row(p, y)[x + o] : t.row(p, y + o)[x];
  }
};

// Stage 1 (direction D): the guide I (2-tap mean along D) on margin 20, then the Laplacian
// products L(I) L(p) and L(I)^2 on margin 18, L = [-1 0 2 0 -1] along D.
template <int D>
void stage_quantities(const Tile& t, const Region& out) {
  for (int y = out.y0 - 20; y < out.y1 + 20; ++y) {
    float* g = t.row(GUIDE, y);
    if (D == 0) {
      const float* r = t.row(RAW, y);
      for (int x = out.x0 - 20; x < out.x1 + 20; ++x) g[x] = 0.5f * (r[x - 1] + r[x + 1]);
    } else {
      const float *u = t.row(RAW, y - 1), *d = t.row(RAW, y + 1);
      for (int x = out.x0 - 20; x < out.x1 + 20; ++x) g[x] = 0.5f * (u[x] + d[x]);
    }
  }
  for (int y = out.y0 - 18; y < out.y1 + 18; ++y) {
    float *lip = t.row(LIP, y), *lii = t.row(LII, y);
    const float *g = t.row(GUIDE, y), *r = t.row(RAW, y);
    const int s = D == 0 ? 2 : 2 * kPS;  // the step-2 neighbour along D, in floats
#pragma GCC ivdep
    for (int x = out.x0 - 18; x < out.x1 + 18; ++x) {
      const float li = (2.f * g[x] - g[x - s]) - g[x + s];
      const float lp = (2.f * r[x] - r[x - s]) - r[x + s];
      lip[x] = li * lp;
      lii[x] = li * li;
    }
  }
}

// Horizontal strided sums of radius R over rows [ya, yb), columns [xa, xb): for each quantity
// plane q, HS[2q] sums the columns of the centre's parity, HS[2q+1] the others, in increasing x.
template <int R>
inline float sum_same(const float* q, int x) {
  float s = q[x - (R & ~1)];
  for (int d = -(R & ~1) + 2; d <= (R & ~1); d += 2) s += q[x + d];
  return s;
}
template <int R>
inline float sum_other(const float* q, int x) {
  constexpr int o = (R & 1) ? R : R - 1;
  float s = q[x - o];
  for (int d = -o + 2; d <= o; d += 2) s += q[x + d];
  return s;
}
// The same along y through row pointers rows[R + dy].
template <int R>
inline float vsum_same(const float* const* rows, int x) {
  float s = rows[R - (R & ~1)][x];
  for (int d = -(R & ~1) + 2; d <= (R & ~1); d += 2) s += rows[R + d][x];
  return s;
}
template <int R>
inline float vsum_other(const float* const* rows, int x) {
  constexpr int o = (R & 1) ? R : R - 1;
  float s = rows[R - o][x];
  for (int d = -o + 2; d <= o; d += 2) s += rows[R + d][x];
  return s;
}

// Stage 2: the MLRI coefficients (a, b) of the four site relations at every pixel of margin m,
// from the quantities (I = plane GUIDE_P, p = RAW, L(I)L(p) = LIP, L(I)^2 = LII) on margin m + R.
template <int R>
void stage_coefficients(const Tile& t, const Region& out, int m, int guide_p, const float* tau_n,
                        const float* inv_n) {
  const int qp[4] = {guide_p, RAW, LIP, LII};
  for (int y = out.y0 - m - R; y < out.y1 + m + R; ++y)
    for (int q = 0; q < 4; ++q) {
      const float* src = t.row(qp[q], y);
      float *hs = t.row(HS0 + 2 * q, y), *ho = t.row(HS0 + 2 * q + 1, y);
      for (int x = out.x0 - m; x < out.x1 + m; ++x) {
        hs[x] = sum_same<R>(src, x);
        ho[x] = sum_other<R>(src, x);
      }
    }
  for (int y = out.y0 - m; y < out.y1 + m; ++y) {
    const float* rows[8][2 * R + 1];
    for (int h = 0; h < 8; ++h)
      for (int d = -R; d <= R; ++d) rows[h][d + R] = t.row(HS0 + h, y + d);
    float* a[4];
    float* b[4];
    for (int k = 0; k < 4; ++k) a[k] = t.row(A0 + k, y), b[k] = t.row(B0 + k, y);
    for (int x = out.x0 - m; x < out.x1 + m; ++x) {
      for (int k = 0; k < 4; ++k) {
        const int kx = k & 1, ky = k >> 1;
        float s[4];
        for (int q = 0; q < 4; ++q) {
          const float* const* rr = rows[2 * q + kx];
          s[q] = ky ? vsum_other<R>(rr, x) : vsum_same<R>(rr, x);
        }
        const float si = s[0], sp = s[1], sip = s[2], sii = s[3];
        const float den = std::max(sii, (tau_n[k] * si) * si);
        const float ak = den > 0.f ? sip / den : 0.f;
        a[k][x] = ak;
        b[k][x] = (sp - ak * si) * inv_n[k];
      }
    }
  }
}

// Box sum of radius R of relation k's coefficient at the centre: the relation of a neighbour at
// offset (dx, dy) is k ^ (dx & 1) ^ ((dy & 1) << 1), so the box mixes the four relation planes.
// H pass (into HA/HB, all four k) over rows of margin m + R, columns of margin m.
template <int R>
void stage_box_h(const Tile& t, const Region& out, int m) {
  for (int y = out.y0 - m - R; y < out.y1 + m + R; ++y)
    for (int ab = 0; ab < 2; ++ab) {
      const float* src[4];
      for (int k = 0; k < 4; ++k) src[k] = t.row((ab ? B0 : A0) + k, y);
      for (int k = 0; k < 4; ++k) {
        float* dst = t.row((ab ? HB0 : HA0) + k, y);
        const float *same = src[k], *odd = src[k ^ 1];
        for (int x = out.x0 - m; x < out.x1 + m; ++x) {
          float s = same[x - R];  // R even or odd: offset -R has parity R & 1
          if (R & 1) s = odd[x - R];
          for (int d = -R + 1; d <= R; ++d) s += (d & 1) ? odd[x + d] : same[x + d];
          dst[x] = s;
        }
      }
    }
}
// V pass of relation k at (x, y) from the H planes.
template <int R>
inline float box_v(const Tile& t, int hplane0, int k, int x, int y) {
  float s = t.row(hplane0 + (k ^ ((R & 1) << 1)), y - R)[x];
  for (int d = -R + 1; d <= R; ++d) s += t.row(hplane0 + (k ^ ((d & 1) << 1)), y + d)[x];
  return s;
}

// Green, direction D: q of the pixel's own class (relation 0) and of its partner along D
// (relation 1 for rows, 2 for columns) on margin 14, then the directional difference
// dif = s (X_est - raw) on margin 13 into DIFH / DIFV (s = +1 at R/B sites, -1 at green sites,
// X_est the other colour of the row/column: own tentative + [1/2 . 1/2] of the neighbours'
// residuals).
template <int D>
void green_direction(const Tile& t, const Region& out, const detail::BayerPhase& ph) {
  const auto& c = detail::mlri_constants();
  stage_quantities<D>(t, out);
  stage_coefficients<kRg>(t, out, 16, GUIDE, c.tau_n_g, c.inv_n_g);
  stage_box_h<kRg>(t, out, 14);
  constexpr int partner = D == 0 ? 1 : 2;
  for (int y = out.y0 - 14; y < out.y1 + 14; ++y) {
    float *qo = t.row(Q0, y), *qp = t.row(Q0 + 1, y);
    const float *g = t.row(GUIDE, y), *r = t.row(RAW, y);
    for (int x = out.x0 - 14; x < out.x1 + 14; ++x) {
      qo[x] = (box_v<kRg>(t, HA0, 0, x, y) * g[x] + box_v<kRg>(t, HB0, 0, x, y)) * c.inv_box_g;
      qp[x] = (box_v<kRg>(t, HA0, partner, x, y) * r[x] + box_v<kRg>(t, HB0, partner, x, y)) * c.inv_box_g;
    }
  }
  for (int y = out.y0 - 13; y < out.y1 + 13; ++y) {
    float* dif = t.row(D == 0 ? DIFH : DIFV, y);
    const float *qp = t.row(Q0 + 1, y), *r = t.row(RAW, y);
    const bool red_or_blue_even = ((y - ph.oy) & 1) == 0 ? true : false;
    for (int x = out.x0 - 13; x < out.x1 + 13; ++x) {
      auto res = [&](int o) { return Dir<D>::at(t, RAW, x, y, o) - Dir<D>::at(t, Q0, x, y, o); };
      const float est = qp[x] + 0.5f * (res(-1) + res(1));
      // R/B sites: (x - ox) and (y - oy) of equal parity.
      const bool rb = (((x - ph.ox) & 1) == 0) == red_or_blue_even;
      dif[x] = rb ? est - r[x] : -(est - r[x]);
    }
  }
}

void green_combine(const Tile& t, const Region& out, const detail::BayerPhase& ph) {
  const auto& c = detail::mlri_constants();
  const float* gw = c.gw;
  // |difference gradient| along each direction (margin 12), its 3x3 box sum (margin 11).
  for (int dir = 0; dir < 2; ++dir) {
    for (int y = out.y0 - 12; y < out.y1 + 12; ++y) {
      float* dh = t.row(DH, y);
      if (dir == 0) {
        const float* d = t.row(DIFH, y);
        for (int x = out.x0 - 12; x < out.x1 + 12; ++x) dh[x] = std::fabs(d[x - 1] - d[x + 1]);
      } else {
        const float *u = t.row(DIFV, y - 1), *d = t.row(DIFV, y + 1);
        for (int x = out.x0 - 12; x < out.x1 + 12; ++x) dh[x] = std::fabs(u[x] - d[x]);
      }
    }
    for (int y = out.y0 - 12; y < out.y1 + 12; ++y) {  // H pass into HA0 (free now)
      const float* d = t.row(DH, y);
      float* h = t.row(HA0 + dir, y);
      for (int x = out.x0 - 11; x < out.x1 + 11; ++x) h[x] = (d[x - 1] + d[x]) + d[x + 1];
    }
    for (int y = out.y0 - 11; y < out.y1 + 11; ++y) {
      const float *u = t.row(HA0 + dir, y - 1), *m = t.row(HA0 + dir, y), *d = t.row(HA0 + dir, y + 1);
      float* w = t.row(dir == 0 ? WH : WV, y);
      for (int x = out.x0 - 11; x < out.x1 + 11; ++x) w[x] = (u[x] + m[x]) + d[x];
    }
  }
  for (int y = out.y0 - 9; y < out.y1 + 9; ++y) {
    float* g = t.row(GREEN, y);
    const float* r = t.row(RAW, y);
    const float *wh = t.row(WH, y), *wn = t.row(WV, y - 1), *ws = t.row(WV, y + 1);
    const float* dh = t.row(DIFH, y);
    const float* dv[9];
    for (int d = -4; d <= 4; ++d) dv[d + 4] = t.row(DIFV, y + d);
    const bool rb_even = ((y - ph.oy) & 1) == 0;
    for (int x = out.x0 - 9; x < out.x1 + 9; ++x) {
      const float Ww = 1.f / (wh[x - 1] * wh[x - 1] + 1e-32f), We = 1.f / (wh[x + 1] * wh[x + 1] + 1e-32f);
      const float Wn = 1.f / (wn[x] * wn[x] + 1e-32f), Ws = 1.f / (ws[x] * ws[x] + 1e-32f);
      float dw = gw[0] * dh[x - 4], de = gw[0] * dh[x + 4], dn = gw[0] * dv[0][x], ds = gw[0] * dv[8][x];
      for (int j = 1; j < 5; ++j) {
        dw += gw[j] * dh[x - 4 + j];
        de += gw[j] * dh[x + 4 - j];
        dn += gw[j] * dv[j][x];
        ds += gw[j] * dv[8 - j][x];
      }
      const float dif = (((Wn * dn + Ws * ds) + Ww * dw) + We * de) / (((Wn + Ws) + Ww) + We);
      const bool rb = (((x - ph.ox) & 1) == 0) == rb_even;
      g[x] = rb ? r[x] + dif : r[x];
    }
  }
}

// Red and blue: quantities on the green guide with the cross Laplacian (margin 7), coefficients
// of the four relations (margin 4), their 7x7 box means -> q_k for all four relations (margin 1),
// then per site type the measured value or q + the bilinear interpolation of the residuals.
void red_blue(const Tile& t, const Region& out, const detail::BayerPhase& ph, float* o, ptrdiff_t o_stride,
              int w) {
  const auto& c = detail::mlri_constants();
  for (int y = out.y0 - 7; y < out.y1 + 7; ++y) {
    float *lip = t.row(LIP, y), *lii = t.row(LII, y);
    const float *g = t.row(GREEN, y), *gu = t.row(GREEN, y - 2), *gd = t.row(GREEN, y + 2);
    const float *r = t.row(RAW, y), *ru = t.row(RAW, y - 2), *rd = t.row(RAW, y + 2);
    for (int x = out.x0 - 7; x < out.x1 + 7; ++x) {
      const float li = (((4.f * g[x] - g[x - 2]) - g[x + 2]) - gu[x]) - gd[x];
      const float lp = (((4.f * r[x] - r[x - 2]) - r[x + 2]) - ru[x]) - rd[x];
      lip[x] = li * lp;
      lii[x] = li * li;
    }
  }
  stage_coefficients<kRb>(t, out, 4, GREEN, c.tau_n_b, c.inv_n_b);
  stage_box_h<kRb>(t, out, 1);
  for (int y = out.y0 - 1; y < out.y1 + 1; ++y) {
    const float* g = t.row(GREEN, y);
    float* q[4];
    for (int k = 0; k < 4; ++k) q[k] = t.row(Q0 + k, y);
    for (int x = out.x0 - 1; x < out.x1 + 1; ++x)
      for (int k = 0; k < 4; ++k)
        q[k][x] = (box_v<kRb>(t, HA0, k, x, y) * g[x] + box_v<kRb>(t, HB0, k, x, y)) * c.inv_box_b;
    float* res = t.row(RES, y);
    const float* r = t.row(RAW, y);
    for (int x = out.x0 - 1; x < out.x1 + 1; ++x) res[x] = r[x] - q[0][x];
  }
  for (int y = out.y0; y < out.y1; ++y) {
    const float *r = t.row(RAW, y), *g = t.row(GREEN, y);
    const float *res = t.row(RES, y), *ru = t.row(RES, y - 1), *rd = t.row(RES, y + 1);
    const float *q1 = t.row(Q0 + 1, y), *q2 = t.row(Q0 + 2, y), *q3 = t.row(Q0 + 3, y);
    float* dst = o + (y - out.y0) * o_stride;
    for (int x = out.x0; x < out.x1; ++x) {
      const float h_est = q1[x] + 0.5f * (res[x - 1] + res[x + 1]);
      const float v_est = q2[x] + 0.5f * (ru[x] + rd[x]);
      const float d_est = q3[x] + 0.25f * ((ru[x - 1] + ru[x + 1]) + (rd[x - 1] + rd[x + 1]));
      float* px = dst + 3 * (x - out.x0);
      switch (detail::cell_type(ph, x, y)) {
        case detail::kR: px[0] = r[x], px[2] = d_est; break;
        case detail::kGr: px[0] = h_est, px[2] = v_est; break;
        case detail::kGb: px[0] = v_est, px[2] = h_est; break;
        default: px[0] = d_est, px[2] = r[x]; break;
      }
      px[1] = g[x];
      if (ph.clear) detail::clear_to_rgb(px);
    }
  }
  (void)w;
}

}  // namespace

ImageF demosaic_mlri(const ImageF& m, CfaPattern pattern) {
  if (!detail::bayer_path_ok(m, pattern)) return detail::demosaic_bilinear_generic(m, pattern);
  const auto ph = detail::bayer_phase(pattern);
  const int w = m.width(), h = m.height();
  ImageF out(w, h, 3, uninitialized, m.unit());
  const int ntx = (w + kTX - 1) / kTX, nty = (h + kTY - 1) / kTY;
#pragma omp parallel
  {
    std::vector<float> scratch(kNumPlanes * kPlane);
#pragma omp for schedule(static)
    for (int i = 0; i < ntx * nty; ++i) {
      const int X0 = (i % ntx) * kTX, Y0 = (i / ntx) * kTY;
      const Region reg{X0, std::min(X0 + kTX, w), Y0, std::min(Y0 + kTY, h)};
      const Tile t{scratch.data(), X0, Y0};
      for (int y = reg.y0 - kMargin; y < reg.y1 + kMargin; ++y) {
        const float* src = m.row(detail::reflect(y, h));
        float* dst = t.row(RAW, y);
        for (int x = reg.x0 - kMargin; x < reg.x1 + kMargin; ++x) dst[x] = src[detail::reflect(x, w)];
      }
      green_direction<0>(t, reg, ph);
      green_direction<1>(t, reg, ph);
      green_combine(t, reg, ph);
      red_blue(t, reg, ph, out.row(reg.y0) + 3 * reg.x0, static_cast<ptrdiff_t>(3) * w, w);
    }
  }
  return out;
}

}  // namespace photosite
