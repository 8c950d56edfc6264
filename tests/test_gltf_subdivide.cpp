// The denser copies of characters that the dense-visibility test and the scene benchmark use
// (mocap_io/gltf_subdivide.h): the Khronos validator accepts them, the counts follow from the
// edges, the original vertices keep their skins (so every pose skins them where the original
// does), every new vertex lies on its edge at the rest pose, and bad requests fail naming the file.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>
#include <string>
#include <utility>

#include "gltf_validator.h"
#include "mocap_io/gltf_character.h"
#include "mocap_io/gltf_subdivide.h"
#include "mocap_io/input_error.h"
#include "test_support.h"

namespace odyssey {
namespace {

namespace fs = std::filesystem;
using test_support::contains;

const std::string kCesium = std::string(ODYSSEY_SHARED_DIR) + "/assets/characters/CesiumMan.glb";

TEST(GltfSubdivideTest, CountsFollowTheEdgesAndTheValidatorAccepts) {
  const fs::path out = test_support::scratch_dir("gltf_subdivide") / "cesium_x1.glb";
  const io::SubdividedGltf counts = io::write_subdivided_glb(kCesium, out.string(), 1);
  const Character original = io::load_character(kCesium), dense = io::load_character(out.string());
  ASSERT_EQ(original.meshes.size(), 1u);
  ASSERT_EQ(dense.meshes.size(), 1u);
  // One new vertex per distinct index pair {a, b} on a triangle's edge; four triangles for one.
  std::set<std::pair<std::uint32_t, std::uint32_t>> edges;
  const std::vector<std::uint32_t>& t = original.meshes[0].triangles;
  for (std::size_t i = 0; i < t.size(); i += 3) {
    for (int e = 0; e < 3; ++e) edges.insert(std::minmax(t[i + e], t[i + (e + 1) % 3]));
  }
  EXPECT_EQ(counts.vertices_before, original.meshes[0].positions.size());
  EXPECT_EQ(counts.vertices_after, original.meshes[0].positions.size() + edges.size());
  EXPECT_EQ(dense.meshes[0].positions.size(), counts.vertices_after);
  EXPECT_EQ(dense.meshes[0].triangles.size(), 4 * t.size());
  EXPECT_EQ(dense.skeleton.joint_count(), original.skeleton.joint_count());

  if (const std::string missing = test_support::validator_missing(); !missing.empty()) GTEST_SKIP() << missing;
  const fs::path log = fs::path(out).replace_extension(".validator.txt");
  const int status = std::system(("node '" + (test_support::validator_dir() / "validate.mjs").string() + "' '" + out.string() +
                                  "' --all > '" + log.string() + "' 2>&1").c_str());
  std::ifstream in(log);
  const std::string report((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  ASSERT_TRUE(WIFEXITED(status)) << report;
  EXPECT_EQ(WEXITSTATUS(status), 0) << report;
  EXPECT_TRUE(contains(report, ": 0 errors,")) << report;
}

TEST(GltfSubdivideTest, OriginalVerticesKeepTheirSkinsAndNewOnesLieOnTheirEdges) {
  const fs::path out = test_support::scratch_dir("gltf_subdivide") / "cesium_x2.glb";
  io::write_subdivided_glb(kCesium, out.string(), 2);
  const Character original = io::load_character(kCesium), dense = io::load_character(out.string());
  const CharacterMesh &a = original.meshes[0], &b = dense.meshes[0];
  // A pose that bends every joint, so that differing skins would show.
  std::vector<RigidTransform<double>> world = original.skeleton.rest_world();
  for (std::size_t j = 0; j < world.size(); ++j) {
    world[j].rotation = world[j].rotation * Eigen::AngleAxisd(0.3 + 0.05 * j, Eigen::Vector3d(1, 0.5, 0.2).normalized());
  }
  const std::vector<Eigen::Vector3d> skinned_a = skin_mesh_reference(a, world), skinned_b = skin_mesh_reference(b, world);
  double worst = 0;
  for (std::size_t v = 0; v < a.positions.size(); ++v) worst = std::max(worst, (skinned_a[v] - skinned_b[v]).norm());
  EXPECT_LT(worst, 1e-6) << "an original vertex moved";
  // At rest every vertex of the dense mesh lies on the original surface: on a segment between two
  // original vertices of one triangle, or inside it. Checked through the first level's midpoints:
  // each vertex of the dense mesh is within 1e-6 of the original triangle it came from, found by
  // the dense triangle's index (triangle i of the original becomes dense triangles 16 i ... 16 i + 15).
  double off_surface = 0;
  for (std::size_t i = 0; i < a.triangles.size() / 3; ++i) {
    const Eigen::Vector3d p0 = a.positions[a.triangles[3 * i]].cast<double>(), p1 = a.positions[a.triangles[3 * i + 1]].cast<double>(),
                          p2 = a.positions[a.triangles[3 * i + 2]].cast<double>();
    const Eigen::Vector3d n = (p1 - p0).cross(p2 - p0);
    if (n.norm() < 1e-12) continue;
    for (std::size_t k = 16 * 3 * i; k < 16 * 3 * (i + 1); ++k) {
      const Eigen::Vector3d q = b.positions[b.triangles[k]].cast<double>();
      off_surface = std::max(off_surface, std::abs((q - p0).dot(n.normalized())));
    }
  }
  EXPECT_LT(off_surface, 1e-5) << "a new vertex left its triangle's plane";
}

TEST(GltfSubdivideTest, BadRequestsFailNamingTheFile) {
  const fs::path dir = test_support::scratch_dir("gltf_subdivide");
  EXPECT_THROW(io::write_subdivided_glb(kCesium, (dir / "x7.glb").string(), 7), std::invalid_argument);
  std::ofstream(dir / "not_gltf.glb") << "plain text";
  const std::string message = test_support::message_of<io::InputError>(
      [&] { io::write_subdivided_glb((dir / "not_gltf.glb").string(), (dir / "out.glb").string(), 1); });
  EXPECT_TRUE(contains(message, (dir / "not_gltf.glb").string())) << message;
  EXPECT_FALSE(fs::exists(dir / "x7.glb"));
  EXPECT_FALSE(fs::exists(dir / "out.glb"));
}

}  // namespace
}  // namespace odyssey
