#include "mocap_io/gltf_character.h"

#include <tiny_gltf.h>

#include <Eigen/SVD>
#include <algorithm>
#include <array>
#include <bit>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string_view>

#include "mocap_io/input_error.h"
#include "mocap_io/input_file.h"
#include "skeleton/node_transform.h"
#include "skeleton/rotation.h"

namespace odyssey::io {
namespace {

static_assert(std::endian::native == std::endian::little,
              "glTF buffers are little-endian and are copied as they are");

// Largest ratio - 1 between the singular values of a world linear part that still counts as one
// uniform scale on a node with joints below it (see the header).
constexpr double kMaxAnisotropy = 1e-3;
// The nodes hold the bind pose when every skin joint's rotation at bind (from the inverse bind
// matrices) and in the nodes agree to this angle (radians); float32 matrices from exporters agree
// to about 1e-6.
constexpr double kBindAngleTolerance = 1e-4;
// An inverse bind matrix whose linear part's smallest singular value is below this fraction of
// its largest cannot be inverted into a bind pose (and would collapse the mesh).
constexpr double kMinIbmConditioning = 1e-9;
// gltf_decode_budget(): a floor for small files, and a factor over the input's bytes.
constexpr std::uint64_t kDecodeBudgetFloor = std::uint64_t(16) << 20;
constexpr std::uint64_t kDecodeBudgetPerInputByte = 64;
// How many components of the JSON path the depth error shows.
constexpr std::size_t kShownPathComponents = 8;
constexpr std::uint32_t kGlbMagic = 0x46546C67;      // "glTF"
constexpr std::uint32_t kGlbJsonChunk = 0x4E4F534A;  // "JSON"

std::string in_quotes(const std::string& name) { return "'" + name + "'"; }

std::string trimmed(std::string text) {
  while (!text.empty() && std::isspace(static_cast<unsigned char>(text.back()))) text.pop_back();
  return text;
}

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream stream(text);
  for (std::string line; std::getline(stream, line);) {
    line = trimmed(line);
    if (!line.empty()) lines.push_back(line);
  }
  return lines;
}

// [offset, offset + length) inside [0, size), without overflow.
bool fits(std::uint64_t offset, std::uint64_t length, std::uint64_t size) {
  return offset <= size && length <= size - offset;
}

std::vector<unsigned char> read_whole_file(const std::string& path) {
  require_input_file(path);
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, "cannot be opened");
  in.seekg(0, std::ios::end);
  const std::streamoff size = in.tellg();
  in.seekg(0, std::ios::beg);
  // tinygltf takes 32-bit lengths, and GLB cannot exceed 4 GiB.
  if (size < 0 || static_cast<std::uint64_t>(size) > std::numeric_limits<std::uint32_t>::max()) {
    throw InputError(path, "cannot be read, or is 4 GiB or larger");
  }
  std::vector<unsigned char> bytes(static_cast<std::size_t>(size));
  if (!bytes.empty() && !in.read(reinterpret_cast<char*>(bytes.data()), size)) {
    throw InputError(path, "could not be read to the end");
  }
  return bytes;
}

std::uint32_t u32_at(const std::vector<unsigned char>& bytes, std::size_t at) {
  std::uint32_t value;
  std::memcpy(&value, bytes.data() + at, 4);
  return value;
}

// The GLB layout: a 12-byte header (magic, version 2, total length), a JSON chunk (length, type,
// data) and optionally a BIN chunk (length, type, data). tinygltf 2.7 lets a BIN chunk overrun
// the declared length by its own 8-byte header, so the chunk sizes are checked here first.
// Returns the declared length (bytes after it are ignored, as the spec's reader would).
std::uint32_t checked_glb_length(const std::string& path, const std::vector<unsigned char>& bytes) {
  if (bytes.size() < 20) {
    throw InputError(path, "truncated GLB: " + std::to_string(bytes.size()) +
                               " bytes, less than the 12-byte header and the JSON chunk's 8-byte header");
  }
  const std::uint32_t version = u32_at(bytes, 4), length = u32_at(bytes, 8);
  const std::uint32_t json_length = u32_at(bytes, 12), json_type = u32_at(bytes, 16);
  if (version != 2) throw InputError(path, "GLB version " + std::to_string(version) + "; only version 2 is read");
  if (length > bytes.size()) {
    throw InputError(path, "truncated GLB: the header declares " + std::to_string(length) + " bytes but the file has " +
                               std::to_string(bytes.size()));
  }
  if (json_type != kGlbJsonChunk) throw InputError(path, "GLB's first chunk is not JSON");
  const std::uint64_t json_end = 20 + std::uint64_t(json_length);
  if (json_end > length) {
    throw InputError(path, "truncated GLB: the JSON chunk declares " + std::to_string(json_length) + " bytes but only " +
                               std::to_string(length - 20) + " follow its header");
  }
  if (json_end < length) {
    if (json_end + 8 > length) throw InputError(path, "truncated GLB: the binary chunk's header is cut off");
    const std::uint32_t bin_length = u32_at(bytes, static_cast<std::size_t>(json_end));
    if (!fits(json_end + 8, bin_length, length)) {
      throw InputError(path, "truncated GLB: the binary chunk declares " + std::to_string(bin_length) +
                                 " bytes but only " + std::to_string(length - json_end - 8) + " follow its header");
    }
  }
  return length;
}

// Images are never needed here: accept them without decoding.
bool skip_image(tinygltf::Image*, const int, std::string*, std::string*, int, int, const unsigned char*, int, void*) {
  return true;
}

tinygltf::Model parse_gltf(const std::string& path, const std::vector<unsigned char>& bytes,
                           std::vector<std::string>& warnings) {
  const bool binary = bytes.size() >= 4 && u32_at(bytes, 0) == kGlbMagic;
  const std::uint32_t length = binary ? checked_glb_length(path, bytes) : static_cast<std::uint32_t>(bytes.size());
  const char* text = reinterpret_cast<const char*>(bytes.data());
  check_gltf_json_depth(path, binary ? std::string_view(text + 20, u32_at(bytes, 12)) : std::string_view(text, length));
  const std::string base_dir = std::filesystem::path(path).parent_path().string();

  tinygltf::TinyGLTF parser;
  parser.SetImageLoader(skip_image, nullptr);
  tinygltf::Model model;
  std::string error, warning;
  bool parsed = false;
  try {
    parsed = binary ? parser.LoadBinaryFromMemory(&model, &error, &warning, bytes.data(), length, base_dir)
                    : parser.LoadASCIIFromString(&model, &error, &warning, reinterpret_cast<const char*>(bytes.data()),
                                                 length, base_dir);
  } catch (const std::exception& e) {
    throw InputError(path, std::string("not a readable glTF file: ") + e.what());
  }
  if (!parsed) {
    const std::string reason = trimmed(error.empty() ? warning : error);
    throw InputError(path, "not a readable glTF file: " + (reason.empty() ? "tinygltf gave no reason" : reason));
  }
  for (const std::string& line : lines_of(warning)) warnings.push_back("glTF parser: " + line);
  for (const std::string& line : lines_of(error)) warnings.push_back("glTF parser: " + line);
  return model;
}

int component_size(int component_type) {
  switch (component_type) {
    case TINYGLTF_COMPONENT_TYPE_BYTE:
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE:
      return 1;
    case TINYGLTF_COMPONENT_TYPE_SHORT:
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT:
      return 2;
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT:
    case TINYGLTF_COMPONENT_TYPE_FLOAT:
      return 4;
    default:
      return 0;
  }
}

std::string component_name(int component_type) {
  switch (component_type) {
    case TINYGLTF_COMPONENT_TYPE_BYTE:
      return "byte";
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE:
      return "unsigned byte";
    case TINYGLTF_COMPONENT_TYPE_SHORT:
      return "short";
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT:
      return "unsigned short";
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT:
      return "unsigned int";
    case TINYGLTF_COMPONENT_TYPE_FLOAT:
      return "float";
    default:
      return "component type " + std::to_string(component_type);
  }
}

std::string type_name(int type) {
  switch (type) {
    case TINYGLTF_TYPE_SCALAR:
      return "SCALAR";
    case TINYGLTF_TYPE_VEC2:
      return "VEC2";
    case TINYGLTF_TYPE_VEC3:
      return "VEC3";
    case TINYGLTF_TYPE_VEC4:
      return "VEC4";
    case TINYGLTF_TYPE_MAT2:
      return "MAT2";
    case TINYGLTF_TYPE_MAT3:
      return "MAT3";
    case TINYGLTF_TYPE_MAT4:
      return "MAT4";
    default:
      return "type " + std::to_string(type);
  }
}

int component_count(int type) {
  switch (type) {
    case TINYGLTF_TYPE_SCALAR:
      return 1;
    case TINYGLTF_TYPE_VEC3:
      return 3;
    case TINYGLTF_TYPE_VEC4:
      return 4;
    case TINYGLTF_TYPE_MAT4:
      return 16;
    default:  // the loader reads no other element type
      return 0;
  }
}

// One component as a number. glTF's normalised integers map to [0, 1] (unsigned, c / max) or
// [-1, 1] (signed, max(c / max, -1)).
double component_at(const unsigned char* at, int component_type, bool normalized) {
  switch (component_type) {
    case TINYGLTF_COMPONENT_TYPE_BYTE: {
      std::int8_t c;
      std::memcpy(&c, at, 1);
      return normalized ? std::max(c / 127.0, -1.0) : c;
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: {
      std::uint8_t c;
      std::memcpy(&c, at, 1);
      return normalized ? c / 255.0 : c;
    }
    case TINYGLTF_COMPONENT_TYPE_SHORT: {
      std::int16_t c;
      std::memcpy(&c, at, 2);
      return normalized ? std::max(c / 32767.0, -1.0) : c;
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
      std::uint16_t c;
      std::memcpy(&c, at, 2);
      return normalized ? c / 65535.0 : c;
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: {
      std::uint32_t c;
      std::memcpy(&c, at, 4);
      return normalized ? c / 4294967295.0 : c;
    }
    default: {  // float, the only other type the callers allow
      float c;
      std::memcpy(&c, at, 4);
      return c;
    }
  }
}

// An accessor's elements, `components` numbers each, row after row.
struct Elements {
  std::size_t count = 0;
  int components = 0;
  std::vector<double> values;
  double at(std::size_t element, int component) const { return values[element * components + component]; }
};

// A node's rigid world frame in the file (rotation R and position t of its world matrix G) and
// the inverse of [R | t], which turns G into the part the rigid skeleton does not carry.
struct RigidFrame {
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
  Eigen::Matrix4d inverse() const {
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
    m.topLeftCorner<3, 3>() = rotation.transpose();
    m.topRightCorner<3, 1>() = -(rotation.transpose() * translation);
    return m;
  }
};

// A skin as the Character holds it: skeleton joints and inverse_bind = [R | t]^-1 G IBM per slot.
struct SkinBinding {
  std::vector<int> joints;
  std::vector<Eigen::Matrix4d> inverse_bind;
};

class CharacterReader {
 public:
  CharacterReader(std::string path, tinygltf::Model model, std::vector<std::string> warnings, std::uint64_t decode_budget)
      : path_(std::move(path)), model_(std::move(model)), warnings_(std::move(warnings)), decode_budget_(decode_budget),
        decode_budget_left_(decode_budget) {}

  Character read() {
    check_required_extensions();
    check_node_references();
    build_hierarchy();
    compute_world_matrices();
    mark_scene();
    select_skeleton_nodes();
    read_inverse_binds();
    Character character;
    character.name = std::filesystem::path(path_).stem().string();
    adopt_bind_pose(character);
    build_skeleton(character);
    record_rest_locals(character);
    read_declared_humanoid(character);
    for (std::size_t skin = 0; skin < model_.skins.size(); ++skin) bindings_.push_back(bind_skin(int(skin)));
    for (int node = 0; node < node_count(); ++node) {
      if (in_scene_[node] && model_.nodes[node].mesh >= 0) add_node_meshes(node, character);
    }
    character.warnings = std::move(warnings_);
    return character;
  }

  // Skins and animations, for summarize_gltf_file().
  GltfFileSummary summarize() {
    check_required_extensions();
    GltfFileSummary summary;
    for (std::size_t k = 0; k < model_.skins.size(); ++k) {
      const tinygltf::Skin& skin = model_.skins[k];
      for (int joint : skin.joints) check_index(joint, model_.nodes.size(), "skin " + std::to_string(k), "node");
      summary.skins.push_back({skin.name.empty() ? "skin_" + std::to_string(k) : skin.name, int(skin.joints.size())});
    }
    for (std::size_t a = 0; a < model_.animations.size(); ++a) {
      const tinygltf::Animation& animation = model_.animations[a];
      GltfAnimationSummary out;
      out.name = animation.name.empty() ? "animation_" + std::to_string(a) : animation.name;
      out.channels = int(animation.channels.size());
      out.samplers = int(animation.samplers.size());
      const std::string label = "animation " + std::to_string(a) + " '" + out.name + "'";
      for (std::size_t c = 0; c < animation.channels.size(); ++c) {
        const tinygltf::AnimationChannel& channel = animation.channels[c];
        const std::string what = label + " channel " + std::to_string(c);
        check_index(channel.sampler, animation.samplers.size(), what, "sampler");
        if (channel.target_node >= 0) check_index(channel.target_node, model_.nodes.size(), what, "node");
      }
      bool any = false;
      for (std::size_t k = 0; k < animation.samplers.size(); ++k) {
        const std::string what = label + " sampler " + std::to_string(k) + " input";
        const Elements times = read_accessor(animation.samplers[k].input, what, TINYGLTF_TYPE_SCALAR,
                                             {TINYGLTF_COMPONENT_TYPE_FLOAT});
        out.keyframes = std::max(out.keyframes, times.count);
        for (double t : times.values) {
          if (!std::isfinite(t)) fail(what + " holds a non-finite time");
          out.start = any ? std::min(out.start, t) : t;
          out.end = any ? std::max(out.end, t) : t;
          any = true;
        }
      }
      summary.animations.push_back(std::move(out));
    }
    return summary;
  }

  // The node hierarchy and the channels of the animation called `name`, for load_gltf_animation().
  NodeAnimation read_animation(const std::string& name) {
    check_required_extensions();
    check_node_references();
    build_hierarchy();
    std::vector<std::string> names;
    int index = -1;
    for (std::size_t a = 0; a < model_.animations.size(); ++a) {
      names.push_back(model_.animations[a].name.empty() ? "animation_" + std::to_string(a) : model_.animations[a].name);
      if (names.back() == name && index < 0) index = static_cast<int>(a);
    }
    if (index < 0) {
      std::string listed;
      for (const std::string& known : names) listed += (listed.empty() ? "" : ", ") + in_quotes(known);
      fail("has no animation " + in_quotes(name) + (names.empty() ? "; it has no animations" : "; its animations: " + listed));
    }
    NodeAnimation animation;
    animation.name = name;
    animation.parents = parent_;
    animation.order = order_;
    animation.to_world = y_up_to_z_up();
    for (int node = 0; node < node_count(); ++node) animation.rest.push_back(node_rest(node));

    const tinygltf::Animation& source = model_.animations[index];
    const std::string label = "animation " + std::to_string(index) + " " + in_quotes(name);
    bool any = false;
    for (std::size_t c = 0; c < source.channels.size(); ++c) {
      const tinygltf::AnimationChannel& channel = source.channels[c];
      const std::string what = label + " channel " + std::to_string(c);
      check_index(channel.sampler, source.samplers.size(), what, "sampler");
      if (channel.target_node < 0) continue;  // a target an extension defines: nothing to play here
      check_index(channel.target_node, model_.nodes.size(), what, "node");
      NodeChannel out;
      out.node = channel.target_node;
      if (channel.target_path == "translation") {
        out.property = NodeProperty::translation;
      } else if (channel.target_path == "rotation") {
        out.property = NodeProperty::rotation;
      } else if (channel.target_path == "scale") {
        out.property = NodeProperty::scale;
      } else if (channel.target_path == "weights") {
        animation.warnings.push_back(what + " animates the morph target weights of " + node_label(channel.target_node) +
                                     ", which are not played (morph targets stay at their default weights)");
        continue;
      } else {
        fail(what + " has target path " + in_quotes(channel.target_path) +
             " (expected translation, rotation, scale or weights)");
      }
      if (!model_.nodes[out.node].matrix.empty()) {
        fail(what + " animates " + node_label(out.node) + ", which is given as a matrix; glTF animates only nodes given "
                    "by translation, rotation and scale");
      }
      const tinygltf::AnimationSampler& sampler = source.samplers[channel.sampler];
      const std::string sampler_label = label + " sampler " + std::to_string(channel.sampler);
      KeyframeTrack& track = out.track;
      if (sampler.interpolation.empty() || sampler.interpolation == "LINEAR") {
        track.interpolation = Interpolation::linear;
      } else if (sampler.interpolation == "STEP") {
        track.interpolation = Interpolation::step;
      } else if (sampler.interpolation == "CUBICSPLINE") {
        track.interpolation = Interpolation::cubic_spline;
      } else {
        fail(sampler_label + " has interpolation " + in_quotes(sampler.interpolation) +
             " (expected LINEAR, STEP or CUBICSPLINE)");
      }
      track.rotation = out.property == NodeProperty::rotation;
      track.components = track.rotation ? 4 : 3;
      const Elements times =
          read_accessor(sampler.input, sampler_label + " input", TINYGLTF_TYPE_SCALAR, {TINYGLTF_COMPONENT_TYPE_FLOAT});
      // KHR_mesh_quantization lets rotations be normalised integers; translations and scales are floats.
      const Elements values =
          track.rotation ? read_accessor(sampler.output, sampler_label + " output", TINYGLTF_TYPE_VEC4,
                                         {TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_COMPONENT_TYPE_BYTE,
                                          TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE, TINYGLTF_COMPONENT_TYPE_SHORT,
                                          TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT})
                         : read_accessor(sampler.output, sampler_label + " output", TINYGLTF_TYPE_VEC3,
                                         {TINYGLTF_COMPONENT_TYPE_FLOAT});
      const std::size_t per_key = track.interpolation == Interpolation::cubic_spline ? 3 : 1;
      if (values.count != times.count * per_key) {
        fail(sampler_label + " has " + std::to_string(times.count) + " key times but " + std::to_string(values.count) +
             " output elements" + (per_key == 3 ? " (CUBICSPLINE needs 3 a key: in-tangent, value, out-tangent)" : ""));
      }
      track.times = times.values;
      track.values = values.values;
      try {
        track.validate(sampler_label);
      } catch (const std::invalid_argument& error) {
        fail(error.what());
      }
      animation.start = any ? std::min(animation.start, track.times.front()) : track.times.front();
      animation.end = any ? std::max(animation.end, track.times.back()) : track.times.back();
      any = true;
      animation.channels.push_back(std::move(out));
    }
    if (!any) fail(label + " animates no node's translation, rotation or scale");
    try {
      animation.validate();
    } catch (const std::invalid_argument& error) {
      fail(error.what());
    }
    return animation;
  }

 private:
  [[noreturn]] void fail(const std::string& problem) const { throw InputError(path_, problem); }

  // A node's rest translation, rotation (normalised) and scale, or its matrix, checked as node_transform does.
  NodeTransform node_rest(int node) const {
    NodeTransform rest = node_transform(node);
    rest.rotation.normalize();
    return rest;
  }

  // VRM avatars declare their humanoid bones: VRM 0.x as extensions.VRM.humanoid.humanBones, an
  // array of {"bone": name, "node": index}; VRM 1.0 as extensions.VRMC_vrm.humanoid.humanBones,
  // an object name -> {"node": index}. A malformed list (wrong types, a node index outside the
  // file, a bone named twice) is an error naming its JSON path; a bone on a node that is not a
  // joint of the skeleton (nothing skinned below it) is skipped with a warning.
  void read_declared_humanoid(Character& character) {
    std::vector<std::pair<std::string, const tinygltf::Value*>> bones;  // name, the value holding "node"
    std::string where;
    const auto member = [&](const tinygltf::Value& object, const char* key, const std::string& path) -> const tinygltf::Value& {
      if (!object.IsObject() || !object.Has(key)) fail(path + " has no '" + key + "'");
      return object.Get(key);
    };
    if (const auto vrm1 = model_.extensions.find("VRMC_vrm"); vrm1 != model_.extensions.end()) {
      where = "extensions.VRMC_vrm.humanoid.humanBones";
      character.declared_humanoid_convention = "VRM 1.0";
      const tinygltf::Value& list = member(member(vrm1->second, "humanoid", "extensions.VRMC_vrm"), "humanBones",
                                           "extensions.VRMC_vrm.humanoid");
      if (!list.IsObject()) fail(where + " is not an object");
      for (const std::string& name : list.Keys()) bones.emplace_back(name, &list.Get(name));
    } else if (const auto vrm0 = model_.extensions.find("VRM"); vrm0 != model_.extensions.end()) {
      where = "extensions.VRM.humanoid.humanBones";
      character.declared_humanoid_convention = "VRM 0.x";
      const tinygltf::Value& list = member(member(vrm0->second, "humanoid", "extensions.VRM"), "humanBones",
                                           "extensions.VRM.humanoid");
      if (!list.IsArray()) fail(where + " is not an array");
      for (std::size_t k = 0; k < list.ArrayLen(); ++k) {
        const tinygltf::Value& entry = list.Get(static_cast<int>(k));
        const tinygltf::Value& bone = member(entry, "bone", where + "[" + std::to_string(k) + "]");
        if (!bone.IsString()) fail(where + "[" + std::to_string(k) + "].bone is not a string");
        bones.emplace_back(bone.Get<std::string>(), &entry);
      }
    } else {
      return;
    }
    for (const auto& [name, holder] : bones) {
      const std::string path = where + (holder->IsObject() && holder->Has("bone") ? "[bone '" + name + "']" : "." + name);
      const tinygltf::Value& node = member(*holder, "node", path);
      if (!node.IsInt()) fail(path + ".node is not an integer");
      const int index = node.GetNumberAsInt();
      check_index(index, model_.nodes.size(), path, "node");
      for (const Character::DeclaredBone& earlier : character.declared_humanoid) {
        if (earlier.bone == name) fail(where + " names bone '" + name + "' twice");
      }
      if (joint_of_node_[index] < 0) {
        warnings_.push_back(where + ": bone '" + name + "' is on " + node_label(index) +
                            ", which is not a joint of the skeleton; it is left out");
        continue;
      }
      character.declared_humanoid.push_back({name, joint_of_node_[index]});
    }
  }

  int node_count() const { return static_cast<int>(model_.nodes.size()); }

  std::string node_label(int node) const {
    std::string label = std::string("node ") + std::to_string(node);
    if (!model_.nodes[node].name.empty()) label += " '" + model_.nodes[node].name + "'";
    return label;
  }

  void check_required_extensions() const {
    for (const std::string& extension : model_.extensionsRequired) {
      if (extension == "KHR_draco_mesh_compression" || extension == "EXT_meshopt_compression") {
        fail("requires " + extension + ", compressed geometry this loader does not decode");
      }
    }
  }

  void check_index(int index, std::size_t size, const std::string& what, const std::string& kind) const {
    if (index < 0 || static_cast<std::size_t>(index) >= size) {
      fail(what + " refers to " + kind + " " + std::to_string(index) + ", but the file has " + std::to_string(size));
    }
  }

  void check_node_references() const {
    for (int node = 0; node < node_count(); ++node) {
      const tinygltf::Node& n = model_.nodes[node];
      for (int child : n.children) check_index(child, model_.nodes.size(), node_label(node) + " child", "node");
      if (n.mesh >= 0) check_index(n.mesh, model_.meshes.size(), node_label(node), "mesh");
      if (n.skin >= 0) check_index(n.skin, model_.skins.size(), node_label(node), "skin");
      if (n.skin >= 0 && n.mesh < 0) fail(node_label(node) + " has a skin but no mesh");
    }
    for (std::size_t skin = 0; skin < model_.skins.size(); ++skin) {
      const std::vector<int>& joints = model_.skins[skin].joints;
      if (joints.empty()) fail("skin " + std::to_string(skin) + " has no joints");
      for (int joint : joints) check_index(joint, model_.nodes.size(), "skin " + std::to_string(skin) + " joint", "node");
    }
  }

  // glTF nodes form a forest: each node has at most one parent and no node is its own ancestor.
  // order_ is a depth-first walk from the root nodes (children in listed order), so parents come
  // first; a node the walk never reaches hangs on a cycle.
  void build_hierarchy() {
    parent_.assign(node_count(), -1);
    std::vector<std::vector<int>> children(node_count());
    for (int node = 0; node < node_count(); ++node) {
      for (int child : model_.nodes[node].children) {
        if (child == node) fail(node_label(node) + " lists itself as a child: the node hierarchy has a cycle");
        if (parent_[child] >= 0) {
          fail(node_label(child) + " has two parents (" + node_label(parent_[child]) + " and " + node_label(node) + ")");
        }
        parent_[child] = node;
      }
      children[node] = model_.nodes[node].children;
    }
    HierarchyOrder walk = depth_first_order(parent_, children);
    if (walk.unreached >= 0) {
      fail("the node hierarchy has a cycle through " + node_label(walk.unreached) + " (it never reaches a root node)");
    }
    order_ = std::move(walk.order);
  }

  void check_finite(const std::vector<double>& values, std::size_t expected, const std::string& what) const {
    if (values.size() != expected) {
      fail(what + " has " + std::to_string(values.size()) + " numbers, expected " + std::to_string(expected));
    }
    for (double v : values) {
      if (!std::isfinite(v)) fail(what + " is not finite");
    }
  }

  // The node's matrix (column-major, as Eigen stores it; its last row made exactly 0 0 0 1) or
  // translation, rotation (as stored) and scale, every number checked.
  NodeTransform node_transform(int node) const {
    const tinygltf::Node& n = model_.nodes[node];
    const std::string label = node_label(node);
    NodeTransform transform;
    if (!n.matrix.empty()) {
      check_finite(n.matrix, 16, label + " matrix");
      Eigen::Matrix4d local = Eigen::Map<const Eigen::Matrix4d>(n.matrix.data());
      if ((local.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).cwiseAbs().maxCoeff() > 1e-6) {
        fail(label + " matrix is not affine (last row not 0 0 0 1)");
      }
      local.row(3) = Eigen::RowVector4d(0, 0, 0, 1);
      transform.matrix = local;
      return transform;
    }
    if (!n.rotation.empty()) {
      check_finite(n.rotation, 4, label + " rotation");
      // glTF stores x, y, z, w; Eigen's constructor takes w, x, y, z.
      transform.rotation = Eigen::Quaterniond(n.rotation[3], n.rotation[0], n.rotation[1], n.rotation[2]);
      if (transform.rotation.norm() < 1e-6) fail(label + " rotation quaternion has (near) zero length");
    }
    if (!n.scale.empty()) {
      check_finite(n.scale, 3, label + " scale");
      transform.scale = Eigen::Vector3d(n.scale[0], n.scale[1], n.scale[2]);
    }
    if (!n.translation.empty()) {
      check_finite(n.translation, 3, label + " translation");
      transform.translation = Eigen::Vector3d(n.translation[0], n.translation[1], n.translation[2]);
    }
    return transform;
  }

  void compute_world_matrices() {
    std::vector<Eigen::Matrix4d> local(node_count());
    for (int node : order_) local[node] = local_matrix(node_transform(node));
    world_matrices(parent_, order_, local, world_);
    for (int node : order_) {
      if (!world_[node].allFinite()) fail(node_label(node) + " world transform overflows");
    }
  }

  // The displayed scene: `scene`, else the first, else every root node.
  void mark_scene() {
    in_scene_.assign(node_count(), false);
    std::vector<int> roots;
    if (model_.scenes.empty()) {
      for (int node = 0; node < node_count(); ++node) {
        if (parent_[node] < 0) roots.push_back(node);
      }
    } else {
      const int scene = model_.defaultScene >= 0 ? model_.defaultScene : 0;
      check_index(scene, model_.scenes.size(), "the default scene", "scene");
      for (int root : model_.scenes[scene].nodes) {
        check_index(root, model_.nodes.size(), "scene " + std::to_string(scene), "node");
        roots.push_back(root);
      }
    }
    // Parents come first in order_, so one pass carries the mark down whole subtrees.
    for (int root : roots) in_scene_[root] = true;
    for (int node : order_) {
      if (parent_[node] >= 0 && in_scene_[parent_[node]]) in_scene_[node] = true;
    }
  }

  void select_skeleton_nodes() {
    is_skin_joint_.assign(node_count(), false);
    for (const tinygltf::Skin& skin : model_.skins) {
      for (int joint : skin.joints) is_skin_joint_[joint] = true;
    }
    needed_ = is_skin_joint_;
    for (int node = 0; node < node_count(); ++node) {
      if (in_scene_[node] && model_.nodes[node].mesh >= 0 && model_.nodes[node].skin < 0) needed_[node] = true;
    }
    // A node is in the skeleton when it, or a node below it, is needed.
    in_skeleton_ = needed_;
    for (auto it = order_.rbegin(); it != order_.rend(); ++it) {
      if (in_skeleton_[*it] && parent_[*it] >= 0) in_skeleton_[parent_[*it]] = true;
    }
    // Fold the unneeded single chain at the top of each tree into the first node that is needed
    // or branches.
    for (int node = 0; node < node_count(); ++node) {
      if (parent_[node] >= 0 || !in_skeleton_[node]) continue;
      int top = node;
      while (!needed_[top]) {
        int only_child = -1, skeleton_children = 0;
        for (int child : model_.nodes[top].children) {
          if (in_skeleton_[child]) {
            only_child = child;
            ++skeleton_children;
          }
        }
        if (skeleton_children != 1) break;
        in_skeleton_[top] = false;
        top = only_child;
      }
    }
  }

  // Names: the node's name, "joint_<node>" when it has none, "_node<node>" appended when taken.
  // Skin joints choose first.
  std::vector<std::string> joint_names(const std::vector<int>& nodes) const {
    std::vector<std::string> names(nodes.size());
    std::set<std::string> taken;
    for (bool skin_joints : {true, false}) {
      std::vector<std::size_t> picks;
      for (std::size_t j = 0; j < nodes.size(); ++j) {
        if (is_skin_joint_[nodes[j]] == skin_joints) picks.push_back(j);
      }
      std::sort(picks.begin(), picks.end(), [&](std::size_t a, std::size_t b) { return nodes[a] < nodes[b]; });
      for (std::size_t j : picks) {
        const int node = nodes[j];
        const std::string own =
            model_.nodes[node].name.empty() ? std::string("joint_") + std::to_string(node) : model_.nodes[node].name;
        std::string name = own;
        for (int attempt = 0; taken.count(name); ++attempt) {
          name = own + "_node" + std::to_string(node);
          if (attempt > 0) name += std::string("_") + std::to_string(attempt);
        }
        taken.insert(name);
        names[j] = name;
      }
    }
    return names;
  }

  // G = [A | t]; R is the rotation closest to A (the polar factor U V^T, with the last column
  // of U flipped when A mirrors) and s = cbrt(|det A|).
  void decompose_world(int node) {
    const Eigen::Matrix3d linear = world_[node].topLeftCorner<3, 3>();
    const Eigen::JacobiSVD<Eigen::Matrix3d> svd(linear, Eigen::ComputeFullU | Eigen::ComputeFullV);
    Eigen::Matrix3d u = svd.matrixU();
    const Eigen::Matrix3d v = svd.matrixV();
    if ((u * v.transpose()).determinant() < 0) u.col(2) = -u.col(2);
    frame_[node].rotation = u * v.transpose();
    frame_[node].translation = world_[node].topRightCorner<3, 1>();
    scale_[node] = std::cbrt(std::abs(linear.determinant()));

    // Joints below this node move rigidly with it, which matches glTF only for a uniform scale.
    bool has_joints_below = false;
    for (int child : model_.nodes[node].children) has_joints_below = has_joints_below || in_skeleton_[child];
    if (!has_joints_below) return;
    const Eigen::Vector3d sigma = svd.singularValues();  // descending
    std::ostringstream values;
    values << sigma(0) << ", " << sigma(1) << ", " << sigma(2);
    if (!(sigma(2) > 0) || sigma(0) / sigma(2) - 1 > kMaxAnisotropy) {
      fail(node_label(node) + " has joints below it, but its world transform scales unevenly (singular values " +
           values.str() + "); a rigid skeleton cannot carry that");
    }
    if (linear.determinant() < 0) {
      fail(node_label(node) + " has joints below it, but its world transform mirrors (negative scale)");
    }
  }

  // Rest transforms: W(n) = C [R | t] for a root, W(parent)^-1 W(n) = [R_p^T R | R_p^T (t - t_p)]
  // below it (C cancels between parent and child).
  void build_skeleton(Character& character) {
    frame_.resize(node_count());
    scale_.assign(node_count(), 1.0);
    joint_of_node_.assign(node_count(), -1);
    std::vector<int> nodes;
    for (int node : order_) {
      if (!in_skeleton_[node]) continue;
      decompose_world(node);
      joint_of_node_[node] = static_cast<int>(nodes.size());
      nodes.push_back(node);
    }
    if (nodes.empty()) fail("has no skin and no mesh in its scene: there is no character to load");

    const Eigen::Matrix3d c = y_up_to_z_up();
    std::vector<int> parents;
    std::vector<Eigen::Vector3d> offsets;
    std::vector<Eigen::Quaterniond> rotations;
    for (int node : nodes) {
      const RigidFrame& own = frame_[node];
      const int parent = parent_[node] >= 0 ? joint_of_node_[parent_[node]] : -1;
      parents.push_back(parent);
      if (parent < 0) {
        offsets.push_back(c * own.translation);
        rotations.push_back(quaternion_from_matrix(c * own.rotation));
      } else {
        const RigidFrame& up = frame_[parent_[node]];
        offsets.push_back(up.rotation.transpose() * (own.translation - up.translation));
        rotations.push_back(quaternion_from_matrix(up.rotation.transpose() * own.rotation));
      }
      character.source_node_of_joint.push_back(node);
      character.source_scale_of_joint.push_back(scale_[node]);
    }
    try {
      character.skeleton = Skeleton(joint_names(nodes), std::move(parents), std::move(offsets), std::move(rotations));
    } catch (const std::invalid_argument& e) {
      fail(std::string("skeleton: ") + e.what());
    }
  }

  // Reads accessor `index` as numbers, checking its type, component type, every byte range and
  // its sparse substitutions.
  Elements read_accessor(int index, const std::string& what, int type, std::initializer_list<int> component_types) {
    check_index(index, model_.accessors.size(), what, "accessor");
    const tinygltf::Accessor& accessor = model_.accessors[index];
    const std::string label = what + " (accessor " + std::to_string(index) + ")";
    if (accessor.type != type) fail(label + " is " + type_name(accessor.type) + ", expected " + type_name(type));
    if (std::find(component_types.begin(), component_types.end(), accessor.componentType) == component_types.end()) {
      std::string allowed;
      for (int t : component_types) allowed += (allowed.empty() ? "" : " or ") + component_name(t);
      fail(label + " has " + component_name(accessor.componentType) + " components, expected " + allowed);
    }
    if (accessor.count == 0) fail(label + " has no elements");
    const int components = component_count(type);
    const std::size_t element_size = std::size_t(components) * component_size(accessor.componentType);

    Elements elements;
    elements.count = accessor.count;
    elements.components = components;
    if (accessor.bufferView < 0) {
      charge_decoding(accessor, label, components);
      elements.values.assign(accessor.count * components, 0.0);
    } else {
      const auto [data, view_length] = buffer_view_bytes(accessor.bufferView, label);
      const std::size_t stride = model_.bufferViews[accessor.bufferView].byteStride == 0
                                     ? element_size
                                     : model_.bufferViews[accessor.bufferView].byteStride;
      if (stride < element_size) {
        fail(label + " elements are " + std::to_string(element_size) + " bytes but the buffer view's stride is " +
             std::to_string(stride));
      }
      // The last element ends at byteOffset + (count - 1) stride + element_size <= view length.
      if (!fits(accessor.byteOffset, element_size, view_length) ||
          accessor.count - 1 > (view_length - accessor.byteOffset - element_size) / stride) {
        fail(label + " reaches past the end of its buffer view (" + std::to_string(accessor.count) + " elements of " +
             std::to_string(element_size) + " bytes, stride " + std::to_string(stride) + ", offset " +
             std::to_string(accessor.byteOffset) + ", view length " + std::to_string(view_length) + ")");
      }
      charge_decoding(accessor, label, components);
      elements.values.resize(accessor.count * components);
      const int size = component_size(accessor.componentType);
      for (std::size_t e = 0; e < accessor.count; ++e) {
        const unsigned char* element = data + accessor.byteOffset + e * stride;
        for (int c = 0; c < components; ++c) {
          elements.values[e * components + c] = component_at(element + c * size, accessor.componentType, accessor.normalized);
        }
      }
    }
    if (accessor.sparse.isSparse) apply_sparse(accessor, label, element_size, elements);
    return elements;
  }

  // Takes the accessor's doubles from the decoding budget, or fails before they are allocated.
  void charge_decoding(const tinygltf::Accessor& accessor, const std::string& label, int components) {
    const std::uint64_t per_element = std::uint64_t(components) * sizeof(double);
    if (accessor.count <= decode_budget_left_ / per_element) {
      decode_budget_left_ -= accessor.count * per_element;
      return;
    }
    const bool representable = accessor.count <= std::numeric_limits<std::uint64_t>::max() / per_element;
    fail(label + (accessor.bufferView < 0 ? " has no buffer view and" : "") + " declares " +
         std::to_string(accessor.count) + " " + type_name(accessor.type) + " elements (" +
         (representable ? std::to_string(accessor.count * per_element) : "over 2^64") +
         " bytes as doubles): decoding its accessors would take more than " + std::to_string(decode_budget_) +
         " bytes, this file's budget (16 MiB + 64 per byte of the file and its external buffers)");
  }

  // Indices (vertex or joint) are plain integers; a normalised accessor would read them as fractions.
  void reject_normalized(int index, const std::string& what) const {
    check_index(index, model_.accessors.size(), what, "accessor");
    if (model_.accessors[index].normalized) {
      fail(what + " (accessor " + std::to_string(index) + ") is normalised, but holds indices");
    }
  }

  // Bytes of a buffer view after checking that it lies inside its buffer.
  std::pair<const unsigned char*, std::size_t> buffer_view_bytes(int view, const std::string& label) const {
    check_index(view, model_.bufferViews.size(), label, "buffer view");
    const tinygltf::BufferView& buffer_view = model_.bufferViews[view];
    check_index(buffer_view.buffer, model_.buffers.size(), label + " buffer view " + std::to_string(view), "buffer");
    const std::vector<unsigned char>& buffer = model_.buffers[buffer_view.buffer].data;
    if (!fits(buffer_view.byteOffset, buffer_view.byteLength, buffer.size())) {
      fail(label + ": buffer view " + std::to_string(view) + " (offset " + std::to_string(buffer_view.byteOffset) +
           ", length " + std::to_string(buffer_view.byteLength) + ") lies outside buffer " +
           std::to_string(buffer_view.buffer) + " of " + std::to_string(buffer.size()) + " bytes");
    }
    return {buffer.data() + buffer_view.byteOffset, buffer_view.byteLength};
  }

  // Sparse storage: `count` element indices (unsigned integers) and as many tightly packed
  // elements that replace the dense (or zero) ones at those indices.
  void apply_sparse(const tinygltf::Accessor& accessor, const std::string& label, std::size_t element_size,
                    Elements& elements) const {
    const auto& sparse = accessor.sparse;
    if (sparse.count < 1 || static_cast<std::size_t>(sparse.count) > accessor.count) {
      fail(label + " has a sparse count of " + std::to_string(sparse.count) + " for " + std::to_string(accessor.count) +
           " elements");
    }
    const std::size_t count = static_cast<std::size_t>(sparse.count);
    const int index_type = sparse.indices.componentType;
    if (index_type != TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE && index_type != TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT &&
        index_type != TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT) {
      fail(label + " sparse indices have " + component_name(index_type) + " components, expected an unsigned integer");
    }
    if (sparse.indices.byteOffset < 0 || sparse.values.byteOffset < 0) fail(label + " has a negative sparse byte offset");
    const auto [index_data, index_length] = buffer_view_bytes(sparse.indices.bufferView, label + " sparse indices");
    const auto [value_data, value_length] = buffer_view_bytes(sparse.values.bufferView, label + " sparse values");
    const std::size_t index_size = component_size(index_type);
    if (!fits(sparse.indices.byteOffset, count * index_size, index_length)) {
      fail(label + " sparse indices reach past the end of their buffer view");
    }
    if (!fits(sparse.values.byteOffset, count * element_size, value_length)) {
      fail(label + " sparse values reach past the end of their buffer view");
    }
    const int size = component_size(accessor.componentType);
    for (std::size_t k = 0; k < count; ++k) {
      const double index = component_at(index_data + sparse.indices.byteOffset + k * index_size, index_type, false);
      if (index >= static_cast<double>(accessor.count)) {
        fail(label + " sparse index " + std::to_string(static_cast<std::uint64_t>(index)) + " is past its " +
             std::to_string(accessor.count) + " elements");
      }
      const std::size_t element = static_cast<std::size_t>(index);
      const unsigned char* value = value_data + sparse.values.byteOffset + k * element_size;
      for (int c = 0; c < elements.components; ++c) {
        elements.values[element * elements.components + c] =
            component_at(value + c * size, accessor.componentType, accessor.normalized);
      }
    }
  }

  // inverse_bind_k = [R | t]^-1 G(joint_k) IBM_k (see the header), G the rest (bind) world.
  SkinBinding bind_skin(int skin_index) {
    const tinygltf::Skin& skin = model_.skins[skin_index];
    SkinBinding binding;
    for (std::size_t k = 0; k < skin.joints.size(); ++k) {
      const int node = skin.joints[k];
      binding.joints.push_back(joint_of_node_[node]);
      binding.inverse_bind.push_back(frame_[node].inverse() * world_[node] * skin_ibms_[skin_index][k]);
    }
    return binding;
  }

  std::string skin_label(int skin) const {
    const std::string& name = model_.skins[skin].name;
    return "skin " + std::to_string(skin) + (name.empty() ? "" : " '" + name + "'");
  }

  // Every skin's inverse bind matrices (the identity where a skin has none), checked: finite,
  // affine, and invertible, since the bind pose is their inverse.
  void read_inverse_binds() {
    skin_ibms_.assign(model_.skins.size(), {});
    for (std::size_t s = 0; s < model_.skins.size(); ++s) {
      const tinygltf::Skin& skin = model_.skins[s];
      std::vector<Eigen::Matrix4d>& out = skin_ibms_[s];
      out.assign(skin.joints.size(), Eigen::Matrix4d::Identity());
      if (skin.inverseBindMatrices < 0) continue;
      const std::string label = "skin " + std::to_string(s) + " inverse bind matrices";
      const Elements matrices =
          read_accessor(skin.inverseBindMatrices, label, TINYGLTF_TYPE_MAT4, {TINYGLTF_COMPONENT_TYPE_FLOAT});
      if (matrices.count < skin.joints.size()) {
        fail(label + " hold " + std::to_string(matrices.count) + " matrices for " + std::to_string(skin.joints.size()) +
             " joints");
      }
      for (std::size_t k = 0; k < skin.joints.size(); ++k) {
        const std::string which = skin_label(int(s)) + " inverse bind matrix " + std::to_string(k) + " (joint " +
                                  node_label(skin.joints[k]) + ")";
        Eigen::Matrix4d m = Eigen::Map<const Eigen::Matrix4d>(&matrices.values[k * 16]);
        if (!m.allFinite()) fail(which + " is not finite");
        if ((m.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).cwiseAbs().maxCoeff() > 1e-6) {
          fail(which + " is not affine (last row not 0 0 0 1)");
        }
        m.row(3) = Eigen::RowVector4d(0, 0, 0, 1);
        const Eigen::Vector3d sigma = Eigen::JacobiSVD<Eigen::Matrix3d>(m.topLeftCorner<3, 3>()).singularValues();
        if (!(sigma(2) > kMinIbmConditioning * sigma(0))) {
          std::ostringstream values;
          values << sigma(0) << ", " << sigma(1) << ", " << sigma(2);
          fail(which + " is singular (singular values " + values.str() + "): it defines no bind pose");
        }
        out[k] = m;
      }
    }
  }

  // The bind pose, as Blender's importer guesses the original one: a skin joint n whose parent p
  // also has an inverse bind matrix (or is the scene root, or the skin's `skeleton` node, or that
  // node's parent when it is itself a joint: the identity there) sits at
  //   Gb(n) = Gb(p) IBM_p IBM_n^-1,
  // since at bind every joint's G IBM is one matrix M; every other node keeps its local
  // transform, Gb(n) = Gb(p) L(n). A joint listed by several skins takes the last skin's matrix,
  // as Blender does. When a joint's rotation differs from the nodes' by more than
  // kBindAngleTolerance, the nodes hold another pose and the bind pose becomes the rest pose:
  // world_ is replaced by Gb. Positions alone are not compared: a node scale the inverse bind
  // matrices do not hold moves joints without posing them, and the rigid skeleton carries it.
  void adopt_bind_pose(Character& character) {
    const int n = node_count();
    std::vector<Eigen::Matrix4d> ibm(n, Eigen::Matrix4d::Identity());
    std::vector<bool> has_ibm(n, false), is_bound_joint(n, false);
    for (std::size_t s = 0; s < model_.skins.size(); ++s) {
      const tinygltf::Skin& skin = model_.skins[s];
      if (skin.inverseBindMatrices < 0) continue;
      if (skin.skeleton >= 0) {
        check_index(skin.skeleton, model_.nodes.size(), skin_label(int(s)) + " skeleton", "node");
        const bool listed = std::find(skin.joints.begin(), skin.joints.end(), skin.skeleton) != skin.joints.end();
        const int anchor = listed ? parent_[skin.skeleton] : skin.skeleton;
        if (anchor >= 0 && !has_ibm[anchor]) has_ibm[anchor] = true;  // identity: IBMs relative to it
      }
      for (std::size_t k = 0; k < skin.joints.size(); ++k) {
        ibm[skin.joints[k]] = skin_ibms_[s][k];
        has_ibm[skin.joints[k]] = is_bound_joint[skin.joints[k]] = true;
      }
    }
    std::vector<Eigen::Matrix4d> bind(n);
    for (int node : order_) {
      const int p = parent_[node];
      const Eigen::Matrix4d above = p < 0 ? Eigen::Matrix4d::Identity() : bind[p];
      if (is_bound_joint[node] && (p < 0 || has_ibm[p])) {
        bind[node] = above * uniform_part((p < 0 ? Eigen::Matrix4d::Identity() : ibm[p]) * ibm[node].inverse());
      } else {
        bind[node] = above * local_matrix(node_transform(node));
      }
      if (!bind[node].allFinite()) fail(node_label(node) + " bind pose transform (from the inverse bind matrices) overflows");
    }

    const auto rotation_of = [](const Eigen::Matrix4d& m) {
      const Eigen::JacobiSVD<Eigen::Matrix3d> svd(m.topLeftCorner<3, 3>(), Eigen::ComputeFullU | Eigen::ComputeFullV);
      Eigen::Matrix3d u = svd.matrixU();
      if ((u * svd.matrixV().transpose()).determinant() < 0) u.col(2) = -u.col(2);
      return Eigen::Matrix3d(u * svd.matrixV().transpose());
    };
    int differing = 0, compared = 0;
    double worst_distance = 0, worst_angle = 0;
    for (int node = 0; node < n; ++node) {
      if (!is_bound_joint[node] || !in_skeleton_[node]) continue;
      ++compared;
      const double distance = (bind[node].topRightCorner<3, 1>() - world_[node].topRightCorner<3, 1>()).norm();
      const double angle = Eigen::AngleAxisd(rotation_of(bind[node]).transpose() * rotation_of(world_[node])).angle();
      if (angle > kBindAngleTolerance) ++differing;
      worst_distance = std::max(worst_distance, distance);
      worst_angle = std::max(worst_angle, angle);
    }
    if (differing == 0) {
      const bool any_ibm = std::any_of(model_.skins.begin(), model_.skins.end(),
                                       [](const tinygltf::Skin& skin) { return skin.inverseBindMatrices >= 0; });
      character.rest_pose_origin = any_ibm ? "node transforms (they hold the bind pose of the inverse bind matrices)"
                                           : "node transforms (no skin has inverse bind matrices)";
      return;
    }
    std::ostringstream origin;
    origin.precision(3);
    origin << "inverse bind matrices (the node transforms hold another pose: " << differing << " of " << compared
           << " skin joints differ, by up to " << worst_distance << " units and " << worst_angle * 180 / std::acos(-1.0)
           << " degrees)";
    character.rest_pose_origin = origin.str();
    world_ = std::move(bind);
    bind_pose_adopted_ = true;
  }

  // A bind local IBM_p IBM_n^-1 = [A | t] as [s R | t], R the rotation closest to A and
  // s = cbrt(det A): float32 matrices leave a shear and an uneven scale of about 1e-7 in the
  // product, which no node's translation, rotation and scale could hold (the animated GLB writes
  // these locals as T R S). The rest mesh, C Gb IBM v, then moves by that much (about 1e-7 of its
  // size) from M v. A mirroring local (det A < 0) is kept as it is.
  static Eigen::Matrix4d uniform_part(const Eigen::Matrix4d& local) {
    const Eigen::Matrix3d linear = local.topLeftCorner<3, 3>();
    const double det = linear.determinant();
    if (!(det > 0)) return local;
    const Eigen::JacobiSVD<Eigen::Matrix3d> svd(linear, Eigen::ComputeFullU | Eigen::ComputeFullV);
    Eigen::Matrix4d out = local;
    out.topLeftCorner<3, 3>() = std::cbrt(det) * (svd.matrixU() * svd.matrixV().transpose());
    return out;
  }

  // When the rest pose is the bind pose, each joint's local matrix there (glTF's frame), for
  // writers that put the rest pose on the file's nodes.
  void record_rest_locals(Character& character) const {
    if (!bind_pose_adopted_) return;
    for (int node : character.source_node_of_joint) {
      const int p = parent_[node];
      character.source_rest_local_of_joint.push_back(p < 0 ? world_[node] : Eigen::Matrix4d(world_[p].inverse() * world_[node]));
    }
  }

  void add_node_meshes(int node, Character& character) {
    const tinygltf::Node& n = model_.nodes[node];
    const tinygltf::Mesh& mesh = model_.meshes[n.mesh];
    const std::string base =
        !mesh.name.empty() ? mesh.name : !n.name.empty() ? n.name : "mesh_" + std::to_string(n.mesh);
    for (std::size_t k = 0; k < mesh.primitives.size(); ++k) {
      const tinygltf::Primitive& primitive = mesh.primitives[k];
      CharacterMesh out;
      out.name = mesh.primitives.size() > 1 ? base + "#" + std::to_string(k) : base;
      const std::string label = "mesh " + std::to_string(n.mesh) + " " + in_quotes(out.name) + " on " + node_label(node);
      if (primitive.mode != TINYGLTF_MODE_TRIANGLES) {
        warnings_.push_back(label + ": primitive mode " + std::to_string(primitive.mode) +
                            " skipped (only TRIANGLES are loaded)");
        continue;
      }
      const auto position = primitive.attributes.find("POSITION");
      if (position == primitive.attributes.end()) {
        warnings_.push_back(label + ": primitive without POSITION skipped");
        continue;
      }
      read_positions(position->second, primitive, n, mesh, label, out);
      read_triangles(primitive, label, out);
      if (n.skin >= 0) {
        out.skin_joints = bindings_[n.skin].joints;
        out.inverse_bind = bindings_[n.skin].inverse_bind;
        read_influences(primitive, label, out);
      } else {
        out.skin_joints = {joint_of_node_[node]};
        out.inverse_bind = {frame_[node].inverse() * world_[node]};
        out.influence_slots.assign(out.positions.size(), {0, 0, 0, 0});
        out.influence_weights.assign(out.positions.size(), {1.0f, 0.0f, 0.0f, 0.0f});
      }
      character.meshes.push_back(std::move(out));
    }
  }

  // POSITION plus the morph targets' POSITION displacements at their default weights.
  void read_positions(int accessor, const tinygltf::Primitive& primitive, const tinygltf::Node& node,
                      const tinygltf::Mesh& mesh, const std::string& label, CharacterMesh& out) {
    const std::initializer_list<int> types = {TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_COMPONENT_TYPE_BYTE,
                                              TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE, TINYGLTF_COMPONENT_TYPE_SHORT,
                                              TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT};
    Elements positions = read_accessor(accessor, label + " POSITION", TINYGLTF_TYPE_VEC3, types);
    if (!primitive.targets.empty()) {
      const std::vector<double>& weights = !node.weights.empty() ? node.weights : mesh.weights;
      if (!weights.empty() && weights.size() != primitive.targets.size()) {
        fail(label + " has " + std::to_string(primitive.targets.size()) + " morph targets but " +
             std::to_string(weights.size()) + " default weights");
      }
      bool baked = false;
      for (std::size_t t = 0; t < primitive.targets.size() && !weights.empty(); ++t) {
        const auto displacement = primitive.targets[t].find("POSITION");
        if (displacement == primitive.targets[t].end() || weights[t] == 0.0) continue;
        if (!std::isfinite(weights[t])) fail(label + " morph target " + std::to_string(t) + " weight is not finite");
        baked = true;
        const Elements delta = read_accessor(displacement->second, label + " morph target " + std::to_string(t) +
                                                                       " POSITION", TINYGLTF_TYPE_VEC3, types);
        if (delta.count != positions.count) {
          fail(label + " morph target " + std::to_string(t) + " has " + std::to_string(delta.count) + " positions for " +
               std::to_string(positions.count) + " vertices");
        }
        for (std::size_t i = 0; i < positions.values.size(); ++i) positions.values[i] += weights[t] * delta.values[i];
      }
      warnings_.push_back(label + ": " + std::to_string(primitive.targets.size()) + " morph targets " +
                          (baked ? "baked in at their non-zero default weights and not animated"
                                 : "not loaded (their default weights are zero: the base shape is the rest shape)"));
    }
    out.positions.resize(positions.count);
    for (std::size_t v = 0; v < positions.count; ++v) {
      const Eigen::Vector3d p(positions.at(v, 0), positions.at(v, 1), positions.at(v, 2));
      if (!p.allFinite()) fail(label + " POSITION " + std::to_string(v) + " is not finite");
      out.positions[v] = p.cast<float>();
    }
  }

  void read_triangles(const tinygltf::Primitive& primitive, const std::string& label, CharacterMesh& out) {
    const std::size_t vertex_count = out.positions.size();
    if (primitive.indices < 0) {
      if (vertex_count % 3 != 0) {
        fail(label + " is an unindexed triangle list of " + std::to_string(vertex_count) +
             " vertices, not a multiple of 3");
      }
      out.triangles.resize(vertex_count);
      for (std::size_t v = 0; v < vertex_count; ++v) out.triangles[v] = static_cast<std::uint32_t>(v);
      return;
    }
    reject_normalized(primitive.indices, label + " indices");
    const Elements indices = read_accessor(primitive.indices, label + " indices", TINYGLTF_TYPE_SCALAR,
                                           {TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE, TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT,
                                            TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT});
    if (indices.count % 3 != 0) {
      fail(label + " has " + std::to_string(indices.count) + " triangle indices, not a multiple of 3");
    }
    out.triangles.resize(indices.count);
    for (std::size_t i = 0; i < indices.count; ++i) {
      const double index = indices.values[i];
      if (index >= static_cast<double>(vertex_count)) {
        fail(label + " index " + std::to_string(static_cast<std::uint64_t>(index)) + " is past its " +
             std::to_string(vertex_count) + " vertices");
      }
      out.triangles[i] = static_cast<std::uint32_t>(index);
    }
  }

  // Every JOINTS_n / WEIGHTS_n pair; the four largest weights kept and divided by their sum.
  void read_influences(const tinygltf::Primitive& primitive, const std::string& label, CharacterMesh& out) {
    const std::size_t vertex_count = out.positions.size();
    const std::size_t slot_count = out.skin_joints.size();
    std::vector<Elements> joints, weights;
    for (int set = 0;; ++set) {
      const std::string joints_name = "JOINTS_" + std::to_string(set), weights_name = "WEIGHTS_" + std::to_string(set);
      const auto joints_at = primitive.attributes.find(joints_name);
      const auto weights_at = primitive.attributes.find(weights_name);
      if (joints_at == primitive.attributes.end() && weights_at == primitive.attributes.end()) break;
      if (joints_at == primitive.attributes.end() || weights_at == primitive.attributes.end()) {
        fail(label + " has only one of " + joints_name + " and " + weights_name);
      }
      reject_normalized(joints_at->second, label + " " + joints_name);
      joints.push_back(read_accessor(joints_at->second, label + " " + joints_name, TINYGLTF_TYPE_VEC4,
                                     {TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE, TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT}));
      weights.push_back(read_accessor(weights_at->second, label + " " + weights_name, TINYGLTF_TYPE_VEC4,
                                      {TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE,
                                       TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT}));
      if (joints.back().count != vertex_count || weights.back().count != vertex_count) {
        fail(label + " " + joints_name + "/" + weights_name + " have " + std::to_string(joints.back().count) + "/" +
             std::to_string(weights.back().count) + " elements for " + std::to_string(vertex_count) + " vertices");
      }
    }
    if (joints.empty()) fail(label + " is on a skinned node but has no JOINTS_0/WEIGHTS_0");

    out.influence_slots.resize(vertex_count);
    out.influence_weights.resize(vertex_count);
    std::size_t truncated = 0, weightless = 0;
    std::vector<std::pair<double, std::uint16_t>> candidates;  // (weight, slot)
    for (std::size_t v = 0; v < vertex_count; ++v) {
      candidates.clear();
      for (std::size_t set = 0; set < joints.size(); ++set) {
        for (int i = 0; i < 4; ++i) {
          const double slot = joints[set].at(v, i), weight = weights[set].at(v, i);
          if (slot >= static_cast<double>(slot_count)) {
            fail(label + " vertex " + std::to_string(v) + " uses joint slot " + std::to_string(int(slot)) +
                 " of a skin with " + std::to_string(slot_count) + " joints");
          }
          if (!(weight >= 0) || !std::isfinite(weight)) {
            fail(label + " vertex " + std::to_string(v) + " has a negative or non-finite weight");
          }
          candidates.emplace_back(weight, static_cast<std::uint16_t>(slot));
        }
      }
      const std::uint16_t first_listed = candidates.front().second;
      if (candidates.size() > 4) {
        std::stable_sort(candidates.begin(), candidates.end(),
                         [](const auto& a, const auto& b) { return a.first > b.first; });
        if (candidates[4].first > 0) ++truncated;
        candidates.resize(4);
      }
      double sum = 0;
      for (const auto& candidate : candidates) sum += candidate.first;
      if (sum > 0) {
        for (int i = 0; i < 4; ++i) {
          out.influence_slots[v][i] = candidates[i].second;
          out.influence_weights[v][i] = static_cast<float>(candidates[i].first / sum);
        }
      } else {
        ++weightless;
        out.influence_slots[v] = {first_listed, 0, 0, 0};
        out.influence_weights[v] = {1.0f, 0.0f, 0.0f, 0.0f};
      }
    }
    if (truncated > 0) {
      warnings_.push_back(label + ": " + std::to_string(truncated) +
                          " vertices have more than 4 non-zero weights; the 4 largest are kept and renormalised");
    }
    if (weightless > 0) {
      warnings_.push_back(label + ": " + std::to_string(weightless) +
                          " vertices have no weight; each follows its first listed joint rigidly");
    }
  }

  std::string path_;
  tinygltf::Model model_;
  std::vector<std::string> warnings_;
  std::vector<int> parent_;  // per node, -1 for a root node
  std::vector<int> order_;   // nodes, parents first
  std::vector<Eigen::Matrix4d> world_;
  std::vector<bool> in_scene_, is_skin_joint_, needed_, in_skeleton_;
  std::vector<RigidFrame> frame_;
  std::vector<double> scale_;
  std::vector<int> joint_of_node_;
  std::vector<SkinBinding> bindings_;
  std::vector<std::vector<Eigen::Matrix4d>> skin_ibms_;  // per skin, per joint slot (identity when absent)
  bool bind_pose_adopted_ = false;                       // world_ holds the bind pose, not the nodes'
  const std::uint64_t decode_budget_;
  std::uint64_t decode_budget_left_;
};

}  // namespace

// Tracks, for the outermost kShownPathComponents open arrays and objects, the member being read
// (an object's last key as written, an array's element index), for the message.
void check_gltf_json_depth(const std::string& path, std::string_view json) {
  struct Level {
    bool object = false;
    bool expecting_key = false;
    std::string key;
    std::size_t index = 0;
  };
  constexpr std::size_t kMaxShownKey = 64;
  std::vector<Level> shown;  // levels 1 .. min(depth, kShownPathComponents)
  std::size_t depth = 0;
  bool in_string = false, escaped = false, string_is_key = false;
  for (std::size_t at = 0; at < json.size(); ++at) {
    const char c = json[at];
    Level* current = depth >= 1 && depth <= shown.size() ? &shown[depth - 1] : nullptr;
    if (in_string) {
      if (!escaped && c == '"') {
        in_string = false;
      } else {
        escaped = !escaped && c == '\\';
        if (string_is_key && current->key.size() < kMaxShownKey) current->key += c;
      }
      continue;
    }
    switch (c) {
      case '"':
        in_string = true;
        string_is_key = current && current->object && current->expecting_key;
        if (string_is_key) {
          current->key.clear();
          current->expecting_key = false;
        }
        break;
      case '[':
      case '{':
        if (++depth > std::size_t(kMaxGltfJsonDepth)) {
          std::string where;
          for (const Level& level : shown) where += level.object ? (where.empty() ? "" : ".") + level.key
                                                                 : "[" + std::to_string(level.index) + "]";
          if (depth - 1 > shown.size()) where += "...";
          throw InputError(path, "JSON nests arrays and objects deeper than " + std::to_string(kMaxGltfJsonDepth) +
                                     " levels at " + where + " (byte " + std::to_string(at) +
                                     "); real glTF files need fewer than 20");
        }
        if (depth <= kShownPathComponents) shown.push_back({c == '{', c == '{', "", 0});
        break;
      case ']':
      case '}':
        if (depth == 0) break;  // unbalanced: the parser will say so
        if (depth <= shown.size()) shown.pop_back();
        --depth;
        break;
      case ',':
        if (current && current->object) current->expecting_key = true;
        if (current && !current->object) ++current->index;
        break;
      default:
        break;
    }
  }
}

std::uint64_t gltf_decode_budget(std::uint64_t input_bytes) {
  const std::uint64_t most = (std::numeric_limits<std::uint64_t>::max() - kDecodeBudgetFloor) / kDecodeBudgetPerInputByte;
  return kDecodeBudgetFloor + kDecodeBudgetPerInputByte * std::min(input_bytes, most);
}

Character load_character(const std::string& path) {
  std::vector<std::string> warnings;
  const std::vector<unsigned char> bytes = read_whole_file(path);
  tinygltf::Model model = parse_gltf(path, bytes, warnings);
  // Input: the file and the external buffers it names (a data URI's bytes are in the file).
  std::uint64_t input_bytes = bytes.size();
  for (const tinygltf::Buffer& buffer : model.buffers) {
    if (!buffer.uri.empty() && buffer.uri.rfind("data:", 0) != 0) input_bytes += buffer.data.size();
  }
  return CharacterReader(path, std::move(model), std::move(warnings), gltf_decode_budget(input_bytes)).read();
}

GltfFileSummary summarize_gltf_file(const std::string& path) {
  std::vector<std::string> warnings;
  const std::vector<unsigned char> bytes = read_whole_file(path);
  tinygltf::Model model = parse_gltf(path, bytes, warnings);
  std::uint64_t input_bytes = bytes.size();
  for (const tinygltf::Buffer& buffer : model.buffers) {
    if (!buffer.uri.empty() && buffer.uri.rfind("data:", 0) != 0) input_bytes += buffer.data.size();
  }
  return CharacterReader(path, std::move(model), std::move(warnings), gltf_decode_budget(input_bytes)).summarize();
}

NodeAnimation load_gltf_animation(const std::string& path, const std::string& name) {
  std::vector<std::string> warnings;
  const std::vector<unsigned char> bytes = read_whole_file(path);
  tinygltf::Model model = parse_gltf(path, bytes, warnings);
  std::uint64_t input_bytes = bytes.size();
  for (const tinygltf::Buffer& buffer : model.buffers) {
    if (!buffer.uri.empty() && buffer.uri.rfind("data:", 0) != 0) input_bytes += buffer.data.size();
  }
  return CharacterReader(path, std::move(model), std::move(warnings), gltf_decode_budget(input_bytes)).read_animation(name);
}

}  // namespace odyssey::io
