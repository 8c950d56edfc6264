// Camera rigs: what moves a camera through a clip. Each rig produces a CameraPath
// (skeleton/camera.h): one world->camera pose (OpenCV axes) and one set of intrinsics per frame.
//
// - Static: a fixed centre looking at a fixed target, image up towards +z.
// - Orbit: circles a vertical axis through the target at a fixed radius and height, looking at the
//   target; at time t = f / fps the camera centre is
//     c(t) = (target.x + r cos(a(t)), target.y + r sin(a(t)), height),
//     a(t) = start_angle + 2 pi t / period   (counter-clockwise seen from above; a negative period
//                                            turns clockwise).
// - Ego-head: rides on a character's head joint. The head's forward and up directions are fixed in
//   the head joint's local axes from the rest pose: at rest the character faces
//     forward_rest = normalise((p_left_hip - p_right_hip) x z)
//   (z up; the left hip is on the character's left), and up_rest = z; with R_h the head joint's
//   rest world rotation, the head-local axes are f_h = R_h^T forward_rest, u_h = R_h^T up_rest.
//   At frame t, with the head's world transform [R(t) | p(t)]:
//     centre(t)  = p(t) + R(t) (forward_offset f_h + up_offset u_h)
//     forward(t) = R(t) f_h,  image up as close to R(t) u_h as forward allows
//   (CameraPose::from_forward_up), so the camera looks along the head's forward axis on every
//   frame and turns with the head.
//   Smoothing (off by default, smoothing_sigma_s = 0) removes head shake above a few Hz: a
//   zero-phase Gaussian filter over time with standard deviation sigma seconds, truncated at
//   3 sigma, applied to the centre (each coordinate) and to the orientation (the quaternions of the
//   frames in the window, each sign-aligned to the centre frame's, averaged with the same weights
//   and normalised). At the ends of the clip the window is cut and its weights renormalised, so a
//   constant or straight-line motion passes through the interior unchanged. The Gaussian's
//   frequency response is exp(-(2 pi f sigma)^2 / 2): sigma = 0.05 s halves 3.7 Hz and keeps
//   98% of 1 Hz.
//
// Errors: std::invalid_argument naming the option (non-finite values, radius <= 0, period 0,
// frames < 1, fps <= 0, centre on the target, a view straight along the up axis, a negative
// sigma, a head or hip joint outside the skeleton, hips that coincide or lie along z).
#pragma once

#include <Eigen/Core>

#include "retarget/bone_map.h"
#include "skeleton/camera.h"
#include "skeleton/clip.h"

namespace odyssey::scene {

struct StaticCameraOptions {
  Eigen::Vector3d centre = Eigen::Vector3d(0, -4, 1.5);
  Eigen::Vector3d target = Eigen::Vector3d(0, 0, 1);
};

struct OrbitCameraOptions {
  Eigen::Vector3d target = Eigen::Vector3d(0, 0, 1);  // the orbit's axis passes through it
  double radius = 4;                                   // metres, > 0
  double height = 1.5;                                 // camera z, metres
  double period_s = 10;                                // one turn; negative: clockwise
  double start_angle_deg = -90;                        // -90: starts on -y, looking along +y
};

struct EgoHeadOptions {
  double forward_offset = 0.1;  // metres along the head's forward axis (the eyes sit in front of the head joint)
  double up_offset = 0.08;      // metres along the head's up axis
  double smoothing_sigma_s = 0; // 0: off
};

// The head's forward and up directions in the head joint's local axes.
struct HeadFrame {
  Eigen::Vector3d forward_local = Eigen::Vector3d::UnitY();
  Eigen::Vector3d up_local = Eigen::Vector3d::UnitZ();
};

CameraPath static_camera_path(int frames, double fps, const PinholeIntrinsics& intrinsics,
                              const StaticCameraOptions& options);
CameraPath orbit_camera_path(int frames, double fps, const PinholeIntrinsics& intrinsics,
                             const OrbitCameraOptions& options);

// The direction the skeleton faces at rest, forward_rest above (unit, horizontal).
Eigen::Vector3d rest_facing(const Skeleton& skeleton, int left_hip, int right_hip);

// From the skeleton's rest pose, as above.
HeadFrame head_frame_from_rest(const Skeleton& skeleton, int head, int left_hip, int right_hip);

CameraPath ego_head_camera_path(const Clip& clip, int head, const HeadFrame& head_frame,
                                const PinholeIntrinsics& intrinsics, const EgoHeadOptions& options);
// The same on a retargeted clip, its head and hips taken from the character's bone map. Throws
// std::invalid_argument when the map has no head or hips.
CameraPath ego_head_camera_path(const Clip& clip, const retarget::BoneMap& map, const PinholeIntrinsics& intrinsics,
                                const EgoHeadOptions& options);

}  // namespace odyssey::scene
