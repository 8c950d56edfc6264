// Speed of linear blend skinning (skinning/lbs.h) in vertex-frames per second, on one thread and
// on two, beside the plain double-precision reference (skin_mesh_reference) in the same run, on
// two meshes with four influences on every vertex (the worst case the engine handles):
//
//   SMPL-X body   the synthetic SMPL-X body (10,475 vertices, 55 joints), its dense-weight variant
//                 cut to the four largest weights, and vertices with fewer given random further
//                 joints (weights 0.01-0.1 before renormalising) until every vertex has four;
//   dense body    the same body with every triangle split at its centroid, twice (94,107
//                 vertices, 188,172 triangles); a new vertex takes the average of its corners'
//                 weights, cut to the four largest and padded as above.
//
// The engine skins batches of 64 random poses per call (skin_frames), positions only and with
// normals; single-frame calls (skin) show the cost of waking the second thread for one frame.
// The sampled-points row skins 5,000 area-weighted surface points of the body (SurfacePointSkinner:
// only their corner vertices, then barycentric interpolation); its rate counts point-frames.
// Times are wall-clock (real time), so the two-thread rows count both threads' work. A table
// after Google Benchmark's own output puts the rates side by side, then the machine line. On a
// machine shared with other work, run repetitions (--benchmark_repetitions=5): interference only
// ever slows a run down, so the table keeps each row's best repetition.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"  // GCC 12 and AVX-512 intrinsics, see lbs.cpp
#include <Eigen/Core>
#pragma GCC diagnostic pop

#include <benchmark/benchmark.h>

#include "bench/machine.h"
#include <sys/resource.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <functional>
#include <map>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "skeleton/character.h"
#include "skeleton/fk.h"
#include "skeleton/rotation.h"
#include "skinning/body_character.h"
#include "skinning/lbs.h"
#include "skinning/lbs_kernel.h"
#include "skinning/sampling.h"
#include "synthetic/synthetic_body.h"

namespace odyssey::skinning {
namespace {

constexpr std::size_t kBatchFrames = 64;
constexpr int kSampledPoints = 5000;

// Gives every vertex with fewer than four non-zero weights random further joints (not already
// among its influences) with weights uniform in [0.01, 0.1], then renormalises.
void pad_to_four_influences(Character& character, std::mt19937& random) {
  CharacterMesh& mesh = character.meshes[0];
  std::uniform_int_distribution<int> any_slot(0, int(mesh.skin_joints.size()) - 1);
  std::uniform_real_distribution<float> extra(0.01f, 0.1f);
  for (std::size_t v = 0; v < mesh.positions.size(); ++v) {
    std::array<std::uint16_t, 4>& slots = mesh.influence_slots[v];
    std::array<float, 4>& weights = mesh.influence_weights[v];
    int count = int(std::count_if(weights.begin(), weights.end(), [](float w) { return w != 0.0f; }));
    while (count < 4) {
      const auto slot = std::uint16_t(any_slot(random));
      if (std::find(slots.begin(), slots.begin() + count, slot) != slots.begin() + count) continue;
      slots[count] = slot;
      weights[count++] = extra(random);
    }
    float total = 0.0f;
    for (const float w : weights) total += w;
    for (float& w : weights) w /= total;
  }
}

// Splits every triangle (a, b, c) into (a, b, m), (b, c, m), (c, a, m) around its centroid m. The
// new vertex's weights are the average of the corners' (as joint -> weight sums), cut to the four
// largest and renormalised.
Character split_at_centroids(const Character& character) {
  Character split = character;
  CharacterMesh& mesh = split.meshes[0];
  const CharacterMesh& source = character.meshes[0];
  mesh.triangles.clear();
  for (std::size_t t = 0; t < source.triangles.size(); t += 3) {
    const std::array<std::uint32_t, 3> corners = {source.triangles[t], source.triangles[t + 1], source.triangles[t + 2]};
    Eigen::Vector3f centroid = Eigen::Vector3f::Zero();
    std::map<std::uint16_t, float> blend;
    for (const std::uint32_t c : corners) {
      centroid += source.positions[c] / 3.0f;
      for (int k = 0; k < 4; ++k) blend[source.influence_slots[c][k]] += source.influence_weights[c][k] / 3.0f;
    }
    std::vector<std::pair<float, std::uint16_t>> strongest;
    for (const auto& [slot, weight] : blend) {
      if (weight > 0.0f) strongest.emplace_back(weight, slot);
    }
    std::sort(strongest.begin(), strongest.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
    strongest.resize(std::min<std::size_t>(strongest.size(), 4));
    float total = 0.0f;
    for (const auto& influence : strongest) total += influence.first;
    std::array<std::uint16_t, 4> slots{};
    std::array<float, 4> weights{};
    for (std::size_t k = 0; k < strongest.size(); ++k) {
      slots[k] = strongest[k].second;
      weights[k] = strongest[k].first / total;
    }
    const auto m = std::uint32_t(mesh.positions.size());
    mesh.positions.push_back(centroid);
    mesh.influence_slots.push_back(slots);
    mesh.influence_weights.push_back(weights);
    for (int e = 0; e < 3; ++e) mesh.triangles.insert(mesh.triangles.end(), {corners[e], corners[(e + 1) % 3], m});
  }
  return split;
}

struct BenchMesh {
  std::string name;
  Character character;
  std::vector<RigidTransform<double>> frames;  // kBatchFrames random poses, frame after frame
};

// Every joint turned from its rest by a random rotation of up to ~1 rad, the root moved too.
std::vector<RigidTransform<double>> random_frames(const Character& character, std::mt19937& random) {
  const Skeleton& skeleton = character.skeleton;
  std::vector<RigidTransform<double>> local(skeleton.joint_count()), world(skeleton.joint_count()), frames;
  std::uniform_real_distribution<double> component(-0.6, 0.6);
  for (std::size_t f = 0; f < kBatchFrames; ++f) {
    skeleton.rest_local(local);
    for (RigidTransform<double>& joint : local) {
      joint.rotation = joint.rotation * rodrigues(Eigen::Vector3d(component(random), component(random), component(random)));
    }
    local[0].translation += Eigen::Vector3d(component(random), component(random), component(random));
    forward_kinematics<double>(skeleton.parents(), local, world);
    frames.insert(frames.end(), world.begin(), world.end());
  }
  return frames;
}

const std::vector<BenchMesh>& bench_meshes() {
  static const std::vector<BenchMesh> meshes = [] {
    std::mt19937 random(20240611);
    Character body = body_character(make_synthetic_body(1, true).model);
    pad_to_four_influences(body, random);
    Character dense = split_at_centroids(split_at_centroids(body));
    pad_to_four_influences(dense, random);
    std::vector<BenchMesh> list;
    list.push_back({"SMPL-X body", std::move(body), {}});
    list.push_back({"dense body", std::move(dense), {}});
    for (BenchMesh& mesh : list) mesh.frames = random_frames(mesh.character, random);
    return list;
  }();
  return meshes;
}

std::size_t joint_count(const BenchMesh& mesh) { return std::size_t(mesh.character.skeleton.joint_count()); }

void engine_batches(benchmark::State& state, const BenchMesh& mesh, int threads, bool normals) {
  const std::vector<MeshVertex> vertices = all_vertices(mesh.character);
  LinearBlendSkinner skinner(mesh.character, vertices, {.threads = threads, .normals = normals});
  std::vector<float> positions(kBatchFrames * 3 * vertices.size()), normal_out(normals ? positions.size() : 0);
  for (auto _ : state) {
    skinner.skin_frames(kBatchFrames, mesh.frames, positions, normal_out);
    benchmark::DoNotOptimize(positions.data());
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(std::int64_t(state.iterations() * kBatchFrames * vertices.size()));
}

void engine_single_frames(benchmark::State& state, const BenchMesh& mesh, int threads) {
  const std::vector<MeshVertex> vertices = all_vertices(mesh.character);
  LinearBlendSkinner skinner(mesh.character, vertices, {.threads = threads});
  std::vector<float> positions(3 * vertices.size());
  const std::size_t joints = joint_count(mesh);
  std::size_t frame = 0;
  for (auto _ : state) {
    skinner.skin(std::span(mesh.frames).subspan(frame * joints, joints), positions);
    benchmark::DoNotOptimize(positions.data());
    benchmark::ClobberMemory();
    frame = (frame + 1) % kBatchFrames;
  }
  state.SetItemsProcessed(std::int64_t(state.iterations() * vertices.size()));
}

void reference(benchmark::State& state, const BenchMesh& mesh) {
  const std::size_t joints = joint_count(mesh);
  std::vector<RigidTransform<double>> world(joints);
  std::size_t frame = 0;
  for (auto _ : state) {
    std::copy_n(mesh.frames.begin() + std::ptrdiff_t(frame * joints), joints, world.begin());
    const std::vector<Eigen::Vector3d> positions = skin_mesh_reference(mesh.character.meshes[0], world);
    benchmark::DoNotOptimize(positions.data());
    frame = (frame + 1) % kBatchFrames;
  }
  state.SetItemsProcessed(std::int64_t(state.iterations() * mesh.character.meshes[0].positions.size()));
}

void sampled_points(benchmark::State& state, const BenchMesh& mesh, int threads) {
  const std::vector<SurfacePoint> points =
      sample_surface_points(mesh.character, {.mode = SamplingMode::surface, .count = kSampledPoints, .seed = 1});
  SurfacePointSkinner skinner(mesh.character, points, threads);
  std::vector<float> out(kBatchFrames * 3 * points.size());
  for (auto _ : state) {
    skinner.skin_frames(kBatchFrames, mesh.frames, out);
    benchmark::DoNotOptimize(out.data());
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(std::int64_t(state.iterations() * kBatchFrames * points.size()));
  state.counters["skinned_vertices"] = double(skinner.skinned_vertex_count());
}

// One row of the summary table per registered benchmark.
struct Row {
  std::string mesh, what;
  std::size_t items = 0;  // vertices (or points) a frame
  int threads = 1;
  double rate = 0.0;      // items x frames per second, filled from the run
};
std::map<std::string, Row> rows;
std::vector<std::string> row_order;

void add(const std::string& name, Row row, const std::function<void(benchmark::State&)>& body) {
  benchmark::RegisterBenchmark(name.c_str(), body)->UseRealTime()->Unit(benchmark::kMicrosecond);
  rows[name] = std::move(row);
  row_order.push_back(name);
}

void register_benchmarks() {
  for (const BenchMesh& mesh : bench_meshes()) {
    const std::size_t vertices = mesh.character.meshes[0].positions.size();
    const std::string prefix = mesh.name == "SMPL-X body" ? "smplx" : "dense";
    add(prefix + "/reference", {mesh.name, "reference (double, one frame a call)", vertices, 1},
        [&mesh](benchmark::State& state) { reference(state, mesh); });
    for (const int threads : {1, 2}) {
      const std::string t = "/threads:" + std::to_string(threads);
      add(prefix + "/engine" + t, {mesh.name, "engine, batches of 64 frames", vertices, threads},
          [&mesh, threads](benchmark::State& state) { engine_batches(state, mesh, threads, false); });
      add(prefix + "/engine_normals" + t, {mesh.name, "engine + normals, batches of 64", vertices, threads},
          [&mesh, threads](benchmark::State& state) { engine_batches(state, mesh, threads, true); });
      add(prefix + "/engine_single_frame" + t, {mesh.name, "engine, one frame a call", vertices, threads},
          [&mesh, threads](benchmark::State& state) { engine_single_frames(state, mesh, threads); });
    }
  }
  const BenchMesh& body = bench_meshes()[0];
  for (const int threads : {1, 2}) {
    add("smplx/sampled_points/threads:" + std::to_string(threads),
        {body.name, "5,000 surface points, batches of 64", std::size_t(kSampledPoints), threads},
        [&body, threads](benchmark::State& state) { sampled_points(state, body, threads); });
  }
}

// Google Benchmark's console output, and the best rate of each row kept for the table.
class TableReporter : public benchmark::ConsoleReporter {
 public:
  void ReportRuns(const std::vector<Run>& runs) override {
    ConsoleReporter::ReportRuns(runs);
    for (const Run& run : runs) {
      if (run.run_type != Run::RT_Iteration || run.error_occurred) continue;
      const auto row = rows.find(run.run_name.function_name);
      const auto rate = run.counters.find("items_per_second");
      if (row != rows.end() && rate != run.counters.end()) row->second.rate = std::max(row->second.rate, rate->second.value);
    }
  }
};

void print_table() {
  std::map<std::string, double> reference_rate;
  for (const auto& [name, row] : rows) {
    if (row.what.rfind("reference", 0) == 0) reference_rate[row.mesh] = row.rate;
  }
  std::printf("\n| mesh | vertices | what | threads | M vertex-frames/s | per thread | vs reference |\n");
  std::printf("|---|---:|---|---:|---:|---:|---:|\n");
  for (const std::string& name : row_order) {
    const Row& row = rows[name];
    if (row.rate == 0.0) continue;  // filtered out of this run
    const double reference = reference_rate[row.mesh];
    char speedup[32] = "-";
    if (reference > 0.0) std::snprintf(speedup, sizeof speedup, "%.1fx", row.rate / reference);
    std::printf("| %s | %zu | %s | %d | %.1f | %.1f | %s |\n", row.mesh.c_str(), row.items, row.what.c_str(), row.threads,
                row.rate / 1e6, row.rate / 1e6 / row.threads, speedup);
  }
  std::printf("(the sampled-points row counts point-frames)\n");
}

}  // namespace
}  // namespace odyssey::skinning

int main(int argc, char** argv) {
  using namespace odyssey::skinning;
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  for (const BenchMesh& mesh : bench_meshes()) {
    const LinearBlendSkinner skinner(mesh.character, all_vertices(mesh.character));
    const std::array<std::size_t, 4> histogram = skinner.influence_histogram();
    std::printf("%s: %zu vertices, %zu triangles, %d joints; vertices with 1/2/3/4 influences: %zu/%zu/%zu/%zu\n",
                mesh.name.c_str(), mesh.character.meshes[0].positions.size(), mesh.character.meshes[0].triangles.size() / 3,
                mesh.character.skeleton.joint_count(), histogram[0], histogram[1], histogram[2], histogram[3]);
  }
#ifdef ODYSSEY_SKINNING_AVX512
  std::printf("kernel: AVX-512 (one 16-lane register holds a vertex's blended 4x4)\n");
#else
  std::printf("kernel: portable (GLM)\n");
#endif
  register_benchmarks();
  TableReporter reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  benchmark::Shutdown();
  print_table();
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  std::printf("machine: %s, %u cores; peak RSS %.0f MiB\n", odyssey::bench::cpu_model().c_str(), std::thread::hardware_concurrency(),
              usage.ru_maxrss / 1024.0);
  return 0;
}
