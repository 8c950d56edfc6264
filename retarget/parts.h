// Which parts of the body a retarget solves (`odyssey retarget --parts`): the body alone, the body
// and the hands, or everything a map names. Parts are sets of canonical joints (canonical.h):
//
//   body        pelvis .. wrists (canonical 0-21): spine, neck, head, arms, legs and feet;
//   body+hands  the body and the 30 finger joints (canonical 25-54, canonical_limb "left_hand" and
//               "right_hand");
//   all         every canonical joint, the face too (jaw 22 and eyes 23-24) where the maps have it.
//
// A part is left out by unmapping its canonical joints on both rigs before the rig is built
// (restrict_bone_map), so nothing downstream sees them: no segment, no alignment term, no metric.
// A target joint left out keeps its rest rotation relative to its parent (transfer.h: it plays
// no paired role), so with `body` the fingers ride rigidly on the hand in their rest pose, and the
// report lists them among the unmapped joints. Mocap rarely captures fingers and faces well (the
// CMU BVH files have a thumb stub and one finger base), and a rest hand is better than one driven
// by noise, hence `body` as the default.
#pragma once

#include <optional>
#include <string_view>

#include "retarget/bone_map.h"

namespace odyssey::retarget {

enum class Parts { body, body_and_hands, all };

// "body", "body+hands" or "all"; nullopt for anything else.
std::optional<Parts> parse_parts(std::string_view text);
const char* parts_name(Parts parts);

// Whether canonical joint `canonical` (0-54) belongs to `parts`.
bool canonical_in_parts(int canonical, Parts parts);

// The map with every canonical joint outside `parts` unmapped, and the followers of those joints
// dropped (they become unmapped joints too). The origin is kept: the parts are a setting, not
// where the map came from.
BoneMap restrict_bone_map(const BoneMap& map, Parts parts);

}  // namespace odyssey::retarget
