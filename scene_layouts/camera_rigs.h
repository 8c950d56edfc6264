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
// Cinematic rigs. They run over the whole shot: with u = f / (frames - 1) (0 for a one-frame
// shot) and the ease s(u) = (1 - cos(pi u)) / 2, which starts and stops at zero speed and has
// s(0) = 0, s(1/2) = 1/2, s(1) = 1:
// - Swoop: a crane arc. It circles the target at a fixed horizontal radius while rising or falling:
//     a(u) = start_angle + sweep s(u),  height(u) = start_height + (end_height - start_height) s(u)
//     c(u) = (target.x + r cos a(u), target.y + r sin a(u), height(u)), looking at the target.
// - Dolly-zoom: the camera moves along its view axis towards or away from the target while its
//   focal length follows the distance, so a subject at the target keeps its image size:
//     v = normalise(target - start_centre), d0 = |target - start_centre|,
//     d(u) = d0 + (end_distance - d0) s(u),  c(u) = target - d(u) v,
//     fx(u) = fx0 d(u) / d0, fy(u) = fy0 d(u) / d0   (f(u) / d(u) constant; principal point fixed).
// - Zoom: a fixed camera whose focal length changes geometrically (a constant rate of zoom as the
//   eye sees it), from the intrinsics' fx0 to fx1 of the end field of view:
//     fx(u) = fx0 (fx1 / fx0)^s(u), fy(u) = fy0 (fx1 / fx0)^s(u)   (the pixel aspect kept).
// - Handheld shake, applied on top of any path: six band-limited signals, three offsets of the
//   centre along the camera's own axes (metres) and three small turns about them (degrees),
//     x_k(t) = A_k (1/N) sum_i sin(2 pi nu_ki t + phi_ki),  N = 8,
//   with frequencies nu uniform in [low_hz, high_hz] and phases uniform in [0, 2 pi), drawn from
//   the seed (splitmix64, portable). So |x_k(t)| <= A_k on every frame, the spectrum holds only
//   the band's frequencies, and a seed always gives the same shake. With the turn
//   D = Rx(x_4) Ry(x_5) Rz(x_6) and the offset e = (x_1, x_2, x_3) in camera axes:
//     R' = D R,  c' = c + R^T e.
//   The band must lie below the Nyquist rate fps / 2.
//
// Errors: std::invalid_argument naming the option (non-finite values, radius <= 0, period 0,
// frames < 1, fps <= 0, centre on the target, a view straight along the up axis, a negative
// sigma, a head or hip joint outside the skeleton, hips that coincide or lie along z, an end
// distance or field of view out of range, a negative amplitude, a band not within (0, fps / 2)).
#pragma once

#include <Eigen/Core>
#include <cstdint>

#include "retarget/bone_map.h"
#include "skeleton/camera.h"
#include "scene_layouts/timed_clip.h"
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

struct SwoopCameraOptions {
  Eigen::Vector3d target = Eigen::Vector3d(0, 0, 1);
  double radius = 4;                                   // horizontal, metres, > 0
  double start_height = 0.5, end_height = 3;           // camera z at the first and last frame
  double start_angle_deg = -90;                        // as the orbit's
  double sweep_deg = 90;                               // turned over the shot; negative: clockwise
};

struct DollyZoomOptions {
  Eigen::Vector3d start_centre = Eigen::Vector3d(0, -4, 1.5);
  Eigen::Vector3d target = Eigen::Vector3d(0, 0, 1);  // the subject; its image size stays constant
  double end_distance = 2;                             // from the target at the last frame, > 0
};

struct ZoomCameraOptions {
  Eigen::Vector3d centre = Eigen::Vector3d(0, -4, 1.5);
  Eigen::Vector3d target = Eigen::Vector3d(0, 0, 1);
  double end_hfov_deg = 40;                            // horizontal field of view at the last frame
};

struct HandheldOptions {
  double amplitude_m = 0.01;      // bound on each offset of the centre along the camera's axes
  double rotation_deg = 0.5;      // bound on each turn about the camera's axes
  double low_hz = 0.5, high_hz = 3;  // the band the shake's frequencies are drawn from
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

// `intrinsics` are the first frame's; dolly-zoom and zoom change them per frame.
CameraPath swoop_camera_path(int frames, double fps, const PinholeIntrinsics& intrinsics,
                             const SwoopCameraOptions& options);
CameraPath dolly_zoom_camera_path(int frames, double fps, const PinholeIntrinsics& intrinsics,
                                  const DollyZoomOptions& options);
CameraPath zoom_camera_path(int frames, double fps, const PinholeIntrinsics& intrinsics,
                            const ZoomCameraOptions& options);
// Shakes `path` in place, drawn from (seed, stream) as in the header.
void apply_handheld(CameraPath& path, const HandheldOptions& options, std::uint64_t seed, std::uint64_t stream);

// The direction the skeleton faces at rest, forward_rest above (unit, horizontal).
Eigen::Vector3d rest_facing(const Skeleton& skeleton, int left_hip, int right_hip);

// From the skeleton's rest pose, as above.
HeadFrame head_frame_from_rest(const Skeleton& skeleton, int head, int left_hip, int right_hip);

CameraPath ego_head_camera_path(const TimedClip& clip, int head, const HeadFrame& head_frame,
                                const PinholeIntrinsics& intrinsics, const EgoHeadOptions& options);
// The same on a retargeted clip, its head and hips taken from the character's bone map. Throws
// std::invalid_argument when the map has no head or hips.
CameraPath ego_head_camera_path(const TimedClip& clip, const retarget::BoneMap& map, const PinholeIntrinsics& intrinsics,
                                const EgoHeadOptions& options);

}  // namespace odyssey::scene
