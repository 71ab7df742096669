// A road's line in pieces, and the road ahead measured from a frame's kerbs (see road_line.h).
#include "photosite/scene/road_line.h"

#include <algorithm>
#include <array>
#include <cmath>


#include "photosite/scene/labels.h"

namespace photosite::scene {

// A straight piece is taken from its origin O = P0 − a0·t (t = (sin ψ0, cos ψ0) along, n =
// (cos ψ0, −sin ψ0) across): O + a·t + off1·n + off2·n. For ψ0 = 0 and D0 = a0 (the anchoring
// pose of a straight drive, or a single frame's camera) that is X0 + off1 + off2 and D = a, the
// expressions and roundings the layout's rows had as straight rows (right edge + setback; phase +
// k·S). An arc turns about its centre C = P0 + n0/κ: P(a) = C − (1/κ − off)·n(ψ), ψ = ψ0 + κ·(a − a0).
void road_piece_point(const RoadPiece& q, double a, double off1, double off2, double* X, double* D) {
  if (q.kappa == 0) {
    const double s = std::sin(q.psi0), c = std::cos(q.psi0), OX = q.X0 - q.a0 * s, OD = q.D0 - q.a0 * c;
    *X = ((OX + a * s) + off1 * c) + off2 * c;
    *D = ((OD + a * c) - off1 * s) - off2 * s;
    return;
  }
  const double r = 1 / q.kappa, CX = q.X0 + r * std::cos(q.psi0), CD = q.D0 - r * std::sin(q.psi0);
  const double psi = q.psi0 + q.kappa * (a - q.a0), rho = r - (off1 + off2);
  *X = CX - rho * std::cos(psi);
  *D = CD + rho * std::sin(psi);
}

RoadPiece road_piece_after(const RoadPiece& q, double kappa, double len_m, double left_m, double right_m) {
  const double a_end = q.a0 + q.len_m;
  RoadPiece n{0, 0, q.psi0 + q.kappa * q.len_m, kappa, a_end, len_m, left_m, right_m};
  road_piece_point(q, a_end, 0, 0, &n.X0, &n.D0);
  return n;
}

// On an arc the angle is taken within half a turn of the piece's middle; a point beyond the centre
// (off > 1/κ) is not on this piece's side.
void road_piece_project(const RoadPiece& q, double X, double D, double* a, double* off) {
  if (q.kappa == 0) {
    const double s = std::sin(q.psi0), c = std::cos(q.psi0), OX = q.X0 - q.a0 * s, OD = q.D0 - q.a0 * c;
    *a = (X - OX) * s + (D - OD) * c;
    *off = (X - OX) * c - (D - OD) * s;
    return;
  }
  const double r = 1 / q.kappa, CX = q.X0 + r * std::cos(q.psi0), CD = q.D0 - r * std::sin(q.psi0);
  const double wX = X - CX, wD = D - CD, k = q.kappa > 0 ? 1.0 : -1.0;
  const double psi = std::atan2(k * wD, -k * wX), um = 0.5 * q.len_m, psi_m = q.psi0 + q.kappa * um;
  *a = q.a0 + um + std::remainder(psi - psi_m, 2 * M_PI) / q.kappa;
  *off = r - k * std::hypot(wX, wD);
}

// Extrapolated on the last arc's curvature: the vehicle keeps turning as it turned over its last
// step (a road's curvature changes gradually: a constant-radius curve is entered and left over
// transition curves; CameraPose's arc is the same model the odometry integrates), where a
// straight extrapolation would put every luminaire ahead on a curve off the road by d²/(2R) at d
// ahead (8 m at 40 m on a 100 m radius). A quarter turn at most: beyond it the extrapolated road
// runs across or behind the view, and a circle smaller than the layout's reach (2πR <
// lamp_max_distance_m) would lay a second row over the first; straight on from there (a photosite
// choice).
RoadPiece road_line_piece(const std::vector<RoadPiece>& line, double a) {
  if (a < line.front().a0) {
    RoadPiece q = line.front();
    q.kappa = 0;
    return q;
  }
  size_t i = line.size() - 1;
  while (i > 0 && line[i].a0 > a) --i;
  const RoadPiece& q = line[i];
  const double end = q.a0 + q.len_m, cap = q.kappa == 0 ? INFINITY : 0.5 * M_PI / std::fabs(q.kappa);
  if (i + 1 < line.size() || a <= end + cap) return q;
  RoadPiece s = q;
  s.a0 = end + cap;
  s.psi0 = q.psi0 + q.kappa * (s.a0 - q.a0);
  road_piece_point(q, s.a0, 0, 0, &s.X0, &s.D0);
  s.kappa = 0;
  s.len_m = 0;
  return s;
}

void road_line_project(const std::vector<RoadPiece>& line, double X, double D, double* a, double* off, RoadPiece* on) {
  // Each piece's projection within its range (the first continued back, the last on), the one
  // nearest across.
  double best = INFINITY;
  for (size_t i = 0; i < line.size(); ++i) {
    const RoadPiece& q = line[i];
    double ai, oi;
    road_piece_project(q, X, D, &ai, &oi);
    if ((i > 0 && ai < q.a0) || (i + 1 < line.size() && ai > q.a0 + q.len_m)) continue;
    if (std::fabs(oi) < best) {
      best = std::fabs(oi);
      *a = ai;
      *off = oi;
      *on = q;
    }
  }
  if (best == INFINITY) {  // in no piece's range (beside a kink of the line): the last piece's
    road_piece_project(line.back(), X, D, a, off);
    *on = line.back();
  }
}

void road_append_quarter_turn(std::vector<RoadPiece>* line, double kappa, double left_m, double right_m) {
  // A quarter turn at most (road_line_piece's extrapolation: beyond it the road continued on the
  // circle runs across or behind the view), then straight on.
  line->push_back(road_piece_after(line->back(), kappa, 0.5 * M_PI / std::fabs(kappa), left_m, right_m));
  line->push_back(road_piece_after(line->back(), 0, 0, left_m, right_m));
}

std::vector<RoadPiece> road_ahead_pieces(const RoadAhead& r) {
  std::vector<RoadPiece> line{{0, 0, r.heading_rad, 0, 0, r.curved ? r.curve_start_m : 0, r.left_m, r.right_m}};
  if (r.curved) road_append_quarter_turn(&line, r.kappa_per_m, r.left_m, r.right_m);
  return line;
}

void carriageway_run(const ImageU16& ids, int x, int y, int* x0, int* x1) {
  auto carriageway = [&](int id) { return id == static_cast<int>(Label::Road) || is_vehicle(id); };
  const int W = ids.width();
  *x0 = *x1 = x;
  while (*x0 > 0 && carriageway(ids.at(*x0 - 1, y))) --*x0;
  while (*x1 < W - 1 && carriageway(ids.at(*x1 + 1, y))) ++*x1;
}

double road_ahead_kerb_se_m(const RoadAhead& r, double a_m, bool right) {
  // The kerb's position across the line at along-line distance a moves by δe + a·δψ (the line
  // turned about the camera's foot) + (a − c)²/2·δκ beyond the start (the arc's sagitta, small
  // angles): J·Cov·Jᵀ with J = (1 on its own kerb, a, max(0, a − c)²/2).
  const double q = std::max(0.0, a_m - r.curve_start_m);
  const std::array<double, 4> J{right ? 0.0 : 1.0, right ? 1.0 : 0.0, a_m, r.curved ? 0.5 * q * q : 0.0};
  double v = 0;
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) v += J[i] * r.covariance[i * 4 + j] * J[j];
  return std::sqrt(std::max(0.0, v));
}

namespace {
// A kerb point: its ground point, which kerb (0 left, 1 right), and the camera z of its row.
struct KerbPoint { double X, D, z; int side; };

// The model's road line: through the camera's foot heading psi, straight to c, then an arc of
// curvature kappa. The offset of (X, D) across it (+ right): in the line's frame (u along, v
// across) a point before c is v across the straight; beyond it, on the arc about (c, 1/κ),
// off = 1/κ − sign(κ)·ρ with ρ the distance from the centre, written as
// (2v − κ(du² + v²)) / (1 + |κ|ρ), |κ|ρ = hypot(κ·du, κ·v − 1): the same value without the
// cancellation of two near-equal radii when κ is small (it is v at κ = 0).
double model_offset(double X, double D, double psi, double c, double kappa) {
  const double s = std::sin(psi), co = std::cos(psi), u = X * s + D * co, v = X * co - D * s;  // (sincos)
  if (u <= c || kappa == 0) return v;
  const double du = u - c;
  return (2 * v - kappa * (du * du + v * v)) / (1 + std::hypot(kappa * du, kappa * v - 1));
}

// Solves the n x n system A·x = b (A symmetric positive definite, row-major) by Cholesky; false
// when A is not (a parameter the points do not determine).
template <int N>
bool solve_spd(std::array<double, N * N> A, std::array<double, N> b, std::array<double, N>* x,
               std::array<double, N * N>* inverse = nullptr) {
  std::array<double, N * N> L{};
  for (int i = 0; i < N; ++i)
    for (int j = 0; j <= i; ++j) {
      double sum = A[i * N + j];
      for (int k = 0; k < j; ++k) sum -= L[i * N + k] * L[j * N + k];
      if (i == j) {
        if (!(sum > 1e-300)) return false;
        L[i * N + i] = std::sqrt(sum);
      } else {
        L[i * N + j] = sum / L[j * N + j];
      }
    }
  auto solve = [&](std::array<double, N> r) {
    for (int i = 0; i < N; ++i) {
      for (int k = 0; k < i; ++k) r[i] -= L[i * N + k] * r[k];
      r[i] /= L[i * N + i];
    }
    for (int i = N - 1; i >= 0; --i) {
      for (int k = i + 1; k < N; ++k) r[i] -= L[k * N + i] * r[k];
      r[i] /= L[i * N + i];
    }
    return r;
  };
  *x = solve(b);
  if (inverse)
    for (int j = 0; j < N; ++j) {
      std::array<double, N> e{};
      e[j] = 1;
      const auto col = solve(e);
      for (int i = 0; i < N; ++i) (*inverse)[i * N + j] = col[i];
    }
  return true;
}

// One fit of the road line for a given curve start c (straight: kappa fixed at 0). Parameters
// (e_left, e_right, psi, kappa). Each point's offset error is its label boundary's pixel
// (sigma_px) across the kerb: z/f across the row, and along the row where the kerb crosses the
// rows at a slant, its slope dX/dD times the row's depth step D²/(f·h) per pixel (a kerb running
// across the image far up a curve is located poorly along its row). The residuals are standardised
// by it and weighted by Tukey's biweight at 4.685 robust scales (95% efficiency at Gaussian noise)
// after Huber's at 1.345 (a convex start), the scale the median absolute deviation's (1.4826·MAD),
// at least 1: a label boundary is not known better than its pixel.
// The heading's prior: the road runs along the camera's axis within 0.05 rad (2.9°; a vehicle
// drives along its lane, a lane change turns it by a few degrees: a photosite choice), taken as one
// more observation of the heading, weighted like the points. Without it a curve whose start lies
// nearer than the first kerb point seen (the rendered street's kerbs enter its view 15.5 m ahead)
// fits as well from the camera with the line turned the other way (13.5 m ahead: c = 0, heading
// -0.134 rad), and a sequence continuing its road line along the vehicle's heading would start the
// arc 13.5 m early. A road truly turned from the camera's axis outweighs it: its residual is
// rejected like an outlier's beyond 4.685 robust scales.
constexpr double kHeadingPrior = 0.05;

struct Fit {
  bool ok = false;
  double el = 0, er = 0, psi = 0, kappa = 0, c = 0;
  double kappa_se = 0, scale = 1, cost = 0, reach = 0, rms = 0;
  std::array<double, 16> cov{};  // of (e_left, e_right, psi, kappa): scale²·(JᵀWJ)⁻¹
  int used = 0;
  std::array<int, 2> on_arc{0, 0};  // points kept beyond the start, left and right kerb
};
Fit fit_road_line(const std::vector<KerbPoint>& pts, double c, bool curved, bool exact, const CameraGeometry& g) {
  Fit f;
  f.c = c;
  const size_t n = pts.size();
  std::vector<double> w(n, 1.0), sig(n, 1.0), r(n, 0.0);
  std::array<double, 4> th{0, 0, 0, 0};  // el, er, psi, kappa
  const int np = curved ? 4 : 3;
  double wp = 1;  // the heading prior's weight (Tukey's, as a point's)
  // The linear model (the line turned by a small psi): before c, X = e + psi·D; beyond it, on the
  // circle about (c, 1/κ), the kerb e satisfies (D − c)² + (X − 1/κ)² = (1/κ − e)², that is
  // X = e + κ/2·((D − c)² + X² − e²) exactly (an algebraic distance: (X − e)·(1 − κ(X + e)/2)
  // of the geometric one, within κ·e = 7% on a 100 m radius), linear in (e, psi, κ) with the
  // point's own X and the kerb's last e on the right (the first pass: e = 0, the parabola).
  auto quad = [&](const KerbPoint& k) {
    if (k.D <= c) return 0.0;
    const double e = k.side == 0 ? th[0] : th[1], q = k.D - c;
    return 0.5 * (q * q + k.X * k.X - e * e);
  };
  auto linear_step = [&]() {
    std::array<double, 16> A{};
    std::array<double, 4> b{};
    for (size_t i = 0; i < n; ++i) {
      if (w[i] <= 0) continue;
      const std::array<double, 4> J{pts[i].side == 0 ? 1.0 : 0.0, pts[i].side == 1 ? 1.0 : 0.0, pts[i].D, quad(pts[i])};
      const double wi = w[i] / (sig[i] * sig[i]);
      for (int a = 0; a < np; ++a) {
        b[a] += wi * J[a] * pts[i].X;
        for (int bb = 0; bb < np; ++bb) A[a * 4 + bb] += wi * J[a] * J[bb];
      }
    }
    A[10] += wp / (kHeadingPrior * kHeadingPrior);  // the heading's prior: 0 ± kHeadingPrior
    if (!curved) A[15] = 1, b[3] = 0;
    std::array<double, 4> x;
    if (!solve_spd<4>(A, b, &x)) return false;
    th = x;
    return true;
  };
  // The exact step (Gauss-Newton on the offsets of model_offset, its two angle derivatives by
  // central differences).
  std::array<double, 16> cov{};
  auto exact_step = [&](bool keep_cov) {
    std::array<double, 16> A{};
    std::array<double, 4> b{};
    const double hp = 1e-6, hk = 1e-7;
    for (size_t i = 0; i < n; ++i) {
      if (w[i] <= 0) continue;
      const KerbPoint& k = pts[i];
      const double e = k.side == 0 ? th[0] : th[1];
      const double res = model_offset(k.X, k.D, th[2], c, th[3]) - e;
      const double dp = (model_offset(k.X, k.D, th[2] + hp, c, th[3]) - model_offset(k.X, k.D, th[2] - hp, c, th[3])) / (2 * hp);
      const double dk = curved ? (model_offset(k.X, k.D, th[2], c, th[3] + hk) - model_offset(k.X, k.D, th[2], c, th[3] - hk)) / (2 * hk) : 0;
      const std::array<double, 4> J{k.side == 0 ? -1.0 : 0.0, k.side == 1 ? -1.0 : 0.0, dp, dk};
      const double wi = w[i] / (sig[i] * sig[i]);
      for (int a = 0; a < np; ++a) {
        b[a] -= wi * J[a] * res;
        for (int bb = 0; bb < np; ++bb) A[a * 4 + bb] += wi * J[a] * J[bb];
      }
    }
    A[10] += wp / (kHeadingPrior * kHeadingPrior);
    b[2] -= wp * th[2] / (kHeadingPrior * kHeadingPrior);
    if (!curved) A[15] = 1, b[3] = 0;
    std::array<double, 4> dx;
    if (!solve_spd<4>(A, b, &dx, keep_cov ? &cov : nullptr)) return false;
    for (int a = 0; a < 4; ++a) th[a] += dx[a];
    return true;
  };
  // Residuals (standardised) and each point's error at the current parameters.
  // (The errors are set anew where the slopes may have moved: once the convex start has put the
  // line near the points, and in each exact step; a tangent per point is the fit's dearest part.)
  auto residuals = [&](bool exact, bool errors) {
    for (size_t i = 0; i < n; ++i) {
      const KerbPoint& k = pts[i];
      const double e = k.side == 0 ? th[0] : th[1];
      const double off = exact ? model_offset(k.X, k.D, th[2], c, th[3]) : k.X - th[2] * k.D - th[3] * quad(k);
      if (errors) {
        const double slope = std::tan(std::clamp(th[2] + th[3] * std::max(0.0, k.D - c), -1.3, 1.3));
        const double across = k.z / g.f_px, along = slope * k.D * k.D / (g.f_px * g.mount_height_m);
        sig[i] = std::hypot(across, along);
      }
      r[i] = (off - e) / sig[i];
    }
  };
  std::vector<double> abs_r(n);
  auto robust_scale = [&]() {
    for (size_t i = 0; i < n; ++i) abs_r[i] = std::fabs(r[i]);
    std::nth_element(abs_r.begin(), abs_r.begin() + n / 2, abs_r.end());
    return std::max(1.0, 1.4826 * abs_r[n / 2]);
  };
  auto weight = [&](bool tukey, double t) {
    if (!tukey) return t <= 1.345 ? 1 : 1.345 / t;
    const double u = t / 4.685;
    return u < 1 ? (1 - u * u) * (1 - u * u) : 0;
  };
  auto weigh = [&](bool tukey, double s) {
    for (size_t i = 0; i < n; ++i) w[i] = weight(tukey, std::fabs(r[i]) / s);
    wp = weight(tukey, std::fabs(th[2]) / kHeadingPrior / s);
  };
  for (size_t i = 0; i < n; ++i) sig[i] = pts[i].z / g.f_px;
  if (!linear_step()) return f;
  for (int it = 0; it < 3; ++it) {
    residuals(false, it == 0);
    weigh(false, robust_scale());
    if (!linear_step()) return f;
  }
  double s = 1;
  for (int it = 0; it < 3; ++it) {
    residuals(false, it == 0);
    s = robust_scale();
    weigh(true, s);
    if (!linear_step()) return f;
  }
  for (int it = 0; exact && it < 4; ++it) {
    residuals(true, true);
    s = robust_scale();
    weigh(true, s);
    if (!exact_step(it == 3)) return f;
  }
  residuals(exact, exact);
  f.ok = true;
  f.el = th[0];
  f.er = th[1];
  f.psi = th[2];
  f.kappa = curved ? th[3] : 0;
  f.scale = s;
  // The curvature's standard error: the weighted least squares' (JᵀWJ)⁻¹ times the robust scale²
  // (the residuals are in units of each point's error).
  f.kappa_se = curved && exact ? s * std::sqrt(std::max(0.0, cov[15])) : 0;
  for (int k = 0; k < 16; ++k) f.cov[k] = exact ? s * s * cov[k] : 0;
  auto rho = [&](double t) {  // Tukey's ρ of a standardised residual, in units of its bound
    const double u = t / (4.685 * s);
    return u * u < 1 ? 1 - std::pow(1 - u * u, 3) : 1;
  };
  double cost = rho(th[2] / kHeadingPrior), ss = 0;
  for (size_t i = 0; i < n; ++i) {
    cost += rho(r[i]);
    if (w[i] > 0) {
      ++f.used;
      if (pts[i].D > c) ++f.on_arc[pts[i].side];
      f.reach = std::max(f.reach, pts[i].D);
      ss += std::pow(r[i] * sig[i], 2);
    }
  }
  f.cost = cost;
  f.rms = f.used ? std::sqrt(ss / f.used) : 0;
  return f;
}
}  // namespace

RoadAhead measure_road_ahead(const ImageU16& ids, const CameraGeometry& g) {
  RoadAhead out;
  const int W = ids.width(), H = ids.height();
  constexpr double kMinD = 10, kMaxD = 100;
  auto carriageway = [&](int id) { return id == static_cast<int>(Label::Road) || is_vehicle(id); };
  std::vector<KerbPoint> pts;
  // Each kerb tracked from the nearest row up. A row's kerb point continues its kerb when it lies
  // within 0.5 m + 0.5·|ΔD| of the kerb continued along its last slope (a curve bends a kerb by
  // ΔD²/(2R) over a row's ΔD, nothing like it; half a metre of label wobble, and half the rows'
  // distance for the slope's own error over a gap behind a parked car); one farther off is a
  // junction's mouth, a driveway or a hidden stretch, and ends that kerb's track there (a kerb is
  // not picked up again: what lies beyond a mouth may be the side street's).
  struct Track { bool alive = true, seen = false; double X = 0, D = 0, slope = 0, kept_D = 0; };
  Track track[2];
  auto predict = [&](const Track& t, double D) { return t.X + t.slope * (D - t.D); };
  // The scan starts at the principal column, then in the last row's run's middle until a kerb is
  // seen, then at the road's middle between the two kerbs continued to the row (projected: the
  // road's middle moves across the image as it bends); with one kerb left, half the last road
  // width from it (the run's middle while only one was ever seen).
  double start = g.cx_px, width = 0;
  bool found = false;
  for (int y = H - 1; y >= 0 && y > g.horizon_y; --y) {
    double D, z;
    if (!g.ground_point(g.cx_px, y, nullptr, &D, &z) || D < kMinD) continue;
    if (D > kMaxD) break;
    const bool l = track[0].alive && track[0].seen, r = track[1].alive && track[1].seen;
    if (!track[0].alive && !track[1].alive) break;  // both kerbs lost: nothing ahead is known to be this road
    if ((l && r) || ((l || r) && width > 0)) {
      const double Xm = l && r ? 0.5 * (predict(track[0], D) + predict(track[1], D))
                               : (l ? predict(track[0], D) + 0.5 * width : predict(track[1], D) - 0.5 * width);
      double u, v, zz;
      if (!g.project(Xm, 0, D, &u, &v, &zz)) break;
      start = u;
    }
    const int xs = static_cast<int>(std::lround(start));
    if (xs < 0 || xs >= W || !carriageway(ids.at(xs, y))) {
      if (found) break;  // the road is lost (behind a building, over a crest): no farther row is it
      continue;
    }
    if (!found && ids.at(xs, y) != static_cast<int>(Label::Road)) continue;
    int x0, x1;
    carriageway_run(ids, xs, y, &x0, &x1);
    double Xa, Xb;
    g.ground_point(x0 - 0.5, y, &Xa, nullptr, nullptr);
    g.ground_point(x1 + 0.5, y, &Xb, nullptr, nullptr);
    // A kerb point where the run ends on road against ground (sidewalk, parking, terrain...): two
    // ground classes meet on the ground at this row's depth. An end against a standing object (a
    // façade, a wall, a hedge, a vehicle) may be its silhouette over a road that runs on behind
    // it: on a curve's inside the façades hide the kerb beyond some 70 m (the rendered street's
    // at R = 100 m) and the run ends on them metres off it. It is the road's edge only where the
    // object stands on the road there: where its lowest pixel in the column beside the run (its
    // ground contact, or where something nearer hides it) lies on this row's ground line, i.e.
    // at most the edge's own slope lower. A road edge at X across from a camera h above the road
    // runs through the image along v − y_h = (h/X)·(u − c_x) (flat ground, small pitch: both
    // are f·h/z and f·X/z), so one column outward its contact is h/|X| rows lower; plus the
    // 1.5 px a label boundary's contact row is taken to (kFacadeInlier_px, scene/geometry.cpp); and
    // the pixel below that lowest one a ground class (the object stands on the ground there).
    // A façade in front of the road that it hides stands nearer than this row's ground, its
    // contact lower by f·h·(1/z_b − 1/z): 20 px for 1 m at 10 m in a 2048-px Cityscapes frame.
    // Walls, fences, guard rails, hedges and trunks (vegetation) and buildings count; a vehicle
    // does not (a car at the kerb stands on the road beside it, its body over the edge).
    auto stands_at_edge = [](int id) {
      return id == static_cast<int>(Label::Building) || id == static_cast<int>(Label::Wall) ||
             id == static_cast<int>(Label::Fence) || id == static_cast<int>(Label::GuardRail) ||
             id == static_cast<int>(Label::Vegetation);
    };
    auto kerb = [&](int inside, int outside, double X_m) {
      if (ids.at(inside, y) != static_cast<int>(Label::Road)) return false;
      const int o = ids.at(outside, y);
      if (is_ground(o)) return true;
      if (!stands_at_edge(o)) return false;
      const double allowed = g.mount_height_m / std::max(0.5, std::fabs(X_m)) + 1.5;
      int yb = y;
      while (yb + 1 < H && ids.at(outside, yb + 1) == o && yb - y <= allowed) ++yb;
      return yb - y <= allowed && yb + 1 < H && is_ground(ids.at(outside, yb + 1));
    };
    const bool at[2] = {x0 > 0 && kerb(x0, x0 - 1, Xa), x1 < W - 1 && kerb(x1, x1 + 1, Xb)};
    const double Xs[2] = {Xa, Xb};
    for (int side = 0; side < 2; ++side) {
      Track& t = track[side];
      if (!at[side] || !t.alive) continue;
      if (t.seen && std::fabs(Xs[side] - predict(t, D)) > 0.5 + 0.5 * std::fabs(D - t.D)) {
        t.alive = false;
        continue;
      }
      if (t.seen && D > t.D) t.slope = std::clamp(0.5 * t.slope + 0.5 * (Xs[side] - t.X) / (D - t.D), -2.0, 2.0);
      t.X = Xs[side];
      t.D = D;
      t.seen = true;
      // Kept for the fit every 2% of distance: the rows near the camera are a few centimetres
      // apart (D²/(f·h): 0.036 m at 10 m in a 2048-px Cityscapes frame), their kerb points the same
      // label edge's pixels, not independent measurements; so the near rows do not outweigh the far
      // ones and the fit's standard errors do not shrink with the resolution. 115 points a kerb
      // at most over 10-100 m (ln 10 / ln 1.02).
      if (!(t.kept_D > 0) || D >= 1.02 * t.kept_D) {
        t.kept_D = D;
        pts.push_back({Xs[side], D, z, side});
      }
    }
    found = true;
    start = 0.5 * (x0 + x1);  // (until the kerbs are seen; then the kerbs continued, above)
    if (track[0].seen && track[1].seen) width = track[1].X - track[0].X;
  }
  int left = 0, right = 0;
  for (const auto& k : pts) (k.side ? right : left)++;
  // Ten points a kerb at least (plan_street_lighting's rule for the straight test: fewer are a
  // glimpse of kerb between vehicles or at a junction's far side).
  if (left < 10 || right < 10) {
    out.state = left + right == 0 ? "not measured: no kerb 10-100 m ahead" : "not measured: fewer than 10 points on a kerb";
    out.points = left + right;
    return out;
  }
  const Fit straight = fit_road_line(pts, 0, false, true, g);
  if (!straight.ok) {
    out.state = "not measured: the kerb points do not determine a line";
    return out;
  }
  // The curve's start on a 5 m grid from the camera to 10 m short of the farthest kerb point (an
  // arc at least 10 m long measured), the one of least robust cost in the small-angle model (a
  // linear least squares: cheap), then fitted exactly.
  double far = 0, best_c = -1, best_cost = 0;
  for (const auto& k : pts) far = std::max(far, k.D);
  for (double c = 0; c <= far - 10; c += 5) {
    const Fit f = fit_road_line(pts, c, true, false, g);
    if (f.ok && (best_c < 0 || f.cost < best_cost)) best_c = c, best_cost = f.cost;
  }
  // Then to the metre about it (a start off by δc moves the arc's points s beyond it by κ·s·δc:
  // 0.1 m at 20 m on a 100 m radius for half a metre): the grid's neighbours within 2 m (a start
  // between two grid points fits best at the nearer, within 2.5 m).
  for (double c = std::max(0.0, best_c - 2), c0 = best_c, hi = std::min(far - 10, best_c + 2); best_c >= 0 && c <= hi; ++c) {
    if (c == c0) continue;
    const Fit f = fit_road_line(pts, c, true, false, g);
    if (f.ok && f.cost < best_cost) best_c = c, best_cost = f.cost;
  }
  Fit best;
  if (best_c >= 0) best = fit_road_line(pts, best_c, true, true, g);
  auto take = [&](const Fit& f) {
    out.covariance = f.cov;
    out.heading_rad = f.psi;
    out.left_m = f.el;
    out.right_m = f.er;
    out.reach_m = f.reach;
    out.points = f.used;
    out.residual_rms_m = f.rms;
  };
  // Curved: its curvature 5 standard errors from 0 (up to 23 starts are tried: at 4 a straight
  // road's kerbs, with Gaussian errors, would be taken for curved in up to 23 × 6.3·10⁻⁵ = 1.4·10⁻³
  // of frames (Bonferroni), at 5 in 23 × 5.7·10⁻⁷ = 1.3·10⁻⁵), and bending the line at least half a
  // metre from straight at the farthest point used (κ(D − c)²/2: twice the quarter metre the kerbs'
  // medians are rounded to, plan_street_lighting), so a bend too slight to move a luminaire is not
  // followed.
  // And both kerbs bend: each has at least 10 points kept on the arc (the rule for a kerb above).
  // A junction's corner, where one kerb turns into the side street and the other runs on or is
  // hidden by parked cars, bends one kerb only: the road runs on across the junction.
  if (best.ok && best.on_arc[0] >= 10 && best.on_arc[1] >= 10 && std::fabs(best.kappa) >= 5 * best.kappa_se &&
      0.5 * std::fabs(best.kappa) * std::pow(std::max(0.0, best.reach - best.c), 2) >= 0.5) {
    take(best);
    out.state = "curved";
    out.curved = true;
    out.curve_start_m = best.c;
    out.kappa_per_m = best.kappa;
    out.kappa_fit_per_m = best.kappa;
    out.kappa_se_per_m = best.kappa_se;
    return out;
  }
  take(straight);
  out.state = "straight";
  // The best curved fit (its curvature and standard error) says how large a bend the kerbs rule out.
  if (best.ok) {
    out.kappa_fit_per_m = best.kappa;
    out.kappa_se_per_m = best.kappa_se;
  }
  return out;
}

}  // namespace photosite::scene
