// Bone map files: JSON that says which joint of a rig plays each canonical (SMPL-X named) joint.
// The retargeting presets in retarget/presets/ and a user's --map file share the format:
//
//   {
//     "name": "mixamo",                                  optional text
//     "description": "Mixamo rigs (mixamorig: names)",   optional text
//     "joints": {
//       "pelvis": "mixamorig:Hips",                      canonical name -> rig joint name
//       "left_wrist": ["Palm2.L", "Palm1.L", "Palm3.L"], a list: the first is the joint, the
//                                                        others are bones that move rigidly with
//                                                        it (a palm split into several bones)
//       "jaw": null                                      explicitly unmapped (a user map uses it
//                                                        to drop a joint that was detected)
//     }
//   }
//
// This reader checks the file's structure only (an object of strings, lists of strings or null,
// no name given twice); whether the names exist is the retargeting module's business, since it
// knows the canonical vocabulary and the rig. Every problem throws InputError(path, problem).
#pragma once

#include <string>
#include <vector>

namespace odyssey::io {

struct BoneMapEntry {
  std::string canonical;                // as written; checked against the vocabulary by retarget
  std::vector<std::string> rig_joints;  // empty: explicitly unmapped; else joint, then followers
};

struct BoneMapFile {
  std::string name;
  std::string description;
  std::vector<BoneMapEntry> entries;  // in file order
};

BoneMapFile load_bone_map_file(const std::string& path);
// The same from JSON text; `origin` names it in errors (a path, or "preset mixamo").
BoneMapFile parse_bone_map(const std::string& json_text, const std::string& origin);

}  // namespace odyssey::io
