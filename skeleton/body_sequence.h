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

}  // namespace odyssey
