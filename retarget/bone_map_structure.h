// A bone map from a skeleton's structure: which joint plays each canonical joint, found from the
// hierarchy and the rest pose alone, the joint names unread (numbered, foreign-language, empty).
//
// The rest pose is taken as standing with z up (the loaders' world), H its height (the joints'
// z span). Joints that sit on their parent (offset under 1e-4 of the skeleton's size) are helpers
// and play nothing; leaves that bind no vertex (end markers such as HeadTop_End, IK targets) are
// pruned first when the caller says which joints bind vertices. Then:
//   legs:    the lowest leaf, and the lowest other leaf whose common ancestor with it lies at
//            least 0.25 H from both (not a toe of the same foot); the pelvis is that common
//            ancestor. Along each path from the pelvis: the ankle is the first joint below the
//            hip in the lowest 0.3 of the leg's height (from the path's first joint down to the
//            lowest joint; a foot flat on the floor puts the ankle far lower in the leg than
//            the knee, whatever the build), the ball of the foot the ankle's child whose
//            subtree reaches furthest horizontally from it (the toes, not a heel), the hip the
//            first joint more than 0.02 H sideways of the pelvis (the deepest of joints sitting
//            on it), the knee the joint between hip and ankle that splits that stretch most
//            evenly, |log(|hip - knee| / |knee - ankle|)| smallest;
//   arms:    the leaf furthest sideways from the pelvis's vertical (at least 0.08 H) that is
//            below the pelvis and not in a leg, and the furthest on the other side (horizontal
//            directions at an obtuse angle) whose common ancestor with it lies at least 0.2 H
//            from both; the chest (spine3) is that common ancestor. Along each path from the chest: the wrist is the first joint with two or
//            more finger branches (children with a child of their own; a twist bone hanging off
//            the forearm has none), else the leaf, or the leaf's parent when the leaf's bone is
//            under 0.4 of the one before (a hand tip); the shoulder and the elbow are the pair
//            before the wrist with |shoulder - elbow| / |elbow - wrist| nearest 1.15 in ratio (an
//            upper arm against forearm), the collar the shoulder's parent when that is not the
//            chest (even one sitting on the chest, as CMU's LeftShoulder: its bone is the clavicle);
//   spine:   the path from the pelvis to the chest, spine1 its first joint, spine2 its last when
//            there are two or more, as the name detection does;
//   head:    the highest joint above the chest outside the arms; walking up the path to it, the
//            head is the first joint that branches (face bones) or that highest joint, the neck
//            the path's first joint when it is not the head;
//   sides:   the rig faces where its feet point (ankle to ball of the foot, horizontally, summed
//            over both feet), its left is up x facing, as humanoid_problems() reads it; each leg
//            and arm is left or right by the side its hip or shoulder lies on.
// Fingers, jaw and eyes are not mapped. A skeleton where one of these steps finds nothing, or
// whose result is not built like a standing human (the chest less than 0.1 H above the pelvis,
// the ankles less than 0.15 H below it, the head not above the chest, both legs or both arms on
// one side), gets no map and a problem saying what was found.
#pragma once

#include <string>
#include <vector>

#include "retarget/bone_map.h"
#include "skeleton/character.h"
#include "skeleton/skeleton.h"

namespace odyssey::retarget {

struct StructureMap {
  BoneMap map;          // origin "skeleton structure"; empty when `problem` is set
  std::string problem;  // what was found and what was missing, empty when a map was found
};

// `binds`: per joint, whether it moves any vertex; empty when unknown (every joint counts).
StructureMap bone_map_from_structure(const Skeleton& rig, const std::vector<bool>& binds = {});
// The same for a character, pruning end joints that bind no vertex of its meshes.
StructureMap bone_map_from_structure(const Character& character);

// Per joint, whether some vertex of the character's meshes has a non-zero weight on it (a rigid
// mesh binds its joint).
std::vector<bool> joints_binding_vertices(const Character& character);

}  // namespace odyssey::retarget
