// The staged API (shot.h, frame_loop.h, sinks.h, pipeline.h): a shot run through the stages in a
// loop of the test's own, with another chunk size, gives exactly the arrays run_scene writes; a
// new output format is one sink class, run beside the built-in ones; the retarget stage at each
// quality gives what its two steps give.
#include <gtest/gtest.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "mocap_io/bvh.h"
#include "mocap_io/gltf_character.h"
#include "mocap_io/npy.h"
#include "mocap_io/output_file.h"
#include "retarget/bone_map.h"
#include "retarget/parts.h"
#include "retarget/quality.h"
#include "scene_layouts/frame_loop.h"
#include "scene_layouts/pipeline.h"
#include "scene_layouts/shot.h"
#include "scene_support.h"
#include "test_support.h"

namespace odyssey {
namespace {

namespace fs = std::filesystem;

fs::path scratch(const std::string& name) {
  const fs::path dir = test_support::scratch_root() / "stages";
  fs::create_directories(dir);
  return dir / name;
}

// Two walkers, a box in the room with points on it, an orbiting and a static camera.
scene::Scene two_walkers_and_a_box() {
  scene::Scene shot;
  shot.name = "stages";
  shot.seconds = 2;
  shot.seed = 5;
  shot.actors = {test_support::walker("figure", test_support::kSceneFigure, -0.8, 0, 90),
                 test_support::walker("cesium", test_support::kSceneCesium, 0.8, 0.3, 90)};
  scene::Prop box;
  box.name = "box";
  box.size = Eigen::Vector3d(0.6, 0.6, 0.8);
  box.position = Eigen::Vector3d(0, 1.5, 0);
  shot.props = {box};
  scene::SceneCamera orbit;
  orbit.name = "orbit";
  orbit.rig = scene::OrbitRig{.period_s = 2};
  scene::SceneCamera fixed;
  fixed.name = "front";
  fixed.width = 320;
  fixed.height = 240;
  shot.cameras = {orbit, fixed};
  shot.outputs.points_per_actor = 300;
  shot.outputs.prop_points = 200;
  return shot;
}

// One camera's arrays over the whole shot, as the test's own loop gathers them.
struct CameraArrays {
  std::vector<float> trajs_2d;
  std::vector<std::uint8_t> valids, visibs, codes;
};

// Whether two clips hold the same rotations, bit for bit.
bool same_rotations(const Clip& a, const Clip& b) {
  if (a.rotations.size() != b.rotations.size()) return false;
  for (std::size_t i = 0; i < a.rotations.size(); ++i) {
    if (a.rotations[i].coeffs() != b.rotations[i].coeffs()) return false;
  }
  return true;
}

std::vector<std::uint8_t> as_bytes(const io::NpyArray& array) {
  const std::vector<double> values = array.to_double();
  return std::vector<std::uint8_t>(values.begin(), values.end());
}

TEST(StagesTest, OwnFrameLoopGivesRunScenesArrays) {
  scene::Scene shot = two_walkers_and_a_box();
  scene::OutputSelection which;
  which.report = false;
  which.camera_paths = false;
  scene::set_outputs_in_folder(shot, scratch("run_scene").string(), which);
  fs::create_directories(scratch("run_scene"));
  const scene::SceneResult result = scene::run_scene(shot);

  const scene::Shot prepared = scene::prepare_shot(shot);
  ASSERT_EQ(prepared.frames, result.frames);
  const std::vector<scene::StreamActor> actors = scene::stream_actors(prepared);
  const std::vector<scene::StreamCamera> cameras = scene::stream_cameras(prepared);
  scene::StreamOptions options;
  options.chunk_frames = 7;  // not run_scene's chunk: the results may not depend on it
  scene::FrameLoop loop(actors, scene::stream_props(prepared), cameras, options);
  const std::size_t n = loop.point_count();
  ASSERT_EQ(n, 2 * 300 + 200u);
  std::vector<float> trajs_3d;
  std::vector<CameraArrays> arrays(cameras.size());
  long frames_seen = 0, visible_on_their_owner = 0, visible = 0;
  for (int first = 0; first < loop.frame_count(); first += loop.chunk_frames()) {
    const int count = std::min(loop.chunk_frames(), loop.frame_count() - first);
    loop.pose(first, count);
    loop.skin();
    for (std::size_t c = 0; c < cameras.size(); ++c) {
      loop.classify(c, [&](const scene::CameraFrame& frame) {
        ++frames_seen;
        // A visible actor point has a pixel of its own actor within one pixel of it (points are
        // numbered actor after actor, 300 each): the pixel holding it is sampled at its centre,
        // up to 0.7 px away, and on a silhouette may show what lies behind.
        for (std::size_t i = 0; i < 600; ++i) {
          if (frame.codes[i] != io::kVisible) continue;
          ++visible;
          const int x = static_cast<int>(frame.uv[2 * i]), y = static_cast<int>(frame.uv[2 * i + 1]);
          bool found = false;
          for (int dy = -1; dy <= 1; ++dy) {
            for (int dx = -1; dx <= 1; ++dx) {
              const std::uint32_t t = frame.depth->triangle_at(x + dx, y + dy);
              found |= t != 0xffffffff && frame.owner(t) == static_cast<int>(i / 300);
            }
          }
          visible_on_their_owner += found;
        }
      });
    }
    const scene::FrameChunk chunk = loop.chunk();
    EXPECT_EQ(chunk.first, first);
    trajs_3d.insert(trajs_3d.end(), chunk.trajs_3d.begin(), chunk.trajs_3d.end());
    for (std::size_t c = 0; c < cameras.size(); ++c) {
      const scene::CameraChunk& from = chunk.cameras[c];
      arrays[c].trajs_2d.insert(arrays[c].trajs_2d.end(), from.trajs_2d.begin(), from.trajs_2d.end());
      arrays[c].valids.insert(arrays[c].valids.end(), from.valids.begin(), from.valids.end());
      arrays[c].visibs.insert(arrays[c].visibs.end(), from.visibs.begin(), from.visibs.end());
      arrays[c].codes.insert(arrays[c].codes.end(), from.visibility_codes.begin(), from.visibility_codes.end());
    }
  }
  EXPECT_EQ(frames_seen, static_cast<long>(cameras.size()) * prepared.frames);
  ASSERT_GT(visible, 1000);
  EXPECT_GT(static_cast<double>(visible_on_their_owner) / visible, 0.995);

  for (std::size_t c = 0; c < cameras.size(); ++c) {
    const io::NpzReader file(scratch("run_scene/trajectories_" + prepared.cameras[c].name + ".npz").string());
    EXPECT_EQ(file.load("trajs_3d").to_float(), trajs_3d) << prepared.cameras[c].name;
    EXPECT_EQ(file.load("trajs_2d").to_float(), arrays[c].trajs_2d) << prepared.cameras[c].name;
    EXPECT_EQ(as_bytes(file.load("valids")), arrays[c].valids) << prepared.cameras[c].name;
    EXPECT_EQ(as_bytes(file.load("visibs")), arrays[c].visibs) << prepared.cameras[c].name;
    EXPECT_EQ(as_bytes(file.load("visibility_codes")), arrays[c].codes) << prepared.cameras[c].name;
  }
  const scene::StreamSummary summary = loop.summary();
  for (std::size_t c = 0; c < cameras.size(); ++c) {
    EXPECT_EQ(summary.cameras[c].visible_fraction, result.streams.cameras[c].visible_fraction);
    EXPECT_EQ(summary.cameras[c].actor_frames_culled, result.streams.cameras[c].actor_frames_culled);
  }
  EXPECT_EQ(summary.actor_mesh_frames, result.streams.actor_mesh_frames);
}

// An output format of the test's own: per camera-frame, the count of visible points, as CSV.
class VisibleCountsSink : public scene::StreamSink {
 public:
  VisibleCountsSink(std::string path, io::StagedOutputs& staged) : path_(std::move(path)), staged_(staged.stage(path_)) {}
  void camera_frame(const scene::CameraFrame& frame) override {
    long count = 0;
    for (const std::uint8_t code : frame.codes) count += code == io::kVisible;
    lines_ << frame.frame << ',' << frame.camera << ',' << count << '\n';
  }
  void finish(const scene::SceneResult&) override { io::write_file_atomically(staged_, "frame,camera,visible\n" + lines_.str()); }
  std::vector<std::string> files() const override { return {path_}; }

 private:
  std::string path_, staged_;
  std::ostringstream lines_;
};

TEST(StagesTest, AnOutputFormatIsOneSink) {
  scene::Scene shot = two_walkers_and_a_box();
  scene::OutputSelection which;
  scene::set_outputs_in_folder(shot, scratch("own_sink").string(), which);
  fs::create_directories(scratch("own_sink"));
  const std::string csv = scratch("own_sink/visible.csv").string();
  fs::remove(csv);

  scene::PrepareOptions prepare;
  prepare.sample_points = scene::tracks_points(shot.outputs);
  scene::Shot prepared = scene::prepare_shot(shot, prepare);
  io::StagedOutputs staged;
  std::vector<std::unique_ptr<scene::StreamSink>> sinks = scene::open_sinks(shot, prepared, staged);
  sinks.push_back(std::make_unique<VisibleCountsSink>(csv, staged));
  const scene::SceneResult result = scene::run_sinks(std::move(prepared), shot, sinks);
  EXPECT_FALSE(fs::exists(csv)) << "written before the commit";
  staged.commit();

  // Every camera-frame once, and each count is the trajectory file's.
  std::ifstream in(csv);
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line, "frame,camera,visible");
  std::vector<std::vector<long>> counts(result.cameras.size(), std::vector<long>(result.frames, -1));
  int frame = 0, camera = 0;
  long count = 0;
  char comma = 0;
  while (in >> frame >> comma >> camera >> comma >> count) counts.at(camera).at(frame) = count;
  for (std::size_t c = 0; c < result.cameras.size(); ++c) {
    const io::NpzReader file(scratch("own_sink/trajectories_" + result.cameras[c].name + ".npz").string());
    const std::vector<double> visibs = file.load("visibs").to_double();
    const std::size_t n = result.streams.points;
    for (int f = 0; f < result.frames; ++f) {
      long expected = 0;
      for (std::size_t i = 0; i < n; ++i) expected += visibs[f * n + i] != 0;
      ASSERT_EQ(counts[c][f], expected) << "camera " << c << " frame " << f;
    }
  }
  // The scene's report lists it among the outputs.
  EXPECT_NE(std::find(result.outputs.begin(), result.outputs.end(), csv), result.outputs.end());
}

TEST(StagesTest, RetargetStageIsFastThenRefine) {
  const std::string bvh = test_support::kSceneWalk;
  const Clip source = io::load_bvh(bvh, io::BvhOptions{io::kCmuMetresPerUnit}).resampled(30);
  const Character figure = io::load_character(test_support::kSceneFigure);
  const retarget::BoneMap source_map =
      retarget::restrict_bone_map(retarget::humanoid_bone_map(source.skeleton, bvh, ""), retarget::Parts::body);
  const retarget::BoneMap target_map =
      retarget::restrict_bone_map(retarget::humanoid_bone_map(figure.skeleton, "figure", ""), retarget::Parts::body);

  const retarget::Retargeting fast = retarget::retarget(source, source_map, figure, target_map, retarget::Quality::fast);
  EXPECT_FALSE(fast.refined);
  retarget::RetargetResult by_hand = retarget::retarget_fast(source, source_map, figure, target_map);
  EXPECT_TRUE(same_rotations(fast.result.transfer.clip, by_hand.transfer.clip));

  const retarget::Retargeting balanced = retarget::retarget(source, source_map, figure, target_map, retarget::Quality::balanced);
  ASSERT_TRUE(balanced.refined);
  retarget::refine(by_hand, source, retarget::default_refine_options(retarget::Quality::balanced));
  EXPECT_TRUE(same_rotations(balanced.result.transfer.clip, by_hand.transfer.clip));
  EXPECT_EQ(balanced.result.report.quality, "balanced");

  const std::string wrong = test_support::message_of<std::invalid_argument>([&] {
    retarget::retarget(source, source_map, figure, target_map, retarget::Quality::accurate, {},
                       retarget::default_refine_options(retarget::Quality::balanced));
  });
  EXPECT_TRUE(test_support::contains(wrong, "the refinement options are balanced's, the request asks for accurate")) << wrong;
}

}  // namespace
}  // namespace odyssey
