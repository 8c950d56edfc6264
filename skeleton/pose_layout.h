// Moving axis-angle poses between the SMPL family's joint layouts. All three share the 22 body
// joints (pelvis .. right_wrist) in the same order; SMPL-H then has 15 joints a hand; SMPL-X puts
// jaw and eyes (22-24) before the hands (25-54); SMPL ends with two hand stubs (22, 23) that
// carry no fingers. Joints the target has and the source lacks get the zero (rest) rotation.
#pragma once

#include <span>
#include <vector>

#include "skeleton/body_model.h"
#include "skeleton/body_sequence.h"

namespace odyssey {

// For each joint of `to`, the joint of `from` it takes its rotation from, or -1.
std::vector<int> pose_joint_map(BodyModelKind from, BodyModelKind to);

// `pose` has 3 * joint_count(from) numbers; the result 3 * joint_count(to).
std::vector<double> convert_pose(BodyModelKind from, std::span<const double> pose, BodyModelKind to);

// The sequence with every frame's pose moved to the `to` layout (a copy when the kinds agree).
BodySequence sequence_for_model(const BodySequence& sequence, BodyModelKind to);

}  // namespace odyssey
