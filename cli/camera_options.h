// The camera options of the commands that see one character through a camera (trajectories, and
// retarget for a camera node in the GLB), turned into a scene camera; unset positions and targets
// follow the actor's framing (scene_layouts/pipeline.h).
#pragma once

#include <optional>

#include "cli/args.h"
#include "scene_layouts/scene.h"

namespace odyssey::cli {

// --camera, --width, --height, --hfov, --camera-position, --camera-target, --camera-radius,
// --camera-height, --camera-period, --eye-forward, --eye-up, --camera-smooth, --camera-file,
// --camera-height-end, --camera-sweep, --camera-end-distance, --hfov-end, --camera-extent,
// --camera-speed, --camera-fps, --camera-aim, --handheld, --handheld-rotation, --handheld-band.
// `default_kind`: "none" where a camera is optional, else the default rig.
void add_camera_options(Args& args, const std::string& default_kind);

// The camera the options ask for, or none for --camera none. Throws UsageError for malformed
// options.
std::optional<scene::SceneCamera> camera_from_options(const Args& args);

}  // namespace odyssey::cli
