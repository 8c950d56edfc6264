// BVH loading: the CMU assets, joint world positions against hand-computed values (sin/cos
// arithmetic written out here, independent of the library's rotation helpers), an independent
// 4x4-matrix reader for the CMU walk, and every kind of bad input.
#include <gtest/gtest.h>

#include <array>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <numbers>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "mocap_io/bvh.h"
#include "mocap_io/input_error.h"
#include "test_support.h"

namespace odyssey::io {
namespace {

namespace fs = std::filesystem;
using Eigen::Vector3d;

const std::string kWalk = std::string(ODYSSEY_SHARED_DIR) + "/assets/mocap/cmu_walk_cgspeed.bvh";
const std::string kJump = std::string(ODYSSEY_SHARED_DIR) + "/assets/mocap/cmu_jump_cgspeed.bvh";

std::string write_scratch(const std::string& name, const std::string& text) {
  const fs::path dir = odyssey::test_support::scratch_root() / "bvh";
  fs::create_directories(dir);
  const fs::path path = dir / name;
  std::ofstream(path, std::ios::binary) << text;
  return path.string();
}

// --- Independent arithmetic: 3x3 matrices as plain arrays, rotations from sin and cos. ---
using Mat3 = std::array<std::array<double, 3>, 3>;
using Vec3 = std::array<double, 3>;

Mat3 rotation(char axis, double degrees) {
  const double a = degrees * std::numbers::pi / 180, c = std::cos(a), s = std::sin(a);
  if (axis == 'X') return {{{1, 0, 0}, {0, c, -s}, {0, s, c}}};
  if (axis == 'Y') return {{{c, 0, s}, {0, 1, 0}, {-s, 0, c}}};
  return {{{c, -s, 0}, {s, c, 0}, {0, 0, 1}}};
}

Mat3 operator*(const Mat3& a, const Mat3& b) {
  Mat3 m{};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < 3; ++k) m[i][j] += a[i][k] * b[k][j];
  return m;
}

Vec3 operator*(const Mat3& a, const Vec3& v) {
  return {a[0][0] * v[0] + a[0][1] * v[1] + a[0][2] * v[2], a[1][0] * v[0] + a[1][1] * v[1] + a[1][2] * v[2],
          a[2][0] * v[0] + a[2][1] * v[1] + a[2][2] * v[2]};
}

Vec3 operator+(const Vec3& a, const Vec3& b) { return {a[0] + b[0], a[1] + b[1], a[2] + b[2]}; }

// R = R_o0(a0) R_o1(a1) R_o2(a2) for an order like "ZXY".
Mat3 euler(const char* order, double a0, double a1, double a2) {
  return rotation(order[0], a0) * rotation(order[1], a1) * rotation(order[2], a2);
}

// Y-up BVH units to the toolkit's Z-up metres: (x, y, z) -> s (x, -z, y).
Vector3d z_up(const Vec3& v, double metres_per_unit = 0.01) { return metres_per_unit * Vector3d(v[0], -v[2], v[1]); }

std::vector<Vector3d> world_positions(const Clip& clip, int frame) {
  std::vector<RigidTransform<double>> world(clip.joint_count());
  clip.world_pose(frame, world);
  std::vector<Vector3d> positions;
  for (const auto& transform : world) positions.push_back(transform.translation);
  return positions;
}

void expect_near(const Vector3d& actual, const Vector3d& expected, double tolerance, const std::string& what) {
  EXPECT_LT((actual - expected).norm(), tolerance)
      << what << ": got " << actual.transpose() << ", expected " << expected.transpose();
}

TEST(BvhTest, LoadsCmuWalkAndJump) {
  const Clip walk = load_bvh(kWalk, {kCmuMetresPerUnit});
  EXPECT_EQ(walk.joint_count(), 31);
  EXPECT_EQ(walk.frame_count(), 344);
  EXPECT_NEAR(walk.fps, 120.0, 1e-6);
  EXPECT_EQ(walk.skeleton.name(0), "Hips");
  EXPECT_EQ(walk.translated_joints, std::vector<int>{0});
  EXPECT_NO_THROW(walk.validate());

  const auto start = std::chrono::steady_clock::now();
  const Clip jump = load_bvh(kJump, {kCmuMetresPerUnit});
  const double milliseconds =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  EXPECT_EQ(jump.joint_count(), 31);
  EXPECT_EQ(jump.frame_count(), 2752);
  EXPECT_NEAR(jump.fps, 120.0, 1e-6);
  std::printf("loaded %s (2752 frames, 31 joints) in %.1f ms\n", kJump.c_str(), milliseconds);
}

TEST(BvhTest, CmuSubjectStandsAboutOnePointSevenMetresTallInZUp) {
  // A check that units and axes are right: at rest the head's end lies about 1.5-1.8 m above
  // the toes along +z, and nothing sticks out along x or y by more than the arm span.
  const Clip walk = load_bvh(kWalk, {kCmuMetresPerUnit});
  const auto rest = walk.skeleton.rest_world();
  const double head = rest[walk.skeleton.find("Head")].translation.z();
  const double toe = rest[walk.skeleton.find("LeftToeBase")].translation.z();
  EXPECT_GT(head - toe, 1.3);
  EXPECT_LT(head - toe, 1.8);
}

// Root ZXY with six channels, chest and head ZXY; an End Site that must not become a joint.
const char* const kZxyChain = R"(HIERARCHY
ROOT Hips
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
  JOINT Chest
  {
    OFFSET 0 10 0
    CHANNELS 3 Zrotation Xrotation Yrotation
    JOINT Head
    {
      OFFSET 0 5 0
      CHANNELS 3 Zrotation Xrotation Yrotation
      End Site
      {
        OFFSET 0 3 0
      }
    }
  }
}
MOTION
Frames: 3
Frame Time: .0083333
1 2 3 0 0 0 0 0 0 0 0 0
10 20 30 90 90 0 0 0 0 0 0 0
-4 50 7 30 -45 60 10 20 -35 -70 15 25
)";

TEST(BvhTest, ZxyChainMatchesHandComputedPositions) {
  const Clip clip = load_bvh(write_scratch("zxy.bvh", kZxyChain), {});
  ASSERT_EQ(clip.joint_count(), 3);  // the End Site is not a joint
  EXPECT_EQ(clip.skeleton.names(), (std::vector<std::string>{"Hips", "Chest", "Head"}));
  EXPECT_EQ(clip.skeleton.parents(), (std::vector<int>{-1, 0, 1}));
  EXPECT_EQ(clip.translated_joints, std::vector<int>{0});
  EXPECT_NEAR(clip.fps, 120.0, 1e-6);

  // Frame 0, no rotation: Y-up cm (1,2,3), (1,12,3), (1,17,3) -> Z-up m (x, -z, y) / 100.
  auto p = world_positions(clip, 0);
  expect_near(p[0], Vector3d(0.01, -0.03, 0.02), 1e-15, "frame 0 hips");
  expect_near(p[1], Vector3d(0.01, -0.03, 0.12), 1e-15, "frame 0 chest");
  expect_near(p[2], Vector3d(0.01, -0.03, 0.17), 1e-15, "frame 0 head");

  // Frame 1: R = Rz(90) Rx(90). Rx(90) takes the chest offset (0,10,0) to (0,0,10), Rz(90)
  // leaves it: chest at (10,20,30) + (0,0,10) = (10,20,40) cm; the head offset (0,5,0) likewise
  // goes to (0,0,5): (10,20,45) cm. Z-up metres: (0.1,-0.4,0.2) and (0.1,-0.45,0.2). (Read as
  // Rx(90) Rz(90), the offset would go to (10,0,0) instead.)
  p = world_positions(clip, 1);
  expect_near(p[0], Vector3d(0.1, -0.3, 0.2), 1e-15, "frame 1 hips");
  expect_near(p[1], Vector3d(0.1, -0.4, 0.2), 1e-15, "frame 1 chest");
  expect_near(p[2], Vector3d(0.1, -0.45, 0.2), 1e-15, "frame 1 head");

  // Frame 2, general angles: chest = t + R0 (0,10,0), head = chest + R0 R1 (0,5,0).
  const Mat3 r0 = euler("ZXY", 30, -45, 60), r1 = euler("ZXY", 10, 20, -35);
  const Vec3 hips{-4, 50, 7};
  const Vec3 chest = hips + r0 * Vec3{0, 10, 0};
  const Vec3 head = chest + (r0 * r1) * Vec3{0, 5, 0};
  p = world_positions(clip, 2);
  expect_near(p[0], z_up(hips), 1e-15, "frame 2 hips");
  expect_near(p[1], z_up(chest), 1e-14, "frame 2 chest");
  expect_near(p[2], z_up(head), 1e-14, "frame 2 head");

  // The joint frames are carried into Z up too: R' = C R C^T, so the head's world rotation
  // applied to the Z-up image of a vector is the Z-up image of the rotated vector.
  std::vector<RigidTransform<double>> world(3);
  clip.world_pose(2, world);
  const Mat3 r2 = euler("ZXY", -70, 15, 25);
  const Vec3 v{0.3, -0.2, 0.9};
  const Vec3 rotated = (r0 * r1 * r2) * v;
  expect_near(world[2].rotation * z_up(v, 1.0), z_up(rotated, 1.0), 1e-14, "frame 2 head rotation");
}

// Root XYZ, middle joint YZX, a third joint in ZYX: each joint reads its own order.
const char* const kMixedOrders = R"(HIERARCHY
ROOT Root
{
	OFFSET 0 0 0
	CHANNELS 6 Xposition Yposition Zposition Xrotation Yrotation Zrotation
	JOINT Upper
	{
		OFFSET 10 0 0
		CHANNELS 3 Yrotation Zrotation Xrotation
		JOINT Lower
		{
			OFFSET 10 0 0
			CHANNELS 3 Zrotation Yrotation Xrotation
			End Site
			{
				OFFSET 4 0 0
			}
		}
	}
}
MOTION
Frames: 2
Frame Time: 0.0333333
0 0 0 90 90 0 90 90 0 0 0 0
5 -6 7 12 -48 33 -20 70 15 40 -25 60
)";

TEST(BvhTest, XyzAndYzxOrdersMatchHandComputedPositions) {
  const Clip clip = load_bvh(write_scratch("mixed_orders.bvh", kMixedOrders), {});
  ASSERT_EQ(clip.joint_count(), 3);
  EXPECT_NEAR(clip.fps, 30.0, 1e-9);

  // Frame 0. Root R0 = Rx(90) Ry(90): Ry(90) takes (10,0,0) to (0,0,-10), Rx(90) takes that to
  // (0,10,0), so Upper sits at (0,10,0). Upper R1 = Ry(90) Rz(90): Rz(90) takes (10,0,0) to
  // (0,10,0), Ry(90) keeps it; R0 then takes (0,10,0) to Rx(90) (0,10,0) = (0,0,10), so Lower
  // sits at (0,10,10) cm, Z-up (0,-0.1,0.1) m.
  auto p = world_positions(clip, 0);
  expect_near(p[0], Vector3d(0, 0, 0), 1e-15, "frame 0 root");
  expect_near(p[1], Vector3d(0, 0, 0.1), 1e-15, "frame 0 upper");
  expect_near(p[2], Vector3d(0, -0.1, 0.1), 1e-15, "frame 0 lower");

  const Mat3 r0 = euler("XYZ", 12, -48, 33), r1 = euler("YZX", -20, 70, 15);
  const Vec3 root{5, -6, 7};
  const Vec3 upper = root + r0 * Vec3{10, 0, 0};
  const Vec3 lower = upper + (r0 * r1) * Vec3{10, 0, 0};
  p = world_positions(clip, 1);
  expect_near(p[1], z_up(upper), 1e-14, "frame 1 upper");
  expect_near(p[2], z_up(lower), 1e-14, "frame 1 lower");
}

// A non-root joint with six channels, position and rotation channels interleaved; a root with
// rotations only (its offset stays its position); a joint with only a Y position channel.
const char* const kSixChannelChild = R"(HIERARCHY
ROOT Base
{
  OFFSET 1 2 3
  CHANNELS 3 Zrotation Yrotation Xrotation
  JOINT Slider
  {
    OFFSET 0 10 0
    CHANNELS 6 Zrotation Xposition Xrotation Yposition Zposition Yrotation
    JOINT Tip
    {
      OFFSET 0 4 0
      CHANNELS 0
      JOINT Lift
      {
        OFFSET 2 0 9
        CHANNELS 1 Yposition
      }
    }
  }
}
MOTION
Frames: 1
Frame Time: 0.04
0 90 0 0 5 90 6 7 0 -3
)";

TEST(BvhTest, SixChannelChildAndPartialPositionChannels) {
  const Clip clip = load_bvh(write_scratch("six_channel_child.bvh", kSixChannelChild), {});
  ASSERT_EQ(clip.joint_count(), 4);
  EXPECT_EQ(clip.translated_joints, (std::vector<int>{1, 3}));
  EXPECT_NEAR(clip.fps, 25.0, 1e-12);

  // Base: offset (1,2,3), R = Ry(90). Slider: positions (5,6,7) replace the offset (0,10,0);
  // Ry(90) takes (5,6,7) to (7,6,-5), so Slider is at (8,8,-2). Its rotations Z=0, X=90, Y=0:
  // Rx(90) takes the Tip offset (0,4,0) to (0,0,4), Ry(90) takes that to (4,0,0): Tip at
  // (12,8,-2). Lift keeps x and z of its offset and takes y = -3 from its channel: local
  // (2,-3,9); Tip has no rotation, so Ry(90) Rx(90) (2,-3,9): Rx(90) gives (2,-9,-3), Ry(90)
  // gives (-3,-9,-2); Lift at (9,-1,-4). Z-up metres (x, -z, y) / 100.
  const auto p = world_positions(clip, 0);
  expect_near(p[0], Vector3d(0.01, -0.03, 0.02), 1e-15, "base");
  expect_near(p[1], Vector3d(0.08, 0.02, 0.08), 1e-15, "slider");
  expect_near(p[2], Vector3d(0.12, 0.02, 0.08), 1e-15, "tip");
  expect_near(p[3], Vector3d(0.09, 0.04, -0.01), 1e-15, "lift");
  // The clip's own record of the slider's translation: C (5,6,7) / 100.
  expect_near(clip.translations[0], Vector3d(0.05, -0.07, 0.06), 1e-15, "slider translation");
}

TEST(BvhTest, FrameTimeReadsAsTheIntegerRateItRoundsFrom) {
  const auto rate = [](const std::string& frame_time) {
    std::string text = kZxyChain;
    text.replace(text.find(".0083333"), 8, frame_time);
    return load_bvh(write_scratch("frame_time.bvh", text), {}).fps;
  };
  EXPECT_DOUBLE_EQ(rate(".0083333"), 120.0);
  EXPECT_DOUBLE_EQ(rate("0.008333"), 120.0);
  EXPECT_DOUBLE_EQ(rate("0.0166667"), 60.0);
  EXPECT_DOUBLE_EQ(rate("8.333333e-3"), 120.0);
  EXPECT_DOUBLE_EQ(rate("0.04"), 25.0);
  // Two digits cannot single out an integer rate: 1/t stands.
  EXPECT_DOUBLE_EQ(rate("0.011"), 1 / 0.011);
  // 29.97 fps (NTSC) is not an integer rate: 1/t stands.
  EXPECT_NEAR(rate("0.0333667"), 1 / 0.0333667, 1e-12);
}

TEST(BvhTest, MetresPerUnitScalesOffsetsAndTranslations) {
  const std::string path = write_scratch("units.bvh", kZxyChain);
  const Clip metres = load_bvh(path, {1.0});
  const auto p = world_positions(metres, 0);
  expect_near(p[2], Vector3d(1, -3, 17), 1e-13, "head in metres");
  EXPECT_THROW(load_bvh(path, {0.0}), std::invalid_argument);
  EXPECT_THROW(load_bvh(path, {-1.0}), std::invalid_argument);
}

// --- An independent reader for the CMU files: tokens from a stringstream, 4x4 matrices. ---
struct ReferenceJoint {
  std::string name;
  int parent;
  Vec3 offset;
  std::vector<std::string> channels;
};

using Mat4 = std::array<std::array<double, 4>, 4>;

Mat4 mul4(const Mat4& a, const Mat4& b) {
  Mat4 m{};
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j)
      for (int k = 0; k < 4; ++k) m[i][j] += a[i][k] * b[k][j];
  return m;
}

Mat4 homogeneous(const Mat3& r, const Vec3& t) {
  return {{{r[0][0], r[0][1], r[0][2], t[0]},
           {r[1][0], r[1][1], r[1][2], t[1]},
           {r[2][0], r[2][1], r[2][2], t[2]},
           {0, 0, 0, 1}}};
}

// World positions (BVH units, Y up) of every joint in one frame.
std::vector<Vec3> reference_positions(const std::string& path, int wanted_frame) {
  std::ifstream file(path);
  std::stringstream buffer;
  buffer << file.rdbuf();
  std::istringstream in(buffer.str());
  std::vector<ReferenceJoint> joints;
  std::vector<int> stack;
  std::string token;
  bool in_end_site = false;
  while (in >> token && token != "MOTION") {
    if (token == "ROOT" || token == "JOINT") {
      ReferenceJoint joint;
      in >> joint.name;
      joint.parent = stack.empty() ? -1 : stack.back();
      joints.push_back(joint);
      stack.push_back(static_cast<int>(joints.size()) - 1);
    } else if (token == "End") {
      in_end_site = true;
    } else if (token == "OFFSET") {
      Vec3 offset;
      in >> offset[0] >> offset[1] >> offset[2];
      if (!in_end_site) joints[stack.back()].offset = offset;
    } else if (token == "CHANNELS") {
      int count;
      in >> count;
      joints[stack.back()].channels.resize(count);
      for (auto& channel : joints[stack.back()].channels) in >> channel;
    } else if (token == "}") {
      if (in_end_site) {
        in_end_site = false;
      } else {
        stack.pop_back();
      }
    }
  }
  std::string skip;
  int frames;
  in >> skip >> frames >> skip >> skip >> skip;  // Frames: N Frame Time: t
  std::size_t channel_count = 0;
  for (const auto& joint : joints) channel_count += joint.channels.size();
  std::vector<double> values(channel_count);
  for (int f = 0; f <= wanted_frame; ++f)
    for (double& value : values) in >> value;

  std::vector<Mat4> world(joints.size());
  std::vector<Vec3> positions;
  std::size_t next = 0;
  for (std::size_t j = 0; j < joints.size(); ++j) {
    Vec3 translation = joints[j].offset;
    Mat3 r = rotation('X', 0);
    for (const std::string& channel : joints[j].channels) {
      const double value = values[next++];
      const int axis = channel[0] - 'X';
      if (channel.substr(1) == "position") {
        translation[axis] = value;
      } else {
        r = r * rotation(channel[0], value);
      }
    }
    const Mat4 local = homogeneous(r, translation);
    world[j] = joints[j].parent < 0 ? local : mul4(world[joints[j].parent], local);
    positions.push_back({world[j][0][3], world[j][1][3], world[j][2][3]});
  }
  return positions;
}

TEST(BvhTest, CmuWalkMatchesIndependentMatrixChain) {
  const Clip walk = load_bvh(kWalk, {kCmuMetresPerUnit});
  for (int frame : {0, 137, 343}) {
    const std::vector<Vec3> expected = reference_positions(kWalk, frame);
    const auto actual = world_positions(walk, frame);
    ASSERT_EQ(expected.size(), actual.size());
    for (std::size_t j = 0; j < expected.size(); ++j) {
      expect_near(actual[j], z_up(expected[j], kCmuMetresPerUnit), 1e-9,
                  "frame " + std::to_string(frame) + " joint " + walk.skeleton.name(int(j)));
    }
  }
}

// --- Bad input: one InputError naming the file and the line, never anything else. ---
struct BadCase {
  const char* name;
  std::string text;
  const char* problem;  // expected in what()
};

std::string with(const std::string& from, const std::string& replace) {
  std::string text = kZxyChain;
  const std::size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  return text.replace(at, from.size(), replace);
}

TEST(BvhTest, BadInputThrowsInputErrorNamingFileAndLine) {
  const std::string last_frame = "-4 50 7 30 -45 60 10 20 -35 -70 15 25\n";
  const BadCase cases[] = {
      {"truncated_frames", with(last_frame, ""), "line 26: file ends after 2 of the 3 frames"},
      {"truncated_mid_line", with(last_frame, "-4 50 7 30 -45"), "line 26: frame 2 has 5 numbers, expected 12"},
      {"short_line", with("10 20 30 90 90 0 0 0 0 0 0 0", "10 20 30 90 90 0 0 0 0 0 0"),
       "line 25: frame 1 has 11 numbers, expected 12"},
      {"long_line", with("10 20 30 90 90 0 0 0 0 0 0 0", "10 20 30 90 90 0 0 0 0 0 0 0 1"),
       "line 25: frame 1 has more than 12 numbers"},
      {"non_numeric", with("10 20 30 90", "10 abc 30 90"), "line 25: frame 1, channel 1 (Hips Yposition): 'abc' is not a number"},
      {"comma_decimal", with("10 20 30 90", "10 2,5 30 90"), "line 25: frame 1, channel 1 (Hips Yposition): '2,5' is not a number"},
      {"nan", with("10 20 30 90", "10 nan 30 90"), "line 25: frame 1, channel 1 (Hips Yposition): value 'nan' is not finite"},
      {"inf", with("10 20 30 90", "10 -inf 30 90"), "line 25: frame 1, channel 1 (Hips Yposition): value '-inf' is not finite"},
      {"overflow", with("10 20 30 90", "10 1e999 30 90"), "line 25: frame 1, channel 1 (Hips Yposition): number '1e999' is out of range"},
      {"nan_offset", with("OFFSET 0 10 0", "OFFSET 0 NaN 0"), "line 8: value 'NaN' is not finite"},
      {"unknown_channel",
       with("CHANNELS 3 Zrotation Xrotation Yrotation\n    JOINT Head",
            "CHANNELS 3 Zrotation Wrotation Yrotation\n    JOINT Head"),
       "line 9: unknown channel 'Wrotation' in joint 'Chest'"},
      {"repeated_channel",
       with("CHANNELS 3 Zrotation Xrotation Yrotation\n    JOINT Head",
            "CHANNELS 3 Zrotation Zrotation Yrotation\n    JOINT Head"),
       "line 9: channel 'Zrotation' appears twice"},
      {"channel_count", with("CHANNELS 6", "CHANNELS 7"), "line 5: CHANNELS count '7' is not a number from 0 to 6"},
      {"missing_close_brace", with("      }\n    }\n  }\n}", "      }\n    }\n  }"),
       "line 20: 'MOTION' inside joint 'Hips' (missing '}')"},
      {"missing_open_brace", with("JOINT Chest\n  {", "JOINT Chest\n"), "line 8: expected '{' after JOINT 'Chest'"},
      {"extra_close_brace", with("}\nMOTION", "}\n}\nMOTION"), "line 21: '}' closes no joint"},
      {"missing_offset", with("OFFSET 0 5 0", ""), "line 18: joint 'Head' has no OFFSET"},
      {"too_many_frames", with("Frames: 3", "Frames: 2"), "line 26: more frame lines than the 2 declared"},
      {"zero_frames", with("Frames: 3", "Frames: 0"), "line 22: frame count '0' is not a positive integer"},
      {"bad_frames", with("Frames: 3", "Frames: three"), "line 22: frame count 'three' is not a positive integer"},
      {"zero_frame_time", with(".0083333", "0"), "line 23: frame time '0' is not positive"},
      {"negative_frame_time", with(".0083333", "-.0083333"), "line 23: frame time '-.0083333' is not positive"},
      {"duplicate_name", with("JOINT Head", "JOINT Chest"), "line 10: joint name 'Chest' is used twice"},
      {"no_motion", std::string(kZxyChain).substr(0, std::string(kZxyChain).find("MOTION")),
       "line 21: file ends before MOTION"},
      {"empty", "", "line 1: expected HIERARCHY, found an empty file"},
      {"binary", std::string("\x89PNG\r\n\x1a\n\0\0", 10), "line 1: expected HIERARCHY, found '?PNG'"},
      {"unexpected_token", with("OFFSET 0 5 0", "OFSET 0 5 0"), "line 12: unexpected 'OFSET' inside joint 'Head'"},
  };
  for (const BadCase& bad : cases) {
    const std::string path = write_scratch(std::string("bad_") + bad.name + ".bvh", bad.text);
    try {
      load_bvh(path, {});
      ADD_FAILURE() << bad.name << ": no error";
    } catch (const InputError& error) {
      EXPECT_EQ(error.file(), path) << bad.name;
      EXPECT_NE(std::string(error.what()).find(path), std::string::npos) << bad.name;
      EXPECT_NE(error.problem().find(bad.problem), std::string::npos) << bad.name << ": " << error.what();
      EXPECT_EQ(error.problem().find('\n'), std::string::npos) << bad.name << ": message is not one line";
    }
  }
  EXPECT_THROW(load_bvh(write_scratch("missing_dir", "") + ".does_not_exist", {}), InputError);
}

// Every prefix of a small file and many random corruptions of it: each either loads or throws
// InputError, and the loaded clip always validates.
TEST(BvhTest, TruncatedAndCorruptedFilesNeverCrash) {
  const std::string text = kZxyChain;
  const auto try_load = [](const std::string& path) {
    try {
      load_bvh(path, {}).validate();
    } catch (const InputError&) {
    }
  };
  for (std::size_t length = 0; length < text.size(); ++length) {
    try_load(write_scratch("prefix.bvh", text.substr(0, length)));
  }
  std::mt19937 random(7);
  const std::string alphabet = "{}0123456789.-+eE \n\tXYZrotationpsiJOINTEnd Site#\0\xff";
  for (int trial = 0; trial < 500; ++trial) {
    std::string corrupt = text;
    for (int edit = 0; edit < 3; ++edit) {
      corrupt[random() % corrupt.size()] = alphabet[random() % alphabet.size()];
    }
    try_load(write_scratch("corrupt.bvh", corrupt));
  }
}

TEST(BvhTest, DeepNestingNeitherRecursesNorFails) {
  // 20000 nested joints: an explicit stack, not recursion, keeps this safe.
  constexpr int kDepth = 20000;
  std::string text = "HIERARCHY\nROOT j0\n{\nOFFSET 0 1 0\nCHANNELS 3 Zrotation Xrotation Yrotation\n";
  for (int j = 1; j <= kDepth; ++j) text += "JOINT j" + std::to_string(j) + "\n{\nOFFSET 0 1 0\n";
  for (int j = 0; j <= kDepth; ++j) text += "}\n";
  text += "MOTION\nFrames: 1\nFrame Time: 0.01\n0 0 0\n";
  const Clip clip = load_bvh(write_scratch("deep.bvh", text), {});
  ASSERT_EQ(clip.joint_count(), kDepth + 1);
  EXPECT_NEAR(world_positions(clip, 0).back().z(), 0.01 * (kDepth + 1), 1e-9);
}

// --- Units and up axis inferred from a human's height (bvh.h, guess_bvh_frame). ---

// A stick figure: Hips with two legs (Leg, Foot) hanging `leg` below it and a spine (Spine,
// Head) rising `torso` above it, plus an arm sideways; along Y (up = 'y') or Z. Its joints span
// leg + torso along the up axis. Every joint has three rotation channels, Hips also three
// position channels: 27 numbers a frame.
std::string stick_figure(double leg, double torso, char up, const std::string& frame = "") {
  const auto along = [&](double x, double length) {
    std::ostringstream text;
    text << x << " " << (up == 'y' ? length : 0.0) << " " << (up == 'z' ? length : 0.0);
    return text.str();
  };
  std::ostringstream bvh;
  bvh << "HIERARCHY\nROOT Hips\n{\n OFFSET 0 0 0\n CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\n";
  for (const char* side : {"Left", "Right"}) {
    const double x = side[0] == 'L' ? 0.1 * torso : -0.1 * torso;
    bvh << " JOINT " << side << "Leg\n {\n  OFFSET " << along(x, -0.5 * leg) << "\n  CHANNELS 3 Zrotation Xrotation Yrotation\n"
        << "  JOINT " << side << "Foot\n  {\n   OFFSET " << along(0, -0.5 * leg) << "\n   CHANNELS 3 Zrotation Xrotation Yrotation\n"
        << "   End Site\n   {\n    OFFSET 0 0 1\n   }\n  }\n }\n";
  }
  bvh << " JOINT Spine\n {\n  OFFSET " << along(0, 0.6 * torso) << "\n  CHANNELS 3 Zrotation Xrotation Yrotation\n"
      << "  JOINT Head\n  {\n   OFFSET " << along(0, 0.4 * torso) << "\n   CHANNELS 3 Zrotation Xrotation Yrotation\n"
      << "   End Site\n   {\n    OFFSET 0 1 0\n   }\n  }\n"
      << "  JOINT LeftArm\n  {\n   OFFSET " << along(0.4 * torso, 0.3 * torso) << "\n   CHANNELS 3 Zrotation Xrotation Yrotation\n"
      << "   End Site\n   {\n    OFFSET 1 0 0\n   }\n  }\n }\n}\n";
  bvh << "MOTION\nFrames: 1\nFrame Time: 0.033333\n" << (frame.empty() ? "0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0" : frame) << "\n";
  return bvh.str();
}

TEST(BvhUnitsTest, EachKnownUnitIsInferredFromAHumanHeight) {
  // 1.7 m from sole to head joint, written in each unit: the unit that makes it 1.0-2.2 m.
  for (const BvhUnit& unit : kBvhUnits) {
    const double height = 1.7 / unit.metres;
    const std::string path = write_scratch(std::string("stick_") + unit.name + ".bvh", stick_figure(0.5 * height, 0.5 * height, 'y'));
    const LoadedBvh loaded = load_bvh_inferring_frame(path);
    EXPECT_EQ(loaded.frame.unit, unit.name);
    EXPECT_EQ(loaded.frame.metres_per_unit, unit.metres) << unit.name;
    EXPECT_TRUE(loaded.frame.unit_inferred);
    EXPECT_TRUE(loaded.frame.plausible) << unit.name;
    EXPECT_EQ(loaded.frame.up, BvhUp::y);
    EXPECT_EQ(loaded.frame.measured_on, "rest pose");
    // The file writes six significant digits.
    EXPECT_NEAR(loaded.frame.height_units, height, 1e-5 * height) << unit.name;
    EXPECT_NEAR(loaded.frame.height_m(), 1.7, 1e-5) << unit.name;
    EXPECT_TRUE(loaded.frame.warning(path).empty());
    // The clip is the one load_bvh gives with that unit.
    const Clip direct = load_bvh(path, {unit.metres});
    EXPECT_EQ(loaded.clip.skeleton.rest_offsets(), direct.skeleton.rest_offsets()) << unit.name;
  }
}

TEST(BvhUnitsTest, SharedFilesGetTheirUnits) {
  for (const std::string& path : {kWalk, kJump}) {
    const LoadedBvh cmu = load_bvh_inferring_frame(path);
    EXPECT_EQ(cmu.frame.unit, "cmu") << path;
    EXPECT_EQ(cmu.frame.up, BvhUp::y);
    // About 23.6 units from toe to head joint in the CMU rest pose (legs splayed): 1.33 m.
    EXPECT_GT(cmu.frame.height_units, 22.0);
    EXPECT_LT(cmu.frame.height_units, 25.0);
    EXPECT_TRUE(cmu.frame.description().starts_with("cmu (0.056444 m per unit, inferred: ")) << cmu.frame.description();
  }
  // Inferring gives load_bvh's clip with the CMU unit: offsets and translations bit for bit.
  const Clip direct = load_bvh(kWalk, {kCmuMetresPerUnit});
  const Clip inferred = load_bvh_inferring_frame(kWalk).clip;
  EXPECT_EQ(inferred.skeleton.rest_offsets(), direct.skeleton.rest_offsets());
  EXPECT_EQ(inferred.translations, direct.translations);
  ASSERT_EQ(inferred.rotations.size(), direct.rotations.size());
  for (std::size_t k = 0; k < direct.rotations.size(); ++k) {
    ASSERT_LT((inferred.rotations[k].coeffs() - direct.rotations[k].coeffs()).norm(), 1e-15) << k;
  }
  // MakeHuman writes decimetres, Z up: 16.4 units from toe to head joint.
  for (const char* file : {"makehuman_walk1.bvh", "makehuman_zombie_walk1.bvh"}) {
    const std::string path = std::string(ODYSSEY_SHARED_DIR) + "/assets/mocap/" + file;
    const LoadedBvh makehuman = load_bvh_inferring_frame(path);
    EXPECT_EQ(makehuman.frame.unit, "dm") << file;
    EXPECT_EQ(makehuman.frame.up, BvhUp::z) << file;
    EXPECT_TRUE(makehuman.frame.plausible) << file;
    // Read Z up, the head stands 1.5-1.7 m above the toes in the toolkit's +z.
    const auto rest = makehuman.clip.skeleton.rest_world();
    const double head = rest[makehuman.clip.skeleton.find("Head")].translation.z();
    const double toe = rest[makehuman.clip.skeleton.find("Toe_L")].translation.z();
    EXPECT_GT(head - toe, 1.4) << file;
    EXPECT_LT(head - toe, 1.7) << file;
  }
}

TEST(BvhUnitsTest, ZUpFilesAreReadWithoutTheYUpTurn) {
  // 170 cm tall along the file's Z: read as it stands, p' = s p.
  const std::string path = write_scratch("stick_z_up.bvh", stick_figure(85, 85, 'z'));
  const LoadedBvh loaded = load_bvh_inferring_frame(path);
  EXPECT_EQ(loaded.frame.up, BvhUp::z);
  EXPECT_EQ(loaded.frame.unit, "cm");
  const auto rest = loaded.clip.skeleton.rest_world();
  expect_near(rest[loaded.clip.skeleton.find("Head")].translation, Vector3d(0, 0, 0.85), 1e-12, "head");
  expect_near(rest[loaded.clip.skeleton.find("LeftArm")].translation, Vector3d(0.34, 0, 0.765), 1e-12, "arm");
  // A rotation about the file's Z is one about the toolkit's Z, unlike a Y-up file's.
  const std::string turned = write_scratch("stick_z_up_turned.bvh",
      stick_figure(85, 85, 'z', "0 0 0 90 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0"));
  const Clip clip = load_bvh_inferring_frame(turned).clip;
  // Hips turned 90 degrees about +z: the arm at (34, 0, 76.5) cm goes to (0, 34, 76.5) cm.
  expect_near(world_positions(clip, 0)[clip.skeleton.find("LeftArm")], Vector3d(0, 0.34, 0.765), 1e-12, "turned arm");
}

TEST(BvhUnitsTest, ADegenerateRestPoseIsMeasuredOnTheFirstFrame) {
  // Every offset zero (a rest pose of one point); the first frame places the joints through
  // position channels, 1700 mm from feet to head.
  std::string bvh = "HIERARCHY\nROOT Hips\n{\n OFFSET 0 0 0\n CHANNELS 3 Xposition Yposition Zposition\n";
  for (const char* joint : {"LeftFoot", "Head"}) {
    bvh += std::string(" JOINT ") + joint + "\n {\n  OFFSET 0 0 0\n  CHANNELS 3 Xposition Yposition Zposition\n"
           "  End Site\n  {\n   OFFSET 0 0 0\n  }\n }\n";
  }
  bvh += "}\nMOTION\nFrames: 1\nFrame Time: 0.01\n0 900 0 100 -900 0 0 800 0\n";
  const std::string path = write_scratch("degenerate_rest.bvh", bvh);
  const LoadedBvh loaded = load_bvh_inferring_frame(path);
  EXPECT_EQ(loaded.frame.measured_on, "first frame");
  EXPECT_NEAR(loaded.frame.height_units, 1700, 1e-9);
  EXPECT_EQ(loaded.frame.unit, "mm");
  EXPECT_TRUE(loaded.frame.plausible);

  // Nothing stands up in either pose: centimetres, with a warning that says so.
  std::string flat = bvh;
  flat.replace(flat.rfind('\n', flat.size() - 2) + 1, std::string::npos, "0 0 0 0 0 0 0 0 0\n");
  const std::string flat_path = write_scratch("flat.bvh", flat);
  const LoadedBvh nothing = load_bvh_inferring_frame(flat_path);
  EXPECT_EQ(nothing.frame.measured_on, "");
  EXPECT_EQ(nothing.frame.unit, "cm");
  EXPECT_FALSE(nothing.frame.plausible);
  EXPECT_EQ(nothing.frame.warning(flat_path), flat_path + ": neither the rest pose nor any frame stands up, so the BVH "
                                                          "unit cannot be inferred; read as cm (0.01 m per unit): give "
                                                          "--bvh-units if that is wrong");
}

TEST(BvhUnitsTest, NoHumanHeightWarnsAndAnExplicitUnitWins) {
  // 0.3 units tall: 0.3 m in metres, the nearest to 1.6 m of any unit, but no human.
  const std::string path = write_scratch("tiny.bvh", stick_figure(0.15, 0.15, 'y'));
  const LoadedBvh tiny = load_bvh_inferring_frame(path);
  EXPECT_EQ(tiny.frame.unit, "m");
  EXPECT_FALSE(tiny.frame.plausible);
  EXPECT_EQ(tiny.frame.warning(path), path + ": the skeleton is 0.3 units tall in the rest pose, a human's 1-2.2 m in no "
                                             "known unit (nearest: m, 0.3 m): give --bvh-units if the unit is wrong");
  // The CMU walk read as centimetres because the user says so: the unit given is used, and the
  // 0.24 m performer is still pointed out.
  const LoadedBvh given = load_bvh_inferring_frame(kWalk, 0.01);
  EXPECT_EQ(given.frame.unit, "cm");
  EXPECT_FALSE(given.frame.unit_inferred);
  EXPECT_EQ(given.frame.metres_per_unit, 0.01);
  EXPECT_FALSE(given.frame.plausible);
  EXPECT_EQ(given.clip.skeleton.rest_offsets(), load_bvh(kWalk, {0.01}).skeleton.rest_offsets());
  const LoadedBvh number = load_bvh_inferring_frame(kWalk, 0.05);
  EXPECT_EQ(number.frame.unit, "0.05");
  EXPECT_TRUE(number.frame.plausible);  // 23.6 x 0.05 = 1.18 m
  EXPECT_THROW(with_bvh_frame(given.clip, -1, BvhUp::y), std::invalid_argument);
}

}  // namespace
}  // namespace odyssey::io
