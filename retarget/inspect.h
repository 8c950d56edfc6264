// What a file is and what it holds, as data: the summary `odyssey inspect` prints and the Python
// module's inspect() returns. Nothing is converted or written.
//
// Every summary has "file" and "kind": "bvh" (units, frames, fps, duration, translated joints,
// joints with parents), "body_model" (model, vertices, faces, shape, expression and corrective
// directions, hand components, joints), "amass" (model, pose numbers, frames, fps, duration,
// gender, betas, skipped keys), "npz" (arrays: dtype, shape, whether loaded), "npy" (dtype, shape)
// or "character" (skins, meshes, rest height and what it is of, where the rest pose comes from,
// joints with parents and the canonical joint each plays, animations, rest pose kind, the bone map
// a retarget would use or why there is none, unmapped joints, warnings).
#pragma once

#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "skeleton/character.h"

namespace odyssey::retarget {

// A .glb, .gltf or .vrm path (case-insensitive): a character.
bool is_gltf_path(const std::string& path);

// The summary of `path`, a character or any motion file (io::detect_motion_file). A BVH is read
// with `metres_per_unit` when given, else its units are inferred. Throws io::InputError naming the
// file.
nlohmann::ordered_json inspect_file(const std::string& path, std::optional<double> metres_per_unit = std::nullopt);

// The summary of a character already loaded from `path`.
nlohmann::ordered_json character_summary(const Character& character, const std::string& path);

}  // namespace odyssey::retarget
