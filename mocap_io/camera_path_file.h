// Camera path files: a CameraPath (skeleton/camera.h) as JSON, for renderers and for importing a
// camera trajectory made elsewhere.
//
//   {
//     "format": "odyssey camera path", "version": 1,
//     "kind": "ego-head", "fps": 30, "frame_count": T,
//     "conventions": "...",      // world Z up, metres; OpenCV camera axes; K in pixels
//     "frames": [ { "frame": 0, "time": 0.0,
//                   "width": 960, "height": 540,
//                   "intrinsics": [[fx,0,cx],[0,fy,cy],[0,0,1]],
//                   "extrinsics": [[r00,r01,r02,t0],[...],[...],[0,0,0,1]],   // world -> camera
//                   "centre": [x, y, z] }, ... ]
//   }
//
// Reading accepts exactly this layout (centre and time are informative and ignored) and checks
// every value; the rotation part of each extrinsics must be a proper rotation within 1e-6.
#pragma once

#include <string>

#include "skeleton/camera.h"

namespace odyssey::io {

// Written under a temporary name and renamed. Throws InputError naming `path` when it cannot be
// written, std::invalid_argument when the path does not validate (CameraPath::validate).
void write_camera_path_json(const std::string& path, const CameraPath& camera);

// Throws InputError naming `path` and the problem (not JSON, a missing or mistyped key, a frame
// with the wrong shape, a non-finite value, an improper rotation, no frames).
CameraPath read_camera_path_json(const std::string& path);

}  // namespace odyssey::io
