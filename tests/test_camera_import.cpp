// Cameras from real video: the RealEstate10K and COLMAP text readers (mocap_io/camera_import.h)
// on hand-made files whose cameras are known and on the shared real samples, and the placement of
// a track in a scene (scene_layouts/imported_camera.h): levelling, slerp resampling, rescaling to
// the extent about the centre, the start direction, re-aiming; and every bad input named.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include "mocap_io/camera_import.h"
#include "mocap_io/input_error.h"
#include "scene_layouts/imported_camera.h"
#include "test_support.h"

namespace odyssey {
namespace {

namespace fs = std::filesystem;
using Eigen::Matrix3d;
using Eigen::Vector3d;
using test_support::contains;
constexpr double kPi = std::numbers::pi;

const std::string kShared = ODYSSEY_SHARED_DIR;
const std::string kRealEstate = kShared + "/assets/cameras/realestate10k/0bf152ef84195293.txt";
const std::string kColmap = kShared + "/assets/cameras/colmap_unsorted";

// A reconstruction's world whose up is +y (as many SfM worlds have it): a camera at `centre`
// looking horizontally along heading angle `yaw` about +y from +x, upright (image up = +y).
//   forward = Ry(yaw) e_x, down = -e_y, right = down x forward (OpenCV: x = y x z).
CameraPose upright_camera(const Vector3d& centre, double yaw) {
  const Vector3d forward = Eigen::AngleAxisd(yaw, Vector3d::UnitY()) * Vector3d::UnitX();
  const Vector3d down = -Vector3d::UnitY();
  CameraPose pose;
  pose.rotation.row(0) = down.cross(forward);
  pose.rotation.row(1) = down;
  pose.rotation.row(2) = forward;
  pose.translation = -(pose.rotation * centre);
  return pose;
}

// One RealEstate10K frame line.
std::string realestate_line(long long time_us, double fx, double fy, const CameraPose& pose) {
  std::ostringstream line;
  line.precision(17);
  line << time_us << ' ' << fx << ' ' << fy << " 0.5 0.5 0 0";
  for (int row = 0; row < 3; ++row) {
    for (int col = 0; col < 3; ++col) line << ' ' << pose.rotation(row, col);
    line << ' ' << pose.translation[row];
  }
  return line.str();
}

fs::path write_file(const fs::path& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
  return path;
}

// Three cameras 0.1 s apart walking along +x in the y-up world, turning 0.4 rad about +y between
// the first and second, with fx/W 0.5 then 0.6.
std::string walk_file() {
  return "https://www.youtube.com/watch?v=none\n" + realestate_line(1000000, 0.5, 0.8888888888888888, upright_camera(Vector3d(0, 0, 0), 0)) +
         "\n" + realestate_line(1100000, 0.6, 1.0666666666666667, upright_camera(Vector3d(2, 0, 0), 0.4)) + "\n" +
         realestate_line(1200000, 0.6, 1.0666666666666667, upright_camera(Vector3d(4, 0, 0), 0.4)) + "\n";
}

TEST(RealEstateReaderTest, ReadsTimesIntrinsicsAndWorldToCameraPosesAsWritten) {
  const fs::path file = write_file(test_support::scratch_dir("camera_import") / "walk.txt", walk_file());
  const io::CameraTrack track = io::read_realestate10k(file.string());
  EXPECT_EQ(track.format, "realestate10k");
  ASSERT_EQ(track.frames.size(), 3u);
  EXPECT_NEAR(track.frames[0].time_s, 1.0, 1e-15);
  EXPECT_NEAR(track.frames[2].time_s, 1.2, 1e-15);
  EXPECT_NEAR(track.frames[1].fx, 0.6, 1e-15);
  EXPECT_NEAR(track.frames[1].cy, 0.5, 1e-15);
  EXPECT_LT((track.frames[1].pose.centre() - Vector3d(2, 0, 0)).norm(), 1e-12);
  EXPECT_LT((track.frames[1].pose.forward() - Vector3d(std::cos(0.4), 0, -std::sin(0.4))).norm(), 1e-12);
  EXPECT_LT((track.frames[0].pose.down() - Vector3d(0, -1, 0)).norm(), 1e-12);
  EXPECT_TRUE(track.notes.empty());
}

// Placed with extent 8 about (1, 2), mean height 1.5 and the first camera towards +y (90 deg):
// the resampled centres (x = 0, 1, 2, 3, 4 at 20 fps from 10 fps) have mean 2 and reach 2, so the
// scale is 4 / 2 = 2; up (+y) becomes +z, and the walk, which went from the mean's -x side to its
// +x side, now runs from (1, 6) to (1, -2): along -y. The first camera looked along the walk.
TEST(ImportedCameraTest, LevelsRescalesCentresAndTurnsTheTrackAsTheHeaderSays) {
  const fs::path file = write_file(test_support::scratch_dir("camera_import") / "walk.txt", walk_file());
  const io::CameraTrack track = io::read_realestate10k(file.string());
  scene::ImportedCameraOptions options;
  options.extent_m = 8;
  options.centre = Eigen::Vector2d(1, 2);
  options.height_m = 1.5;
  options.start_angle_deg = 90;
  std::vector<std::string> notes;
  const CameraPath path = scene::imported_camera_path(track, 5, 20, options, &notes);
  ASSERT_EQ(path.frame_count(), 5);
  EXPECT_EQ(path.kind, "realestate10k");
  const double ys[5] = {6, 4, 2, 0, -2};
  for (int f = 0; f < 5; ++f) {
    EXPECT_LT((path.poses[f].centre() - Vector3d(1, ys[f], 1.5)).norm(), 1e-9) << "frame " << f;
    // Upright: the image's down is world -z on every frame.
    EXPECT_LT((path.poses[f].down() - Vector3d(0, 0, -1)).norm(), 1e-9) << "frame " << f;
  }
  EXPECT_LT((path.poses[0].forward() - Vector3d(0, -1, 0)).norm(), 1e-9);
  EXPECT_LT((path.poses[0].right() - Vector3d(-1, 0, 0)).norm(), 1e-9);
  // The 0.4 rad turn about the reconstruction's up is a 0.4 rad turn about +z; frame 1 lies halfway
  // between the first two cameras (slerp at 1/2: 0.2 rad), frames 2 to 4 at the full turn.
  const Vector3d walk(0, -1, 0);
  EXPECT_LT((path.poses[1].forward() - Eigen::AngleAxisd(0.2, Vector3d::UnitZ()) * walk).norm(), 1e-9);
  for (int f = 2; f < 5; ++f) {
    EXPECT_LT((path.poses[f].forward() - Eigen::AngleAxisd(0.4, Vector3d::UnitZ()) * walk).norm(), 1e-9) << "frame " << f;
  }
  // Intrinsics: normalised values times 960 x 540, interpolated halfway at frame 1.
  EXPECT_NEAR(path.intrinsics[0].fx, 480, 1e-9);
  EXPECT_NEAR(path.intrinsics[1].fx, 0.55 * 960, 1e-9);
  EXPECT_NEAR(path.intrinsics[4].fx, 576, 1e-9);
  EXPECT_NEAR(path.intrinsics[0].fy, 480, 1e-9);
  EXPECT_NEAR(path.intrinsics[0].cx, 480, 1e-12);
  EXPECT_NEAR(path.intrinsics[0].cy, 270, 1e-12);
  EXPECT_TRUE(notes.empty()) << notes.front();
}

TEST(ImportedCameraTest, FramesPastTheTrackHoldItsLastCameraAndSaySo) {
  const fs::path file = write_file(test_support::scratch_dir("camera_import") / "walk.txt", walk_file());
  const io::CameraTrack track = io::read_realestate10k(file.string());
  std::vector<std::string> notes;
  const CameraPath path = scene::imported_camera_path(track, 10, 20, scene::ImportedCameraOptions{}, &notes);
  for (int f = 5; f < 10; ++f) EXPECT_LT((path.poses[f].extrinsics() - path.poses[4].extrinsics()).norm(), 1e-12);
  ASSERT_EQ(notes.size(), 1u);
  EXPECT_TRUE(contains(notes[0], "held for the last 5 of 10 frames")) << notes[0];
}

// Speed 2 plays the track twice as fast: 20 fps output frames land on the 10 fps cameras.
TEST(ImportedCameraTest, SpeedScalesTrackTime) {
  const fs::path file = write_file(test_support::scratch_dir("camera_import") / "walk.txt", walk_file());
  const io::CameraTrack track = io::read_realestate10k(file.string());
  scene::ImportedCameraOptions options;
  options.speed = 2;
  const CameraPath path = scene::imported_camera_path(track, 3, 20, options);
  EXPECT_NEAR(path.intrinsics[1].fx, 0.6 * 960, 1e-9);
  const double forward_turn = std::acos(std::clamp(path.poses[0].forward().dot(path.poses[1].forward()), -1.0, 1.0));
  EXPECT_NEAR(forward_turn, 0.4, 1e-9);
}

// Re-aimed at a fixed point with no smoothing, every camera looks exactly at it and stays upright.
TEST(ImportedCameraTest, AimLooksAtTheSmoothedPointKeepingTheRecordedUp) {
  const fs::path file = write_file(test_support::scratch_dir("camera_import") / "walk.txt", walk_file());
  const io::CameraTrack track = io::read_realestate10k(file.string());
  scene::ImportedCameraOptions options;
  options.centre = Eigen::Vector2d(0, 0);
  options.start_angle_deg = 0;
  const Vector3d point(0.5, 0.2, 1.0);
  options.look_at.assign(5, point);
  options.aim_smoothing_s = 0;
  const CameraPath path = scene::imported_camera_path(track, 5, 20, options);
  for (int f = 0; f < 5; ++f) {
    const CameraPose& pose = path.poses[f];
    EXPECT_LT((pose.forward() - (point - pose.centre()).normalized()).norm(), 1e-12);
    EXPECT_NEAR(pose.right().z(), 0, 1e-12);  // no roll: the recorded up was vertical
    EXPECT_LT(pose.down().z(), 0);
  }
  // Smoothing a look-at point that moves in a straight line leaves the interior frames on it.
  std::vector<Vector3d> line;
  for (int f = 0; f < 5; ++f) line.push_back(Vector3d(0.1 * f, 0.5, 1.0));
  options.look_at = line;
  options.aim_smoothing_s = 0.05;  // one frame at 20 fps: a 3-frame window each side, cut at the ends
  const CameraPath smoothed = scene::imported_camera_path(track, 5, 20, options);
  // The middle frame's window is symmetric, so it sees the line's own point.
  EXPECT_LT((smoothed.poses[2].forward() - (line[2] - smoothed.poses[2].centre()).normalized()).norm(), 1e-12);
}

// Cameras upright about an up of (1, 2, 2) / 3 with different headings, and pairs rolled +-0.3 rad
// about their view axis or pitched +-0.2 rad about their right axis: in each pair the image-up
// axes are up cos(a) +- a sideways part that cancels, so the mean is that up, to rounding.
TEST(ImportedCameraTest, UpIsTheMeanOfTheCamerasImageUpAxes) {
  const Vector3d up = Vector3d(1, 2, 2) / 3;
  const Matrix3d frame = Eigen::Quaterniond::FromTwoVectors(Vector3d::UnitY(), up).toRotationMatrix();
  io::CameraTrack track;
  track.path = "synthetic";
  // A camera's camera-to-world rotation: upright along `heading`, then turned in its own axes.
  const auto add = [&](double heading, const Matrix3d& turn) {
    io::CameraTrackFrame f;
    f.pose.rotation = (frame * upright_camera(Vector3d::Zero(), heading).rotation.transpose() * turn).transpose();
    track.frames.push_back(f);
  };
  for (int k = 0; k < 5; ++k) add(1.1 * k, Matrix3d::Identity());
  EXPECT_LT((scene::estimate_up(track) - up).norm(), 1e-12);
  for (const double sign : {1.0, -1.0}) add(0.7, Eigen::AngleAxisd(sign * 0.3, Vector3d::UnitZ()).toRotationMatrix());
  for (const double sign : {1.0, -1.0}) add(2.0, Eigen::AngleAxisd(sign * 0.2, Vector3d::UnitX()).toRotationMatrix());
  EXPECT_LT((scene::estimate_up(track) - up).norm(), 1e-12);
  // Unpaired, a pitch leans the estimate: 3 cameras pitched 0.2 rad the same way lean it by 0.2 rad.
  track.frames.clear();
  for (int k = 0; k < 3; ++k) add(0.5, Eigen::AngleAxisd(0.2, Vector3d::UnitX()).toRotationMatrix());
  EXPECT_NEAR(std::acos(std::clamp(scene::estimate_up(track).dot(up), -1.0, 1.0)), 0.2, 1e-12);
  // A given up wins over the estimate: telling the walk its up is +x turns the level walk on end,
  // so its cameras now move vertically and not at all horizontally.
  const fs::path file = write_file(test_support::scratch_dir("camera_import") / "walk.txt", walk_file());
  scene::ImportedCameraOptions options;
  options.up = Vector3d::UnitX();
  const std::string message =
      test_support::message_of<io::InputError>([&] { scene::imported_camera_path(io::read_realestate10k(file.string()), 5, 20, options); });
  EXPECT_TRUE(contains(message, "do not move horizontally")) << message;
}

TEST(ImportedCameraTest, ATrackWhoseUpAxesCancelIsAnErrorNamingTheFile) {
  io::CameraTrack track;
  track.path = "upside.txt";
  for (int k = 0; k < 2; ++k) {
    io::CameraTrackFrame f;
    f.time_s = k;
    f.pose = upright_camera(Vector3d(k, 0, 0), 0);
    if (k == 1) f.pose.rotation = Eigen::AngleAxisd(kPi, Vector3d::UnitZ()).toRotationMatrix() * f.pose.rotation;
    track.frames.push_back(f);
  }
  const std::string message = test_support::message_of<io::InputError>([&] { scene::estimate_up(track); });
  EXPECT_TRUE(contains(message, "upside.txt: cannot estimate up")) << message;
}

// The shared RealEstate10K sample: 16 frames, strictly increasing times, the clip's intrinsics;
// the cameras are roughly upright about the estimated up (a hand-held walk-through).
TEST(RealEstateReaderTest, TheRealSampleParses) {
  const io::CameraTrack track = io::read_realestate10k(kRealEstate);
  ASSERT_EQ(track.frames.size(), 16u);
  EXPECT_NEAR(track.frames[0].time_s, 158.692025, 1e-9);
  EXPECT_NEAR(track.frames[0].fx, 0.474812461, 1e-15);
  EXPECT_NEAR(track.frames[0].fy, 0.844111024, 1e-15);
  for (std::size_t k = 1; k < track.frames.size(); ++k) EXPECT_GT(track.frames[k].time_s, track.frames[k - 1].time_s);
  // The first frame's matrix as written, row-major: centre -R^T t.
  Matrix3d r;
  r << 0.780003667, 0.059620168, -0.622928321, -0.062449891, 0.997897983, 0.017311305, 0.622651041, 0.025398925, 0.782087326;
  const Vector3d t(0.726968666, 0.217967188, -1.002211444);
  EXPECT_LT((track.frames[0].pose.centre() - (-(r.transpose() * t))).norm(), 1e-7);
  const Vector3d up = scene::estimate_up(track);
  for (const io::CameraTrackFrame& frame : track.frames) EXPECT_GT(-frame.pose.down().dot(up), std::cos(20 * kPi / 180));
  // Its 16:9 intrinsics on a 960 x 540 image give square pixels (no note), fx = 0.4748 * 960.
  std::vector<std::string> notes;
  const CameraPath path = scene::imported_camera_path(track, 60, 30, scene::ImportedCameraOptions{}, &notes);
  EXPECT_NEAR(path.intrinsics[0].fx, 0.474812461 * 960, 1e-9);
  EXPECT_TRUE(notes.empty());
  double reach = 0;
  for (const CameraPose& pose : path.poses) reach = std::max(reach, pose.centre().head<2>().norm());
  EXPECT_NEAR(reach, 4, 1e-9);  // extent 8 about (0, 0)
}

// COLMAP's quaternion is Hamilton's, world to camera: R written out from (w, x, y, z).
Matrix3d hamilton(double w, double x, double y, double z) {
  const double n = std::sqrt(w * w + x * x + y * y + z * z);
  w /= n, x /= n, y /= n, z /= n;
  Matrix3d r;
  r << 1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w),  //
      2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w),   //
      2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y);
  return r;
}

// The shared COLMAP sample: image ids 100, 200, 300 named bbb, ccc, aaa, so the frames come in the
// order 300, 100, 200; each image has its own SIMPLE_RADIAL camera.
TEST(ColmapReaderTest, TheRealSampleParsesOrderedByName) {
  const io::CameraTrack track = io::read_colmap_text(kColmap, 10);
  EXPECT_EQ(track.format, "colmap");
  ASSERT_EQ(track.frames.size(), 3u);
  EXPECT_NEAR(track.frames[1].time_s, 0.1, 1e-15);
  const io::CameraTrackFrame& aaa = track.frames[0];
  EXPECT_LT((aaa.pose.translation - Vector3d(-3.3755, 0.0632141, 0.843675)).norm(), 1e-12);
  EXPECT_LT((aaa.pose.rotation - hamilton(0.995907, 0.0126643, 0.089425, -0.00358479)).norm(), 1e-12);
  EXPECT_NEAR(aaa.fx, 600.0 / 1024, 1e-15);
  EXPECT_NEAR(aaa.fy, 600.0 / 768, 1e-15);
  EXPECT_NEAR(aaa.cx, 0.5, 1e-15);
  EXPECT_LT((track.frames[1].pose.translation - Vector3d(-4.7554, 0.0407867, 3.9211)).norm(), 1e-12);
  EXPECT_NEAR(track.frames[1].fx, 2332.47 / 4056, 1e-15);
  EXPECT_NEAR(track.frames[2].fy, 500.0 / 600, 1e-15);
  ASSERT_EQ(track.notes.size(), 1u);
  EXPECT_TRUE(contains(track.notes[0], "lens distortion of camera(s) 1, 2, 3 not applied")) << track.notes[0];
  // A file of the model names its folder just the same.
  EXPECT_EQ(io::read_colmap_text(kColmap + "/images.txt", 10).frames.size(), 3u);
}

fs::path colmap_model(const fs::path& base, const std::string& name, const std::string& cameras, const std::string& images) {
  const fs::path dir = base / name;
  fs::create_directories(dir);
  write_file(dir / "cameras.txt", cameras);
  write_file(dir / "images.txt", images);
  return dir;
}

// Hand-made: the four models' focal lengths and principal points; names frame9, frame10, frame1
// in natural order; an image with an empty points line and the last one without any.
TEST(ColmapReaderTest, ModelsNaturalOrderAndEmptyPointsLines) {
  const fs::path dir = colmap_model(test_support::scratch_dir("camera_import"), "models",
                                    "# comment\n1 SIMPLE_PINHOLE 100 50 80 50 25\n2 PINHOLE 200 100 150 160 100 50\n"
                                    "3 SIMPLE_RADIAL 100 100 90 50 50 0\n4 OPENCV 400 300 300 310 200 150 0.1 0 0 0\n",
                                    "# images\n7 1 0 0 0 1 2 3 1 frame10.png\n\n"
                                    "5 0 1 0 0 0 0 0 2 frame9.png\n1.0 2.0 -1\n"
                                    "6 1 0 0 0 0 0 0 3 frame1.png\n\n"
                                    "8 1 0 0 0 0 0 0 4 frame11.png");
  const io::CameraTrack track = io::read_colmap_text(dir.string(), 25);
  ASSERT_EQ(track.frames.size(), 4u);
  // frame1 (camera 3), frame9 (camera 2), frame10 (camera 1), frame11 (camera 4).
  EXPECT_NEAR(track.frames[0].fx, 0.9, 1e-15);
  EXPECT_NEAR(track.frames[1].fx, 150.0 / 200, 1e-15);
  EXPECT_NEAR(track.frames[1].fy, 160.0 / 100, 1e-15);
  EXPECT_NEAR(track.frames[1].cx, 0.5, 1e-15);
  EXPECT_NEAR(track.frames[2].fx, 0.8, 1e-15);
  EXPECT_NEAR(track.frames[2].fy, 80.0 / 50, 1e-15);
  EXPECT_NEAR(track.frames[3].fy, 310.0 / 300, 1e-15);
  EXPECT_NEAR(track.frames[3].cy, 0.5, 1e-15);
  EXPECT_NEAR(track.frames[3].time_s, 3 / 25.0, 1e-15);
  // frame9: q = (0, 1, 0, 0), a half turn about x; centre -R^T t = 0.
  EXPECT_LT((track.frames[1].pose.rotation - Vector3d(1, -1, -1).asDiagonal().toDenseMatrix()).norm(), 1e-15);
  EXPECT_LT((track.frames[2].pose.centre() - Vector3d(-1, -2, -3)).norm(), 1e-15);
  // Only camera 4 has a non-zero distortion.
  ASSERT_EQ(track.notes.size(), 1u);
  EXPECT_TRUE(contains(track.notes[0], "camera(s) 4 not")) << track.notes[0];
}

// Every bad input: one line naming the file, the line and the problem.
TEST(CameraImportErrorsTest, BadFilesAreNamedWithTheirLineAndProblem) {
  const fs::path dir = test_support::scratch_dir("camera_import");
  const std::string url = "https://example.com/v\n";
  const std::string good = realestate_line(0, 0.5, 0.9, upright_camera(Vector3d::Zero(), 0));
  const auto realestate_error = [&](const std::string& name, const std::string& text) {
    const fs::path file = write_file(dir / name, text);
    return test_support::message_of<io::InputError>([&] { io::read_realestate10k(file.string()); });
  };
  struct Case {
    std::string name, text, expected;
  };
  CameraPose sheared = upright_camera(Vector3d::Zero(), 0);
  sheared.rotation(0, 1) = 0.2;
  CameraPose mirrored = upright_camera(Vector3d::Zero(), 0);
  mirrored.rotation.row(0) *= -1;
  const std::vector<Case> cases = {
      {"sheared.txt", url + good + "\n" + realestate_line(10, 0.5, 0.9, sheared) + "\n", "line 3: the 3x3 part of the world-to-camera matrix is not a rotation"},
      {"mirrored.txt", url + realestate_line(10, 0.5, 0.9, mirrored) + "\n", "line 2: the 3x3 part"},
      {"unsorted.txt", url + realestate_line(500, 0.5, 0.9, upright_camera(Vector3d::Zero(), 0)) + "\n" + good + "\n",
       "line 3: timestamp 0 comes before line 2's"},
      {"repeated.txt", url + good + "\n\n" + good + "\n", "line 4: timestamp 0 repeats line 2's"},
      {"zero_focal.txt", url + realestate_line(0, 0, 0.9, upright_camera(Vector3d::Zero(), 0)) + "\n", "line 2: focal length 0 is not positive"},
      {"tiny_focal.txt", url + realestate_line(0, 1e-300, 0.9, upright_camera(Vector3d::Zero(), 0)) + "\n",
       "line 2: normalised intrinsics: fx = 1e-300 gives a field of view of 180 degrees, outside 0.01 to 179"},
      {"huge_focal.txt", url + realestate_line(0, 0.5, 1e9, upright_camera(Vector3d::Zero(), 0)) + "\n",
       "line 2: normalised intrinsics: fy = 1e+09 gives a field of view of"},
      {"far_centre.txt", url + "0 0.5 0.9 7.5 0.5 0 0 1 0 0 0 0 1 0 0 0 0 1 0\n",
       "line 2: normalised intrinsics: cx = 7.5 lies more than one image size (1) outside the image"},
      {"truncated.txt", url + good.substr(0, good.rfind(' ')) + "\n", "line 2: a frame line has 19 numbers"},
      {"word.txt", url + "12 0.5 0.5 0.5 0.5 0 0 1 0 0 0 0 1 0 0 0 0 nan 0\n", "line 2: value 'nan' is not a finite number"},
      {"no_url.txt", good + "\n", "line 1: expected the video's URL"},
      {"empty.txt", "", "empty file"},
      {"url_only.txt", url, "no frames"},
  };
  for (const Case& c : cases) {
    const std::string message = realestate_error(c.name, c.text);
    EXPECT_TRUE(contains(message, (dir / c.name).string() + ": ")) << message;
    EXPECT_TRUE(contains(message, c.expected)) << c.name << ": " << message;
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
  }

  const std::string camera = "1 PINHOLE 100 100 50 50 50 50\n";
  const std::string image = "1 1 0 0 0 0 0 0 1 a.png\n\n";
  struct ColmapCase {
    std::string name, cameras, images, file, expected;
  };
  const std::vector<ColmapCase> colmap_cases = {
      {"unknown_model", "1 FISHEYE 100 100 50 50 50 0\n", image, "cameras.txt", "line 1: unknown camera model 'FISHEYE'"},
      {"short_camera", "# c\n1 OPENCV 100 100 50 50 50 50 0\n", image, "cameras.txt", "line 2: a OPENCV camera line has 12 fields"},
      {"zero_focal", "1 SIMPLE_PINHOLE 100 100 0 50 50\n", image, "cameras.txt", "line 1: focal length 0 is not positive"},
      {"zero_size", "1 SIMPLE_PINHOLE 0 100 10 50 50\n", image, "cameras.txt", "line 1: the image size 0x100"},
      {"tiny_focal", "1 SIMPLE_PINHOLE 100 100 1e-300 50 50\n", image, "cameras.txt",
       "line 1: camera 1: fx = 1e-300 gives a field of view of 180 degrees"},
      {"far_centre", "1 PINHOLE 100 100 50 50 50 -400\n", image, "cameras.txt",
       "line 1: camera 1: cy = -400 lies more than one image size (100) outside the image"},
      {"twice_camera", camera + camera, image, "cameras.txt", "line 2: camera id 1 appears twice"},
      {"no_cameras", "# none\n", image, "cameras.txt", "no cameras"},
      {"short_image", camera, "1 1 0 0 0 0 0 1 a.png\n\n", "images.txt", "line 1: an image line has 10 fields"},
      {"bad_quaternion", camera, "1 0.5 0 0 0 0 0 0 1 a.png\n\n", "images.txt", "line 1: the quaternion QW QX QY QZ has norm 0.5"},
      {"unknown_camera", camera, "1 1 0 0 0 0 0 0 9 a.png\n\n", "images.txt", "line 1: camera id 9 is not in cameras.txt"},
      {"twice_image", camera, image + image, "images.txt", "line 3: image id 1 appears twice"},
      {"twice_name", camera, image + "2 1 0 0 0 1 0 0 1 a.png\n\n", "images.txt", "line 3: image name 'a.png' is also on line 1"},
      {"no_images", camera, "# none\n", "images.txt", "no images"},
  };
  for (const ColmapCase& c : colmap_cases) {
    const fs::path model = colmap_model(dir, c.name, c.cameras, c.images);
    const std::string message = test_support::message_of<io::InputError>([&] { io::read_colmap_text(model.string(), 30); });
    EXPECT_TRUE(contains(message, (model / c.file).string() + ": ")) << message;
    EXPECT_TRUE(contains(message, c.expected)) << c.name << ": " << message;
  }
  const std::string missing = test_support::message_of<io::InputError>([&] { io::read_colmap_text((dir / "nowhere").string(), 30); });
  EXPECT_TRUE(contains(missing, "cameras.txt: no such file")) << missing;
}

// Six cameras on a circle of radius 3 about (5, 1, -2) of a y-up world, each looking at that point
// (turntable capture): anchored on the focus, the point goes to the centre, so with extent 8 every
// camera sits 4 m from (1, 2) and looks straight at it.
TEST(ImportedCameraTest, FocusAnchorPutsThePointTheCamerasLookAtOnTheCentre) {
  const Vector3d subject(5, 1, -2);
  std::string text = "https://example.com/turntable\n";
  for (int k = 0; k < 6; ++k) {
    const double angle = 0.5 * k;  // 2.5 rad of a turn, so the centroid is off the subject
    const Vector3d centre = subject + 3 * Vector3d(std::cos(angle), 0, -std::sin(angle));
    // Heading about +y from +x to the subject: the view is -(cos a, 0, -sin a) = Ry(a + pi) e_x.
    text += realestate_line(100000LL * k, 0.5, 0.9, upright_camera(centre, angle + kPi)) + "\n";
  }
  const fs::path file = write_file(test_support::scratch_dir("camera_import") / "turntable.txt", text);
  const io::CameraTrack track = io::read_realestate10k(file.string());
  scene::ImportedCameraOptions options;
  options.anchor = scene::ImportedCameraOptions::Anchor::focus;
  options.centre = Eigen::Vector2d(1, 2);
  options.height_m = 1.2;
  const CameraPath path = scene::imported_camera_path(track, 6, 10, options);
  for (int f = 0; f < 6; ++f) {
    const Vector3d c = path.poses[f].centre();
    EXPECT_NEAR((c.head<2>() - options.centre).norm(), 4, 1e-9) << "frame " << f;
    EXPECT_NEAR(c.z(), 1.2, 1e-9);
    EXPECT_LT((path.poses[f].forward() - (Vector3d(1, 2, 1.2) - c).normalized()).norm(), 1e-9) << "frame " << f;
  }
  // Anchored on the centroid instead, the cameras are not all 4 m away.
  options.anchor = scene::ImportedCameraOptions::Anchor::centroid;
  const CameraPath centroid = scene::imported_camera_path(track, 6, 10, options);
  EXPECT_GT(std::abs((centroid.poses[0].centre().head<2>() - options.centre).norm() -
                     (centroid.poses[2].centre().head<2>() - options.centre).norm()), 0.5);
  // Parallel view axes (a straight walk looking ahead) have no focus.
  std::string walk = "u\n";
  for (int k = 0; k < 4; ++k) walk += realestate_line(100000LL * k, 0.5, 0.9, upright_camera(Vector3d(k, 0, 0), 0)) + "\n";
  const fs::path straight = write_file(test_support::scratch_dir("camera_import") / "straight.txt", walk);
  options.anchor = scene::ImportedCameraOptions::Anchor::focus;
  const std::string message = test_support::message_of<io::InputError>(
      [&] { scene::imported_camera_path(io::read_realestate10k(straight.string()), 4, 10, options); });
  EXPECT_TRUE(contains(message, "straight.txt: the cameras' view axes do not converge")) << message;
}

// A track that stands still horizontally has nothing to rescale.
TEST(ImportedCameraTest, AStillTrackIsAnErrorNamingTheFile) {
  const std::string text = "u\n" + realestate_line(0, 0.5, 0.9, upright_camera(Vector3d(1, 0, 1), 0)) + "\n" +
                           realestate_line(100000, 0.5, 0.9, upright_camera(Vector3d(1, 3, 1), 0.5)) + "\n";
  const fs::path file = write_file(test_support::scratch_dir("camera_import") / "still.txt", text);
  const std::string message = test_support::message_of<io::InputError>(
      [&] { scene::imported_camera_path(io::read_realestate10k(file.string()), 4, 30, scene::ImportedCameraOptions{}); });
  EXPECT_TRUE(contains(message, "still.txt: the cameras do not move horizontally")) << message;
}

}  // namespace
}  // namespace odyssey
