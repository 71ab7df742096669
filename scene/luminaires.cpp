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
}  // namespace

StreetLighting LuminaireSet::update(const StreetLighting& plan, const CameraGeometry& g, int width, int /*height*/,
                                    const CameraPose& pose, const ScenePreset& p, uint64_t seed) {
  const Pose2 P(pose);
  if (p.street_road_luminance_cd_m2 <= 0) return plan;  // no street lighting: nothing to keep (the plan has the road's extent)
  if (!anchored_) {
    if (!(plan.road_right_m > plan.road_left_m)) return plan;  // nothing to anchor the layout to yet
    double d;
    P.to_world(plan.road_left_m, 0, &left_m_, &d);
    P.to_world(plan.road_right_m, 0, &right_m_, &d);
    phase_m_ = pose.D_m + street_layout_phase_m(p, seed);
    anchored_ = true;
  }
  const double S = p.lamp_spacing_ratio * p.lamp_mount_height_m;
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

  // The layout in the world (plan_street_lighting's, shifted by whole spacings as the camera
  // moves along the road), then the poles onto it.
  std::vector<StreetLamp> world;
  const bool both = right_m_ - left_m_ > p.lamp_mount_height_m;
  const long k0 = static_cast<long>(std::floor(pose.D_m / S));
  for (long k = -1; k * S <= p.lamp_max_distance_m; ++k) {
    const double D = phase_m_ + (k + k0) * S;
    world.push_back({right_m_ + p.lamp_setback_m, p.lamp_mount_height_m, D, false});
    if (both) world.push_back({left_m_ - p.lamp_setback_m, p.lamp_mount_height_m, D + 0.5 * S, false});
  }
  const double mid = 0.5 * (left_m_ + right_m_);
  for (const auto& pole : poles_) {
    int best = -1;
    for (int i = 0; i < static_cast<int>(world.size()); ++i) {
      const auto& l = world[i];
      if (l.from_pole || (l.X_m - mid) * (pole.X_m - mid) <= 0 || std::fabs(l.D_m - pole.D_m) > 0.5 * S) continue;
      if (best < 0 || std::fabs(l.D_m - pole.D_m) < std::fabs(world[best].D_m - pole.D_m)) best = i;
    }
    const StreetLamp sl{pole.X_m, pole.Y_m, pole.D_m, true};
    if (best >= 0) world[best] = sl;
    else world.push_back(sl);
  }

  StreetLighting s;
  s.peak_intensity_cd = plan.peak_intensity_cd;
  s.road_straight = plan.road_straight;  // this frame's measurement (the road ahead may bend later)
  s.source = poles_.empty() ? "road_edges" : "poles+road_edges";
  for (const auto& w : world) {
    StreetLamp l = w;
    P.to_frame(w.X_m, w.D_m, &l.X_m, &l.D_m);
    s.lamps.push_back(l);
  }
  std::stable_sort(s.lamps.begin(), s.lamps.end(),
                   [](const StreetLamp& a, const StreetLamp& b) { return a.D_m != b.D_m ? a.D_m < b.D_m : a.X_m < b.X_m; });
  double d;
  P.to_frame(left_m_, pose.D_m, &s.road_left_m, &d);
  P.to_frame(right_m_, pose.D_m, &s.road_right_m, &d);
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
      out[k] = seen_[best].key;
    } else {
      out[k] = facade_key(w);
      seen_.push_back({w.nX, w.nD, w.d_m, out[k]});
    }
  }
  return out;
}

}  // namespace photosite::scene
