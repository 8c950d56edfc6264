// The canonical humanoid vocabulary every bone map speaks: the 55 SMPL-X joints (names and parents
// exactly as shared/assets/smplx_joints_55.tsv and the smplx package), body 0-21, jaw 22, eyes
// 23-24, left hand 25-39, right hand 40-54. Every rig, source or target, is described by which of
// its joints plays each canonical joint; a source joint drives a target joint when both play the
// same canonical joint. The canonical tree (parents below) is what "the next mapped joint down a
// chain" means when two rigs have chains of different length.
//
// Beware the SMPL-X naming: `left_shoulder` is the upper-arm joint (Mixamo's LeftArm), the
// clavicle is `left_collar`, `left_hip` is the top of the thigh, `left_ankle` the ankle and
// `left_foot` the ball of the foot (Mixamo's LeftToeBase).
#pragma once

#include <array>
#include <string_view>

namespace odyssey::retarget {

inline constexpr int kCanonicalJointCount = 55;

struct CanonicalJoint {
  std::string_view name;
  int parent;  // -1 for the pelvis
};

// Indices of the canonical joints that code refers to by role.
namespace canonical {
inline constexpr int pelvis = 0, left_hip = 1, right_hip = 2, spine1 = 3, left_knee = 4, right_knee = 5,
                     spine2 = 6, left_ankle = 7, right_ankle = 8, spine3 = 9, left_foot = 10, right_foot = 11,
                     neck = 12, left_collar = 13, right_collar = 14, head = 15, left_shoulder = 16,
                     right_shoulder = 17, left_elbow = 18, right_elbow = 19, left_wrist = 20, right_wrist = 21,
                     jaw = 22, left_eye = 23, right_eye = 24, left_index1 = 25, left_thumb1 = 37,
                     right_index1 = 40, right_thumb1 = 52;
}  // namespace canonical

const std::array<CanonicalJoint, kCanonicalJointCount>& canonical_joints();

// Index of a canonical name, or -1.
int canonical_index(std::string_view name);
inline std::string_view canonical_name(int joint) { return canonical_joints()[joint].name; }
inline int canonical_parent(int joint) { return canonical_joints()[joint].parent; }

// The joint's mirror image (left_knee <-> right_knee); the joint itself on the midline.
int canonical_mirror(int joint);
// True for the joints of the left side of the body.
bool canonical_is_left(int joint);

// The body part a bone belongs to, named after the canonical joint the bone ends at: "spine"
// (spine1-3, neck), "head" (head, jaw, eyes), "left_arm" (collar, shoulder, elbow, wrist),
// "right_arm", "left_leg" (hip, knee, ankle, foot), "right_leg", "left_hand" (fingers),
// "right_hand". The pelvis starts bones but ends none.
std::string_view canonical_limb(int joint);

}  // namespace odyssey::retarget
