// The camera's motion over a sequence from the data set's own odometry (issue 14 §3: lights stay
// put when the camera moves), read by `batch --sequence` (scene/ego_motion.cpp).
//
// A frame's pose (luminaires.h CameraPose: the camera's foot in the road coordinates of the
// sequence's first frame, its heading) follows from the previous frame's by dead reckoning on the
// vehicle's speed and yaw rate at the two frames' times. The data sets record them as:
//  * Cityscapes (cityscapesScripts README; docs/csCalibration.pdf §3, Schneider & Cordts 2016):
//    vehicle[_sequence]/<split>/<city>/<stem>_vehicle.json with "speed" in m/s and "yawRate" in
//    rad/s in the vehicle frame of ISO 8855 (x forward, y left, z up; its origin on the ground
//    below the rear axle's centre), and timestamp[_sequence]/<split>/<city>/<stem>_timestamp.txt,
//    the time of recording in ns (the first frame of each sequence 0). The camera's place in that
//    frame is its camera file's extrinsic x and y (m), and its heading the extrinsic yaw (rad).
//  * KITTI raw (its devkit's oxts/dataformat.txt): oxts/data/<frame>.txt, 30 numbers a line, of
//    which vf (the 9th: forward velocity parallel to the earth's surface, m/s) and wu (the 23rd:
//    angular rate around the upward axis, rad/s, positive counter-clockwise: to the left), and
//    oxts/timestamps.txt, one "YYYY-MM-DD HH:MM:SS.fffffffff" line per frame. The camera's place
//    and heading on the vehicle come from the drive date's calibration files where given
//    (read_kitti_camera_mount); without them the OXTS unit is taken as the camera's place (its
//    lever arm, about a metre, then not used: the pose's error is that lever times the heading's
//    change since the first frame).
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "photosite/scene/luminaires.h"
#include "photosite/scene/rig.h"

namespace photosite::scene {

// The vehicle's motion at one frame, in the vehicle frame of ISO 8855.
struct OdometrySample {
  int64_t time_ns = 0;        // the frame's time of recording (any origin common to the sequence)
  double speed_m_s = 0;       // along the vehicle's x (forward)
  double yaw_rate_rad_s = 0;  // about its z (up): positive turning left
  // The camera's place in the vehicle frame (m): ahead of and left of the odometry's reference
  // point (Cityscapes: the rear axle's centre; KITTI: the OXTS unit).
  double camera_forward_m = 0, camera_left_m = 0;
  // The camera's heading against the vehicle's (rad, ISO 8855: positive to the left): the road
  // coordinates photosite measures in are the camera's, so the vehicle's run is turned into them.
  double camera_yaw_rad = 0;
};

// Where the camera sits on the vehicle: OdometrySample's camera_forward_m, camera_left_m and
// camera_yaw_rad (ISO 8855: m ahead of and left of the odometry's reference point; rad, positive
// turned to the left). All 0: the camera at the reference point, looking along the vehicle.
struct CameraMount {
  double forward_m = 0, left_m = 0, yaw_rad = 0;
};
// Cityscapes: from the frame's camera file, read as a rig (CameraRig's mount_*: its extrinsic x,
// y, yaw). Bad input (file: extrinsic.KEY: missing) where the file lacks one.
CameraMount cityscapes_camera_mount(const CameraRig& camera);
// KITTI raw: the colour camera 2 (image_2) on the vehicle, from the three calibration files its
// devkit ships per recording date (readme.txt; Geiger et al., IJRR 2013, §IV) in `calib_dir`:
//  * calib_imu_to_velo.txt and calib_velo_to_cam.txt, lines "R: r11 r12 ... r33" (row-major) and
//    "T: t1 t2 t3" (m): the rigid transforms x_velo = R·x_imu + T and x_cam0 = R·x_velo + T;
//  * calib_cam_to_cam.txt, R_rect_00 (3x3: x_rect = R_rect_00·x_cam0) and P_rect_02 (3x4, the
//    projection of rectified coordinates into image 2: K·[I | t], t camera 2's offset from the
//    rectified camera 0, about 6 cm along x).
// The OXTS unit's frame is x forward, y left, z up (oxts/dataformat.txt), the cameras' x right,
// y down, z forward. The camera's centre in the OXTS frame gives forward_m and left_m, the heading
// of its optical axis projected on the OXTS x-y plane yaw_rad. Bad input (file: key: problem) on
// a missing file or line, a line that does not hold 9 (R, R_rect_00), 3 (T) or 12 (P_rect_02)
// numbers, a rotation that is not one within the rounding of the devkit's 7 significant digits,
// a P_rect_02 that is not K·[I | t], and a camera more than 20 m from the OXTS unit or turned
// more than 0.5 rad from the vehicle's heading.
CameraMount read_kitti_camera_mount(const std::string& calib_dir);
inline constexpr const char* kKittiCalibFiles[] = {"calib_imu_to_velo.txt", "calib_velo_to_cam.txt",
                                                   "calib_cam_to_cam.txt"};

// Cityscapes: the frame's vehicle JSON and timestamp file, with the camera's mount (from its
// camera file: cityscapes_camera_mount; none: 0). Bad input (file: key: problem) on a missing or
// non-numeric key, a speed outside [-100, 100] m/s, a yaw rate outside [-5, 5] rad/s (no road
// vehicle: a file of another kind or in other units), a timestamp that is not a whole number of ns.
OdometrySample read_cityscapes_odometry(const std::string& vehicle_json, const std::string& timestamp_txt,
                                        const CameraMount& mount = {});
// KITTI raw: the frame's OXTS line and line `index` (0-based, the frame's number) of the drive's
// timestamps file, with the camera's mount (read_kitti_camera_mount; none: 0). Bad input as above,
// and on a line that does not hold 30 numbers or a timestamps file without that line.
OdometrySample read_kitti_oxts(const std::string& oxts_txt, const std::string& timestamps_txt, long index,
                               const CameraMount& mount = {});
// The same with the drive's timestamps file already read (read_kitti_timestamps of
// timestamps_txt, which names it in messages): a drive's frames read it once, not once each
// (batch: the whole file for each of a drive's n frames was n² lines read).
OdometrySample read_kitti_oxts(const std::string& oxts_txt, const std::string& timestamps_txt,
                               const std::vector<std::string>& timestamps_lines, long index, const CameraMount& mount);
// A KITTI timestamps file's lines (kitti_timestamps_lines of its text); bad input when it cannot be read.
std::vector<std::string> read_kitti_timestamps(const std::string& timestamps_txt);
// A KITTI timestamps file's text as read_kitti_oxts reads its lines: line k (0-based) is frame
// k's, without its '\n' and a trailing '\r' (a file saved with CRLF endings reads the same). batch
// records a frame's line (its resume manifest's odometry_sources) from these.
std::vector<std::string> kitti_timestamps_lines(const std::string& text);
// "YYYY-MM-DD HH:MM:SS[.fraction]" (UTC, up to 9 fraction digits) as ns since 1970 (KITTI's
// timestamps). Bad input naming `where` otherwise.
int64_t parse_kitti_timestamp_ns(const std::string& text, const std::string& where);

// The pose of the frame recorded at b, from the pose of the frame recorded at a (the camera's, with
// the lever arm of b; a and b share it). Between the two the vehicle is taken to move at the mean
// of their speeds and turn at the mean of their yaw rates (an arc: exact for constant speed and
// yaw rate, second-order in the frame interval otherwise). Bad input (`where`: problem) unless b
// is later than a.
CameraPose advance_pose(const CameraPose& pose_a, const OdometrySample& a, const OdometrySample& b,
                        const std::string& where);

}  // namespace photosite::scene
