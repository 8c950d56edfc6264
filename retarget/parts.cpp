#include "retarget/parts.h"

#include <algorithm>

namespace odyssey::retarget {

std::optional<Parts> parse_parts(std::string_view text) {
  if (text == "body") return Parts::body;
  if (text == "body+hands") return Parts::body_and_hands;
  if (text == "all") return Parts::all;
  return std::nullopt;
}

const char* parts_name(Parts parts) {
  switch (parts) {
    case Parts::body: return "body";
    case Parts::body_and_hands: return "body+hands";
    case Parts::all: return "all";
  }
  return "body";
}

bool canonical_in_parts(int canonical, Parts parts) {
  const std::string_view limb = canonical_limb(canonical);
  const bool finger = limb == "left_hand" || limb == "right_hand";
  const bool face = canonical == canonical::jaw || canonical == canonical::left_eye || canonical == canonical::right_eye;
  switch (parts) {
    case Parts::body: return !finger && !face;
    case Parts::body_and_hands: return !face;
    case Parts::all: return true;
  }
  return false;
}

BoneMap restrict_bone_map(const BoneMap& map, Parts parts) {
  BoneMap restricted = map;
  for (int c = 0; c < kCanonicalJointCount; ++c) {
    if (!canonical_in_parts(c, parts)) restricted.joints[c] = -1;
  }
  std::erase_if(restricted.followers,
                [parts](const BoneMap::Follower& follower) { return !canonical_in_parts(follower.canonical, parts); });
  return restricted;
}

}  // namespace odyssey::retarget
