// Scene files: a shot as JSON (docs/scenes.md documents every key; `odyssey scene
// --example` prints one that runs). Relative paths are relative to the file; a path starting with
// "data:" names a file of the bundled data folder (the project's data/, or ODYSSEY_DATA_DIR when
// set), so an example runs from any directory. Every value is checked, unknown keys are refused,
// and errors name the file and the JSON path: "shot.json: actors[1].placement.yaw: not a number".
#pragma once

#include <string>

#include "scene_layouts/scene.h"

namespace odyssey::scene {

inline constexpr int kSceneFileVersion = 1;

// Throws io::InputError naming the file and JSON path. Outputs are left empty: the caller picks
// the files (set_outputs_in_folder) from the file's "outputs" selection, returned beside.
struct SceneFile {
  Scene scene;
  OutputSelection outputs;
};
SceneFile read_scene_file(const std::string& path);
SceneFile parse_scene(const std::string& json_text, const std::string& path);

// The bundled data folder that "data:" paths resolve against.
std::string bundled_data_folder();

// A documented example scene (JSON text) that runs as printed.
std::string example_scene_json();

}  // namespace odyssey::scene
