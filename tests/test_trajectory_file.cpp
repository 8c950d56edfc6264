// TrajectoryFileWriter: a file streamed in uneven chunks reads back, key by key and value by value,
// both in numpy and in our own NpzReader; stored and deflated archives; spools live beside the
// output while writing and are gone afterwards; bad headers, wrong chunk sizes, too many frames,
// non-finite values, bools other than 0 and 1, visible points that are not valid and a short close()
// are rejected, and a failed or abandoned file leaves
// nothing behind.
#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "test_support.h"
#include "mocap_io/npy.h"
#include "mocap_io/trajectory_file.h"

namespace fs = std::filesystem;
using namespace odyssey::io;

namespace {

using odyssey::test_support::numpy_python;
using odyssey::test_support::message_of;
using odyssey::test_support::contains;

constexpr std::size_t kFrames = 7;
constexpr std::size_t kPoints = 5;
constexpr double kFps = 24;

fs::path scratch_dir() { return odyssey::test_support::scratch_dir("trajectory_file"); }
using odyssey::test_support::files_in;

bool run_python(const fs::path& dir, const std::string& script, const std::vector<std::string>& args) {
  const fs::path path = dir.parent_path() / (dir.filename().string() + ".py");
  std::ofstream(path) << script;
  std::string command = numpy_python() + " '" + path.string() + "'";
  for (const std::string& arg : args) command += " '" + arg + "'";
  return std::system(command.c_str()) == 0;
}

// The content, as formulas of frame t, point n and component k that the numpy check repeats in
// float64 with the same operation order and then rounds to float32, so both sides agree exactly.
// Extrinsics and intrinsics vary per element so that a transposed matrix would show.
float traj3(std::size_t t, std::size_t n, std::size_t k) { return static_cast<float>(1.5 * t + 0.25 * n - 0.125 * k + 0.1); }
float traj2(std::size_t t, std::size_t n, std::size_t k) { return static_cast<float>(100.0 * t + 10.0 * n + k + 0.3); }
std::uint8_t valid(std::size_t t, std::size_t n) { return (t + 2 * n) % 3 != 0; }
// Visible only where valid (the writer enforces it), and hidden at some valid points, so that a
// file mixing the two arrays up shows.
std::uint8_t visible(std::size_t t, std::size_t n) { return valid(t, n) && (t + n) % 2 == 0; }
float intrinsic(std::size_t t, std::size_t i) { return static_cast<float>(500.0 * (i == 0 || i == 4) + 0.5 * i + t); }
float extrinsic(std::size_t t, std::size_t i) { return static_cast<float>(0.25 * i - 0.01 * t); }

struct Frames {
  std::vector<float> trajs_3d, trajs_2d, intrinsics, extrinsics;
  std::vector<std::uint8_t> valids, visibs;
};

Frames make_frames(std::size_t frames, std::size_t points) {
  Frames f;
  for (std::size_t t = 0; t < frames; ++t) {
    for (std::size_t n = 0; n < points; ++n) {
      for (std::size_t k = 0; k < 3; ++k) f.trajs_3d.push_back(traj3(t, n, k));
      for (std::size_t k = 0; k < 2; ++k) f.trajs_2d.push_back(traj2(t, n, k));
      f.valids.push_back(valid(t, n));
      f.visibs.push_back(visible(t, n));
    }
    for (std::size_t i = 0; i < 9; ++i) f.intrinsics.push_back(intrinsic(t, i));
    for (std::size_t i = 0; i < 16; ++i) f.extrinsics.push_back(extrinsic(t, i));
  }
  return f;
}

TrajectoryFileHeader make_header(std::size_t frames = kFrames, std::size_t points = kPoints) {
  TrajectoryFileHeader h;
  h.frames = frames;
  h.points = points;
  h.fps = kFps;
  for (std::size_t n = 0; n < points; ++n) {
    for (std::size_t k = 0; k < 3; ++k) h.point_vertex_ids.push_back(static_cast<std::int32_t>(7 * n + k));
    h.point_barycentric.insert(h.point_barycentric.end(), {0.25f, 0.125f * n, 0.75f - 0.125f * n});
    h.point_actor_ids.push_back(static_cast<std::int32_t>(n % 2));
  }
  return h;
}

// Appends frames [first, first + count) of `f`.
void append(TrajectoryFileWriter& writer, const Frames& f, std::size_t first, std::size_t count, std::size_t points = kPoints) {
  auto slice = [&](const auto& values, std::size_t per_frame) {
    return std::span(values).subspan(first * per_frame, count * per_frame);
  };
  writer.append_frames(count, slice(f.trajs_3d, points * 3), slice(f.trajs_2d, points * 2), slice(f.valids, points),
                       slice(f.visibs, points), slice(f.intrinsics, 9), slice(f.extrinsics, 16));
}

const std::vector<std::string> kKeys = {"trajs_3d",         "trajs_2d",         "visibs",
                                        "valids",           "intrinsics",       "extrinsics",
                                        "point_vertex_ids", "point_barycentric", "point_actor_ids",
                                        "fps"};

// numpy's view of a file written from make_frames / make_header: keys in order, dtypes, shapes,
// every value, and the zip method of every member (argv: path, T, N, method).
constexpr const char* kNumpyCheck = R"PY(
import sys, zipfile
import numpy as np
path, T, N, method = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4])
def fail(message):
    print('numpy check failed:', message)
    sys.exit(1)
with zipfile.ZipFile(path) as zf:
    methods = sorted({info.compress_type for info in zf.infolist()})
    if methods != [method]: fail('zip methods %s, expected %d' % (methods, method))
d = np.load(path)
keys = ['trajs_3d', 'trajs_2d', 'visibs', 'valids', 'intrinsics', 'extrinsics', 'point_vertex_ids', 'point_barycentric', 'point_actor_ids', 'fps']
if d.files != keys: fail('keys %s' % d.files)
layout = {'trajs_3d': ('float32', (T, N, 3)), 'trajs_2d': ('float32', (T, N, 2)), 'visibs': ('bool', (T, N)), 'valids': ('bool', (T, N)),
          'intrinsics': ('float32', (T, 3, 3)), 'extrinsics': ('float32', (T, 4, 4)), 'point_vertex_ids': ('int32', (N, 3)),
          'point_barycentric': ('float32', (N, 3)), 'point_actor_ids': ('int32', (N,)), 'fps': ('float64', ())}
for key, (dtype, shape) in layout.items():
    if str(d[key].dtype) != dtype or d[key].shape != shape: fail('%s is %s %s' % (key, d[key].dtype, d[key].shape))
t = np.arange(T, dtype=np.float64)[:, None, None]
n = np.arange(N, dtype=np.float64)[None, :, None]
k2 = np.arange(2, dtype=np.float64)[None, None, :]
k3 = np.arange(3, dtype=np.float64)[None, None, :]
i = np.arange(16, dtype=np.float64)
K = (500.0 * np.isin(np.arange(9), [0, 4]) + 0.5 * i[:9] + t[:, :, 0]).astype(np.float32).reshape(T, 3, 3)
expected = {
    'trajs_3d': (1.5 * t + 0.25 * n - 0.125 * k3 + 0.1).astype(np.float32),
    'trajs_2d': (100.0 * t + 10.0 * n + k2 + 0.3).astype(np.float32),
    'visibs': ((np.arange(T)[:, None] + 2 * np.arange(N)[None, :]) % 3 != 0) & ((np.arange(T)[:, None] + np.arange(N)[None, :]) % 2 == 0),
    'valids': (np.arange(T)[:, None] + 2 * np.arange(N)[None, :]) % 3 != 0,
    'intrinsics': K,
    'extrinsics': (0.25 * i - 0.01 * t[:, :, 0]).astype(np.float32).reshape(T, 4, 4),
    'point_vertex_ids': (7 * np.arange(N)[:, None] + np.arange(3)[None, :]).astype(np.int32),
    'point_barycentric': np.stack([np.full(N, 0.25), 0.125 * np.arange(N), 0.75 - 0.125 * np.arange(N)], axis=1).astype(np.float32),
    'point_actor_ids': (np.arange(N) % 2).astype(np.int32),
    'fps': np.float64(24.0),
}
for key, value in expected.items():
    if not np.array_equal(d[key], value): fail('%s differs:\n%s\nexpected\n%s' % (key, d[key], value))
if np.any(d['visibs'] & ~d['valids']) or not np.any(d['valids'] & ~d['visibs']): fail('visibs is not a proper subset of valids')
print('numpy read %s: %s, trajs_3d[%d, %d] = %s, K[1] = %s' % (path.rsplit('/', 1)[-1], d.files, T - 1, N - 1, d['trajs_3d'][-1, -1], d['intrinsics'][1].tolist()))
)PY";

// Our own reader on a file written from make_frames / make_header.
void expect_npz_reader_content(const fs::path& path, std::size_t frames, std::size_t points) {
  const NpzReader npz(path.string());
  ASSERT_EQ(npz.keys(), kKeys);
  const Frames f = make_frames(frames, points);
  const TrajectoryFileHeader h = make_header(frames, points);
  auto expect_array = [&](const std::string& key, DType dtype, std::vector<std::size_t> shape) {
    const NpyArray array = npz.load(key);
    EXPECT_EQ(array.dtype(), dtype) << key;
    EXPECT_EQ(array.shape(), shape) << key;
    return array;
  };
  EXPECT_EQ(expect_array("trajs_3d", DType::Float32, {frames, points, 3}).to_float(), f.trajs_3d);
  EXPECT_EQ(expect_array("trajs_2d", DType::Float32, {frames, points, 2}).to_float(), f.trajs_2d);
  const std::vector<std::int64_t> visibs = expect_array("visibs", DType::Bool, {frames, points}).to_int64();
  EXPECT_EQ(visibs, std::vector<std::int64_t>(f.visibs.begin(), f.visibs.end()));
  const std::vector<std::int64_t> valids = expect_array("valids", DType::Bool, {frames, points}).to_int64();
  EXPECT_EQ(valids, std::vector<std::int64_t>(f.valids.begin(), f.valids.end()));
  EXPECT_EQ(expect_array("intrinsics", DType::Float32, {frames, 3, 3}).to_float(), f.intrinsics);
  EXPECT_EQ(expect_array("extrinsics", DType::Float32, {frames, 4, 4}).to_float(), f.extrinsics);
  const std::vector<std::int64_t> vertex_ids = expect_array("point_vertex_ids", DType::Int32, {points, 3}).to_int64();
  EXPECT_EQ(vertex_ids, std::vector<std::int64_t>(h.point_vertex_ids.begin(), h.point_vertex_ids.end()));
  EXPECT_EQ(expect_array("point_barycentric", DType::Float32, {points, 3}).to_float(), h.point_barycentric);
  const std::vector<std::int64_t> actor_ids = expect_array("point_actor_ids", DType::Int32, {points}).to_int64();
  EXPECT_EQ(actor_ids, std::vector<std::int64_t>(h.point_actor_ids.begin(), h.point_actor_ids.end()));
  EXPECT_EQ(expect_array("fps", DType::Float64, {}).to_double(), std::vector<double>{kFps});
}

TEST(TrajectoryFile, UnevenChunksReadBackInNumpyAndNpzReader) {
  const fs::path dir = scratch_dir();
  const fs::path path = dir / "tracks.npz";
  const Frames f = make_frames(kFrames, kPoints);
  {
    TrajectoryFileWriter writer(path.string(), make_header());
    std::size_t first = 0;
    for (const std::size_t count : {3, 0, 1, 2, 1}) {
      append(writer, f, first, count);
      first += count;
      EXPECT_EQ(writer.frames_written(), first);
    }
    // While writing: nothing at `path`; the archive and one spool per per-frame array (except
    // trajs_3d, which goes straight into the archive) beside it, named after the process and key.
    const std::string spool = "tracks.npz.partial-" + std::to_string(::getpid()) + "-";
    const std::vector<std::string> during = files_in(dir);
    EXPECT_EQ(during.size(), 6u);
    for (const char* key : {"trajs_2d", "visibs", "valids", "intrinsics", "extrinsics"})
      EXPECT_NE(std::find(during.begin(), during.end(), spool + key), during.end()) << key;
    EXPECT_FALSE(fs::exists(path));
    writer.close();
    EXPECT_EQ(writer.frames_written(), kFrames);
  }
  EXPECT_EQ(files_in(dir), std::vector<std::string>{"tracks.npz"});
  expect_npz_reader_content(path, kFrames, kPoints);
  REQUIRE_NUMPY();
  EXPECT_TRUE(run_python(dir, kNumpyCheck, {path.string(), std::to_string(kFrames), std::to_string(kPoints), "0"}));
}

TEST(TrajectoryFile, CompressedArchiveDeflatesEveryMember) {
  const fs::path dir = scratch_dir();
  const fs::path stored = dir / "stored.npz";
  const fs::path deflated = dir / "deflated.npz";
  const std::size_t frames = 40, points = 300;  // large enough that deflate has something to work on
  const Frames f = make_frames(frames, points);
  for (const fs::path& path : {stored, deflated}) {
    TrajectoryFileWriter writer(path.string(), make_header(frames, points), /*compress=*/path == deflated);
    append(writer, f, 0, 17, points);
    append(writer, f, 17, 23, points);
    writer.close();
    expect_npz_reader_content(path, frames, points);
  }
  EXPECT_EQ(files_in(dir), (std::vector<std::string>{"deflated.npz", "stored.npz"}));
  // The formulas repeat from frame to frame, so deflate must save a good part of the archive.
  EXPECT_LT(fs::file_size(deflated), fs::file_size(stored) * 3 / 4);
  REQUIRE_NUMPY();
  EXPECT_TRUE(run_python(dir, kNumpyCheck, {deflated.string(), std::to_string(frames), std::to_string(points), "8"}));
}

TEST(TrajectoryFile, RejectsBadHeaders) {
  const fs::path dir = scratch_dir();
  const std::string path = (dir / "tracks.npz").string();
  auto rejects = [&](TrajectoryFileHeader h) {
    return message_of<std::invalid_argument>([&] { TrajectoryFileWriter writer(path, std::move(h)); });
  };
  TrajectoryFileHeader h = make_header();
  h.frames = 0;
  EXPECT_TRUE(contains(rejects(h), "0 frames"));
  h = make_header();
  h.points = 0;
  EXPECT_TRUE(contains(rejects(h), "0 points"));
  for (const double fps : {0.0, -30.0, std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity()}) {
    h = make_header();
    h.fps = fps;
    EXPECT_TRUE(contains(rejects(h), "fps")) << fps;
  }
  h = make_header();
  h.point_vertex_ids.pop_back();
  const std::string ids = rejects(h);
  EXPECT_TRUE(contains(ids, "point_vertex_ids holds 14 values") && contains(ids, "need 15")) << ids;
  h = make_header();
  h.point_barycentric.push_back(0);
  const std::string barycentric = rejects(h);
  EXPECT_TRUE(contains(barycentric, "holds 16") && contains(barycentric, "need 15")) << barycentric;
  h = make_header();
  h.point_actor_ids.resize(2 * kPoints);
  const std::string actors = rejects(h);
  EXPECT_TRUE(contains(actors, "holds 10") && contains(actors, "need 5")) << actors;
  h = make_header();
  h.point_barycentric[4] = std::numeric_limits<float>::quiet_NaN();
  EXPECT_TRUE(contains(rejects(h), "not finite"));
  EXPECT_TRUE(files_in(dir).empty());
}

// A rejected chunk writes nothing: after each mistake the writer goes on with correct chunks and
// the file comes out exactly right.
TEST(TrajectoryFile, RejectedChunksLeaveTheFileIntact) {
  const fs::path dir = scratch_dir();
  const fs::path path = dir / "tracks.npz";
  const Frames f = make_frames(kFrames, kPoints);
  TrajectoryFileWriter writer(path.string(), make_header());
  append(writer, f, 0, 2);
  auto sub = [](const auto& values, std::size_t per_frame, std::size_t first, std::size_t count) {
    return std::span(values).subspan(first * per_frame, count * per_frame);
  };
  const auto traj3 = sub(f.trajs_3d, 15, 2, 3);
  const auto traj2 = sub(f.trajs_2d, 10, 2, 3);
  const auto valids = sub(f.valids, 5, 2, 3);
  const auto visibs = sub(f.visibs, 5, 2, 3);
  const auto intr = sub(f.intrinsics, 9, 2, 3);
  const auto extr = sub(f.extrinsics, 16, 2, 3);

  // Wrong sizes, each naming what arrived and what 3 frames need.
  std::string m = message_of<std::invalid_argument>([&] { writer.append_frames(3, traj3.first(44), traj2, valids, visibs, intr, extr); });
  EXPECT_TRUE(contains(m, "trajs_3d holds 44") && contains(m, "need 45")) << m;
  m = message_of<std::invalid_argument>([&] { writer.append_frames(3, traj3, sub(f.trajs_2d, 10, 2, 4), valids, visibs, intr, extr); });
  EXPECT_TRUE(contains(m, "trajs_2d holds 40") && contains(m, "need 30")) << m;
  m = message_of<std::invalid_argument>([&] { writer.append_frames(3, traj3, traj2, valids.first(14), visibs, intr, extr); });
  EXPECT_TRUE(contains(m, "valids holds 14") && contains(m, "need 15")) << m;
  m = message_of<std::invalid_argument>([&] { writer.append_frames(3, traj3, traj2, valids, sub(f.visibs, 5, 1, 4), intr, extr); });
  EXPECT_TRUE(contains(m, "visibs holds 20") && contains(m, "need 15")) << m;
  m = message_of<std::invalid_argument>([&] { writer.append_frames(3, traj3, traj2, valids, visibs, intr.first(26), extr); });
  EXPECT_TRUE(contains(m, "intrinsics holds 26") && contains(m, "need 27")) << m;
  m = message_of<std::invalid_argument>([&] { writer.append_frames(3, traj3, traj2, valids, visibs, intr, extr.first(47)); });
  EXPECT_TRUE(contains(m, "extrinsics holds 47") && contains(m, "need 48")) << m;

  // More frames than the file holds: 2 written + 6 would make 8 of 7.
  m = message_of<std::invalid_argument>([&] { append(writer, make_frames(8, kPoints), 2, 6); });
  EXPECT_TRUE(contains(m, "would make 8") && contains(m, "holds 7")) << m;

  // Non-finite values and a bool that is not 0 or 1, named by frame (counted over the file).
  std::vector<float> bad2(traj2.begin(), traj2.end());
  bad2[10 + 7] = std::numeric_limits<float>::quiet_NaN();  // chunk frame 1 = file frame 3
  m = message_of<std::invalid_argument>([&] { writer.append_frames(3, traj3, bad2, valids, visibs, intr, extr); });
  EXPECT_TRUE(contains(m, "trajs_2d value nan at frame 3, value 7 of 10 is not finite")) << m;
  std::vector<float> bad_extr(extr.begin(), extr.end());
  bad_extr[2 * 16 + 3] = -std::numeric_limits<float>::infinity();
  m = message_of<std::invalid_argument>([&] { writer.append_frames(3, traj3, traj2, valids, visibs, intr, bad_extr); });
  EXPECT_TRUE(contains(m, "extrinsics value -inf at frame 4, value 3 of 16")) << m;
  std::vector<float> bad3(traj3.begin(), traj3.end());
  bad3[0] = std::numeric_limits<float>::infinity();
  m = message_of<std::invalid_argument>([&] { writer.append_frames(3, bad3, traj2, valids, visibs, intr, extr); });
  EXPECT_TRUE(contains(m, "trajs_3d value inf at frame 2, value 0 of 15")) << m;
  std::vector<std::uint8_t> bad_valids(valids.begin(), valids.end());
  bad_valids[6] = 2;
  m = message_of<std::invalid_argument>([&] { writer.append_frames(3, traj3, traj2, bad_valids, visibs, intr, extr); });
  EXPECT_TRUE(contains(m, "valids value 2 at frame 3, value 1 of 5 is not 0 or 1")) << m;
  std::vector<std::uint8_t> bad_visibs(visibs.begin(), visibs.end());
  bad_visibs[12] = 255;
  m = message_of<std::invalid_argument>([&] { writer.append_frames(3, traj3, traj2, valids, bad_visibs, intr, extr); });
  EXPECT_TRUE(contains(m, "visibs value 255 at frame 4, value 2 of 5 is not 0 or 1")) << m;
  // Visible where not valid: file frame 2 (t = 2), point 2 has (t + 2n) % 3 == 0, so valids is 0.
  ASSERT_EQ(valids[2], 0);
  bad_visibs.assign(visibs.begin(), visibs.end());
  bad_visibs[2] = 1;
  m = message_of<std::invalid_argument>([&] { writer.append_frames(3, traj3, traj2, valids, bad_visibs, intr, extr); });
  EXPECT_TRUE(contains(m, "visibs is 1 but valids 0 at frame 2, value 2 of 5")) << m;

  EXPECT_EQ(writer.frames_written(), 2u);
  append(writer, f, 2, 5);
  writer.close();
  EXPECT_EQ(files_in(dir), std::vector<std::string>{"tracks.npz"});
  expect_npz_reader_content(path, kFrames, kPoints);
}

TEST(TrajectoryFile, ShortCloseLeavesNothing) {
  const fs::path dir = scratch_dir();
  const fs::path path = dir / "tracks.npz";
  const Frames f = make_frames(kFrames, kPoints);
  TrajectoryFileWriter writer(path.string(), make_header());
  append(writer, f, 0, 6);
  EXPECT_EQ(files_in(dir).size(), 6u);  // the archive and five spools
  const std::string m = message_of<std::invalid_argument>([&] { writer.close(); });
  EXPECT_TRUE(contains(m, "6 of 7 frames")) << m;
  EXPECT_TRUE(files_in(dir).empty());
  // The writer is finished: it cannot be completed afterwards.
  EXPECT_THROW(append(writer, f, 6, 1), std::logic_error);
  EXPECT_THROW(writer.close(), std::logic_error);
  EXPECT_TRUE(files_in(dir).empty());
}

TEST(TrajectoryFile, DestructionWithoutCloseLeavesNothing) {
  const fs::path dir = scratch_dir();
  const fs::path path = dir / "tracks.npz";
  const Frames f = make_frames(kFrames, kPoints);
  {
    TrajectoryFileWriter writer(path.string(), make_header());
    append(writer, f, 0, kFrames);  // complete, but never closed
    EXPECT_EQ(files_in(dir).size(), 6u);
  }
  EXPECT_TRUE(files_in(dir).empty());
}

TEST(TrajectoryFile, UnwritableFolderIsAnInputErrorNamingThePath) {
  const fs::path dir = scratch_dir();
  const std::string path = (dir / "missing" / "tracks.npz").string();
  try {
    TrajectoryFileWriter writer(path, make_header());
    ADD_FAILURE() << "no exception";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), path);
  }
  EXPECT_TRUE(files_in(dir).empty());
}

}  // namespace
