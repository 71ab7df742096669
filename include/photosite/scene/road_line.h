// A road's line on the ground, in pieces (straight lines and circular arcs), and the road ahead of
// a frame measured from its kerbs (scene/road_line.cpp).
//
// The street luminaires stand in rows along the road edges (plan_street_lighting, scene/street.cpp;
// LuminaireSet, scene/luminaires.h). Where the road bends, rows continued straight ahead leave it by
// d²/(2R) at d ahead: 8 m at 40 m on a 100 m radius, luminaires standing in the façades or across
// the road. Both place their rows along a road line made of these pieces.
#pragma once
#include <array>
#include <string>
#include <vector>

#include "photosite/scene/night.h"

namespace photosite::scene {

// One piece of a road line: from the ground point (X0, D0) heading psi0 (CameraPose's yaw
// convention: radians from +D, positive toward +X), curvature kappa (1/m, positive turning toward
// +X; 0 straight), along-line coordinate (arc length) a0 there and len_m long (the last piece of a
// line is continued beyond its end), with the road edges across the line (m, + to the right) that
// apply on it.
struct RoadPiece { double X0, D0, psi0, kappa, a0, len_m, left_m, right_m; };

// The ground point at along-line coordinate a on piece q (its line or circle continued beyond its
// ends), offset across the line (to the right) by off1 + off2, each added on its own (see
// road_line.cpp for the roundings a straight piece keeps).
void road_piece_point(const RoadPiece& q, double a, double off1, double off2, double* X, double* D);
// The piece that starts where q ends (q's point and heading at its end), of curvature kappa and
// len_m long, with the road edges left_m, right_m.
RoadPiece road_piece_after(const RoadPiece& q, double kappa, double len_m, double left_m, double right_m);
// A ground point's along-line coordinate *a and offset across the line *off (+ right) on piece q
// (continued beyond its ends): the inverse of road_piece_point. On an arc the angle is taken
// within half a turn of the piece's middle.
void road_piece_project(const RoadPiece& q, double X, double D, double* a, double* off);

// The road ahead of one frame, measured from its kerbs (measure_road_ahead): the road line through
// the camera's foot, heading heading_rad from the camera's axis (toward +X positive), straight for
// curve_start_m, then a circular arc of curvature kappa_per_m (+ turning toward +X); the kerbs at
// left_m and right_m across it. Frame road coordinates (X across, D along the camera's axis on the
// ground).
struct RoadAhead {
  // "curved": the arc's curvature is told from a straight road (see measure_road_ahead); "straight":
  // kerbs were measured and a straight road fits them as well; else why nothing was measured.
  std::string state = "not measured";
  bool curved = false;
  double heading_rad = 0, curve_start_m = 0, kappa_per_m = 0;
  // The curvature's standard error (1/m) from the fit's residuals (kept also when straight: a
  // straight fit's curvature and its error say how far a bend can be ruled out).
  double kappa_se_per_m = 0, kappa_fit_per_m = 0;
  double left_m = 0, right_m = 0;  // kerb offsets across the line at the camera
  double reach_m = 0;              // along-line distance of the farthest kerb point used
  int points = 0;                  // kerb points the fit kept (of both kerbs)
  double residual_rms_m = 0;       // their rms offset from the fitted kerbs
  // The covariance of the fitted (left_m, right_m, heading_rad, kappa_per_m), row-major (the
  // curvature's row and column 0 when straight): the weighted least squares' (JᵀWJ)⁻¹ times the
  // residuals' robust scale². Zero when not measured.
  std::array<double, 16> covariance{};
  // In a sequence (LuminaireSet::update, scene/luminaires.h): where this frame's bend starts at the
  // camera (curve_start_m ≤ kBendAtCameraM), how far behind the camera the vehicle has already
  // been turning the bend's way along the road line it drove; the signs' facing (SignFacing)
  // continues the arc back that far. 0 in a single frame, which does not see the road behind.
  double turning_behind_m = 0;
};
// A fitted bend that starts this close to the camera has the camera on it: the fit's starts are
// tried on a 5 m grid from 0, then to the metre within 2 m of the best (measure_road_ahead), so a
// camera on the arc is fitted a start of 0 to 2 m.
inline constexpr double kBendAtCameraM = 2;
// The standard error (m) of the fitted kerb's position across the road line at along-line
// distance a_m from the camera (the right kerb or the left), from `covariance` (small angles).
// It leaves out the curve start's own error (the start is chosen on a 1 m grid: see
// measure_road_ahead).
double road_ahead_kerb_se_m(const RoadAhead& r, double a_m, bool right);
// The kerbs of the carriageway the camera drives along, from the labels: each ground row with
// depth D in [min_D_m, max_D_m] (10 and 100 m) is scanned outward from where the road was the row
// before (the principal column on the nearest), over road and vehicles, to the first other pixel;
// an end on road (not on a vehicle hiding the kerb) and not at the image border is a kerb point.
// The road line is fitted to both kerbs at once (one line, each kerb at its own offset), for every
// curve start on a 5 m grid, then to the metre about the best, robustly (Tukey's biweight, so a
// junction's mouth or a driveway does not bend it), and the best is "curved" when its curvature is
// at least 5 standard errors from 0 and bends the line by at least half a metre from straight at the
// farthest kerb point used.
RoadAhead measure_road_ahead(const ImageU16& labels, const CameraGeometry& g);

// The run of carriageway (road, or a vehicle standing on it) through column x of row y of the
// label ids, as [*x0, *x1] (x itself is taken to be on it): where plan_street_lighting and
// measure_road_ahead find a row's kerbs.
void carriageway_run(const ImageU16& ids, int x, int y, int* x0, int* x1);
// Appends to `line` the arc of curvature kappa from its last piece's end for a quarter turn, then
// a straight piece on from there (the road ahead beyond a measured bend's start), with the road
// edges left_m, right_m.
void road_append_quarter_turn(std::vector<RoadPiece>* line, double kappa, double left_m, double right_m);
// The pieces of a frame's road line as `r` measured it, from the camera's foot: straight to the
// curve's start, the arc for at most a quarter turn, then straight on (the extrapolation
// LuminaireSet uses beyond its road line). Straight (one piece) unless r.curved.
std::vector<RoadPiece> road_ahead_pieces(const RoadAhead& r);
// The piece of road line `line` (pieces in order of a0, each starting where the one before ends)
// that carries along-line coordinate a: the last one starting at or before it; before the line,
// the first continued straight back along its heading; beyond the last piece's end, that piece
// continued: an arc for at most a quarter turn, straight on after it.
RoadPiece road_line_piece(const std::vector<RoadPiece>& line, double a);
// A ground point's along-line coordinate *a and offset across (+ right) on road line `line`, and
// the piece *on it was taken on: each piece's projection within its range (the first continued
// back, the last on), the one nearest across; in no piece's range (beside a kink), the last's.
void road_line_project(const std::vector<RoadPiece>& line, double X, double D, double* a, double* off, RoadPiece* on);

}  // namespace photosite::scene
