#include "mocap_io/pose_export.h"

#include <algorithm>
#include <array>
#include <exception>
#include <functional>
#include <future>
#include <memory>
#include <thread>
#include <vector>

#include "mocap_io/npy.h"

namespace odyssey::io {
namespace {

// Frames of the clip-joint and joint-only streams per chunk.
constexpr int kChunkFrames = 32;

// Body meshes are evaluated in batches of kBatchFrames consecutive frames (the last batch of the
// sequence may be shorter), each one evaluate_batch() call: the pose correctives of a batch are
// one float32 matrix product whose cost of packing the 61 MB posedirs operand is paid once per
// batch, so longer batches amortise it (32 frames: packing as slow as the product itself; 128:
// a quarter of it). Batch boundaries depend on the frame index only, never on the thread count,
// so every frame gets the same arithmetic, bit for bit, whatever the thread count.
constexpr int kBatchFrames = 128;

// Members are stored, not deflated (as numpy.savez does): float32 vertex streams shrink only to
// about 90% under deflate, and deflating costs ten times what evaluating the frames does.
constexpr bool kCompress = false;

// Runs task(t, i) for i in [0, count) on `threads` threads, the calling thread being thread 0;
// thread t takes i = t, t + threads, ... Rethrows the first exception once every thread is done.
void run_striped(int count, int threads, const std::function<void(int, int)>& task) {
  std::vector<std::exception_ptr> errors(static_cast<std::size_t>(threads));
  const auto stripe = [&](int t) {
    try {
      for (int i = t; i < count; i += threads) task(t, i);
    } catch (...) {
      errors[std::size_t(t)] = std::current_exception();
    }
  };
  std::vector<std::thread> pool;
  for (int t = 1; t < std::min(threads, count); ++t) pool.emplace_back(stripe, t);
  stripe(0);
  for (std::thread& thread : pool) thread.join();
  for (const std::exception_ptr& error : errors) {
    if (error) std::rethrow_exception(error);
  }
}

int thread_count(int requested) {
  if (requested > 0) return requested;
  return std::max(1, int(std::thread::hardware_concurrency()));
}

}  // namespace

int default_pose_threads() { return thread_count(0); }

namespace {

void add_skeleton_arrays(NpzWriter& writer, const std::vector<std::string>& names, const std::vector<int>& parents,
                         double fps) {
  writer.add("joint_names", NpyArray::from_strings(names, {names.size()}));
  writer.add("parents", NpyArray::from_int32(parents, {parents.size()}));
  writer.add("fps", NpyArray::scalar_float64(fps));
}

}  // namespace

void export_body_poses(const BodyModel& model, const BodySequence& sequence, const BodyModelOptions& options,
                       bool joints_only, const std::string& out_path, int threads) {
  const int frames = sequence.frame_count();
  const int joints = model.joint_count();
  const int vertices = model.vertex_count();
  const std::size_t pose_size = sequence.poses.cols();
  threads = joints_only ? 1 : std::min(thread_count(threads), std::max(1, (frames + kBatchFrames - 1) / kBatchFrames));
  // One evaluator per thread (each holds its own per-frame buffers); the model is shared.
  std::vector<BodyModelEvaluator> evaluators;
  evaluators.reserve(std::size_t(threads));
  for (int t = 0; t < threads; ++t) {
    evaluators.emplace_back(model, options);
    evaluators.back().set_shape(sequence.betas);
  }

  NpzWriter writer(out_path, kCompress);
  std::vector<double> joint_chunk(std::size_t(kChunkFrames) * joints * 3);
  std::vector<float> joint_chunk_f32(joint_chunk.size());

  // Joints first, from the cheap joints-only pass, so each array streams as one zip member.
  writer.begin_array("joints", DType::Float32, {std::size_t(frames), std::size_t(joints), 3});
  for (int first = 0; first < frames; first += kChunkFrames) {
    const int count = std::min(kChunkFrames, frames - first);
    for (int f = 0; f < count; ++f) {
      const auto pose = sequence.poses.row(first + f);
      const Eigen::Vector3d translation = sequence.translations.row(first + f).transpose();
      evaluators[0].evaluate(std::span<const double>(pose.data(), pose.size()), translation,
                             std::span<double>(joint_chunk).subspan(std::size_t(f) * joints * 3, std::size_t(joints) * 3),
                             std::span<double>());
    }
    const std::size_t n = std::size_t(count) * joints * 3;
    std::copy_n(joint_chunk.begin(), n, joint_chunk_f32.begin());
    writer.append(std::span<const float>(joint_chunk_f32.data(), n));
  }
  writer.end_array();

  if (!joints_only) {
    // A chunk is one batch per thread. While the threads evaluate chunk k + 1 into one buffer,
    // this thread writes chunk k from the other (CRC and the copy into the file overlap the
    // arithmetic).
    const int chunk_frames = kBatchFrames * threads;
    const std::size_t frame_floats = std::size_t(vertices) * 3;
    // Uninitialised (every float is written before it is read), advised to huge pages first.
    std::array<std::unique_ptr<float[]>, 2> vertex_chunks;
    for (std::unique_ptr<float[]>& chunk : vertex_chunks) {
      chunk.reset(new float[std::size_t(chunk_frames) * frame_floats]);
      advise_huge_pages(chunk.get(), std::size_t(chunk_frames) * frame_floats * sizeof(float));
    }
    std::vector<std::vector<double>> batch_joints(std::size_t(threads),
                                                  std::vector<double>(std::size_t(kBatchFrames) * joints * 3));
    const auto evaluate_chunk = [&](int first, float* out) {
      const int count = std::min(chunk_frames, frames - first);
      run_striped((count + kBatchFrames - 1) / kBatchFrames, threads, [&](int t, int batch) {
        const int offset = batch * kBatchFrames;
        const int n = std::min(kBatchFrames, count - offset);
        const std::size_t start = std::size_t(first + offset);
        evaluators[std::size_t(t)].evaluate_batch(
            n, std::span<const double>(sequence.poses.data() + start * pose_size, std::size_t(n) * pose_size),
            std::span<const double>(sequence.translations.data() + start * 3, std::size_t(n) * 3),
            std::span<double>(batch_joints[std::size_t(t)].data(), std::size_t(n) * joints * 3),
            std::span<float>(out + std::size_t(offset) * frame_floats, std::size_t(n) * frame_floats));
      });
    };
    writer.begin_array("vertices", DType::Float32, {std::size_t(frames), std::size_t(vertices), 3});
    std::future<void> pending = std::async(std::launch::async, evaluate_chunk, 0, vertex_chunks[0].get());
    for (int first = 0, k = 0; first < frames; first += chunk_frames, ++k) {
      pending.get();
      const int next_first = first + chunk_frames;
      if (next_first < frames) {
        pending = std::async(std::launch::async, evaluate_chunk, next_first, vertex_chunks[(k + 1) % 2].get());
      }
      const int count = std::min(chunk_frames, frames - first);
      writer.append(std::span<const float>(vertex_chunks[k % 2].get(), std::size_t(count) * frame_floats));
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
