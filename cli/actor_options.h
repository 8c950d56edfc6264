// The actor sources of the single-actor commands (trajectories, point-cache): a motion retargeted
// onto --character (the retargeting options), the character's own --animation, or an --anime mesh
// (scene_layouts/actor_source.h), with the playback options the last two take.
#pragma once

#include "cli/args.h"
#include "scene_layouts/pipeline.h"
#include "scene_layouts/scene.h"

namespace odyssey::cli {

// Declares --animation, --list-animations, --anime, --anime-fps, --anime-up, --loops, --seconds
// and --scale (the retargeting options are declared by add_retarget_options).
void add_actor_source_options(Args& args);

// With --list-animations: prints the animations of --character (name, duration, keys) and
// returns true (the command then writes nothing).
bool list_animations_if_asked(const Args& args);

// The actor the options ask for, named after its character or anime file, at --fps. Throws
// UsageError for conflicting or malformed options.
scene::SceneActor actor_from_options(const Args& args);

// --threads, checked as the retargeting options check it.
int thread_count(const Args& args);

// The actor's timings line: the retargeting's stages, or how long playing its source took.
std::string actor_timings_line(const scene::PlacedActor& actor);

}  // namespace odyssey::cli
