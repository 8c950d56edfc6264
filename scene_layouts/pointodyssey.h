// Sequences in the PointOdyssey layout, the one the point trackers' loaders read: one folder per
// camera, DIR/<scene>_<camera>/, that appears whole or not at all (io::StagedOutputs::stage_folder):
//
//   anno.npz          the trajectory file's keys (mocap_io/trajectory_file.h): trajs_2d, trajs_3d,
//                     visibs, valids, intrinsics, extrinsics, the three-state visibilities, and the
//                     toolkit's own (visibility_codes, point_vertex_ids, point_barycentric,
//                     point_actor_ids, fps)
//   info.npz          per key of anno.npz with a frame axis, the shape of that array (int64), as
//                     the dataset's info.npz holds trajs_3d's
//   depths/depth_%05d.png    16-bit grey, value = round(z / 1000 m x 65535): metres = value /
//                            65535 x 1000 (steps of 1.53 cm), z along the optical axis; 65535 where
//                            no surface (1,000 m and beyond)
//   depths/depth_%05d.npy    the exact depth, float32 [H, W] metres, +inf where no surface (exact)
//   normals/normal_%05d.jpg  8-bit RGB JPEG (4:4:4) of (n + 1) / 2 x 255, n the world unit normal
//                            (Z up) facing the camera; (128, 128, 128) where no surface
//   normals/normal_%05d.npy  float32 [H, W, 3] world unit normals, 0 where no surface (exact)
//   masks/mask_%05d.png      8-bit grey, the instance id of every pixel (dense_maps.h: 0 nothing,
//                            actors 1 ... A, props A + 1 ...); more than 255 instances is an error
//   scene_info.json   what every number means: instance ids with names, kinds, classes and files;
//                     the camera; frame rate and count; units and axes
// Frame k of every file is frame k of the shot (of scene.glb, of the camera path).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "mocap_io/output_file.h"
#include "mocap_io/trajectory_file.h"
#include "scene_layouts/dense_maps.h"
#include "skinning/worker_pool.h"
#include "scene_layouts/frame_loop.h"
#include "scene_layouts/scene.h"
#include "scene_layouts/shot.h"

namespace odyssey::scene {

// One instance of a shot's masks.
struct Instance {
  int id = 0;
  std::string name;
  std::string kind;       // "actor" or "prop"
  std::string category;   // "human", "animal", "prop", "ground" or "structure"
  std::string source;     // the file its geometry comes from ("" for a box or a ground)
};

// Every actor, then every prop, with ids 1, 2, ... (dense_maps.h's instance_id). Actors driven by
// a retargeted motion are human, a character's own animation human when its rig has a humanoid
// bone map (a head and wrists found), else animal, a vertex-animated mesh animal; a ground prop is
// ground, a box or mesh prop its `category` in the scene (default prop).
std::vector<Instance> shot_instances(const Shot& shot);

class PointOdysseySink : public StreamSink {
 public:
  // `folder` the sequence's final path; `dense` which maps to write; `threads` (>= 1) the threads
  // a frame's maps are filled and encoded on (the frame loop waits for camera_frame, so its own
  // threads are idle meanwhile).
  PointOdysseySink(int camera, const std::string& folder, const io::TrajectoryFileHeader& header,
                   const DenseOutputs& dense, std::vector<Instance> instances, io::StagedOutputs& staged, int threads);
  void camera_frame(const CameraFrame& frame) override;
  void write(const FrameChunk& chunk) override;
  void finish(const SceneResult& result) override;
  std::vector<std::string> files() const override { return {folder_}; }

 private:
  int camera_;
  std::string folder_, staged_;
  DenseOutputs dense_;
  std::vector<Instance> instances_;
  int actors_ = 0;  // instances_ that are actors (they come first)
  std::size_t frames_, points_;
  std::unique_ptr<io::TrajectoryFileWriter> anno_;
  DenseMaps maps_;
  skinning::WorkerPool workers_;
  std::vector<std::uint16_t> depth16_;
  std::vector<std::uint8_t> rgb_, mask8_;
};

}  // namespace odyssey::scene
