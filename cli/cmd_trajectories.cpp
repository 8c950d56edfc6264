// odyssey trajectories: sampled surface points of a retargeted character, their projections into
// a camera, and the cameras, as the dataset's annotation npz (mocap_io/trajectory_file.h), plus
// optionally the camera path as JSON.
//
// The motion comes from the same options and steps as `odyssey retarget` (cli/retarget_job.h), so
// the same command line gives the same motion. Points are sampled once (seeded), then every frame
// is skinned, projected and written a chunk of frames at a time (scene_layouts/streams.h): memory
// stays flat however long the clip. Outputs are staged under temporary names and renamed together
// at the end; on any error nothing is left behind.
#include <array>
#include <cstdio>
#include <filesystem>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "cli/args.h"
#include "cli/camera_options.h"
#include "cli/commands.h"
#include "cli/retarget_job.h"
#include "cli/staged_file.h"
#include "mocap_io/camera_path_file.h"
#include "mocap_io/input_error.h"
#include "mocap_io/trajectory_file.h"
#include "retarget/canonical.h"
#include "scene_layouts/streams.h"
#include "skinning/sampling.h"

namespace odyssey::cli {
namespace {

// --point-parts body: the regions of every joint but those below the wrists (the fingers); the
// wrist joints keep the palms.
std::optional<skinning::JointSet> point_region(const std::string& parts, const Character& character,
                                               const retarget::BoneMap& full_target_map) {
  if (parts == "all") return std::nullopt;
  if (parts != "body") throw UsageError("--point-parts expects all or body, got '" + parts + "'");
  std::vector<int> wrists;
  for (int canonical : {retarget::canonical::left_wrist, retarget::canonical::right_wrist}) {
    if (full_target_map.mapped(canonical)) wrists.push_back(full_target_map.joints[canonical]);
  }
  return skinning::JointSet::all(character.skeleton) - skinning::JointSet::below(character.skeleton, wrists);
}

}  // namespace

int run_trajectories(const std::vector<std::string>& arguments) {
  Args args("trajectories",
            "Retarget a motion onto a character (the options and steps of odyssey retarget: the same command\n"
            "line gives the same motion), sample points on its surface, and write per frame their 3D positions,\n"
            "their pixels in a camera and the camera, as an npz with the dataset's keys: trajs_3d [T,N,3],\n"
            "trajs_2d [T,N,2], valids [T,N] (in front of the camera and inside the image), visibs [T,N] (valid\n"
            "and not hidden by the character's own mesh, by a depth buffer), intrinsics [T,3,3], extrinsics\n"
            "[T,4,4] (world -> camera, OpenCV axes), point_vertex_ids [N,3], point_barycentric [N,3],\n"
            "point_actor_ids [N], fps; float32.\n"
            "\n"
            "Frames are produced and written in chunks: memory does not grow with the clip. A static, orbiting\n"
            "or file camera inside the character (within the box of the tracked points) is an error naming the\n"
            "frame. On any error nothing is written.");
  add_retarget_options(args);
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

  const RetargetSettings settings = retarget_settings(args);
  const std::string out_path = args.get("out");
  const std::optional<std::string> camera_json_path = args.get_optional("camera-path");
  if (camera_json_path && std::filesystem::absolute(*camera_json_path) == std::filesystem::absolute(out_path)) {
    throw UsageError("--camera-path and --out name the same file");
  }
  const long long points = args.get_int("points");
  if (points < 1 || points > 100'000'000) throw UsageError("--points expects 1 to 100000000, got " + args.get("points"));
  const long long seed = args.get_int("seed");
  if (seed < 0) throw UsageError("--seed must not be negative");
  const std::string sampling = args.get("sampling");
  if (sampling != "surface" && sampling != "vertices") {
    throw UsageError("--sampling expects surface or vertices, got '" + sampling + "'");
  }
  const long long chunk_frames = args.get_int("chunk-frames");
  if (chunk_frames < 0 || chunk_frames > 100000) throw UsageError("--chunk-frames expects 0 to 100000");
  if (args.get("camera") == "none") throw UsageError("trajectories need a camera: --camera static, orbit, ego or file");

  RetargetJob job = run_retarget_job(settings);
  const Clip& clip = job.clip();

  const std::optional<CameraPath> camera = camera_path_from_options(args, job.character, job.target_map, clip);
  std::printf("camera     %s, %dx%d px, horizontal fov %.4g deg, %d frames\n", camera->kind.c_str(),
              camera->intrinsics[0].width, camera->intrinsics[0].height, camera->intrinsics[0].horizontal_fov_deg(),
              camera->frame_count());

  skinning::SamplingOptions sampling_options;
  sampling_options.mode = sampling == "surface" ? skinning::SamplingMode::surface : skinning::SamplingMode::vertices;
  sampling_options.count = static_cast<int>(points);
  sampling_options.seed = static_cast<std::uint64_t>(seed);
  sampling_options.region = point_region(args.get("point-parts"), job.character, job.full_target_map);
  std::vector<skinning::SurfacePoint> samples;
  try {
    samples = skinning::sample_surface_points(job.character, sampling_options);
  } catch (const std::invalid_argument& error) {
    throw io::InputError(settings.character_path, std::string("cannot sample points: ") + error.what());
  }

  StagedFile npz(out_path);
  std::optional<StagedFile> camera_json;
  {
    io::TrajectoryFileWriter writer(npz.temp(),
                                    scene::trajectory_file_header(job.character, samples, clip.frame_count(), clip.fps),
                                    args.get_flag("compress"));
    scene::StreamOptions stream_options;
    stream_options.chunk_frames = static_cast<int>(chunk_frames);
    stream_options.threads = settings.refine_options.threads;
    stream_options.reject_camera_inside = camera->kind != "ego-head";
    const scene::TrajectoryExportSummary summary =
        scene::export_trajectories(job.character, clip, samples, *camera, writer, stream_options);
    writer.close();
    std::printf("points     %zu (%s sampling, seed %lld), %zu corner vertices skinned per frame; point-frames: "
                "%.1f%% valid, %.1f%% visible\n",
                summary.points, sampling.c_str(), seed, summary.skinned_vertices, 100 * summary.valid_fraction,
                100 * summary.visible_fraction);
    std::printf("export     %zu frames in %.3f s (%.0f frames/s: skinning, depth buffer, projection, writing)\n",
                summary.frames,
                summary.seconds, summary.seconds > 0 ? summary.frames / summary.seconds : 0.0);
  }
  if (camera_json_path) {
    camera_json.emplace(*camera_json_path);
    io::write_camera_path_json(camera_json->temp(), *camera);
  }
  std::vector<StagedFile*> outputs{&npz};
  if (camera_json) outputs.push_back(&*camera_json);
  commit_all(outputs);
  std::printf("timings    %s\n", retarget_job_timings(job).c_str());
  std::printf("wrote      %s (%d frames at %.6g fps)%s%s\n", out_path.c_str(), clip.frame_count(), clip.fps,
              camera_json_path ? ", " : "", camera_json_path ? camera_json_path->c_str() : "");
  return 0;
}

}  // namespace odyssey::cli
