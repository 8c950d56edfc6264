// GCC 12 reports -Wmaybe-uninitialized inside its own AVX-512 intrinsics when Eigen's matrix
// products (TinySolver's J^T J) are inlined here (GCC bug 105593, fixed in GCC 13); the
// diagnostic is tied to where the intrinsics are first included, so it is silenced for those
// headers only, as in skeleton/body_model.cpp.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#include <Eigen/Core>
#pragma GCC diagnostic pop

#include "retarget/refine.h"

#include <ceres/ceres.h>
#include <ceres/tiny_solver.h>
#include <ceres/tiny_solver_autodiff_function.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <exception>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>
#include <type_traits>
#include <utility>
#include <vector>

#include "retarget/refine_model.h"

namespace odyssey::retarget {

namespace refinement {
namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

// The unit quaternion of the rotation vector x, (cos(|x|/2), sin(|x|/2) x / |x|). Below 1e-10 rad
// the expansion (1 - |x|^2/8, x/2) is exact to double precision and has the right derivatives at
// x = 0, where the closed form divides 0 by 0.
template <class T>
Eigen::Quaternion<T> rotation_from_vector(const T* x) {
  using std::cos;
  using std::sin;
  using std::sqrt;
  const T angle_squared = x[0] * x[0] + x[1] * x[1] + x[2] * x[2];
  if (angle_squared > T(1e-20)) {
    const T angle = sqrt(angle_squared);
    const T k = sin(angle / 2.0) / angle;
    return Eigen::Quaternion<T>(cos(angle / 2.0), k * x[0], k * x[1], k * x[2]);
  }
  return Eigen::Quaternion<T>(T(1.0) - angle_squared / 8.0, x[0] / 2.0, x[1] / 2.0, x[2] / 2.0);
}

// The LimbWork of the scalar type a cost is evaluated with.
template <class Jet>
struct LimbWorkPair {
  LimbWork<double> plain;
  LimbWork<Jet> jet;
  explicit LimbWorkPair(const Limb& limb) : plain(limb), jet(limb) {}
  template <class T>
  LimbWork<T>& get() {
    if constexpr (std::is_same_v<T, double>) {
      return plain;
    } else {
      return jet;
    }
  }
};

// Balanced: one limb of one frame. Unknowns x: a rotation vector per owned slot, the slot's
// rotation being q0 q(x_s) with q0 its starting value (a chart of the unit quaternions at q0, as
// EigenQuaternionManifold's Plus is, turned in the joint's frame rather than its parent's), then,
// when the limb moves the pelvis, dp's change from its starting value and the pelvis's turn as
// turn0 q(x) likewise. Residuals: limb_residuals.
class LimbSolver {
 public:
  virtual ~LimbSolver() = default;
  // Solves the limb in `frame` (filled from `pose`) and writes its unknowns into `pose`; returns
  // the solver's iterations.
  virtual int solve(const LimbFrame& frame, FramePose& pose) = 0;
};

template <int kParameters>
class TinyLimbSolver final : public LimbSolver {
 public:
  TinyLimbSolver(const Limb& limb, const RefineWeights& weights, int max_iterations)
      : cost_(limb, weights), function_(cost_) {
    solver_.options.max_num_iterations = max_iterations;
    solver_.options.gradient_tolerance = 1e-12;
    solver_.options.parameter_tolerance = 1e-7;
    solver_.options.function_tolerance = 1e-14;
  }
  TinyLimbSolver(const TinyLimbSolver&) = delete;
  TinyLimbSolver& operator=(const TinyLimbSolver&) = delete;

  int solve(const LimbFrame& frame, FramePose& pose) override {
    cost_.frame = &frame;
    // What the evaluations leave alone is cast once per frame; they set the owned slots and dp.
    cost_.work.plain.load(frame);
    cost_.work.jet.load(frame);
    typename Solver::Parameters x = Solver::Parameters::Zero();
    solver_.Solve(function_, &x);
    const Limb& limb = cost_.limb;
    for (int s = 0; s < limb.owned; ++s) {
      pose.rotation[limb.slots[s]] = (frame.slot_value[s] * rotation_from_vector(x.data() + 3 * s)).normalized();
    }
    if (limb.moves_pelvis) {
      pose.pelvis_offset = frame.pelvis_offset + x.template segment<3>(3 * limb.owned);
      pose.pelvis_turn = (frame.pelvis_turn * rotation_from_vector(x.data() + 3 * limb.owned + 3)).normalized();
    }
    return solver_.summary.iterations;
  }

 private:
  using Jet = ceres::Jet<double, kParameters>;
  struct Cost {
    const Limb& limb;
    const RefineWeights& weights;
    const LimbFrame* frame = nullptr;
    mutable LimbWorkPair<Jet> work;

    Cost(const Limb& limb, const RefineWeights& weights) : limb(limb), weights(weights), work(limb) {}
    int NumResiduals() const { return limb.residual_count(); }

    template <class T>
    bool operator()(const T* x, T* residual) const {
      LimbWork<T>& w = work.template get<T>();
      for (int s = 0; s < limb.owned; ++s) w.slot(s) = frame->slot_value[s].template cast<T>() * rotation_from_vector(x + 3 * s);
      Vector3<T> offset = frame->pelvis_offset.template cast<T>();
      Eigen::Quaternion<T> turn = frame->pelvis_turn.template cast<T>();
      if (limb.moves_pelvis) {
        offset += Eigen::Map<const Vector3<T>>(x + 3 * limb.owned);
        turn = turn * rotation_from_vector(x + 3 * limb.owned + 3);
      }
      limb_residuals(limb, weights, *frame, offset, turn, w, residual);
      return true;
    }
  };
  using Function = ceres::TinySolverAutoDiffFunction<Cost, Eigen::Dynamic, kParameters>;
  using Solver = ceres::TinySolver<Function>;

  Cost cost_;
  Function function_;
  Solver solver_;
};

std::unique_ptr<LimbSolver> make_limb_solver(const Limb& limb, const RefineWeights& weights, int max_iterations) {
  switch (limb.parameter_count()) {
    case 3: return std::make_unique<TinyLimbSolver<3>>(limb, weights, max_iterations);
    case 6: return std::make_unique<TinyLimbSolver<6>>(limb, weights, max_iterations);
    case 9: return std::make_unique<TinyLimbSolver<9>>(limb, weights, max_iterations);
    case 12: return std::make_unique<TinyLimbSolver<12>>(limb, weights, max_iterations);
    case 15: return std::make_unique<TinyLimbSolver<15>>(limb, weights, max_iterations);
    case 18: return std::make_unique<TinyLimbSolver<18>>(limb, weights, max_iterations);
    case 21: return std::make_unique<TinyLimbSolver<21>>(limb, weights, max_iterations);
    case 24: return std::make_unique<TinyLimbSolver<24>>(limb, weights, max_iterations);
    default:
      throw std::invalid_argument("the " + limb.name + " has " + std::to_string(limb.parameter_count()) +
                                  " unknowns; refinement supports 3 to 24 a limb");
  }
}

// Accurate: one limb of one frame of a span, over Ceres parameter blocks: dp (3) and the pelvis's
// turn (a unit quaternion, x, y, z, w) when the limb moves the pelvis, then one unit quaternion per
// owned slot (held slots keep the frame's value). Derivatives are taken 16 at a time (the lower
// body's 3 + 4 + 6 x 4 parameters in two passes).
constexpr int kSpanStride = 16;

class SpanLimbCost {
 public:
  SpanLimbCost(const Limb& limb, const RefineWeights& weights, const LimbFrame& frame)
      : limb_(limb), weights_(weights), frame_(frame), work_(limb) {
    work_.plain.load(frame);
    work_.jet.load(frame);
  }

  template <class T>
  bool operator()(T const* const* parameters, T* residual) const {
    LimbWork<T>& w = work_.template get<T>();
    int block = 0;
    Vector3<T> offset = frame_.pelvis_offset.template cast<T>();
    Eigen::Quaternion<T> turn = frame_.pelvis_turn.template cast<T>();
    if (limb_.moves_pelvis) {
      offset = Eigen::Map<const Vector3<T>>(parameters[block++]);
      turn = Eigen::Map<const Eigen::Quaternion<T>>(parameters[block++]);
    }
    for (int s = 0; s < limb_.owned; ++s) w.slot(s) = Eigen::Map<const Eigen::Quaternion<T>>(parameters[block++]);
    limb_residuals(limb_, weights_, frame_, offset, turn, w, residual);
    return true;
  }

 private:
  const Limb& limb_;
  const RefineWeights& weights_;
  const LimbFrame& frame_;
  mutable LimbWorkPair<ceres::Jet<double, kSpanStride>> work_;
};

// w fps^2 (c(t+1) - 2 c(t) + c(t-1)), c(t) = q_ref(t)^-1 q(t) the correction of one joint's local
// rotation (quaternion components; for the small corrections here about half its angular
// acceleration in rad/s^2). The reference itself is not smoothed: its noise is the performer's.
struct CorrectionAcceleration {
  std::array<Eigen::Quaterniond, 3> reference_inverse;  // q_ref^-1 at t-1, t, t+1
  double weight;                                        // w_smooth fps^2

  template <class T>
  bool operator()(const T* before, const T* now, const T* after, T* residual) const {
    const T* q[3] = {before, now, after};
    Eigen::Matrix<T, 4, 1> c[3];
    for (int k = 0; k < 3; ++k) {
      c[k] = (reference_inverse[k].template cast<T>() * Eigen::Map<const Eigen::Quaternion<T>>(q[k])).coeffs();
    }
    for (int i = 0; i < 4; ++i) residual[i] = T(weight) * (c[2][i] - 2.0 * c[1][i] + c[0][i]);
    return true;
  }
  static ceres::CostFunction* Create(const std::array<Eigen::Quaterniond, 3>& reference, double weight) {
    return new ceres::AutoDiffCostFunction<CorrectionAcceleration, 4, 4, 4, 4>(new CorrectionAcceleration{
        {reference[0].conjugate(), reference[1].conjugate(), reference[2].conjugate()}, weight});
  }
};

// w L fps^2 (dp(t+1) - 2 dp(t) + dp(t-1)): the pelvis correction's acceleration, in m/s^2 of a
// 1.7 m character (L = RefineModel::length_scale).
struct PelvisAcceleration {
  double weight;  // w_pelvis_smooth L fps^2

  template <class T>
  bool operator()(const T* before, const T* now, const T* after, T* residual) const {
    for (int i = 0; i < 3; ++i) residual[i] = T(weight) * (after[i] - 2.0 * now[i] + before[i]);
    return true;
  }
  static ceres::CostFunction* Create(double weight) {
    return new ceres::AutoDiffCostFunction<PelvisAcceleration, 3, 3, 3, 3>(new PelvisAcceleration{weight});
  }
};

// Runs work(window, state) for every window on up to `threads` threads, each with its own state
// from make_state(). Windows are taken in any order; the first exception is rethrown once all
// threads have stopped.
template <class MakeState, class Work>
void for_each_window(int windows, int threads, MakeState make_state, Work work) {
  std::atomic<int> next{0};
  std::exception_ptr failure;
  std::mutex failure_mutex;
  const auto loop = [&] {
    try {
      auto state = make_state();
      for (int window = next++; window < windows; window = next++) work(window, state);
    } catch (...) {
      const std::lock_guard<std::mutex> lock(failure_mutex);
      if (!failure) failure = std::current_exception();
      next = windows;
    }
  };
  std::vector<std::thread> pool;
  for (int t = 1; t < std::min(threads, windows); ++t) pool.emplace_back(loop);
  loop();
  for (std::thread& thread : pool) thread.join();
  if (failure) std::rethrow_exception(failure);
}

// Everything both passes read, and the solution of the balanced pass: per frame, the unknown
// joints' local rotations and dp.
struct Refinement {
  const RefineModel& model;
  const Clip& reference;
  const Clip& source;
  const Feet& source_feet;
  const MotionPlan& plan;
  const RefineOptions& options;
  std::vector<Eigen::Quaterniond> solved_rotation;  // [frame * unknowns + u]
  std::vector<Eigen::Vector3d> solved_offset;       // [frame]
  std::vector<Eigen::Quaterniond> solved_turn;      // [frame]

  int frames() const { return reference.frame_count(); }
  int unknowns() const { return static_cast<int>(model.unknown_joints.size()); }
};

// Balanced: windows of consecutive frames, each frame warm-started from the one before.
constexpr double kLagLeadSeconds = 0.25;
long balanced_pass(Refinement& refinement, Clip& out, int& window_count) {
  const RefineModel& model = refinement.model;
  const RefineOptions& options = refinement.options;
  const int frames = refinement.frames();
  const int unknowns = refinement.unknowns();
  const int size = options.window_frames;
  window_count = (frames + size - 1) / size;
  std::vector<long> iterations(window_count, 0);
  struct State {
    FrameBuilder builder;
    std::vector<std::unique_ptr<LimbSolver>> solvers;
    std::vector<LimbFrame> limb_frames;
    FramePose pose;
    std::vector<Eigen::Quaterniond> previous_reference;
  };
  const auto make_state = [&] {
    State state{FrameBuilder(model, refinement.reference, refinement.source, refinement.source_feet), {},
                std::vector<LimbFrame>(model.limbs.size()), {}, std::vector<Eigen::Quaterniond>(unknowns)};
    for (const Limb& limb : model.limbs) state.solvers.push_back(make_limb_solver(limb, options.weights, options.max_iterations));
    return state;
  };
  // With the lag, each window first solves the frames of the lead before it and discards them, so
  // that its first frame starts from a settled lag, not from a reset (refine.h).
  const int lead = options.weights.pelvis_lag > 0 ? static_cast<int>(std::lround(kLagLeadSeconds * refinement.reference.fps)) : 0;
  const auto work = [&](int window, State& state) {
    const int first = window * size, end = std::min(frames, first + size), start = std::max(0, first - lead);
    long window_iterations = 0;  // counted here, stored once: neighbouring counters share a cache line
    Eigen::Vector3d solved_offset = Eigen::Vector3d::Zero();  // dp of the frame solved before
    for (int f = start; f < end; ++f) {
      state.builder.load(f);
      const std::vector<Eigen::Vector3d>& pelvis_plan = refinement.plan.pelvis_offset;
      if (f == start || !options.warm_start) {
        state.builder.reference_pose(state.pose);
        state.pose.pelvis_offset = pelvis_plan[f];
      } else {
        // The previous frame's corrections, q_ref^-1 q and dp - dp_plan, carried onto this frame.
        for (int u = 0; u < unknowns; ++u) {
          const Eigen::Quaterniond correction = state.previous_reference[u].conjugate() * state.pose.rotation[u];
          state.pose.rotation[u] = (state.builder.reference_local(model.unknown_joints[u]) * correction).normalized();
        }
        state.pose.pelvis_offset += pelvis_plan[f] - pelvis_plan[f - 1];
      }
      // The lag term holds dp - dp_plan near the previous frame's (refine.h).
      const double lag = f == start ? 0.0 : options.weights.pelvis_lag * model.length_scale * std::sqrt(state.builder.fps());
      const Eigen::Vector3d previous =
          f == start ? pelvis_plan[f] : Eigen::Vector3d(solved_offset + pelvis_plan[f] - pelvis_plan[f - 1]);
      for (std::size_t l = 0; l < model.limbs.size(); ++l) {
        state.builder.fill(model.limbs[l], state.pose, refinement.plan, state.limb_frames[l]);
        state.limb_frames[l].pelvis_previous = previous;
        state.limb_frames[l].pelvis_lag = lag;
        window_iterations += state.solvers[l]->solve(state.limb_frames[l], state.pose);
      }
      solved_offset = state.pose.pelvis_offset;
      for (int u = 0; u < unknowns; ++u) state.previous_reference[u] = state.builder.reference_local(model.unknown_joints[u]);
      if (f < first) continue;  // the lead: another window's frame
      state.builder.write(state.pose, refinement.plan, out);
      for (int u = 0; u < unknowns; ++u) refinement.solved_rotation[std::size_t(f) * unknowns + u] = state.pose.rotation[u];
      refinement.solved_offset[f] = state.pose.pelvis_offset;
      refinement.solved_turn[f] = state.pose.pelvis_turn;
    }
    iterations[window] = window_iterations;
  };
  for_each_window(window_count, options.threads, make_state, work);
  long total = 0;
  for (long count : iterations) total += count;
  return total;
}

// Accurate: the lower body (the limb that moves the pelvis) as a space-time problem, started from
// the balanced solution: every frame's dp, pelvis turn and leg rotations of a span of `span_frames`
// frames in one Ceres problem, with the limb residuals and the smoothness terms. A clip of up to
// `span_frames` frames is one problem. A longer one is solved span after span: each span also
// solves the `span_lookahead` frames after it (discarded, so that where a span is cut does not
// shape its last frames; the next span solves them again), and holds the two frames before it at
// the previous span's solution, so that the accelerations across the cut are terms of its problem.
// The result is smooth at a cut because the problem says so; nothing is cross-faded. The upper body
// keeps its balanced solution, turned with the pelvis so that it keeps its world rotations (run()):
// its residuals read neither dp nor the legs, and its corrections (end effectors against
// directions, no contacts) change smoothly.
class SpaceTimePass {
 public:
  SpaceTimePass(const Refinement& refinement, const Limb& limb)
      : refinement_(refinement),
        options_(refinement.options),
        limb_(limb),
        frames_(refinement.frames()),
        builder_(refinement.model, refinement.reference, refinement.source, refinement.source_feet),
        rotation_jump_(options_.weights.smoothness * options_.smoothness_limit / 2),
        pelvis_jump_(options_.weights.pelvis_smoothness * options_.pelvis_smoothness_limit) {
    solver_options_.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
    solver_options_.max_num_iterations = options_.span_iterations;
    solver_options_.function_tolerance = 1e-8;
    solver_options_.gradient_tolerance = 1e-12;
    solver_options_.parameter_tolerance = 1e-8;
    // One thread: Ceres sums costs and gradients per thread in whatever order its threads take
    // the blocks, which would make the result depend on the thread count and the scheduling.
    solver_options_.num_threads = 1;
    solver_options_.logging_type = ceres::SILENT;
    const int owned = limb_.owned;
    // The unknowns the limb does not own that hang from the pelvis through known joints only.
    const RefineModel& model = refinement.model;
    for (std::size_t u = 0; u < model.unknown_joints.size(); ++u) {
      if (std::find(limb.slots.begin(), limb.slots.begin() + owned, int(u)) != limb.slots.begin() + owned) continue;
      int j = model.kinematics.parents[model.unknown_joints[u]];
      while (j >= 0 && j != model.pelvis && model.unknown_of[j] < 0) j = model.kinematics.parents[j];
      if (j == model.pelvis) upper_body_roots_.push_back(int(u));
    }
    rotation_.resize(std::size_t(frames_) * owned);
    offset_.resize(frames_);
    turn_.resize(frames_);
    for (int f = 0; f < frames_; ++f) {
      balanced_pose(f, pose_);
      for (int s = 0; s < owned; ++s) slot(f, s) = pose_.rotation[limb_.slots[s]];
      offset_[f] = pose_.pelvis_offset;
      turn_[f] = pose_.pelvis_turn;
    }
  }

  // Solves every span in turn and writes every frame into `out`; returns the solver iterations.
  long run(Clip& out, int& span_count) {
    const int size = options_.span_frames;
    span_count = (frames_ + size - 1) / size;
    long iterations = 0;
    for (int span = 0; span < span_count; ++span) {
      const int first = span * size;
      iterations += solve(first, std::min(frames_, first + size + options_.span_lookahead));
    }
    const RefineModel& model = refinement_.model;
    for (int f = 0; f < frames_; ++f) {
      builder_.load(f);
      balanced_pose(f, pose_);
      for (int s = 0; s < limb_.owned; ++s) pose_.rotation[limb_.slots[s]] = slot(f, s).normalized();
      pose_.pelvis_offset = offset_[f];
      // The upper body keeps its world rotations from the balanced pass: with the pelvis's turn
      // changed from t0 to t1, a joint j hanging from it through known joints (its parent p at
      // W(p) = R_pelvis t C, C = R_pelvis^-1 W_ref(p)) keeps W(p) L when its local rotation
      // becomes C^-1 t1^-1 t0 C L. What is solved above it is then as it was, moved only by the
      // pelvis's offsets turning.
      const Eigen::Quaterniond before = pose_.pelvis_turn;
      pose_.pelvis_turn = turn_[f].normalized();
      const Eigen::Quaterniond change = pose_.pelvis_turn.conjugate() * before;
      for (int u : upper_body_roots_) {
        const int parent = model.kinematics.parents[model.unknown_joints[u]];
        const Eigen::Quaterniond c = builder_.reference_rotation(model.pelvis).conjugate() * builder_.reference_rotation(parent);
        pose_.rotation[u] = (c.conjugate() * change * c * pose_.rotation[u]).normalized();
      }
      builder_.write(pose_, refinement_.plan, out);
    }
    return iterations;
  }

 private:
  Eigen::Quaterniond& slot(int f, int s) { return rotation_[std::size_t(f) * limb_.owned + s]; }

  // The balanced pass's solution of frame f.
  void balanced_pose(int f, FramePose& pose) const {
    const int unknowns = refinement_.unknowns();
    pose.rotation.assign(refinement_.solved_rotation.begin() + std::ptrdiff_t(f) * unknowns,
                         refinement_.solved_rotation.begin() + std::ptrdiff_t(f + 1) * unknowns);
    pose.pelvis_offset = refinement_.solved_offset[f];
    pose.pelvis_turn = refinement_.solved_turn[f];
  }

  // Solves frames [first, end) with the two before `first` held; returns the iterations.
  long solve(int first, int end) {
    const int count = end - first;
    limb_frames_.resize(count);
    for (int f = first; f < end; ++f) {
      builder_.load(f);
      balanced_pose(f, pose_);
      for (int s = 0; s < limb_.owned; ++s) pose_.rotation[limb_.slots[s]] = slot(f, s);
      pose_.pelvis_offset = offset_[f];
      pose_.pelvis_turn = turn_[f];
      builder_.fill(limb_, pose_, refinement_.plan, limb_frames_[f - first]);
    }
    ceres::Problem::Options problem_options;
    problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    ceres::Problem problem(problem_options);
    add_limb_costs(problem, first, end);
    add_smoothness(problem, std::max(0, first - 2), end);
    // The held frames enter only through the smoothness terms: a block no term reads (a weight
    // of 0) is not in the problem.
    const auto frame_blocks = [&](int f) {
      std::vector<double*> blocks = {offset_[f].data(), turn_[f].coeffs().data()};
      for (int s = 0; s < limb_.owned; ++s) blocks.push_back(slot(f, s).coeffs().data());
      std::erase_if(blocks, [&](double* block) { return !problem.HasParameterBlock(block); });
      return blocks;
    };
    for (int f = std::max(0, first - 2); f < first; ++f) {
      for (double* block : frame_blocks(f)) problem.SetParameterBlockConstant(block);
    }
    // Eliminated frame by frame, in time order: the normal equations are banded in time (the
    // second differences reach two frames), so this ordering fills nothing outside the band.
    // Left to choose (AMD), SuiteSparse took 2.5-3 times as long per factorisation on the CMU jump.
    ceres::Solver::Options options = solver_options_;
    auto ordering = std::make_shared<ceres::ParameterBlockOrdering>();
    for (int f = std::max(0, first - 2); f < end; ++f) {
      for (double* block : frame_blocks(f)) ordering->AddElementToGroup(block, f);
    }
    options.linear_solver_ordering = ordering;
    ceres::Solver::Summary summary;
    ceres::Solve(options, &problem, &summary);
    return static_cast<long>(summary.iterations.size());
  }

  // Every frame's limb residuals over its dp and owned slots.
  void add_limb_costs(ceres::Problem& problem, int first, int end) {
    const int owned = limb_.owned;
    std::vector<double*> blocks;
    for (int f = first; f < end; ++f) {
      auto* cost = new ceres::DynamicAutoDiffCostFunction<SpanLimbCost, kSpanStride>(
          new SpanLimbCost(limb_, options_.weights, limb_frames_[f - first]));
      blocks.assign({offset_[f].data(), turn_[f].coeffs().data()});
      cost->AddParameterBlock(3);
      cost->AddParameterBlock(4);
      for (int s = 0; s < owned; ++s) {
        cost->AddParameterBlock(4);
        blocks.push_back(slot(f, s).coeffs().data());
      }
      cost->SetNumResiduals(limb_.residual_count());
      problem.AddResidualBlock(cost, nullptr, blocks);
      problem.SetManifold(turn_[f].coeffs().data(), &manifold_);
      for (int s = 0; s < owned; ++s) problem.SetManifold(slot(f, s).coeffs().data(), &manifold_);
    }
  }

  // The second differences about the frames (first, end - 1) (refine.h), through Cauchy losses
  // rho(s) = b^2 log(1 + s / b^2): quadratic below b, where they smooth, and nearly flat far above
  // it, so a genuine jump (the T-pose reference frame that opens CMU files) is left alone instead
  // of being smeared over its neighbours. The residuals at the limits: w alpha / 2 (Delta^2 c is
  // about alpha / 2 / fps^2), and w a for the pelvis (its residuals are in 1.7 m units, as the
  // limit).
  void add_smoothness(ceres::Problem& problem, int first, int end) {
    const RefineWeights& weights = options_.weights;
    const Clip& reference = refinement_.reference;
    const double fps_squared = reference.fps * reference.fps;
    for (int f = first + 1; f + 1 < end; ++f) {
      if (weights.smoothness > 0) {
        for (int s = 0; s < limb_.owned; ++s) {
          const int joint = refinement_.model.unknown_joints[limb_.slots[s]];
          const std::array<Eigen::Quaterniond, 3> around = {reference.rotation(f - 1, joint), reference.rotation(f, joint),
                                                            reference.rotation(f + 1, joint)};
          problem.AddResidualBlock(CorrectionAcceleration::Create(around, weights.smoothness * fps_squared), &rotation_jump_,
                                   slot(f - 1, s).coeffs().data(), slot(f, s).coeffs().data(), slot(f + 1, s).coeffs().data());
        }
        // The pelvis's turn is a correction already: its reference is the identity.
        const Eigen::Quaterniond none = Eigen::Quaterniond::Identity();
        problem.AddResidualBlock(CorrectionAcceleration::Create({none, none, none}, weights.smoothness * fps_squared), &rotation_jump_,
                                 turn_[f - 1].coeffs().data(), turn_[f].coeffs().data(), turn_[f + 1].coeffs().data());
      }
      if (weights.pelvis_smoothness > 0) {
        const double weight = refinement_.model.length_scale * weights.pelvis_smoothness * fps_squared;
        problem.AddResidualBlock(PelvisAcceleration::Create(weight), &pelvis_jump_, offset_[f - 1].data(), offset_[f].data(),
                                 offset_[f + 1].data());
      }
    }
  }

  const Refinement& refinement_;
  const RefineOptions& options_;
  const Limb& limb_;
  const int frames_;
  FrameBuilder builder_;
  ceres::EigenQuaternionManifold manifold_;
  ceres::CauchyLoss rotation_jump_, pelvis_jump_;
  ceres::Solver::Options solver_options_;
  std::vector<Eigen::Quaterniond> rotation_;  // [frame * owned + slot]: the solution so far
  std::vector<Eigen::Vector3d> offset_;       // [frame]
  std::vector<Eigen::Quaterniond> turn_;      // [frame]
  std::vector<LimbFrame> limb_frames_;        // [frame - first] of the span being solved
  std::vector<int> upper_body_roots_;         // unknowns
  FramePose pose_;
};

// The accurate pass over the limb that moves the pelvis (none: nothing to do); sets the span
// count and returns the solver iterations.
long accurate_pass(const Refinement& refinement, Clip& out, int& span_count) {
  const RefineModel& model = refinement.model;
  const auto lower = std::find_if(model.limbs.begin(), model.limbs.end(), [](const Limb& limb) { return limb.moves_pelvis; });
  span_count = 0;
  if (lower == model.limbs.end()) return 0;
  SpaceTimePass pass(refinement, *lower);
  return pass.run(out, span_count);
}

void check_options(const RefineOptions& options) {
  const auto fail = [](const std::string& what) { throw std::invalid_argument("refine options: " + what); };
  if (options.threads < 1) fail("threads must be at least 1, got " + std::to_string(options.threads));
  if (options.window_frames < 1) fail("window_frames must be at least 1, got " + std::to_string(options.window_frames));
  if (options.span_frames < 1) fail("span_frames must be at least 1, got " + std::to_string(options.span_frames));
  if (options.span_lookahead < 0) fail("span_lookahead must not be negative, got " + std::to_string(options.span_lookahead));
  if (!(options.smoothness_limit > 0) || !(options.pelvis_smoothness_limit > 0)) fail("smoothness limits must be positive");
  if (options.max_iterations < 1 || options.span_iterations < 1) {
    fail("iteration limits must be at least 1, got " + std::to_string(options.max_iterations) + " and " +
         std::to_string(options.span_iterations));
  }
  if (!(options.contact_blend_seconds >= 0) || !std::isfinite(options.contact_blend_seconds)) {
    fail("contact_blend_seconds must be a non-negative number, got " + std::to_string(options.contact_blend_seconds));
  }
  if (options.contact_lift && (!(*options.contact_lift >= 0) || !std::isfinite(*options.contact_lift))) {
    fail("contact_lift must be a non-negative number of metres, got " + std::to_string(*options.contact_lift));
  }
  for (const RefineWeightName& weight : refine_weight_names()) {
    const double value = options.weights.*(weight.weight);
    if (!(value >= 0) || !std::isfinite(value)) {
      fail(std::string("weight ") + weight.name + " must be a non-negative number, got " + std::to_string(value));
    }
  }
}

}  // namespace
}  // namespace refinement

std::optional<Quality> parse_quality(std::string_view text) {
  for (Quality quality : {Quality::fast, Quality::balanced, Quality::accurate}) {
    if (text == quality_name(quality)) return quality;
  }
  return std::nullopt;
}

const char* quality_name(Quality quality) {
  switch (quality) {
    case Quality::fast: return "fast";
    case Quality::balanced: return "balanced";
    case Quality::accurate: return "accurate";
  }
  return "unknown";
}

RefineOptions default_refine_options(Quality quality) {
  RefineOptions options;
  options.quality = quality;
  if (quality == Quality::accurate) {
    options.weights.foot_contact = 12;
    options.weights.smoothness = 0.0001;
    options.weights.pelvis_smoothness = 0.01;
    options.weights.pelvis_lag = 0;
  }
  return options;
}

RefineSummary refine(RetargetResult& result, const Clip& source, const RefineOptions& options) {
  using namespace refinement;
  const Clock::time_point start = Clock::now();
  check_options(options);
  RefineSummary summary;
  summary.frames = result.transfer.clip.frame_count();
  if (options.quality == Quality::fast) {
    result.report.quality = quality_name(options.quality);
    summary.seconds = seconds_since(start);
    return summary;
  }
  const RetargetRig& rig = result.rig;
  if (source.skeleton.names() != rig.source.names() || source.skeleton.parents() != rig.source.parents()) {
    throw std::invalid_argument("refine: the source clip's skeleton is not the one the result was retargeted from");
  }
  if (source.frame_count() != summary.frames || result.contacts.frame_count() != summary.frames) {
    throw std::invalid_argument("refine: the source has " + std::to_string(source.frame_count()) + " frames, the result " +
                                std::to_string(summary.frames) + " and its contacts " + std::to_string(result.contacts.frame_count()));
  }

  // The result is replaced only once everything has succeeded.
  const RefineModel model = build_refine_model(result);
  summary.unknown_joints = static_cast<int>(model.unknown_joints.size());
  const Clip& reference = result.transfer.clip;
  const int blend_frames = static_cast<int>(std::lround(options.contact_blend_seconds * reference.fps));
  FrameBuilder planner(model, reference, source, result.source_feet);
  const MotionPlan plan = plan_motion(model, planner, result.source_feet, result.contacts, blend_frames, options.fit_stride,
                                      options.contact_lift);
  summary.stride = plan.stride;
  summary.height = plan.height;
  const std::size_t frames = summary.frames;
  Refinement refinement{model,
                        reference,
                        source,
                        result.source_feet,
                        plan,
                        options,
                        std::vector<Eigen::Quaterniond>(frames * model.unknown_joints.size()),
                        std::vector<Eigen::Vector3d>(frames),
                        std::vector<Eigen::Quaterniond>(frames)};
  Clip out = reference;

  const Clock::time_point solve_start = Clock::now();
  summary.iterations = balanced_pass(refinement, out, summary.windows);
  if (options.quality == Quality::accurate) summary.iterations += accurate_pass(refinement, out, summary.spans);
  summary.solve_seconds = seconds_since(solve_start);
  out.make_signs_continuous();

  RetargetMetrics metrics = result_metrics(rig, source, result.source_feet, out, result.target_feet, result.contacts,
                                           result.report.settings.metric_thresholds);
  result.transfer.clip = std::move(out);
  result.report.result_metrics = std::move(metrics);
  result.report.quality = quality_name(options.quality);
  summary.seconds = seconds_since(start);
  return summary;
}

namespace {
constexpr RefineWeightName kRefineWeightNames[] = {
    {"bone_direction", &RefineWeights::bone_direction},
    {"end_effector", &RefineWeights::end_effector},
    {"foot_contact", &RefineWeights::foot_contact},
    {"floor", &RefineWeights::floor},
    {"pose", &RefineWeights::pose},
    {"pelvis", &RefineWeights::pelvis},
    {"pelvis_turn", &RefineWeights::pelvis_turn},
    {"smoothness", &RefineWeights::smoothness},
    {"pelvis_smoothness", &RefineWeights::pelvis_smoothness},
    {"pelvis_lag", &RefineWeights::pelvis_lag},
};
}  // namespace

std::span<const RefineWeightName> refine_weight_names() { return kRefineWeightNames; }

double* refine_weight(RefineWeights& weights, std::string_view name) {
  for (const RefineWeightName& entry : kRefineWeightNames) {
    if (name == entry.name) return &(weights.*(entry.weight));
  }
  return nullptr;
}

}  // namespace odyssey::retarget
