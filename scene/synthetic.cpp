// A synthetic road scene with known geometry for tests: a flat straight road toward a chosen
// vanishing point, dashed lane markings, sky, building blocks on both sides, box cars.
#include <algorithm>
#include <cmath>

#include "photosite/scene/night.h"

namespace photosite::scene {

SyntheticScene make_synthetic_road(const SyntheticOptions& o) {
  const int W = o.width, H = o.height;
  SyntheticScene s;
  s.day_linear_srgb = ImageF(W, H, 3, 0.f, "linear sRGB");
  s.labels.ids = ImageU16(W, H, 1, 0, unit::label_id);
  s.labels.instances = ImageU16(W, H, 1, 0, "instance id");
  auto set = [&](int x, int y, Label l, float r, float g, float b) {
    s.labels.ids.at(x, y) = static_cast<uint16_t>(l);
    s.day_linear_srgb.at(x, y, 0) = r;
    s.day_linear_srgb.at(x, y, 1) = g;
    s.day_linear_srgb.at(x, y, 2) = b;
  };
  const double vx = o.vp_x, vy = o.vp_y;
  // Road edges at the bottom row: 5% and 95% of the width; lane lines at 1/3 and 2/3.
  auto xb_at = [&](double frac_bottom, double y) {  // x on the line from the VP to the bottom point
    const double xb = frac_bottom * W;
    return vx + (xb - vx) * (y - vy) / (H - 1 - vy);
  };
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const bool below = y > vy;
      if (!below) {
        if (o.buildings && (x < vx - 0.12 * W || x > vx + 0.12 * W) && y > vy - 0.25 * H)
          set(x, y, Label::Building, 0.25f, 0.22f, 0.2f);
        else if (o.sky) set(x, y, Label::Sky, 0.5f, 0.6f, 0.8f);
        else set(x, y, Label::Vegetation, 0.05f, 0.12f, 0.03f);
        continue;
      }
      const double l = xb_at(0.05, y), r = xb_at(0.95, y);
      if (o.road && x >= l && x <= r) {
        set(x, y, Label::Road, 0.08f, 0.08f, 0.085f);
        if (o.lanes) {
          // Dashes: on for alternating bands of 1/depth (equal lengths on the ground).
          const double z = (H - 1 - vy) / std::max(1e-3, y - vy);
          const bool dash_on = std::fmod(z * 4.0, 2.0) < 1.0;
          const double half = std::max(0.8, 0.006 * W * (y - vy) / (H - 1 - vy));
          for (double fr : {1.0 / 3, 2.0 / 3})
            if (dash_on && std::fabs(x - xb_at(fr, y)) <= half) set(x, y, Label::Road, 0.8f, 0.8f, 0.78f);
          // Solid edge lines.
          for (double fr : {0.07, 0.93})
            if (std::fabs(x - xb_at(fr, y)) <= half) set(x, y, Label::Road, 0.8f, 0.8f, 0.78f);
        }
      } else {
        set(x, y, Label::Sidewalk, 0.2f, 0.19f, 0.18f);
      }
    }
  // Cars: boxes standing on the road at decreasing distance, in the right and left lanes.
  for (int c = 0; c < o.cars; ++c) {
    const double yb = vy + (H - 1 - vy) * (0.35 + 0.25 * c);  // bottom row of the car
    const double scale = (yb - vy) / (H - 1 - vy);
    const double fr = c % 2 == 0 ? 0.62 : 0.25;
    const double cx = xb_at(fr, yb), cw = 0.2 * W * scale, ch = 0.13 * W * scale;
    for (int y = std::max(0, static_cast<int>(yb - ch)); y <= std::min(H - 1, static_cast<int>(yb)); ++y)
      for (int x = std::max(0, static_cast<int>(cx - cw / 2)); x <= std::min(W - 1, static_cast<int>(cx + cw / 2)); ++x) {
        set(x, y, Label::Car, 0.3f, 0.05f, 0.05f);
        s.labels.instances.at(x, y) = static_cast<uint16_t>(26000 + c);
      }
  }
  return s;
}

}  // namespace photosite::scene

namespace photosite::scene {

// The centre line's circle has its centre at (road_radius_m, curve_start_D_m), a distance |R| across
// the straight's end, on the side it turns to. A point at distance ρ from the centre lies
// sign(R)·(|R| − ρ) across the line (+ toward the centre for a right-hand curve, as +X on the
// straight) and, at angle φ from the centre's radius to the curve's start (swept toward +D), at
// arc length curve_start_D_m + |R|·φ. φ is taken in (0, π) (points beyond the start, D > D_c):
// the arc runs at most a half turn.
void synthetic_street_coordinates(const SyntheticCameraOptions& o, double X_m, double D_m, double* e_m, double* a_m) {
  const double R = o.road_radius_m, Dc = o.curve_start_D_m;
  if (R == 0 || D_m <= Dc) {
    *e_m = X_m;
    *a_m = D_m;
    return;
  }
  const double sg = R > 0 ? 1 : -1, r = std::fabs(R);
  *e_m = sg * (r - std::hypot(X_m - R, D_m - Dc));
  *a_m = Dc + r * std::atan2(D_m - Dc, sg * (R - X_m));
}

SyntheticCameraScene make_synthetic_camera_scene(const SyntheticCameraOptions& o) {
  const int W = o.width, H = o.height;
  const CameraGeometry& g = o.camera;
  SyntheticCameraScene s;
  s.day_linear_srgb = ImageF(W, H, 3, 0.f, "linear sRGB");
  s.labels.ids = ImageU16(W, H, 1, 0, unit::label_id);
  s.labels.instances = ImageU16(W, H, 1, 0, "instance id");
  s.depth_m = ImageF(W, H, 1, kDepthInfinity_m, "m");
  s.box_front = ImageU8(W, H, 1, 0);
  const double c = std::cos(g.pitch_rad), sn = std::sin(g.pitch_rad), h = g.mount_height_m;
  // The camera's place in the street: a ray's direction turned by the yaw (luminaires.cpp's Pose2,
  // frame → world), its origin moved to the camera's foot. At the origin none of it is taken, so
  // the same operations as before it.
  const double X0 = o.world_X_m, D0 = o.world_D_m, cy = std::cos(o.world_yaw_rad), sy = std::sin(o.world_yaw_rad);
  const bool posed = X0 != 0 || D0 != 0 || o.world_yaw_rad != 0;
  // A curving street: the straight façades end where the curve starts, the curve's own follow it.
  const bool curved = o.road_radius_m != 0;
  const double facade_end_D = curved ? std::min(200.0, o.curve_start_D_m) : 200;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      // Ray per unit camera z in road coordinates: origin (0, h, 0).
      const double xn = (x - g.cx_px) / g.f_px, yn = (y - g.cy_px) / g.f_px;
      const double dXc = xn, dY = -(yn * c + sn), dDc = c - yn * sn;
      const double dX = posed ? dXc * cy + dDc * sy : dXc, dD = posed ? -dXc * sy + dDc * cy : dDc;
      double best = INFINITY;
      int hit = -1;  // -2 ground, >= 0 box index
      bool front = false;
      if (dY < 0) { best = h / -dY; hit = -2; }
      // Building façades beyond the sidewalks: vertical planes X = ±(road + sidewalk), 12 m tall,
      // from 3 m to 200 m ahead.
      bool facade = false;
      double facade_a = NAN;  // the arc length of a hit on a curved façade
      {
        const double xf = o.road_half_width_m + o.sidewalk_m;
        for (double side : {-xf, xf})
          if (dX != 0) {
            const double t = (side - X0) / dX, Y = h + t * dY, D = D0 + t * dD;
            if (t > 0 && t < best && Y >= 0 && Y <= 12 && D >= 3 && D <= facade_end_D) { best = t; hit = -3; facade = true; }
          }
        // On the curve the façades are vertical cylinders about the circle's centre (R, D_c), of
        // radius |R| − sign(R)·(±xf): |P0 + t·d − C|² = ρ² in the ground plane, the nearer root
        // first; a hit counts beyond the curve's start, 3-200 m of arc length along the street.
        const double A = dX * dX + dD * dD;
        if (curved && A > 0) {
          const double R = o.road_radius_m, sg = R > 0 ? 1 : -1, px = X0 - R, pd = D0 - o.curve_start_D_m;
          const double B = px * dX + pd * dD;
          for (double side : {-xf, xf}) {
            const double rho = std::fabs(R) - sg * side, disc = B * B - A * (px * px + pd * pd - rho * rho);
            if (!(rho > 0 && disc >= 0)) continue;
            for (const double t : {(-B - std::sqrt(disc)) / A, (-B + std::sqrt(disc)) / A}) {
              const double Y = h + t * dY, D = D0 + t * dD;
              if (!(t > 0 && t < best && Y >= 0 && Y <= 12 && D > o.curve_start_D_m)) continue;
              double e, a;
              synthetic_street_coordinates(o, X0 + t * dX, D, &e, &a);
              if (a < 3 || a > 200) continue;
              best = t; hit = -3; facade = true; facade_a = a;
              break;
            }
          }
        }
      }
      for (size_t b = 0; b < o.boxes.size(); ++b) {
        const SyntheticBox& B = o.boxes[b];
        // A turned box: the ray in the box's own frame (its front face's centre the origin, its
        // length along +D), as Pose2::to_frame; an unturned one in the street's, as before.
        double bX0 = X0, bD0 = D0, bdX = dX, bdD = dD, bX = B.X_m, bD = B.D_m;
        if (B.yaw_rad != 0) {
          const double cb = std::cos(B.yaw_rad), sb = std::sin(B.yaw_rad), ox = X0 - B.X_m, od = D0 - B.D_m;
          bX0 = ox * cb - od * sb;
          bD0 = ox * sb + od * cb;
          bdX = dX * cb - dD * sb;
          bdD = dX * sb + dD * cb;
          bX = bD = 0;
        }
        auto inside = [&](double t, int face) {
          const double X = bX0 + t * bdX, Y = h + t * dY, D = bD0 + t * bdD;
          if (Y < B.base_m || Y > B.height_m) return false;
          if (face == 0) return std::fabs(X - bX) <= B.width_m / 2;
          if (face == 2) return std::fabs(X - bX) <= B.width_m / 2 && D >= bD && D <= bD + B.length_m;
          return D >= bD && D <= bD + B.length_m;
        };
        if (B.base_m > 0 && dY > 0) {  // the underside of a floating box, seen from below
          const double t = (B.base_m - h) / dY;
          if (t > 0 && t < best && inside(t, 2)) { best = t; hit = static_cast<int>(b); front = false; }
        }
        if (bdD > 0) {
          const double t = (bD - bD0) / bdD;
          if (t > 0 && t < best && inside(t, 0)) { best = t; hit = static_cast<int>(b); front = true; }
        }
        for (double side : {bX - B.width_m / 2, bX + B.width_m / 2})
          if (bdX != 0) {
            const double t = (side - bX0) / bdX;
            if (t > 0 && t < best && inside(t, 1)) { best = t; hit = static_cast<int>(b); front = false; }
          }
      }
      float* px = &s.day_linear_srgb.at(x, y, 0);
      Label l = Label::Sky;
      if (hit == -2) {
        const double X = X0 + best * dX, D = D0 + best * dD;
        // Across and along the street (X and D where it is straight).
        double e = X, along = D;
        if (curved) synthetic_street_coordinates(o, X, D, &e, &along);
        const double ax = std::fabs(e);
        const bool check = (static_cast<int>(std::floor(X)) + static_cast<int>(std::floor(D))) & 1;
        const float tex = check ? 1.1f : 0.9f;
        if (ax <= o.road_half_width_m) {
          l = Label::Road;
          const bool dash = std::fabs(ax - o.lane_width_m / 2) <= 0.075 && std::fmod(along, o.dash_period_m) < o.dash_m;
          const bool edge = std::fabs(ax - (o.road_half_width_m - 0.2)) <= 0.075;
          bool rail = false;
          for (const double rx : o.rail_X_m) rail = rail || std::fabs(e - rx) <= o.rail_head_m / 2;
          const float v = dash || edge ? 0.8f : rail ? 0.5f : 0.08f * tex;
          px[0] = px[1] = px[2] = v;
        } else if (ax <= o.road_half_width_m + o.sidewalk_m) {
          l = Label::Sidewalk;
          px[0] = px[1] = px[2] = 0.2f * tex;
        } else {
          l = Label::Terrain;
          px[0] = 0.06f * tex; px[1] = 0.1f * tex; px[2] = 0.03f * tex;
        }
        s.depth_m.at(x, y) = static_cast<float>(best);
      } else if (facade && hit == -3) {
        l = Label::Building;
        px[0] = 0.25f; px[1] = 0.22f; px[2] = 0.2f;
        if (o.window_pitch_m > 0) {
          const double D = std::isnan(facade_a) ? D0 + best * dD : facade_a, Y = h + best * dY;
          const double u = D - o.window_phase_m + 0.5 * o.window_width_m;
          const double v = Y - o.window_sill_m;
          if (u - std::floor(u / o.window_pitch_m) * o.window_pitch_m < o.window_width_m && v >= 0 &&
              v - std::floor(v / o.window_storey_m) * o.window_storey_m < o.window_height_m)
            px[0] = px[1] = px[2] = 0.04f;
        }
        s.depth_m.at(x, y) = static_cast<float>(best);
      } else if (hit >= 0) {
        l = o.boxes[hit].label;
        if (is_vehicle(static_cast<int>(l))) s.labels.instances.at(x, y) = static_cast<uint16_t>(static_cast<int>(l) * 1000 + hit);
        px[0] = front ? 0.3f : 0.2f; px[1] = 0.05f; px[2] = 0.05f;
        s.depth_m.at(x, y) = static_cast<float>(best);
        s.box_front.at(x, y) = front;
      } else {
        px[0] = 0.5f; px[1] = 0.6f; px[2] = 0.8f;
      }
      s.labels.ids.at(x, y) = static_cast<uint16_t>(l);
    }
  return s;
}

}  // namespace photosite::scene
