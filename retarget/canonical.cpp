#include "retarget/canonical.h"

#include <string>

namespace odyssey::retarget {

const std::array<CanonicalJoint, kCanonicalJointCount>& canonical_joints() {
  static constexpr std::array<CanonicalJoint, kCanonicalJointCount> kJoints = {{
      {"pelvis", -1},         {"left_hip", 0},        {"right_hip", 0},        {"spine1", 0},
      {"left_knee", 1},       {"right_knee", 2},      {"spine2", 3},           {"left_ankle", 4},
      {"right_ankle", 5},     {"spine3", 6},          {"left_foot", 7},        {"right_foot", 8},
      {"neck", 9},            {"left_collar", 9},     {"right_collar", 9},     {"head", 12},
      {"left_shoulder", 13},  {"right_shoulder", 14}, {"left_elbow", 16},      {"right_elbow", 17},
      {"left_wrist", 18},     {"right_wrist", 19},    {"jaw", 15},             {"left_eye_smplhf", 15},
      {"right_eye_smplhf", 15}, {"left_index1", 20},  {"left_index2", 25},     {"left_index3", 26},
      {"left_middle1", 20},   {"left_middle2", 28},   {"left_middle3", 29},    {"left_pinky1", 20},
      {"left_pinky2", 31},    {"left_pinky3", 32},    {"left_ring1", 20},      {"left_ring2", 34},
      {"left_ring3", 35},     {"left_thumb1", 20},    {"left_thumb2", 37},     {"left_thumb3", 38},
      {"right_index1", 21},   {"right_index2", 40},   {"right_index3", 41},    {"right_middle1", 21},
      {"right_middle2", 43},  {"right_middle3", 44},  {"right_pinky1", 21},    {"right_pinky2", 46},
      {"right_pinky3", 47},   {"right_ring1", 21},    {"right_ring2", 49},     {"right_ring3", 50},
      {"right_thumb1", 21},   {"right_thumb2", 52},   {"right_thumb3", 53},
  }};
  return kJoints;
}

int canonical_index(std::string_view name) {
  const auto& joints = canonical_joints();
  for (int i = 0; i < kCanonicalJointCount; ++i) {
    if (joints[i].name == name) return i;
  }
  return -1;
}

bool canonical_is_left(int joint) {
  const std::string_view name = canonical_name(joint);
  return name.starts_with("left_");
}

int canonical_mirror(int joint) {
  const std::string_view name = canonical_name(joint);
  std::string mirrored;
  if (name.starts_with("left_")) {
    mirrored = "right_" + std::string(name.substr(5));
  } else if (name.starts_with("right_")) {
    mirrored = "left_" + std::string(name.substr(6));
  } else {
    return joint;
  }
  return canonical_index(mirrored);
}

std::string_view canonical_limb(int joint) {
  using namespace canonical;
  switch (joint) {
    case pelvis: return "pelvis";
    case spine1: case spine2: case spine3: case neck: return "spine";
    case head: case jaw: case left_eye: case right_eye: return "head";
    case left_collar: case left_shoulder: case left_elbow: case left_wrist: return "left_arm";
    case right_collar: case right_shoulder: case right_elbow: case right_wrist: return "right_arm";
    case left_hip: case left_knee: case left_ankle: case left_foot: return "left_leg";
    case right_hip: case right_knee: case right_ankle: case right_foot: return "right_leg";
    default: return joint < right_index1 ? "left_hand" : "right_hand";
  }
}

}  // namespace odyssey::retarget
