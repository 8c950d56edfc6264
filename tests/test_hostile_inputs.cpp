// Small files that ask for large costs: each test builds its hostile file, and the loader must
// refuse it with an InputError naming the file, or load it, at a cost bounded by what the file's
// data holds. Memory is checked indirectly: errors come before the allocation, and the process's
// peak resident size stays far below the gigabytes the files used to cost.
#include <gtest/gtest.h>
#include <sys/resource.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <span>
#include <sstream>
#include <string>
#include <vector>

#include "mocap_io/amass.h"
#include "mocap_io/bone_map_file.h"
#include "mocap_io/bvh.h"
#include "mocap_io/camera_path_file.h"
#include "mocap_io/input_error.h"
#include "mocap_io/npy.h"
#include "mocap_io/zip.h"
#include "test_support.h"

namespace odyssey::io {
namespace {

namespace fs = std::filesystem;
using odyssey::test_support::contains;

// Every hostile file here used to cost at least 2.5 GB, or hang for seconds; this process,
// all of its tests together, stays under a quarter of that.
constexpr long kPeakResidentLimitMiB = 640;

long peak_resident_mib() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return usage.ru_maxrss / 1024;  // ru_maxrss is in KiB on Linux
}

std::string write_file(const fs::path& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary) << bytes;
  return path.string();
}

// The InputError that `load` throws; a test failure when it throws none, or another type.
template <class F>
InputError input_error_of(F&& load) {
  try {
    load();
  } catch (const InputError& error) {
    return error;
  }
  ADD_FAILURE() << "no InputError";
  return InputError("", "");
}

// An .npy member as numpy lays it out (version 1.0, header padded to 64 bytes), with a shape and
// data that need not agree: the shape is written as given.
std::string npy_bytes(const std::string& descr, const std::string& shape, const std::string& data) {
  std::string dict = "{'descr': '" + descr + "', 'fortran_order': False, 'shape': " + shape + ", }";
  dict += std::string((64 - (10 + dict.size() + 1) % 64) % 64, ' ') + '\n';
  std::string out("\x93NUMPY\x01\x00", 8);
  out += static_cast<char>(dict.size() & 0xFF);
  out += static_cast<char>(dict.size() >> 8);
  return out + dict + data;
}

std::string doubles(std::initializer_list<double> values) {
  std::string out;
  for (double v : values) out.append(reinterpret_cast<const char*>(&v), sizeof v);
  return out;
}

// A stored (uncompressed) zip archive of the given members, in order.
std::string write_zip(const fs::path& path, const std::vector<std::pair<std::string, std::string>>& members) {
  std::FILE* file = std::fopen(path.c_str(), "wb");
  if (!file) throw std::runtime_error("cannot create " + path.string());
  {
    zip::Writer writer(file, path.string());
    for (const auto& [name, bytes] : members) {
      writer.begin_member(name, zip::Method::Stored, bytes.size());
      writer.write(std::as_bytes(std::span(bytes)));
      writer.end_member();
    }
    writer.finish();
  }
  std::fclose(file);
  return path.string();
}

// --- BVH --------------------------------------------------------------------------------------

// A root with one rotation channel and `children` channel-less joints under it, then `frames`
// one-number frames: a few bytes a frame, `children` + 1 stored rotations a frame.
std::string bvh_with_channelless_joints(int children, int frames) {
  std::ostringstream text;
  text << "HIERARCHY\nROOT root\n{\nOFFSET 0 0 0\nCHANNELS 1 Xrotation\n";
  for (int j = 0; j < children; ++j) text << "JOINT j" << j << "\n{\nOFFSET 0 1 0\n}\n";
  text << "}\nMOTION\nFrames: " << frames << "\nFrame Time: 0.0333333\n";
  for (int f = 0; f < frames; ++f) text << "0\n";
  return text.str();
}

TEST(HostileBvh, ChannellessJointsOverManyFramesAreRefusedBeforeAllocating) {
  // 4,000 joints x 20,000 frames in about 150 KB: 2.5 GB as a clip.
  const std::string text = bvh_with_channelless_joints(3999, 20000);
  ASSERT_LT(text.size(), 160u * 1024);
  const std::string path = write_file(test_support::scratch_dir("hostile") / "wide.bvh", text);
  const InputError error = input_error_of([&] { load_bvh(path); });
  EXPECT_EQ(error.file(), path);
  EXPECT_TRUE(contains(error.problem(), "4000 joints x 20000 frames")) << error.what();
  EXPECT_TRUE(contains(error.problem(), "joints without channels")) << error.what();
  EXPECT_LT(peak_resident_mib(), kPeakResidentLimitMiB);
}

TEST(HostileBvh, ChannellessJointsOverFewFramesStillLoad) {
  const std::string path = write_file(test_support::scratch_dir("hostile") / "short.bvh", bvh_with_channelless_joints(3999, 100));
  const Clip clip = load_bvh(path);
  EXPECT_EQ(clip.joint_count(), 4000);
  EXPECT_EQ(clip.frame_count(), 100);
}

TEST(HostileBvh, DenseOneDigitChannelsPastTheSlackStillLoad) {
  // Every joint has a channel and every number is one digit: 16 bytes of clip per byte of
  // frames, 80 MB of clip from 5 MB, past the fixed slack but within the factor.
  constexpr int kJoints = 100, kFrames = 25000;
  std::ostringstream text;
  text << "HIERARCHY\nROOT j0\n{\nOFFSET 0 0 0\nCHANNELS 1 Zrotation\n";
  for (int j = 1; j < kJoints; ++j) text << "JOINT j" << j << "\n{\nOFFSET 0 1 0\nCHANNELS 1 Zrotation\n";
  for (int j = 0; j < kJoints; ++j) text << "}\n";
  text << "MOTION\nFrames: " << kFrames << "\nFrame Time: 0.0333333\n";
  std::string line;
  for (int j = 0; j < kJoints; ++j) line += j ? " 1" : "1";
  line += '\n';
  for (int f = 0; f < kFrames; ++f) text << line;
  const std::string path = write_file(test_support::scratch_dir("hostile") / "dense.bvh", text.str());
  const Clip clip = load_bvh(path);
  EXPECT_EQ(clip.joint_count(), kJoints);
  EXPECT_EQ(clip.frame_count(), kFrames);
}

// --- AMASS ------------------------------------------------------------------------------------

TEST(HostileAmass, SplitKeysDeclaringABillionFramesAreCheckedAgainstTheirData) {
  const std::string billion = "(1000000000, ";
  const std::string path = write_zip(test_support::scratch_dir("hostile") / "billion.npz",
                                     {{"root_orient.npy", npy_bytes("<f8", billion + "3)", doubles({0, 0, 0}))},
                                      {"pose_body.npy", npy_bytes("<f8", billion + "63)", doubles({0}))},
                                      {"pose_hand.npy", npy_bytes("<f8", billion + "90)", doubles({0}))},
                                      {"trans.npy", npy_bytes("<f8", billion + "3)", doubles({0, 0, 0}))},
                                      {"mocap_frame_rate.npy", npy_bytes("<f8", "()", doubles({30}))}});
  ASSERT_LT(fs::file_size(path), 2048u);
  const InputError error = input_error_of([&] { load_amass(path); });
  EXPECT_EQ(error.file(), path);
  EXPECT_TRUE(contains(error.problem(), "root_orient")) << error.what();
  EXPECT_TRUE(contains(error.problem(), "truncated")) << error.what();
  EXPECT_LT(peak_resident_mib(), kPeakResidentLimitMiB);
}

// Run in a death test's child: loads `path` with 128 MiB of address space to spare, prints the
// error, and exits 0 when it is an InputError naming the file.
[[noreturn]] void load_amass_with_little_memory(const std::string& path) {
  std::ifstream status("/proc/self/status");
  std::string line;
  long vm_kib = 0;
  while (std::getline(status, line))
    if (line.rfind("VmSize:", 0) == 0) vm_kib = std::atol(line.c_str() + 7);
  const rlim_t limit = (static_cast<rlim_t>(vm_kib) + 128 * 1024) * 1024;
  const rlimit address_space{limit, limit};
  setrlimit(RLIMIT_AS, &address_space);
  try {
    load_amass(path);
  } catch (const InputError& error) {
    std::fprintf(stderr, "%s\n", error.what());
    std::exit(error.file() == path ? 0 : 2);
  } catch (const std::exception& error) {
    std::fprintf(stderr, "not an InputError: %s\n", error.what());
    std::exit(3);
  }
  std::exit(4);
}

// A sequence whose data is real (deflated zeros) but larger than the memory the loader is given:
// the allocation fails, and the message names the file instead of saying std::bad_alloc.
TEST(HostileAmass, OutOfMemoryNamesTheFile) {
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
  GTEST_SKIP() << "an address-space limit cannot be set under a sanitizer";
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(memory_sanitizer) || __has_feature(thread_sanitizer)
  GTEST_SKIP() << "an address-space limit cannot be set under a sanitizer";
#endif
#endif
  constexpr std::size_t kFrames = 200000;  // poses: 264 MB of float64
  const std::string path = (test_support::scratch_dir("hostile") / "large.npz").string();
  {
    NpzWriter writer(path, /*compress=*/true);
    const std::vector<double> zeros(kFrames * 3, 0.0);
    writer.begin_array("poses", DType::Float64, {kFrames, 165});
    for (int part = 0; part < 55; ++part) writer.append(std::span<const double>(zeros));
    writer.end_array();
    writer.add("trans", NpyArray::from_float64(zeros, {kFrames, 3}));
    writer.add("mocap_frame_rate", NpyArray::scalar_float64(30));
    writer.close();
  }
  EXPECT_EXIT(load_amass_with_little_memory(path), testing::ExitedWithCode(0), "large.npz: out of memory reading the file");
}

// --- npz ------------------------------------------------------------------------------------

std::string member_key(int k) {
  std::string key = "m";
  return key += std::to_string(k);
}

TEST(HostileNpz, FortyThousandMembersOpenAndLoadInLinearTime) {
  // Member lookup used to scan every member: opening and loading n members took O(n^2) (20,000:
  // 2.3 s; 80,000: 44 s).
  constexpr int kMembers = 40000;
  const std::string path = (test_support::scratch_dir("hostile") / "many.npz").string();
  {
    NpzWriter writer(path, /*compress=*/false);
    for (int k = 0; k < kMembers; ++k) writer.add(member_key(k), NpyArray::scalar_float64(k));
    writer.close();
  }
  const NpzReader reader(path);
  ASSERT_EQ(reader.keys().size(), std::size_t(kMembers));
  EXPECT_EQ(reader.keys().back(), member_key(kMembers - 1));
  int mismatches = 0;
  for (int k = kMembers; k-- > 0;) {
    const std::string key = member_key(k);
    mismatches += !reader.contains(key) || reader.load(key).to_double() != std::vector<double>{double(k)};
  }
  EXPECT_EQ(mismatches, 0);
  const InputError missing = input_error_of([&] { reader.load("absent"); });
  EXPECT_EQ(missing.file(), path);
  EXPECT_TRUE(contains(missing.problem(), "no array 'absent'")) << missing.what();
  EXPECT_TRUE(contains(missing.problem(), "40000 in all")) << missing.what();
}

TEST(HostileNpz, DuplicateMembersAreStillRefused) {
  const std::string member = npy_bytes("<f8", "()", doubles({1}));
  const std::string path =
      write_zip(test_support::scratch_dir("hostile") / "twice.npz", {{"a.npy", member}, {"b.npy", member}, {"a.npy", member}});
  const InputError error = input_error_of([&] { NpzReader{path}; });
  EXPECT_EQ(error.file(), path);
  EXPECT_TRUE(contains(error.problem(), "duplicate member 'a.npy'")) << error.what();
}

// --- npy ------------------------------------------------------------------------------------

TEST(HostileNpy, ZeroWidthTextWithManyElementsIsRefusedFromTheHeader) {
  const fs::path dir = test_support::scratch_dir("hostile");
  for (const std::string descr : {"<U0", "|S0"}) {
    for (const std::string count : {"100000000", "1000000000000000000"}) {
      const std::string bytes = npy_bytes(descr, "(" + count + ",)", "");
      ASSERT_EQ(bytes.size(), 128u);
      const std::string path = write_file(dir / (descr.substr(1) + "_" + count + ".npy"), bytes);
      const InputError error = input_error_of([&] { read_npy(path); });
      EXPECT_EQ(error.file(), path);
      EXPECT_TRUE(contains(error.problem(), "zero width")) << error.what();
      EXPECT_TRUE(contains(error.problem(), count + " elements")) << error.what();
    }
  }
  EXPECT_LT(peak_resident_mib(), kPeakResidentLimitMiB);
}

TEST(HostileNpy, EmptyArraysLoadWithoutTouchingTheirBuffer) {
  for (const std::string descr : {"<f8", "<U0", "|S3"}) {
    const std::string bytes = npy_bytes(descr, "(0, 4)", "");
    const NpyArray array = parse_npy(std::as_bytes(std::span(bytes)), "empty.npy");
    EXPECT_EQ(array.element_count(), 0u) << descr;
    EXPECT_TRUE(array.data.empty()) << descr;
  }
}

TEST(HostileNpy, TextIsNotConvertedToNumbers) {
  const std::vector<std::string> words = {"left", "right"};
  const NpyArray text = NpyArray::from_strings(words, {2});
  EXPECT_THROW(text.to_double(), std::invalid_argument);
  EXPECT_THROW(text.to_float(), std::invalid_argument);
  EXPECT_THROW(text.to_int64(), std::invalid_argument);
  EXPECT_EQ(text.to_strings(), words);
}

// --- JSON -----------------------------------------------------------------------------------

TEST(HostileJson, TwoMegabyteBoneMapParsesInLinearTimeAndKeepsFileOrder) {
  // ordered_json inserted every key by a linear scan: 2 MB took 8.6 s. Names count down, so file
  // order is not the sorted order a std::map would give.
  constexpr int kEntries = 100000;
  std::string json = "{\"name\": \"huge\", \"joints\": {";
  for (int k = kEntries; k-- > 0;) json += "\"c" + std::to_string(k) + "\": \"rig" + std::to_string(k) + "\"" + (k ? ", " : "");
  json += "}}";
  ASSERT_GT(json.size(), 2'000'000u);
  const std::string path = write_file(test_support::scratch_dir("hostile") / "huge_map.json", json);
  const BoneMapFile map = load_bone_map_file(path);
  ASSERT_EQ(map.entries.size(), std::size_t(kEntries));
  EXPECT_EQ(map.name, "huge");
  EXPECT_EQ(map.entries.front().canonical, "c" + std::to_string(kEntries - 1));
  EXPECT_EQ(map.entries.back().canonical, "c0");
  EXPECT_EQ(map.entries.back().rig_joints, std::vector<std::string>{"rig0"});
}

TEST(HostileJson, BoneMapNamingACanonicalJointTwiceIsRefused) {
  const std::string path = write_file(test_support::scratch_dir("hostile") / "twice.json",
                                      R"({"joints": {"head": "Head", "neck": "Neck", "head": "Head2"}})");
  const InputError error = input_error_of([&] { load_bone_map_file(path); });
  EXPECT_EQ(error.file(), path);
  EXPECT_EQ(error.problem(), "joints.head: the key \"head\" is given twice in one object");

  const std::string joints_twice = write_file(test_support::scratch_dir("hostile") / "joints_twice.json",
                                              R"({"joints": {"head": "Head"}, "joints": {"neck": "Neck"}})");
  EXPECT_EQ(input_error_of([&] { load_bone_map_file(joints_twice); }).problem(), "joints: the key \"joints\" is given twice in one object");
  const std::string name_twice = write_file(test_support::scratch_dir("hostile") / "name_twice.json",
                                            R"({"name": "a", "joints": {"head": "Head"}, "name": "b"})");
  EXPECT_EQ(input_error_of([&] { load_bone_map_file(name_twice); }).problem(), "name: the key \"name\" is given twice in one object");
}

TEST(HostileJson, CameraPathGivingAKeyTwiceIsRefused) {
  const std::string path = write_file(test_support::scratch_dir("hostile") / "twice_camera.json",
                                      R"({"format": "odyssey-camera-path", "version": 1, "version": 2, "frames": []})");
  EXPECT_EQ(input_error_of([&] { read_camera_path_json(path); }).problem(), "version: the key \"version\" is given twice in one object");
  const std::string frame = write_file(test_support::scratch_dir("hostile") / "twice_frame.json",
                                       R"({"format": "x", "frames": [{"frame": 0}, {"frame": 1, "frame": 1}]})");
  EXPECT_EQ(input_error_of([&] { read_camera_path_json(frame); }).problem(), "frames[1].frame: the key \"frame\" is given twice in one object");
}

TEST(HostileJson, CameraPathWithAHugeObjectParsesInLinearTime) {
  const fs::path dir = test_support::scratch_dir("hostile");
  CameraPath camera;
  camera.kind = "static";
  camera.poses.resize(1);
  camera.intrinsics.push_back({500, 500, 320, 240, 640, 480});
  const std::string written = (dir / "camera.json").string();
  write_camera_path_json(written, camera);
  std::ifstream in(written);
  std::string json((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  // 140,000 keys the reader does not use, in the top-level object.
  std::string padding;
  for (int k = 0; k < 140000; ++k) padding += "\"pad" + std::to_string(k) + "\": 0, ";
  ASSERT_EQ(json.front(), '{');
  json.insert(1, padding);
  ASSERT_GT(json.size(), 2'000'000u);
  const std::string path = write_file(dir / "padded.json", json);
  const CameraPath read = read_camera_path_json(path);
  EXPECT_EQ(read.frame_count(), 1);
  EXPECT_EQ(read.kind, "static");
  EXPECT_EQ(read.intrinsics[0].width, 640);
}

}  // namespace
}  // namespace odyssey::io
