// Shared characters with their nodes struck into another pose than the one their mesh was bound
// in, inverse bind matrices and meshes unchanged: what an exporter that writes an animation's
// frame (or an editor's posed armature) into the nodes leaves (mocap_io/gltf_character.h, "The
// bind pose").
#pragma once

#include <Eigen/Geometry>
#include <cmath>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <vector>

#include "derived_characters.h"
#include "test_support.h"

namespace odyssey::test_support {

// The file with its nodes struck into another pose: every skin joint whose parent is also a joint
// of a skin turned by a different 20-50 degree rotation, as an exporter that writes an animation's
// frame (or an editor's posed armature) into the nodes leaves it; inverse bind matrices and
// meshes unchanged. Nodes given as a matrix are left as they are.
inline std::filesystem::path posed_copy(const std::string& file) {
  const std::filesystem::path source = kSharedCharacters + file;
  const std::string stem = std::filesystem::path(file).stem().string();
  const auto* test = testing::UnitTest::GetInstance()->current_test_info();
  const std::filesystem::path dir = scratch_root() / "posed_characters" / (std::string(test->test_suite_name()) + "." + test->name());
  const std::filesystem::path out = dir / ("posed_" + stem + source.extension().string());
  write_derived_gltf(source, out, [](nlohmann::json& gltf) {
    std::set<int> joints;
    for (const auto& skin : gltf["skins"]) {
      for (int joint : skin["joints"]) joints.insert(joint);
    }
    std::map<int, int> parent;
    for (std::size_t n = 0; n < gltf["nodes"].size(); ++n) {
      for (int child : gltf["nodes"][n].value("children", std::vector<int>{})) parent[child] = static_cast<int>(n);
    }
    int k = 0;
    for (int joint : joints) {
      nlohmann::json& node = gltf["nodes"][joint];
      if (!parent.count(joint) || !joints.count(parent[joint]) || node.contains("matrix")) continue;
      const std::vector<double> r = node.value("rotation", std::vector<double>{0, 0, 0, 1});
      const Eigen::Quaterniond rest(r[3], r[0], r[1], r[2]);
      const double angle = (20.0 + 30.0 * ((k * 7) % 11) / 10.0) * M_PI / 180.0;
      const Eigen::Vector3d axis = Eigen::Vector3d(1.0 + k % 3, 2.0 - k % 2, 0.5 + k % 5).normalized();
      const Eigen::Quaterniond posed = (rest * Eigen::Quaterniond(Eigen::AngleAxisd(angle, axis))).normalized();
      node["rotation"] = {posed.x(), posed.y(), posed.z(), posed.w()};
      ++k;
    }
  });
  return out;
}

}  // namespace odyssey::test_support
