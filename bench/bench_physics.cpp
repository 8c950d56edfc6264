// Cost of props that react (physics/rigid_scene.h) on a busy shot: 50 dynamic props (boxes,
// icosahedron and wedge hulls, 0.1-0.4 m) scattered on a 10 x 10 m floor, 12 of them on the
// actors' paths, kicked at random (0.05 per prop per second), while 4 synthetic walkers, each
// 20 bone colliders (hulls of 16 points on a bone-sized ellipsoid), circle through the floor at
// 1.2 m/s with swinging legs and arms. 2,000 frames at 30 fps (8 substeps of 1/240 s), one
// thread. Rows: the solver's iteration count (10 is the module's default, 50 PyBullet's). The
// table gives the model's build time, the simulation's time per output frame, the props' top
// speed, deepest contact (against anything, and between props) and contact events, then the
// machine line with the peak resident set. CPU time (the process's, one thread) is the figure to
// trust on a shared machine; wall time also counts waiting for a core.
//
// Usage: bench_physics [frames]
#include <sys/resource.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <numbers>
#include <string>
#include <thread>
#include <vector>

#include "bench/machine.h"
#include "physics/bone_colliders.h"
#include "physics/rigid_scene.h"
#include "physics/sampling.h"

namespace {

using namespace odyssey::physics;

std::vector<Eigen::Vector3d> ellipsoid_points(PortableUniform& uniform, const Eigen::Vector3d& radii, int count) {
  std::vector<Eigen::Vector3d> points;
  while (static_cast<int>(points.size()) < count) {
    const Eigen::Vector3d v(uniform.between(-1, 1), uniform.between(-1, 1), uniform.between(-1, 1));
    const double n = v.norm();
    if (n > 0.2 && n <= 1) points.push_back(radii.cwiseProduct(v / n));
  }
  return points;
}

std::vector<Eigen::Vector3d> icosahedron(double radius) {
  const double phi = (1 + std::sqrt(5.0)) / 2;
  std::vector<Eigen::Vector3d> v;
  for (double a : {-1.0, 1.0})
    for (double b : {-phi, phi}) {
      v.emplace_back(0, a, b);
      v.emplace_back(a, b, 0);
      v.emplace_back(b, 0, a);
    }
  for (auto& p : v) p *= radius / std::sqrt(1 + phi * phi);
  return v;
}

// One walker's 20 bones: where each sits on the body (x forward, y left, z up, metres from the
// ground under the pelvis), its size, and how it swings (+1/-1 legs and arms, 0 rigid).
struct BoneLayout {
  Eigen::Vector3d offset, radii;
  double swing;  // phase sign of the gait swing; 0: carried rigidly
  double reach;  // distance below the hip or shoulder the swing turns about
};

std::vector<BoneLayout> walker_layout() {
  std::vector<BoneLayout> bones = {
      {{0, 0, 0.95}, {0.12, 0.16, 0.1}, 0, 0},    {{0, 0, 1.15}, {0.11, 0.15, 0.12}, 0, 0},  {{0, 0, 1.35}, {0.11, 0.17, 0.12}, 0, 0},
      {{0, 0, 1.55}, {0.05, 0.05, 0.06}, 0, 0},    {{0, 0, 1.68}, {0.1, 0.09, 0.12}, 0, 0},
  };
  for (double side : {-1.0, 1.0}) {
    const double y = 0.1 * side;
    bones.push_back({{0, y, 0.72}, {0.07, 0.07, 0.2}, side, 0.23});      // thigh
    bones.push_back({{0, y, 0.32}, {0.05, 0.05, 0.2}, side, 0.63});      // shin
    bones.push_back({{0.05, y, 0.05}, {0.12, 0.05, 0.05}, side, 0.9});   // foot
    bones.push_back({{0.1, y, 0.03}, {0.04, 0.04, 0.03}, side, 0.92});   // toes
    const double ya = 0.22 * side;
    bones.push_back({{0, ya, 1.42}, {0.05, 0.05, 0.05}, 0, 0});          // clavicle
    bones.push_back({{0, ya, 1.25}, {0.05, 0.05, 0.15}, -side, 0.17});  // upper arm
    bones.push_back({{0, ya, 0.98}, {0.04, 0.04, 0.13}, -side, 0.44});  // forearm
    bones.push_back({{0, ya, 0.8}, {0.05, 0.03, 0.08}, -side, 0.62});   // hand
  }
  bones.push_back({{-0.05, 0, 0.8}, {0.1, 0.15, 0.08}, 0, 0});  // hips
  bones.resize(20);
  return bones;
}

struct Row {
  int iterations = 0;
  double build_s = 0, simulate_s = 0, simulate_cpu_s = 0, top_speed = 0, deepest = 0, overlap = 0;
  long long events = 0;
};

}  // namespace

int main(int argc, char** argv) {
  const int frames = argc > 1 ? std::atoi(argv[1]) : 2000;
  if (frames < 2) {
    std::fprintf(stderr, "bench_physics: frames must be >= 2, got %s\n", argv[1]);
    return 2;
  }
  const int props = 50, actors = 4;
  PhysicsScene scene;
  scene.fps = 30;
  scene.frame_count = frames;

  // Walkers circle (radius 3 m) around centres spread over the floor, at 1.2 m/s.
  const std::vector<Eigen::Vector2d> centres = {{-2, -2}, {2, -2}, {-2, 2}, {2, 2}};
  const double radius = 3, speed = 1.2, stride_hz = 0.9;
  const auto layout = walker_layout();
  PortableUniform shapes(1, 0);
  std::vector<std::vector<Eigen::Vector2d>> paths(actors);
  std::vector<KeepOut> keep_out;
  for (int a = 0; a < actors; ++a) {
    std::vector<std::vector<Eigen::Vector3d>> hulls;
    for (const auto& bone : layout) hulls.push_back(ellipsoid_points(shapes, bone.radii, 16));
    std::vector<Pose> track(static_cast<std::size_t>(frames) * layout.size());
    for (int f = 0; f < frames; ++f) {
      const double t = f / scene.fps, angle = speed * t / radius + a;
      const Eigen::Vector2d root = centres[a] + radius * Eigen::Vector2d(std::cos(angle), std::sin(angle));
      const Eigen::Quaterniond heading(Eigen::AngleAxisd(angle + std::numbers::pi / 2, Eigen::Vector3d::UnitZ()));
      const double swing = 0.45 * std::sin(2 * std::numbers::pi * stride_hz * t);
      for (std::size_t b = 0; b < layout.size(); ++b) {
        const BoneLayout& bone = layout[b];
        // Legs and arms turn about the lateral axis through the hip or shoulder.
        const Eigen::Quaterniond turn(Eigen::AngleAxisd(bone.swing * swing, Eigen::Vector3d::UnitY()));
        const Eigen::Vector3d pivot = bone.offset + Eigen::Vector3d(0, 0, bone.reach);
        const Eigen::Vector3d local = pivot + turn * (bone.offset - pivot);
        Pose& pose = track[static_cast<std::size_t>(f) * layout.size() + b];
        pose.rotation = heading * turn;
        pose.position = Eigen::Vector3d(root.x(), root.y(), 0) + heading * local;
      }
      if (f % 10 == 0) paths[a].push_back(root);
      if (f == 0) keep_out.push_back({root, 0.6});  // props never start inside a walker
    }
    add_actor_colliders(scene, hulls, track);
  }

  ScatterRequest scatter;
  scatter.seed = 3;
  scatter.region_min = {-5, -5};
  scatter.region_max = {5, 5};
  scatter.paths = paths;
  scatter.on_paths = 12;
  scatter.keep_out = keep_out;
  std::vector<Shape> prop_shapes;
  for (int i = 0; i < props; ++i) {
    const Eigen::Vector3d half(shapes.between(0.05, 0.2), shapes.between(0.05, 0.2), shapes.between(0.05, 0.2));
    if (i % 3 == 0) {
      prop_shapes.push_back(Shape::box(half));
    } else if (i % 3 == 1) {
      prop_shapes.push_back(Shape::hull(icosahedron(half.x() + 0.05)));
    } else {
      std::vector<Eigen::Vector3d> wedge;
      for (int c = 0; c < 6; ++c) wedge.emplace_back(c & 1 ? half.x() : -half.x(), c & 2 ? half.y() : -half.y(), c & 4 ? half.z() : -half.z());
      prop_shapes.push_back(Shape::hull(wedge));
    }
    scatter.footprint_radii.push_back(i % 3 == 1 ? half.x() + 0.05 : half.head<2>().norm());
  }
  const auto placed = scatter_props(scatter);
  std::vector<double> masses;
  for (int i = 0; i < props; ++i) {
    DynamicProp prop;
    prop.shape = prop_shapes[i];
    prop.mass = 0.5 + 4 * scatter.footprint_radii[i];
    prop.pose.rotation = Eigen::AngleAxisd(placed[i].yaw, Eigen::Vector3d::UnitZ());
    double low = INFINITY;
    const auto corners = prop.shape.kind == Shape::Kind::box ? std::vector<Eigen::Vector3d>{} : prop.shape.parts[0];
    if (prop.shape.kind == Shape::Kind::box) low = -prop.shape.half_extents.z();
    for (const auto& c : corners) low = std::min(low, (prop.pose.rotation * c).z());
    prop.pose.position = Eigen::Vector3d(placed[i].position.x(), placed[i].position.y(), 0.01 - low);
    masses.push_back(prop.mass);
    scene.props.push_back(prop);
  }
  ImpulseSampling kicks;
  kicks.seed = 3;
  kicks.rate = 0.05;
  kicks.lever_arm = 0.05;
  scene.impulses = sample_impulses(kicks, masses, (frames - 1) / scene.fps);

  const int substeps = substeps_per_frame(scene.fps, scene.min_substep_rate);
  std::vector<Row> rows;
  for (int iterations : {10, 50}) {
    scene.solver_iterations = iterations;
    Row row;
    row.iterations = iterations;
    const auto start = std::chrono::steady_clock::now();
    const PhysicsModel model(scene);
    const auto built = std::chrono::steady_clock::now();
    const std::clock_t cpu_start = std::clock();
    const PropMotion motion = simulate(model);
    row.simulate_cpu_s = static_cast<double>(std::clock() - cpu_start) / CLOCKS_PER_SEC;
    const auto done = std::chrono::steady_clock::now();
    row.build_s = std::chrono::duration<double>(built - start).count();
    row.simulate_s = std::chrono::duration<double>(done - built).count();
    for (const auto& report : motion.reports) {
      row.top_speed = std::max(row.top_speed, report.top_speed);
      row.deepest = std::max(row.deepest, report.deepest_penetration);
      row.overlap = std::max(row.overlap, report.deepest_prop_overlap);
      row.events += report.contact_events;
    }
    rows.push_back(row);
  }

  std::printf("%d props, %d actors x 20 bone colliders (%zu colliders), %zu kicks, %d frames at 30 fps, %d substeps per frame\n\n", props, actors,
              scene.colliders.size(), scene.impulses.size(), frames, substeps);
  std::printf("| solver iterations | build model (ms) | simulate, wall (s) | CPU (s) | CPU per frame (ms) | CPU per substep (us) | top speed (m/s) | deepest contact (mm) | deepest prop overlap (mm) | contact events |\n");
  std::printf("|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
  for (const Row& row : rows)
    std::printf("| %d | %.1f | %.2f | %.2f | %.3f | %.1f | %.2f | %.1f | %.1f | %lld |\n", row.iterations, 1e3 * row.build_s, row.simulate_s,
                row.simulate_cpu_s, 1e3 * row.simulate_cpu_s / (frames - 1), 1e6 * row.simulate_cpu_s / ((frames - 1) * substeps), row.top_speed, 1e3 * row.deepest, 1e3 * row.overlap,
                row.events);
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  std::printf("\nmachine: %s, %u cores, one thread used; peak RSS %.0f MiB\n", odyssey::bench::cpu_model().c_str(), std::thread::hardware_concurrency(),
              usage.ru_maxrss / 1024.0);
  return 0;
}
