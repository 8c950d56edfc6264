#include "mocap_io/gltf_export.h"

#include <tiny_gltf.h>

#include <Eigen/SVD>
#include <algorithm>
#include <array>
#include <bit>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>

#include "mocap_io/gltf_character.h"
#include "mocap_io/input_error.h"
#include "mocap_io/output_file.h"
#include "skeleton/node_transform.h"
#include "skeleton/rotation.h"

namespace odyssey::io {
namespace {

static_assert(std::endian::native == std::endian::little,
              "glTF buffers are little-endian and are written from memory as they are");

// The loader's limit on uneven scale above joints (gltf_character.cpp): the same bound applies
// to the folded transform above a root joint, which the animation must rotate under.
constexpr double kMaxAnisotropy = 1e-3;
// A joint written as a matrix must be T R S: its linear part's columns orthogonal to this
// (cosine of the angle between columns); exporters' float noise is around 1e-7.
constexpr double kMaxShear = 1e-4;
// The character's rest joint positions must match the file's to this, relative to its size:
// both come from the same doubles, so only a different file can miss it.
constexpr double kRestMatchTolerance = 1e-6;
// The exported camera's near plane, metres (see the header).
constexpr double kCameraNear = 0.01;
constexpr std::uint32_t kGlbMagic = 0x46546C67;      // "glTF"
constexpr std::uint32_t kGlbJsonChunk = 0x4E4F534A;  // "JSON"
// GLB lengths are 32-bit; leave room for the header and the JSON chunk.
constexpr std::uint64_t kMaxGlbBytes = std::numeric_limits<std::uint32_t>::max();

std::string node_label(const tinygltf::Model& model, int node) {
  std::string label = "node " + std::to_string(node);
  if (!model.nodes[node].name.empty()) label += " '" + model.nodes[node].name + "'";
  return label;
}

std::uint32_t u32_at(const std::vector<unsigned char>& bytes, std::size_t at) {
  std::uint32_t value;
  std::memcpy(&value, bytes.data() + at, 4);
  return value;
}

// [offset, offset + length) inside [0, size), without overflow.
bool fits(std::uint64_t offset, std::uint64_t length, std::uint64_t size) {
  return offset <= size && length <= size - offset;
}

// The GLB container's declared lengths (header, JSON chunk, optional BIN chunk) checked before
// tinygltf, which trusts them; returns the declared total length.
std::uint32_t checked_glb_length(const std::string& path, const std::vector<unsigned char>& bytes) {
  if (bytes.size() < 20) throw InputError(path, "truncated GLB: shorter than its headers");
  const std::uint32_t length = u32_at(bytes, 8), json_length = u32_at(bytes, 12);
  if (u32_at(bytes, 4) != 2) throw InputError(path, "GLB version " + std::to_string(u32_at(bytes, 4)) + "; only 2 is read");
  if (length > bytes.size()) throw InputError(path, "truncated GLB: the header declares more bytes than the file has");
  if (u32_at(bytes, 16) != kGlbJsonChunk) throw InputError(path, "GLB's first chunk is not JSON");
  const std::uint64_t json_end = 20 + std::uint64_t(json_length);
  if (json_end > length) throw InputError(path, "truncated GLB: the JSON chunk runs past the declared length");
  if (json_end < length &&
      (json_end + 8 > length || !fits(json_end + 8, u32_at(bytes, static_cast<std::size_t>(json_end)), length))) {
    throw InputError(path, "truncated GLB: the binary chunk runs past the declared length");
  }
  return length;
}

// tinygltf hands every image's encoded bytes (from a buffer view, a data URI or a file) to the
// image loader; they are kept, undecoded, per image index so external images can be embedded.
bool keep_image_bytes(tinygltf::Image*, const int index, std::string*, std::string*, int, int,
                      const unsigned char* bytes, int size, void* user_data) {
  auto& images = *static_cast<std::vector<std::vector<unsigned char>>*>(user_data);
  if (index < 0) return false;
  if (static_cast<std::size_t>(index) >= images.size()) images.resize(std::size_t(index) + 1);
  images[index].assign(bytes, bytes + std::max(size, 0));
  return true;
}

struct SourceFile {
  tinygltf::Model model;
  std::vector<std::vector<unsigned char>> image_bytes;  // per image index; empty when unread
  std::uint64_t input_bytes = 0;                        // the file's and its external buffers'
};

SourceFile read_source(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, "cannot be opened");
  std::vector<unsigned char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) throw InputError(path, "could not be read to the end");
  if (bytes.size() > kMaxGlbBytes) throw InputError(path, "is 4 GiB or larger");
  const bool binary = bytes.size() >= 4 && u32_at(bytes, 0) == kGlbMagic;
  const std::uint32_t length = binary ? checked_glb_length(path, bytes) : static_cast<std::uint32_t>(bytes.size());
  const char* text = reinterpret_cast<const char*>(bytes.data());
  check_gltf_json_depth(path, binary ? std::string_view(text + 20, u32_at(bytes, 12)) : std::string_view(text, length));
  const std::string base_dir = std::filesystem::path(path).parent_path().string();

  SourceFile source;
  tinygltf::TinyGLTF parser;
  parser.SetImageLoader(keep_image_bytes, &source.image_bytes);
  std::string error, warning;
  bool parsed = false;
  try {
    parsed = binary ? parser.LoadBinaryFromMemory(&source.model, &error, &warning, bytes.data(), length, base_dir)
                    : parser.LoadASCIIFromString(&source.model, &error, &warning,
                                                 reinterpret_cast<const char*>(bytes.data()), length, base_dir);
  } catch (const std::exception& e) {
    throw InputError(path, std::string("not a readable glTF file: ") + e.what());
  }
  if (!parsed) throw InputError(path, "not a readable glTF file: " + (error.empty() ? warning : error));
  source.input_bytes = bytes.size();
  for (const tinygltf::Buffer& buffer : source.model.buffers) {
    if (!buffer.uri.empty() && buffer.uri.rfind("data:", 0) != 0) source.input_bytes += buffer.data.size();
  }
  return source;
}

// The MIME type glTF allows for an embedded image, from its magic bytes (PNG and JPEG in core
// glTF, KTX2 and WebP through their extensions); empty when the bytes are none of them.
std::string image_mime_type(const std::vector<unsigned char>& bytes) {
  const auto starts_with = [&](std::initializer_list<unsigned char> magic, std::size_t at = 0) {
    return bytes.size() >= at + magic.size() && std::equal(magic.begin(), magic.end(), bytes.begin() + at);
  };
  if (starts_with({0x89, 'P', 'N', 'G', 0x0D, 0x0A, 0x1A, 0x0A})) return "image/png";
  if (starts_with({0xFF, 0xD8, 0xFF})) return "image/jpeg";
  if (starts_with({0xAB, 'K', 'T', 'X', ' ', '2', '0', 0xBB})) return "image/ktx2";
  if (starts_with({'R', 'I', 'F', 'F'}) && starts_with({'W', 'E', 'B', 'P'}, 8)) return "image/webp";
  return "";
}

// One stored component as a number; glTF's normalised integers map to [0, 1] (unsigned, c / max)
// or [-1, 1] (signed, max(c / max, -1)).
double component_at(const unsigned char* at, int component_type, bool normalized) {
  const auto read = [at](auto value) {
    std::memcpy(&value, at, sizeof value);
    return value;
  };
  switch (component_type) {
    case TINYGLTF_COMPONENT_TYPE_BYTE:
      return normalized ? std::max(read(std::int8_t()) / 127.0, -1.0) : read(std::int8_t());
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE:
      return normalized ? read(std::uint8_t()) / 255.0 : read(std::uint8_t());
    case TINYGLTF_COMPONENT_TYPE_SHORT:
      return normalized ? std::max(read(std::int16_t()) / 32767.0, -1.0) : read(std::int16_t());
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT:
      return normalized ? read(std::uint16_t()) / 65535.0 : read(std::uint16_t());
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT:
      return normalized ? read(std::uint32_t()) / 4294967295.0 : read(std::uint32_t());
    default:  // float, the only other component type the callers accept
      return read(float());
  }
}

// glTF quaternions are stored x, y, z, w; Eigen's constructor takes w, x, y, z.
Eigen::Quaterniond quaternion_of(const std::vector<double>& xyzw) {
  return Eigen::Quaterniond(xyzw[3], xyzw[0], xyzw[1], xyzw[2]);
}

// The rotation closest to a 3x3 linear part (U V^T from its SVD, kept proper) and the ratio - 1
// of its largest to smallest singular value (infinite when singular).
std::pair<Eigen::Matrix3d, double> polar_rotation(const Eigen::Matrix3d& linear) {
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(linear, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d u = svd.matrixU();
  if ((u * svd.matrixV().transpose()).determinant() < 0) u.col(2) = -u.col(2);
  const Eigen::Vector3d sigma = svd.singularValues();
  const double anisotropy = sigma(2) > 0 ? sigma(0) / sigma(2) - 1 : std::numeric_limits<double>::infinity();
  return {u * svd.matrixV().transpose(), anisotropy};
}

// Per joint, the affine maps that turn a clip frame's local rotation Q and offset o into the
// node's animated rotation and translation (see the header):
//   r' = left * Q * right,   u' = offset_linear * o + offset_shift.
struct ChannelMap {
  int node = -1;
  Eigen::Quaterniond left = Eigen::Quaterniond::Identity();
  Eigen::Quaterniond right = Eigen::Quaterniond::Identity();
  Eigen::Quaterniond node_rest = Eigen::Quaterniond::Identity();
  Eigen::Matrix3d offset_linear = Eigen::Matrix3d::Identity();
  Eigen::Vector3d offset_shift = Eigen::Vector3d::Zero();
};

class AnimatedGlbBuilder {
 public:
  AnimatedGlbBuilder(std::string path, const Character& character, const Clip& clip, const GlbExportOptions& options)
      : path_(std::move(path)), character_(character), clip_(clip), options_(options),
        rest_world_(character.skeleton.rest_world()) {
    SourceFile source = read_source(path_);
    model_ = std::move(source.model);
    image_bytes_ = std::move(source.image_bytes);
    decode_budget_ = decode_budget_left_ = gltf_decode_budget(source.input_bytes);
  }

  std::string build() {
    reject_unrenumberable_extensions();
    put_rest_pose_on_nodes();
    compute_world_matrices();
    check_character_matches_file();
    staging_buffer_ = static_cast<int>(model_.buffers.size());
    model_.buffers.emplace_back();
    model_.animations.clear();
    add_animation();
    rewrite_weights();
    embed_images();
    drop_unused_and_repack_buffers();
    refresh_declared_bounds();
    model_.asset.generator = "odyssey animated GLB writer";

    std::ostringstream glb;
    tinygltf::TinyGLTF writer;
    if (!writer.WriteGltfSceneToStream(&model_, glb, false, true)) fail("tinygltf could not serialise the animated GLB");
    std::string bytes = std::move(glb).str();
    if (!model_.cameras.empty()) bytes = without_zero_zfar(bytes);
    if (bytes.size() > kMaxGlbBytes) throw InputError(path_, "the animated GLB would exceed GLB's 4 GiB limit");
    return bytes;
  }

 private:
  [[noreturn]] void fail(const std::string& problem) const { throw InputError(path_, problem); }

  // tinygltf writes a perspective camera's zfar even when it is 0, its value for "absent", but
  // glTF requires a present zfar to be positive and reads an absent one as an infinite
  // projection. The GLB's JSON chunk (bytes 20 on, after the 12-byte header and its own 8-byte
  // chunk header) is rewritten without those zeros, padded with spaces to 4 bytes as GLB
  // requires; the binary chunk after it is copied as it is.
  std::string without_zero_zfar(const std::string& glb) const {
    const auto u32 = [&](std::size_t at) {
      std::uint32_t value;
      std::memcpy(&value, glb.data() + at, 4);
      return value;
    };
    const std::size_t json_end = 20 + std::size_t(u32(12));
    nlohmann::json document = nlohmann::json::parse(glb.begin() + 20, glb.begin() + json_end, nullptr, false);
    if (document.is_discarded()) fail("tinygltf wrote a GLB whose JSON chunk does not parse");
    if (const auto cameras = document.find("cameras"); cameras != document.end()) {
      for (nlohmann::json& camera : *cameras) {
        const auto perspective = camera.find("perspective");
        if (perspective != camera.end() && perspective->value("zfar", 1.0) == 0) perspective->erase("zfar");
      }
    }
    std::string json = document.dump();
    json.resize((json.size() + 3) / 4 * 4, ' ');
    const std::uint32_t json_length = static_cast<std::uint32_t>(json.size());
    const std::uint32_t length = static_cast<std::uint32_t>(12 + 8 + json.size() + (glb.size() - json_end));
    std::string out = glb.substr(0, 8);
    out.append(reinterpret_cast<const char*>(&length), 4);
    out.append(reinterpret_cast<const char*>(&json_length), 4);
    out.append(glb, 16, 4);  // the chunk type, "JSON"
    out += json;
    out.append(glb, json_end);
    return out;
  }

  int node_count() const { return static_cast<int>(model_.nodes.size()); }

  void check_index(int index, std::size_t size, const std::string& what, const std::string& kind) const {
    if (index < 0 || static_cast<std::size_t>(index) >= size) {
      fail(what + " refers to " + kind + " " + std::to_string(index) + ", but the file has " + std::to_string(size));
    }
  }

  // Accessor and buffer view indices are renumbered when unused ones are dropped; an extension
  // holding such indices in its own JSON would be left pointing at the wrong data.
  void reject_unrenumberable_extensions() const {
    for (const std::string& extension : model_.extensionsUsed) {
      if (extension == "KHR_draco_mesh_compression" || extension == "EXT_meshopt_compression" ||
          extension == "EXT_mesh_gpu_instancing") {
        fail("uses " + extension + ", whose accessor and buffer view references the animated GLB writer cannot renumber");
      }
    }
  }

  // L = matrix or T R S (node_transform.h).
  Eigen::Matrix4d node_local(int node) const {
    const tinygltf::Node& n = model_.nodes[node];
    const auto check = [&](const std::vector<double>& values, std::size_t size, const std::string& what) {
      if (values.size() != size || !std::all_of(values.begin(), values.end(), [](double v) { return std::isfinite(v); })) {
        fail(node_label(model_, node) + " " + what + " is not " + std::to_string(size) + " finite numbers");
      }
    };
    if (!n.matrix.empty()) {
      check(n.matrix, 16, "matrix");
      const Eigen::Matrix4d local = Eigen::Map<const Eigen::Matrix4d>(n.matrix.data());
      if ((local.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).cwiseAbs().maxCoeff() > 1e-6) {
        fail(node_label(model_, node) + " matrix is not affine (last row not 0 0 0 1)");
      }
      return local;
    }
    NodeTransform trs;
    if (!n.rotation.empty()) {
      check(n.rotation, 4, "rotation");
      trs.rotation = quaternion_of(n.rotation);
      if (trs.rotation.norm() < 1e-6) fail(node_label(model_, node) + " rotation has (near) zero length");
    }
    if (!n.scale.empty()) {
      check(n.scale, 3, "scale");
      trs.scale = Eigen::Vector3d(n.scale[0], n.scale[1], n.scale[2]);
    }
    if (!n.translation.empty()) {
      check(n.translation, 3, "translation");
      trs.translation = Eigen::Vector3d(n.translation[0], n.translation[1], n.translation[2]);
    }
    return local_matrix(trs);
  }

  // A character whose rest pose is its skins' bind pose, not the pose its nodes hold
  // (Character::source_rest_local_of_joint), is written with each joint's node at that rest: the
  // animation's channels are worked out from the nodes' rest (the header), and a viewer that does
  // not play the animation shows the character as it was bound.
  void put_rest_pose_on_nodes() {
    const std::vector<Eigen::Matrix4d>& locals = character_.source_rest_local_of_joint;
    if (locals.empty()) return;
    if (locals.size() != character_.source_node_of_joint.size()) {
      fail("the character's rest pose has " + std::to_string(locals.size()) + " joint transforms for " +
           std::to_string(character_.source_node_of_joint.size()) + " joints");
    }
    for (std::size_t j = 0; j < locals.size(); ++j) {
      const int node = character_.source_node_of_joint[j];
      check_index(node, model_.nodes.size(), "the character's joint '" + character_.skeleton.name(int(j)) + "'", "node");
      tinygltf::Node& n = model_.nodes[node];
      n.translation.clear();
      n.rotation.clear();
      n.scale.clear();
      n.matrix.assign(locals[j].data(), locals[j].data() + 16);
    }
  }

  // G(n) = G(parent) L(n) of every node, parents first.
  void compute_world_matrices() {
    parent_.assign(node_count(), -1);
    std::vector<std::vector<int>> children(node_count());
    for (int node = 0; node < node_count(); ++node) {
      for (int child : model_.nodes[node].children) {
        check_index(child, model_.nodes.size(), node_label(model_, node) + " child", "node");
        if (parent_[child] >= 0 || child == node) fail(node_label(model_, child) + " has two parents or is on a cycle");
        parent_[child] = node;
      }
      children[node] = model_.nodes[node].children;
    }
    const HierarchyOrder walk = depth_first_order(parent_, children);
    if (walk.unreached >= 0) fail("the node hierarchy has a cycle");
    std::vector<Eigen::Matrix4d> local(node_count());
    for (int node : walk.order) local[node] = node_local(node);
    world_matrices(parent_, walk.order, local, world_);
  }

  // The character must be the one load_character() made from this file: its joints sit on
  // distinct nodes, nest as those nodes do, and rest where the file puts them (C t_n).
  void check_character_matches_file() const {
    const Skeleton& skeleton = character_.skeleton;
    const std::vector<RigidTransform<double>>& rest = rest_world_;
    Eigen::AlignedBox3d bounds;
    for (const auto& joint : rest) bounds.extend(joint.translation);
    const double tolerance = kRestMatchTolerance * (1.0 + bounds.diagonal().norm());
    const Eigen::Matrix3d c = y_up_to_z_up();
    std::vector<int> joint_of_node(node_count(), -1);
    for (int j = 0; j < skeleton.joint_count(); ++j) {
      const int node = character_.source_node_of_joint[j];
      const std::string joint = "joint '" + skeleton.name(j) + "'";
      check_index(node, model_.nodes.size(), "the character's " + joint, "node");
      if (joint_of_node[node] >= 0) {
        fail("the character's joints '" + skeleton.name(joint_of_node[node]) + "' and '" + skeleton.name(j) +
             "' both claim " + node_label(model_, node));
      }
      joint_of_node[node] = j;
    }
    for (int j = 0; j < skeleton.joint_count(); ++j) {
      const int node = character_.source_node_of_joint[j];
      const int parent_joint = skeleton.parent(j);
      // A root joint's node may hang below folded nodes, but never below another joint's node.
      int above = parent_[node];
      while (parent_joint < 0 && above >= 0 && joint_of_node[above] < 0) above = parent_[above];
      const int expected = parent_joint < 0 ? -1 : character_.source_node_of_joint[parent_joint];
      if ((parent_joint < 0 ? above : parent_[node]) != expected) {
        fail("does not match the character: joint '" + skeleton.name(j) + "' is on " + node_label(model_, node) +
             ", whose parent in the file is not the node of the joint's parent");
      }
      const Eigen::Vector3d in_file = c * world_[node].topRightCorner<3, 1>();
      if ((in_file - rest[j].translation).norm() > tolerance) {
        std::ostringstream problem;
        problem << "does not match the character: joint '" << skeleton.name(j) << "' on " << node_label(model_, node)
                << " rests at (" << in_file.transpose() << ") in the file but at (" << rest[j].translation.transpose()
                << ") in the character";
        fail(problem.str());
      }
    }
  }

  // A joint's node as translation, rotation and scale (glTF animates no `matrix` node); returns
  // its rest rotation r_n, normalised.
  Eigen::Quaterniond make_trs(int node) {
    tinygltf::Node& n = model_.nodes[node];
    if (n.matrix.empty()) return n.rotation.empty() ? Eigen::Quaterniond::Identity() : quaternion_of(n.rotation).normalized();
    const Eigen::Matrix4d local = node_local(node);
    // B = R S with S the column lengths, one of them negated when B mirrors so that R is proper.
    const Eigen::Matrix3d linear = local.topLeftCorner<3, 3>();
    Eigen::Vector3d scale = linear.colwise().norm();
    if (scale.minCoeff() <= 0) fail(node_label(model_, node) + " is a joint whose matrix has a zero scale: it cannot be animated");
    if (linear.determinant() < 0) scale.x() = -scale.x();
    const Eigen::Matrix3d rotation = linear * scale.cwiseInverse().asDiagonal();
    if ((rotation.transpose() * rotation - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() > kMaxShear) {
      fail(node_label(model_, node) + " is a joint whose matrix shears; glTF animates only translation/rotation/scale nodes");
    }
    const Eigen::Quaterniond q = quaternion_from_matrix(rotation);
    n.matrix.clear();
    n.translation = {local(0, 3), local(1, 3), local(2, 3)};
    n.rotation = {q.x(), q.y(), q.z(), q.w()};
    n.scale = {scale.x(), scale.y(), scale.z()};
    return q;
  }

  ChannelMap channel_map(int joint) {
    ChannelMap map;
    map.node = character_.source_node_of_joint[joint];
    map.node_rest = make_trs(map.node);
    const Eigen::Quaterniond rest_inverse = character_.skeleton.rest_rotations()[joint].inverse();
    const int parent_joint = character_.skeleton.parent(joint);
    const Eigen::Matrix3d c = y_up_to_z_up();
    if (parent_joint >= 0) {
      // r' = Q Qr^-1 r_n;  u' = A_m^-1 R_m o, with R_m = C^-1 times the parent's rest world rotation.
      const int parent_node = character_.source_node_of_joint[parent_joint];
      const Eigen::Matrix3d parent_rotation = c.transpose() * rest_world_[parent_joint].rotation;
      map.right = rest_inverse * map.node_rest;
      map.offset_linear = world_[parent_node].topLeftCorner<3, 3>().inverse() * parent_rotation;
      return map;
    }
    // r' = R_F^-1 C^-1 Q Qr^-1 C R_F r_n;  u' = A_F^-1 (C^-1 o - t_F), F the folded world above.
    const int above = parent_[map.node];
    const Eigen::Matrix4d folded = above >= 0 ? world_[above] : Eigen::Matrix4d::Identity();
    const Eigen::Matrix3d folded_linear = folded.topLeftCorner<3, 3>();
    const auto [folded_rotation, anisotropy] = polar_rotation(folded_linear);
    if (!(anisotropy <= kMaxAnisotropy)) {
      fail(node_label(model_, above) + " above the root joint '" + character_.skeleton.name(joint) +
           "' scales unevenly (or mirrors): no rotation of the root below it keeps the character rigid");
    }
    if (folded_linear.determinant() < 0) {
      fail(node_label(model_, above) + " above the root joint '" + character_.skeleton.name(joint) + "' mirrors");
    }
    const Eigen::Quaterniond world_to_file = quaternion_from_matrix(c * folded_rotation);  // C R_F
    map.left = world_to_file.inverse();
    map.right = rest_inverse * world_to_file * map.node_rest;
    const Eigen::Matrix3d folded_inverse = folded_linear.inverse();
    map.offset_linear = folded_inverse * c.transpose();
    map.offset_shift = -(folded_inverse * folded.topRightCorner<3, 1>());
    return map;
  }

  // Appends bytes to the staging buffer as a new buffer view; returns its index. Data the writer
  // makes counts as input in the decoding budget.
  int stage_view(const unsigned char* data, std::size_t size) {
    std::vector<unsigned char>& buffer = model_.buffers[staging_buffer_].data;
    buffer.resize((buffer.size() + 3) / 4 * 4, 0);
    tinygltf::BufferView view;
    view.buffer = staging_buffer_;
    view.byteOffset = buffer.size();
    view.byteLength = size;
    buffer.insert(buffer.end(), data, data + size);
    decode_budget_left_ += gltf_decode_budget(size) - gltf_decode_budget(0);
    model_.bufferViews.push_back(view);
    return static_cast<int>(model_.bufferViews.size()) - 1;
  }

  // A float accessor over `values`, `type` (VEC3, ...) elements, in its own buffer view.
  int stage_float_accessor(const std::vector<float>& values, int type) {
    tinygltf::Accessor accessor;
    accessor.bufferView = stage_view(reinterpret_cast<const unsigned char*>(values.data()), values.size() * sizeof(float));
    accessor.componentType = TINYGLTF_COMPONENT_TYPE_FLOAT;
    accessor.type = type;
    accessor.count = values.size() / tinygltf::GetNumComponentsInType(type);
    model_.accessors.push_back(accessor);
    return static_cast<int>(model_.accessors.size()) - 1;
  }

  int add_sampler(tinygltf::Animation& animation, int input, int output) {
    tinygltf::AnimationSampler sampler;
    sampler.input = input;
    sampler.output = output;
    sampler.interpolation = "LINEAR";
    animation.samplers.push_back(sampler);
    return static_cast<int>(animation.samplers.size()) - 1;
  }

  void add_channel(tinygltf::Animation& animation, int sampler, int node, const std::string& path) {
    tinygltf::AnimationChannel channel;
    channel.sampler = sampler;
    channel.target_node = node;
    channel.target_path = path;
    animation.channels.push_back(channel);
  }

  void add_animation() {
    const int frames = clip_.frame_count();
    const int joints = clip_.joint_count();
    std::vector<float> times(frames);
    for (int f = 0; f < frames; ++f) {
      times[f] = static_cast<float>(f / clip_.fps);
      if (f > 0 && !(times[f] > times[f - 1])) {
        throw std::invalid_argument("frames " + std::to_string(f - 1) + " and " + std::to_string(f) + " at " +
                                    std::to_string(clip_.fps) + " fps get the same float32 time: the clip is too long");
      }
    }
    tinygltf::Animation animation;
    animation.name = options_.animation_name;
    const int time_accessor = stage_float_accessor(times, TINYGLTF_TYPE_SCALAR);
    model_.accessors[time_accessor].minValues = {times.front()};
    model_.accessors[time_accessor].maxValues = {times.back()};

    std::vector<int> translation_slot(joints, -1);  // index into the clip's translated joints
    for (std::size_t k = 0; k < clip_.translated_joints.size(); ++k) translation_slot[clip_.translated_joints[k]] = int(k);
    const std::size_t translated_count = clip_.translated_joints.size();
    for (int j = 0; j < joints; ++j) {
      const ChannelMap map = channel_map(j);
      std::vector<float> rotations(std::size_t(frames) * 4);
      Eigen::Quaterniond previous = map.node_rest;
      for (int f = 0; f < frames; ++f) {
        const Eigen::Quaterniond q = sign_aligned((map.left * clip_.rotation(f, j) * map.right).normalized(), previous);
        previous = q;
        const std::array<double, 4> xyzw = {q.x(), q.y(), q.z(), q.w()};
        for (int c = 0; c < 4; ++c) rotations[std::size_t(f) * 4 + c] = static_cast<float>(xyzw[c]);
      }
      add_channel(animation, add_sampler(animation, time_accessor, stage_float_accessor(rotations, TINYGLTF_TYPE_VEC4)),
                  map.node, "rotation");

      if (character_.skeleton.parent(j) >= 0 && translation_slot[j] < 0) continue;
      std::vector<float> translations(std::size_t(frames) * 3);
      for (int f = 0; f < frames; ++f) {
        const Eigen::Vector3d& offset = translation_slot[j] >= 0
                                            ? clip_.translations[std::size_t(f) * translated_count + translation_slot[j]]
                                            : character_.skeleton.rest_offsets()[j];
        const Eigen::Vector3d u = map.offset_linear * offset + map.offset_shift;
        for (int c = 0; c < 3; ++c) translations[std::size_t(f) * 3 + c] = static_cast<float>(u(c));
      }
      add_channel(animation,
                  add_sampler(animation, time_accessor, stage_float_accessor(translations, TINYGLTF_TYPE_VEC3)),
                  map.node, "translation");
    }
    if (options_.camera) add_camera(animation, time_accessor);
    model_.animations.push_back(std::move(animation));
  }

  // The camera path's node, its perspective camera and its two channels (maths in the header):
  // rotation Rg = C^-1 R_cv^T D, translation C^-1 c, frame 0's intrinsics.
  void add_camera(tinygltf::Animation& animation, int time_accessor) {
    const CameraPath& path = *options_.camera;
    const PinholeIntrinsics& k = path.intrinsics.front();
    tinygltf::Camera camera;
    camera.name = options_.camera_name;
    camera.type = "perspective";
    camera.perspective.yfov = 2 * std::atan(k.height / (2 * k.fy));
    camera.perspective.aspectRatio = double(k.width) / k.height;
    camera.perspective.znear = kCameraNear;
    camera.perspective.zfar = 0;  // absent: infinite (dropped from the JSON, see without_zero_zfar)
    model_.cameras.push_back(camera);

    const Eigen::Matrix3d c_inverse = y_up_to_z_up().transpose();
    const Eigen::Matrix3d d = Eigen::Vector3d(1, -1, -1).asDiagonal();
    const int frames = path.frame_count();
    std::vector<float> translations(std::size_t(frames) * 3), rotations(std::size_t(frames) * 4);
    std::vector<double> first_translation, first_rotation;
    Eigen::Quaterniond previous = Eigen::Quaterniond::Identity();  // any sign will do for frame 0
    for (int f = 0; f < frames; ++f) {
      const CameraPose& pose = path.poses[f];
      const Eigen::Vector3d u = c_inverse * pose.centre();
      const Eigen::Quaterniond q =
          sign_aligned(quaternion_from_matrix(c_inverse * pose.rotation.transpose() * d), previous);
      previous = q;
      const std::array<double, 4> xyzw = {q.x(), q.y(), q.z(), q.w()};
      for (int c = 0; c < 3; ++c) translations[std::size_t(f) * 3 + c] = static_cast<float>(u(c));
      for (int c = 0; c < 4; ++c) rotations[std::size_t(f) * 4 + c] = static_cast<float>(xyzw[c]);
      if (f == 0) {
        first_translation = {u.x(), u.y(), u.z()};
        first_rotation = {xyzw.begin(), xyzw.end()};
      }
    }

    tinygltf::Node node;
    node.name = options_.camera_name;
    node.camera = static_cast<int>(model_.cameras.size()) - 1;
    node.translation = first_translation;
    node.rotation = first_rotation;
    model_.nodes.push_back(node);
    const int camera_node = node_count() - 1;
    // The scene load_character() displays; without scenes every root node is shown already.
    if (!model_.scenes.empty()) {
      const int scene = model_.defaultScene >= 0 ? model_.defaultScene : 0;
      check_index(scene, model_.scenes.size(), "the default scene", "scene");
      model_.scenes[scene].nodes.push_back(camera_node);
    }
    add_channel(animation, add_sampler(animation, time_accessor, stage_float_accessor(translations, TINYGLTF_TYPE_VEC3)),
                camera_node, "translation");
    add_channel(animation, add_sampler(animation, time_accessor, stage_float_accessor(rotations, TINYGLTF_TYPE_VEC4)),
                camera_node, "rotation");
  }

  // An element's bytes: its components', except that each column of a MAT2 or MAT3 of 1- or 2-byte
  // components is padded to 4 bytes, as glTF lays them out. 0 for an unknown type.
  static std::size_t element_size(const tinygltf::Accessor& accessor) {
    const int size = tinygltf::GetComponentSizeInBytes(accessor.componentType);
    const int components = tinygltf::GetNumComponentsInType(accessor.type);
    if (size <= 0 || components <= 0) return 0;
    const int columns = accessor.type == TINYGLTF_TYPE_MAT2   ? 2
                        : accessor.type == TINYGLTF_TYPE_MAT3 ? 3
                        : accessor.type == TINYGLTF_TYPE_MAT4 ? 4
                                                              : 1;
    const std::size_t column = std::size_t(components / columns) * size;
    return columns == 1 ? column : columns * ((column + 3) / 4 * 4);
  }

  // Takes count x bytes_per_element from the decoding budget, or fails before they are allocated.
  void charge_decoding(const tinygltf::Accessor& accessor, const std::string& label, std::uint64_t bytes_per_element) {
    if (accessor.count <= decode_budget_left_ / bytes_per_element) {
      decode_budget_left_ -= accessor.count * bytes_per_element;
      return;
    }
    fail(label + (accessor.bufferView < 0 ? " has no buffer view and" : "") + " declares " +
         std::to_string(accessor.count) + " elements of " + std::to_string(bytes_per_element) +
         " bytes: decoding its accessors would take more than " + std::to_string(decode_budget_) +
         " bytes, this file's budget (16 MiB + 64 per byte of the file and its external buffers)");
  }

  // The accessor's elements as stored, tightly packed (element_size() bytes each), with its sparse
  // substitutions applied; zeros where it has no buffer view. Every index and byte range checked.
  std::vector<unsigned char> stored_elements(int index, const std::string& what) {
    check_index(index, model_.accessors.size(), what, "accessor");
    const tinygltf::Accessor& accessor = model_.accessors[index];
    const std::string label = what + " (accessor " + std::to_string(index) + ")";
    const std::size_t size = element_size(accessor);
    if (size == 0) fail(label + " has an unknown element or component type");
    const auto view_bytes = [&](int view, const std::string& part) -> std::pair<const unsigned char*, std::size_t> {
      check_index(view, model_.bufferViews.size(), part, "buffer view");
      const tinygltf::BufferView& buffer_view = model_.bufferViews[view];
      check_index(buffer_view.buffer, model_.buffers.size(), part, "buffer");
      const std::vector<unsigned char>& buffer = model_.buffers[buffer_view.buffer].data;
      if (!fits(buffer_view.byteOffset, buffer_view.byteLength, buffer.size())) {
        fail(part + ": buffer view " + std::to_string(view) + " lies outside its buffer");
      }
      return {buffer.data() + buffer_view.byteOffset, buffer_view.byteLength};
    };

    std::vector<unsigned char> elements;
    if (accessor.bufferView >= 0) {
      const auto [data, length] = view_bytes(accessor.bufferView, label);
      const std::size_t stride = model_.bufferViews[accessor.bufferView].byteStride
                                     ? model_.bufferViews[accessor.bufferView].byteStride
                                     : size;
      if (accessor.count > 0 && (stride < size || !fits(accessor.byteOffset, size, length) ||
                                 accessor.count - 1 > (length - accessor.byteOffset - size) / stride)) {
        fail(label + " reaches past the end of its buffer view");
      }
      charge_decoding(accessor, label, size);
      elements.resize(accessor.count * size);
      for (std::size_t e = 0; e < accessor.count; ++e) {
        std::memcpy(elements.data() + e * size, data + accessor.byteOffset + e * stride, size);
      }
    } else {
      charge_decoding(accessor, label, size);
      elements.assign(accessor.count * size, 0);
    }
    if (accessor.sparse.isSparse) {
      const auto& sparse = accessor.sparse;
      const std::size_t count = sparse.count > 0 ? std::size_t(sparse.count) : 0;
      const int index_type = sparse.indices.componentType;
      const int index_size = tinygltf::GetComponentSizeInBytes(index_type);
      const auto [index_data, index_length] = view_bytes(sparse.indices.bufferView, label + " sparse indices");
      const auto [value_data, value_length] = view_bytes(sparse.values.bufferView, label + " sparse values");
      if ((index_type != TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE && index_type != TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT &&
           index_type != TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT) ||
          sparse.indices.byteOffset < 0 || sparse.values.byteOffset < 0 ||
          !fits(sparse.indices.byteOffset, count * index_size, index_length) ||
          !fits(sparse.values.byteOffset, count * size, value_length)) {
        fail(label + " has sparse storage that is malformed or reaches past its buffer views");
      }
      for (std::size_t k = 0; k < count; ++k) {
        const double element = component_at(index_data + sparse.indices.byteOffset + k * index_size, index_type, false);
        if (element >= static_cast<double>(accessor.count)) fail(label + " has a sparse index past its elements");
        std::memcpy(elements.data() + std::size_t(element) * size, value_data + sparse.values.byteOffset + k * size, size);
      }
    }
    return elements;
  }

  // An accessor's numbers, its components in a row per element, with its sparse substitutions
  // applied. Normalised integers read as fractions unless `as_stored`.
  std::vector<double> accessor_numbers(int index, const std::string& what, int type,
                                       std::initializer_list<int> component_types, bool as_stored = false) {
    check_index(index, model_.accessors.size(), what, "accessor");
    const tinygltf::Accessor& accessor = model_.accessors[index];
    const std::string label = what + " (accessor " + std::to_string(index) + ")";
    const int components = tinygltf::GetNumComponentsInType(type);
    const int size = tinygltf::GetComponentSizeInBytes(accessor.componentType);
    if (accessor.type != type ||
        std::find(component_types.begin(), component_types.end(), accessor.componentType) == component_types.end() ||
        element_size(accessor) != std::size_t(components) * size) {
      fail(label + " has an element or component type this writer does not read there");
    }
    const std::vector<unsigned char> stored = stored_elements(index, what);
    charge_decoding(accessor, label, components * sizeof(double));
    const bool normalized = accessor.normalized && !as_stored;
    std::vector<double> values(accessor.count * components);
    for (std::size_t i = 0; i < values.size(); ++i) {
      values[i] = component_at(stored.data() + i * size, accessor.componentType, normalized);
    }
    return values;
  }

  // Float weights over all sets of one primitive, each vertex summing to 1 (see the header).
  std::vector<std::vector<float>> normalised_weights(const std::vector<int>& joint_accessors,
                                                     const std::vector<int>& weight_accessors, std::size_t slot_limit,
                                                     const std::string& label) {
    const std::size_t sets = joint_accessors.size();
    std::vector<std::vector<double>> joints(sets), weights(sets);
    for (std::size_t s = 0; s < sets; ++s) {
      const std::string set = std::to_string(s);
      if (model_.accessors.at(joint_accessors[s]).normalized) fail(label + " JOINTS_" + set + " is normalised");
      joints[s] = accessor_numbers(joint_accessors[s], label + " JOINTS_" + set, TINYGLTF_TYPE_VEC4,
                                   {TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE, TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT});
      weights[s] = accessor_numbers(weight_accessors[s], label + " WEIGHTS_" + set, TINYGLTF_TYPE_VEC4,
                                    {TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE,
                                     TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT});
      if (joints[s].size() != joints[0].size() || weights[s].size() != joints[0].size()) {
        fail(label + " JOINTS_n and WEIGHTS_n accessors have different counts");
      }
    }
    const std::size_t vertices = joints[0].size() / 4, influences = sets * 4;
    std::vector<std::vector<float>> out(sets, std::vector<float>(vertices * 4, 0.0f));
    std::vector<double> joint(influences), weight(influences);
    for (std::size_t v = 0; v < vertices; ++v) {
      for (std::size_t i = 0; i < influences; ++i) {
        joint[i] = joints[i / 4][v * 4 + i % 4];
        weight[i] = weights[i / 4][v * 4 + i % 4];
        if (!std::isfinite(weight[i]) || weight[i] < 0) {
          fail(label + " vertex " + std::to_string(v) + " has a negative or non-finite weight");
        }
        if (joint[i] >= static_cast<double>(slot_limit)) {
          fail(label + " vertex " + std::to_string(v) + " uses joint slot " + std::to_string(std::size_t(joint[i])) +
               " of a skin with " + std::to_string(slot_limit) + " joints");
        }
      }
      // A joint listed twice keeps its total weight in its first weighted slot.
      for (std::size_t i = 0; i < influences; ++i) {
        for (std::size_t k = 0; k < i && weight[i] > 0; ++k) {
          if (weight[k] > 0 && joint[k] == joint[i]) {
            weight[k] += weight[i];
            weight[i] = 0;
          }
        }
      }
      double sum = 0;
      for (double w : weight) sum += w;
      if (sum == 0) {
        weight[0] = 1;
        sum = 1;
      }
      // Each weight rounded to float, then the largest replaced by 1 minus the others (as
      // rounded), so the stored floats sum to 1 up to the rounding of the largest alone.
      std::size_t largest = 0;
      std::vector<float> rounded(influences);
      for (std::size_t i = 0; i < influences; ++i) {
        rounded[i] = static_cast<float>(weight[i] / sum);
        if (weight[i] > weight[largest]) largest = i;
      }
      double others = 0;
      for (std::size_t i = 0; i < influences; ++i) others += i == largest ? 0.0 : rounded[i];
      rounded[largest] = static_cast<float>(1.0 - others);
      for (std::size_t i = 0; i < influences; ++i) out[i / 4][v * 4 + i % 4] = rounded[i];
    }
    return out;
  }

  void rewrite_weights() {
    // Joint slots must index the skin of every node that shows the mesh.
    std::vector<std::size_t> slot_limit(model_.meshes.size(), std::numeric_limits<std::size_t>::max());
    for (int node = 0; node < node_count(); ++node) {
      const tinygltf::Node& n = model_.nodes[node];
      if (n.mesh < 0) continue;
      check_index(n.mesh, model_.meshes.size(), node_label(model_, node), "mesh");
      if (n.skin < 0) continue;
      check_index(n.skin, model_.skins.size(), node_label(model_, node), "skin");
      slot_limit[n.mesh] = std::min(slot_limit[n.mesh], model_.skins[n.skin].joints.size());
    }
    // Primitives sharing the same JOINTS/WEIGHTS accessors share the rewritten ones too.
    std::map<std::pair<std::vector<int>, std::vector<int>>, std::vector<int>> rewritten;
    for (std::size_t m = 0; m < model_.meshes.size(); ++m) {
      for (std::size_t p = 0; p < model_.meshes[m].primitives.size(); ++p) {
        auto& attributes = model_.meshes[m].primitives[p].attributes;
        const std::string label = "mesh " + std::to_string(m) + " primitive " + std::to_string(p);
        std::vector<int> joint_accessors, weight_accessors;
        for (int set = 0;; ++set) {
          const auto joints = attributes.find("JOINTS_" + std::to_string(set));
          const auto weights = attributes.find("WEIGHTS_" + std::to_string(set));
          if (joints == attributes.end() && weights == attributes.end()) break;
          if (joints == attributes.end() || weights == attributes.end()) {
            fail(label + " has only one of JOINTS_" + std::to_string(set) + " and WEIGHTS_" + std::to_string(set));
          }
          joint_accessors.push_back(joints->second);
          weight_accessors.push_back(weights->second);
        }
        if (weight_accessors.empty()) continue;
        auto [entry, added] = rewritten.try_emplace({joint_accessors, weight_accessors});
        if (added) {
          for (const std::vector<float>& set : normalised_weights(joint_accessors, weight_accessors, slot_limit[m], label)) {
            entry->second.push_back(stage_float_accessor(set, TINYGLTF_TYPE_VEC4));
          }
        }
        for (std::size_t set = 0; set < entry->second.size(); ++set) {
          attributes["WEIGHTS_" + std::to_string(set)] = entry->second[set];
        }
      }
    }
  }

  // Images given by URI (a file or a data URI) move into buffer views; every image gets the MIME
  // type its bytes show, which glTF requires beside a buffer view.
  void embed_images() {
    for (std::size_t i = 0; i < model_.images.size(); ++i) {
      tinygltf::Image& image = model_.images[i];
      if (image.bufferView >= 0 && !image.mimeType.empty()) continue;
      const std::string label = "image " + std::to_string(i) + (image.uri.empty() ? "" : " '" + image.uri + "'");
      if (i >= image_bytes_.size() || image_bytes_[i].empty()) fail(label + " could not be read, so the GLB cannot hold it");
      const std::vector<unsigned char>& bytes = image_bytes_[i];
      const std::string mime_type = image_mime_type(bytes);
      if (mime_type.empty()) fail(label + " is not PNG, JPEG, KTX2 or WebP data");
      if (image.bufferView < 0) {
        image.bufferView = stage_view(bytes.data(), bytes.size());
        image.uri.clear();
      }
      image.mimeType = mime_type;
    }
  }

  // Keeps the accessors something refers to, renumbered in their old order, and writes every
  // buffer view afresh into one buffer, buffers[0] with no uri (the GLB's binary chunk), whatever
  // the input's layout (interleaved or strided views, views shared by accessors, sparse storage,
  // buffers nothing uses): each accessor with data gets a view of its own holding its elements
  // tightly packed, sparse substitutions applied, and each image one holding its bytes. Views of
  // vertex attributes and indices carry their target; only a vertex attribute whose elements are
  // not a multiple of 4 bytes gets a byteStride (the element rounded up to 4 bytes, the alignment
  // glTF requires of vertex attributes). An accessor with neither a buffer view nor sparse
  // storage stays so: all zeros, nothing to store.
  void drop_unused_and_repack_buffers() {
    const auto for_each_accessor_reference = [&](const std::function<void(int&)>& visit) {
      for (tinygltf::Mesh& mesh : model_.meshes) {
        for (tinygltf::Primitive& primitive : mesh.primitives) {
          for (auto& attribute : primitive.attributes) visit(attribute.second);
          if (primitive.indices >= 0) visit(primitive.indices);
          for (auto& target : primitive.targets) {
            for (auto& attribute : target) visit(attribute.second);
          }
        }
      }
      for (tinygltf::Skin& skin : model_.skins) {
        if (skin.inverseBindMatrices >= 0) visit(skin.inverseBindMatrices);
      }
      for (tinygltf::Animation& animation : model_.animations) {
        for (tinygltf::AnimationSampler& sampler : animation.samplers) {
          visit(sampler.input);
          visit(sampler.output);
        }
      }
    };
    model_.accessors = kept(model_.accessors, "accessor", for_each_accessor_reference);

    std::vector<int> target(model_.accessors.size(), 0);
    for (const tinygltf::Mesh& mesh : model_.meshes) {
      for (const tinygltf::Primitive& primitive : mesh.primitives) {
        for (const auto& attribute : primitive.attributes) target[attribute.second] = TINYGLTF_TARGET_ARRAY_BUFFER;
        for (const auto& morph : primitive.targets) {
          for (const auto& attribute : morph) target[attribute.second] = TINYGLTF_TARGET_ARRAY_BUFFER;
        }
        if (primitive.indices >= 0) target[primitive.indices] = TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER;
      }
    }
    tinygltf::Buffer packed;
    std::vector<tinygltf::BufferView> views;
    // `count` elements of `size` bytes, `stride` bytes apart in a new view at a 4-byte boundary.
    const auto append_view = [&](const unsigned char* data, std::size_t count, std::size_t size, std::size_t stride,
                                 int view_target) {
      tinygltf::BufferView view;
      view.buffer = 0;
      view.byteOffset = (packed.data.size() + 3) / 4 * 4;
      view.byteLength = count * stride;
      view.byteStride = stride == size ? 0 : stride;
      view.target = view_target;
      packed.data.resize(view.byteOffset + view.byteLength, 0);
      for (std::size_t e = 0; e < count; ++e) {
        std::memcpy(packed.data.data() + view.byteOffset + e * stride, data + e * size, size);
      }
      views.push_back(view);
      return static_cast<int>(views.size()) - 1;
    };
    for (std::size_t a = 0; a < model_.accessors.size(); ++a) {
      tinygltf::Accessor& accessor = model_.accessors[a];
      if (accessor.bufferView < 0 && !accessor.sparse.isSparse) continue;
      const std::vector<unsigned char> elements = stored_elements(int(a), "accessor " + std::to_string(a));
      const std::size_t size = element_size(accessor);
      const std::size_t stride = target[a] == TINYGLTF_TARGET_ARRAY_BUFFER ? (size + 3) / 4 * 4 : size;
      accessor.bufferView = append_view(elements.data(), accessor.count, size, stride, target[a]);
      accessor.byteOffset = 0;
      accessor.sparse.isSparse = false;
      accessor.sparse.count = 0;
    }
    for (std::size_t i = 0; i < model_.images.size(); ++i) {
      tinygltf::Image& image = model_.images[i];
      if (image.bufferView < 0) continue;
      const std::string label = "image " + std::to_string(i);
      check_index(image.bufferView, model_.bufferViews.size(), label, "buffer view");
      const tinygltf::BufferView& view = model_.bufferViews[image.bufferView];
      check_index(view.buffer, model_.buffers.size(), label + " buffer view", "buffer");
      const std::vector<unsigned char>& source = model_.buffers[view.buffer].data;
      if (!fits(view.byteOffset, view.byteLength, source.size())) fail(label + ": its buffer view lies outside its buffer");
      image.bufferView = append_view(source.data() + view.byteOffset, view.byteLength, 1, 1, 0);
    }
    model_.bufferViews = std::move(views);
    model_.buffers = {std::move(packed)};
  }

  // Accessor min and max must equal the data's per-component extremes (in stored units: the
  // normalized flag does not apply to them), and POSITION accessors must declare them; exporters get them wrong often
  // enough (float rounding, edited data) that every declared or required pair is recomputed.
  void refresh_declared_bounds() {
    std::vector<bool> required(model_.accessors.size(), false);
    for (const tinygltf::Mesh& mesh : model_.meshes) {
      for (const tinygltf::Primitive& primitive : mesh.primitives) {
        if (const auto position = primitive.attributes.find("POSITION"); position != primitive.attributes.end()) {
          required[position->second] = true;
        }
        for (const auto& target : primitive.targets) {
          if (const auto position = target.find("POSITION"); position != target.end()) required[position->second] = true;
        }
      }
    }
    for (std::size_t a = 0; a < model_.accessors.size(); ++a) {
      tinygltf::Accessor& accessor = model_.accessors[a];
      // MAT2 and MAT3 of 1- or 2-byte components pad their columns; none is a vertex position or
      // a joint or weight, so those keep what they declare.
      const bool padded = accessor.type == TINYGLTF_TYPE_MAT2 || accessor.type == TINYGLTF_TYPE_MAT3;
      if (accessor.count == 0 || padded || (!required[a] && accessor.minValues.empty() && accessor.maxValues.empty())) {
        continue;
      }
      const std::vector<double> values = accessor_numbers(
          int(a), "accessor " + std::to_string(a), accessor.type,
          {TINYGLTF_COMPONENT_TYPE_BYTE, TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE, TINYGLTF_COMPONENT_TYPE_SHORT,
           TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT, TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT, TINYGLTF_COMPONENT_TYPE_FLOAT},
          true);
      const std::size_t components = values.size() / accessor.count;
      accessor.minValues.assign(values.begin(), values.begin() + components);
      accessor.maxValues = accessor.minValues;
      for (std::size_t i = components; i < values.size(); ++i) {
        accessor.minValues[i % components] = std::min(accessor.minValues[i % components], values[i]);
        accessor.maxValues[i % components] = std::max(accessor.maxValues[i % components], values[i]);
      }
    }
  }

  // The elements of `items` that a reference reaches (indices checked), in their old order;
  // every reference is rewritten to the new numbering.
  template <class Item>
  std::vector<Item> kept(const std::vector<Item>& items, const std::string& kind,
                         const std::function<void(const std::function<void(int&)>&)>& for_each_reference) const {
    std::vector<int> new_index(items.size(), -1);
    for_each_reference([&](int& index) {
      check_index(index, items.size(), "a reference", kind);
      new_index[index] = 0;
    });
    std::vector<Item> out;
    for (std::size_t i = 0; i < items.size(); ++i) {
      if (new_index[i] < 0) continue;
      new_index[i] = static_cast<int>(out.size());
      out.push_back(items[i]);
    }
    for_each_reference([&](int& index) { index = new_index[index]; });
    return out;
  }

  std::string path_;
  const Character& character_;
  const Clip& clip_;
  const GlbExportOptions& options_;
  std::vector<RigidTransform<double>> rest_world_;
  tinygltf::Model model_;
  std::vector<std::vector<unsigned char>> image_bytes_;
  std::vector<int> parent_;  // per node, -1 for a root node
  std::vector<Eigen::Matrix4d> world_;
  int staging_buffer_ = -1;  // where new data waits until the buffers are repacked
  std::uint64_t decode_budget_ = 0, decode_budget_left_ = 0;  // see gltf_decode_budget()
};

void check_clip_fits_character(const Character& character, const Clip& clip) {
  clip.validate();
  const Skeleton& ours = character.skeleton;
  const Skeleton& theirs = clip.skeleton;
  if (clip.frame_count() < 1) throw std::invalid_argument("the clip has no frames");
  if (theirs.joint_count() != ours.joint_count()) {
    throw std::invalid_argument("the clip has " + std::to_string(theirs.joint_count()) + " joints but character '" +
                                character.name + "' has " + std::to_string(ours.joint_count()));
  }
  for (int j = 0; j < ours.joint_count(); ++j) {
    if (theirs.name(j) != ours.name(j) || theirs.parent(j) != ours.parent(j)) {
      throw std::invalid_argument("the clip's joint " + std::to_string(j) + " '" + theirs.name(j) +
                                  "' does not match character '" + character.name + "' joint '" + ours.name(j) +
                                  "' (name or parent differs): the clip is not on this skeleton");
    }
  }
  if (character.source_node_of_joint.size() != std::size_t(ours.joint_count())) {
    throw std::invalid_argument("character '" + character.name + "' has no file node for every joint");
  }
}

// The camera path must have one pose per clip frame at the clip's rate, and one set of
// intrinsics throughout, since core glTF cannot animate a camera's projection.
void check_camera_fits_clip(const CameraPath& camera, const Clip& clip) {
  camera.validate();
  if (camera.frame_count() != clip.frame_count()) {
    throw std::invalid_argument("the camera path has " + std::to_string(camera.frame_count()) +
                                " frames but the clip has " + std::to_string(clip.frame_count()));
  }
  if (camera.fps != clip.fps) {
    throw std::invalid_argument("the camera path runs at " + std::to_string(camera.fps) + " fps but the clip at " +
                                std::to_string(clip.fps));
  }
  const PinholeIntrinsics& first = camera.intrinsics.front();
  for (int f = 1; f < camera.frame_count(); ++f) {
    const PinholeIntrinsics& k = camera.intrinsics[f];
    if (k.fx != first.fx || k.fy != first.fy || k.cx != first.cx || k.cy != first.cy || k.width != first.width ||
        k.height != first.height) {
      throw std::invalid_argument("camera path frame " + std::to_string(f) +
                                  " has other intrinsics than frame 0: a glTF camera's projection cannot be animated");
    }
  }
}

}  // namespace

void write_animated_glb(const std::string& character_path, const Character& character, const Clip& clip,
                        const std::string& out_path, const GlbExportOptions& options) {
  check_clip_fits_character(character, clip);
  if (options.camera) check_camera_fits_clip(*options.camera, clip);
  const std::string glb = AnimatedGlbBuilder(character_path, character, clip, options).build();
  write_file_atomically(out_path, glb);
}

}  // namespace odyssey::io
