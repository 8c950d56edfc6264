// odyssey demo: the main job on built-in defaults. Generates the synthetic SMPL-X body and a
// synthetic AMASS-style walk, poses the body over the walk (joints and full mesh per frame),
// converts the bundled CMU walk BVH to world joint trajectories, retargets that walk once onto the
// bundled character and writes from it an animated GLB (with a camera riding on its head), its
// report, 5,000 surface points tracked through an orbiting camera (annotation npz) and the
// deformed mesh as a PC2 point cache, then runs the bundled indoor and outdoor scenes (odyssey
// scene) and makes a two-sequence dataset from the example recipe (odyssey dataset), timing each
// step.
#include <chrono>
#include <cstdlib>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "cli/args.h"
#include "cli/commands.h"
#include "mocap_io/amass.h"
#include "mocap_io/body_model_file.h"
#include "mocap_io/body_model_writer.h"
#include "mocap_io/bvh.h"
#include "mocap_io/pose_export.h"
#include "scene_layouts/pipeline.h"
#include "scene_layouts/scene_file.h"
#include "skeleton/body_sequence.h"
#include "synthetic/synthetic_body.h"
#include "synthetic/synthetic_walk.h"

namespace odyssey::cli {
namespace {

class Stopwatch {
 public:
  double seconds() const { return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count(); }

 private:
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
};

}  // namespace

int run_demo(const std::vector<std::string>& arguments) {
  Args args("demo",
            "Run the main job on the bundled defaults: write the synthetic SMPL-X body model, a synthetic\n"
            "AMASS-style SMPL-X walk, the body posed over the walk (joints and vertices per frame), and the\n"
            "bundled CMU walk BVH as world joint trajectories, then retarget the CMU walk once onto the bundled\n"
            "character and write an animated GLB with an ego-head camera, its JSON report, 5,000 of its surface\n"
            "points tracked through an orbiting camera and its mesh every frame as a PC2 point cache, and run\n"
            "the bundled indoor scene (two people, furniture, three cameras: odyssey scene) and the outdoor one\n"
            "(walkers and a fox kicking scattered props), and make a two-sequence dataset from the example\n"
            "recipe (odyssey dataset). Everything goes to --out.");
  args.option("out", "DIR", "output folder", "demo-out")
      .option("data", "DIR", "the bundled data folder", scene::bundled_data_folder())
      .option("seconds", "S", "length of the synthetic walk", "4")
      .option("fps", "FPS", "output frame rate", "30")
      .option("character", "NAME", "the bundled character to retarget onto (DATA/characters/NAME.glb)", "RiggedFigure")
      .option("quality", "Q", "retargeting quality: fast, balanced or accurate", "balanced");
  if (!args.parse(arguments)) return 0;
  const std::filesystem::path out = args.get("out");
  const std::filesystem::path data = args.get("data");
  const double fps = args.get_double("fps");
  const double seconds = args.get_double("seconds");
  if (!(fps > 0) || !(seconds > 0)) throw UsageError("--fps and --seconds must be positive");
  std::filesystem::create_directories(out);

  Stopwatch step;
  const std::string body_path = (out / "body.npz").string();
  io::write_body_model(body_path, make_synthetic_body(0));
  std::printf("%-44s %7.2f s\n", ("body model        -> " + body_path).c_str(), step.seconds());

  step = Stopwatch();
  const std::string walk_path = (out / "walk_smplx.npz").string();
  const int frames = static_cast<int>(seconds * fps) + 1;
  io::write_amass(walk_path, synthetic_walk(frames, fps, BodyModelKind::SMPLX, 0));
  std::printf("%-44s %7.2f s\n", ("synthetic walk    -> " + walk_path).c_str(), step.seconds());

  step = Stopwatch();
  const std::string posed_path = (out / "walk_posed.npz").string();
  const BodyModel model = io::load_body_model(body_path);
  const BodySequence walk = io::load_amass_file(walk_path).sequence;
  io::export_body_poses(model, walk, BodyModelOptions{}, false, posed_path);
  const double pose_seconds = step.seconds();
  std::printf("%-44s %7.2f s  (%d frames, %.0f frames/s incl. load and write)\n",
              ("posed mesh        -> " + posed_path).c_str(), pose_seconds, walk.frame_count(),
              walk.frame_count() / pose_seconds);

  step = Stopwatch();
  const std::string bvh_path = (data / "mocap" / "cmu_walk_cgspeed.bvh").string();
  const std::string bvh_out = (out / "cmu_walk_joints.npz").string();
  const Clip clip = io::load_bvh(bvh_path, io::BvhOptions{io::kCmuMetresPerUnit}).resampled(fps);
  io::export_clip_joints(clip, bvh_out);
  std::printf("%-44s %7.2f s  (%d frames, %d joints)\n", ("CMU walk joints   -> " + bvh_out).c_str(), step.seconds(),
              clip.frame_count(), clip.joint_count());

  // One scene of the bundled character walking, retargeted once, written as every output a
  // single actor has: the animated GLB with a camera on its head, its report, the head camera's
  // path, 5,000 tracked points seen by an orbiting camera, and its mesh as a point cache.
  step = Stopwatch();
  const std::string character = args.get("character");
  const std::string stem = (out / ("cmu_walk_on_" + character)).string();
  const auto quality = retarget::parse_quality(args.get("quality"));
  if (!quality) throw UsageError("--quality expects fast, balanced or accurate, got '" + args.get("quality") + "'");
  scene::Scene walk_scene;
  walk_scene.name = "cmu_walk_on_" + character;
  walk_scene.fps = fps;
  scene::SceneActor actor;
  actor.name = character;
  scene::RetargetRequest request = scene::retarget_request(bvh_path, (data / "characters" / (character + ".glb")).string(), *quality);
  request.fps = fps;
  request.bvh_metres_per_unit = io::kCmuMetresPerUnit;
  actor.source = std::move(request);
  walk_scene.actors.push_back(actor);
  scene::SceneCamera ego;
  ego.rig = scene::EgoRig{};
  ego.name = "ego";
  scene::SceneCamera orbit;
  orbit.rig = scene::OrbitRig{};
  orbit.name = "orbit";
  walk_scene.cameras = {ego, orbit};
  scene::SceneOutputs& outputs = walk_scene.outputs;
  outputs.glb = stem + ".glb";
  outputs.actor_reports = {stem + ".report.json"};
  outputs.camera_paths = {stem + ".ego_camera.json", ""};
  outputs.trajectories = {"", stem + ".trajectories.npz"};
  outputs.point_caches = {stem + ".pc2"};
  outputs.points_per_actor = 5000;
  const scene::SceneResult walked = scene::run_scene(walk_scene);
  std::printf("%-44s %7.2f s  (%d frames, quality %s, retargeted once)\n", ("CMU walk outputs  -> " + stem + ".*").c_str(),
              step.seconds(), walked.frames, args.get("quality").c_str());
  for (const std::string& file : walked.outputs) std::printf("    %s\n", file.c_str());

  // The indoor example scene: two people among furniture, an ego camera on one looking at the
  // other, an orbit and a static camera.
  step = Stopwatch();
  // Its "data:" paths name files of this run's data folder.
  ::setenv("ODYSSEY_DATA_DIR", data.c_str(), 1);
  const std::filesystem::path scene_path = data / "scenes" / "indoor.json";
  const std::filesystem::path scene_out = out / "scene_indoor";
  std::printf("\nodyssey scene %s --out %s\n", scene_path.c_str(), scene_out.c_str());
  std::fflush(stdout);
  run_scene({scene_path.string(), "--out", scene_out.string(), "--quiet"});
  std::printf("%-44s %7.2f s\n", ("indoor scene      -> " + scene_out.string()).c_str(), step.seconds());

  // The outdoor example: walkers and a fox among scattered props that they and seeded forces kick
  // (Bullet), whose contact sheets show the props move.
  step = Stopwatch();
  const std::filesystem::path outdoor_path = data / "scenes" / "outdoor.json";
  const std::filesystem::path outdoor_out = out / "scene_outdoor";
  std::printf("\nodyssey scene %s --out %s\n", outdoor_path.c_str(), outdoor_out.c_str());
  std::fflush(stdout);
  run_scene({outdoor_path.string(), "--out", outdoor_out.string(), "--quiet"});
  std::printf("%-44s %7.2f s\n", ("outdoor scene     -> " + outdoor_out.string()).c_str(), step.seconds());

  // A two-sequence dataset from the bundled example recipe (odyssey dataset): drawn shots written
  // as PointOdyssey sequences in their splits, with the manifest.
  step = Stopwatch();
  const std::filesystem::path recipe_path = data / "datasets" / "example.json";
  const std::filesystem::path dataset_out = out / "dataset";
  std::printf("\nodyssey dataset %s --count 2 --out %s\n", recipe_path.c_str(), dataset_out.c_str());
  std::fflush(stdout);
  const int made = run_dataset({recipe_path.string(), "--count", "2", "--out", dataset_out.string(), "--quiet"});
  std::printf("%-44s %7.2f s\n", ("example dataset   -> " + dataset_out.string()).c_str(), step.seconds());
  return made;
}

}  // namespace odyssey::cli
