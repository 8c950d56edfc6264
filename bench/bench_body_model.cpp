// Speed of the SMPL-X forward pass on one core, on a model as dense as the released SMPL-X:
// the synthetic fixture (10,475 vertices, 55 joints) with pose correctives on every vertex and
// all 486 pose features, and skinning weights spread over 4 to 8 joints a vertex. Frames per
// second are Google Benchmark's items_per_second. Before the table, the accuracy of the same
// code path against the smplx reference fixture is printed, so speed and error are read together.
#include <benchmark/benchmark.h>

#include "bench/machine.h"
#include <sys/resource.h>

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <random>
#include <string>
#include <thread>

#include "mocap_io/body_model_file.h"
#include "mocap_io/npy.h"
#include "skeleton/body_model.h"
#include "skeleton/fk.h"
#include "skeleton/rotation.h"

namespace odyssey {
namespace {

const std::string kFixtureDir = ODYSSEY_SHARED_DIR "/fixtures/smplx";

// The fixture with its sparse parts made dense, as in the released model:
// - posedirs: normal values with the fixture's own RMS on every row (the fixture fills only
//   every 7th vertex to stay small), so the corrective product streams all 3V x 486 floats;
// - weights: each vertex keeps its fixture joints and gains random others until it has 4 to 8
//   influences (uniform), weights drawn uniform in (0, 1] and normalised to sum to 1.
BodyModel make_dense_model() {
  BodyModel model = io::load_body_model(kFixtureDir + "/SMPLX_FIXTURE.npz");
  std::mt19937 rng(20231001);

  double sum_sq = 0.0;
  long non_zero = 0;
  for (Eigen::Index i = 0; i < model.posedirs.size(); ++i) {
    const double value = model.posedirs.data()[i];
    if (value != 0.0) {
      sum_sq += value * value;
      ++non_zero;
    }
  }
  std::normal_distribution<float> corrective(0.0f, float(std::sqrt(sum_sq / std::max(1L, non_zero))));
  for (Eigen::Index i = 0; i < model.posedirs.size(); ++i) model.posedirs.data()[i] = corrective(rng);

  const int joints = model.joint_count();
  std::uniform_int_distribution<int> influence_count(4, 8), any_joint(0, joints - 1);
  std::uniform_real_distribution<double> weight(1e-3, 1.0);
  std::vector<Eigen::Triplet<double>> entries;
  for (int v = 0; v < model.vertex_count(); ++v) {
    std::vector<int> influences;
    for (Eigen::SparseMatrix<double, Eigen::RowMajor>::InnerIterator it(model.weights, v); it; ++it) {
      influences.push_back(int(it.col()));
    }
    const std::size_t count = std::size_t(influence_count(rng));
    while (influences.size() < count) {
      const int j = any_joint(rng);
      if (std::find(influences.begin(), influences.end(), j) == influences.end()) influences.push_back(j);
    }
    std::vector<double> w(influences.size());
    for (double& value : w) value = weight(rng);
    double total = 0.0;
    for (double value : w) total += value;
    for (std::size_t k = 0; k < influences.size(); ++k) entries.emplace_back(v, influences[k], w[k] / total);
  }
  model.weights.setZero();
  model.weights.setFromTriplets(entries.begin(), entries.end());
  model.validate();
  return model;
}

const BodyModel& dense_model() {
  static const BodyModel model = make_dense_model();
  return model;
}

// Moderate random poses (0.3 rad per axis-angle component) and translations, as a sequence.
struct Sequence {
  int frames = 0;
  std::vector<double> poses, translations;
};

Sequence random_sequence(const BodyModel& model, int frames) {
  std::mt19937 rng(7);
  std::normal_distribution<double> angle(0.0, 0.3), offset(0.0, 0.5);
  Sequence sequence{frames, std::vector<double>(std::size_t(frames) * model.pose_size()),
                    std::vector<double>(std::size_t(frames) * 3)};
  for (double& value : sequence.poses) value = angle(rng);
  for (double& value : sequence.translations) value = offset(rng);
  return sequence;
}

const std::vector<double> kBetas = {0.8, -1.2, 0.3, 0.5, -0.4, 0.1, 0.0, 0.2, -0.3, 0.6};
constexpr int kSequenceFrames = 128;

void set_counters(benchmark::State& state, const BodyModel& model, long frames, bool mesh) {
  state.SetItemsProcessed(frames);
  state.counters["vertices"] = mesh ? model.vertex_count() : 0;
  if (mesh) state.counters["vertices/s"] = benchmark::Counter(double(frames) * model.vertex_count(), benchmark::Counter::kIsRate);
}

// (a), (c): one frame at a time, float32 vertices out (what renderers and caches take).
void BM_MeshSingleFrame(benchmark::State& state) {
  const BodyModel& model = dense_model();
  const bool correctives = state.range(0) != 0;
  BodyModelEvaluator evaluator(model, {.pose_correctives = correctives});
  evaluator.set_shape(kBetas);
  const Sequence sequence = random_sequence(model, kSequenceFrames);
  std::vector<double> joints(model.pose_size());
  std::vector<float> vertices(3 * std::size_t(model.vertex_count()));
  long frames = 0;
  for (auto _ : state) {
    const int f = int(frames % sequence.frames);
    const double* t = &sequence.translations[3 * f];
    evaluator.evaluate(std::span(sequence.poses).subspan(std::size_t(f) * model.pose_size(), model.pose_size()),
                       Eigen::Vector3d(t[0], t[1], t[2]), joints, std::span<float>(vertices));
    benchmark::DoNotOptimize(vertices.data());
    ++frames;
  }
  set_counters(state, model, frames, true);
}
BENCHMARK(BM_MeshSingleFrame)->ArgName("correctives")->Arg(1)->Arg(0)->Unit(benchmark::kMicrosecond);

// (b), (c): batches; with correctives the batch shares one posedirs x features product.
void BM_MeshBatch(benchmark::State& state) {
  const BodyModel& model = dense_model();
  const int batch = int(state.range(0));
  const bool correctives = state.range(1) != 0;
  BodyModelEvaluator evaluator(model, {.pose_correctives = correctives});
  evaluator.set_shape(kBetas);
  const Sequence sequence = random_sequence(model, batch);
  std::vector<double> joints(std::size_t(batch) * model.pose_size());
  std::vector<float> vertices(std::size_t(batch) * 3 * model.vertex_count());
  long frames = 0;
  for (auto _ : state) {
    evaluator.evaluate_batch(batch, sequence.poses, sequence.translations, joints, vertices);
    benchmark::DoNotOptimize(vertices.data());
    frames += batch;
  }
  set_counters(state, model, frames, true);
}
BENCHMARK(BM_MeshBatch)
    ->ArgNames({"batch", "correctives"})
    ->Args({32, 1})
    ->Args({128, 1})
    ->Args({128, 0})
    ->Unit(benchmark::kMillisecond);

// (d): joints only: Rodrigues, forward kinematics, no mesh.
void BM_JointsOnly(benchmark::State& state) {
  const BodyModel& model = dense_model();
  BodyModelEvaluator evaluator(model);
  evaluator.set_shape(kBetas);
  const Sequence sequence = random_sequence(model, kSequenceFrames);
  std::vector<double> joints(model.pose_size());
  long frames = 0;
  for (auto _ : state) {
    const int f = int(frames % sequence.frames);
    const double* t = &sequence.translations[3 * f];
    evaluator.evaluate(std::span(sequence.poses).subspan(std::size_t(f) * model.pose_size(), model.pose_size()),
                       Eigen::Vector3d(t[0], t[1], t[2]), joints, std::span<double>());
    benchmark::DoNotOptimize(joints.data());
    ++frames;
  }
  set_counters(state, model, frames, false);
}
BENCHMARK(BM_JointsOnly)->Unit(benchmark::kMicrosecond);

// (e): forward kinematics over the 55 joints alone, from local transforms built beforehand
// (rotation matrices and rest offsets), and with Rodrigues from axis-angle in the loop.
struct KinematicsInput {
  std::vector<int> parents;
  std::vector<std::vector<RigidTransform<double>>> local_frames;  // per frame
  Sequence sequence;
};

KinematicsInput kinematics_input() {
  const BodyModel& model = dense_model();
  BodyModelEvaluator evaluator(model);
  evaluator.set_shape(kBetas);
  KinematicsInput input{model.parents, {}, random_sequence(model, kSequenceFrames)};
  const RowMatrixXd& rest = evaluator.rest_joints();
  for (int f = 0; f < kSequenceFrames; ++f) {
    std::vector<RigidTransform<double>> local(model.joint_count());
    for (int j = 0; j < model.joint_count(); ++j) {
      const double* r = &input.sequence.poses[std::size_t(f) * model.pose_size() + 3 * j];
      local[j].rotation = rodrigues(Eigen::Vector3d(r[0], r[1], r[2]));
      local[j].translation = rest.row(j).transpose();
      if (model.parents[j] >= 0) local[j].translation -= rest.row(model.parents[j]).transpose();
    }
    input.local_frames.push_back(std::move(local));
  }
  return input;
}

void BM_ForwardKinematics(benchmark::State& state) {
  const KinematicsInput input = kinematics_input();
  std::vector<RigidTransform<double>> world(input.parents.size());
  long frames = 0;
  for (auto _ : state) {
    forward_kinematics<double>(input.parents, input.local_frames[frames % kSequenceFrames], world);
    benchmark::DoNotOptimize(world.data());
    benchmark::ClobberMemory();
    ++frames;
  }
  state.SetItemsProcessed(frames);
  state.counters["joints"] = double(input.parents.size());
}
BENCHMARK(BM_ForwardKinematics)->Unit(benchmark::kNanosecond);

void BM_RodriguesAndForwardKinematics(benchmark::State& state) {
  KinematicsInput input = kinematics_input();
  const std::size_t joints = input.parents.size();
  std::vector<RigidTransform<double>> local = input.local_frames[0], world(joints);
  long frames = 0;
  for (auto _ : state) {
    const double* pose = &input.sequence.poses[std::size_t(frames % kSequenceFrames) * 3 * joints];
    for (std::size_t j = 0; j < joints; ++j) {
      local[j].rotation = rodrigues(Eigen::Vector3d(pose[3 * j], pose[3 * j + 1], pose[3 * j + 2]));
    }
    forward_kinematics<double>(input.parents, local, world);
    benchmark::DoNotOptimize(world.data());
    benchmark::ClobberMemory();
    ++frames;
  }
  state.SetItemsProcessed(frames);
  state.counters["joints"] = double(joints);
}
BENCHMARK(BM_RodriguesAndForwardKinematics)->Unit(benchmark::kNanosecond);

// Max |error| of the benchmarked code path (float32 corrective product, double elsewhere)
// against the smplx float64 reference, over the 15 frames of reference_flat.npz.
void print_reference_accuracy() {
  const BodyModel model = io::load_body_model(kFixtureDir + "/SMPLX_FIXTURE.npz");
  const io::NpzReader reference(kFixtureDir + "/reference_flat.npz");
  const std::vector<double> betas = reference.load("betas").to_double(), expression = reference.load("expression").to_double();
  const std::vector<double> poses = reference.load("full_pose").to_double(), transl = reference.load("transl").to_double();
  const std::vector<double> joints_ref = reference.load("joints").to_double();
  const std::vector<double> vertices_ref = reference.load("vertices").to_double();
  const std::size_t frames = transl.size() / 3, pose_size = model.pose_size(), vertex_numbers = 3 * std::size_t(model.vertex_count());
  BodyModelEvaluator evaluator(model);
  std::vector<double> joints(pose_size), vertices(vertex_numbers);
  double joint_error = 0.0, vertex_error = 0.0;
  for (std::size_t f = 0; f < frames; ++f) {
    evaluator.set_shape(std::span(betas).subspan(f * 10, 10), std::span(expression).subspan(f * 10, 10));
    evaluator.evaluate(std::span(poses).subspan(f * pose_size, pose_size),
                       Eigen::Vector3d(transl[3 * f], transl[3 * f + 1], transl[3 * f + 2]), joints,
                       std::span<double>(vertices));
    for (std::size_t i = 0; i < pose_size; ++i) joint_error = std::max(joint_error, std::abs(joints[i] - joints_ref[f * pose_size + i]));
    for (std::size_t i = 0; i < vertex_numbers; ++i) {
      vertex_error = std::max(vertex_error, std::abs(vertices[i] - vertices_ref[f * vertex_numbers + i]));
    }
  }
  std::printf("accuracy vs smplx float64 reference (%zu frames of reference_flat.npz): max |joint error| %.2g m, "
              "max |vertex error| %.2g m\n", frames, joint_error, vertex_error);
}

}  // namespace
}  // namespace odyssey

int main(int argc, char** argv) {
  // One core: Eigen's products run on the calling thread only, and each benchmark is one thread.
  Eigen::setNbThreads(1);
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  const odyssey::BodyModel& model = odyssey::dense_model();
  std::printf("dense SMPL-X model: %d vertices, %d joints, posedirs %ld x %ld float32, %.2f skinning influences a vertex\n",
              model.vertex_count(), model.joint_count(), long(model.posedirs.rows()), long(model.posedirs.cols()),
              double(model.weights.nonZeros()) / model.vertex_count());
  odyssey::print_reference_accuracy();
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  std::printf("machine: %s, %u cores; runs on 1 thread (Eigen threads: %d); peak RSS %.0f MiB\n",
              odyssey::bench::cpu_model().c_str(), std::thread::hardware_concurrency(), Eigen::nbThreads(),
              usage.ru_maxrss / 1024.0);
  return 0;
}
