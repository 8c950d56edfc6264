// The options of every command that drives a character with a motion (retarget, trajectories,
// point-cache), parsed the same way into one scene::RetargetRequest, and the lines printed while
// scene::retarget_actor runs: the motion, the character, the map used (before the retargeting
// starts, so that it is on screen when that fails), scale, alignment, contacts and metrics.
#pragma once

#include "cli/args.h"
#include "scene_layouts/actor.h"

namespace odyssey::cli {

// Declares --motion, --character, --quality, --parts, --threads, --fps, --map, --source-map,
// --model, --source-rest, --weights and --bvh-units.
void add_retarget_options(Args& args);

// The same without --motion and --character (the batch's settings for every job).
void add_retarget_settings(Args& args);

// Throws UsageError for a malformed value.
scene::RetargetRequest retarget_request_from(const Args& args);
// From add_retarget_settings' options; an empty motion skips the checks that need its format.
scene::RetargetRequest retarget_settings_from(const Args& args, const std::string& motion, const std::string& character);

// Prints each stage of retarget_actor (and of the scene pipeline) as it ends.
void print_progress(const scene::ProgressEvent& event);

}  // namespace odyssey::cli
