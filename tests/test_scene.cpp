// Scenes: scene files (JSON paths in errors, unknown keys), placement and timing, footprints,
// cameras inside geometry, visibility against every actor and prop checked by brute-force ray
// casting, reproducibility, work skipped, and the example scenes end to end through the CLI.
#include <gtest/gtest.h>
#include <png.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <numbers>
#include <string>
#include <vector>

#include "cli_runner.h"
#include "mocap_io/gltf_character.h"
#include "mocap_io/gltf_subdivide.h"
#include "mocap_io/input_error.h"
#include "mocap_io/npy.h"
#include "mocap_io/trajectory_file.h"
#include "retarget/canonical.h"
#include "scene_layouts/pipeline.h"
#include "scene_layouts/scene_file.h"
#include "scene_support.h"
#include "test_support.h"

namespace odyssey {
namespace {

namespace fs = std::filesystem;
using test_support::contains;

const std::string kFigure = test_support::kSceneFigure;
const std::string kCesium = test_support::kSceneCesium;
using test_support::walker;


std::string parse_error(const std::string& json) {
  return test_support::message_of<io::InputError>([&] { scene::parse_scene(json, "shot.json"); });
}

TEST(SceneFileTest, ErrorsNameTheFileAndTheJsonPath) {
  const std::string actor = R"({"motion": "a.bvh", "character": "c.glb"})";
  EXPECT_TRUE(contains(parse_error(R"({"version": 1, "actors": [)" + actor + "," +
                                   R"({"motion": "a.bvh", "character": "c.glb", "placement": {"x": 0, "y": 0, "yaw": "left"}}]})"),
                       "shot.json: actors[1].placement.yaw: not a number"));
  EXPECT_TRUE(contains(parse_error(R"({"version": 1, "actors": [)" + actor + R"(], "lights": []})"),
                       "shot.json: lights: unknown key"));
  EXPECT_TRUE(contains(parse_error(R"({"version": 1, "actors": [{"motion": "a.bvh"}]})"), "actors[0].character: missing"));
  EXPECT_TRUE(contains(parse_error(R"({"actors": [)" + actor + "]}"), "shot.json: version: missing"));
  EXPECT_TRUE(contains(parse_error(R"({"version": 1, "actors": [)" + actor + "," +
                                   R"({"motion": "a.bvh", "character": "c.glb", "placement": {"x": 0, "x": 1}}]})"),
                       "shot.json: actors[1].placement.x: the key \"x\" is given twice in one object"));
  EXPECT_TRUE(contains(parse_error(R"({"version": 1, "version": 1, "actors": [)" + actor + "]}"),
                       "shot.json: version: the key \"version\" is given twice in one object"));
  EXPECT_TRUE(contains(parse_error(R"({"version": 2, "actors": [)" + actor + "]}"), "version: version 2 is not one"));
  EXPECT_TRUE(contains(parse_error(R"({"version": 1, "actors": []})"), "actors: a scene needs at least one actor"));
  EXPECT_TRUE(contains(parse_error(R"({"version": 1, "actors": [)" + actor + R"(], "cameras": [{"type": "ego", "actor": "nobody"}]})"),
                       "cameras[0].actor: no actor is called 'nobody'"));
  EXPECT_TRUE(contains(parse_error(R"({"version": 1, "actors": [)" + actor + R"(], "cameras": [{"type": "orbit", "position": [0, 0, 1]}]})"),
                       "cameras[0].position: not a key of a orbit camera"));
  EXPECT_TRUE(contains(parse_error(R"({"version": 1, "actors": [)" + actor +
                                   R"(], "props": [{"type": "box", "size": [1, 1]}]})"),
                       "props[0].size: a box's size is [x, y, z]"));
  EXPECT_TRUE(contains(parse_error(R"({"version": 1, "actors": [)" + actor +
                                   R"(], "cameras": [{"type": "static"}], "outputs": {"points_per_actor": 0}})"),
                       "zero points to track"));
  EXPECT_TRUE(contains(parse_error(R"({"version": 1, "actors": [)" + actor + R"(], "outputs": {"trajectories": true}})"),
                       "outputs.trajectories: trajectories need a camera"));
  EXPECT_TRUE(contains(parse_error(R"({"version": 1, "actors": [{"motion": 3, "character": "c.glb"}]})"),
                       "actors[0].motion: not a string"));
  EXPECT_TRUE(contains(parse_error(R"({"version": 1, "actors": [{"motion": "a.bvh", "character": "c.glb", "contact_lift": -1}]})"),
                       "actors[0].contact_lift:"));
  EXPECT_TRUE(contains(parse_error(R"({"version": 1, "actors": [{"motion": "a.bvh", "character": "c.glb", "contact_lift": "no"}]})"),
                       "actors[0].contact_lift: expected metres (>= 0) or \"off\""));
  EXPECT_TRUE(contains(parse_error(R"({"version": 1, "actors": [{"motion": "a.bvh", "character": "c.glb", "quality": "fast",
                                      "weights": {"pose": 1}}]})"),
                       "actors[0].weights: a refinement setting, which quality fast does not run"));
  EXPECT_TRUE(contains(parse_error(std::string(200, '[') + std::string(200, ']')), "nested deeper than 64 levels"));
  EXPECT_TRUE(contains(parse_error("{\"version\": 1,"), "shot.json: not valid JSON"));
  // Found by fuzz_scene: a number beyond double's range is nlohmann's out_of_range, not a parse error.
  EXPECT_TRUE(contains(parse_error("{\"version\": 1, \"fps\": 8.9E99999}"), "shot.json: not valid JSON: [json.exception.out_of_range.406]"));
}

TEST(SceneFileTest, PathsResolveAgainstTheFileOrTheBundledData) {
  const scene::SceneFile file = scene::parse_scene(
      R"({"version": 1, "actors": [{"motion": "data:mocap/cmu_walk_cgspeed.bvh", "character": "chars/c.glb",
          "placement": {"x": 1, "y": 2, "yaw": 30}, "trim": [0.5, 2], "speed": 2, "start": [1, 3], "contact_lift": 0.05},
                     {"motion": "a.bvh", "character": "c.glb"}, {"motion": "a.bvh", "character": "c.glb", "contact_lift": "off"}],
          "props": [{"type": "mesh", "path": "/abs/table.obj", "up": "z"}]})",
      "/some/where/shot.json");
  const scene::SceneActor& actor = file.scene.actors[0];
  const auto request = [&](std::size_t a) -> const scene::RetargetRequest& {
    return std::get<scene::RetargetRequest>(file.scene.actors[a].source);
  };
  EXPECT_EQ(fs::path(request(0).motion_path), fs::path(scene::bundled_data_folder()) / "mocap/cmu_walk_cgspeed.bvh");
  EXPECT_EQ(request(0).character_path, "/some/where/chars/c.glb");
  EXPECT_EQ(request(0).quality, retarget::Quality::balanced);
  EXPECT_EQ(request(0).refine_options.contact_lift, 0.05);
  EXPECT_EQ(request(1).refine_options.contact_lift, 0.03);
  EXPECT_FALSE(request(2).refine_options.contact_lift);
  EXPECT_EQ(actor.placement.kind, scene::Placement::Kind::fixed);
  EXPECT_DOUBLE_EQ(actor.placement.yaw_deg, 30);
  EXPECT_DOUBLE_EQ(actor.trim_start_s, 0.5);
  EXPECT_DOUBLE_EQ(*actor.trim_end_s, 2);
  EXPECT_DOUBLE_EQ(actor.speed, 2);
  ASSERT_TRUE(actor.start_range);
  EXPECT_EQ(*actor.start_range, std::pair(1.0, 3.0));
  EXPECT_EQ(file.scene.props[0].path, "/abs/table.obj");
  EXPECT_TRUE(file.scene.props[0].up_z);
  EXPECT_EQ(actor.name, "actor0");
}

// The root at frame 0 lands on (x, y), the actor faces `yaw` there, and heights do not change.
TEST(ScenePipelineTest, PlacementMovesAndTurnsTheMotionAndKeepsTheFeetOnTheFloor) {
  scene::Scene shot;
  shot.actors = {walker("recorded", kFigure, 0, 0, 0), walker("placed", kFigure, 3, -2, 90)};
  shot.actors[0].placement.kind = scene::Placement::Kind::as_recorded;
  shot.seconds = 1;
  const scene::SceneResult result = scene::run_scene(shot);
  ASSERT_EQ(result.frames, 31);
  const scene::RetargetedActor& retargeted = *result.actors[1].retargeted;
  EXPECT_EQ(result.actors[0].retargeted.get(), result.actors[1].retargeted.get()) << "identical requests retarget once";
  const int pelvis = retargeted.target_map.joints[retarget::canonical::pelvis];
  std::vector<RigidTransform<double>> recorded(retargeted.character.skeleton.joint_count()), placed(recorded.size());
  for (int f : {0, 15, 30}) {
    result.actors[0].clip.world_pose(f, recorded);
    result.actors[1].clip.world_pose(f, placed);
    for (std::size_t j = 0; j < placed.size(); ++j) {
      EXPECT_NEAR(placed[j].translation.z(), recorded[j].translation.z(), 1e-9) << "frame " << f << " joint " << j;
    }
    if (f == 0) {
      EXPECT_NEAR(placed[pelvis].translation.x(), 3, 1e-9);
      EXPECT_NEAR(placed[pelvis].translation.y(), -2, 1e-9);
    }
  }
  EXPECT_NEAR(result.actors[1].yaw_deg, 90, 1e-9);
  // The walk goes where the actor faces: after a second the root has moved along +y.
  result.actors[1].clip.world_pose(30, placed);
  EXPECT_GT(placed[pelvis].translation.y() - -2, 0.5);
  EXPECT_LT(std::abs(placed[pelvis].translation.x() - 3), 0.3);
}

TEST(ScenePipelineTest, TimingHoldsTheFirstPoseBeforeTheStartAndPlaysAtTheSpeed) {
  scene::Scene shot;
  shot.actors = {walker("late", kFigure, 0, 0, 0), walker("fast", kFigure, 0, 3, 0)};
  shot.actors[0].start_s = 0.5;
  shot.actors[1].speed = 2;
  shot.actors[1].trim_start_s = 0.4;
  const scene::SceneResult result = scene::run_scene(shot);
  const Clip& source = result.actors[0].retargeted->clip();
  // The scene lasts until the late actor's clip ends: 0.5 s + its duration.
  EXPECT_EQ(result.frames, static_cast<int>(std::floor((0.5 + source.duration()) * 30 + 1e-6)) + 1);
  const int joints = source.joint_count();
  const Clip late = result.actors[0].clip.stored_clip(), fast = result.actors[1].clip.stored_clip();
  EXPECT_DOUBLE_EQ(result.actors[1].clip.source_time(10), 0.4 + 2 * 10 / 30.0);
  for (int j = 1; j < joints; ++j) {
    EXPECT_TRUE(late.rotation(0, j).isApprox(late.rotation(15, j), 1e-12)) << j;
    // Frame 10 of "fast" is clip time 0.4 + 2 * 10/30 s: frame 32 of the 30 fps clip.
    EXPECT_LT(fast.rotation(10, j).angularDistance(source.rotation(32, j)), 1e-9) << j;
  }
}

TEST(ScenePipelineTest, OverlappingActorsAndCamerasInsideGeometryAreErrors) {
  scene::Scene shot;
  shot.actors = {walker("ann", kFigure, 0, 0, 0), walker("bob", kFigure, 0.1, 0, 0)};
  shot.seconds = 0.5;
  std::string message = test_support::message_of<std::invalid_argument>([&] { scene::run_scene(shot); });
  EXPECT_TRUE(contains(message, "actors 'ann' and 'bob' overlap at frame 0")) << message;

  // Placed at random in a region, the second is drawn again until clear: reproducibly.
  shot.actors[1].placement.kind = scene::Placement::Kind::random;
  shot.actors[1].placement.region = Eigen::AlignedBox2d(Eigen::Vector2d(-3, -3), Eigen::Vector2d(3, 3));
  shot.actors[0].start_range = std::pair(0.2, 0.6);
  const scene::SceneResult first = scene::run_scene(shot);
  const scene::SceneResult second = scene::run_scene(shot);
  EXPECT_EQ(first.actors[1].x, second.actors[1].x);
  EXPECT_EQ(first.actors[1].yaw_deg, second.actors[1].yaw_deg);
  EXPECT_EQ(first.actors[0].start_s, second.actors[0].start_s);
  EXPECT_GE(first.actors[0].start_s, 0.2);
  EXPECT_LE(first.actors[0].start_s, 0.6);
  shot.seed = 1;
  EXPECT_NE(scene::run_scene(shot).actors[1].x, first.actors[1].x);

  scene::Scene boxed;
  boxed.actors = {walker("ann", kFigure, 0, 0, 0)};
  boxed.seconds = 0.2;
  scene::Prop box;
  box.name = "crate";
  box.size = Eigen::Vector3d(1, 1, 1);
  box.position = Eigen::Vector3d(4, 4, 0);
  boxed.props = {box};
  scene::SceneCamera camera;
  camera.name = "inside";
  camera.rig = scene::StaticRig{.position = Eigen::Vector3d(4, 4, 0.5), .target = Eigen::Vector3d(0, 0, 1)};
  boxed.cameras = {camera};
  const fs::path dir = test_support::scratch_dir("scene");
  boxed.outputs.trajectories = {(dir / "t.npz").string()};
  message = test_support::message_of<std::invalid_argument>([&] { scene::run_scene(boxed); });
  EXPECT_TRUE(contains(message, "camera 'inside' is inside prop 'crate' at frame 0")) << message;
  EXPECT_TRUE(test_support::files_in(dir).empty());
}

// Reference geometry of one frame: every triangle of every actor and prop in world coordinates,
// with its owner (actor index, or -1 - prop).
struct Triangle {
  Eigen::Vector3d a, b, c;
  int owner;
};

std::vector<Triangle> scene_triangles(const scene::SceneResult& result, int frame) {
  std::vector<Triangle> triangles;
  for (std::size_t a = 0; a < result.actors.size(); ++a) {
    const Character& character = result.actors[a].retargeted->character;
    std::vector<RigidTransform<double>> world(character.skeleton.joint_count());
    result.actors[a].clip.world_pose(frame, world);
    for (const CharacterMesh& mesh : character.meshes) {
      const std::vector<Eigen::Vector3d> v = skin_mesh_reference(mesh, world);
      for (std::size_t t = 0; t < mesh.triangles.size(); t += 3) {
        triangles.push_back({v[mesh.triangles[t]], v[mesh.triangles[t + 1]], v[mesh.triangles[t + 2]], static_cast<int>(a)});
      }
    }
  }
  for (std::size_t p = 0; p < result.props.character.meshes.size(); ++p) {
    const CharacterMesh& mesh = result.props.character.meshes[p];
    for (std::size_t t = 0; t < mesh.triangles.size(); t += 3) {
      triangles.push_back({mesh.positions[mesh.triangles[t]].cast<double>(), mesh.positions[mesh.triangles[t + 1]].cast<double>(),
                           mesh.positions[mesh.triangles[t + 2]].cast<double>(), -1 - static_cast<int>(p)});
    }
  }
  return triangles;
}

// The owner of the nearest triangle crossing the segment from `from` to `to` more than 1e-4 of its length
// before `to` (Moller-Trumbore), or none.
std::optional<int> first_hit(const std::vector<Triangle>& triangles, const Eigen::Vector3d& from, const Eigen::Vector3d& to) {
  const Eigen::Vector3d ray = to - from;
  double nearest = INFINITY;
  std::optional<int> owner;
  for (const Triangle& t : triangles) {
    const Eigen::Vector3d e1 = t.b - t.a, e2 = t.c - t.a;
    const Eigen::Vector3d pv = ray.cross(e2);
    const double det = e1.dot(pv);
    if (std::abs(det) < 1e-15) continue;
    const Eigen::Vector3d tv = from - t.a;
    const double u = tv.dot(pv) / det;
    const Eigen::Vector3d qv = tv.cross(e1);
    const double v = ray.dot(qv) / det;
    const double s = e2.dot(qv) / det;
    if (u >= 0 && v >= 0 && u + v <= 1 && s > 0 && s < 1 - 1e-4 && s < nearest) {
      nearest = s;
      owner = t.owner;
    }
  }
  return owner;
}

// How a trajectory file's visibility compares with a brute-force ray cast against every triangle
// of every actor and prop, over every `stride`-th point of the given frames.
struct BruteForceAgreement {
  std::size_t checked = 0, agree = 0, missed = 0, hidden = 0, by_actor = 0, by_prop = 0, code_agree = 0;
};

BruteForceAgreement compare_with_brute_force(const scene::SceneResult& result, const fs::path& npz,
                                             const std::vector<int>& frames, std::size_t stride) {
  const io::NpzReader file(npz.string());
  const std::vector<float> p3 = file.load("trajs_3d").to_float();
  const std::vector<double> valids = file.load("valids").to_double(), visibs = file.load("visibs").to_double();
  const std::vector<std::int64_t> codes = file.load("visibility_codes").to_int64();
  const std::size_t n = file.load("point_actor_ids").to_int64().size();
  BruteForceAgreement counts;
  for (const int f : frames) {
    const Eigen::Vector3d centre = result.cameras[0].path.poses[f].centre();
    const std::vector<Triangle> triangles = scene_triangles(result, f);
    for (std::size_t i = 0; i < n; i += stride) {
      if (valids[f * n + i] == 0) continue;
      const Eigen::Vector3d point(p3[(f * n + i) * 3], p3[(f * n + i) * 3 + 1], p3[(f * n + i) * 3 + 2]);
      const std::optional<int> hit = first_hit(triangles, centre, point);
      ++counts.checked;
      counts.agree += (visibs[f * n + i] != 0) == !hit;
      counts.missed += visibs[f * n + i] != 0 && hit;
      if (!hit) continue;
      ++counts.hidden;
      const bool actor = *hit >= 0;
      counts.by_actor += actor;
      counts.by_prop += !actor;
      counts.code_agree += codes[f * n + i] == (actor ? io::kOccludedByActor : io::kOccludedByProp);
    }
  }
  std::printf("visibs agree with the brute-force ray cast on %zu of %zu valid points (%zu hidden ones called visible); "
              "%zu hidden (%zu by actors, %zu by props), codes agree on %zu\n",
              counts.agree, counts.checked, counts.missed, counts.hidden, counts.by_actor, counts.by_prop, counts.code_agree);
  return counts;
}

// Two people, one behind the other and both partly behind a box, seen by a static camera: every
// valid point's visibility and its code agree with a brute-force ray cast against every triangle
// of every actor and prop.
TEST(ScenePipelineTest, VisibilityAgreesWithBruteForceRayCastingAcrossActorsAndProps) {
  scene::Scene shot;
  shot.actors = {walker("near", kFigure, 0, -1, 0), walker("far", kCesium, 0.3, 1.2, 0)};
  shot.seconds = 1;
  scene::Prop floor;
  floor.kind = scene::Prop::Kind::ground;
  floor.name = "floor";
  floor.size = Eigen::Vector3d(8, 8, 0);
  scene::Prop box;
  box.name = "crate";
  box.size = Eigen::Vector3d(0.6, 0.6, 0.8);
  box.position = Eigen::Vector3d(0.8, -2.2, 0);
  shot.props = {floor, box};
  scene::SceneCamera camera;
  camera.name = "side";
  camera.rig = scene::StaticRig{.position = Eigen::Vector3d(1.5, -6, 1.2), .target = Eigen::Vector3d(0.6, 0, 0.9)};
  shot.cameras = {camera};
  shot.outputs.points_per_actor = 1500;
  shot.outputs.prop_points = 1500;
  const fs::path dir = test_support::scratch_dir("scene");
  shot.outputs.trajectories = {(dir / "side.npz").string()};
  shot.outputs.report = (dir / "report.json").string();
  const scene::SceneResult result = scene::run_scene(shot);

  const io::NpzReader file((dir / "side.npz").string());
  const std::vector<double> visibs = file.load("visibs").to_double();
  const std::vector<std::int64_t> codes = file.load("visibility_codes").to_int64();
  const std::vector<std::int64_t> ids = file.load("point_actor_ids").to_int64();
  ASSERT_EQ(ids.size(), 1500u * 3);
  EXPECT_EQ(std::count(ids.begin(), ids.end(), 0), 1500);
  EXPECT_EQ(std::count(ids.begin(), ids.end(), 1), 1500);
  EXPECT_EQ(std::count_if(ids.begin(), ids.end(), [](std::int64_t id) { return id == -1 || id == -2; }), 1500);
  const BruteForceAgreement counts = compare_with_brute_force(result, dir / "side.npz", {0, 15, 30}, 3);
  ASSERT_GT(counts.checked, 2000u);
  EXPECT_GE(static_cast<double>(counts.agree) / counts.checked, 0.999) << counts.agree << " of " << counts.checked;
  EXPECT_GT(counts.by_actor, 100u) << "the near actor hides part of the far one";
  EXPECT_GT(counts.by_prop, 50u) << "the crate hides part of the near actor";
  EXPECT_GE(static_cast<double>(counts.code_agree) / counts.hidden, 0.99) << counts.code_agree << " of " << counts.hidden;
  for (std::size_t k = 0; k < codes.size(); ++k) {
    ASSERT_EQ(codes[k] == io::kVisible, visibs[k] != 0) << k;
  }
  const nlohmann::json report = nlohmann::json::parse(std::ifstream(dir / "report.json"));
  EXPECT_EQ(report["actors"].size(), 2u);
  EXPECT_EQ(report["props"][1]["id"], -2);
  EXPECT_GT(report["cameras"][0]["point_frames"]["occluded_by_prop"].get<double>(), 0.0);
}

// Characters as dense as a dataset's (the shared ones subdivided to 25,000-40,000 vertices, so
// that many triangles are smaller than a pixel), walking side by side so that arms pass before
// bodies, under a camera orbiting at 960x540: visibility agrees with the brute-force ray cast on
// at least 99.9% of the valid points.
TEST(ScenePipelineTest, VisibilityOnDenseCharactersAgreesWithBruteForce) {
  const fs::path dir = test_support::scratch_dir("scene_dense");
  const fs::path dense_figure = dir / "RiggedFigure_x4.glb", dense_cesium = dir / "CesiumMan_x2.glb";
  const io::SubdividedGltf figure = io::write_subdivided_glb(kFigure, dense_figure.string(), 4);
  const io::SubdividedGltf cesium = io::write_subdivided_glb(kCesium, dense_cesium.string(), 2);
  std::printf("dense characters: RiggedFigure %zu -> %zu vertices, CesiumMan %zu -> %zu\n", figure.vertices_before,
              figure.vertices_after, cesium.vertices_before, cesium.vertices_after);
  ASSERT_GE(figure.vertices_after, 25000u);
  ASSERT_GE(cesium.vertices_after, 25000u);
  scene::Scene shot;
  shot.actors = {walker("figure", dense_figure.string(), 0, -0.5, 0), walker("cesium", dense_cesium.string(), 0.2, 0.5, 0)};
  shot.seconds = 2;
  scene::Prop floor;
  floor.kind = scene::Prop::Kind::ground;
  floor.name = "floor";
  floor.size = Eigen::Vector3d(12, 12, 0);
  shot.props = {floor};
  scene::SceneCamera camera;
  camera.name = "orbit";
  camera.rig = scene::OrbitRig{.target = Eigen::Vector3d(0.8, 0, 0.9), .radius = 7.0, .height_m = 1.6, .start_angle_deg = 0.0, .period_s = 4};
  shot.cameras = {camera};
  shot.outputs.points_per_actor = 3000;
  shot.outputs.prop_points = 0;
  shot.outputs.trajectories = {(dir / "orbit.npz").string()};
  const scene::SceneResult result = scene::run_scene(shot);
  const BruteForceAgreement counts = compare_with_brute_force(result, dir / "orbit.npz", {0, 10, 20, 30, 40, 50}, 2);
  ASSERT_GT(counts.checked, 5000u);
  EXPECT_GT(counts.hidden, 1000u) << "the camera goes round: each walker hides part of the other and of itself";
  EXPECT_GE(static_cast<double>(counts.agree) / counts.checked, 0.999) << counts.agree << " of " << counts.checked;
}

// A camera that looks away from an actor never rasterises it, and says so.
TEST(ScenePipelineTest, ActorsNoCameraSeesAreNotSkinned) {
  scene::Scene shot;
  shot.actors = {walker("seen", kFigure, 0, 0, 0), walker("behind", kFigure, 0, -8, 0)};
  shot.seconds = 0.5;
  scene::SceneCamera camera;
  camera.name = "front";
  camera.rig = scene::StaticRig{.position = Eigen::Vector3d(0, -3, 1.2), .target = Eigen::Vector3d(0, 0, 1)};
  shot.cameras = {camera};
  shot.outputs.points_per_actor = 200;
  const fs::path dir = test_support::scratch_dir("scene");
  shot.outputs.trajectories = {(dir / "front.npz").string()};
  const scene::SceneResult result = scene::run_scene(shot);
  EXPECT_EQ(result.streams.actor_mesh_frames[0], result.frames);
  EXPECT_EQ(result.streams.actor_mesh_frames[1], 0);
  EXPECT_EQ(result.streams.cameras[0].actor_frames_culled[1], result.frames);
  bool listed = false;
  for (const std::string& line : result.skipped) listed |= contains(line, "actor 'behind': mesh not skinned in 16 of 16 frames");
  EXPECT_TRUE(listed);
  const std::vector<std::int64_t> codes = io::NpzReader((dir / "front.npz").string()).load("visibility_codes").to_int64();
  for (std::size_t f = 0; f < 16; ++f) {
    for (std::size_t i = 200; i < 400; ++i) EXPECT_EQ(codes[f * 400 + i], io::kBehindCamera);
  }
}

// The example prints, runs as printed from another folder, and its head camera sees the person in
// front: most of the leader's points are valid in most frames. Run twice, byte-identical files.
// Mesh props: an OBJ (Y up, as Blender exports) and a GLB at its rest pose, each turned, scaled and
// moved as the scene says; a broken OBJ names its line.
TEST(ScenePipelineTest, MeshPropsFromObjAndGlbAreTurnedScaledAndPlaced) {
  const fs::path dir = test_support::scratch_dir("scene");
  std::ofstream(dir / "wedge.obj") << "# a wedge\nv 0 0 0\nv 1 0 0\nv 0 2 0\nv 0 0 3\nf 1 2 3\nf 1/1/1 3/1/1 4/1/1\nf -4 -3 -1\n";
  scene::Scene shot;
  shot.actors = {walker("solo", kFigure, 0, 0, 0)};
  shot.seconds = 0.1;
  scene::Prop wedge;
  wedge.kind = scene::Prop::Kind::mesh;
  wedge.name = "wedge";
  wedge.path = (dir / "wedge.obj").string();
  wedge.position = Eigen::Vector3d(5, 0, 0);
  wedge.yaw_deg = 90;
  wedge.scale = 2;
  scene::Prop cylinder = wedge;
  cylinder.name = "cylinder";
  cylinder.path = std::string(ODYSSEY_SHARED_DIR) + "/assets/characters/RiggedSimple.glb";
  cylinder.position = Eigen::Vector3d(-5, 1, 0);
  cylinder.yaw_deg = 0;
  cylinder.scale = 1;
  shot.props = {wedge, cylinder};
  const scene::SceneResult result = scene::run_scene(shot);
  ASSERT_EQ(result.props.character.meshes.size(), 2u);
  const CharacterMesh& w = result.props.character.meshes[0];
  ASSERT_EQ(w.positions.size(), 4u);
  EXPECT_EQ(w.triangles.size(), 9u);
  // OBJ (x, y, z) Y up is (x, -z, y) Z up; yaw 90 turns (x, y) to (-y, x); then x2 and + (5, 0, 0).
  const auto expected = [](double x, double y, double z) {
    const Eigen::Vector3d z_up(x, -z, y);
    return Eigen::Vector3d(5 - 2 * z_up.y(), 2 * z_up.x(), 2 * z_up.z());
  };
  EXPECT_LT((w.positions[1].cast<double>() - expected(1, 0, 0)).norm(), 1e-6);
  EXPECT_LT((w.positions[2].cast<double>() - expected(0, 2, 0)).norm(), 1e-6);
  EXPECT_LT((w.positions[3].cast<double>() - expected(0, 0, 3)).norm(), 1e-6);
  // The GLB at rest, moved by (-5, 1, 0): its box is the character's rest box moved so.
  const Eigen::AlignedBox3d rest = io::load_character(cylinder.path).rest_bounds();
  Eigen::AlignedBox3d placed;
  for (const Eigen::Vector3f& p : result.props.character.meshes[1].positions) placed.extend(p.cast<double>());
  EXPECT_LT((placed.min() - (rest.min() + cylinder.position)).norm(), 1e-5);
  EXPECT_LT((placed.max() - (rest.max() + cylinder.position)).norm(), 1e-5);

  std::ofstream(dir / "broken.obj") << "v 0 0 0\nv 1 0 0\nf 1 2 7\n";
  shot.props = {wedge};
  shot.props[0].path = (dir / "broken.obj").string();
  const std::string message = test_support::message_of<io::InputError>([&] { scene::run_scene(shot); });
  EXPECT_TRUE(contains(message, "broken.obj: line 3: face corner 7 names a vertex not defined before it")) << message;
}

// A contact sheet: six half-size tiles, the actor drawn in its colour where the camera sees it,
// green dots on its visible points, read back with libpng.
TEST(ScenePipelineTest, ContactSheetShowsTheActorAndItsVisiblePoints) {
  scene::Scene shot;
  shot.actors = {walker("solo", kFigure, 0, 0, 0)};
  shot.seconds = 1;
  scene::SceneCamera camera;
  camera.name = "front";
  camera.rig = scene::StaticRig{.position = Eigen::Vector3d(0.6, -3.5, 1.0), .target = Eigen::Vector3d(0.6, 0, 0.8)};
  shot.cameras = {camera};
  shot.outputs.points_per_actor = 500;
  const fs::path dir = test_support::scratch_dir("scene");
  shot.outputs.previews = {(dir / "front.png").string()};
  const scene::SceneResult result = scene::run_scene(shot);
  EXPECT_EQ(result.outputs, std::vector<std::string>{(dir / "front.png").string()});

  png_image image{};
  image.version = PNG_IMAGE_VERSION;
  ASSERT_TRUE(png_image_begin_read_from_file(&image, (dir / "front.png").c_str())) << image.message;
  image.format = PNG_FORMAT_RGB;
  std::vector<std::uint8_t> rgb(PNG_IMAGE_SIZE(image));
  ASSERT_TRUE(png_image_finish_read(&image, nullptr, rgb.data(), 0, nullptr)) << image.message;
  EXPECT_EQ(image.width, 3u * 480 + 2 * 4);
  EXPECT_EQ(image.height, 2u * 270 + 4);
  std::size_t actor = 0, green = 0, background = 0;
  for (std::size_t p = 0; p < rgb.size(); p += 3) {
    const int r = rgb[p], g = rgb[p + 1], b = rgb[p + 2];
    actor += b > r + 30 && b > g + 10;            // the first actor's blue, shaded
    green += g > 150 && r < 140 && b < 140;       // visible points
    background += r == 40 && g == 40 && b == 46;  // nothing drawn
  }
  EXPECT_GT(actor, 2000u);
  EXPECT_GT(green, 200u);
  EXPECT_GT(background, rgb.size() / 3 / 2) << "most of each tile is empty floorless space";
}

// The bundled indoor scene, as `odyssey scene --example` prints it, writes its PointOdyssey
// sequences (anno.npz, depth, normals, masks per camera) from any folder, the same bytes twice.
TEST(SceneCliTest, TheExampleRunsFromAnyFolderAndTheHeadCameraSeesTheOtherPerson) {
  const fs::path dir = test_support::scratch_dir("scene_cli");
  const test_support::CliResult example = test_support::run_cli("scene --example");
  ASSERT_EQ(example.exit_code, 0) << example.output;
  std::ofstream(dir / "copy.json") << example.output;
  const std::string command = "scene " + (dir / "copy.json").string() + " --out ";
  const test_support::CliResult run = test_support::run_cli_in("/", command + (dir / "out").string());
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const io::NpzReader head((dir / "out" / "indoor_head" / "anno.npz").string());
  const std::vector<std::int64_t> ids = head.load("point_actor_ids").to_int64();
  const std::vector<double> valids = head.load("valids").to_double();
  const std::size_t n = ids.size(), frames = valids.size() / n;
  std::size_t frames_mostly_valid = 0;
  for (std::size_t f = 0; f < frames; ++f) {
    std::size_t leader = 0, valid = 0;
    for (std::size_t i = 0; i < n; ++i) {
      if (ids[i] != 1) continue;
      ++leader;
      valid += valids[f * n + i] != 0;
    }
    frames_mostly_valid += valid * 2 > leader;
  }
  EXPECT_GT(frames_mostly_valid * 2, frames) << frames_mostly_valid << " of " << frames;
  for (const char* name : {"indoor_orbit/anno.npz", "indoor_corner/anno.npz", "indoor_head/depths/depth_00000.png",
                           "indoor_head/normals/normal_00000.jpg", "indoor_corner/masks/mask_00050.png",
                           "indoor_orbit/scene_info.json", "camera_head.json", "report.json", "retarget_leader.json",
                           "preview_head.png", "scene.glb"}) {
    EXPECT_TRUE(fs::exists(dir / "out" / name)) << name;
  }
  const test_support::CliResult again = test_support::run_cli_in("/", command + (dir / "again").string() + " --quiet");
  ASSERT_EQ(again.exit_code, 0) << again.output;
  for (const char* name : {"indoor_head/anno.npz", "indoor_orbit/anno.npz", "indoor_orbit/depths/depth_00040.png",
                           "indoor_head/masks/mask_00040.png", "camera_orbit.json"}) {
    std::ifstream a(dir / "out" / name, std::ios::binary), b(dir / "again" / name, std::ios::binary);
    const std::string x((std::istreambuf_iterator<char>(a)), {}), y((std::istreambuf_iterator<char>(b)), {});
    EXPECT_TRUE(x == y) << name << " differs between two runs";
  }
}

TEST(SceneCliTest, BadScenesFailNamingTheProblemAndWriteNothing) {
  const fs::path dir = test_support::scratch_dir("scene_cli");
  const std::string good_actor = R"({"name": "a", "motion": "data:mocap/cmu_walk_cgspeed.bvh", "bvh_units": "cmu",
      "character": "data:characters/RiggedFigure.glb", "quality": "fast"})";
  struct Case {
    std::string json, message;
  };
  const Case cases[] = {
      {R"({"version": 1, "actors": [{"name": "a", "motion": "missing.bvh", "character": "data:characters/RiggedFigure.glb"}]})",
       "missing.bvh: no such file"},
      {R"({"version": 1, "actors": [)" + good_actor + "," +
           R"({"name": "b", "motion": "data:mocap/cmu_walk_cgspeed.bvh", "bvh_units": "cmu", "character": "data:characters/RiggedFigure.glb", "quality": "fast"}],
           "cameras": [{"type": "static"}]})",
       "actors 'a' and 'b' overlap at frame 0"},
      {R"({"version": 1, "actors": [)" + good_actor + R"(], "props": [{"type": "mesh", "path": "table.obj"}], "cameras": [{"type": "static"}]})",
       "table.obj: no such file"},
      {R"({"version": 1, "actors": [)" + good_actor + R"(], "cameras": [{"type": "static", "hfov": 0}]})",
       "cameras[0].hfov: expected degrees between 0 and 180"},
  };
  int index = 0;
  for (const Case& bad : cases) {
    const fs::path file = dir / ("bad" + std::to_string(index++) + ".json");
    std::ofstream(file) << bad.json;
    const fs::path out = dir / "out";
    const test_support::CliResult result = test_support::run_cli("scene " + file.string() + " --out " + out.string());
    EXPECT_EQ(result.exit_code, 1) << bad.json << "\n" << result.output;
    EXPECT_TRUE(contains(result.output, bad.message)) << bad.json << "\n" << result.output;
    EXPECT_TRUE(!fs::exists(out) || test_support::files_in(out).empty()) << result.output;
  }
}

}  // namespace
}  // namespace odyssey
