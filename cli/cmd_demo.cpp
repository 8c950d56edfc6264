// odyssey demo: the main job on built-in defaults. Generates the synthetic SMPL-X body and a
// synthetic AMASS-style walk, poses the body over the walk (joints and full mesh per frame),
// converts the bundled CMU walk BVH to world joint trajectories, and retargets that walk onto the
// bundled character as an animated GLB (with a camera riding on its head) and its report, tracks
// 5,000 surface points through an orbiting camera (annotation npz) and writes the deformed mesh as
// a PC2 point cache, timing each step. Those steps run the odyssey commands themselves, with the
// command lines printed, so the demo shows what a user types.
#include <chrono>
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
#include "skeleton/body_sequence.h"
#include "skeleton/synthetic_body.h"

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
            "bundled CMU walk BVH as world joint trajectories, then retarget the CMU walk onto the bundled\n"
            "character (odyssey retarget) as an animated GLB with an ego-head camera and its JSON report, track\n"
            "5,000 of its surface points through an orbiting camera (odyssey trajectories) and write its mesh\n"
            "every frame as a PC2 point cache (odyssey point-cache). Everything goes to --out.");
  args.option("out", "DIR", "output folder", "demo-out")
      .option("data", "DIR", "the bundled data folder", ODYSSEY_DATA_DIR)
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

  // The retargeting steps, each run as the odyssey command a user would type, printed first.
  const std::string character = args.get("character");
  const std::string stem = (out / ("cmu_walk_on_" + character)).string();
  const std::vector<std::string> motion_arguments = {
      "--motion", bvh_path, "--bvh-units", "cmu", "--character", (data / "characters" / (character + ".glb")).string(),
      "--quality", args.get("quality"), "--fps", args.get("fps")};
  const auto run_step = [&](const char* label, const char* name, int (*command)(const std::vector<std::string>&),
                            std::vector<std::string> extra, const std::string& output) {
    std::vector<std::string> arguments = motion_arguments;
    arguments.insert(arguments.end(), extra.begin(), extra.end());
    std::string command_line = std::string("odyssey ") + name;
    for (const std::string& argument : arguments) command_line += " " + argument;
    std::printf("\n%s\n", command_line.c_str());
    std::fflush(stdout);
    const Stopwatch watch;
    command(arguments);
    std::printf("%-44s %7.2f s\n", (std::string(label) + " -> " + output).c_str(), watch.seconds());
  };
  run_step("retargeted walk  ", "retarget", run_retarget,
           {"--out", stem + ".glb", "--report", stem + ".report.json", "--camera", "ego", "--camera-path",
            stem + ".ego_camera.json"},
           stem + ".glb");
  run_step("tracked points   ", "trajectories", run_trajectories,
           {"--out", stem + ".trajectories.npz", "--points", "5000", "--camera", "orbit"}, stem + ".trajectories.npz");
  run_step("point cache      ", "point-cache", run_point_cache, {"--out", stem + ".pc2"}, stem + ".pc2");
  return 0;
}

}  // namespace odyssey::cli
