// A motion of an SMPL-family body: per frame, one axis-angle rotation per model joint and the
// model translation, plus the shape and the frame rate. This is what AMASS files hold; the
// layout follows them and the smplx package:
//   poses.row(t) = [theta_0, theta_1, ..., theta_{J-1}],  theta_j = angle * axis of joint j,
//                  joints in model order (root, 21 body joints, then jaw, eyes and hands for
//                  SMPL-X; hands for SMPL-H; see BodyParts),
//   translations.row(t) = transl, added last by the forward pass (the root joint sits at
//                  J_0(beta) + transl, see body_model.h).
// theta_0 (the root orientation) and transl are in the world frame of the sequence. For AMASS that
// world is Z up, while the body template is Y up, so theta_0 of a person standing upright
// includes the +90 degree turn about X that takes Y up to Z up.
#pragma once

#include <string>
#include <vector>

#include "skeleton/body_model.h"

namespace odyssey {

struct BodySequence {
  BodyModelKind kind = BodyModelKind::SMPLX;
  std::string gender = "neutral";  // as the source wrote it ("male", "female", "neutral", ...)
  double fps = 30.0;
  std::vector<double> betas;  // shape coefficients; empty is the mean shape
  RowMatrixXd poses;          // T x (3 * body_model_joint_count(kind)), axis-angle
  RowMatrixXd translations;   // T x 3, metres

  int frame_count() const { return static_cast<int>(poses.rows()); }
  double duration() const { return frame_count() > 0 ? (frame_count() - 1) / fps : 0.0; }

  // Throws std::invalid_argument on a non-positive frame rate, shapes that do not fit the kind
  // or each other, or a non-finite value (naming the first bad frame, or the beta).
  void validate() const;

  // The sequence at `target_fps` over the same duration, by the rule of Clip::resampled: frame k
  // sits at time k / target_fps, the last frame is the last such time within the source duration.
  // Each joint rotation is slerped (the short way) between the quaternions of the two
  // neighbouring source frames and written back as axis-angle with angle in [0, pi];
  // translations are interpolated linearly. A target frame that falls exactly on a source frame
  // copies it unchanged (no round trip through quaternions), so 120 -> 30 fps keeps every fourth
  // frame bit for bit.
  BodySequence resampled(double target_fps) const;
};

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
