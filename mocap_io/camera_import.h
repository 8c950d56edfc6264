// Camera trajectories recovered from real video by structure from motion, as the files ship them.
// Both formats hold world->camera poses with OpenCV camera axes (x right, y down, z forward) in
// the reconstruction's own world: arbitrary axes (no known up) and arbitrary scale. Placing such a
// track in a scene (levelling, rescaling, resampling) is scene_layouts/imported_camera.h's job;
// these readers only read and check.
//
// RealEstate10K / Mannequin Challenge (one text file per clip):
//   line 1:   the video's URL (ignored)
//   line k>1: timestamp_us fx fy cx cy 0 0 r00 r01 r02 t0 r10 r11 r12 t1 r20 r21 r22 t2
//             19 numbers: the timestamp in microseconds, the intrinsics normalised by the image
//             size (fx/W, fy/H, cx/W, cy/H), two unused numbers, then the row-major 3x4
//             world-to-camera matrix [R | t]. Blank lines are skipped.
//
// COLMAP text model (a folder, or any file in it):
//   cameras.txt  CAMERA_ID MODEL WIDTH HEIGHT PARAMS...   with the models
//                SIMPLE_PINHOLE f cx cy | PINHOLE fx fy cx cy | SIMPLE_RADIAL f cx cy k |
//                OPENCV fx fy cx cy k1 k2 p1 p2
//   images.txt   two lines per image: IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME, then its 2D
//                points (ignored; may be empty, and may be missing after the last image)
//   The quaternion is Hamilton's (w first) and with T maps world to camera: x_cam = R(q) x + T.
//   COLMAP's pixel (0, 0) covers [0, 1)^2 like the toolkit's, so cx, cy need no half-pixel shift.
//   Lens distortion (k, k1, k2, p1, p2) is not applied: the frames keep the pinhole part and the
//   track's notes say which cameras had a non-zero distortion. COLMAP has no timestamps: the
//   images are ordered by NAME (runs of digits compared as numbers, so frame9 comes before
//   frame10) and image k is at time k / fps.
//
// Checks (an io::InputError naming the file, the line and the problem): a line with too few or
// too many numbers or a value that is not a finite number, a 3x3 part that is not a rotation
// (|R^T R - I| above 1e-4 or det R < 0), a quaternion whose norm is off 1 by more than 1e-3,
// timestamps that do not strictly increase (RealEstate10K), a zero or negative focal length or
// image size, an unknown camera model or a camera id no camera has (COLMAP), repeated image ids,
// names or camera ids, and a file with no frames. Rotations within tolerance are snapped to the
// nearest rotation (through a normalised quaternion).
#pragma once

#include <string>
#include <vector>

#include "skeleton/camera.h"

namespace odyssey::io {

struct CameraTrackFrame {
  double time_s = 0;   // seconds from the file's own origin
  CameraPose pose;     // world -> camera, OpenCV axes, in the reconstruction's world and units
  // Intrinsics normalised by the image size: fx/W, fy/H, cx/W, cy/H.
  double fx = 1, fy = 1, cx = 0.5, cy = 0.5;
};

struct CameraTrack {
  std::string path;                       // the file (or COLMAP folder) read
  std::string format;                     // "realestate10k" or "colmap"
  std::vector<CameraTrackFrame> frames;   // times strictly increasing
  std::vector<std::string> notes;         // what was read but is not used, one line each
};

CameraTrack read_realestate10k(const std::string& path);

// `path`: the model's folder or one of its files. `fps`: the rate the images were taken at.
// Throws std::invalid_argument when fps is not positive and finite.
CameraTrack read_colmap_text(const std::string& path, double fps);

}  // namespace odyssey::io
