// A humanoid rig built from numbers, for tests, benchmarks and demos that need a rig with known
// geometry and a known naming convention: the Mixamo-named test rig of the retargeting issue,
// and the same body with SMPL-X names.
//
// The body: 1.75 m from the soles (z = 0) to the top of the head, Z up, facing -Y, its left at
// +X, standing with the arms lowered `arm_drop_deg` below horizontal (0: T-pose, 45: A-pose),
// palms down, fingers straight along the arm. Joint positions (metres, left side; the right side
// mirrors x):
//   pelvis (0, 0, 0.95); hip (0.09, 0, 0.88); knee (0.09, 0.005, 0.50); ankle (0.09, 0.02, 0.09);
//   ball of the foot (0.09, -0.11, 0.03); spine1 (0, 0.01, 1.06); spine2 (0, 0.01, 1.19);
//   spine3 (0, 0, 1.32); neck (0, 0, 1.50); head (0, -0.02, 1.60); jaw (0, -0.07, 1.56);
//   eye (0.03, -0.09, 1.66); collar (0.04, 0, 1.43); shoulder (0.17, 0, 1.44); then along the arm
//   direction d = (cos a, 0, -sin a): elbow = shoulder + 0.28 d, wrist = elbow + 0.25 d; finger
//   roots at the wrist + 0.09 d (index 0.03 forward, middle 0.01 forward, ring 0.01 back, pinky
//   0.03 back, the pinky 0.01 shorter), three 0.035 m phalanges along d; the thumb root at the
//   wrist + 0.025 d, 0.025 forward, its phalanges along unit(d - y).
//
// ReferenceNames::smplx: the 55 canonical joints with SMPL-X names and parents, rest rotations
// identity (as SMPL-X skeletons). ReferenceNames::mixamo: 67 joints, Mixamo's names (mixamorig:
// prefix): the mixamo preset's 54 (eyes included, no jaw) and the 13 end joints Mixamo exports
// (HeadTop_End, LeftToe_End, LeftHandIndex4 ...), with Mixamo-style rest rotations: each joint's
// frame has its +Y axis along the bone to its first child (the shortest turn from world +Y), an end
// joint its parent's frame; offsets are expressed in the parent's frame accordingly.
#pragma once

#include "skeleton/character.h"
#include "skeleton/skeleton.h"

namespace odyssey::retarget {

enum class ReferenceNames { smplx, mixamo };

Skeleton reference_humanoid(ReferenceNames names, double arm_drop_deg);

// The Mixamo-named rig as a character without meshes (its rest bounds are its joints', so the
// balls of the feet at z = 0.03 are its lowest points).
Character mixamo_reference_character(double arm_drop_deg = 45.0);

}  // namespace odyssey::retarget
