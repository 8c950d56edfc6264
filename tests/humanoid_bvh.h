// Humanoid BVH files the tests write: a T-posed skeleton 1.6 m from sole to head joint, named per
// convention, with a walk, and rest offsets standing, lying along +x or all zero.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "test_support.h"

namespace odyssey::test_support::humanoid_bvh {

using Eigen::Vector3d;

// BVH skeletons the tests write: joints with parents and standing offsets (centimetres, Y up,
// facing +Z, so the performer's left is +X), named per convention.

struct BvhJoint {
  std::string name;
  int parent;       // index into the list, -1 for the root
  Vector3d offset;  // standing, from the parent, centimetres
  std::string canonical;  // the canonical joint it plays, empty for none
};

// A humanoid in a T-pose, 1.6 m from sole to head joint: `spine_links` 2 or 3 joints from the
// pelvis to the chest; legs from the pelvis (or from `legs_from`, a spine joint, as Biped does);
// `names` gives each canonical joint's name (a role the map lacks is left out, its children
// moved up to its parent); `extra_root` names a joint above the pelvis (Biped's Bip01,
// HumanIK's Reference), empty for none.
inline std::vector<BvhJoint> humanoid(const std::map<std::string, std::string>& names, const std::string& extra_root = {},
                               const std::string& legs_from = "pelvis") {
  std::vector<BvhJoint> joints;
  std::map<std::string, int> index;
  const auto add = [&](const std::string& role, const std::string& parent, Vector3d offset) {
    if (!names.count(role)) return;
    int p = -1;
    std::string up = parent;
    while (!up.empty() && !index.count(up)) up.clear();  // a missing parent role: hang from the root
    if (!up.empty()) p = index[up];
    else if (!joints.empty()) p = 0;
    joints.push_back({names.at(role), p, offset, role == "_root" ? "" : role});
    index[role] = static_cast<int>(joints.size()) - 1;
  };
  if (!extra_root.empty()) {
    joints.push_back({extra_root, -1, Vector3d(0, 0, 0), ""});
    index["_root"] = 0;
    add("pelvis", "_root", Vector3d(0, 98, 0));
  } else {
    add("pelvis", "", Vector3d(0, 98, 0));
  }
  add("spine1", "pelvis", Vector3d(0, 10, 0));
  const bool three = names.count("spine2") > 0;
  add("spine2", "spine1", Vector3d(0, 12, 0));
  add("spine3", three ? "spine2" : "spine1", Vector3d(0, three ? 12 : 24, 0));
  add("neck", "spine3", Vector3d(0, 20, 0));
  add("head", "neck", Vector3d(0, 10, 0));
  for (const int sign : {1, -1}) {
    const std::string side = sign > 0 ? "left_" : "right_";
    add(side + "collar", "spine3", Vector3d(sign * 3, 16, 0));
    add(side + "shoulder", side + "collar", Vector3d(sign * 13, 0, 0));
    add(side + "elbow", side + "shoulder", Vector3d(sign * 27, 0, 0));
    add(side + "wrist", side + "elbow", Vector3d(sign * 25, 0, 0));
    const std::vector<std::pair<std::string, Vector3d>> fingers = {
        {"thumb", Vector3d(3, 0, 3)}, {"index", Vector3d(9, 0, 2)}, {"middle", Vector3d(9, 0, 0)},
        {"ring", Vector3d(9, 0, -1.5)}, {"pinky", Vector3d(8, 0, -3)}};
    for (const auto& [finger, base] : fingers) {
      add(side + finger + "1", side + "wrist", Vector3d(sign * base.x(), base.y(), base.z()));
      add(side + finger + "2", side + finger + "1", Vector3d(sign * 3, 0, 0));
      add(side + finger + "3", side + finger + "2", Vector3d(sign * 2, 0, 0));
    }
    const Vector3d hip = legs_from == "pelvis" ? Vector3d(sign * 9, -6, 0) : Vector3d(sign * 9, -16, 0);
    add(side + "hip", legs_from, hip);
    add(side + "knee", side + "hip", Vector3d(0, -43, 0));
    add(side + "ankle", side + "knee", Vector3d(0, -42, 0));
    add(side + "foot", side + "ankle", Vector3d(0, -7, 12));
  }
  return joints;
}

// Motion: per frame the local rotation (degrees, Z X Y order) of each joint and the root's position.
struct BvhFrame {
  Vector3d root;
  std::vector<Vector3d> zxy;  // per joint
};

enum class RestKind { standing, along_x, zero };

// Writes the skeleton with its rest offsets standing, lying along +x (each offset's length along
// the file's X axis, as the dataset the issue names writes them) or all zero; with
// `position_channels` every joint carries position channels whose values are the standing
// offsets (the root's: the frame's position), else only the root does.
inline std::string write_bvh(const std::string& name, const std::vector<BvhJoint>& joints, const std::vector<BvhFrame>& frames,
                      RestKind rest, bool position_channels) {
  std::ostringstream out;
  out.precision(10);
  out << "HIERARCHY\n";
  std::vector<std::vector<int>> children(joints.size());
  for (std::size_t j = 1; j < joints.size(); ++j) children[joints[j].parent].push_back(static_cast<int>(j));
  std::vector<int> order;  // file order: depth first
  const std::function<void(int, int)> write = [&](int j, int depth) {
    const std::string pad(depth, ' ');
    order.push_back(j);
    out << pad << (j == 0 ? "ROOT " : "JOINT ") << joints[j].name << "\n" << pad << "{\n";
    Vector3d offset = joints[j].offset;
    if (rest == RestKind::along_x) offset = Vector3d(offset.norm(), 0, 0);
    if (rest == RestKind::zero) offset.setZero();
    out << pad << " OFFSET " << offset.x() << " " << offset.y() << " " << offset.z() << "\n";
    out << pad << (j == 0 || position_channels ? " CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\n"
                                               : " CHANNELS 3 Zrotation Xrotation Yrotation\n");
    if (children[j].empty()) {
      out << pad << " End Site\n" << pad << " {\n" << pad << "  OFFSET 0 " << (rest == RestKind::zero ? 0 : 5) << " 0\n"
          << pad << " }\n";
    }
    for (int child : children[j]) write(child, depth + 1);
    out << pad << "}\n";
  };
  write(0, 0);
  out << "MOTION\nFrames: " << frames.size() << "\nFrame Time: 0.0333333\n";
  for (const BvhFrame& frame : frames) {
    for (int j : order) {
      if (j == 0) out << frame.root.x() << " " << frame.root.y() << " " << frame.root.z() << " ";
      else if (position_channels) out << joints[j].offset.x() << " " << joints[j].offset.y() << " " << joints[j].offset.z() << " ";
      out << frame.zxy[j].x() << " " << frame.zxy[j].y() << " " << frame.zxy[j].z() << " ";
    }
    out << "\n";
  }
  const auto* test = testing::UnitTest::GetInstance()->current_test_info();
  const std::filesystem::path dir = scratch_root() / "humanoid_bvh" / (std::string(test->test_suite_name()) + "." + test->name());
  std::filesystem::create_directories(dir);
  const std::filesystem::path path = dir / name;
  std::ofstream(path) << out.str();
  return path.string();
}

// A walk in place moving forward: legs swing 25 degrees about X, knees bend up to 40, arms hang
// 70 degrees down from the T-pose and swing against the legs; frame 0 stands with legs straight.
inline std::vector<BvhFrame> walk_frames(const std::vector<BvhJoint>& joints, int count) {
  std::vector<BvhFrame> frames;
  for (int f = 0; f < count; ++f) {
    const double phase = 2 * M_PI * f / 30.0;
    BvhFrame frame;
    frame.root = Vector3d(0, 98 + 2 * std::sin(2 * phase), 3.0 * f);
    frame.zxy.assign(joints.size(), Vector3d::Zero());
    for (std::size_t j = 0; j < joints.size(); ++j) {
      const std::string& c = joints[j].canonical;
      const double sign = c.starts_with("left") ? 1 : -1;
      if (c.ends_with("_hip")) frame.zxy[j] = Vector3d(0, -25 * sign * std::sin(phase), 0);
      if (c.ends_with("_knee")) frame.zxy[j] = Vector3d(0, 20 * (1 - std::cos(phase + (sign > 0 ? 0 : M_PI))) * (f > 0), 0);
      if (c.ends_with("_shoulder")) frame.zxy[j] = Vector3d(-70 * sign, 20 * sign * std::sin(phase), 0);
    }
    frames.push_back(frame);
  }
  return frames;
}

inline std::map<std::string, std::string> plain_names() {
  std::map<std::string, std::string> names = {{"pelvis", "Hips"}, {"spine1", "Spine"}, {"spine3", "Chest"},
                                              {"neck", "Neck"},    {"head", "Head"}};
  for (const auto& [side, suffix] : {std::pair("left_", "_L"), std::pair("right_", "_R")}) {
    names[std::string(side) + "collar"] = std::string("Shoulder") + suffix;
    names[std::string(side) + "shoulder"] = std::string("UpperArm") + suffix;
    names[std::string(side) + "elbow"] = std::string("LowerArm") + suffix;
    names[std::string(side) + "wrist"] = std::string("Hand") + suffix;
    names[std::string(side) + "hip"] = std::string("UpperLeg") + suffix;
    names[std::string(side) + "knee"] = std::string("LowerLeg") + suffix;
    names[std::string(side) + "ankle"] = std::string("Foot") + suffix;
    names[std::string(side) + "foot"] = std::string("Toes") + suffix;
  }
  return names;
}

}  // namespace odyssey::test_support::humanoid_bvh
