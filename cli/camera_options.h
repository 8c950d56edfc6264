// The camera options of the commands that see a character through a camera (trajectories, and
// retarget for a camera node in the GLB), turned into a CameraPath over the retargeted clip.
//
// Defaults follow the character and its motion, so that a 5 cm figure and a 50 m one are framed
// alike. With h the character's rest height, m the mean horizontal position of its root over the
// clip and e the radius of the root's horizontal path around m:
//   target    (m.x, m.y, 0.55 h)
//   distance  d = 2.5 h + e
//   static    centre = target + d f, at height 0.9 h, f the direction the character faces at rest
//   orbit     radius d, height 0.9 h, period 10 s, starting in front of the character (on f)
//   ego-head  eye offsets 0.06 h forward and 0.047 h up (10 cm and 8 cm on a 1.7 m figure)
#pragma once

#include <optional>

#include "cli/args.h"
#include "retarget/bone_map.h"
#include "skeleton/camera.h"
#include "skeleton/character.h"
#include "skeleton/clip.h"

namespace odyssey::cli {

// --camera, --width, --height, --hfov, --camera-position, --camera-target, --camera-radius,
// --camera-height, --camera-period, --eye-forward, --eye-up, --camera-smooth, --camera-file.
// `default_kind`: "none" where a camera is optional, else the default rig.
void add_camera_options(Args& args, const std::string& default_kind);

// The path the options ask for over `clip` (the character's retargeted motion, on its skeleton),
// or none for --camera none. Throws UsageError for malformed options, InputError for a bad
// --camera-file.
std::optional<CameraPath> camera_path_from_options(const Args& args, const Character& character,
                                                   const retarget::BoneMap& target_map, const Clip& clip);

}  // namespace odyssey::cli
