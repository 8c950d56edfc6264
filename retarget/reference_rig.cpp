#include "retarget/reference_rig.h"

#include <cmath>
#include <map>
#include <numbers>
#include <string>

#include "retarget/canonical.h"
#include "retarget/geometry.h"

namespace odyssey::retarget {

namespace {

using Eigen::Vector3d;

// World rest position of every canonical joint (see the header).
std::array<Vector3d, kCanonicalJointCount> canonical_positions(double arm_drop_deg) {
  std::array<Vector3d, kCanonicalJointCount> p;
  const auto set = [&](std::string_view name, const Vector3d& position) { p[canonical_index(name)] = position; };
  set("pelvis", {0, 0, 0.95});
  set("spine1", {0, 0.01, 1.06});
  set("spine2", {0, 0.01, 1.19});
  set("spine3", {0, 0, 1.32});
  set("neck", {0, 0, 1.50});
  set("head", {0, -0.02, 1.60});
  set("jaw", {0, -0.07, 1.56});
  const double a = arm_drop_deg * std::numbers::pi / 180.0;
  for (const double side : {1.0, -1.0}) {
    const std::string s = side > 0 ? "left_" : "right_";
    const auto at = [&](double x, double y, double z) { return Vector3d(side * x, y, z); };
    set(s + "eye_smplhf", at(0.03, -0.09, 1.66));
    set(s + "hip", at(0.09, 0, 0.88));
    set(s + "knee", at(0.09, 0.005, 0.50));
    set(s + "ankle", at(0.09, 0.02, 0.09));
    set(s + "foot", at(0.09, -0.11, 0.03));
    set(s + "collar", at(0.04, 0, 1.43));
    const Vector3d shoulder = at(0.17, 0, 1.44);
    const Vector3d d(side * std::cos(a), 0, -std::sin(a));
    set(s + "shoulder", shoulder);
    const Vector3d elbow = shoulder + 0.28 * d;
    const Vector3d wrist = elbow + 0.25 * d;
    set(s + "elbow", elbow);
    set(s + "wrist", wrist);
    const struct {
      const char* finger;
      double forward;
      double reach;
    } fingers[] = {{"index", 0.03, 0.09}, {"middle", 0.01, 0.09}, {"ring", -0.01, 0.09}, {"pinky", -0.03, 0.08}};
    for (const auto& finger : fingers) {
      Vector3d joint = wrist + finger.reach * d + Vector3d(0, -finger.forward, 0);
      for (int k = 1; k <= 3; ++k) {
        set(s + finger.finger + std::to_string(k), joint);
        joint += 0.035 * d;
      }
    }
    const Vector3d thumb_direction = (d - Vector3d::UnitY()).normalized();
    Vector3d thumb = wrist + 0.025 * d + Vector3d(0, -0.025, 0);
    for (int k = 1; k <= 3; ++k) {
      set(s + "thumb" + std::to_string(k), thumb);
      thumb += 0.03 * thumb_direction;
    }
  }
  return p;
}

struct JointSpec {
  std::string name;
  int parent;
  Vector3d position;
};

// Offsets and rotations from world positions: with bones_along_y, each joint's world frame turns
// +Y onto the direction to its first child (an end joint keeps its parent's frame).
Skeleton build(const std::vector<JointSpec>& joints, bool bones_along_y) {
  const int n = static_cast<int>(joints.size());
  std::vector<Eigen::Quaterniond> world(n, Eigen::Quaterniond::Identity());
  if (bones_along_y) {
    for (int j = 0; j < n; ++j) {
      int first_child = -1;
      for (int k = j + 1; k < n && first_child < 0; ++k) {
        if (joints[k].parent == j) first_child = k;
      }
      if (first_child >= 0) {
        world[j] = shortest_rotation(Vector3d::UnitY(), (joints[first_child].position - joints[j].position).normalized());
      } else if (joints[j].parent >= 0) {
        world[j] = world[joints[j].parent];
      }
    }
  }
  std::vector<std::string> names;
  std::vector<int> parents;
  std::vector<Vector3d> offsets;
  std::vector<Eigen::Quaterniond> rotations;
  for (int j = 0; j < n; ++j) {
    const int p = joints[j].parent;
    names.push_back(joints[j].name);
    parents.push_back(p);
    if (p < 0) {
      offsets.push_back(joints[j].position);
      rotations.push_back(world[j]);
    } else {
      offsets.push_back(world[p].conjugate() * (joints[j].position - joints[p].position));
      rotations.push_back(world[p].conjugate() * world[j]);
    }
  }
  return Skeleton(std::move(names), std::move(parents), std::move(offsets), std::move(rotations));
}

}  // namespace

Skeleton reference_humanoid(ReferenceNames names, double arm_drop_deg) {
  const std::array<Vector3d, kCanonicalJointCount> p = canonical_positions(arm_drop_deg);
  std::vector<JointSpec> joints;
  if (names == ReferenceNames::smplx) {
    for (int c = 0; c < kCanonicalJointCount; ++c) joints.push_back({std::string(canonical_name(c)), canonical_parent(c), p[c]});
    return build(joints, false);
  }
  // Mixamo: depth-first from the hips in Mixamo's usual order, end joints included.
  std::map<std::string, int> index;
  const auto add = [&](const std::string& name, const std::string& parent, const Vector3d& position) {
    index[name] = static_cast<int>(joints.size());
    joints.push_back({"mixamorig:" + name, parent.empty() ? -1 : index.at(parent), position});
  };
  const auto at = [&](std::string_view canonical) { return p[canonical_index(canonical)]; };
  add("Hips", "", at("pelvis"));
  add("Spine", "Hips", at("spine1"));
  add("Spine1", "Spine", at("spine2"));
  add("Spine2", "Spine1", at("spine3"));
  add("Neck", "Spine2", at("neck"));
  add("Head", "Neck", at("head"));
  add("HeadTop_End", "Head", at("head") + Vector3d(0, 0, 0.15));
  add("LeftEye", "Head", at("left_eye_smplhf"));
  add("RightEye", "Head", at("right_eye_smplhf"));
  for (const char* side_name : {"Left", "Right"}) {
    const std::string S = side_name;
    const std::string s = S == "Left" ? "left_" : "right_";
    add(S + "Shoulder", "Spine2", at(s + "collar"));
    add(S + "Arm", S + "Shoulder", at(s + "shoulder"));
    add(S + "ForeArm", S + "Arm", at(s + "elbow"));
    add(S + "Hand", S + "ForeArm", at(s + "wrist"));
    for (const auto& [mixamo, canonical] : {std::pair("Thumb", "thumb"), std::pair("Index", "index"), std::pair("Middle", "middle"),
                                            std::pair("Ring", "ring"), std::pair("Pinky", "pinky")}) {
      std::string parent = S + "Hand";
      for (int k = 1; k <= 3; ++k) {
        const std::string name = S + "Hand" + mixamo + std::to_string(k);
        add(name, parent, at(s + canonical + std::to_string(k)));
        parent = name;
      }
      const Vector3d last = at(s + canonical + "3");
      const Vector3d step = last - at(s + canonical + "2");
      add(S + "Hand" + mixamo + "4", parent, last + step);
    }
  }
  for (const char* side_name : {"Left", "Right"}) {
    const std::string S = side_name;
    const std::string s = S == "Left" ? "left_" : "right_";
    add(S + "UpLeg", "Hips", at(s + "hip"));
    add(S + "Leg", S + "UpLeg", at(s + "knee"));
    add(S + "Foot", S + "Leg", at(s + "ankle"));
    add(S + "ToeBase", S + "Foot", at(s + "foot"));
    add(S + "Toe_End", S + "ToeBase", at(s + "foot") + Vector3d(0, -0.07, 0));
  }
  return build(joints, true);
}

Character mixamo_reference_character(double arm_drop_deg) {
  Character character;
  character.name = "mixamo_reference";
  character.skeleton = reference_humanoid(ReferenceNames::mixamo, arm_drop_deg);
  return character;
}

}  // namespace odyssey::retarget
