#include "retarget/bone_map.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <optional>
#include <string_view>
#include <tuple>

#include "mocap_io/input_error.h"
#include "mocap_io/install_layout.h"
#include "retarget/bone_map_structure.h"
#include "retarget/geometry.h"

namespace odyssey::retarget {

namespace {

namespace fs = std::filesystem;

// ---------------------------------------------------------------------------------------------
// Names.

enum class Side { none, left, right };

struct ParsedName {
  Side side = Side::none;
  std::vector<std::string> words;  // lower case, side markers and rig prefixes removed
  int number = -1;                 // the first number after the first word, -1 when none
  bool end_marker = false;         // HeadTop_End, LeftToe_End, Bip01 L Toe0Nub, ...
  bool underscored = false;        // starts with '_': a helper (MakeHuman's __UpLeg_L above UpLeg_L)
};

bool is_upper(char c) { return std::isupper(static_cast<unsigned char>(c)) != 0; }
bool is_lower(char c) { return std::islower(static_cast<unsigned char>(c)) != 0; }
bool is_digit(char c) { return std::isdigit(static_cast<unsigned char>(c)) != 0; }
bool is_alnum(char c) { return std::isalnum(static_cast<unsigned char>(c)) != 0; }

// Splits at non-alphanumerics, at letter/digit changes, before an upper-case letter that follows
// a lower-case one ("UpLeg" -> Up Leg) and before the last of a run of capitals that starts a
// word ("LThumb" -> L Thumb, "LHipJoint" -> L Hip Joint).
std::vector<std::string> split_words(std::string_view name) {
  std::vector<std::string> words;
  std::string current;
  const auto flush = [&] {
    if (current.empty()) return;
    std::transform(current.begin(), current.end(), current.begin(),
                   [](char c) { return static_cast<char>(std::tolower(static_cast<unsigned char>(c))); });
    words.push_back(current);
    current.clear();
  };
  for (std::size_t i = 0; i < name.size(); ++i) {
    const char c = name[i];
    if (!is_alnum(c)) {
      flush();
      continue;
    }
    if (!current.empty()) {
      const char previous = current.back();
      const bool boundary = is_digit(c) != is_digit(previous) || (is_lower(previous) && is_upper(c)) ||
                            (is_upper(previous) && is_upper(c) && i + 1 < name.size() && is_lower(name[i + 1]));
      if (boundary) flush();
    }
    current += c;
  }
  flush();
  return words;
}

ParsedName parse_joint_name(std::string_view name) {
  if (const auto colon = name.rfind(':'); colon != std::string_view::npos) name = name.substr(colon + 1);
  static const std::vector<std::string_view> kRigPrefixes = {"mixamorig", "bip", "def", "b", "bn", "jnt", "joint",
                                                             "bone", "smplhf"};
  static const std::vector<std::string_view> kEndMarkers = {"end", "nub", "tip", "site"};
  ParsedName parsed;
  parsed.underscored = name.starts_with('_');
  const auto set_side = [&](Side side) {
    if (parsed.side == Side::none) parsed.side = side;
  };
  for (std::string word : split_words(name)) {
    if (word == "l" || word == "left") {
      set_side(Side::left);
      continue;
    }
    if (word == "r" || word == "right") {
      set_side(Side::right);
      continue;
    }
    // "lefthand" in names written without separators or case changes.
    if (word.size() > 4 && word.starts_with("left")) {
      set_side(Side::left);
      word = word.substr(4);
    } else if (word.size() > 5 && word.starts_with("right")) {
      set_side(Side::right);
      word = word.substr(5);
    }
    if (std::find(kEndMarkers.begin(), kEndMarkers.end(), word) != kEndMarkers.end()) parsed.end_marker = true;
    if (is_digit(word.front())) {
      if (!parsed.words.empty() && parsed.number < 0 && word.size() <= 3) {
        std::from_chars(word.data(), word.data() + word.size(), parsed.number);
      }
      continue;
    }
    if (std::find(kRigPrefixes.begin(), kRigPrefixes.end(), word) != kRigPrefixes.end()) continue;
    parsed.words.push_back(word);
  }
  return parsed;
}

// A body joint named by `key` (the words run together): the canonical joint (left side for
// sided roles) and a rank, 0 for an unambiguous word, 1 for a word other conventions use for a
// neighbouring joint.
struct Synonym {
  std::string_view key;
  int left_canonical;  // for unsided roles, the joint itself
  bool sided;
  int rank;
};

const std::vector<Synonym>& synonyms() {
  using namespace canonical;
  static const std::vector<Synonym> kSynonyms = {
      {"hips", pelvis, false, 0},        {"pelvis", pelvis, false, 0},        {"hip", pelvis, false, 1},
      {"neck", neck, false, 0},          {"head", head, false, 0},            {"jaw", jaw, false, 0},
      {"eye", left_eye, true, 0},        {"collar", left_collar, true, 0},    {"clavicle", left_collar, true, 0},
      {"clav", left_collar, true, 0},    {"shoulder", left_collar, true, 1},  {"upperarm", left_shoulder, true, 0},
      {"arm", left_shoulder, true, 0},   {"uparm", left_shoulder, true, 0},   {"humerus", left_shoulder, true, 0},
      {"shoulder", left_shoulder, true, 1}, {"forearm", left_elbow, true, 0}, {"lowerarm", left_elbow, true, 0},
      {"elbow", left_elbow, true, 0},    {"loarm", left_elbow, true, 0},      {"wrist", left_wrist, true, 0},
      {"hand", left_wrist, true, 1},     {"upleg", left_hip, true, 0},        {"upperleg", left_hip, true, 0},
      {"thigh", left_hip, true, 0},      {"femur", left_hip, true, 0},        {"hip", left_hip, true, 1},
      {"knee", left_knee, true, 0},      {"shin", left_knee, true, 0},        {"calf", left_knee, true, 0},
      {"lowerleg", left_knee, true, 0},  {"loleg", left_knee, true, 0},       {"leg", left_knee, true, 1},
      {"ankle", left_ankle, true, 0},    {"foot", left_ankle, true, 1},       {"toe", left_foot, true, 0},
      {"toes", left_foot, true, 0},      {"toebase", left_foot, true, 0},     {"ball", left_foot, true, 0},
      {"foot", left_foot, true, 1},
  };
  return kSynonyms;
}

// Finger words -> the canonical finger name stem.
std::optional<std::string_view> finger_of(const std::string& word) {
  if (word == "thumb") return "thumb";
  if (word == "index" || word == "pointer") return "index";
  if (word == "middle") return "middle";
  if (word == "ring") return "ring";
  if (word == "pinky" || word == "pinkie" || word == "little") return "pinky";
  return std::nullopt;
}

int sided(int left_canonical, Side side) {
  return side == Side::left ? left_canonical : canonical_mirror(left_canonical);
}

struct Candidate {
  int joint;
  int rank;
  bool underscored = false;  // ParsedName::underscored
  int number = 0;            // ParsedName::number, 0 when none
};

// A prefix every joint name shares, up to and including a separator ("Character1_" in
// MotionBuilder exports, "mixamorig:" in Mixamo's): it names the rig, not the joint.
std::size_t shared_prefix_length(const Skeleton& rig) {
  if (rig.joint_count() < 2) return 0;
  std::string_view prefix = rig.name(0);
  for (const std::string& name : rig.names()) {
    std::size_t n = 0;
    while (n < prefix.size() && n < name.size() && prefix[n] == name[n]) ++n;
    prefix = prefix.substr(0, n);
  }
  const std::size_t separator = prefix.find_last_of(":_.- ");
  return separator == std::string_view::npos ? 0 : separator + 1;
}

// Which canonical joints each rig joint's name could play.
std::vector<std::vector<Candidate>> name_candidates(const Skeleton& rig) {
  std::vector<std::vector<Candidate>> by_canonical(kCanonicalJointCount);
  const std::size_t prefix = shared_prefix_length(rig);
  for (int j = 0; j < rig.joint_count(); ++j) {
    const ParsedName parsed = parse_joint_name(std::string_view(rig.name(j)).substr(prefix));
    if (parsed.end_marker || parsed.words.empty()) continue;
    std::optional<std::string_view> finger;
    for (const std::string& word : parsed.words) {
      if (!finger) finger = finger_of(word);
    }
    if (finger) {
      if (parsed.side == Side::none) continue;
      const int number = parsed.number < 0 ? 1 : parsed.number;
      if (number < 1 || number > 3) continue;
      const std::string name = std::string(parsed.side == Side::left ? "left_" : "right_") + std::string(*finger) +
                               std::to_string(number);
      by_canonical[canonical_index(name)].push_back({j, parsed.number < 0 ? 1 : 0, parsed.underscored, 0});
      continue;
    }
    std::string key;
    for (const std::string& word : parsed.words) key += word;
    for (const Synonym& synonym : synonyms()) {
      if (synonym.key != key || synonym.sided != (parsed.side != Side::none)) continue;
      const int canonical = synonym.sided ? sided(synonym.left_canonical, parsed.side) : synonym.left_canonical;
      by_canonical[canonical].push_back({j, synonym.rank, parsed.underscored, std::max(parsed.number, 0)});
    }
  }
  return by_canonical;
}

// ---------------------------------------------------------------------------------------------
// Hierarchy helpers.

int lowest_common_ancestor(const Skeleton& rig, int a, int b) {
  for (int j = a; j >= 0; j = rig.parent(j)) {
    if (is_ancestor(rig, j, b)) return j;
  }
  return -1;
}

// Joints that sit on their parent at rest (CMU's LHipJoint, LowerBack, Neck): they carry no bone.
std::vector<bool> sits_on_parent(const Skeleton& rig) {
  const std::vector<RigidTransform<double>> rest = rig.rest_world();
  Eigen::AlignedBox3d box;
  for (const auto& joint : rest) box.extend(joint.translation);
  const double tolerance = 1e-4 * std::max(box.diagonal().norm(), 1e-12);
  std::vector<bool> result(rig.joint_count(), false);
  for (int j = 0; j < rig.joint_count(); ++j) {
    result[j] = rig.parent(j) >= 0 && rig.rest_offsets()[j].norm() < tolerance;
  }
  return result;
}

// The order in which canonical joints claim their candidates: the roles whose words are also
// used for a neighbour claim first (upper arm before clavicle, ankle before the ball of the foot,
// knee before ankle), so the leftover word falls to the neighbour.
std::vector<int> claim_order() {
  using namespace canonical;
  std::vector<int> order = {pelvis,        head,          neck,         jaw,         left_eye,    right_eye,
                            left_shoulder, right_shoulder, left_collar, right_collar, left_elbow, right_elbow,
                            left_wrist,    right_wrist,   left_hip,     right_hip,    left_knee,  right_knee,
                            left_ankle,    right_ankle,   left_foot,    right_foot};
  for (int c = left_index1; c < kCanonicalJointCount; ++c) order.push_back(c);
  return order;
}

std::vector<std::vector<int>> children_of(const Skeleton& rig) {
  std::vector<std::vector<int>> children(rig.joint_count());
  for (int j = 0; j < rig.joint_count(); ++j) {
    if (rig.parent(j) >= 0) children[rig.parent(j)].push_back(j);
  }
  return children;
}

// A rig that names no head (Rigify's spine.004 .. spine.006 continue the spine into the neck and
// head): the head is the top of the chain that leaves the chest (or the named neck) and carries
// no arm, walked while each joint has one child that is not an end marker (a head with face bones
// has several, a leaf head none); the neck, if unnamed, is the chain's first joint when the chain
// has two or more. Zero-length helpers are skipped.
void map_neck_and_head_from_chain(const Skeleton& rig, const std::vector<bool>& helper, BoneMap& map) {
  using namespace canonical;
  if (map.mapped(head)) return;
  const int from = map.mapped(neck) ? map.joints[neck] : map.joints[spine3];
  if (from < 0) return;
  const std::vector<std::vector<int>> children = children_of(rig);
  const auto carries_arm = [&](int j) {
    for (int c : {left_collar, right_collar, left_shoulder, right_shoulder}) {
      if (map.mapped(c) && is_ancestor(rig, j, map.joints[c])) return true;
    }
    return false;
  };
  const auto chain_children = [&](int j) {
    std::vector<int> next;
    for (int child : children[j]) {
      if (map.canonical_of(child) < 0 && !parse_joint_name(rig.name(child)).end_marker && !carries_arm(child)) next.push_back(child);
    }
    return next;
  };
  std::vector<int> chain;
  if (map.mapped(neck)) chain.push_back(from);
  for (std::vector<int> next = chain_children(from); next.size() == 1; next = chain_children(next.front())) {
    if (!helper[next.front()]) chain.push_back(next.front());
  }
  if (chain.empty() || (map.mapped(neck) && chain.size() < 2)) return;
  map.joints[head] = chain.back();
  if (!map.mapped(neck) && chain.size() >= 2) map.joints[neck] = chain.front();
}

}  // namespace

BoneMap bone_map_from_names(const Skeleton& rig) {
  using namespace canonical;
  const std::vector<std::vector<Candidate>> candidates = name_candidates(rig);
  const std::vector<bool> helper = sits_on_parent(rig);
  BoneMap map;
  map.origin = "joint names";
  std::vector<bool> claimed(rig.joint_count(), false);
  for (int c : claim_order()) {
    const Candidate* best = nullptr;
    for (const Candidate& candidate : candidates[c]) {
      if (claimed[candidate.joint]) continue;
      const auto key = [&](const Candidate& x) {
        return std::tuple(x.rank, helper[x.joint] ? 1 : 0, x.underscored ? 1 : 0, x.number, x.joint);
      };
      if (!best || key(candidate) < key(*best)) best = &candidate;
    }
    if (best) {
      map.joints[c] = best->joint;
      claimed[best->joint] = true;
    }
  }

  // The pelvis is where both legs and the upper body meet (MakeHuman's legs hang from Hips, its
  // spine from Root, the parent of both).
  if (map.mapped(left_hip) && map.mapped(right_hip)) {
    int body_meet = lowest_common_ancestor(rig, map.joints[left_hip], map.joints[right_hip]);
    for (int upper : {neck, head, left_collar, right_collar, left_shoulder, right_shoulder}) {
      if (map.mapped(upper) && body_meet >= 0) body_meet = lowest_common_ancestor(rig, body_meet, map.joints[upper]);
    }
    const int named = map.joints[pelvis];
    if (body_meet >= 0 && (named < 0 || !is_ancestor(rig, named, body_meet))) {
      if (map.canonical_of(body_meet) >= 0) map.joints[map.canonical_of(body_meet)] = -1;
      map.joints[pelvis] = body_meet;
    }
  }

  // The spine: the chain from the pelvis to the chest the neck and both arms hang from.
  std::vector<int> hanging;
  for (const auto& [collar, upper_arm] : {std::pair(left_collar, left_shoulder), std::pair(right_collar, right_shoulder)}) {
    if (map.mapped(collar)) hanging.push_back(map.joints[collar]);
    else if (map.mapped(upper_arm)) hanging.push_back(map.joints[upper_arm]);
  }
  if (map.mapped(neck)) hanging.push_back(map.joints[neck]);
  else if (map.mapped(head)) hanging.push_back(map.joints[head]);
  if (map.mapped(pelvis) && hanging.size() >= 2) {
    int chest = hanging[0];
    for (std::size_t k = 1; k < hanging.size() && chest >= 0; ++k) chest = lowest_common_ancestor(rig, chest, hanging[k]);
    const int pelvis_joint = map.joints[pelvis];
    if (chest >= 0 && chest != pelvis_joint && is_ancestor(rig, pelvis_joint, chest) && map.canonical_of(chest) < 0) {
      map.joints[spine3] = chest;
      std::vector<int> chain;  // between pelvis and chest, walked down from the chest
      for (int j = rig.parent(chest); j != pelvis_joint; j = rig.parent(j)) {
        if (!helper[j] && map.canonical_of(j) < 0) chain.push_back(j);
      }
      std::reverse(chain.begin(), chain.end());  // now from the pelvis up
      if (!chain.empty()) map.joints[spine1] = chain.front();
      if (chain.size() >= 2) map.joints[spine2] = chain.back();
    }
  }
  map_neck_and_head_from_chain(rig, helper, map);
  return map;
}

namespace {

// The prefix every rig joint name of a preset shares, up to and including its last separator
// (mixamo's "mixamorig:", humanik's "Character1_", max_biped's "Bip01 "), or empty: it names the
// rig or the character, not the joint, and a rig may carry another in its place.
std::string preset_prefix(const io::BoneMapFile& preset) {
  std::optional<std::string> prefix;
  for (const io::BoneMapEntry& entry : preset.entries) {
    for (const std::string& name : entry.rig_joints) {
      if (!prefix) {
        prefix = name;
        continue;
      }
      std::size_t n = 0;
      while (n < prefix->size() && n < name.size() && (*prefix)[n] == name[n]) ++n;
      prefix->resize(n);
    }
  }
  if (!prefix) return {};
  const std::size_t separator = prefix->find_last_of(":_.- ");
  return separator == std::string::npos ? std::string() : prefix->substr(0, separator + 1);
}

bool is_separator(char c) { return c == ':' || c == '_' || c == '.' || c == '-' || c == ' '; }

// The preset's map restricted to the joints the rig has, with the preset's own name prefix
// replaced by `rig_prefix`; an empty map when the rig lacks one of the preset's body joints
// (pelvis .. wrists, the balls of the feet excepted: files of one convention have them or not, as
// hands and face may be missing on a Mixamo rig exported without fingers). `found` counts the
// entries taken.
BoneMap map_from_preset_where_found(const Skeleton& rig, const io::BoneMapFile& preset, const std::string& name,
                                    const std::string& preset_prefix, const std::string& rig_prefix, int& found) {
  BoneMap map;
  map.origin = "preset " + name;
  found = 0;
  const auto in_rig = [&](const std::string& joint) { return rig.find(rig_prefix + joint.substr(preset_prefix.size())); };
  for (const io::BoneMapEntry& entry : preset.entries) {
    const int c = canonical_index(entry.canonical);
    if (c < 0) throw io::InputError("preset " + name, "unknown canonical joint '" + entry.canonical + "'");
    if (entry.rig_joints.empty()) continue;
    const int joint = in_rig(entry.rig_joints.front());
    const bool required = c <= canonical::right_wrist && c != canonical::left_foot && c != canonical::right_foot;
    if (joint < 0 && required) {
      found = 0;
      return BoneMap();
    }
    if (joint < 0) continue;
    map.joints[c] = joint;
    ++found;
    for (std::size_t k = 1; k < entry.rig_joints.size(); ++k) {
      const int follower = in_rig(entry.rig_joints[k]);
      if (follower >= 0) map.followers.push_back({follower, c});
    }
  }
  return map;
}

// The preset on the rig under every prefix the rig could use in place of the preset's own: the
// preset's, and, for a preset with a prefix, each non-empty one ending in a separator that puts a
// rig joint where the preset's pelvis is (Character2_Hips for Character1_Hips, Bip001 Pelvis for
// Bip01 Pelvis). The prefix that finds most wins, the preset's own among equals. `exact` says
// whether that was the preset's own prefix.
BoneMap map_from_preset(const Skeleton& rig, const io::BoneMapFile& preset, const std::string& name, int& found,
                        bool& exact) {
  const std::string own = preset_prefix(preset);
  std::vector<std::string> prefixes = {own};
  if (!own.empty()) {
    std::string pelvis;
    for (const io::BoneMapEntry& entry : preset.entries) {
      if (entry.canonical == "pelvis" && !entry.rig_joints.empty()) pelvis = entry.rig_joints.front().substr(own.size());
    }
    for (const std::string& joint : rig.names()) {
      if (pelvis.empty() || joint.size() <= pelvis.size() || !joint.ends_with(pelvis)) continue;
      const std::string prefix = joint.substr(0, joint.size() - pelvis.size());
      if (is_separator(prefix.back()) && std::find(prefixes.begin(), prefixes.end(), prefix) == prefixes.end()) {
        prefixes.push_back(prefix);
      }
    }
  }
  BoneMap best;
  found = 0;
  exact = false;
  for (const std::string& prefix : prefixes) {
    int count = 0;
    BoneMap map = map_from_preset_where_found(rig, preset, name, own, prefix, count);
    if (count > found) {
      best = std::move(map);
      found = count;
      exact = prefix == own;
    }
  }
  return best;
}

std::string joined(const std::vector<std::string>& items, const char* separator) {
  std::string text;
  for (std::size_t i = 0; i < items.size(); ++i) text += (i ? separator : "") + items[i];
  return text;
}

// Whether the joints mapped left are on the rig's left, from where the rig faces in its rest
// pose. Which way a rig faces after import is anyone's guess (armatures turned at the root, +Y or
// -Y or +X forward), so facing is read from the body itself, horizontally, by every cue the map
// has: the feet (ankle -> ball of the foot), the eyes (head -> between the eyes) and the jaw
// (head -> jaw). The rig's left is up x facing; the mapped left is the mean of left-minus-right
// over hips and shoulders. Each cue votes; a cue too short to point (under 1% of the
// hip-to-head height horizontally) abstains. Swapped when every voting cue says so: cues that
// disagree (a rig whose eyes look sideways) or none at all leave the names to be trusted.
// Returns the problem naming the cues tried, or empty.
std::string sides_swapped(const Skeleton& rig, const BoneMap& map) {
  using namespace canonical;
  const std::vector<RigidTransform<double>> rest = rig.rest_world();
  const auto at = [&](int c) -> const Eigen::Vector3d& { return rest[map.joints[c]].translation; };
  const auto horizontal = [](Eigen::Vector3d v) {
    v.z() = 0;
    return v;
  };
  const Eigen::Vector3d leftward = horizontal((at(left_hip) - at(right_hip)) + (at(left_shoulder) - at(right_shoulder)));
  const double reach = 0.01 * std::abs(at(head).z() - at(pelvis).z());
  struct Cue {
    const char* name;
    Eigen::Vector3d facing;
  };
  std::vector<Cue> cues;
  if (map.mapped(left_foot) && map.mapped(right_foot)) {
    cues.push_back({"the feet (ankle to ball of the foot)", horizontal((at(left_foot) - at(left_ankle)) + (at(right_foot) - at(right_ankle)))});
  }
  if (map.mapped(left_eye) && map.mapped(right_eye)) {
    cues.push_back({"the eyes (head to between the eyes)", horizontal(0.5 * (at(left_eye) + at(right_eye)) - at(head))});
  }
  if (map.mapped(jaw)) cues.push_back({"the jaw (head to jaw)", horizontal(at(jaw) - at(head))});
  std::vector<std::string> agree, disagree;
  for (const Cue& cue : cues) {
    if (cue.facing.norm() <= reach || leftward.norm() <= reach) continue;
    (Eigen::Vector3d::UnitZ().cross(cue.facing).dot(leftward) < 0 ? disagree : agree).push_back(cue.name);
  }
  if (disagree.empty() || !agree.empty()) return {};
  return "left and right are swapped: the joints mapped to left_* (" + rig.name(map.joints[left_hip]) + ", " +
         rig.name(map.joints[left_shoulder]) + ") are on the rig's right, judged by where " + joined(disagree, " and ") +
         " point in the rest pose, whichever way the rig faces (a user bone map overrides the names)";
}

// Applies entries to `map`; every name must exist.
void apply_entries(BoneMap& map, const Skeleton& rig, const io::BoneMapFile& file, const std::string& origin) {
  for (const io::BoneMapEntry& entry : file.entries) {
    const int c = canonical_index(entry.canonical);
    if (c < 0) {
      throw io::InputError(origin, "'" + entry.canonical + "' is not a canonical (SMPL-X) joint name");
    }
    std::vector<int> joints;
    for (const std::string& name : entry.rig_joints) {
      const int joint = rig.find(name);
      if (joint < 0) {
        throw io::InputError(origin, "the rig has no joint '" + name + "' (mapped to '" + entry.canonical + "')");
      }
      joints.push_back(joint);
    }
    // Whatever played this role, or was claimed by the new entry elsewhere, is released first.
    std::erase_if(map.followers, [&](const BoneMap::Follower& f) {
      return f.canonical == c || std::find(joints.begin(), joints.end(), f.joint) != joints.end();
    });
    for (int joint : joints) {
      if (const int previous = map.canonical_of(joint); previous >= 0) map.joints[previous] = -1;
    }
    map.joints[c] = joints.empty() ? -1 : joints.front();
    for (std::size_t k = 1; k < joints.size(); ++k) map.followers.push_back({joints[k], c});
  }
}

// The user map over `map`, then the humanoid check (humanoid_bone_map).
BoneMap checked_humanoid(BoneMap map, const Skeleton& rig, const std::string& rig_label, const std::string& user_map_path) {
  if (!user_map_path.empty()) override_bone_map(map, rig, io::load_bone_map_file(user_map_path), user_map_path);
  const std::vector<std::string> problems = humanoid_problems(rig, map);
  if (!problems.empty()) {
    throw io::InputError(rig_label, "not a humanoid rig (bone map from " + map.origin + "): " + joined(problems, "; "));
  }
  return map;
}

}  // namespace

// ---------------------------------------------------------------------------------------------

int BoneMap::canonical_of(int rig_joint) const {
  for (int c = 0; c < kCanonicalJointCount; ++c) {
    if (joints[c] == rig_joint) return c;
  }
  return -1;
}

int BoneMap::mapped_count() const {
  return static_cast<int>(std::count_if(joints.begin(), joints.end(), [](int j) { return j >= 0; }));
}

namespace {
// The presets ship with the binary: installed under share/odyssey/presets, else the source tree's.
const std::string& preset_folder() {
  static const std::string folder = io::runtime_folder("presets", ODYSSEY_PRESET_DIR);
  return folder;
}
}  // namespace

std::vector<std::string> preset_names() {
  std::vector<std::string> names;
  for (const auto& entry : fs::directory_iterator(preset_folder())) {
    if (entry.path().extension() == ".json") names.push_back(entry.path().stem().string());
  }
  std::sort(names.begin(), names.end());
  return names;
}

io::BoneMapFile load_preset(const std::string& name) {
  const fs::path path = fs::path(preset_folder()) / (name + ".json");
  if (!fs::exists(path)) {
    throw io::InputError(path.string(), "no bone map preset '" + name + "' (presets: " + joined(preset_names(), ", ") + ")");
  }
  return io::load_bone_map_file(path.string());
}

BoneMap bone_map_from_file(const Skeleton& rig, const io::BoneMapFile& file, const std::string& origin) {
  BoneMap map;
  map.origin = origin;
  apply_entries(map, rig, file, origin);
  return map;
}

BoneMap detect_bone_map(const Skeleton& rig) {
  BoneMap best;
  std::pair<bool, int> best_fit{false, 0};  // (the preset's own prefix, entries found)
  for (const std::string& name : preset_names()) {
    int found = 0;
    bool exact = false;
    BoneMap map = map_from_preset(rig, load_preset(name), name, found, exact);
    if (found > 0 && std::pair(exact, found) > best_fit && humanoid_problems(rig, map).empty()) {
      best = std::move(map);
      best_fit = {exact, found};
    }
  }
  return best_fit.second > 0 ? best : bone_map_from_names(rig);
}

void override_bone_map(BoneMap& map, const Skeleton& rig, const io::BoneMapFile& user, const std::string& origin) {
  apply_entries(map, rig, user, origin);
  map.origin = "user map " + origin + " over " + map.origin;
}

std::vector<std::string> humanoid_problems(const Skeleton& rig, const BoneMap& map) {
  using namespace canonical;
  std::vector<std::string> problems;
  std::vector<std::string> missing;
  for (int c : {pelvis, head, left_hip, right_hip, left_knee, right_knee, left_ankle, right_ankle, left_shoulder,
                right_shoulder, left_elbow, right_elbow, left_wrist, right_wrist}) {
    if (!map.mapped(c)) missing.emplace_back(canonical_name(c));
  }
  if (!map.mapped(spine1) && !map.mapped(spine2) && !map.mapped(spine3)) missing.emplace_back("a spine joint");
  if (!missing.empty()) {
    problems.push_back("no joint plays " + joined(missing, ", "));
    return problems;
  }
  const std::vector<RigidTransform<double>> rest = rig.rest_world();
  const auto at = [&](int c) -> const Eigen::Vector3d& { return rest[map.joints[c]].translation; };
  const auto name = [&](int c) { return std::string(canonical_name(c)) + " (" + rig.name(map.joints[c]) + ")"; };
  const auto require_above = [&](int upper, int lower) {
    if (!(at(upper).z() > at(lower).z())) {
      problems.push_back("in the rest pose the " + name(upper) + " is not above the " + name(lower));
    }
  };
  require_above(head, pelvis);
  require_above(pelvis, left_knee);
  require_above(pelvis, right_knee);
  require_above(left_knee, left_ankle);
  require_above(right_knee, right_ankle);
  if (!problems.empty()) {
    // Say where the body points instead, so that a rig lying down (an armature turned at its
    // root, a Y-up file read as Z-up) is recognised as such.
    const Eigen::Vector3d up = (at(head) - 0.5 * (at(left_ankle) + at(right_ankle))).normalized();
    int axis = 0;
    up.cwiseAbs().maxCoeff(&axis);
    problems.front() += std::string(" (ankles to head points along ") + (up[axis] < 0 ? "-" : "+") + "xyz"[axis] +
                        " in the Z-up world: is the rig turned at its root?)";
  }
  if (const std::string swapped = sides_swapped(rig, map); !swapped.empty()) problems.push_back(swapped);
  return problems;
}

BoneMap bone_map_from_declared(const Skeleton& rig, const std::vector<Character::DeclaredBone>& bones,
                               const std::string& convention) {
  using namespace canonical;
  if (convention != "VRM 0.x" && convention != "VRM 1.0") {
    throw std::invalid_argument("unknown declared humanoid convention '" + convention + "'");
  }
  const bool has_upper_chest = std::any_of(bones.begin(), bones.end(), [](const auto& b) { return b.bone == "upperChest"; });
  std::vector<std::pair<std::string, int>> vocabulary = {
      {"hips", pelvis}, {"spine", spine1}, {"chest", has_upper_chest ? spine2 : spine3}, {"upperChest", spine3},
      {"neck", neck}, {"head", head}, {"jaw", jaw}};
  for (const bool left : {true, false}) {
    const std::string side = left ? "left" : "right";
    const auto sided_joint = [&](int left_canonical) { return left ? left_canonical : canonical_mirror(left_canonical); };
    for (const auto& [part, c] : std::vector<std::pair<const char*, int>>{
             {"Eye", left_eye}, {"Shoulder", left_collar}, {"UpperArm", left_shoulder}, {"LowerArm", left_elbow},
             {"Hand", left_wrist}, {"UpperLeg", left_hip}, {"LowerLeg", left_knee}, {"Foot", left_ankle}, {"Toes", left_foot}}) {
      vocabulary.emplace_back(side + part, sided_joint(c));
    }
    const std::vector<std::string> thumb = convention == "VRM 1.0" ? std::vector<std::string>{"Metacarpal", "Proximal", "Distal"}
                                                                   : std::vector<std::string>{"Proximal", "Intermediate", "Distal"};
    for (int k = 0; k < 3; ++k) {
      vocabulary.emplace_back(side + "Thumb" + thumb[k], canonical_index(side + "_thumb" + std::to_string(k + 1)));
      for (const auto& [vrm, smplx] : {std::pair("Index", "index"), std::pair("Middle", "middle"), std::pair("Ring", "ring"),
                                       std::pair("Little", "pinky")}) {
        const char* segment[] = {"Proximal", "Intermediate", "Distal"};
        vocabulary.emplace_back(side + vrm + segment[k], canonical_index(side + "_" + smplx + std::to_string(k + 1)));
      }
    }
  }
  BoneMap map;
  map.origin = convention + " humanoid declared in the file";
  for (const Character::DeclaredBone& bone : bones) {
    if (bone.joint < 0 || bone.joint >= rig.joint_count()) {
      throw std::invalid_argument("declared bone '" + bone.bone + "' names joint " + std::to_string(bone.joint) +
                                  " of a " + std::to_string(rig.joint_count()) + "-joint skeleton");
    }
    for (const auto& [name, c] : vocabulary) {
      if (name == bone.bone) map.joints[c] = bone.joint;
    }
  }
  return map;
}

namespace {

// The preset that came nearest to fitting: the most of its body joints found (under the best
// prefix), and the ones it lacked; empty when no preset finds any.
std::string closest_preset(const Skeleton& rig) {
  std::string best;
  double best_share = 0;
  for (const std::string& name : preset_names()) {
    const io::BoneMapFile preset = load_preset(name);
    const std::string own = preset_prefix(preset);
    std::vector<std::string> prefixes = {own};
    if (!own.empty()) {
      for (const std::string& joint : rig.names()) {
        // Any rig prefix up to a separator may stand in for the preset's.
        const std::size_t at = joint.find_first_of(":_.- ");
        if (at != std::string::npos) prefixes.push_back(joint.substr(0, at + 1));
      }
      std::sort(prefixes.begin() + 1, prefixes.end());
      prefixes.erase(std::unique(prefixes.begin() + 1, prefixes.end()), prefixes.end());
    }
    for (const std::string& prefix : prefixes) {
      int required = 0, found = 0;
      std::vector<std::string> lacking;
      for (const io::BoneMapEntry& entry : preset.entries) {
        const int c = canonical_index(entry.canonical);
        if (c < 0 || c > canonical::right_wrist || c == canonical::left_foot || c == canonical::right_foot ||
            entry.rig_joints.empty()) {
          continue;
        }
        ++required;
        const std::string joint = prefix + entry.rig_joints.front().substr(own.size());
        if (rig.find(joint) >= 0) ++found;
        else lacking.push_back("'" + joint + "'");
      }
      const double share = required > 0 ? double(found) / required : 0.0;
      if (found > 0 && share > best_share) {
        best_share = share;
        if (lacking.size() > 6) {
          const std::size_t more = lacking.size() - 5;
          lacking.resize(5);
          lacking.push_back("and " + std::to_string(more) + " more");
        }
        best = "preset " + name + " (" + std::to_string(found) + " of its " + std::to_string(required) +
               " body joints found, lacking " + joined(lacking, ", ") + ")";
      }
    }
  }
  return best;
}

// `--map auto-structure` (or a scene's "map": "auto-structure", which the scene reader makes a
// path): the map from the skeleton's structure instead of a file.
bool asks_for_structure(const std::string& user_map_path) {
  if (user_map_path.empty()) return false;
  const fs::path path(user_map_path);
  std::error_code error;
  return path.filename() == kAutoStructureMap && !fs::exists(path, error);
}

// The map detection gives (presets, then names); when it is not a humanoid because names leave
// body joints unplayed, the one the skeleton's structure gives (bone_map_structure.h); else the
// refusal, saying what each way found. A user map file applies over detection and is checked as
// before; `--map auto-structure` asks for the structure's map alone.
BoneMap detected_humanoid(const Skeleton& rig, const std::vector<bool>& binds, const std::string& rig_label,
                          const std::string& user_map_path) {
  if (asks_for_structure(user_map_path)) {
    const StructureMap structure = bone_map_from_structure(rig, binds);
    if (!structure.problem.empty()) {
      throw io::InputError(rig_label, "not a humanoid rig (bone map from the skeleton's structure, as asked): " + structure.problem);
    }
    return checked_humanoid(structure.map, rig, rig_label, "");
  }
  BoneMap map = detect_bone_map(rig);
  if (!user_map_path.empty()) return checked_humanoid(std::move(map), rig, rig_label, user_map_path);
  const std::vector<std::string> problems = humanoid_problems(rig, map);
  if (problems.empty()) return map;
  if (!problems.front().starts_with("no joint plays")) return checked_humanoid(std::move(map), rig, rig_label, "");
  StructureMap structure = bone_map_from_structure(rig, binds);
  std::vector<std::string> structure_problems;
  if (structure.problem.empty()) {
    structure_problems = humanoid_problems(rig, structure.map);
    if (structure_problems.empty()) {
      structure.map.origin = "skeleton structure (the names left " +
                             problems.front().substr(std::string("no joint plays ").size()) + " unplayed)";
      return structure.map;
    }
  } else {
    structure_problems.push_back(structure.problem);
  }
  const std::string closest = closest_preset(rig);
  throw io::InputError(rig_label, "not a humanoid rig (bone map from " + map.origin + "): " + joined(problems, "; ") +
                                      "; closest convention: " + (closest.empty() ? "none (no preset names any joint)" : closest) +
                                      "; from the skeleton's structure: " + joined(structure_problems, "; ") +
                                      "; give a bone map with --map FILE (docs/retargeting.md#bone-maps)");
}

}  // namespace

BoneMap humanoid_bone_map(const Character& character, const std::string& rig_label, const std::string& user_map_path) {
  if (character.declared_humanoid.empty() || asks_for_structure(user_map_path)) {
    std::vector<bool> binds = joints_binding_vertices(character);
    if (std::none_of(binds.begin(), binds.end(), [](bool b) { return b; })) binds.clear();
    return detected_humanoid(character.skeleton, binds, rig_label, user_map_path);
  }
  BoneMap map = bone_map_from_declared(character.skeleton, character.declared_humanoid, character.declared_humanoid_convention);
  return checked_humanoid(std::move(map), character.skeleton, rig_label, user_map_path);
}

BoneMap humanoid_bone_map(const Skeleton& rig, const std::string& rig_label, const std::string& user_map_path) {
  return detected_humanoid(rig, {}, rig_label, user_map_path);
}

std::vector<int> unmapped_joints(const Skeleton& rig, const BoneMap& map) {
  std::vector<bool> used(rig.joint_count(), false);
  for (int joint : map.joints) {
    if (joint >= 0) used[joint] = true;
  }
  for (const BoneMap::Follower& follower : map.followers) used[follower.joint] = true;
  std::vector<int> result;
  for (int j = 0; j < rig.joint_count(); ++j) {
    if (!used[j]) result.push_back(j);
  }
  return result;
}

}  // namespace odyssey::retarget
