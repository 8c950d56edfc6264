// DeformingThings4D .anime meshes (mocap_io/anime_file.h) and vertex-animated actors
// (scene_layouts/actor_source.h): synthetic files whose every vertex moves by a known formula, read
// back, played at another rate, tracked, cached, occluding and occluded, written as morph targets
// that the Khronos validator and Blender accept; and the bad files named record by record.
#include <gtest/gtest.h>

#include <sys/wait.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <numbers>

#include "cli_runner.h"
#include "gltf_validator.h"
#include "mocap_io/anime_file.h"
#include "mocap_io/input_error.h"
#include "mocap_io/npy.h"
#include "scene_layouts/actor_source.h"
#include "skeleton/rotation.h"
#include "test_support.h"

namespace odyssey {
namespace {

namespace fs = std::filesystem;
using test_support::contains;

std::string quoted(const fs::path& path) {
  std::string text = "'";
  text += path.string();
  text += "'";
  return text;
}

// A UV sphere (8 rings, 12 segments; poles included) of unit directions u_i, and its triangles.
struct Sphere {
  std::vector<Eigen::Vector3d> directions;
  std::vector<std::uint32_t> triangles;
};

Sphere unit_sphere() {
  constexpr int kRings = 8, kSegments = 12;
  Sphere s;
  s.directions.push_back(Eigen::Vector3d::UnitY());
  for (int r = 1; r < kRings; ++r) {
    const double polar = std::numbers::pi * r / kRings;
    for (int k = 0; k < kSegments; ++k) {
      const double azimuth = 2 * std::numbers::pi * k / kSegments;
      s.directions.emplace_back(std::sin(polar) * std::cos(azimuth), std::cos(polar), std::sin(polar) * std::sin(azimuth));
    }
  }
  s.directions.push_back(-Eigen::Vector3d::UnitY());
  const auto ring = [](int r, int k) { return std::uint32_t(1 + (r - 1) * kSegments + (k % kSegments)); };
  const std::uint32_t south = std::uint32_t(s.directions.size() - 1);
  for (int k = 0; k < kSegments; ++k) {
    s.triangles.insert(s.triangles.end(), {0, ring(1, k + 1), ring(1, k)});
    for (int r = 1; r + 1 < kRings; ++r) {
      s.triangles.insert(s.triangles.end(), {ring(r, k), ring(r, k + 1), ring(r + 1, k + 1), ring(r, k), ring(r + 1, k + 1), ring(r + 1, k)});
    }
    s.triangles.insert(s.triangles.end(), {south, ring(kRings - 1, k), ring(kRings - 1, k + 1)});
  }
  return s;
}

// The known motion, in the file's Y-up axes: centre (c0 + v t), radius r0 + g t, so every vertex
// moves linearly in time and linear resampling is exact.
struct Motion {
  Eigen::Vector3d start{0, 0.5, 0}, velocity{0.5, 0, 0.2};
  double radius = 0.5, growth = 0.1;
  Eigen::Vector3d vertex(const Eigen::Vector3d& direction, double t) const {
    return start + velocity * t + (radius + growth * t) * direction;
  }
};

fs::path write_sphere(const fs::path& path, const Motion& motion, int frames, double fps) {
  const Sphere sphere = unit_sphere();
  MeshAnimation animation;
  animation.vertex_count = sphere.directions.size();
  for (int f = 0; f < frames; ++f) {
    for (const Eigen::Vector3d& u : sphere.directions) {
      const Eigen::Vector3d p = motion.vertex(u, f / fps);
      animation.positions.insert(animation.positions.end(), {float(p.x()), float(p.y()), float(p.z())});
    }
  }
  io::write_anime_file(path.string(), animation, sphere.triangles);
  return path;
}

std::string file_bytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

TEST(AnimeFileTest, ReadsEveryFrameAsTheFirstPlusItsOffset) {
  const fs::path path = write_sphere(test_support::scratch_dir("anime") / "sphere.anime", Motion{}, 11, 10);
  const Sphere sphere = unit_sphere();
  // 12 + 12 nv + 12 nt + 12 (nf - 1) nv bytes.
  EXPECT_EQ(fs::file_size(path), 12 + 12 * sphere.directions.size() + 4 * sphere.triangles.size() + 12 * 10 * sphere.directions.size());
  const io::AnimeFile file = io::read_anime_file(path.string());
  EXPECT_EQ(file.triangles, sphere.triangles);
  ASSERT_EQ(file.frames.frame_count(), 11);
  ASSERT_EQ(file.frames.vertex_count, sphere.directions.size());
  double worst = 0;
  for (int f = 0; f < 11; ++f) {
    for (std::size_t v = 0; v < sphere.directions.size(); ++v) {
      const Eigen::Vector3d read(file.frames.frame(f)[3 * v], file.frames.frame(f)[3 * v + 1], file.frames.frame(f)[3 * v + 2]);
      worst = std::max(worst, (read - Motion{}.vertex(sphere.directions[v], f / 10.0)).norm());
    }
  }
  EXPECT_LT(worst, 1e-6);  // float32 positions and offsets
}

std::string read_error(const fs::path& path) {
  try {
    io::read_anime_file(path.string());
  } catch (const io::InputError& error) {
    EXPECT_EQ(error.file(), path.string());
    return error.problem();
  }
  return "read without error";
}

TEST(AnimeFileTest, BadFilesAreNamedRecordByRecord) {
  const fs::path dir = test_support::scratch_dir("anime_bad");
  const std::string good = file_bytes(write_sphere(dir / "good.anime", Motion{}, 4, 10));
  const auto variant = [&](const std::string& name, const std::string& bytes) {
    std::ofstream(dir / name, std::ios::binary) << bytes;
    return dir / name;
  };
  const std::size_t nv = unit_sphere().directions.size(), nt = unit_sphere().triangles.size() / 3;
  const std::string expected = std::to_string(12 + 12 * nv + 12 * nt + 12 * 3 * nv);
  EXPECT_EQ(read_error(variant("short.anime", good.substr(0, good.size() - 4))),
            "the header (4 frames, " + std::to_string(nv) + " vertices, " + std::to_string(nt) + " triangles) implies " + expected +
                " bytes, but the file has " + std::to_string(good.size() - 4) + " (truncated)");
  EXPECT_TRUE(contains(read_error(variant("long.anime", good + "xxxx")), "(trailing bytes)"));
  EXPECT_TRUE(contains(read_error(variant("tiny.anime", good.substr(0, 7))), "truncated .anime header: 7 bytes"));

  std::string huge = good;  // nf = 2^31 - 1 on a small file: refused before anything is allocated
  const std::int32_t most = 0x7fffffff;
  std::memcpy(huge.data(), &most, 4);
  EXPECT_TRUE(contains(read_error(variant("huge.anime", huge)), "(truncated)"));
  std::string no_frames = good;
  const std::int32_t zero = 0;
  std::memcpy(no_frames.data(), &zero, 4);
  EXPECT_TRUE(contains(read_error(variant("zero.anime", no_frames)), "expected at least 1 frame"));

  std::string bad_index = good;  // triangle 2's second corner
  const std::int32_t outside = static_cast<std::int32_t>(nv) + 5;
  std::memcpy(bad_index.data() + 12 + 12 * nv + 4 * (2 * 3 + 1), &outside, 4);
  EXPECT_EQ(read_error(variant("index.anime", bad_index)),
            "triangle 2 uses vertex " + std::to_string(nv + 5) + "; the mesh has vertices 0 to " + std::to_string(nv - 1));

  const float nan = NAN;
  std::string bad_first = good;  // frame 1, vertex 3, y
  std::memcpy(bad_first.data() + 12 + 4 * (3 * 3 + 1), &nan, 4);
  EXPECT_EQ(read_error(variant("first.anime", bad_first)), "frame 1, vertex 3 has a non-finite coordinate");
  std::string bad_offset = good;  // frame 3 (the second offset block), vertex 7, z
  std::memcpy(bad_offset.data() + 12 + 12 * nv + 12 * nt + 12 * nv + 4 * (7 * 3 + 2), &nan, 4);
  EXPECT_EQ(read_error(variant("offset.anime", bad_offset)), "frame 3, vertex 7 has a non-finite offset");
  EXPECT_TRUE(contains(read_error(dir / "missing.anime"), "no such file"));
}

TEST(AnimeActorTest, PlaysAtTheRequestedRateInTheToolkitsAxes) {
  const fs::path path = write_sphere(test_support::scratch_dir("anime_actor") / "sphere.anime", Motion{}, 11, 10);
  scene::AnimeRequest request;
  request.path = path.string();
  request.source_fps = 10;
  request.fps = 30;
  request.scale = 2;
  const auto motion = std::make_shared<const scene::ActorMotion>(scene::play_anime(request));
  // Kept at the file's rate; played at the request's.
  EXPECT_EQ(motion->clip.frame_count(), 11);
  const scene::TimedClip played = scene::played_clip(motion, request.fps);
  ASSERT_EQ(played.frame_count(), 31);
  ASSERT_TRUE(played.vertex_animated());
  const Sphere sphere = unit_sphere();
  std::vector<RigidTransform<double>> world(1);
  std::vector<float> local(played.vertex_count() * 3);
  double worst = 0;
  for (int f = 0; f <= 30; ++f) {
    played.world_pose(f, world);
    played.local_vertices(f, local);
    // The joint rides at the mesh's horizontal centroid (z = 0); (x, y, z) -> (x, -z, y), times 2.
    const Eigen::Vector3d centre = 2 * y_up_to_z_up() * (Motion{}.start + Motion{}.velocity * (f / 30.0));
    EXPECT_NEAR(world[0].translation.x(), centre.x(), 1e-5);
    EXPECT_NEAR(world[0].translation.y(), centre.y(), 1e-5);
    EXPECT_EQ(world[0].translation.z(), 0);
    for (std::size_t v = 0; v < sphere.directions.size(); ++v) {
      const Eigen::Vector3d p = world[0] * Eigen::Vector3d(local[3 * v], local[3 * v + 1], local[3 * v + 2]);
      worst = std::max(worst, (p - 2 * y_up_to_z_up() * Motion{}.vertex(sphere.directions[v], f / 30.0)).norm());
    }
  }
  EXPECT_LT(worst, 1e-5);
  // The character is the first frame, standing on its joint.
  EXPECT_EQ(motion->character.meshes.size(), 1u);
  EXPECT_NEAR(motion->character.rest_bounds().sizes().z(), 2 * 2 * 0.5, 1e-5);  // diameter 1, scale 2
  // Z up: the axes are kept.
  request.up_z = true;
  request.scale = 1;
  const scene::ActorMotion upright = scene::play_anime(request);
  upright.clip.world_pose(0, world);
  EXPECT_NEAR(upright.character.rest_bounds().max().y(), 0.5 + 0.5, 1e-6);  // the file's y
}

// Frame f of a PC2 file, vertex v.
Eigen::Vector3d pc2_vertex(const std::string& bytes, int frame, int vertex) {
  std::int32_t points = 0;
  std::memcpy(&points, bytes.data() + 16, 4);
  float p[3];
  std::memcpy(p, bytes.data() + 32 + (std::size_t(frame) * points + vertex) * 12, 12);
  return Eigen::Vector3d(p[0], p[1], p[2]);
}

TEST(AnimeCliTest, PointCacheAndTrajectoriesFollowTheKnownMotion) {
  const fs::path dir = test_support::scratch_dir("anime_cli");
  const fs::path anime = write_sphere(dir / "sphere.anime", Motion{}, 11, 10);
  const Sphere sphere = unit_sphere();
  const Eigen::Matrix3d c = y_up_to_z_up();

  // Looped for 2.5 s at 30 fps: frame 40 is 1.333 s, one second-long loop on: 0.333 s.
  const test_support::CliResult cache = test_support::run_cli("point-cache --anime " + quoted(anime) +
                                                              " --anime-fps 10 --seconds 2.5 --out " + quoted(dir / "c.pc2"));
  ASSERT_EQ(cache.exit_code, 0) << cache.output;
  EXPECT_TRUE(fs::exists(dir / "c.obj"));
  const std::string bytes = file_bytes(dir / "c.pc2");
  std::int32_t frames = 0;
  std::memcpy(&frames, bytes.data() + 28, 4);
  ASSERT_EQ(frames, 76);
  double worst = 0;
  for (const auto& [frame, t] : std::vector<std::pair<int, double>>{{0, 0.0}, {7, 7 / 30.0}, {30, 1.0}, {40, 1 / 3.0}, {75, 0.5}}) {
    for (std::size_t v = 0; v < sphere.directions.size(); ++v) {
      worst = std::max(worst, (pc2_vertex(bytes, frame, int(v)) - c * Motion{}.vertex(sphere.directions[v], t)).norm());
    }
  }
  EXPECT_LT(worst, 1e-5);

  // Tracked points: barycentric on the deforming triangles.
  const test_support::CliResult run = test_support::run_cli(
      "trajectories --anime " + quoted(anime) + " --anime-fps 10 --points 300 --camera static --out " + quoted(dir / "t.npz"));
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const io::NpzReader npz((dir / "t.npz").string());
  const std::vector<float> trajs = npz.load("trajs_3d").to_float();
  const std::vector<std::int64_t> ids = npz.load("point_vertex_ids").to_int64();
  const std::vector<double> barycentric = npz.load("point_barycentric").to_double();
  ASSERT_EQ(trajs.size(), 31u * 300 * 3);
  worst = 0;
  for (int f = 0; f <= 30; f += 5) {
    for (int i = 0; i < 300; ++i) {
      Eigen::Vector3d expected = Eigen::Vector3d::Zero();
      for (int k = 0; k < 3; ++k) expected += barycentric[3 * i + k] * (c * Motion{}.vertex(sphere.directions[ids[3 * i + k]], f / 30.0));
      const Eigen::Vector3d got(trajs[(f * 300 + i) * 3], trajs[(f * 300 + i) * 3 + 1], trajs[(f * 300 + i) * 3 + 2]);
      worst = std::max(worst, (got - expected).norm());
    }
  }
  EXPECT_LT(worst, 1e-5);
}

TEST(AnimeCliTest, ATruncatedFileIsOneLineAndNothingIsWritten) {
  const fs::path dir = test_support::scratch_dir("anime_cli_bad");
  const fs::path anime = write_sphere(dir / "cut.anime", Motion{}, 5, 10);
  const std::string bytes = file_bytes(anime);
  std::ofstream(anime, std::ios::binary | std::ios::trunc) << bytes.substr(0, bytes.size() - 100);
  const fs::path out = dir / "out";
  fs::create_directories(out);
  const test_support::CliResult run =
      test_support::run_cli("trajectories --anime " + quoted(anime) + " --out " + quoted(out / "t.npz") + " --camera-path " + quoted(out / "c.json"));
  EXPECT_NE(run.exit_code, 0);
  EXPECT_TRUE(contains(run.output, anime.string() + ": the header (5 frames")) << run.output;
  EXPECT_TRUE(contains(run.output, "(truncated)")) << run.output;
  EXPECT_TRUE(test_support::files_in(out).empty());
  const test_support::CliResult both = test_support::run_cli("point-cache --anime " + quoted(anime) + " --character x.glb --out " + quoted(out / "c.pc2"));
  EXPECT_NE(both.exit_code, 0);
  EXPECT_TRUE(contains(both.output, "give no --character")) << both.output;
}

TEST(AnimeCliTest, AnEgoCameraNeedsAHeadThatAMeshDoesNotHave) {
  const fs::path dir = test_support::scratch_dir("anime_cli_ego");
  const fs::path anime = write_sphere(dir / "ball.anime", Motion{}, 5, 10);
  const test_support::CliResult run =
      test_support::run_cli("trajectories --anime " + quoted(anime) + " --camera ego --out " + quoted(dir / "t.npz"));
  EXPECT_NE(run.exit_code, 0);
  EXPECT_TRUE(contains(run.output, "whose source (anime) has no bone map: an ego camera needs the head and hips of a retargeted character's"))
      << run.output;
  EXPECT_FALSE(fs::exists(dir / "t.npz"));
}

// Two spheres on the camera's axis, the near one hiding the far one: every point of the far one
// that faces the camera is occluded by an actor (the near sphere subtends the larger angle), none
// of it is visible, and about half of the near one is.
std::string two_spheres_scene(const fs::path& anime, const std::string& outputs) {
  return R"({"version": 1, "fps": 30,
    "actors": [
      {"name": "near", "anime": ")" + anime.string() + R"(", "source_fps": 10, "placement": {"x": 1, "y": 0}, "points": 400},
      {"name": "far", "anime": ")" + anime.string() + R"(", "source_fps": 10, "placement": {"x": 3.5, "y": 0}, "points": 400}],
    "cameras": [{"name": "axis", "type": "static", "position": [-3, 0, 0.5], "target": [3.5, 0, 0.5]}],
    "outputs": )" + outputs + "}";
}

TEST(AnimeCliTest, AVertexAnimatedActorOccludesAndIsOccluded) {
  const fs::path dir = test_support::scratch_dir("anime_occlusion");
  Motion pulsing;  // in place, only breathing
  pulsing.velocity = Eigen::Vector3d::Zero();
  const fs::path anime = write_sphere(dir / "ball.anime", pulsing, 11, 10);
  std::ofstream(dir / "scene.json") << two_spheres_scene(anime, R"({"trajectories": true})");
  const test_support::CliResult run = test_support::run_cli("scene " + quoted(dir / "scene.json") + " --out " + quoted(dir / "out"));
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const io::NpzReader npz((dir / "out" / "trajectories_axis.npz").string());
  const std::vector<std::int64_t> owner = npz.load("point_actor_ids").to_int64();
  const std::vector<std::int64_t> codes = npz.load("visibility_codes").to_int64();
  const std::size_t points = owner.size();
  std::array<std::array<long, 5>, 2> counts{};
  for (std::size_t i = 0; i < codes.size(); ++i) ++counts[owner[i % points]][codes[i]];
  const double near_frames = 400.0 * (codes.size() / points);
  EXPECT_EQ(counts[1][0], 0) << "a point of the far sphere seen through the near one";
  EXPECT_GT(counts[1][1], 0.3 * near_frames);  // its front half, hidden by an actor
  EXPECT_GT(counts[0][0], 0.3 * near_frames);  // the near sphere's front half, visible
  EXPECT_LT(counts[0][0], 0.6 * near_frames);
  EXPECT_GT(counts[0][1], 0.3 * near_frames);  // its back half, hidden by itself
}

// The scene GLB carries the spheres as morph targets on a joint: the validator finds no error,
// and Blender's evaluated meshes (shape keys, then the armature) put every tracked point where
// trajs_3d does (tests/blender/check_scene_glb.py, as for skinned actors).
TEST(AnimeCliTest, TheSceneGlbsMorphTargetsPassTheValidatorAndBlender) {
  const fs::path dir = test_support::scratch_dir("anime_glb");
  const fs::path anime = write_sphere(dir / "ball.anime", Motion{}, 11, 10);
  std::ofstream(dir / "scene.json") << two_spheres_scene(anime, R"({"trajectories": true, "glb": true})");
  const test_support::CliResult run = test_support::run_cli("scene " + quoted(dir / "scene.json") + " --out " + quoted(dir / "out"));
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const fs::path glb = dir / "out" / "scene.glb";
  ASSERT_TRUE(fs::exists(glb));
  if (const std::string missing = test_support::validator_missing(); missing.empty()) {
    const fs::path log = dir / "validator.txt";
    const int status = std::system(("node " + quoted(test_support::validator_dir() / "validate.mjs") + " " + quoted(glb) +
                                    " --all > " + quoted(log) + " 2>&1").c_str());
    const std::string report = file_bytes(log);
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << report;
    EXPECT_TRUE(contains(report, ": 0 errors,")) << report;
  } else {
    std::printf("validator skipped: %s\n", missing.c_str());
  }
  if (std::system("blender --version > /dev/null 2>&1") != 0) GTEST_SKIP() << "blender is not installed";
  const fs::path script = fs::path(__FILE__).parent_path() / "blender" / "check_scene_glb.py";
  const fs::path report_path = dir / "blender.json", log = dir / "blender.log";
  const int status = std::system(("blender -b --factory-startup --python " + quoted(script) + " -- --glb " + quoted(glb) +
                                  " --fps 30 --frames 0,7,16,30 --report " + quoted(report_path) + " --camera axis=" +
                                  quoted(dir / "out" / "trajectories_axis.npz") + " > " + quoted(log) + " 2>&1").c_str());
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << file_bytes(log);
  const nlohmann::json report = nlohmann::json::parse(std::ifstream(report_path));
  EXPECT_EQ(report["points"], 800);
  EXPECT_LE(report["max_error_3d_m"].get<double>(), 1e-5) << report.dump(1);
  std::printf("Blender vs trajs_3d, two .anime spheres: max %.3g m\n", report["max_error_3d_m"].get<double>());
}

}  // namespace
}  // namespace odyssey
