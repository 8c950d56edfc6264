#include "mocap_io/bone_map_file.h"

#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "mocap_io/input_error.h"

namespace odyssey::io {

namespace {

std::string optional_text(const nlohmann::ordered_json& document, const char* key, const std::string& origin) {
  const auto it = document.find(key);
  if (it == document.end() || it->is_null()) return {};
  if (!it->is_string()) throw InputError(origin, std::string("'") + key + "' must be a string");
  return it->get<std::string>();
}

}  // namespace

BoneMapFile parse_bone_map(const std::string& json_text, const std::string& origin) {
  nlohmann::ordered_json document;
  try {
    document = nlohmann::ordered_json::parse(json_text);
  } catch (const nlohmann::json::parse_error& error) {
    throw InputError(origin, std::string("not valid JSON: ") + error.what());
  }
  if (!document.is_object()) throw InputError(origin, "a bone map must be a JSON object");
  BoneMapFile map;
  map.name = optional_text(document, "name", origin);
  map.description = optional_text(document, "description", origin);
  const auto joints = document.find("joints");
  if (joints == document.end() || !joints->is_object()) {
    throw InputError(origin, "a bone map needs a \"joints\" object (canonical name -> rig joint name)");
  }
  std::set<std::string> rig_names_seen;
  for (const auto& [canonical, value] : joints->items()) {
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

BoneMapFile load_bone_map_file(const std::string& path) {
  std::ifstream file(path, std::ios::binary);
  if (!file) throw InputError(path, "cannot open the bone map file");
  std::ostringstream text;
  text << file.rdbuf();
  if (file.bad()) throw InputError(path, "cannot read the bone map file");
  return parse_bone_map(text.str(), path);
}

}  // namespace odyssey::io
