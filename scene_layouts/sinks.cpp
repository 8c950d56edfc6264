#include "scene_layouts/sinks.h"

#include <filesystem>

#include "mocap_io/camera_path_file.h"
#include "mocap_io/gltf_export.h"
#include "mocap_io/input_error.h"
#include "mocap_io/scene_glb.h"
#include "scene_layouts/pipeline.h"

namespace odyssey::scene {

TrajectorySink::TrajectorySink(int camera, const std::string& path, const io::TrajectoryFileHeader& header, bool compress,
                               io::StagedOutputs& staged)
    : camera_(camera), path_(path), writer_(staged.stage(path), header, compress) {}

void TrajectorySink::write(const FrameChunk& chunk) {
  const CameraChunk& c = chunk.cameras[camera_];
  writer_.append_frames(chunk.count, chunk.trajs_3d, c.trajs_2d, c.valids, c.visibs, c.intrinsics, c.extrinsics,
                        c.visibility_codes);
}

void TrajectorySink::finish(const SceneResult&) { writer_.close(); }

PointCacheSink::PointCacheSink(int actor, const Character& character, const std::string& character_source,
                               std::size_t frames, const std::string& path, const std::string& obj_path,
                               io::StagedOutputs& staged)
    : actor_(actor), path_(path), obj_path_(obj_path) {
  std::size_t vertices = 0;
  for (const CharacterMesh& mesh : character.meshes) vertices += mesh.positions.size();
  if (vertices == 0) throw io::InputError(character_source, "the character has no mesh to cache");
  io::write_rest_obj(staged.stage(obj_path), character);
  writer_ = std::make_unique<io::Pc2Writer>(staged.stage(path), vertices, frames);
}

void PointCacheSink::write(const FrameChunk& chunk) {
  writer_->append_frames(chunk.count, actor_ >= 0 ? chunk.actor_vertices[actor_] : chunk.prop_vertices);
}

void PointCacheSink::finish(const SceneResult&) { writer_->close(); }

void CameraPathSink::finish(const SceneResult& result) { io::write_camera_path_json(staged_, result.cameras.at(camera_).path); }

void CharacterGlbSink::finish(const SceneResult& result) {
  const RetargetedActor& actor = *result.actors.at(0).retargeted;
  io::GlbExportOptions options;
  options.animation_name = std::filesystem::path(actor.request.motion_path).stem().string();
  if (!result.cameras.empty()) {
    options.camera = &result.cameras[0].path;
    options.camera_name = result.cameras[0].name;
  }
  io::write_animated_glb(actor.request.character_path, actor.character, result.actors[0].clip.stored_clip(), staged_, options);
}

void SceneGlbSink::finish(const SceneResult& result) {
  // The file holds every frame of every actor, so their clips are stored whole here, for it.
  std::vector<Clip> clips;
  std::vector<MeshAnimation> vertices;
  clips.reserve(result.actors.size());
  vertices.reserve(result.actors.size());
  for (const PlacedActor& actor : result.actors) {
    clips.push_back(actor.clip.stored_clip());
    vertices.push_back(actor.clip.vertex_animated() ? actor.clip.stored_vertices() : MeshAnimation{});
  }
  std::vector<io::SceneGlbActor> actors;
  for (std::size_t a = 0; a < result.actors.size(); ++a) {
    const PlacedActor& actor = result.actors[a];
    actors.push_back({actor.name, &actor.motion->character, &clips[a], actor.clip.vertex_animated() ? &vertices[a] : nullptr});
  }
  std::vector<io::SceneGlbCamera> cameras;
  for (const ShotCamera& camera : result.cameras) {
    // An ego camera does not see its wearer's head (frame_loop.h); the GLB says so for renderers.
    const int head = camera.rides_on >= 0 ? result.actors.at(camera.rides_on).motion->head_joint : -1;
    cameras.push_back({camera.name, &camera.path, head >= 0 ? camera.rides_on : -1, head});
  }
  io::write_scene_glb(staged_, actors, result.props.names.empty() ? nullptr : &result.props.character, cameras, result.fps,
                      result.props.motion);
}

void ActorReportSink::finish(const SceneResult& result) {
  nlohmann::ordered_json json = actor_motion_report_json(*result.actors.at(actor_).motion);
  // Relative to the report's folder, so the pair can move together (a batch builds them in a
  // staging folder and renames it) and a report does not depend on where the run wrote.
  namespace fs = std::filesystem;
  json["inputs"]["output"] = nullptr;
  if (!glb_.empty()) {
    const fs::path report_folder = fs::absolute(path_).parent_path().lexically_normal();
    json["inputs"]["output"] = fs::absolute(glb_).lexically_normal().lexically_relative(report_folder).generic_string();
  }
  json["settings"]["camera"] = result.cameras.empty() ? nlohmann::ordered_json() : nlohmann::ordered_json(result.cameras[0].path.kind);
  json["timings_s"]["command"]["write_outputs"] = result.seconds.streams;
  json["timings_s"]["command"]["total"] = result.seconds.total;
  io::write_file_atomically(staged_, json.dump(2) + "\n");
}

void SceneReportSink::finish(const SceneResult& result) {
  io::write_file_atomically(staged_, scene_report_json(result).dump(2) + "\n");
}

}  // namespace odyssey::scene
