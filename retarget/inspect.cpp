#include "retarget/inspect.h"

#include <algorithm>
#include <cctype>
#include <exception>
#include <filesystem>

#include "mocap_io/amass.h"
#include "mocap_io/body_model_file.h"
#include "mocap_io/bvh.h"
#include "mocap_io/gltf_character.h"
#include "mocap_io/motion_file.h"
#include "mocap_io/npy.h"
#include "retarget/bone_map.h"
#include "retarget/canonical.h"
#include "retarget/rest_pose.h"
#include "skeleton/body_model.h"

namespace odyssey::retarget {
namespace {

using Json = nlohmann::ordered_json;

Json joints_json(const std::vector<std::string>& names, const std::vector<int>& parents) {
  Json joints = Json::array();
  for (std::size_t j = 0; j < names.size(); ++j) {
    joints.push_back({{"name", names[j]}, {"parent", parents[j] < 0 ? Json(nullptr) : Json(names[parents[j]])}});
  }
  return joints;
}

}  // namespace

bool is_gltf_path(const std::string& path) {
  std::string extension = std::filesystem::path(path).extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(), [](unsigned char c) { return std::tolower(c); });
  return extension == ".glb" || extension == ".gltf" || extension == ".vrm";
}

nlohmann::ordered_json character_summary(const Character& character, const std::string& path) {
  const io::GltfFileSummary summary = io::summarize_gltf_file(path);
  const Skeleton& rig = character.skeleton;
  Json json = {{"file", path}, {"kind", "character"}};
  json["skins"] = Json::array();
  for (const io::GltfSkinSummary& skin : summary.skins) json["skins"].push_back({{"name", skin.name}, {"joints", skin.joint_count}});
  json["meshes"] = Json::array();
  std::size_t vertices = 0, triangles = 0;
  for (const CharacterMesh& mesh : character.meshes) {
    vertices += mesh.positions.size();
    triangles += mesh.triangles.size() / 3;
    json["meshes"].push_back({{"name", mesh.name},
                              {"vertices", mesh.positions.size()},
                              {"triangles", mesh.triangles.size() / 3},
                              {"skin", mesh.skin_joints.size() == 1 ? "rigid on " + rig.name(mesh.skin_joints[0])
                                                                    : std::to_string(mesh.skin_joints.size()) + " skin joints"}});
  }
  json["vertices"] = vertices;
  json["triangles"] = triangles;
  const Eigen::AlignedBox3d bounds = character.rest_bounds();
  json["rest_height_m"] = bounds.isEmpty() ? 0.0 : bounds.sizes().z();
  json["rest_z_m"] = {bounds.isEmpty() ? 0.0 : bounds.min().z(), bounds.isEmpty() ? 0.0 : bounds.max().z()};
  json["rest_height_of"] = character.meshes.empty() ? "joints" : "skinned meshes";
  json["rest_pose_from"] = character.rest_pose_origin;

  std::string map_problem;
  std::optional<BoneMap> humanoid;
  try {
    humanoid = humanoid_bone_map(character, path);
  } catch (const std::exception& error) {
    map_problem = error.what();
  }
  const BoneMap map = humanoid ? *humanoid : detect_bone_map(rig);
  json["joints"] = Json::array();
  for (int j = 0; j < rig.joint_count(); ++j) {
    const int canonical = map.canonical_of(j);
    json["joints"].push_back({{"name", rig.name(j)},
                              {"parent", rig.parent(j) < 0 ? Json(nullptr) : Json(rig.name(rig.parent(j)))},
                              {"canonical", canonical >= 0 ? Json(std::string(canonical_name(canonical))) : Json(nullptr)}});
  }
  json["animations"] = Json::array();
  for (const io::GltfAnimationSummary& animation : summary.animations) {
    json["animations"].push_back({{"name", animation.name},
                                  {"duration_s", animation.duration()},
                                  {"start_s", animation.start},
                                  {"end_s", animation.end},
                                  {"channels", animation.channels},
                                  {"keyframes", animation.keyframes}});
  }
  const RestPoseInfo rest = classify_rest_pose(rig, map);
  json["rest_pose"] = {{"kind", rest_pose_kind_name(rest.kind)},
                       {"upper_arm_drop_deg", rest.kind == RestPoseKind::unknown ? Json(nullptr) : Json(rest.drop_deg)},
                       {"left_drop_deg", rest.left_drop_deg ? Json(*rest.left_drop_deg) : Json(nullptr)},
                       {"right_drop_deg", rest.right_drop_deg ? Json(*rest.right_drop_deg) : Json(nullptr)},
                       {"reason", rest.reason},
                       {"from_humanoid_map", humanoid.has_value()}};
  json["bone_map"] = {{"origin", humanoid ? Json(map.origin) : Json(nullptr)},
                      {"mapped", map.mapped_count()},
                      {"canonical_joints", kCanonicalJointCount},
                      {"problem", humanoid ? Json(nullptr) : Json(map_problem)}};
  json["unmapped_joints"] = Json::array();
  for (int joint : unmapped_joints(rig, map)) json["unmapped_joints"].push_back(rig.name(joint));
  json["warnings"] = character.warnings;
  return json;
}

nlohmann::ordered_json inspect_file(const std::string& path, std::optional<double> metres_per_unit) {
  if (is_gltf_path(path)) return character_summary(io::load_character(path), path);
  switch (io::detect_motion_file(path)) {
    case io::MotionFileKind::Bvh: {
      const io::LoadedBvh loaded = io::load_bvh_inferring_frame(path, metres_per_unit);
      const Clip& clip = loaded.clip;
      Json translated = Json::array();
      for (int joint : clip.translated_joints) translated.push_back(clip.skeleton.name(joint));
      return {{"file", path},
              {"kind", "bvh"},
              {"metres_per_unit", loaded.frame.metres_per_unit},
              {"units", loaded.frame.description()},
              {"units_warning", loaded.frame.plausible ? Json(nullptr) : Json(loaded.frame.warning(path))},
              {"frames", clip.frame_count()},
              {"fps", clip.fps},
              {"duration_s", clip.duration()},
              {"translated_joints", translated},
              {"joints", joints_json(clip.skeleton.names(), clip.skeleton.parents())}};
    }
    case io::MotionFileKind::BodyModel: {
      const BodyModel model = io::load_body_model(path);
      return {{"file", path},
              {"kind", "body_model"},
              {"model", body_model_kind_name(model.kind)},
              {"vertices", model.vertex_count()},
              {"faces", model.faces.rows()},
              {"shape_directions", model.shape_count},
              {"expression_directions", model.expression_count},
              {"pose_corrective_directions", model.posedirs.cols()},
              {"hand_pca_components", model.hands_components_left.rows()},
              {"joints", joints_json(model.joint_names, model.parents)}};
    }
    case io::MotionFileKind::Amass: {
      const io::AmassFile file = io::load_amass_file(path);
      const BodySequence& sequence = file.sequence;
      return {{"file", path},
              {"kind", "amass"},
              {"model", body_model_kind_name(sequence.kind)},
              {"pose_numbers", sequence.poses.cols()},
              {"frames", sequence.frame_count()},
              {"fps", sequence.fps},
              {"duration_s", sequence.duration()},
              {"gender", sequence.gender},
              {"betas", sequence.betas.size()},
              {"keys_skipped", file.skipped_keys}};
    }
    case io::MotionFileKind::Npz: {
      const io::NpzReader archive(path);
      Json arrays = Json::object();
      for (const std::string& key : archive.keys()) {
        const io::NpyHeader header = archive.header(key);
        arrays[key] = {{"dtype", io::dtype_name(header.dtype)}, {"shape", header.shape}, {"loaded", header.dtype != io::DType::Object}};
      }
      return {{"file", path}, {"kind", "npz"}, {"arrays", arrays}};
    }
    case io::MotionFileKind::Npy: {
      const io::NpyArray array = io::read_npy(path);
      return {{"file", path}, {"kind", "npy"}, {"dtype", io::dtype_name(array.dtype())}, {"shape", array.shape()}};
    }
  }
  return {};
}

}  // namespace odyssey::retarget
