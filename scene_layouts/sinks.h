// The outputs of a shot, one sink each behind StreamSink (frame_loop.h). Every sink is given its
// final path and stages it in the run's io::StagedOutputs, writes only under the staged name, and
// lists the final names in files(); run_scene commits the set when every sink has finished, so a
// shot's outputs appear together or not at all. Sinks that stream (trajectories, point caches,
// contact sheets: preview.h) take frames from write() and camera_frame(); the others (camera
// paths, GLBs, reports) write at finish() from the shot's result. A new output format is one sink
// and one line in open_sinks (pipeline.cpp).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "mocap_io/output_file.h"
#include "mocap_io/point_cache.h"
#include "mocap_io/trajectory_file.h"
#include "scene_layouts/frame_loop.h"

namespace odyssey::scene {

// Trajectories of every point in camera `camera`: the dataset's keys and this toolkit's
// (mocap_io/trajectory_file.h).
class TrajectorySink : public StreamSink {
 public:
  TrajectorySink(int camera, const std::string& path, const io::TrajectoryFileHeader& header, bool compress,
                 io::StagedOutputs& staged);
  void write(const FrameChunk& chunk) override;
  void finish(const SceneResult&) override;
  std::vector<std::string> files() const override { return {path_}; }

 private:
  int camera_;
  std::string path_;
  io::TrajectoryFileWriter writer_;
};

// The whole mesh of actor `actor` (or, for actor -1, of the props character, where the props are
// each frame: FrameChunk::prop_vertices) every frame as PC2, with its rest OBJ (which fixes the
// vertex order) at `obj_path`. Throws io::InputError naming `character_source` when the character
// has no mesh.
class PointCacheSink : public StreamSink {
 public:
  PointCacheSink(int actor, const Character& character, const std::string& character_source, std::size_t frames,
                 const std::string& path, const std::string& obj_path, io::StagedOutputs& staged);
  void write(const FrameChunk& chunk) override;
  void finish(const SceneResult&) override;
  std::vector<std::string> files() const override { return {path_, obj_path_}; }

 private:
  int actor_;
  std::string path_, obj_path_;
  std::unique_ptr<io::Pc2Writer> writer_;
};

// A sink that writes one file at finish() from the shot's result: `path_` its final name,
// `staged_` the name it writes under.
class OneFileSink : public StreamSink {
 public:
  OneFileSink(const std::string& path, io::StagedOutputs& staged) : path_(path), staged_(staged.stage(path)) {}
  std::vector<std::string> files() const override { return {path_}; }

 protected:
  std::string path_, staged_;
};

// Camera `camera`'s path as JSON (mocap_io/camera_path_file.h).
class CameraPathSink : public OneFileSink {
 public:
  CameraPathSink(int camera, const std::string& path, io::StagedOutputs& staged) : OneFileSink(path, staged), camera_(camera) {}
  void finish(const SceneResult& result) override;

 private:
  int camera_;
};

// The shot's one retargeted actor as an animated GLB, with the shot's first camera when it has one
// (mocap_io/gltf_export.h).
class CharacterGlbSink : public OneFileSink {
 public:
  using OneFileSink::OneFileSink;
  void finish(const SceneResult& result) override;
};

// The whole shot as one GLB: every actor, prop and camera (mocap_io/scene_glb.h).
class SceneGlbSink : public OneFileSink {
 public:
  using OneFileSink::OneFileSink;
  void finish(const SceneResult& result) override;
};

// Actor `actor`'s retargeting report (actor_motion_report_json) with the shot's first camera and
// timings; `glb`, when not empty, is the character GLB it describes (written relative to the
// report's folder, so the pair can move together).
class ActorReportSink : public OneFileSink {
 public:
  ActorReportSink(int actor, const std::string& path, std::string glb, io::StagedOutputs& staged)
      : OneFileSink(path, staged), actor_(actor), glb_(std::move(glb)) {}
  void finish(const SceneResult& result) override;
  bool is_report() const override { return true; }

 private:
  int actor_;
  std::string glb_;
};

// The scene's report (scene_report_json).
class SceneReportSink : public OneFileSink {
 public:
  using OneFileSink::OneFileSink;
  void finish(const SceneResult& result) override;
  bool is_report() const override { return true; }
};

}  // namespace odyssey::scene
