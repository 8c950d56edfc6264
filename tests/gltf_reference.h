// The plain glTF reading that the glTF tests check the toolkit against: tinygltf parsing with
// images left undecoded, dense accessor elements as doubles, and node matrices built from T R S
// with the quaternion written out by hand. Deliberately independent of mocap_io's own code.
#pragma once

#include <tiny_gltf.h>

#include <Eigen/Core>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace odyssey::gltf_reference {

inline bool no_images(tinygltf::Image*, const int, std::string*, std::string*, int, int, const unsigned char*, int,
                      void*) {
  return true;
}

// A .glb or .gltf as tinygltf reads it, images left undecoded.
inline tinygltf::Model parse(const std::string& path) {
  tinygltf::TinyGLTF parser;
  parser.SetImageLoader(no_images, nullptr);
  tinygltf::Model model;
  std::string error, warning;
  const bool binary = std::filesystem::path(path).extension() == ".glb";
  const bool ok = binary ? parser.LoadBinaryFromFile(&model, &error, &warning, path)
                         : parser.LoadASCIIFromFile(&model, &error, &warning, path);
  EXPECT_TRUE(ok) << path << ": " << error;
  return model;
}

// Dense accessor elements as doubles (normalised integers divided by their maximum); no sparse
// storage, which neither the sample files nor the writer use.
inline std::vector<std::vector<double>> elements(const tinygltf::Model& model, int index) {
  const tinygltf::Accessor& accessor = model.accessors.at(index);
  const tinygltf::BufferView& view = model.bufferViews.at(accessor.bufferView);
  const unsigned char* data = model.buffers.at(view.buffer).data.data() + view.byteOffset + accessor.byteOffset;
  const int components = tinygltf::GetNumComponentsInType(accessor.type);
  const int size = tinygltf::GetComponentSizeInBytes(accessor.componentType);
  const std::size_t stride = view.byteStride ? view.byteStride : std::size_t(components * size);
  std::vector<std::vector<double>> out(accessor.count, std::vector<double>(components));
  for (std::size_t e = 0; e < accessor.count; ++e) {
    for (int c = 0; c < components; ++c) {
      const unsigned char* at = data + e * stride + c * size;
      if (accessor.componentType == TINYGLTF_COMPONENT_TYPE_FLOAT) {
        float value;
        std::memcpy(&value, at, 4);
        out[e][c] = value;
      } else if (accessor.componentType == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE) {
        out[e][c] = at[0] / (accessor.normalized ? 255.0 : 1.0);
      } else if (accessor.componentType == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT) {
        std::uint16_t value;
        std::memcpy(&value, at, 2);
        out[e][c] = value / (accessor.normalized ? 65535.0 : 1.0);
      } else {
        std::uint32_t value;
        std::memcpy(&value, at, 4);
        out[e][c] = value;
      }
    }
  }
  return out;
}

// T * R * S, with the rotation (x, y, z, w) written out as a matrix; absent parts are identity.
inline Eigen::Matrix4d trs_matrix(const std::vector<double>& t, const std::vector<double>& q,
                                  const std::vector<double>& s) {
  Eigen::Matrix4d r = Eigen::Matrix4d::Identity();
  if (q.size() == 4) {
    const double n = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    const double x = q[0] / n, y = q[1] / n, z = q[2] / n, w = q[3] / n;
    r(0, 0) = 1 - 2 * (y * y + z * z), r(0, 1) = 2 * (x * y - z * w), r(0, 2) = 2 * (x * z + y * w);
    r(1, 0) = 2 * (x * y + z * w), r(1, 1) = 1 - 2 * (x * x + z * z), r(1, 2) = 2 * (y * z - x * w);
    r(2, 0) = 2 * (x * z - y * w), r(2, 1) = 2 * (y * z + x * w), r(2, 2) = 1 - 2 * (x * x + y * y);
  }
  Eigen::Matrix4d scale = Eigen::Matrix4d::Identity(), translation = Eigen::Matrix4d::Identity();
  if (s.size() == 3) scale(0, 0) = s[0], scale(1, 1) = s[1], scale(2, 2) = s[2];
  if (t.size() == 3) translation(0, 3) = t[0], translation(1, 3) = t[1], translation(2, 3) = t[2];
  return translation * r * scale;
}

// A node's local matrix: its column-major `matrix`, or its T R S.
inline Eigen::Matrix4d static_local(const tinygltf::Node& node) {
  if (node.matrix.size() != 16) return trs_matrix(node.translation, node.rotation, node.scale);
  Eigen::Matrix4d local;
  for (int i = 0; i < 16; ++i) local(i % 4, i / 4) = node.matrix[i];
  return local;
}

// Y up to Z up: (x, y, z) -> (x, -z, y).
inline Eigen::Vector3d z_up(const Eigen::Vector3d& p) { return Eigen::Vector3d(p.x(), -p.z(), p.y()); }

}  // namespace odyssey::gltf_reference
