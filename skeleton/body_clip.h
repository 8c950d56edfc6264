// An SMPL-family body sequence as a Clip, so that AMASS motion drives the same retargeting,
// metrics and writers as BVH. The skeleton is the body's own at the sequence's shape:
//
//   joint names    the model's (SMPL-X names, shared/assets/smplx_joints_55.tsv),
//   rest offsets   J_j(beta) - J_parent(j)(beta) for j > 0, and J_0(beta) for the root, in the
//                  model's Y-up frame, rest rotations identity,
//   root rest      rotation y_up_to_z_up(), so the rest pose stands upright in the Z-up world,
//
// and frame t holds the local rotations R_j = rodrigues(theta_j) of the sequence and the root
// translation transl + J_0(beta). A frame's rotation replaces the rest rotation (clip.h), and
// AMASS root orientations already include the turn from Y up to Z up, so nothing is applied
// twice. Forward kinematics then gives exactly the body model's joints:
//   world_0 = [R_0 | transl + J_0],   world_j = world_parent [R_j | J_j - J_parent],
// which is the smplx forward pass (body_model.h) with the translation folded into the root.
#pragma once

#include "skeleton/body_model.h"
#include "skeleton/body_sequence.h"
#include "skeleton/clip.h"

namespace odyssey {

// Throws std::invalid_argument when the sequence does not validate (naming the bad frame) or
// was made for another model kind than `model`.
Clip clip_from_body_sequence(const BodyModel& model, const BodySequence& sequence);

}  // namespace odyssey
