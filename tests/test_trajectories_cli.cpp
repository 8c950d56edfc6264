// `odyssey trajectories` and `odyssey point-cache` end to end, checked against routes the commands
// do not take:
// - the motion is rebuilt here from the library calls `odyssey retarget` makes with the same
//   options (load, resample, maps, the retarget stage), and the points are re-sampled with the same
//   seed; every tracked point at chosen frames equals forward kinematics plus the plain double
//   skinning reference (skin_mesh_reference) interpolated with the point's barycentric weights;
// - every pixel equals the pinhole model written out by hand from the file's own K and [R t],
//   `valids` is "in front of the camera and inside the image", and `visibs` agrees with ray casting
//   against every skinned triangle;
// - numpy loads the file with the dataset's keys, dtypes and shapes;
// - the ego camera sits at the head joint plus the eye offset and looks along the head's forward
//   axis on every frame;
// - the PC2 header and size are right and its frames equal the reference skinning;
// - peak memory does not grow with the clip (a child process's maximum resident set, 8x frames);
// - bad input fails with a message naming the problem and leaves no file.
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "test_support.h"
#include "cli_runner.h"
#include "mocap_io/bvh.h"
#include "mocap_io/camera_path_file.h"
#include "mocap_io/gltf_character.h"
#include "mocap_io/npy.h"
#include "retarget/bone_map.h"
#include "retarget/canonical.h"
#include "retarget/parts.h"
#include "retarget/quality.h"
#include "scene_layouts/camera_rigs.h"
#include "scene_layouts/frame_loop.h"
#include "skinning/sampling.h"

namespace odyssey {
namespace {

using test_support::contains;
using test_support::numpy_python;

namespace fs = std::filesystem;

const std::string kWalk = std::string(ODYSSEY_DATA_DIR) + "/mocap/cmu_walk_cgspeed.bvh";
const std::string kJump = std::string(ODYSSEY_SHARED_DIR) + "/assets/mocap/cmu_jump_cgspeed.bvh";
const std::string kFigure = std::string(ODYSSEY_DATA_DIR) + "/characters/RiggedFigure.glb";
const auto run = test_support::run_cli;

fs::path scratch(const std::string& name) {
  const fs::path dir = odyssey::test_support::scratch_root() / "trajectories_cli";
  fs::create_directories(dir);
  return dir / name;
}

// Nothing in the scratch folder whose name starts with `stem`, temporaries included.
void expect_no_output_named(const std::string& stem) {
  for (const fs::directory_entry& entry : fs::directory_iterator(scratch(""))) {
    EXPECT_FALSE(entry.path().filename().string().starts_with(stem)) << "left behind: " << entry.path();
  }
}

// The character's motion as `odyssey retarget --motion bvh --character c --quality q` makes it
// (default options: BVH units and up axis inferred, 30 fps, parts body, rest alignment).
struct Retargeted {
  Character character;
  retarget::BoneMap target_map;
  Clip clip;
};

Retargeted retarget_like_the_cli(const std::string& bvh, const std::string& character_path, retarget::Quality quality) {
  Retargeted out;
  const Clip source = io::load_bvh_inferring_frame(bvh).clip.resampled(30);
  out.character = io::load_character(character_path);
  const retarget::BoneMap source_map =
      retarget::restrict_bone_map(retarget::humanoid_bone_map(source.skeleton, bvh, ""), retarget::Parts::body);
  out.target_map = retarget::restrict_bone_map(retarget::humanoid_bone_map(out.character.skeleton, character_path, ""),
                                               retarget::Parts::body);
  out.clip = retarget::retarget(source, source_map, out.character, out.target_map, quality, {}, std::nullopt, bvh)
                 .result.transfer.clip;
  return out;
}

// Reference positions of every vertex of every mesh at one frame, in double.
std::vector<std::vector<Eigen::Vector3d>> reference_vertices(const Character& character, const Clip& clip, int frame) {
  std::vector<RigidTransform<double>> world(clip.joint_count());
  clip.world_pose(frame, world);
  std::vector<std::vector<Eigen::Vector3d>> meshes;
  for (const CharacterMesh& mesh : character.meshes) meshes.push_back(skin_mesh_reference(mesh, world));
  return meshes;
}

double character_size(const Character& character) { return std::max(1.0, character.rest_bounds().sizes().maxCoeff()); }

TEST(TrajectoriesCliTest, PointsAndPixelsMatchTheReferenceAndNumpyLoadsTheFile) {
  const fs::path npz = scratch("walk.npz"), camera_json = scratch("walk_camera.json");
  const test_support::CliResult result =
      run("trajectories --motion " + kWalk + " --character " + kFigure + " --quality balanced --points 400 --seed 7 " +
          "--camera orbit --camera-period 2 --out " + npz.string() + " --camera-path " + camera_json.string());
  ASSERT_EQ(result.exit_code, 0) << result.output;

  const Retargeted motion = retarget_like_the_cli(kWalk, kFigure, retarget::Quality::balanced);
  skinning::SamplingOptions sampling;
  sampling.count = 400;
  sampling.seed = 7;
  const std::vector<skinning::SurfacePoint> points = skinning::sample_surface_points(motion.character, sampling);
  const std::size_t frames = motion.clip.frame_count(), n = points.size();

  const io::NpzReader file(npz.string());
  const io::NpyArray trajs_3d = file.load("trajs_3d"), trajs_2d = file.load("trajs_2d"), valids = file.load("valids");
  const io::NpyArray intrinsics = file.load("intrinsics"), extrinsics = file.load("extrinsics");
  ASSERT_EQ(trajs_3d.shape(), (std::vector<std::size_t>{frames, n, 3}));
  ASSERT_EQ(trajs_2d.shape(), (std::vector<std::size_t>{frames, n, 2}));
  ASSERT_EQ(valids.shape(), (std::vector<std::size_t>{frames, n}));
  ASSERT_EQ(intrinsics.shape(), (std::vector<std::size_t>{frames, 3, 3}));
  ASSERT_EQ(extrinsics.shape(), (std::vector<std::size_t>{frames, 4, 4}));
  EXPECT_EQ(trajs_3d.dtype(), io::DType::Float32);
  EXPECT_EQ(valids.dtype(), io::DType::Bool);
  scene::StreamActor actor;
  actor.character = &motion.character;
  actor.points = points;
  const io::TrajectoryFileHeader header = scene::trajectory_file_header(std::span(&actor, 1), nullptr, frames, 30);
  EXPECT_EQ(file.load("point_vertex_ids").to_int64(),
            std::vector<std::int64_t>(header.point_vertex_ids.begin(), header.point_vertex_ids.end()));

  const std::vector<float> p3 = trajs_3d.to_float(), p2 = trajs_2d.to_float(), k = intrinsics.to_float(),
                           e = extrinsics.to_float();
  const std::vector<double> valid = valids.to_double();
  const double tolerance = 1e-5 * character_size(motion.character);
  const std::vector<double> visible = file.load("visibs").to_double();
  std::size_t checked_valid = 0, checked_visible = 0, visible_agree = 0, visible_count = 0;
  for (const std::size_t f : {std::size_t{0}, frames / 3, frames / 2, frames - 1}) {
    const auto vertices = reference_vertices(motion.character, motion.clip, static_cast<int>(f));
    const Eigen::Vector3d camera_centre = [&] {
      Eigen::Matrix3d r;
      Eigen::Vector3d t;
      for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) r(i, j) = e[f * 16 + 4 * i + j];
        t[i] = e[f * 16 + 4 * i + 3];
      }
      return Eigen::Vector3d(-(r.transpose() * t));
    }();
    for (std::size_t i = 0; i < n; ++i) {
      const skinning::SurfacePoint& point = points[i];
      Eigen::Vector3d expected = Eigen::Vector3d::Zero();
      for (int c = 0; c < 3; ++c) expected += double(point.barycentric[c]) * vertices[point.mesh][point.vertices[c]];
      const float* got = &p3[(f * n + i) * 3];
      ASSERT_NEAR((Eigen::Vector3d(got[0], got[1], got[2]) - expected).norm(), 0, tolerance) << "frame " << f << " point " << i;

      // The pinhole model by hand, from the file's own matrices: x_c = R x + t, (u, v) = (fx x/z + cx, fy y/z + cy).
      const float* m = &e[f * 16];
      const float* kk = &k[f * 9];
      double camera[3];
      for (int r = 0; r < 3; ++r) {
        camera[r] = m[4 * r] * double(got[0]) + m[4 * r + 1] * double(got[1]) + m[4 * r + 2] * double(got[2]) + m[4 * r + 3];
      }
      const double u = kk[0] * camera[0] / camera[2] + kk[2], v = kk[4] * camera[1] / camera[2] + kk[5];
      const bool inside = camera[2] > 0 && u >= 0 && u < 960 && v >= 0 && v < 540;
      // Pixels near the border may flip between the file's double route and this float one.
      const bool near_border =
          std::abs(u) < 0.01 || std::abs(u - 960) < 0.01 || std::abs(v) < 0.01 || std::abs(v - 540) < 0.01;
      if (!near_border) {
        EXPECT_EQ(valid[f * n + i] != 0, inside) << "frame " << f << " point " << i;
      }
      if (camera[2] > 0) {
        EXPECT_NEAR(p2[(f * n + i) * 2], u, 2e-3) << "frame " << f << " point " << i;
        EXPECT_NEAR(p2[(f * n + i) * 2 + 1], v, 2e-3) << "frame " << f << " point " << i;
      }
      checked_valid += inside;
      // Visibility by another route: a ray from the camera to the point, tested against every
      // skinned triangle (Moller-Trumbore); hidden when a triangle not holding the point crosses it
      // more than 1 mm before the point.
      if (inside && !near_border) {
        bool hidden = false;
        const Eigen::Vector3d ray = expected - camera_centre;
        for (std::size_t m = 0; m < motion.character.meshes.size() && !hidden; ++m) {
          const std::vector<std::uint32_t>& tris = motion.character.meshes[m].triangles;
          for (std::size_t t = 0; t < tris.size() && !hidden; t += 3) {
            const Eigen::Vector3d& a = vertices[m][tris[t]];
            const Eigen::Vector3d e1 = vertices[m][tris[t + 1]] - a, e2 = vertices[m][tris[t + 2]] - a;
            const Eigen::Vector3d pv = ray.cross(e2);
            const double det = e1.dot(pv);
            if (std::abs(det) < 1e-15) continue;
            const Eigen::Vector3d tv = camera_centre - a;
            const double bu = tv.dot(pv) / det;
            const Eigen::Vector3d qv = tv.cross(e1);
            const double bv = ray.dot(qv) / det;
            const double along = e2.dot(qv) / det;  // in units of the ray: 1 at the point
            hidden = bu >= 0 && bv >= 0 && bu + bv <= 1 && along > 0 && (1 - along) * ray.norm() > 1e-3;
          }
        }
        ++checked_visible;
        visible_agree += (visible[f * n + i] != 0) == !hidden;
        visible_count += !hidden;
      }
    }
  }
  EXPECT_GT(checked_valid, n);  // the orbit sees the character: most points are in view
  EXPECT_GT(visible_agree, 0.98 * checked_visible) << visible_agree << " of " << checked_visible;
  EXPECT_GT(visible_count, 0.3 * checked_valid);  // a closed body shows a bit less than half its surface
  EXPECT_LT(visible_count, 0.6 * checked_valid);
  // The default image and field of view: 960x540, 80 degrees horizontally.
  EXPECT_NEAR(k[0], 480 / std::tan(40 * M_PI / 180), 1e-3);
  EXPECT_EQ(k[2], 480.0f);
  EXPECT_EQ(k[5], 270.0f);

  // The camera path JSON is the npz's cameras.
  const CameraPath camera = io::read_camera_path_json(camera_json.string());
  ASSERT_EQ(camera.frame_count(), static_cast<int>(frames));
  for (std::size_t f = 0; f < frames; f += 7) {
    const Eigen::Matrix4d m = camera.poses[f].extrinsics();
    for (int r = 0; r < 4; ++r) {
      for (int c = 0; c < 4; ++c) EXPECT_NEAR(m(r, c), e[f * 16 + r * 4 + c], 1e-5 * (1 + std::abs(m(r, c))));
    }
  }

  const std::string python = numpy_python();
  if (python.empty()) GTEST_SKIP() << "python3 with numpy not found";
  const fs::path script = scratch("check.py");
  std::ofstream(script) << "import sys, numpy as np\n"
                           "d = np.load(sys.argv[1])\n"
                           "T, N = int(sys.argv[2]), int(sys.argv[3])\n"
                           "want = {'trajs_3d': ('float32', (T, N, 3)), 'trajs_2d': ('float32', (T, N, 2)),\n"
                           "        'valids': ('bool', (T, N)), 'intrinsics': ('float32', (T, 3, 3)),\n"
                           "        'extrinsics': ('float32', (T, 4, 4)), 'point_vertex_ids': ('int32', (N, 3)),\n"
                           "        'point_barycentric': ('float32', (N, 3)), 'point_actor_ids': ('int32', (N,)),\n"
                           "        'fps': ('float64', ())}\n"
                           "for key, (dtype, shape) in want.items():\n"
                           "    assert d[key].dtype == np.dtype(dtype), (key, d[key].dtype)\n"
                           "    assert d[key].shape == shape, (key, d[key].shape)\n"
                           "assert float(d['fps']) == 30.0\n"
                           "assert np.allclose(d['point_barycentric'].sum(axis=1), 1, atol=1e-6)\n"
                           "assert np.isfinite(d['trajs_3d']).all() and np.isfinite(d['trajs_2d']).all()\n"
                           "assert (d['extrinsics'][:, 3] == [0, 0, 0, 1]).all()\n";
  const int status = std::system((python + " " + script.string() + " " + npz.string() + " " + std::to_string(frames) +
                                  " " + std::to_string(n)).c_str());
  EXPECT_EQ(status, 0);
}

TEST(TrajectoriesCliTest, EgoCameraSitsAtTheHeadPlusTheEyeOffsetAndLooksAlongItsForwardAxis) {
  const fs::path npz = scratch("ego.npz");
  const test_support::CliResult result =
      run("trajectories --motion " + kWalk + " --character " + kFigure +
          " --points 50 --camera ego --eye-forward 0.1 --eye-up 0.05 --out " + npz.string());
  ASSERT_EQ(result.exit_code, 0) << result.output;
  const Retargeted motion = retarget_like_the_cli(kWalk, kFigure, retarget::Quality::fast);
  const int head = motion.target_map.joints[retarget::canonical::head];
  const scene::HeadFrame head_frame =
      scene::head_frame_from_rest(motion.character.skeleton, head, motion.target_map.joints[retarget::canonical::left_hip],
                                  motion.target_map.joints[retarget::canonical::right_hip]);
  const std::vector<float> e = io::NpzReader(npz.string()).load("extrinsics").to_float();
  ASSERT_EQ(e.size(), std::size_t(motion.clip.frame_count()) * 16);
  std::vector<RigidTransform<double>> world(motion.clip.joint_count());
  for (int f = 0; f < motion.clip.frame_count(); ++f) {
    motion.clip.world_pose(f, world);
    const RigidTransform<double>& h = world[head];
    const Eigen::Vector3d centre = h.translation + h.rotation * (0.1 * head_frame.forward_local + 0.05 * head_frame.up_local);
    const Eigen::Vector3d forward = h.rotation * head_frame.forward_local;
    Eigen::Matrix3d r;
    Eigen::Vector3d t;
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) r(i, j) = e[f * 16 + 4 * i + j];
      t[i] = e[f * 16 + 4 * i + 3];
    }
    // Float32 matrices: centre = -R^T t to a few 1e-7 of the distance from the origin.
    EXPECT_NEAR((-(r.transpose() * t) - centre).norm(), 0, 1e-5) << "frame " << f;
    EXPECT_NEAR((r.row(2).transpose() - forward).norm(), 0, 1e-6) << "frame " << f;
  }
}

// PC2 header fields, read back field by field.
struct Pc2Header {
  char magic[12];
  std::int32_t version, points;
  float start, rate;
  std::int32_t samples;
};

TEST(PointCacheCliTest, HeaderSizeAndFramesMatchTheReferenceSkinning) {
  const fs::path pc2 = scratch("walk.pc2");
  const test_support::CliResult result =
      run("point-cache --motion " + kWalk + " --character " + kFigure + " --out " + pc2.string());
  ASSERT_EQ(result.exit_code, 0) << result.output;
  const Retargeted motion = retarget_like_the_cli(kWalk, kFigure, retarget::Quality::fast);
  std::size_t vertices = 0;
  for (const CharacterMesh& mesh : motion.character.meshes) vertices += mesh.positions.size();
  const std::size_t frames = motion.clip.frame_count();

  std::ifstream in(pc2, std::ios::binary);
  const std::vector<char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  ASSERT_EQ(bytes.size(), 32 + frames * vertices * 12);
  Pc2Header header;
  static_assert(sizeof(Pc2Header) == 32);
  std::memcpy(&header, bytes.data(), 32);
  EXPECT_EQ(std::memcmp(header.magic, "POINTCACHE2\0", 12), 0);
  EXPECT_EQ(header.version, 1);
  EXPECT_EQ(header.points, static_cast<std::int32_t>(vertices));
  EXPECT_EQ(header.start, 0.0f);
  EXPECT_EQ(header.rate, 1.0f);
  EXPECT_EQ(header.samples, static_cast<std::int32_t>(frames));

  const double tolerance = 1e-5 * character_size(motion.character);
  for (const std::size_t f : {std::size_t{0}, frames / 2, frames - 1}) {
    const auto reference = reference_vertices(motion.character, motion.clip, static_cast<int>(f));
    std::size_t row = 0;
    for (const auto& mesh : reference) {
      for (const Eigen::Vector3d& expected : mesh) {
        float got[3];
        std::memcpy(got, bytes.data() + 32 + (f * vertices + row) * 12, 12);
        ASSERT_NEAR((Eigen::Vector3d(got[0], got[1], got[2]) - expected).norm(), 0, tolerance) << "frame " << f;
        ++row;
      }
    }
  }
  // The rest OBJ beside it names the same vertices in the same order.
  std::ifstream obj(fs::path(pc2).replace_extension(".obj"));
  std::string line;
  std::size_t obj_vertices = 0;
  while (std::getline(obj, line)) obj_vertices += line.starts_with("v ");
  EXPECT_EQ(obj_vertices, vertices);
}

// Peak resident memory of one command run in a child process, in MiB.
double peak_memory_mib(const std::string& arguments) {
  const pid_t child = fork();
  if (child == 0) {
    const std::string command = std::string(ODYSSEY_CLI) + " " + arguments + " > /dev/null 2>&1";
    execl("/bin/sh", "sh", "-c", ("exec " + command).c_str(), static_cast<char*>(nullptr));
    _exit(127);
  }
  int status = 0;
  rusage usage{};
  if (wait4(child, &status, 0, &usage) != child || !WIFEXITED(status) || WEXITSTATUS(status) != 0) return -1;
  return usage.ru_maxrss / 1024.0;  // kilobytes on Linux
}

TEST(TrajectoriesCliTest, PeakMemoryStaysFlatAsTheClipGrows) {
  // 688 frames at 30 fps, then 5,504 at 240 fps, 1,000 points each: the long file's arrays are
  // 5,504 x 1,000 x 21 bytes = 110 MiB, so an export that held them would grow by more than that.
  const std::string base = "trajectories --motion " + kJump + " --character " + kFigure + " --points 1000 --out ";
  const double short_clip = peak_memory_mib(base + scratch("memory_short.npz").string() + " --fps 30");
  const double long_clip = peak_memory_mib(base + scratch("memory_long.npz").string() + " --fps 240");
  ASSERT_GT(short_clip, 0);
  ASSERT_GT(long_clip, 0);
  EXPECT_LT(long_clip - short_clip, 30) << short_clip << " MiB for 688 frames, " << long_clip << " MiB for 5,504";
  EXPECT_EQ(fs::file_size(scratch("memory_long.npz")) > 100'000'000, true);
  fs::remove(scratch("memory_short.npz"));
  fs::remove(scratch("memory_long.npz"));
}

TEST(TrajectoriesCliTest, BadInputFailsNamingTheProblemAndWritesNothing) {
  const std::string base = "trajectories --motion " + kWalk + " --character " + kFigure + " --out " +
                           scratch("bad.npz").string() + " --camera-path " + scratch("bad_camera.json").string();
  // A static camera at the character's pelvis on the first frame, looking ahead.
  const Retargeted motion = retarget_like_the_cli(kWalk, kFigure, retarget::Quality::fast);
  std::vector<RigidTransform<double>> world(motion.clip.joint_count());
  motion.clip.world_pose(0, world);
  const Eigen::Vector3d pelvis = world[motion.target_map.joints[retarget::canonical::pelvis]].translation;
  const auto triple = [](const Eigen::Vector3d& p) {
    return std::to_string(p.x()) + "," + std::to_string(p.y()) + "," + std::to_string(p.z());
  };
  const std::string inside = " --camera static --camera-position " + triple(pelvis) + " --camera-target " +
                             triple(pelvis + Eigen::Vector3d(0, 1, 0));
  struct Case {
    std::string arguments;
    int exit_code;
    std::string message;
  };
  const Case cases[] = {
      {" --sampling vertices --points 1000000", 1, kFigure + ": cannot sample points"},
      {" --hfov 0", 2, "--hfov"},
      {" --hfov 180", 2, "--hfov"},
      {" --width 0", 2, "--width"},
      {" --camera none", 2, "need a camera"},
      {inside, 1, "is inside actor 'RiggedFigure' at frame 0"},
      {" --camera orbit --camera-radius 0", 2, "--camera-radius"},
      {" --points 0", 2, "--points"},
  };
  for (const Case& bad : cases) {
    const test_support::CliResult result = run(base + bad.arguments);
    EXPECT_EQ(result.exit_code, bad.exit_code) << bad.arguments << "\n" << result.output;
    EXPECT_TRUE(contains(result.output, bad.message)) << bad.arguments << "\n" << result.output;
    expect_no_output_named("bad");
  }

  // A character without a skin: SimpleSkin with its skin taken out has nothing to drive.
  nlohmann::json gltf = nlohmann::json::parse(std::ifstream(std::string(ODYSSEY_SHARED_DIR) + "/assets/characters/SimpleSkin.gltf"));
  gltf.erase("skins");
  for (nlohmann::json& node : gltf["nodes"]) node.erase("skin");
  const fs::path skinless = scratch("skinless.gltf");
  std::ofstream(skinless) << gltf.dump();
  const test_support::CliResult no_skin =
      run("trajectories --motion " + kWalk + " --character " + skinless.string() + " --out " + scratch("bad.npz").string());
  EXPECT_EQ(no_skin.exit_code, 1) << no_skin.output;
  EXPECT_TRUE(contains(no_skin.output, skinless.string() + ": not a humanoid rig")) << no_skin.output;
  expect_no_output_named("bad");

  // A motion of no frames: a BVH whose MOTION section says so.
  std::ifstream walk(kWalk);
  std::string text((std::istreambuf_iterator<char>(walk)), std::istreambuf_iterator<char>());
  text = text.substr(0, text.find("Frames:")) + "Frames: 0\nFrame Time: 0.008333\n";
  const fs::path empty = scratch("empty_motion.bvh");
  std::ofstream(empty) << text;
  const test_support::CliResult result =
      run("trajectories --motion " + empty.string() + " --character " + kFigure + " --out " + scratch("bad.npz").string());
  EXPECT_EQ(result.exit_code, 1) << result.output;
  EXPECT_TRUE(contains(result.output, empty.string())) << result.output;
  expect_no_output_named("bad");
}

}  // namespace
}  // namespace odyssey
