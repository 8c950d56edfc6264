// A camera track recovered from real video (mocap_io/camera_import.h: RealEstate10K, COLMAP) made
// into a CameraPath of a scene: levelled to the toolkit's Z up, resampled to the scene's frames,
// rescaled and placed about the actors, optionally re-aimed at them.
//
// 1. Up. A reconstruction's world has no known up. It is estimated as the mean of the cameras'
//    image-up axes, u = normalise(sum_k -R_k^T e_y) (OpenCV y points down in the image), unless
//    given. People hold cameras upright, so rolls average out; a camera that pitches the same way
//    throughout makes u lean with it, and such a path comes out level. L is the smallest rotation
//    taking u to +z.
// 2. Time. Output frame f is at track time tau = t_0 + speed f / fps. Between the track's frames
//    k and k+1, with w = (tau - t_k) / (t_{k+1} - t_k): the orientation is slerp(q_k, q_{k+1}, w),
//    the centre (1 - w) c_k + w c_{k+1}, and the normalised intrinsics interpolate linearly too.
//    Frames after the track's end hold its last camera (a note says how many).
// 3. Placement. With the resampled centres levelled by L, m their anchor (horizontal) and r the
//    largest horizontal distance of one from m, the track's world maps to the scene's by
//      x' = s Y L x + T,  s = (extent / 2) / r,
//    Y the turn about z that points the direction from m to the first centre at start_angle (when
//    the first centre is at m: the first camera's horizontal view at start_angle + 180 degrees),
//    and T putting m at `centre` and the centres' mean height at `height`. So the path fits a
//    circle of diameter `extent` about `centre`, touching it. The anchor m is the centres' mean
//    (centroid: for walk-throughs, whose middle then passes the actors) or the focus, the point
//    nearest all the cameras' view axes in the least-squares sense (for captures that circle
//    their subject, as COLMAP's and the Mannequin Challenge's do: the actors take the subject's
//    place). Axes too close to parallel to meet are an error. A camera becomes
//      c' = s Y L c + T,  R' = R (Y L)^T
//    (scaling the world moves the centres only; turning it turns the cameras with it).
// 4. Aim (when look-at points are given). Each camera is turned to look at its frame's look-at
//    point, smoothed over time by a zero-phase Gaussian of sigma aim_smoothing_s seconds (cut at
//    3 sigma and at the shot's ends, weights renormalised), with image up as close to its placed
//    image up as the new view allows (CameraPose::from_forward_up), so a recorded roll survives.
// Intrinsics: the normalised values times the output image, fx = fx_n W, fy = fy_n H, cx = cx_n W,
// cy = cy_n H. When W:H differs from the source's aspect the pixels come out non-square, and a
// note says so.
//
// Errors: io::InputError naming the track's file when its cameras' up axes cancel out, it does
// not move horizontally during the shot (nothing to rescale) or, anchored on the focus, its view
// axes are nearly parallel (the least-squares system's smallest eigenvalue under 1e-3 per
// frame, about 1.8 degrees of spread); std::invalid_argument naming the
// option for bad options, and naming the frame when a camera sits on its look-at point.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "mocap_io/camera_import.h"
#include "skeleton/camera.h"

namespace odyssey::scene {

struct ImportedCameraOptions {
  enum class Anchor { centroid, focus };
  int width = 960, height = 540;                      // the output image
  Anchor anchor = Anchor::centroid;                   // the point of the path put on `centre`
  double extent_m = 8;                                // diameter of the circle the path fits, > 0
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();   // where the path's horizontal mean goes
  double height_m = 1.5;                              // the centres' mean height
  double start_angle_deg = -90;                       // direction from the centre to the first camera
  double speed = 1;                                   // track seconds per scene second, > 0
  std::optional<Eigen::Vector3d> up;                  // in the track's world; default: estimated
  std::vector<Eigen::Vector3d> look_at;               // empty, or one point per frame to aim at
  double aim_smoothing_s = 1;                         // sigma of the look-at smoothing, >= 0
};

// The up direction of step 1, in the track's world (unit).
Eigen::Vector3d estimate_up(const io::CameraTrack& track);

// `notes` (when given) receives the track's own notes and this step's (held frames, non-square
// pixels), one line each.
CameraPath imported_camera_path(const io::CameraTrack& track, int frames, double fps, const ImportedCameraOptions& options,
                                std::vector<std::string>* notes = nullptr);

}  // namespace odyssey::scene
