// Every camera of a shot as a path over its frames, from the scene's camera kinds (scene.h,
// camera_rigs.h, imported_camera.h), with the framing that fills unset positions and targets.
//
// Framing (cameras whose position or target is unset). With h the tallest actor's rest height,
// m the mean horizontal position of the actors' roots over the shot and e the largest distance of
// a root from m:
//   target    (m.x, m.y, 0.55 h)
//   distance  d = 2.5 h + e
//   static    centre = target + d f, at height 0.9 h, f the first actor's facing at scene time 0
//   orbit     radius d, height 0.9 h, starting on f
//   ego       eye offsets 0.06 h forward and 0.047 h up of its own actor's height
// Seeded draws: a camera's jitter from stream 2000 + its index, its handheld shake from 4000 + it.
#pragma once

#include <string>
#include <vector>

#include "scene_layouts/scene.h"
#include "scene_layouts/shot.h"

namespace odyssey::scene {

struct Framing {
  double height = 0;
  Eigen::Vector3d target;
  double distance = 0;
  Eigen::Vector3d facing;
};

// Throws std::invalid_argument when the actors have no height at rest.
Framing frame_actors(const std::vector<PlacedActor>& actors);

// Camera `index` of the scene over `frames` frames, handheld shake included; notes of imported
// tracks (a lens distortion dropped) go to `notes`. Throws io::InputError naming a camera file,
// or std::invalid_argument naming the camera.
CameraPath make_camera(const SceneCamera& camera, const Scene& scene, const std::vector<PlacedActor>& actors,
                       const Framing& framing, int frames, std::size_t index, std::vector<std::string>& notes);

}  // namespace odyssey::scene
