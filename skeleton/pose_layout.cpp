#include "skeleton/pose_layout.h"

#include <stdexcept>
#include <string>

namespace odyssey {
namespace {

// First joint of the 30 finger joints (left hand then right), or -1 for a layout without them.
int first_finger_joint(BodyModelKind kind) {
  switch (kind) {
    case BodyModelKind::SMPLX: return 25;
    case BodyModelKind::SMPLH: return 22;
    case BodyModelKind::SMPL: return -1;
  }
  return -1;
}

}  // namespace

std::vector<int> pose_joint_map(BodyModelKind from, BodyModelKind to) {
  std::vector<int> source_of(body_model_joint_count(to), -1);
  for (int joint = 0; joint < BodyParts::kBodyJoints; ++joint) source_of[joint] = joint;
  if (from == to) {
    for (std::size_t joint = 0; joint < source_of.size(); ++joint) source_of[joint] = static_cast<int>(joint);
    return source_of;
  }
  const int from_fingers = first_finger_joint(from), to_fingers = first_finger_joint(to);
  if (from_fingers >= 0 && to_fingers >= 0) {
    for (int k = 0; k < 30; ++k) source_of[to_fingers + k] = from_fingers + k;
  }
  return source_of;
}

std::vector<double> convert_pose(BodyModelKind from, std::span<const double> pose, BodyModelKind to) {
  if (pose.size() != std::size_t(3 * body_model_joint_count(from))) {
    throw std::invalid_argument(std::string(body_model_kind_name(from)) + " pose needs " +
                                std::to_string(3 * body_model_joint_count(from)) + " numbers, got " +
                                std::to_string(pose.size()));
  }
  const std::vector<int> source_of = pose_joint_map(from, to);
  std::vector<double> result(3 * source_of.size(), 0.0);
  for (std::size_t joint = 0; joint < source_of.size(); ++joint) {
    if (source_of[joint] < 0) continue;
    for (int c = 0; c < 3; ++c) result[3 * joint + c] = pose[3 * source_of[joint] + c];
  }
  return result;
}

BodySequence sequence_for_model(const BodySequence& sequence, BodyModelKind to) {
  if (sequence.kind == to) return sequence;
  BodySequence result = sequence;
  result.kind = to;
  result.poses.setZero(sequence.frame_count(), 3 * body_model_joint_count(to));
  for (int frame = 0; frame < sequence.frame_count(); ++frame) {
    const auto row = sequence.poses.row(frame);
    const std::vector<double> pose = convert_pose(sequence.kind, std::span<const double>(row.data(), row.size()), to);
    result.poses.row(frame) = Eigen::Map<const Eigen::RowVectorXd>(pose.data(), pose.size());
  }
  return result;
}

}  // namespace odyssey
