// Animated GLB out: for every sample character, a clip with known rotations (past pi, and with
// sign-flipped quaternions on odd frames), a moving root and a translated inner joint is written,
// then checked from outside the writer:
//   - the Khronos validator (node + tools/gltf-validator) finds zero errors, though the
//     RobotExpressive and CesiumMan inputs have hundreds;
//   - the file, read back with tinygltf and evaluated the plain glTF way (sample the LINEAR
//     channels, full 4x4 T R S with scale, world = parent * local, then Y up -> Z up), puts every
//     joint where the toolkit's forward kinematics of the clip does, at the frames and halfway
//     between them (against the clip resampled with slerp), and skins every mesh like the
//     toolkit's reference skinning;
//   - rotation samples keep one quaternion sign, samplers are LINEAR, times carry min and max;
//   - every vertex's float weights sum to 1 within 1e-6;
//   - a SimpleSkin variant made awkward on purpose (external .bin buffers, a file and a data-URI
//     image, matrix joints with uneven and mirrored scale, a joint listed twice, a weightless
//     vertex, wrong accessor bounds) comes out self-contained, animated right and clean;
//   - failures throw, name the problem and leave nothing at the output path.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <tiny_gltf.h>

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "gltf_reference.h"
#include "mocap_io/gltf_character.h"
#include "mocap_io/gltf_export.h"
#include "mocap_io/input_error.h"
#include "skeleton/rotation.h"
#include "test_support.h"
#include "gltf_validator.h"

namespace odyssey::io {
namespace {

namespace fs = std::filesystem;
using Eigen::Matrix3d;
using Eigen::Matrix4d;
using Eigen::Quaterniond;
using Eigen::Vector3d;

std::string character_path(const std::string& file) {
  return std::string(ODYSSEY_SHARED_DIR) + "/assets/characters/" + file;
}

fs::path scratch_dir() {
  const fs::path dir = odyssey::test_support::scratch_root() / "gltf_export";
  fs::create_directories(dir);
  return dir;
}

// tools/gltf-validator beside tests/ in the source tree.
using test_support::validator_dir;
using test_support::validator_missing;

std::string quoted(const fs::path& path) {
  std::string text = "'";
  text += path.string();
  text += "'";
  return text;
}

// The character's size: the largest extent of its rest meshes.
double size_of(const Character& character) { return character.rest_bounds().sizes().maxCoeff(); }

// The clip under test. Every third joint turns about its own axis by 0.8 (1 + j % 3) f radians at
// frame f, which passes pi by frame 2; odd frames store every quaternion negated (the same
// rotation); the roots travel 10 % of the character's size a frame; one inner joint with children
// has an animated offset growing 5 % a frame.
Clip test_clip(const Character& character, int frames = 5) {
  const Skeleton& skeleton = character.skeleton;
  const int joints = skeleton.joint_count();
  Clip clip;
  clip.skeleton = skeleton;
  clip.fps = 30;
  const double size = size_of(character);
  int inner = -1;
  for (int j = 0; j < joints && inner < 0; ++j) {
    if (skeleton.parent(j) >= 0 && !skeleton.children(j).empty()) inner = j;
  }
  for (int j = 0; j < joints; ++j) {
    if (skeleton.parent(j) < 0) clip.translated_joints.push_back(j);
  }
  if (inner >= 0) clip.translated_joints.push_back(inner);
  for (int f = 0; f < frames; ++f) {
    for (int j = 0; j < joints; ++j) {
      Quaterniond q = skeleton.rest_rotations()[j];
      if (j % 3 == 0) {
        const Vector3d axis = Vector3d(1.0 + j % 2, 0.5, -0.3 * (j % 5)).normalized();
        q = q * Quaterniond(Eigen::AngleAxisd(0.8 * (1 + j % 3) * f, axis));
      }
      clip.rotations.push_back(f % 2 ? Quaterniond(-q.coeffs()) : q);
    }
    for (int j : clip.translated_joints) {
      const Vector3d rest = skeleton.rest_offsets()[j];
      clip.translations.push_back(skeleton.parent(j) < 0 ? Vector3d(rest + size * f * Vector3d(0.1, -0.05, 0.02))
                                                         : Vector3d(rest * (1 + 0.05 * f)));
    }
  }
  return clip;
}

// --- The written file read back and evaluated the plain glTF way. ---

using gltf_reference::elements;
using gltf_reference::parse;
using gltf_reference::static_local;
using gltf_reference::trs_matrix;

// glTF's LINEAR sampler at time t: the keys around t, lerp for vectors and, for rotations, slerp
// as the spec writes it (no sign flip: a file with continuous signs needs none).
std::vector<double> sample(const tinygltf::Model& model, const tinygltf::AnimationSampler& sampler, double t,
                           bool rotation) {
  const auto times = elements(model, sampler.input);
  const auto values = elements(model, sampler.output);
  if (t <= times.front()[0]) return values.front();
  if (t >= times.back()[0]) return values.back();
  std::size_t k = 0;
  while (times[k + 1][0] <= t) ++k;
  const double alpha = (t - times[k][0]) / (times[k + 1][0] - times[k][0]);
  const std::vector<double>& a = values[k];
  const std::vector<double>& b = values[k + 1];
  std::vector<double> out(a.size());
  double wa = 1 - alpha, wb = alpha;
  if (rotation) {
    const double d = std::clamp(a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3], -1.0, 1.0);
    const double angle = std::acos(d);
    if (angle > 1e-9) wa = std::sin((1 - alpha) * angle) / std::sin(angle), wb = std::sin(alpha * angle) / std::sin(angle);
  }
  for (std::size_t c = 0; c < a.size(); ++c) out[c] = wa * a[c] + wb * b[c];
  return out;
}

// World matrices of every node at time t, the animation applied.
std::vector<Matrix4d> world_at(const tinygltf::Model& model, double t) {
  std::vector<std::vector<double>> translation(model.nodes.size()), rotation(model.nodes.size());
  for (std::size_t n = 0; n < model.nodes.size(); ++n) {
    translation[n] = model.nodes[n].translation;
    rotation[n] = model.nodes[n].rotation;
  }
  for (const tinygltf::AnimationChannel& channel : model.animations.at(0).channels) {
    const auto& sampler = model.animations[0].samplers.at(channel.sampler);
    if (channel.target_path == "rotation") rotation.at(channel.target_node) = sample(model, sampler, t, true);
    if (channel.target_path == "translation") translation.at(channel.target_node) = sample(model, sampler, t, false);
  }
  std::vector<Matrix4d> world(model.nodes.size(), Matrix4d::Identity());
  std::vector<bool> has_parent(model.nodes.size(), false);
  for (const auto& node : model.nodes) {
    for (int child : node.children) has_parent[child] = true;
  }
  const std::function<void(int, const Matrix4d&)> walk = [&](int n, const Matrix4d& parent) {
    const tinygltf::Node& node = model.nodes[n];
    world[n] = parent * (node.matrix.size() == 16 ? static_local(node) : trs_matrix(translation[n], rotation[n], node.scale));
    for (int child : node.children) walk(child, world[n]);
  };
  for (std::size_t n = 0; n < model.nodes.size(); ++n) {
    if (!has_parent[n]) walk(int(n), Matrix4d::Identity());
  }
  return world;
}

// The proper rotation closest to a linear part: U diag(1, 1, det(U V^T)) V^T.
Matrix3d closest_rotation(const Matrix3d& linear) {
  const Eigen::JacobiSVD<Matrix3d> svd(linear, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const double sign = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0 ? -1 : 1;
  return svd.matrixU() * Vector3d(1, 1, sign).asDiagonal() * svd.matrixV().transpose();
}

double angle_between(const Matrix3d& a, const Matrix3d& b) {
  return Eigen::AngleAxisd(a.transpose() * b).angle();
}

struct PoseError {
  double position = 0;  // metres
  double rotation = 0;  // radians
};

// Joints of the file at time t against the toolkit's world transforms.
PoseError joint_error(const tinygltf::Model& model, const Character& character, double t,
                      const std::vector<RigidTransform<double>>& expected) {
  const std::vector<Matrix4d> world = world_at(model, t);
  const Matrix3d c = y_up_to_z_up();
  PoseError error;
  for (int j = 0; j < character.skeleton.joint_count(); ++j) {
    const Matrix4d& g = world[character.source_node_of_joint[j]];
    error.position = std::max(error.position, (c * g.topRightCorner<3, 1>() - expected[j].translation).norm());
    error.rotation = std::max(error.rotation, angle_between(c * closest_rotation(g.topLeftCorner<3, 3>()), expected[j].rotation));
  }
  return error;
}

// Every mesh skinned the glTF way at time t (all JOINTS_n/WEIGHTS_n sets, rigid meshes by their
// node's world, morph targets at their default weights), in the loader's mesh order, Z up,
// against the toolkit's reference skinning at the same world pose.
double mesh_error(const tinygltf::Model& model, const Character& character, double t,
                  const std::vector<RigidTransform<double>>& expected) {
  const std::vector<Matrix4d> world = world_at(model, t);
  const Matrix3d c = y_up_to_z_up();
  double error = 0;
  std::size_t mesh_index = 0;
  for (std::size_t n = 0; n < model.nodes.size(); ++n) {
    const tinygltf::Node& node = model.nodes[n];
    if (node.mesh < 0) continue;
    const tinygltf::Mesh& mesh = model.meshes[node.mesh];
    for (const tinygltf::Primitive& primitive : mesh.primitives) {
      if (primitive.mode != TINYGLTF_MODE_TRIANGLES) continue;
      auto positions = elements(model, primitive.attributes.at("POSITION"));
      const std::vector<double>& morph_weights = node.weights.empty() ? mesh.weights : node.weights;
      for (std::size_t k = 0; k < primitive.targets.size() && k < morph_weights.size(); ++k) {
        if (!primitive.targets[k].count("POSITION") || morph_weights[k] == 0) continue;
        const auto delta = elements(model, primitive.targets[k].at("POSITION"));
        for (std::size_t v = 0; v < positions.size(); ++v) {
          for (int i = 0; i < 3; ++i) positions[v][i] += morph_weights[k] * delta[v][i];
        }
      }
      std::vector<Matrix4d> blend(positions.size(), node.skin < 0 ? world[n] : Matrix4d::Zero());
      if (node.skin >= 0) {
        const tinygltf::Skin& skin = model.skins[node.skin];
        const auto ibm = elements(model, skin.inverseBindMatrices);
        for (int set = 0; primitive.attributes.count("JOINTS_" + std::to_string(set)); ++set) {
          const auto joints = elements(model, primitive.attributes.at("JOINTS_" + std::to_string(set)));
          const auto weights = elements(model, primitive.attributes.at("WEIGHTS_" + std::to_string(set)));
          for (std::size_t v = 0; v < positions.size(); ++v) {
            for (int i = 0; i < 4; ++i) {
              if (weights[v][i] == 0) continue;
              const int slot = int(joints[v][i]);
              Matrix4d inverse_bind;
              for (int e = 0; e < 16; ++e) inverse_bind(e % 4, e / 4) = ibm[slot][e];
              blend[v] += weights[v][i] * world[skin.joints[slot]] * inverse_bind;
            }
          }
        }
      }
      const std::vector<Vector3d> toolkit = skin_mesh_reference(character.meshes.at(mesh_index++), expected);
      for (std::size_t v = 0; v < positions.size(); ++v) {
        const Eigen::Vector4d p(positions[v][0], positions[v][1], positions[v][2], 1);
        error = std::max(error, (c * (blend[v] * p).head<3>() - toolkit[v]).norm());
      }
    }
  }
  EXPECT_EQ(mesh_index, character.meshes.size());
  return error;
}

// --- The Khronos validator, through node. ---

void expect_zero_validator_errors(const fs::path& file) {
  const fs::path log = fs::path(file).replace_extension(".validator.txt");
  const int status = std::system(("node " + quoted(validator_dir() / "validate.mjs") + " " + quoted(file) + " > " +
                                  quoted(log) + " 2>&1").c_str());
  std::ifstream in(log);
  const std::string report((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  ASSERT_TRUE(WIFEXITED(status)) << report;
  EXPECT_EQ(WEXITSTATUS(status), 0) << report;
  EXPECT_NE(report.find(": 0 errors,"), std::string::npos) << report;
}

// --- The tests. ---

class GlbExportTest : public testing::TestWithParam<std::string> {};

TEST_P(GlbExportTest, PassesTheKhronosValidatorWithZeroErrors) {
  if (const std::string missing = validator_missing(); !missing.empty()) GTEST_SKIP() << missing;
  const Character character = load_character(character_path(GetParam()));
  const fs::path out = scratch_dir() / (character.name + "_validated.glb");
  write_animated_glb(character_path(GetParam()), character, test_clip(character), out.string());
  expect_zero_validator_errors(out);
}

TEST_P(GlbExportTest, JointsAndMeshesFollowTheClipAtFramesAndBetweenThem) {
  const Character character = load_character(character_path(GetParam()));
  const Clip clip = test_clip(character);
  const fs::path out = scratch_dir() / (character.name + "_posed.glb");
  write_animated_glb(character_path(GetParam()), character, clip, out.string());
  const tinygltf::Model model = parse(out.string());
  ASSERT_EQ(model.animations.size(), 1u);
  const double size = size_of(character);
  std::vector<RigidTransform<double>> expected(character.skeleton.joint_count());
  for (int f = 0; f < clip.frame_count(); ++f) {
    clip.world_pose(f, expected);
    const PoseError error = joint_error(model, character, f / clip.fps, expected);
    EXPECT_LT(error.position, 1e-5 * size) << "frame " << f;
    EXPECT_LT(error.rotation, 1e-5) << "frame " << f;
    EXPECT_LT(mesh_error(model, character, f / clip.fps, expected), 1e-5 * size) << "frame " << f;
  }
  // Halfway between frames, LINEAR interpolation of the file's channels is the clip slerped
  // (rotations) and lerped (translations) locally: frame 2f + 1 of the clip at twice the rate.
  const Clip halfway = clip.resampled(2 * clip.fps);
  for (int f = 1; f < halfway.frame_count(); f += 2) {
    halfway.world_pose(f, expected);
    const PoseError error = joint_error(model, character, f / halfway.fps, expected);
    EXPECT_LT(error.position, 1e-5 * size) << "halfway frame " << f;
    EXPECT_LT(error.rotation, 1e-5) << "halfway frame " << f;
  }
}

TEST_P(GlbExportTest, ChannelsAreLinearWithContinuousSignsAndTimedFrames) {
  const Character character = load_character(character_path(GetParam()));
  const Clip clip = test_clip(character);
  const fs::path out = scratch_dir() / (character.name + "_channels.glb");
  write_animated_glb(character_path(GetParam()), character, clip, out.string(), {.animation_name = "walk"});
  const tinygltf::Model model = parse(out.string());
  ASSERT_EQ(model.animations.size(), 1u);
  const tinygltf::Animation& animation = model.animations[0];
  EXPECT_EQ(animation.name, "walk");

  std::map<std::string, int> channels;
  for (const tinygltf::AnimationChannel& channel : animation.channels) {
    ++channels[channel.target_path];
    const tinygltf::AnimationSampler& sampler = animation.samplers.at(channel.sampler);
    EXPECT_EQ(sampler.interpolation, "LINEAR");
    const tinygltf::Accessor& input = model.accessors.at(sampler.input);
    const auto times = elements(model, sampler.input);
    ASSERT_EQ(times.size(), std::size_t(clip.frame_count()));
    for (int f = 0; f < clip.frame_count(); ++f) EXPECT_EQ(times[f][0], static_cast<float>(f / clip.fps));
    ASSERT_EQ(input.minValues.size(), 1u);
    ASSERT_EQ(input.maxValues.size(), 1u);
    EXPECT_EQ(input.minValues[0], times.front()[0]);
    EXPECT_EQ(input.maxValues[0], times.back()[0]);
    if (channel.target_path != "rotation") continue;
    const auto q = elements(model, sampler.output);
    for (std::size_t f = 0; f < q.size(); ++f) {
      EXPECT_NEAR(std::sqrt(q[f][0] * q[f][0] + q[f][1] * q[f][1] + q[f][2] * q[f][2] + q[f][3] * q[f][3]), 1, 1e-6);
      if (f == 0) continue;
      const double dot = q[f][0] * q[f - 1][0] + q[f][1] * q[f - 1][1] + q[f][2] * q[f - 1][2] + q[f][3] * q[f - 1][3];
      EXPECT_GE(dot, 0) << "node " << channel.target_node << " flips sign at frame " << f;
    }
  }
  const int joints = character.skeleton.joint_count();
  EXPECT_EQ(channels["rotation"], joints);
  // Every root is translated in test_clip, so the translated joints are exactly the channels.
  EXPECT_EQ(channels["translation"], int(clip.translated_joints.size()));
  EXPECT_EQ(channels.size(), 2u);
}

TEST_P(GlbExportTest, IsSelfContainedWithWeightsSummingToOne) {
  const Character character = load_character(character_path(GetParam()));
  const fs::path out = scratch_dir() / (character.name + "_weights.glb");
  write_animated_glb(character_path(GetParam()), character, test_clip(character), out.string());
  const tinygltf::Model model = parse(out.string());
  ASSERT_EQ(model.buffers.size(), 1u);
  EXPECT_TRUE(model.buffers[0].uri.empty());
  for (const tinygltf::Image& image : model.images) {
    EXPECT_GE(image.bufferView, 0);
    EXPECT_TRUE(image.uri.empty());
    EXPECT_FALSE(image.mimeType.empty());
  }
  std::size_t checked = 0;
  for (const tinygltf::Mesh& mesh : model.meshes) {
    for (const tinygltf::Primitive& primitive : mesh.primitives) {
      std::vector<double> sums;
      for (int set = 0; primitive.attributes.count("WEIGHTS_" + std::to_string(set)); ++set) {
        const int accessor = primitive.attributes.at("WEIGHTS_" + std::to_string(set));
        EXPECT_EQ(model.accessors[accessor].componentType, TINYGLTF_COMPONENT_TYPE_FLOAT);
        const auto weights = elements(model, accessor);
        sums.resize(weights.size(), 0.0);
        for (std::size_t v = 0; v < weights.size(); ++v) {
          for (double w : weights[v]) {
            EXPECT_GE(w, 0);
            sums[v] += w;
          }
        }
      }
      for (std::size_t v = 0; v < sums.size(); ++v) ASSERT_NEAR(sums[v], 1.0, 1e-6) << "vertex " << v;
      checked += sums.size();
    }
  }
  EXPECT_GT(checked, 0u);
}

// Frames at rest give back the file's own node rotations and translations (up to float32), or,
// for a character resting in its bind pose rather than its nodes' (RobotExpressive), the bind
// pose's local transforms (Character::source_rest_local_of_joint).
TEST_P(GlbExportTest, RestClipReproducesTheNodeTransforms) {
  const Character character = load_character(character_path(GetParam()));
  const tinygltf::Model source = parse(character_path(GetParam()));
  Clip clip = test_clip(character, 2);
  for (int f = 0; f < 2; ++f) {
    for (int j = 0; j < clip.joint_count(); ++j) {
      clip.rotations[f * clip.joint_count() + j] = character.skeleton.rest_rotations()[j];
    }
    for (std::size_t k = 0; k < clip.translated_joints.size(); ++k) {
      clip.translations[f * clip.translated_joints.size() + k] = character.skeleton.rest_offsets()[clip.translated_joints[k]];
    }
  }
  const fs::path out = scratch_dir() / (character.name + "_rest.glb");
  write_animated_glb(character_path(GetParam()), character, clip, out.string());
  const tinygltf::Model model = parse(out.string());
  const std::vector<Matrix4d> rest = world_at(model, 0.5 / clip.fps);
  for (int j = 0; j < character.skeleton.joint_count(); ++j) {
    const int node = character.source_node_of_joint[j];
    const Matrix4d expected = character.source_rest_local_of_joint.empty() ? static_local(source.nodes[node])
                                                                           : character.source_rest_local_of_joint[j];
    const int parent = [&] {
      for (std::size_t n = 0; n < model.nodes.size(); ++n) {
        const auto& children = model.nodes[n].children;
        if (std::find(children.begin(), children.end(), node) != children.end()) return int(n);
      }
      return -1;
    }();
    const Matrix4d local = parent < 0 ? rest[node] : Matrix4d(rest[parent].inverse() * rest[node]);
    // The last rows are 0 0 0 1 in both; the top three hold rotation, scale and translation.
    EXPECT_LT((local - expected).topRows<3>().norm(), 1e-6 * (1 + expected.topRows<3>().norm()))
        << "joint '" << character.skeleton.name(j) << "'";
  }
}

INSTANTIATE_TEST_SUITE_P(SampleCharacters, GlbExportTest,
                         testing::Values("RobotExpressive.glb", "CesiumMan.glb", "RiggedFigure.glb", "RiggedSimple.glb",
                                         "SimpleSkin.gltf", "Fox.glb"),
                         [](const testing::TestParamInfo<std::string>& info) {
                           return info.param.substr(0, info.param.find('.'));
                         });

// --- Inputs the sample files do not cover, made from SimpleSkin. ---

// A 1x1 PNG, once as bytes and once as base64.
const std::vector<unsigned char> kPixelPng = {
    0x89, 0x50, 0x4e, 0x47, 0x0d, 0x0a, 0x1a, 0x0a, 0x00, 0x00, 0x00, 0x0d, 0x49, 0x48, 0x44, 0x52, 0x00, 0x00,
    0x00, 0x01, 0x00, 0x00, 0x00, 0x01, 0x08, 0x02, 0x00, 0x00, 0x00, 0x90, 0x77, 0x53, 0xde, 0x00, 0x00, 0x00,
    0x0c, 0x49, 0x44, 0x41, 0x54, 0x78, 0x9c, 0x63, 0xf8, 0xdf, 0xc0, 0x00, 0x00, 0x04, 0x01, 0x01, 0x80, 0xc5,
    0x2a, 0x18, 0x5d, 0x00, 0x00, 0x00, 0x00, 0x49, 0x45, 0x4e, 0x44, 0xae, 0x42, 0x60, 0x82};
const char* const kPixelPngBase64 = "iVBORw0KGgoAAAANSUhEUgAAAAEAAAABCAIAAACQd1PeAAAADElEQVR4nGP438AAAAQBAYDFKhhdAAAAAElFTkSuQmCC";

std::vector<double> column_major(const Matrix4d& m) { return std::vector<double>(m.data(), m.data() + 16); }

// SimpleSkin rewritten as a .gltf with external .bin buffers, an external and a data-URI image,
// both joints as `matrix` (the root turned and scaled by 2, the leaf stretched unevenly and
// mirrored), vertex 0 listing joint 1 twice and vertex 1 with no weight at all, and the POSITION
// and JOINTS_0 accessors declaring a wrong max: the validator finds 8 errors in it.
std::string write_awkward_simple_skin(const fs::path& dir) {
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string source = character_path("SimpleSkin.gltf");
  tinygltf::Model model = parse(source);  // for the decoded buffers
  std::ifstream in(source);
  nlohmann::json gltf = nlohmann::json::parse(in);

  // JOINTS_0 (unsigned short) and WEIGHTS_0 (float) interleave in buffer 1 with a 16-byte stride.
  std::vector<unsigned char>& skin_data = model.buffers.at(1).data;
  const std::uint16_t joints0[4] = {1, 1, 0, 0};
  const float weights0[4] = {0.25f, 0.25f, 0, 0}, weights1[4] = {0, 0, 0, 0};
  std::memcpy(skin_data.data() + 0 * 16, joints0, sizeof joints0);
  std::memcpy(skin_data.data() + 160 + 0 * 16, weights0, sizeof weights0);
  std::memcpy(skin_data.data() + 160 + 1 * 16, weights1, sizeof weights1);
  gltf["accessors"][1]["max"] = {1, 2.5, 0};  // POSITION's true maximum is (1, 2, 0)
  for (std::size_t b = 0; b < model.buffers.size(); ++b) {
    const std::string name = "buffer" + std::to_string(b) + ".bin";
    std::ofstream(dir / name, std::ios::binary)
        .write(reinterpret_cast<const char*>(model.buffers[b].data.data()), std::streamsize(model.buffers[b].data.size()));
    gltf["buffers"][b]["uri"] = name;
  }

  Eigen::Affine3d root = Eigen::Translation3d(0, 1, 0) * Eigen::AngleAxisd(0.5, Vector3d::UnitZ()) * Eigen::Scaling(2.0);
  Eigen::Affine3d leaf = Eigen::Translation3d(0.1, 0, 0) * Eigen::AngleAxisd(0.35, Vector3d::UnitX()) *
                         Eigen::Scaling(Vector3d(1, 1.5, -0.5));
  gltf["nodes"][1] = {{"children", {2}}, {"matrix", column_major(root.matrix())}};
  gltf["nodes"][2] = {{"matrix", column_major(leaf.matrix())}};

  std::ofstream(dir / "pixel.png", std::ios::binary)
      .write(reinterpret_cast<const char*>(kPixelPng.data()), std::streamsize(kPixelPng.size()));
  gltf["images"] = {{{"uri", "pixel.png"}}, {{"uri", std::string("data:image/png;base64,") + kPixelPngBase64}}};

  const fs::path path = dir / "awkward.gltf";
  std::ofstream(path) << gltf.dump(1);
  return path.string();
}

TEST(GlbExportInputsTest, EmbedsExternalDataAnimatesMatrixJointsAndCleansWeights) {
  const std::string path = write_awkward_simple_skin(scratch_dir() / "awkward");
  const Character character = load_character(path);
  const Clip clip = test_clip(character);
  const fs::path out = scratch_dir() / "awkward.glb";
  write_animated_glb(path, character, clip, out.string());

  const tinygltf::Model model = parse(out.string());
  ASSERT_EQ(model.buffers.size(), 1u);
  EXPECT_TRUE(model.buffers[0].uri.empty());
  ASSERT_EQ(model.images.size(), 2u);
  for (const tinygltf::Image& image : model.images) {
    EXPECT_TRUE(image.uri.empty());
    EXPECT_EQ(image.mimeType, "image/png");
    const tinygltf::BufferView& view = model.bufferViews.at(image.bufferView);
    const unsigned char* bytes = model.buffers[0].data.data() + view.byteOffset;
    EXPECT_EQ(std::vector<unsigned char>(bytes, bytes + view.byteLength), kPixelPng);
  }
  for (int node : {1, 2}) {
    EXPECT_TRUE(model.nodes[node].matrix.empty());
    EXPECT_EQ(model.nodes[node].scale.size(), 3u);
  }

  const double size = size_of(character);
  std::vector<RigidTransform<double>> expected(character.skeleton.joint_count());
  for (int f = 0; f < clip.frame_count(); ++f) {
    clip.world_pose(f, expected);
    const PoseError error = joint_error(model, character, f / clip.fps, expected);
    EXPECT_LT(error.position, 1e-5 * size) << "frame " << f;
    EXPECT_LT(error.rotation, 1e-5) << "frame " << f;
    EXPECT_LT(mesh_error(model, character, f / clip.fps, expected), 1e-5 * size) << "frame " << f;
  }

  // Joint 1's two quarters merge into its first slot; the weightless vertex follows joint 0.
  const auto weights = elements(model, model.meshes[0].primitives[0].attributes.at("WEIGHTS_0"));
  EXPECT_EQ(weights[0], (std::vector<double>{1, 0, 0, 0}));
  EXPECT_EQ(weights[1], (std::vector<double>{1, 0, 0, 0}));

  if (const std::string missing = validator_missing(); !missing.empty()) GTEST_SKIP() << missing;
  expect_zero_validator_errors(out);
}

// --- Failures: a clear message, and nothing at the output path. ---

std::string message_of(const std::function<void()>& action) {
  try {
    action();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "";
}

bool partial_files_left(const fs::path& dir) {
  for (const auto& entry : fs::directory_iterator(dir)) {
    if (entry.path().filename().string().find(".partial-") != std::string::npos) return true;
  }
  return false;
}

TEST(GlbExportFailureTest, ClipOnAnotherSkeletonIsRejected) {
  const Character figure = load_character(character_path("RiggedSimple.glb"));
  const Character robot = load_character(character_path("RobotExpressive.glb"));
  const fs::path out = scratch_dir() / "mismatched_skeleton.glb";
  fs::remove(out);
  const std::string message = message_of(
      [&] { write_animated_glb(character_path("RiggedSimple.glb"), figure, test_clip(robot), out.string()); });
  EXPECT_NE(message.find("joints but character 'RiggedSimple'"), std::string::npos) << message;
  EXPECT_FALSE(fs::exists(out));
}

TEST(GlbExportFailureTest, CharacterFromAnotherFileIsRejected) {
  // CesiumMan and RiggedFigure share a rig layout (19 joints, same nesting) but not its numbers.
  const Character cesium = load_character(character_path("CesiumMan.glb"));
  const fs::path out = scratch_dir() / "other_file.glb";
  fs::remove(out);
  const std::string message = message_of(
      [&] { write_animated_glb(character_path("RiggedFigure.glb"), cesium, test_clip(cesium), out.string()); });
  EXPECT_NE(message.find("RiggedFigure.glb: does not match the character"), std::string::npos) << message;
  EXPECT_FALSE(fs::exists(out));
}

TEST(GlbExportFailureTest, NonFiniteFrameIsRejectedNamingIt) {
  const Character character = load_character(character_path("CesiumMan.glb"));
  Clip clip = test_clip(character);
  clip.rotations[3 * clip.joint_count() + 2].x() = std::nan("");
  const fs::path out = scratch_dir() / "non_finite.glb";
  fs::remove(out);
  const std::string message =
      message_of([&] { write_animated_glb(character_path("CesiumMan.glb"), character, clip, out.string()); });
  EXPECT_NE(message.find("frame 3"), std::string::npos) << message;
  EXPECT_FALSE(fs::exists(out));
}

TEST(GlbExportFailureTest, UnwritableOutputLeavesNothing) {
  const Character character = load_character(character_path("RiggedSimple.glb"));
  const fs::path dir = scratch_dir() / "no_such_dir";
  fs::remove_all(dir);
  const fs::path out = dir / "out.glb";
  const std::string message = message_of(
      [&] { write_animated_glb(character_path("RiggedSimple.glb"), character, test_clip(character), out.string()); });
  EXPECT_NE(message.find(out.string() + ": its folder " + dir.string() + " does not exist"), std::string::npos) << message;
  EXPECT_FALSE(fs::exists(out));
  EXPECT_FALSE(partial_files_left(scratch_dir()));
}

TEST(GlbExportFailureTest, MissingCharacterFileIsNamed) {
  const Character character = load_character(character_path("RiggedSimple.glb"));
  const fs::path out = scratch_dir() / "missing_source.glb";
  fs::remove(out);
  const std::string missing = (scratch_dir() / "missing.glb").string();
  const std::string message =
      message_of([&] { write_animated_glb(missing, character, test_clip(character), out.string()); });
  EXPECT_NE(message.find(missing + ": cannot be opened"), std::string::npos) << message;
  EXPECT_FALSE(fs::exists(out));
}

}  // namespace
}  // namespace odyssey::io
