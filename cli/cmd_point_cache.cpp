// odyssey point-cache: the full deformed mesh of a retargeted character every frame, as a PC2
// point cache (Blender's Mesh Cache modifier) with the rest mesh as OBJ beside it, so the vertex
// order is unambiguous: vertices across the character's meshes in order, in the toolkit's world
// frame (Z up, metres). The motion comes from the options and steps of `odyssey retarget`.
// Frames are skinned and written a chunk at a time; both files appear together or not at all.
#include <cstdio>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "cli/args.h"
#include "cli/commands.h"
#include "cli/retarget_job.h"
#include "cli/staged_file.h"
#include "mocap_io/point_cache.h"
#include "scene_layouts/streams.h"

namespace odyssey::cli {

int run_point_cache(const std::vector<std::string>& arguments) {
  Args args("point-cache",
            "Retarget a motion onto a character (the options and steps of odyssey retarget) and write its\n"
            "deformed mesh every frame as a PC2 point cache, with the rest mesh as a Wavefront OBJ whose\n"
            "vertex order the cache follows (all meshes in order; world frame, Z up, metres: in Blender import\n"
            "the OBJ with Z up and Y forward and give the Mesh Cache modifier the same axes). Frames are\n"
            "skinned and written in chunks: memory does not grow with the clip.");
  add_retarget_options(args);
  args.option("out", "FILE", "output PC2 point cache (required)")
      .option("obj", "FILE", "the rest mesh (default: the --out path with .obj)");
  if (!args.parse(arguments)) return 0;

  const RetargetSettings settings = retarget_settings(args);
  const std::string out_path = args.get("out");
  const std::string obj_path =
      args.get_optional("obj").value_or(std::filesystem::path(out_path).replace_extension(".obj").string());
  if (std::filesystem::absolute(obj_path) == std::filesystem::absolute(out_path)) {
    throw UsageError("--obj and --out name the same file");
  }

  RetargetJob job = run_retarget_job(settings);
  const Clip& clip = job.clip();
  std::size_t vertices = 0;
  for (const CharacterMesh& mesh : job.character.meshes) vertices += mesh.positions.size();
  if (vertices == 0) throw io::InputError(settings.character_path, "the character has no mesh to cache");

  StagedFile pc2(out_path), obj(obj_path);
  io::write_rest_obj(obj.temp(), job.character);
  io::Pc2Writer writer(pc2.temp(), vertices, static_cast<std::size_t>(clip.frame_count()));
  scene::StreamOptions options;
  options.threads = settings.refine_options.threads;
  const scene::PointCacheSummary summary = scene::export_point_cache(job.character, clip, writer, options);
  writer.close();
  commit_all({&pc2, &obj});
  std::printf("cache      %zu vertices x %zu frames in %.3f s (%.0f frames/s, %.3g vertex-frames/s: skinning and writing)\n",
              summary.vertices, summary.frames, summary.seconds, summary.seconds > 0 ? summary.frames / summary.seconds : 0.0,
              summary.seconds > 0 ? summary.vertices * summary.frames / summary.seconds : 0.0);
  std::printf("timings    %s\n", retarget_job_timings(job).c_str());
  std::printf("wrote      %s (%d frames at %.6g fps), %s\n", out_path.c_str(), clip.frame_count(), clip.fps,
              obj_path.c_str());
  return 0;
}

}  // namespace odyssey::cli
