// The scene GLB (mocap_io/scene_glb.h): a two-actor scene with a box and two cameras is written,
// passes the Khronos validator with zero errors, and its own data (read back from the GLB's JSON
// and binary chunks, not through the toolkit's loader) reproduces the toolkit's joints, skinned
// vertices and cameras, taken from the Z-up world to glTF's Y-up one. Inconsistent input is refused
// and leaves nothing behind.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "mocap_io/input_error.h"
#include "mocap_io/scene_glb.h"
#include "scene_layouts/pipeline.h"
#include "skeleton/rotation.h"
#include "scene_support.h"
#include "test_support.h"
#include "gltf_validator.h"

namespace odyssey {
namespace {

namespace fs = std::filesystem;
using test_support::contains;

const std::string kFigure = test_support::kSceneFigure;
const std::string kCesium = test_support::kSceneCesium;
using test_support::walker;

using test_support::validator_dir;
using test_support::validator_missing;
// Built by appending: GCC 12 warns (-Wrestrict, falsely) on "'" + path.string() + "'".
std::string quoted(const fs::path& path) {
  std::string text = "'";
  text += path.string();
  text += "'";
  return text;
}


// Two walkers side by side, a box ahead of them, a static camera and one on the first's head.
const scene::SceneResult& shared_scene() {
  static const scene::SceneResult result = [] {
    scene::Scene shot;
    shot.actors = {walker("figure", kFigure, 0, -1, 0), walker("cesium", kCesium, 0, 1, 0)};
    shot.seconds = 1;
    scene::Prop box;
    box.name = "crate";
    box.size = Eigen::Vector3d(0.6, 0.6, 0.8);
    box.position = Eigen::Vector3d(3.5, 0, 0);
    shot.props = {box};
    scene::SceneCamera fixed;
    fixed.name = "side";
    fixed.rig = scene::StaticRig{.position = Eigen::Vector3d(1, -6, 1.5), .target = Eigen::Vector3d(1, 0, 0.9)};
    scene::SceneCamera ego;
    ego.rig = scene::EgoRig{.actor = 0};
    ego.name = "head";
    shot.cameras = {fixed, ego};
    return scene::run_scene(shot);
  }();
  return result;
}

struct SceneInput {
  std::vector<Clip> clips;  // each actor's, stored whole (as SceneGlbSink does)
  std::vector<io::SceneGlbActor> actors;
  std::vector<io::SceneGlbCamera> cameras;
};
SceneInput glb_input(const scene::SceneResult& result) {
  SceneInput input;
  input.clips.reserve(result.actors.size());
  for (const scene::PlacedActor& actor : result.actors) {
    input.clips.push_back(actor.clip.stored_clip());
    input.actors.push_back({actor.name, &actor.retargeted->character, &input.clips.back()});
  }
  for (std::size_t c = 0; c < result.cameras.size(); ++c) input.cameras.push_back({result.cameras[c].name, &result.cameras[c].path});
  return input;
}

// --- A GLB read back by hand: the JSON chunk and float/integer accessors of the binary chunk. ---

struct Glb {
  nlohmann::json doc;
  std::vector<unsigned char> bin;

  explicit Glb(const fs::path& path) {
    std::ifstream in(path, std::ios::binary);
    const std::vector<unsigned char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const auto u32 = [&](std::size_t at) {
      std::uint32_t value;
      std::memcpy(&value, bytes.data() + at, 4);
      return value;
    };
    EXPECT_EQ(u32(0), 0x46546C67u);
    EXPECT_EQ(u32(8), bytes.size());
    const std::size_t json_length = u32(12);
    doc = nlohmann::json::parse(bytes.begin() + 20, bytes.begin() + 20 + json_length);
    const std::size_t bin_at = 20 + json_length;
    bin.assign(bytes.begin() + bin_at + 8, bytes.begin() + bin_at + 8 + u32(bin_at));
  }

  // Tightly packed components of an accessor, as doubles.
  std::vector<double> values(int accessor) const {
    const nlohmann::json& a = doc["accessors"][accessor];
    const nlohmann::json& view = doc["bufferViews"][a["bufferView"].get<int>()];
    const std::size_t offset = view.value("byteOffset", 0) + a.value("byteOffset", 0);
    const std::map<std::string, int> components = {{"SCALAR", 1}, {"VEC3", 3}, {"VEC4", 4}, {"MAT4", 16}};
    const std::size_t count = a["count"].get<std::size_t>() * components.at(a["type"]);
    std::vector<double> out(count);
    const int type = a["componentType"];
    for (std::size_t i = 0; i < count; ++i) {
      if (type == 5126) {
        float v;
        std::memcpy(&v, bin.data() + offset + i * 4, 4);
        out[i] = v;
      } else if (type == 5125) {
        std::uint32_t v;
        std::memcpy(&v, bin.data() + offset + i * 4, 4);
        out[i] = v;
      } else {
        std::uint16_t v;
        std::memcpy(&v, bin.data() + offset + i * 2, 2);
        out[i] = v;
      }
    }
    return out;
  }

  int node_named(const std::string& name) const {
    for (std::size_t n = 0; n < doc["nodes"].size(); ++n) {
      if (doc["nodes"][n].value("name", "") == name) return static_cast<int>(n);
    }
    return -1;
  }
};

Eigen::Matrix4d trs(const Eigen::Vector3d& t, const Eigen::Quaterniond& r) {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topLeftCorner<3, 3>() = r.toRotationMatrix();
  m.topRightCorner<3, 1>() = t;
  return m;
}

// Every node's world matrix at animation frame f (the file's sample f; rest where unanimated).
std::vector<Eigen::Matrix4d> world_at_frame(const Glb& glb, int frame) {
  const nlohmann::json& nodes = glb.doc["nodes"];
  std::vector<Eigen::Vector3d> t(nodes.size(), Eigen::Vector3d::Zero());
  std::vector<Eigen::Quaterniond> r(nodes.size(), Eigen::Quaterniond::Identity());
  for (std::size_t n = 0; n < nodes.size(); ++n) {
    if (nodes[n].contains("translation")) t[n] = Eigen::Vector3d(nodes[n]["translation"][0], nodes[n]["translation"][1], nodes[n]["translation"][2]);
    if (nodes[n].contains("rotation")) {
      const auto& q = nodes[n]["rotation"];
      r[n] = Eigen::Quaterniond(q[3], q[0], q[1], q[2]);
    }
  }
  const nlohmann::json& animation = glb.doc["animations"][0];
  for (const nlohmann::json& channel : animation["channels"]) {
    const int node = channel["target"]["node"];
    const std::vector<double> v = glb.values(animation["samplers"][channel["sampler"].get<int>()]["output"]);
    if (channel["target"]["path"] == "translation") {
      t[node] = Eigen::Vector3d(v[frame * 3], v[frame * 3 + 1], v[frame * 3 + 2]);
    } else {
      r[node] = Eigen::Quaterniond(v[frame * 4 + 3], v[frame * 4], v[frame * 4 + 1], v[frame * 4 + 2]).normalized();
    }
  }
  std::vector<Eigen::Matrix4d> world(nodes.size(), Eigen::Matrix4d::Identity());
  std::vector<int> parent(nodes.size(), -1);
  for (std::size_t n = 0; n < nodes.size(); ++n) {
    for (const auto& child : nodes[n].value("children", nlohmann::json::array())) parent[child.get<int>()] = int(n);
  }
  // Parents first: walk each node's chain (the file is small).
  for (std::size_t n = 0; n < nodes.size(); ++n) {
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
    for (int k = int(n); k >= 0; k = parent[k]) m = trs(t[k], r[k]) * m;
    world[n] = m;
  }
  return world;
}

// --- The Khronos validator, through node (as test_gltf_export.cpp runs it). ---

TEST(SceneGlbTest, PassesTheKhronosValidatorWithZeroErrors) {
  if (const std::string missing = validator_missing(); !missing.empty()) GTEST_SKIP() << missing;
  const scene::SceneResult& result = shared_scene();
  const SceneInput input = glb_input(result);
  const fs::path out = test_support::scratch_dir("scene_glb") / "validated.glb";
  io::write_scene_glb(out.string(), input.actors, &result.props.character, input.cameras, result.fps);
  const fs::path log = fs::path(out).replace_extension(".validator.txt");
  const int status = std::system(("node " + quoted(validator_dir() / "validate.mjs") + " " + quoted(out) + " --all > " +
                                  quoted(log) + " 2>&1").c_str());
  std::ifstream in(log);
  const std::string report((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  ASSERT_TRUE(WIFEXITED(status)) << report;
  EXPECT_EQ(WEXITSTATUS(status), 0) << report;
  EXPECT_TRUE(contains(report, ": 0 errors,")) << report;
  std::printf("%s", report.c_str());  // the warnings, for the record
}

// Nodes, meshes, skins, cameras and the animation are all there, and at frames 0, 15 and 30 the
// file's joints sit where the toolkit's clip puts them, its skins deform every vertex to where the
// toolkit skins it, and its cameras look the way the camera paths do, all in glTF's Y-up world.
TEST(SceneGlbTest, TheFileReproducesTheToolkitsJointsSkinsAndCameras) {
  const scene::SceneResult& result = shared_scene();
  const SceneInput input = glb_input(result);
  const fs::path out = test_support::scratch_dir("scene_glb") / "scene.glb";
  io::write_scene_glb(out.string(), input.actors, &result.props.character, input.cameras, result.fps);
  const Glb glb(out);
  const Eigen::Matrix3d to_gltf = y_up_to_z_up().transpose();

  std::size_t expected_nodes = result.props.character.meshes.size() + result.cameras.size(), expected_channels = 2 * result.cameras.size();
  for (std::size_t a = 0; a < result.actors.size(); ++a) {
    const Character& character = result.actors[a].retargeted->character;
    const Clip& clip = input.clips[a];
    expected_nodes += 1 + character.skeleton.joint_count() + character.meshes.size();
    expected_channels += character.skeleton.joint_count();
    for (int j = 0; j < character.skeleton.joint_count(); ++j) {
      const bool translated = std::find(clip.translated_joints.begin(), clip.translated_joints.end(), j) !=
                              clip.translated_joints.end();
      expected_channels += translated || character.skeleton.parent(j) < 0;
    }
  }
  EXPECT_EQ(glb.doc["nodes"].size(), expected_nodes);
  ASSERT_EQ(glb.doc["animations"].size(), 1u);
  EXPECT_EQ(glb.doc["animations"][0]["channels"].size(), expected_channels);
  EXPECT_EQ(glb.doc["cameras"].size(), 2u);
  EXPECT_EQ(glb.doc["scenes"][0]["nodes"].size(),
            result.actors.size() + result.props.character.meshes.size() + result.cameras.size() + result.actors[0].retargeted->character.meshes.size() +
                result.actors[1].retargeted->character.meshes.size());
  const int time_accessor = glb.doc["animations"][0]["samplers"][0]["input"];
  EXPECT_EQ(glb.doc["accessors"][time_accessor]["count"], result.frames);
  EXPECT_NEAR(glb.doc["accessors"][time_accessor]["max"][0].get<double>(), (result.frames - 1) / result.fps, 1e-6);

  for (const int frame : {0, 15, 30}) {
    const std::vector<Eigen::Matrix4d> world = world_at_frame(glb, frame);
    for (const scene::PlacedActor& actor : result.actors) {
      const Character& character = actor.retargeted->character;
      std::vector<RigidTransform<double>> joints(character.skeleton.joint_count());
      actor.clip.world_pose(frame, joints);
      const int group = glb.node_named(actor.name);
      ASSERT_GE(group, 0) << actor.name;
      double joint_error = 0, rotation_error = 0;
      for (int j = 0; j < character.skeleton.joint_count(); ++j) {
        ASSERT_EQ(glb.doc["nodes"][group + 1 + j]["name"], character.skeleton.name(j));
        const Eigen::Matrix4d& g = world[group + 1 + j];
        joint_error = std::max(joint_error, (g.topRightCorner<3, 1>() - to_gltf * joints[j].translation).norm());
        rotation_error = std::max(rotation_error, (g.topLeftCorner<3, 3>() - to_gltf * joints[j].rotation).cwiseAbs().maxCoeff());
      }
      EXPECT_LT(joint_error, 1e-5) << actor.name << " frame " << frame;
      EXPECT_LT(rotation_error, 1e-5) << actor.name << " frame " << frame;
      if (frame == 0) {
        // The root's first translation sample is the placed root, in glTF's axes.
        const int root = group + 1;
        EXPECT_NEAR(world[root](0, 3), joints[0].translation.x(), 1e-5);
        EXPECT_NEAR(world[root](1, 3), joints[0].translation.z(), 1e-5);
        EXPECT_NEAR(world[root](2, 3), -joints[0].translation.y(), 1e-5);
      }

      for (std::size_t m = 0; m < character.meshes.size(); ++m) {
        const CharacterMesh& mesh = character.meshes[m];
        const std::string name = actor.name + "/" + (mesh.name.empty() ? "mesh" + std::to_string(m) : mesh.name);
        const int node = glb.node_named(name);
        ASSERT_GE(node, 0) << name;
        const nlohmann::json& primitive = glb.doc["meshes"][glb.doc["nodes"][node]["mesh"].get<int>()]["primitives"][0];
        const nlohmann::json& skin = glb.doc["skins"][glb.doc["nodes"][node]["skin"].get<int>()];
        const std::vector<double> p = glb.values(primitive["attributes"]["POSITION"]);
        const std::vector<double> slot = glb.values(primitive["attributes"]["JOINTS_0"]);
        const std::vector<double> w = glb.values(primitive["attributes"]["WEIGHTS_0"]);
        const std::vector<double> ibm = glb.values(skin["inverseBindMatrices"]);
        std::vector<Eigen::Matrix4d> skinning(skin["joints"].size());
        for (std::size_t s = 0; s < skinning.size(); ++s) {
          skinning[s] = world[skin["joints"][s].get<int>()] * Eigen::Map<const Eigen::Matrix4d>(ibm.data() + s * 16);
        }
        const std::vector<Eigen::Vector3d> expected = skin_mesh_reference(mesh, joints);
        ASSERT_EQ(p.size(), expected.size() * 3);
        double vertex_error = 0;
        for (std::size_t v = 0; v < expected.size(); ++v) {
          Eigen::Vector4d sum = Eigen::Vector4d::Zero();
          for (int k = 0; k < 4; ++k) {
            sum += w[v * 4 + k] * (skinning[std::size_t(slot[v * 4 + k])] * Eigen::Vector4d(p[v * 3], p[v * 3 + 1], p[v * 3 + 2], 1));
          }
          vertex_error = std::max(vertex_error, (sum.head<3>() - to_gltf * expected[v]).norm());
        }
        EXPECT_LT(vertex_error, 2e-5) << name << " frame " << frame;
        EXPECT_EQ(glb.doc["nodes"][node]["extras"]["odyssey_mesh"], m);
      }
    }
    // glTF cameras look down -Z with +Y up: taken back to the toolkit's world, the path's forward
    // and minus its down axis.
    for (std::size_t c = 0; c < result.cameras.size(); ++c) {
      const int node = glb.node_named(result.cameras[c].name);
      ASSERT_GE(node, 0);
      const CameraPose& pose = result.cameras[c].path.poses[frame];
      const Eigen::Matrix3d rotation = y_up_to_z_up() * world[node].topLeftCorner<3, 3>();
      EXPECT_LT((rotation * Eigen::Vector3d(0, 0, -1) - pose.forward()).norm(), 1e-6);
      EXPECT_LT((rotation * Eigen::Vector3d(0, 1, 0) + pose.down()).norm(), 1e-6);
      EXPECT_LT((y_up_to_z_up() * world[node].topRightCorner<3, 1>() - pose.centre()).norm(), 1e-5);
    }
  }
  const PinholeIntrinsics& k = result.cameras[0].path.intrinsics[0];
  EXPECT_NEAR(glb.doc["cameras"][0]["perspective"]["yfov"].get<double>(), 2 * std::atan(k.height / (2 * k.fy)), 1e-12);
  EXPECT_NEAR(glb.doc["cameras"][0]["perspective"]["aspectRatio"].get<double>(), 960.0 / 540.0, 1e-12);
  EXPECT_FALSE(glb.doc["cameras"][0]["perspective"].contains("zfar"));

  // The prop, static, in glTF's axes.
  const int crate = glb.node_named("crate");
  ASSERT_GE(crate, 0);
  const std::vector<double> p = glb.values(glb.doc["meshes"][glb.doc["nodes"][crate]["mesh"].get<int>()]["primitives"][0]["attributes"]["POSITION"]);
  for (std::size_t v = 0; v < result.props.character.meshes[0].positions.size(); ++v) {
    const Eigen::Vector3d expected = to_gltf * result.props.character.meshes[0].positions[v].cast<double>();
    EXPECT_LT((Eigen::Vector3d(p[v * 3], p[v * 3 + 1], p[v * 3 + 2]) - expected).norm(), 1e-6);
  }
}

TEST(SceneGlbTest, InconsistentInputIsRefusedAndNothingIsWritten) {
  const scene::SceneResult& result = shared_scene();
  SceneInput input = glb_input(result);
  const fs::path dir = test_support::scratch_dir("scene_glb_errors");
  const std::string out = (dir / "bad.glb").string();

  Clip shorter = input.clips[1];
  const int joints = shorter.joint_count();
  shorter.rotations.resize(shorter.rotations.size() - joints);
  shorter.translations.resize(shorter.translations.size() - shorter.translated_joints.size());
  input.actors[1].clip = &shorter;
  std::string message = test_support::message_of<std::invalid_argument>(
      [&] { io::write_scene_glb(out, input.actors, &result.props.character, input.cameras, result.fps); });
  EXPECT_TRUE(contains(message, "actor 'cesium''s clip has 30 frames, but actor 'figure''s clip has 31")) << message;

  input = glb_input(result);
  input.actors[1].clip = &input.clips[0];  // another skeleton
  message = test_support::message_of<std::invalid_argument>(
      [&] { io::write_scene_glb(out, input.actors, &result.props.character, input.cameras, result.fps); });
  EXPECT_TRUE(contains(message, "actor 'cesium': the clip is not on the character's skeleton")) << message;

  input = glb_input(result);
  message = test_support::message_of<std::invalid_argument>(
      [&] { io::write_scene_glb(out, input.actors, &result.props.character, input.cameras, 24); });
  EXPECT_TRUE(contains(message, "runs at 30")) << message;

  Character broken = result.actors[0].retargeted->character;
  broken.meshes[0].triangles[4] = static_cast<std::uint32_t>(broken.meshes[0].positions.size());
  input = glb_input(result);
  input.actors[0].character = &broken;
  message = test_support::message_of<std::invalid_argument>(
      [&] { io::write_scene_glb(out, input.actors, &result.props.character, input.cameras, result.fps); });
  EXPECT_TRUE(contains(message, "a triangle corner is vertex")) << message;
  EXPECT_TRUE(test_support::files_in(dir).empty());

  input = glb_input(result);
  const std::string unwritable = (dir / "no" / "such" / "folder" / "scene.glb").string();
  message = test_support::message_of<io::InputError>(
      [&] { io::write_scene_glb(unwritable, input.actors, &result.props.character, input.cameras, result.fps); });
  EXPECT_TRUE(contains(message, unwritable)) << message;
}

}  // namespace
}  // namespace odyssey
