// A small glTF character written by the tests, whose one animation ("Wave") uses every sampler
// and every path the player must handle:
//
//   node 0 "mover"  no joint, the parent of the skeleton: scale 2 (a channel that keeps it 2),
//                   translation LINEAR, rotation CUBICSPLINE about Y (with tangents)
//   node 1 "hips"   skin joint, rotation STEP
//   node 2 "arm"    skin joint, rotation LINEAR (6 degrees a key about Z)
//   node 3 "hand"   not a joint: carries the rigid mesh "block"; translation CUBICSPLINE
//   node 4 "tail"   skin joint, no channel
//   node 5 "body"   the skinned mesh (skin of hips, arm, tail), at the scene's root
//
// Keys at 0, 0.5 and 1 s. Lengths about 1 unit (2 after mover's scale). Written as GLB with the
// binary chunk built here, independent of the toolkit's own writers.
#pragma once

#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace odyssey::animated_rig {

// Options to break the file on purpose.
struct RigOptions {
  bool grow_arm = false;  // also animate the arm's scale from 1 to 1.5 (changes geometry: refused)
  // false: the two CUBICSPLINE tracks become LINEAR (the rotation through smaller angles) (for Blender 3.4,
  // whose importer ignores CUBICSPLINE tangents: its gltf2_blender_animation_node.py says
  // "TODO manage tangent?" and gives the curve automatic Bezier handles).
  bool cubic = true;
};

class GlbBuilder {
 public:
  // Appends float or integer data as an accessor of `type` ("SCALAR", "VEC3", ...), returns its index.
  int floats(const std::vector<float>& values, const std::string& type, int components, bool with_bounds = false) {
    const int view = add_view(values.data(), values.size() * 4);
    nlohmann::json accessor = {{"bufferView", view}, {"componentType", 5126}, {"count", values.size() / components}, {"type", type}};
    if (with_bounds) {
      std::vector<float> low(components, INFINITY), high(components, -INFINITY);
      for (std::size_t i = 0; i < values.size(); ++i) {
        low[i % components] = std::min(low[i % components], values[i]);
        high[i % components] = std::max(high[i % components], values[i]);
      }
      accessor["min"] = low;
      accessor["max"] = high;
    }
    json["accessors"].push_back(accessor);
    return static_cast<int>(json["accessors"].size()) - 1;
  }
  int uints(const std::vector<std::uint16_t>& values, const std::string& type, int components, int component_type = 5123) {
    std::vector<unsigned char> bytes;
    for (std::uint16_t v : values) {
      if (component_type == 5121) {
        bytes.push_back(static_cast<unsigned char>(v));
      } else {
        bytes.push_back(static_cast<unsigned char>(v & 0xff));
        bytes.push_back(static_cast<unsigned char>(v >> 8));
      }
    }
    const int view = add_view(bytes.data(), bytes.size());
    json["accessors"].push_back({{"bufferView", view}, {"componentType", component_type}, {"count", values.size() / components}, {"type", type}});
    return static_cast<int>(json["accessors"].size()) - 1;
  }

  void write(const std::string& path) {
    json["asset"] = {{"version", "2.0"}};
    json["buffers"] = nlohmann::json::array({{{"byteLength", binary.size()}}});
    std::string text = json.dump();
    while (text.size() % 4) text += ' ';
    while (binary.size() % 4) binary.push_back(0);
    const auto u32 = [](std::string& out, std::uint32_t v) { out.append(reinterpret_cast<const char*>(&v), 4); };
    std::string out;
    u32(out, 0x46546C67);
    u32(out, 2);
    u32(out, static_cast<std::uint32_t>(12 + 8 + text.size() + 8 + binary.size()));
    u32(out, static_cast<std::uint32_t>(text.size()));
    u32(out, 0x4E4F534A);
    out += text;
    u32(out, static_cast<std::uint32_t>(binary.size()));
    u32(out, 0x004E4942);
    out.append(reinterpret_cast<const char*>(binary.data()), binary.size());
    std::ofstream(path, std::ios::binary) << out;
  }

  nlohmann::json json = nlohmann::json::object();
  std::vector<unsigned char> binary;

 private:
  int add_view(const void* data, std::size_t bytes) {
    while (binary.size() % 4) binary.push_back(0);
    const std::size_t offset = binary.size();
    binary.resize(offset + bytes);
    std::memcpy(binary.data() + offset, data, bytes);
    json["bufferViews"].push_back({{"buffer", 0}, {"byteOffset", offset}, {"byteLength", bytes}});
    return static_cast<int>(json["bufferViews"].size()) - 1;
  }
};

// x, y, z, w of a rotation of `degrees` about a unit axis.
inline std::vector<float> quaternion(double degrees, double x, double y, double z) {
  const double half = degrees * 3.14159265358979323846 / 360;
  return {float(x * std::sin(half)), float(y * std::sin(half)), float(z * std::sin(half)), float(std::cos(half))};
}

inline std::vector<float> joined(std::initializer_list<std::vector<float>> parts) {
  std::vector<float> out;
  for (const auto& part : parts) out.insert(out.end(), part.begin(), part.end());
  return out;
}

inline void write_rig(const std::string& path, const RigOptions& options = {}) {
  GlbBuilder glb;
  nlohmann::json& j = glb.json;
  j["scene"] = 0;
  j["scenes"] = nlohmann::json::array({{{"nodes", {0, 5}}}});
  j["nodes"] = nlohmann::json::array({
      {{"name", "mover"}, {"children", {1}}, {"scale", {2, 2, 2}}, {"translation", {0.1, 0, 0}}},
      {{"name", "hips"}, {"children", {2, 4}}, {"translation", {0, 0.5, 0}}},
      {{"name", "arm"}, {"children", {3}}, {"translation", {0, 0.4, 0}}, {"rotation", quaternion(10, 0, 0, 1)}},
      {{"name", "hand"}, {"translation", {0.5, 0, 0}}, {"mesh", 1}},
      {{"name", "tail"}, {"translation", {0, -0.2, -0.3}}},
      {{"name", "body"}, {"mesh", 0}, {"skin", 0}},
  });

  // The body: a strip of 4 quads from the hips (y 0.5) up the arm (y 0.9 .. 1.4, bent along x) and one
  // down to the tail, in the file's rest (mesh) space: with mover's scale 2 and shift, world = 2 local + (0.1, 0, 0).
  // Positions given in the skin's bind space: the inverse bind matrices below are the inverse world rest transforms.
  std::vector<float> positions, weights;
  std::vector<std::uint16_t> joints, indices;
  const float ys[] = {0.8f, 1.0f, 1.6f, 2.2f, 0.5f};
  for (int row = 0; row < 5; ++row) {
    for (const float x : {-0.1f, 0.5f}) {
      const float z = row == 4 ? -0.6f : 0.0f;
      positions.insert(positions.end(), {x + 0.1f, ys[row], z});
      const std::uint16_t joint = row <= 1 ? 0 : row == 4 ? 2 : 1;
      joints.insert(joints.end(), {joint, static_cast<std::uint16_t>(row == 1 ? 1 : 0), 0, 0});
      weights.insert(weights.end(), {row == 1 ? 0.5f : 1.0f, row == 1 ? 0.5f : 0.0f, 0, 0});
    }
  }
  for (const std::uint16_t row : {0, 1, 2}) {
    const std::uint16_t a = 2 * row;
    indices.insert(indices.end(), {a, static_cast<std::uint16_t>(a + 1), static_cast<std::uint16_t>(a + 3), a,
                                   static_cast<std::uint16_t>(a + 3), static_cast<std::uint16_t>(a + 2)});
  }
  indices.insert(indices.end(), {0, 9, 1, 0, 8, 9});
  // Inverse bind matrices (column-major): world rest of hips = T(0.1 + 0, 1.0, 0) S2 ... written as
  // the inverse of each joint's world matrix at rest, computed from the node transforms above.
  // hips: G = T(0.1,0,0) S(2) T(0,0.5,0) -> [2I | (0.1, 1, 0)]; inverse [I/2 | -(0.05, 0.5, 0)].
  // arm:  G = G_hips T(0,0.4,0) R10 -> [2 R10 | (0.1, 1.8, 0)]; inverse [R10^T / 2 | -R10^T (0.1, 1.8, 0) / 2].
  // tail: G = G_hips T(0,-0.2,-0.3) -> [2I | (0.1, 0.6, -0.6)]; inverse [I/2 | -(0.05, 0.3, -0.3)].
  const double c = std::cos(10 * 3.14159265358979323846 / 180), s = std::sin(10 * 3.14159265358979323846 / 180);
  const std::vector<float> hips_ibm = {0.5f, 0, 0, 0, 0, 0.5f, 0, 0, 0, 0, 0.5f, 0, -0.05f, -0.5f, 0, 1};
  const double ax = 0.1, ay = 1.8;
  const std::vector<float> arm_ibm = {float(c / 2), float(-s / 2), 0, 0,  float(s / 2), float(c / 2), 0, 0,  0, 0, 0.5f, 0,
                                      float(-(c * ax + s * ay) / 2), float(-(-s * ax + c * ay) / 2), 0, 1};
  const std::vector<float> tail_ibm = {0.5f, 0, 0, 0, 0, 0.5f, 0, 0, 0, 0, 0.5f, 0, -0.05f, -0.3f, 0.3f, 1};
  const int position_accessor = glb.floats(positions, "VEC3", 3, true);
  const int joint_accessor = glb.uints(joints, "VEC4", 4, 5121);
  const int weight_accessor = glb.floats(weights, "VEC4", 4);
  const int index_accessor = glb.uints(indices, "SCALAR", 1);
  const int ibm_accessor = glb.floats(joined({hips_ibm, arm_ibm, tail_ibm}), "MAT4", 16);
  j["skins"] = nlohmann::json::array({{{"joints", {1, 2, 4}}, {"inverseBindMatrices", ibm_accessor}}});

  // The block on "hand": a small tetrahedron in the node's own space.
  const int block_positions = glb.floats({0, 0, 0, 0.2f, 0, 0, 0, 0.2f, 0, 0, 0, 0.2f}, "VEC3", 3, true);
  const int block_indices = glb.uints({0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3}, "SCALAR", 1);
  nlohmann::json body_primitive, block_primitive;
  body_primitive["attributes"] = {{"POSITION", position_accessor}, {"JOINTS_0", joint_accessor}, {"WEIGHTS_0", weight_accessor}};
  body_primitive["indices"] = index_accessor;
  block_primitive["attributes"] = {{"POSITION", block_positions}};
  block_primitive["indices"] = block_indices;
  nlohmann::json body, block;
  body["name"] = "body";
  body["primitives"] = nlohmann::json::array({body_primitive});
  block["name"] = "block";
  block["primitives"] = nlohmann::json::array({block_primitive});
  j["meshes"] = nlohmann::json::array({body, block});

  // The animation.
  const int times = glb.floats({0, 0.5f, 1}, "SCALAR", 1, true);
  std::vector<nlohmann::json> samplers, channels;
  const auto add = [&](int node, const char* path, const char* interpolation, const std::vector<float>& values, const char* type,
                       int components) {
    samplers.push_back({{"input", times}, {"output", glb.floats(values, type, components)}, {"interpolation", interpolation}});
    channels.push_back({{"sampler", samplers.size() - 1}, {"target", {{"node", node}, {"path", path}}}});
  };
  add(0, "scale", "LINEAR", {2, 2, 2, 2, 2, 2, 2, 2, 2}, "VEC3", 3);
  add(0, "translation", "LINEAR", {0.1f, 0, 0, 0.4f, 0.1f, -0.2f, 0.7f, 0, -0.4f}, "VEC3", 3);
  // Per key: in-tangent, value, out-tangent (units per second).
  if (options.cubic) {
    add(0, "rotation", "CUBICSPLINE",
        joined({{0, 0, 0, 0}, quaternion(0, 0, 1, 0), {0, 0.3f, 0, 0},
                {0, 0.1f, 0, 0}, quaternion(20, 0, 1, 0), {0, -0.2f, 0, 0.05f},
                {0, 0.2f, 0, 0}, quaternion(35, 0, 1, 0), {0, 0, 0, 0}}),
        "VEC4", 4);
  } else {
    // 6 degrees a key: Blender lerps quaternion components, glTF slerps; at 20 degrees a key the two
    // part by 1e-4 rad, at 6 by about 3e-6.
    add(0, "rotation", "LINEAR", joined({quaternion(0, 0, 1, 0), quaternion(6, 0, 1, 0), quaternion(12, 0, 1, 0)}), "VEC4", 4);
  }
  add(1, "rotation", "STEP", joined({quaternion(0, 1, 0, 0), quaternion(25, 1, 0, 0), quaternion(-15, 1, 0, 0)}), "VEC4", 4);
  add(2, "rotation", "LINEAR", joined({quaternion(10, 0, 0, 1), quaternion(16, 0, 0, 1), quaternion(22, 0, 0, 1)}), "VEC4", 4);
  if (options.cubic) {
    add(3, "translation", "CUBICSPLINE",
        {0, 0, 0, 0.5f, 0, 0, 0, 0.4f, 0,
         0.2f, 0, 0, 0.6f, 0.1f, 0, -0.3f, 0, 0.1f,
         0, 0, 0, 0.5f, 0, 0.2f, 0, 0, 0},
        "VEC3", 3);
  } else {
    add(3, "translation", "LINEAR", {0.5f, 0, 0, 0.6f, 0.1f, 0, 0.5f, 0, 0.2f}, "VEC3", 3);
  }
  if (options.grow_arm) add(2, "scale", "LINEAR", {1, 1, 1, 1.2f, 1.2f, 1.2f, 1.5f, 1.5f, 1.5f}, "VEC3", 3);
  j["animations"] = nlohmann::json::array({{{"name", "Wave"}, {"samplers", samplers}, {"channels", channels}}});
  glb.write(path);
}

}  // namespace odyssey::animated_rig
