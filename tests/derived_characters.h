// Characters derived from the shared ones in test code, for rig conventions no shared file
// carries: the same meshes and bones under Unreal mannequin names, or with a VRM humanoid bone
// list (0.x or 1.0) added and every node renamed so that only the list can tell the bones apart.
// A derived file is the source's glTF JSON edited and written beside copies of its external
// files (.gltf), or repacked with its binary chunk unchanged (.glb).
#pragma once

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <map>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>
#include <vector>

namespace odyssey::test_support {

inline const std::string kSharedCharacters = std::string(ODYSSEY_SHARED_DIR) + "/assets/characters/";

// Writes `source` (a .glb or .gltf) with its JSON passed through `edit` to `out` (same extension).
inline void write_derived_gltf(const std::filesystem::path& source, const std::filesystem::path& out,
                               const std::function<void(nlohmann::json&)>& edit) {
  namespace fs = std::filesystem;
  std::ifstream in(source, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  fs::create_directories(out.parent_path());
  if (source.extension() == ".gltf") {
    nlohmann::json gltf = nlohmann::json::parse(bytes);
    edit(gltf);
    std::ofstream(out, std::ios::binary) << gltf.dump();
    for (const char* list : {"buffers", "images"}) {
      for (const auto& item : gltf.value(list, nlohmann::json::array())) {
        if (item.contains("uri")) fs::copy_file(source.parent_path() / item["uri"].get<std::string>(),
                                                out.parent_path() / item["uri"].get<std::string>(),
                                                fs::copy_options::overwrite_existing);
      }
    }
    return;
  }
  // GLB: 12-byte header, then chunks (length, type, data); the JSON chunk first, padded with
  // spaces to 4 bytes.
  const auto u32 = [&](std::size_t at) {
    std::uint32_t value;
    std::memcpy(&value, bytes.data() + at, 4);
    return value;
  };
  const std::uint32_t json_length = u32(12);
  nlohmann::json gltf = nlohmann::json::parse(bytes.substr(20, json_length));
  edit(gltf);
  std::string json = gltf.dump();
  while (json.size() % 4 != 0) json += ' ';
  const std::string rest = bytes.substr(20 + json_length);  // the BIN chunk, header included
  const auto put = [](std::string& to, std::uint32_t value) { to.append(reinterpret_cast<const char*>(&value), 4); };
  std::string glb = "glTF";
  put(glb, 2);
  put(glb, static_cast<std::uint32_t>(12 + 8 + json.size() + rest.size()));
  put(glb, static_cast<std::uint32_t>(json.size()));
  glb += "JSON";
  glb += json;
  glb += rest;
  std::ofstream(out, std::ios::binary) << glb;
}

// Node index of each node name.
inline std::map<std::string, int> node_indices(const nlohmann::json& gltf) {
  std::map<std::string, int> indices;
  for (std::size_t n = 0; n < gltf["nodes"].size(); ++n) indices[gltf["nodes"][n].value("name", "")] = static_cast<int>(n);
  return indices;
}

// Renames nodes by `names` (old -> new); names not listed are kept.
inline void rename_nodes(nlohmann::json& gltf, const std::map<std::string, std::string>& names) {
  for (auto& node : gltf["nodes"]) {
    const auto it = names.find(node.value("name", ""));
    if (it != names.end()) node["name"] = it->second;
  }
}

// Rigify (male_base_mesh.glb) -> Unreal mannequin names (UE4/UE5: pelvis, spine_01.., neck_01,
// clavicle_l, upperarm_l, lowerarm_l, hand_l, thigh_l, calf_l, foot_l, ball_l, index_01_l..).
inline std::map<std::string, std::string> rigify_to_unreal() {
  std::map<std::string, std::string> names = {{"spine", "pelvis"},       {"spine.001", "spine_01"}, {"spine.002", "spine_02"},
                                              {"spine.003", "spine_03"}, {"spine.004", "neck_01"},  {"spine.005", "head"}};
  for (const auto& [blender, unreal] : {std::pair("L", "l"), std::pair("R", "r")}) {
    const std::string b = std::string(".") + blender, u = std::string("_") + unreal;
    for (const auto& [from, to] : std::vector<std::pair<std::string, std::string>>{
             {"shoulder", "clavicle"}, {"upper_arm", "upperarm"}, {"forearm", "lowerarm"}, {"hand", "hand"},
             {"thigh", "thigh"}, {"shin", "calf"}, {"foot", "foot"}, {"toe", "ball"}, {"heel.02", "heel"},
             {"pelvis", "pelvis_twist"}}) {
      names[from + b] = to + u;
    }
    for (const char* finger : {"index", "middle", "ring", "pinky"}) {
      for (int k = 1; k <= 3; ++k) names["f_" + std::string(finger) + ".0" + std::to_string(k) + b] = finger + ("_0" + std::to_string(k)) + u;
    }
    for (int k = 1; k <= 3; ++k) names["thumb.0" + std::to_string(k) + b] = "thumb_0" + std::to_string(k) + u;
  }
  return names;
}

// Adds a VRM humanoid bone list (vrm_bone -> the node named `node_name`), as VRM 0.x
// (extensions.VRM.humanoid.humanBones: [{bone, node}]) or 1.0 (extensions.VRMC_vrm.humanoid.
// humanBones: {bone: {node}}), then renames every node "n<index>".
inline void add_vrm_humanoid(nlohmann::json& gltf, const std::map<std::string, std::string>& bones, bool vrm1) {
  const std::map<std::string, int> nodes = node_indices(gltf);
  nlohmann::json list = vrm1 ? nlohmann::json::object() : nlohmann::json::array();
  for (const auto& [bone, node_name] : bones) {
    const auto it = nodes.find(node_name);
    if (it == nodes.end()) throw std::runtime_error("no node " + node_name);
    if (vrm1) list[bone] = {{"node", it->second}};
    else list.push_back({{"bone", bone}, {"node", it->second}, {"useDefaultValues", true}});
  }
  gltf["extensionsUsed"].push_back(vrm1 ? "VRMC_vrm" : "VRM");
  if (vrm1) gltf["extensions"]["VRMC_vrm"] = {{"specVersion", "1.0"}, {"humanoid", {{"humanBones", list}}}};
  else gltf["extensions"]["VRM"] = {{"specVersion", "0.0"}, {"humanoid", {{"humanBones", list}}}};
  for (std::size_t n = 0; n < gltf["nodes"].size(); ++n) gltf["nodes"][n]["name"] = "n" + std::to_string(n);
}

// The VRM bones of KayKit's manny_med_mod.gltf and of the Rigify male_base_mesh.glb.
inline std::map<std::string, std::string> kaykit_vrm_bones() {
  std::map<std::string, std::string> bones = {{"hips", "hips"}, {"spine", "spine"}, {"chest", "chest"}, {"head", "head"}};
  for (const auto& [vrm, kay] : {std::pair("left", "l"), std::pair("right", "r")}) {
    const std::string v = vrm, k = std::string(".") + kay;
    bones[v + "UpperArm"] = "upperarm" + k;
    bones[v + "LowerArm"] = "lowerarm" + k;
    bones[v + "Hand"] = "wrist" + k;
    bones[v + "UpperLeg"] = "upperleg" + k;
    bones[v + "LowerLeg"] = "lowerleg" + k;
    bones[v + "Foot"] = "foot" + k;
    bones[v + "Toes"] = "toes" + k;
  }
  return bones;
}

inline std::map<std::string, std::string> rigify_vrm1_bones() {
  std::map<std::string, std::string> bones = {{"hips", "spine"},       {"spine", "spine.001"}, {"chest", "spine.002"},
                                              {"upperChest", "spine.003"}, {"neck", "spine.004"}, {"head", "spine.005"}};
  for (const auto& [vrm, side] : {std::pair("left", "L"), std::pair("right", "R")}) {
    const std::string v = vrm, b = std::string(".") + side;
    bones[v + "Shoulder"] = "shoulder" + b;
    bones[v + "UpperArm"] = "upper_arm" + b;
    bones[v + "LowerArm"] = "forearm" + b;
    bones[v + "Hand"] = "hand" + b;
    bones[v + "UpperLeg"] = "thigh" + b;
    bones[v + "LowerLeg"] = "shin" + b;
    bones[v + "Foot"] = "foot" + b;
    bones[v + "Toes"] = "toe" + b;
    bones[v + "ThumbMetacarpal"] = "thumb.01" + b;
    bones[v + "ThumbProximal"] = "thumb.02" + b;
    bones[v + "ThumbDistal"] = "thumb.03" + b;
    bones[v + "IndexProximal"] = "f_index.01" + b;
  }
  return bones;
}

// The derived characters, written under `dir`: Unreal-named male_base_mesh, KayKit with a VRM 0.x
// list, male_base_mesh with a VRM 1.0 list.
inline std::string unreal_character(const std::filesystem::path& dir) {
  const std::filesystem::path out = dir / "unreal_male.glb";
  write_derived_gltf(kSharedCharacters + "male_base_mesh.glb", out, [](nlohmann::json& g) { rename_nodes(g, rigify_to_unreal()); });
  return out.string();
}
inline std::string vrm0_character(const std::filesystem::path& dir) {
  const std::filesystem::path out = dir / "vrm0" / "kaykit_vrm0.gltf";
  write_derived_gltf(kSharedCharacters + "kaykit_mannequin/manny_med_mod.gltf", out,
                     [](nlohmann::json& g) { add_vrm_humanoid(g, kaykit_vrm_bones(), false); });
  return out.string();
}
inline std::string vrm1_character(const std::filesystem::path& dir) {
  const std::filesystem::path out = dir / "male_vrm1.glb";
  write_derived_gltf(kSharedCharacters + "male_base_mesh.glb", out,
                     [](nlohmann::json& g) { add_vrm_humanoid(g, rigify_vrm1_bones(), true); });
  return out.string();
}

}  // namespace odyssey::test_support
