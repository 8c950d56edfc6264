// Props that react (scene_layouts/prop_physics.h): a dropped box settles on the ground, a box on a
// walker's path is kicked forward when the feet reach it and not before, the same scene gives the
// same bytes whatever the thread count, and bad dynamic keys name the file and the JSON path.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "mocap_io/anime_file.h"
#include "mocap_io/input_error.h"
#include "mocap_io/npy.h"
#include "scene_layouts/frame_loop.h"
#include "scene_layouts/pipeline.h"
#include "scene_layouts/placement.h"
#include "scene_layouts/scene_file.h"
#include "scene_layouts/shot.h"
#include "scene_support.h"
#include "test_support.h"

namespace odyssey {
namespace {

using test_support::contains;

// One walker placed at (x, y) facing yaw, tracking no points of its own, a camera far off, and
// `props` with 300 tracked points among them.
scene::Scene shot_with(const std::vector<scene::Prop>& props, double x, double y, double yaw, double seconds) {
  scene::Scene s;
  s.name = "physics";
  s.seconds = seconds;
  s.actors.push_back(test_support::walker("walker", test_support::kSceneFigure, x, y, yaw));
  s.actors.back().points = 0;
  s.props = props;
  scene::SceneCamera camera;
  camera.name = "far";
  camera.rig = scene::StaticRig{Eigen::Vector3d(0, -20, 4), Eigen::Vector3d(0, 0, 0.5), 0};
  s.cameras.push_back(camera);
  s.outputs.prop_points = 300;
  return s;
}

scene::Prop dynamic_box(const std::string& name, const Eigen::Vector3d& position, double edge) {
  scene::Prop box;
  box.name = name;
  box.kind = scene::Prop::Kind::box;
  box.size = Eigen::Vector3d::Constant(edge);
  box.position = position;
  box.dynamics.emplace();
  return box;
}

// The props' tracked points of every frame, [frame][point][xyz], through the frame loop.
std::vector<Eigen::Vector3f> prop_trajectories(const scene::Shot& shot, int threads = 1) {
  const std::vector<scene::StreamActor> actors = scene::stream_actors(shot);
  const std::vector<scene::StreamCamera> cameras = scene::stream_cameras(shot);
  scene::StreamOptions options;
  options.threads = threads;
  scene::FrameLoop loop(actors, scene::stream_props(shot), cameras, options);
  const std::size_t n = loop.point_count(), first_prop = n - shot.props.points.size();
  std::vector<Eigen::Vector3f> out;
  for (int first = 0; first < loop.frame_count(); first += loop.chunk_frames()) {
    const int count = std::min(loop.chunk_frames(), loop.frame_count() - first);
    loop.pose(first, count);
    loop.skin();
    for (std::size_t c = 0; c < cameras.size(); ++c) loop.classify(c);
    const scene::FrameChunk chunk = loop.chunk();
    for (int f = 0; f < count; ++f) {
      for (std::size_t i = first_prop; i < n; ++i) out.push_back(Eigen::Vector3f::Map(chunk.trajs_3d.data() + (f * n + i) * 3));
    }
  }
  return out;
}

TEST(PropPhysicsTest, BoxDroppedFromOneMetreSettlesOnTheGround) {
  // The walker starts 10 m away and walks away from the box.
  const scene::Shot shot = scene::prepare_shot(shot_with({dynamic_box("box", Eigen::Vector3d(-3, 0, 1), 0.2)}, 7, 0, 0, 3));
  const std::size_t points = shot.props.points.size();
  ASSERT_EQ(points, 300u);
  const std::vector<Eigen::Vector3f> p = prop_trajectories(shot);
  const int frames = shot.frames;
  ASSERT_EQ(p.size(), frames * points);
  const auto at = [&](int f, std::size_t i) { return p[f * points + i]; };
  // Falling from rest: after 0.3 s it has dropped g t^2 / 2 = 0.44 m (no contact yet).
  float top0 = -1e9f, top9 = -1e9f;
  for (std::size_t i = 0; i < points; ++i) {
    top0 = std::max(top0, at(0, i).z());
    top9 = std::max(top9, at(9, i).z());
  }
  EXPECT_NEAR(top0 - top9, 0.5 * 9.81 * 0.3 * 0.3, 0.01);
  // Settled within 2 s: from frame 60 on no point moves more than 0.1 mm a frame, and the lowest
  // points rest on z = 0 within 5 mm.
  double worst_step = 0;
  for (int f = 61; f < frames; ++f) {
    for (std::size_t i = 0; i < points; ++i) worst_step = std::max(worst_step, double((at(f, i) - at(f - 1, i)).norm()));
  }
  EXPECT_LT(worst_step, 1e-4);
  float lowest = 1e9f;
  for (std::size_t i = 0; i < points; ++i) lowest = std::min(lowest, at(frames - 1, i).z());
  EXPECT_NEAR(lowest, 0.0, 0.005);
  ASSERT_EQ(shot.prop_reports.size(), 1u);
  ASSERT_TRUE(shot.prop_reports[0].has_value());
  EXPECT_GT(shot.prop_reports[0]->contact_frames, 30);
  EXPECT_LT(shot.prop_reports[0]->deepest_penetration, 0.005);
}

TEST(PropPhysicsTest, BoxOnAWalkersPathIsKickedForwardWhenTheFeetReachIt) {
  // Where the walker's root is 1.2 s in: the box goes there, on the ground.
  scene::Scene probe = shot_with({}, 0, 0, 0, 3);
  probe.outputs.prop_points = 0;
  const scene::Shot walk = scene::prepare_shot(probe);
  const int root = walk.actors[0].motion->root_joint;
  const std::vector<Eigen::Vector2d> track = scene::root_track(walk.actors[0].clip, root);
  const Eigen::Vector2d there = track.at(36);
  const Eigen::Vector2d heading = (track.back() - track.front()).normalized();

  const scene::Shot shot = scene::prepare_shot(shot_with({dynamic_box("box", Eigen::Vector3d(there.x(), there.y(), 0), 0.25)}, 0, 0, 0, 3));
  const std::size_t points = shot.props.points.size();
  const std::vector<Eigen::Vector3f> p = prop_trajectories(shot);
  const int frames = shot.frames;
  const auto moved = [&](int f) {
    double most = 0;
    for (std::size_t i = 0; i < points; ++i) most = std::max(most, double((p[f * points + i] - p[i]).norm()));
    return most;
  };
  int first_moved = -1;
  for (int f = 1; f < frames && first_moved < 0; ++f) {
    if (moved(f) > 1e-3) first_moved = f;
  }
  ASSERT_GT(first_moved, 0) << "the box never moved";
  // Not before: still (under 1 mm) through the first 0.5 s at least, while the walker is more than
  // half a metre off.
  EXPECT_GT(first_moved, 15);
  // When it starts to move, some joint of the walker is within 0.35 m of the box's centre (a foot
  // or a shin touching its side).
  std::vector<RigidTransform<double>> joints(shot.actors[0].clip.joint_count());
  shot.actors[0].clip.world_pose(first_moved, joints);
  double nearest = 1e9;
  for (const auto& joint : joints) nearest = std::min(nearest, (joint.translation - Eigen::Vector3d(there.x(), there.y(), 0.125)).norm());
  EXPECT_LT(nearest, 0.35);
  // After: displaced by more than 5 cm, mostly along the walking direction.
  Eigen::Vector2d shift = Eigen::Vector2d::Zero();
  for (std::size_t i = 0; i < points; ++i) shift += (p[(frames - 1) * points + i] - p[i]).head<2>().cast<double>();
  shift /= static_cast<double>(points);
  EXPECT_GT(shift.dot(heading), 0.05);
  EXPECT_GT(shift.dot(heading), std::abs(shift.x() * heading.y() - shift.y() * heading.x()));
}

// The documented approximation: a vertex-animated actor (an .anime mesh) has no bones, so it
// does not collide; a box in its way stays put, and the shot says why.
TEST(PropPhysicsTest, AVertexAnimatedActorPassesThroughPropsAndTheShotSaysSo) {
  const std::filesystem::path dir = test_support::scratch_dir("PropPhysicsTest");
  // A 0.6 m cube (Z up) sliding 3 m along +x in 1 s, through where the box stands.
  MeshAnimation animation;
  animation.vertex_count = 8;
  for (int f = 0; f < 31; ++f) {
    for (int c = 0; c < 8; ++c) {
      animation.positions.insert(animation.positions.end(), {float((c & 1 ? 0.3 : -0.3) - 1.5 + 0.1 * f), float(c & 2 ? 0.3 : -0.3),
                                                             float(c & 4 ? 0.6 : 0.0)});
    }
  }
  const std::vector<std::uint32_t> triangles = {0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6, 0, 1, 4, 1, 5, 4,
                                                2, 6, 3, 3, 6, 7, 0, 4, 2, 2, 4, 6, 1, 3, 5, 3, 7, 5};
  io::write_anime_file((dir / "slider.anime").string(), animation, triangles);
  scene::Scene s = shot_with({dynamic_box("box", Eigen::Vector3d(0, 0, 0), 0.2)}, 0, 0, 0, 1);
  scene::AnimeRequest request;
  request.path = (dir / "slider.anime").string();
  request.up_z = true;
  s.actors[0].source = request;
  s.actors[0].placement.kind = scene::Placement::Kind::as_recorded;
  const scene::Shot shot = scene::prepare_shot(s);
  EXPECT_TRUE(std::any_of(shot.skipped.begin(), shot.skipped.end(),
                          [](const std::string& line) { return contains(line, "actor 'walker': a vertex-animated mesh has no bones"); }));
  const std::vector<Eigen::Vector3f> p = prop_trajectories(shot);
  const std::size_t points = shot.props.points.size();
  double most = 0;
  for (std::size_t f = 1; f < p.size() / points; ++f) {
    for (std::size_t i = 0; i < points; ++i) most = std::max(most, double((p[f * points + i] - p[i]).norm()));
  }
  // Settling on the ground moves it by micrometres; a push at the cube's 3 m/s would be centimetres.
  EXPECT_LT(most, 1e-4);
}

// An OBJ (Z up) of axis-aligned boxes, each a separate piece: (min, max) corners.
std::string boxes_obj(const std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>>& boxes) {
  std::string obj;
  int first = 1;
  for (const auto& [low, high] : boxes) {
    for (int c = 0; c < 8; ++c) {
      obj += "v " + std::to_string(c & 1 ? high.x() : low.x()) + " " + std::to_string(c & 2 ? high.y() : low.y()) + " " +
             std::to_string(c & 4 ? high.z() : low.z()) + "\n";
    }
    for (const auto& f : std::vector<std::array<int, 3>>{{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
                                                         {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}}) {
      obj += "f " + std::to_string(first + f[0]) + " " + std::to_string(first + f[1]) + " " + std::to_string(first + f[2]) + "\n";
    }
    first += 8;
  }
  return obj;
}

// A table of five pieces (a top on four legs) colliding as pieces leaves room under it: a crate
// standing there at the start stays put and the table stays on its legs. As one hull the same
// table would hold the crate inside its solid, and the crate is thrown out.
TEST(PropPhysicsTest, AMeshCollidingAsPiecesLeavesRoomBetweenThem) {
  const std::filesystem::path dir = test_support::scratch_dir("PropPhysicsTest");
  std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>> table = {{{-0.5, -0.3, 0.7}, {0.5, 0.3, 0.75}}};
  for (const double x : {-0.45, 0.4}) {
    for (const double y : {-0.25, 0.2}) table.push_back({{x, y, 0.0}, {x + 0.05, y + 0.05, 0.7}});
  }
  std::ofstream(dir / "table.obj") << boxes_obj(table);
  const auto run = [&](const std::string& collision) {
    scene::Prop top;
    top.name = "table";
    top.kind = scene::Prop::Kind::mesh;
    top.path = (dir / "table.obj").string();
    top.up_z = true;
    top.position = Eigen::Vector3d(-3, 0, 0.002);
    top.dynamics.emplace();
    top.dynamics->mass = 10;
    top.dynamics->pieces = collision == "pieces";
    const scene::Shot shot = scene::prepare_shot(shot_with({top, dynamic_box("crate", Eigen::Vector3d(-3, 0, 0), 0.3)}, 7, 0, 0, 1));
    const physics::PropReport& crate = *shot.prop_reports.at(1);
    const physics::PropReport& board = *shot.prop_reports.at(0);
    return std::make_pair(crate.path_length, board.path_length);
  };
  const auto [crate_moved, table_moved] = run("pieces");
  EXPECT_LT(crate_moved, 0.001);
  EXPECT_LT(table_moved, 0.005);
  const auto [crate_thrown, table_thrown] = run("hull");
  EXPECT_GT(crate_thrown + table_thrown, 0.05);
  std::printf("pieces: crate moved %.2g m, table %.2g m; one hull: crate %.3g m, table %.3g m\n", crate_moved, table_moved,
              crate_thrown, table_thrown);
}

std::string bytes_of(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

TEST(PropPhysicsTest, SameSceneGivesByteIdenticalTrajectoriesOnAnyThreadCount) {
  const std::filesystem::path dir = test_support::scratch_dir("PropPhysicsTest");
  const auto run = [&](int threads, const std::string& folder) {
    scene::Scene s = shot_with({dynamic_box("box", Eigen::Vector3d(1, 0.2, 0.3), 0.3)}, 0, 0, 0, 2);
    s.scatter.emplace();
    s.scatter->count = 6;
    s.scatter->on_paths = 2;
    s.scatter->region = Eigen::AlignedBox2d(Eigen::Vector2d(-3, -3), Eigen::Vector2d(3, 3));
    scene::Prop crate = dynamic_box("crate", Eigen::Vector3d::Zero(), 0.2);
    s.scatter->props = {crate};
    s.forces.emplace();
    s.forces->count = 1;
    s.outputs.threads = threads;
    scene::OutputSelection which;
    which.camera_paths = false;
    which.report = false;
    scene::set_outputs_in_folder(s, (dir / folder).string(), which);
    std::filesystem::create_directories(dir / folder);
    scene::run_scene(s);
    return bytes_of(dir / folder / "trajectories_far.npz");
  };
  const std::string one = run(1, "a"), again = run(1, "b"), two = run(2, "c");
  ASSERT_GT(one.size(), 1000u);
  EXPECT_TRUE(one == again);
  EXPECT_TRUE(one == two);
}

TEST(PropPhysicsTest, PropsPointCacheHoldsEveryPropWhereItIsEachFrame) {
  const std::filesystem::path dir = test_support::scratch_dir("PropPhysicsTest");
  scene::Scene s = shot_with({dynamic_box("box", Eigen::Vector3d(-3, 0, 1), 0.2), dynamic_box("crate", Eigen::Vector3d(2, 2, 0), 0.3)}, 7, 0, 0, 1);
  s.props.back().dynamics.reset();  // one static prop among them
  scene::OutputSelection which;
  which.trajectories = false;
  which.camera_paths = false;
  which.report = false;
  which.point_caches = true;
  scene::set_outputs_in_folder(s, dir.string(), which);
  ASSERT_EQ(s.outputs.prop_point_cache, (dir / "props_point_cache.pc2").string());
  scene::run_scene(s);
  ASSERT_TRUE(std::filesystem::exists(dir / "props_point_cache.obj"));
  const std::string pc2 = bytes_of(dir / "props_point_cache.pc2");
  // Header: 12 bytes of signature, version, V, start, rate, T (32 bytes), then T x V x 3 float32.
  std::int32_t vertices = 0, samples = 0;
  std::memcpy(&vertices, pc2.data() + 16, 4);
  std::memcpy(&samples, pc2.data() + 28, 4);
  ASSERT_EQ(vertices, 48);  // two boxes of 24 vertices (four a face)
  ASSERT_EQ(samples, 31);
  ASSERT_EQ(pc2.size(), 32u + std::size_t(samples) * vertices * 12);
  // Tracked points interpolate the cached vertices of their triangle: the cache and trajs_3d agree.
  const scene::Shot shot = scene::prepare_shot(s);
  const std::vector<Eigen::Vector3f> p = prop_trajectories(shot);
  const std::size_t points = shot.props.points.size();
  double worst = 0;
  for (int f = 0; f < samples; f += 5) {
    const float* frame = reinterpret_cast<const float*>(pc2.data() + 32) + std::size_t(f) * vertices * 3;
    for (std::size_t i = 0; i < points; ++i) {
      const skinning::SurfacePoint& point = shot.props.points[i];
      const std::size_t first = point.mesh == 0 ? 0 : 24;
      Eigen::Vector3f q = Eigen::Vector3f::Zero();
      for (int c = 0; c < 3; ++c) q += point.barycentric[c] * Eigen::Vector3f::Map(frame + 3 * (first + point.vertices[c]));
      worst = std::max(worst, double((q - p[f * points + i]).norm()));
    }
  }
  EXPECT_LT(worst, 1e-5);
  // The dropped box fell in the cache (its top corner from 1.2 m to under 0.3 m); the static crate stayed.
  const float* last = reinterpret_cast<const float*>(pc2.data() + 32) + std::size_t(samples - 1) * vertices * 3;
  const float* first = reinterpret_cast<const float*>(pc2.data() + 32);
  float top_first = -1, top_last = -1;
  for (int v = 0; v < 24; ++v) {
    top_first = std::max(top_first, first[3 * v + 2]);
    top_last = std::max(top_last, last[3 * v + 2]);
  }
  EXPECT_NEAR(top_first, 1.2, 1e-6);
  EXPECT_LT(top_last, 0.3);
  for (int k = 24 * 3; k < 48 * 3; ++k) EXPECT_EQ(first[k], last[k]);
}

// A minute of an outdoor shot: two walkers and a fox among 30 scattered blocks and crates (6 on the
// walkers' paths) kicked by seeded forces (0.2 a prop a second, up to 3 m/s, spinning). Bounds:
// kicks change a prop's velocity by at most 3 m/s and a foot moves at most about 5 m/s, so
// a prop kicked again while still sliding and spinning stays well under 20 m/s at any point.
TEST(PropPhysicsTest, AMinuteOfKicksKeepsPropsAboveTheGroundApartAndWithinTheirSpeed) {
  const std::filesystem::path dir = test_support::scratch_dir("PropPhysicsTest");
  std::ofstream(dir / "long.json") << R"({
  "version": 1, "name": "long", "fps": 30, "seconds": 60, "seed": 3,
  "actors": [
    {"name": "a", "motion": "data:mocap/cmu_walk_cgspeed.bvh", "bvh_units": "cmu", "character": "data:characters/RiggedFigure.glb",
     "quality": "fast", "placement": {"x": -3, "y": -2, "yaw": 0}, "points": 0},
    {"name": "b", "motion": "data:mocap/cmu_walk_cgspeed.bvh", "bvh_units": "cmu", "character": "data:characters/CesiumMan.glb",
     "quality": "fast", "placement": {"x": 3, "y": 2, "yaw": 180}, "points": 0},
    {"name": "fox", "character": "data:characters/Fox.glb", "animation": "Walk", "seconds": 60, "scale": 0.01,
     "placement": {"x": 0, "y": 4, "yaw": 0}, "points": 0}
  ],
  "props": [{"name": "field", "type": "ground", "size": [30, 30]}],
  "scatter": {"count": 30, "on_paths": 6, "region": [-5, -5, 5, 5],
              "props": [
                {"name": "brick", "type": "mesh", "path": "data:props/kenney_brick.glb", "scale": 0.3, "dynamic": true, "mass": 2},
                {"name": "crate", "type": "box", "size": [0.4, 0.3, 0.25], "dynamic": true, "mass": 3, "friction": 0.6}]},
  "forces": {"rate": 0.2, "speed_change": [0.5, 3], "max_upward": 0.5, "lever_arm": 0.1},
  "cameras": [{"name": "wide", "type": "static", "position": [0, -14, 5], "target": [0, 0, 0.5]}],
  "outputs": {"trajectories": true, "camera_paths": false, "report": false, "prop_points": 3000}
})";
  scene::SceneFile file = scene::read_scene_file((dir / "long.json").string());
  scene::set_outputs_in_folder(file.scene, (dir / "out").string(), file.outputs);
  std::filesystem::create_directories(dir / "out");
  const scene::SceneResult result = scene::run_scene(file.scene);
  ASSERT_EQ(result.frames, 1801);
  int dynamic = 0;
  double penetration = 0, overlap = 0, top_speed = 0;
  for (const auto& report : result.prop_reports) {
    if (!report) continue;
    ++dynamic;
    penetration = std::max(penetration, report->deepest_penetration);
    overlap = std::max(overlap, report->deepest_prop_overlap);
    top_speed = std::max(top_speed, report->top_speed);
  }
  EXPECT_EQ(dynamic, 30);
  // No prop sinks into anything by more than a substep of a foot's travel (the ground: the tracked
  // points below): a kinematic foot at up to 4 m/s moves 4 / 240 = 17 mm into a prop within a
  // substep before the solver can answer, so 2 cm; a prop it drives into another prop sinks into
  // that one as far (seeds 3 to 8 of this shot: the deepest prop into prop 6.6 to 12.7 mm).
  EXPECT_LT(overlap, 0.02);
  EXPECT_LT(penetration, 0.02);
  EXPECT_LT(top_speed, 20.0);
  // The tracked points: none below z = -1 cm, none moving faster than 20 m/s between two frames.
  const io::NpzReader npz((dir / "out" / "trajectories_wide.npz").string());
  const std::vector<float> trajs = npz.load("trajs_3d").to_float();
  const std::vector<std::int64_t> owner = npz.load("point_actor_ids").to_int64();
  const std::size_t n = owner.size(), frames = trajs.size() / (3 * n);
  ASSERT_EQ(frames, 1801u);
  double lowest = 0, fastest = 0;
  for (std::size_t f = 0; f < frames; ++f) {
    for (std::size_t i = 0; i < n; ++i) {
      if (owner[i] >= -1) continue;  // the field is prop 0 (-1)
      const Eigen::Vector3f p = Eigen::Vector3f::Map(&trajs[(f * n + i) * 3]);
      lowest = std::min(lowest, double(p.z()));
      if (f > 0) fastest = std::max(fastest, 30.0 * (p - Eigen::Vector3f::Map(&trajs[((f - 1) * n + i) * 3])).norm());
    }
  }
  EXPECT_GT(lowest, -0.01);
  EXPECT_LT(fastest, 20.0);
  std::printf("60 s, 30 props: deepest penetration %.4f m, prop overlap %.4f m, top speed %.2f m/s, lowest point %.4f m, "
              "fastest point %.2f m/s, physics %.2f s of %.2f s\n",
              penetration, overlap, top_speed, lowest, fastest, result.physics_seconds, result.seconds.total);
}

std::string parse_error(const std::string& props) {
  const std::string json = R"({"version": 1, "actors": [{"motion": "a.bvh", "character": "c.glb"}], )" + props + "}";
  return test_support::message_of<io::InputError>([&] { scene::parse_scene(json, "shot.json"); });
}

TEST(PropPhysicsTest, BadDynamicKeysNameTheFileAndTheJsonPath) {
  EXPECT_TRUE(contains(parse_error(R"("props": [{"type": "box", "size": [1, 1, 1], "dynamic": true, "mass": -1}])"),
                       "shot.json: props[0].mass: a mass is kilograms in (0, 1e6]"));
  EXPECT_TRUE(contains(parse_error(R"("props": [{"type": "box", "size": [1, 1, 1], "dynamic": true, "mass": 0}])"),
                       "shot.json: props[0].mass:"));
  EXPECT_TRUE(contains(parse_error(R"("props": [{"type": "box", "size": [1, 1, 1], "dynamic": true, "velocity": [1, 2]}])"),
                       "shot.json: props[0].velocity: expected [x, y, z]"));
  EXPECT_TRUE(contains(parse_error(R"("props": [{"type": "box", "size": [1, 1, 1], "dynamic": true, "velocity": [1e300, 0, 0]}])"),
                       "shot.json: props[0].velocity: expected a finite [x, y, z] in m/s"));
  EXPECT_TRUE(contains(parse_error(R"("props": [{"type": "box", "size": [1, 1, 1], "mass": 2}])"),
                       "shot.json: props[0].mass: only a dynamic prop"));
  EXPECT_TRUE(contains(parse_error(R"("props": [{"type": "ground", "size": [1, 1], "dynamic": true}])"),
                       "shot.json: props[0].dynamic: a ground cannot be dynamic"));
  EXPECT_TRUE(contains(parse_error(R"("props": [{"type": "box", "size": [1, 1, 1], "dynamic": true, "restitution": 2}])"),
                       "shot.json: props[0].restitution:"));
  EXPECT_TRUE(contains(parse_error(R"("props": [{"type": "box", "size": [1, 1, 1], "dynamic": true, "collision": "pieces"}])"),
                       "shot.json: props[0].collision: only a mesh chooses its collision shape"));
  EXPECT_TRUE(contains(parse_error(R"("props": [{"type": "mesh", "path": "t.obj", "dynamic": true, "collision": "parts"}])"),
                       "shot.json: props[0].collision: expected hull or pieces"));
  EXPECT_TRUE(contains(parse_error(R"("props": [{"type": "box", "size": [1, 1, 1]}], "forces": {"count": 1})"),
                       "shot.json: forces: no dynamic prop for the forces to act on"));
  EXPECT_TRUE(contains(parse_error(R"("props": [{"type": "box", "size": [1, 1, 1], "dynamic": true}], "forces": {"count": 1, "rate": 2})"),
                       "shot.json: forces.rate: give count or rate, not both"));
  EXPECT_TRUE(contains(parse_error(R"("scatter": {"count": 3, "props": [{"type": "box", "size": [1, 1, 1], "position": [0, 0, 0]}]})"),
                       "shot.json: scatter.props[0].position: a scattered prop's place is drawn"));
  EXPECT_TRUE(contains(parse_error(R"("scatter": {"count": 3, "props": [{"type": "box", "size": [1, 1, 1]}], "region": [0, 0, -1, 1]})"),
                       "shot.json: scatter.region: expected x_min < x_max"));
}

TEST(PropPhysicsTest, ScenesThatCannotBeSimulatedNameTheJsonPath) {
  const std::filesystem::path dir = test_support::scratch_dir("PropPhysicsTest");
  // A flat mesh (a square) has no volume for a hull.
  {
    std::ofstream obj(dir / "flat.obj");
    obj << "v 0 0 0\nv 1 0 0\nv 1 0 1\nv 0 0 1\nv 0.5 0 0.5\nf 1 2 3\nf 1 3 4\n";
  }
  scene::Prop flat;
  flat.name = "flat";
  flat.kind = scene::Prop::Kind::mesh;
  flat.path = (dir / "flat.obj").string();
  flat.position = Eigen::Vector3d(3, 3, 0);
  flat.dynamics.emplace();
  scene::Scene s = shot_with({dynamic_box("box", Eigen::Vector3d(-3, 0, 0), 0.2), flat}, 0, 0, 0, 1);
  s.file = "shot.json";
  EXPECT_TRUE(contains(test_support::message_of<io::InputError>([&] { scene::prepare_shot(s); }),
                       "shot.json: props[1]: a dynamic mesh needs a volume for its convex hull"));
  // A scene built in code skips the file's checks; the physics model's own name the prop's path.
  scene::Scene heavy = shot_with({dynamic_box("box", Eigen::Vector3d(-3, 0, 0), 0.2), dynamic_box("light", Eigen::Vector3d(3, 0, 0), 0.2)}, 0, 0, 0, 1);
  heavy.file = "shot.json";
  heavy.props[1].dynamics->mass = -1;
  EXPECT_TRUE(contains(test_support::message_of<io::InputError>([&] { scene::prepare_shot(heavy); }), "shot.json: props[1]: mass"));
  // Thirty 1 m crates cannot fit a 2 m square.
  scene::Scene crowded = shot_with({}, 0, 0, 0, 1);
  crowded.file = "shot.json";
  crowded.scatter.emplace();
  crowded.scatter->count = 30;
  crowded.scatter->region = Eigen::AlignedBox2d(Eigen::Vector2d(4, 4), Eigen::Vector2d(6, 6));
  crowded.scatter->props = {dynamic_box("crate", Eigen::Vector3d::Zero(), 1)};
  EXPECT_TRUE(contains(test_support::message_of<io::InputError>([&] { scene::prepare_shot(crowded); }), "shot.json: scatter: "));
}

}  // namespace
}  // namespace odyssey
