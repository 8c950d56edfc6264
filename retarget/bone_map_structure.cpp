#include "retarget/bone_map_structure.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <sstream>

#include "retarget/geometry.h"

namespace odyssey::retarget {

namespace {

// The fractions of the height H that the header names.
constexpr double kToeSeparation = 0.25;   // a second foot's common ancestor from both feet
constexpr double kHandSeparation = 0.2;   // a second hand's likewise
constexpr double kHandSideways = 0.08;    // a hand's leaf at least this sideways of the pelvis
constexpr double kAnkleBand = 0.3;        // the ankle: the first joint this low in the leg's height
constexpr double kHipSideways = 0.02;     // the hip: the first joint this far sideways of the pelvis
constexpr double kTipShortness = 0.4;     // a leaf bone under this of the one before ends the hand
constexpr double kUpperArmOverForearm = 1.15;
constexpr double kChestAbovePelvis = 0.1;
constexpr double kAnklesBelowPelvis = 0.15;

struct Structure {
  const Skeleton& rig;
  std::vector<Eigen::Vector3d> at;  // rest positions
  std::vector<bool> active;         // not pruned
  std::vector<bool> helper;         // sits on its parent
  std::vector<std::vector<int>> children;  // active children
  double height = 0;
  double low = 0;  // lowest z of an active joint

  std::string name(int j) const { return "'" + rig.name(j) + "'"; }

  double horizontal(const Eigen::Vector3d& v) const { return std::hypot(v.x(), v.y()); }

  int common_ancestor(int a, int b) const {
    for (int j = a; j >= 0; j = rig.parent(j)) {
      if (is_ancestor(rig, j, b)) return j;
    }
    return -1;
  }

  // Joints strictly below `from` down to `to` (a descendant), from the top, helpers left out.
  std::vector<int> path(int from, int to) const {
    std::vector<int> joints;
    for (int j = to; j >= 0 && j != from; j = rig.parent(j)) {
      if (!helper[j]) joints.push_back(j);
    }
    std::reverse(joints.begin(), joints.end());
    return joints;
  }

  std::vector<int> leaves() const {
    std::vector<int> result;
    for (int j = 0; j < rig.joint_count(); ++j) {
      if (active[j] && children[j].empty()) result.push_back(j);
    }
    return result;
  }

  // Whether `joint` lies in the subtree of one of `tops`.
  bool below_any(int joint, const std::vector<int>& tops) const {
    return std::any_of(tops.begin(), tops.end(), [&](int top) { return is_ancestor(rig, top, joint); });
  }

  // The child of `ancestor` on the way down to `joint`.
  int child_towards(int ancestor, int joint) const {
    for (int j = joint; j >= 0; j = rig.parent(j)) {
      if (rig.parent(j) == ancestor) return j;
    }
    return -1;
  }

  // The furthest any joint of the subtree of `top` lies horizontally from `from`.
  double horizontal_reach(int top, const Eigen::Vector3d& from) const {
    double reach = horizontal(at[top] - from);
    for (int j = top + 1; j < rig.joint_count(); ++j) {
      if (active[j] && is_ancestor(rig, top, j)) reach = std::max(reach, horizontal(at[j] - from));
    }
    return reach;
  }
};

Structure structure_of(const Skeleton& rig, const std::vector<bool>& binds) {
  Structure s{rig, {}, {}, {}, {}, 0, 0};
  for (const RigidTransform<double>& joint : rig.rest_world()) s.at.push_back(joint.translation);
  const int n = rig.joint_count();
  Eigen::AlignedBox3d box;
  for (const Eigen::Vector3d& p : s.at) box.extend(p);
  const double size = box.isEmpty() ? 0.0 : box.diagonal().norm();
  s.helper.assign(n, false);
  for (int j = 0; j < n; ++j) s.helper[j] = rig.parent(j) >= 0 && rig.rest_offsets()[j].norm() < 1e-4 * std::max(size, 1e-12);
  // Prune leaves that bind nothing or sit on their parent, repeatedly (parents come first, so a
  // backward pass sees every child before its parent).
  s.active.assign(n, true);
  std::vector<int> active_children(n, 0);
  for (int j = 0; j < n; ++j) {
    if (rig.parent(j) >= 0) ++active_children[rig.parent(j)];
  }
  for (int j = n - 1; j >= 0; --j) {
    const bool unbound = !binds.empty() && !binds[j];
    if (active_children[j] == 0 && (unbound || s.helper[j]) && rig.parent(j) >= 0) {
      s.active[j] = false;
      --active_children[rig.parent(j)];
    }
  }
  s.children.assign(n, {});
  double high = -1e300;
  s.low = 1e300;
  for (int j = 0; j < n; ++j) {
    if (!s.active[j]) continue;
    if (rig.parent(j) >= 0) s.children[rig.parent(j)].push_back(j);
    s.low = std::min(s.low, s.at[j].z());
    high = std::max(high, s.at[j].z());
  }
  s.height = high > s.low ? high - s.low : 0.0;
  return s;
}

struct Leg {
  int hip = -1, knee = -1, ankle = -1, ball = -1;
};
struct Arm {
  int collar = -1, shoulder = -1, elbow = -1, wrist = -1;
};

// Along the path from the pelvis to a foot's lowest leaf (see the header).
std::optional<Leg> find_leg(const Structure& s, int pelvis, int foot, std::string& problem) {
  const std::vector<int> path = s.path(pelvis, foot);
  Leg leg;
  int ankle_at = -1;
  if (!path.empty()) {
    const double leg_height = s.at[path.front()].z() - s.low;
    for (std::size_t k = 1; k < path.size() && ankle_at < 0; ++k) {
      if (s.at[path[k]].z() - s.low < kAnkleBand * leg_height) ankle_at = static_cast<int>(k);
    }
  }
  if (ankle_at < 2) {
    problem = "the leg chain from " + s.name(pelvis) + " to " + s.name(foot) + " has no hip and knee above an ankle";
    return std::nullopt;
  }
  leg.ankle = path[ankle_at];
  double reach = 0;
  for (int child : s.children[leg.ankle]) {
    const double r = s.horizontal_reach(child, s.at[leg.ankle]);
    if (r > reach) {
      reach = r;
      leg.ball = child;
    }
  }
  // A ball that is a helper stands for the joint below it that has length.
  while (leg.ball >= 0 && s.helper[leg.ball] && s.children[leg.ball].size() == 1) leg.ball = s.children[leg.ball].front();
  if (leg.ball >= 0 && s.helper[leg.ball]) leg.ball = -1;
  int hip_at = 0;
  for (int k = 0; k < ankle_at; ++k) {
    if (s.horizontal(s.at[path[k]] - s.at[pelvis]) > kHipSideways * s.height) {
      hip_at = k;
      break;
    }
  }
  while (hip_at + 1 < ankle_at && (s.at[path[hip_at + 1]] - s.at[path[hip_at]]).norm() < 1e-4 * s.height) ++hip_at;
  leg.hip = path[hip_at];
  double best = 1e300;
  for (int k = hip_at + 1; k < ankle_at; ++k) {
    const double upper = (s.at[path[k]] - s.at[leg.hip]).norm(), lower = (s.at[leg.ankle] - s.at[path[k]]).norm();
    if (upper <= 0 || lower <= 0) continue;
    const double misfit = std::abs(std::log(upper / lower));
    if (misfit < best) {
      best = misfit;
      leg.knee = path[k];
    }
  }
  if (leg.knee < 0) {
    problem = "the leg chain from " + s.name(leg.hip) + " to the ankle " + s.name(leg.ankle) + " has no knee between";
    return std::nullopt;
  }
  return leg;
}

int rig_parent(const Structure& s, int joint) { return s.rig.parent(joint); }

// Along the path from the chest to a hand's leaf (see the header).
std::optional<Arm> find_arm(const Structure& s, int chest, int hand, std::string& problem) {
  const std::vector<int> path = s.path(chest, hand);
  Arm arm;
  int wrist_at = -1;
  for (std::size_t k = 0; k < path.size() && wrist_at < 0; ++k) {
    int fingers = 0;
    for (int child : s.children[path[k]]) {
      if (!s.children[child].empty()) ++fingers;
    }
    if (fingers >= 2) wrist_at = static_cast<int>(k);
  }
  if (wrist_at < 0 && !path.empty()) {
    wrist_at = static_cast<int>(path.size()) - 1;
    if (path.size() >= 3) {
      const double last = (s.at[path.back()] - s.at[path[path.size() - 2]]).norm();
      const double before = (s.at[path[path.size() - 2]] - s.at[path[path.size() - 3]]).norm();
      if (last < kTipShortness * before) --wrist_at;
    }
  }
  if (wrist_at < 2) {
    problem = "the arm chain from " + s.name(chest) + " to " + s.name(hand) + " has fewer than three joints to a wrist";
    return std::nullopt;
  }
  arm.wrist = path[wrist_at];
  double best = 1e300;
  int shoulder_at = -1;
  for (int a = 0; a < wrist_at; ++a) {
    for (int b = a + 1; b < wrist_at; ++b) {
      const double upper = (s.at[path[b]] - s.at[path[a]]).norm(), fore = (s.at[arm.wrist] - s.at[path[b]]).norm();
      if (upper <= 0 || fore <= 0) continue;
      const double misfit = std::abs(std::log(upper / fore / kUpperArmOverForearm));
      if (misfit < best) {
        best = misfit;
        shoulder_at = a;
        arm.elbow = path[b];
      }
    }
  }
  arm.shoulder = path[shoulder_at];
  // The collar is the shoulder's parent below the chest, even one sitting on the chest (CMU's
  // LeftShoulder): its bone, out to the shoulder, is the clavicle.
  if (rig_parent(s, arm.shoulder) != chest && rig_parent(s, arm.shoulder) >= 0) arm.collar = rig_parent(s, arm.shoulder);
  return arm;
}

StructureMap refuse(std::string problem) {
  StructureMap result;
  result.problem = std::move(problem);
  return result;
}

}  // namespace

std::vector<bool> joints_binding_vertices(const Character& character) {
  std::vector<bool> binds(character.skeleton.joint_count(), false);
  for (const CharacterMesh& mesh : character.meshes) {
    for (std::size_t v = 0; v < mesh.influence_slots.size() && v < mesh.influence_weights.size(); ++v) {
      for (int i = 0; i < 4; ++i) {
        const int slot = mesh.influence_slots[v][i];
        if (mesh.influence_weights[v][i] > 0 && slot < static_cast<int>(mesh.skin_joints.size())) {
          const int joint = mesh.skin_joints[slot];
          if (joint >= 0 && joint < static_cast<int>(binds.size())) binds[joint] = true;
        }
      }
    }
  }
  return binds;
}

StructureMap bone_map_from_structure(const Character& character) {
  std::vector<bool> binds = joints_binding_vertices(character);
  if (std::none_of(binds.begin(), binds.end(), [](bool b) { return b; })) binds.clear();
  return bone_map_from_structure(character.skeleton, binds);
}

StructureMap bone_map_from_structure(const Skeleton& rig, const std::vector<bool>& binds) {
  using namespace canonical;
  const Structure s = structure_of(rig, binds);
  if (rig.joint_count() < 2 || !(s.height > 0)) {
    return refuse("found " + std::to_string(rig.joint_count()) + " joints and no height to stand on");
  }
  std::vector<int> leaves = s.leaves();
  std::sort(leaves.begin(), leaves.end(), [&](int a, int b) { return s.at[a].z() < s.at[b].z(); });
  if (leaves.size() < 2) return refuse("found " + std::to_string(leaves.size()) + " chain end, no two leg chains");

  // Legs.
  const int foot_a = leaves.front();
  int foot_b = -1, pelvis = -1;
  for (int leaf : leaves) {
    if (leaf == foot_a) continue;
    const int meet = s.common_ancestor(foot_a, leaf);
    if (meet < 0) continue;
    if ((s.at[foot_a] - s.at[meet]).norm() >= kToeSeparation * s.height &&
        (s.at[leaf] - s.at[meet]).norm() >= kToeSeparation * s.height) {
      foot_b = leaf;
      pelvis = meet;
      break;
    }
  }
  if (foot_b < 0) {
    return refuse("found one leg chain (down to " + s.name(foot_a) + ") and no second one branching off it " +
                  std::to_string(kToeSeparation).substr(0, 4) + " of the height away");
  }
  const std::vector<int> leg_tops = {s.child_towards(pelvis, foot_a), s.child_towards(pelvis, foot_b)};

  // Arms: leaves below the pelvis, outside the legs, furthest sideways of its vertical.
  std::vector<int> arm_leaves;
  for (int leaf : leaves) {
    if (leaf != pelvis && is_ancestor(rig, pelvis, leaf) && !s.below_any(leaf, leg_tops) &&
        s.horizontal(s.at[leaf] - s.at[pelvis]) > kHandSideways * s.height) {
      arm_leaves.push_back(leaf);
    }
  }
  const auto sideways = [&](int j) { return s.horizontal(s.at[j] - s.at[pelvis]); };
  std::sort(arm_leaves.begin(), arm_leaves.end(), [&](int a, int b) { return sideways(a) > sideways(b); });
  const std::string legs_found = "two leg chains from " + s.name(pelvis);
  if (arm_leaves.empty()) return refuse("found " + legs_found + " and no arm chains");
  const int hand_a = arm_leaves.front();
  int hand_b = -1, chest = -1;
  for (int leaf : arm_leaves) {
    if (leaf == hand_a) continue;
    Eigen::Vector3d da = s.at[hand_a] - s.at[pelvis], db = s.at[leaf] - s.at[pelvis];
    da.z() = db.z() = 0;
    if (!(da.dot(db) < 0)) continue;
    const int meet = s.common_ancestor(hand_a, leaf);
    if (meet < 0) continue;
    if ((s.at[hand_a] - s.at[meet]).norm() >= kHandSeparation * s.height &&
        (s.at[leaf] - s.at[meet]).norm() >= kHandSeparation * s.height) {
      hand_b = leaf;
      chest = meet;
      break;
    }
  }
  if (hand_b < 0) return refuse("found " + legs_found + " and one arm chain (out to " + s.name(hand_a) + "), no second on the other side");
  const std::string found = legs_found + " and two arm chains from " + s.name(chest);
  if (!(s.at[chest].z() - s.at[pelvis].z() > kChestAbovePelvis * s.height)) {
    return refuse("found " + found + ", but that chest is not above the pelvis: no spine rises between them");
  }

  // Head: the highest joint above the chest outside the arms.
  const std::vector<int> arm_tops = {s.child_towards(chest, hand_a), s.child_towards(chest, hand_b)};
  int top = -1;
  for (int j = 0; j < rig.joint_count(); ++j) {
    if (!s.active[j] || j == chest || !is_ancestor(rig, chest, j) || s.below_any(j, arm_tops)) continue;
    if (top < 0 || s.at[j].z() > s.at[top].z()) top = j;
  }
  if (top < 0 || !(s.at[top].z() > s.at[chest].z())) return refuse("found " + found + ", and no head chain above the chest");
  const std::vector<int> head_path = s.path(chest, top);
  int head = top;
  for (int j : head_path) {
    if (s.children[j].size() != 1) {
      head = j;
      break;
    }
  }
  int neck = -1;
  if (!head_path.empty() && head_path.front() != head) neck = head_path.front();

  std::string problem;
  std::optional<Leg> legs[2] = {find_leg(s, pelvis, foot_a, problem), std::nullopt};
  if (!legs[0]) return refuse("found " + found + ", but " + problem);
  legs[1] = find_leg(s, pelvis, foot_b, problem);
  if (!legs[1]) return refuse("found " + found + ", but " + problem);
  std::optional<Arm> arms[2] = {find_arm(s, chest, hand_a, problem), std::nullopt};
  if (!arms[0]) return refuse("found " + found + ", but " + problem);
  arms[1] = find_arm(s, chest, hand_b, problem);
  if (!arms[1]) return refuse("found " + found + ", but " + problem);
  for (const auto& leg : legs) {
    if (!(s.at[pelvis].z() - s.at[leg->ankle].z() > kAnklesBelowPelvis * s.height)) {
      return refuse("found " + found + ", but the ankle " + s.name(leg->ankle) + " is not below the pelvis as a standing leg's");
    }
  }

  // Sides, from where the feet point.
  Eigen::Vector3d facing = Eigen::Vector3d::Zero();
  for (const auto& leg : legs) {
    if (leg->ball >= 0) facing += s.at[leg->ball] - s.at[leg->ankle];
  }
  facing.z() = 0;
  if (facing.norm() < 0.01 * s.height) {
    return refuse("found " + found + ", but no foot points anywhere (no toe joint beyond the ankles) to tell left from right");
  }
  const Eigen::Vector3d left = Eigen::Vector3d::UnitZ().cross(facing);
  const auto is_left = [&](int joint, int from) { return (s.at[joint] - s.at[from]).dot(left) > 0; };
  const bool leg0_left = is_left(legs[0]->hip, pelvis), arm0_left = is_left(arms[0]->shoulder, chest);
  if (leg0_left == is_left(legs[1]->hip, pelvis)) return refuse("found " + found + ", but both legs on one side of the body");
  if (arm0_left == is_left(arms[1]->shoulder, chest)) return refuse("found " + found + ", but both arms on one side of the body");

  StructureMap result;
  BoneMap& map = result.map;
  map.origin = "skeleton structure";
  map.joints[canonical::pelvis] = pelvis;
  map.joints[spine3] = chest;
  std::vector<int> between = s.path(pelvis, chest);  // below the pelvis down to the chest
  if (!between.empty() && between.back() == chest) between.pop_back();
  if (!between.empty()) map.joints[spine1] = between.front();
  if (between.size() >= 2) map.joints[spine2] = between.back();
  map.joints[canonical::head] = head;
  if (neck >= 0) map.joints[canonical::neck] = neck;
  for (int k = 0; k < 2; ++k) {
    const bool l = k == 0 ? leg0_left : !leg0_left;
    const Leg& leg = *legs[k];
    map.joints[l ? left_hip : right_hip] = leg.hip;
    map.joints[l ? left_knee : right_knee] = leg.knee;
    map.joints[l ? left_ankle : right_ankle] = leg.ankle;
    if (leg.ball >= 0) map.joints[l ? left_foot : right_foot] = leg.ball;
  }
  for (int k = 0; k < 2; ++k) {
    const bool l = k == 0 ? arm0_left : !arm0_left;
    const Arm& arm = *arms[k];
    if (arm.collar >= 0) map.joints[l ? left_collar : right_collar] = arm.collar;
    map.joints[l ? left_shoulder : right_shoulder] = arm.shoulder;
    map.joints[l ? left_elbow : right_elbow] = arm.elbow;
    map.joints[l ? left_wrist : right_wrist] = arm.wrist;
  }
  return result;
}

}  // namespace odyssey::retarget
