// Actors on the shot's timeline and floor (scene.h gives the rules: the time map c(t), placement as
// recorded, fixed or drawn in a region, and footprints that may not overlap).
#pragma once

#include <Eigen/Core>
#include <vector>

#include "scene_layouts/scene.h"
#include "scene_layouts/shot.h"

namespace odyssey::scene {

// A turn of `degrees` about +z (counter-clockwise seen from above).
Eigen::Matrix3d yaw_rotation(double degrees);

// The root joint's horizontal position in every frame of the clip.
std::vector<Eigen::Vector2d> root_track(const TimedClip& clip, int root);

// Each actor's start on the timeline (drawn from its range where it has one, seed stream
// 3000 + actor), and the shot's frame count: the scene's seconds, or until the last clip ends.
// Throws std::invalid_argument for a shot of 10,000,000 frames or more.
int time_actors(const Scene& scene, std::vector<PlacedActor>& actors);

// Every actor's clip timed onto the shot's frames and placed as its spec says, clear of the actors
// placed before it (random placements draw again, seed stream = the actor's index). Throws
// std::invalid_argument naming both actors and the frame where two footprints overlap, or a trim
// beyond the clip.
void place_actors(const Scene& scene, int frames, std::vector<PlacedActor>& actors);

}  // namespace odyssey::scene
