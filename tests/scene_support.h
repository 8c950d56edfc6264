// What the scene tests share: the bundled walk and characters, and an actor walking them.
#pragma once

#include <string>

#include "mocap_io/bvh.h"
#include "scene_layouts/scene.h"

namespace odyssey::test_support {

inline const std::string kSceneData = ODYSSEY_DATA_DIR;
inline const std::string kSceneWalk = kSceneData + "/mocap/cmu_walk_cgspeed.bvh";
inline const std::string kSceneFigure = kSceneData + "/characters/RiggedFigure.glb";
inline const std::string kSceneCesium = kSceneData + "/characters/CesiumMan.glb";

// The bundled CMU walk (CMU units) at quality fast on `character`, its root placed at (x, y)
// facing `yaw` degrees at scene time 0.
inline scene::SceneActor walker(const std::string& name, const std::string& character, double x, double y, double yaw) {
  scene::SceneActor actor;
  actor.name = name;
  scene::RetargetRequest request = scene::retarget_request(kSceneWalk, character, retarget::Quality::fast);
  request.bvh_metres_per_unit = io::kCmuMetresPerUnit;
  actor.source = std::move(request);
  actor.placement.kind = scene::Placement::Kind::fixed;
  actor.placement.x = x;
  actor.placement.y = y;
  actor.placement.yaw_deg = yaw;
  return actor;
}

}  // namespace odyssey::test_support
