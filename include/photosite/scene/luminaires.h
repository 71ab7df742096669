// Street luminaires carried from frame to frame of a sequence, in world coordinates
// (scene/luminaires.cpp), and the rest of a sequence's scene state (issue 14 §3: lights stay put
// when the camera moves).
//
// A single frame infers its street lighting from what it shows (plan_street_lighting): the
// luminaire on a labelled pole, the road-edge layout anchored to the camera. Over a sequence that
// makes a lamp vanish when its pole leaves the view, though its light still falls on what is in
// view. A LuminaireSet keeps, in world coordinates (the road coordinates of the sequence's first
// frame), the road-edge layout along the road the vehicle drives (fixed where driven) and every
// pole luminaire seen, while its light can still reach the view.
#pragma once
#include <cmath>
#include <cstdint>
#include <vector>

#include "photosite/scene/night.h"
#include "photosite/scene/road_line.h"
#include "photosite/scene/street.h"

namespace photosite::scene {

class LuminaireSet {
 public:
  // A pole luminaire in world coordinates; seen_m: the horizontal distance from the camera of the
  // observation its position comes from (the nearest so far: a pole's ground contact is located
  // better from nearer).
  struct Lamp { double X_m, Y_m, D_m, seen_m; };

  // The street lighting of one frame of the sequence, from this frame's own plan `frame_plan`
  // (plan_street_lighting with the frame's geometry `g`, width x height pixels, run seed `seed`)
  // and the frame's pose:
  //  * the road-edge layout runs along a road line, from the first frame whose plan has a road
  //    extent: at along-line distance (arc length) a, the right row at phase + k·S and the left
  //    row S/2 further, each offset across the line by its road edge and the setback. The line
  //    starts at that frame's camera along its heading and grows with the vehicle's steps (poses
  //    at least 1 m apart, each an arc turning by the two yaws' difference: advance_pose's): it
  //    turns as a step does where the frame's kerbs show the road bending that way (their shift
  //    from the line continued straight, seen from the camera's offset and heading; with no kerb
  //    measured, on the odometry alone), else it runs straight on (a lane change, a turn off the
  //    road, a drift across it: the vehicle turns, the road does not). The part driven is fixed,
  //    so a luminaire placed there stays put. Ahead of it the line is extrapolated on its last
  //    piece's curvature (straight after a straight one) up to a quarter turn, then straight —
  //    unless the frame's road ahead measured from its kerbs (StreetLighting::road_ahead,
  //    measure_road_ahead) contradicts that: its kerb at the farthest point measured more than 5
  //    of its standard errors off the extrapolation's. Then the line ahead is the measured one
  //    (straight to the bend's start, the fitted arc for a quarter turn, straight on): a curve is
  //    followed before the vehicle reaches it, and a line still turning after a curve runs
  //    straight once the kerbs do. A luminaire ahead moves when a later frame measures otherwise,
  //    from another pose: at the pose the line ahead was last decided at (a camera at rest, crops of
  //    one view: the same street in view) that decision is kept, not taken anew from the frame's
  //    own measurement (two views of one street can fit a bend differently by more than their
  //    standard errors: crops of aachen_000000 32 px apart, heading −0.025 against −0.253 rad).
  //    The anchoring frame, where its road bends, starts the line along the measured heading with
  //    the fitted kerbs. Behind its start: straight back along it. A straight drive is one straight
  //    piece: the straight rows of a single frame, bit for bit;
  //  * the road edges are the anchoring frame's. A later frame's edges (medians of the kerb 20-60 m
  //    ahead, which move with what is in view and, where the road bends, with the bend; taken
  //    across the line) replace them from the line's end on only once the vehicle has driven 60 m
  //    beyond that frame without turning (the road was straight where they were measured), its
  //    plan having found the road straight ahead (road_straight) and an edge more than half a lane
  //    plus a quarter metre off the kept one (the spread road_straight allows the edge rows, plus
  //    the medians' rounding);
  //  * each pole luminaire of `frame_plan` is matched to a remembered one within
  //    max(1 m, 2 px of ground-contact row at its distance: 2·D²/(f·h)) and replaces it when seen
  //    from nearer, else it is added;
  //  * remembered luminaires stay while their light can reach the view: the distance from their
  //    foot to the horizontal view wedge (X/D between the image borders' (u − c_x)/f, an
  //    approximation that neglects the pitch's few-percent effect on X/D) is at most their reach
  //    (street_lamp_reach_m); others are forgotten;
  //  * each pole replaces the layout's luminaire nearest to it along the line on its side of the
  //    road (across the line) within half a spacing (plan_street_lighting's rule).
  // The result is in the frame's road coordinates, sorted by (D, X); the peak intensity is the
  // plan's (a property of the installation), the EN 13201 field (L_avg, U0) is recomputed on
  // these lamps. The line is kept from three spacings behind the camera on (memory bounded).
  // Deterministic: the same frames in the same order give the same lamps.
  // Before any frame had a road extent: `frame_plan` unchanged.
  StreetLighting update(const StreetLighting& frame_plan, const CameraGeometry& g, int width, int height,
                        const CameraPose& pose, const ScenePreset& p, uint64_t seed);

  const std::vector<Lamp>& poles() const { return poles_; }
  bool anchored() const { return anchored_; }
  // The pieces of the road line kept (each an arc or a straight line).
  size_t path_pieces() const { return path_.size(); }

  // One piece of the road line, in world coordinates (RoadPiece, scene/road_line.h).
  using Piece = RoadPiece;

 private:
  Piece piece_at(double a) const;
  void project(double X_m, double D_m, double* a, double* off, Piece* on) const;
  bool extend_path(const CameraPose& pose, const StreetLighting& plan);  // true: the vehicle turned

  // A frame's road edges (across the line) that differ from the kept ones, at its along-line
  // coordinate a: taken once the vehicle has driven 60 m beyond it without turning.
  struct Pending { double a, left, right; };

  bool anchored_ = false;
  double anchor_a_ = 0, phase_m_ = 0;  // along-line coordinate of the anchoring pose, layout phase
  double node_X_ = 0, node_D_ = 0, node_yaw_ = 0;  // the last pose stepped to
  std::vector<Piece> path_;
  std::vector<Pending> pending_;
  std::vector<Lamp> poles_;
  // The line ahead as last decided (the pieces appended to path_ for it, none where the
  // extrapolation stood) and the pose it was decided at.
  bool ahead_decided_ = false;
  double ahead_X_ = 0, ahead_D_ = 0, ahead_yaw_ = 0;
  std::vector<Piece> ahead_;
};

// The building façades a sequence has seen, in the world, each with the key of its windows' lit
// draws (facade_key, scene/street.h, at its first sighting). facade_key quantises the plane's
// azimuth to 5° and its distance to 5 m, and each frame fits the planes anew: a façade whose fit
// lies near a step's edge would change its key between frames, and every one of its windows would
// be drawn lit or dark anew. keys() gives each of a frame's planes (in the frame's road
// coordinates, the frame at `pose`) the key of the remembered façade it matches — its normal
// within half an azimuth step (2.5°) and its distance from the world's origin within half a
// distance step (2.5 m) of the remembered one's, the nearest in distance — so a plane's key moves
// only when its fit moves by more than half a step; an unmatched plane is remembered with its own
// key. A remembered façade farther than `forget_m` from the camera's foot (the preset's
// max_depth_m: beyond it no pixel is given its depth) is forgotten. Deterministic: the same frames
// in the same order give the same keys.
//
// hold() does the same and also keeps the plane: a fitted plane that matches a remembered fitted
// façade is replaced (its normal and distance; the foot line and flags stay the frame's) by the
// remembered one, carried into the frame, so the façade's depth and its windows stand where
// they stood when it was first fitted. Why: a frame's fit takes its depth from the flat-ground
// model, whose error grows with distance (a horizon δ px off scales depth at D by δ·D/(f·h)), so
// with any error in the pitch the fits of one façade from two poses differ while the odometry
// moves the camera in true metres; the windows laid out on each frame's fit then slid along the
// façade from frame to frame (a vanishing point 0.94 px off the rendered horizon left 93 % of the
// windows' light in place on Luminaires.TurningKeepsTheWindowsOnTheirFacades, < 95 %).
class FacadeSet {
 public:
  std::vector<uint64_t> keys(const std::vector<FacadePlane>& planes, const CameraPose& pose, double forget_m);
  std::vector<uint64_t> hold(std::vector<FacadePlane>* planes, const CameraPose& pose, double forget_m);
  size_t size() const { return seen_.size(); }

 private:
  struct Facade { double nX, nD, d_m; uint64_t key; bool fitted; };  // in the world
  std::vector<Facade> seen_;
};

// The parked vehicles a sequence has seen, in the world, each with its parking lights' draw (on
// or off: vehicle_lamps.parked_lit_fraction, scene/lights.cpp). A frame draws each parked
// vehicle's lights from a key of its own (its instance code, else its ground contact on a 2 m grid
// of the frame's road coordinates): over a sequence whose camera moves, or whose instance codes are
// numbered anew each frame (a segmentation model's), that key changes from frame to frame and the
// parking lights would blink. lit() takes a frame's parked vehicles (their ground contacts in the
// frame at `pose`, and `draw`, the frame's own draw of each) nearest first, and gives each one the
// draw of the nearest remembered vehicle not yet taken in this frame within max(1 m, match_k·r²)
// of it (r the farther of the two sightings' distances; a pixel of contact row is r²/(f·h) at r)
// plus its slack_m (a vehicle cut by the frame: its lowest visible row is not its nearest
// contact, which may lie up to its length away),
// one to one, so that a row of parked cars whose far contacts are located a few metres off is
// not matched each to its neighbour; a matched vehicle's contact is moved to this sighting when
// it is the nearer (a contact is located better from nearer). An unmatched vehicle is remembered
// with its own draw. forget() drops those farther than `forget_m` from the camera's foot.
// Deterministic: the same frames in the same order give the same draws.
class ParkedSet {
 public:
  struct Sighting { double X_m, D_m, slack_m; bool draw; };
  std::vector<char> lit(const std::vector<Sighting>& frame, const CameraPose& pose, double match_k);
  void forget(const CameraPose& pose, double forget_m);
  size_t size() const { return seen_.size(); }

 private:
  struct Vehicle { double X_m, D_m, seen_m; bool lit; };  // in the world; seen_m: its nearest sighting's distance
  std::vector<Vehicle> seen_;
};

// Everything a sequence carries from frame to frame (night_scene's `sequence`). The caller sets
// `pose` before each frame; the rest is filled in as frames are computed.
struct SequenceState {
  CameraPose pose;          // of the frame about to be computed
  LuminaireSet luminaires;  // street lamps in the world
  FacadeSet facades;        // building façades in the world, with their windows' draw keys
  ParkedSet parked;         // parked vehicles in the world, with their parking lights' draws
  ClassMeans reflectance;   // reflectance_texture's class means, fixed when a class is first seen
  // The camera pitch of the first frame (its horizon: the vanishing point's when accepted, else
  // the rig's), kept for the sequence: a camera on a vehicle keeps its mounting pitch, while the
  // per-frame vanishing point jitters with what is in view (crops of one Cityscapes frame 32 px
  // apart: horizon 426 → 444 → 432 px). NaN until the first frame.
  double pitch_rad = NAN;
  int frames = 0;           // frames computed so far
};

}  // namespace photosite::scene
