#include "mocap_io/bone_map_file.h"

#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <unordered_set>
#include <vector>

#include "mocap_io/input_error.h"
#include "mocap_io/input_file.h"
#include "mocap_io/json_reader.h"

namespace odyssey::io {

namespace {

std::string optional_text(const nlohmann::json& document, const char* key, const std::string& origin) {
  const auto it = document.find(key);
  if (it == document.end() || it->is_null()) return {};
  if (!it->is_string()) throw InputError(origin, std::string("'") + key + "' must be a string");
  return it->get<std::string>();
}

// nlohmann::ordered_json inserts each key by a linear scan, quadratic in a map's size; a plain
// json object is a std::map, and the file order of "joints" is recorded as the parser meets its
// keys (depth 1: the document's keys, depth 2: the keys of an object among them).
BoneMapFile parse(const std::string& json_text, const std::string& origin) {
  std::vector<std::string> canonical_order;
  int joints_keys = 0;
  bool in_joints = false;
  const nlohmann::json::parser_callback_t record = [&](int depth, nlohmann::json::parse_event_t event,
                                                       nlohmann::json& parsed) {
    if (event != nlohmann::json::parse_event_t::key) return true;
    if (depth == 1) {
      in_joints = parsed == "joints";
      if (in_joints && ++joints_keys > 1) throw InputError(origin, "\"joints\" is given twice");
    } else if (depth == 2 && in_joints) {
      canonical_order.push_back(parsed.get<std::string>());
    }
    return true;
  };
  nlohmann::json document;
  document = parse_json(json_text, origin, record);
  if (!document.is_object()) throw InputError(origin, "a bone map must be a JSON object");
  BoneMapFile map;
  map.name = optional_text(document, "name", origin);
  map.description = optional_text(document, "description", origin);
  const auto joints = document.find("joints");
  if (joints == document.end() || !joints->is_object()) {
    throw InputError(origin, "a bone map needs a \"joints\" object (canonical name -> rig joint name)");
  }
  std::set<std::string> rig_names_seen;
  std::unordered_set<std::string> canonical_seen;
  for (const std::string& canonical : canonical_order) {
    if (!canonical_seen.insert(canonical).second) throw InputError(origin, "'" + canonical + "' is given twice");
    const nlohmann::json& value = joints->at(canonical);
    BoneMapEntry entry{canonical, {}};
    if (value.is_string()) {
      entry.rig_joints.push_back(value.get<std::string>());
    } else if (value.is_array()) {
      if (value.empty()) throw InputError(origin, "'" + canonical + "' maps to an empty list (write null to unmap it)");
      for (const auto& item : value) {
        if (!item.is_string()) throw InputError(origin, "'" + canonical + "' lists something that is not a joint name");
        entry.rig_joints.push_back(item.get<std::string>());
      }
    } else if (!value.is_null()) {
      throw InputError(origin, "'" + canonical + "' must map to a joint name, a list of joint names or null");
    }
    for (const std::string& rig_joint : entry.rig_joints) {
      if (rig_joint.empty()) throw InputError(origin, "'" + canonical + "' maps to an empty joint name");
      if (!rig_names_seen.insert(rig_joint).second) {
        throw InputError(origin, "rig joint '" + rig_joint + "' is mapped twice (again for '" + canonical + "')");
      }
    }
    map.entries.push_back(std::move(entry));
  }
  return map;
}

}  // namespace

BoneMapFile parse_bone_map(const std::string& json_text, const std::string& origin) {
  return naming_out_of_memory(origin, [&] { return parse(json_text, origin); });
}

BoneMapFile load_bone_map_file(const std::string& path) {
  return naming_out_of_memory(path, [&] {
    return parse(read_input_file(path, kMaxJsonInputBytes), path);
  });
}

}  // namespace odyssey::io
