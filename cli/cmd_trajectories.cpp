// odyssey trajectories: sampled surface points of a retargeted character, their projections into
// a camera, and the cameras, as the dataset's annotation npz (mocap_io/trajectory_file.h), plus
// optionally the camera path as JSON: a scene of one actor and one camera, run by the library
// pipeline (scene_layouts/pipeline.h) like every other command.
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "cli/actor_options.h"
#include "cli/args.h"
#include "cli/camera_options.h"
#include "cli/commands.h"
#include "cli/retarget_options.h"
#include "scene_layouts/pipeline.h"

namespace odyssey::cli {

int run_trajectories(const std::vector<std::string>& arguments) {
  Args args("trajectories",
            "Retarget a motion onto a character (the options and steps of odyssey retarget: the same command\n"
            "line gives the same motion), sample points on its surface, and write per frame their 3D positions,\n"
            "their pixels in a camera and the camera, as an npz with the dataset's keys: trajs_3d [T,N,3],\n"
            "trajs_2d [T,N,2], valids [T,N] (in front of the camera and inside the image), visibs [T,N] (valid\n"
            "and not hidden by the character's own mesh), visibility_codes [T,N] (0 visible, 1 occluded by an\n"
            "actor, 2 by a prop, 3 outside the image, 4 behind the camera), intrinsics [T,3,3], extrinsics\n"
            "[T,4,4] (world -> camera, OpenCV axes), point_vertex_ids [N,3], point_barycentric [N,3],\n"
            "point_actor_ids [N], fps; float32.\n"
            "\n"
            "Frames are produced and written in chunks: memory does not grow with the clip. A static, orbiting\n"
            "or file camera inside the character (within the box of the tracked points) is an error naming the\n"
            "frame. On any error nothing is written. For several actors, props and cameras: odyssey scene.");
  add_retarget_options(args);
  add_actor_source_options(args);
  args.option("out", "FILE", "output annotation npz (required)")
      .option("points", "N", "surface points to track", "5000")
      .option("seed", "S", "seed of the point sampling", "0")
      .option("sampling", "MODE",
              "surface (uniform over the area, barycentric points) or vertices (distinct mesh vertices)", "surface")
      .option("point-parts", "PARTS", "where points may lie: all, or body (no fingers)", "all")
      .option("camera-path", "FILE", "also write the camera path as JSON (default: none)")
      .option("chunk-frames", "N", "frames per chunk (0: about 16 MiB of output per chunk)", "0")
      .flag("compress", "deflate the npz members (smaller, several times slower to write)");
  add_camera_options(args, "static");
  if (!args.parse(arguments)) return 0;
  if (list_animations_if_asked(args)) return 0;

  scene::Scene scene;
  scene::SceneActor actor = actor_from_options(args);
  const scene::RetargetRequest* motion = std::get_if<scene::RetargetRequest>(&actor.source);
  scene.fps = motion ? motion->fps : args.get_double("fps");
  const long long points = args.get_int("points");
  if (points < 1 || points > 100'000'000) throw UsageError("--points expects 1 to 100000000, got " + args.get("points"));
  actor.points = static_cast<int>(points);
  const long long seed = args.get_int("seed");
  if (seed < 0) throw UsageError("--seed must not be negative");
  scene.seed = static_cast<std::uint64_t>(seed);
  const std::string sampling = args.get("sampling");
  if (sampling != "surface" && sampling != "vertices") {
    throw UsageError("--sampling expects surface or vertices, got '" + sampling + "'");
  }
  actor.sampling = sampling == "surface" ? skinning::SamplingMode::surface : skinning::SamplingMode::vertices;
  const std::string point_parts = args.get("point-parts");
  if (point_parts != "all" && point_parts != "body") throw UsageError("--point-parts expects all or body, got '" + point_parts + "'");
  scene.outputs.body_points_only = point_parts == "body";
  const long long chunk_frames = args.get_int("chunk-frames");
  if (chunk_frames < 0 || chunk_frames > 100000) throw UsageError("--chunk-frames expects 0 to 100000");
  scene.outputs.chunk_frames = static_cast<int>(chunk_frames);
  scene.outputs.threads = motion ? motion->refine_options.threads : thread_count(args);
  scene.outputs.compress = args.get_flag("compress");
  if (args.get("camera") == "none") throw UsageError("trajectories need a camera: --camera static, orbit, ego, file, swoop, dolly-zoom, zoom, realestate10k or colmap");
  scene.cameras.push_back(*camera_from_options(args));
  scene.actors.push_back(std::move(actor));
  scene.outputs.trajectories = {args.get("out")};
  if (const auto camera_path = args.get_optional("camera-path")) scene.outputs.camera_paths = {*camera_path};
  if (!scene.outputs.camera_paths.empty() && std::filesystem::absolute(scene.outputs.camera_paths[0]) == std::filesystem::absolute(scene.outputs.trajectories[0])) {
    throw UsageError("--camera-path and --out name the same file");
  }

  const scene::SceneResult result = scene::run_scene(scene, print_progress);
  const CameraPath& camera = result.cameras[0].path;
  const scene::CameraStreamSummary& seen = result.streams.cameras[0];
  std::printf("camera     %s, %dx%d px, horizontal fov %.4g deg, %d frames\n", camera.kind.c_str(),
              camera.intrinsics[0].width, camera.intrinsics[0].height, camera.intrinsics[0].horizontal_fov_deg(),
              camera.frame_count());
  for (const std::string& line : result.notes) std::printf("note       %s\n", line.c_str());
  std::printf("points     %zu (%s sampling, seed %lld); point-frames: %.1f%% valid, %.1f%% visible\n",
              result.streams.points, sampling.c_str(), seed, 100 * seen.valid_fraction, 100 * seen.visible_fraction);
  std::printf("export     %zu frames in %.3f s (%.0f frames/s: skinning, depth buffer, projection, writing)\n",
              result.streams.frames, result.seconds.streams,
              result.seconds.streams > 0 ? result.streams.frames / result.seconds.streams : 0.0);
  std::printf("timings    %s\n", actor_timings_line(result.actors[0]).c_str());
  std::printf("wrote      %s (%d frames at %.6g fps)%s%s\n", scene.outputs.trajectories[0].c_str(), result.frames,
              result.fps, scene.outputs.camera_paths.empty() ? "" : ", ",
              scene.outputs.camera_paths.empty() ? "" : scene.outputs.camera_paths[0].c_str());
  return 0;
}

}  // namespace odyssey::cli
