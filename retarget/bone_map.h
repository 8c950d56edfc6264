// Bone maps: which joint of a rig plays each canonical (SMPL-X named) joint, see canonical.h.
//
// Where a map comes from, in order of precedence:
//   1. a user's JSON map (mocap_io/bone_map_file.h), applied over what was detected: each entry
//      replaces the detected joint for its canonical name, null unmaps it;
//   1b. the humanoid bone list the character file declares (VRM 0.x and 1.0, see
//      bone_map_from_declared), taken as the file says, without presets or names;
//   2. a preset (retarget/presets/*.json) that fits the rig: every body joint the preset names
//      (pelvis to wrists, canonical 0-21, except the balls of the feet) exists in the rig, the
//      balls, hand and face joints where they do, and the result passes the humanoid check below.
//      A preset whose names share a prefix up to a separator ("mixamorig:", "Character1_",
//      "Bip01 ") also fits a rig that has another non-empty prefix there ("Character2_",
//      "Bip001 "), found from the rig joint that ends like the preset's pelvis. Among fitting
//      presets one that fits with its own prefix wins, then the one naming most of the rig's
//      joints, then the first by name;
//   3. detection from joint names: names are normalised (a prefix all the rig's names share up to
//      a separator dropped, as "Character1_", and anything up to the last ':' in a name,
//      split into words at separators '_', '.', ' ', '-', at case changes and at digits,
//      lower-cased; side markers L/R, Left/Right, .L/_l, l_/r_ recognised as whole words or as a
//      left/right prefix; rig prefixes such as Bip/DEF/b dropped; names ending in End/Nub/Tip are
//      end markers and never mapped) and matched against a synonym table per canonical joint.
//      Among candidates of equal rank: a joint that sits on its parent loses (below), then one
//      whose name starts with '_' (MakeHuman's helpers __UpLeg_L, __Clavicle_L above UpLeg_L,
//      Clavicle_L), then the higher number (Unreal's neck_02 to neck_01, Rigify's deform split
//      DEF-upper_arm.L.001 to DEF-upper_arm.L). Words that mean different joints in different conventions are resolved by rank and by
//      which joints are claimed first: "shoulder" is the upper arm unless another joint is named
//      arm/upperarm (then it is the clavicle), "foot" is the ankle unless another joint is named
//      ankle (then it is the ball of the foot), "leg" is the shin unless another is named
//      shin/knee/lowerleg, "hip" with a side is the thigh and without one the pelvis. Among equal
//      candidates a joint that does not sit on its parent wins (CMU's zero-length Neck loses to
//      Neck1), then the one nearer the root. Two rules use the hierarchy instead of names: the
//      pelvis must be an ancestor of both thighs (else it is their lowest common ancestor, as
//      in RobotExpressive where the legs hang from Body, not Hips), and the spine is the chain
//      from the pelvis to the chest, the lowest common ancestor of the neck and both arms: the
//      chest is spine3, the first joint above the pelvis spine1, the last below the chest spine2,
//      skipping zero-length helpers; a pelvis named elsewhere than where the legs and the upper
//      body meet (MakeHuman's Hips, parent of the legs only) gives way to that joint. When no
//      joint is named head (Rigify's spine.004 .. spine.006), the head is the top of the chain
//      that leaves the chest carrying no arm and the neck its first joint (see
//      map_neck_and_head_from_chain in bone_map.cpp). Finger words (thumb, index, middle, ring, pinky/little)
//      with a number 1-3 (none: 1) map to the finger joints.
//   4. (humanoid_bone_map only) the skeleton's structure, when names leave body joints unplayed
//      (bone_map_structure.h).
//
// A map may also list followers: rig joints without a canonical role of their own that move
// rigidly with a mapped joint (a palm split into one bone per finger).
#pragma once

#include <array>
#include <string>
#include <vector>

#include "mocap_io/bone_map_file.h"
#include "retarget/canonical.h"
#include "skeleton/character.h"
#include "skeleton/skeleton.h"

namespace odyssey::retarget {

struct BoneMap {
  struct Follower {
    int joint;      // rig joint
    int canonical;  // the canonical joint whose rig joint it moves rigidly with
  };

  std::string origin;  // "preset mixamo", "joint names", "user map FILE over preset mixamo"
  std::array<int, kCanonicalJointCount> joints;  // rig joint of each canonical joint, -1 unmapped
  std::vector<Follower> followers;

  BoneMap() { joints.fill(-1); }
  bool mapped(int canonical) const { return joints[canonical] >= 0; }
  // The canonical joint a rig joint plays, or -1 (followers play none).
  int canonical_of(int rig_joint) const;
  int mapped_count() const;
};

// Preset names (the stems of retarget/presets/*.json), sorted.
std::vector<std::string> preset_names();
// Throws io::InputError when there is no such preset or it does not parse.
io::BoneMapFile load_preset(const std::string& name);

// The map a file describes, taken literally: throws io::InputError(origin, ...) naming an unknown
// canonical name or a rig joint the skeleton does not have.
BoneMap bone_map_from_file(const Skeleton& rig, const io::BoneMapFile& file, const std::string& origin);

// A fitting preset, else detection from names (see the top of this file). The result may be far
// from humanoid (check with humanoid_problems); throws io::InputError only for a broken preset.
BoneMap detect_bone_map(const Skeleton& rig);
// Detection from names and hierarchy alone, no presets.
BoneMap bone_map_from_names(const Skeleton& rig);

// The map a character file declares (Character::declared_humanoid), in VRM's vocabulary: hips
// pelvis, spine spine1, chest spine3 (spine2 when upperChest is declared, which is then spine3),
// neck, head, jaw, eyes, shoulder the collar, upperArm/lowerArm/hand the shoulder/elbow/wrist,
// upperLeg/lowerLeg/foot/toes the hip/knee/ankle/ball of the foot; fingers Proximal,
// Intermediate, Distal 1, 2, 3 (Little is the pinky), except the VRM 1.0 thumb, Metacarpal,
// Proximal, Distal. Bone names outside this list are ignored. Origin "VRM 1.0 humanoid declared
// in the file". Throws std::invalid_argument for a convention other than "VRM 0.x" or "VRM 1.0".
BoneMap bone_map_from_declared(const Skeleton& rig, const std::vector<Character::DeclaredBone>& bones,
                               const std::string& convention);

// Applies a user map over `map` (see the top of this file). Throws io::InputError(origin, ...)
// naming an unknown canonical name or a missing rig joint.
void override_bone_map(BoneMap& map, const Skeleton& rig, const io::BoneMapFile& user, const std::string& origin);

// Why the map does not describe a humanoid, one line each; empty when it does. Needs pelvis, a
// spine joint (spine1, spine2 or spine3), head, and both hips, knees, ankles, shoulders, elbows
// and wrists; then checks the rest pose: head above pelvis above knees above ankles, and, when
// the balls of the feet are mapped (they tell where the rig faces), the left joints on the
// rig's left.
std::vector<std::string> humanoid_problems(const Skeleton& rig, const BoneMap& map);

// The value of `user_map_path` (--map, a scene's "map") that asks for the map from the skeleton's
// structure (bone_map_structure.h) instead of a file; a file of that name, where one exists, is
// read as a map.
inline constexpr const char* kAutoStructureMap = "auto-structure";

// Detects (or takes the preset/user map), applies the user map when `user_map_path` is not empty,
// and requires a humanoid. When detection leaves body joints unplayed (the names give no complete
// map) and no user map is given, the map from the skeleton's structure is used if it passes the
// humanoid check (origin "skeleton structure (the names left ... unplayed)"); with
// `user_map_path` kAutoStructureMap that map is used alone. Throws
// io::InputError(rig_label, "not a humanoid rig (bone map from ORIGIN): ...") listing the
// problems and, where names left joints unplayed, the preset that came closest with the joints
// it lacked, what the structure found, and how to give a map; io::InputError for a bad user map.
BoneMap humanoid_bone_map(const Skeleton& rig, const std::string& rig_label, const std::string& user_map_path = {});
// The same for a character: its declared humanoid (bone_map_from_declared) when the file has one,
// else detection on its skeleton, the structure pruning end joints that bind no vertex.
BoneMap humanoid_bone_map(const Character& character, const std::string& rig_label, const std::string& user_map_path = {});

// Rig joints that play no canonical joint and follow none, in skeleton order.
std::vector<int> unmapped_joints(const Skeleton& rig, const BoneMap& map);

}  // namespace odyssey::retarget
