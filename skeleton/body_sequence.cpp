#include "skeleton/body_sequence.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "skeleton/rotation.h"

namespace odyssey {

void BodySequence::validate() const {
  if (!(fps > 0) || !std::isfinite(fps))
    throw std::invalid_argument("frame rate " + std::to_string(fps) + " is not positive");
  const int width = 3 * body_model_joint_count(kind);
  if (poses.cols() != width) {
    throw std::invalid_argument("poses have " + std::to_string(poses.cols()) + " columns, expected " +
                                std::to_string(width) + " for " + body_model_kind_name(kind));
  }
  if (translations.rows() != poses.rows() || translations.cols() != 3) {
    throw std::invalid_argument("translations are " + std::to_string(translations.rows()) + " x " +
                                std::to_string(translations.cols()) + ", expected " + std::to_string(poses.rows()) +
                                " x 3 (one row per pose)");
  }
  for (std::size_t k = 0; k < betas.size(); ++k) {
    if (!std::isfinite(betas[k])) throw std::invalid_argument("beta " + std::to_string(k) + " is not finite");
  }
  for (Eigen::Index f = 0; f < poses.rows(); ++f) {
    for (Eigen::Index c = 0; c < width; ++c) {
      if (!std::isfinite(poses(f, c))) {
        throw std::invalid_argument("frame " + std::to_string(f) + ", joint " + std::to_string(c / 3) +
                                    ": pose is not finite");
      }
    }
    if (!translations.row(f).allFinite()) {
      throw std::invalid_argument("frame " + std::to_string(f) + ": translation is not finite");
    }
  }
}

BodySequence BodySequence::resampled(double target_fps) const {
  if (!(target_fps > 0) || !std::isfinite(target_fps)) {
    throw std::invalid_argument("target frame rate " + std::to_string(target_fps) + " is not positive");
  }
  BodySequence out;
  out.kind = kind;
  out.gender = gender;
  out.betas = betas;
  out.fps = target_fps;
  const int frames = frame_count();
  const Eigen::Index width = poses.cols();
  if (frames == 0) {
    out.poses.resize(0, width);
    out.translations.resize(0, 3);
    return out;
  }
  // The same frame-time rule as Clip::resampled, 1e-9 slack included, so a clip and the body
  // sequence it came from resample to the same frame count.
  const int target_frames = static_cast<int>(std::floor(duration() * target_fps * (1 + 1e-9) + 1e-9)) + 1;
  out.poses.resize(target_frames, width);
  out.translations.resize(target_frames, 3);
  for (int f = 0; f < target_frames; ++f) {
    const double source_position = f * fps / target_fps;
    const int f0 = std::min(static_cast<int>(std::floor(source_position)), frames - 1);
    const int f1 = std::min(f0 + 1, frames - 1);
    const double alpha = std::clamp(source_position - f0, 0.0, 1.0);
    if (alpha == 0.0 || f0 == f1) {
      out.poses.row(f) = poses.row(f0);
      out.translations.row(f) = translations.row(f0);
      continue;
    }
    for (Eigen::Index j = 0; j < width / 3; ++j) {
      const Eigen::Quaterniond q0 = quaternion_from_axis_angle<double>(poses.row(f0).segment<3>(3 * j).transpose());
      const Eigen::Quaterniond q1 = quaternion_from_axis_angle<double>(poses.row(f1).segment<3>(3 * j).transpose());
      out.poses.row(f).segment<3>(3 * j) =
          axis_angle_from_quaternion(q0.slerp(alpha, sign_aligned(q1, q0))).transpose();
    }
    out.translations.row(f) = (1 - alpha) * translations.row(f0) + alpha * translations.row(f1);
  }
  return out;
}

}  // namespace odyssey
