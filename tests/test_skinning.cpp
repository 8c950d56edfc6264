// The skinning engine against the plain double-precision reference (skin_mesh_reference) on every
// shared character and the synthetic SMPL-X body at random poses; subsets, frame batches and
// thread counts give the same numbers as the full single-threaded run; normals are unit, follow a
// double-precision reference, and start from OpenMesh's vertex normals; the body as a character
// skins like the body model; the AVX-512 and portable kernels agree; bad setups are rejected.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"  // GCC 12 and AVX-512 intrinsics, see lbs.cpp
#include <Eigen/Core>
#pragma GCC diagnostic pop

#include <gtest/gtest.h>

#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include "mocap_io/gltf_character.h"
#include "skeleton/body_model.h"
#include "skeleton/fk.h"
#include "skeleton/rotation.h"
#include "skinning/body_character.h"
#include "skinning/lbs.h"
#include "skinning/lbs_kernel.h"
#include "skinning/normals.h"
#include "synthetic/synthetic_body.h"

namespace odyssey::skinning {
namespace {

namespace fs = std::filesystem;
using Eigen::Vector3d;
using Eigen::Vector3f;

// Every character file in the shared assets, sorted by name.
std::vector<std::string> shared_character_paths() {
  std::vector<std::string> paths;
  for (const auto& entry : fs::directory_iterator(std::string(ODYSSEY_SHARED_DIR) + "/assets/characters")) {
    const std::string extension = entry.path().extension().string();
    if (extension == ".glb" || extension == ".gltf") paths.push_back(entry.path().string());
  }
  std::sort(paths.begin(), paths.end());
  return paths;
}

struct NamedCharacter {
  std::string name;
  Character character;
};

// The shared characters and the synthetic SMPL-X body (plain, and its dense-weight variant cut
// to four influences a vertex).
const std::vector<NamedCharacter>& test_characters() {
  static const std::vector<NamedCharacter> characters = [] {
    std::vector<NamedCharacter> list;
    for (const std::string& path : shared_character_paths()) {
      list.push_back({fs::path(path).filename().string(), io::load_character(path)});
    }
    list.push_back({"synthetic SMPL-X", body_character(make_synthetic_body(1).model)});
    list.push_back({"synthetic SMPL-X dense", body_character(make_synthetic_body(1, true).model)});
    return list;
  }();
  return characters;
}

// Largest extent of the rest pose; errors are allowed to grow with it beyond 1 m, since float32
// keeps a relative precision.
double character_size(const Character& character) { return character.rest_bounds().sizes().maxCoeff(); }
double position_tolerance(const Character& character) { return 1e-5 * std::max(1.0, character_size(character)); }

// World joint transforms of a random pose: every joint turned from its rest rotation by a random
// rotation of up to ~1 rad, the root moved by up to half the character's size.
std::vector<RigidTransform<double>> random_pose(const Character& character, std::mt19937& random) {
  const Skeleton& skeleton = character.skeleton;
  std::vector<RigidTransform<double>> local(skeleton.joint_count()), world(skeleton.joint_count());
  skeleton.rest_local(local);
  std::uniform_real_distribution<double> component(-0.6, 0.6), offset(-0.5, 0.5);
  for (RigidTransform<double>& joint : local) {
    joint.rotation = joint.rotation * rodrigues(Vector3d(component(random), component(random), component(random)));
  }
  const double size = character_size(character);
  local[0].translation += size * Vector3d(offset(random), offset(random), offset(random));
  forward_kinematics<double>(skeleton.parents(), local, world);
  return world;
}

// The reference, every mesh in order: the rows of all_vertices(character).
std::vector<Vector3d> reference_positions(const Character& character, const std::vector<RigidTransform<double>>& world) {
  std::vector<Vector3d> positions;
  for (const CharacterMesh& mesh : character.meshes) {
    const std::vector<Vector3d> skinned = skin_mesh_reference(mesh, world);
    positions.insert(positions.end(), skinned.begin(), skinned.end());
  }
  return positions;
}

// Reference normals in double: normalise(sum_k w_k A_k n_rest), A_k the 3x3 of W(joint_k) inverse_bind_k.
std::vector<Vector3d> reference_normals(const Character& character, const std::vector<RigidTransform<double>>& world) {
  std::vector<Vector3d> normals;
  for (const CharacterMesh& mesh : character.meshes) {
    const std::vector<Vector3f> rest = rest_vertex_normals(mesh);
    for (std::size_t v = 0; v < mesh.positions.size(); ++v) {
      Vector3d sum = Vector3d::Zero();
      for (int i = 0; i < 4; ++i) {
        const double weight = mesh.influence_weights[v][i];
        if (weight == 0.0) continue;
        const int slot = mesh.influence_slots[v][i];
        const Eigen::Matrix3d linear = world[mesh.skin_joints[slot]].rotation * mesh.inverse_bind[slot].topLeftCorner<3, 3>();
        sum += weight * (linear * rest[v].cast<double>());
      }
      normals.push_back(sum.norm() > 0.0 ? Vector3d(sum.normalized()) : Vector3d::Zero());
    }
  }
  return normals;
}

Vector3d row(const std::vector<float>& values, std::size_t i) {
  return Vector3d(values[3 * i], values[3 * i + 1], values[3 * i + 2]);
}

TEST(LbsTest, MatchesTheReferenceOnEveryCharacter) {
  ASSERT_GE(shared_character_paths().size(), 6u);
  std::mt19937 random(11);
  for (const auto& [name, character] : test_characters()) {
    const std::vector<MeshVertex> vertices = all_vertices(character);
    LinearBlendSkinner skinner(character, vertices);
    std::vector<float> positions(3 * vertices.size());
    double worst = 0.0;
    for (int pose = 0; pose < 5; ++pose) {
      const std::vector<RigidTransform<double>> world = random_pose(character, random);
      skinner.skin(world, positions);
      const std::vector<Vector3d> expected = reference_positions(character, world);
      for (std::size_t i = 0; i < vertices.size(); ++i) worst = std::max(worst, (row(positions, i) - expected[i]).norm());
    }
    const double size = character_size(character);
    std::printf("%-26s %7zu vertices, size %8.3f: max |engine - reference| %.2e (%.2e of the size)\n", name.c_str(),
                vertices.size(), size, worst, worst / size);
    EXPECT_LE(worst, position_tolerance(character)) << name;
  }
}

// A shuffled subset with repeats, across meshes, gives exactly the full mesh's rows.
TEST(LbsTest, SubsetEqualsTheFullMeshOnItsVertices) {
  std::mt19937 random(5);
  for (const auto& [name, character] : test_characters()) {
    const std::vector<MeshVertex> all = all_vertices(character);
    std::vector<MeshVertex> subset;
    std::uniform_int_distribution<std::size_t> pick(0, all.size() - 1);
    for (std::size_t i = 0; i < std::max<std::size_t>(all.size() / 7, 3); ++i) subset.push_back(all[pick(random)]);
    subset.push_back(subset.front());

    LinearBlendSkinner full(character, all), part(character, subset);
    EXPECT_LE(part.palette_size(), full.palette_size()) << name;
    const std::vector<RigidTransform<double>> world = random_pose(character, random);
    std::vector<float> full_positions(3 * all.size()), part_positions(3 * subset.size());
    full.skin(world, full_positions);
    part.skin(world, part_positions);
    for (std::size_t i = 0; i < subset.size(); ++i) {
      const std::size_t r = std::size_t(std::find(all.begin(), all.end(), subset[i]) - all.begin());
      ASSERT_EQ(row(part_positions, i), row(full_positions, r)) << name << " subset row " << i;
    }
  }
}

// Poses of many frames for one character, frame after frame.
std::vector<RigidTransform<double>> random_frames(const Character& character, std::size_t frames, unsigned seed) {
  std::mt19937 random(seed);
  std::vector<RigidTransform<double>> all;
  for (std::size_t f = 0; f < frames; ++f) {
    const std::vector<RigidTransform<double>> world = random_pose(character, random);
    all.insert(all.end(), world.begin(), world.end());
  }
  return all;
}

// More frames than one chunk and a mesh of several blocks, so every way of splitting the work
// is exercised: two or three threads, frames in one call or one by one, give identical bits.
TEST(LbsTest, ThreadsAndBatchesGiveIdenticalBits) {
  const Character& body = test_characters().back().character;
  const std::vector<MeshVertex> vertices = all_vertices(body);
  const std::size_t frames = LinearBlendSkinner::kChunkFrames + 13, floats = 3 * vertices.size();
  ASSERT_GT(vertices.size(), 4 * LinearBlendSkinner::kBlockVertices);
  const std::vector<RigidTransform<double>> world = random_frames(body, frames, 3);

  std::vector<float> one(frames * floats), one_normals(frames * floats);
  LinearBlendSkinner single(body, vertices, {.threads = 1, .normals = true});
  single.skin_frames(frames, world, one, one_normals);
  for (const int threads : {2, 3}) {
    std::vector<float> many(frames * floats), many_normals(frames * floats);
    LinearBlendSkinner parallel(body, vertices, {.threads = threads, .normals = true});
    parallel.skin_frames(frames, world, many, many_normals);
    EXPECT_EQ(0, std::memcmp(one.data(), many.data(), one.size() * sizeof(float))) << threads << " threads";
    EXPECT_EQ(0, std::memcmp(one_normals.data(), many_normals.data(), one.size() * sizeof(float))) << threads;
  }
  std::vector<float> frame_positions(floats), frame_normals(floats);
  const std::size_t joints = std::size_t(body.skeleton.joint_count());
  LinearBlendSkinner parallel(body, vertices, {.threads = 2, .normals = true});
  for (std::size_t f = 0; f < frames; f += 37) {
    parallel.skin(std::span(world).subspan(f * joints, joints), frame_positions, frame_normals);
    EXPECT_EQ(0, std::memcmp(frame_positions.data(), one.data() + f * floats, floats * sizeof(float))) << "frame " << f;
    EXPECT_EQ(0, std::memcmp(frame_normals.data(), one_normals.data() + f * floats, floats * sizeof(float))) << f;
  }
}

TEST(LbsTest, NormalsAreUnitAndFollowTheReference) {
  std::mt19937 random(17);
  for (const auto& [name, character] : test_characters()) {
    const std::vector<MeshVertex> vertices = all_vertices(character);
    LinearBlendSkinner skinner(character, vertices, {.threads = 2, .normals = true});
    std::vector<float> positions(3 * vertices.size()), normals(3 * vertices.size());
    double worst = 0.0, worst_length = 0.0;
    std::size_t zero = 0;
    for (int pose = 0; pose < 3; ++pose) {
      const std::vector<RigidTransform<double>> world = random_pose(character, random);
      skinner.skin(world, positions, normals);
      const std::vector<Vector3d> expected = reference_normals(character, world);
      for (std::size_t i = 0; i < vertices.size(); ++i) {
        const Vector3d normal = row(normals, i);
        ASSERT_TRUE(normal.allFinite()) << name << " vertex " << i;
        if (expected[i].isZero()) {
          EXPECT_TRUE(normal.isZero()) << name << " vertex " << i;
          ++zero;
          continue;
        }
        worst = std::max(worst, (normal - expected[i]).norm());
        worst_length = std::max(worst_length, std::abs(normal.norm() - 1.0));
      }
    }
    std::printf("%-26s normals: max |engine - reference| %.2e, max ||n| - 1| %.2e, %zu zero\n", name.c_str(), worst,
                worst_length, zero / 3);
    EXPECT_LE(worst, 1e-4) << name;
    EXPECT_LE(worst_length, 1e-6) << name;
  }
}

// At the rest pose the rest normals are OpenMesh's, wherever OpenMesh could take every face
// around a vertex (normals.h: refused faces are added on copies of their corners).
TEST(NormalsTest, RestNormalsAreOpenMeshVertexNormals) {
  using Mesh = OpenMesh::TriMesh_ArrayKernelT<OpenMesh::DefaultTraitsDouble>;
  for (const auto& [name, character] : test_characters()) {
    for (const CharacterMesh& mesh : character.meshes) {
      Mesh open_mesh;
      for (const Vector3f& p : mesh.positions) open_mesh.add_vertex(Mesh::Point(p.x(), p.y(), p.z()));
      std::vector<bool> refused_corner(mesh.positions.size(), false);
      ::omerr().disable();
      for (std::size_t t = 0; t < mesh.triangles.size(); t += 3) {
        const std::uint32_t a = mesh.triangles[t], b = mesh.triangles[t + 1], c = mesh.triangles[t + 2];
        if (a == b || b == c || a == c) continue;
        if (!open_mesh.add_face(open_mesh.vertex_handle(a), open_mesh.vertex_handle(b), open_mesh.vertex_handle(c)).is_valid()) {
          refused_corner[a] = refused_corner[b] = refused_corner[c] = true;
        }
      }
      ::omerr().enable();
      open_mesh.request_face_normals();
      open_mesh.request_vertex_normals();
      open_mesh.update_normals();
      const std::vector<Vector3f> normals = rest_vertex_normals(mesh);
      double worst = 0.0;
      for (std::size_t v = 0; v < mesh.positions.size(); ++v) {
        if (refused_corner[v]) continue;
        const Mesh::Normal n = open_mesh.normal(open_mesh.vertex_handle(v));
        worst = std::max(worst, (normals[v].cast<double>() - Vector3d(n[0], n[1], n[2])).norm());
      }
      EXPECT_LE(worst, 1e-6) << name << " mesh " << mesh.name;
    }
  }
}

// One rigid joint at the origin carrying a hand-made mesh.
Character one_joint_character(std::vector<Vector3f> positions, std::vector<std::uint32_t> triangles) {
  Character character;
  character.skeleton = Skeleton({"root"}, {-1}, {Vector3d::Zero()});
  CharacterMesh mesh;
  mesh.name = "hand-made";
  mesh.positions = std::move(positions);
  mesh.triangles = std::move(triangles);
  mesh.skin_joints = {0};
  mesh.inverse_bind = {Eigen::Matrix4d::Identity()};
  mesh.influence_slots.assign(mesh.positions.size(), {0, 0, 0, 0});
  mesh.influence_weights.assign(mesh.positions.size(), {1.0f, 0.0f, 0.0f, 0.0f});
  character.meshes.push_back(std::move(mesh));
  return character;
}

// Three triangles on one edge (a complex edge OpenMesh refuses), a triangle with a repeated
// corner and a vertex on no triangle: each triangle's unit normal counts once at each corner, the
// degenerate one not at all, and the lone vertex's normal is zero, and stays zero when skinned.
TEST(NormalsTest, EveryTriangleCountsOnceEvenWhereTheMeshIsNotManifold) {
  const Character fin = one_joint_character({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {5, 5, 5}},
                                            {0, 1, 2, 1, 0, 3, 0, 1, 4, 2, 2, 4});
  const std::vector<Vector3f> normals = rest_vertex_normals(fin.meshes[0]);
  const Vector3d n0(0, 0, 1), n1(0, 0, 1), n2(0, -1, 0);  // unit normals of the three triangles
  EXPECT_LE((normals[0].cast<double>() - (n0 + n1 + n2).normalized()).norm(), 1e-6);
  EXPECT_LE((normals[1].cast<double>() - (n0 + n1 + n2).normalized()).norm(), 1e-6);
  EXPECT_LE((normals[2].cast<double>() - n0).norm(), 1e-6);
  EXPECT_LE((normals[3].cast<double>() - n1).norm(), 1e-6);
  EXPECT_LE((normals[4].cast<double>() - n2).norm(), 1e-6);
  EXPECT_TRUE(normals[5].isZero());

  const std::vector<MeshVertex> vertices = all_vertices(fin);
  LinearBlendSkinner skinner(fin, vertices, {.normals = true});
  std::vector<RigidTransform<double>> world(1);
  world[0].rotation = rodrigues(Vector3d(0.3, -0.2, 0.9));
  std::vector<float> positions(3 * vertices.size()), skinned(3 * vertices.size());
  skinner.skin(world, positions, skinned);
  EXPECT_EQ(row(skinned, 5), Vector3d::Zero());
  EXPECT_LE((row(skinned, 2) - world[0].rotation * n0).norm(), 1e-6);
}

// Skinning the body as a character at a body pose is the body model's forward pass without pose
// correctives (the plain synthetic body has at most four weights a vertex).
TEST(BodyCharacterTest, SkinsLikeTheBodyModelWithoutCorrectives) {
  const SyntheticBody body = make_synthetic_body(3);
  const std::vector<double> betas = {0.5, -0.8, 0.2, 0.0, 0.3};
  const Character character = body_character(body.model, betas);
  EXPECT_TRUE(character.warnings.empty());
  const int joints = body.model.joint_count();

  std::mt19937 random(23);
  std::normal_distribution<double> angle(0.0, 0.3);
  std::vector<double> pose(3 * joints);
  for (double& value : pose) value = angle(random);
  const Vector3d translation(0.2, -0.1, 0.9);

  BodyModelEvaluator evaluator(body.model, {.pose_correctives = false});
  evaluator.set_shape(betas);
  std::vector<double> model_joints(3 * joints), model_vertices(3 * std::size_t(body.model.vertex_count()));
  evaluator.evaluate(pose, translation, model_joints, std::span<double>(model_vertices));

  // The clip's frame: local rotations replace the rest rotations, the root at transl + J_0.
  std::vector<RigidTransform<double>> local(joints), world(joints);
  character.skeleton.rest_local(local);
  for (int j = 0; j < joints; ++j) local[j].rotation = rodrigues(Vector3d(pose[3 * j], pose[3 * j + 1], pose[3 * j + 2]));
  local[0].translation += translation;
  forward_kinematics<double>(character.skeleton.parents(), local, world);

  const std::vector<MeshVertex> vertices = all_vertices(character);
  LinearBlendSkinner skinner(character, vertices);
  std::vector<float> positions(3 * vertices.size());
  skinner.skin(world, positions);
  double worst = 0.0;
  for (std::size_t v = 0; v < vertices.size(); ++v) {
    worst = std::max(worst, (row(positions, v) - Vector3d(model_vertices[3 * v], model_vertices[3 * v + 1],
                                                          model_vertices[3 * v + 2])).norm());
  }
  EXPECT_LE(worst, 1e-5);

  // The dense variant has up to eight weights: the character keeps four and says so.
  const Character dense = body_character(make_synthetic_body(3, true).model);
  ASSERT_EQ(dense.warnings.size(), 1u);
  EXPECT_NE(dense.warnings[0].find("four largest"), std::string::npos);
}

#ifdef ODYSSEY_SKINNING_AVX512
// The kernel this build runs against the portable GLM one on random palettes and vertices.
template <int C>
void expect_kernels_agree(std::mt19937& random) {
  std::uniform_real_distribution<float> value(-2.0f, 2.0f), weight(0.05f, 1.0f);
  std::vector<kernel::PaletteEntry> palette(37);
  for (kernel::PaletteEntry& entry : palette) {
    entry.matrix = glm::mat4(1.0f);
    for (int c = 0; c < 4; ++c) {
      for (int r = 0; r < 3; ++r) entry.matrix[c][r] = value(random);
    }
  }
  const std::size_t count = 301;
  std::vector<glm::vec4> rest_positions(count), rest_normals(count);
  std::vector<std::uint32_t> entries(C * count), rows(count);
  std::vector<float> weights(C * count);
  for (std::size_t v = 0; v < count; ++v) {
    rest_positions[v] = {value(random), value(random), value(random), 1.0f};
    rest_normals[v] = {value(random), value(random), value(random), 0.0f};
    rows[v] = std::uint32_t(count - 1 - v);
    float total = 0.0f;
    for (int k = 0; k < C; ++k) total += weights[C * v + k] = weight(random);
    for (int k = 0; k < C; ++k) {
      weights[C * v + k] /= total;
      entries[C * v + k] = std::uint32_t(random() % palette.size());
    }
  }
  rest_normals[7] = glm::vec4(0.0f);  // a zero normal stays zero in both
  const kernel::GroupStreams streams{rest_positions.data(), rest_normals.data(), entries.data(), weights.data(), rows.data()};
  std::vector<float> fast(3 * count), fast_normals(3 * count), portable(3 * count), portable_normals(3 * count);
  kernel::skin_block_avx512<C, true>(palette.data(), streams, 0, count, fast.data(), fast_normals.data());
  kernel::skin_block_portable<C, true>(palette.data(), streams, 0, count, portable.data(), portable_normals.data());
  for (std::size_t i = 0; i < 3 * count; ++i) {
    EXPECT_NEAR(fast[i], portable[i], 4e-6f) << C << " influences, float " << i;
    EXPECT_NEAR(fast_normals[i], portable_normals[i], 4e-6f) << C << " influences, float " << i;
  }
  EXPECT_EQ(row(fast_normals, count - 1 - 7), Vector3d::Zero());
}

TEST(LbsKernelTest, Avx512AndPortableKernelsAgree) {
  std::mt19937 random(29);
  expect_kernels_agree<1>(random);
  expect_kernels_agree<2>(random);
  expect_kernels_agree<3>(random);
  expect_kernels_agree<4>(random);
}
#endif

// A vertex whose weights are all zero lands on the origin, as in the reference.
TEST(LbsTest, WeightlessVertexLandsOnTheOrigin) {
  Character character = one_joint_character({{1, 2, 3}, {4, 5, 6}}, {});
  character.meshes[0].influence_weights[1] = {0.0f, 0.0f, 0.0f, 0.0f};
  const std::vector<MeshVertex> vertices = all_vertices(character);
  LinearBlendSkinner skinner(character, vertices);
  EXPECT_EQ(skinner.influence_histogram(), (std::array<std::size_t, 4>{2, 0, 0, 0}));
  std::vector<RigidTransform<double>> world(1);
  world[0].translation = Vector3d(1, 1, 1);
  std::vector<float> positions(6);
  skinner.skin(world, positions);
  EXPECT_EQ(row(positions, 0), Vector3d(2, 3, 4));
  EXPECT_EQ(row(positions, 1), Vector3d::Zero());
  EXPECT_EQ(skin_mesh_reference(character.meshes[0], world)[1], Vector3d::Zero());
}

template <class F>
void expect_invalid(F&& call, const std::string& expected_part) {
  try {
    call();
    ADD_FAILURE() << "no exception; expected one mentioning '" << expected_part << "'";
  } catch (const std::invalid_argument& error) {
    EXPECT_NE(std::string(error.what()).find(expected_part), std::string::npos) << error.what();
  }
}

TEST(LbsTest, RejectsBadSetupsAndWrongSizes) {
  const Character good = one_joint_character({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, {0, 1, 2});
  const std::vector<MeshVertex> vertices = all_vertices(good);
  expect_invalid([&] { LinearBlendSkinner(good, vertices, {.threads = 0}); }, "at least 1 thread");
  expect_invalid([&] { LinearBlendSkinner(good, std::vector<MeshVertex>{{1, 0}}); }, "mesh 1 of 1");
  expect_invalid([&] { LinearBlendSkinner(good, std::vector<MeshVertex>{{0, 3}}); }, "vertex 3 of mesh 'hand-made'");

  Character bad = good;
  bad.meshes[0].inverse_bind.clear();
  expect_invalid([&] { LinearBlendSkinner(bad, vertices); }, "1 skin joints but 0 inverse bind matrices");
  bad = good;
  bad.meshes[0].skin_joints[0] = 4;
  expect_invalid([&] { LinearBlendSkinner(bad, vertices); }, "names joint 4, but the skeleton has 1 joints");
  bad = good;
  bad.meshes[0].influence_slots[2][3] = 1;
  expect_invalid([&] { LinearBlendSkinner(bad, vertices); }, "vertex 2 uses skin slot 1 of 1");
  bad = good;
  bad.meshes[0].influence_weights.pop_back();
  expect_invalid([&] { LinearBlendSkinner(bad, vertices); }, "3 positions but 3 influence slot rows and 2 weight rows");

  LinearBlendSkinner skinner(good, vertices);
  std::vector<RigidTransform<double>> world(1), two_joints(2);
  std::vector<float> positions(9), short_positions(8), normals(9);
  expect_invalid([&] { skinner.skin(two_joints, positions); }, "joint_world (frames x joints) holds 2 values, expected 1");
  expect_invalid([&] { skinner.skin(world, short_positions); }, "holds 8 values, expected 9");
  expect_invalid([&] { skinner.skin(world, positions, normals); }, "without SkinningOptions::normals");
  expect_invalid([&] { skinner.skin_frames(2, world, positions); }, "expected 2");
}

}  // namespace
}  // namespace odyssey::skinning
