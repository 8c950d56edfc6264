#include "mocap_io/pose_export.h"

#include <algorithm>
#include <vector>

#include "mocap_io/npy.h"

namespace odyssey::io {
namespace {

// Frames evaluated per chunk: large enough for the batched corrective product to run at full
// speed, small enough that a chunk of vertices (32 x 10475 x 3 floats = 4 MB) stays in cache range.
constexpr int kChunkFrames = 32;

// Members are stored, not deflated (as numpy.savez does): float32 vertex streams shrink only to
// about 90% under deflate, and deflating costs ten times what evaluating the frames does.
constexpr bool kCompress = false;

void add_skeleton_arrays(NpzWriter& writer, const std::vector<std::string>& names, const std::vector<int>& parents,
                         double fps) {
  writer.add("joint_names", NpyArray::from_strings(names, {names.size()}));
  writer.add("parents", NpyArray::from_int32(parents, {parents.size()}));
  writer.add("fps", NpyArray::scalar_float64(fps));
}

}  // namespace

void export_body_poses(const BodyModel& model, const BodySequence& sequence, const BodyModelOptions& options,
                       bool joints_only, const std::string& out_path) {
  const int frames = sequence.frame_count();
  const int joints = model.joint_count();
  const int vertices = model.vertex_count();
  BodyModelEvaluator evaluator(model, options);
  evaluator.set_shape(sequence.betas);

  NpzWriter writer(out_path, kCompress);
  std::vector<double> joint_chunk(std::size_t(kChunkFrames) * joints * 3);
  std::vector<float> joint_chunk_f32(joint_chunk.size());
  std::vector<float> vertex_chunk(joints_only ? 0 : std::size_t(kChunkFrames) * vertices * 3);

  // Joints first, from the cheap joints-only pass, so each array streams as one zip member.
  writer.begin_array("joints", DType::Float32, {std::size_t(frames), std::size_t(joints), 3});
  for (int first = 0; first < frames; first += kChunkFrames) {
    const int count = std::min(kChunkFrames, frames - first);
    for (int f = 0; f < count; ++f) {
      const auto pose = sequence.poses.row(first + f);
      const Eigen::Vector3d translation = sequence.translations.row(first + f).transpose();
      evaluator.evaluate(std::span<const double>(pose.data(), pose.size()), translation,
                         std::span<double>(joint_chunk).subspan(std::size_t(f) * joints * 3, std::size_t(joints) * 3),
                         std::span<double>());
    }
    const std::size_t n = std::size_t(count) * joints * 3;
    std::copy_n(joint_chunk.begin(), n, joint_chunk_f32.begin());
    writer.append(std::span<const float>(joint_chunk_f32.data(), n));
  }
  writer.end_array();

  if (!joints_only) {
    writer.begin_array("vertices", DType::Float32, {std::size_t(frames), std::size_t(vertices), 3});
    for (int first = 0; first < frames; first += kChunkFrames) {
      const int count = std::min(kChunkFrames, frames - first);
      const std::size_t pose_size = sequence.poses.cols();
      evaluator.evaluate_batch(
          count, std::span<const double>(sequence.poses.data() + std::size_t(first) * pose_size, count * pose_size),
          std::span<const double>(sequence.translations.data() + std::size_t(first) * 3, std::size_t(count) * 3),
          std::span<double>(joint_chunk.data(), std::size_t(count) * joints * 3),
          std::span<float>(vertex_chunk.data(), std::size_t(count) * vertices * 3));
      writer.append(std::span<const float>(vertex_chunk.data(), std::size_t(count) * vertices * 3));
    }
    writer.end_array();
    std::vector<std::uint32_t> faces(model.faces.size());
    std::copy_n(model.faces.data(), faces.size(), faces.begin());
    writer.add("faces", NpyArray::from_uint32(faces, {std::size_t(model.faces.rows()), 3}));
  }
  add_skeleton_arrays(writer, model.joint_names, model.parents, sequence.fps);
  writer.close();
}

void export_clip_joints(const Clip& clip, const std::string& out_path) {
  const int frames = clip.frame_count();
  const int joints = clip.joint_count();
  NpzWriter writer(out_path, kCompress);
  std::vector<RigidTransform<double>> world(joints);
  std::vector<float> chunk(std::size_t(kChunkFrames) * joints * 3);
  writer.begin_array("joints", DType::Float32, {std::size_t(frames), std::size_t(joints), 3});
  for (int first = 0; first < frames; first += kChunkFrames) {
    const int count = std::min(kChunkFrames, frames - first);
    for (int f = 0; f < count; ++f) {
      clip.world_pose(first + f, world);
      for (int j = 0; j < joints; ++j) {
        for (int c = 0; c < 3; ++c) chunk[(std::size_t(f) * joints + j) * 3 + c] = static_cast<float>(world[j].translation[c]);
      }
    }
    writer.append(std::span<const float>(chunk.data(), std::size_t(count) * joints * 3));
  }
  writer.end_array();
  add_skeleton_arrays(writer, clip.skeleton.names(), clip.skeleton.parents(), clip.fps);
  writer.close();
}

}  // namespace odyssey::io
