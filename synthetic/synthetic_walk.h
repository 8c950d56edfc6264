// The procedural walk: an SMPL-family body sequence (body_sequence.h) made from numbers, so that
// demos, tests and benchmarks have motion without a licensed AMASS file.
#pragma once

#include "skeleton/body_model.h"
#include "skeleton/body_sequence.h"

namespace odyssey {

// A procedural walk in the AMASS convention (Z-up world, root orientation including the Y-up to
// Z-up turn), for demos and tests: a steady walk, already under way at frame 0. The body faces
// and walks along world -Y (the body's +Z forward axis under y_up_to_z_up(), and the way a
// Blender character faces the front view), left is +X, at about 1.2 m/s with 120 steps a minute
// (strides of about 1.2 m).
//   Legs are solved by inverse kinematics so that each foot stays planted through stance: the
//   ankle is fixed on the ground until the heel rises about the ball of the foot (toes stay
//   level), then swings to the next plant. Feet land on z = 0 (the foot joints 3.5 cm above it)
//   for a body with the SMPL-X template's legs (thigh 0.38 m, shin 0.40 m, pelvis joint 0.93 m
//   above the soles at rest); with other proportions they hover or sink by the difference and
//   slide by a fraction of it. Knees flex up to about 50 degrees in swing and 15-20 in stance,
//   hips move between about 40 degrees of flexion and 20 of extension.
//   The pelvis rises 4 cm from double support to mid-stance, sways 2 cm toward the stance foot,
//   yaws toward the leg in front, drops on the swing side and tilts 3 degrees forward; the
//   spine counter-rotates, arms hang 77 degrees below horizontal and swing opposite the legs with
//   slightly bent elbows, fingers are gently curled (thumbs stay at rest: their flexion axis is
//   oblique in the template).
// `seed` varies speed, stride, foot placement, pelvis and arm amplitudes, the starting phase and
// the finger curl by a few percent; mt19937 is specified bit for bit by the standard, so a seed
// gives the same walk on every platform. Betas are ten zeros (the mean shape), gender
// "neutral". SMPL has no finger joints, so there its hands stay at rest. Throws
// std::invalid_argument for frames < 1 or fps <= 0.
BodySequence synthetic_walk(int frames, double fps, BodyModelKind kind, unsigned seed);

}  // namespace odyssey
