// Camera paths out of the toolkit:
//   - camera path JSON: a written path reads back to the same poses (within 1e-12) and
//     intrinsics; each kind of bad file (not JSON, a missing key, a 3x4 extrinsics, a non-finite
//     number, an improper rotation, no frames) is an InputError naming the file and the problem;
//     a failed write leaves nothing behind;
//   - an animated GLB with a camera: the bundled RiggedFigure at rest, filmed by an orbiting
//     camera, passes the Khronos validator, and read back with tinygltf (not the writer's code)
//     holds a perspective camera node whose keyframes put the camera at the path's centres and
//     looking along its viewing directions (the node's -Z and +Y taken from glTF's Y up to the
//     toolkit's Z up are pose.forward() and -pose.down()), with continuous quaternion signs;
//   - a camera path that does not match the clip (frame count, fps, changing intrinsics) is
//     rejected and leaves no file.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <tiny_gltf.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <nlohmann/json.hpp>
#include <numbers>
#include <string>
#include <vector>

#include "gltf_reference.h"
#include "mocap_io/camera_path_file.h"
#include "mocap_io/gltf_character.h"
#include "mocap_io/gltf_export.h"
#include "mocap_io/input_error.h"
#include "skeleton/camera.h"
#include "skeleton/rotation.h"
#include "test_support.h"
#include "gltf_validator.h"

namespace odyssey::io {
namespace {

namespace fs = std::filesystem;
using Eigen::Matrix3d;
using Eigen::Vector3d;

fs::path scratch_dir() {
  const fs::path dir = odyssey::test_support::scratch_root() / "camera_export";
  fs::create_directories(dir);
  return dir;
}

std::string read_text(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

void write_text(const fs::path& path, const std::string& text) { std::ofstream(path, std::ios::binary) << text; }

bool partial_files_left(const fs::path& dir) {
  for (const auto& entry : fs::directory_iterator(dir)) {
    if (entry.path().filename().string().find(".partial-") != std::string::npos) return true;
  }
  return false;
}

// A camera circling `target` once over the path (so its heading passes pi, where a quaternion
// taken from each matrix alone changes sign), bobbing up and down, always looking at the target.
CameraPath orbit(int frames, const Vector3d& target, double radius, double fps = 30) {
  CameraPath path;
  path.kind = "orbit";
  path.fps = fps;
  for (int f = 0; f < frames; ++f) {
    const double angle = 2 * std::numbers::pi * f / frames;
    const Vector3d centre = target + Vector3d(radius * std::cos(angle), radius * std::sin(angle),
                                              0.3 * radius * std::sin(3 * angle));
    path.poses.push_back(CameraPose::look_at(centre, target));
    path.intrinsics.push_back(intrinsics_from_hfov(960, 540, 60));
  }
  return path;
}

// --- Camera path JSON. ---

// A written path whose intrinsics differ per frame, and its file as JSON to break in tests.
fs::path written_path_file(const std::string& name, CameraPath* written = nullptr) {
  CameraPath path = orbit(5, Vector3d(0.2, -0.1, 1.0), 2.5, 24);
  path.kind = "ego-head";
  for (int f = 0; f < path.frame_count(); ++f) {
    path.intrinsics[f] = intrinsics_from_hfov(640 + 16 * f, 480, 50 + 3.7 * f);
    path.intrinsics[f].cx += 0.25 * f;  // off centre, as calibrated cameras are
    path.intrinsics[f].fy *= 1.001;
  }
  const fs::path file = scratch_dir() / name;
  write_camera_path_json(file.string(), path);
  if (written) *written = path;
  return file;
}

TEST(CameraPathJsonTest, RoundTripKeepsPosesAndIntrinsics) {
  CameraPath written;
  const fs::path file = written_path_file("round_trip.json", &written);
  const CameraPath read = read_camera_path_json(file.string());
  EXPECT_EQ(read.kind, "ego-head");
  EXPECT_EQ(read.fps, 24);
  ASSERT_EQ(read.frame_count(), written.frame_count());
  ASSERT_EQ(read.intrinsics.size(), written.intrinsics.size());
  for (int f = 0; f < read.frame_count(); ++f) {
    EXPECT_LT((read.poses[f].rotation - written.poses[f].rotation).cwiseAbs().maxCoeff(), 1e-12) << "frame " << f;
    EXPECT_LT((read.poses[f].translation - written.poses[f].translation).cwiseAbs().maxCoeff(), 1e-12) << "frame " << f;
    const PinholeIntrinsics& a = read.intrinsics[f];
    const PinholeIntrinsics& b = written.intrinsics[f];
    EXPECT_EQ(a.width, b.width) << "frame " << f;
    EXPECT_EQ(a.height, b.height) << "frame " << f;
    EXPECT_LT((a.matrix() - b.matrix()).cwiseAbs().maxCoeff(), 1e-12) << "frame " << f;
  }
  // The informative keys say what the reader ignores: the centre and the time.
  const nlohmann::json document = nlohmann::json::parse(read_text(file));
  EXPECT_EQ(document["frame_count"], 5);
  const auto& centre = document["frames"][3]["centre"];
  EXPECT_LT((Vector3d(centre[0], centre[1], centre[2]) - written.poses[3].centre()).norm(), 1e-12);
  EXPECT_NEAR(document["frames"][3]["time"].get<double>(), 3 / 24.0, 1e-15);
  EXPECT_FALSE(partial_files_left(scratch_dir()));
}

// The InputError's problem when reading `text` from `name`, after checking that it names the file.
std::string read_problem(const std::string& name, const std::string& text) {
  const fs::path file = scratch_dir() / name;
  write_text(file, text);
  try {
    read_camera_path_json(file.string());
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), file.string());
    EXPECT_EQ(std::string(e.what()).rfind(file.string() + ": ", 0), 0u) << e.what();
    return e.problem();
  }
  ADD_FAILURE() << name << " was read without an error";
  return "";
}

// The written file's JSON with one change applied.
std::string broken(const std::function<void(nlohmann::ordered_json&)>& change) {
  nlohmann::ordered_json document = nlohmann::ordered_json::parse(read_text(written_path_file("to_break.json")));
  change(document);
  return document.dump(1);
}

TEST(CameraPathJsonTest, BadFilesAreInputErrorsNamingFileAndProblem) {
  EXPECT_NE(read_problem("not_json.json", "{\"format\": \"odyssey camera path\", \"frames\": [").find("not valid JSON"),
            std::string::npos);

  const std::string missing = read_problem(
      "missing_key.json", broken([](auto& d) { d["frames"][2].erase("extrinsics"); }));
  EXPECT_NE(missing.find("frame 2: missing key 'extrinsics'"), std::string::npos) << missing;

  const std::string three_by_four = read_problem(
      "three_by_four.json", broken([](auto& d) { d["frames"][1]["extrinsics"].erase(3); }));
  EXPECT_NE(three_by_four.find("frame 1: 'extrinsics' must be 4 rows of 4 numbers"), std::string::npos) << three_by_four;

  // Non-finite numbers: NaN is not JSON at all, and a number past double's range (which would be
  // infinite) is refused by the parser too; null in a number's place is a mistyped value.
  std::string nan_text = broken([](auto& d) { d["frames"][4]["intrinsics"][0][0] = 12345.5; });
  nan_text.replace(nan_text.find("12345.5"), 7, "NaN");
  const std::string nan = read_problem("nan.json", nan_text);
  EXPECT_NE(nan.find("not valid JSON"), std::string::npos) << nan;
  std::string huge_text = broken([](auto& d) { d["frames"][4]["extrinsics"][0][3] = 12345.5; });
  huge_text.replace(huge_text.find("12345.5"), 7, "1e999");
  const std::string huge = read_problem("huge.json", huge_text);
  EXPECT_NE(huge.find("not valid JSON"), std::string::npos) << huge;
  EXPECT_NE(huge.find("1e999"), std::string::npos) << huge;
  const std::string null = read_problem("null.json", broken([](auto& d) { d["frames"][4]["extrinsics"][0][3] = nullptr; }));
  EXPECT_NE(null.find("frame 4: 'extrinsics' row 0 column 3 must be a number"), std::string::npos) << null;

  // A mirror (determinant -1) is orthonormal but not a rotation.
  const std::string improper = read_problem("improper.json", broken([](auto& d) {
                                              for (int c = 0; c < 4; ++c) {
                                                d["frames"][3]["extrinsics"][0][c] = -d["frames"][3]["extrinsics"][0][c].template get<double>();
                                              }
                                            }));
  EXPECT_NE(improper.find("frame 3: rotation is not a proper rotation"), std::string::npos) << improper;

  const std::string empty = read_problem("no_frames.json", broken([](auto& d) {
                                           d["frames"] = nlohmann::ordered_json::array();
                                           d["frame_count"] = 0;
                                         }));
  EXPECT_NE(empty.find("'frames' is empty"), std::string::npos) << empty;

  const std::string count = read_problem("wrong_count.json", broken([](auto& d) { d["frame_count"] = 4; }));
  EXPECT_NE(count.find("'frame_count' must be the number of entries in 'frames', 5"), std::string::npos) << count;

  const std::string missing_file = (scratch_dir() / "no_such_camera.json").string();
  try {
    read_camera_path_json(missing_file);
    ADD_FAILURE() << "a missing file was read";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), missing_file);
  }
}

TEST(CameraPathJsonTest, FailedWritesLeaveNothing) {
  CameraPath path = orbit(4, Vector3d(0, 0, 1), 3);
  const fs::path dir = scratch_dir() / "no_such_dir";
  fs::remove_all(dir);
  const fs::path unwritable = dir / "camera.json";
  try {
    write_camera_path_json(unwritable.string(), path);
    ADD_FAILURE() << "wrote into a missing folder";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), unwritable.string());
    EXPECT_NE(e.problem().find("its folder " + dir.string() + " does not exist"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(dir));

  const fs::path invalid = scratch_dir() / "invalid_camera.json";
  fs::remove(invalid);
  path.poses[2].rotation.row(1) *= -1;  // a mirror
  EXPECT_THROW(write_camera_path_json(invalid.string(), path), std::invalid_argument);
  EXPECT_THROW(write_camera_path_json(invalid.string(), CameraPath{}), std::invalid_argument);
  EXPECT_FALSE(fs::exists(invalid));
  EXPECT_FALSE(partial_files_left(scratch_dir()));
}

// --- The camera in the animated GLB. ---

std::string figure_path() { return std::string(ODYSSEY_DATA_DIR) + "/characters/RiggedFigure.glb"; }

// The character standing at rest for `frames` frames, its roots translated to their rest offsets.
Clip rest_clip(const Character& character, int frames) {
  const Skeleton& skeleton = character.skeleton;
  Clip clip;
  clip.skeleton = skeleton;
  clip.fps = 30;
  for (int j = 0; j < skeleton.joint_count(); ++j) {
    if (skeleton.parent(j) < 0) clip.translated_joints.push_back(j);
  }
  for (int f = 0; f < frames; ++f) {
    clip.rotations.insert(clip.rotations.end(), skeleton.rest_rotations().begin(), skeleton.rest_rotations().end());
    for (int j : clip.translated_joints) clip.translations.push_back(skeleton.rest_offsets()[j]);
  }
  return clip;
}

// An orbit around the character's middle at twice its size.
CameraPath orbit_around(const Character& character, int frames) {
  const Eigen::AlignedBox3d bounds = character.rest_bounds();
  return orbit(frames, bounds.center(), 2 * bounds.sizes().maxCoeff());
}

constexpr int kFrames = 12;

fs::path write_filmed_figure(const std::string& name, const Character& character, const CameraPath& camera) {
  GlbExportOptions options;
  options.camera = &camera;
  options.camera_name = "orbit_cam";
  const fs::path out = scratch_dir() / name;
  write_animated_glb(figure_path(), character, rest_clip(character, kFrames), out.string(), options);
  return out;
}

using test_support::validator_dir;
using test_support::validator_missing;

TEST(GlbCameraTest, PassesTheKhronosValidatorWithZeroErrors) {
  if (const std::string missing = validator_missing(); !missing.empty()) GTEST_SKIP() << missing;
  const Character character = load_character(figure_path());
  const fs::path out = write_filmed_figure("filmed_validated.glb", character, orbit_around(character, kFrames));
  const fs::path log = fs::path(out).replace_extension(".validator.txt");
  const int status = std::system(("node '" + (validator_dir() / "validate.mjs").string() + "' '" + out.string() +
                                  "' > '" + log.string() + "' 2>&1").c_str());
  const std::string report = read_text(log);
  ASSERT_TRUE(WIFEXITED(status)) << report;
  EXPECT_EQ(WEXITSTATUS(status), 0) << report;
  EXPECT_NE(report.find(": 0 errors,"), std::string::npos) << report;
}

// The GLB's JSON chunk as written (tinygltf reads an absent zfar as 0, so only the JSON shows it).
nlohmann::json glb_json(const fs::path& file) {
  const std::string bytes = read_text(file);
  std::uint32_t length = 0;
  std::memcpy(&length, bytes.data() + 12, 4);
  return nlohmann::json::parse(bytes.substr(20, length));
}

TEST(GlbCameraTest, CameraNodeFollowsThePath) {
  const Character character = load_character(figure_path());
  const CameraPath camera = orbit_around(character, kFrames);
  const fs::path out = write_filmed_figure("filmed.glb", character, camera);
  const tinygltf::Model model = gltf_reference::parse(out.string());

  int node = -1;
  for (std::size_t n = 0; n < model.nodes.size(); ++n) {
    if (model.nodes[n].name == "orbit_cam") node = int(n);
  }
  ASSERT_GE(node, 0);
  for (const tinygltf::Node& other : model.nodes) {
    EXPECT_EQ(std::count(other.children.begin(), other.children.end(), node), 0) << "the camera node is not a root";
  }
  const tinygltf::Scene& scene = model.scenes.at(model.defaultScene >= 0 ? model.defaultScene : 0);
  EXPECT_EQ(std::count(scene.nodes.begin(), scene.nodes.end(), node), 1);

  // The projection: yfov from fy and the image height, the image's aspect, no far plane.
  ASSERT_GE(model.nodes[node].camera, 0);
  const tinygltf::Camera& gltf_camera = model.cameras.at(model.nodes[node].camera);
  EXPECT_EQ(gltf_camera.type, "perspective");
  const PinholeIntrinsics& k = camera.intrinsics[0];
  EXPECT_NEAR(gltf_camera.perspective.yfov, 2 * std::atan(540 / (2 * k.fy)), 1e-12);
  // 60 degrees across 960 pixels is 2 atan(tan(30 deg) 540 / 960) = 35.98 degrees down 540.
  EXPECT_NEAR(gltf_camera.perspective.yfov * 180 / std::numbers::pi, 35.9834, 1e-4);
  EXPECT_NEAR(gltf_camera.perspective.aspectRatio, 960.0 / 540.0, 1e-12);
  EXPECT_NEAR(gltf_camera.perspective.znear, 0.01, 1e-15);
  const nlohmann::json perspective = glb_json(out)["cameras"][model.nodes[node].camera]["perspective"];
  EXPECT_FALSE(perspective.contains("zfar")) << perspective.dump();

  // The two channels, LINEAR, on the joints' time accessor.
  ASSERT_EQ(model.animations.size(), 1u);
  const tinygltf::Animation& animation = model.animations[0];
  const int time_accessor = animation.samplers.at(animation.channels.at(0).sampler).input;
  const tinygltf::AnimationSampler* translation = nullptr;
  const tinygltf::AnimationSampler* rotation = nullptr;
  for (const tinygltf::AnimationChannel& channel : animation.channels) {
    if (channel.target_node != node) continue;
    const tinygltf::AnimationSampler& sampler = animation.samplers.at(channel.sampler);
    EXPECT_EQ(sampler.interpolation, "LINEAR");
    EXPECT_EQ(sampler.input, time_accessor);
    if (channel.target_path == "translation") translation = &sampler;
    if (channel.target_path == "rotation") rotation = &sampler;
  }
  ASSERT_TRUE(translation && rotation);
  const auto times = gltf_reference::elements(model, time_accessor);
  const auto centres = gltf_reference::elements(model, translation->output);
  const auto quaternions = gltf_reference::elements(model, rotation->output);
  ASSERT_EQ(times.size(), std::size_t(kFrames));
  ASSERT_EQ(centres.size(), std::size_t(kFrames));
  ASSERT_EQ(quaternions.size(), std::size_t(kFrames));

  // Each keyframe, taken from glTF's Y up to the toolkit's Z up by C: the node's origin is the
  // camera centre, its -Z the viewing direction, its +Y image up and its +X image right. Float32
  // storage leaves about 1e-7 of error.
  const Matrix3d c = y_up_to_z_up();
  const double scale = camera.poses[0].centre().norm();
  for (int f = 0; f < kFrames; ++f) {
    const CameraPose& pose = camera.poses[f];
    EXPECT_NEAR(times[f][0], f / 30.0, 1e-6);
    const Vector3d centre(centres[f][0], centres[f][1], centres[f][2]);
    EXPECT_LT((c * centre - pose.centre()).norm(), 1e-6 * (1 + scale)) << "frame " << f;
    const Matrix3d r = gltf_reference::trs_matrix({}, quaternions[f], {}).topLeftCorner<3, 3>();
    EXPECT_LT((c * r * Vector3d(0, 0, -1) - pose.forward()).norm(), 1e-6) << "frame " << f;
    EXPECT_LT((c * r * Vector3d(0, 1, 0) + pose.down()).norm(), 1e-6) << "frame " << f;
    EXPECT_LT((c * r * Vector3d(1, 0, 0) - pose.right()).norm(), 1e-6) << "frame " << f;
    // The orbit passes half a turn: signs stay continuous so LINEAR takes the short way.
    if (f > 0) {
      double dot = 0;
      for (int i = 0; i < 4; ++i) dot += quaternions[f][i] * quaternions[f - 1][i];
      EXPECT_GT(dot, 0) << "frame " << f;
    }
  }
  // The static transform is frame 0's, for viewers that do not play the animation.
  const tinygltf::Node& static_node = model.nodes[node];
  ASSERT_EQ(static_node.translation.size(), 3u);
  ASSERT_EQ(static_node.rotation.size(), 4u);
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(static_node.translation[i], centres[0][i], 1e-6 * (1 + scale));
  for (int i = 0; i < 4; ++i) EXPECT_NEAR(static_node.rotation[i], quaternions[0][i], 1e-7);
}

std::string invalid_argument_of(const std::function<void()>& run) {
  try {
    run();
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  ADD_FAILURE() << "no std::invalid_argument";
  return "";
}

TEST(GlbCameraTest, CameraNotMatchingTheClipIsRejectedAndLeavesNoFile) {
  const Character character = load_character(figure_path());
  const fs::path out = scratch_dir() / "mismatched_camera.glb";
  fs::remove(out);

  const std::string frames = invalid_argument_of(
      [&] { write_filmed_figure(out.filename().string(), character, orbit_around(character, kFrames + 1)); });
  EXPECT_NE(frames.find("the camera path has 13 frames but the clip has 12"), std::string::npos) << frames;

  CameraPath slow = orbit_around(character, kFrames);
  slow.fps = 25;
  const std::string fps =
      invalid_argument_of([&] { write_filmed_figure(out.filename().string(), character, slow); });
  EXPECT_NE(fps.find("fps"), std::string::npos) << fps;

  CameraPath zooming = orbit_around(character, kFrames);
  zooming.intrinsics[5] = intrinsics_from_hfov(960, 540, 40);
  const std::string zoom =
      invalid_argument_of([&] { write_filmed_figure(out.filename().string(), character, zooming); });
  EXPECT_NE(zoom.find("camera path frame 5 has other intrinsics than frame 0"), std::string::npos) << zoom;

  EXPECT_FALSE(fs::exists(out));
  EXPECT_FALSE(partial_files_left(scratch_dir()));
}

}  // namespace
}  // namespace odyssey::io
