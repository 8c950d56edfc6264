#include "skeleton/body_clip.h"

#include <stdexcept>
#include <string>

#include "skeleton/rotation.h"

namespace odyssey {

Clip clip_from_body_sequence(const BodyModel& model, const BodySequence& sequence) {
  sequence.validate();
  if (sequence.kind != model.kind) {
    throw std::invalid_argument(std::string("the sequence is for ") + body_model_kind_name(sequence.kind) +
                                " but the body model is " + body_model_kind_name(model.kind));
  }
  BodyModelEvaluator evaluator(model);
  evaluator.set_shape(sequence.betas);
  const RowMatrixXd& rest_joints = evaluator.rest_joints();
  const int joints = model.joint_count();

  std::vector<Eigen::Vector3d> offsets(joints);
  std::vector<Eigen::Quaterniond> rest_rotations(joints, Eigen::Quaterniond::Identity());
  const Eigen::Vector3d root = rest_joints.row(0).transpose();
  offsets[0] = root;
  rest_rotations[0] = Eigen::Quaterniond(y_up_to_z_up());
  for (int j = 1; j < joints; ++j) {
    offsets[j] = (rest_joints.row(j) - rest_joints.row(model.parents[j])).transpose();
  }

  Clip clip;
  clip.skeleton = Skeleton(model.joint_names, model.parents, std::move(offsets), std::move(rest_rotations));
  clip.fps = sequence.fps;
  const int frames = sequence.frame_count();
  clip.rotations.resize(std::size_t(frames) * joints);
  clip.translated_joints = {0};
  clip.translations.resize(frames);
  for (int f = 0; f < frames; ++f) {
    for (int j = 0; j < joints; ++j) {
      const Eigen::Vector3d theta = sequence.poses.row(f).segment<3>(3 * j).transpose();
      clip.rotations[std::size_t(f) * joints + j] = quaternion_from_axis_angle<double>(theta);
    }
    clip.translations[f] = sequence.translations.row(f).transpose() + root;
  }
  return clip;
}

}  // namespace odyssey
