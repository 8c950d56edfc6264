#include "mocap_io/scene_glb.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <vector>

#include "mocap_io/input_error.h"
#include "mocap_io/output_file.h"
#include "skeleton/rotation.h"

namespace odyssey::io {
namespace {

static_assert(std::endian::native == std::endian::little,
              "glTF buffers are little-endian and are written from memory as they are");

using json = nlohmann::ordered_json;

constexpr double kCameraNear = 0.01;  // metres, as gltf_export.h
constexpr std::uint32_t kGlbMagic = 0x46546C67;      // "glTF"
constexpr std::uint32_t kGlbJsonChunk = 0x4E4F534A;  // "JSON"
constexpr std::uint32_t kGlbBinChunk = 0x004E4942;   // "BIN\0"
constexpr std::uint64_t kMaxGlbBytes = std::numeric_limits<std::uint32_t>::max();
constexpr int kArrayBuffer = 34962, kElementArrayBuffer = 34963;
constexpr int kFloat = 5126, kUnsignedShort = 5123, kUnsignedInt = 5125;

// Flat actor colours (linear RGB), then the props' grey.
constexpr std::array<std::array<double, 3>, 8> kActorColours = {{{0.80, 0.25, 0.20},
                                                                 {0.20, 0.45, 0.80},
                                                                 {0.25, 0.65, 0.30},
                                                                 {0.85, 0.65, 0.15},
                                                                 {0.55, 0.30, 0.75},
                                                                 {0.15, 0.65, 0.65},
                                                                 {0.85, 0.40, 0.60},
                                                                 {0.45, 0.35, 0.25}}};
constexpr std::array<double, 3> kPropColour = {0.55, 0.55, 0.55};

// The one place where the toolkit's Z-up world becomes glTF's Y-up world: x -> C^-1 x, and a
// world frame [R | t] -> [C^-1 R | C^-1 t] (see the header).
const Eigen::Matrix3d& to_gltf() {
  static const Eigen::Matrix3d c_inverse = y_up_to_z_up().transpose();
  return c_inverse;
}
Eigen::Vector3d to_gltf(const Eigen::Vector3d& x) { return to_gltf() * x; }
Eigen::Quaterniond to_gltf(const Eigen::Quaterniond& rotation) {
  return (Eigen::Quaterniond(to_gltf()) * rotation).normalized();
}

json xyzw(const Eigen::Quaterniond& q) { return json::array({q.x(), q.y(), q.z(), q.w()}); }
json xyz(const Eigen::Vector3d& v) { return json::array({v.x(), v.y(), v.z()}); }

void require(bool condition, const std::string& problem) {
  if (!condition) throw std::invalid_argument("scene GLB: " + problem);
}

// The JSON document and the binary chunk under construction.
class Document {
 public:
  // A buffer view over a copy of `bytes`, 4-byte aligned; target 0: none.
  int view(const void* bytes, std::size_t size, int target) {
    bin_.resize((bin_.size() + 3) / 4 * 4, 0);
    json view = {{"buffer", 0}, {"byteOffset", bin_.size()}, {"byteLength", size}};
    if (target != 0) view["target"] = target;
    const auto* begin = static_cast<const unsigned char*>(bytes);
    bin_.insert(bin_.end(), begin, begin + size);
    return push("bufferViews", std::move(view));
  }

  // A float accessor of `type` (SCALAR, VEC3, ...) over values; with bounds, min and max per
  // component (required on POSITION and on animation times).
  int floats(const std::vector<float>& values, const char* type, int components, int target, bool bounds) {
    json accessor = {{"bufferView", view(values.data(), values.size() * sizeof(float), target)},
                     {"componentType", kFloat},
                     {"count", values.size() / components},
                     {"type", type}};
    if (bounds) {
      std::vector<double> low(components, INFINITY), high(components, -INFINITY);
      for (std::size_t i = 0; i < values.size(); ++i) {
        low[i % components] = std::min<double>(low[i % components], values[i]);
        high[i % components] = std::max<double>(high[i % components], values[i]);
      }
      accessor["min"] = low;
      accessor["max"] = high;
    }
    return push("accessors", std::move(accessor));
  }

  template <class Int>
  int integers(const std::vector<Int>& values, int component_type, const char* type, int components, int target) {
    return push("accessors", {{"bufferView", view(values.data(), values.size() * sizeof(Int), target)},
                              {"componentType", component_type},
                              {"count", values.size() / components},
                              {"type", type}});
  }

  int push(const char* array, json value) {
    json& list = root_[array];
    list.push_back(std::move(value));
    return static_cast<int>(list.size()) - 1;
  }
  json& at(const char* array, int index) { return root_[array][index]; }

  // The GLB: 12-byte header, the JSON chunk padded with spaces, the binary chunk with zeros.
  std::string glb(const std::string& path) {
    bin_.resize((bin_.size() + 3) / 4 * 4, 0);
    if (!bin_.empty()) root_["buffers"] = json::array({{{"byteLength", bin_.size()}}});
    json ordered = {{"asset", {{"version", "2.0"}, {"generator", "odyssey scene GLB writer"}}}};
    for (const char* key : {"scene", "scenes", "nodes", "meshes", "skins", "materials", "cameras", "animations",
                            "accessors", "bufferViews", "buffers"}) {
      if (root_.contains(key)) ordered[key] = root_[key];
    }
    std::string text = ordered.dump();
    text.resize((text.size() + 3) / 4 * 4, ' ');
    const std::uint64_t total = 12 + 8 + text.size() + (bin_.empty() ? 0 : 8 + bin_.size());
    if (total > kMaxGlbBytes) throw InputError(path, "the scene GLB would exceed GLB's 4 GiB limit");
    std::string out;
    out.reserve(total);
    const auto u32 = [&out](std::uint64_t value) {
      const auto v = static_cast<std::uint32_t>(value);
      out.append(reinterpret_cast<const char*>(&v), 4);
    };
    u32(kGlbMagic);
    u32(2);
    u32(total);
    u32(text.size());
    u32(kGlbJsonChunk);
    out += text;
    if (!bin_.empty()) {
      u32(bin_.size());
      u32(kGlbBinChunk);
      out.append(reinterpret_cast<const char*>(bin_.data()), bin_.size());
    }
    return out;
  }

  json root_ = json::object();

 private:
  std::vector<unsigned char> bin_;
};

// Area-weighted vertex normals of a triangle mesh, unit length; (0, 1, 0) where there is no area.
std::vector<float> vertex_normals(const std::vector<Eigen::Vector3d>& positions, const std::vector<std::uint32_t>& triangles) {
  std::vector<Eigen::Vector3d> sums(positions.size(), Eigen::Vector3d::Zero());
  for (std::size_t t = 0; t + 2 < triangles.size(); t += 3) {
    const Eigen::Vector3d& a = positions[triangles[t]];
    const Eigen::Vector3d n = (positions[triangles[t + 1]] - a).cross(positions[triangles[t + 2]] - a);
    for (int k = 0; k < 3; ++k) sums[triangles[t + k]] += n;
  }
  std::vector<float> normals;
  normals.reserve(positions.size() * 3);
  for (const Eigen::Vector3d& sum : sums) {
    const double length = sum.norm();
    const Eigen::Vector3d n = length > 1e-300 && std::isfinite(length) ? Eigen::Vector3d(sum / length) : Eigen::Vector3d::UnitY();
    for (int c = 0; c < 3; ++c) normals.push_back(static_cast<float>(n(c)));
  }
  return normals;
}

std::vector<float> flat(const std::vector<Eigen::Vector3d>& points) {
  std::vector<float> out;
  out.reserve(points.size() * 3);
  for (const Eigen::Vector3d& p : points) {
    for (int c = 0; c < 3; ++c) out.push_back(static_cast<float>(p(c)));
  }
  return out;
}

// Checks a mesh's arrays; `skinned` adds the skin's.
void check_mesh(const CharacterMesh& mesh, const std::string& label, int joint_count, bool skinned) {
  const std::size_t vertices = mesh.positions.size();
  require(mesh.triangles.size() % 3 == 0, label + ": " + std::to_string(mesh.triangles.size()) + " triangle corners, not a multiple of 3");
  for (const std::uint32_t corner : mesh.triangles) {
    require(corner < vertices, label + ": a triangle corner is vertex " + std::to_string(corner) + " of " + std::to_string(vertices));
  }
  for (std::size_t v = 0; v < vertices; ++v) {
    require(mesh.positions[v].allFinite(), label + ": vertex " + std::to_string(v) + " is not finite");
  }
  if (!skinned) return;
  require(!mesh.skin_joints.empty(), label + ": the mesh has no skin");
  require(mesh.inverse_bind.size() == mesh.skin_joints.size(),
          label + ": " + std::to_string(mesh.inverse_bind.size()) + " inverse bind matrices for " +
              std::to_string(mesh.skin_joints.size()) + " skin joints");
  require(mesh.influence_slots.size() == vertices && mesh.influence_weights.size() == vertices,
          label + ": influences for " + std::to_string(mesh.influence_slots.size()) + " and " +
              std::to_string(mesh.influence_weights.size()) + " vertices, but it has " + std::to_string(vertices));
  std::vector<char> listed(joint_count, 0);
  for (std::size_t s = 0; s < mesh.skin_joints.size(); ++s) {
    const int joint = mesh.skin_joints[s];
    require(joint >= 0 && joint < joint_count, label + ": skin slot " + std::to_string(s) + " is joint " + std::to_string(joint) +
                                                   " of a skeleton of " + std::to_string(joint_count));
    require(!listed[joint], label + ": the skin lists joint " + std::to_string(joint) + " twice");
    listed[joint] = 1;
    require(mesh.inverse_bind[s].allFinite(), label + ": inverse bind matrix " + std::to_string(s) + " is not finite");
  }
}

// JOINTS_0 and WEIGHTS_0 as the header says.
void skin_attributes(const CharacterMesh& mesh, const std::string& label, std::vector<std::uint16_t>& joints,
                     std::vector<float>& weights) {
  const std::size_t vertices = mesh.positions.size();
  joints.assign(vertices * 4, 0);
  weights.assign(vertices * 4, 0.0f);
  for (std::size_t v = 0; v < vertices; ++v) {
    std::array<int, 4> slot{};
    std::array<double, 4> weight{};
    int used = 0;
    double sum = 0;
    for (int k = 0; k < 4; ++k) {
      const double w = mesh.influence_weights[v][k];
      require(std::isfinite(w) && w >= 0, label + ": vertex " + std::to_string(v) + " has weight " + std::to_string(w));
      if (w == 0) continue;
      const int s = mesh.influence_slots[v][k];
      require(s < static_cast<int>(mesh.skin_joints.size()),
              label + ": vertex " + std::to_string(v) + " names skin slot " + std::to_string(s) + " of " +
                  std::to_string(mesh.skin_joints.size()));
      int at = 0;
      while (at < used && slot[at] != s) ++at;
      if (at == used) slot[used++] = s;
      weight[at] += w;
      sum += w;
    }
    if (used == 0) {
      slot[0] = mesh.influence_slots[v][0];
      require(slot[0] < static_cast<int>(mesh.skin_joints.size()),
              label + ": vertex " + std::to_string(v) + " names skin slot " + std::to_string(slot[0]) + " of " +
                  std::to_string(mesh.skin_joints.size()));
      weight[0] = sum = 1;
      used = 1;
    }
    std::array<float, 4> stored{};
    int largest = 0;
    for (int k = 0; k < used; ++k) {
      stored[k] = static_cast<float>(weight[k] / sum);
      if (weight[k] > weight[largest]) largest = k;
    }
    float others = 0;
    for (int k = 0; k < used; ++k) {
      if (k != largest) others += stored[k];
    }
    stored[largest] = 1.0f - others;
    for (int k = 0; k < 4; ++k) {
      joints[v * 4 + k] = static_cast<std::uint16_t>(k < used ? slot[k] : 0);
      weights[v * 4 + k] = k < used ? stored[k] : 0.0f;
    }
  }
}

int material(Document& doc, const std::string& name, const std::array<double, 3>& colour) {
  return doc.push("materials", {{"name", name},
                                {"pbrMetallicRoughness",
                                 {{"baseColorFactor", {colour[0], colour[1], colour[2], 1.0}},
                                  {"metallicFactor", 0.0},
                                  {"roughnessFactor", 0.8}}},
                                {"doubleSided", true}});
}

// One animation sampler and channel; `values` are per frame, `components` each.
void channel(Document& doc, json& animation, int time_accessor, const std::vector<float>& values, int components,
             int node, const char* path) {
  const int output = doc.floats(values, components == 4 ? "VEC4" : "VEC3", components, 0, false);
  animation["samplers"].push_back({{"input", time_accessor}, {"interpolation", "LINEAR"}, {"output", output}});
  animation["channels"].push_back(
      {{"sampler", animation["samplers"].size() - 1}, {"target", {{"node", node}, {"path", path}}}});
}

void append(std::vector<float>& out, const Eigen::Quaterniond& q) {
  for (const double c : {q.x(), q.y(), q.z(), q.w()}) out.push_back(static_cast<float>(c));
}
void append(std::vector<float>& out, const Eigen::Vector3d& v) {
  for (int c = 0; c < 3; ++c) out.push_back(static_cast<float>(v(c)));
}

class SceneGlbBuilder {
 public:
  SceneGlbBuilder(const std::string& path, std::span<const SceneGlbActor> actors, const Character* props,
                  std::span<const SceneGlbCamera> cameras, double fps, std::span<const RigidTransform<double>> prop_motion)
      : path_(path), actors_(actors), props_(props), cameras_(cameras), fps_(fps), prop_motion_(prop_motion) {}

  std::string build() {
    check_timing();
    doc_.root_["scene"] = 0;
    doc_.push("scenes", {{"name", "scene"}, {"nodes", json::array()}});
    if (frames_ > 0) {
      std::vector<float> times(frames_);
      for (int f = 0; f < frames_; ++f) {
        times[f] = static_cast<float>(f / fps_);
        require(f == 0 || times[f] > times[f - 1], "frames " + std::to_string(f - 1) + " and " + std::to_string(f) + " at " +
                                                       std::to_string(fps_) + " fps get the same float32 time: too many frames");
      }
      time_accessor_ = doc_.floats(times, "SCALAR", 1, 0, true);
      animation_ = {{"name", "scene"}, {"channels", json::array()}, {"samplers", json::array()}};
    }
    for (std::size_t a = 0; a < actors_.size(); ++a) add_actor(int(a));
    if (props_ != nullptr) add_props();
    for (std::size_t c = 0; c < cameras_.size(); ++c) add_camera(int(c));
    if (frames_ > 0 && !animation_["channels"].empty()) doc_.push("animations", std::move(animation_));
    if (doc_.at("scenes", 0)["nodes"].empty()) doc_.at("scenes", 0).erase("nodes");  // glTF lists are never empty
    return doc_.glb(path_);
  }

 private:
  // Every clip and camera path has one frame count and the scene's fps.
  void check_timing() {
    require(std::isfinite(fps_) && fps_ > 0, "fps " + std::to_string(fps_) + " is not positive and finite");
    const auto same_rate = [&](double rate) { return std::abs(rate - fps_) <= 1e-9 * fps_; };
    const auto check_frames = [&](int count, const std::string& what) {
      if (frames_ < 0) frames_ = count;
      require(count == frames_, what + " has " + std::to_string(count) + " frames, but " + frames_owner_ + " has " +
                                    std::to_string(frames_));
      if (frames_owner_.empty()) frames_owner_ = what;
    };
    for (const SceneGlbActor& actor : actors_) {
      const std::string label = "actor '" + actor.name + "'";
      require(actor.character != nullptr && actor.clip != nullptr, label + ": no character or no clip");
      const Skeleton& skeleton = actor.character->skeleton;
      const Clip& clip = *actor.clip;
      require(clip.skeleton.joint_count() == skeleton.joint_count() && clip.skeleton.names() == skeleton.names() &&
                  clip.skeleton.parents() == skeleton.parents(),
              label + ": the clip is not on the character's skeleton");
      clip.validate();
      require(same_rate(clip.fps), label + ": the clip runs at " + std::to_string(clip.fps) + " fps, the scene at " +
                                       std::to_string(fps_));
      require(clip.frame_count() > 0, label + ": the clip has no frames");
      check_frames(clip.frame_count(), label + "'s clip");
    }
    for (const SceneGlbCamera& camera : cameras_) {
      const std::string label = "camera '" + camera.name + "'";
      require(camera.path != nullptr, label + ": no camera path");
      camera.path->validate();
      require(same_rate(camera.path->fps), label + ": the path runs at " + std::to_string(camera.path->fps) +
                                               " fps, the scene at " + std::to_string(fps_));
      require(camera.path->frame_count() > 0, label + ": the path has no frames");
      check_frames(camera.path->frame_count(), label);
      require(camera.rides_on < 0 || (camera.rides_on < static_cast<int>(actors_.size()) && camera.hidden_joint >= 0 &&
                                      camera.hidden_joint < static_cast<int>(actors_[camera.rides_on].character->skeleton.joint_count())),
              label + ": rides on no actor of the scene, or hides no joint of its skeleton");
    }
    if (!prop_motion_.empty()) {
      const std::size_t count = props_ != nullptr ? props_->meshes.size() : 0;
      require(count > 0 && prop_motion_.size() % count == 0,
              "the props' motion holds " + std::to_string(prop_motion_.size()) + " transforms, not whole frames of " + std::to_string(count) + " props");
      check_frames(static_cast<int>(prop_motion_.size() / count), "the props' motion");
      for (const RigidTransform<double>& m : prop_motion_) require(m.rotation.allFinite() && m.translation.allFinite(), "a prop's motion is not finite");
    }
    if (frames_ < 0) frames_ = 0;
  }

  int add_node(json node, bool root) {
    const int index = doc_.push("nodes", std::move(node));
    if (root) doc_.at("scenes", 0)["nodes"].push_back(index);
    return index;
  }

  void add_actor(int a) {
    const SceneGlbActor& actor = actors_[a];
    const Character& character = *actor.character;
    const Skeleton& skeleton = character.skeleton;
    const Clip& clip = *actor.clip;
    const int joints = skeleton.joint_count();
    const int group = add_node({{"name", actor.name}}, true);
    const int first_joint = group + 1;
    // Joint nodes at rest; roots hang in the world, so they are the ones taken to glTF's.
    std::vector<Eigen::Quaterniond> rest_rotation(joints);
    for (int j = 0; j < joints; ++j) {
      const bool is_root = skeleton.parent(j) < 0;
      const Eigen::Quaterniond r = skeleton.rest_rotations()[j].normalized();
      rest_rotation[j] = is_root ? to_gltf(r) : r;
      const Eigen::Vector3d u = is_root ? to_gltf(skeleton.rest_offsets()[j]) : skeleton.rest_offsets()[j];
      json node = {{"name", skeleton.name(j)}, {"rotation", xyzw(rest_rotation[j])}, {"translation", xyz(u)}};
      add_node(std::move(node), false);
    }
    json& group_node = doc_.at("nodes", group);
    for (int j = 0; j < joints; ++j) {
      const int parent = skeleton.parent(j);
      json& parent_node = parent < 0 ? group_node : doc_.at("nodes", first_joint + parent);
      parent_node["children"].push_back(first_joint + j);
    }

    // The animation: rotations of every joint, translations of the roots and translated joints.
    std::vector<int> translation_slot(joints, -1);
    for (std::size_t k = 0; k < clip.translated_joints.size(); ++k) translation_slot[clip.translated_joints[k]] = int(k);
    const std::size_t translated = clip.translated_joints.size();
    for (int j = 0; j < joints; ++j) {
      const bool is_root = skeleton.parent(j) < 0;
      std::vector<float> rotations;
      rotations.reserve(std::size_t(frames_) * 4);
      Eigen::Quaterniond previous = rest_rotation[j];
      for (int f = 0; f < frames_; ++f) {
        const Eigen::Quaterniond q = clip.rotation(f, j).normalized();
        previous = sign_aligned(is_root ? to_gltf(q) : q, previous);
        append(rotations, previous);
      }
      channel(doc_, animation_, time_accessor_, rotations, 4, first_joint + j, "rotation");
      if (!is_root && translation_slot[j] < 0) continue;
      std::vector<float> translations;
      translations.reserve(std::size_t(frames_) * 3);
      for (int f = 0; f < frames_; ++f) {
        const Eigen::Vector3d& o = translation_slot[j] >= 0 ? clip.translations[std::size_t(f) * translated + translation_slot[j]]
                                                             : skeleton.rest_offsets()[j];
        append(translations, is_root ? to_gltf(o) : o);
      }
      channel(doc_, animation_, time_accessor_, translations, 3, first_joint + j, "translation");
    }

    const int colour = material(doc_, actor.name, kActorColours[a % kActorColours.size()]);
    std::size_t first_vertex = 0;
    for (std::size_t m = 0; m < character.meshes.size(); ++m) {
      const CharacterMesh& mesh = character.meshes[m];
      const std::string name = actor.name + "/" + (mesh.name.empty() ? "mesh" + std::to_string(m) : mesh.name);
      const std::string label = "actor '" + actor.name + "' mesh " + std::to_string(m) + (mesh.name.empty() ? "" : " '" + mesh.name + "'");
      check_mesh(mesh, label, joints, true);
      const std::size_t vertex_count = mesh.positions.size();
      const json extras = {{"odyssey_actor", a}, {"odyssey_mesh", m}, {"odyssey_first_vertex", first_vertex}};
      first_vertex += vertex_count;
      if (mesh.triangles.empty()) continue;

      std::vector<Eigen::Vector3d> positions(vertex_count);
      for (std::size_t v = 0; v < vertex_count; ++v) positions[v] = mesh.positions[v].cast<double>();
      std::vector<std::uint16_t> joint_slots;
      std::vector<float> weights;
      skin_attributes(mesh, label, joint_slots, weights);
      std::vector<float> stored_positions(vertex_count * 3);
      for (std::size_t v = 0; v < vertex_count; ++v) {
        for (int c = 0; c < 3; ++c) stored_positions[v * 3 + c] = mesh.positions[v](c);
      }
      const int mesh_index = add_mesh(name, stored_positions, vertex_normals(positions, mesh.triangles), mesh.triangles, colour,
                                      &joint_slots, &weights);

      std::vector<float> inverse_bind;
      inverse_bind.reserve(mesh.inverse_bind.size() * 16);
      for (const Eigen::Matrix4d& matrix : mesh.inverse_bind) {
        for (int column = 0; column < 4; ++column) {
          for (int row = 0; row < 3; ++row) inverse_bind.push_back(static_cast<float>(matrix(row, column)));
          inverse_bind.push_back(column == 3 ? 1.0f : 0.0f);  // affine, exactly
        }
      }
      json skin_joints = json::array();
      for (const int joint : mesh.skin_joints) skin_joints.push_back(first_joint + joint);
      const int skin = doc_.push("skins", {{"name", name},
                                           {"inverseBindMatrices", doc_.floats(inverse_bind, "MAT4", 16, 0, false)},
                                           {"joints", std::move(skin_joints)},
                                           {"skeleton", group}});
      const int node = add_node({{"name", name}, {"mesh", mesh_index}, {"skin", skin}, {"extras", extras}}, true);
      if (actor.vertex_animation != nullptr) add_vertex_animation(actor, mesh, mesh_index, node, label);
    }
  }

  // A vertex-animated mesh's frames as morph targets of its one primitive (see the header): frame
  // f's displacement from the stored positions is a target, consecutive equal frames share one,
  // and the node's weights put 1 on frame f's target at time f / fps (LINEAR between frames, so the
  // file moves every vertex linearly from frame to frame, as the toolkit resamples).
  void add_vertex_animation(const SceneGlbActor& actor, const CharacterMesh& mesh, int mesh_index, int node,
                            const std::string& label) {
    const MeshAnimation& animation = *actor.vertex_animation;
    const std::size_t floats = mesh.positions.size() * 3;
    require(actor.character->meshes.size() == 1 && animation.vertex_count == mesh.positions.size(),
            label + ": a vertex animation needs one mesh of as many vertices as it animates");
    require(animation.frame_count() == frames_, label + ": the vertex animation has " + std::to_string(animation.frame_count()) +
                                                    " frames, the scene " + std::to_string(frames_));
    std::vector<int> target_of_frame(frames_);
    json targets = json::array();
    for (int f = 0; f < frames_; ++f) {
      const std::span<const float> frame = animation.frame(f);
      if (f > 0 && std::equal(frame.begin(), frame.end(), animation.frame(f - 1).begin())) {
        target_of_frame[f] = target_of_frame[f - 1];
        continue;
      }
      std::vector<float> displacement(floats);
      for (std::size_t i = 0; i < floats; ++i) {
        displacement[i] = frame[i] - mesh.positions[i / 3](i % 3);
        require(std::isfinite(displacement[i]), label + ": frame " + std::to_string(f) + " has a non-finite vertex");
      }
      target_of_frame[f] = static_cast<int>(targets.size());
      targets.push_back({{"POSITION", doc_.floats(displacement, "VEC3", 3, kArrayBuffer, true)}});
    }
    const std::size_t count = targets.size();
    std::vector<float> weights(std::size_t(frames_) * count, 0.0f);
    for (int f = 0; f < frames_; ++f) weights[std::size_t(f) * count + target_of_frame[f]] = 1.0f;
    json& mesh_json = doc_.at("meshes", mesh_index);
    mesh_json["primitives"][0]["targets"] = std::move(targets);
    mesh_json["weights"] = std::vector<double>(count, 0.0);
    const int output = doc_.floats(weights, "SCALAR", 1, 0, false);
    animation_["samplers"].push_back({{"input", time_accessor_}, {"interpolation", "LINEAR"}, {"output", output}});
    animation_["channels"].push_back(
        {{"sampler", animation_["samplers"].size() - 1}, {"target", {{"node", node}, {"path", "weights"}}}});
  }

  // A triangle mesh of one primitive; skinned when joints and weights are given.
  int add_mesh(const std::string& name, const std::vector<float>& positions, const std::vector<float>& normals,
               const std::vector<std::uint32_t>& triangles, int material_index, const std::vector<std::uint16_t>* joints,
               const std::vector<float>* weights) {
    json attributes = {{"POSITION", doc_.floats(positions, "VEC3", 3, kArrayBuffer, true)},
                       {"NORMAL", doc_.floats(normals, "VEC3", 3, kArrayBuffer, false)}};
    if (joints != nullptr) {
      attributes["JOINTS_0"] = doc_.integers(*joints, kUnsignedShort, "VEC4", 4, kArrayBuffer);
      attributes["WEIGHTS_0"] = doc_.floats(*weights, "VEC4", 4, kArrayBuffer, false);
    }
    json primitive = {{"attributes", std::move(attributes)},
                      {"indices", doc_.integers(triangles, kUnsignedInt, "SCALAR", 1, kElementArrayBuffer)},
                      {"material", material_index},
                      {"mode", 4}};
    return doc_.push("meshes", {{"name", name}, {"primitives", json::array({std::move(primitive)})}});
  }

  void add_props() {
    if (props_->meshes.empty()) return;
    const int colour = material(doc_, "props", kPropColour);
    std::size_t first_vertex = 0;
    for (std::size_t p = 0; p < props_->meshes.size(); ++p) {
      const CharacterMesh& mesh = props_->meshes[p];
      const std::string name = mesh.name.empty() ? "prop" + std::to_string(p) : mesh.name;
      check_mesh(mesh, "prop " + std::to_string(p) + " '" + name + "'", 1, false);
      const json extras = {{"odyssey_prop", p}, {"odyssey_first_vertex", first_vertex}};
      first_vertex += mesh.positions.size();
      if (mesh.triangles.empty()) continue;
      std::vector<Eigen::Vector3d> positions(mesh.positions.size());
      for (std::size_t v = 0; v < positions.size(); ++v) positions[v] = to_gltf(Eigen::Vector3d(mesh.positions[v].cast<double>()));
      const int mesh_index = add_mesh(name, flat(positions), vertex_normals(positions, mesh.triangles), mesh.triangles, colour,
                                      nullptr, nullptr);
      const int node = add_node({{"name", name}, {"mesh", mesh_index}, {"extras", extras}}, true);
      if (!prop_motion_.empty()) add_prop_motion(p, node);
    }
  }

  // A moving prop's channels: rotation C^-1 R C and translation C^-1 t per frame (see the header).
  void add_prop_motion(std::size_t p, int node) {
    const std::size_t count = props_->meshes.size();
    bool moves = false;
    for (int f = 0; f < frames_ && !moves; ++f) {
      const RigidTransform<double>& m = prop_motion_[f * count + p];
      moves = !m.rotation.isIdentity(0) || !m.translation.isZero(0);
    }
    if (!moves) return;
    std::vector<float> translations, rotations;
    translations.reserve(std::size_t(frames_) * 3);
    rotations.reserve(std::size_t(frames_) * 4);
    Eigen::Quaterniond previous = Eigen::Quaterniond::Identity();
    for (int f = 0; f < frames_; ++f) {
      const RigidTransform<double>& m = prop_motion_[f * count + p];
      previous = sign_aligned(quaternion_from_matrix(to_gltf() * m.rotation * to_gltf().transpose()).normalized(), previous);
      append(translations, to_gltf(m.translation));
      append(rotations, previous);
    }
    channel(doc_, animation_, time_accessor_, translations, 3, node, "translation");
    channel(doc_, animation_, time_accessor_, rotations, 4, node, "rotation");
  }

  // The camera's node: rotation C^-1 R_cv^T D and translation C^-1 c per frame (see the header).
  void add_camera(int c) {
    const SceneGlbCamera& camera = cameras_[c];
    const CameraPath& path = *camera.path;
    const PinholeIntrinsics& k = path.intrinsics.front();
    const int camera_index = doc_.push("cameras", {{"name", camera.name},
                                                   {"type", "perspective"},
                                                   {"perspective",
                                                    {{"aspectRatio", double(k.width) / k.height},
                                                     {"yfov", 2 * std::atan(k.height / (2 * k.fy))},
                                                     {"znear", kCameraNear}}}});
    const Eigen::Matrix3d d = Eigen::Vector3d(1, -1, -1).asDiagonal();
    std::vector<float> translations, rotations;
    translations.reserve(std::size_t(frames_) * 3);
    rotations.reserve(std::size_t(frames_) * 4);
    Eigen::Quaterniond previous = Eigen::Quaterniond::Identity(), first_rotation = previous;
    Eigen::Vector3d first_translation = Eigen::Vector3d::Zero();
    for (int f = 0; f < frames_; ++f) {
      const CameraPose& pose = path.poses[f];
      const Eigen::Vector3d u = to_gltf(pose.centre());
      previous = sign_aligned(quaternion_from_matrix(to_gltf() * pose.rotation.transpose() * d).normalized(), previous);
      append(translations, u);
      append(rotations, previous);
      if (f == 0) {
        first_rotation = previous;
        first_translation = u;
      }
    }
    json extras = {{"odyssey_camera", c}};
    if (camera.rides_on >= 0) {
      extras["odyssey_rides_on"] = camera.rides_on;
      extras["odyssey_hides_subtree_of"] = actors_[camera.rides_on].character->skeleton.names()[camera.hidden_joint];
    }
    const int node = add_node({{"name", camera.name},
                               {"camera", camera_index},
                               {"rotation", xyzw(first_rotation)},
                               {"translation", xyz(first_translation)},
                               {"extras", extras}},
                              true);
    channel(doc_, animation_, time_accessor_, translations, 3, node, "translation");
    channel(doc_, animation_, time_accessor_, rotations, 4, node, "rotation");
  }

  std::string path_;
  std::span<const SceneGlbActor> actors_;
  const Character* props_;
  std::span<const SceneGlbCamera> cameras_;
  double fps_;
  std::span<const RigidTransform<double>> prop_motion_;
  int frames_ = -1;
  std::string frames_owner_;
  int time_accessor_ = -1;
  json animation_;
  Document doc_;
};

}  // namespace

void write_scene_glb(const std::string& path, std::span<const SceneGlbActor> actors, const Character* props,
                     std::span<const SceneGlbCamera> cameras, double fps, std::span<const RigidTransform<double>> prop_motion) {
  const std::string glb = SceneGlbBuilder(path, actors, props, cameras, fps, prop_motion).build();
  write_file_atomically(path, glb);
}

}  // namespace odyssey::io
