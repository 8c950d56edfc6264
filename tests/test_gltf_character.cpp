// glTF/GLB characters: every sample character loads with the rig it is known to have; the
// rest-pose skinned meshes agree with an independent evaluation done the plain glTF way (full 4x4
// node matrices with their scale, world = parent * local, skin matrix = world(joint) * IBM, blend,
// then Y up -> Z up); joint positions agree with the file's node matrices; heights and the
// up axis are right; hand-written small files pin sparse accessors, quantised weights, rigid and
// skipped primitives, names and scale folding; and every kind of bad input is rejected with the
// file named.
#include <gtest/gtest.h>
#include <tiny_gltf.h>

#include <Eigen/SVD>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <string>
#include <vector>

#include "gltf_reference.h"
#include "mocap_io/gltf_character.h"
#include "mocap_io/input_error.h"
#include "skeleton/rotation.h"
#include "test_support.h"

namespace odyssey::io {
namespace {

namespace fs = std::filesystem;
using Eigen::Matrix4d;
using Eigen::Vector3d;

std::string character_path(const std::string& file) {
  return std::string(ODYSSEY_SHARED_DIR) + "/assets/characters/" + file;
}

fs::path scratch_dir() {
  const fs::path dir = odyssey::test_support::scratch_root() / "gltf_character";
  fs::create_directories(dir);
  return dir;
}

std::string write_scratch(const std::string& name, const std::string& bytes) {
  const fs::path path = scratch_dir() / name;
  std::ofstream(path, std::ios::binary) << bytes;
  return path.string();
}

// --- The independent evaluation, the way a glTF viewer does it. ---

using gltf_reference::elements;
using gltf_reference::parse;
using gltf_reference::z_up;

struct Reference {
  std::vector<Matrix4d> world;                // per node
  std::vector<int> mesh_nodes;                // in node order, those in the scene
  std::vector<std::vector<Vector3d>> meshes;  // per TRIANGLES primitive, Z up
};

Reference evaluate(const std::string& path) {
  const tinygltf::Model model = parse(path);
  Reference ref;
  ref.world.assign(model.nodes.size(), Matrix4d::Identity());
  std::vector<bool> in_scene(model.nodes.size(), false);
  const std::function<void(int, const Matrix4d&, bool)> walk = [&](int node, const Matrix4d& parent, bool scene) {
    ref.world[node] = parent * gltf_reference::static_local(model.nodes[node]);
    in_scene[node] = in_scene[node] || scene;
    for (int child : model.nodes[node].children) walk(child, ref.world[node], scene);
  };
  std::vector<bool> has_parent(model.nodes.size(), false);
  for (const auto& node : model.nodes)
    for (int child : node.children) has_parent[child] = true;
  const int scene = model.defaultScene >= 0 ? model.defaultScene : 0;
  for (std::size_t n = 0; n < model.nodes.size(); ++n) {
    if (has_parent[n]) continue;
    const auto& roots = model.scenes.at(scene).nodes;
    walk(int(n), Matrix4d::Identity(), std::find(roots.begin(), roots.end(), int(n)) != roots.end());
  }
  for (std::size_t n = 0; n < model.nodes.size(); ++n) {
    const tinygltf::Node& node = model.nodes[n];
    if (!in_scene[n] || node.mesh < 0) continue;
    ref.mesh_nodes.push_back(int(n));
    for (const tinygltf::Primitive& primitive : model.meshes[node.mesh].primitives) {
      if (primitive.mode != TINYGLTF_MODE_TRIANGLES) continue;
      const auto positions = elements(model, primitive.attributes.at("POSITION"));
      std::vector<Vector3d> out;
      if (node.skin < 0) {
        for (const auto& p : positions) out.push_back(z_up((ref.world[n] * Eigen::Vector4d(p[0], p[1], p[2], 1)).head<3>()));
      } else {
        const tinygltf::Skin& skin = model.skins[node.skin];
        std::vector<Matrix4d> joint_matrix;
        const auto ibm = skin.inverseBindMatrices >= 0 ? elements(model, skin.inverseBindMatrices)
                                                       : std::vector<std::vector<double>>{};
        for (std::size_t k = 0; k < skin.joints.size(); ++k) {
          Matrix4d inverse_bind = Matrix4d::Identity();
          if (!ibm.empty()) {
            for (int i = 0; i < 16; ++i) inverse_bind(i % 4, i / 4) = ibm[k][i];
          }
          joint_matrix.push_back(ref.world[skin.joints[k]] * inverse_bind);
        }
        const auto joints = elements(model, primitive.attributes.at("JOINTS_0"));
        const auto weights = elements(model, primitive.attributes.at("WEIGHTS_0"));
        for (std::size_t v = 0; v < positions.size(); ++v) {
          // glTF asks the weights to sum to 1; quantised ones only nearly do, so divide by the sum.
          const double sum = weights[v][0] + weights[v][1] + weights[v][2] + weights[v][3];
          Matrix4d blend = Matrix4d::Zero();
          for (int i = 0; i < 4; ++i) blend += weights[v][i] / sum * joint_matrix[int(joints[v][i])];
          const Eigen::Vector4d p(positions[v][0], positions[v][1], positions[v][2], 1);
          out.push_back(z_up((blend * p).head<3>()));
        }
      }
      ref.meshes.push_back(std::move(out));
    }
  }
  return ref;
}

struct Agreement {
  double max_vertex_error = 0;  // metres (file units)
  double size = 0;              // bounds diagonal
};

// The loader's rest-pose skinning and joints against the reference.
Agreement compare_with_reference(const std::string& path, const Character& character) {
  const Reference ref = evaluate(path);
  const auto rest = character.skeleton.rest_world();
  Agreement agreement;
  agreement.size = character.rest_bounds().diagonal().norm();
  EXPECT_EQ(character.meshes.size(), ref.meshes.size()) << path;
  for (std::size_t m = 0; m < std::min(character.meshes.size(), ref.meshes.size()); ++m) {
    const auto skinned = skin_mesh_reference(character.meshes[m], rest);
    EXPECT_EQ(skinned.size(), ref.meshes[m].size()) << path << " mesh " << m;
    for (std::size_t v = 0; v < std::min(skinned.size(), ref.meshes[m].size()); ++v) {
      agreement.max_vertex_error = std::max(agreement.max_vertex_error, (skinned[v] - ref.meshes[m][v]).norm());
    }
  }
  // Joint origins are the file's node origins exactly; joint axes are its node axes (the columns
  // of the node's world matrix, normalised) and the source scale their length.
  for (int j = 0; j < character.skeleton.joint_count(); ++j) {
    const Matrix4d& g = ref.world[character.source_node_of_joint[j]];
    EXPECT_LT((rest[j].translation - z_up(g.topRightCorner<3, 1>())).norm(), 1e-9 * std::max(1.0, agreement.size))
        << path << " joint " << character.skeleton.name(j);
    // Axes only where the node scales (nearly) uniformly; uneven scale on a leaf skews them.
    const Vector3d lengths = g.topLeftCorner<3, 3>().colwise().norm();
    if (lengths.maxCoeff() / lengths.minCoeff() - 1 > 1e-4) continue;
    for (int axis = 0; axis < 3; ++axis) {
      const Vector3d column = g.block<3, 1>(0, axis);
      EXPECT_LT((rest[j].rotation.col(axis) - z_up(column.normalized())).norm(), 1e-4)
          << path << " joint " << character.skeleton.name(j) << " axis " << axis;
      EXPECT_NEAR(character.source_scale_of_joint[j] / column.norm(), 1.0, 1e-4) << path << " joint " << j;
    }
  }
  return agreement;
}

double max_skinning_discrepancy_seen = 0;

void expect_matches_reference(const std::string& path, const Character& character) {
  const Agreement agreement = compare_with_reference(path, character);
  const double relative = agreement.max_vertex_error / std::max(1.0, agreement.size);
  std::printf("%-18s joints %3d meshes %2zu  height %.4f  max |skinned - reference| %.3g (size %.3g)\n",
              fs::path(path).filename().c_str(), character.skeleton.joint_count(), character.meshes.size(),
              character.rest_bounds().sizes().z(), agreement.max_vertex_error, agreement.size);
  EXPECT_LT(relative, 1e-5) << path;
  max_skinning_discrepancy_seen = std::max(max_skinning_discrepancy_seen, relative);
}

// A file whose nodes hold another pose than its bind pose rests in the bind pose (the
// reference's node pose is not its rest pose); skinned at the pose the nodes hold, W = C [R | t]
// of each joint's node (R the rotation closest to its world matrix), its meshes must still be
// the reference's to 1e-5 of its size.
void expect_node_pose_matches_reference(const std::string& path, const Character& character) {
  const Reference ref = evaluate(path);
  std::vector<RigidTransform<double>> posed(character.skeleton.joint_count());
  for (int j = 0; j < character.skeleton.joint_count(); ++j) {
    const Matrix4d& g = ref.world[character.source_node_of_joint[j]];
    const Eigen::JacobiSVD<Eigen::Matrix3d> svd(g.topLeftCorner<3, 3>(), Eigen::ComputeFullU | Eigen::ComputeFullV);
    posed[j].rotation = y_up_to_z_up() * svd.matrixU() * svd.matrixV().transpose();
    posed[j].translation = z_up(g.topRightCorner<3, 1>());
  }
  const double size = character.rest_bounds().diagonal().norm();
  double worst = 0;
  ASSERT_EQ(character.meshes.size(), ref.meshes.size()) << path;
  for (std::size_t m = 0; m < character.meshes.size(); ++m) {
    const auto skinned = skin_mesh_reference(character.meshes[m], posed);
    ASSERT_EQ(skinned.size(), ref.meshes[m].size()) << path << " mesh " << m;
    for (std::size_t v = 0; v < skinned.size(); ++v) worst = std::max(worst, (skinned[v] - ref.meshes[m][v]).norm());
  }
  std::printf("%-18s at the nodes' pose: max |skinned - reference| %.3g (size %.3g)\n", fs::path(path).filename().c_str(),
              worst, size);
  EXPECT_LT(worst, 1e-5 * std::max(1.0, size)) << path;
}

double joint_z(const Character& character, const std::string& name) {
  const int joint = character.skeleton.find(name);
  EXPECT_GE(joint, 0) << name;
  return joint < 0 ? NAN : character.skeleton.rest_world()[joint].translation.z();
}

void expect_weights_sum_to_one(const Character& character) {
  for (const CharacterMesh& mesh : character.meshes) {
    for (const auto& w : mesh.influence_weights) {
      ASSERT_NEAR(w[0] + w[1] + w[2] + w[3], 1.0f, 1e-6f) << mesh.name;
    }
  }
}

// --- The sample characters. ---

TEST(GltfCharacterTest, RobotExpressiveHasItsRigAndRigidParts) {
  const std::string path = character_path("RobotExpressive.glb");
  const Character robot = load_character(path);
  EXPECT_EQ(robot.name, "RobotExpressive");
  // 43 skin joints plus the 12 rigid mesh nodes; RootNode and the 100-scaled RobotArmature are
  // folded into the root joint "Bone".
  EXPECT_EQ(robot.skeleton.joint_count(), 43 + 12);
  EXPECT_EQ(robot.skeleton.name(0), "Bone");
  EXPECT_EQ(robot.skeleton.parent(0), -1);
  EXPECT_NEAR(robot.source_scale_of_joint[0], 100.0, 1e-3);
  // Feet hang from the root bone, not from the shins (an IK-style rig).
  EXPECT_EQ(robot.skeleton.parent(robot.skeleton.find("Foot.L")), robot.skeleton.find("Bone"));
  // Names taken twice (a bone and the rigid mesh node under it) keep the bone's name.
  EXPECT_EQ(robot.source_node_of_joint[robot.skeleton.find("Torso")], 10);
  EXPECT_EQ(robot.source_node_of_joint[robot.skeleton.find("Torso_node7")], 7);
  EXPECT_EQ(robot.source_node_of_joint[robot.skeleton.find("Foot.L_node4")], 4);
  // 12 rigid mesh nodes with 15 primitives between them, 2 skinned (two primitives each) over
  // two skins of 43 joints.
  int rigid = 0, skinned = 0;
  for (const CharacterMesh& mesh : robot.meshes) {
    if (mesh.skin_joints.size() == 1) ++rigid;
    if (mesh.skin_joints.size() == 43) ++skinned;
  }
  EXPECT_EQ(rigid, 15);
  EXPECT_EQ(skinned, 4);
  EXPECT_EQ(evaluate(path).mesh_nodes.size(), 14u);
  expect_weights_sum_to_one(robot);
  // Its nodes hold the idle pose (arms down, standing on the floor), its inverse bind matrices the
  // T-pose its mesh was modelled in: the rest pose is the T-pose (gltf_character.h, "The bind
  // pose"), and skinning at the nodes' pose gives the file's idle pose exactly.
  EXPECT_TRUE(robot.rest_pose_origin.starts_with("inverse bind matrices")) << robot.rest_pose_origin;
  expect_node_pose_matches_reference(path, robot);

  // Z up. With the armature's scale of 100 applied the file's robot is 4.53 units tall in its
  // T-pose (4.46 in the idle pose three.js shows; glTF units are metres): the loader keeps the
  // file's size, and retargeting equalises heights. Blender's importer puts it 2.39 units below
  // the armature's origin, as here (test_any_humanoid_blender.cpp).
  const Eigen::AlignedBox3d bounds = robot.rest_bounds();
  EXPECT_NEAR(bounds.min().z(), -2.391, 0.005);
  EXPECT_NEAR(bounds.sizes().z(), 4.534, 0.005);
  EXPECT_GT(joint_z(robot, "Head"), joint_z(robot, "Foot.L") + 1.0);
  EXPECT_GT(joint_z(robot, "Head"), joint_z(robot, "Foot.R") + 1.0);
  // The only remarks: the expression morph targets on the head's three primitives (default
  // weights zero) are not loaded.
  ASSERT_EQ(robot.warnings.size(), 3u);
  for (const std::string& warning : robot.warnings) {
    EXPECT_NE(warning.find("'Head#"), std::string::npos) << warning;
    EXPECT_NE(warning.find("morph targets not loaded"), std::string::npos) << warning;
  }
}

TEST(GltfCharacterTest, CesiumManHasNineteenUnnamedJoints) {
  const std::string path = character_path("CesiumMan.glb");
  const Character man = load_character(path);
  EXPECT_EQ(man.skeleton.joint_count(), 19);
  ASSERT_EQ(man.meshes.size(), 1u);
  EXPECT_EQ(man.meshes[0].skin_joints.size(), 19u);
  // Unnamed nodes are named after their node index; the root joint is node 2, under the Z-up
  // conversion matrix and an empty node, both folded away.
  EXPECT_EQ(man.skeleton.name(0), "joint_2");
  for (int j = 0; j < man.skeleton.joint_count(); ++j) {
    EXPECT_EQ(man.skeleton.name(j), "joint_" + std::to_string(man.source_node_of_joint[j]));
  }
  expect_weights_sum_to_one(man);
  expect_matches_reference(path, man);
  const Eigen::AlignedBox3d bounds = man.rest_bounds();
  EXPECT_NEAR(bounds.min().z(), 0.0, 0.02);
  EXPECT_NEAR(bounds.sizes().z(), 1.5065, 0.001);  // a 1.5 m man
  // Node 20 ends the spine (the head), nodes 6 and 10 end the legs.
  EXPECT_GT(joint_z(man, "joint_20"), joint_z(man, "joint_6") + 1.0);
  EXPECT_GT(joint_z(man, "joint_20"), joint_z(man, "joint_10") + 1.0);
}

TEST(GltfCharacterTest, RiggedFigureHasNineteenNamedJoints) {
  const std::string path = character_path("RiggedFigure.glb");
  const Character figure = load_character(path);
  EXPECT_EQ(figure.skeleton.joint_count(), 19);
  EXPECT_EQ(figure.skeleton.name(0), "torso_joint_1");
  EXPECT_GE(figure.skeleton.find("arm_joint_L_1"), 0);
  expect_weights_sum_to_one(figure);
  expect_matches_reference(path, figure);
  const Eigen::AlignedBox3d bounds = figure.rest_bounds();
  EXPECT_NEAR(bounds.min().z(), 0.0, 0.02);
  EXPECT_NEAR(bounds.sizes().z(), 1.4499, 0.001);
  EXPECT_GT(joint_z(figure, "neck_joint_2"), joint_z(figure, "leg_joint_L_5") + 1.0);
  EXPECT_GT(joint_z(figure, "neck_joint_2"), joint_z(figure, "leg_joint_R_5") + 1.0);
}

TEST(GltfCharacterTest, RiggedSimpleIsATwoJointCylinder) {
  const std::string path = character_path("RiggedSimple.glb");
  const Character cylinder = load_character(path);
  EXPECT_EQ(cylinder.skeleton.joint_count(), 2);
  EXPECT_EQ(cylinder.skeleton.names(), (std::vector<std::string>{"joint_2", "joint_3"}));
  EXPECT_EQ(cylinder.skeleton.parents(), (std::vector<int>{-1, 0}));
  expect_matches_reference(path, cylinder);
}

TEST(GltfCharacterTest, FoxHasTwentyFourJoints) {
  const std::string path = character_path("Fox.glb");
  const Character fox = load_character(path);
  EXPECT_EQ(fox.skeleton.joint_count(), 24);
  EXPECT_EQ(fox.skeleton.name(0), "_rootJoint");
  expect_weights_sum_to_one(fox);
  expect_matches_reference(path, fox);
  // Modelled in centimetre-like units with no scale node: the loader keeps the file's units, so
  // the fox stands 79 units tall.
  EXPECT_NEAR(fox.rest_bounds().min().z(), 0.0, 0.5);
  EXPECT_NEAR(fox.rest_bounds().sizes().z(), 79.03, 0.05);
  EXPECT_GT(joint_z(fox, "b_Head_05"), joint_z(fox, "b_LeftFoot02_018"));
}

TEST(GltfCharacterTest, SimpleSkinReadsDataUris) {
  const std::string path = character_path("SimpleSkin.gltf");
  const Character simple = load_character(path);
  EXPECT_EQ(simple.skeleton.joint_count(), 2);
  EXPECT_EQ(simple.skeleton.names(), (std::vector<std::string>{"joint_1", "joint_2"}));
  ASSERT_EQ(simple.meshes.size(), 1u);
  EXPECT_EQ(simple.meshes[0].positions.size(), 10u);
  EXPECT_EQ(simple.meshes[0].triangles.size(), 24u);
  // Joint 1 sits at glTF (0, 1, 0), which is Z-up (0, 0, 1).
  EXPECT_LT((simple.skeleton.rest_world()[1].translation - Vector3d(0, 0, 1)).norm(), 1e-12);
  expect_matches_reference(path, simple);
}

TEST(GltfCharacterTest, ReportsTheLargestSkinningDiscrepancy) {
  // (RobotExpressive rests in its bind pose, not its nodes' pose: checked at the nodes' pose above.)
  for (const char* file : {"CesiumMan.glb", "RiggedFigure.glb", "RiggedSimple.glb", "Fox.glb", "SimpleSkin.gltf"}) {
    const std::string path = character_path(file);
    expect_matches_reference(path, load_character(path));
  }
  std::printf("largest rest-pose skinning discrepancy over the sample characters: %.3g of the character's size\n",
              max_skinning_discrepancy_seen);
}

// --- Small hand-written files. ---

// A buffer, built little-endian, embedded as a base64 data URI.
struct Bytes {
  std::string data;
  void f32(float v) { data.append(reinterpret_cast<const char*>(&v), 4); }
  void u16(std::uint16_t v) { data.append(reinterpret_cast<const char*>(&v), 2); }
  void u8(std::uint8_t v) { data.push_back(static_cast<char>(v)); }
  std::string data_uri() const {
    static const char* const digits = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    std::string out = "data:application/octet-stream;base64,";
    for (std::size_t i = 0; i < data.size(); i += 3) {
      const std::size_t n = std::min<std::size_t>(3, data.size() - i);
      std::uint32_t chunk = 0;
      for (std::size_t k = 0; k < 3; ++k) chunk = chunk << 8 | (k < n ? static_cast<std::uint8_t>(data[i + k]) : 0);
      for (std::size_t k = 0; k < 4; ++k) out.push_back(k <= n ? digits[(chunk >> (18 - 6 * k)) & 63] : '=');
    }
    return out;
  }
};

// One triangle skinned to a two-joint chain, hip at the origin and knee one unit up (glTF y):
// vertex 0 (1, 0, 0) follows the hip, vertex 1 (1, 1, 0) both (quantised weights 100 and 100 of
// 255, renormalised to 1/2 each), vertex 2 (1, 2, 0) the knee. The byte layout:
//   0   positions, 3 float VEC3         (36 bytes)
//   36  indices, 3 unsigned short       (6 bytes, 2 padding)
//   44  joints, 3 unsigned byte VEC4    (12 bytes)
//   56  weights, 3 unsigned byte VEC4   (12 bytes, normalised)
//   68  inverse binds, 2 float MAT4     (128 bytes): identity, and a translation by (0, -1, 0)
//   196 sparse indices, 2 unsigned byte (2 bytes, 2 padding): vertices 1 and 2
//   200 sparse values, 2 float VEC3     (24 bytes): (2, 1, 0) and (2, 2, 0)
//   224 more weights, 3 unsigned byte VEC4 (12 bytes): vertex 1 gets (1, 1, 1, 0)
// Parts of the JSON can be replaced to make each variant.
struct TinyFile {
  std::string nodes = R"([{"mesh": 0, "skin": 0}, {"name": "hip", "children": [2]},
                          {"name": "knee", "translation": [0, 1, 0]}])";
  std::string scene_nodes = "[0, 1]";
  std::string skins = R"([{"joints": [1, 2], "inverseBindMatrices": 4}])";
  std::string primitives = R"([{"attributes": {"POSITION": 0, "JOINTS_0": 2, "WEIGHTS_0": 3}, "indices": 1}])";
  std::string extra_meshes;     // appended to "meshes", after mesh 0
  std::string extra_accessors;  // appended to "accessors", from index 5 on

  std::string json() const {
    Bytes b;
    for (float y : {0.0f, 1.0f, 2.0f}) b.f32(1), b.f32(y), b.f32(0);
    for (std::uint16_t i : {0, 1, 2, 0}) b.u16(i);
    for (std::uint8_t j : {0, 0, 0, 0, 0, 1, 0, 0, 1, 0, 0, 0}) b.u8(j);
    for (std::uint8_t w : {255, 0, 0, 0, 100, 100, 0, 0, 255, 0, 0, 0}) b.u8(w);
    for (int m = 0; m < 2; ++m) {
      for (int i = 0; i < 16; ++i) b.f32(i % 5 == 0 ? 1.0f : (m == 1 && i == 13) ? -1.0f : 0.0f);
    }
    for (std::uint8_t i : {1, 2, 0, 0}) b.u8(i);
    for (float v : {2.0f, 1.0f, 0.0f, 2.0f, 2.0f, 0.0f}) b.f32(v);
    for (std::uint8_t w : {0, 0, 0, 0, 1, 1, 1, 0, 0, 0, 0, 0}) b.u8(w);
    return R"({"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": )" + scene_nodes +
           R"(}], "nodes": )" + nodes + R"(, "skins": )" + skins + R"(, "meshes": [{"name": "leg", "primitives": )" +
           primitives + "}" + extra_meshes + R"(],
  "buffers": [{"byteLength": )" + std::to_string(b.data.size()) + R"(, "uri": ")" + b.data_uri() + R"("}],
  "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 36}, {"buffer": 0, "byteOffset": 36, "byteLength": 6},
                  {"buffer": 0, "byteOffset": 44, "byteLength": 12}, {"buffer": 0, "byteOffset": 56, "byteLength": 12},
                  {"buffer": 0, "byteOffset": 68, "byteLength": 128}, {"buffer": 0, "byteOffset": 196, "byteLength": 2},
                  {"buffer": 0, "byteOffset": 200, "byteLength": 24}, {"buffer": 0, "byteOffset": 224, "byteLength": 12}],
  "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3"},
                {"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"},
                {"bufferView": 2, "componentType": 5121, "count": 3, "type": "VEC4"},
                {"bufferView": 3, "componentType": 5121, "normalized": true, "count": 3, "type": "VEC4"},
                {"bufferView": 4, "componentType": 5126, "count": 2, "type": "MAT4"})" +
           extra_accessors + "]}";
  }
  std::string write(const std::string& name) const { return write_scratch(name, json()); }
};

TEST(GltfCharacterTest, TinyFileSkinsWithRenormalisedByteWeights) {
  const std::string path = TinyFile{}.write("tiny.gltf");
  const Character tiny = load_character(path);
  EXPECT_EQ(tiny.name, "tiny");
  EXPECT_EQ(tiny.skeleton.names(), (std::vector<std::string>{"hip", "knee"}));
  EXPECT_EQ(tiny.skeleton.parents(), (std::vector<int>{-1, 0}));
  ASSERT_EQ(tiny.meshes.size(), 1u);
  const CharacterMesh& leg = tiny.meshes[0];
  EXPECT_EQ(leg.triangles, (std::vector<std::uint32_t>{0, 1, 2}));
  EXPECT_FLOAT_EQ(leg.influence_weights[1][0], 0.5f);
  EXPECT_FLOAT_EQ(leg.influence_weights[1][1], 0.5f);
  EXPECT_EQ(leg.influence_slots[1][1], 1);
  // Bind pose = rest pose: the vertices stay where they are, (1, y, 0) -> Z up (1, 0, y).
  const auto skinned = skin_mesh_reference(leg, tiny.skeleton.rest_world());
  for (int v = 0; v < 3; ++v) EXPECT_LT((skinned[v] - Vector3d(1, 0, v)).norm(), 1e-12) << v;
  expect_matches_reference(path, tiny);
  EXPECT_TRUE(tiny.warnings.empty());
}

TEST(GltfCharacterTest, SparseAccessorOverAnAbsentBufferViewIsZerosThenSubstitutions) {
  TinyFile file;
  // POSITION = accessor 5: no buffer view (zeros), vertices 1 and 2 replaced by sparse values.
  file.primitives = R"([{"attributes": {"POSITION": 5, "JOINTS_0": 2, "WEIGHTS_0": 3}, "indices": 1}])";
  file.extra_accessors = R"(, {"componentType": 5126, "count": 3, "type": "VEC3", "sparse": {"count": 2,
      "indices": {"bufferView": 5, "componentType": 5121}, "values": {"bufferView": 6}}})";
  const Character tiny = load_character(file.write("sparse.gltf"));
  const auto& p = tiny.meshes.at(0).positions;
  EXPECT_EQ(p[0], Eigen::Vector3f(0, 0, 0));
  EXPECT_EQ(p[1], Eigen::Vector3f(2, 1, 0));
  EXPECT_EQ(p[2], Eigen::Vector3f(2, 2, 0));
}

TEST(GltfCharacterTest, RigidMeshesOnNodesAndSkippedModes) {
  TinyFile file;
  // Mesh 1 on the knee: a triangle rigidly attached, and a LINES primitive that is skipped. The
  // knee also scales by 2, which a leaf joint may: the scale lives in its inverse binds.
  file.nodes = R"([{"mesh": 0, "skin": 0}, {"name": "hip", "children": [2]},
                   {"name": "knee", "translation": [0, 1, 0], "scale": [2, 2, 2], "mesh": 1}])";
  file.extra_meshes = R"(, {"name": "pad", "primitives": [{"attributes": {"POSITION": 0}, "indices": 1},
                                                          {"attributes": {"POSITION": 0}, "mode": 1}]})";
  const std::string path = file.write("rigid.gltf");
  const Character tiny = load_character(path);
  ASSERT_EQ(tiny.meshes.size(), 2u);
  const CharacterMesh& pad = tiny.meshes[1];
  EXPECT_EQ(pad.name, "pad#0");
  EXPECT_EQ(pad.skin_joints, std::vector<int>{tiny.skeleton.find("knee")});
  Matrix4d scaled = Matrix4d::Identity();
  scaled(0, 0) = scaled(1, 1) = scaled(2, 2) = 2;
  for (int i = 0; i < 16; ++i) EXPECT_NEAR(pad.inverse_bind[0](i % 4, i / 4), scaled(i % 4, i / 4), 1e-12) << i;
  EXPECT_EQ(tiny.source_scale_of_joint[tiny.skeleton.find("knee")], 2.0);
  ASSERT_EQ(tiny.warnings.size(), 1u);
  EXPECT_NE(tiny.warnings[0].find("mode 1"), std::string::npos) << tiny.warnings[0];
  expect_matches_reference(path, tiny);
}

TEST(GltfCharacterTest, UnevenScaleOnALeafJointIsExactAtRest) {
  TinyFile file;
  file.nodes = R"([{"mesh": 0, "skin": 0}, {"name": "hip", "children": [2], "scale": [1.5, 1.5, 1.5]},
                   {"name": "knee", "translation": [0, 1, 0], "scale": [1, 3, 0.5]}])";
  const std::string path = file.write("leaf_scale.gltf");
  const Character tiny = load_character(path);
  expect_matches_reference(path, tiny);
  // The hip's scale moves the knee to 1.5 units up.
  EXPECT_NEAR(tiny.skeleton.rest_offsets()[1].norm(), 1.5, 1e-12);
}

TEST(GltfCharacterTest, IntermediateNodesBetweenJointsBecomeJoints) {
  TinyFile file;
  // "twist" is no skin joint, but lies between hip and knee and turns 90 degrees about y.
  file.nodes = R"([{"mesh": 0, "skin": 0}, {"name": "hip", "children": [2]},
                   {"name": "twist", "children": [3], "translation": [0, 0.5, 0], "rotation": [0, 0.7071068, 0, 0.7071068]},
                   {"name": "knee", "translation": [0, 0.5, 0]}])";
  file.skins = R"([{"joints": [1, 3], "inverseBindMatrices": 4}])";
  const std::string path = file.write("intermediate.gltf");
  const Character tiny = load_character(path);
  EXPECT_EQ(tiny.skeleton.names(), (std::vector<std::string>{"hip", "twist", "knee"}));
  EXPECT_EQ(tiny.skeleton.parents(), (std::vector<int>{-1, 0, 1}));
  EXPECT_EQ(tiny.meshes.at(0).skin_joints, (std::vector<int>{0, 2}));
  EXPECT_LT((tiny.skeleton.rest_world()[2].translation - Vector3d(0, 0, 1)).norm(), 1e-12);
  expect_matches_reference(path, tiny);
}

TEST(GltfCharacterTest, WeightlessVerticesFollowTheirFirstJoint) {
  TinyFile file;
  // WEIGHTS_0 = accessor 5: no buffer view, so every weight is zero.
  file.primitives = R"([{"attributes": {"POSITION": 0, "JOINTS_0": 2, "WEIGHTS_0": 5}, "indices": 1}])";
  file.extra_accessors = R"(, {"componentType": 5121, "normalized": true, "count": 3, "type": "VEC4"})";
  const Character tiny = load_character(file.write("weightless.gltf"));
  const CharacterMesh& leg = tiny.meshes.at(0);
  for (int v = 0; v < 3; ++v) {
    EXPECT_EQ(leg.influence_weights[v], (std::array<float, 4>{1, 0, 0, 0})) << v;
    EXPECT_EQ(leg.influence_slots[v][0], v == 2 ? 1 : 0) << v;  // JOINTS_0.x of each vertex
  }
  ASSERT_EQ(tiny.warnings.size(), 1u);
  EXPECT_NE(tiny.warnings[0].find("3 vertices have no weight"), std::string::npos) << tiny.warnings[0];
}

TEST(GltfCharacterTest, KeepsTheFourLargestOfMoreInfluences) {
  TinyFile file;
  // A second set: vertex 1 gets weights 1, 1, 1 (of 255) on slots 0, 1, 0 besides 100 and 100.
  file.primitives = R"([{"attributes": {"POSITION": 0, "JOINTS_0": 2, "WEIGHTS_0": 3, "JOINTS_1": 2,
                                        "WEIGHTS_1": 5}, "indices": 1}])";
  file.extra_accessors = R"(, {"bufferView": 7, "componentType": 5121, "normalized": true, "count": 3, "type": "VEC4"})";
  const Character tiny = load_character(file.write("eight_influences.gltf"));
  const CharacterMesh& leg = tiny.meshes.at(0);
  EXPECT_EQ(leg.influence_slots[1], (std::array<std::uint16_t, 4>{0, 1, 0, 1}));
  EXPECT_FLOAT_EQ(leg.influence_weights[1][0], 100.0f / 202);
  EXPECT_FLOAT_EQ(leg.influence_weights[1][3], 1.0f / 202);
  ASSERT_EQ(tiny.warnings.size(), 1u);
  EXPECT_NE(tiny.warnings[0].find("1 vertices have more than 4"), std::string::npos) << tiny.warnings[0];
}

TEST(GltfCharacterTest, NamesAreGeneratedAndMadeUnique) {
  TinyFile file;
  file.nodes = R"([{"mesh": 0, "skin": 0}, {"name": "bone", "children": [2]}, {"name": "bone", "children": [3]},
                   {"translation": [0, 1, 0]}])";
  file.skins = R"([{"joints": [2, 3]}])";  // no inverse binds: identity
  const std::string path = file.write("names.gltf");
  const Character tiny = load_character(path);
  // Node 1 is not a joint of the skin: it lies above, with one child, and is folded away.
  EXPECT_EQ(tiny.skeleton.names(), (std::vector<std::string>{"bone", "joint_3"}));
  EXPECT_EQ(tiny.source_node_of_joint, (std::vector<int>{2, 3}));
  expect_matches_reference(path, tiny);

  file.skins = R"([{"joints": [1, 2, 3]}])";
  const Character three = load_character(file.write("names3.gltf"));
  EXPECT_EQ(three.skeleton.names(), (std::vector<std::string>{"bone", "bone_node2", "joint_3"}));
}

// --- Bad input. ---

void expect_input_error(const std::string& path, const std::string& fragment) {
  try {
    load_character(path);
    ADD_FAILURE() << path << " loaded, expected an error about '" << fragment << "'";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(path), std::string::npos) << what;
    EXPECT_NE(what.find(fragment), std::string::npos) << what;
    std::printf("  rejected as expected: %s\n", what.c_str());
  }
}

TEST(GltfCharacterTest, RejectsAMissingFile) {
  expect_input_error((scratch_dir() / "no_such_character.glb").string(), "no such file");
}

TEST(GltfCharacterTest, RejectsATruncatedGlb) {
  std::ifstream in(character_path("RiggedSimple.glb"), std::ios::binary);
  const std::string whole((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  ASSERT_GT(whole.size(), 1000u);
  expect_input_error(write_scratch("half.glb", whole.substr(0, whole.size() / 2)), "truncated GLB");
  expect_input_error(write_scratch("header_only.glb", whole.substr(0, 16)), "truncated GLB");
  expect_input_error(write_scratch("json_cut.glb", whole.substr(0, 100)), "truncated GLB");
  // The same bytes with the header's length patched to match: the JSON chunk is what's cut.
  std::string patched = whole.substr(0, 100);
  const std::uint32_t length = 100;
  std::memcpy(patched.data() + 8, &length, 4);
  expect_input_error(write_scratch("json_cut_patched.glb", patched), "JSON chunk");
}

TEST(GltfCharacterTest, RejectsAJointCycle) {
  TinyFile file;
  file.nodes = R"([{"mesh": 0, "skin": 0}, {"name": "hip", "children": [2]}, {"name": "knee", "children": [1]}])";
  file.scene_nodes = "[0]";
  expect_input_error(file.write("cycle.gltf"), "cycle");
  file.nodes = R"([{"mesh": 0, "skin": 0}, {"name": "hip", "children": [1]}, {"name": "knee"}])";
  expect_input_error(file.write("self_child.gltf"), "cycle");
  file.nodes = R"([{"mesh": 0, "skin": 0, "children": [2]}, {"name": "hip", "children": [2]}, {"name": "knee"}])";
  expect_input_error(file.write("two_parents.gltf"), "two parents");
}

TEST(GltfCharacterTest, RejectsOutOfRangeReferences) {
  TinyFile file;
  file.primitives = R"([{"attributes": {"POSITION": 99, "JOINTS_0": 2, "WEIGHTS_0": 3}, "indices": 1}])";
  expect_input_error(file.write("accessor_index.gltf"), "accessor 99");
  file = TinyFile{};
  file.skins = R"([{"joints": [1, 7], "inverseBindMatrices": 4}])";
  expect_input_error(file.write("joint_index.gltf"), "node 7");
  file = TinyFile{};
  file.nodes = R"([{"mesh": 0, "skin": 0}, {"name": "hip", "children": [2, 9]}, {"name": "knee"}])";
  expect_input_error(file.write("child_index.gltf"), "node 9");
  // Accessor 5 claims 4 positions in a view of 3.
  file = TinyFile{};
  file.primitives = R"([{"attributes": {"POSITION": 5, "JOINTS_0": 2, "WEIGHTS_0": 3}, "indices": 1}])";
  file.extra_accessors = R"(, {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3"})";
  expect_input_error(file.write("accessor_range.gltf"), "past the end of its buffer view");
  // The weights' bytes read as joint slots: slot 255 of a two-joint skin; and read through the
  // weights' own normalised accessor, which cannot hold indices.
  file = TinyFile{};
  file.primitives = R"([{"attributes": {"POSITION": 0, "JOINTS_0": 5, "WEIGHTS_0": 3}, "indices": 1}])";
  file.extra_accessors = R"(, {"bufferView": 3, "componentType": 5121, "count": 3, "type": "VEC4"})";
  expect_input_error(file.write("joint_slot.gltf"), "joint slot 255");
  file = TinyFile{};
  file.primitives = R"([{"attributes": {"POSITION": 0, "JOINTS_0": 3, "WEIGHTS_0": 3}, "indices": 1}])";
  expect_input_error(file.write("joint_normalised.gltf"), "normalised");
  // Positions read as the wrong element type, and a sparse index past the end.
  file = TinyFile{};
  file.primitives = R"([{"attributes": {"POSITION": 2, "JOINTS_0": 2, "WEIGHTS_0": 3}, "indices": 1}])";
  expect_input_error(file.write("position_type.gltf"), "expected VEC3");
  file = TinyFile{};
  file.primitives = R"([{"attributes": {"POSITION": 5, "JOINTS_0": 2, "WEIGHTS_0": 3}, "indices": 1}])";
  file.extra_accessors = R"(, {"componentType": 5126, "count": 2, "type": "VEC3", "sparse": {"count": 2,
      "indices": {"bufferView": 5, "componentType": 5121}, "values": {"bufferView": 6}}})";
  expect_input_error(file.write("sparse_index.gltf"), "sparse index 2");
}

TEST(GltfCharacterTest, RejectsUnevenScaleAboveJoints) {
  TinyFile file;
  file.nodes = R"([{"mesh": 0, "skin": 0}, {"name": "hip", "children": [2], "scale": [1, 2, 1]},
                   {"name": "knee", "translation": [0, 1, 0]}])";
  expect_input_error(file.write("uneven_scale.gltf"), "scales unevenly");
  file.nodes = R"([{"mesh": 0, "skin": 0}, {"name": "hip", "children": [2], "scale": [1, 1, -1]},
                   {"name": "knee", "translation": [0, 1, 0]}])";
  expect_input_error(file.write("mirror.gltf"), "mirrors");
}

TEST(GltfCharacterTest, RejectsMalformedJson) {
  expect_input_error(write_scratch("broken.gltf", R"({"asset": {"version": "2.0"}, "nodes": [)"), "not a readable glTF");
}

}  // namespace
}  // namespace odyssey::io
