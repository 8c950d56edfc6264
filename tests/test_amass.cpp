// AMASS sequences: round trips through write_amass/load_amass, files written by numpy in every
// layout AMASS uses (and read back by numpy), resampling a loaded file, and every kind of bad
// input, each of which must be one InputError naming the file.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <numbers>
#include <string>
#include <tuple>
#include <vector>

#include "mocap_io/amass.h"
#include "mocap_io/input_error.h"
#include "mocap_io/npy.h"
#include "skeleton/body_sequence.h"
#include "synthetic/synthetic_walk.h"
#include "test_support.h"

namespace odyssey::io {
namespace {

namespace fs = std::filesystem;

fs::path scratch() {
  const fs::path dir = odyssey::test_support::scratch_root() / "amass";
  fs::create_directories(dir);
  return dir;
}

// The configured python when it can import numpy, else empty (the numpy tests then skip).
std::string numpy_python() {
  const std::string python = ODYSSEY_PYTHON;
  if (python.empty()) return "";
  if (std::system((python + " -c 'import numpy' > /dev/null 2>&1").c_str()) != 0) return "";
  return python;
}

// The values the numpy script writes: pose[t, c] = sin(0.1 t + 0.01 c), trans = (0.01 t,
// -0.02 t, 0.9).
double pose_value(int t, int c) { return std::sin(0.1 * t + 0.01 * c); }

const char* const kNumpyScript = R"(import sys
import numpy as np

out, mode = sys.argv[1], sys.argv[2]
if mode == 'write':
    T = 12
    t = np.arange(T)[:, None]
    def pose(width, frames=T):
        return np.sin(0.1 * np.arange(frames)[:, None] + 0.01 * np.arange(width)[None, :])
    trans = np.concatenate([0.01 * t, -0.02 * t, 0.9 + 0.0 * t], axis=1)
    p = pose(165)
    split = dict(root_orient=p[:, :3], pose_body=p[:, 3:66], pose_jaw=p[:, 66:69], pose_eye=p[:, 69:75],
                 pose_hand=p[:, 75:])
    pickled = np.array([{'x': 1}], dtype=object)
    # SMPL-X as AMASS ships it: 165-D poses beside the split keys (float32, as some files store
    # them), gender as str, frame rate under mocap_frame_rate, extra and pickled keys.
    np.savez(out + '/smplx_poses.npz', poses=p, trans=trans, betas=np.linspace(-1, 1, 16).astype(np.float32),
             gender=np.array('male'), mocap_frame_rate=np.array(120.0), surface_model_type=np.array('smplx'),
             extra_pickled=pickled, **{k: v.astype(np.float32) for k, v in split.items()})
    # SMPL-X split keys only, betas (1,N), gender as bytes, compressed.
    np.savez_compressed(out + '/smplx_split.npz', trans=trans, betas=np.linspace(-1, 1, 10)[None, :],
                        gender=np.array(b'female'), mocap_frame_rate=np.array(60.0), **split)
    # SMPL-H: 156-D float32 poses, mocap_framerate, gender as a one-element array, dmpls.
    np.savez(out + '/smplh.npz', poses=pose(156).astype(np.float32), trans=trans.astype(np.float32),
             betas=np.zeros(16), gender=np.array(['neutral']), mocap_framerate=np.array(60.0),
             dmpls=np.zeros((T, 8)), extra_pickled=pickled)
    # SMPL: 72-D, gender as a one-element bytes array.
    np.savez(out + '/smpl.npz', poses=pose(72), trans=trans, betas=np.zeros(10), gender=np.array([b'male']),
             mocap_framerate=np.array(30.0))
    # One second at 120 fps, for resampling.
    np.savez(out + '/walk120.npz', poses=pose(165, 121), trans=np.zeros((121, 3)), betas=np.zeros(10),
             gender=np.array('neutral'), mocap_frame_rate=np.array(120.0))
    # Bad: the pose is a pickled object array; the split keys contradict poses.
    np.savez(out + '/bad_pickled_poses.npz', poses=np.array([{'x': 1}] * T, dtype=object), trans=trans,
             mocap_frame_rate=np.array(30.0))
    np.savez(out + '/bad_disagreeing_split.npz', poses=p, trans=trans, mocap_frame_rate=np.array(30.0),
             pose_body=p[:, 3:66] + 0.01)
elif mode == 'check':
    # A file from write_amass: SMPL-X, 40 frames, gender female, 30 fps.
    d = np.load(out)
    assert d['poses'].shape == (40, 165) and d['poses'].dtype == np.float64, d['poses'].shape
    assert d['trans'].shape == (40, 3)
    assert d['betas'].shape == (10,)
    assert str(d['gender']) == 'female', repr(d['gender'])
    assert float(d['mocap_frame_rate']) == 30.0
    p = d['poses']
    for key, lo, hi in [('root_orient', 0, 3), ('pose_body', 3, 66), ('pose_jaw', 66, 69), ('pose_eye', 69, 75),
                        ('pose_hand', 75, 165)]:
        assert np.array_equal(d[key], p[:, lo:hi]), key
    print(sorted(d.files))
)";

class AmassNumpyTest : public testing::Test {
 protected:
  static void SetUpTestSuite() {
    python_ = numpy_python();
    if (python_.empty()) return;
    script_ = (scratch() / "amass_numpy.py").string();
    std::ofstream(script_) << kNumpyScript;
    written_ = std::system((python_ + " " + script_ + " " + scratch().string() + " write").c_str()) == 0;
  }
  void SetUp() override {
    if (python_.empty()) GTEST_SKIP() << "no python3 with numpy (ODYSSEY_PYTHON='" << ODYSSEY_PYTHON << "')";
    ASSERT_TRUE(written_) << "the numpy script failed";
  }
  static std::string path(const std::string& name) { return (scratch() / name).string(); }

  static void expect_poses(const BodySequence& sequence, double tolerance) {
    for (int t = 0; t < sequence.frame_count(); ++t) {
      for (int c = 0; c < sequence.poses.cols(); ++c) {
        ASSERT_NEAR(sequence.poses(t, c), pose_value(t, c), tolerance) << "frame " << t << " column " << c;
      }
      ASSERT_NEAR(sequence.translations(t, 0), 0.01 * t, tolerance);
      ASSERT_NEAR(sequence.translations(t, 1), -0.02 * t, tolerance);
      ASSERT_NEAR(sequence.translations(t, 2), 0.9, tolerance);
    }
  }

  static inline std::string python_, script_;
  static inline bool written_ = false;
};

TEST_F(AmassNumpyTest, SmplxWithFullPosesAndExtraKeys) {
  const AmassFile file = load_amass_file(path("smplx_poses.npz"));
  const BodySequence& sequence = file.sequence;
  EXPECT_EQ(sequence.kind, BodyModelKind::SMPLX);
  EXPECT_EQ(sequence.frame_count(), 12);
  EXPECT_EQ(sequence.fps, 120.0);
  EXPECT_EQ(sequence.gender, "male");
  ASSERT_EQ(sequence.betas.size(), 16u);
  EXPECT_NEAR(sequence.betas.front(), -1.0, 1e-7);
  EXPECT_NEAR(sequence.betas.back(), 1.0, 1e-7);
  expect_poses(sequence, 1e-12);
  EXPECT_EQ(file.pose_keys, "poses");
  EXPECT_EQ(file.frame_rate_key, "mocap_frame_rate");
  // The split keys agree with poses and count as read; the rest, pickled included, are skipped.
  EXPECT_EQ(file.skipped_keys, (std::vector<std::string>{"surface_model_type", "extra_pickled"}));
}

TEST_F(AmassNumpyTest, SmplxSplitKeysOnly) {
  const AmassFile file = load_amass_file(path("smplx_split.npz"));
  EXPECT_EQ(file.sequence.kind, BodyModelKind::SMPLX);
  EXPECT_EQ(file.pose_keys, "split keys");
  EXPECT_EQ(file.sequence.gender, "female");  // from bytes
  EXPECT_EQ(file.sequence.fps, 60.0);
  EXPECT_EQ(file.sequence.betas.size(), 10u);  // from (1,10)
  expect_poses(file.sequence, 1e-12);          // assembled in SMPL-X order
  EXPECT_TRUE(file.skipped_keys.empty());
}

TEST_F(AmassNumpyTest, SmplhWith156DPosesAndMocapFramerate) {
  const AmassFile file = load_amass_file(path("smplh.npz"));
  EXPECT_EQ(file.sequence.kind, BodyModelKind::SMPLH);
  EXPECT_EQ(file.sequence.poses.cols(), 156);
  EXPECT_EQ(body_model_joint_count(file.sequence.kind), 52);
  EXPECT_EQ(file.sequence.fps, 60.0);
  EXPECT_EQ(file.frame_rate_key, "mocap_framerate");
  EXPECT_EQ(file.sequence.gender, "neutral");  // from a one-element array
  expect_poses(file.sequence, 1e-6);           // stored as float32
  EXPECT_EQ(file.skipped_keys, (std::vector<std::string>{"dmpls", "extra_pickled"}));
}

TEST_F(AmassNumpyTest, Smpl72D) {
  const BodySequence sequence = load_amass(path("smpl.npz"));
  EXPECT_EQ(sequence.kind, BodyModelKind::SMPL);
  EXPECT_EQ(sequence.poses.cols(), 72);
  EXPECT_EQ(sequence.gender, "male");
  EXPECT_EQ(sequence.fps, 30.0);
}

TEST_F(AmassNumpyTest, ResamplingALoadedFileKeepsEveryFourthFrame) {
  const BodySequence source = load_amass(path("walk120.npz"));
  ASSERT_EQ(source.frame_count(), 121);
  const BodySequence target = source.resampled(30);
  ASSERT_EQ(target.frame_count(), 31);
  for (int f = 0; f < target.frame_count(); ++f) EXPECT_EQ(target.poses.row(f), source.poses.row(4 * f));
}

TEST_F(AmassNumpyTest, PickledOrContradictoryPosesAreRejected) {
  for (const auto& [name, problem] : std::map<std::string, std::string>{
           {"bad_pickled_poses.npz", "'poses' is a pickled object array"},
           {"bad_disagreeing_split.npz", "'pose_body' disagrees with columns 3..65 of 'poses' at frame 0"}}) {
    try {
      load_amass(path(name));
      ADD_FAILURE() << name << ": no error";
    } catch (const InputError& error) {
      EXPECT_EQ(error.file(), path(name));
      EXPECT_NE(error.problem().find(problem), std::string::npos) << error.what();
    }
  }
}

TEST_F(AmassNumpyTest, NumpyReadsWhatWriteAmassWrites) {
  BodySequence walk = synthetic_walk(40, 30, BodyModelKind::SMPLX, 2);
  walk.gender = "female";
  const std::string written = path("written_for_numpy.npz");
  write_amass(written, walk);
  EXPECT_EQ(std::system((python_ + " " + script_ + " " + written + " check").c_str()), 0);
}

TEST(AmassTest, RoundTripKeepsEveryValue) {
  for (BodyModelKind kind : {BodyModelKind::SMPLX, BodyModelKind::SMPLH, BodyModelKind::SMPL}) {
    BodySequence walk = synthetic_walk(25, 60, kind, 4);
    walk.betas = {0.1, -0.2, 0.3};
    walk.gender = "male";
    const std::string path = (scratch() / (std::string("round_trip_") + body_model_kind_name(kind) + ".npz")).string();
    write_amass(path, walk);
    const AmassFile file = load_amass_file(path);
    EXPECT_EQ(file.sequence.kind, kind);
    EXPECT_EQ(file.sequence.poses, walk.poses);
    EXPECT_EQ(file.sequence.translations, walk.translations);
    EXPECT_EQ(file.sequence.betas, walk.betas);
    EXPECT_EQ(file.sequence.gender, "male");
    EXPECT_EQ(file.sequence.fps, 60.0);
    EXPECT_TRUE(file.skipped_keys.empty()) << body_model_kind_name(kind);
  }
}

TEST(AmassTest, WriteRejectsInvalidSequencesAndLeavesNoFile) {
  BodySequence walk = synthetic_walk(5, 30, BodyModelKind::SMPLX, 1);
  walk.poses(2, 7) = std::numeric_limits<double>::quiet_NaN();
  const fs::path path = scratch() / "not_written.npz";
  fs::remove(path);
  EXPECT_THROW(write_amass(path.string(), walk), std::invalid_argument);
  EXPECT_FALSE(fs::exists(path));
  EXPECT_THROW(
      write_amass((scratch() / "no_such_dir" / "x.npz").string(), synthetic_walk(5, 30, BodyModelKind::SMPLX, 1)),
      InputError);
}

// --- Bad files, written with the library's own npz writer so they need no python. ---
using Keys = std::map<std::string, NpyArray>;

NpyArray matrix(int rows, int cols, double value = 0.1) {
  return NpyArray::from_float64(std::vector<double>(std::size_t(rows) * cols, value),
                                {std::size_t(rows), std::size_t(cols)});
}

Keys valid_keys() {
  return {{"poses", matrix(12, 165)},
          {"trans", matrix(12, 3)},
          {"betas", NpyArray::from_float64(std::vector<double>(10, 0.0), {10})},
          {"gender", NpyArray::scalar_string("male")},
          {"mocap_frame_rate", NpyArray::scalar_float64(120)}};
}

Keys split_keys() {
  Keys keys = valid_keys();
  keys.erase("poses");
  keys["root_orient"] = matrix(12, 3);
  keys["pose_body"] = matrix(12, 63);
  keys["pose_hand"] = matrix(12, 90);
  keys["pose_jaw"] = matrix(12, 3);
  keys["pose_eye"] = matrix(12, 6);
  return keys;
}

Keys with(Keys keys, const std::string& key, NpyArray array) {
  keys[key] = std::move(array);
  return keys;
}

Keys without(Keys keys, const std::string& key) {
  keys.erase(key);
  return keys;
}

NpyArray with_value(NpyArray array, std::size_t index, double value) {
  std::vector<double> values = array.to_double();
  values[index] = value;
  return NpyArray::from_float64(values, array.shape());
}

TEST(AmassTest, BadInputThrowsInputErrorNamingFileKeyAndShapes) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const std::vector<std::tuple<std::string, Keys, std::string>> cases = {
      {"wrong_width", with(valid_keys(), "poses", matrix(12, 160)),
       "'poses' has shape (12,160), expected (T,165) SMPL-X, (T,156) SMPL-H or (T,72) SMPL"},
      {"one_dimensional_poses",
       with(valid_keys(), "poses", NpyArray::from_float64(std::vector<double>(165, 0.0), {165})),
       "'poses' has shape (165,), expected (T,165)"},
      {"no_frames", with(with(valid_keys(), "poses", matrix(0, 165)), "trans", matrix(0, 3)),
       "'poses' has shape (0,165): no frames"},
      {"frame_count_mismatch", with(valid_keys(), "trans", matrix(10, 3)),
       "'trans' has shape (10,3), expected (T,3) with T=12 (from 'poses')"},
      {"trans_width", with(valid_keys(), "trans", matrix(12, 2)), "'trans' has shape (12,2), expected (T,3) with T=12"},
      {"nan_pose_frame_7", with(valid_keys(), "poses", with_value(matrix(12, 165), 7 * 165 + 12, nan)),
       "'poses' frame 7 holds a non-finite value (column 12)"},
      {"inf_trans_frame_7",
       with(valid_keys(), "trans", with_value(matrix(12, 3), 7 * 3 + 2, -std::numeric_limits<double>::infinity())),
       "'trans' frame 7 holds a non-finite value (column 2)"},
      {"nan_beta",
       with(valid_keys(), "betas", with_value(NpyArray::from_float64(std::vector<double>(10, 0.0), {10}), 3, nan)),
       "'betas' value 3 is not finite"},
      {"missing_trans", without(valid_keys(), "trans"), "missing key 'trans'"},
      {"missing_frame_rate", without(valid_keys(), "mocap_frame_rate"), "missing frame rate"},
      {"zero_frame_rate", with(valid_keys(), "mocap_frame_rate", NpyArray::scalar_float64(0)),
       "'mocap_frame_rate' is 0.000000, expected a positive frame rate"},
      {"disagreeing_frame_rates", with(valid_keys(), "mocap_framerate", NpyArray::scalar_float64(60)),
       "'mocap_frame_rate' (120.000000) and 'mocap_framerate' (60.000000) disagree"},
      {"frame_rate_array", with(valid_keys(), "mocap_frame_rate", matrix(1, 2)),
       "'mocap_frame_rate' has shape (1,2), expected one number"},
      {"no_pose", without(valid_keys(), "poses"), "no pose: neither 'poses' nor the split keys"},
      {"split_missing_hand", without(split_keys(), "pose_hand"), "missing key 'pose_hand'"},
      {"split_frame_mismatch", with(split_keys(), "pose_body", matrix(11, 63)),
       "'pose_body' has shape (11,63), expected (T,63) with T=12 (from 'root_orient')"},
      {"split_nan_frame_7", with(split_keys(), "pose_hand", with_value(matrix(12, 90), 7 * 90, nan)),
       "'pose_hand' frame 7 holds a non-finite value (column 0)"},
      {"numeric_gender", with(valid_keys(), "gender", NpyArray::scalar_float64(1)),
       "'gender' has dtype float64, expected text"},
      {"two_genders",
       with(valid_keys(), "gender", NpyArray::from_strings(std::vector<std::string>{"male", "female"}, {2})),
       "'gender' has shape (2,), expected one string"},
      {"betas_per_frame", with(valid_keys(), "betas", matrix(2, 10)),
       "'betas' has shape (2,10), expected (N,) or (1,N)"},
      {"text_poses", with(valid_keys(), "poses", NpyArray::from_strings(std::vector<std::string>(12, "x"), {12})),
       "'poses' holds text, expected numbers"},
  };
  for (const auto& [name, keys, problem] : cases) {
    const std::string path = (scratch() / ("bad_" + name + ".npz")).string();
    {
      NpzWriter writer(path);
      for (const auto& [key, array] : keys) writer.add(key, array);
      writer.close();
    }
    try {
      load_amass(path);
      ADD_FAILURE() << name << ": no error";
    } catch (const InputError& error) {
      EXPECT_EQ(error.file(), path) << name;
      EXPECT_NE(error.problem().find(problem), std::string::npos) << name << ": " << error.what();
    }
  }
}

TEST(AmassTest, NotAnArchiveOrMissingFileThrowsInputError) {
  const std::string text = (scratch() / "not_a_zip.npz").string();
  std::ofstream(text) << "poses,trans\n1,2\n";
  EXPECT_THROW(load_amass(text), InputError);
  EXPECT_THROW(load_amass((scratch() / "does_not_exist.npz").string()), InputError);
}

}  // namespace
}  // namespace odyssey::io
