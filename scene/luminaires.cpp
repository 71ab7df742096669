// Street luminaires carried across a sequence in world coordinates (see luminaires.h).
#include "photosite/scene/luminaires.h"

#include <algorithm>
#include <cmath>

namespace photosite::scene {

namespace {
struct Pose2 {
  double X, D, c, s;
  explicit Pose2(const CameraPose& p) : X(p.X_m), D(p.D_m), c(std::cos(p.yaw_rad)), s(std::sin(p.yaw_rad)) {}
  // Frame road coordinates → world (the first frame's), and back. At yaw 0 these are exact shifts.
  void to_world(double x, double d, double* xw, double* dw) const {
    *xw = X + x * c + d * s;
    *dw = D - x * s + d * c;
  }
  void to_frame(double xw, double dw, double* x, double* d) const {
    const double dx = xw - X, dd = dw - D;
    *x = dx * c - dd * s;
    *d = dx * s + dd * c;
  }
};

// Distance from the ground point (X, D) to the horizontal view wedge {D >= 0, ul·D <= X <= ur·D}
// (a convex cone with its apex at the camera's foot): 0 inside, else the distance to the nearer
// of its two boundary rays.
double wedge_distance(double X, double D, double ul, double ur) {
  if (D >= 0 && X >= ul * D && X <= ur * D) return 0;
  auto ray = [&](double u) {
    const double n = std::hypot(u, 1.0), ex = u / n, ed = 1 / n, t = X * ex + D * ed;
    return t <= 0 ? std::hypot(X, D) : std::hypot(X - t * ex, D - t * ed);
  };
  return std::min(ray(ul), ray(ur));
}

using Piece = LuminaireSet::Piece;

// A road straight within this curvature puts the kerb 60 m ahead (the plan's farthest row) off the
// kerb at the camera by at most κ·60²/2 = 0.125 m, half the medians' quarter metre.
constexpr double kStraightKappa = 2 * 0.125 / (60.0 * 60.0);

}  // namespace

LuminaireSet::Piece LuminaireSet::piece_at(double a) const { return road_line_piece(path_, a); }

void LuminaireSet::project(double X, double D, double* a, double* off, Piece* on) const {
  road_line_project(path_, X, D, a, off, on);
}

bool LuminaireSet::extend_path(const CameraPose& pose, const StreetLighting& plan) {
  // The vehicle's step from the last pose: at least 1 m, ahead (a pose behind the last one,
  // reversing, adds nothing). 1 m: a photosite choice — the curvature extrapolated ahead is the
  // step's turn over its length, and over a shorter baseline a yaw-rate sensor's noise sets it (a
  // vehicle creeping 0.01 m in a 0.06 s frame with 0.005 rad/s of noise would turn on a 30 m
  // radius). Its arc (advance_pose's: through both poses, turning by their yaw difference) has
  // length len and curvature turn/len.
  Piece& last = path_.back();
  const double dX = pose.X_m - node_X_, dD = pose.D_m - node_D_, chord = std::hypot(dX, dD);
  if (!(chord >= 1.0) || dX * std::sin(node_yaw_) + dD * std::cos(node_yaw_) <= 0) return false;
  const double turn = std::remainder(pose.yaw_rad - node_yaw_, 2 * M_PI);
  const double len = turn == 0 ? chord : chord * (0.5 * turn) / std::sin(0.5 * turn), kappa = turn / len;
  // Bent: the vehicle turned, or stepped sideways, by more than a path straight within
  // kStraightKappa (the pending road edges below wait for a straight drive).
  const double chord_psi = std::atan2(dX, dD) - 0.5 * turn;
  const bool bent = std::fabs(kappa) > kStraightKappa ||
                    std::fabs(std::remainder(chord_psi - node_yaw_, 2 * M_PI)) > kStraightKappa * len;
  node_X_ = pose.X_m;
  node_D_ = pose.D_m;
  node_yaw_ = pose.yaw_rad;
  // Does the road turn with the vehicle? The frame's kerbs (medians 20-60 m ahead) against those
  // of the road line continued straight along its heading at the camera: with the camera off the
  // line by `off` and turned from it by β, a kerb at e across the line appears at
  // (e − off)·cos β − D·sin β at D ahead, D = 30 m (the median row's distance over 20-60 m, where
  // 1/D is even in the image rows). The mean shift of the two kerbs from that is where the road
  // bends (κ·D²/2 on a curve); a vehicle that turns on a straight road (a lane change, a turn off
  // it) sees none: its turn is in β. The turn is followed when the kerbs shift its way by more than
  // the medians' quarter metre and the 30 m's error (D is anywhere in 20-60 m: |sin β|·30 m); not
  // when they do not; with no kerb measured, on the odometry alone.
  bool follow = turn != 0;
  if (follow && plan.road_right_m > plan.road_left_m) {
    double a, off;
    Piece on;
    project(pose.X_m, pose.D_m, &a, &off, &on);
    const Piece q = piece_at(a);
    const double beta = std::remainder(pose.yaw_rad - (q.psi0 + q.kappa * (a - q.a0)), 2 * M_PI);
    const double cb = std::cos(beta), sb = std::sin(beta);
    const double shift = 0.5 * ((plan.road_left_m - ((q.left_m - off) * cb - 30 * sb)) +
                                (plan.road_right_m - ((q.right_m - off) * cb - 30 * sb)));
    follow = shift * kappa > 0 && std::fabs(shift) > 0.25 + 30 * std::fabs(sb);
  }
  if (follow || last.kappa != 0) {
    // The road line turns as the vehicle did, from its end; or runs straight on from an arc's end.
    path_.push_back(road_piece_after(last, follow ? kappa : 0, len, last.left_m, last.right_m));
  } else {
    // Straight on: the last piece grows to the camera's place along it (a straight drive stays one
    // piece, its rows the straight rows of its first pose).
    double a, off;
    road_piece_project(last, pose.X_m, pose.D_m, &a, &off);
    last.len_m = std::max(last.len_m, a - last.a0);
  }
  return bent;
}

StreetLighting LuminaireSet::update(const StreetLighting& plan, const CameraGeometry& g, int width, int /*height*/,
                                    const CameraPose& pose, const ScenePreset& p, uint64_t seed) {
  const Pose2 P(pose);
  if (p.street_road_luminance_cd_m2 <= 0) return plan;  // no street lighting: nothing to keep (the plan has the road's extent)
  const double S = p.lamp_spacing_ratio * p.lamp_mount_height_m;
  if (!anchored_) {
    if (!(plan.road_right_m > plan.road_left_m)) return plan;  // nothing to anchor the layout to yet
    // The first piece: at the camera's foot along its heading, the along-line coordinate there its
    // D (so that at pose 0 and along a straight drive the rows are the single frame's).
    // Where the frame's kerbs show the road bending (measure_road_ahead), the line starts along the
    // road's measured heading with the kerbs' fitted offsets at the camera (the medians lie off
    // them by about κD²/2 at their rows' D: 4.5 m at 30 m on a 100 m radius).
    const RoadAhead& ra = plan.road_ahead;
    if (ra.curved)
      path_.assign(1, Piece{pose.X_m, pose.D_m, pose.yaw_rad + ra.heading_rad, 0, pose.D_m, 0, ra.left_m, ra.right_m});
    else
      path_.assign(1, Piece{pose.X_m, pose.D_m, pose.yaw_rad, 0, pose.D_m, 0, plan.road_left_m, plan.road_right_m});
    node_X_ = pose.X_m;
    node_D_ = pose.D_m;
    node_yaw_ = pose.yaw_rad;
    anchor_a_ = pose.D_m;
    phase_m_ = anchor_a_ + street_layout_phase_m(p, seed);
    anchored_ = true;
    pending_.clear();
  }
  const bool bent = extend_path(pose, plan);
  double a_cam, off_cam;
  Piece here;
  project(pose.X_m, pose.D_m, &a_cam, &off_cam, &here);
  // New road edges. A frame's edges are medians of the kerb 20-60 m ahead (plan_street_lighting):
  // where the road bends there they are off the kerb at the camera by about κ·D²/2 at the median
  // row's D, both the same way, as after a lane change, and the plan's road_straight does not
  // always see it (a left-hand curve of 100 m radius keeps few rows on the road at the principal
  // column: there it reports straight with both edges 2.75 m off; RoadEdgeLayoutFollowsACurvingRoad).
  // So a frame's edges are taken only once the vehicle has driven the plan's farthest row (60 m)
  // beyond it without turning (no step bent by more than kStraightKappa: the road there was
  // straight), when its plan found the road straight and an edge more than half a lane plus a
  // quarter metre off the kept one (road_straight lets the edge rows spread by half a lane, so a
  // median of other rows moves that far; each median is rounded to a quarter metre): a road that
  // widens or narrows. (A lane change moves the camera across the road line, not the kerbs: the
  // frame's edges are taken across the line, off_cam added.) They apply from the road line's end
  // on (the luminaires placed behind it stay).
  const double edge_tol = 0.5 * p.veh_lane_width_m + 0.25;
  auto differs = [&](double l, double r) {
    const Piece& q = path_.back();
    return std::fabs(l - q.left_m) > edge_tol || std::fabs(r - q.right_m) > edge_tol;
  };
  if (bent) pending_.clear();
  // (The frame's kerbs across the road line: the camera is off it by off_cam.)
  const double left_m = plan.road_left_m + off_cam, right_m = plan.road_right_m + off_cam;
  if (plan.road_straight && plan.road_right_m > plan.road_left_m && differs(left_m, right_m) &&
      (pending_.empty() || a_cam >= pending_.back().a + 1))  // one a metre at most: bounded
    pending_.push_back({a_cam, left_m, right_m});
  while (!pending_.empty() && a_cam - pending_.front().a >= 60) {
    const Pending e = pending_.front();
    pending_.erase(pending_.begin());
    if (!differs(e.left, e.right)) continue;
    Piece& last = path_.back();
    if (last.len_m == 0) {
      last.left_m = e.left;
      last.right_m = e.right;
    } else {
      path_.push_back(road_piece_after(last, last.kappa, 0, e.left, e.right));
    }
  }
  // The road line kept: from three spacings behind the camera (the layout below starts at most two
  // behind; a pole matched within half a spacing of it).
  while (path_.size() > 1 && path_[1].a0 < a_cam - 3 * S) path_.erase(path_.begin());
  // The road line with the road ahead as this frame measures it (measure_road_ahead), where the
  // measurement contradicts the line's own extrapolation (the last piece continued): the two kerbs
  // they put at the farthest kerb point measured (reach, small angles: β·s + κ·s²/2 continued,
  // ψ·s + κ_f·(s − c)²/2 measured, β the line's heading from the camera's) differ by more than 5 of
  // the fitted kerb's standard errors there (road_ahead_kerb_se_m). Entering a curve the line runs
  // straight while the kerbs bend; leaving one it still turns while they run straight. Then:
  // straight to the bend's start, the fitted arc for a quarter turn, straight on, with the kerbs
  // kept; from the line's end where the measured heading agrees with the line's, else from the
  // camera's foot along the measured heading, the kerbs across that line (the camera is off_cam
  // off the road line). A straight measurement replaces only a turning line: a straight drive keeps its
  // one piece, bit for bit. The driven part stays as it was.
  std::vector<Piece> line = path_;
  // At the pose the line ahead was decided at, that decision (the same street in view).
  if (ahead_decided_ && pose.X_m == ahead_X_ && pose.D_m == ahead_D_ && pose.yaw_rad == ahead_yaw_) {
    line.insert(line.end(), ahead_.begin(), ahead_.end());
  } else {
    const RoadAhead& ra = plan.road_ahead;
    const Piece last = path_.back();
    if ((ra.curved || (ra.state == "straight" && last.kappa != 0)) && a_cam >= last.a0) {
      const double s_m = ra.reach_m;
      const double beta = std::remainder(last.psi0 + last.kappa * (a_cam - last.a0) - pose.yaw_rad, 2 * M_PI);
      const double q = ra.curved ? std::max(0.0, s_m - ra.curve_start_m) : 0;
      const double continued = beta * s_m + 0.5 * last.kappa * s_m * s_m;
      const double measured = ra.heading_rad * s_m + 0.5 * ra.kappa_per_m * q * q;
      const double se = std::max(road_ahead_kerb_se_m(ra, s_m, false), road_ahead_kerb_se_m(ra, s_m, true));
      if (std::fabs(continued - measured) > 5 * se) {
        if (std::fabs(ra.heading_rad - beta) <= 5 * std::sqrt(std::max(0.0, ra.covariance[10]))) {
          // The measured heading is the line's (within 5 of its standard errors): on from the
          // line's end, the bend's start counted from the camera (a straight line's rows ahead of
          // the bend stay where they were, to rounding).
          const double a_end = last.a0 + last.len_m, c = ra.curved ? std::max(0.0, a_cam + ra.curve_start_m - a_end) : 0;
          line.push_back(road_piece_after(last, 0, c, last.left_m, last.right_m));
          if (ra.curved) road_append_quarter_turn(&line, ra.kappa_per_m, last.left_m, last.right_m);
        } else {
          RoadAhead here = ra;
          here.left_m = last.left_m - off_cam;
          here.right_m = last.right_m - off_cam;
          for (Piece w : road_ahead_pieces(here)) {
            // Frame → world: the pieces start at the camera's foot, their headings turned by the yaw.
            double X, D;
            P.to_world(w.X0, w.D0, &X, &D);
            w.X0 = X;
            w.D0 = D;
            w.psi0 += pose.yaw_rad;
            w.a0 += a_cam;
            line.push_back(w);
          }
        }
      }
    }
    ahead_decided_ = true;
    ahead_X_ = pose.X_m;
    ahead_D_ = pose.D_m;
    ahead_yaw_ = pose.yaw_rad;
    ahead_.assign(line.begin() + static_cast<std::ptrdiff_t>(path_.size()), line.end());
  }
  // This frame's pole luminaires into the remembered set.
  const double match_k = 2.0 / (g.f_px * g.mount_height_m);  // 2 px of contact row: ΔD = 2·D²/(f·h)
  std::vector<char> matched(poles_.size(), 0);
  for (const auto& l : plan.lamps) {
    if (!l.from_pole) continue;
    Lamp w;
    P.to_world(l.X_m, l.D_m, &w.X_m, &w.D_m);
    w.Y_m = l.Y_m;
    w.seen_m = std::hypot(l.X_m, l.D_m);
    int best = -1;
    double best_d = 0;
    for (size_t i = 0; i < poles_.size(); ++i) {
      if (matched[i]) continue;
      const double far = std::max(w.seen_m, poles_[i].seen_m);
      const double r = std::max(1.0, match_k * far * far);
      const double dist = std::hypot(poles_[i].X_m - w.X_m, poles_[i].D_m - w.D_m);
      if (dist <= r && (best < 0 || dist < best_d)) {
        best = static_cast<int>(i);
        best_d = dist;
      }
    }
    if (best < 0) {
      poles_.push_back(w);
      matched.push_back(1);
    } else {
      matched[best] = 1;
      if (w.seen_m < poles_[best].seen_m) poles_[best] = w;
    }
  }
  // Forget the luminaires whose light no longer reaches the view.
  const double ul = (-0.5 - g.cx_px) / g.f_px, ur = (width - 0.5 - g.cx_px) / g.f_px;
  std::vector<Lamp> kept;
  for (const auto& w : poles_) {
    double x, d;
    P.to_frame(w.X_m, w.D_m, &x, &d);
    if (wedge_distance(x, d, ul, ur) <= street_lamp_reach_m(w.Y_m, p)) kept.push_back(w);
  }
  poles_.swap(kept);
  std::sort(poles_.begin(), poles_.end(),
            [](const Lamp& a, const Lamp& b) { return a.D_m != b.D_m ? a.D_m < b.D_m : a.X_m < b.X_m; });

  // The layout along the road line (plan_street_lighting's rows, their along-line coordinates counted
  // in whole spacings from the anchoring pose), then the poles onto it.
  struct Placed { StreetLamp l; double a, off, mid; };
  std::vector<Placed> world;
  auto place = [&](double a, bool right) {
    const Piece q = road_line_piece(line, a);
    if (!right && !(q.right_m - q.left_m > p.lamp_mount_height_m)) return;  // one row on a narrow road
    const double edge = right ? q.right_m : q.left_m, setback = right ? p.lamp_setback_m : -p.lamp_setback_m;
    Placed w{{0, p.lamp_mount_height_m, 0, false}, a, edge + setback, 0.5 * (q.left_m + q.right_m)};
    road_piece_point(q, a, edge, setback, &w.l.X_m, &w.l.D_m);
    world.push_back(w);
  };
  const long k0 = static_cast<long>(std::floor((a_cam - anchor_a_) / S));
  for (long k = -1; k * S <= p.lamp_max_distance_m; ++k) {
    const double a = phase_m_ + (k + k0) * S;
    place(a, true);
    place(a + 0.5 * S, false);
  }
  for (const auto& pole : poles_) {
    double a, off;
    Piece on;
    road_line_project(line, pole.X_m, pole.D_m, &a, &off, &on);
    int best = -1;
    for (int i = 0; i < static_cast<int>(world.size()); ++i) {
      const auto& w = world[i];
      if (w.l.from_pole || (w.off - w.mid) * (off - w.mid) <= 0 || std::fabs(w.a - a) > 0.5 * S) continue;
      if (best < 0 || std::fabs(w.a - a) < std::fabs(world[best].a - a)) best = i;
    }
    const Placed sl{{pole.X_m, pole.Y_m, pole.D_m, true}, a, off, 0};
    if (best >= 0) world[best] = sl;
    else world.push_back(sl);
  }

  StreetLighting s;
  s.peak_intensity_cd = plan.peak_intensity_cd;
  s.road_straight = plan.road_straight;  // this frame's measurement (the road ahead may bend later)
  s.road_ahead = plan.road_ahead;        // likewise
  // Where this frame's bend starts at the camera: how far back along the road line driven the
  // vehicle has been turning the bend's way (the pieces behind the camera with curvature of that
  // sign, back from the camera's own), for the signs' facing (RoadAhead::turning_behind_m). Up to
  // the line kept (three spacings behind the camera).
  if (s.road_ahead.curved && s.road_ahead.curve_start_m <= kBendAtCameraM) {
    double behind = 0;
    for (size_t j = path_.size(); j-- > 0;) {
      const Piece& q = path_[j];
      if (q.a0 > a_cam) continue;  // (none: the line driven ends at the camera)
      if (!(q.kappa * s.road_ahead.kappa_per_m > 0)) break;
      // the part behind the camera (the last piece runs on to it: it is continued beyond its end)
      behind += j + 1 == path_.size() ? a_cam - q.a0 : std::min(q.len_m, a_cam - q.a0);
    }
    s.road_ahead.turning_behind_m = behind;
  }
  s.source = poles_.empty() ? "road_edges" : "poles+road_edges";
  for (const auto& w : world) {
    StreetLamp l = w.l;
    P.to_frame(w.l.X_m, w.l.D_m, &l.X_m, &l.D_m);
    s.lamps.push_back(l);
  }
  std::stable_sort(s.lamps.begin(), s.lamps.end(),
                   [](const StreetLamp& a, const StreetLamp& b) { return a.D_m != b.D_m ? a.D_m < b.D_m : a.X_m < b.X_m; });
  // The road edges across the line at the camera, in the frame.
  {
    const Piece q = road_line_piece(line, a_cam);
    double X, D, d;
    road_piece_point(q, a_cam, q.left_m, 0, &X, &D);
    P.to_frame(X, D, &s.road_left_m, &d);
    road_piece_point(q, a_cam, q.right_m, 0, &X, &D);
    P.to_frame(X, D, &s.road_right_m, &d);
  }
  // The EN 13201-3 field of plan_street_lighting (10 x 6 points over one spacing from
  // max(10 m, S), across the road extent) on these lamps.
  s.grid_D0_m = std::max(10.0, S);
  double sum = 0, mn = 1e300;
  for (int i = 0; i < 10; ++i)
    for (int j = 0; j < 6; ++j) {
      const double e = street_illuminance_lux(s.road_left_m + (j + 0.5) * (s.road_right_m - s.road_left_m) / 6,
                                              s.grid_D0_m + (i + 0.5) * S / 10, s, p);
      sum += e;
      mn = std::min(mn, e);
    }
  const double avg = sum / 60;
  s.uniformity_u0 = avg > 0 ? mn / avg : 0;
  s.avg_luminance_cd_m2 = p.rho_road * avg / M_PI;
  return s;
}

std::vector<char> ParkedSet::lit(const std::vector<Sighting>& frame, const CameraPose& pose, double match_k) {
  const Pose2 P(pose);
  std::vector<size_t> order(frame.size());
  for (size_t k = 0; k < order.size(); ++k) order[k] = k;
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    return std::hypot(frame[a].X_m, frame[a].D_m) < std::hypot(frame[b].X_m, frame[b].D_m);
  });
  const size_t remembered = seen_.size();  // (this frame's new vehicles are not matched against)
  std::vector<char> taken(remembered, 0), out(frame.size(), 0);
  for (const size_t k : order) {
    const Sighting& s = frame[k];
    double Xw, Dw;
    P.to_world(s.X_m, s.D_m, &Xw, &Dw);
    const double seen = std::hypot(s.X_m, s.D_m);
    int best = -1;
    double best_d = INFINITY;
    for (size_t i = 0; i < remembered; ++i) {
      if (taken[i]) continue;
      const double d = std::hypot(seen_[i].X_m - Xw, seen_[i].D_m - Dw), r = std::max(seen, seen_[i].seen_m);
      if (d <= std::max(1.0, match_k * r * r) + s.slack_m && d < best_d) { best = static_cast<int>(i); best_d = d; }
    }
    if (best < 0) {
      seen_.push_back({Xw, Dw, seen, s.draw});
      out[k] = s.draw;
      continue;
    }
    taken[best] = 1;
    Vehicle& v = seen_[best];
    if (seen < v.seen_m) { v.X_m = Xw; v.D_m = Dw; v.seen_m = seen; }
    out[k] = v.lit;
  }
  return out;
}

void ParkedSet::forget(const CameraPose& pose, double forget_m) {
  std::erase_if(seen_, [&](const Vehicle& v) { return std::hypot(v.X_m - pose.X_m, v.D_m - pose.D_m) > forget_m; });
}

std::vector<uint64_t> FacadeSet::keys(const std::vector<FacadePlane>& planes, const CameraPose& pose, double forget_m) {
  std::vector<FacadePlane> copy = planes;
  return hold(&copy, pose, forget_m);
}

std::vector<uint64_t> FacadeSet::hold(std::vector<FacadePlane>* planes_io, const CameraPose& pose, double forget_m) {
  std::vector<FacadePlane>& planes = *planes_io;
  // Forgotten first: the façades now beyond forget_m of the camera's foot (|n·T − d|).
  std::erase_if(seen_, [&](const Facade& f) { return std::fabs(f.nX * pose.X_m + f.nD * pose.D_m - f.d_m) > forget_m; });
  const double cos_tol = std::cos(2.5 * M_PI / 180), d_tol = 2.5;
  const size_t remembered = seen_.size();  // (this frame's new façades are not matched against)
  std::vector<uint64_t> out(planes.size());
  for (size_t k = 0; k < planes.size(); ++k) {
    const FacadePlane w = facade_in_world(planes[k], pose);
    int best = -1;
    for (size_t i = 0; i < remembered; ++i) {
      const Facade& f = seen_[i];
      if (f.nX * w.nX + f.nD * w.nD < cos_tol || std::fabs(f.d_m - w.d_m) > d_tol) continue;
      if (best < 0 || std::fabs(f.d_m - w.d_m) < std::fabs(seen_[best].d_m - w.d_m)) best = static_cast<int>(i);
    }
    if (best >= 0) {
      const Facade& f = seen_[best];
      out[k] = f.key;
      if (f.fitted && planes[k].fitted) {
        // The remembered plane in the frame (facade_in_world inverted: the normal turned back by
        // the yaw, the distance less the normal's component of the pose's place).
        FacadePlane& q = planes[k];
        if (pose.at_origin()) {
          q.nX = f.nX;
          q.nD = f.nD;
          q.d_m = f.d_m;
        } else {
          const double cy = std::cos(pose.yaw_rad), sy = std::sin(pose.yaw_rad);
          q.nX = f.nX * cy - f.nD * sy;
          q.nD = f.nX * sy + f.nD * cy;
          q.d_m = f.d_m - (f.nX * pose.X_m + f.nD * pose.D_m);
        }
      }
    } else {
      out[k] = facade_key(w);
      seen_.push_back({w.nX, w.nD, w.d_m, out[k], planes[k].fitted});
    }
  }
  return out;
}

}  // namespace photosite::scene
